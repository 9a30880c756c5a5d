"""Tests of the lazy neighbourhood graph (Krüger 2010, sec. 4.1) and its online variant (Tautges 2012, sec. 3.4.3).

The oracles at the top are slow plain-Python loops (no numba, no mocapkit):
subsequence DTW with classic steps, the LNG as a dictionary DAG, and
exhaustive enumeration of all paths for tiny graphs (LNG and OLNG).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mocapkit.search import Match
from mocapkit.search.lng import (
    OLNG_STEPS,
    OnlineLazyNeighborhoodGraph,
    lazy_neighborhood_graph,
    lng_costs,
    online_lng_costs,
)

INF = math.inf
SETTINGS = settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# -- slow oracles ---------------------------------------------------------------------------


def same_clip(clip_ids, a, b):
    """Frames a < b are consecutive frames of one clip all the way."""
    if clip_ids is None:
        return True
    return all(clip_ids[u] == clip_ids[u + 1] for u in range(a, b))


def naive_sdtw(C, clip_ids=None):
    """Classic subsequence DTW over a local cost table C[t][i] (query t, database i).

    D[0][i] = C[0][i]; D[t][i] = C[t][i] + min(diagonal, vertical D[t][i-1],
    horizontal D[t-1][i]) with database steps only inside a clip. Returns D and
    the best (cost, path) with ties: diagonal, vertical, horizontal; ends by
    (cost, index).
    """
    M, N = len(C), len(C[0])
    D = [[INF] * N for _ in range(M)]
    for t in range(M):
        for i in range(N):
            if t == 0:
                D[t][i] = C[t][i]
                continue
            ok = i > 0 and same_clip(clip_ids, i - 1, i)
            best = min(D[t - 1][i - 1] if ok else INF, D[t][i - 1] if ok else INF, D[t - 1][i])
            D[t][i] = C[t][i] + best
    end = min(range(N), key=lambda i: (D[M - 1][i], i))
    if D[M - 1][end] == INF:
        return D, None
    path = [(M - 1, end)]
    t, i = M - 1, end
    while t > 0:
        ok = i > 0 and same_clip(clip_ids, i - 1, i)
        cands = [
            (D[t - 1][i - 1] if ok else INF, (t - 1, i - 1)),
            (D[t][i - 1] if ok else INF, (t, i - 1)),
            (D[t - 1][i], (t - 1, i)),
        ]
        best = min(c for c, _ in cands)
        t, i = next(cell for c, cell in cands if c == best)
        path.append((t, i))
    return D, (D[M - 1][end], path[::-1])


def node_table(knn_idx, knn_dist):
    """Per column a dict database index -> smallest reported distance (missing entries dropped)."""
    cols = []
    for row_i, row_d in zip(knn_idx, knn_dist):
        col = {}
        for i, d in zip(row_i, row_d):
            i, d = int(i), float(d)
            if i < 0 or not math.isfinite(d):
                continue
            col[i] = min(d, col.get(i, INF))
        cols.append(col)
    return cols


def naive_lng(knn_idx, knn_dist, clip_ids=None):
    """LNG by dictionaries in topological order: {(t, i): (cost, predecessor or None)}."""
    cols = node_table(knn_idx, knn_dist)
    best = {}
    for t, col in enumerate(cols):
        for i in sorted(col):
            if t == 0:
                best[(0, i)] = (col[i], None)
                continue
            ok = same_clip(clip_ids, i - 1, i) if i > 0 else False
            cands = []
            if ok and (t - 1, i - 1) in best:
                cands.append((best[(t - 1, i - 1)][0], (t - 1, i - 1)))
            if ok and (t, i - 1) in best:
                cands.append((best[(t, i - 1)][0], (t, i - 1)))
            if (t - 1, i) in best:
                cands.append((best[(t - 1, i)][0], (t - 1, i)))
            cands = [c for c in cands if c[0] < INF]
            if cands:
                m = min(c for c, _ in cands)
                pred = next(p for c, p in cands if c == m)
                best[(t, i)] = (col[i] + m, pred)
    return best


def naive_lng_matches(knn_idx, knn_dist, clip_ids=None, k=1, max_overlap=0):
    """(cost, path) of the k best LNG paths, each overlapping better ones by <= max_overlap frames."""
    best = naive_lng(knn_idx, knn_dist, clip_ids)
    M = len(knn_idx)
    ends = sorted((c, i) for (t, i), (c, _) in best.items() if t == M - 1)
    out, ranges = [], []
    for c, i in ends:
        if len(out) >= k:
            break
        path = [(M - 1, i)]
        while best[path[-1]][1] is not None:
            path.append(best[path[-1]][1])
        path = path[::-1]
        s, e = path[0][1], path[-1][1]
        if all(min(e, pe) - max(s, ps) + 1 <= max_overlap for ps, pe in ranges):
            out.append((c, path))
            ranges.append((s, e))
    return out


def enumerate_lng_best(knn_idx, knn_dist, clip_ids=None):
    """Minimum path cost from column 0 to column M-1 over all LNG paths (exhaustive DFS)."""
    cols = node_table(knn_idx, knn_dist)
    M = len(cols)
    best = INF

    def walk(t, i, acc):
        nonlocal best
        if t == M - 1:
            best = min(best, acc)
        if i + 1 in cols[t] and same_clip(clip_ids, i, i + 1):
            walk(t, i + 1, acc + cols[t][i + 1])
        if t + 1 < M:
            if i + 1 in cols[t + 1] and same_clip(clip_ids, i, i + 1):
                walk(t + 1, i + 1, acc + cols[t + 1][i + 1])
            if i in cols[t + 1]:
                walk(t + 1, i, acc + cols[t + 1][i])

    for i, d in cols[0].items():
        walk(0, i, d)
    return best


def olng_path_cost(cols, frames, steps, pf):
    """Cost of one OLNG path given as frames per window column (-1: no node); None if not a valid path."""
    L = len(cols)
    used = [c for c in range(L) if frames[c] >= 0]
    if not used or used[-1] != L - 1:
        return None
    cost = sum(pf * max(cols[s].values(), default=0.0) for s in range(used[0]))
    for c in used:
        if frames[c] not in cols[c]:
            return None
        cost += cols[c][frames[c]]
    for a, b in zip(used, used[1:]):
        if (b - a, frames[b] - frames[a]) not in steps:
            return None
        if b - a == 2:
            cost += cols[b][frames[b]]
    return cost


def naive_olng(knn_idx, knn_dist, clip_ids=None, extra_steps=True, pf=2.0):
    """OLNG costs of the last row by enumerating every path ending at each node (backwards DFS)."""
    steps = OLNG_STEPS if extra_steps else OLNG_STEPS[:3]
    cols = node_table(knn_idx, knn_dist)
    L = len(cols)
    pen_before = [0.0]
    for c in range(L):
        pen_before.append(pen_before[-1] + pf * max(cols[c].values(), default=0.0))

    def best_ending(c, i):
        # cheapest (nodes + skip edges) of paths ending at (c, i), plus the penalty before their start
        d = cols[c][i]
        best = d + pen_before[c]
        for dc, di in steps:
            pc, pi = c - dc, i - di
            if pc < 0 or pi < 0 or pi not in cols[pc] or not same_clip(clip_ids, pi, i):
                continue
            best = min(best, best_ending(pc, pi) + d + (d if dc == 2 else 0.0))
        return best

    out = []
    for i, d in zip(knn_idx[-1], knn_dist[-1]):
        i = int(i)
        out.append(best_ending(L - 1, i) if i >= 0 and math.isfinite(d) else INF)
    return out


# -- helpers --------------------------------------------------------------------------------


def random_walk(rng, N, D=3):
    return np.cumsum(rng.normal(size=(N, D)), axis=0)


def knn_brute(query, data, K):
    C = np.sqrt(((query[:, None, :] - data[None, :, :]) ** 2).sum(-1))
    idx = np.argsort(C, axis=1, kind="stable")[:, :K]
    return C, idx, np.take_along_axis(C, idx, axis=1)


def check_lng_path(m: Match, knn_idx, knn_dist, clip_ids):
    """A match's path is a valid LNG path over reported nodes and its cost is their sum."""
    cols = node_table(knn_idx, knn_dist)
    p = m.path
    assert p[0, 0] == 0 and p[-1, 0] == len(cols) - 1
    assert (m.start, m.end) == (p[0, 1], p[-1, 1])
    total = 0.0
    for (t0, i0), (t1, i1) in zip(p[:-1], p[1:]):
        assert (t1 - t0, i1 - i0) in {(1, 1), (0, 1), (1, 0)}
        if i1 != i0:
            assert same_clip(clip_ids, i0, i1)
    for t, i in p:
        total += cols[t][int(i)]
    assert m.cost == pytest.approx(total, rel=1e-12, abs=1e-12)


# -- LNG: equality with subsequence DTW ----------------------------------------------------


def warped_query(rng, data, lo, hi, M, noise):
    """A time-warped noisy copy of data[lo:hi] with M frames (monotone, repeats and skips)."""
    steps = rng.choice([0, 1, 1, 1, 2], size=M - 1)
    pos = np.concatenate([[0], np.cumsum(steps)])
    pos = lo + np.round(pos * (hi - 1 - lo) / max(pos[-1], 1)).astype(int)
    return data[pos] + noise * rng.normal(size=(M, data.shape[1]))


@pytest.mark.parametrize("seed", range(4))
def test_lng_with_all_frames_as_neighbours_is_subsequence_dtw(seed):
    rng = np.random.default_rng(seed)
    N = 60
    data = random_walk(rng, N)
    clip_ids = np.repeat([0, 1, 2], [17, 25, 18])
    query = warped_query(rng, data, 20, 34, 9, 0.3)
    C = np.sqrt(((query[:, None] - data[None]) ** 2).sum(-1))
    # every frame is a neighbour, rows shuffled
    perm = np.array([rng.permutation(N) for _ in range(len(query))])
    idx, dist = perm, np.take_along_axis(C, perm, axis=1)
    D, (cost, path) = naive_sdtw(C.tolist(), clip_ids)
    r = lng_costs(idx, dist, clip_ids)
    got = np.empty_like(C)
    np.put_along_axis(got, perm, r.cost, axis=1)
    np.testing.assert_allclose(got, np.array(D), rtol=1e-13)
    [m] = lazy_neighborhood_graph(idx, dist, clip_ids)
    assert m.cost == pytest.approx(cost, rel=1e-13)
    assert m.path.tolist() == [list(c) for c in path]
    check_lng_path(m, idx, dist, clip_ids)


def test_lng_equals_dtw_module():
    dtw = pytest.importorskip("mocapkit.search.dtw")
    rng = np.random.default_rng(7)
    N = 600
    data = random_walk(rng, N, D=4)
    clip_ids = np.repeat(np.arange(4), [150, 180, 120, 150])
    query = warped_query(rng, data, 200, 240, 50, 0.2)
    C, _, _ = knn_brute(query, data, 1)
    # K = N: the graph holds every cell, so all accumulated costs and the k best matches agree
    perm = np.array([rng.permutation(N) for _ in range(len(query))])
    r = lng_costs(perm, np.take_along_axis(C, perm, axis=1), clip_ids)
    full = np.empty_like(C)
    np.put_along_axis(full, perm, r.cost, axis=1)
    np.testing.assert_allclose(full, dtw.accumulated_cost(None, None, clip_ids=clip_ids, cost=C), rtol=1e-12)
    want = dtw.subsequence_dtw(None, None, clip_ids=clip_ids, k=3, cost=C)
    got = lazy_neighborhood_graph(perm, np.take_along_axis(C, perm, axis=1), clip_ids, k=3)
    assert len(got) == len(want) == 3
    for g, w in zip(got, want):
        assert (g.start, g.end) == (w.start, w.end)
        assert g.cost == pytest.approx(w.cost, rel=1e-12)
        np.testing.assert_array_equal(g.path, w.path)
    # K << N: the optimal DTW path lies among the neighbours, so the LNG finds it
    [best] = want[:1]
    for K in (40, 120):
        idx = np.argsort(C, axis=1)[:, :K]
        assert all(i in set(idx[t]) for t, i in best.path.tolist()), "construction: path cells must be kNN"
        [m] = lazy_neighborhood_graph(idx, np.take_along_axis(C, idx, axis=1), clip_ids)
        assert (m.start, m.end) == (best.start, best.end)
        assert m.cost == pytest.approx(best.cost, rel=1e-12)
        np.testing.assert_array_equal(m.path, best.path)
        assert 200 <= m.start and m.end <= 240


knn_case = st.tuples(
    st.integers(1, 6),  # M
    st.integers(3, 25),  # N
    st.integers(1, 25),  # K
    st.integers(0, 2**32 - 1),  # seed
    st.booleans(),  # clips
)


@SETTINGS
@given(knn_case)
def test_lng_against_oracles(case):
    M, N, K, seed, use_clips = case
    rng = np.random.default_rng(seed)
    K = min(K, N)
    C = rng.random((M, N)).round(2)  # rounded: ties happen and must resolve like the oracle
    clip_ids = np.cumsum(rng.random(N) < 0.2) if use_clips else None
    idx = np.array([rng.permutation(N)[:K] for _ in range(M)])
    dist = np.take_along_axis(C, idx, axis=1)
    # missing neighbours: -1, inf, NaN
    miss = rng.random((M, K)) < 0.15
    idx = np.where(miss & (rng.random((M, K)) < 0.5), -1, idx)
    dist = np.where(miss & (idx >= 0), rng.choice([np.inf, np.nan], size=(M, K)), dist)

    r = lng_costs(idx, dist, clip_ids)
    best = naive_lng(idx, dist, clip_ids)
    for t in range(M):
        for k in range(K):
            if idx[t, k] < 0 or not np.isfinite(dist[t, k]):
                assert r.cost[t, k] == INF and r.pred[t, k] == -1 and r.start[t, k] == -1
                continue
            c, pred = best.get((t, int(idx[t, k])), (INF, None))
            assert r.cost[t, k] == pytest.approx(c, rel=1e-12)
            if pred is None:
                assert r.pred[t, k] == -1
            else:
                pt, pk = divmod(int(r.pred[t, k]), K)
                assert (pt, int(idx[pt, pk])) == pred

    got = lazy_neighborhood_graph(idx, dist, clip_ids, k=3, max_overlap=1)
    want = naive_lng_matches(idx, dist, clip_ids, k=3, max_overlap=1)
    assert [(m.cost, m.path.tolist()) for m in got] == [(c, [list(x) for x in p]) for c, p in want]
    for m in got:
        check_lng_path(m, idx, dist, clip_ids)
    if N <= 12 and M <= 4:
        assert (got[0].cost if got else INF) == pytest.approx(enumerate_lng_best(idx, dist, clip_ids), rel=1e-12)

    # LNG paths are DTW paths: never cheaper than subsequence DTW; equal when DTW's path is in the graph
    _, sd = naive_sdtw(C.tolist(), clip_ids)
    if got:
        assert got[0].cost >= sd[0] - 1e-12
    cols = node_table(idx, dist)
    if sd is not None and all(i in cols[t] for t, i in sd[1]):
        assert got[0].cost == pytest.approx(sd[0], rel=1e-12)


def test_lng_long_rows():
    # K >= 512 takes the radix-sort path: same results as the oracle, with missing entries and duplicates
    rng = np.random.default_rng(4)
    M, K, N = 6, 700, 900
    idx = rng.integers(-20, N, size=(M, K))
    dist = rng.random((M, K)).round(2)
    dist[rng.random((M, K)) < 0.05] = np.nan
    clip_ids = np.cumsum(rng.random(N) < 0.05)
    r = lng_costs(idx, dist, clip_ids)
    best = naive_lng(idx, dist, clip_ids)
    want = np.array([[best.get((t, int(i)), (INF, None))[0] if i >= 0 and np.isfinite(d) else INF
                      for i, d in zip(idx[t], dist[t])] for t in range(M)])
    np.testing.assert_allclose(r.cost, want, rtol=1e-12)
    got = lazy_neighborhood_graph(idx, dist, clip_ids, k=4)
    assert [(m.cost, m.path.tolist()) for m in got] == \
        [(c, [list(x) for x in p]) for c, p in naive_lng_matches(idx, dist, clip_ids, k=4)]
    g = OnlineLazyNeighborhoodGraph(clip_ids, window=4)
    for t in range(M):
        out = g.push(idx[t], dist[t])
        lo = max(0, t - 3)
        np.testing.assert_allclose(out, naive_olng(idx[lo:t + 1].tolist(), dist[lo:t + 1].tolist(), clip_ids),
                                   rtol=1e-12, atol=1e-12)


def test_lng_never_crosses_clip_boundaries():
    rng = np.random.default_rng(3)
    data = random_walk(rng, 200)
    query = data[95:105].copy()  # a perfect match straddling the boundary at 100
    C, idx, dist = knn_brute(query, data, 200)
    [free] = lazy_neighborhood_graph(idx, dist)
    assert (free.start, free.end, free.cost) == (95, 104, 0.0)
    clip_ids = np.repeat([0, 1], [100, 100])
    ms = lazy_neighborhood_graph(idx, dist, clip_ids, k=4)
    assert ms and ms[0].cost > 0
    for m in ms:
        assert clip_ids[m.start] == clip_ids[m.end]
        check_lng_path(m, idx, dist, clip_ids)
    # the same when the frames before/after the boundary are the only neighbours
    near = np.tile(np.arange(90, 110), (len(query), 1))
    ms = lazy_neighborhood_graph(near, np.take_along_axis(C, near, axis=1), clip_ids, k=2)
    assert ms and all(clip_ids[m.start] == clip_ids[m.end] for m in ms)
    for m in ms:
        check_lng_path(m, near, np.take_along_axis(C, near, axis=1), clip_ids)


def test_lng_missing_duplicate_and_order_invariance():
    rng = np.random.default_rng(11)
    data = random_walk(rng, 150)
    query = warped_query(rng, data, 40, 70, 25, 0.2)
    _, idx, dist = knn_brute(query, data, 30)
    ref = lazy_neighborhood_graph(idx, dist, k=3, max_overlap=20)
    assert len(ref) == 3
    # shuffle rows, append missing entries and worse duplicates
    M = len(query)
    perm = np.array([rng.permutation(30) for _ in range(M)])
    idx2 = np.concatenate([np.take_along_axis(idx, perm, 1), np.full((M, 3), -1), idx[:, :4], idx[:, 4:6]], axis=1)
    dist2 = np.concatenate([np.take_along_axis(dist, perm, 1), np.zeros((M, 3)), dist[:, :4] + 1.0,
                            np.full((M, 2), np.nan)], axis=1)
    got = lazy_neighborhood_graph(idx2, dist2, k=3, max_overlap=20)
    assert [(m.start, m.end, m.cost, m.path.tolist()) for m in got] == \
        [(m.start, m.end, m.cost, m.path.tolist()) for m in ref]
    r = lng_costs(idx2, dist2)
    r0 = lng_costs(idx, dist)
    np.testing.assert_array_equal(r.cost[:, :30], np.take_along_axis(r0.cost, perm, 1))
    np.testing.assert_array_equal(r.cost[:, 33:37], r0.cost[:, :4])  # a duplicate shows its node's result
    assert np.all(np.isinf(r.cost[:, 30:33])) and np.all(np.isinf(r.cost[:, 37:]))


def test_lng_k_best_and_overlap():
    rng = np.random.default_rng(5)
    data = random_walk(rng, 400)
    seg = data[100:120]
    data[300:320] = seg + 0.01  # a second near copy
    query = seg + 0.001 * rng.normal(size=seg.shape)
    _, idx, dist = knn_brute(query, data, 60)
    ms = lazy_neighborhood_graph(idx, dist, k=5)
    assert [m.start for m in ms[:2]] == [100, 300]
    costs = [m.cost for m in ms]
    assert costs == sorted(costs)
    for a in range(len(ms)):
        check_lng_path(ms[a], idx, dist, None)
        for b in range(a):
            assert not ms[a].overlaps(ms[b])
    loose = lazy_neighborhood_graph(idx, dist, k=5, max_overlap=19)
    assert [m.start for m in loose[:2]] == [100, 300]
    assert any(x.overlaps(y) for a, x in enumerate(loose) for y in loose[:a])  # shifted copies come back
    for a in range(len(loose)):
        for b in range(a):
            x, y = loose[a], loose[b]
            assert min(x.end, y.end) - max(x.start, y.start) + 1 <= 19


def test_lng_no_path_and_single_frame():
    idx = np.array([[3, 8], [20, 30], [21, 31]])
    dist = np.ones((3, 2))
    assert lazy_neighborhood_graph(idx, dist) == []
    idx[1, 1] = -1
    idx[1, 0] = -1
    assert lazy_neighborhood_graph(idx, dist) == []
    assert lazy_neighborhood_graph(np.zeros((0, 3), int), np.zeros((0, 3))) == []
    [m] = lazy_neighborhood_graph([[4, 2]], [[0.5, 0.25]])
    assert (m.start, m.end, m.cost, m.path.tolist()) == (2, 2, 0.25, [[0, 2]])
    # ties between ends: the lower database index
    [m] = lazy_neighborhood_graph([[5, 1]], [[0.5, 0.5]])
    assert m.start == 1


def test_lng_tie_breaking():
    # (1, 4) has no diagonal or horizontal predecessor: unreachable
    r = lng_costs([[5, 2], [4, 5]], [[1.0, 0.0], [1.0, 0.0]])
    assert r.cost[1, 0] == INF and r.pred[1, 0] == -1
    # (1, 5): diagonal from (0, 4) and vertical from (1, 4) both give 1.0: the diagonal wins
    r = lng_costs([[4, 3], [4, 5]], [[0.5, 0.0], [0.5, 0.5]])
    assert r.cost[1].tolist() == [0.5, 1.0]
    assert r.pred[1].tolist() == [1, 0]  # (1, 4) <- (0, 3) diagonal; (1, 5) <- (0, 4) diagonal
    # (1, 5): vertical from (1, 4) and horizontal from (0, 5) both give 1.0: the vertical
    # (database advance) wins, as in mocapkit.search.dtw
    r = lng_costs([[3, 5], [4, 5]], [[0.5, 1.0], [0.5, 0.0]])
    assert r.cost[1].tolist() == [1.0, 1.0]
    assert r.pred[1, 1] == 1 * 2 + 0
    assert r.start[1].tolist() == [3, 3]


def test_lng_ties_like_dtw_module():
    dtw = pytest.importorskip("mocapkit.search.dtw")
    rng = np.random.default_rng(1)
    for _ in range(30):
        M, N = rng.integers(2, 7), rng.integers(5, 30)
        C = rng.integers(0, 3, size=(M, N)).astype(float)  # many ties
        clip_ids = np.cumsum(rng.random(N) < 0.2)
        full = np.tile(np.arange(N), (M, 1))
        r = lng_costs(full, C, clip_ids)
        np.testing.assert_array_equal(r.cost, dtw.accumulated_cost(None, None, clip_ids=clip_ids, cost=C))
        want = dtw.subsequence_dtw(None, None, clip_ids=clip_ids, k=3, cost=C)
        got = lazy_neighborhood_graph(full, C, clip_ids, k=3)
        # same ends, starts and costs: the end order and the start carried with each tie rule agree
        assert [(m.start, m.end, m.cost) for m in got] == [(m.start, m.end, m.cost) for m in want]
        _, sd = naive_sdtw(C.tolist(), clip_ids)
        assert got[0].path.tolist() == [list(c) for c in sd[1]]


def test_lng_input_errors():
    with pytest.raises(ValueError, match=r"knn_idx: expected shape \(M, K\)"):
        lazy_neighborhood_graph(np.arange(3), np.ones(3))
    with pytest.raises(ValueError, match="knn_dist: expected shape"):
        lazy_neighborhood_graph(np.zeros((2, 3), int), np.ones((2, 2)))
    with pytest.raises(ValueError, match="integer"):
        lazy_neighborhood_graph(np.zeros((2, 3)), np.ones((2, 3)))
    with pytest.raises(ValueError, match=">= 0"):
        lazy_neighborhood_graph(np.zeros((2, 3), int), -np.ones((2, 3)))
    with pytest.raises(ValueError, match="out of range"):
        lazy_neighborhood_graph(np.full((2, 3), 5), np.ones((2, 3)), clip_ids=np.zeros(5, int))
    # scipy's padding of missing neighbours (index N, distance inf) is just missing
    [m] = lazy_neighborhood_graph([[5, 1], [2, 5]], [[np.inf, 0.5], [0.5, np.inf]], clip_ids=np.zeros(5, int))
    assert m.path.tolist() == [[0, 1], [1, 2]]
    with pytest.raises(ValueError, match="clip_ids"):
        lazy_neighborhood_graph(np.zeros((2, 3), int), np.ones((2, 3)), clip_ids=np.zeros((5, 1), int))
    with pytest.raises(ValueError, match="k must"):
        lazy_neighborhood_graph(np.zeros((2, 3), int), np.ones((2, 3)), k=0)
    with pytest.raises(ValueError, match="max_overlap"):
        lazy_neighborhood_graph(np.zeros((2, 3), int), np.ones((2, 3)), max_overlap=-1)


# -- OLNG -----------------------------------------------------------------------------------


olng_case = st.tuples(
    st.integers(1, 5),  # K
    st.integers(1, 6),  # window
    st.integers(1, 11),  # stream length
    st.integers(0, 2**32 - 1),  # seed
    st.booleans(),  # clips
    st.booleans(),  # extra steps
    st.sampled_from([0.0, 0.5, 2.0]),  # penalty factor
)


def random_stream(rng, T, K, N, runs=True):
    """kNN rows over N frames where some neighbours continue earlier ones; with -1, inf, NaN and duplicates."""
    idx = rng.integers(0, N, size=(T, K))
    if runs:
        for t in range(1, T):
            cont = rng.random(K) < 0.6
            idx[t, cont] = np.clip(idx[t - 1, rng.permutation(K)][cont] + rng.integers(0, 5, K)[cont], 0, N - 1)
    dist = rng.random((T, K)).round(1)
    miss = rng.random((T, K)) < 0.15
    idx[miss & (rng.random((T, K)) < 0.5)] = -1
    dist[miss & (idx >= 0)] = rng.choice([np.inf, np.nan], size=int((miss & (idx >= 0)).sum()))
    return idx, dist


@SETTINGS
@given(olng_case)
def test_olng_push_equals_from_scratch_and_enumeration(case):
    K, W, T, seed, use_clips, extra, pf = case
    rng = np.random.default_rng(seed)
    N = 20
    clip_ids = np.cumsum(rng.random(N) < 0.15) % 2 if use_clips else None  # ids repeat: only runs join
    idx, dist = random_stream(rng, T, K, N)
    g = OnlineLazyNeighborhoodGraph(clip_ids, window=W, extra_steps=extra, penalty_factor=pf)
    for t in range(T):
        got = g.push(idx[t], dist[t])
        lo = max(0, t + 1 - W)
        scratch = online_lng_costs(idx[lo:t + 1], dist[lo:t + 1], clip_ids, extra_steps=extra, penalty_factor=pf)
        np.testing.assert_allclose(got, scratch, rtol=1e-12, atol=1e-12)
        if K <= 4 and W <= 5:
            want = naive_olng(idx[lo:t + 1].tolist(), dist[lo:t + 1].tolist(), clip_ids, extra, pf)
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
        assert len(g) == t + 1
        np.testing.assert_array_equal(g.current_nodes, idx[t])
        # best paths are valid paths of the window and cost what push reported
        cols = node_table(idx[lo:t + 1], dist[lo:t + 1])
        steps = set(OLNG_STEPS if extra else OLNG_STEPS[:3])
        paths = g.best_paths(K + 1)
        assert len(paths) == len(cols[-1])
        assert [p.cost for p in paths] == sorted(p.cost for p in paths)
        by_frame = {int(i): c for i, c in zip(idx[t], got) if np.isfinite(c)}
        assert sorted(p.cost for p in paths) == sorted(by_frame.values())
        assert all(by_frame[int(p.frames[-1])] == p.cost for p in paths)
        for p in paths:
            assert len(p.frames) == t + 1 - lo
            c = olng_path_cost(cols, p.frames.tolist(), steps, pf)
            assert c is not None and c == pytest.approx(p.cost, rel=1e-12, abs=1e-12)
            used = p.frames[p.frames >= 0]
            assert all(same_clip(clip_ids, int(a), int(b)) for a, b in zip(used[:-1], used[1:]))


@SETTINGS
@given(st.integers(1, 4), st.integers(1, 5), st.integers(0, 2**32 - 1), st.booleans())
def test_online_lng_costs_equals_enumeration(K, W, seed, extra):
    rng = np.random.default_rng(seed)
    idx, dist = random_stream(rng, W, K, 12)
    clip_ids = np.repeat([0, 1, 0], [5, 4, 3])
    got = online_lng_costs(idx, dist, clip_ids, extra_steps=extra, penalty_factor=1.5)
    want = naive_olng(idx.tolist(), dist.tolist(), clip_ids, extra, 1.5)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_olng_planted_run_wins():
    rng = np.random.default_rng(2)
    K, W, N = 32, 13, 100_000
    g = OnlineLazyNeighborhoodGraph(window=W)
    i0 = 5000
    run_d = np.full(W + 5, 0.01)  # equal costs: skipping a node (paying the target twice) gains nothing
    for t in range(W + 5):
        idx = rng.integers(0, N, K)
        dist = rng.uniform(0.5, 1.0, K)
        idx[7], dist[7] = i0 + t, run_d[t]
        out = g.push(idx, dist)
    assert np.argmin(out) == 7
    # a full-window run pays no penalty: its cost is the sum of its node distances
    assert out[7] == pytest.approx(run_d[-W:].sum(), rel=1e-12)
    [best] = g.best_paths(1)
    np.testing.assert_array_equal(best.frames, np.arange(i0 + 5, i0 + 5 + W))
    others = np.delete(out, 7)
    assert np.all(others > 10 * out[7])


def test_olng_penalty_prefers_longer_paths():
    W, d = 6, 0.5
    g = OnlineLazyNeighborhoodGraph(window=W, penalty_factor=2.0)
    for t in range(W):
        # node 0 continues a run over the whole window; node 1 only over the last three columns
        i1 = 1000 + t if t >= W - 3 else 50_000 + 97 * t
        out = g.push([100 + t, i1, 70_000 + 13 * t], [d, d, 1.0])
    assert out[0] == pytest.approx(W * d)
    assert out[1] == pytest.approx(3 * d + (W - 3) * 2.0 * 1.0)
    assert out[2] == pytest.approx(1.0 + (W - 1) * 2.0)
    assert out[0] < out[1] < out[2]
    frames = [p.frames.tolist() for p in g.best_paths(3)]
    assert frames[0] == [100 + t for t in range(W)]
    assert frames[1] == [-1, -1, -1, 1003, 1004, 1005]
    assert frames[2] == [-1] * (W - 1) + [70_000 + 13 * (W - 1)]


def test_olng_ties_prefer_the_longer_path():
    # 10 -> 11 costs 1.0 + 0.5; 11 alone costs 0.5 + penalty 1.0 * 1.0: equal, the longer path wins
    g = OnlineLazyNeighborhoodGraph(window=2, penalty_factor=1.0)
    g.push([10], [1.0])
    assert g.push([11], [0.5]).tolist() == [1.5]
    assert g.best_paths(1)[0].frames.tolist() == [10, 11]


def test_olng_skip_steps_and_extra_steps():
    # a run with one scattered column in the middle: 10, 11, (nothing), 13, 14
    rows = [10, 11, -1, 13, 14]
    for extra, expect in ((True, 5 * 0.5 - 0.5 + 0.5), (False, None)):
        g = OnlineLazyNeighborhoodGraph(window=5, extra_steps=extra, penalty_factor=2.0)
        for t, i in enumerate(rows):
            out = g.push([i, 900 + 31 * t], [0.5 if i >= 0 else np.inf, 1.0])
        if extra:
            # 10, 11, skip, 13 (edge costs 0.5), 14: nodes 2.0 + skip edge 0.5
            assert out[0] == pytest.approx(expect)
            assert g.best_paths(1)[0].frames.tolist() == [10, 11, -1, 13, 14]
        else:
            # 11 -> 13 needs (2, 2): without it the path starts at 13 and pays for 3 columns
            assert out[0] == pytest.approx(1.0 + 2.0 * (1.0 + 1.0 + 1.0))
    # the basic (2, 1) skip step is always there: 10, 11, skip, 12
    g = OnlineLazyNeighborhoodGraph(window=4, extra_steps=False)
    for t, i in enumerate([10, 11, -1, 12]):
        out = g.push([i], [0.25 if i >= 0 else np.nan])
    assert out[0] == pytest.approx(0.25 * 3 + 0.25)
    # (1, 2) step: 10, 12, 14
    g = OnlineLazyNeighborhoodGraph(window=3, extra_steps=False)
    for i in (10, 12, 14):
        out = g.push([i], [0.25])
    assert out[0] == pytest.approx(0.75)


def test_olng_clip_boundaries_and_window():
    clip_ids = np.repeat([0, 1], [103, 100])
    g = OnlineLazyNeighborhoodGraph(clip_ids, window=4)
    for t in range(6):
        out = g.push([100 + t], [0.125])
    # frames 100..102 are clip 0, 103.. clip 1: the path ending at 105 starts at 103
    assert g.best_paths(1)[0].frames.tolist() == [-1, 103, 104, 105]
    assert out[0] == pytest.approx(3 * 0.125 + 2.0 * 0.125)
    # without clips the path is as long as the window allows
    g = OnlineLazyNeighborhoodGraph(window=4)
    for t in range(6):
        out = g.push([100 + t], [0.125])
    assert g.best_paths(1)[0].frames.tolist() == [102, 103, 104, 105]
    assert out[0] == pytest.approx(4 * 0.125)


def test_olng_state_and_errors():
    g = OnlineLazyNeighborhoodGraph(window=3)
    assert len(g) == 0 and g.best_paths(5) == [] and g.current_nodes.shape == (0,)
    out = g.push(np.array([4, 4, -1], dtype=np.int32), [0.5, 0.25, 0.0])
    assert out.tolist() == [0.25, 0.25, INF]  # a duplicate is one node with the smaller distance
    assert g.costs.tolist() == out.tolist()
    with pytest.raises(ValueError, match=r"expected shape \(3,\)"):
        g.push([1, 2], [0.1, 0.2])
    with pytest.raises(ValueError, match=">= 0"):
        g.push([1, 2, 3], [0.1, -0.2, 0.0])
    with pytest.raises(ValueError, match=r"expected shape \(K,\)"):
        g.push([[1, 2, 3]], [[0.1, 0.2, 0.3]])
    g.reset()
    assert len(g) == 0
    assert g.push([1, 2], [0.1, 0.2]).tolist() == [0.1, 0.2]  # K may change after reset
    with pytest.raises(ValueError, match="window"):
        OnlineLazyNeighborhoodGraph(window=0)
    with pytest.raises(ValueError, match="penalty_factor"):
        OnlineLazyNeighborhoodGraph(penalty_factor=-1)
    with pytest.raises(ValueError, match="out of range"):
        OnlineLazyNeighborhoodGraph(clip_ids=np.zeros(4, int)).push([4], [0.0])
    with pytest.raises(ValueError, match="n must"):
        g.best_paths(-1)


def test_read_only_and_writable_clip_ids_give_one_signature():
    """A database opened from disk gives read-only clip ids, one built in memory writable: the online graph and
    the offline costs pass both read-only, so each kernel has one machine code (the one the warm-up caches)."""
    from mocapkit.search import lng

    idx, dist = random_stream(np.random.default_rng(0), 6, 3, 20)
    ids = np.repeat([0, 1], 10)
    frozen = ids.copy()
    frozen.flags.writeable = False
    got = []
    for clip_ids in (ids, frozen):
        g = OnlineLazyNeighborhoodGraph(clip_ids, window=4)
        pushed = [g.push(idx[t], dist[t]) for t in range(6)]
        got.append(pushed + [online_lng_costs(idx, dist, clip_ids), lng_costs(idx, dist, clip_ids).cost])
    assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(*got, strict=True))
    for kernel in (lng._olng_push, lng._olng_scratch, lng._lng_kernel):  # clip ids are the fourth argument of each
        assert kernel.signatures and not any(sig[3].mutable for sig in kernel.signatures)
    assert ids.flags.writeable  # the caller's array is left as it was
