"""A spike's flags bounded to its own frames (mocapkit.cleaning.ssa.spike_bounds).

The real take is HDM05's HDM_dg_throwBasketball_007: its right hand turns 180 degrees from frame 151 to 152
and back from 153 to 154 (a flip of the capture itself), while the frames around it move under a degree a
frame. Performer dg's other throws (008, 009) hold the same flip, so against them the flipped frames do not
digress and the good frames beside them do; the spike's margin confirmed those good frames, and repair turned
them 62-148 deg toward the flip while leaving the flip.
"""

from __future__ import annotations

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa.spike_bounds import spike_frames

FLIP = (152, 153)  # the frames the right hand is flipped on (0-based)


def test_spike_frames_are_the_frames_inside_each_event():
    # a 2-frame spike at 10-11 breaks at 9..12; a 1-frame spike at 30 at 29..31; an edge event of two frames
    assert spike_frames(np.array([9, 10, 11, 12, 29, 30, 31, 50, 51])).tolist() == [10, 11, 30, 50, 51]


def _throw(shared_data, n):
    hdm = shared_data / "hdm05_asfamc"
    return mocapkit.load(hdm / f"HDM_dg_throwBasketball_{n:03d}_120.amc", asf=hdm / "HDM_dg.asf")


@pytest.fixture(scope="module")
def throw(shared_data):
    return _throw(shared_data, 7), [_throw(shared_data, 8), _throw(shared_data, 9)]


@pytest.mark.parametrize("with_context", [True, False], ids=["dg-throws", "default"])
def test_a_flipped_hand_is_flagged_and_repaired_on_its_flipped_frames_only(throw, with_context):
    take, others = throw
    j = take.skeleton.joint_names.index("rhand")
    det = ssa.detect(take, others if with_context else None)
    assert np.flatnonzero(det.flags[140:170, j]).tolist() == [f - 140 for f in FLIP]
    fixed = ssa.repair(take, det, foot_skate=False)
    good = np.ones(take.num_frames, dtype=bool)
    good[list(FLIP)] = False
    assert np.array_equal(fixed.rotations[good, j], take.rotations[good, j])
    # the flipped frames come back near the path: within 15 deg of the flip turned back (the step into it undone)
    q = np.asarray(take.rotations[:, j])
    step = R.quaternion_multiply(q[FLIP[0]], R.quaternion_inverse(q[FLIP[0] - 1]))
    back = R.quaternion_multiply(R.quaternion_inverse(step)[None], q[list(FLIP)])
    assert np.degrees(R.geodesic_angle(np.asarray(fixed.rotations[list(FLIP), j]), back)).max() < 15.0
