"""A left/right mirror image that keeps the take's own skeleton.

:meth:`mocapkit.motion.Motion.mirror` reflects a take and mirrors its skeleton
too: exact positions on any rig, but rotations that pose the *mirrored*
skeleton. Where the reflection maps the skeleton onto itself (Acclaim, the CMU
and most BVH conversions: :func:`~mocapkit.motion.mirror_mismatch` a few per
cent) those rotations fit the original skeleton as well, and a database of
mirrored clips or a label-swap check can reuse them there. On rigs whose bones
lie along each joint's own axis with frames that differ by side (the Bandai
Namco game rig: the rest pose lies along one axis, the left arm along +x and
the right along -x) they pose another body. :func:`mirror_keeping_skeleton`
gives the mirror image on the take's own skeleton, and :func:`mirror_for_rig`
picks whichever of the two fits the rig (the first where it maps onto itself,
so those rigs' results are unchanged).

The maths
---------
Let ``M`` be the reflection across the sagittal plane (``-1`` on the lateral
axis), ``p = pi(j)`` the left/right partner of joint ``j``
(:func:`~mocapkit.motion.mirror_pairs`), ``L_j`` / ``G_j`` the local / global
rotations of the take and ``o_j`` the skeleton offsets. ``Motion.mirror``
gives offsets ``o'_j = M o_p``, rotations ``L'_j = M L_p M`` and so global
rotations ``G'_j = M G_p M`` and positions ``P'_j = M P_p``.

On the original skeleton take the global rotations ``G*_j = G'_j C_j`` with a
constant per-joint *rest correction* ``C_j``. Then joint ``c`` (child of
``j``) lies at ``P*_j + G'_j C_j o_c``, which is ``P'_c`` whenever
``C_j o_c = o'_c``: every bone points where the reflected take's bone points
and joints land on the reflected, pair-swapped positions up to the
difference of a bone's length and its partner's. The local rotations are
``L*_j = C_par^-1 L'_j C_j`` (the root: ``L'_0 C_0``), the root position
``M r``, and animated joint translations ``t*_j = C_par^-1 M t_p``, which
puts those joints exactly. ``C_j`` relates joint ``j``'s rest frame to the
reflection of its partner's: ``K_j = M C_j`` is the fixed improper map with
``G*_j = M G_p K_j``. A rig that maps onto itself has ``C = I`` (``K = M``);
limbs of a game rig mirrored with reversed bone axes have ``K = -I`` (all
three axes of the right frame reversed from the left's).

``C_j`` from the rest pose:

* children at two or more directions (a branching joint: non-collinear
  offsets): the rotation taking the offsets ``o_c`` best onto ``o'_c``
  (Kabsch; exact where the partner bones are as long);
* one direction (a single child, a chain): the shortest rotation ``S``
  taking ``B o_c`` onto ``o'_c`` after a reference ``B``, ``C_j = S B``. The
  bone fixes ``C_j`` only up to a twist about it; the reference fixes the
  twist. It is the correction of the branching joint the chain of single
  bones leads down to (the spine takes the chest's twist, so the chest's
  local rotation keeps its angle), else (a limb's chain that ends in an end
  effector) the parent's, parents before children. Where the reference's
  corrected bone points away from the mirrored one (the bone reverses
  direction by side) the reference is also tried turned half a turn about its
  lateral axis, ``B = H(M l) C_ref`` with ``l`` the axis of ``K_ref``'s
  rotoreflection (its eigenvector of eigenvalue -1: the normal of its mirror
  plane), and the one whose remaining swing ``S`` is smaller kept. Reversing a
  bone that lies in the reference's mirror plane by that half turn gives
  ``K_j = -I``, the reversed-axes mirror; the shortest swing alone would leave
  the half turn's axis undetermined;
* no child (an end effector): ``C_j = C_par``.

Where a joint and its parent share their mirror relation (``K_j = K_par``),
``L*_j = K^-1 L_p K`` turns by the same angle as the partner's rotation: the
mirror moves no rotation about into another joint.

Joints whose offset is animated (translations that change during the take,
such as a game rig's hips under a fixed root) are placed by their mirrored
translation and do not define their parent's correction. The root's
reference is the identity and its lateral axis the mirror axis.

The construction is symmetric: the partner gets ``C_p = M C_j^-1 M``, so the
mirror of the mirror is the take itself (rotations and positions), and a
joint without a partner gets an improper involution ``K_j``.

On the Bandai Namco rig this gives ``K = -I`` on every limb joint and the
chest's plane reflection on the spine, neck and head: the relations its takes
show. In near-symmetric poses (the bows) ``L_p^-1 K_par L_j`` lies within the
poses' own asymmetry of them, and about half a turn from the ``K = M`` of the
plain mirror.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from . import rotations as R
from .motion import MIRROR_MISMATCH_MAX, Motion, Skeleton, lateral_axis, mirror_mismatch, mirror_pairs

__all__ = ["mirror_corrections", "mirror_keeping_skeleton", "mirror_for_rig"]

_STATIC = 1e-4  # a translation moving less than this fraction of the skeleton's longest offset is a bone
_COLLINEAR = 0.05  # second singular value of a joint's unit child directions, over the first: one direction below


def mirror_corrections(skeleton: Skeleton, axis: int | None = None, bones: np.ndarray | None = None) -> np.ndarray:
    """Rest corrections ``C_j`` (J, 4) (w first) of :func:`mirror_keeping_skeleton` (module docstring).

    ``axis`` is the lateral axis (default :func:`~mocapkit.motion.lateral_axis`);
    ``bones`` (J,) bool says which joints' offsets are bones that define their
    parent's correction (default: every joint; joints with animated offsets
    are left out by :func:`mirror_keeping_skeleton`). End sites at a non-zero
    offset count as children too.
    """
    sk = skeleton
    J = sk.num_joints
    perm = mirror_pairs(sk.joint_names)
    if axis is None:
        axis = lateral_axis(sk)
    M = np.eye(3)
    M[axis, axis] = -1.0
    bones = np.ones(J, dtype=bool) if bones is None else np.asarray(bones, dtype=bool)
    mirrored = _mirrored_skeleton(sk, axis)
    scale = max(float(np.abs(sk.offsets).max(initial=0.0)), float(np.abs(sk.end_site_offsets).max(initial=0.0)), 1e-300)
    kids: list[list[tuple[np.ndarray, np.ndarray, int]]] = [[] for _ in range(J)]  # (o_c, o'_c, joint or -1)
    for c in range(1, J):
        if bones[c]:
            kids[sk.parents[c]].append((sk.offsets[c], mirrored.offsets[c], c))
    for e, p in enumerate(sk.end_site_parents.tolist()):
        kids[p].append((sk.end_site_offsets[e], mirrored.end_site_offsets[e], -1))
    tiny = 1e-9 * scale
    kids = [[k for k in ks if np.linalg.norm(k[0]) > tiny and np.linalg.norm(k[1]) > tiny] for ks in kids]
    C = np.empty((J, 3, 3))
    lat = np.empty((J, 3))  # each joint's lateral axis, the axis of K_j = M C_j
    bone = np.full(J, -1)  # a chain joint's bone: its longest child (a joint, or -1 for an end site)
    branch = np.zeros(J, dtype=bool)
    for j in range(J):
        if not kids[j]:
            continue
        u = np.array([k[0] for k in kids[j]])
        dirs = u / np.linalg.norm(u, axis=1, keepdims=True)
        s = np.linalg.svd(dirs, compute_uv=False)
        if len(s) > 1 and s[1] > _COLLINEAR * s[0]:  # children at two or more directions fix the rotation
            branch[j] = True
            C[j] = R.kabsch(u, np.array([k[1] for k in kids[j]]))
            lat[j] = _lateral(M @ C[j], np.eye(3)[axis])
        else:
            bone[j] = kids[j][int(np.argmax(np.linalg.norm(u, axis=1)))][2]
    for j in range(J):
        if branch[j]:
            continue
        par = int(sk.parents[j])
        below = _branch_below(j, bone, kids, branch)
        if below >= 0:  # the twist of the branching joint the chain leads to
            ref, ref_lat = C[below], lat[below]
        elif par >= 0:  # else the parent's
            ref, ref_lat = C[par], lat[par]
        else:
            ref, ref_lat = np.eye(3), np.eye(3)[axis]
        if not kids[j]:
            C[j] = ref
        else:
            u, v, _ = max(kids[j], key=lambda k: np.linalg.norm(k[0]))
            b, sw = ref, R.quaternion_to_matrix(R.shortest_arc(ref @ u, v))
            if _angle(sw) > np.pi / 2:  # the bone reverses by side: try the half turn about the lateral axis
                half = _half_turn(M @ ref_lat) @ ref
                sw_half = R.quaternion_to_matrix(R.shortest_arc(half @ u, v))
                if _angle(sw_half) < _angle(sw):
                    b, sw = half, sw_half
            C[j] = sw @ b
        lat[j] = _lateral(M @ C[j], ref_lat)
    return R.matrix_to_quaternion(C)


def mirror_keeping_skeleton(motion: Motion, axis: int | None = None) -> Motion:
    """The mirror image of ``motion`` on its own skeleton (module docstring).

    Global joint positions are the reflected, pair-swapped positions of the
    take (those of :meth:`~mocapkit.motion.Motion.mirror`) up to the
    difference between each bone's length and its partner's (exactly, for
    joints placed by animated translations); bone directions are exact. The
    name gains ``_mirror`` as with ``mirror()``.
    """
    sk = motion.skeleton
    if axis is None:
        axis = lateral_axis(sk)
    mm = motion.mirror(axis)
    bones = np.ones(sk.num_joints, dtype=bool)
    if motion.translations is not None and motion.num_frames:
        tr = motion.translations
        tol = _STATIC * max(float(np.abs(sk.offsets).max(initial=0.0)), 1e-300)
        with warnings.catch_warnings():  # a joint missing in every frame: NaN spread, not a bone
            warnings.simplefilter("ignore", RuntimeWarning)
            spread = np.nanmax(tr, axis=0) - np.nanmin(tr, axis=0)  # missing frames (NaN) left out
        bones = np.all(spread <= tol, axis=1)
        bones = bones & bones[mirror_pairs(sk.joint_names)]  # partners alike, so mirroring twice undoes itself
    cq = mirror_corrections(sk, axis, bones)
    par = sk.parents.copy()
    cpar = np.concatenate([R.identity((1,)), cq[par[1:]]])  # the root's parent correction: the identity
    rot = R.quaternion_multiply(R.quaternion_multiply(R.quaternion_conjugate(cpar)[None], mm.rotations), cq[None])
    tr = None
    if mm.translations is not None:
        tr = R.quaternion_rotate(R.quaternion_conjugate(cpar)[None], mm.translations)
        tr[:, 0] = mm.translations[:, 0]
    return dataclasses.replace(mm, skeleton=sk, rotations=rot, translations=tr)


def mirror_for_rig(motion: Motion, axis: int | None = None) -> Motion:
    """The mirror image whose rotations fit ``motion``'s own skeleton.

    :meth:`~mocapkit.motion.Motion.mirror` (unchanged, skeleton mirrored) on
    a rig that reflects onto itself (:func:`~mocapkit.motion.mirror_mismatch`
    at most :data:`~mocapkit.motion.MIRROR_MISMATCH_MAX`), where its rotations
    already fit the original skeleton; :func:`mirror_keeping_skeleton`
    otherwise. Mirrored databases and the label-swap check and injection use
    it.
    """
    if mirror_mismatch(motion.skeleton, axis) <= MIRROR_MISMATCH_MAX:
        return motion.mirror(axis)
    return mirror_keeping_skeleton(motion, axis)


def _branch_below(j: int, bone: np.ndarray, kids: list, branch: np.ndarray) -> int:
    """The first branching joint down the chain of single bones from joint ``j`` (-1 if it ends first)."""
    c = int(bone[j]) if kids[j] else -1
    while c >= 0 and not branch[c]:
        c = int(bone[c]) if kids[c] else -1
    return c


def _mirrored_skeleton(sk: Skeleton, axis: int) -> Skeleton:
    """The skeleton :meth:`Motion.mirror` gives ``sk`` (offsets ``M o_p``, end sites alike)."""
    one = Motion(sk, R.identity((1, sk.num_joints)), np.zeros((1, 3)), 30.0)
    return one.mirror(axis).skeleton


def _half_turn(axis: np.ndarray) -> np.ndarray:
    """The half turn (3, 3) about ``axis``: ``2 n n^T - I``."""
    n = axis / np.linalg.norm(axis)
    return 2.0 * np.outer(n, n) - np.eye(3)


def _angle(rot: np.ndarray) -> float:
    """Rotation angle of a (3, 3) rotation, radians in [0, pi]."""
    return float(np.arccos(np.clip((np.trace(rot) - 1.0) / 2.0, -1.0, 1.0)))


def _lateral(k: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """The axis of the improper ``k`` (3, 3) (its eigenvector of eigenvalue -1, the normal of the mirror plane
    it reflects across); ``fallback`` where that axis is not unique (``k`` near the point inversion ``-I``)."""
    _, s, vt = np.linalg.svd(k + np.eye(3))
    if s[1] < 0.5:  # -1 is a double or triple eigenvalue: no single axis
        return fallback
    n = vt[-1]
    return n if np.dot(n, fallback) >= 0 else -n
