"""The baseline detectors Aristidou et al. 2018 compare against (section 6, Table 1 bottom).

"(a) a method that checks whether the joint rotation values violate
anthropometric constraints, (b) a method that detects unrealistic abrupt
changes in joint rotations by checking if their derivative is above a
threshold, and (c) a combination of the two. We searched over a large dataset
of clean data to define the limits for both the joints' rotation values, and
rotation change rate."

Both limits are learnt here from clean motions (:func:`learn_joint_limits`):

- rotation values: each joint's local rotation is expressed relative to the
  joint's mean rotation over the clean data, as an exponential-map (rotation
  vector) in degrees, ``v = degrees(2 log(mean^-1 q))`` (3 components). This
  works alike for BVH joints (3 channels) and ASF joints with 1-3 degrees of
  freedom (the unused components stay near 0), and has no Euler wrap-around:
  it only wraps for rotations more than 180 deg away from the mean. The limits
  are per-component quantile boxes ``[low, high]`` widened by a margin. The
  root's facing (its twist about the vertical) is removed first, so walking in
  any direction is the same pose; only its tilt is limited.
- rotation change rate: the angular speed of each joint in deg/s, the geodesic
  angle between consecutive frames times the frame rate (so limits learnt at
  120 fps apply to 30 fps clips), limited by a high quantile times a factor.

Detections are boolean (F, J) masks, the layout of
:func:`mocapkit.metrics.precision_recall`; missing cells (NaN) are never flagged.

Examples
--------
>>> import mocapkit
>>> from mocapkit import corrupt
>>> from mocapkit.cleaning import baselines as B
>>> m = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
>>> limits = B.learn_joint_limits([m])
>>> int(B.detect_baseline(m, limits, "c").sum())     # the clean clip it was learnt from
0
>>> bad, truth, _ = corrupt.real_errors(m, kinds=("spike",), n_errors=1, seed=3)
>>> found = B.detect_rate(bad, limits)
>>> bool((found & truth).any())
True
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .. import rotations as R
from ..errors import SkeletonError
from ..io import atomic_write
from ..motion import Motion, Skeleton, find_joint

__all__ = [
    "JointLimits",
    "learn_joint_limits",
    "detect_limits",
    "detect_rate",
    "detect_baseline",
    "rotation_components",
    "angular_speed",
    "BASELINE_KINDS",
]

BASELINE_KINDS = ("a", "b", "c")


def _readonly(a: np.ndarray) -> np.ndarray:
    v = a.view()
    v.setflags(write=False)
    return v


@dataclass(frozen=True, eq=False)
class JointLimits:
    """Per-joint rotation and rotation-rate limits learnt from clean motions.

    Attributes
    ----------
    joint_names : tuple of str, (J,)
        The joints the limits belong to; motions checked must have exactly these.
    mean : float array (J, 4)
        Each joint's mean local rotation over the clean data (w first, w >= 0);
        for the root, of its rotation with the facing removed.
    low, high : float array (J, 3)
        Per-component bounds in degrees on ``degrees(2 log(mean^-1 q))``, the
        rotation vector of the joint relative to its mean. NaN: not limited.
    max_speed : float array (J,)
        Largest plausible angular speed in deg/s (geodesic angle between
        consecutive frames times fps). NaN: not limited.
    up : float array (3,)
        The vertical axis (a unit coordinate axis) about which the root's facing
        is removed.
    quantile, margin_deg, rate_quantile, rate_margin, min_speed : float
        The settings the limits were learnt with (see :func:`learn_joint_limits`).
    num_frames : int
        How many clean frames they were learnt from.
    """

    joint_names: tuple[str, ...]
    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    max_speed: np.ndarray
    up: np.ndarray
    quantile: float = 1.0
    margin_deg: float = 0.0
    rate_quantile: float = 1.0
    rate_margin: float = 1.0
    min_speed: float = 0.0
    num_frames: int = 0

    def __post_init__(self):
        names = tuple(str(n) for n in self.joint_names)
        object.__setattr__(self, "joint_names", names)
        J = len(names)
        for field_name, tail in (("mean", (4,)), ("low", (3,)), ("high", (3,)), ("max_speed", ()), ("up", None)):
            arr = np.array(getattr(self, field_name), dtype=np.float64)
            want = (3,) if tail is None else (J,) + tail
            if arr.shape != want:
                raise ValueError(f"JointLimits.{field_name}: expected shape {want}, got {arr.shape}")
            object.__setattr__(self, field_name, _readonly(arr))
        for field_name in ("quantile", "margin_deg", "rate_quantile", "rate_margin", "min_speed"):
            object.__setattr__(self, field_name, float(getattr(self, field_name)))
        object.__setattr__(self, "num_frames", int(self.num_frames))

    @property
    def num_joints(self) -> int:
        return len(self.joint_names)

    def save(self, path) -> None:
        """Write the limits to a ``.npz`` file (atomically; readable with ``allow_pickle=False``)."""
        arrays = dict(
            joint_names=np.array(self.joint_names, dtype=str),
            mean=self.mean,
            low=self.low,
            high=self.high,
            max_speed=self.max_speed,
            up=self.up,
            settings=np.array([self.quantile, self.margin_deg, self.rate_quantile, self.rate_margin, self.min_speed]),
            num_frames=np.array(self.num_frames, dtype=np.int64),
        )
        with atomic_write(path, "wb") as fh:
            np.savez(fh, **arrays)

    @classmethod
    def load(cls, path) -> "JointLimits":
        """Read limits written by :meth:`save`; a file that is not one raises ``ValueError``."""
        from ..io.npz import load_arrays

        z = load_arrays(path)  # checked before inflating
        need = {"joint_names", "mean", "low", "high", "max_speed", "up", "settings", "num_frames"}
        missing = sorted(need - set(z))
        if missing:
            raise ValueError(f"{path}: not a JointLimits file (missing {', '.join(missing)})")
        settings = z["settings"]
        if settings.shape != (5,):
            raise ValueError(f"{path}: not a JointLimits file (settings of shape {settings.shape})")
        q, margin, rq, rm, floor = (float(x) for x in settings)
        return cls(
            joint_names=tuple(str(n) for n in z["joint_names"]),
            mean=z["mean"],
            low=z["low"],
            high=z["high"],
            max_speed=z["max_speed"],
            up=z["up"],
            quantile=q,
            margin_deg=margin,
            rate_quantile=rq,
            rate_margin=rm,
            min_speed=floor,
            num_frames=int(z["num_frames"]),
        )


# -- representation ------------------------------------------------------------------


def _up_axis(skeleton: Skeleton) -> np.ndarray:
    """The coordinate axis closest to pelvis -> head in the rest pose (+Y when the rig has no head)."""
    up = np.zeros(3)
    try:
        rest = skeleton.rest_positions()
        d = rest[find_joint(skeleton, "head")] - rest[find_joint(skeleton, "pelvis")]
    except (KeyError, SkeletonError):
        up[1] = 1.0
        return up
    k = int(np.argmax(np.abs(d)))
    up[k] = 1.0 if d[k] >= 0 else -1.0
    return up


def _remove_facing(q: np.ndarray, up: np.ndarray) -> np.ndarray:
    """``t^-1 q`` where ``t`` is the twist of ``q`` about the world axis ``up``: the tilt left after facing.

    The twist is the projection of the quaternion onto ``(w, up)`` (swing-twist
    decomposition); where it is undefined (a pure 180 deg swing) it is the identity.
    """
    return R.quaternion_multiply(R.quaternion_conjugate(R.quaternion_twist(q, up)), q)


def _limit_rotations(motion: Motion, up: np.ndarray) -> np.ndarray:
    """Local rotations (F, J, 4) with the root's facing removed: the quantities limited by (a)."""
    rot = np.array(motion.rotations)
    rot[:, 0] = _remove_facing(rot[:, 0], up)
    return rot


def _mean_rotation(q: np.ndarray) -> np.ndarray:
    """Per-joint mean rotation (J, 4) of (N, J, 4) samples: principal eigenvector of sum q q^T (sign-free).

    All-missing joints get NaN.
    """
    finite = np.all(np.isfinite(q), axis=-1)
    z = np.where(finite[..., None], q, 0.0)
    m = np.einsum("nji,njk->jik", z, z)
    _, vecs = np.linalg.eigh(m)
    mean = vecs[..., -1]
    mean = np.where(mean[:, :1] < 0.0, -mean, mean)
    mean[~finite.any(axis=0)] = np.nan
    return mean


def rotation_components(motion: Motion, limits: JointLimits) -> np.ndarray:
    """The values baseline (a) limits: rotation vectors relative to each joint's mean, degrees, (F, J, 3).

    ``degrees(2 log(mean_j^-1 q_fj))``, the root's facing removed first. NaN where missing.
    """
    _check_names(motion, limits)
    rot = _limit_rotations(motion, limits.up)
    rel = R.quaternion_multiply(R.quaternion_conjugate(limits.mean)[None], rot)
    return np.degrees(R.quaternion_to_rotvec(rel))


def angular_speed(motion: Motion) -> np.ndarray:
    """Angular speed of every joint's local rotation between consecutive frames, deg/s, (F - 1, J).

    The geodesic angle between frames ``f`` and ``f + 1`` times fps; NaN where
    either is missing. For the root this includes its facing (a turn is motion).
    """
    q = motion.rotations
    if motion.num_frames < 2:
        return np.zeros((0, motion.num_joints))
    return np.degrees(R.geodesic_angle(q[:-1], q[1:])) * motion.fps


def _check_names(motion: Motion, limits: JointLimits) -> None:
    names = motion.skeleton.joint_names
    if names != limits.joint_names:
        extra = [n for n in names if n not in limits.joint_names][:5]
        raise ValueError(
            f"motion {motion.name!r} has joints that differ from the limits' "
            f"({len(names)} vs {limits.num_joints} joints{'; e.g. ' + ', '.join(extra) if extra else ', other order'})"
        )


def _nan_quantile(x: np.ndarray, q: float) -> np.ndarray:
    """Column quantiles of a (N, ...) array ignoring NaN; all-NaN columns give NaN (no warning)."""
    x = np.asarray(x, dtype=np.float64)
    out = np.full(x.shape[1:], np.nan)
    has = np.any(np.isfinite(x), axis=0)
    if np.any(has):
        out[has] = np.nanquantile(x[:, has], q, axis=0)
    return out


# -- learning ------------------------------------------------------------------------


def learn_joint_limits(
    motions: Sequence[Motion],
    quantile: float = 1.0,
    margin_deg: float = 15.0,
    rate_quantile: float = 1.0,
    rate_margin: float = 1.5,
    min_speed: float = 360.0,
    include_root: bool = True,
) -> JointLimits:
    """Learn rotation and rotation-rate limits from clean motions (Aristidou 6, baselines a and b).

    Rotation limits: per joint and per component of the rotation vector
    relative to the joint's mean (see :func:`rotation_components`), the
    ``1 - quantile`` and ``quantile`` quantiles over all clean frames, widened
    by ``margin_deg`` degrees on each side. Rate limits: per joint the
    ``rate_quantile`` quantile of the angular speed (deg/s) times
    ``rate_margin``, and at least ``min_speed`` (a joint barely moving in the
    clean data may still turn at a full turn per second; a 30 deg one-frame
    spike is 900 deg/s even at 30 fps). The defaults (the extremes seen, 15 deg
    and x1.5 of headroom) follow the paper's "searched over a large dataset of
    clean data to define the limits": on a small training set the headroom
    stands in for the clean motion not seen. Clean data with glitches of its
    own (CMU BVH thumbs turn 180 deg in a frame) calls for quantiles below 1.
    ``include_root=False`` leaves the root unlimited (NaN limits).

    ``motions`` must share joint names (same rig; actors may differ); their
    frame rates may differ. Raises ``ValueError`` otherwise or when there are
    no frames.
    """
    motions = list(motions)
    if not motions:
        raise ValueError("learn_joint_limits needs at least one clean motion")
    if not 0.5 < quantile <= 1.0 or not 0.0 < rate_quantile <= 1.0:
        raise ValueError(f"quantiles must lie in (0.5, 1] and (0, 1], got {quantile!r} and {rate_quantile!r}")
    if not (margin_deg >= 0 and rate_margin > 0 and min_speed >= 0):
        raise ValueError(
            "margin_deg and min_speed must be >= 0 and rate_margin > 0, "
            f"got {margin_deg!r}, {min_speed!r}, {rate_margin!r}"
        )
    first = motions[0]
    names = first.skeleton.joint_names
    for m in motions[1:]:
        if m.skeleton.joint_names != names:
            raise ValueError(
                f"motions must share joint names: {m.name!r} differs from {first.name!r} "
                f"({m.num_joints} vs {first.num_joints} joints)"
            )
    if sum(m.num_frames for m in motions) == 0:
        raise ValueError("learn_joint_limits: the clean motions have no frames")
    up = _up_axis(first.skeleton)
    rots = np.concatenate([_limit_rotations(m, up) for m in motions])
    mean = _mean_rotation(rots)
    rel = R.quaternion_multiply(R.quaternion_conjugate(mean)[None], rots)
    comps = np.degrees(R.quaternion_to_rotvec(rel))
    low = _nan_quantile(comps, 1.0 - quantile) - margin_deg
    high = _nan_quantile(comps, quantile) + margin_deg
    speeds = np.concatenate([angular_speed(m) for m in motions])
    max_speed = np.full(len(names), np.nan)
    if len(speeds):
        max_speed = _nan_quantile(speeds, rate_quantile) * rate_margin
        max_speed = np.where(np.isnan(max_speed), np.nan, np.maximum(max_speed, min_speed))
    if not include_root:
        low[0] = high[0] = max_speed[0] = np.nan
    return JointLimits(
        joint_names=names,
        mean=mean,
        low=low,
        high=high,
        max_speed=max_speed,
        up=up,
        quantile=quantile,
        margin_deg=margin_deg,
        rate_quantile=rate_quantile,
        rate_margin=rate_margin,
        min_speed=min_speed,
        num_frames=len(rots),
    )


# -- detection -----------------------------------------------------------------------


def detect_limits(motion: Motion, limits: JointLimits) -> np.ndarray:
    """Baseline (a): (F, J) True where a joint's rotation leaves its learnt per-component box.

    Missing cells and joints without limits are never flagged.
    """
    v = rotation_components(motion, limits)
    with np.errstate(invalid="ignore"):
        out = (v < limits.low[None]) | (v > limits.high[None])
    return np.any(out, axis=-1)


def detect_rate(motion: Motion, limits: JointLimits) -> np.ndarray:
    """Baseline (b): (F, J) True at both frames of every step faster than the joint's learnt speed limit.

    A step ``f -> f + 1`` whose angular speed exceeds ``max_speed`` flags both
    ``f`` and ``f + 1`` (which side is wrong cannot be told from the step alone).
    """
    _check_names(motion, limits)
    out = np.zeros((motion.num_frames, motion.num_joints), dtype=bool)
    speed = angular_speed(motion)
    with np.errstate(invalid="ignore"):
        fast = speed > limits.max_speed[None]
    out[:-1] |= fast
    out[1:] |= fast
    return out


def detect_baseline(motion: Motion, limits: JointLimits, kind: str = "c") -> np.ndarray:
    """Run baseline ``kind``: ``"a"`` rotation limits, ``"b"`` rate limits, ``"c"`` either (a OR b); (F, J) bool."""
    if kind == "a":
        return detect_limits(motion, limits)
    if kind == "b":
        return detect_rate(motion, limits)
    if kind == "c":
        return detect_limits(motion, limits) | detect_rate(motion, limits)
    raise ValueError(f"baseline kind must be one of {', '.join(BASELINE_KINDS)}, got {kind!r}")
