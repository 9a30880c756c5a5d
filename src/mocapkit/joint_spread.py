"""How far each joint turns over a take, as a rotation: the scale Mall et al.'s angular noise is meant to follow.

Mall et al. 2017 (section 4) corrupt a take with Gaussian noise of ``amount`` x each joint-angle
channel's std. Adding ``delta`` degrees to one Euler channel turns the joint by exactly ``|delta|``
(the channel's elementary rotation composes at its place in the product), so the channel's std is
meant as how far that channel turns the joint. Near gimbal lock (the middle channel of an Euler
triple near +-90 deg) the first and third channels counter-rotate by tens of degrees while the
joint hardly turns (a Bandai Namco ``Hips`` in a heading turn, ZXY with X through 90: Z and Y swing
through +-180 for a 90-deg turn), and their std says nothing about the motion. The joint's own
spread (:func:`joint_rotation_spread`) bounds how far any of its channels can turn it, and
:func:`noise_spread` caps each channel's std there.
"""

from __future__ import annotations

import numpy as np

__all__ = ["joint_rotation_spread", "noise_spread"]


def joint_rotation_spread(rotations: np.ndarray) -> np.ndarray:
    """RMS rotation angle (J,) in degrees of each joint's rotations (F, J, 4) from their mean rotation.

    The mean is the chordal L2 mean of unit quaternions (Markley et al. 2007, "Averaging quaternions"):
    the eigenvector of the largest eigenvalue of ``sum q q^T``, blind to the sign of each ``q``. The angle
    is the geodesic ``2 arccos |<q, mean>|``. For a joint that turns about one fixed axis this is at least
    the std of its angle (the arithmetic mean minimises the RMS), so a one-channel joint is never capped.
    Frames with a non-finite rotation are left out; a joint with none finite has spread 0.
    """
    q = np.asarray(rotations, dtype=np.float64)
    ok = np.all(np.isfinite(q), axis=-1)  # (F, J)
    qz = np.where(ok[..., None], q, 0.0)
    scatter = np.einsum("fji,fjk->jik", qz, qz)  # (J, 4, 4)
    _, vecs = np.linalg.eigh(scatter)
    mean = vecs[..., -1]  # (J, 4) eigenvector of the largest eigenvalue
    cos = np.clip(np.abs(np.einsum("fji,ji->fj", qz, mean)), 0.0, 1.0)
    ang = np.degrees(2.0 * np.arccos(cos))
    n = ok.sum(axis=0)
    ms = np.where(ok, ang**2, 0.0).sum(axis=0) / np.maximum(n, 1)
    return np.where(n > 0, np.sqrt(ms), 0.0)


def noise_spread(channel_spread: np.ndarray, owner: np.ndarray, joint_spread: np.ndarray) -> np.ndarray:
    """Per-channel noise scale (C,) degrees: each channel's spread, at most its joint's rotation spread.

    ``channel_spread`` (C,) degrees (:func:`mocapkit.corrupt.channel_spread`), ``owner`` (C,) the joint of
    each channel, ``joint_spread`` (J,) degrees (:func:`joint_rotation_spread`). A channel whose values
    move more than its joint turns (Euler coupling near gimbal lock) gets its joint's spread; every other
    channel keeps its own spread bit for bit.
    """
    cap = np.asarray(joint_spread, dtype=np.float64)[np.asarray(owner, dtype=np.int64)]
    return np.minimum(np.asarray(channel_spread, dtype=np.float64), cap)
