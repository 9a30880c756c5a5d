"""The source BVH's own channel values kept in an .npz made from it, for the Euler writer of a later step.

A take read from a BVH and written as .npz (``mocapkit corrupt take.bvh g.npz``, ``mocapkit convert take.bvh
take.npz``) holds unit quaternions: which of a rotation's Euler triples the file wrote (its whole turns, its
branch of the middle angle) is lost, and a BVH written from the .npz later (``mocapkit fill g.npz -o f.bvh``)
would write every cell, untouched ones included, on the branch the plain conversion gives: the same rotation,
but a 180 or 360 degree jump in a curve editor and in any channel diff. So the .npz keeps the file's numbers,
``(F, C)`` degrees and file units in the columns of the channel layout the BVH writer writes
(:data:`LAYOUT_KEY`, JSON), and :func:`mocapkit.io.bvh.write_bvh` given such an .npz as ``like`` writes every cell
whose rotation is still the file's with the file's numbers, and a changed one on the branch nearest them.
:func:`mocapkit.io.npz.read_npz` ignores both arrays; the Motion read is the same.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

__all__ = ["VALUES_KEY", "LAYOUT_KEY", "kept_arrays", "kept_values"]

VALUES_KEY = "source_channel_values"
LAYOUT_KEY = "source_channel_layout"


def kept_arrays(values: np.ndarray | None, channels) -> dict[str, np.ndarray]:
    """The arrays an .npz keeps beside a take (``write_npz``'s ``extra``): the source file's ``values`` (F, C) in
    the columns of ``channels`` (one tuple of channel names per joint); none when ``values`` is None."""
    if values is None:
        return {}
    return {VALUES_KEY: np.asarray(values, dtype=np.float64), LAYOUT_KEY: np.array(json.dumps([list(c) for c in channels]))}


def kept_values(path, channels, num_frames: int) -> np.ndarray | None:
    """The source file's numbers (F, C) an .npz at ``path`` keeps for a take written with ``channels`` (one tuple per
    joint) over ``num_frames`` frames; None when ``path`` is no such .npz, keeps none, or keeps them for another
    layout or length (the take was cut, resampled or put on other channels since)."""
    from ..errors import MocapError
    from .npz import load_arrays

    path = Path(path)
    if path.suffix.lower() != ".npz" or not path.is_file():
        return None
    try:
        data = load_arrays(path)
        values, layout = data.get(VALUES_KEY), data.get(LAYOUT_KEY)
        if values is None or layout is None or layout.dtype.kind != "U" or layout.ndim != 0:
            return None
        said = json.loads(str(layout))
    except (MocapError, OSError, ValueError):
        return None
    width = sum(len(c) for c in channels)
    if ([list(c) for c in channels] != said or values.dtype.kind != "f"
            or values.shape != (num_frames, width)):
        return None
    return np.asarray(values, dtype=np.float64)
