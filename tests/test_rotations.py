import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from mocapkit import rotations as R

ORDERS = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"]

finite = st.floats(-1.0, 1.0, allow_nan=False, width=64)
quats = arrays(np.float64, (4,), elements=finite).filter(lambda q: np.linalg.norm(q) > 0.1).map(
    lambda q: q / np.linalg.norm(q)
)


def test_scipy_order_is_pinned_w_first():
    # 90 degrees about z: scipy's scalar-first quaternion must equal ours.
    q = R.euler_to_quaternion([90.0], "Z")
    np.testing.assert_allclose(q, [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], atol=1e-15)
    np.testing.assert_allclose(R.from_scipy(R.to_scipy(q))[0], q, atol=1e-15)
    np.testing.assert_allclose(Rotation.from_quat(q, scalar_first=True).as_rotvec(), [0, 0, np.pi / 2], atol=1e-15)


@pytest.mark.parametrize("order", ORDERS + [o.lower() for o in ORDERS])
def test_euler_to_quaternion_matches_scipy(order):
    rng = np.random.default_rng(0)
    ang = rng.uniform(-180, 180, size=(200, 3))
    ours = R.euler_to_quaternion(ang, order)
    ref = Rotation.from_euler(order, ang, degrees=True).as_quat(scalar_first=True)
    dots = np.abs(np.sum(ours * ref, axis=1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-12)


def test_bvh_and_asf_conventions_agree():
    # BVH "Zrotation Yrotation Xrotation" (intrinsic ZYX) and ASF "dof rx ry rz" (extrinsic xyz)
    # are the same matrix Rz @ Ry @ Rx for the same x, y, z angles.
    x, y, z = 10.0, -25.0, 70.0
    bvh = R.euler_to_quaternion([z, y, x], "ZYX")
    asf = R.euler_to_quaternion([x, y, z], "xyz")
    assert np.degrees(R.geodesic_angle(bvh, asf)) < 1e-12
    m = R.quaternion_to_matrix(bvh)
    c = lambda a: (np.cos(np.radians(a)), np.sin(np.radians(a)))
    (cx, sx), (cy, sy), (cz, sz) = c(x), c(y), c(z)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    np.testing.assert_allclose(m, rz @ ry @ rx, atol=1e-14)


@settings(max_examples=200, deadline=None)
@given(
    order=st.sampled_from(ORDERS + [o.lower() for o in ORDERS]),
    a=st.floats(-179.0, 179.0),
    b=st.floats(-85.0, 85.0),
    c=st.floats(-179.0, 179.0),
)
def test_euler_quat_euler_round_trip(order, a, b, c):
    ang = np.array([a, b, c])
    back = R.quaternion_to_euler(R.euler_to_quaternion(ang, order), order)
    # Away from gimbal lock (middle angle within +-85 deg) the angles themselves come back.
    np.testing.assert_allclose(back, ang, atol=1e-7)


@settings(max_examples=100, deadline=None)
@given(order=st.sampled_from(["x", "y", "z", "xz", "zx", "XY", "YZ", "ZX"]), data=st.data())
def test_partial_orders_round_trip(order, data):
    ang = np.array([data.draw(st.floats(-80.0, 80.0)) for _ in order])
    back = R.quaternion_to_euler(R.euler_to_quaternion(ang, order), order)
    np.testing.assert_allclose(back, ang, atol=1e-7)


@settings(max_examples=200, deadline=None)
@given(q=quats)
def test_log_exp_inverse(q):
    back = R.quaternion_exp(R.quaternion_log(q))
    assert abs(abs(np.dot(back, q)) - 1.0) < 1e-12


@settings(max_examples=200, deadline=None)
@given(v=arrays(np.float64, (3,), elements=st.floats(-0.9, 0.9)).filter(lambda v: np.linalg.norm(v) < 1.55))
def test_exp_log_inverse_within_half_pi(v):
    # log returns half-angle vectors of norm <= pi/2; inside that ball exp then log is the identity.
    np.testing.assert_allclose(R.quaternion_log(R.quaternion_exp(v)), v, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(a=quats, b=quats)
def test_geodesic_symmetric_and_zero_on_identical(a, b):
    assert R.geodesic_angle(a, a) < 1e-7
    assert R.geodesic_angle(a, -a) < 1e-7
    assert abs(R.geodesic_angle(a, b) - R.geodesic_angle(b, a)) < 1e-12
    # equals twice the log norm of the relative rotation (Aristidou eq. 1)
    rel = R.quaternion_multiply(R.quaternion_inverse(a), b)
    assert abs(R.geodesic_angle(a, b) - 2 * np.linalg.norm(R.quaternion_log(rel))) < 1e-9


@settings(max_examples=100, deadline=None)
@given(q=quats, v=arrays(np.float64, (3,), elements=st.floats(-10, 10)))
def test_rotate_matches_matrix(q, v):
    np.testing.assert_allclose(R.quaternion_rotate(q, v), R.quaternion_to_matrix(q) @ v, atol=1e-12)


@settings(max_examples=100, deadline=None)
@given(a=quats, b=quats)
def test_multiply_is_matrix_product(a, b):
    np.testing.assert_allclose(
        R.quaternion_to_matrix(R.quaternion_multiply(a, b)),
        R.quaternion_to_matrix(a) @ R.quaternion_to_matrix(b),
        atol=1e-12,
    )


def test_matrix_round_trip():
    rng = np.random.default_rng(1)
    q = R.quaternion_normalize(rng.normal(size=(50, 4)))
    back = R.matrix_to_quaternion(R.quaternion_to_matrix(q))
    np.testing.assert_allclose(np.abs(np.sum(back * q, axis=1)), 1.0, atol=1e-12)


@settings(max_examples=100, deadline=None)
@given(a=quats, b=quats, t=st.floats(0.0, 1.0))
def test_slerp_endpoints_and_constant_speed(a, b, t):
    assert R.geodesic_angle(R.slerp(a, b, 0.0), a) < 1e-6
    assert R.geodesic_angle(R.slerp(a, b, 1.0), b) < 1e-6
    total = R.geodesic_angle(a, b)
    mid = R.slerp(a, b, t)
    assert abs(R.geodesic_angle(a, mid) - t * total) < 1e-6


def test_continuity_removes_sign_flips_and_bridges_nan():
    rng = np.random.default_rng(2)
    angles = np.cumsum(rng.normal(scale=2.0, size=(100, 3)), axis=0)
    q = R.euler_to_quaternion(angles, "ZYX")
    signs = rng.choice([-1.0, 1.0], size=(100, 1))
    flipped = q * signs
    flipped[40:45] = np.nan
    out = R.quaternion_continuity(flipped)
    assert np.all(np.isnan(out[40:45]))
    ok = np.isfinite(out[:, 0])
    idx = np.flatnonzero(ok)
    dots = np.sum(out[idx[1:]] * out[idx[:-1]], axis=1)
    assert np.all(dots > 0)
    # same rotations as before
    assert np.all(R.geodesic_angle(out[ok], q[ok]) < 1e-7)


def test_nan_passes_through():
    q = np.array([[np.nan, 0, 0, 0], [1, 0, 0, 0]])
    assert np.isnan(R.quaternion_multiply(q, q)[0]).all()
    assert np.isnan(R.quaternion_log(q)[0]).all()
    assert np.isnan(R.quaternion_to_euler(q, "ZYX")[0]).all()
    assert np.isfinite(R.quaternion_to_euler(q, "ZYX")[1]).all()


def test_bad_shapes_name_the_fix():
    with pytest.raises(ValueError, match=r"expected shape \(\.\.\., 4\)"):
        R.geodesic_angle(np.zeros((3, 5)), np.zeros((3, 4)))
    with pytest.raises(ValueError, match="only contain x, y and z"):
        R.euler_to_quaternion([1.0, 2.0, 3.0], "ABC")
    with pytest.raises(ValueError, match="mixes cases"):
        R.euler_to_quaternion([1.0, 2.0, 3.0], "Xyz")


vecs = arrays(np.float64, (3,), elements=st.floats(-10, 10)).filter(lambda v: np.linalg.norm(v) > 1e-3)


@given(u=vecs, v=vecs)
def test_shortest_arc_turns_u_onto_v_about_their_common_normal(u, v):
    q = R.shortest_arc(u, v)
    np.testing.assert_allclose(np.linalg.norm(q), 1.0, atol=1e-12)
    un, vn = u / np.linalg.norm(u), v / np.linalg.norm(v)
    np.testing.assert_allclose(R.quaternion_rotate(q, un), vn, atol=1e-9)
    # the smallest such rotation: its angle is the angle between the two directions
    angle = 2.0 * np.arctan2(np.linalg.norm(q[1:]), abs(q[0]))
    np.testing.assert_allclose(angle, np.arccos(np.clip(un @ vn, -1.0, 1.0)), atol=1e-6)


def test_shortest_arc_opposite_zero_and_batched():
    u = np.array([[0.0, 2.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
    v = np.array([[0.0, -3.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [-1.0, 1.0, 0.0]])
    q = R.shortest_arc(u, v)
    assert q.shape == (4, 4)
    # opposite: a half turn about an axis square to u
    assert abs(q[0, 0]) < 1e-12 and abs(q[0, 1:] @ [0.0, 1.0, 0.0]) < 1e-12
    np.testing.assert_allclose(R.quaternion_rotate(q[0], [0.0, 1.0, 0.0]), [0.0, -1.0, 0.0], atol=1e-12)
    np.testing.assert_array_equal(q[1], [1.0, 0.0, 0.0, 0.0])  # the same direction
    np.testing.assert_array_equal(q[2], [1.0, 0.0, 0.0, 0.0])  # a zero vector: the identity
    np.testing.assert_allclose(R.quaternion_rotate(q[3], [1.0, 1.0, 0.0]) / np.sqrt(2), [-1.0, 1.0, 0.0] / np.sqrt(2),
                               atol=1e-12)
    # batched rows are the rows computed one at a time, bit for bit
    for i in range(4):
        np.testing.assert_array_equal(R.shortest_arc(u[i], v[i]), q[i])


@given(q=quats)
@settings(max_examples=50)
def test_kabsch_recovers_the_rotation_of_a_point_set(q):
    rng = np.random.default_rng(1)
    ref = rng.normal(size=(6, 3))
    cur = ref @ R.quaternion_to_matrix(q).T
    m = R.kabsch(ref, cur)
    np.testing.assert_allclose(m, R.quaternion_to_matrix(q), atol=1e-9)
    # one reference per set gives the same, and noise never yields a reflection
    noisy = cur[None] + 0.3 * rng.normal(size=(4, 6, 3))
    per_set = R.kabsch(np.broadcast_to(ref, noisy.shape), noisy)
    np.testing.assert_allclose(per_set, R.kabsch(ref, noisy), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(per_set), 1.0, atol=1e-9)


def test_kabsch_never_reflects_a_mirrored_set():
    ref = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 0.0]])
    mirrored = ref * [-1.0, 1.0, 1.0]
    m = R.kabsch(ref, mirrored)
    np.testing.assert_allclose(np.linalg.det(m), 1.0, atol=1e-12)
    np.testing.assert_allclose(m @ m.T, np.eye(3), atol=1e-12)


@pytest.mark.parametrize("sa, sb", [((4,), (4,)), ((7, 4), (7, 4)), ((4,), (5, 3, 4)), ((5, 1, 4), (1, 3, 4)),
                                    ((0, 4), (4,)), ((300, 6, 4), (300, 6, 4))])
def test_quaternion_multiply_is_the_stacked_product_it_replaces(sa, sb):
    """quaternion_multiply writes each component into its place: bit for bit the np.stack of the four it replaced
    (broadcasting, 0-d, empty, NaN, signed zeros and huge and tiny values too)."""
    rng = np.random.default_rng(len(sa) * 10 + len(sb))
    a = rng.normal(size=sa) * 10.0 ** rng.integers(-150, 150, size=sa)
    b = rng.normal(size=sb) * 10.0 ** rng.integers(-150, 150, size=sb)
    if a.size > 8:
        a.reshape(-1)[:3] = [np.nan, -0.0, np.inf]
    if b.size > 8:
        b.reshape(-1)[1:4] = [0.0, -0.0, np.nan]
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    with np.errstate(all="ignore"):
        want = np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                         aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)
        got = R.quaternion_multiply(a, b)
    assert got.shape == want.shape and got.dtype == want.dtype
    assert np.array_equal(got.view(np.int64), want.view(np.int64)) or np.array_equal(got, want, equal_nan=True)
    assert np.array_equal(np.signbit(got), np.signbit(want)) and np.array_equal(got, want, equal_nan=True)


def test_geodesic_angle_is_nan_quietly_where_a_rotation_is_missing():
    """The one rotation angle (denoise_guard kept a copy for its NaN handling): NaN where either side has a NaN, no
    warning; either sign and any length of a quaternion give the same angle."""
    import warnings

    a = R.euler_to_quaternion(np.array([[10.0, 0.0, 0.0], [0.0, 0.0, 0.0]]), "XYZ")
    b = R.euler_to_quaternion(np.array([[-20.0, 0.0, 0.0], [0.0, 0.0, 0.0]]), "XYZ")
    b[1] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = np.degrees(R.geodesic_angle(a, b))
        assert d[0] == pytest.approx(30.0) and np.isnan(d[1])
        assert np.degrees(R.geodesic_angle(a[0], -2.0 * b[0])) == pytest.approx(30.0)


def test_row_norms_are_numpys_norms_bit_for_bit():
    """row_norms sums the squares column by column: the same bits as np.linalg.norm(axis=-1) on quaternions and
    3-vectors of every shape the library passes (one row, strided views, empty), magnitudes from 1e-150 to 1e150
    (where a different order of the additions would round differently), NaN, inf and zero rows."""
    rng = np.random.default_rng(7)
    for shape in [(4,), (3,), (2,), (1, 4), (5, 4), (0, 4), (7200, 31, 4), (300, 3), (3, 5, 2), (6, 1)]:
        x = rng.normal(size=shape) * np.exp(rng.normal(size=shape) * 30)
        if x.size > 8:
            flat = x.reshape(-1)
            flat[:: 97] = np.nan
            flat[5:: 89] = np.inf
            flat[7:: 83] = -np.inf
            x.reshape(-1, shape[-1])[3] = 0.0
        for arr in (x, x[..., 1:], x[..., ::-1]):
            for keep in (False, True):
                want = np.linalg.norm(arr, axis=-1, keepdims=keep)
                got = R.row_norms(arr, keepdims=keep)
                assert np.shape(got) == np.shape(want) and np.asarray(got).dtype == np.asarray(want).dtype
                assert np.asarray(got).tobytes() == np.asarray(want).tobytes(), (shape, keep)
    q = rng.normal(size=(50, 6, 4))
    assert R.quaternion_normalize(q).tobytes() == (q / np.linalg.norm(q, axis=-1, keepdims=True)).tobytes()


def test_quaternion_to_euler_the_same_with_and_without_missing_rows():
    """Rotations without a missing row convert in one call, no copy in or out: every angle the same, bit for bit, as
    the path for rotations with missing (NaN, inf or zero) rows gives those rows, and the empty set stays empty."""
    rng = np.random.default_rng(3)
    q = R.quaternion_normalize(rng.normal(size=(200, 3, 4)))
    for order in ("xyz", "ZXY", "zy", "x"):
        whole = R.quaternion_to_euler(q, order)
        gappy = q.copy()
        gappy[5, 1] = np.nan
        gappy[9, 0, 2] = np.inf
        gappy[11, 2] = 0.0
        part = R.quaternion_to_euler(gappy, order)
        bad = np.zeros((200, 3), dtype=bool)
        bad[5, 1] = bad[9, 0] = bad[11, 2] = True
        assert np.isnan(part[bad]).all() and part[~bad].tobytes() == whole[~bad].tobytes()
        assert R.quaternion_to_euler(q[:0], order).shape == (0, 3, len(order))
