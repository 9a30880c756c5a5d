"""The constrained word DTW's distance, row by row: the same number as ``word_dtw._word_dtw`` with less work.

The nearest-word search (section 3.3 of Aristidou et al. 2018,
:func:`mocapkit.cleaning.ssa.word_dtw.word_knn_profile`) runs the appendix's
constrained DTW on a hundred or more target positions per source word and
needs only its distance and end cell, never the path. The full kernel fills
(N, M, 7) tables of cumulative cost and path length, one entry per state
(the last step diagonal, or one to three horizontal or vertical steps in a
row). A cell depends only on its own row and the row above, and its
neighbours read only a few things of it: the cell to its right the best of
its states 0, 4, 5, 6 (a horizontal step may follow a diagonal or vertical
one) and its states 1 and 2; the cell below the best of states 0-3 and
states 4 and 5; the cell below-right the best of all seven. So each cell's
seven states are computed in registers, and only those aggregates are kept:
for the row above, :data:`ROW_STATES` per column (best of all, best of
0-3, states 4 and 5); along the row, three carried values. Each aggregate
is the first minimum in state order (strict ``<``), as a scan of the seven
states in the full kernel picks it.

A state no path reaches holds ``inf``; adding a cost to it keeps it ``inf``
(costs are finite or ``inf``, never NaN), so no state is tested before it is
extended, and a path length that rides along an ``inf`` is never read.
Every cumulative cost, path length, comparison and tie-break is otherwise
that of ``_word_dtw`` (the last-row end cells before the last-column ones),
so the returned ``(mean, i_end, j_end)`` is the same, bit for bit;
``tests/cleaning/ssa/test_dtw_rows.py`` checks it against that kernel and
against path enumeration.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["best_state", "word_dtw_rows", "ROW_STATES"]

_INF = np.inf
#: Values kept per column of the row above by :func:`word_dtw_rows` (the last axis of its ``acc`` and ``ln``).
ROW_STATES = 4


@njit(cache=True, inline="always")
def best_state(acc, ln, r, j):
    """The lowest accumulated cost over the 7 states of cell ``(r, j)`` and its path length (1 where all are inf).

    ``acc`` float (R, M, 7), ``ln`` int (R, M, 7): the tables of the full word DTW (``word_dtw._word_dtw``).
    Ties keep the lowest state, as every reader of the states does.
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

    C : 2-D local costs (float32 or float64, no NaN; a cell of ``inf`` is
    impassable); the block's source word is rows ``si..si+N-1``, the target
    word columns ``tj..tj+M-1`` (N <= M). Constraints (a)-(e) of the appendix,
    as in :mod:`mocapkit.cleaning.ssa.word_dtw` (seven states per cell:
    diagonal, 1-3 horizontal, 1-3 vertical steps in a row). ``acc`` (2, M,
    :data:`ROW_STATES`) float64, ``ln`` (2, M, :data:`ROW_STATES`) int64,
    ``col_best`` (>= N,) float64, ``col_len`` (>= N,) int64 are scratch.
    Returns (inf, -1, -1) when no admissible path exists.
    """
    for i in range(N):
        cur = i & 1
        prv = 1 - cur
        hB = _INF  # of the cell to the left: the best of its states 0, 4, 5, 6, and its states 1 and 2
        hL = 0
        h1 = _INF
        h1L = 0
        h2 = _INF
        h2L = 0
        for j in range(M):
            c = C[si + i, tj + j]
            a0 = a1 = a2 = a3 = a4 = a5 = a6 = _INF  # the cell's seven states (module docstring)
            l0 = l1 = l2 = l3 = l4 = l5 = l6 = 0
            if i == 0 and j == 0:
                a0 = c
                l0 = 1
            else:
                if i > 0 and j > 0:  # diagonal from any state of (i-1, j-1)
                    a0 = acc[prv, j - 1, 0] + c
                    l0 = ln[prv, j - 1, 0] + 1
                if j > 0 and i < N - 1:  # horizontal (0, 1), not from the last row
                    a1 = hB + c
                    l1 = hL + 1
                    if max_run >= 2:
                        a2 = h1 + c
                        l2 = h1L + 1
                    if max_run >= 3:
                        a3 = h2 + c
                        l3 = h2L + 1
                if i > 0 and j < M - 1:  # vertical (1, 0), not from the last column
                    a4 = acc[prv, j, 1] + c
                    l4 = ln[prv, j, 1] + 1
                    if max_run >= 2:
                        a5 = acc[prv, j, 2] + c
                        l5 = ln[prv, j, 2] + 1
                    if max_run >= 3:
                        a6 = acc[prv, j, 3] + c
                        l6 = ln[prv, j, 3] + 1
            m1, m1L = a1, l1  # the first minimum of states 1-3, and of states 4-6
            if a2 < m1:
                m1, m1L = a2, l2
            if a3 < m1:
                m1, m1L = a3, l3
            m4, m4L = a4, l4
            if a5 < m4:
                m4, m4L = a5, l5
            if a6 < m4:
                m4, m4L = a6, l6
            vB, vL = a0, l0  # what a vertical step reads: states 0-3
            if m1 < vB:
                vB, vL = m1, m1L
            hB, hL = a0, l0  # what a horizontal step reads: states 0, 4, 5, 6
            if m4 < hB:
                hB, hL = m4, m4L
            bB, bL = vB, vL  # what a diagonal step and an end cell read: all seven
            if m4 < bB:
                bB, bL = m4, m4L
            h1, h1L, h2, h2L = a1, l1, a2, l2
            acc[cur, j, 0] = bB
            acc[cur, j, 1] = vB
            acc[cur, j, 2] = a4
            acc[cur, j, 3] = a5
            ln[cur, j, 0] = bL
            ln[cur, j, 1] = vL
            ln[cur, j, 2] = l4
            ln[cur, j, 3] = l5
        # this row's last-column cell, an end cell when the target word finishes here
        col_best[i] = acc[cur, M - 1, 0]
        col_len[i] = ln[cur, M - 1, 0]
    best_mean = _INF
    bi = -1
    bj = -1
    last = (N - 1) & 1
    lo = min_width - 1
    for x in range(max(lo, 0), M):  # ends on the last row (source finished)
        best = acc[last, x, 0]
        if best < _INF:
            mean = best / ln[last, x, 0]
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
