"""A reconstruction on its skeleton's dofs: 2-dof ASF bones turned only about their dof axes."""

import numpy as np

import mocapkit
from mocapkit import rotations as R
from mocapkit import samples
from mocapkit.reconstruct.dofs import on_joint_dofs


def _angle_deg(a, b):
    return np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(a * b, axis=-1)), 0.0, 1.0)))


def test_a_two_dof_bone_turned_about_its_missing_axis_comes_back_as_the_amc_reads_it(tmp_path):
    take = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))[:40]
    sk = take.skeleton
    foot = sk.joint_names.index("rfoot")
    assert sk.rotation_order(foot) and len(sk.rotation_order(foot)) == 2
    twisted = np.array(take.rotations)
    spin = R.quaternion_from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(np.linspace(0, 8, len(take))))
    twisted[:, foot] = R.quaternion_multiply(twisted[:, foot], spin)
    m = take.__class__(sk, twisted, take.root_positions, take.fps, "twisted")
    out = on_joint_dofs(m)
    assert _angle_deg(out.rotations[:, foot], m.rotations[:, foot]).max() > 1.0  # the twist was not on its dofs
    path = mocapkit.save(out, tmp_path / "out.amc", asf=samples.path("HDM_bk.asf"), like=False)
    back = mocapkit.load(path)
    assert _angle_deg(back.rotations, out.rotations).max() < 1e-3  # what is returned is what the AMC holds
    others = [j for j in range(sk.num_joints) if j != foot]
    assert np.array_equal(out.rotations[:, others], m.rotations[:, others])  # 3-dof and untouched bones as given


def test_a_bvh_skeleton_is_returned_as_it_is():
    take = mocapkit.load(samples.path("131_01.bvh"))[:10]
    assert on_joint_dofs(take) is take


def test_only_the_bones_of_fewer_dofs_are_converted_to_the_numbers_a_whole_conversion_gives(monkeypatch):
    """on_joint_dofs runs once per frame in the accelerometer synthesis: it converts the bones of 1 or 2 rotation
    dofs alone (a 3-dof bone is kept as given, so its Euler round trip was work thrown away), and those to the
    numbers the conversion of every bone gives (a held-out HDM05 jog, every bone twisted up to 8 deg about y)."""
    from mocapkit.io.asfamc import amc_dofs, amc_held_rotations
    from mocapkit.reconstruct import dofs as D

    jog = mocapkit.load(samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"))
    spin = R.quaternion_from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(np.linspace(0, 8, len(jog))))
    take = jog.__class__(jog.skeleton, R.quaternion_multiply(jog.rotations, spin[:, None]), jog.root_positions,
                         jog.fps, "twisted")
    asked = []
    monkeypatch.setattr(D, "amc_held_rotations", lambda m, d, joints=None: asked.append(joints) or
                        amc_held_rotations(m, d, joints=joints))
    out = on_joint_dofs(take)
    n_rot = np.array([sum(x[0] == "r" for x in jd) for jd in amc_dofs(take.skeleton)])
    fewer = np.flatnonzero((n_rot > 0) & (n_rot < 3) & (np.arange(len(n_rot)) > 0))
    assert len(asked) == 1 and np.array_equal(asked[0], fewer)
    whole = amc_held_rotations(take)
    whole = np.where(np.sum(whole * take.rotations, axis=-1, keepdims=True) < 0, -whole, whole)
    moved = ~np.all(out.rotations == take.rotations, axis=-1)
    three = (n_rot == 3) | (np.arange(len(n_rot)) == 0)  # and the root: kept bit for bit
    assert moved[:, fewer].any() and not moved[:, three].any()
    moved[:, ~np.isin(np.arange(len(n_rot)), fewer)] = False  # (bones of no dofs read back as the identity)
    assert np.array_equal(out.rotations[moved], whole[moved])  # the cells moved onto their dofs
