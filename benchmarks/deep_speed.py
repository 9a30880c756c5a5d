"""Speed of the shipped deep cleaners on the CPU: offline frames/s, streaming latency, training step time.

Usage::

    python benchmarks/deep_speed.py [--frames 60000] [--json]

* offline: ``deep.denoise_channels`` (EBF) and ``deep.fill_channels`` (EBD + EBF on
  2.5 % gaps) on the held-out clips, 0.5-noisy, concatenated to ``--frames`` frames at
  120 fps, best of 3, with torch's default threads (2 on the CI machine). Baseline in
  the same run: scipy's 58 ms Gaussian on the same channels. Target: EBF >= 20,000
  frames/s.
* streaming: ``deep.Denoiser.push`` per frame on a held-out clip (file-channel rows in,
  cleaned rows out 15 frames later): median and 95th percentile per push. Target:
  <= 1 ms beyond the 15-frame look-ahead (0.125 s at 120 fps).
* training: seconds per optimiser step of the shipped configurations (EBF and EBD),
  measured here on a few steps, and the recorded training time of the shipped models
  (``docs/models.md``).
"""

from __future__ import annotations

import time

import numpy as np
import torch

import _deep  # noqa: F401
import _harness as harness
from _deep import gaussian, test_clips

import mocapkit  # noqa: E402
from mocapkit import corrupt  # noqa: E402
from mocapkit.cleaning import deep  # noqa: E402
from mocapkit.cleaning.deep import training  # noqa: E402
from mocapkit.cleaning.deep.channels import encode  # noqa: E402


def best_of(fn, n=3) -> float:
    t = []
    for _ in range(n):
        s = time.perf_counter()
        fn()
        t.append(time.perf_counter() - s)
    return min(t)


def main(argv=None) -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--frames", type=int, default=60000)
    ap.add_argument("--stream-frames", type=int, default=1200)
    a = ap.parse_args(argv)
    ebf, ebd = deep.shipped_model("ebf"), deep.shipped_model("ebd")
    clips = [mocapkit.load(p) for p in test_clips()]
    xs, cs = [], []
    for k, c in enumerate(clips):
        x, ctx = encode(corrupt.angular_noise(c, 0.5, seed=k)[0], ebf.layout)
        xs.append(x)
        cs.append(ctx)
    x, ctx = np.concatenate(xs), np.concatenate(cs)
    reps = int(np.ceil(a.frames / len(x)))
    x, ctx = np.tile(x, (reps, 1))[: a.frames], np.tile(ctx, (reps, 1))[: a.frames]
    F = len(x)
    deep.denoise_channels(x[:500], ctx[:500], ebf)  # warm-up
    t_ebf = best_of(lambda: deep.denoise_channels(x, ctx, ebf))
    t_gauss = best_of(lambda: gaussian(x, 0.058, 120.0))
    rng = np.random.default_rng(0)
    mask = training.gap_mask(x.shape, 120.0, rng, start_prob=0.1 / 120.0)
    xg = np.where(mask, np.nan, x)
    t_fill = best_of(lambda: deep.fill_channels(xg, ctx, ebd, ebf), n=2)

    # streaming on the longest held-out clip
    clip = max(clips, key=lambda c: c.num_frames)
    rows = corrupt.angular_noise(clip, 0.5, seed=1)[0].channel_values()
    rows = np.tile(rows, (int(np.ceil(a.stream_frames / len(rows))), 1))[: a.stream_frames]
    st = deep.Denoiser(clip.skeleton, clip.fps, ebf)
    lat = []
    for r in rows:
        s = time.perf_counter()
        st.push(r)
        lat.append(time.perf_counter() - s)
    lat = np.array(lat[60:]) * 1e3  # steady state

    # training step time
    tr_clips = clips[:6]
    steps = {}
    for kind in ("ebf", "ebd"):
        cfg = training.TrainConfig(kind=kind, hidden=64 if kind == "ebf" else 32, batch=32 if kind == "ebf" else 16)
        data = [training.prepare_clip((c, ebf.layout, ("angular:0.5",), 1, i)) for i, c in enumerate(tr_clips)]
        net = cfg.network(ebf.layout.num_channels)
        net.set_statistics(*training._statistics(data))
        opt = torch.optim.Adam(net.parameters(), 1e-3)
        r = np.random.default_rng(0)
        times = []
        for i in range(4):
            s = time.perf_counter()
            if kind == "ebf":
                xb, cb, yb = training._ebf_batch(data, cfg, r)
                loss = torch.mean((net(xb, cb) - yb) ** 2)
            else:
                xb, mb, cb, yb = training._ebd_batch(data, cfg, r, net)
                loss = training._ebd_loss((net(xb, mb, cb) - yb) ** 2, mb[:, net.half] > 0.5, cfg.observed_weight)
            opt.zero_grad()
            loss.backward()
            opt.step()
            times.append(time.perf_counter() - s)
        steps[kind] = round(float(np.median(times[1:])), 3)

    fps_ebf = F / t_ebf
    lat_median = round(float(np.median(lat)), 3)
    if not a.json:
        print(f"EBF offline {round(fps_ebf):,} frames/s ({torch.get_num_threads()} threads), Gaussian "
              f"{round(F / t_gauss):,}; EBD+EBF fill {round(F / t_fill):,}")
        print(f"streaming {lat_median} ms median, {float(np.percentile(lat, 95)):.3f} ms p95")
        print(f"training s/step {steps}")
    harness.emit(
        "deep_speed", a,
        figures={"offline_frames_per_s": round(fps_ebf), "fill_frames_per_s": round(F / t_fill),
                 "streaming_ms_median": lat_median,
                 "streaming_ms_p95": round(float(np.percentile(lat, 95)), 3),
                 "train_s_per_step_ebf": steps["ebf"], "train_s_per_step_ebd": steps["ebd"]},
        baselines={"offline_frames_per_s": round(F / t_gauss)},
        targets={"offline_frames_per_s": {"value": 20000.0, "op": ">=", "of": "figures"},
                 "streaming_ms_median": {"value": 1.0, "op": "<=", "of": "figures"}},
        details={"baseline": "scipy Gaussian (58 ms) on the same channels, same run",
                 "threads": torch.get_num_threads(), "frames": F, "channels": int(x.shape[1]),
                 "ebf_hidden": ebf.net.config["hidden"], "fill_missing_share": round(float(mask.mean()), 4),
                 "streaming_lookahead_frames": deep.networks.HALF_WINDOW,
                 "shipped_training_seconds": {k: round(float(m.meta.get("train_seconds", float("nan"))), 1)
                                              for k, m in (("ebf", ebf), ("ebd", ebd))},
                 "shipped_epochs": {k: len(m.meta.get("history", [])) for k, m in (("ebf", ebf), ("ebd", ebd))}},
    )

if __name__ == "__main__":
    main()
