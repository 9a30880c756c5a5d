"""Benchmark: full body from four simulated accelerometers on HDM05 (Tautges 2012, ch. 3, sec. 3.6.2).

Test clips: actor mm's locomotion clips (jog, sneak) and a few clips of other
classes, resampled to 25 fps as in the thesis; the four default sensors
(wrists, ankles) are simulated on them. Knowledge bases (not mirrored):

* ``other_actors``: all classes of the other four actors (thesis scenario 3);
* ``same_actor``: all classes of all five actors without the test clip
  (thesis scenario 1).

Error: RMS joint-position error in cm in the root frame
(``metrics.joint_position_rms(..., root_relative="frame")``). Baselines in the
same run: the single-frame nearest neighbour of the readings, and the priors
replaced by Mahalanobis terms (sec. 3.6.2). Time per frame: the online
reconstructor's push, median and mean over frames; preprocessing: the
knowledge base (readings, derivatives, kd-tree).

OpenBLAS is limited to one thread (set before numpy loads): on this shared
2-core machine its thread pool makes the per-frame 60x60 eigen-decompositions
several times slower.

    python benchmarks/reconstruct_accelerometers.py --json [--quick]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import _reconstruct as B  # noqa: E402

import mocapkit  # noqa: E402
from mocapkit import metrics  # noqa: E402
from mocapkit.features import virtual_accelerometers  # noqa: E402
from mocapkit.reconstruct import accelerometers as A  # noqa: E402

FPS = 25.0
OTHERS = ("hopBothLegs1hops", "squat1Reps", "kickLFront1Reps", "grabHighR")


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def run_clip(db, path, params):
    m = mocapkit.load(path).resample(FPS)
    rd = virtual_accelerometers(m)
    rec = A.AccelerometerReconstructor(db, FPS, **params)
    for r in rd[:3]:  # compile the numba kernels outside the timing
        rec.push(r)
    rec.reset()
    times, poses = [], []
    for r in rd:
        t0 = time.perf_counter()
        poses.append(rec.push(r))
        times.append(time.perf_counter() - t0)
    out = A._motion_of(poses, rec.skeleton, FPS, "reconstruction")
    err = metrics.joint_position_rms(out, m, root_relative="frame")
    nn = metrics.joint_position_rms(A.reconstruct_nearest_neighbor(rd, db, FPS), m, root_relative="frame")
    maha = metrics.joint_position_rms(A.reconstruct_mahalanobis(rd, db, FPS, **params), m, root_relative="frame")
    return {"clip": path.name, "frames": len(rd), "rms_cm": err, "nn_rms_cm": nn, "mahalanobis_rms_cm": maha,
            "ms_per_frame": [1e3 * t for t in times]}


def summarise(rows):
    out = {}
    for group in ("locomotion", "other"):
        rs = [r for r in rows if (B.parse_name(r["clip"]) in B.LOCOMOTION) == (group == "locomotion")]
        if not rs:
            continue
        e, nn, mh = (float(np.mean([r[k] for r in rs])) for k in ("rms_cm", "nn_rms_cm", "mahalanobis_rms_cm"))
        out[group] = {"clips": len(rs), "rms_cm": e, "nn_rms_cm": nn, "mahalanobis_rms_cm": mh,
                      "ratio_vs_nn": e / nn, "ratio_vs_mahalanobis": e / mh}
    ms = np.concatenate([r["ms_per_frame"] for r in rows])
    out["ms_per_frame_median"] = float(np.median(ms))
    out["ms_per_frame_mean"] = float(np.mean(ms))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--quick", action="store_true", help="2 locomotion clips and 1 other, fewer same-actor databases")
    ap.add_argument("-k", type=int, default=A.DEFAULTS["k"])
    args = ap.parse_args()
    params = {"k": args.k}
    B.parse_name = lambda name: B.parse(name)[1]
    classes = B.LOCOMOTION + OTHERS
    _, tests = B.scenario("mm", None)
    loco = [p for p in tests if B.parse(p)[1] in B.LOCOMOTION]
    other = [next(p for p in tests if B.parse(p)[1] == c) for c in OTHERS]
    if args.quick:
        loco = [next(p for p in loco if B.parse(p)[1] == c) for c in B.LOCOMOTION]
        other = other[:1]
    test_paths = loco + other
    log(f"{len(test_paths)} test clips of mm; classes {classes}")
    result = {"benchmark": "reconstruct_accelerometers", "fps": FPS, "mirrored": False, "params": {**A.DEFAULTS, **params},
              "test_clips": [p.name for p in test_paths], "scenarios": {}}
    # (a) other actors: one database
    db_paths, _ = B.scenario("mm", None, same_actor=False)
    db = B.database(db_paths, FPS)
    A._KB_CACHE.pop(db, None)
    t0 = time.perf_counter()
    kb = A.knowledge_base(db)
    pre = time.perf_counter() - t0
    rows = []
    for p in test_paths:
        rows.append(run_clip(db, p, params))
        log(f"other_actors {p.name}: {rows[-1]['rms_cm']:.2f} cm (nn {rows[-1]['nn_rms_cm']:.2f}, "
            f"mahalanobis {rows[-1]['mahalanobis_rms_cm']:.2f}), {np.median(rows[-1]['ms_per_frame']):.2f} ms/frame")
    result["scenarios"]["other_actors"] = {"db_frames": db.num_frames, "preprocessing_s": pre,
                                           "kb_build_s": kb.build_seconds, **summarise(rows),
                                           "per_clip": [{k: v for k, v in r.items() if k != "ms_per_frame"} for r in rows]}
    # (b) same actor: all actors, never the test clip
    all_paths, _ = B.scenario("mm", None, same_actor=True)
    rows, pres, sizes = [], [], []
    for p in (test_paths[:2] if args.quick else test_paths):
        dbp = B.database(B.without(all_paths, p), FPS)
        t0 = time.perf_counter()
        A.knowledge_base(dbp)
        pres.append(time.perf_counter() - t0)
        sizes.append(dbp.num_frames)
        rows.append(run_clip(dbp, p, params))
        log(f"same_actor {p.name}: {rows[-1]['rms_cm']:.2f} cm (nn {rows[-1]['nn_rms_cm']:.2f}, "
            f"mahalanobis {rows[-1]['mahalanobis_rms_cm']:.2f})")
        A._KB_CACHE.pop(dbp, None)
    result["scenarios"]["same_actor"] = {"db_frames": int(np.mean(sizes)), "preprocessing_s": float(np.mean(pres)),
                                         **summarise(rows),
                                         "per_clip": [{k: v for k, v in r.items() if k != "ms_per_frame"} for r in rows]}
    a = result["scenarios"]["other_actors"]
    result["targets"] = {"locomotion_rms_cm<=5": a["locomotion"]["rms_cm"] <= 5.0,
                         "ms_per_frame<=10": a["ms_per_frame_median"] <= 10.0}
    if args.json:
        print(json.dumps(result))
    else:
        print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
