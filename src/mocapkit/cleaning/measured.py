"""The channels a BVH (dofs an AMC) still measures in a cell it leaves partly missing, put back after the fill.

A joint's sample is its whole rotation (``Motion.rotations`` (F, J, 4)), so one NaN channel of a BVH cell (a
``Zrotation`` written as ``nan`` for ten frames) makes the joint missing in those frames. The networks' fill
reads the measured channels there (:func:`measured_rotations`) and estimates the missing ones conditioned on
them; the spline's makes up the whole rotation. The file's other rotation channels of those cells are measurements,
which a cleaning tool must not lose (nor the rotation of a joint missing by a position channel alone, nor
the measured axes of a position): :func:`keep_measured` keeps the file's measured angles and gives the missing
channel the angle whose rotation is nearest the filled one (on the whole turn nearest its own curve), so only the
missing channel takes the fill's value, and the rotation written is the fill's as nearly as the measured angles
allow (taking the filled rotation apart and keeping its angle instead left it tens of degrees off near gimbal
lock, as Z and Y trade off there). The BVH
and AMC writers then keep the measured channels' own text in those cells (:func:`mocapkit.io.bvh.write_bvh`,
:func:`mocapkit.io.amc_writer.write_amc`, with ``like``).

The repair step judges a joint's whole rotation too: where detection flags such a cell and the repair replaces
it, :func:`keep_measured_in_repair` keeps the measured channels as the file gives them and moves only the missing
ones, wherever they alone bring the rotation within :data:`REPAIR_TOLERANCE_DEG` of the repair's (the flag is then
explained by the made-up channel); a repair no missing channel can reach is evidence against the measured ones,
and stands whole, as for a cell the file measures whole. The denoise step alike
(:func:`keep_measured_in_denoise`): a filled cell inside a noisy joint's run is denoised with it, and its measured
channels moved with the noise around them. A root position the file gives partly ``nan`` (its ``Yposition``
written ``nan``, X and Z measured) keeps its measured axes through the fill; :func:`measured_axes` names them, so that
the teleport put-back (:func:`mocapkit.cleaning.take_breaks.fix_teleports`) moves such an axis only on evidence
against that axis itself.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np

from .. import rotations as R
from ..errors import MocapFormatError
from ..io.euler_branches import bridged, partly_missing
from ..io.sources import recall
from ..motion import Motion, channel_starts
from ..words import frame_span, listed, plural

__all__ = ["keep_measured", "keep_measured_in_repair", "keep_measured_in_denoise", "kept_note", "measured_axes",
           "filled_channels", "filled_channels_note", "measured_rotations", "MAX_NAMED_JOINTS",
           "REPAIR_TOLERANCE_DEG"]

#: Degrees: a repaired cell the file gives partly ``nan`` keeps its measured channels where its missing ones alone put
#: the rotation this close to the repair's: clean's default noise level (``--noise-deg``, NOISE_DEG), under which a
#: difference is the capture's noise, no evidence against a measured channel.
REPAIR_TOLERANCE_DEG = 1.0


def keep_measured(before: Motion, after: Motion) -> tuple[Motion, np.ndarray]:
    """``after`` (``before`` filled) with every number ``before`` measured in a cell it leaves missing put back.

    A joint is missing where any of its numbers is NaN (:meth:`Motion.missing`), and the fill makes up the whole
    cell; here ``after`` keeps of each filled cell only what ``before`` lacks: a rotation ``before`` has whole
    (the cell was missing by a position channel) is ``before``'s, bit for bit; a root position or animated
    offset axis ``before`` has (``root_positions`` (F, 3), ``translations`` (F, J, 3); file units) is
    ``before``'s; and where the BVH or AMC file ``before`` was read from (its ``source_file``, or an .npz keeping
    such a file's numbers, :mod:`mocapkit.io.kept_channels`) gives a joint's rotation channels partly ``nan``
    (:func:`~mocapkit.io.euler_branches.partly_missing`), the measured channels are the file's numbers and one
    missing channel the angle whose rotation (built as the BVH reader builds it, intrinsic, in the joint's channel
    order) is nearest the filled one, on the whole turn nearest its own curve bridged linearly over its gap
    (:func:`_filled_angles`; two missing, the pair whose rotation is nearest the filled one), so only the missing
    channels take the fill's value; an AMC bone line partly ``nan`` alike (its dofs the Euler angles of ``C^-1 q C``, ``C`` the bone's ASF
    axis frame, in the dofs' extrinsic order). Returns ``(motion, cells)``:
    ``cells`` (F, J) bool the cells changed from ``after``; ``after`` itself where none is.
    """
    rot = np.array(after.rotations)
    whole = np.isfinite(before.rotations).all(axis=-1)
    rot[whole] = before.rotations[whole]
    _partly_measured(before, after, rot, ~whole)
    root = np.where(np.isfinite(before.root_positions), before.root_positions, after.root_positions)
    trans = after.translations
    if trans is not None and before.translations is not None:
        trans = np.where(np.isfinite(before.translations), before.translations, trans)
    from .whole_take import differing  # whole_take fills with keep_measured: imported on use

    cells = differing(rot, after.rotations)
    cells[:, 0] |= differing(root, after.root_positions)
    if trans is not None:
        cells |= differing(trans, after.translations)
    if not cells.any():
        return after, cells
    return dataclasses.replace(after, rotations=rot, root_positions=root, translations=trans), cells


def keep_measured_in_repair(before: Motion, after: Motion, cells: np.ndarray,
                            tolerance_deg: float = REPAIR_TOLERANCE_DEG) -> tuple[Motion, np.ndarray]:
    """``after`` (``before`` repaired: the repair step's medoid words) with the cells ``cells`` (F, J) bool (those the
    repair changed) that ``before``'s BVH or AMC file gives partly ``nan`` (a filled cell: :func:`keep_measured`)
    put back on the file's measured channels, where that costs the repair little.

    Detection flags a joint's whole rotation, and the repair replaces it, measured channels and all: a filled cell
    flagged and repaired came back with its measured channels moved (cmu_01_01_start's LeftUpLeg, Z nan, repaired
    by 0.19-0.60 deg: its measured Y and X moved up to 0.18 deg), numbers the file measured changed on no evidence
    against them. Here each such cell is rebuilt as the fill's is
    (:func:`_filled_angles`): the measured angles the file's, the missing ones those whose rotation is nearest the
    repair's. Where that rotation is within ``tolerance_deg`` (degrees; :data:`REPAIR_TOLERANCE_DEG`) of the
    repair's it is taken: the flag is explained by the made-up channel, which alone changes. Where it is further,
    the measured channels themselves disagree with the repair (a spike in them: CMU 01_01's LeftToeBase at frame
    844 with its Z nan, 11 deg away) and the repair stands whole, as in a cell the file measures whole. Returns ``(motion,
    kept, stood)``: ``kept`` (F, J) bool the cells put back on their measured channels (``after`` itself where none
    is); ``stood`` (F, J) bool the filled cells whose repair stands whole, its measured channels changed with it
    (:func:`kept_note` says both)."""
    kept = np.zeros(np.shape(cells), dtype=bool)
    rot = np.array(after.rotations)
    _partly_measured(before, after, rot, np.asarray(cells, dtype=bool))
    from .whole_take import differing  # whole_take repairs with keep_measured_in_repair: imported on use

    moved = differing(rot, after.rotations)
    if moved.any():
        off = np.degrees(R.geodesic_angle(rot[moved], after.rotations[moved]))
        kept[moved] = off <= tolerance_deg
    stood = moved & ~kept
    if not kept.any():
        return after, kept, stood
    return dataclasses.replace(after, rotations=np.where(kept[..., None], rot, after.rotations)), kept, stood


def keep_measured_in_denoise(before: Motion, after: Motion) -> tuple[Motion, np.ndarray, np.ndarray]:
    """``after`` (``before`` denoised, the same frames) with the cells it changed that ``before``'s BVH or AMC file
    gives partly ``nan`` (a filled cell) put back on the file's measured channels where the missing ones alone reach
    the denoised rotation within :data:`REPAIR_TOLERANCE_DEG`: the rule of :func:`keep_measured_in_repair`, for the
    denoise step (:func:`mocapkit.cleaning.whole_take.denoise_take`,
    ``clean``'s denoise step on the frames between calibration poses).

    A noisy joint's run is denoised as a whole, its filled cells too (they are smooth and left out of the noise
    test, not out of the run): cmu_01_01_start's LeftUpLeg, noisy (2 deg noise written on its channels around
    frames 45-50, its Z ``nan`` there), came back with the measured Y and X of those frames moved by up to 0.85 deg,
    numbers the file measured with no noise in them. Where the measured channels are themselves noisy, no missing
    channel reaches the denoised rotation and the denoise stands whole (the noise is the evidence against them).
    Both are whole takes (the file's frames: a slice of one has no file rows to put back). Returns
    ``(motion, kept, stood)`` as :func:`keep_measured_in_repair` (:func:`kept_note` says both)."""
    from .whole_take import differing  # whole_take denoises with this: imported on use

    return keep_measured_in_repair(before, after, differing(before.rotations, after.rotations))


def kept_note(kept: np.ndarray, names, step: str, stood: np.ndarray | None = None) -> str:
    """One line saying the cells ``kept`` (F, J) bool a ``step`` ("denoise", "repair") put back on their measured
    channels (:func:`keep_measured_in_denoise`, :func:`keep_measured_in_repair`), and, given ``stood`` (F, J) bool,
    the filled cells it changed whole, measured channels too, because no missing channel alone came within
    :data:`REPAIR_TOLERANCE_DEG` of its rotation (the measured ones disagree with it: the evidence against them);
    each a count and the joints named (``names``: the take's joint names); "" for none of either."""
    def cells(mask) -> str:
        joints = ", ".join(names[j] for j in np.flatnonzero(np.any(mask, axis=0)))
        n = int(np.sum(mask))
        return f"{n} filled cell{'' if n == 1 else 's'} ({joints})"

    said = []
    if np.any(kept):
        said.append(f"{cells(kept)} kept the file's measured channels, the {step} moving the missing ones alone "
                    f"(within {REPAIR_TOLERANCE_DEG:g} deg of its rotation)")
    if stood is not None and np.any(stood):
        said.append(f"{cells(stood)} changed whole by the {step}, measured channels too: the missing ones alone came "
                    f"no nearer than {REPAIR_TOLERANCE_DEG:g} deg to its rotation (evidence against the measured ones)")
    return "; ".join(said)


#: Joints :func:`filled_channels_note` names one by one; the rest it counts.
MAX_NAMED_JOINTS = 6


def filled_channels(before: Motion, after: Motion) -> tuple[np.ndarray, list[str]] | None:
    """The file channels ``after`` (``before`` filled, :func:`keep_measured`) filled in the cells ``before``'s BVH
    or AMC file (its ``source_file``, or an .npz keeping such a file's numbers) gives partly ``nan``: ``(mask,
    names)``, ``mask`` (F, C) bool over the file's channels in the writers' column order, ``names`` the C names
    ``"joint.channel"`` (a BVH's ``Zrotation``, an AMC's ``rx``). A cell is a joint's channels in one frame; one
    partly ``nan`` (some channels ``nan``, the others measured: a rotation with one angle missing, a rotation
    missing beside measured position channels) is filled in its ``nan`` channels alone, and ``after`` has it
    (not missing). None where no file is or no cell is partly ``nan`` and filled (a whole joint's gap is said by
    the cell counts)."""
    values, channels, bvh = _file_numbers(after, before.source_file)
    if values is None or values.shape[0] != after.num_frames or len(channels) != after.num_joints:
        return None
    has = ~after.missing()
    mask = np.zeros(values.shape, dtype=bool)
    names: list[str] = []
    starts = channel_starts(channels)
    for j, chans in enumerate(channels):
        cols = slice(starts[j], starts[j + 1])
        names.extend(f"{after.skeleton.joint_names[j]}.{c}" for c in chans)
        if len(chans) < 2:
            continue
        own = values[:, cols]
        mask[:, cols] = np.isnan(own) & (partly_missing(own) & has[:, j])[:, None]
    return (mask, names) if mask.any() else None


def filled_channels_note(before: Motion, after: Motion) -> str:
    """One line naming the channels ``after`` filled in cells ``before``'s file gives partly ``nan``
    (:func:`filled_channels`), joint by joint with their frames (0-based; the first :data:`MAX_NAMED_JOINTS`
    joints, the rest counted), and saying that the file's measured channels there are kept as written: what
    ``clean``'s fill step and ``mocapkit fill`` say, so that a person knows which numbers of a partly measured
    cell are made up; "" where there is none."""
    found = filled_channels(before, after)
    if found is None:
        return ""
    mask, names = found
    parts = []
    cells = 0
    cols = np.flatnonzero(mask.any(axis=0))
    for joint in dict.fromkeys(names[c].rsplit(".", 1)[0] for c in cols):
        own = [c for c in cols if names[c].rsplit(".", 1)[0] == joint]
        rows = np.flatnonzero(mask[:, own].any(axis=1))
        cells += rows.size
        whole = rows[-1] - rows[0] + 1 == rows.size
        frames = (frame_span(int(rows[0]), int(rows[-1])) if whole
                  else f"{plural(int(rows.size), 'frame')} of {frame_span(int(rows[0]), int(rows[-1]))}")
        parts.append(f"{joint} {listed(names[c].rsplit('.', 1)[1] for c in own)} ({frames})")
    more = len(parts) - MAX_NAMED_JOINTS
    said = "; ".join(parts[:MAX_NAMED_JOINTS]) + (f"; and {plural(more, 'more joint')}" if more > 0 else "")
    return (f"{plural(cells, 'partly measured cell')} filled in their nan channels alone, the measured channels "
            f"kept as the file writes them: {said}")


def measured_rotations(motion: Motion) -> np.ndarray | None:
    """(F, C) over ``motion``'s file channels (:meth:`Motion.channel_values`' columns): the rotation numbers (degrees)
    its BVH file (its ``source_file``, or an .npz keeping such a file's numbers) measures in the cells ``motion``
    lacks because some other channel of the joint is ``nan`` there (a ``Zrotation`` written ``nan`` beside measured
    ``Xrotation`` and ``Yrotation``, or a whole rotation beside a ``nan`` position), NaN in every other entry;
    None where there is no such number. What a fill conditions its estimate of those cells on
    (:func:`mocapkit.cleaning.deep.fill_gaps`), so that its rotation agrees with the measured angles
    (:func:`keep_measured` then writes them as the file does). An ASF/AMC take's rotation dofs alike (an
    ``lfoot`` with ``rx rz``, its ``rz`` written ``nan``): the AMC lists a bone's dofs in the ASF's order (``rx ry
    rz``), :meth:`Motion.channel_values` its channels in the skeleton's (``Zrotation Yrotation Xrotation``, the same
    angles), so each dof goes to the column of its axis. A cell counts where the file gives the joint's numbers
    partly ``nan`` (:func:`~mocapkit.io.euler_branches.partly_missing`) alone: where it gives them whole and
    ``motion`` lacks the cell (an .npz of a take with gaps cut into it, ``mocapkit corrupt take.bvh g.npz``, keeps the
    source file's numbers), they are the numbers that were taken out, not a measurement the gap left."""
    values, names, bvh = _file_numbers(motion, motion.source_file)
    F = motion.num_frames
    if values is None or values.shape[0] != F or len(names) != motion.num_joints:
        return None
    gone = motion.missing()
    sk = motion.skeleton
    own_channels = [sk.joint_channels(j) for j in range(sk.num_joints)]
    starts, at = channel_starts(names), channel_starts(own_channels)
    out = np.full((F, at[-1]), np.nan)
    for j, chans in enumerate(names):
        own = own_channels[j]
        rows = gone[:, j] & partly_missing(values[:, starts[j]:starts[j + 1]])
        if bvh:
            pairs = [(starts[j] + k, at[j] + k) for k, c in enumerate(chans) if c.endswith("rotation")]
        else:  # dof "rx" -> channel "Xrotation" of the same joint
            pairs = [(starts[j] + k, at[j] + own.index(f"{d[1].upper()}rotation")) for k, d in enumerate(chans)
                     if d[0] == "r" and f"{d[1].upper()}rotation" in own]
        if not pairs:
            continue
        src, dst = (list(c) for c in zip(*pairs))
        out[np.ix_(rows, dst)] = values[np.ix_(rows, src)]
    return out if np.isfinite(out).any() else None


def measured_axes(motion: Motion) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``(root, offsets)``: the position axes ``motion``'s BVH or AMC file (its ``source_file``, or an .npz keeping
    such a file's numbers) measures in the cells where it gives a joint's position channels partly ``nan`` (a root
    ``Yposition`` written ``nan``, its ``Xposition`` and ``Zposition`` numbers; an AMC root's ``ty``).

    ``root``: (F, 3) bool, axes x, y, z of ``Motion.root_positions``; ``offsets``: (F, J, 3) bool, of the animated
    offsets ``Motion.translations`` (None where the take has none). Each is None where no such cell is (no file,
    none partly ``nan``, or the file gone since it was read). The fill keeps those numbers as the file writes them
    (:func:`keep_measured`); a later step that moves the position of such a cell has evidence against the missing
    axis it made up, not necessarily against these."""
    values, names, bvh = _file_numbers(motion, motion.source_file)
    F = motion.num_frames
    if values is None or values.shape[0] != F or not np.isnan(values).any():
        return None, None
    axis_of = (lambda c: c[0] if c.endswith("position") else "") if bvh else (lambda d: d[1] if d[0] == "t" else "")
    root = np.zeros((F, 3), dtype=bool)
    offsets = None if motion.translations is None else np.zeros((F, motion.num_joints, 3), dtype=bool)
    starts = channel_starts(names)
    for j, chans in enumerate(names):
        axes = [(starts[j] + k, "xyz".index(a.lower())) for k, a in enumerate(map(axis_of, chans)) if a]
        into = root if j == 0 else None if offsets is None else offsets[:, j]
        if len(axes) < 2 or into is None:
            continue
        own = values[:, [c for c, _ in axes]]
        part = partly_missing(own)
        for i, (_, ax) in enumerate(axes):
            into[:, ax] |= part & np.isfinite(own[:, i])
    return (root if root.any() else None), (offsets if offsets is not None and offsets.any() else None)


_NAN = re.compile(rb"[nN][aA][nN]")


def _may_hold_nan(src) -> bool:
    """False only where the BVH or AMC file ``src`` holds no ``nan`` anywhere in its text (its bytes as the take was
    read from it, :func:`mocapkit.io.sources.recall`): then no cell is partly ``nan`` and there is nothing to keep,
    and its numbers need not be parsed again (a 4.5-minute BVH at 120 fps takes 0.5-0.8 s, on every denoise and
    repair of its take). An .npz, or bytes that cannot be had, may hold some: True."""
    if Path(src).suffix.lower() == ".npz":
        return True
    try:
        data = recall(src)
    except (MocapFormatError, OSError):
        return True  # the caller's own reading says what became of the file
    return data is None or _NAN.search(data) is not None


def _file_numbers(motion: Motion, src) -> tuple[np.ndarray | None, tuple, bool]:
    """``(values, names, bvh)``: the numbers (F, C) of the BVH or AMC file ``src`` (or of an .npz keeping such a
    file's numbers) that ``motion`` was read from, as the writers read them (:func:`mocapkit.io.bvh.source_values`,
    :func:`mocapkit.io.amc_writer.source_numbers`), each joint's channel or dof names, and whether it is a BVH's;
    ``values`` None where there is no such file, its text holds no ``nan`` (:func:`_may_hold_nan`: nothing partly
    measured), or it was removed or replaced since it was read, its bytes let go (:mod:`mocapkit.io.sources`):
    nothing to keep, the step stands as for a take read from no file."""
    bvh = motion.skeleton.axes is None
    if src is None or Path(src).suffix.lower() not in (".bvh", ".amc", ".npz") or not _may_hold_nan(src):
        return None, (), bvh
    try:
        if bvh:
            from ..io.bvh import source_values  # io is below cleaning; imported on use: most takes have no gaps

            return (*source_values(motion, src), bvh)
        from ..io.amc_writer import source_numbers

        return (*source_numbers(motion, src), bvh)
    except (MocapFormatError, OSError):
        return None, (), bvh


def _partly_measured(before: Motion, after: Motion, rot: np.ndarray, gone: np.ndarray) -> None:
    """Put the measured rotation channels (BVH) or dofs (AMC) of ``before``'s file back into ``rot`` (F, J, 4;
    ``after``'s filled rotations, in place) in the cells the file gives partly ``nan`` (:func:`keep_measured`) and
    ``before`` lacks (``gone`` (F, J) bool): a cell ``before`` has is its own, whatever its file says there."""
    if not gone.any():
        return
    values, names, bvh = _file_numbers(after, before.source_file)
    if values is not None:
        (_bvh_measured if bvh else _amc_measured)(after, values, names, rot, gone)


def _amc_measured(after: Motion, values: np.ndarray, dofs, rot: np.ndarray, gone: np.ndarray) -> None:
    """:func:`_partly_measured` for an ASF/AMC take (``values``, ``dofs``: its file's, :func:`_file_numbers`): a
    bone's dof angles are the Euler angles of ``C^-1 q C`` (``C`` its ASF axis frame; extrinsic, in the dofs' order),
    as the AMC reader builds ``q`` from them."""
    for j, own, part, order in _partly_nan(after, values, dofs, lambda x: x[1] if x[0] == "r" else "", rot, gone):
        c = np.broadcast_to(after.skeleton.axes[j], rot[part, j].shape)
        m = R.quaternion_multiply(R.quaternion_multiply(R.quaternion_conjugate(c), rot[part, j]), c)
        m = R.euler_to_quaternion(_filled_angles(m, own[part], bridged(own)[part], order), order)
        rot[part, j] = R.quaternion_multiply(R.quaternion_multiply(c, m), R.quaternion_conjugate(c))


def _bvh_measured(after: Motion, values: np.ndarray, channels, rot: np.ndarray, gone: np.ndarray) -> None:
    """:func:`_partly_measured` for a BVH take (``values``, ``channels``: its file's, :func:`_file_numbers`): a
    joint's rotation channels are intrinsic Euler angles in the file's channel order, as the BVH reader builds the
    rotation from them."""
    for j, own, part, order in _partly_nan(after, values, channels, lambda c: c[0] if c.endswith("rotation") else "",
                                           rot, gone):
        rot[part, j] = R.euler_to_quaternion(_filled_angles(rot[part, j], own[part], bridged(own)[part], order), order)


def _partly_nan(after: Motion, values, channels, axis_of, rot: np.ndarray, gone: np.ndarray):
    """The joints whose rotation numbers in the file are partly ``nan`` in cells ``after`` lacks (``gone``) and
    the fill gave a rotation: yields ``(j, own, part, order)``, ``own`` (F, n) the joint's rotation numbers
    (degrees), ``part`` (F,) bool those cells, ``order`` the rotation axes' letters in file order.

    ``values`` (F, C): every number of the file, joint after joint (None: no such file); ``channels``: per joint
    its channel names (BVH) or dof names (AMC); ``axis_of(name)``: the axis letter of a rotation channel, "" for
    any other. A joint with fewer than two rotation channels has no partly-missing rotation."""
    if values is None or values.shape[0] != after.num_frames or not np.isnan(values).any():
        return
    starts = channel_starts(channels)
    for j, names in enumerate(channels):
        axes = [(k, a) for k, a in enumerate(map(axis_of, names)) if a]
        cols = [starts[j] + k for k, _ in axes]
        if len(cols) < 2:
            continue
        own = values[:, cols]
        part = partly_missing(own) & gone[:, j] & np.isfinite(rot[:, j]).all(axis=-1)
        if part.any():
            yield j, own, part, "".join(a for _, a in axes)


def _filled_angles(target: np.ndarray, own: np.ndarray, near: np.ndarray, order: str) -> np.ndarray:
    """(N, n) Euler angles (degrees, in ``order``) of N cells: ``own``'s (N, n) where measured, the missing ones
    chosen so that the rotation is the nearest to ``target`` (N, 4; the fill's) that the measured ones allow, on
    the whole turn nearest ``near`` (N, n; the missing channel's curve bridged over its gap).

    The fill is solved for in the rotation, not filled in the channel space: the network and the gap prior fill
    a joint's whole rotation, and a missing Euler channel is whatever angle, beside the measured ones, gives the
    rotation nearest to it (the least geodesic angle, i.e. the largest ``|<q, target>|``). A channel curve filled
    on its own knows nothing of the other channels, and near gimbal lock (the middle angle near 90 deg) Z and Y
    trade off, so neither a spline through the missing channel nor the fill's own angle for it is the rotation the
    fill found.

    The rotation is ``A r(t) B`` in each angle ``t`` (``r`` the turn about its axis), so
    ``q(t) = cos(t/2) q(0) + sin(t/2) q(180)``. One missing angle: ``<q(t), target>`` is largest at
    ``t = 2 atan2(<q(180), target>, <q(0), target>)``. Two missing angles ``s``, ``t``: ``q`` is bilinear in
    ``x = (cos(s/2), sin(s/2))`` and ``y = (cos(t/2), sin(t/2))``, so ``<q, target> = x^T M y`` with ``M`` (2, 2)
    its values at ``s, t`` in {0, 180}; its largest over unit ``x``, ``y`` is ``M``'s largest singular value, at
    its singular vectors. Both are the geodesic nearest, exactly, in any order (intrinsic or extrinsic, middle
    angle measured or not). Taking ``target`` apart and keeping its angles for the missing channels instead puts
    the rotation as far from the fill as the measured angles are from ``target``'s own: Bandai bye_giant's Spine
    (X 89.5 deg, its Z missing) came out up to 68 deg from the fill, 0.4 deg by the nearest angle; 131_01's
    LeftElbow (ZYX) with Z and Y missing and a fill 5 deg off about its Y, 5.0 deg, 3.2 by the nearest pair."""
    angles = R.nearest_euler(R.quaternion_to_euler(target, order), near, order)
    lost = np.isnan(own)
    angles = np.where(lost, angles, own)
    count = lost.sum(axis=-1)
    n = own.shape[-1]
    for k in range(n):  # one missing angle
        rows = np.flatnonzero((count == 1) & lost[:, k])
        if rows.size:
            at = [_at(angles[rows], {k: h}) for h in (0.0, 180.0)]
            a, b = (np.sum(R.euler_to_quaternion(x, order) * target[rows], axis=-1) for x in at)
            angles[rows, k] = _near_turn(2.0 * np.degrees(np.arctan2(b, a)), near[rows, k])
    for k, m in ((k, m) for k in range(n) for m in range(k + 1, n)):  # two missing angles
        rows = np.flatnonzero((count == 2) & lost[:, k] & lost[:, m])
        if not rows.size:
            continue
        M = np.empty((rows.size, 2, 2))
        for i, hk in enumerate((0.0, 180.0)):
            for j, hm in enumerate((0.0, 180.0)):
                q = R.euler_to_quaternion(_at(angles[rows], {k: hk, m: hm}), order)
                M[:, i, j] = np.sum(q * target[rows], axis=-1)
        u, _, vt = np.linalg.svd(M)
        angles[rows, k] = _near_turn(2.0 * np.degrees(np.arctan2(u[:, 1, 0], u[:, 0, 0])), near[rows, k])
        angles[rows, m] = _near_turn(2.0 * np.degrees(np.arctan2(vt[:, 0, 1], vt[:, 0, 0])), near[rows, m])
    return angles


def _at(angles: np.ndarray, set_to: dict) -> np.ndarray:
    """A copy of ``angles`` (N, n) with column ``k`` set to ``set_to[k]`` degrees for each key."""
    out = np.array(angles, dtype=np.float64)
    for k, v in set_to.items():
        out[:, k] = v
    return out


def _near_turn(turn: np.ndarray, near: np.ndarray) -> np.ndarray:
    """``turn`` (degrees) plus the whole turns that put it nearest ``near``: the same rotation, on the branch of the
    channel's own curve."""
    return turn + 360.0 * np.round((near - turn) / 360.0)
