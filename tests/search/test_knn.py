"""KNNIndex against brute force: random data, real features, radius, exclusion, NaN, backends."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit.search.knn import KNNIndex


def naive_knn(data, q, k, radius=np.inf, exclude=None):
    """Sort all distances per query in plain numpy; ties by index."""
    out_d, out_i = [], []
    for n, x in enumerate(q):
        d = np.sqrt(((data - x) ** 2).sum(axis=1))
        d[~np.isfinite(d)] = np.inf
        if exclude is not None:
            lo, hi = exclude[n]
            d[lo:hi] = np.inf
        order = np.lexsort((np.arange(len(d)), d))[:k]
        dd, ii = d[order], order.copy()
        ii[~(dd <= radius)] = -1
        dd[~(dd <= radius)] = np.inf
        pad = k - len(dd)
        out_d.append(np.concatenate([dd, np.full(pad, np.inf)]))
        out_i.append(np.concatenate([ii, np.full(pad, -1)]))
    return np.array(out_d), np.array(out_i, dtype=np.int64)


def assert_same_neighbours(d, i, d_ref, i_ref, atol=1e-9):
    np.testing.assert_allclose(d, d_ref, rtol=0, atol=atol)
    # indices agree except where distances tie
    differ = i != i_ref
    assert np.all(np.isclose(d[differ], d_ref[differ], atol=atol))


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 60),
    dim=st.integers(1, 6),
    k=st.integers(1, 8),
    seed=st.integers(0, 2**31),
    backend=st.sampled_from(["kdtree", "brute"]),
)
def test_random_data_equals_naive(n, dim, k, seed, backend):
    rng = np.random.default_rng(seed)
    data = rng.normal(size=(n, dim))
    q = rng.normal(size=(7, dim))
    d, i = KNNIndex(data, backend=backend).query(q, k=k)
    assert_same_neighbours(d, i, *naive_knn(data, q, k))


def test_real_features_equal_brute_force(small_db):
    data = np.asarray(small_db.features["F15"])
    rng = np.random.default_rng(1)
    q = data[rng.integers(0, len(data), 300)] + rng.normal(0, 1.0, size=(300, 15))
    for k in (1, 16, 64):
        d, i = KNNIndex(data).query(q, k=k)
        db_, ib = KNNIndex(data, backend="brute").query(q, k=k)
        assert_same_neighbours(d, i, db_, ib)


def test_radius_returns_at_most_k_within_radius(rng):
    data = rng.normal(size=(500, 3))
    q = rng.normal(size=(40, 3))
    for backend in ("kdtree", "brute"):
        d, i = KNNIndex(data, backend=backend).query(q, k=10, radius=0.5)
        ref = naive_knn(data, q, 10, radius=0.5)
        assert_same_neighbours(d, i, *ref)
        assert np.all(d[i >= 0] <= 0.5) and np.all(i[np.isinf(d)] == -1)
        assert (i == -1).any(), "a radius this small must leave some slots empty"


def test_exclude_range_per_query(rng):
    data = np.cumsum(rng.normal(size=(400, 4)), axis=0)
    rows = np.array([5, 100, 399, 0])
    q = data[rows]
    exclude = np.stack([np.maximum(rows - 7, 0), rows + 8], axis=1)
    for backend in ("kdtree", "brute"):
        d, i = KNNIndex(data, backend=backend).query(q, k=5, exclude=exclude)
        assert_same_neighbours(d, i, *naive_knn(data, q, 5, exclude=exclude))
        for n, (lo, hi) in enumerate(exclude):
            assert not np.any((i[n] >= lo) & (i[n] < hi))


def test_one_exclude_range_for_all_queries(rng):
    data = rng.normal(size=(100, 2))
    d, i = KNNIndex(data).query(data[:10], k=3, exclude=(0, 50))
    assert np.all(i >= 50)


def test_nan_rows_and_queries(rng):
    data = rng.normal(size=(50, 3))
    data[[3, 17]] = np.nan
    q = rng.normal(size=(4, 3))
    q[1] = np.nan
    for backend in ("kdtree", "brute"):
        d, i = KNNIndex(data, backend=backend).query(q, k=48)
        assert not np.isin(i, [3, 17]).any()
        assert np.all(i[1] == -1) and np.all(np.isinf(d[1]))
        # 48 finite rows exist: every slot of a finite query is filled
        assert np.all(i[[0, 2, 3]] >= 0)
        assert_same_neighbours(d[[0, 2, 3]], i[[0, 2, 3]], *naive_knn(data, q[[0, 2, 3]], 48))


def test_more_neighbours_than_points(rng):
    data = rng.normal(size=(5, 2))
    d, i = KNNIndex(data).query(data[:1], k=8)
    assert sorted(i[0, :5]) == [0, 1, 2, 3, 4] and np.all(i[0, 5:] == -1)


def test_approximate_distances_within_eps(rng):
    data = rng.normal(size=(3000, 8))
    q = rng.normal(size=(100, 8))
    index = KNNIndex(data)
    d_exact, _ = index.query(q, k=10)
    d_apx, _ = index.query(q, k=10, eps=0.5)
    assert np.all(d_apx <= d_exact * 1.5 + 1e-12)


def test_faiss_backend_agrees(rng):
    pytest.importorskip("faiss")
    data = rng.normal(size=(2000, 15))
    q = rng.normal(size=(50, 15))
    d, i = KNNIndex(data, backend="faiss").query(q, k=16)
    d_ref, i_ref = KNNIndex(data).query(q, k=16)
    np.testing.assert_allclose(d, d_ref, rtol=1e-4)
    assert (i == i_ref).mean() > 0.99
    d, i = KNNIndex(data, backend="faiss").query(q, k=16, radius=float(np.median(d_ref[:, 8])), exclude=(0, 100))
    assert np.all((i == -1) | (i >= 100))


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"k": 0}, "k must be a positive integer"),
        ({"eps": -1}, "eps must be"),
        ({"radius": 0}, "radius must be"),
        ({"exclude": [(0, 1)] * 3}, "exclude: expected"),
    ],
)
def test_bad_arguments(rng, kwargs, message):
    index = KNNIndex(rng.normal(size=(20, 3)))
    with pytest.raises(ValueError, match=message):
        index.query(rng.normal(size=(2, 3)), **kwargs)


def test_bad_shapes(rng):
    index = KNNIndex(rng.normal(size=(20, 3)))
    with pytest.raises(ValueError, match=r"points: expected shape \(Q, 3\)"):
        index.query(rng.normal(size=(2, 4)))
    with pytest.raises(ValueError, match="unknown kNN backend"):
        KNNIndex(rng.normal(size=(20, 3)), backend="annoy")
