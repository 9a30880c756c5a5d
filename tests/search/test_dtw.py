"""DTW kernels against the plain-Python full-matrix oracles in tests/naive.py."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mocapkit.search import Match
from mocapkit.search import dtw as dtw_mod
from mocapkit.search.dtw import (
    accumulated_cost,
    dtw,
    local_cost_matrix,
    subsequence_dtw,
    subsequence_dtw_costs,
)
from tests.naive import (
    naive_backtrack,
    naive_dtw,
    naive_k_best,
    naive_local_cost,
    naive_subsequence_dtw_matrix,
)

STEPS = ["classic", "tautges"]
SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def same(a, b, tol=1e-9):
    """Equal to ``tol`` (relative to the magnitude), with infinities in the same places."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape
    fa, fb = np.isfinite(a), np.isfinite(b)
    assert np.array_equal(fa, fb), (a, b)
    assert np.array_equal(a[~fa], b[~fb])
    np.testing.assert_allclose(a[fa], b[fb], rtol=tol, atol=tol)


@st.composite
def problems(draw, max_m=6, max_n=24, nan=True):
    """A random query/database pair with clips, excluded frames and NaN rows."""
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    M = draw(st.integers(1, max_m))
    N = draw(st.integers(1, max_n))
    D = draw(st.integers(1, 9))
    if draw(st.booleans()):
        # small integers: exact ties everywhere, which exercises the tie-breaking rules
        query = rng.integers(0, 2, (M, D)).astype(float)
        data = rng.integers(0, 2, (N, D)).astype(float)
    else:
        query = rng.standard_normal((M, D))
        data = rng.standard_normal((N, D))
    if nan and draw(st.booleans()):
        data[rng.random(N) < 0.15, rng.integers(D)] = np.nan
    if nan and draw(st.booleans()):
        query[rng.integers(M), rng.integers(D)] = np.nan
    clip_ids = np.cumsum(rng.random(N) < draw(st.sampled_from([0.0, 0.1, 0.3])))
    exclude = (rng.random(N) < 0.15) if draw(st.booleans()) else None
    return query, data, clip_ids, exclude


def path_cost(C, path, steps):
    """Accumulated cost of a path: classic sums the cells, Tautges weights by the query advance."""
    total = C[path[0][0], path[0][1]]
    for (i0, _), (i1, j1) in zip(path[:-1], path[1:]):
        w = (i1 - i0) if steps == "tautges" else 1
        total = total + w * C[i1, j1]
    return total


def check_steps(path, steps):
    d = np.diff(np.asarray(path), axis=0)
    allowed = {(1, 1), (1, 0), (0, 1)} if steps == "classic" else {(1, 1), (1, 2), (2, 1)}
    assert {tuple(r) for r in d.tolist()} <= allowed, d


# -- local costs -------------------------------------------------------------------------------


@SETTINGS
@given(problems())
def test_local_cost_matrix_equals_naive(prob):
    query, data, _, _ = prob
    same(local_cost_matrix(query, data), naive_local_cost(query, data), tol=0)


def test_local_cost_matrix_blocks(monkeypatch, rng):
    q = rng.standard_normal((7, 3))
    x = rng.standard_normal((50, 3))
    x[11] = np.inf
    full = local_cost_matrix(q, x)
    monkeypatch.setattr(dtw_mod, "_CHUNK_CELLS", 20)  # blocks of 2 database frames
    assert np.array_equal(local_cost_matrix(q, x), full)
    assert np.isinf(full[:, 11]).all() and np.isfinite(np.delete(full, 11, axis=1)).all()


# -- global DTW --------------------------------------------------------------------------------


@SETTINGS
@given(problems(max_m=7, max_n=9), st.sampled_from(STEPS))
def test_dtw_equals_naive(prob, steps):
    x, y, _, _ = prob
    cost, path = dtw(x, y, steps=steps)
    C = naive_local_cost(x, y)
    ncost, npath = naive_dtw(C, steps)
    same(cost, ncost)
    assert path.tolist() == [list(p) for p in npath]
    c2, p2 = dtw(cost=C, steps=steps)
    assert c2 == cost and np.array_equal(p2, path)
    if np.isfinite(cost):
        assert path[0].tolist() == [0, 0] and path[-1].tolist() == [len(x) - 1, len(y) - 1]
        check_steps(path, steps)
        same(path_cost(C, path, steps), cost)
    else:
        assert path.shape == (0, 2)


def test_tautges_never_skips_an_unusable_frame():
    x = np.array([[0.0], [1.0]])
    y = np.array([[0.0], [np.nan], [1.0]])
    assert dtw(x, y, steps="tautges")[0] == np.inf
    assert dtw(x, y[[0, 2]], steps="tautges")[0] == 0.0
    assert subsequence_dtw(x, y, steps="tautges") == []
    ex = np.array([False, True, False])
    y = np.array([[0.0], [0.5], [1.0]])
    assert subsequence_dtw(x, y, steps="tautges")[0].cost == 0.0
    assert subsequence_dtw(x, y, steps="tautges", exclude=ex) == []


def test_dtw_tautges_slope_limit():
    # 2 frames cannot be aligned to 5 with slopes in [1/2, 2]
    cost, path = dtw(np.zeros((2, 1)), np.zeros((5, 1)), steps="tautges")
    assert cost == np.inf and path.shape == (0, 2)
    cost, path = dtw(np.zeros((3, 1)), np.zeros((5, 1)), steps="tautges")
    assert cost == 0.0 and path.tolist() == [[0, 0], [1, 2], [2, 4]]


# -- accumulated cost and its O(N) last row ---------------------------------------------------


@SETTINGS
@given(problems(), st.sampled_from(STEPS))
def test_accumulated_cost_equals_naive(prob, steps):
    query, data, clip_ids, exclude = prob
    C = naive_local_cost(query, data)
    D_naive, pred = naive_subsequence_dtw_matrix(C, clip_ids, steps, exclude)
    D = accumulated_cost(query, data, clip_ids, steps=steps, exclude=exclude)
    same(D, D_naive)
    same(accumulated_cost(None, None, clip_ids, steps=steps, cost=C, exclude=exclude), D_naive)
    costs, starts = subsequence_dtw_costs(query, data, clip_ids, steps=steps, exclude=exclude)
    assert np.array_equal(costs, D[-1])
    M = len(query)
    for m in range(len(data)):
        if np.isfinite(costs[m]):
            assert starts[m] == naive_backtrack(pred, M - 1, m)[0][1]
        else:
            assert starts[m] == -1


def test_tie_breaking():
    # all costs zero: the diagonal wins, then the database step, then the query step
    costs, starts = subsequence_dtw_costs(np.zeros((2, 1)), np.zeros((3, 1)))
    assert costs.tolist() == [0.0, 0.0, 0.0] and starts.tolist() == [0, 0, 1]
    costs, starts = subsequence_dtw_costs(np.zeros((3, 1)), np.zeros((4, 1)), steps="tautges")
    assert costs.tolist() == [np.inf, 0.0, 0.0, 0.0] and starts.tolist() == [-1, 0, 0, 1]
    C = np.zeros((3, 4))
    C[1, 2] = 1.0  # Tautges, cell (2, 3): (1, 2) from (1, 1) [start 0] beats (2, 1) from (0, 2) [start 2]
    assert subsequence_dtw_costs(None, None, steps="tautges", cost=C)[1].tolist() == [-1, 0, 0, 0]
    C = np.zeros((3, 3))
    assert dtw(cost=C)[1].tolist() == [[0, 0], [1, 1], [2, 2]]
    C[1, 1] = 1.0  # at (2, 2) the database step from (2, 1) beats the query step from (1, 2)
    assert dtw(cost=C)[1].tolist() == [[0, 0], [1, 0], [2, 1], [2, 2]]
    # equal end costs: the earlier end comes first
    (m,) = subsequence_dtw(np.zeros((1, 1)), np.zeros((3, 1)))
    assert (m.start, m.end) == (0, 0)


def test_accumulated_cost_hand_example():
    # Müller's subsequence DTW: free start in row 0, unit weights
    C = np.array([[1.0, 0.0, 2.0], [2.0, 1.0, 0.0]])
    assert accumulated_cost(None, None, cost=C).tolist() == [[1.0, 0.0, 2.0], [3.0, 1.0, 0.0]]
    # a clip starting at frame 1: (1, 1) can only come from (0, 1)
    D = accumulated_cost(None, None, clip_ids=[0, 1, 1], cost=C)
    assert D.tolist() == [[1.0, 0.0, 2.0], [3.0, 1.0, 0.0]]
    D = accumulated_cost(None, None, clip_ids=[0, 0, 1], cost=C)
    assert D.tolist() == [[1.0, 0.0, 2.0], [3.0, 1.0, 2.0]]
    # Tautges: first column infinite below row 0, D(1, 2) by the (1, 2) step from (0, 0),
    # D(2, 1) by the (2, 1) step from (0, 0) paying 2 * C(2, 1)
    C = np.array([[0.0, 5.0, 5.0], [1.0, 1.0, 1.0], [1.0, 3.0, 0.5]])
    D = accumulated_cost(None, None, steps="tautges", cost=C)
    assert D.tolist() == [[0.0, 5.0, 5.0], [np.inf, 1.0, 1.0], [np.inf, 6.0, 1.5]]
    assert dtw(cost=C, steps="tautges")[1].tolist() == [[0, 0], [1, 1], [2, 2]]


# -- k best matches ----------------------------------------------------------------------------


@SETTINGS
@given(problems(max_m=5, max_n=30), st.sampled_from(STEPS), st.integers(1, 4), st.sampled_from([0, 0, 2]))
def test_k_best_equal_oracle(prob, steps, k, max_overlap):
    query, data, clip_ids, exclude = prob
    found = subsequence_dtw(query, data, clip_ids, k=k, steps=steps, exclude=exclude, max_overlap=max_overlap)
    if not np.isfinite(query).all():
        assert found == []
        return
    C = naive_local_cost(query, data)
    expected = naive_k_best(C, clip_ids, steps, exclude, k, max_overlap)
    assert [(m.start, m.end) for m in found] == [(s, e) for s, e, _, _ in expected]
    ties = np.array_equal(data[np.isfinite(data)], np.round(data[np.isfinite(data)]))
    for m, (_, _, cost, path) in zip(found, expected):
        same(m.cost, cost)
        if not ties:
            # the restricted DTW may pick another optimal path only when costs tie
            assert m.path.tolist() == [list(p) for p in path]
    # the precomputed-cost route gives the same matches
    again = subsequence_dtw(None, None, clip_ids, k=k, steps=steps, exclude=exclude, cost=C, max_overlap=max_overlap)
    assert [(m.start, m.end, m.cost) for m in again] == [(m.start, m.end, m.cost) for m in found]


@SETTINGS
@given(problems(max_m=6, max_n=60), st.sampled_from(STEPS), st.integers(1, 6))
def test_match_properties(prob, steps, k):
    query, data, clip_ids, exclude = prob
    query = np.nan_to_num(query)
    found = subsequence_dtw(query, data, clip_ids, k=k, steps=steps, exclude=exclude)
    C = local_cost_matrix(query, data)
    bad = ~np.isfinite(data).all(axis=1)
    if exclude is not None:
        bad |= exclude
    costs = [m.cost for m in found]
    assert costs == sorted(costs)
    for i, m in enumerate(found):
        assert isinstance(m, Match)
        p = m.path
        assert p[0, 0] == 0 and p[-1, 0] == len(query) - 1
        assert p[0, 1] == m.start and p[-1, 1] == m.end
        check_steps(p, steps)
        # one clip, no unusable frame anywhere in the range
        assert len(set(clip_ids[m.start : m.end + 1].tolist())) == 1
        assert not bad[m.start : m.end + 1].any()
        # the cost is the (weighted) sum of local costs along the path ...
        same(path_cost(C, p.tolist(), steps), m.cost)
        # ... and exactly the cost of a global DTW restricted to the matched range
        assert dtw(query, data[m.start : m.end + 1], steps=steps)[0] == m.cost
        for other in found[:i]:
            assert not m.overlaps(other)
        if steps == "tautges":
            slope = (m.end - m.start) / max(1, len(query) - 1)
            assert 0.5 <= slope <= 2.0 or len(query) == 1


def _planted(rng, idx, n_before=7, n_after=5, D=3):
    """A database of noise with ``base[idx]`` planted after ``n_before`` frames."""
    base = rng.standard_normal((max(idx) + 1, D))
    data = np.concatenate([rng.standard_normal((n_before, D)) + 10, base[idx], rng.standard_normal((n_after, D)) + 10])
    return base, data


@pytest.mark.parametrize("seed", range(5))
def test_planted_stretched_match_classic(seed):
    rng = np.random.default_rng(seed)
    M = 12
    # the database plays the query slower: interior frames repeated up to 3 times
    reps = np.r_[1, rng.integers(1, 4, M - 2), 1]
    idx = np.repeat(np.arange(M), reps)
    query, data = _planted(rng, idx)
    (m,) = subsequence_dtw(query, data)
    assert (m.start, m.end, m.cost) == (7, 7 + len(idx) - 1, 0.0)
    assert m.path.tolist() == [[int(q), 7 + j] for j, q in enumerate(idx)]
    # and the query playing slower than the database: query frames repeated
    q_idx = np.repeat(np.arange(M), reps)
    base, data = _planted(rng, np.arange(M))
    (m,) = subsequence_dtw(base[q_idx], data)
    assert (m.start, m.end, m.cost) == (7, 7 + M - 1, 0.0)
    assert m.path.tolist() == [[n, 7 + int(q)] for n, q in enumerate(q_idx)]


@pytest.mark.parametrize("seed", range(8))
def test_planted_stretched_match_tautges(seed):
    rng = np.random.default_rng(seed)
    M = 15
    # plant along a random Tautges path: a (1, 2) step repeats the current query frame in the
    # database (slower), a (2, 1) step drops a query frame (faster)
    idx, n, first = [0], 0, True
    while n < M - 1:
        step = rng.integers(0, 3) if n + 2 <= M - 1 else rng.integers(0, 2)
        if step == 1 and first:
            step = 0  # a repeated first frame would make the start ambiguous
        first = False
        if step == 1:
            idx.append(n)
        n += 2 if step == 2 else 1
        idx.append(n)
    base, data = _planted(rng, idx)
    (m,) = subsequence_dtw(base, data, steps="tautges")
    assert (m.start, m.end, m.cost) == (7, 7 + len(idx) - 1, 0.0)
    check_steps(m.path, "tautges")
    # every aligned pair is the same pose
    assert all(idx[j - 7] == n for n, j in m.path.tolist())


def test_exclude_and_clip_boundaries():
    rng = np.random.default_rng(3)
    query = rng.standard_normal((6, 2))
    data = np.concatenate([query, rng.standard_normal((4, 2)), query])
    (m,) = subsequence_dtw(query, data)
    assert (m.start, m.cost) == (0, 0.0)
    ex = np.zeros(len(data), bool)
    ex[2] = True
    for steps in STEPS:
        (m,) = subsequence_dtw(query, data, exclude=ex, steps=steps)
        assert (m.start, m.end, m.cost) == (10, 15, 0.0)
    # a clip boundary in the middle of the second copy hides it too
    clip = np.r_[np.zeros(13, int), np.ones(3, int)]
    for steps in STEPS:
        (m,) = subsequence_dtw(query, data, clip, exclude=ex, steps=steps)
        assert m.cost > 0
        assert len(set(clip[m.start : m.end + 1])) == 1 and not ex[m.start : m.end + 1].any()


def test_nan_handling():
    rng = np.random.default_rng(0)
    query = rng.standard_normal((4, 3))
    data = np.concatenate([rng.standard_normal((5, 3)), query, rng.standard_normal((5, 3))])
    q_nan = query.copy()
    q_nan[2, 1] = np.nan
    for steps in STEPS:
        assert subsequence_dtw(q_nan, data, steps=steps) == []
    data[6, 0] = np.nan  # inside the planted copy
    for steps in STEPS:
        for m in subsequence_dtw(query, data, k=3, steps=steps):
            assert not (m.start <= 6 <= m.end)
        costs, starts = subsequence_dtw_costs(query, data, steps=steps)
        assert np.isinf(costs[6]) and starts[6] == -1
    C = local_cost_matrix(query, data)
    C[0, 3] = np.nan  # a NaN in a precomputed cost matrix is an infinite cost
    D = accumulated_cost(None, None, cost=C)
    assert np.isinf(D[0, 3]) and np.isfinite(D[0, 4])


def test_max_overlap_allows_shifted_copies():
    rng = np.random.default_rng(1)
    query = rng.standard_normal((5, 2))
    data = np.concatenate([rng.standard_normal((3, 2)), query, rng.standard_normal((3, 2))])
    disjoint = subsequence_dtw(query, data, k=5)
    shifted = subsequence_dtw(query, data, k=5, max_overlap=4)
    assert all(not a.overlaps(b) for i, a in enumerate(disjoint) for b in disjoint[:i])
    assert disjoint[0].cost == shifted[0].cost == 0.0
    assert any(a.overlaps(shifted[0]) for a in shifted[1:])
    assert all(
        min(a.end, b.end) - max(a.start, b.start) + 1 <= 4 for i, a in enumerate(shifted) for b in shifted[:i]
    )


def test_larger_database_agrees_with_full_matrix():
    # many columns through the O(N) kernels, candidate selection beyond its first block
    rng = np.random.default_rng(7)
    query = rng.standard_normal((9, 4))
    data = rng.standard_normal((3000, 4))
    clip = np.repeat(np.arange(30), 100)
    for steps in STEPS:
        D = accumulated_cost(query, data, clip, steps=steps)
        costs, starts = subsequence_dtw_costs(query, data, clip, steps=steps)
        assert np.array_equal(costs, D[-1])
        found = subsequence_dtw(query, data, clip, k=40, steps=steps)
        assert len(found) == 40
        ends = np.array([m.end for m in found])
        assert np.array_equal(np.array([m.cost for m in found]), costs[ends])
        assert np.array_equal(np.array([m.start for m in found]), starts[ends])
        assert found[0].cost == costs.min()


# -- input checks --------------------------------------------------------------------------------


def test_input_errors():
    q = np.zeros((3, 2))
    x = np.zeros((10, 2))
    with pytest.raises(ValueError, match=r"query: expected shape \(M, D\), got \(3,\)"):
        subsequence_dtw(np.zeros(3), x)
    with pytest.raises(ValueError, match="data: expected 2 feature columns"):
        subsequence_dtw(q, np.zeros((10, 3)))
    with pytest.raises(ValueError, match="steps"):
        subsequence_dtw(q, x, steps="fast")
    with pytest.raises(ValueError, match="clip_ids"):
        subsequence_dtw(q, x, clip_ids=np.zeros(9, int))
    with pytest.raises(ValueError, match="exclude"):
        subsequence_dtw(q, x, exclude=np.zeros(10, int))
    with pytest.raises(ValueError, match="k:"):
        subsequence_dtw(q, x, k=0)
    with pytest.raises(ValueError, match="max_overlap"):
        subsequence_dtw(q, x, max_overlap=-1)
    with pytest.raises(ValueError, match="not both"):
        subsequence_dtw(q, x, cost=np.zeros((3, 10)))
    with pytest.raises(ValueError, match="non-negative"):
        accumulated_cost(None, None, cost=-np.ones((3, 10)))
    with pytest.raises(ValueError, match="at least one frame"):
        subsequence_dtw_costs(np.zeros((0, 2)), x)
    with pytest.raises(ValueError, match="cost"):
        dtw(cost=np.zeros(3))
    assert subsequence_dtw(q, np.zeros((0, 2))) == []


def test_each_kernel_compiles_once_whatever_the_shapes():
    """One row, one column or many, with costs given or computed, recorded or not: one signature per kernel (numba
    types an array both C- and F-contiguous as C, so an F-ordered argument of one row or column compiled anew).

    Writable arrays alone: a database's read-only (memory-mapped) features are a type of their own to numba, the
    second signature :func:`mocapkit.warmup` compiles, which a database test run earlier in the same process (as
    pytest-xdist's scheduling may put it) has made already."""
    from numba.types import Array

    rng = np.random.default_rng(4)
    for M, N in ((1, 1), (1, 6), (5, 1), (4, 7)):
        q, x = rng.standard_normal((M, 3)), rng.standard_normal((N, 3))
        C = local_cost_matrix(q, x)
        for steps in STEPS:
            accumulated_cost(q, x, steps=steps)
            accumulated_cost(None, None, steps=steps, cost=C)
            subsequence_dtw_costs(q, x, steps=steps)
            subsequence_dtw_costs(None, None, steps=steps, cost=C)
            subsequence_dtw(q, x, steps=steps)
            dtw(q, x, steps=steps)
            dtw(cost=C, steps=steps)
    for kernel in (dtw_mod._sdtw_classic, dtw_mod._sdtw_tautges, dtw_mod._global_dtw, dtw_mod._window_cost):
        writable = [sig for sig in kernel.signatures if all(a.mutable for a in sig if isinstance(a, Array))]
        assert len(writable) == 1, (kernel.__name__, kernel.signatures)
