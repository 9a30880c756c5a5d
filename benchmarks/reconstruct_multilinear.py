"""Multilinear motion model (Tautges 2012, ch. 2) fitted to four simulated accelerometers, on held-out HDM05 actor mm.

Per motion class: the model is built from every clip of actors bd, bk, dg, tr
(tensor DOF x joint x frame x actor x repetition; HDM05 has no style mode and
an unequal number of repetitions, the grid is completed with each actor's
mean, ``missing="mean"``). The test clips are all of actor mm's clips of the
class. Readings: the four default sensors (forearms and shins next to wrists
and ankles, :func:`mocapkit.features.default_sensors`) simulated on the test
clip at 120 fps (:func:`~mocapkit.features.virtual_accelerometers`), turned
into global gravity-free accelerations with the sensors' true orientations
(the thesis' IMU orientation, sec. 2.3.1).

Figure: RMS joint-position error (cm) against the held-out clip,
``metrics.joint_position_rms``:

* ``frame``: positions in each motion's root frame (root position and heading
  removed), the main figure, comparable across all methods;
* ``root``: root position removed only (heading kept), for the methods that
  estimate a heading (the model's eq. 2.10 rotation);
* ``dtw_frame``: the output first aligned to the ground truth by DTW on F15
  features (an oracle for the timing: what is left once timing errors are
  removed).

The output of the model is on the recording's frames already (the time map is
estimated from the readings, see :meth:`MultilinearModel.fit_readings`), so
``frame`` and ``root`` compare frame by frame without any use of the ground
truth for the timing.

Baselines measured in the same run:

* ``mean``: the model's mean motion (uniform weights) on the linear time map,
  heading by eq. 2.10 (``fit_readings(optimize=False)``);
* ``knn``: ``mocapkit.reconstruct.accelerometers.reconstruct`` (Tautges ch. 3)
  on a 30 fps database of the same class and training actors, when it exists;
* ``nn``: the nearest training frame per recording frame in the 12-D space of
  the sensor-frame readings (gravity included, so it sees the sensors' tilt),
  pose copied.
  The kNN methods' heading is not comparable, so only the root-frame figures
  are reported for them.

Usage: ``python benchmarks/reconstruct_multilinear.py --json [--quick]``.
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _harness as harness
from _reconstruct import clips, database  # noqa: F401  (puts src/ on sys.path)

import mocapkit  # noqa: E402
from mocapkit import metrics  # noqa: E402
from mocapkit import rotations as R  # noqa: E402
from mocapkit.features import default_sensors, feature_set, virtual_accelerometers  # noqa: E402
from mocapkit.motion import Motion  # noqa: E402
from mocapkit.reconstruct.multilinear import MultilinearModel  # noqa: E402
from mocapkit.search.dtw import dtw  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

TRAIN = ("bd", "bk", "dg", "tr")
TEST = "mm"
DB_FPS = 30.0  # the kNN database rate (Tautges ch. 3 works on a 30 Hz database grid)


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def readings(m: Motion):
    """Sensor-frame readings (F, 4, 3) and the sensors' global orientations (F, 4, 4) of the default sensors."""
    sens = default_sensors(m.skeleton)
    loc = virtual_accelerometers(m, sens)
    grot, _ = m.global_transforms()
    q = R.quaternion_multiply(grot[:, [m.skeleton.index(s.joint) for s in sens]], np.stack([s.rotation for s in sens]))
    return loc, q


def nn_baseline(train: list[Motion], test: Motion, local: np.ndarray) -> Motion:
    """The nearest training frame per recording frame in the space of the 12 sensor-frame readings, pose copied."""
    feats, rots, roots = [], [], []
    for m in train:
        mm = m.resample(test.fps)
        feats.append(readings(mm)[0].reshape(mm.num_frames, -1))
        rots.append(mm.rotations)
        roots.append(mm.root_positions)
    _, idx = cKDTree(np.concatenate(feats)).query(local.reshape(local.shape[0], -1))
    return Motion(test.skeleton, np.concatenate(rots)[idx], np.concatenate(roots)[idx], test.fps, name="nn")


def knn_baseline(train_paths, test: Motion, local: np.ndarray) -> Motion | None:
    """Tautges ch. 3 (online LNG + kernel priors) on a database of the same class and actors, when it exists."""
    try:
        from mocapkit.reconstruct.accelerometers import reconstruct
    except ImportError:
        return None
    out = reconstruct(local, database(train_paths, DB_FPS), test.fps, skeleton=test.skeleton)
    return Motion(test.skeleton, out.rotations, out.root_positions, test.fps, name="knn")


def dtw_aligned(gt: Motion, out: Motion) -> Motion:
    """``out`` warped onto ``gt``'s frames by DTW on F15 features (the timing oracle).

    Tautges' slope-limited steps: with the classic unit-weight steps, two clips
    of equal length get the diagonal path almost whatever they contain.
    """
    _, path = dtw(feature_set(gt, "F15", scale_cm=True).values, feature_set(out, "F15", scale_cm=True).values, steps="tautges")
    N = gt.num_frames
    sums = np.bincount(path[:, 0], weights=path[:, 1].astype(float), minlength=N)
    cnt = np.bincount(path[:, 0], minlength=N)
    t = sums / np.maximum(cnt, 1)
    i0 = np.floor(t).astype(int)
    i1 = np.minimum(i0 + 1, out.num_frames - 1)
    a = t - i0
    rot = R.slerp(out.rotations[i0], out.rotations[i1], a[:, None])
    root = out.root_positions[i0] * (1 - a)[:, None] + out.root_positions[i1] * a[:, None]
    return Motion(out.skeleton, rot, root, out.fps)


def errors(gt: Motion, out: Motion, heading: bool = True) -> dict:
    e = {
        "frame": metrics.joint_position_rms(gt, out, root_relative="frame"),
        "dtw_frame": metrics.joint_position_rms(gt, dtw_aligned(gt, out), root_relative="frame"),
    }
    if heading:
        e["root"] = metrics.joint_position_rms(gt, out, root_relative=True)
    return e


def run_class(cls: str, quick: bool) -> dict:
    train_paths = clips(TRAIN, (cls,))
    test_paths = clips((TEST,), (cls,))
    train = [mocapkit.load(p) for p in train_paths]
    tests = [mocapkit.load(p) for p in test_paths]
    if quick:
        tests = tests[:2]
    t0 = time.perf_counter()
    model = MultilinearModel(missing="mean", starts=1 if quick else 3, warp_iterations=1 if quick else 2).fit(train)
    build_s = time.perf_counter() - t0
    log(f"{cls}: {len(train)} training clips -> tensor {model.tensor_.rotations.shape}, built in {build_s:.1f} s")
    rows = []
    for gt in tests:
        local, q = readings(gt)
        t0 = time.perf_counter()
        w, out, info = model.fit_readings(local, gt.fps, orientations=q, skeleton=gt.skeleton, maxiter=30 if quick else 60, return_info=True)
        fit_s = time.perf_counter() - t0
        _, mean, minfo = model.fit_readings(local, gt.fps, orientations=q, skeleton=gt.skeleton, optimize=False, return_info=True)
        nn = nn_baseline(train, gt, local)
        t1 = time.perf_counter()
        knn = knn_baseline(train_paths, gt, local)
        knn_s = time.perf_counter() - t1
        row = {
            "clip": gt.name,
            "frames": gt.num_frames,
            "fit_s": round(fit_s, 2),
            "acc_distance_rel": {"multilinear": info["relative_distance"], "mean": minfo["relative_distance"]},
            "multilinear": errors(gt, out),
            "mean": errors(gt, mean),
            "nn": errors(gt, nn, heading=False),
            **({"knn": errors(gt, knn, heading=False), "knn_s": round(knn_s, 2)} if knn is not None else {}),
            "weights": {m: np.round(x, 3).tolist() for m, x in zip(model.modes_, w)},
        }
        rows.append(row)
        log(
            f"  {gt.name}: multilinear {row['multilinear']['frame']:.1f} cm (dtw {row['multilinear']['dtw_frame']:.1f}), "
            f"mean {row['mean']['frame']:.1f}, nn {row['nn']['frame']:.1f}, "
            f"knn {row['knn']['frame'] if 'knn' in row else float('nan'):.1f}; acc dist {info['relative_distance']:.3f} "
            f"vs mean {minfo['relative_distance']:.3f}; {fit_s:.1f} s"
        )
    # Capacity check: readings of a training clip (in the tensor) — the best the model can do.
    own = train[0]
    local, q = readings(own)
    _, out, info = model.fit_readings(local, own.fps, orientations=q, skeleton=own.skeleton, maxiter=30 if quick else 60, return_info=True)
    in_sample = {"clip": own.name, **errors(own, out), "acc_distance_rel": info["relative_distance"]}
    log(f"  in-sample {own.name}: {in_sample['frame']:.1f} cm")

    def avg(method, key):
        vals = [r[method][key] for r in rows if method in r]
        return float(np.mean(vals)) if vals else None

    summary = {
        "multilinear_cm": avg("multilinear", "frame"),
        "mean_cm": avg("mean", "frame"),
        "nn_cm": avg("nn", "frame"),
        "knn_cm": avg("knn", "frame"),
        "multilinear_root_cm": avg("multilinear", "root"),
        "mean_root_cm": avg("mean", "root"),
        "multilinear_dtw_cm": avg("multilinear", "dtw_frame"),
        "mean_dtw_cm": avg("mean", "dtw_frame"),
        "nn_dtw_cm": avg("nn", "dtw_frame"),
        "knn_dtw_cm": avg("knn", "dtw_frame"),
    }
    summary["ratio_vs_mean"] = summary["multilinear_cm"] / summary["mean_cm"]
    summary["ratio_vs_nn"] = summary["multilinear_cm"] / summary["nn_cm"]
    summary["ratio_vs_knn"] = summary["multilinear_cm"] / summary["knn_cm"] if summary["knn_cm"] else None
    return {
        "class": cls,
        "train_clips": len(train),
        "test_clips": len(tests),
        "tensor_shape": list(model.tensor_.rotations.shape),
        "observed_cells": int(model.tensor_.observed.sum()),
        "build_s": round(build_s, 2),
        "knn": "mocapkit.reconstruct.accelerometers.reconstruct (database: same class, same actors, 30 fps)"
        if rows and "knn" in rows[0] else "not available",
        **summary,
        "in_sample": in_sample,
        "clips": rows,
    }


def main():
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="one class, two test clips, fewer optimiser iterations")
    ap.add_argument("--classes", nargs="*", default=None)
    args = ap.parse_args()
    classes = args.classes or (["sneak2StepsLStart"] if args.quick else ["sneak2StepsLStart", "squat1Reps", "hopBothLegs1hops"])
    t0 = time.perf_counter()
    results = [run_class(c, args.quick) for c in classes]
    out = {
        "method": "Tautges 2012 ch. 2: HOSVD motion tensor of one class, weights fitted to 4 accelerometers (eq. 2.10)",
        "test_actor": TEST,
        "train_actors": list(TRAIN),
        "metric": "joint_position_rms cm, root frame (root position and rotation removed; 'root': position only), output on the recording's frames",
        "classes": results,
        "multilinear_cm": float(np.mean([r["multilinear_cm"] for r in results])),
        "mean_cm": float(np.mean([r["mean_cm"] for r in results])),
        "nn_cm": float(np.mean([r["nn_cm"] for r in results])),
        "knn_cm": float(np.mean([r["knn_cm"] for r in results])) if all(r["knn_cm"] for r in results) else None,
        "seconds": round(time.perf_counter() - t0, 1),
    }
    out["ratio_vs_mean"] = out["multilinear_cm"] / out["mean_cm"]
    out["ratio_vs_nn"] = out["multilinear_cm"] / out["nn_cm"]
    out["ratio_vs_knn"] = out["multilinear_cm"] / out["knn_cm"] if out["knn_cm"] else None
    out["baseline"] = "the class mean motion (all mode weights at the mean), same clips, same run"
    figures = {f"{r['class']}_cm": r["multilinear_cm"] for r in results}
    figures["all_cm"] = out["multilinear_cm"]
    figures["in_sample_cm"] = float(np.mean([r["in_sample"]["frame"] for r in results]))
    baselines = {f"{r['class']}_cm": r["mean_cm"] for r in results}
    baselines["all_cm"] = out["mean_cm"]
    harness.emit("reconstruct_multilinear", args, figures=figures, baselines=baselines, details=out)


if __name__ == "__main__":
    main()
