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


# -- ASF/AMC ----------------------------------------------------------------------


def _extrinsic(angles_deg, axes: str) -> np.ndarray:
    """Rotation matrix applying elementary rotations in the listed order (x first for "xyz").

    Each later rotation multiplies from the left: "xyz" gives Rz @ Ry @ Rx.
    """
    m = np.eye(3)
    for value, axis in zip(angles_deg, axes):
        m = _ELEMENTARY[axis.upper()](value) @ m
    return m


def naive_asf_parse(path) -> dict:
    """Parse an ASF file with plain string handling (Latin-1, any line ends, # comments).

    Returns
    -------
    dict
        ``length`` (the ``:units length`` value, 1.0 if absent), ``radians``
        (bool), ``root`` (dict of ``order``, ``axis``, ``position``,
        ``orientation`` as token lists), ``bones`` (name -> dict with
        ``direction`` (3,), ``length``, ``axis`` (3 angles), ``axis_order``,
        ``dof`` list), ``children`` (name -> list of child bone names in file order).
    """
    with open(path, encoding="latin-1", newline=None) as fh:
        lines = fh.read().splitlines()
    out = {"length": 1.0, "radians": False, "root": {}, "bones": {}, "children": {}}
    section = None
    bone = None
    for raw in lines:
        line = raw.split("#")[0].strip()
        if not line:
            continue
        tokens = line.split()
        if line.startswith(":"):
            section = tokens[0]
            continue
        if section == ":units":
            if tokens[0] == "length":
                out["length"] = float(tokens[1])
            elif tokens[0] == "angle":
                out["radians"] = tokens[1].lower() == "rad"
        elif section == ":root":
            out["root"][tokens[0]] = tokens[1:]
        elif section == ":bonedata":
            if tokens[0] == "begin":
                bone = {"dof": [], "axis": [0.0, 0.0, 0.0], "axis_order": "xyz"}
            elif tokens[0] == "end":
                out["bones"][bone["name"]] = bone
            elif tokens[0] == "name":
                bone["name"] = tokens[1]
            elif tokens[0] == "direction":
                bone["direction"] = np.array([float(t) for t in tokens[1:4]])
            elif tokens[0] == "length":
                bone["length"] = float(tokens[1])
            elif tokens[0] == "axis":
                bone["axis"] = [float(t) for t in tokens[1:4]]
                bone["axis_order"] = tokens[4].lower()
            elif tokens[0] == "dof":
                bone["dof"] = [t.lower() for t in tokens[1:]]
        elif section == ":hierarchy" and tokens[0] not in ("begin", "end"):
            out["children"].setdefault(tokens[0], []).extend(tokens[1:])
    return out


def naive_amc_parse(path, only=None) -> tuple[list[dict], bool]:
    """Parse an AMC file: a list of frames, each ``{bone name: [values]}``, and whether it is in radians.

    With ``only`` (a set of 0-based frame indices) the other frames are left as empty dicts.
    """
    with open(path, encoding="latin-1", newline=None) as fh:
        lines = fh.read().splitlines()
    frames: list[dict] = []
    radians = False
    keep = True
    for raw in lines:
        tokens = raw.split()
        if not tokens or tokens[0].startswith("#"):
            continue
        if tokens[0].startswith(":"):
            radians = radians or tokens[0].upper() == ":RADIANS"
            continue
        if len(tokens) == 1 and tokens[0].isdigit():
            keep = only is None or len(frames) in only
            frames.append({})
            continue
        if keep:
            frames[-1][tokens[0]] = [float(t) for t in tokens[1:]]
    return frames, radians


def naive_asfamc_fk(asf_path, amc_path, frames) -> list[dict]:
    """Bone start and end points of the given AMC frames, from the ASF definition.

    One bone at a time with 3x3 matrices: the axis frame ``C`` of a bone is the
    extrinsic rotation of its ``axis`` angles in the stated order, its motion
    ``M`` the extrinsic rotation of the AMC values in ``dof`` order; the
    global rotation is ``G = G_parent @ C @ M @ C^T``, the bone starts where
    its parent ends (bones on the root: at the root position plus ``G_root``
    applied to the root ``position``) and ends at ``start + G @ (direction * length)``.
    The root's ``C`` comes from ``orientation`` in the ``:root axis`` order,
    its position and ``M`` from the AMC root values read by ``order``.

    Returns
    -------
    list of dict, one per requested frame
        ``"root"`` -> position (3,), and each bone name -> ``(start, end)``,
        in ASF length units.
    """
    asf = naive_asf_parse(asf_path)
    data, amc_radians = naive_amc_parse(amc_path, only=set(frames))
    to_deg = (lambda v: [math.degrees(x) for x in v]) if asf["radians"] else (lambda v: list(v))
    amc_deg = (lambda v: [math.degrees(x) for x in v]) if amc_radians else (lambda v: list(v))
    root = asf["root"]
    order = [t.lower() for t in root.get("order", ["TX", "TY", "TZ", "RX", "RY", "RZ"])]
    root_axis = root.get("axis", ["XYZ"])[0].lower()
    orientation = to_deg([float(t) for t in root.get("orientation", [0, 0, 0])])
    position = np.array([float(t) for t in root.get("position", [0, 0, 0])])
    c_root = _extrinsic(orientation, root_axis)
    results = []
    for f in frames:
        values = data[f]
        rv = values.get("root", [0.0] * len(order))
        translation = np.zeros(3)
        rot_values, rot_axes = [], ""
        for name, v in zip(order, rv):
            if name[0] == "t":
                translation["xyz".index(name[1])] = v
            else:
                rot_values.append(v)
                rot_axes += name[1]
        g_root = c_root @ _extrinsic(amc_deg(rot_values), rot_axes) @ c_root.T
        res = {"root": translation}

        def visit(name, g_parent, start):
            bone = asf["bones"][name]
            c = _extrinsic(to_deg(bone["axis"]), bone["axis_order"])
            dof = bone["dof"]
            m = _extrinsic(amc_deg(values.get(name, [0.0] * len(dof))), "".join(d[1] for d in dof))
            g = g_parent @ c @ m @ c.T
            end = start + g @ (bone["direction"] * bone["length"])
            res[name] = (start, end)
            for child in asf["children"].get(name, []):
                visit(child, g, end)

        for child in asf["children"]["root"]:
            visit(child, g_root, translation + g_root @ position)
        results.append(res)
    return results
