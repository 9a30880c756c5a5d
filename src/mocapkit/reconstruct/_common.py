"""What every reconstruction method needs from a MotionDatabase: per-frame values computed clip by clip."""

from __future__ import annotations

from typing import Callable

import numpy as np

from .. import rotations as R
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


def align_about_vertical(source: np.ndarray, target: np.ndarray, up: np.ndarray, weights=None) -> tuple[np.ndarray, np.ndarray]:
    """Optimal rotation about ``up`` and ground translation mapping ``source`` points onto ``target`` (Tautges eq. 4.3).

    Minimises ``sum_i w_i |rotate(yaw(theta), a_i) + t - b_i|^2`` over the
    angle ``theta`` and a translation ``t`` orthogonal to ``up``, in closed
    form (a weighted 2-D Procrustes fit without scaling, Kovar et al.'s
    point-cloud alignment): with the points' ground-plane parts centred on
    their weighted means, ``theta = atan2(sum w up . (a_i x b_i), sum w a_i . b_i)``
    and ``t = mean(b) - rotate(yaw(theta), mean(a))`` projected onto the ground.

    Parameters
    ----------
    source : float array (..., M, 3)
        Points ``a_i``, any leading dimensions (one alignment per leading index).
    target : float array (M, 3) or (..., M, 3)
        Points ``b_i``, broadcast against ``source``.
    up : float array (3,)
        Unit vertical axis.
    weights : float array (M,) or (..., M), optional
        ``w_i >= 0``, broadcast like the points; 1 when None. An all-zero row
        gives the identity.

    Returns
    -------
    theta : float array (...)
        Angle in radians about ``up`` (right-handed).
    translation : float array (..., 3)
        Ground-plane translation (no component along ``up``).

    >>> up = np.array([0.0, 1.0, 0.0])
    >>> a = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 2.0], [-1.0, 0.5, 0.0]])
    >>> q = R.quaternion_from_axis_angle(up, 0.3)
    >>> theta, t = align_about_vertical(a, R.quaternion_rotate(q, a) + [5.0, 0.0, -2.0], up)
    >>> round(float(theta), 12), np.round(t, 12).tolist()
    (0.3, [5.0, 0.0, -2.0])
    """
    a = np.asarray(source, dtype=np.float64)
    b = np.asarray(target, dtype=np.float64)
    up = np.asarray(up, dtype=np.float64)
    ha = a - (a @ up)[..., None] * up
    hb = b - (b @ up)[..., None] * up
    if weights is None:
        w = np.ones(np.broadcast_shapes(ha.shape, hb.shape)[:-1])
    else:
        w = np.broadcast_to(np.asarray(weights, dtype=np.float64), np.broadcast_shapes(ha.shape, hb.shape)[:-1])
    W = w.sum(axis=-1)
    safe = np.where(W > 0, W, 1.0)
    ma = np.sum(w[..., None] * ha, axis=-2) / safe[..., None]
    mb = np.sum(w[..., None] * hb, axis=-2) / safe[..., None]
    ca, cb = ha - ma[..., None, :], hb - mb[..., None, :]
    sin = np.sum(w * (np.cross(ca, cb) @ up), axis=-1)
    cos = np.sum(w * np.sum(ca * cb, axis=-1), axis=-1)
    theta = np.where(W > 0, np.arctan2(sin, cos), 0.0)
    t = mb - R.quaternion_rotate(R.quaternion_from_axis_angle(up, theta), ma)
    t = t - (t @ up)[..., None] * up
    return theta, np.where((W > 0)[..., None], t, 0.0)

