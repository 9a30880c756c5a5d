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


@pytest.mark.parametrize("take, seed, joint, frames, below_joint", [
    ("HDM_dg_squat1Reps_025_120.amc", 1001, "lfemur", (62, 79), None),
    ("HDM_bk_depositFloorR_007_120.amc", 1001, "rfemur", (138, 214), ("rtibia", 173, 206)),
])
def test_a_half_turn_onto_the_legs_other_solution_is_left(hdm05_errors, take, seed, joint, frames, below_joint):
    """HDM05 takes with real-style errors whose clean take holds the solver's other solution of a leg (the thigh
    half a turn about its bone, the knee bent past its limit): dg squat1Reps' left thigh swap (62-78) ends on it
    and its bridge turned the thigh half a turn to meet frame 79 (37.5 -> 83.5 deg off the clean take, the foot up
    to 9 units off); bk depositFloorR's right thigh holds it over 138-205, taken away as an offset (23.5 -> 127.3
    deg), and the knee's repair inside it (0.0 -> 33.7). Each is given back as it came, named."""
    ref, bad, mask, det = hdm05_errors(take, seed)
    j = ref.skeleton.index(joint)
    a, b = frames
    off = lambda m, k, s, e: np.degrees(R.geodesic_angle(m.rotations[s:e, k], ref.rotations[s:e, k])).mean()  # noqa
    unguarded, _ = ssa.repair_with_left(bad, det, None, foot_skate=False, guard=False)
    assert off(unguarded, j, a, b) > off(bad, j, a, b) + 30.0
    new, left = ssa.repair_with_left(bad, det, None, foot_skate=False)
    assert np.array_equal(new.rotations[a:b, j], bad.rotations[a:b, j])
    assert any(r.joint == joint and r.start == a and r.end == b and "limb" in r.reason for r in left)
    if below_joint is not None:
        name, s, e = below_joint
        k = ref.skeleton.index(name)
        assert off(unguarded, k, s, e) > off(bad, k, s, e) + 10.0
        assert np.array_equal(new.rotations[s:e, k], bad.rotations[s:e, k])
        assert any(r.joint == name and r.start == s and r.end == e and "above it" in r.reason for r in left)
