"""Breaks of the whole take: the root's path (teleports, jumps that stay, a frozen root) and cuts.

Self-similarity (:mod:`mocapkit.cleaning.ssa`) judges each joint's rotations. Two kinds of damage are no
error of one joint's rotation, and this module finds them from the take alone, in physical units:

**The root's path.** The pelvis (:func:`mocapkit.rigs.pelvis_index`, the joint that carries the hips'
translation: ``Hips`` on the Bandai Namco rig under a ``joint_Root`` on the floor, the root elsewhere) is
followed in world space, in centimetres (:func:`mocapkit.joints.unit_scale_cm`). A body's centre never
changes its velocity by :data:`JUMP_CM` (25 cm per frame, i.e. a change of 7.5 m/s in 1/30 s or 30 m/s in
1/120 s: ten times a hard landing) from one frame to the next. Where the step into a frame differs from the
steps beside it by more than that, the root *jumps* (:func:`root_jumps`). A jump away and, within
:data:`TELEPORT_MAX_S`, back by the opposite step is a *teleport* (a few wrong root samples): its frames
are put back on the straight line between the good frames around them (:func:`fix_teleports`), named
and undoable as any repair. A jump with no way back (the rest of the take offset) is named and left: which
side is right is not known (the take may start or end offset, or have been cut there). A root held bit for
bit for :data:`FROZEN_MIN_S` or more while the legs turn and the root moves elsewhere in the take is named
and left: nothing tells where the body went.

**Cuts.** Where two takes were joined, or frames were dropped, the whole body breaks at one frame: most
joints' midpoint residuals (:func:`mocapkit.cleaning.ssa.cues.midpoint_residuals`) jump together, far over
what each joint's own motion reaches. :func:`cuts` finds such frames. Detection confirms a digression by
its joint's own break; at a cut every joint breaks, so without care the frames beside a cut are "repaired"
(the pelvis of a walk turned round in the 17 frames before a splice). :func:`mocapkit.cleaning.whole_take.detect_take`
(:func:`~mocapkit.cleaning.whole_take.across_breaks`) lets no break at a cut, or where the root jumps and stays,
confirm a digression: the cut is named, the motion on either side kept.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..motion import Motion
from ..words import frame_span, listed, plural

__all__ = ["CUT_KEPT", "JUMP_CM", "AXIS_CM", "TELEPORT_MAX_S", "FROZEN_MIN_S", "CUT_SHARE", "CUT_RATIO", "CUT_MIN_DEG", "RootEvent",
           "Cut", "with_root_jumps", "PHRASE_CUTS", "cuts_phrase", "pelvis_path_cm", "root_jumps", "root_events",
           "fix_teleports", "cut_scores", "cuts", "cut_mask"]

JUMP_CM = 25.0  # a step of the pelvis this far off the steps beside it (cm per frame) no body makes
#: cm: an axis of a teleport's position is put on the line only when it alone is this far off
#: it (:func:`fix_teleports`): a channel put back is off by half JUMP_CM, so its farthest axis by at least this
AXIS_CM = 0.5 * JUMP_CM / np.sqrt(3.0)
TELEPORT_MAX_S = 0.5  # a jump back within this long makes a teleport
FROZEN_MIN_S = 0.5  # a root held bit for bit this long while the legs turn is named
FROZEN_TURN_DEG = 10.0  # ... the legs turning at least this far over the hold
CUT_SHARE = 0.6  # share of the moving joints that must break at one frame for a cut
CUT_RATIO = 4.0  # a joint breaks at a cut when its midpoint residual passes this many times its usual peak
CUT_MIN_DEG = 2.0  # ... and this many degrees
CUT_MOVING_DEG = 10.0  # joints turning less than this from the first frame over the take are not asked
CUT_MIN_JOINTS = 6  # a take with fewer moving joints is not asked
CUT_MIN_FRAMES = 11  # a shorter take is not asked: its 8 inner residuals or fewer hold no usual peak below the 8 largest


@dataclass(frozen=True)
class RootEvent:
    """One finding on the root's path: ``kind`` "teleport", "jump" or "frozen"; frames ``first``..``last``
    (inclusive; for a jump, ``first`` is the frame the root lands on and ``last`` the take's last frame);
    ``size_cm``: how far the root is off, cm (teleport, jump), or how far the legs turned over the hold, degrees
    (frozen); ``joint``: the pelvis's name; ``fixed``: the frames were put back (teleports); ``review``: a teleport
    the repair step puts back, said where no repair runs (``clean --steps detect``, ``detect``) and left."""

    kind: str
    first: int
    last: int
    size_cm: float
    joint: str
    fixed: bool = False
    review: bool = False

    def __str__(self) -> str:
        frames = frame_span(self.first, self.last)
        if self.kind == "teleport":
            where = "on the path between the frames around them"
            what = (f"{frames}: the root ({self.joint}) jumps {self.size_cm:.0f} cm away and back "
                    "(wrong root samples)" + (f"; put back {where}" if self.fixed else
                                              f"; left as is (repair would put it back {where})" if self.review
                                              else ""))
        elif self.kind == "jump":
            what = (f"frame {self.first}: the root ({self.joint}) jumps {self.size_cm:.0f} cm and stays there "
                    "(an offset, or a cut); left as it is: which side is right is not known")
        else:
            what = (f"{frames}: the root ({self.joint}) is held still, bit for bit, while the legs turn up to "
                    f"{self.size_cm:.0f} deg (a frozen root channel?); left as it is")
        return what


#: what ``clean`` does about a cut (:class:`Cut`): no sample changes for it
CUT_KEPT = ("nothing: no sample changed for it; its breaks confirm no repair, the motion on either side is kept as "
            "it is")


@dataclass(frozen=True)
class Cut:
    """A frame where the whole body jumps: ``frame``, the first frame after the break (of two takes joined, the
    second's first frame), the ``share`` of the moving joints breaking there (the cut's score, 0-1), and
    ``root_cm``, how far the root's path jumps at that frame and stays (cm, as :class:`RootEvent` measures a
    "jump"; 0 where the root does not jump there): two takes joined whose captures start at another place."""

    frame: int
    share: float
    root_cm: float = 0.0

    def _root(self) -> str:
        return f", and the root jumps {self.root_cm:.0f} cm with them" if self.root_cm else ""

    @property
    def meaning(self) -> str:
        """What the break means for a person deciding about it, one sentence."""
        return (f"{100 * self.share:.0f} % of the moving joints jump at once between frames {self.frame - 1} and "
                f"{self.frame}, far over their own motion{self._root()}: two takes joined here (frame {self.frame} "
                "the second's first), or frames dropped; split the take here, or keep it whole")

    def __str__(self) -> str:
        return (f"frame {self.frame}: the whole body jumps ({100 * self.share:.0f} % of the joints at once"
                f"{self._root()}): a cut, or dropped frames; its breaks confirm no repair, the motion on either side "
                "is kept")


def with_root_jumps(found, events) -> tuple[list[Cut], list[RootEvent]]:
    """``(cuts, events)``: the cuts ``found`` (:class:`Cut`), each at whose frame the root jumps and stays (a
    ``"jump"`` of ``events``, :class:`RootEvent`, counted in the same frames) given that jump's size as its
    ``root_cm``, and ``events`` without those jumps. A cut where the captures joined start at another place is one
    finding, said once: a cut with a root jump, not a jump "left as it is: which side is right is not known"."""
    jumps = {e.first: e for e in events if e.kind == "jump"}
    cuts = [dataclasses.replace(c, root_cm=float(jumps[c.frame].size_cm)) if c.frame in jumps else c for c in found]
    at = {c.frame for c in found}
    return cuts, [e for e in events if not (e.kind == "jump" and e.first in at)]


#: the frames of cuts a take's phrase names (:func:`cuts_phrase`); past them, a count
PHRASE_CUTS = 12


def cuts_phrase(found) -> str:
    """The cuts ``found`` (:class:`Cut`, or their fields as a dict: a batch row's ``cuts``) of one take in one
    phrase, as ``clean-batch``'s line for the take and its overview say them: ``"1 cut at frame 200 (two takes
    joined, or frames dropped; the root jumps 78 cm there): no sample changed for it"``; the first
    :data:`PHRASE_CUTS` frames, then a count; "" for none."""
    found = [c if isinstance(c, Cut) else Cut(**c) for c in found]
    if not found:
        return ""
    n = len(found)
    frames = [str(c.frame) for c in found[:PHRASE_CUTS]] + ([f"{n - PHRASE_CUTS} more"] if n > PHRASE_CUTS else [])
    jumps = [c for c in found if c.root_cm]
    root = ("; the root jumps " + listed(f"{c.root_cm:.0f} cm" + ("" if n == 1 else f" at frame {c.frame}")
                                         for c in jumps[:PHRASE_CUTS]) + (" there" if n == 1 else "")
            + (f" and at {len(jumps) - PHRASE_CUTS} more" if len(jumps) > PHRASE_CUTS else "")) if jumps else ""
    return (f"{plural(n, 'cut')} at frame{'s' if n > 1 else ''} {listed(frames)} (two takes joined, or frames "
            f"dropped{root}): no sample changed for {'it' if n == 1 else 'them'}")


def pelvis_path_cm(motion: Motion) -> tuple[np.ndarray, int]:
    """``(path, pelvis)``: the pelvis's world positions (F, 3) in centimetres and its joint index."""
    from ..rigs import pelvis_index

    sk = motion.skeleton
    p = pelvis_index(sk)
    scale = _scale(sk)
    if p == 0 and motion.translations is None:
        pos = np.asarray(motion.root_positions, dtype=np.float64)
    else:
        pos = np.asarray(motion.global_positions()[:, p], dtype=np.float64)
    return pos * scale, p


def root_jumps(path: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(frames, excess)``: the frames the pelvis ``path`` (F, 3) cm jumps into (the step into frame f is
    more than :data:`JUMP_CM` off the median of the two steps before and two after it), and each excess (cm)."""
    F = len(path)
    if F < 3:
        return np.zeros(0, dtype=int), np.zeros(0)
    d = np.diff(path, axis=0)  # d[i]: the step into frame i + 1
    n = len(d)
    beside = np.full((n, 4, 3), np.nan)  # the steps two before and two after each, NaN past the ends
    for k, o in enumerate((-2, -1, 1, 2)):
        lo, hi = max(0, -o), min(n, n - o)
        beside[lo:hi, k] = d[lo + o:hi + o]
    has = np.isfinite(beside).all(axis=2).any(axis=1)  # a one-step path has no step beside its own
    ref = np.zeros((n, 3))
    if has.any():
        with np.errstate(all="ignore"):
            ref[has] = np.nanmedian(beside[has], axis=1)
    excess = np.linalg.norm(d - ref, axis=1)
    bad = np.flatnonzero(np.nan_to_num(excess) > JUMP_CM)
    return bad + 1, excess[bad]


def root_events(motion: Motion, span: tuple[int, int] | None = None) -> list[RootEvent]:
    """The :class:`RootEvent` of ``motion``'s root path (module docstring), frames at the take's; ``span``
    ``(lo, hi)``: look only there (calibration poses left out)."""
    F = motion.num_frames
    lo, hi = (0, F) if span is None else span
    if hi - lo < 3:
        return []
    path, p = pelvis_path_cm(motion)
    path = path[lo:hi]
    name = motion.skeleton.joint_names[p]
    frames, _ = root_jumps(path)
    out: list[RootEvent] = []
    longest = max(1, int(round(TELEPORT_MAX_S * motion.fps)))
    used: set[int] = set()
    for k, a in enumerate(frames):
        if a in used:
            continue
        step_in = path[a] - path[a - 1]
        back = None
        for b in frames[k + 1:]:
            if b - a > longest:
                break
            # back: the root returns to the line it left (the good frames around agree)
            before, after = path[a - 1], path[b]
            gap = b - a + 1
            left, right = max(a - 2, 0), min(b + 1, len(path) - 1)
            slope = (path[right] - path[left]) / max(1, right - left)
            if np.linalg.norm(after - (before + slope * gap)) < JUMP_CM:
                back = int(b)
                break
        if back is not None:
            seg = path[a:back]
            t = np.arange(1, back - a + 1) / (back - a + 1)
            line = path[a - 1] + t[:, None] * (path[back] - path[a - 1])
            size = float(np.max(np.linalg.norm(seg - line, axis=1)))
            out.append(RootEvent("teleport", lo + int(a), lo + back - 1, size, name))
            used.update(int(b) for b in frames[(frames >= a) & (frames <= back)])
        else:
            size = float(np.linalg.norm(step_in - (path[a - 1] - path[max(a - 2, 0)])))
            out.append(RootEvent("jump", lo + int(a), hi - 1, size, name))
            used.add(int(a))
    held = _frozen(motion, path, lo, name)
    ends = {e.last + 1 for e in held}  # where a held root lets go it jumps to where the body went: part of the hold
    out = [e for e in out if not (e.kind == "jump" and e.first in ends)] + held
    return sorted(out, key=lambda e: e.first)


def _frozen(motion: Motion, path: np.ndarray, lo: int, name: str) -> list[RootEvent]:
    """Runs of a root held bit for bit (:data:`FROZEN_MIN_S` or longer) while the legs turn, in a take whose
    root moves elsewhere."""
    from ..joints import standard_joints
    from .. import rotations as R
    from .ik import contact_segments

    still = np.zeros(len(path), dtype=bool)
    still[1:] = np.all(path[1:] == path[:-1], axis=1)
    if still[1:].all() or not still.any():
        return []  # a root that never moves (an in-place take) says nothing
    legs = [j for r, j in standard_joints(motion.skeleton).items() if r.endswith(("_hip", "_knee"))]
    if not legs:
        return []
    rot = np.asarray(motion.rotations, dtype=np.float64)[lo:lo + len(path)]
    need = max(2, int(round(FROZEN_MIN_S * motion.fps)))
    out = []
    for a, b in contact_segments(still):
        first = a - 1  # the frame the hold starts from
        if b - first < need:
            continue
        seg = rot[first:b][:, legs]
        turn = float(np.degrees(np.max(R.geodesic_angle(seg, seg[:1]))))
        if turn >= FROZEN_TURN_DEG:
            out.append(RootEvent("frozen", lo + first, lo + b - 1, turn, name))
    return out


def fix_teleports(motion: Motion, events, measured=(None, None)) -> tuple[Motion, list[RootEvent]]:
    """``motion`` with each teleport of ``events`` put back, and the events (teleports marked ``fixed``).

    Over a teleport's frames, each position channel that carries the jump (the root position, and the
    animated translations of the joints from the root down to the pelvis) is put on the straight line
    between its values at the frames before and after, axis by axis: an axis off that line by at most
    :data:`AXIS_CM` is left as written (a root that jumps 1 m in X for a frame keeps its measured height and
    Z bit for bit), and a channel off the line by less than half :data:`JUMP_CM` is left whole, as is every
    other frame. A teleport touching the take's ends is left (there is no good frame on one side).

    ``measured``: ``(root (F, 3), offsets (F, J, 3))`` bool or None each
    (:func:`mocapkit.cleaning.measured.measured_axes`), the axes the file measures in a position it gives partly
    ``nan``: such an axis is put on the line only where it alone is off it by more than :data:`AXIS_CM`, else left
    as written. The jump is evidence against the axes that carry it: a CMU root with ``Yposition`` ``nan`` in the
    frames of a teleport in X had its measured Z, on its path, moved onto the line too (by up to 0.006 in).
    """
    sk = motion.skeleton
    _, p = pelvis_path_cm(motion)
    chain = [p]
    while sk.parents[chain[-1]] >= 0:
        chain.append(int(sk.parents[chain[-1]]))
    scale = _scale(sk)
    root = np.array(motion.root_positions, dtype=np.float64)
    tr = None if motion.translations is None else np.array(motion.translations, dtype=np.float64)
    chans = [root] + ([] if tr is None else [tr[:, j] for j in chain if j > 0])  # views: written in place
    at_root, at_offsets = measured
    kept = [at_root] + ([] if tr is None else
                        [None if at_offsets is None else at_offsets[:, j] for j in chain if j > 0])
    out = []
    for e in events:
        if e.kind != "teleport" or e.first < 1 or e.last + 1 >= motion.num_frames:
            out.append(e)
            continue
        a, b = e.first, e.last + 1  # wrong frames a..b-1; good frames a-1 and b
        t = ((np.arange(a, b) - (a - 1)) / (b - (a - 1)))[:, None]
        for c, keep in zip(chans, kept):
            line = c[a - 1] + t * (c[b] - c[a - 1])
            if np.max(np.linalg.norm(c[a:b] - line, axis=1)) * scale > 0.5 * JUMP_CM:
                # an axis no jump of its own moves stays as written; of a position the file gives partly nan, only
                # its measured axes (an axis the fill made follows the line)
                mine = np.ones(c[a:b].shape, dtype=bool)
                if keep is not None:
                    part = keep[a:b].any(axis=1)
                    mine[part] = keep[a:b][part]
                line = np.where(mine & (np.abs(c[a:b] - line) * scale <= AXIS_CM), c[a:b], line)
                c[a:b] = line
        out.append(dataclasses.replace(e, fixed=True))
    return dataclasses.replace(motion, root_positions=root, translations=tr), out


def _scale(sk) -> float:
    """Centimetres per unit of ``sk`` (1 for a rig whose unit cannot be told)."""
    from ..errors import SkeletonError
    from ..joints import unit_scale_cm

    try:
        return unit_scale_cm(sk)
    except SkeletonError:
        return 1.0


def _usual_peak(resid: np.ndarray) -> np.ndarray:
    """(J,) radians: a joint's usual peak midpoint residual, its 98th percentile (below the 8 largest in a short take;
    its smallest in a take of 8 frames or fewer, as an 8-frame take cut to 12 fps from 20 frames at 30 fps)."""
    F = resid.shape[0]
    return np.percentile(resid, max(0.0, min(98.0, 100.0 * (1.0 - 8.0 / max(F, 1)))), axis=0)


def cut_scores(motion: Motion, resid: np.ndarray | None = None, ignore: np.ndarray | None = None) -> np.ndarray:
    """(F,) the share of moving joints that break into each frame (module docstring; 0 at frame 0).

    ``resid``: ``midpoint_residuals(motion.rotations)`` when the caller has them already (None: made here).
    ``ignore``: (F, J) bool or None, cells that are no evidence (channels written as 0, :mod:`.zeros`): a joint
    with such a cell at a frame or beside it is left out of that frame's share, its breaks and its count alike, so
    that a dropout's own jumps make no cut. A break between frames ``c - 1`` and ``c`` puts a joint's residual
    over its limit at both, so it counts at ``c - 1``, ``c`` and ``c + 1`` alike (:func:`cuts` names ``c``)."""
    return _break_shares(motion, resid, ignore)[0]


def _break_shares(motion: Motion, resid: np.ndarray | None, ignore: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """``(into, between)``, (F,) each: :func:`cut_scores`, and the share of the same joints whose residuals are
    over their limits at both ``f - 1`` and ``f``, the break between them (its peak names a cut's frame)."""
    from .ssa.cues import midpoint_residuals

    if resid is None:
        resid = midpoint_residuals(motion.rotations)  # (F, J) radians, at f against f-1 and f+1
    F = resid.shape[0]
    out = np.zeros(F)
    if F < 4:
        return out, out.copy()
    from .. import rotations as R

    q = np.asarray(motion.rotations, dtype=np.float64)
    travel = np.nan_to_num(np.max(R.geodesic_angle(q, q[:1]), axis=0))  # (J,) radians from the first frame
    moving = travel > np.radians(CUT_MOVING_DEG)
    if moving.sum() < CUT_MIN_JOINTS:
        return out, out.copy()
    peak = _usual_peak(resid[1:-1])
    limit = np.maximum(CUT_RATIO * peak, np.radians(CUT_MIN_DEG))
    over = resid > limit  # a break between f-1 and f shows at f-1 and at f
    into = np.zeros_like(over)
    into[1:] = over[:-1] | over[1:]
    between = np.zeros_like(over)
    between[1:] = over[:-1] & over[1:]
    if ignore is None:
        out, both = into[:, moving].mean(axis=1), between[:, moving].mean(axis=1)
    else:  # a cell ignored at f - 2 .. f + 1 touches the residuals that make into[f]
        given = np.asarray(ignore, dtype=bool)
        ign = given.copy()
        ign[1:] |= given[:-1]
        ign[2:] |= given[:-2]
        ign[:-1] |= given[1:]
        counted = moving[None, :] & ~ign
        with np.errstate(invalid="ignore", divide="ignore"):
            out = np.nan_to_num((into & counted).sum(axis=1) / counted.sum(axis=1))
            both = np.nan_to_num((between & counted).sum(axis=1) / counted.sum(axis=1))
    out[0] = both[0] = 0.0
    return out, both


def cuts(motion: Motion, span: tuple[int, int] | None = None, resid: np.ndarray | None = None,
         ignore: np.ndarray | None = None) -> list[Cut]:
    """The :class:`Cut` frames of ``motion`` (within ``span`` ``(lo, hi)``; module docstring).

    A cut is named by the first frame of the new take (``Cut.frame``: where two takes were joined, the second's
    first frame): of the frames whose share (:func:`cut_scores`) reaches :data:`CUT_SHARE`, two or fewer apart
    (one break shows at three), the one with the most joints broken on both sides of it (``_break_shares``), the
    first on a tie. ``resid``: the midpoint residuals of ``motion[lo:hi]`` when the caller has them already;
    ``ignore``: (F, J) cells of ``motion`` that are no evidence (:func:`cut_scores`)."""
    F = motion.num_frames
    lo, hi = (0, F) if span is None else span
    if hi - lo < CUT_MIN_FRAMES:
        return []
    part = motion if (lo, hi) == (0, F) else motion[lo:hi]
    share, both = _break_shares(part, resid, None if ignore is None else np.asarray(ignore)[lo:hi])
    runs: list[list[int]] = []
    for f in np.flatnonzero(share >= CUT_SHARE):
        if runs and f - runs[-1][-1] <= 2:  # one cut shows at two frames at most
            runs[-1].append(int(f))
        else:
            runs.append([int(f)])
    out = []
    for run in runs:
        frames = np.arange(run[0], run[-1] + 1)
        f = int(frames[np.argmax(both[frames])])
        out.append(Cut(lo + f, float(share[frames].max())))
    return out


def cut_mask(frames, num_frames: int, margin: int) -> np.ndarray:
    """(F,) bool: the frames within ``margin`` of each break into a frame of ``frames`` (the frame before it and
    the frame itself, and ``margin`` more on each side)."""
    out = np.zeros(num_frames, dtype=bool)
    for f in frames:
        out[max(0, f - 1 - margin):min(num_frames, f + 1 + margin)] = True
    return out
