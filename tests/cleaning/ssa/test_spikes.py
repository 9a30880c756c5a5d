"""Spikes told from steps, and the spikes far past a joint's own motion (mocapkit.cleaning.ssa.spikes)."""

from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning.ssa import cues, spikes
from tests.cleaning.ssa.helpers import turned


def test_spike_breaks_tell_a_spike_from_a_step(walk):
    """A one-frame spike leaves the joint on its path (a spike); a step, or a drift's end, moves it to another."""
    spiked, j = turned(walk, "LeftElbow", np.array([400]), 30.0)
    q = np.asarray(spiked.rotations)
    resid = cues.midpoint_residuals(q)
    breaks = cues.own_breaks(resid, 8.0)
    assert np.flatnonzero(breaks[:, j]).tolist() == [399, 400, 401]
    assert np.array_equal(spikes.spike_breaks(q, resid, breaks)[:, j], breaks[:, j])
    stepped, j = turned(walk, "LeftElbow", np.arange(400, walk.num_frames), 30.0)
    q = np.asarray(stepped.rotations)
    resid = cues.midpoint_residuals(q)
    breaks = cues.own_breaks(resid, 8.0)
    assert np.flatnonzero(breaks[:, j]).tolist() == [399, 400]
    assert not spikes.spike_breaks(q, resid, breaks)[:, j].any()


def _lone(m, judged=None):
    from mocapkit.cleaning.ssa.texture import informative_joints

    q = np.asarray(m.rotations, dtype=np.float64)
    analysed = np.zeros(m.num_joints, dtype=bool)
    analysed[informative_joints([m])] = True
    judged = np.zeros(q.shape[:2], dtype=bool) if judged is None else judged
    return spikes.lone_spikes(q, cues.midpoint_residuals(q), judged, analysed, m.skeleton.parents), analysed


@pytest.mark.parametrize("path, frames, seed, found", [
    (Path("hdm05_asfamc") / "HDM_mm_lieDownFloor_015_120.amc", slice(None), 45313, 4),
    (Path("hdm05_asfamc") / "HDM_mm_depositFloorR_019_120.amc", slice(None, None, 4), 3, 4),
    # a 35 deg spike on a dancing shin (3 times its own largest residual: the MDM's to judge) and a 32 deg one
    # on a dancing upper arm (4.3 times) are left
    (Path("secondary_bandai_namco_CC-BY-NC") / "dataset-1_dance-short_normal_001.bvh", slice(900), 46520, 2),
])
def test_lone_spikes_flag_a_spike_far_past_the_joints_own_motion_and_nothing_on_the_clean_take(shared_data, path,
                                                                                                frames, seed, found):
    """trialA finding 4: 30-90 deg spikes of 1-3 frames on joints that lie down, dance or put a box down (120
    and 30 fps) stand out from everything else the joint does in the take (the lying toes' largest frame
    step elsewhere 1.7 deg); flagged on their own frames, not on the untouched take, not where judged."""
    m = mocapkit.load(shared_data / path)[frames]
    assert not _lone(m)[0].any()
    bad, mask, records = corrupt.real_errors(m, kinds=("spike",), n_errors=4, seed=seed)
    lone, _ = _lone(bad)
    assert not (lone & ~mask).any()
    assert sum(bool(lone[r.start : r.end, m.skeleton.index(r.joint)].all()) for r in records) == found
    assert not _lone(bad, judged=np.ones(mask.shape, dtype=bool))[0].any()  # judged cells are the MDM's
