"""mocapkit.cleaning.calibration: T-pose / A-pose frames at the ends of real takes, found by joint positions."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.cleaning.calibration import CalibrationPose, calibration_mask, calibration_poses, pose_kinds

DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="module")
def cmu_start():
    """CMU 01_01 (cgspeed BVH), frames 0-99: frame 0 is the converter's T-pose."""
    return mocapkit.load(DATA / "cmu_01_01_start.bvh")


def test_cmu_bvh_frame_0_is_a_t_pose(cmu_start):
    poses = calibration_poses(cmu_start)
    assert len(poses) == 1
    p = poses[0]
    assert (p.start, p.stop, p.kind, p.where) == (0, 1, "T-pose", "start")
    assert p.frames == (0, 1)  # the converter jumps straight into the motion: no transition
    assert str(p) == "frame 0: calibration T-pose, left alone"
    assert calibration_mask(poses, cmu_start.num_frames).tolist() == [True] + [False] * (cmu_start.num_frames - 1)


def test_pose_kinds_measure_the_arms(cmu_start):
    kinds, elev = pose_kinds(cmu_start)
    assert kinds[0] == 1 and not kinds[1:].any()
    assert np.all(np.abs(elev[0]) < 10.0)  # both arms horizontal in the T-pose
    assert np.all(elev[1:20, 1] < -60.0)  # from frame 1 the right arm hangs: no longer a calibration pose


@pytest.mark.parametrize("name", ["131_01.bvh", "12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"])
def test_takes_without_a_calibration_pose_give_none(name):
    m = mocapkit.load(samples.path(name))
    assert calibration_poses(m) == ()


def test_a_pose_and_a_closing_pose(cmu_start):
    """The T-pose frame held for 0.1 s at the end too; its arms lowered 40 deg make an A-pose."""
    m = cmu_start
    t = m[0:1]
    tail = dataclasses.replace(m, rotations=np.concatenate([m.rotations, np.repeat(t.rotations, 12, axis=0)]),
                               root_positions=np.concatenate([m.root_positions, np.repeat(t.root_positions, 12, axis=0)]))
    poses = calibration_poses(tail)
    assert [(p.kind, p.where, p.start, p.stop) for p in poses] == [("T-pose", "start", 0, 1), ("T-pose", "end", 100, 112)]
    # lower both arms by 40 deg about the body's forward axis: rotate each upper arm in world space
    from mocapkit import rotations as R
    from mocapkit.motion import find_joint

    sk = m.skeleton
    P = t.global_positions()[0]
    up = P[find_joint(sk, "head")] - 0.5 * (P[find_joint(sk, "left_foot")] + P[find_joint(sk, "right_foot")])
    up /= np.linalg.norm(up)
    lateral = P[find_joint(sk, "left_shoulder")] - P[find_joint(sk, "right_shoulder")]
    forward = np.cross(lateral, up)
    forward /= np.linalg.norm(forward)
    grot, _ = t.global_transforms()
    rot = np.array(t.rotations)
    for side, sign in (("left", -1.0), ("right", 1.0)):
        j = find_joint(sk, f"{side}_shoulder")
        par = sk.parents[j]
        turn = R.quaternion_from_axis_angle(forward * sign, np.radians(40.0))
        new_global = R.quaternion_multiply(turn, grot[0, j])
        rot[0, j] = R.quaternion_multiply(R.quaternion_inverse(grot[0, par]), new_global)
    a = dataclasses.replace(t, rotations=rot)
    kinds, elev = pose_kinds(a)
    assert kinds[0] == 2, elev
    assert np.all((elev[0] < -30.0) & (elev[0] > -50.0))
