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
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MocapFormatError
from ..motion import _readonly

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
        object.__setattr__(self, "positions", _readonly(pos))
        object.__setattr__(self, "labels", labels)
        object.__setattr__(self, "fps", float(self.fps))

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
        fps=float(c["header"]["points"]["frame_rate"]),
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
        fps = float(reader.point_rate)
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


def read_c3d(path) -> MarkerSet:
    """Read the 3D points of a C3D file; occluded samples (negative residual) become NaN.

    Raises :class:`~mocapkit.errors.MocapFormatError` when neither ezc3d nor the
    fallback reader can make sense of the file.
    """
    path = Path(path)
    first_error = None
    try:
        markers = _read_ezc3d(path)
        if markers is not None:
            return markers
    except Exception as exc:  # ezc3d raises plain RuntimeError/ValueError on malformed files
        first_error = exc
    try:
        markers = _read_c3d_package(path)
    except MocapFormatError:
        raise
    except Exception as exc:
        reason = f"not a readable C3D file ({first_error or exc})"
        raise MocapFormatError(path, reason.replace("\n", " ")) from exc
    if markers.num_markers == 0 or markers.num_frames == 0:
        raise MocapFormatError(path, "C3D file holds no 3D points")
    return markers
