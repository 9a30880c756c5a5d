"""Tests of mocapkit.cleaning.ssa.ordering: numpy's partition and stable argsort, exactly."""

from __future__ import annotations

import numpy as np

from mocapkit.cleaning.ssa.ordering import kth_smallest, sort_by_key


def test_kth_smallest_is_numpys_partition(rng):
    for n in (1, 2, 7, 64, 65, 300):
        for fill in (None, np.inf, np.nan):
            x = np.round(rng.normal(size=n), 1)  # ties
            if fill is not None:
                x[rng.random(n) < 0.3] = fill
            for k in {1, min(n, 5), min(n, 64), n}:
                got, want = kth_smallest(x, k, np.empty(k)), np.partition(x, k - 1)[k - 1]
                assert got == want or (np.isnan(got) and np.isnan(want))


def test_sort_by_key_is_a_stable_argsort(rng):
    for n in (0, 1, 2, 3, 17, 64, 200):
        key = np.round(rng.normal(size=300), 1)  # ties
        key[rng.random(300) < 0.1] = np.inf
        idx = np.sort(rng.choice(300, size=n, replace=False)).astype(np.int64)
        want = idx[np.argsort(key[idx], kind="mergesort")]
        got = idx.copy()
        sort_by_key(got, key, np.empty_like(got))
        assert np.array_equal(got, want)


def test_sort_by_key_is_a_stable_argsort_across_runs_and_merges(rng):
    """Long inputs (the kNN search sorts 1,000-1,400 bounds): insertion-sorted runs, merges, runs already in
    order, ties that straddle runs and infinite keys, each against numpy's stable argsort."""
    for n in (15, 16, 17, 31, 32, 33, 100, 1000, 1421):
        for kind in ("random", "ascending", "descending", "few"):
            key = rng.normal(size=1500)
            if kind == "ascending":
                key = np.sort(key)
            elif kind == "descending":
                key = np.sort(key)[::-1].copy()
            elif kind == "few":
                key = rng.integers(0, 3, size=1500).astype(np.float64)  # long runs of ties
            key[rng.random(1500) < 0.05] = np.inf
            idx = np.sort(rng.choice(1500, size=n, replace=False)).astype(np.int64)
            want = idx[np.argsort(key[idx], kind="mergesort")]
            got = idx.copy()
            sort_by_key(got, key, np.empty_like(got))
            assert np.array_equal(got, want), (n, kind)
