"""The forward-kinematics kernel of :meth:`mocapkit.motion.Motion.global_positions`, in numba.

One compiled loop over joints (in parent order) and frames: linear in joints x
frames for any depth of hierarchy, with no per-joint array temporaries. Kept
apart from :mod:`mocapkit.motion` so that importing the package loads no numba;
``motion`` imports it on the first forward-kinematics call.
"""

from __future__ import annotations

from numba import njit

__all__ = ["fk_kernel"]


@njit(cache=True)
def fk_kernel(parents, lrot, local, grot, gpos):
    """Fill ``grot`` (F, J, 4) and ``gpos`` (F, J, 3) from their root column, joint by joint in parent order.

    ``local`` is (F, J, 3), or (1, J, 3) for offsets shared by all frames.
    The expressions are those of ``quaternion_multiply`` and of
    ``quaternion_rotate`` (``v + w t + u x t`` with ``t = 2 u x v``, each
    cross product as ``numpy.cross`` computes it), so results are bit-identical.
    """
    F = lrot.shape[0]
    J = lrot.shape[1]
    shared = local.shape[0] == 1
    for j in range(1, J):
        p = parents[j]
        for f in range(F):
            aw = grot[f, p, 0]
            ax = grot[f, p, 1]
            ay = grot[f, p, 2]
            az = grot[f, p, 3]
            bw = lrot[f, j, 0]
            bx = lrot[f, j, 1]
            by = lrot[f, j, 2]
            bz = lrot[f, j, 3]
            grot[f, j, 0] = aw * bw - ax * bx - ay * by - az * bz
            grot[f, j, 1] = aw * bx + ax * bw + ay * bz - az * by
            grot[f, j, 2] = aw * by - ax * bz + ay * bw + az * bx
            grot[f, j, 3] = aw * bz + ax * by - ay * bx + az * bw
            fo = 0 if shared else f
            v0 = local[fo, j, 0]
            v1 = local[fo, j, 1]
            v2 = local[fo, j, 2]
            t0 = 2.0 * (ay * v2 - az * v1)
            t1 = 2.0 * (az * v0 - ax * v2)
            t2 = 2.0 * (ax * v1 - ay * v0)
            r0 = v0 + aw * t0 + (ay * t2 - az * t1)
            r1 = v1 + aw * t1 + (az * t0 - ax * t2)
            r2 = v2 + aw * t2 + (ax * t1 - ay * t0)
            gpos[f, j, 0] = gpos[f, p, 0] + r0
            gpos[f, j, 1] = gpos[f, p, 1] + r1
            gpos[f, j, 2] = gpos[f, p, 2] + r2
