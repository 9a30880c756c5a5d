"""Joint naming: sides, mirror partners, the body roles joints play, and a skeleton's length unit.

A rig is known by its joints' names (``LeftUpLeg``, ``lfemur``, ``UpperLeg_L``, ``thigh_l`` ...):
:func:`joint_sides` and :func:`mirror_pairs` read left and right from them, :func:`find_joint` the
joint playing a body role (:data:`ROLES`: pelvis, chest, head, hands, feet ...; on a rig of a known
family the family's own names, :func:`family_roles`, so ``info``, the features and the networks agree;
where names say nothing, the tree and rest pose may, :func:`mocapkit.rigs.roles_by_topology`), and
:func:`unit_scale_cm` the length unit from the bones between ankle and head. The motion model
(:mod:`mocapkit.motion`) re-exports these names.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Iterable, Sequence

import numpy as np

from .errors import SkeletonError

if TYPE_CHECKING:
    from .motion import Skeleton

__all__ = [
    "some_names",
    "name_readings",
    "DAG_PATH",
    "mirror_pairs",
    "mirror_mismatch",
    "MIRROR_MISMATCH_MAX",
    "lateral_axis",
    "joint_sides",
    "bone_moving_joints",
    "find_joint",
    "family_roles",
    "standard_joints",
    "unit_scale_cm",
    "ROLES",
]


def some_names(names: Sequence[str], shown: int = 40) -> str:
    """The first ``shown`` names joined by commas, then how many more: messages stay one short line."""
    head = ", ".join(names[:shown])
    return head if len(names) <= shown else f"{head}, ... ({len(names) - shown:,} more)"


_SIDE_SWAPS = [
    (re.compile(r"^Left"), "Right"), (re.compile(r"^Right"), "Left"),
    (re.compile(r"^left"), "right"), (re.compile(r"^right"), "left"),
    (re.compile(r"^L(?=[A-Z_])"), "R"), (re.compile(r"^R(?=[A-Z_])"), "L"),
    (re.compile(r"^l(?=[a-z_])"), "r"), (re.compile(r"^r(?=[a-z_])"), "l"),
    (re.compile(r"^l(?=[A-Z])"), "r"), (re.compile(r"^r(?=[A-Z])"), "l"),
    (re.compile(r"([_.\- ])L$"), r"\1R"), (re.compile(r"([_.\- ])R$"), r"\1L"),
    (re.compile(r"([_.\- ])l$"), r"\1r"), (re.compile(r"([_.\- ])r$"), r"\1l"),
    (re.compile(r"Left"), "Right"), (re.compile(r"Right"), "Left"),
    (re.compile(r"([_.\- ])L([_.\- ])"), r"\1R\2"), (re.compile(r"([_.\- ])R([_.\- ])"), r"\1L\2"),
]


#: What ends a namespace or a path before a joint's own name: ``Character1:Hips``, ``rig|Hips``, ``Character1_Hips``
_SEPARATORS = (":", "|", "_")

#: The prefix :func:`name_readings` gives names read by the last part of their Maya DAG paths (``|Root|Hips``
#: -> ``Hips``), Maya's wildcard for any path (a Maya node name never holds ``*``); a namespace set aside after it
#: follows it (``"*|Character1:"``).
DAG_PATH = "*|"


def _head(name: str) -> str:
    """``name`` up to and including its first separator (:data:`_SEPARATORS`), "" where it has none or nothing
    follows it."""
    at = min((i for i in (name.find(c) for c in _SEPARATORS) if i > 0), default=-1)
    return name[: at + 1] if 0 < at < len(name) - 1 else ""


def _shared_head(names: tuple[str, ...]) -> str:
    """The head (:func:`_head`) that every name shares but at most one in ten (an extra ``Reference`` root, a prop
    joint the exporter did not put in the namespace), "" where none does."""
    heads: dict[str, int] = {}
    for n in names:
        h = _head(n)
        if h:
            heads[h] = heads.get(h, 0) + 1
    if not heads:
        return ""
    head, count = max(heads.items(), key=lambda kv: kv[1])
    return head if count >= 2 and count >= len(names) - len(names) // 10 else ""


def name_readings(joint_names: Sequence[str]):
    """``(prefix, names)``, the joint names as a namespace or a path exporters write before every one may hide
    them, in order: as written (prefix ""), then with each shared head (:func:`_shared_head`) set aside in turn
    (``ns:Character1_Hips`` -> ``Character1_Hips`` -> ``Hips``), while the names stay distinct; at most three
    heads. Names that are Maya DAG paths, each joint named by the path of its ancestors (``|Root|Hips|Spine``,
    ``|Character1:Root|Character1:Hips``: no head is shared, the paths differ in depth), are then read by the
    last part of each path (``Spine``, ``Character1:Hips``; prefix :data:`DAG_PATH`), and their shared heads
    set aside in turn after it (prefix ``"*|Character1:"``). :func:`mocapkit.rigs.rig_family` matches
    families on the first that one fits; :func:`mirror_pairs` pairs by the last the names a namespace or path
    leaves unpaired (``Character1_lhand``).

    >>> [p for p, _ in name_readings(["ns:Character1_Hips", "ns:Character1_Spine", "ns:Character1_Head"])]
    ['', 'ns:', 'ns:Character1_']
    >>> [(p, n) for p, n in name_readings(["|ns:Hips", "|ns:Hips|ns:Spine", "|ns:Hips|ns:Spine|ns:Head"])][-2:]
    [('*|', ('ns:Hips', 'ns:Spine', 'ns:Head')), ('*|ns:', ('Hips', 'Spine', 'Head'))]
    """
    names = tuple(joint_names)
    last = names
    for last in _heads_set_aside("", names):
        yield last
    leaves = tuple(n.rsplit("|", 1)[-1] for n in names)
    if leaves != last[1] and leaves != names and len(set(leaves)) == len(leaves) and all(leaves):
        yield from _heads_set_aside(DAG_PATH, leaves)


def _heads_set_aside(prefix: str, names: tuple[str, ...]):
    """``(prefix, names)`` as given, then with each shared head set aside in turn (:func:`name_readings`)."""
    yield prefix, names
    for _ in range(3):
        head = _shared_head(names)
        if not head:
            return
        names = tuple(n[len(head):] if n.startswith(head) else n for n in names)
        if len(set(names)) != len(names):
            return
        prefix += head
        yield prefix, names


def _partner_name(name: str, names: set[str]) -> str | None:
    for pat, rep in _SIDE_SWAPS:
        if pat.search(name):
            cand = pat.sub(rep, name, count=1)
            if cand != name and cand in names:
                return cand
    return None


def mirror_pairs(joint_names: Sequence[str]) -> np.ndarray:
    """Permutation (J,) mapping each joint to its left/right partner (itself when unpaired).

    A name pairs with another when swapping its side marker gives that other
    name: ``Left``/``Right``, ``l``/``r`` prefixes (``lfemur``, ``lThigh``), ``L``/``R``
    prefixes (``LHipJoint``), ``_L``/``_R`` suffixes and ``_L_``/``_R_`` (or
    space-separated) markers inside a name (``m_avg_L_Hip``, ``Bip01 L Thigh``).
    ``lowerback`` stays unpaired because ``rowerback`` does not exist.

    >>> mirror_pairs(["root", "lfemur", "rfemur", "lowerback"]).tolist()
    [0, 2, 1, 3]
    """
    names = list(joint_names)
    perm = _pairs(names)
    *_, (prefix, bare) = name_readings(names)
    if prefix:  # a namespace (Character1_lhand): the names it leaves unpaired paired by the names without it
        alone = perm == np.arange(len(names))
        more = _pairs(list(bare))
        perm = np.where(alone & alone[more], more, perm)
    return perm


def _pairs(names: list[str]) -> np.ndarray:
    """:func:`mirror_pairs` of ``names`` as written."""
    pos = {n: i for i, n in enumerate(names)}
    known = set(names)
    perm = np.arange(len(names))
    for i, n in enumerate(names):
        p = _partner_name(n, known)
        if p is not None and _partner_name(p, known) == n:
            perm[i] = pos[p]
    return perm


MIRROR_MISMATCH_MAX = 0.1
"""Largest :func:`mirror_mismatch` at which a mirrored take's rotations are taken to fit the skeleton itself
(captured actors' skeletons lie at 0.02-0.04, rigs whose joints' rest frames differ by side at 0.1-0.2); above
it :func:`mocapkit.mirroring.mirror_for_rig` poses the mirror image on the take's own skeleton instead."""


def mirror_mismatch(skeleton: Skeleton, axis: int | None = None) -> float:
    """How far :meth:`Motion.mirror`'s skeleton lies from ``skeleton`` itself: the summed distance between
    each joint's offset and its partner's reflected offset, over twice the summed offset lengths (0: left/right
    symmetric).

    :meth:`Motion.mirror` is exact for positions on any rig (it mirrors the
    skeleton too), but its rotations fit the *original* skeleton, as a
    database of mirrored clips or a swap check assumes, only where the
    reflection maps the skeleton onto itself. That holds on rigs whose rest
    frames are the world's (Acclaim, the CMU and most BVH conversions: a
    skeleton captured from one actor, a few per cent off), and not on rigs
    whose bones lie along each joint's own axis with frames that differ by
    side (the Bandai Namco game rig: 0.1-0.2); there
    :func:`mocapkit.mirroring.mirror_keeping_skeleton` gives rotations that do.
    """
    perm = mirror_pairs(skeleton.joint_names)
    if axis is None:
        axis = _lateral_axis(skeleton, perm)
    flip = np.ones(3)
    flip[axis] = -1.0
    off = np.asarray(skeleton.offsets, dtype=np.float64)
    total = 2.0 * float(np.abs(off).sum())
    return float(np.abs(off[perm] * flip - off).sum()) / total if total > 0 else 0.0


def lateral_axis(skeleton: Skeleton) -> int:
    """The lateral axis (0, 1, 2) of ``skeleton``: the one separating left/right paired joints
    (:func:`mirror_pairs`) most in the rest pose, summed over the pairs; the axis :meth:`Motion.mirror`
    reflects along by default. ``SkeletonError`` when no joint has a partner."""
    return _lateral_axis(skeleton, mirror_pairs(skeleton.joint_names))


def _lateral_axis(sk: Skeleton, perm: np.ndarray) -> int:
    rest = sk.rest_positions()
    paired = np.flatnonzero(perm != np.arange(len(perm)))
    if len(paired) == 0:
        raise SkeletonError("cannot mirror: no left/right joint pairs found by name")
    d = np.abs(rest[paired] - rest[perm[paired]]).sum(axis=0)
    return int(np.argmax(d))


def _side_and_part(name: str, names: set[str]) -> tuple[str | None, str]:
    """('left'|'right'|None, body-part name lower-cased without its side marker or namespace).

    A namespace (``mixamorig:`` in ``mixamorig:LeftArm``, as FBX exports and
    MotionBuilder write them) or a path (``rig|`` in ``rig|LeftArm``, Maya's)
    is dropped before the side and part are read.
    """
    partner = _partner_name(name, names)
    low = re.split(r"[:|]", name.lower())[-1]
    if partner is None:  # the prefixes of the Bandai Namco rig (``joint_``), SMPL's models (``m_avg_``), VRoid's
        return None, re.sub(r"^(joint_|[mf]_avg_|j_bip_c_)", "", low)
    for pat, side in (
        (r"^left[_.\- ]?", "left"), (r"^right[_.\- ]?", "right"),
        (r"[_.\- ]l$", "left"), (r"[_.\- ]r$", "right"),
        (r"^l[_.\- ]?", "left"), (r"^r[_.\- ]?", "right"),
        (r"^.*?[_.\- ]l[_.\- ]", "left"), (r"^.*?[_.\- ]r[_.\- ]", "right"),  # m_avg_L_Hip, Bip01 L Thigh
    ):
        if re.search(pat, low):
            return side, re.sub(pat, "", low)
    return None, low



def joint_sides(joint_names: Sequence[str]) -> list[str | None]:
    """``'left'``, ``'right'`` or None for each joint name: the side of a joint with a mirror partner by name."""
    *_, (prefix, bare) = name_readings(joint_names)
    if prefix:  # a namespace (Character1_lhand, rig|LeftArm): sides read without it, of the joints mirror_pairs pairs
        perm, names = mirror_pairs(joint_names), set(bare)
        return [None if perm[j] == j else _side_and_part(n, names)[0] for j, n in enumerate(bare)]
    names = set(joint_names)
    return [_side_and_part(n, names)[0] for n in joint_names]

# Role -> ordered patterns on side-stripped lower-case names; the first pattern with a match wins. A numbered
# trunk (Xsens MVN's ``Chest`` ... ``Chest4``, Biovision's ``Chest``, ``Chest2``) has its chest at the top and its
# lower back at ``Chest``; Unity's ``UpperChest`` is above its ``Chest``.
ROLES: dict[str, tuple[str | None, tuple[str, ...]]] = {
    "pelvis": (None, (r"hips", r"pelvis", r"root")),
    "lower_back": (None, (r"lowerback", r"spine", r"abdomen", r"spine_01", r"spine1", r"chest")),
    "chest": (None, (r"thorax", r"upperchest", r"chest4", r"chest3", r"chest2", r"chest", r"spine3", r"spine_05",
                     r"spine_03", r"spine1", r"upperback", r"spine2")),
    "neck": (None, (r"lowerneck", r"neck", r"neck_01")),
    "head": (None, (r"head",)),
    "left_shoulder": ("left", (r"humerus", r"upperarm", r"arm", r"shoulder", r"shldr")),
    "right_shoulder": ("right", (r"humerus", r"upperarm", r"arm", r"shoulder", r"shldr")),
    "left_elbow": ("left", (r"elbow", r"radius", r"forearm", r"lowerarm")),
    "right_elbow": ("right", (r"elbow", r"radius", r"forearm", r"lowerarm")),
    "left_hand": ("left", (r"wrist", r"hand")),
    "right_hand": ("right", (r"wrist", r"hand")),
    "left_hip": ("left", (r"femur", r"upleg", r"upperleg", r"hip", r"thigh")),
    "right_hip": ("right", (r"femur", r"upleg", r"upperleg", r"hip", r"thigh")),
    "left_knee": ("left", (r"knee", r"tibia", r"lowerleg", r"leg", r"shin", r"calf")),
    "right_knee": ("right", (r"knee", r"tibia", r"lowerleg", r"leg", r"shin", r"calf")),
    "left_foot": ("left", (r"ankle", r"foot")),
    "right_foot": ("right", (r"ankle", r"foot")),
    "left_toe": ("left", (r"toes?", r"toebase", r"ball")),
    "right_toe": ("right", (r"toes?", r"toebase", r"ball")),
}


# the role of :mod:`mocapkit.rigs` that each of :data:`ROLES` names, where the spelling differs
_TOPOLOGY_ROLE = {"lower_back": "spine"}
for _s in ("left", "right"):
    _TOPOLOGY_ROLE.update({f"{_s}_shoulder": f"{_s}_upper_arm", f"{_s}_elbow": f"{_s}_forearm",
                           f"{_s}_hip": f"{_s}_thigh", f"{_s}_knee": f"{_s}_shin"})
_MIDDLE_ROLES = frozenset({"pelvis", "lower_back", "chest", "neck", "head"})


def bone_moving_joints(skeleton: Skeleton) -> np.ndarray:
    """(J,) bool: joints whose rotation moves a bone (a child joint or end site at a non-zero offset)."""
    moves = np.zeros(skeleton.num_joints, dtype=bool)
    for c in range(1, skeleton.num_joints):
        moves[skeleton.parents[c]] |= np.linalg.norm(skeleton.offsets[c]) > 1e-9
    for e, p in enumerate(skeleton.end_site_parents):
        moves[p] |= np.linalg.norm(skeleton.end_site_offsets[e]) > 1e-9
    return moves


def family_roles(skeleton: Skeleton) -> dict[str, int]:
    """Role (a key of :data:`ROLES`) -> joint index for the roles the skeleton's rig family names
    (:func:`mocapkit.rigs.roles` under :func:`mocapkit.rigs.rig_family`); empty for a rig of no known family.

    The family's table is the one answer where it has one: ``info``, the features and the networks' joint
    map then agree (an Unreal rig's chest is its highest ``spine_0N`` however many bones hang beside it).
    """
    from .rigs import rig_family, roles  # rigs imports this module

    if rig_family(skeleton) is None:
        return {}
    found = roles(skeleton)
    return {r: found[_TOPOLOGY_ROLE.get(r, r)] for r in ROLES if _TOPOLOGY_ROLE.get(r, r) in found}


def find_joint(skeleton: Skeleton, role: str) -> int:
    """Index of the joint playing ``role`` (a key of :data:`ROLES`) on CMU, HDM05 and common BVH rigs.

    Hands are the wrists and feet the ankles, as in Krüger et al.'s F15
    features. A rig of a known family plays the roles its family's names
    give (:func:`family_roles`); otherwise, and for roles the family does not
    name, the patterns of :data:`ROLES` on the names decide. Where no name
    matches, the roles the skeleton's tree and rest pose show
    (:func:`mocapkit.rigs.roles_by_topology`; the middle of the body even
    where left and right are not told); ``pelvis`` falls back to
    :func:`mocapkit.rigs.pelvis_index` (the first joint where the tree
    branches, or the root).

    >>> import mocapkit
    >>> sk = mocapkit.load(mocapkit.samples.path("131_01.bvh")).skeleton
    >>> sk.joint_names[find_joint(sk, "left_hand")]
    'LeftWrist'
    """
    if role not in ROLES:
        raise KeyError(f"unknown role {role!r}; roles are: {', '.join(ROLES)}")
    return _find(skeleton, role, family_roles(skeleton))


def _find(skeleton: Skeleton, role: str, by_family: dict[str, int]) -> int:
    """:func:`find_joint` with the skeleton's :func:`family_roles` computed once by the caller."""
    if role in by_family:
        return by_family[role]
    want_side, patterns = ROLES[role]
    names = set(skeleton.joint_names)
    parsed = [_side_and_part(n, names) for n in skeleton.joint_names]
    for pat in patterns:
        rx = re.compile(rf"^{pat}$")
        for j, (side, part) in enumerate(parsed):
            if side == want_side and rx.match(part):
                return j
    if role.endswith("_toe"):  # SMPL names the ankle ``Ankle`` and the toes below it ``Foot``
        for j, (side, part) in enumerate(parsed):
            p = int(skeleton.parents[j])
            if side == want_side and part == "foot" and p >= 0 and parsed[p] == (want_side, "ankle"):
                return j
    from .rigs import pelvis_index, roles_by_topology  # names say nothing: the tree and rest pose may

    topology = roles_by_topology(skeleton, sides=role not in _MIDDLE_ROLES)
    if topology is not None and _TOPOLOGY_ROLE.get(role, role) in topology:
        return topology[_TOPOLOGY_ROLE.get(role, role)]
    if role == "pelvis":
        return pelvis_index(skeleton)
    raise KeyError(f"no joint plays the role {role!r} in skeleton with joints: {some_names(skeleton.joint_names)}")


def standard_joints(skeleton: Skeleton, roles: Iterable[str] | None = None) -> dict[str, int]:
    """Map of role -> joint index for every role found (or exactly ``roles``, raising if one is missing)."""
    by_family = family_roles(skeleton)
    if roles is not None:
        for r in roles:
            if r not in ROLES:
                raise KeyError(f"unknown role {r!r}; roles are: {', '.join(ROLES)}")
        return {r: _find(skeleton, r, by_family) for r in roles}
    out = {}
    for r in ROLES:
        try:
            out[r] = _find(skeleton, r, by_family)
        except KeyError:
            pass
    return out


# Known length units in centimetres; a skeleton's unit is the one giving a plausible adult size.
_UNITS_CM = {"mm": 0.1, "cm": 1.0, "inch": 2.54, "CMU (1/0.45 inch)": 2.54 / 0.45, "dm": 10.0, "foot": 30.48, "m": 100.0}


def unit_scale_cm(skeleton: Skeleton) -> float:
    """Centimetres per length unit of ``skeleton``.

    Uses ``skeleton.unit_cm`` when the file stated it; otherwise it checks the
    bone lengths instead of guessing: the rest-pose path from the ankle through
    the pelvis to the head (about 0.9 of standing height) is read in each known
    unit (mm, cm, inch, CMU's 1/0.45 inch, dm, foot, m) and the unit giving a
    height closest to 1.7 m wins. A skeleton that is no human of 1.0-2.3 m in
    any of them raises ``SkeletonError``.
    """
    if skeleton.unit_cm is not None:
        return float(skeleton.unit_cm)
    try:
        foot = find_joint(skeleton, "left_foot")
        head = find_joint(skeleton, "head")
    except KeyError as exc:  # a rig of no known naming: its length unit cannot be read from a human's height
        raise SkeletonError(f"the length unit cannot be told from the bones: {exc.args[0] if exc.args else exc} "
                            "(a rig of no known naming)") from None
    rest = skeleton.rest_positions()
    # path length foot -> common ancestor -> head along the tree
    def chain(j):
        out = [j]
        while skeleton.parents[out[-1]] >= 0:
            out.append(int(skeleton.parents[out[-1]]))
        return out

    a, b = chain(foot), chain(head)
    in_b = set(b)
    common = next(j for j in a if j in in_b)
    length = 0.0
    for path in (a, b):
        for j in path:
            if j == common:
                break
            length += np.linalg.norm(rest[j] - rest[skeleton.parents[j]])
    # ankle-to-head along the skeleton is about 0.9 of standing height
    best, best_err = None, np.inf
    for unit, cm in _UNITS_CM.items():
        height = length * cm / 0.9
        err = abs(np.log(height / 170.0))
        if 100.0 <= height <= 230.0 and err < best_err:
            best, best_err = cm, err
    if best is None:
        raise SkeletonError(
            f"cannot tell the length unit: ankle-to-head path is {length:.4g} units, "
            "no known unit makes that an adult; name the unit with --unit mm|cm|m|in "
            "(Python: the skeleton's unit_cm, io.takes.with_unit)"
        )
    return best
