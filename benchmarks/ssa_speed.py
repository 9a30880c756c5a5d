"""Self-similarity analysis time on real clips against its targets, with the exhaustive search in the same run.

Usage::

    python benchmarks/ssa_speed.py [--json] [--quick]

Three analyses with ``ssa.detect``'s defaults (24 fps words, K = 5, the five joint
groups), numba compiled before the timing on a short clip:

* **local**: a 20 s take (held-out HDM05 actor mm clips concatenated, 120 fps)
  against itself. Target <= 2 s (the paper: ~140 s).
* **small**: an HDM05 jog clip of actor bd against 8 jog clips of the other
  actors (the realistic use: HDM05 clips are single repetitions). Target
  <= 1 s per second of motion (the paper: 20 min per 15 s clip).
* **large**: the same clip against about 600 s of other HDM05 and CMU clips,
  searched exactly, as ``detect`` searches every context (the kd-tree prefilter
  is opt-in). Target <= 120 s (the paper: ~3 h).

**Baseline.** The nearest-word search (``ssa.nearest_words``, the step that is
quadratic in the context) on the local take and the small context, once with the
pruned search (``word_dtw.word_knn_profile``: DTW only where a lower bound is
below the K-th local minimum) and once exhaustive (every source word against every
target position, ``word_distance_profile``, as the paper computes the distance
function), same inputs, same run; the neighbours must be identical.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO / "benchmarks"))

import _harness as harness  # noqa: E402
import mocapkit  # noqa: E402
from clean_takes import long_take  # noqa: E402  (the same held-out HDM05 mm take)
from mocapkit.cleaning import ssa  # noqa: E402

DATA = REPO.parent / "shared" / "data"
TARGETS = {"local_seconds": 2.0, "small_seconds_per_second": 1.0, "large_seconds": 120.0}


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def take(seconds: float):
    return long_take(seconds)[0]


def contexts(clip_path: Path, seconds: float):
    hdm = sorted((DATA / "hdm05_asfamc").glob("HDM_*.amc"))
    small = [p for p in hdm if "_jog" in p.name and "HDM_bd_" not in p.name][:8]
    pool, total = [], 0.0
    for p in small + [q for q in hdm + sorted((DATA / "cmu_asfamc").glob("*.amc")) if q not in small]:
        if p.name == clip_path.name or "HDM_bd_jog" in p.name:
            continue
        m = mocapkit.load(p)
        if tuple(m.skeleton.joint_names) != CLIP_JOINTS:
            continue
        pool.append(m)
        total += m.duration
        if total >= seconds:
            break
    return [mocapkit.load(p) for p in small], pool


def timed(fn, *a, **kw):
    t = time.perf_counter()
    out = fn(*a, **kw)
    return out, time.perf_counter() - t


def search_vs_exhaustive(motion, context) -> dict:
    """nearest_words pruned vs exhaustive on the textures ``detect`` builds; identical neighbours required."""
    an = ssa.prepare(motion, context)
    src, full, rows, words = an.source, an.texture, list(an.group_rows), an.words
    opts = dict(k=5, source_length=15, target_length=20, min_width=11, max_run=3, self_clip=0)
    pruned, tp = timed(ssa.nearest_words, src, full, rows, words, **opts)
    exhaustive, te = timed(ssa.nearest_words, src, full, rows, words, exhaustive=True, **opts)
    same = bool(np.array_equal(pruned.pos, exhaustive.pos) and np.array_equal(pruned.dist, exhaustive.dist))
    return {"words": int(len(words)), "groups": len(rows), "target_positions": int(len(full.target_starts(20))),
            "pruned_seconds": round(tp, 3), "exhaustive_seconds": round(te, 3), "speedup": round(te / tp, 2),
            "identical_neighbours": same}


CLIP_JOINTS: tuple = ()


def main(argv=None) -> None:
    global CLIP_JOINTS
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="10 s take, 300 s large context")
    args = ap.parse_args(argv)
    local_s, large_s = (10.0, 300.0) if args.quick else (20.0, 600.0)
    clip_path = sorted((DATA / "hdm05_asfamc").glob("HDM_bd_jog*.amc"))[0]
    clip = mocapkit.load(clip_path)
    CLIP_JOINTS = tuple(clip.skeleton.joint_names)
    small, large = contexts(clip_path, large_s)
    local = take(local_s)
    ssa.detect(local[:480])  # numba compiled, caches warm
    ssa.detect(clip[:480], small[:2])

    res = {}
    _, t = timed(ssa.detect, local)
    res["local"] = {"clip": f"{local.duration:.0f} s of HDM05 mm clips concatenated", "frames": local.num_frames,
                    "seconds": round(t, 2), "target_seconds": TARGETS["local_seconds"],
                    "ratio_to_target": round(t / TARGETS["local_seconds"], 2), "paper_seconds": 140}
    log(f"local {local.duration:.0f} s take: {t:.2f} s")
    _, t = timed(ssa.detect, clip, small)
    ctx_s = sum(m.duration for m in small)
    res["small"] = {"clip": clip_path.name, "clip_seconds": round(clip.duration, 2), "context_clips": len(small),
                    "context_seconds": round(ctx_s, 1), "seconds": round(t, 2),
                    "seconds_per_second": round(t / clip.duration, 3), "target": TARGETS["small_seconds_per_second"],
                    "ratio_to_target": round(t / clip.duration / TARGETS["small_seconds_per_second"], 3),
                    "paper_seconds_per_second": 80.0}
    log(f"small context ({len(small)} clips, {ctx_s:.0f} s): {t:.2f} s for {clip.duration:.1f} s")
    det, t = timed(ssa.detect, clip, large)
    ctx_s = sum(m.duration for m in large)
    res["large"] = {"clip": clip_path.name, "context_clips": len(large), "context_seconds": round(ctx_s, 1),
                    "prefilter": bool(det.params.prefilter), "seconds": round(t, 2),
                    "target_seconds": TARGETS["large_seconds"], "ratio_to_target": round(t / TARGETS["large_seconds"], 3),
                    "paper_seconds": 3 * 3600}
    log(f"large context ({len(large)} clips, {ctx_s:.0f} s, prefilter {det.params.prefilter}): {t:.2f} s")

    res["search_local"] = search_vs_exhaustive(local, None)
    res["search_small"] = search_vs_exhaustive(clip, small)
    for k in ("search_local", "search_small"):
        r = res[k]
        log(f"{k}: pruned {r['pruned_seconds']} s, exhaustive {r['exhaustive_seconds']} s ({r['speedup']}x), identical {r['identical_neighbours']}")
    harness.emit(
        "ssa_speed", args,
        figures={"local_s": res["local"]["seconds"], "small_s_per_s": res["small"]["seconds_per_second"],
                 "large_s": res["large"]["seconds"],
                 "search_local_s": res["search_local"]["pruned_seconds"],
                 "search_small_s": res["search_small"]["pruned_seconds"]},
        baselines={"search_local_s": res["search_local"]["exhaustive_seconds"],
                   "search_small_s": res["search_small"]["exhaustive_seconds"]},
        targets={"local_s": {"value": TARGETS["local_seconds"], "op": "<=", "of": "figures"},
                 "small_s_per_s": {"value": TARGETS["small_seconds_per_second"], "op": "<=", "of": "figures"},
                 "large_s": {"value": TARGETS["large_seconds"], "op": "<=", "of": "figures"}},
        details={"baseline": "nearest_words exhaustive (the whole distance function) in the same run",
                 "results": res},
    )

if __name__ == "__main__":
    main()
