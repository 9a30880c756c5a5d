"""A left/right swap that runs from the take's first frame, or to its last: one break, and the side it lies on.

A swap inside the take breaks twice, into the run and out of it, and both limbs exchanged over the frames
between join the take at both ends (:func:`~mocapkit.cleaning.ssa.swap_exchange.joined_swaps`). A swap the take
starts in (or ends in) breaks once: at the step ``a -> a + 1`` both joints of a pair step onto their partner's
mirrored rotation, and exchanged back over ``0 .. a`` they join the take at that step. Exchanged over ``a + 1 ..``
instead they join it just as well (the join of one side exchanged is the mirror image of the other's), so the join
cannot say which side is swapped. What can: a swapped limb holds its partner's motion while the rest of the body
keeps its own (the arm swinging with the leg it no longer faces, a hand waving on the other side), motion the
neighbour words of the take do not hold (Aristidou et al. 2018, section 4: the movement digression); the clean
side agrees with them. And a swap breaks twice unless it touches an edge: the breaks of a pair read as swaps
(the run from the edge, then the others paired in time order, against all of them paired in time order,
:func:`~mocapkit.cleaning.ssa.cues.swaps_from_residuals`) must each start or end a swapped run, and the reading
that leaves one unpaired is the wrong one (a swap at frame 0 and another a second later: paired in time order, the
first's break and the second's entry exchange the clean frames between the two, and the second's exit is left
over). The run within ``max_s`` of the edge is the swap where its reading leaves fewer breaks unpaired and the
pair digresses more over it than over what the other reading swaps (or, where that swaps nothing, over the rest
of the take); where the readings leave as many, or the other side of the break is itself within ``max_s`` of the
take's other edge, only a clear digression tells (:data:`EDGE_CLEAR` times the other's); where its reading leaves
more, it is no swap. A swap found so takes its break: the break is paired with no other. Where nothing tells
(each side as far off, or no neighbour word judges one), a break the other reading pairs with nothing is left
as it came, named a possible swap, and paired with no other; one it pairs is left to the rules of a swap with
two breaks.
A rule of this library, not of the paper.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ... import rotations as R
from .swap_exchange import SWAP_JOIN_RATIO, exchange_joins, parent_orientations, root_depths

__all__ = ["EDGE_CLEAR", "EdgeSwap", "edge_swaps", "mirror_steps", "possible_swap_note", "swap_step_events",
           "unexplained"]

#: the swapped side's mean digression (radians) must exceed this many times the other side's
EDGE_CLEAR = 2.0


@dataclass(frozen=True)
class EdgeSwap:
    """A one-break swap candidate of joints ``joint`` and ``partner`` over frames ``start .. end`` (inclusive),
    one of which is the take's first or last frame, or the swap inside such a run whose other break the rules of two
    breaks missed (:func:`missed_break`); ``found``: the readings of the pair's breaks told it (:func:`edge_swaps`;
    exchanged back by the repair), else a possible swap left as it came; ``inside`` and ``other`` the pair's mean
    digression (radians, NaN where no neighbour word judges it) over the run from the edge and over the other side
    of its break; ``breaks`` the steps ``a -> a + 1`` that bound the swap inside the take, in order."""

    joint: int
    partner: int
    start: int
    end: int
    found: bool
    inside: float
    other: float
    breaks: tuple = ()


def mirror_steps(q: np.ndarray, mirrored: np.ndarray, j: int, p: int) -> np.ndarray:
    """(F - 1,) bool: the steps ``a -> a + 1`` at which both joints ``j`` and ``p`` land on their partner's mirrored
    rotation of frame ``a`` nearer than the step's size: a label exchange (into a swap or out of it) lands on it, a
    mirror-symmetric move of both limbs does not. A limb moving fast lands a step of its own away (a walking shin
    at 30 fps, 13 deg a frame), so the nearer, not a share of the step. ``q``, ``mirrored`` (F, J, 4)."""
    ok = np.ones(len(q) - 1, dtype=bool)
    for k in (j, p):
        own = R.geodesic_angle(q[1:, k], q[:-1, k])
        onto = R.geodesic_angle(q[1:, k], mirrored[:-1, k])
        ok &= onto < own
    return ok


def swap_step_events(q: np.ndarray, mirrored: np.ndarray, breaks: np.ndarray, j: int, p: int):
    """``(steps, (first, last))``: the steps ``a -> a + 1`` (sorted (n,) int) at which both joints ``j`` and ``p``
    break (``breaks`` (F, J) bool, midpoint residuals over the break level, at frame ``a`` or ``a + 1``) and land on
    their partner's mirrored rotation (:func:`mirror_steps`), and the events they make: each run of successive steps
    one event, its first and last step (a step breaks at its two frames; a short swap's two steps a few frames
    apart, one break event to the rules of two breaks, stay two here). ``q``, ``mirrored`` (F, J, 4)."""
    both = breaks[:, j] & breaks[:, p]
    steps = np.flatnonzero((both[:-1] | both[1:]) & mirror_steps(q, mirrored, j, p))
    if len(steps) == 0:
        return steps, (steps, steps)
    cut = np.flatnonzero(np.diff(steps) > 1) + 1
    return steps, (steps[np.concatenate([[0], cut])], steps[np.concatenate([cut - 1, [len(steps) - 1]])])


def _mean(d: np.ndarray) -> float:
    """The mean of the finite values of ``d``; NaN where there are none."""
    d = d[np.isfinite(d)]
    return float(d.mean()) if d.size else float("nan")


def _pair_swaps(q, mirrored, resid, joint_names, partner, parents, fps, jump_deg, max_s, pair, held, edge, others):
    """(F,) bool: the swap cells detection's rules of two breaks find on the pair ``pair`` ``(j, p)``, with the
    F, J masks ``held`` (the break frames paired with no other), ``edge`` (a one-break swap taken as found) and
    ``others`` (the swaps of the other pairs, exchanged back before the pair's joins are judged)."""
    from .cues import swaps_from_residuals
    from .swap_exchange import joined_swaps

    only = np.zeros(q.shape[1], dtype=bool)
    only[list(pair)] = True
    got = swaps_from_residuals(resid, joint_names, fps, jump_deg, max_s, only, rotations=q, mirrored=mirrored,
                               held=held) | edge
    got |= joined_swaps(q, mirrored, resid, partner, parents, fps, jump_deg, max_s, only, got | others, held=held)
    return got[:, pair[0]]


def unexplained(cells: np.ndarray, events) -> int:
    """How many of the swap steps' events ``events`` ``(first, last)`` (steps ``a -> a + 1``, :func:`mirror_steps`,
    each run of successive ones an event) no run of ``cells`` (F,) bool, a reading of a pair's swaps, starts or
    ends at (a step of its edge within a frame of the event's)."""
    cells = np.asarray(cells, dtype=bool)
    bounds = np.flatnonzero(cells[1:] != cells[:-1])  # the steps s -> s + 1 into or out of a run
    return int(sum(not ((bounds >= f - 1) & (bounds <= l + 1)).any() for f, l in zip(*events)))


def edge_swaps(rotations: np.ndarray, mirrored: np.ndarray | None, resid: np.ndarray, digression: np.ndarray,
               joint_names, parents, fps: float, jump_deg: float, max_s: float, swaps: np.ndarray, joints=None,
               clear: float = EDGE_CLEAR) -> list[EdgeSwap]:
    """The one-break swaps at the take's two edges, found (the digression tells which side) or possible.

    For each left/right pair (:func:`~mocapkit.motion.mirror_pairs` of ``joint_names``), the first step
    ``a -> a + 1`` within ``max_s`` seconds of the take's first frame where both joints break by ``jump_deg`` or
    more (``resid`` (F, J) radians, :func:`~mocapkit.cleaning.ssa.cues.midpoint_residuals`) and step nearer their
    partner's mirrored rotation than their own (:func:`mirror_steps`), or where ``swaps`` starts or ends a swap of
    the pair (a limb moving faster than the two lie apart lands no nearer its partner's mirror image: the shins of
    a run), with both limbs exchanged over ``0 .. a`` joining the take at that step
    (:func:`~mocapkit.cleaning.ssa.swap_exchange.exchange_joins`, each joint's value and its limb's orientation in
    the body); likewise the last such step within ``max_s`` of the last frame, the run
    ``a + 1 .. F - 1``. Two readings of the pair's breaks are compared: the run swapped, its break paired with no
    other (the rules of two breaks, :func:`~mocapkit.cleaning.ssa.cues.swaps_from_residuals` and
    :func:`~mocapkit.cleaning.ssa.swap_exchange.joined_swaps`, on the rest), against ``swaps`` (F, J) bool, what
    those rules find with every break free. The pair's mean ``digression`` (F, J, radians) is taken over the cells
    only the first reading swaps, and over each half of the run (the least of the three: a run reaching past a
    swap's missed break holds clean frames), against its mean over the cells only the second reading swaps (over
    the rest of the take where it swaps none of them). ``found`` where the first reading leaves fewer of the swap
    steps' events unexplained (:func:`unexplained`), the other side of the break is longer than ``max_s`` and the
    run digresses more; or, the two leaving as many, where it digresses ``clear`` times as much. None where the
    first leaves more, or where one of its swaps begins at the break (the break is that swap's). A found run
    holding a shorter one, from a frame inside it to the break, that joins the take at both ends is that swap, its
    other break missed (:func:`missed_break`). A run not found is a possible swap where the second reading leaves
    its break unpaired, and none otherwise (the rules of two breaks judge it). A break is read from one edge only,
    the first; the swap found there is in both readings of the other edge (its break paired with no other: a swap
    from the first frame and one to a break near the last, read apart, left the second's exit a break of its own
    and the second unfound). ``rotations``
    (F, J, 4) and ``mirrored`` (the take's mirror image on its own skeleton,
    :func:`~mocapkit.cleaning.ssa.cues.mirrored_rotations`; None: none) unit quaternions; ``parents`` (J,) int,
    the skeleton's; ``joints`` (J,) bool the joints judged (None:
    all). A take of under 4 frames has none.
    """
    from ...motion import mirror_pairs

    q = np.asarray(rotations, dtype=np.float64)
    F, J = q.shape[:2]
    if mirrored is None or F < 4:
        return []
    mirrored = np.asarray(mirrored, dtype=np.float64)
    partner = mirror_pairs(joint_names)
    parents = np.asarray(parents, dtype=np.int64)
    dig = np.asarray(digression, dtype=np.float64)
    use = np.ones(J, dtype=bool) if joints is None else np.asarray(joints, dtype=bool)
    breaks = np.asarray(resid) > np.radians(jump_deg)
    longest = int(round(max_s * fps))
    depth = root_depths(parents)
    body = parent_orientations(q, parents)
    out: list[EdgeSwap] = []
    for j in sorted(range(J), key=lambda k: (depth[k], k)):
        p = int(partner[j])
        if p <= j or not (use[j] and use[p]):
            continue
        steps, events = swap_step_events(q, mirrored, breaks, j, p)
        if len(steps) == 0:
            continue
        free_p = np.asarray(swaps[:, j], dtype=bool)
        others = np.array(swaps, dtype=bool)
        others[:, [j, p]] = False
        judged = set()  # the breaks read from one edge already: not again from the other
        # a swap found at the first edge: its cells and break frames in both readings of the other edge's
        kept_edge, kept_held = np.zeros((F, J), dtype=bool), np.zeros((F, J), dtype=bool)
        # the swap steps, and the steps the rules of two breaks start or end a swap at (a limb moving faster than
        # the two lie apart lands no nearer its partner's mirror image)
        tried_steps = np.union1d(steps, np.flatnonzero(free_p[1:] != free_p[:-1]))
        for entry in (True, False):
            near = (tried_steps[tried_steps + 1 <= longest] if entry else
                    tried_steps[F - 1 - tried_steps <= longest][::-1])
            for a in near:
                lo, hi = (0, a + 1) if entry else (a + 1, F)
                if a in judged or hi - lo >= F or not exchange_joins(q, mirrored, (j, p), lo, hi, frames=body):
                    continue
                judged.add(a)
                # the other side of the break a swap as long as this one could be: only the digression tells
                both_short = F - (hi - lo) <= longest
                held, edge = kept_held.copy(), kept_edge.copy()
                held[a : a + 2, [j, p]] = True
                edge[lo:hi, [j, p]] = True
                taken = _pair_swaps(q, mirrored, resid, joint_names, partner, parents, fps, jump_deg, max_s,
                                    (j, p), held, edge, others)
                if taken[hi] if entry else taken[lo - 1]:
                    break  # a swap begins at the break: the run joins it, and its break is that swap's
                mine, theirs = taken & ~free_p, free_p & ~taken
                if not mine[lo:hi].any():
                    break  # the second reading swaps the run already
                other = theirs if theirs.any() else ~taken
                # a swap holds its whole run: each half of it digresses (a run reaching past a missed break does not)
                mid = (lo + hi + 1) // 2
                inside = float(np.min([_mean(dig[mine][:, [j, p]]), _mean(dig[lo:mid, [j, p]]),
                                       _mean(dig[mid:hi, [j, p]])]))
                beyond = _mean(dig[other][:, [j, p]])
                told = bool(np.isfinite(inside) and np.isfinite(beyond))
                left, right = unexplained(taken, events), unexplained(free_p, events)
                if left > right:
                    break  # the run leaves a swap break unpaired that the rules of two breaks pair
                found = told and (inside > beyond if left < right and not both_short else inside > clear * beyond)
                k = missed_break(q, mirrored, body, breaks, (j, p), lo, hi, entry) if found else None
                if k is not None:  # a swap whose other break was missed: the frames beside the edge are clean
                    out.append(EdgeSwap(int(j), p, *((k, hi - 1) if entry else (lo, k - 1)), True, inside, beyond,
                                        tuple(sorted((int(a), k - 1)))))
                elif found or free_p[a] == free_p[a + 1]:  # possible where the rules of two breaks leave the break
                    out.append(EdgeSwap(int(j), p, int(lo), int(hi - 1), found, inside, beyond, (int(a),)))
                if found:
                    e = out[-1]
                    for b in e.breaks:
                        kept_held[b : b + 2, [j, p]] = True
                    kept_edge[e.start : e.end + 1, [j, p]] = True
                    free_p = taken.copy()  # the second reading of the other edge: with this swap found
                    free_p[lo : e.start] = free_p[e.end + 1 : hi] = False  # less the clean frames beside it
                break
    return out


def missed_break(q: np.ndarray, mirrored: np.ndarray, body: np.ndarray, breaks: np.ndarray, pair, lo: int, hi: int,
                 entry: bool) -> int | None:
    """The frame ``k`` inside a one-break swap's run ``lo .. hi - 1`` (from the take's first frame, ``entry``, or to
    its last) at which a shorter run, ``k .. hi - 1`` (entry) or ``lo .. k - 1``, joins the take at both ends
    (:func:`~mocapkit.cleaning.ssa.swap_exchange.exchange_joins`): a swap whose other break, the step ``k - 1 ->
    k`` (two frames at least from the break), the rules of two breaks missed, the frames between it and the edge
    clean. Where no such run joins, the frame of a step where both joints break (``breaks`` (F, J) bool, at
    ``k - 1`` or ``k``) at which the exchange joins every track better than the input does (each joint's value and
    its limb's orientation in the body, under once the input's angular acceleration there): a swap begun where the
    two limbs pass each other breaks little (Bandai Namco run_normal_016 with ``corrupt.real_errors(kinds=("swap",),
    seed=1)``: the forearms swapped over frames 10-26, the right one's value 7.0 against 13.6 deg/frame^2 into frame
    10 exchanged, more than half).
    The frame nearest the edge; None where there is none. ``q``, ``mirrored`` (F, J, 4) as :func:`edge_swaps`,
    ``body`` (F, J, 4) their :func:`~mocapkit.cleaning.ssa.swap_exchange.parent_orientations`; ``pair`` the
    joints."""
    j, p = pair
    # nearest the edge first; two frames at least between the step k - 1 -> k and the break, whose second
    # differences the join at k would read
    frames = range(lo + 1, hi - 2) if entry else range(hi - 1, lo + 2, -1)
    stepped = [k for k in frames if (breaks[k - 1 : k + 1, j] & breaks[k - 1 : k + 1, p]).any()]
    for ratio, tried in ((SWAP_JOIN_RATIO, frames), (1.0, stepped)):
        for k in tried:
            if exchange_joins(q, mirrored, pair, *((k, hi) if entry else (lo, k)), ratio=ratio, frames=body):
                return int(k)
    return None


def possible_swap_note(swap: EdgeSwap, joint_names) -> str:
    """The line a detection's notes give a one-break swap the digression did not tell (:func:`edge_swaps`)."""
    edge = "first" if swap.start == 0 else "last"
    at = swap.breaks[0]
    told = ("no neighbour word judges one side" if not (np.isfinite(swap.inside) and np.isfinite(swap.other)) else
            f"mean digression {np.degrees(swap.inside):.1f} deg over them, {np.degrees(swap.other):.1f} beyond")
    return (f"{joint_names[swap.joint]} and {joint_names[swap.partner]}: a possible left/right swap over frames "
            f"{swap.start}-{swap.end}, from the take's {edge} frame to one break (step {at} -> {at + 1}); which side "
            f"of the break is swapped is not clear ({told}): left as captured")
