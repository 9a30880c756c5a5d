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

from ...kernel_cache import read_only
from .dtw_rows import ROW_STATES, best_state, word_dtw_rows
from .word_bounds import cheap_bounds
from .ordering import kth_smallest, sort_by_key
from .self_costs import (DELTA_RTOL, checked_cost_block, half_angle_sq, mirror_upper, pack_groups, polynomial_frames,
                         robust_sum, self_pose_costs)
from .twins import twin_kernels
from .word_means import robust_word_means, select_separated_minima, shift_tolerant_angles  # re-exported

__all__ = [
    "group_pose_distances",
    "self_pose_distances",
    "word_dtw",
    "word_dtw_path",
    "word_distance_profile",
    "word_knn_profile",
    "knn_workspace",
    "word_dtw_lower_bounds",
    "word_distance_pairs",
    "warp_target_words",
    "robust_word_means",
    "shift_tolerant_angles",
    "select_separated_minima",
    "NUM_STATES",
]

NUM_STATES = 7  # 0: diagonal (or start); 1..3: 1-3 horizontal steps in a row; 4..6: 1-3 vertical steps in a row
_INF = np.inf

# Problem sizes from which each kernel runs its parallel twin (see mocapkit.cleaning.ssa.twins), in the
# unit its caller passes to pick(). Each is set near 3-10 ms of serial work, measured on a 2-core machine:
# below that, starting the threads (more so when the cores are busy with other processes) eats the
# gain. On the bundled 3 s walk every call stays serial (the largest:
# 69 x 69 pose-distance cells, 600 knn DTW positions, 23 warps), so a cold first clean compiles only
# the serial twins; on a 60 s take the heavy calls (840 x 840 cells, ~135,000 knn positions,
# 70-900 warps) run in parallel.
_PARALLEL_CELLS = 16384  # Fa * Fb pose-distance cells, ~0.5 us each
_PARALLEL_DTWS = 2048  # W * T word DTWs, ~3 us each
_PARALLEL_ROW_MINIMA = 262144  # source rows * target starts, ~15 ns each
_PARALLEL_KNN = 8192  # W * T target positions bounded (a share of them DTW'd), ~1 us each
_PARALLEL_PAIRS = 256  # pairs, pose costs and DTW, ~20 us each
_PARALLEL_WARPS = 64  # pairs, pose costs, DTW, trace and warp, ~50 us each


@twin_kernels(_PARALLEL_CELLS)
def _group_pose_distances(A, B, members, offsets, drop):
    Fa, Fb = A.shape[0], B.shape[0]
    m = A.shape[1]
    G = drop.shape[0]
    out = np.empty((G, Fa, Fb), dtype=np.float32)
    for a in prange(Fa):
        terms = np.empty(m)
        for b in range(Fb):
            finite = True
            for k in range(m):
                v = half_angle_sq(A[a, k], B[b, k])
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
                out[g, a, b] = robust_sum(terms, members[offsets[g] : offsets[g + 1]], drop[g])
    return out




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
    members, offsets = pack_groups(groups)
    A, B = read_only(A), read_only(B)
    return _group_pose_distances.pick(A.shape[0] * B.shape[0])(A, B, members, offsets, drop)


def self_pose_distances(A: np.ndarray, groups: np.ndarray, drop) -> np.ndarray:
    """:func:`group_pose_distances` of ``A`` against itself, (G, F, F) float32, computing only half the cells.

    Eq. 1 is symmetric (every joint term is the same for frames ``(a, b)`` and
    ``(b, a)``, bit for bit), so each cell of the upper triangle is computed
    once and mirrored: the same array as ``group_pose_distances(A, A, ...)``
    at half the cost (the self-distance matrix of the motion words, Aristidou
    et al. 2018, section 3.3), its cells from polynomial joint terms checked
    to round alike (:func:`~mocapkit.cleaning.ssa.self_costs.self_pose_costs`).
    """
    A = np.ascontiguousarray(A, dtype=np.float64)
    if A.ndim != 3 or A.shape[2] != 4:
        raise ValueError(f"A must be (F, m, 4), got {A.shape}")
    groups = np.asarray(groups, dtype=bool).reshape(-1, A.shape[1])
    drop = np.asarray(drop, dtype=np.int64).reshape(-1)
    if len(drop) != len(groups) or np.any((drop < 0) | (drop > 3)):
        raise ValueError("drop must give 0..3 for every group")
    members, offsets = pack_groups(groups)
    F = A.shape[0]
    out = np.empty((len(groups), F, F), dtype=np.float32)
    if F:
        self_pose_costs(A, members, offsets, drop, out)  # the upper triangle, few acos (self_costs)
        mirror_upper(out)
    return out


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
            best, bl = best_state(acc, ln, i, j)
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


@twin_kernels(_PARALLEL_DTWS)
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
        _profile.pick(len(src) * len(tgt))(D, src, tgt, N, M, int(min_width), int(max_run), dist, iend, jend)
    return dist, iend, jend


# -- the K nearest words without the whole distance function ------------------------
#
# Section 3.3 keeps only the K smallest local minima of a source word's distance
# function. Most target positions are far from the source word, and a cheap lower
# bound of their DTW distance proves it: :func:`_knn_profile` evaluates the DTW in
# increasing order of the bound and stops once the bound exceeds the K-th smallest
# local minimum found, which leaves the answer exactly that of the full profile.
#
# The bound. An admissible path visits every row 0..i_end (i_end >= min_width - 1),
# each with 1 to max_run + 1 cells (at most max_run horizontal steps in a row), and
# row i only in columns 0..(max_run + 1)(i + 1) - 1. With r_i the smallest cost of
# row i over those columns, the path's mean cost is at least the smallest weighted
# mean of r_0..r_iend with weights in [1, max_run + 1]: weight max_run + 1 on the
# smallest values, 1 on the others, the split tried at every rank. The DTW's
# distance (the best mean over end cells of least-sum paths) is a path mean, so it
# is bounded too. The bounds cascade, cheapest first (the UCR suite's order,
# Rakthanmanon et al. 2012): every position gets the sort-free bound of
# :mod:`mocapkit.cleaning.ssa.word_bounds`, and only those it leaves under ``tau`` this
# sorting one; the DTW runs row by row (:mod:`mocapkit.cleaning.ssa.dtw_rows`).
#
# A second test runs before each DTW once a K-th minimum ``tau`` is known: the word
# distance exceeds ``tau`` when every admissible path's sum of ``c - tau`` is positive,
# which a one-state DP with the slope limit relaxed proves (:func:`_mean_exceeds`, a
# seventh of the DTW's work). A position it rules out keeps ``tau`` as a strict bound
# (``d > tau``) and is not evaluated; the proof of a local minimum next to it reads
# that bound. Every position with ``d <= tau`` is still evaluated, so the answer is
# unchanged, bit for bit.


def _row_windows(N, M, max_run):
    """Column window length of each source row, and the distinct lengths (the bound's row minima)."""
    per_row = np.array([min(M, (max_run + 1) * (i + 1)) for i in range(N)], dtype=np.int64)
    lens = np.unique(per_row)
    level = np.searchsorted(lens, per_row).astype(np.int64)
    return lens, level


@twin_kernels(_PARALLEL_ROW_MINIMA)
def _row_minima(D, tgt, lens, out):
    """out[l, r, t] = min(D[r, tgt[t] : tgt[t] + lens[l]]), the lens increasing.

    The minima of every block of ``lens[0]`` columns are taken once per row, so
    a window that grows by that step costs one comparison, not one per column.
    Each output is the running ``c < v`` scan of its window in column order;
    the loops run level by level over all target starts (SIMD lanes, with
    contiguous loads where the starts are consecutive frames, as a take's
    are), each start's scan the same sequence of comparisons as one start at a time.
    """
    R = D.shape[0]
    T = tgt.shape[0]
    Fb = D.shape[1]
    step = lens[0]
    nb = max(Fb - step + 1, 0)
    base = tgt[0] if T > 0 else 0  # the first start, when every start is the one before plus one; else -1
    for t in range(1, T):
        if tgt[t] != tgt[t - 1] + 1:
            base = -1
            break
    for r in prange(R):
        block = np.empty(max(nb, 1))
        cur = np.empty(T)
        row = D[r]
        for x in range(nb):
            block[x] = _INF
        for j in range(step):
            for x in range(nb):
                c = row[x + j]
                if c < block[x]:
                    block[x] = c
        for t in range(T):
            cur[t] = _INF
        j0 = 0
        for l in range(lens.shape[0]):
            if lens[l] - j0 == step and base >= 0:
                for t in range(T):
                    c = block[base + j0 + t]
                    if c < cur[t]:
                        cur[t] = c
            elif lens[l] - j0 == step:
                for t in range(T):
                    c = block[tgt[t] + j0]
                    if c < cur[t]:
                        cur[t] = c
            else:
                for j in range(j0, lens[l]):
                    if base >= 0:
                        for t in range(T):
                            c = row[base + j + t]
                            if c < cur[t]:
                                cur[t] = c
                    else:
                        for t in range(T):
                            c = row[tgt[t] + j]
                            if c < cur[t]:
                                cur[t] = c
            for t in range(T):
                out[l, r, t] = cur[t]
            j0 = lens[l]


@njit(cache=True, inline="always")
def _bound(rowmin, level, s, t, N, min_width, wmax, buf):
    """Lower bound of the word distance of the source word at row ``s`` and target ``t`` (see above)."""
    best = _INF
    n = 0
    lo = min_width - 1 if min_width >= 1 else 0
    for i in range(N):
        v = rowmin[level[i], s + i, t]
        if not v < _INF:
            return best  # no finite path reaches past row i
        # insertion into the sorted prefix buf[:n]
        k = n
        while k > 0 and buf[k - 1] > v:
            buf[k] = buf[k - 1]
            k -= 1
        buf[k] = v
        n += 1
        if i >= lo:
            total = 0.0
            for q in range(n):
                total += buf[q]
            low = 0.0
            for q in range(n + 1):  # the q smallest rows carry weight wmax
                m = (wmax * low + (total - low)) / (wmax * q + (n - q))
                if m < best:
                    best = m
                if q == n or buf[q] >= m:
                    break  # weighting the next row more raises the mean from here on (the rows are sorted)
                low += buf[q]
    return best


@njit(cache=True, inline="always")
def _proven_minimum(d, evaluated, lb, strict, consec, t, v):
    """Whether ``v = d[t]`` is a local minimum (``<=`` left, ``<`` right, across consecutive starts).

    An unevaluated neighbour counts through its lower bound (``d >= lb``, or
    ``d > lb`` where ``strict``): the answer is True only when the bound
    already proves it.
    """
    T = d.shape[0]
    if t > 0 and consec[t]:
        if evaluated[t - 1]:
            if not v <= d[t - 1]:
                return False
        elif not lb[t - 1] >= v:
            return False
    if t + 1 < T and consec[t + 1]:
        if evaluated[t + 1]:
            if not v < d[t + 1]:
                return False
        elif not (lb[t + 1] > v or (strict[t + 1] and lb[t + 1] >= v)):
            return False
    return True


@njit(cache=True)
def _mean_exceeds(D, si, tj, N, M, min_width, lam, row):
    """Whether every admissible path of the block ``D[si:si+N, tj:tj+M]`` has a mean cost above ``lam``.

    A path's mean exceeds ``lam`` exactly when its sum of ``c - lam`` is
    positive; the least such sum over all monotone paths from ``(0, 0)`` to an
    admissible end cell (constraints (a)-(c) and (e); the slope limit (d)
    relaxed, so the paths of :func:`_word_dtw` are among them) takes one
    state per cell instead of seven. True only when that least sum is
    positive by more than its round-off; then the word distance exceeds
    ``lam``. The first end cell whose sum is not above that margin answers
    False at once: later cells only lower the least sum and raise the largest
    cost ``cmax`` the margin scales with, so the whole block would answer the
    same (a block the DTW then runs on stops 1-4 rows early). ``row`` is an
    (M,) scratch buffer.
    """
    lo = min_width - 1 if min_width >= 1 else 0
    best = _INF
    cmax = lam
    for i in range(N):
        # row 0 extends only to the right, column 0 only down; inside, the least of up, diagonal and left
        # (a least value, whatever the order it is taken in: costs are never NaN)
        c = D[si + i, tj]
        if c < _INF and c > cmax:
            cmax = c
        diag = row[0]  # (i - 1, 0), the next cell's diagonal
        left = (0.0 if i == 0 else diag) + (c - lam)
        row[0] = left
        for j in range(1, M):
            c = D[si + i, tj + j]
            if c < _INF and c > cmax:
                cmax = c
            prev = left
            if i > 0:
                up = row[j]
                if up < prev:
                    prev = up
                if diag < prev:
                    prev = diag
                diag = up
            left = prev + (c - lam)
            row[j] = left
        # this row's end cells: the last row from column lo, the last column from row lo (the last row's last
        # cell too when the block is narrower than min_width, where range(lo, M) is empty)
        if i == N - 1:
            for j in range(lo, M):
                if row[j] < best:
                    best = row[j]
        if i >= lo and row[M - 1] < best:
            best = row[M - 1]
        if not best > 1e-12 * (N + M) * cmax:
            return False  # the least sum only falls and the margin only grows from here: proven
    return best > 1e-12 * (N + M) * cmax


@njit(cache=True, inline="always")
def _confirm(d, evaluated, lb, strict, consec, proven, tgt, lo, hi, t, k, vals, n):
    """Count position ``t`` among the proven local minima if it now is one; returns how many of ``vals`` (k,), the
    K smallest such values ascending, are set. ``proven`` (T,) marks those counted. A proof reads only the value
    and the two neighbours' values or bounds, and bounds only rise: checking the positions next to each change (a
    DTW run, a bound raised) keeps ``vals`` what a scan of every evaluated position gives, its K-th value ``tau``.
    Positions whose start lies in ``[lo, hi]`` (the source word's own place) are never counted."""
    T = d.shape[0]
    if t < 0 or t >= T or proven[t] or not evaluated[t]:
        return n
    v = d[t]
    if not v < _INF or lo <= tgt[t] <= hi:
        return n
    if not _proven_minimum(d, evaluated, lb, strict, consec, t, v):
        return n
    proven[t] = True
    if n == k and v >= vals[k - 1]:
        return n
    q = n if n < k else k - 1
    while q > 0 and vals[q - 1] > v:
        vals[q] = vals[q - 1]
        q -= 1
    vals[q] = v
    return n + 1 if n < k else n


@twin_kernels(_PARALLEL_KNN)
def _knn_profile(D, rowmin, level, src, tgt, consec, excl_lo, excl_hi, N, M, min_width, max_run, k,
                 out_idx, out_dist, out_iend, out_jend, out_evaluated):
    W = src.shape[0]
    T = tgt.shape[0]
    wmax = float(max_run + 1)
    first = min(T, 64)
    for w in prange(W):
        acc = np.empty((2, M, ROW_STATES))
        ln = np.empty((2, M, ROW_STATES), dtype=np.int64)
        col_best = np.empty(N)
        col_len = np.empty(N, dtype=np.int64)
        buf = np.empty(N)
        vals = np.empty(k)
        lb = np.empty(T)
        d = np.empty(T)
        ie = np.zeros(T, dtype=np.int64)
        je = np.zeros(T, dtype=np.int64)
        evaluated = np.zeros(T, dtype=np.bool_)
        strict = np.zeros(T, dtype=np.bool_)
        refined = np.zeros(T, dtype=np.bool_)
        proven = np.zeros(T, dtype=np.bool_)
        nv = 0  # of vals set
        row = np.empty(M)
        ev = np.empty(T, dtype=np.int64)
        heap = np.empty(T)
        rest = np.empty(T)  # the bound of each position not yet visited, NaN once visited
        btot = np.empty(T)
        bmu = np.empty(T)
        alive = np.empty(T, dtype=np.bool_)
        ne = 0
        lo = excl_lo[w]
        hi = excl_hi[w]
        cheap_bounds(rowmin, level, src[w], N, min_width, wmax, btot, bmu, lb, alive)  # cheap_bound at every t
        for t in range(T):
            if lo < tgt[t] < hi:  # inside the source's own place: never chosen, never a chosen one's neighbour
                lb[t] = _INF
            else:
                lb[t] = lb[t] * (1.0 - 1e-9)
        for t in range(T):
            rest[t] = lb[t]
        tau = _INF
        batch = first
        done = False
        while not done:
            # in increasing order of the bound, a batch at a time: while tau is unknown the `batch` lowest not yet
            # visited (64, then twice as many each time: a word whose tau takes a few hundred DTWs to know sorts
            # those, not the take's thousands), then only the positions whose bound is at most tau. The batches
            # join into one stable sort of the bounds (a batch takes every tie of its cut, and a visited
            # position's bound is never below the tau it was visited under), so the positions are visited
            # in the order, and with the outcomes, of a sort of them all
            if tau < _INF:
                cut = tau
                done = True
            else:
                cut = kth_smallest(rest, batch, heap) if batch < T else np.nan
                if cut != cut:  # fewer than `batch` left: all of them
                    cut = _INF
                    done = True
                batch *= 2
            order = np.flatnonzero(rest <= cut)
            if order.shape[0] == 0:
                break
            sort_by_key(order, rest, np.empty_like(order))
            for x in range(order.shape[0]):
                t = order[x]
                if not lb[t] <= tau:
                    done = True
                    break
                rest[t] = np.nan
                if evaluated[t] or strict[t] or lo < tgt[t] < hi:
                    continue
                if tau < _INF and not refined[t]:  # the sorting bound, only where the cheap one is not enough
                    lb[t] = max(lb[t], _bound(rowmin, level, src[w], t, N, min_width, wmax, buf) * (1.0 - 1e-9))
                    refined[t] = True
                    if not lb[t] <= tau:  # a bound raised: a neighbour's proof may read it
                        nv = _confirm(d, evaluated, lb, strict, consec, proven, tgt, lo, hi, t - 1, k, vals, nv)
                        nv = _confirm(d, evaluated, lb, strict, consec, proven, tgt, lo, hi, t + 1, k, vals, nv)
                        tau = vals[k - 1] if nv == k else _INF
                        continue
                if tau < _INF and _mean_exceeds(D, src[w], tgt[t], N, M, min_width, tau * (1.0 + 1e-9), row):
                    lb[t] = tau  # the distance exceeds tau: a strict bound, no DTW needed
                    strict[t] = True
                    nv = _confirm(d, evaluated, lb, strict, consec, proven, tgt, lo, hi, t - 1, k, vals, nv)
                    nv = _confirm(d, evaluated, lb, strict, consec, proven, tgt, lo, hi, t + 1, k, vals, nv)
                    tau = vals[k - 1] if nv == k else _INF
                    continue
                dd, i, j = word_dtw_rows(D, src[w], tgt[t], N, M, min_width, max_run, acc, ln, col_best, col_len)
                d[t] = dd
                ie[t] = i
                je[t] = j
                evaluated[t] = True
                ev[ne] = t
                ne += 1
                for u in range(t - 1, t + 2):  # the new value: its own proof and its neighbours'
                    nv = _confirm(d, evaluated, lb, strict, consec, proven, tgt, lo, hi, u, k, vals, nv)
                tau = vals[k - 1] if nv == k else _INF
        out_evaluated[w] = ne
        # the K smallest proven local minima, ties to the earlier target
        n = 0
        picked = np.full(k, -1, dtype=np.int64)
        for e in range(ne):
            t = ev[e]
            v = d[t]
            if not v < _INF or lo <= tgt[t] <= hi:
                continue
            if not _proven_minimum(d, evaluated, lb, strict, consec, t, v):
                continue
            if n == k and (v > out_dist[w, k - 1] or (v == out_dist[w, k - 1] and t > picked[k - 1])):
                continue
            q = n if n < k else k - 1
            while q > 0 and (out_dist[w, q - 1] > v or (out_dist[w, q - 1] == v and picked[q - 1] > t)):
                out_dist[w, q] = out_dist[w, q - 1]
                picked[q] = picked[q - 1]
                q -= 1
            out_dist[w, q] = v
            picked[q] = t
            if n < k:
                n += 1
        for q in range(k):
            t = picked[q]
            out_idx[w, q] = t
            if t >= 0:
                out_iend[w, q] = ie[t]
                out_jend[w, q] = je[t]
            else:
                out_dist[w, q] = _INF
                out_iend[w, q] = 0
                out_jend[w, q] = 0


def _check_starts(D, src, tgt, N, M):
    if len(src) and (src.min() < 0 or src.max() + N > D.shape[0]):
        raise ValueError("a source word runs past the end of the pose-distance matrix")
    if len(tgt) and (tgt.min() < 0 or tgt.max() + M > D.shape[1]):
        raise ValueError("a target word runs past the end of the pose-distance matrix")


def word_dtw_lower_bounds(D, src_starts, tgt_starts, N=15, M=20, min_width=11, max_run=3):
    """The lower bounds :func:`word_knn_profile` prunes with, (W, T) float64 (for tests and diagnostics).

    Every entry is at most the corresponding :func:`word_distance_profile` distance.
    """
    D = np.asarray(D)
    src = np.ascontiguousarray(src_starts, dtype=np.int64)
    tgt = np.ascontiguousarray(tgt_starts, dtype=np.int64)
    _check_starts(D, src, tgt, N, M)
    lens, level = _row_windows(N, M, max_run)
    rowmin = np.empty((len(lens), D.shape[0], len(tgt)), dtype=np.float32)
    _row_minima.pick(D.shape[0] * len(tgt))(D, tgt, lens, rowmin)
    buf = np.empty(N)
    out = np.empty((len(src), len(tgt)))
    for w in range(len(src)):
        for t in range(len(tgt)):
            out[w, t] = _bound(rowmin, level, int(src[w]), t, N, int(min_width), float(max_run + 1), buf)
    return out


def knn_workspace(rows: int, targets: int, N: int = 15, M: int = 20, max_run: int = 3) -> np.ndarray:
    """A float32 buffer (1-D) that holds :func:`word_knn_profile`'s row minima for up to ``rows`` rows of ``D``
    against ``targets`` target starts: (levels, rows, targets) entries, the levels of :func:`_row_windows`
    (5 for N=15, M=20). A search that runs chunk after chunk passes the same one to every call: a long take's
    chunks each allocated and faulted in ~50 MB anew (an 18-minute take: 1,500 times)."""
    return np.empty(len(_row_windows(N, M, max_run)[0]) * int(rows) * int(targets), dtype=np.float32)


def word_knn_profile(D, src_starts, tgt_starts, k=5, exclude_center=None, exclude_half=7, N=15, M=20,
                     min_width=11, max_run=3, return_evaluated=False, work=None):
    """The K smallest local minima of each source word's distance function, without computing all of it.

    The same answer as :func:`word_distance_profile` followed by taking, per
    row, the ``k`` smallest local minima over the target starts (section 3.3;
    neighbouring entries are compared only where the starts are consecutive
    frames), but the DTW runs only where a lower bound of the distance (see
    the comment above :func:`_row_windows`) is below the K-th minimum found:
    on real takes about half the target positions of a 20 s take, a fifth of
    a 60 s one (the longer the take, the more of it is far from each word). Minima whose start lies
    within ``exclude_half`` frames of ``exclude_center[w]`` (the source word's
    own place, or None) are not chosen; those positions still belong to the
    distance function, so the slope down into the source's own place is not
    mistaken for a minimum at the edge of the excluded zone (a "trivial match",
    the source shifted by half a word). Ties go to the earlier target.

    Returns ``idx`` int64 (W, k) indices into ``tgt_starts`` (-1: fewer than
    ``k`` minima), ``dist`` float32 (W, k) ascending (inf where -1), ``i_end``,
    ``j_end`` int16 (W, k), and with ``return_evaluated`` the number of DTWs run
    per source word (W,). ``work``: a :func:`knn_workspace` buffer the row minima
    are written into when it is large enough (else they are allocated); every
    entry is written before it is read, so the answer is the same either way.
    """
    D = np.asarray(D)
    src = np.ascontiguousarray(src_starts, dtype=np.int64)
    tgt = np.ascontiguousarray(tgt_starts, dtype=np.int64)
    _check_starts(D, src, tgt, N, M)
    if k < 1:
        raise ValueError(f"k must be at least 1, got {k}")
    W, T = len(src), len(tgt)
    idx = np.full((W, k), -1, dtype=np.int64)
    dist = np.full((W, k), np.inf)
    iend = np.zeros((W, k), dtype=np.int64)
    jend = np.zeros((W, k), dtype=np.int64)
    evaluated = np.zeros(W, dtype=np.int64)
    if W and T:
        if exclude_center is None:
            lo, hi = np.ones(W, dtype=np.int64), np.zeros(W, dtype=np.int64)
        else:
            c = np.asarray(exclude_center, dtype=np.int64).reshape(W)
            lo, hi = c - int(exclude_half), c + int(exclude_half)
        consec = np.zeros(T, dtype=np.bool_)
        consec[1:] = tgt[1:] == tgt[:-1] + 1
        lens, level = _row_windows(N, M, max_run)
        shape = (len(lens), D.shape[0], T)
        size = shape[0] * shape[1] * shape[2]
        if work is not None and work.dtype == np.float32 and work.ndim == 1 and work.size >= size:
            rowmin = work[:size].reshape(shape)  # C-contiguous: the kernels' one signature
        else:
            rowmin = np.empty(shape, dtype=np.float32)
        _row_minima.pick(D.shape[0] * len(tgt))(D, tgt, lens, rowmin)
        _knn_profile.pick(W * T)(D, rowmin, level, src, tgt, consec, lo, hi, N, M, int(min_width), int(max_run), int(k),
                     idx, dist, iend, jend, evaluated)
    out = (idx, dist.astype(np.float32), iend.astype(np.int16), jend.astype(np.int16))
    return out + (evaluated,) if return_evaluated else out


@njit(cache=True, inline="always")
def _cost_block(A, B, members, drop, s0, t0, terms, C):
    """C[i, j] = eq. 1 between frames ``s0 + i`` of A and ``t0 + j`` of B on ``members`` (inf if one is NaN)."""
    N, M = C.shape
    for i in range(N):
        for j in range(M):
            finite = True
            for k in members:
                v = half_angle_sq(A[s0 + i, k], B[t0 + j, k])
                terms[k] = v
                if v == _INF:
                    finite = False
            C[i, j] = robust_sum(terms, members, drop) if finite else _INF


@twin_kernels(_PARALLEL_PAIRS)
def _pairs(A, B, members, drop, src, tgt, N, M, min_width, max_run, dist, iend, jend):
    P = src.shape[0]
    for p in prange(P):
        C = np.empty((N, M))
        terms = np.empty(A.shape[1])
        acc = np.empty((N, M, 7))
        ln = np.empty((N, M, 7), dtype=np.int64)
        _cost_block(A, B, members, drop, src[p], tgt[p], terms, C)
        # int64 origins, not literal 0s (a numba type of their own): word_dtw's signature, one compile for both
        d, i, j = _word_dtw(C, np.int64(0), np.int64(0), N, M, min_width, max_run, acc, ln)
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
        _pairs.pick(len(src))(A, B, members, int(drop), src, tgt, N, M, int(min_width), int(max_run), dist, iend, jend)
    return dist, iend, jend


@twin_kernels(_PARALLEL_WARPS)
def _warp(S, T, okS, okT, members, rows, drop, src, tgt, N, M, min_width, max_run, costs, out, iend):
    P = src.shape[0]
    R = rows.shape[0]
    given = costs.shape[0] > 0
    for p in prange(P):
        C = np.empty((N, M))
        terms = np.empty(S.shape[1])
        acc = np.empty((N, M, 7))
        ln = np.empty((N, M, 7), dtype=np.int64)
        back = np.zeros((N, M, 7), dtype=np.int8)
        if given:  # the search's own pose distances
            for i in range(N):
                for j in range(M):
                    C[i, j] = costs[src[p] + i, tgt[p] + j]
        else:  # as group_pose_distances gives it, so the path is the one the search saw
            checked_cost_block(S, T, okS, okT, members, drop, src[p], tgt[p], DELTA_RTOL, terms, C)
        # int64 origins, not literal 0s: word_dtw_path's signature, one compile for both
        d, bi, bj = _word_dtw(C, np.int64(0), np.int64(0), N, M, min_width, max_run, acc, ln, back)
        iend[p] = bi
        if bi < 0:
            continue
        path = _trace(acc, back, bi, bj)
        w = np.zeros((bi + 1, R, 4))
        t0 = tgt[p] + path[0, 1]
        for n in range(path.shape[0]):
            i = path[n, 0]
            f = tgt[p] + path[n, 1]
            for r in range(R):
                k = rows[r]
                dot = 0.0
                for c in range(4):
                    dot += T[f, k, c] * T[t0, k, c]
                sgn = -1.0 if dot < 0.0 else 1.0
                for c in range(4):
                    w[i, r, c] += sgn * T[f, k, c]
        for i in range(bi + 1):
            for r in range(R):
                nrm = math.sqrt(w[i, r, 0] ** 2 + w[i, r, 1] ** 2 + w[i, r, 2] ** 2 + w[i, r, 3] ** 2)
                for c in range(4):
                    out[p, i, r, c] = w[i, r, c] / nrm if nrm > 0.0 else np.nan


def warp_target_words(S, T, members, drop, src_starts, tgt_starts, N=15, M=20, min_width=11, max_run=3, rows=None,
                      costs=None):
    """Target words time-warped onto their source words' frames (section 3.2), many pairs in one call.

    S : (Fs, m, 4) source texture, T : (Ft, m, 4) target texture
    (hemisphere-continuous in time, as :func:`mocapkit.cleaning.ssa.motion_texture`
    makes it); members : joint rows the DTW compares, ``drop`` of their largest
    eq. 1 terms ignored; rows : joint rows to warp (default ``members``). For
    each pair the constrained DTW path between the source word at
    ``src_starts[p]`` and the target word at ``tgt_starts[p]`` is found, and
    each matched source frame takes the normalised mean of the target frames
    matched to it, signs aligned with the word's first target frame.

    ``costs``: the pose distances of ``S`` against ``T`` on ``members`` (Fs, Ft), as
    :func:`group_pose_distances` or :func:`self_pose_distances` computed them for
    the search; read instead of computed again (the same float32 values). Without them each pair's block is
    computed from checked polynomial terms
    (:func:`~mocapkit.cleaning.ssa.self_costs.checked_cost_block`: the same float32 values, few ``acos``).

    Returns ``warped`` float64 (P, N, len(rows), 4), valid in frames
    ``0..i_end[p]`` (NaN after), and ``i_end`` int64 (P,) (-1: no admissible path).
    """
    S = np.ascontiguousarray(S, dtype=np.float64)
    T = np.ascontiguousarray(T, dtype=np.float64)
    members = np.ascontiguousarray(members, dtype=np.int64)
    rows = members if rows is None else np.ascontiguousarray(rows, dtype=np.int64)
    src = np.ascontiguousarray(src_starts, dtype=np.int64)
    tgt = np.ascontiguousarray(tgt_starts, dtype=np.int64)
    if src.shape != tgt.shape:
        raise ValueError("src_starts and tgt_starts must have the same length")
    if len(src) and (src.min() < 0 or src.max() + N > S.shape[0] or tgt.min() < 0 or tgt.max() + M > T.shape[0]):
        raise ValueError("a word runs past the end of its texture")
    if costs is None:
        costs = np.zeros((0, 0), dtype=np.float32)
    elif costs.shape != (S.shape[0], T.shape[0]) or costs.dtype != np.float32:
        raise ValueError(f"costs must be float32 ({S.shape[0]}, {T.shape[0]}), got {costs.dtype} {costs.shape}")
    out = np.full((len(src), N, len(rows), 4), np.nan)
    iend = np.full(len(src), -1, dtype=np.int64)
    if len(src):
        okS = polynomial_frames(S)
        okT = okS if T is S else polynomial_frames(T)
        _warp.pick(len(src))(S, T, okS, okT, members, rows, int(drop), src, tgt, int(N), int(M), int(min_width),
                             int(max_run), costs, out, iend)
    return out, iend
