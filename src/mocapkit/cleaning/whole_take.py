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

Three more things of a whole take go the same way in every command:

- **Channels written as 0 where the capture lost data** (:mod:`mocapkit.cleaning.zeros`) are missing
  samples, as NaN is. :func:`fill_take` (``clean``'s fill step and the ``fill`` command) makes them
  missing and fills them with the NaN gaps; :func:`detect_take` (``clean``'s detect step, the ``detect`` and
  ``repair`` commands) refuses them as it refuses NaN, in one line naming the first run: analysed as
  motion, a dropout's edges were flagged and "repaired", good frames beside it included; :func:`denoise_take`
  (``clean``'s denoise step and the ``denoise`` command) leaves them as written and out of what the filter
  reads.
- **The root's teleports** (:mod:`mocapkit.cleaning.take_breaks`) are put back by :func:`repair_whole`
  (``clean``'s repair step and the ``repair`` command), after the flagged cells are repaired; their
  cells join the flags with the cause ``teleport`` (:func:`with_teleports`), so they are undone like any
  repair. Where no repair runs (``clean --steps detect``, the ``detect`` command) the same cells are flagged and
  the same line says them, left as is (:func:`review_whole`).
- **Turn-overs** (a bone turned 180 deg about itself in one frame and back, :mod:`mocapkit.cleaning.ssa.flips`)
  are found by :func:`turn_overs`: turned back by :func:`repair_whole` where that is checked right, and named,
  none turned back, where no repair runs (:func:`review_turn_overs`: ``clean --steps detect`` and the ``detect``
  command). Either way their cells join the flags with the cause ``flip`` (:func:`with_flips`) and one line names
  each, in the same words on the same frames.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MocapError, SkeletonError
from ..motion import Motion
from ..words import plural
from .calibration import calibration_mask, calibration_poses
from .denoise_guard import Guarded, guarded_take
from .measured import filled_channels_note, keep_measured, keep_measured_in_repair, kept_note, measured_axes
from .zeros import as_missing, find_zeros
from . import take_breaks as tb

__all__ = ["MAX_WORD_ANGLE_DEG", "MADE_UP_SHARE", "TakeDetection", "TakeFill", "TakeRepair", "take_params",
           "motion_span", "made_up_note", "resolve_model", "fill_take", "denoise_take", "denoise_guarded", "check_no_zeros", "detect_take", "take_cuts", "across_breaks",
           "repair_take", "repair_whole", "TurnOvers", "body_joints", "turn_overs", "review_turn_overs", "turn_overs_note", "with_flips",
           "TakeReview", "review_whole", "teleports_note",
           "with_teleports", "flagged_in_all_note", "changed_cells", "differing", "REVIEW_WHY"]

MAX_WORD_ANGLE_DEG = 8.0  # words with no neighbour this close (RMS joint angle) are not judged
#: above this share of missing joint samples, a fill is said to have made up most of the take
MADE_UP_SHARE = 0.5


@dataclass(frozen=True)
class TakeDetection:
    """What :func:`detect_take` found.

    ``detection``: the :class:`~mocapkit.cleaning.ssa.Detection` at the take's frames (its ``span`` set when
    calibration poses were left out), or None when nothing could be analysed; ``skipped``: then why, one
    line ("" otherwise); ``calibration``: the :class:`~mocapkit.cleaning.calibration.CalibrationPose` of the
    take, left alone; ``span``: ``(lo, hi)``, the frames between them; ``breaks``: the lines among the
    detection's notes that name the take's cuts and its root's jumps (:func:`across_breaks`), which a summary
    may count past the first few (a long take of many cuts names dozens); ``cuts``: the
    :class:`~mocapkit.cleaning.take_breaks.Cut` s found, at the take's frames (those where the root jumps and stays
    too with its size, ``root_cm``: their line names both), which the report lists.
    """

    detection: object
    calibration: tuple
    span: tuple
    skipped: str = ""
    breaks: tuple = ()
    cuts: tuple = ()


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


def made_up_note(missing: np.ndarray) -> str:
    """One line when most of a take was missing ((F, J) bool ``missing``), so that the fill invented most of what
    comes out (a batch user would not notice otherwise), else "". The fill has nothing to compare with there: a
    take 88 % missing came out 10.6 deg off its truth on average, a straight line between the samples 8.6."""
    share = float(np.mean(missing)) if np.size(missing) else 0.0
    if share <= MADE_UP_SHARE:
        return ""
    return (f"{100.0 * share:.0f} % of the take's joint samples were missing: the fill made up most of what it "
            "returns; look at it before use")


def resolve_model(model) -> tuple[object, str]:
    """``(model, label)`` for a model given as None (the shipped one for the take's rig, chosen by
    :func:`mocapkit.cleaning.deep.served_by`: ``(None, "shipped")``), a file or shipped name (loaded; labelled by
    its file name) or a model object (``"given"``)."""
    if model is None:
        return None, "shipped"
    if isinstance(model, (str, Path)):
        from . import deep

        return deep.load_model(model), Path(model).name
    return model, "given"


@dataclass(frozen=True)
class TakeFill:
    """What :func:`fill_take` did.

    ``motion``: the take filled (the input itself when there was nothing to fill); ``filled``: (F, J) bool, the
    cells the fill changed (NaN gaps and the runs written as 0); ``zeros``: (F, J) bool, the cells written as 0
    where the capture lost data, and ``zero_runs`` their :class:`~mocapkit.cleaning.zeros.ZeroRun` s
    (:func:`~mocapkit.cleaning.zeros.find_zeros`); ``method``: what filled (``"nothing (no gaps)"`` when nothing
    was missing); ``note``: the fallback or licence line of :func:`mocapkit.cleaning.deep.fill_or_fallback` ("" when
    none); ``warnings``: lines a person should read (most of the take made up, fills far from the line between a
    gap's ends, the channels filled in cells the file measures in part:
    :func:`~mocapkit.cleaning.measured.filled_channels_note`).
    """

    motion: Motion
    filled: np.ndarray
    zeros: np.ndarray
    zero_runs: tuple
    method: str
    note: str = ""
    warnings: tuple = ()


def fill_take(motion: Motion, ebd=None, ebf=None, *, smooth: bool = True, method: str = "auto", options=None,
              zeros=None) -> TakeFill:
    """Fill the gaps of ``motion``, the runs its channels are written as 0 where the capture lost data among them:
    ``clean``'s fill step and the ``fill`` command (module docstring).

    The runs of :func:`~mocapkit.cleaning.zeros.find_zeros` (``zeros``: its result when the caller has it) become
    missing cells (:func:`~mocapkit.cleaning.zeros.as_missing`), and every missing cell is filled by
    :func:`mocapkit.cleaning.deep.fill_or_fallback` (the EBD where it serves the take, else the cubic spline),
    the numbers a missing cell still has put back (:func:`~mocapkit.cleaning.measured.keep_measured`: a BVH cell
    with one ``nan`` channel takes the fill's value in that channel alone, and ``warnings`` names the channels so
    filled: :func:`~mocapkit.cleaning.measured.filled_channels_note`); every other sample is returned bit-identical. ``ebd``, ``ebf``: as :func:`resolve_model` takes them;
    ``smooth``, ``method``, ``options``: as for ``fill_or_fallback``. Raises :class:`~mocapkit.errors.MocapError`
    naming the take when a joint is missing in every frame (nothing to fill it from).
    """
    name = motion.name or "motion"
    cells, runs, frames = find_zeros(motion) if zeros is None else zeros
    cur = as_missing(motion, cells, frames) if runs else motion
    gaps = cur.missing()
    never = np.flatnonzero(gaps.all(axis=0))
    if len(never):
        names = ", ".join(motion.skeleton.joint_names[j] for j in never[:4])
        raise MocapError(f"{name}: joint(s) {names} are missing in every frame; nothing to fill them from")
    if not gaps.any():
        return TakeFill(motion, np.zeros_like(gaps), cells, tuple(runs), "nothing (no gaps)")
    from . import deep  # torch is imported only when there is something to fill

    ebd, label = resolve_model(ebd)
    ebf, _ = resolve_model(ebf)
    doubts: list[str] = []
    out, how, note = deep.fill_or_fallback(cur, ebd, ebf, smooth=smooth, label=label, method=method,
                                           options=options, doubts=doubts)
    out, _ = keep_measured(cur, out)  # a cell's measured numbers put back: only its missing ones filled
    filled = differing(cur.rotations, out.rotations) | (gaps & ~out.missing())
    warnings = tuple(w for w in (made_up_note(gaps), *doubts, filled_channels_note(cur, out)) if w)
    return TakeFill(out, filled, cells, tuple(runs), how, note, warnings)


def denoise_take(motion: Motion, ebf=None, *, cells: np.ndarray | None = None, options=None,
                 zeros=None, measured: bool = True) -> tuple[Motion, str, str]:
    """Denoise ``motion`` (only ``cells`` (F, J) when given) by :func:`mocapkit.cleaning.deep.denoise_or_fallback`,
    its channels written as 0 where the capture lost data left as written: ``clean``'s denoise step and the
    ``denoise`` command (module docstring). Returns ``(motion, method, note)`` as ``denoise_or_fallback``.

    The runs of :func:`~mocapkit.cleaning.zeros.find_zeros` (``zeros``: its result when the caller has it) are
    missing to the filter (the EBF reads around them, as around a gap) and come back as they were: read as motion,
    a dropout's jump into 0 and out was spread over the good frames beside it (a Bandai Namco hip zeroed for 40
    frames: its 5 frames on each side turned by up to 80 deg). A cell the denoiser moves further than the take's
    noise explains is kept as it came, and its neighbours denoised without it (:func:`~mocapkit.cleaning.denoise_guard.guarded_take`,
    said in the note). A denoised cell its BVH or AMC file gives partly ``nan`` (filled) keeps its measured channels
    where its missing ones reach the denoised rotation (:func:`~mocapkit.cleaning.measured.keep_measured_in_denoise`,
    said in the note; ``measured`` False leaves that to a caller that has the whole take of a part it denoises).
    ``ebf``: as :func:`resolve_model` takes it; ``options``: as for ``denoise_or_fallback``.
    """
    return denoise_guarded(motion, ebf, cells=cells, options=options, zeros=zeros, measured=measured).as_tuple()


def denoise_guarded(motion: Motion, ebf=None, *, cells: np.ndarray | None = None, options=None, zeros=None,
                    measured: bool = True, keep: np.ndarray | None = None) -> Guarded:
    """:func:`denoise_take`'s denoise as the :class:`~mocapkit.cleaning.denoise_guard.Guarded` that says the cells
    kept as they came (``kept`` (F, J)) apart from the denoiser's own note (a fallback, a licence) and the measured
    channels kept (:func:`~mocapkit.cleaning.denoise_guard.guarded_take`); ``keep`` (F, J) bool: cells kept as they
    came whatever the guard finds (``clean``'s denoise after its repair keeps those its first denoise kept)."""
    from . import deep  # torch: only once there is something to denoise

    ebf, label = resolve_model(ebf)
    return guarded_take(motion, cells, lambda m, c: deep.denoise_or_fallback(m, ebf, cells=c, label=label,
                                                                             options=options),
                        zeros=zeros, measured=measured, keep=keep)


def check_no_zeros(motion: Motion, runs=None, span: tuple[int, int] | None = None) -> None:
    """Raise :class:`~mocapkit.errors.MocapError` naming the take and the first run when channels of ``motion``
    (within ``span`` ``(lo, hi)``) are written as 0 where the capture lost data (``runs``: the
    :class:`~mocapkit.cleaning.zeros.ZeroRun` s when the caller found them, else found here): missing samples,
    which detection cannot judge (module docstring)."""
    if runs is None:
        runs = find_zeros(motion)[1]
    lo, hi = (0, motion.num_frames) if span is None else span
    runs = [z for z in runs if z.last >= lo and z.first < hi]
    if runs:
        more = f" and {len(runs) - 1} more such run{'s' if len(runs) > 2 else ''}" if len(runs) > 1 else ""
        raise MocapError(f"{motion.name or 'motion'}: {runs[0].what()}{more}: samples the capture lost, missing as "
                         "NaN is; detect needs complete frames (fill them first: the fill step of clean, or "
                         "`mocapkit fill`, fills them)")


def _analysis_frames(num_frames: int, fps: float, analysis_fps: float) -> int:
    """Frames of a take of ``num_frames`` at ``fps`` resampled to ``analysis_fps`` (as :meth:`Motion.resample`
    makes them)."""
    return int(np.floor((num_frames - 1) * analysis_fps / fps + 1e-9)) + 1


def detect_take(motion: Motion, context=None, *, threshold: float = 0.5, params=None, progress: bool = False,
                poses=None, zero_runs=None) -> TakeDetection:
    """Self-similarity detection of ``motion`` with its calibration poses left out (module docstring).

    ``context``: as for :func:`mocapkit.cleaning.ssa.detect` (None, Motions, a database); ``params``: an
    :class:`~mocapkit.cleaning.ssa.SSAParams` (default :func:`take_params`, ``clean``'s); ``poses``: the
    take's calibration poses when the caller found them already (default: found here). The frames between
    the poses must be complete: no NaN, and no channel written as 0 where the capture lost data
    (:func:`check_no_zeros`; ``zero_runs``: the runs when the caller found them, default: found here); when they
    are fewer than one motion word, or there are none, or the take's rate is too coarse for a word
    (:func:`~mocapkit.cleaning.ssa.texture.too_coarse`: under 12 fps), nothing is analysed and
    :attr:`TakeDetection.skipped` says why. A bad parameter or a context of other joints raises :class:`~mocapkit.errors.MocapError` naming
    the take.
    """
    from . import ssa
    from .ssa.repeats import analysed_frames

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
        n = int(missing.sum())
        raise MocapError(f"{name}: {n} frame{'s have' if n != 1 else ' has'} missing joints; detect needs complete frames "
                         "(fill the gaps first)")
    check_no_zeros(motion, zero_runs, span)
    try:
        params = take_params() if params is None else params
        N = params.source_length
        coarse = ssa.too_coarse(part.fps, params)
        if coarse:
            return TakeDetection(None, poses, span, f"{coarse}: not judged")
        kept = analysed_frames(part)  # repeated and interpolated frames are analysed once (ssa.repeats)
        if _analysis_frames(kept, part.fps, params.analysis_fps) < N:
            less = f", {kept} without its repeated and interpolated frames," if kept < hi - lo else ""
            return TakeDetection(None, poses, span,
                                 f"{hi - lo} frames ({part.duration:.2f} s){less} is shorter than one motion word "
                                 f"({N} frames at {params.analysis_fps:g} fps, {N / params.analysis_fps:.3f} s)")
        det = ssa.detect(part, context, threshold=threshold, params=params, progress=progress)
    except (ValueError, SkeletonError) as exc:
        raise MocapError(f"{name}: detect: {exc}") from None
    before = len(det.notes)
    an = det.analysis  # its midpoint residuals are part's when it analysed part itself
    found = tb.cuts(part, resid=an.residuals if an is not None and an.motion is part else None)
    events = tb.root_events(part)
    det = across_breaks(part, det, lo=lo, found=found, events=events)
    found = tb.with_root_jumps(found, events)[0]
    return TakeDetection(det.padded(lo, F) if poses else det, poses, span, breaks=tuple(det.notes[before:]),
                         cuts=tuple(dataclasses.replace(c, frame=c.frame + lo) for c in found))


def take_cuts(motion: Motion) -> list:
    """The :class:`~mocapkit.cleaning.take_breaks.Cut` s of ``motion``, at the take's frames, found as ``clean``'s
    detect step finds them but on the take as it is: between its calibration poses (:func:`motion_span`), the cells
    missing or written as 0 where the capture lost data (:func:`~mocapkit.cleaning.zeros.find_zeros`) no evidence.
    What ``mocapkit info`` names."""
    lo, hi = motion_span(calibration_poses(motion), motion.num_frames)
    if hi - lo < tb.CUT_MIN_FRAMES:
        return []
    found = tb.cuts(motion, span=(lo, hi), ignore=find_zeros(motion)[0] | motion.missing())
    return tb.with_root_jumps(found, tb.root_events(motion, (lo, hi)))[0] if found else found


def across_breaks(part: Motion, det, *, lo: int = 0, found=None, events=None):
    """``det`` (a detection of ``part``, the frames analysed: the take's frames ``lo ..``) with the take's breaks
    said and judged as such.

    The cuts of ``part`` and the jumps of its root's path (:mod:`mocapkit.cleaning.take_breaks`) are named in
    the detection's notes (so ``detect`` prints them and ``clean`` says them); at a cut, or where the root
    jumps and stays, the whole take changes, and a joint's break there confirms no digression: the breaks
    (``jumps``) within ``confirm_margin_s`` of it are cleared and the flags made again, so the frames on
    either side are not "repaired" because of it (a splice of two walks had the pelvis of the 17 frames before
    it turned round by up to 172 deg). The notes name the take's frames (``lo`` on from part's), as the repair
    step's lines do: named at part's, a teleport after a calibration T-pose was said one frame early.
    ``found``: the :class:`~mocapkit.cleaning.take_breaks.Cut` s of ``part`` when the caller has them (None: found
    here); ``events``: the :class:`~mocapkit.cleaning.take_breaks.RootEvent` s of ``part``'s root (None: found here).
    A cut where the root jumps and stays is said once, as a cut with a root jump
    (:func:`~mocapkit.cleaning.take_breaks.with_root_jumps`).
    """
    events = tb.root_events(part) if events is None else events
    if found is None:
        an = det.analysis  # its midpoint residuals are part's when it analysed part itself
        found = tb.cuts(part, resid=an.residuals if an is not None and an.motion is part else None)
    at = sorted({c.frame for c in found} | {e.first for e in events if e.kind == "jump"})
    found, rest = tb.with_root_jumps(found, events)
    said = ([dataclasses.replace(e, first=e.first + lo, last=e.last + lo) for e in rest]
            + [dataclasses.replace(c, frame=c.frame + lo) for c in found if not any(e.first == c.frame for e in rest)])
    lines = [str(x) for x in said]
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
    return repair_take_left(motion, detection, context, foot_skate=foot_skate, poses=poses)[0]


def repair_take_left(motion: Motion, detection, context=None, *, foot_skate: bool = False, poses=None):
    """``(repaired, left)``: :func:`repair_take`, and the runs the repair guard gave back as they were
    (:class:`~mocapkit.cleaning.ssa.LeftRun`, named "left: repair not better than the take")."""
    import dataclasses

    from . import ssa

    if detection.span is None and detection.flags.any():
        calib = calibration_mask(calibration_poses(motion) if poses is None else poses, motion.num_frames)
        if (detection.flags[calib]).any():
            detection = dataclasses.replace(detection, flags=detection.flags & ~calib[:, None])
    try:
        return ssa.repair_with_left(motion, detection, context, foot_skate=foot_skate)
    except ValueError as exc:
        raise MocapError(f"{motion.name or 'motion'}: repair: {exc}") from None


@dataclass(frozen=True)
class TakeRepair:
    """What :func:`repair_whole` did: ``motion``, the take repaired; ``repaired``: (F, J) bool, the cells the
    medoid words (and the foot-skate cleanup) changed; ``teleported``: (F, J) bool, the cells of the root's
    teleports put back (the root's position on joint 0, the pelvis's animated offset on its joint), none of them
    in ``repaired``; ``put_back``: one line per teleport put back
    (:class:`~mocapkit.cleaning.take_breaks.RootEvent`); ``left``: one line per run the repair guard left as it
    was ("left: repair not better than the take: ...", :class:`~mocapkit.cleaning.ssa.LeftRun`); ``turned``
    and ``turn_flags``: (F, J) bool or None, the cells of the turn-overs turned back, and those plus the cells of
    the turn-overs named and left (:func:`mocapkit.cleaning.ssa.flips.turned_back`); ``flips``: one line per
    turn-over ("flip: lfemur (with ltibia) turned 180 deg about itself, frames 78-82, ..."); ``measured``: what
    became of the repaired cells the take's file gives partly ``nan`` (their measured channels kept, or changed
    with the repair standing whole, and why: :func:`~mocapkit.cleaning.measured.kept_note`), "" for none;
    ``swapped``: (F, J) bool or None, the cells exchanged back with their left/right partner's mirrored rotation
    (:func:`~mocapkit.cleaning.ssa.swap_exchange.exchanged_cells`), on both sides of each swap, whether detection
    flagged it as one or the repair found it (a swap flagged on one side only)."""

    motion: Motion
    repaired: np.ndarray
    teleported: np.ndarray
    put_back: tuple = ()
    left: tuple = ()
    turned: np.ndarray | None = None
    turn_flags: np.ndarray | None = None
    flips: tuple = ()
    measured: str = ""
    swapped: np.ndarray | None = None

    @property
    def changed(self) -> np.ndarray:
        """(F, J) bool: every cell the repair changed."""
        out = self.repaired | self.teleported
        return out if self.turned is None else out | self.turned


def repair_whole(motion: Motion, detection, context=None, *, foot_skate: bool = False, poses=None) -> TakeRepair:
    """``clean``'s repair step and the ``repair`` command: :func:`repair_take` (a repaired cell its BVH or AMC file
    gives partly ``nan`` keeping its measured channels where its missing ones reach the repair's rotation:
    :func:`~mocapkit.cleaning.measured.keep_measured_in_repair`), then the teleports of the root's
    path between the calibration poses put back (:func:`mocapkit.cleaning.take_breaks.fix_teleports`), then the
    turn-overs turned back where that is right and named either way (:func:`turn_overs`).

    The frames looked at are the detection's (``detection.span``) when it has them, else those between the
    take's calibration ``poses`` (found here when not given). Raises as :func:`repair_take`.
    """
    done, span, leaves, _ = _repaired(motion, detection, context, foot_skate=foot_skate, poses=poses)
    return turned_over(done, span, leaves)


def _repaired(motion: Motion, detection, context=None, *, foot_skate: bool = False, poses=None):
    """``(TakeRepair, span, leaves, put_back)``: :func:`repair_whole` before the turn-overs, the frames ``(lo, hi)``
    it looked at, the joints self-similarity did not analyse (whose constant half turns :func:`turn_overs` looks
    for), and the teleports put back (:class:`~mocapkit.cleaning.take_breaks.RootEvent`, ``fixed``)."""
    F = motion.num_frames
    if detection.span is None and poses is None:
        poses = calibration_poses(motion)
    span = tuple(detection.span) if detection.span is not None else motion_span(poses, F)
    fixed, left = repair_take_left(motion, detection, context, foot_skate=foot_skate, poses=poses)
    left = tuple(str(r) for r in left)
    # a filled cell's measured channels kept where its missing ones explain the repair (measured module docstring)
    fixed, kept, stood = keep_measured_in_repair(motion, fixed, changed_cells(motion, fixed))
    moved = changed_cells(motion, fixed)
    events = [e for e in tb.root_events(fixed, span) if e.kind == "teleport"]
    # a measured axis of a root the file gives partly nan put on the path only on its own evidence (measured_axes)
    back, done = tb.fix_teleports(fixed, events, measured_axes(motion)) if events else (fixed, ())
    teleported = changed_cells(motion, back) & ~moved
    leaves = [name for name, _ in getattr(detection, "left_out", ()) or ()]
    put_back = tuple(e for e in done if e.fixed)
    measured = kept_note(kept, motion.skeleton.joint_names, "repair", stood)
    swapped = None
    if moved.any():
        from ..motion import mirror_pairs
        from .ssa.cues import mirrored_rotations
        from .ssa.swap_exchange import exchanged_cells

        swapped = exchanged_cells(motion.rotations, back.rotations, mirrored_rotations(motion),
                                  mirror_pairs(motion.skeleton.joint_names))
    return (TakeRepair(back, moved, teleported, tuple(str(e) for e in put_back), left, measured=measured,
                       swapped=swapped), span, leaves, put_back)


#: the reason a review gives for leaving a turn-over the repair step turns back (``clean --steps detect``, ``detect``)
REVIEW_WHY = "repair would turn it back exactly"


@dataclass(frozen=True)
class TurnOvers:
    """The turn-overs of a take (:func:`turn_overs`): ``motion``, the take with those turned back (the take itself
    where none was, and in a review); ``turned`` and ``flagged``: (F, J) bool, the cells turned back, and those
    plus the cells of the turn-overs named and left; ``lines``: one per turn-over, in frame order, as ``clean``'s
    console, record and report say it ("flip: lfemur (with ltibia) turned 180 deg about itself, frames 78-82, ...")."""

    motion: Motion
    turned: np.ndarray
    flagged: np.ndarray
    lines: tuple = ()


def body_joints(skeleton) -> list[int]:
    """The pelvis (:func:`mocapkit.rigs.pelvis_index`) and every joint below it: the body, without what hangs
    from a root above the pelvis beside it (Unreal's ``ik_foot_root``/``ik_hand_root`` chains, props).

    Those helpers copy a body joint's world rotation (``ik_foot_l`` the foot's) or hold a target: a half turn
    of one is the body joint's, which the turn-over rules judge on the body itself, not a glitch of the helper's
    to turn back (``turn_overs`` looks for none there). On a rig whose root is the pelvis (Acclaim, the CMU BVH)
    every joint.
    """
    from ..rigs import pelvis_index

    parents = np.asarray(skeleton.parents)
    top = pelvis_index(skeleton)
    inside = np.zeros(len(parents), dtype=bool)
    inside[top] = True
    for j in range(top + 1, len(parents)):  # parents come before their children
        inside[j] = parents[j] >= 0 and inside[parents[j]]
    return np.flatnonzero(inside).tolist()


def turn_overs(motion: Motion, span: tuple[int, int], leaves=(), *, changed=None, review: bool = False) -> TurnOvers:
    """The turn-overs of ``motion`` within frames ``span`` (``lo .. hi - 1``), turned back where that is right and
    named either way (:func:`mocapkit.cleaning.ssa.flips.turned_back`; ``leaves``: the joints self-similarity did
    not analyse, whose constant half turns are looked for too): the one rule by which ``clean``'s repair step, the
    ``repair`` command and the review (:func:`review_turn_overs`) find and name them.

    ``changed``: (F, J) bool, the cells a repair changed before; a turn-over touching them is named and left.
    ``review``: nothing is turned back; a turn-over that would be is named and left with the reason
    :data:`REVIEW_WHY`, one that would be left keeps its own reason.
    """
    from .ssa.flips import turned_back

    lo, hi = int(span[0]), int(span[1])
    names = list(motion.skeleton.joint_names)
    full = np.zeros((motion.num_frames, len(names)), dtype=bool)
    full_flags = np.zeros_like(full)
    body = set(body_joints(motion.skeleton))
    part, turned, flagged, flips = turned_back(motion[lo:hi], [n for n in leaves if n in names and
                                                               names.index(n) in body])
    if not flips:
        return TurnOvers(motion, full, full_flags)
    rot = np.array(motion.rotations)
    full_flags[lo:hi] = flagged
    lines = []
    for f in flips:
        a, b = f.first + lo, f.last + lo
        cells = turned[f.first : f.last + 1]
        if f.fixed and changed is not None and (changed[a : b + 1] & cells).any():
            f = dataclasses.replace(f, fixed=False, why="the repair changed its cells")
        elif f.fixed and review:
            # a leaf turned back by measured offsets, not a half turn exactly, is said so (ssa.flips.Flip.measured)
            f = dataclasses.replace(f, fixed=False, why=f"repair would turn it back {f.measured}" if f.measured
                                    else REVIEW_WHY)
        elif f.fixed:
            full[a : b + 1] |= cells
            rot[a : b + 1] = np.where(cells[..., None], part.rotations[f.first : f.last + 1], rot[a : b + 1])
        lines.append(f"flip: {dataclasses.replace(f, first=a, last=b)}")
    out = dataclasses.replace(motion, rotations=rot) if full.any() else motion
    return TurnOvers(out, full, full_flags, tuple(lines))


def review_turn_overs(motion: Motion, detection, context=None, *, poses=None) -> TurnOvers:
    """What the repair step would say of the turn-overs of ``motion`` (:func:`repair_whole` on ``detection``, its
    ``context`` and calibration ``poses``, foot-skate cleanup off as in ``clean``), said and flagged with none
    turned back: the turn-overs of ``clean --steps detect`` and the ``detect`` command.

    The repair is made in memory to find them and given up: a turn-over whose cells self-similarity flagged is
    replaced from motion words first, and then is no turn-over left for the repair step to name, or is named and
    left; looked for on the take as it is, the review named some the cleaning never did (an injected 180 deg
    flip of a CMU walk's humerus, flagged and repaired from motion words). So the review's lines and ``flagged``
    cells are those of the repair step, on the same frames and in the same words, except that one the repair step
    turns back is left with the reason :data:`REVIEW_WHY`; ``motion`` is the input itself, ``turned`` all False.
    :func:`review_whole` says the root's teleports with them.
    """
    return review_whole(motion, detection, context, poses=poses).turn_overs


@dataclass(frozen=True)
class TakeReview:
    """What the repair step would do to a take beyond its flagged cells, said and flagged with none of it done
    (:func:`review_whole`): ``teleported``: (F, J) bool, the cells of the root's teleports it would put back
    (:attr:`TakeRepair.teleported`); ``teleports``: one line per teleport, the repair step's line with "left as is
    (repair would put it back on the path between the frames around them)" for its outcome; ``turn_overs``: the
    :class:`TurnOvers` of :func:`review_turn_overs`."""

    teleported: np.ndarray
    teleports: tuple
    turn_overs: TurnOvers

    @property
    def lines(self) -> tuple:
        """The teleports' lines, then the turn-overs', in the order the repair step says them."""
        return tuple(self.teleports) + tuple(self.turn_overs.lines)


def review_whole(motion: Motion, detection, context=None, *, poses=None) -> TakeReview:
    """The review of ``clean --steps detect`` and the ``detect`` command: what :func:`repair_whole` (on
    ``detection``, its ``context`` and calibration ``poses``, foot-skate cleanup off as in ``clean``) would do to
    the root's teleports and the turn-overs, said and flagged, none of it done; the take is not changed.

    The repair is made in memory and given up. Its teleports (the root a jump away and back within 0.5 s,
    :mod:`mocapkit.cleaning.take_breaks`) come back on the same cells and frames in the repair step's words,
    left; its turn-overs as :func:`review_turn_overs` says. Without this, a review flagged neither and said a
    teleport only as detection's finding, nothing of what the cleaning would do to it.
    """
    done, span, leaves, put_back = _repaired(motion, detection, context, poses=poses)
    found = turn_overs(done.motion, span, leaves, changed=done.repaired | done.teleported, review=True)
    teleports = tuple(str(dataclasses.replace(e, fixed=False, review=True)) for e in put_back)
    return TakeReview(done.teleported, teleports, dataclasses.replace(found, motion=motion))


def teleports_note(lines) -> str:
    """``"1 teleport (0 put back)"``: the count a review's record says of the teleport ``lines``
    (:attr:`TakeReview.teleports`); "" for none."""
    if not lines:
        return ""
    return f"{len(lines)} teleport{'' if len(lines) == 1 else 's'} (0 put back)"


def turn_overs_note(lines) -> str:
    """``"2 turn-overs (1 turned back)"``: the count a step's record says of the turn-over ``lines``
    (:attr:`TurnOvers.lines`); "" for none."""
    if not lines:
        return ""
    turned = sum(": turned back " in line for line in lines)
    return f"{len(lines)} turn-over{'' if len(lines) == 1 else 's'} ({turned} turned back)"


def turned_over(done: TakeRepair, span: tuple[int, int], leaves=()) -> TakeRepair:
    """``done`` with the turn-overs of its take within frames ``span`` (``lo .. hi - 1``) turned back where that is
    right and named either way (:func:`turn_overs`; ``leaves``: the joints self-similarity did not analyse, whose
    constant half turns are looked for too). A turn-over whose cells the repair changed before is named and left."""
    found = turn_overs(done.motion, span, leaves, changed=done.repaired | done.teleported)
    if not found.lines:
        return done
    return dataclasses.replace(done, motion=found.motion, turned=found.turned, turn_flags=found.flagged,
                               flips=found.lines)


def with_flips(flags: np.ndarray, causes: np.ndarray | None, turn_flags: np.ndarray | None):
    """``(flags, causes)`` (F, J) with the cells of a take's turn-overs (``turn_flags``: :attr:`TakeRepair.turn_flags`,
    :attr:`TurnOvers.flagged`) flagged, cause ``flip`` (:data:`mocapkit.cleaning.ssa.cues.CAUSES`), so that a record
    lists them and a person can reject a turn-back; the inputs as they are when there is none."""
    if turn_flags is None or not turn_flags.any():
        return flags, causes
    from .ssa.cues import CAUSE_DTYPE, CAUSES

    causes = np.zeros(flags.shape, dtype=CAUSE_DTYPE) if causes is None else np.array(causes, dtype=CAUSE_DTYPE)
    causes[turn_flags] |= CAUSE_DTYPE(1 << [k for k, _ in CAUSES].index("flip"))
    return flags | turn_flags, causes


def with_swaps(flags: np.ndarray, causes: np.ndarray | None, swapped: np.ndarray | None):
    """``(flags, causes)`` (F, J) with the cells a repair exchanged back with their left/right partner
    (``swapped``, :attr:`TakeRepair.swapped`) flagged, cause ``swap`` (:data:`mocapkit.cleaning.ssa.cues.CAUSES`),
    so that a record ties the two sides of each swap (:mod:`mocapkit.cleaning.ties`), the frames and the side
    detection's flags missed included; the inputs as they are when there is none."""
    if swapped is None or not swapped.any():
        return flags, causes
    from .ssa.cues import CAUSE_DTYPE, CAUSES

    causes = np.zeros(flags.shape, dtype=CAUSE_DTYPE) if causes is None else np.array(causes, dtype=CAUSE_DTYPE)
    causes[swapped] |= CAUSE_DTYPE(1 << [k for k, _ in CAUSES].index("swap"))
    return flags | swapped, causes


def with_teleports(flags: np.ndarray, causes: np.ndarray | None, teleported: np.ndarray):
    """``(flags, causes)`` (F, J) with the cells of the teleports put back (``teleported``, :class:`TakeRepair`)
    flagged, cause ``teleport`` (:data:`mocapkit.cleaning.ssa.cues.CAUSES`), so that a record lists them as changes
    a person can reject; the inputs as they are when there is none."""
    if not teleported.any():
        return flags, causes
    from .ssa.cues import CAUSE_DTYPE, CAUSES

    causes = np.zeros(flags.shape, dtype=CAUSE_DTYPE) if causes is None else np.array(causes, dtype=CAUSE_DTYPE)
    causes[teleported] |= CAUSE_DTYPE(1 << [k for k, _ in CAUSES].index("teleport"))
    return flags | teleported, causes


def flagged_in_all_note(before: np.ndarray, after: np.ndarray, teleported=None, turned=None, swapped=None) -> str:
    """``"5 flagged segments in all with the turn-overs' cells (4 before)"``: what a step's record says when it
    flags cells (:func:`with_teleports`, :func:`with_flips`) beyond those detection flagged, so that the counts
    of the record agree with the flags the report lists (:func:`mocapkit.cleaning.decisions.flag_segments`, one
    run of frames of one joint each); "" when the step flagged nothing more.

    ``before``, ``after``: (F, J) bool flags before and after the step; ``teleported``, ``turned``: (F, J) bool
    cells of its teleports and turn-overs, ``swapped`` of the swaps it exchanged back (:func:`with_swaps`) (None:
    none), which name what it flagged. A turn-over touching a flag of
    detection lengthens that flag instead of adding one, so the count in all is said, not the difference.
    """
    from .ik import contact_segments

    before, after = np.asarray(before, dtype=bool), np.asarray(after, dtype=bool)
    if not (after & ~before).any():
        return ""

    def runs(flags: np.ndarray) -> int:
        return sum(len(contact_segments(flags[:, j])) for j in np.flatnonzero(flags.any(axis=0)))

    kinds = [what for what, cells in (("teleports", teleported), ("swaps", swapped), ("turn-overs", turned))
             if cells is not None and (np.asarray(cells, dtype=bool) & ~before).any()]
    whose = f" with the {' and '.join(kinds)}' cells" if kinds else ""
    return f"{plural(runs(after), 'flagged segment')} in all{whose} ({runs(before)} before)"


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
