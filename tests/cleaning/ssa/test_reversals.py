"""A stretch played backwards is named as such, not as a left/right swap (real takes: HDM05 jog, CMU walk,
Bandai Namco run at 30 fps)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa import cues

BANDAI_RUN = Path(__file__).resolve().parents[2] / "data" / "dataset-2_run_active_049.bvh"


def _jog():
    return mocapkit.load(mocapkit.samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"),
                         asf=mocapkit.samples.path("HDM_bd.asf"))


def _reversed(motion, a: int, b: int):
    """``motion`` with frames ``a .. b - 1`` played backwards (rotations and the root's path)."""
    q, r = np.array(motion.rotations), np.array(motion.root_positions)
    q[a:b], r[a:b] = q[a:b][::-1].copy(), r[a:b][::-1].copy()
    return dataclasses.replace(motion, rotations=q, root_positions=r)


@pytest.mark.parametrize("which", ["walk", "run"])
def test_reversal_costs_tell_a_reversed_stretch_from_a_label_swap(walk, which):
    from mocapkit.cleaning.ssa.reversals import REVERSED_RATIO, reversal_costs

    m = walk if which == "walk" else mocapkit.load(BANDAI_RUN)
    rng = np.random.default_rng(5)
    steps = np.degrees(R.geodesic_angle(m.rotations[1:], m.rotations[:-1])).mean(axis=1)
    tried = 0
    while tried < 6:
        n = int(rng.uniform(0.1, 1.0) * m.fps)
        a = int(rng.integers(2, m.num_frames - n - 2))
        fwd, back = reversal_costs(_reversed(m, a, a + n).rotations, a, a + n)
        if fwd < 4 * np.median(steps):  # a stretch of whole cycles joins its ends anyway: no break to name
            continue
        tried += 1
        assert back < REVERSED_RATIO * fwd, (a, n, fwd, back)
    for seed in range(4):
        bad, _, records = corrupt.real_errors(m, kinds=("swap",), n_errors=1, seed=seed)
        for r in records:
            fwd, back = reversal_costs(bad.rotations, r.start, r.end)
            assert back >= REVERSED_RATIO * fwd, (seed, r, fwd, back)
    with pytest.raises(ValueError):
        reversal_costs(m.rotations, 0, 5)


def test_a_time_reversed_stretch_is_named_reversed_not_a_swap_and_flags_the_same_cells():
    """The HDM05 jog with 0.6 s (frames 97-168) played backwards: the side-swap cue finds the four limb joints
    breaking twice; the summary names a stretch played backwards, and no left/right swap."""
    det = ssa.detect(_reversed(_jog(), 97, 169))
    names = cues.cause_names(det.causes())
    reversed_words = dict(cues.CAUSES).get("reversed", "a stretch played backwards")
    assert det.flags[97:169].any() and reversed_words in names
    assert dict(cues.CAUSES)["swap"] not in names
    # the same cells are flagged as by the swap rule alone: only their name changed
    plain = cues.flag_rule(det.mdm, det.jumps, det.holds, det.swaps, det.offsets, det.threshold, det.fps,
                           det.params.confirm, det.params.confirm_margin_s, det.drifts(), det.spikes,
                           np.isfinite(det.digression), det.lone_spikes)
    assert np.array_equal(plain, det.flags)


def test_a_label_swap_keeps_its_name(walk):
    bad, _, records = corrupt.real_errors(walk, kinds=("swap",), n_errors=1, seed=0)
    det = ssa.detect(bad)
    r = records[0]
    names = cues.cause_names(det.causes()[r.start:r.end, walk.skeleton.index(r.joint)])
    assert dict(cues.CAUSES)["swap"] in names and not det.reversals.any()
