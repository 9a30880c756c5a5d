"""Channels written as 0 where the capture lost data (mocapkit.cleaning.zeros) and what clean does with them."""

from __future__ import annotations

import dataclasses

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
