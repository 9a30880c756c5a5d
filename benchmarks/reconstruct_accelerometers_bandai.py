"""Benchmark: full body from four simulated accelerometers with a Bandai Namco knowledge base (Tautges 2012, ch. 3).

Data: the Bandai Namco Research Motiondataset 1 and 2 (``_bandai.py``; 2,675
takes, 30 fps, one 22-joint game rig whose root ``joint_Root`` stays on the
floor while ``Hips`` carries the translation; CC BY-NC 4.0, never copied into
the repository). Split by style, never by cutting takes:

* held out: dataset-2 style ``elderly`` (all its contents) and every
  dataset-1 style that dataset-2 does not have (``angry``, ``childish``,
  ``chimpira``, ``giant``, ``happy``, ``masculinity``, ``musical``,
  ``not-confident``, ``old``, ``proud``, ``sad``, ``tired``);
* knowledge base: every other take (dataset-2 ``active``, ``normal``,
  ``feminine``, ``masculine``, ``exhausted`` and dataset-1 ``normal``,
  ``active``, ``feminine``), not mirrored, at 30 fps.

Build: ``MotionDatabase.build`` over local processes (:mod:`mocapkit.parallel`),
saved under ``~/.cache/mocapkit/accel_bandai/`` (outside the repository), opened
memory-mapped, then the knowledge base (readings, derivatives, pose PCA; in
parallel from the database on disk) saved beside it and opened memory-mapped;
timed, with the process's peak resident memory and the size of the arrays on
disk. Open time: ``MotionDatabase.open`` + ``open_knowledge_base`` + the
kd-tree rebuilt over the readings.

Test: ``--takes`` held-out takes (evenly spread over the held-out list, both
datasets), each its first ``--frames`` frames (evaluation time only; the split
is by style). Parameters: K = 256 neighbours, I = 2 paths, approximate
kd-tree search (eps = 1), the thesis' one-sample search key (:data:`VALIDATED`,
chosen by ``--validate``; a key with 0.3 s of history did not do better there);
mocapkit's defaults (K = 1 %
of the frames, I = K / 16) are reported beside them. The four default sensors (wrists, ankles) are simulated on them
(:func:`mocapkit.features.virtual_accelerometers`). Error: RMS joint-position
error of the body below the pelvis, pelvis position and heading removed, the
pelvis tilt kept (``metrics.joint_position_rms(..., root_relative="heading")``),
in cm. Beside it in the same run: the single-frame nearest neighbour of the
readings (baseline), and the oracle: the knowledge-base pose closest to each
true pose (posed on the test skeleton, heading frame, exact search), a floor
for any method that retrieves poses from this database. Time per frame: the
online reconstructor's push, median and 95th percentile.

``--validate`` sweeps K and I on a validation style instead: dataset-2
``exhausted``, left out of its knowledge base as well; the test styles are
never looked at there.

OpenBLAS is limited to one thread (set before numpy loads), as in
``reconstruct_accelerometers.py``.

    python benchmarks/reconstruct_accelerometers_bandai.py --json [--quick] [--takes N] [--frames F] [--reuse]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import dataclasses  # noqa: E402
import resource  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import _harness as harness  # noqa: E402
from _bandai import bandai_takes, split_by_style  # noqa: E402

import mocapkit  # noqa: E402
from mocapkit import metrics  # noqa: E402
from mocapkit import rotations as R  # noqa: E402
from mocapkit.database import MotionDatabase  # noqa: E402
from mocapkit.features import root_frame, virtual_accelerometers  # noqa: E402
from mocapkit.motion import unit_scale_cm  # noqa: E402
from mocapkit.reconstruct import accelerometers as A  # noqa: E402
from mocapkit.reconstruct._common import body_motion  # noqa: E402

FPS = 30.0
VALIDATION_D2 = "exhausted"
CACHE = Path.home() / ".cache" / "mocapkit" / "accel_bandai"


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def split(takes):
    """(knowledge-base takes, held-out takes): dataset-2 ``elderly`` and dataset-1 styles absent from dataset-2 held out."""
    return split_by_style(takes)


def peak_rss_mb() -> dict:
    """Peak resident memory (MB) of this process and of its (finished) worker processes."""
    return {"self": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "workers": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}


def folder_mb(p: Path) -> float:
    return sum(f.stat().st_size for f in p.rglob("*") if f.is_file()) / 2**20


def heading_points(m) -> np.ndarray:
    """Body joint positions (F, B-1, 3) in cm, pelvis at the origin, heading removed."""
    b = body_motion(m)
    _, p = b.global_transforms()
    rel = p[:, 1:] - p[:, :1]
    return R.quaternion_rotate(R.quaternion_conjugate(root_frame(b)[0][:, None]), rel) * unit_scale_cm(b.skeleton)


_ORACLE_DB: dict = {}


def oracle_rms(db, m, chunk: int = 64) -> float:
    """RMS (heading frame, cm) of the database pose closest to each true pose, posed on the test skeleton (exact)."""
    key = (id(db), m.skeleton.offsets.tobytes())
    if key not in _ORACLE_DB:
        _ORACLE_DB.clear()
        parts = [heading_points(dataclasses.replace(db.clip(c), skeleton=m.skeleton, translations=None))
                 for c in range(db.num_clips)]
        D = np.concatenate([p.reshape(len(p), -1) for p in parts], axis=0).astype(np.float32)
        _ORACLE_DB[key] = (D, np.einsum("ij,ij->i", D, D))
    D, dn = _ORACLE_DB[key]
    Q = heading_points(m).reshape(len(m), -1).astype(np.float32)
    best = np.empty(len(Q))
    for a in range(0, len(Q), chunk):
        q = Q[a:a + chunk]
        d2 = dn[None] - 2.0 * (q @ D.T) + np.einsum("ij,ij->i", q, q)[:, None]
        best[a:a + chunk] = np.maximum(d2.min(axis=1), 0.0)
    return float(np.sqrt(np.mean(best) / Q.shape[1] * 3))


def run_take(db, take, frames: int, params: dict, oracle: bool = True, defaults: bool = False) -> dict:
    m = mocapkit.load(take.path)
    m = m[: min(frames, len(m))]
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
    out = A.motion_of_poses(poses, rec.skeleton, FPS, "reconstruction", up=rec.kb.up)
    nn = A.reconstruct_nearest_neighbor(rd, db, FPS, skeleton=m.skeleton)
    extra = {}
    if defaults:  # mocapkit's default K and I, for comparison
        d = A.reconstruct(rd, db, FPS, skeleton=m.skeleton)
        extra = {"default_heading_cm": metrics.joint_position_rms(d, m, root_relative="heading")}
    return {"take": take.path.name, "dataset": take.dataset, "style": take.style, "content": take.content,
            "frames": len(m), "k": rec.k, "paths": rec.n_paths,
            "ours_heading_cm": metrics.joint_position_rms(out, m, root_relative="heading"),
            "ours_frame_cm": metrics.joint_position_rms(out, m, root_relative="frame"),
            "nn_heading_cm": metrics.joint_position_rms(nn, m, root_relative="heading"),
            "nn_frame_cm": metrics.joint_position_rms(nn, m, root_relative="frame"),
            "oracle_heading_cm": oracle_rms(db, m) if oracle else None, **extra,
            "ms_per_frame": [1e3 * t for t in times]}


def build(train, reuse: bool, cache: Path = CACHE):
    """The database and knowledge base of ``train`` (built, saved, reopened memory-mapped), with timings and memory."""
    db_dir, kb_dir = cache / "database", cache / "knowledge"
    info: dict = {"cache": str(cache)}
    if not (reuse and db_dir.is_dir()):
        t0 = time.perf_counter()
        db = MotionDatabase.build([t.path for t in train], fps=FPS, progress=False)
        info["db_build_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        shutil.rmtree(kb_dir, ignore_errors=True)
        db.save(db_dir, overwrite=True)
        info["db_save_s"] = time.perf_counter() - t0
        del db
    info["peak_rss_after_db_mb"] = peak_rss_mb()
    db = MotionDatabase.open(db_dir)
    t0 = time.perf_counter()
    kb = A.knowledge_base(db, cache_dir=kb_dir)
    info["kb_s"] = time.perf_counter() - t0  # build + save, or open when reused
    info["kb_build_s"] = kb.build_seconds
    info["peak_rss_after_kb_mb"] = peak_rss_mb()
    info["db_disk_mb"] = folder_mb(db_dir)
    info["kb_disk_mb"] = folder_mb(kb_dir)
    # open time, cold process state: forget the in-memory knowledge base
    del kb, db
    A.clear_cache()
    t0 = time.perf_counter()
    db = MotionDatabase.open(db_dir)
    t1 = time.perf_counter()
    kb = A.knowledge_base(db, cache_dir=kb_dir)
    t2 = time.perf_counter()
    kb.index("kdtree", VALIDATED.get("history", (0,)))
    t3 = time.perf_counter()
    info["open_db_s"], info["open_kb_s"], info["kdtree_rebuild_s"] = t1 - t0, t2 - t1, t3 - t2
    info["kb_memory_mapped"] = isinstance(kb.readings, np.memmap)
    info["db_frames"], info["db_clips"] = db.num_frames, db.num_clips
    return db, kb, info


#: K, I, the search key's history and the kd-tree's eps chosen by ``--validate`` (dataset-2 exhausted): the lowest validation error of the sweep.
VALIDATED = {"k": 256, "n_paths": 2, "eps": 1.0}
#: The validation sweep: overrides of mocapkit's defaults (K = 1 % of the frames, I = K / 16, one-sample key, exact search).
SWEEP = ({}, {"k": 1024}, {"k": 256}, {"n_paths": 16}, {"k": 1024, "n_paths": 8}, {"k": 256, "n_paths": 4},
         {"k": 128}, {"k": 64}, {"k": 512, "n_paths": 4}, {"k": 128, "n_paths": 4}, {"k": 64, "n_paths": 4},
         {"k": 256, "n_paths": 2}, {"k": 256, "n_paths": 8},
         # the search key with 0.3 s of history (approximate kd-tree search: exact search in 48-D is 10x slower)
         {"k": 256, "n_paths": 4, "eps": 1.0}, {"k": 256, "n_paths": 2, "eps": 1.0},
         {"k": 256, "n_paths": 4, "history": (0, 3, 6, 9), "eps": 1.0},
         {"k": 256, "n_paths": 2, "history": (0, 3, 6, 9), "eps": 1.0},
         {"k": 256, "n_paths": 1, "history": (0, 3, 6, 9), "eps": 1.0},
         {"k": 256, "n_paths": 2, "history": (0, 5, 10), "eps": 1.0},
         {"k": 256, "n_paths": 1, "history": (0, 4, 8), "eps": 1.0})


def validate(args, train) -> None:
    """K (neighbours) and I (paths) swept on the validation style; the test styles are never looked at."""
    fit = [t for t in train if not (t.dataset == 2 and t.style == VALIDATION_D2)]
    val = [t for t in train if t.dataset == 2 and t.style == VALIDATION_D2]
    db, kb, info = build(fit, args.reuse, CACHE / "validate")
    picks = [val[int(i)] for i in np.unique(np.linspace(0, len(val) - 1, args.takes).round().astype(int))]
    sweep = {}
    for params in SWEEP:
        rows = [run_take(db, t, args.frames, params, oracle=False) for t in picks]
        name = f"K={rows[0]['k']} I={rows[0]['paths']}" + "".join(f" {key}={v}" for key, v in params.items() if key not in ("k", "n_paths"))
        sweep[name] = {"heading_cm": float(np.mean([r["ours_heading_cm"] for r in rows])),
                       "nn_heading_cm": float(np.mean([r["nn_heading_cm"] for r in rows])),
                       "ms_per_frame": float(np.median(np.concatenate([r["ms_per_frame"] for r in rows])))}
        log(f"validation {name}: {sweep[name]}")
    figures = {f"{name} {key}": v for name, row in sweep.items() for key, v in row.items()}
    harness.emit("reconstruct_accelerometers_bandai_validate", args, figures=figures,
                 details={"validation_style": f"dataset-2 {VALIDATION_D2}", "db_frames": info["db_frames"],
                          "takes": [t.path.name for t in picks], "frames_per_take": args.frames, "sweep": sweep})


def main():
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="4 held-out takes of 120 frames")
    ap.add_argument("--takes", type=int, default=12, help="held-out takes tested (evenly spread)")
    ap.add_argument("--frames", type=int, default=240, help="frames per tested take (from its start)")
    ap.add_argument("--reuse", action="store_true", help="reuse a database already built in the cache folder")
    ap.add_argument("--validate", action="store_true",
                    help="the parameter sweep on validation style dataset-2 exhausted instead (held out of its knowledge base too)")
    ap.add_argument("-k", type=int, default=None, help="neighbours per sample (default: mocapkit's default_k)")
    ap.add_argument("--paths", type=int, default=None, help="OLNG paths kept, I (default: K / 16)")
    args = ap.parse_args()
    if args.quick:
        args.takes, args.frames = 4, 120
    params = {**VALIDATED, **{key: v for key, v in (("k", args.k), ("n_paths", args.paths)) if v is not None}}
    takes = bandai_takes()
    train, held = split(takes)
    log(f"{len(train)} knowledge-base takes, {len(held)} held out")
    if args.validate:
        validate(args, train)
        return
    db, kb, info = build(train, args.reuse)
    log(f"built: {info}")
    picks = [held[int(i)] for i in np.unique(np.linspace(0, len(held) - 1, args.takes).round().astype(int))]
    rows = []
    for t in picks:
        rows.append(run_take(db, t, args.frames, params, defaults=True))
        r = rows[-1]
        log(f"{r['take']}: heading ours {r['ours_heading_cm']:.2f} (defaults {r['default_heading_cm']:.2f}) nn {r['nn_heading_cm']:.2f} oracle {r['oracle_heading_cm']:.2f} cm, "
            f"{np.median(r['ms_per_frame']):.1f} ms/frame, K={r['k']}")
    ms = np.concatenate([r["ms_per_frame"] for r in rows])

    def mean(key, rs=rows):
        return float(np.mean([r[key] for r in rs]))

    groups = {}
    for name, rs in (("dataset2_elderly", [r for r in rows if r["dataset"] == 2]),
                     ("dataset1_styles", [r for r in rows if r["dataset"] == 1])):
        if rs:
            groups[name] = {"takes": len(rs), **{k: mean(k, rs) for k in ("ours_heading_cm", "default_heading_cm", "nn_heading_cm", "oracle_heading_cm", "ours_frame_cm")}}
    figures = {"heading_rms_cm": mean("ours_heading_cm"), "frame_rms_cm": mean("ours_frame_cm"),
               "oracle_heading_cm": mean("oracle_heading_cm"), "default_params_heading_rms_cm": mean("default_heading_cm"),
               "ms_per_frame": float(np.median(ms)), "ms_per_frame_p95": float(np.percentile(ms, 95)),
               "db_frames": info["db_frames"], "kb_build_s": info["kb_build_s"],
               "open_s": info["open_db_s"] + info["open_kb_s"] + info["kdtree_rebuild_s"]}
    if "db_build_s" in info:
        figures["db_build_s"] = info["db_build_s"]
    baselines = {"heading_rms_cm": mean("nn_heading_cm"), "frame_rms_cm": mean("nn_frame_cm")}
    details = {"fps": FPS, "held_out": "dataset-2 style elderly; dataset-1 styles not in dataset-2",
               "knowledge_base_takes": len(train), "held_out_takes": len(held), "tested_takes": len(rows),
               "frames_per_take": args.frames, "params": {**A.DEFAULTS, **params}, "build": info, "groups": groups,
               "baseline": "single-frame nearest neighbour of the readings (kd-tree), same knowledge base, same run",
               "per_take": [{k: v for k, v in r.items() if k != "ms_per_frame"} for r in rows]}
    harness.emit("reconstruct_accelerometers_bandai", args, figures=figures, baselines=baselines,
                 targets={"heading_rms_cm": {"value": 5.0, "op": "<=", "of": "figures"},
                          "ms_per_frame": {"value": 10.0, "op": "<=", "of": "figures"}},
                 details=details)


if __name__ == "__main__":
    main()
