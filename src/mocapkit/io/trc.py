"""TRC marker files (Motion Analysis "Track Row Column"; OpenSim, Cortex, MotionBuilder, BTK).

A TRC file is tab-separated text: a ``PathFileType 4 (X/Y/Z) NAME`` line, a
line of header names (DataRate, CameraRate, NumFrames, NumMarkers, Units,
OrigDataRate, OrigDataStartFrame, OrigNumFrames) and a line of their values,
a ``Frame#  Time  LABEL1 _ _ LABEL2 ...`` line (each label over its three
columns), an ``X1 Y1 Z1 X2 ...`` line, then one row per frame: frame number,
time in seconds, and X Y Z of each marker, with empty fields where a marker
was not seen. Format as Motion Analysis documents it and OpenSim's
``TRCFileAdapter`` reads it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import MocapFormatError, SkeletonError
from .outputs import check_file_path
from ..markerset import (MODELLED_GROUPS, MarkerSet, MarkerSource, marker_units, repeated_labels_note, unique_labels,
                         unit_symbol)
from ..motion import check_fps
from ..words import plural
from .c3d import apply_zero_gaps, checked_unit_cm
from .c3d_trial import trial_rate, written_first
from .sources import bom_length

__all__ = ["read_trc", "write_trc", "trc_notes", "TRC_DECIMALS", "MODELLED_KEY", "modelled_field"]

TRC_DECIMALS = 5  # coordinates written with 5 decimals (Cortex and OpenSim write 5)
_HEADER_KEYS = ("DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units",
                "OrigDataRate", "OrigDataStartFrame", "OrigNumFrames")


MODELLED_KEY = "ModelledPoints"
_KINDS = tuple(g.lower() for g in MODELLED_GROUPS) + ("positions",)


def modelled_field(kinds) -> str:
    """The ``ModelledPoints`` header value for the (M,) kinds of :meth:`MarkerSet.modelled_kinds` ("" for none).

    A TRC has no place for a C3D's POINT groups nor its camera masks, which
    tell a modelled point (an angle, a force, a centre of mass, a joint
    centre) from a marker: the header states them in one more field,
    ``KIND=N,N-N;KIND=...`` with 1-based marker numbers in file order (the
    ``X1 Y1 Z1`` numbering; no tab, as a header value may hold none, and no
    label, which may hold any character), so that read back and cleaned no
    modelled point is cleaned as a marker. OpenSim keeps a header field it
    does not know as metadata.
    """
    kinds = np.asarray(kinds, dtype=str)
    parts = []
    for kind in _KINDS:
        idx = np.flatnonzero(kinds == kind) + 1
        if idx.size:
            cut = np.flatnonzero(np.diff(idx) != 1) + 1
            runs = [(int(r[0]), int(r[-1])) for r in np.split(idx, cut)]
            parts.append(kind + "=" + ",".join(str(a) if a == b else f"{a}-{b}" for a, b in runs))
    return ";".join(parts)


def _read_modelled(path: Path, text: str, labels) -> dict[str, str]:
    """The ``ModelledPoints`` header value :func:`modelled_field` wrote, as ``{label: kind}``; refused in one line
    naming the file where it is not one."""
    out: dict[str, str] = {}
    for part in filter(None, (t.strip() for t in text.split(";"))):
        kind, _, numbers = part.partition("=")
        if kind.strip() not in _KINDS:
            raise MocapFormatError(path, f"header field {MODELLED_KEY}: unknown kind {kind.strip()[:40]!r} (kinds are "
                                   f"{', '.join(_KINDS)})", line=3)
        for run in numbers.split(","):
            a, _, b = run.strip().partition("-")
            try:
                lo, hi = int(a), int(b or a)
            except ValueError:
                raise MocapFormatError(path, f"header field {MODELLED_KEY}: {run.strip()[:40]!r} is not a marker "
                                       "number or range", line=3) from None
            if not 1 <= lo <= hi <= len(labels):
                raise MocapFormatError(path, f"header field {MODELLED_KEY}: markers {lo}-{hi} are out of the file's "
                                       f"1-{len(labels)}", line=3)
            out.update((labels[k - 1], kind.strip()) for k in range(lo, hi + 1))
    return out


def _fields(line: str) -> list[str]:
    return line.rstrip("\r\n").split("\t")


def read_trc(path, zeros_as_gaps: bool | None = None, units: str | None = None) -> MarkerSet:
    """Read a TRC file as a :class:`~mocapkit.markerset.MarkerSet` (empty fields become NaN).

    The frame rate is DataRate (CameraRate when DataRate is absent), the unit
    the Units field; where that is empty, ``units`` when given, else mm or m as
    the marker distances say (:func:`~mocapkit.markerset.marker_units`; the
    MarkerSet's ``units_from`` says which). Every trajectory the rows hold is read: the marker count
    is the largest of NumMarkers, the labels and the whole X Y Z triples of
    the widest row (fields past them are not coordinates). Labels come from
    the ``Frame#`` line, named apart in memory
    (:func:`~mocapkit.markerset.unique_labels`: a marker without one is
    M and its place, a repeat gets _2); the file's own are kept in
    ``source.labels`` (an empty text for a column without a label, past the
    label line's end too: :meth:`~mocapkit.markerset.MarkerSet.unlabelled`)
    and its text in ``source.text`` for :func:`write_trc`.
    A row with fewer fields than markers has the rest missing. The Time
    column places the rows when it steps by 1/DataRate (rows a frame apart
    are consecutive frames whatever their Frame#), else the Frame# column
    when it is whole numbers that increase, else the row order; a frame
    skipped is a frame with every marker missing (:func:`_frame_slots`).
    What the user should know (trajectories past NumMarkers or without a
    label, extra fields, skipped frames, a Frame# out of step, repeated
    labels) is in ``notes``. ``zeros_as_gaps`` as for
    :func:`~mocapkit.io.c3d.read_c3d` (some exporters write unseen markers as 0 0 0).

    Raises :class:`~mocapkit.errors.MocapFormatError` naming the file and line
    for a file that is not a TRC (first line), a header cut short, a missing
    or non-positive frame rate, an unknown unit, a field that is not a number,
    a frame number out of range, a time that goes back, repeats or is not a
    whole number of frames on, no data rows, or a file
    cut short (fewer frames than NumFrames, or a last row cut partway
    through: :func:`_check_complete`).
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
        text = raw[bom_length(raw):].decode("utf-8", errors="replace")  # a byte-order mark is not text
    except OSError as exc:
        raise MocapFormatError(path, f"cannot read: {exc.strerror or exc}") from None
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise MocapFormatError(path, "empty file: a TRC file starts with a PathFileType line")
    first = _fields(lines[0])
    if first[0].strip() != "PathFileType":
        raise MocapFormatError(path, f"not a TRC file: the first line starts with {first[0][:40]!r}, not 'PathFileType'", line=1)
    if len(lines) < 5:
        raise MocapFormatError(path, f"truncated TRC header: {plural(len(lines), 'line')}, the header needs 5 "
                               "(PathFileType, names, values, Frame#/labels, X1 Y1 Z1)", line=len(lines))
    keys = [k.strip() for k in _fields(lines[1])]
    values = [v.strip() for v in _fields(lines[2])]
    header = {k: (values[i] if i < len(values) else "") for i, k in enumerate(keys) if k}

    def number(key: str, default=None) -> float | None:
        raw = header.get(key, "")
        if not raw:
            return default
        try:
            return float(raw)
        except ValueError:
            raise MocapFormatError(path, f"header field {key} is {raw!r}, not a number", line=3) from None

    rate = number("DataRate", None)
    if rate is None:
        rate = number("CameraRate", None)
    if rate is None:
        raise MocapFormatError(path, "the header states no DataRate (nor CameraRate)", line=3)
    try:
        fps = check_fps(rate, "DataRate")
    except SkeletonError as exc:
        raise MocapFormatError(path, str(exc), line=3) from None
    stated_units = header.get("Units", "")
    if stated_units:
        checked_unit_cm(path, stated_units)  # an unknown unit is refused before the rows are read
    label_line = _fields(lines[3])
    if label_line[0].strip() != "Frame#":
        raise MocapFormatError(path, f"line 4 should start with 'Frame#', got {label_line[0][:40]!r}", line=4)
    label_text = [label_line[j] for j in range(2, len(label_line), 3)]  # as the file has them, spaces included
    while label_text and not label_text[-1].strip():
        label_text.pop()
    rows, numbers, times, row_lines = [], [], [], []  # numbers, times: the Frame# and Time texts
    last_fields = last_line = 0
    ends_in_row = not text.endswith(("\n", "\r"))  # no line break after the last line: cut there, or a writer's habit
    for n, line in enumerate(lines[5:], start=6):
        hint = " (the file ends in this row without a line break: cut short?)" if ends_in_row and n == len(lines) else ""
        if not line.strip():
            continue
        f = _fields(line)
        last_fields, last_line = len(f), n
        while f and not f[-1].strip():
            f.pop()
        if f[0].strip():  # an empty Frame# is read by its time (or place); any other text must be a frame number
            try:
                frame = float(f[0])
            except ValueError:
                raise MocapFormatError(path, f"frame number {f[0][:20]!r} is not a number{hint}", line=n) from None
            if not math.isfinite(frame):
                raise MocapFormatError(path, f"frame number {f[0][:20]!r} is not a number{hint}", line=n)
            if abs(frame) >= 2**31:
                raise MocapFormatError(path, f"frame number {f[0][:20]!r} is out of range{hint}", line=n)
        vals = np.full(len(f) - 2 if len(f) > 2 else 0, np.nan)
        for j, v in enumerate(f[2:]):
            v = v.strip()
            if v:
                try:
                    vals[j] = float(v)
                except ValueError:
                    raise MocapFormatError(path, f"field {j + 3} is {v[:20]!r}, not a number{hint}", line=n) from None
        if np.isinf(vals).any():
            raise MocapFormatError(path, f"infinite coordinate in field {int(np.flatnonzero(np.isinf(vals))[0]) + 3}", line=n)
        rows.append(vals)
        numbers.append(f[0])
        times.append(f[1] if len(f) > 1 else "")
        row_lines.append(n)
    if not rows:
        raise MocapFormatError(path, "the TRC file holds no data rows")
    stated = number("NumMarkers", 0) or 0
    if stated < 0 or stated != int(stated):
        raise MocapFormatError(path, f"header field NumMarkers is {header['NumMarkers']!r}, not a marker count", line=3)
    # Every trajectory the rows hold is read: NumMarkers, the labels, or the whole X Y Z triples of the
    # widest row, whichever is most (BTK and OpenSim read NumMarkers only: Gait.trc states 66, names 33
    # and its rows hold 105); a file stating 0 gets as many as its rows hold, by the same rule.
    held = max(len(r) // 3 for r in rows)
    present = max(held, len(label_text))
    if stated > present + 1000:
        raise MocapFormatError(path, f"header field NumMarkers says {int(stated)} markers, the file names and holds "
                               f"at most {present}", line=3)
    m = max(int(stated), present)
    slots, frame_notes, first_frame = _frame_slots(path, numbers, times, row_lines, fps)
    _check_complete(path, header, int(slots[-1]) + 1, last_fields - 2, m, last_line,
                    ends_in_row=ends_in_row and last_line == len(lines))
    data = np.full((int(slots[-1]) + 1, 3 * m), np.nan)
    for i, r in zip(slots, rows):
        data[i, : min(len(r), 3 * m)] = r[: 3 * m]
    xyz = data.reshape(data.shape[0], m, 3)
    xyz[np.any(np.isnan(xyz), axis=-1)] = np.nan  # a sample with one empty coordinate is not seen
    labels = unique_labels(label_text, m)
    file_labels = tuple(label_text) + ("",) * (m - len(label_text))  # a column past the labels has none
    units, units_from = marker_units(path, stated_units, xyz, units)
    zeros = apply_zero_gaps(labels, xyz, None, checked_unit_cm(path, units), zeros_as_gaps)
    notes = repeated_labels_note(tuple(t.strip() for t in file_labels), labels)
    notes += _count_notes(int(stated), len([t for t in label_text if t.strip()]), held, m, labels)
    notes += _frame_count_notes(header, len(rows))
    notes += _extra_field_notes(rows, row_lines, m)
    notes += frame_notes
    modelled = _read_modelled(path, header.get(MODELLED_KEY, ""), labels)
    source = MarkerSource(format="trc", parameters={"PathFileType": first[3].strip() if len(first) > 3 else "", **header},
                          first_frame=first_frame, labels=file_labels,
                          text=raw.decode("utf-8", errors="surrogateescape"), modelled=modelled)
    return MarkerSet(labels=labels, positions=xyz, fps=fps, units=units, name=path.stem, reader="trc",
                     source=source, zero_gaps=zeros, notes=notes, units_from=units_from)


# Frames a file may skip, inserted as missing samples: more than this many is refused as not a frame numbering.
_MAX_INSERTED = 100_000


def _number(text: str) -> float:
    """A Frame# or Time text as a number; NaN when it is empty or not a finite number."""
    try:
        value = float(text)
    except (ValueError, TypeError):
        return math.nan
    return value if math.isfinite(value) else math.nan


def _places(texts) -> int:
    """The most decimal places among number texts ``texts`` (``1.5e-05``: 6), what they resolve."""
    most = 0
    for t in texts:
        t = t.strip().lower()
        mantissa, _, exp = t.partition("e")
        places = len(mantissa.split(".", 1)[1]) if "." in mantissa else 0
        try:
            places -= int(exp) if exp else 0
        except ValueError:
            pass
        most = max(most, places)
    return min(most, 17)  # (a float holds no more)


def _first_frame(text: str) -> int:
    """The take's first frame number from the first row's Frame# text: 1 where it is not a whole number."""
    value = _number(text)
    return int(value) if value == value and value == int(value) else 1


def _frame_slots(path: Path, numbers: list[str], times: list[str], row_lines: list[int],
                 fps: float) -> tuple[np.ndarray, tuple[str, ...], int]:
    """Where each data row goes: ((rows,) int frame from 0, notes, the first frame number).

    The Time column decides when it can: when every row has a time, written
    finely enough to tell frames apart at DataRate, and at least half its
    steps are one frame (1/DataRate). Then rows one frame apart are
    consecutive frames whatever their Frame# says (a thinned export numbered
    by camera frame: 1, 3, 5 ...; a Frame# that repeats or restarts; a note
    says so and the Frame# text is written back as it was), and a step of
    k frames inserts k - 1 frames with every marker missing, so that every
    frame keeps its time (a cleaner fills them as gaps). A time that goes
    back or repeats, or a step that is not a whole number of frames, is
    refused naming its line. Without such a Time column, the Frame# column
    decides when it is whole numbers that increase (a skip inserts frames
    as above), and otherwise the rows are read in file order (a note says
    so). More than :data:`_MAX_INSERTED` inserted frames is refused.
    """
    nums = np.array([_number(t) for t in numbers])
    t = np.array([_number(x) for x in times])
    n = len(nums)
    first = _first_frame(numbers[0])
    whole = ~np.isnan(nums) & (nums == np.round(nums))
    resolution = 10.0 ** -_places(times) * fps  # frames a time written with those places may be off, a step 2x half
    tol = resolution + 0.05
    with np.errstate(over="ignore", invalid="ignore"):
        dt = np.diff(t)
        steps = dt * fps  # (inf for times 1e308 apart, refused below as too large a skip)
    time_why = ""
    if np.isnan(t).any():
        time_why = "has rows without a time"
    elif tol >= 0.5:
        time_why = f"is written too coarsely to tell frames apart at DataRate {fps:g}"
    elif n > 1 and 2 * int(np.sum(np.abs(steps - 1.0) <= tol)) < n - 1:
        typical = float(np.median(dt))
        time_why = f"does not step by 1/DataRate ({1 / fps:.6g} s; its steps are mostly {typical:.6g} s)"
    if not time_why:
        far = np.flatnonzero(~(steps <= _MAX_INSERTED + 1))
        if far.size:
            i = int(far[0]) + 1
            raise MocapFormatError(path, f"time {times[i].strip()[:20]} follows {times[i - 1].strip()[:20]}: a skip of "
                                   f"more than {_MAX_INSERTED} frames at DataRate {fps:g}", line=row_lines[i])
        k = np.rint(steps).astype(np.int64) if n > 1 else np.zeros(0, np.int64)
        bad = np.flatnonzero((k < 1) | (np.abs(steps - k) > tol))
        if bad.size:
            i = int(bad[0]) + 1
            was, now = times[i - 1].strip()[:20], times[i].strip()[:20]
            if k[i - 1] < 1:
                what = "repeats" if abs(steps[i - 1]) <= tol else "goes back"
                raise MocapFormatError(path, f"time {now} follows {was}: the Time column {what} (it must go forward "
                                       f"by whole frames of 1/DataRate)", line=row_lines[i])
            raise MocapFormatError(path, f"time {now} follows {was}: a step of {steps[i - 1]:.3g} frames at DataRate "
                                   f"{fps:g}, not a whole number of frames", line=row_lines[i])
        slots = np.concatenate([[0], np.cumsum(k)])
        agree = whole & (nums - nums[0] == slots) if whole[0] else np.zeros(n, bool)
        notes = ()
        if not agree.all():
            i = int(np.argmin(agree))
            said = (f"Frame# {numbers[i].strip() or '(empty)'} follows {numbers[i - 1].strip() or '(empty)'}" if i
                    else f"Frame# {numbers[0].strip() or '(empty)'} first")
            notes += (f"the Frame# column is not consecutive ({said}, line {row_lines[i]}) but the Time column steps "
                      "by 1/DataRate: the rows are placed by their time (Frame# kept as the file has it)",)
        notes += _skipped_frame_notes(slots, row_lines, numbers if agree.all() else None, times)
        return _checked_inserted(path, slots, row_lines), notes, first
    if whole.all() and (n == 1 or (np.diff(nums) > 0).all()):
        slots = (nums - nums[0]).astype(np.int64)
        notes = ()
        if time_why.startswith("does not step") and (np.abs(steps - np.diff(slots)) > tol).any():
            notes += (f"the Time column {time_why}: the rows are placed by their Frame#",)  # not where Frame# says
        notes += _skipped_frame_notes(slots, row_lines, numbers, None)
        return _checked_inserted(path, slots, row_lines), notes, first
    i = int(np.argmin(whole)) if not whole.all() else int(np.flatnonzero(np.diff(nums) <= 0)[0]) + 1
    said = (f"Frame# {numbers[i].strip() or '(empty)'}" + (f" follows {numbers[i - 1].strip() or '(empty)'}" if i else "")
            + f", line {row_lines[i]}")
    return np.arange(n), (f"the Frame# column is not whole numbers that increase ({said}) and the Time column "
                          f"{time_why}: the rows are read in file order as consecutive frames",), first


def _checked_inserted(path: Path, slots: np.ndarray, row_lines: list[int]) -> np.ndarray:
    """``slots``, refused naming the line of the largest skip when they insert more than :data:`_MAX_INSERTED` frames."""
    if int(slots[-1]) + 1 - len(slots) > _MAX_INSERTED:
        k = int(np.argmax(np.diff(slots))) + 1
        raise MocapFormatError(path, f"the frames skip {int(slots[-1]) + 1 - len(slots)} frames in all (the most at "
                               f"this line): more than the {_MAX_INSERTED} read as missing", line=row_lines[k])
    return slots


def _skipped_frame_notes(slots: np.ndarray, row_lines: list[int], numbers: list[str] | None,
                         times: list[str] | None) -> tuple[str, ...]:
    """One note naming the frames skipped (inserted as missing samples): by Frame# when ``numbers`` name
    them, else by time; () for none."""
    step = np.diff(slots)
    at = np.flatnonzero(step > 1)
    if at.size == 0:
        return ()
    total = int((step[at] - 1).sum())
    if numbers is not None:
        nums = [int(_number(x)) for x in numbers]
        runs = [f"{nums[k] + 1}" if step[k] == 2 else f"{nums[k] + 1}-{nums[k + 1] - 1}" for k in at[:5]]
        what = f"the Frame# column skips frame{'s' if total > 1 else ''}"
    else:
        runs = [f"{step[k] - 1} after {times[k].strip()[:20]} s" for k in at[:5]]
        what = f"the Time column skips frame{'s' if total > 1 else ''}:"
    more = f" and {at.size - 5} more runs" if at.size > 5 else ""
    return (f"{what} {', '.join(runs)}{more} (at line {row_lines[int(at[0]) + 1]}): read as {total} "
            f"frame{'s' if total > 1 else ''} with every marker missing, so every frame keeps its time",)


def _count_notes(stated: int, named: int, held: int, m: int, labels) -> tuple[str, ...]:
    """One note when the file holds trajectories its header does not count or its labels do not name."""
    said = []
    if stated and held > stated:
        said.append(f"the header states NumMarkers {stated}, the rows hold {held} trajectories: all {m} are read")
    unnamed = [label for k, label in enumerate(labels) if k >= named]
    if unnamed and (said or named):
        span = unnamed[0] if len(unnamed) == 1 else f"{unnamed[0]}-{unnamed[-1]}"
        said.append(f"{plural(len(unnamed), 'trajectory', 'trajectories')} without a label named {span} "
                    "(M and the marker's place in the file)")
    return ("; ".join(said),) if said else ()


def _frame_count_notes(header: dict, frames: int) -> tuple[str, ...]:
    """One note when the header's NumFrames is a whole count below the ``frames`` data rows the file holds (a take
    grown by hand, its header left): every row is read, and the user is told the header and the file disagree."""
    try:
        declared = float(header.get("NumFrames", "") or 0)
    except ValueError:
        return ()
    if not (math.isfinite(declared) and declared == int(declared) and 0 < declared < frames):
        return ()
    return (f"the header states NumFrames {int(declared)}, the file holds {frames} rows: all {frames} are read",)


def _extra_field_notes(rows, row_lines, m: int) -> tuple[str, ...]:
    """One note for rows holding fields past the last marker's X Y Z (not coordinates); () for none."""
    extra = [(k, r) for k, r in enumerate(rows) if len(r) > 3 * m and not np.all(np.isnan(r[3 * m:]))]
    if not extra:
        return ()
    k, r = extra[0]
    return (f"{plural(len(extra), 'row', 'rows')} hold fields past the last marker's X Y Z (line {row_lines[k]}: field "
            f"{3 * m + 3}, {r[3 * m]:g}): not coordinates, not read; a TRC written from this take keeps them",)


def _check_complete(path: Path, header: dict, frames: int, last_values: int, m: int, last_line: int,
                    ends_in_row: bool) -> None:
    """Refuse a TRC file cut short: fewer rows than NumFrames, or a last row cut partway through.

    A copy or download cut short otherwise reads as a shorter take (111 of
    SprintMotion.trc's 788 frames, its last row ending mid-number) that a
    command would then write out as if whole. ``ends_in_row``: the file ends
    on its last row (line ``last_line``) without a line break; there a row
    with fewer than the ``3 * m`` values its markers need is cut, not a row
    whose trailing markers are missing (those end with a line break: rows of
    BTK's Gait.trc and the Unnamed samples stop at their last seen marker).
    A NumFrames that is absent, 0 or not a whole number, or below the rows
    there (the header of a take trimmed by hand), says nothing of a cut.
    """
    cut = ends_in_row and last_values < 3 * m
    try:
        declared = float(header.get("NumFrames", "") or 0)
    except ValueError:
        declared = 0.0
    if math.isfinite(declared) and declared == int(declared) and frames < declared:
        raise MocapFormatError(path, f"truncated file: it has {frames} of the {int(declared)} frames its header "
                               f"declares (NumFrames){', the last cut mid-row' if cut else ''}; the file is cut short",
                               line=last_line)
    if cut:
        raise MocapFormatError(path, f"truncated file: the last row holds {max(last_values, 0)} of the {3 * m} values "
                               f"its {plural(m, 'marker')} need and ends without a line break; the file is cut short", line=last_line)


def _rate(x: float) -> str:
    return f"{x:.2f}" if round(x, 2) == x else repr(float(x))


def write_trc(markers: MarkerSet, path, *, like=None, decimals: int = TRC_DECIMALS, keep_modelled: bool = False) -> None:
    """Write ``markers`` as a tab-separated TRC file, atomically (temp file + rename).

    A take read from a TRC file (or written ``like`` one) whose markers are
    still the file's own, in its order, rate and unit, is written as the
    file's text with only the changed samples rewritten
    (:func:`_edited_text`): every other cell, the Frame# and Time columns,
    the header, labels (spaces and repeats included), fields past the last
    marker and the line breaks stay as the file had them, so an unchanged
    take comes back byte for byte. A changed sample is written with the
    file's decimals or ``decimals``, whichever is more; a frame the file
    skipped (read as missing) gets a row of its own, numbered and timed as
    the file's own timing gives it (:func:`_between`).

    Otherwise (another format's take, a selection of markers) the file is
    written new: coordinates with ``decimals`` decimals (a round trip gives
    back each coordinate rounded to them), missing samples as empty fields,
    frame numbers from the source's first frame (1 without one) and times
    that go with them (the source TRC's first time, else (frame - 1) / fps).
    CameraRate, OrigDataRate, OrigDataStartFrame, OrigNumFrames and the
    PathFileType line's name come from ``like`` (a MarkerSet or a TRC file)
    or the TRC file ``markers`` was read from, else they restate the take's
    own rate and frames.

    A TRC holds markers, all in one length unit (``Units``), and OpenSim reads
    every point of it as one: the modelled quantities a C3D lists as points
    (joint angles in degrees, forces, moments, powers:
    :meth:`MarkerSet.quantities <mocapkit.markerset.MarkerSet.quantities>`)
    are left out unless ``keep_modelled`` (:func:`mocapkit.io.marker_notes`
    names them). Modelled positions (segment axes, centre of mass) are kept.
    """
    from . import atomic_write

    path = Path(check_file_path(path))  # "out/x/" names a folder: refused, not written as out/x
    quantities = markers.quantities() != ""
    if quantities.any() and not keep_modelled:
        markers = markers.select([label for label, q in zip(markers.labels, quantities) if not q])
    if markers.num_markers == 0 or markers.num_frames == 0:
        raise MocapFormatError(path, "a TRC file needs at least one marker and one frame")
    # a file's own label may be empty (read as M and its place, and so again when written back)
    bad = [label for label in markers.labels if not label.strip()] + [
        label for label in markers.labels + markers.file_labels() if any(c in label for c in "\t\r\n")]
    if bad:
        raise MocapFormatError(path, f"marker label {bad[0]!r} is empty or holds a tab or line break, which TRC cannot store")
    checked_unit_cm(path, markers.units)
    if like is not None and not isinstance(like, MarkerSet):
        like = read_trc(like, zeros_as_gaps=False)
    source = (like if like is not None else markers).source
    trc = source if source is not None and source.format == "trc" else None
    out = _edited_text(markers, trc, decimals) if trc is not None else None
    if out is None:
        # the first frame's number on the clock of the file's frame numbers (a resampled take keeps the file's)
        clock = trial_rate(source.layout, (like if like is not None else markers).fps) if source is not None else markers.fps
        out = _new_text(markers, path, trc, source.first_frame if source is not None else 1, decimals, clock)
    with atomic_write(path, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        fh.write(out)


def _rows(text: str) -> tuple[list[str], list[int], list[str], list[str]]:
    """A TRC text's lines (line breaks kept), the index of each data row, and its Frame# and Time texts."""
    lines = text.splitlines(keepends=True)
    at, numbers, times = [], [], []
    for i in range(5, len(lines)):
        if lines[i].strip():
            fields = lines[i].rstrip("\r\n").split("\t") + [""]
            at.append(i)
            numbers.append(fields[0])
            times.append(fields[1])
    return lines, at, numbers, times


def _decimals(cells) -> int:
    """The most decimals among number texts ``cells`` (0 for none)."""
    return max((len(c.strip().split(".", 1)[1]) for c in cells if "." in c and "e" not in c.lower()), default=0)


def _edited_text(markers: MarkerSet, source: MarkerSource, decimals: int) -> str | None:
    """The source TRC's text with the samples ``markers`` changed rewritten; None when it is not this take's file.

    It is when the markers are the file's own (:meth:`MarkerSet.file_labels`),
    at its rate and unit, and its first frame and frame count (skipped frames
    included, placed as the reader placed them: :func:`_frame_slots`) are the take's. A row without a changed sample is kept as it
    stands; in a row with one, the changed samples' three fields are
    rewritten (empty for a sample now missing), the rest kept. A sample read
    as missing from an exact 0 0 0 (:func:`~mocapkit.markerset.zero_gap_mask`)
    and still missing is unchanged.
    """
    if source.text is None or markers.file_labels() != source.labels or len(source.labels) != markers.num_markers:
        return None
    head = dict(source.parameters)
    try:
        rate = float(head.get("DataRate") or head.get("CameraRate") or "nan")
    except ValueError:
        return None
    if markers.units != (head.get("Units") or markers.units) or markers.fps != rate:  # none stated: read from the data
        return None
    lines, at, numbers, times = _rows(source.text)
    F, M = markers.num_frames, markers.num_markers
    if not at or _first_frame(numbers[0]) != source.first_frame:
        return None
    try:  # where the reader put each row (its Time column, else its Frame#, else its place)
        slots = _frame_slots(Path("?"), numbers, times, [a + 1 for a in at], rate)[0]
    except MocapFormatError:
        return None
    if int(slots[-1]) + 1 != F:
        return None
    first_row = lines[at[0]]
    eol = first_row[len(first_row.rstrip("\r\n")):] or "\n"
    cells0 = first_row.rstrip("\r\n").split("\t")
    fmt = f"{{:.{max(int(decimals), _decimals(cells0[2:]))}f}}"
    pos = markers.positions.reshape(F, 3 * M)
    out = []
    for r, i in enumerate(slots.tolist()):
        if r:  # the frames the file skipped before this row: rows of their own, numbered and timed as the file's
            # own timing gives them (:func:`_between`)
            gap = i - int(slots[r - 1])
            for j in range(1, gap):
                number = _between(numbers[r - 1], numbers[r], j, gap)
                time = _between(times[r - 1], times[r], j, gap, 1 / rate)
                out.append(_new_row(number, time, pos[i - gap + j], fmt) + eol)
        line = lines[at[r]]
        body = line.rstrip("\r\n")
        fields = body.split("\t")
        old = np.full(3 * M, np.nan)
        for j, v in enumerate(fields[2 : 2 + 3 * M]):
            v = v.strip()
            if v:
                old[j] = float(v)
        o, new = old.reshape(M, 3), pos[i].reshape(M, 3)
        o_gap = np.isnan(o).any(axis=1) | np.all(o == 0.0, axis=1)
        same = np.all(o == new, axis=1) | (np.isnan(new).any(axis=1) & o_gap)
        if same.all():
            out.append(line)
            continue
        # a row shorter than the widest (Gait.trc: 102 fields of 317) keeps its own width and trailing tabs:
        # extended only as far as a sample written past its end needs (a removed one there is empty already)
        changed = np.flatnonzero(~same)
        fields += [""] * (5 + 3 * int(changed[-1]) - len(fields))
        for k in changed:
            fields[2 + 3 * k : 5 + 3 * k] = ["" if math.isnan(v) else fmt.format(v) for v in new[k].tolist()]
        out.append("\t".join(fields) + line[len(body):])
    header = list(lines[: at[0]])
    if len(header) > 2 and F != len(at):  # frames the file skipped were inserted: NumFrames counts them
        header[2] = _set_field(lines[1], header[2], "NumFrames", len(at), F)
    tail = lines[at[-1] + 1 :]
    for k in range(len(out) - (0 if tail else 1)):  # a row that ended the file goes on with a line break
        if not out[k].endswith(("\n", "\r")):
            out[k] += eol
    return "".join(header + out + tail)


def _between(before: str, after: str, j: int, gap: int, frame: float | None = None) -> str:
    """The Frame# or Time text ``j`` of ``gap`` frames from ``before`` to ``after`` (texts of two rows), written
    with their decimals (a whole number stays whole where the step is); empty where either is not a number.

    Times (``frame``: 1/DataRate) that are whole multiples of a frame as written (``0.133`` at 30 fps: frame 4),
    ``gap`` frames apart, give frame ``j`` on from ``before``'s (0.167 for the next, not 0.133 + 1/30); other
    values are spaced evenly between the two.
    """
    a, b = _number(before), _number(after)
    if a != a or b != b:
        return ""
    places = _places([before, after])
    if frame is not None:
        on = [x / frame for x in (a, b)]
        slack = 0.5 * 10.0 ** -places / frame + 1e-9  # frames a time written with these places may be off
        if all(abs(x - round(x)) <= slack for x in on) and round(on[1]) - round(on[0]) == gap:
            return f"{(round(on[0]) + j) * frame:.{max(places, 1)}f}"
    step = (b - a) / gap
    if places <= 0 and step == int(step):
        return str(int(a) + j * int(step))
    return f"{a + j * step:.{max(places, 1)}f}"


def _time_text(like: str, t: float) -> str:
    """``t`` seconds with the decimals of the time text ``like`` (6 when it has none)."""
    return f"{t:.{_decimals([like]) or 6}f}"


def _new_row(frame: int, time: str, values, fmt: str) -> str:
    """A data row: frame number, time text, then the (3 * M,) coordinates (empty fields for NaN)."""
    return f"{frame}\t{time}\t" + "\t".join("" if math.isnan(v) else fmt.format(v) for v in values.tolist())


def _set_field(names_line: str, values_line: str, key: str, was: int, value: int) -> str:
    """``values_line`` with header field ``key`` set to ``value`` where it said ``was``, its width kept."""
    names = [k.strip() for k in names_line.rstrip("\r\n").split("\t")]
    body = values_line.rstrip("\r\n")
    values = body.split("\t")
    if key in names and names.index(key) < len(values):
        j = names.index(key)
        try:
            if float(values[j]) == was:
                values[j] = str(value).rjust(len(values[j]))
        except ValueError:
            pass
    return "\t".join(values) + values_line[len(body):]


def trc_notes(markers: MarkerSet, path, *, keep_modelled: bool = False, filled=None, record=None) -> list[str]:
    """The lines a command says when it writes ``markers`` to the TRC ``path`` (:func:`mocapkit.io.marker_notes`'s).

    - the modelled quantities :func:`write_trc` leaves out (none with
      ``keep_modelled``): their count and kinds (:meth:`MarkerSet.quantities`);
    - the samples the file holds that are no recorded ones, which a TRC
      (no residual column) writes like recorded ones: ``filled`` ((F, M) bool,
      the fills of a cleaning) with ``record``, the file that lists them;
      and the samples ``markers`` marks as interpolated (residual 0 where
      some other sample of a marker has one over 0, modelled points and
      unlabelled trajectories aside: a capture program's fills, or those of
      a cleaned C3D), which a .c3d output keeps marked.
    """
    from collections import Counter

    notes = []
    kinds = markers.quantities()
    if not keep_modelled and np.any(kinds != ""):
        n = Counter(k for k in kinds if k)
        counted = ", ".join(f"{n[g.lower()]} {g.lower()}" for g in MODELLED_GROUPS if n[g.lower()])
        notes.append(f"{path}: left out {plural(int(np.sum(kinds != '')), 'modelled quantity', 'modelled quantities')}, not markers ({counted}): "
                     "a TRC holds markers in one length unit (--keep-modelled writes them as points)")
    if filled is not None and np.any(filled):
        where = f"; {record} lists them (its masks filled, spikes, duplicates)" if record is not None else ""
        notes.append(f"{path}: {plural(int(np.sum(filled)), 'sample')} the cleaning wrote (gaps filled, spikes and duplicates "
                     f"replaced) are written like recorded ones: a TRC has no residual column to tell them apart{where}")
    marked = markers.interpolated() & ~(np.asarray(filled, dtype=bool) if filled is not None else False)
    if marked.any():
        notes.append(f"{path}: {plural(int(marked.sum()), 'sample')} the input marks as interpolated (residual 0) are "
                     "written like recorded ones: a TRC has no residual column (a .c3d output keeps them marked)")
    return notes


def _new_text(markers: MarkerSet, path: Path, source: MarkerSource | None, first: int, decimals: int,
              clock: float | None = None) -> str:
    """A TRC text written new (see :func:`write_trc`): the source TRC's header fields, line breaks and first time kept.

    ``first``: the number of the take's first frame on the clock of its file's frame numbers, ``clock`` Hz (the
    take's rate where None). A resampled take (``markers[150::2]`` of a 100 Hz file: its frame 151, 1.5 s) is
    numbered at its own rate from the frame nearest that time (:func:`~mocapkit.io.c3d_trial.written_first`:
    Frame# 76 at 50 Hz) and timed from that time, as the C3D writer numbers its header; the file's own frame
    number stays in OrigDataStartFrame where the file states none.
    """
    clock = float(markers.fps) if clock is None else float(clock)
    old = dict(source.parameters) if source is not None else {}
    text = source.text if source is not None else None
    eol = "\r\n" if text is not None and "\r\n" in text.split("\n", 1)[0] + "\n" else "\n"
    t0, time_like = (first - 1) / clock, "0.000000"
    if text is not None:
        lines, at, numbers, _ = _rows(text)
        if at:
            decimals = max(int(decimals), _decimals(lines[at[0]].rstrip("\r\n").split("\t")[2:]))
        if at and _first_frame(numbers[0]) == first:
            time_like = (lines[at[0]].split("\t") + ["", ""])[1]
            try:
                t0 = float(time_like)
            except ValueError:
                time_like = "0.000000"
    F, M = markers.num_frames, markers.num_markers
    head = {
        "DataRate": _rate(markers.fps), "CameraRate": old.get("CameraRate") or _rate(markers.fps),
        "NumFrames": str(F), "NumMarkers": str(M),
        # the TRC's own spelling, else the symbol (a C3D's 4-character "mete" is no unit OpenSim reads)
        "Units": markers.units if old.get("Units") == markers.units else unit_symbol(markers.units),
        "OrigDataRate": old.get("OrigDataRate") or _rate(markers.fps),
        "OrigDataStartFrame": old.get("OrigDataStartFrame") or str(first), "OrigNumFrames": old.get("OrigNumFrames") or str(F),
    }
    keys = _HEADER_KEYS
    modelled = modelled_field(markers.modelled_kinds())
    if modelled:  # the modelled points, which a TRC cannot otherwise tell from markers
        head[MODELLED_KEY], keys = modelled, keys + (MODELLED_KEY,)
    out = [f"PathFileType\t4\t(X/Y/Z)\t{old.get('PathFileType') or path.name}",
           "\t".join(keys), "\t".join(head[k] for k in keys),
           "\t".join(["Frame#", "Time"] + [f"{label}\t\t" for label in markers.file_labels()]).rstrip("\t"),
           "\t\t" + "\t".join(f"X{k + 1}\tY{k + 1}\tZ{k + 1}" for k in range(M)), ""]
    fmt = f"{{:.{int(decimals)}f}}"
    pos = markers.positions.reshape(F, 3 * M)
    number = written_first(first, markers.fps, clock)
    for i in range(F):
        out.append(_new_row(number + i, _time_text(time_like, t0 + i / markers.fps), pos[i], fmt))
    return eol.join(out) + eol
