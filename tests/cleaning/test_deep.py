"""Deep cleaning (Mall et al. 2017): filter layer maths, model files, streaming = offline, gap filling, training."""

from __future__ import annotations

import contextlib
import dataclasses
import json

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

import mocapkit
from mocapkit import corrupt, metrics
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import channels as ch
from mocapkit.cleaning.deep import networks as nw
from mocapkit.cleaning.deep import training
from mocapkit.errors import MocapFormatError, SkeletonError
from tests.shared import unknown_rig


@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(mocapkit.samples.path("12_walk.amc"))


@pytest.fixture(scope="module")
def tiny_ebf(walk):
    torch.manual_seed(0)
    lay = deep.layout_for(walk)
    net = deep.EBF(lay.num_channels, hidden=16, width=32)
    return deep.DeepModel("ebf", net, lay, walk.fps)


@pytest.fixture(scope="module")
def tiny_ebd(walk):
    torch.manual_seed(1)
    lay = deep.layout_for(walk)
    net = deep.EBD(lay.num_channels, hidden=8, width=32)
    x, _ = ch.encode(walk, lay)
    net.set_statistics(x.mean(0), np.maximum(x.std(0), 1.0), np.ones(3))
    return deep.DeepModel("ebd", net, lay, walk.fps)


# -- the filter layer ------------------------------------------------------------------


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(1e-3, 50.0), min_size=1, max_size=8))
def test_gaussian_taps_are_normalised(sigmas):
    w = nw.gaussian_weights(torch.tensor(sigmas, dtype=torch.float64))
    assert w.shape == (len(sigmas), 31)
    assert torch.allclose(w.sum(-1), torch.ones(len(sigmas), dtype=torch.float64), atol=1e-12)
    assert torch.all(w >= 0)
    # symmetric about the centre tap, and the centre is the largest
    assert torch.allclose(w, w.flip(-1), atol=1e-15)
    assert torch.all(w.argmax(-1) == 15)


def test_small_sigma_is_the_identity():
    x = torch.randn(2, 60, 5, dtype=torch.float64)
    taps = nw.gaussian_weights(torch.full((2, 30, 5), 1e-3, dtype=torch.float64))
    y = nw.apply_filter(x, taps)
    assert torch.equal(y, x[:, 15:45])


def test_filter_matches_a_direct_weighted_average():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(1, 40, 2))
    sigma = rng.uniform(0.5, 6, size=(1, 10, 2))
    y = nw.apply_filter(torch.tensor(x), nw.gaussian_weights(torch.tensor(sigma))).numpy()
    k = np.arange(-15, 16)
    for t in range(10):
        for c in range(2):
            w = np.exp(-(k**2) / (2 * sigma[0, t, c] ** 2))
            assert y[0, t, c] == pytest.approx(np.sum(w * x[0, t : t + 31, c]) / w.sum(), abs=1e-12)


def test_lookahead_lstm_backward_sees_only_its_window():
    torch.manual_seed(0)
    layer = nw.LookaheadLSTM(3, 4, lookahead=5).double()
    x = torch.randn(1, 30, 3, dtype=torch.float64)
    y, _ = layer(x)
    assert y.shape == (1, 25, 8)
    x2 = x.clone()
    x2[0, 20:] += 1.0  # frames 20.. change: outputs before 15 must not
    y2, _ = layer(x2)
    assert torch.equal(y[0, :15], y2[0, :15])
    assert not torch.equal(y[0, 15], y2[0, 15])


# -- channels --------------------------------------------------------------------------


@pytest.mark.parametrize("rep", ["euler", "rot6d"])
def test_encode_decode_round_trip(walk, rep):
    lay = deep.layout_for(walk, rep)
    x, ctx = ch.encode(walk, lay)
    assert x.shape == (walk.num_frames, lay.num_channels) and ctx.shape == (walk.num_frames, 3)
    back = ch.decode(x, walk, lay)
    assert np.array_equal(back.root_positions, walk.root_positions)
    assert np.array_equal(back.rotations[:, 0], walk.rotations[:, 0])
    assert metrics.pose_error(walk, back).max() < 1e-16


def test_euler_encode_keeps_a_joint_near_gimbal_lock_on_one_branch():
    # ZXY joint with X at 89 +- 2 deg (the Bandai Namco Hips in a heading turn): the plain conversion flips to
    # (z + 180, 180 - x, y + 180) on every frame past 90; the model must read one continuous curve
    sk = mocapkit.Skeleton(("root", "a"), [-1, 0], [[0, 0, 0], [0, 1, 0]])
    F = 120
    vals = np.zeros((F, 9))
    vals[:, 6] = 30.0 + 5.0 * np.sin(np.arange(F) / 20.0)
    vals[:, 7] = 89.0 + np.random.default_rng(0).normal(0.0, 2.0, F)
    vals[:, 8] = -20.0
    m = mocapkit.Motion.from_channel_values(sk, vals, 30.0)
    assert np.abs(np.diff(m.channel_values()[:, 6])).max() > 170.0  # the plain conversion flips
    lay = deep.layout_for(m)
    x, _ = ch.encode(m, lay)
    assert np.abs(np.diff(x, axis=0)).max() < 15.0
    # a smoother of the channels stays near the joint's rotations (mixing the branches turned it by ~180 deg)
    from scipy.ndimage import gaussian_filter1d

    smooth = ch.decode(gaussian_filter1d(x, 2.0, axis=0, mode="nearest"), m, lay)
    assert np.degrees(metrics.geodesic_pose_distance(m, smooth)).max() < 10.0


def test_euler_decode_converts_only_changed_cells_bit_for_bit(walk):
    """decode converts only the cells not kept, joint by joint: the same bits as converting every file channel
    back (Motion.from_channel_values) and then copying the kept cells, NaN and out-of-range values too."""
    import dataclasses

    from mocapkit.motion import Motion

    lay = deep.layout_for(walk, "euler")
    x, _ = ch.encode(walk, lay)
    rng = np.random.default_rng(4)
    x = x + rng.normal(scale=3.0, size=x.shape)
    x[5, 3], x[7, 0] = np.nan, 400.0
    like = dataclasses.replace(walk, rotations=np.where((np.arange(walk.num_frames) == 9)[:, None, None], np.nan,
                                                        walk.rotations))
    keep = rng.random((walk.num_frames, walk.num_joints)) < 0.7
    full = like.channel_values()
    full[:, ch.euler_columns(like)] = (x + 180.0) % 360.0 - 180.0
    rot = np.array(Motion.from_channel_values(like.skeleton, np.nan_to_num(full), like.fps, like.name).rotations)
    ref = like.rotations
    flip = np.all(np.isfinite(ref), axis=-1, keepdims=True) & (np.sum(rot * np.nan_to_num(ref), axis=-1, keepdims=True) < 0)
    rot = np.where(flip, -rot, rot)
    in_layout = np.isin(np.arange(walk.num_joints), [walk.skeleton.index(n) for n in lay.joints])
    rot[:, ~in_layout] = ref[:, ~in_layout]
    for k in (None, keep):
        want = rot if k is None else np.where(k[..., None], ref, rot)
        got = ch.decode(x, like, lay, keep=k).rotations
        assert np.array_equal(got, want, equal_nan=True)


def test_root_angular_velocity_ignores_heading(walk):
    from mocapkit import rotations as R

    q = walk.rotations[:, 0]
    turn = R.quaternion_from_axis_angle(np.array([0.0, 1.0, 0.0]), np.array(1.3))
    w1 = ch.root_angular_velocity(q, walk.fps)
    w2 = ch.root_angular_velocity(R.quaternion_multiply(turn, q), walk.fps)
    assert np.allclose(w1, w2, atol=1e-9)
    assert np.all(w1[0] == 0) and np.abs(w1).max() > 0.1


def test_unwrap_skips_gaps():
    x = np.array([[170.0], [np.nan], [-175.0], [-170.0]])
    assert np.allclose(ch.unwrap_degrees(x)[[0, 2, 3], 0], [170, 185, 190])


def test_other_skeleton_is_refused(tiny_ebf, tmp_path):
    odd = unknown_rig(tmp_path / "odd.bvh")
    with pytest.raises(SkeletonError, match="no joint map is known"):
        deep.denoise(odd, tiny_ebf)


# -- model files -----------------------------------------------------------------------


def test_saved_model_loads_and_gives_identical_output(tmp_path, walk, tiny_ebf):
    p = deep.save_model(tiny_ebf, tmp_path / "m.pt")
    again = deep.load_model(p)
    noisy, _ = corrupt.angular_noise(walk, 0.5, seed=0)
    a, b = deep.denoise(noisy, tiny_ebf), deep.denoise(noisy, again)
    assert np.array_equal(a.rotations, b.rotations)


def test_bad_model_files_are_format_errors(tmp_path):
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"not a model")
    with pytest.raises(MocapFormatError, match="junk.pt"):
        deep.load_model(junk)
    torch.save({"format": "something else"}, tmp_path / "other.pt")
    with pytest.raises(MocapFormatError, match="malformed"):
        deep.load_model(tmp_path / "other.pt")
    with pytest.raises(MocapFormatError, match="no such model"):
        deep.load_model(tmp_path / "missing.pt")


def test_model_file_with_code_is_refused(tmp_path):
    class Evil:
        def __reduce__(self):
            return (print, ("pwned",))

    torch.save({"format": deep.inference.FORMAT, "x": Evil()}, tmp_path / "evil.pt")
    with pytest.raises(MocapFormatError):
        deep.load_model(tmp_path / "evil.pt")


# -- streaming -------------------------------------------------------------------------


@pytest.mark.parametrize("calibrate", [True, False])
def test_streaming_equals_offline(walk, tiny_ebf, calibrate):
    noisy, _ = corrupt.angular_noise(walk, 0.5, seed=3)
    rows = noisy.channel_values()
    offline = deep.denoise_rows(walk.skeleton, rows, walk.fps, tiny_ebf, calibrate=calibrate)
    stream = deep.Denoiser(walk.skeleton, walk.fps, tiny_ebf, calibrate=calibrate)
    assert stream.lag == (480 + 240 - 1 if calibrate else 15)  # 120 fps: a 4 s block and the 2 s fixing its edges
    out = []
    for k, r in enumerate(rows):
        o = stream.push(r)
        assert (o is None) == (k < stream.lag)
        if o is not None:
            out.append(o)
    out += stream.flush()
    out = np.array(out)
    assert out.shape == rows.shape
    d = out - offline
    d = (d + 180.0) % 360.0 - 180.0
    assert np.abs(d).max() < 1e-3  # float32 rounding only
    assert np.array_equal(out[:, :6], rows[:, :6])  # root channels pass through


def test_streaming_rejects_bad_rows(walk, tiny_ebf):
    s = deep.Denoiser(walk.skeleton, walk.fps, tiny_ebf)
    with pytest.raises(ValueError, match="channels"):
        s.push(np.zeros(5))
    with pytest.raises(ValueError, match="finite"):
        s.push(np.full(62, np.nan))


# -- gap filling -----------------------------------------------------------------------


def test_fill_never_changes_observed_values(walk, tiny_ebd, tiny_ebf):
    gapped, mask = corrupt.gaps(walk, start_prob=0.02, seed=0)
    assert mask.any()
    filled = deep.fill_gaps(gapped, tiny_ebd, tiny_ebf)
    assert not np.isnan(filled.rotations).any()
    obs = ~gapped.missing()
    assert np.array_equal(filled.rotations[obs], walk.rotations[obs])
    assert np.array_equal(filled.root_positions, walk.root_positions)


def test_fill_channels_keeps_observed_entries_bit_identical(walk, tiny_ebd, tiny_ebf):
    lay = tiny_ebd.layout
    x, ctx = ch.encode(walk, lay)
    rng = np.random.default_rng(0)
    mask = training.gap_mask(x.shape, walk.fps, rng)
    mask[100:300, 7] = True  # a long single-channel gap
    out = deep.fill_channels(np.where(mask, np.nan, x), ctx, tiny_ebd, tiny_ebf)
    assert np.array_equal(out[~mask], x[~mask])
    assert np.isfinite(out).all()


def test_fill_refuses_an_empty_channel(walk, tiny_ebd):
    x, ctx = ch.encode(walk, tiny_ebd.layout)
    x[:, 3] = np.nan
    with pytest.raises(ValueError, match="no observed sample"):
        deep.fill_channels(x, ctx, tiny_ebd)


def test_lerp_fill():
    x = np.array([[np.nan, 1.0], [0.0, np.nan], [np.nan, np.nan], [3.0, 4.0]])
    assert np.array_equal(deep.lerp_fill(x), [[0.0, 1.0], [0.0, 2.0], [1.5, 3.0], [3.0, 4.0]])


# -- training --------------------------------------------------------------------------


def test_gap_mask_statistics():
    rng = np.random.default_rng(0)
    m = training.gap_mask((20000, 4), 120.0, rng, start_prob=1 / 120, mean_length_s=0.25)
    runs = np.diff(np.r_[0, m[:, 0].astype(int), 0])
    lengths = np.flatnonzero(runs == -1) - np.flatnonzero(runs == 1)
    assert 22 < lengths.mean() < 38  # geometric with mean 30 frames
    long = training.gap_mask((2000, 50), 120.0, rng, long=True)
    per = long.sum(0)
    assert per.max() <= 600 and np.all((per == 0) | (per >= 60))


@pytest.mark.parametrize("kind,variant", [("ebf", {}), ("ebf", {"head": "free", "bias": True}), ("ebd", {})])
def test_tiny_model_overfits_a_short_clip(tmp_path, walk, kind, variant):
    clip = walk[:200]
    # the last two epochs' best over the first (must be < 0.85): EBF 0.77 and 0.32 after 4 epochs of 10 steps (0.72
    # and 0.20 after 6 of 15); the EBD needs its 6 of 15 (0.82; 0.90 after 4 of 10)
    epochs, steps = (6, 15) if kind == "ebd" else (4, 10)
    cfg = training.TrainConfig(
        kind=kind, hidden=16, epochs=epochs, steps_per_epoch=steps, batch=8, crop=60, centres=16, lr=3e-3,
        noise=("angular:0.5",) if kind == "ebf" else ("clean",), variants=1, long_gap_share=0.0, gap_rate=1.0,
        observed_weight=0.0, **variant,
    )
    model = training.train([clip], tmp_path / kind, cfg, executor="serial", progress=False)
    h = model.meta["history"]
    assert min(x["train_rmse"] for x in h[-2:]) < 0.85 * h[0]["train_rmse"]
    assert (tmp_path / kind / "model.pt").is_file() and (tmp_path / kind / "checkpoint.pt").is_file()


def test_training_is_deterministic_and_resumable(tmp_path, walk):
    clip = walk[:160]
    cfg = training.TrainConfig(kind="ebf", hidden=8, epochs=3, steps_per_epoch=3, batch=4, crop=40,
                               noise=("angular:0.5",), variants=1)
    a = training.train([clip], tmp_path / "a", cfg, executor="serial", progress=False)
    short = training.TrainConfig(**{**cfg.__dict__, "epochs": 2})
    training.train([clip], tmp_path / "b", short, executor="serial", progress=False)
    # the same config with more epochs continues from the checkpoint, exactly as an unbroken run
    b = training.train([clip], tmp_path / "b", cfg, executor="serial", progress=False)
    ha, hb = a.meta["history"], b.meta["history"]
    assert len(hb) == 3
    assert [h["train_rmse"] for h in ha] == [h["train_rmse"] for h in hb]
    other = training.TrainConfig(**{**cfg.__dict__, "seed": 5})
    with pytest.raises(ValueError, match="other settings"):  # a changed config does not replace the folder's run
        training.train([clip], tmp_path / "b", other, executor="serial", progress=False)
    c = training.train([clip], tmp_path / "b", other, resume=False, executor="serial", progress=False)
    assert c.meta["history"][0]["train_rmse"] != ha[0]["train_rmse"]  # --restart: started over


def test_ebd_forward_at_equals_forward_on_the_gathered_windows(walk, tiny_ebd):
    """Encoding each frame once and gathering the codes is the EBD run on each window (the slow oracle),
    at the take's ends (clamped windows) and inside it."""
    net = tiny_ebd.net.double().eval()
    x, ctx = ch.encode(walk, tiny_ebd.layout)
    rng = np.random.default_rng(5)
    mask = (rng.random(x.shape) < 0.2).astype(np.float64)
    X, MK, C = (torch.as_tensor(a, dtype=torch.float64) for a in (x, mask, ctx))
    centres = torch.as_tensor(np.r_[0, 1, 3, 40, 41, 42, 200, len(x) - 2, len(x) - 1])
    idx = nw.window_indices(centres, len(X), net.half, net.stride)
    with torch.no_grad():
        slow = net(X[idx], MK[idx], C[idx])
        fast = net.forward_at(X, MK, C, centres)
    tiny_ebd.net.float()
    assert fast.shape == (len(centres), x.shape[1])
    assert torch.allclose(fast, slow, rtol=0, atol=1e-12)


def test_lookahead_backward_equals_nn_lstm_on_every_window():
    """The batched backward pass is the nn.LSTM cell run on each window x[t + L] .. x[t] (the slow oracle)."""
    torch.manual_seed(3)
    layer = nw.LookaheadLSTM(5, 6, lookahead=4).double()
    x = torch.randn(2, 23, 5, dtype=torch.float64)
    fast = layer.backward_outputs(x, chunk=6)  # several chunks
    slow = torch.stack(
        [torch.stack([layer.bwd(x[b : b + 1, t : t + 5].flip(1))[0][0, -1] for t in range(19)]) for b in range(2)]
    )
    assert fast.shape == (2, 19, 6)
    assert torch.allclose(fast, slow, atol=1e-12)


@pytest.mark.parametrize("hidden", [64, 6])  # the shipped width, and one that leaves SIMD tails in every row
def test_lookahead_backward_in_place_equals_the_autograd_pass_bit_for_bit(hidden):
    """Inference's in-place steps give what training's steps, every tensor new (the written-out reference), give."""
    torch.manual_seed(5)
    layer = nw.LookaheadLSTM(9, hidden, lookahead=7).eval()
    x = torch.randn(2, 120, 9)
    for xb, chunk, parts in ((x[:1], 8192, 1), (x[:1], 30, 2), (x, 80, 1)):
        want = layer.backward_outputs(xb, chunk=chunk, parts=parts).detach()  # grad on: the reference
        with torch.inference_mode():
            got = layer.backward_outputs(xb, chunk=chunk, parts=parts)
        assert got.dtype == torch.float32 and torch.equal(got, want)


def test_lookahead_backward_makes_two_tensors_a_step(monkeypatch):
    """In inference each recurrent step allocates only the recurrent product and tanh(c), the gates and the cell
    worked out in place in them (``torch.sigmoid`` never called, ``torch.tanh`` once a step): the ten temporaries a
    step it made before were a quarter of the pass's time on a 60 s take."""
    calls = {"sigmoid": 0, "tanh": 0}
    for name in calls:
        def counted(*a, _f=getattr(torch, name), _n=name, **k):
            calls[_n] += 1
            return _f(*a, **k)

        monkeypatch.setattr(torch, name, counted)
    layer = nw.LookaheadLSTM(5, 8, lookahead=6).eval()
    with torch.inference_mode():
        layer.backward_outputs(torch.randn(1, 40, 5), chunk=20)  # two chunks of positions, 7 steps each
    assert calls == {"sigmoid": 0, "tanh": 2 * 7}


def test_holdout_folds_are_disjoint_and_cover_the_clips(walk):
    import dataclasses

    clips = [dataclasses.replace(walk[k * 20 : k * 20 + 40], name=f"clip{k}") for k in range(11)]
    folds = training.holdout_folds(clips, 5, 2, seed=1)
    assert len(folds) == 5
    vals = [tuple(c.name for c in v) for _, v in folds]
    assert all(len(v) == 2 for v in vals) and len({n for v in vals for n in v}) == 10
    for tr, v in folds:
        assert len(tr) == 9 and not {c.name for c in tr} & {c.name for c in v}
    with pytest.raises(ValueError, match="need more than"):
        training.holdout_folds(clips, 5, 3)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.floats(-6.0, 4.0))
def test_numba_gaussian_filter_equals_the_torch_layer(seed, shift):
    """The inference filter (two exponentials per output) is eq. 1 as the training layer computes it."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(1, 45, 3)) * 30.0
    log_sigma = np.clip(rng.normal(shift, 1.5, size=(1, 15, 3)), *nw.LOG_SIGMA_RANGE)
    ref = nw.apply_filter(torch.tensor(x), nw.gaussian_weights(torch.exp(torch.tensor(log_sigma))))[0].numpy()
    fast = nw.gaussian_filter_frames(x[0], log_sigma[0])
    np.testing.assert_allclose(fast, ref, rtol=1e-9, atol=1e-9)
    tiny = nw.gaussian_filter_frames(x[0], np.full((15, 3), nw.LOG_SIGMA_RANGE[0]))
    assert np.array_equal(tiny, x[0, 15:30])  # sigma -> 0 is exactly the identity


def test_streaming_equals_offline_with_free_taps_and_bias(walk):
    torch.manual_seed(7)
    lay = deep.layout_for(walk)
    net = deep.EBF(lay.num_channels, hidden=8, width=16, head="free", bias=True, init="xavier")
    x, _ = ch.encode(walk, lay)
    net.set_statistics(x.mean(0), np.maximum(x.std(0), 1.0), np.ones(3))
    model = deep.DeepModel("ebf", net, lay, walk.fps)
    rows = corrupt.angular_noise(walk, 0.5, seed=5)[0].channel_values()[:80]
    offline = deep.denoise_rows(walk.skeleton, rows, walk.fps, model)
    stream = deep.Denoiser(walk.skeleton, walk.fps, model)
    out = [o for o in (stream.push(r) for r in rows) if o is not None] + stream.flush()
    d = (np.array(out) - offline + 180.0) % 360.0 - 180.0
    assert np.abs(d).max() < 1e-3


def test_load_clips_from_files_folders_and_a_database(tmp_path, walk):
    from mocapkit.database import MotionDatabase

    db = MotionDatabase.build([walk], fps=120, features=("F15",))
    db.save(tmp_path / "walk.db")
    from_db = training.load_clips(tmp_path / "walk.db")
    assert len(from_db) == 1 and from_db[0].num_frames == walk.num_frames
    assert np.allclose(from_db[0].rotations, walk.rotations, atol=1e-6)  # stored as float32
    files = training.load_clips([mocapkit.samples.path("12_walk.amc")])
    assert len(files) == 1 and files[0].num_frames == walk.num_frames


def test_plateau_rule_halves_after_patience_epochs_without_a_better_validation():
    vals = [3.0, 2.0, 2.5, 2.6, 2.1, 2.2, 2.3, 1.0]
    h = [{"val_rmse": v} for v in vals]
    assert training._plateau_halvings(h, 2) == [False, False, False, True, False, True, False, False]
    assert not any(training._plateau_halvings(h, 0))


def test_resumed_training_follows_the_plateau_rule(tmp_path, walk):
    clip = walk[:160]
    cfg = training.TrainConfig(kind="ebf", hidden=8, epochs=4, steps_per_epoch=2, batch=4, crop=40,
                               noise=("angular:0.5",), variants=1, lr_patience=1)
    val = [walk[160:320]]
    a = training.train([clip], tmp_path / "a", cfg, validation=val, executor="serial", progress=False)
    training.train([clip], tmp_path / "b", training.TrainConfig(**{**cfg.__dict__, "epochs": 2}), validation=val,
                   executor="serial", progress=False)
    b = training.train([clip], tmp_path / "b", cfg, validation=val, executor="serial", progress=False)
    ha, hb = a.meta["history"], b.meta["history"]
    assert [(h["val_rmse"], h["lr"]) for h in ha] == [(h["val_rmse"], h["lr"]) for h in hb]
    halved = training._plateau_halvings(ha, 1)
    for k in range(1, len(ha)):
        assert ha[k]["lr"] == ha[k - 1]["lr"] * (0.5 if halved[k - 1] else 1.0)


# -- augmentation ----------------------------------------------------------------------


def _pool(walk, noise=("angular:0.5",)):
    return [training.prepare_clip((walk[:300], deep.layout_for(walk), noise, 2, 3))]


def test_resample_crop_reads_frames_at_the_given_speed():
    a = np.arange(40, dtype=np.float32)[:, None] * np.array([[1.0, -2.0]], dtype=np.float32)
    assert np.array_equal(training._resample_crop(a, 5, 1.0, 10), a[5:15])
    assert np.array_equal(training._resample_crop(a, 4, 2.0, 10), a[4:24:2])
    half = training._resample_crop(a, 3.0, 0.5, 9)
    assert np.allclose(half[:, 0], 3.0 + 0.5 * np.arange(9))  # a ramp is interpolated exactly


def test_train_config_refuses_a_bad_speed_range_or_offset():
    for bad in ((0.0, 2.0), (1.4, 0.7), (-1.0, 1.0)):
        with pytest.raises(ValueError, match="speed_range"):
            training.TrainConfig(speed_range=bad)
    with pytest.raises(ValueError, match="offset"):
        training.TrainConfig(offset=-0.1)
    for bad in (-0.1, 1.5):
        with pytest.raises(ValueError, match="patchy"):
            training.TrainConfig(patchy=bad)
    assert training.TrainConfig(speed_range=(0.5, 0.5)).speed_range == (0.5, 0.5)


def test_unaugmented_batches_are_the_plain_crops(walk):
    """speed_range (1, 1) and offset 0 draw the same crops as before augmentation existed."""
    data = _pool(walk)
    cfg = training.TrainConfig(batch=3, crop=60)
    x, c, y = training._ebf_batch(data, cfg, np.random.default_rng(4), np.ones(data[0]["clean"].shape[1], np.float32))
    rng = np.random.default_rng(4)
    T = 90
    lens = np.array([300.0])
    pick = rng.choice([0], size=3, p=lens / lens.sum())
    for b in range(3):
        s = int(rng.integers(0, 300 - T + 1))
        v = data[pick[b]]["noisy"][int(rng.integers(2))]
        assert np.array_equal(x[b].numpy(), v[s : s + T])
        assert np.array_equal(y[b].numpy(), data[0]["clean"][s + 15 : s + T - 15])
        assert np.array_equal(c[b].numpy(), data[0]["ctx"][s : s + T])


def test_augmented_crops_keep_the_noise_and_a_consistent_target(walk):
    """Replayed crops: noisy - clean is the white noise of a real variant, the target is the replayed clean
    motion (offsets included), and the speeds span the range."""
    data = _pool(walk)
    C = data[0]["clean"].shape[1]
    std = np.full(C, 10.0, np.float32)
    cfg = training.TrainConfig(batch=16, crop=60, speed_range=(0.7, 1.4), offset=0.5)
    x, c, y = (a.numpy() for a in training._ebf_batch(data, cfg, np.random.default_rng(1), std))
    noise = ch.wrap_degrees(x[:, 15:-15] - y)
    ref = np.concatenate([ch.wrap_degrees(v - data[0]["clean"]) for v in data[0]["noisy"]])
    # the same noise level as the variants it came from (0.5 x channel std), not smoothed by the resampling
    assert np.allclose(noise.std(axis=(0, 1)), ref.std(axis=0), rtol=0.25)
    lag1 = np.mean(noise[:, 1:] * noise[:, :-1]) / np.mean(noise**2)
    assert abs(lag1) < 0.05
    # the clean target moves as fast as the clip played at 0.7-1.4x: its frame-to-frame steps scale with speed
    step = np.abs(np.diff(y, axis=1)).mean(axis=(1, 2))
    base = np.abs(np.diff(data[0]["clean"], axis=0)).mean()
    assert step.min() < 0.9 * base and step.max() > 1.15 * base
    # offsets move input and target together; without them the target is a stretch of the clip
    cfg0 = training.TrainConfig(batch=16, crop=60, speed_range=(0.7, 1.4), offset=0.0)
    y0 = training._ebf_batch(data, cfg0, np.random.default_rng(1), std)[2].numpy()
    off = (y - y0).reshape(-1, C)
    assert not np.allclose(off, off[0], atol=1e-3)  # differs per crop
    assert np.allclose(y - y0, (y - y0)[:, :1], atol=1e-3)  # one offset per crop and channel
    lo, hi = data[0]["clean"].min(0), data[0]["clean"].max(0)
    assert np.all((y0 >= lo - 1e-3) & (y0 <= hi + 1e-3))



def test_patchy_noise_is_the_noise_times_a_channel_gain_over_one_stretch():
    rng = np.random.default_rng(0)
    T, C = 150, 40
    zero = 0
    for _ in range(50):
        noise = rng.normal(size=(T, C)) + 3.0
        gain = training._patchy(noise, rng) / noise  # (T, C): the gain where it is on, 0 elsewhere
        on = np.flatnonzero(np.abs(gain).sum(axis=1) > 0)
        assert len(on) >= T // 4 and np.all(np.diff(on) == 1)  # one stretch of at least a quarter
        g = gain[on[0]]
        assert np.allclose(gain[on], g[None, :])  # one gain per channel over the stretch
        assert np.all((g == 0) | ((g >= 0.2 - 1e-12) & (g <= 1.0)))
        zero += int((g == 0).sum())
    assert 0.4 < zero / (50 * C) < 0.6  # about half the channels clean


def test_patchy_crops_keep_noise_on_one_stretch_and_a_clean_target(walk):
    data = _pool(walk)
    x, _, y = (a.numpy() for a in training._ebf_batch(data, training.TrainConfig(batch=16, crop=60, patchy=1.0),
                                                        np.random.default_rng(3)))
    clean_channels = 0
    for b in range(16):
        noise = ch.wrap_degrees(x[b, 15:-15] - y[b])
        rows = np.flatnonzero(np.abs(noise).sum(axis=1) > 1e-4)
        assert len(rows) and np.all(np.diff(rows) == 1)  # noise on one stretch of the output frames only
        clean_channels += int((np.abs(noise).max(axis=0) < 1e-4).sum())
    assert 0.3 < clean_channels / (16 * x.shape[2]) < 0.75  # about half the channels, plus the still ones


def test_a_clip_too_short_to_replay_faster_is_replayed_at_the_speed_it_allows(walk):
    data = [training.prepare_clip((walk[:90], deep.layout_for(walk), ("angular:0.5",), 1, 3))]
    cfg = training.TrainConfig(batch=8, crop=60, speed_range=(1.4, 1.4))
    x, _, y = training._ebf_batch(data, cfg, np.random.default_rng(0))
    assert np.allclose(y.numpy(), data[0]["clean"][15:75], atol=1e-4)  # all 90 frames at speed 1
    assert torch.isfinite(x).all()


def test_ebd_batches_replay_the_clip_at_the_drawn_speed(walk):
    data = _pool(walk)
    net = deep.EBD(data[0]["clean"].shape[1], hidden=4, width=8)
    cfg = training.TrainConfig(kind="ebd", batch=4, centres=8, speed_range=(0.5, 0.5), gap_rate=2.0)
    x, m, c, y = (a.numpy() for a in training._ebd_batch(data, cfg, np.random.default_rng(2), net))
    clean = data[0]["clean"]
    halfway = np.concatenate([clean, (clean[:-1] + clean[1:]) / 2])  # every frame of the clip played at half speed
    d = np.abs(y[:, None, :] - halfway[None]).max(axis=2).min(axis=1)
    assert np.all(d < 1e-3)
    assert np.any(np.abs(y[:, None, :] - clean[None]).max(axis=2).min(axis=1) > 0.1)  # some targets fall between frames
    assert x.shape[1] == 31 and np.isfinite(x).all() and (m[:, 15] > 0.5).any(axis=1).all()


# -- the noise-level input -------------------------------------------------------------


def test_noise_level_feature_estimates_white_noise_on_a_real_walk(walk):
    """On a real walk at 120 fps the second-difference estimate finds the std of the added white noise."""
    lay = deep.layout_for(walk)
    clean, _ = ch.encode(walk, lay)
    moving = clean.std(axis=0) > 5.0
    std = torch.ones(lay.num_channels, dtype=torch.float64)
    for amount in (0.1, 0.5):
        noisy, _ = ch.encode(corrupt.angular_noise(walk, amount, seed=11)[0], lay)
        truth = amount * np.nanstd(walk.channel_values()[:, ch.euler_columns(walk.skeleton)], axis=0)
        f = nw.noise_level_feature(torch.tensor(noisy)[None], std)[0].numpy()
        est = np.exp(3.0 * f[nw.NOISE_WINDOW :] - 3.0) - nw.NOISE_FLOOR  # back to degrees
        ratio = np.median(est, axis=0)[moving] / truth[moving]
        # every moving channel within 30 % (the motion's own curvature adds to low noise), typically within 10 %
        assert np.all(np.abs(ratio - 1.0) < 0.3), ratio
        assert abs(np.median(ratio) - 1.0) < 0.1, ratio


def test_noise_level_feature_is_causal():
    x = torch.randn(1, 80, 4, dtype=torch.float64)
    std = torch.ones(4, dtype=torch.float64)
    y = x.clone()
    y[:, 50:] += torch.randn(1, 30, 4, dtype=torch.float64) * 10.0
    a, b = nw.noise_level_feature(x, std), nw.noise_level_feature(y, std)
    assert torch.equal(a[:, :50], b[:, :50])  # frames before a change never see it
    assert not torch.equal(a[:, 50:], b[:, 50:])


def test_streaming_equals_offline_with_the_noise_input(walk, tmp_path, tiny_ebd):
    torch.manual_seed(8)
    lay = deep.layout_for(walk)
    net = deep.EBF(lay.num_channels, hidden=8, width=16, init="xavier", noise_input=True)
    x, _ = ch.encode(walk, lay)
    net.set_statistics(x.mean(0), np.maximum(x.std(0), 1.0), np.ones(3))
    model = deep.DeepModel("ebf", net, lay, walk.fps)
    path = deep.save_model(model, tmp_path / "noise.pt")
    loaded = deep.load_model(path)
    assert loaded.net.noise_input and loaded.net.encoder[0].in_features == 2 * lay.num_channels + 3
    rows = corrupt.angular_noise(walk, 0.5, seed=5)[0].channel_values()[:90]
    offline = deep.denoise_rows(walk.skeleton, rows, walk.fps, loaded)
    assert np.array_equal(offline, deep.denoise_rows(walk.skeleton, rows, walk.fps, model))
    stream = deep.Denoiser(walk.skeleton, walk.fps, loaded)
    out = [o for o in (stream.push(r) for r in rows) if o is not None] + stream.flush()
    d = (np.array(out) - offline + 180.0) % 360.0 - 180.0
    assert np.abs(d).max() < 1e-3
    # the paths that measure the level outside the network: gaps (observed samples only), another rate
    gapped, _ = corrupt.gaps(walk, start_prob=0.02, seed=0)
    filled = deep.fill_gaps(gapped, tiny_ebd, loaded)
    obs = ~gapped.missing()
    assert not np.isnan(filled.rotations).any() and np.array_equal(filled.rotations[obs], walk.rotations[obs])
    w30 = walk.resample(30)
    assert deep.denoise(w30, loaded).num_frames == w30.num_frames


def test_noise_level_from_observed_samples_ignores_filled_gaps(walk):
    """Around a gap the level is measured on observed samples: a lerp-filled stretch does not read as clean."""
    lay = deep.layout_for(walk)
    noisy, _ = ch.encode(corrupt.angular_noise(walk, 0.5, seed=2)[0], lay)
    std = np.maximum(noisy.std(axis=0), 1.0)
    every = nw.noise_level_observed(noisy, np.ones(noisy.shape, bool), std)
    ref = nw.noise_level_feature(torch.tensor(noisy)[None], torch.tensor(std))[0].numpy()
    assert np.allclose(every[nw.NOISE_WINDOW + 1 :], ref[nw.NOISE_WINDOW + 1 :], atol=1e-9)  # all observed: the same
    missing = np.zeros(noisy.shape, bool)
    missing[100:220, 5] = True
    filled = deep.lerp_fill(np.where(missing, np.nan, noisy))
    naive = nw.noise_level_feature(torch.tensor(filled)[None], torch.tensor(std))[0].numpy()
    observed = nw.noise_level_observed(filled, ~missing, std)
    assert naive[150:220, 5].max() < every[99, 5] - 1.0  # measured on the lerp, the gap looks noiseless
    assert np.allclose(observed[100:222, 5], observed[99, 5])  # the last measured level carries through the gap
    assert np.array_equal(observed[:, 4], every[:, 4])  # other channels untouched


def test_training_metadata_carries_the_rig_and_licence_into_the_model_file(tmp_path, walk):
    """A model inherits its training data's licence: ``train(meta=...)`` puts it in the saved file."""
    cfg = training.TrainConfig(kind="ebf", hidden=8, epochs=1, steps_per_epoch=2, batch=2, crop=40,
                               noise=("angular:0.5",), variants=1)
    m = training.train([walk[:160]], tmp_path, cfg, executor="serial", progress=False,
                       meta={"rig": "bandai_namco", "licence": "CC BY-NC 4.0: non-commercial"})
    again = deep.load_model(tmp_path / "model.pt")
    assert m.meta["rig"] == again.meta["rig"] == "bandai_namco"
    # beside it, its layout and card for `info` without torch (cleaning.deep.layouts.layout_beside)
    from mocapkit.cleaning.deep.layouts import layout_beside

    kept = layout_beside(tmp_path / "model.pt")
    assert kept is not None and kept.meta == again.meta and kept.layout == again.layout and kept.kind == "ebf"
    assert deep.licence_note(again).startswith("licence of the EBF used: CC BY-NC 4.0: non-commercial; --ebf (clean, "
                                               "clean-batch; models= in Python) picks another")


def test_a_resume_with_other_settings_or_clips_is_refused_not_started_over(tmp_path, walk):
    """Rerunning into the same folder with another --hidden, or other clips, replaced model.pt and checkpoint.pt
    silently (a user trial); --restart (resume=False) is the way to start over."""
    cfg = training.TrainConfig(kind="ebf", hidden=8, epochs=1, steps_per_epoch=2, batch=2, crop=40,
                               noise=("angular:0.5",), variants=1)
    training.train([walk[:160]], tmp_path, cfg, executor="serial", progress=False)
    before = (tmp_path / "model.pt").read_bytes()
    with pytest.raises(ValueError, match="holds a training with other settings"):
        training.train([walk[:160]], tmp_path, dataclasses.replace(cfg, hidden=16), executor="serial", progress=False)
    other = dataclasses.replace(walk[:160], name="another clip")
    with pytest.raises(ValueError, match="holds a training with other clips"):
        training.train([other], tmp_path, cfg, executor="serial", progress=False)
    assert (tmp_path / "model.pt").read_bytes() == before
    longer = training.train([walk[:160]], tmp_path, dataclasses.replace(cfg, epochs=2), executor="serial",
                            progress=False)  # the same run, continued
    assert len(longer.meta["history"]) == 2


def _tiny(**kw):
    return training.TrainConfig(**{"kind": "ebf", "hidden": 8, "epochs": 1, "steps_per_epoch": 2, "batch": 2,
                                   "crop": 40, "noise": ("angular:0.5",), "variants": 1, **kw})


def test_a_resume_on_clips_of_other_content_is_refused(tmp_path, walk):
    """Finding 7: the same clip name with other motion resumed the checkpoint (names were compared, not content)."""
    training.train([walk[:160]], tmp_path, _tiny(), executor="serial", progress=False)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    rot = walk.rotations[:160].copy()
    rot[40:80, 3] = rot[40:80, 3][::-1]
    edited = dataclasses.replace(walk[:160], rotations=rot)
    assert edited.name == walk[:160].name
    with pytest.raises(ValueError, match=r"holds a training with other clips .*; --restart \(resume=False in Python\) starts it over there"):
        training.train([edited], tmp_path, _tiny(epochs=2), executor="serial", progress=False)
    # a checkpoint from before clip digests (names only) is no match either
    ck = torch.load(tmp_path / "checkpoint.pt", weights_only=True)
    ck["data"] = json.dumps({"train": [walk[:160].name], "validation": []})
    torch.save(ck, tmp_path / "checkpoint.pt")
    with pytest.raises(ValueError, match="written by an earlier mocapkit, which kept no digest of its clips' content"):
        training.train([walk[:160]], tmp_path, _tiny(epochs=2), executor="serial", progress=False)
    assert (tmp_path / "model.pt").read_bytes() == before["model.pt"]


def test_a_model_without_its_checkpoint_is_refused_before_any_work(tmp_path, walk, monkeypatch):
    """Finding 6: model.pt without a checkpoint of the same training was replaced after the first epoch."""
    training.train([walk[:160]], tmp_path, _tiny(), executor="serial", progress=False)
    (tmp_path / "checkpoint.pt").unlink()
    before = (tmp_path / "model.pt").read_bytes()

    def no_work(*args, **kwargs):
        raise AssertionError("training started before the folder was checked")

    monkeypatch.setattr(training, "prepare_clip", no_work)
    with pytest.raises(ValueError, match=r"model.pt already exists \(no checkpoint of this training beside it\); "
                                         r"--restart or --overwrite \(resume=False or overwrite=True in Python\) replaces it"):
        training.train([walk[:160]], tmp_path, _tiny(), executor="serial", progress=False)
    (tmp_path / "model.pt").write_bytes(b"a file that is no model")
    with pytest.raises(ValueError, match="model.pt already exists"):
        training.check_out_dir(tmp_path, [walk[:160]], _tiny())
    monkeypatch.undo()
    assert (tmp_path / "model.pt").read_bytes() == b"a file that is no model"
    training.train([walk[:160]], tmp_path, _tiny(), executor="serial", progress=False, overwrite=True)
    assert deep.load_model(tmp_path / "model.pt").meta["training"]
    assert training.check_out_dir(tmp_path, [walk[:160]], _tiny(epochs=3)) is True  # now the same run: resumes


def test_a_kill_between_model_and_checkpoint_never_lets_a_worse_model_replace_the_better(tmp_path, walk, monkeypatch):
    """Suspected finding: model.pt of epoch 1 written, the process dies before epoch 1's checkpoint; the resumed run
    redoes epoch 1 (on a GPU not bit for bit: here another seed and a worse score) and must keep the better model."""
    cfg = _tiny(epochs=2, dropout=0.5)
    scores = iter([2.0, 1.0])  # validation RMS of epochs 0 and 1: epoch 1 is better and written to model.pt
    monkeypatch.setattr(training, "_validate", lambda *a, **k: next(scores))
    real_write, writes = training.write_torch, []

    def dying_write(payload, path):
        writes.append(path)
        if len(writes) == 2:  # epoch 1's checkpoint: the process dies first
            raise KeyboardInterrupt
        return real_write(payload, path)

    monkeypatch.setattr(training, "write_torch", dying_write)
    monkeypatch.setattr(training, "removed_on_failure", lambda *a, **k: contextlib.nullcontext())  # killed: no handler runs
    with pytest.raises(KeyboardInterrupt):
        training.train([walk[:160]], tmp_path, cfg, validation=[walk[160:320]], executor="serial", progress=False)
    monkeypatch.undo()
    better = deep.load_model(tmp_path / "model.pt")
    assert torch.load(tmp_path / "checkpoint.pt", weights_only=True)["epoch"] == 0
    real_seed = torch.manual_seed
    monkeypatch.setattr(training, "_validate", lambda *a, **k: 1.5)  # the redo of epoch 1: worse than 1.0, better than 2.0
    monkeypatch.setattr(torch, "manual_seed", lambda s: real_seed(s + 99))  # and other weights, as on a GPU
    resumed = training.train([walk[:160]], tmp_path, cfg, validation=[walk[160:320]], executor="serial", progress=False)
    monkeypatch.undo()
    kept = deep.load_model(tmp_path / "model.pt")
    for k, v in better.net.state_dict().items():
        assert torch.equal(v, kept.net.state_dict()[k]), k
    assert kept.meta["best_val_rmse"] == resumed.meta["best_val_rmse"] == 1.0 and kept.meta["best_epoch"] == 1


def test_a_finished_training_without_its_model_says_so(tmp_path, walk):
    """The checkpoint of a finished run without model.pt: nothing to resume (it ended in a raw 'no such file')."""
    training.train([walk[:160]], tmp_path, _tiny(), executor="serial", progress=False)
    (tmp_path / "model.pt").unlink()
    with pytest.raises(ValueError, match=r"its training is finished but model.pt is missing; more --epochs "
                                         r"\(TrainConfig.epochs\) continue it, --restart \(resume=False\)"):
        training.train([walk[:160]], tmp_path, _tiny(), executor="serial", progress=False)
    assert training.train([walk[:160]], tmp_path, _tiny(epochs=2), executor="serial", progress=False).meta["best_epoch"] == 1


def test_a_full_disk_in_the_first_epoch_names_the_file_and_leaves_nothing_that_blocks_the_rerun(tmp_path, walk, monkeypatch):
    """Trial 20: torch's zip writer said "[enforce fail at inline_container.cc:672] . unexpected pos" (no file, no
    cause), and model.pt stayed without checkpoint.pt, so the rerun was refused until --restart."""
    import errno
    import io as pyio
    import os

    import mocapkit.io

    out = tmp_path / "run"
    real_fdopen = os.fdopen

    class FullDisk(pyio.BufferedWriter):
        written = 0

        def write(self, b):  # the disk fills 3,000 bytes into the checkpoint
            self.written += len(b)
            if self.written > 3000:
                raise OSError(errno.ENOSPC, "No space left on device")
            return super().write(b)

    def fdopen(fd, mode="r", *args, **kwargs):
        if "checkpoint.pt" in os.readlink(f"/proc/self/fd/{fd}"):
            return FullDisk(pyio.FileIO(fd, "wb"))
        return real_fdopen(fd, mode, *args, **kwargs)

    monkeypatch.setattr(mocapkit.io.os, "fdopen", fdopen)
    with pytest.raises(OSError) as caught:
        training.train([walk[:160]], out, _tiny(), executor="serial", progress=False)
    monkeypatch.undo()
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(out / "checkpoint.pt")
    assert not out.exists()  # no model.pt without its checkpoint (nor the folder made for them)
    assert training.train([walk[:160]], out, _tiny(), executor="serial", progress=False).meta["best_epoch"] == 0
    assert sorted(p.name for p in out.iterdir()) == ["checkpoint.pt", "model.layout.json", "model.pt"]


def test_a_kill_between_the_first_epochs_two_writes_starts_over_unasked(tmp_path, walk, monkeypatch):
    """Left by trial 20: killed outright between epoch 0's model.pt and its checkpoint, the folder held this run's
    model without a checkpoint, and the same command was refused until --restart. It starts over now, and the
    run's result is the uninterrupted run's, bit for bit; a finished model without its checkpoint is still refused."""
    cfg = _tiny(epochs=2)
    real_write = training.write_torch

    def dying_write(payload, path):
        raise KeyboardInterrupt  # the first epoch's checkpoint: the process dies first

    monkeypatch.setattr(training, "write_torch", dying_write)
    monkeypatch.setattr(training, "removed_on_failure", lambda *a, **k: contextlib.nullcontext())  # killed: no handler runs
    with pytest.raises(KeyboardInterrupt):
        training.train([walk[:160]], tmp_path / "a", cfg, executor="serial", progress=False)
    monkeypatch.undo()
    assert (tmp_path / "a" / "model.pt").is_file() and not (tmp_path / "a" / "checkpoint.pt").exists()
    assert real_write is training.write_torch
    again = training.train([walk[:160]], tmp_path / "a", cfg, executor="serial", progress=False)
    whole = training.train([walk[:160]], tmp_path / "b", cfg, executor="serial", progress=False)
    assert again.meta["finished"] is True and len(again.meta["history"]) == 2
    for k, v in whole.net.state_dict().items():
        assert torch.equal(v, again.net.state_dict()[k]), k
    (tmp_path / "b" / "checkpoint.pt").unlink()  # a finished run's model: not started over
    with pytest.raises(ValueError, match=r"model.pt already exists \(no checkpoint of this training beside it\)"):
        training.check_out_dir(tmp_path / "b", [walk[:160]], cfg)


def test_ebf_training_refuses_clips_shorter_than_a_crop_naming_them(tmp_path, walk):
    """A clip shorter than one crop (crop + 30 frames) is never drawn by the EBF's batches: it is refused before any
    work, naming it, rather than counted in the model card and left out of the training."""
    cfg = training.TrainConfig(kind="ebf", hidden=8, epochs=1, steps_per_epoch=1, batch=2, crop=40,
                               noise=("angular:0.5",), variants=1)
    short = dataclasses.replace(walk[:60], name="short_one", source_file=None)
    with pytest.raises(ValueError, match=r"1 of 2 training clips is shorter than a crop of 70 frames .*short_one \(60\)"):
        training.train([walk[:200], short], tmp_path / "m", cfg, executor="serial", progress=False)
    assert not (tmp_path / "m").exists()
    gap_cfg = training.TrainConfig(**{**cfg.__dict__, "kind": "ebd", "centres": 4})
    training.check_clip_lengths([walk[:200], short], gap_cfg)  # the EBD trains on whole clips of any length


def test_a_truncated_model_or_checkpoint_is_refused_as_damaged_not_as_another_training(tmp_path, walk):
    """A model.pt or checkpoint.pt cut short (a full disk, an interrupted copy) was refused as "no checkpoint of this
    training beside it" / "not one mocapkit wrote": it is named as damaged, and nothing in the folder is replaced."""
    whole = tmp_path / "whole.pt"
    torch.save({"meta": json.dumps({"training": "x"}), "state": torch.zeros(4096)}, whole)
    cut = whole.read_bytes()[: whole.stat().st_size // 2]
    (tmp_path / "model.pt").write_bytes(cut)
    with pytest.raises(ValueError, match=r"model.pt already exists \(damaged or truncated: torch cannot read it\); "
                                         r"--restart or --overwrite"):
        training.check_out_dir(tmp_path, [walk[:160]], _tiny())
    (tmp_path / "checkpoint.pt").write_bytes(cut)
    with pytest.raises(ValueError, match=r"holds a damaged or truncated checkpoint.pt \(torch cannot read it\)"):
        training.check_out_dir(tmp_path, [walk[:160]], _tiny())
    assert (tmp_path / "model.pt").read_bytes() == cut and (tmp_path / "checkpoint.pt").read_bytes() == cut
    (tmp_path / "model.pt").write_bytes(whole.read_bytes())  # a whole torch file that is no model of this training
    (tmp_path / "checkpoint.pt").unlink()
    with pytest.raises(ValueError, match=r"model.pt already exists \(no checkpoint of this training beside it\)"):
        training.check_out_dir(tmp_path, [walk[:160]], _tiny())
