"""Column statistics over each column's own rows (mocapkit.cleaning.deep.column_statistics): numpy's 1-D ones, bit
for bit, all columns at once."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from mocapkit.cleaning.deep.column_statistics import column_means, column_medians, column_quantiles


def _bits(a) -> bytes:
    """The bytes of ``a`` with every NaN one NaN (numpy's sign of a NaN is no number)."""
    a = np.asarray(a, dtype=np.float64)
    return np.where(np.isnan(a), np.nan, a).tobytes()


@pytest.mark.parametrize("seed", range(6))
def test_each_column_s_mean_median_and_quantile_are_numpy_s_of_its_own_rows(seed):
    """Columns of many lengths (pairwise sums of 8-128 and over), ties, zeros, inf and NaN among the rows, columns
    with as many rows (summed together), with one row and with none."""
    rng = np.random.default_rng(seed)
    F, C = [(1, 3), (7, 20), (9, 40), (300, 30), (2000, 25), (5000, 8)][seed]
    values = rng.normal(size=(F, C)) * 10.0 ** rng.uniform(-4, 4, size=C)
    values[:, ::5] = np.round(values[:, ::5], 1)
    values[rng.random((F, C)) < 0.01] = np.inf
    values[rng.random((F, C)) < 0.005] = np.nan
    values[rng.random((F, C)) < 0.05] = 0.0
    rows = rng.random((F, C)) < rng.uniform(0.0, 1.0, size=C)
    rows[:, : C // 3] = rows[:, :1]
    rows[:, -1] = False
    rows[:, -2] = np.arange(F) == F // 2
    got = column_means(values, rows), column_medians(values, rows), column_quantiles(values, rows, 0.25)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpy's empty-slice warning for the column with no rows
        want = [[f(values[rows[:, c], c]) for c in range(C)]
                for f in (np.mean, np.median, lambda v: np.quantile(v, 0.25) if len(v) else np.nan)]
    for g, w in zip(got, want):
        assert _bits(g) == _bits(w)


def test_quantiles_at_every_interpolation_step():
    """The linear method between two sorted rows: at 0, 1/4, 1/2 and 3/4 of the way (the two rounding branches of
    numpy's interpolation), at both ends of the range and on neighbouring floats."""
    rng = np.random.default_rng(7)
    values = rng.normal(size=(12, 40))
    values[:, 20:] = 1.0 + np.arange(12)[:, None] * np.finfo(float).eps  # neighbouring floats
    rows = np.arange(12)[:, None] < np.arange(40) % 12 + 1
    for q in (0.0, 0.25, 0.5, 0.75, 1.0, 0.1):
        want = [np.quantile(values[rows[:, c], c], q) for c in range(40)]
        assert _bits(column_quantiles(values, rows, q)) == _bits(want)
