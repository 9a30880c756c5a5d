"""Left/right label swaps on the Bandai Namco game rig: found by the swap check, flagged by ``detect``, undone by ``repair``.

The Bandai Namco rig's joints have rest frames that differ by side (bones
along each joint's own axis, the right side's reversed), so no reflection maps
its skeleton onto itself (``motion.mirror_mismatch`` 0.1-0.2). A real label
swap puts each joint of a pair at its partner's mirror image on the take's own
skeleton (``mirroring.mirror_for_rig``); ``corrupt.real_errors`` injects
exactly that, and the swap check (``ssa.side_swaps``, part of ``detect``)
confirms a pair's breaks as a swap when each joint steps onto that image.

Data: ``--takes`` takes evenly spread over both datasets (``_bandai.py``,
2,675 takes, 30 fps, CC BY-NC 4.0, never copied into the repository), each its
first ``--frames`` frames; ``--seeds`` seeds per take, each ``--swaps`` swaps
(``corrupt.real_errors(kinds=("swap",))``, 0.1-1 s windows where both sides
differ by 15 degrees or more from their mirror image at every frame). The
take itself is the context (local analysis).

Figures, pooled over takes and seeds, per (frame, joint) cell:

* ``swap_recall`` / ``swap_precision``: the swap check's cells
  (``Detection.swaps``) against the swapped cells;
* ``flag_recall``: swapped cells that ``detect`` flags (any cue);
* ``swap_cells_on_untouched_takes``: swap-check cells on the untouched takes
  (false alarms);
* ``repair_error_deg``: mean geodesic angle from the truth over the swapped
  cells after ``repair`` (baseline: before it, the corrupted take);
* ``repair_position_rms_cm``: joint-position RMS (global, all joints) from
  the truth over the frames holding a swap, after ``repair`` (baseline: before
  it);
* ``edge_*``: the same corrupted takes cut so that a swap touches the take's
  edge (even seeds: from the first swap's first frame on, so it starts at
  frame 0; odd seeds: up to the last swap's last frame, so it runs to the
  take's end; cuts under 30 frames skipped): ``edge_swap_recall`` /
  ``edge_swap_precision`` of the swap check's cells, ``edge_repair_error_deg``
  over the swapped cells after ``repair`` (baseline: before it),
  ``edge_repaired_share`` the swapped cells put back within 0.01 deg, and
  ``edge_harmed_cells`` the cells off a swap that ``repair`` moved by more.

Baseline of the swap check: the same check given the plain mirror's rotations
(``Motion.mirror()`` reused on the take's skeleton, what it was given before
the rig's rest frames were taken into account), on the same corrupted takes
(``plain_mirror_swap_recall`` / ``_precision``).

    python benchmarks/swaps_bandai.py --json                 # 60 takes x 2 seeds
    python benchmarks/swaps_bandai.py --takes 4 --seeds 1    # quick look
"""

from __future__ import annotations

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
from mocapkit import corrupt  # noqa: E402
from mocapkit import rotations as R  # noqa: E402
from mocapkit.cleaning import ssa  # noqa: E402
from mocapkit.cleaning.ssa import cues  # noqa: E402
from mocapkit.motion import mirror_mismatch  # noqa: E402


def spread(items: list, n: int) -> list:
    """``n`` items evenly spread over ``items`` (all of them when fewer)."""
    if n >= len(items):
        return list(items)
    return [items[int(i)] for i in np.linspace(0, len(items) - 1, n).round().astype(int)]


def plain_mirror_swaps(bad, det) -> np.ndarray:
    """(F, J) the swap check as ``detect`` runs it, given ``Motion.mirror()``'s rotations instead."""
    p = ssa.SSAParams()
    q = np.asarray(bad.rotations, dtype=np.float64)
    return cues.swaps_from_residuals(cues.midpoint_residuals(q), bad.skeleton.joint_names, bad.fps, p.swap_jump_deg,
                                     p.swap_max_s, det.analysed, rotations=q, mirrored=bad.mirror().rotations)


def position_rms(motion, truth, frames: np.ndarray) -> float:
    """RMS distance (file units: cm on this rig) of all joints from the truth's over ``frames`` (F,) bool."""
    d = np.sum((motion.global_positions() - truth.global_positions()) ** 2, axis=-1)[frames]
    return float(np.sqrt(d.mean()))


def counts(found: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(true positives, found, truth) cell counts."""
    return np.array([int((found & truth).sum()), int(found.sum()), int(truth.sum())])


def ratio(a: float, b: float) -> float | None:
    """``a / b``; None (no figure) when nothing was counted."""
    return float(a / b) if b else None


def edge_cut(m, bad, records, seed: int):
    """``(truth, corrupted, truth mask)`` cut so that a swap touches the take's edge: from the first record's start
    (even ``seed``) or up to the last record's end (odd); None where under 30 frames are left."""
    lo, hi = (min(r.start for r in records), m.num_frames) if seed % 2 == 0 else (0, max(r.end for r in records))
    if hi - lo < 30:
        return None
    truth = np.zeros((hi - lo, m.num_joints), dtype=bool)
    for r in records:
        truth[max(r.start - lo, 0) : min(r.end, hi) - lo, m.skeleton.index(r.joint)] = True
    return m[lo:hi], bad[lo:hi], truth


def main(argv=None) -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--takes", type=int, default=60, help="takes, evenly spread over both datasets")
    ap.add_argument("--frames", type=int, default=300, help="frames of each take, from its start")
    ap.add_argument("--seeds", type=int, default=2, help="seeds per take")
    ap.add_argument("--swaps", type=int, default=2, help="swaps per take and seed")
    args = ap.parse_args(argv)

    takes = spread(bandai_takes(), args.takes)
    swap, plain, flag = np.zeros(3, int), np.zeros(3, int), np.zeros(3, int)
    untouched_cells = 0
    err_before, err_after, n_cells = 0.0, 0.0, 0
    pos_before, pos_after = [], []
    rows = []
    t_detect = []
    edge, edge_before, edge_after, edge_cells, edge_back, edge_harmed = np.zeros(3, int), 0.0, 0.0, 0, 0, 0
    for take in takes:
        m = mocapkit.load(take.path)[: args.frames]
        clean_det = ssa.detect(m)
        untouched_cells += int(clean_det.swaps.sum())
        for seed in range(args.seeds):
            bad, _, records = corrupt.real_errors(m, kinds=("swap",), n_errors=args.swaps, seed=seed)
            truth = np.zeros((m.num_frames, m.num_joints), dtype=bool)
            for r in records:
                truth[r.start : r.end, m.skeleton.index(r.joint)] = True
            if not truth.any():
                continue
            t0 = time.process_time()
            det = ssa.detect(bad)
            t_detect.append(time.process_time() - t0)
            fixed = ssa.repair(bad, det)
            swap += counts(det.swaps, truth)
            plain += counts(plain_mirror_swaps(bad, det), truth)
            flag += counts(det.flags, truth)
            cells = np.nonzero(truth)
            before = np.degrees(R.geodesic_angle(bad.rotations[cells], m.rotations[cells]))
            after = np.degrees(R.geodesic_angle(fixed.rotations[cells], m.rotations[cells]))
            err_before += float(before.sum())
            err_after += float(after.sum())
            n_cells += len(before)
            frames = truth.any(axis=1)
            pb, pa = position_rms(bad, m, frames), position_rms(fixed, m, frames)
            pos_before.append(pb)
            pos_after.append(pa)
            cut = edge_cut(m, bad, records, seed)
            if cut is not None:
                em, eb, et = cut
                edet = ssa.detect(eb)
                efixed = ssa.repair(eb, edet)
                edge += counts(edet.swaps, et)
                off = np.degrees(R.geodesic_angle(efixed.rotations, em.rotations))
                was = np.degrees(R.geodesic_angle(eb.rotations, em.rotations))
                edge_before += float(was[et].sum())
                edge_after += float(off[et].sum())
                edge_cells += int(et.sum())
                edge_back += int((off[et] < 0.01).sum())
                edge_harmed += int(((off > 0.01) & ~et).sum())
            rows.append({"take": take.path.name, "seed": seed, "frames": m.num_frames,
                         "mismatch": round(mirror_mismatch(m.skeleton), 3),
                         "pairs": sorted({r.joint for r in records}),
                         "swap_cells": int(truth.sum()), "found": int((det.swaps & truth).sum()),
                         "flagged": int((det.flags & truth).sum()),
                         "error_deg_before": round(float(before.mean()), 2), "error_deg_after": round(float(after.mean()), 2),
                         "position_rms_cm_before": round(pb, 2), "position_rms_cm_after": round(pa, 2)})
    figures = {
        "swap_recall": ratio(swap[0], swap[2]),
        "swap_precision": ratio(swap[0], swap[1]),
        "plain_mirror_swap_recall": ratio(plain[0], plain[2]),
        "plain_mirror_swap_precision": ratio(plain[0], plain[1]),
        "flag_recall": ratio(flag[0], flag[2]),
        "swap_cells_on_untouched_takes": untouched_cells,
        "repair_error_deg": err_after / max(n_cells, 1),
        "repair_position_rms_cm": float(np.sqrt(np.mean(np.square(pos_after)))) if pos_after else float("nan"),
        "swapped_cells": int(swap[2]),
        "edge_swap_recall": ratio(edge[0], edge[2]),
        "edge_swap_precision": ratio(edge[0], edge[1]),
        "edge_repair_error_deg": edge_after / max(edge_cells, 1),
        "edge_repaired_share": ratio(edge_back, edge_cells),
        "edge_harmed_cells": edge_harmed,
        "edge_swapped_cells": edge_cells,
        "corrupted_takes": len(rows),
        "detect_cpu_s_median": float(np.median(t_detect)) if t_detect else float("nan"),
    }
    baselines = {
        "swap_recall": figures["plain_mirror_swap_recall"],
        "swap_precision": figures["plain_mirror_swap_precision"],
        "repair_error_deg": err_before / max(n_cells, 1),
        "edge_repair_error_deg": edge_before / max(edge_cells, 1),
        "repair_position_rms_cm": float(np.sqrt(np.mean(np.square(pos_before)))) if pos_before else float("nan"),
    }
    details = {"takes": [t.path.name for t in takes], "rows": rows,
               "note": "baselines: swap_* the swap check given Motion.mirror()'s rotations on the same takes; "
                       "repair_* the corrupted take before repair"}
    harness.emit("swaps_bandai", args, figures=figures, baselines=baselines, details=details)


if __name__ == "__main__":
    main()
