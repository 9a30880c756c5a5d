import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mocapkit
from mocapkit import rotations as R
from mocapkit.errors import SkeletonError
from mocapkit.motion import (
    MIRROR_MISMATCH_MAX,
    Motion,
    Skeleton,
    channel_starts,
    concatenate,
    find_joint,
    joint_sides,
    mirror_mismatch,
    mirror_pairs,
    standard_joints,
    unit_scale_cm,
)


def random_motion(seed=0, frames=20, joints=7, with_axes=False, with_translations=False):
    rng = np.random.default_rng(seed)
    parents = np.array([-1] + [int(rng.integers(0, j)) for j in range(1, joints)])
    sk = Skeleton(
        joint_names=tuple(f"j{i}" for i in range(joints)),
        parents=parents,
        offsets=rng.normal(size=(joints, 3)),
        end_site_parents=np.array([joints - 1]),
        end_site_offsets=rng.normal(size=(1, 3)),
        axes=R.quaternion_normalize(rng.normal(size=(joints, 4))) if with_axes else None,
    )
    rot = R.quaternion_normalize(rng.normal(size=(frames, joints, 4)))
    tr = rng.normal(size=(frames, joints, 3)) if with_translations else None
    return Motion(sk, rot, rng.normal(size=(frames, 3)), fps=30.0, name="rand", translations=tr)


def naive_fk(motion):
    """Per frame, per joint 4x4 matrices: the obvious reference for Motion.global_transforms."""
    sk = motion.skeleton
    out = np.zeros((motion.num_frames, sk.num_joints, 3))
    local = motion.local_offsets()
    for f in range(motion.num_frames):
        mats = []
        for j in range(sk.num_joints):
            m = np.eye(4)
            m[:3, :3] = R.to_scipy(motion.rotations[f, j]).as_matrix()[0]
            m[:3, 3] = local[f, j]
            mats.append(m if sk.parents[j] < 0 else mats[sk.parents[j]] @ m)
            out[f, j] = mats[j][:3, 3]
    return out


@pytest.mark.parametrize("translations", [False, True])
def test_fk_matches_matrix_loop(translations):
    m = random_motion(3, with_translations=translations)
    np.testing.assert_allclose(m.global_positions(), naive_fk(m), atol=1e-12)


def test_end_sites_follow_their_joint():
    m = random_motion(4)
    p = m.global_positions(end_sites=True)
    grot = m.global_rotations()
    j = m.skeleton.end_site_parents[0]
    expected = p[:, j] + R.quaternion_rotate(grot[:, j], m.skeleton.end_site_offsets[0])
    np.testing.assert_allclose(p[:, m.num_joints], expected, atol=1e-12)
    assert m.skeleton.end_site_names == ("j6_end",)
    np.testing.assert_allclose(m.positions(["j6_end", "j2"]), p[:, [7, 2]])


def test_motion_is_immutable_and_replace_makes_new():
    m = random_motion(5)
    with pytest.raises(ValueError):
        m.rotations[0, 0, 0] = 2.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.fps = 10
    src = np.array(m.rotations)
    m2 = dataclasses.replace(m, rotations=src)
    src[0, 0, 0] = 99.0  # our view is read-only, the caller's array stays writable
    assert m2.rotations.flags.writeable is False


def test_bad_shapes_raise_with_the_expected_shape():
    m = random_motion(6)
    with pytest.raises(SkeletonError, match=r"expected shape \(F, 7, 4\)"):
        Motion(m.skeleton, np.zeros((5, 6, 4)), np.zeros((5, 3)), 30.0)
    with pytest.raises(SkeletonError, match="topological"):
        Skeleton(("a", "b", "c"), [-1, 2, 0], np.zeros((3, 3)))
    with pytest.raises(SkeletonError, match="fps"):
        Motion(m.skeleton, m.rotations, m.root_positions, 0.0)


def test_slicing():
    m = random_motion(7, frames=40)
    s = m[10:20]
    assert s.num_frames == 10 and s.fps == 30.0
    np.testing.assert_array_equal(s.rotations, m.rotations[10:20])
    t = m[::4]
    assert t.fps == 7.5 and t.num_frames == 10
    one = m[-1]
    assert one.num_frames == 1
    np.testing.assert_array_equal(one.root_positions[0], m.root_positions[-1])
    with pytest.raises(TypeError):
        m[[1, 2]]


def test_resample_to_quarter_rate_keeps_every_fourth_frame_exactly():
    m = random_motion(8, frames=41)
    m = dataclasses.replace(m, fps=120.0)
    r = m.resample(30)
    assert r.fps == 30 and r.num_frames == 11
    np.testing.assert_array_equal(r.rotations, m.rotations[::4])
    np.testing.assert_array_equal(r.root_positions, m.root_positions[::4])


def test_resample_interpolates_on_the_arc():
    sk = Skeleton(("root",), [-1], np.zeros((1, 3)))
    q = R.euler_to_quaternion(np.array([[0.0], [90.0]]), "Z")[:, None]
    m = Motion(sk, q, np.array([[0.0, 0, 0], [2.0, 0, 0]]), fps=1.0)
    r = m.resample(2.0)
    assert r.num_frames == 3
    assert abs(np.degrees(R.geodesic_angle(r.rotations[1, 0], R.euler_to_quaternion([45.0], "Z")))) < 1e-9
    np.testing.assert_allclose(r.root_positions[1], [1.0, 0, 0])


def test_nan_survives_slicing_resampling_mirroring_and_fk():
    m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:120]
    rot = np.array(m.rotations)
    rot[0, 5] = np.nan  # start
    rot[60, 7] = np.nan  # middle
    rot[-1, 9] = np.nan  # end
    g = dataclasses.replace(m, rotations=rot)
    assert g.missing()[[0, 60, 119], [5, 7, 9]].all() and g.missing().sum() == 3
    # a joint's own position hangs on its ancestors; its missing rotation makes its children missing
    child = m.skeleton.children(7)[0]
    assert np.isfinite(g.global_positions()[60, 7]).all()
    assert np.isnan(g.global_positions()[60, child]).all()
    assert np.isnan(g.global_rotations()[60, 7]).all()
    assert g.resample(30).missing()[0, 5] and g.resample(30).missing()[15, 7]
    perm = mirror_pairs(m.skeleton.joint_names)
    assert g.mirror().missing()[60, perm[7]]
    assert g[50:70].missing()[10, 7]


def test_mirror_reflects_and_swaps_exactly():
    m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:50]
    mm = m.mirror()
    perm = mirror_pairs(m.skeleton.joint_names)
    names = m.skeleton.joint_names
    assert names[perm[names.index("LeftWrist")]] == "RightWrist"
    assert names[perm[names.index("LHipJoint")]] == "RHipJoint"
    assert names[perm[names.index("Hips")]] == "Hips"
    p, q = m.global_positions(), mm.global_positions()
    flip = np.array([-1.0, 1.0, 1.0])  # CMU: x is lateral
    np.testing.assert_allclose(q, p[:, perm] * flip, atol=1e-9)
    # mirroring twice gives the original back
    back = mm.mirror()
    np.testing.assert_allclose(back.global_positions(), p, atol=1e-9)


SIDED_FRAMES_BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0 90 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 15 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 15 0 0
    }
  }
  JOINT UpperLeg_L
  {
    OFFSET 0 0 10
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT LowerLeg_L
    {
      OFFSET 40 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 40 0 0
      }
    }
  }
  JOINT UpperLeg_R
  {
    OFFSET 0 0 -10
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT LowerLeg_R
    {
      OFFSET -40 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET -40 0 0
      }
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
0 90 0 0 0 90 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
1 90 0 0 0 90 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
"""


def test_mirror_mismatch_tells_rigs_whose_frames_differ_by_side(tmp_path):
    """Bones along each joint's own axis, the right side's pointing the other way (as on game rigs): no reflection
    maps the skeleton onto itself, though mirroring stays exact for positions."""
    for name in ("131_01.bvh", "12_walk.amc"):
        assert mirror_mismatch(mocapkit.load(mocapkit.samples.path(name)).skeleton) < 0.05
    path = tmp_path / "sided.bvh"
    path.write_text(SIDED_FRAMES_BVH)
    m = mocapkit.load(path)
    assert mirror_mismatch(m.skeleton) > MIRROR_MISMATCH_MAX
    perm = mirror_pairs(m.skeleton.joint_names)
    for axis in range(3):
        flip = np.ones(3)
        flip[axis] = -1.0
        np.testing.assert_allclose(m.mirror(axis).global_positions(), m.global_positions()[:, perm] * flip, atol=1e-9)
        assert mirror_mismatch(m.skeleton, axis) > MIRROR_MISMATCH_MAX


def test_mirror_pairs_on_common_rigs():
    assert mirror_pairs(["joint_Root", "Hips", "UpperLeg_L", "UpperLeg_R"]).tolist() == [0, 1, 3, 2]
    assert mirror_pairs(["Hips", "LeftUpLeg", "RightUpLeg", "LThumb", "RThumb"]).tolist() == [0, 2, 1, 4, 3]
    assert mirror_pairs(["root", "lowerback", "lhumerus", "rhumerus"]).tolist() == [0, 1, 3, 2]


def test_concatenate():
    m = random_motion(9, frames=10)
    c = concatenate([m, m[2:5]], name="both")
    assert c.num_frames == 13 and c.name == "both"
    np.testing.assert_array_equal(c.rotations[10:], m.rotations[2:5])
    other = dataclasses.replace(m, fps=60.0)
    with pytest.raises(SkeletonError, match="fps"):
        concatenate([m, other])
    offsets = np.array(m.skeleton.offsets)
    offsets[3] *= 1.1  # another actor's bone: the result would draw the second part on the first's bones
    taller = dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, offsets=offsets), name="taller")
    with pytest.raises(SkeletonError, match=f"its bones differ .*offset of {m.skeleton.joint_names[3]!r}"):
        concatenate([m, taller])


def test_concatenate_refuses_two_hdm05_actors():
    bd = mocapkit.load(mocapkit.samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"))
    bk = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    with pytest.raises(SkeletonError, match="its bones differ"):
        concatenate([bd, bk])
    both = concatenate([bk, mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))])  # one actor
    assert both.num_frames > bk.num_frames


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), axes=st.booleans())
def test_channel_values_round_trip(seed, axes):
    rng = np.random.default_rng(seed)
    orders = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "ZX", "Y", ""]
    J = 6
    channels = [("Xposition", "Yposition", "Zposition") + tuple(f"{a}rotation" for a in "ZYX")]
    for _ in range(1, J):
        o = orders[rng.integers(len(orders))]
        channels.append(tuple(f"{a}rotation" for a in o))
    sk = Skeleton(
        tuple(f"j{i}" for i in range(J)),
        [-1, 0, 1, 2, 1, 4],
        rng.normal(size=(J, 3)),
        channels=tuple(channels),
        axes=R.quaternion_normalize(rng.normal(size=(J, 4))) if axes else None,
    )
    ncols = sum(len(c) for c in channels)
    values = rng.uniform(-80, 80, size=(5, ncols))
    m = Motion.from_channel_values(sk, values, fps=60)
    np.testing.assert_allclose(m.channel_values(), values, atol=1e-8)
    assert m.channel_names()[0] == "j0.Xposition"


def test_find_joint_on_cmu_hdm05_and_bvh_rigs():
    bvh = mocapkit.load(mocapkit.samples.path("131_01.bvh")).skeleton
    got = {r: bvh.joint_names[j] for r, j in standard_joints(bvh).items()}
    assert got["left_hand"] == "LeftWrist" and got["right_foot"] == "RightAnkle" and got["head"] == "Head"
    assert got["left_elbow"] == "LeftElbow" and got["left_shoulder"] == "LeftShoulder" and got["pelvis"] == "Hips"
    mb = Skeleton(
        ("Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot", "Spine", "Spine1",
         "Head", "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand", "RightShoulder", "RightArm",
         "RightForeArm", "RightHand"),
        [-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 8, 10, 11, 12, 8, 14, 15, 16],
        np.ones((18, 3)),
    )
    names = lambda role: mb.joint_names[find_joint(mb, role)]
    assert names("left_hand") == "LeftHand" and names("left_shoulder") == "LeftArm"
    assert names("left_knee") == "LeftLeg" and names("left_hip") == "LeftUpLeg" and names("chest") == "Spine1"
    bandai = Skeleton(
        ("joint_Root", "Hips", "Spine", "Chest", "Neck", "Head", "Shoulder_L", "UpperArm_L", "LowerArm_L", "Hand_L",
         "Shoulder_R", "UpperArm_R", "LowerArm_R", "Hand_R", "UpperLeg_L", "LowerLeg_L", "Foot_L", "UpperLeg_R",
         "LowerLeg_R", "Foot_R"),
        [-1, 0, 1, 2, 3, 4, 3, 6, 7, 8, 3, 10, 11, 12, 1, 14, 15, 1, 17, 18],
        np.ones((20, 3)),
    )
    names = lambda role: bandai.joint_names[find_joint(bandai, role)]
    assert names("pelvis") == "Hips" and names("right_hand") == "Hand_R" and names("left_foot") == "Foot_L"
    assert names("left_shoulder") == "UpperArm_L" and names("lower_back") == "Spine"
    with pytest.raises(KeyError, match="unknown role"):
        find_joint(bandai, "tail")


def test_find_joint_on_a_numbered_trunk():
    """Xsens MVN's ``Chest`` ... ``Chest4``, Unity's ``Spine``, ``Chest``, ``UpperChest`` and the 3dsMax CMU release's
    ``lowerback``, ``Chest``, ``Chest2``: the chest is the top of the trunk (where the collars hang), the lower back
    its bottom."""
    from tests.shared import motionbuilder_spelling, xsens_spelling

    real = mocapkit.load(Path(__file__).parent / "data" / "pybvh_test2_xsens.bvh").skeleton
    got = {r: real.joint_names[j] for r, j in standard_joints(real).items()}
    assert got["chest"] == "Chest4" and got["lower_back"] == "Chest" and got["left_shoulder"] == "LeftShoulder"
    assert got["left_hip"] == "LeftHip" and got["right_toe"] == "RightToe" and len(got) == 19
    sk = xsens_spelling(motionbuilder_spelling(mocapkit.load(mocapkit.samples.path("12_walk.amc")))).skeleton
    assert sk.joint_names[find_joint(sk, "chest")] == "Chest4"
    from tests.shared import unity_spelling

    unity = unity_spelling(motionbuilder_spelling(mocapkit.load(mocapkit.samples.path("12_walk.amc")))).skeleton
    assert unity.joint_names[find_joint(unity, "chest")] == "UpperChest"
    assert unity.joint_names[find_joint(unity, "left_shoulder")] == "LeftUpperArm"  # Unity's LeftShoulder: a clavicle
    cmu = mocapkit.load(mocapkit.samples.path("131_01.bvh")).skeleton
    assert cmu.joint_names[find_joint(cmu, "chest")] == "Chest2"
    assert cmu.joint_names[find_joint(cmu, "lower_back")] == "lowerback"


def test_find_joint_on_smpl_and_unreal_rigs():
    """SMPL's ``L_Hip`` (side prefix with an underscore) and Unreal's ``calf_l``, ``ball_l``, ``spine_03``: every
    role of Krüger's F39 features found, each on the joint of that body part."""
    from mocapkit.features import FEATURE_SETS
    from tests.shared import motionbuilder_spelling
    from tests.shared import smpl_spelling, unreal_spelling

    smpl = smpl_spelling(motionbuilder_spelling(mocapkit.load(mocapkit.samples.path("12_walk.amc")))).skeleton
    got = {r: smpl.joint_names[j] for r, j in standard_joints(smpl, FEATURE_SETS["F39"]).items()}
    assert got == {"left_hand": "L_Wrist", "right_hand": "R_Wrist", "left_foot": "L_Ankle", "right_foot": "R_Ankle",
                   "head": "Head", "left_elbow": "L_Elbow", "right_elbow": "R_Elbow", "left_knee": "L_Knee",
                   "right_knee": "R_Knee", "chest": "Spine3", "left_shoulder": "L_Shoulder",
                   "right_shoulder": "R_Shoulder", "lower_back": "Spine1"}
    assert smpl.joint_names[find_joint(smpl, "left_toe")] == "L_Foot"  # the toes below the ankle
    assert joint_sides(["L_Hip", "R_Hip", "Spine1"]) == ["left", "right", None]
    fbx = dataclasses.replace(smpl, joint_names=tuple("m_avg_" + n for n in smpl.joint_names))  # SMPL's FBX names
    assert standard_joints(fbx, FEATURE_SETS["F39"]) == standard_joints(smpl, FEATURE_SETS["F39"])
    assert mirror_pairs(fbx.joint_names).tolist() == mirror_pairs(smpl.joint_names).tolist()
    from tests.shared import daz_spelling

    daz = daz_spelling(motionbuilder_spelling(mocapkit.load(mocapkit.samples.path("12_walk.amc")))).skeleton
    got = {r: daz.joint_names[j] for r, j in standard_joints(daz).items()}
    assert got["left_shoulder"] == "lShldr" and got["right_hip"] == "rThigh" and got["left_knee"] == "lShin"
    assert got["lower_back"] == "abdomen" and got["chest"] == "chest" and got["left_hand"] == "lHand"
    assert joint_sides(["lThigh", "rThigh", "lowerback"]) == ["left", "right", None]
    # side markers inside a name, as 3ds Max Biped writes them
    assert joint_sides(["Bip01 L Thigh", "Bip01 R Thigh", "Bip01 Spine"]) == ["left", "right", None]
    bandai = mocapkit.load(Path(__file__).parent / "data" / "dataset-1_dash_normal_001.bvh")
    unreal = unreal_spelling(bandai).skeleton
    got = {r: unreal.joint_names[j] for r, j in standard_joints(unreal).items()}
    assert got["pelvis"] == "pelvis" and got["left_knee"] == "calf_l" and got["right_toe"] == "ball_r"
    assert got["chest"] == "spine_03" and got["lower_back"] == "spine_01" and got["neck"] == "neck_01"
    assert got["left_hand"] == "hand_l" and got["right_shoulder"] == "upperarm_r"


def test_unit_scale_checks_bone_lengths():
    bvh = mocapkit.load(mocapkit.samples.path("131_01.bvh")).skeleton
    assert unit_scale_cm(bvh) == pytest.approx(2.54 / 0.45)  # a CMU conversion, lengths in 1/0.45 inch
    scaled = dataclasses.replace(bvh, offsets=bvh.offsets * (2.54 / 0.45))
    assert unit_scale_cm(scaled) == 1.0  # the same body in centimetres
    tiny = dataclasses.replace(bvh, offsets=bvh.offsets * 1e-4)
    with pytest.raises(SkeletonError, match="cannot tell the length unit"):
        unit_scale_cm(tiny)


def test_frame_rates_outside_the_range_are_refused():
    from mocapkit.motion import FPS_RANGE, check_fps

    assert FPS_RANGE == (1.0, 10000.0)
    assert check_fps(1) == 1.0 and check_fps(2000) == 2000.0 and check_fps(10000) == 10000.0  # high-speed captures
    m = random_motion(12, frames=5)
    for bad in (0.01, 0.999, 10000.5, float("inf"), float("nan"), -30.0, "fast"):
        with pytest.raises(SkeletonError, match=r"fps must be a positive number from 1 to 10000 "):
            Motion(m.skeleton, m.rotations, m.root_positions, bad)
        with pytest.raises(SkeletonError, match=r"from 1 to 10000 "):
            m.resample(bad)


def test_resample_refuses_a_result_over_the_limit_before_allocating():
    from mocapkit.errors import MocapError
    from mocapkit.motion import RESAMPLE_LIMIT_BYTES

    # 300 frames at 1 fps made 1000 fps: 299,001 frames x 31 joints x 32 bytes = 296 MB > 256 MiB
    m = dataclasses.replace(random_motion(13, frames=300, joints=31), fps=1.0)
    assert 299_001 * 31 * 32 > RESAMPLE_LIMIT_BYTES
    with pytest.raises(MocapError, match=r"from 1 to 1000 fps would make 299,001 frames of 31 joints"):
        m.resample(1000)
    assert m.resample(100).num_frames == 29_901  # under the limit it works


def test_resample_in_blocks_equals_per_frame_interpolation():
    # 2,000 joints make blocks of 2,097 frames: 3,301 new frames take two blocks
    m = random_motion(14, frames=100, joints=2000, with_translations=True)
    rot = np.array(m.rotations)
    rot[50, 3] = np.nan
    m = dataclasses.replace(m, rotations=rot)
    r = m.resample(1000)
    assert r.num_frames == 3301 and r.fps == 1000.0
    for k in (0, 1, 1665, 2096, 2097, 2098, 3299, 3300):
        t = k * (30.0 / 1000.0)  # as resample computes it
        i0 = min(int(np.floor(t + 1e-9)), 99)
        i1 = min(i0 + 1, 99)
        a = t - i0
        if a == 0.0:
            np.testing.assert_array_equal(r.rotations[k], m.rotations[i0])
            np.testing.assert_array_equal(r.translations[k], m.translations[i0])
        else:
            want = R.slerp(m.rotations[i0], m.rotations[i1], np.full(2000, a))
            np.testing.assert_array_equal(r.rotations[k], want)
            np.testing.assert_allclose(r.root_positions[k], m.root_positions[i0] * (1 - a) + m.root_positions[i1] * a)
    assert np.isnan(r.rotations[1666:1700, 3]).all() and not np.isnan(r.rotations[1700:, 3]).any()


def test_messages_about_missing_joints_list_a_few_names_not_all():
    sk = Skeleton(tuple(f"j{j}" for j in range(5000)), np.arange(-1, 4999), np.ones((5000, 3)))
    with pytest.raises(KeyError) as exc:
        find_joint(sk, "left_foot")
    msg = exc.value.args[0]
    assert "j0, j1," in msg and msg.endswith("j39, ... (4,960 more)") and len(msg) < 400
    with pytest.raises(KeyError, match=r"no joint 'x'; joints are: j0, .*j39, \.\.\. \(4,960 more\)"):
        sk.index("x")


def test_a_motion_does_not_change_with_the_arrays_it_was_built_from():
    """Immutable means the caller's arrays changing afterwards leave the Motion and its Skeleton as built."""
    m = mocapkit.load(mocapkit.samples.path("12_walk.amc"))[:20]
    rot, root, offsets = np.array(m.rotations), np.array(m.root_positions), np.array(m.skeleton.offsets)
    built = Motion(dataclasses.replace(m.skeleton, offsets=offsets), rot, root, m.fps)
    before = built.global_positions().copy()
    rot[:] = [1.0, 0.0, 0.0, 0.0]
    root += 100.0
    offsets *= 2.0
    np.testing.assert_array_equal(built.global_positions(), before)
    for a in (built.rotations, built.root_positions, built.skeleton.offsets):
        assert not a.flags.writeable
    sliced = built[5:10]  # a frozen array's slice is a view, not a copy
    assert np.shares_memory(sliced.rotations, built.rotations)


def test_slices_say_what_is_wrong_with_them():
    m = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    with pytest.raises(ValueError, match="run forwards: the step must be a positive integer, got -1"):
        m[::-1]
    with pytest.raises(ValueError, match="a step of 1000 frames gives 0.12 fps"):
        m[::1000]
    assert m[-1].num_frames == 1 and m[::4].fps == 30.0


def test_a_motion_cannot_be_made_writable_again(tmp_path):
    """A Motion's arrays are views of read-only memory: ``setflags(write=True)`` is refused, so the take cannot be
    changed in place; a memory-mapped array is copied, so writes to the file under it leave the Motion as built."""
    m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:30]
    for built in (m, Motion(m.skeleton, np.array(m.rotations), np.array(m.root_positions), m.fps)):
        for a in (built.rotations, built.root_positions, built.skeleton.offsets):
            with pytest.raises(ValueError, match="WRITEABLE"):
                a.setflags(write=True)
    np.save(tmp_path / "rot.npy", np.array(m.rotations))
    mapped = np.load(tmp_path / "rot.npy", mmap_mode="r")
    built = Motion(m.skeleton, mapped, m.root_positions, m.fps)
    assert not np.shares_memory(built.rotations, mapped)
    w = np.load(tmp_path / "rot.npy", mmap_mode="r+")
    w[0, 0] = [0.0, 1.0, 0.0, 0.0]
    w.flush()
    np.testing.assert_array_equal(built.rotations, m.rotations)


def test_no_rate_from_a_bool_no_nan_offset_no_infinite_root():
    m = random_motion(4, frames=5)
    for bad in (True, np.bool_(True)):
        with pytest.raises(SkeletonError, match="fps must be a positive number"):
            Motion(m.skeleton, m.rotations, m.root_positions, bad)
    offsets = np.array(m.skeleton.offsets)
    offsets[2, 1] = np.nan
    with pytest.raises(SkeletonError, match=f"offsets: {m.skeleton.joint_names[2]} is .*finite"):
        dataclasses.replace(m.skeleton, offsets=offsets)
    with pytest.raises(SkeletonError, match="end_site_offsets"):
        Skeleton(("a", "b"), [-1, 0], np.zeros((2, 3)), [1], [[0.0, np.inf, 0.0]])
    root = np.array(m.root_positions)
    root[3, 0] = -np.inf
    with pytest.raises(SkeletonError, match="root_positions: frame 3 is infinite"):
        dataclasses.replace(m, root_positions=root)
    root[3, 0] = np.nan  # missing: allowed
    assert dataclasses.replace(m, root_positions=root).missing()[3, 0]


def test_missing_is_made_once_and_handed_out_as_a_new_array():
    """Motion.missing(): the mask made once per Motion (its arrays are read-only), each call a new writable array;
    a Motion made from it (replace, slicing) makes its own."""
    import dataclasses

    m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    rot = np.array(m.rotations)
    rot[5:9, 3] = np.nan
    m = dataclasses.replace(m, rotations=rot)
    a = m.missing()
    assert a.flags.writeable and np.array_equal(a, np.isnan(rot).any(axis=-1)) and a[5:9, 3].all()
    a[:] = True  # the caller's to change
    assert np.array_equal(m.missing(), np.isnan(rot).any(axis=-1)) and m.missing() is not m.missing()
    assert not m[10:].missing().any() and m[:20].missing()[5:9, 3].all()
    assert not dataclasses.replace(m, rotations=np.nan_to_num(m.rotations, nan=0.5)).missing().any()


def test_forward_kinematics_passes_the_kernel_one_argument_type():
    """Whatever a Motion holds (contiguous rotations, a strided slice's, animated translations), global_transforms
    calls the FK kernel with read-only inputs: numba compiles one machine code per argument type, so that one
    signature, which ``python -m mocapkit.warmup`` caches, serves every take."""
    from mocapkit._numba_fk import fk_kernel

    plain = random_motion(5)
    for m in (plain, plain[::2], random_motion(6, with_translations=True)):
        grot, gpos = m.global_transforms()
        assert np.allclose(gpos[:, 0], m.root_positions)
    inputs = {sig[1:3] for sig in fk_kernel.signatures}
    assert {(a.mutable, b.mutable) for a, b in inputs} == {(False, False)}, fk_kernel.signatures


def test_repr_counts_in_exact_plurals():
    """Trial T1: a one-frame slice printed "1 frames" (the house words: words.plural)."""
    take = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    assert repr(take[5]) == "Motion('131_01', 1 frame @ 120 fps, 31 joints, 0.01 s)"
    assert repr(take[:2]).startswith("Motion('131_01', 2 frames @ 120 fps, 31 joints")


def test_euler_angles_of_a_changed_take_convert_its_changed_cells_to_the_whole_conversions_bits():
    """A take made from another by with_rotations (noise on three joints, gaps as NaN), or sliced from it, gives the
    channel values a whole conversion of a fresh Motion gives, bit for bit (the changed cells converted alone, the
    others the take's), on the bundled HDM05 clip (ASF axes), the CMU BVH and a Bandai Namco take; a take with no
    Euler angles made gives them whole."""
    from mocapkit import corrupt

    for path in (mocapkit.samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"), mocapkit.samples.path("131_01.bvh"),
                 Path(__file__).parent / "data" / "dataset-1_bow_active_001.bvh"):
        take = mocapkit.load(path)
        whole = take.channel_values()
        noisy, _ = corrupt.angular_noise(take, amount=0.5, seed=1)
        gappy, _ = corrupt.gaps(take, seed=3)
        for other in (noisy, gappy):
            made = take.with_rotations(other.rotations)
            assert "_euler_seed" in made.__dict__
            fresh = dataclasses.replace(other).channel_values()
            assert np.array_equal(made.channel_values().view(np.int64), fresh.view(np.int64))
            part = take.with_rotations(other.rotations)[7:-5]
            assert np.array_equal(part.channel_values().view(np.int64), fresh[7:-5].view(np.int64))
            assert np.array_equal(made.euler_angles(), made.channel_values()[:, _rotation_columns(take)], equal_nan=True)
        assert np.array_equal(take[10:90].channel_values().view(np.int64), whole[10:90].view(np.int64))


def _rotation_columns(take):
    sk = take.skeleton
    return [i for i, ch in enumerate(c for j in range(sk.num_joints) for c in sk.joint_channels(j)) if ch.endswith("rotation")]


def test_a_pickled_motion_carries_no_euler_angles_of_another_take():
    """A Motion made from another (with_rotations) pickles without the other take's arrays, and gives the same
    channel values, bit for bit, where it is read back."""
    import pickle

    take = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    whole = take.channel_values()
    made = take.with_rotations(np.array(take.rotations))
    back = pickle.loads(pickle.dumps(made))
    assert "_euler_seed" in made.__dict__ and not {"_euler", "_euler_seed"} & set(back.__dict__)
    assert len(pickle.dumps(made)) == len(pickle.dumps(dataclasses.replace(made)))
    assert np.array_equal(back.channel_values().view(np.int64), whole.view(np.int64))


@pytest.mark.parametrize("clip", ["131_01.bvh", "HDM_bk_sneak2StepsLStart_004_120.amc"])
def test_channel_starts_slice_each_joints_columns_of_a_real_take(clip):
    m = mocapkit.load(mocapkit.samples.path(clip))
    sk = m.skeleton
    starts = channel_starts([sk.joint_channels(j) for j in range(sk.num_joints)])
    names, values = m.channel_names(), m.channel_values()
    assert starts.shape == (sk.num_joints + 1,) and starts[0] == 0 and starts[-1] == values.shape[1]
    sizes = {int(n) for n in np.diff(starts)}
    assert len(sizes) > 1  # joints of several channel counts (a 6-channel root, 1-3 dof AMC joints, none)
    for j, name in enumerate(sk.joint_names):
        assert names[starts[j]:starts[j + 1]] == [f"{name}.{c}" for c in sk.joint_channels(j)]
