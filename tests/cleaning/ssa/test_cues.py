"""The cues that confirm a digression or find an error: breaks, held joints, side swaps, transient offsets."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa import cues
from tests.cleaning.ssa.helpers import swinging, turned


def test_discontinuities_mark_steps_and_spikes_not_smooth_motion(walk):
    body = [walk.skeleton.index(n) for n in ("LeftHip", "LeftKnee", "RightKnee", "LeftShoulder", "LeftElbow", "Chest")]
    assert not ssa.discontinuities(walk)[:, body].any()  # a real walk at 120 fps is smooth
    stepped, j = turned(walk, "LeftElbow", np.arange(300, walk.num_frames), 20.0)
    jumps = ssa.discontinuities(stepped)
    assert set(np.flatnonzero(jumps[:, j])) == {299, 300}  # both sides of the 20 deg step
    assert np.array_equal(jumps[:, np.arange(walk.num_joints) != j], ssa.discontinuities(walk)[:, np.arange(walk.num_joints) != j])
    small, j = turned(walk, "LeftElbow", np.arange(300, walk.num_frames), 12.0)
    assert not ssa.discontinuities(small)[:, j].any()  # a 12 deg step is under 2 x 8 deg
    spiked, j = turned(walk, "LeftElbow", np.array([400]), 10.0)
    assert np.flatnonzero(ssa.discontinuities(spiked)[:, j]).tolist() == [400]
    with pytest.raises(ValueError, match="jump_deg"):
        ssa.discontinuities(walk, jump_deg=float("nan"))


def test_confirm_flags_keep_whole_runs_that_reach_the_threshold_and_hold_a_break():
    F, fps = 100, 100.0
    mdm = np.zeros((F, 3))
    mdm[10:30, 0] = 0.3
    mdm[15:20, 0] = 0.8  # run 10-30 reaches 0.8; a break 4 frames before its start confirms it (margin 5 frames)
    mdm[60:70, 0] = 0.9  # a clear digression with no break near: distinct motion, not an error
    mdm[70:80, 1] = 0.4  # a break, but the run never exceeds the threshold
    mdm[40:50, 2] = 0.9  # the break near it is on joint 0, not this one
    jumps = np.zeros((F, 3), dtype=bool)
    jumps[6, 0] = jumps[75, 1] = jumps[45, 0] = True
    flags = ssa.confirm_flags(mdm, jumps, 0.5, fps, margin_s=0.05)
    expect = np.zeros((F, 3), dtype=bool)
    expect[10:30, 0] = True
    assert np.array_equal(flags, expect)
    assert not ssa.confirm_flags(mdm, jumps, 0.5, fps, margin_s=0.03)[:, 0].any()  # the break is 4 frames off
    # a run holding two break events is cut to them (within the margin); with one it is kept whole
    long = np.zeros((F, 1))
    long[10:70, 0] = 0.8
    steps = np.zeros((F, 1), dtype=bool)
    steps[30:32, 0] = True  # a step marks the frames on both of its sides
    assert np.flatnonzero(ssa.confirm_flags(long, steps, 0.5, fps)).tolist() == list(range(10, 70))
    steps[50, 0] = True
    assert np.flatnonzero(ssa.confirm_flags(long, steps, 0.5, fps)).tolist() == list(range(25, 56))
    early = np.zeros((F, 1))
    early[0:70, 0] = 0.8  # a run from the first frame, its first break within the margin of it
    first = np.zeros((F, 1), dtype=bool)
    first[2, 0] = first[50, 0] = True
    assert np.flatnonzero(ssa.confirm_flags(early, first, 0.5, fps)).tolist() == list(range(0, 56))
    with pytest.raises(ValueError, match="shape"):
        ssa.confirm_flags(mdm, jumps[:, :2], 0.5, fps)


def test_held_joints_find_a_frozen_channel_and_leave_motion_alone(walk):
    F = walk.num_frames
    t = np.arange(F) / walk.fps
    swing = 30.0 * np.sin(2 * np.pi * t)  # the joint swings +-30 deg once a second
    frozen = swing.copy()
    frozen[300:340] = swing[299]  # held for 1/3 s at a value inside its range
    clamped = np.maximum(swing, -20.0)  # held at -20 deg in every swing: a joint limit the solver clamps at
    at_peak = swing.copy()
    peak = int(np.argmax(swing[200:320])) + 200
    at_peak[peak : peak + 40] = swing[peak]  # frozen once at the top of its swing, the edge of its range
    moving = np.full((F, walk.num_joints), 50.0)  # every joint analysed, its mean texture moving at 50 deg/s
    for name, signal_deg in (("frozen", frozen), ("clamped", clamped), ("at_peak", at_peak)):
        m, j = swinging(walk, "LeftElbow", signal_deg)
        moving[:, j] = 2 * np.pi * 30.0 * np.abs(np.cos(2 * np.pi * t))  # the unfrozen swing's speed, deg/s
        held = ssa.held_joints(m, moving)
        if name == "frozen":
            assert np.flatnonzero(held[:, j]).tolist() == list(range(299, 340))
        elif name == "at_peak":
            assert np.flatnonzero(held[:, j]).tolist() == list(range(peak, peak + 40))
        else:
            assert (clamped == -20.0).sum() > 100 and not held.any()
    rest = swing.copy()
    rest[300:340] = 0.0  # held once at exactly the rest pose (a solver's straight knee), not frozen
    m, j = swinging(walk, "LeftElbow", rest)
    assert not ssa.held_joints(m, moving).any()
    rest[300:340] = 0.05  # the same hold a twentieth of a degree off the rest pose is a freeze
    m, j = swinging(walk, "LeftElbow", rest)
    assert np.flatnonzero(ssa.held_joints(m, moving)[:, j]).tolist() == list(range(300, 340))
    m, j = swinging(walk, "LeftElbow", frozen)
    still_context = moving.copy()
    still_context[:, j] = 0.0  # the similar motion holds there too: no error
    assert not ssa.held_joints(m, still_context).any()
    repeated = np.array(m.rotations)
    repeated[300:340] = repeated[299]  # the whole pose held: a repeated frame, not one joint
    assert not ssa.held_joints(dataclasses.replace(m, rotations=repeated), moving).any()
    mostly, j = swinging(walk, "LeftElbow", np.where(t < 0.6 * t[-1], 5.0, swing))  # still for 60 % of the take
    assert not ssa.held_joints(mostly, moving).any()
    with pytest.raises(ValueError, match="mean_speed"):
        ssa.held_joints(m, moving[:, :3])
    with pytest.raises(ValueError, match="travel_deg"):
        ssa.held_joints(m, moving, travel_deg=0.0)
    with pytest.raises(ValueError, match="recur_deg"):
        ssa.held_joints(m, moving, recur_deg=-1.0)
    with pytest.raises(ValueError, match="rest_deg"):
        ssa.held_joints(m, moving, rest_deg=-1.0)
    # the speeds come from a cheaper angle than rotations.geodesic_angle: the same to 1e-6 rad, also off unit length
    q = walk.rotations * 1.001
    assert np.allclose(cues.step_angles(q), R.geodesic_angle(walk.rotations[1:], walk.rotations[:-1]), atol=1e-6)


def test_side_swaps_find_both_joints_of_a_label_swap_and_nothing_in_clean_takes(walk):
    for name in ("131_01.bvh", "12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"):
        assert not ssa.side_swaps(mocapkit.load(mocapkit.samples.path(name))).any(), name
    bad, mask, records = corrupt.real_errors(walk, kinds=("swap",), n_errors=1, seed=2)
    assert {r.kind for r in records} == {"swap"} and len(records) == 2
    swaps = ssa.side_swaps(bad)
    expect = np.zeros_like(swaps)
    for r in records:
        expect[r.start : r.end, walk.skeleton.index(r.joint)] = True
    assert np.array_equal(swaps, expect)
    one = records[0]
    j = walk.skeleton.index(one.joint)
    assert not ssa.side_swaps(bad, joints=np.arange(walk.num_joints) != j).any()  # the pair needs both joints
    assert not ssa.side_swaps(bad, max_s=0.9 * (one.end - one.start) / walk.fps).any()  # breaks too far apart
    # one side breaking alone (a step on one joint) is not a swap
    stepped, _ = turned(walk, one.joint, np.arange(one.start, one.end), 40.0)
    assert not ssa.side_swaps(stepped).any()
    with pytest.raises(ValueError, match="max_s"):
        ssa.side_swaps(walk, max_s=0.0)
    det = ssa.detect(bad)
    assert np.array_equal(det.swaps, expect & det.analysed[None, :]) and (det.flags >= det.swaps).all()


def test_transient_offsets_flag_exactly_a_drift_or_flip_between_its_two_steps(walk):
    """A drift or flip steps off the joint's path and back: flagged from its first to its last frame, exactly."""
    for kind, seed in (("drift", 0), ("drift", 2), ("flip", 1), ("flip", 3)):
        bad, mask, records = corrupt.real_errors(walk, kinds=(kind,), n_errors=1, seed=seed)
        r = records[0]
        j = walk.skeleton.index(r.joint)
        offsets = ssa.transient_offsets(bad)
        assert np.flatnonzero(offsets[:, j]).tolist() == list(range(r.start, r.end)), (kind, seed)
        clean_joints = np.arange(walk.num_joints) != j
        assert np.array_equal(offsets[:, clean_joints], ssa.transient_offsets(walk)[:, clean_joints])
        assert not ssa.transient_offsets(bad, max_s=0.9 * (r.end - r.start) / walk.fps)[:, j].any()  # steps too far apart
        assert not ssa.transient_offsets(bad, joints=clean_joints)[:, j].any()
        det = ssa.detect(bad)
        assert (det.flags >= det.offsets).all() and det.offsets[r.start : r.end, j].all()


def test_transient_offsets_leave_smooth_motion_spikes_and_one_way_steps_alone(walk):
    for name in ("12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"):
        assert not ssa.transient_offsets(mocapkit.load(mocapkit.samples.path(name))).any(), name
    # the walk's own right-thumb glitches (180 deg turns in one frame and back) are the only ones in it
    own = ssa.transient_offsets(walk)
    assert set(np.flatnonzero(own.any(axis=0))) <= {walk.skeleton.index("RThumb")}
    others = np.ones(walk.num_joints, dtype=bool)
    others[walk.skeleton.index("RThumb")] = False
    spiked, _, records = corrupt.real_errors(walk, kinds=("spike",), n_errors=1, seed=2)  # out and back in one event
    assert not ssa.transient_offsets(spiked, joints=others).any()
    # a step that never comes back, and two steps the same way, are not a transient offset
    j = walk.skeleton.index("LeftElbow")
    stepped, _ = turned(walk, "LeftElbow", np.arange(400, walk.num_frames), 30.0)
    assert not ssa.transient_offsets(stepped)[:, j].any()
    twice, _ = turned(stepped, "LeftElbow", np.arange(450, walk.num_frames), 30.0)
    assert not ssa.transient_offsets(twice)[:, j].any()
    back, _ = turned(walk, "LeftElbow", np.arange(400, 450), 30.0)
    assert np.flatnonzero(ssa.transient_offsets(back)[:, j]).tolist() == list(range(400, 450))
    with pytest.raises(ValueError, match="max_s"):
        ssa.transient_offsets(walk, max_s=0.0)


def test_transient_offsets_at_30_fps_find_errors_and_leave_fast_motion_alone():
    """At 30 fps fast motion breaks too: the untouched takes give nothing, a flip and a drift are found exactly."""
    for name in ("12_walk.amc", "131_01.bvh", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"):
        assert not ssa.transient_offsets(mocapkit.load(mocapkit.samples.path(name)).resample(30.0)).any(), name
    walk30 = mocapkit.load(mocapkit.samples.path("12_walk.amc")).resample(30.0)
    for kind, seed in (("flip", 0), ("drift", 1)):
        bad, _, records = corrupt.real_errors(walk30, kinds=(kind,), n_errors=1, seed=seed)
        r = records[0]
        offsets = ssa.transient_offsets(bad)
        assert np.flatnonzero(offsets[:, walk30.skeleton.index(r.joint)]).tolist() == list(range(r.start, r.end)), kind
        assert offsets.sum() == r.end - r.start


BANDAI_RUN = Path(__file__).resolve().parents[2] / "data" / "dataset-2_run_active_049.bvh"


def test_side_swaps_at_30_fps_only_where_labels_swap():
    """Bandai Namco run, 30 fps (a clean studio take): no side swap; a real swap there is found exactly."""
    run = mocapkit.load(BANDAI_RUN)
    assert not ssa.side_swaps(run).any()
    bad, _, records = corrupt.real_errors(run, kinds=("swap",), n_errors=1, seed=0)
    expect = np.zeros((run.num_frames, run.num_joints), dtype=bool)
    for r in records:
        expect[r.start : r.end, run.skeleton.index(r.joint)] = True
    assert np.array_equal(ssa.side_swaps(bad), expect)


def test_a_mirror_symmetric_step_of_both_limbs_is_not_a_swap(walk):
    """Both arms step out together and back (the same turn mirrored): breaks on both sides, twice, but each joint
    steps away from its partner's mirror image, not onto it."""
    mirrored = cues.mirrored_rotations(walk)
    assert mirrored is not None
    sk = walk.skeleton
    frames = np.arange(400, 450)
    a, _ = turned(walk, "LeftShoulder", frames, 40.0)
    rot = np.array(a.rotations)
    rot[:, sk.index("RightShoulder")] = a.mirror().rotations[:, sk.index("RightShoulder")]  # right = mirror of left
    sym = dataclasses.replace(walk, rotations=rot)
    both = cues.own_breaks(cues.midpoint_residuals(sym.rotations), 6.0)
    assert both[:, sk.index("LeftShoulder")].any() and both[:, sk.index("RightShoulder")].any()
    assert not ssa.side_swaps(sym).any()


def test_a_limb_stepping_off_and_back_at_once_is_not_a_transient_offset(walk):
    """Hip and knee of one leg step off their path and back at the same frames: motion of the limb, not an
    error of one joint; either joint alone is an offset, and so is a joint with its mirror partner (a swap)."""
    frames = np.arange(400, 450)
    hip, knee = walk.skeleton.index("LeftHip"), walk.skeleton.index("LeftKnee")
    one, _ = turned(walk, "LeftHip", frames, 30.0)
    assert np.flatnonzero(ssa.transient_offsets(one)[:, hip]).tolist() == list(range(400, 450))
    both, _ = turned(one, "LeftKnee", frames, 30.0)
    offsets = ssa.transient_offsets(both)
    assert not offsets[:, hip].any() and not offsets[:, knee].any()
    pair, _ = turned(one, "RightHip", frames, 30.0)
    assert ssa.transient_offsets(pair)[:, hip].sum() == 50
