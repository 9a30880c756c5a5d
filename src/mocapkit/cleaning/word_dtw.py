"""Numba kernels of the self-similarity analysis: pose distances between motion words and constrained DTW.

Aristidou et al. 2018 compare a source motion word (``N`` frames) with a
target word (``M >= N`` frames) by dynamic time warping over the pose
distance of eq. 1, under the appendix's five constraints:

(a) boundary: the path starts at ``(0, 0)`` and stops as soon as either word
    reaches its end (last row or last column);
(b) monotonicity and (c) continuity: steps ``(1, 0)``, ``(0, 1)``, ``(1, 1)``;
(d) slope: at most ``max_run`` (3) consecutive steps in the same
    non-diagonal direction;
(e) width: the warped window is longer than 10 frames, i.e. the path ends at
    row ``N-1`` with column ``>= min_width - 1`` or at column ``M-1`` with row
    ``>= min_width - 1`` (``min_width = 11``).

The slope constraint is kept exactly by carrying seven states per cell (the
last step diagonal, or one to three consecutive horizontal or vertical steps).
For every admissible end cell the path of least cumulative cost is taken; the
word distance is the smallest **mean** cost per matched frame pair over those
end cells ("the average distance of the matched frames in the optimal matching
sequence"). The kernels return the distance and the end cell ``(i_end, j_end)``
so the matched part of the target can be resampled to the source's length.

Local cost (eq. 1, as in :func:`mocapkit.metrics.pose_error`): for frames ``a``
and ``b`` the squared half-angle ``||log(q_a^-1 q_b)||^2`` of each joint of the
word's group, summed after dropping the ``drop`` largest terms (3 for the whole
body, 1 for small groups: robust to a few broken joints). A pair of frames with
a non-finite quaternion costs ``inf``.

The plain-Python oracles these kernels are tested against live in
``tests/naive.py``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

__all__ = [
    "group_pose_distances",
    "word_dtw",
    "word_dtw_path",
    "word_distance_profile",
    "word_distance_pairs",
    "select_separated_minima",
    "NUM_STATES",
]

NUM_STATES = 7  # 0: diagonal (or start); 1..3: 1-3 horizontal steps in a row; 4..6: 1-3 vertical steps in a row
_INF = np.inf


@njit(cache=True, inline="always")
def _half_angle_sq(a, b) -> float:
    d = abs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3])
    if not d == d:  # NaN
        return _INF
    if d > 1.0:
        d = 1.0
    h = math.acos(d)
    return h * h


@njit(cache=True, inline="always")
def _robust_sum(terms, members, drop) -> float:
    """Sum of ``terms[members]`` without its ``drop`` (<= 3) largest values."""
    s = 0.0
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
    if drop >= 1 and t0 > 0.0:
        s -= t0
    if drop >= 2 and t1 > 0.0:
        s -= t1
    if drop >= 3 and t2 > 0.0:
        s -= t2
    if s < 0.0:  # round-off
        s = 0.0
    return s


def _group_pose_distances_py(A, B, members, offsets, drop):
    Fa, Fb = A.shape[0], B.shape[0]
    m = A.shape[1]
    G = drop.shape[0]
    out = np.empty((G, Fa, Fb), dtype=np.float32)
    for a in prange(Fa):
        terms = np.empty(m)
        for b in range(Fb):
            finite = True
            for k in range(m):
                v = _half_angle_sq(A[a, k], B[b, k])
                terms[k] = v
                if v == _INF:
                    finite = False
            for g in range(G):
                if not finite:
                    bad = False
                    for k in members[offsets[g] : offsets[g + 1]]:
                        if terms[k] == _INF:
                            bad = True
                    if bad:
                        out[g, a, b] = _INF
                        continue
                out[g, a, b] = _robust_sum(terms, members[offsets[g] : offsets[g + 1]], drop[g])
    return out


# Two compilations of one kernel: threads pay off on long clips, but a word against a word (15 x 20
# frames, called once per neighbour in mean_motion_texture) spends ~2 ms starting them for ~20 us of work.
_group_pose_distances = njit(cache=True, parallel=True)(_group_pose_distances_py)
_group_pose_distances_serial = njit(cache=True)(_group_pose_distances_py)
_SERIAL_CELLS = 4096


def _pack_groups(groups):
    """(G, m) boolean group masks -> (members, offsets) CSR arrays for the kernels."""
    groups = np.asarray(groups, dtype=bool)
    members = np.concatenate([np.flatnonzero(g) for g in groups]).astype(np.int64)
    offsets = np.zeros(len(groups) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum(groups.sum(axis=1))
    return members, offsets


def group_pose_distances(A: np.ndarray, B: np.ndarray, groups: np.ndarray, drop) -> np.ndarray:
    """Eq. 1 pose distances between every frame of ``A`` and of ``B`` for each joint group.

    A : (Fa, m, 4) and B : (Fb, m, 4) float64 unit quaternions (w first) of the
    same ``m`` joints; groups : (G, m) bool, which joints each group holds;
    drop : (G,) int in 0..3, how many of the largest joint terms each group
    ignores. Returns float32 (G, Fa, Fb): ``dist^2`` in squared radians of
    half-angle, ``inf`` where a frame holds a non-finite quaternion of the group.
    """
    A = np.ascontiguousarray(A, dtype=np.float64)
    B = np.ascontiguousarray(B, dtype=np.float64)
    if A.ndim != 3 or B.ndim != 3 or A.shape[1:] != B.shape[1:] or A.shape[2] != 4:
        raise ValueError(f"A and B must be (F, m, 4) over the same joints, got {A.shape} and {B.shape}")
    groups = np.asarray(groups, dtype=bool).reshape(-1, A.shape[1])
    drop = np.asarray(drop, dtype=np.int64).reshape(-1)
    if len(drop) != len(groups) or np.any((drop < 0) | (drop > 3)):
        raise ValueError("drop must give 0..3 for every group")
    members, offsets = _pack_groups(groups)
    kernel = _group_pose_distances_serial if A.shape[0] * B.shape[0] <= _SERIAL_CELLS else _group_pose_distances
    return kernel(A, B, members, offsets, drop)


# -- constrained DTW ---------------------------------------------------------


@njit(cache=True)
def _word_dtw(C, si, tj, N, M, min_width, max_run, acc, ln, back=None):
    """DTW of the block ``C[si:si+N, tj:tj+M]`` under the appendix constraints.

    ``acc``/``ln`` are (N, M, NUM_STATES) scratch buffers (cumulative cost and
    path length). Returns (mean cost, i_end, j_end); (inf, -1, -1) when no
    admissible path exists.
    """
    for i in range(N):
        for j in range(M):
            c = C[si + i, tj + j]
            for s in range(7):
                acc[i, j, s] = _INF
                ln[i, j, s] = 0
            if i == 0 and j == 0:
                acc[0, 0, 0] = c
                ln[0, 0, 0] = 1
                continue
            # diagonal from any state of (i-1, j-1)
            if i > 0 and j > 0:
                best = _INF
                bl = 0
                bs = 0
                for s in range(7):
                    v = acc[i - 1, j - 1, s]
                    if v < best:
                        best = v
                        bl = ln[i - 1, j - 1, s]
                        bs = s
                if best < _INF:
                    acc[i, j, 0] = best + c
                    ln[i, j, 0] = bl + 1
                    if back is not None:
                        back[i, j, 0] = bs
            # horizontal (0, 1): not from the last row (the path has already stopped there)
            if j > 0 and i < N - 1:
                best = _INF
                bl = 0
                bs = 0
                for s in (0, 4, 5, 6):
                    v = acc[i, j - 1, s]
                    if v < best:
                        best = v
                        bl = ln[i, j - 1, s]
                        bs = s
                if best < _INF:
                    acc[i, j, 1] = best + c
                    ln[i, j, 1] = bl + 1
                    if back is not None:
                        back[i, j, 1] = bs
                for r in range(2, max_run + 1):
                    v = acc[i, j - 1, r - 1]
                    if v < _INF:
                        acc[i, j, r] = v + c
                        ln[i, j, r] = ln[i, j - 1, r - 1] + 1
                        if back is not None:
                            back[i, j, r] = r - 1
            # vertical (1, 0): not from the last column
            if i > 0 and j < M - 1:
                best = _INF
                bl = 0
                bs = 0
                for s in (0, 1, 2, 3):
                    v = acc[i - 1, j, s]
                    if v < best:
                        best = v
                        bl = ln[i - 1, j, s]
                        bs = s
                if best < _INF:
                    acc[i, j, 4] = best + c
                    ln[i, j, 4] = bl + 1
                    if back is not None:
                        back[i, j, 4] = bs
                for r in range(2, max_run + 1):
                    v = acc[i - 1, j, 3 + r - 1]
                    if v < _INF:
                        acc[i, j, 3 + r] = v + c
                        ln[i, j, 3 + r] = ln[i - 1, j, 3 + r - 1] + 1
                        if back is not None:
                            back[i, j, 3 + r] = 3 + r - 1
    best_mean = _INF
    bi = -1
    bj = -1
    # ends on the last row (source finished), then on the last column (target finished)
    for e in range(2):
        lo = min_width - 1
        hi = M if e == 0 else N - 1  # the corner (N-1, M-1) is visited once, with the last row
        for x in range(max(lo, 0), hi):
            i = N - 1 if e == 0 else x
            j = x if e == 0 else M - 1
            best = _INF
            bl = 1
            for s in range(7):
                v = acc[i, j, s]
                if v < best:
                    best = v
                    bl = ln[i, j, s]
            if best < _INF:
                mean = best / bl
                if mean < best_mean:
                    best_mean = mean
                    bi = i
                    bj = j
    return best_mean, bi, bj


@njit(cache=True)
def _trace(acc, back, bi, bj):
    """Warping path (p, 2) of (source, target) frames ending at (bi, bj), from the predecessor states."""
    s = 0
    best = _INF
    for x in range(7):
        if acc[bi, bj, x] < best:
            best = acc[bi, bj, x]
            s = x
    path = np.empty((bi + bj + 1, 2), dtype=np.int64)
    n = 0
    i, j = bi, bj
    while True:
        path[n, 0] = i
        path[n, 1] = j
        n += 1
        if i == 0 and j == 0:
            break
        prev = back[i, j, s]
        if s == 0:
            i -= 1
            j -= 1
        elif s <= 3:
            j -= 1
        else:
            i -= 1
        s = prev
    return path[:n][::-1].copy()


def word_dtw(cost: np.ndarray, min_width: int = 11, max_run: int = 3) -> tuple[float, int, int]:
    """Constrained DTW of one (N, M) local-cost block: ``(mean cost, i_end, j_end)``.

    ``cost[i, j]`` is the local cost of source frame ``i`` against target frame
    ``j`` (``N <= M``). See the module docstring for the constraints. Returns
    ``(inf, -1, -1)`` when no path satisfies them.
    """
    C = np.ascontiguousarray(cost, dtype=np.float64)
    if C.ndim != 2 or C.shape[0] < 1 or C.shape[1] < 1:
        raise ValueError(f"cost must be a non-empty (N, M) matrix, got shape {C.shape}")
    if not 0 <= max_run <= 3:
        raise ValueError(f"max_run must be 0..3, got {max_run}")
    N, M = C.shape
    acc = np.empty((N, M, NUM_STATES))
    ln = np.empty((N, M, NUM_STATES), dtype=np.int64)
    d, i, j = _word_dtw(C, 0, 0, N, M, int(min_width), int(max_run), acc, ln)
    return float(d), int(i), int(j)


def word_dtw_path(cost: np.ndarray, min_width: int = 11, max_run: int = 3):
    """Like :func:`word_dtw`, also returning the optimal warping path (p, 2) of (source, target) frames."""
    C = np.ascontiguousarray(cost, dtype=np.float64)
    if C.ndim != 2 or C.shape[0] < 1 or C.shape[1] < 1:
        raise ValueError(f"cost must be a non-empty (N, M) matrix, got shape {C.shape}")
    N, M = C.shape
    acc = np.empty((N, M, NUM_STATES))
    ln = np.empty((N, M, NUM_STATES), dtype=np.int64)
    back = np.zeros((N, M, NUM_STATES), dtype=np.int8)
    d, i, j = _word_dtw(C, 0, 0, N, M, int(min_width), int(max_run), acc, ln, back)
    if i < 0:
        return float(d), np.zeros((0, 2), dtype=np.int64)
    return float(d), _trace(acc, back, i, j)


@njit(cache=True, parallel=True)
def _profile(D, src, tgt, N, M, min_width, max_run, dist, iend, jend):
    W = src.shape[0]
    T = tgt.shape[0]
    for w in prange(W):
        acc = np.empty((N, M, 7))
        ln = np.empty((N, M, 7), dtype=np.int64)
        for t in range(T):
            d, i, j = _word_dtw(D, src[w], tgt[t], N, M, min_width, max_run, acc, ln)
            dist[w, t] = d
            iend[w, t] = i
            jend[w, t] = j


def word_distance_profile(D, src_starts, tgt_starts, N=15, M=20, min_width=11, max_run=3):
    """Word distances of every source word against every target position, from a pose-distance matrix.

    D : (Fa, Fb) pose distances (one group of :func:`group_pose_distances`);
    src_starts (W,), tgt_starts (T,) first frames of the words (``s + N <= Fa``,
    ``t + M <= Fb``). Returns ``dist`` float32 (W, T) (Fig. 3's distance
    function, one row per source word) and ``i_end``, ``j_end`` int16 (W, T).
    """
    D = np.asarray(D)
    src = np.ascontiguousarray(src_starts, dtype=np.int64)
    tgt = np.ascontiguousarray(tgt_starts, dtype=np.int64)
    if len(src) and (src.min() < 0 or src.max() + N > D.shape[0]):
        raise ValueError("a source word runs past the end of the pose-distance matrix")
    if len(tgt) and (tgt.min() < 0 or tgt.max() + M > D.shape[1]):
        raise ValueError("a target word runs past the end of the pose-distance matrix")
    dist = np.empty((len(src), len(tgt)), dtype=np.float32)
    iend = np.empty((len(src), len(tgt)), dtype=np.int16)
    jend = np.empty((len(src), len(tgt)), dtype=np.int16)
    if len(src) and len(tgt):
        _profile(D, src, tgt, N, M, int(min_width), int(max_run), dist, iend, jend)
    return dist, iend, jend


@njit(cache=True, parallel=True)
def _pairs(A, B, members, drop, src, tgt, N, M, min_width, max_run, dist, iend, jend):
    P = src.shape[0]
    m = members.shape[0]
    for p in prange(P):
        C = np.empty((N, M))
        terms = np.empty(A.shape[1])
        acc = np.empty((N, M, 7))
        ln = np.empty((N, M, 7), dtype=np.int64)
        for i in range(N):
            for j in range(M):
                for kk in range(m):
                    k = members[kk]
                    terms[k] = _half_angle_sq(A[src[p] + i, k], B[tgt[p] + j, k])
                C[i, j] = _robust_sum(terms, members, drop)
        d, i, j = _word_dtw(C, 0, 0, N, M, min_width, max_run, acc, ln)
        dist[p] = d
        iend[p] = i
        jend[p] = j


def word_distance_pairs(A, B, group, drop, src_starts, tgt_starts, N=15, M=20, min_width=11, max_run=3):
    """Word distances for explicit (source start, target start) pairs, pose costs computed on the fly.

    A : (Fa, m, 4), B : (Fb, m, 4) textures; group : (m,) bool joints of the
    word; drop : how many largest joint terms to ignore; src_starts, tgt_starts
    (P,). Used after a kd-tree prefilter, where only a few target positions per
    source word are ranked by DTW. Returns ``dist`` float32 (P,), ``i_end``,
    ``j_end`` int16 (P,). Equal to :func:`word_distance_profile` on the same pairs
    up to float32 rounding of the pose-distance matrix.
    """
    A = np.ascontiguousarray(A, dtype=np.float64)
    B = np.ascontiguousarray(B, dtype=np.float64)
    members = np.flatnonzero(np.asarray(group, dtype=bool)).astype(np.int64)
    src = np.ascontiguousarray(src_starts, dtype=np.int64)
    tgt = np.ascontiguousarray(tgt_starts, dtype=np.int64)
    if src.shape != tgt.shape:
        raise ValueError("src_starts and tgt_starts must have the same length")
    dist = np.empty(len(src), dtype=np.float32)
    iend = np.empty(len(src), dtype=np.int16)
    jend = np.empty(len(src), dtype=np.int16)
    if len(src):
        _pairs(A, B, members, int(drop), src, tgt, N, M, int(min_width), int(max_run), dist, iend, jend)
    return dist, iend, jend


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
