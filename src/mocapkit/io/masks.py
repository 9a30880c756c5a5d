"""The ground-truth file of a corruption (``NAME.mask.npz``): which joint samples changed, and how.

:func:`mocapkit.corrupt.corrupt` returns the corrupted motion, a mask and, for
artificial errors, one record per error. ``mocapkit corrupt`` writes them
beside the corrupted take so that a detector or cleaner can be scored
against the truth later (``mocapkit plot`` shades it). The file holds:

- ``mask`` bool (F, J): True where a joint sample was changed;
- ``joint_names`` (J,) str, ``kind`` and ``seed`` of the corruption; of a marker capture's gaps
  (``corrupt --kind gaps`` of a .c3d, .trc or marker .npz), ``labels`` (M,) str in its place, and ``mask``
  (F, M) True where a marker sample was made missing;
- ``params``: the corruption's parameters as JSON;
- ``errors``: the error records as a JSON list of objects.

>>> import tempfile, pathlib, numpy as np
>>> p = pathlib.Path(tempfile.mkdtemp()) / "x.mask.npz"
>>> _ = write_mask(p, np.eye(3, dtype=bool), ["a", "b", "c"], kind="noise", seed=1)
>>> int(read_mask(p).sum())
3
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import MocapFormatError
from ..words import plural

__all__ = ["write_mask", "read_mask", "error_record", "mask_path_for"]


def mask_path_for(path: os.PathLike | str) -> Path:
    """The mask file that goes with a corrupted take: ``noisy.bvh`` -> ``noisy.mask.npz``."""
    path = Path(path)
    stem = path.name[: -len(path.suffix)] if path.suffix else path.name
    return path.with_name(stem + ".mask.npz")


def error_record(record) -> dict:
    """One error record of :func:`mocapkit.corrupt.real_errors` (named tuple, dataclass or dict) as a plain dict."""
    if isinstance(record, dict):
        return record
    if hasattr(record, "_asdict"):
        return dict(record._asdict())
    if dataclasses.is_dataclass(record):
        return dataclasses.asdict(record)
    return {"error": str(record)}


def write_mask(path, mask: np.ndarray, joint_names: Sequence[str], *, kind: str, seed, params: dict | None = None,
               records: Sequence = (), markers: bool = False) -> Path:
    """Write the ground truth of one corruption to ``path`` atomically; returns the path. ``markers``: ``mask`` is
    (F, M) over a marker capture's markers and ``joint_names`` their labels, stored as ``labels``."""
    from . import atomic_write

    path = Path(path)
    names = {"labels" if markers else "joint_names": np.array(list(joint_names), dtype=str)}
    with atomic_write(path, "wb") as fh:
        np.savez_compressed(
            fh,
            mask=np.asarray(mask, dtype=bool),
            **names,
            kind=np.array(kind),
            seed=np.array(seed if seed is not None else -1),
            params=np.array(json.dumps(params or {})),
            errors=np.array(json.dumps([error_record(r) for r in records], default=str)),
        )
    return path


def read_mask(path, frames: int | None = None) -> np.ndarray:
    """The (F, J) bool mask of a ``.mask.npz``; ``frames``: refuse a mask of another length (one line)."""
    path = Path(path)
    from .npz import load_arrays

    arrays = load_arrays(path)  # checked before inflating: a zip bomb is refused in one line
    try:
        mask = np.asarray(arrays["mask"], dtype=bool)
    except (ValueError, KeyError) as exc:
        raise MocapFormatError(path, f"not a mocapkit mask file ({type(exc).__name__}: {exc})") from None
    if mask.ndim != 2:
        raise MocapFormatError(path, f"the mask must be (frames, joints), got shape {mask.shape}")
    if frames is not None and mask.shape[0] != frames:
        raise MocapFormatError(path, f"the mask has {plural(mask.shape[0], 'frame')} and the take {frames}")
    return mask
