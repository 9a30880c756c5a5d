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


# -- constructed cases on tiny skeletons ---------------------------------------------------

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra.numpy import arrays  # noqa: E402


def fork(frames=4, fps=10.0, child_rotations=None):
    """Root with two children 10 cm along x and y, each ending in an end site; unit 1 cm."""
    sk = mocapkit.Skeleton(
        ("root", "a", "b"), [-1, 0, 0], [[0, 0, 0], [10, 0, 0], [0, 10, 0]],
        end_site_parents=[1, 2], end_site_offsets=[[0, 0, 0], [0, 0, 0]], unit_cm=1.0,
    )
    rot = R.identity((frames, 3))
    if child_rotations is not None:
        rot[:, 0] = child_rotations
    return mocapkit.Motion(sk, rot, np.zeros((frames, 3)), fps)


def test_geodesic_and_eq2_conventions_on_a_constructed_case():
    a = fork()
    q = R.quaternion_from_axis_angle([0, 0, 1], np.pi / 2)
    b = fork(child_rotations=q)
    g = M.geodesic_pose_distance(a, b)
    np.testing.assert_allclose(g[:, 0], np.pi / 2, rtol=1e-12)
    np.testing.assert_allclose(g[:, 1:], 0.0, atol=1e-15)
    # eq. 2 with the half-angle log: ||log(q_a^-1 q_b)||^2 = (theta / 2)^2
    direct = np.sum(np.sum(R.quaternion_log(R.quaternion_multiply(R.quaternion_conjugate(a.rotations), b.rotations)) ** 2, -1), -1)
    np.testing.assert_allclose(M.pose_error(a, b), direct, rtol=1e-12)
    np.testing.assert_allclose(M.pose_error(a, b), (np.pi / 4) ** 2, rtol=1e-12)
    # q and -q are the same rotation
    neg = dataclasses.replace(b, rotations=-np.asarray(b.rotations))
    np.testing.assert_allclose(M.pose_error(a, neg), M.pose_error(a, b), rtol=1e-12)


def test_d_pv_by_hand_on_a_static_fork():
    a = fork()
    # turn the root 90 deg about x: bone b (along y) goes to z, bone a stays on x
    q = R.quaternion_from_axis_angle([1, 0, 0], np.pi / 2)
    b = fork(child_rotations=q)
    # at the root: c1 = (10,0,0) x (0,10,0) = (0,0,100), c2 = (10,0,0) x (0,0,10) = (0,-100,0)
    # static motions: no derivative term; two ordered pairs per frame, 4 frames
    per_pair = np.linalg.norm([0, 100, 100])
    assert M.d_pv(a, b) == pytest.approx(np.sqrt(4 * 2 * per_pair**2), rel=1e-12)
    np.testing.assert_allclose(M.d_pv_per_frame(a, b), 2 * per_pair**2, rtol=1e-12)
    assert M.d_pv(a, b, scale_cm=2.0) == pytest.approx(4 * M.d_pv(a, b), rel=1e-12)  # cm^2
    assert M.d_pv(a, a) == 0.0


def test_d_pv_sees_motion_not_only_poses():
    # same poses, played in a different order: the derivative term sees it
    angles = np.radians([0, 10, 20, 30, 40])
    q = R.quaternion_from_axis_angle([0, 0, 1], angles[:, None] * np.ones((1, 1)))[:, 0]
    fwd = fork(frames=5, child_rotations=q)
    static = fork(frames=5, child_rotations=q[[2, 2, 2, 2, 2]])
    assert M.d_pv(fwd, static) > 0.0


def test_d_pv_sees_a_turned_motion_and_position_rms_can_ignore_it(clip):
    turn = R.quaternion_from_axis_angle([0, 1, 0], np.pi / 2)
    rot = np.array(clip.rotations)
    rot[:, 0] = R.quaternion_multiply(turn, rot[:, 0])
    turned = dataclasses.replace(clip, rotations=rot)
    # a global turn of one motion against the other is an error for D_pv (global quantities)...
    assert M.d_pv(clip, turned) > 0.0
    assert M.joint_position_rms(clip, turned) > 1.0
    # ...but not in the root frame, nor for the local joints
    assert M.joint_position_rms(clip, turned, root_relative="frame") == pytest.approx(0.0, abs=1e-9)
    assert M.joint_position_rms(clip, turned, root_relative="heading") == pytest.approx(0.0, abs=1e-9)
    assert np.all(M.geodesic_pose_distance(clip, turned)[:, 1:] < 1e-9)


def test_heading_frame_rms_keeps_the_pelvis_tilt(clip):
    # a forward tilt of the pelvis (about the left-right axis) is free in the root frame but an error once
    # only the heading is removed
    tilt = R.quaternion_from_axis_angle([1, 0, 0], np.radians(20))
    rot = np.array(clip.rotations)
    rot[:, 0] = R.quaternion_multiply(rot[:, 0], tilt)
    tilted = dataclasses.replace(clip, rotations=rot)
    assert M.joint_position_rms(clip, tilted, root_relative="frame") == pytest.approx(0.0, abs=1e-9)
    assert M.joint_position_rms(clip, tilted, root_relative="heading") > 5.0
    with pytest.raises(ValueError, match="heading"):
        M.joint_position_rms(clip, tilted, root_relative="yaw")


quats = arrays(np.float64, (6, 3, 4), elements=st.floats(-1, 1, allow_nan=False)).filter(
    lambda q: np.all(np.linalg.norm(q, axis=-1) > 0.1)
)


@settings(max_examples=40, deadline=None)
@given(qa=quats, qb=quats)
def test_metrics_are_symmetric_and_zero_on_identical(qa, qb):
    a = fork(frames=6, fps=30.0)
    a = dataclasses.replace(a, rotations=R.quaternion_normalize(qa))
    b = dataclasses.replace(a, rotations=R.quaternion_normalize(qb))
    np.testing.assert_allclose(M.geodesic_pose_distance(a, b), M.geodesic_pose_distance(b, a), atol=1e-12)
    np.testing.assert_allclose(M.pose_error(a, b), M.pose_error(b, a), atol=1e-12)
    assert M.joint_position_rms(a, b) == pytest.approx(M.joint_position_rms(b, a), abs=1e-9)
    assert M.d_pv(a, b) == pytest.approx(M.d_pv(b, a), rel=1e-9, abs=1e-9)
    assert M.joint_angle_rms(a, b) == pytest.approx(M.joint_angle_rms(b, a), abs=1e-9)
    g = M.geodesic_pose_distance(a, b)
    assert np.all((g >= 0) & (g <= np.pi + 1e-12))
    assert np.all(M.pose_error(a, a) < 1e-24) and M.d_pv(a, a) == 0.0 and M.joint_position_rms(a, a) == 0.0


def test_per_frame_and_root_options_of_joint_angle_rms(clip):
    bad = with_joint_rotated(clip, "Hips", 10.0, frames=slice(0, 10), axis=(0.0, 0.0, 1.0))
    per_frame = M.joint_angle_rms(clip, bad, per_frame=True)
    assert per_frame.shape == (clip.num_frames,) and np.all(per_frame[10:] < 1e-9) and np.all(per_frame[:10] > 0)
    assert M.joint_angle_rms(clip, bad, include_root=False) == pytest.approx(0.0, abs=1e-9)


def test_all_missing_gives_nan_without_warnings(clip):
    import warnings

    gone = dataclasses.replace(clip, rotations=np.full(clip.rotations.shape, np.nan))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isnan(M.pose_error(clip, gone)).all()
        assert np.isnan(M.pose_error_per_joint(clip, gone)).all()
        assert np.isnan(M.joint_angle_rms(clip, gone))
        assert np.isnan(M.joint_position_rms(clip, gone))
        assert np.isnan(M.d_pv(clip, gone))


def test_words_cover_the_clip_end_and_can_count_whole_words():
    truth = np.zeros((32, 3), dtype=bool)
    truth[31, 2] = True  # only in the last frame: words 0, 5, 10, 15 end at 29, a flush word 17..31 catches it
    w = M.word_precision_recall(np.zeros_like(truth), truth, word_length=15, stride=5)
    assert (w.tp, w.fp, w.fn) == (0, 0, 1) and w.recall == 0.0 and w.precision == 1.0 and w.f1 == 0.0
    det = np.zeros_like(truth)
    det[31, 1] = True  # right word, wrong joint
    assert M.word_precision_recall(det, truth).as_dict() == {
        "precision": 0.0, "recall": 0.0, "f1": 0.0, "tp": 0, "fp": 1, "fn": 1
    }
    whole = M.word_precision_recall(det, truth, per_joint=False)
    assert (whole.tp, whole.fp, whole.fn) == (1, 0, 0)
    empty = M.precision_recall(np.zeros((5, 2), bool), np.zeros((5, 2), bool))
    assert (empty.precision, empty.recall) == (1.0, 1.0)
    with pytest.raises(ValueError, match="at least 1"):
        M.word_precision_recall(det, truth, stride=0)


def test_ignored_cells_take_their_pairs_out_of_the_counts():
    """Words are 0-14, 5-19, 10-24, 15-29, 17-31; a false flag at frame 2 of joint 0 falls in word 0 only, the error at frame 20 in words 10, 15 and 17."""
    truth = np.zeros((32, 2), dtype=bool)
    truth[20, 1] = True
    det = np.zeros_like(truth)
    det[2, 0] = det[20, 1] = True
    assert (lambda s: (s.tp, s.fp, s.fn))(M.word_precision_recall(det, truth)) == (3, 1, 0)
    ignore = np.zeros_like(truth)
    ignore[3, 0] = True  # unknown truth in word 0 on joint 0: that pair is not scored either way
    s = M.word_precision_recall(det, truth, ignore=ignore)
    assert (s.tp, s.fp, s.fn) == (3, 0, 0)
    assert M.word_precision_recall(det, truth, ignore=np.zeros_like(truth)) == M.word_precision_recall(det, truth)
    whole = M.word_precision_recall(det, truth, per_joint=False, ignore=ignore)
    assert (whole.tp, whole.fp, whole.fn) == (3, 0, 0)  # word 0 is left out as a whole
    ignore[19, 1] = True  # next to the error: its words that hold the error still count, word 5-19 drops out
    assert M.word_precision_recall(det, truth, ignore=ignore) == s
    miss = M.word_precision_recall(np.zeros_like(det), truth, ignore=ignore)
    assert (miss.tp, miss.fp, miss.fn) == (0, 0, 3)
    with pytest.raises(ValueError, match="shape"):
        M.word_precision_recall(det, truth, ignore=ignore[:, :1])


def test_root_relative_errors_are_about_the_pelvis_by_role():
    """On the Bandai Namco rig the root stays on the floor and Hips moves: moving the root (and Hips back) changes nothing."""
    from pathlib import Path

    m = mocapkit.load(Path(__file__).resolve().parent / "data" / "bandai_dance-short_normal_001_first60.bvh")
    shift = np.array([150.0, 0.0, -80.0])
    tr = np.array(m.translations)
    tr[:, 1] -= shift  # joint_Root has identity rotation: Hips stays where it was
    assert np.allclose(m.rotations[:, 0], [1, 0, 0, 0])
    moved = dataclasses.replace(m, root_positions=m.root_positions + shift, translations=tr)
    np.testing.assert_allclose(moved.global_positions()[:, 1:], m.global_positions()[:, 1:], atol=1e-9)
    for rel in (True, "frame", "heading"):
        assert M.joint_position_rms(moved, m, root_relative=rel) < 1e-9
    assert M.joint_position_rms(moved, m, root_relative=False) > 10.0
    # a wrong arm counts
    rot = np.array(m.rotations)
    rot[:, m.skeleton.index("UpperArm_L")] = R.quaternion_from_axis_angle(np.array([0.0, 0.0, 1.0]), 0.5)
    assert M.joint_position_rms(dataclasses.replace(m, rotations=rot), m, root_relative="heading") > 1.0


def test_joint_angles_of_an_amc_take_and_its_bvh_conversion_agree(tmp_path):
    """The same motion as ASF/AMC and as BVH: channels of other orders and axes (it raised IndexError)."""
    amc = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    mocapkit.save(amc, tmp_path / "same.bvh")
    bvh = mocapkit.load(tmp_path / "same.bvh")
    assert bvh.skeleton.channels != amc.skeleton.channels
    assert M.joint_angle_rms(amc, bvh) < 1e-4


def test_joint_angle_rms_reads_the_other_euler_branch_as_no_error():
    # ZXY joint at X = 89.5 turned 1 deg about X: its plain conversion is on the other branch (Z, Y + 180, X 89.5)
    sk = mocapkit.Skeleton(("root", "a"), [-1, 0], [[0, 0, 0], [0, 1, 0]])
    vals = np.zeros((3, 9))
    vals[:, 6:9] = [30.0, 89.5, -20.0]
    other = vals.copy()
    other[:, 7] = 90.5
    a = mocapkit.Motion.from_channel_values(sk, vals, 30)
    b = mocapkit.Motion.from_channel_values(sk, other, 30)
    assert abs(b.channel_values()[0, 6] - 30.0) > 170.0
    # one degree on one of the 6 rotation channels, every frame
    assert M.joint_angle_rms(a, b) == pytest.approx(np.sqrt(1.0 / 6), rel=1e-6)
    assert M.joint_angle_rms(b, a) == pytest.approx(np.sqrt(1.0 / 6), rel=1e-6)
    np.testing.assert_array_equal(M.same_branch_channels(a.channel_values(), b.channel_values(), sk)[:, :6],
                                  a.channel_values()[:, :6])


def test_joint_position_mean_is_the_mean_euclidean_distance_not_the_rms(clip):
    """Krüger et al. 2010, Table 3: cm per joint, the mean distance; the RMS squares first."""
    F = clip.num_frames
    shift = np.zeros((F, 3))
    shift[: F // 4, 0] = 4.0  # a quarter of the frames 4 units off, the rest exact
    moved = dataclasses.replace(clip, root_positions=clip.root_positions + shift)
    assert M.joint_position_mean(clip, moved, scale_cm=1.0) == pytest.approx(1.0)  # every joint 4 in 1/4 frames
    assert M.joint_position_rms(clip, moved, root_relative=False, scale_cm=1.0) == pytest.approx(2.0)
    assert M.joint_position_mean(clip, moved, root_relative=True) == pytest.approx(0.0, abs=1e-9)
    assert M.joint_position_mean(clip, clip) == 0.0
