"""Breaks the digression backs (mocapkit.cleaning.ssa.backed): errors under a 30 fps toe's own motion level."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning.ssa import backed, cues
from mocapkit.cleaning.whole_take import detect_take, take_params

WALK = ("secondary_bandai_namco_CC-BY-NC", "dataset-1_walk_normal_001.bvh")


@pytest.fixture(scope="module")
def walk(shared_data):
    return mocapkit.load(shared_data.joinpath(*WALK))


def _turned(m, joint: str, start: int, frames: int, deg: float):
    """``m`` with ``joint`` turned ``deg`` about its own x axis over frames ``start .. start + frames - 1``."""
    j = m.skeleton.index(joint)
    q = np.array(m.rotations)
    turn = R.rotvec_to_quaternion(np.array([np.radians(deg), 0.0, 0.0]))
    q[start : start + frames, j] = R.quaternion_multiply(q[start : start + frames, j], turn[None])
    return dataclasses.replace(m, rotations=q), j


@pytest.mark.parametrize("start", [47, 81])
def test_a_two_frame_spike_beside_a_walking_toes_roll_is_flagged(walk, start):
    """A 60 deg 2-frame spike on the right toe of a real 30 fps walk, just after the toe rolls off the floor
    (residuals of 10-14 deg): its 30 deg residuals stayed under the toe's own level (3 x its 95th percentile),
    so the MDM of 1 there confirmed nothing; it leaves the path 4 times as far as the toe ever does."""
    bad, j = _turned(walk, "Toes_R", start, 2, 60.0)
    det = detect_take(bad, params=take_params()).detection
    assert det.flags[start : start + 2, j].all()
    assert det.flags.sum() == det.flags[start : start + 2, j].sum()  # nothing else


@pytest.mark.parametrize("start, frames", [(60, 30), (90, 45)])
def test_a_held_toe_offset_in_a_walk_is_flagged(walk, start, frames):
    """A 40 deg offset held 1-1.5 s on the left toe of a real 30 fps walk: its steps (20 deg residuals) join the toe's
    own roll and stayed under the toe's level; the stretch digresses by 40 deg where the frames beside it do not."""
    bad, j = _turned(walk, "Toes_L", start, frames, 40.0)
    det = detect_take(bad, params=take_params()).detection
    assert det.flags[start : start + frames, j].mean() >= 0.85
    assert det.flags.sum() == det.flags[start : start + frames, j].sum()


def test_the_clean_walk_gets_no_backed_break(walk):
    """The untouched take: no break the digression backs, on any joint (its toes roll at 10-14 deg residuals)."""
    det = detect_take(walk, params=take_params()).detection
    q = np.asarray(walk.rotations, dtype=np.float64)
    found = backed.backed_breaks(q, cues.midpoint_residuals(q), det.digression, det.analysed, walk.fps,
                                 walk.skeleton.parents)
    assert not found.any() and not det.flags.any()


def _rolling_toe(F: int = 120, fps: float = 30.0) -> np.ndarray:
    """(F, 1, 4) a toe bending 40 deg and back once a second (a roll whose midpoint residuals reach about 5 deg)."""
    t = np.arange(F) / fps
    angle = np.radians(20.0) * (1.0 - np.cos(2.0 * np.pi * t))
    return R.rotvec_to_quaternion(np.stack([angle, np.zeros(F), np.zeros(F)], axis=1))[:, None]


def test_backed_spikes_take_the_spikes_core_and_its_ratio_to_the_joints_own_residuals():
    """The maths: a 2-frame 60 deg spike joined to the roll's own breaks (one event) is found by its core; a spike
    leaving the path by less than SPIKE_RATIO times the joint's largest residual elsewhere is not."""
    q = _rolling_toe()
    clean = cues.midpoint_residuals(q)
    assert not backed.backed_spikes(q, clean, np.ones(1, dtype=bool)).any()
    bad = np.array(q)
    bad[50:52, 0] = R.quaternion_multiply(bad[50:52, 0], R.rotvec_to_quaternion(np.array([np.radians(60), 0, 0]))[None])
    got = backed.backed_spikes(bad, cues.midpoint_residuals(bad), np.ones(1, dtype=bool), jump_deg=3.0)
    assert got[:, 0].any() and set(np.flatnonzero(got[:, 0])) <= set(range(48, 54))
    ratio = np.radians(70.0) / clean.max()  # 70 deg is more than the spike leaves the path by
    assert not backed.backed_spikes(bad, cues.midpoint_residuals(bad), np.ones(1, dtype=bool), jump_deg=3.0,
                                    ratio=ratio).any()


def test_backed_offsets_need_the_stretch_alone_to_digress():
    """The maths: two break events around a stretch digressing 40 deg where beside it is 2 deg pair; the same
    stretch with the frames beside it digressing as much (a style the take holds) does not."""
    q = _rolling_toe()
    bad = np.array(q)
    bad[40:70, 0] = R.quaternion_multiply(bad[40:70, 0], R.rotvec_to_quaternion(np.array([np.radians(40), 0, 0]))[None])
    resid = cues.midpoint_residuals(bad)
    dig = np.full((120, 1), np.radians(2.0))
    dig[40:70] = np.radians(40.0)
    got = backed.backed_offsets(bad, resid, dig, np.ones(1, dtype=bool), 30.0)
    assert got[39:41, 0].any() and got[69:71, 0].any() and not got[45:65, 0].any()
    assert not backed.backed_offsets(bad, resid, np.full((120, 1), np.radians(40.0)), np.ones(1, dtype=bool), 30.0).any()
