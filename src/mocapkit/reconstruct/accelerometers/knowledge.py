"""The knowledge base of the accelerometer reconstruction (Tautges 2012, sec. 3.3).

Every database clip gets simulated readings of the same sensors
(:func:`~mocapkit.features.virtual_accelerometers`, m/s^2, sensor frames),
indexed for kNN search (:class:`~mocapkit.search.knn.KNNIndex`, 3S-D), and
per frame the pose vector (the root's tilt and every joint's local rotation
as rotation vectors, radians), the velocities and accelerations of all joints
and sensors in the root frame (five-point stencils, eqs. 3.1/3.2, cm/s and
cm/s^2) and the root motion (sec. 3.6.4). It is computed clip by clip, so no
derivative runs across a clip boundary, and cached per (database, sensors).

The *root frame*: root at the origin, heading (rotation about the vertical)
removed, the root's tilt kept (:func:`mocapkit.features.root_frame`);
lengths in centimetres. Departure from the thesis: the knowledge base keeps
each clip's own skeleton (the thesis averages bone lengths).
"""

from __future__ import annotations

import time
import weakref
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ... import rotations as R
from ...database import MotionDatabase
from ...features import Sensor, default_sensors, detect_up_axis, five_point_derivative, root_frame, virtual_accelerometers
from ...motion import Motion, Skeleton, unit_scale_cm
from ...search.knn import KNNIndex
from .._common import per_clip

__all__ = ["KnowledgeBase", "knowledge_base", "clear_cache", "clip_values", "check_sensors"]


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


def clear_cache(db: MotionDatabase | None = None) -> None:
    """Forget the cached knowledge bases of ``db`` (of every database when None): the next call builds them again."""
    if db is None:
        _KB_CACHE.clear()
    else:
        _KB_CACHE.pop(db, None)


def _sensor_key(sensors) -> tuple:
    return tuple((s.name, s.joint, tuple(np.round(s.rotation, 12)), tuple(np.round(s.offset, 12))) for s in sensors)


def check_sensors(db_skeleton: Skeleton, sensors) -> tuple:
    """``sensors`` as a tuple of :class:`~mocapkit.features.Sensor` on joints of ``db_skeleton`` (default sensors when None).

    Raises ValueError naming the sensor and what is wrong with it.
    """
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


def clip_values(m: Motion, sensors, up: np.ndarray) -> np.ndarray:
    """Per-frame knowledge-base values of one clip ``m`` as one (F, D) block, the columns in this order.

    Readings (3S, m/s^2, sensor frames), pose vector (3J, radians: root tilt,
    then joints 1..J-1 as rotation vectors), velocities and accelerations of
    joints 1..J-1 and the sensors in the root frame (3M each, cm/s and
    cm/s^2, M = J - 1 + S), root velocity in the heading frame (3, cm/s),
    heading rate (1, rad/s), root height along ``up`` (1, cm); see
    :func:`knowledge_base`.
    """
    sk = m.skeleton
    scale = unit_scale_cm(sk)
    J = sk.num_joints
    grot, gpos = m.global_transforms()
    heading, _ = root_frame(m, up_axis=up)
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

    Computed clip by clip (:func:`~mocapkit.reconstruct._common.per_clip`), so
    no derivative runs across a clip boundary. The kNN index is built on first
    use (:meth:`KnowledgeBase.index`) and kept with it.
    """
    if not isinstance(db, MotionDatabase):
        raise ValueError(f"db: expected a MotionDatabase, got {type(db).__name__}")
    if db.num_frames == 0:
        raise ValueError("the database is empty (0 frames); build it from at least one clip")
    sk0 = db.skeletons[0]
    sensors = check_sensors(sk0, sensors)
    key = _sensor_key(sensors)
    per_db = _KB_CACHE.setdefault(db, {})
    if key in per_db:
        return per_db[key]
    t0 = time.perf_counter()
    up = detect_up_axis(sk0)
    S, J = len(sensors), sk0.num_joints
    M = J - 1 + S
    vals = per_clip(db, lambda m: clip_values(m, sensors, up))
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
