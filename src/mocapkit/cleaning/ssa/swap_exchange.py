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

A pair that detection did not name a swap is tried the same way where the repair guard leaves one side and its
partner digresses over the same frames (:func:`pair_exchange`): a swap the detection took for two digressions
(flagged by their breaks) was otherwise repaired on one side from neighbour words and left on the other.
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R
from ..runs import true_runs

__all__ = ["pair_exchange", "swap_exchanges", "SWAP_JOIN_RATIO"]

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


def pair_exchange(rotations: np.ndarray, mirrored: np.ndarray | None, flags: np.ndarray, joint: int, start: int,
                  end: int, partner, ratio: float = SWAP_JOIN_RATIO) -> tuple[int, int] | None:
    """The frames ``(a, b)`` (inclusive) over which ``joint`` and its partner, exchanged with their mirrored
    rotations, join the take at both ends, or None.

    The frames tried are the flagged runs (``flags`` (F, J) bool) of either joint that overlap ``start .. end -
    1`` (a run of ``joint`` the repair guard left), the longest first: a swap's two sides are flagged over
    frames that need not agree, and its breaks bound the one right. The exchange joins where, for both joints,
    at each end of the run that is not the take's, the angular acceleration at the join
    (:func:`~mocapkit.cleaning.ssa.guard.end_roughness`) is under ``ratio`` times the input's there. Not
    :func:`swap_exchanges`' test of steps: a fast limb at 30 fps moves 10 degrees a frame, as much as its
    exchanged value steps from the frame beside it (a Bandai Namco punch's upper arms swapped over frames
    150-164: the right one steps 10.1 deg into frame 165 exchanged, 17.7 as swapped), while a swap's step is a
    jolt no limb makes and the exchange takes it away (there 18.3 against 2-5 deg/frame^2 around it).
    ``rotations``, ``mirrored``, ``partner``: as :func:`swap_exchanges` (``mirrored`` None: a rig that cannot
    be mirrored, None).
    """
    from .guard import angular_acceleration, end_roughness

    p = int(np.asarray(partner)[joint])
    if mirrored is None or p == joint:
        return None
    q = np.asarray(rotations, dtype=np.float64)
    mirrored = np.asarray(mirrored, dtype=np.float64)
    F = len(q)
    runs = {(a, b) for k in (joint, p) for a, b in true_runs(np.asarray(flags[:, k], dtype=bool))
            if a < end and b >= start}
    for a, b in sorted(runs, key=lambda r: (r[0] - r[1], r[0])):
        if a == 0 and b == F - 1:
            continue
        ok = True
        for k in (joint, p):
            track = q[:, k].copy()
            track[a : b + 1] = mirrored[a : b + 1, k]
            before = end_roughness(angular_acceleration(q[:, k]), a, b + 1)
            after = end_roughness(angular_acceleration(track), a, b + 1)
            ok &= all(o < ratio * i for o, i, inside in zip(after, before, (a > 0, b < F - 1)) if inside)
        if ok:
            return a, b
    return None
