"""A reconstruction on its skeleton's degrees of freedom: each joint turned only the ways its channels can turn it.

The fits (:mod:`.markers`' local PCA in rotation-vector space, :mod:`.accelerometers`' kernels, :mod:`.ssg`'s
cross-fades and resampling) work on full 3-D rotations. An ASF bone has the rotation dofs its ``dof`` line lists:
HDM05's and CMU's feet, hands and thumbs ``dof rz rx`` (2), some bones none. Such a bone cannot perform a
rotation about its missing axes, and an AMC keeps only its dof angles (:mod:`mocapkit.io.amc_writer`): a
reconstruction saved as ``.amc`` and read back was another motion than the one returned, reported and measured
(a held-out HDM05 sneak from six markers: the right foot 3.3 degrees, joints 0.5 cm). Projecting every such
joint onto its dofs before the result is returned makes what is returned, measured and saved the same motion.

A BVH writes any rotation (its writer adds the channels a rotating joint lacks), so a skeleton without ASF axes
is returned unchanged.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import rotations as R
from ..io.asfamc import amc_dofs, amc_held_rotations
from ..motion import Motion

__all__ = ["on_joint_dofs"]

#: A rotation whose projection moves no quaternion component more than this is already on its dofs and is kept
#: as given (the Euler round trip's rounding, ~1e-16, would otherwise change every cell of a bone).
_ON_DOFS = 1e-12


def on_joint_dofs(motion: Motion) -> Motion:
    """``motion`` with each joint of an ASF skeleton turned only about its rotation dofs.

    A bone with 1 or 2 rotation dofs gets the rotation its dof angles make (the Euler angles of
    ``C^-1 q C`` in its dof order, the others dropped: :func:`mocapkit.io.asfamc.amc_held_rotations`, what
    an AMC reads back) where that moves it (a rotation already on its dofs is kept bit for bit); a bone with
    none (not the root) the identity, as an AMC reads it; bones with 3 dofs,
    the root's position and any skeleton without ASF axes (BVH, whose writer keeps every rotation) are kept
    bit for bit. ``motion.rotations`` (F, J, 4) unit quaternions; returns a new Motion (``motion`` itself
    when nothing changes).
    """
    sk = motion.skeleton
    if sk.axes is None:
        return motion
    dofs = amc_dofs(sk)
    n_rot = np.array([sum(d[0] == "r" for d in jd) for jd in dofs])
    few = n_rot < 3
    few[0] = False  # the root: its position and 3 rotation dofs are written as they are
    if not few.any() or motion.num_frames == 0:
        return motion
    rot = np.array(motion.rotations, dtype=np.float64)
    some = few & (n_rot > 0)
    if some.any():
        held = amc_held_rotations(motion, dofs, joints=np.flatnonzero(some))  # bones of 3 dofs are kept as given
        held = np.where(np.sum(held * rot, axis=-1, keepdims=True) < 0, -held, held)
        off = np.nan_to_num(np.abs(held - rot).max(axis=-1), nan=0.0) > _ON_DOFS  # (F, J)
        cells = off & some[None, :]
        rot[cells] = held[cells]
    none = few & (n_rot == 0)
    seen = np.isfinite(rot).all(axis=-1)
    rot[:, none] = np.where(seen[:, none, None], R.identity(), rot[:, none])
    return dataclasses.replace(motion, rotations=rot)
