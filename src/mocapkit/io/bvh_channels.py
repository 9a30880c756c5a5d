"""BVH channel values to a :class:`~mocapkit.motion.Motion`: the reader's one numba pass over a file's table.

:func:`channels_to_arrays` turns every frame's channels (positions, Euler angles in degrees, unit scales) into local
quaternions and offsets in one fused pass; :func:`motion_from_channels` makes the take of a BVH skeleton from them
(:func:`mocapkit.io.bvh.read_bvh`, and the writer's view of a ``like`` source's numbers).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numba import njit

from ..motion import Motion, Skeleton

__all__ = ["channels_to_arrays", "motion_from_channels"]


@njit(cache=True)
def channels_to_arrays(values, col_joint, col_kind, offsets):
    """Fused conversion of BVH channels to local quaternions and offsets, one pass over the values.

    Parameters
    ----------
    values : float array (F, C)
        Channel values in file order; rotations in degrees.
    col_joint : int array (C,)
        Joint of each column.
    col_kind : int array (C,)
        0, 1, 2 for X/Y/Z position; 3, 4, 5 for X/Y/Z rotation; 6 for a scale channel (skipped: unit scale).
    offsets : float array (J, 3)
        Skeleton offsets; position channels replace their axis.

    Returns
    -------
    rot : float array (F, J, 4)
        Local rotations, w first: the product of the elementary rotations in
        channel order (intrinsic), as ``rotations.euler_to_quaternion`` does.
    local : float array (F, J, 3)
        Local offsets per frame.
    """
    F, C = values.shape
    J = offsets.shape[0]
    rot = np.empty((F, J, 4))
    local = np.empty((F, J, 3))
    k = np.pi / 180.0
    for f in range(F):
        for j in range(J):
            rot[f, j, 0] = 1.0
            rot[f, j, 1] = 0.0
            rot[f, j, 2] = 0.0
            rot[f, j, 3] = 0.0
            local[f, j, 0] = offsets[j, 0]
            local[f, j, 1] = offsets[j, 1]
            local[f, j, 2] = offsets[j, 2]
        for c in range(C):
            j = col_joint[c]
            kind = col_kind[c]
            v = values[f, c]
            if kind < 3:
                local[f, j, kind] = v
                continue
            if kind > 5:
                continue
            half = (v * k) * 0.5
            co = np.cos(half)
            si = np.sin(half)
            w = rot[f, j, 0]
            x = rot[f, j, 1]
            y = rot[f, j, 2]
            z = rot[f, j, 3]
            # q * (cos, sin * axis): the elementary rotation applied last (intrinsic order)
            if kind == 3:
                rot[f, j, 0] = w * co - x * si
                rot[f, j, 1] = w * si + x * co
                rot[f, j, 2] = y * co + z * si
                rot[f, j, 3] = z * co - y * si
            elif kind == 4:
                rot[f, j, 0] = w * co - y * si
                rot[f, j, 1] = x * co - z * si
                rot[f, j, 2] = w * si + y * co
                rot[f, j, 3] = x * si + z * co
            else:
                rot[f, j, 0] = w * co - z * si
                rot[f, j, 1] = x * co + y * si
                rot[f, j, 2] = y * co - x * si
                rot[f, j, 3] = w * si + z * co
    return rot, local


def motion_from_channels(skeleton: Skeleton, values: np.ndarray, fps: float, name: str, path: Path) -> Motion:
    """``Motion.from_channel_values(..., animated_offsets=True)`` for BVH skeletons, fused in one numba pass; the
    Motion's ``source_file`` is ``path``."""
    col_joint, col_kind = [], []
    moving = False
    for j, chans in enumerate(skeleton.channels):
        for ch in chans:
            col_joint.append(j)
            col_kind.append(6 if ch.endswith("scale") else "XYZ".index(ch[0]) + (0 if ch.endswith("position") else 3))
            moving = moving or (j > 0 and ch.endswith("position"))
    rot, local = channels_to_arrays(
        values, np.array(col_joint, dtype=np.int64), np.array(col_kind, dtype=np.int64), skeleton.offsets
    )
    return Motion(
        skeleton=skeleton,
        rotations=rot,
        root_positions=np.ascontiguousarray(local[:, 0]),
        fps=fps,
        name=name,
        translations=local if moving else None,
        source_file=path,
    )
