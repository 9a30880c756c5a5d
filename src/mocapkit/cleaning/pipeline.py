"""One call to clean a take: fill gaps, detect and repair erroneous joints, denoise only what is noisy.

:func:`clean` chains the cleaners of :mod:`mocapkit.cleaning` in a fixed order,
whatever order the steps are named in (denoise also runs once before detect:
step 4):

1. **fill** — the missing (NaN) joints. On a rig the networks serve
   (:func:`mocapkit.cleaning.deep.served_by`: the Acclaim ASF/AMC rig of CMU
   and HDM05 they were trained on, and its CMU BVH spellings through a joint
   map) the EBD model fills the gap entries (its gap prior by default); on any other
   rig the cubic interpolating spline of :mod:`mocapkit.cleaning.gapfill`
   does, with a note saying why (:func:`mocapkit.cleaning.deep.fill_or_fallback`,
   the rule ``mocapkit fill`` applies too). A context (clips or a database) is not used to fill gaps: it
   feeds detection and repair. Fill comes first because self-similarity
   analysis needs every frame.
2. **detect** — erroneous joints by self-similarity
   (:func:`mocapkit.cleaning.ssa.detect`, Aristidou et al. 2018) on the filled
   take with its noisy cells denoised (step 4): against the clip itself (``context=None``), related clips (a list of
   Motions with the same joints) or a :class:`~mocapkit.database.MotionDatabase`.
   A word whose nearest neighbour differs from it by more than 8 degrees
   (RMS over the group's joints, ``max_word_angle_deg``) is not judged: the
   context holds nothing like it, and a repair from unlike motion does more
   harm than the error: on a take with no context (a single throw, a fall
   to the floor) judging every word would "repair" whole limbs.
3. **repair** — only the flagged cells (:func:`mocapkit.cleaning.ssa.repair`).
   Foot-skate cleanup is off by default (``foot_skate=False``): it would also
   move the hip and knee of a leg whose foot is planted, cells nobody flagged.
   Detect and repair run through :func:`mocapkit.cleaning.whole_take.detect_take`
   and :func:`~mocapkit.cleaning.whole_take.repair_whole` (the flagged cells,
   then the root's teleports put back), as the ``detect`` and ``repair``
   commands do: their flags and changes are clean's.
4. **denoise** — only where the take is noisy. The noisy cells of the filled
   take are denoised before detect, which judges that take: self-similarity
   reads the jitter of a fast limb as breaks and digressions, and repairs it
   from motion words far from the motion (Mall et al.'s angular noise, 0.3, on
   HDM05 grabHighR: worst cell 40.7 deg off the clean take, 72.1 after a repair
   of the take judged noisy, 15.7 judged denoised). Repair works on the take as
   filled; where it changed cells, the same noisy cells are denoised again from
   the repaired take. A take with no noisy cell is detected as it is. Tests on each
   joint's own track (see :func:`noise_level` and :func:`noise_direction`):
   the *level*, the rotation left over after a cubic Savitzky-Golay fit over
   0.06 s (at least 7 frames), i.e. the part of the motion no smooth curve
   explains, as a median in degrees over a sliding 0.5 s window, must exceed
   ``noise_deg`` (1.0 deg by default) over a run of at least 0.4 s
   (``NOISE_MIN_RUN_S``); and the residual must look like noise rather than
   motion: over the run, the frame-to-frame rotation steps must turn back on
   each other (the median cosine between consecutive steps below
   ``NOISE_REVERSAL``, -0.2). Independent per-frame errors (the Gaussian
   noise on each channel of Mall et al.'s noise model, :mod:`mocapkit.corrupt`)
   give a cosine near -0.5 (the steps of white noise are anti-correlated),
   while real motion, however fast and however coarsely sampled, keeps its
   direction from one frame to the next. The level alone calls fast clean
   motion at 30 fps noisy (a cubic over 7 frames spans 0.23 s there, and a
   foot strike or a dance hit leaves a residual of several degrees); the
   direction test keeps such motion; and the run's median frame-to-frame step
   must reach its median level (:func:`noisy_cells`: a toe flicking between
   still frames turns back too). Under 117 fps (where the fit's 7 frames
   span more than 0.06 s) a run on a hand or toe joint counts only where the
   rest of the body is noisy too (:mod:`mocapkit.cleaning.noise_scope`:
   CMU's toes and hands wobble in the files, and at 30 fps that wobble
   reverses frame to frame like noise). Tuned on Bandai Namco dataset-1 and HDM05 actors other than mm
   (``benchmarks/clean_untouched.py``), checked on the rest. Noisy cells take
   the EBF's output (:func:`mocapkit.cleaning.deep.denoise`); on a rig the
   EBF does not serve, a quadratic Savitzky-Golay filter over 0.1 s on those
   cells, with a note (:func:`mocapkit.cleaning.deep.denoise_or_fallback`, as
   ``mocapkit denoise``).

**Zeros and stutters.** Before fill, channels the take writes as exactly 0
where the capture lost data (a joint, one of its channels, or a whole frame,
between frames that do not read 0; :mod:`mocapkit.cleaning.zeros`) become
missing cells, which fill fills (:func:`mocapkit.cleaning.whole_take.fill_take`,
as ``mocapkit fill``). Without the fill step they are named and kept, and
detect refuses them as it refuses NaN gaps (missing samples it cannot
judge; :func:`~mocapkit.cleaning.whole_take.check_no_zeros`); frames that repeat the one before bit for bit while the take moves
(:mod:`mocapkit.cleaning.stutters`) are named and left. Both are named in the
summary.

**Calibration poses.** T-pose and A-pose frames opening or closing the take
(the CMU BVH converter's frame 0, a standing calibration pose held before the
motion) and their transition into the motion are found after fill
(:func:`mocapkit.cleaning.calibration.calibration_poses`, by joint positions,
any humanoid rig) and left out of detect, repair and denoise: those run on the
frames between, so the poses are neither flagged, repaired nor denoised, and
the jump from a pose into the motion is no evidence for flags next to it. The
summary names them ("frames 0-1: calibration T-pose, left alone").

Every cell that is neither missing, flagged nor noisy is returned
bit-identical to the input (the root trajectory too, unless it had gaps). The
result records which cells each step changed (``filled``, ``repaired``,
``denoised``, all (F, J) bool), the detection, and per step its time, the
number of cells changed and the method used and why: a
:class:`~mocapkit.cleaning.clean_record.CleanResult`, saved as the ``.clean.npz``
beside the output. The record lives in :mod:`mocapkit.cleaning.clean_record`;
its names (``CleanResult``, ``StepRecord``, ``clean_path``, ``capped_lines``)
are importable from here too.

Edge cases (documented fallbacks, never a crash):

- a clip shorter than one motion word (15 frames at the 24 fps analysis rate,
  0.625 s) is not analysed: detect and repair are skipped with a note;
- a clip under 12 fps (half the analysis rate) is too coarse for a motion word
  (:func:`mocapkit.cleaning.ssa.texture.too_coarse`): most of each word's frames
  would be interpolation, so it is not analysed either, with a note;
- a clip with fewer frames than the noise criterion's fit (7) is not denoised,
  with a note;
- a clip under 24 fps is not denoised either, with a note: its rate cannot hold
  capture noise apart from motion (:mod:`mocapkit.cleaning.noise_rate`);
- a single frame, a take missing in every frame, or a joint never observed
  that a step needs raise :class:`~mocapkit.errors.MocapError` with a message
  naming the take and the problem;
- missing data (NaN, or channels written as 0 where the capture lost data)
  with ``fill`` not among the steps raises when detect needs complete frames.

Examples
--------
>>> import mocapkit
>>> from mocapkit import corrupt
>>> from mocapkit.cleaning.pipeline import clean
>>> m = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
>>> bad, mask, _ = corrupt.real_errors(m, n_errors=2, seed=3)
>>> res = clean(bad)
>>> [s.name for s in res.steps]
['fill', 'detect', 'repair', 'denoise']
>>> import numpy as np
>>> untouched = ~(res.filled | res.repaired | res.denoised)
>>> bool(np.array_equal(res.motion.rotations[untouched], bad.rotations[untouched]))
True
"""

from __future__ import annotations

import dataclasses
import os
import time
from typing import Mapping, Sequence

import numpy as np

from .. import rotations as R
from ..errors import MocapError
from ..motion import Motion
from ..side_labels import exchanged_sides
from ..words import plural
from .calibration import calibration_poses
# the record of a cleaning (CleanResult, StepRecord, the .clean.npz), its own module: importable from here as ever
from .clean_record import (FORMAT, MAX_LINES, CleanResult, StepRecord, capped_lines, clean_path,
                           record_kind_hint)
from .denoise_guard import kept_cells_line
from .inbetweens import interpolated_note
from .measured import keep_measured_in_denoise, kept_note
from .noise_rate import noise_too_coarse
from .noise_scope import with_body_noise
from .stutters import find_stutters, stutter_frames
from .whole_take import (MAX_WORD_ANGLE_DEG, denoise_guarded, detect_take, differing, fill_take, flagged_in_all_note,
                         motion_span, repair_whole, review_whole, take_params, teleports_note, turn_overs_note,
                         with_flips, with_swaps, with_teleports)
from .zeros import find_zeros

__all__ = ["STEPS", "CleanResult", "StepRecord", "clean", "capped_lines", "noise_level", "noise_direction", "noisy_cells", "clean_path", "parse_steps",
           "check_noise_deg", "check_threshold", "check_models"]

STEPS = ("fill", "detect", "repair", "denoise")
NOISE_FIT_S = 0.06  # cubic Savitzky-Golay fit whose residual is "noise"
NOISE_FIT_MIN = 7  # frames
NOISE_WINDOW_S = 0.5  # median window of the residual
NOISE_DEG = 1.0  # default threshold
NOISE_REVERSAL = -0.2  # median cosine of consecutive steps over a run below which its residual is noise
NOISE_MIN_RUN_S = 0.4  # shorter runs above the level are local events (a toe flick), not sustained noise
NOISE_STEP_RATIO = 1.0  # median frame-to-frame step over a run, in units of its median level, that noise reaches


# -- the noise criterion ---------------------------------------------------------------------


def noise_level(motion: Motion, fit_s: float = NOISE_FIT_S, window_s: float = NOISE_WINDOW_S) -> np.ndarray:
    """(F, J) local high-frequency rotation level in degrees: what a short cubic fit does not explain.

    Each joint's quaternion track is made hemisphere-continuous and fitted by a
    cubic Savitzky-Golay filter over ``fit_s`` seconds (at least 7 frames); the
    geodesic angle between the track and the fit is the residual, and the level
    is its **median** over a centred window of ``window_s`` seconds. A cubic
    follows any smooth motion over 0.06 s closely, so the level of clean
    capture stays well under a degree while frame-to-frame jitter shows fully.
    The median, unlike an RMS, is high only where more than half the window is
    jittery: a noisy stretch does not spill a quarter of a second into the
    clean frames around it, and the few frames of residual an isolated jump (a
    spike, the onset of a flip) leaves are not called noise. Missing cells are
    NaN; a clip shorter than the fit gives NaN everywhere.
    """
    return _level(motion, *_continuous_tracks(motion), fit_s, window_s)


def _continuous_tracks(motion: Motion) -> tuple[np.ndarray, np.ndarray]:
    """``(q (F, J, 4), miss (F, J))``: hemisphere-continuous tracks, missing cells as the identity."""
    q = np.array(motion.rotations)
    miss = ~np.all(np.isfinite(q), axis=-1)
    q[miss] = R.identity()
    return R.quaternion_continuity(q, axis=0), miss


def _level(motion: Motion, q: np.ndarray, miss: np.ndarray, fit_s: float, window_s: float) -> np.ndarray:
    """:func:`noise_level` from the tracks of :func:`_continuous_tracks`."""
    from scipy.ndimage import median_filter
    from scipy.signal import savgol_filter

    F, J = motion.num_frames, motion.num_joints
    w = max(NOISE_FIT_MIN, int(round(fit_s * motion.fps)) | 1)
    out = np.full((F, J), np.nan)
    if F < w:
        return out
    fit = savgol_filter(q, w, 3, axis=0, mode="interp")
    fit /= np.maximum(np.linalg.norm(fit, axis=-1, keepdims=True), 1e-12)
    # the angle between unit quaternions from their chord, stable near 0 (unlike arccos of the dot product)
    chord = np.clip(np.linalg.norm(q - fit, axis=-1) / 2.0, 0.0, 1.0)
    res = np.degrees(4.0 * np.arcsin(chord))  # |q - q'| = 2 sin(a / 2) for the 4-D angle a; rotation angle 2a
    res[miss] = 0.0
    L = max(3, int(round(window_s * motion.fps)) | 1)
    level = np.empty_like(res)
    for j in range(J):  # scipy's 1-D running median is much faster than its (L, 1) footprint; same values
        level[:, j] = median_filter(res[:, j], size=L, mode="nearest")
    level[miss] = np.nan
    return level


def noise_direction(motion: Motion) -> np.ndarray:
    """(F, J) cosine between the rotation steps into and out of each frame: +1 keeps turning, -1 turns back.

    The step into frame t is the difference of the hemisphere-continuous unit
    quaternions of frames t and t-1 (for the small steps of a track, the
    rotation's direction and size). White noise added to a track gives
    anti-correlated steps (each error enters two steps with opposite signs: an
    expected cosine of -0.5), while captured motion at 30 or 120 fps keeps its
    direction over consecutive frames (cosines near +1) except at the few
    frames where it reverses. The first and last frames take their
    neighbour's value; a joint that does not move (zero steps) gives 0;
    missing cells are NaN; a clip under 3 frames gives NaN everywhere.
    """
    return _direction(*_continuous_tracks(motion))


def _direction(q: np.ndarray, miss: np.ndarray) -> np.ndarray:
    """:func:`noise_direction` from the tracks of :func:`_continuous_tracks`."""
    F, J = miss.shape
    if F < 3:
        return np.full((F, J), np.nan)
    d = np.diff(q, axis=0)  # (F-1, J, 4)
    n = np.linalg.norm(d, axis=-1)
    cos = np.sum(d[1:] * d[:-1], axis=-1) / np.maximum(n[1:] * n[:-1], 1e-12)  # at frames 1 .. F-2
    cos = np.concatenate([cos[:1], cos, cos[-1:]], axis=0)
    cos[miss] = np.nan
    return cos


def noisy_cells(motion: Motion, noise_deg: float = NOISE_DEG, filled: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(noisy (F, J) bool, level (F, J))``: cells of joints with rotation channels that are noisy.

    Per joint, each run of frames whose :func:`noise_level` exceeds
    ``noise_deg`` is noisy as a whole when it lasts at least
    ``NOISE_MIN_RUN_S`` (0.4 s) and the median over the run of its
    :func:`noise_direction` is below ``NOISE_REVERSAL`` (the residual is
    jitter, not fast motion; module docstring, step 4), and left alone
    otherwise. Judging the run, not a window around each frame, keeps the
    edges of a noisy stretch (where a window holds clean frames too) with it.
    The level is a median over 0.5 s, so sustained noise gives runs about
    that long; a shorter run is a local event whose residual the cubic fit
    spread over a few frames (a toe flicking down and back at 30 fps, a
    foot strike), which turns back too but is motion. Third, noise moves
    the joint at every frame: the median frame-to-frame rotation step over
    the run must reach ``NOISE_STEP_RATIO`` (1.0) times the run's median
    level (white noise makes steps about twice its level, at 30 and 120
    fps). A joint that flicks and is still between flicks (a toe pushing off
    in every stride of a dash at 30 fps, two or three frames each) has a
    high level from the flicks, and its steps turn back, but between the
    flicks it hardly moves: the median step is a third of the level or less.
    ``filled`` (F, J) bool, optional: cells a gap filler made up (smooth by
    construction, so no evidence either way), left out of the medians.
    Last, where the take's rate is too low for the fit to span only
    ``NOISE_FIT_S`` (under 117 fps its ``NOISE_FIT_MIN`` frames span more,
    0.23 s at 30 fps, and the residual takes in the joint's own motion up to
    a few Hz), a run on a hand or toe joint is noisy only where a joint of
    the rest of the body is noisy at one of its frames
    (:func:`mocapkit.cleaning.noise_scope.with_body_noise`): there the
    extremities' own wobble (CMU's toes and hands) passes every test of one
    track, and only the company it keeps tells it from sensor or solver
    noise. At 120 fps and above nothing changes.
    Under :data:`~mocapkit.cleaning.noise_rate.NOISE_MIN_FPS` (24 fps) no cell
    is noisy: the rate cannot hold jitter apart from motion
    (:func:`mocapkit.cleaning.noise_rate.noise_too_coarse`).
    """
    from .ik import contact_segments

    q, miss = _continuous_tracks(motion)  # once for the level and the direction
    level = _level(motion, q, miss, NOISE_FIT_S, NOISE_WINDOW_S)
    sk = motion.skeleton
    has_dofs = np.array([j > 0 and bool(sk.rotation_order(j)) for j in range(sk.num_joints)])
    high = (np.nan_to_num(level) > noise_deg) & has_dofs[None, :]
    noisy = np.zeros_like(high)
    if noise_too_coarse(motion.fps):
        return noisy, level
    min_run = int(np.ceil(NOISE_MIN_RUN_S * motion.fps))
    if high.any():
        cos = _direction(q, miss)
        rot = np.asarray(motion.rotations, dtype=np.float64)
        step = np.zeros(high.shape)
        step[1:] = np.degrees(R.geodesic_angle(rot[1:], rot[:-1]))  # into each frame (NaN next to missing cells)
        step[0] = step[1]
        for j in np.flatnonzero(high.any(axis=0)):
            seen = np.ones(len(cos), dtype=bool) if filled is None else ~np.asarray(filled, dtype=bool)[:, j]
            for a, b in contact_segments(high[:, j]):
                if b - a < min_run:
                    continue
                ok = seen[a:b]  # missing cells are never high
                c, s, lv = cos[a:b, j][ok], step[a:b, j][ok], level[a:b, j][ok]
                if (len(c) and np.median(c) < NOISE_REVERSAL
                        and np.nanmedian(s) >= NOISE_STEP_RATIO * np.median(lv)):
                    noisy[a:b, j] = True
    if noise_fit_frames(motion.fps) > (int(round(NOISE_FIT_S * motion.fps)) | 1):
        noisy = with_body_noise(noisy, sk)  # under 117 fps the fit's 7 frames span more than NOISE_FIT_S
    return noisy, level


# -- the pipeline ----------------------------------------------------------------------------


def parse_steps(steps) -> tuple[str, ...]:
    """``steps`` (a comma-separated string or a list of step names) as a tuple in :data:`STEPS` order; ValueError
    naming an unknown step or an empty request, TypeError for something that is neither."""
    if isinstance(steps, str):
        steps = [s.strip() for s in steps.split(",") if s.strip()]
    try:
        steps = list(steps)
    except TypeError:
        raise TypeError(f"steps must be a comma-separated string or a list of step names, got "
                        f"{type(steps).__name__}") from None
    bad = [s for s in steps if s not in STEPS]
    if not steps:
        raise ValueError(f"no step given; steps are {', '.join(STEPS)} (comma-separated, or a list)")
    if bad:
        raise ValueError(f"unknown step(s) {', '.join(map(str, bad))}; steps are {', '.join(STEPS)}")
    if "repair" in steps and "detect" not in steps:
        raise ValueError("the repair step needs the detect step (it replaces what detect flags)")
    return tuple(s for s in STEPS if s in steps)


def check_models(models) -> dict:
    """``models`` (``{"ebf": ..., "ebd": ...}``, None: the shipped ones) checked before any work, as the CLI checks
    ``--ebf`` / ``--ebd``: each file (or shipped model's name) read as a model of its key's kind, each model given
    of that kind. Returns the dict with files as given (they are read again where a step needs them).

    Raises TypeError for something that is no dict (a list of files) or a value that is no model or path,
    :class:`~mocapkit.errors.MocapError` for another key, and :class:`~mocapkit.errors.MocapFormatError`
    naming a missing, malformed or other-kind model file.
    """
    if models is None:
        return {}
    if not isinstance(models, Mapping):
        raise TypeError(f"models must be a dict {{'ebf': ..., 'ebd': ...}} of model files or models, got "
                        f"{type(models).__name__}")
    models = dict(models)
    bad = [k for k in models if k not in ("ebd", "ebf")]
    if bad:
        raise MocapError(f"models: keys are 'ebd' and 'ebf', got {', '.join(map(repr, bad))}")
    if not models:
        return models
    from . import deep

    for kind, m in models.items():
        if isinstance(m, (str, os.PathLike)):
            deep.load_model(m, kind)  # a missing, malformed or other-kind file: one line naming it
        elif not isinstance(m, deep.DeepModel):
            raise TypeError(f"models[{kind!r}] must be a model file or a loaded model, got {type(m).__name__}")
        elif m.kind != kind:
            raise MocapError(f"models[{kind!r}] is an {m.kind.upper()} model, but this needs an {kind.upper()}")
    return models


def _check(motion: Motion) -> None:
    if not isinstance(motion, Motion):
        raise TypeError(f"clean needs a mocapkit Motion, got {type(motion).__name__}")
    name = motion.name or "motion"
    if motion.num_frames < 2:
        raise MocapError(f"{name}: {motion.num_frames} frame(s); cleaning compares frames over time and needs at least 2")
    if motion.missing().all():
        raise MocapError(f"{name}: every joint is missing (NaN) in every frame; nothing to clean")


def _denoise(cur: Motion, lo: int, hi: int, noisy: np.ndarray, models: dict, zeros,
             keep: np.ndarray | None = None, repaired: np.ndarray | None = None
             ) -> tuple[np.ndarray, str, list[str], np.ndarray]:
    """``(rotations, method, notes, kept)``: ``cur``'s (F, J, 4) with the ``noisy`` cells (Fs, J) of frames
    ``lo .. hi - 1`` denoised, a filled cell's measured channels kept where its missing ones reach the denoise
    (:func:`~mocapkit.cleaning.measured.keep_measured_in_denoise`: on the whole take, which has the file's rows);
    ``notes`` its lines, each one: the denoiser's own (a fallback, a licence), the cells the guard kept as they came,
    the measured channels kept; ``kept`` (Fs, J) bool those guarded cells, each kept in the result as ``cur`` has it
    (:func:`~mocapkit.cleaning.denoise_guard.guard`; ``keep`` (Fs, J): kept whatever the guard finds).
    ``repaired`` (Fs, J): the cells a repair changed in ``cur``; those kept are named on a line of their own, kept as
    the repair made them, not among the cells kept as they came. Every line names the take's frames."""
    if not noisy.any():
        return np.array(cur.rotations), "nothing (no joint is noisy)", [], np.zeros_like(noisy)
    # the EBF runs only as far as the noisy cells need; the rule and fallback every command applies, and the path
    # `mocapkit denoise` takes (whole_take.denoise_take: channels written as 0 left as written)
    done = denoise_guarded(cur[lo:hi], models.get("ebf"), cells=noisy, zeros=zeros, measured=False, keep=keep)
    rot = np.array(cur.rotations)
    rot[lo:hi] = np.where(noisy[..., None], done.motion.rotations, rot[lo:hi])
    # measured channels kept here, on the whole take (its rows are the file's), whatever the frames denoised
    kept_m, kept, stood = keep_measured_in_denoise(cur, dataclasses.replace(cur, rotations=rot))
    names = cur.skeleton.joint_names
    came = np.zeros((cur.num_frames, len(names)), dtype=bool)  # at the take's frames, calibration poses before lo
    came[lo:hi] = done.kept
    by_repair = np.zeros_like(came)
    if repaired is not None:
        by_repair[lo:hi] = done.kept & repaired
    said = [done.note, kept_cells_line(came & ~by_repair, names),
            kept_cells_line(by_repair, names, "the repair changed are kept as the repair made them, not denoised"),
            kept_note(kept, names, "denoise", stood)]
    return kept_m.rotations, done.method, [x for x in said if x], done.kept


def _context_label(context) -> str:
    from ..context import context_label

    return context_label(context)


def noise_fit_frames(fps: float) -> int:
    """Frames the noise criterion fits at a time (odd, at least :data:`NOISE_FIT_MIN`): a take shorter than this has
    nothing to tell noise from motion by, and is not denoised."""
    return max(NOISE_FIT_MIN, int(round(NOISE_FIT_S * fps)) | 1)


#: limb joints that never hold one rotation, bit for bit, through a moving take of two seconds or more
HELD_ROLES = tuple(f"{s}_{p}" for s in ("left", "right") for p in ("shoulder", "elbow", "hip", "knee"))


def held_still_note(motion: Motion) -> str:
    """One line naming the limb joints (:data:`HELD_ROLES`) whose rotation is the same, bit for bit, in every frame of
    a take of at least two seconds while another of them moves, else "".

    A lost or frozen channel, which self-similarity does not flag: the take's own similar motion holds it too.
    Nothing in 561 real takes (HDM05, CMU, Bandai Namco, peers' BVH files) holds a shoulder, elbow, hip or knee
    still so; fingers and hands do (the CMU fingers' fixed 7.125 deg), so they are not asked.
    """
    from ..joints import standard_joints

    if motion.num_frames < 2.0 * motion.fps:
        return ""
    found = standard_joints(motion.skeleton)
    limbs = [found[r] for r in HELD_ROLES if r in found]
    held = [j for j in limbs if np.all(motion.rotations[:, j] == motion.rotations[0, j])]
    if not held or len(held) == len(limbs):
        return ""
    names = ", ".join(motion.skeleton.joint_names[j] for j in held)
    return (f"{names} {'holds' if len(held) == 1 else 'hold'} one rotation, bit for bit, through the whole take while "
            "the body moves: a lost or frozen channel? (not flagged: every word of the take holds it alike)")


def check_threshold(threshold: float) -> None:
    """Raise TypeError unless ``threshold`` (the MDM level over which a joint is flagged) is a number, ValueError
    unless it is in (0, 1)."""
    if isinstance(threshold, (bool, np.bool_)) or not isinstance(threshold, (int, float, np.integer, np.floating)):
        raise TypeError(f"threshold must be a number in (0, 1), got {type(threshold).__name__} {threshold!r}")
    if not 0.0 < threshold < 1.0:
        raise ValueError(f"threshold must be in (0, 1), got {threshold}")


def check_noise_deg(noise_deg: float) -> None:
    """Raise ValueError unless ``noise_deg`` (the noisy-cell level, degrees) is a positive number."""
    if isinstance(noise_deg, (bool, np.bool_)) or not isinstance(noise_deg, (int, float, np.integer, np.floating)):
        raise TypeError(f"noise_deg must be a number of degrees, got {type(noise_deg).__name__} {noise_deg!r}")
    if not (np.isfinite(noise_deg) and noise_deg > 0):
        raise ValueError(f"noise_deg must be a positive number of degrees, got {noise_deg!r}")


def clean(
    motion: Motion,
    context=None,
    *,
    steps: Sequence[str] | str = STEPS,
    threshold: float = 0.5,
    noise_deg: float = NOISE_DEG,
    models: dict | None = None,
    foot_skate: bool = False,
    progress: bool = False,
    max_word_angle_deg: float | None = MAX_WORD_ANGLE_DEG,
    drifts: bool = False,
) -> CleanResult:
    """Clean ``motion``: fill gaps, detect and repair erroneous joints, denoise the noisy cells (module docstring).

    Parameters
    ----------
    motion : Motion
        The take (any rig, any frame rate; NaN = missing).
    context : None, list of Motions, or MotionDatabase
        What detect and repair compare with besides the clip itself (same joints).
    steps : sequence of "fill", "detect", "repair", "denoise" (or a comma-separated string)
        The steps to run; they always run in that order. "repair" needs "detect".
    threshold : float
        MDM value above which a joint is flagged (0.5, the paper's).
    noise_deg : float
        Noise level (degrees, :func:`noise_level`) above which a cell is denoised.
    models : dict, optional
        ``{"ebd": ..., "ebf": ...}`` model objects or files; missing keys use the shipped models.
    foot_skate : bool
        Also pin planted feet on repaired frames (changes unflagged hip/knee cells).
    progress : bool
        Show detect's progress bar.
    max_word_angle_deg : float or None
        Words whose nearest neighbour in the context differs by more than this
        RMS joint angle are not judged (module docstring, step 2); None judges
        every word, as the paper does.
    drifts : bool
        Also flag (and repair) smooth drifts, digressions with no break, where ``context`` repeats the
        take's motion (:mod:`mocapkit.cleaning.ssa.drifts`; ``docs/guide/cleaning.md``). Off by default:
        against a context that does not repeat the motion a performer's style looks the same.

    Returns
    -------
    CleanResult
    """
    from . import precompile
    from .decisions import take_digest

    _check(motion)
    steps = parse_steps(steps)
    models = check_models(models)  # before any work, as the CLI checks --ebf / --ebd
    named = {k: m for k, m in models.items() if {"ebd": "fill", "ebf": "denoise"}[k] in steps}
    if named:  # a model asked for by name is used or refused, before any work
        from . import deep

        deep.check_named(motion, named)
    check_threshold(threshold)
    check_noise_deg(noise_deg)
    if "detect" in steps:  # with an empty numba cache, later steps' kernels compile beside the first steps
        precompile.start(precompile.kernels_for(steps))
    params = take_params(max_word_angle_deg=max_word_angle_deg, drifts=drifts)
    name = motion.name or "motion"
    F, J = motion.num_frames, motion.num_joints
    zeros = np.zeros((F, J), dtype=bool)
    filled = zeros
    records: list[StepRecord] = []
    notes: list[str] = []
    det = None
    cuts = ()  # the take's cuts (take_breaks.Cut), found by detect: named, no sample changed for them
    left_out = None
    cur = motion

    held = held_still_note(motion) if "detect" in steps else ""
    if held:
        notes.append(held)
    sides = exchanged_sides(motion)  # a rig mapped left for right: named, nothing changed for it
    if sides is not None:
        notes.append(str(sides))
    # channels written as 0 where the capture lost data are missing cells, which fill fills (module docstring)
    values = motion.channel_values()  # the file's channels, read by the zeros and the interpolated frames
    found_zeros = find_zeros(motion, values)
    zero_cells, zero_runs, zero_frames = found_zeros
    stutters = find_stutters(motion, skip=zero_frames)
    skip = zero_frames | stutter_frames(stutters, motion.num_frames)
    interpolated = interpolated_note(motion, skip=skip, values=values)
    del values
    if interpolated:
        notes.append(interpolated)
    if "fill" in steps:
        t = time.perf_counter()
        # the path `mocapkit fill` takes too (whole_take.fill_take)
        done = fill_take(motion, models.get("ebd"), models.get("ebf"), zeros=found_zeros)
        # the filled take's Euler angles (the networks' channels) converted in its filled cells alone
        cur, filled, note = done.motion.euler_from(motion), done.filled, done.note
        if note:
            notes.append(note)
        for warn in done.warnings:  # a warning line, as a fallback's note is
            notes.append(warn)
            note = "; ".join(n for n in (note, warn) if n)
        records.append(StepRecord("fill", time.perf_counter() - t, int(filled.sum()), done.method, note))
    else:
        zero_runs = tuple(dataclasses.replace(z, filled=False) for z in zero_runs)

    # calibration poses opening or closing the take are left out of every later step (module docstring)
    poses = calibration_poses(cur) if any(s in steps for s in ("detect", "repair", "denoise")) else ()
    lo, hi = motion_span(poses, F)
    Fs = hi - lo
    if poses and Fs == 0:
        notes.append("detect, repair and denoise skipped: the whole take is a calibration pose")
        steps = tuple(s for s in steps if s == "fill")
    mdm, flags, causes = np.zeros((F, J)), zeros, None
    repaired, denoised, noise = zeros, zeros, np.full((F, J), np.nan)

    den_record, redo = None, None
    if "denoise" in steps:  # before detect, which judges the take denoised (module docstring, step 4)
        t = time.perf_counter()
        w = noise_fit_frames(cur.fps)
        coarse = noise_too_coarse(cur.fps)
        if coarse:
            note = f"denoise skipped: {coarse}"
            notes.append(note)
            den_record = StepRecord("denoise", time.perf_counter() - t, 0, "skipped", note)
        elif Fs < w:
            note = f"denoise skipped: {plural(Fs, 'frame')} is shorter than the noise criterion's fit ({w} frames)"
            notes.append(note)
            den_record = StepRecord("denoise", time.perf_counter() - t, 0, "skipped", note)
        else:
            part = cur[lo:hi]  # calibration frames as they came out of fill
            noisy, sub_noise = noisy_cells(part, noise_deg, filled=filled[lo:hi])
            noisy &= ~part.missing()
            # the zeros fill did not fill, in the part's frames (none after fill)
            left = ((zero_cells[lo:hi], zero_runs, zero_frames[lo:hi]) if "fill" not in steps
                    else (np.zeros_like(noisy), (), np.zeros(Fs, dtype=bool)))
            rot, method, den_notes, guarded = _denoise(cur, lo, hi, noisy, models, left)
            at = len(notes)  # where its lines stand: a denoise after the repair says its own lines there instead
            notes.extend(den_notes)
            denoised, den_rot = differing(cur.rotations, rot), rot
            # repair works on the take as filled, denoised after it, keeping the cells this denoise kept
            undenoised, redo = cur, (noisy, left, guarded)
            cur = cur.with_rotations(rot)
            noise[lo:hi] = sub_noise
            extra = (f"{plural(int(noisy.sum()), 'noisy cell')} (level > {noise_deg:g} deg) on "
                     f"{plural(int(noisy.any(axis=0).sum()), 'joint')}")
            den_record = StepRecord("denoise", time.perf_counter() - t, int(denoised.sum()), method,
                                    "; ".join([extra, *den_notes]))

    if "detect" in steps:
        t = time.perf_counter()
        gaps = cur[lo:hi].missing().any(axis=1)
        if gaps.any():
            n = int(gaps.sum())
            raise MocapError(f"{name}: {n} frame{'s have' if n != 1 else ' has'} missing joints; detect needs "
                             "complete frames: add the fill step")
        # the path `mocapkit detect` and `mocapkit repair` take too (whole_take): their flags are these
        found = detect_take(cur, context, threshold=threshold, params=params, progress=progress, poses=poses,
                            zero_runs=() if "fill" in steps else zero_runs)
        if found.detection is None:
            note = f"detect and repair skipped: {found.skipped}"
            notes.append(note)
            records.append(StepRecord("detect", time.perf_counter() - t, 0, "skipped", note))
            steps = tuple(s for s in steps if s != "repair")
        else:
            det = found.detection  # at the take's frames, nothing flagged on a calibration pose
            cuts = found.cuts
            mdm = np.nan_to_num(np.asarray(det.mdm, dtype=np.float64))
            flags = np.asarray(det.flags, dtype=bool)
            causes = det.causes()
            left_out = tuple(det.not_analysed().items())
            what = "the clip itself" if context is None else f"the clip and {_context_label(context)}"
            said = det.analysed_part().notes  # the frames analysed are said by the calibration lines
            if len(found.breaks) > MAX_LINES:  # a long take of many cuts: the first few, then a count
                said = tuple(n for n in said if n not in found.breaks) + tuple(capped_lines(
                    list(found.breaks), "cuts and jumps of the root", " (`mocapkit detect` lists them all)"))
            note = f"{plural(len(det.segments()), 'flagged segment')} on {plural(int(flags.any(axis=0).sum()), 'joint')}" + (
                f"; {'; '.join(said)}" if said else "")
            if "repair" not in steps:  # review: the teleports and turn-overs the repair step would name, flagged, left
                seen = (review_whole(cur, det, poses=poses) if redo is None else
                        review_whole(undenoised, det, context, poses=poses))
                detected = flags
                flags, causes = with_teleports(flags, causes, seen.teleported)
                flags, causes = with_flips(flags, causes, seen.turn_overs.flagged)
                notes.extend(seen.lines)
                # the flags in all, as the report lists them: a turn-over's cells are flagged here, not by detection
                note = "; ".join(x for x in (note, teleports_note(seen.teleports), turn_overs_note(seen.turn_overs.lines),
                                             flagged_in_all_note(detected, flags, seen.teleported,
                                                                 seen.turn_overs.flagged)) if x)
            records.append(StepRecord("detect", time.perf_counter() - t, 0, f"self-similarity against {what}", note))

    if "repair" in steps and det is not None:
        t = time.perf_counter()
        # on the take as filled, teleports put back after: the path `mocapkit repair` takes too
        # (the detection's prepared take serves only the take it judged: the take as filled is prepared again,
        # against the same context)
        done = (repair_whole(cur, det, foot_skate=foot_skate, poses=poses) if redo is None else
                repair_whole(undenoised, det, context, foot_skate=foot_skate, poses=poses))
        cur, repaired = done.motion.euler_from(cur), done.changed
        if redo is not None and repaired.any():  # the noisy cells denoised again, around the repaired ones
            # the cells the first denoise kept as they came are kept again: what the record says is what is written
            # (one the repair changed is kept as the repair made it: denoised alone between kept cells, it was read
            # with no neighbour, and came out further from the truth than the repair put it: Bandai punch at 0.3)
            rot, _, again, _ = _denoise(cur, lo, hi, redo[0], models, redo[1], keep=redo[2],
                                        repaired=repaired[lo:hi])
            denoised = differing(cur.rotations, rot)
            cur = cur.with_rotations(rot)
            notes[at:at + len(den_notes)] = again  # the lines of the denoise written, in the first one's place
            den_record = dataclasses.replace(den_record, cells=int(denoised.sum()),
                                             note="; ".join([extra, *again]))
        elif redo is not None:
            cur = dataclasses.replace(cur, rotations=np.where(denoised[..., None], den_rot, cur.rotations))
        # the root cells put back: flagged in the record, so a person can undo them
        detected = flags
        flags, causes = with_teleports(flags, causes, done.teleported)
        flags, causes = with_swaps(flags, causes, done.swapped)  # both sides of a swap exchanged back: tied
        flags, causes = with_flips(flags, causes, done.turn_flags)  # turn-overs turned back or named: named below
        note = "; ".join(done.put_back) if done.put_back else "" if flags.any() else "nothing flagged"
        notes.extend(done.flips)  # every one: a flag's outcome in the report reads its line
        # the flags in all, as the report lists them: detect's note counts only what detection flagged
        note = "; ".join(x for x in (note, turn_overs_note(done.flips),
                                     flagged_in_all_note(detected, flags, done.teleported, done.turn_flags, done.swapped),
                                     done.measured) if x)  # kept or changed whole
        if done.left:  # runs the repair guard gave back as they were: flagged, not changed, named
            notes.extend(capped_lines(done.left, "runs left"))
            note = "; ".join(x for x in (note, f"{plural(len(done.left), 'run')} left: repair not better than the take") if x)
        records.append(StepRecord("repair", time.perf_counter() - t, int(repaired.sum()),
                                  "medoid of the nearest motion words (transient offsets taken away, confirmed left/right swaps exchanged "
                                  "back)" + (" + foot-skate cleanup" if foot_skate else "")
                                  + (" + turn-overs turned back (ssa.flips)" if done.turned is not None and done.turned.any() else ""),
                                  note))

    if den_record is not None:  # listed in the order of STEPS, where the record has always listed it
        records.append(den_record)

    if cur.source_file != motion.source_file or cur.source_frames != motion.source_frames:
        # the file a writer keeps the text of (mocapkit.io.save's like), and which of its frames the take holds
        cur = dataclasses.replace(cur, source_file=motion.source_file, source_frames=motion.source_frames)
    params = dict(steps=list(steps), threshold=float(threshold), noise_deg=float(noise_deg), foot_skate=bool(foot_skate),
                  context="none" if context is None else _context_label(context), analysed=[int(lo), int(hi)])
    return CleanResult(
        motion=cur, mdm=mdm, flags=flags, filled=filled, repaired=repaired, denoised=denoised, noise=noise,
        joint_names=tuple(motion.skeleton.joint_names), fps=float(motion.fps), steps=tuple(records),
        notes=tuple(notes), params=params, detection=det, calibration=tuple(poses), causes=causes,
        take_sha256=take_digest(motion), left_out=left_out, zeros=zero_cells, zero_runs=zero_runs, stutters=stutters,
        cuts=cuts,
    )
