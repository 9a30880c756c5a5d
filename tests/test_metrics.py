import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import metrics as M
from mocapkit import rotations as R


@pytest.fixture(scope="module")
def clip():
    return mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:240]


def with_joint_rotated(m, joint, degrees, frames=slice(None), axis=(1.0, 0.0, 0.0)):
    rot = np.array(m.rotations)
    j = m.skeleton.index(joint)
    rot[frames, j] = R.quaternion_multiply(rot[frames, j], R.quaternion_from_axis_angle(axis, np.radians(degrees)))
    return dataclasses.replace(m, rotations=rot)


def test_zero_on_identical(clip):
    assert np.all(M.pose_error(clip, clip) < 1e-20)
    assert M.joint_angle_rms(clip, clip) == 0.0
    assert M.joint_position_rms(clip, clip) == 0.0
    assert M.d_pv(clip, clip) == 0.0


def test_eq2_uses_half_angle_logs(clip):
    bad = with_joint_rotated(clip, "LeftKnee", 90.0)
    e = M.pose_error(clip, bad)
    np.testing.assert_allclose(e, (np.pi / 4) ** 2, rtol=1e-9)
    per_joint = M.pose_error_per_joint(clip, bad)
    assert per_joint[clip.skeleton.index("LeftKnee")] == pytest.approx((np.pi / 4) ** 2)
    assert np.sum(per_joint > 1e-20) == 1
    # symmetric
    np.testing.assert_allclose(M.pose_error(bad, clip), e)
    assert M.joint_position_rms(bad, clip) == pytest.approx(M.joint_position_rms(clip, bad))


def test_joint_angle_rms_in_degrees_and_wrap_free():
    sk = mocapkit.Skeleton(("root", "a"), [-1, 0], [[0, 0, 0], [0, 1, 0]])
    vals = np.zeros((4, 9))
    vals[:, 6] = [179.0, 179.0, -179.0, 10.0]  # Zrotation of joint a
    other = vals.copy()
    other[:, 6] = [-179.0, 179.0, 179.0, 12.0]
    a = mocapkit.Motion.from_channel_values(sk, vals, 30)
    b = mocapkit.Motion.from_channel_values(sk, other, 30)
    # differences 2, 0, 2, 2 degrees over the 6 rotation channels of 4 frames
    assert M.joint_angle_rms(a, b) == pytest.approx(np.sqrt((3 * 4.0) / 24), rel=1e-6)


def test_joint_position_rms_in_cm(clip):
    moved = dataclasses.replace(clip, root_positions=clip.root_positions + [1.0, 0, 0])
    assert M.joint_position_rms(clip, moved) == pytest.approx(0.0, abs=1e-9)
    assert M.joint_position_rms(clip, moved, root_relative=False) == pytest.approx(2.54 / 0.45)
    assert M.joint_position_rms(clip, moved, root_relative=False, scale_cm=1.0) == pytest.approx(1.0)


def test_d_pv_sees_a_flip_and_ignores_translation(clip):
    flipped = with_joint_rotated(clip, "LeftElbow", 180.0, frames=slice(100, 110), axis=(1.0, -1.0, 0.0))
    assert M.d_pv(clip, flipped) > 0.0
    moved = dataclasses.replace(flipped, root_positions=flipped.root_positions + [3.0, 0.0, -2.0])
    assert M.d_pv(clip, moved) == pytest.approx(M.d_pv(clip, flipped), rel=1e-9)


def test_nan_cells_are_ignored(clip):
    rot = np.array(clip.rotations)
    rot[5, 3] = np.nan
    gappy = dataclasses.replace(clip, rotations=rot)
    assert np.isfinite(M.pose_error(clip, gappy)).all()
    assert M.pose_error(clip, gappy)[5] == pytest.approx(0.0, abs=1e-20)
    assert np.isfinite(M.joint_angle_rms(clip, gappy))


def test_precision_recall_on_hand_made_masks():
    truth = np.zeros((30, 4), dtype=bool)
    truth[10:12, 1] = True
    det = np.zeros_like(truth)
    det[10:13, 1] = True
    det[20, 2] = True
    s = M.precision_recall(det, truth)
    assert (s.tp, s.fp, s.fn) == (2, 2, 0)
    assert s.precision == 0.5 and s.recall == 1.0 and s.f1 == pytest.approx(2 / 3)
    w = M.word_precision_recall(det, truth, word_length=15, stride=5)
    # words start at 0, 5, 10, 15: joint 1 is positive in words 0..2 in both; joint 2 only in detection
    assert (w.tp, w.fn) == (3, 0) and w.fp == 2
    with pytest.raises(ValueError, match="differ in shape"):
        M.precision_recall(det, truth[:5])
