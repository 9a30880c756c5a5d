"""What a reconstruction's ``.npz`` holds: the Motion, and arrays that say what it is without mocapkit.

``mocapkit reconstruct -o OUT.npz`` writes mocapkit's native Motion npz (:mod:`mocapkit.io.npz`: local
rotations, root positions, skeleton; ``mocapkit.load`` reads it back), and beside it the arrays a user of
numpy alone looks for: the global joint positions (F, J, 3) with their length unit, the joint names, the
frame rate, the control signal it was reconstructed from, and a ``contents`` text naming every array with its
shape and unit. The poses are the database's takes': where the project knows their terms (the Bandai Namco
set's CC BY-NC 4.0, :func:`mocapkit.rigs.data_terms`, kept in the database's ``info["licence"]``) a ``licence``
text says them, so a file shipped alone still carries them. A BVH or AMC has no field for it (the console says it).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import SkeletonError
from ..joints import unit_scale_cm

__all__ = ["carried_above", "described_arrays", "kept_licence", "laid_out_like", "save_reconstruction", "UNIT_NAMES"]

#: Centimetres per unit -> the unit's name, for ``length_unit``.
UNIT_NAMES = {0.1: "mm", 1.0: "cm", 2.54: "in", 10.0: "dm", 30.48: "ft", 100.0: "m"}

_CONTENTS = """mocapkit reconstruction ({method}), a mocapkit Motion npz (mocapkit.load reads it).
positions: float64 (F, J, 3), global joint positions, in length_unit ({unit}), the skeleton's up axis.
joint_names: (J,) the joints of positions and rotations, in order; parents: (J,) each joint's parent (-1: root).
fps: frames per second; F = {frames} frames.
rotations: float64 (F, J, 4), local joint rotations, unit quaternions (w, x, y, z), relative to the parent.
root_positions: float64 (F, 3), the root joint's position, in length_unit.
offsets: float64 (J, 3), each joint's offset from its parent at rest, in length_unit.
cm_per_unit: centimetres per length unit (NaN when it cannot be told).
method: the control signal: markers, accelerometers or ssg (gappy markers); multilinear: accelerometers fitted by a multilinear model.{licence}"""


def _unit(motion) -> tuple[float, str]:
    """Centimetres per length unit of ``motion``'s skeleton and the unit's name ("unknown" where no human height
    or stated unit tells it, NaN cm)."""
    try:
        cm = unit_scale_cm(motion.skeleton)
    except SkeletonError:
        return float("nan"), "unknown"
    name = next((n for c, n in UNIT_NAMES.items() if np.isclose(cm, c, rtol=1e-6)), f"{cm:g} cm")
    return cm, name


def described_arrays(motion, method: str, licence: str | None = None) -> dict:
    """The arrays beside the Motion in a reconstruction's npz (module docstring): ``positions`` (F, J, 3) float64
    global joint positions in the skeleton's length unit, ``length_unit`` (str), ``cm_per_unit`` (float),
    ``method`` (str), ``contents`` (str: every array with its shape and unit) and, when ``licence`` is given (the
    terms of the database's takes), ``licence`` (str)."""
    cm, unit = _unit(motion)
    positions = motion.global_positions()
    said = f"\nlicence: the terms of the database's takes the poses come from: {licence}" if licence else ""
    contents = _CONTENTS.format(method=method, unit=unit, frames=motion.num_frames, licence=said)
    out = {"positions": positions, "length_unit": np.array(unit), "cm_per_unit": np.array(cm),
           "method": np.array(method), "contents": np.array(contents)}
    if licence:
        out["licence"] = np.array(str(licence))
    return out


def laid_out_like(m, take, follow: bool = False):
    """``m`` (a whole reconstructed Motion on ``take``'s joints) with the joints above the pelvis as ``take`` (the
    input take, a Motion, or a database) has them, every body joint where it was.

    A game rig's file is written laid out as its input: where ``take`` holds those joints still
    (:func:`mocapkit.reconstruct._common.held_above`: the Bandai Namco ``joint_Root`` at the origin of
    dataset 2), there, ``Hips``' position channels carrying the world translation. Where it moves them (root
    motion: the ``joint_Root`` of four dataset-1 takes travels on the floor with the body) and ``take`` is a
    Motion of ``m``'s frames with those joints in every frame: with ``follow`` (the body placed in ``take``'s
    frame, as markers place it) ``take``'s own, frame by frame; without it (accelerometers and multilinear
    models, which do not place the body) where they are in ``take`` relative to its pelvis's ground frame
    (heading and ground position, :func:`mocapkit.features.root_frame`), put in ``m``'s pelvis's ground
    frame (:func:`carried_above`). ``m`` itself otherwise: the pelvis is the root or has no position
    channels, or ``take`` cannot say (another length, a gap in those joints or, without ``follow``, in either
    pelvis).
    """
    from ._common import body_joints, body_motion, held_above, whole_motion

    held = held_above(take)
    if held is None and getattr(take, "num_frames", -1) == m.num_frames and take.num_frames:
        above = np.setdiff1d(np.arange(take.num_joints), body_joints(take.skeleton))
        whole = [take.root_positions, take.rotations[:, above]]
        if take.translations is not None:
            whole.append(take.translations[:, above])
        if above.size and all(np.isfinite(a).all() for a in whole):  # a gap there: nothing to keep
            held = take if follow else carried_above(take, m)
    if held is None:
        return m
    return whole_motion(body_motion(m), m.skeleton, np.zeros(3), held)


def carried_above(take, m):
    """``take`` (a Motion whose joints above the pelvis move: root motion) with its root moved, frame by frame, from
    ``take``'s pelvis's ground frame into ``m``'s (a reconstruction of ``take``'s frames on its joints).

    The ground frame (:func:`mocapkit.features.root_frame`) is the pelvis's heading about the vertical and its
    position on the floor; the vertical is ``take``'s (:func:`mocapkit.features.find_up_axis`). With ``(H_t,
    g_t)`` that frame in ``take`` and ``(H_m, g_m)`` in ``m``, the root's global rotation ``q`` and position ``p``
    become ``H_m H_t^-1 q`` and ``H_m H_t^-1 (p - g_t) + g_m``: a root ``take`` keeps 3 cm behind its pelvis on
    the floor, turned as the body, is 3 cm behind ``m``'s, turned as ``m``'s body. The joints between the root
    and the pelvis keep ``take``'s local rotations and offsets. Returns a Motion on ``take``'s skeleton of its
    frames (positions in ``take``'s length unit) for :func:`~mocapkit.reconstruct._common.whole_motion`, or None
    where a frame of either pelvis is missing (NaN): no root is made up there.
    """
    from .. import rotations as R
    from ..features import find_up_axis, root_frame
    from ..motion import Motion

    up = find_up_axis(take.skeleton, take.global_positions())
    h_t, g_t = root_frame(take, up)
    h_m, g_m = root_frame(m, up)
    s = 1.0 if m.skeleton is take.skeleton else _unit(m)[0] / _unit(take)[0]  # m's unit -> take's
    s = s if np.isfinite(s) else 1.0
    turn = R.quaternion_multiply(h_m, R.quaternion_conjugate(h_t))
    rot = np.array(take.rotations, dtype=np.float64)
    rot[:, 0] = R.quaternion_multiply(turn, rot[:, 0])
    root = R.quaternion_rotate(turn, np.asarray(take.root_positions, dtype=np.float64) - g_t) + g_m * s
    if not (np.isfinite(root).all() and np.isfinite(rot[:, 0]).all()):
        return None
    return Motion(take.skeleton, rot, root, take.fps, take.name, take.translations)


def save_reconstruction(motion, path, method: str, *, asf=None, licence: str | None = None) -> Path:
    """Write a reconstruction to ``path`` (.bvh, .amc, .npz) atomically: an npz says what it holds
    (:func:`described_arrays`, with ``licence``: the terms of the database's takes, ``db.info.get("licence")``),
    the other formats are written as :func:`mocapkit.io.save` writes them.
    ``method``: "markers", "accelerometers", "ssg" or "multilinear"; ``asf``: an AMC's skeleton file."""
    from .. import io

    path = Path(path)
    extra = {"extra": described_arrays(motion, method, licence)} if path.suffix.lower() == ".npz" else {}
    return io.save(motion, path, asf=asf, like=False, copy_asf=False, **extra)


def kept_licence(path) -> str | None:
    """The ``licence`` text an ``.npz`` at ``path`` keeps (:func:`described_arrays`: the terms of the database's
    takes a reconstruction's poses come from), or None: no such member, not an npz, or not one text. Read after
    the file was read as a take (whose reader bounds its members' sizes), for ``mocapkit info``."""
    path = Path(path)
    if path.suffix.lower() != ".npz":
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            if "licence" not in z.files:
                return None
            text = z["licence"]
    except (OSError, ValueError):
        return None
    return str(text) if text.dtype.kind == "U" and text.ndim == 0 and str(text) else None
