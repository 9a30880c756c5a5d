"""mocapkit.cleaning.whole_take: detect and repair a take with its calibration pose left out, as clean does.

The take: CMU 12_walk (bundled) opening with its rest pose, a T-pose, as the CMU BVH converter's frame 0 does,
with errors injected (a spike, a flip, a swap of the feet)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocapkit.cleaning import ssa
from mocapkit.cleaning.pipeline import clean
from mocapkit.cleaning.whole_take import changed_cells, detect_take, repair_take


@pytest.fixture(scope="module")
def t_pose_walk():
    from tests.shared import t_pose_walk as make

    return make()


@pytest.fixture(scope="module")
def found(t_pose_walk):
    return detect_take(t_pose_walk)


def test_detect_take_leaves_the_t_pose_out_and_flags_what_clean_flags(t_pose_walk, found):
    m = t_pose_walk
    det = found.detection
    assert [str(c) for c in found.calibration] == ["frame 0: calibration T-pose, left alone"]
    assert found.span == det.span == (1, m.num_frames) and not found.skipped
    assert det.flags.shape == (m.num_frames, m.num_joints) and det.flags.any() and not det.flags[0].any()
    res = clean(m, steps="detect")
    assert np.array_equal(det.flags, res.flags) and np.array_equal(det.causes(), res.causes)
    # the part analysed is what ssa.detect makes of the frames after the pose
    alone = ssa.detect(m[1:], params=det.params)
    part = det.analysed_part()
    assert part.span is None and np.array_equal(part.flags, alone.flags) and np.array_equal(part.mdm, alone.mdm)
    assert part.notes == alone.notes and det.notes[-1].startswith("analysed frames 1-")
    # whole, the pose was flagged on the arms and legs
    assert ssa.detect(m, params=det.params).flags[0].any()


def test_a_padded_detection_keeps_its_span_through_a_file_and_another_threshold(t_pose_walk, found, tmp_path):
    det = found.detection
    back = ssa.Detection.load(det.save(tmp_path / "det.npz"))
    assert back.span == det.span and np.array_equal(back.flags, det.flags)
    lower = back.with_threshold(0.3)
    again = det.analysed_part().with_threshold(0.3)
    assert lower.span == det.span and not lower.flags[0].any()
    assert np.array_equal(lower.flags[1:], again.flags) and lower.flags.sum() >= det.flags.sum()
    with pytest.raises(ValueError, match="padded already"):
        det.padded(1, t_pose_walk.num_frames)


def test_repair_of_a_padded_detection_changes_the_flagged_cells_of_its_span_only(t_pose_walk, found, tmp_path):
    m, det = t_pose_walk, found.detection
    fixed = ssa.repair(m, det, foot_skate=False)
    changed = changed_cells(m, fixed)
    assert changed.any() and not (changed & ~det.flags).any() and not changed[0].any()
    part = ssa.repair(m[1:], det.analysed_part(), foot_skate=False)
    assert np.array_equal(fixed.rotations[1:], part.rotations) and np.array_equal(fixed.rotations[0], m.rotations[0])
    # read back from a file (no prepared take kept): the same repair
    loaded = ssa.Detection.load(det.save(tmp_path / "det.npz"))
    assert np.array_equal(ssa.repair(m, loaded, foot_skate=False).rotations, fixed.rotations)
    # foot-skate cleanup stays inside the span too
    skated = changed_cells(m, ssa.repair(m, det, foot_skate=True))
    assert not skated[0].any()
    assert np.array_equal(repair_take(m, det).rotations, clean(m, steps="detect,repair").motion.rotations)


def test_repair_take_drops_flags_on_the_pose_of_a_whole_take_detection(t_pose_walk):
    """A detection of every frame (ssa.detect, or a file written before poses were left out) flags the T-pose;
    repair_take leaves the pose as it is all the same."""
    m = t_pose_walk
    whole = ssa.detect(m, max_word_angle_deg=8.0)
    assert whole.flags[0].any()
    fixed = repair_take(m, whole)
    changed = changed_cells(m, fixed)
    assert not changed[0].any() and changed[1:].any() and not (changed & ~whole.flags).any()


def test_detect_take_says_why_nothing_was_analysed(t_pose_walk):
    short = detect_take(t_pose_walk[:10])
    assert short.detection is None and short.span == (1, 10)
    assert short.skipped.startswith("9 frames (0.07 s) is shorter than one motion word (15 frames at 24 fps")
    pose = detect_take(t_pose_walk[:1])
    assert pose.detection is None and pose.skipped == "the whole take is a calibration pose"


def test_detect_take_does_not_judge_a_take_too_coarse_for_a_word(t_pose_walk):
    """A take at 1 fps (a BVH whose Frame Time is 1 s) was resampled to 24 times its frames and searched word by
    word; the summary now says it was not judged, and why."""
    import dataclasses

    coarse = detect_take(dataclasses.replace(t_pose_walk[:60], fps=1.0))
    assert coarse.detection is None and coarse.span == (1, 60)
    assert coarse.skipped.startswith("1 fps is too coarse for motion words: a source word spans 0.625 s")
    assert coarse.skipped.endswith("(at least half of each word's frames the take's own): not judged")


def test_a_take_shorter_than_a_word_without_its_interpolated_frames_is_skipped(tmp_path):
    """71 frames at 120 fps make one word; one of them a slerp midpoint another tool inserted, the 70 analysed make
    none: the take is skipped with the statement, as a take shorter than a word is, not failed."""
    import mocapkit
    from mocapkit import samples
    from tests.cleaning.ssa.helpers import with_midpoints

    m = mocapkit.load(with_midpoints(Path(samples.path("131_01.bvh")), [350], tmp_path / "retimed.bvh", 4))
    short = m[316:387]
    got = detect_take(short)
    assert got.detection is None
    assert got.skipped.startswith("71 frames (0.59 s), 70 without its repeated and interpolated frames, is shorter "
                                  "than one motion word")
