"""What every reconstruction method needs from a MotionDatabase: per-frame values computed clip by clip."""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..database import MotionDatabase
from ..features import virtual_markers
from ..motion import Motion, Skeleton


def per_clip(db: MotionDatabase, fn: Callable[[Motion], np.ndarray]) -> np.ndarray:
    """``fn`` applied to every clip of ``db`` (float64 Motions), stacked along frames: (N, ...).

    For values that need a whole clip (derivatives, root frames) and must not
    run across clip boundaries.
    """
    parts = [np.asarray(fn(db.clip(c))) for c in range(db.num_clips)]
    out = np.concatenate(parts, axis=0)
    if out.shape[0] != db.num_frames:
        raise ValueError(f"fn returned {out.shape[0]} frames for a database of {db.num_frames}")
    return out


def database_positions(db: MotionDatabase, names) -> np.ndarray:
    """Global positions (N, M, 3) of joints or end sites ``names`` in every database frame, file units."""
    names = list(names)
    return per_clip(db, lambda m: virtual_markers(m, names))


def output_skeleton(db: MotionDatabase, skeleton: Skeleton | None) -> Skeleton:
    """The skeleton a reconstruction is written on: ``skeleton`` (the performer's, same topology) or the database's first."""
    if skeleton is None:
        return db.skeletons[0]
    if not skeleton.is_compatible(db.skeletons[0]):
        raise ValueError(
            "the skeleton has a different joint layout from the database's; "
            "retarget it to the database skeleton first"
        )
    return skeleton
