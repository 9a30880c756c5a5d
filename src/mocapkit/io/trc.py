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
from ..markerset import MarkerSet, MarkerSource, repeated_labels_note, unique_labels
from ..motion import check_fps
from .c3d import apply_zero_gaps, checked_unit_cm

__all__ = ["read_trc", "write_trc", "TRC_DECIMALS"]

TRC_DECIMALS = 5  # coordinates written with 5 decimals (Cortex and OpenSim write 5)
_HEADER_KEYS = ("DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units",
                "OrigDataRate", "OrigDataStartFrame", "OrigNumFrames")


def _fields(line: str) -> list[str]:
    return line.rstrip("\r\n").split("\t")


def read_trc(path, zeros_as_gaps: bool | None = None) -> MarkerSet:
    """Read a TRC file as a :class:`~mocapkit.markerset.MarkerSet` (empty fields become NaN).

    The frame rate is DataRate (CameraRate when DataRate is absent), the unit
    the Units field. Every trajectory the rows hold is read: the marker count
    is the largest of NumMarkers, the labels and the whole X Y Z triples of
    the widest row (fields past them are not coordinates). Labels come from
    the ``Frame#`` line, named apart in memory
    (:func:`~mocapkit.markerset.unique_labels`: a marker without one is
    M and its place, a repeat gets _2); the file's own are kept in
    ``source.labels`` and its text in ``source.text`` for :func:`write_trc`.
    A row with fewer fields than markers has the rest missing; a frame the
    Frame# column skips is a frame with every marker missing
    (:func:`_frame_slots`). What the user should know (trajectories past
    NumMarkers or without a label, extra fields, skipped frames, repeated
    labels) is in ``notes``. ``zeros_as_gaps`` as for
    :func:`~mocapkit.io.c3d.read_c3d` (some exporters write unseen markers as 0 0 0).

    Raises :class:`~mocapkit.errors.MocapFormatError` naming the file and line
    for a file that is not a TRC (first line), a header cut short, a missing
    or non-positive frame rate, an unknown unit, a field that is not a number,
    a frame number out of range or not increasing, no data rows, or a file
    cut short (fewer frames than NumFrames, or a last row cut partway
    through: :func:`_check_complete`).
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
        text = raw.decode("utf-8", errors="replace")
    except OSError as exc:
        raise MocapFormatError(path, f"cannot read: {exc.strerror or exc}") from None
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise MocapFormatError(path, "empty file: a TRC file starts with a PathFileType line")
    first = _fields(lines[0])
    if first[0].strip() != "PathFileType":
        raise MocapFormatError(path, f"not a TRC file: the first line starts with {first[0][:40]!r}, not 'PathFileType'", line=1)
    if len(lines) < 5:
        raise MocapFormatError(path, f"truncated TRC header: {len(lines)} lines, the header needs 5 "
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
    units = header.get("Units", "") or "mm"
    unit_cm = checked_unit_cm(path, units)
    label_line = _fields(lines[3])
    if label_line[0].strip() != "Frame#":
        raise MocapFormatError(path, f"line 4 should start with 'Frame#', got {label_line[0][:40]!r}", line=4)
    label_text = [label_line[j] for j in range(2, len(label_line), 3)]  # as the file has them, spaces included
    while label_text and not label_text[-1].strip():
        label_text.pop()
    rows, numbers, row_lines = [], [], []
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
        try:
            frame = int(float(f[0]))
        except (ValueError, OverflowError):
            raise MocapFormatError(path, f"frame number {f[0][:20]!r} is not a number{hint}", line=n) from None
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
        numbers.append(frame)
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
    slots = _frame_slots(path, numbers, row_lines)
    _check_complete(path, header, int(slots[-1]) + 1, last_fields - 2, m, last_line,
                    ends_in_row=ends_in_row and last_line == len(lines))
    data = np.full((int(slots[-1]) + 1, 3 * m), np.nan)
    for i, r in zip(slots, rows):
        data[i, : min(len(r), 3 * m)] = r[: 3 * m]
    xyz = data.reshape(data.shape[0], m, 3)
    xyz[np.any(np.isnan(xyz), axis=-1)] = np.nan  # a sample with one empty coordinate is not seen
    labels = unique_labels(label_text, m)
    file_labels = tuple(label_text) + labels[len(label_text):]
    zeros = apply_zero_gaps(labels, xyz, None, unit_cm, zeros_as_gaps)
    notes = repeated_labels_note(tuple(t.strip() for t in file_labels), labels)
    notes += _count_notes(int(stated), len([t for t in label_text if t.strip()]), held, m, labels)
    notes += _extra_field_notes(rows, row_lines, m)
    notes += _skipped_frame_notes(numbers, row_lines)
    source = MarkerSource(format="trc", parameters={"PathFileType": first[3].strip() if len(first) > 3 else "", **header},
                          first_frame=numbers[0], labels=file_labels,
                          text=raw.decode("utf-8", errors="surrogateescape"))
    return MarkerSet(labels=labels, positions=xyz, fps=fps, units=units, name=path.stem, reader="trc",
                     source=source, zero_gaps=zeros, notes=notes)


# Frames a file may skip, inserted as missing samples: more than this many is refused as not a frame numbering.
_MAX_INSERTED = 100_000


def _frame_slots(path: Path, numbers: list[int], row_lines: list[int]) -> np.ndarray:
    """(rows,) int: the frame (0-based, from the first row's number) each data row holds.

    Frame numbers must increase; a file that skips some (``1..40, 42..89``)
    gets the skipped frames inserted as frames with every marker missing, so
    that frame ``k`` of the take stays at the file's time (a cleaner then
    fills them as gaps; :func:`_skipped_frame_notes` says so). A number that
    does not increase, or a skip of more than :data:`_MAX_INSERTED` frames,
    is refused naming its line.
    """
    nums = np.asarray(numbers, dtype=np.int64)
    step = np.diff(nums)
    bad = np.flatnonzero(step <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise MocapFormatError(path, f"frame number {numbers[k]} follows frame {numbers[k - 1]}: the Frame# column "
                               "must increase", line=row_lines[k])
    if int(nums[-1] - nums[0]) + 1 - len(nums) > _MAX_INSERTED:
        k = int(np.argmax(step)) + 1
        raise MocapFormatError(path, f"frame number {numbers[k]} follows frame {numbers[k - 1]}: the Frame# column "
                               f"skips more than {_MAX_INSERTED} frames", line=row_lines[k])
    return nums - nums[0]


def _skipped_frame_notes(numbers: list[int], row_lines: list[int]) -> tuple[str, ...]:
    """One note naming the frames the Frame# column skips (inserted as missing samples); () for none."""
    step = np.diff(np.asarray(numbers, dtype=np.int64))
    at = np.flatnonzero(step > 1)
    if at.size == 0:
        return ()
    runs = [f"{numbers[k] + 1}" if step[k] == 2 else f"{numbers[k] + 1}-{numbers[k + 1] - 1}" for k in at[:5]]
    more = f" and {at.size - 5} more runs" if at.size > 5 else ""
    total = int((step[at] - 1).sum())
    return (f"the Frame# column skips frame{'s' if total > 1 else ''} {', '.join(runs)}{more} (at line "
            f"{row_lines[int(at[0]) + 1]}): read as {total} frame{'s' if total > 1 else ''} with every marker missing, "
            "so every frame keeps its time",)


def _count_notes(stated: int, named: int, held: int, m: int, labels) -> tuple[str, ...]:
    """One note when the file holds trajectories its header does not count or its labels do not name."""
    said = []
    if stated and held > stated:
        said.append(f"the header states NumMarkers {stated}, the rows hold {held} trajectories: all {m} are read")
    unnamed = [label for k, label in enumerate(labels) if k >= named]
    if unnamed and (said or named):
        span = unnamed[0] if len(unnamed) == 1 else f"{unnamed[0]}-{unnamed[-1]}"
        said.append(f"{_plural(len(unnamed), 'trajectory', 'trajectories')} without a label named {span} "
                    "(M and the marker's place in the file)")
    return ("; ".join(said),) if said else ()


def _extra_field_notes(rows, row_lines, m: int) -> tuple[str, ...]:
    """One note for rows holding fields past the last marker's X Y Z (not coordinates); () for none."""
    extra = [(k, r) for k, r in enumerate(rows) if len(r) > 3 * m and not np.all(np.isnan(r[3 * m:]))]
    if not extra:
        return ()
    k, r = extra[0]
    return (f"{_plural(len(extra), 'row', 'rows')} hold fields past the last marker's X Y Z (line {row_lines[k]}: field "
            f"{3 * m + 3}, {r[3 * m]:g}): not coordinates, not read; a TRC written from this take keeps them",)


def _plural(n: int, word: str, many: str) -> str:
    return f"{n} {word if n == 1 else many}"


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
                               f"its {m} markers need and ends without a line break; the file is cut short", line=last_line)


def _rate(x: float) -> str:
    return f"{x:.2f}" if round(x, 2) == x else repr(float(x))


def write_trc(markers: MarkerSet, path, *, like=None, decimals: int = TRC_DECIMALS) -> None:
    """Write ``markers`` as a tab-separated TRC file, atomically (temp file + rename).

    A take read from a TRC file (or written ``like`` one) whose markers are
    still the file's own, in its order, rate and unit, is written as the
    file's text with only the changed samples rewritten
    (:func:`_edited_text`): every other cell, the Frame# and Time columns,
    the header, labels (spaces and repeats included), fields past the last
    marker and the line breaks stay as the file had them, so an unchanged
    take comes back byte for byte. A changed sample is written with the
    file's decimals or ``decimals``, whichever is more; a frame the file
    skipped (read as missing) gets a row of its own.

    Otherwise (another format's take, a selection of markers) the file is
    written new: coordinates with ``decimals`` decimals (a round trip gives
    back each coordinate rounded to them), missing samples as empty fields,
    frame numbers from the source's first frame (1 without one) and times
    that go with them (the source TRC's first time, else (frame - 1) / fps).
    CameraRate, OrigDataRate, OrigDataStartFrame, OrigNumFrames and the
    PathFileType line's name come from ``like`` (a MarkerSet or a TRC file)
    or the TRC file ``markers`` was read from, else they restate the take's
    own rate and frames.
    """
    from . import atomic_write

    path = Path(path)
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
        out = _new_text(markers, path, trc, source.first_frame if source is not None else 1, decimals)
    with atomic_write(path, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        fh.write(out)


def _rows(text: str) -> tuple[list[str], list[int], list[int]]:
    """A TRC text's lines (line breaks kept), the index of each data row and its frame number."""
    lines = text.splitlines(keepends=True)
    at, numbers = [], []
    for i in range(5, len(lines)):
        field = lines[i].split("\t", 1)[0].strip()
        if lines[i].strip():
            try:
                numbers.append(int(float(field)))
            except (ValueError, OverflowError):
                return lines, [], []
            at.append(i)
    return lines, at, numbers


def _decimals(cells) -> int:
    """The most decimals among number texts ``cells`` (0 for none)."""
    return max((len(c.strip().split(".", 1)[1]) for c in cells if "." in c and "e" not in c.lower()), default=0)


def _edited_text(markers: MarkerSet, source: MarkerSource, decimals: int) -> str | None:
    """The source TRC's text with the samples ``markers`` changed rewritten; None when it is not this take's file.

    It is when the markers are the file's own (:meth:`MarkerSet.file_labels`),
    at its rate and unit, and its first frame and frame count (skipped frames
    included) are the take's. A row without a changed sample is kept as it
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
    if markers.units != (head.get("Units") or "mm") or markers.fps != rate:
        return None
    lines, at, numbers = _rows(source.text)
    F, M = markers.num_frames, markers.num_markers
    if not at or numbers[0] != source.first_frame or numbers[-1] - numbers[0] + 1 != F or len(set(numbers)) != len(at):
        return None
    first_row = lines[at[0]]
    eol = first_row[len(first_row.rstrip("\r\n")):] or "\n"
    cells0 = first_row.rstrip("\r\n").split("\t")
    fmt = f"{{:.{max(int(decimals), _decimals(cells0[2:]))}f}}"
    pos = markers.positions.reshape(F, 3 * M)
    rows = dict(zip(numbers, at))
    out = []
    for i in range(F):
        n = numbers[0] + i
        if n not in rows:  # a frame the file skipped: a row of its own, time in step with its neighbours
            out.append(_new_row(n, _time_text(cells0[1], (n - numbers[0]) / markers.fps), pos[i], fmt) + eol)
            continue
        line = lines[rows[n]]
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
        fields += [""] * (2 + 3 * M - len(fields))
        for k in np.flatnonzero(~same):
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


def _new_text(markers: MarkerSet, path: Path, source: MarkerSource | None, first: int, decimals: int) -> str:
    """A TRC text written new (see :func:`write_trc`): the source TRC's header fields, line breaks and first time kept."""
    old = dict(source.parameters) if source is not None else {}
    text = source.text if source is not None else None
    eol = "\r\n" if text is not None and "\r\n" in text.split("\n", 1)[0] + "\n" else "\n"
    t0, time_like = (first - 1) / markers.fps, "0.000000"
    if text is not None:
        lines, at, numbers = _rows(text)
        if at:
            decimals = max(int(decimals), _decimals(lines[at[0]].rstrip("\r\n").split("\t")[2:]))
        if at and numbers[0] == first:
            time_like = (lines[at[0]].split("\t") + ["", ""])[1]
            try:
                t0 = float(time_like)
            except ValueError:
                time_like = "0.000000"
    F, M = markers.num_frames, markers.num_markers
    head = {
        "DataRate": _rate(markers.fps), "CameraRate": old.get("CameraRate") or _rate(markers.fps),
        "NumFrames": str(F), "NumMarkers": str(M), "Units": markers.units,
        "OrigDataRate": old.get("OrigDataRate") or _rate(markers.fps),
        "OrigDataStartFrame": old.get("OrigDataStartFrame") or str(first), "OrigNumFrames": old.get("OrigNumFrames") or str(F),
    }
    out = [f"PathFileType\t4\t(X/Y/Z)\t{old.get('PathFileType') or path.name}",
           "\t".join(_HEADER_KEYS), "\t".join(head[k] for k in _HEADER_KEYS),
           "\t".join(["Frame#", "Time"] + [f"{label}\t\t" for label in markers.file_labels()]).rstrip("\t"),
           "\t\t" + "\t".join(f"X{k + 1}\tY{k + 1}\tZ{k + 1}" for k in range(M)), ""]
    fmt = f"{{:.{int(decimals)}f}}"
    pos = markers.positions.reshape(F, 3 * M)
    for i in range(F):
        out.append(_new_row(first + i, _time_text(time_like, t0 + i / markers.fps), pos[i], fmt))
    return eol.join(out) + eol
