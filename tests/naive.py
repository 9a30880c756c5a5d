"""Slow, obvious reference implementations used as test oracles.

Nothing here uses mocapkit: files are parsed with plain string splitting and
kinematics is done with 4x4 homogeneous matrices built from elementary
rotation matrices, one frame and one joint at a time.
"""

from __future__ import annotations

import math

import numpy as np


# -- BVH --------------------------------------------------------------------------


def _rot_x(deg: float) -> np.ndarray:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(deg: float) -> np.ndarray:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(deg: float) -> np.ndarray:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


_ELEMENTARY = {"X": _rot_x, "Y": _rot_y, "Z": _rot_z}


def naive_bvh_parse(path):
    """Parse a BVH file the simple way.

    Returns
    -------
    joints : list of dict
        In file order: ``name``, ``parent`` (index or -1), ``offset`` (3 floats),
        ``channels`` (list of names as written).
    end_sites : list of (parent index, offset)
        In file order.
    frames : list of list of float
        One list of channel values per frame line.
    frame_time : float
    """
    with open(path, encoding="utf-8", errors="replace") as fh:
        text = fh.read()
    head, _, motion = text.partition("MOTION")
    tokens = head.split()
    joints: list[dict] = []
    end_sites: list[tuple[int, list[float]]] = []
    stack: list[object] = []  # joint index, or "end" for an End Site block
    current = None
    i = 0
    while i < len(tokens):
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            parent = next((s for s in reversed(stack) if s != "end"), -1) if stack else -1
            joints.append({"name": tokens[i + 1], "parent": parent, "offset": [0.0, 0.0, 0.0], "channels": []})
            current = len(joints) - 1
            i += 2
        elif t == "End":
            end_sites.append((stack[-1], [0.0, 0.0, 0.0]))
            current = "end"
            i += 2
        elif t == "{":
            stack.append(current)
            i += 1
        elif t == "}":
            stack.pop()
            i += 1
        elif t == "OFFSET":
            off = [float(tokens[i + 1]), float(tokens[i + 2]), float(tokens[i + 3])]
            if stack[-1] == "end":
                end_sites[-1] = (end_sites[-1][0], off)
            else:
                joints[stack[-1]]["offset"] = off
            i += 4
        elif t == "CHANNELS":
            n = int(tokens[i + 1])
            joints[stack[-1]]["channels"] = tokens[i + 2 : i + 2 + n]
            i += 2 + n
        else:
            i += 1
    lines = motion.splitlines()
    frame_time = None
    frames = []
    for line in lines:
        s = line.strip()
        if not s:
            continue
        if s.startswith("Frames"):
            continue
        if s.startswith("Frame Time"):
            frame_time = float(s.split(":")[1])
            continue
        frames.append([float(x) for x in s.split()])
    return joints, end_sites, frames, frame_time


def naive_bvh_fk(path, frames) -> np.ndarray:
    """Global positions of joints then end sites, (len(frames), J + E, 3), by 4x4 matrices.

    Per frame and joint: the local transform is a translation (the OFFSET, with
    each axis that has a position channel replaced by that channel's value)
    times the product of elementary rotations in channel order (intrinsic:
    ``Zrotation Yrotation Xrotation`` gives ``Rz @ Ry @ Rx``); the global
    transform is the parent's global transform times the local one.
    """
    joints, end_sites, data, _ = naive_bvh_parse(path)
    out = []
    for f in frames:
        row = data[f]
        col = 0
        globals_: list[np.ndarray] = []
        for joint in joints:
            t = list(joint["offset"])
            rot = np.eye(3)
            for ch in joint["channels"]:
                value = row[col]
                col += 1
                axis = ch[0].upper()
                if ch.lower().endswith("position"):
                    t["XYZ".index(axis)] = value
                else:
                    rot = rot @ _ELEMENTARY[axis](value)
            local = np.eye(4)
            local[:3, :3] = rot
            local[:3, 3] = t
            parent = joint["parent"]
            g = local if parent < 0 else globals_[parent] @ local
            globals_.append(g)
        pos = [g[:3, 3] for g in globals_]
        for parent, off in end_sites:
            tr = np.eye(4)
            tr[:3, 3] = off
            pos.append((globals_[parent] @ tr)[:3, 3])
        out.append(np.array(pos))
    return np.array(out)
