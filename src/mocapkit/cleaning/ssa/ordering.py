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


@njit(cache=True)
def sort_by_key(idx, key, tmp):
    """``idx`` (n,) int64 reordered in place so that ``key[idx]`` increases, ties in their order (a stable sort).

    What ``idx[np.argsort(key[idx], kind="mergesort")]`` gives for keys that
    are not NaN; a bottom-up merge sort with ``tmp`` (n,) as scratch, written
    out because numba's ``argsort`` takes most of a second to compile.
    """
    n = idx.shape[0]
    width = 1
    src = idx
    dst = tmp
    in_tmp = False
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            a, b, o = lo, mid, lo
            while a < mid and b < hi:
                if key[src[b]] < key[src[a]]:
                    dst[o] = src[b]
                    b += 1
                else:
                    dst[o] = src[a]
                    a += 1
                o += 1
            while a < mid:
                dst[o] = src[a]
                a += 1
                o += 1
            while b < hi:
                dst[o] = src[b]
                b += 1
                o += 1
        src, dst = dst, src
        in_tmp = not in_tmp
        width *= 2
    if in_tmp:
        for q in range(n):  # a loop: numba's slice assignment alone takes a second to compile
            idx[q] = tmp[q]
