"""The repair guard (cleaning/ssa/guard.py): a repaired run the take shows to be worse is left as it was, and named."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, samples
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.pipeline import clean
from mocapkit.cleaning.whole_take import detect_take, take_params
from mocapkit.cleaning.ssa.guard import (angular_acceleration, end_roughness, guard_joint, held, held_guess_runs,
                                         joined_path, margin_runs, on_path_ends, pair_left, rougher_end, roughness)


def _turn(angles_deg: np.ndarray) -> np.ndarray:
    """(F, 4): a joint turning about z by ``angles_deg`` (F,)."""
    return R.rotvec_to_quaternion(np.radians(angles_deg)[:, None] * np.array([0.0, 0.0, 1.0]))


def test_angular_acceleration_of_a_steady_turn_is_zero_and_of_a_step_is_its_size():
    steady = _turn(np.arange(20) * 3.0)
    assert np.allclose(angular_acceleration(steady), 0.0, atol=1e-9)
    step = _turn(np.where(np.arange(20) >= 10, 40.0, 0.0))
    acc = angular_acceleration(step)
    assert acc[9] == pytest.approx(40.0) and acc[10] == pytest.approx(40.0)
    assert roughness(acc, 12, 15) == pytest.approx(0.0, abs=1e-9) and roughness(acc, 11, 15) == pytest.approx(40.0)


def test_a_repair_that_puts_a_step_into_a_smooth_turn_is_left():
    F = 60
    orig = _turn(np.cumsum(np.sin(np.linspace(0, np.pi, F)) * 10.0))  # a fast real turn, smooth
    out = np.array(orig)
    out[25:31] = orig[24]  # "repaired" by holding: two steps
    changed = np.zeros(F, dtype=bool)
    changed[25:31] = True
    bad = guard_joint(orig, out, changed, np.zeros(F, dtype=bool), changed)
    assert [(s, e) for s, e, _ in bad] == [(25, 31)] and "less smoothly" in bad[0][2]


def test_a_repair_that_takes_a_step_away_is_kept():
    F = 60
    truth = _turn(np.arange(F) * 2.0)
    orig = np.array(truth)
    orig[20:30] = R.quaternion_multiply(_turn(np.full(10, 60.0)), truth[20:30])  # an offset, a step at each end
    changed = np.zeros(F, dtype=bool)
    changed[20:30] = True
    assert guard_joint(orig, truth, changed, np.zeros(F, dtype=bool), changed) == []
    # bridged: the slerp between the ends turns as the joint does: kept
    assert guard_joint(orig, truth, changed, changed, changed) == []


def test_a_run_whose_exit_gains_a_step_is_left_though_its_entry_had_a_larger_one():
    F = 60
    orig = _turn(np.where(np.arange(F) >= 20, 0.0, 30.0) + np.arange(F) * 1.0)  # a 30-degree step at frame 20
    out = np.array(orig)
    out[20:30] = R.quaternion_multiply(_turn(np.linspace(20.0, 15.0, 10)), orig[20:30])  # off the take, then a step back
    changed = np.zeros(F, dtype=bool)
    changed[20:30] = True
    acc_in, acc_out = angular_acceleration(orig), angular_acceleration(out)
    assert roughness(acc_out, 20, 30) < roughness(acc_in, 20, 30)  # the whole-run rule alone keeps it
    assert end_roughness(acc_in, 20, 30)[1] < 0.5 and end_roughness(acc_out, 20, 30)[1] > 10.0
    assert "exit" in rougher_end(acc_in, acc_out, 20, 30)
    bad = guard_joint(orig, out, changed, np.zeros(F, dtype=bool), changed)
    assert [(s, e) for s, e, _ in bad] == [(20, 30)] and "exit" in bad[0][2]


def test_a_held_run_is_not_judged_by_its_ends():
    """A frozen channel joins the take smoothly where it starts holding; its repair, moving again, cannot."""
    F = 60
    truth = _turn(np.arange(F) * 1.0)
    orig = np.array(truth)
    orig[20:30] = truth[19]  # frozen: a step of 10 degrees back to the motion at frame 30
    changed = np.zeros(F, dtype=bool)
    changed[20:30] = True
    out = np.array(truth)
    out[20:30] = R.quaternion_multiply(_turn(np.full(10, 8.0)), truth[20:30])  # the word's motion, 8 degrees off
    acc_in, acc_out = angular_acceleration(orig), angular_acceleration(out)
    assert held(orig, 20, 30) and not held(truth, 20, 30)
    assert rougher_end(acc_in, acc_out, 20, 30) is not None  # its entry gains a step ...
    assert guard_joint(orig, out, changed, np.zeros(F, dtype=bool), changed) == []  # ... but a freeze's repair is kept


def test_the_path_the_joins_imply_is_a_steady_turn_where_the_joint_turns_steadily():
    q = _turn(np.arange(40) * 2.0)
    frozen = np.array(q)
    frozen[10:20] = q[9]  # the values inside the run are never read
    path = joined_path(frozen, 10, 20)
    assert path.shape == (10, 4)
    assert np.degrees(R.geodesic_angle(path, q[10:20])).max() < 1e-6
    # it leaves at the turn into the run and arrives with the turn out of it: a swing out and back is bent, not a chord
    swing = _turn(np.concatenate([np.arange(10) * 2.0, 18.0 - np.arange(30) * 2.0]))  # turns back at frame 9
    bent = np.degrees(R.quaternion_to_rotvec(joined_path(swing, 5, 20))[:, 2])
    assert bent.max() > 10.0 and bent[-1] < 0.0  # on past its last sample, then back to frame 20's -4 deg
    assert joined_path(q, 1, 10) is None and joined_path(q, 30, 39) is None  # no turn beyond the take to read


def test_a_guess_across_a_freeze_is_kept_only_nearer_the_joined_path_than_the_hold():
    """A joint held still over frames 20-39 (its input) while it swings 24 deg one way and back: a bridge between the
    run's ends turning the other way is left; on a steady turn the bridge is the turn itself and is kept."""
    F = 80
    t = np.arange(F, dtype=float)
    truth_deg = np.where((t >= 14) & (t < 46), -24.0 * np.sin(np.pi * (t - 14) / 32.0), 0.0) + 0.5 * t
    orig = _turn(truth_deg)
    orig[20:40] = orig[19]  # frozen at frame 19's sample
    changed = np.zeros(F, dtype=bool)
    changed[20:40] = True
    out = np.array(orig)
    out[20:40] = R.slerp(orig[19], orig[40], (np.arange(20, 40) - 19) / 21.0)
    err = lambda x: np.degrees(R.geodesic_angle(x[20:40], _turn(truth_deg)[20:40])).mean()  # noqa: E731
    assert err(out) > err(orig) + 1.0  # the bridge lands further from the swing than the hold does
    assert guard_joint(orig, out, changed, changed, changed) == []  # smooth and slow: the join rules keep it
    bad = held_guess_runs(orig, out, changed, changed)
    assert [(s, e) for s, e, _ in bad] == [(20, 40)] and "freeze" in bad[0][2]
    assert [(s, e) for s, e, _ in held_guess_runs(orig, out, changed, changed & (t < 30))] == [(20, 40)]  # in part
    assert held_guess_runs(orig, out, changed, np.zeros(F, dtype=bool)) == []  # all from a repeat: not judged
    steady = _turn(0.5 * t)
    held_steady = np.array(steady)
    held_steady[20:40] = steady[19]
    bridge = np.array(held_steady)
    bridge[20:40] = R.slerp(steady[19], steady[40], (np.arange(20, 40) - 19) / 21.0)
    assert held_guess_runs(held_steady, bridge, changed, changed) == []
    assert held_guess_runs(steady, bridge, changed, changed) == []  # not held: the join rules judge it


def test_a_bridge_that_turns_a_still_joint_fast_is_left():
    F = 60
    orig = _turn(np.where(np.arange(F) >= 30, 180.0, 0.0) + 0.01 * np.arange(F))  # still, a flip at frame 30
    changed = np.zeros(F, dtype=bool)
    changed[20:30] = True  # the clean side was flagged and bridged across the flip: 16 deg a frame
    out = np.array(orig)
    out[20:30] = R.slerp(orig[19], orig[30], ((np.arange(20, 30) - 19) / 11.0))
    bad = guard_joint(orig, out, changed, changed, changed)
    assert [(s, e) for s, e, _ in bad] == [(20, 30)] and "bridge" in bad[0][2]


def test_a_runs_end_frame_whose_break_is_its_neighbours_is_on_the_path():
    """A two-frame spike (frames 20-21) on a steady turn breaks at the frames beside it too: flagged from 19 or to
    22, that frame is on the joint's own path (its outer side turns smoothly into it); a step's first frame is not."""
    F = 40
    truth = np.arange(F) * 3.0
    spike = _turn(np.where((np.arange(F) >= 20) & (np.arange(F) < 22), truth + 50.0, truth))
    flags = np.zeros(F, dtype=bool)
    flags[19:22] = True
    assert np.flatnonzero(on_path_ends(spike, flags)).tolist() == [19]
    flags[:] = False
    flags[20:23] = True
    assert np.flatnonzero(on_path_ends(spike, flags)).tolist() == [22]
    flags[:] = False
    flags[20:22] = True  # the spike's own frames: nothing on the path
    assert not on_path_ends(spike, flags).any()
    step = _turn(np.where(np.arange(F) >= 20, truth + 50.0, truth))  # an offset from frame 20 on
    flags[:] = False
    flags[20:30] = True
    assert not on_path_ends(step, flags).any()


def test_a_partners_run_over_the_same_frames_is_left_with_the_run_left():
    changed = np.zeros((50, 3), dtype=bool)
    changed[10:20, 0] = True  # left upper arm, left by the guard
    changed[12:18, 1] = changed[30:35, 1] = True  # its partner: one run over the same frames, one elsewhere
    changed[10:20, 2] = True  # unpaired
    out = pair_left(changed, [(0, 10, 20)], np.array([1, 0, 2]))
    assert [(j, s, e) for j, s, e, _ in out] == [(1, 12, 18)] and "partner" in out[0][3]
    assert pair_left(changed, [(2, 10, 20)], np.array([1, 0, 2])) == []
    replaced = np.array(changed)
    replaced[15, 1] = False  # part of the partner's run put back by its own motion (a swap exchanged, an offset)
    assert pair_left(changed, [(0, 10, 20)], np.array([1, 0, 2]), replaced) == []
    changed[12:18, 1] = False
    changed[16:40, 1] = True  # a partner's run over other frames mostly: its own
    assert pair_left(changed, [(0, 10, 20)], np.array([1, 0, 2])) == []


def test_guard_off_repairs_as_before_and_the_guard_changes_only_the_runs_it_names(hdm05_errors):
    """HDM05 grabHighR (bk, 010) with real-style errors: a flip of the right toes (frames 46-104) had its clean
    side (23-45) flagged, which the repair bridged across the flip: 0 -> 90 degrees off the clean take."""
    ref, bad, _, det = hdm05_errors("HDM_bk_grabHighR_010_120.amc", 1001)
    old = ssa.repair(bad, det, None, foot_skate=False, guard=False)
    new, left = ssa.repair_with_left(bad, det, None, foot_skate=False)
    j = ref.skeleton.index("rtoes")
    off = np.degrees(R.geodesic_angle(old.rotations[23:46, j], ref.rotations[23:46, j])).mean()
    assert off > 45.0  # what the unguarded repair did to clean frames
    assert np.array_equal(new.rotations[23:46, j], bad.rotations[23:46, j])
    assert any(r.joint == "rtoes" and r.start <= 23 and r.end >= 46 for r in left)
    kept = np.ones(new.rotations.shape[:2], dtype=bool)
    for r in left:
        kept[r.start : r.end, ref.skeleton.index(r.joint)] = False
    assert np.array_equal(new.rotations[kept], old.rotations[kept])  # elsewhere the repair is the same


def test_flags_past_an_error_over_clean_frames_are_given_back(hdm05_errors):
    """HDM05 grabHighR (bd, 001) with real-style errors (seed 1002): the flags of the right forearm run on past the
    error's last frame (204) over frames 205-211, which the input holds as captured and which run on smoothly into
    the take; a neighbour word written there put them 8-20 degrees off the clean take with a step at frame 211."""
    ref, bad, mask, det = hdm05_errors("HDM_bd_grabHighR_001_120.amc", 1002)
    j = ref.skeleton.index("rradius")
    assert not mask[205:212, j].any()
    assert det.flags[205:212, j].all()
    new, left = ssa.repair_with_left(bad, det, None, foot_skate=False)
    assert np.array_equal(new.rotations[205:212, j], ref.rotations[205:212, j])
    assert any(r.joint == "rradius" and r.start <= 205 and r.end >= 212 and "exit" in r.reason for r in left)


@pytest.mark.parametrize("take, seed, joint, frames", [
    ("HDM_bk_rotateArmsBothBackward1Reps_005_120.amc", 1002, "rwrist", (101, 134)),
    ("HDM_bd_sneak2StepsLStart_001_120.amc", 1001, "rtoes", (102, 127)),
    ("HDM_dg_throwBasketball_007_120.amc", 1002, "rwrist", (268, 301)),
])
def test_a_freeze_s_guess_further_from_its_joined_path_is_given_back(hdm05_errors, take, seed, joint, frames):
    """HDM05 takes with real-style errors, a freeze among them: bk rotateArmsBothBackward's right wrist held over
    frames 101-133 while it turns 17 deg one way and back (bridged the other way: 9.6 -> 15.8 deg off the clean
    take), bd sneak2StepsLStart's right toes held over 102-126 (written from the take's own next moment, flexing
    where the toes extend: 10.8 -> 12.1 deg), dg throwBasketball's right wrist held over 268-300, bridged over its
    first 5 frames and written from a neighbour word over the rest (4.2 -> 7.6 deg). Each freeze is given back as it
    came, named."""
    ref, bad, mask, det = hdm05_errors(take, seed)
    j = ref.skeleton.index(joint)
    a, b = frames
    assert mask[a:b, j].all() and held(bad.rotations[:, j], a, b)
    assert det.flags[a:b, j].all()
    unguarded, _ = ssa.repair_with_left(bad, det, None, foot_skate=False, guard=False)
    off = lambda m: np.degrees(R.geodesic_angle(m.rotations[a:b, j], ref.rotations[a:b, j])).mean()  # noqa: E731
    assert off(unguarded) > off(bad) + 1.0  # the guess lands further from the clean take than the freeze
    new, left = ssa.repair_with_left(bad, det, None, foot_skate=False)
    assert np.array_equal(new.rotations[a:b, j], bad.rotations[a:b, j])
    assert any(r.joint == joint and r.start <= a and r.end >= b and "freeze" in r.reason for r in left)


def _bandai_punch():
    """Bandai Namco's dataset-1_punch_normal_002 (30 fps), from the unpacked archive (benchmarks/_bandai.py)."""
    import os
    from pathlib import Path

    root = Path(os.environ.get("MOCAPKIT_BANDAI_CACHE", Path.home() / ".cache" / "mocapkit" / "bandai_namco"))
    path = root / "dataset" / "Bandai-Namco-Research-Motiondataset-1" / "data" / "dataset-1_punch_normal_002.bvh"
    if not path.is_file():
        pytest.skip("the Bandai Namco archive is not unpacked")
    return mocapkit.load(path)


def test_a_spike_is_repaired_without_the_clean_frame_before_it():
    """`corrupt --kind spike --seed 3` of the punch: the right upper arm turned 55.8 deg at frames 251-252, flagged
    from 250, whose break is its neighbour's. Repaired from 250, the clean frame 250 came out 16.8 deg off the clean
    take and 251 37.6; the left knee's clean frame 45 (spike at 46) 8.2."""
    ref = _bandai_punch()
    bad, mask, _ = corrupt.corrupt(ref, kind="spike", seed=3)
    det = detect_take(bad, None, params=take_params()).detection
    out, left = ssa.repair_with_left(bad, det, None, foot_skate=False)
    off = np.degrees(R.geodesic_angle(out.rotations, ref.rotations))
    for name, clean, spike in (("UpperArm_R", 250, [251, 252]), ("LowerLeg_L", 45, [46])):
        j = ref.skeleton.index(name)
        assert det.flags[clean, j] and not mask[clean, j]  # flagged, uncorrupted
        assert np.array_equal(out.rotations[clean, j], bad.rotations[clean, j])
        assert any(r.joint == name and r.start == clean and "own path" in r.reason for r in left)
        assert (off[spike, j] < np.degrees(R.geodesic_angle(bad.rotations, ref.rotations))[spike, j] - 20.0).all()
    assert off[251:253, ref.skeleton.index("UpperArm_R")].max() < 35.0  # 37.6 and 25.3 before


def test_a_swap_flagged_as_two_digressions_is_put_back_as_a_swap():
    """`corrupt --kind swap --seed 7` of the punch: the upper arms swapped over frames 150-164. Detection names it a
    swap (both arms exchanged join the take at both ends, swap_exchange.joined_swaps); with that cue taken away,
    the arms are flagged by their breaks alone, as two digressions: the left arm was repaired from neighbour words
    (24.6 deg off the clean take) and the right one left holding the left arm's motion; the guard exchanges them
    back, both the clean take's. Either way the arms come back as they were captured."""
    ref = _bandai_punch()
    bad, _, _ = corrupt.corrupt(ref, kind="swap", seed=7)
    det = detect_take(bad, None, params=take_params()).detection
    arms = [ref.skeleton.index(name) for name in ("UpperArm_L", "UpperArm_R")]
    assert det.swaps[150:165, arms].all()
    digressions = dataclasses.replace(det, swaps=np.zeros_like(det.swaps))
    assert digressions.flags[150:165, arms].any(axis=0).all()
    for d in (det, digressions):
        out, _ = ssa.repair_with_left(bad, d, None, foot_skate=False)
        assert np.degrees(R.geodesic_angle(out.rotations[150:165, arms], ref.rotations[150:165, arms])).max() < 0.01


def test_a_run_written_up_to_the_take_s_first_or_last_frame_is_open_ended():
    """open_end_runs: a changed run that starts or ends the take and holds a cell written from the take's own next
    moment; a run inside the take, or one at its edge with no such cell (a repeat's, or put back), is not."""
    from mocapkit.cleaning.ssa.guard import open_end_runs

    changed = np.zeros(20, dtype=bool)
    changed[0:3] = changed[8:11] = changed[17:20] = True
    written = changed.copy()
    assert [r[:2] for r in open_end_runs(changed, written)] == [(0, 3), (17, 20)]
    assert "first frame" in open_end_runs(changed, written)[0][2]
    written[17:20] = False  # written from a repeat of the motion, or an offset taken away
    assert [r[:2] for r in open_end_runs(changed, written)] == [(0, 3)]


def test_a_clean_take_s_onset_judged_by_one_word_is_not_repaired_by_a_guess():
    """Bandai dataset-2 raise-up-both-hands_active_061 (clean, 30 fps): both arms swing out and back over frames 0-5
    before they rise; the right forearm's break at 5-6 confirms its digression from the one neighbour word its first
    frames have, the take 12 analysis frames on, and the repair wrote frames 0-5 38 deg off the capture on average
    (the left arm, making the same swing, unflagged). The flag stays; the take comes back bit-identical, the run
    named."""
    from pathlib import Path

    take = mocapkit.load(Path(__file__).parents[2] / "data" / "dataset-2_raise-up-both-hands_active_061.bvh")
    arm = take.skeleton.joint_names.index("LowerArm_R")
    det = detect_take(take, None, params=take_params()).detection
    assert det.flags[:6, arm].all()
    out, left = ssa.repair_with_left(take, det, None, foot_skate=False)
    np.testing.assert_array_equal(out.rotations, take.rotations)
    assert [(r.joint, r.start, r.end) for r in left] == [("LowerArm_R", 0, 6)]
    assert "take's first frame" in left[0].reason


def test_a_swap_flagged_on_one_side_only_is_exchanged_back_on_both():
    """A studio's trial: `corrupt --kind errors --seed 2` of the Bandai walk_normal_001 swaps the shins over frames
    45-51; detection flags the right one over 47-51 alone. Repaired from neighbour words there, the right knee came
    out at 54.5 deg (clean take 68.9) while the left kept the right one's bend (69.0, clean 27.3): both knees bent
    at once, and no tie in the report. Exchanged back, both are the clean take's, and both sides' cells are the
    record's swap (tied)."""
    import os
    from pathlib import Path

    from mocapkit.cleaning.whole_take import repair_whole

    root = Path(os.environ.get("MOCAPKIT_BANDAI_CACHE", Path.home() / ".cache" / "mocapkit" / "bandai_namco"))
    path = root / "dataset" / "Bandai-Namco-Research-Motiondataset-1" / "data" / "dataset-1_walk_normal_001.bvh"
    if not path.is_file():
        pytest.skip("the Bandai Namco archive is not unpacked")
    ref = mocapkit.load(path)
    bad, _, _ = corrupt.corrupt(ref, kind="errors", seed=2)
    det = detect_take(bad, None, params=take_params()).detection
    knees = [ref.skeleton.index("LowerLeg_L"), ref.skeleton.index("LowerLeg_R")]
    assert not det.flags[45:52, knees[0]].any() and not det.swaps[45:52, knees].any()
    done = repair_whole(bad, det)
    off = np.degrees(R.geodesic_angle(done.motion.rotations[45:52, knees], ref.rotations[45:52, knees]))
    assert off.max() < 0.01
    assert done.swapped[45:52, knees].all() and not done.swapped[:45].any() and not done.swapped[52:].any()


def test_a_run_within_the_margin_beside_an_error_put_back_by_the_take_is_left():
    """A swap exchanged back over frames 20-29 (``undone``); runs replaced from neighbour words over frames 31-32 and
    17-18 lie within a 2-frame margin (and the break's frame) beside it and are left; one over 36-39, or one put
    back in part by the take's own motion, is not judged so."""
    F = 60
    undone = np.zeros(F, dtype=bool)
    undone[20:30] = True
    changed = np.array(undone)
    changed[31:33] = changed[17:19] = changed[36:40] = True
    replaced = changed & ~undone
    got = margin_runs(changed, replaced, undone, 2)
    assert [(s, e) for s, e, _ in got] == [(17, 19), (31, 33)] and "margin" in got[0][2]
    assert margin_runs(changed, replaced, undone, 0) == []
    replaced[31] = False  # put back in part by the take's own motion
    assert [(s, e) for s, e, _ in margin_runs(changed, replaced, undone, 2)] == [(17, 19)]


def test_clean_frames_past_a_swap_exchanged_back_are_left_as_captured(hdm05_errors):
    """Frames the flags took in past a swap the exchange put back, clean and written from a neighbour word: Bandai
    Namco's dataset-2_walk_active_013 (``corrupt --kind errors --seed 2001``), the forearms swapped over frames 52-56,
    the left one's 58-59 (0.0 -> 1.1 deg off the clean take); HDM05 bd jogLeftCircle4StepsRstart 001 (seed 1002), the
    right upper arm's frame 81 past its swap over 14-74 (0.0 -> 1.0). Each is left as captured, named, and the
    swap is still put back."""
    import os
    from pathlib import Path

    root = Path(os.environ.get("MOCAPKIT_BANDAI_CACHE", Path.home() / ".cache" / "mocapkit" / "bandai_namco"))
    path = root / "dataset" / "Bandai-Namco-Research-Motiondataset-2" / "data" / "dataset-2_walk_active_013.bvh"
    cases = []
    if path.is_file():
        ref = mocapkit.load(path)
        bad, mask, _ = corrupt.corrupt(ref, kind="errors", seed=2001)
        cases.append((ref, bad, mask, detect_take(bad, None, params=take_params()).detection, "LowerArm_L", (58, 60),
                      (52, 57)))
    try:
        cases.append(hdm05_errors("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", 1002) + ("rhumerus", (81, 82),
                                                                                           (14, 75)))
    except pytest.skip.Exception:
        pass
    if not cases:
        pytest.skip("neither the Bandai Namco archive nor the HDM05 take is at hand")
    for ref, bad, mask, det, joint, (a, b), (s, e) in cases:
        j = ref.skeleton.index(joint)
        assert not mask[a:b, j].any() and det.flags[a:b, j].all() and det.swaps[s:e, j].all()
        unguarded, _ = ssa.repair_with_left(bad, det, None, foot_skate=False, guard=False)
        assert np.degrees(R.geodesic_angle(unguarded.rotations[a:b, j], ref.rotations[a:b, j])).max() > 0.5
        new, left = ssa.repair_with_left(bad, det, None, foot_skate=False)
        assert np.array_equal(new.rotations[a:b, j], ref.rotations[a:b, j])
        assert any(r.joint == joint and (r.start, r.end) == (a, b) and "margin" in r.reason for r in left)
        assert np.degrees(R.geodesic_angle(new.rotations[s:e, j], ref.rotations[s:e, j])).max() < 0.01
