"""Acclaim ASF/AMC, the native format of the CMU and HDM05 databases.

The ASF describes *bones*; mocapkit's skeleton is joint based with BVH
semantics, so the ASF is converted on reading:

* joint 0 is ``root``; then one joint per bone, named as the bone, in
  depth-first order of the ``:hierarchy`` (children in the order listed);
* the joint of bone ``b`` sits at the *start* of ``b`` (the end of its parent
  bone): its offset is the parent bone's ``direction * length``, and for the
  children of the root the root ``position`` (normally zero);
* every leaf bone gets an end site at its tip, ``direction * length`` from its
  joint;
* the bone's ``axis`` frame ``C`` goes to ``Skeleton.axes`` (the root's from
  ``:root orientation`` in the ``:root axis`` order), so the local rotation is
  ``C @ M @ C^-1`` with ``M`` built from the AMC degrees of freedom applied in
  dof order. ASF angles are *extrinsic*: ``dof rx ry rz`` and ``axis ... XYZ``
  mean ``Rz @ Ry @ Rx``;
* ``Skeleton.channels`` are BVH style, rotations in *intrinsic* order, which is
  the dof order reversed (``dof rx ry rz`` -> ``Zrotation Yrotation
  Xrotation``); the root has its position channels first. ``Skeleton.limits``
  follow the channels (so are reversed too), in degrees;
* lengths stay in ASF units; ``Skeleton.unit_cm = 2.54 / length`` from
  ``:units length`` (CMU and HDM05's 0.45 gives 5.644 cm per unit).

The AMC root line's translations become ``Motion.root_positions`` (ASF units).

Reading is vectorised and chunked: the AMC body is cut into pieces of about
1 MiB of whole lines; in each, numpy finds the bone name starting each line,
the names are blanked and every number is parsed in one pass
(:func:`mocapkit.io._numparse.parse_floats`); the frame structure is checked on
arrays (a frame straddling two pieces is carried over), and Euler angles
become quaternions per group of joints sharing a dof order. Memory stays a
small multiple of the file (the text, the value tables, the motion).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import rotations as R
from ..errors import MocapFormatError, SkeletonError
from ..motion import MAX_JOINTS, Motion, Skeleton, channel_starts, check_fps
from ..words import plural
from .sources import bom_length, remember

__all__ = ["read_asf", "read_amc", "read_amc_numbers", "amc_table_arrays", "asf_dofs", "amc_dofs", "amc_held_rotations",
           "amc_header", "find_asf", "pick_asf", "fps_from_name", "amc_rate", "stated_fps", "rate_comment", "with_rate",
           "amc_comment_lines", "DEFAULT_FPS"]

DEFAULT_FPS = 120.0
"""Frame rate of an AMC that states none, its name gives none and no ``fps=`` is given: the rate the CMU and
HDM05 databases were captured at (120 Hz). An AMC has no field for its rate."""

_RATE_LINE = re.compile(rb"^#\s*frame rate:\s*(\d+(?:\.\d*)?(?:[eE][+-]?\d+)?)\s*fps\b", re.IGNORECASE)
_HDM05_NAME = re.compile(r"^HDM_[A-Za-z]{2}_.+_(\d+)$")

_ROT_CHANNEL = {"x": "Xrotation", "y": "Yrotation", "z": "Zrotation"}
_POS_CHANNEL = {"x": "Xposition", "y": "Yposition", "z": "Zposition"}
_LIMIT_PAIR = re.compile(r"\(\s*([^\s,()]+)\s*,?\s*([^\s,()]+)\s*\)")


@dataclass(frozen=True)
class _Layout:
    """How the AMC lists each joint's numbers.

    ``dofs[j]`` is the joint's dof tokens in AMC order, each ``"rx"`` ... ``"tz"``
    (lower case); only the root may have translations.
    """

    dofs: tuple[tuple[str, ...], ...]
    radians: bool


# -- ASF -----------------------------------------------------------------------------


def _read_text(path: Path) -> str:
    try:
        data = path.read_bytes()
        return data[bom_length(data):].decode("latin-1")  # a byte-order mark is not text
    except OSError as exc:
        raise MocapFormatError(path, f"cannot read: {exc.strerror or exc}") from None


def _numbers(path: Path, tokens: list[str], line: int, what: str, n: int | None = None,
             finite: bool = True) -> list[float]:
    try:
        vals = [float(t) for t in tokens]
    except ValueError:
        raise MocapFormatError(path, f"{what}: non-numeric value in {' '.join(tokens)!r}", line) from None
    if n is not None and len(vals) != n:
        raise MocapFormatError(path, f"{what}: expected {plural(n, 'number')}, got {len(vals)}", line)
    if finite and not all(np.isfinite(v) for v in vals):
        raise MocapFormatError(path, f"{what}: values must be finite, got {' '.join(tokens)!r}", line)
    return vals


def _axis_order(path: Path, token: str, line: int, what: str) -> str:
    low = token.lower()
    if len(low) != 3 or sorted(low) != ["x", "y", "z"]:
        raise MocapFormatError(path, f"{what}: axis order must be a permutation of XYZ, got {token!r}", line)
    return low


def _parse_asf(path: Path) -> tuple[Skeleton, _Layout]:
    """Parse an ASF file into a Skeleton and the AMC column layout of its joints."""
    text = _read_text(path)
    length_unit: float | None = None
    radians = False
    root_order: list[str] = ["tx", "ty", "tz", "rx", "ry", "rz"]
    root_axis = "xyz"
    root_position = [0.0, 0.0, 0.0]
    root_orientation = [0.0, 0.0, 0.0]
    bones: dict[str, dict] = {}
    children: dict[str, list[str]] = {}
    section = None
    bone: dict | None = None
    in_limits = False
    for ln, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        tok = line.split()
        if line.startswith(":"):
            section = tok[0][1:].lower()
            in_limits = False
            if section == "bonedata" or section == "hierarchy":
                bone = None
            continue
        key = tok[0].lower()
        if section == "units":
            if key == "length":
                length_unit = _numbers(path, tok[1:], ln, "units length", 1)[0]
                if not (length_unit > 0 and np.isfinite(2.54 / length_unit)):
                    raise MocapFormatError(path, f"units length must be a positive number, got {tok[1]}", ln)
            elif key == "angle":
                unit = tok[1].lower() if len(tok) > 1 else ""
                if unit not in ("deg", "rad"):
                    raise MocapFormatError(path, f"units angle must be deg or rad, got {unit or '(none)'!r}", ln)
                radians = unit == "rad"
            elif key == "mass":
                _numbers(path, tok[1:], ln, "units mass", 1)
        elif section == "root":
            if key == "order":
                root_order = [t.lower() for t in tok[1:]]
                bad = [t for t in root_order if t not in ("tx", "ty", "tz", "rx", "ry", "rz")]
                if bad or len(set(root_order)) != len(root_order):
                    got = " ".join(tok[1:])
                    raise MocapFormatError(path, f"root order must list distinct TX TY TZ RX RY RZ, got {got!r}", ln)
            elif key == "axis":
                if len(tok) != 2:
                    raise MocapFormatError(path, "root axis needs one order like XYZ", ln)
                root_axis = _axis_order(path, tok[1], ln, "root axis")
            elif key == "position":
                root_position = _numbers(path, tok[1:], ln, "root position", 3)
            elif key == "orientation":
                root_orientation = _numbers(path, tok[1:], ln, "root orientation", 3)
        elif section == "bonedata":
            if key == "begin":
                if bone is not None:
                    raise MocapFormatError(path, "begin inside a bone block (missing end)", ln)
                if len(bones) + 1 >= MAX_JOINTS:  # the root is a joint too
                    raise MocapFormatError(path, f"more than {MAX_JOINTS - 1:,} bones: not a skeleton mocapkit reads", ln)
                bone = {"line": ln, "dof": [], "limits": [], "axis": [0.0, 0.0, 0.0], "axis_order": "xyz",
                        "direction": None, "length": None}
                in_limits = False
                continue
            if bone is None:
                raise MocapFormatError(path, f"{tok[0]!r} outside a begin/end bone block", ln)
            if key == "end":
                _finish_bone(path, bone, bones, ln)
                bone = None
                in_limits = False
                continue
            if line.startswith("(") and in_limits:
                bone["limits"].extend(_limit_pairs(path, line, ln))
                continue
            in_limits = False
            if key == "name":
                if len(tok) != 2:
                    raise MocapFormatError(path, "bone name must be one word", ln)
                bone["name"] = tok[1]
            elif key == "direction":
                bone["direction"] = _numbers(path, tok[1:], ln, "direction", 3)
            elif key == "length":
                bone["length"] = _numbers(path, tok[1:], ln, "length", 1)[0]
            elif key == "axis":
                if len(tok) != 5:
                    raise MocapFormatError(path, "axis needs three angles and an order like XYZ", ln)
                bone["axis"] = _numbers(path, tok[1:4], ln, "axis", 3)
                bone["axis_order"] = _axis_order(path, tok[4], ln, "axis")
            elif key == "dof":
                dofs = [t.lower() for t in tok[1:]]
                for d in dofs:
                    if d == "l":
                        raise MocapFormatError(path, "dof l (animated bone length) is not supported", ln)
                    if d in ("tx", "ty", "tz"):
                        raise MocapFormatError(
                            path, f"dof {d} on a bone (animated bone translation) is not supported", ln
                        )
                    if d not in ("rx", "ry", "rz"):
                        raise MocapFormatError(path, f"unknown dof {d!r}; expected rx ry rz", ln)
                if len(set(dofs)) != len(dofs):
                    raise MocapFormatError(path, f"dof repeats an axis: {' '.join(tok[1:])}", ln)
                bone["dof"] = dofs
            elif key == "limits":
                bone["limits"] = _limit_pairs(path, line[len(tok[0]):], ln)
                in_limits = True
            # id, bodymass, cofmass and other per-bone extras carry nothing we use
        elif section == "hierarchy":
            if key in ("begin", "end"):
                continue
            parent = tok[0]
            if parent != "root" and parent not in bones:
                raise MocapFormatError(path, f"hierarchy names bone {parent!r} that :bonedata lacks", ln)
            for c in tok[1:]:
                if c not in bones:
                    raise MocapFormatError(path, f"hierarchy names bone {c!r} that :bonedata lacks", ln)
                children.setdefault(parent, []).append(c)
        # :version, :name, :documentation and unknown sections are skipped
    if bone is not None:
        raise MocapFormatError(path, f"bone block opened at line {bone['line']} is never closed")
    if not bones:
        raise MocapFormatError(path, "no bones: the ASF has no :bonedata blocks")
    if "root" not in children:
        raise MocapFormatError(path, "no bone hangs from root in :hierarchy")

    def deg(v):
        return np.degrees(np.asarray(v, dtype=np.float64)) if radians else np.asarray(v, dtype=np.float64)

    root_rot = [d[1] for d in root_order if d[0] == "r"]
    root_pos = [d[1] for d in root_order if d[0] == "t"]
    names = ["root"]
    parents = [-1]
    offsets = [np.zeros(3)]
    with np.errstate(over="ignore", invalid="ignore"):
        axes = [R.euler_to_quaternion(deg(root_orientation), root_axis)]
    if not np.all(np.isfinite(axes[0])):
        raise MocapFormatError(path, f"root orientation {root_orientation} gives no finite rotation")
    channels = [tuple(_POS_CHANNEL[a] for a in root_pos) + tuple(_ROT_CHANNEL[a] for a in reversed(root_rot))]
    limits = [tuple((-np.inf, np.inf) for _ in root_rot)]
    dofs = [tuple(root_order)]
    end_parents: list[int] = []
    end_offsets: list[np.ndarray] = []
    placed: set[str] = set()
    # Iterative depth-first walk (children in listed order); each entry is (bone, parent joint, offset).
    stack = [(c, 0, np.asarray(root_position, dtype=np.float64)) for c in reversed(children["root"])]
    while stack:
        name, parent, offset = stack.pop()
        if name in placed:
            raise MocapFormatError(path, f"bone {name!r} appears twice in :hierarchy")
        placed.add(name)
        b = bones[name]
        j = len(names)
        names.append(name)
        parents.append(parent)
        offsets.append(offset)
        with np.errstate(over="ignore", invalid="ignore"):
            axes.append(R.euler_to_quaternion(deg(b["axis"]), b["axis_order"]))
        axes_of_dof = [d[1] for d in b["dof"]]
        channels.append(tuple(_ROT_CHANNEL[a] for a in reversed(axes_of_dof)))
        lim = b["limits"] or [(-np.inf, np.inf)] * len(axes_of_dof)
        if radians:
            with np.errstate(over="ignore"):
                lim = [(float(np.degrees(lo)), float(np.degrees(hi))) for lo, hi in lim]
        limits.append(tuple(reversed(lim)))
        dofs.append(tuple(b["dof"]))
        with np.errstate(over="ignore", invalid="ignore"):
            tip = np.asarray(b["direction"], dtype=np.float64) * b["length"]
            axis_q = axes[-1]
        if not np.all(np.isfinite(tip)):
            raise MocapFormatError(path, f"bone {name!r}: direction * length is not finite", b["line"])
        if not np.all(np.isfinite(axis_q)):
            raise MocapFormatError(path, f"bone {name!r}: axis angles {b['axis']} give no finite rotation", b["line"])
        kids = children.get(name, [])
        if not kids:
            end_parents.append(j)
            end_offsets.append(tip)
        stack.extend((c, j, tip) for c in reversed(kids))
    unplaced = [n for n in bones if n not in placed]
    if unplaced:
        raise MocapFormatError(path, f"bones not reachable from root in :hierarchy: {', '.join(unplaced)}")
    skeleton = Skeleton(
        joint_names=tuple(names),
        parents=np.array(parents, dtype=np.int64),
        offsets=np.array(offsets),
        end_site_parents=np.array(end_parents, dtype=np.int64),
        end_site_offsets=np.array(end_offsets).reshape(-1, 3),
        channels=tuple(channels),
        axes=np.array(axes),
        limits=tuple(limits),
        unit_cm=None if length_unit is None else 2.54 / length_unit,
        source_file=path,
    )
    return skeleton, _Layout(dofs=tuple(dofs), radians=radians)


def _limit_pairs(path: Path, text: str, line: int) -> list[tuple[float, float]]:
    pairs = _LIMIT_PAIR.findall(text)
    rest = _LIMIT_PAIR.sub("", text).strip()
    if rest or not pairs:
        raise MocapFormatError(path, f"limits must be pairs like (-10.0 170.0), got {text.strip()!r}", line)
    out = []
    for lo, hi in pairs:
        a, b = _numbers(path, [lo, hi], line, "limits", 2, finite=False)  # (-inf inf) is common
        out.append((a, b))
    return out


def _finish_bone(path: Path, bone: dict, bones: dict, line: int) -> None:
    where = f"bone block opened at line {bone['line']}"
    if "name" not in bone:
        raise MocapFormatError(path, f"{where} has no name", line)
    name = bone["name"]
    if name == "root" or name in bones:
        raise MocapFormatError(path, f"bone name {name!r} is used twice", line)
    if bone["direction"] is None or bone["length"] is None:
        raise MocapFormatError(path, f"bone {name!r} needs a direction and a length", line)
    if bone["limits"] and len(bone["limits"]) != len(bone["dof"]):
        raise MocapFormatError(
            path, f"bone {name!r} has {len(bone['limits'])} limits for {len(bone['dof'])} dofs", line
        )
    bones[name] = bone


def read_asf(path) -> Skeleton:
    """Read an ASF skeleton as a joint-based :class:`~mocapkit.motion.Skeleton`.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.asf`` file (ASCII or Latin-1, LF or CRLF line ends).

    Returns
    -------
    Skeleton
        ``root`` plus one joint per bone in depth-first hierarchy order; offsets
        (J, 3) and end-site offsets (E, 3) in ASF length units; ``axes`` (J, 4)
        the bones' axis frames as w-first quaternions; ``channels`` and
        ``limits`` (degrees) in BVH intrinsic order (the dof order reversed);
        ``unit_cm`` from ``:units length`` (None if the file gives none).

    Raises
    ------
    MocapFormatError
        Malformed or unsupported content (e.g. the ``l`` length dof), with the line.
    """
    return _parse_asf(Path(path))[0]


def asf_dofs(path) -> tuple[tuple[str, ...], ...]:
    """Each joint's AMC numbers in the order the ASF lists them (``"tx"`` ... ``"rz"``; the root's ``order`` as written).

    The skeleton keeps the root's translations before its rotations whatever
    the ASF's ``:root order``; an AMC line follows the ASF, which this gives.
    """
    return _parse_asf(Path(path))[1].dofs


def amc_dofs(skeleton: Skeleton) -> tuple[tuple[str, ...], ...]:
    """Each joint's AMC numbers of a skeleton given directly: ``("tx", ..., "rz", ...)``, root translations first.

    Derived from the skeleton's BVH-style channels, whose rotations are the
    ASF dof order reversed (module docstring); :func:`asf_dofs` gives an
    ASF's own order.
    """
    dofs = []
    for j in range(skeleton.num_joints):
        chans = skeleton.joint_channels(j)
        pos = ["t" + c[0].lower() for c in chans if c.endswith("position")]
        rot = ["r" + c[0].lower() for c in chans if c.endswith("rotation")][::-1]
        dofs.append(tuple(pos + rot))
    return tuple(dofs)


def amc_held_rotations(motion: Motion, dofs=None, joints=None) -> np.ndarray:
    """The local rotations (F, J, 4) an AMC written for ``motion`` reads back as: each bone's rotation on its dofs.

    An ASF bone with fewer than three rotation dofs cannot hold every rotation: the AMC writer
    (:mod:`mocapkit.io.amc_writer`) writes the bone's dof angles and drops the rest, and the file reads
    back as the rotation those angles make. This is that rotation, made the writer's way and read
    back the reader's way without a file (so without the text's rounding to its decimals): what a
    cleaning written as AMC measures and records its changes with. ``dofs``: the AMC layout the
    writer uses (default :func:`amc_dofs`). ``joints``: only these bones are converted, to the same numbers
    (a check of the 18 bones of fewer dofs of HDM05's 29 turning ones: 0.25 -> 0.16 s on 9,760 frames); the
    others, joints without rotation dofs and cells with a missing (NaN) value are returned as given.
    ``motion.skeleton`` must come from an ASF (``axes`` set).
    """
    import dataclasses

    from .amc_writer import dof_values

    sk = motion.skeleton
    if sk.axes is None:
        raise ValueError("an AMC holds the rotations of a skeleton read from an ASF; this one has no ASF axes")
    dofs = amc_dofs(sk) if dofs is None else tuple(tuple(d) for d in dofs)
    if joints is not None:  # the others without dofs: neither written nor read back
        dofs = tuple(d if j in set(map(int, joints)) else () for j, d in enumerate(dofs))
    rot = np.asarray(motion.rotations, dtype=np.float64)
    turning = [j for j, jd in enumerate(dofs) if any(d[0] == "r" for d in jd)]  # whole columns: no (F, J) mask
    seen = np.isfinite(rot[:, turning]).all(axis=-1)
    safe = np.array(rot)  # a NaN would run through the writer's unwrapping
    safe[:, turning] = np.where(seen[..., None], rot[:, turning], R.identity())
    values = dof_values(dataclasses.replace(motion, rotations=safe, root_positions=np.zeros((len(rot), 3))), dofs,
                        radians=False)
    out = np.array(rot)
    cols = [v for v in values if v is not None]
    if not cols:
        return out
    held, _ = _to_motion_arrays(np.concatenate(cols, axis=1), sk, _Layout(dofs, False), radians=False)
    out[:, turning] = np.where(seen[..., None], held[:, turning], rot[:, turning])
    return out


# -- finding the skeleton, the frame rate -----------------------------------------------


def _at_boundary(stem: str, k: int) -> bool:
    """True when ``stem[:k]`` ends a word of ``stem``: at its end, before a separator, or at a letter/digit switch."""
    if k == len(stem):
        return True
    a, b = stem[k - 1], stem[k]
    if not b.isalnum():
        return True
    return a.isalpha() != b.isalpha()


def find_asf(amc) -> Path:
    """The ASF skeleton file for an AMC motion file in the same folder.

    The ASF whose stem is the longest prefix of the AMC's stem ending at a word
    boundary (compared ignoring case): ``07_01.amc`` -> ``07.asf``,
    ``HDM_bd_kick_001_120.amc`` -> ``HDM_bd.asf``, ``charleston1.amc`` ->
    ``charleston.asf``. Failing that, the only ASF in the folder.

    Raises
    ------
    MocapFormatError
        No such ASF, naming the file looked for.
    """
    amc = Path(amc)
    folder = amc.parent
    try:
        asfs = sorted(p for p in folder.iterdir() if p.suffix.lower() == ".asf" and p.is_file())
    except OSError as exc:
        raise MocapFormatError(amc, f"cannot list {folder} to find its ASF: {exc.strerror or exc}") from None
    best = pick_asf(amc.name, asfs)
    if best is not None:
        return best
    first = next((k for k in range(1, len(amc.stem) + 1) if _at_boundary(amc.stem, k)), len(amc.stem))
    wanted = folder / f"{amc.stem[:first]}.asf"
    found = plural(len(asfs), "other ASF file") if asfs else "no ASF files"
    raise MocapFormatError(
        amc,
        f"no skeleton: looked for {wanted} (or another ASF named by a prefix of {amc.stem!r}) "
        f"and found {found} there; name the skeleton with --asf FILE (command line) or asf=FILE (Python)",
    )


def pick_asf(amc_name: str, asfs, only_one: bool = True):
    """The ASF of ``asfs`` (paths in one folder) that :func:`find_asf` gives the AMC named ``amc_name``; None if none.

    The rule alone, on any list (one that does not exist yet included): the longest stem that is a prefix
    of the AMC's at a word boundary, ignoring case; else (``only_one``) the only ASF.
    """
    stem = Path(amc_name).stem.lower()
    best = None
    for p in asfs:
        s = Path(p).stem.lower()
        if s and stem.startswith(s) and _at_boundary(stem, len(s)):
            if best is None or len(s) > len(Path(best).stem):
                best = p
    if best is not None:
        return best
    return asfs[0] if only_one and len(asfs) == 1 else None


def fps_from_name(stem: str) -> float | None:
    """Frame rate an HDM05 file stem ends with (``HDM_bd_kick_001_120``: 120), if plausible (24 Hz up); else None.

    Only HDM05's naming (``HDM_`` + the actor's two letters + ``_`` ... ``_RATE``) gives a rate: a number
    ending any other name is no rate (CMU numbers its trials ``SUBJECT_TRIAL``, so ``86_30`` is trial 30).
    """
    from ..motion import FPS_RANGE

    m = _HDM05_NAME.match(stem)
    if m is None:
        return None
    rate = int(m.group(1))
    return float(rate) if 24 <= rate <= FPS_RANGE[1] else None


def stated_fps(data: bytes) -> float | None:
    """The frame rate an AMC's header states in mocapkit's comment line (:func:`rate_comment`), or None.

    ``data``: the file's bytes (its header at least). Only the comment lines before the first frame are read;
    other programs skip them (``#`` starts an Acclaim comment).
    """
    body_at = amc_header(data)[0]
    for line in data[bom_length(data):body_at].splitlines():
        m = _RATE_LINE.match(line.strip())
        if m is not None:
            return float(m.group(1))
    return None


def amc_rate(path, fps: float | None = None, data: bytes | None = None) -> tuple[float, str]:
    """The frame rate an AMC at ``path`` is read at (frames per second) and where it comes from.

    In this order: ``fps`` when given (``"given"``); the rate the file states in mocapkit's comment line
    (``"file"``, :func:`stated_fps`); the rate an HDM05 name ends with (``"name"``, :func:`fps_from_name`);
    else :data:`DEFAULT_FPS` (``"default"``). ``data``: the file's bytes when already read (else its first
    MiB is read: the header). The rate is not checked here (:func:`read_amc` does).
    """
    path = Path(path)
    if fps is not None:
        return float(fps), "given"
    if data is None:
        try:
            with open(path, "rb") as fh:
                data = fh.read(1 << 20)
        except OSError as exc:
            raise MocapFormatError(path, f"cannot read: {exc.strerror or exc}") from None
    stated = stated_fps(data)
    if stated is not None:
        return stated, "file"
    named = fps_from_name(path.stem)
    if named is not None:
        return named, "name"
    return DEFAULT_FPS, "default"


def amc_comment_lines(data: bytes) -> int:
    """How many lines of an AMC's text ``data`` hold a comment (``#`` to the line's end, an Acclaim comment: the
    ``#!OML:ASF`` line CMU and HDM05 files start with, a frame line's trailing note), mocapkit's rate line
    (:func:`rate_comment`) not counted: a writer states the rate of the take it writes."""
    return sum(b"#" in line and _RATE_LINE.match(line.strip()) is None
               for line in data[bom_length(data):].splitlines())


def rate_comment(fps: float) -> str:
    """mocapkit's AMC comment line stating the frame rate (no line ending): ``# frame rate: 60 fps (mocapkit)``.

    Written exactly (``repr`` of the float, so 30000/1001 reads back bit for bit); ``#`` starts an Acclaim
    comment, so other AMC readers skip it.
    """
    text = repr(float(fps))
    return f"# frame rate: {text[:-2] if text.endswith('.0') else text} fps (mocapkit)"


def with_rate(header: str, fps: float, path) -> str:
    """An AMC header (the text before the first frame) that makes the file at ``path`` read at ``fps``.

    ``header`` itself when the file would be read at ``fps`` already (:func:`amc_rate` of its stated rate, the
    name's, or the default 120) and, for a file stating none, ``fps`` is the default 120 too (so a renamed copy
    keeps it); else ``header`` with mocapkit's rate line (:func:`rate_comment`) first and any earlier one removed
    (only removed at 120 fps): a 120 fps AMC is written as before, byte for byte. A byte-order mark the header
    starts with (:data:`~mocapkit.io.sources.BOM`, as latin-1 text) stays first.
    """
    mark = header[:bom_length(header.encode("latin-1", "replace"))]
    if mark:
        return mark + with_rate(header[len(mark):], fps, path)
    data = header.encode("latin-1", "replace")
    stated = stated_fps(data)
    named = fps_from_name(Path(path).stem)
    if stated == float(fps) or (stated is None and float(fps) == DEFAULT_FPS and named in (None, DEFAULT_FPS)):
        return header
    ending = "\r\n" if "\r\n" in header else "\n"
    kept = "".join(line for line in header.splitlines(keepends=True)
                   if _RATE_LINE.match(line.strip().encode("latin-1", "replace")) is None)
    if float(fps) == DEFAULT_FPS and named in (None, DEFAULT_FPS):
        return kept  # 120 fps needs no line: the stale one goes
    return rate_comment(fps) + ending + kept


# -- AMC -------------------------------------------------------------------------------


def amc_header(data: bytes) -> tuple[int, int, bool | None]:
    """(byte offset of the body, its 1-based first line, radians flag or None if unstated); a byte-order mark
    before the first line (:func:`~mocapkit.io.sources.bom_length`) is skipped, and counted in the offset."""
    pos = bom_length(data)
    line = 1
    radians = None
    n = len(data)
    while pos < n:
        end = data.find(b"\n", pos)
        end = n if end < 0 else end
        s = data[pos:end].strip()
        if s and not s.startswith(b"#"):
            if not s.startswith(b":"):
                return pos, line, radians
            word = s.split()[0].upper()
            if word == b":RADIANS":
                radians = True
            elif word == b":DEGREES":
                radians = False
        pos = end + 1
        line += 1
    return n, line, radians


def read_amc(path, asf=None, fps: float | None = None, dofs=None) -> Motion:
    """Read an AMC motion with its ASF skeleton.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.amc`` file: ``:FULLY-SPECIFIED``, ``:DEGREES`` or ``:RADIANS``,
        then per frame a frame-number line and one line per bone,
        ``name v1 v2 ...`` in the bone's dof order.
    asf : str, os.PathLike or Skeleton, optional
        The skeleton; by default :func:`find_asf` looks beside the AMC. A
        Skeleton given directly must have ASF channels (e.g. from
        :func:`read_asf`); its root line is read as positions then rotations.
    fps : float, optional
        Frame rate; by default the one the file states in mocapkit's comment line, else the one an HDM05
        name ends with, else 120 (:func:`amc_rate`).
    dofs : tuple, optional
        With a Skeleton given as ``asf``: each joint's numbers in file order
        (:func:`asf_dofs` of its ASF), where the root's ``order`` puts
        rotations before translations.

    Returns
    -------
    Motion
        ``rotations`` (F, J, 4) local quaternions (``C @ M @ C^-1``; bones the
        frame omits get the identity), ``root_positions`` (F, 3) in ASF length
        units, ``name`` the file stem.

    Raises
    ------
    MocapFormatError
        With the AMC's path and line: unknown bone, wrong count of values,
        non-numeric value, no frames, frame numbers not consecutive, bone
        listed twice in a frame, last frame truncated; or no ASF found.
    """
    return _read_amc(path, asf, fps, dofs)[0]


def read_amc_numbers(path, asf=None, fps: float | None = None, dofs=None, data: bytes | None = None):
    """:func:`read_amc`'s Motion and the file's numbers as written, (F, columns): each joint's dofs in file order
    joint after joint (degrees or radians as the file says; 0 for a bone a frame does not list). The AMC writer
    (:func:`mocapkit.io.amc_writer.write_amc`) reads them to keep a changed bone on the file's branches, from
    ``data``, the file's bytes as the take was read (:func:`mocapkit.io.sources.recall`)."""
    return _read_amc(path, asf, fps, dofs, keep_numbers=True, data=data)


def amc_table_arrays(table: np.ndarray, skeleton: Skeleton, dofs, radians: bool = False):
    """Rotations (F, J, 4) and root positions (F, 3) from AMC numbers ``table`` (F, columns; each joint's ``dofs``
    in order, joint after joint, angles in degrees or ``radians``), computed as :func:`read_amc` computes them, so
    numbers a file holds give bit for bit the take read from it."""
    return _to_motion_arrays(np.asarray(table, dtype=np.float64), skeleton,
                             _Layout(tuple(tuple(d) for d in dofs), bool(radians)), radians=bool(radians))


def _read_amc(path, asf=None, fps: float | None = None, dofs=None, keep_numbers: bool = False,
              data: bytes | None = None):
    """:func:`read_amc`'s Motion and, with ``keep_numbers``, the file's numbers as written: (F, columns), each
    joint's dofs in file order joint after joint (degrees or radians as the file says; 0 for a bone a frame does
    not list), which :func:`mocapkit.io.amc_writer.write_amc` needs to stay on the file's branches; else None."""
    path = Path(path)
    if isinstance(asf, Skeleton):
        order = amc_dofs(asf) if dofs is None else tuple(tuple(d) for d in dofs)
        skeleton, layout, asf_name = asf, _Layout(dofs=order, radians=False), "skeleton"
    else:
        asf_path = Path(asf) if asf is not None else find_asf(path)
        if not asf_path.is_file():
            raise MocapFormatError(asf_path, "no such ASF file")
        skeleton, layout = _parse_asf(asf_path)
        asf_name = asf_path.name
    if data is None:
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise MocapFormatError(path, f"cannot read: {exc.strerror or exc}") from None
        remember(path, data)  # the text the AMC writer keeps (mocapkit.io.sources)
    body_at, first_line, radians = amc_header(data)
    if radians is None:
        radians = layout.radians
    tables = _parse_amc_body(path, data, body_at, first_line, skeleton, layout, asf_name)
    header = data[:body_at]
    del data  # the text is no longer needed: free it before the rotations are made
    F = sum(t.shape[0] for t in tables)
    numbers = np.concatenate(tables, axis=0) if keep_numbers else None
    rotations = np.empty((F, skeleton.num_joints, 4))
    root = np.empty((F, 3))
    r0 = 0
    while tables:  # chunk by chunk, each table freed once converted
        t = tables.pop(0)
        rotations[r0 : r0 + t.shape[0]], root[r0 : r0 + t.shape[0]] = _to_motion_arrays(t, skeleton, layout, radians)
        r0 += t.shape[0]
        del t
    try:
        rate = check_fps(amc_rate(path, fps, data=header)[0])
    except SkeletonError as exc:
        raise MocapFormatError(path, f"frame rate: {exc}") from None
    return Motion(skeleton=skeleton, rotations=rotations, root_positions=root, fps=rate, name=path.stem,
                  source_file=path), numbers


_CHUNK_BYTES = 1 << 20
"""The AMC body is parsed in pieces of about this many bytes (whole lines), so that the
vectorised parser's temporaries (about 20 bytes per byte of text) stay a few tens of MB
whatever the file's size; frames may straddle pieces."""

_MAX_LINE_BYTES = 1 << 20
"""An AMC line holds a bone name and a few numbers; a longer line is refused, not parsed
(with chunks of at least this size such a line always spans a chunk's cut, where it is measured)."""


@dataclass
class _Frames:
    """What the chunks have found so far: finished tables and the frame still open at a chunk's end."""

    tables: list  # (F_c, columns) arrays, one per chunk that starts frames
    count: int = 0  # frames started so far
    last_number: float = 0.0  # frame number of the open (last) frame
    open_seen: np.ndarray | None = None  # (J,) joints listed so far in the open frame
    open_joints: int = 0  # joints with values listed so far in the open frame
    most_joints: int = 0  # most joints with values in any finished frame


def _parse_amc_body(path, data: bytes, body_at: int, first_line: int, skeleton: Skeleton, layout: _Layout,
                    asf_name: str) -> list[np.ndarray]:
    """Parse and check the frames chunk by chunk; returns the (F_c, columns) value tables in frame order.

    Each chunk is whole lines of about :data:`_CHUNK_BYTES`; a frame that
    straddles chunks is continued (its joints, duplicates and values carried
    over), so memory is the tables plus one chunk's temporaries.
    """
    n = len(data)
    J = skeleton.num_joints
    ndof = np.array([len(d) for d in layout.dofs], dtype=np.int64)
    col0 = channel_starts(layout.dofs)
    state = _Frames(tables=[], open_seen=np.zeros(J, dtype=bool))
    pos, line = body_at, first_line
    any_line = False
    while pos < n:
        cut = min(pos + _CHUNK_BYTES, n - 1)
        end = data.find(b"\n", cut)
        end = n if end < 0 else end + 1
        # A line longer than the chunk size always spans the cut: that is the one line to measure.
        cut_line_at = data.rfind(b"\n", pos, cut) + 1 or pos
        if end - cut_line_at > _MAX_LINE_BYTES:
            raise MocapFormatError(path, f"line longer than {_MAX_LINE_BYTES:,} bytes: not an AMC frame or bone line",
                                   line + data.count(b"\n", pos, cut_line_at))
        any_line = True
        chunk = data[pos:end]
        if b"#" in chunk:
            chunk = re.sub(rb"#[^\n]*", b"", chunk)
        _parse_chunk(path, chunk, line, skeleton, layout, asf_name, ndof, col0, state)
        line += chunk.count(b"\n")
        pos = end
    if not any_line:
        raise MocapFormatError(path, "no frames: the file holds a header only")
    if state.count == 0:
        raise MocapFormatError(path, "no frames: no frame-number line after the header")
    last, most = state.open_joints, max(state.most_joints, state.open_joints)
    if last < most or last == 0:
        last_line = line - (1 if data.endswith(b"\n") else 0)
        raise MocapFormatError(
            path, f"truncated: the last frame ({state.last_number:.0f}) lists {last} of {most} joints", last_line
        )
    return state.tables


def _parse_chunk(path, body: bytes, first_line: int, skeleton: Skeleton, layout: _Layout, asf_name: str,
                 ndof: np.ndarray, col0: np.ndarray, state: _Frames) -> None:
    """Parse whole lines ``body`` (1-based first line ``first_line``), check them and add their frames to ``state``."""
    from ._numparse import line_of_offset, parse_floats

    arr = np.frombuffer(body, dtype=np.uint8)
    n = arr.shape[0]
    newlines = np.flatnonzero(arr == 10)
    n_lines = newlines.shape[0] + (1 if n and arr[-1] != 10 else 0)
    if n_lines == 0:
        return
    line_starts = np.concatenate([[0], newlines + 1])[:n_lines]
    line_ends = np.concatenate([newlines, [n]])[:n_lines]
    del newlines

    def where(k: int) -> int:  # 1-based file line of chunk line k
        return first_line + int(k)

    # The first token of every line: a bone name starts with anything but a digit, sign or point.
    solid = arr > 32
    tok_start = np.flatnonzero(solid & ~np.concatenate([[False], solid[:-1]]))
    k = np.searchsorted(tok_start, line_starts)
    first = np.append(tok_start, n)[k]
    del tok_start, k
    has_token = first < line_ends
    c0 = np.where(has_token, np.append(arr, np.uint8(32))[first], 48)
    numeric_start = ((c0 >= 48) & (c0 <= 57)) | (c0 == 43) | (c0 == 45) | (c0 == 46)
    is_name = has_token & ~numeric_start
    name_lines = np.flatnonzero(is_name)
    name_starts = first[name_lines]
    gaps = np.flatnonzero(~solid)
    name_ends = np.append(gaps, n)[np.searchsorted(gaps, name_starts)]
    del gaps, solid
    # Blank the names out and parse every remaining number at once.
    mark = np.zeros(n + 1, dtype=np.int8)
    mark[name_starts] = 1
    mark[name_ends] -= 1
    numbers = arr.copy()
    numbers[np.cumsum(mark[:n], dtype=np.int8).astype(bool)] = 32
    del mark
    values, counts, err = parse_floats(numbers)
    if err >= 0:
        ln = line_of_offset(numbers, err)
        tok = body[err:].split(None, 1)[0].decode("latin-1")
        raise MocapFormatError(path, f"non-numeric value {tok!r}", where(ln))
    del numbers
    if counts.shape[0] < n_lines:
        counts = np.concatenate([counts, np.zeros(n_lines - counts.shape[0], dtype=counts.dtype)])
    infinite = np.flatnonzero(np.isinf(values))
    if infinite.size:  # NaN means missing; an infinite angle or translation means nothing
        ln = int(np.searchsorted(np.cumsum(counts), infinite[0], side="right"))
        raise MocapFormatError(path, f"infinite value {float(values[infinite[0]])!r}", where(ln))
    value_at = np.concatenate([[0], np.cumsum(counts)])[:-1]  # index of each line's first number

    frame_lines = np.flatnonzero(has_token & ~is_name)
    bad = frame_lines[counts[frame_lines] != 1]
    if bad.size:
        raise MocapFormatError(
            path, f"expected a frame number or a bone line, found {plural(int(counts[bad[0]]), 'number')}", where(bad[0])
        )
    numbers_of_frames = values[value_at[frame_lines]]
    nonint = np.flatnonzero(numbers_of_frames != np.round(numbers_of_frames))
    if nonint.size:
        i = nonint[0]
        raise MocapFormatError(path, f"frame number {numbers_of_frames[i]!r} is not an integer", where(frame_lines[i]))
    carried = name_lines < (frame_lines[0] if frame_lines.size else len(line_starts))
    if state.count == 0 and np.any(carried):
        raise MocapFormatError(path, "bone values before the first frame number", where(name_lines[0]))
    chain = numbers_of_frames if state.count == 0 else np.concatenate([[state.last_number], numbers_of_frames])
    jumps = np.flatnonzero(np.diff(chain) != 1)
    if jumps.size:
        i = jumps[0]
        a, b = chain[i], chain[i + 1]
        at = frame_lines[i + (0 if state.count == 0 else -1) + 1]
        raise MocapFormatError(path, f"frame {b:.0f} follows frame {a:.0f}: frame numbers must be consecutive", where(at))
    Fc = frame_lines.shape[0]

    # Bones: name -> joint, check the value counts.
    ids = _token_ids(arr, name_starts, name_ends, skeleton.joint_names)
    unknown = np.flatnonzero(ids < 0)
    if unknown.size:
        i = unknown[0]
        name = body[name_starts[i] : name_ends[i]].decode("latin-1")
        raise MocapFormatError(path, f"AMC names joint {name!r} that the ASF {asf_name} lacks", where(name_lines[i]))
    got = counts[name_lines]
    wrong = np.flatnonzero(got != ndof[ids])
    if wrong.size:
        i = wrong[0]
        joint, dofs = skeleton.joint_names[ids[i]], " ".join(layout.dofs[ids[i]])
        raise MocapFormatError(
            path, f"joint {joint} needs {plural(int(ndof[ids[i]]), 'value')} ({dofs}), got {got[i]}", where(name_lines[i])
        )
    # Row 0 is the frame left open by the previous chunk; rows 1.. this chunk's frames.
    row = np.searchsorted(frame_lines, name_lines)
    J = skeleton.num_joints
    key = row * J + ids
    repeated = np.ones(key.shape[0], dtype=bool)
    repeated[np.unique(key, return_index=True)[1]] = False
    repeated |= (row == 0) & state.open_seen[ids]
    if np.any(repeated):
        i = int(np.flatnonzero(repeated)[0])
        number = state.last_number if row[i] == 0 else numbers_of_frames[row[i] - 1]
        raise MocapFormatError(
            path, f"joint {skeleton.joint_names[ids[i]]} appears twice in frame {number:.0f}", where(name_lines[i])
        )
    seen = np.bincount(key, minlength=(Fc + 1) * J).reshape(Fc + 1, J).astype(bool)
    seen[0] |= state.open_seen
    per_frame = (seen * (ndof > 0)).sum(axis=1)  # a bone line without values says nothing
    # Values into a (1 + Fc, columns) table, columns in AMC dof order joint after joint.
    ncols = int(col0[-1])
    table = np.zeros((Fc + 1, ncols))
    total = int(got.sum())
    within = np.arange(total) - np.repeat(np.cumsum(got) - got, got)
    src = np.repeat(value_at[name_lines], got) + within
    dst = np.repeat(row * ncols + col0[ids], got) + within
    table.reshape(-1)[dst] = values[src]
    if state.count:  # finish the open frame in the previous chunk's table
        touched = np.zeros(ncols, dtype=bool)
        touched[dst[dst < ncols]] = True
        state.tables[-1][-1, touched] = table[0, touched]
    if Fc == 0:
        state.open_seen = seen[0]
        state.open_joints = int(per_frame[0])
        return
    if state.count:
        state.most_joints = max(state.most_joints, int(per_frame[0]))
    if Fc > 1:
        state.most_joints = max(state.most_joints, int(per_frame[1:-1].max()))
    state.tables.append(table[1:])
    state.count += Fc
    state.last_number = float(numbers_of_frames[-1])
    state.open_seen = seen[-1]
    state.open_joints = int(per_frame[-1])


_HASH_BASE = np.uint64(1099511628211)


def _latin1(name: str) -> bytes:
    """``name`` as the AMC's Latin-1 bytes; a name with other characters becomes b"\\0", which no token holds."""
    try:
        return name.encode("latin-1")
    except UnicodeEncodeError:
        return b"\0"


def _token_ids(arr: np.ndarray, starts: np.ndarray, ends: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """Index in ``names`` of each token ``arr[starts[i]:ends[i]]`` (-1 where none), vectorised.

    Tokens are hashed (a polynomial over their bytes, wrapping in uint64), looked
    up among the hashes of ``names``, and the candidate is confirmed byte by byte,
    so a hash collision can never map an unknown token to a joint.
    """
    count = starts.shape[0]
    if count == 0:
        return np.zeros(0, dtype=np.int64)
    known = [_latin1(n) for n in names]
    width = max(len(k) for k in known)
    if len(known) * width > 2**24:  # many joints or a very long name: a (J, width) table would not fit
        lookup = {k: i for i, k in enumerate(known)}
        raw = arr.tobytes()
        return np.array([lookup.get(raw[a:b], -1) for a, b in zip(starts.tolist(), ends.tolist())], dtype=np.int64)
    table = np.zeros((len(known), width), dtype=np.uint8)
    for i, k in enumerate(known):
        table[i, : len(k)] = np.frombuffer(k, dtype=np.uint8)
    known_len = np.array([len(k) for k in known], dtype=np.int64)
    lens = ends - starts
    # Only tokens no longer than the longest name can be names; longer ones are hashed on a prefix.
    use = np.minimum(lens, width)
    first = np.cumsum(use) - use
    within = np.arange(int(use.sum())) - np.repeat(first, use)
    chars = arr[np.repeat(starts, use) + within]
    with np.errstate(over="ignore"):
        powers = np.concatenate([[np.uint64(1)], np.cumprod(np.full(width - 1, _HASH_BASE, dtype=np.uint64))])
        h = np.add.reduceat(chars.astype(np.uint64) * powers[within], first)
        kh = (table.astype(np.uint64) * powers).sum(axis=1)
    if np.unique(kh).shape[0] < kh.shape[0]:  # two joint names share a hash: look tokens up one by one
        lookup = {k: i for i, k in enumerate(known)}
        raw = arr.tobytes()
        return np.array([lookup.get(raw[a:b], -1) for a, b in zip(starts.tolist(), ends.tolist())], dtype=np.int64)
    order = np.argsort(kh)
    slot = np.minimum(np.searchsorted(kh[order], h), len(known) - 1)
    cand = order[slot]
    ok = (kh[cand] == h) & (lens == known_len[cand])
    # confirm byte by byte
    same = chars == table[np.repeat(cand, use), within]
    ok &= np.logical_and.reduceat(same, first)
    return np.where(ok, cand, -1).astype(np.int64)


def _to_motion_arrays(table: np.ndarray, skeleton: Skeleton, layout: _Layout, radians: bool):
    """Rotations (F, J, 4) and root positions (F, 3) from the (F, columns) AMC table."""
    F = table.shape[0]
    J = skeleton.num_joints
    rotations = np.empty((F, J, 4))
    rotations[..., 0] = 1.0
    rotations[..., 1:] = 0.0
    root = np.zeros((F, 3))
    groups: dict[str, tuple[list[int], list[list[int]]]] = {}
    col = 0
    for j, dofs in enumerate(layout.dofs):
        rot_cols, order = [], ""
        for d in dofs:
            if d[0] == "t":
                root[:, "xyz".index(d[1])] = table[:, col]
            else:
                rot_cols.append(col)
                order += d[1]
            col += 1
        if order:
            js, cols = groups.setdefault(order, ([], []))
            js.append(j)
            cols.append(rot_cols)
    rotated = []
    for order, (js, cols) in groups.items():
        rotations[:, js] = R.euler_to_quaternion(table[:, np.array(cols)], order, degrees=not radians)
        rotated.extend(js)
    if skeleton.axes is not None and rotated:
        rotated = np.sort(np.array(rotated))
        c = skeleton.axes[rotated]
        m = R.quaternion_multiply(R.quaternion_multiply(c, rotations[:, rotated]), R.quaternion_conjugate(c))
        rotations[:, rotated] = m
    return rotations, root
