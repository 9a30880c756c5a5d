"""Whole-clip quaternion smoothing (Gaussian, Savitzky-Golay): the smoothing baselines of Aristidou Table 2."""

import dataclasses
import functools
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mocapkit
from mocapkit import corrupt, metrics, samples
from mocapkit import rotations as R
from mocapkit.cleaning.filters import gaussian_smooth, savgol_smooth, window_frames

FILTERS = [gaussian_smooth, savgol_smooth]
CLIPS = ["12_walk.amc", "131_01.bvh", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"]


@functools.lru_cache(maxsize=None)
def clip(name: str):
    return mocapkit.load(samples.path(name))


def unit_norms(m):
    n = np.linalg.norm(m.rotations, axis=-1)
    return n[np.isfinite(n)]


@pytest.mark.parametrize("smooth", FILTERS)
@pytest.mark.parametrize("name", CLIPS)
def test_clean_clip_changes_little(smooth, name):
    m = clip(name)
    s = smooth(m)
    change = np.degrees(metrics.geodesic_pose_distance(m, s))
    assert change.mean() < 1.0  # degrees, over all joints and frames
    assert np.median(change) < 0.5
    np.testing.assert_allclose(unit_norms(s), 1.0, atol=1e-12)
    # the root trajectory moves by well under a centimetre on average
    cm = mocapkit.motion.unit_scale_cm(m.skeleton)
    assert np.linalg.norm(s.root_positions - m.root_positions, axis=1).mean() * cm < 0.5
    # quaternions keep the input's signs: no new sign jumps
    assert np.all(np.sum(s.rotations * m.rotations, axis=-1) > 0.0)


@pytest.mark.parametrize("smooth", FILTERS)
@pytest.mark.parametrize("name", CLIPS)
def test_smoothing_reduces_angular_noise(smooth, name):
    """Mall's "0.5 noise" (6 dB): both filters cut the eq. 2 pose error against the clean clip by over 70%."""
    m = clip(name)
    noisy, _ = corrupt.angular_noise(m, amount=0.5, seed=3)
    before = metrics.pose_error(m, noisy).mean()
    after = metrics.pose_error(m, smooth(noisy)).mean()
    assert after < 0.3 * before


@pytest.mark.parametrize("name", CLIPS)
def test_gaussian_helps_even_on_weak_noise(name):
    """At 0.1 noise (20 dB) the default Gaussian still lowers the error; smoothing's own change is that small."""
    m = clip(name)
    noisy, _ = corrupt.angular_noise(m, amount=0.1, seed=3)
    assert metrics.pose_error(m, gaussian_smooth(noisy)).mean() < 0.9 * metrics.pose_error(m, noisy).mean()


@pytest.mark.parametrize("smooth", FILTERS)
def test_unselected_joints_are_bit_identical(smooth):
    m = clip("131_01.bvh")
    noisy, _ = corrupt.angular_noise(m, amount=0.5, seed=1)
    picked = ["LeftKnee", "RightElbow", 0]
    s = smooth(noisy, joints=picked, root=False)
    sel = np.zeros(m.num_joints, dtype=bool)
    sel[[m.skeleton.index("LeftKnee"), m.skeleton.index("RightElbow"), 0]] = True
    assert np.array_equal(s.rotations[:, ~sel], noisy.rotations[:, ~sel])
    assert np.array_equal(s.root_positions, noisy.root_positions)
    assert not np.array_equal(s.rotations[:, sel], noisy.rotations[:, sel])
    # the input is never modified, and one joint by name works
    one = smooth(noisy, joints="LeftKnee")
    assert np.array_equal(np.delete(one.rotations, m.skeleton.index("LeftKnee"), axis=1),
                          np.delete(noisy.rotations, m.skeleton.index("LeftKnee"), axis=1))
    assert not np.array_equal(one.root_positions, noisy.root_positions)  # root=True by default


@pytest.mark.parametrize("smooth", FILTERS)
def test_constant_motion_is_a_fixed_point(smooth):
    m = clip("12_walk.amc")
    pose = np.broadcast_to(m.rotations[50], m.rotations.shape)
    pose = pose * np.where(np.arange(m.num_frames) % 7 == 0, -1.0, 1.0)[:, None, None]  # signs do not matter
    root = np.broadcast_to(m.root_positions[50], (m.num_frames, 3))
    still = dataclasses.replace(m, rotations=pose, root_positions=root)
    s = smooth(still)
    np.testing.assert_allclose(s.rotations, still.rotations, atol=1e-12)
    np.testing.assert_allclose(s.root_positions, still.root_positions, atol=1e-9)


@pytest.mark.parametrize("smooth", FILTERS)
def test_missing_frames_stay_missing_and_nothing_leaks_across_gaps(smooth):
    m = clip("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc")
    holey, gap = corrupt.gaps(m, start_prob=0.03, seed=4)
    assert gap.any()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = smooth(holey)
    assert np.array_equal(s.missing(), holey.missing())
    np.testing.assert_allclose(unit_norms(s), 1.0, atol=1e-12)
    # a run of observed frames is smoothed on its own: what lies across a gap cannot change it
    j = int(np.flatnonzero(gap.any(axis=0))[0])
    f = int(np.flatnonzero(gap[:, j])[0])
    other = np.array(holey.rotations)
    other[:f, j] = R.quaternion_multiply(R.quaternion_from_axis_angle([1.0, 0.0, 0.0], 1.0), other[:f, j])
    s2 = smooth(dataclasses.replace(holey, rotations=other), joints=[j])
    after = slice(f, None)
    np.testing.assert_array_equal(s2.rotations[after, j], s.rotations[after, j])


def test_filters_are_frame_rate_independent():
    """A filter of so many seconds does about the same to a clip at 120 and at 30 fps."""
    m = clip("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc")
    slow = m.resample(30.0)
    for smooth, kw in ((gaussian_smooth, dict(sigma_s=0.05)), (savgol_smooth, dict(window_s=0.3))):
        fast_s = smooth(m, **kw)[::4]
        slow_s = smooth(slow, **kw)
        d = np.degrees(R.geodesic_angle(fast_s.rotations, slow_s.rotations))
        change = np.degrees(metrics.geodesic_pose_distance(slow, slow_s))
        assert np.median(d) < 0.5 * np.median(change) + 0.05


def test_stronger_smoothing_changes_more():
    m = clip("12_walk.amc")
    weak = np.degrees(metrics.geodesic_pose_distance(m, gaussian_smooth(m, sigma_s=0.01))).mean()
    strong = np.degrees(metrics.geodesic_pose_distance(m, gaussian_smooth(m, sigma_s=0.1))).mean()
    assert weak < strong
    a = np.degrees(metrics.geodesic_pose_distance(m, savgol_smooth(m, window_s=0.1))).mean()
    b = np.degrees(metrics.geodesic_pose_distance(m, savgol_smooth(m, window_s=0.5))).mean()
    assert a < b


@settings(max_examples=50, deadline=None)
@given(st.floats(0.001, 2.0), st.floats(10.0, 240.0), st.integers(0, 5))
def test_window_frames_is_odd_and_long_enough(window_s, fps, polyorder):
    n = window_frames(window_s, fps, polyorder)
    assert n % 2 == 1 and n >= polyorder + 2
    assert abs(n - window_s * fps) <= 1.5 or n <= polyorder + 3


def test_short_runs_and_short_clips():
    m = clip("12_walk.amc")[:3]
    s = savgol_smooth(m, window_s=1.0)  # window longer than the clip: largest odd window that fits
    np.testing.assert_allclose(unit_norms(s), 1.0, atol=1e-12)
    one = clip("12_walk.amc")[:1]
    for smooth in FILTERS:
        assert np.array_equal(smooth(one).rotations, one.rotations)


def test_bad_arguments_raise():
    m = clip("12_walk.amc")
    with pytest.raises(ValueError, match="sigma_s"):
        gaussian_smooth(m, sigma_s=0.0)
    with pytest.raises(ValueError, match="window_s"):
        savgol_smooth(m, window_s=-1.0)
    with pytest.raises(ValueError, match="polyorder"):
        savgol_smooth(m, polyorder=-1)
    with pytest.raises(ValueError, match="out of range"):
        gaussian_smooth(m, joints=[99])
    with pytest.raises(KeyError):
        gaussian_smooth(m, joints=["nosuchjoint"])
