"""Full body from six markers on held-out HDM05 clips (Krüger et al. 2010, sec. 5.2, Table 3).

Usage::

    python benchmarks/reconstruct_markers.py [--quick] [--json] [--fps 30] [--k K] [--head-weight 1.5]
    python benchmarks/reconstruct_markers.py --leave-one-out [--quick] [--json]

Scenario "other actors" (``_reconstruct.scenario``): the database holds every
HDM05 clip (all 11 classes) of actors bd, bk, dg and tr at 30 fps (Krüger's
HDM05 prior database is "entire HDM05"; 30 fps as in most of their
experiments); the test clips are actor mm's, never in the database:
the locomotion classes (jogLeftCircle4StepsRstart, sneak2StepsLStart: every mm
clip) and three others (grabHighR, kickLFront1Reps, squat1Reps: two clips
each). ``--quick``: one clip per class, at most 150 frames each.

Markers: 6 (lhand, rhand, lfoot, rfoot, head, root, i.e. the 4 end effectors,
head and root of sec. 5.2) simulated with ``features.virtual_markers`` on the
test clip at 30 fps, plus uniform noise within 1 mm per coordinate.

Figures, per clip and averaged over locomotion / others: the Table 3 error,
mean (max) in cm per joint: the Euclidean distance of every joint's global
position (not root-relative: the root marker is given) on the performer's own
skeleton (mm's ASF, so bone lengths are the actor's), averaged over joints and
frames, and in brackets the largest per-frame average; also the root-relative
mean. Baseline in the same run: ``markers.nearest_neighbor``, the nearest
database pose of each frame's control features placed by the same tracked
root frame (no local model, no optimisation); ``ratio`` = method / baseline.
Time per frame of ``reconstruct`` (one core, database preparation excluded
and reported separately). Target: mean <= 2.0 cm on locomotion (the paper:
1.3-3.4 cm).

Mode ``--leave-one-out`` (result ``reconstruct_markers_loo``, also run as
``benchmarks/reconstruct_markers_loo.py``): every HDM05
actor (bd, bk, dg, mm, tr) held out in turn, the database the other four
actors' clips of all 11 classes (never the held-out actor's). Queries: the
held-out actor's clips of the locomotion classes, every one as in the mm
scenario above (``--locomotion-clips``, default 0: all; 6-17 per actor), and
the first ``--clips-per-class`` clips (default 2) of every other class, each
cut to its first ``--max-frames`` frames (default 150 = 5 s); ``--quick`` one
clip per class, 90 frames. Locomotion here is jog, sneak and hop
(``jogLeftCircle4StepsRstart``, ``sneak2StepsLStart``, ``hopBothLegs1hops``);
"all" is all 11 classes, ``--clips-per-class`` clips of each (the locomotion
classes' first ones too), so that no class outweighs the others. Per held-out
actor: the frame-weighted mean error on locomotion and on all classes of
``reconstruct`` with the chosen settings
(``--k``, default ``markers.default_neighbours`` of the database size;
``--head-weight``, the head marker's weight in the neighbour search), of
``reconstruct`` with the previous defaults (``k=256``, every marker weighted 1
in the search; reported as ``previous``), and of the nearest-neighbour
baseline, all in the same run. Target: <= 2.0 cm on locomotion for every held-out actor.

The leave-one-out run also holds out Bandai Namco styles with the large
database (:func:`bandai_folds`; ``--bandai-styles``, default
``elderly,angry,giant,old,proud,tired``; ``--bandai-takes`` locomotion takes
per style, evenly spread over its takes, default 7: every locomotion take of
each dataset-1 style, 7 of elderly's 106; ``--bandai-styles ''`` for none): the split of
``reconstruct_accelerometers_bandai.py`` (dataset-2 ``elderly`` and the
dataset-1 styles dataset-2 lacks held out; every other take, about 280,000
frames at 30 fps, in the database, saved once and opened memory-mapped),
six markers on hands, ankles, head and pelvis (``Hips``), the error on the
body (the floor-bound ``joint_Root`` is not part of it). Target: <= 2.0 cm on
locomotion for every held-out style.

Where the error sits (``details.actors[*].locomotion_carriage``, and the
same per Bandai Namco style; :func:`carriage`): over each performer's
locomotion clips, the pelvis-relative error in the truth's heading frame,
the part one constant offset per joint and take explains (a carriage or a
build no database performer shares) and the rest, the chest's distance in
front of the line from the pelvis to the head in the truth and in the
reconstruction, and the six joints with the largest error.

OpenBLAS is pinned to one thread (small matrices per frame; threads only
compete on a busy machine).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import _harness as harness  # noqa: E402
import _reconstruct as B  # noqa: E402  (puts src/ on sys.path)

import mocapkit  # noqa: E402
from mocapkit.features import virtual_markers  # noqa: E402
from mocapkit.motion import unit_scale_cm  # noqa: E402
from mocapkit.reconstruct import markers as M  # noqa: E402
from mocapkit.reconstruct._common import body_motion  # noqa: E402

MARKERS = ["lhand", "rhand", "lfoot", "rfoot", "head", "root"]
OTHERS = ("grabHighR", "kickLFront1Reps", "squat1Reps")
LOO_LOCOMOTION = B.LOCOMOTION + ("hopBothLegs1hops",)
PREVIOUS = {"k": 256, "search_weights": (1.0,) * 6}  # the defaults before the head weight and the size-dependent k
#: held-out Bandai Namco styles of the leave-one-out run (dataset-2 elderly and dataset-1 styles dataset-2 lacks)
BANDAI_STYLES = ("elderly", "angry", "giant", "old", "proud", "tired")


def errors(out, truth) -> dict:
    """Mean, max and root-relative joint-position errors (cm) of the body: the pelvis and the joints below it.

    On Acclaim rigs that is every joint; on the Bandai Namco rig the floor-bound
    ``joint_Root`` (left at the origin by the takes) is not part of the body.
    """
    s = unit_scale_cm(truth.skeleton)
    a, b = body_motion(out).global_positions(), body_motion(truth).global_positions()
    per_frame = np.linalg.norm(a - b, axis=-1).mean(axis=1) * s
    rel = np.linalg.norm((a - a[:, :1]) - (b - b[:, :1]), axis=-1)[:, 1:].mean() * s
    return {"mean_cm": float(per_frame.mean()), "max_cm": float(per_frame.max()), "root_relative_mean_cm": float(rel)}


def carriage(out, truth) -> dict:
    """Where a take's error sits, pelvis-relative, in the truth's heading frame (cm).

    Each joint's position relative to the pelvis is expressed in the truth's
    heading frame (left from its right to its left thigh, up, forward), per
    frame. ``per_joint``: each joint's mean error; ``relative_cm``: the mean
    over joints and frames; ``constant_cm``: the mean over joints of the
    length of the take's mean offset (what one fixed correction per joint
    would remove: a carriage, a build); ``varying_cm``: the mean error left
    once that offset is removed. ``chest_forward_cm``: the chest's mean
    distance in front of the line from the pelvis to the head, ``(truth,
    reconstruction)``: how the trunk is carried, which six markers see only
    through the head.
    """
    from mocapkit.features import find_up_axis
    from mocapkit.rigs import roles

    a, b = body_motion(out), body_motion(truth)
    s = unit_scale_cm(truth.skeleton)
    pa, pb = a.global_positions(), b.global_positions()
    role = roles(b.skeleton)
    up = find_up_axis(b.skeleton, pb)
    left = pb[:, role["left_thigh"]] - pb[:, role["right_thigh"]]
    left = left - (left @ up)[:, None] * up
    left /= np.linalg.norm(left, axis=-1, keepdims=True)
    frame = np.stack([left, np.broadcast_to(up, left.shape), np.cross(left, up)], axis=1)  # (F, 3, 3) rows

    def local(p):
        return np.einsum("fij,fkj->fki", frame, p - p[:, :1]) * s

    d = local(pa) - local(pb)
    mean_offset = d.mean(axis=0)

    def chest_forward(p):
        pelvis, head, chest = p[:, role["pelvis"]], p[:, role["head"]], p[:, role["chest"]]
        axis = (head - pelvis) / np.linalg.norm(head - pelvis, axis=-1, keepdims=True)
        v = chest - pelvis
        v = v - np.sum(v * axis, axis=-1, keepdims=True) * axis
        return float(np.mean(np.sum(v * frame[:, 2], axis=-1)) * s)

    return {"per_joint": np.linalg.norm(d, axis=-1).mean(axis=0), "relative_cm": float(np.linalg.norm(d, axis=-1).mean()),
            "constant_cm": float(np.linalg.norm(mean_offset, axis=-1).mean()),
            "varying_cm": float(np.linalg.norm(d - mean_offset, axis=-1).mean()),
            "chest_forward_cm": (chest_forward(pb), chest_forward(pa)), "joints": b.skeleton.joint_names}


def carriage_summary(pairs) -> dict:
    """Frame-weighted :func:`carriage` over ``pairs`` of ``(frames, carriage dict)``: the figures and the six
    joints with the largest mean error."""
    w = np.array([f for f, _ in pairs], dtype=np.float64)
    per_joint = np.average([c["per_joint"] for _, c in pairs], axis=0, weights=w)
    names = pairs[0][1]["joints"]
    worst = np.argsort(per_joint)[::-1][:6]
    out = {k: float(np.average([c[k] for _, c in pairs], weights=w)) for k in ("relative_cm", "constant_cm", "varying_cm")}
    chest = np.average([c["chest_forward_cm"] for _, c in pairs], axis=0, weights=w)
    out["chest_forward_cm"] = {"truth": float(chest[0]), "reconstruction": float(chest[1])}
    out["worst_joints_cm"] = {names[j]: float(per_joint[j]) for j in worst}
    return out


def main(argv=None) -> int:
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--k", type=int, default=None, help="neighbours (default: markers.default_neighbours of the database size)")
    ap.add_argument("--head-weight", type=float, default=M.HEAD_SEARCH_WEIGHT,
                    help="weight of the head marker in the neighbour search (the others 1)")
    ap.add_argument("--prior-weight", type=float, default=0.01)
    ap.add_argument("--limit-weight", type=float, default=100.0, help="joint-range term (0: off)")
    ap.add_argument("--smooth-weight", type=float, default=0.01)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--leave-one-out", action="store_true", help="hold out each HDM05 actor in turn")
    ap.add_argument("--clips-per-class", type=int, default=2)
    ap.add_argument("--locomotion-clips", type=int, default=0,
                    help="--leave-one-out: clips per locomotion class and held-out actor (0: all of them)")
    ap.add_argument("--max-frames", type=int, default=150)
    ap.add_argument("--bandai-styles", default=",".join(BANDAI_STYLES),
                    help="--leave-one-out: held-out Bandai Namco styles to test with the large database ('' for none)")
    ap.add_argument("--bandai-takes", type=int, default=7,
                    help="locomotion takes per held-out Bandai style (7: all of each dataset-1 style's)")
    args = ap.parse_args(argv)
    log = lambda *a: print(*a, file=sys.stderr, flush=True)  # noqa: E731
    if args.leave_one_out:
        return leave_one_out(args, log)

    db_paths, tests = B.scenario("mm", None)
    t0 = time.perf_counter()
    db = B.database(db_paths, args.fps, ("F15",))
    log(f"database: {db} ({time.perf_counter() - t0:.1f} s)")
    chosen = []
    for cls in B.LOCOMOTION + OTHERS:
        clips = [p for p in tests if B.parse(p)[1] == cls]
        n = 1 if args.quick else (len(clips) if cls in B.LOCOMOTION else 2)
        chosen += clips[:n]
    rng = np.random.default_rng(args.seed)

    # database preparation (features, root frames, kd-tree) is cached per (db, markers): time it once
    t0 = time.perf_counter()
    # on the performer's skeleton, as reconstruct(skeleton=...) uses it (every mm clip has mm's ASF)
    M._marker_database(db, tuple(MARKERS), np.array([0.0, 1.0, 0.0]), mocapkit.load(chosen[0]).skeleton,
                       np.array(_weights(MARKERS, args)))
    prep_s = time.perf_counter() - t0

    rows = []
    for path in chosen:
        truth = mocapkit.load(path).resample(args.fps)
        if args.quick:
            truth = truth[:150]
        x = virtual_markers(truth, MARKERS)
        x = x + rng.uniform(-0.1, 0.1, size=x.shape) / unit_scale_cm(truth.skeleton)  # within 1 mm
        t0 = time.perf_counter()
        out = M.reconstruct(
            x, MARKERS, db, args.fps, k=args.k, skeleton=truth.skeleton, search_weights=_weights(MARKERS, args),
            prior_weight=args.prior_weight, smooth_weight=args.smooth_weight,
            limit_weight=args.limit_weight,
        )
        dt = time.perf_counter() - t0
        nn = M.nearest_neighbor(x, MARKERS, db, args.fps, skeleton=truth.skeleton, search_weights=_weights(MARKERS, args))
        fit = M.marker_residuals(out, x, MARKERS)
        _, cls, rep = B.parse(path)
        row = {
            "clip": path.stem,
            "class": cls,
            "locomotion": cls in B.LOCOMOTION,
            "frames": truth.num_frames,
            "method": errors(out, truth),
            "baseline_nn": errors(nn, truth),
            "marker_fit_mean_cm": float(np.mean(fit)),
            "ms_per_frame": 1000.0 * dt / truth.num_frames,
        }
        row["ratio"] = row["method"]["mean_cm"] / row["baseline_nn"]["mean_cm"]
        rows.append(row)
        log(
            f"{path.stem}: {row['method']['mean_cm']:.2f} ({row['method']['max_cm']:.2f}) cm, "
            f"nn {row['baseline_nn']['mean_cm']:.2f} ({row['baseline_nn']['max_cm']:.2f}) cm, "
            f"fit {row['marker_fit_mean_cm']:.3f} cm, {row['ms_per_frame']:.1f} ms/frame"
        )

    def summary(sel):
        if not sel:
            return None
        w = np.array([r["frames"] for r in sel], dtype=np.float64)
        avg = lambda key, sub: float(np.average([r[key][sub] for r in sel], weights=w))  # noqa: E731
        return {
            "clips": len(sel),
            "frames": int(w.sum()),
            "mean_cm": avg("method", "mean_cm"),
            "max_cm": float(max(r["method"]["max_cm"] for r in sel)),
            "root_relative_mean_cm": avg("method", "root_relative_mean_cm"),
            "baseline_nn_mean_cm": avg("baseline_nn", "mean_cm"),
            "baseline_nn_max_cm": float(max(r["baseline_nn"]["max_cm"] for r in sel)),
            "ratio": avg("method", "mean_cm") / avg("baseline_nn", "mean_cm"),
            "ms_per_frame": float(np.average([r["ms_per_frame"] for r in sel], weights=w)),
        }

    loco = summary([r for r in rows if r["locomotion"]])
    result = {
        "paper": "Krüger et al. 2010, sec. 5.2, Table 3 (HDM05: 1.33-3.37 cm mean per joint)",
        "scenario": "database: HDM05 actors bd, bk, dg, tr, all 11 classes; test: actor mm",
        "database": {"clips": db.num_clips, "frames": db.num_frames, "fps": db.fps, "prep_s": prep_s},
        "markers": MARKERS,
        "noise": "uniform within 1 mm per coordinate",
        "error": "mean (max over frames) of the per-frame average joint-position error, global, cm, on mm's skeleton",
        "k": args.k if args.k is not None else M.default_neighbours(db.num_frames),
        "head_weight": args.head_weight,
        "prior_weight": args.prior_weight,
        "limit_weight": args.limit_weight,
        "smooth_weight": args.smooth_weight,
        "quick": args.quick,
        "locomotion": loco,
        "others": summary([r for r in rows if not r["locomotion"]]),
        "all": summary(rows),
        "baseline": "the database pose nearest to the marker features of each frame (kd-tree), same run",
        "clips": rows,
    }
    others = result["others"] or {}
    figures = {"locomotion_mean_cm": loco["mean_cm"] if loco else None,
               "locomotion_max_cm": loco["max_cm"] if loco else None,
               "others_mean_cm": others.get("mean_cm"),
               "ms_per_frame": result["all"]["ms_per_frame"] if result["all"] else None}
    baselines = {"locomotion_mean_cm": loco["baseline_nn_mean_cm"] if loco else None,
                 "locomotion_max_cm": loco["baseline_nn_max_cm"] if loco else None,
                 "others_mean_cm": others.get("baseline_nn_mean_cm")}
    harness.emit("reconstruct_markers", args, figures=figures,
                 baselines={k: v for k, v in baselines.items() if v is not None},
                 targets={"locomotion_mean_cm": {"value": 2.0, "op": "<=", "of": "figures"}}, details=result)
    return 0


def _weights(markers, args) -> tuple:
    """Search weights of ``markers`` (the six, head fifth): ``--head-weight`` on the head, 1 elsewhere."""
    return tuple(args.head_weight if i == 4 else 1.0 for i in range(len(markers)))


def _noisy_markers(truth, rng):
    x = virtual_markers(truth, MARKERS)
    return x + rng.uniform(-0.1, 0.1, size=x.shape) / unit_scale_cm(truth.skeleton)  # within 1 mm


def leave_one_out(args, log) -> int:
    """Every HDM05 actor held out in turn (see the module docstring); emits ``reconstruct_markers_loo``."""
    per_clip = 1 if args.quick else args.clips_per_class
    per_locomotion = 1 if args.quick else args.locomotion_clips  # 0: every clip of the class
    max_frames = 90 if args.quick else args.max_frames
    rng = np.random.default_rng(args.seed)
    actors, rows, carried = {}, [], {}
    for actor in B.ACTORS:
        db_paths, tests = B.scenario(actor, None)
        db = B.database(db_paths, args.fps, ("F15",))
        chosen, count = [], {}
        for p in tests:
            cls = B.parse(p)[1]
            if count.get(cls, 0) < ((per_locomotion or len(tests)) if cls in LOO_LOCOMOTION else per_clip):
                count[cls] = count.get(cls, 0) + 1
                chosen.append((p, count[cls] <= per_clip))  # (clip, one of its class's first per_clip: in "all")
        for path, in_all in chosen:
            truth = mocapkit.load(path).resample(args.fps)[:max_frames]
            x = _noisy_markers(truth, rng)
            common = dict(skeleton=truth.skeleton, prior_weight=args.prior_weight, smooth_weight=args.smooth_weight,
                          limit_weight=args.limit_weight)
            t0 = time.perf_counter()
            out = M.reconstruct(x, MARKERS, db, args.fps, k=args.k, search_weights=_weights(MARKERS, args), **common)
            dt = time.perf_counter() - t0
            before = M.reconstruct(x, MARKERS, db, args.fps, **PREVIOUS, **common)
            nn = M.nearest_neighbor(x, MARKERS, db, args.fps, skeleton=truth.skeleton, search_weights=_weights(MARKERS, args))
            cls = B.parse(path)[1]
            row = {"actor": actor, "clip": path.stem, "class": cls, "locomotion": cls in LOO_LOCOMOTION, "in_all": in_all,
                   "frames": truth.num_frames, "method_cm": errors(out, truth)["mean_cm"],
                   "previous_cm": errors(before, truth)["mean_cm"], "baseline_nn_cm": errors(nn, truth)["mean_cm"],
                   "ms_per_frame": 1000.0 * dt / truth.num_frames}
            rows.append(row)
            if row["locomotion"]:
                carried.setdefault(actor, []).append((truth.num_frames, carriage(out, truth)))
            log(f"{actor} {path.stem}: {row['method_cm']:.2f} cm (previous defaults: {row['previous_cm']:.2f}, "
                f"nn {row['baseline_nn_cm']:.2f}), {row['ms_per_frame']:.1f} ms/frame")
        mine = [r for r in rows if r["actor"] == actor]

        def avg(sel, key):
            return float(np.average([r[key] for r in sel], weights=[r["frames"] for r in sel]))

        loco = [r for r in mine if r["locomotion"]]
        actors[actor] = {
            "database": {"clips": db.num_clips, "frames": db.num_frames},
            "k": args.k if args.k is not None else M.default_neighbours(db.num_frames),
            "clips": len(mine), "locomotion_clips": len(loco), "frames": int(sum(r["frames"] for r in mine)),
            **{f"{part}_{key}": avg(sel, key) for part, sel in (("locomotion", loco), ("all", [r for r in mine if r["in_all"]]))
               for key in ("method_cm", "previous_cm", "baseline_nn_cm")},
            "ms_per_frame": avg(mine, "ms_per_frame"),
            "locomotion_carriage": carriage_summary(carried[actor]),
        }
        c = actors[actor]["locomotion_carriage"]
        log(f"held out {actor}: locomotion {actors[actor]['locomotion_method_cm']:.2f} cm, all {actors[actor]['all_method_cm']:.2f} cm; "
            f"pelvis-relative {c['relative_cm']:.2f} cm, {c['varying_cm']:.2f} cm with each joint's mean offset per take "
            f"removed (those offsets {c['constant_cm']:.2f} cm long); chest {c['chest_forward_cm']['truth']:+.1f} cm in "
            f"front of the pelvis-head line (reconstructed {c['chest_forward_cm']['reconstruction']:+.1f})")

    figures, baselines, targets = {}, {}, {}
    for actor, a in actors.items():
        for part in ("locomotion", "all"):
            figures[f"{actor}_{part}_mean_cm"] = a[f"{part}_method_cm"]
            baselines[f"{actor}_{part}_mean_cm"] = a[f"{part}_baseline_nn_cm"]
            figures[f"{actor}_{part}_previous_cm"] = a[f"{part}_previous_cm"]
        targets[f"{actor}_locomotion_mean_cm"] = {"value": 2.0, "op": "<=", "of": "figures"}
    figures["worst_locomotion_mean_cm"] = max(a["locomotion_method_cm"] for a in actors.values())
    figures["ms_per_frame"] = float(np.average([r["ms_per_frame"] for r in rows], weights=[r["frames"] for r in rows]))
    details = {
        "paper": "Krüger et al. 2010, sec. 5.2, Table 3 (HDM05: 1.33-3.37 cm mean per joint)",
        "scenario": "leave one HDM05 actor out: database the other four actors, all 11 classes; queries the held-out actor",
        "locomotion_classes": list(LOO_LOCOMOTION),
        "clips_per_class": per_clip, "locomotion_clips": per_locomotion or "all",
        "max_frames": max_frames, "markers": MARKERS,
        "noise": "uniform within 1 mm per coordinate",
        "error": "frame-weighted mean of the per-frame average global joint-position error, cm, on the actor's own skeleton",
        "carriage": ("locomotion_carriage of each actor and style: where the error sits (reconstruct_markers.carriage, "
                     "frame-weighted over the locomotion clips): pelvis-relative in the truth's heading frame, the part one "
                     "constant offset per joint and take explains (constant_cm) and the rest (varying_cm), the chest's "
                     "distance in front of the pelvis-head line in the truth and the reconstruction, the six worst joints"),
        "k": args.k if args.k is not None else "markers.default_neighbours of each database (see actors)",
        "head_weight": args.head_weight,
        "previous": {"k": PREVIOUS["k"], "head_weight": 1.0}, "prior_weight": args.prior_weight, "smooth_weight": args.smooth_weight,
        "limit_weight": args.limit_weight,
        "baseline": "nearest database pose per frame (markers.nearest_neighbor), same run",
        "actors": actors, "clips": rows,
    }
    if args.bandai_styles:
        bandai = bandai_folds(args, rng, log)
        details["bandai"] = bandai
        for style, a in bandai["styles"].items():
            figures[f"bandai_{style}_locomotion_mean_cm"] = a["locomotion_method_cm"]
            figures[f"bandai_{style}_locomotion_previous_cm"] = a["locomotion_previous_cm"]
            baselines[f"bandai_{style}_locomotion_mean_cm"] = a["locomotion_baseline_nn_cm"]
            targets[f"bandai_{style}_locomotion_mean_cm"] = {"value": 2.0, "op": "<=", "of": "figures"}
        figures["bandai_worst_locomotion_mean_cm"] = max(a["locomotion_method_cm"] for a in bandai["styles"].values())
    harness.emit("reconstruct_markers_loo", args, figures=figures, baselines=baselines, targets=targets, details=details)
    return 0


BANDAI_MARKERS = ["Hand_L", "Hand_R", "Foot_L", "Foot_R", "Head", "Hips"]
BANDAI_LOCOMOTION = ("walk", "run", "dash", "walk-back", "walk-left", "walk-right", "walk-turn-left", "walk-turn-right")
BANDAI_CACHE = Path.home() / ".cache" / "mocapkit" / "markers_bandai"


def bandai_folds(args, rng, log) -> dict:
    """Six markers on the Bandai Namco rig, styles held out, the large database (every other style's takes).

    The split of ``reconstruct_accelerometers_bandai.py`` (``_bandai.split_by_style``):
    held out dataset-2 ``elderly`` and the dataset-1 styles dataset-2 lacks;
    the database every other take at 30 fps (built once, saved under
    ``~/.cache/mocapkit/markers_bandai``, opened memory-mapped). Queries: per
    held-out style in ``--bandai-styles``, up to ``--bandai-takes`` locomotion
    takes (walks, runs, dashes, turns), the first ``--max-frames`` frames.
    Markers: hands, ankles (``Foot_*``), head and pelvis (``Hips``).
    """
    from _bandai import bandai_takes, split_by_style

    from mocapkit.database import MotionDatabase

    train, held = split_by_style(bandai_takes())
    db_dir = BANDAI_CACHE / "database"
    t0 = time.perf_counter()
    if not (db_dir / "database.json").is_file():
        MotionDatabase.build([t.path for t in train], fps=args.fps, progress=False).save(db_dir, overwrite=True)
    db = MotionDatabase.open(db_dir)
    build_s = time.perf_counter() - t0
    styles, rows, carried = {}, [], {}
    max_frames = 90 if args.quick else args.max_frames
    for style in args.bandai_styles.split(","):
        mine = [t for t in held if t.style == style and t.content in BANDAI_LOCOMOTION]
        if not mine:
            raise SystemExit(f"no held-out Bandai Namco locomotion takes of style {style!r}")
        picks = [mine[int(i)] for i in np.unique(np.linspace(0, len(mine) - 1, args.bandai_takes).round().astype(int))]
        for take in picks:
            truth = mocapkit.load(take.path)
            truth = truth.resample(args.fps)[:max_frames] if truth.fps != args.fps else truth[:max_frames]
            x = virtual_markers(truth, BANDAI_MARKERS)
            x = x + rng.uniform(-0.1, 0.1, size=x.shape) / unit_scale_cm(truth.skeleton)  # within 1 mm
            t1 = time.perf_counter()
            common = dict(skeleton=truth.skeleton, prior_weight=args.prior_weight, smooth_weight=args.smooth_weight,
                          limit_weight=args.limit_weight)
            out = M.reconstruct(x, BANDAI_MARKERS, db, args.fps, k=args.k, search_weights=_weights(BANDAI_MARKERS, args),
                                **common)
            dt = time.perf_counter() - t1
            before = M.reconstruct(x, BANDAI_MARKERS, db, args.fps, **PREVIOUS, **common)
            nn = M.nearest_neighbor(x, BANDAI_MARKERS, db, args.fps, skeleton=truth.skeleton,
                                    search_weights=_weights(BANDAI_MARKERS, args))
            row = {"style": style, "take": take.path.name, "content": take.content, "frames": truth.num_frames,
                   "method_cm": errors(out, truth)["mean_cm"], "previous_cm": errors(before, truth)["mean_cm"],
                   "baseline_nn_cm": errors(nn, truth)["mean_cm"],
                   "ms_per_frame": 1000.0 * dt / truth.num_frames}
            rows.append(row)
            carried.setdefault(style, []).append((truth.num_frames, carriage(out, truth)))
            log(f"bandai {style} {take.path.name}: {row['method_cm']:.2f} cm (previous defaults {row['previous_cm']:.2f}, "
                f"nn {row['baseline_nn_cm']:.2f}), {row['ms_per_frame']:.1f} ms/frame")
        sel = [r for r in rows if r["style"] == style]
        w = [r["frames"] for r in sel]
        styles[style] = {"takes": len(sel), "frames": int(sum(w)),
                         "locomotion_method_cm": float(np.average([r["method_cm"] for r in sel], weights=w)),
                         "locomotion_previous_cm": float(np.average([r["previous_cm"] for r in sel], weights=w)),
                         "locomotion_baseline_nn_cm": float(np.average([r["baseline_nn_cm"] for r in sel], weights=w)),
                         "locomotion_carriage": carriage_summary(carried[style])}
        c = styles[style]["locomotion_carriage"]
        log(f"held out Bandai style {style}: locomotion {styles[style]['locomotion_method_cm']:.2f} cm; pelvis-relative "
            f"{c['relative_cm']:.2f} cm, {c['varying_cm']:.2f} cm with each joint's mean offset per take removed; chest "
            f"{c['chest_forward_cm']['truth']:+.1f} cm in front of the pelvis-head line (reconstructed "
            f"{c['chest_forward_cm']['reconstruction']:+.1f})")
    return {"scenario": "Bandai Namco styles held out (dataset-2 elderly, dataset-1 styles not in dataset-2); "
                        "database every other take at 30 fps, memory-mapped",
            "database": {"takes": len(train), "frames": db.num_frames, "open_or_build_s": build_s},
            "k": args.k if args.k is not None else M.default_neighbours(db.num_frames),
            "markers": BANDAI_MARKERS, "locomotion_contents": list(BANDAI_LOCOMOTION),
            "takes_per_style": args.bandai_takes, "max_frames": max_frames, "styles": styles, "takes": rows}


if __name__ == "__main__":
    raise SystemExit(main())
