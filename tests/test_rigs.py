"""mocapkit.rigs: families, roles and the pelvis on the real files of every rig in ../shared/data."""

from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import rigs, samples
from mocapkit.io.asfamc import read_asf
from mocapkit.motion import Skeleton, standard_joints
from tests.shared import (PYBVH, curated_files, daz_spelling, lafan_spelling, motionbuilder_spelling, respelled,
                          smpl_spelling, unity_spelling, unknown_rig, unnamed, unreal_spelling, xsens_spelling)

# the joint each family names for a few roles (what the files write, not what the code says)
EXPECTED = {
    "acclaim": {"pelvis": "root", "left_thigh": "lfemur", "left_hip_bone": "lhipjoint", "chest": "thorax",
                "right_upper_arm": "rhumerus", "left_hand": "lwrist", "left_thumb": "lthumb"},
    "cmu_bvh_motionbuilder": {"pelvis": "Hips", "left_thigh": "LeftUpLeg", "left_hip_bone": "LHipJoint",
                              "left_shin": "LeftLeg", "left_forearm": "LeftForeArm", "left_clavicle": "LeftShoulder",
                              "spine": "LowerBack", "chest": "Spine1", "left_palm": "LeftFingerBase"},
    "cmu_bvh_3dsmax": {"pelvis": "Hips", "left_thigh": "LeftHip", "left_shin": "LeftKnee",
                       "left_upper_arm": "LeftShoulder", "left_clavicle": "LeftCollar", "spine": "lowerback",
                       "chest": "Chest2"},
    "bandai_namco": {"root": "joint_Root", "pelvis": "Hips", "left_thigh": "UpperLeg_L",
                     "right_forearm": "LowerArm_R", "left_clavicle": "Shoulder_L", "chest": "Chest"},
    "mixamo": {"pelvis": "mixamorig:Hips", "left_thigh": "mixamorig:LeftUpLeg", "chest": "mixamorig:Spine2",
               "spine_mid": "mixamorig:Spine1", "left_clavicle": "mixamorig:LeftShoulder"},
    "humanik": {"pelvis": "Hips", "spine": "Spine", "chest": "Spine3", "spine_mid": "Spine1",
                "left_upper_arm": "LeftArm", "left_clavicle": "LeftShoulder"},
    "smpl": {"pelvis": "Pelvis", "left_thigh": "L_Hip", "left_shin": "L_Knee", "left_foot": "L_Ankle",
             "left_toe": "L_Foot", "left_clavicle": "L_Collar", "left_upper_arm": "L_Shoulder", "right_hand": "R_Wrist",
             "left_palm": "L_Hand", "spine": "Spine1", "spine_mid": "Spine2", "chest": "Spine3"},
    "cmu_bvh_daz": {"pelvis": "hip", "spine": "abdomen", "chest": "chest", "left_hip_bone": "lButtock",
                    "left_thigh": "lThigh", "right_shin": "rShin", "left_clavicle": "lCollar",
                    "left_upper_arm": "lShldr", "right_hand": "rHand", "left_thumb": "lThumb1"},
    "xsens_mvn": {"pelvis": "Hips", "spine": "Chest", "spine_mid": "Chest2", "chest": "Chest4", "neck": "Neck",
                  "left_thigh": "LeftHip", "right_shin": "RightKnee", "left_toe": "LeftToe",
                  "left_clavicle": "LeftCollar", "left_upper_arm": "LeftShoulder", "right_forearm": "RightElbow",
                  "right_hand": "RightWrist"},
    "unity_humanoid": {"pelvis": "Hips", "spine": "Spine", "spine_mid": "Chest", "chest": "UpperChest",
                       "left_thigh": "LeftUpperLeg", "right_shin": "RightLowerLeg", "left_toe": "LeftToes",
                       "left_clavicle": "LeftShoulder", "left_upper_arm": "LeftUpperArm",
                       "right_forearm": "RightLowerArm", "left_thumb": "LeftThumbProximal",
                       "right_fingers": "RightIndexProximal"},
    "unreal": {"root": "root", "pelvis": "pelvis", "left_thigh": "thigh_l", "right_shin": "calf_r",
               "left_toe": "ball_l", "left_clavicle": "clavicle_l", "left_upper_arm": "upperarm_l", "right_forearm": "lowerarm_r",
               "spine": "spine_01", "chest": "spine_03", "neck": "neck_01"},
}


def _skeleton(path):
    return read_asf(path) if path.suffix == ".asf" else mocapkit.load(path).skeleton


def _check(sk, family):
    assert rigs.rig_family(sk) == family
    r = rigs.roles(sk)
    names = {role: sk.joint_names[j] for role, j in r.items()}
    for role, name in EXPECTED[family].items():
        assert names[role] == name, (family, role)
    assert len(set(r.values())) == len(r)  # one joint per role
    assert list(r) == [x for x in rigs.ROLES if x in r]
    for role, j in r.items():  # each role hangs below its nearest present parent role
        up = rigs.PARENT_ROLE.get(role)
        while up is not None and up not in r:
            up = rigs.PARENT_ROLE.get(up)
        if up is not None:
            a = int(sk.parents[j])
            while a not in (-1, r[up]):
                a = int(sk.parents[a])
            assert a == r[up], (family, role)
    return r


def test_every_curated_rig_is_recognised(shared_data):
    seen = {}
    for path in curated_files(shared_data, "*.asf") + curated_files(shared_data, "*.bvh"):
        sk = _skeleton(path)
        family = rigs.rig_family(sk)
        seen.setdefault(family, []).append(path.name)
        r = _check(sk, family)
        # the pelvis carries the hips' translation: the root, except on the Bandai Namco rig
        expect = "Hips" if family == "bandai_namco" else sk.joint_names[0]
        assert sk.joint_names[rigs.pelvis_index(sk)] == expect
        if family in ("acclaim", "cmu_bvh_motionbuilder", "cmu_bvh_3dsmax"):
            assert len(r) == 31  # every joint of the CMU skeleton plays a role
    assert None not in seen
    assert set(seen) == {"acclaim", "cmu_bvh_motionbuilder", "cmu_bvh_3dsmax", "bandai_namco"}
    assert {"01_01.bvh"} <= set(seen["cmu_bvh_motionbuilder"]) and {"131_01.bvh"} <= set(seen["cmu_bvh_3dsmax"])


def test_peer_rigs_mixamo_humanik_and_unknown(shared_data):
    peer = shared_data / "peer_files"
    _check(_skeleton(peer / "20tab+bvh-python/tests/test_freebvh.bvh"), "mixamo")
    _check(_skeleton(peer / "VictorS-67+pybvh/bvh_data/standard_skeleton.bvh"), "humanik")
    assert rigs.rig_family(_skeleton(peer / "VictorS-67+pybvh/bvh_data/cmu_12_01_walk.bvh")) == "cmu_bvh_motionbuilder"
    sk = _skeleton(peer / "Wasserwecken+bvhio/bvhio/tests/example.bvh")  # LeftUpArm/LeftLowArm: no known family
    assert rigs.rig_family(sk) is None
    # ... but its tree shows every role it has (no toes: the sides come from its names)
    assert rigs.role_names(sk) == {
        "pelvis": "Hips", "left_thigh": "LeftUpLeg", "right_thigh": "RightUpLeg", "left_shin": "LeftLowLeg",
        "right_shin": "RightLowLeg", "left_foot": "LeftFoot", "right_foot": "RightFoot", "chest": "Chest",
        "neck": "Neck", "head": "Head", "left_clavicle": "LeftCollar", "right_clavicle": "RightCollar",
        "left_upper_arm": "LeftUpArm", "right_upper_arm": "RightUpArm", "left_forearm": "LeftLowArm",
        "right_forearm": "RightLowArm", "left_hand": "LeftHand", "right_hand": "RightHand"}


def test_bandai_pelvis_is_hips_not_the_floor_root():
    path = Path(__file__).parent / "data" / "dataset-1_dash_normal_001.bvh"
    m = mocapkit.load(path)
    sk = m.skeleton
    assert sk.joint_names[0] == "joint_Root" and rigs.rig_family(sk) == "bandai_namco"
    p = rigs.pelvis_index(sk)
    assert sk.joint_names[p] == "Hips"
    pos = m.global_positions()
    # the Hips travel and stay about a metre up (cm, Y up); joint_Root is the floor projection
    assert np.ptp(pos[:, p, 2]) > 100 or np.ptp(pos[:, p, 0]) > 100
    assert pos[:, p, 1].min() > 60 and abs(pos[:, 0, 1]).max() < 1


def test_smpl_and_unreal_rigs_on_real_takes():
    """SMPL's names (both spellings) on a CMU walk's BVH, Unreal's on a Bandai Namco take: each a family, the
    pelvis where the hips' translation is (``pelvis`` below Unreal's floor ``root``)."""
    smpl = smpl_spelling(motionbuilder_spelling(mocapkit.load(samples.path("12_walk.amc")))).skeleton
    assert smpl.num_joints == 24
    r = _check(smpl, "smpl")
    assert len(r) == 24 and rigs.pelvis_index(smpl) == 0
    lower = {"Pelvis": "pelvis", "Spine1": "spine1", "Spine2": "spine2", "Spine3": "spine3", "Neck": "neck",
             "Head": "head"}
    for old, new in (("L_Hip", "left_hip"), ("L_Knee", "left_knee"), ("L_Ankle", "left_ankle"), ("L_Foot", "left_foot"),
                     ("L_Collar", "left_collar"), ("L_Shoulder", "left_shoulder"), ("L_Elbow", "left_elbow"),
                     ("L_Wrist", "left_wrist"), ("L_Hand", "left_hand")):
        lower[old], lower["R" + old[1:]] = new, "right" + new[4:]
    smplx = Skeleton(tuple(lower[n] for n in smpl.joint_names), np.array(smpl.parents), smpl.offsets)
    assert rigs.rig_family(smplx) == "smpl" and rigs.roles(smplx) == r
    for pre in ("m_avg_", "f_avg_"):  # the SMPL FBX models' names
        fbx = Skeleton(tuple(pre + n for n in smpl.joint_names), np.array(smpl.parents), smpl.offsets)
        assert rigs.rig_family(fbx) == "smpl" and rigs.roles(fbx) == r
    unreal = unreal_spelling(mocapkit.load(Path(__file__).parent / "data" / "dataset-1_dash_normal_001.bvh")).skeleton
    r = _check(unreal, "unreal")
    assert "spine_mid" not in r and unreal.joint_names[rigs.pelvis_index(unreal)] == "pelvis"
    # UE5's five-segment spine: the chest is the highest, the middle spine the lowest left
    names = list(unreal.joint_names)
    names[names.index("spine_03")] = "spine_05"
    assert rigs.role_names(Skeleton(tuple(names), np.array(unreal.parents), unreal.offsets))["chest"] == "spine_05"


def test_the_daz_friendly_cmu_spelling():
    """The CMU walk as cgspeed's Daz-friendly release spells it (``hip``, ``abdomen``, ``lButtock``, ``lThigh``,
    ``lShldr`` ...; no middle spine, upper neck, toes or palms)."""
    sk = daz_spelling(motionbuilder_spelling(mocapkit.load(samples.path("12_walk.amc")))).skeleton
    r = _check(sk, "cmu_bvh_daz")
    assert len(r) == sk.num_joints and rigs.pelvis_index(sk) == 0


def test_the_xsens_mvn_rig():
    """Xsens MVN's BVH export, a real file (pybvh's test clip: ``Hips``, ``Chest`` ... ``Chest4``, ``LeftCollar``,
    ``LeftShoulder``, ``LeftHip``) and a CMU walk on its rig: the chest is the top of the trunk, where the neck and
    the collars hang (``Chest4``), and ``Chest3`` between plays no role; a Biovision trunk of ``Chest`` and
    ``Chest2`` (collars on ``Chest2``) is read as before, by the 3dsMax conversion's names."""
    real = mocapkit.load(Path(__file__).parent / "data" / "pybvh_test2_xsens.bvh").skeleton
    r = _check(real, "xsens_mvn")
    assert real.index("Chest3") not in r.values() and len(r) == real.num_joints - 1
    assert rigs.pelvis_index(real) == 0
    walk = motionbuilder_spelling(mocapkit.load(samples.path("12_walk.amc")))
    sk = xsens_spelling(walk).skeleton
    assert len(_check(sk, "xsens_mvn")) == sk.num_joints == 22
    names = {"LowerBack": "Chest", "Spine1": "Chest2", "LeftUpLeg": "LeftHip", "RightUpLeg": "RightHip",
             "LeftLeg": "LeftKnee", "RightLeg": "RightKnee", "LeftFoot": "LeftAnkle", "RightFoot": "RightAnkle",
             "LeftShoulder": "LeftCollar", "RightShoulder": "RightCollar", "LeftArm": "LeftShoulder",
             "RightArm": "RightShoulder", "LeftForeArm": "LeftElbow", "RightForeArm": "RightElbow",
             "LeftHand": "LeftWrist", "RightHand": "RightWrist"}
    biovision = respelled(walk, names, drop=("Spine", "Neck1", "LHipJoint", "RHipJoint", "LeftToeBase", "RightToeBase",
                                             "LeftFingerBase", "LFingers", "LThumb", "RightFingerBase", "RFingers",
                                             "RThumb")).skeleton
    assert rigs.rig_family(biovision) == "cmu_bvh_3dsmax"
    assert rigs.role_names(biovision)["chest"] == "Chest2"


def test_the_lafan1_rig():
    """A CMU walk on the rig of Ubisoft's LaFAN1 BVH files (HumanIK's names but ``LeftToe`` for the toes, no hip
    bones, upper neck or fingers): every joint plays a role, the toes too. The HumanIK family did not name
    ``LeftToe``, so the toes played none and their wobble at 30 fps was denoised as the body's noise."""
    walk = motionbuilder_spelling(mocapkit.load(samples.path("12_walk.amc")))
    sk = lafan_spelling(walk).skeleton
    assert rigs.rig_family(sk) == "humanik" and len(rigs.roles(sk)) == sk.num_joints == 22
    named = rigs.role_names(sk)
    assert (named["left_toe"], named["right_toe"], named["chest"], named["spine_mid"]) == (
        "LeftToe", "RightToe", "Spine2", "Spine1")


def test_the_unity_humanoid_rig():
    """A CMU walk on Unity's humanoid avatar (``HumanBodyBones`` names: ``Spine``, ``Chest``, ``UpperChest``,
    ``LeftShoulder`` the clavicle, ``LeftUpperArm``, ``LeftUpperLeg``, ``LeftToes``), every joint a role; without
    ``UpperChest`` (it is optional in Unity) the chest is ``Chest``; a ``Root`` above the hips (as VMC-protocol
    recorders write) plays the root, and the pelvis is still ``Hips``; VRoid's names for the same bones
    (``J_Bip_C_Hips``, ``J_Bip_L_UpperLeg``, ``J_Bip_L_ToeBase``) play the same roles."""
    walk = motionbuilder_spelling(mocapkit.load(samples.path("12_walk.amc")))
    sk = unity_spelling(walk).skeleton
    assert len(_check(sk, "unity_humanoid")) == sk.num_joints == 26
    names = list(sk.joint_names)
    short = respelled(unity_spelling(walk), {}, drop=("UpperChest",)).skeleton
    assert rigs.role_names(short)["chest"] == "Chest" and "spine_mid" not in rigs.roles(short)
    rooted = Skeleton(("Root",) + tuple(names), np.r_[-1, np.where(sk.parents < 0, 0, sk.parents + 1)],
                      np.r_[[np.zeros(3)], sk.offsets])
    r = _check(rooted, "unity_humanoid")
    assert r["root"] == 0 and rigs.pelvis_index(rooted) == 1
    # VRoid Studio's names for the same bones
    vroid = {"Shoulder": "Shoulder", "UpperArm": "UpperArm", "LowerArm": "LowerArm", "Hand": "Hand",
             "UpperLeg": "UpperLeg", "LowerLeg": "LowerLeg", "Foot": "Foot", "Toes": "ToeBase",
             "IndexProximal": "Index1", "ThumbProximal": "Thumb1"}
    renamed = {}
    for n in names:
        side = "L" if n.startswith("Left") else "R" if n.startswith("Right") else None
        renamed[n] = f"J_Bip_{side}_{vroid[n[4 if side == 'L' else 5:]]}" if side else f"J_Bip_C_{n}"
    vr = Skeleton(tuple(renamed[n] for n in names), np.array(sk.parents), sk.offsets)
    assert rigs.rig_family(vr) == "unity_humanoid" and rigs.roles(vr) == rigs.roles(sk)
    assert standard_joints(vr) == standard_joints(sk)


def test_roles_by_topology_are_the_roles_the_names_give():
    """Renamed ``bone0``, ``bone1``, ... (no family, no sides in the names), real rigs keep their roles: read from
    the tree and the rest pose (left is up crossed with the toes' direction), the same joints as their families
    name, the palms, fingers and thumbs left out; HumanIK with its toes, the 3dsMax conversion with its arms hanging
    down, the MotionBuilder release with its hip bones and long clavicles, Xsens and Unity rigs."""
    walk = motionbuilder_spelling(mocapkit.load(samples.path("12_walk.amc")))
    takes = [mocapkit.load(PYBVH), mocapkit.load(samples.path("131_01.bvh")), walk, xsens_spelling(walk),
             unity_spelling(walk), mocapkit.load(Path(__file__).parent / "data" / "pybvh_test2_xsens.bvh")]
    hands = ("palm", "fingers", "thumb")
    for take in takes:
        sk = take.skeleton
        named = {r: j for r, j in rigs.roles(sk).items() if not r.endswith(hands)}
        odd = unnamed(take).skeleton
        assert rigs.rig_family(odd) is None
        assert rigs.roles_by_topology(odd) == named == rigs.roles(odd), sk.joint_names[:3]
        assert rigs.roles_by_topology(sk) == named  # names that carry sides give the same
        middle = {r: j for r, j in named.items() if "left" not in r and "right" not in r}
        assert rigs.roles_by_topology(odd, sides=False) == middle


def test_roles_by_topology_refuse_what_is_not_plain(tmp_path):
    """Not read: a rig without toes whose names carry no side (which way is left?), the Bandai Namco rig renamed
    (its rest pose lies on its side: the toes point along the hips), and a chain of joints; the middle of the body
    is still read where the tree shows it."""
    odd = unknown_rig(tmp_path / "odd.bvh").skeleton  # pybvh's clip without toes
    assert rigs.roles_by_topology(odd) is None and rigs.roles(odd) == {"pelvis": 0}
    assert odd.joint_names[rigs.roles_by_topology(odd, sides=False)["head"]] == "bone7"
    daz = daz_spelling(motionbuilder_spelling(mocapkit.load(samples.path("12_walk.amc"))))
    assert rigs.roles_by_topology(unnamed(daz).skeleton) is None
    bandai = unnamed(mocapkit.load(Path(__file__).parent / "data" / "dataset-1_dash_normal_001.bvh")).skeleton
    assert rigs.roles_by_topology(bandai) is None
    chain = Skeleton(tuple(f"s{j}" for j in range(6)), np.array([-1, 0, 1, 2, 3, 4]), np.tile([0.0, 10.0, 0.0], (6, 1)))
    assert rigs.roles_by_topology(chain) is None and rigs.roles_by_topology(chain, sides=False) is None


def test_samples_and_an_unknown_rig_by_topology():
    assert rigs.rig_family(mocapkit.load(samples.path("12_walk.amc")).skeleton) == "acclaim"
    assert rigs.rig_family(mocapkit.load(samples.path("131_01.bvh")).skeleton) == "cmu_bvh_3dsmax"
    # a rig of made-up names: a floor root, then a branching joint
    sk = Skeleton(("ground", "pelvis_x", "legA", "legB", "trunk"), np.array([-1, 0, 1, 1, 1]), np.zeros((5, 3)))
    assert rigs.rig_family(sk) is None and rigs.pelvis_index(sk) == 1
    chain = Skeleton(("a", "b", "c"), np.array([-1, 0, 1]), np.zeros((3, 3)))
    assert rigs.pelvis_index(chain) == 0


def test_a_wrong_tree_is_not_a_family():
    """Acclaim names on the wrong joints (thigh and upper arm exchanged): no role may hang below the wrong parent."""
    sk = read_asf(samples.path("12.asf"))
    assert rigs.rig_family(sk) == "acclaim"
    swapped = list(sk.joint_names)
    i, k = swapped.index("lfemur"), swapped.index("lhumerus")
    swapped[i], swapped[k] = swapped[k], swapped[i]
    assert rigs.rig_family(Skeleton(tuple(swapped), np.array(sk.parents), sk.offsets)) is None


@pytest.mark.parametrize("family", list(rigs.FAMILIES))
def test_family_tables_name_only_known_roles(family):
    table = rigs.FAMILIES[family]
    assert set(table) <= set(rigs.ROLES)
    for core in ("pelvis", "left_thigh", "right_thigh", "head"):
        assert core in table


def _with_bone(skeleton: Skeleton, name: str, parent: str, offset=(0.0, 0.0, 8.0), leaf: bool = True) -> Skeleton:
    """``skeleton`` with a joint ``name`` hung from ``parent`` (a weapon, twist or tail bone); ``leaf=False`` gives
    it a child ``name_end`` too (a chain of two, as a tail)."""
    names, parents, offsets = list(skeleton.joint_names), list(skeleton.parents), [tuple(o) for o in skeleton.offsets]
    names.append(name)
    parents.append(names.index(parent))
    offsets.append(offset)
    if not leaf:
        names.append(f"{name}_end")
        parents.append(len(names) - 2)
        offsets.append(offset)
    return Skeleton(tuple(names), np.array(parents), np.array(offsets))


def test_one_answer_for_roles_when_bones_hang_beside_the_body():
    """Issue 5: an Unreal rig whose chest is ``spine_02`` (UE4's two-segment variant) keeps its chest in
    ``standard_joints`` (info, the F30 features) with a weapon, twist or tail bone added, as the family reads it."""
    take = unreal_spelling(mocapkit.load(Path(__file__).parent / "data" / "dataset-1_dash_normal_001.bvh"))
    names = list(take.skeleton.joint_names)
    names[names.index("spine_03")] = "spine_02"
    base = Skeleton(tuple(names), np.array(take.skeleton.parents), take.skeleton.offsets)
    variants = {"base": base, "weapon": _with_bone(base, "weapon_r", "hand_r"),
                "twist": _with_bone(base, "upperarm_twist_01_l", "upperarm_l"),
                "tail": _with_bone(base, "tail_01", "pelvis", offset=(0.0, -10.0, -10.0), leaf=False)}
    to_rigs = {"lower_back": "spine", "left_shoulder": "left_upper_arm", "right_shoulder": "right_upper_arm",
               "left_elbow": "left_forearm", "right_elbow": "right_forearm", "left_hip": "left_thigh",
               "right_hip": "right_thigh", "left_knee": "left_shin", "right_knee": "right_shin"}
    for what, sk in variants.items():
        assert rigs.rig_family(sk) == "unreal", what
        found = standard_joints(sk)
        assert sk.joint_names[found["chest"]] == "spine_02", what
        assert len(found) == len(mocapkit.motion.ROLES), what
        family = rigs.roles(sk)
        assert {r: j for r, j in found.items() if to_rigs.get(r, r) in family} == \
            {r: family[to_rigs.get(r, r)] for r in found if to_rigs.get(r, r) in family}, what


def test_the_pelvis_of_a_rig_read_from_nothing_is_the_one_rigs_gives():
    """Issue 5: on a Bandai take under names no family knows, with a two-joint weapon at the right hand (the tree
    then does not read plainly), ``find_joint`` and :func:`rigs.pelvis_index` agree on the pelvis: the hips below
    the floor root, not the root."""
    sk = mocapkit.load(Path(__file__).parent / "data" / "dataset-1_dash_normal_001.bvh").skeleton
    sk = _with_bone(sk, "weapon_r", "Hand_R", leaf=False)
    sk = Skeleton(tuple(f"bone{j}" for j in range(sk.num_joints)), np.array(sk.parents), sk.offsets)
    assert rigs.rig_family(sk) is None and rigs.roles_by_topology(sk, sides=False) is None
    assert mocapkit.motion.find_joint(sk, "pelvis") == rigs.pelvis_index(sk) == 1


def test_rig_family_is_read_once_per_skeleton(monkeypatch):
    # every role a step finds asks the family again: the families' names are read for the first ask only
    sk = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"), asf=samples.path("HDM_bk.asf")).skeleton
    same = Skeleton(tuple(sk.joint_names), np.array(sk.parents), np.array(sk.offsets))
    rigs.rig_family.cache_clear()  # the renamed skeleton below may be kept from another test (fit_context asks it)
    rigs.rig_family(sk)
    resolved = []
    read = rigs._resolve
    monkeypatch.setattr(rigs, "_resolve", lambda skeleton, family: resolved.append(family) or read(skeleton, family))
    assert rigs.rig_family(sk) == rigs.rig_family(same) == "acclaim"
    assert resolved == []
    renamed = Skeleton(tuple(n.upper() for n in sk.joint_names), np.array(sk.parents), np.array(sk.offsets))
    assert rigs.rig_family(renamed) != "acclaim" and len(resolved) == len(rigs.FAMILIES)


def test_rig_family_is_kept_per_skeleton_by_names_and_parents_in_a_bounded_cache():
    """rig_family reads only joint names and parents: a skeleton asked again is answered from functools' cache
    (64 kept), the same answer as a fresh pass, and another tree under the same names is asked anew."""
    sk = mocapkit.load(samples.path("131_01.bvh")).skeleton
    info = rigs.rig_family.cache_info
    rigs.rig_family.cache_clear()
    assert rigs.rig_family(sk) == "cmu_bvh_3dsmax" and info().misses == 1
    assert rigs.rig_family(sk) == "cmu_bvh_3dsmax" and info().hits == 1
    flat = Skeleton(sk.joint_names, np.r_[-1, np.zeros(sk.num_joints - 1, dtype=np.int64)], sk.offsets)
    assert rigs.rig_family(flat) is None and info().misses == 2  # a wrong tree is not the family
    assert info().maxsize == 64


# namespaces exporters write before every joint name: Maya HumanIK's default character, MotionBuilder and Maya
# namespaces, a Maya DAG path, an FBX namespace, two at once
NAMESPACES = ("Character1_", "Character1:", "rig|", "ns:", "mixamorig:", "ns:Character1_")


def _named(sk: Skeleton, names) -> Skeleton:
    return Skeleton(tuple(names), np.array(sk.parents), np.array(sk.offsets))


@pytest.mark.parametrize("prefix", NAMESPACES)
def test_a_namespace_before_every_joint_name_is_set_aside_for_the_family(prefix):
    """A user trial: `Character1_Hips`, `rig|Hips`, `ns:Hips` and a Bandai Namco rig exported as
    `mixamorig:UpperLeg_L` were of "none known" family, while the bare names are humanik / bandai_namco; with the
    family went the shipped model and its licence line. The prefix is set aside for the matching alone: the same
    family, roles, pelvis, sides, mirror partners and data terms, the file's names kept."""
    from mocapkit.motion import joint_sides, mirror_pairs

    data = Path(__file__).parent / "data"
    for sk, family in ((mocapkit.load(data / "dataset-1_dash_normal_001.bvh").skeleton, "bandai_namco"),
                       (mocapkit.load(samples.path("131_01.bvh")).skeleton, "cmu_bvh_3dsmax"),
                       (read_asf(samples.path("HDM_bk.asf")), "acclaim")):
        ns = _named(sk, [prefix + n for n in sk.joint_names])
        assert (rigs.rig_family(ns), rigs.family_prefix(ns), rigs.family_prefix(sk)) == (family, prefix, "")
        assert rigs.family_names(ns) == tuple(sk.joint_names) and ns.joint_names[0].startswith(prefix)
        assert rigs.roles(ns) == rigs.roles(sk) and rigs.pelvis_index(ns) == rigs.pelvis_index(sk)
        np.testing.assert_array_equal(mirror_pairs(ns.joint_names), mirror_pairs(sk.joint_names))
        assert joint_sides(ns.joint_names) == joint_sides(sk.joint_names)
        assert rigs.data_terms([ns]) == rigs.data_terms([sk])
    # an extra root the exporter left out of the namespace (one name in ten may lack it)
    sk = mocapkit.load(data / "dataset-1_dash_normal_001.bvh").skeleton
    ns = _named(sk, ["Reference"] + [prefix + n for n in sk.joint_names[1:]])
    assert rigs.rig_family(ns) == "bandai_namco" and rigs.family_prefix(ns) == prefix


def dag_paths(sk: Skeleton, namespace: str = "", leading: str = "|") -> tuple[str, ...]:
    """``sk``'s joint names as Maya writes each joint by its full DAG path: ``|Root|Hips|Spine`` (``leading`` the
    path's first ``|``), every part under ``namespace`` (``|Character1:Root|Character1:Hips``)."""
    paths: list[str] = []
    for j, n in enumerate(sk.joint_names):
        p = int(sk.parents[j])
        paths.append((leading if p < 0 else paths[p] + "|") + namespace + n)
    return tuple(paths)


@pytest.mark.parametrize("namespace, leading", [("", "|"), ("Character1:", "|"), ("", "")])
def test_joints_named_by_their_dag_paths_read_as_the_names_the_paths_end_in(namespace, leading):
    """Maya exports (and FBX-to-BVH converters) that name every joint by its full DAG path (`|Hips|LHipJoint|LeftHip`,
    `|Character1:joint_Root|Character1:Hips`) share no head to set aside, and the paths differ in depth: 131_01, the
    Bandai Namco dash and HDM05's bk were of no known family, the pelvis and sides read wrong. Each name is read by
    the last part of its path (then a namespace is set aside): the same family, roles, sides, mirror partners and
    data terms as the bare names, the file's names kept."""
    from mocapkit.motion import find_joint, joint_sides, mirror_pairs, ROLES

    data = Path(__file__).parent / "data"
    for sk, family in ((mocapkit.load(data / "dataset-1_dash_normal_001.bvh").skeleton, "bandai_namco"),
                       (mocapkit.load(samples.path("131_01.bvh")).skeleton, "cmu_bvh_3dsmax"),
                       (read_asf(samples.path("HDM_bk.asf")), "acclaim")):
        dag = _named(sk, dag_paths(sk, namespace, leading))
        assert "|" in dag.joint_names[-1] and dag.joint_names[-1].endswith(namespace + sk.joint_names[-1])
        assert (rigs.rig_family(dag), rigs.family_prefix(dag)) == (family, "*|" + namespace)
        assert rigs.family_names(dag) == tuple(sk.joint_names)
        assert rigs.roles(dag) == rigs.roles(sk) and rigs.pelvis_index(dag) == rigs.pelvis_index(sk)
        assert {r: find_joint(dag, r) for r in ROLES} == {r: find_joint(sk, r) for r in ROLES}
        np.testing.assert_array_equal(mirror_pairs(dag.joint_names), mirror_pairs(sk.joint_names))
        assert joint_sides(dag.joint_names) == joint_sides(sk.joint_names)
        assert rigs.data_terms([dag]) == rigs.data_terms([sk])


def test_names_that_match_as_written_or_not_at_all_keep_their_prefix():
    """Only a prefix (nearly) every name shares is set aside, and only where the names as written match no family:
    Mixamo's own `mixamorig:` stays mixamo, Bandai's `_L` suffixes and SMPL's `m_avg_` are read as written, and a
    rig whose names share a prefix but match no family without it is still of none known."""
    sk = mocapkit.load(samples.path("131_01.bvh")).skeleton
    humanik = {j: rigs.FAMILIES["humanik"][role][0] for role, j in rigs.roles(sk).items() if role in rigs.FAMILIES["humanik"]}
    names = [humanik.get(j, n) for j, n in enumerate(sk.joint_names)]  # 131_01 with HumanIK's names for its roles
    assert rigs.rig_family(_named(sk, names)) == "humanik"
    mixamo = _named(sk, ["mixamorig:" + n for n in names])
    assert (rigs.rig_family(mixamo), rigs.family_prefix(mixamo)) == ("mixamo", "")
    hik = _named(sk, ["Character1_" + n for n in names])
    assert (rigs.rig_family(hik), rigs.family_prefix(hik)) == ("humanik", "Character1_")
    bandai = mocapkit.load(Path(__file__).parent / "data" / "dataset-1_dash_normal_001.bvh").skeleton
    assert rigs.family_prefix(bandai) == "" and rigs.family_names(bandai) == tuple(bandai.joint_names)
    odd = _named(sk, ["Rig_" + n.upper() for n in sk.joint_names])  # LEFTHIP ...: no family, prefix or not
    assert rigs.rig_family(odd) is None and rigs.family_prefix(odd) == "" and rigs.family_names(odd) == odd.joint_names
    half = _named(sk, [("Character1_" if j % 4 else "") + n for j, n in enumerate(sk.joint_names)])
    assert rigs.rig_family(half) is None  # a quarter of the names without it: not a namespace
