"""mocapkit's native format: a numpy ``.npz`` that round-trips a Motion (or MarkerSet) losslessly.

Every array is stored as is (float64, NaN included); the skeleton's text
fields (channels, limits) are stored as JSON strings. Files are read with
``allow_pickle=False``: an npz is untrusted input and can execute no code.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from ..errors import MocapFormatError
from ..motion import Motion, Skeleton
from . import atomic_write

__all__ = ["read_npz", "write_npz", "FORMAT_VERSION"]

FORMAT_VERSION = 1


def write_npz(obj, path, compress: bool = True) -> None:
    """Write a Motion or MarkerSet to ``path`` atomically (temp file + rename)."""
    from .c3d import MarkerSet

    if isinstance(obj, Motion):
        sk = obj.skeleton
        arrays = {
            "kind": np.array("motion"),
            "format_version": np.array(FORMAT_VERSION),
            "rotations": obj.rotations,
            "root_positions": obj.root_positions,
            "fps": np.array(obj.fps),
            "name": np.array(obj.name),
            "joint_names": np.array(sk.joint_names),
            "parents": sk.parents,
            "offsets": sk.offsets,
            "end_site_parents": sk.end_site_parents,
            "end_site_offsets": sk.end_site_offsets,
            "channels": np.array(json.dumps(sk.channels)),
            "limits": np.array(json.dumps(sk.limits)),
            "unit_cm": np.array(np.nan if sk.unit_cm is None else sk.unit_cm),
        }
        if sk.axes is not None:
            arrays["axes"] = sk.axes
        if obj.translations is not None:
            arrays["translations"] = obj.translations
    elif isinstance(obj, MarkerSet):
        arrays = {
            "kind": np.array("markers"),
            "format_version": np.array(FORMAT_VERSION),
            "labels": np.array(obj.labels),
            "positions": obj.positions,
            "fps": np.array(obj.fps),
            "units": np.array(obj.units),
            "name": np.array(obj.name),
        }
    else:
        raise TypeError(f"write_npz takes a Motion or MarkerSet, got {type(obj).__name__}")
    with atomic_write(path, "wb") as fh:
        (np.savez_compressed if compress else np.savez)(fh, **arrays)


def read_npz(path):
    """Read a file written by :func:`write_npz` (a Motion, or a MarkerSet for marker files)."""
    from .c3d import MarkerSet

    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as exc:
        raise MocapFormatError(path, f"not a readable .npz file ({exc})") from None
    kind = str(data.get("kind", ""))
    version = int(data.get("format_version", -1))
    if version != FORMAT_VERSION:
        raise MocapFormatError(path, f"not a mocapkit npz (format_version {version}, expected {FORMAT_VERSION})")
    try:
        if kind == "markers":
            return MarkerSet(
                labels=tuple(str(s) for s in data["labels"]),
                positions=data["positions"],
                fps=float(data["fps"]),
                units=str(data["units"]),
                name=str(data["name"]),
                reader="npz",
            )
        if kind != "motion":
            raise MocapFormatError(path, f"unknown npz kind {kind!r}")
        channels = json.loads(str(data["channels"]))
        limits = json.loads(str(data["limits"]))
        unit_cm = float(data["unit_cm"])
        skeleton = Skeleton(
            joint_names=tuple(str(s) for s in data["joint_names"]),
            parents=data["parents"],
            offsets=data["offsets"],
            end_site_parents=data["end_site_parents"],
            end_site_offsets=data["end_site_offsets"],
            channels=None if channels is None else tuple(tuple(c) for c in channels),
            axes=data.get("axes"),
            limits=None if limits is None else tuple(tuple(tuple(p) for p in jl) for jl in limits),
            unit_cm=None if np.isnan(unit_cm) else unit_cm,
        )
        return Motion(
            skeleton=skeleton,
            rotations=data["rotations"],
            root_positions=data["root_positions"],
            fps=float(data["fps"]),
            name=str(data["name"]),
            translations=data.get("translations"),
        )
    except KeyError as exc:
        raise MocapFormatError(path, f"npz lacks the array {exc.args[0]!r}") from None
    except (ValueError, TypeError) as exc:
        if isinstance(exc, MocapFormatError):
            raise
        raise MocapFormatError(path, f"inconsistent npz contents: {exc}") from None
