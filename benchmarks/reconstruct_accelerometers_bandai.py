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
is by style). Parameters (:data:`VALIDATED`, chosen by ``--validate``): K =
2048 neighbours of the one-sample search key on standardised readings (every
sensor axis at unit spread), approximate kd-tree search (eps = 1), the lazy
neighbourhood graph, and the pose regressed (``synthesis="regression"``) on
the readings now, 3 and 6 frames back over the graph's 512 cheapest nodes,
smoothed causally (``smoothing=0.3``); the root motion from the I = 16
cheapest paths. The mean pose of those paths (the previous choice, K = 1024)
and the thesis' eq. 3.4 energy did worse there. mocapkit's defaults (K = 1 %
of the frames, exact search, mean pose) are reported beside them. The four default sensors (wrists, ankles) are simulated on them
(:func:`mocapkit.features.virtual_accelerometers`). Error: RMS joint-position
error of the body below the pelvis, pelvis position and heading removed, the
pelvis tilt kept (``metrics.joint_position_rms(..., root_relative="heading")``),
in cm. Beside it in the same run: the single-frame nearest neighbour of the
readings (baseline), and the oracle: the knowledge-base pose closest to each
true pose (posed on the test skeleton, heading frame, exact search), a floor
for any method that retrieves poses from this database. Time per frame: the
online reconstructor's push, median and 95th percentile.

``--validate`` sweeps K, I and the search and synthesis options (:data:`SWEEP`) on a validation style instead: dataset-2
``exhausted``, left out of its knowledge base as well; the test styles are
never looked at there.

OpenBLAS is limited to one thread (set before numpy loads), as in
``reconstruct_accelerometers.py``.

``--diagnose`` follows retrieval and synthesis frame by frame on the
validation style (:func:`diagnose`).

``--parts`` splits the gap between the output and the oracle on the
held-out takes of the test run by body part, speed and content
(:func:`parts`; a diagnosis: the parameters stay those of the validation style).

``--mirror`` adds every take's left/right mirror image to the knowledge base
(560,000 frames, the thesis' size); ``--cache`` puts the database elsewhere.

    python benchmarks/reconstruct_accelerometers_bandai.py --json [--quick] [--takes N] [--frames F] [--reuse] [--mirror] [--cache DIR] [--validate | --diagnose | --parts]
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
from mocapkit.reconstruct._common import body_motion, body_skeleton  # noqa: E402
from mocapkit.reconstruct.accelerometers.kernels import Rig  # noqa: E402
from mocapkit.reconstruct.accelerometers.knowledge import clip_values  # noqa: E402

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


def build(train, reuse: bool, cache: Path = CACHE, mirror: bool = False):
    """The database and knowledge base of ``train`` (built, saved, reopened memory-mapped), with timings and memory."""
    db_dir, kb_dir = cache / "database", cache / "knowledge"
    info: dict = {"cache": str(cache)}
    if not (reuse and db_dir.is_dir()):
        t0 = time.perf_counter()
        db = MotionDatabase.build([t.path for t in train], fps=FPS, mirror=mirror, progress=False)
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
    chosen = {**A.DEFAULTS, **VALIDATED}
    kb.index("kdtree", chosen["history"], chosen["standardise"])
    t3 = time.perf_counter()
    info["open_db_s"], info["open_kb_s"], info["kdtree_rebuild_s"] = t1 - t0, t2 - t1, t3 - t2
    info["kb_memory_mapped"] = isinstance(kb.readings, np.memmap)
    info["db_frames"], info["db_clips"] = db.num_frames, db.num_clips
    return db, kb, info


#: K, I and the search and synthesis options chosen by ``--validate`` (dataset-2 exhausted): the lowest validation error of the sweep.
VALIDATED = {"k": 2048, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 512, "smoothing": 0.3}
#: The thesis' search and synthesis (raw readings, eq. 3.4 energy), which the sweep's first entries keep.
THESIS = {"standardise": False, "synthesis": "energy"}
#: The validation sweep: overrides of mocapkit's defaults (K = 1 % of the frames, I = 16, one-sample key, exact search,
#: standardised readings, eq. 3.3 weights, mean pose). The previous choice (K = 256, I = 2 with the thesis' search and
#: synthesis: in effect the cheapest path's pose) first.
SWEEP = ({**THESIS, "k": 256, "n_paths": 2, "eps": 1.0},
         {**THESIS, "k": 1024, "n_paths": 16, "eps": 1.0},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "synthesis": "energy", "weights": "uniform"},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "synthesis": "energy", "weights": "uniform", "w_motion": 0.0, "w_smooth": 0.0},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "synthesis": "energy", "w_motion": 0.0, "w_smooth": 0.0},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "standardise": False, "weights": "uniform"},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "weights": "uniform"},
         {"k": 1024, "n_paths": 16, "eps": 1.0},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "standardise": False},
         {"k": 1024, "n_paths": 32, "eps": 1.0, "weights": "uniform"},
         {"k": 256, "n_paths": 16, "eps": 1.0, "weights": "uniform"},
         {"k": 2048, "n_paths": 16, "eps": 1.0, "weights": "uniform"},
         {"k": 1024, "n_paths": 8, "eps": 1.0},
         {"k": 2048, "n_paths": 32, "eps": 1.0},
         {}, {"eps": 1.0},
         # around the choice: the OLNG window (frames at 30 fps), its shortness penalty, the search key's history
         {"k": 1024, "n_paths": 16, "eps": 1.0, "window": 20},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "window": 30},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "window": 8},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "penalty_factor": 4.0},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "penalty_factor": 1.0},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "history": (0, 5, 10)},
         # the locally weighted regression of the pose on the recent readings over the graph's cheapest nodes
         {"k": 1024, "n_paths": 16, "eps": 1.0, "synthesis": "regression"},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 128},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 512},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_lags": (0,)},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_lags": (0, 3, 6, 9)},
         {"k": 1024, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "ridge": 4e-3},
         {"k": 2048, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 512},
         {"k": 2048, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 1024},
         {"k": 4096, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 1024},
         {"k": 2048, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 512, "regression_lags": (0, 3, 6, 9)},
         {"k": 2048, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 512, "smoothing": 0.3},
         {"k": 2048, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 512, "smoothing": 0.5},
         {"k": 2048, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 512, "smoothing": 0.3, "regression_cap": None},
         {"k": 2048, "n_paths": 16, "eps": 1.0, "synthesis": "regression", "regression_n": 512, "smoothing": 0.3, "regression_cap": 0.5})


def validate(args, train) -> None:
    """K (neighbours) and I (paths) swept on the validation style; the test styles are never looked at."""
    fit = [t for t in train if not (t.dataset == 2 and t.style == VALIDATION_D2)]
    val = [t for t in train if t.dataset == 2 and t.style == VALIDATION_D2]
    db, kb, info = build(fit, args.reuse, args.cache / ("validate-mirror" if args.mirror else "validate"), args.mirror)
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
    harness.emit("reconstruct_accelerometers_bandai_validate" + ("_mirror" if args.mirror else ""), args, figures=figures,
                 details={"validation_style": f"dataset-2 {VALIDATION_D2}", "db_frames": info["db_frames"],
                          "takes": [t.path.name for t in picks], "frames_per_take": args.frames, "sweep": sweep})


def _frame_errors(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Per-pose RMS distance (cm) of root-frame joint points ``P`` (n, B-1, 3) to one true frame ``T`` (B-1, 3)."""
    d = P - T[None]
    return np.sqrt(np.mean(np.einsum("nbc,nbc->nb", d, d), axis=1))


#: The configurations --diagnose follows frame by frame: the previous choice and :data:`VALIDATED`.
DIAGNOSED = {"K=256 I=2 (previous)": {**THESIS, "k": 256, "n_paths": 2, "eps": 1.0},
             "K=1024 I=16 mean (previous)": {"k": 1024, "n_paths": 16, "eps": 1.0}, "validated": VALIDATED}


def diagnose(args, train) -> None:
    """Where the error comes from, frame by frame on the validation style (the test styles are never looked at).

    Per frame, RMS over the body's joints in the root frame (pelvis at the
    origin, heading removed, tilt kept; cm), for each configuration of
    :data:`DIAGNOSED`: the synthesised pose, the pose at the end of the
    cheapest OLNG path, the best of the K retrieved poses, the best of the I
    paths kept, and the database oracle; the length of the cheapest path
    (columns of the window it covers); and the rank, by search distance, of
    the oracle's frame among all database frames.
    """
    fit = [t for t in train if not (t.dataset == 2 and t.style == VALIDATION_D2)]
    val = [t for t in train if t.dataset == 2 and t.style == VALIDATION_D2]
    db, kb, info = build(fit, args.reuse, args.cache / "validate")
    picks = [val[int(i)] for i in np.unique(np.linspace(0, len(val) - 1, args.takes).round().astype(int))]
    S = len(kb.sensors)
    rows: dict = {name: [] for name in DIAGNOSED}
    for t in picks:
        m = mocapkit.load(t.path)
        m = m[: min(args.frames, len(m))]
        rd = virtual_accelerometers(m)
        rig = Rig(body_skeleton(m.skeleton), kb.sensors)
        B = rig.J
        P = np.empty((kb.num_frames, B - 1, 3), np.float32)  # every database pose on the test skeleton
        for a in range(0, kb.num_frames, 20000):
            P[a:a + 20000] = rig.points(np.asarray(kb.poses[a:a + 20000]))[0][:, :B - 1]
        T = rig.points(clip_values(m, kb.sensors, kb.up)[:, 3 * S:3 * S + 3 * B])[0][:, :B - 1]
        oracle = [_frame_errors(P, T[f]) for f in range(len(m))]
        for name, params in DIAGNOSED.items():
            rec = A.AccelerometerReconstructor(db, FPS, skeleton=m.skeleton, **params)
            scale = kb.reading_scale if rec.params["standardise"] else np.ones(3 * S)
            for f in range(len(m)):
                rec.push(rd[f])
                info_f = rec.last_info
                if info_f.get("held", True):
                    continue
                nodes, costs = rec.olng.current_nodes, rec.olng.costs
                ok = (nodes >= 0) & np.isfinite(costs)
                ek = _frame_errors(P[nodes[ok]], T[f])
                out = rig.points(rec._p[None])[0][0, :B - 1]
                o = int(np.argmin(oracle[f]))
                dr = np.sqrt(np.sum(((np.asarray(kb.readings) - rd[f].ravel()) * scale) ** 2, axis=1))
                rows[name].append({
                    "out": float(np.sqrt(np.mean(np.sum((out - T[f]) ** 2, axis=-1)))),
                    "best_path": float(ek[np.argmin(costs[ok])]),
                    "best_of_K": float(ek.min()), "mean_of_K": float(ek.mean()),
                    "best_of_I": float(_frame_errors(P[info_f["frames"]], T[f]).min()),
                    "oracle": float(oracle[f][o]),
                    "best_path_columns": int(np.sum(rec.olng.best_paths(1)[0].frames >= 0)),
                    "oracle_search_rank": int(np.sum(dr < dr[o]))})
        log(f"{t.path.name}: done")
    figures, details = {}, {}
    for name, rs in rows.items():
        keys = ("out", "best_path", "best_of_K", "mean_of_K", "best_of_I", "oracle", "best_path_columns")
        d = {k: float(np.mean([r[k] for r in rs])) for k in keys}
        d["oracle_search_rank_median"] = float(np.median([r["oracle_search_rank"] for r in rs]))
        d["oracle_in_K_fraction"] = float(np.mean([r["oracle_search_rank"] < DIAGNOSED[name]["k"] for r in rs]))
        for x in (4.0, 6.0):
            for k in ("best_of_K", "best_of_I", "best_path", "out"):
                d[f"{k}_within_{x:g}cm"] = float(np.mean([r[k] < x for r in rs]))
        details[name] = {"frames": len(rs), **d}
        figures.update({f"{name} {k}": v for k, v in d.items() if k in ("out", "best_path", "best_of_K", "best_of_I", "oracle")})
        log(f"{name}: {details[name]}")
    harness.emit("reconstruct_accelerometers_bandai_diagnose", args, figures=figures,
                 details={"validation_style": f"dataset-2 {VALIDATION_D2}", "db_frames": info["db_frames"],
                          "takes": [t.path.name for t in picks], "frames_per_take": args.frames,
                          "configs": {k: {**v} for k, v in DIAGNOSED.items()},
                          "units": "cm, per-frame RMS over the body's joints, root frame (heading removed, tilt kept)",
                          "per_config": details})


#: Body parts of the Bandai Namco body for :func:`parts` (joint-name prefixes; the pelvis is the origin).
PARTS = {"trunk and head": ("Spine", "Chest", "Neck", "Head"), "shoulders and upper arms": ("Shoulder", "UpperArm"),
         "forearms and hands": ("LowerArm", "Hand"), "thighs and shins": ("UpperLeg", "LowerLeg"), "feet and toes": ("Foot", "Toes")}
#: Bins of the true body's speed for :func:`parts`: RMS over the joints of their root-frame speed, cm/s.
SPEEDS = ((0.0, 20.0), (20.0, 60.0), (60.0, np.inf))


def parts(args, train, held) -> None:
    """Where the gap between the output and the database oracle lies, on the held-out takes of the test run.

    A diagnosis, never a choice of parameters (those come from the validation
    style). Per frame, in the root frame (pelvis at the origin, heading
    removed, tilt kept; cm), for :data:`VALIDATED`: each body joint's
    distance to the truth for the output and for the oracle (the database
    pose closest to the true pose, posed on the test skeleton); per body
    part (:data:`PARTS`) their RMS and the part's share of the squared gap
    (sum over the part of output^2 - oracle^2, over the whole body's); the
    per-frame RMS by the true body's speed (:data:`SPEEDS`) and by the takes'
    content; the angle between the vertical as each sensor sees it on the
    output and on the truth (its tilt: what a still sensor's reading gives),
    by speed; and, among the regression's candidates (the graph's
    ``regression_n`` cheapest nodes), the cheapest one's error, the best one's
    and how many lie closer to the truth than the output.
    """
    db, kb, info = build(train, True, args.cache)
    picks = [held[int(i)] for i in np.unique(np.linspace(0, len(held) - 1, args.takes).round().astype(int))]
    S = len(kb.sensors)
    params = {**A.DEFAULTS, **VALIDATED}
    E, EO, speed, content, cheapest, best, closer, tilt = [], [], [], [], [], [], [], []
    names = None
    for t in picks:
        m = mocapkit.load(t.path)
        m = m[: min(args.frames, len(m))]
        rd = virtual_accelerometers(m)
        body = body_skeleton(m.skeleton)
        rig = Rig(body, kb.sensors)
        B = rig.J
        names = list(body.joint_names)[1:B]
        P = np.empty((kb.num_frames, B - 1, 3), np.float32)  # every database pose on the test skeleton
        for a in range(0, kb.num_frames, 20000):
            P[a:a + 20000] = rig.points(np.asarray(kb.poses[a:a + 20000]))[0][:, :B - 1]
        Pf = P.reshape(len(P), -1)
        pn = np.einsum("ij,ij->i", Pf, Pf)
        T, T_rot = rig.points(clip_values(m, kb.sensors, kb.up)[:, 3 * S:3 * S + 3 * B])
        T = T[:, :B - 1]
        up = np.broadcast_to(kb.up, (S, 3))
        Tf = T.reshape(len(T), -1).astype(np.float32)
        oracle = np.concatenate([np.argmin(pn[None] - 2.0 * (Tf[a:a + 32] @ Pf.T), axis=1) for a in range(0, len(T), 32)])
        v = np.zeros(len(m))
        v[1:] = np.sqrt(np.mean(np.sum(np.diff(T, axis=0) ** 2, axis=-1), axis=1)) * FPS
        rec = A.AccelerometerReconstructor(db, FPS, skeleton=m.skeleton, **VALIDATED)
        for f in range(len(m)):
            rec.push(rd[f])
            if rec.last_info.get("held", True):
                continue
            out, out_rot = (x[0] for x in rig.points(rec._p[None]))
            out = out[:B - 1]
            g_out = R.quaternion_rotate(R.quaternion_conjugate(out_rot), up)  # the vertical in each sensor's frame
            g_true = R.quaternion_rotate(R.quaternion_conjugate(T_rot[f]), up)
            tilt.append(np.degrees(np.arccos(np.clip(np.sum(g_out * g_true, axis=1), -1.0, 1.0))))
            E.append(np.sqrt(np.sum((out - T[f]) ** 2, axis=-1)))
            EO.append(np.sqrt(np.sum((P[oracle[f]] - T[f]) ** 2, axis=-1)))
            nodes, costs = rec.olng.current_nodes, rec.olng.costs
            ok = np.flatnonzero((nodes >= 0) & np.isfinite(costs))
            cand = nodes[ok[np.lexsort((nodes[ok], costs[ok]))][:params["regression_n"]]]
            ec = _frame_errors(P[cand], T[f])
            cheapest.append(ec[0])
            best.append(ec.min())
            closer.append(int(np.sum(ec < np.sqrt(np.mean(E[-1] ** 2)))))
            speed.append(v[f])
            content.append(t.content)
        log(f"{t.path.name}: done")
    E, EO, speed = np.stack(E), np.stack(EO), np.asarray(speed)
    out_f, orc_f = np.sqrt(np.mean(E ** 2, axis=1)), np.sqrt(np.mean(EO ** 2, axis=1))
    gap = float(np.mean(np.sum(E ** 2 - EO ** 2, axis=1)))
    by_part = {}
    for part, prefixes in PARTS.items():
        js = [j for j, n in enumerate(names) if n.startswith(prefixes)]
        by_part[part] = {"output_rms": float(np.sqrt(np.mean(E[:, js] ** 2))), "oracle_rms": float(np.sqrt(np.mean(EO[:, js] ** 2))),
                         "share_of_gap": float(np.mean(np.sum(E[:, js] ** 2 - EO[:, js] ** 2, axis=1)) / gap)}
    tilt = np.stack(tilt)
    by_speed = {f"{lo:g}-{hi:g} cm/s": {"frames": float(np.mean(sel)), "output": float(out_f[sel].mean()), "oracle": float(orc_f[sel].mean()),
                                        "sensor_tilt_deg_median": dict(zip((x.name for x in kb.sensors), np.median(tilt[sel], axis=0).tolist()))}
                for lo, hi in SPEEDS for sel in [(speed >= lo) & (speed < hi)] if sel.any()}
    by_content = {c: {"frames": int(np.sum(sel)), "output": float(out_f[sel].mean()), "oracle": float(orc_f[sel].mean())}
                  for c in sorted(set(content)) for sel in [np.asarray(content) == c]}
    figures = {"output": float(out_f.mean()), "oracle": float(orc_f.mean()), "cheapest_candidate": float(np.mean(cheapest)),
               "best_candidate": float(np.mean(best)), "candidates_closer_than_output_median": float(np.median(closer)),
               **{f"{p} share_of_gap": d["share_of_gap"] for p, d in by_part.items()}}
    log(f"parts: {figures}")
    harness.emit("reconstruct_accelerometers_bandai_parts", args, figures=figures,
                 details={"takes": [t.path.name for t in picks], "frames_per_take": args.frames, "frames": len(E),
                          "params": params, "units": "cm, per-frame RMS over the body's joints, root frame (heading removed, tilt kept)",
                          "per_joint": {n: {"output_rms": float(np.sqrt(np.mean(E[:, j] ** 2))), "oracle_rms": float(np.sqrt(np.mean(EO[:, j] ** 2)))}
                                        for j, n in enumerate(names)},
                          "per_part": by_part, "per_speed": by_speed, "per_content": by_content})


def main():
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="4 held-out takes of 120 frames")
    ap.add_argument("--takes", type=int, default=12, help="held-out takes tested (evenly spread)")
    ap.add_argument("--frames", type=int, default=240, help="frames per tested take (from its start)")
    ap.add_argument("--reuse", action="store_true", help="reuse a database already built in the cache folder")
    ap.add_argument("--validate", action="store_true",
                    help="the parameter sweep on validation style dataset-2 exhausted instead (held out of its knowledge base too)")
    ap.add_argument("--diagnose", action="store_true",
                    help="per-frame diagnosis of retrieval and synthesis on the validation style instead")
    ap.add_argument("--parts", action="store_true",
                    help="where the gap to the oracle lies on the held-out takes (per body part, speed, content) instead")
    ap.add_argument("--cache", type=Path, default=CACHE, help=f"folder for the database and knowledge base (default {CACHE})")
    ap.add_argument("--mirror", action="store_true", help="the knowledge base holds every take and its left/right mirror image")
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
    if args.diagnose:
        diagnose(args, train)
        return
    if args.parts:
        parts(args, train, held)
        return
    db, kb, info = build(train, args.reuse, args.cache / "mirror" if args.mirror else args.cache, args.mirror)
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
