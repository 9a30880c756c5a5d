"""Four-accelerometer reconstruction (Tautges 2012, ch. 3) written laid out as its take, on held-out Bandai Namco takes whose root moves or stays.

The Bandai Namco game rig's root ``joint_Root`` lies above the pelvis: on the
floor at the origin in most takes, travelling with the body in four dataset-1
takes (``dash_normal_001``, ``run_normal_001``, ``walk-back_normal_001``,
``walk_normal_002``), while ``Hips`` carries the translation (``_bandai.py``;
CC BY-NC 4.0, never copied into the repository). ``mocapkit reconstruct
--accelerometers TAKE`` writes the result laid out as ``TAKE``
(:func:`mocapkit.reconstruct.output.laid_out_like`, what this script runs).

Database: the dataset-2 ``walk`` and ``run`` takes of the styles ``normal``
and ``active`` (in-place takes: ``joint_Root`` at the origin), 30 fps, not
mirrored. Tests: the dataset-1 ``walk``, ``run``, ``dash`` and ``walk-back``
takes of the styles ``normal`` (the four that move ``joint_Root`` among
them), ``happy`` and ``tired``, each its first ``--frames`` frames; none is
in the database. Readings: the four default sensors simulated on the take
(:func:`mocapkit.features.virtual_accelerometers`); mocapkit's default
parameters, as the command runs them.

Figures:

* ``moving_root_cm``: where the take moves ``joint_Root``, the RMS of its
  position in the pelvis's ground frame (heading and floor position removed,
  :func:`mocapkit.features.root_frame`) against the take's, mean over those takes;
* ``still_root_cm``: where the take holds it still, the RMS of its global
  position against the take's;
* ``body_cm``: the body's RMS in the heading frame
  (``metrics.joint_position_rms(..., root_relative="heading")``), which the
  layout must not change; ``body_moved_cm``: the most any body joint moves
  when the result is laid out.

    python benchmarks/reconstruct_accelerometers_root_bandai.py --json [--frames F]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import _harness as harness  # noqa: E402
from _bandai import bandai_takes  # noqa: E402
from _corpus import DEFAULT_DATA  # noqa: E402,F401  (puts src/ on sys.path)

import mocapkit  # noqa: E402
from mocapkit import metrics  # noqa: E402
from mocapkit import rotations as R  # noqa: E402
from mocapkit.database import MotionDatabase  # noqa: E402
from mocapkit.features import root_frame, virtual_accelerometers  # noqa: E402
from mocapkit.reconstruct import accelerometers as A  # noqa: E402
from mocapkit.reconstruct.output import laid_out_like  # noqa: E402

UP = np.array([0.0, 1.0, 0.0])
TESTED_STYLES = ("normal", "happy", "tired")


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def root_in_pelvis_frame(m) -> np.ndarray:
    """joint_Root's position (F, 3) in the pelvis's ground frame, file units."""
    h, t = root_frame(m, UP)
    return R.quaternion_rotate(R.quaternion_conjugate(h), m.global_positions()[:, 0] - t)


def rms(d: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(d * d, axis=-1))))


def main():
    ap = harness.parser(__doc__)
    ap.add_argument("--frames", type=int, default=120, help="frames per tested take (from its start)")
    args = ap.parse_args()
    takes = bandai_takes()
    db_takes = [t for t in takes if t.dataset == 2 and t.content in ("walk", "run") and t.style in ("normal", "active")]
    tests = [t for t in takes if t.dataset == 1 and t.content in ("walk", "run", "dash", "walk-back")
             and t.style in TESTED_STYLES]
    t0 = time.perf_counter()
    db = MotionDatabase.build([t.path for t in db_takes], fps=30, progress=False)
    log(f"database: {len(db_takes)} takes, {db.num_frames} frames, {time.perf_counter() - t0:.0f} s")
    rows = []
    for t in tests:
        gt = mocapkit.load(t.path)[: args.frames]
        out = A.reconstruct(virtual_accelerometers(gt), db, gt.fps, skeleton=gt.skeleton)
        lay = laid_out_like(out, gt)
        still = np.ptp(gt.root_positions, axis=0).max() == 0 and np.ptp(gt.rotations[:, 0], axis=0).max() == 0
        if still:
            root = rms(lay.global_positions()[:, 0] - gt.global_positions()[:, 0])
        else:
            root = rms(root_in_pelvis_frame(lay) - root_in_pelvis_frame(gt))
        rows.append({"take": t.path.stem, "frames": gt.num_frames, "root_still": bool(still), "root_cm": root,
                     "body_cm": metrics.joint_position_rms(gt, lay, root_relative="heading"),
                     "body_moved_cm": float(np.abs(lay.global_positions()[:, 1:] - out.global_positions()[:, 1:]).max())})
        log(f"  {t.path.stem}: joint_Root {root:.3f} cm ({'still' if still else 'moving'}), body {rows[-1]['body_cm']:.2f} cm")

    def avg(key, still=None):
        vals = [r[key] for r in rows if still is None or r["root_still"] == still]
        return float(np.mean(vals)) if vals else None

    figures = {"moving_root_cm": avg("root_cm", False), "still_root_cm": avg("root_cm", True), "body_cm": avg("body_cm"),
               "body_moved_cm": max(r["body_moved_cm"] for r in rows)}
    details = {"database_takes": len(db_takes), "database_frames": int(db.num_frames), "tested_styles": list(TESTED_STYLES),
               "frames": args.frames, "takes": rows, "seconds": round(time.perf_counter() - t0, 1)}
    harness.emit("reconstruct_accelerometers_root_bandai", args, figures=figures, details=details)


if __name__ == "__main__":
    main()
