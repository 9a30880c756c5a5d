"""Full-body motion from four accelerometers (Tautges 2012, chapter 3; Tautges et al. 2011).

Four 3-D accelerometers on the lower arms and legs, next to the wrists and
ankles (:func:`mocapkit.features.default_sensors`, Fig. 3.3), drive a
data-driven synthesis from a :class:`~mocapkit.database.MotionDatabase`:

1. **Knowledge base** (sec. 3.3, :func:`knowledge_base`): every database clip
   gets simulated readings of the same sensors
   (:func:`~mocapkit.features.virtual_accelerometers`, m/s^2, sensor frames),
   indexed for kNN search (:class:`~mocapkit.search.knn.KNNIndex`, 12-D), and
   per frame the pose vector (the root's tilt and every joint's local rotation
   as rotation vectors, radians), the velocities and accelerations of all
   joints and sensors in the root frame (five-point stencils, eqs. 3.1/3.2,
   cm/s and cm/s^2) and the root motion (sec. 3.6.4). It is computed clip by
   clip and cached per (database, sensors).
2. **Search** (sec. 3.4): the K nearest readings of every new sample feed an
   :class:`~mocapkit.search.lng.OnlineLazyNeighborhoodGraph` (window M = 13);
   the I cheapest paths ending in the newest column give the poses
   ``Q^t`` and, by eq. 3.3, the weights ``W^t``.
3. **Synthesis** (sec. 3.5): the pose minimises eq. 3.4,
   ``w_prior (w_pose E_pose + w_motion E_motion + w_smooth E_smooth) + w_contr E_contr``
   with the square-root kernels of eqs. 3.7, 3.9, 3.10 and 3.13, in the
   weighted-PCA space of ``Q^t`` keeping 99% of the variance, starting from
   the previous pose. The root follows the weighted mean root motion of
   ``Q^t`` (sec. 3.6.4).

The frame of the energies is the *root frame*: root at the origin, heading
(rotation about the vertical) removed, the root's tilt kept
(:func:`mocapkit.features.root_frame`); lengths in centimetres.

Departures from the thesis, all documented where they happen:

* Minimiser: instead of MATLAB's ``lsqnonlin``, majorise-minimise with
  Gauss-Newton steps: each square-root kernel ``sqrt(|r|)`` is bounded by a
  quadratic tangent at the current residual (iteratively reweighted least
  squares), forward kinematics is linearised by finite differences in the PCA
  coordinates, and a halving line search keeps every step downhill on the
  true energy (eq. 3.4).
* The pose prior (eq. 3.7) measures ``|q_i - q|`` between rotation-vector
  pose vectors (the thesis: joint angles); the residual of ``q_i`` outside the
  PCA subspace stays in the distance.
* The control term (eqs. 3.12/3.13) uses the sensor positions themselves (on
  the forearm / shin) as the "joints next to the sensors", with the
  neighbours' sensor velocities ``v_i^{t+1}``; ``alpha^{t+1}`` is turned into
  the root frame by the sensor orientations of the previous synthesised pose,
  and gravity is subtracted.
* The knowledge base keeps each clip's own skeleton (the thesis averages bone
  lengths); the output is posed on the database's first skeleton or the
  performer's (same topology).
* K, the neighbours per sample, defaults to 1 % of the database's frames
  within [128, 4096] (:func:`default_k`; the thesis' 4096 is 0.7 % of its
  560,000 frames), and I, the paths kept, to K / 16 (the thesis' 256 of
  4096): on the small databases of ``../shared/data`` the thesis' fixed
  values average poses from a third of the database.

Sampling rates. The synthesis runs at the database's rate. Readings at another
rate are linearly interpolated onto the database's time grid as they arrive;
the pose returned for a reading is the latest one synthesised at or before its
time (a zero-order hold, at most one database frame late), so the output has
one pose per input sample at the input's rate.

Missing readings. A sample with any non-finite value holds the previous pose
(state unchanged, the graph not updated); before the first valid sample the
pose is the knowledge base's mean pose at the origin.

Recordings as CSV (:func:`read_readings_csv`, :func:`write_readings_csv`)::

    time,left_wrist.x,left_wrist.y,left_wrist.z,right_wrist.x,...,right_ankle.z
    0.000000,1.234,-9.61,0.52,...

One header line: ``time`` then three columns ``<sensor>.x, <sensor>.y,
<sensor>.z`` per sensor, in the sensor's local frame, m/s^2 (gravity
included, as an accelerometer reads it); time in seconds, strictly
increasing. Empty cells and ``nan`` are missing values. The default sensor
names are those of :func:`~mocapkit.features.default_sensors`:
``left_wrist, right_wrist, left_ankle, right_ankle``. Irregular time stamps
are resampled (linearly) to a uniform rate, the median sample interval.

Examples
--------
>>> import mocapkit
>>> from mocapkit import samples
>>> from mocapkit.database import MotionDatabase
>>> from mocapkit.features import virtual_accelerometers
>>> db = MotionDatabase.build([samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")], fps=25,
...                           mirror=True, progress=False, executor="serial")
>>> test = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")).resample(25)
>>> out = reconstruct(virtual_accelerometers(test), db, fps=25)
>>> out.num_frames == test.num_frames, out.fps
(True, 25.0)
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple, Sequence

import numba
import numpy as np
from tqdm.auto import tqdm

from .. import rotations as R
from ..database import MotionDatabase
from ..errors import MocapFormatError
from ..features import Sensor, _root_frame, default_sensors, detect_up_axis, five_point_derivative, virtual_accelerometers
from ..motion import Motion, Skeleton, unit_scale_cm
from ..search.knn import KNNIndex
from ..search.lng import OnlineLazyNeighborhoodGraph
from ._common import _qexp, _qmul, _qrot, output_skeleton, per_clip

__all__ = [
    "DEFAULTS",
    "default_k",
    "KnowledgeBase",
    "knowledge_base",
    "Pose",
    "AccelerometerReconstructor",
    "reconstruct",
    "reconstruct_nearest_neighbor",
    "reconstruct_mahalanobis",
    "read_readings_csv",
    "write_readings_csv",
]

#: Default parameters of :class:`AccelerometerReconstructor` (weights of sec. 3.5.3).
DEFAULTS: dict = {
    "k": None,  # kNN per sample; None: 1 % of the database's frames, clamped to [128, 4096] (see default_k)
    "n_paths": None,  # I, the best OLNG paths kept; None: K / 16 (the thesis' 256 of 4096)
    "window": 13,  # OLNG window M (Fig. 3.19)
    "penalty_factor": 2.0,  # OLNG shortness penalty (Fig. 3.8)
    "extra_steps": True,  # OLNG steps of Fig. 3.10 c
    "w_contr": 1.0,
    "w_prior": 5.0,
    "w_pose": 0.6,
    "w_motion": 0.2,
    "w_smooth": 0.2,
    "variance": 0.99,  # weighted-PCA variance kept (sec. 3.5.3)
    "max_components": 24,
    "iterations": 12,  # majorise-minimise / Gauss-Newton steps per frame
    "prior": "kernel",  # "kernel" (eqs. 3.7-3.13) or "mahalanobis" (sec. 3.6.2 comparison)
    "backend": "kdtree",  # KNNIndex backend ("kdtree" as the thesis; "brute" is faster for large K / small N)
    "eps": 0.0,  # kd-tree approximation factor
    "gravity": 9.81,  # m/s^2
}

_EPS_POSE = 1e-4  # rad: floor of the pose residual in the reweighting
_EPS_POS = 1e-3  # cm (cm/s^2 for the smoothness residual)
_FD_STEP = 1e-4  # finite-difference step in PCA coordinates


# -- knowledge base (sec. 3.3) --------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class KnowledgeBase:
    """What the synthesis needs from a database, per frame (Tautges 2012, sec. 3.3).

    Attributes
    ----------
    sensors : tuple of Sensor (S,)
    up : float array (3,)
        The vertical axis of the database skeletons.
    readings : float array (N, 3S)
        Simulated accelerometer readings, m/s^2, sensor frames.
    poses : float array (N, 3J)
        Pose vectors: root tilt (heading removed) and the local rotations of
        joints 1..J-1 as rotation vectors, radians.
    pose_mean : float array (3J,), pose_basis : float array (3J, P)
        The directions in which the database's pose vectors vary at all
        (global PCA, variance above 1e-12 of the largest), orthonormal.
    pose_coords : float array (N, P)
        ``(poses - pose_mean) @ pose_basis``: the pose vectors without their
        constant directions (joints without degrees of freedom), for a
        cheaper per-frame PCA.
    velocities, accelerations : float32 arrays (N, M, 3)
        Of the points (joints 1..J-1, then the S sensors) in the root frame,
        cm/s and cm/s^2 (eqs. 3.1/3.2, per clip).
    root_velocity : float array (N, 3)
        Root velocity in the heading frame, cm/s.
    yaw_rate : float array (N,)
        Heading angular velocity, rad/s.
    root_height : float array (N,)
        Root height above the origin along ``up``, cm.
    clip_ids : int array (N,)
    fps : float
    build_seconds : float
        Time it took to build (readings, derivatives, index).
    """

    sensors: tuple
    up: np.ndarray
    readings: np.ndarray
    poses: np.ndarray
    pose_mean: np.ndarray
    pose_basis: np.ndarray
    pose_coords: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    root_velocity: np.ndarray
    yaw_rate: np.ndarray
    root_height: np.ndarray
    clip_ids: np.ndarray
    fps: float
    build_seconds: float

    @property
    def num_frames(self) -> int:
        return int(self.readings.shape[0])

    def index(self, backend: str = "kdtree") -> KNNIndex:
        """The kNN index over :attr:`readings` (built once per backend)."""
        cache = self.__dict__.setdefault("_indexes", {})
        if backend not in cache:
            cache[backend] = KNNIndex(self.readings, backend=backend)
        return cache[backend]


_KB_CACHE: "weakref.WeakKeyDictionary[MotionDatabase, dict]" = weakref.WeakKeyDictionary()


def _sensor_key(sensors) -> tuple:
    return tuple((s.name, s.joint, tuple(np.round(s.rotation, 12)), tuple(np.round(s.offset, 12))) for s in sensors)


def _check_sensors(db_skeleton: Skeleton, sensors) -> tuple:
    if sensors is None:
        sensors = default_sensors(db_skeleton)
    sensors = tuple(sensors)
    if not sensors:
        raise ValueError("sensors: at least one sensor is needed")
    for s in sensors:
        if not isinstance(s, Sensor):
            raise ValueError(f"sensors: expected mocapkit.features.Sensor objects, got {type(s).__name__}")
        if s.joint not in db_skeleton.joint_names:
            raise ValueError(f"sensor {s.name!r} rides on joint {s.joint!r}, which the database skeleton lacks")
    return sensors


def _heading_angle(h: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Angle (F,) of rotations about ``up`` (F, 4)."""
    return 2.0 * np.arctan2(h[:, 1:] @ up, h[:, 0])


def _clip_values(m: Motion, sensors, up: np.ndarray) -> np.ndarray:
    """Per-frame knowledge-base values of one clip, as one (F, D) block (see :func:`knowledge_base`)."""
    sk = m.skeleton
    scale = unit_scale_cm(sk)
    J = sk.num_joints
    grot, gpos = m.global_transforms()
    heading, _ = _root_frame(sk, grot, gpos, up)
    hinv = R.quaternion_conjugate(heading)
    tilt = R.quaternion_multiply(hinv, m.rotations[:, 0])
    pose = R.quaternion_to_rotvec(np.concatenate([tilt[:, None], m.rotations[:, 1:]], axis=1)).reshape(len(m), 3 * J)
    sj = [sk.index(s.joint) for s in sensors]
    soff = np.stack([s.offset for s in sensors])
    spos = gpos[:, sj] + R.quaternion_rotate(grot[:, sj], soff)
    pts = np.concatenate([gpos[:, 1:], spos], axis=1) - gpos[:, :1]
    pts = R.quaternion_rotate(hinv[:, None], pts) * scale
    vel = five_point_derivative(pts, m.fps, order=1)
    acc = five_point_derivative(pts, m.fps, order=2)
    root = gpos[:, 0] * scale
    rvel = R.quaternion_rotate(hinv, five_point_derivative(root, m.fps, order=1))
    yaw = five_point_derivative(np.unwrap(_heading_angle(heading, up)), m.fps, order=1)
    height = root @ up
    readings = virtual_accelerometers(m, sensors, up_axis=up)
    F = len(m)
    return np.concatenate(
        [readings.reshape(F, -1), pose, vel.reshape(F, -1), acc.reshape(F, -1), rvel, yaw[:, None], height[:, None]],
        axis=1,
    )


def knowledge_base(db: MotionDatabase, sensors: Sequence[Sensor] | None = None) -> KnowledgeBase:
    """The knowledge base of ``db`` for ``sensors`` (default: :func:`default_sensors`), cached per (db, sensors).

    Computed clip by clip (:func:`mocapkit.reconstruct._common.per_clip`), so
    no derivative runs across a clip boundary. The kNN index is built on first
    use (:meth:`KnowledgeBase.index`) and kept with it.
    """
    import time

    if not isinstance(db, MotionDatabase):
        raise ValueError(f"db: expected a MotionDatabase, got {type(db).__name__}")
    if db.num_frames == 0:
        raise ValueError("the database is empty (0 frames); build it from at least one clip")
    sk0 = db.skeletons[0]
    sensors = _check_sensors(sk0, sensors)
    key = _sensor_key(sensors)
    per_db = _KB_CACHE.setdefault(db, {})
    if key in per_db:
        return per_db[key]
    t0 = time.perf_counter()
    up = detect_up_axis(sk0)
    S, J = len(sensors), sk0.num_joints
    M = J - 1 + S
    vals = per_clip(db, lambda m: _clip_values(m, sensors, up))
    cuts = np.cumsum([3 * S, 3 * J, 3 * M, 3 * M, 3, 1])
    rd, pose, vel, acc, rvel, yaw, height = np.split(vals, cuts, axis=1)
    N = db.num_frames
    good = np.isfinite(pose).all(axis=1)
    pmean = pose[good].mean(axis=0)
    lam, vec = np.linalg.eigh(np.cov((pose[good] - pmean).T, bias=True).reshape(pose.shape[1], pose.shape[1]))
    keep = lam > 1e-12 * max(lam.max(), 1e-300)
    pbasis = np.ascontiguousarray(vec[:, keep][:, ::-1])
    kb = KnowledgeBase(
        sensors=sensors,
        up=up,
        readings=np.ascontiguousarray(rd),
        poses=np.ascontiguousarray(pose),
        pose_mean=pmean,
        pose_basis=pbasis,
        pose_coords=np.ascontiguousarray((pose - pmean) @ pbasis),
        velocities=vel.reshape(N, M, 3).astype(np.float32),
        accelerations=acc.reshape(N, M, 3).astype(np.float32),
        root_velocity=np.ascontiguousarray(rvel),
        yaw_rate=yaw[:, 0].copy(),
        root_height=height[:, 0].copy(),
        clip_ids=np.asarray(db.clip_ids, dtype=np.int64),
        fps=db.fps,
        build_seconds=0.0,
    )
    kb.index("kdtree")
    object.__setattr__(kb, "build_seconds", time.perf_counter() - t0)
    per_db[key] = kb
    return kb


# -- forward kinematics in the root frame (numba) -------------------------------------------


@numba.njit(cache=True)
def _fk_one(pose, parents, offsets, sens_joint, sens_off, sens_rot, pts, srot, g, p):
    """Forward kinematics of one pose vector (3J,) into ``pts`` (M, 3) and ``srot`` (S, 4); ``g``, ``p`` scratch."""
    J = parents.shape[0]
    S = sens_joint.shape[0]
    for j in range(J):
        q0, q1, q2, q3 = _qexp(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2])
        par = parents[j]
        if par < 0:
            g[j, 0], g[j, 1], g[j, 2], g[j, 3] = q0, q1, q2, q3
            p[j, 0] = 0.0
            p[j, 1] = 0.0
            p[j, 2] = 0.0
        else:
            a0, a1, a2, a3 = g[par, 0], g[par, 1], g[par, 2], g[par, 3]
            g[j, 0], g[j, 1], g[j, 2], g[j, 3] = _qmul(a0, a1, a2, a3, q0, q1, q2, q3)
            ox, oy, oz = _qrot(a0, a1, a2, a3, offsets[j, 0], offsets[j, 1], offsets[j, 2])
            p[j, 0] = p[par, 0] + ox
            p[j, 1] = p[par, 1] + oy
            p[j, 2] = p[par, 2] + oz
    for j in range(1, J):
        pts[j - 1, 0] = p[j, 0]
        pts[j - 1, 1] = p[j, 1]
        pts[j - 1, 2] = p[j, 2]
    for k in range(S):
        j = sens_joint[k]
        a0, a1, a2, a3 = g[j, 0], g[j, 1], g[j, 2], g[j, 3]
        ox, oy, oz = _qrot(a0, a1, a2, a3, sens_off[k, 0], sens_off[k, 1], sens_off[k, 2])
        pts[J - 1 + k, 0] = p[j, 0] + ox
        pts[J - 1 + k, 1] = p[j, 1] + oy
        pts[J - 1 + k, 2] = p[j, 2] + oz
        srot[k, 0], srot[k, 1], srot[k, 2], srot[k, 3] = _qmul(
            a0, a1, a2, a3, sens_rot[k, 0], sens_rot[k, 1], sens_rot[k, 2], sens_rot[k, 3]
        )


@numba.njit(cache=True)
def _fk_points(poses, parents, offsets, sens_joint, sens_off, sens_rot, pts, srot):
    """Root-frame points of pose vectors (forward kinematics, root rotation = tilt, root at the origin).

    poses (B, 3J) rotation vectors; parents (J,); offsets (J, 3) cm; sensors on
    joints ``sens_joint`` (S,) at ``sens_off`` (S, 3) cm with ``sens_rot``
    (S, 4). Writes ``pts`` (B, J-1+S, 3) (joints 1..J-1, then the sensors) and
    ``srot`` (B, S, 4), the sensors' orientations in the root frame.
    """
    J = parents.shape[0]
    g = np.empty((J, 4))
    p = np.empty((J, 3))
    for b in range(poses.shape[0]):
        _fk_one(poses[b], parents, offsets, sens_joint, sens_off, sens_rot, pts[b], srot[b], g, p)
    return pts, srot


@numba.njit(cache=True)
def _kernel_energy(z, X, Z, rperp2, w, Xm, A, base, Xc, use, coef, dt, s0):
    """Eq. 3.4 with the square-root kernels (eqs. 3.7, 3.9, 3.10, 3.13) at PCA coordinates z, points X (M, 3)."""
    n, d = Z.shape
    M = X.shape[0]
    e = 0.0
    for i in range(n):
        r2 = rperp2[i]
        for k in range(d):
            t = z[k] - Z[i, k]
            r2 += t * t
        e += coef[0] * w[i] * r2 ** 0.25
    inv = 1.0 / (dt * dt)
    for i in range(n):
        if use[0]:
            r2 = 0.0
            for m in range(M):
                for c in range(3):
                    t = X[m, c] - Xm[i, m, c]
                    r2 += t * t
            e += coef[1] * w[i] * r2 ** 0.25
        if use[1]:
            r2 = 0.0
            for m in range(M):
                for c in range(3):
                    t = X[m, c] * inv + base[m, c] - A[i, m, c]
                    r2 += t * t
            e += coef[2] * dt * w[i] * r2 ** 0.25
        if use[2]:
            r2 = 0.0
            for m in range(Xc.shape[1]):
                for c in range(3):
                    t = X[s0 + m, c] - Xc[i, m, c]
                    r2 += t * t
            e += coef[3] * w[i] * r2 ** 0.25
    return e


@numba.njit(cache=True)
def _kernel_minimise(z0, mu, Bf, Z, rperp2, w, Xm, A, base, Xc, use, coef, dt, iterations, h, eps_pose, eps_pos,
                     parents, offsets, sens_joint, sens_off, sens_rot):
    """Majorise-minimise / Gauss-Newton for the kernel energy (see :func:`_minimise`); returns (z, X, E, steps)."""
    d = z0.shape[0]
    n = Z.shape[0]
    J = parents.shape[0]
    S = sens_joint.shape[0]
    M = J - 1 + S
    s0 = J - 1
    g4 = np.empty((J, 4))
    p3 = np.empty((J, 3))
    srot = np.empty((S, 4))
    P = np.empty((d + 1, M, 3))
    Pn = np.empty((d + 1, M, 3))
    z = z0.copy()
    zn = np.empty(d)
    pose = np.empty(mu.shape[0])

    def fk_all(zz, out, nb):
        for b in range(nb):
            for q in range(mu.shape[0]):
                v = mu[q]
                for k in range(d):
                    v += Bf[q, k] * (zz[k] + (h if b == k + 1 else 0.0))
                pose[q] = v
            _fk_one(pose, parents, offsets, sens_joint, sens_off, sens_rot, out[b], srot, g4, p3)

    fk_all(z, P, d + 1)
    E = _kernel_energy(z, P[0], Z, rperp2, w, Xm, A, base, Xc, use, coef, dt, s0)
    steps = 0
    inv = 1.0 / (dt * dt)
    Jx = np.empty((3 * M, d))
    Dsum = np.empty(3 * M)
    for _ in range(iterations):
        X = P[0]
        for m in range(M):
            for c in range(3):
                for k in range(d):
                    Jx[3 * m + c, k] = (P[k + 1, m, c] - X[m, c]) / h
        JtJ = np.zeros((d, d))
        JsJs = np.zeros((d, d))
        for r in range(3 * M):
            for a in range(d):
                v = Jx[r, a]
                if v != 0.0:
                    for b in range(a, d):
                        JtJ[a, b] += v * Jx[r, b]
                        if r >= 3 * s0:
                            JsJs[a, b] += v * Jx[r, b]
        for a in range(d):
            for b in range(a):
                JtJ[a, b] = JtJ[b, a]
                JsJs[a, b] = JsJs[b, a]
        H = np.zeros((d, d))
        g = np.zeros(d)
        # pose prior (eq. 3.7): residual z - Z_i plus the constant part outside the subspace
        csum = 0.0
        for i in range(n):
            r2 = rperp2[i]
            for k in range(d):
                t = z[k] - Z[i, k]
                r2 += t * t
            ci = coef[0] * w[i] * 0.25 * max(r2, eps_pose * eps_pose) ** -0.75
            csum += ci
            for k in range(d):
                g[k] += ci * (z[k] - Z[i, k])
        for k in range(d):
            H[k, k] += csum
        for term in range(3):
            if not use[term]:
                continue
            Dsum[:] = 0.0
            csum = 0.0
            for i in range(n):
                r2 = 0.0
                if term == 0:
                    for m in range(M):
                        for c in range(3):
                            t = X[m, c] - Xm[i, m, c]
                            r2 += t * t
                elif term == 1:
                    for m in range(M):
                        for c in range(3):
                            t = X[m, c] * inv + base[m, c] - A[i, m, c]
                            r2 += t * t
                else:
                    for m in range(S):
                        for c in range(3):
                            t = X[s0 + m, c] - Xc[i, m, c]
                            r2 += t * t
                nr = math.sqrt(r2)
                if term == 0:
                    ci = coef[1] * w[i] * 0.25 * max(nr, eps_pos) ** -1.5
                    for m in range(M):
                        for c in range(3):
                            Dsum[3 * m + c] += ci * (X[m, c] - Xm[i, m, c])
                elif term == 1:
                    ci = coef[2] * dt * w[i] * 0.25 * max(nr, eps_pos) ** -1.5
                    for m in range(M):
                        for c in range(3):
                            Dsum[3 * m + c] += ci * (X[m, c] * inv + base[m, c] - A[i, m, c])
                else:
                    ci = coef[3] * w[i] * 0.25 * max(nr, eps_pos) ** -1.5
                    for m in range(S):
                        for c in range(3):
                            Dsum[3 * (s0 + m) + c] += ci * (X[s0 + m, c] - Xc[i, m, c])
                csum += ci
            scale_h = csum if term != 1 else csum * inv * inv
            scale_g = 1.0 if term != 1 else inv
            for a in range(d):
                acc = 0.0
                for r in range(3 * M):
                    acc += Jx[r, a] * Dsum[r]
                g[a] += scale_g * acc
                for b in range(d):
                    H[a, b] += scale_h * (JsJs[a, b] if term == 2 else JtJ[a, b])
        tr = 0.0
        for k in range(d):
            tr += H[k, k]
        for k in range(d):
            H[k, k] += 1e-9 * (tr / d + 1.0)
        delta = -np.linalg.solve(H, g)
        t = 1.0
        accepted = False
        En = E
        for _ls in range(6):
            for k in range(d):
                zn[k] = z[k] + t * delta[k]
            fk_all(zn, Pn, 1)
            En = _kernel_energy(zn, Pn[0], Z, rperp2, w, Xm, A, base, Xc, use, coef, dt, s0)
            if En <= E:
                accepted = True
                break
            t *= 0.5
        if not accepted:
            break
        steps += 1
        step2 = 0.0
        zz = 0.0
        for k in range(d):
            step2 += (t * delta[k]) ** 2
            zz += z[k] ** 2
        z[:] = zn
        P, Pn = Pn, P
        E = En
        if math.sqrt(step2) < 1e-5 * (1.0 + math.sqrt(zz)) or E == 0.0:
            break
        fk_all(z, P, d + 1)
    return z, P[0].copy(), E, steps


class _Rig:
    """The output skeleton as the FK kernel needs it (offsets in cm)."""

    def __init__(self, skeleton: Skeleton, sensors):
        self.skeleton = skeleton
        self.scale = unit_scale_cm(skeleton)
        self.parents = np.asarray(skeleton.parents, dtype=np.int64)
        self.offsets = np.ascontiguousarray(skeleton.offsets, dtype=np.float64) * self.scale
        self.sens_joint = np.array([skeleton.index(s.joint) for s in sensors], dtype=np.int64)
        self.sens_off = np.stack([s.offset for s in sensors]).astype(np.float64) * self.scale
        self.sens_rot = np.stack([s.rotation for s in sensors]).astype(np.float64)
        self.J = skeleton.num_joints
        self.S = len(sensors)
        self.M = self.J - 1 + self.S

    def points(self, poses: np.ndarray):
        """Root-frame points (B, M, 3) cm and sensor orientations (B, S, 4) of pose vectors (B, 3J)."""
        poses = np.ascontiguousarray(poses, dtype=np.float64)
        B = poses.shape[0]
        pts = np.empty((B, self.M, 3))
        srot = np.empty((B, self.S, 4))
        return _fk_points(poses, self.parents, self.offsets, self.sens_joint, self.sens_off, self.sens_rot, pts, srot)


# -- per-frame synthesis (sec. 3.5) -----------------------------------------------------------


def default_k(num_frames: int) -> int:
    """The number of nearest neighbours per sample for a database of ``num_frames`` frames.

    The thesis uses K = 4096 on about 560,000 frames (0.7 %). On databases of
    a few ten thousand frames a fixed 4096 takes a third of the database into
    every column, and the lazy neighbourhood graph then strings together
    paths whose poses have little to do with the readings: on the HDM05
    validation actor (tr, database bd/bk/dg, 9,000 frames at 25 fps) K = 4096
    gave 25.9 cm, K = 128 16.9 cm (``benchmarks/reconstruct_accelerometers.py
    --sweep``). Hence 1 % of the frames, at least 128 and at most the
    thesis' 4096.

    >>> default_k(12_000), default_k(560_000), default_k(1_000)
    (128, 4096, 128)
    """
    return int(min(4096, max(128, round(0.01 * num_frames))))


def path_weights(costs: np.ndarray) -> np.ndarray:
    """Normalised weights of eq. 3.3, ``(max C - c_i) / sum_j (max C - c_j)``; uniform if all costs are equal."""
    c = np.asarray(costs, dtype=np.float64)
    w = c.max() - c
    total = w.sum()
    if not total > 0:
        return np.full(c.shape, 1.0 / c.size)
    return w / total


def weighted_pca(Q: np.ndarray, w: np.ndarray, variance: float = 0.99, max_components: int = 24):
    """Weighted PCA of poses ``Q`` (I, P) with weights ``w`` (I,) summing to 1 (sec. 3.5.3).

    Returns ``mean`` (P,), ``basis`` (P, d) orthonormal columns keeping
    ``variance`` of the weighted variance (at most ``max_components``),
    ``eigenvalues`` (d,) and ``coords`` (I, d) of the samples.
    """
    mu = w @ Q
    D = Q - mu
    Y = D * np.sqrt(w)[:, None]
    lam, vec = np.linalg.eigh(Y.T @ Y)  # ascending
    lam = np.maximum(lam[::-1], 0.0)
    total = lam.sum()
    if not total > 1e-24:
        return mu, np.zeros((Q.shape[1], 0)), np.zeros(0), np.zeros((Q.shape[0], 0))
    d = int(np.searchsorted(np.cumsum(lam) / total, variance - 1e-12) + 1)
    d = max(1, min(d, max_components, lam.size))
    B = np.ascontiguousarray(vec[:, ::-1][:, :d])
    return mu, B, lam[:d], D @ B


class _Problem:
    """The energy of eq. 3.4 for one frame, in PCA coordinates ``z`` (pose ``mean + basis z``).

    ``kind="kernel"``: the square-root kernel sums of eqs. 3.7, 3.9, 3.10,
    3.13; ``kind="mahalanobis"``: each term replaced by a weighted Gaussian's
    negative log-likelihood ``0.5 (r - mu)^T Sigma^-1 (r - mu)`` (sec. 3.6.2).
    A term without its history (first frames) is left out.
    """

    def __init__(self, rig, p, kind, w, mu, B, lam, Z, rperp2, Xm, A, base, Xc, dt):
        self.rig, self.kind, self.w, self.mu, self.B = rig, kind, w, mu, B
        self.Z, self.rperp2, self.Xm, self.A, self.base, self.Xc, self.dt = Z, rperp2, Xm, A, base, Xc, dt
        self.c_pose = p["w_prior"] * p["w_pose"]
        self.c_motion = p["w_prior"] * p["w_motion"]
        self.c_smooth = p["w_prior"] * p["w_smooth"]
        self.c_contr = p["w_contr"]
        self.sens = slice(rig.J - 1, rig.M)
        if kind == "mahalanobis":
            self.lam = np.maximum(lam, 1e-8 + 1e-6 * (lam.max() if lam.size else 0.0))
            self.gm = [None, None, None]
            for t, X in enumerate((Xm, A, Xc)):
                if X is not None:
                    self.gm[t] = _gaussian(X.reshape(X.shape[0], -1), w)

    def pose(self, z):
        return self.mu + self.B @ z

    def fk(self, zs):
        """Points (B, M, 3) of PCA coordinates ``zs`` (B, d)."""
        return self.rig.points(self.mu + zs @ self.B.T)[0]

    def energy(self, z, X) -> float:
        w, e = self.w, 0.0
        if self.kind == "kernel":
            e += self.c_pose * float(w @ (np.sum((self.Z - z) ** 2, axis=1) + self.rperp2) ** 0.25)
            if self.Xm is not None:
                e += self.c_motion * float(w @ np.sqrt(np.linalg.norm((X - self.Xm).reshape(len(w), -1), axis=1)))
            if self.A is not None:
                a = X / self.dt**2 + self.base
                e += self.c_smooth * self.dt * float(w @ np.sqrt(np.linalg.norm((a - self.A).reshape(len(w), -1), axis=1)))
            if self.Xc is not None:
                e += self.c_contr * float(w @ np.sqrt(np.linalg.norm((X[self.sens] - self.Xc).reshape(len(w), -1), axis=1)))
            return e
        e += self.c_pose * 0.5 * float(np.sum(z * z / self.lam))
        for c, g, r in self._maha_residuals(X):
            e += c * 0.5 * float(r @ r)
        return e

    def _maha_residuals(self, X):
        out = []
        if self.gm[0] is not None:
            m, W = self.gm[0]
            out.append((self.c_motion, W, W @ (X.ravel() - m)))
        if self.gm[1] is not None:
            m, W = self.gm[1]
            out.append((self.c_smooth, W, W @ ((X / self.dt**2 + self.base).ravel() - m)))
        if self.gm[2] is not None:
            m, W = self.gm[2]
            out.append((self.c_contr, W, W @ (X[self.sens].ravel() - m)))
        return out

    def normal_equations(self, z, X, Jx):
        """Gauss-Newton system ``(H, g)`` of the quadratic majoriser at ``z`` (Jx (3M, d) = dX/dz)."""
        d = z.size
        w = self.w
        H = np.zeros((d, d))
        g = np.zeros(d)
        n = len(w)
        Js = Jx.reshape(self.rig.M, 3, d)[self.sens].reshape(-1, d)
        if self.kind == "kernel":
            Dz = z - self.Z
            r2 = np.sum(Dz * Dz, axis=1) + self.rperp2
            c = self.c_pose * w * 0.25 * np.maximum(r2, _EPS_POSE**2) ** -0.75
            H += c.sum() * np.eye(d)
            g += c @ Dz
            terms = []
            if self.Xm is not None:
                terms.append((self.c_motion, (X - self.Xm).reshape(n, -1), Jx))
            if self.A is not None:
                terms.append((self.c_smooth * self.dt, (X / self.dt**2 + self.base - self.A).reshape(n, -1), Jx / self.dt**2))
            if self.Xc is not None:
                terms.append((self.c_contr, (X[self.sens] - self.Xc).reshape(n, -1), Js))
            for coef, D, Jt in terms:
                nr = np.linalg.norm(D, axis=1)
                c = coef * w * 0.25 * np.maximum(nr, _EPS_POS) ** -1.5
                H += c.sum() * (Jt.T @ Jt)
                g += Jt.T @ (c @ D)
            return H, g
        H += self.c_pose * np.diag(1.0 / self.lam)
        g += self.c_pose * z / self.lam
        jac = [Jx, Jx / self.dt**2, Js]
        for (c, W, r), Jt in zip(self._maha_residuals(X), [jac[t] for t in range(3) if self.gm[t] is not None]):
            Jw = W @ Jt
            H += c * (Jw.T @ Jw)
            g += c * (Jw.T @ r)
        return H, g


def _gaussian(X: np.ndarray, w: np.ndarray):
    """Weighted mean (D,) and whitening matrix W (D, D), ``W^T W = (Sigma + ridge)^-1``, of samples X (I, D)."""
    m = w @ X
    D = (X - m) * np.sqrt(w)[:, None]
    C = D.T @ D
    ridge = 1e-3 * np.trace(C) / C.shape[0] + 1e-6
    L = np.linalg.cholesky(C + ridge * np.eye(C.shape[0]))
    return m, np.linalg.inv(L)


def _minimise(prob: _Problem, z0: np.ndarray, iterations: int):
    """Majorise-minimise / Gauss-Newton with a halving line search; returns ``(z, X, energy, steps)``."""
    if z0.size > 0 and prob.kind == "kernel":
        rig = prob.rig
        e0 = np.empty((1, 1, 3))
        use = np.array([prob.Xm is not None, prob.A is not None, prob.Xc is not None])
        coef = np.array([prob.c_pose, prob.c_motion, prob.c_smooth, prob.c_contr])
        return _kernel_minimise(
            np.ascontiguousarray(z0, dtype=np.float64), prob.mu, np.ascontiguousarray(prob.B), np.ascontiguousarray(prob.Z),
            prob.rperp2, prob.w, e0 if prob.Xm is None else prob.Xm, e0 if prob.A is None else prob.A,
            np.zeros((1, 3)) if prob.base is None else prob.base, e0 if prob.Xc is None else prob.Xc, use, coef, prob.dt,
            int(iterations), _FD_STEP, _EPS_POSE, _EPS_POS, rig.parents, rig.offsets, rig.sens_joint, rig.sens_off, rig.sens_rot,
        )
    return _minimise_numpy(prob, z0, iterations)


def _minimise_numpy(prob: _Problem, z0: np.ndarray, iterations: int):
    """The same iteration in numpy for any prior kind (the reference twin of :func:`_kernel_minimise`)."""
    d = z0.size
    z = z0.copy()
    h = _FD_STEP
    steps = 0
    if d == 0:
        X = prob.fk(z[None])[0]
        return z, X, prob.energy(z, X), 0
    batch = np.vstack([z, z + h * np.eye(d)])
    P = prob.fk(batch)
    X = P[0]
    E = prob.energy(z, X)
    for _ in range(iterations):
        Jx = ((P[1:] - X) / h).reshape(d, -1).T  # (3M, d)
        H, g = prob.normal_equations(z, X, Jx)
        H[np.diag_indices(d)] += 1e-9 * (np.trace(H) / d + 1.0)
        try:
            delta = -np.linalg.solve(H, g)
        except np.linalg.LinAlgError:
            break
        t = 1.0
        accepted = False
        for _ in range(6):
            zn = z + t * delta
            batch = np.vstack([zn, zn + h * np.eye(d)])
            Pn = prob.fk(batch)
            En = prob.energy(zn, Pn[0])
            if En <= E:
                accepted = True
                break
            t *= 0.5
        if not accepted:
            break
        steps += 1
        small = np.linalg.norm(t * delta) < 1e-6 * (1.0 + np.linalg.norm(z))
        z, P, X, E = zn, Pn, Pn[0], En
        if small or E == 0:
            break
    return z, X, E, steps


class Pose(NamedTuple):
    """One synthesised frame: local joint rotations (J, 4), w first, and the root position (3,) in skeleton units.

    Arrays are read-only. ``Motion`` frames of a reconstruction are stacks of these.
    """

    rotations: np.ndarray
    root_position: np.ndarray


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


def _check_params(params: dict) -> dict:
    unknown = set(params) - set(DEFAULTS)
    if unknown:
        raise ValueError(f"unknown parameter(s) {', '.join(sorted(unknown))}; known: {', '.join(DEFAULTS)}")
    p = {**DEFAULTS, **params}
    for name in ("k", "n_paths", "window", "max_components", "iterations"):
        v = p[name]
        if name in ("k", "n_paths") and v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < (0 if name == "iterations" else 1):
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
        p[name] = int(v)
    for name in ("w_contr", "w_prior", "w_pose", "w_motion", "w_smooth", "penalty_factor", "eps", "gravity"):
        v = float(p[name])
        if not np.isfinite(v) or v < 0:
            raise ValueError(f"{name} must be a finite number >= 0, got {p[name]!r}")
        p[name] = v
    if not 0 < float(p["variance"]) <= 1:
        raise ValueError(f"variance must be in (0, 1], got {p['variance']!r}")
    if p["prior"] not in ("kernel", "mahalanobis"):
        raise ValueError(f"prior must be 'kernel' or 'mahalanobis', got {p['prior']!r}")
    return p


def _check_fps(fps, what="fps") -> float:
    f = float(fps)
    if not np.isfinite(f) or f <= 0:
        raise ValueError(f"{what} must be a positive number, got {fps!r}")
    return f


class AccelerometerReconstructor:
    """Online reconstruction from a stream of accelerometer readings (Tautges 2012, secs. 3.4-3.6).

    Parameters
    ----------
    db : MotionDatabase
        The knowledge base's motions (:func:`knowledge_base` is cached per db and sensors).
    fps : float, optional
        Rate of the readings; the database's when None. Another rate is
        interpolated onto the database's time grid (see the module notes).
    sensors : sequence of Sensor, optional
        :func:`~mocapkit.features.default_sensors` of the database skeleton when None.
    skeleton : Skeleton, optional
        The performer's skeleton (same topology as the database's) to pose the output on.
    **params
        Overrides of :data:`DEFAULTS` (``k``, ``n_paths``, the weights ``w_*``, ``prior``, ...).

    :meth:`push` takes one sample ``(S, 3)`` (m/s^2, sensor frames) and
    returns a :class:`Pose`; :meth:`reset` starts a new stream.
    """

    def __init__(self, db: MotionDatabase, fps: float | None = None, sensors=None, *, skeleton: Skeleton | None = None, **params):
        self.params = _check_params(params)
        self.kb = knowledge_base(db, sensors)
        self.sensors = self.kb.sensors
        self.db_fps = float(db.fps)
        self.fps = self.db_fps if fps is None else _check_fps(fps)
        self.skeleton = output_skeleton(db, skeleton)
        self.rig = _Rig(self.skeleton, self.sensors)
        self.index = self.kb.index(self.params["backend"])
        k = self.params["k"]
        self.k = min(default_k(self.kb.num_frames) if k is None else k, self.kb.num_frames)
        n_paths = self.params["n_paths"]
        self.n_paths = max(1, self.k // 16) if n_paths is None else min(n_paths, self.k)
        self.olng = OnlineLazyNeighborhoodGraph(
            self.kb.clip_ids, window=self.params["window"], extra_steps=self.params["extra_steps"],
            penalty_factor=self.params["penalty_factor"],
        )
        self._mean_pose = self.kb.poses.mean(axis=0)
        self.reset()

    # -- state ------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget the stream: the next :meth:`push` is the first sample."""
        self.olng.reset()
        self._n_in = 0  # input samples pushed
        self._n_grid = 0  # database-rate steps taken
        self._last_in = None
        self._p = None  # pose vector of the last synthesised frame
        self._x = None  # its root-frame points (M, 3)
        self._x2 = None  # the frame before's
        self._srot = None  # its sensor orientations (S, 4)
        self._heading = 0.0
        self._ground = np.zeros(3)  # root position on the ground plane, cm
        self._pose = self._make_pose(self._mean_pose, float(np.mean(self.kb.root_height)))
        self.last_info: dict = {}

    def __repr__(self) -> str:
        return (f"AccelerometerReconstructor({self.kb.num_frames} frames @ {self.db_fps:g} fps, input {self.fps:g} fps, "
                f"K={self.k}, I={self.n_paths}, prior={self.params['prior']!r}, pushed={self._n_in})")

    @property
    def pose(self) -> Pose:
        """The pose returned by the last :meth:`push`."""
        return self._pose

    def _make_pose(self, p: np.ndarray, height: float) -> Pose:
        J = self.rig.J
        q = R.rotvec_to_quaternion(p.reshape(J, 3))
        up = self.kb.up
        h = R.quaternion_from_axis_angle(up, self._heading)
        q[0] = R.quaternion_multiply(h, q[0])
        root = (self._ground + height * up) / self.rig.scale
        return Pose(_readonly(q), _readonly(root))

    # -- input ------------------------------------------------------------------------------

    def push(self, reading) -> Pose:
        """Add one sample (S, 3) in m/s^2 (sensor frames) and return the pose at its time.

        A sample with a non-finite value holds the previous pose.
        """
        a = np.asarray(reading, dtype=np.float64)
        S = len(self.sensors)
        if a.shape != (S, 3):
            raise ValueError(f"reading: expected shape ({S}, 3) for {S} sensors, got {a.shape}")
        n = self._n_in
        if self.fps == self.db_fps:
            self._step(a)
        else:
            # database-grid times k / db_fps in (t_{n-1}, t_n], linearly interpolated
            t_n = n / self.fps
            while self._n_grid / self.db_fps <= t_n + 1e-9:
                tau = self._n_grid / self.db_fps
                if n == 0 or self._last_in is None:
                    v = a
                else:
                    t_prev = (n - 1) / self.fps
                    f = min(max((tau - t_prev) * self.fps, 0.0), 1.0)
                    v = a if f >= 1.0 else self._last_in * (1.0 - f) + a * f
                self._step(v)
            self._last_in = a.copy()
        self._n_in += 1
        return self._pose

    def _step(self, a: np.ndarray) -> None:
        """One database-rate frame of synthesis from the sample ``a`` (S, 3)."""
        self._n_grid += 1
        if not np.all(np.isfinite(a)):
            self.last_info = {"held": True}
            return
        p, kb = self.params, self.kb
        dt = 1.0 / self.db_fps
        dist, idx = self.index.query(a.reshape(1, -1), k=self.k, eps=p["eps"])
        costs = self.olng.push(idx[0], dist[0])
        good = np.flatnonzero(np.isfinite(costs))
        if good.size == 0:
            self.last_info = {"held": True}
            return
        n = min(self.n_paths, good.size)
        sel = good if n == good.size else good[np.argpartition(costs[good], n - 1)[:n]]
        sel = sel[np.lexsort((idx[0, sel], costs[sel]))]
        frames = idx[0, sel]
        w = path_weights(costs[sel])
        Q = kb.pose_coords[frames]
        mu, B, lam, Z = weighted_pca(Q, w, p["variance"], p["max_components"])
        rperp2 = np.maximum(np.sum((Q - mu) ** 2, axis=1) - np.sum(Z * Z, axis=1), 0.0)
        mu = kb.pose_mean + kb.pose_basis @ mu  # back to full pose vectors
        B = kb.pose_basis @ B
        V = kb.velocities[frames].astype(np.float64)
        A = kb.accelerations[frames].astype(np.float64)
        Xm = Xc = As = base = None
        if self._x is not None:
            Xm = self._x + V * dt + 0.5 * A * dt * dt
            # eq. 3.12: the reading turned into the root frame by the previous pose's sensor frames, gravity removed
            f = R.quaternion_rotate(self._srot, a)
            alpha = (f - p["gravity"] * kb.up) * 100.0  # cm/s^2
            sens = slice(self.rig.J - 1, self.rig.M)
            Xc = self._x[sens] + V[:, sens] * dt + 0.5 * alpha * dt * dt
            if self._x2 is not None:
                As = A
                base = (-2.0 * self._x + self._x2) / dt**2
        prob = _Problem(self.rig, p, p["prior"], w, mu, B, lam, Z, rperp2, Xm, As, base, Xc, dt)
        z0 = np.zeros(B.shape[1]) if self._p is None else (self._p - mu) @ B
        z, X, E, steps = _minimise(prob, z0, p["iterations"])
        pose = prob.pose(z)
        # sec. 3.6.4: the weighted mean root motion of Q^t
        up = kb.up
        v = w @ kb.root_velocity[frames]
        v = v - (v @ up) * up
        self._ground = self._ground + R.quaternion_rotate(R.quaternion_from_axis_angle(up, self._heading), v) * dt
        self._heading += float(w @ kb.yaw_rate[frames]) * dt
        height = float(w @ kb.root_height[frames])
        srot = self.rig.points(pose[None])[1][0]
        self._x2, self._x, self._srot, self._p = self._x, X, srot, pose
        self._pose = self._make_pose(pose, height)
        self.last_info = {"held": False, "energy": E, "steps": steps, "components": B.shape[1], "paths": n,
                          "best_cost": float(costs[sel[0]]), "frames": frames, "weights": w, "mean_pose": mu}


# -- offline --------------------------------------------------------------------------------


def _check_readings(readings, sensors) -> np.ndarray:
    a = np.asarray(readings, dtype=np.float64)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"readings: expected shape (F, S, 3), got {a.shape}")
    if a.shape[1] != len(sensors):
        raise ValueError(f"readings have {a.shape[1]} sensors but {len(sensors)} sensors were given")
    return a


def _motion_of(poses: list[Pose], skeleton: Skeleton, fps: float, name: str) -> Motion:
    J = skeleton.num_joints
    if not poses:
        return Motion(skeleton, np.zeros((0, J, 4)), np.zeros((0, 3)), fps, name)
    return Motion(skeleton, np.stack([p.rotations for p in poses]), np.stack([p.root_position for p in poses]), fps, name)


def reconstruct(readings, db: MotionDatabase, fps: float, sensors=None, *, skeleton: Skeleton | None = None,
                progress: bool = False, **params) -> Motion:
    """Reconstruct a motion from accelerometer readings (Tautges 2012, ch. 3): :meth:`AccelerometerReconstructor.push` per sample.

    Parameters
    ----------
    readings : float array (F, S, 3)
        m/s^2 in each sensor's frame, as :func:`~mocapkit.features.virtual_accelerometers` gives them.
    db : MotionDatabase
    fps : float
        Rate of the readings; the output has one frame per sample at this rate.
    sensors : sequence of Sensor (S,), optional
        :func:`~mocapkit.features.default_sensors` of the database skeleton when None.
    skeleton : Skeleton, optional
        Performer's skeleton for the output (same topology as the database's).
    progress : bool
        Show a tqdm bar.
    **params
        Overrides of :data:`DEFAULTS`.

    Returns
    -------
    Motion (F frames at ``fps``) on ``skeleton`` or the database's first skeleton.
    """
    fps = _check_fps(fps)
    rec = AccelerometerReconstructor(db, fps, sensors, skeleton=skeleton, **params)
    a = _check_readings(readings, rec.sensors)
    poses = [rec.push(r) for r in tqdm(a, desc="frames", disable=not progress, leave=False)]
    return _motion_of(poses, rec.skeleton, fps, "reconstruction")


def reconstruct_mahalanobis(readings, db: MotionDatabase, fps: float, sensors=None, *, skeleton=None,
                            progress: bool = False, **params) -> Motion:
    """Baseline of sec. 3.6.2: every prior and the control term as a weighted Gaussian (Mahalanobis), not kernels.

    :func:`reconstruct` with ``prior="mahalanobis"``: the pose prior is the
    Gaussian of the PCA space (``0.5 sum z_k^2 / lambda_k``), the motion,
    smoothness and control terms Gaussians fitted (weighted, ridge-regularised)
    to the same samples as the kernels use.
    """
    return reconstruct(readings, db, fps, sensors, skeleton=skeleton, progress=progress, **{**params, "prior": "mahalanobis"})


def _grid_map(F: int, fps: float, db_fps: float):
    """Database-grid readings times (G,) and, per input sample, the grid step it holds (F,), as the stream does."""
    if F == 0:
        return np.zeros(0), np.zeros(0, dtype=np.int64)
    t_last = (F - 1) / fps
    G = int(np.floor(t_last * db_fps + 1e-9 * db_fps)) + 1
    tau = np.arange(G) / db_fps
    held = np.floor((np.arange(F) / fps + 1e-9) * db_fps).astype(np.int64)
    return tau, np.minimum(held, G - 1)


def reconstruct_nearest_neighbor(readings, db: MotionDatabase, fps: float, sensors=None, *, skeleton=None) -> Motion:
    """Baseline: each sample's single nearest database reading, its pose and root motion (no graph, no priors).

    The same knowledge base, rate handling and root integration as
    :func:`reconstruct`; a non-finite sample holds the previous pose.
    """
    fps = _check_fps(fps)
    kb = knowledge_base(db, sensors)
    a = _check_readings(readings, kb.sensors)
    sk = output_skeleton(db, skeleton)
    F = a.shape[0]
    db_fps = float(db.fps)
    if fps == db_fps:
        g, held = a, np.arange(F)
    else:
        tau, held = _grid_map(F, fps, db_fps)
        t = np.arange(F) / fps
        flat = a.reshape(F, -1)
        g = np.stack([np.interp(tau, t, flat[:, c]) for c in range(flat.shape[1])], axis=1).reshape(len(tau), -1, 3)
    _, idx = kb.index("kdtree").query(g.reshape(len(g), -1), k=1)
    idx = idx[:, 0]
    J, up, dt = sk.num_joints, kb.up, 1.0 / db_fps
    scale = unit_scale_cm(sk)
    rot = np.empty((len(g), J, 4))
    root = np.empty((len(g), 3))
    p = kb.poses.mean(axis=0)
    ground, heading, height = np.zeros(3), 0.0, float(np.mean(kb.root_height))
    for k, i in enumerate(idx):
        if i >= 0:
            p = kb.poses[i]
            v = kb.root_velocity[i] - (kb.root_velocity[i] @ up) * up
            ground = ground + R.quaternion_rotate(R.quaternion_from_axis_angle(up, heading), v) * dt
            heading += float(kb.yaw_rate[i]) * dt
            height = float(kb.root_height[i])
        q = R.rotvec_to_quaternion(p.reshape(J, 3))
        q[0] = R.quaternion_multiply(R.quaternion_from_axis_angle(up, heading), q[0])
        rot[k], root[k] = q, (ground + height * up) / scale
    return Motion(sk, rot[held], root[held], fps, "nearest neighbour")


# -- CSV recordings ---------------------------------------------------------------------------


def _parse_cell(s: str) -> float:
    s = s.strip()
    if s == "":
        return math.nan
    return float(s)


def read_readings_csv(path, fps: float | None = None):
    """Read a recording (format in the module docstring).

    Parameters
    ----------
    path : str or Path
    fps : float, optional
        Resample to this rate. When None, uniform time stamps are kept as
        they are and irregular ones are resampled to the median interval.

    Returns
    -------
    timestamps : float array (F,), seconds, uniform
    readings : float array (F, S, 3), m/s^2
    sensor_names : list of str (S,)

    Raises
    ------
    MocapFormatError
        ``"PATH:LINE: reason"`` for a bad header, a bad number, a wrong
        number of values, non-increasing or non-finite time.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as e:
        raise MocapFormatError(path, f"cannot read the file: {e}") from None
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise MocapFormatError(path, "empty file; expected a header 'time,<sensor>.x,<sensor>.y,<sensor>.z,...'", 1)
    head = [h.strip() for h in lines[0].split(",")]
    if head[0].lower() != "time":
        raise MocapFormatError(path, f"the first column must be 'time', got {head[0]!r}", 1)
    cols = head[1:]
    if not cols or len(cols) % 3:
        raise MocapFormatError(path, f"expected 3 columns <sensor>.x,<sensor>.y,<sensor>.z per sensor after 'time', got {len(cols)}", 1)
    names = []
    for s in range(len(cols) // 3):
        trio = cols[3 * s:3 * s + 3]
        base = trio[0].rsplit(".", 1)[0] if "." in trio[0] else None
        if base is None or trio != [f"{base}.x", f"{base}.y", f"{base}.z"] or not base:
            raise MocapFormatError(path, f"columns {3 * s + 2}-{3 * s + 4} must be <sensor>.x,<sensor>.y,<sensor>.z, got {','.join(trio)}", 1)
        if base in names:
            raise MocapFormatError(path, f"sensor {base!r} appears twice in the header", 1)
        names.append(base)
    ncol = 1 + len(cols)
    rows = []
    lineno = []
    for ln, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = line.split(",")
        if len(cells) != ncol:
            raise MocapFormatError(path, f"expected {ncol} values, got {len(cells)}", ln)
        try:
            vals = [_parse_cell(c) for c in cells]
        except ValueError:
            bad = next(c for c in cells if not _is_number(c))
            raise MocapFormatError(path, f"not a number: {bad.strip()!r}", ln) from None
        if not np.isfinite(vals[0]):
            raise MocapFormatError(path, "the time must be a finite number", ln)
        if rows and vals[0] <= rows[-1][0]:
            raise MocapFormatError(path, f"time {vals[0]:g} s does not increase (previous {rows[-1][0]:g} s)", ln)
        rows.append(vals)
        lineno.append(ln)
    if not rows:
        raise MocapFormatError(path, "no data rows after the header")
    data = np.array(rows, dtype=np.float64)
    t = data[:, 0]
    a = data[:, 1:].reshape(len(t), len(names), 3)
    dt = np.diff(t)
    if fps is None:
        if dt.size == 0:
            return t, a, names
        step = float(np.median(dt))
        if np.all(np.abs(dt - step) <= 1e-3 * step + 2e-6):
            return t, a, names
        fps = 1.0 / step
    fps = _check_fps(fps)
    G = int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1
    tg = t[0] + np.arange(G) / fps
    flat = a.reshape(len(t), -1)
    out = np.stack([np.interp(tg, t, flat[:, c]) for c in range(flat.shape[1])], axis=1)
    return tg, out.reshape(G, len(names), 3), names


def _is_number(s: str) -> bool:
    try:
        _parse_cell(s)
        return True
    except ValueError:
        return False


def write_readings_csv(path, timestamps, readings, sensor_names=None, digits: int = 9) -> Path:
    """Write a recording (format in the module docstring), atomically (temp file + rename).

    Time is written with 6 decimals (microseconds), readings with ``digits``
    significant digits; NaN as ``nan``. Returns the path.
    """
    from ..io import atomic_write

    t = np.asarray(timestamps, dtype=np.float64)
    a = np.asarray(readings, dtype=np.float64)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"readings: expected shape (F, S, 3), got {a.shape}")
    if t.shape != (a.shape[0],):
        raise ValueError(f"timestamps: expected shape ({a.shape[0]},), got {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError("timestamps must be finite and strictly increasing")
    S = a.shape[1]
    if sensor_names is None:
        sensor_names = [s for s in ("left_wrist", "right_wrist", "left_ankle", "right_ankle")][:S]
        if len(sensor_names) != S:
            sensor_names = [f"sensor{i}" for i in range(S)]
    names = [str(n) for n in sensor_names]
    if len(names) != S:
        raise ValueError(f"sensor_names: {len(names)} names for {S} sensors")
    for n in names:
        if not n or "," in n or "\n" in n:
            raise ValueError(f"sensor name {n!r} cannot be written in a CSV header")
    path = Path(path)
    header = "time," + ",".join(f"{n}.{c}" for n in names for c in "xyz")
    fmt = f"{{:.{int(digits)}g}}"
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(header + "\n")
        flat = a.reshape(len(t), -1)
        for ti, row in zip(t, flat):
            fh.write(f"{ti:.6f}," + ",".join(fmt.format(v) for v in row) + "\n")
    return path
