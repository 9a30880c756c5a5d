"""Breaks a joint's own motion makes again elsewhere (mocapkit.cleaning.ssa.recurring_peaks), and the untouched
Bandai Namco wave they, and the backed offsets' take-wide test (mocapkit.cleaning.ssa.backed), let be repaired."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning.ssa import cues
from mocapkit.cleaning.ssa.recurring_peaks import RECUR_RATIO, recurring_breaks

DATA = Path(__file__).resolve().parents[2] / "data"
BANDAI = Path.home() / ".cache/mocapkit/bandai_namco/dataset/Bandai-Namco-Research-Motiondataset-1/data"
JUMP = 8.0


def _breaks(m):
    q = np.asarray(m.rotations, dtype=np.float64)
    resid = cues.midpoint_residuals(q)
    return resid, cues.own_breaks(resid, JUMP, m.fps, q)


@pytest.fixture(scope="module")
def run():
    """A real 30 fps run (bundled): the left toe pushes off once a stride."""
    return mocapkit.load(DATA / "dataset-2_run_active_049.bvh")


def test_a_running_toes_push_offs_confirm_nothing(run):
    """The left toe's push-offs break its own level (frames 37 and 59), and the toe reaches 80 % of each at two other
    places of the take at least: the stride's motion, not an error."""
    resid, own = _breaks(run)
    j = run.skeleton.index("Toes_L")
    assert {37, 59} <= set(np.flatnonzero(own[:, j]))
    kept = recurring_breaks(resid, own, run.fps, JUMP)
    assert not kept[[37, 59], j].any()
    assert (kept <= own).all()
    r = resid[:, j]
    for f in (37, 59):
        rest = r.copy()
        rest[f - 2 : f + 3] = 0.0
        assert ((rest >= RECUR_RATIO * r[f]) & (rest <= r[f] / RECUR_RATIO)).sum() >= 2


def test_a_spike_on_the_running_toe_still_breaks(run):
    """A 40 deg one-frame spike on the same toe, between its push-offs, leaves the toe's path by more than its
    strides ever do: it still breaks, so the digression it makes is still confirmed."""
    j = run.skeleton.index("Toes_L")
    q = np.array(run.rotations)
    q[48, j] = R.quaternion_multiply(q[48, j], R.rotvec_to_quaternion(np.array([np.radians(40.0), 0.0, 0.0])))
    bad = dataclasses.replace(run, rotations=q)
    resid, own = _breaks(bad)
    assert own[48, j]
    assert recurring_breaks(resid, own, bad.fps, JUMP)[48, j]


def test_nothing_changes_at_120_fps():
    """Over about 60 fps the cap is under the break threshold: no limb motion breaks, every break is kept."""
    m = mocapkit.load(DATA / "cmu_01_01_start.bvh")
    resid, own = _breaks(m)
    assert own.any()
    assert (recurring_breaks(resid, own, m.fps, JUMP) == own).all()


@pytest.mark.skipif(not (BANDAI / "dataset-1_byebye_angry_001.bvh").is_file(),
                    reason="the unpacked Bandai Namco set (~/.cache/mocapkit/bandai_namco) is not present")
def test_the_untouched_angry_wave_comes_back_bit_identical():
    """``mocapkit clean``'s defaults on the untouched 30 fps wave changed 7 samples: the left hand's wave peak at
    frame 42 (35.6 deg, over the 33 deg cap, where the hand peaks at 35.8 and 30.6 deg at frames 30 and 38 too), and
    the right forearm's first swing on frames 5-10 (a backed offset from the swing's stop to the next wave's breaks,
    digressing 22 deg where the forearm's 90th percentile elsewhere is 15: ssa.backed). Clean motion comes back bit
    for bit."""
    m = mocapkit.load(BANDAI / "dataset-1_byebye_angry_001.bvh")
    out = mocapkit.clean(m).motion
    assert np.array_equal(np.asarray(out.rotations), np.asarray(m.rotations))
