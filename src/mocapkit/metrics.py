"""Error measures of the four papers: geodesic pose error, joint-angle and joint-position RMS, mean joint distance, D_pv, precision/recall.

All measures compare two motions frame by frame (same skeleton, same number
of frames) and ignore NaN cells (missing data): sums and means run over the
cells that are finite in both (``nansum`` / ``nanmean``); a result with no
finite cell at all is NaN.
Lengths are reported in centimetres with the skeleton's unit scale
(:func:`mocapkit.motion.unit_scale_cm`) unless ``scale_cm`` is given.

Examples
--------
>>> import mocapkit
>>> from mocapkit import corrupt, metrics
>>> m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:240]
>>> bad, mask, _ = corrupt.real_errors(m, kinds=("spike", "flip"), n_errors=2, seed=0)
>>> detected = metrics.geodesic_pose_distance(m, bad) > 0.26   # 15 degrees
>>> metrics.precision_recall(detected, mask).as_dict()["recall"]
1.0
>>> float(metrics.pose_error(m, m).max()), metrics.d_pv(m, m)
(0.0, 0.0)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import rotations as R
from .errors import SkeletonError
from .io.euler_branches import three_axis_groups
from .rigs import pelvis_index
from .motion import Motion, unit_scale_cm, with_channels_of
from .words import plural

__all__ = [
    "geodesic_pose_distance",
    "pose_error",
    "pose_error_per_joint",
    "joint_angle_rms",
    "same_branch_channels",
    "joint_position_rms",
    "joint_position_mean",
    "d_pv",
    "d_pv_per_frame",
    "DetectionScore",
    "precision_recall",
    "word_precision_recall",
]


def _nanmean(x: np.ndarray, axis=None):
    """``np.nanmean`` without the all-NaN warning (the answer is NaN there)."""
    x = np.asarray(x, dtype=np.float64)
    n = np.sum(~np.isnan(x), axis=axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.nansum(x, axis=axis) / np.where(n > 0, n, np.nan)


def _check_pair(a: Motion, b: Motion) -> None:
    if not a.skeleton.is_compatible(b.skeleton):
        raise SkeletonError(f"cannot compare {a.name!r} and {b.name!r}: different skeletons")
    if a.num_frames != b.num_frames:
        raise SkeletonError(f"cannot compare {plural(a.num_frames, 'frame')} with {plural(b.num_frames, 'frame')}")


def geodesic_pose_distance(a: Motion, b: Motion) -> np.ndarray:
    """Rotation angle in radians, in [0, pi], between corresponding local joint rotations, (F, J).

    This is ``2 |log(q_a^-1 q_b)|`` (the full angle; ``quaternion_log`` gives
    half-angle vectors). NaN where either motion is missing the joint.
    """
    _check_pair(a, b)
    angle = R.geodesic_angle(a.rotations, b.rotations)
    # identical quaternions are exactly 0 apart (renormalisation would leave ~1e-16)
    same = np.all(a.rotations == b.rotations, axis=-1)
    return np.where(same, 0.0, angle)


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
    return _nanmean(half**2, axis=0)


def same_branch_channels(values: np.ndarray, ref: np.ndarray, skeleton) -> np.ndarray:
    """``values`` (F, C) with each joint's Euler triple on the branch nearest ``ref``'s (F, C), degrees.

    A rotation with middle angle ``x`` is also ``(z + 180, 180 - x, y + 180)`` (``-x`` for a repeated axis):
    near gimbal lock (``x`` near +-90) a few degrees of noise move the plain conversion to that other branch,
    and comparing it channel by channel with a take on the first branch counts two 180-deg "errors" for a
    rotation that turned a few degrees (a Bandai Namco ``Hips`` in a heading turn, ZXY with X through 90).
    :func:`mocapkit.rotations.nearest_euler` picks, cell by cell, the triple of the same rotation nearest
    ``ref``; position channels and joints with fewer than three rotation channels are returned as given.
    """
    out = np.array(values, dtype=np.float64)
    for order, idx in three_axis_groups(skeleton):  # idx (K, 3)
        out[:, idx] = R.nearest_euler(out[:, idx], ref[:, idx], order)
    return out


def joint_angle_rms(a: Motion, b: Motion, per_frame: bool = False, include_root: bool = True):
    """RMS difference in degrees over the joint-angle channels, as Mall et al. report it.

    Channels are the files' rotation channels (:meth:`Motion.channel_values`:
    BVH Euler angles, ASF degrees of freedom); differences are wrapped to
    [-180, 180) so a wrap-around is no error, and each joint's Euler triple of
    ``b`` is read on the branch nearest ``a``'s (:func:`same_branch_channels`) so
    the other branch of the same rotation is no error either. Root position
    channels never count; the root's rotation channels do unless
    ``include_root`` is False. Returns one float over all channels and frames,
    or with ``per_frame`` the RMS over channels of each frame (F,) (Mall's
    error-over-time plots). NaN channels are left out.
    """
    _check_pair(a, b)
    b = with_channels_of(b, a.skeleton)  # an AMC take and its BVH conversion: the same angles, other channels
    sk = a.skeleton
    rot = np.array(
        [c.endswith("rotation") and (include_root or j > 0) for j in range(sk.num_joints) for c in sk.joint_channels(j)],
        dtype=bool,
    )
    va = a.channel_values()
    d = va[:, rot] - same_branch_channels(b.channel_values(), va, sk)[:, rot]
    d = (d + 180.0) % 360.0 - 180.0
    if per_frame:
        return np.sqrt(_nanmean(d**2, axis=1))
    return float(np.sqrt(_nanmean(d**2)))


def _below_pelvis(skeleton, end_sites: bool = False) -> tuple[int, np.ndarray]:
    """The pelvis (by role) and the joints (K,) below it, in skeleton order; with ``end_sites``, also the end sites
    below it, indexed after the J joints (``J + e``), as in :meth:`~mocapkit.motion.Motion.global_positions`."""
    p = pelvis_index(skeleton)
    inside = np.zeros(skeleton.num_joints, dtype=bool)
    inside[p] = True
    for j in range(p + 1, skeleton.num_joints):
        inside[j] = inside[skeleton.parents[j]]
    ends = np.flatnonzero(inside[np.asarray(skeleton.end_site_parents, dtype=int)]) if end_sites else np.zeros(0, int)
    inside[p] = False
    return p, np.concatenate([np.flatnonzero(inside), skeleton.num_joints + ends])


def joint_position_rms(
    a: Motion, b: Motion, scale_cm: float | None = None, root_relative: bool | str = True, end_sites: bool = False
) -> float:
    """RMS joint-position error in cm over joints and frames: ``sqrt(mean |p_a - p_b|^2)``.

    ``end_sites``: the end sites (head top, toe tips, finger tips) count as joints too, so that an error in the
    rotation of a joint whose only child is an end site (the head, the toes) is seen; without it (the benchmarks'
    figure) only joints with channels count.

    ``root_relative``:

    - True (default): each motion's pelvis position is subtracted first, so a
      root trajectory error does not dominate; the pelvis itself (always zero
      then) and the joints above it are left out of the mean. The pelvis is
      found by its role (:func:`mocapkit.rigs.pelvis_index`): the root on
      Acclaim and most BVH rigs, ``Hips`` on the Bandai Namco rig, whose root
      stays on the floor;
    - ``"frame"``: positions in each motion's pelvis frame (pelvis position
      and rotation removed), as Tautges et al. evaluate reconstructions whose
      heading is free; the pelvis and above are left out too;
    - ``"heading"``: pelvis position and heading (the rotation about the
      vertical, :func:`mocapkit.features.root_frame`) removed, the pelvis's tilt
      kept: free heading, but a wrongly tilted pelvis counts;
    - ``"body"``: global positions of the pelvis and the joints below it (the
      body a reconstruction places in the markers' frame; a game rig's
      floor-bound root above the pelvis is left out);
    - ``"pelvis"``: the pelvis's global position alone;
    - False: global positions, all joints.

    Lengths are converted with ``scale_cm`` or :func:`unit_scale_cm` of
    ``a``'s skeleton. NaN joints are left out.
    """
    pa, pb, scale = _compared_positions(a, b, scale_cm, root_relative, end_sites)
    d2 = np.sum((pa - pb) ** 2, axis=-1)
    return float(np.sqrt(_nanmean(d2)) * scale)


def joint_position_mean(
    a: Motion, b: Motion, scale_cm: float | None = None, root_relative: bool | str = False, end_sites: bool = False
) -> float:
    """Mean joint-position error in cm over joints and frames: ``mean |p_a - p_b|``, the Euclidean distance.

    The measure of Krüger et al. 2010 (sec. 5.2, Table 3: "average (max) reconstruction errors (in cm per joint)", global
    positions; their six markers include the root, which places the body), and the six-marker figures of
    ``benchmarks/reconstruct_markers.py``. By default (``root_relative=False``) global positions of all
    joints, as there. :func:`joint_position_rms` squares before averaging, so on the same result it is
    larger wherever the error is uneven over joints and frames (about 1.5x on a six-marker reconstruction,
    whose hands and feet sit on their markers while elbows and knees miss). ``root_relative``,
    ``end_sites`` and ``scale_cm`` select and convert as in :func:`joint_position_rms`. NaN joints are left out.
    """
    pa, pb, scale = _compared_positions(a, b, scale_cm, root_relative, end_sites)
    return float(_nanmean(np.linalg.norm(pa - pb, axis=-1)) * scale)


def _compared_positions(a: Motion, b: Motion, scale_cm, root_relative, end_sites) -> tuple[np.ndarray, np.ndarray, float]:
    """The joint positions (F, J', 3) of ``a`` and ``b`` that :func:`joint_position_rms` and
    :func:`joint_position_mean` compare (their ``root_relative`` and ``end_sites``), and cm per unit."""
    _check_pair(a, b)
    if root_relative not in (True, False, "frame", "heading", "body", "pelvis"):
        raise ValueError(f"root_relative must be True, False, 'frame', 'heading', 'body' or 'pelvis', got {root_relative!r}")
    scale = unit_scale_cm(a.skeleton) if scale_cm is None else float(scale_cm)
    ga, pa = a.global_transforms()
    gb, pb = b.global_transforms()
    if end_sites:
        pa = np.concatenate([pa, a.end_sites_from(ga, pa)], axis=1)
        pb = np.concatenate([pb, b.end_sites_from(gb, pb)], axis=1)
    if root_relative in ("body", "pelvis"):
        p, below = _below_pelvis(a.skeleton, end_sites)
        keep = [p] if root_relative == "pelvis" else [p, *below]
        pa, pb = pa[:, keep], pb[:, keep]
    elif root_relative is not False:
        p, below = _below_pelvis(a.skeleton, end_sites)
        pa = pa[:, below] - pa[:, p : p + 1]
        pb = pb[:, below] - pb[:, p : p + 1]
        if root_relative == "frame":
            pa = R.quaternion_rotate(R.quaternion_conjugate(ga[:, p : p + 1]), pa)
            pb = R.quaternion_rotate(R.quaternion_conjugate(gb[:, p : p + 1]), pb)
        elif root_relative == "heading":
            from .features import root_frame

            pa = R.quaternion_rotate(R.quaternion_conjugate(root_frame(a)[0][:, None]), pa)
            pb = R.quaternion_rotate(R.quaternion_conjugate(root_frame(b)[0][:, None]), pb)
    return pa, pb, scale


def d_pv_per_frame(a: Motion, b: Motion, scale_cm: float | None = None) -> np.ndarray:
    """Tautges' per-frame term ``sum_j D^j(f)`` (eq. 2.24 summed over joints), (F,), in cm^4.

    ``d_pv(a, b) == sqrt(nansum(d_pv_per_frame(a, b)))``; see :func:`d_pv`.
    """
    _check_pair(a, b)
    sk = a.skeleton
    scale = unit_scale_cm(sk) if scale_cm is None else float(scale_cm)
    J = sk.num_joints
    # End sites are bone ends too: append them as extra points after the joints.
    pa = a.global_positions(end_sites=True) * scale
    pb = b.global_positions(end_sites=True) * scale
    kids: list[list[int]] = [[] for _ in range(J)]
    for c in range(1, J):
        kids[int(sk.parents[c])].append(c)
    for e, p in enumerate(sk.end_site_parents):
        kids[int(p)].append(J + e)
    triples = []  # (joint, a, b) for ordered pairs a != b
    for j in range(J):
        ends = list(kids[j])
        if len(ends) == 1 and sk.parents[j] >= 0:
            ends.append(int(sk.parents[j]))  # a chain joint: its bone to the parent and to the child
        triples += [(j, x, y) for x in ends for y in ends if x != y]
    F = a.num_frames
    if not triples:
        return np.zeros(F)
    j, x, y = (np.array(t) for t in zip(*triples))

    def cross(p):
        return np.cross(p[:, x] - p[:, j], p[:, y] - p[:, j])

    ca, cb = cross(pa), cross(pb)
    if F > 1:
        # central differences inside, one-sided at the ends (np.gradient), per second
        da = np.gradient(ca, 1.0 / a.fps, axis=0)
        db = np.gradient(cb, 1.0 / b.fps, axis=0)
    else:
        da, db = np.zeros_like(ca), np.zeros_like(cb)
    lengths = np.linalg.norm(pa[:, x] - pa[:, j], axis=-1) * np.linalg.norm(pa[:, y] - pa[:, j], axis=-1)
    denom = np.linalg.norm(da, axis=-1) + np.linalg.norm(db, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        dt = np.where(denom > 0, lengths / np.where(denom > 0, denom, 1.0), 0.0)  # eq. 2.22
    D = np.linalg.norm(ca - cb, axis=-1) + dt * np.linalg.norm(da - db, axis=-1)  # eqs. 2.19-2.21
    out = np.nansum(D**2, axis=1)
    out[np.all(np.isnan(D), axis=1)] = np.nan
    return out


def d_pv(a: Motion, b: Motion, scale_cm: float | None = None) -> float:
    """Tautges' D_pv (thesis 2.4, eqs. 2.13-2.24) between two motions, in cm^2 (the unit of the cross products).

    For every joint ``j`` and ordered pair of distinct bone ends ``a != b``
    hanging from it, the cross product ``c = v_{j->a} x v_{j->b}`` of the two
    bone vectors (eq. 2.13) and its time derivative ``c'`` (finite differences
    at the clip's fps) are compared: ``D = |c1 - c2| + dt |c1' - c2'|``
    (eqs. 2.19-2.21, the thesis' simplification of eq. 2.18) with
    ``dt = |v_a||v_b| / (|c1'| + |c2'|)`` (eq. 2.22, bone lengths of ``a``; 0
    where both derivatives vanish). ``D_pv = sqrt(sum_f sum_j sum_{a != b} D^2)``
    (eqs. 2.23/2.24); every unordered pair counts twice, as in eq. 2.24.

    Bone ends are child joints and end sites. A joint with a single bone end
    (a chain: elbow, knee) uses its parent joint as the second, so chains
    count too (the thesis' skeletons branch at every joint it evaluates); a
    joint with nothing hanging from it adds nothing, and zero-length bones add
    zero. Positions are in cm (``scale_cm`` or :func:`unit_scale_cm`).
    Invariant to a global translation, not to a global rotation (as the
    thesis notes). NaN terms are left out of the sum.
    """
    per_frame = d_pv_per_frame(a, b, scale_cm)
    if np.all(np.isnan(per_frame)) and per_frame.size:
        return float("nan")
    return float(np.sqrt(np.nansum(per_frame)))


@dataclass(frozen=True)
class DetectionScore:
    """Counts and rates of a detection against ground truth.

    Conventions for empty denominators: with nothing detected precision is 1
    (no false alarm), with nothing to find recall is 1; f1 is 0 when both
    precision and recall are 0.
    """

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

    def as_dict(self) -> dict:
        """Counts and rates as a plain dict (for JSON)."""
        return {"precision": self.precision, "recall": self.recall, "f1": self.f1, "tp": self.tp, "fp": self.fp, "fn": self.fn}


def _check_masks(detected, truth) -> tuple[np.ndarray, np.ndarray]:
    detected = np.asarray(detected, dtype=bool)
    truth = np.asarray(truth, dtype=bool)
    if detected.shape != truth.shape:
        raise ValueError(f"masks differ in shape: {detected.shape} vs {truth.shape}")
    return detected, truth


def precision_recall(detected: np.ndarray, truth: np.ndarray) -> DetectionScore:
    """Precision and recall per (frame, joint) cell of two boolean (F, J) masks (any equal shapes).

    ``detected`` is what a detector flagged, ``truth`` the ground truth (e.g. a
    corruption mask). See :class:`DetectionScore` for the empty cases.
    """
    detected, truth = _check_masks(detected, truth)
    return DetectionScore(
        tp=int(np.sum(detected & truth)), fp=int(np.sum(detected & ~truth)), fn=int(np.sum(~detected & truth))
    )


def motion_word_starts(F: int, word_length: int, stride: int) -> np.ndarray:
    """Starts of words of ``word_length`` frames every ``stride`` frames, plus one flush with the end."""
    if word_length < 1 or stride < 1:
        raise ValueError(f"word_length and stride must be at least 1, got {word_length} and {stride}")
    last = max(F - word_length, 0)
    starts = np.arange(0, last + 1, stride)
    if starts[-1] != last:
        starts = np.append(starts, last)  # so the last frames belong to a word too
    return starts


def _words(mask: np.ndarray, word_length: int, stride: int) -> np.ndarray:
    starts = motion_word_starts(mask.shape[0], word_length, stride)
    return np.stack([mask[s : s + word_length].any(axis=0) for s in starts])


def word_precision_recall(
    detected: np.ndarray,
    truth: np.ndarray,
    word_length: int = 15,
    stride: int = 5,
    per_joint: bool = True,
    ignore: np.ndarray | None = None,
) -> DetectionScore:
    """Precision and recall at motion-word level, as Aristidou et al. (section 6, Table 1) count them.

    Words are windows of ``word_length`` frames every ``stride`` frames (15 and
    5 in the paper, in frames of the clip as analysed; a last word flush with
    the clip's end is added when the stride does not reach it, so every frame
    is in some word). A word is positive when any of its cells is. The paper
    counts "joint rotation anomalies" in words ("words ... include at least
    one joint with erroneous rotations"), so by default the counts are over
    (word, joint) pairs: a detection must name the right joint in the right
    word. With ``per_joint=False`` a word is one item, positive if any joint
    is, and a detection only has to find the right word.

    ``ignore`` (F, J) bool marks cells whose ground truth is unknown or
    indifferent (a glitch already in the "clean" reference, a cell an injected
    error changed too little to see): the items (pairs, or words with
    ``per_joint=False``) holding one and no ``truth`` cell are not counted
    either way.
    """
    detected, truth = _check_masks(detected, truth)
    if detected.ndim != 2:
        raise ValueError(f"masks must be (F, J), got shape {detected.shape}")
    wd, wt = _words(detected, word_length, stride), _words(truth, word_length, stride)
    wi = np.zeros_like(wd) if ignore is None else _words(_check_masks(ignore, truth)[0], word_length, stride)
    if not per_joint:
        wd, wt, wi = wd.any(axis=1), wt.any(axis=1), wi.any(axis=1)
    keep = ~wi | wt
    return precision_recall(wd[keep], wt[keep])
