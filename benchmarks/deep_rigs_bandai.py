"""The shipped Bandai Namco EBF and EBD on held-out styles: denoising, 1-4 s gaps, speed, clean takes.

Usage::

    python benchmarks/deep_rigs_bandai.py [--every 3] [--seeds 2] [--json]

Takes: the Bandai Namco test styles of ``scripts/train_shipped.py`` (``BANDAI_TEST``:
dataset-2 ``elderly``, dataset-1 ``old``, ``sad``, ``proud``; whole styles, never
trained on, never used to pick an epoch), every ``--every``-th of them; 22-joint
game rig, 30 fps. The models are the ones ``deep.shipped_model(kind, take)`` picks
for these takes (the rule of :func:`mocapkit.cleaning.deep.served_by`), so the run
also checks that a Bandai take gets ``ebf_bandai.pt`` / ``ebd_bandai.pt``.

* ``denoise``: Mall et al. 2017's angular noise at 0.1, 0.5 and 0.9 of each channel's
  std (``corrupt.angular_noise``; ``Hips`` carries the rig's pelvis rotation and is a
  channel like the others, ``joint_Root`` stays clean), ``--seeds`` draws per take;
  ``ebf`` (``deep.denoise(..., guard=False)``, the network's own output) against the 58 ms and 125 ms Gaussians on the same
  joint-angle channels (Mall's baselines) and the best fixed Gaussian of a sweep
  (tuned on these test takes: a bound for any fixed Gaussian). RMS in degrees over the
  non-root channels (``metrics.joint_angle_rms(..., include_root=False)``), averaged
  over takes and draws. Target: ebf <= 0.60x the better of the two Gaussians at 0.5,
  below it at 0.1 and 0.9.
* ``gaps``: 0.5 angular noise, then one gap of 1-4 s (uniform, at most the take less
  0.25 s each side) in every channel of one whole joint that moves (some channel with
  >= 5 deg std), three joints per take and draw, one at a time; takes under 1.5 s are
  skipped. ``ebd+ebf``: the EBD network on the gap entries, then the EBF on the whole take
  (Mall's pipeline, as ``deep_gapfill.py``); ``prior+ebf``: the EBD model's Gaussian gap
  prior instead of the network, reading the observed channels as the EBF denoises them
  (``deep.fill_channels(..., ebf, smooth=True)``: what ``fill`` and ``clean`` run), then the EBF
  on the whole take; ``prior_gauss_read+ebf`` the same prior reading them through its 58 ms
  Gaussian (``smooth=False``, same run); against ``lerp+gauss`` (linear fill, then the 58 ms
  Gaussian) and ``lerp+ebf``; RMS over the gap
  entries. Target: the shipped fill <= 0.60x.
* ``hard_gaps``: what ``gaps`` never makes (trial A, finding 2), on the clean takes: three moving joints lost at
  once, 1-5 s each, one gap running to the take's start or end; RMS over the gap entries of ``lerp``, ``prior``,
  ``ebd`` and ``auto`` (what ``fill`` and ``clean`` run), and per fill the draws that ended worse than ``lerp``.
* ``speed``: offline EBF frames per second on the test takes' 0.5-noise channels joined
  into one array (``deep.denoise_channels``, one torch thread), and streaming
  (``deep.Denoiser.push``) milliseconds per frame over one take, median and p95.
* ``clean_takes``: ``clean()`` on the first ``--clean`` clean test takes, with the
  shipped models chosen for the rig (the Bandai ones) and with the Acclaim ones given
  explicitly (which do not serve the rig: the Savitzky-Golay / spline fallback, what a
  Bandai take got before): joint cells changed by each. The denoiser runs only on the
  cells the noisy-cell rule picks, so the counts should match.
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _deep  # noqa: F401  (sets sys.path)
import _harness as harness
from _deep import gaussian, wrapped_rms

import mocapkit  # noqa: E402
import train_shipped  # noqa: E402
from mocapkit import corrupt, metrics  # noqa: E402
from mocapkit.cleaning import deep  # noqa: E402
from mocapkit.cleaning.deep.channels import decode, encode  # noqa: E402
from mocapkit.cleaning.deep.training import channel_joints  # noqa: E402

NOISES = (0.1, 0.5, 0.9)
GAUSS_SWEEP = (0.015, 0.020, 0.030, 0.040, 0.058, 0.080, 0.125)
SIGMA = 0.058


def test_takes(every: int):
    sys.path.insert(0, str(train_shipped.ROOT / "benchmarks"))
    _, _, test = train_shipped.bandai_split(train_shipped.bandai_takes())
    return test[::every]


def denoise_rows(clean, ebf, seeds: int) -> dict:
    """Errors of every method at every noise level for one clean take: {noise: {method: [per draw]}}."""
    lay = ebf.layout
    out: dict = {}
    for amount in NOISES:
        rows = out.setdefault(amount, {})
        for seed in range(seeds):
            noisy = corrupt.angular_noise(clean, amount, seed=(seed, 31))[0]
            x, _ = encode(noisy, lay)

            def err(m):
                return metrics.joint_angle_rms(clean, m, include_root=False)

            row = {"noisy": err(noisy), "ebf": err(deep.denoise(noisy, ebf, guard=False))}
            for s in GAUSS_SWEEP:
                row[f"gauss:{s}"] = err(decode(gaussian(x, s, clean.fps), noisy, lay))
            for k, v in row.items():
                rows.setdefault(k, []).append(v)
    return out


def moving_joints(y: np.ndarray, groups: np.ndarray) -> list:
    """The joints (``groups`` values, one per channel of ``y`` (F, C) degrees) with a channel whose spread over the
    take is 5 deg or more: the joints a gap is drawn on (a still joint's gap is filled by any method)."""
    return [g for g in np.unique(groups) if np.std(y[:, groups == g], axis=0).max() >= 5.0]


def gap_rows(clean, ebf, ebd, seeds: int, name: str) -> dict:
    """Gap RMS of each fill on 1-4 s whole-joint gaps of one take: {method: [per gap]}."""
    lay, fps = ebf.layout, clean.fps
    F = clean.num_frames
    margin = int(round(0.25 * fps))
    out: dict = {"lerp+gauss": [], "lerp+ebf": [], "ebd+ebf": [], "prior+ebf": [], "prior_gauss_read+ebf": [],
                 "seconds": []}
    if F < int(1.5 * fps):
        return out
    y, _ = encode(clean, lay)
    groups = channel_joints(lay)
    moving = moving_joints(y, groups)
    for seed in range(seeds):
        rng = np.random.default_rng([seed, 7, len(name), F])
        noisy = corrupt.angular_noise(clean, 0.5, seed=(seed, 41))[0]
        xn, ctx = encode(noisy, lay)
        for g in rng.choice(moving, size=min(3, len(moving)), replace=False):
            hi = min(int(4 * fps), F - 2 * margin)
            n = int(rng.integers(int(fps), hi + 1))
            s = int(rng.integers(margin, F - margin - n + 1))
            xg = xn.copy()
            xg[s : s + n, groups == g] = np.nan
            mask = np.isnan(xg)
            lerp = deep.lerp_fill(xg)
            filled = deep.fill_channels(xg, ctx, ebd, smooth=False, fps=fps, method="ebd")
            by_prior = deep.fill_channels(xg, ctx, ebd, ebf, fps=fps, smooth=True, method="prior")
            gauss_read = deep.fill_channels(xg, ctx, ebd, smooth=False, fps=fps, method="prior")
            fills = {"lerp+gauss": gaussian(lerp, SIGMA, fps),
                     "lerp+ebf": deep.denoise_channels(lerp, ctx, ebf, fps=fps),
                     "ebd+ebf": deep.denoise_channels(filled, ctx, ebf, fps=fps),
                     "prior+ebf": deep.denoise_channels(by_prior, ctx, ebf, fps=fps),
                     "prior_gauss_read+ebf": deep.denoise_channels(gauss_read, ctx, ebf, fps=fps)}
            for k, v in fills.items():
                out[k].append(wrapped_rms(v, y, mask))
            out["seconds"].append(n / fps)
    return out


def hard_gap_rows(clean, ebf, ebd, seeds: int, name: str) -> dict:
    """The gaps ``gap_rows`` never makes, on the clean take: three moving joints lost at once for 1-5 s each, one
    of the gaps running to the take's start or end. RMS over the gap entries of the linear fill (``lerp``), the
    prior (``prior``), the network (``ebd``) and what ``fill`` and ``clean`` run (``auto``), with the EBF; and per
    fill how many draws ended further from the truth than ``lerp`` ("worse")."""
    lay, fps = ebf.layout, clean.fps
    F = clean.num_frames
    out: dict = {"lerp": [], "prior": [], "ebd": [], "auto": []}
    if F < int(2.5 * fps):
        return out
    y, ctx = encode(clean, lay)
    groups = channel_joints(lay)
    moving = moving_joints(y, groups)
    for seed in range(seeds):
        rng = np.random.default_rng([seed, 11, len(name), F])
        xg = y.copy()
        for k, g in enumerate(rng.choice(moving, size=min(3, len(moving)), replace=False)):
            n = int(rng.integers(int(fps), min(int(5 * fps), F - int(fps)) + 1))
            s = (0 if rng.random() < 0.5 else F - n) if k == 0 else int(rng.integers(1, F - n))
            xg[s : s + n, groups == g] = np.nan
        mask = np.isnan(xg)
        fills = {"lerp": deep.lerp_fill(xg), "prior": deep.fill_channels(xg, ctx, ebd, ebf, fps=fps, method="prior"),
                 "ebd": deep.fill_channels(xg, ctx, ebd, ebf, fps=fps, method="ebd"),
                 "auto": deep.fill_channels(xg, ctx, ebd, ebf, fps=fps)}
        for k, v in fills.items():
            out[k].append(wrapped_rms(v, y, mask))
    return out


def speed(takes, ebf) -> dict:
    """Offline frames/s on the takes joined, and streaming ms per frame on the longest take."""
    import torch

    torch.set_num_threads(1)
    xs, cs = [], []
    for clean in takes:
        x, c = encode(corrupt.angular_noise(clean, 0.5, seed=(0, 51))[0], ebf.layout)
        xs.append(x)
        cs.append(c)
    x, c = np.concatenate(xs), np.concatenate(cs)
    deep.denoise_channels(x[:300], c[:300], ebf, fps=30.0)  # warm-up
    best = np.inf
    for _ in range(3):
        t = time.perf_counter()
        deep.denoise_channels(x, c, ebf, fps=30.0)
        best = min(best, time.perf_counter() - t)
    longest = max(takes, key=lambda m: m.num_frames)
    noisy = corrupt.angular_noise(longest, 0.5, seed=(0, 52))[0]
    rows = noisy.channel_values()
    den = deep.Denoiser(noisy.skeleton, noisy.fps, ebf)
    for r in rows[:40]:  # warm-up (numba compiles on first use)
        den.push(r)
    den = deep.Denoiser(noisy.skeleton, noisy.fps, ebf)
    times = []
    for r in rows:
        t = time.perf_counter()
        den.push(r)
        times.append(time.perf_counter() - t)
    ms = 1000.0 * np.array(times)
    return {"offline_frames": int(len(x)), "offline_frames_per_s": round(len(x) / best, 0),
            "stream_frames": int(len(rows)), "stream_ms_median": round(float(np.median(ms)), 3),
            "stream_ms_p95": round(float(np.percentile(ms, 95)), 3)}


def clean_counts(takes) -> dict:
    """Cells ``clean()`` changes on clean takes with the models chosen for the rig and with the Acclaim ones."""
    from mocapkit.cleaning.pipeline import clean

    acclaim = {"ebf": deep.shipped_model("ebf"), "ebd": deep.shipped_model("ebd")}
    rows = []
    for m in takes:
        a = clean(m)
        b = clean(m, models=acclaim)
        rows.append({"take": m.name, "frames": m.num_frames, "changed_bandai_models": int(a.changed.sum()),
                     "changed_before": int(b.changed.sum()),
                     "denoise_method": next((s.method for s in a.steps if s.name == "denoise"), "")})
    return {"takes": rows, "changed_bandai_models": sum(r["changed_bandai_models"] for r in rows),
            "changed_before": sum(r["changed_before"] for r in rows)}


def main(argv=None) -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--every", type=int, default=3, help="every N-th held-out take")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--clean", type=int, default=8, help="clean takes for the clean_takes check")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    paths = test_takes(a.every)
    takes = [mocapkit.load(t.path) for t in paths]
    ebf, ebd = deep.shipped_model("ebf", takes[0]), deep.shipped_model("ebd", takes[0])
    den: dict = {n: {} for n in NOISES}
    gaps: dict = {}
    hard: dict = {}
    from tqdm import tqdm

    for t, clean in tqdm(list(zip(paths, takes)), desc="takes", disable=a.json):
        for n, rows in denoise_rows(clean, ebf, a.seeds).items():
            for k, v in rows.items():
                den[n].setdefault(k, []).extend(v)
        for k, v in gap_rows(clean, ebf, ebd, a.seeds, t.path.name).items():
            gaps.setdefault(k, []).extend(v)
        for k, v in hard_gap_rows(clean, ebf, ebd, a.seeds, t.path.name).items():
            hard.setdefault(k, []).extend(v)
    result: dict = {
        "test_styles": [f"dataset-{d} {s}" for d, s in train_shipped.BANDAI_TEST], "takes": len(takes),
        "every": a.every, "frames": int(sum(m.num_frames for m in takes)), "seeds": a.seeds, "fps": 30,
        "ebf_model": {k: ebf.meta.get(k) for k in ("rig", "licence")}, "ebd_model": {k: ebd.meta.get(k) for k in ("rig", "licence")},
        "ebf_training": {"train_clips": len(ebf.meta.get("train_clips", [])), "validation_clips": len(ebf.meta.get("validation_clips", [])),
                         "train_seconds": round(ebf.meta.get("train_seconds", 0.0)), "epochs": len(ebf.meta.get("history", []))},
        "ebd_training": {"train_clips": len(ebd.meta.get("train_clips", [])),
                         "train_seconds": round(ebd.meta.get("train_seconds", 0.0)), "epochs": len(ebd.meta.get("history", []))},
        "unit": "degrees RMS over non-root joint-angle channels", "denoise": {},
    }
    for n in NOISES:
        e = {k: float(np.mean(v)) for k, v in den[n].items()}
        g_best = min(GAUSS_SWEEP, key=lambda s: e[f"gauss:{s}"])
        better = min(e["gauss:0.058"], e["gauss:0.125"])
        result["denoise"][f"angular:{n}"] = {
            "noisy": round(e["noisy"], 3), "ebf": round(e["ebf"], 3), "gauss58": round(e["gauss:0.058"], 3),
            "gauss125": round(e["gauss:0.125"], 3), "gauss_best": round(e[f"gauss:{g_best}"], 3),
            "gauss_best_sigma_s": g_best, "ratio_ebf_vs_better_gaussian": round(e["ebf"] / better, 3),
            "ratio_ebf_vs_gauss_best": round(e["ebf"] / e[f"gauss:{g_best}"], 3)}
    gm = {k: round(float(np.mean(v)), 3) for k, v in gaps.items() if k != "seconds"}
    result["gaps"] = {"runs": len(gaps["seconds"]), "gap_rms": gm,
                      "gap_seconds_mean": round(float(np.mean(gaps["seconds"])), 2),
                      "ratio_ebd_ebf_vs_lerp_gauss": round(gm["ebd+ebf"] / gm["lerp+gauss"], 3),
                      "ratio_prior_ebf_vs_lerp_gauss": round(gm["prior+ebf"] / gm["lerp+gauss"], 3),
                      "ratio_prior_gauss_read_ebf_vs_lerp_gauss":
                          round(gm["prior_gauss_read+ebf"] / gm["lerp+gauss"], 3)}
    hv = {k: np.array(v) for k, v in hard.items()}
    result["hard_gaps"] = {"runs": len(hv["lerp"]), "gap_rms": {k: round(float(v.mean()), 3) for k, v in hv.items()},
                           "worse_than_lerp": {k: int(np.sum(v > hv["lerp"])) for k, v in hv.items() if k != "lerp"},
                           "ratio_auto_vs_lerp": round(float(hv["auto"].mean() / hv["lerp"].mean()), 3)}
    result["speed"] = speed(takes, ebf)
    result["clean_takes"] = clean_counts(takes[: a.clean])
    result["seconds"] = round(time.perf_counter() - t0, 1)
    if not a.json:
        for n, r in result["denoise"].items():
            print(f"{n}: " + ", ".join(f"{k} {v}" for k, v in r.items()))
        print("gaps:", result["gaps"])
        print("hard gaps:", result["hard_gaps"])
        print("speed:", result["speed"])
        print("clean takes: changed", result["clean_takes"]["changed_bandai_models"], "before",
              result["clean_takes"]["changed_before"])
    d = result["denoise"]
    figures = {f"ebf angular:{n}": d[f"angular:{n}"]["ebf"] for n in NOISES}
    baselines = {f"ebf angular:{n}": min(d[f"angular:{n}"]["gauss58"], d[f"angular:{n}"]["gauss125"]) for n in NOISES}
    figures["long_gap_rms_deg"] = gm["prior+ebf"]
    baselines["long_gap_rms_deg"] = gm["lerp+gauss"]
    figures["long_gap_ebd_rms_deg"] = gm["ebd+ebf"]
    figures["hard_gap_auto_rms_deg"] = result["hard_gaps"]["gap_rms"]["auto"]
    baselines["hard_gap_auto_rms_deg"] = result["hard_gaps"]["gap_rms"]["lerp"]
    baselines["long_gap_ebd_rms_deg"] = gm["lerp+gauss"]
    figures["offline_frames_per_s"] = result["speed"]["offline_frames_per_s"]
    figures["stream_ms_p95"] = result["speed"]["stream_ms_p95"]
    figures["clean_takes_changed_cells"] = result["clean_takes"]["changed_bandai_models"]
    baselines["clean_takes_changed_cells"] = result["clean_takes"]["changed_before"]
    figures["clean_takes_extra_changed_cells"] = (result["clean_takes"]["changed_bandai_models"]
                                                  - result["clean_takes"]["changed_before"])
    harness.emit("deep_rigs_bandai", a, figures=figures, baselines=baselines, targets={
        "ebf angular:0.5": {"value": 0.60, "op": "<=", "of": "ratios"},
        "ebf angular:0.1": {"value": 1.0, "op": "<=", "of": "ratios"},
        "ebf angular:0.9": {"value": 1.0, "op": "<=", "of": "ratios"},
        "long_gap_rms_deg": {"value": 0.60, "op": "<=", "of": "ratios"},
        "offline_frames_per_s": {"value": 20000, "op": ">=", "of": "figures"},
        "stream_ms_p95": {"value": 1.0, "op": "<=", "of": "figures"},
        "clean_takes_extra_changed_cells": {"value": 0, "op": "<=", "of": "figures"},
    }, details=result)


if __name__ == "__main__":
    main()
