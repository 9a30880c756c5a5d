"""The row-by-row word DTW against the full-table kernel (bit for bit) and against path enumeration."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit.cleaning.ssa import word_dtw as W
from mocapkit.cleaning.ssa.dtw_rows import ROW_STATES, word_dtw_rows
from tests.naive import word_dtw_enumerate


def _rows(C, si, tj, N, M, min_width, max_run):
    """word_dtw_rows as the kNN profile calls it: float32 pose distances (the one signature the warm-up compiles)."""
    assert C.dtype == np.float32
    acc, ln = np.empty((2, M, ROW_STATES)), np.empty((2, M, ROW_STATES), dtype=np.int64)
    return word_dtw_rows(C, si, tj, N, M, min_width, max_run, acc, ln, np.empty(N), np.empty(N, dtype=np.int64))


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 15),
    extra=st.integers(0, 6),
    min_width=st.integers(0, 12),
    max_run=st.integers(0, 3),
    holes=st.floats(0.0, 0.3),
    seed=st.integers(0, 2**31 - 1),
)
def test_rows_equal_the_full_table_bit_for_bit(n, extra, min_width, max_run, holes, seed):
    rng = np.random.default_rng(seed)
    M = n + extra
    big = rng.random((n + 3, M + 5)).astype(np.float32)
    big[rng.random(big.shape) < holes] = np.inf  # impassable cells, as non-finite poses give
    si, tj = int(rng.integers(0, 4)), int(rng.integers(0, 6))
    acc, ln = np.empty((n, M, W.NUM_STATES)), np.empty((n, M, W.NUM_STATES), dtype=np.int64)
    want = W._word_dtw(big, si, tj, n, M, min_width, max_run, acc, ln)
    got = _rows(big, si, tj, n, M, min_width, max_run)
    assert got[1:] == want[1:]
    assert np.float64(got[0]).tobytes() == np.float64(want[0]).tobytes()


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 6), extra=st.integers(0, 3), min_width=st.integers(1, 6), max_run=st.integers(1, 3),
       seed=st.integers(0, 2**31 - 1))
def test_rows_equal_path_enumeration(n, extra, min_width, max_run, seed):
    C = np.random.default_rng(seed).random((n, n + extra)).astype(np.float32)
    d, i, j = _rows(C, 0, 0, n, n + extra, min_width, max_run)
    d0, i0, j0 = word_dtw_enumerate(C.astype(np.float64), min_width=min_width, max_run=max_run)
    if np.isinf(d0):
        assert np.isinf(d) and i == -1
    else:
        assert (i, j) == (i0, j0)
        assert d == pytest.approx(d0, rel=1e-12)


def test_no_admissible_path():
    C = np.full((15, 20), np.inf, dtype=np.float32)
    assert _rows(C, 0, 0, 15, 20, 11, 3) == (np.inf, -1, -1)
