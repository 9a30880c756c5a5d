"""A repair that turns a joint half a turn is judged by where it puts the limb, not by its rotations.

A joint chain has more than one set of rotations for one set of positions: an inverse-kinematics solver that
fits a skeleton to markers may turn a thigh half a turn about its own bone and bend the knee past its limit the
other way, the *other solution* of the leg, with the knee and foot where the markers put them. Its rotations
step where the solver changes solution while the limb's positions run on smoothly, so self-similarity repair
(Aristidou et al. 2018, section 4) takes the steps for an error: a transient offset taken away, or a bridge
slerped from one solution to the other across a run, turns the joint half a turn and the bones below it follow,
the foot wherever the joint's new rotation puts it, not where the capture had it. The rotation rules
of :mod:`~mocapkit.cleaning.ssa.guard` cannot see it: the repaired rotations join the take more smoothly than
the solver's steps did.

The take's positions can: over a run, the positions of the joint's descendants (its joints and end sites below
it) follow a path their joins imply, the cubic Hermite curve from the frame before the run to the frame after
it with the limb's own velocity on each side (:func:`joined_positions`, as
:func:`~mocapkit.cleaning.ssa.guard.joined_path` for rotations). A repaired run that moves some cell by
:data:`HALF_TURN_DEG` or more from its input, and whose limb lies on average further from that path than the
input's did (by more than :data:`LIMB_MARGIN` of it), is given back (:func:`limb_runs`): an error of half a
turn (a flip, a swap of two limbs that move apart) puts the limb off the path and its repair puts it back, so
only a repair that takes the limb away from where the capture had it fails. The positions are taken in the
parent's frame (:func:`limb_positions`), so the body's own motion above the joint does not swamp the limb's.
HDM05 dg ``squat1Reps`` 025 (``corrupt.real_errors`` seed 1001): the left thigh's swap over frames 62-78 ends
on the solver's other solution (78-82), and its bridge, turning the thigh up to 166 deg to meet frame 79, put
the foot up to 9 units off the clean take where the swapped input had it within 1 (4.7 against 1.7 units from
the joined path, over the knee, ankle, toes and toe tip); bk ``depositFloorR`` 007 (seed 1001): the right
thigh's other solution over 138-205, taken away as an offset, put the foot 5.5-10.5 units off (5.0 against 4.1
from the path). Each is given back and named; a run inside it, of a joint below, replaced from neighbour words
or bridged, goes with it (:func:`limb_left`). Where the joint's left/right partner digresses over the same
frames, the pair is exchanged back as a swap (each its partner's mirrored rotation) if that puts both limbs
nearer their joined paths than the input (:func:`exchange_nearer`): the squat's thighs, swapped over 62-78, put
back exactly (37.5 -> 0.0 deg), where the exchange's rotation joins fail at frame 79 on the solver's own step.
A rule of this library, not of the paper.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ... import rotations as R
from ..ik import contact_segments

__all__ = ["HALF_TURN_DEG", "LIMB_MARGIN", "below", "exchange_nearer", "joined_positions", "limb_left",
           "limb_positions", "limb_runs"]

#: degrees: a repaired run that moves some cell of its joint this far from its input turns the limb below it
#: elsewhere and is judged by the limb's positions (a thigh's other solution taken away: 150-180 deg)
HALF_TURN_DEG = 90.0
#: a run fails where its limb lies further from the joined path than the input's by more than this share of the
#: input's distance: a half turn about the bone itself moves nothing below it but an end site, and ties
LIMB_MARGIN = 0.1


def below(parents: np.ndarray, end_site_parents: np.ndarray, j: int) -> np.ndarray:
    """The rows of the positions ``Motion.global_positions(end_sites=True)`` (F, J + E, 3) that joint ``j`` moves:
    the joints below it (not ``j`` itself) and the end sites of ``j`` and of those joints, in row order.

    ``parents`` (J,) int, each joint's parent (-1 for the root); ``end_site_parents`` (E,) int, each end site's
    joint.
    """
    parents = np.asarray(parents, dtype=np.int64)
    J = len(parents)
    under = np.zeros(J, dtype=bool)
    under[j] = True
    for k in range(J):  # parents come before their children
        if parents[k] >= 0 and under[parents[k]]:
            under[k] = True
    sites = under[np.asarray(end_site_parents, dtype=np.int64)]
    under[j] = False
    return np.concatenate([np.flatnonzero(under), J + np.flatnonzero(sites)])


def limb_positions(motion, grot: np.ndarray, gpos: np.ndarray, j: int) -> np.ndarray:
    """(F, K, 3): the positions of joint ``j``'s descendants (:func:`below`) in its parent's frame, relative to the
    parent (the root's: in the world), in the file's units: the limb as joint ``j`` and the joints below it place it,
    whatever the body above does.

    ``motion`` gives the skeleton; ``grot`` (F, J, 4) and ``gpos`` (F, J, 3) its global rotations and positions
    (:meth:`~mocapkit.motion.Motion.global_transforms`, of the rotations to judge).
    """
    sk = motion.skeleton
    rows = below(sk.parents, sk.end_site_parents, j)
    pos = np.concatenate([gpos, motion.end_sites_from(grot, gpos)], axis=1)[:, rows]
    p = int(sk.parents[j])
    if p < 0:
        return pos
    return R.quaternion_rotate(R.quaternion_inverse(grot[:, p])[:, None], pos - gpos[:, p, None])


def joined_positions(p: np.ndarray, start: int, end: int) -> np.ndarray | None:
    """(end - start, K, 3): the path the joins of the run ``start .. end - 1`` imply for the positions ``p`` (F, K, 3);
    None where the run has no frame on one side to read a velocity from (``start < 2`` or ``end > F - 2``).

    The cubic Hermite curve from ``p[start - 1]`` to ``p[end]`` over ``end - start + 1`` frame steps, its tangents
    the velocity into the run (``p[start - 1] - p[start - 2]``) and out of it (``p[end + 1] - p[end]``), in the
    positions' units per frame. The values inside the run are never read.
    """
    p = np.asarray(p, dtype=np.float64)
    F = len(p)
    if start < 2 or end > F - 2 or end <= start:
        return None
    steps = end - start + 1
    u = ((np.arange(start, end) - (start - 1)) / steps)[:, None, None]
    p0, p1 = p[start - 1], p[end]
    m0, m1 = (p[start - 1] - p[start - 2]) * steps, (p[end + 1] - p[end]) * steps
    return ((2 * u**3 - 3 * u**2 + 1) * p0 + (u**3 - 2 * u**2 + u) * m0 + (3 * u**2 - 2 * u**3) * p1
            + (u**3 - u**2) * m1)


def limb_runs(orig: np.ndarray, out: np.ndarray, changed: np.ndarray, pos_in: np.ndarray,
              pos_out: np.ndarray) -> list[tuple[int, int, str]]:
    """The runs of one joint's repair that turn it half a turn and take its limb off the path the joins imply
    (module docstring), as ``(start, end, reason)`` (end exclusive).

    ``orig``, ``out`` (F, 4): the joint's input and repaired tracks; ``changed`` (F,) bool: the frames the repair
    changed (the runs judged are its maximal runs); ``pos_in``, ``pos_out`` (F, K, 3): the positions of the
    joint's descendants (:func:`below`) in the input and in the repaired take, in the file's units. A run is judged
    where some cell moves :data:`HALF_TURN_DEG` or more and the run has two frames on each side; the mean distance
    of ``pos_out`` and of ``pos_in`` from :func:`joined_positions` of ``pos_in`` over the run and the descendants
    are compared, the output failing where it is further by more than :data:`LIMB_MARGIN` of the input's.
    """
    orig, out = np.asarray(orig, dtype=np.float64), np.asarray(out, dtype=np.float64)
    if np.shape(pos_in)[1] == 0:
        return []
    turn = np.degrees(R.geodesic_angle(orig, out))
    bad = []
    for s, e in contact_segments(np.asarray(changed, dtype=bool)):
        if turn[s:e].max() < HALF_TURN_DEG:
            continue
        path = joined_positions(pos_in, s, e)
        if path is None:
            continue
        d_out = float(np.linalg.norm(pos_out[s:e] - path, axis=-1).mean())
        d_in = float(np.linalg.norm(pos_in[s:e] - path, axis=-1).mean())
        if d_out > (1.0 + LIMB_MARGIN) * d_in:
            bad.append((int(s), int(e), f"turns the joint up to {turn[s:e].max():.0f} deg and puts the limb below it "
                                        f"{d_out:.2f} units from the path its joins imply, the input {d_in:.2f}"))
    return bad


def limb_left(changed: np.ndarray, left: list[tuple[int, int, int]], parents: np.ndarray,
              replaced: np.ndarray) -> list[tuple[int, int, int, str]]:
    """The runs to leave because :func:`limb_runs` left a joint above them over the same frames, as ``(joint, start,
    end, reason)``.

    ``changed`` (F, J) bool: the cells the repair changed (each joint's maximal runs are judged); ``left``
    ``(joint, start, end)``: the runs :func:`limb_runs` left (frames ``start .. end - 1``); ``parents`` (J,) int;
    ``replaced`` (F, J) bool: the cells written from neighbour words or bridged. A run of a joint below a left one,
    within its frames and replaced throughout, is left: the capture's rotations below a joint are relative to
    it, and where the joint's half turn is the capture's own (the other solution of a leg), the digression of the
    joints below it over the same frames is that solution's bend, not an error; repaired against the joint's own
    values, it puts the limb off the capture as well (HDM05 bk ``depositFloorR`` with ``real_errors`` seed 1001:
    the right knee over frames 173-205, inside the thigh's other solution, 0.0 -> 33.7 deg off the clean take).
    """
    parents = np.asarray(parents, dtype=np.int64)
    J = len(parents)
    out = []
    for j, s, e in left:
        under = below(parents, np.zeros(0, dtype=np.int64), j)
        for k in under[under < J]:
            for a, b in contact_segments(np.asarray(changed[:, k], dtype=bool)):
                if s <= a and b <= e and replaced[a:b, k].all():
                    out.append((int(k), int(a), int(b), f"the joint above it is left over frames {s}-{e - 1} by its "
                                                        "limb's positions: the joints below follow it"))
    return out


def exchange_nearer(motion, mirrored: np.ndarray, joints, start: int, end: int) -> bool:
    """Whether the left/right pair ``joints`` exchanged with their mirrored rotations over frames ``start .. end - 1``
    puts both limbs nearer the path their joins imply than the input does (the mean distance of each limb's
    positions, :func:`limb_positions`, from :func:`joined_positions` of the input's over the run).

    The rotation joins of such an exchange may fail where the take's own other solution steps at the run's end
    (:func:`~mocapkit.cleaning.ssa.swap_exchange.pair_exchange`), while the limbs' positions run on: HDM05 dg
    ``squat1Reps`` 025 (``real_errors`` seed 1001), the thighs swapped over frames 62-78, the left one's next
    frame on its other solution. ``motion`` the input take; ``mirrored`` (F, J, 4) its mirrored rotations
    (:func:`~mocapkit.cleaning.ssa.cues.mirrored_rotations`).
    """
    joints = list(joints)
    trial = np.array(motion.rotations)
    trial[start:end, joints] = mirrored[start:end, joints]
    given = motion.global_transforms()
    exchanged = dataclasses.replace(motion, rotations=trial).global_transforms()
    for k in joints:
        p_in, p_ex = limb_positions(motion, *given, k), limb_positions(motion, *exchanged, k)
        path = joined_positions(p_in, start, end)
        if path is None or p_in.shape[1] == 0:
            return False
        d_ex = float(np.linalg.norm(p_ex[start:end] - path, axis=-1).mean())
        d_in = float(np.linalg.norm(p_in[start:end] - path, axis=-1).mean())
        if not d_ex < d_in:
            return False
    return True
