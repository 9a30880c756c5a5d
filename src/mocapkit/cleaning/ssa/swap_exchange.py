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
times the step the input makes there (the swap's own break), or the angular acceleration at the join, of each
joint's value and of its limb's orientation in the body, under ``ratio`` times the input's
(:func:`exchange_joins`). Elsewhere the run is left to the neighbour words.

The same join finds the swaps whose breaks the limbs' own fast motion hides (:func:`joined_swaps`, part of
detection): at 30 fps a running leg's steps reach what a swap's do, but exchanged back a swapped pair continues
both limbs' paths at both ends, and a real move, exchanged, leaves them.

A pair that detection did not name a swap is tried the same way where the repair guard leaves one side and its
partner digresses over the same frames (:func:`pair_exchange`): a swap the detection took for two digressions
(flagged by their breaks) was otherwise repaired on one side from neighbour words and left on the other.

A swap detection flagged on one side only is found before the neighbour words are written
(:func:`partner_swaps`): where the two sides exchanged join the frames beside one side's flagged run better
than as they came, the exchange is made over the swap's own frames (its ends sought near the flags'), or,
fitting better but not at every end, both sides are left as they came. The joins are judged on each limb's
orientation in the body (:func:`parent_orientations`), not on its joint's value alone: a swap exchanges the two
limbs, so exchanged back each limb continues its own path; a joint whose value breaks while its parent turns
the other way in the same frames (a twist handed between the joints of one arm) breaks no limb, and its
partner's mirrored value, which may happen to lie near its own, is no swap of it. The cells a repair exchanged,
by any of these rules, are the record's swap on both joints (:func:`exchanged_cells`), so the report ties the two
sides.
A rule of this library, not of the paper.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ... import rotations as R
from ..runs import true_runs
from .events import pair_events

__all__ = ["EXTENT_S", "PartnerSwap", "clean_stretches", "exchanged_cells", "joined_swaps", "pair_exchange", "parent_orientations",
           "partner_swaps", "root_depths", "swap_exchanges", "SWAP_JOIN_RATIO", "end_join", "join_steps"]

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


def root_depths(parents) -> np.ndarray:
    """(J,) int: each joint's number of bones from the root (0 for the root), from ``parents`` (J,) int, the
    skeleton's (each parent before its children): the pairs nearer the root are judged first."""
    parents = np.asarray(parents, dtype=np.int64)
    depth = np.zeros(len(parents), dtype=np.int64)
    for k in range(1, len(parents)):
        depth[k] = depth[parents[k]] + 1
    return depth


def swap_exchanges(rotations: np.ndarray, mirrored: np.ndarray | None, swaps: np.ndarray, partner,
                   ratio: float = SWAP_JOIN_RATIO, parents=None) -> tuple[np.ndarray, np.ndarray]:
    """``(values, cells)``: the swap runs put back by exchanging the two sides with their mirrored rotations.

    ``rotations`` (F, J, 4) unit quaternions of the take; ``mirrored`` (F, J, 4) the take's mirror image on its
    own skeleton (:func:`~mocapkit.cleaning.ssa.cues.mirrored_rotations`; None: a rig that cannot be mirrored,
    nothing exchanged); ``swaps`` (F, J) bool the swap cells to repair (the detection's flagged swaps, less the
    time-reversed stretches); ``partner`` (J,) int each joint's left/right partner
    (:func:`~mocapkit.motion.mirror_pairs`). A run of frames both joints of a pair have flagged is exchanged
    when the exchange joins the take at both its ends (module docstring), or, with ``parents`` (J,) int (the
    skeleton's), where both limbs exchanged join the take as :func:`joined_swaps` found it (:func:`exchange_joins`,
    the pairs nearer the root first, on the take with the runs exchanged so far). ``values`` (F, J, 4)
    ``rotations`` with ``mirrored`` written into ``cells`` (F, J) bool, the cells exchanged.
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
    depth = root_depths(parents) if parents is not None else np.zeros(len(partner), dtype=np.int64)
    for j in sorted(np.flatnonzero(swaps.any(axis=0)), key=lambda k: (depth[k], k)):
        p = int(partner[j])
        if p <= j:
            continue
        for a, b in true_runs(swaps[:, j] & swaps[:, p]):
            if all(_joins(q[:, k], mirrored[a : b + 1, k], a, b, ratio) for k in (j, p)) \
                    or parents is not None and exchange_joins(values, mirrored, (j, p), a, b + 1, parents, ratio):
                cells[a : b + 1, [j, p]] = True
                values[a : b + 1, [j, p]] = mirrored[a : b + 1, [j, p]]
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


def exchange_joins(q: np.ndarray, mirrored: np.ndarray, joints, start: int, end: int, parents=None,
                   ratio: float = SWAP_JOIN_RATIO, frames: np.ndarray | None = None) -> bool:
    """Whether ``joints`` exchanged over frames ``start .. end - 1`` (each taking its mirrored rotation) join the
    take at each end of the run that is not the take's: the angular acceleration at the join
    (:func:`~mocapkit.cleaning.ssa.guard.end_roughness`) under ``ratio`` times the input's there, for every joint.
    With ``parents`` (J,) int the joins of each limb's orientation in the body (:func:`parent_orientations` times
    the joint's value, as :func:`partner_swaps` judges them) must pass as well: a swap exchanged back continues
    both the joint's channels and its limb's path. On the values alone a twist handed between the joints of one
    arm passes (the CMU backflip on LaFAN1's rig at 30 fps, its hands over frames 33-40); in the body alone a
    toe whose foot turns fast passes, the foot's turn swamping the toe's (CMU 131_02 at 12 fps, its toes over
    frames 68-79: 8.7 against 49.7 deg/frame^2 in the body, more than half the input's on their values), both
    clean takes. ``frames`` (F, J, 4): the parent orientations of ``q`` made already
    (:func:`parent_orientations`), used instead. ``q``, ``mirrored`` (F, J, 4) as :func:`swap_exchanges`. Only
    the frames the joins read are turned (two beside each end)."""
    from .guard import angular_acceleration, end_roughness

    F = len(q)
    if start <= 0 and end >= F:
        return False
    lo, hi = max(start - 2, 0), min(end + 2, F)  # every second difference the two joins read, as in the whole take
    joints = list(joints)
    own, new = q[lo:hi, joints], mirrored[lo:hi, joints]
    judged = [(own, new)]  # each joint's value: the channels a swap exchanges
    # and its limb's path: the chain above it turns the limb too (a frame's parent orientations are that frame's)
    body = (frames[lo:hi, joints] if frames is not None else
            None if parents is None else parent_orientations(q[lo:hi], parents)[:, joints])
    if body is not None:
        judged.append((R.quaternion_multiply(body, own), R.quaternion_multiply(body, new)))
    a, b, n = start - lo, end - lo, hi - lo
    for own, new in judged:
        for i in range(len(joints)):
            track = own[:, i].copy()
            track[a:b] = new[a:b, i]
            before = end_roughness(angular_acceleration(own[:, i]), a, b)
            after = end_roughness(angular_acceleration(track), a, b)
            if not all(o < ratio * x for o, x, inside in zip(after, before, (a > 0, b < n)) if inside):
                return False
    return True


def joined_swaps(rotations: np.ndarray, mirrored: np.ndarray | None, resid: np.ndarray, partner, parents,
                 fps: float, jump_deg: float, max_s: float, joints=None, swaps: np.ndarray | None = None,
                 ratio: float = SWAP_JOIN_RATIO, held: np.ndarray | None = None) -> np.ndarray:
    """(F, J) bool: left/right swaps whose two steps break both joints of a pair by ``jump_deg`` or more and
    whose exchange back joins the take at both ends.

    :func:`~mocapkit.cleaning.ssa.cues.side_swaps` asks each break to stand out from the joint's own motion
    (:func:`~mocapkit.cleaning.ssa.cues.own_breaks`) and to step onto the partner's mirror image from the frame
    before: at 30 fps a running leg's midpoint residuals reach the cap of 33 deg, and its partner moves 15-25
    deg a frame, so a shin swap's steps, 20-40 deg, stand out from nothing (Bandai Namco run_normal_016 with
    ``corrupt.real_errors(kinds=("swap",), seed=0)``: the shins swapped over frames 64-78 break 32 and 39 deg
    into the run, 25 and 28 out of it, under levels of 34 and 38: that check names neither side). A label
    exchange is no motion, though, and the exchange back proves it: two break events of both joints within
    ``max_s`` seconds, where both limbs exchanged over the frames between join the take with an angular
    acceleration under ``ratio`` times the input's at both ends (:func:`exchange_joins`: each joint's value and
    its limb's orientation in the body). A real move joins the take already: exchanged, it steps away from it at
    both ends.
    The pairs nearer the root are judged first, and within a pair the runs in time order, each entry with the
    first exit after it whose exchange joins; the take is judged with the swaps found so far exchanged back (the
    step out of one is no break beside the next: two shin swaps 4 frames apart otherwise exchange the clean
    frames between them). ``rotations`` (F, J, 4) and ``mirrored`` (its mirror image on its own skeleton, None:
    nothing found) as :func:`swap_exchanges`; ``resid`` (F, J) radians the midpoint residuals
    (:func:`~mocapkit.cleaning.ssa.cues.midpoint_residuals`); ``partner`` (J,) int; ``parents`` (J,) int, the
    skeleton's; ``fps`` the take's rate; ``joints`` (J,) bool the joints judged (None: all); ``swaps`` (F, J)
    bool the swaps found already, whose runs are not judged again (None: none); ``held`` (F, J) bool the break
    frames of swaps with one break (:func:`~mocapkit.cleaning.ssa.edge_swaps.edge_swaps`, None: none), paired with
    no other (:func:`~mocapkit.cleaning.ssa.events.pair_events`).
    """
    q = np.asarray(rotations, dtype=np.float64)
    F, J = q.shape[:2]
    out = np.zeros((F, J), dtype=bool)
    if mirrored is None or F < 3:
        return out
    mirrored = np.asarray(mirrored, dtype=np.float64)
    partner = np.asarray(partner, dtype=np.int64)
    parents = np.asarray(parents, dtype=np.int64)
    use = np.ones(J, dtype=bool) if joints is None else np.asarray(joints, dtype=bool)
    found = np.zeros((F, J), dtype=bool) if swaps is None else np.asarray(swaps, dtype=bool)
    track = q.copy()  # the take with the swaps found so far exchanged back
    both = found & found[:, partner] & (partner != np.arange(J))[None, :]
    track[both] = mirrored[both]
    breaks = np.asarray(resid) > np.radians(jump_deg)
    longest = int(round(max_s * fps))
    depth = root_depths(parents)
    body = parent_orientations(track, parents)
    for j in sorted(range(J), key=lambda k: (depth[k], k)):
        p = int(partner[j])
        if p <= j or not (use[j] and use[p]):
            continue
        first, last = pair_events(breaks, j, p, held)
        if not len(first):
            continue
        # the steps a -> a + 1 of each event (its break frames are a and a + 1)
        steps = sorted({a for f, l in zip(first, last) for a in range(max(int(f) - 1, 0), min(int(l), F - 2) + 1)})
        taken = found[:, j] | found[:, p]
        for a in steps:
            if taken[a]:
                continue  # the step out of a swap is no step into another: the frame before it is swapped
            for b in steps:
                if b <= a + 1 or b - a > longest:
                    continue
                if taken[a + 1 : min(b + 2, F)].any():
                    break
                if exchange_joins(track, mirrored, (j, p), a + 1, b + 1, ratio=ratio, frames=body):
                    out[a + 1 : b + 1, [j, p]] = taken[a + 1 : b + 1] = True
                    track[a + 1 : b + 1, [j, p]] = mirrored[a + 1 : b + 1, [j, p]]
                    for s, e in clean_stretches(track, q, (j, p), a, b, steps, parents, ratio):
                        out[s:e, [j, p]] = False
                        track[s:e, [j, p]] = q[s:e, [j, p]]
                    body[a + 1 : b + 1] = parent_orientations(track[a + 1 : b + 1], parents)
                    break
    return out


def clean_stretches(track: np.ndarray, q: np.ndarray, joints, a: int, b: int, steps, parents,
                    ratio: float = SWAP_JOIN_RATIO) -> list[tuple[int, int]]:
    """The stretches ``(s, e)`` (frames ``s .. e - 1``) of a swap run exchanged over frames ``a + 1 .. b`` that are
    the clean frames between two swaps: a step ``m -> m + 1`` out of the first and a later one ``n -> n + 1`` into
    the next, both among the pair's break steps ``steps`` inside the run, where the frames ``m + 1 .. n`` put back
    as they came join the exchanged take (:func:`exchange_joins`, ``q`` (F, J, 4) the input taking the place of the
    mirror image) at both ends. A swap's break is its start or its end, not both: exchanged with the swaps beside
    them, those frames step onto their partner's mirror image and back, as a swap of their own does. Bandai Namco
    walk-turn-left_exhausted_005 (tests/data) with its shins swapped over frames 36-50 and 52-65: the entry of the
    first and the exit of the second join the take, and the run between them holds the clean frame 51. ``track``
    (F, J, 4) the take with the run exchanged; ``joints`` the pair; ``parents`` (J,) the skeleton's."""
    inner = [m for m in steps if a < m < b]
    out, after = [], a
    for i, m in enumerate(inner):
        if m <= after:
            continue
        for n in inner[i + 1 :]:
            if exchange_joins(track, q, joints, m + 1, n + 1, parents, ratio):
                out.append((m + 1, n + 1))
                after = n
                break
    return out


#: how far (seconds) a swap's extent may lie from the flags of its one flagged side: the flags start and end at
#: the breaks the analysis (at a lower rate) saw, and a swap begun where the two limbs pass each other breaks
#: little (the Bandai Namco walk's shins swapped over frames 45-51, flagged on one side over 47-51)
EXTENT_S = 0.2


@dataclass(frozen=True)
class PartnerSwap:
    """A flagged run of one side of a left/right pair judged against its partner's mirrored values
    (:func:`partner_swaps`): ``joint`` and ``partner``, the frames ``start .. end`` (inclusive) of the exchange,
    the flagged run ``flagged`` ``(first, last)`` of ``joint`` it was found from, and ``confirmed``: the exchange
    joins the take at every end for both joints (a swap, exchanged back), else it only fits better than the
    input there (a swap not confirmed: both sides left as they are)."""

    joint: int
    partner: int
    start: int
    end: int
    flagged: tuple
    confirmed: bool


def _join_frames(f: int, entry: bool, F: int) -> tuple[int, int]:
    """``(lo, hi)``: the frames ``lo .. hi - 1`` of a take of ``F`` frames that the join of a run starting
    (``entry``) or ending at frame ``f`` reads (:func:`end_join`): two on each side of it."""
    lo, hi = (f - 2, f + 2) if entry else (f - 1, f + 3)
    return max(lo, 0), min(hi, F)


def join_steps(q: np.ndarray, new: np.ndarray) -> np.ndarray:
    """(4, F - 1, 3) radians: the steps from each frame to the next (rotation vectors, as
    :func:`~.guard.angular_acceleration` takes them) of the track ``q`` (F, 4), of the run's values ``new`` (F, 4),
    into the run (``q[i]`` to ``new[i + 1]``) and out of it (``new[i]`` to ``q[i + 1]``): every step a join of a
    run of ``new`` written into ``q`` reads (:func:`end_join`), made once per track for all its candidate ends.
    Each step is its own frames' product and logarithm, so the numbers are the ones the join's own frames give."""
    q = np.asarray(q, dtype=np.float64)
    new = np.asarray(new, dtype=np.float64)
    to = np.stack([q[1:], new[1:], new[1:], q[1:]])
    since = np.stack([q[:-1], new[:-1], q[:-1], new[:-1]])
    return R.quaternion_to_rotvec(R.quaternion_multiply(to, R.quaternion_inverse(since)))


def end_join(steps: np.ndarray, f: int, entry: bool) -> tuple[float, float]:
    """``(after, before)``: the angular acceleration (degrees per frame squared, :func:`~.guard.angular_acceleration`)
    at the join of a run that starts (``entry``) or ends at frame ``f`` of a track, with the run's values written
    from ``f`` on (entry) or up to ``f``, and as the track is; 0 at the take's ends. ``steps``: the track's
    :func:`join_steps`. The join reads the second differences at the frame before and the run's first frame (entry)
    or its last frame and the frame after, each at frames 1 .. F - 2 only, so each end is judged alone."""
    old, run, into, out_of = steps
    F = old.shape[0] + 1
    if (f == 0) if entry else (f == F - 1):
        return 0.0, 0.0
    at = [g for g in ((f - 1, f) if entry else (f, f + 1)) if 0 < g < F - 1]
    if not at:
        return 0.0, 0.0

    def written(s: int) -> np.ndarray:  # the step s -> s + 1 with the run written in
        if entry:
            return old[s] if s < f - 1 else into[s] if s == f - 1 else run[s]
        return run[s] if s < f else out_of[s] if s == f else old[s]

    after = np.stack([written(g) - written(g - 1) for g in at])
    before = np.stack([old[g] - old[g - 1] for g in at])
    return (float(np.degrees(np.linalg.norm(after, axis=-1)).max()),
            float(np.degrees(np.linalg.norm(before, axis=-1)).max()))


def parent_orientations(rotations: np.ndarray, parents) -> np.ndarray:
    """(F, J, 4) each joint's parent's orientation in the root joint's frame: the product of the local rotations
    ``rotations`` (F, J, 4, unit quaternions, w first) of the joint's ancestors below the root; the identity for
    the root and its children. ``parents`` (J,) int, topological (``parents[j] < j``, the root's -1), as
    :class:`~mocapkit.motion.Skeleton` holds them. A joint's orientation in the body is this times its own
    rotation: the limb's path, whichever of its joints turns."""
    q = np.asarray(rotations, dtype=np.float64)
    parents = np.asarray(parents, dtype=np.int64)
    body = np.empty_like(q)  # each joint's own orientation in the root's frame, the root's the identity
    body[:, 0] = R.identity((len(q),))
    for j in range(1, q.shape[1]):
        body[:, j] = R.quaternion_multiply(body[:, parents[j]], q[:, j])
    return body[:, np.maximum(parents, 0)]


def partner_swaps(rotations: np.ndarray, mirrored: np.ndarray | None, flags: np.ndarray, partner, parents,
                  fps: float, ratio: float = SWAP_JOIN_RATIO, fixed: np.ndarray | None = None) -> list[PartnerSwap]:
    """The flagged runs of one side of a left/right pair over which the two sides' values exchanged (each taking
    its partner's mirrored rotation) fit the frames beside them better than the input does, with the extent of
    the exchange: a swap detection saw on one side only.

    A swap's two limbs digress by the same angle in mirrored ways (each holds the other's mirrored motion), and
    where they pass close to each other one side's break is too small to flag: the Bandai Namco walk's shins
    swapped over frames 45-51 were flagged on the right over 47-51 alone; repaired from neighbour words there, the
    right knee came out at 54.5 deg (clean take 68.9) while the left kept the right one's bend (69.0, clean 27.3),
    both knees bent at once. For each flagged run ``a .. b`` of ``joint`` (``flags`` (F, J) bool, the cells
    still to repair) whose partner is another joint flagged nowhere in ``a .. b`` (a pair flagged over the same
    frames is detection's swap, :func:`swap_exchanges`, or the guard's, :func:`pair_exchange`), the exchange's
    first frame is sought within :data:`EXTENT_S` of ``a`` and its last within that of ``b`` (holding half the
    run at least): the frame nearest the flags' where the larger of the two joints' join ratios (angular
    acceleration at the join, exchanged against input, :func:`~.guard.end_roughness`, of the limb's orientation
    in the body: :func:`parent_orientations` times the joint's value; of the joint's value alone where one of its
    ancestors is itself flagged over the frames the join reads, its values no path to judge by: Bandai Namco
    walk_normal_001 with ``corrupt --kind errors --seed 2`` spikes the left thigh over 43-44, beside the shins'
    swap 45-51) is under ``ratio``, else
    where it is least (at 120 fps the least one lay 15 frames past a swap's end on HDM05 mm grabHighR,
    exchanging clean frames). **Confirmed** where every join of both joints is under ``ratio``
    times the input's and the exchange takes a step of more than :data:`~.guard.END_TOL_DEG` away (the swap's
    own break: a pair held alike in a symmetric pose exchanges to the same values); **not confirmed** where each
    joint's joins together are smoother exchanged than as they came, but not so at every end. Neither: the run
    is no swap, and is repaired as any other. Judged on the joint's value alone, a twist handed between the joints
    of one limb passes for a swap: the CMU backflip on LaFAN1's rig at 30 fps turns its left upper arm 179 deg
    about itself into frame 33 and its left wrist (``LeftHand``) 173 deg back (the hand turns 110 deg in the body),
    and the right wrist's mirrored value at frame 33 lies 8 deg from the left one's at 32; the hands exchanged over
    33-40 join at both ends by their values (left entry 100 against 268 deg/frame^2), while in the body they
    break the left hand's path (187 against 88: a step of 177 deg). A swap's limb exchanged back continues its own
    path; the pairs nearer the root are judged first, and a confirmed one is written in (no longer flagged) before
    its children are judged. ``parents`` (J,) int: the skeleton's (:func:`parent_orientations`). ``rotations``
    (F, J, 4): the take with what the repair already put back by its own motion (detection's swaps exchanged,
    offsets taken away), whose cells ``fixed`` (F, J) bool (None: none) no exchange reaches: the flags a swap
    detection found left past its end are no swap of their own (HDM05 mm kickLFront1Reps with ``real_errors``
    seed 2001: the shins' swap 42-63 exchanged back, the right one's flags 64-67 beyond it, judged against the
    input's swapped frames, joined an exchange of the clean frames 64-77). ``mirrored`` (the input's mirror
    image; None: a rig that cannot be mirrored, nothing found), ``partner``, ``ratio``: as :func:`swap_exchanges`;
    ``fps``: the take's rate.
    """
    from .guard import END_TOL_DEG

    if mirrored is None:
        return []
    q = np.array(rotations, dtype=np.float64)  # a copy: each confirmed exchange is written in as it is found
    mirrored = np.asarray(mirrored, dtype=np.float64)
    flags = np.asarray(flags, dtype=bool)
    partner = np.asarray(partner, dtype=np.int64)
    parents = np.asarray(parents, dtype=np.int64)
    F = len(q)
    fixed = np.zeros(flags.shape, dtype=bool) if fixed is None else np.asarray(fixed, dtype=bool)
    W = max(2, int(round(EXTENT_S * fps)))
    out: list[PartnerSwap] = []
    taken = np.zeros(flags.shape, dtype=bool)
    depth = root_depths(parents)

    doubt = flags.copy()  # the cells still to repair, whose values no join of their children can trust

    def in_body(q):
        """Each limb's orientation in the body as it stands (F, J, 4), each with its mirrored value instead, and
        (F, J) bool the frames where one of its ancestors is still to repair."""
        frames = parent_orientations(q, parents)
        unsure = np.zeros(doubt.shape, dtype=bool)
        for k in range(1, len(parents)):
            unsure[:, k] = unsure[:, parents[k]] | doubt[:, parents[k]]
        return R.quaternion_multiply(frames, q), R.quaternion_multiply(frames, mirrored), unsure

    steps: dict = {}  # (joint, of its value alone?) -> its join_steps, for the take as it stands

    def join(k, f, entry):
        """:func:`end_join` of joint ``k`` at frame ``f``: of its orientation in the body, or of its value where
        an ancestor is still to repair over the frames the join reads."""
        lo, hi = _join_frames(f, entry, F)
        alone = bool(unsure[lo:hi, k].any())
        if (k, alone) not in steps:
            steps[k, alone] = join_steps(q[:, k], mirrored[:, k]) if alone else join_steps(body[:, k], body_mirrored[:, k])
        return end_join(steps[k, alone], f, entry)

    body, body_mirrored, unsure = in_body(q)
    # a limb's pair before its children's, which are judged on the chain as its exchange puts it back
    for j in sorted(np.flatnonzero(flags.any(axis=0)), key=lambda k: (depth[k], k)):
        p = int(partner[j])
        if p == j:
            continue
        for a, b in true_runs(flags[:, j]):
            if a == 0 and b == F - 1 or taken[a : b + 1, j].any() or flags[a : b + 1, p].any() \
                    or fixed[a : b + 1, p].any():
                continue  # a pair flagged over the same frames: detection's swap, or the guard's (pair_exchange)
            n = b - a + 1
            ends = []
            for entry, frames in ((True, [0] if a == 0 else range(max(a - W, 1), min(a + W, a + n // 2) + 1)),
                                  (False, [F - 1] if b == F - 1 else range(max(b - W, b - n // 2),
                                                                           min(b + W, F - 2) + 1))):
                got = []
                for f in frames:
                    lo, hi = (min(f, a), max(f, a)) if entry else (min(f, b), max(f, b))
                    if fixed[lo : hi + 1, [j, p]].any():
                        continue
                    joins = [join(k, f, entry) for k in (int(j), p)]
                    worst = max((x / y if y > 0 else (0.0 if x == 0 else np.inf)) for x, y in joins)
                    got.append((worst, f, joins))
                # the join nearest the flags' end that passes; else the one that comes closest to passing
                near = [g for g in got if g[0] < ratio]
                if got:
                    ends.append(min(near, key=lambda g: (abs(g[1] - (a if entry else b)), g[0])) if near else
                                min(got, key=lambda g: g[0]))
            if len(ends) < 2:
                continue
            (r_in, a2, j_in), (r_out, b2, j_out) = ends
            if b2 - a2 < 1 or a2 == 0 and b2 == F - 1:
                continue
            gain = max(y - x for x, y in j_in + j_out)
            better = all(x1 + x2 < y1 + y2 for (x1, y1), (x2, y2) in zip(j_in, j_out))
            # an end where the two limbs pass each other joins alike exchanged or not: it adds no step there
            level = [r < ratio or all(x <= y + END_TOL_DEG for x, y in joins) for r, joins in
                     ((r_in, j_in), (r_out, j_out))]
            confirmed = min(r_in, r_out) < ratio and all(level) and gain > END_TOL_DEG
            if confirmed or better and gain > END_TOL_DEG:
                out.append(PartnerSwap(int(j), p, a2, b2, (int(a), int(b)), bool(confirmed)))
                taken[a2 : b2 + 1, [j, p]] = True
                if confirmed:
                    q[a2 : b2 + 1, [j, p]] = mirrored[a2 : b2 + 1, [j, p]]
                    doubt[a2 : b2 + 1, [j, p]] = False
                    body, body_mirrored, unsure = in_body(q)
                    steps.clear()
    return out


def exchanged_cells(rotations: np.ndarray, repaired: np.ndarray, mirrored: np.ndarray | None, partner) -> np.ndarray:
    """(F, J) bool: the cells a repair exchanged with their left/right partner, whichever rule found the swap
    (detection's :func:`swap_exchanges`, :func:`partner_swaps`, :func:`pair_exchange`): changed from ``rotations``
    (F, J, 4) to ``repaired`` (F, J, 4) and equal, bit for bit, to the take's mirror image ``mirrored`` there, with
    the partner's cell in the same frame likewise. A record flags them as a swap on both joints, so a person
    accepts or rejects the two sides together (:mod:`mocapkit.cleaning.ties`). None ``mirrored``: none."""
    q = np.asarray(rotations)
    out = np.zeros(q.shape[:2], dtype=bool)
    if mirrored is None:
        return out
    partner = np.asarray(partner, dtype=np.int64)
    new = np.asarray(repaired)
    out = np.any(new != q, axis=-1) & np.all(new == np.asarray(mirrored), axis=-1)
    return out & out[:, partner] & (partner != np.arange(len(partner)))[None, :]
