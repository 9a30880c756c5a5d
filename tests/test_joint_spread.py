import numpy as np
import pytest

from mocapkit import rotations as R
from mocapkit.joint_spread import joint_rotation_spread, noise_spread


def turns(angles_deg, axis=(0.3, 0.9, 0.3)):
    axis = np.asarray(axis) / np.linalg.norm(axis)
    return R.quaternion_from_axis_angle(np.broadcast_to(axis, (len(angles_deg), 3)), np.radians(angles_deg))


def test_a_one_axis_turn_spreads_as_its_angle():
    ang = 40.0 + 30.0 * np.sin(np.linspace(0.0, 6.0, 400))
    q = turns(ang)
    q[::3] *= -1.0  # the sign of a quaternion is no turn
    still = np.tile(R.quaternion_from_axis_angle(np.array([1.0, 0, 0]), 0.4), (400, 1))
    s = joint_rotation_spread(np.stack([q, still], axis=1))
    assert s[0] >= np.std(ang) - 1e-9  # never below the arithmetic std: a one-channel joint is never capped
    assert s[0] == pytest.approx(np.std(ang), rel=0.01)
    assert s[1] == pytest.approx(0.0, abs=1e-5)


def test_missing_frames_are_left_out_and_an_empty_joint_is_still():
    ang = np.linspace(-20.0, 20.0, 101)
    q = turns(ang)
    gappy = q.copy()
    gappy[40:60] = np.nan
    s = joint_rotation_spread(np.stack([gappy, np.full_like(q, np.nan)], axis=1))
    assert s[0] == pytest.approx(np.std(np.r_[ang[:40], ang[60:]]), rel=0.01)
    assert s[1] == 0.0


def test_noise_spread_caps_only_channels_that_move_more_than_their_joint():
    out = noise_spread(np.array([5.0, 80.0, 3.0, 0.1]), np.array([0, 0, 1, 1]), np.array([7.0, 2.0]))
    np.testing.assert_array_equal(out, [5.0, 7.0, 2.0, 0.1])
