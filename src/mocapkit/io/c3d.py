"""C3D optical marker files: read into a :class:`~mocapkit.markerset.MarkerSet`, written back with ezc3d.

Read with ezc3d, the reference C3D library. A few real files in circulation
have parameter-section quirks ezc3d refuses (c3d.org's PhoeniX samples: "OFFSET
parameter is not an INT"; big-endian SGI files), a header that claims no points
(the PhaseSpace sample), no ``POINT:DATA_START`` parameter, or analog samples
in the header's frames without ``ANALOG:RATE``, which make ezc3d read the data
block from the wrong offset or with the wrong frame size (c3d.org sample28), or
a data block holding fewer whole frames than the header states
(ezc3d-testFiles Optotrak.c3d: 29 of the 1,149 frames its header and
POINT:FRAMES state, read as ezc3d and the c3d package read it); for those the
pure-Python ``c3d`` package reads the data block, the parameter section is read
record by record (:func:`~mocapkit.io.c3d_parameters.read_parameters`: the
package stops at the section's stated blocks), and the MarkerSet records
which reader was used in ``reader``. A data block that stops partway through
a frame is a file cut short, refused as truncated BVH and AMC files are.
Samples stored as exact (0, 0, 0) gaps are read as missing
(:func:`~mocapkit.markerset.zero_gap_mask`).
Residuals and camera masks are read from each point's fourth word as
the C3D guide defines it (:func:`point_words`: ezc3d 1.7 swaps its two
bytes), and the header's events (:func:`~mocapkit.io.c3d_layout.header_events`) are kept.

:func:`write_c3d` writes with ezc3d and keeps every other parameter as read
(:func:`~mocapkit.io.c3d_section.keep_parameters`: entries past POINT:USED and
ANALOG:USED, descriptions and locks included) and the analog channels of the file read, and an integer file's 16-bit storage
(:func:`~mocapkit.io.c3d_layout.integer_data`). Coordinates and analog samples
are read as the float32 values a float C3D holds (:func:`_float32_values`), so
that what is written back reads the same, bit for bit, wherever a command did
not change it, integer files included. C3D
format: Motion Lab Systems, "The C3D File Format User Guide" (c3d.org).
"""

from __future__ import annotations

import dataclasses
import re
import struct
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import MocapFormatError, SkeletonError
from .outputs import check_file_path
from ..markerset import (MODELLED_GROUPS, MarkerSet, MarkerSource, length_unit_cm, marker_units,
                         repeated_labels_note, unique_labels, zero_gap_mask)
from ..motion import check_fps
from .c3d_frames import (FRAME_CAP, long_frame_parameters, missing_stored, point_words, put_missing_stored,
                         put_stored_zeros, read_float, read_frames, residuals_and_cameras, rest_of_trial, trial_first,
                         zero_gap_words)
from .c3d_layout import (channel_values, header_events, header_layout, held_analogs, integer_data, integer_scale,
                         keep_data_start, oversized_parameter, put_analogs, put_header_events, put_header_gap,
                         put_spare_events, spare_events, stored_analogs, text_chunks, with_offsets)
from .c3d_modelled import modelled_parameters, stated_positions
from .c3d_parameters import read_parameters
from .c3d_section import keep_parameters
from .c3d_structure import check_structure
from .c3d_trial import (channels_held, fit_event_group, fit_force_plates, fit_header_events, trial_frames, trial_rate,
                         trial_span, written_first)

__all__ = ["MarkerSet", "read_c3d", "write_c3d", "apply_zero_gaps", "checked_unit_cm"]


def _point_rate(path: Path, rate) -> float:
    """The file's point frame rate, checked against :data:`~mocapkit.motion.FPS_RANGE`."""
    try:
        return check_fps(rate, "point frame rate")
    except SkeletonError as exc:
        raise MocapFormatError(path, str(exc)) from None


# Modelled quantities (markerset.MODELLED_GROUPS) are not markers, and a zero
# there is a value, never a gap.
_MODELLED = MODELLED_GROUPS


class _NoPoints(Exception):
    """ezc3d read the file and found no 3D points; the message says what it holds instead."""


def _float32_values(values) -> np.ndarray:
    """``values`` (point coordinates or analog samples) as float64 holding the float32 nearest each.

    ezc3d writes float32 data only (:func:`write_c3d` turns an integer
    file's back into 16-bit numbers where they fit). A float C3D holds float32 already;
    an integer one (positive POINT:SCALE: Eb015pi.c3d, BTK's Gait.c3d) holds
    ``int16 * scale``, which ezc3d and the c3d package compute in float64 and
    float32 cannot all hold: written back, 97 % of Gait's samples came back
    up to 1.2e-4 mm off. Rounded here (by at most half a float32 step, 3e-5 mm
    at a metre, far below any integer file's scale), every sample reads the
    same from the file and from what the writer makes of it, so a sample a
    command did not change reads back bit-identical. Residuals are kept as
    read: ezc3d writes them as whole multiples of the scale, truncating, and
    a residual rounded down to float32 would lose one. A value past float32's
    range (a damaged scale) is kept as read: no float32 is near it.
    """
    values = np.asarray(values, dtype=np.float64)
    with np.errstate(over="ignore"):  # a value past float32's range (a damaged file's scale) cannot be rounded
        near = values.astype(np.float32).astype(np.float64)
    return np.where(np.isinf(near) & np.isfinite(values), values, near)


def _stored_rows(rows: np.ndarray | None) -> np.ndarray | None:
    """:func:`~mocapkit.io.c3d_frames.missing_stored`'s rows with their coordinates read as the float32 values
    every other sample is read as (:func:`_float32_values`)."""
    if rows is None:
        return None
    rows = np.array(rows, dtype=np.float64)
    rows[:, 2:5] = _float32_values(rows[:, 2:5])
    return rows


def _ezc3d_parameters(c) -> dict:
    """The parameter section as plain nested dicts (group -> name -> {type, description, is_locked, value})."""
    out = {}
    for group in c["parameters"]:
        out[group] = {name: dict(param) for name, param in c["parameters"][group].items()}
    return out


@contextmanager
def _address_space_budget(extra: int):
    """Cap this process's address space at its current size + ``extra`` bytes while the block runs (Linux).

    ezc3d (C++) allocates what a non-standard file's fields claim before it
    finds the file malformed: a 583 KB c3d.org sample (sample22
    BKINtechnologies.c3d) made it touch 12 GB before it gave up. Under the cap
    such an allocation fails at once (``bad_alloc``, a Python exception) and
    the file goes to the fallback reader. Where the limit cannot be read or
    set, nothing is capped.
    """
    try:
        import resource

        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        with open("/proc/self/statm") as fh:
            size = int(fh.read().split()[0]) * resource.getpagesize()
        cap = size + int(extra)
        if soft != resource.RLIM_INFINITY and soft <= cap:
            cap = None
        elif hard != resource.RLIM_INFINITY:
            cap = min(cap, hard)
        if cap is not None:
            resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    except (ImportError, OSError, ValueError):
        cap = None
    try:
        yield
    finally:
        if cap is not None:
            resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def _read_ezc3d(path: Path, raw: bytes):
    import ezc3d

    with _address_space_budget(max(1 << 30, 64 * path.stat().st_size)):
        c = ezc3d.c3d(str(path))
    pts = c["data"]["points"]  # (4, M, F)
    n = pts.shape[1]
    params = c["parameters"]["POINT"]
    if n == 0 or pts.shape[2] == 0:
        # the fallback reader may still find points (the PhaseSpace sample's header claims none)
        frames = max(pts.shape[2], c["header"]["points"]["last_frame"] - c["header"]["points"]["first_frame"] + 1)
        analogs = c["data"]["analogs"].shape[1]
        raise _NoPoints(f"C3D file holds no 3D points ({frames} frames, {analogs} analog channels"
                        + (", rotations only)" if c["header"]["rotations"]["size"] else ")"))
    start = params["DATA_START"]["value"] if "DATA_START" in params else []
    if len(start) == 0 or int(start[0]) < 2:
        # Without POINT:DATA_START ezc3d reads the data block from the wrong place
        # (seen on c3d.org sample28); the fallback uses the header's pointer.
        return None
    labels = list(params["LABELS"]["value"]) if "LABELS" in params else []
    for k in range(2, 100):
        if f"LABELS{k}" not in params:
            break
        labels += list(params[f"LABELS{k}"]["value"])
    units = params["UNITS"]["value"][0] if "UNITS" in params and len(params["UNITS"]["value"]) else ""
    xyz = _float32_values(np.transpose(pts[:3], (2, 1, 0)))
    resid = np.array(c["data"]["meta_points"]["residuals"][0].T, dtype=np.float64)  # (F, M)
    scale_param = np.ravel(params["SCALE"]["value"]) if "SCALE" in params else []
    scale = float(scale_param[0]) if len(scale_param) else read_float(raw, raw[(raw[0] - 1) * 512 + 3], 12)
    a = c["data"]["analogs"]  # (1, A, F * ratio): the frame layout ezc3d read
    per_frame = a.shape[1] * (a.shape[2] // max(xyz.shape[0], 1))
    analogs = c["data"]["analogs"][0] if a.size else None
    if analogs is not None:  # ezc3d subtracts each ANALOG:OFFSET's magnitude: read again as the C3D guide has it
        analogs = with_offsets(analogs, c["parameters"],
                               np.abs(channel_values(c["parameters"], "ANALOG", "OFFSET").astype(np.int64)))
    # a trial past the 65,535 frames a header can state: ezc3d read the first 65,535, numpy reads the rest
    rest = rest_of_trial(path, raw, c["parameters"], np.transpose(pts[:3], (2, 1, 0)), analogs, per_frame, scale)
    if rest is not None:
        xyz = np.concatenate([xyz, _float32_values(rest[0])])
        analogs = None if analogs is None else np.concatenate([analogs, rest[1]], axis=1)
    words = point_words(raw, xyz.shape[0], n, scale, per_frame)
    if rest is not None:  # the frames ezc3d did not read: their residuals and cameras from the words alone
        resid = np.concatenate([resid, residuals_and_cameras(words[pts.shape[2]:], scale)[0]])
    cameras = stored = None
    # ezc3d's residuals are the camera byte (see point_words); both read a negative word as a missing sample, so
    # where they disagree on that the word was not found where ezc3d read it: ezc3d's residuals are kept
    if words is not None and np.array_equal(words < 0, resid < 0):
        resid, cameras = residuals_and_cameras(words, scale)
        stored = _stored_rows(missing_stored(raw, xyz.shape[0], n, scale, per_frame))
    xyz[resid < 0] = np.nan
    modelled = set()
    for key in _MODELLED:
        if key in params and params[key]["type"] == -1:
            modelled.update(str(v).strip() for v in np.ravel(params[key]["value"]))
    source = MarkerSource(
        format="c3d",
        parameters=_ezc3d_parameters(c),
        analogs=None if analogs is None else _float32_values(analogs),
        analog_numbers=None if analogs is None else held_analogs(analogs, c["parameters"]),
        first_frame=trial_first(c["parameters"], int(c["header"]["points"]["first_frame"]) + 1),
        missing_stored=stored,
    )
    fps = _point_rate(path, c["header"]["points"]["frame_rate"])
    return labels, xyz, (resid, cameras), fps, units, "ezc3d", source, modelled


# Groups the readers, the writer and ezc3d look up by their upper-case names: the pure-Python reader's
# upper-cased names are kept there (:func:`_with_written_case`).
_LOOKED_UP = frozenset({"POINT", "ANALOG", "TRIAL", "FORCE_PLATFORM", "EVENT"})


def _with_written_case(parameters: dict, written: dict) -> dict:
    """``parameters`` (the ``c3d`` package's, every name upper-cased) with the names as the file writes them.

    ezc3d keeps a file's names as written (dynamic.c3d's ``SUBJECT:Address``), and
    lookups by name are case-sensitive, so a take read by the pure-Python reader
    is written back with its own names. ``written``: (GROUP, NAME) upper-cased -> (group, name, locked) as the
    file writes them, a group's own record keyed (GROUP, "") (:func:`~mocapkit.io.c3d_structure.check_structure` reads them). The groups in
    :data:`_LOOKED_UP` (and their parameters) keep their upper-case names; a name the package changed
    otherwise (a repeated group renamed) is kept as the package gives it. Each keeps its lock (a negative name
    length in the file), which the package does not read and ezc3d does: Eb015si.c3d's POINT:USED stays locked.
    """
    out = {}
    for group, params in parameters.items():
        g = group if group in _LOOKED_UP else written.get((group, ""), (group, ""))[0]
        got = {}
        for k, v in params.items():
            if k == "__METADATA__":
                got[k] = dict(v, IS_LOCKED=bool(written.get((group, ""), ("", "", v.get("IS_LOCKED")))[2]))
                continue
            spelled = written.get((group, k), (g, k, v.get("is_locked")))
            got[k if group in _LOOKED_UP else spelled[1]] = dict(v, is_locked=bool(spelled[2]))
        out[g] = got
    return out


def _read_c3d_package(path: Path, written: dict, raw: bytes | None = None, records=None):
    """The pure-Python reader: what :func:`_read_ezc3d` returns, for the file ``path`` (its bytes ``raw``) whose
    parameters the file names as ``written`` says (:func:`_with_written_case`); ``records``: its parameter
    section's records as :func:`~mocapkit.io.c3d_structure.check_structure` walked them (None: walked again)."""
    import c3d

    with open(path, "rb") as fh, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = c3d.Reader(fh)
        frames, analog = [], []
        for _, points, analogs in reader.read_frames():
            frames.append(points)
            analog.append(analogs)
        if not frames:
            raise MocapFormatError(path, "C3D file holds no point frames")
        data = np.asarray(frames, dtype=np.float64)  # (F, M, 5): x y z residual cameras
        labels = []
        for key in ["LABELS"] + [f"LABELS{k}" for k in range(2, 100)]:  # past 255 points: LABELS2, LABELS3 ...
            param = reader.get(f"POINT:{key}")
            if param is None:
                break
            labels += list(param.string_array)
        unit_param = reader.get("POINT:UNITS")
        units = ""
        if unit_param is not None:  # one unit, or one per point (ezc3d-testFiles Optotrak.c3d): the first
            units = (list(unit_param.string_array.reshape(-1)) or [""])[0] if len(unit_param.dimensions) > 1 else unit_param.string_value
        fps = _point_rate(path, reader.point_rate)
        # every record of the section, not the package's reading, which stops at the section's stated blocks
        # (c3d.org's Dance.c3d: its ANALOG group's 9 parameters past them) and leaves out a value it cannot shape
        parameters = _with_written_case(read_parameters(path.read_bytes() if raw is None else raw,
                                                        None if raw is None else records), written)
        modelled = set()
        for key in _MODELLED:
            p = reader.get(f"POINT:{key}")
            if p is not None and p.bytes_per_element == -1:
                try:
                    modelled.update(s.strip() for s in p.string_array.reshape(-1))
                except Exception:
                    pass
        # the package reads TRIAL:ACTUAL_START_FIELD where a file has it, its high word as 65,535 frames (and
        # ACTUAL_END_FIELD's as 65,536): past frame 65,535 it numbered the trial one frame early and read one
        # frame more than the file holds, from the padding after the data block
        first = trial_first(parameters, int(reader.header.first_frame)) if "TRIAL" in parameters else 0
        if first > FRAME_CAP and first != int(reader.first_frame):
            held = int(reader.last_frame) - first + 1
            if 0 < held < data.shape[0]:
                data, analog = data[:held], analog[:held]
        else:
            first = int(reader.first_frame)
        scale = reader.point_scale
        offsets = reader.get_analog_transform_parameters()[2] if reader.analog_used else []
    if data.shape[1] == 0:
        raise MocapFormatError(path, "C3D file holds no 3D points")
    xyz = _float32_values(data[..., :3])
    # the package's residuals are float32 (byte * |scale| rounded): made the float64 products ezc3d's reading gives
    # (residuals_and_cameras), so that a big-endian file read here and written back (little-endian, read by ezc3d)
    # reads back equal (Eb015si.c3d: 8,357 residuals 2e-7 mm apart)
    step = abs(float(scale))
    resid = np.where(data[..., 3] < 0, -1.0, np.rint(data[..., 3] / step) * step if step > 0 else data[..., 3])
    gone = (resid < 0) & (data[..., :3] != 0).any(axis=-1) & np.isfinite(data[..., :3]).all(axis=-1)
    f, m = np.nonzero(gone)  # the stored coordinates under a missing sample's word, which the package reads as -1
    stored = _stored_rows(np.column_stack([f, m, data[f, m, :3], -np.ones(len(f))]) if len(f) else None)
    xyz[resid < 0] = np.nan
    analogs = None
    if analog and np.asarray(analog[0]).size:
        a = np.asarray(analog, dtype=np.float64)  # (F, A, ratio)
        a = a.transpose(1, 0, 2).reshape(a.shape[1], -1)
        if "OFFSET" in parameters.get("ANALOG", {}):  # the package's offsets read as the C3D guide has them
            a = with_offsets(a, parameters, offsets)
        analogs = _float32_values(a)
    numbers = None if analogs is None or raw is None else _package_analog_numbers(raw, data.shape[0], data.shape[1],
                                                                                   scale, parameters, analogs)
    source = MarkerSource(format="c3d", parameters=parameters, analogs=analogs, analog_numbers=numbers,
                          first_frame=max(first, 1), missing_stored=stored)
    # (F, M) camera masks: the c3d package reads the fourth word of a point as the C3D guide has it
    cameras = np.where(resid < 0, 0, data[..., 4]).astype(np.int64)
    return labels, xyz, (resid, cameras), fps, units, "c3d", source, modelled


def _package_analog_numbers(raw: bytes, frames: int, points: int, scale: float, parameters: dict,
                           analogs: np.ndarray) -> np.ndarray | None:
    """(A, F * ratio) float64: the numbers a float C3D stored for its analog samples, for the ``c3d`` package's
    reading (which scales them in float32, so :func:`~mocapkit.io.c3d_layout.held_analogs` cannot tell them from
    its values): the samples read again from ``raw``'s data block in float64 as ezc3d reads them
    (:func:`~mocapkit.io.c3d_frames.read_frames`), then held_analogs as the ezc3d path keeps them
    (``MarkerSource.analog_numbers``), so both readers keep the same numbers. None for an integer file, or where
    that reading does not agree with the package's ``analogs`` (A, F * ratio) to float32 precision."""
    proc = raw[(raw[0] - 1) * 512 + 3]
    per_frame, = struct.unpack_from(">H" if proc == 86 else "<H", raw, 4)  # analog samples a frame
    got = read_frames(raw, 0, frames, points, per_frame, scale, parameters)
    if got is None or got[1] is None or got[1].shape != analogs.shape:
        return None
    if not np.allclose(got[1], analogs, rtol=1e-6, atol=1e-9, equal_nan=True):
        return None
    return held_analogs(got[1], parameters)


def _check_result(path: Path, markers: MarkerSet) -> MarkerSet:
    if markers.num_markers == 0 or markers.num_frames == 0:
        raise MocapFormatError(path, "C3D file holds no 3D points")
    inf = np.isinf(markers.positions)
    if np.any(inf):
        f, m, _ = np.argwhere(inf)[0]
        raise MocapFormatError(path, f"infinite coordinate of marker {markers.labels[m]!r} in frame {f + 1}")
    return markers


def apply_zero_gaps(labels, xyz, resid, unit_cm: float, zeros_as_gaps, modelled=()):
    """Turn samples stored as exact (0, 0, 0) into gaps (NaN, residual -1) in place; returns how many.

    ``zeros_as_gaps``: True turns every exact-zero sample of a marker into a gap,
    False keeps them all, None decides from the data (:func:`~mocapkit.markerset.zero_gap_mask`).
    Labels in ``modelled`` (modelled angles, forces, ...) are never touched.
    """
    if zeros_as_gaps is False:
        return 0
    skip = [m for m, label in enumerate(labels) if label in modelled]
    if zeros_as_gaps is None:
        mask = zero_gap_mask(xyz, unit_cm, skip=skip)
    elif zeros_as_gaps is True:
        mask = np.all(xyz == 0.0, axis=-1)
        mask[:, skip] = False
    else:
        raise TypeError(f"zeros_as_gaps must be True, False or None, got {zeros_as_gaps!r}")
    xyz[mask] = np.nan
    if resid is not None:
        resid[mask] = -1.0
    return int(mask.sum())


def checked_unit_cm(path, units: str) -> float:
    """Centimetres per unit of a file's stated length unit; a one-line MocapFormatError for one not known."""
    try:
        return length_unit_cm(units)
    except ValueError as exc:
        raise MocapFormatError(path, f"{exc}; the file's coordinates cannot be put on a length scale") from None


def read_c3d(path, zeros_as_gaps: bool | None = None, units: str | None = None) -> MarkerSet:
    """Read the 3D points of a C3D file; occluded samples (negative residual) become NaN.

    ``zeros_as_gaps`` (None: decide from the data; True; False): whether
    samples stored as exact (0, 0, 0), as Qualisys exports write gaps, are
    read as missing (see :func:`~mocapkit.markerset.zero_gap_mask`); the
    MarkerSet's ``zero_gaps`` says how many were. The result keeps the
    residuals and, in ``source``, the parameter section and analog channels
    :func:`write_c3d` writes back. The length unit is POINT:UNITS; where that is
    empty or absent, ``units`` when given, else mm or m as the marker distances
    say (:func:`~mocapkit.markerset.marker_units`; ``units_from`` says which).

    Raises :class:`~mocapkit.errors.MocapFormatError` for a malformed header or
    parameter section (checked before any reader runs), a file cut short
    (inside its parameter section, or partway through a frame of its data
    block; whole frames fewer than stated are read), a non-positive frame rate, infinite coordinates, no points, a
    length unit that is not one, or when neither ezc3d nor the fallback reader
    can make sense of the file.
    """
    path = Path(path)
    given = units  # the name is the file's unit below
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise MocapFormatError(path, f"cannot read: {exc.strerror or exc}") from None
    first_error = None
    got = None
    no_points = None
    ezc3d_ok, written, records = check_structure(path, raw)
    if ezc3d_ok:
        try:
            got = _read_ezc3d(path, raw)
        except MocapFormatError:
            raise
        except _NoPoints as exc:
            no_points = str(exc)
        except Exception as exc:  # ezc3d raises plain RuntimeError/ValueError on malformed files
            first_error = exc
    if got is None:
        try:
            got = _read_c3d_package(path, written, raw, records)
        except MocapFormatError as exc:
            raise MocapFormatError(path, no_points) if no_points else exc from None
        except Exception as exc:
            if no_points:
                raise MocapFormatError(path, no_points) from None
            scales = re.search(r"inconsistent scale factor! (\S+) header != (\S+) POINT:SCALE", str(exc))
            if scales:
                reason = (f"the header's point scale {float(scales[1]):.6g} disagrees with POINT:SCALE "
                          f"{float(scales[2]):.6g}, so the integer coordinates cannot be scaled with confidence; "
                          "re-export the file from the capture software")
            else:
                reason = f"not a readable C3D file ({first_error or exc})"
            raise MocapFormatError(path, reason.replace("\n", " ")) from exc
    raw_labels, xyz, (resid, cameras), fps, units, reader, source, modelled = got
    n = xyz.shape[1]
    labels = unique_labels(raw_labels, n)
    file_labels = tuple(str(s).strip() for s in list(raw_labels)[:n]) + labels[len(raw_labels):]
    layout = dict(header_layout(raw), trial_first=source.first_frame, trial_frames=xyz.shape[0],  # the whole file
                  trial_rate=fps, **spare_events(raw))
    source = dataclasses.replace(source, labels=file_labels, events=header_events(raw), layout=layout,
                                 modelled=stated_positions(source.parameters, labels))
    modelled = set(modelled) | set(source.modelled)
    stated = str(units).replace("\x00", " ").strip()  # NUL-padded in some files (and cut ones)
    units, units_from = marker_units(path, stated, xyz, given)
    unit_cm = checked_unit_cm(path, units)
    was = resid.copy(), ~np.isnan(xyz).any(axis=-1)
    zeros = apply_zero_gaps(labels, xyz, resid, unit_cm, zeros_as_gaps, modelled)
    source = dataclasses.replace(source, stored_zeros=zero_gap_words(was[0], cameras, was[1] & np.isnan(xyz).any(-1)))
    if cameras is not None:
        cameras[np.isnan(xyz).any(axis=-1)] = 0
    markers = MarkerSet(labels=labels, positions=xyz, fps=fps, units=units, name=path.stem, reader=reader,
                        residuals=resid, source=source, zero_gaps=zeros, cameras=cameras,
                        notes=repeated_labels_note(file_labels, labels), units_from=units_from)
    return _check_result(path, markers)


def _c3d_like(markers: MarkerSet, like) -> tuple[MarkerSource | None, bool]:
    """The C3D metadata to keep: ``like``'s (a MarkerSet, or a C3D file read for it), else the take's own; and
    whether it is the take's own trial, whose events are the take's (:func:`~mocapkit.io.c3d_trial.trial_frames`).
    A ``like`` holding more of the take's trial than the take (a crop written like its whole file) is cut to the
    take's frames, so that its analogs (and the force plates in them) are kept too; a resampled take's (``[::2]``)
    is sliced as the take was, its analogs dropped, as the take's own source has them."""
    own = True
    if like is not None:
        if not isinstance(like, MarkerSet):
            like = read_c3d(like, zeros_as_gaps=False)
        source = like.source
        own = source is markers.source
        if not own and source is not None and source.format == "c3d":
            held = trial_frames(markers, like)
            own = held is not None
            if own and (held.start, held.stop, held.step) != (0, like.num_frames, 1):
                source = like[held].source
    else:
        source = markers.source
    return (source, own) if source is not None and source.format == "c3d" else (None, own)


def _parts(params: dict, key: str, pop: bool = False) -> list:
    """The values of the parameter ``key`` of a group ``params`` (ezc3d's layout) and of its continuations
    KEY2, KEY3 ... past 255 entries (:func:`~mocapkit.io.c3d_layout.text_chunks`) in one list; ``pop``: each
    taken out of ``params`` as it is read."""
    out = []
    for k in [key] + [f"{key}{i}" for i in range(2, 100)]:
        if k in params:
            out += list(np.ravel((params.pop(k) if pop else params[k])["value"]))
    return out


def _c3d_object(markers: MarkerSet, source: MarkerSource | None, own: bool, first: int, rate: float):
    """An ezc3d ``c3d`` holding ``markers`` and the parameter groups and analogs of ``source``, and the (A, F *
    ratio) analog numbers to store (:func:`~mocapkit.io.c3d_layout.stored_analogs`; None without analogs) with
    their (A,) ANALOG:OFFSET, which ezc3d writes its own way (0 each) and :func:`write_c3d` writes over.
    Force plates whose analog channels are not written, and the events of another trial than the take's
    (``own`` False) or outside its frames, are left out (:mod:`mocapkit.io.c3d_trial`). ``first``: the take's
    own first frame number, 1-based, at ``rate`` Hz, the file's rate (a resampled take's differs: its header
    gets :func:`~mocapkit.io.c3d_trial.written_first`)."""
    import copy

    import ezc3d

    c = ezc3d.c3d()
    F, M = markers.num_frames, markers.num_markers
    analogs = None
    if source is not None:
        for group, params in source.parameters.items():
            c["parameters"][group] = copy.deepcopy(dict(params))
        ratio = source.analog_ratio(F)
        if ratio and source.analogs.shape[1] == F * ratio:
            analogs = source.analogs
    fit_force_plates(c["parameters"], 0 if analogs is None else analogs.shape[0], channels_held(source, own))
    fit_event_group(c["parameters"], own, markers.fps, first, F, trial_span(source.layout) if source is not None else None,
                    rate)
    first = written_first(first, markers.fps, rate)  # the take's own clock from here on
    # ezc3d's header counts from 0; past 65,535 the header holds the cap and TRIAL:ACTUAL_START_FIELD the number
    # (long_frame_parameters below), as the c3d package writes it: ezc3d wrote the number's low 16 bits
    c["header"]["points"]["first_frame"] = min(first, FRAME_CAP) - 1
    for group in ("POINT", "ANALOG"):
        if group not in c["parameters"]:
            c["parameters"][group] = copy.deepcopy(dict(ezc3d.c3d()["parameters"][group]))
    point = c["parameters"]["POINT"]
    old_labels = [str(v).strip() for v in _parts(point, "LABELS")]
    # the file's own labels while the markers are the file's (a label it repeats written as it had it)
    labels = [label.strip() for label in markers.file_labels()]
    same_markers = old_labels[:M] == labels
    texts = [str(v) for v in _parts(point, "DESCRIPTIONS")]  # the file's per-marker descriptions
    # the values the file states past the points and channels written (its spare labels: Eb015pr.c3d's 48 for 26
    # points; its unused channels' LABELS ... OFFSET: 32 for 16), kept where the points (channels) are the file's
    # own, all of them in its order; ezc3d writes each cut to USED, keep_parameters writes them as ``full`` says
    held = len(source.labels or ()) if source is not None else 0  # the file's points (its POINT:USED)
    whole = same_markers and source is not None and M == held
    # the label slots the file keeps past its points, kept too where the markers written are some of the file's
    # (a choice of them, in any order: markers.select): each label names a point the file has
    spare = [str(v) for v in _parts(point, "LABELS")][held:] if held and set(markers.labels) <= set(
        unique_labels(source.labels, held)) else []
    full = {("POINT", "LABELS"): (None, labels + spare)}
    if whole and "DESCRIPTIONS" in point:  # as the file has them (Eb015pr.c3d: 20 for 26 points)
        full[("POINT", "DESCRIPTIONS")] = dict(point["DESCRIPTIONS"], type=-1), texts
    described = dict(point["DESCRIPTIONS"]) if "DESCRIPTIONS" in point and same_markers else None
    for k in list(point):
        # POINT:DATA_START stays: ezc3d writes its own value there, keeping the file's description and lock
        if (k.startswith("LABELS") and k != "LABELS") or k.startswith("DESCRIPTIONS"):
            del point[k]  # per-marker descriptions only while the markers are the file's, in its order
    if described is not None:  # one per marker (Eb015pr.c3d has 20 for 26 markers)
        point.update(text_chunks("DESCRIPTIONS", dict(described, type=-1), (texts + [""] * M)[:M]))
    # Float data (a negative scale); its magnitude is the residuals' resolution, kept from the source.
    old_scale = np.ravel(point.get("SCALE", {}).get("value", [])) if source is not None else []
    scale = -abs(float(old_scale[0])) if len(old_scale) and np.isfinite(old_scale[0]) and old_scale[0] != 0 else -1.0
    for key, typ, value in (("LABELS", -1, labels), ("RATE", 4, np.array([markers.fps])),
                            ("UNITS", -1, [markers.units]), ("SCALE", 4, np.array([scale]))):
        old = point.get(key, {})
        point[key] = {"type": typ, "description": old.get("description", ""), "is_locked": old.get("is_locked", False),
                      "value": value}
    stated = markers.source.modelled if markers.source is not None else {}  # a TRC's or npz's modelled points
    point.update(modelled_parameters(labels, [stated.get(label, "") for label in markers.labels], point))
    analog = c["parameters"]["ANALOG"]
    A = 0 if analogs is None else analogs.shape[0]
    for key in ("LABELS", "DESCRIPTIONS", "UNITS"):  # one text per channel written, LABELS2... folded in
        old = dict(analog.get(key, {}))  # its description and lock kept, as the file had them
        meta = {"type": -1, "description": old.get("description", ""), "is_locked": old.get("is_locked", False)}
        read = values = [str(v) for v in _parts(analog, key, pop=True)]
        if key == "LABELS" or values:
            values = (values + [f"Analog{i + 1}" if key == "LABELS" else "" for i in range(len(values), A)])[:A]
            analog.update(text_chunks(key, meta, values))
        if old or key == "LABELS":  # stated as read (a label for each channel written), or none where none is
            full[("ANALOG", key)] = meta, ((values if key == "LABELS" else read[:A]) + read[A:]
                                           if analogs is not None else values)
    # the numbers the file stored under its own scales and offsets (stored_analogs), else the values read, scale 1;
    # a file without analogs whose ANALOG:RATE says 0 keeps saying so (the frame rate written there read as an
    # analog rate)
    old_rate = np.ravel(analog.get("RATE", {}).get("value", [np.nan]))
    none_at_0 = analogs is None and len(old_rate) > 0 and old_rate[0] == 0
    rate = 0.0 if none_at_0 else markers.fps * (1 if analogs is None else analogs.shape[1] // F)
    kept = None if analogs is None else stored_analogs(analogs, {**source.parameters, "ANALOG": analog},
                                                       held=source.analog_numbers)
    stored, scales, offsets, gen = (analogs, np.ones(A), np.zeros(A, dtype=int), 1.0) if kept is None else kept
    for key, typ, value in (("SCALE", 4, scales), ("OFFSET", 2, np.zeros(A, dtype=int)), ("GEN_SCALE", 4, np.array([gen])),
                            ("RATE", 4, np.array([rate]))):
        old = analog.get(key, {})
        if key in ("SCALE", "OFFSET"):  # the channels written's, then those the file states past them
            spare = np.ravel(_parts(source.parameters.get("ANALOG", {}), key))[A:] if analogs is not None else []
            full[("ANALOG", key)] = None, np.concatenate([offsets if key == "OFFSET" else value, spare]).astype(
                int if key == "OFFSET" else float)
        for k in [f"{key}{i}" for i in range(2, 100)]:  # past 255 channels: SCALE2, OFFSET2 ... made anew
            analog.pop(k, None)
        analog.update(text_chunks(key, {"type": typ, "description": old.get("description", ""),
                                        "is_locked": old.get("is_locked", False)}, value))
    data_analogs = np.zeros((1, 0, 0 if none_at_0 else F)) if analogs is None else analogs[None]
    # the trial's first and last frames and its length, kept in step with the frames written where the file
    # states them (Qualisys states POINT:LONG_FRAMES in every file), and written whenever the header's 16-bit
    # frame numbers cannot hold them (long_frame_parameters)
    beyond = first + F - 1 > FRAME_CAP  # a frame number past the header's 16-bit words
    for (group, key), param in long_frame_parameters(first, F).items():
        params = c["parameters"]
        if beyond and group not in params:
            params[group] = {"__METADATA__": {"DESCRIPTION": "", "IS_LOCKED": False}}
        if beyond or key in params.get(group, {}):
            old = params[group].get(key, {})
            params[group][key] = dict(param, description=old.get("description", param["description"]),
                                      is_locked=old.get("is_locked", param["is_locked"]))
    pts = np.ones((4, M, F))
    pts[:3] = np.transpose(markers.positions, (2, 1, 0))
    c["data"]["points"] = pts
    c["data"]["meta_points"] = {"residuals": markers.residual_or_default().T[None].astype(np.float64)}
    c["data"]["analogs"] = data_analogs
    wanted = _wanted(c["parameters"], full)
    for group in c["parameters"]:
        for key, param in c["parameters"][group].items():
            if not isinstance(param, dict):
                continue
            # a text ezc3d cannot write (a Latin-1 byte it read as '\udce9'), handed to it in a form it can:
            # keep_parameters writes the file's bytes (before 0.18.0 such a file could not be written)
            param = {k: _writable(v) for k, v in param.items()}
            value = param.get("value") if param.get("type") == -1 else None
            if isinstance(value, list) and value and all(isinstance(v, str) and not v.strip() for v in value):
                # ezc3d writes a list of empty texts with no columns, which reads back as no text at all ([''] ->
                # []); a space each keeps its entries, read back as the empty texts they were
                param = dict(param, value=[" "] * len(value))
            c["parameters"][group][key] = param
    return c, None if analogs is None else stored, wanted


def _writable(value):
    """``value`` (a parameter's field) with each text UTF-8 can encode as it is, another (holding a surrogate: a
    byte ezc3d read that is no UTF-8) with that byte replaced, as ezc3d's writer takes only those."""
    if isinstance(value, str):
        return value.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
    if isinstance(value, list):
        return [_writable(v) for v in value]
    return value


def _wanted(parameters: dict, full: dict) -> dict:
    """The parameters a written file states (:func:`~mocapkit.io.c3d_section.keep_parameters`): a copy of
    ``parameters`` (those handed to ezc3d) with each (GROUP, NAME) of ``full`` stating the values given there
    (the points' or channels' written, then those the file states past them), split NAME, NAME2 ... past 255
    entries: ``full`` maps it to ``(meta, values)``, ``meta`` its type, description and lock (None: those of
    ``parameters``' own, where it has one)."""
    import copy

    out = {group: copy.deepcopy(dict(params)) for group, params in parameters.items()}  # ezc3d holds its own class
    for (group, key), (meta, values) in full.items():
        params = out.get(group, {})
        if meta is None and key not in params:
            continue
        meta = {k: (meta or params[key])[k] for k in ("type", "description", "is_locked")}
        _parts(params, key, pop=True)
        params.update(text_chunks(key, meta, values))
    return out


def _data_block(data: bytearray, frames: int, points: int) -> np.ndarray:
    """The float data block of a C3D ezc3d wrote, as a writable (F, 4 * points + analog samples) float32 view."""
    analog, data_start = struct.unpack_from("<H", data, 4)[0], struct.unpack_from("<H", data, 16)[0]
    width = 4 * points + analog
    return np.frombuffer(data, dtype="<f4", count=frames * width, offset=(data_start - 1) * 512).reshape(frames, width)


def _put_point_words(data: bytearray, markers: MarkerSet, scale: float) -> None:
    """Write every point's fourth word as the C3D guide has it: residual byte, camera byte, -1 where missing.

    ezc3d writes the residual in the camera byte (:func:`point_words`);
    this puts the take's residuals (in units of ``|scale|``, 0 to 255) in
    the low byte and its camera masks (0 where it has none: a TRC or npz
    take) in bits 8-14, so the ``c3d`` package and capture software read
    back what the file held.
    """
    block = _data_block(data, markers.num_frames, markers.num_markers)
    res = markers.residual_or_default()
    step = abs(scale) or 1.0
    byte = np.clip(np.rint(np.where(res < 0, 0.0, res) / step), 0, 255).astype(np.int64)
    cams = np.zeros_like(byte) if markers.cameras is None else markers.cameras & 0x7F
    block[:, 3::4][:, : markers.num_markers] = np.where(res < 0, -1, (cams << 8) | byte).astype(np.float32)


def _ezc3d_bytes(c, path: Path, frames: int, points: int) -> bytearray:
    """The file ezc3d writes for ``c``, checked whole: ezc3d writes into a hidden folder beside ``path``
    (``.NAME.RANDOM.part``, named as :func:`mocapkit.io.atomic_write` names its files: on the disk the output
    goes to, not the temporary folder's), which is read and removed.

    ezc3d does not check its writes: on a full disk it leaves the file cut short, its header unfinished
    (the data start block it writes last still 1), and reports nothing. A file whose header is unfinished,
    or which is shorter than the data block the header describes (frames x (4 x points + analog samples)
    floats from the data start block), raises ``OSError(ENOSPC)`` naming ``path`` when the disk has no room
    left, else :class:`~mocapkit.errors.MocapFormatError`; nothing is written then.
    """
    import errno
    import os
    import shutil
    import tempfile

    from .outputs import missing_folders, temp_prefix

    made = missing_folders([path.absolute().parent])  # removed again, when left empty, if the write fails
    done = False
    path.parent.mkdir(parents=True, exist_ok=True)
    stage = tempfile.mkdtemp(prefix=temp_prefix(path.name), suffix=".part", dir=path.parent)
    try:
        try:
            c.write(os.path.join(stage, "out.c3d"))  # a name ending .c3d: ezc3d adds the suffix to any other
        except Exception as exc:  # ezc3d raises plain RuntimeError/ValueError
            raise MocapFormatError(path, f"cannot write C3D: {exc}".replace("\n", " ")) from None
        data = bytearray(Path(stage, "out.c3d").read_bytes())
        data_start = struct.unpack_from("<H", data, 16)[0] if len(data) >= 18 else 0
        need = (data_start - 1) * 512 + frames * (4 * points + struct.unpack_from("<H", data, 4)[0]) * 4 \
            if data_start >= 2 else None  # unfinished: ezc3d never got to write where the data starts
        if need is not None and len(data) >= need:
            done = True
            return data
        try:  # asked while the cut file still fills the disk
            room = os.statvfs(path.parent)
            full = room.f_bavail * room.f_frsize < max(need or 0, len(data)) - len(data) + (64 << 10)
        except (OSError, AttributeError):  # no statvfs (not POSIX): say what is known
            full = False
        if full:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        raise MocapFormatError(path, f"cannot write C3D: ezc3d wrote {len(data)} bytes, "
                                     + (f"not the {need} its header describes" if need else "its header unfinished"))
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        for folder in [] if done else made:
            try:
                folder.rmdir()
            except OSError:  # not empty, or never made
                pass


def write_c3d(markers: MarkerSet, path, *, like=None, stored_zeros: bool = False) -> None:
    """Write ``markers`` to a C3D file with ezc3d, atomically (temp file + rename).

    Points are written as float32 (POINT:SCALE negative), or, where the file
    kept (``like``'s, else the take's own) is the take's trial and stores 16-bit
    integers, as its integers where every value fits (:func:`~mocapkit.io.c3d_layout.integer_data`:
    an unchanged sample the file's own number, a changed one rounded to its
    step); :func:`read_c3d` reads both as float32 values, so every sample not
    changed reads back bit-identical; missing samples with
    residual -1 (and NaN coordinates, which ezc3d and the ``c3d`` package both
    read back as missing), seen ones with the take's residuals and camera
    masks (residual 0 and no camera for a sample a cleaner changed or
    filled: "interpolated" in C3D's convention), written in the fourth word
    as the C3D guide has it (:func:`_put_point_words`). Labels are the
    file's own while the markers are (:meth:`MarkerSet.file_labels`: a label
    the file repeats is written as it had it, with its POINT:DESCRIPTIONS),
    else ``markers.labels``; the events of the take's own trial within its frames
    are kept, another trial's are not, nor force plates whose analog channels are not written
    (:mod:`mocapkit.io.c3d_trial`). Rate and units come from ``markers``; every other parameter group and the
    analog channels come from ``like`` (a MarkerSet or a C3D file) or, by
    default, from the file ``markers`` was read from (``markers.source``), with
    POINT:USED and the frame counts made consistent by ezc3d; every parameter is then written as ``source``
    states it, the entries past POINT:USED and ANALOG:USED included where the points (channels) are all the
    file's, and no group of ezc3d's own (:func:`~mocapkit.io.c3d_section.keep_parameters`). Analogs are
    kept when they span the same frames as the points, as the numbers the file
    stored under its ANALOG:OFFSET, SCALE and GEN_SCALE; the header's
    interpolation gap and the data block's start are the file's where ezc3d's
    parameter section allows (:mod:`mocapkit.io.c3d_layout`).
    ``stored_zeros``: a gap the file held as exact (0, 0, 0) is written back as
    it held it while still missing (:func:`~mocapkit.io.c3d_frames.put_stored_zeros`);
    by default it is residual -1, as every other gap.
    """
    from . import atomic_write

    path = Path(check_file_path(path))  # "out/x/" names a folder: refused, not written as out/x
    if markers.num_markers == 0 or markers.num_frames == 0:
        raise MocapFormatError(path, "a C3D file needs at least one marker and one frame")
    bad = [label for label in markers.labels + markers.file_labels() if not label.isprintable() or not label.isascii()]
    if bad:
        raise MocapFormatError(path, f"marker label {bad[0]!r} is not printable ASCII, which C3D labels must be")
    checked_unit_cm(path, markers.units)
    source, own = _c3d_like(markers, like)
    # the take's own frame numbers (a TRC's Frame# column included), 1-based: the header's, the events kept
    first = max(int(markers.source.first_frame), 1) if markers.source is not None else 1
    # the clock of those frame numbers: the file's rate (a resampled take's is not the file's)
    rate = trial_rate(markers.source.layout, markers.fps) if markers.source is not None else markers.fps
    c, stored, wanted = _c3d_object(markers, source, own, first, rate)
    oversized = oversized_parameter(c["parameters"]) or oversized_parameter(wanted)
    if oversized:
        raise MocapFormatError(path, f"cannot write C3D: {oversized}, more than the 255 a C3D parameter states")
    data = _ezc3d_bytes(c, path, markers.num_frames, markers.num_markers)
    # every parameter as the file read states it, ezc3d's own groups left out (ROTATION kept past 65,535 frames)
    data = keep_parameters(data, wanted, ("ROTATION",) if markers.num_frames > FRAME_CAP else ())
    # ezc3d writes -1 as the header's scale whatever POINT:SCALE says; readers that check the two
    # agree (the c3d package) refuse the mismatch, so the header gets POINT:SCALE (Intel byte order).
    scale = float(c["parameters"]["POINT"]["SCALE"]["value"][0])
    struct.pack_into("<f", data, 12, scale)
    _put_point_words(data, markers, scale)
    put_missing_stored(_data_block(data, markers.num_frames, markers.num_markers), markers)
    if stored_zeros:
        put_stored_zeros(_data_block(data, markers.num_frames, markers.num_markers), markers, scale)
    if stored is not None:
        put_analogs(data, markers.num_frames, markers.num_markers, stored)
    events = fit_header_events(source.events, own, markers.fps, first, markers.num_frames, trial_span(source.layout),
                               rate) if source is not None else ()
    put_header_events(data, events)
    if source is not None and own:  # the slots no event uses, as the take's own file had them
        put_spare_events(data, source.layout, min(len(events), 18))
    if source is not None and source.layout:
        put_header_gap(data, source.layout["interpolation_gap"])
        data = keep_data_start(data, source.layout)
    # the take's own integer file keeps its storage where every value fits (else float, as ezc3d wrote); another
    # trial's samples, never on that file's steps, are not rounded to them
    step = integer_scale(source.parameters, markers.units) if source is not None and own else None
    if step is not None:
        data = integer_data(data, markers.num_frames, markers.num_markers, step) or data
    with atomic_write(path, "wb") as fh:
        fh.write(data)
