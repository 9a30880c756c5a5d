"""Inverse kinematics for repairs: an analytic two-bone solver, FABRIK, foot contacts and foot-skate cleanup.

Aristidou et al. 2018, section 4: in the constrained case "we integrate an
inverse kinematic solver that manipulates the skeleton so that the affected
end effector moves to the desired position", followed by "a post-processing
step that involves motion refinement for foot-skating and/or foot-plant
violations" (Lyard & Magnenat-Thalmann 2007). This module is that layer,
hand-written on :class:`~mocapkit.motion.Motion`:

- :func:`two_bone_ik` - law-of-cosines solver for grandparent -> parent -> end
  (hip -> knee -> ankle, shoulder -> elbow -> wrist); changes only the local
  rotations of the two chain joints, keeps the bend plane (pole = the current
  middle joint unless given) and straightens toward out-of-reach targets.
- :func:`fabrik` - FABRIK (Aristidou & Lasenby 2011) on any parent -> child
  chain, converted back to rotations by minimal swings (twist is kept).
- :func:`foot_contacts` - ankle plants from speed and height above the clip's
  floor, thresholds in centimetres.
- :func:`foot_skate_cleanup` - pins planted ankles in the repaired frames with
  :func:`two_bone_ik` on the leg, the correction blended in and out at the
  contact edges.
- :func:`reach` - dispatches to one of the two solvers.

Positions are world positions in the file's units, as
:meth:`Motion.global_positions` gives them; joints are given by name, by
index, or by a role of :data:`mocapkit.motion.ROLES` (``"left_foot"``...).

>>> import mocapkit
>>> m = mocapkit.load(mocapkit.samples.path("12_walk.amc"))[:40]
>>> ankle = m.skeleton.index("lfoot")
>>> target = m.global_positions()[:, ankle] + [0.0, 0.5, 0.0]  # lift the ankle 0.5 units (2.8 cm)
>>> out = two_bone_ik(m, "lfoot", target)
>>> bool(np.abs(out.global_positions()[:, ankle] - target).max() < 1e-9)
True
>>> changed = np.flatnonzero(np.any(out.rotations != m.rotations, axis=(0, 2)))
>>> [m.skeleton.joint_names[j] for j in changed]
['lfemur', 'ltibia']
>>> walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
>>> c = foot_contacts(walk)
>>> c.shape, [round(float(x), 2) for x in c.mean(axis=0)]
((343, 2), [0.55, 0.36])
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from .. import rotations as R
from ..errors import SkeletonError
from ..features import parse_up_axis, detect_up_axis
from ..motion import ROLES, Motion, Skeleton, find_joint, unit_scale_cm

__all__ = ["two_bone_ik", "fabrik", "foot_contacts", "foot_skate_cleanup", "reach", "contact_segments", "segment_frames"]

_TINY = 1e-12  # relative size below which a direction or a plane is taken as degenerate
_NEAR_STRAIGHT = np.radians(10.0)  # below this bend the limb's plane comes (partly) from its usual hinge


# -- small helpers ------------------------------------------------------------------------------


def _joint_index(sk: Skeleton, joint) -> int:
    """Joint index from an index, a joint name or a role of ``ROLES``."""
    if isinstance(joint, (int, np.integer)) and not isinstance(joint, bool):
        j = int(joint)
        if not 0 <= j < sk.num_joints:
            raise SkeletonError(f"joint index {j} out of range for {sk.num_joints} joints")
        return j
    if isinstance(joint, str):
        if joint in sk.joint_names:
            return sk.index(joint)
        if joint in ROLES:
            try:
                return find_joint(sk, joint)
            except KeyError:
                raise SkeletonError(f"no joint plays the role {joint!r} in this skeleton") from None
        raise SkeletonError(f"no joint or role named {joint!r}; joints are: {', '.join(sk.joint_names)}")
    raise SkeletonError(f"a joint is a name, a role or an index, got {joint!r}")


def _frame_indices(frames, F: int) -> np.ndarray:
    """Frame indices (n,) from None (all), a boolean (F,) mask or integers (no repeats, negatives allowed)."""
    if frames is None:
        return np.arange(F)
    fr = np.asarray(frames)
    if fr.dtype == bool:
        if fr.shape != (F,):
            raise ValueError(f"frames: a boolean mask must have shape ({F},), got {fr.shape}")
        return np.flatnonzero(fr)
    if fr.ndim == 0:
        fr = fr.reshape(1)
    if fr.ndim != 1 or (fr.size and not np.issubdtype(fr.dtype, np.integer)):
        raise ValueError(
            f"frames: expected a boolean (F,) mask or a 1-D array of frame indices, got {fr.dtype} {fr.shape}"
        )
    fr = fr.astype(np.int64)
    if np.any((fr < -F) | (fr >= F)):
        raise ValueError(f"frames: indices out of range for {F} frames")
    fr = fr % F if F else fr
    if np.unique(fr).size != fr.size:
        raise ValueError("frames: repeated frame indices")
    return fr


def _per_frame(values, idx: np.ndarray, F: int, name: str) -> np.ndarray:
    """(n, 3) values for the selected frames from (F, 3) per-frame or (n, 3) per-selected-frame input."""
    v = np.asarray(values, dtype=np.float64)
    if v.ndim == 1 and v.shape == (3,):
        return np.broadcast_to(v, (idx.size, 3)).copy()
    if v.ndim == 2 and v.shape[1] == 3:
        if v.shape[0] == idx.size:
            return v.copy()
        if v.shape[0] == F:
            return v[idx]
    raise ValueError(f"{name}: expected shape ({F}, 3) or ({idx.size}, 3) (one row per selected frame), got {v.shape}")


def _sub_motion(motion: Motion, idx: np.ndarray) -> Motion:
    """The selected frames as a Motion (fancy indexing; Motion slicing only takes slices)."""
    tr = None if motion.translations is None else motion.translations[idx]
    return dataclasses.replace(
        motion, rotations=motion.rotations[idx], root_positions=motion.root_positions[idx], translations=tr
    )


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def _norm(a: np.ndarray) -> np.ndarray:
    return np.linalg.norm(a, axis=-1)


def _unit(v: np.ndarray, eps: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors and a mask of the rows whose norm exceeds ``eps`` (the others become zero)."""
    n = _norm(v)
    ok = n > eps
    safe = np.where(ok, n, 1.0)
    return np.where(ok[..., None], v / safe[..., None], 0.0), ok


def _any_perpendicular(u: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to each unit row of ``u`` (zero rows give the x axis)."""
    k = np.argmin(np.abs(u), axis=-1)
    e = np.eye(3)[k]
    p, ok = _unit(np.cross(u, e))
    return np.where(ok[..., None], p, np.array([1.0, 0.0, 0.0]))


def _smoothstep(x: np.ndarray) -> np.ndarray:
    """3x^2 - 2x^3 on [0, 1] (0 below, 1 above): a ramp with zero slope at both ends."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _angle_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unsigned angle (radians) between rows of ``u`` and ``v``, by atan2 (accurate near 0 and pi)."""
    return np.arctan2(_norm(np.cross(u, v)), _dot(u, v))


def _axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Quaternions (n, 4) from unit axes (n, 3) and angles (n,)."""
    half = 0.5 * angle
    return np.concatenate([np.cos(half)[..., None], np.sin(half)[..., None] * axis], axis=-1)


def _same_hemisphere(new: np.ndarray, old: np.ndarray) -> np.ndarray:
    """Unit ``new`` with its sign chosen to lie in ``old``'s hemisphere (keeps quaternion continuity)."""
    new = new / _norm(new)[..., None]
    return np.where((_dot(new, old) < 0.0)[..., None], -new, new)


def _parent_global(grot: np.ndarray, parents: np.ndarray, j: int) -> np.ndarray:
    """Global rotation of ``j``'s parent (identity for the root), (n, 4)."""
    p = parents[j]
    if p < 0:
        return R.identity((grot.shape[0],))
    return grot[:, p]


def _reach_frames(idx: np.ndarray, *arrays: np.ndarray) -> np.ndarray:
    """Mask of selected frames where every array row is finite."""
    ok = np.ones(idx.size, dtype=bool)
    for a in arrays:
        ok &= np.all(np.isfinite(a.reshape(a.shape[0], -1)), axis=1)
    return ok


# -- two-bone IK ------------------------------------------------------------------------------


def _hinge_axis_local(motion: Motion, gp: int, p: int, e: int) -> np.ndarray | None:
    """The limb's usual bend axis in the grandparent's (thigh's) local frame, or None if it never bends.

    The mean over the clip of ``(c - a) x (b - a) / (|c - a| |b - a|)`` (the bend
    normal scaled by the sine of the bend) mapped into the thigh's frame:
    clearly bent frames dominate, so jitter around a straight or slightly
    hyperextended knee does not decide which way the knee folds. The hinge of
    a knee or elbow is fixed in that frame.
    """
    grot, gpos = motion.global_transforms()
    a, b, c = gpos[:, gp], gpos[:, p], gpos[:, e]
    scale = _norm(c - a) * _norm(b - a)
    ok = (scale > 0) & np.all(np.isfinite(gpos[:, [gp, p, e]]), axis=(1, 2)) & np.all(np.isfinite(grot[:, gp]), axis=-1)
    if not np.any(ok):
        return None
    n = np.cross(c[ok] - a[ok], b[ok] - a[ok]) / scale[ok, None]
    local = R.quaternion_rotate(R.quaternion_conjugate(grot[ok, gp]), n)
    mean, good = _unit(local.mean(axis=0, keepdims=True), 1e-3)
    return mean[0] if good[0] else None


def _triangle_angles(l_ab: np.ndarray, l_bc: np.ndarray, l_at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angles at ``a`` (between ab and at) and at ``b`` (between ba and bc) of a triangle with these sides.

    The law of cosines in its half-angle form, ``tan(A/2) = sqrt((s-x)(s-y) / (s (s-z)))``
    with the differences formed directly, so a straight limb (``l_at = l_ab + l_bc``)
    gives exactly 0 and pi instead of the ``sqrt(eps)`` error of ``arccos``.
    Sides must satisfy the triangle inequality (``l_at`` is clamped before).
    """
    s2 = l_ab + l_bc + l_at  # 2 s
    d_ab = np.maximum(l_bc + l_at - l_ab, 0.0)  # 2 (s - l_ab)
    d_bc = np.maximum(l_ab + l_at - l_bc, 0.0)  # 2 (s - l_bc)
    d_at = np.maximum(l_ab + l_bc - l_at, 0.0)  # 2 (s - l_at)
    ang_a = 2.0 * np.arctan2(np.sqrt(d_ab * d_at), np.sqrt(s2 * d_bc))  # opposite l_bc
    ang_b = 2.0 * np.arctan2(np.sqrt(d_ab * d_bc), np.sqrt(s2 * d_at))  # opposite l_at
    return ang_a, ang_b


def two_bone_ik(motion: Motion, end_joint, targets, frames=None, pole=None) -> Motion:
    """Move ``end_joint`` to ``targets`` by rotating its parent and grandparent (analytic, law of cosines).

    The chain is ``a = parent(parent(end))`` (hip / shoulder), ``b = parent(end)``
    (knee / elbow), ``c = end`` (ankle / wrist); only the LOCAL rotations of
    ``a`` and ``b`` change, in the selected frames; every other value of the
    Motion stays bit-identical. Per frame:

    1. triangle: with ``l_ab = |b - a|``, ``l_bc = |c - b|`` and the target
       distance ``l_at = |t - a|`` clamped to ``[|l_ab - l_bc|, l_ab + l_bc]``,
       the law of cosines gives the new angles at ``a`` and ``b``; both joints
       turn about the bend-plane normal ``n = (c - a) x (b - a)``, so ``b``'s
       change is a pure hinge about that axis and ``c`` stays on the ray
       ``a -> c`` at distance ``l_at``;
    2. swing: the minimal rotation at ``a`` taking ``c - a`` to ``t - a``;
    3. pole: with ``pole``, a twist about ``a -> t`` bringing the middle joint
       into the plane of ``a``, ``t`` and the pole, on the pole's side.

    Without a pole the current middle joint is the pole hint: the bend stays in
    the current plane, carried by the minimal swing, so the knee stays on the
    side it was and nothing twists about the hip-target axis (an explicit twist
    toward the current knee is ill-conditioned for a nearly straight leg and
    would spin the thigh).

    A limb bent less than 10 degrees has no trustworthy plane (jitter, slight
    hyperextension): there ``n`` leans toward the limb's usual hinge, the bend
    axis the clip shows in the thigh's frame (weighted by bend), reaching it at
    straight, so such a knee folds forward and the solution stays continuous
    in time (the bend is done as "straighten, then fold about n", exact for any
    ``n``). An out-of-reach target gives a straight limb pointing at it (too
    near: fully folded); no NaN.

    Parameters
    ----------
    motion : Motion
    end_joint : str or int
        Joint name, index or role (``"left_foot"``, ``"right_hand"``...); it needs a parent and a grandparent.
    targets : array (F, 3) or (n, 3)
        World positions in file units: one row per frame, or one row per
        selected frame in the order of ``frames`` (that reading wins when
        n == F), or a single (3,) point for all. Frames whose target or pose
        has NaN are left unchanged.
    frames : int array (n,) or bool array (F,), optional
        Frames to solve (default all); others are untouched.
    pole : array (F, 3) or (n, 3), optional
        World points the middle joint should bend toward.

    Returns
    -------
    Motion
        A new Motion with the two chain joints' rotations changed.
    """
    sk = motion.skeleton
    F = motion.num_frames
    e = _joint_index(sk, end_joint)
    p = int(sk.parents[e])
    gp = int(sk.parents[p]) if p >= 0 else -1
    if p < 0 or gp < 0:
        raise SkeletonError(f"two_bone_ik: joint {sk.joint_names[e]!r} needs a parent and a grandparent")
    idx = _frame_indices(frames, F)
    tgt = _per_frame(targets, idx, F, "targets")
    pol = None if pole is None else _per_frame(pole, idx, F, "pole")
    if idx.size == 0:
        return motion
    sub = _sub_motion(motion, idx)
    grot, gpos = sub.global_transforms()
    ok = _reach_frames(idx, tgt, gpos[:, [gp, p, e]], grot[:, [gp, p]], _parent_global(grot, sk.parents, gp))
    if pol is not None:
        ok &= _reach_frames(idx, pol)
    if not np.any(ok):
        return motion
    idx, tgt = idx[ok], tgt[ok]
    grot, gpos = grot[ok], gpos[ok]
    pol = None if pol is None else pol[ok]
    a, b, c = gpos[:, gp], gpos[:, p], gpos[:, e]
    q_par = _parent_global(grot, sk.parents, gp)
    q_a = grot[:, gp]

    ab, cb, ca, ta = b - a, c - b, c - a, tgt - a
    l_ab, l_bc = _norm(ab), _norm(cb)
    limb = l_ab + l_bc
    eps = _TINY * np.maximum(limb, np.finfo(float).tiny)
    l_at = np.clip(_norm(ta), np.abs(l_ab - l_bc), limb)
    l_ab_safe = np.maximum(l_ab, eps)

    # 1. bend, as "straighten along a -> c, then fold about n": thigh and shin turn about the
    #    current plane normal u0 until straight, then about n by the law-of-cosines angles. With
    #    n = u0 (a clearly bent limb) this is one hinge rotation at each joint in the current plane.
    ang_a1, ang_b1 = _triangle_angles(l_ab, l_bc, l_at)
    ang_a0 = _angle_between(ca, ab)
    bend0 = np.pi - _angle_between(-ab, cb)  # 0 = straight
    ca_u, ca_ok = _unit(ca)
    ca_u = np.where(ca_ok[:, None], ca_u, _unit(ab)[0])
    u0, u0_ok = _unit(np.cross(ca, ab), 1e-9 * np.maximum(_norm(ca), eps) * l_ab_safe)
    n = u0.copy()
    near = ~u0_ok | (bend0 < _NEAR_STRAIGHT)
    if np.any(near):
        # Nearly straight: the plane is jitter; lean on the clip's usual hinge (in the thigh's frame).
        hinge = _hinge_axis_local(motion, gp, p, e)
        h = _any_perpendicular(ca_u[near])
        if hinge is not None:
            hh = R.quaternion_rotate(q_a[near], hinge)
            hh = hh - _dot(hh, ca_u[near])[:, None] * ca_u[near]
            hu, hok = _unit(hh, 1e-6)
            h = np.where(hok[:, None], hu, h)
        uu = u0[near] * np.where(_dot(u0[near], h) < 0.0, -1.0, 1.0)[:, None]
        w = _smoothstep(bend0[near] / _NEAR_STRAIGHT)[:, None] * u0_ok[near, None]
        blend, b_ok = _unit(w * uu + (1.0 - w) * h, 1e-6)
        n[near] = np.where(b_ok[:, None], blend, h)
    u0 = np.where(u0_ok[:, None], u0, n)
    straighten_a = _axis_angle(u0, -ang_a0)
    q_a_straight = R.quaternion_multiply(straighten_a, q_a)
    r_a = R.quaternion_multiply(_axis_angle(n, ang_a1), straighten_a)
    # knee: both hinge turns expressed in the thigh's frame at the moment they happen
    k1 = R.quaternion_multiply(R.quaternion_conjugate(q_a), R.quaternion_multiply(_axis_angle(u0, bend0), q_a))
    k2 = R.quaternion_multiply(
        R.quaternion_conjugate(q_a_straight),
        R.quaternion_multiply(_axis_angle(n, ang_b1 - np.pi), q_a_straight),
    )
    k = R.quaternion_multiply(k2, k1)

    # 2. swing the (unchanged) direction a -> c onto a -> t.
    d, d_ok = _unit(ta, eps)
    d = np.where(d_ok[:, None], d, ca_u)
    r_s = R.shortest_arc(ca, d)
    q1 = R.quaternion_multiply(r_s, r_a)

    # 3. with a pole, twist about a -> t so the middle joint turns toward it.
    q_total = q1
    if pol is not None:
        b1 = R.quaternion_rotate(q1, ab)
        kp = b1 - _dot(b1, d)[:, None] * d
        pp = (pol - a) - _dot(pol - a, d)[:, None] * d
        kp_u, k_ok = _unit(kp, 1e-9 * limb)
        pp_u, p_ok = _unit(pp, 1e-9 * limb)
        twist = np.arctan2(_dot(d, np.cross(kp_u, pp_u)), _dot(kp_u, pp_u))
        twist = np.where(k_ok & p_ok, twist, 0.0)
        q_total = R.quaternion_multiply(_axis_angle(d, twist), q1)

    # Local rotations: a's parent frame is unchanged; b's local change is the hinge turn k (thigh frame).
    new_ga = R.quaternion_multiply(q_total, q_a)
    la_new = R.quaternion_multiply(R.quaternion_conjugate(q_par), new_ga)
    lb_new = R.quaternion_multiply(k, motion.rotations[idx, p])
    rot = np.array(motion.rotations)
    rot[idx, gp] = _same_hemisphere(la_new, rot[idx, gp])
    rot[idx, p] = _same_hemisphere(lb_new, rot[idx, p])
    return dataclasses.replace(motion, rotations=rot)


# -- FABRIK ----------------------------------------------------------------------------------


def _resolve_chain(sk: Skeleton, chain: Sequence) -> list[int]:
    """Joint indices root -> end; a gap between an ancestor and a descendant is filled with the path between."""
    js = [_joint_index(sk, j) for j in chain]
    if len(js) < 2:
        raise ValueError("fabrik: a chain needs at least two joints (a root and an end effector)")
    out = [js[0]]
    for j in js[1:]:
        path = [j]
        while path[-1] != out[-1]:
            up = int(sk.parents[path[-1]])
            if up < 0:
                raise SkeletonError(
                    f"fabrik: {sk.joint_names[out[-1]]!r} is not an ancestor of {sk.joint_names[j]!r}; "
                    "a chain runs from a joint down to one of its descendants"
                )
            path.append(up)
        out.extend(reversed(path[:-1]))
    return out


def _fabrik_positions(P: np.ndarray, t: np.ndarray, iterations: int, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """FABRIK on joint positions P (n, k, 3) toward targets t (n, 3); returns new positions and iterations used."""
    n, k, _ = P.shape
    P = P.copy()
    lengths = _norm(P[:, 1:] - P[:, :-1])  # (n, k-1)
    total = lengths.sum(axis=1)
    root = P[:, 0].copy()
    used = np.zeros(n, dtype=np.int64)

    def place(frm, to, length):  # point at ``length`` from ``frm`` toward ``to``
        u, ok = _unit(to - frm)
        return frm + u * length[:, None]

    far = _norm(t - root) >= total
    if np.any(far):  # out of reach: straight toward the target (Aristidou & Lasenby 2011, Alg. 1, first branch)
        for i in range(k - 1):
            P[far, i + 1] = place(P[far, i], t[far], lengths[far, i])
    active = ~far & (_norm(P[:, -1] - t) > tolerance)
    for it in range(iterations):
        if not np.any(active):
            break
        Q, tt, L = P[active], t[active], lengths[active]
        Q[:, -1] = tt  # backward reaching: end effector on the target
        for i in range(k - 2, -1, -1):
            Q[:, i] = place(Q[:, i + 1], Q[:, i], L[:, i])
        Q[:, 0] = root[active]  # forward reaching: root back in place
        for i in range(k - 1):
            Q[:, i + 1] = place(Q[:, i], Q[:, i + 1], L[:, i])
        P[active] = Q
        used[active] = it + 1
        active[active] = _norm(Q[:, -1] - tt) > tolerance
    return P, used


def fabrik(
    motion: Motion, chain: Sequence, targets, frames=None, iterations: int = 20, tolerance: float = 1e-3
) -> Motion:
    """FABRIK (Aristidou & Lasenby 2011) on ``chain`` so its last joint reaches ``targets``.

    Positions are solved by backward/forward reaching with the chain's first
    joint fixed, then turned into rotations from the root down: each chain
    joint (except the end) gets the minimal swing from its old to its new bone
    direction, so twist about the bones is kept and bone lengths are exact.
    Only the local rotations of the chain joints other than the end change, in
    the selected frames; an out-of-reach target gives a straight chain pointing
    at it. Iteration stops per frame when the end is within ``tolerance``.

    Parameters
    ----------
    motion : Motion
    chain : sequence of str or int
        Joints root -> end effector (names, indices or roles); each must be an
        ancestor of the next, missing joints in between are filled in, so
        ``["lowerback", "lwrist"]`` is the whole spine-to-wrist chain.
    targets : array (F, 3) or (n, 3)
        World positions in file units (rows with NaN leave their frame unchanged).
    frames : int array (n,) or bool array (F,), optional
    iterations : int
        Most backward/forward passes per frame.
    tolerance : float
        Distance to the target, in the file's units, at which a frame stops
        (1e-3 units = 0.056 mm on CMU/HDM05 skeletons, 0.01 mm on centimetre rigs).

    Returns
    -------
    Motion
    """
    sk = motion.skeleton
    F = motion.num_frames
    js = _resolve_chain(sk, chain)
    if iterations < 0:
        raise ValueError(f"fabrik: iterations must be >= 0, got {iterations}")
    if not tolerance >= 0:
        raise ValueError(f"fabrik: tolerance must be >= 0, got {tolerance}")
    idx = _frame_indices(frames, F)
    tgt = _per_frame(targets, idx, F, "targets")
    if idx.size == 0:
        return motion
    sub = _sub_motion(motion, idx)
    grot, gpos = sub.global_transforms()
    ok = _reach_frames(idx, tgt, gpos[:, js], grot[:, js], _parent_global(grot, sk.parents, js[0]))
    if not np.any(ok):
        return motion
    idx, tgt, grot, gpos = idx[ok], tgt[ok], grot[ok], gpos[ok]
    P_new, _ = _fabrik_positions(gpos[:, js], tgt, int(iterations), float(tolerance))

    local_off = _sub_motion(motion, idx).local_offsets()
    rot = np.array(motion.rotations)
    q_parent = _parent_global(grot, sk.parents, js[0])
    pos = gpos[:, js[0]]
    for i in range(len(js) - 1):
        j, child = js[i], js[i + 1]
        q_cur = R.quaternion_multiply(q_parent, rot[idx, j])
        bone = R.quaternion_rotate(q_cur, local_off[:, child])
        q_new = R.quaternion_multiply(R.shortest_arc(bone, P_new[:, i + 1] - pos), q_cur)
        local = R.quaternion_multiply(R.quaternion_conjugate(q_parent), q_new)
        rot[idx, j] = _same_hemisphere(local, rot[idx, j])
        q_parent = R.quaternion_multiply(q_parent, rot[idx, j])
        pos = pos + R.quaternion_rotate(q_parent, local_off[:, child])
    return dataclasses.replace(motion, rotations=rot)


# -- reach: one entry point --------------------------------------------------------------------


def reach(
    motion: Motion, end_joint, targets, frames=None, method: str = "two_bone", chain_length: int = 3, **kwargs
) -> Motion:
    """Move ``end_joint`` to ``targets`` with :func:`two_bone_ik` or :func:`fabrik` (the section-4 IK step).

    ``chain_length`` is the number of joints of the FABRIK chain ending at
    ``end_joint`` (3 = the same joints as the two-bone solver); ``kwargs`` go
    to the solver (``pole`` for two-bone, ``iterations``/``tolerance`` for FABRIK).
    """
    if method == "two_bone":
        return two_bone_ik(motion, end_joint, targets, frames=frames, **kwargs)
    if method == "fabrik":
        sk = motion.skeleton
        if chain_length < 2:
            raise ValueError(f"reach: chain_length must be >= 2, got {chain_length}")
        chain = [_joint_index(sk, end_joint)]
        while len(chain) < chain_length:
            up = int(sk.parents[chain[-1]])
            if up < 0:
                raise SkeletonError(f"reach: {sk.joint_names[chain[0]]!r} has fewer than {chain_length - 1} ancestors")
            chain.append(up)
        return fabrik(motion, chain[::-1], targets, frames=frames, **kwargs)
    raise ValueError(f"reach: method must be 'two_bone' or 'fabrik', got {method!r}")


# -- foot contacts -----------------------------------------------------------------------------


def contact_segments(mask: np.ndarray) -> list[tuple[int, int]]:
    """Runs of True in a boolean (F,) array as half-open ``(start, end)`` frame ranges.

    >>> contact_segments(np.array([0, 1, 1, 0, 1], dtype=bool))
    [(1, 3), (4, 5)]
    """
    m = np.asarray(mask, dtype=bool).astype(np.int8)
    d = np.diff(np.concatenate([[0], m, [0]]))
    return [(int(s), int(e)) for s, e in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1))]


def segment_frames(starts, lengths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Segments laid end to end: ``(frames, segment, first)``.

    Segment ``i`` covers frames ``starts[i] .. starts[i] + lengths[i] - 1``;
    ``frames`` (sum of lengths,) are all of them in segment order, ``segment``
    the segment of each, and ``first`` (n,) each segment's first position
    among them: the index arrays that treat many runs at once.

    >>> frames, segment, first = segment_frames([1, 4], [2, 3])
    >>> frames.tolist(), segment.tolist(), first.tolist()
    ([1, 2, 4, 5, 6], [0, 0, 1, 1, 1], [0, 2])
    """
    starts = np.asarray(starts, dtype=np.int64)
    lengths = np.asarray(lengths, dtype=np.int64)
    first = np.cumsum(lengths) - lengths
    segment = np.repeat(np.arange(len(lengths)), lengths)
    return starts[segment] + np.arange(len(segment)) - first[segment], segment, first


def _clean_runs(mask: np.ndarray, min_frames: int) -> np.ndarray:
    """Fill interior gaps shorter than ``min_frames``, then drop contacts shorter than ``min_frames``."""
    out = mask.copy()
    F = out.size
    for s, e in contact_segments(~out):
        if s > 0 and e < F and e - s < min_frames:
            out[s:e] = True
    for s, e in contact_segments(out):
        if e - s < min_frames:
            out[s:e] = False
    return out


def _speed(P: np.ndarray, fps: float, k: int) -> np.ndarray:
    """Speed (F, ...) by central differences over +-k frames (edges repeated), in units per second."""
    pad = [(k, k)] + [(0, 0)] * (P.ndim - 1)
    Q = np.pad(P, pad, mode="edge")
    return _norm(Q[2 * k:] - Q[: Q.shape[0] - 2 * k]) * fps / (2 * k)


def _toe_of(sk: Skeleton, foot: int) -> int | None:
    """The toe joint of ankle ``foot``: the toe role on the same side if it is a child, else its first child."""
    kids = sk.children(foot)
    for role in ("left_toe", "right_toe"):
        try:
            t = find_joint(sk, role)
        except KeyError:
            continue
        if t in kids:
            return t
    return kids[0] if kids else None


def foot_contacts(
    motion: Motion,
    feet: Sequence = ("left_foot", "right_foot"),
    velocity_cm_s: float = 40.0,
    height_cm: float = 10.0,
    toes: bool = False,
    min_duration_s: float = 0.1,
    up_axis=None,
    floor_percentile: float = 2.0,
) -> np.ndarray:
    """Foot plants (F, n_feet): the ankle is slow and near the clip's floor.

    A frame is a contact of a foot when its ankle moves slower than
    ``velocity_cm_s`` (central difference over about 1/30 s, robust to
    marker jitter) and sits less than ``height_cm`` above the floor, the
    ``floor_percentile``-th percentile of all the ankles' heights along the up
    axis (so a slightly sloped or offset floor still works). With ``toes`` the
    toe joint must also be slow and within ``height_cm`` of the toes' floor
    (flat-foot contacts only; the default counts heel plants too, which is
    what pinning the ankle needs). Gaps and contacts shorter than
    ``min_duration_s`` are then filled / dropped. Thresholds are in cm via
    :func:`~mocapkit.motion.unit_scale_cm`; the defaults give alternating
    plants of 0.5-0.6 s on the CMU walk 12_walk.amc (stance 35-60 % of frames).

    Parameters
    ----------
    feet : sequence of str or int
        Ankle joints (names, indices or roles).
    up_axis : optional
        ``"y"``, ``"-z"``, an index or a vector; default :func:`~mocapkit.features.detect_up_axis`.

    Returns
    -------
    bool array (F, len(feet))
    """
    sk = motion.skeleton
    F = motion.num_frames
    feet_idx = [_joint_index(sk, f) for f in feet]
    if not feet_idx:
        raise ValueError("foot_contacts: no feet given")
    if not (velocity_cm_s > 0 and height_cm > 0 and min_duration_s >= 0):
        raise ValueError("foot_contacts: velocity_cm_s and height_cm must be > 0, min_duration_s >= 0")
    up = detect_up_axis(sk) if up_axis is None else parse_up_axis(up_axis)
    cm = unit_scale_cm(sk)
    if F == 0:
        return np.zeros((0, len(feet_idx)), dtype=bool)
    pos = motion.global_positions() * cm
    k = max(1, int(round(motion.fps / 60.0)))
    min_frames = max(1, int(round(min_duration_s * motion.fps)))

    def low_and_slow(joints: list[int]) -> np.ndarray:
        P = pos[:, joints]  # (F, n, 3)
        h = P @ up
        finite = np.isfinite(h)
        if not np.any(finite):
            return np.zeros((F, len(joints)), dtype=bool)
        floor = np.percentile(h[finite], floor_percentile)
        with np.errstate(invalid="ignore"):
            return (_speed(P, motion.fps, k) < velocity_cm_s) & (h - floor < height_cm)

    out = low_and_slow(feet_idx)
    if toes:
        toe_idx = [_toe_of(sk, f) for f in feet_idx]
        have = [i for i, t in enumerate(toe_idx) if t is not None]
        if have:
            out[:, have] &= low_and_slow([toe_idx[i] for i in have])
    return np.stack([_clean_runs(out[:, i], min_frames) for i in range(out.shape[1])], axis=1)


# -- foot-skate cleanup -------------------------------------------------------------------------


def _soften(pos: np.ndarray, end: int, parents: np.ndarray, target: np.ndarray, soft_reach: float) -> np.ndarray:
    """Pull targets near full extension inward (soft IK), so a leg straightens smoothly instead of snapping.

    With ``L`` the limb length, ``r`` the target's distance from the hip and
    ``s = max(r_now, soft_reach * L)`` (never below the current extension, so a
    pose the clip already has is kept), a target beyond ``s`` goes to
    ``s + (L - s)(1 - exp(-(r - s) / (L - s)))``: continuous, with continuous
    slope, and below ``L``. Near full extension the knee angle moves as
    ``sqrt(L - r)``, so without this a target crossing ``L`` makes the knee pop.
    """
    p = int(parents[end])
    gp = int(parents[p])
    hip, knee, ankle = pos[:, gp], pos[:, p], pos[:, end]
    L = _norm(knee - hip) + _norm(ankle - knee)
    r_now = _norm(ankle - hip)
    v = target - hip
    r = _norm(v)
    s = np.minimum(np.maximum(r_now, soft_reach * L), L)
    span = L - s
    soft = (r > s) & (span > 1e-9 * L)
    r_new = r.copy()
    sp = np.where(soft, span, 1.0)
    r_new[soft] = (s + span * (1.0 - np.exp(-(r - s) / sp)))[soft]
    hard = (r > s) & ~soft
    r_new[hard] = np.minimum(r, L)[hard]
    scale = np.where(r > 0, r_new / np.where(r > 0, r, 1.0), 1.0)
    return hip + v * scale[:, None]


def foot_skate_cleanup(
    motion: Motion,
    frames=None,
    contacts: np.ndarray | None = None,
    blend_frames: int | None = None,
    feet: Sequence = ("left_foot", "right_foot"),
    keep_foot_orientation: bool = True,
    soft_reach: float | None = 0.98,
) -> Motion:
    """Pin planted ankles in the repaired ``frames`` (Lyard & Magnenat-Thalmann 2007 style; Aristidou 2018 sec. 4).

    For each foot and each contact segment the plant is the ankle's median
    position over the segment's frames outside ``frames`` (the trusted ones),
    or over the whole segment when all of it was repaired. In the selected
    frames of the segment the ankle is moved onto the plant by
    :func:`two_bone_ik` on that leg's hip and knee; the correction fades in
    over the segment's first ``blend_frames`` frames and out over its last
    ones (smoothstep weight on the target, zero slope at the ends), so the
    foot lands and leaves without a pop and frames between plants are not
    touched. With ``keep_foot_orientation`` the ankle joint's rotation is
    adjusted so the foot keeps its world orientation (the toes do not swing
    with the corrected shin); ``soft_reach`` keeps the knee from snapping
    straight when a plant is out of the leg's reach. Frames outside
    ``frames`` are bit-identical.

    Parameters
    ----------
    frames : int array or bool (F,), optional
        Frames that may change (the repaired ones); default all.
    contacts : bool array (F, n_feet), optional
        Plants per foot, columns in ``feet`` order; default :func:`foot_contacts`
        on ``motion`` (pass the contacts of the motion before repair when the
        repair itself made the foot slide).
    blend_frames : int, optional
        Ramp length in frames; default 0.1 s of frames.
    feet : sequence
        Ankle joints (names, indices or roles).
    keep_foot_orientation : bool
        Keep each corrected foot's world orientation (changes the ankle joint's rotation too).
    soft_reach : float or None
        Soft IK (see :func:`_soften`): targets beyond ``max(current extension,
        soft_reach * leg length)`` are pulled in smoothly so the knee never
        snaps straight; None or 1 gives the hard clamp of :func:`two_bone_ik`.

    Returns
    -------
    Motion
    """
    sk = motion.skeleton
    F = motion.num_frames
    feet_idx = [_joint_index(sk, f) for f in feet]
    if contacts is None:
        contacts = foot_contacts(motion, feet=feet_idx)
    contacts = np.asarray(contacts, dtype=bool)
    if contacts.ndim == 1 and len(feet_idx) == 1:
        contacts = contacts[:, None]
    if contacts.shape != (F, len(feet_idx)):
        raise ValueError(f"contacts: expected shape ({F}, {len(feet_idx)}), got {contacts.shape}")
    B = max(0, int(round(0.1 * motion.fps))) if blend_frames is None else int(blend_frames)
    if B < 0:
        raise ValueError(f"blend_frames must be >= 0, got {blend_frames}")
    if soft_reach is not None and not 0.0 < soft_reach <= 1.0:
        raise ValueError(f"soft_reach must be in (0, 1] or None, got {soft_reach}")
    sel = np.zeros(F, dtype=bool)
    sel[_frame_indices(frames, F)] = True
    if not np.any(sel) or not np.any(contacts):
        return motion

    out = motion
    for col, foot in enumerate(feet_idx):
        segs = contact_segments(contacts[:, col])
        if not segs:
            continue
        ankle = out.global_positions()[:, foot]
        delta = np.zeros((F, 3))
        weight = np.zeros(F)
        for s, e in segs:
            seg = np.arange(s, e)
            trusted = seg[~sel[seg]]
            src = trusted if trusted.size else seg
            vals = ankle[src]
            vals = vals[np.all(np.isfinite(vals), axis=1)]
            if vals.size == 0:
                continue
            plant = np.median(vals, axis=0)
            # the correction fades in over the first B frames of the plant and out over its last B
            edge = np.minimum(seg - s + 1, e - seg)
            w = _smoothstep(edge / (B + 1.0))
            fix = sel[seg]
            delta[seg[fix]] = plant - ankle[seg[fix]]
            weight[seg[fix]] = w[fix]
        todo = sel & (weight > 0) & np.all(np.isfinite(delta), axis=1)
        todo &= np.any(delta != 0.0, axis=1)
        if not np.any(todo):
            continue
        idx = np.flatnonzero(todo)
        target = ankle[idx] + weight[idx, None] * delta[idx]
        if soft_reach is not None and soft_reach < 1.0:
            target = _soften(_sub_motion(out, idx).global_positions(), foot, sk.parents, target, soft_reach)
        before = out.global_rotations()[idx, foot] if keep_foot_orientation else None
        solved = two_bone_ik(out, foot, target, frames=idx)
        if keep_foot_orientation:
            knee = int(sk.parents[foot])
            g_knee = _sub_motion(solved, idx).global_rotations()[:, knee]
            local = R.quaternion_multiply(R.quaternion_conjugate(g_knee), before)
            ok = np.all(np.isfinite(local), axis=1)
            rot = np.array(solved.rotations)
            rot[idx[ok], foot] = _same_hemisphere(local[ok], rot[idx[ok], foot])
            solved = dataclasses.replace(solved, rotations=rot)
        out = solved
    return out
