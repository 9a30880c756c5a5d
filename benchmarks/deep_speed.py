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

import argparse
import json
import platform
import time

import numpy as np
import torch

import _deep  # noqa: F401
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
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=60000)
    ap.add_argument("--stream-frames", type=int, default=1200)
    ap.add_argument("--json", action="store_true")
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
    res = {
        "benchmark": "deep_speed", "threads": torch.get_num_threads(), "frames": F, "channels": int(x.shape[1]),
        "ebf_hidden": ebf.net.config["hidden"],
        "offline_ebf_frames_per_s": round(fps_ebf), "offline_gaussian_frames_per_s": round(F / t_gauss),
        "ratio_ebf_vs_gaussian_time": round(t_ebf / t_gauss, 1),
        "offline_fill_ebd_ebf_frames_per_s": round(F / t_fill), "fill_missing_share": round(float(mask.mean()), 4),
        "streaming_ms_per_frame_median": round(float(np.median(lat)), 3),
        "streaming_ms_per_frame_p95": round(float(np.percentile(lat, 95)), 3),
        "streaming_lookahead_frames": deep.networks.HALF_WINDOW,
        "train_seconds_per_step": steps,
        "shipped_training_seconds": {k: round(float(m.meta.get("train_seconds", float("nan"))), 1) for k, m in
                                     (("ebf", ebf), ("ebd", ebd))},
        "shipped_epochs": {k: len(m.meta.get("history", [])) for k, m in (("ebf", ebf), ("ebd", ebd))},
        "target_offline": ">= 20000 frames/s", "ratio_offline_vs_target": round(fps_ebf / 20000.0, 3),
        "target_streaming": "<= 1 ms per frame", "machine": platform.processor() or platform.machine(),
    }
    res["target_met"] = bool(fps_ebf >= 20000 and res["streaming_ms_per_frame_median"] <= 1.0)
    if not a.json:
        print(f"EBF offline {res['offline_ebf_frames_per_s']:,} frames/s ({res['threads']} threads), Gaussian "
              f"{res['offline_gaussian_frames_per_s']:,}; EBD+EBF fill {res['offline_fill_ebd_ebf_frames_per_s']:,}")
        print(f"streaming {res['streaming_ms_per_frame_median']} ms median, {res['streaming_ms_per_frame_p95']} ms p95")
        print(f"training s/step {steps}")
    print(json.dumps(res))


if __name__ == "__main__":
    main()
