"""Readers and writers; ``load`` and ``save`` choose the format by the file suffix.

Readers return a :class:`~mocapkit.motion.Motion` (C3D and TRC: a
:class:`~mocapkit.markerset.MarkerSet`), writers take one. ``load_markers``
and ``save_markers`` are the marker-file entry points (.c3d, .trc, marker .npz). Every reader raises
:class:`~mocapkit.errors.MocapFormatError` naming the file, the line when
known, and the problem. Writers write to a temporary file in the target
folder and rename it, so a failed or interrupted write leaves no partial file.
"""

from __future__ import annotations

import os
import warnings
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path

from ..errors import MissingFileError, MocapError, MocapFormatError
from ..interrupts import interrupts_held, whole_hand_over
from ..markerset import MarkerSet
from ..words import plural
from .outputs import check_file_path, missing_folders, named_as_given, publish, temp_prefix

__all__ = ["load", "save", "check_writable", "check_complete", "load_markers", "save_markers", "check_keep_modelled",
           "marker_notes", "motion_notes", "unit_note", "atomic_write",
           "MarkerSet",
           "READERS", "WRITERS", "MARKER_FORMATS"]

READERS = {".bvh": "bvh", ".amc": "asfamc", ".npz": "npz", ".c3d": "c3d", ".trc": "trc"}
WRITERS = {".bvh": "bvh", ".amc": "amc", ".npz": "npz"}
MARKER_FORMATS = {".c3d": "c3d", ".trc": "trc", ".npz": "npz"}


def suffix_kind(path: Path, table: dict, verb: str) -> str:
    """The format ``table`` gives ``path``'s suffix; a one-line MocapFormatError for an unknown one."""
    suf = path.suffix.lower()
    if suf not in table:
        known = ", ".join(sorted(table))
        raise MocapFormatError(path, f"unknown suffix {suf or '(none)'!r} for {verb}; known: {known}")
    return table[suf]


def _not_a_folder(path: Path, table: dict) -> None:
    """Refuse a folder given where one file is read, saying so (its suffix, usually none, says nothing)."""
    if path.is_dir():
        known = ", ".join(sorted(table))
        raise MocapFormatError(path, f"a folder, not a file: give one of the files in it ({known})")


def load(path, **kwargs):
    """Read a motion file, choosing the format by suffix (.bvh, .amc, .npz; .c3d and .trc give a MarkerSet).

    Keyword arguments go to the format's reader (e.g. ``asf=`` and ``fps=`` for AMC; ``zeros_as_gaps=`` and
    ``units=`` for .c3d and .trc; none for .bvh and .npz); one the file's reader does not take is refused in one
    :class:`~mocapkit.errors.MocapFormatError` naming the file and which keywords fit which format
    (the readers' own parameters).
    """
    path = Path(path)
    _not_a_folder(path, READERS)
    kind = suffix_kind(path, READERS, "reading")
    if not path.is_file():
        raise (MocapFormatError(path, "not a regular file") if path.exists() else MissingFileError(path))
    _check_keywords(path, kwargs, READERS, "load")
    return _reader(kind)(path, **kwargs)


def _check_keywords(path: Path, kwargs: dict, table: dict, caller: str) -> None:
    """Refuse a keyword of ``kwargs`` that the reader of ``path``'s format does not take, in one
    :class:`~mocapkit.errors.MocapFormatError` naming the file and which keywords fit which suffix of ``table``
    (:data:`READERS` for :func:`load`, :data:`MARKER_FORMATS` for :func:`load_markers`; ``caller`` names the
    function). A raw ``TypeError`` from the reader is missed by ``except MocapError``."""
    wrong = [k for k in kwargs if k not in _reader_keywords(table[path.suffix.lower()])]
    if wrong:
        fits = {}  # the keywords -> the suffixes whose reader takes them
        for suffix, other in table.items():
            fits.setdefault(_reader_keywords(other), []).append(suffix)
        said = "; ".join(f"{', '.join(sorted(sufs))}: {', '.join(k + '=' for k in kws) or 'none'}"
                         for kws, sufs in sorted(fits.items(), key=lambda kv: sorted(kv[1])))
        raise MocapFormatError(path, f"{caller} takes no {', '.join(k + '=' for k in wrong)} for "
                                     f"{path.suffix.lower()} files; the keywords by format: {said}")


def _reader(kind: str):
    """The read function of a :data:`READERS` kind."""
    if kind == "bvh":
        from .bvh import read_bvh as reader
    elif kind == "asfamc":
        from .asfamc import read_amc as reader
    elif kind == "npz":
        from .npz import read_npz as reader
    elif kind == "trc":
        from .trc import read_trc as reader
    else:
        from .c3d import read_c3d as reader
    return reader


def _reader_keywords(kind: str) -> tuple[str, ...]:
    """The keyword arguments :func:`load` passes on to the reader of a :data:`READERS` kind (``"asfamc"``:
    ``("asf", "fps", "dofs")``), read from its signature: every parameter after the path."""
    import inspect

    return tuple(inspect.signature(_reader(kind)).parameters)[1:]


def load_markers(path, **kwargs) -> MarkerSet:
    """Read a marker file (.c3d, .trc, or an npz written from a MarkerSet) as a :class:`MarkerSet`.

    Keyword arguments go to the reader: ``zeros_as_gaps`` (True, False, or
    None to decide from the data) and ``units`` for .c3d and .trc; none for a marker npz. Raises
    :class:`~mocapkit.errors.MocapFormatError` for a folder, an unknown suffix, a keyword the format's reader
    does not take (one line naming the keywords by format, as :func:`load`), a file
    that is not a marker file (an npz holding a Motion) or any reader error.
    """
    path = Path(path)
    _not_a_folder(path, MARKER_FORMATS)
    kind = suffix_kind(path, MARKER_FORMATS, "reading markers")
    if not path.is_file():
        raise (MocapFormatError(path, "not a regular file") if path.exists() else MissingFileError(path))
    _check_keywords(path, kwargs, MARKER_FORMATS, "load_markers")
    if kind == "npz":
        from .npz import read_npz

        obj = read_npz(path)
        if not isinstance(obj, MarkerSet):
            raise MocapFormatError(path, "this npz holds a motion (joint angles), not marker trajectories")
        from .c3d import checked_unit_cm

        checked_unit_cm(path, obj.units)
        return obj
    if kind == "trc":
        from .trc import read_trc

        return read_trc(path, **kwargs)
    from .c3d import read_c3d

    return read_c3d(path, **kwargs)


def save_markers(markers: MarkerSet, path, *, like=None, stored_zeros: bool = False,
                 keep_modelled: bool = False, filled=None, overwrite: bool = False) -> Path:
    """Write ``markers`` to ``path`` (.c3d, .trc or .npz, by suffix) atomically; returns the path.

    ``like`` (a MarkerSet or a file of the same format) supplies the file
    contents other than the trajectories to keep: a C3D's parameter groups and
    analog channels, a TRC's header fields. Without it, those of the file
    ``markers`` was read from are kept when it had the same format. A C3D's
    force plates are kept only with their analog channels, its events only
    where ``like`` is the take's own trial (same rate, the take's frames, markers that agree there: a crop of
    the file keeps the events inside it) and within the frames written (:mod:`mocapkit.io.c3d_trial`).
    ``stored_zeros`` (C3D): a gap the file stored as exact (0, 0, 0) that is
    still missing is written back as the file had it
    (:func:`~mocapkit.io.c3d.write_c3d`), not as residual -1. A .trc
    holds markers only: a C3D's modelled quantities (angles, forces, moments,
    powers) are left out unless ``keep_modelled``
    (:func:`mocapkit.io.trc.write_trc`). ``filled`` ((F, M) bool, or None): the
    samples a cleaning filled, which a .npz lists in its ``filled`` mask
    (:func:`mocapkit.io.npz.write_npz`; a C3D marks them by residual 0, a TRC cannot).

    An existing ``path`` is refused (:class:`~mocapkit.errors.MocapFormatError`) unless ``overwrite=True``:
    a marker file written anew is not the file it replaces (a C3D's parameter section is ezc3d's),
    so a capture is never rewritten by a call that did not ask for it. ``path`` naming the file ``like``
    is refused even so: that file is what the output is written like, and it is read while writing.
    """
    from .outputs import same_file

    path = Path(check_file_path(path))  # "x.trc/" names a folder: refused, not written as x.trc
    kind = suffix_kind(path, MARKER_FORMATS, "writing markers")
    if not isinstance(markers, MarkerSet):
        raise TypeError(f"save_markers takes a MarkerSet, got {type(markers).__name__}")
    if isinstance(like, (str, os.PathLike)) and same_file(path, like):
        raise MocapFormatError(path, "is the file given as like=; refusing to write over it, choose another path")
    if not overwrite and (path.exists() or path.is_symlink()):
        raise MocapFormatError(path, "already exists; pass overwrite=True to replace it")
    if kind == "npz":
        from .npz import write_npz

        write_npz(markers, path, filled=filled)
    elif kind == "trc":
        from .trc import write_trc

        write_trc(markers, path, like=like, keep_modelled=keep_modelled)
    else:
        from .c3d import write_c3d

        write_c3d(markers, path, like=like, stored_zeros=stored_zeros)
    return path


def check_keep_modelled(inp, out) -> None:
    """Refuse, in one line naming the file, ``--keep-modelled`` where it has no meaning.

    Only a C3D lists modelled quantities (POINT:ANGLES, FORCES, MOMENTS,
    POWERS, SCALARS, REACTIONS: :meth:`MarkerSet.quantities`), and only a
    .trc output leaves them out (it holds markers in one length unit,
    :func:`mocapkit.io.trc.write_trc`): a .c3d or .npz output keeps every
    point as read, and a TRC or npz input lists none, so the option would
    change nothing there. ``inp``, ``out``: the paths, judged by suffix.
    """
    inp, out = Path(inp), Path(out)
    if out.suffix.lower() != ".trc":
        raise MocapError(f"{out}: --keep-modelled (keep_modelled=True) chooses what a .trc output holds; a .c3d or .npz output keeps "
                         "every point as read, modelled quantities included")
    if inp.suffix.lower() != ".c3d":
        raise MocapError(f"{inp}: --keep-modelled (keep_modelled=True) keeps the modelled quantities a C3D lists (POINT:ANGLES, FORCES, "
                         "MOMENTS, POWERS, ...); a .trc or .npz input lists none")


def marker_notes(markers: MarkerSet, path, inp=None, *, keep_modelled: bool = False, filled=None,
                 record=None) -> list[str]:
    """What a command tells its user when it writes ``markers`` (read from ``inp``) to ``path``: one line each.

    The reader's notes (``markers.notes``: labels a file repeats, trajectories
    its header does not count, frames it skips), then one line naming what the
    take holds that ``path``'s format cannot (a C3D's analog channels, events,
    parameter groups, residuals and camera masks in a .trc or .npz; a TRC's
    header rates and counts in a .c3d or .npz), so that nothing is dropped
    without a word. Each line names the file it is about (``inp``, ``path``).

    A .c3d written after a cleaning (``filled`` given) of an integer C3D, stored as 16-bit integers as the
    input is (:func:`mocapkit.io.c3d_layout.integer_data`), gets a line saying that the changed and filled
    samples are rounded to the file's steps (POINT:SCALE).
    A .trc also gets a line for the modelled quantities it leaves out (count
    and kinds, :meth:`MarkerSet.quantities`; none with ``keep_modelled``), and
    one for the samples it writes like recorded ones although they are not,
    as a TRC has no residual column to mark them: those ``markers`` marks as
    interpolated (residual 0 where other samples have a residual over 0: a
    capture program's fills, or a cleaned C3D's), and ``filled`` ((F, M) bool:
    the samples a cleaning's fills made), with ``record``, the file that lists
    them (a ``.clean.npz``).
    """
    import numpy as np

    path = Path(path)
    kind = MARKER_FORMATS.get(path.suffix.lower())
    notes = [f"{inp}: {note}" if inp is not None else note for note in markers.notes]
    source = markers.source
    lost: list[str] = []
    if kind in ("trc", "npz") and source is not None and source.format == "c3d":
        if source.analogs is not None and source.analogs.shape[0]:
            lost.append(f"{source.analogs.shape[0]} analog channel{'s' if source.analogs.shape[0] > 1 else ''}")
        event = source.parameters.get("EVENT", {})
        used = np.ravel(event.get("USED", {}).get("value", [0])) if isinstance(event, dict) else [0]
        if source.events or (len(used) and int(used[0]) > 0):
            lost.append("events")
        lost.append("parameter groups")
    if kind in ("trc", "npz") and markers.residuals is not None and np.any(markers.residuals > 0):
        lost.append("residuals")
    if kind in ("trc", "npz") and markers.cameras is not None and np.any(markers.cameras):
        lost.append("camera masks")
    if kind in ("c3d", "npz") and source is not None and source.format == "trc":
        fields = [k for k in ("CameraRate", "OrigDataRate", "OrigDataStartFrame", "OrigNumFrames")
                  if source.parameters.get(k)]
        if fields:
            lost.append(f"TRC header fields {', '.join(fields)}")
    if kind == "c3d" and filled is not None and source is not None and source.format == "c3d":
        from .c3d_layout import stored_scale

        step = stored_scale(path)  # the output's: 16-bit integers where the input's were and every value fitted
        if step is not None and step > 0:
            notes.append(f"{path}: samples stored as 16-bit integers in steps of {step:.4g} {markers.units}, as "
                         f"{inp if inp is not None else 'the input'} stores them: a sample the cleaning changed or "
                         f"filled is rounded to the nearest step ({step / 2:.2g} {markers.units} at most), every "
                         "other one is the input's own number")
    if kind == "c3d" and markers.units_from != "file" and not _is_input(path, inp):  # OUT the input: nothing added
        notes.append(_stated_unit_note(markers, path, inp))
    if kind == "c3d" and (source is None or source.format != "c3d"):
        note = _float32_note(markers, path, inp)
        if note:
            notes.append(note)
    if kind == "trc":
        from .trc import trc_notes

        notes += trc_notes(markers, path, keep_modelled=keep_modelled, filled=filled, record=record)
    unread = unread_note(path, inp)
    if unread:
        notes.append(unread)
    if lost:
        what = ", ".join(lost[:-1]) + (" and " if len(lost) > 1 else "") + lost[-1]
        fmt = {"trc": "TRC", "npz": "a marker npz", "c3d": "C3D"}[kind]
        keep = {"c3d": "a .c3d output keeps them", "trc": "a .trc output keeps them"}[source.format] \
            if source is not None and source.format in ("c3d", "trc") else ""
        notes.append(f"{path}: not written, as {fmt} cannot hold them: the input's {what}"
                     + (f" ({keep})" if keep else ""))
    return notes


def _is_input(path, inp) -> bool:
    """Whether the file written at ``path`` is the input ``inp``'s bytes (a marker cleaning that changed no sample
    gives the input file back: :func:`mocapkit.marker_files.the_input`)."""
    import filecmp

    try:
        return inp is not None and filecmp.cmp(inp, path, shallow=False)
    except OSError:
        return False


def _stated_unit_note(markers: MarkerSet, path: Path, inp) -> str:
    """The line saying that a C3D at ``path`` states the length unit ``markers`` were read in (POINT:UNITS),
    where ``inp`` stated none (``markers.units_from`` "given" or "data": :func:`~mocapkit.markerset.marker_units`).

    The unit is written rather than left out because writing it loses nothing and leaving it out would: a unit
    given with --unit would be lost, and every later reader would guess again (C3D readers commonly assume mm;
    mocapkit infers it from the marker distances), while the take's coordinates are in the unit written. The
    line says so, that the parameter the output gains is seen and explained, not added silently."""
    why = "given with --unit" if markers.units_from == "given" else "inferred from the marker distances; --unit sets it"
    return (f"{path}: POINT:UNITS {markers.units} written, the unit the take was read in ({why}); "
            f"{inp if inp is not None else 'the input'} states no length unit")


def _float32_note(markers: MarkerSet, path: Path, inp) -> str | None:
    """The line saying how many coordinates of ``markers`` a C3D at ``path`` rounds: a C3D stores them as 32-bit
    floats (the data block of a float file: "The C3D File Format User Guide", c3d.org), and a TRC's text or an
    npz holds more digits (BTK's T.trc: 1639.63722 mm is stored as 1639.6372 mm, 5,521 of its 10,947 coordinates
    up to 6e-05 mm off). None where every coordinate is a 32-bit float already (a take read from a C3D)."""
    import numpy as np

    pos = np.asarray(markers.positions, dtype=np.float64)
    seen = np.isfinite(pos)
    with np.errstate(over="ignore"):
        off = np.abs(pos[seen].astype(np.float32).astype(np.float64) - pos[seen])
    rounded = int(np.count_nonzero(off))
    if not rounded:
        return None
    return (f"{path}: C3D stores coordinates as 32-bit floats: {rounded:,} of {off.size:,} coordinates of "
            f"{inp if inp is not None else 'the take'} are rounded to the nearest, up to {float(np.max(off)):.2g} "
            f"{markers.units} off (a .trc or .npz output keeps them)")


def motion_notes(motion, path, like=None) -> list[str]:
    """What a command tells its user when it writes ``motion`` to ``path`` with :func:`save`'s ``like``: one line
    each, naming ``path``. A take read from a BVH file with other ROOTs (a prop, a camera:
    :mod:`mocapkit.io.bvh_roots`) keeps them only in a BVH written like that file
    (:func:`mocapkit.io.bvh.source_fits`); any other output leaves them out, and the line says which. So do its
    ``#`` comment lines (:mod:`mocapkit.io.bvh_comments`): a line says how many the output leaves out. An .npz
    that keeps the BVH's text (the take on its joints, channels and frames: :mod:`mocapkit.io.kept_channels`)
    leaves out neither: a BVH written from it has them."""
    from .bvh import dropped_comments, source_fits, source_kept
    from .bvh_comments import comment_lines
    from .bvh_roots import left_out_note
    from .sources import recall

    path = Path(path)
    kind = suffix_kind(path, WRITERS, "writing")
    bvh, text = kind == "bvh", False
    if like is False:
        like, carried = motion.source_file, False
    else:
        like = like if like is not None else motion.source_file
        carried = bvh and like is not None and source_fits(motion, like)
        text = kind == "npz" and like is not None and Path(like).suffix.lower() == ".bvh" and \
            source_kept(motion, like)[4] is not None
    note = left_out_note(motion, path, like, carried or text)
    notes = [note] if note else []
    if like is not None and Path(like).suffix.lower() == ".bvh" and not text:
        if carried:
            n, why = dropped_comments(motion, like), "their places in the take's hierarchy written anew are not known"
            if motion.source_frames:  # a slice of the file's frames (Motion.source_frames)
                why = "a slice keeps the header's and those among its own frames"
        else:
            data = recall(Path(like))
            n = comment_lines(data) if data is not None else 0
            why = ("a .bvh keeps them only when written like its source, at its frames, rate and skeleton" if bvh
                   else f"{path.suffix[1:].upper() or 'this format'} holds no comments")
            if n and suffix_kind(path, WRITERS, "writing") == "npz":  # an .npz keeps the header's and the motion's
                n -= _npz_kept_comments(motion, like)
                why = "an .npz keeps them only at the take's frames, rate and skeleton"
        if n:
            notes.append(f"{path}: not written: {plural(n, 'comment line')} of {like} ({why})")
    amc = _amc_dropped_comments(motion, path, kind, like)
    unread = unread_note(path, like if like not in (None, False) else motion.source_file)
    unit = unit_note(motion, path)
    return notes + ([amc] if amc else []) + ([unread] if unread else []) + ([unit] if unit else [])


def unit_note(motion, path) -> str | None:
    """The line saying that the BVH ``path`` leaves out ``motion``'s stated length unit (``skeleton.unit_cm``: an
    ASF's ``:units length``, HDM05's 5.644 cm, or a ``--unit`` given), or None: a BVH has no field for it, so a
    reader of the file guesses it from the bones, assuming an adult (:func:`mocapkit.motion.unit_scale_cm`). An
    AMC is read with the ASF stating it, an .npz keeps it."""
    cm = getattr(motion.skeleton, "unit_cm", None)
    if cm is None or suffix_kind(Path(path), WRITERS, "writing") != "bvh":
        return None
    asf = motion.skeleton.source_file
    return (f"{path}: not written: the length unit, {float(cm):.4g} cm{f' (stated by {asf})' if asf else ''}: a BVH "
            "has no field for it, a reader guesses it from the bones (an .npz keeps it)")


def unread_note(path, inp) -> str | None:
    """The line saying that ``path`` leaves out the arrays of the npz ``inp`` that mocapkit does not read
    (:func:`mocapkit.io.npz.unread_arrays`: a user's own, a reconstruction's description), or None: the take
    is read from the format's arrays alone, and an output of any format is written from the take."""
    if inp is None or Path(inp).suffix.lower() != ".npz":
        return None
    from .npz import unread_arrays

    names = unread_arrays(inp)
    if not names:
        return None
    shown = ", ".join(names[:8]) + (f" and {len(names) - 8} more" if len(names) > 8 else "")
    return (f"{path}: not written: {plural(len(names), 'array')} of {inp} that mocapkit "
            f"does not read ({shown})")


def _amc_dropped_comments(motion, path: Path, kind: str, like) -> str | None:
    """The line saying that ``path`` leaves out the comment lines of the AMC ``motion`` was read from (``like``:
    that AMC, or an .npz keeping its text), or None. An AMC or .npz written like that AMC (the take on its
    skeleton and frames: :func:`mocapkit.io.amc_writer.source_numbers` gives its text) keeps them; any other
    output (a BVH, an AMC or .npz at another rate or frame count, a slice) does not, as for a BVH's comments."""
    from .amc_writer import kept_lines, source_numbers
    from .asfamc import amc_comment_lines
    from .kept_channels import kept_text
    from .sources import recall

    if like is None or like is False or Path(like).suffix.lower() not in (".amc", ".npz"):
        return None
    try:
        data = recall(Path(like)) if Path(like).suffix.lower() == ".amc" else kept_text(like, ".amc")
        n = amc_comment_lines(data) if data is not None else 0
        if n and kind in ("amc", "npz") and motion.skeleton.axes is not None:
            n = 0 if source_numbers(motion, like, with_text=True)[2] is not None else n
        if n and kind == "amc":  # written like it, a slice of its frames: its header's and those frames' kept
            kept = kept_lines(motion, like)
            n -= 0 if kept is None else amc_comment_lines(kept.encode("latin-1"))
    except MocapError:
        return None
    if not n:
        return None
    return (f"{path}: not written: {plural(n, 'comment line')} of {like} (an AMC's are kept only in an "
            ".amc or .npz written like it, at its frames and skeleton)")


def _npz_kept_comments(motion, like) -> int:
    """How many comment lines of the BVH ``like`` an .npz of ``motion`` keeps (:mod:`mocapkit.io.kept_channels`):
    those of its header where the .npz keeps the header's text (the take at the file's skeleton, rate and frame
    count), and those between its motion lines where it keeps the file's numbers (its joints, channels and frame
    count): :func:`mocapkit.io.bvh.source_kept`."""
    from .bvh import source_kept
    from .bvh_comments import comment_lines

    values, _, header, between, _ = source_kept(motion, like)
    if values is None:
        return 0
    return (comment_lines(header.encode()) if header else 0) + sum(len(b) for b in between or ())


def save(motion, path, like=None, asf=None, overwrite: bool | None = None, copy_asf: bool = True, **kwargs) -> Path:
    """Write ``motion`` to ``path`` (.bvh, .amc or .npz) atomically; returns the path.

    ``overwrite``: by default (None), as Python's ``open(path, "w")`` does, the file ``path`` names is
    replaced when it exists (the file the take was read from too), and no other file is: an ASF beside an
    AMC output that differs from the take's skeleton is refused (see below). ``overwrite=False`` refuses an
    existing ``path`` too (:class:`~mocapkit.errors.MocapFormatError`), as the command line does without
    ``--overwrite``; ``overwrite=True`` also replaces that ASF, as ``--overwrite`` does. The companion ASF
    is replaced only on that explicit request because the call names the AMC, not the ASF: a user's edited
    skeleton beside the output is never lost to a default.

    ``like``: the file ``motion`` was read from; by default ``motion.source_file``, which the readers set
    and every operation keeps (a cleaned take's too), so ``save(mocapkit.clean(path).motion, out)`` keeps
    the input's text as ``mocapkit clean`` does; ``False`` writes the file whole. A BVH written from a
    BVH, or an AMC from an AMC, keeps that file's text wherever the motion did not change (see
    :func:`mocapkit.io.bvh.write_bvh` and :func:`mocapkit.io.amc_writer.write_amc`), so an untouched take
    comes back the same file, and a contiguous slice of it (``take[100:200]``: ``Motion.source_frames``) the
    file's lines of those frames; a concatenation, a resampled or a strided take is written whole. Other pairs
    of formats ignore it. What the output leaves out of the take (a BVH: the length unit an ASF states, comment
    lines, other roots) is not warned of here: :func:`motion_notes` gives those lines, as the commands print
    them. When that file was changed or removed
    since the take was read and its text is no longer kept (:mod:`mocapkit.io.sources`), the save is
    refused in one line (``like=False`` writes it whole).

    An AMC is written only for a take on an ASF skeleton (read with the same ASF); ``asf``, that ASF
    (by default ``motion.skeleton.source_file``, the one it was read with), sets the order of the
    root's numbers (other formats ignore it). An AMC holds no skeleton and is read with the ASF beside
    it, so with ``copy_asf`` that ASF is copied beside ``path`` first where the folder lacks it (under
    its own name when it prefixes the AMC's, else the AMC's stem + ``.asf``:
    :func:`mocapkit.io.takes.asf_for_output`), as the command line does; an ASF of that name with
    other contents is replaced only with ``overwrite=True`` and where no other AMC in the folder is read
    with it (else refused). A take whose skeleton's ASF is not known (one read from
    .npz) is read back with ``load(path, asf=...)``. A :class:`~mocapkit.markerset.MarkerSet` is
    written by :func:`save_markers` (.c3d, .trc, .npz; ``like`` as there).

    A BVH holds a joint declaring one or two rotation channels (a hinge's ``CHANNELS 1 Xrotation``), an AMC a bone
    with fewer than three ASF dofs (CMU's and HDM05's ``dof rx`` tibia), only by its angles about those axes: where
    ``motion`` turns such a joint about another axis too (``mocapkit.clean``'s result, which does not know the
    output's format), the file drops that part and a :class:`UserWarning` says
    how many rotations and how much at most (:func:`mocapkit.io.euler_branches.off_axis_note`);
    :func:`mocapkit.io.euler_branches.bvh_written` puts the changed ones on the axes first, as the commands do.
    """
    from ..motion import Motion

    path = Path(check_file_path(path))  # "x.bvh/" names a folder: refused, not written as x.bvh
    if like is not None and like is not False and not isinstance(like, (str, os.PathLike, MarkerSet)):
        raise TypeError(f"like must be a path, False or None, got {type(like).__name__}")
    if overwrite is False and (path.exists() or path.is_symlink()):
        raise MocapFormatError(path, "already exists; pass overwrite=True to replace it")
    if isinstance(motion, MarkerSet):
        return save_markers(motion, path, like=like or None, overwrite=True)  # path: checked above
    if not isinstance(motion, Motion):
        raise TypeError(f"save takes a Motion or a MarkerSet, got {type(motion).__name__}")
    kind = suffix_kind(path, WRITERS, "writing")
    if like is None:
        like = motion.source_file
    like = like or None
    if kind == "bvh":
        from .bvh import write_bvh
        from .euler_branches import off_axis_note

        write_bvh(motion, path, like=like, **kwargs)
        lost = off_axis_note(motion, path)  # a hinge's rotation about other axes: a BVH cannot hold it, said
        if lost:
            warnings.warn(lost, UserWarning, stacklevel=2)
    elif kind == "amc":
        from .amc_writer import check_amc_writable, write_amc
        from .euler_branches import off_axis_note
        from .outputs import removed_on_failure
        from .takes import asf_for_output, place_asf

        asf = asf if asf is not None else motion.skeleton.source_file
        check_amc_writable(motion, path)  # before the ASF is copied
        copy = asf_for_output(path, asf, overwrite is True) if copy_asf and asf is not None and Path(asf).is_file() else None
        with removed_on_failure([copy]):
            place_asf(copy, asf)  # first: an AMC is never left without the ASF it is read with
            write_amc(motion, path, like=like, asf=asf, **kwargs)
        lost = off_axis_note(motion, path, asf, like)  # a bone of fewer dofs turned about others: dropped, said
        if lost:
            warnings.warn(lost, UserWarning, stacklevel=2)
    else:
        from .bvh import source_kept
        from .kept_channels import kept_arrays, kept_header
        from .npz import write_npz

        # a BVH's or AMC's own numbers (or those an .npz made from one keeps), for a file written from this .npz
        # later; none where that file's text is gone (removed or changed since it was read): the .npz is the take
        # all the same
        try:
            if like is not None:
                values, channels, header, comments, text = source_kept(motion, like)
                kept = kept_arrays(values, channels, header=header or kept_header(like, motion), comments=comments,
                                   text=None if text is None else (".bvh", text))
            else:
                kept = {}
            if not kept and like is not None:  # an AMC's own numbers (or those an .npz made from one keeps)
                from .amc_writer import source_numbers

                numbers, dofs, text = source_numbers(motion, like, asf, with_text=True)
                kept = kept_arrays(numbers, dofs, text=None if text is None else (".amc", text))
        except MocapFormatError:
            kept = {}
        write_npz(motion, path, **({"extra": {**kept, **kwargs.pop("extra", {})}} if kept else {}), **kwargs)
    from .sources import forget

    forget(path)  # a file read earlier and now written over: what was read of it is no longer its text
    return path


def check_writable(motion, path) -> None:
    """Raise :class:`~mocapkit.errors.MocapFormatError` when ``path``'s format cannot hold ``motion`` at all.

    Called before a command's work, so that a take is refused before it is
    cleaned, not after: an unknown suffix, or an AMC for a take that has no ASF
    skeleton (:func:`mocapkit.io.amc_writer.check_amc_writable`; missing values
    are left to the writer, since the work may fill them).
    """
    path = Path(path)
    if suffix_kind(path, WRITERS, "writing") == "amc":
        from .amc_writer import check_amc_writable

        check_amc_writable(motion, path, missing_ok=True)


def check_complete(motion, path, what: str, hint: str) -> None:
    """Raise :class:`~mocapkit.errors.MocapFormatError` (``what, which BVH cannot hold; hint``) when ``path`` is
    a BVH or AMC file and ``motion`` still has missing values (NaN rotations): those formats have no way to
    say a sample is missing, and the writer would refuse it only after the work. ``what`` names the cause
    ("the cleaned take still has missing joints (NaN)"), ``hint`` the way out ("write .npz")."""
    import numpy as np

    path = Path(path)
    if path.suffix.lower() in (".bvh", ".amc") and np.isnan(motion.rotations).any():
        raise MocapFormatError(path, f"{what}, which {path.suffix[1:].upper()} cannot hold; {hint}")


def _final_mode(path: Path) -> int:
    try:
        return stat.S_IMODE(path.stat().st_mode)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


@contextmanager
@whole_hand_over
def atomic_write(path, mode: str = "w", **open_kwargs):
    """Open a temporary file beside ``path`` for writing and rename it over ``path`` on success.

    On any exception (KeyboardInterrupt included) the temporary file is removed,
    ``path`` is untouched, and the folders made for it are removed again when
    left empty. The file gets the permissions an ordinary
    ``open(path, "w")`` would give it (those of the file it replaces, else
    0o666 less the umask), not the temporary file's private 0o600.
    """
    path = Path(check_file_path(path))
    made = missing_folders([path.absolute().parent])
    tmp = fh = None
    try:
        # made, named and opened as one, interrupts held: one that landed in mkstemp once the file was made left
        # it behind, unnamed; now it waits for this block, then lands here, where the file is known and removed
        with interrupts_held():
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=temp_prefix(path.name), suffix=".part", dir=path.parent)
            fh = os.fdopen(fd, mode, **open_kwargs)
    except BaseException as exc:
        if tmp is not None:
            _close_quietly(fh, fd)
            _discard(tmp)
        _remove_empty(made)
        if isinstance(exc, OSError):  # a read-only or full file system: the temporary file named as the user gave OUT
            named_as_given(exc, path)
        raise
    try:
        with fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, _final_mode(path))
        publish(tmp, path)  # a rename; a link where the file must still be new (outputs.removed_on_failure)
    except OSError as exc:
        if exc.filename is None:  # a write or fsync failed (a full disk): the error names the output
            exc.filename = str(path)
        named_as_given(exc, path)
        _discard(tmp)
        _remove_empty(made)
        raise
    except BaseException:
        _discard(tmp)
        _remove_empty(made)
        raise


def _close_quietly(fh, fd: int) -> None:
    """Close the temporary file: ``fh`` where it was opened, else the descriptor (which a failed ``fdopen`` may have
    closed already)."""
    try:
        fh.close() if fh is not None else os.close(fd)
    except OSError:
        pass


def _discard(tmp: str) -> None:
    try:
        os.unlink(tmp)
    except FileNotFoundError:
        pass


def _remove_empty(folders: list[Path]) -> None:
    """Remove the folders a failed write made (deepest first), each only when nothing else was put there."""
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:  # not empty, or already gone
            pass
