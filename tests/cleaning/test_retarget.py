"""cleaning.deep.retarget: the one rule for which takes the networks serve, and the joint map onto the Acclaim rig."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, rigs, samples
from mocapkit import rotations as R
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import channels as ch
from mocapkit.cleaning.deep import retarget
from mocapkit.motion import Motion, Skeleton
from tests.shared import (PYBVH, daz_spelling, motionbuilder_spelling, smpl_spelling, unity_spelling, unknown_rig,
                          unnamed, unreal_spelling, xsens_spelling)

BANDAI = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"


def arms_down(motion: Motion, degrees: float = 90.0) -> Motion:
    """``motion`` (a BVH spelling, arms held out at rest) on a rest pose whose arms hang ``degrees`` down, every
    joint where it was: each arm's bones (upper arm down to the fingertips) turned by ``P`` (about the forward
    axis), their child offsets by ``P``, and their rotations so the world pose is the same (``L P^-1`` at the
    upper arm, ``P L P^-1`` below it): 90 as the CMU 3dsMax-friendly release holds its arms, 45 an A pose."""
    sk = motion.skeleton
    rot = np.array(motion.rotations)
    offsets = np.array(sk.offsets)
    ends = np.array(sk.end_site_offsets)
    for side, sign in (("left", 1.0), ("right", -1.0)):
        top = rigs.roles(sk)[f"{side}_upper_arm"]
        p = R.quaternion_from_axis_angle([0.0, 0.0, 1.0], -sign * np.radians(degrees))  # +-X towards -Y
        below = [j for j in range(sk.num_joints) if j != top and top in _ancestors(sk, j)]
        for j in [top] + below:
            for c in sk.children(j):
                offsets[c] = R.quaternion_rotate(p, offsets[c])
            for e in np.flatnonzero(sk.end_site_parents == j):
                ends[e] = R.quaternion_rotate(p, ends[e])
            rot[:, j] = R.quaternion_multiply(rot[:, j], R.quaternion_conjugate(p))
            if j != top:
                rot[:, j] = R.quaternion_multiply(p, rot[:, j])
    rested = Skeleton(sk.joint_names, np.array(sk.parents), offsets, sk.end_site_parents, ends, channels=sk.channels)
    return Motion(rested, rot, motion.root_positions, motion.fps, motion.name)


def _ancestors(sk: Skeleton, j: int) -> list[int]:
    out = []
    while sk.parents[j] >= 0:
        j = int(sk.parents[j])
        out.append(j)
    return out


def mixamo_spelling(motion: Motion) -> Motion:
    """``motion`` (a MotionBuilder-release BVH spelling) under Mixamo's names: every joint ``mixamorig:``, the
    fingers and thumbs HumanIK's ``LeftHandIndex1`` and ``LeftHandThumb1``, the CMU-only joints
    (``LowerBack``, ``LHipJoint``, the palms ``LeftFingerBase``) under names no role claims: a three-segment
    spine (``Spine``, ``Spine1``), no middle spine, no palms."""
    hik = {"LFingers": "LeftHandIndex1", "RFingers": "RightHandIndex1", "LThumb": "LeftHandThumb1",
           "RThumb": "RightHandThumb1"}
    sk = motion.skeleton
    names = tuple("mixamorig:" + hik.get(n, n) for n in sk.joint_names)
    mix = Skeleton(names, np.array(sk.parents), sk.offsets, sk.end_site_parents, sk.end_site_offsets,
                   channels=sk.channels)
    return Motion(mix, motion.rotations, motion.root_positions, motion.fps, motion.name)


@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(samples.path("12_walk.amc"))


@pytest.fixture(scope="module")
def ebf():
    return deep.shipped_model("ebf")


def test_an_asf_take_is_served_directly(walk, ebf):
    s = deep.served_by(walk, ebf)
    assert isinstance(s, deep.Serving) and s.direct and s.family == "acclaim"


@pytest.mark.parametrize("order", ["ZYX", "XYZ", "YXZ"])
def test_the_bvh_spelling_gives_the_model_the_asf_channels(walk, ebf, order):
    bvh = motionbuilder_spelling(walk, order)
    s = deep.served_by(bvh, ebf)
    assert isinstance(s, deep.Serving) and not s.direct and s.family == "cmu_bvh_motionbuilder"
    assert [bvh.skeleton.joint_names[j] for j in s.joints[:3]] == ["LeftUpLeg", "LeftLeg", "LeftFoot"]
    v_asf, c_asf = ch.encode(walk, ebf.layout)
    v_bvh, c_bvh = retarget.encode(bvh, s)
    # the fingers (fixed at 7.12502 deg in every training take) are read at the model's float32 mean of them
    assert np.abs(v_asf - v_bvh).max() < 1e-4 and np.abs(c_asf - c_bvh).max() < 1e-9
    assert np.abs(np.delete(v_asf - v_bvh, [ebf.layout.names.index(f"{s}fingers.Xrotation") for s in "lr"], 1)).max() < 1e-6


def test_decode_keeps_what_the_model_did_not_change(walk, ebf):
    bvh = motionbuilder_spelling(walk)
    s = deep.served_by(bvh, ebf)
    values, _ = retarget.encode(bvh, s)
    same = retarget.decode(values, bvh, s)
    assert np.array_equal(same.rotations, bvh.rotations)  # bit-identical, not just close
    moved = values.copy()
    moved[100:110, :3] += 5.0  # lfemur's channels over 10 frames
    out = retarget.decode(moved, bvh, s)
    thigh = bvh.skeleton.index("LeftUpLeg")
    diff = np.any(out.rotations != bvh.rotations, axis=-1)
    assert diff[100:110, thigh].all() and diff.sum() == 10
    back, _ = retarget.encode(out, s)
    assert np.allclose(back, moved, atol=1e-6)
    keep = np.zeros(diff.shape, dtype=bool)
    keep[100:105] = True
    assert np.any(retarget.decode(moved, bvh, s, keep=keep).rotations != bvh.rotations, axis=-1).sum() == 5


def test_denoise_and_fill_agree_on_both_spellings(walk, ebf):
    # the walk's first 120 frames (1 s): the two spellings' agreement does not depend on the take's length
    walk = walk[:120]
    noisy, _ = corrupt.angular_noise(walk, 0.5, seed=3)
    a = deep.denoise(noisy)
    b = deep.denoise(motionbuilder_spelling(noisy))
    # the joints the network never saw move (fingers, clavicles) get the fallback's filter on the map
    from mocapkit.cleaning.filters import savgol_smooth

    held = [walk.skeleton.index(n) for n in ("lfingers", "rfingers", "lclavicle", "rclavicle")]
    smooth = savgol_smooth(noisy, window_s=0.1, polyorder=2, joints=held, root=False)
    assert np.array_equal(b.rotations[:, held], smooth.rotations[:, held])
    body = np.delete(np.arange(walk.num_joints), held)
    assert np.degrees(R.geodesic_angle(a.rotations[:, body], b.rotations[:, body])).max() < 1e-3
    root_and_hipjoints = [0, walk.skeleton.index("lhipjoint"), walk.skeleton.index("rhipjoint")]
    assert np.array_equal(b.rotations[:, root_and_hipjoints], noisy.rotations[:, root_and_hipjoints])
    gapped, _ = corrupt.gaps(walk, seed=2, start_prob=0.02)
    fa = deep.fill_gaps(gapped)
    gb = motionbuilder_spelling(gapped)
    fb = deep.fill_gaps(gb)
    assert not fb.missing().any()
    # the fingers (NaN in gaps on the ASF, the model's mean on the map) are inputs too: close, not equal
    miss = gapped.missing()
    assert abs(_rms(walk, fb, miss) - _rms(walk, fa, miss)) < 0.05 * _rms(walk, fa, miss)
    obs = ~gapped.missing()
    assert np.array_equal(fb.rotations[obs], gb.rotations[obs])


def test_the_rule_refuses_other_rigs_with_the_reason(walk, ebf):
    bvh = motionbuilder_spelling(walk)
    sk = bvh.skeleton
    names = tuple("LeftLowerArm" if n == "LeftForeArm" else n for n in sk.joint_names)  # no left forearm role
    no_forearm = Motion(Skeleton(names, np.array(sk.parents), sk.offsets, sk.end_site_parents, sk.end_site_offsets,
                                 channels=sk.channels), bvh.rotations, bvh.root_positions, bvh.fps)
    why = deep.served_by(no_forearm, ebf)
    assert isinstance(why, str) and "has no joint for 1 of its 28 joints: lradius" in why
    odd = Skeleton(("a", "b", "c"), np.array([-1, 0, 1]), np.ones((3, 3)))
    why = deep.served_by(odd, ebf)
    assert isinstance(why, str) and "no joint map is known" in why
    with pytest.raises(mocapkit.errors.SkeletonError, match="has no joint for"):
        deep.denoise(no_forearm, ebf)


@pytest.mark.parametrize("degrees", [90.0, 45.0])
def test_a_rest_pose_with_the_arms_down_is_retargeted(walk, ebf, degrees):
    """The same pose on a rig whose arms hang down at rest (90 deg, or an A pose): the model reads the same
    channels (step 2)."""
    bvh = motionbuilder_spelling(walk)
    down = arms_down(bvh, degrees)
    assert np.allclose(down.global_positions(end_sites=True), bvh.global_positions(end_sites=True), atol=1e-9)
    s = deep.served_by(down, ebf)
    assert isinstance(s, deep.Serving) and "retargeted" in s.describe()
    moved = {ebf.layout.joints[k] for k in s.retargeted}
    assert {"lhumerus", "lradius", "lwrist", "rhumerus", "rradius", "rwrist"} <= moved
    assert not moved & {"lfemur", "ltibia", "lowerback", "thorax", "head", "lclavicle"}
    v_bvh, c_bvh = retarget.encode(bvh, deep.served_by(bvh, ebf))
    v_down, c_down = retarget.encode(down, s)
    assert np.abs(v_down - v_bvh).max() < 1e-6 and np.abs(c_down - c_bvh).max() < 1e-9
    assert np.array_equal(retarget.decode(v_down, down, s).rotations, down.rotations)
    # denoised by the network on either rest pose: the same body (guard=False: the guard reads local rotations)
    noisy, _ = corrupt.angular_noise(bvh, 0.5, seed=3, joints=["LeftArm", "LeftForeArm", "RightUpLeg"])
    a = deep.denoise(noisy, guard=False)
    b = deep.denoise(arms_down(noisy, degrees), guard=False)
    assert np.abs(a.global_positions() - b.global_positions()).max() < 1e-6 * np.abs(a.global_positions()).max()


def test_a_mixamo_rig_lacking_joints_is_served(walk, ebf):
    """Mixamo's names: no middle spine (half the turn of the spine above it), no palms, and fingers the network
    never saw move (held at the model's means), the rest mapped by role."""
    mix = mixamo_spelling(motionbuilder_spelling(walk))
    assert rigs.rig_family(mix.skeleton) == "mixamo"
    s = deep.served_by(mix, ebf)
    assert isinstance(s, deep.Serving) and not s.retargeted
    assert {ebf.layout.joints[k] for k in s.lacking} == {"upperback", "lhand", "rhand", "lfingers", "rfingers",
                                                         "lclavicle", "rclavicle"}  # the last four never moved
    values, _ = retarget.encode(mix, s)
    v_asf, _ = ch.encode(walk, ebf.layout)
    names = ebf.layout.joints
    cols = {n: [i for i, c in enumerate(ebf.layout.names) if c.split(".")[0] == n] for n in names}
    for name in ("lhand", "rhand", "lfingers", "rfingers", "lclavicle", "rclavicle"):
        assert np.array_equal(values[:, cols[name]], np.broadcast_to(s.filler[cols[name]], (len(values), len(cols[name]))))
    for name in names:  # the spine's lower two segments are read as one, and the palms' turn joins the fingers
        if name not in ("lowerback", "upperback", "thorax", "lhand", "rhand", "lfingers", "rfingers", "lclavicle",
                        "rclavicle"):
            assert np.abs(values[:, cols[name]] - v_asf[:, cols[name]]).max() < 1e-6, name
    # the middle spine and the chest share the chest's turn: the two halves make it again
    m = retarget._dof_rotations(mix, s)
    up, th = names.index("upperback"), names.index("thorax")
    halves = R.quaternion_multiply(retarget._conj(s.axes[up], m[:, up]), retarget._conj(s.axes[th], m[:, th]))
    assert np.degrees(R.geodesic_angle(halves, mix.rotations[:, mix.skeleton.index("mixamorig:Spine1")])).max() < 1e-6
    assert np.array_equal(retarget.decode(values, mix, s).rotations, mix.rotations)
    noisy, _ = corrupt.angular_noise(mix, 0.5, seed=4)
    out, method, note = deep.denoise_or_fallback(noisy)
    assert method == "EBF (shipped, via the mixamo joint map)" and note == _acclaim_terms()  # no fallback: only the pair's licence line
    assert _rms(mix, out) < 0.6 * _rms(mix, noisy)
    gapped, _ = corrupt.gaps(mix, seed=5, start_prob=0.02)
    filled, method, _ = deep.fill_or_fallback(gapped)
    obs = ~gapped.missing()
    assert method.startswith("EBD") and not filled.missing().any()
    assert np.array_equal(filled.rotations[obs], gapped.rotations[obs])


def test_joints_the_map_does_not_cover_get_the_fallback_filter(walk):
    """Denoising a mapped rig: a joint no role claims (the Mixamo spelling's LowerBack) is smoothed as the
    fallback would, the joints above the pelvis and the root are not touched."""
    from mocapkit.cleaning.filters import savgol_smooth

    mix = mixamo_spelling(motionbuilder_spelling(walk))
    back = mix.skeleton.index("mixamorig:LowerBack")
    noisy, _ = corrupt.angular_noise(mix, 0.5, seed=9, joints=["mixamorig:LowerBack", "mixamorig:LeftUpLeg"])
    out = deep.denoise(noisy)
    smooth = savgol_smooth(noisy, window_s=0.1, polyorder=2, joints=[back], root=False)
    assert np.array_equal(out.rotations[:, back], smooth.rotations[:, back])
    assert np.array_equal(out.rotations[:, 0], noisy.rotations[:, 0])


def biovision_spelling(bvh: Motion) -> Motion:
    """A MotionBuilder-release CMU BVH under the 3dsMax/Biovision names (``Chest``, ``Chest2``, ``Neck``,
    ``LeftHip`` ...), its lower back and lower neck under names no role claims: a trunk of four segments."""
    mb = rigs.FAMILIES["cmu_bvh_motionbuilder"]
    bio = rigs.FAMILIES["cmu_bvh_3dsmax"]
    rename = {mb[r][0]: bio[r][0] for r in mb if r in bio and r not in ("spine", "neck")}
    rename.update({"LowerBack": "Waist", "Neck": "NeckBase"})
    sk = bvh.skeleton
    return Motion(Skeleton(tuple(rename.get(n, n) for n in sk.joint_names), np.array(sk.parents), sk.offsets,
                           sk.end_site_parents, sk.end_site_offsets, channels=sk.channels),
                  bvh.rotations, bvh.root_positions, bvh.fps, bvh.name)


def test_a_trunk_lacking_segments_shares_their_turns(walk, ebf):
    """A four-segment trunk (no lower back, no lower neck): each lacking segment takes half the turn of the
    segment mapped right below it; two lacking in a row are refused."""
    bvh = motionbuilder_spelling(walk)
    bio = biovision_spelling(bvh)
    assert rigs.rig_family(bio.skeleton) == "cmu_bvh_3dsmax"
    s = deep.served_by(bio, ebf)
    assert isinstance(s, deep.Serving)
    names = ebf.layout.joints
    assert {names[k] for k in s.lacking} >= {"lowerback", "lowerneck"}
    assert s.shares[names.index("upperback")] == names.index("lowerback")
    assert s.shares[names.index("upperneck")] == names.index("lowerneck")
    values, _ = retarget.encode(bio, s)
    mb_values, _ = retarget.encode(bvh, deep.served_by(bvh, ebf))
    limbs = [i for i, c in enumerate(ebf.layout.names) if c.split(".")[0][1:] in ("femur", "tibia", "humerus", "radius")]
    assert np.abs(values[:, limbs] - mb_values[:, limbs]).max() < 1e-6
    assert np.array_equal(retarget.decode(values, bio, s).rotations, bio.rotations)
    noisy, _ = corrupt.angular_noise(bio, 0.5, seed=7)
    assert _rms(bio, deep.denoise(noisy)) < 0.6 * _rms(bio, noisy)
    sk = bio.skeleton  # without Chest too, the lower and middle back lack in a row
    names2 = tuple("Loin" if n == "Chest" else n for n in sk.joint_names)
    two = Motion(Skeleton(names2, np.array(sk.parents), sk.offsets, sk.end_site_parents, sk.end_site_offsets,
                          channels=sk.channels), bio.rotations, bio.root_positions, bio.fps)
    why = deep.served_by(two, ebf)
    assert isinstance(why, str) and "lacks lowerback" in why


def test_a_biovision_take_from_another_project_is_served_better_than_the_fallback(shared_data, ebf):
    """20tab/bvh-python's test take: Hips, Chest, Chest2, Neck, Head and limbs to the wrists, 30 fps."""
    take = mocapkit.load(shared_data / "peer_files" / "20tab+bvh-python" / "tests" / "test_mocapbank.bvh")
    s = deep.served_by(take, ebf)
    assert isinstance(s, deep.Serving) and s.family == "cmu_bvh_3dsmax"
    from mocapkit.cleaning.filters import savgol_smooth

    noisy, _ = corrupt.angular_noise(take, 0.5, seed=8)
    assert _rms(take, deep.denoise(noisy)) < _rms(take, savgol_smooth(noisy, 0.1, 2, root=False))


@pytest.mark.parametrize("rig", ["smpl", "cmu_bvh_daz", "xsens_mvn", "unity_humanoid", "unreal"])
def test_rigs_users_bring_are_served_better_than_the_fallback(walk, ebf, rig):
    """SMPL's rig (a CMU walk on its 24 joints: no hip bones, upper neck, fingers or thumbs), the CMU Daz-friendly
    release's (no middle spine, upper neck, toes or palms), Xsens MVN's (a ``Chest`` ... ``Chest4`` trunk, no hip
    bones, palms or fingers), Unity's humanoid avatar (no hip bones, upper neck or palms) and Unreal's mannequin
    names (a Bandai Namco take: floor root, no middle spine) through the Acclaim networks' joint map: observed cells
    come back as they were, 0.5 noise is denoised better than by the fallback, gaps are filled."""
    from mocapkit.cleaning.filters import savgol_smooth

    bandai = BANDAI.with_name("dataset-1_dash_chimpira_001.bvh")  # 69 frames (the normal dash has 20)
    spell = {"smpl": smpl_spelling, "cmu_bvh_daz": daz_spelling, "xsens_mvn": xsens_spelling,
             "unity_humanoid": unity_spelling}
    take = spell[rig](motionbuilder_spelling(walk)) if rig in spell else unreal_spelling(mocapkit.load(bandai))
    s = deep.served_by(take, ebf)
    assert isinstance(s, deep.Serving) and s.family == rig and not s.direct
    assert deep.shipped_model("ebf", take) is ebf  # the Bandai rig's own model (CC BY-NC) serves its own names only
    values, _ = retarget.encode(take, s)
    assert np.array_equal(retarget.decode(values, take, s).rotations, take.rotations)
    noisy, _ = corrupt.angular_noise(take, 0.5, seed=3)
    out, method, note = deep.denoise_or_fallback(noisy)
    assert method == f"EBF (shipped, via the {rig} joint map)" and note == _acclaim_terms()  # no fallback: only the pair's licence line
    assert _rms(take, out) < 0.95 * _rms(take, savgol_smooth(noisy, 0.1, 2, root=False))
    gapped, _ = corrupt.gaps(take, seed=5, start_prob=0.02)
    filled, method, _ = deep.fill_or_fallback(gapped)
    obs = ~gapped.missing()
    assert method.startswith("EBD") and not filled.missing().any()
    assert np.array_equal(filled.rotations[obs], gapped.rotations[obs])


def test_a_z_up_humanik_rig_from_another_project_is_served(ebf):
    """pybvh's test clip (HumanIK names, Z up, inches, 30 fps, no palms, fingers or thumbs): its body frame
    turned onto the Acclaim one, denoised better than the fallback would."""
    take = mocapkit.load(PYBVH)
    s = deep.served_by(take, ebf)
    assert isinstance(s, deep.Serving) and s.family == "humanik" and abs(s.body[0]) < 0.9
    values, _ = retarget.encode(take, s)
    assert np.array_equal(retarget.decode(values, take, s).rotations, take.rotations)
    from mocapkit.cleaning.filters import savgol_smooth

    noisy, _ = corrupt.angular_noise(take, 0.5, seed=6)
    out = deep.denoise(noisy)
    assert _rms(take, out) < 0.8 * _rms(take, noisy)
    assert _rms(take, out) < _rms(take, savgol_smooth(noisy, 0.1, 2, root=False))


def test_a_real_xsens_mvn_file_is_served(ebf):
    """pybvh's Xsens MVN clip (its own rest pose, 120 fps): the shipped EBF serves it through the xsens_mvn map,
    retargeted from its rest pose, and an untouched decode is bit-identical."""
    take = mocapkit.load(PYBVH.with_name("pybvh_test2_xsens.bvh"))
    s = deep.served_by(take, ebf)
    assert isinstance(s, deep.Serving) and s.family == "xsens_mvn" and not s.direct
    values, _ = retarget.encode(take, s)
    assert np.array_equal(retarget.decode(values, take, s).rotations, take.rotations)
    noisy, _ = corrupt.angular_noise(take, 0.5, seed=2)
    out, method, _ = deep.denoise_or_fallback(noisy)
    assert method == "EBF (shipped, via the xsens_mvn joint map)"
    assert _rms(take, out) < 0.6 * _rms(take, noisy)


def test_a_rig_of_no_known_names_is_served_through_its_tree(walk, ebf):
    """A CMU walk under names no family knows (``bone0``, ``bone1``, ...): the roles its tree and rest pose show
    (:func:`mocapkit.rigs.roles_by_topology`) map it onto the Acclaim networks, denoising within 5 % of the named
    MotionBuilder map (which also shows the network the palms); an untouched decode is bit-identical; clean runs
    on it end to end and leaves the clean take as it is."""
    from mocapkit.cleaning.filters import savgol_smooth

    named = motionbuilder_spelling(walk)
    take = unnamed(named)
    s = deep.served_by(take, ebf)
    assert isinstance(s, deep.Serving) and s.family == retarget.INFERRED and not s.direct
    assert "tree and rest pose" in s.describe()
    values, _ = retarget.encode(take, s)
    assert np.array_equal(retarget.decode(values, take, s).rotations, take.rotations)
    noisy, _ = corrupt.angular_noise(take, 0.5, seed=4)
    out, method, note = deep.denoise_or_fallback(noisy)
    assert method == "EBF (shipped, via the inferred joint map)" and note == _acclaim_terms()  # no fallback: only the pair's licence line
    by_name = deep.denoise(dataclasses.replace(noisy, skeleton=named.skeleton))
    assert _rms(take, out) < 1.05 * _rms(named, by_name)
    assert _rms(take, out) < 0.95 * _rms(take, savgol_smooth(noisy, 0.1, 2, root=False))
    res = mocapkit.clean(take)
    assert not res.changed.any() and np.array_equal(res.motion.rotations, take.rotations)


def test_fallbacks_are_the_same_everywhere(walk, tmp_path):
    bandai = unknown_rig(tmp_path / "odd.bvh")  # a rig nothing ships for
    den, method, note = deep.denoise_or_fallback(bandai)
    assert method == deep.FALLBACK_DENOISE and note.startswith("Savitzky-Golay: the shipped EBF does not serve")
    assert np.array_equal(den.rotations[:, 0], bandai.rotations[:, 0])
    gapped, _ = corrupt.gaps(bandai, seed=1, start_prob=0.02)
    filled, method, note = deep.fill_or_fallback(gapped)
    assert method == deep.FALLBACK_FILL and note.startswith("cubic spline: the shipped EBD does not serve")
    assert not filled.missing().any()
    same, method, note = deep.fill_or_fallback(bandai)
    assert same is bandai and method == "nothing (no gaps)" and note == ""
    out, method, note = deep.denoise_or_fallback(motionbuilder_spelling(walk))
    assert method == "EBF (shipped, via the cmu_bvh_motionbuilder joint map)" and note == _acclaim_terms()  # no fallback: only the pair's licence line


def _rms(ref, m, cells=None):
    d = np.degrees(R.geodesic_angle(ref.rotations[:, 1:], m.rotations[:, 1:]))
    return float(np.sqrt(np.mean(d[cells[:, 1:]] ** 2 if cells is not None else d ** 2)))


def test_cmu_01_01_as_bvh_is_served_as_well_as_as_asf(shared_data):
    """The real twin: CMU 01_01 as ASF/AMC and as the MotionBuilder-release BVH (frame 0: the converter's T-pose)."""
    d = shared_data
    asf = mocapkit.load(d / "cmu_asfamc" / "01_01.amc", asf=d / "cmu_asfamc" / "01.asf")[:600]
    bvh = mocapkit.load(d / "cmu_bvh" / "01_01.bvh")[1:601]
    ebf = deep.shipped_model("ebf")
    s = deep.served_by(bvh, ebf)
    assert isinstance(s, deep.Serving) and s.family == "cmu_bvh_motionbuilder"
    assert np.abs(retarget.encode(bvh, s)[0] - ch.encode(asf, ebf.layout)[0]).max() < 1e-3  # AMC prints 6 digits
    # the same noisy pose in both spellings: the same error
    noisy, _ = corrupt.angular_noise(asf, 0.5, seed=1)
    as_bvh = Motion(bvh.skeleton, noisy.rotations, bvh.root_positions, bvh.fps, bvh.name)
    e_asf, e_bvh = _rms(asf, deep.denoise(noisy)), _rms(bvh, deep.denoise(as_bvh))
    assert e_asf < 0.4 * _rms(asf, noisy) and abs(e_bvh - e_asf) < 0.02 * e_asf
    # noise in the BVH's own channels (three per joint, so partly outside the Acclaim dofs): better than the
    # fallback a rig the networks do not serve would get
    own, _ = corrupt.angular_noise(bvh, 0.5, seed=1)
    from mocapkit.cleaning.filters import savgol_smooth

    e_net = _rms(bvh, deep.denoise(own))
    assert e_net < 0.5 * _rms(bvh, own) and e_net < _rms(bvh, savgol_smooth(own, 0.1, 2, root=False))
    # the same gaps: the same fill
    gapped, _ = corrupt.gaps(asf, seed=3, start_prob=0.01)
    g_bvh = Motion(bvh.skeleton, gapped.rotations, bvh.root_positions, bvh.fps, bvh.name)
    miss = gapped.missing()
    f_asf, f_bvh = _rms(asf, deep.fill_gaps(gapped), miss), _rms(bvh, deep.fill_gaps(g_bvh), miss)
    assert abs(f_bvh - f_asf) < 0.02 * f_asf


def test_gaps_in_the_root_and_in_joints_the_map_does_not_cover(walk):
    import dataclasses

    bvh = motionbuilder_spelling(walk)
    rot = np.array(bvh.rotations)
    rot[100:110, 0] = np.nan  # the root's rotation
    rot[150:160, bvh.skeleton.index("LHipJoint")] = np.nan  # a joint the networks do not read
    rot[150:160, bvh.skeleton.index("LeftUpLeg")] = np.nan  # below it, a joint they do
    gapped = dataclasses.replace(bvh, rotations=rot)
    out = deep.fill_gaps(gapped)
    miss = gapped.missing()
    assert not out.missing().any() and np.array_equal(out.rotations[~miss], gapped.rotations[~miss])
    # the root interpolated between its neighbours, the thigh filled near the truth (the walk's own motion)
    assert np.degrees(R.geodesic_angle(out.rotations[100:110, 0], walk.rotations[100:110, 0])).max() < 5
    assert np.degrees(R.geodesic_angle(out.rotations[150:160, 2], walk.rotations[150:160, 2])).max() < 15


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.degrees(2.0 * np.arccos(np.clip(np.abs(np.sum(a * b, axis=-1)), 0.0, 1.0)))


@pytest.mark.parametrize("joint", ["LeftWrist", "RightWrist", "RThumb"])
def test_a_short_gap_of_a_mapped_rig_keeps_the_rotation_the_model_cannot_see(joint):
    """The 3dsMax conversion's wrists turn about axes the Acclaim wrist lacks, and its thumbs are not mapped: a
    3-frame gap there is filled by bridging those parts between the frames either side (it came out 11-37 deg off,
    the part dropped or the thumb held still)."""
    take = mocapkit.load(samples.path("131_01.bvh"))
    k = take.skeleton.index(joint)
    for start in (100, 200, 300):
        rot = np.array(take.rotations)
        rot[start:start + 3, k] = np.nan
        filled = deep.fill_gaps(dataclasses.replace(take, rotations=rot))
        assert _angle_deg(filled.rotations[start:start + 3, k], take.rotations[start:start + 3, k]).max() < 6.0


def _acclaim_terms() -> str:
    """The one line a take served by the shipped Acclaim EBF gets: its research-use terms (HDM05), no fallback."""
    return deep.licence_note(deep.shipped_model("ebf"))


BYE = Path(__file__).resolve().parents[1] / "data" / "dataset-1_bye_giant_001.bvh"


def test_a_mapped_joint_near_gimbal_lock_is_read_on_one_branch():
    """A Bandai Namco wave served by the Acclaim EBF through the joint map: the rig's Spine, as the model's
    ``lowerback`` (ZYX), holds its middle angle near 90 deg, where the plain Euler conversion changes branch twice;
    read as it is, the network sees two 180-deg jumps and smooths the Spine into rotations it never had."""
    take = mocapkit.load(BYE)
    model = deep.shipped_model("ebf")
    serving = retarget.served_by(take, model)
    assert not serving.direct
    k = serving.layout.joints.index("lowerback")
    c = sum(len(o) for o in serving.orders[:k])
    values, _ = retarget.encode(take, serving)
    step = np.abs(np.diff(values[:, c:c + len(serving.orders[k])], axis=0))
    assert step.max() < 90.0  # no branch change (185 deg on the plain conversion)
    assert np.array_equal(retarget.decode(values, take, serving).rotations, take.rotations)  # read back: as it was
    spine = serving.joints[k]
    out = deep.denoise(take, model=model)
    turned = np.degrees(R.geodesic_angle(out.rotations[:, spine], take.rotations[:, spine]))
    assert turned.max() < 20.0  # a denoised clean take: 14 deg at most here, 33 deg averaging the two branches
