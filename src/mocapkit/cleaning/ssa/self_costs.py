"""The take's self pose-distance matrix (eq. 1 of Aristidou et al. 2018) without most of its ``acos`` calls.

The self-distance matrix of a 60 s take (1440 texture frames, 24 joints, 5
groups) takes 25 million joint terms ``acos(|q_a . q_b|)^2``, and ``acos``
was four fifths of its time. Here each term is first taken from a polynomial
instead (:func:`approx_half_angle_sq`: ``acos(d) = 2 asin(sqrt((1 - d) / 2))``,
and ``asin(s) / s`` a degree-16 polynomial in ``t = 1 - 2 d``, so no ``acos``
and no square root; the loops over a row's cells run in SIMD lanes), within a
relative :data:`TERM_RTOL` of the ``acos`` term (measured: 2.2e-15). A cell's
group sum (the robust sum of ``word_dtw``, ``drop`` largest terms left out)
then lies within ``DELTA_RTOL`` times its terms' total of the sum the exact
terms give (the robust sum moves by at most twice the terms' total error, and
each sum's round-off is below ``(m + 3)`` units of the last place of the
total). The matrix is float32: where both ends of that interval round to the
same float32, so does the exact sum, and that float32 is stored; otherwise
(about one cell in 10^4) the cell is computed again with ``acos``, as
``word_dtw``'s kernels compute it. The matrix is the one
:func:`~mocapkit.cleaning.ssa.word_dtw.group_pose_distances` gives, bit for bit
(``tests/cleaning/ssa/test_self_costs.py``), at a fraction of the time.

A frame holding a non-finite or overlong (any component above 2 in size)
quaternion is never approximated: every cell of its row and column is computed
the exact way (``inf`` where a group's term is).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .twins import twin_kernels

__all__ = ["self_pose_costs", "self_pose_rows", "pack_groups", "mirror_upper", "approx_half_angle_sq",
           "half_angle_sq", "robust_sum", "checked_cost_block", "polynomial_frames", "frame_lanes", "TERM_RTOL",
           "DELTA_RTOL", "PARALLEL_CELLS"]

_INF = np.inf

#: Relative error bound used for a polynomial term against the ``acos`` one (400x what was measured, 2.2e-15
#: over 4 million values of ``d``, ``tests/cleaning/ssa/test_self_costs.py``).
TERM_RTOL = 1e-12

#: A cell's group sum of polynomial terms is within ``DELTA_RTOL`` times their total of the exact one: twice the
#: terms' error (the sum, and at most as much again through the dropped largest terms), plus both sums' round-off
#: (below 3e-15 each for 24 joints), with room to spare.
DELTA_RTOL = 4e-12

#: F * F / 2 cells from which the parallel twin runs (the threshold of word_dtw's pose-distance kernels).
PARALLEL_CELLS = 16384

# asin(s) / s with s = sqrt((1 + t) / 4), t in [-1, 1], in powers of t (a degree-16 Chebyshev interpolant fitted
# at 40 digits, converted to monomials; every coefficient positive and |t| <= 1, so any order of evaluation is
# well conditioned: Estrin's, below, within 2.6e-15 of acos)
_COEF = (1.0471975511965979, 0.0537514935913165, 0.007798902238970451, 0.0015196685400978211,
         0.00034086372357476044, 8.302317095249746e-05, 2.1345550379954454e-05, 5.701826721154319e-06,
         1.5669766358133022e-06, 4.400550332229293e-07, 1.2579926945696048e-07, 3.6755083788958076e-08,
         1.078871832720154e-08, 2.9005835285697755e-09, 8.647556963724701e-10, 4.300065905943289e-10,
         1.308933671927025e-10)
(_C0, _C1, _C2, _C3, _C4, _C5, _C6, _C7, _C8, _C9, _C10, _C11, _C12, _C13, _C14, _C15, _C16) = _COEF


@njit(cache=True, inline="always")
def approx_half_angle_sq(d) -> float:
    """``acos(d)^2`` for ``d`` in [0, 1] from the polynomial (relative error under :data:`TERM_RTOL`; 0 at 1).

    The polynomial in ``t = 1 - 2 d`` is evaluated by Estrin's scheme: pairs ``c_2k + c_2k+1 t``, then pairs of
    those with ``t^2``, ``t^4`` and ``t^8``, four dependent steps where Horner's rule takes sixteen. A row of
    cells runs this in SIMD lanes, and Horner's chain of dependent multiply-adds held each lane for its whole
    latency: the joint terms of a row cost half the time this way (94 -> 52 ns a cell of 24 joints, 2-core VM).
    Its rounding differs from Horner's by a few units of the last place (largest relative error from ``acos``
    2.6e-15 against 2.2e-15, :data:`TERM_RTOL` 1e-12), and a stored cost never depends on it: a cell keeps the
    float32 that the exact sum rounds to, or is computed with ``acos`` (module docstring).
    """
    t = 1.0 - 2.0 * d
    t2 = t * t
    t4 = t2 * t2
    t8 = t4 * t4
    a0 = _C0 + _C1 * t
    a1 = _C2 + _C3 * t
    a2 = _C4 + _C5 * t
    a3 = _C6 + _C7 * t
    a4 = _C8 + _C9 * t
    a5 = _C10 + _C11 * t
    a6 = _C12 + _C13 * t
    a7 = _C14 + _C15 * t
    b0 = a0 + a1 * t2  # c0..c3
    b1 = a2 + a3 * t2  # c4..c7
    b2 = a4 + a5 * t2  # c8..c11
    b3 = a6 + a7 * t2  # c12..c15
    p = (b0 + b1 * t4) + ((b2 + b3 * t4) + _C16 * t8) * t8
    return 2.0 * (1.0 - d) * (p * p)


@njit(cache=True, inline="always")
def half_angle_sq(a, b) -> float:
    """The exact eq. 1 term of two unit quaternions (Aristidou et al. 2018): ``acos(|a . b|)^2``, the squared half
    rotation angle between them in radians; ``inf`` for a non-finite quaternion. Every pose-distance kernel's."""
    d = abs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3])
    if not d == d:  # NaN
        return _INF
    if d > 1.0:
        d = 1.0
    h = math.acos(d)
    return h * h


@njit(cache=True, inline="always")
def robust_sum(terms, members, drop) -> float:
    """Sum of ``terms[members]`` without its ``drop`` (<= 3) largest values.

    The sum runs in ``members`` order and the dropped values are subtracted
    from it afterwards, largest first; dropping none only sums, dropping one
    tracks only the largest value.
    """
    s = 0.0
    if drop == 0:
        for k in members:
            s += terms[k]
    elif drop == 1:
        t0 = -1.0
        for k in members:
            v = terms[k]
            s += v
            if v > t0:
                t0 = v
        if t0 > 0.0:
            s -= t0
    else:
        t0 = -1.0
        t1 = -1.0
        t2 = -1.0
        for k in members:
            v = terms[k]
            s += v
            if v > t0:
                t2 = t1
                t1 = t0
                t0 = v
            elif v > t1:
                t2 = t1
                t1 = v
            elif v > t2:
                t2 = v
        if t0 > 0.0:
            s -= t0
        if t1 > 0.0:
            s -= t1
        if drop >= 3 and t2 > 0.0:
            s -= t2
    if s < 0.0:  # round-off
        s = 0.0
    return s


@njit(cache=True)
def _exact_cell(A, a, b, members, offsets, drop, g, terms):
    """The float32 eq. 1 cost of frames ``a``, ``b`` on group ``g``, every term from ``acos`` (``terms`` scratch)."""
    for k in members[offsets[g] : offsets[g + 1]]:
        v = half_angle_sq(A[a, k], A[b, k])
        if v == _INF:
            return np.float32(_INF)
        terms[k] = v
    return np.float32(robust_sum(terms, members[offsets[g] : offsets[g + 1]], drop[g]))


@njit(cache=True, inline="always")
def checked_cost_block(A, B, okA, okB, members, drop, s0, t0, rtol, terms, C):
    """``C[i, j]`` = the float32 eq. 1 cost of frames ``s0 + i`` of ``A`` and ``t0 + j`` of ``B`` on ``members``
    (``drop`` largest terms left out), as a float64 holding that float32: the value
    ``word_dtw.group_pose_distances`` stores, bit for bit.

    A word pair's (N, M) block, as the warps of the mean motion texture read it where the take's whole self-distance
    matrix was not kept (Aristidou et al. 2018, section 3.2). Each cell first sums polynomial terms
    (:func:`approx_half_angle_sq`) and keeps that sum's float32 where both ends of its error interval (``rtol``
    times the terms' total, :data:`DELTA_RTOL`) round to it, as :func:`self_pose_costs` does; otherwise, and where
    either frame is not in ``okA`` / ``okB`` (:func:`polynomial_frames`), the cell takes the ``acos`` terms.
    ``terms`` : (m,) float64 scratch.
    """
    N, M = C.shape
    for i in range(N):
        a = s0 + i
        for j in range(M):
            b = t0 + j
            if okA[a] and okB[b]:
                total = 0.0
                for k in members:
                    d = abs(A[a, k, 0] * B[b, k, 0] + A[a, k, 1] * B[b, k, 1] + A[a, k, 2] * B[b, k, 2]
                            + A[a, k, 3] * B[b, k, 3])
                    v = approx_half_angle_sq(min(d, 1.0))
                    terms[k] = v
                    total += v
                r = robust_sum(terms, members, drop)
                delta = rtol * total
                lo = np.float32(max(r - delta, 0.0))
                if lo == np.float32(r + delta):
                    C[i, j] = lo
                    continue
            finite = True
            for k in members:
                v = half_angle_sq(A[a, k], B[b, k])
                terms[k] = v
                if v == _INF:
                    finite = False
            C[i, j] = np.float32(robust_sum(terms, members, drop)) if finite else _INF


@njit(cache=True, inline="always")
def _top3(x, m0, m1, m2, v):
    """A cell's running sum ``x`` and its three largest terms ``m0 >= m1 >= m2`` with the term ``v`` added (the
    insertion word_dtw's robust sum keeps)."""
    x0, x1 = m0, m1
    return x + v, max(x0, v), max(x1, min(x0, v)), max(m2, min(x1, v))


@njit(cache=True, inline="always")
def _row(A, Q, ok, members, offsets, drop, rtol, a, c0, ra, out, term, tot, s, t0, t1, t2, exact):
    """Cells ``(a, c0..F-1)`` of every group into ``out[:, ra, c0:]``: polynomial terms checked, the unsure cells
    exact.

    A group's sums take its joints four at a time: each cell's running sum and largest terms are loaded once per
    four joints instead of once per joint (the sums of a 24-joint take's five groups: 47 -> 34 ns a cell on the
    2-core VM), and each cell still adds its terms and keeps its largest ones in the joints' order, so the sums
    are those of one joint at a time, bit for bit."""
    F, m = A.shape[0], A.shape[1]
    G = drop.shape[0]
    n = F - c0
    if not ok[a]:
        for g in range(G):
            for j in range(n):
                out[g, ra, c0 + j] = _exact_cell(A, a, c0 + j, members, offsets, drop, g, exact)
        return
    for k in range(m):
        a0, a1, a2, a3 = A[a, k, 0], A[a, k, 1], A[a, k, 2], A[a, k, 3]
        q0, q1, q2, q3 = Q[k, 0], Q[k, 1], Q[k, 2], Q[k, 3]
        tk = term[k]
        for j in range(n):
            b = c0 + j
            d = abs(a0 * q0[b] + a1 * q1[b] + a2 * q2[b] + a3 * q3[b])
            d = min(d, 1.0)
            tk[j] = approx_half_angle_sq(d)
    for g in range(G):
        mem = members[offsets[g] : offsets[g + 1]]
        dg = drop[g]
        for j in range(n):
            s[j] = 0.0
            t0[j] = -1.0
            t1[j] = -1.0
            t2[j] = -1.0
        nm = mem.shape[0]
        q = 0
        while q + 4 <= nm:  # four joints a pass: each cell's operations in the same order, a quarter of the loads
            ta, tb, tc, td = term[mem[q]], term[mem[q + 1]], term[mem[q + 2]], term[mem[q + 3]]
            if dg == 0:
                for j in range(n):
                    s[j] = s[j] + ta[j] + tb[j] + tc[j] + td[j]
            elif dg == 1:
                for j in range(n):
                    va, vb, vc, vd = ta[j], tb[j], tc[j], td[j]
                    s[j] = s[j] + va + vb + vc + vd
                    t0[j] = max(max(max(max(t0[j], va), vb), vc), vd)
            else:
                for j in range(n):
                    x, m0, m1, m2 = s[j], t0[j], t1[j], t2[j]
                    x, m0, m1, m2 = _top3(x, m0, m1, m2, ta[j])
                    x, m0, m1, m2 = _top3(x, m0, m1, m2, tb[j])
                    x, m0, m1, m2 = _top3(x, m0, m1, m2, tc[j])
                    x, m0, m1, m2 = _top3(x, m0, m1, m2, td[j])
                    s[j], t0[j], t1[j], t2[j] = x, m0, m1, m2
            q += 4
        for k in mem[q:]:  # the last one to three joints, one a pass
            tk = term[k]
            if dg == 0:
                for j in range(n):
                    s[j] += tk[j]
            elif dg == 1:
                for j in range(n):
                    v = tk[j]
                    s[j] += v
                    t0[j] = max(t0[j], v)
            else:  # the three largest, as word_dtw's insertion keeps them
                for j in range(n):
                    v = tk[j]
                    s[j] += v
                    x0, x1 = t0[j], t1[j]
                    t0[j] = max(x0, v)
                    t1[j] = max(x1, min(x0, v))
                    t2[j] = max(t2[j], min(x1, v))
        for j in range(n):
            total = s[j]
            r = total
            if dg >= 1 and t0[j] > 0.0:
                r -= t0[j]
            if dg >= 2 and t1[j] > 0.0:
                r -= t1[j]
            if dg >= 3 and t2[j] > 0.0:
                r -= t2[j]
            r = max(r, 0.0)
            delta = rtol * total
            lo = np.float32(max(r - delta, 0.0))
            hi = np.float32(r + delta)
            tot[j] = lo if lo == hi else np.float32(np.nan)  # NaN: not sure, computed again
        for j in range(n):
            v = tot[j]
            if v == v and ok[c0 + j]:
                out[g, ra, c0 + j] = v
            else:
                out[g, ra, c0 + j] = _exact_cell(A, a, c0 + j, members, offsets, drop, g, exact)


@twin_kernels(PARALLEL_CELLS)
def _self_costs(A, Q, ok, members, offsets, drop, rtol, r0, r1, full, o0, out):
    """The upper triangle into ``out`` (G, F, F), or with ``full`` every cell of rows ``r0..r1-1`` into rows
    ``o0..o0 + r1 - r0 - 1`` of ``out`` (G, >= o0 + r1 - r0, F)."""
    F = A.shape[0]
    m = A.shape[1]
    steps = r1 - r0 if full else (F + 1) // 2
    for h in prange(steps):
        term = np.empty((m, F))
        tot = np.empty(F, dtype=np.float32)
        s = np.empty(F)
        t0 = np.empty(F)
        t1 = np.empty(F)
        t2 = np.empty(F)
        exact = np.empty(m)
        top = np.int64(h)
        if full:
            _row(A, Q, ok, members, offsets, drop, rtol, r0 + top, 0, o0 + top, out, term, tot, s, t0, t1, t2, exact)
            continue
        for side in range(2):  # a long row and a short one per step, so the threads share the triangle evenly
            a = top if side == 0 else F - 1 - top
            if side == 1 and a == top:
                break
            _row(A, Q, ok, members, offsets, drop, rtol, a, a, a, out, term, tot, s, t0, t1, t2, exact)


def self_pose_costs(A: np.ndarray, members: np.ndarray, offsets: np.ndarray, drop: np.ndarray, out: np.ndarray,
                    rtol: float = DELTA_RTOL) -> None:
    """The upper triangle (``b >= a``) of the eq. 1 costs of ``A`` against itself, per group, into ``out``.

    A : (F, m, 4) float64 C-contiguous quaternions; members, offsets : int64 CSR of the groups' joints
    (``word_dtw``'s packing); drop : (G,) int64 in 0..3; out : (G, F, F) float32, its lower triangle left
    as it is. Every stored value equals ``word_dtw.group_pose_distances(A, A, ...)``'s, bit for bit.
    ``rtol``: the sums' error bound relative to their terms' total (:data:`DELTA_RTOL`; never less: a larger one
    only sends more cells the exact way, as the tests do to reach that path).
    """
    if not rtol >= DELTA_RTOL:
        raise ValueError(f"rtol must be at least DELTA_RTOL ({DELTA_RTOL}), got {rtol}")
    F = A.shape[0]
    if F == 0:
        return
    Q, ok = frame_lanes(A)
    _self_costs.pick(F * F // 2)(A, Q, ok, members, offsets, drop, float(rtol), 0, F, False, 0, out)


def self_pose_rows(A: np.ndarray, r0: int, r1: int, members: np.ndarray, offsets: np.ndarray, drop: np.ndarray,
                   rtol: float = DELTA_RTOL, lanes: tuple | None = None, out: np.ndarray | None = None,
                   at: int = 0) -> np.ndarray:
    """Rows ``r0..r1-1`` of the take's self pose-distance matrix, every column: (G, r1 - r0, F) float32.

    What a long take's search reads chunk by chunk when its whole matrix (G F^2 float32) would not fit in memory:
    the same cells, bit for bit, as ``word_dtw.group_pose_distances(A[r0:r1], A, ...)``, from the checked
    polynomial terms of :func:`self_pose_costs` (arguments as there) instead of an ``acos`` per joint term.
    ``lanes``: :func:`frame_lanes` of ``A``, made once by a caller that reads many row blocks (a copy of the whole
    texture each time otherwise: a 20-minute take's search reads some 400 blocks). ``out``: a C-contiguous
    (G, R, F) float32 buffer the rows are written into, from its row ``at`` on (``at + r1 - r0 <= R``), and
    returned as that view ``out[:, at : at + r1 - r0]``: a search that runs chunk after chunk keeps one buffer
    instead of allocating its rows (~48 MB) per chunk.
    """
    if not rtol >= DELTA_RTOL:
        raise ValueError(f"rtol must be at least DELTA_RTOL ({DELTA_RTOL}), got {rtol}")
    F = A.shape[0]
    if not 0 <= r0 <= r1 <= F:
        raise ValueError(f"rows {r0}..{r1} are not within the {F} frames")
    if out is None:
        out, at = np.empty((len(drop), r1 - r0, F), dtype=np.float32), 0
    elif (out.dtype != np.float32 or not out.flags.c_contiguous or out.ndim != 3 or out.shape[0] != len(drop)
          or out.shape[2] != F or not 0 <= at <= out.shape[1] - (r1 - r0)):
        raise ValueError(f"out must be a C-contiguous ({len(drop)}, >= {at + r1 - r0}, {F}) float32 array")
    if r1 > r0:
        Q, ok = frame_lanes(A) if lanes is None else lanes
        _self_costs.pick((r1 - r0) * F)(A, Q, ok, members, offsets, drop, float(rtol), int(r0), int(r1), True,
                                        int(at), out)
    return out[:, at : at + r1 - r0]


def pack_groups(groups):
    """(G, m) boolean group masks -> ``(members, offsets)``, the int64 CSR arrays of the groups' joints the kernels
    take."""
    groups = np.asarray(groups, dtype=bool)
    members = np.concatenate([np.flatnonzero(g) for g in groups]).astype(np.int64)
    offsets = np.zeros(len(groups) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum(groups.sum(axis=1))
    return members, offsets


def polynomial_frames(A: np.ndarray) -> np.ndarray:
    """Which frames of ``A`` (F, m, 4) may take polynomial terms, (F,) bool: finite, no component above 2 in size."""
    return np.all(np.isfinite(A) & (np.abs(A) <= 2.0), axis=(1, 2))


def frame_lanes(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(Q, ok)``: A's (m, 4, F) layout, a joint's component over frames for SIMD lanes, and which frames (F,) may
    take polynomial terms (finite, no component above 2 in size)."""
    return np.ascontiguousarray(A.transpose(1, 2, 0)), polynomial_frames(A)


@njit(cache=True)
def mirror_upper(out):
    """``out[g, r, c] = out[g, c, r]`` below the diagonal of (G, F, F) ``out``, in place: the lower triangle of
    :func:`self_pose_costs`' upper one, in 64 x 64 blocks (a column-wise write per cell would miss the cache on
    every one)."""
    G, F = out.shape[0], out.shape[1]
    B = 64
    for g in range(G):
        for r0 in range(0, F, B):
            for c0 in range(0, r0 + 1, B):
                for r in range(r0, min(r0 + B, F)):
                    for c in range(c0, min(c0 + B, r)):
                        out[g, r, c] = out[g, c, r]
