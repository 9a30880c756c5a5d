"""The knowledge base of the accelerometer reconstruction (Tautges 2012, sec. 3.3).

Every database clip gets simulated readings of the same sensors
(:func:`~mocapkit.features.virtual_accelerometers`, m/s^2, sensor frames),
indexed for kNN search (:class:`~mocapkit.search.knn.KNNIndex`, 3S-D), and
per frame the pose vector (the root's tilt and every joint's local rotation
as rotation vectors, radians), the velocities and accelerations of all joints
and sensors in the root frame (five-point stencils, eqs. 3.1/3.2, cm/s and
cm/s^2) and the root motion (sec. 3.6.4). It is computed clip by clip, so no
derivative runs across a clip boundary, and cached per (database, sensors).

The *root frame*: pelvis at the origin, heading (rotation about the vertical)
removed, the pelvis's tilt kept (:func:`mocapkit.features.root_frame`);
lengths in centimetres. Everything is computed on the *body*
(:func:`~mocapkit.reconstruct._common.body_motion`): the pelvis, found by its
role (:func:`mocapkit.rigs.pelvis_index`), and the joints below it, so a game
rig whose root stays on the floor (Bandai Namco) is handled like an Acclaim
skeleton. The vertical axis is found from the database's frames
(:func:`mocapkit.features.find_up_axis`), not from the rest pose.

A knowledge base of a large database (the Bandai Namco takes: about 360,000
frames) is built once, in parallel over local processes when the database
was opened from disk (:mod:`mocapkit.parallel`), and saved
(:func:`save_knowledge_base`) as ``.npy`` arrays that
:func:`open_knowledge_base` memory-maps; the kd-tree over the readings is
rebuilt on first use. ``knowledge_base(db, cache_dir=...)`` does both, and
reuses a saved knowledge base only when it was built from the same content
(the database's :attr:`~mocapkit.database.MotionDatabase.digest`, read from
``database.json`` for a saved database, so the check costs no array read).
Saving loses nothing: a folder that is not a knowledge base is refused
before any work (:func:`check_knowledge_base_output`), and the write goes
through a hidden folder renamed into place
(:func:`mocapkit.database_folder.publish_folder`), as a database's does.

Departure from the thesis: the knowledge base keeps each clip's own skeleton
(the thesis averages bone lengths).
"""

from __future__ import annotations

import json
import os
import time
import weakref
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Sequence

import numpy as np

from ... import rotations as R
from ...database import MotionDatabase
from ...database_folder import recover_leftovers, write_staged
from ...errors import MocapFormatError
from ...features import Sensor, default_sensors, find_up_axis, five_point_derivative, root_frame, virtual_accelerometers
from ...io.outputs import KNOWLEDGE_DESCRIPTION, KNOWLEDGE_FORMAT, resolved
from ...motion import Motion, Skeleton, unit_scale_cm
from ...parallel import map_ordered
from ...search.knn import KNNIndex
from .._common import body_motion, body_skeleton, database_up

__all__ = ["KnowledgeBase", "knowledge_base", "clear_cache", "clip_values", "check_sensors", "database_up", "stacked_readings", "clip_starts",
           "save_knowledge_base", "open_knowledge_base", "check_knowledge_base_output"]


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
        Pose vectors of the body (J joints, pelvis first): pelvis tilt (heading
        removed) and the local rotations of body joints 1..J-1 as rotation
        vectors, radians.
    pose_mean : float array (3J,), pose_basis : float array (3J, P)
        The directions in which the database's pose vectors vary at all
        (global PCA, variance above 1e-12 of the largest), orthonormal.
    pose_coords : float array (N, P)
        ``(poses - pose_mean) @ pose_basis``: the pose vectors without their
        constant directions (joints without degrees of freedom), for a
        cheaper per-frame PCA.
    velocities, accelerations : float32 arrays (N, M, 3)
        Of the points (body joints 1..J-1, then the S sensors) in the root frame,
        cm/s and cm/s^2 (eqs. 3.1/3.2, per clip).
    root_velocity : float array (N, 3)
        Pelvis velocity in the heading frame, cm/s.
    yaw_rate : float array (N,)
        Heading angular velocity, rad/s.
    root_height : float array (N,)
        Pelvis height above the origin along ``up``, cm.
    clip_ids : int array (N,)
    fps : float
    build_seconds : float
        Time it took to build (readings, derivatives, index).
    path : Path or None
        The folder it was opened from (:func:`open_knowledge_base`); its arrays are then memory-mapped.
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
    path: Path | None = None

    @property
    def num_frames(self) -> int:
        return int(self.readings.shape[0])

    @property
    def reading_scale(self) -> np.ndarray:
        """Per-column weights (3S,) of the readings, ``1 / std`` over the knowledge base (s^2/m), computed once.

        Multiplying readings by it standardises every sensor axis: raw m/s^2
        let the axes that swing most (the wrists' dynamic accelerations,
        twice the ankles' spread) decide the neighbours alone, while the
        quieter axes (each segment's tilt against gravity) say as much
        about the pose (:func:`~.synthesis.DEFAULTS` ``standardise``).
        """
        scale = self.__dict__.get("_reading_scale")
        if scale is None:
            rd = np.asarray(self.readings, dtype=np.float64)
            sd = rd.std(axis=0)
            scale = 1.0 / np.maximum(sd, 1e-6 * max(float(sd.max()), 1e-300) + 1e-12)
            self.__dict__["_reading_scale"] = scale
        return scale

    def index(self, backend: str = "kdtree", lags: Sequence[int] = (0,), standardise: bool = False) -> KNNIndex:
        """The kNN index over the readings stacked at ``lags`` frames back (:func:`stacked_readings`), built once per (backend, lags, standardise).

        ``standardise``: the readings times :attr:`reading_scale` (every
        axis at unit spread); a query must be scaled the same way.
        """
        cache = self.__dict__.setdefault("_indexes", {})
        key = (backend, tuple(int(g) for g in lags), bool(standardise))
        if key not in cache:
            data = self.readings if key[1] == (0,) else stacked_readings(self.readings, self.clip_ids, key[1])
            if key[2]:
                data = np.asarray(data, dtype=np.float64) * np.tile(self.reading_scale, len(key[1]))
            cache[key] = KNNIndex(data, backend=backend)
        return cache[key]


def stacked_readings(readings: np.ndarray, clip_ids: np.ndarray | None, lags: Sequence[int]) -> np.ndarray:
    """Each frame's readings beside those ``lags`` frames earlier: (N, 3S) -> (N, 3S * len(lags)).

    A lag reaching before the first frame of the frame's clip (``clip_ids``,
    N; one clip when None) takes that first frame, as a stream's first
    samples do (:class:`~.synthesis.AccelerometerReconstructor`). The search
    key of the synthesis: twelve numbers of one instant say little about a
    pose, the last 0.3 s of them much more.
    """
    rd = np.asarray(readings, dtype=np.float64)
    n = np.arange(len(rd))
    start = np.zeros(len(rd), dtype=np.int64) if clip_ids is None else clip_starts(clip_ids)
    return np.concatenate([rd[np.maximum(n - int(g), start)] for g in lags], axis=1)


def clip_starts(clip_ids: np.ndarray) -> np.ndarray:
    """The first frame (N,) of each frame's clip, for clip ids ``clip_ids`` (N,) that run in blocks.

    >>> clip_starts(np.array([0, 0, 0, 1, 1, 2])).tolist()
    [0, 0, 0, 3, 3, 5]
    """
    cid = np.asarray(clip_ids)
    if cid.size == 0:
        return np.zeros(0, dtype=np.int64)
    first = np.r_[0, np.flatnonzero(np.diff(cid) != 0) + 1]
    return first[np.searchsorted(first, np.arange(cid.size), side="right") - 1].astype(np.int64)


_KB_CACHE: "weakref.WeakKeyDictionary[MotionDatabase, dict]" = weakref.WeakKeyDictionary()


def clear_cache(db: MotionDatabase | None = None) -> None:
    """Forget the cached knowledge bases of ``db`` (of every database when None): the next call builds them again."""
    if db is None:
        _KB_CACHE.clear()
    else:
        _KB_CACHE.pop(db, None)


def _sensor_key(sensors) -> tuple:
    return tuple((s.name, s.joint, tuple(np.round(s.rotation, 12)), tuple(np.round(s.offset, 12))) for s in sensors)


def check_sensors(db_skeleton: Skeleton, sensors, up=None) -> tuple:
    """``sensors`` as a tuple of :class:`~mocapkit.features.Sensor` on joints of ``db_skeleton`` (default sensors when None).

    ``up``: the vertical axis the default sensors are oriented by (the rest
    pose's when None). Raises ValueError naming the sensor and what is wrong
    with it.
    """
    if sensors is None:
        sensors = default_sensors(db_skeleton, up_axis=up)
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

    Readings (3S, m/s^2, sensor frames), pose vector (3J, radians: pelvis
    tilt, then body joints 1..J-1 as rotation vectors), velocities and
    accelerations of body joints 1..J-1 and the sensors in the root frame (3M
    each, cm/s and cm/s^2, M = J - 1 + S), pelvis velocity in the heading
    frame (3, cm/s), heading rate (1, rad/s), pelvis height along ``up`` (1,
    cm); J counts the body's joints (:func:`~mocapkit.reconstruct._common.body_motion`).
    See :func:`knowledge_base`.
    """
    m = body_motion(m)
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


def _split_values(vals: np.ndarray, S: int, J: int) -> tuple:
    """:func:`clip_values` columns as (readings, poses, velocities, accelerations, rest): float64, float64, float32 (F, M, 3) twice, float64 (F, 5)."""
    M = J - 1 + S
    F = vals.shape[0]
    rd, pose, vel, acc, rest = np.split(vals, np.cumsum([3 * S, 3 * J, 3 * M, 3 * M]), axis=1)
    return (np.ascontiguousarray(rd), np.ascontiguousarray(pose), vel.reshape(F, M, 3).astype(np.float32),
            acc.reshape(F, M, 3).astype(np.float32), np.ascontiguousarray(rest))


def _clip_block(clips: range, sensors, up, database: str) -> tuple:
    """:func:`_split_values` of the clips ``clips`` of the database saved at ``database`` (a worker's share)."""
    db = MotionDatabase.open(database)
    J = body_skeleton(db.skeletons[0]).num_joints
    parts = [_split_values(clip_values(db.clip(c), sensors, up), len(sensors), J) for c in clips]
    return tuple(np.concatenate(p, axis=0) for p in zip(*parts))


_ARRAYS = ("readings", "poses", "pose_mean", "pose_basis", "pose_coords", "velocities", "accelerations",
           "root_velocity", "yaw_rate", "root_height", "clip_ids")
DESCRIPTION = KNOWLEDGE_DESCRIPTION
_FORMAT = KNOWLEDGE_FORMAT  # knowledge.json's "format" (io.outputs refuses other outputs inside)


def knowledge_base(db: MotionDatabase, sensors: Sequence[Sensor] | None = None, *, cache_dir=None,
                   executor=None, progress: bool = False) -> KnowledgeBase:
    """The knowledge base of ``db`` for ``sensors`` (default: :func:`default_sensors`), cached per (db, sensors).

    Computed clip by clip, so no derivative runs across a clip boundary: in
    this process for a database in memory, on ``executor``
    (:func:`mocapkit.parallel.map_ordered`, local processes by default) for
    one opened from disk (:meth:`MotionDatabase.open`), whose workers
    memory-map it. The kNN index is built on first use
    (:meth:`KnowledgeBase.index`) and kept with it.

    ``cache_dir``: a folder for the knowledge base on disk, looked at on
    every call (a knowledge base this process already holds is saved there
    rather than built again). When it holds one
    of this database (same content digest, frames, clips and sensors) it is
    opened memory-mapped (:func:`open_knowledge_base`); otherwise the
    knowledge base is built and saved there (:func:`save_knowledge_base`),
    replacing only a knowledge base: any other existing folder is refused
    before any work (:func:`check_knowledge_base_output`).
    """
    if not isinstance(db, MotionDatabase):
        raise ValueError(f"db: expected a MotionDatabase, got {type(db).__name__}")
    if db.num_frames == 0:
        raise ValueError("the database is empty (0 frames); build it from at least one clip")
    sk0 = body_skeleton(db.skeletons[0])
    up = database_up(db)
    sensors = check_sensors(sk0, sensors, up)
    key = _sensor_key(sensors)
    per_db = _KB_CACHE.setdefault(db, {})
    if cache_dir is None:
        if key in per_db:
            return per_db[key]
    else:  # the folder asked for is opened or written every time, whatever this process holds in memory
        found = _open_matching(Path(cache_dir), db, key)
        if found is not None:
            per_db[key] = found
            return found
        check_knowledge_base_output(cache_dir)  # before the build: a folder of other files is refused, not emptied
        if key in per_db:
            return _saved(per_db[key], cache_dir, db)
    t0 = time.perf_counter()
    S, J = len(sensors), sk0.num_joints
    if db.path is not None and executor != "serial" and db.num_clips > 1:
        # workers return float32 derivatives: a third of the float64 block each, so the parent's peak stays low
        chunks = [range(a, min(a + 64, db.num_clips)) for a in range(0, db.num_clips, 64)]
        job = partial(_clip_block, sensors=sensors, up=up, database=str(db.path))
        blocks = map_ordered(job, chunks, executor=executor, progress=progress, desc="knowledge base")
    else:
        blocks = [_split_values(clip_values(db.clip(c), sensors, up), S, J) for c in range(db.num_clips)]
    fields = []
    for k in range(5):  # concatenate field by field, freeing each field's blocks as it goes
        fields.append(np.concatenate([b[k] for b in blocks], axis=0))
        blocks = [tuple(None if i == k else x for i, x in enumerate(b)) for b in blocks]
    del blocks
    rd, pose, vel, acc, rest = fields
    del fields
    if rd.shape[0] != db.num_frames:
        raise ValueError(f"the knowledge base has {rd.shape[0]} frames for a database of {db.num_frames}")
    good = np.isfinite(pose).all(axis=1)
    pmean = pose[good].mean(axis=0)
    lam, vec = np.linalg.eigh(np.cov((pose[good] - pmean).T, bias=True).reshape(pose.shape[1], pose.shape[1]))
    keep = lam > 1e-12 * max(lam.max(), 1e-300)
    pbasis = np.ascontiguousarray(vec[:, keep][:, ::-1])
    kb = KnowledgeBase(
        sensors=sensors,
        up=up,
        readings=rd,
        poses=pose,
        pose_mean=pmean,
        pose_basis=pbasis,
        pose_coords=np.ascontiguousarray((pose - pmean) @ pbasis),
        velocities=vel,
        accelerations=acc,
        root_velocity=np.ascontiguousarray(rest[:, :3]),
        yaw_rate=rest[:, 3].copy(),
        root_height=rest[:, 4].copy(),
        clip_ids=np.asarray(db.clip_ids, dtype=np.int64),
        fps=db.fps,
        build_seconds=0.0,
    )
    del rest
    kb.index("kdtree")
    object.__setattr__(kb, "build_seconds", time.perf_counter() - t0)
    if cache_dir is not None:
        kb = _saved(kb, cache_dir, db)
    per_db[key] = kb
    return kb


def _saved(kb: KnowledgeBase, cache_dir, db: MotionDatabase) -> KnowledgeBase:
    """``kb`` after writing it to ``cache_dir`` as ``db``'s (:func:`save_knowledge_base`); it stays in memory (``path`` None)."""
    save_knowledge_base(kb, cache_dir, _fingerprint(db), licence=db.info.get("licence"))
    return kb


def _fingerprint(db: MotionDatabase) -> dict:
    """What identifies ``db`` to a saved knowledge base: its content digest (free for a saved database), frames, clips, fps."""
    return {"digest": db.digest, "frames": int(db.num_frames), "clips": [[c.name, int(c.frames)] for c in db.clips],
            "fps": float(db.fps)}


def _sensor_json(sensors) -> list:
    return [{"name": s.name, "joint": s.joint, "rotation": [float(x) for x in s.rotation],
             "offset": [float(x) for x in s.offset]} for s in sensors]


def _not_a_knowledge_base(folder: Path) -> str:
    """Why the existing ``folder`` may not be replaced ("" when it is a knowledge base or empty).

    Only what :func:`save_knowledge_base` writes may be lost: ``knowledge.json``
    naming the format and the ``.npy`` file of each array, all regular
    files (no links, sub-folders or other files).
    """
    if not folder.is_dir():
        return "it is a file, not a knowledge base folder"
    names = {}
    with os.scandir(folder) as entries:
        for e in entries:
            names[e.name] = e.is_file(follow_symlinks=False)
    if not names:
        return ""
    if not names.get(DESCRIPTION):
        return f"it is not a knowledge base (no {DESCRIPTION})"
    allowed = {DESCRIPTION} | {f"{n}.npy" for n in _ARRAYS}
    for name, regular in sorted(names.items()):
        if name not in allowed or not regular:
            return f"it holds {name}, which a knowledge base save does not write"
    try:
        with open(folder / DESCRIPTION, encoding="utf-8") as fh:
            meta = json.loads(fh.read(2**20))
    except (OSError, ValueError):
        meta = None
    if not isinstance(meta, dict) or meta.get("format") != _FORMAT or "sensors" not in meta:
        return f"it is not a knowledge base ({DESCRIPTION} does not say so)"
    return ""


def check_knowledge_base_output(directory) -> None:
    """Refuse, before any work, a folder that :func:`save_knowledge_base` could not replace without loss.

    ``directory`` may be missing, an empty folder or a knowledge base
    (``knowledge.json`` of this format and the array files, nothing else):
    a cache folder is replaced without asking. Anything else (a results
    folder, a file, a broken link, a parent that is a file) is one
    :class:`~mocapkit.errors.MocapFormatError` line naming it, and nothing
    is touched. What a killed save left beside it is tidied first
    (:func:`mocapkit.database_folder.recover_leftovers`).
    """
    out = Path(directory)
    parent = resolved(out).parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise MocapFormatError(out, f"cannot create it: {parent} is a file, not a folder")
    if resolved(out).parent.is_dir():
        recover_leftovers(resolved(out))
    if not os.path.lexists(out):
        return
    why = _not_a_knowledge_base(resolved(out)) if out.exists() else "it is a broken symbolic link"
    if why:
        raise MocapFormatError(out, f"refusing to replace it with a knowledge base: {why}; give an empty or new folder")


def save_knowledge_base(kb: KnowledgeBase, directory, database: dict | None = None, licence: str | None = None) -> Path:
    """Write ``kb`` to the folder ``directory``: ``knowledge.json`` (sensors, up, fps, build time) and one ``.npy`` per array.

    ``database`` (optional, JSON-friendly) identifies the database it was
    built from; :func:`knowledge_base` compares it before reusing the folder.
    ``licence``: the terms of that database's takes (its ``info["licence"]``,
    :func:`mocapkit.rigs.data_terms`), kept in ``knowledge.json``.
    An existing ``directory`` is replaced only when it is a knowledge base
    (or empty); anything else is refused (:func:`check_knowledge_base_output`).
    The folder is written into a hidden ``.NAME.OWNER-XXXX.part`` beside the
    target (removed on any failure or interrupt) and renamed into place, the
    old knowledge base deleted only after that
    (:func:`mocapkit.database_folder.publish_folder`), so an interrupted save
    leaves the old or the new knowledge base, never a partial one, and can
    simply be run again. A failing write is one MocapFormatError line.
    Returns the folder.
    """
    check_knowledge_base_output(directory)
    meta = {"format": _FORMAT, "sensors": _sensor_json(kb.sensors), "up": [float(x) for x in kb.up], "fps": float(kb.fps),
            "build_seconds": float(kb.build_seconds), "database": database}
    if licence:  # the terms of the database's takes (its info["licence"], e.g. the Bandai Namco set's CC BY-NC 4.0)
        meta["licence"] = str(licence)

    def fill(tmp: Path) -> None:
        for name in _ARRAYS:
            np.save(tmp / f"{name}.npy", np.ascontiguousarray(getattr(kb, name)))
        (tmp / DESCRIPTION).write_text(json.dumps(meta))

    write_staged(directory, fill, lambda: check_knowledge_base_output(directory), "the knowledge base")
    return Path(directory)


def open_knowledge_base(directory, mmap: bool = True) -> KnowledgeBase:
    """Open a knowledge base written by :func:`save_knowledge_base`; its arrays are memory-mapped read-only unless ``mmap=False``.

    Opening reads only the description and the ``.npy`` headers; the pages
    are read as the synthesis touches them and shared between processes. The
    kd-tree over the readings is rebuilt on first use
    (:meth:`KnowledgeBase.index`). A missing or inconsistent folder raises
    :class:`~mocapkit.errors.MocapFormatError` naming it.
    """
    directory = Path(directory)
    try:
        meta = json.loads((directory / DESCRIPTION).read_text())
        arrays = {n: np.load(directory / f"{n}.npy", mmap_mode="r" if mmap else None, allow_pickle=False) for n in _ARRAYS}
        sensors = tuple(Sensor(d["name"], d["joint"], np.asarray(d["rotation"]), np.asarray(d["offset"])) for d in meta["sensors"])
        up = np.asarray(meta["up"], dtype=np.float64)
        fps, built = float(meta["fps"]), float(meta["build_seconds"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise MocapFormatError(directory, f"not a readable knowledge base ({exc})") from None
    N = arrays["readings"].shape[0]
    if any(arrays[n].shape[0] != N for n in _ARRAYS if n not in ("pose_mean", "pose_basis")):
        raise MocapFormatError(directory, "inconsistent knowledge base: its arrays differ in frame count")
    return KnowledgeBase(sensors=sensors, up=up, fps=fps, build_seconds=built, path=directory, **arrays)


def _open_matching(directory: Path, db: MotionDatabase, key: tuple) -> KnowledgeBase | None:
    """The knowledge base in ``directory`` if it was built from ``db`` with the sensors of ``key``, else None."""
    try:
        meta = json.loads((directory / DESCRIPTION).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(meta, dict):
        return None
    if meta.get("database") != json.loads(json.dumps(_fingerprint(db))):
        return None
    kb = open_knowledge_base(directory)
    return kb if _sensor_key(kb.sensors) == key else None
