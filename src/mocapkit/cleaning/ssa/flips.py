"""Turn-overs undone: a joint turned 180 deg in one frame and turned back later, found and turned back exactly.

A pose solver can turn a limb over in one frame and back some frames later. Two kinds are seen in the data:

- **A chain turned over about its own bones** (HDM05 dg_squat1Reps_025, lfemur frames 78-82; squat_026's
  rfemur 80-99 and lfemur 81-100; bk_depositFloorR_007 rfemur 138-205): the thigh turns 180 deg about
  itself and the shank 180 deg about itself, so the hip, knee and ankle stay where they are while the knee
  now bends backwards (ltibia's AMC value reads 203 deg against the ASF's limit of 170). The positions need
  no change, so self-similarity's breaks are left out of confirmation
  (:mod:`~mocapkit.cleaning.ssa.still_positions`), and a repair from motion words is the wrong tool for it:
  it blends the two sides and swings the foot. A rotation of pi about a bone's own direction is known
  exactly, so the flip is undone exactly: each joint of the chain is turned back by pi about its bone over
  the flipped frames (its local rotation ``q`` becomes ``R_p q R_j^-1``, ``R_j`` the half turn about joint
  ``j``'s bone and ``R_p`` its parent's, identity above the chain); the joint below the chain keeps its
  local rotation when its own world orientation turned over with the chain (the foot, carried back with
  the shank), and is compensated (``R_last q``, its world orientation kept) when it did not. Every joint of
  the chain and the joint below stay where they were, bit for bit up to rounding. A joint below that turned
  over with the chain *and* stepped off its own path at the turn-over's two frames by one offset (the solver's
  share of the turn-over: bk_depositFloorR_009's rfoot, 29 deg in at frame 163 and 26 out at 189) has that
  offset taken away as a leaf's is (:func:`_stepped_with`), where the checks below pass with it; else the chain
  is turned back without it.
- **A leaf joint turned by a constant half turn** (the thumbs: HDM05 bd_throwBasketball_002 rthumb frames
  102-141, whose AMC ``rz`` channel jumps by 180 deg; CMU 131_02's RThumb near gimbal lock): no joint
  hangs below, so nothing is compensated. The offset is measured at both steps, as a turn in the parent's
  frame and in the joint's own (the two frames :mod:`~mocapkit.cleaning.ssa.undo` measures a transient
  offset in, here at the frames beside each step so that a one-frame flip is measured too); where both
  ends agree the offset is slerped across the run and taken away.

A turn-over is undone only where the result is checked to be right: both steps become small
(:data:`STEP_OK_DEG`), no position beside a step moves more than it did, the AMC channels can hold the new
rotation (its degrees of freedom) and an ASF joint's limits are kept, or broken no more than the take breaks
them beside the run. Otherwise it is named and left as it is. Either way its cells are flagged (cause
``flip``) and a line names it. The leaf rule is applied to the joints self-similarity does not analyse
(thumbs, fingers: :func:`~mocapkit.cleaning.ssa.texture.informative_joints`); the chain rule to every
joint. A repair of this library, not of Aristidou et al. (2018).
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

import numpy as np

from ... import rotations as R
from ...motion import channel_starts
from ...words import frame_span

__all__ = ["FLIP_DEG", "AXIS_COS", "AGREE_DEG", "STEP_OK_DEG", "LIMIT_TOL_DEG", "LASTS_TO_END", "Flip", "left_from_note", "turn_steps", "point_steps", "turned_back"]

#: a step of a joint's rotation this large (degrees, in one frame) is a turn-over
FLIP_DEG = 150.0
#: a turn-over is about the joint's own bone when its axis and the bone's direction have at least this |cosine|
AXIS_COS = 0.99
#: a leaf's offsets measured at its two steps agree within this angle (degrees) for it to be taken away
AGREE_DEG = 10.0
#: after turning back, each changed joint's rotation step at both ends is at most this (degrees)
STEP_OK_DEG = 20.0
#: a joint channel may leave its ASF limits by this much (degrees) more than the take beside the run does
LIMIT_TOL_DEG = 1.0
#: why a turn-over is left where it is not turned back by the take's end: it has no "and back"
LASTS_TO_END = "it lasts to the end of the take"
#: frames each side of a turn-over's run that its repair and checks are given (they read two each side)
WINDOW_MARGIN = 3
HALF_TURN_DEG = 179.99  # a leaf turned back by at least this everywhere was turned back by a half turn exactly


@dataclass(frozen=True)
class Flip:
    """A turn-over: ``joints`` (names, the chain's top first) turned over frames ``first .. last`` (0-based,
    inclusive); ``kind`` ``"bone"`` (about their own bones, positions unchanged) or ``"leaf"`` (a constant half
    turn of a joint with no joint below); ``fixed`` whether it was turned back, ``why`` why not; ``steps_below``
    (names) the joints below the chain whose own steps at its two frames were taken away with it; ``turned_deg``
    ``(least, most)`` degrees a leaf turned back was turned by over its frames: a half turn exactly where the file's
    channel jumped by one, else the offsets measured at the two steps, slerped across the run (CMU 131_03's RThumb
    frames 478-481: 158-164 deg, which the line called "a constant half turn ... turned back exactly")."""

    joints: tuple
    first: int
    last: int
    kind: str
    fixed: bool
    why: str = ""
    steps_below: tuple = ()
    turned_deg: tuple = ()

    @property
    def measured(self) -> str:
        """How a leaf is turned back where that is not a half turn exactly: ``"by the offsets measured at its two
        steps (158-164 deg, slerped across the run)"``; "" for a half turn exactly, a chain, or none measured."""
        if self.kind != "leaf" or not self.turned_deg or self.turned_deg[0] >= HALF_TURN_DEG:
            return ""
        lo, hi = (round(x) for x in self.turned_deg)
        return f"by the offsets measured at its two steps ({lo if lo == hi else f'{lo}-{hi}'} deg, slerped across the run)"

    def __str__(self) -> str:
        j = self.joints[0] + (f" (with {', '.join(self.joints[1:])})" if len(self.joints) > 1 else "")
        frames = frame_span(self.first, self.last)
        below = "".join(f", {n}'s own steps at both ends taken away with it" for n in self.steps_below)
        what = (f"turned 180 deg about itself, {frames}, positions unchanged" if self.kind == "bone"
                else f"turned 180 deg to the take's end, {frames} (a constant half turn)" if self.why == LASTS_TO_END
                else f"turned about a half turn and back, {frames}" if self.measured
                else f"turned 180 deg and back, {frames} (a constant half turn)")
        done = f"turned back {self.measured}" if self.measured else f"turned back exactly{below}"
        return f"{j} {what}: " + (done if self.fixed else f"left as is ({self.why})")


_NOTE = re.compile(r"^flip: (\S+)(?: \(with ([^)]*)\))? turned (?:180 deg|about a half turn) .*?frames? (\d+)(?:-(\d+))?.*?"
                   r": left as is \((.*)\)$")


def left_from_note(note: str):
    """``(joint names, first, last, why)`` of a turn-over named and left, read back from its line (``"flip: ..."``,
    as :class:`Flip` says it and a clean record's notes keep it); None for any other line."""
    m = _NOTE.match(note)
    if m is None:
        return None
    joints = (m.group(1),) + (tuple(m.group(2).split(", ")) if m.group(2) else ())
    first = int(m.group(3))
    return joints, first, int(m.group(4) or first), m.group(5)


def turn_steps(q: np.ndarray, flip_deg: float = FLIP_DEG) -> np.ndarray:
    """(F - 1, J) bool: the steps ``f -> f + 1`` of rotations ``q`` (F, J, 4) over ``flip_deg`` degrees."""
    return np.degrees(R.geodesic_angle(q[:-1], q[1:])) > flip_deg


def _bone_axes(skeleton) -> np.ndarray:
    """(J, 3): each joint's bone direction in its own frame, its children's common offset direction (NaN for a
    joint with no child joint, or with children in different directions: a half turn would move one)."""
    off = np.asarray(skeleton.offsets, dtype=np.float64)
    parents = np.asarray(skeleton.parents)
    out = np.full((len(off), 3), np.nan)
    for j in range(len(off)):
        kids = np.flatnonzero(parents == j)
        d = off[kids]
        n = np.linalg.norm(d, axis=1)
        if not len(kids) or (n <= 0).any():
            continue
        u = d / n[:, None]
        if (np.abs(u @ u[0]) > 1 - 1e-9).all():
            out[j] = u[0]
    return out


def _pair_steps(at: np.ndarray) -> list[tuple[int, int | None]]:
    """The steps ``at`` (step ``i`` is the turn into frame ``i + 1``) paired in order: ``(first flipped frame,
    last flipped frame)``, the last None for a step left over at the end (a flip to the end of the take)."""
    at = list(at)
    out = [(at[k] + 1, at[k + 1]) for k in range(0, len(at) - 1, 2)]
    if len(at) % 2:
        out.append((at[-1] + 1, None))
    return out


def _chain_repair(q: np.ndarray, g: np.ndarray, sk, axes: np.ndarray, chain: list[int], a: int, b: int,
                  below_steps: bool = True):
    """The chain ``chain`` (joint indices, each the child of the one before) turned back by pi about its bones
    over frames ``a .. b`` of ``q`` (F, J, 4) local rotations (``g`` the world ones): ``(new q, changed joints,
    stepped)``; ``stepped``: a joint below that turned over with the chain had its own steps at the turn-over's two
    frames taken away too (:func:`_stepped_with`; only with ``below_steps``): their indices."""
    new = np.array(q)
    halves = {j: R.quaternion_from_axis_angle(axes[j], np.pi) for j in chain}
    prev = None
    for j in chain:
        r = new[a : b + 1, j]
        if prev is not None:
            r = R.quaternion_multiply(halves[prev], r)
        new[a : b + 1, j] = R.quaternion_multiply(r, R.quaternion_inverse(halves[j]))
        prev = j
    changed = list(chain)
    stepped = []
    last = chain[-1]
    for c in np.flatnonzero(np.asarray(sk.parents) == last):
        # the joint below keeps its local rotation when it turned over with the chain, else its world orientation
        turned = np.degrees(R.geodesic_angle(g[a - 1, c], g[a, c])) > FLIP_DEG
        if not turned:
            new[a : b + 1, c] = R.quaternion_multiply(halves[last], new[a : b + 1, c])
            changed.append(int(c))
        elif below_steps and _stepped_with(new[:, c], a, b):
            # it turned over with the chain and stepped off its own path at the turn-over's two frames by the same
            # offset (the solver's share of the turn-over): that offset goes with it
            new, _ = _leaf_repair(new, int(c), a, b)
            changed.append(int(c))
            stepped.append(int(c))
    new[a : b + 1] = R.quaternion_normalize(new[a : b + 1])
    return new, changed, stepped


def _stepped_with(t: np.ndarray, a: int, b: int) -> bool:
    """Whether track ``t`` (F, 4) steps off its path into frame ``a`` and back out of frame ``b`` by the same offset,
    both over :data:`AGREE_DEG` and within :data:`AGREE_DEG` of each other (as :func:`_leaf_repair` measures them):
    HDM05 bk_depositFloorR_009's right foot, which turned over with its thigh and shank over frames 163-188 and
    steps 29 deg in and 26 deg out with them; kept, it stepped so after the chain was turned back."""
    if a < 2 or b + 2 >= len(t):
        return False
    _, on, back = _closer_offsets(t, a, b)
    size = np.degrees(R.geodesic_angle(np.stack([on, back]), np.array([1.0, 0.0, 0.0, 0.0])))
    return bool(size.min() > AGREE_DEG and np.degrees(R.geodesic_angle(on, back)) <= AGREE_DEG)


def _channel_halves(sk, j: int) -> np.ndarray:
    """(k, 4): the half turns about joint ``j``'s rotation channel axes, in its local frame (an ASF joint's
    through its ``axis`` frame ``C``: ``C R C^-1``): the offsets an Euler channel jumping by 180 deg makes."""
    axes = [np.eye(3)["XYZ".index(c[0])] for c in sk.joint_channels(j) if c.endswith("rotation")]
    if not axes:
        return np.zeros((0, 4))
    h = R.quaternion_from_axis_angle(np.array(axes), np.full(len(axes), np.pi))
    if sk.axes is not None:
        c = np.broadcast_to(sk.axes[j], h.shape)
        h = R.quaternion_multiply(R.quaternion_multiply(c, h), R.quaternion_inverse(c))
    return h


def _offsets_apart(t: np.ndarray, a: int, b: int) -> float:
    """Degrees between the offsets of a joint's track ``t`` (F, 4) at the step into frame ``a`` and at the step
    out of frame ``b`` (measured as :func:`_leaf_repair` does, the closer of the parent's and the own frame);
    0 where there is no room to measure."""
    if a < 2 or b + 2 >= len(t):
        return 0.0
    _, on, back = _closer_offsets(t, a, b)
    return float(np.degrees(R.geodesic_angle(on, back)))


def _ahead(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """(4,): ``q1`` carried one frame further along the constant-velocity path from ``q0``."""
    q0 = np.where(np.sum(q0 * q1) < 0, -q0, q0)
    return R.quaternion_multiply(R.quaternion_multiply(q1, R.quaternion_inverse(q0)), q1)


def _offset_ends(t: np.ndarray, a: int, b: int) -> dict:
    """The offset of frames ``a .. b`` of track ``t`` (F, 4) at each end, ``{"parent": (on, back), "own": ...}``:
    ``t[a]`` against the path of ``t[a - 2], t[a - 1]`` carried on, ``t[b]`` against ``t[b + 2], t[b + 1]``'s."""
    good_a, good_b = _ahead(t[a - 2], t[a - 1]), _ahead(t[b + 2], t[b + 1])
    inv = R.quaternion_inverse
    return {"parent": (R.quaternion_multiply(t[a], inv(good_a)), R.quaternion_multiply(t[b], inv(good_b))),
            "own": (R.quaternion_multiply(inv(good_a), t[a]), R.quaternion_multiply(inv(good_b), t[b]))}


def _closer_offsets(t: np.ndarray, a: int, b: int) -> tuple[str, np.ndarray, np.ndarray]:
    """``(frame, on, back)``: the offsets of :func:`_offset_ends` in the frame (``"parent"`` or ``"own"``) where the
    two ends agree better, as :func:`_leaf_repair`, :func:`_offsets_apart` and :func:`_stepped_with` measure them."""
    ends = _offset_ends(t, a, b)
    frame = min(ends, key=lambda k: float(R.geodesic_angle(*ends[k])))
    return (frame, *ends[frame])


def _leaf_repair(q: np.ndarray, j: int, a: int, b: int, halves=None) -> tuple[np.ndarray | None, str]:
    """Joint ``j``'s constant half turn over frames ``a .. b`` of ``q`` (F, J, 4) taken away: ``(new q, "")``, or
    ``(None, why)`` where the offsets at the two steps do not agree or there is no room to measure them. Where
    both measured offsets lie within :data:`AGREE_DEG` of one of ``halves`` ((k, 4), :func:`_channel_halves`),
    that exact half turn is taken away instead of the measured ones (a channel's 180 deg jump undone exactly)."""
    F = len(q)
    if a < 2 or b + 2 >= F:
        return None, "too near the take's end to measure"
    t = q[:, j]
    inv = R.quaternion_inverse
    frame, on, back = _closer_offsets(t, a, b)
    if np.degrees(R.geodesic_angle(on, back)) > AGREE_DEG:
        return None, f"the two steps' offsets differ by {np.degrees(R.geodesic_angle(on, back)):.0f} deg"
    back = np.where(np.sum(on * back) < 0, -back, back)
    n = b - a + 1
    if halves is not None and len(halves):
        near = np.maximum(R.geodesic_angle(halves, on), R.geodesic_angle(halves, back))
        if np.degrees(near.min()) <= AGREE_DEG:
            on = back = halves[int(np.argmin(near))]
    off_inv = inv(R.slerp(np.broadcast_to(on, (n, 4)), np.broadcast_to(back, (n, 4)), (np.arange(n) + 0.5) / n))
    run = t[a : b + 1]
    fixed = R.quaternion_multiply(off_inv, run) if frame == "parent" else R.quaternion_multiply(run, off_inv)
    new = np.array(q)
    new[a : b + 1, j] = R.quaternion_normalize(fixed)
    return new, ""


def point_steps(motion) -> np.ndarray:
    """(F - 1, P): how far each joint and end site moves from one frame to the next, in file units."""
    p = motion.global_positions(end_sites=True)
    return np.linalg.norm(np.diff(p, axis=0), axis=-1)


def _check(motion, q: np.ndarray, new_q: np.ndarray, joints: list[int], a: int, b: int, usual: np.ndarray,
           at: int = 0) -> str:
    """Why turning back frames ``a .. b`` of ``joints`` is not right, or "" when it is: each joint's step at both
    ends at most :data:`STEP_OK_DEG` and smaller than it was; no joint or end site stepping further there than it
    did by more than ``usual`` (P,), its own 95th-percentile step over the take; the file's channels able to hold
    the new rotations; and a one-channel joint (a knee's hinge) inside its ASF limits, or out by no more than the
    take is beside the run (+ :data:`LIMIT_TOL_DEG`).

    ``q`` and ``new_q`` (n, J, 4): the take's rotations before and after over frames ``at .. at + n - 1``, which hold
    frames ``a - 1 .. b + 1`` where the take has them (``motion``'s own rotations are not read: the turn-overs
    turned back before this one are in ``q``). Only those frames are read, so a check costs the same on a take of
    any length (:func:`turned_back` passes a few frames around the run, not the take: a copy of the whole take
    per turn-over grew as the square of its length, 6.7 s of CPU for a 9-minute HDM05 take's 64, now 3.3 s)."""
    sk = motion.skeleton
    F = motion.num_frames
    steps = [s for s in (a, b + 1) if 1 <= s < F]
    for j in joints:
        for s in steps:
            after = float(np.degrees(R.geodesic_angle(new_q[s - 1 - at, j], new_q[s - at, j])))
            before = float(np.degrees(R.geodesic_angle(q[s - 1 - at, j], q[s - at, j])))
            if after > STEP_OK_DEG or after >= before:
                return f"{sk.joint_names[j]} would still step {after:.0f} deg at frame {s}"
    lo, hi = max(a - 1, 0), min(b + 2, F)
    around = motion[lo:hi]
    part = dataclasses.replace(around, rotations=q[lo - at : hi - at])
    fixed = dataclasses.replace(around, rotations=new_q[lo - at : hi - at])
    m0, m1 = point_steps(part), point_steps(fixed)
    names = list(sk.joint_names) + list(sk.end_site_names)
    scale, unit = (sk.unit_cm, "cm") if sk.unit_cm else (1.0, "file units")
    for s in steps:
        worse = m1[s - 1 - lo] - m0[s - 1 - lo] - usual
        if (worse > 0).any():
            k = int(np.argmax(worse))
            return (f"{names[k]} would step {m1[s - 1 - lo, k] * scale:.3g} against {m0[s - 1 - lo, k] * scale:.3g} "
                    f"{unit} at frame {s}")
    vals = fixed.channel_values()
    # position channels below the root (LaFAN1's on every joint, Unreal's pelvis under its root) read back as they are
    back = type(motion).from_channel_values(sk, vals, motion.fps, animated_offsets=True).rotations
    if np.degrees(R.geodesic_angle(back[:, joints], fixed.rotations[:, joints])).max() > 0.01:
        return "the file's channels cannot hold the turned-back rotation"
    if sk.limits is None:
        return ""
    orig = part.channel_values()
    starts = channel_starts([sk.joint_channels(j) for j in range(sk.num_joints)])
    inside = slice(1 if a >= 1 else 0, (hi - lo) - 1 if b + 1 < F else hi - lo)
    for j in range(sk.num_joints):
        chans = sk.joint_channels(j)
        rot = [i for i, c in enumerate(chans) if c.endswith("rotation")]
        if j in joints and len(rot) == 1 and sk.limits[j]:
            lim_lo, lim_hi = sk.limits[j][0]
            c = int(starts[j]) + rot[0]

            def past(v):  # degrees past the limits
                return np.maximum(lim_lo - v, v - lim_hi).clip(0)

            beside = max([0.0] + [float(past(orig[r, c])) for r, ok in ((0, a >= 1), (-1, b + 1 < F)) if ok])
            v = vals[inside, c]
            if past(v).max() > beside + LIMIT_TOL_DEG:
                return (f"{sk.joint_names[j]}.{chans[rot[0]]} would read {v[np.argmax(past(v))]:.0f} deg against "
                        f"its limits {lim_lo:g}..{lim_hi:g}")
    return ""


def turned_back(motion, leaves=()) -> tuple:
    """``(motion, changed, flagged, flips)``: ``motion`` with its turn-overs turned back where that is right.

    ``leaves``: names of the joints whose constant half turns are looked for too (the leaf joints
    self-similarity does not analyse; only those with no joint below are). ``changed`` and ``flagged`` (F, J)
    bool: the cells turned back, and those plus the cells of the turn-overs left as they are; ``flips`` the
    :class:`Flip` of each, in frame order. A take with no turn-over comes back as it is (the same object).
    """
    sk = motion.skeleton
    F, J = motion.num_frames, sk.num_joints
    changed = np.zeros((F, J), dtype=bool)
    flagged = np.zeros((F, J), dtype=bool)
    if F < 3:
        return motion, changed, flagged, ()
    q = np.asarray(motion.rotations, dtype=np.float64)
    parents = np.asarray(sk.parents)
    g = motion.global_rotations()
    axes = _bone_axes(sk)
    found = []  # (first, last or None, chain, kind)
    world = turn_steps(g)  # (F - 1, J)
    step = R.quaternion_multiply(R.quaternion_inverse(g[:-1]), g[1:])
    about = np.abs(np.einsum("fjk,jk->fj", step[..., 1:], np.nan_to_num(axes)))
    about /= np.maximum(np.linalg.norm(step[..., 1:], axis=-1), 1e-12)
    bone = world & (about > AXIS_COS) & np.isfinite(axes[:, 0])[None]
    top = bone & ~np.concatenate([np.zeros((F - 1, 1), dtype=bool), bone[:, parents[1:]]], axis=1)
    for j in np.flatnonzero(top.any(axis=0)):
        for a, b in _pair_steps(np.flatnonzero(top[:, j])):
            chain = [int(j)]
            while True:
                kids = np.flatnonzero(parents == chain[-1])
                nxt = [int(c) for c in kids if bone[a - 1, c]]
                if len(nxt) != 1:
                    break
                chain.append(nxt[0])
            found.append((a, b, chain, "bone"))
    names = list(sk.joint_names)
    local = turn_steps(q)
    for name in leaves:
        j = names.index(name)
        if (parents == j).any():
            continue
        at = np.flatnonzero(local[:, j])
        k = 0
        while k < len(at):  # a step whose next one does not turn the same half turn back pairs with none
            a, b = at[k] + 1, (at[k + 1] if k + 1 < len(at) else None)
            found.append((int(a), None if b is None else int(b), [j], "leaf"))
            # the next step turns some other way (offsets over 90 deg apart): the step off pairs with none; two
            # steps that turn nearly the same half turn back stay a pair, undone or named
            apart = _offsets_apart(q[:, j], a, b) if b is not None else 0.0
            k += 1 if apart > 90.0 and k + 2 < len(at) else 2
    flips = []
    out = q  # copied once, at the first turn-over turned back
    usual = np.percentile(point_steps(motion), 95, axis=0) if found else None
    for a, b, chain, kind in sorted(found, key=lambda x: (x[0], x[2][0])):
        joint_names = tuple(names[c] for c in chain)
        if b is None:
            flips.append(Flip(joint_names, a, F - 1, kind, False, LASTS_TO_END))
            flagged[a:, chain] = True
            continue
        # every repair and check reads frames a - 2 .. b + 2 only: they run on those frames (and one more each
        # side), not on a copy of the whole take per turn-over, the same numbers (the window keeps the take's
        # own ends, so a run near one is refused as before)
        w0, w1 = max(a - WINDOW_MARGIN, 0), min(b + 1 + WINDOW_MARGIN, F)
        win, a0, b0 = out[w0:w1], a - w0, b - w0
        if kind == "bone":
            new, joints, stepped = _chain_repair(win, g[w0:w1], sk, axes, chain, a0, b0)
            why = _check(motion, win, new, joints, a, b, usual, at=w0)
            if why and stepped:  # the joint below's steps cannot go (its channels, limits): turned back without them
                new, joints, stepped = _chain_repair(win, g[w0:w1], sk, axes, chain, a0, b0, below_steps=False)
                why = _check(motion, win, new, joints, a, b, usual, at=w0)
        else:
            new, why = _leaf_repair(win, chain[0], a0, b0, _channel_halves(sk, chain[0]))
            joints = chain
            if new is not None:
                why = _check(motion, win, new, joints, a, b, usual, at=w0)
        flagged[a : b + 1, chain] = True
        if why:
            flips.append(Flip(joint_names, a, b, kind, False, why))
            continue
        if out is q:
            out = np.array(q)
        out[w0:w1] = new
        changed[a : b + 1, joints] = True
        flagged[a : b + 1, joints] = True
        turned = ()
        if kind == "leaf":  # what the leaf was turned back by: a half turn exactly, or the measured offsets
            moved = np.degrees(R.geodesic_angle(q[a : b + 1, chain[0]], new[a0 : b0 + 1, chain[0]]))
            turned = (float(moved.min()), float(moved.max()))
        flips.append(Flip(joint_names, a, b, kind, True, steps_below=tuple(names[c] for c in stepped)
                          if kind == "bone" else (), turned_deg=turned))
    if not changed.any():
        return motion, changed, flagged, tuple(flips)
    return dataclasses.replace(motion, rotations=np.where(changed[..., None], out, q)), changed, flagged, tuple(flips)
