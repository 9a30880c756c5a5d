"""Fast smooth turns (cleaning/ssa/smooth_turns.py): a joint's own flick confirms no digression; errors still break."""

from __future__ import annotations

import numpy as np
import pytest

from mocapkit import corrupt
from mocapkit import rotations as R
from mocapkit.cleaning.pipeline import clean
from mocapkit.cleaning.ssa.cues import event_bounds, midpoint_residuals, own_breaks
from mocapkit.cleaning.ssa.recurring_peaks import recurring_breaks
from mocapkit.cleaning.ssa.smooth_turns import COARSE_SHARE, coarse_share, coarse_turn, smooth_turn, smooth_turn_breaks

JUMP = 8.0  # SSAParams().jump_deg


def _track(steps_deg, axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    """(F, 4): one joint turning about ``axis`` by the successive ``steps_deg`` (F - 1,)."""
    angles = np.radians(np.r_[0.0, np.cumsum(steps_deg)])
    return R.rotvec_to_quaternion(angles[:, None] * np.asarray(axis))


def _events(q: np.ndarray) -> list[tuple[int, int]]:
    resid = midpoint_residuals(q[:, None])[:, 0]
    frames = np.flatnonzero(own_breaks(resid[:, None], JUMP)[:, 0])
    first, last, _ = event_bounds(frames)
    return [(int(a), int(b)) for a, b in zip(first, last)]


def test_a_bell_shaped_turn_is_smooth_and_the_same_turn_with_a_step_or_a_spike_is_not():
    flick = np.r_[np.full(20, 4.0), 6, 10, 22, 40, 55, 34, 12, 11, 15, 16, 13, 10, np.full(20, 5.0)]  # 131_01's wrist
    q = _track(flick)
    resid = midpoint_residuals(q[:, None])[:, 0]
    events = _events(q)
    assert events and all(smooth_turn(q, resid, a, b, JUMP) for a, b in events)
    stepped = flick.copy()
    stepped[22] += 25.0  # one frame's step out of the turn, held after it
    steady = np.r_[np.full(20, 4.0), 7.0, np.full(5, 32.0), np.full(20, 4.0)]  # a gap filled by a straight line
    bad = [_track(stepped), _track(steady)]
    for f, deg in ((24, 60.0), (30, 30.0)):  # a spike across the turn at its peak, and after it
        spiked = q.copy()
        spiked[f] = R.quaternion_multiply(R.rotvec_to_quaternion(np.radians([deg, 0.0, 0.0])), q[f])
        bad.append(spiked)
    for b in bad:
        r = midpoint_residuals(b[:, None])[:, 0]
        assert _events(b) and any(not smooth_turn(b, r, first, last, JUMP) for first, last in _events(b))
    # the cost: a spike smaller than the steps of a turn this fast reads as part of the turn
    spiked = q.copy()
    spiked[24] = R.quaternion_multiply(R.rotvec_to_quaternion(np.radians([30.0, 0.0, 0.0])), q[24])
    r = midpoint_residuals(spiked[:, None])[:, 0]
    assert all(smooth_turn(spiked, r, first, last, JUMP) for first, last in _events(spiked))


def test_a_held_frame_or_a_turn_back_is_no_smooth_turn():
    held = np.r_[np.full(20, 4.0), 10, 20, 0.0, 20, 10, np.full(20, 4.0)]
    back = np.r_[np.full(20, 4.0), 10, 20, 30, -30, -20, -10, np.full(20, -4.0)]
    for steps in (held, back):
        q = _track(steps)
        r = midpoint_residuals(q[:, None])[:, 0]
        assert _events(q) and not any(smooth_turn(q, r, a, b, JUMP) for a, b in _events(q))


def test_a_smooth_turn_while_a_joint_up_its_chain_breaks_is_kept():
    flick = np.r_[np.full(20, 4.0), 6, 10, 22, 40, 55, 34, 12, 11, 15, 16, 13, 10, np.full(20, 5.0)]
    foot = _track(flick)
    still = _track(np.full(len(flick), 1.0), axis=(1.0, 0.0, 0.0))
    over = _track(np.where(np.arange(len(flick)) == 24, 180.0, 1.0), axis=(0.0, 1.0, 0.0))  # a turn-over at 24
    for thigh, kept in ((still, False), (over, True)):
        q = np.stack([still, thigh, foot], axis=1)  # (F, 3, 4): root, thigh, foot
        resid = midpoint_residuals(q)
        breaks = own_breaks(resid, JUMP)
        assert breaks[:, 2].any()
        out = smooth_turn_breaks(q, resid, breaks, JUMP, parents=[-1, 0, 1])
        if kept:  # the thigh's turn-over moves the foot: its breaks stay
            assert np.array_equal(out[:, 2], breaks[:, 2])
        else:
            assert not out[:, 2].any()
        assert not smooth_turn_breaks(q, resid, breaks, JUMP)[:, 2].any()  # the foot's shape alone: a smooth turn


def test_the_hdm05_squats_foot_turning_around_its_thighs_turn_over_still_breaks(shared_data):
    """HDM05 dg_squat1Reps_026: the right foot turns 180 deg in 9 smooth frames (peak 52 deg at frame 100) around
    the frame its thigh turns back over in one: the turn-over's, not the foot's own motion."""
    import mocapkit

    path = shared_data / "hdm05_asfamc" / "HDM_dg_squat1Reps_026_120.amc"
    if not path.is_file():
        pytest.skip("HDM05 squat take not in the shared data")
    m = mocapkit.load(path, asf=shared_data / "hdm05_asfamc" / "HDM_dg.asf")
    q = np.asarray(m.rotations, dtype=np.float64)
    resid = midpoint_residuals(q)
    breaks = own_breaks(resid, JUMP, m.fps, q)
    j = m.skeleton.index("rfoot")
    assert breaks[99, j] and breaks[102, j]
    assert smooth_turn_breaks(q, resid, breaks, JUMP)[99:103, j].sum() == 0  # its shape alone: a smooth turn
    assert np.array_equal(smooth_turn_breaks(q, resid, breaks, JUMP, m.skeleton.parents)[:, j], breaks[:, j])


def test_the_walks_wrist_flicks_are_smooth_turns_and_no_other_break_of_the_take_is(walk):
    q = np.asarray(walk.rotations, dtype=np.float64)
    resid = midpoint_residuals(q)
    breaks = own_breaks(resid, JUMP, walk.fps, q)
    kept = smooth_turn_breaks(q, resid, breaks, JUMP, walk.skeleton.parents)
    j = walk.skeleton.index("RightWrist")
    assert breaks[235:239, j].all() and breaks[808, j] and breaks[810, j]
    gone = breaks & ~kept
    assert np.flatnonzero(gone.any(axis=0)).tolist() == [j]
    assert np.flatnonzero(gone[:, j]).tolist() == [235, 236, 237, 238, 808, 810]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_injected_error_still_breaks(walk, seed):
    bad, mask, _ = corrupt.real_errors(walk, n_errors=6, seed=seed)
    q = np.asarray(bad.rotations, dtype=np.float64)
    resid = midpoint_residuals(q)
    breaks = own_breaks(resid, JUMP, bad.fps, q)
    kept = smooth_turn_breaks(q, resid, breaks, JUMP)  # by their shape alone, no chain
    near = np.zeros_like(mask)  # the cells within 2 frames of an injected error
    for d in range(-2, 3):
        near |= np.roll(mask, d, axis=0)
    assert (breaks & near).any()
    assert np.array_equal(kept & near, breaks & near)


def test_clean_leaves_the_walks_wrist_flick_unflagged_and_untouched(walk):
    """CMU 131_01: the right wrist flicks 133 deg in 4 frames at frame 235 (and 76 deg at 808), as 131_02 and 131_03
    flick it when the arm stops, slower. The break rule flagged both and the repair guard gave the repair back; the
    flick is now no break, so nothing is flagged there and nothing is left to say."""
    res = clean(walk, steps=("detect", "repair"))
    j = walk.skeleton.index("RightWrist")
    assert not res.flags[225:255, j].any() and not res.flags[795:815, j].any()
    assert np.array_equal(res.motion.rotations[:, j], walk.rotations[:, j])
    assert not any("RightWrist" in line for line in res.summary())


def _breaks_at(m):
    """(q, resid, breaks) of ``m`` as detect reads them before the smooth turns (own level, then recurring peaks)."""
    q = np.asarray(m.rotations, dtype=np.float64)
    resid = midpoint_residuals(q)
    return q, resid, recurring_breaks(resid, own_breaks(resid, JUMP, m.fps, q), m.fps, JUMP)


def test_the_walks_wrist_flick_at_30_fps_is_a_coarse_turn_and_breaks_at_120_fps_stay(walk):
    """131_01 at 30 fps (every 4th frame, as clean_untouched's cmu_bvh_30fps): the wrist turns 75, 87 and 54 deg in
    three frames (58-61, steps 150 deg apart), the 120 fps flick at frame 235 sampled coarsely; no break there."""
    low = walk[::4]
    q, resid, breaks = _breaks_at(low)
    j = low.skeleton.index("RightWrist")
    assert breaks[59:61, j].all()
    assert not smooth_turn(q[:, j], resid[:, j], 59, 60, JUMP)  # the shape test reads a turn back at this rate
    assert coarse_turn(q[:, j], resid[:, j], 59, 60, low.fps)
    kept = smooth_turn_breaks(q, resid, breaks, JUMP, low.skeleton.parents, low.fps)
    assert not kept[55:65, j].any()
    assert np.array_equal(kept, smooth_turn_breaks(q, resid, breaks, JUMP, low.skeleton.parents) & kept)
    q, resid, breaks = _breaks_at(walk)  # over about 60 fps the coarse test is not made
    assert np.array_equal(smooth_turn_breaks(q, resid, breaks, JUMP, walk.skeleton.parents, walk.fps),
                          smooth_turn_breaks(q, resid, breaks, JUMP, walk.skeleton.parents))


def test_a_spike_step_or_held_frame_at_30_fps_is_no_coarse_turn():
    """An error steps off the path in one or two fast steps, between steps at the joint's own pace."""
    pace = np.full(15, 6.0)
    cases = {"spike": np.r_[pace, 60.0, -60.0, pace], "step": np.r_[pace, 70.0, pace],
             "two-frame spike": np.r_[pace, 60.0, 6.0, -60.0, pace], "held": np.r_[pace, 50.0, 60.0, 0.0, 55.0, pace]}
    for name, steps in cases.items():
        q = _track(steps)
        resid = midpoint_residuals(q[:, None])[:, 0]
        events = _events(q)
        assert events and not any(coarse_turn(q, resid, a, b, 30.0) for a, b in events), name
    flick = _track(np.r_[pace, 75.0, 87.0, 54.0, pace])  # three fast steps: a turn, whichever way each points
    resid = midpoint_residuals(flick[:, None])[:, 0]
    assert all(coarse_turn(flick, resid, a, b, 30.0) for a, b in _events(flick))
    small = _track(np.r_[pace, 20.0, 20.0, 20.0, 45.0, 5.0, pace])  # under what limb motion makes at 30 fps
    resid = midpoint_residuals(small[:, None])[:, 0]
    assert _events(small) and not any(coarse_turn(small, resid, a, b, 30.0) for a, b in _events(small))


def test_the_share_a_coarse_turns_steps_reach_falls_with_the_rate_under_30_fps():
    """A turn's midpoint residual grows with the square of the frame time, its steps with the frame time."""
    assert coarse_share(30.0) == coarse_share(120.0) == COARSE_SHARE
    assert coarse_share(24.0) == pytest.approx(0.6) and coarse_share(20.0) == pytest.approx(0.5)
    assert coarse_share(15.0) == pytest.approx(2.0 / 3.0)  # a frame longer than a fast turn: the share rises again
    # a wrist turning 70 and 94 deg and 125 deg back in three frames at 24 fps (110 deg residual: 131_03's flick)
    flick = _track(np.r_[np.full(15, 6.0), 70.0, 94.0, -125.0, np.full(15, -6.0)])
    resid = midpoint_residuals(flick[:, None])[:, 0]
    assert all(coarse_turn(flick, resid, a, b, 24.0) for a, b in _events(flick))
    assert not any(coarse_turn(flick, resid, a, b, 30.0) for a, b in _events(flick))
    # at 15 fps a 170 deg spike out and back on a joint stepping 80 deg into it stays a break
    spike = _track(np.r_[np.full(15, 20.0), 80.0, 170.0, -170.0, np.full(15, 20.0)])
    resid = midpoint_residuals(spike[:, None])[:, 0]
    assert _events(spike) and not any(coarse_turn(spike, resid, a, b, 15.0) for a, b in _events(spike))


def test_the_walks_thumb_turn_at_24_fps_is_a_coarse_turn(walk):
    """131_01 at 24 fps (every 5th frame from frame 1): the right thumb turns 46, 74 and 40 deg in three frames
    (60-63) around a 57 deg residual at frame 62; 3/4 of it (43 deg) is more than the arm's 40 deg step, 0.6 of it
    (34 deg, the share at 24 fps) is not."""
    low = walk[1::5]
    q, resid, breaks = _breaks_at(low)
    j = low.skeleton.index("RThumb")
    assert low.fps == 24.0 and breaks[62, j]
    assert coarse_turn(q[:, j], resid[:, j], 62, 62, low.fps)
    assert not smooth_turn_breaks(q, resid, breaks, JUMP, low.skeleton.parents, low.fps)[60:65, j].any()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_injected_error_still_breaks_at_24_and_20_fps(walk, seed):
    for k in (5, 6):  # every 5th and 6th frame: 24 and 20 fps
        bad, mask, records = corrupt.real_errors(walk[::k], n_errors=6, seed=seed)
        q, resid, breaks = _breaks_at(bad)
        kept = smooth_turn_breaks(q, resid, breaks, JUMP, bad.skeleton.parents, bad.fps)
        for r in records:
            j = bad.skeleton.index(r.joint)
            near = slice(max(r.start - 2, 0), r.end + 2)
            assert kept[near, j].any() == breaks[near, j].any(), (k, r)


def test_clean_leaves_131_03s_wrist_flick_at_24_fps_untouched(shared_data):
    """CMU 131_03 at 24 fps (mocapkit convert --fps 24: every 5th frame): the wrist turns 71, 94 and 125 deg in three
    frames (49-52) around a 108 deg residual; clean moved RightWrist frames 50-53 by up to 155 deg."""
    import mocapkit

    path = shared_data / "cmu_bvh" / "131_03.bvh"
    if not path.is_file():
        pytest.skip("CMU 131_03 not in the shared data")
    low = mocapkit.load(path).resample(24.0)
    res = clean(low)
    j = low.skeleton.index("RightWrist")
    assert not res.flags[:, j].any()
    assert np.array_equal(res.motion.rotations[:, j], low.rotations[:, j])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_injected_error_still_breaks_at_30_fps(walk, seed):
    low = walk[::4]
    bad, mask, records = corrupt.real_errors(low, n_errors=6, seed=seed)
    q, resid, breaks = _breaks_at(bad)
    kept = smooth_turn_breaks(q, resid, breaks, JUMP, bad.skeleton.parents, bad.fps)
    for r in records:
        j = bad.skeleton.index(r.joint)
        near = slice(max(r.start - 2, 0), r.end + 2)
        assert kept[near, j].any() == breaks[near, j].any(), r


def test_clean_leaves_the_walks_wrist_flick_at_30_fps_untouched(walk):
    """clean_untouched's cmu_bvh_30fps: clean (defaults) moved 131_01's RightWrist frames 59-60 by 49 and 72 deg."""
    low = walk[::4]
    res = clean(low)
    j = low.skeleton.index("RightWrist")
    assert not res.flags[:, j].any()
    assert np.array_equal(res.motion.rotations[:, j], low.rotations[:, j])
