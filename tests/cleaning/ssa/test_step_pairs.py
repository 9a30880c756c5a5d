import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa.step_pairs import (MAX_STEP_FRAMES, RETURN_RATIO, UNDO_RATIO, is_step, returns,
                                              steps_back, undo_left)
from tests.cleaning.ssa.helpers import turned


def test_undo_left_steps_back_and_returns_measure_the_two_steps():
    x = np.array([1.0, 0.0, 0.0])
    off = np.radians(40.0) * x
    assert undo_left(off, -off) < 1e-12
    assert np.isclose(np.degrees(undo_left(off, -np.radians(11.0) * x)), 29.0)
    half = np.radians(180.0) * x  # a half turn has no sign: the same half turn again undoes it
    assert undo_left(half, half) < 1e-6
    steps = np.stack([off, -np.radians(28.0) * x])  # leaves 12 of 40 deg: does not undo it
    assert not steps_back((steps,), 0, 1, UNDO_RATIO) and steps_back((steps,), 0, 1, 0.5)
    assert steps_back((np.stack([off, -off]), steps), 0, 1, UNDO_RATIO)  # one frame that holds is enough
    assert returns(off, -np.radians(20.0) * x) and not returns(off, -np.radians(19.0) * x)
    assert returns(off, -np.radians(60.0) * x)  # a drift that grew while off snaps back by more
    assert RETURN_RATIO == 0.5


def test_a_step_back_that_takes_back_little_of_the_step_off_ends_no_transient_offset(walk):
    """A 40 deg step off and an opposite 16 deg twitch later leave the joint 24 deg off: no offset that ended;
    a 28 deg step back (not the inverse: the loose pair) ends it."""
    j = walk.skeleton.index("LeftElbow")
    off, _ = turned(walk, "LeftElbow", np.arange(400, walk.num_frames), 40.0)
    twitch, _ = turned(off, "LeftElbow", np.arange(450, walk.num_frames), -16.0)
    assert not ssa.transient_offsets(twitch)[:, j].any()
    back, _ = turned(off, "LeftElbow", np.arange(450, walk.num_frames), -28.0)  # not its inverse, but a return
    assert np.flatnonzero(ssa.transient_offsets(back)[:, j]).tolist() == list(range(400, 450))


def test_a_loose_pair_needs_two_steps_not_a_step_and_a_burst(walk):
    """The loose pair of the test above (40 deg off, 28 deg back) ends an offset where the step back is a jump
    between two frames; where the joint comes back through a 5-frame burst of 150 deg spins instead, the burst is
    no step back and the stretch before it no offset."""
    off, j = turned(walk, "LeftElbow", np.arange(400, walk.num_frames), 40.0)
    back, _ = turned(off, "LeftElbow", np.arange(450, walk.num_frames), -28.0)
    assert np.flatnonzero(ssa.transient_offsets(back)[:, j]).tolist() == list(range(400, 450))
    burst, _ = turned(back, "LeftElbow", np.arange(450, 455), [150.0, -150.0, 150.0, -150.0, 150.0])
    assert not ssa.transient_offsets(burst)[:, j][400:450].any()
    assert is_step(1) and is_step(MAX_STEP_FRAMES) and not is_step(MAX_STEP_FRAMES + 1) and not is_step(0)


@pytest.fixture(scope="module")
def backflip(shared_data):
    """The CMU backflip and ``mocapkit.clean``'s result on it (defaults)."""
    m = mocapkit.load(shared_data / "cmu_asfamc" / "backflip.amc")
    return m, mocapkit.clean(m)


def test_the_backflip_hands_real_motion_after_their_spin_is_left_alone(backflip):
    """CMU backflip: the left hand spins 110-155 deg a frame on frames 127-131 (a solver's glitch) and moves
    smoothly after it, up to a one-frame twitch at 160. The spin is repaired; the smooth frames between are
    not turned to undo an offset the twitch never takes back (they were turned 67-78 deg)."""
    m, res = backflip
    j = m.skeleton.index("lhand")
    changed = ~np.all(m.rotations[:, j] == res.motion.rotations[:, j], axis=-1)
    assert changed[127:132].all()
    assert not changed[142:160].any()
    turn = np.degrees(R.geodesic_angle(res.motion.rotations[127:133, j], res.motion.rotations[128:134, j]))
    assert turn.max() < 20.0  # the spin is gone


def test_the_backflip_right_hand_between_its_swing_and_its_spin_burst_is_left_alone(backflip):
    """CMU backflip: the right hand ends a fast 6-frame swing with a 69 deg step at frame 134, then holds the pose
    it has before the flip and after frame 172 (steps of 1-9 deg a frame on frames 144-159), until a spin burst
    (146-162 deg a frame) on frames 160-165. The step and the burst point roughly opposite ways, but the smooth
    frames between digress no more than the flip beside them: they are no offset and are not turned (they were
    turned 40-72 deg, the repair ending 70 deg off the input at frame 160)."""
    m, res = backflip
    j = m.skeleton.index("rhand")
    changed = ~np.all(m.rotations[:, j] == res.motion.rotations[:, j], axis=-1)
    assert not changed[147:160].any()
