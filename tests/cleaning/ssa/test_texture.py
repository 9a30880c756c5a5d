"""The motion texture's pieces: joint groups, informative joints, the root's heading removed (section 3.1)."""

import numpy as np

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning import ssa


def test_joint_groups_of_cmu_rig(walk):
    g = ssa.joint_groups(walk.skeleton)
    names = walk.skeleton.joint_names
    assert set(g) == {"whole", "upper", "lower", "left", "right"}
    assert "LeftKnee" in [names[j] for j in g["lower"]] and "LeftKnee" in [names[j] for j in g["left"]]
    assert "LeftElbow" in [names[j] for j in g["upper"]] and "LeftElbow" not in [names[j] for j in g["right"]]
    assert "Head" not in [names[j] for j in g["lower"]]


def test_informative_joints_take_left_and_right_partners_together():
    """On the sneak take the right hand alone ranked 25th (its partner made the 24); now the pair comes in together."""
    from mocapkit.motion import mirror_pairs

    take = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    sk = take.skeleton
    perm = mirror_pairs(sk.joint_names)
    for count in (24, 9, 5):
        sel = ssa.informative_joints([take], count)
        assert len(sel) == count and 0 in sel
        unpaired = [j for j in sel if perm[j] != j and perm[j] not in sel]
        assert len(unpaired) <= 1, [sk.joint_names[j] for j in unpaired]  # only a last slot a pair could not fill
    sel = ssa.informative_joints([take], 24)
    assert sk.index("lhand") in sel and sk.index("rhand") in sel
    assert np.array_equal(ssa.informative_joints([take.mirror()], 24), np.sort(perm[sel]))  # mirrored take: mirrored set


def test_facing_aligned_removes_heading(walk, rng):
    up = np.array([0.0, 1.0, 0.0])
    turn = R.quaternion_from_axis_angle(up, rng.uniform(-np.pi, np.pi))
    turned = np.array(walk.rotations)
    turned[:, 0] = R.quaternion_multiply(turn, turned[:, 0])
    a = ssa.facing_aligned(walk.rotations, up)
    b = ssa.facing_aligned(turned, up)
    assert np.allclose(R.geodesic_angle(a, b), 0.0, atol=1e-6)
