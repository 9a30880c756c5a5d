"""Channels written as 0 where the capture lost data (mocapkit.cleaning.zeros) and what clean does with them."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.cleaning.decisions import apply, changes
from mocapkit.cleaning.pipeline import CleanResult, clean
from mocapkit.cleaning.zeros import find_zeros
from mocapkit.errors import MocapError


def _zeroed_bvh(src, dst, edits):
    """``src`` BVH written to ``dst`` with the channels ``edits`` {(joint, channel or None): frames} as the file's
    zeros ("0.000000", "0" and "-0" in turn); joint None: every channel of those frames."""
    text = src.read_text().splitlines(keepends=True)
    at = next(i for i, line in enumerate(text) if line.strip() == "MOTION") + 3
    chans, joint = [], None
    for line in text[:at]:
        t = line.split()
        if t and t[0] in ("ROOT", "JOINT"):
            joint = t[1]
        if t and t[0] == "CHANNELS":
            chans += [(joint, c) for c in t[2:]]
    spell = ("0.000000", "0", "-0")
    for (j, ch), frames in edits.items():
        cols = [k for k, (jj, c) in enumerate(chans) if j is None or (jj == j and (c == ch or (ch is None and c.endswith("rotation"))))]
        for n, f in enumerate(frames):
            vals = text[at + f].split()
            for k in cols:
                vals[k] = spell[(n + k) % 3]
            text[at + f] = " ".join(vals) + "\n"
    dst.write_text("".join(text))
    return dst


@pytest.fixture(scope="module")
def cmu_zeroed(tmp_path_factory):
    """CMU 131_01 (bundled) with LeftHip's rotation 0 for 3 s, RightKnee's Xrotation 0 for 0.5 s, frame 504 all 0."""
    src = samples.path("131_01.bvh")
    path = _zeroed_bvh(src, tmp_path_factory.mktemp("zeros") / "131_zeroed.bvh",
                       {("LeftHip", None): range(100, 460), ("RightKnee", "Xrotation"): range(600, 660),
                        (None, None): [504]})
    return mocapkit.load(src), mocapkit.load(path)


def test_clean_takes_have_no_dropouts():
    # the bundled HDM05 jog holds its left knee at its limit (ltibia reads 0 over frames 45-66): a limit, not a dropout
    for name in ("131_01.bvh", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", "12_walk.amc"):
        cells, runs, frames = find_zeros(mocapkit.load(samples.path(name)))
        assert runs == () and not cells.any() and not frames.any(), name


def test_knee_limits_of_real_takes_are_no_dropouts(shared_data):
    # exact zeros of clean captures: Acclaim knees straight at their limit for up to 137 frames (CMU BVH 131_01's
    # LeftKnee 794-930 too), Bandai Namco toe/knee/elbow channels at theirs; each reaches 0, none jumps there
    names = ["cmu_asfamc/lambada.amc", "hdm05_asfamc/HDM_tr_elbowToKnee1RepsLelbowStart_022_120.amc",
             "hdm05_asfamc/HDM_bk_lieDownFloor_007_120.amc", "secondary_bandai_namco_CC-BY-NC/dataset-1_run_normal_001.bvh",
             "secondary_bandai_namco_CC-BY-NC/dataset-1_walk-back_normal_001.bvh"]
    for name in names:
        path = shared_data / name
        if not path.exists():
            pytest.skip(f"{name} is not in the shared data")
        assert find_zeros(mocapkit.load(path))[1] == (), name


def test_zero_runs_are_found_and_named(cmu_zeroed):
    _, bad = cmu_zeroed
    cells, runs, frames = find_zeros(bad)
    said = [str(r) for r in runs]
    assert said == ["frame 504: every channel written as 0, the root's position too (a dropout), filled",
                    "LeftHip frames 100-459: channels written as 0 (a dropout), filled",
                    "RightKnee frames 600-659: Xrotation written as 0 (a dropout), filled"]
    sk = bad.skeleton
    assert np.flatnonzero(frames).tolist() == [504]
    assert np.flatnonzero(cells[:, sk.index("LeftHip")]).tolist() == list(range(100, 460)) + [504]
    assert np.flatnonzero(cells[:, sk.index("RightKnee")]).tolist() == [504] + list(range(600, 660))


def test_clean_fills_the_zeros_and_touches_nothing_else(cmu_zeroed, tmp_path):
    truth, bad = cmu_zeroed
    res = clean(bad, steps="fill")
    cells, _, _ = find_zeros(bad)
    assert np.array_equal(res.filled, cells) and np.array_equal(res.zeros, cells)
    out = res.motion
    assert np.array_equal(out.rotations[~cells], bad.rotations[~cells])  # bit for bit
    keep = np.ones(bad.num_frames, dtype=bool)
    keep[504] = False
    assert np.array_equal(out.root_positions[keep], bad.root_positions[keep])
    # the all-zero frame's root goes back where the body is (it was at the origin, 1.7 m away)
    assert np.linalg.norm(out.root_positions[504] - truth.root_positions[504]) < 0.5
    ang = np.degrees(mocapkit.rotations.geodesic_angle(out.rotations[504], truth.rotations[504]))
    assert ang.max() < 5.0
    lines = res.summary()
    assert "LeftHip frames 100-459: channels written as 0 (a dropout), filled" in lines
    # the record keeps them; the change list says why; rejecting every change gives the take back
    path = res.save(tmp_path / "r.clean.npz")
    back = CleanResult.load(path, motion=out)
    assert back.zero_runs == res.zero_runs and np.array_equal(back.zeros, cells)
    found = changes(back, bad)
    hip = [c for c in found if c.id == "fill:LeftHip:100-459"]
    assert len(hip) == 1 and hip[0].reason == "written as 0 (a dropout) in 360 of 360 frames"
    assert hip[0].max_deg > 10
    undone = apply(bad, back, {c.id: "reject" for c in found})
    assert np.array_equal(undone.rotations, bad.rotations) and np.array_equal(undone.root_positions, bad.root_positions)


def test_without_fill_the_zeros_are_named_and_left_and_detect_refuses_them(cmu_zeroed):
    _, bad = cmu_zeroed
    res = clean(bad[300:503], steps="detect")  # the hip's run touches the cut's start: not interior, nothing found
    assert "LeftHip frames 0-" not in " ".join(res.summary()) and res.zero_runs == ()
    res = clean(bad[:700], steps="denoise")
    assert "LeftHip frames 100-459: channels written as 0 (a dropout), left as written (the fill step did not run)" \
        in res.summary()
    assert not res.changed[100:460].any()
    # samples the capture lost, as NaN is: detect judged the dropout as motion and "repaired" its good edges
    with pytest.raises(MocapError, match=r"131_zeroed: frame 504: every channel written as 0, the root's position too "
                                         r"\(a dropout\) and 2 more such runs: .* detect needs complete frames"):
        clean(bad[:700], steps="detect")


def test_all_zero_frame_on_a_rig_with_animated_offsets(shared_data, tmp_path):
    # the Bandai Namco rig has position channels on every joint: a frame of zeros collapsed the skeleton to a point
    src = shared_data / "secondary_bandai_namco_CC-BY-NC/dataset-1_walk_normal_001.bvh"
    if not src.exists():
        pytest.skip("the secondary Bandai Namco takes are not in the shared data")
    truth = mocapkit.load(src)
    bad = mocapkit.load(_zeroed_bvh(src, tmp_path / "bn.bvh", {(None, None): [60], ("LowerLeg_L", "Yrotation"): range(80, 95)}))
    res = clean(bad, steps="fill")
    assert [str(r).split(":")[0] for r in res.zero_runs] == ["frame 60", "LowerLeg_L frames 80-94"]
    out = res.motion
    assert np.allclose(out.translations[60], truth.translations[60], atol=0.5)  # cm: the Hips channels move
    extent = np.ptp(out.global_positions()[60], axis=0)
    assert np.allclose(extent, np.ptp(truth.global_positions()[60], axis=0), atol=3.0)  # cm; it was 0
    j = bad.skeleton.index("LowerLeg_L")
    err_in = np.degrees(mocapkit.rotations.geodesic_angle(bad.rotations[80:95, j], truth.rotations[80:95, j]))
    err_out = np.degrees(mocapkit.rotations.geodesic_angle(out.rotations[80:95, j], truth.rotations[80:95, j]))
    # the joint's whole rotation is filled (its other channels too): closer, not exact, on this short take
    assert err_out.max() < err_in.max() and err_out.mean() < 0.8 * err_in.mean()
    changed = res.changed
    assert not changed[:60].any() and not changed[61:80].any() and not changed[95:].any()


def test_a_joint_that_never_moves_or_rests_at_zero_is_left():
    m = mocapkit.load(samples.path("131_01.bvh"))
    rot = np.array(m.rotations)
    j = m.skeleton.index("LeftElbow")
    rot[:, j] = [1.0, 0.0, 0.0, 0.0]  # 0 through the whole take: nothing to tell a dropout by
    rest = np.array(rot)
    rest[300:320] = [1.0, 0.0, 0.0, 0.0]  # every rotation 0, the root where it is: a rest pose
    for r in (rot, rest):
        assert find_zeros(dataclasses.replace(m, rotations=r))[1] == ()


def _stitched_6dp(paths, dst):
    """Takes of one rig stitched end to end as a studio exporter writes them (trial T4): the first take's header,
    every number at six decimals (``%.6f``), the Hips' X/Z positions shifted so that each take starts where the one
    before it ended."""
    head, rows, xz = None, [], []
    for p in paths:
        text = p.read_text().splitlines()
        at = next(i for i, line in enumerate(text) if line.strip() == "MOTION") + 3
        if head is None:
            head, chans, joint = text[:at], [], None
            for line in head:
                t = line.split()
                if t and t[0] in ("ROOT", "JOINT"):
                    joint = t[1]
                if t and t[0] == "CHANNELS":
                    chans += [(joint, c) for c in t[2:]]
            xz = [chans.index(("Hips", "Xposition")), chans.index(("Hips", "Zposition"))]
        frames = [[float(v) for v in line.split()] for line in text[at:] if line.strip()]
        for k in xz if rows else ():
            d = rows[-1][k] - frames[0][k]
            for fr in frames:
                fr[k] += d
        rows += frames
    head = [f"Frames:\t{len(rows)}" if h.startswith("Frames:") else h for h in head]
    dst.write_text("\n".join(head + [" ".join(f"{v:.6f}" for v in fr) for fr in rows]) + "\n")
    return dst


def test_a_straight_elbow_written_0_beside_a_join_is_no_dropout(shared_data, tmp_path):
    # trial T4: walk-back_normal_001 holds its left elbow straight, off-axis channels 1e-15 deg that a 6-decimal
    # exporter writes 0.000000 beside 0.000001; stitched after another take, the elbow's zero runs opened at the
    # join (frame 247 here: -69 deg -> 0) and were "filled" as dropouts, bending the straight elbow by up to 78 deg
    src = shared_data / "secondary_bandai_namco_CC-BY-NC"
    paths = [src / f"dataset-1_{n}.bvh" for n in ("walk_tired_001", "walk-back_normal_001", "walk_normal_002")]
    if not all(p.exists() for p in paths):
        pytest.skip("the secondary Bandai Namco takes are not in the shared data")
    path = _stitched_6dp(paths, tmp_path / "stitched.bvh")
    assert find_zeros(mocapkit.load(path))[1] == ()
    # real dropouts in the same stitched take are still found, in either take: values far from 0 on both sides; runs
    # that close the second take or open the third (the join at 278 is a cut) are at a take's end, left as alone
    bad = _zeroed_bvh(path, tmp_path / "bad.bvh", {(None, None): [100], ("LowerLeg_R", None): range(120, 136),
                                                    ("UpperArm_L", "Yrotation"): range(285, 296),
                                                    ("UpperArm_R", "Yrotation"): range(268, 278),
                                                    ("LowerLeg_L", None): range(278, 288)})
    assert [str(r) for r in find_zeros(mocapkit.load(bad))[1]] == [
        "frame 100: every channel written as 0, the root's position too (a dropout), filled",
        "UpperArm_L frames 285-295: Yrotation written as 0 (a dropout), filled",
        "LowerLeg_R frames 120-135: channels written as 0 (a dropout), filled"]


def test_blank_frames_an_exporter_wrote_are_named_once_and_left(tmp_path):
    # trial T4: a studio export with a blank last frame (every channel 0, the root's position too) was said to be a
    # 414 cm root jump "and stays there", a cut at the frame before it and a Shoulder_R half turn "in one frame and
    # back"; it is now named for what it is, at either end, and the take comes back as it was
    src = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_chimpira_001.bvh"
    text = src.read_text().splitlines()
    at = next(i for i, line in enumerate(text) if line.strip() == "MOTION") + 1
    F = int(text[at].split()[1])
    blank = " ".join(["0"] * len(text[at + 2].split()))
    text[at] = f"Frames:\t{F + 2}"
    path = tmp_path / "blank_ends.bvh"
    path.write_text("\n".join(text[:at + 2] + [blank] + text[at + 2:at + 2 + F] + [blank]) + "\n")
    take = mocapkit.load(path)
    assert find_zeros(take)[1] == ()
    res = clean(take, steps="detect,repair")  # the steps that read the take's breaks
    lines = res.summary()
    assert lines[:2] == ["frame 0: every channel 0 (a blank frame an exporter prepended); left as it is",
                         f"frame {F + 1}: every channel 0 (a blank frame an exporter appended); left as it is"]
    said = " ".join(lines)
    assert not any(w in said for w in ("jumps", "a cut", "flip", "turn-over", "and back")), said
    assert not res.changed.any() and not res.flags.any()
    assert np.array_equal(res.motion.rotations, take.rotations)
