"""Error measures of the four papers: geodesic pose error, joint-angle and joint-position RMS, D_pv, precision/recall.

All measures compare two motions frame by frame (same skeleton, same number
of frames) and ignore NaN cells (missing data), averaging over what is left.
Lengths are reported in centimetres with the skeleton's unit scale
(:func:`mocapkit.motion.unit_scale_cm`) unless ``scale_cm`` is given.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import rotations as R
from .errors import SkeletonError
from .motion import Motion, unit_scale_cm

__all__ = [
    "geodesic_pose_distance",
    "pose_error",
    "pose_error_per_joint",
    "joint_angle_rms",
    "joint_position_rms",
    "d_pv",
    "DetectionScore",
    "precision_recall",
    "word_precision_recall",
]


def _check_pair(a: Motion, b: Motion) -> None:
    if not a.skeleton.is_compatible(b.skeleton):
        raise SkeletonError(f"cannot compare {a.name!r} and {b.name!r}: different skeletons")
    if a.num_frames != b.num_frames:
        raise SkeletonError(f"cannot compare {a.num_frames} frames with {b.num_frames} frames")


def geodesic_pose_distance(a: Motion, b: Motion) -> np.ndarray:
    """Rotation angle (radians) between corresponding local joint rotations, (F, J); NaN where missing."""
    _check_pair(a, b)
    return R.geodesic_angle(a.rotations, b.rotations)


def pose_error(a: Motion, b: Motion) -> np.ndarray:
    """Aristidou et al. eq. 2 per frame (F,): ``sum_k ||log(q_ak^-1 q_bk)||^2`` over joints.

    ``log`` is the pure-quaternion log whose norm is half the rotation angle,
    so a 90-degree error on one joint contributes ``(pi/4)^2``. Missing joints
    are left out of the sum (a frame with every joint missing gives NaN).
    """
    half = 0.5 * geodesic_pose_distance(a, b)
    out = np.nansum(half**2, axis=1)
    out[np.all(np.isnan(half), axis=1)] = np.nan
    return out


def pose_error_per_joint(a: Motion, b: Motion) -> np.ndarray:
    """Mean over frames of each joint's eq. 2 term ``||log(q_a^-1 q_b)||^2``, (J,)."""
    half = 0.5 * geodesic_pose_distance(a, b)
    with np.errstate(invalid="ignore"):
        return np.nanmean(half**2, axis=0)


def joint_angle_rms(a: Motion, b: Motion) -> float:
    """RMS difference in degrees over all joint-angle channels and frames, as Mall et al. report it.

    Channels are the files' rotation channels (:meth:`Motion.channel_values`);
    differences are wrapped to [-180, 180) so a wrap-around is no error.
    """
    _check_pair(a, b)
    names = a.channel_names()
    rot = np.array([n.endswith("rotation") for n in names])
    d = a.channel_values()[:, rot] - b.channel_values()[:, rot]
    d = (d + 180.0) % 360.0 - 180.0
    return float(np.sqrt(np.nanmean(d**2)))


def joint_position_rms(a: Motion, b: Motion, scale_cm: float | None = None, root_relative: bool = True) -> float:
    """RMS joint-position error in cm over joints and frames (root-relative by default).

    ``root_relative`` subtracts each motion's root position first, so a root
    trajectory error does not dominate; set it False for global positions.
    """
    _check_pair(a, b)
    scale = unit_scale_cm(a.skeleton) if scale_cm is None else float(scale_cm)
    pa, pb = a.global_positions(), b.global_positions()
    if root_relative:
        pa = pa - pa[:, :1]
        pb = pb - pb[:, :1]
    d2 = np.sum((pa - pb) ** 2, axis=-1)
    return float(np.sqrt(np.nanmean(d2)) * scale)


def d_pv(a: Motion, b: Motion, scale_cm: float | None = None) -> float:
    """Tautges' D_pv (thesis 2.4, eqs. 2.13-2.24) between two motions, in cm^2 units of the cross products.

    For every joint ``j`` with child joints ``a != b`` the cross product
    ``c = v_{j->a} x v_{j->b}`` of the two bone vectors (eq. 2.13) and its time
    derivative are compared: ``D = |c1 - c2| + dt |c1' - c2'|`` (eq. 2.19) with
    ``dt = |v_a||v_b| / (|c1'| + |c2'|)`` (eq. 2.22); D_pv is the square root
    of the sum of ``D^2`` over frames, joints and ordered child pairs (eqs.
    2.23/2.24). Joints with a single child use (parent, child) as their pair,
    so chains such as arms and legs count too (the thesis' skeletons branch
    at every joint it evaluates). Invariant to global translation, not to
    global rotation (as the thesis notes). Positions are in cm.
    """
    _check_pair(a, b)
    sk = a.skeleton
    scale = unit_scale_cm(sk) if scale_cm is None else float(scale_cm)
    pa, pb = a.global_positions() * scale, b.global_positions() * scale
    pairs = []
    for j in range(sk.num_joints):
        kids = sk.children(j)
        if len(kids) >= 2:
            pairs += [(j, x, y) for x in kids for y in kids if x != y]
        elif len(kids) == 1 and sk.parents[j] >= 0:
            p = int(sk.parents[j])
            pairs += [(j, kids[0], p), (j, p, kids[0])]
    if not pairs:
        return 0.0
    j, x, y = (np.array(t) for t in zip(*pairs))

    def cross(p):
        return np.cross(p[:, x] - p[:, j], p[:, y] - p[:, j])

    ca, cb = cross(pa), cross(pb)
    da = np.gradient(ca, 1.0 / a.fps, axis=0) if a.num_frames > 1 else np.zeros_like(ca)
    db = np.gradient(cb, 1.0 / b.fps, axis=0) if b.num_frames > 1 else np.zeros_like(cb)
    va = np.linalg.norm(pa[:, x] - pa[:, j], axis=-1) * np.linalg.norm(pa[:, y] - pa[:, j], axis=-1)
    denom = np.linalg.norm(da, axis=-1) + np.linalg.norm(db, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        dt = np.where(denom > 0, va / denom, 0.0)
    D = np.linalg.norm(ca - cb, axis=-1) + dt * np.linalg.norm(da - db, axis=-1)
    return float(np.sqrt(np.nansum(D**2)))


@dataclass(frozen=True)
class DetectionScore:
    """Counts and rates of a detection against ground truth."""

    tp: int
    fp: int
    fn: int

    @property
    def precision(self) -> float:
        return self.tp / (self.tp + self.fp) if self.tp + self.fp else 1.0

    @property
    def recall(self) -> float:
        return self.tp / (self.tp + self.fn) if self.tp + self.fn else 1.0

    @property
    def f1(self) -> float:
        p, r = self.precision, self.recall
        return 2 * p * r / (p + r) if p + r else 0.0


def precision_recall(detected: np.ndarray, truth: np.ndarray) -> DetectionScore:
    """Precision and recall per (frame, joint) cell of two boolean (F, J) masks.

    With nothing detected precision is 1; with nothing to find recall is 1.
    """
    detected = np.asarray(detected, dtype=bool)
    truth = np.asarray(truth, dtype=bool)
    if detected.shape != truth.shape:
        raise ValueError(f"masks differ in shape: {detected.shape} vs {truth.shape}")
    return DetectionScore(
        tp=int(np.sum(detected & truth)), fp=int(np.sum(detected & ~truth)), fn=int(np.sum(~detected & truth))
    )


def _words(mask: np.ndarray, word_length: int, stride: int) -> np.ndarray:
    F = mask.shape[0]
    starts = np.arange(0, max(F - word_length, 0) + 1, stride)
    return np.stack([mask[s : s + word_length].any(axis=0) for s in starts])


def word_precision_recall(
    detected: np.ndarray, truth: np.ndarray, word_length: int = 15, stride: int = 5
) -> DetectionScore:
    """Precision and recall at motion-word level, as Aristidou et al. Table 1 counts them.

    Words are windows of ``word_length`` frames every ``stride`` frames (15 and
    5 at 24 fps in the paper). A (word, joint) is positive when any of its
    cells is; the counts are over (word, joint) pairs, so a detection must
    name the right joint in the right word to count.
    """
    detected = np.asarray(detected, dtype=bool)
    truth = np.asarray(truth, dtype=bool)
    if detected.shape != truth.shape:
        raise ValueError(f"masks differ in shape: {detected.shape} vs {truth.shape}")
    return precision_recall(_words(detected, word_length, stride), _words(truth, word_length, stride))
