"""Calibration poses: the T-pose or A-pose frames at the start or end of a take, which cleaning leaves alone.

A capture session opens (and often closes) with the actor standing in a
calibration pose: arms straight out to the sides, horizontal (T-pose) or
lowered by about 30-45 degrees (A-pose), legs straight. Converters add one
too: the CMU BVH conversions (cgspeed) put a T-pose at frame 0, one frame
before the motion starts. Such frames are not motion: they share no motion
word with the rest of the take, and the jump from the pose into the first
pose of the motion is a break no smooth motion makes. Left in the analysis,
they are flagged and "repaired", and the break confirms digressions of the
frames after it (a word spans 0.6 s), so the first second of the motion is
rewritten too.

:func:`calibration_poses` finds them from joint *positions* of joints found by
role (:func:`mocapkit.motion.find_joint`: shoulders, elbows, hands, hips,
knees, feet, head), so it works on any humanoid rig whatever its joint names,
rest pose, units or up axis:

- *up* is the direction from the feet's midpoint to the head in that frame
  (a calibration pose stands upright);
- each arm is *straight* (upper arm and forearm within ``straight_deg``, 25 deg)
  and points *sideways* (its horizontal part within ``sideways_deg``, 35 deg, of
  the line from the other shoulder through its own);
- its *elevation* (angle of shoulder -> hand above the horizontal) is within
  ``t_deg`` (20 deg) of 0 for a T-pose, or between -``a_max_deg`` (60) and
  -``t_deg`` for an A-pose, both arms the same kind within ``symmetry_deg``
  (15 deg) of each other;
- each leg is straight (thigh and shank within ``straight_deg``) and hangs
  down (hip -> foot within ``leg_deg``, 25 deg, of straight down).

A calibration pose is the run of such frames that opens the take (from frame
0) or closes it (to the last frame), plus its *transition*: the frames after
an opening pose (before a closing one) whose arms are still out (both arms'
elevation above -``a_max_deg``) and that move like a pose being left, up to
``transition_s`` (0.5 s). A converter's single T-pose frame has none: the
take jumps straight into its motion.

The poses are named in the clean summary ("frames 0-1: calibration T-pose,
left alone"); :func:`calibration_mask` is the (F,) bool of the frames every
cleaning step leaves alone.

Blank frames an exporter wrote before or after the take (every channel 0, the
root's position too: :func:`mocapkit.cleaning.zeros.blank_ends`) are left alone
the same way, as poses of kind :data:`BLANK` outside the calibration poses, and
named for what they are ("frame 195: every channel 0 (a blank frame an exporter
appended); left as it is"): read as motion, the jump into a blank last frame
would read as a root jump of the whole figure, a cut and a turn-over.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..motion import Motion, find_joint
from ..words import frame_span

__all__ = ["CalibrationPose", "calibration_poses", "calibration_mask", "pose_kinds", "BLANK"]

ROLES_USED = ("head", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_hand", "right_hand",
              "left_hip", "right_hip", "left_knee", "right_knee", "left_foot", "right_foot")
NONE, T_POSE, A_POSE = 0, 1, 2
KIND_NAMES = {T_POSE: "T-pose", A_POSE: "A-pose"}
BLANK = "blank"  # the kind of the frames of every channel 0 an exporter wrote before or after the take


@dataclass(frozen=True)
class CalibrationPose:
    """One calibration pose: frames ``[start, stop)`` hold the pose, ``[t_start, t_stop)`` the transition.

    ``kind`` is ``"T-pose"`` or ``"A-pose"``; ``where`` ``"start"`` or ``"end"``
    of the take. :attr:`frames` is the whole span left alone.
    """

    start: int
    stop: int
    kind: str
    where: str
    t_start: int
    t_stop: int

    @property
    def frames(self) -> tuple[int, int]:
        """``(first, stop)``: the pose and its transition together, half-open."""
        return min(self.start, self.t_start), max(self.stop, self.t_stop)

    def __str__(self) -> str:
        a, b = self.frames
        span = frame_span(a, b - 1)
        if self.kind == BLANK:
            put = "appended" if self.where == "end" else "prepended"
            what = f"a blank frame an exporter {put}" if b - a == 1 else f"blank frames an exporter {put}"
            return f"{span}: every channel 0 ({what}); left as {'it is' if b - a == 1 else 'they are'}"
        extra = f" with {self.t_stop - self.t_start} transition frames" if self.t_stop > self.t_start else ""
        return f"{span}: calibration {self.kind}{extra}, left alone"


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Degrees between vectors (..., 3)."""
    return np.degrees(np.arccos(np.clip(np.sum(_unit(a) * _unit(b), axis=-1), -1.0, 1.0)))


def _roles(motion: Motion) -> dict[str, int] | None:
    try:
        return {r: find_joint(motion.skeleton, r) for r in ROLES_USED}
    except KeyError:
        return None


def pose_kinds(
    motion: Motion,
    *,
    t_deg: float = 20.0,
    a_max_deg: float = 60.0,
    straight_deg: float = 25.0,
    sideways_deg: float = 35.0,
    symmetry_deg: float = 15.0,
    leg_deg: float = 25.0,
) -> tuple[np.ndarray, np.ndarray]:
    """``(kind (F,) int, elevation (F, 2) degrees)``: per frame 1 (T-pose), 2 (A-pose) or 0, and each arm's elevation.

    The tests of the module docstring on global joint positions; a rig
    without one of the roles (no arms, no legs) or a frame with missing joints
    gives 0 (and NaN elevations).
    """
    F = motion.num_frames
    kinds = np.zeros(F, dtype=np.int8)
    elev = np.full((F, 2), np.nan)
    roles = _roles(motion)
    if roles is None or F == 0:
        return kinds, elev
    P = motion.global_positions()
    g = {r: P[:, j] for r, j in roles.items()}
    feet = 0.5 * (g["left_foot"] + g["right_foot"])
    up = _unit(g["head"] - feet)
    lateral = g["left_shoulder"] - g["right_shoulder"]  # points to the left
    lateral = _unit(lateral - np.sum(lateral * up, axis=-1, keepdims=True) * up)
    ok = np.ones(F, dtype=bool)
    arm_kind = []
    for side, sign in (("left", 1.0), ("right", -1.0)):
        s, e, h = g[f"{side}_shoulder"], g[f"{side}_elbow"], g[f"{side}_hand"]
        arm = h - s
        el = np.degrees(np.arcsin(np.clip(np.sum(_unit(arm) * up, axis=-1), -1.0, 1.0)))
        elev[:, 0 if side == "left" else 1] = el
        horiz = arm - np.sum(arm * up, axis=-1, keepdims=True) * up
        ok &= _angle(e - s, h - e) <= straight_deg
        ok &= _angle(horiz, sign * lateral) <= sideways_deg
        arm_kind.append(np.where(np.abs(el) <= t_deg, T_POSE, np.where((el < -t_deg) & (el >= -a_max_deg), A_POSE, NONE)))
        hip, knee, foot = g[f"{side}_hip"], g[f"{side}_knee"], g[f"{side}_foot"]
        ok &= _angle(knee - hip, foot - knee) <= straight_deg
        ok &= _angle(foot - hip, -up) <= leg_deg
    same = (arm_kind[0] == arm_kind[1]) & (np.abs(elev[:, 0] - elev[:, 1]) <= symmetry_deg)
    ok &= same & np.all(np.isfinite(P[:, list(roles.values())]), axis=(1, 2))
    kinds[ok] = arm_kind[0][ok]
    return kinds, elev


def calibration_poses(motion: Motion, transition_s: float = 0.5, a_max_deg: float = 60.0) -> tuple[CalibrationPose, ...]:
    """The calibration poses opening and closing ``motion`` (none, one or two), see the module docstring, and
    outside them the blank frames (every channel 0, :func:`mocapkit.cleaning.zeros.blank_ends`) an exporter wrote
    before or after the take, kind :data:`BLANK`: left alone as a pose is, and named for what they are (read as
    motion, the jump into a blank last frame would be a root jump, a cut and a turn-over).

    A take that is a calibration pose (or blank) from end to end gives one pose at the start covering it all.
    """
    from .zeros import blank_ends

    F = motion.num_frames
    if F == 0:
        return ()
    lead, trail = blank_ends(motion)
    if lead == F:
        return (CalibrationPose(0, F, BLANK, "start", F, F),)
    if lead or trail:
        inner = _poses(motion[lead:F - trail], transition_s, a_max_deg)
        shifted = tuple(CalibrationPose(p.start + lead, p.stop + lead, p.kind, p.where, p.t_start + lead,
                                        p.t_stop + lead) for p in inner)
        return ((CalibrationPose(0, lead, BLANK, "start", lead, lead),) if lead else ()) + shifted + (
            (CalibrationPose(F - trail, F, BLANK, "end", F - trail, F - trail),) if trail else ())
    return _poses(motion, transition_s, a_max_deg)


def _poses(motion: Motion, transition_s: float, a_max_deg: float) -> tuple[CalibrationPose, ...]:
    """:func:`calibration_poses` of a take with no blank frame at its ends."""
    F = motion.num_frames
    kinds, elev = pose_kinds(motion, a_max_deg=a_max_deg)
    out = []
    arms_out = np.all(np.nan_to_num(elev, nan=-90.0) > -a_max_deg, axis=1)
    n_trans = max(0, int(round(transition_s * motion.fps)))

    def run(order: np.ndarray) -> int:
        """How many frames, in ``order``, hold one calibration pose kind from the first."""
        k0 = kinds[order[0]]
        if k0 == NONE:
            return 0
        n = 0
        while n < len(order) and kinds[order[n]] == k0:
            n += 1
        return n

    fwd = np.arange(F)
    n = run(fwd)
    if n:
        t = n
        while t < min(F, n + n_trans) and arms_out[t]:
            t += 1
        out.append(CalibrationPose(0, n, KIND_NAMES[int(kinds[0])], "start", n, t))
        if n == F:
            return tuple(out)
    back = fwd[::-1]
    m = run(back)
    first_free = out[0].frames[1] if out else 0
    if m and F - m >= first_free:
        s = F - m
        t = s
        while t > max(first_free, s - n_trans) and arms_out[t - 1]:
            t -= 1
        out.append(CalibrationPose(s, F, KIND_NAMES[int(kinds[-1])], "end", t, s))
    return tuple(out)


def calibration_mask(poses, num_frames: int) -> np.ndarray:
    """(F,) bool: the frames of ``poses`` (from :func:`calibration_poses`), transitions included."""
    out = np.zeros(int(num_frames), dtype=bool)
    for p in poses:
        a, b = p.frames
        out[a:b] = True
    return out
