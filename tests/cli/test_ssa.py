"""`mocapkit detect` and `mocapkit repair` on a real clip with an injected error."""

import json
import re
from pathlib import Path

import numpy as np

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning import ssa, take_breaks
from tests.cli.helpers import SAMPLE, one_error_line, run

BANDAI = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"


def test_detect_and_repair(tmp_path):
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:600]  # 5 s: the injected flip and RThumb turn-overs
    bad, mask, records = corrupt.real_errors(walk, kinds=("flip",), n_errors=1, seed=1, joints=["LeftKnee"])
    inp = tmp_path / "bad.bvh"
    mocapkit.save(bad, inp)
    det_path, png = tmp_path / "det.npz", tmp_path / "mdm.png"
    code, out, err = run("detect", str(inp), "--out", str(det_path), "--png", str(png))
    assert code == 0, err
    det = ssa.Detection.load(det_path)
    r = records[0]
    assert det.flags[r.start : r.end, walk.skeleton.index("LeftKnee")].mean() > 0.9
    assert png.stat().st_size > 10_000 and "LeftKnee" in out
    knee = [line for line in out.splitlines() if line.strip().startswith("LeftKnee")]
    assert knee and all(any(w in line for _, w in ssa.cues.CAUSES) for line in knee)  # each says why
    fixed_path = tmp_path / "fixed.bvh"
    code, out, err = run("repair", str(inp), "-o", str(fixed_path), "--detection", str(det_path), "--no-foot-skate")
    assert code == 0, err
    fixed = mocapkit.load(fixed_path)
    again = mocapkit.load(inp)  # what a BVH round trip of the input gives
    keep = ~det.flags
    # the sample's own RThumb flips (not analysed by detect) are turned back by repair and named (ssa.flips)
    assert "flip: RThumb turned 180 deg and back, frames 178-191 (a constant half turn): turned back exactly" in out
    keep[:, walk.skeleton.index("RThumb")] = False
    assert np.allclose(fixed.rotations[keep], again.rotations[keep], atol=1e-6) or np.allclose(
        np.abs(np.sum(fixed.rotations[keep] * again.rotations[keep], axis=-1)), 1.0, atol=1e-9
    )
    # by default as with --no-foot-skate (foot-skate cleanup is opt-in, as in clean), and the count printed is of
    # the samples that changed (it was the flags' count while the cleanup moved unflagged hips and knees too)
    code, out, err = run("repair", str(inp), "-o", str(tmp_path / "default.bvh"), "--detection", str(det_path))
    assert code == 0, err
    assert (tmp_path / "default.bvh").read_bytes() == fixed_path.read_bytes()
    changed = ~np.all(mocapkit.load(tmp_path / "default.bvh").rotations == again.rotations, axis=-1)
    thumb = np.zeros_like(det.flags)
    thumb[:, walk.skeleton.index("RThumb")] = True
    assert changed.any() and not (changed & ~det.flags & ~thumb).any()
    turned = int((changed & thumb & ~det.flags).sum())  # flagged by repair as turn-overs, cause "flip"
    assert turned > 0
    said = re.search(f"{int(changed.sum())} joint samples changed in {int(changed.any(axis=1).sum())} of "
                     f"{walk.num_frames} frames \\(([0-9]+) flagged\\)", out)
    assert said and int(said.group(1)) >= int(det.flags.sum()) + turned  # a turn-over named and left is flagged too


def test_detect_errors_are_one_line(tmp_path):
    inp = mocapkit.samples.path("131_01.bvh")
    code, _, err = run("detect", str(inp), "--out", str(tmp_path / "d.npz"), "--context", str(mocapkit.samples.path("12_walk.amc")))
    assert code == 2 and one_error_line(err) and "joints differ" in err
    assert not (tmp_path / "d.npz").exists()
    code, _, err = run("detect", str(inp), "--out", str(tmp_path / "d.txt"))
    assert code == 2 and one_error_line(err) and ".npz" in err
    code, _, err = run("repair", str(inp), "-o", str(tmp_path / "x.bvh"), "--detection", str(inp))
    assert code == 2 and one_error_line(err) and "not a mocapkit detection file" in err


def test_detect_no_confirm_gives_the_papers_flags(tmp_path):
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:600]
    inp = tmp_path / "walk.npz"
    mocapkit.save(walk, inp)
    paths = {rule: tmp_path / f"{rule}.npz" for rule in ("confirm", "no-confirm")}
    segments, notes = {}, {}
    for rule, path in paths.items():
        code, out, err = run("detect", str(inp), "--out", str(path), f"--{rule}", "--json")
        assert code == 0, err
        found = json.loads(out.strip().splitlines()[-1])
        segments[rule], notes[rule] = found["segments"], found["notes"]
    confirmed, paper = (ssa.Detection.load(p) for p in paths.values())
    # each segment names the rules that flagged it: without confirmation, the digression alone, and the take's own
    # RThumb turn-overs (not analysed by self-similarity) under either rule, as repair would look for them
    words = dict(ssa.cues.CAUSES)
    flips = {rule: [(g["joint"], g["start"], g["last"]) for g in segs if g["causes"] == [words["flip"]]]
             for rule, segs in segments.items()}
    assert flips["confirm"] == flips["no-confirm"] == [("RThumb", 178, 191), ("RThumb", 237, 242)]
    assert ("flip: RThumb turned 180 deg and back, frames 178-191 (a constant half turn): left as is (repair would "
            "turn it back exactly)") in notes["no-confirm"]
    assert not paper.flags[:, walk.skeleton.index("RThumb")].any()  # the file keeps self-similarity's flags alone
    segments = {rule: [g for g in segs if g["causes"] != [words["flip"]]] for rule, segs in segments.items()}
    assert segments["no-confirm"] and all(g["causes"] == [words["digression"]] for g in segments["no-confirm"])
    others = set(words.values()) - {words["digression"]}
    assert all(g["causes"] and set(g["causes"]) <= others for g in segments["confirm"])  # none, or named
    assert all(g["last"] == g["end"] - 1 >= g["start"] for g in segments["no-confirm"])  # last inclusive, as printed
    assert np.array_equal(confirmed.mdm, paper.mdm)
    assert np.array_equal(paper.flags, paper.mdm > 0.5) and not paper.params.confirm
    broke = (confirmed.causes() & 1) != 0  # digressions a break confirms (the cues flag unjudged words too)
    assert confirmed.params.confirm and (broke <= paper.flags | (confirmed.mdm > 0.25)).all()
    assert confirmed.flags.sum() < paper.flags.sum()  # the clean walk's unrepeated gestures are not errors
    code, _, err = run("detect", str(inp), "--out", str(tmp_path / "bad.npz"), "--jump-deg", "-1")
    assert code == 2 and one_error_line(err) and "jump_deg" in err
    assert not (tmp_path / "bad.npz").exists()


def test_detect_prints_joint_names_with_markup_as_they_are(tmp_path):
    import dataclasses

    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    bad, _, _ = corrupt.real_errors(walk, kinds=("flip",), n_errors=1, seed=1, joints=["LeftKnee"])
    names = tuple("[/b]" if n == "LeftKnee" else n for n in bad.skeleton.joint_names)
    bad = dataclasses.replace(bad, skeleton=dataclasses.replace(bad.skeleton, joint_names=names), name="[/]")
    inp = tmp_path / "[b]bad[_].npz"
    mocapkit.save(bad, inp)
    code, out, err = run("detect", str(inp), "--out", str(tmp_path / "det.npz"))
    assert code == 0, err
    assert "  [/b]" in out  # the flagged joint, printed as it is named


def test_repair_refuses_a_detection_of_another_take(tmp_path):
    inp = mocapkit.samples.path("131_01.bvh")
    short = tmp_path / "short.npz"
    mocapkit.save(mocapkit.load(inp)[:300], short)
    det = tmp_path / "det.npz"
    code, _, err = run("detect", str(short), "--out", str(det), "--json")
    assert code == 0, err
    code, _, err = run("repair", str(inp), "-o", str(tmp_path / "x.bvh"), "--detection", str(det))
    assert code == 2 and one_error_line(err) and "det.npz: the detection is of 300 frames" in err
    assert not (tmp_path / "x.bvh").exists()


def test_detect_context_forms(tmp_path):
    """--context: a folder of takes (built once, cached), none (the clip alone), nothing (the bundled default)."""
    import shutil

    take = mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")
    folder = tmp_path / "ctx"
    folder.mkdir()
    for n in ("HDM_bk.asf", "HDM_bk_sneak2StepsLStart_004_120.amc"):
        shutil.copy(mocapkit.samples.path(n), folder / n)
    out = tmp_path / "d.npz"
    code, text, err = run("detect", take, "-o", out, "--context", folder)
    assert code == 0, err
    assert f"judged against the takes of {folder} (1 clip, " in text
    assert ssa.Detection.load(out).context_clips[1][0] == "HDM_bk_sneak2StepsLStart_004_120"
    code, text, err = run("detect", take, "-o", out, "--overwrite", "--context", "none")
    assert code == 0 and "judged against the clip itself" in text and len(ssa.Detection.load(out).context_clips) == 1
    code, text, err = run("detect", take, "-o", out, "--overwrite")
    assert code == 0 and "judged against the bundled default context (" in text
    assert len(ssa.Detection.load(out).context_clips) > 20
    assert sorted(p.name for p in folder.iterdir()) == ["HDM_bk.asf", "HDM_bk_sneak2StepsLStart_004_120.amc"]


def test_detect_says_a_short_take_in_its_own_frames(tmp_path):
    short = tmp_path / "short.bvh"
    mocapkit.save(mocapkit.load(SAMPLE)[:10], short)
    code, _, err = run("detect", short, "--out", tmp_path / "d.npz")
    assert code == 2 and "10 frames (0.08 s) is shorter than one motion word (15 frames at 24 fps, 0.625 s)" in err


def test_detect_refuses_a_take_too_coarse_for_a_word_in_one_line(tmp_path):
    """A BVH whose Frame Time is 1 s (the fuzzer's mutant 472) ran 25 s and more of word search on slerp between
    its samples; it is refused in one line saying why, and nothing is written."""
    import dataclasses

    coarse = tmp_path / "coarse.bvh"
    mocapkit.save(dataclasses.replace(mocapkit.load(SAMPLE)[:40], fps=1.0), coarse)
    code, out, err = run("detect", coarse, "--out", tmp_path / "d.npz")
    assert code == 2 and one_error_line(err) and not (tmp_path / "d.npz").exists()
    assert f"{coarse}: 1 fps is too coarse for motion words: a source word spans 0.625 s" in err
    assert "self-similarity judges takes of 12 fps or more" in err and err.rstrip().endswith(": not judged")


def test_detect_flags_what_clean_in_review_mode_flags(tmp_path):
    """`mocapkit detect` judges with clean's word gate: without it, words with no neighbour within 8 deg were judged
    and the command flagged cells `clean --steps detect` did not (a user trial: 180 against 78)."""
    take = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    bad, mask, _ = corrupt.real_errors(take, n_errors=3, seed=5)
    inp = tmp_path / "bad.npz"
    mocapkit.save(bad, inp)
    code, out, _ = run("detect", str(inp), "--out", str(tmp_path / "det.npz"), "--context", "none")
    assert code == 0
    # a segment's times are its first and last frame's, as the report's viewer labels them (frame f at f / fps)
    import re
    a, last, t0, t1 = re.search(r"frames (\d+)-(\d+) \((\d+\.\d+)-(\d+\.\d+) s\)", out).groups()
    assert (t0, t1) == (f"{int(a) / bad.fps:.2f}", f"{int(last) / bad.fps:.2f}")
    assert run("clean", str(inp), "-o", str(tmp_path / "review.npz"), "--steps", "detect", "--context", "none")[0] == 0
    det = ssa.Detection.load(tmp_path / "det.npz")
    with np.load(tmp_path / "review.clean.npz") as z:
        flags = z["flags"]
    assert det.flags.any() and np.array_equal(det.flags, flags)
    assert re.search(r"\d+ of \d+ words (has|have) no neighbour within 8 deg", " ".join(det.notes))


def _t_pose_walk(tmp_path, seed: int = 1):
    """:func:`tests.shared.t_pose_walk` (``seed``) saved as an .npz take: ``(its path, the take)``."""
    from tests.shared import t_pose_walk

    bad = t_pose_walk(seed)
    inp = tmp_path / "t_pose_walk.npz"
    mocapkit.save(bad, inp)
    return inp, bad


def test_detect_and_repair_do_what_clean_does_and_leave_the_calibration_pose_alone(tmp_path):
    """`detect` flags what `clean --steps detect` flags and `repair` writes what `clean --steps detect,repair` writes,
    on a take opening with a T-pose: before, both analysed the pose with the motion, so `detect` flagged it on ten
    joints (and flags next to it), `repair` rewrote it, and foot-skate cleanup (on by default) moved unflagged legs."""
    from mocapkit.cleaning import decisions as dec
    from mocapkit.cleaning.pipeline import CleanResult

    inp, bad = _t_pose_walk(tmp_path)
    code, out, err = run("detect", inp, "-o", tmp_path / "det.npz", "--json")
    assert code == 0, err
    found = {(g["joint"], g["start"], g["last"]) for g in json.loads(out.strip().splitlines()[-1])["segments"]}
    assert run("clean", inp, "-o", tmp_path / "review.npz", "--steps", "detect")[0] == 0
    review = CleanResult.load(tmp_path / "review.clean.npz")
    assert found and found == {(g["joint"], g["first"], g["last"]) for g in dec.flag_segments(review)}
    det = ssa.Detection.load(tmp_path / "det.npz")
    assert np.array_equal(det.flags, review.flags) and not det.flags[0].any()
    assert det.span == (1, bad.num_frames)  # the T-pose was left out of the analysis

    assert run("clean", inp, "-o", tmp_path / "cleaned.npz", "--steps", "detect,repair")[0] == 0
    cleaned = mocapkit.load(tmp_path / "cleaned.npz")
    for args in ((), ("--detection", tmp_path / "det.npz")):  # detecting again, or reading detect's file
        code, out, err = run("repair", inp, "-o", tmp_path / "repaired.npz", "--overwrite", *args)
        assert code == 0, err
        repaired = mocapkit.load(tmp_path / "repaired.npz")
        assert np.array_equal(repaired.rotations, cleaned.rotations)
        assert np.array_equal(repaired.root_positions, cleaned.root_positions)
        changed = ~np.all(repaired.rotations == bad.rotations, axis=-1)
        assert changed.any() and not changed[0].any() and not (changed & ~det.flags).any()
        assert (f"{int(changed.sum())} joint samples changed in {int(changed.any(axis=1).sum())} of "
                f"{bad.num_frames} frames ({int(det.flags.sum())} flagged)") in out


def test_repair_moves_unflagged_legs_only_with_foot_skate_and_says_so(tmp_path):
    """Foot-skate cleanup is opt-in (as in `clean`), and the count printed is of the samples that changed: before,
    `repair` said "92 joint samples replaced" (the flags) while it changed 128, unflagged hips and knees among them.
    The take is seed 4's, whose right thigh is frozen over frames 165-224 and replaced (seed 1's leg error, its feet
    swapped, is exchanged back: the feet where they were captured, nothing for the cleanup to mend)."""
    from mocapkit.motion import find_joint

    inp, bad = _t_pose_walk(tmp_path, seed=4)
    code, out, err = run("detect", inp, "-o", tmp_path / "det.npz")
    assert code == 0, err
    flags = ssa.Detection.load(tmp_path / "det.npz").flags
    code, out, err = run("repair", inp, "-o", tmp_path / "skate.npz", "--detection", tmp_path / "det.npz",
                         "--foot-skate")
    assert code == 0, err
    fixed = mocapkit.load(tmp_path / "skate.npz")
    changed = ~np.all(fixed.rotations == bad.rotations, axis=-1)
    extra = changed & ~flags
    legs = set()
    for role in ("left_foot", "right_foot"):
        j = find_joint(bad.skeleton, role)
        while j > 0:
            legs.add(j)
            j = int(bad.skeleton.parents[j])
    assert extra.any() and set(np.flatnonzero(extra.any(axis=0))) <= legs and not changed[0].any()
    assert (f"{int(changed.sum())} joint samples changed in {int(changed.any(axis=1).sum())} of {bad.num_frames} "
            f"frames ({int(flags.sum())} flagged; {int(extra.sum())} more moved by the foot-skate cleanup)") in out
    code, out, err = run("repair", inp, "-o", tmp_path / "plain.npz", "--detection", tmp_path / "det.npz")
    assert code == 0, err
    plain = ~np.all(mocapkit.load(tmp_path / "plain.npz").rotations == bad.rotations, axis=-1)
    assert plain.any() and not (plain & ~flags).any() and "foot-skate" not in out


def test_detect_json_names_the_joints_not_analysed(tmp_path):
    """/tmp/trial19 R3: `detect --json` listed the flagged segments only, so a joint nobody analysed read as clean.
    It prints one object: the segments, the joints not analysed with the reason, and the notes."""
    walk = mocapkit.load(SAMPLE)[1:400]  # CMU 131 BVH: still palms, fingers and a collar; thumbs after the body
    inp = tmp_path / "walk.npz"
    mocapkit.save(walk, inp)
    code, out, err = run("detect", inp, "-o", tmp_path / "det.npz", "--json")
    assert code == 0, err
    doc = json.loads(out.strip().splitlines()[-1])
    assert set(doc) == {"segments", "not_analysed", "notes"}
    still, crowded = {"lhand", "LFingers", "RightCollar", "rhand", "RFingers"}, {"LThumb", "RThumb"}
    assert doc["not_analysed"] == {n: "rotation never changes" if n in still else "beyond the 24 analysed (body first)"
                                   for n in walk.skeleton.joint_names if n in still | crowded}
    assert list(doc["not_analysed"]) == [n for n in walk.skeleton.joint_names if n in still | crowded]  # skeleton order
    assert any(n.startswith("not analysed, 7 joints: lhand, LFingers") for n in doc["notes"])
    det = ssa.Detection.load(tmp_path / "det.npz")  # the detection file keeps them too
    assert det.not_analysed() == doc["not_analysed"]
    assert sorted(det.texture_joints.tolist()) == [j for j, n in enumerate(walk.skeleton.joint_names)
                                                   if n not in still | crowded]


def test_repair_puts_back_a_root_teleport_as_clean_does(tmp_path):
    """`repair` takes clean's repair step: the root 1 m away for two frames of a real take is put back, said in the
    line clean's summary says, and OUT is clean --steps detect,repair's byte for byte (it was left 1 m away)."""
    from tests.cleaning.test_take_breaks import _moved_root

    for src in (mocapkit.samples.path("131_01.bvh"), BANDAI):  # the root position; the Bandai Hips' animated offset
        walk = mocapkit.load(src)[:400]  # the CMU walk's first 400 frames (the Bandai dash's 20): a jump mid-take
        f = walk.num_frames // 2
        inp = tmp_path / f"tele_{src.stem}.bvh"
        mocapkit.save(_moved_root(walk, slice(f, f + 2), (100.0, 0.0, 0.0)), inp, like=src)
        out, ref = tmp_path / f"rep_{src.stem}.bvh", tmp_path / f"cl_{src.stem}.bvh"
        code, said, err = run("repair", str(inp), "-o", str(out), "--context", "none")
        assert code == 0, err
        text = " ".join(said.split())
        assert f"frames {f}-{f + 1}: the root" in text and "put back on the path between the frames around them" in text
        code, said_c, err = run("clean", str(inp), "-o", str(ref), "--steps", "detect,repair", "--context", "none")
        assert code == 0, err
        assert out.read_bytes() == ref.read_bytes()
        path, _ = take_breaks.pelvis_path_cm(mocapkit.load(out))
        truth, _ = take_breaks.pelvis_path_cm(walk)
        assert np.linalg.norm(path[f:f + 2] - truth[f:f + 2], axis=1).max() < 5.0


def test_detect_names_and_flags_a_root_teleport_as_the_review_mode_does(tmp_path):
    """`detect` flags the cells of a teleport repair puts back (cause teleport) and says it in clean's review line,
    left as is (it printed detection's finding alone, nothing flagged); the detection file keeps self-similarity's
    flags alone."""
    from tests.cleaning.test_take_breaks import _moved_root

    src = Path(__file__).resolve().parents[1] / "data" / "cmu_01_01_start.bvh"
    inp, det = tmp_path / "tele.bvh", tmp_path / "det.npz"
    mocapkit.save(_moved_root(mocapkit.load(src), slice(50, 52), (100.0, 0.0, 0.0)), inp, like=src)
    code, out, err = run("detect", str(inp), "-o", str(det), "--context", "none", "--json")
    assert code == 0, err
    doc = json.loads(out.strip().splitlines()[-1])
    words = dict(ssa.cues.CAUSES)
    assert [(g["joint"], g["start"], g["last"], g["causes"]) for g in doc["segments"]] == [
        ("Hips", 50, 51, [words["teleport"]])]
    assert ("frames 50-51: the root (Hips) jumps 100 cm away and back (wrong root samples); left as is (repair would "
            "put it back on the path between the frames around them)") in doc["notes"]
    assert not ssa.Detection.load(det).flags.any()


def test_detect_and_repair_refuse_channels_written_as_zero_as_they_refuse_gaps(tmp_path):
    """A dropout written as 0 is samples the capture lost: detect and repair refuse it in one line naming the file
    and the run, as clean without its fill step does (detect flagged the run with two good frames before it, and
    repair "repaired" them)."""
    from tests.cleaning.test_zeros import _zeroed_bvh

    inp = _zeroed_bvh(Path(SAMPLE), tmp_path / "zeroed.bvh", {("LeftHip", None): range(100, 200)})
    det = tmp_path / "det.npz"
    for args in (("detect", str(inp), "-o", str(det)), ("repair", str(inp), "-o", str(tmp_path / "r.bvh"))):
        code, _, err = run(*args, "--context", "none")
        assert code == 2 and one_error_line(err), err
        assert f"{inp}: LeftHip frames 100-199: channels written as 0 (a dropout)" in " ".join(err.split())
        assert "detect needs complete frames" in err
    assert not det.exists() and not (tmp_path / "r.bvh").exists()
    code, _, err = run("clean", str(inp), "-o", str(tmp_path / "c.bvh"), "--steps", "detect", "--context", "none")
    assert code == 2 and "LeftHip frames 100-199: channels written as 0" in " ".join(err.split())
    # a detection made of the take otherwise (Python, an earlier mocapkit) repairs nothing in it either
    ssa.detect(mocapkit.load(inp)).save(det)
    code, _, err = run("repair", str(inp), "-o", str(tmp_path / "r.bvh"), "--detection", str(det))
    assert code == 2 and one_error_line(err) and "LeftHip frames 100-199" in err


def test_detect_and_repair_say_the_stutters_clean_says(tmp_path):
    """A frame written again bit for bit while the take moves: clean names it; detect and repair said nothing."""
    import dataclasses

    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:600]  # the stutter's note, whatever the take's length
    rot, root = np.array(walk.rotations), np.array(walk.root_positions)
    rot[505], root[505] = rot[504], root[504]
    inp = tmp_path / "stutter.npz"
    mocapkit.save(dataclasses.replace(walk, rotations=rot, root_positions=root), inp)
    line = "frame 505 repeats frame 504 bit for bit while the take moves (a capture stutter)"
    code, said_c, err = run("clean", str(inp), "-o", str(tmp_path / "c.npz"), "--steps", "detect", "--context", "none")
    assert code == 0 and line in " ".join(said_c.split()), err
    for args in (("detect", str(inp), "-o", str(tmp_path / "d.npz")), ("repair", str(inp), "-o", str(tmp_path / "r.npz"))):
        code, said, err = run(*args, "--context", "none")
        assert code == 0, err
        assert line in " ".join(said.split())


def test_a_take_too_coarse_for_a_word_builds_no_context_in_any_command(tmp_path, monkeypatch):
    """`clean`, `detect` and `repair` on a 5 fps take with a folder as --context: detection does not run, so the
    folder is neither built nor cached; `clean` says so in one note, `detect` and `repair` refuse in one line."""
    cache = tmp_path / "cache"
    monkeypatch.setenv("MOCAPKIT_CACHE_DIR", str(cache))
    folder = tmp_path / "ctx"
    folder.mkdir()
    (folder / "walk.bvh").write_bytes(Path(SAMPLE).read_bytes())
    coarse = tmp_path / "coarse.bvh"
    mocapkit.save(mocapkit.load(SAMPLE).resample(5), coarse)
    code, out, _ = run("clean", coarse, "-o", tmp_path / "c.bvh", "--context", folder, "--steps", "detect,repair")
    assert code == 0 and "note: the context given was neither built nor read: at 5 fps detect and repair do not run" in out
    for cmd in ("detect", "repair"):
        code, out, err = run(cmd, coarse, "-o", tmp_path / f"{cmd}.npz", "--context", folder)
        assert code == 2 and one_error_line(err) and out == "" and "5 fps is too coarse for motion words" in err
    assert not (cache / "contexts").exists() or not any((cache / "contexts").iterdir())


def test_detect_and_clean_say_in_one_line_that_drifts_were_not_looked_for_without_a_chosen_context(tmp_path):
    # a Bandai Namco take: with --drifts and no --context the drift rule cannot run; the count of flags alone read as
    # "no drift found" (docs/guide/cleaning.md, Smooth drifts: nothing is flagged without a context)
    code, out, err = run("detect", str(BANDAI), "--out", str(tmp_path / "d.npz"), "--drifts")
    assert code == 0, err
    said = [ln for ln in out.splitlines() if "smooth drifts not looked for" in ln]
    assert len(said) == 1 and "--context" in said[0], out
    code, out, err = run("clean", str(BANDAI), "-o", str(tmp_path / "c.bvh"), "--drifts", "--steps", "detect")
    assert code == 0, err
    assert sum("smooth drifts not looked for" in ln for ln in out.splitlines()) == 1, out
    code, out, err = run("detect", str(BANDAI), "--out", str(tmp_path / "e.npz"))  # not asked for: not said
    assert code == 0, err
    assert "smooth drifts" not in out


def test_detect_and_repair_send_a_marker_capture_to_clean(tmp_path):
    """They said 'solve it to a skeleton first', which mocapkit does not do; `clean` reviews and cleans marker files."""
    c3d = mocapkit.samples.path("Eb015pr.c3d")
    for argv, says in ((["detect", str(c3d), "-o", str(tmp_path / "d.npz")], "`mocapkit clean --steps detect` reviews"),
                       (["repair", str(c3d), "-o", str(tmp_path / "r.c3d")], "`mocapkit clean` cleans a marker file")):
        code, _, err = run(*argv)
        text = " ".join(err.split())
        assert code == 2 and one_error_line(err), err
        assert f"{c3d}: a marker file has no joint angles, which {argv[0]} needs; {says}" in text, text
    assert list(tmp_path.iterdir()) == []


def test_detect_png_draws_the_frames_no_word_judged_grey(tmp_path, monkeypatch):
    """Their MDM is 0 though nothing checked them: the map drew them black, as found clean, while the console said
    '... not judged there' and the report stripes them; now grey, 'not analysed or judged'."""
    import mocapkit.report.plots
    from mocapkit.cleaning.judged import not_judged_cells

    drawn = {}

    def plot_mdm(mdm, joint_names, fps, path, **kwargs):
        drawn.update(mdm=mdm, grey=kwargs.get("grey"))
        Path(path).write_bytes(b"")

    monkeypatch.setattr(mocapkit.report.plots, "plot_mdm", plot_mdm)
    take = mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")
    code, _, err = run("detect", take, "-o", tmp_path / "d.npz", "--png", tmp_path / "d.png", "--context", "none")
    assert code == 0, err
    unjudged = not_judged_cells(ssa.Detection.load(tmp_path / "d.npz"))
    assert unjudged.any()
    assert np.isnan(drawn["mdm"][unjudged]).all() and drawn["grey"] == "not analysed or judged"
