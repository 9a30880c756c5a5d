"""The cheap first bound of the word DTW: never above the sorting bound, so never above the distance."""

import numpy as np
import pytest

from mocapkit import rotations as R
from mocapkit.cleaning.ssa import word_dtw as W
from mocapkit.cleaning.ssa.word_bounds import cheap_bound


def _rowmin(D, tgt, N, M, run):
    lens, level = W._row_windows(N, M, run)
    rowmin = np.empty((len(lens), D.shape[0], len(tgt)), dtype=np.float32)
    W._row_minima.serial(D, tgt, lens, rowmin)
    return rowmin, level


@pytest.mark.parametrize("N, M, mw, run", [(15, 20, 11, 3), (10, 12, 8, 1), (15, 20, 11, 0), (6, 9, 0, 2)])
def test_cheap_bound_under_the_sorting_bound_and_the_distance(rng, N, M, mw, run):
    A = R.quaternion_normalize(rng.normal(size=(40, 5, 4)))
    B = R.quaternion_normalize(rng.normal(size=(60, 5, 4)))
    B[33, 1] = np.nan  # impassable cells: the bound of a word through them is that of its rows before
    D = W.group_pose_distances(A, B, np.ones((1, 5), dtype=bool), [1])[0]
    src = np.arange(0, 40 - N + 1, 3)
    tgt = np.arange(0, 60 - M + 1)
    rowmin, level = _rowmin(D, tgt, N, M, run)
    cheap = np.array([[cheap_bound(rowmin, level, s, t, N, mw, float(run + 1)) for t in range(len(tgt))] for s in src])
    tight = W.word_dtw_lower_bounds(D, src, tgt, N, M, mw, run)
    dist = W.word_distance_profile(D, src, tgt, N, M, mw, run)[0].astype(np.float64)
    assert np.all(cheap <= tight * (1 + 1e-12))
    fin = np.isfinite(dist)
    assert np.all(cheap[fin] <= dist[fin] * (1 + 1e-6))
    assert np.all(np.isinf(cheap) <= np.isinf(dist))  # inf only where no path is finite
    assert np.mean(cheap[fin] / dist[fin]) > 0.2  # and not a trivial bound


def test_cheap_bound_of_equal_rows_is_their_value():
    """Rows all costing r: every path's mean is r, and so is the bound."""
    D = np.full((15, 25), 0.25, dtype=np.float32)
    rowmin, level = _rowmin(D, np.arange(6), 15, 20, 3)
    assert cheap_bound(rowmin, level, 0, 2, 15, 11, 4.0) == pytest.approx(0.25)


@pytest.mark.parametrize("N, M, mw, run", [(15, 20, 11, 3), (10, 12, 8, 1), (6, 9, 0, 2)])
def test_cheap_bounds_at_every_position_are_cheap_bound_bit_for_bit(rng, N, M, mw, run):
    """The row-by-row form over all target positions gives each position's cheap_bound, inf rows included."""
    from numba import njit

    from mocapkit.cleaning.ssa.word_bounds import cheap_bounds

    @njit(cache=False)
    def every(rowmin, level, s, N, mw, wmax, T):
        best = np.empty(T)
        cheap_bounds(rowmin, level, s, N, mw, wmax, np.empty(T), np.empty(T), best, np.empty(T, dtype=np.bool_))
        return best

    A = R.quaternion_normalize(rng.normal(size=(40, 5, 4)))
    B = R.quaternion_normalize(rng.normal(size=(60, 5, 4)))
    B[33, 1] = np.nan
    A[20, 2] = np.nan  # a source row of inf costs: the bound stops there
    D = W.group_pose_distances(A, B, np.ones((1, 5), dtype=bool), [1])[0]
    tgt = np.arange(0, 60 - M + 1)
    rowmin, level = _rowmin(D, tgt, N, M, run)
    for s in range(0, 40 - N + 1, 2):
        want = np.array([cheap_bound(rowmin, level, s, t, N, mw, float(run + 1)) for t in range(len(tgt))])
        got = every(rowmin, level, s, N, mw, float(run + 1), len(tgt))
        assert np.array_equal(got, want)
