"""A joint still for one step where it turns back is at the turning point of its own motion, not frozen.

:func:`~mocapkit.cleaning.ssa.cues.held_joints` flags a joint held still (under 0.5 deg/s) while the similar
motion moves; at 24-30 fps its shortest hold is two frames, one still step. A joint that swings out and comes
back passes through zero speed at the end of its swing, and when two frames fall either side of that instant at
about the same angle (a parabola sampled symmetrically about its vertex) they are equal to hundredths of a
degree: the step into the "hold" and the step out of it are full-speed steps in opposite directions. Bandai
Namco dataset-2 ``walk-turn-left_feminine_005`` (30 fps): the left toe bends 7.0 deg a frame up to 24.2 deg at
push-off (frames 47-49), frames 49 and 50 lie 0.013 deg apart, and it comes back 11.2 and 8.7 deg a frame;
the neighbour words move 18 deg over those two frames, so ``clean`` flagged Toes_L 49-50 as held.

A frozen channel is not like that: the tracker repeats the last value while the limb goes on, and the channel
then jumps to where the limb has gone, on along its way (:mod:`~mocapkit.cleaning.ssa.freezes`). So a hold of
a single still step (two frames, ``a`` and ``a + 1``) is left out of the holds when the joint turns back across
it: the rotation one frame after the hold lies closer to the one a frame before it than either step into or out
of the hold does (the direction turns by more than 120 deg when the steps are of equal size; the toe: 4.3 deg
against steps of 7.0 and 11.2). A joint that eases out of rest (a step of 0.1 deg into the hold, 4.3 out of it:
Bandai dataset-1 ``dash_feminine_001``'s left toe, frames 74-75) does not turn back, and stays judged. A hold of
two still steps or more (a joint that stops, not one that turns) is judged as before, and so is every hold at
120 fps, where :func:`~mocapkit.cleaning.ssa.cues.held_joints` takes none shorter than 6 frames.
:func:`mocapkit.corrupt.real_errors` freezes last 0.1 s and more (at least 3 held frames at 30 fps), so none
of them is a single still step. A cue of this library, not of Aristidou et al. (2018).
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R
from ..runs import true_runs

__all__ = ["turning_point_holds", "without_turning_points"]


def turning_point_holds(rotations: np.ndarray, holds: np.ndarray) -> np.ndarray:
    """(F, J) bool: the two-frame runs of ``holds`` at which the joint turns back (module docstring).

    ``rotations`` (F, J, 4) unit quaternions of the take; ``holds`` (F, J) bool, the held cells
    (:func:`~mocapkit.cleaning.ssa.cues.held_joints`). A run of frames ``a``, ``a + 1`` with a frame on either
    side is returned when the geodesic angle from frame ``a - 1`` to ``a + 2`` is under both the angles
    ``a - 1 -> a`` and ``a + 1 -> a + 2``; a run at the take's first or last frame, or longer, is not.
    """
    q = np.asarray(rotations, dtype=np.float64)
    holds = np.asarray(holds, dtype=bool)
    if q.ndim != 3 or q.shape[2] != 4 or holds.shape != q.shape[:2]:
        raise ValueError(f"need rotations (F, J, 4) and holds (F, J), got {q.shape} and {holds.shape}")
    F = len(q)
    out = np.zeros_like(holds)
    for j in np.flatnonzero(holds.any(axis=0)):
        for a, last in true_runs(holds[:, j]):
            if last != a + 1 or a < 1 or last + 1 >= F:
                continue
            before, after = q[a - 1, j], q[last + 1, j]
            step_in = R.geodesic_angle(before, q[a, j])
            step_out = R.geodesic_angle(q[last, j], after)
            if R.geodesic_angle(before, after) < min(step_in, step_out):  # NaN compares False: kept as a hold
                out[a : last + 1, j] = True
    return out


def without_turning_points(rotations: np.ndarray, holds: np.ndarray) -> np.ndarray:
    """``holds`` (F, J) bool without its runs at a turning point of the joint (:func:`turning_point_holds`)."""
    holds = np.asarray(holds, dtype=bool)
    return holds & ~turning_point_holds(rotations, holds)
