"""Lazy neighbourhood graphs: global matching from per-frame kNN (Krüger 2010, sec. 4.1; Tautges 2012, sec. 3.4).

Both graphs are built only from what a k-nearest-neighbour search reported for
each query frame, so their cost is linear in the number of reported
neighbours instead of the ``O(MN)`` of dynamic time warping.

* :func:`lazy_neighborhood_graph` — the *lazy neighbourhood graph* (LNG) of
  Krüger et al. 2010, sec. 4.1: nodes are the neighbours ``h_j(q_t)`` of every
  query frame, edges are the classic DTW steps between them, and the
  shortest paths from the first to the last query frame are the global
  matches. Whenever every cell of the optimal subsequence-DTW path is among
  the reported neighbours, the LNG finds exactly that path and cost
  (:func:`mocapkit.search.dtw.subsequence_dtw` with ``steps="classic"``).
  :func:`lng_costs` gives the per-node costs and back-pointers.
* :class:`OnlineLazyNeighborhoodGraph` — the *online* LNG (OLNG) of Tautges
  2012, sec. 3.4.3 (Figs. 3.7-3.10): a sliding window over a stream of query
  frames that rates every neighbour of the newest frame by the best path
  ending there, with paths of any length up to the window (shortness is
  penalised). Here it is computed *exactly* (not with the thesis' greedy
  extension): each node keeps one best cost per path start inside the window,
  so an update equals :func:`online_lng_costs` built from scratch on the same
  window.

Inputs are the answers of a kNN search (e.g.
:meth:`mocapkit.search.knn.KNNIndex.query`): ``knn_idx`` database frame
indices (negative = no neighbour) and ``knn_dist`` their Euclidean distances
(non-finite = no neighbour), one row per query frame; rows need not be
sorted. A database index reported twice in one row is one node, with the
smaller distance. ``clip_ids (N,)`` tells which database frames are
consecutive frames of one clip (``clip_ids[i] == clip_ids[i + 1]``); no step
ever goes from one clip into another. ``clip_ids=None`` means a single clip.
"""

from __future__ import annotations

import threading
from typing import NamedTuple

import numba
import numpy as np

from ..kernel_cache import read_only
from .matches import Match

__all__ = [
    "LNGCosts",
    "lng_costs",
    "lazy_neighborhood_graph",
    "OnlinePath",
    "OnlineLazyNeighborhoodGraph",
    "online_lng_costs",
    "OLNG_STEPS",
]

_NONE = np.iinfo(np.int64).max

#: OLNG valid continuations ``(column step, database step)`` in order of
#: preference on ties: the three basic steps of Tautges 2012, sec. 3.4.3
#: (Fig. 3.10 b), then the three extra two-column steps (Fig. 3.10 c).
OLNG_STEPS = ((1, 1), (1, 2), (2, 1), (2, 2), (2, 3), (2, 4))
_STEP_DC = np.array([s[0] for s in OLNG_STEPS], dtype=np.int64)
_STEP_DI = np.array([s[1] for s in OLNG_STEPS], dtype=np.int64)


# -- input checks -----------------------------------------------------------------------


def _check_clip_ids(clip_ids):
    """(clip ids as a read-only contiguous int64 view, whether given): a database opened from disk gives read-only
    ids, one built in memory writable, and numba compiles a kernel once per kind; read-only always, one machine code."""
    if clip_ids is None:
        return read_only(np.zeros(0, dtype=np.int64)), False
    c = np.asarray(clip_ids)
    if c.ndim != 1:
        raise ValueError(f"clip_ids: expected shape (N,), got {c.shape}")
    if c.size and not np.issubdtype(c.dtype, np.integer):
        raise ValueError(f"clip_ids: expected integers, got dtype {c.dtype}")
    return read_only(np.ascontiguousarray(c, dtype=np.int64)), True


def _check_knn(knn_idx, knn_dist, ndim: int, n_db: int | None):
    shape = "(M, K)" if ndim == 2 else "(K,)"
    idx = np.asarray(knn_idx)
    dist = np.asarray(knn_dist)
    if idx.ndim != ndim:
        raise ValueError(f"knn_idx: expected shape {shape}, got {idx.shape}")
    if dist.shape != idx.shape:
        raise ValueError(f"knn_dist: expected shape {idx.shape} like knn_idx, got {dist.shape}")
    if idx.size and not np.issubdtype(idx.dtype, np.integer):
        raise ValueError(f"knn_idx: expected integer database indices, got dtype {idx.dtype}")
    idx = np.ascontiguousarray(idx, dtype=np.int64)
    dist = np.ascontiguousarray(dist, dtype=np.float64)
    if np.any(dist < 0):  # NaN compares False: missing, not an error
        raise ValueError("knn_dist: distances must be >= 0 (use inf or NaN for a missing neighbour)")
    if n_db is not None and idx.size and idx.max() >= n_db:
        # only reported neighbours count: scipy's cKDTree pads missing ones with index N, distance inf
        bad = idx[(idx >= n_db) & np.isfinite(dist)]
        if bad.size:
            raise ValueError(f"knn_idx: index {int(bad.max())} out of range for clip_ids of length {n_db}")
    return idx, dist


# -- shared numba pieces ----------------------------------------------------------------


_RADIX_MIN_K = 512  # below this numpy's argsort is as fast as the radix sort


@numba.njit(cache=True)
def _radix_order(idx, dist, out):
    """Per row of (M, K), positions by database index, missing last: stable LSD radix sort, 11-bit digits."""
    M, K = idx.shape
    B = 2048
    key = np.empty(K, dtype=np.int64)
    tmp = np.empty(K, dtype=np.int64)
    count = np.empty(B + 1, dtype=np.int64)
    for t in range(M):
        mx = -1
        for k in range(K):
            v = idx[t, k]
            if v >= 0 and np.isfinite(dist[t, k]):
                key[k] = v
                if v > mx:
                    mx = v
            else:
                key[k] = -1
        for k in range(K):
            if key[k] < 0:
                key[k] = mx + 1
        src = out[t]
        dst = tmp
        for k in range(K):
            src[k] = k
        swapped = False
        shift = 0
        while (mx + 1) >> shift > 0:
            count[:] = 0
            for k in range(K):
                count[((key[src[k]] >> shift) & (B - 1)) + 1] += 1
            for b in range(B):
                count[b + 1] += count[b]
            for k in range(K):
                d = (key[src[k]] >> shift) & (B - 1)
                dst[count[d]] = src[k]
                count[d] += 1
            src, dst = dst, src
            swapped = not swapped
            shift += 11
        if swapped:
            out[t, :] = src
    return out


def _sort_order(idx, dist):
    """Per row, positions sorted by database index with missing neighbours last.

    numpy's argsort for short rows; a numba radix sort for long ones (5x faster at K = 4096).
    """
    if idx.shape[-1] < _RADIX_MIN_K:
        key = np.where((idx >= 0) & np.isfinite(dist), idx, _NONE)
        return np.argsort(key, axis=-1)
    i2, d2 = idx.reshape(-1, idx.shape[-1]), dist.reshape(-1, idx.shape[-1])
    return _radix_order(i2, d2, np.empty(i2.shape, dtype=np.int64)).reshape(idx.shape)


@numba.njit(cache=True)
def _sort_column(idx, dist, order, s_idx, s_dist, s_pos, slot_of):
    """Valid nodes of one kNN row sorted by database index, duplicates merged.

    ``order`` sorts the row by database index with missing neighbours last
    (:func:`_sort_order`). Writes the ``n`` nodes to ``s_idx[:n]``
    (ascending), ``s_dist[:n]`` and ``s_pos[:n]`` (the row position kept:
    smallest distance, then smallest position); ``slot_of[k]`` is the node of
    row position ``k`` (-1 if missing). Returns ``n``.
    """
    K = idx.shape[0]
    n = 0
    for r in range(K):
        k = order[r]
        v = idx[k]
        d = dist[k]
        slot_of[k] = -1
        if v < 0 or not np.isfinite(d):
            continue
        if n > 0 and s_idx[n - 1] == v:
            if d < s_dist[n - 1] or (d == s_dist[n - 1] and k < s_pos[n - 1]):
                s_dist[n - 1] = d
                s_pos[n - 1] = k
        else:
            s_idx[n] = v
            s_dist[n] = d
            s_pos[n] = k
            n += 1
        slot_of[k] = n - 1
    return n


@numba.njit(cache=True)
def _run_back(i, clip, has_clip, cap):
    """Largest ``r <= cap`` with frames ``i - r .. i`` consecutive frames of one clip."""
    r = 0
    while r < cap and i - r - 1 >= 0:
        if has_clip and clip[i - r - 1] != clip[i - r]:
            break
        r += 1
    return r


# -- LNG (Krüger et al. 2010, sec. 4.1) -------------------------------------------------


# predecessor kinds of an LNG node, in order of preference on ties
_START, _DIAG, _VERT, _HORIZ = 0, 1, 2, 3


# Per-thread scratch memory for the LNG: allocating a dozen fresh (M, K) arrays per
# query costs more in page faults than the whole graph search (malloc returns
# big blocks to the OS on free), so blocks up to this size are kept and reused.
_WORK = threading.local()
_WORK_CACHE_BYTES = 64 * 2**20


def _lng_workspace(M: int, K: int):
    """Views (s_idx (M, K+1), s_dist, cost, start, s_pos, slot_of, pred, kind) on reused scratch memory."""
    spec = [((M, K + 1), np.int64), ((M, K), np.float64), ((M, K), np.float64), ((M, K), np.int64),
            ((M, K), np.int32), ((M, K), np.int32), ((M, K), np.int32), ((M, K), np.int8)]
    sizes = [-(-int(np.prod(shape)) * np.dtype(dt).itemsize // 8) * 8 for shape, dt in spec]
    total = max(sum(sizes), 8)
    buf = getattr(_WORK, "buf", None)
    if buf is None or buf.nbytes < total:
        buf = np.empty(total, dtype=np.uint8)
        if total <= _WORK_CACHE_BYTES:
            _WORK.buf = buf
    out, off = [], 0
    for (shape, dt), size in zip(spec, sizes):
        n = int(np.prod(shape)) * np.dtype(dt).itemsize
        out.append(buf[off:off + n].view(dt).reshape(shape))
        off += size
    return out


@numba.njit(cache=True)
def _lng_kernel(knn_idx, knn_dist, order, clip, has_clip, s_idx, s_dist, cost, start, s_pos, slot_of, pred, kind):
    """DAG shortest paths over the sorted columns, written into the given scratch arrays.

    Node ``j`` of column ``t`` (``j < cnt[t]``, ascending database index
    ``s_idx[t, j]``) gets ``cost``, ``start`` (database frame where its best
    path starts) and its predecessor: ``kind`` (start, diagonal, vertical,
    horizontal) and ``pred`` (its node in column ``t``, vertical, or ``t-1``).
    Returns ``cnt``.
    """
    M, K = knn_idx.shape
    cnt = np.zeros(M, dtype=np.int64)
    for t in range(M):
        cnt[t] = _sort_column(knn_idx[t], knn_dist[t], order[t], s_idx[t], s_dist[t], s_pos[t], slot_of[t])
        s_idx[t, cnt[t]] = _NONE  # a sentinel after the last node
    if M == 0:
        return cnt
    # column 0: every node starts a path (edge from the source, cost 0); a
    # vertical step inside column 0 never costs less, so it is never taken.
    for j in range(cnt[0]):
        cost[0, j] = s_dist[0, j]
        start[0, j] = s_idx[0, j]
        pred[0, j] = -1
        kind[0, j] = _START
    for t in range(1, M):
        pi, pc, ps = s_idx[t - 1], cost[t - 1], start[t - 1]
        ci, cc, cs, cd = s_idx[t], cost[t], start[t], s_dist[t]
        cp, ck = pred[t], kind[t]
        p = 0
        for j in range(cnt[t]):
            i = ci[j]
            while pi[p] < i - 1:  # stops at the sentinel
                p += 1
            best = np.inf
            bj = -1
            bk = _START
            q = p
            # 1. diagonal (t-1, i-1) -> (t, i)
            if pi[q] == i - 1:
                if pc[q] < best and ((not has_clip) or clip[i - 1] == clip[i]):
                    best = pc[q]
                    bj = q
                    bk = _DIAG
                q += 1
            # 2. vertical (t, i-1) -> (t, i): same query frame, next database frame
            if j > 0 and ci[j - 1] == i - 1:
                if cc[j - 1] < best and ((not has_clip) or clip[i - 1] == clip[i]):
                    best = cc[j - 1]
                    bj = j - 1
                    bk = _VERT
            # 3. horizontal (t-1, i) -> (t, i): next query frame, same database frame
            if pi[q] == i:
                if pc[q] < best:
                    best = pc[q]
                    bj = q
                    bk = _HORIZ
            cp[j] = bj
            ck[j] = bk
            if bk != _START:
                cc[j] = cd[j] + best
                cs[j] = cs[bj] if bk == _VERT else ps[bj]
            else:
                cc[j] = np.inf
                cs[j] = -1
    return cnt


@numba.njit(cache=True)
def _lng_to_input_layout(s_pos, slot_of, cost, pred, kind, start):
    M, K = slot_of.shape
    c_out = np.full((M, K), np.inf)
    p_out = np.full((M, K), -1, dtype=np.int64)
    s_out = np.full((M, K), -1, dtype=np.int64)
    for t in range(M):
        for k in range(K):
            j = slot_of[t, k]
            if j < 0:
                continue
            c_out[t, k] = cost[t, j]
            s_out[t, k] = start[t, j]
            if kind[t, j] != _START:
                tb = t if kind[t, j] == _VERT else t - 1
                p_out[t, k] = tb * K + s_pos[tb, pred[t, j]]
    return c_out, p_out, s_out


@numba.njit(cache=True)
def _lng_backtrack(s_idx, pred, kind, t, j):
    n = 1
    tt, jj = t, j
    while kind[tt, jj] != _START:
        n += 1
        tt, jj = (tt if kind[tt, jj] == _VERT else tt - 1), pred[tt, jj]
    path = np.empty((n, 2), dtype=np.int64)
    for r in range(n - 1, -1, -1):
        path[r, 0] = t
        path[r, 1] = s_idx[t, j]
        t, j = (t if kind[t, j] == _VERT else t - 1), pred[t, j]
    return path


class LNGCosts(NamedTuple):
    """Per-node results of the lazy neighbourhood graph, in the layout of the kNN input (M, K).

    Attributes
    ----------
    cost : float array (M, K)
        Cost of the best path from any neighbour of query frame 0 to this node
        (sum of the node distances on it); ``inf`` for missing neighbours and
        unreachable nodes.
    pred : int array (M, K)
        Predecessor on that path as a flat index ``t * K + k`` into the input
        arrays; -1 for path starts, missing and unreachable nodes.
    start : int array (M, K)
        Database frame where that path starts (in query frame 0); -1 if none.
    """

    cost: np.ndarray
    pred: np.ndarray
    start: np.ndarray


def lng_costs(knn_idx, knn_dist, clip_ids=None) -> LNGCosts:
    """Best path costs to every node of the lazy neighbourhood graph (Krüger et al. 2010, sec. 4.1).

    Single-source shortest paths on the DAG of :func:`lazy_neighborhood_graph`
    (source linked to all neighbours of query frame 0), in time linear in the
    number of nodes after one sort per query frame.

    Parameters
    ----------
    knn_idx : int array (M, K)
        Database indices of the neighbours of each query frame (negative: none).
    knn_dist : float array (M, K)
        Their distances (local costs), >= 0; non-finite: no neighbour.
    clip_ids : int array (N,), optional
        Clip of every database frame; None: one clip.

    Returns
    -------
    LNGCosts
        ``cost``, ``pred`` and ``start``, each (M, K). A database index
        reported twice in one row is one node: both positions show its result.

    Examples
    --------
    >>> import numpy as np
    >>> r = lng_costs(np.array([[4, 9], [5, 9]]), np.array([[1.0, 2.0], [0.5, 0.25]]))
    >>> r.cost.tolist()
    [[1.0, 2.0], [1.5, 2.25]]
    >>> r.pred.tolist()  # (1, 0) continues (0, 0) diagonally, (1, 1) stays on frame 9
    [[-1, -1], [0, 1]]
    """
    clip, has_clip = _check_clip_ids(clip_ids)
    idx, dist = _check_knn(knn_idx, knn_dist, 2, clip.shape[0] if has_clip else None)
    s_idx, s_dist, cost, start, s_pos, slot_of, pred, kind = _lng_workspace(*idx.shape)
    _lng_kernel(idx, dist, _sort_order(idx, dist), clip, has_clip,
                s_idx, s_dist, cost, start, s_pos, slot_of, pred, kind)
    return LNGCosts(*_lng_to_input_layout(s_pos, slot_of, cost, pred, kind, start))


def lazy_neighborhood_graph(knn_idx, knn_dist, clip_ids=None, k: int = 1, max_overlap: int = 0) -> list[Match]:
    """Global matches of a query by shortest paths in the lazy neighbourhood graph (Krüger et al. 2010, sec. 4.1).

    Nodes are the reported neighbours ``h_j(q_t)`` of every query frame
    ``t``; a node costs its distance. Edges are the valid continuations of
    classic DTW: diagonal ``(t, i) -> (t+1, i+1)``, horizontal
    ``(t, i) -> (t+1, i)`` (next query frame, same database frame) and
    vertical ``(t, i) -> (t, i+1)`` (same query frame, next database frame,
    both neighbours of ``q_t``); database steps ``i -> i+1`` only inside one
    clip. A source is linked to every node of query frame 0 and the DAG is
    solved in topological order (query frame, then database index), in
    linear time (plus one sort per frame). A path's cost is the sum of its
    node costs, so it equals the classic subsequence-DTW cost of the same
    warping path; when every cell of the optimal subsequence-DTW path is a
    reported neighbour, the best LNG match is that path.

    Ties are broken deterministically, exactly as in
    :func:`mocapkit.search.dtw.subsequence_dtw`: a node prefers the diagonal
    predecessor, then the vertical one (the database advance), then the
    horizontal one (the query advance); in query frame 0 a node always starts
    a path; candidate ends are taken by cost, then database index.

    Parameters
    ----------
    knn_idx : int array (M, K)
        Database indices of the neighbours of each query frame (negative: none).
    knn_dist : float array (M, K)
        Their distances (local costs), >= 0; non-finite: no neighbour.
    clip_ids : int array (N,), optional
        Clip of every database frame; None: one clip.
    k : int
        Number of matches wanted.
    max_overlap : int
        Number of database frames a match may share with a better one already
        accepted. Ends in query frame ``M-1`` are visited by increasing cost,
        backtracked, and kept if they overlap no accepted match by more.

    Returns
    -------
    list of Match
        At most ``k``, best first; path rows (query frame, database frame).
        Empty when no path spans all query frames.

    Examples
    --------
    >>> import numpy as np
    >>> idx = np.array([[10, 3], [11, 7], [12, 4]])
    >>> dist = np.array([[0.5, 1.0], [0.25, 1.0], [0.5, 2.0]])
    >>> [m] = lazy_neighborhood_graph(idx, dist)
    >>> m.start, m.end, m.cost
    (10, 12, 1.25)
    >>> m.path.tolist()
    [[0, 10], [1, 11], [2, 12]]
    """
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be a positive integer, got {k!r}")
    if isinstance(max_overlap, bool) or not isinstance(max_overlap, (int, np.integer)) or max_overlap < 0:
        raise ValueError(f"max_overlap must be a non-negative integer, got {max_overlap!r}")
    clip, has_clip = _check_clip_ids(clip_ids)
    idx, dist = _check_knn(knn_idx, knn_dist, 2, clip.shape[0] if has_clip else None)
    M = idx.shape[0]
    if M == 0:
        return []
    s_idx, s_dist, cost, start, s_pos, slot_of, pred, kind = _lng_workspace(*idx.shape)
    cnt = _lng_kernel(idx, dist, _sort_order(idx, dist), clip, has_clip,
                      s_idx, s_dist, cost, start, s_pos, slot_of, pred, kind)
    n = int(cnt[M - 1])
    end_cost = cost[M - 1, :n]
    end_idx = s_idx[M - 1, :n]
    end_start = start[M - 1, :n]
    order = np.lexsort((end_idx, end_cost))
    matches: list[Match] = []
    for j in order:
        c = float(end_cost[j])
        if not np.isfinite(c) or len(matches) >= k:
            break
        s, e = int(end_start[j]), int(end_idx[j])
        if any(min(e, m.end) - max(s, m.start) + 1 > max_overlap for m in matches):
            continue
        matches.append(Match(s, e, c, _lng_backtrack(s_idx, pred, kind, M - 1, int(j))))
    return matches


# -- OLNG (Tautges 2012, sec. 3.4.3) ----------------------------------------------------


@numba.njit(cache=True)
def _olng_push(idx, dist, order, clip, has_clip, c, n_steps, pf,
               col_idx, col_dist, col_cnt, col_pen, G, BP, s_pos, slot_of,
               last_cost, last_age, out):
    """Add column ``c`` (0-based count of pushed frames) to the ring buffers; fill ``out`` (K,)."""
    W = G.shape[0]
    K = idx.shape[0]
    slot = c % W
    n = _sort_column(idx, dist, order, col_idx[slot], col_dist[slot], s_pos, slot_of)
    col_cnt[slot] = n
    maxd = 0.0
    for j in range(n):
        if col_dist[slot, j] > maxd:
            maxd = col_dist[slot, j]
    col_pen[slot] = pf * maxd
    amax = min(c, W - 1)
    # shortness penalty for a path that started `a` columns ago: the window
    # columns c-amax .. c-a-1 before its first node.
    pen = np.zeros(W)
    acc = 0.0
    for a in range(amax, -1, -1):
        pen[a] = acc
        if a >= 1:
            acc += col_pen[(c - a) % W]
    prev1 = (c - 1) % W
    prev2 = (c - 2) % W
    n1 = col_cnt[prev1] if amax >= 1 else 0
    n2 = col_cnt[prev2] if amax >= 2 else 0
    ptr = np.zeros(n_steps, dtype=np.int64)
    for j in range(n):
        i = col_idx[slot, j]
        d = col_dist[slot, j]
        g = G[slot, j]
        bp = BP[slot, j]
        for a in range(W):
            g[a] = np.inf
            bp[a] = -1
        r = -1  # consecutive frames before i in its clip (up to 4), computed when first needed
        for s in range(n_steps):
            dc = _STEP_DC[s]
            di = _STEP_DI[s]
            if dc > amax:
                continue
            if dc == 1:
                col = prev1
                ncol = n1
                extra = 0.0
            else:
                col = prev2
                ncol = n2
                extra = d  # an edge skipping a column costs the node it points at
            target = i - di
            p = ptr[s]
            while p < ncol and col_idx[col, p] < target:
                p += 1
            ptr[s] = p
            if p < ncol and col_idx[col, p] == target:
                if r < 0:
                    r = _run_back(i, clip, has_clip, 4)
                if di > r:
                    continue
                src = G[col, p]
                code = p * 2 + (dc - 1)
                for a in range(dc, amax + 1):
                    v = src[a - dc] + extra
                    if v < g[a]:
                        g[a] = v
                        bp[a] = code
        g[0] = 0.0
        best = np.inf
        best_a = 0
        for a in range(amax, -1, -1):  # ties: the longer path
            if g[a] < np.inf:
                g[a] = g[a] + d
                tot = g[a] + pen[a]
                if tot < best:
                    best = tot
                    best_a = a
        last_cost[j] = best
        last_age[j] = best_a
    for k in range(K):
        j = slot_of[k]
        out[k] = last_cost[j] if j >= 0 else np.inf
    return n


@numba.njit(cache=True)
def _olng_backtrack(col_idx, BP, c, L, nodes, ages):
    """Frames (n, L) of the best paths ending at nodes ``nodes`` of column ``c`` with start offsets ``ages``."""
    W = BP.shape[0]
    frames = np.full((nodes.shape[0], L), -1, dtype=np.int64)
    first = c - L + 1
    for r in range(nodes.shape[0]):
        t = c
        j = nodes[r]
        a = ages[r]
        while True:
            slot = t % W
            frames[r, t - first] = col_idx[slot, j]
            code = BP[slot, j, a]
            if code < 0:
                break
            dc = (code & 1) + 1
            j = code >> 1
            t -= dc
            a -= dc
    return frames


@numba.njit(cache=True)
def _olng_scratch(knn_idx, knn_dist, order, clip, has_clip, n_steps, pf):
    """From-scratch OLNG costs of the last column: one DAG solve per start column."""
    L, K = knn_idx.shape
    s_idx = np.empty((L, K), dtype=np.int64)
    s_dist = np.empty((L, K), dtype=np.float64)
    s_pos = np.empty((L, K), dtype=np.int64)
    slot_of = np.empty((L, K), dtype=np.int64)
    cnt = np.empty(L, dtype=np.int64)
    colpen = np.zeros(L)
    for t in range(L):
        cnt[t] = _sort_column(knn_idx[t], knn_dist[t], order[t], s_idx[t], s_dist[t], s_pos[t], slot_of[t])
        m = 0.0
        for j in range(cnt[t]):
            m = max(m, s_dist[t, j])
        colpen[t] = pf * m
    out = np.full(K, np.inf)
    if L == 0:
        return out
    best = np.full(K, np.inf)
    H = np.empty((L, K))
    penalty = 0.0
    for s in range(L):  # first column of the path
        if s > 0:
            penalty += colpen[s - 1]
        H[:, :] = np.inf
        for j in range(cnt[s]):
            H[s, j] = s_dist[s, j]
        for c in range(s + 1, L):
            for j in range(cnt[c]):
                i = s_idx[c, j]
                d = s_dist[c, j]
                r = _run_back(i, clip, has_clip, 4)
                h = np.inf
                for st in range(n_steps):
                    dc = _STEP_DC[st]
                    di = _STEP_DI[st]
                    cp = c - dc
                    if cp < s or di > r:
                        continue
                    n = cnt[cp]
                    p = np.searchsorted(s_idx[cp, :n], i - di)
                    if p < n and s_idx[cp, p] == i - di:
                        v = H[cp, p] + (d if dc == 2 else 0.0)
                        if v < h:
                            h = v
                if h < np.inf:
                    H[c, j] = h + d
        for j in range(cnt[L - 1]):
            v = H[L - 1, j] + penalty
            if v < best[j]:
                best[j] = v
    for k in range(K):
        j = slot_of[L - 1, k]
        if j >= 0:
            out[k] = best[j]
    return out


def _check_olng_params(window, penalty_factor):
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 1:
        raise ValueError(f"window must be a positive integer, got {window!r}")
    pf = float(penalty_factor)
    if not np.isfinite(pf) or pf < 0:
        raise ValueError(f"penalty_factor must be a finite number >= 0, got {penalty_factor!r}")
    return int(window), pf


def online_lng_costs(knn_idx, knn_dist, clip_ids=None, extra_steps: bool = True, penalty_factor: float = 2.0):
    """OLNG costs of the newest frame's neighbours, computed from scratch on one window (Tautges 2012, sec. 3.4.3).

    The rows of ``knn_idx`` are the window, oldest first; the result rates
    the neighbours of the last row exactly as
    :meth:`OnlineLazyNeighborhoodGraph.push` does after pushing these rows
    (see the class for the cost definition). Solves the DAG once per start
    column: ``O(W^2 K log K)``; the online class is ``O(W K)`` per frame.

    Parameters
    ----------
    knn_idx : int array (W, K)
        Neighbours of the window's query frames (negative: none).
    knn_dist : float array (W, K)
        Their distances, >= 0 (non-finite: none).
    clip_ids : int array (N,), optional
        Clip of every database frame; None: one clip.
    extra_steps : bool
        Also allow the two-column steps ``(2, 2), (2, 3), (2, 4)`` (Fig. 3.10 c).
    penalty_factor : float
        Shortness penalty per uncovered column, times its largest distance.

    Returns
    -------
    float array (K,)
        Best path cost to each neighbour of the last row; ``inf`` if missing.

    Examples
    --------
    >>> import numpy as np
    >>> online_lng_costs(np.array([[5, 20], [6, 40], [7, 41]]),
    ...                  np.array([[1.0, 1.0], [0.25, 1.0], [0.5, 1.0]])).tolist()
    [1.75, 4.0]
    """
    clip, has_clip = _check_clip_ids(clip_ids)
    _, pf = _check_olng_params(1, penalty_factor)
    idx, dist = _check_knn(knn_idx, knn_dist, 2, clip.shape[0] if has_clip else None)
    return _olng_scratch(idx, dist, _sort_order(idx, dist), clip, has_clip, 6 if extra_steps else 3, pf)


class OnlinePath(NamedTuple):
    """A best path of the online lazy neighbourhood graph ending at a neighbour of the newest frame.

    Attributes
    ----------
    cost : float
        Its total cost (nodes, skip edges and shortness penalty).
    frames : int array (L,)
        Database frame of the path in each column of the window (oldest
        first, ``L = min(len(graph), window)``), -1 where it has no node
        (before its start or in a skipped column).
    """

    cost: float
    frames: np.ndarray


class OnlineLazyNeighborhoodGraph:
    """Online lazy neighbourhood graph over a stream of kNN answers (Tautges 2012, sec. 3.4.3, Figs. 3.7-3.10).

    Keeps the neighbours of the last ``window`` query frames (the columns;
    ``t`` a column, ``i`` a database index) and, after each :meth:`push`,
    rates every neighbour of the newest frame by the cheapest path ending
    there. Definition:

    * **Steps** (valid continuations) ``(t, i) -> (t + dt, i + di)`` for
      ``(dt, di)`` in ``(1, 1), (1, 2), (2, 1)``, and with ``extra_steps``
      also ``(2, 2), (2, 3), (2, 4)``; frames ``i .. i + di`` must be
      consecutive frames of one clip. The column index grows strictly, which
      limits the warping.
    * **Path cost** = sum of its node distances + edge costs (an edge that
      skips a column, ``dt = 2``, costs the distance of the node it points
      at; others cost 0) + shortness penalty: ``penalty_factor`` times the
      largest distance of every window column before the path's first node
      (its K-th neighbour; missing ones and duplicates aside; 0 for a column
      without neighbours). Columns skipped inside the
      path are charged by their skip edge only.
    * Paths lie entirely in the window: the columns pushed so far, at most
      the last ``window`` ones.

    This is computed exactly, not by the thesis' greedy extension: every node
    keeps, per start offset ``s`` in ``[0, window)``, the cost of the best path
    that started ``s`` columns before it, so a push costs
    ``O(K * window * steps)`` after sorting the column, and its result equals
    :func:`online_lng_costs` on the same window. Ties: the step listed first,
    then the longer path.

    Parameters
    ----------
    clip_ids : int array (N,), optional
        Clip of every database frame; None: one clip.
    window : int
        Number of columns ``M``; 13 gave the smallest reconstruction error in
        Tautges 2012, Fig. 3.19 (about half a second at 25 fps).
    extra_steps : bool
        Use the three extra two-column steps (Fig. 3.10 c).
    penalty_factor : float
        Weight of the K-th neighbour's distance per uncovered column (2 in the thesis, Fig. 3.8).

    Examples
    --------
    >>> g = OnlineLazyNeighborhoodGraph(window=3)
    >>> g.push([5, 20], [1.0, 1.0]).tolist()
    [1.0, 1.0]
    >>> g.push([6, 40], [0.25, 1.0]).tolist()  # 5 -> 6; 40 alone: 1 + penalty 2 * 1
    [1.25, 3.0]
    >>> g.push([7, 41], [0.5, 1.0]).tolist()  # 5 -> 6 -> 7 (skip 5 -> 7 costs 1 + 0.5 + 0.5)
    [1.75, 4.0]
    >>> g.best_paths(1)[0].frames.tolist()
    [5, 6, 7]
    """

    def __init__(self, clip_ids=None, window: int = 13, extra_steps: bool = True, penalty_factor: float = 2.0):
        self.window, self.penalty_factor = _check_olng_params(window, penalty_factor)
        self._clip, self._has_clip = _check_clip_ids(clip_ids)
        self.extra_steps = bool(extra_steps)
        self._n_steps = 6 if self.extra_steps else 3
        self._K: int | None = None
        self.reset()

    def reset(self) -> None:
        """Forget all pushed frames (the number of neighbours K may change afterwards)."""
        self._n = 0
        self._K = None
        self._nodes = np.zeros(0, dtype=np.int64)
        self._costs = np.zeros(0)

    def _alloc(self, K: int) -> None:
        W = self.window
        self._K = K
        self._col_idx = np.zeros((W, K), dtype=np.int64)
        self._col_dist = np.zeros((W, K))
        self._col_cnt = np.zeros(W, dtype=np.int64)
        self._col_pen = np.zeros(W)
        self._G = np.full((W, K, W), np.inf)
        self._BP = np.full((W, K, W), -1, dtype=np.int32 if 2 * K < 2**31 else np.int64)
        self._s_pos = np.zeros(K, dtype=np.int64)
        self._slot_of = np.zeros(K, dtype=np.int64)
        self._last_cost = np.zeros(K)
        self._last_age = np.zeros(K, dtype=np.int64)

    def __len__(self) -> int:
        """Number of frames pushed since construction or :meth:`reset`."""
        return self._n

    def __repr__(self) -> str:
        return (f"OnlineLazyNeighborhoodGraph(window={self.window}, extra_steps={self.extra_steps}, "
                f"penalty_factor={self.penalty_factor}, pushed={self._n}, K={self._K})")

    @property
    def current_nodes(self) -> np.ndarray:
        """Database indices (K,) of the last push, as given (read-only)."""
        return self._nodes

    @property
    def costs(self) -> np.ndarray:
        """Costs (K,) returned by the last push (read-only)."""
        return self._costs

    def push(self, knn_idx, knn_dist) -> np.ndarray:
        """Add the neighbours of the next query frame and rate them.

        Parameters
        ----------
        knn_idx : int array (K,)
            Database indices of its neighbours (negative: none); K must stay
            the same until :meth:`reset` (pad with -1).
        knn_dist : float array (K,)
            Their distances, >= 0 (non-finite: none).

        Returns
        -------
        float array (K,)
            For each input position, the cost of the best path ending at that
            neighbour in the current window; ``inf`` where there is none.
        """
        idx, dist = _check_knn(knn_idx, knn_dist, 1, self._clip.shape[0] if self._has_clip else None)
        K = idx.shape[0]
        if self._K is None:
            self._alloc(K)
        elif K != self._K:
            raise ValueError(f"knn_idx: expected shape ({self._K},) as in earlier pushes, got {idx.shape}")
        out = np.empty(K)
        _olng_push(idx, dist, _sort_order(idx, dist), self._clip, self._has_clip, self._n, self._n_steps,
                   self.penalty_factor, self._col_idx, self._col_dist, self._col_cnt, self._col_pen, self._G, self._BP,
                   self._s_pos, self._slot_of, self._last_cost, self._last_age, out)
        self._n += 1
        idx.setflags(write=False)
        out.setflags(write=False)
        self._nodes = idx
        self._costs = out
        return out

    def best_paths(self, n: int) -> list[OnlinePath]:
        """The ``n`` cheapest paths ending in the newest column, best first (ties: lower database index).

        One path per distinct neighbour of the newest frame (duplicates count
        once, missing ones never); fewer than ``n`` if there are fewer.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n must be a non-negative integer, got {n!r}")
        if self._n == 0:
            return []
        c = self._n - 1
        slot = c % self.window
        cnt = int(self._col_cnt[slot])
        costs = self._last_cost[:cnt]
        order = np.lexsort((self._col_idx[slot, :cnt], costs))[:n]
        L = min(self._n, self.window)
        frames = _olng_backtrack(self._col_idx, self._BP, c, L, order.astype(np.int64), self._last_age[order])
        return [OnlinePath(float(costs[j]), f) for j, f in zip(order, frames)]
