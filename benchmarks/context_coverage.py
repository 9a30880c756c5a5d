"""Share of a take's frames that self-similarity judges, without and with the bundled default context.

Usage::

    python benchmarks/context_coverage.py [--json] [--quick]

Self-similarity detection (Aristidou et al. 2018, section 3.3) judges a motion
word only when some word of the context lies within 8 degrees (RMS joint
angle, ``mocapkit.cleaning.pipeline.MAX_WORD_ANGLE_DEG``); a frame is
*judged* when every analysed joint has such a neighbour there (the frames
``clean`` does not list as "no neighbour words"). With no ``--context``,
``clean`` and ``detect`` now use the bundled default context
(:mod:`mocapkit.context`); before, the take alone.

Takes, none of them in the default context: the CMU subject 131 BVH takes
(``cmu_bvh/131_*.bvh``, the cgspeed 3dsMax conversion; no ASF/AMC copies are in
the data set) and the 44 HDM05 takes of actor ``mm``, each as the CLI reads
it. Each take is analysed with the pipeline's detection settings twice, alone
(``context=False``, the baseline, measured in the same run) and with the
default (``context=None``), alternating; the figures are the frame-weighted
judged share per collection, the median extra detection time per take, and
the flags (flagged joint samples) on these clean takes and on three more clean
CMU takes (12 walk, 11_01 kick, the zombie walk), which must not rise.
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
from mocapkit.cleaning.pipeline import clean  # noqa: E402
from mocapkit.context import context_label, fit_context, resolve_context  # noqa: E402

DATA = REPO.parent / "shared" / "data"


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def collections(quick: bool) -> dict[str, list[Path]]:
    cmu131 = sorted((DATA / "cmu_bvh").glob("131_*.bvh")) + sorted((DATA / "cmu_asfamc").glob("131_*.amc"))
    mm = sorted((DATA / "hdm05_asfamc").glob("HDM_mm_*.amc"))
    extra = [DATA / "cmu_asfamc" / n for n in ("12_from_examples_02_01.amc", "11_01.amc", "zombie.amc")]
    if quick:
        cmu131, mm, extra = cmu131[:1], mm[::8], extra[:1]
    return {"cmu_131": cmu131, "hdm05_mm": mm, "cmu_other_clean": extra}


def analyse(take, ctx) -> dict:
    t = time.perf_counter()
    fitted, note = fit_context(take, ctx)
    res = clean(take, fitted, steps=("detect",))
    seconds = time.perf_counter() - t
    det = res.detection
    if det is None:  # a take shorter than one motion word: nothing is judged
        return {"judged_frames": 0, "frames": int(take.num_frames), "seconds": seconds, "flags": 0, "segments": 0,
                "context": context_label(fitted), "note": "; ".join(res.notes)}
    judged = np.isfinite(det.digression[:, det.analysed]).all(axis=1)
    return {"judged_frames": int(judged.sum()), "frames": int(take.num_frames), "seconds": seconds,
            "flags": int(det.flags.sum()), "segments": len(det.segments()),
            "context": context_label(fitted), "note": note}


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="one 131 take, every 8th mm take, one extra CMU take")
    args = ap.parse_args()
    default = resolve_context(None)
    warm = mocapkit.load(DATA / "hdm05_asfamc" / "HDM_mm_hopBothLegs1hops_031_120.amc")
    analyse(warm, None), analyse(warm, default)  # numba compiled before any timing
    rows, per = [], {}
    for coll, paths in collections(args.quick).items():
        for k, p in enumerate(paths):
            take = mocapkit.load(p)
            order = ("before", "after") if k % 2 == 0 else ("after", "before")  # alternate which runs first
            r = {w: analyse(take, None if w == "before" else default) for w in order}
            row = {"collection": coll, "take": p.name, **{f"{w}_{f}": r[w][f] for w in r for f in
                                                          ("judged_frames", "seconds", "flags", "segments")},
                   "frames": take.num_frames, "after_context": r["after"]["context"], "after_note": r["after"]["note"]}
            rows.append(row)
            log(f"{p.name}: judged {row['before_judged_frames']}/{take.num_frames} -> {row['after_judged_frames']}, "
                f"flags {row['before_flags']} -> {row['after_flags']}, {row['before_seconds']:.2f} -> "
                f"{row['after_seconds']:.2f} s ({row['after_context']})")
        sel = [r for r in rows if r["collection"] == coll]
        F = sum(r["frames"] for r in sel)
        per[coll] = {
            "takes": len(sel), "frames": F,
            "judged_before": round(sum(r["before_judged_frames"] for r in sel) / F, 4),
            "judged_after": round(sum(r["after_judged_frames"] for r in sel) / F, 4),
            "flags_before": sum(r["before_flags"] for r in sel), "flags_after": sum(r["after_flags"] for r in sel),
            "takes_with_more_flags": sum(r["after_flags"] > r["before_flags"] for r in sel),
            "median_extra_seconds": round(float(np.median([r["after_seconds"] - r["before_seconds"] for r in sel])), 3),
            "median_seconds_before": round(float(np.median([r["before_seconds"] for r in sel])), 3),
            "served_by_default": sum(r["after_context"] != "the clip itself" for r in sel),
        }
    one = next((r for r in rows if r["take"] == "131_01.bvh"), None)
    figures = {f"{c}_judged": v["judged_after"] for c, v in per.items() if c != "cmu_other_clean"}
    figures.update({f"{c}_flags": v["flags_after"] for c, v in per.items()})
    figures["median_extra_seconds_per_take"] = round(float(np.median([r["after_seconds"] - r["before_seconds"] for r in rows])), 3)
    baselines = {f"{c}_judged": v["judged_before"] for c, v in per.items() if c != "cmu_other_clean"}
    baselines.update({f"{c}_flags": v["flags_before"] for c, v in per.items()})
    harness.emit(
        "context_coverage", args, figures=figures, baselines=baselines,
        targets={f"{c}_flags": {"value": 1.0, "op": "<=", "of": "ratios"} for c in per if per[c]["flags_before"] > 0},
        details={"context": context_label(default), "collections": per,
                 "131_01": None if one is None else {k: one[k] for k in ("frames", "before_judged_frames", "after_judged_frames", "after_note")},
                 "baseline": "the same takes analysed alone (context=False), same run, alternating order",
                 "quick": bool(args.quick), "rows": rows},
    )


if __name__ == "__main__":
    main()
