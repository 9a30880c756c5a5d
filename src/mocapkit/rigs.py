"""Humanoid rigs: standard joint roles, the names each known rig family gives them, and where the pelvis is.

Motion-capture files spell the same human skeleton in many ways: the CMU
and HDM05 Acclaim ASF calls the thigh ``lfemur``, Bruce Hahne's CMU BVH
conversions call it ``LeftUpLeg`` (MotionBuilder-friendly release),
``LeftHip`` (3dsMax-friendly release) or ``lThigh`` (Daz-friendly
release), the Bandai Namco game rig
``UpperLeg_L``, MotionBuilder/HumanIK ``LeftUpLeg``, Mixamo
``mixamorig:LeftUpLeg``, SMPL ``L_Hip`` (or ``m_avg_L_Hip``, ``left_hip``),
Unreal Engine's mannequin ``thigh_l``, Xsens MVN's BVH export ``LeftHip``
(on a trunk of ``Chest`` ... ``Chest4``) and Unity's humanoid avatar
``LeftUpperLeg``. Code that needs "the left thigh"
or "the pelvis" asks this module instead of matching names itself.

A **role** names the joint whose rotation moves a body segment (BVH
semantics: the joint sits at the segment's start), e.g. ``left_thigh`` is
the hip joint that swings the femur and ``left_hand`` the wrist. The roles
form a tree (:data:`PARENT_ROLE`, the Acclaim topology, the richest of the
known rigs); a rig plays a subset of them, possibly with joints between two
roles that play none (``Spine2`` on a four-segment HumanIK spine).

A **family** is a naming convention: a table role -> candidate joint names
(:data:`FAMILIES`). :func:`rig_family` picks the family whose names cover
most of a skeleton's joints; :func:`roles` maps each role that family names
to a joint index. Names are matched exactly (case-sensitive, as the files
write them), so ``LeftShoulder`` is the clavicle on a HumanIK rig and the
upper arm on the 3dsMax CMU conversions, decided by the family, never by
guessing from a substring.

The **pelvis** (:func:`pelvis_index`) is the joint that carries the hips'
translation: the root on Acclaim and most BVH rigs, but ``Hips`` on the
Bandai Namco rig, whose root ``joint_Root`` stays on the floor, and
``pelvis`` below Unreal's ``root``. On a rig of no known family it is the
first joint below the root where the hierarchy branches (legs and spine
part there).

A rig whose names no family knows may still show its roles in its **tree
and rest pose** (:func:`roles_by_topology`): three limbs leave the pelvis
and three the chest, the legs and the arms are twin chains, and left and
right come from the names' side markers or from the way the toes point.
:func:`roles` falls back to it.

A **namespace** an exporter writes before every joint's own name
(``Character1:Hips`` or ``ns:Hips``, Maya and MotionBuilder namespaces;
``rig|Hips``, a Maya DAG path; ``Character1_Hips``, the names of HumanIK's
default character; the Bandai Namco rig exported as ``mixamorig:UpperLeg_L``)
is set aside for family matching where the names as written match no family
(:func:`family_prefix`): the part up to a separator (``:``, ``|``, ``_``) that
(nearly) every joint name shares, one part at a time, until a family matches.
Names as written come first, so Mixamo's own ``mixamorig:LeftUpLeg`` stays
``mixamo`` and a suffix such as Bandai's ``_L`` is never touched; names
sharing a prefix that match no family with it set aside stay of none known.
Joints each named by the full Maya DAG path of its ancestors (``|Root|Hips|Spine``,
``|Character1:Root|Character1:Hips``, as Maya and FBX-to-BVH converters write them) share no such part: they are
read by the last part of each path, then a namespace set aside the same way (``family_prefix`` ``"*|"``,
``"*|Character1:"``). Only the matching reads the names without it: the take, its output, the
decisions and the report keep the file's names.

Pure functions of a :class:`~mocapkit.motion.Skeleton`; nothing here reads
files or depends on frame data.
"""

from __future__ import annotations

import functools
from types import MappingProxyType

import numpy as np

from .joints import name_readings
from .motion import Skeleton

__all__ = [
    "ROLES",
    "PARENT_ROLE",
    "FAMILIES",
    "rig_family",
    "family_prefix",
    "family_names",
    "roles",
    "roles_by_topology",
    "pelvis_index",
    "role_names",
    "DATA_TERMS",
    "data_terms",
]


def _sided(base: str) -> tuple[str, str]:
    return f"left_{base}", f"right_{base}"


#: Every standard role, root first, in the Acclaim skeleton's depth-first order.
ROLES: tuple[str, ...] = (
    "root",  # a ground reference above the pelvis (game rigs); absent where the pelvis is the root
    "pelvis",
    *_sided("hip_bone"),  # pelvis centre -> hip socket (Acclaim lhipjoint)
    *_sided("thigh"), *_sided("shin"), *_sided("foot"), *_sided("toe"),
    "spine", "spine_mid", "chest", "neck", "neck_upper", "head",
    *_sided("clavicle"), *_sided("upper_arm"), *_sided("forearm"), *_sided("hand"),
    *_sided("palm"), *_sided("fingers"), *_sided("thumb"),
)

_PARENT = {
    "pelvis": "root",
    "spine": "pelvis", "spine_mid": "spine", "chest": "spine_mid", "neck": "chest", "neck_upper": "neck",
    "head": "neck_upper",
}
for _s in ("left", "right"):
    _PARENT.update({
        f"{_s}_hip_bone": "pelvis", f"{_s}_thigh": f"{_s}_hip_bone", f"{_s}_shin": f"{_s}_thigh",
        f"{_s}_foot": f"{_s}_shin", f"{_s}_toe": f"{_s}_foot",
        f"{_s}_clavicle": "chest", f"{_s}_upper_arm": f"{_s}_clavicle", f"{_s}_forearm": f"{_s}_upper_arm",
        f"{_s}_hand": f"{_s}_forearm", f"{_s}_palm": f"{_s}_hand", f"{_s}_fingers": f"{_s}_palm",
        f"{_s}_thumb": f"{_s}_hand",
    })

#: The parent role of every role but ``root`` (the Acclaim topology). A rig that lacks a role in between
#: (no ``spine_mid``) hangs the child on the nearest role above that it has.
PARENT_ROLE = MappingProxyType(_PARENT)


def _both(table: dict[str, tuple[str, ...]], left: dict[str, tuple[str, ...]], swap) -> dict[str, tuple[str, ...]]:
    """``table`` plus the left-side entries and their right-side mirror (names through ``swap``)."""
    out = dict(table)
    for role, names in left.items():
        out[f"left_{role}"] = names
        out[f"right_{role}"] = tuple(swap(n) for n in names)
    return out


def _lr(name: str) -> str:
    """Left -> right in side prefixes: ``Left``/``left_`` (HumanIK, smplx), ``L``/``L_`` (CMU, SMPL), ``l`` (Acclaim,
    Daz), ``J_Bip_L_`` (VRoid)."""
    if name.startswith("J_Bip_L_"):
        return "J_Bip_R_" + name[8:]
    if name.startswith("Left"):
        return "Right" + name[4:]
    if name.startswith("left_"):
        return "right_" + name[5:]
    if name.startswith("L") and (name[1:2].isupper() or name[1:2] == "_"):
        return "R" + name[1:]
    if name.startswith("l"):
        return "r" + name[1:]
    return name


def _suffix_lr(name: str) -> str:
    """Left -> right in side suffixes: ``_L`` (Bandai Namco), ``_l`` (Unreal)."""
    return name[:-1] + {"L": "R", "l": "r"}[name[-1]] if name.endswith(("_L", "_l")) else name


_ACCLAIM = _both(
    {"pelvis": ("root",), "spine": ("lowerback",), "spine_mid": ("upperback",), "chest": ("thorax",),
     "neck": ("lowerneck",), "neck_upper": ("upperneck",), "head": ("head",)},
    {"hip_bone": ("lhipjoint",), "thigh": ("lfemur",), "shin": ("ltibia",), "foot": ("lfoot",), "toe": ("ltoes",),
     "clavicle": ("lclavicle",), "upper_arm": ("lhumerus",), "forearm": ("lradius",), "hand": ("lwrist",),
     "palm": ("lhand",), "fingers": ("lfingers",), "thumb": ("lthumb",)},
    _lr,
)

_CMU_MOTIONBUILDER = _both(  # cgspeed "MotionBuilder-friendly" CMU BVH (also the CMU BVH of pybvh, bvh11 ...)
    {"pelvis": ("Hips",), "spine": ("LowerBack",), "spine_mid": ("Spine",), "chest": ("Spine1",),
     "neck": ("Neck",), "neck_upper": ("Neck1",), "head": ("Head",)},
    {"hip_bone": ("LHipJoint",), "thigh": ("LeftUpLeg",), "shin": ("LeftLeg",), "foot": ("LeftFoot",),
     "toe": ("LeftToeBase",), "clavicle": ("LeftShoulder",), "upper_arm": ("LeftArm",), "forearm": ("LeftForeArm",),
     "hand": ("LeftHand",), "palm": ("LeftFingerBase",), "fingers": ("LFingers", "LeftHandIndex1"),
     "thumb": ("LThumb",)},
    _lr,
)

_CMU_DAZ = _both(  # cgspeed "Daz-friendly" CMU BVH (and Poser/Daz figures): Buttock = hip bone, Shldr = upper arm
    {"pelvis": ("hip",), "spine": ("abdomen",), "chest": ("chest",), "neck": ("neck",), "head": ("head",)},
    {"hip_bone": ("lButtock",), "thigh": ("lThigh",), "shin": ("lShin",), "foot": ("lFoot",),
     "clavicle": ("lCollar",), "upper_arm": ("lShldr",), "forearm": ("lForeArm",), "hand": ("lHand",),
     "fingers": ("lIndex1",), "thumb": ("lThumb1",)},
    _lr,
)

_CMU_3DSMAX = _both(  # cgspeed "3dsMax-friendly" CMU BVH: Collar = clavicle, Shoulder = upper arm, Hip = thigh
    {"pelvis": ("Hips",), "spine": ("lowerback",), "spine_mid": ("Chest",), "chest": ("Chest2",),
     "neck": ("lowerneck",), "neck_upper": ("Neck",), "head": ("Head",)},
    {"hip_bone": ("LHipJoint",), "thigh": ("LeftHip",), "shin": ("LeftKnee",), "foot": ("LeftAnkle",),
     "toe": ("LeftToe",), "clavicle": ("LeftCollar",), "upper_arm": ("LeftShoulder",), "forearm": ("LeftElbow",),
     "hand": ("LeftWrist",), "palm": ("lhand",), "fingers": ("LFingers",), "thumb": ("LThumb",)},
    _lr,
)

_BANDAI_NAMCO = _both(  # Bandai Namco Research Motiondataset game rig (root on the floor, Hips moves)
    {"root": ("joint_Root",), "pelvis": ("Hips",), "spine": ("Spine",), "chest": ("Chest",), "neck": ("Neck",),
     "head": ("Head",)},
    {"thigh": ("UpperLeg_L",), "shin": ("LowerLeg_L",), "foot": ("Foot_L",), "toe": ("Toes_L",),
     "clavicle": ("Shoulder_L",), "upper_arm": ("UpperArm_L",), "forearm": ("LowerArm_L",), "hand": ("Hand_L",)},
    _suffix_lr,
)

# Xsens MVN's BVH export: the trunk ``Chest`` (lowest) to ``Chest4`` (the thorax, where the neck and collars hang),
# the limbs named as the 3dsMax CMU release names them (``Collar`` the clavicle, ``Shoulder`` the upper arm, ``Hip`` the
# thigh); the chest is the highest trunk joint present and the middle spine the lowest one left (as HumanIK).
_XSENS_CHESTS = ("Chest4", "Chest3", "Chest2")
_XSENS_MVN = _both(
    {"pelvis": ("Hips",), "spine": ("Chest",), "chest": _XSENS_CHESTS, "spine_mid": _XSENS_CHESTS[::-1],
     "neck": ("Neck",), "head": ("Head",)},
    {"thigh": ("LeftHip",), "shin": ("LeftKnee",), "foot": ("LeftAnkle",), "toe": ("LeftToe",),
     "clavicle": ("LeftCollar",), "upper_arm": ("LeftShoulder",), "forearm": ("LeftElbow",), "hand": ("LeftWrist",)},
    _lr,
)

# Unity's humanoid avatar (``HumanBodyBones``: the names Unity, VRM tools and VMC-protocol capture write in BVH), and
# the same bones as VRoid Studio's models name them (``J_Bip_C_Hips``, ``J_Bip_L_UpperLeg``): ``Shoulder`` the
# clavicle, ``UpperArm``/``LowerArm``/``Hand``, ``UpperLeg``/``LowerLeg``/``Foot``/``Toes``; the chest is
# ``UpperChest`` where there is one, a ``Root`` above the hips may carry the path.
_UNITY = _both(
    {"root": ("Root",), "pelvis": ("Hips", "J_Bip_C_Hips"), "spine": ("Spine", "J_Bip_C_Spine"),
     "chest": ("UpperChest", "Chest", "J_Bip_C_UpperChest", "J_Bip_C_Chest"), "spine_mid": ("Chest", "J_Bip_C_Chest"),
     "neck": ("Neck", "J_Bip_C_Neck"), "head": ("Head", "J_Bip_C_Head")},
    {"thigh": ("LeftUpperLeg", "J_Bip_L_UpperLeg"), "shin": ("LeftLowerLeg", "J_Bip_L_LowerLeg"),
     "foot": ("LeftFoot", "J_Bip_L_Foot"), "toe": ("LeftToes", "J_Bip_L_ToeBase"),
     "clavicle": ("LeftShoulder", "J_Bip_L_Shoulder"), "upper_arm": ("LeftUpperArm", "J_Bip_L_UpperArm"),
     "forearm": ("LeftLowerArm", "J_Bip_L_LowerArm"), "hand": ("LeftHand", "J_Bip_L_Hand"),
     "fingers": ("LeftIndexProximal", "J_Bip_L_Index1"), "thumb": ("LeftThumbProximal", "J_Bip_L_Thumb1")},
    _lr,
)

# HumanIK (MotionBuilder's character rig): Spine, Spine1 ... Spine9 and Neck, Neck1 ... Neck9; the chest is the
# highest spine joint present (resolved first), the middle spine the lowest one left. Ubisoft's LaFAN1 BVH files
# spell the same rig with ``LeftToe`` for the toes.
_SPINES = tuple(f"Spine{k}" for k in range(9, 0, -1))
_HUMANIK = _both(
    {"pelvis": ("Hips",), "spine": ("Spine",), "chest": _SPINES, "spine_mid": _SPINES[::-1],
     "neck": ("Neck",), "neck_upper": tuple(f"Neck{k}" for k in range(1, 10)), "head": ("Head",)},
    {"thigh": ("LeftUpLeg",), "shin": ("LeftLeg",), "foot": ("LeftFoot",), "toe": ("LeftToeBase", "LeftToe"),
     "clavicle": ("LeftShoulder",), "upper_arm": ("LeftArm",), "forearm": ("LeftForeArm",), "hand": ("LeftHand",),
     "fingers": ("LeftHandIndex1",), "thumb": ("LeftHandThumb1",)},
    _lr,
)


# SMPL, SMPL-H and SMPL-X body joints (AMASS and the many BVH exports of SMPL fits), in the capitalised spelling of
# the SMPL code (``L_Hip``), with the ``m_avg_`` / ``f_avg_`` prefix of the SMPL FBX models (``m_avg_L_Hip``), and
# the lower-case one of smplx (``left_hip``). SMPL's ``Shoulder`` is the upper arm, ``Collar`` the clavicle, ``Hip``
# the thigh, ``Ankle`` the foot and ``Foot`` the toes; its ``Hand`` is the palm, which SMPL-H and SMPL-X replace by
# fingers hanging from the wrist.
_SMPL_NAMES = _both(
    {"pelvis": ("Pelvis", "pelvis"), "spine": ("Spine1", "spine1"), "spine_mid": ("Spine2", "spine2"),
     "chest": ("Spine3", "spine3"), "neck": ("Neck", "neck"), "head": ("Head", "head")},
    {"thigh": ("L_Hip", "left_hip"), "shin": ("L_Knee", "left_knee"), "foot": ("L_Ankle", "left_ankle"),
     "toe": ("L_Foot", "left_foot"), "clavicle": ("L_Collar", "left_collar"),
     "upper_arm": ("L_Shoulder", "left_shoulder"), "forearm": ("L_Elbow", "left_elbow"),
     "hand": ("L_Wrist", "left_wrist"), "palm": ("L_Hand", "left_hand"), "fingers": ("left_index1",),
     "thumb": ("left_thumb1",)},
    _lr,
)
_SMPL = {role: tuple(pre + n for n in names for pre in ("", "m_avg_", "f_avg_")) for role, names in _SMPL_NAMES.items()}

# Unreal Engine's mannequin (UE4: spine_01-03, neck_01; UE5: spine_01-05, neck_01-02): ``root`` on the floor,
# ``pelvis`` carrying the translation; the chest is the highest spine joint present, the middle spine the lowest
# one left (as HumanIK); twist bones (``upperarm_twist_01_l``) and IK bones play no role.
_UNREAL_SPINES = ("spine_05", "spine_04", "spine_03", "spine_02")
_UNREAL = _both(
    {"root": ("root",), "pelvis": ("pelvis",), "spine": ("spine_01",), "chest": _UNREAL_SPINES,
     "spine_mid": _UNREAL_SPINES[::-1], "neck": ("neck_01",), "neck_upper": ("neck_02",), "head": ("head",)},
    {"thigh": ("thigh_l",), "shin": ("calf_l",), "foot": ("foot_l",), "toe": ("ball_l",),
     "clavicle": ("clavicle_l",), "upper_arm": ("upperarm_l",), "forearm": ("lowerarm_l",), "hand": ("hand_l",),
     "fingers": ("index_01_l",), "thumb": ("thumb_01_l",)},
    _suffix_lr,
)

_MIXAMO_PREFIX = "mixamorig:"
_MIXAMO = {role: tuple(_MIXAMO_PREFIX + n for n in names) for role, names in _HUMANIK.items()}

#: Role -> candidate joint names, per rig family. For each role the first candidate the skeleton has wins.
FAMILIES = MappingProxyType({
    "acclaim": MappingProxyType(_ACCLAIM),
    "humanik": MappingProxyType(_HUMANIK),
    "mixamo": MappingProxyType(_MIXAMO),
    "cmu_bvh_motionbuilder": MappingProxyType(_CMU_MOTIONBUILDER),
    "cmu_bvh_3dsmax": MappingProxyType(_CMU_3DSMAX),
    "cmu_bvh_daz": MappingProxyType(_CMU_DAZ),
    "xsens_mvn": MappingProxyType(_XSENS_MVN),
    "unity_humanoid": MappingProxyType(_UNITY),
    "bandai_namco": MappingProxyType(_BANDAI_NAMCO),
    "smpl": MappingProxyType(_SMPL),
    "unreal": MappingProxyType(_UNREAL),
})

# the roles a skeleton must play for a family to be recognised at all
_CORE = ("pelvis", "left_thigh", "right_thigh", "left_shin", "right_shin", "left_upper_arm", "right_upper_arm", "head")

# resolution order: the chest before the middle spine (HumanIK's candidates overlap), otherwise ROLES order
_ORDER = tuple(sorted(ROLES, key=lambda r: (r == "spine_mid", ROLES.index(r))))


def _resolve(joint_names, family: str) -> dict[str, int]:
    """Role -> joint index of the first of ``family``'s names for each role found among ``joint_names``."""
    table = FAMILIES[family]
    index = {n: j for j, n in enumerate(joint_names)}
    out: dict[str, int] = {}
    taken: set[int] = set()
    for role in _ORDER:
        for name in table.get(role, ()):
            j = index.get(name)
            if j is not None and j not in taken:
                out[role] = j
                taken.add(j)
                break
    return out


def _covers(parents, found: dict[str, int]) -> bool:
    """The core roles are all found, and each role's joint lies below its parent role's joint (``parents``: each
    joint's parent index, -1 for the root)."""
    if not all(r in found for r in _CORE):
        return False
    for role, j in found.items():
        up = PARENT_ROLE.get(role)
        while up is not None and up not in found:
            up = PARENT_ROLE.get(up)
        if up is None:
            continue
        a, p = int(parents[j]), found[up]
        while a >= 0 and a != p:
            a = int(parents[a])
        if a != p:
            return False
    return True


def rig_family(skeleton: Skeleton) -> str | None:
    """The name (a key of :data:`FAMILIES`) of the family whose names cover most of ``skeleton``'s joints.

    A family counts only when its core roles (pelvis, thighs, shins, upper
    arms, head) are all found and every role it finds hangs below its parent
    role's joint. Ties go to the family listed first in :data:`FAMILIES` (HumanIK
    before the CMU conversions, whose names it shares: a rig that has none of
    the CMU-only joints is read as HumanIK; the 3dsMax conversion before Xsens
    MVN: a Biovision trunk of ``Chest`` and ``Chest2`` keeps the 3dsMax reading).
    Where the names as written fit none, they are matched again with a
    namespace they share set aside (:func:`family_prefix`). None when no
    family fits.

    >>> import mocapkit
    >>> rig_family(mocapkit.load(mocapkit.samples.path("131_01.bvh")).skeleton)
    'cmu_bvh_3dsmax'
    """
    return _reading(skeleton)[0]


def family_prefix(skeleton: Skeleton) -> str:
    """The namespace :func:`rig_family` set aside to match ``skeleton``'s family (``"Character1_"`` for
    ``Character1_Hips`` ..., ``"mixamorig:"`` for a Bandai Namco rig exported as ``mixamorig:Hips``;
    :data:`mocapkit.joints.DAG_PATH`, ``"*|"``, for joints each named by its Maya DAG path, ``|Hips|Spine``, read by
    the last part, and ``"*|Character1:"`` with a namespace on every part), "" where the names as written match it
    or no family matches (module docstring).

    >>> from mocapkit.motion import Skeleton
    >>> sk = Skeleton(("rig|Hips", "rig|LeftUpLeg", "rig|LeftLeg", "rig|RightUpLeg", "rig|RightLeg", "rig|Spine",
    ...                "rig|LeftArm", "rig|RightArm", "rig|Head"), [-1, 0, 1, 0, 3, 0, 5, 5, 5], np.zeros((9, 3)))
    >>> rig_family(sk), family_prefix(sk)
    ('humanik', 'rig|')
    """
    return _reading(skeleton)[1]


def family_names(skeleton: Skeleton) -> tuple[str, ...]:
    """``skeleton``'s joint names as its family is matched on them: the file's, with :func:`family_prefix` set
    aside (a model trained on a family's names serves the same rig under a namespace:
    :func:`mocapkit.cleaning.deep.served_by`)."""
    return _reading(skeleton)[2]


def _reading(skeleton: Skeleton) -> tuple[str | None, str, tuple[str, ...]]:
    return _family_of(tuple(skeleton.joint_names), tuple(np.asarray(skeleton.parents).tolist()))


@functools.lru_cache(maxsize=64)
def _family_of(joint_names: tuple[str, ...], parents: tuple[int, ...]) -> tuple[str | None, str, tuple[str, ...]]:
    """``(family, prefix, names)``: :func:`rig_family`, :func:`family_prefix` and :func:`family_names` of a skeleton
    by all they read, its joint names and parents (hashable tuples), kept for the 64 skeletons asked last: a take's
    steps ask it of one skeleton dozens of times (every role a cue finds), each a pass over every family's names.
    The first reading of the names (:func:`mocapkit.joints.name_readings`) that some family covers wins."""
    for prefix, names in name_readings(joint_names):
        best, best_n = None, 0
        for family in FAMILIES:
            found = _resolve(names, family)
            if len(found) > best_n and _covers(parents, found):
                best, best_n = family, len(found)
        if best is not None:
            return best, prefix, names
    return None, "", joint_names


rig_family.cache_info = _family_of.cache_info  # as on a functools.cache function: what is kept, hits and misses
rig_family.cache_clear = _family_of.cache_clear


def roles(skeleton: Skeleton) -> dict[str, int]:
    """Role -> joint index for every role ``skeleton`` plays under its family (:func:`rig_family`).

    Roles the family does not name, or the skeleton lacks, are absent; a
    skeleton of no known family gets the roles its tree and rest pose show
    (:func:`roles_by_topology`), or only ``{"pelvis": pelvis_index(...)}``
    where they do not show them plainly. The result is in :data:`ROLES` order.

    >>> import mocapkit
    >>> sk = mocapkit.load(mocapkit.samples.path("131_01.bvh")).skeleton
    >>> r = roles(sk)
    >>> sk.joint_names[r["left_upper_arm"]], sk.joint_names[r["left_clavicle"]]
    ('LeftShoulder', 'LeftCollar')
    """
    family, _, names = _reading(skeleton)
    if family is None:
        return roles_by_topology(skeleton) or {"pelvis": pelvis_index(skeleton)}
    found = _resolve(names, family)
    return {r: found[r] for r in ROLES if r in found}


def pelvis_index(skeleton: Skeleton) -> int:
    """Index of the joint that carries the hips' translation (the pelvis).

    The ``pelvis`` role of the skeleton's family (``root`` on Acclaim,
    ``Hips`` on the CMU BVH, HumanIK and Mixamo rigs, ``Pelvis`` on SMPL, and
    ``Hips`` on the Bandai Namco rig and ``pelvis`` on Unreal's, whose roots
    stay on the floor). On a rig of no known family: the first joint, from
    the root down a chain of single children, that has more than one child
    (the legs and the spine part there), or the root when the chain never
    branches.
    """
    family, _, names = _reading(skeleton)
    if family is not None:
        return _resolve(names, family)["pelvis"]
    j = 0
    while True:
        kids = skeleton.children(j)
        if len(kids) != 1:
            return j if len(kids) > 1 else 0
        j = kids[0]


def role_names(skeleton: Skeleton) -> dict[str, str]:
    """Role -> joint name for :func:`roles` (for messages and ``mocapkit info``)."""
    return {r: skeleton.joint_names[j] for r, j in roles(skeleton).items()}


def _subtree_sizes(skeleton: Skeleton) -> list[int]:
    size = [1] * skeleton.num_joints
    for j in range(skeleton.num_joints - 1, 0, -1):  # parents precede their children
        size[int(skeleton.parents[j])] += size[j]
    return size


def _chain(skeleton: Skeleton, j: int, size: list[int]) -> list[int]:
    """The joints from ``j`` down while one child carries the limb on: the only child with children of its own
    (leaf children, such as twist or helper bones, are passed over), or a single leaf (the toes); it stops at a
    joint where the body branches (a chest, a hand with fingers) or ends."""
    out = [j]
    while True:
        kids = skeleton.children(out[-1])
        big = [c for c in kids if size[c] > 1]
        if len(big) == 1:
            out.append(big[0])
        elif not big and len(kids) == 1:
            out.append(kids[0])
        else:
            return out


def _bone(skeleton: Skeleton, j: int, nxt: int | None) -> float:
    """Length of the segment joint ``j`` moves: to the next joint of its chain, else to its farthest end site."""
    if nxt is not None:
        return float(np.linalg.norm(skeleton.offsets[nxt]))
    ends = skeleton.end_site_offsets[skeleton.end_site_parents == j]
    return float(np.linalg.norm(ends, axis=1).max()) if len(ends) else 0.0


def _bones(skeleton: Skeleton, chain: list[int]) -> np.ndarray:
    """(len(chain),) length of the segment each joint of ``chain`` moves (:func:`_bone`)."""
    return np.array([_bone(skeleton, j, chain[k + 1] if k + 1 < len(chain) else None) for k, j in enumerate(chain)])


def _long_pair(skeleton: Skeleton, chain: list[int], first: int = 0) -> int | None:
    """Index in ``chain`` (``first`` or later) of the first of the two consecutive segments longest together (thigh
    and shin, upper arm and forearm); None for a chain too short to hold them and a joint after them."""
    if len(chain) < first + 3:
        return None
    bones = _bones(skeleton, chain)
    return first + int(np.argmax(bones[first:-1] + bones[first + 1:]))


def _twins(chains: list[list[int]], skeleton: Skeleton) -> list[list[int]] | None:
    """The two chains of ``chains`` most alike (the same number of joints, segments of the nearest lengths: a pair
    of limbs), or None when fewer than two have the same length."""
    bones = [_bones(skeleton, c) for c in chains]
    best, pair = np.inf, None
    for i, a in enumerate(chains):
        for k, b in enumerate(chains[i + 1:], start=i + 1):
            if len(a) != len(b):
                continue
            d = float(np.abs(bones[i] - bones[k]).sum())
            if d < best:
                best, pair = d, [a, b]
    return pair


def _side_votes(chain: list[int], sides: list[str | None]) -> int:
    """+1 per joint of ``chain`` its name calls left, -1 per right."""
    return sum((sides[j] == "left") - (sides[j] == "right") for j in chain)


def roles_by_topology(skeleton: Skeleton, sides: bool = True) -> dict[str, int] | None:
    """The roles of a humanoid skeleton whose names no family knows, read from its tree and rest pose; None unless
    they are plain. ``sides=False``: only the roles of the body's middle (pelvis to head), which need no left and
    right.

    From the pelvis (:func:`pelvis_index`) three limbs leave: two legs (chains
    of the same length whose two longest consecutive segments are the thigh
    and the shin, then the foot and the toes; a joint before the thigh is the
    hip bone) and the trunk, up to the chest where it branches into two arms
    (the twin chains of four joints or more most alike in their segments:
    the clavicle, then the upper arm and forearm, the two longest consecutive
    segments after it, then the hand) and the neck (the longest other chain,
    the one reaching highest among equals: neck, upper neck, head). A chain
    passes over leaf joints beside it (twist and helper bones). The first trunk
    joint plays the spine and the next the middle spine; joints between, and
    fingers, play none. Left and right come from the joints' names where they
    carry sides (:func:`mocapkit.motion.joint_sides`: ``L_``, ``_r``,
    ``Left`` ...), else from the rest pose: left is up (pelvis to chest)
    crossed with forward (ankle to toes), so a rig without toes and without
    sides in its names is not read. None as well where any part does not
    match (no three limbs at the pelvis or at the chest, legs or arms of other
    lengths, no foot, no clavicle, sides that disagree).
    """
    from .motion import joint_sides

    size = _subtree_sizes(skeleton)
    rest = skeleton.rest_positions()
    pelvis = pelvis_index(skeleton)
    limbs = [_chain(skeleton, c, size) for c in skeleton.children(pelvis) if size[c] > 1]
    trunk = [c for c in limbs if len(skeleton.children(c[-1])) >= 3]
    legs = [c for c in limbs if c not in trunk]
    if len(limbs) != 3 or len(trunk) != 1 or len(legs) != 2:
        return None
    trunk = trunk[0]
    chest = trunk[-1]
    up = rest[chest] - rest[pelvis]
    if np.linalg.norm(up) < 1e-9:
        return None
    up = up / np.linalg.norm(up)
    branches = [_chain(skeleton, c, size) for c in skeleton.children(chest)]
    arms = _twins([b for b in branches if len(b) >= 4], skeleton)
    rest_of = [b for b in branches if arms is None or b not in arms]
    if arms is None or not rest_of:
        return None
    neck = max(rest_of, key=lambda b: (len(b), float(np.dot(rest[b[-1]] - rest[chest], up))))
    sided: dict[str, list[dict[str, int]]] = {}  # "leg"/"arm": the two chains' roles, in either order
    for kind, pair in (("leg", legs), ("arm", arms)):
        parts = []
        for chain in pair:
            k = _long_pair(skeleton, chain, 0 if kind == "leg" else 1)  # an arm starts at its clavicle
            if k is None or k + 2 >= len(chain):
                return None  # no foot or hand
            names = (("hip_bone",) * (k > 0) + ("thigh", "shin", "foot") + ("toe",) * (k + 3 < len(chain))
                     if kind == "leg" else ("clavicle", "upper_arm", "forearm", "hand"))
            start = k - 1 if k > 0 else 0
            parts.append(dict(zip(names, chain[start:])))
        if set(parts[0]) != set(parts[1]):
            return None
        sided[kind] = parts
    found = {"pelvis": pelvis}
    if pelvis != 0:
        found["root"] = 0
    for j, role in zip(trunk[:-1], ("spine", "spine_mid")):
        found[role] = j
    found["chest"] = chest
    found["neck"] = neck[0]
    if len(neck) >= 3:
        found["neck_upper"] = neck[1]
    if len(neck) >= 2:
        found["head"] = neck[-1]
    if "head" not in found:
        return None
    if not sides:
        return {r: found[r] for r in ROLES if r in found}
    named = joint_sides(skeleton.joint_names)
    votes = {kind: _side_votes(list(a.values()), named) - _side_votes(list(b.values()), named)
             for kind, (a, b) in sided.items()}
    if all(votes.values()):
        first_left = {kind: v > 0 for kind, v in votes.items()}
    else:
        toes = [p["toe"] for p in sided["leg"] if "toe" in p]
        feet = [p["foot"] for p in sided["leg"] if "toe" in p]
        if len(toes) != 2:
            return None
        forward = (rest[toes] - rest[feet]).sum(axis=0)
        forward = forward - np.dot(forward, up) * up
        if np.linalg.norm(forward) < 1e-9:
            return None
        left = np.cross(up, forward)
        first_left = {}
        for kind, parts in sided.items():
            top = "thigh" if kind == "leg" else "upper_arm"
            da, db = (float(np.dot(rest[p[top]] - rest[pelvis], left)) for p in parts)
            if da * db >= 0:
                return None
            first_left[kind] = da > 0
    for kind, parts in sided.items():
        for i, side in ((0, "left" if first_left[kind] else "right"), (1, "right" if first_left[kind] else "left")):
            for role, j in parts[i].items():
                found[f"{side}_{role}"] = j
    if len(set(found.values())) != len(found):
        return None
    return {r: found[r] for r in ROLES if r in found}


#: The terms of the takes of a rig family that is one data set's own rig: the 22-joint game rig of the Bandai Namco
#: Research Motiondataset 1 and 2 is that set's, CC BY-NC 4.0 (``../shared/data`` README). What is made from such
#: takes (a model: :mod:`mocapkit.cleaning.deep.provenance`; a database, its knowledge base, a reconstruction from
#: it) inherits them.
DATA_TERMS = MappingProxyType({
    "bandai_namco": "CC BY-NC 4.0: the Bandai Namco Research Motiondataset (Bandai Namco Research Inc.); "
                    "non-commercial use only",
})


def data_terms(skeletons, worded=DATA_TERMS) -> str | None:
    """The terms of :data:`DATA_TERMS` that takes on ``skeletons`` carry when each is of such a family (one line, the
    families' terms joined by "; " when several), else None: the project does not know them. ``worded``: the same
    families' terms as something made from the takes words them (a model's card:
    :data:`mocapkit.cleaning.deep.provenance.DATA_LICENCES`)."""
    found = [worded.get(rig_family(sk)) for sk in skeletons]
    if not found or any(t is None for t in found):
        return None
    return "; ".join(dict.fromkeys(found))
