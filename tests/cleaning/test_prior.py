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

# the Bandai Namco models' licence is said by a LicenceWarning, tested in test_deep_shipped.py
pytestmark = pytest.mark.filterwarnings("ignore::mocapkit.errors.LicenceWarning")


def _coupled(F: int, seed: int, fps: float = 30.0) -> np.ndarray:
    """Three synthetic channels (degrees): a smooth random walk a, b = 2 a + 5, c = -a / 2 delayed by the prior's
    longest lag."""
    rng = np.random.default_rng(seed)
    a = np.cumsum(gaussian_filter1d(rng.normal(size=F + 20), 3.0)) * 2.0
    d = int(P.lag_frames(fps)[-1])
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
    assert np.array_equal(back.cov, prior.cov) and back.lags.tolist() == [-8, -4, -2, 0, 2, 4, 8]
    assert back.frames == prior.frames and back.ramp
    free = P.fit_gap_prior([_coupled(300, 7)], 30.0, ramp=False)
    assert not P.GapPrior.from_arrays(free.to_arrays()).ramp
    old = {k: v for k, v in prior.to_arrays().items() if k != "ramp"}  # a file written before the choice: a ramp
    assert P.GapPrior.from_arrays(old).ramp
    bad = prior.to_arrays()
    bad["scale"] = bad["scale"][:-1]
    with pytest.raises(ValueError, match="inconsistent"):
        P.GapPrior.from_arrays(bad)
    with pytest.raises(ValueError, match="channels"):
        P.conditional_fill(np.zeros((10, 4)), prior, 30.0)
    with pytest.raises(ValueError, match="finite"):
        P.fit_gap_prior([np.full((10, 3), np.nan)], 30.0)


def test_local_windows_are_the_fits_windows_at_its_stored_frames():
    """The local frames keep one frame in ``local_step``; their windows, clip by clip, are the full-rate windows at
    those frames wherever no lag reaches past a clip's end (every lag is a multiple of the step)."""
    rng = np.random.default_rng(1)
    clips = [np.cumsum(gaussian_filter1d(rng.normal(size=(n, 3)), 4.0, axis=0), axis=0) for n in (400, 250)]
    prior = P.fit_gap_prior(clips, 120.0, local_takes=clips, local_step=8)
    assert prior.local_step == 8 and prior.local_starts.tolist() == [0, 50, 82]
    win = P.local_windows(prior)
    reach = int(prior.lags.max())
    for clip, (a, b) in zip(clips, zip(prior.local_starts[:-1], prior.local_starts[1:])):
        full = (P.lagged(clip, prior.lags)[::8] - prior.mean) / prior.scale
        inner = slice(reach // 8, (b - a) - reach // 8)
        assert np.allclose(win[a:b][inner], full[inner], atol=1e-4)  # float32 frames
    assert P.fit_gap_prior(clips, 120.0, local_takes=clips).local_step == 8  # the default: about 15 frames a second
    # lags of 18, 36 and 72 frames: the largest divisor of their gcd (18) at most 120 / 15 = 8 is 6
    assert P.fit_gap_prior(clips, 120.0, lags_s=(0.15, 0.3, 0.6), local_takes=clips).local_step == 6
    with pytest.raises(ValueError, match="divide"):
        P.fit_gap_prior(clips, 120.0, local_takes=clips, local_step=3)
    assert P.local_windows(P.fit_gap_prior(clips, 120.0)).shape == (0, len(prior.mean))


def test_the_local_prior_is_the_nearest_windows_pooled_with_the_global_one():
    """Two kinds of windows; a query among the second kind draws its mean and covariance from them (``n0=0``), and
    ``n0`` windows' worth of the global prior pulls it back (the pooled mean and second moment)."""
    rng = np.random.default_rng(4)
    near = rng.normal(3.0, 0.5, (200, 6))
    far = rng.normal(-3.0, 2.0, (300, 6))
    windows = np.concatenate([far, near])
    entries = np.array([0, 1, 2, 3])  # the query is compared on these entries only
    query = np.concatenate([np.full((2, 4), 3.0), np.full((2, 2), -50.0)], axis=1)
    mean, cov = np.zeros(6), np.eye(6)
    m, c = P.local_prior(windows, query, entries, mean, cov, k=150, n0=0.0)
    chosen = np.unique(np.argpartition(np.sum((windows[:, entries] - 3.0) ** 2, axis=1), 150)[:150])
    assert np.all(chosen >= 300) and np.allclose(m, windows[chosen].mean(axis=0))
    assert np.allclose(c, np.cov(windows[chosen].T, bias=True))
    m2, c2 = P.local_prior(windows, query, entries, mean, cov, k=150, n0=150.0)
    assert np.allclose(m2, 0.5 * m)  # as many windows of the global prior as of neighbours
    second = 0.5 * (c + np.outer(m, m)) + 0.5 * (cov + np.outer(mean, mean))  # pooled second moments
    assert np.allclose(c2, second - np.outer(m2, m2))
    norms = np.einsum("ij,ij->i", windows, windows)  # computed once by the caller: the same prior, bit for bit
    m3, c3 = P.local_prior(windows, query, entries, mean, cov, k=150, n0=150.0, norms=norms)
    assert np.array_equal(m3, m2) and np.array_equal(c3, c2)
    assert P.local_prior(windows[:1], query, entries, mean, cov)[0] is mean  # too few windows: the global prior
    # nothing read around the gap (a whole-body dropout): no window is nearer than another, so the global prior
    assert P.local_prior(windows, query, np.array([], dtype=int), mean, cov)[1] is cov


def test_a_long_gap_reads_the_local_prior_and_a_short_one_the_global(monkeypatch):
    """Training takes of two couplings of their channels: the global prior averages them, the local one (drawn from
    the training windows whose other channels are like the take's around the gap) fills a long gap of the rarer
    coupling nearer the truth (8.3 against 21.5 deg; a straight line 35.5); gaps under ``LOCAL_MIN_S`` are filled exactly as without local frames, and observed
    entries are kept."""
    fps = 30.0

    def take(F, seed, sign):  # the second coupling also holds the third channel 60 deg higher: what tells them apart
        x = _coupled(F, seed, fps)
        x[:, 1] = sign * 2.0 * x[:, 0] + 5.0
        x[:, 2] += 30.0 * (1.0 - sign)
        return x

    # a small training set (600 windows of the rarer coupling), and the local prior alone: the two couplings are
    # opposite here, and pooled with the global prior they mix (on real motion pooling 300 windows' worth helps)
    monkeypatch.setattr(P, "LOCAL_K", 100)
    monkeypatch.setattr(P, "LOCAL_N0", 0.0)
    train = [take(600, s, +1.0) for s in range(6)] + [take(600, 10 + s, -1.0) for s in range(2)]
    glob = P.fit_gap_prior(train, fps)
    loc = P.fit_gap_prior(train, fps, local_takes=train, local_step=2)
    x = take(600, 30, -1.0)
    g = x.copy()
    g[200:290, 1] = np.nan  # 3 s
    g[400:405, 1] = np.nan  # short
    by_glob, by_loc = P.conditional_fill(g, glob, fps, prior_s=np.inf), P.conditional_fill(g, loc, fps, prior_s=np.inf)
    assert np.array_equal(by_loc[~np.isnan(g)], x[~np.isnan(g)])
    assert np.array_equal(by_loc[400:405], by_glob[400:405])

    def err(a):
        return float(np.sqrt(np.mean((a[200:290, 1] - x[200:290, 1]) ** 2)))

    assert err(by_loc) < 0.5 * err(by_glob)
    back = P.GapPrior.from_arrays(loc.to_arrays())
    assert np.array_equal(P.conditional_fill(g, back, fps, prior_s=np.inf), by_loc)
    bad = loc.to_arrays()
    bad["local_starts"] = bad["local_starts"][:-1]
    with pytest.raises(ValueError, match="local"):
        P.GapPrior.from_arrays(bad)


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
    case: measured 18.4 deg by the prior updated by the take's own frames, 16.9 by the prior alone, 19.1
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
    assert rms(prior) < 0.8 * rms(lerp_gauss) and rms(net) < 0.8 * rms(lerp_gauss)


def test_training_an_ebd_fits_its_prior(tmp_path, walk):
    from mocapkit.cleaning.deep import training

    cfg = training.TrainConfig(kind="ebd", hidden=8, epochs=1, steps_per_epoch=2, batch=2, crop=40,
                               noise=("angular:0.5",), variants=1)
    m = training.train([walk[:200]], tmp_path, cfg, executor="serial", progress=False)
    again = deep.load_model(tmp_path / "model.pt")
    assert m.prior is not None and again.prior is not None and again.prior.frames == m.prior.frames
    x, _ = encode(walk[:200], again.layout)
    C, l0 = again.prior.num_channels, int(np.flatnonzero(again.prior.lags == 0)[0])
    assert np.allclose(again.prior.mean[l0 * C : (l0 + 1) * C], x[::4].mean(0))  # the entries at lag 0


def test_lags_are_distinct_frames_at_every_rate():
    assert P.lag_frames(30.0).tolist() == [-8, -4, -2, 0, 2, 4, 8]
    assert P.lag_frames(120.0).tolist() == [-32, -16, -8, 0, 8, 16, 32]
    assert P.lag_frames(10.0).tolist() == [-3, -1, 0, 1, 3]  # 0.67 and 1.3 frames both round to one


def _slow_field(g: np.ndarray, prior: P.GapPrior, fps: float, s: int, e: int, chans, unread=()) -> np.ndarray:
    """The field's minimiser by brute force (a slow reference): the energy's residuals ``z(t) @ chol(P)`` over every
    frame whose window reaches the unknowns, as a function of the unknowns, its Jacobian column by column, and a
    least-squares solve. The prior alone; ``unread`` channels (missing near the gap) left out of the vectors, ``P``
    the inverse of the rest's covariance (their marginal)."""
    base = gaussian_filter1d(deep.lerp_fill(g), P.SMOOTH_S * fps, axis=0, mode="nearest")
    F, C = g.shape
    reach = int(np.abs(prior.lags).max())
    u0, u1 = (max(0, s - 2 * reach), min(F, e + 2 * reach)) if prior.ramp else (s, e)
    keep = np.tile(~np.isin(np.arange(C), unread), len(prior.lags))
    cov = prior.cov[np.ix_(keep, keep)] + prior.ridge * np.eye(int(keep.sum()))
    chol = np.linalg.cholesky(np.linalg.inv(cov))
    frames = np.arange(max(0, u0 - reach), min(F, u1 + reach))

    def residual(u):
        xb = base.copy()
        xb[u0:u1, chans] = u.reshape(u1 - u0, len(chans))
        return (((P.lagged(xb, prior.lags)[frames] - prior.mean) / prior.scale)[:, keep] @ chol).ravel()

    n = (u1 - u0) * len(chans)
    r0 = residual(np.zeros(n))
    jac = np.stack([residual(np.eye(n)[i]) - r0 for i in range(n)], axis=1)
    pred = np.linalg.lstsq(jac, -r0, rcond=None)[0].reshape(u1 - u0, len(chans))
    if not prior.ramp:
        return pred
    r = (np.arange(s, e) - (s - 1))[:, None] / (e - (s - 1))
    left, right = base[s - 1, chans] - pred[s - 1 - u0], base[e, chans] - pred[e - u0]
    return pred[s - u0 : e - u0] + (1 - r) * left + r * right


@pytest.mark.parametrize("ramp", [False, True])
@pytest.mark.parametrize("chans", [[1], [0, 2]])
@pytest.mark.parametrize("where", [(80, 110), (6, 30), (170, 195)])
def test_the_banded_solve_is_the_fields_minimiser(ramp, chans, where):
    """conditional_fill assembles the banded normal equations of the field's energy and solves them by a Cholesky of
    the band; a brute-force least squares of the same energy gives the same numbers (one channel, and two lost
    together; mid-take, where the band is added lag pair by lag pair, and near either end, where lagged frames are
    clamped and it is added entry by entry)."""
    x = _coupled(200, 10)
    prior = dataclasses.replace(P.fit_gap_prior([_coupled(2000, 11), _coupled(2000, 12)], 30.0), ramp=ramp)
    s, e = where
    g = x.copy()
    g[s:e, chans] = np.nan
    out = P.conditional_fill(g, prior, 30.0, prior_s=np.inf, cross=0.0, anchor=False)  # the prior alone, read by the Gaussian
    assert np.allclose(out[s:e][:, chans], _slow_field(g, prior, 30.0, s, e, chans), rtol=0, atol=1e-7)
    assert np.array_equal(out[~np.isnan(g)], x[~np.isnan(g)])


@pytest.mark.parametrize("unread", [[2], [0, 2]])
def test_a_channel_missing_near_a_gap_is_marginalised_out(unread):
    """Another channel missing within the field's reach of a gap is not read there: the gap is filled under the
    marginal of the rest (conditional_fill: a Schur complement of the full precision when fewer entries go than
    stay, else the inverse of the rest's covariance, as the slow reference), and that other gap is filled in its
    turn."""
    x = _coupled(200, 13)
    prior = P.fit_gap_prior([_coupled(2000, 14), _coupled(2000, 15)], 30.0, ramp=False)
    g = x.copy()
    g[80:110, 1] = np.nan
    g[118:122, unread] = np.nan  # within 2 x 8 frames of the first gap: the first one does not read them
    out = P.conditional_fill(g, prior, 30.0, prior_s=np.inf, cross=0.0, anchor=False)
    assert np.allclose(out[80:110, [1]], _slow_field(g, prior, 30.0, 80, 110, [1], unread=unread), rtol=0, atol=1e-7)
    assert np.isfinite(out).all() and np.array_equal(out[~np.isnan(g)], x[~np.isnan(g)])


def test_the_field_reads_a_channels_own_samples_around_its_gap():
    """With every channel lost over the same frames nothing else is read: the field bridges the gap from the
    channels' own samples at the lags either side (an oscillation continues where a straight line would cut it)."""
    t = np.arange(3000) / 30.0
    wave = np.stack([30 * np.sin(2 * np.pi * 0.8 * t), 20 * np.cos(2 * np.pi * 0.8 * t + 1.0)], axis=1)
    prior = P.fit_gap_prior([wave], 30.0, ridge=1e-4, ramp=False)
    x = wave[:300]
    g = x.copy()
    g[100:112] = np.nan  # a bit under half a period, across a crest
    out = P.conditional_fill(g, prior, 30.0, prior_s=np.inf, cross=0.0, anchor=False)

    def rms(a):
        return float(np.sqrt(np.mean((a[100:112] - x[100:112]) ** 2)))

    assert rms(out) < 0.2 * rms(deep.lerp_fill(g))


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
    ``EBF_READ_MAX_FPS`` (a Bandai Namco take, 30 fps), its own 58 ms Gaussian above (a CMU walk, 120 fps), where the
    EBF takes no part in the prior's fill."""
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
        # the prior's fill is not filtered again: without the EBF's reading, smooth or not is the same fill
        assert np.array_equal(out, deep.fill_channels(x, ctx, ebd, ebf, fps=take.fps, smooth=False)) != reads
        assert deep.ebf_takes_part(ebd, True) == reads and not deep.ebf_takes_part(ebd, False)
        assert deep.ebf_takes_part(ebd, True, method="ebd")  # the network's fill: Mall's EBF over it


def test_a_gap_of_a_clean_take_meets_the_samples_it_continues():
    """On a clean take the fill meets the observed samples at its ends, not their smoothed reading: 3-frame gaps of
    an HDM05 take within 0.2 deg (0.12-0.37 deg when the fill met the reading)."""
    import mocapkit
    from mocapkit import samples
    from mocapkit.cleaning import deep

    take = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    for joint in ("ltibia", "rradius", "lhumerus"):
        k = take.skeleton.index(joint)
        for start in (100, 150, 200):
            rot = np.array(take.rotations)
            rot[start:start + 3, k] = np.nan
            filled = deep.fill_gaps(dataclasses.replace(take, rotations=rot))
            q, t = filled.rotations[start:start + 3, k], take.rotations[start:start + 3, k]
            assert np.degrees(2.0 * np.arccos(np.clip(np.abs(np.sum(q * t, axis=-1)), 0.0, 1.0))).max() < 0.2


def test_the_raw_weight_is_one_on_clean_channels_and_zero_on_noisy_ones():
    from mocapkit.cleaning.deep.prior import RAW_WEIGHT_MIN, raw_weight

    rng = np.random.default_rng(0)
    t = np.arange(600) / 120.0
    clean = 30.0 * np.sin(2 * np.pi * 0.8 * t)[:, None] + np.zeros((1, 3))
    reading = gaussian_filter1d(clean, 7.0, axis=0, mode="nearest")  # bends the motion a little
    miss = np.zeros(clean.shape, dtype=bool)
    assert np.all(raw_weight(clean, reading, miss) >= RAW_WEIGHT_MIN)
    noisy = clean + rng.normal(0.0, 3.0, clean.shape)
    assert np.all(raw_weight(noisy, gaussian_filter1d(noisy, 7.0, axis=0, mode="nearest"), miss) == 0.0)


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.degrees(2.0 * np.arccos(np.clip(np.abs(np.sum(a * b, axis=-1)), 0.0, 1.0)))


def test_short_gaps_of_a_clean_30fps_take_follow_the_samples_course(monkeypatch):
    """On a clean Bandai Namco take (30 fps) 1-3 frame gaps follow the samples' course: the prior's field, which never
    reads a gap's neighbouring frames and leans towards its training mean, filled them 2.4 deg off unramped (a still
    foot 3 deg off in one frame) and 0.68 deg off ramped onto the smoothed reading (without ``anchor_ends``); the
    fill is 0.27 deg off and beats a straight line between the ends (0.31 deg; 0.76 when the Bandai prior's unramped
    field stepped off the samples at the gap's ends)."""
    from mocapkit.rotations import quaternion_continuity

    take = mocapkit.load(Path(__file__).parents[1] / "data" / "dataset-1_bow_active_001.bvh")
    rng = np.random.default_rng(3)
    rot = np.array(take.rotations)
    for k in range(1, take.num_joints):
        for n in (1, 2, 3):
            s = int(rng.integers(10, take.num_frames - 10))
            rot[s:s + n, k] = np.nan
    gappy = dataclasses.replace(take, rotations=rot)
    miss = np.isnan(rot[..., 0])

    def error(filled) -> float:
        return float(np.mean(_angle_deg(filled.rotations[miss], take.rotations[miss])))

    ours = error(deep.fill_gaps(gappy))
    q = np.array(take.rotations)
    line = []
    for k in range(1, take.num_joints):
        runs = np.flatnonzero(np.diff(np.concatenate([[0], miss[:, k].astype(int), [0]])))
        for s, e in zip(runs[::2], runs[1::2]):
            ends = quaternion_continuity(q[[s - 1, e], k])
            u = (np.arange(1, e - s + 1) / (e - s + 1))[:, None]
            lerp = (1 - u) * ends[0] + u * ends[1]
            line.append(_angle_deg(lerp / np.linalg.norm(lerp, axis=-1, keepdims=True), q[s:e, k]))
    monkeypatch.setattr(P, "anchor_ends", lambda *a, **k: None)
    alone = error(deep.fill_gaps(gappy))
    assert ours < 0.5 * alone and ours < float(np.mean(np.concatenate(line)))


def test_a_clean_30fps_takes_gaps_meet_their_ends_with_the_unramped_prior():
    """The Bandai Namco prior has no ramp (chosen on noisy clips) and its field ends where it ends: on this clean take a
    still arm's 0.33 s gap began 1.1 deg and ended 2.2 deg off the samples either side (2.3 deg mean over these five
    gaps' end frames). A clean take's gaps are ramped onto their ends (``prior.is_clean_take``): 0.5 deg."""
    take = mocapkit.load(Path(__file__).parents[1] / "data" / "dataset-1_bow_active_001.bvh")
    ends = []
    for joint, s, n in (("UpperArm_R", 60, 10), ("LowerArm_L", 30, 8), ("UpperLeg_R", 90, 12), ("Spine", 20, 6),
                        ("Hand_R", 100, 9)):
        j = take.skeleton.index(joint)
        rot = np.array(take.rotations)
        rot[s:s + n, j] = np.nan
        filled = deep.fill_gaps(dataclasses.replace(take, rotations=rot))
        ends += _angle_deg(filled.rotations[[s, s + n - 1], j], take.rotations[[s, s + n - 1], j]).tolist()
    assert np.mean(ends) < 0.8 and max(ends) < 2.0


def test_a_take_is_clean_unless_noise_fills_most_of_its_channels():
    """``is_clean_take`` on the bundled clean take, and at Mall's 0.1 and 0.5 angular noise (which keep a prior's own
    choice of the ramp)."""
    take = mocapkit.load(Path(__file__).parents[1] / "data" / "dataset-1_bow_active_001.bvh")
    ebd = deep.shipped_model("ebd", take)

    def clean(m) -> bool:
        x = encode(m, ebd.layout)[0]
        return P.is_clean_take(x, np.isnan(x), m.fps)

    assert clean(take)
    assert not clean(corrupt.angular_noise(take, 0.1, seed=1)[0])
    assert not clean(corrupt.angular_noise(take, 0.5, seed=1)[0])
    assert not P.is_clean_take(np.zeros((5, 3)), np.zeros((5, 3), dtype=bool), 30.0)  # too short to tell


def test_clean_channels_tell_fast_clean_motion_from_noise():
    """At 30 fps a fast clean channel bends as much from frame to frame as noise does (the second differences call
    it noisy); the frames where it bends least do not."""
    t = np.arange(300) / 30.0
    fast = 40.0 * np.sin(2 * np.pi * 2.0 * t) + 20.0 * np.sin(2 * np.pi * 3.1 * t + 1.0)
    x = np.stack([fast, fast + np.random.default_rng(1).normal(0.0, 4.0, len(t))], axis=1)
    miss = np.zeros(x.shape, dtype=bool)
    miss[100:103] = True
    assert P.clean_channels(np.where(miss, np.nan, x), miss, 30.0).tolist() == [True, False]
    reading = gaussian_filter1d(x, P.SMOOTH_S * 30.0, axis=0, mode="nearest")
    assert P.raw_weight(np.where(miss, np.nan, x), reading, miss)[0] == 0.0  # what the whole-take estimate says


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-5, 5), min_size=4, max_size=4), st.integers(1, 12))
def test_the_hermite_blend_is_the_cubic_near_the_ends_and_keeps_a_cubic_fill(coef, n):
    """Where the blend weighs the cubic fully (a huge rate: every frame next to an end) it reproduces a cubic
    polynomial from its end values and slopes; a fill that is that cubic comes back unchanged at any rate."""
    c0, c1, c2, c3 = coef
    f = lambda t: c0 + c1 * t + c2 * t**2 + c3 * t**3  # noqa: E731  (frames -1 .. n)
    df = lambda t: c1 + 2 * c2 * t + 3 * c3 * t**2  # noqa: E731
    inner = f(np.arange(n, dtype=float))
    args = (f(-1.0), f(float(n)), df(-1.0), df(float(n)))
    assert np.allclose(P.hermite_blend(np.full(n, 100.0), np.arange(n), n, *args, fps=1e12), inner, atol=1e-6)
    assert np.allclose(P.hermite_blend(inner, np.arange(n), n, *args, fps=30.0), inner, atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(frames=st.integers(1, 40), channels=st.integers(1, 4),
       lags=st.lists(st.integers(-60, 60), min_size=1, max_size=7), seed=st.integers(0, 2**16))
def test_lagged_is_the_clamped_gather_of_every_lag(frames, channels, lags, seed):
    """The shifted-slice form equals the reference: for each lag, frame t holds x[clip(t + lag, 0, F - 1)]."""
    x = np.random.default_rng(seed).normal(size=(frames, channels))
    t = np.arange(frames)
    ref = np.concatenate([x[np.clip(t + lag, 0, frames - 1)] for lag in lags], axis=1)
    assert np.array_equal(P.lagged(x, lags), ref)
    assert np.array_equal(P.lagged(x > 0, lags), ref > 0)


@settings(max_examples=100, deadline=None)
@given(frames=st.integers(1, 40), channels=st.integers(1, 4), seed=st.integers(0, 2**16))
def test_a_frame_missing_within_the_lags_is_a_channel_missing_in_the_lagged_vector(frames, channels, seed):
    """The take's complete rows (``_take_update``) are read from the frames' any-missing mask, lagged: the same rows
    as lagging every channel's mask."""
    rng = np.random.default_rng(seed)
    miss = rng.random((frames, channels)) < rng.random() * 0.2
    lags = deep.shipped_model("ebd").prior.lags
    assert np.array_equal((P.lagged(miss.astype(np.float64), lags) > 0).any(axis=1),
                          P.lagged(np.any(miss, axis=1)[:, None], lags).any(axis=1))


@pytest.mark.parametrize("k, nf", [(1, 9), (3, 17), (4, 5)])
def test_pair_band_is_the_add_at_it_replaces(k, nf):
    """field_fill's band added by one bincount: the same numbers, bit for bit, as np.add.at per channel pair."""
    rng = np.random.default_rng(k * 100 + nf)
    L = 7
    lags = np.array([-4, -2, -1, 0, 1, 2, 4])
    pa, pb = np.nonzero(lags[:, None] >= lags[None, :])
    d0 = lags[pa] - lags[pb]
    val = rng.normal(size=(len(pa), k, k)) * 10.0 ** rng.integers(-8, 8, size=(len(pa), k, k))
    hit = (rng.random((len(pa), nf)) < 0.7).astype(float)
    n = nf * k
    bw = min(n - 1, int(d0.max()) * k + k - 1)
    want = np.zeros((bw + 1, n))
    for j1 in range(k):
        for j2 in range(k):
            row = d0 * k + j1 - j2
            ok = (row >= 0) & (row <= bw)
            np.add.at(want, (row[ok][:, None], np.arange(j2, n, k)[None, :]), val[ok, j1, j2][:, None] * hit[ok])
    assert L == len(lags) and np.array_equal(P.pair_band(d0, val, hit, k, n, bw), want)


def test_local_priors_made_on_two_threads_fill_as_made_one_by_one(monkeypatch):
    """The long gaps' local priors are made up front in two halves on two threads: the fill is the one they give
    made in the calling thread one after the other, bit for bit."""
    from mocapkit.cleaning.deep import threads

    fps = 30.0
    train = [_coupled(600, s, fps) for s in range(4)]
    loc = P.fit_gap_prior(train, fps, local_takes=train, local_step=2)
    x = _coupled(900, 40, fps)
    g = x.copy()
    for s0, c in ((100, 1), (300, 0), (420, 2), (600, 1), (800, 0)):  # five long gaps, and a short one
        g[s0 : s0 + 40, c] = np.nan
    g[500:504, 1] = np.nan
    calls = []
    real = threads.run_in_parts

    def spy(fn, n, parts=threads.INFERENCE_PARTS, min_rows=threads.MIN_PART_ROWS):
        calls.append((n, len(threads.part_bounds(n, parts, min_rows))))
        return real(fn, n, parts, min_rows)

    monkeypatch.setattr(threads, "run_in_parts", spy)
    both = P.conditional_fill(g, loc, fps)
    monkeypatch.setattr(threads, "run_in_parts", lambda fn, n, parts=2, min_rows=1: [fn(0, n)])
    one = P.conditional_fill(g, loc, fps)
    assert calls == [(5, 2)] and np.array_equal(both, one)


@pytest.mark.parametrize("u0, u1, turns", [(20, 31, True), (0, 6, True), (40, 50, False)])
def test_field_fill_shift_is_the_shifted_copy_it_replaces(u0, u1, turns):
    """field_fill(base, ..., shift=s) reads the windows' frames minus ``s``: the same numbers, bit for bit, as
    field_fill(base - s, ...) on a shifted copy of the whole take (interior and clamped at the take's start)."""
    rng = np.random.default_rng(u0 + u1)
    F, C = 50, 6
    lags = np.array([-16, -8, 0, 8, 16])
    read = np.array([0, 1, 2, 4, 5])
    chans = np.array([1, 4])
    L, R, k = len(lags), len(read), len(chans)
    base = rng.normal(size=(F, C)) * 90.0
    a = rng.normal(size=(L * R, L * R))
    prec = a @ a.T + L * R * np.eye(L * R)
    unk = (np.arange(L)[:, None] * R + np.searchsorted(read, chans)[None, :]).ravel()
    pcols = prec[:, unk]
    mean, scale = rng.normal(size=L * R), 1.0 + rng.random(L * R)
    shift = 360.0 * rng.integers(-2, 3, size=C).astype(float) if turns else 0.0
    want = P.field_fill(base - shift, lags, mean, scale, pcols, read, chans, u0, u1)
    got = P.field_fill(base, lags, mean, scale, pcols, read, chans, u0, u1, shift=shift)
    assert np.array_equal(got, want) and np.isfinite(got).all()


BANDAI_240 = Path(__file__).parents[1] / "data" / "bandai_dance-short_normal_001_first240.bvh"


@pytest.mark.parametrize("clip, noise", [
    (mocapkit.samples.path("131_01.bvh"), 0.0), (mocapkit.samples.path("131_01.bvh"), 0.5), (BANDAI_240, 0.0),
    (BANDAI_240, 0.5), (mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"), 0.1),
])
def test_the_noise_estimates_and_gap_ends_of_all_channels_at_once_are_each_channel_s_own(clip, noise):
    """clean_channels, raw_weight and anchor_ends read every channel and gap of a real take together: bit for bit
    what each channel and gap read alone gives (tests/naive.py), clean and 0.1 / 0.5 noisy, ramped onto the
    reading and not."""
    from mocapkit.cleaning.deep.channels import lerp_fill
    from mocapkit.cleaning.runs import column_runs
    from mocapkit.motion import channel_starts
    from tests.naive import naive_anchor_ends, naive_clean_channels, naive_raw_weight

    take = mocapkit.load(clip)
    if noise:
        take = corrupt.angular_noise(take, noise, seed=1)[0]
    gone = corrupt.gaps(take, seed=2)[0].missing()  # (F, J)
    sk = take.skeleton
    starts = channel_starts([sk.joint_channels(j) for j in range(sk.num_joints)])
    miss = np.repeat(gone, np.diff(starts), axis=1)  # a joint's gap over all its channels
    miss[:5, -1] = True  # a gap from the take's first frame, and one channel missing throughout
    miss[:, 1] = True
    x = np.where(miss, np.nan, take.channel_values())
    fps = take.fps
    reading = gaussian_filter1d(lerp_fill(x), P.SMOOTH_S * fps, axis=0, mode="nearest")
    clean = naive_clean_channels(x, miss, reading, P.CLEAN_NOISE_SHARE)
    assert np.array_equal(P.clean_channels(x, miss, fps), clean)
    w = naive_raw_weight(x, reading, miss, P.RAW_WEIGHT_MIN)
    assert P.raw_weight(x, reading, miss).tobytes() == w.tobytes()
    w = np.where(clean, 1.0, w)
    for meets in (True, False):
        fill = reading + 0.3 * np.sin(np.arange(len(x)))[:, None]  # a fill that meets neither the reading nor x
        want = fill.copy()
        naive_anchor_ends(want, x, reading, miss, fps, clean, w, meets, P.HERMITE_S, P.HERMITE_MAX_S)
        P.anchor_ends(fill, x, reading, miss, fps, meets_reading=meets)
        assert fill.tobytes() == want.tobytes()
    col, s, e = column_runs(miss)
    cubic = clean[col] & (s > 0) & (e < len(x)) & (e - s <= P.HERMITE_MAX_S * fps)
    assert cubic.any() or noise > 0.0  # on a clean take the cubic had gaps to work on
