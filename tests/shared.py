"""Real takes several test modules share: the curated takes of ``../shared/data`` that golden I/O tests
walk, a real take on a rig of no known family (:func:`unknown_rig`), any take under names that say nothing
(:func:`unnamed`), and real takes respelled on the rigs
users bring that ``../shared/data`` does not hold (:func:`smpl_spelling`, :func:`daz_spelling`,
:func:`xsens_spelling`, :func:`unity_spelling`, :func:`unreal_spelling`, :func:`lafan_spelling`,
:func:`motionbuilder_spelling`; the
benchmarks use them too).

``peer_files/`` (other projects' test files, many deliberately odd) and
``bandai_namco_full/`` (an archive to unpack) are not curated takes: the I/O
tests read the former by name, and nothing in ``make test`` needs the latter.
"""

from pathlib import Path

NOT_CURATED = ("peer_files", "bandai_namco_full")


def curated_files(shared_data: Path, pattern: str) -> list[Path]:
    """Every file under ``shared_data`` matching ``pattern`` (recursive), sorted, outside :data:`NOT_CURATED`."""
    return sorted(p for p in shared_data.rglob(pattern) if not set(p.relative_to(shared_data).parts) & set(NOT_CURATED))


#: A real take on a rig of its own (VictorS-67/pybvh's test clip, HumanIK names, Z up; see tests/data/README.md).
PYBVH = Path(__file__).resolve().parent / "data" / "pybvh_test1_zup.bvh"


def unnamed(motion):
    """``motion`` with its joints renamed ``bone0``, ``bone1``, ...: the same rig under names no family knows and
    that carry no side."""
    import dataclasses

    sk = motion.skeleton
    return dataclasses.replace(motion, skeleton=dataclasses.replace(
        sk, joint_names=tuple(f"bone{j}" for j in range(sk.num_joints))))


def unknown_rig(path: Path):
    """The pybvh clip without its toes and with its joints renamed ``bone0``, ``bone1``, ...: a real take on a rig
    of no known family whose names and rest pose do not tell left from right (no toes to show which way it faces:
    :func:`mocapkit.rigs.roles_by_topology` does not read it), which nothing shipped serves; saved as BVH at
    ``path``, returned as a Motion."""
    import mocapkit

    take = unnamed(respelled(mocapkit.load(PYBVH), {}, drop=("LeftToeBase", "RightToeBase")))
    mocapkit.save(take, path)
    return mocapkit.load(path)


def respelled(motion, names: dict, drop=()):
    """``motion`` on a rig that names its joints ``names[old]`` (unlisted ones keep theirs) and lacks the joints
    ``drop``: each dropped joint's rotation joins its children's (``L_dropped L_child``) and its rest offset theirs;
    its end sites hang from its nearest kept ancestor (one per joint), and a dropped leaf without one becomes one.
    The result is a take on that rig in its own right (a dropped joint that moved changes where its children
    are), which is what rig tests need: real motion under another family's names and topology. Rest rotations
    are the identity (BVH), and no joint but the root may carry animated translations where joints are dropped."""
    import numpy as np

    from mocapkit import rotations as R
    from mocapkit.motion import Motion, Skeleton

    sk = motion.skeleton
    drop = {sk.index(n) for n in drop}
    if drop and motion.translations is not None:
        raise ValueError("respelled: cannot drop joints of a take with animated translations")
    keep = [j for j in range(sk.num_joints) if j not in drop]
    new = {j: k for k, j in enumerate(keep)}
    rot = np.array(motion.rotations)
    parents, offsets = [], []
    for j in keep:
        p, off, q = int(sk.parents[j]), np.array(sk.offsets[j], dtype=np.float64), rot[:, j]
        while p in drop:
            off = off + sk.offsets[p]
            q = R.quaternion_multiply(rot[:, p], q)
            p = int(sk.parents[p])
        rot[:, j] = q
        parents.append(new[p] if p >= 0 else -1)
        offsets.append(off)
    ends, end_offsets = [], []
    for e, p in enumerate(sk.end_site_parents):
        off, p = np.array(sk.end_site_offsets[e], dtype=np.float64), int(p)
        while p in drop:
            off, p = off + sk.offsets[p], int(sk.parents[p])
        if p not in ends:
            ends.append(p)
            end_offsets.append(off)
    for j in sorted(drop):  # a dropped leaf (and its end sites) becomes one end site of its kept parent
        p = int(sk.parents[j])
        if not sk.children(j) and p not in drop and p not in ends:
            ends.append(p)
            end_offsets.append(np.array(sk.offsets[j], dtype=np.float64))
    channels = tuple(sk.channels[j] for j in keep) if sk.channels is not None else None
    rig = Skeleton(tuple(names.get(sk.joint_names[j], sk.joint_names[j]) for j in keep), np.array(parents),
                   np.array(offsets), np.array([new[p] for p in ends], dtype=np.int64),
                   np.array(end_offsets).reshape(-1, 3), channels=channels)
    tr = motion.translations[:, keep] if motion.translations is not None else None
    return Motion(rig, rot[:, keep], motion.root_positions, motion.fps, motion.name, tr)


def _sides(pairs: dict, left: str, right: str) -> dict:
    """Both sides of ``{"{s}Arm": "{s}_Shoulder", ...}``: ``{s}`` is ``Left``/``Right`` (``{c}`` ``L``/``R``) in the
    old names and ``left``/``right`` in the new."""
    out = {}
    for old, new in pairs.items():
        out[old.format(s="Left", c="L")] = new.format(s=left)
        out[old.format(s="Right", c="R")] = new.format(s=right)
    return out


def smpl_spelling(motion):
    """A CMU MotionBuilder-release BVH take (``Hips``, ``LHipJoint``, ``LeftUpLeg`` ...) on SMPL's rig and names:
    ``Pelvis``, ``Spine1-3``, ``Neck``, ``Head``, ``L_Hip``, ``L_Knee``, ``L_Ankle``, ``L_Foot``, ``L_Collar``,
    ``L_Shoulder``, ``L_Elbow``, ``L_Wrist``, ``L_Hand`` (24 joints): the hip bones, the upper neck, the fingers and
    the thumbs dropped (:func:`respelled`)."""
    names = {"Hips": "Pelvis", "LowerBack": "Spine1", "Spine": "Spine2", "Spine1": "Spine3"}
    names |= _sides({"{s}UpLeg": "{s}_Hip", "{s}Leg": "{s}_Knee", "{s}Foot": "{s}_Ankle", "{s}ToeBase": "{s}_Foot",
                     "{s}Shoulder": "{s}_Collar", "{s}Arm": "{s}_Shoulder", "{s}ForeArm": "{s}_Elbow",
                     "{s}Hand": "{s}_Wrist", "{s}FingerBase": "{s}_Hand"}, "L", "R")
    return respelled(motion, names, drop=("LHipJoint", "RHipJoint", "Neck1", "LFingers", "LThumb", "RFingers",
                                          "RThumb"))


def xsens_spelling(motion):
    """A CMU MotionBuilder-release BVH take on the rig and names of Xsens MVN's BVH export: ``Hips``, ``Chest``,
    ``Chest2``, ``Chest4`` (the thorax, where the neck and collars hang; no ``Chest3``), ``Neck``, ``Head``,
    ``LeftHip``, ``LeftKnee``, ``LeftAnkle``, ``LeftToe``, ``LeftCollar``, ``LeftShoulder``, ``LeftElbow``,
    ``LeftWrist`` (22 joints): the hip bones, the upper neck, the palms, fingers and thumbs dropped
    (:func:`respelled`)."""
    names = {"LowerBack": "Chest", "Spine": "Chest2", "Spine1": "Chest4"}
    names |= _sides({"{s}UpLeg": "{s}Hip", "{s}Leg": "{s}Knee", "{s}Foot": "{s}Ankle", "{s}ToeBase": "{s}Toe",
                     "{s}Shoulder": "{s}Collar", "{s}Arm": "{s}Shoulder", "{s}ForeArm": "{s}Elbow",
                     "{s}Hand": "{s}Wrist"}, "Left", "Right")
    return respelled(motion, names, drop=("LHipJoint", "RHipJoint", "Neck1", "LeftFingerBase", "LFingers", "LThumb",
                                          "RightFingerBase", "RFingers", "RThumb"))


def unity_spelling(motion):
    """A CMU MotionBuilder-release BVH take on the rig and names of Unity's humanoid avatar (``HumanBodyBones``):
    ``Hips``, ``Spine``, ``Chest``, ``UpperChest``, ``Neck``, ``Head``, ``LeftUpperLeg``, ``LeftLowerLeg``,
    ``LeftFoot``, ``LeftToes``, ``LeftShoulder`` (the clavicle), ``LeftUpperArm``, ``LeftLowerArm``, ``LeftHand``,
    ``LeftIndexProximal``, ``LeftThumbProximal`` (26 joints): the hip bones, the upper neck and the palms dropped
    (:func:`respelled`)."""
    names = {"LowerBack": "Spine", "Spine": "Chest", "Spine1": "UpperChest"}
    names |= _sides({"{s}UpLeg": "{s}UpperLeg", "{s}Leg": "{s}LowerLeg", "{s}ToeBase": "{s}Toes",
                     "{s}Arm": "{s}UpperArm", "{s}ForeArm": "{s}LowerArm", "{c}Fingers": "{s}IndexProximal",
                     "{c}Thumb": "{s}ThumbProximal"}, "Left", "Right")
    return respelled(motion, names, drop=("LHipJoint", "RHipJoint", "Neck1", "LeftFingerBase", "RightFingerBase"))


def unreal_spelling(motion):
    """A Bandai Namco take (``joint_Root``, ``Hips``, ``Spine``, ``Chest`` ...) under Unreal Engine mannequin names:
    ``root``, ``pelvis``, ``spine_01``, ``spine_03`` (no ``spine_02``), ``neck_01``, ``head``, ``clavicle_l``,
    ``upperarm_l``, ``lowerarm_l``, ``hand_l``, ``thigh_l``, ``calf_l``, ``foot_l``, ``ball_l``; the same rig."""
    names = {"joint_Root": "root", "Hips": "pelvis", "Spine": "spine_01", "Chest": "spine_03", "Neck": "neck_01",
             "Head": "head"}
    for a, b in (("L", "l"), ("R", "r")):
        names |= {f"Shoulder_{a}": f"clavicle_{b}", f"UpperArm_{a}": f"upperarm_{b}", f"LowerArm_{a}": f"lowerarm_{b}",
                  f"Hand_{a}": f"hand_{b}", f"UpperLeg_{a}": f"thigh_{b}", f"LowerLeg_{a}": f"calf_{b}",
                  f"Foot_{a}": f"foot_{b}", f"Toes_{a}": f"ball_{b}"}
    return respelled(motion, names)


def lafan_spelling(motion):
    """A CMU MotionBuilder-release BVH take on the rig of Ubisoft's LaFAN1 BVH files: ``Hips``, ``Spine``,
    ``Spine1``, ``Spine2``, ``Neck``, ``Head``, ``LeftShoulder``, ``LeftArm``, ``LeftForeArm``, ``LeftHand``,
    ``LeftUpLeg``, ``LeftLeg``, ``LeftFoot``, ``LeftToe`` (22 joints: the hip bones, the upper neck, the palms,
    fingers and thumbs dropped, :func:`respelled`), with position channels on every joint whose values are the
    offsets (as LaFAN1 writes them); the frame rate as given (LaFAN1's is 30 fps: slice ``[::4]`` a 120 fps take)."""
    import dataclasses

    import numpy as np

    names = {"LowerBack": "Spine", "Spine": "Spine1", "Spine1": "Spine2", "LeftToeBase": "LeftToe",
             "RightToeBase": "RightToe"}
    take = respelled(motion, names, drop=("LHipJoint", "RHipJoint", "Neck1", "LeftFingerBase", "LFingers", "LThumb",
                                          "RightFingerBase", "RFingers", "RThumb"))
    sk = take.skeleton
    pos = ("Xposition", "Yposition", "Zposition")
    channels = tuple(c if c[0].endswith("position") else pos + c for c in sk.channels)
    offsets = np.broadcast_to(sk.offsets, (take.num_frames, sk.num_joints, 3)).copy()
    offsets[:, 0] = take.root_positions
    return dataclasses.replace(take, skeleton=dataclasses.replace(sk, channels=channels), translations=offsets)


def motionbuilder_spelling(motion, order: str = "ZYX"):
    """``motion`` (an Acclaim ASF take) as the CMU MotionBuilder-release BVH spells it: the same rotations, joints
    renamed by role, three rotation channels in ``order`` on every joint, no axis frames."""
    import numpy as np

    from mocapkit import rigs
    from mocapkit.motion import Motion, Skeleton

    sk = motion.skeleton
    acclaim = rigs.roles(sk)
    mb = rigs.FAMILIES["cmu_bvh_motionbuilder"]
    names = [None] * sk.num_joints
    for role, j in acclaim.items():
        names[j] = mb[role][0]
    rot = tuple(f"{a}rotation" for a in order)
    channels = (("Xposition", "Yposition", "Zposition") + rot,) + (rot,) * (sk.num_joints - 1)
    bvh = Skeleton(tuple(names), np.array(sk.parents), sk.offsets, sk.end_site_parents, sk.end_site_offsets,
                   channels=channels)
    return Motion(bvh, motion.rotations, motion.root_positions, motion.fps, motion.name)


def daz_spelling(motion):
    """A CMU MotionBuilder-release BVH take on the rig and names of the Daz-friendly release: ``hip``, ``abdomen``,
    ``chest``, ``neck``, ``head``, ``lButtock``, ``lThigh``, ``lShin``, ``lFoot``, ``lCollar``, ``lShldr``,
    ``lForeArm``, ``lHand``, ``lThumb1``, ``lIndex1`` (the middle spine, upper neck, toes and palms dropped:
    :func:`respelled`)."""
    names = {"Hips": "hip", "LowerBack": "abdomen", "Spine1": "chest", "Neck": "neck", "Head": "head"}
    names |= _sides({"{c}HipJoint": "{s}Buttock", "{s}UpLeg": "{s}Thigh", "{s}Leg": "{s}Shin", "{s}Foot": "{s}Foot",
                     "{s}Shoulder": "{s}Collar", "{s}Arm": "{s}Shldr", "{s}ForeArm": "{s}ForeArm", "{s}Hand": "{s}Hand",
                     "{c}Fingers": "{s}Index1", "{c}Thumb": "{s}Thumb1"}, "l", "r")
    return respelled(motion, names, drop=("Spine", "Neck1", "LeftToeBase", "RightToeBase", "LeftFingerBase",
                                          "RightFingerBase"))


def record_map_ordered(monkeypatch) -> list:
    """Patch :func:`mocapkit.parallel.map_ordered` to run as before and keep every item it hands out; returns that
    list (what a batch's or a build's workers are given)."""
    import mocapkit.parallel

    seen: list = []
    real = mocapkit.parallel.map_ordered

    def spy(fn, items, **kwargs):
        items = list(items)
        seen.extend(items)
        return real(fn, items, **kwargs)

    monkeypatch.setattr(mocapkit.parallel, "map_ordered", spy)
    return seen


def t_pose_walk(seed: int = 1):
    """CMU 12_walk (bundled) opening with the rest pose, a T-pose, as the CMU BVH converter's frame 0 does, with
    three errors injected (``corrupt.real_errors``, ``seed``; 1: a spike, a flip and the feet swapped): the take
    ``clean``, ``detect`` and ``repair`` must treat alike, the calibration pose left alone."""
    import dataclasses

    import numpy as np

    import mocapkit
    from mocapkit import corrupt

    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    rest = np.array(walk.rotations[:1])
    rest[0, 1:] = (1.0, 0.0, 0.0, 0.0)
    take = dataclasses.replace(walk, rotations=np.concatenate([rest, walk.rotations]),
                               root_positions=np.concatenate([walk.root_positions[:1], walk.root_positions]),
                               name="t_pose_walk")
    return corrupt.real_errors(take, n_errors=3, seed=seed)[0]


def marker_decisions_file(folder: Path, inp: Path, choices: dict, name: str = "d.json", stamped: bool = True) -> Path:
    """A decisions file for the marker cleaning recorded in ``folder/out.clean.npz`` of ``inp``, written as
    ``folder/name``: as the report downloads it (``stamped``: keeping the digest of the cleaning reviewed) or as a
    person writes one by hand (not stamped)."""
    import json

    from mocapkit.cleaning.markers import decisions as md
    from mocapkit.cleaning.markers.record import read_marker_record
    from mocapkit.io import load_markers

    ms = load_markers(inp)
    res = md.result_from_record(ms, read_marker_record(folder / "out.clean.npz"))
    doc = md.template(ms, md.changes(ms, res.markers, res.fixes), inp.name, "out.c3d", choices,
                      cleaned=res.markers if stamped else None, record=folder / "out.clean.npz")
    path = folder / name
    path.write_text(json.dumps(doc))
    return path


def report_review(report: Path) -> dict:
    """The changes list and decisions document a clean report embeds (its ``mocapkit-review`` JSON)."""
    import json
    import re

    found = re.search(r'<script type="application/json" id="mocapkit-review">(.*?)</script>',
                      Path(report).read_text(encoding="utf-8"), re.S)
    assert found, "the report has no changes list"
    return json.loads(found.group(1))


def corrupted_walk(folder: Path) -> Path:
    """The bundled real CMU walk 12 with four real-style errors (seed 11), saved as ``folder/walk_bad.npz``."""
    import mocapkit
    from mocapkit import corrupt, samples

    bad, _, _ = corrupt.real_errors(mocapkit.load(samples.path("12_walk.amc")), n_errors=4, seed=11)
    inp = folder / "walk_bad.npz"
    mocapkit.save(bad, inp)
    return inp


def joined_sneaks():
    """Two real takes joined end to end (a cut at frame 200): HDM05 actor bk's sneak 004, frames 0-199, then its sneak
    005 from the frame whose pose is nearest 004's frame 199 (the smoothest join the two allow), on 004's skeleton."""
    import dataclasses

    import numpy as np

    import mocapkit
    from mocapkit import rotations as R

    a = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    b = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    start = int(np.argmin(np.nanmean(R.geodesic_angle(b.rotations, a.rotations[199][None]), axis=1)))
    a, b = a[:200], b[start:]
    return dataclasses.replace(a, rotations=np.concatenate([a.rotations, b.rotations]),
                               root_positions=np.concatenate([a.root_positions, b.root_positions]), name="joined")


def joined_sneaks_apart():
    """Two real takes joined end to end where the second capture starts elsewhere (a cut at frame 200 with a root
    jump): HDM05 actor bk's sneak 004, frames 0-199, then its sneak 005 from its first frame, whose root stands 78 cm
    from where 004's frame 199 left it, on 004's skeleton."""
    import dataclasses

    import numpy as np

    import mocapkit

    a = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))[:200]
    b = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    return dataclasses.replace(a, rotations=np.concatenate([a.rotations, b.rotations]),
                               root_positions=np.concatenate([a.root_positions, b.root_positions]), name="joined")
