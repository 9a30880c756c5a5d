"""Breaks the joint positions do not show: a solver turning a chain over while its joints stay where they are.

A pose solver can turn a thigh 180 deg about itself and bend the knee the
other way in one frame (HDM05 dg_squat1Reps_026, frames 80-81: both femurs 180 deg,
both knees 62 deg; they turn back at frames 100-101): every joint of the legs stays
on its path, only the knees now face backwards. Both rotations break
(:func:`~mocapkit.cleaning.ssa.cues.discontinuities`), but the positions need no
change, and the repair of such a break, words blended over a few frames, is the
wrong tool: it swung the feet 22 cm in a frame and back where the take held them
still. Such a turn-over is turned back exactly, or named, by
:mod:`~mocapkit.cleaning.ssa.flips` after the repair.
:func:`position_kept_breaks` leaves those break events out of the breaks that
confirm a digression, as :func:`~mocapkit.cleaning.ssa.cues.uncompensated_breaks`
leaves out the turns a chain's rotations undo: a turn that another joint of its
chain shares at the same frames and that moves none of the joint's children off
their smooth path. A turn of one joint alone (an error in that joint) is judged
as before, whatever the positions, and so is a turn that moves a child (the
squat's foot turning 23 deg as the legs turn over moves the toes 2 cm, and stays
flagged). A cue of this library, not of Aristidou et al. (2018).
"""

from __future__ import annotations

import numpy as np

from .cues import chain_table
from .events import event_bounds

#: a break event is left out when the joint's children leave their smooth path by less than this share of what the
#: joint's own turn would move them (the HDM05 squat's knee and ankle: under 0.1 % of it)
POSITION_RATIO = 0.1
#: the levels above and below a joint searched for another joint breaking at the same frames
CHAIN_DEPTH = 2


def position_kept_breaks(positions: np.ndarray, parents, breaks: np.ndarray, resid: np.ndarray,
                         ratio: float = POSITION_RATIO, depth: int = CHAIN_DEPTH) -> np.ndarray:
    """``breaks`` (F, J) bool without the break events of a chain that turns over in place.

    An event (break frames at most 3 apart) of joint ``j`` is left out when
    another joint of its chain (``depth`` levels above or below) breaks within
    a frame of it too, and ``j``'s children keep their place relative to ``j``:
    at every frame of the event the vector from ``j`` to each child leaves the
    midpoint of its vectors at frames ``f - 1`` and ``f + 1`` by less than
    ``ratio`` times what ``j``'s own largest midpoint residual ``theta`` over the
    event would move the farthest child (a chord, ``2 L sin(theta / 2)``). A
    joint with no child, or an event at the take's first or last frame, is
    judged as before. ``positions`` (F, J, 3) global joint positions in any one
    unit; ``parents`` (J,); ``breaks`` (F, J) bool; ``resid`` (F, J) radians, the
    joints' midpoint residuals (:func:`~mocapkit.cleaning.ssa.cues.midpoint_residuals`).
    """
    out = np.array(breaks, dtype=bool)
    P = np.asarray(positions, dtype=np.float64)
    parents = np.asarray(parents)
    F = len(P)
    for j in np.flatnonzero(out.any(axis=0)):
        children = np.flatnonzero(parents == j)
        chain = np.setdiff1d(chain_table(parents, int(j), depth), [-1, j])  # depth levels above and below j
        if not len(children) or not len(chain):
            continue
        firsts, lasts, _ = event_bounds(np.flatnonzero(out[:, j]))
        for first, last in zip(firsts.tolist(), lasts.tolist()):
            lo, hi = max(first, 1), min(last, F - 2)
            if hi < lo or not np.asarray(breaks)[max(first - 1, 0) : last + 2, chain].any():
                continue
            v = P[lo - 1 : hi + 2, children] - P[lo - 1 : hi + 2, j, None]  # (n + 2, C, 3)
            left = np.linalg.norm(v[1:-1] - (v[:-2] + v[2:]) / 2.0, axis=-1).max()
            reach = np.linalg.norm(v, axis=-1).max()
            theta = float(np.max(resid[lo : hi + 1, j]))
            if np.isfinite(left) and left < ratio * 2.0 * reach * np.sin(theta / 2.0):
                out[first : last + 1, j] = False
    return out
