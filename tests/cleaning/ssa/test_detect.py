"""Detection on real clips: injected errors flagged on the right joint, exact where the answer is known (a twin context)."""

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa import cues
from mocapkit.errors import MocapError, NotJudgedError, SkeletonError
from mocapkit.motion import concatenate
from tests.cleaning.ssa.helpers import turned


def test_shapes_and_range(walk, flipped):
    det = flipped[3]
    F, J = walk.num_frames, walk.num_joints
    assert det.mdm.shape == det.flags.shape == (F, J)
    assert np.all((det.mdm >= 0) & (det.mdm <= 1))
    assert det.params.confirm
    cues = det.holds | det.swaps | det.offsets | det.drifts()
    assert np.array_equal(det.flags, ssa.confirm_flags(det.mdm, det.jumps, det.threshold, det.fps, spikes=det.spikes) | cues)
    assert not (det.flags & ~cues & (det.mdm <= det.threshold / 2)).any()
    assert not (det.jumps | cues)[:, ~det.analysed].any()
    assert det.joint_names == tuple(walk.skeleton.joint_names)
    assert det.analysed.sum() == 24 and det.analysed[0]
    assert np.all(det.mdm[:, ~det.analysed] == 0)


def test_injected_flip_is_flagged_on_its_joint_and_not_its_neighbours(walk, flipped):
    bad, mask, records, det = flipped
    sk = walk.skeleton
    r = records[0]
    j = sk.index(r.joint)
    window = slice(r.start, r.end)
    assert det.flags[window, j].mean() > 0.9
    assert not det.flags[window, sk.parents[j]].any()
    for c in sk.children(j):
        assert not det.flags[window, c].any()


def test_twin_context_reproduces_the_clip(walk):
    """With the clip's exact twin as context and K = 1, every word's neighbour is itself: no digression."""
    # two frames longer: a clip of the take's length holding its samples is the input itself, left out by content
    twin = concatenate([walk, walk[-2:]], name="twin")
    det = ssa.detect(walk, [twin], k=1)
    d = np.degrees(det.digression[:, det.analysed])
    assert np.nanmedian(d) < 0.5
    assert np.nanpercentile(d, 95) < 2.0
    # every word but the last (a 20-frame target cannot start within 20 frames of the end) finds itself
    assert (det.neighbor_dist[:, :-2, 0] < 1e-9).all()


def test_repeated_walk_is_mostly_below_threshold(walk):
    """A walk played three times: every word has exact repeats; flags are rare (the CMU thumbs flip on their own)."""
    rep = concatenate([walk, walk, walk], name="rep")
    det = ssa.detect(rep)
    assert det.flags.mean() < 0.01
    body = [walk.skeleton.index(n) for n in ("LeftKnee", "RightKnee", "LeftHip", "RightHip", "Chest", "Neck")]
    assert det.mdm[:, body].max() < det.threshold


def test_detection_round_trip(tmp_path, flipped):
    det = flipped[3]
    path = det.save(tmp_path / "det.npz")
    back = ssa.Detection.load(path)
    assert det.analysis is not None and back.analysis is None  # the prepared take is not saved
    for f in dataclasses.fields(det):
        if f.name == "analysis":
            continue
        a, b = getattr(det, f.name), getattr(back, f.name)
        if isinstance(a, np.ndarray):
            assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), f.name
        else:
            assert a == b, f.name
    assert list(tmp_path.iterdir()) == [path]


def test_a_take_no_word_can_judge_is_refused_naming_it_as_clean_skips_it(walk):
    """A take shorter than one motion word, or under 12 fps, is refused by one documented exception that names the
    take and the length or rate a word needs, in the words ``mocapkit.clean``'s summary says as it skips the take."""
    short = dataclasses.replace(walk[:40], name="short_take")
    with pytest.raises(NotJudgedError) as caught:
        ssa.detect(short)
    err = caught.value
    assert isinstance(err, MocapError) and isinstance(err, ValueError)
    assert err.take == "short_take"
    assert str(err) == ("short_take: 40 frames (0.33 s) is shorter than one motion word (15 frames at 24 fps, "
                        "0.625 s): not judged")
    skipped = mocapkit.clean(short, steps="detect", context=False)
    assert skipped.detection is None and err.reason in "\n".join(skipped.summary())
    coarse = dataclasses.replace(walk, fps=10.0, name="coarse_take")
    with pytest.raises(NotJudgedError, match=r"^coarse_take: 10 fps is too coarse for motion words: .*: not judged$"):
        ssa.detect(coarse)


def test_bad_inputs(walk):
    hdm = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    with pytest.raises(SkeletonError, match="joints differ"):
        ssa.detect(walk, [hdm])
    with pytest.raises(ValueError, match="shorter than one motion word"):
        ssa.detect(walk[:20])
    holes = np.array(walk.rotations)
    holes[5, 3] = np.nan
    with pytest.raises(ValueError, match="missing rotations"):
        ssa.detect(dataclasses.replace(walk, rotations=holes))
    with pytest.raises(ValueError, match="threshold"):
        ssa.detect(walk, threshold=1.5)
    with pytest.raises(ValueError, match="jump_deg"):
        ssa.detect(walk, jump_deg=0)
    with pytest.raises(ValueError, match="confirm_margin_s"):
        ssa.detect(walk, confirm_margin_s=-0.1)
    with pytest.raises(ValueError, match="hold_travel_deg"):
        ssa.detect(walk, hold_travel_deg=0.0)


def test_context_clip_equal_to_the_input_is_left_out(walk):
    det = ssa.detect(walk[:400], [walk[:400]])
    assert any("the input itself" in n for n in det.notes)
    assert len(det.context_clips) == 1


def test_the_input_itself_is_told_by_its_samples_not_its_name():
    """Trial T1: a renamed corrupted copy of a default-context take was judged against the context's clean copy of
    itself (HDM_bd_grabHighR_001_120: 162 changed cells under its own name, 137 renamed), and a take sharing a clip's
    name and length would drop that clip. The bundled default context's HDM_bk_sneak2StepsLStart_005_120 and two
    clips of 19 frames at 24 fps (actors bd and dg, rotateArmsBothBackward1Reps)."""
    from mocapkit.cleaning.ssa.texture import context_motions
    from mocapkit.context import default_context

    db = default_context()
    clips = [db.clip(i) for i in range(db.num_clips)]
    take = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    broken = corrupt.real_errors(take, seed=1)[0]
    for m in (take, dataclasses.replace(take, name="my_take"), dataclasses.replace(broken, name="my_take")):
        kept, notes = context_motions(m, clips)
        assert [c.name for c in clips if c not in kept] == ["HDM_bk_sneak2StepsLStart_005_120"], m.name
        assert any("'HDM_bk_sneak2StepsLStart_005_120' is the input itself" in n for n in notes)
    bd, dg = (next(c for c in clips if c.name == f"HDM_{a}_rotateArmsBothBackward1Reps_{n}_120")
              for a, n in (("bd", "001"), ("dg", "009")))
    assert bd.num_frames == dg.num_frames
    kept, notes = context_motions(dataclasses.replace(dg, name=bd.name), clips)  # another take, the same name
    assert bd in kept and dg not in kept and len(kept) == len(clips) - 1


def test_small_context_and_prefilter_find_the_error():
    """HDM05 sneak: one actor's take against another take of the same actor (bundled), kd-tree prefilter on."""
    a = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    b = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    bad, mask, records = corrupt.real_errors(a, kinds=("flip",), n_errors=1, seed=2, joints=["rtibia"])
    for prefilter in (False, True):
        det = ssa.detect(bad, [b], prefilter=prefilter)
        r = records[0]
        assert det.flags[r.start : r.end, a.skeleton.index("rtibia")].mean() > 0.8
        assert det.params.prefilter == prefilter


def test_prefilter_agrees_with_exhaustive_search(walk):
    ctx = [dataclasses.replace(walk[400:], name="rest")]
    ex = ssa.detect(walk[:400], ctx, prefilter=False)
    pf = ssa.detect(walk[:400], ctx, prefilter=True, candidates=64)
    # the kd-tree proposes candidates, DTW ranks them: the best neighbour is found for most words (54 of the 70
    # (group, word) pairs since the wrists are analysed and the glitching thumbs not, 57 before; 58 with 128 candidates)
    same = np.abs(ex.neighbor_dist[:, :, 0] - pf.neighbor_dist[:, :, 0]) <= 1e-6 + 0.05 * ex.neighbor_dist[:, :, 0]
    assert same.mean() > 0.75


def test_two_stage_matches_single_stage_on_the_error():
    a = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    b = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    bad, mask, records = corrupt.real_errors(a, kinds=("flip",), n_errors=1, seed=2, joints=["rtibia"])
    det = ssa.detect(bad, [b], two_stage=True)
    r = records[0]
    assert det.params.two_stage
    assert det.flags[r.start : r.end, a.skeleton.index("rtibia")].mean() > 0.8


def test_unseen_words_are_not_judged(walk, flipped):
    bad = flipped[0]
    none = ssa.detect(bad, max_word_angle_deg=0.01)  # nothing in the clip is this close to anything else
    assert np.all(none.mdm == 0) and not none.holds.any()
    # steps off the path and back need no neighbour word: the flip is still found, and nothing else is
    assert np.array_equal(none.flags, none.swaps | none.offsets)
    r = flipped[2][0]
    assert none.flags[r.start : r.end, walk.skeleton.index(r.joint)].all()
    assert any("not judged" in n for n in none.notes)
    loose = ssa.detect(bad, max_word_angle_deg=180.0)
    assert np.array_equal(loose.mdm, flipped[3].mdm)


def test_a_smooth_distinct_gesture_is_flagged_only_without_confirmation(walk):
    """A 70 deg elbow bump over 0.6 s, once in the take: the paper's rule flags it, confirmation does not (no break)."""
    frames = np.arange(500, 572)
    bump = 70.0 * np.sin(np.linspace(0.0, np.pi, len(frames))) ** 2
    gesture, j = turned(walk, "LeftElbow", frames, bump)
    confirmed = ssa.detect(gesture)
    paper = ssa.detect(gesture, confirm=False)
    assert np.array_equal(confirmed.mdm, paper.mdm)
    assert np.array_equal(paper.flags, paper.mdm > paper.threshold)
    assert paper.flags[frames, j].mean() > 0.3
    assert not confirmed.flags[frames, j].any()
    # the same bump with a break in it (the second half held at zero: a dropout) is an error
    broken, j = turned(walk, "LeftElbow", frames[:36], bump[:36])
    assert ssa.detect(broken).flags[frames[:36], j].mean() > 0.3


def test_with_threshold_applies_the_detection_rule(flipped):
    det = flipped[3]
    assert np.array_equal(det.with_threshold(det.threshold).flags, det.flags)
    low = det.with_threshold(0.3)
    assert np.array_equal(low.flags, ssa.confirm_flags(det.mdm, det.jumps, 0.3, det.fps, spikes=det.spikes)
                          | det.holds | det.swaps | det.offsets | det.drifts())
    assert (low.flags >= det.flags).all()
    plain = dataclasses.replace(det, params=det.params.replace(confirm=False))
    assert np.array_equal(plain.with_threshold(0.3).flags, det.mdm > 0.3)
    with pytest.raises(ValueError, match="threshold"):
        det.with_threshold(0.0)


def test_a_detection_file_without_jumps_loads_with_none(tmp_path, flipped):
    """Files written before confirmation existed have no jumps array; their flags were MDM > threshold."""
    det = dataclasses.replace(flipped[3], params=flipped[3].params.replace(confirm=False))
    path = det.save(tmp_path / "det.npz")
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files if k not in ("jumps", "holds", "swaps", "offsets", "spikes")}
    np.savez(tmp_path / "old.npz", **arrays)
    back = ssa.Detection.load(tmp_path / "old.npz")
    assert back.jumps.shape == back.holds.shape == back.swaps.shape == back.offsets.shape == det.mdm.shape
    assert not (back.jumps.any() or back.holds.any() or back.swaps.any() or back.offsets.any())
    assert back.spikes is None  # written before spikes were told apart: no run is cut as a spike's
    assert np.array_equal(back.with_threshold(0.4).flags, det.mdm > 0.4)


def test_detect_flags_a_freeze_from_its_first_held_frame(walk):
    bad, mask, records = corrupt.real_errors(walk, kinds=("freeze",), n_errors=1, seed=4, joints=["RightElbow"])
    r = records[0]
    j = walk.skeleton.index(r.joint)
    det = ssa.detect(bad)
    assert det.holds[r.start : r.end, j].mean() > 0.9 and (det.flags >= det.holds).all()
    assert det.flags[r.start : r.start + 5, j].all()  # where the held value is still close to the truth
    paper = ssa.detect(bad, confirm=False)
    assert not paper.flags[r.start : r.start + 5, j].any()
    others = np.arange(walk.num_joints) != j
    assert not det.holds[:, others].any()


def test_digression_on_the_groups_joints_equals_it_on_every_joint(flipped):
    """:func:`detect._digression` computes only the columns a group's mean texture holds; the other joints'
    texture is NaN throughout, so the angles, scores and speeds equal those of every column, bit for bit."""
    import importlib

    from mocapkit.cleaning.ssa import word_dtw
    from mocapkit.cleaning.ssa.cues import step_angles
    from mocapkit.cleaning.ssa.neighbours import Neighbors, mean_motion_texture
    from mocapkit.cleaning.ssa.texture import facing_aligned, upsample_quaternions

    D = importlib.import_module("mocapkit.cleaning.ssa.detect")
    det = flipped[3]
    an, p = det.analysis, det.params
    nb = Neighbors(det.neighbor_pos, det.neighbor_iend, det.neighbor_jend, det.neighbor_dist)
    mean_tex, spread = mean_motion_texture(an.source, an.texture, list(an.group_rows), an.words, nb,
                                           p.source_length, p.target_length, return_spread=True)
    assert np.isnan(mean_tex).all(axis=(1, 3)).any()  # some groups leave joints out
    motion, fps_a, joints = an.motion, p.analysis_fps, an.joints
    got = D._digression(motion, mean_tex, spread, joints, an.up, fps_a, p.noise_deg, p.shift_s, speeds=True)
    F, G = motion.num_frames, len(mean_tex)
    inp = facing_aligned(motion.rotations, an.up)[:, joints]
    want = [np.full((G, F, len(joints)), np.nan) for _ in range(3)]
    t, src_t = np.arange(F) * (fps_a / motion.fps), np.arange(mean_tex.shape[1])
    for g in range(G):  # every column, as one call per group
        up_q = upsample_quaternions(mean_tex[g], fps_a, F, motion.fps)
        step = np.degrees(step_angles(up_q)) * motion.fps
        want[2][g] = np.concatenate([step, step[-1:]])
        want[0][g] = word_dtw.shift_tolerant_angles(inp, up_q, int(round(p.shift_s * motion.fps)))
        sp = np.stack([np.interp(t, src_t, spread[g][:, c]) for c in range(len(joints))], axis=1)
        want[1][g] = want[0][g] / np.sqrt(np.where(np.isfinite(sp), sp, 0.0) ** 2 + np.radians(p.noise_deg) ** 2)
    for a, b in zip(got, want):
        assert np.array_equal(a, b, equal_nan=True)


def test_causes_made_with_the_flags_are_those_made_again(flipped):
    """The causes detect, with_threshold and padded keep beside the flags (made once) are what the detection's
    fields give when made again (Detection.flag_causes), and their flags the detection's; a copy each call."""
    bad, mask, records, det = flipped
    assert "_causes" in det.__dict__
    fresh = det.flag_causes(det.threshold)
    assert np.array_equal(det.causes(), fresh) and np.array_equal(det.flags, fresh != 0) and fresh.any()
    det.causes()[:] = 0  # a copy: the kept one stays
    assert np.array_equal(det.causes(), fresh)
    other = det.with_threshold(0.3)
    assert np.array_equal(other.causes(), other.flag_causes(0.3)) and np.array_equal(other.flags, other.causes() != 0)
    padded = det.padded(7, det.num_frames + 12)
    bare = dataclasses.replace(padded)  # replace leaves the kept causes behind: made again from the fields
    assert "_causes" not in bare.__dict__
    assert np.array_equal(padded.causes(), bare.causes())
    assert np.array_equal(padded.with_threshold(0.3).causes(), dataclasses.replace(padded.with_threshold(0.3)).causes())
    assert np.array_equal(dataclasses.replace(det).causes(), fresh)


def test_a_large_context_is_searched_exactly_by_default(walk):
    """A context of over 3,000 target words (the real walk at 18 frame offsets and mirrored) is searched exactly: the
    approximate kd-tree prefilter runs only when asked for, and the neighbours are those of prefilter=False."""
    ctx = [dataclasses.replace((walk if i % 2 else walk.mirror())[i:], name=f"walk{i}") for i in range(18)]
    det = ssa.detect(walk[:240], ctx)
    assert len(det.analysis.texture.target_starts(20)) > 3000
    assert det.params.prefilter is False
    exact = ssa.detect(walk[:240], ctx, prefilter=False)
    for a in ("neighbor_pos", "neighbor_iend", "neighbor_jend", "neighbor_dist"):
        assert np.array_equal(getattr(det, a), getattr(exact, a))
    assert np.array_equal(det.flags, exact.flags) and np.array_equal(det.mdm, exact.mdm)
