"""The motion model: ``Skeleton`` and ``Motion``, forward kinematics, slicing, resampling, mirroring.

Both are small frozen dataclasses holding read-only numpy arrays; every
operation returns a new object (``dataclasses.replace(motion, rotations=...)``
is the way to change a field). Arrays are frames first: rotations (F, J, 4)
local to the parent joint, w first; positions (F, J, 3) in the file's units.
Missing data is NaN and survives every operation that does not fill it.

A skeleton is a ``parents`` array in topological order (``parents[0] == -1``,
``parents[j] < j``); forward kinematics is one loop over joints on whole arrays.
Joint ``j`` sits at its parent's position plus the parent's global rotation
applied to ``offsets[j]`` (BVH semantics); ASF/AMC skeletons are converted to
that form on reading, their per-bone axis frames kept in ``Skeleton.axes``.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import numpy as np

from . import rotations as R
from .errors import MocapError, SkeletonError
from .words import plural
from .joints import (  # the joint-naming names, re-exported: mocapkit.motion is where they were always found
    MIRROR_MISMATCH_MAX,
    ROLES,
    bone_moving_joints,
    find_joint,
    joint_sides,
    lateral_axis,
    mirror_mismatch,
    mirror_pairs,
    some_names,
    standard_joints,
    unit_scale_cm,
)

__all__ = [
    "Skeleton",
    "Motion",
    "concatenate",
    "mirror_pairs",
    "mirror_mismatch",
    "MIRROR_MISMATCH_MAX",
    "lateral_axis",
    "joint_sides",
    "find_joint",
    "standard_joints",
    "unit_scale_cm",
    "check_fps",
    "frame_slice",
    "frozen",
    "source_part",
    "with_channels_of",
    "channel_starts",
    "readonly_view",
    "FPS_RANGE",
    "MAX_JOINTS",
    "RESAMPLE_LIMIT_BYTES",
    "ROLES",
    "DEFAULT_ROOT_CHANNELS",
    "DEFAULT_JOINT_CHANNELS",
]

DEFAULT_ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
DEFAULT_JOINT_CHANNELS = ("Zrotation", "Yrotation", "Xrotation")
_CHANNEL_NAMES = {"Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation", "Xscale", "Yscale", "Zscale"}

FPS_RANGE = (1.0, 10000.0)
"""Frame rates mocapkit accepts, in frames per second, both ends included.

Human motion capture runs at 24-480 Hz, high-speed optical systems at 1-10 kHz
(a 2,000 Hz C3D is a real capture); a rate outside this range is a corrupt file
(a BVH ``Frame Time: 1000`` is 0.001 fps), and resampling such a clip to a
working rate would make millions of frames from a few hundred.
Every reader and every :class:`Motion` refuses a rate outside it (a motion
database keeps its own, narrower range: :data:`mocapkit.database.FPS_RANGE`).
"""

MAX_JOINTS = 100_000
"""Most joints a skeleton may have. Human rigs have tens to a few hundred; a file
declaring more is refused while it is read (reading, forward kinematics and
writing are linear in joints, but a 50 MB BVH could declare 600,000 and take a
minute and 1.6 GB to convert)."""

RESAMPLE_LIMIT_BYTES = 256 * 2**20
"""Largest rotation array (F_new * J * 4 float64, in bytes) :meth:`Motion.resample` makes.

256 MiB is 270,000 frames of a 31-joint skeleton (37 minutes at 120 fps);
resampling works through it in blocks, so its peak memory stays near twice
this. A larger result is refused with the number of frames it would have.
"""


def check_fps(fps, what: str = "fps") -> float:
    """``fps`` as a float when it is a frame rate within :data:`FPS_RANGE`, else ``SkeletonError``.

    ``what`` names the rate in the message (``"fps"``, ``"point frame rate"``).

    The one frame-rate check: readers call it (and re-raise naming the file),
    and so do :class:`Motion`, :class:`~mocapkit.io.c3d.MarkerSet` and
    :meth:`Motion.resample`.

    >>> check_fps(120)
    120.0
    >>> check_fps(0.001)
    Traceback (most recent call last):
    ...
    mocapkit.errors.SkeletonError: fps must be a positive number from 1 to 10000 (frames per second), got 0.001
    """
    try:
        value = float("nan") if isinstance(fps, (bool, np.bool_)) else float(fps)  # True is no rate, not 1 fps
    except (TypeError, ValueError):
        value = float("nan")
    lo, hi = FPS_RANGE
    if not (np.isfinite(value) and lo <= value <= hi):
        raise SkeletonError(f"{what} must be a positive number from {lo:g} to {hi:g} (frames per second), got {fps!r}")
    return value


def readonly_view(a: np.ndarray) -> np.ndarray:
    v = a.view()
    v.setflags(write=False)
    return v


def _joint_euler(q: np.ndarray, skeleton, joints, order: str) -> np.ndarray:
    """(n, len(joints), len(order)) degrees: the Euler angles of the rotations ``q`` (n, len(joints), 4) of
    ``joints`` (of one rotation ``order``) in their channel frame (an ASF ``axis`` removed)."""
    if skeleton.axes is not None:
        c = skeleton.axes[joints]
        q = R.quaternion_multiply(R.quaternion_multiply(R.quaternion_conjugate(c), q), c)
    return R.quaternion_to_euler(q, order)


def frozen(a: np.ndarray) -> np.ndarray:
    """``a`` as a container keeps it: a read-only view of memory nothing can write (a slice of another frozen
    array), else a read-only view of a read-only copy, so that the caller's array changing afterwards does not
    change a Motion, Skeleton or MarkerSet built from it.

    A memory map is copied whatever its mode: the file under it can be written by another map or program, and
    the container would follow. The result is always a view whose base is read-only, so that
    ``setflags(write=True)`` on it is refused (numpy allows that on an array that owns its memory).
    """
    b = a
    while isinstance(b, np.ndarray):
        if b.flags.writeable or isinstance(b, np.memmap):
            break
        b = b.base
    else:
        if b is None and a.base is not None:  # a view of read-only memory an array owns: nothing can write it
            return readonly_view(a)
    c = np.array(a, copy=True)
    c.setflags(write=False)
    return readonly_view(c)


def frame_slice(key, num_frames: int, fps: float, what: str = "take") -> tuple[slice, float]:
    """``take[key]`` of a take of ``num_frames`` frames at ``fps``: the frame slice and the rate it gives.

    A single index is that one frame; a slice runs forwards (a step ``k`` divides the rate by ``k``,
    and must leave one of :data:`FPS_RANGE`). Raises IndexError, TypeError or ValueError saying which.
    """
    if isinstance(key, (int, np.integer)):
        k = int(key)
        if not -num_frames <= k < num_frames:
            raise IndexError(f"frame {k} out of range for {num_frames} frames")
        k %= num_frames
        key = slice(k, k + 1)
    if not isinstance(key, slice):
        raise TypeError(f"a {what} is sliced by frames: {what}[a:b], {what}[a:b:k] or {what}[i]")
    step = 1 if key.step is None else int(key.step)
    if step <= 0:
        raise ValueError(f"frame slices run forwards: the step must be a positive integer, got {step}")
    if fps / step < FPS_RANGE[0]:
        raise ValueError(f"a step of {step} frames gives {fps / step:.3g} fps, below the {FPS_RANGE[0]:g} fps a take "
                         "may have")
    return key, fps / step


#: How far a rotation's squared length may be from 1 (float32 storage rounds it by up to about 2.4e-7).
UNIT_TOLERANCE = 1e-5


def _check_unit(rot: np.ndarray, skeleton) -> None:
    """Refuse rotations that are not unit quaternions (NaN, a missing joint, allowed): forward kinematics
    would scale the body by their length (3q put joints 5e8 away) and a zero one is no rotation at all."""
    n2 = np.einsum("fjk,fjk->fj", rot, rot)
    with np.errstate(invalid="ignore"):
        bad = np.abs(n2 - 1.0) > UNIT_TOLERANCE  # False where NaN
    if bad.any():
        f, j = (int(x[0]) for x in np.nonzero(bad))
        raise SkeletonError(f"rotations: quaternions must have unit length; frame {f}, joint "
                            f"{skeleton.joint_names[j]!r} has length {float(np.sqrt(n2[f, j])):.6g}")


def _check_finite(a: np.ndarray, name: str, rows) -> None:
    """Refuse a NaN or infinite row of ``a`` (N, 3), naming it by ``rows[i]``: a skeleton's rest offsets have no
    missing values (forward kinematics would put every joint below it nowhere)."""
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise SkeletonError(f"{name}: {rows[i]} is {a[i].tolist()}; offsets must be finite numbers")


def _source_path(path, name: str) -> str:
    """``path`` (a str or path-like) as an absolute path string, else TypeError."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"{name} must be a path (str or os.PathLike) or None, got {type(path).__name__}")
    return os.path.abspath(os.fspath(path))


def _as_float(a, name: str, shape_tail: tuple[int, ...], ndim: int) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim != ndim or arr.shape[arr.ndim - len(shape_tail):] != shape_tail:
        tail = ", ".join(str(s) for s in shape_tail)
        raise SkeletonError(f"{name}: expected shape ({'N, ' * (ndim - len(shape_tail))}{tail}), got {arr.shape}")
    return frozen(arr)


@dataclass(frozen=True, eq=False)
class Skeleton:
    """Joint hierarchy with rest offsets.

    Attributes
    ----------
    joint_names : tuple of str, (J,)
        Joint names; end sites are not joints.
    parents : int array (J,)
        Parent index of each joint, -1 for the root (index 0); ``parents[j] < j``.
    offsets : float array (J, 3)
        Rest offset of each joint from its parent, in the file's units.
    end_site_parents : int array (E,)
        The joint each end site (BVH ``End Site``, ASF leaf bone tip) hangs from.
    end_site_offsets : float array (E, 3)
        End-site offsets from their parent joint.
    channels : tuple of tuple of str, optional
        Per joint, the BVH-style channels of the source file in file order
        (``"Xposition"``, ``"Zrotation"``, ...). Rotation channels are in
        intrinsic order. Scale channels (``"Xscale"``, ...) are kept as the
        file's layout only: their value is always 1 (a skeleton has no scale). None means the BVH default (root: 3 positions + ZYX,
        others ZYX).
    axes : float array (J, 4), optional
        ASF ``axis`` frame ``C`` of each joint: the local rotation is
        ``C @ M @ C^-1`` where ``M`` is built from the joint-angle channels.
        None means identity (BVH).
    limits : tuple, optional
        Per joint, a (lo, hi) pair in degrees for each rotation channel (ASF ``limits``).
    unit_cm : float, optional
        Centimetres per length unit when the source states it (ASF ``:units length``).
    source_file : str, optional
        The ASF file the skeleton was read from (absolute path; None otherwise): the ASF an AMC written for
        it is read with (:func:`mocapkit.io.save` copies it beside the AMC). Not compared.
    """

    joint_names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    end_site_parents: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    end_site_offsets: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    channels: tuple[tuple[str, ...], ...] | None = None
    axes: np.ndarray | None = None
    limits: tuple[tuple[tuple[float, float], ...], ...] | None = None
    unit_cm: float | None = None
    source_file: str | None = None

    def __post_init__(self):
        names = tuple(str(n) for n in self.joint_names)
        object.__setattr__(self, "joint_names", names)
        J = len(names)
        if J == 0:
            raise SkeletonError("a skeleton needs at least one joint")
        if J > MAX_JOINTS:
            raise SkeletonError(f"{J:,} joints, more than the {MAX_JOINTS:,} a skeleton may have")
        if len(set(names)) != J:
            seen: set[str] = set()
            dup = sorted({n for n in names if n in seen or seen.add(n)})
            raise SkeletonError(f"duplicate joint names: {', '.join(dup)}")
        parents = np.asarray(self.parents, dtype=np.int64)
        if parents.shape != (J,):
            raise SkeletonError(f"parents: expected shape ({J},), got {parents.shape}")
        if parents[0] != -1:
            raise SkeletonError("the root must be joint 0 with parent -1")
        if J > 1 and np.any((parents[1:] < 0) | (parents[1:] >= np.arange(1, J))):
            raise SkeletonError("parents must be in topological order: 0 <= parents[j] < j for every j > 0")
        object.__setattr__(self, "parents", frozen(parents))
        offsets = _as_float(self.offsets, "offsets", (3,), 2)
        if offsets.shape[0] != J:
            raise SkeletonError(f"offsets: expected shape ({J}, 3), got {offsets.shape}")
        _check_finite(offsets, "offsets", names)
        object.__setattr__(self, "offsets", offsets)
        esp = np.asarray(self.end_site_parents, dtype=np.int64).reshape(-1)
        if np.any((esp < 0) | (esp >= J)):
            raise SkeletonError("end_site_parents must index joints")
        object.__setattr__(self, "end_site_parents", frozen(esp))
        eso = _as_float(np.asarray(self.end_site_offsets, dtype=np.float64).reshape(-1, 3), "end_site_offsets", (3,), 2)
        if eso.shape[0] != esp.shape[0]:
            raise SkeletonError("end_site_offsets and end_site_parents differ in length")
        _check_finite(eso, "end_site_offsets", [f"{names[p]} (end site)" for p in esp])
        object.__setattr__(self, "end_site_offsets", eso)
        if self.channels is not None:
            ch = tuple(tuple(str(c) for c in cs) for cs in self.channels)
            if len(ch) != J:
                raise SkeletonError(f"channels: expected one entry per joint ({J}), got {len(ch)}")
            for name, cs in zip(names, ch):
                bad = [c for c in cs if c not in _CHANNEL_NAMES]
                if bad:
                    raise SkeletonError(f"joint {name}: unknown channel(s) {', '.join(bad)}")
                if len(set(cs)) != len(cs):
                    raise SkeletonError(f"joint {name}: repeated channel in {cs}")
            object.__setattr__(self, "channels", ch)
        if self.axes is not None:
            axes = _as_float(self.axes, "axes", (4,), 2)
            if axes.shape[0] != J:
                raise SkeletonError(f"axes: expected shape ({J}, 4), got {axes.shape}")
            object.__setattr__(self, "axes", axes)
        if self.limits is not None:
            lim = tuple(tuple((float(lo), float(hi)) for lo, hi in jl) for jl in self.limits)
            if len(lim) != J:
                raise SkeletonError(f"limits: expected one entry per joint ({J}), got {len(lim)}")
            object.__setattr__(self, "limits", lim)
        if self.source_file is not None:
            object.__setattr__(self, "source_file", _source_path(self.source_file, "source_file"))

    # -- basic facts -------------------------------------------------------
    @property
    def num_joints(self) -> int:
        return len(self.joint_names)

    @property
    def num_end_sites(self) -> int:
        return int(self.end_site_parents.shape[0])

    @property
    def end_site_names(self) -> tuple[str, ...]:
        """Names of end sites: ``"<parent joint>_end"`` (numbered if a joint has several)."""
        out, seen = [], {}
        for p in self.end_site_parents:
            base = f"{self.joint_names[p]}_end"
            k = seen.get(base, 0)
            seen[base] = k + 1
            out.append(base if k == 0 else f"{base}{k + 1}")
        return tuple(out)

    def index(self, name: str) -> int:
        """Index of joint ``name``; raises ``KeyError`` naming the joints that exist."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise KeyError(f"no joint {name!r}; joints are: {some_names(self.joint_names)}") from None

    def children(self, j: int) -> list[int]:
        return [int(c) for c in np.flatnonzero(self.parents == j)]

    def joint_channels(self, j: int) -> tuple[str, ...]:
        """The file channels of joint ``j`` (the BVH default when the skeleton has none)."""
        if self.channels is not None:
            return self.channels[j]
        return DEFAULT_ROOT_CHANNELS if j == 0 else DEFAULT_JOINT_CHANNELS

    def rotation_order(self, j: int) -> str:
        """Intrinsic Euler order of joint ``j``'s rotation channels, e.g. ``"ZYX"`` ('' if none)."""
        return "".join(c[0] for c in self.joint_channels(j) if c.endswith("rotation"))

    def bone_lengths(self) -> np.ndarray:
        """Length of every joint's offset (J,); the root's is 0 by convention."""
        lengths = np.linalg.norm(self.offsets, axis=1)
        lengths[0] = 0.0
        return lengths

    def rest_positions(self, end_sites: bool = False) -> np.ndarray:
        """Global joint positions of the rest pose (identity rotations, root at its offset), (J, 3)."""
        pos = np.zeros((self.num_joints, 3))
        pos[0] = self.offsets[0]
        for j in range(1, self.num_joints):
            pos[j] = pos[self.parents[j]] + self.offsets[j]
        if end_sites:
            pos = np.concatenate([pos, pos[self.end_site_parents] + self.end_site_offsets])
        return pos

    def is_compatible(self, other: "Skeleton") -> bool:
        """Same joint names and hierarchy (offsets may differ: another actor of the same rig)."""
        return self.joint_names == other.joint_names and np.array_equal(self.parents, other.parents)

    def __eq__(self, other) -> bool:
        if not isinstance(other, Skeleton):
            return NotImplemented
        return (
            self.is_compatible(other)
            and np.array_equal(self.offsets, other.offsets)
            and np.array_equal(self.end_site_parents, other.end_site_parents)
            and np.array_equal(self.end_site_offsets, other.end_site_offsets)
            and self.same_axes(other)
        )

    def same_axes(self, other: "Skeleton") -> bool:
        """Both without ASF axis frames, or both with the same ones (a rotation's channels mean the same)."""
        if self.axes is None or other.axes is None:
            return self.axes is None and other.axes is None
        return bool(np.array_equal(self.axes, other.axes))

    __hash__ = None  # mutable-looking arrays inside: not hashable

    def __repr__(self) -> str:
        return (f"Skeleton({plural(self.num_joints, 'joint')}, {plural(self.num_end_sites, 'end site')}, "
                f"root={self.joint_names[0]!r})")


@dataclass(frozen=True, eq=False)
class Motion:
    """A clip: a skeleton animated by local joint rotations and a root trajectory.

    Attributes
    ----------
    skeleton : Skeleton
    rotations : float array (F, J, 4)
        Local joint rotations relative to the parent, unit quaternions, w first.
    root_positions : float array (F, 3)
        Global position of the root joint in the file's units.
    fps : float
        Frames per second.
    name : str
        Free text, usually the file stem.
    translations : float array (F, J, 3), optional
        Per-frame local offsets for files that animate them (BVH position
        channels on non-root joints). Where given, forward kinematics uses
        ``translations[:, j]`` instead of ``skeleton.offsets[j]`` for every
        joint ``j > 0``; column 0 is unused (the root is ``root_positions``).
    source_file : str, optional
        The file the take was read from (absolute path; set by the readers, kept by every operation that
        returns a new Motion, None for a take made in Python). :func:`mocapkit.io.save` writes a BVH or AMC
        like it (its text kept wherever the take did not change, as the command line does). Not compared,
        not written to .npz.
    source_frames : range, optional
        Which of that file's frames the take's frames are (0-based, in the file's order), where that is known:
        slicing sets it (``take[100:200]`` of a file's take holds ``range(100, 200)``, and a slice of it is
        sliced from those), so that :func:`mocapkit.io.save` writes a contiguous part of the file's frames
        with the file's own lines (:func:`source_part`). None: the file's frames as read (the whole file when
        the take has as many frames). An empty range on a take with frames: none of the file's frames in
        order (a resampled or concatenated take): the file is written whole. Not compared, not written to .npz.

    Examples
    --------
    >>> import mocapkit
    >>> m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    >>> m.rotations.shape, m.fps
    ((994, 31, 4), 120.0)
    >>> m[10:20].global_positions().shape
    (10, 31, 3)
    """

    skeleton: Skeleton
    rotations: np.ndarray
    root_positions: np.ndarray
    fps: float
    name: str = ""
    translations: np.ndarray | None = None
    source_file: str | None = None
    source_frames: range | None = None

    def __post_init__(self):
        if not isinstance(self.skeleton, Skeleton):
            raise TypeError(f"skeleton must be a Skeleton, got {type(self.skeleton).__name__}")
        J = self.skeleton.num_joints
        rot = np.asarray(self.rotations, dtype=np.float64)
        if rot.ndim != 3 or rot.shape[1:] != (J, 4):
            raise SkeletonError(f"rotations: expected shape (F, {J}, 4) with w first, got {rot.shape}")
        F = rot.shape[0]
        _check_unit(rot, self.skeleton)
        root = np.asarray(self.root_positions, dtype=np.float64)
        if root.shape != (F, 3):
            raise SkeletonError(f"root_positions: expected shape ({F}, 3), got {root.shape}")
        if np.isinf(root).any():  # NaN is a missing sample; an infinite position is none
            f = int(np.flatnonzero(np.isinf(root).any(axis=1))[0])
            raise SkeletonError(f"root_positions: frame {f} is infinite ({root[f].tolist()}); missing is NaN")
        fps = check_fps(self.fps)
        object.__setattr__(self, "rotations", frozen(rot))
        object.__setattr__(self, "root_positions", frozen(root))
        object.__setattr__(self, "fps", fps)
        object.__setattr__(self, "name", str(self.name))
        if self.translations is not None:
            tr = np.asarray(self.translations, dtype=np.float64)
            if tr.shape != (F, J, 3):
                raise SkeletonError(f"translations: expected shape ({F}, {J}, 3), got {tr.shape}")
            if np.isinf(tr).any():
                raise SkeletonError("translations: an offset is infinite; missing is NaN")
            object.__setattr__(self, "translations", frozen(tr))
        if self.source_file is not None:
            object.__setattr__(self, "source_file", _source_path(self.source_file, "source_file"))
        if self.source_frames is not None and not isinstance(self.source_frames, range):
            raise TypeError(f"source_frames must be a range or None, got {type(self.source_frames).__name__}")

    # -- sizes -------------------------------------------------------------
    @property
    def num_frames(self) -> int:
        return int(self.rotations.shape[0])

    @property
    def num_joints(self) -> int:
        return self.skeleton.num_joints

    @property
    def duration(self) -> float:
        """Length in seconds, ``num_frames / fps``."""
        return self.num_frames / self.fps

    def __len__(self) -> int:
        return self.num_frames

    def __repr__(self) -> str:
        return (
            f"Motion({self.name!r}, {plural(self.num_frames, 'frame')} @ {self.fps:g} fps, "
            f"{plural(self.num_joints, 'joint')}, {self.duration:.2f} s)"
        )

    # -- slicing -----------------------------------------------------------
    def __getitem__(self, key) -> "Motion":
        """Frames by slice (a step ``k`` divides fps by ``k``) or by a single index (one frame)."""
        key, fps = frame_slice(key, self.num_frames, self.fps, "motion")
        tr = None if self.translations is None else self.translations[key]
        frames = self.source_frames
        if self.source_file is not None:  # the file's frames the part holds: those of the take's, sliced
            held = range(self.num_frames) if frames is None else frames
            frames = held[key] if len(held) == self.num_frames else range(0)
        out = dataclasses.replace(
            self, rotations=self.rotations[key], root_positions=self.root_positions[key], fps=fps, translations=tr,
            source_frames=frames,
        )
        seed = self._euler_source()  # the frames' Euler angles are the take's (each frame its own)
        if seed is not None:
            object.__setattr__(out, "_euler_seed", (seed[0][key], seed[1][key]))
        return out

    # -- forward kinematics -------------------------------------------------
    def local_offsets(self) -> np.ndarray:
        """Per-frame local joint offsets (F, J, 3): skeleton offsets, animated translations, root position."""
        F, J = self.num_frames, self.num_joints
        if self.translations is not None:
            off = np.array(self.translations)
        else:
            off = np.broadcast_to(self.skeleton.offsets, (F, J, 3)).copy()
        off[:, 0] = self.root_positions
        return off

    def global_transforms(self) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics: global rotations (F, J, 4) and positions (F, J, 3) of all joints.

        One compiled loop over joints and frames (:func:`mocapkit._numba_fk.fk_kernel`), the
        same arithmetic as ``rotations.quaternion_multiply`` and
        ``quaternion_rotate`` on whole arrays and bit for bit equal to them,
        without their per-joint overhead: a 100,000-joint chain takes
        milliseconds, not minutes.
        """
        F, J = self.num_frames, self.num_joints
        grot = np.empty((F, J, 4))
        gpos = np.empty((F, J, 3))
        grot[:, 0] = self.rotations[:, 0]
        gpos[:, 0] = self.root_positions
        local = self.skeleton.offsets[None] if self.translations is None else self.translations
        from ._numba_fk import fk_kernel  # lazy: importing mocapkit loads no numba

        # the inputs always read-only: numba compiles one machine code per argument type, and a copy made contiguous
        # (a slice's rotations) or animated translations would otherwise be writable arrays, a type of their own
        fk_kernel(
            readonly_view(np.ascontiguousarray(self.skeleton.parents)),
            readonly_view(np.ascontiguousarray(self.rotations)),
            readonly_view(np.ascontiguousarray(local)),
            grot,
            gpos,
        )
        return grot, gpos

    def global_rotations(self) -> np.ndarray:
        """Global joint rotations (F, J, 4), w first."""
        return self.global_transforms()[0]

    def global_positions(self, end_sites: bool = False) -> np.ndarray:
        """Global joint positions (F, J, 3) in the file's units; with ``end_sites`` (F, J + E, 3)."""
        grot, gpos = self.global_transforms()
        if not end_sites:
            return gpos
        return np.concatenate([gpos, self.end_sites_from(grot, gpos)], axis=1)

    def end_site_positions(self) -> np.ndarray:
        """Global end-site positions (F, E, 3), in ``skeleton.end_site_names`` order."""
        grot, gpos = self.global_transforms()
        return self.end_sites_from(grot, gpos)

    def end_sites_from(self, grot: np.ndarray, gpos: np.ndarray) -> np.ndarray:
        """End-site positions (F, E, 3) from global rotations (F, J, 4) and positions (F, J, 3) already computed
        (:meth:`global_transforms`), so callers that need both pay for forward kinematics once."""
        sk = self.skeleton
        p = sk.end_site_parents
        return gpos[:, p] + R.quaternion_rotate(grot[:, p], sk.end_site_offsets)

    def positions(self, names: Sequence[str]) -> np.ndarray:
        """Global positions (F, len(names), 3) of named joints and/or end sites."""
        sk = self.skeleton
        lookup = {n: i for i, n in enumerate(sk.joint_names + sk.end_site_names)}
        missing = [n for n in names if n not in lookup]
        if missing:
            raise KeyError(f"no joint or end site named {', '.join(map(repr, missing))}")
        allpos = self.global_positions(end_sites=bool(set(names) & set(sk.end_site_names)))
        return allpos[:, [lookup[n] for n in names]]

    # -- missing data --------------------------------------------------------
    def missing(self) -> np.ndarray:
        """Boolean (F, J) mask of joints with any NaN in their rotation (root: or its position); a new array each
        call, the mask made once per Motion (its arrays are read-only)."""
        made = self.__dict__.get("_missing")
        if made is None:
            made = np.any(np.isnan(self.rotations), axis=-1)
            made[:, 0] |= np.any(np.isnan(self.root_positions), axis=-1)
            if self.translations is not None:
                made[:, 1:] |= np.any(np.isnan(self.translations[:, 1:]), axis=-1)
            made.flags.writeable = False
            object.__setattr__(self, "_missing", made)  # a cache beside the frozen fields, not one of them
        return made.copy()

    # -- channels as the file gives them ------------------------------------
    def channel_names(self) -> list[str]:
        """Names ``"joint.Channel"`` of :meth:`channel_values`' columns."""
        sk = self.skeleton
        return [f"{sk.joint_names[j]}.{c}" for j in range(sk.num_joints) for c in sk.joint_channels(j)]

    def channel_values(self) -> np.ndarray:
        """All file channels (F, C): positions in file units, rotations in degrees, in file order.

        Each rotation's Euler angles in the skeleton's channel order (for ASF skeletons: the AMC degrees of
        freedom, with the ``axis`` frame removed) as the plain conversion gives them
        (:func:`mocapkit.rotations.quaternion_to_euler`), frame by frame: the first and last angle in
        [-180, 180], the middle one of three in [-90, 90]. They give each rotation exactly, but not always the
        file's numbers: a file that writes an angle past 180 degrees or on the other Euler solution (CMU's
        01_01.bvh Hips, 2,668 of its cells) reads here wrapped, with 360-degree jumps the file does not have.
        The numbers as the BVH gives them (the file's own where the take did not change, else continuous over
        frames) are :func:`mocapkit.io.bvh.written_values`, what the writer writes. Joints without rotation
        channels contribute nothing; scale channels are 1.
        """
        sk = self.skeleton
        local = self.local_offsets()
        angles = self.euler_angles()
        cols = []
        k = 0
        for j in range(sk.num_joints):
            for ch in sk.joint_channels(j):
                if ch.endswith("position"):
                    cols.append(local[:, j, "XYZ".index(ch[0])])
                elif ch.endswith("scale"):
                    cols.append(np.ones(self.num_frames))
                else:
                    cols.append(angles[:, k])
                    k += 1
        return np.stack(cols, axis=1) if cols else np.zeros((self.num_frames, 0))

    def euler_angles(self) -> np.ndarray:
        """(F, R) degrees: the rotation channels of :meth:`channel_values` alone, joint by joint in file order.

        Made once per Motion (its arrays are read-only) and returned as a new array each call. A Motion made by
        :meth:`with_rotations` or sliced from one that has them converts only the cells whose rotation differs,
        bit for bit, from the rotations they were made of: the conversion is the cell's own
        (:func:`mocapkit.rotations.quaternion_to_euler` per (frame, joint)), so the angles are the ones a whole
        conversion gives, and ``clean``'s networks read a take that fill, denoise and repair change in a few cells
        without converting the whole take again at each.
        """
        made = self.__dict__.get("_euler")
        if made is None:
            seed = self.__dict__.get("_euler_seed")
            made = self._convert_euler(seed)
            made.flags.writeable = False
            object.__setattr__(self, "_euler", made)  # a cache beside the frozen fields, as missing()'s
            self.__dict__.pop("_euler_seed", None)
        return made.copy()

    def _convert_euler(self, seed) -> np.ndarray:
        """(F, R) the Euler angles of every rotation cell, or, with ``seed`` ``(rotations (F, J, 4), angles (F, R))``
        of the same skeleton, of the cells whose rotation differs in any bit from ``seed``'s (joint by joint), the
        others copied from it."""
        sk = self.skeleton
        starts, c = {}, 0
        by_order: dict[str, list[int]] = {}  # one vectorised conversion per rotation order
        for j in range(sk.num_joints):
            order = sk.rotation_order(j)
            if order:
                by_order.setdefault(order, []).append(j)
                starts[j] = c
                c += len(order)
        if seed is None:
            out = np.empty((self.num_frames, c))
            for order, js in by_order.items():
                eul = _joint_euler(self.rotations[:, js], sk, js, order)  # (F, len(js), len(order))
                for i, j in enumerate(js):
                    out[:, starts[j] : starts[j] + len(order)] = eul[:, i]
            return out
        before, out = seed[0], np.array(seed[1])
        q = self.rotations
        changed = ~(q.view(np.int64) == before.view(np.int64)).all(axis=-1)  # (F, J): any bit, NaN's included
        for order, js in by_order.items():
            for j in js:
                frames = np.flatnonzero(changed[:, j])
                if len(frames):
                    out[frames, starts[j] : starts[j] + len(order)] = _joint_euler(q[frames][:, [j]], sk, [j], order)[:, 0]
        return out

    def _euler_source(self):
        """``(rotations, angles)`` a Motion of the same skeleton derived from this one starts its Euler angles from
        (:meth:`euler_angles`): this one's own, or those it was itself derived from; None if neither is made."""
        made = self.__dict__.get("_euler")
        return (self.rotations, made) if made is not None else self.__dict__.get("_euler_seed")

    def __getstate__(self) -> dict:
        """The fields (and :meth:`missing`'s mask) to pickle, without the Euler angles and those they start from:
        a Motion sent to another process carries no earlier take's arrays (they are made again there on use)."""
        return {k: v for k, v in self.__dict__.items() if k not in ("_euler", "_euler_seed")}

    def euler_from(self, like: "Motion") -> "Motion":
        """This Motion, its :meth:`euler_angles` (when not made yet) to convert only the cells whose rotation
        differs from ``like``'s (a Motion of the same skeleton and frames it was made from: a step's result from
        the take it changed); itself unchanged where the skeletons or frame counts differ."""
        seed = like._euler_source()
        if (seed is not None and "_euler" not in self.__dict__ and self.skeleton is like.skeleton
                and self.rotations.shape == seed[0].shape):
            object.__setattr__(self, "_euler_seed", seed)  # a cache beside the frozen fields
        return self

    def with_rotations(self, rotations: np.ndarray, **fields) -> "Motion":
        """This Motion with ``rotations`` (F, J, 4) (and any other ``fields`` but the skeleton and frame count, as
        ``dataclasses.replace`` takes them), whose :meth:`euler_angles` convert only the cells whose rotation
        differs from this one's (:meth:`euler_from`)."""
        return dataclasses.replace(self, rotations=rotations, **fields).euler_from(self)

    @classmethod
    def from_channel_values(
        cls, skeleton: Skeleton, values: np.ndarray, fps: float, name: str = "", animated_offsets: bool = False
    ) -> "Motion":
        """Inverse of :meth:`channel_values`: build a Motion from (F, C) file channels.

        Joints with no position channels keep their skeleton offset; a root
        without position channels stays at its offset. With
        ``animated_offsets``, position channels of non-root joints become
        ``translations``; otherwise they must be absent. Scale columns are
        ignored (a skeleton has no scale; :func:`mocapkit.io.bvh.read_bvh`
        refuses values other than 1).
        """
        values = np.asarray(values, dtype=np.float64)
        sk = skeleton
        F = values.shape[0]
        J = sk.num_joints
        ncols = sum(len(sk.joint_channels(j)) for j in range(J))
        if values.ndim != 2 or values.shape[1] != ncols:
            raise SkeletonError(f"channel values: expected shape (F, {ncols}), got {values.shape}")
        rot = np.empty((F, J, 4))
        local = np.broadcast_to(sk.offsets, (F, J, 3)).copy()
        has_tr = False
        col = 0
        # Group joints by rotation order so each distinct order is one vectorised conversion.
        by_order: dict[str, list[tuple[int, list[int]]]] = {}
        for j in range(J):
            chans = sk.joint_channels(j)
            rcols = []
            for ch in chans:
                if ch.endswith("position"):
                    local[:, j, "XYZ".index(ch[0])] = values[:, col]
                    has_tr = has_tr or j > 0
                elif not ch.endswith("scale"):
                    rcols.append(col)
                col += 1
            by_order.setdefault(sk.rotation_order(j), []).append((j, rcols))
        for order, items in by_order.items():
            js = [j for j, _ in items]
            if not order:
                rot[:, js] = R.identity((F, len(js)))
                continue
            cols_idx = np.array([c for _, c in items])  # (n, k)
            rot[:, js] = R.euler_to_quaternion(values[:, cols_idx], order)
        if sk.axes is not None:
            c = sk.axes[None]
            rot = R.quaternion_multiply(R.quaternion_multiply(c, rot), R.quaternion_conjugate(c))
        if has_tr and not animated_offsets:
            raise SkeletonError("non-root joints have position channels; pass animated_offsets=True")
        return cls(
            skeleton=sk,
            rotations=rot,
            root_positions=local[:, 0],
            fps=fps,
            name=name,
            translations=local if has_tr else None,
        )

    # -- resampling ----------------------------------------------------------
    def resample(self, fps: float) -> "Motion":
        """Resample to ``fps`` by slerp of rotations and linear interpolation of positions.

        Frame 0 is kept; the new frames are at times ``k / fps`` up to the last
        original frame. A NaN endpoint makes the interpolated sample NaN.
        ``fps`` must lie in :data:`FPS_RANGE`, and a result whose rotations
        would exceed :data:`RESAMPLE_LIMIT_BYTES` is refused (``MocapError``
        naming the frames it would make) before anything is allocated; the
        frames are interpolated in blocks, so temporaries stay small.
        """
        fps = check_fps(fps)
        if fps == self.fps:
            return self
        F, J = self.num_frames, self.num_joints
        n_new = int(np.floor((F - 1) * fps / self.fps + 1e-9)) + 1 if F > 0 else 0
        need = n_new * J * 4 * 8
        if need > RESAMPLE_LIMIT_BYTES:
            raise MocapError(
                f"resampling {F} frames from {self.fps:g} to {fps:g} fps would make {n_new:,} frames of "
                f"{J} joints ({need / 2**20:,.0f} MiB of rotations), over the "
                f"{RESAMPLE_LIMIT_BYTES / 2**20:,.0f} MiB limit; cut the clip or choose a lower rate"
            )
        rot = np.empty((n_new, J, 4))
        root = np.empty((n_new, 3))
        tr = None if self.translations is None else np.empty((n_new, J, 3))
        block = max(1, 2**22 // max(J, 1))  # about 128 MiB of rotation temporaries per block
        for s0 in range(0, n_new, block):
            k = np.arange(s0, min(s0 + block, n_new))
            t = k * (self.fps / fps)
            i0 = np.minimum(np.floor(t + 1e-9).astype(np.int64), max(F - 1, 0))
            i1 = np.minimum(i0 + 1, max(F - 1, 0))
            a = np.clip(t - i0, 0.0, 1.0)
            # Exact hits stay exact (no renormalisation round-off on kept frames).
            exact = a == 0.0
            r = R.slerp(self.rotations[i0], self.rotations[i1], a[:, None])
            r[exact] = self.rotations[i0[exact]]
            rot[k] = r
            root[k] = _lerp(self.root_positions, i0, i1, a, exact)
            if tr is not None:
                tr[k] = _lerp(self.translations, i0, i1, a, exact)
        # new frames, none of them the file's in order: a writer writes the file whole (source_part)
        return dataclasses.replace(self, rotations=rot, root_positions=root, fps=fps, translations=tr,
                                   source_frames=None if self.source_file is None else range(0))

    # -- mirroring -----------------------------------------------------------
    def mirror(self, axis: int | None = None) -> "Motion":
        """Left/right mirror image: reflect across the sagittal plane and swap paired joints.

        Pairs are found by name (:func:`mirror_pairs`); ``axis`` is the lateral
        axis (0, 1, 2), by default the one separating paired joints in the rest
        pose. The skeleton is mirrored too, so ``mirror().global_positions()``
        is the reflected, pair-swapped ``global_positions()`` exactly. For
        rotations that pose the take's own skeleton (a rig whose joints' rest
        frames differ by side) see :func:`mocapkit.mirroring.mirror_keeping_skeleton`.
        """
        sk = self.skeleton
        perm = mirror_pairs(sk.joint_names)
        if axis is None:
            axis = lateral_axis(sk)
        flip = np.ones(3)
        flip[axis] = -1.0
        qflip = np.ones(4)
        qflip[1:] = -flip  # reflection M R M negates the quaternion's non-lateral components
        rot = self.rotations[:, perm] * qflip
        root = self.root_positions * flip
        tr = None if self.translations is None else self.translations[:, perm] * flip
        # An end site takes the mirrored offset of the same-rank end site on its joint's partner.
        es_off_new = sk.end_site_offsets * flip
        slots_of: dict[int, list[int]] = {}
        rank = []
        for slot, p in enumerate(sk.end_site_parents.tolist()):
            rank.append(len(slots_of.setdefault(p, [])))
            slots_of[p].append(slot)
        for slot, p in enumerate(sk.end_site_parents.tolist()):
            partner_slots = slots_of.get(int(perm[p]), [])
            if rank[slot] < len(partner_slots):
                es_off_new[slot] = sk.end_site_offsets[partner_slots[rank[slot]]] * flip
        axes = None if sk.axes is None else sk.axes[perm] * qflip
        limits = None
        if sk.limits is not None:
            lim = []
            for j in range(sk.num_joints):
                src = perm[j]
                order_src = sk.rotation_order(src)
                new = []
                for (lo, hi), ax in zip(sk.limits[src], order_src):
                    new.append((lo, hi) if "XYZ".index(ax) == axis else (-hi, -lo))
                lim.append(tuple(new))
            limits = tuple(lim)
        channels = None if sk.channels is None else tuple(sk.channels[perm[j]] for j in range(sk.num_joints))
        new_sk = dataclasses.replace(
            sk,
            offsets=sk.offsets[perm] * flip,
            end_site_offsets=es_off_new,
            channels=channels,
            axes=axes,
            limits=limits,
        )
        return dataclasses.replace(
            self, skeleton=new_sk, rotations=rot, root_positions=root, translations=tr, name=self.name + "_mirror"
        )


def _lerp(x: np.ndarray, i0: np.ndarray, i1: np.ndarray, a: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """Linear interpolation of frames ``x[i0]`` to ``x[i1]`` (F, ...) by ``a`` (F,); ``exact`` rows copied as is."""
    w = a.reshape((-1,) + (1,) * (x.ndim - 1))
    out = x[i0] * (1 - w) + x[i1] * w
    out[exact] = x[i0[exact]]
    return out


def channel_starts(channels) -> np.ndarray:
    """(J + 1,) int: where each joint's columns start in the (F, C) channel matrix, and C last: joint ``j``'s are
    ``starts[j]:starts[j + 1]``. ``channels``: per joint its channel names in column order (a BVH's ``Zrotation``,
    an AMC's ``rx``; :meth:`Skeleton.joint_channels`), the layout of :meth:`Motion.channel_values` and the files."""
    return np.cumsum([0] + [len(c) for c in channels])


def with_channels_of(motion: Motion, skeleton: Skeleton) -> Motion:
    """``motion`` with ``skeleton``'s channels (Euler orders, ASF axes) when it is on the same joints and
    hierarchy but its channels differ, so that its ``channel_values`` compare with a take on ``skeleton``:
    an ASF/AMC take and its BVH conversion hold the same rotations, yet a channel named Zrotation is
    another angle in each. The rotations are unchanged; ``motion`` itself when nothing differs or when it
    animates joint offsets (translations)."""
    sk = motion.skeleton
    if (sk.channels == skeleton.channels and sk.same_axes(skeleton)) or not sk.is_compatible(skeleton) or motion.translations is not None:
        return motion
    return dataclasses.replace(motion, skeleton=dataclasses.replace(sk, channels=skeleton.channels, axes=skeleton.axes))


def concatenate(motions: Iterable[Motion], name: str | None = None) -> Motion:
    """Frames of several clips one after another; skeletons must be the same (joints, hierarchy, bone offsets
    and ASF axes: the result has one skeleton, and another actor's bones would move every joint of their
    frames) and frame rates agree.

    The result keeps the first clip's ``source_file``; its ``source_frames`` say it holds none of that file's
    frames in order (an empty range), so :func:`mocapkit.io.save` writes the file whole, unless the clips are
    consecutive slices of that one file (``m[:100]`` and ``m[100:200]``: the file's frames 0-199)."""
    motions = list(motions)
    if not motions:
        raise ValueError("concatenate needs at least one motion")
    first = motions[0]
    for m in motions[1:]:
        if not m.skeleton.is_compatible(first.skeleton):
            raise SkeletonError(f"cannot concatenate {m.name!r}: its skeleton differs from {first.name!r}'s")
        a, b = np.asarray(m.skeleton.offsets), np.asarray(first.skeleton.offsets)
        if not np.array_equal(a, b):
            j = int(np.argmax(np.linalg.norm(a - b, axis=1)))
            raise SkeletonError(f"cannot concatenate {m.name!r}: its bones differ from {first.name!r}'s (the offset of "
                                f"{m.skeleton.joint_names[j]!r} by {float(np.linalg.norm(a[j] - b[j])):.3g} length "
                                "units); concatenate takes of one actor")
        if not m.skeleton.same_axes(first.skeleton):
            raise SkeletonError(f"cannot concatenate {m.name!r}: its ASF axes differ from {first.name!r}'s")
        if m.fps != first.fps:
            raise SkeletonError(f"cannot concatenate {m.name!r} at {m.fps:g} fps with {first.name!r} at {first.fps:g} fps")
    any_tr = any(m.translations is not None for m in motions)
    tr = np.concatenate([m.local_offsets() for m in motions]) if any_tr else None
    return dataclasses.replace(
        first,
        rotations=np.concatenate([m.rotations for m in motions]),
        root_positions=np.concatenate([m.root_positions for m in motions]),
        translations=tr,
        name=first.name if name is None else name,
        source_frames=_joined_frames(motions),
    )


def _joined_frames(motions: list[Motion]) -> range | None:
    """The ``source_frames`` of ``motions`` one after another: the run of the file's frames they hold where each is
    a contiguous slice of the first's file continuing the one before; else an empty range (None without a file)."""
    first = motions[0]
    if first.source_file is None:
        return None
    if len(motions) == 1:
        return first.source_frames
    spans = [m.source_frames for m in motions]
    if any(m.source_file != first.source_file or s is None or len(s) != m.num_frames or (len(s) > 1 and s.step != 1)
           for m, s in zip(motions, spans)):
        return range(0)
    if any(a.stop != b.start for a, b in zip(spans, spans[1:])):
        return range(0)
    return range(spans[0].start, spans[-1].stop)


def source_part(motion: Motion, file_frames: int) -> range | None:
    """The frames of its source file (one of ``file_frames`` frames) that ``motion`` holds, where they are a
    contiguous run of them in the file's order, else None: what a writer keeps the file's lines of
    (:func:`mocapkit.io.bvh.write_bvh`, :func:`mocapkit.io.amc_writer.write_amc`).

    ``motion.source_frames`` None: the file's own frames when the take has ``file_frames`` of them (as read);
    a range: those frames (a slice, a slice of a slice), if it is contiguous (step 1), as long as the take and
    lies within the file. A strided slice, a resampled or concatenated take (an empty range) gives None: such a
    take is written whole."""
    F = motion.num_frames
    frames = motion.source_frames
    if frames is None:
        return range(F) if F == file_frames else None
    if len(frames) != F or (F > 1 and frames.step != 1) or frames.start < 0 or frames.start + F > file_frames:
        return None
    return range(frames.start, frames.start + F)
