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
from ..markerset import MarkerSet, MarkerSource
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
    the Units field. Labels come from the ``Frame#`` line (stripped; a marker
    without one is named M001, M002, ...); the marker count is the larger of
    NumMarkers and the columns the rows hold. A row with fewer fields than
    markers has the rest missing. ``zeros_as_gaps`` as for
    :func:`~mocapkit.io.c3d.read_c3d` (some exporters write unseen markers as 0 0 0).

    Raises :class:`~mocapkit.errors.MocapFormatError` naming the file and line
    for a file that is not a TRC (first line), a header cut short, a missing
    or non-positive frame rate, an unknown unit, a field that is not a number,
    no data rows, or a file cut short (fewer rows than NumFrames, or a last
    row cut partway through: :func:`_check_complete`).
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8", errors="replace")
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
    labels_raw = [label_line[j].strip() for j in range(2, len(label_line), 3)]
    while labels_raw and not labels_raw[-1]:
        labels_raw.pop()
    rows, numbers = [], []
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
    if not rows:
        raise MocapFormatError(path, "the TRC file holds no data rows")
    stated = number("NumMarkers", 0) or 0
    if stated < 0 or stated != int(stated):
        raise MocapFormatError(path, f"header field NumMarkers is {header['NumMarkers']!r}, not a marker count", line=3)
    # NumMarkers decides when stated (fields past it are ignored, as BTK and OpenSim read them);
    # a file stating 0 gets as many markers as its widest row holds.
    present = max(max((len(r) + 2) // 3 for r in rows), len(labels_raw))
    if stated > present + 1000:
        raise MocapFormatError(path, f"header field NumMarkers says {int(stated)} markers, the file names and holds "
                               f"at most {present}", line=3)
    m = int(stated) or present
    _check_complete(path, header, len(rows), last_fields - 2, m, last_line,
                    ends_in_row=ends_in_row and last_line == len(lines))
    data = np.full((len(rows), 3 * m), np.nan)
    for i, r in enumerate(rows):
        data[i, : min(len(r), 3 * m)] = r[: 3 * m]
    xyz = data.reshape(len(rows), m, 3)
    xyz[np.any(np.isnan(xyz), axis=-1)] = np.nan  # a sample with one empty coordinate is not seen
    labels = _labels(labels_raw, m)
    zeros = apply_zero_gaps(labels, xyz, None, unit_cm, zeros_as_gaps)
    source = MarkerSource(format="trc", parameters={"PathFileType": first[3].strip() if len(first) > 3 else "", **header},
                          first_frame=numbers[0])
    return MarkerSet(labels=labels, positions=xyz, fps=fps, units=units, name=path.stem, reader="trc",
                     source=source, zero_gaps=zeros)


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


def _labels(raw: list[str], m: int) -> tuple[str, ...]:
    """Labels for ``m`` markers: the file's, unnamed ones as M001..., duplicates suffixed _2, _3."""
    out, seen = [], {}
    for k in range(m):
        label = raw[k] if k < len(raw) and raw[k] else f"M{k + 1:03d}"
        count = seen.get(label, 0)
        seen[label] = count + 1
        out.append(label if count == 0 else f"{label}_{count + 1}")
    return tuple(out)


def _rate(x: float) -> str:
    return f"{x:.2f}" if round(x, 2) == x else repr(float(x))


def write_trc(markers: MarkerSet, path, *, like=None, decimals: int = TRC_DECIMALS) -> None:
    """Write ``markers`` as a tab-separated TRC file, atomically (temp file + rename).

    Coordinates are written with ``decimals`` decimals (a round trip gives back
    each coordinate rounded to them), missing samples as empty fields, the
    time column as (frame - 1) / fps. CameraRate, OrigDataRate,
    OrigDataStartFrame and OrigNumFrames come from ``like`` (a MarkerSet or a
    TRC file) or the file ``markers`` was read from when it was a TRC, else
    they restate the take's own rate and frames. Frame numbers start at the
    source's first frame (1 without one).
    """
    from . import atomic_write

    path = Path(path)
    if markers.num_markers == 0 or markers.num_frames == 0:
        raise MocapFormatError(path, "a TRC file needs at least one marker and one frame")
    bad = [label for label in markers.labels if any(c in label for c in "\t\r\n") or not label.strip()]
    if bad:
        raise MocapFormatError(path, f"marker label {bad[0]!r} is empty or holds a tab or line break, which TRC cannot store")
    checked_unit_cm(path, markers.units)
    if like is not None and not isinstance(like, MarkerSet):
        like = read_trc(like, zeros_as_gaps=False)
    source = (like if like is not None else markers).source
    old = dict(source.parameters) if source is not None and source.format == "trc" else {}
    first = source.first_frame if source is not None else 1
    F, M = markers.num_frames, markers.num_markers
    head = {
        "DataRate": _rate(markers.fps), "CameraRate": old.get("CameraRate") or _rate(markers.fps),
        "NumFrames": str(F), "NumMarkers": str(M), "Units": markers.units,
        "OrigDataRate": old.get("OrigDataRate") or _rate(markers.fps),
        "OrigDataStartFrame": old.get("OrigDataStartFrame") or str(first), "OrigNumFrames": old.get("OrigNumFrames") or str(F),
    }
    out = [f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
           "\t".join(_HEADER_KEYS), "\t".join(head[k] for k in _HEADER_KEYS),
           "\t".join(["Frame#", "Time"] + [f"{label}\t\t" for label in markers.labels]).rstrip("\t"),
           "\t\t" + "\t".join(f"X{k + 1}\tY{k + 1}\tZ{k + 1}" for k in range(M)), ""]
    fmt = f"{{:.{int(decimals)}f}}"
    pos = markers.positions.reshape(F, 3 * M)
    for i in range(F):
        cells = ["" if math.isnan(v) else fmt.format(v) for v in pos[i].tolist()]
        out.append(f"{first + i}\t{i / markers.fps:.6f}\t" + "\t".join(cells))
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write("\n".join(out) + "\n")
