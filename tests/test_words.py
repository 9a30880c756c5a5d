"""Counts and lists in a person's words (mocapkit.words): "1 of 1 file", never "1 of 1 files"; "A, B and C"."""

import dataclasses

import pytest

import mocapkit
from mocapkit import metrics, samples
from mocapkit.cleaning.deep import training
from mocapkit.cleaning.ssa.texture import motion_words
from mocapkit.errors import MocapFormatError, SkeletonError
from mocapkit.reference import check_reference
from mocapkit.words import listed, plural


def test_plural_and_listed():
    assert [plural(n, "file") for n in (0, 1, 2)] == ["0 files", "1 file", "2 files"]
    assert plural(1, "modelled quantity", "modelled quantities") == "1 modelled quantity"
    assert plural(3, "modelled quantity", "modelled quantities") == "3 modelled quantities"
    assert [listed(x) for x in ([], ["A"], ["A", "B"], ["A", "B", "C", "D"])] == ["", "A", "A and B", "A, B, C and D"]


def test_notes_and_errors_that_count_one_say_it_in_the_singular():
    """Each said "1 frames", "1 of 1 training clips are", "1 other ASF files": the count of one reads as one."""
    walk = mocapkit.load(samples.path("12_walk.amc"))
    one = walk[:1]
    with pytest.raises(MocapFormatError, match=r"must have the input's joints and 1 frame \(it has 2 frames\)"):
        check_reference(walk[:2], "ref.bvh", frames=1, joint_names=walk.skeleton.joint_names)
    with pytest.raises(MocapFormatError, match=r"and 2 frames \(it has 1 frame\)"):
        check_reference(one, "ref.bvh", frames=2, joint_names=walk.skeleton.joint_names)
    with pytest.raises(SkeletonError, match=r"cannot compare 1 frame with 2 frames"):
        metrics.joint_angle_rms(one, walk[:2])
    with pytest.raises(ValueError, match=r"a clip of 1 frame is shorter than one motion word"):
        motion_words(1, 15)
    cfg = training.TrainConfig(kind="ebf", hidden=8, epochs=1, steps_per_epoch=1, batch=2, crop=40,
                               noise=("angular:0.5",), variants=1)
    with pytest.raises(ValueError, match=r"^1 of 1 training clip is shorter than a crop of 70 frames"):
        training.check_clip_lengths([dataclasses.replace(walk[:60], name="short_one", source_file=None)], cfg)
    with pytest.raises(ValueError, match=r"^1 holdout of 1 clip needs more than 1 clip, got 1$"):
        training.holdout_folds([walk[:60]], 1, 1)


def test_messages_a_user_reads_count_one_frame_in_the_singular(tmp_path):
    """Follow-up: "NaN in 1 frames" (saving a take with one missing frame), "holds only 1 frames" (a BVH cut
    after its first frame), "the mask has 1 frames" and "the clips cover 1 frames" (a damaged database) each
    said a count of one in the plural."""
    import json
    import numpy as np
    from mocapkit.io.masks import read_mask
    walk = mocapkit.load(samples.path("12_walk.amc"))[:3]
    rot = np.array(walk.rotations)
    rot[1, 2] = np.nan
    gap = dataclasses.replace(walk, rotations=rot)
    with pytest.raises(MocapFormatError, match=r"missing values \(NaN\) in 1 frame; fill"):
        mocapkit.save(gap, tmp_path / "gap.bvh")
    mocapkit.save(walk, tmp_path / "three.bvh")
    text = (tmp_path / "three.bvh").read_text().rstrip("\n").split("\n")
    (tmp_path / "cut.bvh").write_text("\n".join(text[:-2]) + "\n")
    with pytest.raises(MocapFormatError, match=r"Frames: says 3 but the data holds only 1 frame$"):
        mocapkit.load(tmp_path / "cut.bvh")
    np.savez(tmp_path / "m.npz", mask=np.zeros((1, walk.num_joints), bool))
    with pytest.raises(MocapFormatError, match=r"the mask has 1 frame and the take 3"):
        read_mask(tmp_path / "m.npz", frames=3)
    from mocapkit.database import MotionDatabase
    db = MotionDatabase.build([mocapkit.load(samples.path("12_walk.amc"))[:12]], progress=False, executor="serial")
    db.save(tmp_path / "db")
    doc = json.loads((tmp_path / "db" / "database.json").read_text())
    doc["clips"][0]["frames"] = 1
    (tmp_path / "db" / "database.json").write_text(json.dumps(doc))
    with pytest.raises(MocapFormatError, match=r"the clips cover 1 frame, num_frames says 3$"):
        MotionDatabase.open(tmp_path / "db")


def test_a_one_frame_run_is_said_as_one_frame_everywhere():
    """A one-frame flag read "flagged UpperArm_R frames 255-255 (8.50-8.50 s)" and "left: ... UpperArm_R frames
    255-255", and a bad id "1 change id(s) are not changes of this cleaning" (a user trial); `corrupt` said
    "frame 46". words.frame_span is the one way a run of frames is said; the lines read back still read."""
    from mocapkit.cleaning.decisions import check_choices
    from mocapkit.cleaning.ssa import LeftRun
    from mocapkit.words import frame_span

    assert frame_span(255, 255, 30.0) == "frame 255 (8.50 s)" and frame_span(250, 252, 30) == "frames 250-252 (8.33-8.40 s)"
    assert frame_span(7, 7) == "frame 7" and frame_span(7, 9) == "frames 7-9"
    run = LeftRun("UpperArm_R", 255, 256, "joins the take less smoothly")
    assert str(run) == "left: repair not better than the take: UpperArm_R frame 255 (joins the take less smoothly)"
    assert LeftRun.from_note(str(run)) == run
    with pytest.raises(ValueError, match=r"^1 change id is not a change of this cleaning: 'repair:Spine:12-14'$"):
        check_choices({"repair:Spine:12-14": "reject"}, ["repair:Spine:12-13"])
    with pytest.raises(ValueError, match=r"^2 change ids are not changes of this cleaning: "):
        check_choices({"a": "reject", "b": "accept"}, ["c"])


def test_runs_of_frames_are_said_each_exactly_not_as_one_span_over_frames_between_them():
    """The kept cells of a Bandai take (raise-up-right-hand 060 at 0.3 noise) were said "Foot_R frames 20-36": one
    span over frames 27-31 and 33-34 that a repair changed. words.frame_runs says each run."""
    from mocapkit.words import frame_runs

    assert frame_runs([(20, 26), (32, 32), (35, 36)]) == "frames 20-26, 32 and 35-36"
    assert frame_runs([(252, 252)]) == "frame 252" and frame_runs([(3, 3), (5, 5)]) == "frames 3 and 5"
    assert frame_runs([(1, 2), (4, 5), (7, 7), (9, 9), (11, 12)], most=2) == "frames 1-2, 4-5 and 3 more runs"
    assert frame_runs([]) == ""
