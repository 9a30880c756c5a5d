"""Do no harm in denoising: a cell the denoiser moved further than the take's noise explains is kept as it came.

A smoother reads every frame of its window. Where the take holds a jump no noise makes, it spreads the jump over
the good frames around it: HDM05's ``HDM_dg_squat1Reps_025_120.amc`` turns ``lfemur`` by 180 deg on frames 78-82
of the file itself (a flip in the source, not noise), and at 0.1 noise the EBF moved frame 77, a good frame, by
128 deg (the Savitzky-Golay fallback by 86), with nothing repaired. So :func:`guarded` runs the denoiser, finds
the cells it moved further than :func:`departure_bounds` (a bound tied to each joint's own noise level) that the
take holds where they are (:func:`held_cells`: near the frame before or after; a lone spike is noise's and is left
to the denoiser), runs it again with those cells missing (read around, as around a gap: their neighbours are denoised without the jump),
and gives those cells back as they came, bit for bit; a cell of the second run that still moved too far is kept
as it came too. The count and the joints are said in the step's note.

Rotations are (F, J, 4) unit quaternions (w, x, y, z), frames first; angles in degrees.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import rotations as R
from ..motion import Motion

__all__ = ["midpoint_deviation", "departure_bounds", "far_cells", "held_cells", "guarded", "SIGMAS",
           "MARGIN_DEG"]

SIGMAS = 4.0  # the bound, in standard deviations of the noise along its widest axis: white noise passes it ~2e-4
MARGIN_DEG = 3.0  # added to the bound: what a smoother may move a clean cell by (a capture's own jitter)
# a white noise sample n_t less the mean of its neighbours' has 1.5 times its variance; the median of |N(0, 1)|
_MEDIAN_ABS_NORMAL = 0.6745


def midpoint_deviation(rotations: np.ndarray) -> np.ndarray:
    """(F, J, 3) degrees: each cell's rotation away from the midpoint of its two neighbours in time (the normalised
    sum of the two quaternions, the geodesic midpoint), as a rotation vector in the midpoint's frame; NaN at the
    first and last frame and next to a missing cell. Smooth motion at capture rates leaves well under a degree;
    white noise shows whole, along its own axes."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.full(q.shape[:2] + (3,), np.nan)
    if len(q) < 3:
        return out
    a, b = q[:-2], q[2:]
    b = np.where(np.sum(a * b, axis=-1, keepdims=True) < 0.0, -b, b)
    mid = a + b
    mid /= np.maximum(np.linalg.norm(mid, axis=-1, keepdims=True), 1e-12)
    rel = R.quaternion_multiply(R.quaternion_conjugate(mid), q[1:-1])
    out[1:-1] = np.degrees(R.quaternion_to_rotvec(rel))
    return out


def departure_bounds(rotations: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(J,) degrees: how far a denoiser may move a cell of each joint, ``SIGMAS`` standard deviations of the joint's
    noise along its widest axis plus ``MARGIN_DEG``.

    The noise's std along each axis of :func:`midpoint_deviation` is its median absolute value over the joint's
    ``cells`` (F, J) (the ones being denoised: a take noisy in one stretch is judged by that stretch) over that of
    white noise; the widest axis counts (noise added to Euler channels is far wider along one axis than the
    others). The median is the robust choice: a few frames of a jump (a flip, a spike) do not raise it. A joint
    without a cell to judge by gets ``MARGIN_DEG``.
    """
    dev = np.abs(midpoint_deviation(rotations))
    dev = np.where(np.asarray(cells, dtype=bool)[..., None], dev, np.nan)
    J = dev.shape[1]
    std = np.zeros(J)
    judged = np.any(np.isfinite(dev[..., 0]), axis=0)
    if judged.any():
        med = np.nanmedian(dev[:, judged], axis=0)  # (judged, 3)
        std[judged] = med.max(axis=-1) / (_MEDIAN_ABS_NORMAL * np.sqrt(1.5))
    return SIGMAS * std + MARGIN_DEG


def far_cells(before: np.ndarray, after: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """(F, J) bool: cells whose rotation ``after`` (F, J, 4) is more than their joint's ``bounds`` (J,) degrees from
    ``before``; a missing cell on either side is not far."""
    d = np.degrees(R.geodesic_angle(before, after))
    return np.nan_to_num(d, nan=0.0) > np.asarray(bounds)[None, :]


def held_cells(rotations: np.ndarray, far: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """(F, J) bool: the ``far`` cells (F, J) that the take holds where they are, within their joint's ``bounds`` (J,)
    degrees of the frame before or after (a cell with no neighbour to judge by counts as held). A good frame the
    filter dragged towards a jump beside it, and the frames of a jump held for several frames, are held; a spike
    away from both neighbours is what noise makes, and is left to the denoiser."""
    q = np.asarray(rotations, dtype=np.float64)
    step = np.degrees(R.geodesic_angle(q[1:], q[:-1]))  # (F - 1, J)
    pad = np.full((1, q.shape[1]), np.nan)
    near = np.fmin(np.concatenate([pad, step]), np.concatenate([step, pad]))  # NaN only without a neighbour
    return far & ~(np.nan_to_num(near, nan=0.0) > np.asarray(bounds)[None, :])


def _kept_note(kept: np.ndarray, motion: Motion) -> str:
    names = motion.skeleton.joint_names
    joints = np.flatnonzero(kept.any(axis=0))
    said = ", ".join(f"{names[j]} {_frames(np.flatnonzero(kept[:, j]))}" for j in joints[:3])
    more = f" and {len(joints) - 3} more joints" if len(joints) > 3 else ""
    return (f"{int(kept.sum())} cells kept as they came: the denoiser moved them further than the take's noise "
            f"explains ({said}{more}; frames from 0)")


def _frames(f: np.ndarray) -> str:
    return f"frame {f[0]}" if len(f) == 1 else f"frames {f[0]}-{f[-1]}"


def guarded(motion: Motion, cells: np.ndarray | None, run) -> tuple[Motion, str, str]:
    """Denoise ``motion`` by ``run(motion, cells) -> (motion, method, note)`` (only ``cells`` (F, J), None: every
    non-root joint), keeping as they came the cells it moved further than :func:`departure_bounds` that the take
    holds where they are (:func:`held_cells`; module docstring). Returns ``run``'s ``(motion, method, note)``, the
    note saying the kept cells when there are any; every kept cell is bit-identical to the input."""
    F, J = motion.num_frames, motion.num_joints
    judged = np.zeros((F, J), dtype=bool)
    if cells is None:
        judged[:, 1:] = True
    else:
        judged[:] = np.asarray(cells, dtype=bool)
    out, method, note = run(motion, cells)
    bounds = departure_bounds(motion.rotations, judged)
    far = held_cells(motion.rotations, far_cells(motion.rotations, out.rotations, bounds) & judged, bounds)
    if not far.any():
        return out, method, note
    around = dataclasses.replace(motion, rotations=np.where(far[..., None], np.nan, motion.rotations))
    out, method, note = run(around, judged & ~far)
    far |= held_cells(motion.rotations, far_cells(motion.rotations, out.rotations, bounds) & judged, bounds)
    rot = np.where(far[..., None], motion.rotations, out.rotations)
    kept = _kept_note(far, motion)
    return dataclasses.replace(out, rotations=rot), method, f"{note}; {kept}" if note else kept
