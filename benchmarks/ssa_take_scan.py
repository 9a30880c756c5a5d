"""What ``ssa.transient_offsets`` flags on untouched real takes: its exposure to false flags, and what it finds.

Usage::

    python benchmarks/ssa_take_scan.py [--data DIR] [--json]

Every take of ``../shared/data`` with a skeleton (HDM05 ASF/AMC, CMU ASF/AMC, the
CMU BVH conversions without the T-pose the converter put in frame 0, and the
Bandai Namco BVH set, 30 fps) is scanned at its own frame rate and resampled to
30 fps: the share of (frame, joint) cells that :func:`mocapkit.cleaning.ssa.transient_offsets`
flags on all joints, per folder, and every flagged run with the physical evidence
of ``ssa_detection.take_breaks`` (the one-frame step near it, how far the joint's
distal end moves, how much the end of its chain turns). There is no ground
truth for these takes: the rows say what the flags sit on, for a person to judge.
An analysis, not a target check; the baseline is the share of cells whose
one-frame step is faster than 5,000 deg/s (the detection benchmark's glitch rule),
from the same takes in the same run.
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
from mocapkit.cleaning import baselines, ssa  # noqa: E402
from ssa_detection import take_breaks  # noqa: E402

FOLDERS = ("hdm05_asfamc", "cmu_asfamc", "cmu_bvh", "secondary_bandai_namco_CC-BY-NC")


def takes(data: Path):
    for folder in FOLDERS:
        for p in sorted((data / folder).rglob("*.amc")) + sorted((data / folder).rglob("*.bvh")):
            m = mocapkit.load(p)
            if folder == "cmu_bvh" and p.name.startswith("131_"):
                m = m[1:]  # the converter's T-pose (data README)
            yield folder, p, m


def main(argv=None) -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    summary: dict = {}
    runs: dict = {}
    for folder, path, motion in takes(args.data):
        for rate in ("native", "30fps"):
            m = motion if rate == "native" or abs(motion.fps - 30.0) < 1e-6 else motion.resample(30.0)
            offsets = ssa.transient_offsets(m)
            fast = np.zeros(offsets.shape, dtype=bool)
            fast[1:] = baselines.angular_speed(m) > 5000.0
            row = summary.setdefault(f"{folder}/{rate}", {"takes": 0, "cells": 0, "flagged": 0, "fast_cells": 0})
            row["takes"] += 1
            row["cells"] += offsets.size
            row["flagged"] += int(offsets.sum())
            row["fast_cells"] += int(fast.sum())
            if offsets.any():
                runs[f"{folder}/{rate}/{path.name}"] = take_breaks(m, offsets)
    for row in summary.values():
        row["flagged_share"] = round(row["flagged"] / row["cells"], 5)
        row["fast_share"] = round(row["fast_cells"] / row["cells"], 5)
    kinds: dict = {}
    for key, rows in runs.items():
        rate = key.split("/")[1]
        for r in rows:
            k = kinds.setdefault(rate, {"step": 0, "twist exchange": 0})
            k[r["kind"]] += r["cells"]
    if not args.json:
        for k, v in summary.items():
            print(f"{k:45s} {v['takes']:4d} takes  flagged {100 * v['flagged_share']:.3f} % of cells "
                  f"(> 5,000 deg/s: {100 * v['fast_share']:.3f} %)")
        for key, rows in runs.items():
            for r in rows:
                print(f"  {key:70s} {r['joint']:12s} {r['start']:5d}-{r['end']:5d} step {r['step_deg']:6.1f} deg "
                      f"({r['speed_deg_s']} deg/s) distal {r['distal_move_cm']:.1f} cm  {r['kind']}")
    harness.emit(
        "ssa_take_scan", args,
        figures={f"{k} flagged share": v["flagged_share"] for k, v in summary.items()},
        baselines={f"{k} flagged share": v["fast_share"] for k, v in summary.items()},
        details={"summary": summary, "flagged_cells_by_kind": kinds,
                 "baseline": "share of cells whose one-frame step is faster than 5,000 deg/s, same takes",
                 "runs": runs, "seconds_total": round(time.perf_counter() - t0, 1)},
    )

if __name__ == "__main__":
    main()
