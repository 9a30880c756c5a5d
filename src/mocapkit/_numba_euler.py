"""The numba kernel behind :func:`mocapkit.rotations.continuous_euler` (see there for the rule it follows).

Choosing a frame's Euler triple needs the triple just chosen for the frame
before it, so the pass over frames is a true sequential loop; it runs here
on scalars, one compiled call for a whole group of joints.
``tests/test_rotations.py`` checks it against a slow pure-Python reference of
the same rule.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._numba_quaternions import qmul

__all__ = ["continuous_kernel"]


@numba.njit(cache=True, inline="always")
def _wrap_to(v, ref, period):
    """``v`` plus the multiple of ``period`` that brings it nearest ``ref`` (``v`` itself, same bits, when none)."""
    k = math.floor((ref - v) / period + 0.5)
    return v + period * k if k != 0.0 else v


@numba.njit(cache=True, inline="always")
def _pick(a, ref, flip, period, out):
    """Write into ``out`` (n,) the triple equivalent to ``a`` (n,) nearest ``ref`` (n,) (sum of absolute
    differences): each angle moved by whole turns and, with ``flip`` (1: Tait-Bryan ``(x+h, h-y, z+h)``, 2: proper
    Euler ``(x+h, -y, z+h)``, h = half a turn), the other branch of the middle angle tried too; a tie keeps the
    branch ``a`` gives. Returns True when the other branch was chosen."""
    n = a.shape[0]
    cost = 0.0
    for i in range(n):
        v = _wrap_to(a[i], ref[i], period)
        out[i] = v
        cost += abs(v - ref[i])
    if flip == 0:
        return False
    h = 0.5 * period
    x = _wrap_to(a[0] + h, ref[0], period)
    y = _wrap_to((h - a[1]) if flip == 1 else -a[1], ref[1], period)
    z = _wrap_to(a[2] + h, ref[2], period)
    if abs(x - ref[0]) + abs(y - ref[1]) + abs(z - ref[2]) < cost:
        out[0] = x
        out[1] = y
        out[2] = z
        return True
    return False


@numba.njit(cache=True, inline="always")
def _dist(u, v):
    """Sum of absolute differences of two angle vectors (n,)."""
    s = 0.0
    for i in range(u.shape[0]):
        s += abs(u[i] - v[i])
    return s


@numba.njit(cache=True, inline="always")
def _quat(e, axes, intrinsic, to_rad):
    """The quaternion (w, x, y, z) of the 3 Euler angles ``e`` about ``axes`` (3,) (1 x, 2 y, 3 z), intrinsic
    (``R = R0 R1 R2``) or extrinsic (``R = R2 R1 R0``), angles times ``to_rad`` in radians."""
    w, x, y, z = 1.0, 0.0, 0.0, 0.0
    for t in range(3):
        i = t if intrinsic else 2 - t
        h = 0.5 * e[i] * to_rad
        c, s = math.cos(h), math.sin(h)
        b1 = s if axes[i] == 1 else 0.0
        b2 = s if axes[i] == 2 else 0.0
        b3 = s if axes[i] == 3 else 0.0
        w, x, y, z = qmul(w, x, y, z, c, b1, b2, b3)
    return w, x, y, z


@numba.njit(cache=True, inline="always")
def _far(ea, eb, axes, intrinsic, period, cos_half):
    """True when the rotations of Euler triples ``ea`` and ``eb`` (3,) are more than ``2 acos(cos_half)`` apart."""
    to_rad = 2.0 * math.pi / period
    a0, a1, a2, a3 = _quat(ea, axes, intrinsic, to_rad)
    b0, b1, b2, b3 = _quat(eb, axes, intrinsic, to_rad)
    return abs(a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3) < cos_half


@numba.njit(cache=True)
def _chain(col, rows, lo, hi, ref, step, flip, period, cos_half, axes, intrinsic, out):
    """Chain ``col[rows[lo..hi]]`` (inclusive) from ``ref`` (n,) in direction ``step`` (+1 from ``lo``, -1 from
    ``hi``): each row the triple nearest the one written before it, written into ``out`` (same rows). Where that
    is the other branch of the middle angle but the rotation steps farther than ``cos_half`` allows from the one
    before it (Euler order ``axes``, ``intrinsic``), only whole turns are chosen: the branch stays the one ``col``
    gives (nothing is continuous across such a step). The check runs only where the branch would change."""
    prev = ref.copy()
    t = lo if step > 0 else hi
    for _ in range(hi - lo + 1):
        r = rows[t]
        if _pick(col[r], prev, flip, period, out[r]) and _far(col[r], prev, axes, intrinsic, period, cos_half):
            _pick(col[r], prev, 0, period, out[r])
        prev[:] = out[r]
        t += step


@numba.njit(cache=True)
def continuous_kernel(a, fixed, start, flip, period, cos_half, axes, intrinsic):
    """Continuous Euler angles (F, K, n) from ``a`` (F, K, n), keeping the ``fixed`` (F, K) cells as given.

    ``axes`` (n,) (1 x, 2 y, 3 z) and ``intrinsic`` give the Euler order
    (read only when ``flip`` is not 0); ``cos_half`` the cosine of half the
    largest rotation step across which the branch of the middle angle is
    continued. Per column k, over its finite cells (a cell
    with a NaN angle is left as it is and skipped), each run of unfixed cells
    is chained: from the fixed cell before it (forward) and from the one
    after it (backward); with only one of them, from that one; with neither
    (no fixed cell in the column), forward from ``start[k]`` when finite,
    else from the run's first cell as given. With both, the run is written
    forward up to a split and backward from it, the split where the written
    curve's total variation (sum of absolute steps, fixed ends included) is
    least; among splits within 1e-9 of a turn of the least, the one nearest
    the middle (each cell following its nearer fixed cell, the earlier on a
    tie). When the two chains agree, as they do unless the fixed ends are on
    different branches, every split gives the same angles. ``period`` is 360
    (degrees) or 2 pi.
    """
    F, K, n = a.shape
    out = a.copy()
    fw = np.empty((F, n))
    bw = np.empty((F, n))
    rows = np.empty(F, dtype=np.int64)
    cum = np.empty(F + 1)
    cost = np.empty(F + 1)
    tol = 1e-9 * period
    for k in range(K):
        col = np.ascontiguousarray(a[:, k, :])  # (F, n), rows of one layout for the chains
        m = 0
        for f in range(F):
            ok = True
            for i in range(n):
                if math.isnan(col[f, i]):
                    ok = False
            if ok:
                rows[m] = f
                m += 1
        t = 0
        while t < m:
            if fixed[rows[t], k]:
                t += 1
                continue
            lo = t  # a run of unfixed cells rows[lo..hi]
            while t < m and not fixed[rows[t], k]:
                t += 1
            hi = t - 1
            left = lo > 0
            right = hi + 1 < m
            if not right:
                if left:
                    ref = col[rows[lo - 1]].copy()
                else:
                    ref = col[rows[lo]].copy()
                    given = True
                    for i in range(n):
                        if math.isnan(start[k, i]):
                            given = False
                    if given:
                        ref[:] = start[k]
                _chain(col, rows, lo, hi, ref, 1, flip, period, cos_half, axes, intrinsic, fw)
                for s in range(lo, hi + 1):
                    out[rows[s], k] = fw[rows[s]]
                continue
            _chain(col, rows, lo, hi, col[rows[hi + 1]], -1, flip, period, cos_half, axes, intrinsic, bw)
            if not left:
                for s in range(lo, hi + 1):
                    out[rows[s], k] = bw[rows[s]]
                continue
            _chain(col, rows, lo, hi, col[rows[lo - 1]], 1, flip, period, cos_half, axes, intrinsic, fw)
            # cum[i]: variation of the forward chain from the left fixed cell up to run cell lo + i - 1
            cum[0] = 0.0
            prev = col[rows[lo - 1]]
            for i in range(hi - lo + 1):
                cum[i + 1] = cum[i] + _dist(prev, fw[rows[lo + i]])
                prev = fw[rows[lo + i]]
            # split s (cells lo..s-1 forward, s..hi backward), s from hi + 1 down to lo; back: the backward chain's
            # variation from cell s to the right fixed cell
            back = 0.0
            nxt = col[rows[hi + 1]]
            least = np.inf
            for s in range(hi + 1, lo - 1, -1):
                if s <= hi:
                    back += _dist(bw[rows[s]], nxt)
                    nxt = bw[rows[s]]
                before = fw[rows[s - 1]] if s > lo else col[rows[lo - 1]]
                cost[s - lo] = cum[s - lo] + _dist(before, nxt) + back
                least = min(least, cost[s - lo])
            mid = lo  # the split where each cell follows its nearer fixed cell (the earlier on a tie)
            while mid <= hi and rows[mid] - rows[lo - 1] <= rows[hi + 1] - rows[mid]:
                mid += 1
            best = -1
            for s in range(lo, hi + 2):
                if cost[s - lo] <= least + tol and (best < 0 or abs(s - mid) < abs(best - mid)):
                    best = s
            for s in range(lo, hi + 1):
                out[rows[s], k] = fw[rows[s]] if s < best else bw[rows[s]]
    return out
