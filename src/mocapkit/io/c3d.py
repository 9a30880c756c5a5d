"""C3D optical marker files: a :class:`MarkerSet` of labelled 3D trajectories, NaN where occluded.

Read with ezc3d, the reference C3D library. A few real files in circulation
have parameter-section quirks ezc3d refuses (c3d.org's PhoeniX samples: "OFFSET
parameter is not an INT"), a header that claims no points (the PhaseSpace
sample) or no ``POINT:DATA_START`` parameter, which makes ezc3d read the data
block from the wrong offset (c3d.org sample28); for those the pure-Python ``c3d`` package reads the data block, and
the MarkerSet records which reader was used in ``reader``.
"""

from __future__ import annotations

import dataclasses
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MocapFormatError, SkeletonError
from ..motion import check_fps, readonly_view

__all__ = ["MarkerSet", "read_c3d"]

_UNIT_CM = {"mm": 0.1, "cm": 1.0, "m": 100.0, "dm": 10.0, "in": 2.54, "inch": 2.54}


@dataclass(frozen=True, eq=False)
class MarkerSet:
    """Labelled marker trajectories.

    Attributes
    ----------
    labels : tuple of str, (M,)
    positions : float array (F, M, 3)
        Marker positions in ``units``; NaN where the marker was not seen.
    fps : float
    units : str
        Length unit as the file states it ("mm" when it states none).
    name : str
    reader : str
        "ezc3d" or "c3d" (the fallback for quirky files).
    """

    labels: tuple[str, ...]
    positions: np.ndarray
    fps: float
    units: str = "mm"
    name: str = ""
    reader: str = "ezc3d"

    def __post_init__(self):
        pos = np.asarray(self.positions, dtype=np.float64)
        labels = tuple(str(label) for label in self.labels)
        if pos.ndim != 3 or pos.shape[1:] != (len(labels), 3):
            raise ValueError(f"positions: expected shape (F, {len(labels)}, 3), got {pos.shape}")
        object.__setattr__(self, "positions", readonly_view(pos))
        object.__setattr__(self, "labels", labels)
        object.__setattr__(self, "fps", check_fps(self.fps))

    @property
    def num_frames(self) -> int:
        return int(self.positions.shape[0])

    @property
    def num_markers(self) -> int:
        return len(self.labels)

    @property
    def unit_cm(self) -> float:
        """Centimetres per unit of ``positions``."""
        try:
            return _UNIT_CM[self.units.lower()]
        except KeyError:
            raise ValueError(f"unknown C3D length unit {self.units!r}") from None

    def missing(self) -> np.ndarray:
        """Boolean (F, M) mask of occluded samples."""
        return np.any(np.isnan(self.positions), axis=-1)

    def select(self, labels) -> "MarkerSet":
        """The markers named in ``labels``, in that order."""
        idx = []
        for label in labels:
            if label not in self.labels:
                raise KeyError(f"no marker {label!r}; markers are: {', '.join(self.labels)}")
            idx.append(self.labels.index(label))
        return dataclasses.replace(self, labels=tuple(labels), positions=self.positions[:, idx])

    def __getitem__(self, key) -> "MarkerSet":
        if not isinstance(key, slice):
            raise TypeError("a MarkerSet is sliced by frames: markers[a:b]")
        step = 1 if key.step is None else int(key.step)
        return dataclasses.replace(self, positions=self.positions[key], fps=self.fps / step)

    def __repr__(self) -> str:
        miss = 100.0 * self.missing().mean() if self.positions.size else 0.0
        return f"MarkerSet({self.name!r}, {self.num_frames} frames @ {self.fps:g} fps, {self.num_markers} markers, {miss:.1f}% missing)"


def _clean_labels(raw, n: int) -> tuple[str, ...]:
    labels = [str(s).strip() for s in list(raw)[:n]]
    labels += [f"M{i + 1:03d}" for i in range(len(labels), n)]
    # Duplicate labels happen in the wild; keep them addressable.
    seen: dict[str, int] = {}
    out = []
    for label in labels:
        label = label or f"M{len(out) + 1:03d}"
        k = seen.get(label, 0)
        seen[label] = k + 1
        out.append(label if k == 0 else f"{label}_{k + 1}")
    return tuple(out)


def _point_rate(path: Path, rate) -> float:
    """The file's point frame rate, checked against :data:`~mocapkit.motion.FPS_RANGE`."""
    try:
        return check_fps(rate, "point frame rate")
    except SkeletonError as exc:
        raise MocapFormatError(path, str(exc)) from None


def _read_ezc3d(path: Path) -> MarkerSet | None:
    import ezc3d

    c = ezc3d.c3d(str(path))
    pts = c["data"]["points"]  # (4, M, F)
    n = pts.shape[1]
    if n == 0 or pts.shape[2] == 0:
        return None
    params = c["parameters"]["POINT"]
    start = params["DATA_START"]["value"] if "DATA_START" in params else []
    if len(start) == 0 or int(start[0]) < 2:
        # Without POINT:DATA_START ezc3d reads the data block from the wrong place
        # (seen on c3d.org sample28); the fallback uses the header's pointer.
        return None
    labels = list(params["LABELS"]["value"]) if "LABELS" in params else []
    for extra in ("LABELS2", "LABELS3", "LABELS4"):
        if extra in params:
            labels += list(params[extra]["value"])
    units = params["UNITS"]["value"][0].strip() if "UNITS" in params and len(params["UNITS"]["value"]) else ""
    xyz = np.transpose(pts[:3], (2, 1, 0)).astype(np.float64)
    resid = c["data"]["meta_points"]["residuals"][0].T  # (F, M)
    xyz[resid < 0] = np.nan
    return MarkerSet(
        labels=_clean_labels(labels, n),
        positions=xyz,
        fps=_point_rate(path, c["header"]["points"]["frame_rate"]),
        units=units or "mm",
        name=path.stem,
        reader="ezc3d",
    )


def _read_c3d_package(path: Path) -> MarkerSet:
    import c3d

    with open(path, "rb") as fh, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = c3d.Reader(fh)
        frames = [points for _, points, _ in reader.read_frames()]
        if not frames:
            raise MocapFormatError(path, "C3D file holds no point frames")
        data = np.asarray(frames, dtype=np.float64)  # (F, M, 5): x y z residual cameras
        param = reader.get("POINT:LABELS")
        labels = list(param.string_array) if param is not None else []
        unit_param = reader.get("POINT:UNITS")
        units = unit_param.string_value.strip() if unit_param is not None else ""
        fps = _point_rate(path, reader.point_rate)
    xyz = data[..., :3].copy()
    xyz[data[..., 3] < 0] = np.nan
    return MarkerSet(
        labels=_clean_labels(labels, xyz.shape[1]),
        positions=xyz,
        fps=fps,
        units=units or "mm",
        name=path.stem,
        reader="c3d",
    )


# Types ezc3d takes for granted (a char ANALOG:USED crashes it): parameters of another type or
# without a value send the file to the pure-Python reader instead.
_EXPECTED_TYPES = {
    ("POINT", "USED"): (2,), ("POINT", "FRAMES"): (2, 4), ("POINT", "DATA_START"): (2,),
    ("POINT", "SCALE"): (4,), ("POINT", "RATE"): (4,), ("POINT", "LABELS"): (-1,), ("POINT", "LABELS2"): (-1,),
    ("POINT", "DESCRIPTIONS"): (-1,), ("POINT", "UNITS"): (-1,), ("ANALOG", "USED"): (2,),
    ("ANALOG", "RATE"): (4,), ("ANALOG", "SCALE"): (4,), ("ANALOG", "GEN_SCALE"): (4,), ("ANALOG", "OFFSET"): (2,),
    ("ANALOG", "LABELS"): (-1,), ("ANALOG", "UNITS"): (-1,), ("ANALOG", "FORMAT"): (-1,), ("ANALOG", "BITS"): (2,),
    ("TRIAL", "ACTUAL_START_FIELD"): (2,), ("TRIAL", "ACTUAL_END_FIELD"): (2,), ("TRIAL", "CAMERA_RATE"): (4,),
    ("FORCE_PLATFORM", "USED"): (2,), ("FORCE_PLATFORM", "TYPE"): (2,), ("FORCE_PLATFORM", "CHANNEL"): (2,),
    ("FORCE_PLATFORM", "CORNERS"): (4,), ("FORCE_PLATFORM", "ORIGIN"): (4,), ("FORCE_PLATFORM", "ZERO"): (2,),
}


def _check_structure(path: Path, b: bytes) -> bool:
    """Refuse a C3D whose header or parameter section is malformed, before any C++ reader sees it.

    ezc3d (C++) crashes or loops on some malformed parameter sections and
    allocates what the header claims; this walk checks, in Python and within
    the file's size: the header key, the parameter section pointer and its
    block count, every parameter record (name, type -1/1/2/4, at most 7
    dimensions, its data and description inside the section, the pointer to
    the next record moving forward) and that the data block the header
    describes (points, analog samples, frames, integer or float) fits in the file,
    and that an integer ``POINT:USED`` agrees with the header's point count (a
    section claiming 32,767 markers against a header of 33 is refused, not read).
    Returns whether ezc3d may read the file: False when a parameter it relies on
    has an unexpected type or no value (the pure-Python reader copes with those).
    """
    n = len(b)

    def fail(reason: str):
        raise MocapFormatError(path, reason)

    if n < 512:
        fail(f"not a C3D file: {n} bytes, shorter than the 512-byte header")
    if b[1] != 0x50:
        fail(f"not a C3D file: header key is {b[1]:#04x}, expected 0x50")
    pblock = b[0]
    start = (pblock - 1) * 512
    if pblock < 2 or start + 4 > n:
        fail(f"parameter section at block {pblock} is outside the file ({n} bytes)")
    proc = b[start + 3]
    if proc not in (84, 85, 86):
        fail(f"unknown processor type {proc} in the parameter section (expected 84, 85 or 86)")
    e = ">" if proc == 86 else "<"
    nblocks = b[start + 2]
    if start + nblocks * 512 > n:
        fail(f"truncated file: the parameter section claims {nblocks} blocks, the file ends inside it")
    end = n  # real files understate the block count (c3d.org's Dance, golfswing): records may run on
    i = start + 4
    groups: dict[int, str] = {}
    used: set[int] = set()
    typed: list[tuple[int, str, int, int]] = []  # (group id, name, type, data bytes)
    value_at: dict[tuple[int, str], int] = {}  # (group id, name) -> byte offset of its data
    count = 0
    while nblocks and i + 2 <= end:
        nlen = abs(struct.unpack_from("b", b, i)[0])
        gid = struct.unpack_from("b", b, i + 1)[0]
        if nlen == 0 or gid == 0:
            break  # end of the parameters
        name = b[i + 2 : i + 2 + nlen]
        at = i + 2 + nlen
        if at + 2 > end:
            fail(f"parameter record at byte {i} runs past the parameter section")
        if not all(32 <= c < 127 for c in name):
            fail(f"parameter record at byte {i} has a malformed name {name!r}")
        nxt = struct.unpack_from(e + "h", b, at)[0]
        body = at + 2
        if gid < 0:
            if gid == -128:
                fail(f"parameter record at byte {i}: group id 128 is out of range (1 to 127)")
            if -gid in groups:
                fail(f"parameter section defines group id {-gid} twice ({groups[-gid]}, {name.decode().upper()})")
            groups[-gid] = name.decode().upper()
            need = 1
            if body + 1 <= end:
                need += b[body]
        else:
            used.add(gid)
            if body + 2 > end:
                fail(f"parameter {name.decode()} runs past the parameter section")
            typ = struct.unpack_from("b", b, body)[0]
            ndim = b[body + 1]
            if typ not in (-1, 1, 2, 4):
                fail(f"parameter {name.decode()} has type {typ} (expected -1, 1, 2 or 4)")
            if ndim > 7 or body + 2 + ndim > end:
                fail(f"parameter {name.decode()} has {ndim} dimensions")
            size = abs(typ)
            for d in b[body + 2 : body + 2 + ndim]:
                size *= d
            typed.append((gid, name.decode().upper(), typ, size if typ != -1 or ndim else 0))
            value_at[(gid, name.decode().upper())] = body + 2 + ndim
            need = 2 + ndim + size + 1
            if body + need <= end:
                need += b[body + need - 1]
        if body + need > end:
            fail(f"parameter record {name.decode()} runs past the parameter section")
        count += 1
        if nxt == 0:
            break
        if nxt < 0 or nxt < need + 2:
            fail(f"parameter record {name.decode()}: the offset to the next record ({nxt}) points backwards or inside it")
        i = at + nxt
    missing = used - set(groups)
    if missing:
        fail(f"parameters belong to group ids {sorted(missing)} that the parameter section does not define")
    ezc3d_ok = len({(gid, name) for gid, name, _, _ in typed}) == len(typed)  # no parameter defined twice
    for gid, name, typ, size in typed:
        want = _EXPECTED_TYPES.get((groups[gid], name))
        if want is not None and (typ not in want or size < abs(typ)):
            ezc3d_ok = False
        if typ == -1 and size == 0:  # a string without dimensions (ezc3d: SIGSEGV)
            ezc3d_ok = False
    points, analog, first, last = struct.unpack_from(e + "4H", b, 2)
    have = {(groups[gid], name) for gid, name, _, _ in typed}
    if analog and not {("ANALOG", k) for k in ("USED", "OFFSET", "SCALE", "GEN_SCALE")} <= have:
        ezc3d_ok = False  # analog samples without their scaling parameters (ezc3d: SIGSEGV)
    if points and ("POINT", "USED") not in have:
        ezc3d_ok = False
    scale = struct.unpack_from(e + "f", b, 12)[0]
    data_start = struct.unpack_from(e + "H", b, 16)[0]
    if points == 0:
        return ezc3d_ok  # some writers leave the header empty; the parameters decide (the fallback reader)
    used = _point_used(b, e, groups, typed, value_at)
    if used is not None and used != points:
        fail(f"the parameter section disagrees with the header: POINT:USED is {used} markers, "
             f"the header says {points}")
    if last < first:
        fail(f"header: last frame {last} comes before the first frame {first}")
    if data_start < 2:
        fail(f"header: data block at block {data_start}")
    size = 4 if (proc == 85 or scale < 0 or not np.isfinite(scale)) else 2
    frames = last - first + 1
    need = (data_start - 1) * 512 + frames * (4 * points + analog) * (2 if size == 2 else 4)
    if need > n and (data_start - 1) * 512 + frames * (4 * points + analog) * 2 > n:
        fail(f"truncated file: {frames} frames of {points} points and {analog} analog samples need "
             f"{need} bytes, the file has {n}")
    return ezc3d_ok


def _point_used(b: bytes, e: str, groups: dict, typed: list, value_at: dict) -> int | None:
    """The first value of an integer ``POINT:USED`` parameter (read as unsigned, like the header's count), or None."""
    for gid, name, typ, size in typed:
        if groups.get(gid) == "POINT" and name == "USED" and typ == 2 and size >= 2:
            return struct.unpack_from(e + "H", b, value_at[(gid, name)])[0]
    return None


def _check_result(path: Path, markers: MarkerSet) -> MarkerSet:
    if markers.num_markers == 0 or markers.num_frames == 0:
        raise MocapFormatError(path, "C3D file holds no 3D points")
    inf = np.isinf(markers.positions)
    if np.any(inf):
        f, m, _ = np.argwhere(inf)[0]
        raise MocapFormatError(path, f"infinite coordinate of marker {markers.labels[m]!r} in frame {f + 1}")
    return markers


def read_c3d(path) -> MarkerSet:
    """Read the 3D points of a C3D file; occluded samples (negative residual) become NaN.

    Raises :class:`~mocapkit.errors.MocapFormatError` for a malformed header or
    parameter section (checked before any reader runs), a data block the file
    is too short for, a non-positive frame rate, infinite coordinates, no
    points, or when neither ezc3d nor the fallback reader can make sense of the file.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise MocapFormatError(path, f"cannot read: {exc.strerror or exc}") from None
    first_error = None
    if _check_structure(path, raw):
        try:
            markers = _read_ezc3d(path)
            if markers is not None:
                return _check_result(path, markers)
        except Exception as exc:  # ezc3d raises plain RuntimeError/ValueError on malformed files
            first_error = exc
    try:
        markers = _read_c3d_package(path)
    except MocapFormatError:
        raise
    except Exception as exc:
        reason = f"not a readable C3D file ({first_error or exc})"
        raise MocapFormatError(path, reason.replace("\n", " ")) from exc
    return _check_result(path, markers)
