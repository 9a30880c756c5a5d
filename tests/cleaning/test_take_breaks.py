"""The root's path and cuts (mocapkit.cleaning.take_breaks): teleports put back, jumps and holds named, cuts
named and no frame beside them "repaired" because of them; clean takes untouched and unnamed."""

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.cleaning import decisions
from mocapkit.cleaning import take_breaks as tb
from mocapkit.cleaning.pipeline import clean
from mocapkit.cleaning.ssa.cues import CAUSES
from mocapkit.joints import unit_scale_cm


def _cat(a, b):
    tr = None if a.translations is None else np.concatenate([a.translations, b.translations])
    return dataclasses.replace(a, rotations=np.concatenate([a.rotations, b.rotations]),
                               root_positions=np.concatenate([a.root_positions, b.root_positions]), translations=tr)


def _moved_root(m, frames, by_cm):
    """``m`` with the pelvis's position channel moved by ``by_cm`` (x, y, z) over ``frames`` (the Bandai rig's Hips
    translation, the root position elsewhere)."""
    by = np.asarray(by_cm, dtype=float) / unit_scale_cm(m.skeleton)
    if m.translations is not None:
        tr = np.array(m.translations)
        tr[frames, 1] += by
        return dataclasses.replace(m, translations=tr)
    root = np.array(m.root_positions)
    root[frames] += by
    return dataclasses.replace(m, root_positions=root)


def _note(res) -> str:
    return " ".join(res.summary())


@pytest.fixture(scope="module")
def walk131():
    return mocapkit.load(mocapkit.samples.path("131_01.bvh"))


@pytest.fixture(scope="module")
def bandai_walks(shared_data):
    d = shared_data / "secondary_bandai_namco_CC-BY-NC"
    return mocapkit.load(d / "dataset-1_walk_normal_001.bvh"), mocapkit.load(d / "dataset-1_walk_normal_002.bvh")


@pytest.mark.parametrize("rig", ["cmu", "bandai"])
def test_teleport_put_back_named_and_undoable(rig, walk131, request):
    m = walk131 if rig == "cmu" else request.getfixturevalue("bandai_walks")[0]
    f = m.num_frames // 2
    bad = _moved_root(m, slice(f, f + 1), (100.0, 0.0, 0.0))  # 1 m away for one frame
    res = clean(bad, steps="fill,detect,repair")
    path, p = tb.pelvis_path_cm(res.motion)
    truth, _ = tb.pelvis_path_cm(m)
    assert np.linalg.norm(path[f] - truth[f]) < 5.0  # was 100 cm: never looked at
    assert f"frame {f}: the root ({m.skeleton.joint_names[p]}) jumps 100 cm away and back" in _note(res)
    put = [c for c in decisions.changes(res, bad) if "root's path" in c.reason]
    assert [(c.joint_index, c.first, c.last) for c in put] == [(p if m.translations is not None else 0, f, f)]
    back = decisions.apply(bad, res, {c.id: "reject" for c in put})
    assert np.array_equal(back.root_positions, bad.root_positions)
    assert bad.translations is None or np.array_equal(back.translations, bad.translations)


def test_jump_that_stays_and_frozen_root_named_not_changed(walk131):
    f = 500
    held = np.array(walk131.root_positions)
    held[f:f + 240] = held[f]  # 2 s while the body walks
    for bad, words in [(_moved_root(walk131, slice(f, None), (200.0, 0.0, 0.0)), f"frame {f}: the root (Hips) jumps 200 cm and stays"),
                       (dataclasses.replace(walk131, root_positions=held), f"frames {f}-{f + 239}: the root (Hips) is held still")]:
        res = clean(bad, steps="fill,detect,repair")
        assert words in _note(res)
        assert np.array_equal(res.motion.root_positions, bad.root_positions)


#: a cut where the root jumps too, said in one line (take_breaks.with_root_jumps)
_CUT_AND_ROOT = (r"frame {frame}: the whole body jumps \(\d+ % of the joints at once, and the root jumps \d+ cm with "
                 r"them\): a cut, or dropped frames")


def test_bandai_splice_leaves_the_frames_before_the_cut(bandai_walks):
    a, b = bandai_walks
    m = _cat(a[:143], b[b.num_frames // 2:])
    res = clean(m, steps="fill,detect,repair")
    assert re.search(_CUT_AND_ROOT.format(frame=143), _note(res))  # the captures stand apart: one line says both
    assert not res.repaired[113:173].any()  # the Hips of frames 126-142 was turned up to 172 deg


def test_cmu_splice_and_dropped_frames(walk131, shared_data):
    other = mocapkit.load(shared_data / "cmu_bvh" / "131_02.bvh")
    for m, words in [(_cat(walk131[:504], other[other.num_frames // 2:]), _CUT_AND_ROOT.format(frame=504)),
                     (_cat(walk131[:504], walk131[514:]), r"frame 504: the whole body jumps \(\d+ % of the joints at "
                                                          r"once\): a cut")]:
        res = clean(m, steps="fill,detect,repair")
        assert re.search(words, _note(res)), _note(res)
        # good frames 473-503 were turned up to 120 deg; a wrist "repaired". 131_02's right thumb turned over
        # (frames 639-683 of its file) is turned back: a defect of the file, not the splice (ssa.flips)
        flip = 1 << [name for name, _ in CAUSES].index("flip")
        turned = (np.asarray(res.causes).astype(np.int64) & flip) != 0
        assert not (res.repaired & ~turned)[474:534].any()
        assert not np.delete(turned, [m.skeleton.index("RThumb")], axis=1).any()


@pytest.mark.parametrize("name", ["131_01.bvh", "12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"])
def test_clean_takes_have_no_breaks(name):
    m = mocapkit.load(mocapkit.samples.path(name))
    assert tb.cuts(m) == [] and tb.root_events(m) == []
    low = dataclasses.replace(m[::4], fps=m.fps / 4)  # the same capture at 30 fps
    assert tb.cuts(low) == [] and tb.root_events(low) == []


def test_fast_real_takes_have_no_breaks(shared_data):
    for p in sorted((shared_data / "secondary_bandai_namco_CC-BY-NC").glob("*.bvh")):
        m = mocapkit.load(p)
        assert tb.cuts(m) == [] and tb.root_events(m) == [], p.name


def test_root_jumps_matches_the_frame_by_frame_reference():
    """root_jumps compares each step with the median of the steps beside it, all frames at once: the same
    frames and excesses as the loop over frames (short paths included)."""
    import numpy as np

    from mocapkit.cleaning import take_breaks as tb

    def reference(path):
        d = np.diff(path, axis=0)
        n = len(d)
        excess = np.zeros(n)
        for i in range(n):
            idx = [k for k in (i - 2, i - 1, i + 1, i + 2) if 0 <= k < n]
            ref = np.median(d[idx], axis=0) if idx else np.zeros(3)
            excess[i] = np.linalg.norm(d[i] - ref)
        bad = np.flatnonzero(excess > tb.JUMP_CM)
        return bad + 1, excess[bad]

    rng = np.random.default_rng(0)
    for F in (2, 3, 4, 5, 7, 60, 400):
        for _ in range(10):
            path = np.cumsum(rng.normal(0.0, 8.0, (F, 3)), axis=0)
            if F > 5:
                path[rng.integers(1, F - 1)] += 100.0
            got, want = tb.root_jumps(path), reference(path)
            assert np.array_equal(got[0], want[0]) and np.allclose(got[1], want[1])


def test_cuts_read_the_residuals_detection_made(walk131):
    """A splice's cuts found on residuals handed in (the detection's, made once: Analysis.residuals) are the cuts
    found on residuals made here, and across_breaks hands the analysis' own residuals of the part."""
    from mocapkit.cleaning import ssa
    from mocapkit.cleaning.ssa.cues import midpoint_residuals
    from mocapkit.cleaning.whole_take import across_breaks, take_params

    m = _cat(walk131[:200], walk131[400:600])
    resid = midpoint_residuals(m.rotations)
    assert np.array_equal(tb.cut_scores(m, resid), tb.cut_scores(m))
    assert tb.cuts(m, resid=resid) == tb.cuts(m) and tb.cuts(m)
    det = ssa.detect(m, params=take_params())
    an = det.analysis
    assert an.motion is m and np.array_equal(an.residuals, resid) and not an.residuals.flags.writeable
    assert an.residuals is an.residuals  # made once
    seen = []
    real = tb.cuts
    try:
        tb.cuts = lambda part, span=None, resid=None: seen.append(resid) or real(part, span, resid)
        across_breaks(m, det)
    finally:
        tb.cuts = real
    assert len(seen) == 1 and seen[0] is an.residuals


@pytest.mark.parametrize("frames", [8, 9])
def test_a_take_of_8_or_9_frames_is_cleaned(shared_data, frames):
    """Bandai Namco's dash_normal_001 (20 frames at 30 fps) resampled to 12 fps is 8 frames: the cut test's usual
    peak asked numpy for a negative percentile and clean raised ValueError. A take that short holds no usual peak
    to stand out from: no cut is named, and clean runs."""
    m = mocapkit.load(shared_data / "secondary_bandai_namco_CC-BY-NC" / "dataset-1_dash_normal_001.bvh")
    take = m.resample(12.0) if frames == 8 else m.resample(13.5)
    assert take.num_frames == frames
    assert tb.cuts(take) == []
    res = clean(take)
    assert res.motion.num_frames == frames and not any("cut" in n for n in res.notes)


def test_the_root_s_teleport_is_named_at_the_take_s_frames_after_a_calibration_pose():
    """CMU 01_01 opens on the converter's T-pose (frame 0, left out of detection). Its root 1 m away on frames
    50-51: detect's line said "frames 49-50" (the analysed part's frames), repair's "frames 50-51"."""
    m = mocapkit.load(Path(__file__).parents[1] / "data" / "cmu_01_01_start.bvh")
    res = clean(_moved_root(m, slice(50, 52), (100.0, 0.0, 0.0)), steps="detect")
    assert [str(p) for p in res.calibration] == ["frame 0: calibration T-pose, left alone"]
    detect = next(s for s in res.steps if s.name == "detect")
    assert "frames 50-51: the root (Hips) jumps 100 cm away and back" in detect.note
    assert "frames 49-50" not in detect.note


def test_the_review_mode_names_and_flags_the_teleports_clean_puts_back_and_changes_nothing():
    """The review mode (steps="detect") said a teleport only as detection's finding: no flag on its cells, nothing
    of what the repair step does to it. It now flags the cells the repair step puts back (cause teleport), in the
    repair step's line with "left as is", and returns the take bit for bit (CMU 01_01's start, root 1 m away)."""
    from mocapkit.cleaning.flags_left import flag_outcomes

    m = mocapkit.load(Path(__file__).parents[1] / "data" / "cmu_01_01_start.bvh")
    bad = _moved_root(m, slice(50, 52), (100.0, 0.0, 0.0))
    review, cleaned = clean(bad, steps="detect"), clean(bad, steps="detect,repair")
    put_back = next(s for s in cleaned.steps if s.name == "repair").note
    line = "frames 50-51: the root (Hips) jumps 100 cm away and back (wrong root samples)"
    assert f"{line}; put back on the path between the frames around them" in put_back
    assert f"{line}; left as is (repair would put it back on the path between the frames around them)" in review.notes
    assert "1 teleport (0 put back)" in next(s for s in review.steps if s.name == "detect").note
    tele = 1 << [name for name, _ in CAUSES].index("teleport")
    assert np.array_equal(review.flags, cleaned.flags) and np.flatnonzero(review.flags[:, 0]).tolist() == [50, 51]
    assert (np.asarray(review.causes[50:52, 0]).astype(np.int64) & tele).all()
    assert np.array_equal(review.motion.root_positions, bad.root_positions) and not review.changed.any()
    assert [(f["joint"], f["first"], f["last"], f["left"]) for f in flag_outcomes(review)] == [
        ("Hips", 50, 51, "left as it was: the repair step did not run")]


def test_a_take_of_many_jumps_names_the_first_few_in_clean_s_summary_and_counts_the_rest(walk131):
    """A long take of many cuts (a session of takes joined) named every one in the detect step's single summary
    line; the first :data:`~mocapkit.cleaning.clean_record.MAX_LINES` are named, the rest counted."""
    from mocapkit.cleaning.pipeline import MAX_LINES

    root = np.array(walk131.root_positions)
    at = list(range(60, walk131.num_frames - 30, 60))  # 16 jumps that stay
    for f in at:
        root[f:, 0] += 200.0
    res = clean(dataclasses.replace(walk131, root_positions=root), steps="fill,detect")
    note = next(s.note for s in res.steps if s.name == "detect")
    assert note.count("and stays there") == MAX_LINES
    assert f"... and {len(at) - MAX_LINES} more cuts and jumps of the root (`mocapkit detect` lists them all)" in note
    assert np.array_equal(res.motion.root_positions, root)  # named, not changed


@pytest.mark.parametrize("second_from", [30, "near"])
def test_a_cut_is_named_by_the_first_frame_of_the_second_take(tmp_path, second_from):
    """HDM05's bk sneak 004 (frames 0-199) joined to sneak 005 (from frame 30, or from the frame whose pose is
    nearest 004's frame 199): the break between frames 199 and 200 puts the joints' residuals over at both, so
    the shares tie at 199, 200 and 201, and the cut was named by the first, 199, one frame before the second take
    begins, and where the root jumps at 200 too it was named twice (the root's jump at 200, the cut at 199). A
    cut is named by the second take's first frame, 200, in the summary and the record `info` reads; where the
    root jumps there too (sneak 005 from frame 30; 131_01 frames 0-399 then 700-) it is named once, as a cut with
    the root's jump (named by the jump alone, it read "left as it is: which side is right is not known")."""
    from mocapkit import rotations as R
    from tests.cli.helpers import run

    a = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    b = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    start = second_from if second_from != "near" else int(np.argmin(
        np.nanmean(R.geodesic_angle(b.rotations, a.rotations[199][None]), axis=1)))
    m = _cat(a[:200], b[start:])
    assert [c.frame for c in tb.cuts(m)] == [200]
    take, out = tmp_path / "stitched.bvh", tmp_path / "out.bvh"
    mocapkit.save(m, take)
    code, said, err = run("clean", take, "-o", out)
    assert code == 0, err
    # from frame 30 the root jumps 71 cm there too: the cut is named once, with the root's jump
    named = "frame 200: the whole body jumps (" + ("86 % of the joints at once, and the root jumps 71 cm with them)"
                                                   if second_from == 30 else "")
    assert named in said and "frame 199" not in said and "stays there" not in said, said
    code, info, err = run("info", tmp_path / "out.clean.npz")
    assert code == 0 and named in " ".join(info.split()) and "frame 199" not in info, info + err
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    both = _cat(walk[:400], walk[700:])
    assert [c.frame for c in tb.cuts(both)] == [400]
    notes = _note(clean(both, steps="fill,detect"))
    assert re.search(_CUT_AND_ROOT.format(frame=400), notes) and "stays there" not in notes, notes


@pytest.mark.parametrize("rig", ["cmu", "bandai"])
def test_a_teleport_in_one_axis_leaves_the_others_as_written(rig, walk131, request):
    """The root jumps 1 m in X for three frames: X goes back on the line between the frames around them, the
    height and Z, on their own path all along, stay bit for bit as the file gives them (the line is up to 3 mm off
    them on the Bandai walk)."""
    m = walk131 if rig == "cmu" else request.getfixturevalue("bandai_walks")[0]
    f = m.num_frames // 2
    bad = _moved_root(m, slice(f, f + 3), (100.0, 0.0, 0.0))
    res = clean(bad, steps="fill,detect,repair")
    put = res.motion.root_positions if m.translations is None else res.motion.translations[:, 1]
    was = bad.root_positions if m.translations is None else bad.translations[:, 1]
    assert not np.array_equal(put[f:f + 3, 0], was[f:f + 3, 0])  # X put back
    assert np.array_equal(put[:, 1:], was[:, 1:])  # height and Z as written
    truth, _ = tb.pelvis_path_cm(m)
    path, _ = tb.pelvis_path_cm(res.motion)
    assert np.linalg.norm(path[f:f + 3] - truth[f:f + 3], axis=1).max() < 5.0
