"""Multilinear motion model (Tautges 2012, ch. 2) on the Bandai Namco game rig, held-out styles, four simulated accelerometers.

Data: the Bandai Namco Research Motiondataset 1 (``_bandai.py``; one 22-joint
game rig whose root ``joint_Root`` lies above the pelvis: on the floor at the
origin in most takes, travelling with the body in four ``normal`` takes, while
``Hips`` carries the translation; CC BY-NC 4.0, never copied into the
repository). Per motion class (``run``, ``dash``, ``walk-back``: one take per
style; ``walk``: two), the model is built from the takes of 12 of the 15
styles (modes style, or style x repetition); the takes of the held-out styles
``normal``, ``happy`` and ``tired`` are the tests. Split by style, never by
cutting takes.

Readings: the four default sensors (:func:`mocapkit.features.default_sensors`,
up y) simulated on the test take at its 30 fps, turned into global
gravity-free accelerations with the sensors' true orientations
(``reconstruct_multilinear.py`` does the same on HDM05). Fit: 1 start, 1 time-warp
round, 30 L-BFGS iterations.

Figures:

* ``body_cm``: RMS joint-position error of the body below the pelvis, pelvis
  position and heading removed (``metrics.joint_position_rms(...,
  root_relative="heading")``), mean over the test takes;
* ``still_root_cm``: where the take holds ``joint_Root`` still, the RMS of its
  global position in the model's output (the file as written);
* ``moving_root_cm``: where the take moves it, the RMS of its position in the
  pelvis's ground frame (heading and floor position removed,
  :func:`mocapkit.features.root_frame`) after
  :func:`mocapkit.reconstruct.output.laid_out_like` (output, take);
* ``pelvis_travel_ratio``: how far the output's pelvis ends from where it
  starts on the floor, over the take's (the takes where the root is still: whole
  performances of the class).

Baseline in the same run: the class mean motion (uniform weights) on the
linear time map, its heading by eq. 2.10 (``fit_readings(optimize=False)``).

    python benchmarks/reconstruct_multilinear_bandai.py --json [--quick] [--classes run dash]
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _harness as harness
from _bandai import bandai_takes
from _corpus import DEFAULT_DATA  # noqa: F401  (puts src/ on sys.path)

import mocapkit  # noqa: E402
from mocapkit import metrics  # noqa: E402
from mocapkit import rotations as R  # noqa: E402
from mocapkit.features import default_sensors, root_frame, virtual_accelerometers  # noqa: E402
from mocapkit.reconstruct.multilinear import MultilinearModel  # noqa: E402
from mocapkit.reconstruct.output import laid_out_like  # noqa: E402
from mocapkit.rigs import pelvis_index  # noqa: E402

CLASSES = ("run", "dash", "walk-back", "walk")
HELD_OUT = ("normal", "happy", "tired")
UP = np.array([0.0, 1.0, 0.0])


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def readings(m, sensors):
    """Sensor-frame readings (F, 4, 3) and the sensors' global orientations (F, 4, 4)."""
    grot, _ = m.global_transforms()
    q = R.quaternion_multiply(grot[:, [m.skeleton.index(s.joint) for s in sensors]], np.stack([s.rotation for s in sensors]))
    return virtual_accelerometers(m, sensors), q


def root_in_pelvis_frame(m) -> np.ndarray:
    """joint_Root's position (F, 3) in the pelvis's ground frame, file units."""
    h, t = root_frame(m, UP)
    return R.quaternion_rotate(R.quaternion_conjugate(h), m.global_positions()[:, 0] - t)


def travel(m) -> float:
    p = m.global_positions()[:, pelvis_index(m.skeleton)]
    d = p[-1] - p[0]
    return float(np.linalg.norm(d - (d @ UP) * UP))


def scores(gt, out) -> dict:
    still = np.ptp(gt.root_positions, axis=0).max() == 0 and np.ptp(gt.rotations[:, 0], axis=0).max() == 0
    row = {"body_cm": metrics.joint_position_rms(gt, out, root_relative="heading"), "root_still": bool(still)}
    if still:
        row["root_cm"] = float(np.sqrt(np.mean(np.sum((gt.global_positions()[:, 0] - out.global_positions()[:, 0]) ** 2, -1))))
        row["pelvis_travel_ratio"] = travel(out) / travel(gt)
    else:
        d = root_in_pelvis_frame(gt) - root_in_pelvis_frame(laid_out_like(out, gt))
        row["root_cm"] = float(np.sqrt(np.mean(np.sum(d * d, -1))))
    return row


def run_class(cls: str, takes) -> list[dict]:
    tk = [t for t in takes if t.content == cls]
    train = [t for t in tk if t.style not in HELD_OUT]
    test = [t for t in tk if t.style in HELD_OUT]
    two = len({t.style for t in tk}) < len(tk)  # walk: two takes per style

    def label(t):
        rep = sorted(u.take_id for u in tk if u.style == t.style).index(t.take_id)
        return (t.style, rep) if two else (t.style,)

    t0 = time.process_time()
    model = MultilinearModel(modes=("style", "repetition") if two else ("style",), missing="mean", starts=1,
                             warp_iterations=1).fit([mocapkit.load(t.path) for t in train], [label(t) for t in train])
    rows = []
    for t in test:
        gt = mocapkit.load(t.path)
        sensors = default_sensors(gt.skeleton, up_axis="y")
        local, q = readings(gt, sensors)
        kw = dict(sensors=sensors, orientations=q, skeleton=gt.skeleton)
        _, out = model.fit_readings(local, gt.fps, maxiter=30, **kw)
        _, mean = model.fit_readings(local, gt.fps, optimize=False, **kw)
        rows.append({"take": t.path.stem, "frames": gt.num_frames, "multilinear": scores(gt, out), "mean": scores(gt, mean)})
        r = rows[-1]["multilinear"]
        log(f"  {t.path.stem}: body {r['body_cm']:.2f} cm (mean motion {rows[-1]['mean']['body_cm']:.2f}), "
            f"joint_Root {r['root_cm']:.3f} cm ({'still' if r['root_still'] else 'moving, laid out'})")
    log(f"{cls}: {len(train)} training takes, {len(test)} tests, {time.process_time() - t0:.1f} s CPU")
    return rows


def main():
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="the classes run and dash only")
    ap.add_argument("--classes", nargs="*", default=None, help=f"dataset-1 contents (default {' '.join(CLASSES)})")
    args = ap.parse_args()
    classes = args.classes or (["run", "dash"] if args.quick else list(CLASSES))
    takes = [t for t in bandai_takes() if t.dataset == 1]
    t0 = time.perf_counter()
    rows = [r for c in classes for r in run_class(c, takes)]

    def avg(method, key, still=None):
        vals = [r[method][key] for r in rows if key in r[method] and (still is None or r[method]["root_still"] == still)]
        return float(np.mean(vals)) if vals else None

    figures = {"body_cm": avg("multilinear", "body_cm"), "still_root_cm": avg("multilinear", "root_cm", True),
               "moving_root_cm": avg("multilinear", "root_cm", False),
               "pelvis_travel_ratio": avg("multilinear", "pelvis_travel_ratio")}
    baselines = {"body_cm": avg("mean", "body_cm")}
    details = {"classes": classes, "held_out_styles": list(HELD_OUT), "takes": rows,
               "metric": "body: joint_position_rms cm, heading frame; joint_Root: global where the take holds it still, "
                         "in the pelvis's ground frame after laid_out_like where it moves",
               "baseline": "the class mean motion (uniform weights), same takes, same run",
               "seconds": round(time.perf_counter() - t0, 1)}
    harness.emit("reconstruct_multilinear_bandai", args, figures=figures, baselines=baselines, details=details)


if __name__ == "__main__":
    main()
