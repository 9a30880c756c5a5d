"""The streaming EBF (deep.Denoiser) and its batch counterpart (deep.denoise_rows) read each joint's Euler triple on
one branch, as deep.denoise does (channels.euler_values), on a real Bandai Namco turn whose Hips (ZXY) sits at the
gimbal lock: the plain conversion of its rotations changes branch at frame 7."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep.channels import encode, euler_values
from mocapkit.io.euler_branches import continuous_rotations

TURN = Path(__file__).resolve().parents[1] / "data" / "dataset-2_walk-turn-left_exhausted_005.bvh"


@pytest.fixture(scope="module")
def turn():
    return mocapkit.load(TURN)


@pytest.fixture(scope="module")
def model(turn):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the shipped Bandai EBF's non-commercial notice
        return deep.inference.model_of_kind(None, "ebf", turn.skeleton)


def _hips_cols(sk):
    start = sum(len(sk.joint_channels(j)) for j in range(sk.index("Hips")))
    return np.arange(start + 3, start + 6)  # Hips: 3 positions, then Z X Y rotations


def _stream(sk, rows, fps, model, calibrate=True):
    s = deep.Denoiser(sk, fps, model, calibrate=calibrate)
    out = [o for o in (s.push(r) for r in rows) if o is not None]
    return np.array(out + s.flush())


def test_the_take_crosses_the_lock(turn):
    rows = turn.channel_values()
    step = np.abs(np.diff(rows[:, _hips_cols(turn.skeleton)], axis=0))
    assert ((step > 90.0) & (step < 270.0)).any()  # the plain conversion jumps by ~180 deg: the other branch


def test_rows_on_either_branch_read_as_the_encoding_of_deep_denoise(turn, model):
    sk = turn.skeleton
    plain = turn.channel_values()
    one = plain.copy()
    continuous_rotations(one, [sk.joint_channels(j) for j in range(sk.num_joints)])
    assert np.array_equal(euler_values(plain, sk), encode(turn, model.layout)[0])
    assert np.array_equal(euler_values(one, sk), euler_values(plain, sk))


def test_streaming_equals_offline_across_the_lock_and_does_not_jump(turn, model):
    sk = turn.skeleton
    plain = turn.channel_values()  # on the other branch from frame 7 on
    one = plain.copy()
    continuous_rotations(one, [sk.joint_channels(j) for j in range(sk.num_joints)])  # the same rotations, one branch
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        offline = deep.denoise_rows(sk, plain, turn.fps, model, calibrate=True)
        stream = _stream(sk, plain, turn.fps, model)
        stream_one = _stream(sk, one, turn.fps, model)
    wrap = lambda d: (d + 180.0) % 360.0 - 180.0  # noqa: E731
    assert stream.shape == plain.shape
    assert np.abs(wrap(stream - offline)).max() < 1e-3  # float32 rounding only
    assert np.abs(wrap(stream - stream_one)).max() < 1e-9  # the branch a row comes on does not matter
    # the calibration keeps this clean turn's Hips as it came: its channels step as the input's on that branch do
    # (Z and Y swing against each other at the lock), its rotation by no more than the input's
    hips = sk.index("Hips")
    q = mocapkit.Motion.from_channel_values(sk, stream, turn.fps, animated_offsets=True).rotations[:, hips]
    q_in = turn.rotations[:, hips]
    assert R.geodesic_angle(q[1:], q[:-1]).max() <= R.geodesic_angle(q_in[1:], q_in[:-1]).max() + 1e-6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        widths = _stream(sk, plain, turn.fps, model, calibrate=False)  # the network's own widths
    step = np.abs(wrap(np.diff(widths[:, _hips_cols(sk)], axis=0)))
    assert step.max() < 45.0
