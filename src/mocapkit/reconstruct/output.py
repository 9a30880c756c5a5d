"""What a reconstruction's ``.npz`` holds: the Motion, and arrays that say what it is without mocapkit.

``mocapkit reconstruct -o OUT.npz`` writes mocapkit's native Motion npz (:mod:`mocapkit.io.npz`: local
rotations, root positions, skeleton; ``mocapkit.load`` reads it back), and beside it the arrays a user of
numpy alone looks for: the global joint positions (F, J, 3) with their length unit, the joint names, the
frame rate, the control signal it was reconstructed from, and a ``contents`` text naming every array with its
shape and unit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import SkeletonError
from ..joints import unit_scale_cm

__all__ = ["described_arrays", "save_reconstruction", "UNIT_NAMES"]

#: Centimetres per unit -> the unit's name, for ``length_unit``.
UNIT_NAMES = {0.1: "mm", 1.0: "cm", 2.54: "in", 10.0: "dm", 30.48: "ft", 100.0: "m"}

_CONTENTS = """mocapkit reconstruction ({method}), a mocapkit Motion npz (mocapkit.load reads it).
positions: float64 (F, J, 3), global joint positions, in length_unit ({unit}), the skeleton's up axis.
joint_names: (J,) the joints of positions and rotations, in order; parents: (J,) each joint's parent (-1: root).
fps: frames per second; F = {frames} frames.
rotations: float64 (F, J, 4), local joint rotations, unit quaternions (w, x, y, z), relative to the parent.
root_positions: float64 (F, 3), the root joint's position, in length_unit.
offsets: float64 (J, 3), each joint's offset from its parent at rest, in length_unit.
cm_per_unit: centimetres per length unit (NaN when it cannot be told).
method: the control signal: markers, accelerometers or ssg (gappy markers)."""


def _unit(motion) -> tuple[float, str]:
    """Centimetres per length unit of ``motion``'s skeleton and the unit's name ("unknown" where no human height
    or stated unit tells it, NaN cm)."""
    try:
        cm = unit_scale_cm(motion.skeleton)
    except SkeletonError:
        return float("nan"), "unknown"
    name = next((n for c, n in UNIT_NAMES.items() if np.isclose(cm, c, rtol=1e-6)), f"{cm:g} cm")
    return cm, name


def described_arrays(motion, method: str) -> dict:
    """The arrays beside the Motion in a reconstruction's npz (module docstring): ``positions`` (F, J, 3) float64
    global joint positions in the skeleton's length unit, ``length_unit`` (str), ``cm_per_unit`` (float),
    ``method`` (str) and ``contents`` (str: every array with its shape and unit)."""
    cm, unit = _unit(motion)
    positions = motion.global_positions()
    contents = _CONTENTS.format(method=method, unit=unit, frames=motion.num_frames)
    return {"positions": positions, "length_unit": np.array(unit), "cm_per_unit": np.array(cm),
            "method": np.array(method), "contents": np.array(contents)}


def save_reconstruction(motion, path, method: str, *, asf=None) -> Path:
    """Write a reconstruction to ``path`` (.bvh, .amc, .npz) atomically: an npz says what it holds
    (:func:`described_arrays`), the other formats are written as :func:`mocapkit.io.save` writes them.
    ``method``: "markers", "accelerometers" or "ssg"; ``asf``: an AMC's skeleton file."""
    from .. import io

    path = Path(path)
    extra = {"extra": described_arrays(motion, method)} if path.suffix.lower() == ".npz" else {}
    return io.save(motion, path, asf=asf, like=False, copy_asf=False, **extra)
