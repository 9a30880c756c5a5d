"""A cheap first lower bound of the constrained word DTW distance (the first stage of a bound cascade).

The nearest-word search of section 3.3 (Aristidou et al. 2018;
:func:`mocapkit.cleaning.ssa.word_dtw.word_knn_profile`) ranks a source word
against every target position of a take and runs the DTW only where a lower
bound does not already prove the position too far. As in the UCR suite
(Rakthanmanon et al. 2012, "Searching and mining trillions of time series
subsequences under dynamic time warping"), bounds are tried cheapest first:
this one costs a pass over the word's rows without sorting, and only the
positions it cannot rule out pay for the tighter, sorting bound of
``word_dtw`` and then for the DTW itself.

The bound. An admissible path visits every row ``0..e`` (``e >= min_width - 1``)
with weights ``w_i`` in ``[1, wmax]`` cells each (``wmax = max_run + 1``), and
every cell of row ``i`` in the columns it can reach costs at least the row's
minimum ``r_i >= 0``. With ``n = e + 1``, ``S = r_0 + ... + r_e`` and
``mu = min r_i``, the path's mean cost is at least
``sum w_i r_i / sum w_i >= mu + (S - n mu) / sum w_i >= mu + (S - n mu) / (wmax n)``
(the first step since ``w_i - 1 >= 0`` multiplies values ``>= mu``, the
second since ``S >= n mu``). The smallest of these over the admissible ``e``
bounds the word distance; it is never above the sorting bound, which
optimises the weights exactly.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["cheap_bound", "cheap_bounds"]

_INF = np.inf


@njit(cache=True, inline="always")
def cheap_bound(rowmin, level, s, t, N, min_width, wmax):
    """Lower bound of the word distance of the source word at row ``s`` and target position ``t``.

    rowmin : (L, rows, T) float32 row minima over the column windows of
    increasing length, level : (N,) which window each source row uses (as
    ``word_dtw`` builds them); wmax = max_run + 1. Returns float64, ``inf``
    when no finite path reaches an admissible end row.
    """
    best = _INF
    lo = min_width - 1 if min_width >= 1 else 0
    total = 0.0
    mu = _INF
    for i in range(N):
        v = rowmin[level[i], s + i, t]
        if not v < _INF:
            return best  # no finite path reaches past row i
        total += v
        if v < mu:
            mu = v
        if i >= lo:
            n = i + 1
            m = mu + (total - n * mu) / (wmax * n)
            if m < best:
                best = m
    return best


@njit(cache=True, inline="always")
def cheap_bounds(rowmin, level, s, N, min_width, wmax, total, mu, best, alive):
    """:func:`cheap_bound` of the source word at row ``s`` against every target position at once, into ``best``.

    The same arithmetic per position, run row by row over all positions (SIMD lanes) instead of position by
    position: ``best`` (T,) float64 gets exactly what ``cheap_bound(rowmin, level, s, t, ...)`` returns for each
    ``t``. ``total``, ``mu`` (T,) float64 and ``alive`` (T,) bool are scratch.
    """
    T = best.shape[0]
    lo = min_width - 1 if min_width >= 1 else 0
    for t in range(T):
        best[t] = _INF
        total[t] = 0.0
        mu[t] = _INF
        alive[t] = True
    for i in range(N):
        row = rowmin[level[i], s + i]
        scored = i >= lo
        n = i + 1
        for t in range(T):
            v = row[t]
            a = alive[t] and v < _INF  # no finite path reaches past row i: best stays as it is
            alive[t] = a
            tot = total[t] + v
            m0 = mu[t]
            m1 = v if v < m0 else m0
            if a:
                total[t] = tot
                mu[t] = m1
            if a and scored:
                m = m1 + (tot - n * m1) / (wmax * n)
                if m < best[t]:
                    best[t] = m
