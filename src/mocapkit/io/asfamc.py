"""Acclaim ASF/AMC (the native CMU and HDM05 format).

The ASF describes bones; mocapkit's skeleton is joint based (BVH semantics), so
joint 0 is ``root`` and every bone becomes the joint at its start (the end of
its parent bone): its offset is the parent bone's ``direction * length``
(children of the root: the root ``position``), and every leaf bone gets an end
site at its tip. The bone's ``axis`` frame ``C`` is kept in
``Skeleton.axes`` so the local rotation is ``C @ M @ C^-1`` with ``M`` built
from the AMC's degrees of freedom, applied in dof order (extrinsic: ``dof rx ry
rz`` is ``Rz @ Ry @ Rx``). Channels are stored BVH style in intrinsic order,
i.e. the dof order reversed; limits are kept aligned with them.

Lengths stay in ASF units; ``Skeleton.unit_cm = 2.54 / length`` from
``:units length`` (CMU's 0.45 gives 5.644 cm per unit).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .. import rotations as R
from ..errors import MocapFormatError
from ..motion import Motion, Skeleton

__all__ = ["read_asf", "read_amc", "find_asf"]

_DOF = {"rx": "Xrotation", "ry": "Yrotation", "rz": "Zrotation", "tx": "Xposition", "ty": "Yposition", "tz": "Zposition"}


def _lines(path: Path) -> list[str]:
    try:
        return path.read_bytes().decode("latin-1").splitlines()
    except OSError as exc:
        raise MocapFormatError(path, f"cannot read: {exc.strerror or exc}") from None


def _floats(path, tokens, line, what, n=None):
    try:
        vals = [float(t) for t in tokens]
    except ValueError:
        raise MocapFormatError(path, f"non-numeric {what}: {' '.join(tokens)!r}", line) from None
    if n is not None and len(vals) != n:
        raise MocapFormatError(path, f"{what} needs {n} numbers, got {len(vals)}", line)
    return vals


def read_asf(path) -> Skeleton:
    """Read an ASF skeleton file into a joint-based :class:`Skeleton` (see the module docstring)."""
    path = Path(path)
    lines = _lines(path)
    length_unit, angle_unit = 1.0, "deg"
    root = {"order": ["TX", "TY", "TZ", "RX", "RY", "RZ"], "axis": "XYZ", "position": [0.0] * 3, "orientation": [0.0] * 3}
    bones: dict[str, dict] = {}
    order: list[str] = []
    children: dict[str, list[str]] = {}
    section = None
    bone = None
    limits_left = 0
    for ln, raw in enumerate(lines, start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if line.startswith(":"):
            head = line.split()
            section = head[0][1:].lower()
            if section in ("version", "name"):
                section = None
            continue
        tok = line.split()
        if section == "units":
            if tok[0] == "length":
                length_unit = _floats(path, tok[1:2], ln, "length unit", 1)[0]
            elif tok[0] == "angle":
                angle_unit = tok[1].lower()
                if angle_unit not in ("deg", "rad"):
                    raise MocapFormatError(path, f"unknown angle unit {tok[1]!r}", ln)
        elif section == "root":
            key = tok[0].lower()
            if key == "order":
                root["order"] = [t.upper() for t in tok[1:]]
            elif key == "axis":
                root["axis"] = tok[1].upper()
            elif key in ("position", "orientation"):
                root[key] = _floats(path, tok[1:4], ln, key, 3)
        elif section == "bonedata":
            key = tok[0].lower()
            if key == "begin":
                bone = {"line": ln, "dof": [], "limits": [], "axis": [0.0] * 3, "axis_order": "XYZ",
                        "direction": [0.0] * 3, "length": 0.0}
                limits_left = 0
            elif key == "end":
                if bone is None or "name" not in bone:
                    raise MocapFormatError(path, "bone without a name", ln)
                bones[bone["name"]] = bone
                order.append(bone["name"])
                bone = None
            elif bone is None:
                raise MocapFormatError(path, f"{tok[0]!r} outside a begin/end bone block", ln)
            elif key == "name":
                bone["name"] = tok[1]
            elif key == "direction":
                bone["direction"] = _floats(path, tok[1:4], ln, "direction", 3)
            elif key == "length":
                bone["length"] = _floats(path, tok[1:2], ln, "length", 1)[0]
            elif key == "axis":
                bone["axis"] = _floats(path, tok[1:4], ln, "axis", 3)
                bone["axis_order"] = tok[4].upper() if len(tok) > 4 else "XYZ"
            elif key == "dof":
                dofs = [t.lower() for t in tok[1:]]
                bad = [d for d in dofs if d not in _DOF]
                if bad:
                    raise MocapFormatError(path, f"unsupported dof {' '.join(bad)} (only rx ry rz tx ty tz)", ln)
                bone["dof"] = dofs
            elif key == "limits" or (limits_left and line.startswith("(")):
                text = line[len("limits"):] if key == "limits" else line
                for lo, hi in re.findall(r"\(\s*([^\s,()]+)\s*,?\s*([^\s,()]+)\s*\)", text):
                    bone["limits"].append((_lim(path, lo, ln), _lim(path, hi, ln)))
                limits_left = len(bone["dof"]) - len(bone["limits"])
            elif key == "id" or key == "bodymass" or key == "cofmass":
                pass
            elif line.startswith("("):
                for lo, hi in re.findall(r"\(\s*([^\s,()]+)\s*,?\s*([^\s,()]+)\s*\)", line):
                    bone["limits"].append((_lim(path, lo, ln), _lim(path, hi, ln)))
        elif section == "hierarchy":
            key = tok[0].lower()
            if key in ("begin", "end"):
                continue
            parent = tok[0]
            if parent != "root" and parent not in bones:
                raise MocapFormatError(path, f"hierarchy names unknown bone {parent!r}", ln)
            for c in tok[1:]:
                if c not in bones:
                    raise MocapFormatError(path, f"hierarchy names unknown bone {c!r}", ln)
                children.setdefault(parent, []).append(c)
    if not bones:
        raise MocapFormatError(path, "no :bonedata bones found")
    if "root" not in children:
        raise MocapFormatError(path, "no :hierarchy under root")
    to_deg = (lambda v: np.degrees(v)) if angle_unit == "rad" else (lambda v: np.asarray(v, dtype=float))

    names = ["root"]
    parents = [-1]
    offsets = [np.asarray(root["position"], dtype=float)]
    axes = [R.euler_to_quaternion(to_deg(root["orientation"]), root["axis"].lower())]
    rot_dofs = [d for d in root["order"] if d.startswith("R")]
    pos_dofs = [d for d in root["order"] if d.startswith("T")]
    channels = [tuple(_DOF[d.lower()] for d in pos_dofs) + tuple(_DOF[d.lower()] for d in reversed(rot_dofs))]
    limits = [tuple((-np.inf, np.inf) for _ in rot_dofs)]
    end_parents, end_offsets = [], []
    seen = set()

    def visit(bname: str, parent_index: int, offset):
        if bname in seen:
            raise MocapFormatError(path, f"bone {bname!r} appears twice in the hierarchy")
        seen.add(bname)
        b = bones[bname]
        j = len(names)
        names.append(bname)
        parents.append(parent_index)
        offsets.append(np.asarray(offset, dtype=float))
        axes.append(R.euler_to_quaternion(to_deg(b["axis"]), b["axis_order"].lower()))
        rd = [d for d in b["dof"] if d.startswith("r")]
        channels.append(tuple(_DOF[d] for d in reversed(rd)))
        lim = list(b["limits"])[: len(b["dof"])]
        lim = [l for d, l in zip(b["dof"], lim) if d.startswith("r")]
        if len(lim) < len(rd):
            lim += [(-np.inf, np.inf)] * (len(rd) - len(lim))
        limits.append(tuple(reversed(lim)))
        tip = np.asarray(b["direction"], dtype=float) * b["length"]
        kids = children.get(bname, [])
        if not kids:
            end_parents.append(j)
            end_offsets.append(tip)
        for c in kids:
            visit(c, j, tip)

    for c in children["root"]:
        visit(c, 0, np.zeros(3))
    axes_arr = np.array(axes)
    return Skeleton(
        joint_names=tuple(names),
        parents=np.array(parents),
        offsets=np.array(offsets),
        end_site_parents=np.array(end_parents, dtype=np.int64),
        end_site_offsets=np.array(end_offsets).reshape(-1, 3),
        channels=tuple(channels),
        axes=axes_arr,
        limits=tuple(limits),
        unit_cm=2.54 / length_unit if length_unit > 0 else None,
    )


def _lim(path, tok, ln) -> float:
    t = tok.lower()
    if t in ("inf", "+inf"):
        return np.inf
    if t == "-inf":
        return -np.inf
    try:
        return float(tok)
    except ValueError:
        raise MocapFormatError(path, f"non-numeric limit {tok!r}", ln) from None


def find_asf(amc: Path) -> Path:
    """The ASF for an AMC: the longest ASF stem that prefixes the AMC stem, else the only ASF beside it."""
    amc = Path(amc)
    asfs = sorted(p for p in amc.parent.iterdir() if p.suffix.lower() == ".asf")
    stem = amc.stem
    best = None
    for p in asfs:
        s = p.stem
        if stem.startswith(s) and (len(stem) == len(s) or not stem[len(s)].isalpha() or s[-1].isdigit() is False):
            if best is None or len(s) > len(best.stem):
                best = p
    if best is not None:
        return best
    if len(asfs) == 1:
        return asfs[0]
    prefix = stem.split("_")[0]
    raise MocapFormatError(
        amc,
        f"no skeleton: found no {prefix}.asf (or other ASF named by a prefix of {stem!r}) and "
        f"{len(asfs)} ASF files beside it; pass asf=",
    )


def _fps_from_name(stem: str) -> float | None:
    m = re.search(r"_(\d+)$", stem)
    if m and 24 <= int(m.group(1)) <= 1000:
        return float(m.group(1))
    return None


def read_amc(path, asf=None, fps: float | None = None) -> Motion:
    """Read an AMC motion with its ASF skeleton (``asf=``, else :func:`find_asf`).

    The frame rate is ``fps``, else the number ending the file name (HDM05
    ``..._120.amc``), else 120 Hz (CMU).
    """
    path = Path(path)
    asf_path = Path(asf) if asf is not None else find_asf(path)
    skeleton = read_asf(asf_path)
    lines = _lines(path)
    radians = False
    body_start = None
    for ln, raw in enumerate(lines):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith(":"):
            radians = radians or s.upper().startswith(":RADIANS")
            continue
        body_start = ln
        break
    if body_start is None:
        raise MocapFormatError(path, "no frames: the AMC holds only a header")
    names = skeleton.joint_names
    index = {n: i for i, n in enumerate(names)}
    ndof = {n: len(skeleton.joint_channels(i)) for n, i in index.items()}
    frames: list[dict[str, list[str]]] = []
    numbers: list[int] = []
    cur = None
    for ln in range(body_start, len(lines)):
        s = lines[ln].strip()
        if not s or s.startswith("#"):
            continue
        tok = s.split()
        if len(tok) == 1 and tok[0].lstrip("-").isdigit():
            n = int(tok[0])
            if numbers and n != numbers[-1] + 1:
                raise MocapFormatError(path, f"frame {n} follows frame {numbers[-1]}: frames must be consecutive", ln + 1)
            numbers.append(n)
            cur = {}
            frames.append(cur)
            continue
        if cur is None:
            raise MocapFormatError(path, f"expected a frame number, found {tok[0]!r}", ln + 1)
        name = tok[0]
        if name not in index:
            raise MocapFormatError(path, f"AMC names joint {name!r} that the ASF {asf_path.name} lacks", ln + 1)
        if len(tok) - 1 != ndof[name]:
            raise MocapFormatError(path, f"joint {name} needs {ndof[name]} values, got {len(tok) - 1}", ln + 1)
        cur[name] = (tok[1:], ln + 1)
    if not frames:
        raise MocapFormatError(path, "no frames")
    F = len(frames)
    expected = {n for n in names if ndof[n] > 0}
    last = frames[-1]
    if set(last) != set(frames[0]) and len(last) < len(frames[0]):
        raise MocapFormatError(path, f"truncated: the last frame {numbers[-1]} lists {len(last)} of {len(frames[0])} joints")
    cols = sum(ndof.values())
    values = np.zeros((F, cols))
    col0 = {}
    c = 0
    for n in names:
        col0[n] = c
        c += ndof[n]
    for f, fr in enumerate(frames):
        for n, (toks, ln) in fr.items():
            values[f, col0[n] : col0[n] + ndof[n]] = _floats(path, toks, ln, f"values of {n}")
    del expected
    # AMC lists dofs in dof order; channels are stored reversed (intrinsic) except root positions.
    reordered = values.copy()
    for j, n in enumerate(names):
        chans = skeleton.joint_channels(j)
        k = ndof[n]
        if k == 0:
            continue
        if j == 0:
            # root: AMC gives values in :root order; channels are positions then reversed rotations
            order = [d for d in _root_order(skeleton)]
            src = values[:, col0[n] : col0[n] + k]
            pos_idx = [i for i, d in enumerate(order) if d.startswith("T")]
            rot_idx = [i for i, d in enumerate(order) if d.startswith("R")]
            reordered[:, col0[n] : col0[n] + k] = src[:, pos_idx + rot_idx[::-1]]
        else:
            reordered[:, col0[n] : col0[n] + k] = values[:, col0[n] : col0[n] + k][:, ::-1]
        del chans
    if radians:
        rot_cols = np.array([ch.endswith("rotation") for j in range(len(names)) for ch in skeleton.joint_channels(j)])
        reordered[:, rot_cols] = np.degrees(reordered[:, rot_cols])
    rate = fps if fps is not None else (_fps_from_name(path.stem) or 120.0)
    return Motion.from_channel_values(skeleton, reordered, rate, name=path.stem)


def _root_order(skeleton: Skeleton) -> list[str]:
    chans = skeleton.joint_channels(0)
    pos = [c for c in chans if c.endswith("position")]
    rot = [c for c in chans if c.endswith("rotation")][::-1]
    return ["T" + c[0] for c in pos] + ["R" + c[0] for c in rot]
