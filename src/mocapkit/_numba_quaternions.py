"""Scalar quaternion helpers for numba kernels (w first), inlined into the kernels that call them.

The forward-kinematics kernels of :mod:`mocapkit.reconstruct.markers` and
:mod:`mocapkit.reconstruct.accelerometers` work one joint at a time on
scalars, where the array functions of :mod:`mocapkit.rotations` would
allocate per call. Same convention as :mod:`mocapkit.rotations`: a
quaternion is ``(w, x, y, z)``, a rotation vector is axis times angle in
radians. Each function is tested against its array twin in
:mod:`mocapkit.rotations`.

:func:`multiply_rows` is the loop behind :func:`mocapkit.rotations.quaternion_multiply` on many rows: the
same products and sums in the same order, one pass without the temporaries numpy makes per term.

Importing this module compiles nothing: numba compiles a helper the first
time a kernel that calls it is compiled (and caches it with that kernel).
"""

from __future__ import annotations

import math

import numba

__all__ = ["qmul", "qrot", "qexp", "multiply_rows"]


@numba.njit(cache=True, inline="always")
def qmul(a0, a1, a2, a3, b0, b1, b2, b3):
    """Hamilton product a * b of two quaternions given as scalars; returns (w, x, y, z)."""
    return (
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
        a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
    )


@numba.njit(cache=True, inline="always")
def qrot(q0, q1, q2, q3, x, y, z):
    """The vector (x, y, z) rotated by the unit quaternion q; returns (x', y', z') in the vector's units."""
    # v + 2 w (u x v) + 2 u x (u x v), u = (q1, q2, q3)
    tx = 2.0 * (q2 * z - q3 * y)
    ty = 2.0 * (q3 * x - q1 * z)
    tz = 2.0 * (q1 * y - q2 * x)
    return (x + q0 * tx + (q2 * tz - q3 * ty), y + q0 * ty + (q3 * tx - q1 * tz), z + q0 * tz + (q1 * ty - q2 * tx))


@numba.njit(cache=True, inline="always")
def qexp(rx, ry, rz):
    """The unit quaternion (w, x, y, z) of the rotation vector (rx, ry, rz), radians (a series near zero)."""
    ang = math.sqrt(rx * rx + ry * ry + rz * rz)
    s = math.sin(0.5 * ang) / ang if ang > 1e-12 else 0.5 - ang * ang / 48.0
    return math.cos(0.5 * ang), rx * s, ry * s, rz * s


@numba.njit(cache=True)
def multiply_rows(a, b, out):
    """``out[i] = a[i] * b[i]`` (Hamilton product) for (N, 4) float64 rows, C-contiguous; True when every
    component written is finite.

    Each component is :func:`qmul`'s expression, the terms added left to right as
    :func:`mocapkit.rotations.quaternion_multiply` adds them (no fused multiply-add: numba does not contract
    without ``fastmath``), so a finite result is the same number, bit for bit (IEEE rounds each product and sum
    alone). Every component reads all eight inputs, and an inf or NaN, once made, never turns finite again: a
    finite result had finite inputs and no overflow on the way. Otherwise (False) the caller takes numpy's: the
    sign bit of a NaN that ``inf - inf`` makes depends on the operand order the compiler picks, and numpy warns.
    """
    ok = True
    for i in range(a.shape[0]):
        w, x, y, z = qmul(a[i, 0], a[i, 1], a[i, 2], a[i, 3], b[i, 0], b[i, 1], b[i, 2], b[i, 3])
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = w, x, y, z
        if not (math.isfinite(w) and math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
            ok = False
    return ok
