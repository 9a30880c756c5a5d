"""Statistics of each column of an (F, C) array over that column's own rows, all columns at once.

A gap prior judges every channel by its own observed frames (:func:`mocapkit.cleaning.deep.prior.clean_channels`,
:func:`~mocapkit.cleaning.deep.prior.raw_weight`): a mean, a median, a quantile of a different set of rows per
column. These give, bit for bit, what numpy's 1-D ``np.mean``, ``np.median`` and ``np.quantile`` (its default
``linear`` method) give on ``values[rows[:, c], c]``, so that reading the channels together changes no number:
a mean sums the columns with as many rows together along a contiguous last axis (numpy's pairwise sum, as on
one column); a median or quantile reads the column sorted. A column with no rows, or a NaN among them, gives NaN,
as numpy does (without its warning).
"""

from __future__ import annotations

import numpy as np

__all__ = ["column_means", "column_medians", "column_quantiles"]


def column_means(values: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """(C,) the mean of each column of (F, C) ``values`` over its ``rows`` (F, C) bool: ``np.mean`` of
    ``values[rows[:, c], c]``, NaN where a column has no rows."""
    n = rows.sum(axis=0)
    out = np.full(values.shape[1], np.nan)
    vt, rt = values.T, rows.T
    for k in np.unique(n[n > 0]):  # one sum per row count: the pairwise sum of a column depends on its length
        cols = np.flatnonzero(n == k)
        picked = np.ascontiguousarray(vt[cols][rt[cols]].reshape(len(cols), int(k)))
        out[cols] = np.add.reduce(picked, axis=1) / k
    return out


def _sorted(values: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(s, n, nan)``: (C, F) each column's rows sorted first (NaN after them), one column a contiguous row; (C,)
    how many rows; (C,) whether a NaN is among them."""
    s = np.ascontiguousarray(np.where(rows, values, np.nan).T)
    s.sort(axis=1)
    return s, rows.sum(axis=0), (rows & np.isnan(values)).any(axis=0)


def _at(s: np.ndarray, i: np.ndarray) -> np.ndarray:
    """(C,) ``s[c, i[c]]``, ``i`` clipped into ``s``'s rows."""
    return s[np.arange(len(s)), np.clip(i, 0, max(s.shape[1] - 1, 0))]


def column_medians(values: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """(C,) the median of each column of (F, C) ``values`` over its ``rows`` (F, C) bool: ``np.median`` of
    ``values[rows[:, c], c]`` (the middle row, or the mean of the two middle ones), NaN where a column has no rows
    or a NaN among them."""
    if values.shape[0] == 0:
        return np.full(values.shape[1], np.nan)
    s, n, nan = _sorted(values, rows)
    hi = _at(s, n // 2)
    lo = _at(s, n // 2 - 1)
    with np.errstate(invalid="ignore", over="ignore"):  # numpy's mean of the middle rows: a sum from +0
        med = np.where(n % 2 == 1, 0.0 + hi, (0.0 + lo + hi) / 2)
    return np.where(nan | (n == 0), np.nan, med)


def column_quantiles(values: np.ndarray, rows: np.ndarray, q: float) -> np.ndarray:
    """(C,) the ``q`` quantile of each column of (F, C) ``values`` over its ``rows`` (F, C) bool: ``np.quantile``
    of ``values[rows[:, c], c]`` by its ``linear`` method (Hyndman and Fan's 7th: at ``(n - 1) q`` in the sorted
    rows, the two around it interpolated as numpy does), NaN where a column has no rows or a NaN among them."""
    if values.shape[0] == 0:
        return np.full(values.shape[1], np.nan)
    s, n, nan = _sorted(values, rows)
    at = (n - 1) * np.float64(q)
    below = np.floor(at)
    gamma = at - below
    below = below.astype(np.int64)
    above = np.where(at >= n - 1, below, below + 1)
    a, b = _at(s, below), _at(s, above)
    with np.errstate(invalid="ignore", over="ignore"):
        diff = b - a
        out = np.where(gamma >= 0.5, b - diff * (1 - gamma), a + diff * gamma)
    return np.where(nan | (n == 0), np.nan, out)
