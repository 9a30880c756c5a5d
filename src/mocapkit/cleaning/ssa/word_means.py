"""Numba kernels on the neighbour words once they are found: robust means, shift-tolerant angles, separated minima.

Aristidou et al. 2018 average each source word's K nearest neighbours into a
mean motion word (section 3.4) and measure the digression of the input from
the mean texture (section 4); the sparse (kd-tree) search of section 7 picks
its K candidates greedily, a word apart. These kernels do the per-cell work:
:func:`robust_word_means` (medoid-trimmed chordal means and their spread),
:func:`shift_tolerant_angles` (the MDM's timing tolerance) and
:func:`select_separated_minima`. The word DTW itself is in
:mod:`mocapkit.cleaning.ssa.word_dtw`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .twins import twin_kernels

__all__ = ["robust_word_means", "shift_tolerant_angles", "select_separated_minima"]

_INF = np.inf

# Problem sizes from which each kernel runs its parallel twin (see mocapkit.cleaning.ssa.twins), set
# near a few ms of serial work on a 2-core machine, as in mocapkit.cleaning.ssa.word_dtw.
_PARALLEL_MEAN_CELLS = 65536  # W * K * N * m neighbour cells, ~50 ns each
_PARALLEL_SHIFT_CELLS = 65536  # F * m cells, ~30 ns each


@njit(cache=True, inline="always")
def _angle(a, b):
    """Rotation angle (radians) between unit quaternions a and b, as mocapkit.rotations.geodesic_angle."""
    w = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    x = a[0] * b[1] - a[1] * b[0] - a[2] * b[3] + a[3] * b[2]
    y = a[0] * b[2] + a[1] * b[3] - a[2] * b[0] - a[3] * b[1]
    z = a[0] * b[3] - a[1] * b[2] + a[2] * b[1] - a[3] * b[0]
    return 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), abs(w))


@twin_kernels(_PARALLEL_MEAN_CELLS)
def _robust_means(words, valid, slack, mean, spread):
    W, K, N, m = words.shape[:4]
    for w in prange(W):
        idx = np.empty(K, dtype=np.int64)
        n = 0
        for k in range(K):
            if valid[w, k]:
                idx[n] = k
                n += 1
        if n == 0:
            continue
        pair = np.zeros((K, K))
        to_med = np.empty(K)
        srt = np.empty(K)
        keep = np.zeros(K, dtype=np.bool_)
        for i in range(N):
            for j in range(m):
                if n == 1:
                    for c in range(4):
                        mean[w, i, j, c] = words[w, idx[0], i, j, c]
                    spread[w, i, j] = 0.0
                    continue
                for a in range(n):
                    for b in range(a + 1, n):
                        v = _angle(words[w, idx[a], i, j], words[w, idx[b], i, j])
                        pair[a, b] = v
                        pair[b, a] = v
                med = 0
                best = _INF
                for a in range(n):
                    t = 0.0
                    for b in range(n):
                        if b != a:
                            t += pair[a, b]
                    if t < best:
                        best = t
                        med = a
                for a in range(n):
                    to_med[a] = 0.0 if a == med else pair[a, med]
                    q = a
                    while q > 0 and srt[q - 1] > to_med[a]:
                        srt[q] = srt[q - 1]
                        q -= 1
                    srt[q] = to_med[a]
                median = srt[n // 2] if n % 2 == 1 else 0.5 * (srt[n // 2 - 1] + srt[n // 2])
                s0 = 0.0
                s1 = 0.0
                s2 = 0.0
                s3 = 0.0
                kept = 0
                for a in range(n):
                    keep[a] = to_med[a] <= 2.0 * median + slack
                    if keep[a]:
                        kept += 1
                        s0 += words[w, idx[a], i, j, 0]
                        s1 += words[w, idx[a], i, j, 1]
                        s2 += words[w, idx[a], i, j, 2]
                        s3 += words[w, idx[a], i, j, 3]
                nrm = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3)
                mean[w, i, j, 0] = s0 / nrm
                mean[w, i, j, 1] = s1 / nrm
                mean[w, i, j, 2] = s2 / nrm
                mean[w, i, j, 3] = s3 / nrm
                dev = 0.0
                for a in range(n):
                    if keep[a]:
                        v = _angle(words[w, idx[a], i, j], mean[w, i, j])
                        dev += v * v
                spread[w, i, j] = math.sqrt(dev / kept)


def robust_word_means(words, valid, slack):
    """Per cell of each source word: the chordal mean of its neighbour words near their medoid, and their spread.

    words : (W, K, N, m, 4) hemisphere-aligned unit quaternions, valid : (W, K)
    bool; slack : radians. For every (word, frame, joint) cell the medoid of
    the valid neighbours (least summed angle to the others; ties to the first)
    is found, the neighbours farther from it than ``2 * median + slack`` are
    dropped, and the rest averaged (normalised sum). Returns ``mean`` (W, N, m, 4)
    and ``spread`` (W, N, m), the RMS angle of the kept ones from the mean
    (0 with a single neighbour, whose value is the mean); rows without a valid
    neighbour stay NaN.
    """
    words = np.ascontiguousarray(words, dtype=np.float64)
    valid = np.ascontiguousarray(valid, dtype=np.bool_)
    W, K, N, m = words.shape[:4]
    if valid.shape != (W, K):
        raise ValueError(f"valid must be (W, K) = {(W, K)}, got {valid.shape}")
    mean = np.full((W, N, m, 4), np.nan)
    spread = np.full((W, N, m), np.nan)
    if W:
        _robust_means.pick(W * K * N * m)(words, valid, float(slack), mean, spread)
    return mean, spread


@twin_kernels(_PARALLEL_SHIFT_CELLS)
def _shift_angles(inp, ref, shift, out):
    F, m = inp.shape[:2]
    for f in prange(F):
        for j in range(m):
            best = np.nan
            for d in range(-shift, shift + 1):
                g = min(max(f + d, 0), F - 1)
                if not (ref[g, j, 0] == ref[g, j, 0]):  # NaN: no mean texture there
                    continue
                v = _angle(inp[f, j], ref[g, j])
                if not (best <= v):  # also replaces the NaN start
                    best = v
            out[f, j] = best


def shift_tolerant_angles(inp, ref, shift):
    """Per cell the smallest rotation angle (radians) between ``inp[f]`` and ``ref[f + d]``, ``|d| <= shift``.

    inp, ref : (F, m, 4) unit quaternions (``ref`` may hold NaN rows: skipped;
    frames past either end are clamped). Returns (F, m), NaN where every
    ``ref`` in reach is NaN. The MDM's timing tolerance (:func:`mocapkit.cleaning.ssa.detect`).
    """
    inp = np.ascontiguousarray(inp, dtype=np.float64)
    ref = np.ascontiguousarray(ref, dtype=np.float64)
    if inp.shape != ref.shape or inp.ndim != 3 or inp.shape[2] != 4:
        raise ValueError(f"inp and ref must both be (F, m, 4), got {inp.shape} and {ref.shape}")
    out = np.empty(inp.shape[:2])
    if inp.shape[0]:
        _shift_angles.pick(inp.shape[0] * inp.shape[1])(inp, ref, int(shift), out)
    return out


@njit(cache=True)
def _select(dist, pos, clip, k, separation, excl_lo, excl_hi, out):
    W = dist.shape[0]
    picked_clip = np.empty(k, dtype=np.int64)
    for w in range(W):
        order = np.argsort(dist[w])
        n = 0
        for c in order:
            if n >= k or not dist[w, c] < _INF:
                break
            p = pos[w, c]
            if excl_lo[w] <= p < excl_hi[w]:
                continue
            ok = True
            for q in range(n):
                if picked_clip[q] == clip[w, c] and abs(p - out[w, q]) < separation:
                    ok = False
                    break
            if ok:
                out[w, n] = p
                picked_clip[n] = clip[w, c]
                n += 1
    return out


def select_separated_minima(dist, positions, clips, k, separation, exclude_lo, exclude_hi):
    """Greedy choice of the ``k`` best candidates per row, pairwise ``separation`` frames apart within a clip.

    The sparse counterpart of "the K smallest local minima" (section 3.3) for
    candidates gathered by a kd-tree: dist, positions, clips are (W, C); a
    candidate whose position lies in ``[exclude_lo[w], exclude_hi[w])`` (the
    source word's own neighbourhood) is skipped. Returns (W, k) positions, -1
    where fewer than ``k`` candidates qualify.
    """
    dist = np.ascontiguousarray(dist, dtype=np.float64)
    out = np.full((dist.shape[0], k), -1, dtype=np.int64)
    return _select(
        dist,
        np.ascontiguousarray(positions, dtype=np.int64),
        np.ascontiguousarray(clips, dtype=np.int64),
        int(k),
        int(separation),
        np.ascontiguousarray(exclude_lo, dtype=np.int64),
        np.ascontiguousarray(exclude_hi, dtype=np.int64),
        out,
    )
