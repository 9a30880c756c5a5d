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
