"""Subsequence-graph reconstruction (Tautges 2012, ch. 4) on HDM05 locomotion, held-out actor mm.

Knowledge base: the HDM05 locomotion classes of ``_reconstruct.LOCOMOTION``
(jogLeftCircle4StepsRstart, sneak2StepsLStart) of the four other actors (bd,
bk, dg, tr), resampled to 60 fps, the thesis's rate (about 50 s, the thesis
used about 75 s). Test clips: actor mm's clips of the same classes (never in
the database), control markers simulated on them at 60 fps, exactly on the
joints; the reconstruction is on mm's own skeleton.

Scenarios (thesis sec. 4.4):

1. ``hands_feet``: 4 markers (lhand, rhand, lfoot, rfoot), N = 20, o = 10, k = 8;
2. ``hands_feet_gaps``: the same with all markers removed in random intervals
   of 5..80 frames (seeded; about a third of the frames);
3. ``head_back``: head, upperneck, thorax, upperback; N = 15, o = 6, k = 16,
   transition weight 4 (the thesis: "increasing the transition weights").

Figures per scenario: the mean joint-position error in cm (per frame the mean
Euclidean distance over the 31 joints, averaged over the frames of all clips),
global (the reconstruction is placed in the markers' frame, so no extra
alignment) and root-relative (both root positions subtracted), and the share
of frames whose global error is below 5 cm. Baselines in the same run:

* ``window_best``: every window's best subsequence concatenated with the same
  cross-fades (k = 1, no graph: the thesis's first, "not satisfying" outline);
* ``nearest_pose``: :func:`mocapkit.reconstruct.ssg.framewise`, markers linearly
  interpolated over gaps, then per frame the database frame with the least
  eq. 4.3 cost, placed by its alignment.

``ratio`` = SSG error / baseline error (below 1 is better).

    python benchmarks/reconstruct_ssg.py --json [--quick]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

import _harness as harness
import _reconstruct as H

import mocapkit  # noqa: E402
from mocapkit.features import virtual_markers  # noqa: E402
from mocapkit.motion import Motion, unit_scale_cm  # noqa: E402
from mocapkit.reconstruct import ssg  # noqa: E402

SCENARIOS = {
    "hands_feet": dict(joints=("lhand", "rhand", "lfoot", "rfoot"), gaps=False, window=20, overlap=10, k=8, tw=1.0),
    "hands_feet_gaps": dict(joints=("lhand", "rhand", "lfoot", "rfoot"), gaps=True, window=20, overlap=10, k=8, tw=1.0),
    "head_back": dict(joints=("head", "upperneck", "thorax", "upperback"), gaps=False, window=15, overlap=6, k=16, tw=4.0),
}


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def random_gaps(F: int, rng, lo: int = 5, hi: int = 80, share: float = 0.33, margin: int = 8) -> list[tuple[int, int]]:
    """Non-overlapping gaps [a, b) of lo..hi frames inside [margin, F - margin) until ``share`` of the frames."""
    free = np.ones(F, bool)
    free[:margin] = free[F - margin :] = False
    gaps = []
    for _ in range(200):
        if sum(b - a for a, b in gaps) >= share * F:
            break
        L = int(rng.integers(lo, hi + 1))
        if L > F - 2 * margin - 10:
            continue
        a = int(rng.integers(margin, F - margin - L + 1))
        # keep at least 4 observed frames between gaps
        if free[max(0, a - 4) : min(F, a + L + 4)].all():
            free[a : a + L] = False
            gaps.append((a, a + L))
    return sorted(gaps)


def errors(out: Motion, truth: Motion, cm: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame mean joint distance (F,) in cm: global, and with both roots subtracted."""
    a = out.global_positions()
    b = truth.global_positions()
    glob = np.linalg.norm(a - b, axis=-1).mean(axis=1) * cm
    rel = np.linalg.norm((a - a[:, :1]) - (b - b[:, :1]), axis=-1)[:, 1:].mean(axis=1) * cm
    return glob, rel


def main(argv=None) -> int:
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="2 test clips")
    ap.add_argument("--fps", type=float, default=60.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--data", type=Path, default=H.HDM05)
    args = ap.parse_args(argv)

    db_paths, test_paths = H.scenario("mm", H.LOCOMOTION, data=args.data)
    if args.quick:
        test_paths = [test_paths[0], test_paths[-1]]
    t0 = time.perf_counter()
    db = H.database(db_paths, args.fps)
    log(f"database: {db} ({db.duration:.1f} s) in {time.perf_counter() - t0:.1f} s; {len(test_paths)} test clips")
    rng = np.random.default_rng(args.seed)
    truths = [mocapkit.load(p).resample(args.fps) for p in test_paths]
    gaps = [random_gaps(m.num_frames, rng) for m in truths]

    result = {
        "database": {
            "actors": [a for a in H.ACTORS if a != "mm"],
            "classes": list(H.LOCOMOTION),
            "clips": db.num_clips,
            "frames": db.num_frames,
            "seconds": round(db.duration, 1),
            "fps": args.fps,
        },
        "test": {"actor": "mm", "clips": [p.name for p in test_paths], "frames": int(sum(m.num_frames for m in truths))},
        "gaps": {
            "count": int(sum(len(g) for g in gaps)),
            "max_frames": int(max((b - a for g in gaps for a, b in g), default=0)),
            "mean_frames": float(np.mean([b - a for g in gaps for a, b in g])) if any(gaps) else 0.0,
            "missing_share": float(sum(b - a for g in gaps for a, b in g) / sum(m.num_frames for m in truths)),
        },
        "error": "per-frame mean joint distance (31 joints) in cm, averaged over all test frames",
        "scenarios": {},
        "quick": bool(args.quick),
    }
    for name, sc in SCENARIOS.items():
        per = {"ssg": ([], []), "window_best": ([], []), "nearest_pose": ([], [])}
        times = {"ssg": 0.0, "window_best": 0.0, "nearest_pose": 0.0}
        for truth, g in zip(truths, gaps):
            X = virtual_markers(truth, sc["joints"])
            if sc["gaps"]:
                for a, b in g:
                    X[a:b] = np.nan
            cm = unit_scale_cm(truth.skeleton)
            kw = dict(window=sc["window"] / db.fps, overlap=sc["overlap"] / db.fps, skeleton=truth.skeleton)
            runs = {
                "ssg": lambda: ssg.reconstruct(X, sc["joints"], db, truth.fps, k=sc["k"], transition_weight=sc["tw"], **kw),
                "window_best": lambda: ssg.reconstruct(X, sc["joints"], db, truth.fps, k=1, **kw),
                "nearest_pose": lambda: ssg.framewise(X, sc["joints"], db, truth.fps, skeleton=truth.skeleton),
            }
            for method, run in runs.items():
                t = time.perf_counter()
                out = run()
                times[method] += time.perf_counter() - t
                ge, re = errors(out, truth, cm)
                per[method][0].append(ge)
                per[method][1].append(re)
        figs = {}
        for method, (ge, re) in per.items():
            ge, re = np.concatenate(ge), np.concatenate(re)
            figs[method] = {
                "mean_error_cm": round(float(ge.mean()), 2),
                "mean_error_root_relative_cm": round(float(re.mean()), 2),
                "share_below_5cm": round(float(np.mean(ge < 5.0)), 3),
                "share_below_5cm_root_relative": round(float(np.mean(re < 5.0)), 3),
                "seconds": round(times[method], 2),
            }
        s = figs["ssg"]["mean_error_cm"]
        figs["ratio_vs_window_best"] = round(s / figs["window_best"]["mean_error_cm"], 3)
        figs["ratio_vs_nearest_pose"] = round(s / figs["nearest_pose"]["mean_error_cm"], 3)
        figs["params"] = {k: (list(v) if isinstance(v, tuple) else v) for k, v in sc.items()}
        result["scenarios"][name] = figs
        log(name, json.dumps(figs))
    result["seconds"] = round(time.perf_counter() - t0, 1)
    result["baseline"] = "window_best: the best subsequence of each window (k = 1), no graph, same run"
    sc = result["scenarios"]
    figures = {f"{name}_cm": sc[name]["ssg"]["mean_error_cm"] for name in sc}
    figures.update({f"{name}_root_relative_cm": sc[name]["ssg"]["mean_error_root_relative_cm"] for name in sc})
    baselines = {f"{name}_cm": sc[name]["window_best"]["mean_error_cm"] for name in sc}
    baselines.update({f"{name}_root_relative_cm": sc[name]["window_best"]["mean_error_root_relative_cm"] for name in sc})
    harness.emit("reconstruct_ssg", args, figures=figures, baselines=baselines, details=result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
