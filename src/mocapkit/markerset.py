"""Optical marker trajectories: the :class:`MarkerSet` container every marker reader returns.

A MarkerSet holds labelled 3D trajectories, frames first (F, M, 3), NaN where a
marker was not seen, with the per-sample residuals the capture system stated
and the file metadata (:class:`MarkerSource`) a writer needs to write a
cleaned take back in the form it came in (every C3D parameter group and analog
channel kept). Readers live in :mod:`mocapkit.io` (C3D, TRC, npz).

Gaps stored as exact zeros: some exporters (Qualisys among them) write an
unseen marker as the sample (0, 0, 0) with a non-negative residual instead of
flagging it (C3D: residual -1; TRC: empty fields). :func:`zero_gap_mask` finds
those samples from the data, so that readers can turn them into gaps.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from .motion import check_fps, frame_slice, frozen
from .words import plural

__all__ = ["MarkerSet", "MarkerSource", "marker_counts", "length_unit_cm", "unit_symbol", "zero_gap_mask", "unique_labels", "repeated_labels_note",
           "subject_of",
           "infer_units", "marker_units", "check_units", "UNIT_MISMATCH_FACTOR", "ZERO_GAP_DISTANCE_CM", "BODY_SPAN_M",
           "MODELLED_GROUPS"]

# Vicon writes modelled quantities (joint angles, forces, moments, powers) as
# C3D points and lists them in these POINT parameters; they are not markers.
MODELLED_GROUPS = ("ANGLES", "FORCES", "MOMENTS", "POWERS", "SCALARS", "REACTIONS")

# Length units as files state them (lower case, stripped). C3D's POINT:UNITS is
# a 4-character field in many writers, so metres arrive as "mete" (c3d.org FP1.C3D).
_UNIT_CM = {
    "mm": 0.1, "millimeter": 0.1, "millimeters": 0.1, "millimetre": 0.1, "millimetres": 0.1, "mill": 0.1,
    "cm": 1.0, "centimeter": 1.0, "centimeters": 1.0, "centimetre": 1.0, "centimetres": 1.0, "cent": 1.0,
    "dm": 10.0, "decimeter": 10.0, "decimeters": 10.0, "decimetre": 10.0, "decimetres": 10.0,
    "m": 100.0, "meter": 100.0, "meters": 100.0, "metre": 100.0, "metres": 100.0, "mete": 100.0, "metr": 100.0,
    "in": 2.54, "inch": 2.54, "inches": 2.54, "ft": 30.48, "foot": 30.48, "feet": 30.48,
}

BODY_SPAN_M = (0.3, 3.0)
"""The span of a whole body's marker set, in metres: the 90th percentile of a frame's distances between the markers
seen, taken at its median over the take. Real whole-body captures span 0.37-1.7 m (tests/test_markerset.py checks
every marker file of the shared data); a file that states no unit is read in mm or m, whichever puts its span in
this range (:func:`infer_units`). The lower end keeps centimetres out: an adult in cm spans about 120 units, which
read as mm would be a 12 cm body; a capture of one body part (a knee's markers span 0.1 m) is asked for its unit.
"""

# A real marker trajectory that is interrupted by an exact (0, 0, 0) sample
# jumps there from at least this far away: the lab origin is not a place a
# marker teleports to and from.
ZERO_GAP_DISTANCE_CM = 10.0


_COM_WORDS = re.compile(r"cent(re|er)of(the)?mass")
_COM_ACRONYM = re.compile(r"(?<![A-Z])(COM|CoM)(?![a-z]|[A-Z](?![a-z]))|(?<![A-Za-z])com(?![a-z])")


def _names_centre_of_mass(label: str) -> bool:
    """Whether a point's label names a centre of mass: "centre/center of (the) mass" in any case, spacing or
    punctuation (``CentreOfMass``, ``Centre_of_Mass``, ``Male:center of mass floor``), or the acronym as a word
    of its own (``COM``, ``CoM``, ``BodyCOM``, ``CoM_Floor``, ``com``; not ``Compass``, ``COMB`` nor ``LCOMP``)."""
    return bool(_COM_WORDS.search(re.sub(r"[^a-z]", "", label.lower())) or _COM_ACRONYM.search(label))


def unique_labels(raw, m: int) -> tuple[str, ...]:
    """Names for ``m`` markers from a file's labels ``raw``: stripped, unique, one per marker.

    A marker the file names with an empty label or does not name at all is
    M001, M002, ... by its 1-based place in the file (a stable name: the same
    file always gives the same one); a label a file repeats (legal in C3D and
    TRC) gets _2, _3, ... on its second, third use, so that every marker can
    be addressed by name in memory. Writers put the file's own labels back
    (:meth:`MarkerSet.file_labels`).
    """
    raw = [str(s).strip() for s in list(raw)[:m]]
    base = [label or f"M{k + 1:03d}" for k, label in enumerate(raw)] + [f"M{k + 1:03d}" for k in range(len(raw), m)]
    taken = set(base)
    counts: dict[str, int] = {}
    used: set[str] = set()
    out: list[str] = []
    for label in base:
        k = counts.get(label, 0) + 1
        name = label if k == 1 else f"{label}_{k}"
        while k > 1 and (name in used or name in taken):  # never a name the file gives another marker
            k += 1
            name = f"{label}_{k}"
        counts[label] = k
        used.add(name)
        out.append(name)
    return tuple(out)


def repeated_labels_note(file_labels, labels) -> tuple[str, ...]:
    """One note naming the labels a file repeats and what their repeats are called here; () for none.

    ``file_labels``: the file's labels (stripped), ``labels``: the names
    :func:`unique_labels` gave them. Readers put it in ``MarkerSet.notes``.
    """
    repeats = [(a, b) for a, b in zip(file_labels, labels) if a and a != b and a.strip() in labels]
    if not repeats:
        return ()
    names = list(dict.fromkeys(a for a, _ in repeats))
    shown = ", ".join(b for _, b in repeats[:8]) + (f" and {len(repeats) - 8} more" if len(repeats) > 8 else "")
    return (f"the file repeats marker label{'s' if len(names) > 1 else ''} {', '.join(names[:8])}"
            f"{' ...' if len(names) > 8 else ''}: the repeats are called {shown} here; files written from this "
            "take keep the file's labels",)


def subject_of(label: str) -> str:
    """The subject a marker label names: the text before its first ``:`` ("Alice" for "Alice:LTHI"), stripped; "" for none.

    Vicon Nexus and Qualisys prefix each marker of a multi-subject (or subject-and-prop) capture with its subject's
    name; cleaning treats each subject's markers as one body (:func:`mocapkit.cleaning.markers.gaps.nobody_seen`).
    """
    text = str(label)
    return text.split(":", 1)[0].strip() if ":" in text else ""


def length_unit_cm(units: str) -> float:
    """Centimetres per unit for a length unit as a file states it ("mm", "m", "mete", "inches", ...).

    Raises ValueError naming the unit when it is not a known length unit;
    readers turn that into a one-line :class:`~mocapkit.errors.MocapFormatError`.
    """
    key = str(units).strip().lower()
    try:
        return _UNIT_CM[key]
    except KeyError:
        known = "mm, cm, dm, m, in, ft (and their spelled-out forms)"
        raise ValueError(f"unknown length unit {str(units)!r}; known: {known}") from None


def unit_symbol(units: str) -> str:
    """The symbol of a length unit as a file states it: ``"mete"`` (a 4-character C3D field: c3d.org FP1.C3D),
    ``"metres"``, ``"M"`` -> ``"m"``; ``"millimeters"`` -> ``"mm"``; ``"inches"`` -> ``"in"``.

    What a TRC written new states in its Units field: OpenSim and Motion Analysis read the symbols, and a
    C3D's truncated ``"mete"`` copied into a TRC names no unit they know. Raises ValueError as
    :func:`length_unit_cm` for an unknown unit.
    """
    cm = length_unit_cm(units)
    return next(name for name in ("mm", "cm", "dm", "m", "in", "ft") if _UNIT_CM[name] == cm)


def infer_units(positions: np.ndarray) -> str | None:
    """The length unit, "mm" or "m", that puts a marker set's span in :data:`BODY_SPAN_M`; None when neither does.

    ``positions``: (F, M, 3), NaN where unseen (exact (0, 0, 0) samples are left out too: gaps some exporters
    write). The span is the 90th percentile of each frame's distances between the markers it sees, at its
    median over up to 64 frames spread over the take (a few stray trajectories do not move it). mm and m are
    1000 apart and the range is 10 wide, so at most one fits; cm (10 from each) is never inferred (a body in cm
    fits neither), nor is any unit of a take with no frame seeing two markers: the caller asks for it then.
    """
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 3 or pos.shape[0] == 0:
        return None
    spans = []
    for t in np.unique(np.linspace(0, pos.shape[0] - 1, min(pos.shape[0], 64)).astype(np.int64)):
        p = pos[t]
        p = p[np.all(np.isfinite(p), axis=1) & np.any(p != 0.0, axis=1)]
        if len(p) < 2:
            continue
        d = np.linalg.norm(p[:, None] - p[None], axis=-1)[np.triu_indices(len(p), 1)]
        spans.append(np.percentile(d, 90))
    if not spans:
        return None
    span = float(np.median(spans))
    for unit, metres in (("mm", 0.001), ("m", 1.0)):
        if BODY_SPAN_M[0] <= span * metres <= BODY_SPAN_M[1]:
            return unit
    return None


#: A stated unit this many times another that the marker distances fit is refused by :func:`check_units` (a
#: factor of 10, cm for mm, is one order of magnitude; mm and m differ by 1,000).
UNIT_MISMATCH_FACTOR = 10.0


def check_units(markers: "MarkerSet") -> None:
    """Refuse (:class:`~mocapkit.errors.MocapError`) marker positions whose stated unit is implausible by an order of
    magnitude or more: the marker distances fit a whole body in another unit (:func:`infer_units`, the readers'
    inference for a file that states none). Metres left at the default "mm" made a 60 mm spike 0.06 units, never
    seen; mm labelled "m" removed 4,705 good samples of a complete capture as spikes. A set whose distances fit
    neither mm nor m (one body part, a body in cm) is not judged, nor one whose unit was inferred so.
    """
    from .errors import MocapError

    if markers.units_from == "data":
        return
    found = infer_units(markers.positions)
    if found is None:
        return
    stated, fits = length_unit_cm(markers.units), length_unit_cm(found)
    if max(stated, fits) / min(stated, fits) >= UNIT_MISMATCH_FACTOR:
        ratio, size = max(stated, fits) / min(stated, fits), "smaller" if stated < fits else "larger"
        raise MocapError(f"{markers.name or 'the marker set'}: positions are said to be in {markers.units!r}, but their "
                         f"distances are a body's in {found!r} (read in {markers.units!r}, the body is {ratio:g} times "
                         f"{size} than a person); give units={found!r} (or convert the positions)")


def marker_units(path, stated: str, positions: np.ndarray, given: str | None = None) -> tuple[str, str]:
    """A marker file's length unit and where it comes from: ``(units, "file" | "given" | "data")``.

    ``stated``: the file's unit field ("" when it is empty); ``given``: the unit the user names (``--unit``,
    ``units=``), which serves a file that states none and must agree with one that does; else the unit is
    inferred from ``positions`` (:func:`infer_units`). Raises :class:`~mocapkit.errors.MocapFormatError`
    naming ``path`` for an unknown unit, a given one that disagrees with the file, or a file stating none whose
    data fits neither mm nor m.
    """
    from .errors import MocapFormatError

    stated = str(stated).strip()
    for text in (stated, given):
        if text:
            try:
                length_unit_cm(text)
            except ValueError as exc:
                raise MocapFormatError(path, f"{exc}; the file's coordinates cannot be put on a length scale") from None
    if stated:
        if given and length_unit_cm(given) != length_unit_cm(stated):
            raise MocapFormatError(path, f"the file states its unit is {stated!r}, not {given!r}: a unit is given "
                                         "only for a file that states none")
        return stated, "file"
    if given:
        return given, "given"
    found = infer_units(positions)
    if found is None:
        raise MocapFormatError(path, "the file states no length unit and its marker distances fit neither mm nor m; "
                                     "name it with --unit mm|cm|m|in (Python: units=)")
    return found, "data"


@dataclass(frozen=True, eq=False)
class MarkerSource:
    """What a marker file held besides the trajectories, kept so a writer can write it back.

    Attributes
    ----------
    format : str
        "c3d" or "trc": the format the take was read from.
    parameters : mapping
        C3D: the parameter section as ezc3d parses it (group -> parameter ->
        {"type", "description", "is_locked", "value"}, plus each group's
        "__METADATA__"). TRC: the header fields (name -> text). Read-only by
        convention; writers copy it.
    analogs : float array (A, F * ratio) or None
        C3D analog channels at the analog rate (``ratio`` samples per point
        frame), in the file's scaled units; None when the file has none.
    first_frame : int
        Number of the first frame in the file (C3D header, TRC Frame# column), 1-based: the file's own number
        of the take's first sample, on the clock of the file's frames (``layout``'s ``trial_rate``, else the
        take's rate), so that ``take[::2][75:200]`` is numbered as ``take[150:400:2]`` (Eb015pr.c3d's frame 151).
    labels : tuple of str
        The marker labels as the file states them, one per marker read, in
        file order (repeats and a TRC label's spaces included), so a writer
        can put them back where the markers are still the file's own.
    events : tuple of (float, str, int)
        C3D header events (time in seconds, the 4-character label, display
        flag), in the order the header lists them; () for none.
    text : str or None
        TRC: the file's text, so that a TRC writer keeps every cell, line and
        header field the take did not change; None otherwise (and for a part
        of the take: :meth:`MarkerSet.__getitem__`).
    layout : mapping of str to number (or bytes)
        C3D: header words a writer keeps as the file had them
        (:func:`mocapkit.io.c3d_layout.header_layout`: the interpolation gap,
        the data block's first block, the parameter section's block count;
        :func:`mocapkit.io.c3d_layout.spare_events`: the event slots no event
        uses, as bytes),
        and the whole file's first frame number, frame count and frame rate
        (``trial_first``, ``trial_frames``, ``trial_rate`` Hz: the clock of
        ``first_frame``, which a resampled take keeps; a part of the take keeps them, so
        that a writer keeps an event past the file's ends while the frames
        written reach that end: :func:`mocapkit.io.c3d_trial.event_kept`).
        A TRC or npz take has ``trial_rate`` alone once resampled (the first
        step :meth:`MarkerSet.__getitem__` takes, or an npz's
        ``first_frame_rate``); empty otherwise.
    stored_zeros : float array (F, M, 2) or None
        C3D: the residual (in the file's units, as :attr:`MarkerSet.residuals`)
        and camera mask the file stored with each sample it held as exact
        (0, 0, 0) and the reader read as a gap (:func:`zero_gap_mask`); NaN
        for every other sample; None when the reader read no such gap. A
        writer asked to (``clean``'s output) writes such a sample that is
        still missing back as the file had it.
    missing_stored : float array (K, 6) or None
        C3D: the samples the file marks missing (a negative fourth word) under
        which it stored coordinates other than (0, 0, 0), one row each: frame
        (0-based, in this take's frames), marker, x, y, z (the file's unit) and
        the stored word; None for none. Readers read such a sample as missing;
        a writer writes one still missing back as the file held it
        (:func:`mocapkit.io.c3d_frames.put_missing_stored`; ADemo1's integer
        copy holds 85).
    filled : bool array (F, M) or None
        npz: the file's ``filled`` mask, the samples it holds that are no
        recorded ones (a cleaning's fills, or samples a C3D marked as
        interpolated: :func:`mocapkit.io.npz.write_npz`); None otherwise.
    modelled : mapping of str to str
        TRC and npz: the points the file names as modelled, by label, each
        with its kind (a :data:`MODELLED_GROUPS` name in lower case, or
        "positions" for a modelled position), as mocapkit writes them
        (:meth:`MarkerSet.modelled_kinds`: a TRC's ``ModelledPoints`` header
        field, a marker npz's ``modelled`` array), since neither format has
        C3D's POINT groups nor its camera masks; empty otherwise.
    analog_numbers : float array (A, F * ratio) or None
        C3D float file: the float32 numbers the file stored for ``analogs``
        (before its offsets and scales: :func:`mocapkit.io.c3d_layout.held_analogs`),
        which a writer stores again wherever they still read as the sample; None
        otherwise (an integer file's whole numbers are found from the samples) and
        where they are not of ``analogs``' shape.
    """

    format: str
    parameters: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    analogs: np.ndarray | None = None
    first_frame: int = 1
    labels: tuple[str, ...] = ()
    events: tuple[tuple[float, str, int], ...] = ()
    text: str | None = None
    layout: Mapping[str, int] = dataclasses.field(default_factory=dict)
    stored_zeros: np.ndarray | None = None
    missing_stored: np.ndarray | None = None
    filled: np.ndarray | None = None
    modelled: Mapping[str, str] = dataclasses.field(default_factory=dict)
    analog_numbers: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))
        object.__setattr__(self, "modelled", MappingProxyType({str(k): str(v) for k, v in self.modelled.items()}))
        object.__setattr__(self, "layout", MappingProxyType(dict(self.layout)))
        object.__setattr__(self, "labels", tuple(str(s) for s in self.labels))
        object.__setattr__(self, "events", tuple((float(t), str(label), int(d)) for t, label, d in self.events))
        if self.analogs is not None:
            a = np.asarray(self.analogs, dtype=np.float64)
            if a.ndim != 2:
                raise ValueError(f"analogs: expected shape (A, N), got {a.shape}")
            object.__setattr__(self, "analogs", frozen(a))
        if self.analog_numbers is not None:  # numbers of other samples than ``analogs`` (replaced) say nothing
            held = np.asarray(self.analog_numbers, dtype=np.float64)
            keep = self.analogs is not None and held.shape == self.analogs.shape
            object.__setattr__(self, "analog_numbers", frozen(held) if keep else None)
        if self.stored_zeros is not None:
            z = np.asarray(self.stored_zeros, dtype=np.float64)
            if z.ndim != 3 or z.shape[2] != 2:
                raise ValueError(f"stored_zeros: expected shape (F, M, 2), got {z.shape}")
            object.__setattr__(self, "stored_zeros", frozen(z))
        if self.missing_stored is not None:
            rows = np.asarray(self.missing_stored, dtype=np.float64)
            if rows.ndim != 2 or rows.shape[1] != 6:
                raise ValueError(f"missing_stored: expected shape (K, 6), got {rows.shape}")
            object.__setattr__(self, "missing_stored", frozen(rows))
        if self.filled is not None:
            f = np.asarray(self.filled)
            if f.ndim != 2 or f.dtype != bool:
                raise ValueError(f"filled: expected a bool array (F, M), got {f.dtype} {f.shape}")
            object.__setattr__(self, "filled", frozen(f))

    def analog_ratio(self, num_frames: int) -> int:
        """Analog samples per point frame (0 without analogs)."""
        if self.analogs is None or self.analogs.shape[0] == 0 or num_frames == 0:
            return 0
        return self.analogs.shape[1] // num_frames


@dataclass(frozen=True, eq=False)
class MarkerSet:
    """Labelled marker trajectories.

    Attributes
    ----------
    labels : tuple of str, (M,)
    positions : float array (F, M, 3)
        Marker positions in ``units``; NaN where the marker was not seen.
    fps : float
        Point frame rate, frames per second.
    units : str
        Length unit as the file states it; see :func:`length_unit_cm` for the
        accepted spellings. For a file that states none, the one the user
        gave, else the one its data fits (:func:`marker_units`).
    name : str
    reader : str
        Which reader produced it: "ezc3d", "c3d" (the pure-Python fallback for
        quirky C3D files), "trc" or "npz".
    residuals : float array (F, M) or None
        The capture system's per-sample residual (>= 0 where seen; 0 means
        interpolated or filtered in C3D's convention) and -1 where missing.
        None when the file has none (TRC, npz); :meth:`residual_or_default`
        then gives 0 where seen.
    source : MarkerSource or None
        File metadata a writer keeps (C3D parameters and analogs, TRC header).
    zero_gaps : int or None
        How many samples the reader found stored as exact (0, 0, 0) gaps and
        read as missing (see :func:`zero_gap_mask`); 0 when none or when asked to keep them. A part of
        the take (:meth:`__getitem__`) and a choice of its markers (:meth:`select`) count their own where the
        reader kept where they were (a C3D's :attr:`MarkerSource.stored_zeros`); None where that cannot be
        known (a part of a TRC holding some: the reader keeps no place for them).
    cameras : int array (F, M) or None
        C3D camera masks: bit k (0-6) set where camera k saw the sample, as
        the file stores them; None when the file has none (TRC, npz).
    notes : tuple of str
        What the reader did that the user should know (labels a file repeats
        named apart, trajectories beyond the header's count read, frames a
        file skips inserted as missing); commands print them.
    units_from : str
        Where ``units`` comes from: "file" (stated there), "given" (by the
        user, for a file that states none) or "data" (inferred:
        :func:`infer_units`).
    """

    labels: tuple[str, ...]
    positions: np.ndarray
    fps: float
    units: str = "mm"
    name: str = ""
    reader: str = "ezc3d"
    residuals: np.ndarray | None = None
    source: MarkerSource | None = None
    zero_gaps: int | None = 0
    cameras: np.ndarray | None = None
    notes: tuple[str, ...] = ()
    units_from: str = "file"

    def __post_init__(self):
        if self.units_from not in ("file", "given", "data"):
            raise ValueError(f"units_from: 'file', 'given' or 'data', got {self.units_from!r}")
        try:
            length_unit_cm(self.units)
        except ValueError as exc:  # cleaning and writing need the scale: refused here, not at their first use
            from .errors import MocapError

            raise MocapError(f"units: {exc}") from None
        pos = np.asarray(self.positions, dtype=np.float64)
        labels = tuple(str(label) for label in self.labels)
        if pos.ndim != 3 or pos.shape[1:] != (len(labels), 3):
            raise ValueError(f"positions: expected shape (F, {len(labels)}, 3), got {pos.shape}")
        object.__setattr__(self, "positions", frozen(pos))
        object.__setattr__(self, "labels", labels)
        object.__setattr__(self, "fps", check_fps(self.fps))
        if self.residuals is not None:
            res = np.array(self.residuals, dtype=np.float64)
            if res.shape != pos.shape[:2]:
                raise ValueError(f"residuals: expected shape {pos.shape[:2]}, got {res.shape}")
            res[np.any(np.isnan(pos), axis=-1)] = -1.0
            res[np.isnan(res)] = -1.0
            object.__setattr__(self, "residuals", frozen(res))
        if self.cameras is not None:
            cams = np.array(self.cameras, dtype=np.int64)
            if cams.shape != pos.shape[:2]:
                raise ValueError(f"cameras: expected shape {pos.shape[:2]}, got {cams.shape}")
            object.__setattr__(self, "cameras", frozen(cams))
        object.__setattr__(self, "notes", tuple(str(n) for n in self.notes))

    @property
    def num_frames(self) -> int:
        return int(self.positions.shape[0])

    @property
    def num_markers(self) -> int:
        return len(self.labels)

    @property
    def unit_cm(self) -> float:
        """Centimetres per unit of ``positions`` (ValueError for a unit :func:`length_unit_cm` does not know)."""
        return length_unit_cm(self.units)

    def missing(self) -> np.ndarray:
        """Boolean (F, M) mask of samples where the marker was not seen."""
        return np.any(np.isnan(self.positions), axis=-1)

    def interpolated(self) -> np.ndarray:
        """Boolean (F, M) mask of the seen samples of markers that the file marks as interpolated.

        In C3D's convention a residual of 0 at a seen sample means "interpolated" (a capture
        program's fill, or a cleaned C3D's); it says so only in a file where some seen marker sample
        has a residual over 0 (a file of zeros throughout cannot tell). In a file that records
        camera masks (some seen marker sample has one), a sample whose mask names cameras was
        measured by them: its residual 0 is a residual under the file's resolution (its low byte
        counts steps of |POINT:SCALE|; the C3D User Guide, "3D point data"), not a fill. Vicon's
        FunctionalWalk.c3d stores residuals in 0.18 mm steps: 11,203 of its 11,215 seen samples
        of residual 0 have a mask (cameras 1, 2 and 7, ...), which 0.15.0 called interpolated; 12
        have none. Modelled points and unlabelled trajectories are left out: their residual 0 says
        nothing. All False without residuals (TRC, npz).
        """
        out = np.zeros(self.positions.shape[:2], dtype=bool)
        if self.residuals is None:
            return out
        cols = ~self.modelled() & ~self.unlabelled()
        seen = ~self.missing()[:, cols]
        r = np.asarray(self.residuals)[:, cols]
        if np.any(r[seen] > 0):
            out[:, cols] = seen & (r == 0)
            if self.cameras is not None:
                cams = np.asarray(self.cameras)[:, cols]
                if np.any(cams[seen] != 0):  # the file records which cameras saw a sample: one seen is measured
                    out[:, cols] &= cams == 0
        return out

    def modelled(self) -> np.ndarray:
        """Boolean (M,) mask of points that are modelled quantities, not markers.

        Vicon writes joint angles, forces, moments and powers as C3D points and
        lists their labels in POINT:ANGLES, FORCES, MOMENTS, POWERS, SCALARS and
        REACTIONS (:data:`MODELLED_GROUPS`); cleaning leaves them alone. A TRC
        or npz mocapkit wrote states them (:attr:`MarkerSource.modelled`).

        Modelled *positions* (Plug-in Gait's segment axes, centre of mass,
        joint centres) are listed nowhere; they are found as points no
        camera measured (:meth:`computed`).
        """
        return (self.quantities() != "") | self.computed()

    def quantities(self) -> np.ndarray:
        """(M,) str: for each point a C3D lists as a modelled quantity, its kind ("angles", "forces", "moments",
        "powers", "scalars", "reactions": the POINT group naming it, :data:`MODELLED_GROUPS`, lower case); "" for
        the others.

        These are no positions: their values are degrees, newtons, newton-millimetres, watts under the file's
        length unit, so a format that holds only markers in one unit (TRC) leaves them out
        (:func:`mocapkit.io.trc.write_trc`). Modelled positions (:meth:`computed`) are positions and are not
        among them. A TRC or npz mocapkit wrote names them too (:attr:`MarkerSource.modelled`); all "" for
        another TRC or npz.
        """
        kinds: dict[str, str] = {}
        named = self.source.modelled if self.source is not None else {}
        kinds.update((label, kind) for label, kind in named.items() if kind.upper() in MODELLED_GROUPS)
        point = self.source.parameters.get("POINT", {}) if self.source is not None else {}
        for key in MODELLED_GROUPS:
            param = point.get(key)
            if isinstance(param, Mapping) and param.get("type") == -1:
                for v in np.ravel(param.get("value", [])):
                    kinds.setdefault(str(v).strip(), key.lower())
        return np.array([kinds.get(label, "") for label in self.labels], dtype=object).astype(str)

    def modelled_kinds(self) -> np.ndarray:
        """(M,) str: each modelled point's kind (:meth:`quantities`' kind, else "positions" for a :meth:`computed`
        one), "" for a marker: what a TRC or npz written from this take states (:attr:`MarkerSource.modelled`), so
        that read back and cleaned, no modelled point is cleaned as a marker."""
        kinds = self.quantities()
        return np.where((kinds == "") & self.computed(), "positions", kinds).astype(str)

    def computed(self) -> np.ndarray:
        """Boolean (M,) mask of points a model computed rather than cameras measured.

        Three kinds of evidence, strongest first:

        - the file records camera masks (some sample of some point has a
          non-zero one) and this point has mask 0 and residual 0 at every
          seen sample: no camera ever saw it (FunctionalWalk's PELO,
          LTIA, ..., LeftHipCenterScore). Where no point has a camera mask
          (CMU, HDM05, Plug-in Gait exports) this says nothing;
        - the point is exact in a way no measured marker is: one coordinate
          exactly 0 at every seen sample while the others move and most
          points' is not (a floor projection: CentreOfMassFloor, z == 0), or one of four points
          ``<stem>O``, ``<stem>A``, ``<stem>L``, ``<stem>P`` where A, L and P
          are at every seen frame equally far from O (within 0.05 mm) in
          mutually perpendicular directions (cosines under 0.001): an axis
          triad (Plug-in Gait's segment axes HEDO/HEDA/HEDL/HEDP, LFEO, ...),
          which no four skin markers form; the four of one subject (the same
          ``Subject:`` prefix, :func:`subject_of`: in a two-subject file
          Alice:LFEO goes with Alice:LFEA, not Bob's);
        - the weaker clue of a name that says centre of mass, however spelt
          (:func:`_names_centre_of_mass`: Plug-in Gait's ``CentreOfMass``,
          ``Centre_of_Mass``, ``center of mass``, ``COM``, ``BodyCoM``,
          a subject's ``Sub_CentreOfMass``): a TRC lists no modelled points,
          so in a TRC written from a Plug-in Gait C3D (modelled positions are
          kept, :func:`mocapkit.io.trc.write_trc`) the name is what is left.

        A TRC or npz mocapkit wrote states them (kind "positions" in
        :attr:`MarkerSource.modelled`): the evidence above is lost there.
        """
        pos = np.asarray(self.positions, dtype=np.float64)
        m = pos.shape[1]
        seen = ~np.any(np.isnan(pos), axis=-1)
        out = np.zeros(m, dtype=bool)
        if self.cameras is not None and np.any(self.cameras[seen] != 0):
            res = self.residuals if self.residuals is not None else np.zeros(seen.shape)
            for i in range(m):
                s = seen[:, i]
                out[i] = bool(s.any() and np.all(self.cameras[s, i] == 0) and np.all(res[s, i] == 0))
        zero = np.all((pos == 0) | ~seen[..., None], axis=0)  # (M, 3): a coordinate 0 wherever seen
        moves = np.any(np.abs(np.diff(np.where(seen[..., None], pos, 0.0), axis=0)) > 0, axis=0)
        flat = (seen.sum(axis=0) >= 10) & np.any(moves & ~zero, axis=1)  # seen, and moving
        projected = flat & np.any(zero & (np.mean(zero[flat], axis=0) < 0.5), axis=1) if flat.any() else flat
        out |= projected  # a coordinate 0 that most points' is not (a planar capture's z == 0 everywhere is no clue)
        bare = [str(label).split(":")[-1].strip() for label in self.labels]
        who = [subject_of(label) for label in self.labels]  # a triad is one subject's: Alice's LFEO with her LFEA, ...
        where = {(w, b): i for i, (w, b) in enumerate(zip(who, bare))}
        try:
            unit_cm = self.unit_cm
        except ValueError:  # a unit length_unit_cm does not know: read as millimetres
            unit_cm = 0.1
        tol = 0.005 / max(unit_cm, 1e-12)  # 0.05 mm in the take's unit
        for i, (w, b) in enumerate(zip(who, bare)):
            if len(b) < 2 or not b.endswith("O") or not all((w, b[:-1] + k) in where for k in "ALP"):
                continue
            group = [i] + [where[(w, b[:-1] + k)] for k in "ALP"]
            both = np.all(seen[:, group], axis=1)
            if both.sum() < 10:
                continue
            v = pos[both][:, group[1:]] - pos[both][:, group[:1]]  # (T, 3 axes, 3)
            d = np.linalg.norm(v, axis=-1)
            if np.any(d <= tol):
                continue
            u = v / d[..., None]
            cos = np.abs(np.einsum("tai,tbi->tab", u, u)[:, [0, 0, 1], [1, 2, 2]])
            if np.all(np.ptp(d, axis=1) <= tol) and np.all(cos < 1e-3):
                out[group] = True
        out |= np.array([_names_centre_of_mass(str(label)) for label in self.labels], dtype=bool)
        named = self.source.modelled if self.source is not None else {}
        out |= np.array([named.get(label) == "positions" for label in self.labels], dtype=bool)
        return out

    def unlabelled(self) -> np.ndarray:
        """Boolean (M,) mask of unlabelled trajectories: points the capture system tracked but did not identify.

        A marker is unlabelled when the file gives it no label (a TRC column
        without one, an empty C3D label; read as M and its place:
        :func:`unique_labels`) or a label starting with ``*`` (Vicon's ``*0``,
        ``*1``, ...). C3D points past the end of POINT:LABELS are not: their
        reader names them by place in ``source.labels`` (c3d.org's PhaseSpace
        sample lists no labels; its active markers are told apart by their
        LEDs). Decided on the file's own labels (``source.labels``,
        each marker found by its name, so a :meth:`select` keeps it); a marker
        that is not the file's (no source, or a name the file does not give)
        by its own label. Such a trajectory is a point on the body while seen,
        but which one, and whether the same one each time it appears, is
        unknown: cleaning leaves it as read and uses it for nothing.
        """
        raw = self.source.labels if self.source is not None else ()
        own = dict(zip(unique_labels(raw, len(raw)), (str(s).strip() for s in raw)))
        texts = [own.get(label, label) for label in self.labels]
        return np.array([not text or text.startswith("*") for text in texts], dtype=bool)

    def residual_or_default(self) -> np.ndarray:
        """(F, M) residuals: the file's, or 0 where seen and -1 where missing when it had none."""
        if self.residuals is not None:
            return self.residuals
        return np.where(self.missing(), -1.0, 0.0)

    def with_positions(self, positions, residuals=None, sources=None) -> "MarkerSet":
        """A copy with new ``positions`` (F, M, 3) of the same shape, e.g. a cleaned take.

        ``sources`` (int array (F, M), optional): the marker column of this
        take each new sample was taken from, where a command moved samples
        between markers (an undone label swap); default: each its own.
        Residuals (unless given) and camera masks follow their samples, in
        C3D's convention: a sample equal to its source keeps the source's
        residual and cameras, a changed or newly filled sample gets residual 0
        ("interpolated") and camera mask 0 (no camera saw the value written
        there: a cleaner computed it), a sample now NaN gets -1. The labels,
        rate, units and :class:`MarkerSource` are kept, so writing the result
        with the same writer keeps the file's other contents.
        """
        new = np.asarray(positions, dtype=np.float64)
        if new.shape != self.positions.shape:
            raise ValueError(f"positions: expected shape {self.positions.shape}, got {new.shape}")
        rows = np.arange(self.num_frames)[:, None]
        cols = np.broadcast_to(np.arange(self.num_markers), new.shape[:2]) if sources is None else np.asarray(sources)
        if cols.shape != new.shape[:2]:
            raise ValueError(f"sources: expected shape {new.shape[:2]}, got {cols.shape}")
        old = self.positions[rows, cols]
        changed = np.any(~((new == old) | (np.isnan(new) & np.isnan(old))), axis=-1)
        if residuals is None and self.residuals is not None:
            residuals = np.where(changed, 0.0, self.residuals[rows, cols])
        cameras = None if self.cameras is None else np.where(changed, 0, self.cameras[rows, cols])
        return dataclasses.replace(self, positions=new, residuals=residuals, cameras=cameras)

    def select(self, labels) -> "MarkerSet":
        """The markers named in ``labels``, in that order.

        ``zero_gaps`` counts those of the chosen markers (:meth:`_own_zero_gaps`: a C3D's
        :attr:`MarkerSource.stored_zeros`, which is chosen with them); the whole take's count when every marker
        is chosen once; None for a choice of a TRC's markers holding some, as it cannot be known which of
        their missing samples they are."""
        idx = []
        for label in labels:
            if label not in self.labels:
                raise KeyError(f"no marker {label!r}; markers are: {', '.join(self.labels)}")
            idx.append(self.labels.index(label))
        res = None if self.residuals is None else self.residuals[:, idx]
        cams = None if self.cameras is None else self.cameras[:, idx]
        source = self.source
        stored = None if source is None else source.stored_zeros
        if stored is not None:
            stored = stored[:, idx] if stored.shape[1] == self.num_markers else None
        if source is not None:
            filled = None if source.filled is None else source.filled[:, idx]
            source = dataclasses.replace(source, filled=filled, stored_zeros=stored)
        whole = sorted(idx) == list(range(self.num_markers))
        return dataclasses.replace(self, labels=tuple(labels), positions=self.positions[:, idx], residuals=res,
                                   cameras=cams, source=source, zero_gaps=self._own_zero_gaps(stored, whole))

    def _own_zero_gaps(self, stored, whole: bool) -> int | None:
        """``zero_gaps`` of a part of this take (some frames: :meth:`__getitem__`; some markers: :meth:`select`):
        the whole take's count when ``whole`` (every sample kept once) or when it is 0; else the samples
        ``stored`` (the part's :attr:`MarkerSource.stored_zeros`, (F', M', 2), NaN but where a gap was stored
        as (0, 0, 0)) holds; None where the reader kept no such place (a TRC), as which of the part's missing
        samples were stored as zeros cannot be known."""
        if whole or not self.zero_gaps:
            return self.zero_gaps
        return None if stored is None else int((~np.isnan(stored)).any(axis=-1).sum())

    def file_labels(self) -> tuple[str, ...]:
        """The labels a writer writes: the file's own (repeats included) while the markers are the file's, else ``labels``.

        The markers are the file's own when the source lists one label per
        marker and naming them apart (:func:`unique_labels`) gives this
        take's labels, in order: then a label the file repeats (RKNE twice in
        BTK's Gait.c3d, read as RKNE and RKNE_2) is written as the file had it.
        """
        raw = self.source.labels if self.source is not None else ()
        if len(raw) == self.num_markers and unique_labels(raw, len(raw)) == self.labels:
            return raw
        return self.labels

    def __getitem__(self, key) -> "MarkerSet":
        """Frames by slice (a step ``k`` divides fps by ``k``; analogs are kept only without a step) or by a
        single index (one frame), as a Motion is sliced (:func:`mocapkit.motion.frame_slice`).

        ``zero_gaps`` counts those of the part's frames where the reader kept where they were (a C3D's
        :attr:`MarkerSource.stored_zeros`: :meth:`_own_zero_gaps`); a part of a take holding some that does not keep
        them (a TRC) says None, as it cannot be known which of its missing samples they are (the whole take keeps
        its count)."""
        key, fps = frame_slice(key, self.num_frames, self.fps, "markers")
        start, stop, step = key.indices(self.num_frames)
        stored = None if self.source is None or self.source.stored_zeros is None else self.source.stored_zeros[key]
        zero_gaps = self._own_zero_gaps(stored, (start, max(start, stop), step) == (0, self.num_frames, 1))
        res = None if self.residuals is None else self.residuals[key]
        cams = None if self.cameras is None else self.cameras[key]
        source = self.source
        if source is not None:
            ratio = source.analog_ratio(self.num_frames)
            analogs = numbers = None
            if ratio and step == 1:
                analogs = source.analogs[:, start * ratio : max(start, stop) * ratio]
                if source.analog_numbers is not None:
                    numbers = source.analog_numbers[:, start * ratio : max(start, stop) * ratio]
            whole = (start, max(start, stop), step) == (0, self.num_frames, 1)
            zeros = None if source.stored_zeros is None else source.stored_zeros[key]
            filled = None if source.filled is None else source.filled[key]
            rows = source.missing_stored
            if rows is not None:  # each row's frame renumbered in the part's frames; rows of frames left out dropped
                at = np.full(self.num_frames, -1)
                at[np.arange(self.num_frames)[key]] = np.arange(len(range(start, stop, step)))
                rows = np.array(rows)[rows[:, 0] < self.num_frames]
                rows[:, 0] = at[rows[:, 0].astype(np.int64)]
                rows = rows[rows[:, 0] >= 0]
            # the first frame kept, numbered on the clock of the file's frame numbers (layout's trial_rate, kept
            # from the first step taken): a frame of a take at a k-th of that rate is k of the file's frames
            clock = float(source.layout.get("trial_rate", self.fps))
            layout = source.layout if step == 1 else {**source.layout, "trial_rate": clock}
            first = source.first_frame + int(round(start * clock / float(self.fps)))
            source = dataclasses.replace(source, analogs=analogs, analog_numbers=numbers, first_frame=first, layout=layout,
                                         text=source.text if whole else None, stored_zeros=zeros, filled=filled,
                                         missing_stored=rows)
        return dataclasses.replace(self, positions=self.positions[key], fps=fps, residuals=res, source=source,
                                   cameras=cams, zero_gaps=zero_gaps)

    def __repr__(self) -> str:
        """Frames, rate, markers and their missing share counted as ``mocapkit info`` counts them
        (:func:`marker_counts`: a C3D's modelled quantities apart, their empty samples no marker's)."""
        markers, quantities, missing = marker_counts(self)
        also = f" (+{plural(quantities, 'modelled quantity', 'modelled quantities')})" if quantities else ""
        return (f"MarkerSet({self.name!r}, {plural(self.num_frames, 'frame')} @ {self.fps:g} fps, "
                f"{plural(markers, 'marker')}{also}, {100.0 * missing:.1f}% missing)")


def marker_counts(markers: MarkerSet) -> tuple[int, int, float]:
    """``(markers, modelled, missing)``: how many of ``markers``' points are markers (positions, measured or
    modelled) and how many are modelled quantities (a C3D's angles, forces, moments, powers:
    :meth:`MarkerSet.quantities`), and the share (0..1) of the markers' samples that are missing. A quantity's
    gaps are not marker samples missing, so they are not counted: the share is the one a .trc written from the
    file (which holds markers only) shows. 0.0 for a take of no marker. ``mocapkit info``, ``clean`` and
    :meth:`MarkerSet.__repr__` count by it."""
    quantity = markers.quantities() != ""
    kept = ~quantity
    missing = float(markers.missing()[:, kept].mean()) if kept.any() and markers.num_frames else 0.0
    return int(kept.sum()), int(quantity.sum()), missing


def zero_gap_mask(positions, unit_cm: float, skip=()) -> np.ndarray:
    """Boolean (F, M) mask of samples that are gaps stored as exact (0, 0, 0).

    Decided run by run: a run of samples of a marker at exactly (0, 0, 0) is a
    gap unless the marker's own observed samples right before and right after
    it (the one there is, at the take's start or end) all lie within
    :data:`ZERO_GAP_DISTANCE_CM` of the origin: a trajectory that really
    passes through the origin approaches it and leaves it gradually, while a
    tracked marker does not jump to the lab origin from 10 cm or more away,
    nor back. So one run next to a sample near the origin (a heel passing 5
    cm from it, then occluded) says nothing about the marker's other runs,
    and a run with one end near the origin and the other far is a gap too. A
    marker at (0, 0, 0) in every frame is a marker never seen. Markers whose
    index is in ``skip`` (e.g. a Vicon file's modelled angles and forces,
    listed in POINT:ANGLES, FORCES, MOMENTS, POWERS, SCALARS) are left alone.

    positions : (F, M, 3) in the file's units; unit_cm : centimetres per unit.
    """
    pos = np.asarray(positions, dtype=np.float64)
    zero = np.all(pos == 0.0, axis=-1)
    out = np.zeros(zero.shape, dtype=bool)
    if not zero.any():
        return out
    far = ZERO_GAP_DISTANCE_CM / float(unit_cm)
    with np.errstate(invalid="ignore"):  # hypot: no overflow on huge coordinates (NaN stays NaN)
        dist = np.hypot(np.hypot(pos[..., 0], pos[..., 1]), pos[..., 2])
    seen = ~np.any(np.isnan(pos), axis=-1) & ~zero
    skip = set(skip)
    for m in np.flatnonzero(zero.any(axis=0)):
        if m in skip:
            continue
        z = zero[:, m]
        edges = np.flatnonzero(np.diff(np.concatenate([[0], z.astype(np.int8), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):  # zero run [a, b)
            before = np.flatnonzero(seen[:a, m])
            after = np.flatnonzero(seen[b:, m])
            near = [dist[before[-1], m]] if len(before) else []
            near += [dist[b + after[0], m]] if len(after) else []
            if not near or any(d >= far for d in near):  # never seen, or a jump from or to 10 cm away: a gap
                out[a:b, m] = True
    return out
