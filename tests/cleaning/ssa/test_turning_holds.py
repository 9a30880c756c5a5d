"""A joint still for one step where it turns back is no held joint (mocapkit.cleaning.ssa.turning_holds)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning.ssa.turning_holds import turning_point_holds, without_turning_points

#: the unpacked Bandai Namco set (benchmarks/_bandai.py), if this machine has it
BANDAI = (Path(os.environ["MOCAPKIT_BANDAI_DIR"]) if os.environ.get("MOCAPKIT_BANDAI_DIR")
          else Path.home() / ".cache" / "mocapkit" / "bandai_namco") / "dataset"


def _track(angles_deg):
    """(F, 1, 4): one joint turning about x by ``angles_deg`` (F,)."""
    angles = np.radians(np.asarray(angles_deg, dtype=float))
    return R.quaternion_from_axis_angle(np.array([1.0, 0.0, 0.0]), angles)[:, None]


def test_a_still_step_at_the_end_of_a_swing_is_left_out_and_a_frozen_one_is_kept():
    """Frames 3 and 4 equal in both tracks; the swing comes back after them (a turning point sampled either side
    of its vertex), the frozen track jumps on to where the limb has gone (a frozen channel)."""
    hold = np.zeros((8, 1), dtype=bool)
    hold[3:5] = True
    swing = _track([0.0, 9.0, 16.0, 20.0, 20.0, 16.0, 9.0, 0.0])
    frozen = _track([0.0, 7.0, 14.0, 21.0, 21.0, 35.0, 42.0, 49.0])
    np.testing.assert_array_equal(turning_point_holds(swing, hold), hold)
    assert not without_turning_points(swing, hold).any()
    assert not turning_point_holds(frozen, hold).any()
    np.testing.assert_array_equal(without_turning_points(frozen, hold), hold)


def test_a_longer_hold_or_one_at_the_take_s_edge_is_kept():
    """Two still steps are a joint that stops, not one that turns; a hold at frame 0 has no step into it."""
    swing = _track([0.0, 9.0, 16.0, 20.0, 20.0, 20.0, 16.0, 9.0])
    hold = np.zeros((8, 1), dtype=bool)
    hold[3:6] = True
    assert not turning_point_holds(swing, hold).any()
    edge = _track([20.0, 20.0, 16.0, 9.0, 0.0, 0.0, 0.0, 0.0])
    first = np.zeros((8, 1), dtype=bool)
    first[0:2] = True
    assert not turning_point_holds(edge, first).any()


def test_a_joint_easing_out_of_rest_after_a_still_step_is_kept():
    """A step of 0.1 deg into the hold and 4.3 out of it, the same way or not: no turn back (Bandai dataset-1
    dash_feminine_001's left toe at frames 74-75), so the hold stays for the similar motion to judge."""
    hold = np.zeros((6, 1), dtype=bool)
    hold[2:4] = True
    for back in (0.1, -0.1):
        track = _track([0.0, 0.0, back, back, back - 4.3, back - 8.0])
        assert not turning_point_holds(track, hold).any()


TOE_OFF = BANDAI / "Bandai-Namco-Research-Motiondataset-2" / "data" / "dataset-2_walk-turn-left_feminine_005.bvh"


@pytest.mark.skipif(not TOE_OFF.is_file(), reason="the unpacked Bandai Namco set is not on this machine")
def test_a_toe_at_the_end_of_its_bend_at_push_off_is_not_held():
    """Bandai dataset-2 walk-turn-left_feminine_005 (30 fps): the left toe bends 7 deg a frame to 24.2 deg at
    push-off, frames 49 and 50 lie 0.013 deg apart, and it comes back 11.2 deg a frame; clean flagged Toes_L
    49-50 as held still while the similar motion moves. Nothing of the take is flagged now."""
    from mocapkit.cleaning.ssa import detect

    take = mocapkit.load(TOE_OFF)
    toe = take.skeleton.joint_names.index("Toes_L")
    det = detect(take)
    assert not det.holds[:, toe].any()
    assert not det.flags.any()
