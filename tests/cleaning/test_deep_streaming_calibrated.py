"""The streaming EBF (deep.Denoiser) calibrates its widths as offline denoising does (sure.calibrated_log_sigma, the
one shared function), the Bandai Namco rig's wrapped channels among them: on a real Bandai dance of 240 frames (two
4 s blocks, the first calibrated mid-stream, the last at flush) at Mall's 0.5 noise, the streamed take is the
offline one (deep.denoise without its guard, deep.denoise_rows) to float32 rounding."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, metrics
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep.sure import wrapped_channels

DANCE = Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first240.bvh"


@pytest.fixture(scope="module")
def noisy():
    return corrupt.angular_noise(mocapkit.load(DANCE), 0.5, seed=4)[0]


@pytest.fixture(scope="module")
def model(noisy):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the shipped Bandai EBF's non-commercial notice
        return deep.inference.model_of_kind(None, "ebf", noisy.skeleton)


@pytest.fixture(scope="module")
def offline(noisy, model):
    """{calibrate: deep.denoise_rows of the noisy dance's rows}, each made once for the tests that compare with it."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {c: deep.denoise_rows(noisy.skeleton, noisy.channel_values(), noisy.fps, model, calibrate=c)
                for c in (True, False)}


def _apart(a, b):
    """Degrees: the largest difference between two takes' channel rows, wrapped to [-180, 180)."""
    return np.abs((a - b + 180.0) % 360.0 - 180.0).max()


def _stream(noisy, model, **kw):
    s = deep.Denoiser(noisy.skeleton, noisy.fps, model, **kw)
    pushed = [s.push(r) for r in noisy.channel_values()]
    return s, pushed, np.array([o for o in pushed if o is not None] + s.flush())


def test_the_model_has_wrapped_channels(model):
    assert wrapped_channels(model.net.std.numpy()).any()  # the Bandai rig's UpperLeg_R, Hips


def test_streaming_equals_offline_calibrated(noisy, model, offline):
    rows = noisy.channel_values()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s, pushed, stream = _stream(noisy, model, calibrate=True)
        take = deep.denoise(noisy, model, guard=False)
    assert s.lag == 179  # a 120-frame block and the 60 frames that fix its edges
    assert [o is None for o in pushed] == [k < s.lag for k in range(len(rows))]
    assert stream.shape == rows.shape
    assert _apart(stream, offline[True]) < 1e-3  # float32 rounding only
    streamed = mocapkit.Motion.from_channel_values(noisy.skeleton, stream, noisy.fps, animated_offsets=True)
    assert np.degrees(np.nanmax(metrics.geodesic_pose_distance(take, streamed)[:, 1:])) < 1e-3


def test_uncalibrated_streaming_keeps_the_network_widths_15_frames_behind(noisy, model, offline):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s, pushed, stream = _stream(noisy, model, calibrate=False)
        default = deep.Denoiser(noisy.skeleton, noisy.fps, model)
    assert default.lag == 15  # a live stream's default: the look-ahead, not a block and a half
    assert s.lag == 15 and pushed[14] is None and pushed[15] is not None
    assert _apart(stream, offline[False]) < 1e-3
    assert _apart(stream, offline[True]) > 1.0  # the calibration changes the take
