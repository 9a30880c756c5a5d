"""Self-similarity analysis for motion-capture cleaning (Aristidou, Cohen-Or, Hodgins, Shamir 2018).

A clip's joint rotations over time form a *motion texture* (section 3.1):
resampled to 24 fps, one row per joint, the root's heading removed so global
pose does not matter. *Motion words* are windows of it on groups of joints
(whole body, upper, lower, left, right): source words of 15 frames every 5
frames, target words of 20 frames at every frame. Each source word is compared
with every target word of a context (the clip itself, or related clips) by the
constrained DTW of the appendix over the pose distance of eq. 1
(:mod:`mocapkit.cleaning.word_dtw`); its K = 5 nearest neighbours are the K
smallest local minima of that distance function (section 3.3). The matched
part of each neighbour is resampled to the source word's length with a
polyphase filter, the neighbours are averaged into a *mean motion word*, and
overlapping mean words into the *mean motion texture*. Where a joint digresses
from it, the *movement digression map* (MDM, section 3.4) is high: that is an
error, or a motion the context has never seen.

:func:`detect` returns the MDM and the flags (MDM above a threshold) at the
input's frame rate; :func:`repair` replaces only flagged joints in flagged
frames by the median (medoid) of their neighbour words, blended with a
quadratic Savitzky-Golay filter (section 4).

Departures from the paper, and why:

- The MDM compares the input at its own frame rate with the mean texture
  upsampled from 24 fps, so a one-frame spike at 120 fps is seen even though
  the words are matched at 24 fps.
- A joint's digression is the rotation angle between the input and the mean
  texture; with several groups a joint belongs to, the group that explains it
  best (smallest digression) counts, so a motion that only a sub-group of the
  context repeats is not called an error (section 3.1's reason for groups).
- Row normalisation: the paper divides each joint's row by its mean, which
  puts every row's mean at the kernel's knee (``1 - e^-1 = 0.63 > 0.5``), so a
  clean clip would be flagged everywhere at the paper's own threshold. Rows
  are divided by ``row_scale`` times the row's median digression instead (the
  median is not pulled up by the errors themselves), with a floor of
  ``floor_deg`` so a joint that barely moves is not flagged for a
  fraction of a degree. ``normalization="mean"`` gives the paper's rule.
- Timing tolerance: a joint's digression at a frame is its smallest angle
  from the mean texture within ``shift_s`` (0.02 s) of that frame. The
  neighbours are time-warped on the whole group, so a fast joint (a knee in
  mid-swing) that leads or lags its group by a frame or two digresses by tens
  of degrees without being wrong; on the detection benchmark most false flags
  sat in the fastest quarter of each joint's motion. Spikes, flips and swaps
  are not explained by a 0.02 s shift.
- Confirmation (``confirm=True``, the default): a digression is flagged as an
  error only where the joint's own trajectory also breaks
  (:func:`discontinuities`: a step or one-frame spike no smooth motion makes)
  within ``confirm_margin_s`` of it. Without it the flags are the paper's,
  ``MDM > threshold``, and they also fire on every motion the context does
  not repeat (a gesture made once): on the detection benchmark, 79-87 % of
  its (word, joint) flags without a large context. A confirmed run is the
  connected cells of ``MDM > threshold / 2`` that reach ``threshold`` and
  hold a break, so the repair covers the error's whole extent; a run with
  two breaks or more is cut to the first and last of them, since beyond
  them the digression is the error's wake in the neighbour words. The price: an error that
  grows smoothly out of the motion and back (no step anywhere) is left
  unflagged; ``confirm=False`` finds it, with the false flags above.
  Confirmation also flags held joints (:func:`held_joints`): a joint held
  bit-still while its mean motion texture travels 10 degrees, a frozen
  channel whose digression is still small where it starts; and left/right
  label swaps (:func:`side_swaps`): a joint and its mirror partner breaking
  at the same frame and again within a second, which a swapped limb in a
  plausible pose shows though it hardly digresses; and transient offsets
  (:func:`transient_offsets`): a joint that steps off its own path and back
  by the opposite step within a second, a drift or flip between its two
  steps, flagged even where the context holds poses like the wrong ones (a
  drifted shoulder in a walk full of shoulder motion digressed under the
  threshold).
- "Median of the KNN": the medoid word (the neighbour closest to the others on
  the flagged joints), an actual motion, as the paper requires.

Examples
--------
>>> import mocapkit
>>> from mocapkit import corrupt
>>> from mocapkit.cleaning import ssa
>>> walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
>>> bad, mask, records = corrupt.real_errors(walk, kinds=("flip",), n_errors=1, seed=3)
>>> det = ssa.detect(bad)
>>> det.mdm.shape == det.flags.shape == (walk.num_frames, walk.num_joints)
True
>>> j = walk.skeleton.index(records[0].joint)
>>> bool(det.flags[records[0].start : records[0].end, j].any())
True
>>> fixed = ssa.repair(bad, det, foot_skate=False)   # foot_skate=True may also adjust planted legs
>>> bool((fixed.rotations[~det.flags] == bad.rotations[~det.flags]).all())
True
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
from scipy.signal import resample_poly, savgol_filter

from .. import rotations as R
from ..errors import SkeletonError
from ..features import detect_up_axis
from ..metrics import motion_word_starts
from ..motion import Motion, _side_and_part, bone_moving_joints, find_joint
from . import word_dtw
from .filters import window_frames
from .ik import contact_segments

__all__ = [
    "Contact",
    "Detection",
    "MotionTexture",
    "detect",
    "repair",
    "reconstruct_sparse",
    "motion_texture",
    "motion_words",
    "joint_groups",
    "informative_joints",
    "facing_aligned",
    "word_distance",
    "nearest_words",
    "mean_motion_texture",
    "movement_digression_map",
    "discontinuities",
    "confirm_flags",
    "held_joints",
    "side_swaps",
    "transient_offsets",
    "DEFAULTS",
]

#: The paper's parameters (section 5, "Implementation").
DEFAULTS = dict(
    fps=24.0,
    source_length=15,
    stride=5,
    target_length=20,
    min_width=11,
    max_run=3,
    k=5,
    joints=24,
    row_scale=3.0,
    floor_deg=20.0,
)

_LARGE_GROUP = 12  # groups with at least this many joints drop 3 joint terms, smaller ones 1


# -- motion texture ------------------------------------------------------------------


def facing_aligned(rotations: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Rotations (F, J, 4) with the root's heading (twist about ``up``) removed (section 3.2 footnote).

    The root keeps its tilt (the remaining 2 DOF), so anomalies on it are
    still visible; other joints are local rotations and unchanged.
    """
    out = np.array(rotations, dtype=np.float64)
    out[:, 0] = R.quaternion_multiply(R.quaternion_conjugate(R.quaternion_twist(out[:, 0], up)), out[:, 0])
    return out


def _moving_joints(skeleton) -> np.ndarray:
    """(J,) joints with rotation channels that move a bone (a child or end site at a non-zero offset)."""
    has = np.array([bool(skeleton.rotation_order(j)) for j in range(skeleton.num_joints)])
    out = bone_moving_joints(skeleton) & has
    out[0] = True  # the root: its tilt is analysed (heading removed)
    return out


def informative_joints(motions: Sequence[Motion], count: int = 24) -> np.ndarray:
    """The ``count`` most informative joints, sorted skeleton indices (section 5: "m = 24").

    Joints with rotation channels that move a bone, ranked by how much they
    rotate: the mean angle from their average rotation over all frames of
    ``motions`` (sharing one skeleton). The root is always kept. Joints that
    never move (fingers of most captures) come last. Left/right partners
    (:func:`mocapkit.motion.mirror_pairs`) are taken together, ranked by the
    one that rotates more, so the set does not depend on which hand moved
    more in the take and the left and right groups match (a swap, which
    :func:`side_swaps` finds, needs both joints); a last slot that no pair
    fits takes the next single joint, or else the half of a pair that
    rotates more.
    """
    from ..motion import mirror_pairs

    sk = motions[0].skeleton
    cand = np.flatnonzero(_moving_joints(sk))
    spread = np.zeros(sk.num_joints)
    for j in cand:
        qs = np.concatenate([R.quaternion_continuity(np.asarray(m.rotations[:, j])) for m in motions])
        qs = qs[np.all(np.isfinite(qs), axis=1)]
        if len(qs) == 0:
            continue
        mean = qs.mean(axis=0)
        if np.linalg.norm(mean) < 1e-9:
            spread[j] = np.pi
            continue
        mean = mean / np.linalg.norm(mean)
        spread[j] = float(np.mean(R.geodesic_angle(qs, mean)))
    perm = mirror_pairs(sk.joint_names)
    in_cand = np.zeros(sk.num_joints, dtype=bool)
    in_cand[cand] = True
    single = (perm == np.arange(sk.num_joints)) | ~in_cand[perm]
    units = [(int(j),) if single[j] else (int(j), int(perm[j])) for j in cand if single[j] or perm[j] > j]
    units.sort(key=lambda u: (0 not in u, -max(spread[list(u)]), min(u)))
    chosen: list[int] = []
    for u in units:
        if len(chosen) + len(u) <= int(count):
            chosen.extend(u)
    rest = sorted((j for j in cand if j not in chosen), key=lambda j: (-spread[j], j))
    chosen.extend(rest[: max(int(count) - len(chosen), 0)])  # a slot no pair fits and no single is left for
    return np.array(sorted(chosen), dtype=np.int64)


def joint_groups(skeleton, joints: Sequence[int] | None = None) -> dict[str, np.ndarray]:
    """The paper's joint groups (section 3.1) as skeleton indices within ``joints``.

    ``whole`` (all), ``upper`` (spine, head, arms), ``lower`` (root and legs),
    ``left`` and ``right`` (root and the joints of that side). Legs are the
    subtrees hanging from the root that hold the feet; sides come from joint
    names (``l``/``left`` prefixes and the like, as :func:`mocapkit.motion.mirror_pairs`).
    Groups with fewer than two joints are left out.
    """
    J = skeleton.num_joints
    joints = np.arange(J) if joints is None else np.asarray(joints, dtype=np.int64)
    parents = skeleton.parents
    leg = np.zeros(J, dtype=bool)
    for role in ("left_foot", "right_foot"):
        try:
            j = find_joint(skeleton, role)
        except KeyError:
            continue
        top = j
        while parents[top] > 0:
            top = int(parents[top])
        if parents[top] == 0 or top == j:
            for c in range(J):  # mark the subtree under `top`
                a = c
                while a > 0 and a != top:
                    a = int(parents[a])
                leg[c] |= a == top
    names = set(skeleton.joint_names)
    side = np.array([_side_and_part(n, names)[0] or "" for n in skeleton.joint_names])
    sel = np.zeros(J, dtype=bool)
    sel[joints] = True
    root = np.arange(J) == 0
    groups = {
        "whole": sel,
        "upper": sel & ~leg & ~root,
        "lower": sel & (leg | root),
        "left": sel & ((side == "left") | root),
        "right": sel & ((side == "right") | root),
    }
    return {k: np.flatnonzero(v) for k, v in groups.items() if v.sum() >= 2}


@dataclass(frozen=True, eq=False)
class MotionTexture:
    """Joint rotations of one or more clips as one texture (section 3.1).

    values : float (F, m, 4) unit quaternions, the root's heading removed,
    hemisphere-continuous in time; fps : frames per second; joints : (m,)
    skeleton indices of the rows; clip_starts : (C+1,) frame ranges of the clips
    stacked in ``values``; clip_names : (C,).
    """

    values: np.ndarray
    fps: float
    joints: np.ndarray
    clip_starts: np.ndarray
    clip_names: tuple

    @property
    def num_frames(self) -> int:
        return int(self.values.shape[0])

    def clip_of(self, frames: np.ndarray) -> np.ndarray:
        """Clip number of each frame index."""
        return np.searchsorted(self.clip_starts, np.asarray(frames), side="right") - 1

    def target_starts(self, length: int) -> np.ndarray:
        """Every frame where a word of ``length`` frames fits inside one clip."""
        out = [np.arange(a, b - length + 1) for a, b in zip(self.clip_starts[:-1], self.clip_starts[1:]) if b - a >= length]
        return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def motion_texture(motions, fps: float = 24.0, joints: Sequence[int] | None = None, up=None) -> MotionTexture:
    """Motion texture of one clip or of several clips stacked (same skeleton), resampled to ``fps``.

    ``joints`` selects rows (default: all); ``up`` is the vertical axis
    (default: :func:`mocapkit.features.detect_up_axis`).
    """
    if isinstance(motions, Motion):
        motions = [motions]
    motions = list(motions)
    sk = motions[0].skeleton
    up = detect_up_axis(sk) if up is None else np.asarray(up, dtype=np.float64)
    joints = np.arange(sk.num_joints) if joints is None else np.asarray(joints, dtype=np.int64)
    parts, starts = [], [0]
    for m in motions:
        r = m.resample(fps).rotations
        r = facing_aligned(r, up)[:, joints]
        parts.append(R.quaternion_continuity(r, axis=0))
        starts.append(starts[-1] + len(r))
    values = np.concatenate(parts) if parts else np.zeros((0, len(joints), 4))
    return MotionTexture(values, float(fps), joints, np.array(starts), tuple(m.name for m in motions))


def motion_words(num_frames: int, length: int = 15, stride: int = 5) -> np.ndarray:
    """First frames of the source words: every ``stride`` frames, plus one flush with the end (section 5)."""
    if num_frames < length:
        raise ValueError(f"a clip of {num_frames} frames is shorter than one motion word ({length} frames)")
    return motion_word_starts(num_frames, length, stride)


def word_distance(a: np.ndarray, b: np.ndarray, drop: int = 3, min_width: int = 11, max_run: int = 3):
    """Duration-invariant distance between two motion words (section 3.2 and appendix).

    a : (N, m, 4) source word, b : (M, m, 4) target word (N <= M), quaternions
    of the same joints. Returns ``(distance, i_end, j_end)``: the mean eq. 1
    cost (squared half-angle radians, ``drop`` largest joint terms ignored) over
    the matched frame pairs of the constrained DTW path, and where it ends.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    D = word_dtw.group_pose_distances(a, b, np.ones((1, a.shape[1]), dtype=bool), [drop])[0]
    return word_dtw.word_dtw(D, min_width=min_width, max_run=max_run)


# -- nearest neighbour words ---------------------------------------------------------


def _drop(members) -> int:
    """Joint terms eq. 1 ignores for a group: 3 of a large (whole-body) word, 1 of a small one (section 5)."""
    return 3 if len(members) >= _LARGE_GROUP else 1


@dataclass
class _Neighbors:
    """K nearest target words per (group, source word): positions in the context texture, DTW ends, distances."""

    pos: np.ndarray  # (G, W, K) int64, -1 = none
    iend: np.ndarray  # (G, W, K) int16
    jend: np.ndarray  # (G, W, K) int16
    dist: np.ndarray  # (G, W, K) float32


def _local_minima_knn(dist, tgt, k, exclude_center, half):
    """K smallest local minima per row of ``dist`` (W, T) over target starts ``tgt`` (T,) (section 3.3)."""
    W, T = dist.shape
    d = dist.astype(np.float64, copy=True)
    consecutive = np.zeros(T + 1, dtype=bool)
    consecutive[1:-1] = tgt[1:] == tgt[:-1] + 1
    left = np.full_like(d, np.inf)
    right = np.full_like(d, np.inf)
    left[:, 1:] = np.where(consecutive[None, 1:-1], d[:, :-1], np.inf)
    right[:, :-1] = np.where(consecutive[None, 1:-1], d[:, 1:], np.inf)
    is_min = (d <= left) & (d < right) & np.isfinite(d)
    if exclude_center is not None:  # minima of the whole function, then the source's own place left out
        is_min &= np.abs(tgt[None, :] - exclude_center[:, None]) > half
    cand = np.where(is_min, d, np.inf)
    kk = min(k, T)
    idx = np.argpartition(cand, kk - 1, axis=1)[:, :kk] if T > kk else np.tile(np.arange(T), (W, 1))
    vals = np.take_along_axis(cand, idx, axis=1)
    order = np.argsort(vals, axis=1, kind="stable")
    idx = np.take_along_axis(idx, order, axis=1)
    vals = np.take_along_axis(vals, order, axis=1)
    if kk < k:
        pad = k - kk
        idx = np.concatenate([idx, np.zeros((W, pad), dtype=idx.dtype)], axis=1)
        vals = np.concatenate([vals, np.full((W, pad), np.inf)], axis=1)
    return idx, vals


def _descriptors(values: np.ndarray, starts: np.ndarray, members: np.ndarray, length: int) -> np.ndarray:
    """Cheap word descriptors for the kd-tree prefilter: 6-D rotations of the group at 3 frames of the word."""
    offs = np.array([0, length // 2, length - 1])
    q = values[starts[:, None] + offs[None, :]][:, :, members]  # (P, 3, m, 4)
    mats = R.quaternion_to_matrix(q)[..., :, :2]  # first two columns: continuous, no sign ambiguity
    return mats.reshape(len(starts), -1)


def nearest_words(
    source: MotionTexture,
    context: MotionTexture,
    groups: Sequence[np.ndarray],
    word_starts: np.ndarray,
    k: int = 5,
    source_length: int = 15,
    target_length: int = 20,
    min_width: int = 11,
    max_run: int = 3,
    self_clip: int | None = 0,
    prefilter: bool = False,
    candidates: int = 48,
    chunk: int = 96,
    progress=None,
    exhaustive: bool = False,
) -> _Neighbors:
    """The K nearest target words of each source word, per joint group (section 3.3).

    groups : list of (m_g,) row indices into the textures' joints. With
    ``prefilter`` a kd-tree on cheap word descriptors (6-D rotations of three
    frames, reduced by PCA) proposes ``candidates`` target positions per source
    word and only those are ranked by DTW (section 7's suggestion); otherwise
    every target position is compared, and the neighbours are the K smallest
    local minima of the distance function, minima within N/2 frames of the
    source word in its own clip left out (found by
    :func:`~mocapkit.cleaning.word_dtw.word_knn_profile`, which skips the
    positions a lower bound proves too far: the same neighbours, 1.7x faster
    on a 20 s take and more on longer ones; ``exhaustive=True`` computes the whole distance function
    instead, the reference benchmarks/ssa_speed.py times it against). With the
    prefilter the source's own clip is left out a whole word either side,
    since sparse candidates cannot tell a minimum from the slope down into the
    source's own place. ``self_clip`` is the clip of
    ``context`` that ``source`` is (its neighbours closer than N/2 frames to the
    source word are excluded), or None.
    """
    N, M = source_length, target_length
    G, W = len(groups), len(word_starts)
    m = source.values.shape[1]
    drops = np.array([_drop(g) for g in groups])
    masks = np.zeros((G, m), dtype=bool)
    for gi, g in enumerate(groups):
        masks[gi, g] = True
    out = _Neighbors(
        np.full((G, W, k), -1, dtype=np.int64),
        np.zeros((G, W, k), dtype=np.int16),
        np.zeros((G, W, k), dtype=np.int16),
        np.full((G, W, k), np.inf, dtype=np.float32),
    )
    tgt = context.target_starts(M)
    if len(tgt) == 0 or W == 0:
        return out
    offset = int(context.clip_starts[self_clip]) if self_clip is not None else 0
    half = N // 2
    if prefilter:
        from ..search.knn import KNNIndex

        tclip = context.clip_of(tgt)
        for gi in range(G):
            desc_t = _descriptors(context.values, tgt, groups[gi], N)
            desc_s = _descriptors(source.values, word_starts, groups[gi], N)
            mean = desc_t.mean(axis=0)
            sample = desc_t[:: max(1, len(desc_t) // 20000)] - mean
            _, _, vt = np.linalg.svd(sample, full_matrices=False)
            basis = vt[: min(24, vt.shape[0])].T
            index = KNNIndex((desc_t - mean) @ basis)
            kq = min(candidates, len(tgt))
            _, cidx = index.query((desc_s - mean) @ basis, k=kq)
            cidx = np.where(cidx < 0, 0, cidx)
            src_rep = np.repeat(word_starts, kq)
            d, ie, je = word_dtw.word_distance_pairs(
                source.values, context.values, masks[gi], drops[gi], src_rep, tgt[cidx].ravel(), N, M, min_width, max_run
            )
            d = d.reshape(W, kq).astype(np.float64)
            pos = tgt[cidx]
            # sparse candidates cannot tell a minimum from the slope into the source's own place, so the
            # source's own clip is left out a whole word either side (not half a word, as with the full profile)
            lo = word_starts + offset - N if self_clip is not None else np.full(W, -1)
            hi = word_starts + offset + N + 1 if self_clip is not None else np.full(W, -1)
            chosen = word_dtw.select_separated_minima(d, pos, tclip[cidx], k, half + 1, lo, hi)
            for w in range(W):
                for kk in range(k):
                    p = chosen[w, kk]
                    if p < 0:
                        continue
                    c = int(np.flatnonzero(pos[w] == p)[0])
                    out.pos[gi, w, kk] = p
                    out.iend[gi, w, kk] = ie[w * kq + c]
                    out.jend[gi, w, kk] = je[w * kq + c]
                    out.dist[gi, w, kk] = d[w, c]
            if progress is not None:
                progress.update(W)
        return out
    for c0 in range(0, W, chunk):
        ws = word_starts[c0 : c0 + chunk]
        f0, f1 = int(ws.min()), int(ws.max()) + N
        D = word_dtw.group_pose_distances(source.values[f0:f1], context.values, masks, drops)
        for gi in range(G):
            excl = ws + offset if self_clip is not None else None
            if exhaustive:
                dist, ie, je = word_dtw.word_distance_profile(D[gi], ws - f0, tgt, N, M, min_width, max_run)
                idx, vals = _local_minima_knn(dist, tgt, k, excl, half)
                idx = np.where(np.isfinite(vals), idx, -1)
                ie = np.take_along_axis(ie, np.maximum(idx, 0), axis=1)
                je = np.take_along_axis(je, np.maximum(idx, 0), axis=1)
                vals = np.where(idx >= 0, vals, np.inf).astype(np.float32)
            else:
                idx, vals, ie, je = word_dtw.word_knn_profile(D[gi], ws - f0, tgt, k, excl, half, N, M, min_width, max_run)
            sl = slice(c0, c0 + len(ws))
            out.pos[gi, sl] = np.where(idx >= 0, tgt[np.maximum(idx, 0)], -1)
            out.iend[gi, sl] = ie
            out.jend[gi, sl] = je
            out.dist[gi, sl] = vals
        if progress is not None:
            progress.update(len(ws) * G)
    return out


def _neighbor_words(
    source_values, context: MotionTexture, members, drop, src_starts, pos, N, M, min_width=11, out_rows=None
) -> tuple[np.ndarray, np.ndarray]:
    """Neighbour words time-warped onto their source words' N frames (section 3.2), (P, N, m_g, 4).

    For each pair the constrained DTW path between the source word at
    ``src_starts[p]`` and the target word at ``pos[p]`` (on the rows
    ``members``, ignoring ``drop`` largest joint terms) is found; every source
    frame takes the mean of the target frames matched to it (the time-warped
    target). When the target word ran out first (path ending before the last
    source frame) the warped part is resized to N frames with the polyphase
    filter ``scipy.signal.resample_poly``, as the paper does. ``out_rows``
    warps other rows of the target along the path found on ``members``
    (sparse reconstruction: matched on a few joints, copied for all).

    Returns ``words`` (P, N, len(rows), 4) and ``ok`` (P,) bool (False where
    the target word does not fit its clip or no admissible path exists; those
    words are NaN). The DTW, path and warp run in one numba kernel
    (:func:`mocapkit.cleaning.word_dtw.warp_target_words`); the warped parts
    shorter than N frames are resized with ``resample_poly``, one call per length.
    """
    src_starts = np.asarray(src_starts, dtype=np.int64)
    pos = np.asarray(pos, dtype=np.int64)
    rows = members if out_rows is None else out_rows
    clip = context.clip_of(pos)
    fits = (pos >= 0) & (pos + M <= context.clip_starts[np.maximum(clip, 0) + 1])
    idx = np.flatnonzero(fits)
    words = np.full((len(pos), N, len(rows), 4), np.nan)
    ok = np.zeros(len(pos), dtype=bool)
    if len(idx) == 0:
        return words, ok
    warped, iend = word_dtw.warp_target_words(
        source_values, context.values, members, drop, src_starts[idx], pos[idx], N, M, min_width, 3, rows
    )
    for L in np.unique(iend[(iend >= 0) & (iend + 1 != N)]) + 1:
        sel = np.flatnonzero(iend + 1 == L)
        part = R.quaternion_continuity(warped[sel, :L], axis=1).reshape(len(sel), L, -1)
        warped[sel] = resample_poly(part, N, L, axis=1, padtype="line").reshape(len(sel), N, len(rows), 4)
    good = iend >= 0
    words[idx[good]] = R.quaternion_normalize(warped[good])
    ok[idx[good]] = True
    return words, ok


def _align(q: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``q`` with each quaternion's sign flipped into the hemisphere of ``ref``."""
    s = np.sign(np.sum(q * ref, axis=-1, keepdims=True))
    return q * np.where(s == 0, 1.0, s)


_NEIGHBOR_RATIO = 2.0  # neighbour words farther than this times the nearest's distance (+ 0.001) are not examples of it


def _near_neighbors(dist, best, ratio: float = _NEIGHBOR_RATIO):
    """Which word distances ``dist`` lie within ``ratio`` times the nearest one's, ``best`` (+ 0.001).

    When the context repeats a word fewer than K times, the other local
    minima are different motions, not examples of it: the mean texture
    leaves them out, and so does the repair's medoid.
    """
    return dist <= ratio * best + 1e-3


def _robust_means(words: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean word and spread of each source word's hemisphere-aligned neighbours, robust to outliers.

    words : (W, K, N, m, 4), valid : (W, K) which of the K are neighbours (at
    least one per row). Per cell the neighbours far from the cell's medoid
    (more than twice the median distance to it, plus 5 degrees) are left out of
    the chordal mean: a neighbour that overlaps an error of the clip itself (a
    long error outlasts the N/2 exclusion zone of section 3.3) must not pull
    the mean towards the error. Returns the means (W, N, m, 4) and the spread
    (W, N, m), the RMS angle of the kept neighbours from the mean in radians
    (0 where a word has one neighbour, whose word is the mean). The cell loop
    is :func:`mocapkit.cleaning.word_dtw.robust_word_means`.
    """
    return word_dtw.robust_word_means(words, valid, np.radians(5.0))


def _unseen_words(neighbors: _Neighbors, groups, max_word_angle_deg) -> np.ndarray:
    """Drop, in place, the neighbours of source words the context has nothing like; returns (G, W) bool of them.

    A word's nearest neighbour at eq. 1 distance ``d`` (the mean over matched
    frames of the summed squared half-angles of the group's joints, the
    ``drop`` largest left out) differs from it by an RMS joint angle of
    ``2 sqrt(d / (m_g - drop))``; above ``max_word_angle_deg`` the neighbours
    are other motions, their mean says nothing about errors, and the word is
    not judged (section 7: self-similarity needs the motion to have been seen).
    """
    G, W = neighbors.pos.shape[:2]
    unseen = np.zeros((G, W), dtype=bool)
    if max_word_angle_deg is None:
        return unseen
    for gi, members in enumerate(groups):
        terms = max(len(members) - _drop(members), 1)
        best = neighbors.dist[gi, :, 0].astype(np.float64)
        rms = np.degrees(2.0 * np.sqrt(np.maximum(best, 0.0) / terms))
        unseen[gi] = np.isfinite(best) & (rms > max_word_angle_deg)
    neighbors.pos[unseen] = -1
    neighbors.dist[unseen] = np.inf
    return unseen


def mean_motion_texture(
    source: MotionTexture,
    context: MotionTexture,
    groups,
    word_starts,
    neighbors: _Neighbors,
    source_length: int = 15,
    target_length: int = 20,
    return_spread: bool = False,
    neighbor_ratio: float = _NEIGHBOR_RATIO,
):
    """Mean motion texture per group, (G, F, m, 4) (section 3.4).

    Each source word's K neighbours (time-warped to N frames) are averaged into
    a mean motion word; overlapping mean words are averaged per frame. Rows of
    a group's non-members and frames no word covers are NaN. Averages of
    quaternions are the normalised sums of hemisphere-aligned values (the
    chordal mean), accurate for the nearby rotations averaged here.
    Neighbours whose word distance exceeds ``neighbor_ratio`` times the best
    one's (plus 0.001) are left out: when the context repeats a word only
    twice, the other local minima are different motions, not examples of it. With
    ``return_spread`` also the neighbours' spread (G, F, m): the RMS angle
    (radians) of the K words from their mean, averaged like the texture.
    """
    N = source_length
    G = len(groups)
    F, m = source.values.shape[:2]
    out = np.full((G, F, m, 4), np.nan)
    spread = np.full((G, F, m), np.nan)
    K = neighbors.pos.shape[2]
    for gi, members in enumerate(groups):
        acc = np.zeros((F, len(members), 4))
        sacc = np.zeros((F, len(members)))
        cnt = np.zeros(F)
        dists = neighbors.dist[gi]  # (W, K)
        best = np.min(dists, axis=1, keepdims=True).astype(np.float64)  # inf where a word has none: all pass
        use = (neighbors.pos[gi] >= 0) & _near_neighbors(dists, best, neighbor_ratio)
        wi, ki = np.nonzero(use)
        nws, ok = _neighbor_words(
            source.values, context, members, _drop(members), word_starts[wi], neighbors.pos[gi][wi, ki], N, target_length
        )
        # (W, K, N, m_g, 4) in neighbour order, each word's aligned with its first neighbour, not the
        # source: a broken source joint may sit 90 degrees away in quaternion space, where hemispheres
        # are arbitrary
        valid = np.zeros((len(word_starts), K), dtype=bool)
        valid[wi[ok], ki[ok]] = True
        stacked = np.zeros((len(word_starts), K, N, len(members), 4))
        stacked[wi[ok], ki[ok]] = nws[ok]
        has = valid.any(axis=1)
        first = np.argmax(valid, axis=1)
        stacked = _align(stacked, stacked[np.arange(len(word_starts)), first][:, None])
        means = np.zeros((len(word_starts), N, len(members), 4))
        spreads = np.zeros((len(word_starts), N, len(members)))
        for c0 in range(0, len(word_starts), 256):
            sl = np.flatnonzero(has[c0 : c0 + 256]) + c0
            if len(sl):
                means[sl], spreads[sl] = _robust_means(stacked[sl], valid[sl])
        for w, s in enumerate(word_starts):
            if not has[w]:
                continue
            mean_word, word_spread = means[w], spreads[w]
            ref = np.where(np.linalg.norm(acc[s : s + N], axis=-1, keepdims=True) > 0, acc[s : s + N], mean_word)
            acc[s : s + N] += _align(mean_word, ref)
            sacc[s : s + N] += word_spread
            cnt[s : s + N] += 1
        ok = cnt > 0
        vals = np.full((F, len(members), 4), np.nan)
        vals[ok] = R.quaternion_normalize(acc[ok])
        out[gi][:, members] = vals
        sp = np.full((F, len(members)), np.nan)
        sp[ok] = sacc[ok] / cnt[ok, None]
        spread[gi][:, members] = sp
    return (out, spread) if return_spread else out


# -- the movement digression map --------------------------------------------------------


def _upsample(q: np.ndarray, fps_from: float, n_out: int, fps_to: float) -> np.ndarray:
    """Quaternion tracks (F, ..., 4) at ``fps_from`` sampled at ``n_out`` frames of ``fps_to`` by slerp."""
    F = q.shape[0]
    t = np.arange(n_out) * (fps_from / fps_to)
    i0 = np.clip(np.floor(t).astype(np.int64), 0, F - 1)
    i1 = np.minimum(i0 + 1, F - 1)
    a = np.clip(t - i0, 0.0, 1.0).reshape((-1,) + (1,) * (q.ndim - 1))
    a0, a1 = q[i0], q[i1]
    a1 = _align(a1, a0)
    out = R.quaternion_normalize(a0 * (1 - a) + a1 * a)  # nlerp: the frames are 1/24 s apart
    return out


def movement_digression_map(
    digression: np.ndarray,
    normalization: str = "median",
    row_scale: float = 3.0,
    floor_deg: float = 20.0,
    z_scale: float = 2.5,
) -> np.ndarray:
    """MDM in [0, 1] from per-cell digressions (F, J) (section 3.4): ``1 - exp(-M^2)``.

    ``normalization`` says what ``digression`` holds and how rows are scaled:

    - ``"median"`` (default): angles in radians; each joint's row is divided by
      ``max(row_scale * row median, floor_deg)``.
    - ``"spread"``: digressions already divided by the neighbours' spread at
      the cell (:func:`detect`); ``M = digression / z_scale``.
    - ``"mean"``: angles; rows divided by their mean, as the paper writes it
      (every row's mean then sits at ``1 - e^-1 = 0.63``, above the paper's
      threshold of 0.5, so this flags a large share of any clip).

    NaN digressions (not analysed) give 0.
    """
    d = np.asarray(digression, dtype=np.float64)
    valid = np.isfinite(d)
    filled = np.where(valid, d, np.nan)
    any_valid = valid.any(axis=0)
    scale = np.full(d.shape[1], np.inf)
    if normalization == "spread":
        scale[:] = z_scale
    elif normalization == "mean":
        scale[any_valid] = np.nanmean(filled[:, any_valid], axis=0)
    elif normalization == "median":
        scale[any_valid] = np.maximum(row_scale * np.nanmedian(filled[:, any_valid], axis=0), np.radians(floor_deg))
    else:
        raise ValueError(f"normalization must be 'spread', 'median' or 'mean', got {normalization!r}")
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, np.inf)
    Mn = np.where(valid, d / scale, 0.0)
    return 1.0 - np.exp(-(Mn**2))


def discontinuities(motion: Motion, jump_deg: float = 8.0) -> np.ndarray:
    """(F, J) bool: frames where a joint's rotation leaves the smooth path through its two neighbours.

    The residual at frame f is the rotation angle between ``q[f]`` and the
    midpoint of ``q[f-1]`` and ``q[f+1]`` (their normalised sum). Smooth motion
    makes it second order in time, ``|alpha| dt^2 / 2``: under a degree at
    120 fps for a limb accelerating at 20,000 deg/s^2, about 11 deg at 30 fps.
    A step of s degrees gives s/2 at the frames on both sides of it, a
    one-frame spike its whole size; so ``jump_deg = 8`` marks steps of more
    than 16 deg and spikes of more than 8 deg. The first and last frames and
    missing cells are never marked. Used by :func:`confirm_flags`.
    """
    return _breaks(_midpoint_residuals(motion.rotations), jump_deg)


def _breaks(resid: np.ndarray, jump_deg: float) -> np.ndarray:
    """:func:`discontinuities` on midpoint residuals already computed (:func:`_midpoint_residuals`)."""
    if not (np.isfinite(jump_deg) and jump_deg > 0):
        raise ValueError(f"jump_deg must be a positive number of degrees, got {jump_deg!r}")
    return resid > np.radians(jump_deg)


def _midpoint_residuals(rotations: np.ndarray) -> np.ndarray:
    """(F, J) radians: angle between ``q[f]`` and the midpoint of ``q[f-1]``, ``q[f+1]``; 0 at the ends and where missing."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.zeros(q.shape[:2])
    if len(q) < 3:
        return out
    a, b, c = q[:-2], q[1:-1], q[2:]
    c = np.where((np.sum(a * c, axis=-1) < 0)[..., None], -c, c)
    mid = a + c
    norm = np.linalg.norm(mid, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        mid = mid / norm
        resid = R.geodesic_angle(b, mid)
    out[1:-1] = np.nan_to_num(resid, nan=0.0)
    return out


_SWAP_JUMP_DEG, _SWAP_MAX_S = 6.0, 1.0  # side_swaps' defaults, which detect uses


def side_swaps(motion: Motion, jump_deg: float = _SWAP_JUMP_DEG, max_s: float = _SWAP_MAX_S, joints=None) -> np.ndarray:
    """(F, J) bool: left/right label swaps, a joint and its mirror partner breaking together, twice.

    When the labels of the two sides swap, both joints of a left/right pair
    (:func:`mocapkit.motion.mirror_pairs`) jump at the same frame, and again
    when the labels swap back. A break here is a midpoint residual (see
    :func:`discontinuities`) over ``jump_deg`` and over ten times the joint's
    median residual in the take (at low frame rates fast motion has large
    residuals of its own). Where both joints of a pair break within a frame of
    each other, and again within ``max_s`` seconds, both are flagged from the
    frame after the first break's first frame to the second break's first
    frame (a step between frames f and f + 1 shows at both); the events pair
    up in time order. No smooth motion breaks like that, and no digression is
    needed: a swapped limb often takes a plausible pose. ``joints`` (bool (J,), optional) limits the
    pairs to those whose two joints it holds.
    """
    if not (np.isfinite(jump_deg) and jump_deg > 0 and max_s > 0):
        raise ValueError(f"need jump_deg > 0 and max_s > 0, got {jump_deg!r} and {max_s!r}")
    return _side_swaps(_midpoint_residuals(motion.rotations), motion.skeleton.joint_names, motion.fps, jump_deg, max_s, joints)


def _side_swaps(resid, joint_names, fps, jump_deg, max_s, joints) -> np.ndarray:
    """:func:`side_swaps` on midpoint residuals already computed (:func:`_midpoint_residuals`)."""
    from scipy import ndimage

    from ..motion import mirror_pairs

    F, J = resid.shape
    out = np.zeros((F, J), dtype=bool)
    use = np.ones(J, dtype=bool) if joints is None else np.asarray(joints, dtype=bool)
    breaks = resid > np.maximum(np.radians(jump_deg), 10.0 * np.median(resid, axis=0))[None, :]
    perm = mirror_pairs(joint_names)
    longest = int(round(max_s * fps))
    for j in range(J):
        p = int(perm[j])
        if p <= j or not (use[j] and use[p]):
            continue
        both = ndimage.binary_dilation(breaks[:, j], structure=np.ones(3, dtype=bool)) & breaks[:, p]
        frames = np.flatnonzero(both)
        if len(frames) < 2:
            continue
        for a, b in _paired_events([run[0] for run in _break_events(frames)], longest):
            out[a + 1 : b + 1, j] = out[a + 1 : b + 1, p] = True  # a step from f to f + 1 breaks at both
    return out


def _break_events(frames: np.ndarray) -> list[np.ndarray]:
    """Sorted break frames grouped into events: runs whose frames lie at most 3 apart."""
    return np.split(frames, np.flatnonzero(np.diff(frames) > 3) + 1)


def _paired_events(starts, longest: int, match=None) -> list[tuple[int, int]]:
    """Successive events paired in time order, ``(start k, start k + 1)``, where the second starts at most
    ``longest`` frames after the first and ``match(k, k + 1)`` holds (if given); a paired event is not paired
    again (:func:`side_swaps`, :func:`transient_offsets`)."""
    pairs, k = [], 0
    while k + 1 < len(starts):
        if starts[k + 1] - starts[k] <= longest and (match is None or match(k, k + 1)):
            pairs.append((int(starts[k]), int(starts[k + 1])))
            k += 2
        else:
            k += 1
    return pairs


_OFFSET_JUMP_DEG, _OFFSET_MAX_S, _OFFSET_MIN_DEG = 7.0, 1.0, 10.0  # transient_offsets' defaults, which detect uses


def transient_offsets(
    motion: Motion,
    jump_deg: float = _OFFSET_JUMP_DEG,
    max_s: float = _OFFSET_MAX_S,
    min_offset_deg: float = _OFFSET_MIN_DEG,
    joints=None,
) -> np.ndarray:
    """(F, J) bool: a joint that steps off its own path and steps back within ``max_s`` seconds.

    A drift, a flip or a marker lost and found again starts and ends as a
    step: the rotation leaves the path the previous frames were on by an
    offset, and later jumps back by about the opposite offset. The frames
    between the two steps are wrong whatever the digression says: a drifted
    shoulder in a walk full of shoulder motion, or a flipped wrist where the
    context's actors hold their wrists differently, can look like motion the
    context has seen. A break event is a run of midpoint residuals
    (:func:`discontinuities`) over ``jump_deg``, over ten times the joint's
    median residual in the take and over what its own motion reaches
    (:func:`_usual_residual`): at low frame rates fast motion has large
    residuals of its own; at 120 fps 7 deg means an angular acceleration of
    about 200,000 deg/s^2, ten times what a limb reaches.
    Its step is the rotation from where constant-velocity extrapolation of
    the two frames before the event puts the joint after it, to where the
    joint is (parent frame, a rotation vector); a one-frame spike returns
    within its event and has no step. Two successive events of a joint whose
    steps both exceed ``min_offset_deg``, point in roughly opposite
    directions (cosine at most -0.5; a half turn has no sign, so two steps
    near 180 deg pair either way) and start at most ``max_s`` apart are
    flagged from the frame after the first event's first frame to the second
    event's first frame (a step between frames f and f + 1 shows at both).
    Pairs are taken in time order, as in :func:`side_swaps`. ``joints`` (bool (J,),
    optional) limits the joints looked at.
    """
    if not (np.isfinite(jump_deg) and jump_deg > 0 and max_s > 0 and min_offset_deg >= 0):
        raise ValueError(
            f"need jump_deg > 0, max_s > 0 and min_offset_deg >= 0, got {jump_deg!r}, {max_s!r} and {min_offset_deg!r}"
        )
    q = np.asarray(motion.rotations, dtype=np.float64)
    return _transient_offsets(q, _midpoint_residuals(q), motion.fps, jump_deg, max_s, min_offset_deg, joints)


def _usual_residual(resid: np.ndarray) -> np.ndarray:
    """(J,) radians: what a joint's own motion reaches, three times its 95th-percentile midpoint residual.

    In a take under 160 frames the percentile is taken below the 8 largest
    residuals instead, so that one error's breaks (2 frames a step) do not
    raise it. At 120 fps this stays under the break thresholds; at 30 fps
    fast motion breaks too (a dancer's toes push off by 25 deg in one frame
    and come back), and a break must stand out from the joint's own motion.
    Used by :func:`transient_offsets` only: on a joint under heavy noise it
    rises past a flip's 90 deg residuals (``clean_takes``' neck: 134-214
    deg), and there confirmation by the digression still finds the error
    from the plain breaks.
    """
    F = resid.shape[0]
    return 3.0 * np.percentile(resid, min(95.0, 100.0 * (1.0 - 8.0 / F)), axis=0)


def _event_step(q: np.ndarray, first: int, last: int) -> np.ndarray | None:
    """Rotation vector (radians, parent frame) from the constant-velocity extrapolation of ``q[first - 2]``,
    ``q[first - 1]`` to ``q[last + 1]``, to ``q[last + 1]``; None where the event touches the take's ends."""
    if first < 2 or last + 1 >= len(q):
        return None
    a, b = q[first - 2], q[first - 1]
    if np.dot(a, b) < 0:
        a = -a
    velocity = R.quaternion_multiply(b, R.quaternion_inverse(a))
    pred = b
    for _ in range(last + 2 - first):
        pred = R.quaternion_multiply(velocity, pred)
    return R.quaternion_to_rotvec(R.quaternion_multiply(q[last + 1], R.quaternion_inverse(pred)))


def _transient_offsets(q, resid, fps, jump_deg, max_s, min_offset_deg, joints) -> np.ndarray:
    """:func:`transient_offsets` on rotations ``q`` (F, J, 4) with their midpoint residuals already computed."""
    F, J = resid.shape
    out = np.zeros((F, J), dtype=bool)
    use = np.ones(J, dtype=bool) if joints is None else np.asarray(joints, dtype=bool)
    usual = np.maximum(10.0 * np.median(resid, axis=0), _usual_residual(resid))
    breaks = resid > np.maximum(np.radians(jump_deg), usual)[None, :]
    longest = int(round(max_s * fps))
    half_turn = np.radians(150.0)
    for j in np.flatnonzero(use & breaks.any(axis=0)):
        frames = np.flatnonzero(breaks[:, j])
        starts, steps = [], []
        for run in _break_events(frames):
            step = _event_step(q[:, j], int(run[0]), int(run[-1]))
            if step is not None and np.linalg.norm(step) >= np.radians(min_offset_deg):
                starts.append(int(run[0]))
                steps.append(step)

        def back(k, m):  # the second step points roughly opposite the first (a half turn has no sign)
            na, nb = np.linalg.norm(steps[k]), np.linalg.norm(steps[m])
            cos = float(np.dot(steps[k], steps[m]) / (na * nb)) if na > 0 and nb > 0 else 1.0
            return cos <= -0.5 or (max(na, nb) > half_turn and abs(cos) >= 0.5)

        for a, b in _paired_events(starts, longest, back):
            out[a + 1 : b + 1, j] = True
    return out


def confirm_flags(
    mdm: np.ndarray, jumps: np.ndarray, threshold: float, fps: float, margin_s: float = 0.05, extent: float = 0.5
) -> np.ndarray:
    """Error flags (F, J) from an MDM confirmed by the joint's own discontinuities (see :func:`detect`).

    Per joint, a run is a connected stretch of frames with ``mdm > extent *
    threshold`` or within ``margin_s`` seconds of a ``jumps`` frame of the
    same joint (so the digression on the two sides of a break is one run);
    its cells with ``mdm > extent * threshold`` are flagged when it reaches
    ``mdm > threshold`` somewhere and one of them lies within the margin of
    the break. So every flagged run both digresses clearly and holds a
    break no smooth motion makes.
    A run that holds two breaks or more (separate steps or spikes) is cut
    to its first and last break, within ``margin_s``: an error starts and
    ends with a break, and beyond them the digression comes from the
    neighbour words the error itself led astray (a word spans 0.6 s), not
    from more error; repairing there replaced clean frames (a 60 deg knee
    error of 0.25 s on a walk flagged 1.7 s and the repair put clean frames
    68 deg off). A run with one break (a drift that grows smoothly and ends
    in a step) is kept whole. ``mdm`` float (F, J) in [0, 1]; ``jumps``
    bool (F, J).
    """
    from scipy import ndimage

    mdm = np.nan_to_num(np.asarray(mdm, dtype=np.float64))
    jumps = np.asarray(jumps, dtype=bool)
    if mdm.shape != jumps.shape or mdm.ndim != 2:
        raise ValueError(f"mdm and jumps must be the same (F, J) shape, got {mdm.shape} and {jumps.shape}")
    if not 0.0 < extent <= 1.0 or not margin_s >= 0:
        raise ValueError(f"need 0 < extent <= 1 and margin_s >= 0, got {extent!r} and {margin_s!r}")
    low = mdm > extent * threshold
    if not low.any():
        return low
    n = int(round(margin_s * fps))
    near = ndimage.binary_dilation(jumps, structure=np.ones((2 * n + 1, 1), dtype=bool)) if n > 0 else jumps
    along_time = np.array([[0, 1, 0], [0, 1, 0], [0, 1, 0]], dtype=bool)  # runs never join across joints
    # a run takes in the frames within the margin of a break, so the digression on both sides of a break joins
    labels, count = ndimage.label(low | near, structure=along_time)
    idx = np.arange(1, count + 1)
    peak = ndimage.maximum(mdm, labels, idx) > threshold
    broken = ndimage.maximum(near & low, labels, idx).astype(bool)  # a digressing frame within the margin of a break
    keep = np.concatenate([[False], peak & broken])
    out = keep[labels] & low
    for lab, (rows, cols) in enumerate(ndimage.find_objects(labels), start=1):
        if not keep[lab]:
            continue
        a, j = rows.start, cols.start
        at = np.flatnonzero(jumps[rows, j]) + a
        if (np.diff(at) > 2).any():  # two break events or more (a step marks two adjacent frames)
            out[a : max(at[0] - n, a), j] = False  # (a negative stop would count from the end)
            out[at[-1] + n + 1 : rows.stop, j] = False
    return out


def _flag_rule(mdm, jumps, holds, swaps, offsets, threshold: float, fps: float, confirm: bool, margin_s) -> np.ndarray:
    """The flags of :func:`detect` and :meth:`Detection.with_threshold`: confirmed digressions, holds, swaps and
    transient offsets, or the paper's ``mdm > threshold`` without confirmation."""
    if confirm:
        return confirm_flags(mdm, jumps, threshold, fps, margin_s) | holds | swaps | offsets
    return mdm > threshold


def _step_angles(q: np.ndarray) -> np.ndarray:
    """Rotation angle in radians between consecutive frames of unit quaternions (F, ...) -> (F - 1, ...).

    ``2 acos |q_f . q_f+1|`` over the norms: cheaper than
    :func:`mocapkit.rotations.geodesic_angle`, accurate to about 1e-7 rad near 0.
    """
    norm = np.linalg.norm(q, axis=-1)
    dot = np.abs(np.sum(q[1:] * q[:-1], axis=-1)) / (norm[1:] * norm[:-1])  # quaternions a little off unit length too
    return 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))


def held_joints(
    motion: Motion,
    mean_speed: np.ndarray,
    hold_deg_s: float = 0.5,
    min_s: float = 0.05,
    travel_deg: float = 10.0,
    recur_deg: float = 1.0,
    rest_deg: float = 0.01,
) -> np.ndarray:
    """(F, J) bool: joints held still where the mean motion texture says they move (a frozen channel).

    A hold is a run of at least ``min_s`` seconds in which the joint turns
    slower than ``hold_deg_s`` (a solver or tracker repeating the last value;
    live motion is never that still for long while the body moves on). It is
    flagged when the mean texture's speed ``mean_speed`` (F, J) deg/s at the
    input's frames (NaN: not analysed) adds up to at least ``travel_deg`` over
    it: the similar motion moves there, this joint does not. Holds that are
    motion, not errors, are left out: a joint held in more than half the
    take (it barely moves at all), frames where most analysed joints hold at
    once (a repeated frame: timing, not one joint), and a hold that recurs:
    the joint held again, in another hold of the take, within
    ``recur_deg`` of the same rotation (a joint limit the solver clamps at,
    such as a straight knee in every stride, or a rest pose). A frozen
    channel repeats the one value it last had; a limit is met again and
    again. Also left alone: a hold at the skeleton's rest pose (the joint's
    rotation within ``rest_deg`` of the identity, all its channels 0), where
    the CMU and HDM05 solvers clamp a straight knee (the pirouette's standing
    knee sits at exactly 0 for its last 2 s); a frozen channel repeats the
    arbitrary last value it had, never exactly the rest pose. Where a frozen
    joint starts the digression is still small; this finds it from the first
    held frame.
    """
    q = np.asarray(motion.rotations, dtype=np.float64)
    F, J = q.shape[:2]
    out = np.zeros((F, J), dtype=bool)
    mean_speed = np.asarray(mean_speed, dtype=np.float64)
    if mean_speed.shape != (F, J):
        raise ValueError(f"mean_speed must be (F, J) = {(F, J)}, got {mean_speed.shape}")
    if not (hold_deg_s > 0 and min_s >= 0 and travel_deg > 0 and recur_deg >= 0 and rest_deg >= 0):
        raise ValueError(
            f"need hold_deg_s > 0, min_s >= 0, travel_deg > 0, recur_deg >= 0 and rest_deg >= 0, "
            f"got {hold_deg_s!r}, {min_s!r}, {travel_deg!r}, {recur_deg!r}, {rest_deg!r}"
        )
    if F < 2:
        return out
    from scipy import ndimage

    analysed = np.isfinite(mean_speed).any(axis=0)
    speed = np.degrees(_step_angles(q)) * motion.fps
    still = (np.nan_to_num(speed, nan=np.inf) < hold_deg_s) & analysed[None, :]  # (F - 1, J) steps
    if not still.any():
        return out
    pose_hold = still[:, analysed].mean(axis=1) >= 0.5
    min_frames = max(2, int(np.ceil(min_s * motion.fps)))
    travel = np.nan_to_num(mean_speed) / motion.fps  # degrees per frame
    recur = np.radians(recur_deg)
    for j in np.flatnonzero(still.any(axis=0)):
        if still[:, j].mean() > 0.5:
            continue
        labels, count = ndimage.label(still[:, j] & ~pose_hold)
        runs = [(run.start, run.stop + 1) for (run,) in ndimage.find_objects(labels)]  # held frames a .. b - 1
        runs = [(a, b) for a, b in runs if b - a >= min_frames]
        if not runs:
            continue
        held = q[[a for a, _ in runs], j]  # (n, 4) the held rotations
        near = R.geodesic_angle(held[:, None], held[None, :]) <= recur
        np.fill_diagonal(near, False)
        at_rest = R.geodesic_angle(held, R.identity()) <= np.radians(rest_deg)
        for (a, b), exempt in zip(runs, near.any(axis=1) | at_rest):
            if not exempt and travel[a:b, j].sum() >= travel_deg:
                out[a:b, j] = True
    return out


# -- detection ------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Detection:
    """Result of :func:`detect`; everything (F, J) is at the input's frames and joint order.

    mdm : float (F, J) movement digression map in [0, 1] (0 on joints not analysed);
    flags : bool (F, J) the errors: ``mdm > threshold`` confirmed by ``jumps``
    (:func:`confirm_flags`), with ``holds``, ``swaps`` and ``offsets``; or ``mdm >
    threshold`` alone when the detection was made with ``confirm=False``; jumps : bool (F, J) the analysed joints'
    :func:`discontinuities`; holds, swaps, offsets : bool (F, J) their
    :func:`held_joints`, :func:`side_swaps` and :func:`transient_offsets`
    (flagged with confirmation at any threshold); digression : float (F, J) angle in
    radians between the input and the mean motion texture (NaN where not
    analysed); best_group : int8 (F, J) the group whose neighbours explain the
    cell best (-1 none). The rest records how the analysis was made so that
    :func:`repair` can fetch the neighbour words again.
    """

    mdm: np.ndarray
    flags: np.ndarray
    digression: np.ndarray
    best_group: np.ndarray
    threshold: float
    fps: float
    joint_names: tuple
    analysed: np.ndarray  # (J,) bool
    texture_joints: np.ndarray  # (m,) skeleton indices
    group_names: tuple
    group_masks: np.ndarray  # (G, m) bool
    word_starts: np.ndarray  # (W,) at the analysis rate
    neighbor_pos: np.ndarray  # (G, W, K)
    neighbor_iend: np.ndarray
    neighbor_jend: np.ndarray
    neighbor_dist: np.ndarray
    context_clips: tuple  # ((name, frames at the analysis rate), ...) of the context texture, clip 0 = the input
    jumps: np.ndarray  # (F, J) bool
    holds: np.ndarray  # (F, J) bool
    swaps: np.ndarray  # (F, J) bool
    offsets: np.ndarray  # (F, J) bool
    params: dict = field(default_factory=dict)
    notes: tuple = ()

    @property
    def num_frames(self) -> int:
        return int(self.mdm.shape[0])

    def segments(self) -> list[tuple[str, int, int]]:
        """Flagged runs as ``(joint name, start frame, end frame)``, half-open, sorted by start."""
        out = []
        for j in np.flatnonzero(self.flags.any(axis=0)):
            out += [(self.joint_names[j], a, b) for a, b in contact_segments(self.flags[:, j])]
        return sorted(out, key=lambda s: (s[1], s[0]))

    def with_threshold(self, threshold: float) -> "Detection":
        """The same analysis flagged at another threshold (confirmed by the jumps if the detection was)."""
        threshold = float(threshold)
        if not 0.0 < threshold < 1.0:
            raise ValueError(f"threshold must be in (0, 1), got {threshold}")
        flags = _flag_rule(self.mdm, self.jumps, self.holds, self.swaps, self.offsets, threshold, self.fps,
                           bool(self.params.get("confirm")), self.params.get("confirm_margin_s"))
        return dataclasses.replace(self, threshold=threshold, flags=flags)

    def save(self, path) -> Path:
        """Write as ``.npz`` (no pickles) through a temporary file and a rename."""
        from ..io import atomic_write

        arrays = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        meta = {
            "threshold": self.threshold,
            "fps": self.fps,
            "joint_names": list(self.joint_names),
            "group_names": list(self.group_names),
            "context_clips": [list(c) for c in self.context_clips],
            "params": self.params,
            "notes": list(self.notes),
        }
        for key in meta:
            arrays.pop(key)
        arrays["meta"] = np.array(json.dumps(meta))
        path = Path(path)
        with atomic_write(path, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        return path

    @classmethod
    def load(cls, path) -> "Detection":
        """Read a detection written by :meth:`save`."""
        from ..errors import MocapFormatError

        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}
            meta = json.loads(str(data.pop("meta")))
            for key in ("jumps", "holds", "swaps", "offsets"):  # written before these rules existed
                if key not in data:
                    data[key] = np.zeros(data["mdm"].shape, dtype=bool)
            return cls(
                **data,
                threshold=float(meta["threshold"]),
                fps=float(meta["fps"]),
                joint_names=tuple(meta["joint_names"]),
                group_names=tuple(meta["group_names"]),
                context_clips=tuple((str(n), int(f)) for n, f in meta["context_clips"]),
                params=dict(meta["params"]),
                notes=tuple(meta["notes"]),
            )
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise MocapFormatError(path, f"not a mocapkit detection file ({e})") from None


def _context_motions(motion: Motion, context) -> tuple[list[Motion], list[str]]:
    """Context as a list of Motions with the input's joints; clips that are the input itself are dropped."""
    notes = []
    if context is None:
        return [], notes
    from ..database import MotionDatabase

    if isinstance(context, MotionDatabase):
        motions = [context.clip(i) for i in range(context.num_clips)]
    elif isinstance(context, Motion):
        motions = [context]
    else:
        motions = list(context)
    out = []
    names = motion.skeleton.joint_names
    for c in motions:
        if not isinstance(c, Motion):
            raise TypeError(f"context must hold Motions or be a MotionDatabase, got {type(c).__name__}")
        if tuple(c.skeleton.joint_names) != tuple(names):
            raise SkeletonError(
                f"context clip {c.name!r}: its joints differ from {motion.name or 'the motion'}'s "
                f"({len(c.skeleton.joint_names)} vs {len(names)} joints, first difference "
                f"{next(((a, b) for a, b in zip(c.skeleton.joint_names, names) if a != b), ('-', '-'))}); "
                "retarget it first (MotionDatabase.build(joint_map=...))"
            )
        if c.name and c.name == motion.name and abs(c.duration - motion.duration) < 1.5 / min(c.fps, motion.fps):
            notes.append(f"context clip {c.name!r} is the input itself; left out")
            continue
        out.append(c)
    return out, notes


def _prepare(motion: Motion, context, fps, joints):
    if not isinstance(motion, Motion):
        raise TypeError(f"motion must be a Motion, got {type(motion).__name__}")
    if not np.all(np.isfinite(motion.rotations)):
        bad = np.flatnonzero(~np.all(np.isfinite(motion.rotations), axis=(1, 2)))
        raise ValueError(
            f"{motion.name or 'motion'}: {len(bad)} frames have missing rotations (first: {bad[0]}); fill the gaps first"
        )
    ctx, notes = _context_motions(motion, context)
    if isinstance(joints, (int, np.integer)):
        joints = informative_joints([motion] + ctx, int(joints))
    else:
        joints = np.array([motion.skeleton.index(j) if isinstance(j, str) else int(j) for j in joints])
    up = detect_up_axis(motion.skeleton)
    src = motion_texture(motion, fps, joints, up)
    full = motion_texture([motion] + ctx, fps, joints, up) if ctx else src
    return src, full, joints, up, notes


def _group_rows(groups, texture_joints) -> tuple[list[str], list[np.ndarray]]:
    pos = {int(j): i for i, j in enumerate(texture_joints)}
    names, rows = [], []
    for name, js in groups.items():
        r = np.array([pos[int(j)] for j in js if int(j) in pos], dtype=np.int64)
        if len(r) >= 2:
            names.append(name)
            rows.append(r)
    return names, rows


def _digression(motion, mean_tex, spread, texture_joints, up, fps_a, noise_deg, shift_s=0.0, speeds=False):
    """Per-group digression of the input (at its own rate) from the mean texture upsampled from ``fps_a``.

    With ``shift_s`` the angle at frame f is the smallest over the mean
    texture's frames within ``shift_s`` seconds of f: a timing tolerance.

    Returns ``(angle, z)``, both (G, F, m): the rotation angle in radians, and
    that angle over the neighbours' spread at the cell, ``sqrt(spread^2 +
    noise^2)`` with ``noise_deg`` the capture noise floor. With ``speeds``
    also the mean texture's angular speed at the input's frames, deg/s (G, F, m).
    """
    F = motion.num_frames
    inp = facing_aligned(motion.rotations, up)[:, texture_joints]
    G = mean_tex.shape[0]
    ang = np.full((G, F, len(texture_joints)), np.nan)
    z = np.full_like(ang, np.nan)
    t = np.arange(F) * (fps_a / motion.fps)
    src_t = np.arange(mean_tex.shape[1])
    noise = np.radians(noise_deg)
    speed = np.full_like(ang, np.nan) if speeds else None
    for g in range(G):
        up_q = _upsample(mean_tex[g], fps_a, F, motion.fps)
        if speeds and F > 1:
            step = np.degrees(_step_angles(up_q)) * motion.fps
            speed[g] = np.concatenate([step, step[-1:]])
        # timing tolerance: the smallest angle to the mean texture a few frames earlier or later
        a = word_dtw.shift_tolerant_angles(inp, up_q, int(round(shift_s * motion.fps)))
        ang[g] = a
        sp = np.stack([np.interp(t, src_t, spread[g][:, c]) for c in range(spread.shape[2])], axis=1)
        z[g] = a / np.sqrt(np.where(np.isfinite(sp), sp, 0.0) ** 2 + noise**2)
    return (ang, z, speed) if speeds else (ang, z)


def detect(
    motion: Motion,
    context=None,
    threshold: float = 0.5,
    *,
    groups: Mapping[str, Sequence] | None = None,
    joints: int | Sequence = 24,
    fps: float = 24.0,
    k: int = 5,
    source_length: int = 15,
    stride: int = 5,
    target_length: int = 20,
    two_stage: bool = False,
    screen_threshold: float = 0.3,
    prefilter: bool | None = None,
    candidates: int = 48,
    normalization: str = "median",
    z_scale: float = 2.5,
    noise_deg: float = 5.0,
    shift_s: float = 0.02,
    max_word_angle_deg: float | None = None,
    row_scale: float = 3.0,
    floor_deg: float = 20.0,
    confirm: bool = True,
    jump_deg: float = 8.0,
    confirm_margin_s: float = 0.05,
    hold_travel_deg: float = 10.0,
    progress: bool = False,
) -> Detection:
    """Movement digression map and error flags of ``motion`` by self-similarity (sections 3 and 5).

    Parameters
    ----------
    motion : Motion
        The take to analyse (any frame rate; no missing frames).
    context : None, list of Motions, or MotionDatabase
        Where to look for similar words besides the clip itself: None is local
        analysis; related clips (same joints) make a small or large context.
        A context clip with the input's name and length is the input itself and
        is left out.
    threshold : float
        MDM value above which a cell is flagged (0.5 in the paper).
    groups : dict name -> joint names or indices, optional
        Joint groups for motion words; default :func:`joint_groups` (whole,
        upper, lower, left, right).
    joints : int or sequence
        Analyse the ``joints`` most informative joints (24), or exactly these.
    two_stage : bool
        Section 5's two stages: local analysis of the whole body first, then the
        context with all groups only around words whose local MDM exceeds
        ``screen_threshold``.
    prefilter : bool or None
        Rank only kd-tree candidates by DTW (None: when the context holds more
        than 3,000 target words).
    normalization, row_scale, floor_deg
        MDM row normalisation (:func:`movement_digression_map`).
    shift_s : float
        Timing tolerance in seconds: the digression at a frame is the smallest
        angle from the mean texture within this time (module docstring).
    max_word_angle_deg : float or None
        Leave unjudged the words whose nearest neighbour differs by more than
        this RMS joint angle (the context has nothing like them; their flags
        would be guesses). None (the paper) judges every word;
        :func:`mocapkit.cleaning.pipeline.clean` uses 8 degrees.
    confirm, jump_deg, confirm_margin_s : bool, degrees, seconds
        Flag a digression only where the joint's own trajectory breaks
        (:func:`discontinuities` above ``jump_deg``) within
        ``confirm_margin_s`` of it (:func:`confirm_flags`; module docstring).
        ``confirm=False`` gives the paper's flags, ``mdm > threshold``.
        Confirmation also flags held joints (:func:`held_joints`): a joint
        held still while its mean motion texture travels ``hold_travel_deg``;
        left/right label swaps (:func:`side_swaps`); and transient offsets
        (:func:`transient_offsets`), a joint stepping off its path and back.
    """
    from tqdm.auto import tqdm

    if not 0.0 < threshold < 1.0:
        raise ValueError(f"threshold must be in (0, 1), got {threshold}")
    N, M = int(source_length), int(target_length)
    if not 2 <= N <= M:
        raise ValueError(f"need 2 <= source_length <= target_length, got {N} and {M}")
    min_width = min(11, N)
    if not (np.isfinite(confirm_margin_s) and confirm_margin_s >= 0):
        raise ValueError(f"confirm_margin_s must be >= 0 seconds, got {confirm_margin_s!r}")
    if not (np.isfinite(hold_travel_deg) and hold_travel_deg > 0):
        raise ValueError(f"hold_travel_deg must be a positive number of degrees, got {hold_travel_deg!r}")
    src, full, tex_joints, up, notes = _prepare(motion, context, fps, joints)
    resid = _midpoint_residuals(motion.rotations)  # for the breaks and the side swaps
    jumps = _breaks(resid, jump_deg)  # checks jump_deg before the analysis starts
    sk = motion.skeleton
    if groups is None:
        groups = joint_groups(sk, tex_joints)
    else:
        groups = {n: [sk.index(j) if isinstance(j, str) else int(j) for j in js] for n, js in groups.items()}
    gnames, grows = _group_rows(groups, tex_joints)
    if not gnames:
        raise ValueError("no joint group has two analysed joints")
    words = motion_words(src.num_frames, N, stride)
    W, G, m = len(words), len(grows), len(tex_joints)
    has_context = full is not src
    if prefilter is None:
        prefilter = has_context and len(full.target_starts(M)) > 3000
    opts = dict(k=k, source_length=N, target_length=M, min_width=min_width, max_run=3, candidates=candidates)
    neighbors = _Neighbors(
        np.full((G, W, k), -1, dtype=np.int64),
        np.zeros((G, W, k), dtype=np.int16),
        np.zeros((G, W, k), dtype=np.int16),
        np.full((G, W, k), np.inf, dtype=np.float32),
    )
    mean_tex = np.full((G, src.num_frames, m, 4), np.nan)
    spread = np.full((G, src.num_frames, m), np.nan)
    bar = tqdm(total=W * G * (2 if two_stage and has_context else 1), desc=f"ssa {motion.name or 'motion'}", disable=not progress, unit="word")
    try:
        if two_stage and has_context:
            whole = [gnames.index("whole")] if "whole" in gnames else [int(np.argmax([len(r) for r in grows]))]
            nb1 = nearest_words(src, src, [grows[i] for i in whole], words, self_clip=0, progress=bar, **opts)
            _unseen_words(nb1, [grows[i] for i in whole], max_word_angle_deg)
            mt1, sp1 = mean_motion_texture(src, src, [grows[i] for i in whole], words, nb1, N, M, return_spread=True)
            a1, z1 = _digression(motion, mt1, sp1, tex_joints, up, fps, noise_deg, shift_s)
            mdm1 = movement_digression_map(z1[0] if normalization == "spread" else a1[0], normalization, row_scale, floor_deg, z_scale)
            hot_frames = np.flatnonzero(mdm1.max(axis=1) > screen_threshold) * (fps / motion.fps)
            distinct = np.zeros(W, dtype=bool)
            for f in hot_frames:
                distinct |= (words <= f) & (f < words + N)
            # words overlapping the distinct ones, so every frame of the region keeps full word coverage
            region = np.zeros(src.num_frames, dtype=bool)
            for s in words[distinct]:
                region[s : s + N] = True
            redo = np.array([region[s : s + N].any() for s in words])
            for gi in whole:
                neighbors.pos[gi], neighbors.iend[gi] = nb1.pos[0], nb1.iend[0]
                neighbors.jend[gi], neighbors.dist[gi] = nb1.jend[0], nb1.dist[0]
                mean_tex[gi] = mt1[0]
                spread[gi] = sp1[0]
            if redo.any():
                sub = words[redo]
                nb2 = nearest_words(src, full, grows, sub, self_clip=0, prefilter=prefilter, progress=bar, **opts)
                _unseen_words(nb2, grows, max_word_angle_deg)
                for a in ("pos", "iend", "jend", "dist"):
                    getattr(neighbors, a)[:, redo] = getattr(nb2, a)
                mt2, sp2 = mean_motion_texture(src, full, grows, sub, nb2, N, M, return_spread=True)
                # region frames take the second stage; groups other than the whole body exist only there
                mean_tex[:, region] = mt2[:, region]
                spread[:, region] = sp2[:, region]
                for gi in range(G):
                    if gi not in whole:
                        mean_tex[gi, ~region] = np.nan
                        spread[gi, ~region] = np.nan
            notes.append(f"two-stage: {int(redo.sum())} of {W} words re-analysed against the context")
        else:
            nb = nearest_words(src, full, grows, words, self_clip=0, prefilter=prefilter and has_context, progress=bar, **opts)
            unseen = _unseen_words(nb, grows, max_word_angle_deg)
            if unseen.any():
                notes.append(
                    f"{int(unseen.any(axis=0).sum())} of {W} words have no neighbour within {max_word_angle_deg:g} deg "
                    "(RMS joint angle) in some joint group: not judged there"
                )
            neighbors = nb
            mean_tex, spread = mean_motion_texture(src, full, grows, words, nb, N, M, return_spread=True)
    finally:
        bar.close()
    dig_g, z_g, speed_g = _digression(motion, mean_tex, spread, tex_joints, up, fps, noise_deg, shift_s, speeds=True)  # (G, F, m)
    F, J = motion.num_frames, sk.num_joints
    filled = np.where(np.isnan(dig_g), np.inf, dig_g)
    best = np.argmin(filled, axis=0)  # (F, m): the group whose mean texture is closest
    dmin = np.take_along_axis(filled, best[None], axis=0)[0]
    smin = np.take_along_axis(z_g if normalization == "spread" else filled, best[None], axis=0)[0]
    smin = np.where(np.isfinite(dmin), smin, np.inf)
    ok = np.isfinite(smin)
    digression = np.full((F, J), np.nan)
    digression[:, tex_joints] = np.where(ok, dmin, np.nan)
    scores = np.full((F, J), np.nan)
    scores[:, tex_joints] = np.where(ok, smin, np.nan)
    best_group = np.full((F, J), -1, dtype=np.int8)
    best_group[:, tex_joints] = np.where(ok, best, -1)
    mean_speed = np.full((F, J), np.nan)
    mean_speed[:, tex_joints] = np.where(ok, np.take_along_axis(speed_g, best[None], axis=0)[0], np.nan)
    mdm = movement_digression_map(scores, normalization, row_scale, floor_deg, z_scale)
    analysed = np.zeros(J, dtype=bool)
    analysed[tex_joints] = True
    jumps &= analysed[None, :]
    holds = held_joints(motion, mean_speed, travel_deg=hold_travel_deg) & analysed[None, :]
    swaps = _side_swaps(resid, sk.joint_names, motion.fps, _SWAP_JUMP_DEG, _SWAP_MAX_S, analysed)
    offsets = _transient_offsets(
        np.asarray(motion.rotations, dtype=np.float64), resid, motion.fps, _OFFSET_JUMP_DEG, _OFFSET_MAX_S, _OFFSET_MIN_DEG, analysed
    )
    flags = _flag_rule(mdm, jumps, holds, swaps, offsets, threshold, motion.fps, confirm, confirm_margin_s)
    masks = np.zeros((G, m), dtype=bool)
    for gi, r in enumerate(grows):
        masks[gi, r] = True
    if not ok.all():
        notes.append(f"{int((~ok).any(axis=1).sum())} frames have no neighbour words (context too short)")
    clips = tuple((str(n), int(b - a)) for n, a, b in zip(full.clip_names, full.clip_starts[:-1], full.clip_starts[1:]))
    params = dict(
        fps=fps, k=k, source_length=N, stride=stride, target_length=M, two_stage=bool(two_stage and has_context),
        prefilter=bool(prefilter and has_context), normalization=normalization, z_scale=z_scale, noise_deg=noise_deg, shift_s=shift_s,
        max_word_angle_deg=max_word_angle_deg,
        row_scale=row_scale, floor_deg=floor_deg, confirm=bool(confirm), jump_deg=float(jump_deg),
        confirm_margin_s=float(confirm_margin_s), hold_travel_deg=float(hold_travel_deg),
    )
    return Detection(
        mdm=mdm, flags=flags, digression=digression, best_group=best_group, threshold=float(threshold),
        fps=motion.fps, joint_names=tuple(sk.joint_names), analysed=analysed, texture_joints=tex_joints,
        group_names=tuple(gnames), group_masks=masks, word_starts=words, neighbor_pos=neighbors.pos,
        neighbor_iend=neighbors.iend, neighbor_jend=neighbors.jend, neighbor_dist=neighbors.dist,
        context_clips=clips, jumps=jumps, holds=holds, swaps=swaps, offsets=offsets, params=params, notes=tuple(notes),
    )


# -- repair ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Contact:
    """An end-effector contact the repair must respect (section 4, Fig. 7).

    joint : name of the end effector (e.g. ``"lwrist"``); frames ``[start,
    end)`` of the input; position : (3,) world position in the file's units.
    """

    joint: str
    start: int
    end: int
    position: tuple

    def target(self) -> np.ndarray:
        return np.asarray(self.position, dtype=np.float64).reshape(3)


def _medoid(words: list[np.ndarray], cols: np.ndarray) -> int:
    """Index of the word closest to all others (sum of squared angles) on the rows ``cols``: the KNN's median."""
    if len(words) == 1:
        return 0
    X = np.stack([w[:, cols] for w in words])  # (K, N, c, 4)
    K = len(words)
    a, b = np.triu_indices(K, 1)
    pair = np.sum(R.geodesic_angle(X[a], X[b]) ** 2, axis=(1, 2))
    cost = np.zeros((K, K))
    cost[a, b] = cost[b, a] = pair
    return int(np.argmin(cost.sum(axis=1)))


def _blend_runs(orig: np.ndarray, new: np.ndarray, flags: np.ndarray, window: int) -> np.ndarray:
    """Smooth transitions into and out of replaced runs, changing only flagged frames (section 4).

    ``orig``, ``new`` (F, 4) one joint's track; ``flags`` (F,). Each run's
    replacement is first offset so that it meets the original at both ends
    (a displacement blended linearly across the run), then the hybrid track is
    filtered with a quadratic Savitzky-Golay filter of ``window`` frames, and
    only the flagged frames take the filtered values.
    """
    F = len(orig)
    out = np.array(orig)
    track = np.array(orig)
    for a, b in contact_segments(flags):
        rep = _align(new[a:b], np.broadcast_to(orig[a - 1] if a > 0 else new[a], new[a:b].shape))
        rep = R.quaternion_continuity(rep, axis=0)
        da = R.quaternion_log(R.quaternion_multiply(orig[a - 1], R.quaternion_inverse(rep[0]))) if a > 0 else np.zeros(3)
        db = R.quaternion_log(R.quaternion_multiply(orig[b], R.quaternion_inverse(rep[-1]))) if b < F else da * 0
        if a == 0:
            da = db
        if b == F:
            db = da
        u = (np.arange(a, b) - (a - 1)) / (b - (a - 1))
        delta = (1 - u)[:, None] * da + u[:, None] * db
        track[a:b] = R.quaternion_multiply(R.quaternion_exp(delta), rep)
    cont = R.quaternion_continuity(track, axis=0)
    if F >= window:
        smooth = savgol_filter(cont, window, 2, axis=0, mode="interp")
    else:
        smooth = cont
    smooth = R.quaternion_normalize(smooth)
    out[flags] = _align(smooth[flags], orig[flags])
    return out


def repair(
    motion: Motion,
    detection: Detection,
    context=None,
    *,
    contacts=None,
    foot_skate: bool = True,
    blend_s: float = 0.25,
) -> Motion:
    """Replace the flagged joints in flagged frames by the median of their KNN words (section 4).

    For each flagged cell the source word around the frame gives K neighbour
    words (in the group that explained the joint best); the medoid of those
    within twice the nearest one's DTW distance, as for the mean texture
    (the others are the next best of a context that repeats the motion
    fewer than K times, and a medoid of them picks a wrong motion), and
    never of a word of the take itself that spans a flagged cell of the
    joints repaired (it would copy the error back), on the word's flagged
    joints replaces the values (a flagged run no
    neighbour word covers is bridged by slerp between its ends, unflagged
    or already replaced, as a gap would be), which are blended into the
    untouched motion with a quadratic Savitzky-Golay filter (``blend_s``
    seconds). Every unflagged value is bit-identical to the input, except, with
    ``foot_skate``, the hip and knee of a leg whose joints were replaced in a
    frame where its foot is planted (foot-skate cleanup, see
    :func:`mocapkit.cleaning.ik.foot_skate_cleanup`). ``contacts`` (list of
    :class:`mocapkit.cleaning.ik.Contact`) picks, instead of the medoid, the
    neighbour word whose end effector comes closest to the contact point, and
    finishes with inverse kinematics. ``context`` must be the one the
    detection was made with.
    """
    if not isinstance(detection, Detection):
        raise TypeError(f"detection must be a Detection, got {type(detection).__name__}")
    if detection.num_frames != motion.num_frames or tuple(motion.skeleton.joint_names) != detection.joint_names:
        raise ValueError(
            f"{motion.name or 'motion'}: the detection was made on another clip "
            f"({detection.num_frames} frames, {len(detection.joint_names)} joints vs "
            f"{motion.num_frames} frames, {motion.num_joints} joints)"
        )
    flags = np.asarray(detection.flags, dtype=bool) & detection.analysed[None, :]
    if not flags.any():
        return motion
    p = detection.params
    fps_a, N = float(p["fps"]), int(p["source_length"])
    src, full, _, up, _ = _prepare(motion, context, fps_a, detection.texture_joints)
    clips = tuple((str(n), int(b - a)) for n, a, b in zip(full.clip_names, full.clip_starts[:-1], full.clip_starts[1:]))
    if clips != detection.context_clips:
        raise ValueError(
            f"{motion.name or 'motion'}: repair needs the context the detection was made with "
            f"({len(detection.context_clips) - 1} context clips, got {len(clips) - 1})"
        )
    tex_joints = detection.texture_joints
    col = {int(j): i for i, j in enumerate(tex_joints)}
    words = detection.word_starts
    F = motion.num_frames
    tau = np.arange(F) * (fps_a / motion.fps)  # analysis time of each input frame
    centers = words + (N - 1) / 2.0
    # the source word around each input frame: the one whose centre is nearest
    word_of = np.argmin(np.abs(tau[:, None] - centers[None, :]), axis=1)
    groups = [np.flatnonzero(detection.group_masks[g]) for g in range(len(detection.group_names))]
    new = np.array(motion.rotations)
    placed = np.zeros(flags.shape, dtype=bool)  # the flagged cells a neighbour word was written into
    heading = R.quaternion_twist(motion.rotations[:, 0], up)
    flagged_frames_by_word: dict[tuple[int, int], list] = {}
    fi, ji = np.nonzero(flags)
    for f, j in zip(fi, ji):
        g = int(detection.best_group[f, j])
        if g < 0:
            continue
        flagged_frames_by_word.setdefault((g, int(word_of[f])), []).append((f, j))
    # every neighbour word the repair needs, warped in one batch per group
    M = int(p["target_length"])
    warped: dict[tuple[int, int], list[tuple[np.ndarray, float, int]]] = {}  # (word, DTW distance, position)
    for g in sorted({g for g, _ in flagged_frames_by_word}):
        ws = np.array(sorted({w for gg, w in flagged_frames_by_word if gg == g}), dtype=np.int64)
        pos = detection.neighbor_pos[g, ws]  # (n, K)
        wi, ki = np.nonzero(pos >= 0)
        members = groups[g]
        nws, ok = _neighbor_words(src.values, full, members, _drop(members), words[ws[wi]], pos[wi, ki], N, M)
        dist = detection.neighbor_dist[g, ws][wi, ki]
        for q in np.flatnonzero(ok):
            warped.setdefault((g, int(ws[wi[q]])), []).append((nws[q], float(dist[q]), int(pos[wi[q], ki[q]])))
    # the take's own flagged cells at the analysis rate (+-1 frame): a neighbour word from the take that
    # spans one of them on a joint to repair would copy the error back (the rest of a long error, a
    # repeated glitch)
    n_self = int(full.clip_starts[1])
    flagged_a = np.zeros((n_self + 1, flags.shape[1]), dtype=bool)
    np.logical_or.at(flagged_a, np.clip(np.round(tau).astype(np.int64), 0, n_self), flags)
    flagged_a[1:] |= flagged_a[:-1].copy()
    flagged_a[:-1] |= flagged_a[1:].copy()
    for (g, w), cells in flagged_frames_by_word.items():
        members = groups[g]
        fs = np.array([f for f, _ in cells], dtype=np.int64)
        js = np.array([j for _, j in cells], dtype=np.int64)
        here = np.unique(js)
        found = [(nw, d) for nw, d, q in warped.get((g, w), []) if not (q < n_self and flagged_a[q : q + M, here].any())]
        if not found:
            continue
        nearest = min(d for _, d in found)
        words_k = [nw for nw, d in found if _near_neighbors(d, nearest)]
        cs = np.searchsorted(members, [col[int(j)] for j in js])  # the cells' rows within the word
        flagged_cols = np.unique(cs)
        x = np.clip(tau[fs] - words[w], 0.0, N - 1.0)
        i0 = np.floor(x).astype(np.int64)
        i1 = np.minimum(i0 + 1, N - 1)
        a = (x - i0)[:, None]
        root = js == 0

        def place(word, target, fs=fs, js=js, cs=cs, i0=i0, i1=i1, a=a, root=root):
            """Write ``word`` (N, m_g, 4) into ``target`` at the flagged cells, interpolated to their frames."""
            q0 = word[i0, cs]
            q1 = _align(word[i1, cs], q0)
            q = R.quaternion_normalize(q0 * (1 - a) + q1 * a)
            if root.any():
                q[root] = R.quaternion_multiply(heading[fs[root]], q[root])
            target[fs, js] = _align(q, motion.rotations[fs, js])

        choice = None
        if contacts:
            choice = _closest_to_contacts(motion, words_k, place, cells, contacts)
        if choice is None:
            choice = _medoid(words_k, flagged_cols)
        place(words_k[choice], new)
        placed[fs, js] = True
    # a flagged run no neighbour word was written into is bridged like a gap: slerp between its ends,
    # unflagged or already replaced (blending its own values towards the ends would bend a 180-degree
    # flip, not undo it)
    for j in np.flatnonzero((flags & ~placed).any(axis=0)):
        for a, b in contact_segments(flags[:, j] & ~placed[:, j]):
            lo = new[a - 1, j] if a > 0 else None
            hi = new[b, j] if b < F else None
            if lo is None and hi is None:
                continue
            lo = hi if lo is None else lo
            hi = lo if hi is None else hi
            u = (np.arange(a, b) - (a - 1)) / (b - (a - 1))
            new[a:b, j] = R.slerp(np.broadcast_to(lo, (b - a, 4)), np.broadcast_to(hi, (b - a, 4)), u)
            placed[a:b, j] = True
    window = window_frames(blend_s, motion.fps, 2)
    out_rot = np.array(motion.rotations)
    for j in np.flatnonzero(placed.any(axis=0)):
        out_rot[:, j] = _blend_runs(motion.rotations[:, j], new[:, j], placed[:, j], window)
    out = dataclasses.replace(motion, rotations=out_rot)
    if contacts:
        from . import ik

        for c in contacts:
            frames = np.arange(max(c.start, 0), min(c.end, F))
            if len(frames):
                out = ik.two_bone_ik(out, c.joint, c.target(), frames=frames)
    if foot_skate:
        out = _foot_skate(motion, out, flags)
    return out


def _closest_to_contacts(motion, words_k, place, cells, contacts) -> int | None:
    """The neighbour word whose end effectors come closest to the contact points (section 4), or None."""
    frames = np.array(sorted({f for f, _ in cells}))
    relevant = [c for c in contacts if np.any((frames >= c.start) & (frames < c.end))]
    if not relevant:
        return None
    costs = []
    for word in words_k:
        trial = np.array(motion.rotations)
        place(word, trial)
        pos = dataclasses.replace(motion, rotations=trial).global_positions()
        cost = 0.0
        for c in relevant:
            fr = frames[(frames >= c.start) & (frames < c.end)]
            cost += float(np.sum(np.linalg.norm(pos[fr, motion.skeleton.index(c.joint)] - c.target(), axis=-1)))
        costs.append(cost)
    return int(np.argmin(costs))


def _foot_skate(original: Motion, repaired: Motion, flags: np.ndarray) -> Motion:
    """Foot-skate cleanup on frames where a leg joint was replaced (Lyard & Magnenat-Thalmann 2007)."""
    try:
        from . import ik
    except ImportError:  # pragma: no cover
        return repaired
    sk = original.skeleton
    leg_frames = np.zeros(original.num_frames, dtype=bool)
    for role in ("left_foot", "right_foot"):
        try:
            foot = find_joint(sk, role)
        except KeyError:
            continue
        chain = [foot]
        while sk.parents[chain[-1]] > 0:
            chain.append(int(sk.parents[chain[-1]]))
        leg_frames |= flags[:, chain].any(axis=1)
    if not leg_frames.any():
        return repaired
    try:
        contacts = ik.foot_contacts(original)
    except (KeyError, ValueError, SkeletonError):
        return repaired
    return ik.foot_skate_cleanup(repaired, frames=leg_frames, contacts=contacts)


# -- sparse reconstruction ------------------------------------------------------------------


def reconstruct_sparse(
    sparse: Motion,
    joints: Sequence,
    context,
    *,
    fps: float = 24.0,
    k: int = 5,
    source_length: int = 15,
    target_length: int = 20,
    blend_s: float = 0.25,
    progress: bool = False,
) -> Motion:
    """Full-body motion from a few joints' rotations and a context of full-body clips (section 4, Fig. 8).

    ``sparse`` holds the skeleton and the rotations of ``joints`` (names or
    indices; the other joints' values are ignored and may be NaN). Its words
    (non-overlapping, ``source_length`` frames) are matched on those joints
    against ``context`` (list of Motions or a MotionDatabase, same joints);
    the first output word is the nearest neighbour of the first input word,
    and each next one is the candidate among the next word's K neighbours
    whose first frame is closest (eq. 1, all joints) to the last frame of the
    word chosen before. The chain is upsampled to the input's frame rate,
    its transitions smoothed with a quadratic Savitzky-Golay filter, and the
    given joints keep their input values exactly. The root trajectory is the
    input's where it is finite.
    """
    from tqdm.auto import tqdm

    sk = sparse.skeleton
    known = np.array(sorted({sk.index(j) if isinstance(j, str) else int(j) for j in joints}), dtype=np.int64)
    if len(known) < 2:
        raise ValueError("sparse reconstruction needs at least two known joints")
    if not np.all(np.isfinite(sparse.rotations[:, known])):
        raise ValueError(f"{sparse.name or 'motion'}: the known joints have missing rotations; fill the gaps first")
    ctx, _ = _context_motions(sparse, context)
    if not ctx:
        raise ValueError("sparse reconstruction needs a context of full-body clips")
    N, M = int(source_length), int(target_length)
    up = detect_up_axis(sk)
    all_rows = np.arange(sk.num_joints)
    filled = np.array(sparse.rotations)
    filled[:, np.setdiff1d(all_rows, known)] = R.identity()
    src = motion_texture(dataclasses.replace(sparse, rotations=filled), fps, all_rows, up)
    full = motion_texture(ctx, fps, all_rows, up)
    if src.num_frames < N:
        raise ValueError(f"a clip of {src.num_frames} frames at {fps:g} fps is shorter than one motion word")
    words = motion_word_starts(src.num_frames, N, N)
    nb = nearest_words(src, full, [known], words, k=k, source_length=N, target_length=M, min_width=min(11, N), self_clip=None)
    drop = _drop(known)
    out = np.array(src.values)
    prev_last = None
    wi, ki = np.nonzero(nb.pos[0] >= 0)
    nws, ok = _neighbor_words(src.values, full, known, drop, words[wi], nb.pos[0][wi, ki], N, M, min(11, N), out_rows=all_rows)
    for w, s in enumerate(tqdm(words, desc="sparse reconstruction", disable=not progress, unit="word")):
        cands = [(float(nb.dist[0, w, ki[q]]), nws[q]) for q in np.flatnonzero((wi == w) & ok)]
        if not cands:
            continue
        if prev_last is None:
            choice = min(cands, key=lambda c: c[0])[1]
        else:
            choice = min(cands, key=lambda c: float(np.sum(R.geodesic_angle(c[1][0], prev_last) ** 2)))[1]
        # a last word flush with the end overlaps the one before: keep what is already placed
        a = s if w == 0 else max(s, int(words[w - 1]) + N)
        out[a : s + N] = choice[a - s :]
        prev_last = choice[-1]
    rot = _upsample(R.quaternion_continuity(out, axis=0), fps, sparse.num_frames, sparse.fps)
    window = window_frames(blend_s, sparse.fps, 2)
    if sparse.num_frames >= window:
        rot = R.quaternion_normalize(savgol_filter(R.quaternion_continuity(rot, axis=0), window, 2, axis=0, mode="interp"))
    if 0 in known:
        rot[:, 0] = R.quaternion_multiply(R.quaternion_twist(sparse.rotations[:, 0], up), rot[:, 0])
    rot[:, known] = sparse.rotations[:, known]
    root = np.where(np.isfinite(sparse.root_positions), sparse.root_positions, 0.0)
    return dataclasses.replace(sparse, rotations=rot, root_positions=root, name=(sparse.name or "motion") + "_reconstructed")
