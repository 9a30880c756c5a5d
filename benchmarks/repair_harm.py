"""Repairs that make a take worse (issue 21, "do no harm"): self-similarity repair's runs against the clean take.

Usage::

    python benchmarks/repair_harm.py [--quick] [--collections C,...] [--workers W] [--json] [--no-save]

Each take is cleaned as ``clean --steps detect,repair`` cleans it (``whole_take.detect_take`` with
``take_params()``, then ``ssa.repair_with_left``, no foot-skate cleanup), once as it is (a clean take, where
every change is harm) and once per seed corrupted with ``corrupt.real_errors`` (4 errors; the CLI's
``mocapkit corrupt --kind errors``). A *run* is a maximal run of frames in which the repair changed one joint;
each run is judged by the mean angle (degrees) of its cells off the clean take, input against output:

* ``worse``: the output is more than 1 degree further off than the input was (the guide's figure);
* ``improved``: more than 1 degree nearer; ``repaired``: every run the repair left changed.

``moved``: the cells no error touched that the repair changed, how many and by how much (mean and largest
angle from their input, which is the clean take there). The baseline, in the same run on the same detections,
is the repair without its guard (``guard=False``).

Collections (tune: the rules may be chosen on them; check: judge there, never tune):

* ``cmu`` (tune): CMU ASF/AMC 11_01, charleston1, pirouette, backflip, 12_02_01 and CMU BVH 131_01-02
  (131_03 holds a dropout detect refuses), clean and seed 1001;
* ``hdm05`` (tune): HDM05 actors bd, bk, dg, tr, the first take of each of the 11 classes, clean and seeds
  1001, 1002 (``--quick``: grabHighR only);
* ``hdm05_mm`` (check): actor mm, the first two takes of each class, clean and seed 2001 (``--quick``: kick
  and grabHighR);
* ``bandai`` (check): 12 Bandai Namco takes (every 200th of the 2,675, sorted by path), clean and seed 2001
  (``--quick``: 4).

Where the worse runs are (every collection, ``--json --no-save``): cmu 12 of 40, hdm05 15 of 393, hdm05_mm 0 of
87, bandai 0 of 54. All 27 lie where the "clean" take has a glitch of its own, which the repair takes away;
against the take that counts as worse, and it is a repair (``(c)``: under every seed that leaves it, clean or not):

=====================================================  ==================================================
run (frames 0-based, ``seed``: c, 1001, 1002)           the input there
=====================================================  ==================================================
CMU charleston1 ltoes 285 and 332 (c, 1001),            one-frame spikes of a one-channel toe at 120 fps:
rtoes 84 (1001): 0.0 -> 18.8, 21.9, 13.2 deg            rx -31.3, -6.5, -21.5 (285); -17.9, +9.1, -13.8
                                                        (332); -29.8, -15.2, -24.2 (84)
CMU pirouette rtoes 13-27 (c, 1001): 0.0 -> 40.6        rx +52.6 -> -2.5 at 13 and -52.9 -> -33.4 -> +27.1
                                                        at 26-28: 15 frames 110 deg off the path both sides
CMU backflip lhand 128-134, rhand 122-135, rwrist       the hands lost in the flip: lhand rz -22, -123, -274,
130-135, lradius 131-138 (c; rwrist 1001 too):          -119, -268, -384 (150 deg a frame each way), rwrist
0.0 -> 106.9, 22.6, 23.7, 7.2                           22, -2, 23, 94, 137, 152, 125, 45, 1 deg
HDM05 dg lieDownFloor lhand 143-174, rhand 191-196      a hand's rz steps half a turn and back (ASF limit
(c, 1001, 1002); dg throwBasketball rhand 152-153       +-45 deg): lhand 270.5 -> 450.2 at 143, 451.1 ->
(c, 1001, 1002); tr throwBasketball rhand 176-207,      271.7 at 175; dg rhand 89.8 -> 269.6 -> 448.5; tr
267-298 (c, 1001, 1002): 0.0 -> 165.6-179.8             -272 -> -451 at 176, -479 -> -642 at 208
=====================================================  ==================================================

Left by the guard and counted in no row (the unguarded baseline's worse runs): a leg's other solution in the
clean take (the thigh half a turn about its bone, the knee past its limit), which a swap ends on or an offset
reads as its own, is given back by its limb's positions (``cleaning/ssa/limb_paths.py``): HDM05 bk depositFloorR
s1001 rfemur 138-213 (23.5 -> 127.3 deg unguarded) and the knee inside it, rtibia 173-205 (0.0 -> 33.7); dg
squat1Reps s1001 lfemur 62-78 (37.5 -> 83.5 unguarded) is exchanged back with its partner by the limbs'
positions (``limb_paths.exchange_nearer``): both thighs 37.5 -> 0.0.
Clean frames within the confirmation's margin past a swap exchanged back (``guard.margin_runs``): Bandai
walk_active_013 s2001 LowerArm_L 58-59 (0.0 -> 1.1 deg), HDM05 bd jogLeftCircle4StepsRstart s1002 rhumerus 81
(0.0 -> 1.0), mm squat1Reps 038 s2001 rhumerus 66-69 (0.0 -> 0.5).

    python benchmarks/repair_harm.py --json --no-save            # every collection (~10 min on 2 cores)
    python benchmarks/repair_harm.py --quick --json --no-save    # ~3 min
"""

from __future__ import annotations

import os
import sys
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO / "benchmarks"))

import _harness as harness  # noqa: E402

# the real data beside the repository; $MOCAPKIT_SHARED_DATA for a checkout elsewhere (a git worktree), as _corpus
DATA = Path(os.environ.get("MOCAPKIT_SHARED_DATA", REPO.parent / "shared" / "data"))
COLLECTIONS = ("cmu", "hdm05", "hdm05_mm", "bandai")
CHECK = ("hdm05_mm", "bandai")
WORSE_DEG = 1.0


def _hdm05(actors, per_class: int, classes=None) -> list[Path]:
    root = DATA / "hdm05_asfamc"
    out = []
    for actor in actors:
        by_class = defaultdict(list)
        for p in sorted(root.glob(f"HDM_{actor}_*_120.amc")):
            by_class[p.name.split("_")[2]].append(p)
        for c in sorted(by_class):
            if classes is None or c in classes:
                out += by_class[c][:per_class]
    return out


def jobs(collections, quick: bool) -> list[tuple[str, str, int | None]]:
    """``(collection, path, seed)`` for every run (seed None: the clean take)."""
    out = []
    if "cmu" in collections:
        names = ["11_01.amc", "charleston1.amc", "pirouette.amc", "backflip.amc", "12_from_examples_02_01.amc"]
        paths = [DATA / "cmu_asfamc" / n for n in names] + [DATA / "cmu_bvh" / f"131_0{i}.bvh" for i in (1, 2)]
        if quick:
            paths = paths[3:5] + paths[5:6]
        out += [("cmu", str(p), s) for p in paths for s in (None, 1001)]
    if "hdm05" in collections:
        paths = _hdm05(("bd", "bk", "dg", "tr"), 1, ("grabHighR",) if quick else None)
        out += [("hdm05", str(p), s) for p in paths for s in (None, 1001, 1002)]
    if "hdm05_mm" in collections:
        paths = _hdm05(("mm",), 2, ("kickLFront1Reps", "grabHighR") if quick else None)
        out += [("hdm05_mm", str(p), s) for p in paths for s in (None, 2001)]
    if "bandai" in collections:
        from _bandai import bandai_takes

        takes = bandai_takes()[::200][: 4 if quick else 12]
        out += [("bandai", str(t.path), s) for t in takes for s in (None, 2001)]
    return out


def _asf(path: Path) -> Path | None:
    if path.suffix != ".amc":
        return None
    if path.parent.name == "hdm05_asfamc":
        return path.parent / f"HDM_{path.name.split('_')[1]}.asf"
    own = path.with_suffix(".asf")
    if own.is_file():
        return own
    stem = path.stem.split("_")[0]
    for cand in (path.parent / f"{stem}.asf", path.parent / f"{stem.rstrip('0123456789')}.asf"):
        if cand.is_file():
            return cand
    return None


def _runs(changed: np.ndarray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate([[0], changed.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def judge(clean_rot, bad_rot, out_rot, mask) -> dict:
    """The runs of ``out_rot`` (F, J, 4) changed from ``bad_rot`` judged against ``clean_rot``; ``mask`` (F, J) the
    corrupted cells."""
    from mocapkit import rotations as R

    off_in = np.degrees(R.geodesic_angle(bad_rot, clean_rot))
    off_out = np.degrees(R.geodesic_angle(out_rot, clean_rot))
    changed = np.any(out_rot != bad_rot, axis=-1)
    runs = []
    for j in np.flatnonzero(changed.any(axis=0)):
        for s, e in _runs(changed[:, j]):
            runs.append((int(j), s, e, float(off_in[s:e, j].mean()), float(off_out[s:e, j].mean()),
                         bool(mask[s:e, j].any())))
    moved = changed & ~mask
    step = np.degrees(R.geodesic_angle(out_rot, bad_rot))[moved]
    return {"runs": runs, "moved": int(moved.sum()), "moved_mean_deg": float(step.mean()) if step.size else 0.0,
            "moved_max_deg": float(step.max()) if step.size else 0.0}


def one(job) -> dict:
    """Both repairs of one take (clean or corrupted) and their runs."""
    import mocapkit
    from mocapkit import corrupt
    from mocapkit.cleaning import ssa
    from mocapkit.cleaning.whole_take import detect_take, take_params
    from mocapkit.io.takes import load_take

    coll, path, seed = job
    p = Path(path)
    asf = _asf(p)
    clean = load_take(p, asf=asf) if asf is not None else mocapkit.load(p)
    if seed is None:
        bad, mask = clean, np.zeros(clean.rotations.shape[:2], dtype=bool)
    else:
        bad, mask, _ = corrupt.corrupt(clean, kind="errors", seed=seed)
    det = detect_take(bad, None, params=take_params()).detection
    res = {"collection": coll, "take": p.name, "seed": seed, "joints": list(clean.skeleton.joint_names)}
    for name, guard in (("guarded", True), ("unguarded", False)):
        out, _ = ssa.repair_with_left(bad, det, None, foot_skate=False, guard=guard)
        res[name] = judge(clean.rotations, bad.rotations, out.rotations, mask)
    return res


def summarise(results: list[dict], which: str) -> dict:
    """Per collection: runs repaired / improved / worse, uncorrupted cells moved and by how much."""
    out = {}
    for coll in sorted({r["collection"] for r in results}):
        rs = [r for r in results if r["collection"] == coll]
        runs = [x for r in rs for x in r[which]["runs"]]
        worse = sum(o - i > WORSE_DEG for _, _, _, i, o, _ in runs)
        improved = sum(i - o > WORSE_DEG for _, _, _, i, o, _ in runs)
        moved = sum(r[which]["moved"] for r in rs)
        mean = (sum(r[which]["moved"] * r[which]["moved_mean_deg"] for r in rs) / moved) if moved else 0.0
        out[coll] = {"takes": len(rs), "runs": len(runs), "improved": improved, "worse": worse,
                     "worse_deg": round(sum(max(o - i, 0.0) for _, _, _, i, o, _ in runs if o - i > WORSE_DEG), 1),
                     "moved": moved, "moved_mean_deg": round(mean, 2),
                     "moved_max_deg": round(max((r[which]["moved_max_deg"] for r in rs), default=0.0), 2)}
    return out


def worse_rows(results: list[dict], which: str, sign: float = 1.0) -> list[str]:
    """One line per run made worse (``sign`` -1: per run improved)."""
    rows = []
    for r in results:
        for j, s, e, i, o, hit in r[which]["runs"]:
            if sign * (o - i) > WORSE_DEG:
                rows.append(f"{r['collection']} {r['take']} seed {r['seed']}: {r['joints'][j]} frames {s}-{e - 1} "
                            f"{i:.1f} -> {o:.1f} deg{'' if hit else ' (no error there)'}")
    return rows


def main(argv=None) -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="fewer takes per collection")
    ap.add_argument("--collections", default=",".join(COLLECTIONS), help="comma-separated: " + ", ".join(COLLECTIONS))
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    colls = [c for c in args.collections.split(",") if c]
    bad = [c for c in colls if c not in COLLECTIONS]
    if bad:
        raise SystemExit(f"unknown collection(s) {bad}; collections are {', '.join(COLLECTIONS)}")
    todo = jobs(colls, args.quick)
    if args.workers > 1:
        with ProcessPoolExecutor(args.workers) as ex:
            results = list(ex.map(one, todo))
    else:
        results = [one(j) for j in todo]
    new, old = summarise(results, "guarded"), summarise(results, "unguarded")
    figures, baselines = {}, {}
    for coll in new:
        for key in ("runs", "improved", "worse", "moved", "moved_max_deg"):
            figures[f"{coll}_{key}"] = new[coll][key]
            baselines[f"{coll}_{key}"] = old[coll][key]
    if not args.json:
        for coll in new:
            print(coll, "guarded", new[coll], "\n", " " * len(coll), "unguarded", old[coll])
        print("\n".join(worse_rows(results, "guarded")))
    harness.emit("repair_harm", args, figures=figures, baselines=baselines,
                 details={"guarded": new, "unguarded": old, "check_collections": list(CHECK),
                          "worse_runs": worse_rows(results, "guarded"),
                          "worse_runs_unguarded": worse_rows(results, "unguarded"),
                          "improved_runs": worse_rows(results, "guarded", -1.0)})


if __name__ == "__main__":
    main()
