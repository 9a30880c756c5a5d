"""The numba kernels of the self-similarity analysis against slow, obvious oracles (tests/naive.py)."""

import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit import rotations as R
from mocapkit.cleaning.ssa import word_dtw as W
from mocapkit.cleaning.ssa.twins import COLD_FACTOR, PARALLEL_SUFFIX, Twins, forced
from tests.naive import group_pose_distance_naive, naive_local_minima_knn, word_dtw_enumerate


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(2, 6),
    extra=st.integers(0, 3),
    min_width=st.integers(1, 6),
    max_run=st.integers(1, 3),
    seed=st.integers(0, 2**31 - 1),
)
def test_word_dtw_equals_path_enumeration(n, extra, min_width, max_run, seed):
    C = np.random.default_rng(seed).random((n, n + extra))
    d, i, j = W.word_dtw(C, min_width=min_width, max_run=max_run)
    d0, i0, j0 = word_dtw_enumerate(C, min_width=min_width, max_run=max_run)
    if np.isinf(d0):
        assert np.isinf(d) and i == -1
    else:
        assert (i, j) == (i0, j0)
        assert d == pytest.approx(d0, rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 15), extra=st.integers(0, 6), seed=st.integers(0, 2**31 - 1))
def test_word_dtw_path_obeys_the_appendix(n, extra, seed):
    M = n + extra
    C = np.random.default_rng(seed).random((n, M))
    mw = min(11, n)
    d, path = W.word_dtw_path(C, min_width=mw)
    assert tuple(path[0]) == (0, 0)
    steps = np.diff(path, axis=0)
    assert all(tuple(s) in {(1, 0), (0, 1), (1, 1)} for s in steps)  # continuity, monotonicity
    # at most 3 consecutive steps in one non-diagonal direction
    run, last = 0, None
    for s in map(tuple, steps):
        run = run + 1 if s == last and s != (1, 1) else 1
        last = s
        assert s == (1, 1) or run <= 3
    i, j = path[-1]
    assert i == n - 1 or j == M - 1  # stops at the first end reached
    assert not any((p[0] == n - 1 or p[1] == M - 1) for p in path[:-1])
    assert (i == n - 1 and j + 1 >= mw) or (j == M - 1 and i + 1 >= mw)  # window wider than 10 frames
    assert d == pytest.approx(C[path[:, 0], path[:, 1]].mean(), rel=1e-12)
    assert (d, i, j) == pytest.approx(W.word_dtw(C, min_width=mw))


def test_the_wrappers_share_the_dtw_signatures_of_the_pairs_and_the_warps(rng):
    """word_dtw and word_dtw_path call the DTW kernel with the argument types the pairs and the warps pass from
    inside their kernels (int64 origins, not literal 0s): two float64 signatures in all, each compiled (and cached
    by the warm-up) once for the kernels and the wrappers."""
    A, B = _random_quats(rng, (20, 3)), _random_quats(rng, (24, 3))
    W.word_distance_pairs(A, B, np.ones(3, dtype=bool), 1, [0, 5], [0, 4])
    W.warp_target_words(A, B, np.arange(3), 1, [0, 5], [0, 4])
    C = rng.random((15, 20))
    W.word_dtw(C)
    W.word_dtw_path(C)
    from numba import types

    f64 = [sig for sig in W._word_dtw.signatures if sig[0].dtype == types.float64]
    assert len(f64) == 2 and {isinstance(sig[-1], types.Array) for sig in f64} == {False, True}  # back table or not


def test_pose_distances_of_writable_and_read_only_textures_share_one_signature(rng):
    """detect's textures are read-only, a caller's own arrays writable: group_pose_distances passes both read-only,
    so each twin has one machine code (the one the warm-up caches), and the distances do not depend on it."""
    A = _random_quats(rng, (6, 3))
    frozen = A.copy()
    frozen.flags.writeable = False
    groups = np.ones((1, 3), dtype=bool)
    got = _both(W.group_pose_distances, A, A, groups, [1]) + _both(W.group_pose_distances, frozen, frozen, groups, [1])
    assert all(np.array_equal(g, got[0]) for g in got)
    for twin in (W._group_pose_distances.serial, W._group_pose_distances.parallel):
        assert twin.signatures and not any(sig[0].mutable or sig[1].mutable for sig in twin.signatures)
    assert A.flags.writeable  # the caller's array is left as it was


def _random_quats(rng, shape):
    return R.quaternion_normalize(rng.normal(size=shape + (4,)))


@pytest.mark.parametrize("drop", [0, 1, 3])
def test_group_pose_distances_equal_eq1_with_dropped_joints(rng, drop):
    A, B = _random_quats(rng, (6, 7)), _random_quats(rng, (5, 7))
    groups = np.array([[True] * 7, [True, True, False, True, False, True, True]])
    D = W.group_pose_distances(A, B, groups, [drop, min(drop, 1)])
    for g, dr in ((0, drop), (1, min(drop, 1))):
        members = np.flatnonzero(groups[g])
        for a in range(6):
            for b in range(5):
                assert D[g, a, b] == pytest.approx(group_pose_distance_naive(A[a], B[b], members, dr), rel=1e-5, abs=1e-6)


def test_group_pose_distances_nan_is_infinite(rng):
    A, B = _random_quats(rng, (3, 4)), _random_quats(rng, (3, 4))
    A[1, 2] = np.nan
    D = W.group_pose_distances(A, B, np.array([[True] * 4, [True, True, False, False]]), [1, 1])
    assert np.isinf(D[0, 1]).all() and np.isfinite(D[1, 1]).all() and np.isfinite(D[0, 0]).all()


def test_profile_and_pairs_equal_single_dtw(rng):
    A, B = _random_quats(rng, (40, 6)), _random_quats(rng, (50, 6))
    group = np.ones(6, dtype=bool)
    D = W.group_pose_distances(A, B, group[None], [1])[0]
    src, tgt = np.array([0, 5, 25]), np.arange(0, 31, 3)
    dist, ie, je = W.word_distance_profile(D, src, tgt)
    for a, s in enumerate(src):
        for b, t in enumerate(tgt):
            d, i, j = W.word_dtw(D[s : s + 15, t : t + 20].astype(np.float64))
            assert dist[a, b] == pytest.approx(d, rel=1e-6) and (ie[a, b], je[a, b]) == (i, j)
    ps, pt = np.repeat(src, len(tgt)), np.tile(tgt, len(src))
    d2, _, _ = W.word_distance_pairs(A, B, group, 1, ps, pt)
    np.testing.assert_allclose(d2.reshape(dist.shape), dist, rtol=1e-5)


def _walk_texture(n_frames=160, seed=0):
    """A quasi-periodic synthetic texture (F, 6, 4): smooth rotations whose pattern repeats with drift."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_frames)[:, None]
    axes = rng.normal(size=(6, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    ang = 0.6 * np.sin(2 * np.pi * t / 23.0 + rng.uniform(0, 6, 6)) + 0.05 * rng.normal(size=(n_frames, 6))
    q = np.concatenate([np.cos(ang / 2)[..., None], np.sin(ang / 2)[..., None] * axes[None]], axis=-1)
    return q


@pytest.mark.parametrize("exclude", [False, True])
def test_knn_profile_equals_full_profile_minima(exclude):
    A = _walk_texture(160, 1)
    D = W.group_pose_distances(A, A, np.ones((1, 6), dtype=bool), [1])[0]
    src = np.arange(0, 160 - 15, 5)
    tgt = np.concatenate([np.arange(0, 70), np.arange(75, 141)])  # two "clips": a break in the starts
    dist, ie, je = W.word_distance_profile(D, src, tgt)
    center = src if exclude else None
    want = naive_local_minima_knn(dist, tgt, 5, center, 7)
    idx, d, i_end, j_end, ev = W.word_knn_profile(D, src, tgt, 5, center, 7, return_evaluated=True)
    for w in range(len(src)):
        got = [(float(d[w, q]), int(idx[w, q])) for q in range(5) if idx[w, q] >= 0]
        assert [t for _, t in got] == [t for _, t in want[w]]
        np.testing.assert_allclose([v for v, _ in got], [v for v, _ in want[w]], rtol=1e-6)
        for q, (_, t) in enumerate(got):
            assert (i_end[w, q], j_end[w, q]) == (ie[w, t], je[w, t])
    assert ev.mean() < len(tgt)  # the bound pruned something


def test_knn_profile_past_its_first_batches_equals_full_profile_minima():
    """Words whose K-th minimum takes more than the first batch of 64 positions to know (a drifting walk: no two
    cycles alike) visit the rest in later batches; the answer is still the full profile's minima, tie for tie."""
    rng = np.random.default_rng(3)
    n = 400
    A = _walk_texture(n, 3)
    ang = 2.0 * np.cumsum(rng.normal(size=(n, 6)), axis=0) / np.sqrt(n)  # a drift on top of the cycles
    axes = rng.normal(size=(6, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    drift = np.concatenate([np.cos(ang / 2)[..., None], np.sin(ang / 2)[..., None] * axes[None]], axis=-1)
    A = R.quaternion_multiply(A, drift)
    D = W.group_pose_distances(A, A, np.ones((1, 6), dtype=bool), [1])[0]
    src, tgt = np.arange(0, n - 15, 5), np.arange(0, n - 19)
    dist, ie, je = W.word_distance_profile(D, src, tgt)
    want = naive_local_minima_knn(dist, tgt, 5, src, 7)
    idx, d, i_end, j_end, ev = W.word_knn_profile(D, src, tgt, 5, src, 7, return_evaluated=True)
    assert (ev > 64).sum() >= 10  # past the first batch
    for w in range(len(src)):
        got = [(float(d[w, q]), int(idx[w, q])) for q in range(5) if idx[w, q] >= 0]
        assert [t for _, t in got] == [t for _, t in want[w]]
        assert [v for v, _ in got] == [float(np.float32(dist[w, t])) for _, t in want[w]]
        for q, (_, t) in enumerate(got):
            assert (i_end[w, q], j_end[w, q]) == (ie[w, t], je[w, t])


def test_knn_profile_lower_bound_is_a_bound(rng):
    A, B = _random_quats(rng, (40, 5)), _random_quats(rng, (60, 5))
    D = W.group_pose_distances(A, B, np.ones((1, 5), dtype=bool), [0])[0]
    src, tgt = np.arange(0, 26, 5), np.arange(0, 41)
    for N, M, mw, run in ((15, 20, 11, 3), (10, 12, 8, 1), (15, 20, 11, 0)):
        s = src[src + N <= 40]
        dist, _, _ = W.word_distance_profile(D, s, tgt[tgt + M <= 60], N, M, mw, run)
        lb = W.word_dtw_lower_bounds(D, s, tgt[tgt + M <= 60], N, M, mw, run)
        fin = np.isfinite(dist)
        assert np.all(lb[fin] <= dist[fin].astype(np.float64) * (1 + 1e-6))
        assert np.mean(lb[fin] / dist[fin]) > 0.3  # and not a trivial one


@pytest.mark.parametrize("frames", [1, 2, 37, 38])
def test_self_pose_distances_equal_the_full_matrix_bit_for_bit(rng, frames):
    """Half the cells computed and mirrored: the same float32 array as group_pose_distances(A, A), NaN frames too."""
    A = _random_quats(rng, (frames, 7))
    if frames > 5:
        A[4, 2] = np.nan
    groups = np.array([[True] * 7, [True, True, False, True, False, True, True], [False, True] * 3 + [False]])
    want = W.group_pose_distances(A, A, groups, [3, 1, 0])
    for got in _both(W.self_pose_distances, A, groups, [3, 1, 0]):
        assert got.dtype == np.float32 and np.array_equal(got, want)


def test_warps_reading_the_search_costs_equal_warps_computing_them(rng):
    """The mean texture hands the self-distance matrix to the warps: the same paths and warped words, bit for bit."""
    T = _walk_texture(160, 1)
    T[70, 2] = np.nan  # a non-finite frame: impassable either way
    groups = np.array([[True] * 6, [True, False, True, True, False, False]])
    D = W.self_pose_distances(T, groups, [3, 1])
    src, tgt = np.repeat(np.arange(0, 145, 20), 6), np.tile(np.arange(0, 141, 25), 8)
    for g, drop in ((0, 3), (1, 1)):
        members = np.flatnonzero(groups[g])
        want = _both(W.warp_target_words, T, T, members, drop, src, tgt)
        got = _both(W.warp_target_words, T, T, members, drop, src, tgt, costs=D[g])
        _assert_same(*want)
        _assert_same(want[0], got[0])
        _assert_same(want[1], got[1])
        assert (want[0][1] == -1).any() and (want[0][1] >= 0).any()
    with pytest.raises(ValueError, match="costs must be float32"):
        W.warp_target_words(T, T, members, 1, src, tgt, costs=D[1].astype(np.float64))


def test_mean_exceeds_only_when_every_path_mean_does(rng):
    """The knn profile's test before a DTW: True means the word distance is above lam, never a wrong skip."""
    row = np.empty(20)
    said, seen = 0, 0
    for trial in range(300):
        C = (rng.random((15, 20)) ** 3).astype(np.float32)  # float32 as the knn profile's pose distances
        if trial % 7 == 0:
            C[rng.integers(15), rng.integers(20)] = np.inf
        d, _, _ = W.word_dtw(C)
        for lam in (0.0, 0.5 * d, 0.9 * d, d, 1.1 * d):
            seen += 1
            if W._mean_exceeds(C, 0, 0, 15, 20, 11, lam, row):
                said += 1
                assert d > lam
    assert said > seen // 3  # and it does skip: lam well under the distance is proven


def _mean_exceeds_reference(C, N, M, min_width, lam):
    """The one-state DP of ``_mean_exceeds`` over the whole block, then the decision: the slow reference."""
    lo = min_width - 1
    S = np.full((N, M), np.inf)
    cmax, best = lam, np.inf
    for i in range(N):
        for j in range(M):
            c = float(C[i, j])
            if c < np.inf and c > cmax:
                cmax = c
            prev = 0.0 if i == j == 0 else min(S[i - 1, j] if i else np.inf, S[i - 1, j - 1] if i and j else np.inf,
                                               S[i, j - 1] if j else np.inf)
            S[i, j] = prev + (c - lam)
            if (i == N - 1 and j >= lo) or (j == M - 1 and i >= lo):
                best = min(best, S[i, j])
    return best > 1e-12 * (N + M) * cmax


def test_mean_exceeds_stopping_early_is_the_whole_blocks_answer(rng):
    """``_mean_exceeds`` (first row and column filled apart, False at the first row whose end cells prove it: the
    least sum only falls, the margin only grows) gives the answer of the plain DP over the whole block, including
    where a later row holds larger costs or the first row and column impassable cells, and for blocks narrower or
    shorter than ``min_width`` (``reconstruct.sparse`` passes ``min(11, N)`` with any target length)."""
    early = 0
    for N, M, min_width in ((15, 20, 11), (15, 8, 11), (12, 20, 12), (8, 8, 8)):
        row = np.empty(M)
        for trial in range(120):
            C = (rng.random((N, M)) ** 3).astype(np.float32)  # float32 as the knn profile's pose distances
            if trial % 5 == 0:
                C[min(min_width, N - 1):] *= 50.0  # rows after the first end cells: large costs raise cmax after a stop
            if trial % 7 == 0:
                C[rng.integers(N), rng.integers(M)] = np.inf
            if trial % 11 == 0:  # impassable cells on the first row and column, which the kernel fills apart
                C[0, rng.integers(1, M)] = C[rng.integers(1, N), 0] = np.inf
            top = float(C.max(initial=0.0, where=np.isfinite(C)))
            for lam in (0.0, 0.1 * top, 0.3 * top, top):
                got = W._mean_exceeds(C, 0, 0, N, M, min_width, lam, row)
                assert got == _mean_exceeds_reference(C, N, M, min_width, lam), (N, M, min_width, trial, lam)
                early += not got
    assert early > 600  # the early stop is exercised


def test_knn_profile_few_minima_and_k_larger_than_targets():
    A = _walk_texture(60, 2)
    D = W.group_pose_distances(A, A, np.ones((1, 6), dtype=bool), [1])[0]
    src, tgt = np.array([0, 20]), np.arange(0, 8)
    dist, _, _ = W.word_distance_profile(D, src, tgt)
    want = naive_local_minima_knn(dist, tgt, 20)
    idx, d, _, _ = W.word_knn_profile(D, src, tgt, 20)
    for w in range(2):
        n = len(want[w])
        assert idx[w, :n].tolist() == [t for _, t in want[w]] and (idx[w, n:] == -1).all() and np.isinf(d[w, n:]).all()


# -- serial and parallel twins (mocapkit.cleaning.ssa.twins) ----------------------


def _both(fn, *args, **kw):
    """fn's result with every twin forced serial, and forced parallel."""
    with forced("serial"):
        s = fn(*args, **kw)
    with forced("parallel"):
        p = fn(*args, **kw)
    return s, p


def _assert_same(s, p):
    s, p = (s, p) if isinstance(s, tuple) else ((s,), (p,))
    for x, y in zip(s, p, strict=True):
        assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True)


def test_every_prange_kernel_has_twins():
    from mocapkit.cleaning.ssa import self_costs, word_means

    kernels = {name: v for mod in (W, word_means, self_costs) for name, v in vars(mod).items() if isinstance(v, Twins)}
    assert set(kernels) == {"_group_pose_distances", "_self_costs", "_profile", "_row_minima", "_knn_profile",
                            "_pairs", "_warp", "_robust_means", "_shift_angles"}
    for name, t in kernels.items():
        assert t.parallel.targetoptions.get("parallel") and not t.serial.targetoptions.get("parallel")
        assert t.parallel.py_func.__qualname__ == t.serial.py_func.__qualname__ + PARALLEL_SUFFIX  # own cache files
        assert t.pick(0) is t.serial and t.pick(t.threshold - 1) is t.serial
        assert t.pick(t.threshold) is (t.parallel if t.parallel_ready() else t.serial)
        assert t.pick(COLD_FACTOR * t.threshold) is t.parallel


def test_worker_threads_get_the_serial_twin():
    """A kernel called from a worker thread (a Dask worker's task pool) runs serial whatever its size; forced wins."""
    from concurrent.futures import ThreadPoolExecutor

    t = W._knn_profile
    big = t.threshold * COLD_FACTOR
    with ThreadPoolExecutor(1) as pool:
        assert pool.submit(t.pick, big).result() is t.serial
    assert t.pick(big) is t.parallel  # the main thread

    def forced_pick():
        with forced("parallel"):
            return t.pick(0)

    with ThreadPoolExecutor(1) as pool:
        assert pool.submit(forced_pick).result() is t.parallel


def test_twins_equal_each_other_and_the_oracles(rng):
    A, B = _random_quats(rng, (40, 7)), _random_quats(rng, (50, 7))
    A[3, 2] = np.nan
    groups = np.array([[True] * 7, [True, True, False, True, False, True, True]])
    s, p = _both(W.group_pose_distances, A, B, groups, [3, 1])
    _assert_same(s, p)
    for g, dr in ((0, 3), (1, 1)):
        members = np.flatnonzero(groups[g])
        for a in (0, 3, 17):
            for b in (0, 9, 49):
                want = np.inf if a == 3 and 2 in members else group_pose_distance_naive(A[a], B[b], members, dr)
                assert s[g, a, b] == pytest.approx(want, rel=1e-5, abs=1e-6)
    D = s[0]
    src, tgt = np.array([0, 5, 25]), np.arange(0, 31, 3)
    prof = _both(W.word_distance_profile, D, src, tgt)
    _assert_same(*prof)
    d, i, j = W.word_dtw(D[5:20, 9:29].astype(np.float64))  # itself checked against word_dtw_enumerate above
    assert prof[0][0][1, 3] == pytest.approx(d, rel=1e-6) and (prof[0][1][1, 3], prof[0][2][1, 3]) == (i, j)
    ps, pt = np.repeat(src, len(tgt)), np.tile(tgt, len(src))
    _assert_same(*_both(W.word_distance_pairs, A, B, groups[1], 1, ps, pt))
    _assert_same(*_both(W.warp_target_words, A, B, np.arange(7), 3, ps, pt))
    T = _walk_texture(160, 1)
    DT = W.group_pose_distances(T, T, np.ones((1, 6), dtype=bool), [1])[0]
    src, tgt = np.arange(0, 145, 5), np.arange(0, 141)
    knn = _both(W.word_knn_profile, DT, src, tgt, 5, src, 7, return_evaluated=True)
    _assert_same(*knn)
    want = naive_local_minima_knn(W.word_distance_profile(DT, src, tgt)[0], tgt, 5, src, 7)
    assert [[t for t in row if t >= 0] for row in knn[0][0].tolist()] == [[t for _, t in row] for row in want]
    _assert_same(*_both(W.word_dtw_lower_bounds, DT, src, tgt))
    words = _random_quats(rng, (6, 4, 15, 5))
    valid = rng.random((6, 4)) < 0.7
    _assert_same(*_both(W.robust_word_means, words, valid, 0.1))
    inp, ref = _random_quats(rng, (30, 4)), _random_quats(rng, (30, 4))
    ref[5:8, 1] = np.nan
    _assert_same(*_both(W.shift_tolerant_angles, inp, ref, 2))


_TWIN_MODULE = '''
import numpy as np
from numba import prange
from mocapkit.cleaning.ssa.twins import twin_kernels

@twin_kernels(100)
def square(x, out):
    for i in prange(x.shape[0]):
        out[i] = x[i] * x[i]
'''

# One process of the cold-cache sequence: the twins named in ``sides`` called in that order, each line
# ``side cache_hits cache_misses``; ``picks`` first prints the twin pick() gives below, at and far over the threshold
# (before any call, so it reads the cache as a new process finds it) and, after the calls, at the threshold again.
_TWIN_RUN = '''
import sys, numpy as np
sys.path.insert(0, {folder!r})
import twinmod
from mocapkit.cleaning.ssa.twins import COLD_FACTOR
t = twinmod.square
if {picks!r}:
    print("picks", t.pick(99) is t.serial, t.pick(100) is t.parallel, t.pick(100 * COLD_FACTOR) is t.parallel)
x = np.arange(200.0)
for side in {sides!r}:
    k = getattr(t, side)
    out = np.empty(200)
    k(x, out)
    assert np.array_equal(out, x * x)
    st = k.stats
    print(side, len(st.cache_hits), len(st.cache_misses))
if {picks!r}:
    print("after", t.pick(100) is t.parallel)
'''


@pytest.fixture(scope="module")
def cold_twin_runs(tmp_path_factory):
    """A two-twin kernel in a fresh numba cache, through three processes (the one cold compile of each twin that
    the tests below share; a parallel twin compiles cold in seconds, the test run's costliest step here):

    1. ``serial``: the serial twin alone, with an empty cache;
    2. ``parallel``: pick() with only the serial twin cached, then the parallel twin alone;
    3. ``both``: pick() with both cached, then the serial and the parallel twin.

    Returns ``(outputs, names)``: each run's lines as ``{first word: the rest}``, and the sorted kernel names of
    the cache's index files.
    """
    import subprocess
    import sys

    folder = tmp_path_factory.mktemp("twins")
    (folder / "twinmod.py").write_text(_TWIN_MODULE)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(folder / "cache")}

    def run(sides, picks):
        code = _TWIN_RUN.format(folder=str(folder), sides=sides, picks=picks)
        out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True)
        return {line.split()[0]: tuple(line.split()[1:]) for line in out.stdout.splitlines()}

    outputs = {"serial": run(("serial",), False), "parallel": run(("parallel",), True),
               "both": run(("serial", "parallel"), True)}
    names = sorted(p.name.split("-")[0] for p in (folder / "cache").rglob("*.nbi"))
    return outputs, names


def test_twins_keep_their_own_cache_entries(cold_twin_runs):
    """Compiled serial only, then parallel in a fresh process: the parallel twin compiles (it does not load the
    serial machine code); a third process loads both from the cache."""
    out, names = cold_twin_runs
    assert out["serial"] == {"serial": ("0", "1")}  # compiled, saved
    assert out["parallel"]["parallel"] == ("0", "1")  # not the serial entry: compiled, saved
    assert {k: out["both"][k] for k in ("serial", "parallel")} == {"serial": ("1", "0"), "parallel": ("1", "0")}
    assert names == ["twinmod.square", "twinmod.square" + PARALLEL_SUFFIX]


def test_a_parallel_twin_not_compiled_nor_cached_runs_only_on_very_large_problems(cold_twin_runs):
    """With the parallel twin neither compiled nor cached (the serial one cached beside it) a size over the threshold
    still gets the serial twin (compiling the parallel one would cost more than it saves), up to COLD_FACTOR x the
    threshold; once compiled, and in a later process that finds it in the cache, the threshold alone decides."""
    out, _ = cold_twin_runs
    assert out["parallel"]["picks"] == ("True", "False", "True")  # cold: serial at the threshold
    assert out["parallel"]["after"] == ("True",)  # compiled: parallel
    assert out["both"]["picks"] == ("True", "True", "True")  # cached: parallel at the threshold before any call
    assert out["both"]["after"] == ("True",)


_TORCH_THREADS_RUN = '''
import numpy as np, torch
from mocapkit.cleaning.ssa.twins import forced
from mocapkit.cleaning.ssa.word_dtw import group_pose_distances
torch.set_num_threads(1)
torch.ones(300, 300) @ torch.ones(300, 300)  # torch's OpenMP threads (a denoiser's inference starts them), then numba's
q = np.tile([1.0, 0.0, 0.0, 0.0], (40, 3, 1))
with forced("parallel"):
    group_pose_distances(q, q, np.ones((1, 3), bool), [0])
print(torch.get_num_threads())
'''


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="numba's pool of one thread sets the count torch was given")
def test_a_parallel_twin_leaves_the_callers_torch_threads_as_set():
    """The first parallel kernel in a process (after torch had run) started numba's OpenMP pool, which set the
    OpenMP thread count to the core count: a caller's torch.set_num_threads(1) read 2 after its first clean.
    A product of two torch tensors runs torch's threads as the EBF denoiser's inference does (without
    ``twins.start_threads`` the count read here is 2 either way) at a fraction of its cost."""
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", _TORCH_THREADS_RUN], check=True, capture_output=True, text=True)
    assert out.stdout.split() == ["1"]


@pytest.mark.parametrize("contiguous", [True, False])
@pytest.mark.parametrize("N, M, run", [(15, 20, 3), (10, 12, 1), (6, 9, 2)])
def test_row_minima_equal_the_window_minima(rng, contiguous, N, M, run):
    """Each bound row minimum is the minimum of its column window, consecutive starts or not, both twins."""
    D = rng.random((30, 70)).astype(np.float32)
    D[4, 20:26] = np.inf
    D[9] = np.inf
    tgt = np.arange(3, 70 - M + 1) if contiguous else np.sort(rng.choice(70 - M + 1, 25, replace=False))
    lens, _ = W._row_windows(N, M, run)
    want = np.array([[[D[r, t : t + n].min() for t in tgt] for r in range(30)] for n in lens])
    for side in ("serial", "parallel"):
        got = np.full((len(lens), 30, len(tgt)), -1.0, dtype=np.float32)
        getattr(W._row_minima, side)(D, tgt, lens, got)
        assert np.array_equal(got, want)
