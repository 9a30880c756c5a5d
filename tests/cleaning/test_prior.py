"""The Gaussian gap prior (mocapkit.cleaning.deep.prior): its conditional mean, model files, its use in fill."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.ndimage import gaussian_filter1d

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import prior as P
from mocapkit.cleaning.deep.channels import encode


def _coupled(F: int, seed: int, fps: float = 30.0) -> np.ndarray:
    """Three synthetic channels (degrees): a smooth random walk a, b = 2 a + 5, c = -a / 2 delayed by the prior's lag."""
    rng = np.random.default_rng(seed)
    a = np.cumsum(gaussian_filter1d(rng.normal(size=F + 20), 3.0)) * 2.0
    d = int(round(P.LAG_S * fps))
    return np.stack([a[20:], 2.0 * a[20:] + 5.0, -0.5 * a[20 - d : F + 20 - d]], axis=1)


def test_lagged_vectors_clamp_at_the_ends():
    x = np.arange(5.0)[:, None] * [1.0, 10.0]
    v = P.lagged(x, [-2, 0, 1])
    assert v.shape == (5, 6)
    assert v[:, 0].tolist() == [0, 0, 0, 1, 2] and v[:, 2].tolist() == [0, 1, 2, 3, 4] and v[:, 4].tolist() == [1, 2, 3, 4, 4]
    assert np.array_equal(v[:, 5], 10 * v[:, 4])


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 10_000), st.integers(31, 150), st.sampled_from([0, 1, 2]))
def test_a_linearly_coupled_channel_is_recovered_and_observed_entries_kept(seed, n, c):
    """Where a channel is a linear function of the others, its conditional mean over a long gap is that function:
    far closer to the truth than linear interpolation, observed entries returned bit for bit."""
    x = _coupled(600, seed)
    prior = P.fit_gap_prior([_coupled(3000, seed + 1), _coupled(3000, seed + 2)], 30.0, ridge=1e-4)
    s = 200
    g = x.copy()
    g[s : s + n, c] = np.nan
    out = P.conditional_fill(g, prior, 30.0)
    assert np.array_equal(out[~np.isnan(g)], x[~np.isnan(g)])
    assert np.isfinite(out).all()
    err = np.sqrt(np.mean((out[s : s + n, c] - x[s : s + n, c]) ** 2))
    lerp = np.sqrt(np.mean((deep.lerp_fill(g)[s : s + n, c] - x[s : s + n, c]) ** 2))
    assert err < 0.3 * lerp + 0.3  # the rest: the regression reads the 58 ms smoothing of the others


def test_gaps_at_the_take_ends_and_joint_events():
    """A gap at either end is offset from its one observed side; two channels lost over the same frames are one
    event, predicted from the third only."""
    x = _coupled(400, 3)
    prior = P.fit_gap_prior([_coupled(4000, 4)], 30.0, ridge=1e-4)
    g = x.copy()
    g[:40, 0] = np.nan  # the take's start
    g[350:, 2] = np.nan  # its end
    g[150:250, 0] = g[150:250, 1] = np.nan  # a and b together: c alone says where they were
    out = P.conditional_fill(g, prior, 30.0)
    miss = np.isnan(g)
    assert np.isfinite(out).all() and np.array_equal(out[~miss], x[~miss])
    for c, sl in ((0, slice(0, 40)), (2, slice(350, 400)), (0, slice(150, 250)), (1, slice(150, 250))):
        err = np.sqrt(np.mean((out[sl, c] - x[sl, c]) ** 2))
        hold = np.sqrt(np.mean((deep.lerp_fill(g)[sl, c] - x[sl, c]) ** 2))
        assert err < 0.5 * hold + 0.1, (c, sl, err, hold)


def test_the_fill_meets_the_observed_samples_at_a_gap_edge():
    x = _coupled(500, 5)
    prior = P.fit_gap_prior([_coupled(3000, 6)], 30.0, ridge=1.0)  # a strong ridge: the prediction alone is off
    g = x.copy()
    g[100:300, 1] = np.nan
    out = P.conditional_fill(g, prior, 30.0)
    base = gaussian_filter1d(deep.lerp_fill(g), P.SMOOTH_S * 30.0, axis=0, mode="nearest")
    step = np.abs(np.diff(x[:, 1])).max()  # the largest frame-to-frame change of the truth
    assert abs(out[100, 1] - base[99, 1]) < 2 * step and abs(out[299, 1] - base[300, 1]) < 2 * step


def test_the_prior_reads_the_channels_it_is_given():
    """``smoothed``: the channels the regression reads and the gap's ends are met on. The prior's own 58 ms Gaussian
    given explicitly is the default; the clean channels given (a perfect denoiser) fill a noisy take's gap better
    than the Gaussian's reading of the noise; a reading of another shape, or missing an observed entry, is refused."""
    x = _coupled(600, 7)
    prior = P.fit_gap_prior([_coupled(4000, 8)], 30.0)
    noisy = x + np.random.default_rng(9).normal(scale=3.0, size=x.shape)
    g = noisy.copy()
    g[200:330, 0] = np.nan
    base = gaussian_filter1d(deep.lerp_fill(g), P.SMOOTH_S * 30.0, axis=0, mode="nearest")
    assert np.array_equal(P.conditional_fill(g, prior, 30.0, smoothed=base), P.conditional_fill(g, prior, 30.0))
    read = np.where(np.isnan(g), np.nan, x)  # the observed entries without their noise; the gap may stay NaN
    out = P.conditional_fill(g, prior, 30.0, smoothed=read)
    miss = np.isnan(g)
    assert np.array_equal(out[~miss], noisy[~miss])

    def err(a):
        return float(np.sqrt(np.mean((a[200:330, 0] - x[200:330, 0]) ** 2)))

    assert err(out) < err(P.conditional_fill(g, prior, 30.0))
    with pytest.raises(ValueError, match="smoothed"):
        P.conditional_fill(g, prior, 30.0, smoothed=read[:-1])
    bad = read.copy()
    bad[10, 1] = np.nan
    with pytest.raises(ValueError, match="smoothed"):
        P.conditional_fill(g, prior, 30.0, smoothed=bad)


def test_prior_arrays_round_trip_and_refuse_inconsistent_ones():
    prior = P.fit_gap_prior([_coupled(300, 7)], 30.0)
    back = P.GapPrior.from_arrays(prior.to_arrays())
    assert np.array_equal(back.cov, prior.cov) and back.lags.tolist() == [-8, 0, 8] and back.frames == prior.frames
    bad = prior.to_arrays()
    bad["scale"] = bad["scale"][:-1]
    with pytest.raises(ValueError, match="inconsistent"):
        P.GapPrior.from_arrays(bad)
    with pytest.raises(ValueError, match="channels"):
        P.conditional_fill(np.zeros((10, 4)), prior, 30.0)
    with pytest.raises(ValueError, match="finite"):
        P.fit_gap_prior([np.full((10, 3), np.nan)], 30.0)


# -- in the EBD model and in fill -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(mocapkit.samples.path("12_walk.amc"))


def test_a_model_file_keeps_its_prior_and_fill_chooses_by_method(tmp_path, walk):
    ebd = deep.shipped_model("ebd")
    assert ebd.prior is not None and ebd.prior.num_channels == ebd.layout.num_channels
    bare = dataclasses.replace(ebd, prior=None)
    deep.save_model(ebd, tmp_path / "with.pt")
    deep.save_model(bare, tmp_path / "without.pt")
    again = deep.load_model(tmp_path / "with.pt")
    assert np.array_equal(again.prior.cov, ebd.prior.cov) and deep.load_model(tmp_path / "without.pt").prior is None
    x, ctx = encode(walk, ebd.layout)
    x[100:220, 10:13] = np.nan
    by_prior = deep.fill_channels(x, ctx, ebd, smooth=False)
    assert np.array_equal(by_prior, deep.fill_channels(x, ctx, ebd, smooth=False, method="prior"))
    assert np.array_equal(by_prior, P.conditional_fill(x, ebd.prior, walk.fps))  # at the model's own rate
    by_net = deep.fill_channels(x, ctx, ebd, smooth=False, method="ebd")
    assert np.array_equal(by_net, deep.fill_channels(x, ctx, bare, smooth=False))  # no prior: the network
    assert not np.array_equal(by_net, by_prior)
    with pytest.raises(ValueError, match="no gap prior"):
        deep.fill_channels(x, ctx, bare, method="prior")
    with pytest.raises(ValueError, match="method"):
        deep.fill_channels(x, ctx, ebd, method="spline")
    gappy, _ = corrupt.gaps(walk, seed=2, start_prob=0.01)
    for bad, model in (("spline", None), ("prior", bare)):  # a bad request is an error, never the spline fallback
        with pytest.raises(ValueError, match="method|no gap prior"):
            deep.fill_or_fallback(gappy, model, method=bad)


def test_the_shipped_prior_fills_a_long_knee_gap_better_than_lerp(walk):
    """Mall's Fig. 10 case on a held-out take: the left knee's flexion missing for 1.5 s under 0.5 noise (one
    case: measured 23.0 deg by the prior updated by the take's own frames, 20.3 by the prior alone, 19.1
    by the network, 26.8 by lerp + Gaussian; the benchmarks compare the fills over many gaps)."""
    ebf, ebd = deep.shipped_model("ebf"), deep.shipped_model("ebd")
    noisy, _ = corrupt.angular_noise(walk, 0.5, seed=2)
    y, _ = encode(walk, ebf.layout)
    x, ctx = encode(noisy, ebf.layout)
    c = list(ebf.layout.names).index("ltibia.Xrotation")
    x[60:240, c] = np.nan
    gap = np.isnan(x)

    def rms(a):
        d = (a - y + 180.0) % 360.0 - 180.0
        return float(np.sqrt(np.mean(d[gap] ** 2)))

    lerp_gauss = gaussian_filter1d(deep.lerp_fill(x), 0.058 * 120, axis=0, mode="nearest")
    prior = deep.denoise_channels(deep.fill_channels(x, ctx, ebd, smooth=False), ctx, ebf)
    net = deep.denoise_channels(deep.fill_channels(x, ctx, ebd, smooth=False, method="ebd"), ctx, ebf)
    assert rms(prior) < 0.9 * rms(lerp_gauss) and rms(net) < 0.8 * rms(lerp_gauss)


def test_training_an_ebd_fits_its_prior(tmp_path, walk):
    from mocapkit.cleaning.deep import training

    cfg = training.TrainConfig(kind="ebd", hidden=8, epochs=1, steps_per_epoch=2, batch=2, crop=40,
                               noise=("angular:0.5",), variants=1)
    m = training.train([walk[:200]], tmp_path, cfg, executor="serial", progress=False)
    again = deep.load_model(tmp_path / "model.pt")
    assert m.prior is not None and again.prior is not None and again.prior.frames == m.prior.frames
    x, _ = encode(walk[:200], again.layout)
    assert np.allclose(again.prior.mean[again.prior.num_channels : 2 * again.prior.num_channels], x[::4].mean(0))


def test_whole_frames_missing_fall_back_to_a_ramp_between_the_gap_ends():
    """With every channel missing around the gap nothing is read: the mean pose, offset to meet both ends, is
    the straight line between the (smoothed) samples either side."""
    x = _coupled(300, 8)
    prior = P.fit_gap_prior([_coupled(2000, 9)], 30.0)
    g = x.copy()
    g[100:130] = np.nan
    out = P.conditional_fill(g, prior, 30.0)
    base = gaussian_filter1d(deep.lerp_fill(g), P.SMOOTH_S * 30.0, axis=0, mode="nearest")
    r = (np.arange(100, 130) - 99)[:, None] / 31.0
    assert np.allclose(out[100:130], (1 - r) * base[99] + r * base[130], atol=1e-9)


def test_the_precision_route_is_the_conditional_mean_formula():
    """conditional_fill solves the precision's few unobserved entries; the textbook formula solves the observed
    block, S_mo (S_oo + ridge I)^-1 (v_o - mu_o): the same numbers (a slow reference)."""
    x = _coupled(300, 10)
    prior = P.fit_gap_prior([_coupled(2000, 11), _coupled(2000, 12)], 30.0)
    g = x.copy()
    g[100:160, 1] = np.nan
    out = P.conditional_fill(g, prior, 30.0, prior_s=np.inf)  # the prior alone (no update from the take)
    base = gaussian_filter1d(deep.lerp_fill(g), P.SMOOTH_S * 30.0, axis=0, mode="nearest")
    z = (P.lagged(base, prior.lags) - prior.mean) / prior.scale
    C, L = 3, len(prior.lags)
    keep = np.tile(np.array([True, False, True]), L)
    tgt = 1 + C * int(np.flatnonzero(prior.lags == 0)[0])
    a = prior.cov[np.ix_(keep, keep)] + prior.ridge * np.eye(int(keep.sum()))
    pred = (z[99:161][:, keep] @ np.linalg.solve(a, prior.cov[keep, tgt])) * prior.scale[tgt] + prior.mean[tgt]
    r = (np.arange(100, 160) - 99) / 61.0
    slow = pred[1:-1] + (1 - r) * (base[99, 1] - pred[0]) + r * (base[160, 1] - pred[-1])
    assert np.allclose(out[100:160, 1], slow, rtol=0, atol=1e-9)


def test_the_take_teaches_the_prior_its_own_relations():
    """A performer whose channels relate otherwise than the training clips': the take's own complete frames
    update the prior (self-similarity), and its gap is filled by its own relation, not the training one."""
    def periodic(F, seed, relation):  # a motion that repeats: two rhythms of random phase, a third channel apart
        rng = np.random.default_rng(seed)
        t = np.arange(F) / 30.0
        a = 20 * np.sin(2 * np.pi * 0.7 * t + rng.uniform(0, 6.3)) + 10 * np.sin(2 * np.pi * 1.3 * t + rng.uniform(0, 6.3))
        c = 15 * np.sin(2 * np.pi * 0.4 * t + rng.uniform(0, 6.3))
        return np.stack([a, relation(a), c], axis=1)

    prior = P.fit_gap_prior([periodic(3000, 14, lambda a: 2 * a + 5)], 30.0, ridge=1e-3)
    x = periodic(900, 15, lambda a: 40.0 - a)  # this performer: b = 40 - a
    g = x.copy()
    g[400:460, 1] = np.nan

    def rms(out):
        return float(np.sqrt(np.mean((out[400:460, 1] - x[400:460, 1]) ** 2)))

    taught = P.conditional_fill(g, prior, 30.0)
    alone = P.conditional_fill(g, prior, 30.0, prior_s=np.inf)
    lerp = deep.lerp_fill(g)
    assert rms(taught) < 0.25 * rms(lerp) and rms(taught) < 0.25 * rms(alone)
    assert np.array_equal(taught[~np.isnan(g)], x[~np.isnan(g)])
    short = g[380:480]  # 100 frames, 40 of them complete: the update still happens, weighted 40 / (40 + 30)
    assert not np.array_equal(P.conditional_fill(short, prior, 30.0), P.conditional_fill(short, prior, 30.0, prior_s=np.inf))


def test_the_prior_reads_through_the_ebf_at_low_rates_only(walk, monkeypatch):
    """``fill_channels`` gives the prior the EBF's reading of the observed channels at rates up to
    ``EBF_READ_MAX_FPS`` (a Bandai Namco take, 30 fps), its own 58 ms Gaussian above (a CMU walk, 120 fps)."""
    from mocapkit.cleaning.deep import inference

    bandai = mocapkit.load(Path(__file__).parents[1] / "data" / "dataset-2_run_active_049.bvh")
    for take, reads in ((walk[:240], False), (bandai, True)):
        ebf, ebd = deep.shipped_model("ebf", take), deep.shipped_model("ebd", take)
        x, ctx = encode(corrupt.angular_noise(take, 0.5, seed=3)[0], ebd.layout)
        x[20:50, :3] = np.nan
        out = deep.fill_channels(x, ctx, ebd, ebf, fps=take.fps)
        monkeypatch.setattr(inference, "EBF_READ_MAX_FPS", 0.0)
        gauss = deep.fill_channels(x, ctx, ebd, ebf, fps=take.fps)
        monkeypatch.undo()
        assert np.array_equal(out, gauss) != reads
