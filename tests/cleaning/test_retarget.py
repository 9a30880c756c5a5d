"""cleaning.deep.retarget: the one rule for which takes the networks serve, and the joint map onto the Acclaim rig."""

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

BANDAI = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"
OTHER = Path(__file__).resolve().parents[1] / "data" / "pybvh_test1_zup.bvh"


def motionbuilder_spelling(motion: Motion, order: str = "ZYX") -> Motion:
    """``motion`` (an Acclaim ASF take) as the CMU MotionBuilder-release BVH spells it: the same rotations, joints
    renamed by role, three rotation channels in ``order`` on every joint, no axis frames."""
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
    assert np.abs(v_asf - v_bvh).max() < 1e-6 and np.abs(c_asf - c_bvh).max() < 1e-9


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
    noisy, _ = corrupt.angular_noise(walk, 0.5, seed=3)
    a = deep.denoise(noisy)
    b = deep.denoise(motionbuilder_spelling(noisy))
    assert np.degrees(R.geodesic_angle(a.rotations, b.rotations)).max() < 1e-3
    root_and_hipjoints = [0, walk.skeleton.index("lhipjoint"), walk.skeleton.index("rhipjoint")]
    assert np.array_equal(b.rotations[:, root_and_hipjoints], noisy.rotations[:, root_and_hipjoints])
    gapped, _ = corrupt.gaps(walk, seed=2, start_prob=0.02)
    fa = deep.fill_gaps(gapped)
    gb = motionbuilder_spelling(gapped)
    fb = deep.fill_gaps(gb)
    assert not fb.missing().any()
    assert np.degrees(R.geodesic_angle(fa.rotations, fb.rotations)).max() < 1e-3
    obs = ~gapped.missing()
    assert np.array_equal(fb.rotations[obs], gb.rotations[obs])


def test_the_rule_refuses_other_rigs_with_the_reason(ebf):
    bandai = mocapkit.load(BANDAI)
    why = deep.served_by(bandai, ebf)
    assert isinstance(why, str) and "bandai_namco rig has no joint for 8 of its 28 joints" in why
    three = mocapkit.load(samples.path("131_01.bvh"))  # the 3dsMax release: arms hang down in its rest pose
    why = deep.served_by(three, ebf)
    assert isinstance(why, str) and "rest pose differs" in why and "LeftShoulder by 90 deg" in why
    odd = Skeleton(("a", "b", "c"), np.array([-1, 0, 1]), np.ones((3, 3)))
    why = deep.served_by(odd, ebf)
    assert isinstance(why, str) and "no joint map is known" in why
    with pytest.raises(mocapkit.errors.SkeletonError, match="has no joint for"):
        deep.denoise(bandai, ebf)


def test_fallbacks_are_the_same_everywhere(walk):
    bandai = mocapkit.load(OTHER)  # a rig nothing ships for (the Bandai Namco rig has its own models)
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
    assert method == "EBF (shipped, via the cmu_bvh_motionbuilder joint map)" and note == ""


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
