"""The report's viewer on every rig of ../shared/data: is the figure upright, whole in the panel, and big enough.

For each take the page's points are computed as ``write_report`` computes them
(forward kinematics, the up axis of :func:`mocapkit.report.view.find_up_axis`
turned to +y, centimetres, points off the body left out) and framed with
:func:`mocapkit.report.view.fit_view`. Then, per collection:

- ``up_correct``: share of takes whose up axis is found right. The CMU, HDM05
  and Bandai Namco collections are Y up (``../shared/data/README.md``); the
  peer files have no stated axis and are only framed. The baseline is the rule
  the report used before, the rig's rest pose
  (:func:`mocapkit.features.detect_up_axis`), on the same takes. HDM05's
  lieDownFloor takes (lying in most frames) and the Bandai rig (rest pose
  folded along x) are the hard cases.
- ``worst_extent``: over every take, every 5th frame, 8 yaw and 3 pitch angles
  of the orbit camera and 3 panel shapes (611 x 540, 151 x 280, 800 x 300 px),
  the largest distance of a body point from the panel's centre as a share of
  its smaller half-size, at the fitted camera distance, following or not as
  the page starts. At most ``1 - MARGIN`` (0.92): nothing leaves the panel.
- ``median_fill``: median over takes of the figure's drawn height at the
  page's first view (yaw 0.6, pitch 0.25) as a share of a square panel's side.

The camera is the page's (``viewer.js``: pinhole, focal length from the
panel's smaller side and ``HALF_FOV``), written again here in numpy.

Usage: ``python benchmarks/report_framing.py [--bandai N] --json`` (``--bandai 0``: all 2,675 takes).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO / "benchmarks"))

import _harness as harness  # noqa: E402
from _bandai import bandai_takes  # noqa: E402

import mocapkit  # noqa: E402
from mocapkit.features import detect_up_axis  # noqa: E402
from mocapkit.motion import unit_scale_cm  # noqa: E402
from mocapkit.report.view import HALF_FOV, MARGIN, body_points, find_up_axis, fit_view, rotation_to_y  # noqa: E402

DATA = REPO.parent / "shared" / "data"
PANELS = ((611, 540), (151, 280), (800, 300))
YAWS = np.linspace(0, 2 * math.pi, 8, endpoint=False)
PITCHES = (-0.6, 0.25, 1.2)


def project(points, target, dist, yaw, pitch, width, height):
    """viewer.js ``camera`` + ``project``: (F, P, 3) points and (F, 3) targets -> (F, P, 2) pixels."""
    cp = math.cos(pitch)
    back = np.array([cp * math.sin(yaw), math.sin(pitch), cp * math.cos(yaw)])
    f = -back
    r = np.cross(f, [0.0, 1.0, 0.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    d = points - (target + dist * back)[:, None, :]
    zc = d @ f
    focal = 0.5 * min(width, height) / math.tan(HALF_FOV)
    return np.stack([width / 2 + focal * (d @ r) / zc, height / 2 - focal * (d @ u) / zc], axis=-1)


#: the up axis each collection's README states; the peer files state none.
TRUTH = {"cmu_asfamc": "+y", "cmu_bvh": "+y", "hdm05_asfamc": "+y", "bandai_namco": "+y"}


def axis_name(v) -> str:
    k = int(np.flatnonzero(v)[0])
    return ("+" if v[k] > 0 else "-") + "xyz"[k]


def measure(m):
    sk = m.skeleton
    raw = m.global_positions(end_sites=True)
    try:
        scale = unit_scale_cm(sk)
    except Exception:
        scale = 1.0
    up = find_up_axis(sk, raw[:, :m.num_joints])
    turn = rotation_to_y(up) * scale
    pts = raw @ turn.T
    view = fit_view([pts], fps=m.fps, body=body_points(sk, raw))
    row = {"frames": m.num_frames, "hidden": int(view.hidden.sum()), "follow": bool(view.follow), "up": axis_name(up)}
    try:
        row["up_rest_rule"] = axis_name(detect_up_axis(sk))
    except (KeyError, ValueError):
        row["up_rest_rule"] = "+y"  # what the report drew for a rig without roles
    body = pts[::5, ~view.hidden]
    idx = np.arange(0, m.num_frames, 5)
    if view.follow:
        target = np.stack([view.track[idx, 0], np.full(len(idx), view.track_height), view.track[idx, 1]], axis=1)
    else:
        target = np.broadcast_to(view.centre, (len(idx), 3))
    dist = view.distance(view.follow)
    worst = 0.0
    for w, h in PANELS:
        for yaw in YAWS:
            for pitch in PITCHES:
                px = project(body, target, dist, yaw, pitch, w, h)
                off = np.nanmax(np.abs(px - [w / 2, h / 2])) / (min(w, h) / 2)
                worst = max(worst, float(off))
    px = project(body, target, dist, 0.6, 0.25, 400, 400)
    fill = np.nanmax(px[..., 1], axis=1) - np.nanmin(px[..., 1], axis=1)
    row["worst_extent"] = worst
    row["fill"] = float(np.nanmedian(fill) / 400)
    return row


def label(p: Path) -> str:
    """A take's path relative to ../shared/data, or its file name (Bandai Namco takes are unpacked elsewhere)."""
    try:
        return str(p.relative_to(DATA))
    except ValueError:
        return p.name


def collections(n_bandai: int):
    out = {
        "cmu_asfamc": sorted((DATA / "cmu_asfamc").glob("*.amc")),
        "cmu_bvh": sorted((DATA / "cmu_bvh").glob("*.bvh")),
        "hdm05_asfamc": sorted((DATA / "hdm05_asfamc").glob("*.amc")),
        "peer_bvh": sorted((DATA / "peer_files").rglob("*.bvh")),
    }
    takes = [t.path for t in bandai_takes()]
    if n_bandai and n_bandai < len(takes):
        takes = takes[:: len(takes) // n_bandai][:n_bandai]  # evenly over both sets, every content and style
    out["bandai_namco"] = takes
    return out


def main():
    ap = harness.parser(__doc__)
    ap.add_argument("--bandai", type=int, default=500, help="Bandai Namco takes, evenly spaced (0: all 2,675)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    figures, baselines, details = {}, {}, {"collections": {}, "unreadable": []}
    all_worst = 0.0
    for name, paths in collections(args.bandai).items():
        rows = []
        for p in paths:
            try:
                m = mocapkit.load(p)
            except Exception as e:  # peer files include broken ones on purpose
                details["unreadable"].append(f"{label(p)}: {type(e).__name__}")
                continue
            if m.num_frames < 1:
                continue
            row = measure(m)
            row["take"] = label(p)
            rows.append(row)
        worst = max(rows, key=lambda r: r["worst_extent"])
        all_worst = max(all_worst, worst["worst_extent"])
        truth = TRUTH.get(name)
        if truth:
            figures[f"{name}_up_correct"] = round(float(np.mean([r["up"] == truth for r in rows])), 4)
            baselines[f"{name}_up_correct"] = round(float(np.mean([r["up_rest_rule"] == truth for r in rows])), 4)
        figures[f"{name}_worst_extent"] = round(worst["worst_extent"], 4)
        figures[f"{name}_median_fill"] = round(float(np.median([r["fill"] for r in rows])), 3)
        details["collections"][name] = {
            "takes": len(rows),
            "up_found": {a: sum(r["up"] == a for r in rows) for a in sorted({r["up"] for r in rows})},
            "wrong_up": [r["take"] for r in rows if truth and r["up"] != truth],
            "wrong_up_rest_rule": [r["take"] for r in rows if truth and r["up_rest_rule"] != truth][:10],
            "worst_take": worst["take"],
            "followed": sum(r["follow"] for r in rows),
            "with_hidden_points": sum(r["hidden"] > 0 for r in rows),
            "smallest_fill": min(rows, key=lambda r: r["fill"])["take"],
        }
    figures["worst_extent"] = round(all_worst, 4)
    details["seconds"] = round(time.perf_counter() - t0, 1)
    targets = {f"{n}_up_correct": {"value": 1.0, "op": ">=", "of": "figures"} for n in TRUTH}
    targets["worst_extent"] = {"value": round(1 - MARGIN, 4), "op": "<=", "of": "figures"}
    harness.emit("report_framing", args, figures=figures, baselines=baselines, targets=targets, details=details)


if __name__ == "__main__":
    main()
