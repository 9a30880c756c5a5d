"""Turn-overs on real takes: a thigh turned 180 deg about itself and back, a thumb's constant half turn."""

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning.ssa.cues import CAUSES, cause_names
from mocapkit.cleaning.ssa.flips import turned_back

FLIP_BIT = 1 << [name for name, _ in CAUSES].index("flip")


def _steps(q):
    return np.degrees(R.geodesic_angle(q[:-1], q[1:]))


def _load(shared_data, name):
    return mocapkit.load(shared_data / "hdm05_asfamc" / name)


def test_a_thigh_turned_over_and_back_is_turned_back_exactly_and_named(shared_data):
    """HDM05 dg_squat1Reps_025: lfemur and ltibia turned 180 deg about themselves over frames 78-82 (ltibia's AMC
    value 203 deg against the ASF's 170). clean turns both back on those frames only, the hip, knee and ankle
    where they were, the knee inside its limit, and names it in the record's notes and causes."""
    m = _load(shared_data, "HDM_dg_squat1Reps_025_120.amc")
    res = mocapkit.clean(m)
    sk = m.skeleton
    fem, tib, foot = sk.index("lfemur"), sk.index("ltibia"), sk.index("lfoot")
    changed = res.changed
    assert changed[78:83, [fem, tib]].all()
    assert changed.sum() == 10  # nothing else in the take
    out = res.motion
    for j in (fem, tib):
        assert _steps(out.rotations[:, j])[77] < 5 and _steps(out.rotations[:, j])[82] < 5
    p0, p1 = m.global_positions(), out.global_positions()
    assert np.allclose(p1[:, [fem, tib, foot]], p0[:, [fem, tib, foot]], atol=1e-9)
    col = out.channel_names().index("ltibia.Xrotation")
    lo, hi = sk.limits[tib][0]
    v0 = m.channel_values()[78:83, col]
    assert ((v0 < lo) | (v0 > hi)).all()  # the take's knee bent backwards, past its limits
    assert (out.channel_values()[78:83, col] >= lo).all() and (out.channel_values()[78:83, col] <= hi).all()
    assert (res.causes[78:83, fem] & FLIP_BIT).all() and res.flags[78:83, [fem, tib]].all()
    assert any("lfemur (with ltibia) turned 180 deg about itself, frames 78-82, positions unchanged: turned back exactly"
               in n for n in res.notes)


def test_a_turn_over_whose_turn_back_would_move_the_toes_is_named_and_left(shared_data):
    """HDM05 dg_squat1Reps_026: the right leg's foot makes its own 52 deg turn as it turns back at frame 100, so
    turning the thigh back there would step the toes 13 cm: left bit for bit, flagged and named; the left leg
    (frames 81-100) is turned back."""
    m = _load(shared_data, "HDM_dg_squat1Reps_026_120.amc")
    res = mocapkit.clean(m)
    sk = m.skeleton
    for name in ("rfemur", "rtibia"):
        j = sk.index(name)
        assert np.array_equal(res.motion.rotations[:, j], m.rotations[:, j]), name
        assert res.flags[80:100, j].all() and (res.causes[80:100, j] & FLIP_BIT).all()
    assert any(n.startswith("flip: rfemur (with rtibia) turned 180 deg about itself, frames 80-99, positions unchanged: "
                            "left as is (rtoes_end would step") for n in res.notes)
    lf = sk.index("lfemur")
    assert res.changed[81:101, lf].all() and _steps(res.motion.rotations[:, lf]).max() < 20


@pytest.mark.parametrize("name, joint, first, last", [
    ("HDM_dg_squat1Reps_030_120.amc", "rfemur", 78, 96),
    ("HDM_bk_depositFloorR_007_120.amc", "rfemur", 138, 205),
    ("HDM_dg_depositFloorR_018_120.amc", "rfemur", 213, 231),
    ("HDM_bk_depositFloorR_011_120.amc", "rfemur", 121, 160),
])
def test_turn_overs_of_other_takes_are_turned_back_with_the_knee_in_its_limits(shared_data, name, joint, first, last):
    m = _load(shared_data, name)
    out, changed, flagged, flips = turned_back(m)
    [flip] = flips
    assert (flip.joints[0], flip.first, flip.last, flip.fixed) == (joint, first, last, True)
    j = m.skeleton.index(joint)
    rows = np.flatnonzero(changed.any(axis=1))
    assert rows.min() == first and rows.max() == last and np.array_equal(changed, flagged)
    tib = m.skeleton.index(joint[0] + "tibia")
    lo, hi = m.skeleton.limits[tib][0]
    knee = out.channel_values()[:, out.channel_names().index(f"{joint[0]}tibia.Xrotation")]
    assert lo <= knee[first : last + 1].min() and knee[first : last + 1].max() <= hi
    assert _steps(out.rotations[:, j])[[first - 1, last]].max() < 5
    kept = ~changed
    assert np.array_equal(np.asarray(out.rotations)[kept], np.asarray(m.rotations)[kept])


def test_a_thumbs_constant_half_turn_is_undone_on_its_channel(shared_data):
    """HDM05 bd_throwBasketball_002: rthumb's AMC rz jumps by 180 deg at frame 102 and back at 142. clean (the
    thumb not analysed by self-similarity) turns it back exactly: rz 180 deg back, rx as it was, nothing else."""
    m = _load(shared_data, "HDM_bd_throwBasketball_002_120.amc")
    res = mocapkit.clean(m)
    j = m.skeleton.index("rthumb")
    assert np.array_equal(np.flatnonzero(res.changed.any(axis=1)), np.arange(102, 142))
    assert res.changed[:, j].sum() == 40 and res.changed.sum() == 40
    names = m.channel_names()
    z, x = names.index("rthumb.Zrotation"), names.index("rthumb.Xrotation")
    before, after = m.channel_values(), res.motion.channel_values()
    dz = (after[102:142, z] - before[102:142, z] + 180.0) % 360.0 - 180.0
    assert np.allclose(np.abs(dz), 180.0, atol=1e-6) and np.allclose(after[102:142, x], before[102:142, x], atol=1e-6)
    assert _steps(res.motion.rotations[:, j])[[101, 141]].max() < 10
    assert any("rthumb turned 180 deg and back, frames 102-141 (a constant half turn): turned back exactly" in n
               for n in res.notes)


def test_a_take_with_no_turn_over_comes_back_as_it_is(shared_data):
    m = _load(shared_data, "HDM_bd_squat1Reps_001_120.amc")
    leaves = [n for n in m.skeleton.joint_names if "thumb" in n or "fingers" in n]
    out, changed, flagged, flips = turned_back(m, leaves)
    assert out is m and not changed.any() and not flagged.any() and flips == ()


def test_the_review_mode_names_and_flags_the_turn_overs_clean_turns_back_and_changes_nothing():
    """The bundled CMU 131_01 turns its RThumb a constant half turn on frames 178-191 (clean turns it back) and on
    237-242 (left: its two steps disagree). The review mode (steps="detect") said neither: a person reviewing the take
    saw nothing there. It now names both in clean's words on clean's frames, flags their cells (cause flip) for the
    report's list, says why each is left, and returns the take bit for bit."""
    from mocapkit.cleaning.flags_left import flag_outcomes

    take = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[150:260]  # the two turn-overs at frames 28-41, 87-92
    review, cleaned = mocapkit.clean(take, steps="detect"), mocapkit.clean(take, steps="detect,repair")
    said = {n for n in cleaned.notes if n.startswith("flip: ")}
    assert said == {"flip: RThumb turned 180 deg and back, frames 28-41 (a constant half turn): turned back exactly",
                    "flip: RThumb turned 180 deg and back, frames 87-92 (a constant half turn): left as is (the two "
                    "steps' offsets differ by 23 deg)"}
    assert {n for n in review.notes if n.startswith("flip: ")} == {
        n.replace(": turned back exactly", ": left as is (repair would turn it back exactly)") for n in said}
    assert any(line.startswith("note: flip: RThumb") for line in review.summary())
    j = take.skeleton.index("RThumb")
    assert np.array_equal(review.flags, cleaned.flags) and review.flags[:, j].sum() == 20
    assert (review.causes[28:42, j] & FLIP_BIT).all() and (review.causes[87:93, j] & FLIP_BIT).all()
    assert np.array_equal(review.motion.rotations, take.rotations) and not review.changed.any()
    left = {(f["first"], f["last"]): f["left"] for f in flag_outcomes(review) if f["joint"] == "RThumb"}
    assert left[(28, 41)].endswith("not turned back (repair would turn it back exactly)")
    assert left[(87, 92)].endswith("not turned back (the two steps' offsets differ by 23 deg)")


def test_the_foots_own_steps_at_a_thigh_turn_over_go_with_it(shared_data):
    """HDM05 bk_depositFloorR_009: rfemur and rtibia turned over about themselves over frames 163-188, and the right
    foot, turning over with them, steps 29 deg into frame 163 and 26 deg out of frame 188 in its own channels. The
    chain was turned back and the foot kept: its toes then jumped 0.21 units at both frames (0.07 a frame beside)
    and the break rule flagged the foot. Its steps are taken away with the turn-over; only it and the chain change."""
    m = mocapkit.load(shared_data / "hdm05_asfamc" / "HDM_bk_depositFloorR_009_120.amc")
    out, changed, flagged, flips = turned_back(m)
    [flip] = flips
    assert (flip.joints, flip.first, flip.last, flip.fixed) == (("rfemur", "rtibia"), 163, 188, True)
    assert str(flip).endswith("turned back exactly, rfoot's own steps at both ends taken away with it")
    sk = m.skeleton
    foot = sk.index("rfoot")
    assert _steps(np.asarray(m.rotations)[:, foot])[[162, 188]].min() > 25
    assert _steps(out.rotations[:, foot])[[162, 188]].max() < 3
    assert np.flatnonzero(changed.any(axis=0)).tolist() == sorted(sk.index(n) for n in ("rfemur", "rtibia", "rfoot"))
    assert np.flatnonzero(changed[:, foot]).tolist() == list(range(163, 189))
    toes = sk.index("rtoes")
    step = np.linalg.norm(np.diff(out.global_positions()[:, toes], axis=0), axis=-1)
    assert step[[162, 188]].max() < 2 * step[[160, 161, 189, 190]].max()


def test_a_take_with_position_channels_on_every_joint_is_turned_back_as_without_them():
    """LaFAN1 and Unreal exports carry position channels below the root (every joint's, or the pelvis's under
    ``root``). The check that the file's channels hold a turn-back read them back without animated offsets and
    raised SkeletonError, so ``mocapkit clean`` failed on such a take wherever it had a turn-over (2 of 33 HDM05 and
    Bandai takes on an Unreal mannequin rig). The bundled 131_01's RThumb half turns, on the same rig with position
    channels (their values the offsets) on every joint, are turned back (or left) as on the take without them."""
    import dataclasses

    take = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[150:260]
    sk = take.skeleton
    pos = ("Xposition", "Yposition", "Zposition")
    channels = tuple(c if c[0].endswith("position") else pos + c for c in sk.channels)
    offsets = np.broadcast_to(sk.offsets, (take.num_frames, sk.num_joints, 3)).copy()
    offsets[:, 0] = take.root_positions
    lafan = dataclasses.replace(take, skeleton=dataclasses.replace(sk, channels=channels), translations=offsets)
    out, changed, _, flips = turned_back(take, ["RThumb", "LThumb"])
    out2, changed2, _, flips2 = turned_back(lafan, ["RThumb", "LThumb"])
    assert [f.fixed for f in flips] == [True, False] and flips2 == flips
    assert np.array_equal(changed2, changed) and np.array_equal(out2.rotations, out.rotations)


def test_a_helper_bone_beside_the_pelvis_is_not_turned_back_as_a_leaf():
    """An Unreal mannequin's ``ik_hand_r`` hangs from ``root`` beside the pelvis and copies the hand's world
    rotation (here the bundled 131_01's RThumb, which turns a constant half turn on frames 28-41). The leaf rule
    turned the helper back on its own (HDM05 dg_squat1Reps_027 on that rig: ``ik_foot_l`` 13 cells changed
    while the foot it copies was left): now only the body's joints are looked at, and RThumb is turned back as
    before."""
    from mocapkit.cleaning.whole_take import body_joints, turn_overs
    from mocapkit.motion import Motion, Skeleton

    take = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[150:260]
    sk, F = take.skeleton, take.num_frames
    g, p = take.global_transforms()
    thumb = sk.index("RThumb")
    pos = ("Xposition", "Yposition", "Zposition")
    rig = Skeleton(("root",) + sk.joint_names + ("ik_hand_r",), np.r_[-1, np.asarray(sk.parents) + 1, 0],
                   np.r_[[np.zeros(3)], sk.offsets, [np.zeros(3)]], np.asarray(sk.end_site_parents) + 1,
                   sk.end_site_offsets, channels=(pos + ("Zrotation", "Yrotation", "Xrotation"),) +
                   ((pos + sk.channels[0][3:]),) + sk.channels[1:] + (pos + ("Zrotation", "Yrotation", "Xrotation"),))
    rot = np.concatenate([np.broadcast_to(R.identity(), (F, 1, 4)), take.rotations, g[:, thumb : thumb + 1]], axis=1)
    tr = np.concatenate([np.zeros((F, 1, 3)), np.broadcast_to(sk.offsets, (F, sk.num_joints, 3)), p[:, None, thumb]],
                        axis=1)
    tr[:, 1] = take.root_positions
    ue = Motion(rig, rot, np.zeros((F, 3)), take.fps, translations=tr)
    assert np.allclose(ue.global_positions()[:, -1], p[:, thumb])
    assert body_joints(rig) == list(range(1, rig.num_joints - 1))
    found = turn_overs(ue, (0, F), ["RThumb", "ik_hand_r"])
    changed = np.flatnonzero(found.turned.any(axis=0))
    assert changed.tolist() == [rig.index("RThumb")] and np.flatnonzero(found.turned[:, changed[0]]).tolist() == list(
        range(28, 42))


def test_a_leaf_turned_back_by_measured_offsets_is_said_as_such_not_exactly(shared_data):
    """CMU 131_03's RThumb frames 478-481: the line said "turned 180 deg and back (a constant half turn): turned back
    exactly", but the change was 158-164 deg (the offsets measured at both steps, slerped). Each leaf's line now says
    what was done: "exactly" only where every cell was turned by a half turn, else the measured range."""
    import re

    m = mocapkit.load(shared_data / "cmu_bvh" / "131_03.bvh")
    out, changed, _, flips = turned_back(m, ["RThumb"])
    j = m.skeleton.index("RThumb")
    moved = np.degrees(R.geodesic_angle(m.rotations[:, j], out.rotations[:, j]))
    fixed = [f for f in flips if f.fixed]
    assert len(fixed) >= 5 and any(f.first == 478 and f.last == 481 for f in fixed)
    for f in fixed:
        run, line = moved[f.first : f.last + 1], str(f)
        if "turned back exactly" in line:
            assert run.min() > 179.99 and "a constant half turn" in line, line
        else:
            lo, hi = map(int, re.search(r"\((\d+)-(\d+) deg, slerped", line).groups())
            assert (lo, hi) == (round(run.min()), round(run.max())) and run.min() < 179.0, line
    assert str(next(f for f in fixed if f.first == 478)) == (
        "RThumb turned about a half turn and back, frames 478-481: turned back by the offsets measured at its two "
        "steps (158-164 deg, slerped across the run)")


def test_a_turn_over_lasting_to_the_takes_end_is_not_said_to_turn_back():
    """Trial T4: a turn-over with no turn back before the take's end was said "turned 180 deg in one frame and back"
    (the flag's cause), "... and back, frame 195 ..." and "a half turn in one frame and back, not turned back" beside
    "(it lasts to the end of the take)". The bundled CMU 131_01 cut at frame 186 ends inside RThumb's constant half
    turn of frames 178-191: every line about it now says it turns, none that it turns back."""
    from mocapkit.cleaning.flags_left import flag_outcomes

    take = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[100:186]  # the half turn from frame 78 to the end
    review = mocapkit.clean(take, steps="detect")
    said = [n for n in review.notes if n.startswith("flip: ")]
    assert said == ["flip: RThumb turned 180 deg to the take's end, frames 78-85 (a constant half turn): left as is "
                    "(it lasts to the end of the take)"]
    left = [f["left"] for f in flag_outcomes(review) if f["joint"] == "RThumb"]
    assert left == ["left as it was: a half turn in one frame, not turned back (it lasts to the end of the take)"]
    j = take.skeleton.index("RThumb")
    assert cause_names(review.causes[78:, j]) == ["turned 180 deg in one frame (a turn-over, mocapkit.cleaning.ssa.flips)"]
    assert np.array_equal(review.motion.rotations, take.rotations)


def test_a_long_takes_turn_overs_are_each_checked_on_their_own_frames_not_on_the_whole_take(monkeypatch):
    """Each turn-over was repaired on a copy of the whole take and checked on a Motion of the whole take (its
    quaternions all validated): the cost of a turn-over grew with the take, and as turn-overs come with its
    length, the step with the square of it (a 9-minute HDM05 take's 64: 6.7 s of CPU, now 3.3 s).
    Now each reads a few frames around its run. The bundled 131_01's two RThumb half turns, six times over:
    the same outcome at each copy as on one (turned back, left), bit for bit, and no Motion of the take's
    length built but the one returned."""
    from mocapkit.motion import Motion, concatenate

    one = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[150:260]
    take = concatenate([one] * 6)
    F, n = take.num_frames, one.num_frames
    built = []
    post_init = Motion.__post_init__

    def counting(self):
        built.append(np.shape(self.rotations)[0])
        post_init(self)

    ref, ref_changed, _, ref_flips = turned_back(one, ["RThumb", "LThumb"])
    monkeypatch.setattr(Motion, "__post_init__", counting)
    out, changed, _, flips = turned_back(take, ["RThumb", "LThumb"])
    monkeypatch.undo()
    assert [f.fixed for f in ref_flips] == [True, False]
    assert [(f.first, f.last, f.fixed) for f in flips] == [(f.first + k * n, f.last + k * n, f.fixed)
                                                         for k in range(6) for f in ref_flips]
    assert np.array_equal(changed, np.tile(ref_changed, (6, 1)))
    assert np.array_equal(out.rotations, np.tile(ref.rotations, (6, 1, 1)))
    assert built.count(F) == 1  # the take returned; before: one per turn-over checked as well (7)
