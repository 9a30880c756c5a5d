"""Order statistics for the pruned neighbour search of :func:`mocapkit.cleaning.ssa.word_dtw.word_knn_profile`.

Two numba kernels that do what numpy's ``np.partition`` and stable
``np.argsort`` do on the arrays the search sorts (the lower bounds of a
source word's distance to every target position), written out because
numba's builds of those numpy functions take seconds to compile, which a
first ``mocapkit clean`` with an empty cache pays. Both give numpy's answer
exactly (tests compare them).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["kth_smallest", "sort_by_key"]


@njit(cache=True)
def kth_smallest(x, k, heap):
    """The ``k``-th smallest value of ``x`` (1-based), what ``np.partition(x, k - 1)[k - 1]`` gives.

    A max-heap of the ``k`` smallest values in ``heap`` (a (k,) scratch
    buffer), O(len(x) log k). NaN sorts last, as in numpy: fewer than ``k``
    values that are not NaN give NaN. Written out rather than calling
    ``np.partition``, whose numba implementation takes seconds to compile.
    """
    n = 0
    for v in x:
        if v != v:
            continue
        if n < k:  # sift up
            c = n
            heap[c] = v
            n += 1
            while c > 0:
                parent = (c - 1) // 2
                if heap[parent] >= heap[c]:
                    break
                heap[parent], heap[c] = heap[c], heap[parent]
                c = parent
        elif v < heap[0]:  # replace the largest, sift down
            heap[0] = v
            c = 0
            while True:
                big = c
                a = 2 * c + 1
                b = a + 1
                if a < k and heap[a] > heap[big]:
                    big = a
                if b < k and heap[b] > heap[big]:
                    big = b
                if big == c:
                    break
                heap[big], heap[c] = heap[c], heap[big]
                c = big
    return heap[0] if n == k else np.nan


#: run length :func:`sort_by_key` sorts by insertion before merging
_RUN = 16


@njit(cache=True)
def sort_by_key(idx, key, tmp):
    """``idx`` (n,) int64 reordered in place so that ``key[idx]`` increases, ties in their order (a stable sort).

    What ``idx[np.argsort(key[idx], kind="mergesort")]`` gives for keys that
    are not NaN; written out because numba's ``argsort`` takes most of a
    second to compile. The keys are gathered once and move with their
    indices (no indirect load per comparison); runs of ``_RUN`` are sorted by
    insertion, then merged bottom-up, ``tmp`` (n,) as scratch, a merge of two
    runs already in order copied as it is. Stable throughout (an element
    moves before an earlier one only on a strictly smaller key), so the order
    is the stable sort's, tie for tie; 1.7x faster than a merge sort from
    single elements on the kNN search's bounds (1,000-1,400 per word).
    """
    n = idx.shape[0]
    if n < 2:
        return
    ka = np.empty(n)
    kb = np.empty(n)
    for q in range(n):
        ka[q] = key[idx[q]]
    for lo in range(0, n, _RUN):  # stable insertion sort of each run
        hi = min(lo + _RUN, n)
        for a in range(lo + 1, hi):
            v = ka[a]
            x = idx[a]
            b = a
            while b > lo and ka[b - 1] > v:
                ka[b] = ka[b - 1]
                idx[b] = idx[b - 1]
                b -= 1
            ka[b] = v
            idx[b] = x
    width = _RUN
    si, sk, di, dk = idx, ka, tmp, kb
    in_tmp = False
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            if mid >= hi or not sk[mid] < sk[mid - 1]:  # one run, or two already in order
                for q in range(lo, hi):
                    di[q] = si[q]
                    dk[q] = sk[q]
                continue
            a, b, o = lo, mid, lo
            while a < mid and b < hi:
                if sk[b] < sk[a]:
                    di[o] = si[b]
                    dk[o] = sk[b]
                    b += 1
                else:
                    di[o] = si[a]
                    dk[o] = sk[a]
                    a += 1
                o += 1
            while a < mid:
                di[o] = si[a]
                dk[o] = sk[a]
                a += 1
                o += 1
            while b < hi:
                di[o] = si[b]
                dk[o] = sk[b]
                b += 1
                o += 1
        si, di = di, si
        sk, dk = dk, sk
        in_tmp = not in_tmp
        width *= 2
    if in_tmp:
        for q in range(n):  # a loop: numba's slice assignment alone takes a second to compile
            idx[q] = tmp[q]
