import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa import cues
from mocapkit.cleaning.ssa.step_pairs import (MAX_STEP_FRAMES, RETURN_RATIO, UNDO_RATIO, is_step, offset_step_breaks,
                                              returns, steps_back, undo_left)
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
    assert changed[128:133].all()  # the spun frames (steps of 109-155 deg into 128-132; 127 moves 9 deg, on its path)
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


def test_offset_step_breaks_are_the_break_events_at_an_offsets_two_steps():
    """An offset flagged on frames 20-39 steps off between 19 and 20 and back between 39 and 40: the break events
    holding those frames (one spanning 18-20, one 39-41) are its steps; a break inside it (30) and one elsewhere
    (5), or on another joint, are not."""
    F = 60
    offsets = np.zeros((F, 2), dtype=bool)
    offsets[20:40, 0] = True
    breaks = np.zeros((F, 2), dtype=bool)
    breaks[[5, 18, 20, 30, 39, 41], 0] = True
    breaks[[19, 20, 39, 40], 1] = True  # the same frames on a joint with no offset
    out = offset_step_breaks(breaks, offsets)
    assert np.flatnonzero(out[:, 0]).tolist() == [18, 20, 39, 41]
    assert not out[:, 1].any()
    assert not offset_step_breaks(breaks, np.zeros_like(offsets)).any()
    with pytest.raises(ValueError, match="same"):
        offset_step_breaks(breaks, offsets[:, :1])


def test_an_offsets_steps_confirm_no_digression_beside_it():
    """The digression beside an offset's two steps (neighbour words the error led astray) is not flagged by the
    break rule: the flags are the offset's frames alone. A break of its own beside it still confirms, and so do
    the steps of an offset that is a side swap."""
    F, fps = 80, 120.0
    offsets = np.zeros((F, 1), dtype=bool)
    offsets[30:50] = True
    jumps = np.zeros((F, 1), dtype=bool)
    jumps[[29, 30, 49, 50]] = True
    mdm = np.zeros((F, 1))
    mdm[26:56] = 1.0  # digresses 4 frames before the step off to 6 after the step back
    none = np.zeros((F, 1), dtype=bool)
    flags = cues.flag_rule(mdm, jumps, none, none, offsets, 0.5, fps, True, 0.05)
    assert np.flatnonzero(flags[:, 0]).tolist() == list(range(30, 50))
    # a side swap's cells are replaced by neighbour words, not undone: its steps still confirm the digression
    swapped = cues.flag_rule(mdm, jumps, none, offsets, offsets, 0.5, fps, True, 0.05)
    assert np.flatnonzero(swapped[:, 0]).tolist() == list(range(26, 56))
    jumps[54] = True  # a break of its own, 4 frames past the step back
    flags = cues.flag_rule(mdm, jumps, none, none, offsets, 0.5, fps, True, 0.05)
    assert flags[50:56, 0].all()


@pytest.fixture(scope="module")
def basketball(shared_data):
    """HDM05 ``tr_throwBasketball_014`` and ``mocapkit.clean``'s result on it (defaults)."""
    m = mocapkit.load(shared_data / "hdm05_asfamc" / "HDM_tr_throwBasketball_014_120.amc")
    return m, mocapkit.clean(m)


def test_a_hand_flip_is_repaired_on_the_flipped_frames_alone(basketball):
    """HDM05 tr_throwBasketball_014: the right hand flips by 180 deg on frames 54-148 and 201-245 (one-frame turns
    of 168-180 deg at both ends of each). Both flips are taken back; every other frame of the hand comes back
    bit-identical (frames 198-200 and 246-252, real motion beside the second flip, were replaced by neighbour
    words and joined the take 9-12 deg off), and the repaired hand joins the take smoothly."""
    m, res = basketball
    j = m.skeleton.index("rhand")
    a, b = m.rotations[:, j], res.motion.rotations[:, j]
    step = np.degrees(R.geodesic_angle(a[1:], a[:-1]))
    flipped = np.zeros(m.num_frames, dtype=bool)
    flipped[54:149] = flipped[201:246] = True
    assert (step[[53, 148, 200, 245]] > 160.0).all()  # the take's own flips
    changed = ~np.all(a == b, axis=-1)
    assert changed[flipped].all()
    assert not changed[~flipped].any()
    turn = np.degrees(R.geodesic_angle(b[1:], b[:-1]))
    assert turn[[53, 148, 200, 245]].max() < 20.0  # the flips are gone
    assert turn[195:251].max() < 8.0  # no join rougher than the hand's own motion beside it (up to 5.5 deg a frame)
