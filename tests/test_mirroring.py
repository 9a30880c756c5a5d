"""The mirror image that keeps the take's skeleton: positions, mirror of the mirror, rest corrections, rig choice."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mocapkit
from mocapkit import rotations as R
from mocapkit.mirroring import mirror_corrections, mirror_for_rig, mirror_keeping_skeleton
from mocapkit.motion import MIRROR_MISMATCH_MAX, Motion, lateral_axis, mirror_mismatch, mirror_pairs

DATA = Path(__file__).resolve().parent / "data"
BANDAI = ("bandai_dance-short_normal_001_first60.bvh", "dataset-2_run_active_049.bvh")
ACCLAIM = (("12_walk.amc", "12.asf"), ("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", "HDM_bd.asf"))


def bandai(name):
    return mocapkit.load(DATA / name)


def acclaim(amc, asf):
    return mocapkit.load(mocapkit.samples.path(amc), asf=mocapkit.samples.path(asf))


def reflected(m: Motion) -> np.ndarray:
    """(F, J + E, 3) the take's joint and end-site positions reflected and pair-swapped (``Motion.mirror``'s)."""
    return m.mirror().global_positions(end_sites=True)


def length_slack(m: Motion) -> np.ndarray:
    """(J + E,) summed differences between each bone's length and its partner's along the path from the root:
    how far a joint may land from the reflected position when the rig's bones differ in length by side."""
    sk = m.skeleton
    mirrored = m.mirror().skeleton
    d = np.abs(np.linalg.norm(sk.offsets, axis=1) - np.linalg.norm(mirrored.offsets, axis=1))
    d[0] = 0.0
    path = np.zeros(sk.num_joints)
    for j in range(1, sk.num_joints):
        path[j] = path[sk.parents[j]] + d[j]
    es = path[sk.end_site_parents] + np.abs(
        np.linalg.norm(sk.end_site_offsets, axis=1) - np.linalg.norm(mirrored.end_site_offsets, axis=1))
    return np.concatenate([path, es])


@pytest.mark.parametrize("name", BANDAI)
def test_on_the_bandai_rig_joints_land_on_the_reflected_take(name):
    """Real Bandai Namco takes (bones along each joint's own axis, frames differing by side): on the take's own
    skeleton every joint and end site lands on the reflected, pair-swapped position, where posing the plain mirror's
    rotations on that skeleton puts another body."""
    m = bandai(name)
    assert mirror_mismatch(m.skeleton) > MIRROR_MISMATCH_MAX
    mm = mirror_keeping_skeleton(m)
    assert mm.skeleton == m.skeleton and mm.name == m.name + "_mirror"
    want = reflected(m)
    scale = np.abs(m.global_positions()).max()
    np.testing.assert_allclose(mm.global_positions(end_sites=True), want, atol=1e-9 * scale)
    plain = dataclasses.replace(m.mirror(), skeleton=m.skeleton, translations=m.translations)
    assert np.linalg.norm(plain.global_positions(end_sites=True) - want, axis=-1).max() > 20.0  # centimetres


@pytest.mark.parametrize("name", BANDAI)
def test_the_mirror_of_the_mirror_is_the_take(name):
    m = bandai(name)
    back = mirror_keeping_skeleton(mirror_keeping_skeleton(m))
    np.testing.assert_allclose(back.global_positions(end_sites=True), m.global_positions(end_sites=True), atol=1e-9)
    assert R.geodesic_angle(back.rotations, m.rotations).max() < 1e-9
    np.testing.assert_allclose(back.translations, m.translations, atol=1e-9)


@pytest.mark.parametrize("amc, asf", ACCLAIM)
def test_on_acclaim_takes_joints_land_within_the_bone_length_differences(amc, asf):
    """An actor's skeleton is a few per cent asymmetric: bone directions are exact, so each joint lands within
    the summed length differences of its bones and their partners' of the reflected position, and the mirror
    of the mirror is the take."""
    m = acclaim(amc, asf)
    mm = mirror_keeping_skeleton(m)
    err = np.linalg.norm(mm.global_positions(end_sites=True) - reflected(m), axis=-1)
    slack = length_slack(m)
    assert (err <= slack[None] + 1e-9).all()
    assert err.max() > 1e-3  # the bones differ, so the bound is what holds, not equality
    back = mirror_keeping_skeleton(mm)
    np.testing.assert_allclose(back.global_positions(end_sites=True), m.global_positions(end_sites=True), atol=1e-9)
    assert R.geodesic_angle(back.rotations, m.rotations).max() < 1e-9


def _random_pose(m: Motion, seed: int, frames: int = 4) -> Motion:
    rng = np.random.default_rng(seed)
    rot = R.quaternion_normalize(rng.normal(size=(frames, m.num_joints, 4)))
    root = rng.normal(scale=50.0, size=(frames, 3))
    tr = None
    if m.translations is not None:
        tr = np.repeat(m.translations[:1], frames, axis=0)
        tr[:, 1] += rng.normal(scale=30.0, size=(frames, 3))  # the game rig's hips move under a fixed root
    return dataclasses.replace(m[:frames], rotations=rot, root_positions=root, translations=tr)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), which=st.sampled_from(range(len(BANDAI) + len(ACCLAIM))))
def test_property_any_pose_mirrors_onto_the_reflected_pose_and_back(seed, which):
    """Any poses (random rotations, root and hip positions) on the real skeletons: positions land within the
    bone-length slack of the reflection (exactly on the game rig, its partner bones alike), and mirroring twice
    gives the poses back."""
    take = bandai(BANDAI[which]) if which < len(BANDAI) else acclaim(*ACCLAIM[which - len(BANDAI)])
    m = _random_pose(take, seed)
    mm = mirror_keeping_skeleton(m)
    err = np.linalg.norm(mm.global_positions(end_sites=True) - reflected(m), axis=-1)
    assert (err <= length_slack(m)[None] + 1e-6).all()
    back = mirror_keeping_skeleton(mm)
    np.testing.assert_allclose(back.global_positions(end_sites=True), m.global_positions(end_sites=True), atol=1e-6)
    assert R.geodesic_angle(back.rotations, m.rotations).max() < 1e-7


def test_rest_corrections_of_the_game_rig_reverse_the_limbs_frames():
    """On the Bandai rig the limbs' frames differ by side with every axis reversed: the corrections make the
    relation ``K_j = M C_j`` the point inversion ``-I`` on every limb joint; the hips and chest, which have
    several children, reflect across their own lateral plane (an improper involution), and the joint's partner
    gets ``M C_j^-1 M``."""
    m = bandai(BANDAI[1])
    sk = m.skeleton
    axis = lateral_axis(sk)
    M = np.eye(3)
    M[axis, axis] = -1.0
    bones = np.ones(sk.num_joints, dtype=bool)
    bones[sk.index("Hips")] = False  # its offset is animated
    C = R.quaternion_to_matrix(mirror_corrections(sk, axis, bones))
    perm = mirror_pairs(sk.joint_names)
    for j, name in enumerate(sk.joint_names):
        K = M @ C[j]
        if perm[j] != j:
            np.testing.assert_allclose(K, -np.eye(3), atol=5e-3, err_msg=name)  # within the rig's own asymmetry
            np.testing.assert_allclose(C[perm[j]], M @ C[j].T @ M, atol=1e-9, err_msg=name)
        else:
            np.testing.assert_allclose(K @ K, np.eye(3), atol=1e-9, err_msg=name)
    for name in ("Hips", "Chest"):
        K = M @ C[sk.index(name)]
        assert np.sum(np.isclose(np.linalg.eigvalsh((K + K.T) / 2), -1.0, atol=1e-6)) == 1, name  # a plane reflection


@pytest.mark.parametrize("name", BANDAI)
def test_joints_sharing_their_parents_mirror_relation_keep_their_rotation_angle(name):
    """Where ``K_j = K_par`` the mirrored local rotation is the partner's conjugated by one reflection, the same
    angle: the chest (the spine takes its twist, not the hips'), neck, head and every limb joint below the first.
    The game rig's chest turns 5-20 degrees from its rest; a twist taken from the hips would turn it by half a turn."""
    m = bandai(name)
    sk = m.skeleton
    mm = mirror_keeping_skeleton(m)
    perm = mirror_pairs(sk.joint_names)
    same = ["Chest", "Neck", "Head", "UpperArm_L", "LowerArm_L", "Hand_R", "LowerLeg_R", "Foot_L", "Toes_R"]
    for n in same:
        j = sk.index(n)
        np.testing.assert_allclose(R.geodesic_angle(mm.rotations[:, j], R.identity()),
                                   R.geodesic_angle(m.rotations[:, perm[j]], R.identity()), atol=5e-3, err_msg=n)  # 0.3 deg: the rig's asymmetry
    assert np.degrees(R.geodesic_angle(mm.rotations[:, sk.index("Chest")], R.identity())).max() < 45.0


def test_a_rig_that_reflects_onto_itself_needs_little_correction():
    """CMU and Acclaim skeletons reflect onto themselves within a few per cent: the corrections are small turns."""
    for sk in (mocapkit.load(mocapkit.samples.path("131_01.bvh")).skeleton, acclaim(*ACCLAIM[0]).skeleton):
        angles = np.degrees(R.geodesic_angle(mirror_corrections(sk), R.identity((sk.num_joints,))))
        assert angles.max() < 10.0


def test_mirror_for_rig_keeps_the_plain_mirror_where_the_rig_reflects_onto_itself():
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:40]
    a, b = mirror_for_rig(walk), walk.mirror()
    assert a.skeleton == b.skeleton and np.array_equal(a.rotations, b.rotations)
    assert np.array_equal(a.root_positions, b.root_positions)
    run = bandai(BANDAI[1])
    c = mirror_for_rig(run)
    assert c.skeleton == run.skeleton
    assert np.array_equal(c.rotations, mirror_keeping_skeleton(run).rotations)
    with pytest.raises(mocapkit.errors.SkeletonError, match="no left/right joint pairs"):
        mirror_for_rig(dataclasses.replace(walk, skeleton=dataclasses.replace(
            walk.skeleton, joint_names=tuple(f"j{i}" for i in range(walk.num_joints)))))


def test_missing_rotations_stay_missing_on_the_partner_and_change_nothing_else():
    m = bandai(BANDAI[1])
    rot = np.array(m.rotations)
    tr = np.array(m.translations)
    j = m.skeleton.index("LowerArm_L")
    rot[10:15, j] = np.nan
    tr[20:25, j] = np.nan  # a gap in a joint's translation does not make its bone animated
    mm = mirror_keeping_skeleton(dataclasses.replace(m, rotations=rot, translations=tr))
    p = mirror_pairs(m.skeleton.joint_names)[j]
    assert np.isnan(mm.rotations[10:15, p]).all() and not np.isnan(mm.rotations[:10]).any()
    full = mirror_keeping_skeleton(m)
    keep = np.ones(m.num_frames, dtype=bool)
    keep[10:15] = False
    np.testing.assert_array_equal(np.delete(mm.rotations[keep], p, axis=1), np.delete(full.rotations[keep], p, axis=1))
