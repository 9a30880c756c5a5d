"""Quaternion algebra on arrays, w first.

One convention for the whole package, stated once: a quaternion is the last axis
of an array of shape (..., 4) ordered (w, x, y, z); any leading dimensions are
allowed (frames first, then joints). Rotations act on column vectors, and
``quaternion_multiply(a, b)`` rotates by ``b`` first, then ``a`` (the matrix
product ``A @ B``). Missing data is NaN and passes through every function.

Euler angles follow scipy's naming: an upper-case order (``"ZYX"``) is
intrinsic, i.e. the BVH convention where ``CHANNELS Zrotation Yrotation
Xrotation`` means ``R = Rz @ Ry @ Rx``; a lower-case order (``"xyz"``) is
extrinsic, the ASF/AMC convention where ``dof rx ry rz`` applies x first, which
is the same matrix ``R = Rz @ Ry @ Rx``. Orders may name one, two or three axes
(ASF joints often have fewer than three degrees of freedom).

We cross to :class:`scipy.spatial.transform.Rotation` only with
``scalar_first=True`` (see :func:`to_scipy`, :func:`from_scipy`). It is
imported where it is used: ``scipy.spatial`` takes about 0.3 s to import,
which every ``import mocapkit`` and every command would pay otherwise (reading
a take never needs it; its Euler conversion is the hand-written one below).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = [
    "identity",
    "nearest_euler",
    "quaternion_multiply",
    "quaternion_multiply_numpy",
    "quaternion_conjugate",
    "quaternion_inverse",
    "quaternion_normalize",
    "row_norms",
    "quaternion_rotate",
    "quaternion_continuity",
    "quaternion_log",
    "quaternion_exp",
    "quaternion_to_rotvec",
    "rotvec_to_quaternion",
    "quaternion_from_axis_angle",
    "quaternion_twist",
    "shortest_arc",
    "kabsch",
    "geodesic_angle",
    "slerp",
    "euler_to_quaternion",
    "quaternion_to_euler",
    "continuous_euler",
    "quaternion_to_matrix",
    "matrix_to_quaternion",
    "to_scipy",
    "from_scipy",
    "check_quaternions",
]

_AXIS_INDEX = {"x": 1, "y": 2, "z": 3}


def check_quaternions(q: np.ndarray, name: str = "quaternions") -> np.ndarray:
    """Return ``q`` as a float64 array, raising ``ValueError`` unless its last axis is 4."""
    q = np.asarray(q, dtype=np.float64)
    if q.ndim == 0 or q.shape[-1] != 4:
        raise ValueError(f"{name}: expected shape (..., 4) with w first, got {q.shape}")
    return q


def identity(shape: tuple[int, ...] = ()) -> np.ndarray:
    """Identity rotations of the given leading shape, (*shape, 4).

    >>> identity((2,)).tolist()
    [[1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]
    """
    q = np.zeros(tuple(shape) + (4,))
    q[..., 0] = 1.0
    return q


#: rows from which :func:`quaternion_multiply` runs the numba loop (below, numpy's temporaries cost less than a call)
KERNEL_ROWS = 2048


def quaternion_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of (..., 4) arrays (broadcasting): rotate by b, then a.

    From :data:`KERNEL_ROWS` products on, one numba pass (:func:`mocapkit._numba_quaternions.multiply_rows`: the
    same sums in the same order, the same numbers bit for bit, 4-8x faster on a 60 s take's (7200, 31, 4)
    rotations); where an input or a result is not finite, numpy's (:func:`quaternion_multiply_numpy`: its NaN
    signs and its warnings)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    shape = np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    rows = math.prod(shape)
    if rows < KERNEL_ROWS or a.ndim == 0 or b.ndim == 0 or a.shape[-1] != 4 or b.shape[-1] != 4:
        return quaternion_multiply_numpy(a, b)
    # C-contiguous and writable (a copy where broadcast, strided or read-only, as a Motion's arrays are): the one
    # signature the kernel is compiled for (numba types a read-only array apart; mocapkit.warmup compiles it)
    ar = np.require(a if a.shape[:-1] == shape else np.broadcast_to(a, shape + (4,)), None, ("C", "W")).reshape(rows, 4)
    br = np.require(b if b.shape[:-1] == shape else np.broadcast_to(b, shape + (4,)), None, ("C", "W")).reshape(rows, 4)
    from ._numba_quaternions import multiply_rows

    out = np.empty((rows, 4))
    if not multiply_rows(ar, br, out):  # a NaN or inf in or out: numpy's, with its NaN signs and its warning
        return quaternion_multiply_numpy(a, b)
    return out.reshape(shape + (4,))


def quaternion_multiply_numpy(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`quaternion_multiply` in numpy alone (the reference its numba loop is tested against)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    # each component written into its place (``np.stack`` of the four, the same numbers, copied 3x slower)
    out = np.empty(np.broadcast_shapes(aw.shape, bw.shape) + (4,))
    out[..., 0] = aw * bw - ax * bx - ay * by - az * bz
    out[..., 1] = aw * bx + ax * bw + ay * bz - az * by
    out[..., 2] = aw * by - ax * bz + ay * bw + az * bx
    out[..., 3] = aw * bz + ax * by - ay * bx + az * bw
    return out


def quaternion_conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate (w, -x, -y, -z); the inverse of a unit quaternion."""
    q = np.asarray(q, dtype=np.float64)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quaternion_inverse(q: np.ndarray) -> np.ndarray:
    """Inverse ``conj(q) / |q|^2`` (equals the conjugate for unit quaternions)."""
    q = np.asarray(q, dtype=np.float64)
    return quaternion_conjugate(q) / np.sum(q * q, axis=-1, keepdims=True)


def row_norms(x: np.ndarray, keepdims: bool = False) -> np.ndarray:
    """Euclidean norms over the last axis, ``np.linalg.norm(x, axis=-1, keepdims=keepdims)`` bit for bit.

    For float64 ``x`` whose last axis holds 2-4 entries (quaternions, 3-vectors) the squares are summed column by
    column in axis order, ``((x0^2 + x1^2) + x2^2) + x3^2``, the order numpy's reduction adds so few entries in
    (``tests/test_rotations.py`` checks every bit on every shape the library passes, NaN and inf included), without
    its per-row reduction loop: 2.5-4x faster on a take's (F, J, 4) rotations. Other inputs go to numpy.
    """
    x = np.asarray(x)
    n = x.shape[-1] if x.ndim else 0
    if x.dtype != np.float64 or not 2 <= n <= 4:
        return np.linalg.norm(x, axis=-1, keepdims=keepdims)
    s = x[..., 0] * x[..., 0]
    for i in range(1, n):
        s += x[..., i] * x[..., i]
    out = np.sqrt(s)
    return out[..., None] if keepdims else out


def quaternion_normalize(q: np.ndarray) -> np.ndarray:
    """Scale to unit length; a zero quaternion becomes NaN (it is no rotation)."""
    q = np.asarray(q, dtype=np.float64)
    norm = row_norms(q, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = q / norm
    out[np.broadcast_to(norm == 0.0, out.shape)] = np.nan
    return out


def quaternion_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v`` (..., 3) by unit quaternions ``q`` (..., 4), broadcasting.

    Uses ``v' = v + 2 w (u x v) + 2 u x (u x v)`` with ``u = (x, y, z)``.

    >>> q = quaternion_from_axis_angle([0, 0, 1], np.pi / 2)
    >>> np.round(quaternion_rotate(q, [1.0, 0.0, 0.0]), 12).tolist()
    [0.0, 1.0, 0.0]
    """
    q = np.asarray(q, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    u = q[..., 1:]
    w = q[..., :1]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quaternion_continuity(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip signs along ``axis`` (time) so consecutive quaternions lie in one hemisphere.

    ``q`` and ``-q`` are the same rotation; interpolation, filtering and
    learning need the sign chosen consistently. NaN samples stay NaN and are
    bridged: the first sample after a gap is compared with the last one before it.
    """
    q = check_quaternions(q)
    q = np.moveaxis(q, axis, 0)
    n = q.shape[0]
    if n < 2:
        return np.moveaxis(q.copy(), 0, axis)
    valid = np.all(np.isfinite(q), axis=-1)
    frame = np.arange(n).reshape((n,) + (1,) * (q.ndim - 2))
    last = np.maximum.accumulate(np.where(valid, frame, 0), axis=0)
    filled = np.take_along_axis(q, last[..., None], axis=0)
    flips = np.sum(filled[1:] * filled[:-1], axis=-1) < 0.0
    parity = np.concatenate([np.zeros((1,) + flips.shape[1:], dtype=np.int64), np.cumsum(flips, axis=0)], axis=0)
    sign = np.where(parity % 2 == 1, -1.0, 1.0)[..., None]
    return np.moveaxis(q * sign, 0, axis)


def quaternion_log(q: np.ndarray) -> np.ndarray:
    """Logarithm of unit quaternions as (..., 3) vectors ``(theta / 2) * axis``.

    The pure-quaternion log, so ``|log(q)|`` is half the rotation angle and
    ``|log(a^-1 b)|^2`` is the geodesic term of Aristidou et al. 2018, eq. 1.
    ``q`` and ``-q`` give logs of the same rotation; the one with ``w >= 0``
    (angle at most pi) is returned.
    """
    q = check_quaternions(q)
    q = np.where(q[..., :1] < 0.0, -q, q)
    v = q[..., 1:]
    s = row_norms(v, keepdims=True)
    half = np.arctan2(s, q[..., :1])
    # sin(half)/half -> 1 as half -> 0; use the series to stay exact near identity.
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(s > 1e-12, half / np.where(s > 1e-12, s, 1.0), 1.0 + s * s / 6.0)
    out = v * scale
    out[np.any(np.isnan(q), axis=-1)] = np.nan
    return out


def quaternion_exp(v: np.ndarray) -> np.ndarray:
    """Inverse of :func:`quaternion_log`: (..., 3) vectors ``(theta / 2) * axis`` to (..., 4)."""
    v = np.asarray(v, dtype=np.float64)
    half = row_norms(v, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        sinc = np.where(half > 1e-12, np.sin(half) / np.where(half > 1e-12, half, 1.0), 1.0 - half * half / 6.0)
    return np.concatenate([np.cos(half), v * sinc], axis=-1)


def quaternion_to_rotvec(q: np.ndarray) -> np.ndarray:
    """Rotation vectors ``theta * axis`` (radians), (..., 3)."""
    return 2.0 * quaternion_log(q)


def rotvec_to_quaternion(r: np.ndarray) -> np.ndarray:
    """Unit quaternions from rotation vectors ``theta * axis`` (radians)."""
    return quaternion_exp(0.5 * np.asarray(r, dtype=np.float64))


def quaternion_from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Quaternion rotating by ``angle`` radians about ``axis`` (normalised here)."""
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    half = 0.5 * np.asarray(angle, dtype=np.float64)[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def quaternion_twist(q: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Twist of ``q`` (..., 4) about the unit ``axis`` (3,) in the swing-twist decomposition.

    The projection of ``q`` onto ``(w, axis)``, normalised; where that is zero
    (a pure 180-degree swing) the identity. About the vertical axis this is a
    root's heading, so ``conjugate(twist) * q`` is its tilt alone.
    """
    q = np.asarray(q, dtype=np.float64)
    axis = np.asarray(axis, dtype=np.float64)
    t = np.concatenate([q[..., :1], (q[..., 1:] @ axis)[..., None] * axis], axis=-1)
    n = np.linalg.norm(t, axis=-1, keepdims=True)
    ok = n > 1e-9
    return np.where(ok, t / np.where(ok, n, 1.0), identity())


def shortest_arc(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The smallest rotations (..., 4) taking the directions of ``u`` (..., 3) onto those of ``v`` (..., 3).

    The half-angle form ``q ~ (1 + u.v, u x v)`` for unit ``u, v``; opposite
    directions turn by pi about a perpendicular axis (``u`` crossed with the
    coordinate axis it is least along); the identity where either vector is
    zero or not finite. Used to swing a bone onto a direction: inverse
    kinematics, rest-pose retargeting, mirroring and sensor placement.
    """
    uu, oku = _unit_rows(np.asarray(u, dtype=np.float64))
    vv, okv = _unit_rows(np.asarray(v, dtype=np.float64))
    w = 1.0 + np.sum(uu * vv, axis=-1)
    q = np.concatenate([w[..., None], np.cross(uu, vv)], axis=-1)
    anti = w < 1e-12
    if np.any(anti):
        k = np.argmin(np.abs(uu[anti]), axis=-1)
        perp, ok = _unit_rows(np.cross(uu[anti], np.eye(3)[k]))
        perp = np.where(ok[..., None], perp, np.array([1.0, 0.0, 0.0]))
        q[anti] = np.concatenate([np.zeros((int(anti.sum()), 1)), perp], axis=-1)
    q = q / np.linalg.norm(q, axis=-1)[..., None]
    q[~(oku & okv)] = np.array([1.0, 0.0, 0.0, 0.0])
    return q


def _unit_rows(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit rows of ``v`` (..., 3) and a mask of the nonzero ones (zero rows stay zero)."""
    n = np.linalg.norm(v, axis=-1)
    ok = n > 0.0
    safe = np.where(ok, n, 1.0)
    return np.where(ok[..., None], v / safe[..., None], 0.0), ok


def kabsch(ref: np.ndarray, cur: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) taking the points ``ref`` best onto ``cur`` (..., K, 3) (Kabsch 1976).

    ``ref`` (K, 3) for one reference shape, or (..., K, 3) like ``cur`` for one
    per set. Least squares over the K points as given (centre both first for a
    rigid fit): ``cur_k ~ R ref_k``; a reflection is never returned (the
    smallest singular direction is flipped instead).
    """
    ref = np.asarray(ref, dtype=np.float64)
    cur = np.asarray(cur, dtype=np.float64)
    shape = cur.shape[:-2]
    cur = cur.reshape((-1,) + cur.shape[-2:])
    if ref.ndim == 2:
        h = np.einsum("ki,tkj->tij", ref, cur)  # (T, 3, 3) = sum_k ref_k cur_k^T
    else:
        h = np.einsum("tki,tkj->tij", ref.reshape(cur.shape), cur)
    u, _, vt = np.linalg.svd(h)
    det = np.sign(np.linalg.det(np.einsum("tji,tkj->tik", vt, u)))
    det[det == 0] = 1.0
    d = np.ones((h.shape[0], 3))
    d[:, 2] = det
    # R = V diag(1, 1, det) U^T
    return np.einsum("tji,tj,tkj->tik", vt, d, u).reshape(shape + (3, 3))


def geodesic_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle in radians, in [0, pi], between rotations ``a`` and ``b`` (broadcasting).

    Equals ``2 |log(a^-1 b)|``; computed with ``atan2`` so it is accurate for
    both tiny and near-pi angles, and symmetric in its arguments. Either sign
    of a quaternion gives the same angle, and a quaternion need not be of unit
    length. NaN where either rotation has a NaN (a missing joint), quietly:
    a caller comparing takes with gaps reads NaN there (``np.nanmax`` and the
    like leave those cells out).
    """
    a = check_quaternions(a, "a")
    b = check_quaternions(b, "b")
    d = quaternion_multiply(quaternion_conjugate(a), b)
    d = d / row_norms(d, keepdims=True)
    return 2.0 * np.arctan2(row_norms(d[..., 1:]), np.abs(d[..., 0]))


def slerp(a: np.ndarray, b: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """Spherical linear interpolation from ``a`` (t=0) to ``b`` (t=1) along the shorter arc.

    ``t`` broadcasts against the leading shape of ``a`` and ``b``.
    """
    a = check_quaternions(a, "a")
    b = check_quaternions(b, "b")
    t = np.asarray(t, dtype=np.float64)[..., None]
    dot = np.sum(a * b, axis=-1, keepdims=True)
    b = np.where(dot < 0.0, -b, b)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_theta = np.sin(theta)
    small = sin_theta < 1e-9
    with np.errstate(invalid="ignore", divide="ignore"):
        wa = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / np.where(small, 1.0, sin_theta))
        wb = np.where(small, t, np.sin(t * theta) / np.where(small, 1.0, sin_theta))
    return quaternion_normalize(wa * a + wb * b)


def _check_order(order: str) -> tuple[str, bool]:
    if not isinstance(order, str) or not 1 <= len(order) <= 3:
        raise ValueError(f"Euler order must name 1 to 3 axes like 'ZYX' or 'xz', got {order!r}")
    if not (order.isupper() or order.islower()):
        raise ValueError(f"Euler order {order!r} mixes cases: upper is intrinsic, lower extrinsic")
    low = order.lower()
    if any(c not in _AXIS_INDEX for c in low):
        raise ValueError(f"Euler order {order!r} may only contain x, y and z")
    for i in range(len(low) - 1):
        if low[i] == low[i + 1]:
            raise ValueError(f"Euler order {order!r} repeats an axis consecutively")
    return low, order.isupper()


def euler_to_quaternion(angles: np.ndarray, order: str, degrees: bool = True) -> np.ndarray:
    """Quaternions from Euler angles (..., n) about the n axes named by ``order``.

    Upper-case orders are intrinsic (BVH: ``"ZYX"`` gives ``Rz @ Ry @ Rx``),
    lower-case extrinsic (ASF: ``"xyz"`` gives the same matrix). Vectorised as a
    product of elementary half-angle quaternions; about 15x faster than scipy's
    ``from_euler`` on whole clips, and checked against it in the tests.

    >>> q = euler_to_quaternion([90.0, 0.0, 0.0], "ZYX")
    >>> np.round(q, 6).tolist()
    [0.707107, 0.0, 0.0, 0.707107]
    """
    low, intrinsic = _check_order(order)
    angles = np.asarray(angles, dtype=np.float64)
    if angles.shape[-1:] != (len(low),):
        raise ValueError(f"Euler angles for order {order!r}: expected shape (..., {len(low)}), got {angles.shape}")
    half = (np.deg2rad(angles) if degrees else angles) * 0.5
    c, s = np.cos(half), np.sin(half)
    # Intrinsic a-b-c is R = Ra Rb Rc; extrinsic a-b-c is R = Rc Rb Ra.
    seq = range(len(low)) if intrinsic else range(len(low) - 1, -1, -1)
    out = None
    for i in seq:
        e = np.zeros(angles.shape[:-1] + (4,))
        e[..., 0] = c[..., i]
        e[..., _AXIS_INDEX[low[i]]] = s[..., i]
        out = e if out is None else quaternion_multiply(out, e)
    return out


def _complete_order(low: str) -> str:
    """Extend a 1- or 2-axis (lower-case) order to a 3-axis Tait-Bryan order containing it."""
    if len(low) == 3:
        return low
    missing = [a for a in "xyz" if a not in low]
    if len(low) == 2:
        return low[0] + missing[0] + low[1]
    return low + missing[0] + missing[1]


def quaternion_to_euler(q: np.ndarray, order: str, degrees: bool = True) -> np.ndarray:
    """Euler angles (..., n) for the n axes of ``order`` (case as in :func:`euler_to_quaternion`).

    For 3-axis orders this is exact (up to the usual gimbal-lock ambiguity; the
    returned angles always reproduce the rotation). For 1- and 2-axis orders the
    rotation is decomposed in a 3-axis order that contains them and the extra
    axis is dropped: exact when the rotation has no component about that axis
    (as for an ASF joint with fewer degrees of freedom), a projection otherwise.
    NaN quaternions give NaN angles.
    """
    low, intrinsic = _check_order(order)
    q = check_quaternions(q)
    full = _complete_order(low)
    shape = q.shape[:-1]
    flat = q.reshape(-1, 4)
    # finite and not zero (each column's test, then the norm: the mask np.all(np.isfinite) & norm > 0 gives)
    good = np.isfinite(flat[:, 0]) & np.isfinite(flat[:, 1]) & np.isfinite(flat[:, 2]) & np.isfinite(flat[:, 3])
    good &= row_norms(flat) > 0
    every = len(good) > 0 and bool(good.all())
    out = None if every else np.full((flat.shape[0], 3), np.nan)
    if every or np.any(good):
        seq = full.upper() if intrinsic else full
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # gimbal lock is handled: angles stay valid
            if every:  # no copy in and out of the rows that convert (a take without gaps: all of them)
                out = to_scipy(flat).as_euler(seq, degrees=degrees)
            else:
                out[good] = to_scipy(flat[good]).as_euler(seq, degrees=degrees)
    keep = [full.index(a) for a in low]
    return out[:, keep].reshape(shape + (len(low),))


def continuous_euler(angles, order: str, fixed=None, start=None, degrees: bool = True,
                     max_step: float = 90.0) -> np.ndarray:
    """Euler angles rewritten as the equivalent angles nearest their neighbouring frames (an "Euler filter").

    The one rule every writer of Euler text follows (:func:`mocapkit.io.bvh.write_bvh`,
    :func:`mocapkit.io.amc_writer.write_amc`), so that the written curves are
    continuous as a graph editor shows them. A rotation has many Euler
    triples: each angle plus any whole turn and, for a 3-axis ``order``, the
    other branch of the middle angle, ``(a + 180, 180 - b, c + 180)``
    (``(a + 180, -b, c + 180)`` for a repeated-axis order such as ``"ZXZ"``).
    With fewer than 3 axes (an ASF bone with 1 or 2 dofs, a BVH joint with
    1 or 2 rotation channels) only whole turns apply. For each cell that is
    not ``fixed`` the triple nearest a reference (sum of absolute
    differences; a tie keeps the branch ``angles`` gives) is chosen:

    - the value of the nearest ``fixed`` cell of the same column, chained
      through the cells in between (each nearest the one written next to it;
      a cell between two fixed ones follows the nearer, the earlier on a tie);
    - in a column with no fixed cell, each frame the one before it, the first
      (finite) frame nearest ``start`` when given, else as ``angles`` has it.

    Where the rotation itself jumps, by more than ``max_step`` from the frame
    it is chained from (a T-pose frame 0 before the motion, a cut, a broken
    frame), nothing is continuous: the cell keeps the branch of the middle
    angle ``angles`` gives (whole turns are still chosen), so a jump does not
    carry a whole take onto the other branch. Between two fixed cells on
    different branches (the file itself jumps there) the changed cells are
    split between the two chains where the written curve's total variation
    is least (nearest the middle on a tie).

    Parameters
    ----------
    angles : array (F, n) or (F, K, n)
        Any Euler triples of the rotations (degrees, or radians with
        ``degrees=False``), frames first, K columns (joints) of ``n`` angles
        in ``order``; e.g. :func:`quaternion_to_euler`'s output. Cells with a
        NaN angle stay NaN and are skipped (the chain crosses them).
    order : str
        The axes of the ``n`` angles (case as in :func:`euler_to_quaternion`;
        intrinsic and extrinsic orders have the same equivalent triples).
    fixed : bool array (F,) or (F, K), optional
        Cells kept exactly as ``angles`` gives them (a file's own numbers,
        which are the reference of the cells around them). None: none.
    start : array (n,) or (K, n), optional
        Where a column with no fixed cell starts from (e.g. the file's own
        numbers of its first frame, to stay on the file's branch); NaN or None:
        its first frame as given.
    degrees : bool
        Units of ``angles`` and ``start``.
    max_step : float
        Degrees, whatever the units of ``angles``: the largest rotation from
        one frame to the next across which the branch of the middle angle is
        continued. 90 is above the steps of fast real motion (the bundled CMU
        pirouette turns a joint by up to 61 degrees in a frame at 120 Hz) and
        below a flip's 180; a larger step (a T-pose edge, the backflip's 179
        degree glitches) starts the branch afresh.

    Returns
    -------
    ndarray, the shape of ``angles``: fixed cells and NaN cells bit for bit
    as given, every other cell an equivalent triple of the same rotation
    (bit for bit as given when no turn or branch change was needed).
    """
    low, _ = _check_order(order)
    a = np.asarray(angles, dtype=np.float64)
    flat = a.ndim == 2
    if a.ndim not in (2, 3) or a.shape[-1] != len(low):
        raise ValueError(f"Euler angles for order {order!r}: expected shape (F, {len(low)}) or (F, K, {len(low)}), "
                         f"got {a.shape}")
    a3 = np.ascontiguousarray(a[:, None] if flat else a)
    F, K, n = a3.shape
    fx = np.zeros((F, K), dtype=np.bool_) if fixed is None else np.asarray(fixed, dtype=np.bool_).reshape(F, K)
    st = np.full((K, n), np.nan) if start is None else np.asarray(start, dtype=np.float64).reshape(K, n)
    flip = 0 if n < 3 else (2 if low[0] == low[2] else 1)
    if F == 0 or K == 0:
        return a.copy()
    from ._numba_euler import continuous_kernel

    axes = np.array([_AXIS_INDEX[c] for c in low], dtype=np.int64)
    out = continuous_kernel(a3, np.ascontiguousarray(fx), np.ascontiguousarray(st), flip,
                            360.0 if degrees else 2.0 * np.pi, float(np.cos(np.radians(max_step) / 2.0)),
                            axes, order.isupper())
    return out[:, 0] if flat else out


def nearest_euler(angles, ref, order: str, degrees: bool = True) -> np.ndarray:
    """The Euler triples of ``angles``' rotations nearest ``ref``, cell by cell: (..., n), the shape of ``angles``.

    The candidates are those :func:`continuous_euler` chooses among (each angle plus whole turns and, for a
    3-axis ``order``, the other branch of the middle angle); the nearest is the one with the least sum of absolute
    differences from ``ref`` (a tie keeps the branch ``angles`` gives). A writer of a changed cell uses it with the
    source file's own numbers of that cell as ``ref``, so the written curve stays on the file's branch wherever the
    file's does (a denoised or slightly corrected joint near gimbal lock, a joint whose file angle is past 180).
    ``angles`` and ``ref`` broadcast, degrees (radians with ``degrees=False``); a cell with a NaN in ``ref`` is
    returned as ``angles`` gives it.
    """
    low, _ = _check_order(order)
    a = np.asarray(angles, dtype=np.float64)
    r = np.broadcast_to(np.asarray(ref, dtype=np.float64), a.shape)
    if a.shape[-1] != len(low):
        raise ValueError(f"Euler angles for order {order!r}: expected shape (..., {len(low)}), got {a.shape}")
    period = 360.0 if degrees else 2.0 * np.pi
    half = period / 2.0
    cands = [a]
    if len(low) == 3:
        middle = -a[..., 1] if low[0] == low[2] else half - a[..., 1]
        cands.append(np.stack([a[..., 0] + half, middle, a[..., 2] + half], axis=-1))
    best = best_cost = None
    for c in cands:
        w = c - period * np.round((c - r) / period)  # each angle the whole turn nearest ref
        cost = np.abs(w - r).sum(axis=-1)
        if best is None:
            best, best_cost = w, cost
        else:
            take = cost < best_cost - 1e-9 * period
            best = np.where(take[..., None], w, best)
            best_cost = np.where(take, cost, best_cost)
    return np.where(np.isfinite(r).all(axis=-1, keepdims=True), best, a)


def quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from unit quaternions (..., 4)."""
    q = check_quaternions(q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )


def matrix_to_quaternion(m: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4), w >= 0, from rotation matrices (..., 3, 3) (via scipy)."""
    m = np.asarray(m, dtype=np.float64)
    if m.shape[-2:] != (3, 3):
        raise ValueError(f"rotation matrices: expected shape (..., 3, 3), got {m.shape}")
    from scipy.spatial.transform import Rotation

    shape = m.shape[:-2]
    q = from_scipy(Rotation.from_matrix(m.reshape(-1, 3, 3)))
    q = np.where(q[:, :1] < 0, -q, q)
    return q.reshape(shape + (4,))


def to_scipy(q: np.ndarray) -> Rotation:
    """A scipy ``Rotation`` from (..., 4) w-first quaternions (flattened to (N, 4))."""
    from scipy.spatial.transform import Rotation

    q = check_quaternions(q)
    return Rotation.from_quat(q.reshape(-1, 4), scalar_first=True)


def from_scipy(r: Rotation) -> np.ndarray:
    """(N, 4) w-first quaternions from a scipy ``Rotation``."""
    return np.asarray(r.as_quat(scalar_first=True)).reshape(-1, 4)
