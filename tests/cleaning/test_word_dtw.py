"""The numba kernels of the self-similarity analysis against slow, obvious oracles (tests/naive.py)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit import rotations as R
from mocapkit.cleaning import word_dtw as W
from tests.naive import group_pose_distance_naive, word_dtw_enumerate


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


def test_select_separated_minima():
    dist = np.array([[0.1, 0.2, 0.3, 0.05, 0.4, 0.5]])
    pos = np.array([[10, 12, 40, 100, 60, 80]])
    clips = np.array([[0, 0, 0, 0, 1, 0]])
    out = W.select_separated_minima(dist, pos, clips, 3, 7, np.array([95]), np.array([105]))
    # 100 is in the excluded zone; 12 is too close to 10; 40 next
    assert out.tolist() == [[10, 40, 60]]
