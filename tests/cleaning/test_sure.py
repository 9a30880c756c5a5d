"""The EBF's widths calibrated by Stein's risk estimate: the estimate itself (maths on synthetic signals), and on
real takes a light touch on clean motion, the same cells in a partial run as in a whole one."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mocapkit
from mocapkit import corrupt, metrics
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import inference, sure
from mocapkit.cleaning.deep.channels import decode, encode
from mocapkit.cleaning.deep.networks import HALF_WINDOW, gaussian_filter_frames
from mocapkit.motion import concatenate


@given(st.integers(1, 5000), st.integers(1, 600))
def test_block_edges_cover_the_take_in_blocks(F, block):
    e = sure.block_edges(F, block)
    assert e[0] == 0 and e[-1] == F and np.all(np.diff(e) > 0)
    sizes = np.diff(e)
    assert np.all(sizes[:-1] == block)
    assert len(sizes) == 1 or sizes[-1] >= block / 2


def _smooth_and_noisy(F=2400, C=4, s=0.7, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(F)[:, None] / 120.0
    y = 20.0 * np.sin(2 * np.pi * np.array([0.3, 0.7, 1.1, 1.9]) * t)[:, :C]
    return y, y + rng.normal(0.0, s, y.shape)


def test_noise_std_of_white_noise_on_smooth_motion():
    y, x = _smooth_and_noisy(s=0.7)
    edges = sure.block_edges(len(x), 480)
    s, n = sure.noise_std(x, np.ones(x.shape, bool), edges)
    assert np.allclose(s, 0.7, rtol=0.1) and n.min() >= 470
    s0, _ = sure.noise_std(y, np.ones(y.shape, bool), edges)
    assert s0.max() < 0.1  # the motion itself (a 1.9 Hz swing of 20 units) adds little at 120 fps
    hidden = np.ones(x.shape, bool)
    hidden[:, 0] = False
    s_h, n_h = sure.noise_std(x, hidden, edges)
    assert (n_h[:, 0] == 0).all() and (s_h[:, 0] == 0).all()


@pytest.mark.parametrize("log_scale", [-2.0, -0.7, 0.0, 0.7])
def test_steins_estimate_tracks_the_true_risk(log_scale):
    """Summed over blocks and channels, change + 2 s^2 sum(w0) - n s^2 is within 10 % of the true squared error."""
    est, true = 0.0, 0.0
    for seed in range(4):
        y, x = _smooth_and_noisy(seed=seed)
        xp = np.concatenate([np.repeat(x[:1], HALF_WINDOW, 0), x, np.repeat(x[-1:], HALF_WINDOW, 0)]).astype(np.float32)
        log_sigma = np.full(x.shape, 1.0, np.float32)
        edges = sure.block_edges(len(x), 480)
        obs = np.ones(x.shape, bool)
        change, centre, n = sure.risk_terms(xp, log_sigma, obs, edges, np.array([log_scale]), HALF_WINDOW, 4)
        assert np.array_equal(n, np.ceil(np.diff(edges) / 4)[:, None].repeat(x.shape[1], 1))
        s, _ = sure.noise_std(x, obs, edges)
        est += 4 * float((change[0] + 2 * s**2 * centre[0] - n * s**2).sum())  # every fourth frame scored
        ls = np.clip(log_sigma + log_scale, -6, 4).astype(np.float32)
        true += float(((gaussian_filter_frames(xp, ls) - y) ** 2).sum())
    assert est == pytest.approx(true, rel=0.1)


def test_calibration_narrows_on_clean_motion_and_keeps_heavy_noise_wide():
    y, x = _smooth_and_noisy(s=2.0)
    for signal, expect_narrow in ((y, True), (x, False)):
        xp = np.concatenate([np.repeat(signal[:1], HALF_WINDOW, 0), signal, np.repeat(signal[-1:], HALF_WINDOW, 0)])
        xp = xp.astype(np.float32)
        log_sigma = np.full(signal.shape, 1.0, np.float32)
        out = sure.calibrated_log_sigma(xp, log_sigma, np.ones(signal.shape, bool), sure.block_edges(len(signal), 480),
                                        HALF_WINDOW)
        assert out.dtype == np.float32 and out.shape == signal.shape
        if expect_narrow:  # narrower than the network's width on every channel: a light touch
            assert out.max() < 1.0 - 0.3
        else:
            assert out.mean() > 0.5  # noise of 2 units keeps about the network's width
    with pytest.raises(ValueError, match="edges"):
        sure.calibrated_log_sigma(xp, log_sigma, np.ones(signal.shape, bool), np.array([0, 10]), HALF_WINDOW)



def test_a_channel_every_factor_would_make_worse_is_kept_as_it_came():
    """A 2.5 Hz swing at 30 fps under light noise (a foot's step at the Bandai Namco rig's rate), a 1-frame width:
    every factor of SCALES takes off more motion than noise, the estimate says so against the identity's N s^2, and
    the channel comes back bit-identical; a slow channel under heavy noise beside it is still filtered."""
    rng = np.random.default_rng(3)
    t = np.arange(480)[:, None] / 30.0
    y = np.concatenate([20.0 * np.sin(2 * np.pi * 2.5 * t), 20.0 * np.sin(2 * np.pi * 0.2 * t)], axis=1)
    x = y + rng.normal(0.0, 1.0, y.shape) * np.array([0.3, 4.0])
    xp = np.concatenate([np.repeat(x[:1], HALF_WINDOW, 0), x, np.repeat(x[-1:], HALF_WINDOW, 0)]).astype(np.float32)
    log_sigma = np.zeros(x.shape, np.float32)
    kept = xp[HALF_WINDOW:-HALF_WINDOW].astype(np.float64)

    def rms(z, c):
        return np.sqrt(np.mean((z[:, c] - y[:, c]) ** 2))

    for f in sure.SCALES[sure.SCALES >= 0.5]:  # the truth: these factors make the fast channel worse than its input
        assert rms(gaussian_filter_frames(xp, log_sigma + np.float32(np.log(f))), 0) > 1.2 * rms(kept, 0)
    out = sure.calibrated_log_sigma(xp, log_sigma, np.ones(x.shape, bool), sure.block_edges(len(x), 120), HALF_WINDOW)
    z = gaussian_filter_frames(xp, out)
    assert np.array_equal(z[:, 0], kept[:, 0])  # the input, to the bit
    assert np.all(out[:, 0] == sure.LOG_SIGMA_KEEP)
    assert np.all(out[:, 1] >= 0.0) and rms(z, 1) < 0.5 * rms(kept, 1)  # heavy noise: the network's width or wider


@pytest.fixture(scope="module")
def long_walk():
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    return concatenate([walk] * 4)  # 1,372 frames at 120 fps: three 4 s blocks


def test_denoise_leaves_clean_motion_nearly_alone_and_takes_light_noise_off():
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    ebf = deep.shipped_model("ebf")
    x, ctx = encode(walk, ebf.layout)

    def rms(values):
        return metrics.joint_angle_rms(walk, decode(values, walk, ebf.layout), include_root=False)

    raw = rms(inference.denoise_channels(x, ctx, ebf, fps=walk.fps, calibrate=False))
    cal = rms(inference.denoise_channels(x, ctx, ebf, fps=walk.fps))
    assert cal < 0.5 * raw  # degrees changed on a clean take
    noisy, _ = corrupt.angular_noise(walk, 0.1, seed=4)
    x, ctx = encode(noisy, ebf.layout)
    before = metrics.joint_angle_rms(walk, noisy, include_root=False)
    after = metrics.joint_angle_rms(walk, deep.denoise(noisy, ebf), include_root=False)
    uncalibrated = rms(inference.denoise_channels(x, ctx, ebf, fps=walk.fps, calibrate=False))
    assert after < 0.9 * before and after < 0.9 * uncalibrated  # the network alone made this take worse


def test_a_partial_run_gives_the_cells_of_a_whole_run(long_walk):
    ebf = deep.shipped_model("ebf")
    noisy, _ = corrupt.angular_noise(long_walk, 0.5, seed=6)
    x, ctx = encode(noisy, ebf.layout)
    whole = inference.denoise_channels(x, ctx, ebf, fps=noisy.fps)
    for until in (1, 479, 480, 481, 700, 960, 1000, len(x)):
        part = inference.denoise_channels(x, ctx, ebf, fps=noisy.fps, until=until)
        assert np.array_equal(part[:until], whole[:until]), until


def test_a_resampled_take_keeps_the_networks_widths(long_walk):
    ebf = deep.shipped_model("ebf")
    w60 = long_walk.resample(60)
    x, ctx = encode(w60, ebf.layout)
    assert np.array_equal(inference.denoise_channels(x, ctx, ebf, fps=60.0),
                          inference.denoise_channels(x, ctx, ebf, fps=60.0, calibrate=False), equal_nan=True)


def test_risk_terms_are_the_same_for_any_set_of_factors():
    """The fast path for SCALES' sqrt(2) steps gives the terms each factor gives on its own."""
    y, x = _smooth_and_noisy(F=600, s=0.5)
    xp = np.concatenate([np.repeat(x[:1], HALF_WINDOW, 0), x, np.repeat(x[-1:], HALF_WINDOW, 0)]).astype(np.float32)
    log_sigma = np.random.default_rng(1).normal(0.5, 0.8, x.shape).astype(np.float32)  # some widths clamp
    obs = np.ones(x.shape, bool)
    edges = sure.block_edges(len(x), 240)
    together = sure.risk_terms(xp, log_sigma, obs, edges, np.log(sure.SCALES), HALF_WINDOW, 2)
    for a, f in enumerate(sure.SCALES):
        alone = sure.risk_terms(xp, log_sigma, obs, edges, np.array([np.log(f)]), HALF_WINDOW, 2)
        np.testing.assert_allclose(together[0][a], alone[0][0], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(together[1][a], alone[1][0], rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(together[2], alone[2])
