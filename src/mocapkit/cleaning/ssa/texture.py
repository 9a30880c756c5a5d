"""The motion texture of a take and of its context, prepared once for detection and repair (section 3.1).

A clip's joint rotations over time form a *motion texture*: resampled to the
analysis rate (24 fps), one row per joint, the root's heading removed so global
pose does not matter. :func:`prepare` builds, once per take, everything the
analysis of :mod:`~mocapkit.cleaning.ssa.detect` and the repair of
:mod:`~mocapkit.cleaning.ssa.repair` share: the joints analysed, the texture of
the take and of the take stacked with its context, the joint groups and the
source words (an :class:`Analysis`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Mapping, Sequence

import numpy as np

from ... import rotations as R
from ...errors import NotJudgedError, SkeletonError
from ...features import detect_up_axis
from ...metrics import motion_word_starts
from ...motion import Motion, bone_moving_joints, find_joint, joint_sides
from ...words import plural
from .coarse_cues import under_rate
from .params import SSAParams

__all__ = [
    "Analysis",
    "MotionTexture",
    "prepare",
    "motion_texture",
    "motion_words",
    "frame_words",
    "nearest_sorted",
    "joint_groups",
    "informative_joints",
    "analysable_joints",
    "body_joints",
    "digit_joints",
    "palm_standins",
    "left_out_joints",
    "left_out_note",
    "own_share",
    "SAME_CELL_DEG",
    "STILL_RAD",
    "HAND_DETAIL_ROLES",
    "facing_aligned",
    "context_motions",
    "group_rows",
    "align_hemisphere",
    "upsample_quaternions",
    "MAX_UPSAMPLING",
    "min_take_fps",
    "too_coarse",
]

_D = SSAParams()


def facing_aligned(rotations: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Rotations (F, J, 4) with the root's heading (twist about ``up``) removed (section 3.2 footnote).

    The root keeps its tilt (the remaining 2 DOF), so anomalies on it are
    still visible; other joints are local rotations and unchanged.
    """
    out = np.array(rotations, dtype=np.float64)
    out[:, 0] = R.quaternion_multiply(R.quaternion_conjugate(R.quaternion_twist(out[:, 0], up)), out[:, 0])
    return out


#: Rotations that never turn more than this (radians) from their first frame are still: nothing to analyse.
STILL_RAD = 1e-6

#: Roles (:data:`mocapkit.rigs.ROLES`) of the digits, which :func:`body_joints` leaves to the extras with the other
#: finger segments: small bones (on the CMU and HDM05 rigs one-segment stubs whose tracks glitch, a thumb flipping
#: 180 degrees in 1/120 s), and on a game rig each hand's first finger and thumb segments, which would otherwise
#: take four slots from the body. The palm (the Acclaim ``lhand``, the hand's flexion) is the body's.
HAND_DETAIL_ROLES = ("left_fingers", "right_fingers", "left_thumb", "right_thumb")


def body_joints(skeleton) -> np.ndarray:
    """(J,) bool: the joints of the human body, which :func:`informative_joints` analyses before any other.

    A joint plays a body role (:func:`mocapkit.rigs.roles`: pelvis, spine, neck, head, clavicles, arms to
    the wrists and palms, legs to the toes; not the digits, :data:`HAND_DETAIL_ROLES`) or lies on the chain
    from the root to one (a spine or neck segment no role names). The rest are extras: finger segments,
    twist and helper bones, weapon and prop bones, tails. On a rig of no known family, whose roles are
    read from its tree (:func:`mocapkit.rigs.roles_by_topology`, which names no palm), the wrist's one
    child that holds more joints than any other (two at least: a palm with its fingers) is the palm. On
    a rig whose roles are not known at all only the pelvis and the joints above it are body joints.
    """
    from ...rigs import rig_family, roles

    body = np.zeros(skeleton.num_joints, dtype=bool)
    parents = skeleton.parents
    found = roles(skeleton)
    read_from_tree = rig_family(skeleton) is None
    for side in ("left", "right"):  # a palm no name tells: the one child of the wrist that holds more joints
        hand = found.get(f"{side}_hand")
        if read_from_tree and hand is not None and f"{side}_palm" not in found:
            sizes = {int(c): int(np.sum([_descends(parents, k, int(c)) for k in range(skeleton.num_joints)]))
                     for c in skeleton.children(hand) if int(c) not in found.values()}  # not a named finger
            big = [c for c, n in sizes.items() if n >= 2 and n == max(sizes.values(), default=0)]
            if len(big) == 1:
                found[f"{side}_palm"] = big[0]
    for role, j in found.items():
        if role in HAND_DETAIL_ROLES:
            continue
        while j >= 0 and not body[j]:
            body[j] = True
            j = int(parents[j])
    return body


def digit_joints(skeleton) -> np.ndarray:
    """(J,) bool: the joints that play a digit's role (:data:`HAND_DETAIL_ROLES`: each hand's first finger
    and thumb segments, :func:`mocapkit.rigs.roles`), which :func:`informative_joints` analyses in left/right
    pairs only."""
    from ...rigs import roles

    out = np.zeros(skeleton.num_joints, dtype=bool)
    for role, j in roles(skeleton).items():
        if role in HAND_DETAIL_ROLES:
            out[j] = True
    return out


def palm_standins(skeleton) -> np.ndarray:
    """(J,) bool: on a rig of a known family that names no palm, each hand's first finger joint (role
    ``{side}_fingers``, a child of the wrist), which :func:`informative_joints` ranks before any other extra.

    Where a rig has no palm, the first finger joint turns with the hand's flexion (the Acclaim ``lhand``
    folded into ``lfingers``: the CMU Daz-friendly release, Unity's humanoid avatar), so it stands for the
    palm the Acclaim rig analyses as a body joint. Ranked with the other extras by how much it turns, a
    thumb could take its slot instead: the same HDM05 lieDownFloor_013 had its palm's 178 degree flip
    repaired on the Acclaim rig and its thumb's on the Daz rig. It stays an extra, so it never pushes a
    body joint out. A rig read from its tree gets its palm from :func:`body_joints` and has none."""
    from ...rigs import rig_family, roles

    out = np.zeros(skeleton.num_joints, dtype=bool)
    if rig_family(skeleton) is None:
        return out
    found = roles(skeleton)
    for side in ("left", "right"):
        hand, fingers = found.get(f"{side}_hand"), found.get(f"{side}_fingers")
        if f"{side}_palm" not in found and hand is not None and fingers is not None \
                and int(skeleton.parents[fingers]) == hand:
            out[fingers] = True
    return out


def _descends(parents, k: int, a: int) -> bool:
    """Whether joint ``k`` is ``a`` or below it."""
    while k >= 0 and k != a:
        k = int(parents[k])
    return k == a


def _rotation_spread(motions: Sequence[Motion], joints) -> tuple[np.ndarray, np.ndarray]:
    """(J,) mean angle (radians) of each of ``joints``' rotations from their average over every frame of
    ``motions`` (0 for a still joint), and (J,) bool whether the rotation turns at all (more than
    :data:`STILL_RAD` from its first finite frame); 0 and False for the other joints. All joints at once where
    every frame is finite (the same numbers as joint by joint: flips, angles and the mean over frames go joint by
    joint alike; each joint's mean angle its own column's), else joint by joint."""
    sk = motions[0].skeleton
    spread = np.zeros(sk.num_joints)
    turns = np.zeros(sk.num_joints, dtype=bool)
    joints = np.asarray(list(joints), dtype=np.int64)
    if not len(joints):
        return spread, turns
    qs = np.concatenate([R.quaternion_continuity(np.asarray(m.rotations[:, joints]), axis=0) for m in motions])
    if len(qs) == 0 or not np.all(np.isfinite(qs)):
        for j in joints:
            spread[j], turns[j] = _joint_spread(motions, int(j))
        return spread, turns
    turns[joints] = np.max(R.geodesic_angle(qs, qs[0]), axis=0) > STILL_RAD
    # exactly 0, not rounding noise: still joints tie, and their order is the skeleton's
    live = np.flatnonzero(turns[joints])
    mean = qs[:, live].mean(axis=0)  # (n, 4)
    size = np.array([np.linalg.norm(m) for m in mean])
    flat = size < 1e-9
    rows = np.ascontiguousarray(qs[:, live[~flat]].swapaxes(0, 1))  # (n, F, 4): each joint's mean over a row
    ang = R.geodesic_angle(rows, (mean[~flat] / size[~flat, None])[:, None])  # (n, F)
    spread[joints[live[flat]]] = np.pi
    spread[joints[live[~flat]]] = [float(np.mean(a)) for a in ang]
    return spread, turns


def _joint_spread(motions: Sequence[Motion], j: int) -> tuple[float, bool]:
    """:func:`_rotation_spread` of one joint ``j``: its frames' NaN rows left out."""
    qs = np.concatenate([R.quaternion_continuity(np.asarray(m.rotations[:, j])) for m in motions])
    qs = qs[np.all(np.isfinite(qs), axis=1)]
    if len(qs) == 0:
        return 0.0, False
    if not np.max(R.geodesic_angle(qs, qs[0])) > STILL_RAD:
        return 0.0, False
    mean = qs.mean(axis=0)
    if np.linalg.norm(mean) < 1e-9:
        return float(np.pi), True
    mean = mean / np.linalg.norm(mean)
    return float(np.mean(R.geodesic_angle(qs, mean))), True


def analysable_joints(motions: Sequence[Motion]) -> np.ndarray:
    """(J,) bool: the joints self-similarity can judge in ``motions`` (sharing one skeleton).

    A joint with rotation channels whose rotation turns in the data (more than :data:`STILL_RAD` from its
    first frame) or that moves a bone (a child or end site at a non-zero offset); the root always (its
    tilt is analysed, the heading removed). The data decides, not only the bone's length: a game rig's
    head, hands and toes end in an End Site at offset 0, yet a mesh is skinned to their rotations, so a
    wrong turn there shows. A zero-length joint whose rotation is the same in every frame has nothing to judge. A
    still joint that moves a bone stays a candidate (ranked by its spread, 0): the word distance's
    8 degree gate is an RMS over a group's joints, and leaving the CMU BVH's still collars and hip
    joints out raised it so that on CMU 131_01 the frames no joint is judged at rose from 176 to 573
    and a 50 degree head spike went unjudged.
    """
    return _candidates(motions)[0]


def _candidates(motions: Sequence[Motion]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`analysable_joints` and the (J,) rotation spread of :func:`_rotation_spread`, computed once."""
    sk = motions[0].skeleton
    has = np.array([bool(sk.rotation_order(j)) for j in range(sk.num_joints)])
    spread, turns = _rotation_spread(motions, np.flatnonzero(has))
    out = has & (turns | bone_moving_joints(sk))
    out[0] = True
    return out, spread


def informative_joints(motions: Sequence[Motion], count: int = _D.joints) -> np.ndarray:
    """The ``count`` joints analysed, sorted skeleton indices (section 5: "m = 24").

    Candidates are the :func:`analysable_joints`. The body's joints (:func:`body_joints`) come first,
    then the extras (finger segments, twist, weapon and prop bones, tails) in the slots left, a palm's
    stand-in (:func:`palm_standins`) first: an
    animated extra rotates more than a clavicle or a wrist and, ranked with them, would push body
    joints out of the analysis (fingers on one hand of a Bandai walk: the forearms, hands, spine, neck
    and pelvis; a weapon, a prop, twist bones and a tail on CMU 131_01: the head). Within each of the two, joints are ranked by how much they rotate:
    the mean angle from their average rotation over all frames of ``motions`` (sharing one
    skeleton). The root is always kept. Left/right partners (:func:`mocapkit.motion.mirror_pairs`)
    are taken together, ranked by the one that rotates more, so the set does not depend on which
    hand moved more in the take and the left and right groups match (a swap, which
    :func:`side_swaps` finds, needs both joints); a last slot that no pair of the body fits takes
    the half of a body pair that rotates more before any extra, and a last slot no pair of extras
    fits the next single extra, or else the half of a pair that rotates more, but never half a pair of
    digits (:func:`digit_joints`): a digit is analysed with its partner or not at all. One thumb judged
    and the other not would make a hand's judgement hang on the rig's joint count, not on the motion:
    the same CMU backflip on the Daz rig (25 joints) had its spare 24th slot given to ``rThumb1`` and
    its thumb flips repaired, where the Acclaim rig (31) and Unity's (26) judge neither thumb.
    :func:`left_out_joints` says why each other joint is not analysed.
    """
    from ...motion import mirror_pairs

    sk = motions[0].skeleton
    ok, spread = _candidates(motions)
    cand = np.flatnonzero(ok)
    extra = (~body_joints(sk)).astype(int) * 2 - palm_standins(sk)  # 0 body, 1 a palm's stand-in, 2 other extras
    digit = digit_joints(sk)
    perm = mirror_pairs(sk.joint_names)
    in_cand = np.zeros(sk.num_joints, dtype=bool)
    in_cand[cand] = True
    single = (perm == np.arange(sk.num_joints)) | ~in_cand[perm]
    units = [(int(j),) if single[j] else (int(j), int(perm[j])) for j in cand if single[j] or perm[j] > j]
    units.sort(key=lambda u: (0 not in u, -max(spread[list(u)]), min(u)))
    chosen: list[int] = []
    for tier in (0, 1, 2):  # the body's joints, then the palms' stand-ins, then the other extras
        for u in units:
            if min(extra[list(u)]) == tier and len(chosen) + len(u) <= int(count):
                chosen.extend(u)
        # a slot no pair of the tier fits and no single is left for
        rest = sorted((j for j in cand if j not in chosen and extra[j] == tier and not digit[j]),
                      key=lambda j: (-spread[j], j))
        chosen.extend(rest[: max(int(count) - len(chosen), 0)])
    return np.array(sorted(chosen), dtype=np.int64)


def left_out_joints(motions: Sequence[Motion], analysed: Sequence[int], count: int | None = None) -> dict[str, str]:
    """Joint name -> why it is not analysed, for every joint of ``motions``' skeleton not in ``analysed``.

    The reasons, briefly: ``"no rotation channels"``; ``"rotation never changes"`` (the same rotation
    in every frame: nothing to compare; a zero-length one is no candidate, :func:`analysable_joints`,
    one that moves a bone ranks last);
    ``"beyond the COUNT analysed (body first)"`` (crowded out of :func:`informative_joints`'s
    ``count`` slots, extras after the body's joints); ``"not chosen"`` (an explicit joint list left
    it out). In skeleton order. The summary, ``detect --json``, the record
    and the report name them, so that an error there is not taken for checked and clean.
    """
    sk = motions[0].skeleton
    has = [bool(sk.rotation_order(j)) for j in range(sk.num_joints)]
    inside = set(int(j) for j in analysed)
    _, turns = _rotation_spread(motions, [j for j in range(sk.num_joints) if has[j] and j not in inside])
    out = {}
    for j, name in enumerate(sk.joint_names):
        if j in inside:
            continue
        if not has[j]:
            out[name] = "no rotation channels"
        elif not turns[j]:
            out[name] = "rotation never changes"
        elif count is not None:
            out[name] = f"beyond the {int(count)} analysed (body first)"
        else:
            out[name] = "not chosen"
    return out


def left_out_note(left_out: Mapping[str, str]) -> str:
    """One line naming the joints not analysed, grouped by reason ("" when every joint is)."""
    by: dict[str, list[str]] = {}
    for name, why in left_out.items():
        by.setdefault(why, []).append(name)
    if not by:
        return ""
    parts = [f"{', '.join(names)} ({why})" for why, names in by.items()]
    return f"not analysed, {len(left_out)} joint{'' if len(left_out) == 1 else 's'}: " + "; ".join(parts)


def joint_groups(skeleton, joints: Sequence[int] | None = None) -> dict[str, np.ndarray]:
    """The paper's joint groups (section 3.1) as skeleton indices within ``joints``.

    ``whole`` (all), ``upper`` (spine, head, arms), ``lower`` (root and legs),
    ``left`` and ``right`` (root and the joints of that side). Legs are the
    subtrees hanging from the pelvis (:func:`mocapkit.rigs.pelvis_index`) that hold the feet; the root is the
    pelvis and any joint above it (the Bandai Namco rig's ``joint_Root``, Unreal's ``root``, which were traced
    into the legs: ``lower`` was the whole body and ``upper`` missing); ``upper`` is what else hangs from the
    pelvis, not helpers beside it (Unreal's ``ik_foot_root``). Sides come from joint
    names (``l``/``left`` prefixes and the like, as :func:`mocapkit.motion.mirror_pairs`).
    Groups with fewer than two joints are left out.
    """
    from ...rigs import pelvis_index

    J = skeleton.num_joints
    joints = np.arange(J) if joints is None else np.asarray(joints, dtype=np.int64)
    parents = skeleton.parents
    pelvis = pelvis_index(skeleton)
    leg = np.zeros(J, dtype=bool)
    for role in ("left_foot", "right_foot"):
        try:
            j = find_joint(skeleton, role)
        except KeyError:
            continue
        top = j
        while parents[top] > pelvis:  # up to the joint hanging from the pelvis (not from a root above it)
            top = int(parents[top])
        if parents[top] == pelvis or top == j:
            for c in range(J):  # mark the subtree under `top`
                a = c
                while a > 0 and a != top:
                    a = int(parents[a])
                leg[c] |= a == top
    side = np.array([s or "" for s in joint_sides(skeleton.joint_names)])
    sel = np.zeros(J, dtype=bool)
    sel[joints] = True
    root = np.zeros(J, dtype=bool)  # the pelvis and the joints above it (a root above the pelvis), not beside it
    a = pelvis
    while a >= 0:
        root[a] = True
        a = int(parents[a])
    body = np.zeros(J, dtype=bool)  # below the pelvis: not the helpers hanging from a root above it beside it
    for c in range(pelvis + 1, J):
        body[c] = parents[c] == pelvis or body[parents[c]]
    groups = {
        "whole": sel,
        "upper": sel & ~leg & body,
        "lower": sel & (leg | root),
        "left": sel & ((side == "left") | root),
        "right": sel & ((side == "right") | root),
    }
    return {k: np.flatnonzero(v) for k, v in groups.items() if v.sum() >= 2}


@dataclass(frozen=True, eq=False)
class MotionTexture:
    """Joint rotations of one or more clips as one texture (section 3.1).

    values : float (F, m, 4) unit quaternions, the root's heading removed,
    hemisphere-continuous in time; analysis_fps : its frames per second; joints : (m,)
    skeleton indices of the rows; clip_starts : (C+1,) frame ranges of the clips
    stacked in ``values``; clip_names : (C,).
    """

    values: np.ndarray
    analysis_fps: float
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


def motion_texture(motions, analysis_fps: float = _D.analysis_fps, joints: Sequence[int] | None = None, up=None) -> MotionTexture:
    """Motion texture of one clip or of several clips stacked (same skeleton), resampled to ``analysis_fps``.

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
        r = m.resample(analysis_fps).rotations
        r = facing_aligned(r, up)[:, joints]
        parts.append(R.quaternion_continuity(r, axis=0))
        starts.append(starts[-1] + len(r))
    values = np.concatenate(parts) if parts else np.zeros((0, len(joints), 4))
    return MotionTexture(values, float(analysis_fps), joints, np.array(starts), tuple(m.name for m in motions))


#: the most the motion texture is made denser than the take: a take below ``analysis_fps / MAX_UPSAMPLING`` (12 fps)
#: would give each source word more frames made by interpolation than samples of its own
MAX_UPSAMPLING = 2.0


def min_take_fps(params: SSAParams = _D) -> float:
    """The lowest frame rate (fps) at which a take is judged by its motion words: ``analysis_fps / MAX_UPSAMPLING``.

    A motion word is a span of time: ``source_length`` frames at ``analysis_fps`` (15 at 24 fps, 0.625 s,
    section 5), where the paper reduced 120 fps captures to 24 fps because motion is locally linear and smooth
    at that rate. A take at a lower rate is resampled up to it by slerp: at 12 fps every second frame of a word is
    interpolated, at 1 fps a word lies inside one of the take's frame intervals and the texture is interpolation
    made 24 times denser than the take (3,577 frames and 714 words for 150 frames), slow to search and matching
    nothing the capture measured. Below this rate the take is not judged, and the summary says so."""
    return float(params.analysis_fps) / MAX_UPSAMPLING


def too_coarse(fps: float, params: SSAParams = _D) -> str:
    """One line saying why a take at ``fps`` is too coarse for motion words (:func:`min_take_fps`), or "" when it
    is not. A rate within 0.1 % of the lowest counts as it: a BVH at 12 fps may write its Frame Time rounded up
    (0.0833334 s, 11.99999 fps)."""
    low = min_take_fps(params)
    if not under_rate(fps, low):
        return ""
    N, a = params.source_length, params.analysis_fps
    return (f"{fps:g} fps is too coarse for motion words: a source word spans {N / a:.3f} s ({N} frames at {a:g} fps), "
            f"{N * fps / a:.2g} of the take's frames; self-similarity judges takes of {low:g} fps or more (at least "
            f"half of each word's frames the take's own)")


def motion_words(num_frames: int, length: int = _D.source_length, stride: int = _D.stride) -> np.ndarray:
    """First frames of the source words: every ``stride`` frames, plus one flush with the end (section 5)."""
    if num_frames < length:
        raise ValueError(f"a clip of {plural(num_frames, 'frame')} is shorter than one motion word ({length} frames)")
    return motion_word_starts(num_frames, length, stride)


def nearest_sorted(values: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Index of the entry of the ascending ``values`` nearest each of ``queries`` (the lower index on a tie), as
    ``argmin(|queries[:, None] - values|, axis=1)`` gives it, in O((F + W) log W) memory and time instead of an
    (F, W) matrix: 4 GB for a 10-minute take at 120 fps and its 7,000 words."""
    values = np.asarray(values, dtype=np.float64)
    queries = np.asarray(queries, dtype=np.float64)
    if len(values) == 0:
        raise ValueError("no values to be nearest to")
    if np.any(np.diff(values) < 0):
        raise ValueError("values must be ascending")
    hi = np.clip(np.searchsorted(values, queries, side="left"), 1, max(len(values) - 1, 1))
    lo = hi - 1
    if len(values) == 1:
        return np.zeros(len(queries), dtype=np.int64)
    take_lo = np.abs(queries - values[lo]) <= np.abs(values[hi] - queries)
    pick = np.where(take_lo, lo, hi)
    return np.searchsorted(values, values[pick], side="left").astype(np.int64)  # the first of equal values


def frame_words(words: np.ndarray, length: int, num_frames: int, analysis_fps: float, fps: float) -> np.ndarray:
    """(F,) int64: the source word around each of a take's ``num_frames`` frames at ``fps``, the one of ``words``
    (first frames at ``analysis_fps``, ``length`` frames long) whose centre is nearest (the earlier on a tie): the
    word whose neighbours :func:`~mocapkit.cleaning.ssa.repair` reads for the frame."""
    tau = np.arange(num_frames) * (analysis_fps / fps)  # analysis time of each frame
    return nearest_sorted(np.asarray(words) + (length - 1) / 2.0, tau)



def align_hemisphere(q: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``q`` with each quaternion's sign flipped into the hemisphere of ``ref``."""
    s = np.sign(np.sum(q * ref, axis=-1, keepdims=True))
    return q * np.where(s == 0, 1.0, s)



def upsample_quaternions(q: np.ndarray, fps_from: float, n_out: int, fps_to: float) -> np.ndarray:
    """Quaternion tracks (F, ..., 4) at ``fps_from`` sampled at ``n_out`` frames of ``fps_to`` by slerp."""
    F = q.shape[0]
    t = np.arange(n_out) * (fps_from / fps_to)
    i0 = np.clip(np.floor(t).astype(np.int64), 0, F - 1)
    i1 = np.minimum(i0 + 1, F - 1)
    a = np.clip(t - i0, 0.0, 1.0).reshape((-1,) + (1,) * (q.ndim - 1))
    a0, a1 = q[i0], q[i1]
    a1 = align_hemisphere(a1, a0)
    out = R.quaternion_normalize(a0 * (1 - a) + a1 * a)  # nlerp: the frames are 1/24 s apart
    return out



SAME_CELL_DEG = 0.01
"""A context clip's rotation within this many degrees of the take's (resampled to the clip's rate) is the take's own
sample: a database keeps its clips as float32 (the bundled default context's copy of HDM_bd_grabHighR_001_120 is
within 5e-06 deg of the take resampled to its 24 fps)."""


def own_share(motion: Motion, clip: Motion, resampled: dict | None = None) -> float:
    """The share (0-1) of ``clip``'s cells (frame x joint rotations) that are ``motion``'s own samples: ``motion``
    resampled to the clip's rate (:meth:`Motion.resample`, as :meth:`MotionDatabase.build` makes its clips), with
    the clip's frame count, within :data:`SAME_CELL_DEG`, over the joints the clip turns (one it never turns is
    alike in any take: HDM05's hip joints have no rotation channels); 0 where the lengths differ. ``resampled``: a cache of
    ``motion`` per rate. A corrupted copy of a clip's take shares most of its cells (the errors touch a few joints
    over some frames); another take, even of the same length and name, next to none."""
    if abs(clip.duration - motion.duration) >= 1.5 / min(clip.fps, motion.fps):
        return 0.0
    cache = {} if resampled is None else resampled
    if clip.fps not in cache:
        cache[clip.fps] = motion.resample(clip.fps)
    m = cache[clip.fps]
    if m.num_frames != clip.num_frames or m.num_joints != clip.num_joints or clip.num_frames == 0:
        return 0.0
    q = np.asarray(clip.rotations, dtype=np.float64)
    near = np.cos(np.radians(SAME_CELL_DEG) / 2)
    with np.errstate(invalid="ignore"):
        same = np.abs(np.sum(np.asarray(m.rotations, dtype=np.float64) * q, -1)) >= near  # NaN: not the take's
        moving = ~np.all(np.abs(np.sum(q * q[:1], -1)) >= near, axis=0)
    # joints the clip never turns (no rotation channels, fingers held) are alike in every take of the skeleton
    return float(np.mean(same[:, moving] if moving.any() else same))


def context_motions(motion: Motion, context, params: SSAParams | None = None) -> tuple[list[Motion], list[str]]:
    """Context as a list of Motions with the input's joints; clips that are the input itself are dropped, and with
    ``params``, clips too coarse for motion words (:func:`too_coarse`: one note names them and says why).

    A clip is the input itself by its content, not its name (a free text): more than half of its cells are the
    take's own samples (:func:`own_share`), so that a renamed copy of a context take, clean or with errors, is not
    judged against its own clean copy, and another take that shares a clip's name and length is kept. The note
    says which clip was left out, and the take's name where it differs."""
    notes, coarse = [], []
    if context is None:
        return [], notes
    from ...database import MotionDatabase

    if isinstance(context, MotionDatabase):
        motions = [context.clip(i) for i in range(context.num_clips)]
    elif isinstance(context, Motion):
        motions = [context]
    else:
        motions = list(context)
    out, resampled = [], {}
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
        share = own_share(motion, c, resampled)
        if share > 0.5:
            named = "" if c.name == motion.name else f", named {motion.name or 'nothing'!r} here"
            notes.append(f"context clip {c.name!r} is the input itself ({int(share * 100)}% of its samples are the "
                         f"input's{named}); left out")
            continue
        if params is not None and too_coarse(c.fps, params):
            coarse.append(c)
            continue
        out.append(c)
    if coarse:
        more = f" and {len(coarse) - 1} more" if len(coarse) > 1 else ""
        notes.append(f"context clip {coarse[0].name!r}{more} left out: {too_coarse(coarse[0].fps, params)}")
    return out, notes


def group_rows(groups, texture_joints) -> tuple[list[str], list[np.ndarray]]:
    """Names and texture rows of the groups (name -> skeleton indices) with at least two analysed joints."""
    pos = {int(j): i for i, j in enumerate(texture_joints)}
    names, rows = [], []
    for name, js in groups.items():
        r = np.array([pos[int(j)] for j in js if int(j) in pos], dtype=np.int64)
        if len(r) >= 2:
            names.append(name)
            rows.append(r)
    return names, rows


@dataclass(frozen=True, eq=False)
class Analysis:
    """A take prepared once for self-similarity analysis; :func:`~mocapkit.cleaning.ssa.detect` makes it and
    :func:`~mocapkit.cleaning.ssa.repair` reuses it (through :attr:`Detection.analysis`).

    motion : the take; context : tuple of the context's Motions (the take itself left out);
    params : :class:`SSAParams`; up : (3,) vertical axis; source : the take's
    :class:`MotionTexture` at ``params.analysis_fps``; texture : the take and its context stacked
    (clip 0 the take; ``source`` itself when there is no context); group_names, group_rows : the joint
    groups with their rows in the textures; words : (W,) first frames of the source words at the
    analysis rate; notes : what was left out and why; context_given : the ``context`` argument it was
    prepared from (so that a repair handed the same object knows it); left_out : ``((joint name, why),
    ...)`` the joints not analysed and why (:func:`left_out_joints`), in skeleton order; warped : neighbour words
    already warped on this take and its context, kept by the detection for its repair
    (:func:`~mocapkit.cleaning.ssa.neighbours.flagged_words`: a group's rows as bytes -> its source word starts,
    neighbour positions, words and whether each was warped), read by
    :func:`~mocapkit.cleaning.ssa.repair` instead of warping them again.
    """

    motion: Motion
    context: tuple
    params: SSAParams
    up: np.ndarray
    source: MotionTexture
    texture: MotionTexture
    group_names: tuple
    group_rows: tuple
    words: np.ndarray
    notes: tuple = ()
    context_given: object = None
    left_out: tuple = ()
    warped: dict = field(default_factory=dict, repr=False)

    @property
    def joints(self) -> np.ndarray:
        """(m,) skeleton indices of the analysed joints (the textures' rows)."""
        return self.source.joints

    @cached_property
    def residuals(self) -> np.ndarray:
        """(F, J) radians: the take's midpoint residuals (:func:`~mocapkit.cleaning.ssa.cues.midpoint_residuals`),
        made once for detection and for the take's breaks (:func:`~mocapkit.cleaning.whole_take.across_breaks`);
        read-only."""
        from .cues import midpoint_residuals

        out = midpoint_residuals(self.motion.rotations)
        out.flags.writeable = False
        return out

    @property
    def has_context(self) -> bool:
        return self.texture is not self.source

    @property
    def clips(self) -> tuple:
        """``((name, frames at the analysis rate), ...)`` of the stacked texture, clip 0 the take."""
        t = self.texture
        return tuple((str(n), int(b - a)) for n, a, b in zip(t.clip_names, t.clip_starts[:-1], t.clip_starts[1:]))

    def group_masks(self) -> np.ndarray:
        """(G, m) bool: the rows of each group."""
        masks = np.zeros((len(self.group_rows), len(self.joints)), dtype=bool)
        for gi, r in enumerate(self.group_rows):
            masks[gi, r] = True
        return masks

    def serves(self, motion: Motion) -> bool:
        """Whether this preparation is of ``motion`` (the same object, or the same skeleton, rate and rotations)."""
        m = self.motion
        if motion is m:
            return True
        return (motion.fps == m.fps and tuple(motion.skeleton.joint_names) == tuple(m.skeleton.joint_names)
                and motion.rotations.shape == m.rotations.shape and np.array_equal(motion.rotations, m.rotations))


def prepare(
    motion: Motion,
    context=None,
    params: SSAParams | None = None,
    *,
    groups: Mapping[str, Sequence] | None = None,
    joints: Sequence | None = None,
) -> Analysis:
    """Prepare ``motion`` (and ``context``) once for :func:`~mocapkit.cleaning.ssa.detect` and
    :func:`~mocapkit.cleaning.ssa.repair`: the analysed joints, both motion textures, the groups and words.

    ``context``: None, a Motion, a list of Motions with the take's joints, or a MotionDatabase; a clip
    with the take's name and length is the take itself and is left out (noted). ``groups``: name ->
    joint names or indices (default :func:`joint_groups`). ``joints``: exactly these joints (skeleton
    indices, e.g. a saved detection's ``texture_joints``) instead of ``params.joints``. Raises
    :class:`~mocapkit.errors.NotJudgedError` (a ValueError naming the take) on a take shorter than one source word or
    too coarse for one (:func:`too_coarse`), ValueError on missing rotations or no group with two analysed joints; :class:`~mocapkit.errors.SkeletonError` on a context clip with other joints.
    """
    params = SSAParams() if params is None else params
    if not isinstance(motion, Motion):
        raise TypeError(f"motion must be a Motion, got {type(motion).__name__}")
    if not np.all(np.isfinite(motion.rotations)):
        bad = np.flatnonzero(~np.all(np.isfinite(motion.rotations), axis=(1, 2)))
        raise ValueError(
            f"{motion.name or 'motion'}: {len(bad)} frame{'s have' if len(bad) != 1 else ' has'} missing rotations "
            f"(first: {bad[0]}); fill the gaps first"
        )
    coarse = too_coarse(motion.fps, params)
    if coarse:  # before the texture: resampled to the analysis rate, a 1 fps take would be 24 times its frames
        raise NotJudgedError(motion.name or "motion", coarse)
    ctx, notes = context_motions(motion, context, params)
    sk = motion.skeleton
    chosen = params.joints if joints is None else joints
    if isinstance(chosen, (int, np.integer)):
        # the bundled default context, a general sample, does not choose which of the take's joints are analysed:
        # its still fingers left a take's finger error unanalysed, so the cues that need no context missed it
        info = getattr(context, "info", None)
        general = isinstance(info, dict) and bool(info.get("default"))
        ranked = [motion] + ([] if general else ctx)
        tex_joints = informative_joints(ranked, int(chosen))
        left_out = left_out_joints(ranked, tex_joints, int(chosen))
    else:
        tex_joints = np.array([sk.index(j) if isinstance(j, str) else int(j) for j in chosen], dtype=np.int64)
        left_out = left_out_joints([motion] + ctx, tex_joints)
    if left_out:  # said, so that a joint nobody checked is not taken for checked and clean
        notes.append(left_out_note(left_out))
    up = detect_up_axis(sk)
    src = motion_texture(motion, params.analysis_fps, tex_joints, up)
    full = motion_texture([motion] + ctx, params.analysis_fps, tex_joints, up) if ctx else src
    if groups is None:
        groups = joint_groups(sk, tex_joints)
    else:
        groups = {n: [sk.index(j) if isinstance(j, str) else int(j) for j in js] for n, js in groups.items()}
    gnames, grows = group_rows(groups, tex_joints)
    if not gnames:
        raise ValueError("no joint group has two analysed joints")
    if src.num_frames < params.source_length:  # said in the take's own frames, as clean says it
        N, fps = params.source_length, params.analysis_fps
        raise NotJudgedError(motion.name or "motion", f"{plural(motion.num_frames, 'frame')} ({motion.duration:.2f} s) is shorter "
                             f"than one motion word ({N} frames at {fps:g} fps, {N / fps:.3f} s)")
    words = motion_words(src.num_frames, params.source_length, params.stride)
    return Analysis(motion, tuple(ctx), params, up, src, full, tuple(gnames), tuple(grows), words, tuple(notes), context,
                    tuple(left_out.items()))
