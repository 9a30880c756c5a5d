"""Forward kinematics of one local-model pose and its analytic Jacobian (the per-frame fit of :mod:`.markers`).

The per-frame optimisation of Krüger et al. 2010, sec. 5.2 (the Chai & Hodgins
2005 energy, :mod:`mocapkit.reconstruct.markers`) moves a pose
``q_j = mean_j * exp(r_j)``, ``r = mu + basis @ u`` (rotation vectors in
radians, ``u`` the whitened PCA coefficients), the root turned by a heading
``theta`` about the vertical and placed at a root position. Its Jacobian was
taken by forward differences, ``d + 4`` extra forward-kinematics passes per
solver iteration; here it is exact and costs about one pass:

* a rotation vector ``r_k`` moved by ``delta`` turns joint ``k``'s global
  frame by the world angular step ``omega = G_k J_r(r_k) delta``, ``G_k`` its
  global rotation and ``J_r`` the right Jacobian of SO(3) (``exp(r + delta) ~
  exp(r) exp(J_r(r) delta)``); every point ``x`` carried by ``k`` or a joint
  below it moves by ``omega x (x - p_k)``;
* the heading turns every point about the vertical ``up`` through the root:
  ``up x (x - p_root)``;
* the root position (centimetres in the parameters, file units in the
  positions) moves every point by ``1 / scale``.

Summed over the joints with the ancestor mask (P, J) this is two small
matrix products per pose, not a loop over parameters. The forward
differences stay in the tests as the reference
(``tests/reconstruct/test_markers.py``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._numba_quaternions import qexp, qmul, qrot

__all__ = ["fk_model_poses", "fk_model_pose", "right_jacobian", "right_jacobian_inverse", "carried_by", "point_jacobian",
           "range_coordinates", "range_excess_jacobian"]


@numba.njit(cache=True)
def fk_model_poses(mean, rel, yaw, root, parents, offsets, mk_joint, mk_offset, gpos, mpos):
    """Global joint and marker positions of poses ``mean[j] * exp(rel[b, j])`` with the root turned by ``yaw[b]``.

    mean (J, 4) local rotations (root: tilt), rel (B, J, 3) rotation vectors
    (radians) relative to them, yaw (B, 4) rotations about the vertical
    applied to the root, root (B, 3) root positions; parents (J,), offsets
    (J, 3); markers on joints ``mk_joint`` (M,) at ``mk_offset`` (M, 3) in the
    joint's global frame. Writes gpos (B, J, 3) and mpos (B, M, 3).
    """
    J = parents.shape[0]
    grot = np.empty((J, 3, 3))  # each pose's rotation matrices, not returned
    for b in range(rel.shape[0]):
        fk_model_pose(mean, rel[b], yaw[b], root[b], parents, offsets, mk_joint, mk_offset, gpos[b], mpos[b], grot)


@numba.njit(cache=True)
def fk_model_pose(mean, rel, yaw, root, parents, offsets, mk_joint, mk_offset, gpos, mpos, grot):
    """One pose ``mean[j] * exp(rel[j])`` with the root turned by ``yaw``: global positions and rotations.

    mean (J, 4) local rotations (root: tilt), rel (J, 3) rotation vectors
    (radians), yaw (4,) rotation about the vertical applied to the root,
    root (3,) root position; parents (J,), offsets (J, 3); markers on joints
    ``mk_joint`` (M,) at ``mk_offset`` (M, 3) in the joint's global frame.
    Writes gpos (J, 3), mpos (M, 3) (the units of ``offsets``) and grot
    (J, 3, 3), each joint's global rotation matrix. :func:`fk_model_poses` runs it for each pose of a batch.
    """
    J = parents.shape[0]
    g = np.empty((J, 4))
    for j in range(J):
        e0, e1, e2, e3 = qexp(rel[j, 0], rel[j, 1], rel[j, 2])
        q0, q1, q2, q3 = qmul(mean[j, 0], mean[j, 1], mean[j, 2], mean[j, 3], e0, e1, e2, e3)
        par = parents[j]
        if par < 0:
            a0, a1, a2, a3 = yaw[0], yaw[1], yaw[2], yaw[3]
            gpos[j, 0], gpos[j, 1], gpos[j, 2] = root[0], root[1], root[2]
        else:
            a0, a1, a2, a3 = g[par, 0], g[par, 1], g[par, 2], g[par, 3]
            ox, oy, oz = qrot(a0, a1, a2, a3, offsets[j, 0], offsets[j, 1], offsets[j, 2])
            gpos[j, 0] = gpos[par, 0] + ox
            gpos[j, 1] = gpos[par, 1] + oy
            gpos[j, 2] = gpos[par, 2] + oz
        w, x, y, z = qmul(a0, a1, a2, a3, q0, q1, q2, q3)
        g[j, 0], g[j, 1], g[j, 2], g[j, 3] = w, x, y, z
        grot[j, 0, 0] = 1.0 - 2.0 * (y * y + z * z)
        grot[j, 0, 1] = 2.0 * (x * y - w * z)
        grot[j, 0, 2] = 2.0 * (x * z + w * y)
        grot[j, 1, 0] = 2.0 * (x * y + w * z)
        grot[j, 1, 1] = 1.0 - 2.0 * (x * x + z * z)
        grot[j, 1, 2] = 2.0 * (y * z - w * x)
        grot[j, 2, 0] = 2.0 * (x * z - w * y)
        grot[j, 2, 1] = 2.0 * (y * z + w * x)
        grot[j, 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    for k in range(mk_joint.shape[0]):
        j = mk_joint[k]
        ox, oy, oz = qrot(g[j, 0], g[j, 1], g[j, 2], g[j, 3], mk_offset[k, 0], mk_offset[k, 1], mk_offset[k, 2])
        mpos[k, 0] = gpos[j, 0] + ox
        mpos[k, 1] = gpos[j, 1] + oy
        mpos[k, 2] = gpos[j, 2] + oz


def _skew(r: np.ndarray) -> np.ndarray:
    """Cross-product matrices (..., 3, 3) of vectors (..., 3)."""
    k = np.zeros(r.shape + (3,))
    k[..., 0, 1], k[..., 0, 2] = -r[..., 2], r[..., 1]
    k[..., 1, 0], k[..., 1, 2] = r[..., 2], -r[..., 0]
    k[..., 2, 0], k[..., 2, 1] = -r[..., 1], r[..., 0]
    return k


def right_jacobian(r: np.ndarray) -> np.ndarray:
    """Right Jacobians (..., 3, 3) of SO(3) at rotation vectors ``r`` (..., 3), radians.

    ``exp(r + delta) = exp(r) exp(J_r(r) delta) + O(|delta|^2)``;
    ``J_r = I - (1 - cos t) / t^2 [r]x + (t - sin t) / t^3 [r]x^2``, ``t = |r|``
    (series below 1e-4 rad).
    """
    t = np.linalg.norm(r, axis=-1)[..., None, None]
    small = t < 1e-4
    ts = np.where(small, 1.0, t)
    a = np.where(small, 0.5 - t**2 / 24.0, (1.0 - np.cos(ts)) / ts**2)
    b = np.where(small, 1.0 / 6.0 - t**2 / 120.0, (ts - np.sin(ts)) / ts**3)
    k = _skew(r)
    return np.eye(3) - a * k + b * (k @ k)


def right_jacobian_inverse(v: np.ndarray) -> np.ndarray:
    """Inverses (..., 3, 3) of :func:`right_jacobian` at rotation vectors ``v`` (..., 3), ``|v| < pi``.

    ``J_r^-1 = I + [v]x / 2 + (1 / t^2 - (1 + cos t) / (2 t sin t)) [v]x^2`` (series below 1e-4 rad).
    """
    t = np.linalg.norm(v, axis=-1)[..., None, None]
    small = t < 1e-4
    ts = np.where(small, 1.0, t)
    c = np.where(small, 1.0 / 12.0 + t**2 / 720.0, 1.0 / ts**2 - (1.0 + np.cos(ts)) / (2.0 * ts * np.sin(ts)))
    k = _skew(v)
    return np.eye(3) + 0.5 * k + c * (k @ k)


def carried_by(parents: np.ndarray, mk_joint: np.ndarray) -> np.ndarray:
    """Float mask (J + M, J): 1 where joint ``k`` is the point's joint or above it.

    Points: the J joints, then the M markers (on joints ``mk_joint``). A
    joint's own rotation does not move its position (its offset hangs from
    the parent), but the lever ``x - p_k`` is zero there, so the mask may hold it.
    """
    J = len(parents)
    anc = np.zeros((J, J))
    for j in range(J):
        k = j
        while k >= 0:
            anc[j, k] = 1.0
            k = parents[k]
    return np.concatenate([anc, anc[np.asarray(mk_joint, dtype=np.int64)]], axis=0)


def point_jacobian(points: np.ndarray, gpos: np.ndarray, grot: np.ndarray, rel: np.ndarray, basis: np.ndarray,
                   mask: np.ndarray, up: np.ndarray, scale: float) -> np.ndarray:
    """Derivatives (P, 3, d + 4) of points (P, 3) with respect to the parameters ``(u, theta, root * scale)``.

    points: the joints then the markers (file units), gpos (J, 3) the joints,
    grot (J, 3, 3) their global rotations, rel (J, 3) the local rotation
    vectors ``mu + basis @ u``, basis (3J, d) the whitened PCA basis
    (radians per unit ``u``), mask (P, J) from :func:`carried_by`, up (3,)
    the unit vertical, scale centimetres per file unit. Columns: ``u``
    (file units per unit), the heading (file units per radian), the root
    position (file units per centimetre).
    """
    J, d = len(gpos), basis.shape[1]
    P = len(points)
    out = np.empty((P, 3, d + 4))
    if d:
        # world angular velocity of each joint per unit u: G_k J_r(r_k) basis_k, (J, 3, d); a point carried by
        # joints k moves by sum_k omega_k x (x - p_k) = [p_k]x omega_k summed - [x]x (omega_k summed)
        w = np.matmul(grot @ right_jacobian(rel), basis.reshape(J, 3, d))
        s = (mask @ w.reshape(J, 3 * d)).reshape(P, 3, d)
        t = (mask @ np.matmul(_skew(gpos), w).reshape(J, 3 * d)).reshape(P, 3, d)
        out[:, :, :d] = t - np.matmul(_skew(points), s)
    out[:, :, d] = (points - gpos[0]) @ _skew(up).T
    out[:, :, d + 1:] = np.eye(3) / scale
    return out

@numba.njit(cache=True)
def range_coordinates(mean, rel, range_mean, axes, v, c):
    """Where the pose ``mean[j] * exp(rel[j])`` lies in each joint's range frame (:class:`.markers._JointRanges`).

    mean (J, 4), rel (J, 3) radians, range_mean (J, 4), axes (J, 3, 3).
    Writes v (J, 3), the rotation vector (radians, ``|v| <= pi``) of
    ``range_mean^-1 * mean * exp(rel)``, and c (J, 3) = ``axes @ v``, the
    coordinates the ranges bound (as ``_JointRanges.excess`` computes them).
    """
    for j in range(rel.shape[0]):
        e0, e1, e2, e3 = qexp(rel[j, 0], rel[j, 1], rel[j, 2])
        q0, q1, q2, q3 = qmul(mean[j, 0], mean[j, 1], mean[j, 2], mean[j, 3], e0, e1, e2, e3)
        p0, p1, p2, p3 = qmul(range_mean[j, 0], -range_mean[j, 1], -range_mean[j, 2], -range_mean[j, 3], q0, q1, q2, q3)
        if p0 < 0:
            p0, p1, p2, p3 = -p0, -p1, -p2, -p3
        s = math.sqrt(p1 * p1 + p2 * p2 + p3 * p3)
        f = 2.0 * (math.atan2(s, p0) / s if s > 1e-12 else 1.0 + s * s / 6.0)
        v[j, 0], v[j, 1], v[j, 2] = f * p1, f * p2, f * p3
        for a in range(3):
            c[j, a] = axes[j, a, 0] * v[j, 0] + axes[j, a, 1] * v[j, 1] + axes[j, a, 2] * v[j, 2]


def range_excess_jacobian(rel: np.ndarray, v: np.ndarray, c: np.ndarray, basis: np.ndarray, axes: np.ndarray,
                          lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Derivative (3J, d) of the joint-range excess (radians, :class:`.markers._JointRanges`) in ``u``.

    rel (J, 3) the pose's rotation vectors (radians), v and c (J, 3) from
    :func:`range_coordinates`, basis (3J, d), the ranges' principal ``axes``
    (J, 3, 3) and bounds ``lo``, ``hi`` (J, 3) radians. ``v`` moves by
    ``J_r(v)^-1 J_r(r) dr``; the excess along an axis by +-1 per radian
    beyond the range, 0 inside (and at the bound, as the excess is).
    """
    J, d = len(rel), basis.shape[1]
    sign = (c > hi).astype(np.float64) - (c < lo)
    if not sign.any():
        return np.zeros((3 * J, d))
    dc = axes @ right_jacobian_inverse(v) @ right_jacobian(rel)  # (J, 3, 3) radians per radian
    return (sign[..., None] * np.matmul(dc, basis.reshape(J, 3, d))).reshape(3 * J, d)
