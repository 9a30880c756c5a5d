"""Which Euler triple a writer puts in each rotation cell: the source file's own, or the nearest to it.

A rotation has many Euler triples (whole turns, two branches of the middle angle). Where the file a take came
from is known (:func:`mocapkit.io.bvh.write_bvh`'s and :func:`mocapkit.io.amc_writer.write_amc`'s ``like``: the
BVH or AMC read, or an .npz keeping its numbers, :mod:`mocapkit.io.kept_channels`) a cell whose rotation did not
change is the file's own numbers, and a changed cell whose rotation stays within :data:`NEAR_SOURCE_DEG` of the
file's is the triple nearest the file's numbers of that cell (:func:`mocapkit.rotations.nearest_euler`), so noise,
a denoised or a slightly corrected joint stays on the file's curve; the others follow their neighbours
(:func:`mocapkit.rotations.continuous_euler`).
"""

from __future__ import annotations

import numpy as np

from .. import rotations as R
from ..motion import channel_starts

__all__ = ["MEASURED_TOLERANCE_DEG", "NEAR_SOURCE_DEG", "OFF_AXIS_DEG", "bridged", "bvh_held_rotations", "bvh_written",
           "continuous_rotations", "measured_text", "off_axis_note", "partly_missing", "partial_rotation_joints",
           "source_branches", "three_axis_groups", "written_layout", "written_partial_joints"]

#: Degrees: a changed cell whose rotation stays this close to the source file's is written on the branch nearest the
#: file's numbers of that cell; one turned further (a flip repaired) follows its neighbours (continuous_euler's max_step).
NEAR_SOURCE_DEG = 90.0

#: Degrees: in a cell the file leaves partly missing (a ``nan`` channel), a measured channel whose value to write is
#: this close to the file's number keeps the file's text (the fill put it back: mocapkit.cleaning.measured; what is
#: left is the rounding of taking the rotation apart again).
MEASURED_TOLERANCE_DEG = 1e-9


def continuous_rotations(values: np.ndarray, channels, source=None) -> None:
    """Rewrite, in place, the rotation channels of ``values`` (F, C; columns in ``channels``' order, degrees) as
    the Euler triples a writer puts in the file.

    Without ``source`` each joint starts as the plain conversion gives it and every next frame takes the triple
    nearest the one before (:func:`mocapkit.rotations.continuous_euler`). With ``source`` (``turned`` (F, J) bool:
    cells whose rotation is not the file's; ``values`` (F, C): the file's numbers) an unchanged cell is the file's
    own numbers; a changed cell within :data:`NEAR_SOURCE_DEG` of the file's rotation the triple nearest the file's
    numbers of that cell; any other changed cell the triple nearest its nearest written neighbour, chained (a joint
    with no such neighbour starts from the file's first frame). One call per rotation order, all joints with that
    order together."""
    starts = channel_starts(channels)
    groups: dict[str, tuple[list[int], list[list[int]]]] = {}
    for j, chans in enumerate(channels):
        rot = [k for k, c in enumerate(chans) if c.endswith("rotation")]
        if rot:
            js, cols = groups.setdefault("".join(chans[k][0] for k in rot), ([], []))
            js.append(j)
            cols.append([int(starts[j]) + k for k in rot])
    for order, (js, cols) in groups.items():
        idx = np.array(cols)  # (K, n)
        angles = values[:, idx]
        fixed = start = None
        if source is not None:
            own = source.values[:, idx]
            # a changed cell's nan channel beside measured ones: placed nearest the bridged curve (an unchanged
            # cell is the file's own numbers, its nan kept: a missing value is never written as a measured one)
            part = partly_missing(own) & source.turned[:, js]
            if part.any():
                own = np.where(part[..., None], bridged(own), own)
            angles, fixed = source_branches(angles, own, source.turned[:, js], order)
            start = source.values[0, idx]
        values[:, idx] = R.continuous_euler(angles, order, fixed=fixed, start=start)


def partly_missing(own: np.ndarray) -> np.ndarray:
    """(...) bool: the cells of ``own`` (..., n; a joint's rotation channels as the file gives them, NaN for
    ``nan``) with some channels missing and some measured."""
    nan = np.isnan(own)
    return nan.any(axis=-1) & ~nan.all(axis=-1)


def bridged(own: np.ndarray) -> np.ndarray:
    """``own`` (F, ...) with each column's NaN replaced by the straight line between its measured frames (held
    flat past the first or last): the curve a missing channel's new value is placed nearest (whole turns, Euler
    branch). A column with no measured value stays NaN."""
    out = np.array(own, dtype=np.float64)
    flat = out.reshape(out.shape[0], -1)
    t = np.arange(flat.shape[0])
    for k in range(flat.shape[1]):
        ok = np.isfinite(flat[:, k])
        if ok.any() and not ok.all():
            flat[~ok, k] = np.interp(t[~ok], t[ok], flat[ok, k])
    return flat.reshape(out.shape)


def measured_text(values: np.ndarray, channels, own: np.ndarray, kind_of=None, tolerance=None) -> np.ndarray:
    """(F, C) bool: the channels a writer keeps the file's text of in a changed cell: those the file measures
    (``own`` (F, C), the file's numbers, finite) among a joint's rotation (or position) channels it leaves partly
    missing (:func:`partly_missing`), whose value to write (``values`` (F, C), degrees or file units) is the
    file's within ``tolerance`` of the channel's kind: the fill filled the missing channel and put the measured
    ones back (:func:`mocapkit.cleaning.measured.keep_measured`).

    ``channels``: per joint its channel names, in ``values``' column order. ``kind_of(name)``: a channel's kind,
    "" for one kept by no rule (default: a BVH channel's, ``"rotation"`` or ``"position"``); ``tolerance``: per
    kind (default :data:`MEASURED_TOLERANCE_DEG` for both; an AMC in radians passes its own, and 0 for its
    translations, which the fill puts back exactly)."""
    if kind_of is None:
        kind_of = _bvh_kind
    if tolerance is None:
        tolerance = {"rotation": MEASURED_TOLERANCE_DEG, "position": MEASURED_TOLERANCE_DEG}
    keep = np.zeros(values.shape, dtype=bool)
    starts = channel_starts(channels)
    for j, chans in enumerate(channels):
        kinds = [kind_of(c) for c in chans]
        for kind, tol in tolerance.items():
            cols = [starts[j] + k for k, c in enumerate(kinds) if c == kind]
            if len(cols) < 2:
                continue
            part = partly_missing(own[:, cols])
            if part.any():
                close = np.abs(values[:, cols] - own[:, cols]) <= tol  # False where own is NaN
                keep[:, cols] = part[:, None] & close
    return keep


def _bvh_kind(channel: str) -> str:
    return "rotation" if channel.endswith("rotation") else "position" if channel.endswith("position") else ""


def source_branches(angles: np.ndarray, own: np.ndarray, turned: np.ndarray, order: str,
                    degrees: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The Euler angles a writer puts in the cells it can place by the source file alone, and which those are.

    ``angles`` (..., n): the take's rotations as the plain conversion gives them, in ``order`` (any case, 1 to 3
    axes); ``own`` (..., n): the file's numbers of the same cells; ``turned`` (...) bool: cells whose rotation is
    not the file's. Returns ``(angles, placed)``: an unchanged cell is the file's own numbers; a changed cell
    whose rotation stays within :data:`NEAR_SOURCE_DEG` of the file's is the triple nearest the file's numbers
    of that cell (:func:`mocapkit.rotations.nearest_euler`: noise, a denoised or slightly corrected joint stays
    on the file's curve); ``placed`` is True on both. The other cells (a repaired flip) are left for
    :func:`mocapkit.rotations.continuous_euler` to place next to their neighbours. Degrees, radians with
    ``degrees=False``."""
    fixed = ~np.asarray(turned, dtype=bool)
    angles = np.where(fixed[..., None], own, angles)
    near = ~fixed & _turned_less(angles, own, order, NEAR_SOURCE_DEG, degrees)
    angles = np.where(near[..., None], R.nearest_euler(angles, own, order, degrees=degrees), angles)
    return angles, fixed | near


def _turned_less(a: np.ndarray, b: np.ndarray, order: str, limit_deg: float, degrees: bool = True) -> np.ndarray:
    """(...) bool: where the Euler triples ``a`` and ``b`` (..., n; degrees, radians with ``degrees=False``, in
    ``order``) are both finite and their rotations lie within ``limit_deg`` degrees of each other."""
    ok = np.isfinite(a).all(axis=-1) & np.isfinite(b).all(axis=-1)
    qa = R.euler_to_quaternion(np.where(ok[..., None], a, 0.0), order, degrees=degrees)
    qb = R.euler_to_quaternion(np.where(ok[..., None], b, 0.0), order, degrees=degrees)
    return ok & (np.degrees(R.geodesic_angle(qa, qb)) < limit_deg)


def three_axis_groups(skeleton) -> list[tuple[str, np.ndarray]]:
    """``(order, columns (K, 3))`` per rotation order (``"ZXY"``, ...) of the joints of ``skeleton`` with three
    rotation channels, columns into the file's channel rows (:meth:`~mocapkit.skeleton.Skeleton.joint_channels`
    in joint order): the Euler triples a branch choice applies to (a joint with fewer axes has only whole turns,
    which unwrapping takes care of)."""
    groups: dict[str, list[list[int]]] = {}
    channels = [skeleton.joint_channels(j) for j in range(skeleton.num_joints)]
    starts = channel_starts(channels)
    for j, chans in enumerate(channels):
        rot = [k for k, c in enumerate(chans) if c.endswith("rotation")]
        if len(rot) == 3:
            groups.setdefault("".join(chans[k][0] for k in rot), []).append([int(starts[j]) + k for k in rot])
    return [(order, np.array(cols, dtype=np.int64)) for order, cols in groups.items()]


def partial_rotation_joints(skeleton) -> list[int]:
    """The joints of a BVH skeleton (``axes`` None) declaring one or two rotation channels (a hinge's
    ``CHANNELS 1 Xrotation``): a BVH written on that layout holds only the rotations about those axes."""
    if skeleton.axes is not None:
        return []
    return [j for j in range(skeleton.num_joints) if 0 < len(skeleton.rotation_order(j)) < 3]


def bvh_held_rotations(motion, joints=None) -> np.ndarray:
    """The local rotations (F, J, 4) a BVH written for ``motion`` reads back as: a joint declaring one or two
    rotation channels (:func:`partial_rotation_joints`) holds its rotation's angles about those axes and drops
    the rest (:meth:`mocapkit.motion.Motion.channel_values`, read back by ``from_channel_values``), as an AMC bone
    with fewer than three dofs does (:func:`mocapkit.io.asfamc.amc_held_rotations`): what a cleaning written as
    that BVH measures and records its changes with (:func:`mocapkit.cleaning.decisions.as_written`). Other joints
    and missing (NaN) cells are returned as given; ``joints``: only those of these are converted (as
    :func:`mocapkit.io.asfamc.amc_held_rotations`' ``joints``)."""
    rot = np.array(motion.rotations, dtype=np.float64)
    for j in partial_rotation_joints(motion.skeleton):
        if joints is not None and j not in joints:
            continue
        order = motion.skeleton.rotation_order(j)
        q = rot[:, j]
        seen = np.isfinite(q).all(axis=-1)
        if seen.any():
            q[seen] = R.euler_to_quaternion(R.quaternion_to_euler(q[seen], order), order)
    return rot


def bvh_written(original, motion, path, asf=None, like=None, layout=None):
    """``motion`` (an operation's output of ``original``, the same frames and joints) as the file at ``path`` holds
    it: each rotation of a joint the file keeps only some rotation axes of (:func:`written_partial_joints`: a BVH
    joint declaring one or two rotation channels, an AMC bone with fewer than three rotation dofs) that differs
    from ``original``'s put on those axes (:func:`bvh_held_rotations`; for an AMC
    :func:`mocapkit.io.asfamc.amc_held_rotations` on the layout written, :func:`mocapkit.io.amc_writer.file_dofs`
    of ``asf``/``like``), every other value as given (an unchanged cell bit for bit). What ``fill``, ``denoise``
    and ``repair`` write and report from, as ``clean`` does (:func:`mocapkit.cleaning.decisions.as_written`).
    ``motion`` itself for another output format or a skeleton without such joints. ``layout``: the
    :func:`written_layout` of ``motion``, ``path``, ``asf``, ``like`` where the caller has it (read once)."""
    import dataclasses

    joints, held_of = written_layout(motion, path, asf, like) if layout is None else layout
    if not joints:
        return motion
    rot = np.array(motion.rotations, dtype=np.float64)
    held = held_of(motion, joints)[:, joints]
    was = np.asarray(original.rotations, dtype=np.float64)
    if was.shape != rot.shape:  # another take: every cell of those joints is the file's
        rot[:, joints] = held
    else:
        a, b = rot[:, joints], was[:, joints]
        changed = np.any((a != b) & ~(np.isnan(a) & np.isnan(b)), axis=-1)
        rot[:, joints] = np.where(changed[..., None], held, a)
    return dataclasses.replace(motion, rotations=rot)


def written_layout(motion, path, asf=None, like=None):
    """``(joints, held)``: how a file at ``path`` holds ``motion``'s rotations, the one place deciding it (for
    :func:`bvh_written`, :func:`off_axis_note` and ``clean``'s :func:`mocapkit.cleaning.decisions.as_written`).

    ``joints``: those it keeps only some rotation axes of, a BVH's joints declaring one or two rotation channels
    (:func:`partial_rotation_joints`) or an AMC's bones with fewer than three rotation dofs in the layout written
    (:func:`mocapkit.io.amc_writer.file_dofs` of ``asf``/``like``: the ASF's order). ``held(take, joints=None)``:
    the rotations (F, J, 4) such a file written from ``take`` reads back as (:func:`bvh_held_rotations`;
    :func:`mocapkit.io.asfamc.amc_held_rotations` on that layout, every bone through its Euler angles), only
    ``joints`` converted where given. ``held`` is None where a file holds every rotation as given: an .npz (it
    keeps the quaternions), a BVH without such joints; an AMC always has one (a take without an ASF skeleton:
    ``([], None)``, which the AMC writer refuses)."""
    from pathlib import Path

    kind = Path(path).suffix.lower()
    if kind == ".bvh":
        joints = partial_rotation_joints(motion.skeleton)
        return joints, (bvh_held_rotations if joints else None)
    if kind != ".amc" or motion.skeleton.axes is None:
        return [], None
    from .amc_writer import file_dofs  # lazy: amc_writer imports this module
    from .asfamc import amc_held_rotations

    dofs = file_dofs(motion, asf, like)
    joints = [j for j, d in enumerate(dofs) if 0 < sum(x[0] == "r" for x in d) < 3]
    return joints, (lambda take, only=None: amc_held_rotations(take, dofs, only))


def written_partial_joints(motion, path, asf=None, like=None) -> list[int]:
    """The joints of ``motion`` a file at ``path`` keeps only some rotation axes of: a BVH's one- or two-channel
    joints (:func:`partial_rotation_joints`), an AMC's bones with fewer than three rotation dofs (in the layout
    :func:`mocapkit.io.amc_writer.file_dofs` gives for ``asf``/``like``); [] for another format."""
    return written_layout(motion, path, asf, like)[0]


#: Degrees: a rotation of a one- or two-channel joint further than this from its channels' axes loses that part in
#: a BVH (:func:`off_axis_note`); rounding of the Euler round trip is far below it.
OFF_AXIS_DEG = 1e-6


def off_axis_note(motion, path, asf=None, like=None) -> str | None:
    """The line saying how many rotations of ``motion`` a BVH or AMC at ``path`` cannot hold and by how much at most:
    those of joints the file keeps only some rotation axes of (:func:`written_partial_joints`: a BVH joint declaring
    one or two rotation channels, an AMC bone with fewer than three rotation dofs, ``asf``/``like`` giving its
    layout) that turn about another axis by more than :data:`OFF_AXIS_DEG` (the file keeps the angles about those
    axes: :func:`bvh_held_rotations`, :func:`mocapkit.io.asfamc.amc_held_rotations`). None for another format or
    where there are none (a take read from such a file and changed only by putting the changed cells on the axes:
    :func:`bvh_written`)."""
    from pathlib import Path

    joints, held_of = written_layout(motion, path, asf, like)
    if not joints:
        return None
    a = np.asarray(motion.rotations, dtype=np.float64)[:, joints]
    b = held_of(motion, joints)[:, joints]  # only those bones through the Euler round trip
    chord = np.linalg.norm(a - np.where(np.sum(a * b, axis=-1, keepdims=True) < 0, -b, b), axis=-1)
    with np.errstate(invalid="ignore"):
        off = np.degrees(4.0 * np.arcsin(np.clip(chord / 2.0, 0.0, 1.0)))
    lost = off > OFF_AXIS_DEG  # NaN (missing): not counted
    n = int(lost.sum())
    if not n:
        return None
    names = [motion.skeleton.joint_names[joints[k]] for k in np.flatnonzero(lost.any(axis=0))]
    bvh = Path(path).suffix.lower() == ".bvh"
    return (f"{path}: {n:,} rotation{'s' if n > 1 else ''} of {', '.join(names[:4])}{' ...' if len(names) > 4 else ''}"
            f" ({'one or two rotation channels' if bvh else 'fewer than three rotation dofs'}) turn about other axes"
            f" too, up to {float(off[lost].max()):.2g} deg: the {'BVH' if bvh else 'AMC'} holds only the angles about"
            f" the {'declared axes' if bvh else 'ASF dofs'}, that part is not written")
