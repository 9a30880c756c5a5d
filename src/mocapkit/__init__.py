"""mocapkit: clean and reconstruct human motion-capture data.

>>> import mocapkit
>>> m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
>>> m.skeleton.joint_names[:3]
('Hips', 'LHipJoint', 'LeftHip')

The main job, :func:`clean`, takes a file or a Motion:

>>> res = mocapkit.clean(mocapkit.samples.path("12_walk.amc"), steps="fill,denoise")
>>> res.motion.num_frames, [s.name for s in res.steps]
(343, ['fill', 'denoise'])

Importing the package is cheap: torch and the numba kernels load only in the
functions that use them.
"""

from __future__ import annotations

import dataclasses
import os

from .kernel_cache import ensure_cache_dir

ensure_cache_dir()  # before any kernel loads: a read-only install without a writable home still runs

from . import rotations, samples  # noqa: E402
from .errors import MissingFileError, MocapError, MocapFormatError, SkeletonError  # noqa: E402
from .io import load, save  # noqa: E402
from .motion import Motion, Skeleton, concatenate  # noqa: E402

__version__ = "0.23.0"

__all__ = [
    "Motion",
    "Skeleton",
    "MocapError",
    "MocapFormatError",
    "MissingFileError",
    "SkeletonError",
    "clean",
    "load",
    "save",
    "concatenate",
    "rotations",
    "samples",
]


def clean(take, context=None, *, steps=None, threshold: float | None = None, asf=None,
          drifts: bool | None = None, models: dict | None = None, progress: bool = False, noise_deg: float | None = None,
          fps: float | None = None, unit: str | None = None, decisions=None, record=None, joint_map=None,
          zeros_as_gaps: bool | None = None):
    """Clean a take: fill gaps, detect and repair erroneous joints, denoise the noisy cells.

    The main job of mocapkit, :func:`mocapkit.cleaning.pipeline.clean` on a
    file or a Motion: every cell that is neither missing, flagged nor noisy
    comes back bit-identical, and the result records what each step changed.

    Parameters
    ----------
    take : Motion, MarkerSet, str or os.PathLike
        The take, or its file (.bvh, .amc, .npz; an AMC's skeleton is the
        ``.asf`` beside it unless ``asf`` is given). A marker capture
        (MarkerSet, .c3d, .trc, marker .npz) goes to
        :func:`mocapkit.cleaning.markers.clean_markers` (label swaps, spikes,
        gaps), which returns a ``MarkerCleanResult``; ``steps="detect"`` is
        its review mode (nothing changed: the result's ``output`` is the
        input, its ``fixes`` what cleaning would change, ``review`` True), and
        ``decisions`` applies a person's decisions to it; the other parameters
        apply to motions only and are refused for it.
    context : None, False, "none", MotionDatabase, database folder, folder of takes, or list of Motions or files
        What detection and repair compare with besides the clip itself
        (:func:`mocapkit.context.resolve_context`): a folder of takes or a
        list of files is built into a database once and cached, a list of
        Motions into the same database in memory (the result is bit for bit
        that of their files: each resampled to 24 fps by slerp and stored as
        float32, :func:`mocapkit.context.motions_context`); None: the
        bundled default context (skipped, with a note, for a take on another
        skeleton); False or "none": the clip itself alone.
    joint_map : dict, str or os.PathLike, optional
        ``{clip joint: joint of a known rig}``, or the JSON file holding it
        (the CLI's ``--joint-map``, :func:`mocapkit.database.read_joint_map`):
        the names a ``context`` folder, files or Motions are built under, for a
        rig whose joint names say no roles (hands, feet, head); the context is
        cached under a key that includes the map, and the result's request
        keeps its content.
    steps : str or sequence of str, optional
        Any of "fill", "detect", "repair", "denoise" (comma-separated or a
        list); they always run in that order, and "repair" needs "detect".
        Default (None): all four.
    threshold : float, optional
        MDM value in (0, 1) above which a joint is flagged and repaired (default, None: 0.5).
    asf : str, os.PathLike or Skeleton, optional
        The ASF skeleton of an AMC take (context AMC files use the ASF beside them).
    drifts : bool, optional
        Also flag and repair smooth drifts (digressions with no break), where
        ``context`` repeats the take's motion (``docs/guide/cleaning.md``; the CLI's ``--drifts``; default, None: False).
    models : dict, optional
        ``{"ebf": ..., "ebd": ...}``: model files, shipped models' names (``"ebf.pt"``) or
        loaded models for the denoiser and the gap filler (the CLI's ``--ebf`` / ``--ebd``);
        default the pair for the take's rig.
    progress : bool
        Show detection's progress bar.
    noise_deg : float, optional
        The noise level in degrees over which a joint's cells are denoised
        (:func:`mocapkit.cleaning.pipeline.noisy_cells`; default 1; the CLI's ``--noise-deg``).
    fps : float, optional
        The frame rate of an AMC file, which states none (the CLI's ``--amc-fps``;
        default :func:`mocapkit.io.asfamc.amc_rate`).
    unit : {"mm", "cm", "m", "in"}, optional
        The length unit of a file that states none (the CLI's ``--unit``).
    zeros_as_gaps : bool, optional
        How a .c3d or .trc file's samples at exactly (0, 0, 0) are read: True gaps, False positions (the CLI's
        ``--zeros-as-gaps`` / ``--keep-zeros``); default (None) decided from the data
        (:func:`mocapkit.io.load_markers`). Marker files only.
    decisions : str, os.PathLike or dict, optional
        A decisions file (the report's *Download decisions*; the CLI's
        ``--decisions``), or the same document as a dict: the result then holds only the changes it accepts, every other
        sample the input's bit for bit, and its ``summary()`` says what
        ``mocapkit clean --decisions`` says (``result.decided``). The file
        applies only to the cleaning it was made on, as for the CLI: its
        ``record``, or a new cleaning with the options reviewed giving the
        very same values; a refusal is the CLI's line naming the file
        (:func:`mocapkit.cleaning.decide.clean_and_decide`,
        :func:`mocapkit.cleaning.markers.decisions.clean_and_decide`). A
        cleaning made here keeps its options as the CLI's record does
        (``params["request"]``), so ``result.save(record)`` and
        :func:`mocapkit.report.html.write_clean_report` give a record and a
        report whose decisions apply from here or from the CLI alike.
    record : str or os.PathLike, optional
        With ``decisions``: the ``.clean.npz`` of the cleaning reviewed (the
        CLI's ``--record``), read back instead of cleaning again (no context is
        read). The options that shape a cleaning (``context``, ``steps``,
        ``threshold``, ``drifts``, ``models``, ``noise_deg``, ``joint_map``), when given (not
        None, even at their default value: ``threshold=0.5`` beside a record
        made at 0.3 is refused), are honoured only where they are those the
        record's cleaning was made with, and otherwise refused in one line naming the record and each keyword
        (:func:`mocapkit.cleaning.replay.check_replay`); ``asf``, ``fps`` and
        ``unit`` read the take, which must be the one the record was made from.

    Returns
    -------
    CleanResult
        ``motion`` (the cleaned take), the (F, J) cell masks ``filled``,
        ``repaired``, ``denoised``, the detection, and one record per step
        (see :class:`mocapkit.cleaning.clean_record.CleanResult`); its
        ``summary()`` lines are those ``mocapkit clean`` prints, the line on
        how its 0-based frames relate to the file's own numbers (an AMC's,
        a TRC's, a C3D's) included when ``take`` is such a file.

    Raises
    ------
    MocapFormatError
        A file that cannot be read (a bad AMC/ASF pair, ...).
    MocapError
        A take the steps cannot clean (e.g. missing in every frame).
    """
    from .cleaning.decisions import frames_note
    from .cleaning.pipeline import clean as clean_motion
    from .io.takes import check_unit
    from .markerset import MarkerSet

    check_unit(unit, "unit=")
    if isinstance(joint_map, (str, os.PathLike)):
        from .database import read_joint_map

        joint_map = read_joint_map(joint_map)
    asked = {"steps": steps is not None, "threshold": threshold is not None, "drifts": drifts is not None}
    steps = "fill,detect,repair,denoise" if steps is None else steps
    threshold = 0.5 if threshold is None else threshold
    drifts = False if drifts is None else drifts
    if isinstance(take, (MarkerSet, Motion)):  # options of a file, refused as fps= is for a .bvh path
        given = [f"{name}=" for name, value in (("asf", asf), ("fps", fps), ("unit", unit),
                                                 ("zeros_as_gaps", zeros_as_gaps)) if value is not None]
        if given:
            raise MocapError(f"{take.name or 'the take'}: {', '.join(given)} {'apply' if len(given) > 1 else 'applies'} "
                             f"to a file read here, not to a {type(take).__name__} already read")
    path = take if isinstance(take, (str, os.PathLike)) else None
    if path is not None and os.fspath(path).lower().endswith((".c3d", ".trc", ".npz")):
        from .io.takes import load_take

        _amc_only(path, asf, fps)  # an AMC's skeleton and rate: refused for a marker capture too, not ignored

        take = load_take(path, unit=unit, unit_option="unit=", zeros_as_gaps=zeros_as_gaps)
    if isinstance(take, MarkerSet):
        from .cleaning.decisions import RECORD_KEYWORD
        from .cleaning.markers.decisions import clean_and_decide
        from .cleaning.pipeline import STEPS, parse_steps
        from .marker_files import joint_angle_options, marker_request, refuse_marker_options

        review = parse_steps(steps) == ("detect",)
        refuse_marker_options(take.name or "the take", joint_angle_options({key: value for key, value, given in (
            ("steps", parse_steps(steps), parse_steps(steps) not in (STEPS, ("detect",))),
            ("threshold", threshold, threshold != 0.5), ("drifts", drifts, drifts), ("models", models, bool(models)),
            ("context", context, context is not None), ("noise_deg", noise_deg, noise_deg is not None),
            ("joint_map", joint_map, joint_map is not None)) if given}, flags=False))
        _, res = clean_and_decide(take, name=os.fspath(path) if path is not None else "", decisions=decisions,
                                  record=record, review=review,
                                  request=marker_request(unit, review=review, zeros_as_gaps=zeros_as_gaps),
                                  option=RECORD_KEYWORD,
                                  take=os.path.basename(os.fspath(path)) if path is not None else "")
        return dataclasses.replace(res, frames_note=frames_note(path, take))
    if record is not None and decisions is None:
        raise MocapError(f"{record}: an earlier run's record is applied with decisions; give the decisions file")
    if zeros_as_gaps is not None:
        raise MocapError(f"{take}: zeros_as_gaps= applies only to marker captures (.c3d, .trc)")
    motion = take if isinstance(take, Motion) else _load_motion(take, asf, fps, unit)
    request = _request(context, steps, threshold, drifts, models, noise_deg, fps, unit, joint_map)
    if record is not None:
        from .cleaning.pipeline import parse_steps
        from .cleaning.replay import check_replay, given_options

        given = set(given_options(parse_steps(steps), threshold, drifts, context is not None, models, noise_deg))
        given |= {key for key, on in {**asked, "joint_map": joint_map is not None}.items() if on}  # at its default too
        check_replay(record, request, given, False, "record=")

    def cleaning():
        ctx, note = _load_context(context, motion, steps, joint_map)
        extra = {} if noise_deg is None else {"noise_deg": noise_deg}
        res = clean_motion(motion, ctx, steps=steps, threshold=threshold, progress=progress, drifts=drifts,
                           models=models, **extra)
        return dataclasses.replace(res, notes=res.notes + ((note,) if note else ()),
                                   params={**res.params, "request": request})

    if decisions is None:
        return dataclasses.replace(cleaning(), frames_note=frames_note(path))
    from .cleaning.decide import clean_and_decide

    name = os.path.basename(os.fspath(path)) if path is not None else ""
    _, res = clean_and_decide(motion, cleaning, decisions=decisions, record=record, request=request, take=name)
    return dataclasses.replace(res, frames_note=frames_note(path))


def _request(context, steps, threshold, drifts, models, noise_deg, fps, unit, joint_map=None) -> dict:
    """The options a take is cleaned with, as the CLI's record keeps them (:func:`mocapkit.batch_request.clean_request`):
    a cleaning made here and one made by ``mocapkit clean`` with the same options have one
    :func:`~mocapkit.cleaning.decisions.cleaning_digest`. ``context`` is said as ``--context`` says it (None: the
    default; False or "none": none; a folder or files: their paths); one held in memory (a database, Motions), which
    no command line can give, by what it is."""
    from .batch_request import clean_request

    if context is None or context is False:
        said = None if context is None else ["none"]
    elif isinstance(context, (str, os.PathLike)):
        said = [context]
    elif isinstance(context, (list, tuple)):
        said = [c if isinstance(c, (str, os.PathLike)) else f"<{type(c).__name__} {getattr(c, 'name', '') or ''}>"
                for c in context]
    else:
        said = [f"<{type(context).__name__} in memory>"]
    # options of the wrong type are refused by the cleaning in its own words, not here
    return clean_request(steps, threshold, drifts, said, models if isinstance(models, dict) else None, noise_deg,
                         fps, unit, joint_map)


def _amc_only(path, asf, fps) -> None:
    """Refuse ``asf`` or ``fps`` given for a file ``path`` that is no AMC, in one line naming the file and keyword."""
    is_amc = os.fspath(path).lower().endswith(".amc")
    for name, given in (("asf", asf), ("fps", fps)):
        if given is not None and not is_amc:
            raise MocapFormatError(path, f"{name}= applies to .amc files only")


def _load_motion(path, asf, fps=None, unit=None) -> Motion:
    """The Motion in ``path`` (``asf`` and ``fps`` for an AMC file, ``unit`` where the file states none); a marker
    file, or ``asf`` or ``fps`` with another format, is refused."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"expected a Motion or a file path, got {type(path).__name__}")
    _amc_only(path, asf, fps)
    from .io.takes import load_take

    out = load_take(path, asf, fps=fps, unit=unit, unit_option="unit=")
    if not isinstance(out, Motion):
        raise MocapFormatError(path, "holds marker trajectories, not a skeleton motion; clean takes .bvh, .amc or .npz motions")
    return out


def _load_context(context, motion, steps=None, joint_map=None):
    """``context`` as :func:`mocapkit.cleaning.pipeline.clean` takes it (:func:`mocapkit.context.resolve_context`,
    built under ``joint_map``),
    fitted to ``motion``'s skeleton (:func:`mocapkit.context.fit_context`); returns ``(context, note)``.
    ``(None, "")`` when ``steps`` (None: every step) leave detection out: no other step reads a context; ``(None,
    line)`` for a take too coarse for detection (:func:`mocapkit.cleaning.take_context.unread_context`)."""
    from .cleaning.pipeline import STEPS, parse_steps
    from .cleaning.take_context import unread_context
    from .context import fit_context, resolve_context, topology_id

    if "detect" not in parse_steps(STEPS if steps is None else steps):
        return None, ""
    unread = unread_context(motion, context)  # under 12 fps detection does not run: nothing is built or read
    if unread is not None:
        return None, unread
    return fit_context(motion, resolve_context(context, prefer=topology_id(motion.skeleton), joint_map=joint_map))
