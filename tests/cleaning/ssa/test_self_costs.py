"""The self pose-distance matrix from polynomial terms checked against the acos ones (mocapkit.cleaning.ssa.self_costs)."""

import numpy as np
import pytest
from numba import njit

import mocapkit
from mocapkit import rotations as R
from mocapkit import samples
from mocapkit.cleaning.ssa import self_costs as S
from mocapkit.cleaning.ssa import word_dtw as W
from mocapkit.cleaning.ssa.twins import forced


@njit(cache=False)
def _approx(d):
    out = np.empty_like(d)
    for i in range(d.shape[0]):
        out[i] = S.approx_half_angle_sq(d[i])
    return out


def test_polynomial_term_is_within_its_bound_of_acos():
    rng = np.random.default_rng(3)
    d = np.concatenate([np.linspace(0.0, 1.0, 400001), 1.0 - np.geomspace(1e-17, 1.0, 200001), rng.random(200000),
                        1.0 - rng.random(200000) ** 8, [0.0, 0.5, 1.0]])
    d = np.clip(d, 0.0, 1.0)
    want = np.arccos(d) ** 2
    got = _approx(d)
    assert np.array_equal(got == 0.0, want == 0.0)  # zero exactly where acos is (d = 1)
    nz = want > 0
    assert np.max(np.abs(got[nz] - want[nz]) / want[nz]) < S.TERM_RTOL / 100  # the bound has room to spare


def _estrin(d: float) -> float:
    """The slow reference of the term: the polynomial of self_costs._COEF in t = 1 - 2 d by Estrin's scheme, in
    Python floats, each operation as approx_half_angle_sq's docstring orders them."""
    c = S._COEF
    t = 1.0 - 2.0 * d
    t2 = t * t
    t4 = t2 * t2
    t8 = t4 * t4
    a = [c[2 * i] + c[2 * i + 1] * t for i in range(8)]
    b = [a[2 * i] + a[2 * i + 1] * t2 for i in range(4)]
    p = (b[0] + b[1] * t4) + ((b[2] + b[3] * t4) + c[16] * t8) * t8
    return 2.0 * (1.0 - d) * (p * p)


def test_polynomial_term_is_estrins_evaluation_bit_for_bit():
    """The kernel's term is the reference's, bit for bit (Estrin's four dependent steps, not Horner's sixteen, which
    held the SIMD lanes of a row for their latency), on random values of d, near 0 and 1, and on a real take's."""
    rng = np.random.default_rng(17)
    m = mocapkit.load(samples.path("131_01.bvh"))
    q = R.quaternion_normalize(np.asarray(m.rotations[:200], dtype=np.float64))
    real = np.abs(np.einsum("fjc,gjc->fgj", q[:40], q)).ravel()[::7]  # |dot| of the take's joints, frame pairs
    d = np.clip(np.concatenate([rng.random(3000), 1.0 - np.geomspace(1e-17, 1.0, 2001), np.geomspace(1e-17, 1.0, 2001),
                                [0.0, 0.5, 1.0], real]), 0.0, 1.0)
    got = _approx(d)
    want = np.array([_estrin(float(x)) for x in d])
    assert np.array_equal(got, want)


def test_rows_of_a_real_take_equal_the_acos_matrix_for_every_group_size():
    """A group's sums take its joints four at a time and the last one to three one at a time: groups of 1 to 9 joints
    (every remainder) and drops 0 to 3 on a real take's rotations, both twins, equal the one-joint-at-a-time acos
    kernel's cells bit for bit."""
    m = mocapkit.load(samples.path("131_01.bvh"))
    A = np.ascontiguousarray(R.quaternion_normalize(np.asarray(m.rotations[::4][:150, :10], dtype=np.float64)))
    groups = np.array([[j < size for j in range(10)] for size in range(1, 10)] + [[True] * 10])
    drop = np.array([0, 1, 1, 3, 2, 3, 0, 3, 1, 3], dtype=np.int64)
    drop = np.minimum(drop, groups.sum(axis=1) - 1)
    members, offsets = S.pack_groups(groups)
    want = W.group_pose_distances(A, A, groups, drop)
    for side in ("serial", "parallel"):
        with forced(side):
            got = S.self_pose_rows(A, 20, 60, members, offsets, drop)
        assert np.array_equal(got, want[:, 20:60])


@njit(cache=False)
def _blocks(A, B, okA, okB, members, drop, starts, rtol, N, M):
    out = np.empty((len(starts), N, M))
    terms = np.empty(A.shape[1])
    for p in range(len(starts)):
        S.checked_cost_block(A, B, okA, okB, members, drop, starts[p, 0], starts[p, 1], rtol, terms, out[p])
    return out


def _textures(rng):
    """Quaternion sets meant to trip the check: tiny and large angles, repeated frames, NaN and overlong ones."""
    walk = np.cumsum(rng.normal(scale=0.05, size=(61, 9, 4)), axis=0) + np.array([1.0, 0.0, 0.0, 0.0])
    walk = R.quaternion_normalize(walk)
    walk[10] = walk[9]  # a held frame: zero costs
    walk[20:23] = R.quaternion_normalize(walk[20:23] + 1e-9 * rng.normal(size=(3, 9, 4)))  # tiny angles
    walk[30, 2] = np.nan
    walk[40, 5] = walk[40, 5] * 2.5  # not unit, a component above 2: the exact way
    walk[44] = -walk[43]  # the same rotations, other hemisphere
    spread = R.quaternion_normalize(rng.normal(size=(47, 9, 4)))  # every angle, d below 0.5 too
    return walk, spread


@pytest.mark.parametrize("rtol", [S.DELTA_RTOL, 1e-3, 1.0])
def test_upper_triangle_equals_the_acos_matrix_bit_for_bit(rtol):
    """Both twins, every drop; a large rtol sends most (1.0: every nonzero) cells the exact way."""
    rng = np.random.default_rng(5)
    groups = np.array([[True] * 9, [True, True, False, True, False, True, True, True, False],
                       [False, True] * 4 + [False], [True] * 3 + [False] * 6])
    for A in _textures(rng):
        for drop in ([3, 1, 0, 2], [0, 3, 1, 1]):
            want = W.group_pose_distances(A, A, groups, drop)
            members, offsets = S.pack_groups(groups)
            upper = np.triu(np.ones(want.shape[1:], dtype=bool))
            for side in ("serial", "parallel"):
                out = np.full(want.shape, -7.0, dtype=np.float32)
                with forced(side):
                    S.self_pose_costs(A, members, offsets, np.array(drop, dtype=np.int64), out, rtol)
                assert np.array_equal(out[:, upper], want[:, upper], equal_nan=True)
                assert (out[:, ~upper] == -7.0).all()  # the lower triangle left alone
    with pytest.raises(ValueError, match="rtol"):
        S.self_pose_costs(A, members, offsets, np.array(drop, dtype=np.int64), out, S.DELTA_RTOL / 2)


def test_self_pose_distances_of_a_long_texture_equal_the_full_matrix():
    """Long rows (SIMD lanes over hundreds of frames) on a smooth walk, as a take's texture."""
    rng = np.random.default_rng(11)
    A = R.quaternion_normalize(np.cumsum(rng.normal(scale=0.03, size=(400, 12, 4)), axis=0) + np.array([1.0, 0, 0, 0]))
    groups = np.array([[True] * 12, [True] * 6 + [False] * 6, [False] * 6 + [True] * 6])
    want = W.group_pose_distances(A, A, groups, [3, 1, 1])
    assert np.array_equal(W.self_pose_distances(A, groups, [3, 1, 1]), want)


@pytest.mark.parametrize("rtol", [S.DELTA_RTOL, 1.0])
def test_rows_equal_the_acos_matrix_bit_for_bit(rtol):
    """Row blocks of the self matrix (every column), both twins, NaN and overlong frames among the rows and columns,
    the texture's lanes made here or handed over."""
    rng = np.random.default_rng(7)
    groups = np.array([[True] * 9, [True, True, False, True, False, True, True, True, False], [True] * 3 + [False] * 6])
    drop = np.array([3, 1, 2], dtype=np.int64)
    members, offsets = S.pack_groups(groups)
    for A in _textures(rng):
        want = W.group_pose_distances(A, A, groups, drop)
        for r0, r1 in ((0, len(A)), (25, 46), (len(A) - 1, len(A)), (5, 5)):
            for side in ("serial", "parallel"):
                with forced(side):
                    got = S.self_pose_rows(A, r0, r1, members, offsets, drop, rtol)
                    given = S.self_pose_rows(A, r0, r1, members, offsets, drop, rtol, lanes=S.frame_lanes(A))
                assert got.shape == (3, r1 - r0, len(A))
                assert np.array_equal(got, want[:, r0:r1], equal_nan=True)
                assert np.array_equal(given, want[:, r0:r1], equal_nan=True)  # the lanes made once by the caller
                buf = np.full((3, r1 - r0 + 7, len(A)), -5.0, dtype=np.float32)  # a long take's reused chunk buffer
                with forced(side):
                    into = S.self_pose_rows(A, r0, r1, members, offsets, drop, rtol, out=buf, at=4)
                assert into.base is buf and np.array_equal(into, want[:, r0:r1], equal_nan=True)
                assert (buf[:, :4] == -5.0).all() and (buf[:, r1 - r0 + 4 :] == -5.0).all()  # only its rows written
    with pytest.raises(ValueError, match="rows"):
        S.self_pose_rows(A, 3, len(A) + 1, members, offsets, drop)
    with pytest.raises(ValueError, match="C-contiguous"):
        S.self_pose_rows(A, 0, 5, members, offsets, drop, out=np.empty((3, 4, len(A)), dtype=np.float32))


def test_rows_are_bit_symmetric_on_a_real_take():
    """d(a, b) == d(b, a) in floating point for every cell the rows kernel gives (each term's dot product takes the
    same products in the same order, the group sums the same terms in the joints' order), which the whole-matrix
    path relies on when it mirrors its upper triangle: the rows of a real take, both twins, equal their transpose."""
    m = mocapkit.load(samples.path("131_01.bvh"))
    A = np.ascontiguousarray(R.quaternion_normalize(np.asarray(m.rotations[::3][:240], dtype=np.float64)))
    groups = np.zeros((3, A.shape[1]), dtype=bool)
    groups[0], groups[1, ::2], groups[2, :7] = True, True, True
    members, offsets = S.pack_groups(groups)
    drop = np.array([3, 1, 0], dtype=np.int64)
    for side in ("serial", "parallel"):
        with forced(side):
            D = S.self_pose_rows(A, 0, len(A), members, offsets, drop)
        assert np.array_equal(D, D.transpose(0, 2, 1)) and (D > 0).any()


@pytest.mark.parametrize("rtol", [S.DELTA_RTOL, 1.0])
def test_word_pair_blocks_equal_the_acos_matrix_bit_for_bit(rtol):
    """The (N, M) cost blocks the warps compute, source against itself and against another texture, every drop,
    NaN, overlong and repeated frames among them: the float32 cells of group_pose_distances, bit for bit."""
    rng = np.random.default_rng(9)
    walk, spread = _textures(rng)
    members = np.array([0, 1, 3, 5, 6, 7], dtype=np.int64)
    group = np.zeros((1, 9), dtype=bool)
    group[0, members] = True
    for A, B in ((walk, walk), (walk, spread[:40]), (spread, walk)):
        okA, okB = S.polynomial_frames(A), S.polynomial_frames(B)
        assert not okA.all() or not okB.all()
        starts = np.array([[a, b] for a in range(0, len(A) - 15, 4) for b in range(0, len(B) - 20, 3)], dtype=np.int64)
        for drop in (0, 1, 2, 3):
            want = W.group_pose_distances(A, B, group, [drop])[0].astype(np.float64)
            got = _blocks(A, B, okA, okB, members, drop, starts, rtol, 15, 20)
            for p, (a, b) in enumerate(starts):
                assert np.array_equal(got[p], want[a : a + 15, b : b + 20])
