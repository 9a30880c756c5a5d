"""Detect and repair a whole take: the one path ``mocapkit clean``, ``mocapkit detect`` and ``mocapkit repair`` share.

:func:`mocapkit.cleaning.ssa.detect` and :func:`~mocapkit.cleaning.ssa.repair`
analyse every frame they are given. A take is more than its motion: a
calibration pose may open or close it (the CMU BVH converter's T-pose at frame
0, :mod:`mocapkit.cleaning.calibration`), which shares no motion word with the
rest and jumps into the motion by a break no smooth motion makes. Analysed with
the take, the pose is flagged and "repaired", and the break confirms
digressions in the second after it; and since every row of the movement
digression map is scaled by its own median, leaving the pose in or out moves
flags elsewhere in the take too.

:func:`detect_take` therefore finds the calibration poses, runs
:func:`~mocapkit.cleaning.ssa.detect` on the frames between them with
``clean``'s parameters (:func:`take_params`: the word gate of
:data:`MAX_WORD_ANGLE_DEG`), and puts the detection back at the take's frames
(:meth:`~mocapkit.cleaning.ssa.Detection.padded`); :func:`repair_take`
replaces flagged cells inside that span only, with foot-skate cleanup off
unless asked for (it would also move the hip and knee of a leg whose foot is
planted: cells nobody flagged). :func:`mocapkit.cleaning.pipeline.clean` calls
both, and so do the ``detect`` and ``repair`` commands: on the same take, context
and options, ``detect`` flags what ``clean --steps detect`` flags and ``repair``
changes what ``clean --steps detect,repair`` changes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MocapError, SkeletonError
from ..motion import Motion
from .calibration import calibration_mask, calibration_poses

__all__ = ["MAX_WORD_ANGLE_DEG", "TakeDetection", "take_params", "motion_span", "detect_take", "across_breaks", "repair_take",
           "changed_cells", "differing"]

MAX_WORD_ANGLE_DEG = 8.0  # words with no neighbour this close (RMS joint angle) are not judged


@dataclass(frozen=True)
class TakeDetection:
    """What :func:`detect_take` found.

    ``detection``: the :class:`~mocapkit.cleaning.ssa.Detection` at the take's frames (its ``span`` set when
    calibration poses were left out), or None when nothing could be analysed; ``skipped``: then why, one
    line ("" otherwise); ``calibration``: the :class:`~mocapkit.cleaning.calibration.CalibrationPose` of the
    take, left alone; ``span``: ``(lo, hi)``, the frames between them.
    """

    detection: object
    calibration: tuple
    span: tuple
    skipped: str = ""


def take_params(*, max_word_angle_deg: float | None = MAX_WORD_ANGLE_DEG, drifts: bool = False, **overrides):
    """The :class:`~mocapkit.cleaning.ssa.SSAParams` a take is judged with: ``clean``'s word gate
    (``max_word_angle_deg``, :mod:`mocapkit.cleaning.pipeline` step 2), the drift rule on request, and any other
    field of SSAParams (``confirm``, ``jump_deg``) in ``overrides``. Raises ValueError for a bad value."""
    from .ssa import SSAParams

    return SSAParams(max_word_angle_deg=max_word_angle_deg, drift=bool(drifts)).replace(**overrides)


def motion_span(poses, num_frames: int) -> tuple[int, int]:
    """``(lo, hi)``: the frames between the calibration ``poses`` (the whole take when there is none; ``(0, 0)``
    when the whole take is a pose)."""
    keep = ~calibration_mask(poses, num_frames)
    if not keep.any():
        return 0, 0
    idx = np.flatnonzero(keep)
    return int(idx[0]), int(idx[-1]) + 1


def _analysis_frames(motion: Motion, analysis_fps: float) -> int:
    """Frames of ``motion`` resampled to ``analysis_fps`` (as :meth:`Motion.resample` makes them)."""
    return int(np.floor((motion.num_frames - 1) * analysis_fps / motion.fps + 1e-9)) + 1


def detect_take(motion: Motion, context=None, *, threshold: float = 0.5, params=None, progress: bool = False,
                poses=None) -> TakeDetection:
    """Self-similarity detection of ``motion`` with its calibration poses left out (module docstring).

    ``context``: as for :func:`mocapkit.cleaning.ssa.detect` (None, Motions, a database); ``params``: an
    :class:`~mocapkit.cleaning.ssa.SSAParams` (default :func:`take_params`, ``clean``'s); ``poses``: the
    take's calibration poses when the caller found them already (default: found here). The frames between
    the poses must be complete (no NaN); when they are fewer than one motion word, or there are none, nothing
    is analysed and :attr:`TakeDetection.skipped` says why. A bad parameter or a context of other joints
    raises :class:`~mocapkit.errors.MocapError` naming the take.
    """
    from . import ssa

    name = motion.name or "motion"
    F = motion.num_frames
    if poses is None:
        poses = calibration_poses(motion)
    poses = tuple(poses)
    lo, hi = motion_span(poses, F)
    span = (lo, hi)
    if hi == lo:
        return TakeDetection(None, poses, span, "the whole take is a calibration pose")
    part = motion[lo:hi]
    missing = part.missing().any(axis=1)
    if missing.any():
        raise MocapError(f"{name}: {int(missing.sum())} frames have missing joints; detect needs complete frames "
                         "(fill the gaps first)")
    try:
        params = take_params() if params is None else params
        N = params.source_length
        if _analysis_frames(part, params.analysis_fps) < N:
            return TakeDetection(None, poses, span,
                                 f"{hi - lo} frames ({part.duration:.2f} s) is shorter than one motion word "
                                 f"({N} frames at {params.analysis_fps:g} fps, {N / params.analysis_fps:.3f} s)")
        det = ssa.detect(part, context, threshold=threshold, params=params, progress=progress)
    except (ValueError, SkeletonError) as exc:
        raise MocapError(f"{name}: detect: {exc}") from None
    det = across_breaks(part, det)
    return TakeDetection(det.padded(lo, F) if poses else det, poses, span)


def across_breaks(part: Motion, det):
    """``det`` (a detection of ``part``, the frames analysed) with the take's breaks said and judged as such.

    The cuts of ``part`` and the jumps of its root's path (:mod:`mocapkit.cleaning.take_breaks`) are named in
    the detection's notes (so ``detect`` prints them and ``clean`` says them); at a cut, or where the root
    jumps and stays, the whole take changes, and a joint's break there confirms no digression: the breaks
    (``jumps``) within ``confirm_margin_s`` of it are cleared and the flags made again, so the frames on
    either side are not "repaired" because of it (a splice of two walks had the pelvis of the 17 frames before
    it turned round by up to 172 deg).
    """
    import dataclasses

    from . import take_breaks as tb

    events = tb.root_events(part)
    an = det.analysis  # its midpoint residuals are part's when it analysed part itself
    found = tb.cuts(part, resid=an.residuals if an is not None and an.motion is part else None)
    at = sorted({c.frame for c in found} | {e.first for e in events if e.kind == "jump"})
    lines = [str(e) for e in events] + [str(c) for c in found if not any(e.first == c.frame for e in events)]
    if not lines:
        return det
    det = dataclasses.replace(det, notes=tuple(det.notes) + tuple(lines))
    if not at:
        return det
    margin = int(np.ceil(det.params.confirm_margin_s * part.fps))
    near = tb.cut_mask(at, part.num_frames, margin)
    if not (np.asarray(det.jumps, dtype=bool) & near[:, None]).any():
        return det
    det = dataclasses.replace(det, jumps=np.asarray(det.jumps, dtype=bool) & ~near[:, None])
    return det.with_threshold(det.threshold)


def repair_take(motion: Motion, detection, context=None, *, foot_skate: bool = False, poses=None) -> Motion:
    """``motion`` with the cells ``detection`` flags replaced (:func:`mocapkit.cleaning.ssa.repair`), the
    calibration poses left alone.

    A detection of :func:`detect_take` repairs the frames it analysed only. A detection of the whole take
    (made by :func:`~mocapkit.cleaning.ssa.detect`, or a file written before calibration poses were left out)
    has its flags on the calibration frames (``poses``, found here when not given) dropped first. Foot-skate
    cleanup is off unless ``foot_skate``: with it, the hip and knee of a leg whose repaired foot is planted
    change too, cells nobody flagged. Raises :class:`~mocapkit.errors.MocapError` naming the take when the
    detection or context do not fit it.
    """
    import dataclasses

    from . import ssa

    if detection.span is None and detection.flags.any():
        calib = calibration_mask(calibration_poses(motion) if poses is None else poses, motion.num_frames)
        if (detection.flags[calib]).any():
            detection = dataclasses.replace(detection, flags=detection.flags & ~calib[:, None])
    try:
        return ssa.repair(motion, detection, context, foot_skate=foot_skate)
    except ValueError as exc:
        raise MocapError(f"{motion.name or 'motion'}: repair: {exc}") from None


def differing(a, b) -> np.ndarray:
    """(F, J) bool where two (F, J, k) arrays (rotations, translations; or (F, k) root positions: (F,)) differ in
    any component, NaN equal to NaN."""
    a, b = np.asarray(a), np.asarray(b)
    return ~np.all((a == b) | (np.isnan(a) & np.isnan(b)), axis=-1)


def changed_cells(before: Motion, after: Motion) -> np.ndarray:
    """(F, J) bool: the joint samples ``after`` changed from ``before``: a rotation, an animated translation, or
    (on the root, joint 0) the root position. NaN equal to NaN."""
    out = differing(before.rotations, after.rotations)
    out[:, 0] |= differing(before.root_positions, after.root_positions)
    if before.translations is not None and after.translations is not None:
        out |= differing(before.translations, after.translations)
    return out
