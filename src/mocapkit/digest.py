"""The digest of a take's samples: what a decisions file names its take by (:mod:`mocapkit.cleaning.decisions`).

Kept apart from the decisions so that reading it (``mocapkit info`` prints it, for a decisions file written
by hand) imports no cleaning code.
"""

from __future__ import annotations

import hashlib
import json

import numpy as np

from .markerset import MarkerSet
from .motion import Motion

__all__ = ["take_digest"]


def take_digest(motion: Motion) -> str:
    """SHA-256 (hex) of a take's samples: joint names, rate, rotations, root positions, animated offsets; for a
    :class:`~mocapkit.markerset.MarkerSet`, labels, rate, unit, positions, residuals and camera masks.

    Two reads of the same file give the same digest; any change of a sample changes it.
    """
    h = hashlib.sha256()
    if isinstance(motion, MarkerSet):  # a marker capture: labels, rate, unit, positions, residuals, camera masks
        h.update(json.dumps(["markers", list(motion.labels), float(motion.fps), motion.units]).encode())
        arrays = [motion.positions] + [a for a in (motion.residuals, motion.cameras) if a is not None]
    else:
        h.update(json.dumps([list(motion.skeleton.joint_names), float(motion.fps)]).encode())
        arrays = [motion.rotations, motion.root_positions] + ([motion.translations] if motion.translations is not None else [])
    for a in arrays:
        a = np.ascontiguousarray(a, dtype="<f8")
        h.update(np.where(np.isnan(a), np.nan, a).tobytes())  # one bit pattern for every NaN
    return h.hexdigest()
