"""The frames a confirmed run's breaks give it (mocapkit.cleaning.ssa.run_extent).

The real take is CMU 131_01 (bundled), judged against subject 131's other takes 131_02 and 131_03 (shared data):
its right wrist turns 133 deg in 4 frames at frame 235, a turn the other takes do not make. The digression
begins with the turn and runs on after it; the turn's breaks confirmed frames 235-242, and repair moved them up
to 91 deg with a new 28-deg pop at frame 243.
"""

from __future__ import annotations

import numpy as np
import pytest

import mocapkit
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa.run_extent import run_cells


def _run(low, breaks, spikes=None, margin=2, length=20):
    mask = np.zeros(length, dtype=bool)
    lo, br = mask.copy(), mask.copy()
    lo[list(low)] = True
    br[list(breaks)] = True
    sp = None if spikes is None else br.copy()
    return np.flatnonzero(run_cells(lo, br, sp, margin)).tolist()


def test_a_burst_with_nothing_digressing_before_it_is_not_flagged_a_step_is():
    assert _run(range(6, 14), range(6, 10)) == []  # a 4-frame burst, the digression from it on: a turn
    assert _run(range(6, 14), range(6, 8)) == list(range(6, 10))  # a step: up to the margin past it
    assert _run(range(2, 14), range(6, 10)) == list(range(2, 12))  # a burst ending a digression: kept
    assert _run(range(2, 14), [5, 6, 12, 13]) == list(range(3, 14))  # two steps: from the first, within the margin


def test_a_spike_only_run_is_its_spikes_frames():
    assert _run(range(2, 14), [7, 8, 9], spikes=True) == [8]


def test_a_fast_turn_the_context_does_not_make_is_left_as_captured(walk, shared_data):
    others = [mocapkit.load(shared_data / "cmu_bvh" / f"131_0{i}.bvh") for i in (2, 3)]
    j = walk.skeleton.joint_names.index("RightWrist")
    det = ssa.detect(walk, others)
    assert not det.flags[225:250, j].any()
    fixed = ssa.repair(walk, det, foot_skate=False)
    assert np.array_equal(fixed.rotations[225:250, j], walk.rotations[225:250, j])
