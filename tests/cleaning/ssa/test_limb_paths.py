"""A repair that turns a joint half a turn is judged by where it puts the limb (cleaning/ssa/limb_paths.py)."""

from __future__ import annotations

import numpy as np
import pytest

from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa.limb_paths import below, joined_positions, limb_left, limb_runs


def test_below_names_the_joints_and_end_sites_a_joint_moves():
    parents = np.array([-1, 0, 1, 2, 0, 4])  # root, thigh, shin, foot; other thigh, shin
    sites = np.array([3, 5])  # an end site under each foot... and under the other shin
    assert below(parents, sites, 1).tolist() == [2, 3, 6]  # shin, foot, the foot's end site (row J + 0)
    assert below(parents, sites, 3).tolist() == [6]
    assert below(parents, sites, 0).tolist() == [1, 2, 3, 4, 5, 6, 7]


def test_the_joined_path_of_a_steady_motion_is_the_motion():
    t = np.arange(40, dtype=float)
    p = np.stack([np.stack([t, 0.5 * t, np.zeros_like(t)], axis=-1)] * 2, axis=1)  # (40, 2, 3) a steady walk
    path = joined_positions(p, 10, 20)
    assert path.shape == (10, 2, 3) and np.allclose(path, p[10:20])
    assert joined_positions(p, 1, 10) is None and joined_positions(p, 30, 39) is None


def test_a_half_turn_that_takes_the_limb_off_its_path_is_left_and_one_that_puts_it_back_kept():
    """A thigh turning half a turn about the vertical over frames 20-39 where the capture's shin is bent with it (the
    limb stays put): repaired back to no turn, the foot swings away (left); the same half turn as an error (the
    limb off), repaired, puts the foot back (kept). A turn under HALF_TURN_DEG is not judged."""
    F = 60
    changed = np.zeros(F, dtype=bool)
    changed[20:40] = True
    still = np.tile(R.quaternion_from_axis_angle([0.0, 0.0, 1.0], 0.0), (F, 1))
    half = np.array(still)
    half[20:40] = R.quaternion_from_axis_angle([0.0, 0.0, 1.0], np.pi)
    foot = np.tile([[1.0, 0.0, 0.0]], (F, 1, 1))  # the capture's foot, in the thigh's parent's frame
    swung = np.array(foot)
    swung[20:40] = [[-1.0, 0.0, 0.0]]  # where the thigh's half turn puts it with the shin as captured
    bad = limb_runs(half, still, changed, foot, swung)  # the capture's half turn taken away
    assert [(s, e) for s, e, _ in bad] == [(20, 40)] and "limb" in bad[0][2]
    assert limb_runs(still, half, changed, swung, foot) == []  # an error's half turn taken away
    small = np.array(still)
    small[20:40] = R.quaternion_from_axis_angle([0.0, 0.0, 1.0], np.radians(60.0))
    assert limb_runs(still, small, changed, foot, swung) == []  # not half a turn: the rotation rules judge it
    assert limb_runs(half, still, changed, foot, foot) == []  # a turn about the bone itself: nothing below moves


def test_the_runs_below_a_limb_left_within_its_frames_are_left():
    parents = np.array([-1, 0, 1, 2])
    changed = np.zeros((50, 4), dtype=bool)
    changed[10:30, 1] = changed[15:25, 2] = changed[5:12, 3] = True
    replaced = np.array(changed)
    got = limb_left(changed, [(1, 10, 30)], parents, replaced)
    assert [(k, a, b) for k, a, b, _ in got] == [(2, 15, 25)]  # the shin's run within; the foot's runs past it
    replaced[20, 2] = False  # put back in part by the take's own motion: not left
    assert limb_left(changed, [(1, 10, 30)], parents, replaced) == []


def test_a_half_turn_onto_the_legs_other_solution_is_left(hdm05_errors):
    """HDM05 bk depositFloorR 007 with real-style errors (seed 1001): the clean take holds the solver's other solution
    of the right leg over frames 138-205 (the thigh half a turn about its bone, the knee bent past its limit); the
    repair took it for an offset and turned the thigh back (23.5 -> 127.3 deg off the clean take, the foot 5-10
    units off), and repaired the knee inside it (0.0 -> 33.7). Both are given back as they came, named."""
    ref, bad, mask, det = hdm05_errors("HDM_bk_depositFloorR_007_120.amc", 1001)
    off = lambda m, k, s, e: np.degrees(R.geodesic_angle(m.rotations[s:e, k], ref.rotations[s:e, k])).mean()  # noqa
    unguarded, _ = ssa.repair_with_left(bad, det, None, foot_skate=False, guard=False)
    new, left = ssa.repair_with_left(bad, det, None, foot_skate=False)
    for name, (a, b), why, worse in (("rfemur", (138, 214), "limb", 30.0), ("rtibia", (173, 206), "above it", 10.0)):
        k = ref.skeleton.index(name)
        assert off(unguarded, k, a, b) > off(bad, k, a, b) + worse
        assert np.array_equal(new.rotations[a:b, k], bad.rotations[a:b, k])
        assert any(r.joint == name and (r.start, r.end) == (a, b) and why in r.reason for r in left)


def test_a_swap_ending_on_the_legs_other_solution_is_exchanged_back_by_the_limbs_positions(hdm05_errors):
    """HDM05 dg squat1Reps 025 with real-style errors (seed 1001): the thighs swapped over frames 62-78, the left one's
    next frame on the solver's other solution. Its bridge turned the thigh half a turn to meet it (37.5 -> 83.5 deg
    off the clean take); the exchange's rotation joins fail at that frame, which holds the solver's step, but both
    limbs' positions come nearer their joined paths exchanged: both thighs are put back as captured."""
    ref, bad, mask, det = hdm05_errors("HDM_dg_squat1Reps_025_120.amc", 1001)
    thighs = [ref.skeleton.index("lfemur"), ref.skeleton.index("rfemur")]
    assert mask[62:79, thighs].all()
    unguarded, _ = ssa.repair_with_left(bad, det, None, foot_skate=False, guard=False)
    off = lambda m: np.degrees(R.geodesic_angle(m.rotations[62:79, thighs], ref.rotations[62:79, thighs]))  # noqa
    assert off(unguarded)[:, 0].mean() > off(bad)[:, 0].mean() + 30.0
    new, left = ssa.repair_with_left(bad, det, None, foot_skate=False)
    assert off(new).max() < 0.01
    assert not any(r.joint in ("lfemur", "rfemur") and r.start < 79 and r.end > 62 for r in left)
