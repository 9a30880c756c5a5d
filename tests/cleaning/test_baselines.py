"""Baselines (a), (b), (c) of Aristidou et al. 2018, section 6: rotation limits and rotation-rate limits."""

import dataclasses
import functools
import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import mocapkit
from mocapkit import corrupt, metrics, samples
from mocapkit import rotations as R
from mocapkit.cleaning import baselines as B


@functools.lru_cache(maxsize=None)
def clip(name: str):
    return mocapkit.load(samples.path(name))


@functools.lru_cache(maxsize=None)
def walk_limits():
    return B.learn_joint_limits([clip("12_walk.amc")])


@functools.lru_cache(maxsize=None)
def sneak_limits():
    return B.learn_joint_limits([clip("HDM_bk_sneak2StepsLStart_004_120.amc")])


def unit_quaternions(n):
    return st.lists(st.floats(-1, 1, allow_nan=False), min_size=4 * n, max_size=4 * n).filter(
        lambda v: min(np.linalg.norm(np.reshape(v, (n, 4)), axis=1)) > 0.1
    ).map(lambda v: R.quaternion_normalize(np.reshape(v, (n, 4))))


# -- learnt limits on clean data -----------------------------------------------------


@pytest.mark.parametrize("name", ["12_walk.amc", "HDM_bk_sneak2StepsLStart_004_120.amc", "131_01.bvh"])
def test_clean_clip_flags_nothing_against_its_own_limits(name):
    m = clip(name)
    limits = B.learn_joint_limits([m])
    assert limits.joint_names == m.skeleton.joint_names
    assert limits.num_frames == m.num_frames
    for kind in B.BASELINE_KINDS:
        found = B.detect_baseline(m, limits, kind)
        assert found.shape == (m.num_frames, m.num_joints) and found.dtype == bool
        assert not found.any(), kind
    # the boxes hold every clean value with the margin to spare, and rates the fastest clean step
    v = B.rotation_components(m, limits)
    assert np.all(v >= limits.low - 1e-9) and np.all(v <= limits.high + 1e-9)
    assert np.all(v.min(axis=0) - limits.low >= limits.margin_deg - 1e-9)
    assert np.all(B.angular_speed(m).max(axis=0) <= limits.max_speed)


def test_limits_learnt_from_one_walk_hold_on_another_walk(shared_data):
    """Limits from one CMU subject-12 walk flag (almost) nothing on another of that subject's walks."""
    other = mocapkit.load(shared_data / "cmu_asfamc" / "12_from_examples_02_01.amc")
    for kind in B.BASELINE_KINDS:
        assert B.detect_baseline(other, walk_limits(), kind).mean() < 0.005, kind


def test_limits_learnt_from_jogging_actors_hold_on_a_new_actor(shared_data):
    """Learn on four HDM05 actors' jogs, check the fifth actor's jogs: under 0.5% of cells flagged."""
    paths = sorted((shared_data / "hdm05_asfamc").glob("HDM_*_jogLeftCircle4StepsRstart_*_120.amc"))
    train = [mocapkit.load(p) for p in paths if not p.name.startswith("HDM_mm")]
    held = [mocapkit.load(p) for p in paths if p.name.startswith("HDM_mm")]
    assert len(train) >= 8 and len(held) >= 2
    limits = B.learn_joint_limits(train)
    assert limits.num_frames == sum(m.num_frames for m in train)
    for kind in B.BASELINE_KINDS:
        for m in held:
            assert B.detect_baseline(m, limits, kind).mean() < 0.005, (kind, m.name)
        for m in train:
            assert not B.detect_baseline(m, limits, kind).any()


def test_rate_limits_are_frame_rate_independent():
    """Deg/s, not deg/frame: a joint turning steadily has one speed at any rate; real clips pass when resampled."""
    m = clip("12_walk.amc")
    j = m.skeleton.index("lfemur")
    omega = np.radians(240.0)  # rad/s
    learnt = []
    for fps in (120.0, 30.0):
        t = np.arange(int(2 * fps)) / fps
        rot = np.array(m.rotations[: len(t)])
        rot[:, j] = R.quaternion_from_axis_angle([0.2, 0.1, 1.0], omega * t)
        steady = dataclasses.replace(m, rotations=rot, root_positions=m.root_positions[: len(t)], fps=fps)
        np.testing.assert_allclose(B.angular_speed(steady)[:, j], 240.0, rtol=1e-9)
        learnt.append(B.learn_joint_limits([steady], rate_margin=1.0, min_speed=0.0).max_speed[j])
    assert learnt[0] == pytest.approx(learnt[1], rel=1e-9)
    # limits learnt at 120 fps hold for the same clean clip at 60 and 30 fps
    for fps in (60.0, 30.0):
        assert not B.detect_rate(m.resample(fps), walk_limits()).any()
    # the speed is the geodesic step times fps exactly
    s = B.angular_speed(m)
    np.testing.assert_allclose(s, np.degrees(R.geodesic_angle(m.rotations[:-1], m.rotations[1:])) * 120.0)


# -- detection of injected errors --------------------------------------------------


@pytest.mark.parametrize("seed", range(8))
def test_spike_is_flagged_by_rate_baseline_on_its_joint(seed):
    m = clip("12_walk.amc")
    limits = walk_limits()
    bad, truth, records = corrupt.real_errors(m, kinds=("spike",), n_errors=1, seed=seed)
    (rec,) = records
    j = m.skeleton.index(rec.joint)
    found = B.detect_rate(bad, limits)
    # flagged on the spiked joint, at the spike (both frames of each abrupt step: the window and its edges)
    assert (found[:, j] & truth[:, j]).any()
    assert found[rec.start, j] and found[rec.end - 1, j]
    hit = np.flatnonzero(found[:, j])
    assert hit.min() >= rec.start - 1 and hit.max() <= rec.end
    # other joints are untouched by the error, so their detections are the clean ones (none)
    others = np.ones(m.num_joints, dtype=bool)
    others[j] = False
    assert not found[:, others].any()


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("name", ["12_walk.amc", "131_01.bvh"])
def test_flip_is_flagged_by_a_or_b_on_its_joint(name, seed):
    m = clip(name)
    limits = B.learn_joint_limits([m])
    bad, truth, records = corrupt.real_errors(m, kinds=("flip",), n_errors=1, seed=seed)
    (rec,) = records
    j = m.skeleton.index(rec.joint)
    a, b = B.detect_limits(bad, limits), B.detect_rate(bad, limits)
    assert ((a | b)[:, j] & truth[:, j]).any()
    # a flip is a 180 deg turn: the box on its joint cannot hold it for a whole window
    assert a[rec.start : rec.end, j].any()


def test_combined_is_the_union_and_scores_like_table_1():
    """(c) == (a) | (b); on many injected errors (c) has perfect precision on this clip."""
    m = clip("HDM_bk_sneak2StepsLStart_004_120.amc")
    limits = sneak_limits()
    bad, truth, records = corrupt.real_errors(m, kinds=("spike", "flip", "drift", "freeze"), n_errors=8, seed=5)
    a, b, c = (B.detect_baseline(bad, limits, k) for k in "abc")
    assert np.array_equal(c, a | b)
    assert c.any()
    score = metrics.precision_recall(c, truth)
    # every flagged cell lies on a corrupted joint within one frame of its window (b flags step edges)
    near = truth | np.roll(truth, 1, axis=0) | np.roll(truth, -1, axis=0)
    assert not (c & ~near).any()
    assert score.recall > 0.0


def test_missing_cells_are_never_flagged_and_do_not_warn():
    m = clip("12_walk.amc")
    holey, gap_mask = corrupt.gaps(m, start_prob=0.02, seed=1)
    assert gap_mask.any()
    bad, truth, _ = corrupt.real_errors(holey, kinds=("spike", "flip"), n_errors=4, seed=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for kind in B.BASELINE_KINDS:
            found = B.detect_baseline(bad, walk_limits(), kind)
            assert not (found & bad.missing()).any()
        limits = B.learn_joint_limits([holey])  # learning over gaps too
    assert np.all(np.isfinite(limits.low[1:])) and np.all(np.isfinite(limits.max_speed))


def test_root_facing_is_ignored_but_its_tilt_is_limited():
    """Turning the whole clip about the vertical changes nothing; tipping the root over is flagged."""
    m = clip("12_walk.amc")
    limits = walk_limits()
    np.testing.assert_array_equal(limits.up, [0.0, 1.0, 0.0])
    yaw = R.quaternion_from_axis_angle([0.0, 1.0, 0.0], np.radians(135.0))
    rot = np.array(m.rotations)
    rot[:, 0] = R.quaternion_multiply(yaw, rot[:, 0])
    turned = dataclasses.replace(m, rotations=rot, root_positions=R.quaternion_rotate(yaw, m.root_positions))
    np.testing.assert_allclose(B.rotation_components(turned, limits), B.rotation_components(m, limits), atol=1e-7)
    assert not B.detect_baseline(turned, limits, "c").any()
    tip = R.quaternion_from_axis_angle([1.0, 0.0, 0.0], np.radians(90.0))
    rot[:, 0] = R.quaternion_multiply(tip, m.rotations[:, 0])
    tipped = dataclasses.replace(m, rotations=rot)
    assert B.detect_limits(tipped, limits)[:, 0].all()
    free = B.learn_joint_limits([m], include_root=False)
    assert np.all(np.isnan(free.low[0])) and np.isnan(free.max_speed[0])
    assert not B.detect_baseline(tipped, free, "c")[:, 0].any()


# -- maths -------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(unit_quaternions(1), st.floats(-np.pi, np.pi))
def test_remove_facing_leaves_no_twist_about_up(q, yaw):
    up = np.array([0.0, 1.0, 0.0])
    assume(np.hypot(q[0, 0], q[0, 2]) > 1e-3)  # a pure 180 deg swing has no defined facing
    tilt = B._remove_facing(q, up)
    # no component about the vertical: the vertical axis' rotation is the minimal swing
    assert abs(tilt[0, 2]) < 1e-9
    # and the facing is removed exactly: a pre-turn about the vertical changes nothing
    turned = R.quaternion_multiply(R.quaternion_from_axis_angle(up, yaw), q)
    assert R.geodesic_angle(B._remove_facing(turned, up), tilt)[0] < 1e-6


@settings(max_examples=40, deadline=None)
@given(unit_quaternions(6), st.lists(st.booleans(), min_size=6, max_size=6))
def test_mean_rotation_ignores_quaternion_signs(q, signs):
    flipped = np.where(np.array(signs)[:, None], -q, q)
    a = B._mean_rotation(q[:, None])
    b = B._mean_rotation(flipped[:, None])
    assert R.geodesic_angle(a, b)[0] < 1e-6
    assert abs(np.linalg.norm(a) - 1.0) < 1e-12 and a[0, 0] >= 0.0


def test_mean_rotation_of_a_symmetric_spread_is_its_centre():
    centre = R.quaternion_from_axis_angle([0.3, 1.0, -0.2], 1.1)
    offsets = R.quaternion_from_axis_angle(np.eye(3).repeat(2, axis=0), np.tile([0.4, -0.4], 3))
    q = R.quaternion_multiply(centre, offsets)
    assert R.geodesic_angle(B._mean_rotation(q[:, None])[0], centre) < 1e-9


# -- files and errors ----------------------------------------------------------------


def test_save_load_round_trip(tmp_path):
    limits = sneak_limits()
    path = tmp_path / "limits.npz"
    limits.save(path)
    back = B.JointLimits.load(path)
    assert back.joint_names == limits.joint_names
    for f in ("mean", "low", "high", "max_speed", "up"):
        np.testing.assert_array_equal(getattr(back, f), getattr(limits, f))
    for f in ("quantile", "margin_deg", "rate_quantile", "rate_margin", "min_speed", "num_frames"):
        assert getattr(back, f) == getattr(limits, f)
    m = clip("HDM_bk_sneak2StepsLStart_005_120.amc")
    np.testing.assert_array_equal(B.detect_baseline(m, back), B.detect_baseline(m, limits))
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="not a JointLimits file"):
        B.JointLimits.load(tmp_path / "other.npz")


def test_bad_input_raises_clear_errors():
    walk, bvh = clip("12_walk.amc"), clip("131_01.bvh")
    with pytest.raises(ValueError, match="share joint names"):
        B.learn_joint_limits([walk, bvh])
    with pytest.raises(ValueError, match="at least one"):
        B.learn_joint_limits([])
    with pytest.raises(ValueError, match="quantiles"):
        B.learn_joint_limits([walk], quantile=0.3)
    with pytest.raises(ValueError, match="differ from the limits"):
        B.detect_limits(bvh, walk_limits())
    with pytest.raises(ValueError, match="differ from the limits"):
        B.detect_rate(bvh, walk_limits())
    with pytest.raises(ValueError, match="baseline kind"):
        B.detect_baseline(walk, walk_limits(), "d")
    with pytest.raises(ValueError, match="expected shape"):
        dataclasses.replace(walk_limits(), low=np.zeros((3, 3)))
    limits = walk_limits()
    with pytest.raises(ValueError):
        limits.low[0, 0] = 1.0  # read-only
