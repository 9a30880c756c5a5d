"""The blind-spot prediction of each channel from the others (mocapkit.cleaning.deep.blindspot)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.ndimage import convolve1d, gaussian_filter1d

from mocapkit.cleaning.deep import blindspot as B
from mocapkit.cleaning.deep.channels import lerp_fill


def _latent_mix(F: int, C: int, seed: int) -> np.ndarray:
    """C channels (degrees), each a fixed mix of two smooth random walks: every channel is told by the others."""
    rng = np.random.default_rng(seed)
    latent = np.cumsum(gaussian_filter1d(rng.normal(size=(F, 2)), 4.0, axis=0), axis=0) * 3.0
    return latent @ rng.normal(size=(2, C)) + rng.normal(scale=10.0, size=C)


def _slow_prediction(x: np.ndarray, fps: float, ridge: float) -> np.ndarray:
    """One ridge least squares per channel, on the frames where it is observed, as an augmented lstsq."""
    F, C = x.shape
    miss = np.isnan(x)
    xf = lerp_fill(x)
    s = B.SIGMA_S * fps
    Z = np.concatenate([gaussian_filter1d(xf, s, axis=0, mode="nearest"),
                        gaussian_filter1d(xf, 2 * s, axis=0, mode="nearest"),
                        convolve1d(xf, B.blind_kernel(s), axis=0, mode="nearest")], axis=1)
    Z = (Z - Z.mean(axis=0)) / Z.std(axis=0)
    out = x.copy()
    for c in range(C):
        o = ~miss[:, c]
        others = [k for k in range(C) if k != c]
        A = Z[:, others + [C + k for k in others] + [2 * C + c]]
        Ao = A[o] - A[o].mean(axis=0)
        y = x[o, c] - x[o, c].mean()
        n = int(o.sum())
        aug = np.vstack([Ao, np.sqrt(ridge * n) * np.eye(A.shape[1])])
        beta = np.linalg.lstsq(aug, np.concatenate([y, np.zeros(A.shape[1])]), rcond=None)[0]
        out[:, c] = x[o, c].mean() + (A - A[o].mean(axis=0)) @ beta
    return out


def test_the_blind_kernel_is_a_gaussian_without_its_centre():
    k = B.blind_kernel(1.74)
    h = len(k) // 2
    assert k[h] == 0.0 and np.isclose(k.sum(), 1.0) and np.allclose(k, k[::-1])
    assert k[h - 1] > k[h - 2] > k[0] > 0
    tiny = B.blind_kernel(0.01)  # a take at a fraction of a frame per 58 ms: the neighbours, never 0 / 0
    assert np.isfinite(tiny).all() and np.isclose(tiny.sum(), 1.0) and tiny[len(tiny) // 2] == 0.0
    x = _latent_mix(60, 4, 8)
    assert np.isfinite(B.cross_channel_prediction(x, 0.25)).all()


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([30.0, 120.0]))
def test_the_shared_gram_matrices_give_the_slow_references_prediction(seed, fps):
    """Channels observed on the same frames share one Gram matrix (the take's, less the missing rows): the same
    coefficients as one ridge regression per channel on its observed frames."""
    x = _latent_mix(400, 5, seed) + np.random.default_rng(seed).normal(size=(400, 5))
    x[50:120, 1] = np.nan
    x[200:260, [2, 3]] = np.nan
    got = B.cross_channel_prediction(x, fps, ridge=0.3)
    assert got is not None and np.isfinite(got).all()
    np.testing.assert_allclose(got, _slow_prediction(x, fps, 0.3), rtol=1e-7, atol=1e-7)


def test_noise_independent_between_channels_is_removed_and_its_share_measured():
    """Eight channels told by two latent motions, white noise on each: the prediction, fitted on the noisy take
    alone (a light ridge), lands far closer to the clean channels than the noise, and noise explains most of its
    residual; on the clean take little of it. The default ridge shrinks these large, slow channels towards their
    means: that bias is residual noise does not explain, so those channels get a small share."""
    clean = _latent_mix(1200, 8, 3)
    noisy = clean + np.random.default_rng(4).normal(scale=2.0, size=clean.shape)
    pred = B.cross_channel_prediction(noisy, 30.0, ridge=1e-3)
    assert np.sqrt(np.mean((pred - clean) ** 2)) < 0.4 * 2.0
    assert B.noise_share(noisy, pred).min() > 0.6
    assert B.noise_share(clean, B.cross_channel_prediction(clean, 30.0, ridge=1e-3)).max() < 0.1
    shrunk = B.cross_channel_prediction(noisy, 30.0)
    share = B.noise_share(noisy, shrunk)
    bias = np.sqrt(np.mean((shrunk - clean) ** 2, axis=0))
    assert share[np.argmax(bias)] < 0.2 and share[np.argmin(bias)] > 0.6


def test_short_takes_still_channels_and_bad_shapes():
    x = _latent_mix(200, 4, 5)
    assert B.cross_channel_prediction(x[:25], 30.0) is None  # under a second of complete frames
    gappy = x.copy()
    gappy[10:190, 0] = np.nan  # 20 complete frames left: not enough
    assert B.cross_channel_prediction(gappy, 30.0) is None
    x[:, 2] = 7.0  # a channel that does not move is returned as it is
    out = B.cross_channel_prediction(x, 30.0)
    assert np.array_equal(out[:, 2], x[:, 2]) and not np.allclose(out[:, 0], x[:, 0])
    assert B.cross_channel_prediction(x[:, :1], 30.0) is None  # one channel: nothing to predict it from
    with pytest.raises(ValueError, match="channels"):
        B.cross_channel_prediction(np.zeros(10), 30.0)


def test_the_inputs_are_standardised_in_place_with_the_same_numbers():
    """standardised_inputs writes the three smoothed parts into one array and standardises it in place: the parts,
    their concatenation and the centred and scaled copies were four arrays of the take's (F, 3 C) size (49 MB each
    on an 18-minute 30 fps Bandai Namco session); the numbers are those of the expression it replaced, bit for bit,
    on a real take with a constant channel (its inputs 0) and gaps."""
    import tracemalloc
    from pathlib import Path

    from mocapkit import load
    from mocapkit.motion import concatenate

    take = load(Path(__file__).resolve().parents[1] / "data" / "dataset-1_bye_giant_001.bvh")
    x = np.array(concatenate([take] * 12).channel_values())[:, :40]  # (1704, 40)
    x[100:130, 5:8] = np.nan
    x[:, 0] = 3.0
    xf = lerp_fill(x)
    s = B.SIGMA_S * take.fps
    Z = np.concatenate([gaussian_filter1d(xf, s, axis=0, mode="nearest"),
                        gaussian_filter1d(xf, 2.0 * s, axis=0, mode="nearest"),
                        convolve1d(xf, B.blind_kernel(s), axis=0, mode="nearest")], axis=1)
    sd = Z.std(axis=0)
    sd[sd < 1e-9] = np.inf
    want = (Z - Z.mean(axis=0)) / sd
    tracemalloc.start()
    try:
        got = B.standardised_inputs(xf, s)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
        B.cross_channel_prediction(x, take.fps)
        whole = tracemalloc.get_traced_memory()[1] - got.nbytes
    finally:
        tracemalloc.stop()
    assert np.array_equal(got, want) and not got[:, 0].any()
    assert peak < 2.2 * want.nbytes  # the inputs and the std's one temporary (the parts and two copies more)
    assert whole < 2.7 * want.nbytes  # the prediction: the same two and the bridged channels (it was 3 (F, 3 C) and those)
