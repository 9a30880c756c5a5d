"""Motions with known changes for the self-similarity tests."""

import dataclasses

import numpy as np

from mocapkit import rotations as R


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
