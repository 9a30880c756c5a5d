"""Benchmark: full body from four simulated accelerometers on HDM05 (Tautges 2012, ch. 3, sec. 3.6.2).

Test clips: actor mm's locomotion clips (jog, sneak) and a few clips of other
classes, resampled to 25 fps as in the thesis; the four default sensors
(wrists, ankles) are simulated on them. Knowledge bases (not mirrored):

* ``other_actors``: all classes of the other four actors (thesis scenario 3);
* ``same_actor``: all classes of all five actors without the test clip
  (thesis scenario 1).

Error: RMS joint-position error in cm relative to the root, in two frames:
``frame`` (root position and rotation removed, ``metrics.joint_position_rms(...,
root_relative="frame")``, the thesis' "relative to the skeleton root frame")
and ``heading`` (root position and heading removed, the pelvis tilt kept).
Baselines in the same run: the single-frame nearest neighbour of the readings,
and the priors replaced by Mahalanobis terms (sec. 3.6.2). ``oracle`` is the
database pose closest to the true pose in every frame (posed on the test
actor's skeleton, heading frame): a floor for any method that retrieves poses
from this database. ``thesis_k`` repeats the locomotion clips with the thesis'
K = 4096. Time per frame: the online reconstructor's push, median and mean
over frames; preprocessing: the knowledge base (readings, derivatives,
kd-tree).

``--validate`` sweeps K on the validation actor instead (database bd, bk, dg;
test clips tr's locomotion), the run that chose :func:`default_k`; mm is never
looked at there.

OpenBLAS is limited to one thread (set before numpy loads): on this shared
2-core machine its thread pool makes the per-frame 60x60 eigen-decompositions
several times slower.

    python benchmarks/reconstruct_accelerometers.py --json [--quick] [--validate]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import dataclasses  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

import _harness as harness  # noqa: E402
import _reconstruct as B  # noqa: E402

import mocapkit  # noqa: E402
from mocapkit import metrics  # noqa: E402
from mocapkit import rotations as R  # noqa: E402
from mocapkit.features import root_frame, virtual_accelerometers  # noqa: E402
from mocapkit.motion import unit_scale_cm  # noqa: E402
from mocapkit.reconstruct import accelerometers as A  # noqa: E402
from mocapkit.reconstruct._common import per_clip  # noqa: E402

FPS = 25.0
OTHERS = ("hopBothLegs1hops", "squat1Reps", "kickLFront1Reps", "grabHighR")


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def _heading_points(m):
    """Joint positions (F, J-1, 3) in cm, root at the origin, heading removed."""
    _, p = m.global_transforms()
    rel = p[:, 1:] - p[:, :1]
    return R.quaternion_rotate(R.quaternion_conjugate(root_frame(m)[0][:, None]), rel) * unit_scale_cm(m.skeleton)


def oracle_rms(db, m) -> float:
    """RMS (heading frame, cm) of the database pose closest to each true pose, posed on the test skeleton."""
    D = per_clip(db, lambda c: _heading_points(dataclasses.replace(c, skeleton=m.skeleton))).reshape(db.num_frames, -1)
    Q = _heading_points(m).reshape(len(m), -1)
    d, _ = cKDTree(D).query(Q, k=1)
    return float(np.sqrt(np.mean(d**2) / (m.num_joints - 1)))


def _errors(out, m) -> dict:
    return {"frame": metrics.joint_position_rms(out, m, root_relative="frame"),
            "heading": metrics.joint_position_rms(out, m, root_relative="heading")}


def run_clip(db, path, params, baselines=True, oracle=True):
    m = mocapkit.load(path).resample(FPS)
    rd = virtual_accelerometers(m)
    rec = A.AccelerometerReconstructor(db, FPS, skeleton=m.skeleton, **params)
    for r in rd[:3]:  # compile the numba kernels outside the timing
        rec.push(r)
    rec.reset()
    times, poses = [], []
    for r in rd:
        t0 = time.perf_counter()
        poses.append(rec.push(r))
        times.append(time.perf_counter() - t0)
    out = A.motion_of_poses(poses, rec.skeleton, FPS, "reconstruction")
    row = {"clip": path.name, "frames": len(rd), "k": rec.k, "paths": rec.n_paths, "ours": _errors(out, m),
           "ms_per_frame": [1e3 * t for t in times]}
    if baselines:
        row["nn"] = _errors(A.reconstruct_nearest_neighbor(rd, db, FPS, skeleton=m.skeleton), m)
        row["mahalanobis"] = _errors(A.reconstruct_mahalanobis(rd, db, FPS, skeleton=m.skeleton, **params), m)
    if oracle:
        row["oracle_heading"] = oracle_rms(db, m)
    return row


def summarise(rows):
    out = {}
    for group in ("locomotion", "other"):
        rs = [r for r in rows if (B.parse(r["clip"])[1] in B.LOCOMOTION) == (group == "locomotion")]
        if not rs:
            continue
        g = {"clips": len(rs)}
        for method in ("ours", "nn", "mahalanobis"):
            if method in rs[0]:
                for frame in ("frame", "heading"):
                    g[f"{method}_{frame}_cm"] = float(np.mean([r[method][frame] for r in rs]))
        if "oracle_heading" in rs[0]:
            g["oracle_heading_cm"] = float(np.mean([r["oracle_heading"] for r in rs]))
        for frame in ("frame", "heading"):
            for base in ("nn", "mahalanobis"):
                if f"{base}_{frame}_cm" in g:
                    g[f"ratio_vs_{base}_{frame}"] = g[f"ours_{frame}_cm"] / g[f"{base}_{frame}_cm"]
        out[group] = g
    ms = np.concatenate([r["ms_per_frame"] for r in rows])
    out["ms_per_frame_median"] = float(np.median(ms))
    out["ms_per_frame_mean"] = float(np.mean(ms))
    out["ms_per_frame_p95"] = float(np.percentile(ms, 95))
    return out


def _strip(rows):
    return [{k: v for k, v in r.items() if k != "ms_per_frame"} for r in rows]


def validate(args) -> dict:
    """K sweep on the validation actor tr (database bd, bk, dg): how default_k was chosen; then the thesis' search and synthesis against the defaults."""
    db = B.database(B.clips(("bd", "bk", "dg")), FPS)
    tests = B.clips(("tr",), B.LOCOMOTION)
    if args.quick:
        tests = tests[:2]
    ks = (64, 128, 256, 1024, 4096)
    sweep = {}
    # K with mocapkit's defaults; then, at the default K, the thesis' search and synthesis (raw readings,
    # I = K / 16, eq. 3.4 energy) and each default switched back to it alone
    runs = [(str(k), {"k": k}) for k in ks] + [
        ("thesis", {"standardise": False, "n_paths": None, "synthesis": "energy"}),
        ("raw readings", {"standardise": False}), ("I=K/16", {"n_paths": None}), ("energy", {"synthesis": "energy"})]
    for name, params in runs:
        rows = [run_clip(db, p, params, baselines=False, oracle=False) for p in tests]
        sweep[name] = {f: float(np.mean([r["ours"][f] for r in rows])) for f in ("frame", "heading")}
        sweep[name]["ms_per_frame_median"] = float(np.median(np.concatenate([r["ms_per_frame"] for r in rows])))
        log(f"validation {name}: {sweep[name]}")
    return {"benchmark": "reconstruct_accelerometers", "mode": "validate", "db_frames": db.num_frames,
            "test_clips": [p.name for p in tests], "default_k": A.default_k(db.num_frames), "sweep": sweep}


def _log_row(scenario, r):
    o = r["ours"]
    extra = ""
    if "nn" in r:
        extra = (f" (nn {r['nn']['frame']:.2f}/{r['nn']['heading']:.2f}, mahalanobis "
                 f"{r['mahalanobis']['frame']:.2f}/{r['mahalanobis']['heading']:.2f}, oracle {r['oracle_heading']:.2f})")
    log(f"{scenario} {r['clip']}: frame/heading {o['frame']:.2f}/{o['heading']:.2f} cm{extra}, "
        f"K={r['k']}, {np.median(r['ms_per_frame']):.2f} ms/frame")


def main():
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="2 locomotion clips and 1 other, fewer same-actor databases")
    ap.add_argument("--validate", action="store_true", help="the K sweep on validation actor tr instead")
    ap.add_argument("-k", type=int, default=None, help="neighbours per sample (default: mocapkit's default_k)")
    args = ap.parse_args()
    if args.validate:
        result = validate(args)
        result.pop("benchmark", None)
        figures = {f"{'K=' if k.isdigit() else ''}{k} {key}": v for k, row in result["sweep"].items() for key, v in row.items()}
        harness.emit("reconstruct_accelerometers_validate", args, figures=figures, details=result)
        return
    params = {} if args.k is None else {"k": args.k}
    classes = B.LOCOMOTION + OTHERS
    _, tests = B.scenario("mm", None)
    loco = [p for p in tests if B.parse(p)[1] in B.LOCOMOTION]
    other = [next(p for p in tests if B.parse(p)[1] == c) for c in OTHERS]
    if args.quick:
        loco = [next(p for p in loco if B.parse(p)[1] == c) for c in B.LOCOMOTION]
        other = other[:1]
    test_paths = loco + other
    log(f"{len(test_paths)} test clips of mm; classes {classes}")
    result = {"fps": FPS, "mirrored": False, "params": {**A.DEFAULTS, **params},
              "test_clips": [p.name for p in test_paths], "scenarios": {}}
    # (a) other actors: one database
    db_paths, _ = B.scenario("mm", None, same_actor=False)
    db = B.database(db_paths, FPS)
    A.clear_cache(db)
    t0 = time.perf_counter()
    kb = A.knowledge_base(db)
    pre = time.perf_counter() - t0
    rows = []
    for p in test_paths:
        rows.append(run_clip(db, p, params))
        _log_row("other_actors", rows[-1])
    result["scenarios"]["other_actors"] = {"db_frames": db.num_frames, "k": rows[0]["k"], "paths": rows[0]["paths"],
                                           "preprocessing_s": pre, "kb_build_s": kb.build_seconds, **summarise(rows),
                                           "per_clip": _strip(rows)}
    # the thesis' K = 4096 on the same database, locomotion clips
    rows_k = [run_clip(db, p, {**params, "k": 4096}, baselines=False, oracle=False) for p in loco]
    for r in rows_k:
        _log_row("thesis_k", r)
    result["scenarios"]["thesis_k"] = {"k": 4096, **summarise(rows_k), "per_clip": _strip(rows_k)}
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
        _log_row("same_actor", rows[-1])
        A.clear_cache(dbp)
    result["scenarios"]["same_actor"] = {"db_frames": int(np.mean(sizes)), "preprocessing_s": float(np.mean(pres)),
                                         **summarise(rows), "per_clip": _strip(rows)}
    a = result["scenarios"]["other_actors"]
    same = result["scenarios"]["same_actor"]
    result["baseline"] = "single-frame nearest neighbour of the readings (kd-tree), same database, same run"
    figures = {"locomotion_rms_cm": a["locomotion"]["ours_frame_cm"],
               "locomotion_heading_rms_cm": a["locomotion"]["ours_heading_cm"],
               "same_actor_locomotion_rms_cm": same["locomotion"]["ours_frame_cm"],
               "ms_per_frame": a["ms_per_frame_median"], "ms_per_frame_p95": a["ms_per_frame_p95"],
               "oracle_heading_cm": a["locomotion"].get("oracle_heading_cm")}
    baselines = {"locomotion_rms_cm": a["locomotion"].get("nn_frame_cm"),
                 "locomotion_heading_rms_cm": a["locomotion"].get("nn_heading_cm"),
                 "same_actor_locomotion_rms_cm": same["locomotion"].get("nn_frame_cm")}
    harness.emit("reconstruct_accelerometers", args, figures=figures,
                 baselines={k: v for k, v in baselines.items() if v is not None},
                 targets={"locomotion_rms_cm": {"value": 5.0, "op": "<=", "of": "figures"},
                          "ms_per_frame": {"value": 10.0, "op": "<=", "of": "figures"}},
                 details=result)


if __name__ == "__main__":
    main()
