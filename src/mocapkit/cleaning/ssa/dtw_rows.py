"""The constrained word DTW's distance, row by row: the same number as ``word_dtw._word_dtw`` with less memory.

The nearest-word search (section 3.3 of Aristidou et al. 2018,
:func:`mocapkit.cleaning.ssa.word_dtw.word_knn_profile`) runs the appendix's
constrained DTW on a hundred or more target positions per source word and
needs only its distance and end cell, never the path. The full kernel fills
(N, M, 7) tables of cumulative cost and path length; a cell depends only on
its own row and the row above, so two rows of (M, 7) suffice: about a
seventh of the memory per DTW (it stays in the first-level cache), and each
state of a cell is written once, from registers, instead of set to ``inf``
and then overwritten.

Every cumulative cost, path length, comparison and tie-break is done in the
order of ``_word_dtw`` (same states, same ``<`` tests, the last-row end cells
before the last-column ones), so the returned ``(mean, i_end, j_end)`` is the
same, bit for bit; ``tests/cleaning/ssa/test_dtw_rows.py`` checks it against
that kernel and against path enumeration.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["best_state", "word_dtw_rows"]

_INF = np.inf


@njit(cache=True, inline="always")
def best_state(acc, ln, r, j):
    """The lowest accumulated cost over the 7 states of cell ``(r, j)`` and its path length (1 where all are inf).

    ``acc`` float (R, M, 7), ``ln`` int (R, M, 7): the rows of :func:`word_dtw_rows` or the whole matrix of
    the full word DTW. Ties keep the lowest state, as every reader of the states does.
    """
    best = _INF
    bl = 1
    for s in range(7):
        v = acc[r, j, s]
        if v < best:
            best = v
            bl = ln[r, j, s]
    return best, bl


@njit(cache=True)
def word_dtw_rows(C, si, tj, N, M, min_width, max_run, acc, ln, col_best, col_len):
    """Constrained DTW distance of the block ``C[si:si+N, tj:tj+M]``: ``(mean cost, i_end, j_end)``.

    C : 2-D local costs (float32 or float64; a cell of ``inf`` is impassable);
    the block's source word is rows ``si..si+N-1``, the target word columns
    ``tj..tj+M-1`` (N <= M). Constraints (a)-(e) of the appendix, as in
    :mod:`mocapkit.cleaning.ssa.word_dtw` (seven states per cell: diagonal,
    1-3 horizontal, 1-3 vertical steps in a row). ``acc`` (2, M, 7) float64,
    ``ln`` (2, M, 7) int64, ``col_best`` (>= N,) float64, ``col_len`` (>= N,)
    int64 are scratch. Returns (inf, -1, -1) when no admissible path exists.
    """
    for i in range(N):
        cur = i & 1
        prv = 1 - cur
        for j in range(M):
            c = C[si + i, tj + j]
            a0 = _INF
            a1 = _INF
            a2 = _INF
            a3 = _INF
            a4 = _INF
            a5 = _INF
            a6 = _INF
            l0 = 0
            l1 = 0
            l2 = 0
            l3 = 0
            l4 = 0
            l5 = 0
            l6 = 0
            if i == 0 and j == 0:
                a0 = c
                l0 = 1
            else:
                if i > 0 and j > 0:  # diagonal from any state of (i-1, j-1)
                    best, bl = best_state(acc, ln, prv, j - 1)
                    if best < _INF:
                        a0 = best + c
                        l0 = bl + 1
                if j > 0 and i < N - 1:  # horizontal (0, 1), not from the last row
                    best = _INF
                    bl = 0
                    for s in (0, 4, 5, 6):
                        v = acc[cur, j - 1, s]
                        if v < best:
                            best = v
                            bl = ln[cur, j - 1, s]
                    if best < _INF:
                        a1 = best + c
                        l1 = bl + 1
                    if max_run >= 2:
                        v = acc[cur, j - 1, 1]
                        if v < _INF:
                            a2 = v + c
                            l2 = ln[cur, j - 1, 1] + 1
                    if max_run >= 3:
                        v = acc[cur, j - 1, 2]
                        if v < _INF:
                            a3 = v + c
                            l3 = ln[cur, j - 1, 2] + 1
                if i > 0 and j < M - 1:  # vertical (1, 0), not from the last column
                    best = _INF
                    bl = 0
                    for s in (0, 1, 2, 3):
                        v = acc[prv, j, s]
                        if v < best:
                            best = v
                            bl = ln[prv, j, s]
                    if best < _INF:
                        a4 = best + c
                        l4 = bl + 1
                    if max_run >= 2:
                        v = acc[prv, j, 4]
                        if v < _INF:
                            a5 = v + c
                            l5 = ln[prv, j, 4] + 1
                    if max_run >= 3:
                        v = acc[prv, j, 5]
                        if v < _INF:
                            a6 = v + c
                            l6 = ln[prv, j, 5] + 1
            acc[cur, j, 0] = a0
            acc[cur, j, 1] = a1
            acc[cur, j, 2] = a2
            acc[cur, j, 3] = a3
            acc[cur, j, 4] = a4
            acc[cur, j, 5] = a5
            acc[cur, j, 6] = a6
            ln[cur, j, 0] = l0
            ln[cur, j, 1] = l1
            ln[cur, j, 2] = l2
            ln[cur, j, 3] = l3
            ln[cur, j, 4] = l4
            ln[cur, j, 5] = l5
            ln[cur, j, 6] = l6
        # this row's last-column cell, an end cell when the target word finishes here
        best, bl = best_state(acc, ln, cur, M - 1)
        col_best[i] = best
        col_len[i] = bl
    best_mean = _INF
    bi = -1
    bj = -1
    last = (N - 1) & 1
    lo = min_width - 1
    for x in range(max(lo, 0), M):  # ends on the last row (source finished)
        best, bl = best_state(acc, ln, last, x)
        if best < _INF:
            mean = best / bl
            if mean < best_mean:
                best_mean = mean
                bi = N - 1
                bj = x
    for x in range(max(lo, 0), N - 1):  # then on the last column (target finished); the corner came with the last row
        best = col_best[x]
        if best < _INF:
            mean = best / col_len[x]
            if mean < best_mean:
                best_mean = mean
                bi = x
                bj = M - 1
    return best_mean, bi, bj
