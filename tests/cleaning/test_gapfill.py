"""Gap-filling baselines (linear, cubic, quintic spline) on channel arrays and on real clips."""

import dataclasses
import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import InterpolatedUnivariateSpline

import mocapkit
from mocapkit import corrupt, metrics, samples
from mocapkit.cleaning.filters import gaussian_smooth
from mocapkit.cleaning.gapfill import METHODS, fill_channels, fill_motion, nexus_window

CLIPS = ["12_walk.amc", "131_01.bvh", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"]


@functools.lru_cache(maxsize=None)
def clip(name: str):
    return mocapkit.load(samples.path(name))


def same_bits(a, b) -> bool:
    return np.array_equal(np.asarray(a).view(np.uint64), np.asarray(b).view(np.uint64))


def naive_fill(values, k, side=None):
    """Slow reference: one InterpolatedUnivariateSpline per gap and channel (the gapfill package's way).

    Window = ``side`` frames each side (default Nexus's ceil(n/2) + 5), observed
    samples only; interior gaps with at least (k + 1) / 2 samples on each side.
    Returns the filled array and a mask of the cells it filled.
    """
    out = values.copy()
    done = np.zeros(values.shape, dtype=bool)
    F = len(values)
    for c in range(values.shape[1]):
        miss = np.isnan(values[:, c])
        f = 0
        while f < F:
            if not miss[f]:
                f += 1
                continue
            e = f
            while e < F and miss[e]:
                e += 1
            n = e - f
            h = (n + 1) // 2 + 5 if side is None else side
            if f > 0 and e < F:
                left = [i for i in range(max(0, f - h), f) if not miss[i]]
                right = [i for i in range(e, min(F, e + h)) if not miss[i]]
                if min(len(left), len(right)) >= (k + 1) // 2:
                    x = np.array(left + right, dtype=float)
                    spl = InterpolatedUnivariateSpline(x, values[left + right, c], k=k)
                    out[f:e, c] = spl(np.arange(f, e, dtype=float))
                    done[f:e, c] = True
            f = e
    return out, done


def random_gaps(rng, F, C, start_prob, mean_len, max_len):
    mask = np.zeros((F, C), dtype=bool)
    for c in range(C):
        f = int(rng.geometric(start_prob)) - 1
        while f < F:
            n = min(int(rng.geometric(1.0 / mean_len)), max_len)
            mask[f : f + n, c] = True
            f += n + int(rng.geometric(start_prob))
    return mask


# -- fill_channels: exactness -----------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    method=st.sampled_from(METHODS),
    frac=st.floats(0.0, 0.9),
    context=st.sampled_from([None, 0.02, 0.1]),
)
def test_observed_entries_bit_identical_and_all_filled(seed, method, frac, context):
    rng = np.random.default_rng(seed)
    F, C = int(rng.integers(1, 80)), int(rng.integers(1, 6))
    x = rng.normal(size=(F, C)) * 10.0 ** rng.integers(-3, 4)
    mask = rng.random((F, C)) < frac
    v = x.copy()
    v[mask] = np.nan
    before = v.copy()
    out = fill_channels(v, method, fps=120.0, context_s=context)
    assert same_bits(v, before)  # input untouched
    assert out.shape == v.shape and out.dtype == np.float64
    assert same_bits(out[~mask], x[~mask])
    empty = mask.all(axis=0)
    assert np.isnan(out[:, empty]).all()
    assert np.isfinite(out[:, ~empty]).all()


@pytest.mark.parametrize("method,degree", [("linear", 1), ("cubic", 3), ("quintic", 5)])
def test_polynomials_up_to_the_degree_are_filled_exactly(method, degree, rng):
    F = 200
    t = np.arange(F) / 120.0 - 0.8
    coeffs = rng.normal(size=(degree + 1, 4)) * 50
    x = sum(coeffs[p] * t[:, None] ** p for p in range(degree + 1))
    mask = np.zeros_like(x, dtype=bool)
    mask[20:23, 0] = mask[60:90, 1] = mask[100:101, 2] = True  # gaps of 3, 30 and 1 frames
    mask[150:180, 3] = mask[185:190, 3] = True  # two gaps sharing a window
    v = np.where(mask, np.nan, x)
    for context in (None, 0.1):
        out = fill_channels(v, method, context_s=context)
        np.testing.assert_allclose(out[mask], x[mask], rtol=0, atol=1e-9 * np.abs(x).max())
    if degree > 1:
        # one degree higher is not reproduced: the spline really is of that degree
        x2 = x + 40 * t[:, None] ** (degree + 1)
        out = fill_channels(np.where(mask, np.nan, x2), method)
        assert np.abs(out[mask] - x2[mask]).max() > 1e-6


def test_sine_errors_fall_with_order():
    """A 1 Hz sine at 120 fps with a 12-frame gap: measured 4e-2 (linear), 4.4e-4 (cubic), 2.5e-6 (quintic)."""
    t = np.arange(240) / 120.0
    x = np.sin(2 * np.pi * t)[:, None]
    v = x.copy()
    v[100:112] = np.nan
    err = {m: np.abs(fill_channels(v, m)[100:112] - x[100:112]).max() for m in METHODS}
    assert err["linear"] > 1e-2
    assert err["cubic"] < err["linear"] / 50
    assert err["quintic"] < err["cubic"] / 50
    assert err["quintic"] < 1e-5


@pytest.mark.parametrize("k,method", [(3, "cubic"), (5, "quintic")])
@pytest.mark.parametrize("side", [None, 12])
def test_matches_one_spline_per_gap(k, method, side, rng):
    """Batched fits equal a plain per-gap FITPACK interpolating spline (gapfill's algorithm) wherever that one fills."""
    F, C = 600, 5
    x = np.cumsum(rng.normal(size=(F, C)), axis=0)
    mask = random_gaps(rng, F, C, start_prob=0.05, mean_len=6, max_len=40)
    v = np.where(mask, np.nan, x)
    ref, done = naive_fill(v, k, side)
    assert done.sum() > 0.8 * (mask.sum() - mask[:5].sum() - mask[-5:].sum())  # most gaps are spline fills
    out = fill_channels(v, method, fps=120.0, context_s=None if side is None else side / 120.0)
    np.testing.assert_allclose(out[done], ref[done], rtol=0, atol=1e-8 * np.abs(x).max())


def test_falls_back_to_lower_orders_with_few_neighbours():
    """Quintic needs 3 samples per side, cubic 2; with fewer the gap is filled by the next lower order."""
    t = np.arange(30.0)
    x = 0.01 * t**3
    v = np.tile(x[:, None], (1, 3))
    # channel 0: 3 observed samples (14-16) left of the gap 17-19 -> quintic
    # channel 1: 2 observed left (15-16)                          -> cubic
    # channel 2: 1 observed left (16)                             -> linear
    v[:14, 0] = np.nan
    v[:15, 1] = np.nan
    v[:16, 2] = np.nan
    v[17:20] = np.nan
    out = {m: fill_channels(v, m) for m in METHODS}
    lerp = np.interp(np.arange(17, 20), [16, 20], x[[16, 20]])
    assert np.allclose(out["quintic"][17:20, 0], x[17:20], atol=1e-9)
    assert np.allclose(out["quintic"][17:20, 1], x[17:20], atol=1e-9)  # cubic reproduces the cubic
    assert np.allclose(out["cubic"][17:20, 1], x[17:20], atol=1e-9)
    assert np.allclose(out["quintic"][17:20, 2], lerp, atol=1e-12)
    assert np.allclose(out["cubic"][17:20, 2], lerp, atol=1e-12)
    assert not np.allclose(lerp, x[17:20], atol=1e-3)  # the two fills really differ


def test_context_limits_the_fit_window():
    """Samples further than context_s from the gap do not change the fill; nearer ones do."""
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.normal(size=400))[:, None]
    v = x.copy()
    v[200:210] = np.nan
    base = fill_channels(v, "cubic", fps=100.0, context_s=0.2)  # 20 frames each side
    far = v.copy()
    far[:170] += 1000.0
    far[250:] -= 1000.0
    assert same_bits(fill_channels(far, "cubic", fps=100.0, context_s=0.2)[200:210], base[200:210])
    near = v.copy()
    near[185] += 5.0
    assert not same_bits(fill_channels(near, "cubic", fps=100.0, context_s=0.2)[200:210], base[200:210])
    nearer = v.copy()
    nearer[197] += 5.0
    assert np.abs(fill_channels(nearer, "cubic", fps=100.0, context_s=0.2) - base)[200:210].max() > 0.1
    # the default window (Nexus: ceil(10/2) + 5 = 10 frames) ignores frame 185 too
    assert nexus_window(10) == 10
    assert same_bits(fill_channels(near, "cubic")[200:210], fill_channels(v, "cubic")[200:210])


def test_edge_runs_hold_and_empty_channels_stay_nan():
    v = np.array(
        [
            [np.nan, np.nan, np.nan, 1.0],
            [np.nan, 2.0, np.nan, np.nan],
            [5.0, np.nan, np.nan, np.nan],
            [6.0, np.nan, np.nan, 4.0],
            [np.nan, 3.0, np.nan, np.nan],
        ]
    )
    for m in METHODS:
        out = fill_channels(v, m)
        np.testing.assert_array_equal(out[:, 0], [5.0, 5.0, 5.0, 6.0, 6.0])
        assert out[0, 1] == 2.0 and out[4, 1] == 3.0
        assert np.isnan(out[:, 2]).all()
        assert out[4, 3] == 4.0
    np.testing.assert_allclose(fill_channels(v, "linear")[1:4, 1], [2.0, 7.0 / 3.0, 8.0 / 3.0])


def test_dtype_and_trivial_shapes():
    v32 = np.array([[1.0], [np.nan], [3.0]], dtype=np.float32)
    out = fill_channels(v32)
    assert out.dtype == np.float32 and out[1, 0] == 2.0
    ints = np.arange(6).reshape(3, 2)
    assert fill_channels(ints).dtype == np.float64
    assert fill_channels(np.zeros((0, 3))).shape == (0, 3)
    assert fill_channels(np.zeros((4, 0)), "quintic").shape == (4, 0)
    assert np.isnan(fill_channels(np.full((1, 2), np.nan))).all()


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(values=np.zeros(5)), "2-D"),
        (dict(values=np.zeros((2, 3, 4))), "2-D"),
        (dict(values=np.zeros((5, 2)), method="spline"), "unknown gap-fill method 'spline'"),
        (dict(values=np.array([[1.0], [np.inf]])), "inf"),
        (dict(values=np.zeros((5, 2)), fps=0.0), "fps"),
        (dict(values=np.zeros((5, 2)), context_s=-1.0), "context_s"),
        (dict(values=np.zeros((5, 2)), context_s=float("nan")), "context_s"),
    ],
)
def test_bad_input_raises(kwargs, match):
    with pytest.raises(ValueError, match=match):
        fill_channels(**kwargs)


def test_long_clip_many_gaps_is_filled():
    """~20% of 25k frames (3.5 min at 120 Hz) x 60 channels missing in ~10k gaps of 1-240 frames: every method fills
    them all without overshoot (its speed is benchmarks'; each gap is filled from its own window, so 100k frames
    add only more gaps of the same kinds)."""
    rng = np.random.default_rng(0)
    F, C = 25_000, 60
    t = np.arange(F) / 120.0
    x = 30 * np.sin(2 * np.pi * rng.uniform(0.1, 0.5, C) * t[:, None] + rng.uniform(0, 6, C))
    mask = random_gaps(rng, F, C, start_prob=1 / 120, mean_len=30, max_len=240)
    assert 0.15 < mask.mean() < 0.25
    v = np.where(mask, np.nan, x)
    for m in METHODS:
        out = fill_channels(v, m)
        assert np.isfinite(out).all() and same_bits(out[~mask], x[~mask])
        assert np.abs(out[mask]).max() < 2 * 30  # no overshoot blowing up between far-apart observations (amplitude 30)


# -- fill_motion on real clips -------------------------------------------------------------


@pytest.mark.parametrize("name", CLIPS)
@pytest.mark.parametrize("method", METHODS)
def test_fill_motion_keeps_observed_and_fills_the_rest(name, method):
    m = clip(name)
    gappy, mask = corrupt.gaps(m, seed=1, joints=None)
    assert mask.any()
    out = fill_motion(gappy, method)
    assert out.skeleton is m.skeleton and out.fps == m.fps and out.num_frames == m.num_frames
    assert out.name == m.name
    assert not out.missing().any()
    assert same_bits(out.rotations[~mask], gappy.rotations[~mask])
    assert same_bits(out.root_positions, gappy.root_positions)  # root not gapped: untouched
    np.testing.assert_allclose(np.linalg.norm(out.rotations[mask], axis=-1), 1.0, atol=1e-12)
    # filled quaternions sit in the hemisphere of the joint's previous observed rotation
    f, j = np.nonzero(mask)
    prev = np.where(f > 0, f - 1, f)
    ok = ~mask[prev, j]
    assert np.all(np.sum(out.rotations[f[ok], j[ok]] * gappy.rotations[prev[ok], j[ok]], axis=-1) >= 0)
    err = metrics.joint_angle_rms(m, out)
    assert np.isfinite(err) and err < 10.0  # degrees; the quintic overshoots most (7.2 on 131_01)


def test_walk_default_gaps_errors():
    """12_walk, default gaps (seed 0): measured RMS lerp 0.951, cubic 1.069, quintic 2.415 degrees."""
    m = clip("12_walk.amc")
    gappy, mask = corrupt.gaps(m, seed=0)
    err = {k: metrics.joint_angle_rms(m, fill_motion(gappy, k)) for k in METHODS}
    assert err["linear"] == pytest.approx(0.9508, abs=1e-3)
    assert err["cubic"] == pytest.approx(1.0692, abs=1e-3)
    assert err["quintic"] == pytest.approx(2.4151, abs=1e-3)
    # and the error is all in the gaps: observed channels are exact
    per = metrics.joint_angle_rms(m, fill_motion(gappy, "cubic"), per_frame=True)
    assert np.all(per[~mask.any(axis=1)] == 0.0)


def test_cubic_beats_linear_on_short_gaps_of_smooth_motion():
    """Gaps of at most 0.1 s: on the walk after a 10 ms Gaussian the cubic fill beats lerp for every seed.

    (On the raw walk the capture jitter makes it a coin toss, which the
    interpolating splines of Nexus and gapfill share.)
    """
    m = gaussian_smooth(clip("12_walk.amc"), sigma_s=0.01)
    for seed in range(4):
        gappy, mask = corrupt.gaps(m, seed=seed, start_prob=0.01, mean_length_s=0.05, max_length_s=0.1)
        lin = metrics.joint_angle_rms(m, fill_motion(gappy, "linear"))
        cub = metrics.joint_angle_rms(m, fill_motion(gappy, "cubic"))
        assert cub < 0.9 * lin, (seed, lin, cub)


def test_root_trajectory_gaps_cubic_beats_linear():
    """The root trajectory is smooth: with root gaps of up to 0.25 s the cubic fill beats lerp on every seed.

    (With gaps of a few frames the millimetre jitter of the capture decides
    and either can win.)
    """
    m = clip("12_walk.amc")
    errs = []
    for seed in (0, 1, 2, 3, 5):  # seed 4 draws no gap
        gappy, mask = corrupt.gaps(m, seed=seed, joints=[0], start_prob=0.01, max_length_s=0.25)
        assert mask[:, 0].any() and not mask[:, 1:].any()
        e = {}
        for k in ("linear", "cubic"):
            out = fill_motion(gappy, k)
            assert same_bits(out.root_positions[~mask[:, 0]], m.root_positions[~mask[:, 0]])
            assert same_bits(out.rotations[:, 1:], m.rotations[:, 1:])
            e[k] = np.sqrt(np.mean((out.root_positions - m.root_positions)[mask[:, 0]] ** 2))
        errs.append(e)
        assert e["cubic"] <= e["linear"], (seed, e)
    assert np.mean([e["cubic"] for e in errs]) < 0.8 * np.mean([e["linear"] for e in errs])


def test_fill_motion_unwraps_across_180():
    """A joint turning steadily through +-180 degrees is filled along the turn, not back through 0."""
    m = clip("131_01.bvh")[:200]
    sk = m.skeleton
    values = m.channel_values()
    names = m.channel_names()
    j = 1
    col = names.index(f"{sk.joint_names[j]}.{sk.joint_channels(j)[0]}")
    turn = np.linspace(150.0, 210.0, m.num_frames)  # crosses 180 at frame ~100
    values[:, col] = (turn + 180.0) % 360.0 - 180.0
    clean = mocapkit.motion.Motion.from_channel_values(sk, values, m.fps, name=m.name)
    rot = np.array(clean.rotations)
    rot[90:110, j] = np.nan
    gappy = dataclasses.replace(clean, rotations=rot)
    for k in METHODS:
        out = fill_motion(gappy, k)
        err = np.degrees(metrics.geodesic_pose_distance(clean, out))[90:110, j]
        assert err.max() < 0.5, (k, err.max())
        filled = out.channel_values()[90:110, col]
        assert np.all((filled > -180.0) & (filled <= 180.0))


def test_fill_motion_root_and_whole_missing_joint():
    m = clip("12_walk.amc")
    gappy, mask = corrupt.gaps(m, seed=2, joints=[0, 5], start_prob=0.05, max_length_s=0.1)
    assert mask[:, 0].any()
    rot = np.array(gappy.rotations)
    rot[:, 7] = np.nan  # a joint missing in every frame stays missing
    gappy = dataclasses.replace(gappy, rotations=rot)
    out = fill_motion(gappy, "cubic")
    miss = out.missing()
    assert miss[:, 7].all() and not np.delete(miss, 7, axis=1).any()
    assert np.isfinite(out.root_positions).all()
    keep = ~mask[:, 0]
    assert same_bits(out.root_positions[keep], m.root_positions[keep])
    gap = mask[:, 0]
    rms = np.sqrt(np.mean((out.root_positions - m.root_positions)[gap] ** 2))
    assert rms < 0.5  # file units (CMU ~5.6 cm); measured 0.25


def test_fill_motion_without_gaps_returns_input_and_rejects_bad_input():
    m = clip("12_walk.amc")
    assert fill_motion(m, "cubic") is m
    with pytest.raises(ValueError, match="unknown gap-fill method"):
        fill_motion(m, "akima")
    with pytest.raises(ValueError, match="Motion"):
        fill_motion(m.rotations)
    with pytest.raises(ValueError, match="context_s"):
        fill_motion(m, "cubic", context_s=0.0)
