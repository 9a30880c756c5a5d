"""Tests of mocapkit.features: root normalisation, Krüger feature sets, PCA, virtual markers and accelerometers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mocapkit
from mocapkit import features as fe
from mocapkit import rotations as R
from mocapkit.motion import Motion, Skeleton, find_joint, unit_scale_cm

CMU_CM = 2.54 / 0.45  # 5.644 cm per CMU / HDM05 length unit

# -- a small Y-up humanoid, facing +Z, left = +X, lengths in metres ---------------------

_JOINTS = [
    ("Hips", -1, (0.0, 1.0, 0.0)),
    ("LeftHip", 0, (0.1, 0.0, 0.0)),
    ("LeftKnee", 1, (0.0, -0.45, 0.0)),
    ("LeftAnkle", 2, (0.0, -0.45, 0.0)),
    ("RightHip", 0, (-0.1, 0.0, 0.0)),
    ("RightKnee", 4, (0.0, -0.45, 0.0)),
    ("RightAnkle", 5, (0.0, -0.45, 0.0)),
    ("LowerBack", 0, (0.0, 0.1, 0.0)),
    ("Chest", 7, (0.0, 0.2, 0.0)),
    ("Neck", 8, (0.0, 0.2, 0.0)),
    ("Head", 9, (0.0, 0.1, 0.0)),
    ("LeftShoulder", 8, (0.18, 0.15, 0.0)),
    ("LeftElbow", 11, (0.0, -0.3, 0.0)),
    ("LeftWrist", 12, (0.0, -0.25, 0.0)),
    ("RightShoulder", 8, (-0.18, 0.15, 0.0)),
    ("RightElbow", 14, (0.0, -0.3, 0.0)),
    ("RightWrist", 15, (0.0, -0.25, 0.0)),
]


def humanoid(tpose: bool = False, unit_cm: float | None = 100.0) -> Skeleton:
    """Hanging arms by default; ``tpose`` puts the arms out sideways (along +-X)."""
    offsets = np.array([o for _, _, o in _JOINTS])
    if tpose:
        for name, sign in (("LeftElbow", 1), ("LeftWrist", 1), ("RightElbow", -1), ("RightWrist", -1)):
            j = [n for n, _, _ in _JOINTS].index(name)
            offsets[j] = (sign * np.linalg.norm(offsets[j]), 0.0, 0.0)
    return Skeleton(
        joint_names=tuple(n for n, _, _ in _JOINTS),
        parents=np.array([p for _, p, _ in _JOINTS]),
        offsets=offsets,
        end_site_parents=np.array([10, 13]),
        end_site_offsets=np.array([[0.0, 0.1, 0.0], [0.0, -0.08, 0.0]]),
        unit_cm=unit_cm,
    )


def random_motion(rng, frames: int = 40, skeleton: Skeleton | None = None, fps: float = 120.0, spread=0.4) -> Motion:
    sk = humanoid() if skeleton is None else skeleton
    J = sk.num_joints
    rot = R.rotvec_to_quaternion(rng.normal(0.0, spread, size=(frames, J, 3)))
    root = np.cumsum(rng.normal(0.0, 0.01, size=(frames, 3)), axis=0) + np.array([0.3, 1.0, -0.2])
    return Motion(sk, rot, root, fps, name="random")


def yaw_and_shift(motion: Motion, angle: float, dx: float, dz: float, dy: float = 0.0) -> Motion:
    """The whole motion turned by ``angle`` about +Y (through the origin) and translated."""
    q = R.quaternion_from_axis_angle([0.0, 1.0, 0.0], angle)
    rot = np.array(motion.rotations)
    rot[:, 0] = R.quaternion_multiply(q, rot[:, 0])
    root = R.quaternion_rotate(q, motion.root_positions) + np.array([dx, dy, dz])
    return dataclasses.replace(motion, rotations=rot, root_positions=root)


def at_rest(motion: Motion, frames: int = 12) -> Motion:
    """Frame 0 of ``motion`` held still for ``frames`` frames."""
    return dataclasses.replace(
        motion,
        rotations=np.repeat(motion.rotations[:1], frames, axis=0),
        root_positions=np.repeat(motion.root_positions[:1], frames, axis=0),
    )


@pytest.fixture
def motion(rng):
    return random_motion(rng)


# -- up axis and root frame ---------------------------------------------------------------


def test_detect_up_axis_y_and_z():
    assert fe.detect_up_axis(humanoid()).tolist() == [0.0, 1.0, 0.0]
    # Turn the rig so that +Y becomes +Z: (x, y, z) -> (x, -z, y).
    sk = humanoid()
    m = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    zup = dataclasses.replace(sk, offsets=sk.offsets @ m.T, end_site_offsets=sk.end_site_offsets @ m.T)
    assert fe.detect_up_axis(zup).tolist() == [0.0, 0.0, 1.0]


@pytest.mark.parametrize("spec,expected", [("y", [0, 1, 0]), ("-Z", [0, 0, -1]), ("+x", [1, 0, 0]), (2, [0, 0, 1])])
def test_up_axis_override_spellings(spec, expected):
    assert fe.parse_up_axis(spec).tolist() == expected


@pytest.mark.parametrize("bad", ["w", 3, [1.0, 1.0, 0.0]])
def test_up_axis_bad_spelling_raises(bad):
    with pytest.raises(ValueError, match="up_axis"):
        fe.parse_up_axis(bad)


def test_root_frame_of_rest_pose_is_identity_and_ground_translation():
    sk = humanoid()
    m = Motion(sk, R.identity((3, sk.num_joints)), np.array([[0.5, 1.0, 2.0]] * 3), 30.0)
    rot, tr = fe.root_frame(m)
    np.testing.assert_allclose(rot, R.identity((3,)), atol=1e-12)
    np.testing.assert_allclose(tr, [[0.5, 0.0, 2.0]] * 3)


@pytest.mark.parametrize("angle", [0.3, -2.0, np.pi - 1e-3])
def test_root_frame_follows_yaw_and_survives_pitch_and_roll(angle):
    sk = humanoid()
    F = 3
    rot = R.identity((F, sk.num_joints))
    yaw = R.quaternion_from_axis_angle([0, 1, 0], angle)
    rot[0, 0] = yaw
    # pitched 90 degrees forward (lying face down) and rolled 90 degrees: heading still the yaw
    rot[1, 0] = R.quaternion_multiply(yaw, R.quaternion_from_axis_angle([1, 0, 0], np.pi / 2))
    rot[2, 0] = R.quaternion_multiply(yaw, R.quaternion_from_axis_angle([0, 0, 1], np.pi / 2))
    m = Motion(sk, rot, np.zeros((F, 3)), 30.0)
    q, _ = fe.root_frame(m)
    for k in range(F):
        assert R.geodesic_angle(q[k], yaw) < 1e-9


def test_root_frame_heading_is_the_swing_twist_yaw(rng):
    sk = humanoid()
    F = 50
    rot = R.identity((F, sk.num_joints))
    q = R.quaternion_normalize(rng.normal(size=(F, 4)))
    rot[:, 0] = q
    m = Motion(sk, rot, rng.normal(size=(F, 3)), 30.0)
    heading, _ = fe.root_frame(m)
    yaw = 2 * np.arctan2(q[:, 2], q[:, 0])  # twist about +Y
    expected = R.quaternion_from_axis_angle([0.0, 1.0, 0.0], yaw)
    assert np.all(R.geodesic_angle(heading, expected) < 1e-9)


def test_normalize_positions_faces_plus_z_and_keeps_height(motion):
    pos = motion.global_positions()
    local = fe.normalize_positions(motion, pos)
    up = np.array([0.0, 1.0, 0.0])
    np.testing.assert_allclose(local[..., 1], pos[..., 1], atol=1e-12)  # heights kept
    np.testing.assert_allclose(local[:, 0, [0, 2]], 0.0, atol=1e-12)  # root on the vertical axis
    # The rotated pelvis forward vector projects onto +Z.
    rot = motion.global_rotations()[:, 0]
    fwd = R.quaternion_rotate(rot, [0.0, 0.0, 1.0]) + np.cross(R.quaternion_rotate(rot, [1.0, 0.0, 0.0]), up)
    heading = fe.normalize_positions(motion, pos[:, 0] + fwd) - local[:, 0]
    assert np.all(np.abs(heading[:, 0]) < 1e-9) and np.all(heading[:, 2] > 0)
    # (F, 3) input works too
    np.testing.assert_allclose(fe.normalize_positions(motion, pos[:, 3]), local[:, 3])


def test_normalize_positions_checks_shape(motion):
    with pytest.raises(ValueError, match="positions"):
        fe.normalize_positions(motion, np.zeros((motion.num_frames + 1, 2, 3)))


# -- feature sets -------------------------------------------------------------------------


@settings(max_examples=30, deadline=None)
@given(
    angle=st.floats(-np.pi, np.pi),
    dx=st.floats(-100, 100),
    dz=st.floats(-100, 100),
    seed=st.integers(0, 2**31 - 1),
    name=st.sampled_from(["F15", "F39x3"]),
)
def test_features_invariant_to_yaw_and_ground_translation(angle, dx, dz, seed, name):
    m = random_motion(np.random.default_rng(seed), frames=25, spread=0.6)
    f0 = fe.feature_set(m, name).values
    f1 = fe.feature_set(yaw_and_shift(m, angle, dx, dz), name).values
    np.testing.assert_allclose(f1, f0, atol=1e-8)


def test_features_keep_height(motion):
    f0 = fe.feature_set(motion, "F15").values.reshape(-1, 5, 3)
    f1 = fe.feature_set(yaw_and_shift(motion, 0.7, 1.0, 2.0, dy=0.25), "F15").values.reshape(-1, 5, 3)
    np.testing.assert_allclose(f1[..., 1] - f0[..., 1], 0.25, atol=1e-12)
    np.testing.assert_allclose(f1[..., [0, 2]], f0[..., [0, 2]], atol=1e-10)


@pytest.mark.parametrize(
    "name,dim", [("F15", 15), ("F30", 30), ("F39", 39), ("F15x3", 45), ("F15x5", 75), ("F30x3", 90), ("F39x3", 117)]
)
def test_feature_dims_and_names(motion, name, dim):
    f = fe.feature_set(motion, name)
    assert isinstance(f, fe.Features)
    assert f.values.shape == (motion.num_frames, dim) and f.dim == dim and len(f.names) == dim
    assert len(set(f.names)) == dim
    assert f.fps == motion.fps
    assert not f.values.flags.writeable


def test_feature_names_and_order(motion):
    f15 = fe.feature_set(motion, "F15")
    assert f15.names[:3] == ("left_hand.x", "left_hand.y", "left_hand.z")
    assert [n.split(".")[0] for n in f15.names[::3]] == ["left_hand", "right_hand", "left_foot", "right_foot", "head"]
    f39 = fe.feature_set(motion, "F39")
    assert f39.names[:30] == fe.feature_set(motion, "F30").names
    assert f39.names[30::3] == ("left_shoulder.x", "right_shoulder.x", "lower_back.x")
    # values: the wrist in the normalised frame
    sk = motion.skeleton
    local = fe.normalize_positions(motion, motion.global_positions())
    np.testing.assert_allclose(f15.values[:, :3], local[:, sk.index("LeftWrist")])
    np.testing.assert_allclose(f15.values[:, 12:15], local[:, sk.index("Head")])


def test_unknown_feature_set_raises(motion):
    with pytest.raises(ValueError, match="F15x3"):
        fe.feature_set(motion, "F16")


def test_window_offsets_120_and_30_fps():
    assert fe.window_offsets(120, 3).tolist() == [-18, 0, 18]
    assert fe.window_offsets(120, 5).tolist() == [-18, -9, 0, 9, 18]
    assert fe.window_offsets(30, 3).tolist() == [-5, 0, 5]
    assert fe.window_offsets(30, 5).tolist() == [-5, -2, 0, 2, 5]
    assert fe.window_offsets(25, 3).tolist() == [-4, 0, 4]


@pytest.mark.parametrize("fps", [120.0, 30.0])
def test_windowed_features_sample_shifted_frames_clamped(rng, fps):
    m = random_motion(rng, frames=50, fps=fps)
    base = fe.feature_set(m, "F15").values
    for name, n in (("F15x3", 3), ("F15x5", 5)):
        f = fe.feature_set(m, name)
        offs = fe.window_offsets(fps, n)
        blocks = f.values.reshape(m.num_frames, n, 15)
        for b, off in enumerate(offs):
            idx = np.clip(np.arange(m.num_frames) + off, 0, m.num_frames - 1)
            np.testing.assert_array_equal(blocks[:, b], base[idx])
            assert f.names[15 * b] == f"left_hand.x@{off:+d}".replace("@+0", "@0")


def test_features_in_centimetres(motion):
    f = fe.feature_set(motion, "F15")
    fcm = fe.feature_set(motion, "F15", scale_cm=True)
    assert f.unit_cm == 100.0 and fcm.unit_cm == 1.0
    np.testing.assert_allclose(fcm.values, 100.0 * f.values)


def test_features_of_rig_with_unknown_unit_keep_file_units(rng):
    sk = humanoid(unit_cm=None)
    tiny = dataclasses.replace(sk, offsets=sk.offsets * 0.01)  # 1.8 cm tall in metres: no known unit fits
    m = random_motion(rng, skeleton=tiny)
    f = fe.feature_set(m, "F15")
    assert f.unit_cm is None and np.all(np.isfinite(f.values))
    with pytest.raises(mocapkit.SkeletonError):
        fe.feature_set(m, "F15", scale_cm=True)
    with pytest.raises(mocapkit.SkeletonError):
        fe.virtual_accelerometers(m)
    assert np.all(np.isfinite(fe.virtual_accelerometers(m, unit_cm=100.0)))


# -- PCA ----------------------------------------------------------------------------------


def test_pca_shapes_and_contract(rng):
    train = [random_motion(rng, frames=60), random_motion(rng, frames=40)]
    pca = fe.PCAFeatures(n_components=8)
    assert pca.fit(train) is pca
    D = 3 * train[0].num_joints
    assert pca.mean_.shape == (D,) and pca.components_.shape == (8, D)
    assert pca.explained_variance_ratio_.shape == (8,)
    assert np.all(np.diff(pca.explained_variance_ratio_) <= 1e-12) and pca.explained_variance_ratio_.sum() <= 1 + 1e-12
    np.testing.assert_allclose(pca.components_ @ pca.components_.T, np.eye(8), atol=1e-10)
    z = pca.transform(train[1])
    assert z.shape == (40, 8)
    assert pca.features(train[1]).names[:2] == ("pc0", "pc1")
    assert "PCAFeatures" in repr(pca)


def test_pca_reconstructs_training_data_better_with_more_components(rng):
    train = [random_motion(rng, frames=80)]
    X = fe._base_values(train[0], "joint_positions", None, False)
    errors = []
    for k in (2, 8, 20, X.shape[1]):
        pca = fe.PCAFeatures(n_components=k).fit(train)
        rec = pca.inverse_transform(pca.transform(train[0]))
        errors.append(np.sqrt(np.mean((rec - X) ** 2)))
    assert all(a >= b for a, b in zip(errors, errors[1:]))
    assert errors[-1] < 1e-10


def test_pca_on_feature_set_base(rng):
    train = [random_motion(rng, frames=60)]
    pca = fe.PCAFeatures(n_components=5, base="F15").fit(train[0])
    assert pca.components_.shape == (5, 15)
    assert pca.transform(train[0]).shape == (60, 5)


def test_pca_errors(rng):
    m = random_motion(rng, frames=10)
    with pytest.raises(ValueError, match="not fitted"):
        fe.PCAFeatures().transform(m)
    with pytest.raises(ValueError, match="n_components"):
        fe.PCAFeatures(n_components=100).fit([m])
    pca = fe.PCAFeatures(n_components=2).fit([m])
    other = Skeleton(("a", "b"), np.array([-1, 0]), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="skeleton"):
        pca.transform(Motion(other, R.identity((3, 2)), np.zeros((3, 3)), 30.0))


def test_pca_skips_nan_frames_in_fit(rng):
    m = random_motion(rng, frames=30)
    rot = np.array(m.rotations)
    rot[5, 2] = np.nan  # the knee: moves the ankle
    m_nan = dataclasses.replace(m, rotations=rot)
    pca = fe.PCAFeatures(n_components=4).fit([m_nan])
    assert np.all(np.isfinite(pca.components_))
    z = pca.transform(m_nan)
    assert np.all(np.isnan(z[5])) and np.all(np.isfinite(np.delete(z, 5, axis=0)))


# -- virtual markers ----------------------------------------------------------------------


def test_virtual_markers_positions_offsets_and_noise(motion):
    names = ["LeftWrist", "Head", "Head_end"]
    sk = motion.skeleton
    assert "Head_end" in sk.end_site_names
    plain = fe.virtual_markers(motion, names)
    np.testing.assert_allclose(plain, motion.positions(names))
    off = np.array([[0.0, 0.05, 0.02], [0.1, 0.0, 0.0], [0.0, 0.0, 0.03]])
    shifted = fe.virtual_markers(motion, names, local_offsets=off)
    grot = motion.global_rotations()
    j = [sk.index("LeftWrist"), sk.index("Head"), sk.index("Head")]  # Head_end rides on the head's frame
    np.testing.assert_allclose(shifted, plain + R.quaternion_rotate(grot[:, j], off))
    # distances to the joint are the offset lengths, in every frame
    np.testing.assert_allclose(np.linalg.norm(shifted - plain, axis=-1), np.broadcast_to(np.linalg.norm(off, axis=1), (motion.num_frames, 3)))
    n1 = fe.virtual_markers(motion, names, noise_std=0.01, seed=3)
    n2 = fe.virtual_markers(motion, names, noise_std=0.01, seed=3)
    np.testing.assert_array_equal(n1, n2)
    assert 0.005 < np.std(n1 - plain) < 0.02
    with pytest.raises(KeyError, match="Nose"):
        fe.virtual_markers(motion, ["Nose"])
    with pytest.raises(ValueError, match="local_offsets"):
        fe.virtual_markers(motion, names, local_offsets=np.zeros((2, 3)))


# -- five-point stencil -------------------------------------------------------------------


@settings(max_examples=40, deadline=None)
@given(
    coeffs=st.lists(st.floats(-10, 10), min_size=4, max_size=4),
    n=st.integers(4, 30),
    fps=st.sampled_from([30.0, 100.0, 120.0]),
)
def test_five_point_stencil_exact_on_cubics(coeffs, n, fps):
    c0, c1, c2, c3 = coeffs
    t = np.arange(n) / fps
    x = c0 + c1 * t + c2 * t**2 + c3 * t**3
    v = c1 + 2 * c2 * t + 3 * c3 * t**2
    a = 2 * c2 + 6 * c3 * t
    scale = 1 + np.abs(coeffs).sum()
    np.testing.assert_allclose(fe.five_point_derivative(x, fps, order=1), v, atol=1e-6 * scale * fps)
    np.testing.assert_allclose(fe.five_point_derivative(x, fps, order=2), a, atol=1e-6 * scale * fps**2)


def test_five_point_interior_is_the_paper_stencil_and_exact_on_quintics():
    fps = 10.0
    t = np.arange(12) / fps
    x = t**5 - 2 * t**4
    a = fe.five_point_derivative(x, fps, order=2)
    np.testing.assert_allclose(a[2:-2], 20 * t[2:-2] ** 3 - 24 * t[2:-2] ** 2, atol=1e-9)
    h = 1 / fps
    k = 5
    eq32 = (-x[k + 2] + 16 * x[k + 1] - 30 * x[k] + 16 * x[k - 1] - x[k - 2]) / (12 * h * h)
    eq31 = (-x[k + 2] + 8 * x[k + 1] - 8 * x[k - 1] + x[k - 2]) / (12 * h)
    assert a[k] == pytest.approx(eq32, rel=1e-12)
    assert fe.five_point_derivative(x, fps, order=1)[k] == pytest.approx(eq31, rel=1e-12)


def test_five_point_axis_short_series_and_bad_order():
    x = np.arange(24.0).reshape(3, 8) ** 2  # time along axis 1
    np.testing.assert_allclose(fe.five_point_derivative(x, 1.0, order=2, axis=1), 2.0)
    assert np.all(fe.five_point_derivative(np.array([1.0, 2.0]), 1.0, order=2) == 0)
    np.testing.assert_allclose(fe.five_point_derivative(np.array([0.0, 1.0, 4.0]), 1.0, order=2), 2.0)
    np.testing.assert_allclose(fe.five_point_derivative(np.array([0.0, 1.0, 4.0]), 1.0, order=1), [0.0, 2.0, 4.0])
    with pytest.raises(ValueError, match="order"):
        fe.five_point_derivative(x, 1.0, order=3)


# -- virtual accelerometers -----------------------------------------------------------------


def test_default_sensors_follow_fig_3_3_hanging_arms():
    sk = humanoid()
    sensors = fe.default_sensors(sk)
    assert [s.name for s in sensors] == ["left_wrist", "right_wrist", "left_ankle", "right_ankle"]
    assert [s.joint for s in sensors] == ["LeftElbow", "RightElbow", "LeftKnee", "RightKnee"]
    axes = [R.quaternion_to_matrix(s.rotation) for s in sensors]  # columns: sensor X, Y, Z in the joint frame
    for m in axes:
        np.testing.assert_allclose(m @ m.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(m) == pytest.approx(1.0)
    # X along the bone away from the body (down for hanging arms and legs)
    for m in axes:
        np.testing.assert_allclose(m[:, 0], [0, -1, 0], atol=1e-12)
    # arms: Z is what points up once the arm is raised sideways, i.e. outward now
    np.testing.assert_allclose(axes[0][:, 2], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(axes[1][:, 2], [-1, 0, 0], atol=1e-12)
    # legs: Z forward
    np.testing.assert_allclose(axes[2][:, 2], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(axes[3][:, 2], [0, 0, 1], atol=1e-12)
    # near the wrist / ankle, on the lower arm / leg
    np.testing.assert_allclose(sensors[0].offset, 0.9 * sk.offsets[sk.index("LeftWrist")])


def test_tpose_wrist_sensors_read_gravity_on_z():
    """Tautges sec. 3.3: in a t-pose with palms down gravity projects onto the wrist sensors' z-axes."""
    sk = humanoid(tpose=True)
    sensors = fe.default_sensors(sk)
    np.testing.assert_allclose(R.quaternion_to_matrix(sensors[0].rotation)[:, 0], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(R.quaternion_to_matrix(sensors[1].rotation)[:, 0], [-1, 0, 0], atol=1e-12)
    m = Motion(sk, R.identity((10, sk.num_joints)), np.zeros((10, 3)), 60.0)
    acc = fe.virtual_accelerometers(m)
    np.testing.assert_allclose(acc[:, :2], np.broadcast_to([0, 0, 9.81], (10, 2, 3)), atol=1e-12)
    # legs hang: their X axes point down, so the upward reading is -X
    np.testing.assert_allclose(acc[:, 2:], np.broadcast_to([-9.81, 0, 0], (10, 2, 3)), atol=1e-12)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), gravity=st.sampled_from([9.81, 9.80665, 1.62]))
def test_accelerometer_at_rest_reads_gravity_up(seed, gravity):
    rng = np.random.default_rng(seed)
    m = at_rest(random_motion(rng, frames=3, spread=1.0), frames=9)
    acc = fe.virtual_accelerometers(m, gravity=gravity)
    assert acc.shape == (9, 4, 3)
    np.testing.assert_allclose(np.linalg.norm(acc, axis=-1), gravity, rtol=1e-12)
    sensors = fe.default_sensors(m.skeleton)
    grot = m.global_rotations()
    for s, sensor in enumerate(sensors):
        q = R.quaternion_multiply(grot[:, m.skeleton.index(sensor.joint)], sensor.rotation)
        np.testing.assert_allclose(acc[:, s], R.quaternion_rotate(R.quaternion_conjugate(q), [0, gravity, 0]), atol=1e-12)


def test_accelerometer_on_uniformly_accelerating_root_reads_a_minus_g(rng):
    sk = humanoid()
    F, fps = 30, 60.0
    t = np.arange(F) / fps
    a = np.array([1.5, -0.5, 3.0])  # m/s^2 (the rig is in metres: unit_cm = 100)
    root = np.array([0.2, 1.0, 0.1]) + np.outer(t, [0.4, 0.0, -1.0]) + 0.5 * np.outer(t**2, a)
    rot = np.repeat(R.rotvec_to_quaternion(rng.normal(0, 0.5, size=(1, sk.num_joints, 3))), F, axis=0)
    m = Motion(sk, rot, root, fps)
    root_sensor = fe.Sensor("pelvis", "Hips", R.rotvec_to_quaternion([0.3, -0.2, 1.0]), [0.0, 0.05, 0.1])
    acc = fe.virtual_accelerometers(m, [root_sensor] + fe.default_sensors(sk))
    g_vec = np.array([0.0, -9.81, 0.0])
    grot = m.global_rotations()
    sensors = [root_sensor] + fe.default_sensors(sk)
    for s, sensor in enumerate(sensors):
        q = R.quaternion_multiply(grot[:, sk.index(sensor.joint)], sensor.rotation)
        np.testing.assert_allclose(acc[:, s], R.quaternion_rotate(R.quaternion_conjugate(q), a - g_vec), atol=1e-9)
    # the coordinate accelerations are a for every joint, gravity-free
    np.testing.assert_allclose(fe.global_accelerations(m, ["Hips", "LeftWrist", 3]), np.broadcast_to(a, (F, 3, 3)), atol=1e-9)


def test_accelerometer_unit_conversion(rng):
    m = random_motion(rng, frames=20)
    a_m = fe.virtual_accelerometers(m, gravity=0.0)  # unit_cm = 100: metres
    a_cm = fe.virtual_accelerometers(m, gravity=0.0, unit_cm=1.0)  # the same numbers read as centimetres
    np.testing.assert_allclose(a_cm, a_m / 100.0, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("k", [0, 1, 10, 20, 38, 39])
def test_nan_stays_near_its_frame(rng, k):
    m = random_motion(rng, frames=40)
    rot = np.array(m.rotations)
    rot[k, m.skeleton.index("LeftElbow")] = np.nan
    m = dataclasses.replace(m, rotations=rot)
    acc = fe.virtual_accelerometers(m)
    bad = np.any(np.isnan(acc[:, 0]), axis=-1)
    assert bad[k]
    assert set(np.flatnonzero(bad)) <= set(range(k - 3, k + 4))
    assert np.all(np.isfinite(acc[:, 2:]))  # the leg sensors do not see the arm
    f = fe.feature_set(m, "F15").values
    assert np.flatnonzero(np.any(np.isnan(f), axis=1)).tolist() == [k]
    # a NaN root position makes the frame NaN in every feature, only there
    root = np.array(m.root_positions)
    root[k] = np.nan
    f = fe.feature_set(dataclasses.replace(m, root_positions=root), "F15").values
    assert np.flatnonzero(np.any(np.isnan(f), axis=1)).tolist() == [k]


# -- real clips -----------------------------------------------------------------------------


def _load_sample(name):
    return mocapkit.load(mocapkit.samples.path(name))


def test_cmu_bvh_features_and_accelerometers():
    m = _load_sample("131_01.bvh")
    assert fe.detect_up_axis(m.skeleton).tolist() == [0.0, 1.0, 0.0]
    assert unit_scale_cm(m.skeleton) == pytest.approx(CMU_CM)
    f = fe.feature_set(m, "F39x3", scale_cm=True)
    assert f.values.shape == (m.num_frames, 117) and f.unit_cm == 1.0
    assert np.all(np.isfinite(f.values))
    f15 = fe.feature_set(m, "F15", scale_cm=True).values.reshape(-1, 5, 3)
    head_height = np.median(f15[:, 4, 1] - np.minimum(f15[:, 2, 1], f15[:, 3, 1]))
    assert 120 < head_height < 190  # cm from the lower ankle to the head
    sensors = fe.default_sensors(m.skeleton)
    assert [s.joint for s in sensors] == ["LeftElbow", "RightElbow", "LeftKnee", "RightKnee"]
    acc = fe.virtual_accelerometers(m)
    assert acc.shape == (m.num_frames, 4, 3)
    med = np.median(np.linalg.norm(acc, axis=-1))
    assert 5 < med < 30
    np.testing.assert_allclose(acc, fe.virtual_accelerometers(m, unit_cm=CMU_CM))


def test_hdm05_jog_accelerometers_have_plausible_magnitudes():
    m = _load_sample("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc")
    assert unit_scale_cm(m.skeleton) == pytest.approx(CMU_CM, rel=1e-3)
    assert fe.detect_up_axis(m.skeleton).tolist() == [0.0, 1.0, 0.0]
    acc = fe.virtual_accelerometers(m)
    assert acc.shape == (m.num_frames, 4, 3)
    mag = np.linalg.norm(acc, axis=-1)
    assert 5 < np.median(mag) < 30
    # a jog: the ankles swing harder than the body's 1 g baseline
    assert np.percentile(mag[:, 2:], 90) > 15
    np.testing.assert_allclose(acc, fe.virtual_accelerometers(m, unit_cm=CMU_CM), rtol=1e-3, atol=1e-3)
    f = fe.feature_set(m, "F15")
    assert f.values.shape == (m.num_frames, 15) and np.all(np.isfinite(f.values))
    # the joints playing Krüger's roles exist on the HDM05 rig
    for role in fe.FEATURE_SETS["F39"]:
        find_joint(m.skeleton, role)


def test_up_axis_of_a_take_whose_rest_pose_lies_along_x_comes_from_its_frames():
    """Bandai Namco: the rest pose folds along x (the rest-pose rule says x); the data stand along y."""
    from pathlib import Path

    from mocapkit.report import view

    m = mocapkit.load(Path(__file__).resolve().parent / "data" / "bandai_dance-short_normal_001_first60.bvh")
    assert fe.detect_up_axis(m.skeleton).tolist() == [1.0, 0.0, 0.0]
    assert fe.find_up_axis(m.skeleton, m.global_positions()).tolist() == [0.0, 1.0, 0.0]
    assert view.find_up_axis is fe.find_up_axis
    # normalisation turns about y and keeps the pelvis height: the frame's translation lies in the floor
    rot, trans = fe.root_frame(m)
    axis = rot[:, 1:] / np.linalg.norm(rot[:, 1:], axis=1, keepdims=True).clip(1e-12)
    assert np.all(np.abs(axis[:, [0, 2]]) < 1e-9)
    np.testing.assert_allclose(trans[:, 1], 0.0, atol=1e-9)
    # gravity along y: a still sensor reads +9.81 along the world's y
    rd = fe.virtual_accelerometers(m)
    assert np.all(np.isfinite(rd)) and rd.shape == (len(m), 4, 3)
    np.testing.assert_array_equal(rd, fe.virtual_accelerometers(m, up_axis="y"))


def test_a_skeleton_without_a_head_is_up_along_y_and_cleans():
    """A chain of joints (no head by name or by tree): +y, the BVH convention, and ``clean`` runs on it (before, detect
    stopped at the head no joint plays) and leaves the smooth take as it is."""
    sk = Skeleton(tuple(f"seg{j}" for j in range(6)), np.array([-1, 0, 1, 2, 3, 4]),
                  np.array([[0.0, 0.0, 0.0]] + [[0.0, 0.0, 10.0]] * 5))
    assert fe.detect_up_axis(sk).tolist() == [0.0, 1.0, 0.0]
    t = np.linspace(0.0, 4.0, 200)
    rv = np.zeros((200, 6, 3))
    rv[:, 1:, 1] = 0.3 * np.sin(t)[:, None]
    take = Motion(sk, R.rotvec_to_quaternion(rv), np.zeros((200, 3)), 30.0, "chain")
    res = mocapkit.clean(take)
    assert not res.changed.any()
