"""Time-reversed stretches: the swap cue's runs that join the take better played backwards.

A stretch of frames ``a .. b - 1`` played backwards (an edit or a
retiming gone wrong) breaks the whole body at both of its ends: frame ``a``
holds what was frame ``b - 1`` and frame ``b - 1`` what was frame ``a``. Each
joint and its left/right partner therefore break at the same frame and again
within a second, which is what the side-swap cue
(:func:`~mocapkit.cleaning.ssa.cues.side_swaps`) looks for, and in a gait or a
wave the stepped-to pose can lie near the partner's mirror image too. Such a
run was named "a left/right swap" though no label swapped.

The two explanations differ in what the run's ends join to. Played forwards,
the run costs its two breaks, ``d(a - 1, a) + d(b - 1, b)``; played
backwards, frame ``b - 1`` follows ``a - 1`` and frame ``a`` comes before
``b``: ``d(a - 1, b - 1) + d(a, b)``, two ordinary frame steps where the
stretch was reversed. ``d`` is the whole body's pose distance, the mean
geodesic angle of the local rotations over the analysed joints (degrees). A
swap of labels leaves the unpaired joints (spine, head) on their path and
turns the pair elsewhere, so turning the run around does not mend its ends.

On real takes (HDM05 and CMU at 120 and 30 fps, Bandai Namco at 30 fps; 216
stretches of 0.1-1 s reversed, 185 swaps injected by
:func:`mocapkit.corrupt.real_errors`) the backwards cost over the forwards
one was at most 0.83 for the reversals (99 % under :data:`REVERSED_RATIO`)
and at least 1.0 for the swaps. The cue renames the cells of such a run
(cause ``reversed`` instead of ``swap``); it flags nothing new and unflags
nothing.
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R

__all__ = ["REVERSED_RATIO", "reversal_costs", "reversed_runs"]

#: a run is called reversed when its ends join the take with this share of their forward cost, or less
REVERSED_RATIO = 0.7


def _pose_distance(q: np.ndarray, x: int, y: int, joints: np.ndarray) -> float:
    """Mean geodesic angle (degrees) between frames ``x`` and ``y`` of ``q`` (F, J, 4) over ``joints`` (J,) bool."""
    return float(np.degrees(R.geodesic_angle(q[x, joints], q[y, joints])).mean())


def reversal_costs(rotations: np.ndarray, a: int, b: int, joints=None) -> tuple[float, float]:
    """``(forwards, backwards)``: the whole-body break cost (degrees) of frames ``a .. b - 1`` of ``rotations``
    (F, J, 4 local quaternions) joined to their neighbours as they are, and played backwards (module
    docstring). ``joints`` (J,) bool, the joints counted (None: all). Needs ``1 <= a < b < F``."""
    q = np.asarray(rotations, dtype=np.float64)
    F, J = q.shape[:2]
    if not 1 <= a < b < F:
        raise ValueError(f"frames {a}-{b - 1} have no neighbours on both sides in a take of {F} frames")
    use = np.ones(J, dtype=bool) if joints is None else np.asarray(joints, dtype=bool)
    forwards = _pose_distance(q, a - 1, a, use) + _pose_distance(q, b - 1, b, use)
    backwards = _pose_distance(q, a - 1, b - 1, use) + _pose_distance(q, a, b, use)
    return forwards, backwards


def reversed_runs(rotations: np.ndarray, swaps: np.ndarray, joints=None, ratio: float = REVERSED_RATIO) -> np.ndarray:
    """(F, J) bool: the cells of ``swaps`` (F, J bool, the side-swap cue) whose run, one joint's consecutive
    frames ``a .. b - 1``, joins the take better backwards: :func:`reversal_costs` backwards under ``ratio`` times
    forwards (a run at the take's first or last frame is never called reversed). ``rotations`` (F, J, 4) the
    take's local quaternions, ``joints`` (J,) bool the joints the pose distance counts (None: all)."""
    swaps = np.asarray(swaps, dtype=bool)
    out = np.zeros(swaps.shape, dtype=bool)
    if not swaps.any():
        return out
    from scipy import ndimage  # here: importing it takes ~0.2 s, which a take without swaps never needs

    F = swaps.shape[0]
    judged: dict[tuple[int, int], bool] = {}  # a pair's two joints share their run
    for j in np.flatnonzero(swaps.any(axis=0)):
        labels, _ = ndimage.label(swaps[:, j])
        for (rows,) in ndimage.find_objects(labels):
            a, b = rows.start, rows.stop
            if a < 1 or b >= F:
                continue
            if (a, b) not in judged:
                forwards, backwards = reversal_costs(rotations, a, b, joints)
                judged[(a, b)] = bool(backwards < ratio * forwards)
            out[a:b, j] = judged[(a, b)]
    return out
