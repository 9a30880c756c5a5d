"""Multilinear motion models (Tautges 2012, ch. 2): n-mode algebra, HOSVD, eq. 2.10, synthesis and the fit to readings."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

import mocapkit
from mocapkit import metrics, samples
from mocapkit import rotations as R
from mocapkit.features import default_sensors, virtual_accelerometers
from mocapkit.reconstruct.multilinear import (
    MultilinearModel,
    _sensor_positions,
    acceleration_distance,
    hdm05_labels,
    hosvd,
    mode_product,
    motion_tensor,
    reconstruct_tensor,
    unfold,
)
from mocapkit.features import five_point_derivative
from mocapkit.motion import unit_scale_cm

UP = np.array([0.0, 1.0, 0.0])


@pytest.fixture(scope="module")
def sneak():
    return [mocapkit.load(samples.path(f"HDM_bk_sneak2StepsLStart_00{i}_120.amc")) for i in (4, 5)]


@pytest.fixture(scope="module")
def sneak_model(sneak):
    return MultilinearModel(fps=30.0).fit(sneak)


def _readings(m):
    sens = default_sensors(m.skeleton)
    grot, _ = m.global_transforms()
    q = R.quaternion_multiply(grot[:, [m.skeleton.index(s.joint) for s in sens]], np.stack([s.rotation for s in sens]))
    return virtual_accelerometers(m, sens), q


# -- n-mode algebra ------------------------------------------------------------------------


def _mode_product_loops(t, m, mode):
    """Slow twin: out[..., i, ...] = sum_j m[i, j] t[..., j, ...] by explicit loops over every index."""
    shape = list(t.shape)
    shape[mode] = m.shape[0]
    out = np.zeros(shape)
    for idx in itertools.product(*[range(s) for s in shape]):
        i = idx[mode]
        acc = 0.0
        for j in range(t.shape[mode]):
            src = list(idx)
            src[mode] = j
            acc += m[i, j] * t[tuple(src)]
        out[idx] = acc
    return out


@given(st.lists(st.integers(1, 4), min_size=1, max_size=4), st.data())
@settings(max_examples=30, deadline=None)
def test_mode_product_matches_loops_and_einsum(shape, data):
    rng = np.random.default_rng(data.draw(st.integers(0, 1000)))
    mode = data.draw(st.integers(0, len(shape) - 1))
    t = rng.normal(size=shape)
    m = rng.normal(size=(data.draw(st.integers(1, 3)), shape[mode]))
    got = mode_product(t, m, mode)
    np.testing.assert_allclose(got, _mode_product_loops(t, m, mode), atol=1e-12)
    letters = "abcd"[: len(shape)]
    out = letters.replace(letters[mode], "z")
    np.testing.assert_allclose(got, np.einsum(f"z{letters[mode]},{letters}->{out}", m, t), atol=1e-12)


def test_mode_product_row_vector_and_bad_shapes():
    t = np.arange(24.0).reshape(2, 3, 4)
    v = np.array([1.0, -1.0, 2.0])
    assert mode_product(t, v, 1).shape == (2, 1, 4)
    np.testing.assert_allclose(mode_product(t, v, 1)[:, 0], t[:, 0] - t[:, 1] + 2 * t[:, 2])
    with pytest.raises(ValueError, match="columns"):
        mode_product(t, np.ones((2, 4)), 1)
    with pytest.raises(ValueError, match="out of range"):
        mode_product(t, np.ones((2, 3)), 5)


@pytest.mark.parametrize("shape", [(4, 3, 5, 2), (6, 2, 1), (3, 3, 3)])
def test_hosvd_full_rank_round_trip_and_orthonormal(shape, rng):
    t = rng.normal(size=shape)
    core, factors = hosvd(t)
    for k, U in enumerate(factors):
        assert U.shape[0] == shape[k]
        np.testing.assert_allclose(U.T @ U, np.eye(U.shape[1]), atol=1e-12)
    np.testing.assert_allclose(reconstruct_tensor(core, factors), t, atol=1e-12)
    # (6, 2, 1): the mode-0 unfolding has only 2 columns; the factor is completed to a 6x6 orthonormal matrix.
    full = hosvd(t, [s for s in shape])
    np.testing.assert_allclose(reconstruct_tensor(*full), t, atol=1e-12)
    for U, s in zip(full[1], shape):
        np.testing.assert_allclose(U.T @ U, np.eye(s), atol=1e-12)


def test_hosvd_truncation_is_the_projection_and_orders_energy(rng):
    # A tensor of multilinear rank (2, 2, 2) is recovered exactly by rank-(2, 2, 2) truncation.
    core = rng.normal(size=(2, 2, 2))
    Us = [np.linalg.qr(rng.normal(size=(d, 2)))[0] for d in (5, 4, 6)]
    t = reconstruct_tensor(core, Us)
    c2, f2 = hosvd(t, [2, 2, 2])
    np.testing.assert_allclose(reconstruct_tensor(c2, f2), t, atol=1e-10)
    # Truncating a generic tensor: the core's slice energies decrease along every mode (Fig. 2.2).
    g = rng.normal(size=(5, 4, 6))
    c, _ = hosvd(g)
    for k in range(3):
        energy = np.sum(unfold(c, k) ** 2, axis=1)
        assert np.all(np.diff(energy) <= 1e-9)
    with pytest.raises(ValueError, match="rank"):
        hosvd(g, [6, None, None])


# -- eq. 2.10 --------------------------------------------------------------------------------


def _brute_distance(a, b, up=UP):
    def f(th):
        q = R.quaternion_from_axis_angle(up, th)
        return float(np.sum((a - R.quaternion_rotate(q, b)) ** 2))

    grid = np.linspace(-np.pi, np.pi, 361)
    th0 = grid[np.argmin([f(x) for x in grid])]
    res = minimize_scalar(f, bounds=(th0 - 0.02, th0 + 0.02), method="bounded", options={"xatol": 1e-10})
    return res.fun, res.x


@given(st.integers(0, 10_000), st.sampled_from(["y", "z", "-x"]))
@settings(max_examples=20, deadline=None)
def test_acceleration_distance_equals_brute_force(seed, axis):
    rng = np.random.default_rng(seed)
    up = {"y": UP, "z": np.array([0.0, 0.0, 1.0]), "-x": np.array([-1.0, 0.0, 0.0])}[axis]
    a = rng.normal(size=(7, 3, 3))
    b = rng.normal(size=(7, 3, 3))
    d, th = acceleration_distance(a, b, up_axis=axis)
    bd, bth = _brute_distance(a, b, up)
    assert d == pytest.approx(bd, rel=1e-7, abs=1e-9)
    rotated = R.quaternion_rotate(R.quaternion_from_axis_angle(up, th), b)
    assert np.sum((a - rotated) ** 2) == pytest.approx(d, rel=1e-9, abs=1e-9)


@given(st.integers(0, 10_000), st.floats(-3.1, 3.1))
@settings(max_examples=40, deadline=None)
def test_rotated_copy_has_zero_distance(seed, angle):
    b = np.random.default_rng(seed).normal(size=(20, 4, 3))
    a = R.quaternion_rotate(R.quaternion_from_axis_angle(UP, angle), b)
    d, th = acceleration_distance(a, b)
    assert d < 1e-9 * np.sum(b * b)
    assert np.angle(np.exp(1j * (th - angle))) == pytest.approx(0.0, abs=1e-7)


def test_acceleration_distance_ignores_nan_and_checks_shapes():
    b = np.random.default_rng(1).normal(size=(10, 2, 3))
    a = b.copy()
    a[3, 1, 0] = np.nan
    assert acceleration_distance(a, b)[0] == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="shape"):
        acceleration_distance(a, b[:5])


# -- motion tensors and synthesis -------------------------------------------------------------


def test_motion_tensor_layout(sneak):
    t = motion_tensor(sneak, fps=30.0)
    J = sneak[0].skeleton.num_joints
    assert t.modes == ("actor", "repetition")
    assert t.entries == (("bk",), (0, 1))
    assert t.rotations.shape[:2] == (4, J) and t.rotations.shape[3:] == (1, 2)
    assert t.root.shape == (3, t.num_frames, 1, 2)
    assert t.observed.all()
    # The reference is aligned to itself: its first frame is its first frame (root at the origin).
    c = t.clip((0, 0))
    np.testing.assert_allclose(c.root_positions[0, [0, 2]], 0.0, atol=1e-9)
    # Every joint's quaternions in the reference's hemisphere.
    dots = np.sum(t.rotations[..., 0, 0] * t.rotations[..., 0, 1], axis=0)
    assert np.all(np.sum(dots, axis=1) > 0)


def test_hdm05_labels_rank_repetitions():
    names = ["HDM_bd_x_003_120", Path("/d/HDM_bd_x_001_120.amc"), "HDM_tr_x_007_120"]
    assert hdm05_labels(names) == [("bd", 1), ("bd", 0), ("tr", 0)]
    with pytest.raises(ValueError, match="HDM05"):
        hdm05_labels(["walk_01"])


def test_name_labels_read_the_modes_and_the_one_class_from_hdm05_and_bandai_names():
    from mocapkit.reconstruct.motion_tensor import name_labels

    assert name_labels(["HDM_bd_x_003_120.amc", "HDM_bd_x_001_120.amc", "HDM_tr_x_007_120.amc"]) == (
        ("actor", "repetition"), [("bd", 1), ("bd", 0), ("tr", 0)], "x")
    # Bandai Namco: one take per style gives one mode; a style with two takes adds the repetition
    assert name_labels(["dataset-1_run_old_001.bvh", Path("/d/dataset-2_run_active_049.bvh")]) == (
        ("style",), [("old",), ("active",)], "run")
    assert name_labels(["dataset-1_walk_sad_002.bvh", "dataset-1_walk_sad_001.bvh", "dataset-1_walk_not-confident_001"]) == (
        ("style", "repetition"), [("sad", 1), ("sad", 0), ("not-confident", 0)], "walk")
    with pytest.raises(ValueError, match=r"takes of 2 motion classes \(run, walk\)"):
        name_labels(["dataset-1_run_old_001.bvh", "dataset-1_walk_sad_001.bvh"])
    with pytest.raises(ValueError, match="'131_01' is named neither"):
        name_labels(["HDM_bd_x_003_120.amc", "131_01.bvh"])


def test_synthesis_of_training_weights_reproduces_the_aligned_clip(sneak, sneak_model):
    t = sneak_model.tensor_
    for idx in [(0, 0), (0, 1)]:
        out = sneak_model.synthesize(sneak_model.clip_weights(idx))
        assert metrics.joint_position_rms(t.clip(idx), out) < 1e-8
    # Truncated frame mode (20 of 70-odd components): close, not exact; dropping a repetition
    # component (rank 1 of 2) loses what tells the two repetitions apart, a larger error.
    def err(ranks):
        small = MultilinearModel(ranks=ranks).fit(t)
        return metrics.joint_position_rms(t.clip((0, 1)), small.synthesize(small.clip_weights((0, 1))), root_relative="frame")

    e_frame, e_rep = err({"frame": 20}), err({"repetition": 1})
    assert 1e-3 < e_frame < 2.0
    assert e_rep > e_frame
    # Uniform weights = the mean of the two aligned clips (multilinearity).
    mean = sneak_model.synthesize()
    direct = 0.5 * (t.rotations[..., 0, 0] + t.rotations[..., 0, 1])
    direct = np.transpose(direct, (2, 1, 0))
    np.testing.assert_allclose(mean.rotations, direct / np.linalg.norm(direct, axis=-1, keepdims=True), atol=1e-10)


def test_bad_input_raises(sneak):
    other_rig = mocapkit.load(samples.path("131_01.bvh"))[:300]
    with pytest.raises(ValueError, match="joint layout"):
        motion_tensor([sneak[0], other_rig], labels=[("a", 0), ("b", 0)])
    with pytest.raises(ValueError, match="at least 2 clips"):
        motion_tensor(sneak[:1])
    with pytest.raises(ValueError, match="needs at least"):
        MultilinearModel(ranks={"repetition": 3}).fit(sneak)
    with pytest.raises(ValueError, match="unknown modes"):
        MultilinearModel(ranks={"style": 1}).fit(sneak)
    with pytest.raises(ValueError, match="share the labels"):
        motion_tensor(sneak, labels=[("bk", 0), ("bk", 0)])
    with pytest.raises(ValueError, match="no clip"):
        motion_tensor(sneak, labels=[("bk", 0), ("bd", 1)])
    filled = motion_tensor(sneak, labels=[("bk", 0), ("bd", 1)], missing="mean")
    assert filled.entries == (("bd", "bk"), (0, 1))
    assert filled.observed.tolist() == [[False, True], [True, False]]
    # Each actor's missing repetition is that actor's mean (here its only clip), not the other actor's.
    np.testing.assert_allclose(filled.rotations[..., 0, 0], filled.rotations[..., 0, 1])
    np.testing.assert_allclose(filled.rotations[..., 1, 1], filled.rotations[..., 1, 0])
    assert not np.allclose(filled.rotations[..., 0, 0], filled.rotations[..., 1, 0])
    three = motion_tensor(sneak + sneak[:1], labels=[("bk", 0), ("bk", 1), ("bd", 0)], missing="mean")
    np.testing.assert_allclose(three.rotations[..., 0, 1], three.rotations[..., 0, 0])  # bd's mean
    dropped = motion_tensor(sneak + sneak[:1], labels=[("bk", 0), ("bk", 1), ("bd", 0)], missing="drop")
    assert dropped.shape == (2, 1) and dropped.observed.all() and len(dropped.names) == 2
    with pytest.raises(ValueError, match="no entry"):
        motion_tensor(sneak, labels=[("bk", 0), ("bd", 1)], missing="drop")
    model = MultilinearModel().fit(sneak)
    with pytest.raises(ValueError, match="expected shape"):
        model.fit_readings(np.zeros((50, 3, 3)), 120.0)
    with pytest.raises(ValueError, match="orientations"):
        model.fit_readings(np.zeros((50, 4, 3)), 120.0, orientations=np.zeros((50, 4, 3)))
    with pytest.raises(ValueError, match="weights of mode"):
        model.synthesize([np.ones(1), np.ones(3)])
    with pytest.raises(ValueError, match="not fitted"):
        MultilinearModel().synthesize()


# -- fitting readings ------------------------------------------------------------------------------


def test_readings_frames_and_heading(sneak, sneak_model):
    """Sensor-frame readings with orientations = global accelerations; a turned recording turns the output."""
    m = sneak[1]
    local, q = _readings(m)
    sens = default_sensors(m.skeleton)
    glob = five_point_derivative(_sensor_positions(m, sens) * unit_scale_cm(m.skeleton) / 100, m.fps, order=2)
    _, out1, i1 = sneak_model.fit_readings(local, m.fps, orientations=q, optimize=False, return_info=True)
    _, out2, i2 = sneak_model.fit_readings(glob, m.fps, optimize=False, return_info=True)
    assert i1["distance"] == pytest.approx(i2["distance"], rel=1e-9)
    assert out1.num_frames == m.num_frames and out1.fps == m.fps
    turn = R.quaternion_from_axis_angle(UP, 1.0)
    _, out3, i3 = sneak_model.fit_readings(R.quaternion_rotate(turn, glob), m.fps, optimize=False, return_info=True)
    assert i3["distance"] == pytest.approx(i2["distance"], rel=1e-9)
    assert np.angle(np.exp(1j * (i3["theta"] - i2["theta"] - 1.0))) == pytest.approx(0.0, abs=1e-9)
    # Root-frame poses do not change, global ones turn with the recording.
    assert metrics.joint_position_rms(out2, out3, root_relative="frame") < 1e-8
    p2 = out2.global_positions()
    np.testing.assert_allclose(out3.global_positions(), R.quaternion_rotate(turn, p2), atol=1e-8)


def test_fit_beats_the_mean_on_a_training_clip(sneak, sneak_model):
    """Bundled samples only: readings of repetition 005 pick that repetition out of the 2-clip tensor."""
    m = sneak[1]
    local, q = _readings(m)
    w, out, info = sneak_model.fit_readings(local, m.fps, orientations=q, maxiter=25, return_info=True)
    _, mean, mi = sneak_model.fit_readings(local, m.fps, orientations=q, optimize=False, return_info=True)
    assert info["relative_distance"] < 0.6 * mi["relative_distance"]
    assert w[1][1] > w[1][0]  # the weight goes to the clip that made the readings
    e_fit = metrics.joint_position_rms(m, out, root_relative="frame")
    e_mean = metrics.joint_position_rms(m, mean, root_relative="frame")
    assert e_fit < 0.7 * e_mean
    assert np.allclose([x.sum() for x in w], 1.0)


def test_held_out_actor_beats_the_mean(shared_data):
    """HDM05 sneak2StepsLStart: model of actors bd bk dg tr, readings of actor mm's clip (never in the tensor)."""
    root = shared_data / "hdm05_asfamc"
    train = [mocapkit.load(p) for a in ("bd", "bk", "dg", "tr") for p in sorted(root.glob(f"HDM_{a}_sneak2StepsLStart_*_120.amc"))]
    test = mocapkit.load(root / "HDM_mm_sneak2StepsLStart_011_120.amc")
    model = MultilinearModel(missing="mean", starts=1, warp_iterations=1).fit(train)
    assert model.tensor_.shape == (4, 4) and model.tensor_.observed.sum() == len(train)
    local, q = _readings(test)
    _, out, info = model.fit_readings(local, test.fps, orientations=q, skeleton=test.skeleton, maxiter=30, return_info=True)
    _, mean, mi = model.fit_readings(local, test.fps, orientations=q, skeleton=test.skeleton, optimize=False, return_info=True)
    assert info["relative_distance"] < mi["relative_distance"]
    e_fit = metrics.joint_position_rms(test, out, root_relative="frame")
    e_mean = metrics.joint_position_rms(test, mean, root_relative="frame")
    assert e_fit < e_mean


# -- a rig whose pelvis is not the root (Bandai Namco: joint_Root on the floor, Hips moves) -------------------


@pytest.fixture(scope="module")
def bandai_runs():
    data = Path(__file__).resolve().parents[1] / "data"
    return [mocapkit.load(data / n) for n in ("dataset-2_run_active_049.bvh", "dataset-1_run_masculinity_001.bvh")]


@pytest.fixture(scope="module")
def bandai_model(bandai_runs):
    return MultilinearModel(modes=("style",)).fit(bandai_runs, [("active",), ("masculinity",)])


def _ground_travel(m: "mocapkit.Motion") -> float:
    """How far (file units) the pelvis (Hips) ends from where it starts, on the floor (x, z)."""
    p = m.global_positions()[:, m.skeleton.index("Hips")]
    return float(np.linalg.norm((p[-1] - p[0])[[0, 2]]))


def test_a_bandai_model_is_of_the_body_with_joint_root_held_on_the_floor(bandai_model, bandai_runs):
    """Two runs on the game rig (joint_Root at the origin, Hips carrying the translation): the tensors hold the body
    from Hips down and Hips' trajectory, the vertical is y (the rest pose lies along x), and the reference run's
    weights give the run back: its body, its 7.5 m on the floor, joint_Root at the origin in every frame (a tensor
    of joint_Root would hold no translation: the pelvis would stand still)."""
    run = bandai_runs[0]
    assert bandai_model.tensor_.reference == run.name
    np.testing.assert_array_equal(bandai_model.up_, UP)
    assert bandai_model.tensor_.rotations.shape[1] == run.num_joints - 1  # Hips and below
    out = bandai_model.synthesize(bandai_model.clip_weights(["active"]), run.skeleton)
    assert out.skeleton.joint_names == run.skeleton.joint_names and out.num_frames == run.num_frames
    np.testing.assert_array_equal(out.root_positions, 0.0)
    np.testing.assert_array_equal(out.rotations[:, 0], np.broadcast_to([1.0, 0.0, 0.0, 0.0], (run.num_frames, 4)))
    assert metrics.joint_position_rms(run, out, root_relative="heading") < 1e-3  # cm
    assert _ground_travel(out) == pytest.approx(_ground_travel(run), rel=1e-6)
    assert _ground_travel(run) > 700.0


def test_a_bandai_run_fitted_to_its_own_accelerometers_travels_with_its_root_on_the_floor(bandai_model, bandai_runs):
    run = bandai_runs[0]
    sensors = default_sensors(run.skeleton, up_axis="y")
    grot, _ = run.global_transforms()
    orient = R.quaternion_multiply(grot[:, [run.skeleton.index(s.joint) for s in sensors]],
                                   np.stack([s.rotation for s in sensors]))
    w, out = bandai_model.fit_readings(virtual_accelerometers(run, sensors), run.fps, sensors=sensors,
                                       orientations=orient, skeleton=run.skeleton, maxiter=30)
    assert w[0][0] > 0.95  # its own style
    assert metrics.joint_position_rms(run, out, root_relative="heading") < 0.2  # cm
    assert _ground_travel(out) == pytest.approx(_ground_travel(run), rel=0.01)
    np.testing.assert_array_equal(out.root_positions, 0.0)
