"""Fat-graph base poses in O(n log n) by fixed-radius kNN (Krüger et al. 2010, sec. 5.3).

Shin and Oh's fat graphs (2006) need "base poses", a clustering of the
database poses, which they compute with quadratic effort. Krüger et al.
replace it by kd-tree searches: (1) for every frame, its neighbours within a
radius ``r``, at most ``k`` of them, in O(k n log n); (2) the pose with the
most neighbours becomes a base pose, in O(n). Repeating step 2 on the frames
not yet covered by a base pose's neighbourhood gives the whole set of base
poses; the neighbour lists are reused, so the loop stays O(k n).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .knn import KNNIndex

__all__ = ["BasePoses", "fat_graph_base_poses"]


@dataclass(frozen=True, eq=False)
class BasePoses:
    """Base poses and the clusters they stand for.

    Attributes
    ----------
    indices : int64 array (B,)
        Database frames chosen as base poses, in the order they were chosen
        (most neighbours first).
    labels : int64 array (N,)
        For every frame, the number (into ``indices``) of the base pose whose
        neighbourhood covered it first; -1 for frames never covered (only
        when ``max_poses`` stopped early, or for non-finite features).
    counts : int64 array (N,)
        Neighbours within the radius of every frame (itself included, capped at ``k``).
    """

    indices: np.ndarray
    labels: np.ndarray
    counts: np.ndarray

    def __len__(self) -> int:
        return int(self.indices.shape[0])


@numba.njit(cache=True)
def _greedy_cover(nbr: np.ndarray, counts: np.ndarray, max_poses: int):
    """Pick frames by decreasing uncovered-neighbour count until every frame is covered.

    ``nbr`` (N, k) neighbour lists (-1 padded; with the cap ``k`` the relation
    need not be symmetric, so a reverse adjacency tells whose counts drop when
    a frame is covered). Uses a lazy max-heap over the live counts (counts
    only decrease), so the whole loop is O(k n log n).
    """
    N, K = nbr.shape
    # reverse adjacency in CSR form: rev[rptr[j]:rptr[j+1]] = frames h with j in nbr[h]
    rptr = np.zeros(N + 1, dtype=np.int64)
    for h in range(N):
        for a in range(K):
            j = nbr[h, a]
            if j >= 0:
                rptr[j + 1] += 1
    for j in range(N):
        rptr[j + 1] += rptr[j]
    rev = np.empty(rptr[N], dtype=np.int64)
    fill = rptr[:N].copy()
    for h in range(N):
        for a in range(K):
            j = nbr[h, a]
            if j >= 0:
                rev[fill[j]] = h
                fill[j] += 1
    covered = np.zeros(N, dtype=np.bool_)
    live = counts.copy()
    labels = np.full(N, -1, dtype=np.int64)
    # heap of (-count, index) as two parallel arrays
    heap_c = np.empty(N, dtype=np.int64)
    heap_i = np.empty(N, dtype=np.int64)
    size = 0
    order = np.argsort(-counts, kind="mergesort")
    for j in range(N):
        i = order[j]
        if counts[i] > 0:
            heap_c[size] = -counts[i]
            heap_i[size] = i
            size += 1
    # the sorted array already satisfies the heap property
    chosen = np.empty(N, dtype=np.int64)
    nchosen = 0
    while size > 0 and nchosen < max_poses:
        c, i = -heap_c[0], heap_i[0]
        # pop
        size -= 1
        heap_c[0] = heap_c[size]
        heap_i[0] = heap_i[size]
        p = 0
        while True:
            l = 2 * p + 1
            r = l + 1
            m = p
            if l < size and (heap_c[l] < heap_c[m] or (heap_c[l] == heap_c[m] and heap_i[l] < heap_i[m])):
                m = l
            if r < size and (heap_c[r] < heap_c[m] or (heap_c[r] == heap_c[m] and heap_i[r] < heap_i[m])):
                m = r
            if m == p:
                break
            heap_c[p], heap_c[m] = heap_c[m], heap_c[p]
            heap_i[p], heap_i[m] = heap_i[m], heap_i[p]
            p = m
        if covered[i] or live[i] <= 0:
            continue
        if c != live[i]:  # stale entry: push back with the current count
            heap_c[size] = -live[i]
            heap_i[size] = i
            q = size
            size += 1
            while q > 0:
                par = (q - 1) // 2
                if heap_c[q] < heap_c[par] or (heap_c[q] == heap_c[par] and heap_i[q] < heap_i[par]):
                    heap_c[q], heap_c[par] = heap_c[par], heap_c[q]
                    heap_i[q], heap_i[par] = heap_i[par], heap_i[q]
                    q = par
                else:
                    break
            continue
        chosen[nchosen] = i
        if not covered[i]:  # a pose covers itself even if the cap k left it out of its own list
            covered[i] = True
            labels[i] = nchosen
            for b in range(rptr[i], rptr[i + 1]):
                live[rev[b]] -= 1
        for a in range(K):
            j = nbr[i, a]
            if j < 0 or covered[j]:
                continue
            covered[j] = True
            labels[j] = nchosen
            # j no longer counts towards the uncovered totals of the frames listing it
            for b in range(rptr[j], rptr[j + 1]):
                live[rev[b]] -= 1
        nchosen += 1
    return chosen[:nchosen], labels


def fat_graph_base_poses(
    features,
    radius: float,
    k: int = 64,
    max_poses: int | None = None,
    index: KNNIndex | None = None,
    workers: int = 1,
) -> BasePoses:
    """Base poses of a fat graph by fixed-radius kNN (Krüger et al. 2010, sec. 5.3).

    Every frame's neighbours within ``radius`` (at most ``k``, itself
    included) are searched once; then the frame whose neighbourhood covers
    the most not-yet-covered frames is taken as a base pose, its
    neighbourhood is marked covered, and so on until all frames are covered
    (or ``max_poses`` are chosen). The first pick is exactly the paper's
    "pose with maximum number of neighbours".

    Parameters
    ----------
    features : float array (N, D)
        Frame features (e.g. ``db.features["F15"]``, centimetres).
    radius : float
        Neighbourhood radius in feature units.
    k : int
        Most neighbours per frame.
    max_poses : int, optional
        Stop after this many base poses.
    index : KNNIndex, optional
        A prebuilt index over ``features``.

    Returns
    -------
    BasePoses

    Examples
    --------
    >>> x = np.array([[0.0], [0.1], [0.2], [5.0], [5.1], [9.0]])
    >>> bp = fat_graph_base_poses(x, radius=0.15, k=8)
    >>> bp.indices.tolist(), bp.labels.tolist(), bp.counts.tolist()
    ([1, 3, 5], [0, 0, 0, 1, 1, 2], [2, 3, 2, 2, 2, 1])
    """
    x = np.asarray(features, dtype=np.float64)
    if x.ndim != 2:
        raise ValueError(f"features: expected shape (N, D), got {x.shape}")
    if not radius > 0:
        raise ValueError(f"radius must be > 0, got {radius}")
    index = index or KNNIndex(x)
    _, nbr = index.query(x, k=k, radius=radius, workers=workers)
    counts = (nbr >= 0).sum(axis=1).astype(np.int64)
    chosen, labels = _greedy_cover(np.ascontiguousarray(nbr), counts, x.shape[0] if max_poses is None else int(max_poses))
    return BasePoses(chosen.astype(np.int64), labels, counts)
