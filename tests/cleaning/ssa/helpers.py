"""Motions with known changes for the self-similarity tests."""

import dataclasses
import re
from pathlib import Path

import numpy as np

import mocapkit
from mocapkit import rotations as R
from mocapkit.motion import Motion


def turned(motion, joint, frames, angle_deg):
    """``motion`` with ``joint`` turned by ``angle_deg`` (scalar, or one per frame) about x on ``frames``."""
    j = motion.skeleton.index(joint)
    rot = np.array(motion.rotations)
    ang = np.broadcast_to(np.radians(angle_deg), (len(frames),))
    turn = R.quaternion_from_axis_angle(np.array([1.0, 0.0, 0.0]), ang)
    rot[frames, j] = R.quaternion_multiply(rot[frames, j], turn)
    return dataclasses.replace(motion, rotations=rot), j


def swinging(walk, joint, angle_deg):
    """``walk`` with ``joint`` set to a turn of ``angle_deg`` (one per frame) about x: a one-channel test signal."""
    j = walk.skeleton.index(joint)
    rot = np.array(walk.rotations)
    rot[:, j] = R.quaternion_from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(angle_deg))
    return dataclasses.replace(walk, rotations=rot), j


def offset_on(walk, joint, frames, angle_deg, own_frame):
    """``walk`` with ``joint`` offset by ``angle_deg`` about x on ``frames``: in the joint's own frame (``q * turn``,
    a flip about a bone) or in the parent's (``turn * q``, an offset on the first Euler channel)."""
    j = walk.skeleton.index(joint)
    rot = np.array(walk.rotations)
    turn = R.quaternion_from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(angle_deg))
    rot[frames, j] = R.quaternion_multiply(rot[frames, j], turn) if own_frame else R.quaternion_multiply(turn, rot[frames, j])
    return dataclasses.replace(walk, rotations=rot), j


def midpoint_line(m: Motion, t: int, decimals: int) -> str:
    """The BVH line of the slerp midpoint of frames ``t`` and ``t + 1`` of ``m``, written at ``decimals``."""
    q = R.slerp(m.rotations[t], m.rotations[t + 1], 0.5)
    rp = (m.root_positions[t] + m.root_positions[t + 1]) / 2
    tr = None if m.translations is None else ((m.translations[t] + m.translations[t + 1]) / 2)[None]
    one = Motion(m.skeleton, q[None], rp[None], m.fps, translations=tr)
    return " ".join(f"{v:.{decimals}f}" for v in one.channel_values()[0])


def with_midpoints(path: Path, after, out: Path, decimals: int) -> Path:
    """The BVH file ``path`` with the slerp midpoint of frames ``t`` and ``t + 1`` written after each frame ``t``
    of ``after`` (as another tool's retiming writes it, at ``decimals``), saved as ``out``."""
    text = path.read_text()
    head, motion = text.split("Frame Time:")
    lines = motion.splitlines()
    rows = lines[1:]
    m = mocapkit.load(path)
    for t in sorted(after, reverse=True):
        rows.insert(t + 1, midpoint_line(m, t, decimals))
    head = re.sub(r"Frames:\s*\d+", f"Frames: {len(rows)}", head)
    out.write_text(head + "Frame Time:" + "\n".join([lines[0]] + rows) + "\n")
    return out


def twin_of(motion, name="twin"):
    """``motion``'s twin as a context clip that repeats it: its frames and its last quarter second again. A clip of
    the take's own length holding its samples, clean or not, is the input itself and left out of a context
    (:func:`mocapkit.cleaning.ssa.texture.own_share`), whatever its name; a quarter second longer, it is another
    clip at any rate a context is kept at (at 24 fps two frames more at 120 fps are the same length)."""
    from mocapkit.motion import concatenate

    return concatenate([motion, motion[-int(np.ceil(0.25 * motion.fps)):]], name=name)
