"""The cues that confirm a digression as an error, or find one a digression misses (see :mod:`mocapkit.cleaning.ssa`).

A joint's own trajectory tells errors from unseen motion: :func:`discontinuities`
(a step or a one-frame spike no smooth motion makes), :func:`held_joints` (a
frozen channel), :func:`side_swaps` (left/right labels swapped and swapped
back) and :func:`transient_offsets` (a joint stepping off its path and back).
:func:`confirm_flags` keeps the digressions of the movement digression map that
hold a break. All work on (F, J) arrays at the take's own frame rate.
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R
from ...motion import Motion
from ..ik import contact_segments, segment_frames
from .edge_swaps import swap_step_events
from .events import event_bounds, pair_events
from .freeze_bounds import bounded_breaks
from .freezes import recurring
from .run_extent import run_cells
from .params import SSAParams
from .step_pairs import UNDO_RATIO, is_step, offset_step_breaks, returns, steps_back

__all__ = [
    "unshared_offsets",
    "discontinuities",
    "midpoint_residuals",
    "midpoint_angles",
    "residual_breaks",
    "own_breaks",
    "own_level",
    "motion_explained",
    "side_swaps",
    "mirrored_rotations",
    "swap_reading",
    "swaps_from_residuals",
    "transient_offsets",
    "offsets_from_residuals",
    "confirm_flags",
    "CAUSES",
    "CAUSE_DTYPE",
    "flag_causes",
    "cause_names",
    "flag_rule",
    "held_joints",
    "step_angles",
    "uncompensated_breaks",
    "chain_table",
    "event_bounds", "event_steps", "off_path", "stands_out", "row_norms",
]

_D = SSAParams()
MAX_ACCEL_DEG_S2 = 60_000.0  # three times the 20,000 deg/s^2 a fast limb reaches (discontinuities)

def discontinuities(motion: Motion, jump_deg: float = _D.jump_deg) -> np.ndarray:
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
    return residual_breaks(midpoint_residuals(motion.rotations), jump_deg)


def residual_breaks(resid: np.ndarray, jump_deg: float) -> np.ndarray:
    """:func:`discontinuities` on midpoint residuals already computed (:func:`midpoint_residuals`), (F, J) bool."""
    if not (np.isfinite(jump_deg) and jump_deg > 0):
        raise ValueError(f"jump_deg must be a positive number of degrees, got {jump_deg!r}")
    return resid > np.radians(jump_deg)


def own_breaks(resid: np.ndarray, jump_deg: float, fps: float | None = None, rotations=None) -> np.ndarray:
    """(F, J) bool: midpoint residuals over ``jump_deg`` *and* over what the joint's own motion reaches.

    What a joint's motion reaches is ten times its median residual in the
    take or three times its 95th percentile (:func:`_usual_residual`),
    whichever is larger. At 120 fps this stays under the break thresholds, so
    the breaks are those of :func:`residual_breaks`; at 30 fps the midpoint
    residual of fast real motion is second order in a frame time four times
    as long (16 times as large: a dancer's arms swinging both ways at once, a
    foot strike), and a break must stand out from the joint's own motion to
    be an error. With ``fps`` that level is capped at the residual the
    fastest limb motion can make at that rate, ``MAX_ACCEL_DEG_S2 / (2 fps^2)``
    (2.1 deg at 120 fps, 33 deg at 30 fps): where heavy noise raises a
    joint's residuals, its breaks still confirm an error's digression (used
    so for the confirmation and the side swaps; the transient offsets take
    the uncapped level). With ``fps`` and ``rotations`` (F, J, 4) too, a
    break event under that cap that the joint's speed beside it explains is
    no break (:func:`motion_explained`): the level is the joint's over the
    whole take, and a joint still for most of it (a throwing arm, 131_02 at
    24 and 30 fps) breaks that level wherever it moves fast.
    """
    if not (np.isfinite(jump_deg) and jump_deg > 0):
        raise ValueError(f"jump_deg must be a positive number of degrees, got {jump_deg!r}")
    usual = own_level(resid)
    if fps is not None:
        cap = np.radians(MAX_ACCEL_DEG_S2 / (2.0 * float(fps) ** 2))
        usual = np.minimum(usual, cap)
    breaks = resid > np.maximum(np.radians(jump_deg), usual)[None, :]
    if fps is not None and rotations is not None and cap > np.radians(jump_deg):
        breaks = motion_explained(np.asarray(rotations, dtype=np.float64), resid, breaks, cap)
    return breaks


def own_level(resid: np.ndarray) -> np.ndarray:
    """(J,) radians: what a joint's own motion reaches, uncapped (:func:`own_breaks`), from ``resid`` (F, J)."""
    return np.maximum(10.0 * np.median(resid, axis=0), _usual_residual(resid))


def motion_explained(q: np.ndarray, resid: np.ndarray, breaks: np.ndarray, cap: float) -> np.ndarray:
    """``breaks`` (F, J) bool without the break events a joint's own fast motion beside them explains.

    The midpoint residual of smooth motion is half the change of its
    frame-to-frame step (:func:`discontinuities`), so it can reach the
    joint's speed where the joint starts, stops or turns within a frame: an
    arm that throws at 24 fps turns 36, 51 and then 9 deg in three frames
    (a residual of 30 deg, the CMU 131_02 right shoulder), far over what
    the joint's motion in the rest of the take reaches. An error steps off
    a path the joint follows at its own pace. So a break event (grouped
    as :func:`event_bounds` does) whose largest residual stays under
    ``cap`` (radians, what limb motion can make at the take's rate:
    :func:`own_breaks`) and under the joint's speed just outside it (the
    larger of the steps ``q[first - 2] -> q[first - 1]`` and ``q[last + 1]
    -> q[last + 2]``, frames the event's own steps do not touch, whether it
    is a step or a one-frame spike) is motion, not a break. Residuals over
    ``cap`` are breaks whatever the speed, and where ``cap`` is under the
    break threshold (over about 60 fps at the defaults) no event is left out:
    only at low frame rates can real motion break at all. Used for the
    confirmation (:func:`~mocapkit.cleaning.ssa.detect`'s ``jumps``), not the
    side swaps, whose step onto the partner's mirror image is evidence that
    speed does not explain. What it costs: at
    24-30 fps an error smaller than about twice the speed of a fast-moving
    joint confirms nothing. ``q`` (F, J, 4) rotations, ``resid`` (F, J)
    radians (:func:`midpoint_residuals`). A cue of this library's
    confirmation, not of the paper (Aristidou et al. 2018 flag ``MDM >
    threshold``, section 3.4).
    """
    out = np.array(breaks, dtype=bool)
    F = len(q)
    if F < 3 or not out.any():
        return out
    step = np.nan_to_num(step_angles(q))  # (F - 1, J): step i is q[i] -> q[i + 1]
    for j in np.flatnonzero(out.any(axis=0)):
        frames = np.flatnonzero(out[:, j])
        first, last, event = event_bounds(frames)
        peak = np.maximum.reduceat(resid[frames, j], np.flatnonzero(np.r_[True, np.diff(event) > 0]))
        before = np.where(first >= 2, step[np.clip(first - 2, 0, F - 2), j], 0.0)
        after = np.where(last + 1 <= F - 2, step[np.clip(last + 1, 0, F - 2), j], 0.0)
        explained = (peak < cap) & (peak <= np.maximum(before, after))
        out[frames[explained[event]], j] = False
    return out


def midpoint_residuals(rotations: np.ndarray) -> np.ndarray:
    """(F, J) radians: angle between ``q[f]`` and the midpoint of ``q[f-1]``, ``q[f+1]``; 0 at the ends and where missing."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.zeros(q.shape[:2])
    if len(q) < 3:
        return out
    out[1:-1] = np.nan_to_num(midpoint_angles(q[:-2], q[1:-1], q[2:]), nan=0.0)
    return out


def midpoint_angles(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(...) radians: angle between ``b`` and the midpoint of ``a`` and ``c`` (their normalised sum, ``c`` on
    ``a``'s side), for unit quaternions (..., 4) of three consecutive frames; NaN where one is missing."""
    c = np.where((np.sum(a * c, axis=-1) < 0)[..., None], -c, c)
    mid = a + c
    norm = np.linalg.norm(mid, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return R.geodesic_angle(b, mid / norm)


def side_swaps(motion: Motion, jump_deg: float = _D.swap_jump_deg, max_s: float = _D.swap_max_s, joints=None) -> np.ndarray:
    """(F, J) bool: left/right label swaps, a joint and its mirror partner breaking together, twice.

    When the labels of the two sides swap, both joints of a left/right pair
    (:func:`mocapkit.motion.mirror_pairs`) jump at the same frame, and again
    when the labels swap back. A break here is a midpoint residual (see
    :func:`discontinuities`) over ``jump_deg`` and over what the joint's own
    motion reaches (:func:`own_breaks`: at low frame rates fast motion has
    large residuals of its own, and a dance swinging both arms at once breaks
    both sides together). Where both joints of a pair break within a frame of
    each other, and again within ``max_s`` seconds, both are flagged from the
    frame after the first break's first frame to the second break's first
    frame (a step between frames f and f + 1 shows at both); the events pair
    up in time order. Each event must also step both joints onto their
    partner's mirror image (:func:`_swap_step`), as a label swap does and a
    mirror-symmetric move of both limbs does not. No smooth motion breaks like
    that, and no digression is needed: a swapped limb often takes a plausible
    pose. ``joints`` (bool (J,), optional) limits the
    pairs to those whose two joints it holds.
    """
    if not (np.isfinite(jump_deg) and jump_deg > 0 and max_s > 0):
        raise ValueError(f"need jump_deg > 0 and max_s > 0, got {jump_deg!r} and {max_s!r}")
    q = np.asarray(motion.rotations, dtype=np.float64)
    return swaps_from_residuals(midpoint_residuals(q), motion.skeleton.joint_names, motion.fps, jump_deg, max_s, joints,
                                rotations=q, mirrored=mirrored_rotations(motion))


def mirrored_rotations(motion: Motion) -> np.ndarray | None:
    """(F, J, 4) the rotations of the take's mirror image on its own skeleton (each joint takes its partner's
    reflected rotation: :func:`mocapkit.mirroring.mirror_for_rig`, which is ``motion.mirror()`` on rigs that
    reflect onto themselves), or None on a rig that cannot be mirrored (no left/right pairs by name)."""
    from ...errors import SkeletonError
    from ...mirroring import mirror_for_rig

    try:
        return np.asarray(mirror_for_rig(motion).rotations, dtype=np.float64)
    except SkeletonError:
        return None


def swaps_from_residuals(resid, joint_names, fps, jump_deg, max_s, joints, rotations=None, mirrored=None,
                         held=None) -> np.ndarray:
    """:func:`side_swaps` on midpoint residuals already computed (:func:`midpoint_residuals`).

    With ``rotations`` (F, J, 4) and ``mirrored`` (the take's
    :meth:`~mocapkit.motion.Motion.mirror` rotations, F, J, 4) each break
    event must also look like a swap (:func:`_swap_step`). ``held`` (F, J)
    bool (None: none): the break frames of swaps with one break
    (:func:`~mocapkit.cleaning.ssa.edge_swaps.edge_swaps`), held on both
    joints of the pair: that swap's, paired with no other
    (:func:`~mocapkit.cleaning.ssa.events.pair_events`).
    """
    from ...motion import mirror_pairs

    F, J = resid.shape
    out = np.zeros((F, J), dtype=bool)
    use = np.ones(J, dtype=bool) if joints is None else np.asarray(joints, dtype=bool)
    breaks = own_breaks(resid, jump_deg, fps)
    perm = mirror_pairs(joint_names)
    longest = int(round(max_s * fps))
    for j in range(J):
        p = int(perm[j])
        if p <= j or not (use[j] and use[p]):
            continue
        first, last = pair_events(breaks, j, p, held)
        if not len(first):
            continue
        starts, whole, hidden = [int(f) for f in first], [], []
        if rotations is not None and mirrored is not None:
            whole = [_whole_swap(rotations, mirrored, int(f), int(l), j, p) for f, l in zip(first, last)]
            starts = [f for f, w in zip(starts, whole) if w is None
                      and _swap_step(rotations, mirrored, f, j) and _swap_step(rotations, mirrored, f, p)]
            if any(w is not None for w in whole):  # the steps the own level hides judge a tie of two readings
                hidden = swap_step_events(rotations, mirrored, residual_breaks(resid, jump_deg), j, p)[1]
                hidden = [h for h, e in zip(*hidden) if not ((first <= e + 2) & (last >= h - 1)).any()]
        for a, b in swap_reading(starts, [w for w in whole if w is not None], longest, hidden):
            out[a + 1 : b + 1, j] = out[a + 1 : b + 1, p] = True  # a step from f to f + 1 breaks at both
    return out


def swap_reading(starts, whole, longest: int, hidden=()) -> list[tuple[int, int]]:
    """The swaps ``(a, b)`` (steps ``a -> a + 1`` into the swap and ``b -> b + 1`` out of it) that a pair's break
    events read as: ``starts`` the first frames of the events of one swap step each, ``whole`` the steps ``(a, ...,
    b)`` of the events that hold two or more (:func:`_whole_swap`), ``longest`` the most frames a swap spans.

    An event of two steps is a whole short swap, or the clean frames between two swaps: the first swap's step out
    and the next one's step in (a label swap is undone by the next step onto the partner's mirror image). The
    second reading splits those events into their steps and pairs every step in time order
    (:func:`_paired_events`); it is taken where it leaves fewer steps unpaired than the first (the events of one
    step paired in time order beside the whole swaps, an event's steps between its first and last unpaired), or
    as many while a whole swap lies inside a swap the first pairs (its frames exchanged twice, so back as they
    came), or, the two still even, where it wins so with the ``hidden`` steps paired too: the pair's swap steps
    the joints' own level hides (:func:`~mocapkit.cleaning.ssa.edge_swaps.swap_step_events` outside every event
    of ``starts`` and ``whole``), which the exchange of the swap they bound proves later
    (:func:`~mocapkit.cleaning.ssa.swap_exchange.joined_swaps`). Bandai Namco call_normal_001 with
    ``corrupt.real_errors(kinds=("swap",), seed=0)``: the feet swapped over frames 43-57 and 62-75 break at 42,
    57, 61 and 75, the middle two one event; read whole, that event is a swap over the clean frames 58-61 and
    neither real swap is found. An event of three steps is a one-frame swap beside another swap: read whole, its
    first and last steps swap the frames between, one of them clean.
    """
    whole = [tuple(int(a) for a in w) for w in whole]
    pairs = _paired_events(starts, longest)
    if not whole:
        return pairs
    ends = [(w[0], w[-1]) for w in whole]
    split = _paired_events(sorted(list(starts) + [f for w in whole for f in w]), longest)

    def split_wins(starts):  # (the split reading wins, the two leave as many steps unpaired)
        steps = sorted(list(starts) + [f for w in whole for f in w])
        left = len(starts) - 2 * len(_paired_events(starts, longest)) + sum(len(w) - 2 for w in whole)
        left_split = len(steps) - 2 * len(_paired_events(steps, longest))
        nested = any(a <= c and d <= b for a, b in _paired_events(starts, longest) for c, d in ends)
        return left_split < left or left_split == left and nested, left_split == left

    wins, even = split_wins(starts)
    if even and not wins and len(hidden):
        wins = split_wins(sorted(list(starts) + [int(h) for h in hidden]))[0]
    return split if wins else pairs + ends


def _whole_swap(q: np.ndarray, mirrored: np.ndarray, first: int, last: int, j: int, p: int) -> tuple | None:
    """``(a, ..., b)``, the steps ``a -> a + 1`` and ``b -> b + 1`` that swap joints ``j`` and ``p`` and swap them
    back, when one break event (frames ``first .. last``, :func:`event_bounds`) holds a whole swap, with the steps
    between them that do so too (a one-frame swap beside another swap: three steps); else None.

    A swap of 1-4 frames breaks at frames at most 3 apart, which group into one event; paired with the next
    event it flagged the clean frames up to that one (a 4-frame swap of a waving forearm and a swap 1 s later
    were one flag on 30 fps Bandai Namco, 26 clean frames repaired up to 21 deg off). Both joints step onto
    their partner's mirror image (:func:`_swap_step`) at the event's first step (starting at ``first`` or
    ``first + 1``) and back at its last (starting at ``last - 1`` or ``last``), a later one.
    """
    F = len(q)

    def both(a):
        return a + 1 < F and _swap_step(q, mirrored, a, j, tries=1) and _swap_step(q, mirrored, a, p, tries=1)

    offs = [a for a in (first, first + 1) if a < last - 1 and both(a)]
    backs = [b for b in (last - 1, last) if offs and b > offs[0] and both(b)]
    if not backs:
        return None
    return (offs[0], *[m for m in range(offs[0] + 1, backs[0]) if both(m)], backs[0])


def _swap_step(q: np.ndarray, mirrored: np.ndarray, f: int, j: int, ratio: float = 0.5, tries: int = 2) -> bool:
    """Whether joint ``j`` steps at ``f -> f + 1`` (or ``f + 1 -> f + 2``) onto its partner's mirrored rotation.

    When labels swap (or swap back), the joint's new rotation is the mirror
    image of its partner's rotation just before: it lies within ``ratio`` of
    the step's size of ``mirrored[f, j]``. A dance move that swings both arms
    at once in mirror symmetry breaks both sides together too, but there the
    partner's mirror image is the joint's own pose, as far from the new
    rotation as the step itself.
    """
    F = len(q)
    for a in range(f, f + tries):  # (f, f + 1): the break frames of a step from f to f + 1 are f and f + 1
        if a + 1 >= F:
            break
        own = float(R.geodesic_angle(q[a + 1, j], q[a, j]))
        partner = float(R.geodesic_angle(q[a + 1, j], mirrored[a, j]))
        if partner < ratio * own:
            return True
    return False


def _paired_events(starts, longest: int, match=None, skip=()) -> list[tuple[int, int]]:
    """Successive events paired in time order, ``(start k, start k + 1)``, where the second starts at most
    ``longest`` frames after the first and ``match(k, k + 1)`` holds (if given); a paired event is not paired
    again, nor one of ``skip`` (indices paired already) (:func:`side_swaps`, :func:`transient_offsets`)."""
    pairs, k = [], 0
    while k + 1 < len(starts):
        if k in skip or k + 1 in skip:
            k += 1
        elif starts[k + 1] - starts[k] <= longest and (match is None or match(k, k + 1)):
            pairs.append((int(starts[k]), int(starts[k + 1])))
            k += 2
        else:
            k += 1
    return pairs


def transient_offsets(
    motion: Motion,
    jump_deg: float = _D.offset_jump_deg,
    max_s: float = _D.offset_max_s,
    min_offset_deg: float = _D.offset_min_deg,
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
    near 180 deg pair either way), the second turning at least half as far
    as the first (:func:`~mocapkit.cleaning.ssa.step_pairs.returns`: a twitch
    after a step leaves the joint as far off), each event a step and not a burst of several frames
    (:func:`~mocapkit.cleaning.ssa.step_pairs.is_step`) and start at most ``max_s`` apart are
    flagged from the frame after the first event's first frame to the second
    event's first frame (a step between frames f and f + 1 shows at both).
    Pairs are taken in time order, as in :func:`side_swaps`, after the pairs
    whose second step undoes the first (equal and opposite: :func:`offsets_from_residuals`,
    which :func:`~mocapkit.cleaning.ssa.detect` also lets pair across the joint's
    own steps between them). A pair whose two
    steps another joint (not the mirror partner) takes at the same frames is
    left out (:func:`_single_joint_offsets`): a limb moving at once is
    motion, an error moves one joint. ``joints`` (bool (J,),
    optional) limits the joints looked at.
    """
    if not (np.isfinite(jump_deg) and jump_deg > 0 and max_s > 0 and min_offset_deg >= 0):
        raise ValueError(
            f"need jump_deg > 0, max_s > 0 and min_offset_deg >= 0, got {jump_deg!r}, {max_s!r} and {min_offset_deg!r}"
        )
    q = np.asarray(motion.rotations, dtype=np.float64)
    return offsets_from_residuals(q, midpoint_residuals(q), motion.fps, jump_deg, max_s, min_offset_deg, joints,
                                  motion.skeleton.joint_names, motion.skeleton.parents)


def _usual_residual(resid: np.ndarray) -> np.ndarray:
    """(J,) radians: what a joint's own motion reaches, three times its 95th-percentile midpoint residual.

    In a take under 160 frames the percentile is taken below the 8 largest
    residuals instead, so that one error's breaks (2 frames a step) do not
    raise it. At 120 fps this stays under the break thresholds; at 30 fps
    fast motion breaks too (a dancer's toes push off by 25 deg in one frame
    and come back), and a break must stand out from the joint's own motion.
    Used through :func:`own_breaks`: on a joint under heavy noise it can rise
    past a flip's 90 deg residuals (the noise itself is the denoise step's).
    """
    F = resid.shape[0]
    return 3.0 * np.percentile(resid, min(95.0, 100.0 * (1.0 - 8.0 / F)), axis=0)


def event_steps(q: np.ndarray, first: np.ndarray, last: np.ndarray, own_frame: bool = False) -> np.ndarray:
    """(n, 3) rotation vectors (radians, parent frame) from a joint's path before each event to its path after it.

    ``q`` (F, 4) the joint's track; event i spans frames ``first[i] ..
    last[i]``. Each path is the constant-velocity line through the two frames
    on its side (``q[first - 2]``, ``q[first - 1]`` and ``q[last + 1]``,
    ``q[last + 2]``), and both are taken at the event's middle. A step (the
    joint jumps onto a parallel path, as a drift or flip starts and ends)
    gives its size; a kink (the joint stops or turns sharply, the paths
    meeting inside the event) gives about nothing, and constant acceleration
    cancels exactly, however coarse the frame rate. NaN rows where the event
    touches the take's ends. All events at once, row by row the values of
    one event at a time. ``own_frame``: the step in the joint's own frame
    instead (``after = before * step``, as a flip about the bone turns it).
    """
    first, last = np.asarray(first, dtype=np.int64), np.asarray(last, dtype=np.int64)
    out = np.full((len(first), 3), np.nan)
    ok = (first >= 2) & (last + 2 < len(q))
    if not ok.any():
        return out
    f, l = first[ok], last[ok]
    a, b, c, d = (np.array(q[i], dtype=np.float64) for i in (f - 2, f - 1, l + 1, l + 2))
    a = np.where((_row_dots(a, b) < 0)[:, None], -a, a)
    d = np.where((_row_dots(c, d) < 0)[:, None], -d, d)
    half = (0.5 * (l + 2 - f))[:, None]  # frames from first - 1 (and from last + 1) to the middle
    before = R.quaternion_multiply(R.rotvec_to_quaternion(half * _velocity(a, b)), b)
    after = R.quaternion_multiply(R.rotvec_to_quaternion(-half * _velocity(c, d)), c)
    step = (R.quaternion_multiply(R.quaternion_inverse(before), after) if own_frame
            else R.quaternion_multiply(after, R.quaternion_inverse(before)))
    out[ok] = R.quaternion_to_rotvec(step)
    return out


def _row_dots(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) ``np.dot(a[i], b[i])`` of (n, k) rows, for sign tests: summed at once, and by ``np.dot`` itself
    (whose BLAS sum may round otherwise) where the sum is too near 0 for its sign to be sure."""
    out = np.sum(a * b, axis=-1)
    for i in np.flatnonzero(np.abs(out) < 1e-9):
        out[i] = np.dot(a[i], b[i])
    return out


def row_norms(v: np.ndarray) -> np.ndarray:
    """(n,) ``np.linalg.norm(v[i])`` of (n, k) rows, each by the 1-D call (the square root of a BLAS dot
    product, which a sum along the rows may round otherwise); NaN rows NaN. For float64 rows the same dot
    product and square root as that call (``x.dot(x)`` of the contiguous row, then ``sqrt``: bit for bit), without
    its per-call checks."""
    v = np.asarray(v)
    if v.dtype != np.float64 or v.ndim != 2:
        return np.array([np.linalg.norm(r) for r in v], dtype=np.float64)
    v = np.ascontiguousarray(v)  # each row contiguous, as ``norm``'s ``ravel`` leaves it
    return np.sqrt(np.array([r.dot(r) for r in v], dtype=np.float64))


def _velocity(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation vector (radians per frame, parent frame) of the step from ``a`` to ``b``."""
    return R.quaternion_to_rotvec(R.quaternion_multiply(b, R.quaternion_inverse(a)))


def _compensated(q: np.ndarray, parents, j: int, first, last, depth: int = 3, ratio: float = 0.5) -> np.ndarray:
    """(n,) bool: whether joint ``j``'s break across each event is undone within its chain: a representation jump.

    Some solvers share one turn between the joints of a chain and, from
    one frame to the next, share it another way (the HDM05 spine: the
    lower back turns 17 deg in one frame and the thorax turns back, so the
    upper body does not move). The joint's own rotation jumps, but the
    chain's composed rotation from an ancestor to a descendant (``depth``
    levels at most each way) does not. An error in one joint breaks every
    such composed rotation's track as much as the joint's own (the error
    ``e`` in ``A q e B`` leaves ``B^-1 e B``, a turn of the same angle); here
    some chain breaks less than ``ratio`` times as much. A break is the
    largest midpoint residual (:func:`midpoint_angles`) over the event's
    frames ``first[i] .. last[i]`` (n,): the departure from the smooth path
    through each frame's neighbours, whichever way the error turns and
    whatever the rest of the chain does meanwhile (the chain's own motion
    is second order in time; the turn from the frame before the event,
    which this compared once, adds a 30 fps stride's first-order motion and
    called a thigh error compensated or not by its direction). ``q``
    (F, J, 4) local rotations, ``parents`` (J,). All of the joint's events
    at once: the frames ``first - 1 .. last + 1`` of each are stacked and the
    largest residuals taken per event.
    """
    first, last = np.asarray(first, dtype=np.int64), np.asarray(last, dtype=np.int64)
    f0, f1 = np.maximum(first - 1, 0), np.minimum(last + 1, len(q) - 1)
    out = np.zeros(len(first), dtype=bool)
    chains = chain_table(parents, j, depth)
    has = f1 - f0 >= 2  # an event with a frame between two others
    if not has.any() or not len(chains):
        return out
    frames, event, start = segment_frames(f0[has], f1[has] - f0[has] + 1)  # f0 .. f1 of each event
    at = np.asarray(q[frames], dtype=np.float64)  # (T, J, 4)
    inner = np.ones(len(event), dtype=bool)
    inner[start] = False
    inner[np.append(start[1:], len(event)) - 1] = False  # each event's first and last rows are neighbours only
    rows = np.flatnonzero(inner)
    firsts = start - 2 * np.arange(len(start))  # each event's first row among the inner ones
    own = np.maximum.reduceat(midpoint_angles(at[rows - 1, j], at[rows, j], at[rows + 1, j]), firsts)
    composed = at[:, chains[:, 0]]  # (T, C, 4): each chain's rotation from its root-side joint down
    for i in range(1, chains.shape[1]):
        on = chains[:, i] >= 0
        composed[:, on] = R.quaternion_multiply(composed[:, on], at[:, chains[on, i]])
    turns = np.maximum.reduceat(midpoint_angles(composed[rows - 1], composed[rows], composed[rows + 1]), firsts,
                                axis=0)  # (n, C)
    out[has] = (own > 0) & (turns < ratio * own[:, None]).any(axis=1)
    return out


def chain_table(parents, j: int, depth: int = 3) -> np.ndarray:
    """(C, L) int: the chains through joint ``j`` that :func:`_compensated` composes, root side first, -1 padded.

    A chain runs from ``j`` or one of its ancestors (``depth`` levels up
    at most) down through ``j`` to ``j`` or one of its descendants
    (``depth`` levels down at most); the chain of ``j`` alone is left out.
    """
    parents = np.asarray(parents)
    ups = [j]  # ancestors of j (and j), nearest first
    while len(ups) <= depth and parents[ups[-1]] >= 0:
        ups.append(int(parents[ups[-1]]))
    downs, frontier = [[]], [(j, [])]  # paths below j
    for _ in range(depth):
        frontier = [(int(c), path + [int(c)]) for k, path in frontier for c in np.flatnonzero(parents == k)]
        downs += [path for _c, path in frontier]
    chains = [ups[n_up::-1] + below for n_up in range(len(ups)) for below in downs if n_up or below]
    if not chains:
        return np.zeros((0, 1), dtype=np.intp)
    table = np.full((len(chains), max(map(len, chains))), -1, dtype=np.intp)
    for i, c in enumerate(chains):
        table[i, : len(c)] = c
    return table


def offsets_from_residuals(q, resid, fps, jump_deg, max_s, min_offset_deg, joints, joint_names=None,
                           parents=None, digression=None) -> np.ndarray:
    """:func:`transient_offsets` on rotations ``q`` (F, J, 4) with their midpoint residuals already computed.

    ``joint_names`` (optional) name the mirror partners (:func:`mocapkit.motion.mirror_pairs`) that
    :func:`_single_joint_offsets` does not count as sharing a joint's steps; ``parents`` (optional, (J,))
    lets :func:`_compensated` leave out the steps the joint's chain undoes.

    A step back that undoes a step off (:data:`~mocapkit.cleaning.ssa.step_pairs.UNDO_RATIO`: equal and opposite, in the parent's frame or in
    the joint's own) is paired with it first, also where other events of the joint lie between them: a joint's
    own steps while it is off (the CMU 131_01 right wrist turns 133 deg in 4 frames) leave the offset's two
    steps apart, and paired only in turn the error went unflagged (:func:`_undoing_pairs`). With
    ``digression`` (F, J) radians (NaN: not judged) given, such a pair with events between counts only where
    the stretch between digresses from the neighbour words and the frames beside it do not
    (:func:`stands_out`); without, only successive events pair. The events left pair in turn as before, loosely
    (two roughly opposite steps, each a jump and not a burst: :mod:`~mocapkit.cleaning.ssa.step_pairs`).
    """
    from ...motion import mirror_pairs

    F, J = resid.shape
    partner = None if joint_names is None else mirror_pairs(joint_names)
    pairs: dict = {}
    use = np.ones(J, dtype=bool) if joints is None else np.asarray(joints, dtype=bool)
    breaks = own_breaks(resid, jump_deg)
    longest = int(round(max_s * fps))
    half_turn = np.radians(150.0)
    for j in np.flatnonzero(use & breaks.any(axis=0)):
        first, last, _ = event_bounds(np.flatnonzero(breaks[:, j]))
        step = event_steps(q[:, j], first, last)
        keep = row_norms(step) >= np.radians(min_offset_deg)  # NaN (ends of the take): not kept
        if parents is not None and keep.any():
            keep[keep] = ~_compensated(q, parents, int(j), first[keep], last[keep])
        starts, steps = [int(f) for f in first[keep]], list(step[keep])
        spans = (last[keep] - first[keep] + 1).tolist()
        own = event_steps(q[:, j], first[keep], last[keep], own_frame=True)

        def back(k, m):  # the second step points roughly opposite the first (a half turn has no sign)
            na, nb = np.linalg.norm(steps[k]), np.linalg.norm(steps[m])
            cos = float(np.dot(steps[k], steps[m]) / (na * nb)) if na > 0 and nb > 0 else 1.0
            opposite = cos <= -0.5 or (max(na, nb) > half_turn and abs(cos) >= 0.5)
            return opposite and returns(steps[k], steps[m])  # and turns back half as far at least

        def undoes(k, m):  # the second step is the first one's inverse, in one frame or the other
            return steps_back((np.asarray(steps), own), k, m, UNDO_RATIO)

        def apart(a, b):  # a pair with events between: the stretch alone differs from the neighbour words
            return digression is not None and stands_out(digression[:, j], a + 1, b + 1)

        def loose_pair(k, m):  # roughly opposite steps, each a jump between two frames, not a burst
            return back(k, m) and is_step(spans[k]) and is_step(spans[m])

        strict = _undoing_pairs(starts, longest, undoes, apart)
        taken = {k for pair in strict for k in pair}
        loose = _paired_events(starts, longest, loose_pair, skip=taken)
        pairs[j] = sorted([(starts[k], starts[m]) for k, m in strict] + loose)
    events = {int(k): event_bounds(np.flatnonzero(breaks[:, k]))[0] for k in np.flatnonzero(breaks.any(axis=0))}
    return _single_joint_offsets(pairs, F, J, partner, events)


def _undoing_pairs(starts, longest: int, undoes, apart) -> list[tuple[int, int]]:
    """``(k, m)`` index pairs of events, in time order, where event ``m`` starts at most ``longest`` frames after
    event ``k`` and ``undoes(k, m)``: the nearest such ``m`` whose events between are not paired yet, and, where
    there are events between, ``apart(starts[k], starts[m])`` holds (:func:`offsets_from_residuals`)."""
    taken = np.zeros(len(starts), dtype=bool)
    out = []
    for k in range(len(starts)):
        if taken[k]:
            continue
        m = k + 1
        while m < len(starts) and starts[m] - starts[k] <= longest and not taken[m]:
            if undoes(k, m) and (m == k + 1 or apart(starts[k], starts[m])):
                out.append((k, m))
                taken[k] = taken[m] = True
                break
            m += 1
    return out


def stands_out(digression: np.ndarray, a: int, b: int) -> bool:
    """Whether frames ``a .. b - 1`` of a joint's ``digression`` (F,) radians (NaN: not judged) digress from the
    neighbour words, as a median, at least twice as much as the as many frames on either side of them do (an
    offset is the take's alone; where the motion beside digresses as much, nothing marks the stretch as an
    error). A side with fewer than half its frames judged does not count; False where the stretch has fewer
    than half its frames judged, or neither side counts."""
    n = b - a
    medians = []
    for part in (digression[a:b], digression[max(a - n, 0) : a], digression[b : b + n]):
        part = part[np.isfinite(part)]
        medians.append(float(np.median(part)) if 2 * len(part) >= n else np.nan)
    inside, beside = medians[0], [m for m in medians[1:] if np.isfinite(m)]
    return bool(np.isfinite(inside) and beside and inside >= 2.0 * max(beside))


def unshared_offsets(offsets: np.ndarray, digression: np.ndarray, min_offset_deg: float) -> np.ndarray:
    """``offsets`` (F, J) bool without the runs the joint's neighbour words share (Aristidou et al. 2018, sec. 3.4).

    A transient offset (:func:`transient_offsets`) whose frames stay, as a median, within half of
    ``min_offset_deg`` of the mean motion texture is held the same way by the similar motion: the
    joint's own motion, not an error (a game rig's toe bending in one 30 fps frame as the foot rolls
    and staying bent, which repair "put back" by 30 degrees on untouched Bandai Namco runs). An
    error's offset is the take's alone, so the mean texture is off it by about the offset itself.
    ``digression`` (F, J) radians, NaN where not judged: a run with no judged frame is kept (no
    evidence either way).
    """
    out = np.array(offsets, dtype=bool)
    half = np.radians(float(min_offset_deg)) / 2.0
    for j in np.flatnonzero(out.any(axis=0)):
        for a, b in contact_segments(out[:, j]):
            d = digression[a:b, j]
            d = d[np.isfinite(d)]
            if len(d) and float(np.median(d)) < half:
                out[a:b, j] = False
    return out


def _single_joint_offsets(pairs: dict, F: int, J: int, partner: np.ndarray | None, events: dict) -> np.ndarray:
    """(F, J) bool from each joint's paired events ``{j: [(a, b), ...]}``, leaving out the pairs another joint
    (not its mirror partner) shares: it breaks within a frame of both steps (``events``, ``{k: first frames}``:
    every joint's break events, paired or not, a joint's counting with its mirror partner's).

    A drift, a flip or a lost marker moves one joint's rotation; a limb or a
    body that steps off and back at once (the hip, knee and ankle of a leg
    bouncing at the bottom of a squat, the upper arm and wrist of a throw)
    moves several joints at the same frames, and that is motion. A mirror
    partner stepping with it is left to :func:`side_swaps`. The other joint's steps need not pair with each
    other, and its partner's count: an error of its own between them pairs them otherwise, and a left/right
    swap over one moves it into the partner (HDM05 ``HDM_dg_lieDownFloor_011``: the thigh turns half a turn
    about its bone as the knee bends the other way, frames 92-151, the joints' positions on their path; with
    a thigh swap at 95-112 the knee's steps pair alone, and repaired they move the foot about a shin length off it).
    """
    out = np.zeros((F, J), dtype=bool)
    for j, pj in pairs.items():
        others = [k for k in events if k != j and (partner is None or k != partner[j])]
        for a, b in pj:
            shared = any(
                _breaks_near(events, k, partner, a) and _breaks_near(events, k, partner, b) for k in others
            )
            if not shared:
                out[a + 1 : b + 1, j] = True  # a step from f to f + 1 breaks at both
    return out


def _breaks_near(events: dict, k: int, partner: np.ndarray | None, f: int) -> bool:
    """Whether joint ``k`` or its mirror partner has a break event starting within a frame of frame ``f``."""
    own = {k} if partner is None else {k, int(partner[k])}
    return any(np.any(np.abs(np.asarray(events.get(i, ()), dtype=np.int64) - f) <= 1) for i in own)


def confirm_flags(
    mdm: np.ndarray, jumps: np.ndarray, threshold: float, fps: float, margin_s: float = _D.confirm_margin_s, extent: float = 0.5,
    spikes: np.ndarray | None = None,
) -> np.ndarray:
    """Error flags (F, J) from an MDM confirmed by the joint's own discontinuities (see :func:`detect`).

    Per joint, a run is a connected stretch of frames with ``mdm > extent * threshold`` or within ``margin_s``
    seconds of a ``jumps`` frame of the same joint (so the digression on the two sides of a break is one run);
    its cells with ``mdm > extent * threshold`` are flagged when it reaches ``mdm > threshold`` somewhere and
    one of them lies within the margin of the break. So every flagged run both digresses clearly and holds a
    break no smooth motion makes. Which of a run's frames are flagged, its breaks say
    (:mod:`~mocapkit.cleaning.ssa.run_extent`): a run whose breaks are all ``spikes``, the spikes' own frames,
    digressing or not; one that holds two breaks or more (separate steps), its digressing frames from its
    first to its last break, within ``margin_s``: an error starts and ends with a break, and beyond them the
    digression comes from the neighbour words the error itself led astray (a word spans 0.6 s), not from more
    error, and repairing there would replace clean frames. A run with one break (a drift that grows
    smoothly, a frozen channel, each ending in a step) keeps its frames before the break, not those after it:
    an error ends with a break, and past its last one the joint is back on its path, whatever the digression
    says there (the neighbour words the error led astray, the take's own motion that nothing repeats: on 30
    fps Bandai Namco takes, 30 frames after a frozen upper arm were repaired 65 deg off); with none digressing
    before its break, none. ``mdm`` float (F, J) in [0, 1]; ``jumps`` bool (F, J).
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
        j = cols.start
        if keep[lab] and jumps[rows, j].any():  # the frames its breaks give it (run_extent)
            out[rows, j] = run_cells(low[rows, j], jumps[rows, j], None if spikes is None else spikes[rows, j], n)
    return out


#: The rules that flag a cell, in the order of the bits of :func:`flag_causes` (bit ``i`` is ``1 << i``), and the
#: words a report says them in.
CAUSES = (
    ("break", "a digression its own break confirms"),
    ("held", "held still while the similar motion moves"),
    ("swap", "a left/right swap"),
    ("offset", "a transient offset (a step off its path and back)"),
    ("drift", "a smooth drift (off its neighbours' path, no break)"),
    ("digression", "a digression over the threshold"),
    ("teleport", "the root's path jumps away and back (wrong root samples)"),
    ("spike", "a spike far past the joint's own motion, where no similar motion judges it"),
    ("reversed", "a stretch played backwards (time-reversed), not a left/right swap"),
    ("frozen", "one rotation repeated bit for bit while the body moves, then a break (a frozen channel)"),
    ("flip", "turned 180 deg in one frame (a turn-over, mocapkit.cleaning.ssa.flips)"),
)
#: the integer type of :func:`flag_causes` (one bit per entry of :data:`CAUSES`)
CAUSE_DTYPE = np.uint16


def flag_causes(mdm, jumps, holds, swaps, offsets, threshold: float, fps: float, confirm: bool, margin_s,
                drifts=None, spikes=None, judged=None, lone=None, reversed_=None, frozen=None) -> np.ndarray:
    """(F, J) :data:`CAUSE_DTYPE`: which rules flag each cell, one bit per entry of :data:`CAUSES` (0: not flagged).

    The arguments are :func:`flag_rule`'s, whose flags are exactly the cells with a bit set: with ``confirm``,
    digressions confirmed by a break (:func:`confirm_flags`), holds, swaps, transient offsets and smooth drifts
    (``drifts``, bool (F, J) or None: none) and the :func:`~mocapkit.cleaning.ssa.spikes.lone_spikes` (``lone``, bool
    (F, J) or None: none); the breaks that are the two steps of a flagged offset that is no swap (the offsets repair
    takes away) confirm no digression (:func:`~mocapkit.cleaning.ssa.step_pairs.offset_step_breaks`); without, ``mdm >
    threshold`` alone (the "digression" bit). A cell two rules flag has both bits, so a report can say why each change
    was made. ``reversed_`` (F, J) bool or None: the swap cells whose run plays better backwards
    (:func:`~mocapkit.cleaning.ssa.reversals.reversed_runs`), named ``reversed`` instead of ``swap`` (the same cells
    flagged). ``frozen`` (F, J) bool or None: the frozen channels
    (:func:`~mocapkit.cleaning.ssa.freezes.frozen_channels`), judged or not: the break that ends one confirms its
    frozen cells only (:func:`~mocapkit.cleaning.ssa.freeze_bounds.bounded_breaks`).
    """
    bit = {name: CAUSE_DTYPE(1 << i) for i, (name, _) in enumerate(CAUSES)}
    mdm = np.asarray(mdm)
    out = np.zeros(mdm.shape, dtype=CAUSE_DTYPE)
    if not confirm:
        out[mdm > threshold] = bit["digression"]
        return out
    breaks = jumps if judged is None else np.asarray(jumps, dtype=bool) & np.asarray(judged, dtype=bool)
    swaps = np.asarray(swaps, dtype=bool)
    breaks = breaks & ~offset_step_breaks(breaks, np.asarray(offsets, dtype=bool) & ~swaps)  # confirm nothing beside
    back = np.zeros_like(swaps) if reversed_ is None else swaps & np.asarray(reversed_, dtype=bool)
    confirmed = bounded_breaks(lambda b: confirm_flags(mdm, b, threshold, fps, margin_s, spikes=spikes), breaks, frozen)
    rules = [("break", confirmed), ("held", holds),
             ("swap", swaps & ~back), ("reversed", back), ("offset", offsets)] + ([] if drifts is None else [("drift", drifts)]) + (
                 [] if lone is None else [("spike", lone)]) + ([] if frozen is None else [("frozen", frozen)])
    for name, cells in rules:
        out[np.asarray(cells, dtype=bool)] |= bit[name]
    return out


def cause_names(causes) -> list[str]:
    """The words of :data:`CAUSES` for the bits set anywhere in ``causes`` (an int or an array of them), in order."""
    seen = int(np.bitwise_or.reduce(np.asarray(causes, dtype=CAUSE_DTYPE).ravel())) if np.size(causes) else 0
    return [words for i, (_, words) in enumerate(CAUSES) if seen & (1 << i)]


def flag_rule(mdm, jumps, holds, swaps, offsets, threshold: float, fps: float, confirm: bool, margin_s,
              drifts=None, spikes=None, judged=None, lone=None, reversed_=None) -> np.ndarray:
    """The flags of :func:`detect` and :meth:`Detection.with_threshold`: confirmed digressions, holds, swaps,
    transient offsets and smooth drifts (``drifts``, bool (F, J) or None: none), or the paper's ``mdm > threshold``
    without confirmation. ``spikes``: :func:`~mocapkit.cleaning.ssa.spikes.spike_breaks` of the take (None: no run is
    cut as a spike's, as in detections made before it). ``judged`` (F, J) bool, the cells the context judged (a finite
    digression; None: all): a break outside them confirms no digression. The digression beside such a break (at a
    take's end that no neighbour word covers) says nothing about the break, and repairing it would change the frames
    before an error and leave the error. Which rule flags each cell: :func:`flag_causes`; ``lone``:
    :func:`~mocapkit.cleaning.ssa.spikes.lone_spikes` (None: none); ``reversed_`` names cells only."""
    return flag_causes(mdm, jumps, holds, swaps, offsets, threshold, fps, confirm, margin_s, drifts, spikes,
                       judged, lone, reversed_) != 0


def uncompensated_breaks(q: np.ndarray, parents, breaks: np.ndarray, memo: dict | None = None) -> np.ndarray:
    """``breaks`` (F, J) bool without the break events whose turn the joint's chain undoes (:func:`_compensated`).

    A solver that shares a spine's bend between the lower back and the
    thorax another way from one frame to the next breaks both joints'
    tracks while the body does not move: no evidence of an error, so such
    breaks confirm no digression. ``q`` (F, J, 4) local rotations,
    ``parents`` (J,); events are grouped as :func:`event_bounds` does.
    ``memo``: a dict ``(joint, first, last) -> compensated`` of the events already judged on this ``q`` and
    ``parents`` (another call's), read and added to: an event's answer is its own, whichever events it is judged
    with, so the events found again are not judged again (detection's breaks and :func:`~mocapkit.cleaning.ssa.spikes.lone_spikes`').
    """
    out = np.array(breaks, dtype=bool)
    for j in np.flatnonzero(out.any(axis=0)):
        frames = np.flatnonzero(out[:, j])
        first, last, event = event_bounds(frames)
        if memo is None:
            comp = _compensated(q, parents, int(j), first, last)
        else:
            keys = [(int(j), int(a), int(b)) for a, b in zip(first, last)]
            todo = np.array([key not in memo for key in keys], dtype=bool)
            if todo.any():
                found = _compensated(q, parents, int(j), first[todo], last[todo])
                memo.update(zip([keys[i] for i in np.flatnonzero(todo)], found.tolist()))
            comp = np.array([memo[key] for key in keys], dtype=bool)
        out[frames[comp[event]], j] = False
    return out


def off_path(q: np.ndarray, first: np.ndarray, last: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(off, turn)`` (n,) radians for the events ``first[i] .. last[i]`` of one joint's track ``q`` (F, 4), none
    touching the take's ends: the largest angle of an event's frames from the slerp between the frames beside it
    (``first - 1`` and ``last + 1``), and the angle between those two frames. Every event's frames at once (the
    same numbers as one event at a time: every step is elementwise)."""
    first, last = np.asarray(first, dtype=np.int64), np.asarray(last, dtype=np.int64)
    if not len(first):
        return np.zeros(0), np.zeros(0)
    frames, event, start = segment_frames(first, last - first + 1)
    lo, hi = q[first - 1], q[last + 1]
    u = (frames - (first - 1)[event]) / (last + 2 - first)[event]
    path = R.slerp(lo[event], hi[event], u)
    return np.maximum.reduceat(R.geodesic_angle(q[frames], path), start), R.geodesic_angle(lo, hi)


def step_angles(q: np.ndarray) -> np.ndarray:
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
    travel_deg: float = _D.hold_travel_deg,
    recur_deg: float = 1.0,
    rest_deg: float = 0.01,
    min_frames: int = 2,
) -> np.ndarray:
    """(F, J) bool: joints held still where the mean motion texture says they move (a frozen channel).

    A hold is a run of at least ``min_s`` seconds (two frames or more) in which the joint turns
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
    held frame (detection flags its repeats only:
    :func:`~mocapkit.cleaning.ssa.freeze_bounds.held_repeats`). Only holds of ``min_frames`` frames or more are
    flagged; shorter ones still count as recurrences
    (under the analysis rate: :func:`~mocapkit.cleaning.ssa.coarse_cues.hold_min_frames`).
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
    speed = np.degrees(step_angles(q)) * motion.fps
    still = (np.nan_to_num(speed, nan=np.inf) < hold_deg_s) & analysed[None, :]  # (F - 1, J) steps
    if not still.any():
        return out
    pose_hold = still[:, analysed].mean(axis=1) >= 0.5
    shortest = max(2, int(np.ceil(min_s * motion.fps)))
    travel = np.nan_to_num(mean_speed) / motion.fps  # degrees per frame
    recur = np.radians(recur_deg)
    for j in np.flatnonzero(still.any(axis=0)):
        if still[:, j].mean() > 0.5:
            continue
        labels, count = ndimage.label(still[:, j] & ~pose_hold)
        runs = [(run.start, run.stop + 1) for (run,) in ndimage.find_objects(labels)]  # held frames a .. b - 1
        runs = [(a, b) for a, b in runs if b - a >= shortest]
        if not runs:
            continue
        held = q[[a for a, _ in runs], j]  # (n, 4) the held rotations
        at_rest = R.geodesic_angle(held, R.identity()) <= np.radians(rest_deg)
        for (a, b), exempt in zip(runs, recurring(held, recur) | at_rest):
            if not exempt and b - a >= min_frames and travel[a:b, j].sum() >= travel_deg:
                out[a:b, j] = True
    return out
