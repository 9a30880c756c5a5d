"""What every reconstruction method needs from a MotionDatabase: per-frame values computed clip by clip, and the body below the pelvis.

Rigs differ above the pelvis: on Acclaim and most BVH rigs the pelvis is the
root, on the Bandai Namco game rig the root ``joint_Root`` stays on the floor
and ``Hips`` carries the translation. Reconstruction works on the *body*: the
pelvis (found by its role, :func:`mocapkit.rigs.pelvis_index`) and the joints
below it, re-rooted so the pelvis is joint 0 (:func:`body_motion`), and puts
the joints above it back on output (:func:`whole_motion`) as the takes hold
them (:func:`held_above`): the Bandai Namco root at the origin, the pelvis's
position channels carrying the whole translation.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .. import rotations as R
from ..database import MotionDatabase
from ..features import find_up_axis, virtual_markers
from ..motion import Motion, Skeleton, unit_scale_cm
from ..rigs import pelvis_index


def per_clip(db: MotionDatabase, fn: Callable[[Motion], np.ndarray]) -> np.ndarray:
    """``fn`` applied to every clip of ``db`` (float64 Motions), stacked along frames: (N, ...).

    For values that need a whole clip (derivatives, root frames) and must not
    run across clip boundaries.
    """
    parts = [np.asarray(fn(db.clip(c))) for c in range(db.num_clips)]
    out = np.concatenate(parts, axis=0)
    if out.shape[0] != db.num_frames:
        raise ValueError(f"fn returned {out.shape[0]} frames for a database of {db.num_frames}")
    return out


def database_positions(db: MotionDatabase, names) -> np.ndarray:
    """Global positions (N, M, 3) of joints or end sites ``names`` in every database frame, file units."""
    names = list(names)
    return per_clip(db, lambda m: virtual_markers(m, names))


def database_up(db: MotionDatabase, clips: int = 16) -> np.ndarray:
    """The vertical axis (3,) of ``db``'s motion, not of its rest pose (a game rig's T-pose may lie along another axis): :func:`~mocapkit.features.find_up_axis` over the frames of up to ``clips`` clips spread over it."""
    picks = np.unique(np.linspace(0, db.num_clips - 1, min(clips, db.num_clips)).round().astype(int))
    pos = np.concatenate([db.clip(int(c)).global_positions() for c in picks], axis=0)
    return find_up_axis(db.skeletons[0], pos)


def output_skeleton(db: MotionDatabase, skeleton: Skeleton | None) -> Skeleton:
    """The skeleton a reconstruction is written on: ``skeleton`` (the performer's, same topology) or the database's first."""
    if skeleton is None:
        return db.skeletons[0]
    if not skeleton.is_compatible(db.skeletons[0]):
        raise ValueError(
            "the skeleton has a different joint layout from the database's; "
            "retarget it to the database skeleton first"
        )
    return skeleton


def in_database_units(db: MotionDatabase, skeleton: Skeleton) -> tuple[Skeleton, float]:
    """``skeleton`` in the database's length unit, and the factor that takes a result back to its own.

    Marker positions and the database's poses are in the database skeleton's
    unit (:func:`~mocapkit.motion.unit_scale_cm`); a performer's skeleton read
    from a file in metres or millimetres is not. The fit runs on the returned
    skeleton (offsets scaled, ``unit_cm`` the database's), and
    :func:`in_units_of` writes the result on ``skeleton`` again. ``skeleton``
    itself and 1.0 when the units agree.

    Returns
    -------
    Skeleton, float
        The scaled skeleton, and ``skeleton``'s units per database unit.
    """
    db_cm = unit_scale_cm(db.skeletons[0])
    own_cm = unit_scale_cm(skeleton)
    if abs(own_cm - db_cm) <= 1e-9 * db_cm:
        return skeleton, 1.0
    s = own_cm / db_cm
    import dataclasses

    scaled = dataclasses.replace(skeleton, offsets=skeleton.offsets * s, end_site_offsets=skeleton.end_site_offsets * s, unit_cm=db_cm)
    return scaled, 1.0 / s


def in_units_of(m: Motion, skeleton: Skeleton, factor: float) -> Motion:
    """``m`` (on :func:`in_database_units`' scaled skeleton) written on ``skeleton``: positions times ``factor``."""
    if factor == 1.0 and m.skeleton is skeleton:
        return m
    tr = None if m.translations is None else np.asarray(m.translations) * factor
    return Motion(skeleton, m.rotations, np.asarray(m.root_positions) * factor, m.fps, m.name, tr)


def align_about_vertical(source: np.ndarray, target: np.ndarray, up: np.ndarray, weights=None) -> tuple[np.ndarray, np.ndarray]:
    """Optimal rotation about ``up`` and ground translation mapping ``source`` points onto ``target`` (Tautges eq. 4.3).

    Minimises ``sum_i w_i |rotate(yaw(theta), a_i) + t - b_i|^2`` over the
    angle ``theta`` and a translation ``t`` orthogonal to ``up``, in closed
    form (a weighted 2-D Procrustes fit without scaling, Kovar et al.'s
    point-cloud alignment): with the points' ground-plane parts centred on
    their weighted means, ``theta = atan2(sum w up . (a_i x b_i), sum w a_i . b_i)``
    and ``t = mean(b) - rotate(yaw(theta), mean(a))`` projected onto the ground.

    Parameters
    ----------
    source : float array (..., M, 3)
        Points ``a_i``, any leading dimensions (one alignment per leading index).
    target : float array (M, 3) or (..., M, 3)
        Points ``b_i``, broadcast against ``source``.
    up : float array (3,)
        Unit vertical axis.
    weights : float array (M,) or (..., M), optional
        ``w_i >= 0``, broadcast like the points; 1 when None. An all-zero row
        gives the identity.

    Returns
    -------
    theta : float array (...)
        Angle in radians about ``up`` (right-handed).
    translation : float array (..., 3)
        Ground-plane translation (no component along ``up``).

    >>> up = np.array([0.0, 1.0, 0.0])
    >>> a = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 2.0], [-1.0, 0.5, 0.0]])
    >>> q = R.quaternion_from_axis_angle(up, 0.3)
    >>> theta, t = align_about_vertical(a, R.quaternion_rotate(q, a) + [5.0, 0.0, -2.0], up)
    >>> round(float(theta), 12), np.round(t, 12).tolist()
    (0.3, [5.0, 0.0, -2.0])
    """
    a = np.asarray(source, dtype=np.float64)
    b = np.asarray(target, dtype=np.float64)
    up = np.asarray(up, dtype=np.float64)
    ha = a - (a @ up)[..., None] * up
    hb = b - (b @ up)[..., None] * up
    if weights is None:
        w = np.ones(np.broadcast_shapes(ha.shape, hb.shape)[:-1])
    else:
        w = np.broadcast_to(np.asarray(weights, dtype=np.float64), np.broadcast_shapes(ha.shape, hb.shape)[:-1])
    W = w.sum(axis=-1)
    safe = np.where(W > 0, W, 1.0)
    ma = np.sum(w[..., None] * ha, axis=-2) / safe[..., None]
    mb = np.sum(w[..., None] * hb, axis=-2) / safe[..., None]
    ca, cb = ha - ma[..., None, :], hb - mb[..., None, :]
    sin = np.sum(w * (np.cross(ca, cb) @ up), axis=-1)
    cos = np.sum(w * np.sum(ca * cb, axis=-1), axis=-1)
    theta = np.where(W > 0, np.arctan2(sin, cos), 0.0)
    t = mb - R.quaternion_rotate(R.quaternion_from_axis_angle(up, theta), ma)
    t = t - (t @ up)[..., None] * up
    return theta, np.where((W > 0)[..., None], t, 0.0)



def body_joints(skeleton: Skeleton) -> np.ndarray:
    """Indices (B,) of the pelvis (:func:`mocapkit.rigs.pelvis_index`) and every joint below it, in skeleton order, pelvis first."""
    p = pelvis_index(skeleton)
    inside = np.zeros(skeleton.num_joints, dtype=bool)
    inside[p] = True
    for j in range(p + 1, skeleton.num_joints):
        inside[j] = inside[skeleton.parents[j]]
    return np.flatnonzero(inside)


def body_skeleton(skeleton: Skeleton) -> Skeleton:
    """The pelvis's subtree of ``skeleton`` as a skeleton rooted at the pelvis (``skeleton`` itself when the pelvis is the root).

    Offsets, end sites, channels, ASF axes and limits are those of the kept
    joints; the new root's offset is zero and it gets position channels if it
    had none.
    """
    idx = body_joints(skeleton)
    if idx[0] == 0:
        return skeleton
    new = np.full(skeleton.num_joints, -1, dtype=np.int64)
    new[idx] = np.arange(idx.size)
    parents = np.array([-1] + [new[skeleton.parents[j]] for j in idx[1:]], dtype=np.int64)
    offsets = np.array(skeleton.offsets[idx], dtype=np.float64)
    offsets[0] = 0.0
    keep_es = np.flatnonzero(new[skeleton.end_site_parents] >= 0) if skeleton.num_end_sites else np.zeros(0, dtype=np.int64)
    channels = None
    if skeleton.channels is not None:
        channels = [skeleton.channels[j] for j in idx]
        if not any(c.endswith("position") for c in channels[0]):
            channels[0] = ("Xposition", "Yposition", "Zposition", *channels[0])
    return Skeleton(
        tuple(skeleton.joint_names[j] for j in idx), parents, offsets,
        new[skeleton.end_site_parents[keep_es]], skeleton.end_site_offsets[keep_es], channels,
        None if skeleton.axes is None else skeleton.axes[idx],
        None if skeleton.limits is None else tuple(skeleton.limits[j] for j in idx),
        skeleton.unit_cm,
    )


def body_motion(m: Motion) -> Motion:
    """``m`` on :func:`body_skeleton`: the pelvis's global rotation and position become the root's (``m`` itself when the pelvis is the root).

    Every body joint keeps its global transform, so joint positions agree with
    ``m``'s exactly; animated translations of the kept joints are kept.
    """
    sk = m.skeleton
    idx = body_joints(sk)
    if idx[0] == 0:
        return m
    grot, gpos = m.global_transforms()
    rot = np.array(m.rotations[:, idx])
    rot[:, 0] = grot[:, idx[0]]
    tr = None
    if m.translations is not None:
        tr = np.array(m.translations[:, idx])
        tr[:, 0] = 0.0
    return Motion(body_skeleton(sk), rot, gpos[:, idx[0]], m.fps, m.name, tr)


def _cm_per_unit(skeleton: Skeleton) -> float:
    """Centimetres per length unit of ``skeleton`` (:func:`~mocapkit.motion.unit_scale_cm`), 1 where it cannot be told."""
    from ..errors import SkeletonError

    try:
        return unit_scale_cm(skeleton)
    except SkeletonError:
        return 1.0


def held_above(take) -> Motion | None:
    """The pose of the joints above the pelvis where ``take`` holds them still, else None.

    ``take``: a Motion or a :class:`~mocapkit.database.MotionDatabase` (every frame of its takes). A game rig's
    root above the pelvis either stays put (the Bandai Namco ``joint_Root`` at the origin in every frame, the
    pelvis's position channels carrying the translation: an in-place root) or follows the body (root motion).
    Returned for the first: a one-frame Motion on ``take``'s skeleton whose joints above the pelvis (the root's
    position, their rotations and animated offsets) are theirs in every finite frame, within 1e-3 cm and about
    2e-4 rad. None when the pelvis is the root, when they move, or when no frame is finite.
    """
    sk = take.skeletons[0] if hasattr(take, "skeletons") else take.skeleton
    inside = np.zeros(sk.num_joints, dtype=bool)
    inside[body_joints(sk)] = True
    above = np.flatnonzero(~inside)
    if inside[0]:
        return None
    rot = np.asarray(take.rotations[:, above], dtype=np.float64)
    root = np.asarray(take.root_positions, dtype=np.float64)
    tr = getattr(take, "translations", None)
    tr = None if tr is None else np.asarray(tr, dtype=np.float64)
    ok = np.isfinite(rot).all(axis=(1, 2)) & np.isfinite(root).all(axis=1)
    if tr is not None:
        ok &= np.isfinite(tr[:, above]).all(axis=(1, 2))
    if not ok.any():
        return None
    f = int(np.argmax(ok))
    cm = _cm_per_unit(sk)
    turned = 1.0 - np.abs(np.sum(rot[ok] * rot[f], axis=-1))  # 1 - cos(angle / 2), q and -q alike
    moved = [np.abs(root[ok] - root[f]).max() * cm]
    if tr is not None:
        moved.append(np.abs(tr[ok][:, above] - tr[f, above]).max() * cm)
    if turned.max() > 5e-9 or max(moved) > 1e-3:
        return None
    one = np.asarray(take.rotations[f:f + 1], dtype=np.float64)
    return Motion(sk, one / np.linalg.norm(one, axis=-1, keepdims=True), root[f:f + 1], take.fps, "held above the pelvis",
                  None if tr is None else tr[f:f + 1])


def whole_motion(body: Motion, skeleton: Skeleton, up: np.ndarray, held: Motion | None = None) -> Motion:
    """The inverse of :func:`body_motion`: ``body`` (on ``body_skeleton(skeleton)``) back on ``skeleton``.

    Every body joint keeps its global transform. When the pelvis has position channels and ``held`` is given
    (a Motion on ``skeleton``'s joints of one frame, :func:`held_above`: the takes hold the joints above the
    pelvis still; or of ``body``'s frames: the input take's own), the joints above the pelvis are written as
    ``held`` has them (the Bandai Namco ``joint_Root`` at the origin) and the pelvis's rotation and position
    channels carry its whole global transform, relative to its parent there. Otherwise the joints above the
    pelvis keep their rest rotations (identity); when the pelvis has position channels (a root that follows the
    body) the root is put on the ground plane (orthogonal to the unit ``up``) under the pelvis and the pelvis's
    translation lifts it, else the root sits where the pelvis's rest offset puts the pelvis in place.
    ``held``'s positions are converted from its skeleton's unit to ``skeleton``'s.
    """
    idx = body_joints(skeleton)
    if idx[0] == 0:
        return body if body.skeleton is skeleton else Motion(skeleton, body.rotations, body.root_positions, body.fps, body.name, body.translations)
    F, J, p = body.num_frames, skeleton.num_joints, int(idx[0])
    rot = np.zeros((F, J, 4))
    rot[..., 0] = 1.0
    rot[:, idx] = body.rotations
    rest = skeleton.rest_positions()
    pelvis = np.asarray(body.root_positions, dtype=np.float64)
    moves = skeleton.channels is not None and any(c.endswith("position") for c in skeleton.channels[p])
    tr = None
    if moves or body.translations is not None:
        tr = np.broadcast_to(skeleton.offsets, (F, J, 3)).copy()
        if body.translations is not None:
            tr[:, idx[1:]] = body.translations[:, 1:]
    if moves and held is not None:
        above = np.setdiff1d(np.arange(J), idx)
        s = _cm_per_unit(held.skeleton) / _cm_per_unit(skeleton)  # held's unit -> skeleton's
        n = held.num_frames  # 1 (held still) or F
        rot[:, above] = held.rotations[:, above]
        if held.translations is not None:
            tr[:, above] = held.translations[:, above] * s
        root = np.broadcast_to(held.root_positions * s, (F, 3))
        grot, gpos = Motion(skeleton, rot[:n], root[:n], body.fps, translations=tr[:n]).global_transforms()
        inv = R.quaternion_conjugate(grot[:, skeleton.parents[p]])
        rot[:, p] = R.quaternion_multiply(inv, body.rotations[:, 0])
        tr[:, p] = R.quaternion_rotate(inv, pelvis - gpos[:, skeleton.parents[p]])
    elif moves:
        root = pelvis - (pelvis @ up)[:, None] * up
        tr[:, p] = pelvis - root - (rest[skeleton.parents[p]] - rest[0])
    else:
        root = pelvis - (rest[p] - rest[0])
    return Motion(skeleton, rot, root, body.fps, body.name, tr)


def database_bodies(db: MotionDatabase) -> tuple[np.ndarray, np.ndarray]:
    """Every database frame's *body* (:func:`._common.body_motion`), what a played-back subsequence is made of.

    On Acclaim and most BVH rigs the pelvis is the root and these are the
    database's own arrays. On the Bandai Namco game rig the root
    ``joint_Root`` stays on the floor and ``Hips`` carries the translation:
    the body is rooted at ``Hips``, so aligning and cross-fading it moves the
    pelvis itself, not the floor-bound root. As in :mod:`mocapkit.reconstruct.markers`, the bone
    lengths are the output skeleton's (no animated offsets are played).

    Returns
    -------
    rotations : float array (N, B, 4)
        Local rotations of the body joints, the pelvis's global.
    pelvis : float array (N, 3)
        The pelvis's global position, file units.
    """
    sk = db.skeletons[0]
    if body_skeleton(sk) is sk:
        return db.rotations, db.root_positions

    def packed(m: Motion) -> np.ndarray:
        b = body_motion(m)
        return np.concatenate([b.rotations.reshape(b.num_frames, -1), b.root_positions], axis=1)

    flat = per_clip(db, packed)
    return flat[:, :-3].reshape(flat.shape[0], -1, 4), flat[:, -3:]


def onto_pelvis_marker(pelvis: np.ndarray, markers: np.ndarray, joints: list[str], skeleton: Skeleton) -> np.ndarray:
    """The played-back pelvis positions (F, 3) moved onto the pelvis's own marker where it is seen.

    The alignment of eq. 4.3 places each subsequence as a whole, so its pelvis
    lies where the database actor's would (his height, his stride) and jumps
    by the difference at every change of subsequence. A marker on the pelvis
    (found by its role, :func:`mocapkit.rigs.pelvis_index`, as
    :mod:`mocapkit.reconstruct.markers` pins its root) says where it is: the offset ``marker -
    pelvis`` (F, 3) is taken where the marker is seen, linearly interpolated
    over its gaps and held before its first and after its last sighting, and
    added. Without such a marker, or when it is never seen, ``pelvis`` is
    returned as it is. ``markers`` (F, M, 3) NaN where unseen, file units.
    """
    name = skeleton.joint_names[pelvis_index(skeleton)]
    cols = [m for m, j in enumerate(joints) if j == name]
    if not cols:
        return pelvis
    x = markers[:, cols[0]]
    seen = np.isfinite(x).all(axis=1)
    if not seen.any():
        return pelvis
    t = np.arange(len(pelvis))
    d = x[seen] - pelvis[seen]
    return pelvis + np.stack([np.interp(t, t[seen], d[:, c]) for c in range(3)], axis=1)


def onto_marker_heights(pelvis: np.ndarray, rotations: np.ndarray, markers: np.ndarray, joints: list[str],
                        skeleton: Skeleton, fps: float, up: np.ndarray) -> np.ndarray:
    """The played-back pelvis positions (F, 3) lifted or lowered so that the body's markers meet the given ones'
    heights, where no pelvis marker is seen (:func:`onto_pelvis_marker` places the pelvis then).

    The alignment of eq. 4.3 turns a subsequence about the vertical and moves it on the ground: its height is the
    database actor's. Where the database lacks the performer's motion the graph can play motion at another height
    (a standing T-pose played as hop apexes: the body 30 cm above the floor for seconds). Per frame, the median
    over the seen markers of ``(marker - body's marker) . up`` says how far; it is interpolated over frames with
    no marker (held at the ends), smoothed with a Gaussian of 0.25 s (the played motion's own vertical motion
    is kept, a per-frame median's jitter is not) and added along ``up``. ``rotations`` (F, J_body, 4) and
    ``pelvis`` are the body's (:func:`body_skeleton` of ``skeleton``, the performer's in the markers' units);
    ``markers`` (F, M, 3) NaN where unseen, on ``joints``; markers on joints outside the body are not used.
    """
    from scipy.ndimage import gaussian_filter1d

    name = skeleton.joint_names[pelvis_index(skeleton)]
    if any(j == name and np.isfinite(markers[:, m]).all(axis=-1).any() for m, j in enumerate(joints)):
        return pelvis
    body = body_skeleton(skeleton)
    known = set(body.joint_names) | set(body.end_site_names)
    cols = [m for m, j in enumerate(joints) if j in known]
    if not cols:
        return pelvis
    played = virtual_markers(Motion(body, rotations, pelvis, fps), [joints[m] for m in cols])
    d = (markers[:, cols] - played) @ up  # (F, M') NaN where unseen
    seen = np.isfinite(d).any(axis=1)
    if not seen.any():
        return pelvis
    off = np.nanmedian(np.where(seen[:, None], d, 0.0), axis=1)
    t = np.arange(len(pelvis))
    off = gaussian_filter1d(np.interp(t, t[seen], off[seen]), 0.25 * fps, mode="nearest")
    return pelvis + off[:, None] * up
