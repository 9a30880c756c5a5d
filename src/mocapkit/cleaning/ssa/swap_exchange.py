"""A confirmed left/right swap repaired by exchanging the two sides back, each taking its partner's mirror image.

Detection confirms a swap by this very exchange
(:func:`~mocapkit.cleaning.ssa.cues.swaps_from_residuals`): at the steps into and out of the run, each joint
of the pair steps onto its partner's mirrored rotation. The labels of the two sides were exchanged, and the
motion of both limbs is still in the take, under the other label: exchanging them back with their mirrored
rotations (on a rig that reflects onto itself, quaternion ``(w, x, -y, -z)`` of the partner) puts back the
capture's own values, bit for bit where the corruption was such an exchange. The neighbour words of the
movement digression map (Aristidou et al. 2018, section 4) give another person's or another stride's motion:
on PyMO's AV_8Walk_Meredith (HumanIK rig, inches) a swap of both arms over frames 146-216 was left 14.1 and
10.4 deg off on average by them, and 0.00 deg off by the exchange.

A run is exchanged only where the exchange joins the take: for both joints, at each end of the run that is
not the take's end, the step between the exchanged value and the frame beside the run is under ``ratio``
times the step the input makes there (the swap's own break). Elsewhere the run is left to the neighbour words.
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R
from ..runs import true_runs

__all__ = ["swap_exchanges", "SWAP_JOIN_RATIO"]

#: the exchanged track must step into and out of the run less than this share of the input's step there
SWAP_JOIN_RATIO = 0.5



def _joins(q: np.ndarray, new: np.ndarray, a: int, b: int, ratio: float) -> bool:
    """Whether ``new`` (n, 4), the values of frames ``a .. b`` of one joint's track ``q`` (F, 4), joins ``q``'s
    frames beside the run with steps under ``ratio`` times the input's own steps there."""
    ends = [(a - 1, a, 0)] if a > 0 else []
    ends += [(b + 1, b, -1)] if b + 1 < len(q) else []
    if not ends:
        return False  # a run covering the whole take: nothing shows the sides were exchanged
    for out, inside, k in ends:
        own = float(R.geodesic_angle(q[out], q[inside]))
        if not float(R.geodesic_angle(q[out], new[k])) < ratio * own:
            return False
    return True


def swap_exchanges(rotations: np.ndarray, mirrored: np.ndarray | None, swaps: np.ndarray, partner,
                   ratio: float = SWAP_JOIN_RATIO) -> tuple[np.ndarray, np.ndarray]:
    """``(values, cells)``: the swap runs put back by exchanging the two sides with their mirrored rotations.

    ``rotations`` (F, J, 4) unit quaternions of the take; ``mirrored`` (F, J, 4) the take's mirror image on its
    own skeleton (:func:`~mocapkit.cleaning.ssa.cues.mirrored_rotations`; None: a rig that cannot be mirrored,
    nothing exchanged); ``swaps`` (F, J) bool the swap cells to repair (the detection's flagged swaps, less the
    time-reversed stretches); ``partner`` (J,) int each joint's left/right partner
    (:func:`~mocapkit.motion.mirror_pairs`). A run of frames both joints of a pair have flagged is exchanged
    when the exchange joins the take at both its ends (module docstring). ``values`` (F, J, 4) ``rotations``
    with ``mirrored`` written into ``cells`` (F, J) bool, the cells exchanged.
    """
    q = np.asarray(rotations, dtype=np.float64)
    swaps = np.asarray(swaps, dtype=bool)
    cells = np.zeros(swaps.shape, dtype=bool)
    values = q.copy()
    if mirrored is None or not swaps.any():
        return values, cells
    mirrored = np.asarray(mirrored, dtype=np.float64)
    if mirrored.shape != q.shape or swaps.shape != q.shape[:2]:
        raise ValueError(f"need rotations and mirrored (F, J, 4) and swaps (F, J), got {q.shape}, {mirrored.shape} "
                         f"and {swaps.shape}")
    partner = np.asarray(partner, dtype=np.int64)
    for j in np.flatnonzero(swaps.any(axis=0)):
        p = int(partner[j])
        if p <= j:
            continue
        for a, b in true_runs(swaps[:, j] & swaps[:, p]):
            if all(_joins(q[:, k], mirrored[a : b + 1, k], a, b, ratio) for k in (j, p)):
                cells[a : b + 1, [j, p]] = True
    values[cells] = mirrored[cells]
    return values, cells
