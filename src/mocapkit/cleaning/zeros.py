"""Channels written as exactly 0 where the capture lost data: a dropout, not motion.

An exporter with no value for a channel (the solver lost the joint, the
capture dropped a frame) often writes 0 there: a joint stuck at zero rotation
for a second or three, one channel of a joint at 0, or a whole frame of zeros
(root position included: the skeleton collapses to a point at the origin).
Self-similarity sees only the edges of such a run (the jumps into and out of
it), so it was left without a word or "repaired" at its edges, good frames
next to it included. :func:`find_zeros` finds these runs; :func:`as_missing`
makes their cells missing (NaN), so that ``clean``'s fill step fills them as
it fills any gap and the frames next to them are not touched.

A value *reads as 0* when the file's channel (:meth:`Motion.channel_values`,
degrees; positions in file units) is within ``ZERO_TOL`` (1e-9) of 0: the
file's ``0``, ``-0`` or ``0.000000`` after the reader's Euler -> quaternion ->
Euler round trip (about 1e-14), the same for BVH, ASF/AMC and npz takes, while
the smallest value a file prints (1e-6 at six decimals) stays far above it.

Three kinds of run, each *interior* (frames on both sides of it do not read 0;
a run opening or closing the take may be a rest pose and is left alone):

- an **all-zero frame** run: every channel of the frame reads 0, the root's
  position too. Any length (one frame is enough: no motion writes every
  channel as exactly 0 between frames that do not). Every joint with channels is
  missing there, the root's position too (the fill step interpolates it);
  animated offsets (BVH position channels of non-root joints, the Bandai Namco
  rig's) are put back by linear interpolation between the frames around.
- a **joint** run: every rotation channel of one joint reads 0 (an identity
  rotation) for at least ``MIN_RUN`` (2) frames;
- a **channel** run: one rotation channel of a joint with several reads 0 for
  at least ``MIN_RUN`` frames while the joint's others do not.

Clean takes hold exact zeros too, and the rule is measured against them
(every take of HDM05, CMU ASF/AMC and BVH, the 2,675 Bandai Namco takes, the
peers' BVH files): a knee straight at its joint limit reads 0 for up to 137
frames (the Acclaim tibia's single channel, and the CMU BVH knees converted
from it), a Bandai Namco toe, knee or elbow channel for up to 49. A joint
*reaches* such a limit: the last value before the run is about one frame's
step from 0. A dropout *jumps*: at one of its edges the joint's distance from
0 (its rotation angle; a channel's value) is more than ``JUMP_RATIO`` (10)
times the step the joint makes between that frame and the one beyond it, and
at least ``MIN_JUMP_DEG`` (0.5 deg). The clean takes' largest ratio is 6.0 (a
Bandai toe at 30 fps). A run whose joint (channel) reads 0 in half the take or
more, outside the run, is left alone (a channel that rarely moves: a Mixamo toe reads 0 in 52 of 69 frames), as are frames where every
rotation reads 0 but the root's position does not (a rest pose). A dropout
that starts and ends where the joint happened to be near 0 is not told from a
limit, and is left to detection.

A joint that *rests* at 0 is no dropout either, whatever the run's other edge
does (studio BVH exports at six decimals):

- a run with an edge where the joint (channel) reads within ``HOVER_DEG``
  (1e-3 deg) of 0, at the frame beside the run and the one beyond it: the
  joint sits at 0 and the exporter rounds it (a Bandai Namco straight elbow's
  off-axis channels, 1e-15 deg, written ``0.000000`` beside ``0.000001`` and
  ``-0.000024``);
- a channel run over which the joint's other rotation channels do not change
  at all: the joint is not animated there (a toe held still through a whole
  take), its 0 is its rest.

**Stitched takes.** A deliverable of several takes joined end to end has a
take's start and end inside it. The frames the take breaks into are its cuts
(:func:`~mocapkit.cleaning.take_breaks.cuts`, judged without the runs' own
cells, so that a dropout's jumps make no cut) and its root's jumps that stay
(:func:`~mocapkit.cleaning.take_breaks.root_events`). A run within a frame of
a break, or holding one, opens or closes a take and is left, as at the take's
ends; the share of ``MAX_SHARE`` is counted between the breaks around the run
(each take judged as it would be alone). So a straight elbow's zeros beside a
join of Bandai Namco takes stitched at six decimals are left (a fill would bend
it by up to 78 deg), while dropouts injected into such takes are still found
(87 of 100 over 50 stitched triples of Bandai Namco styles; CMU BVH: 12 of 16).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .. import rotations as R
from ..motion import Motion, channel_starts
from ..words import frame_span
from .ik import contact_segments
from .take_breaks import cuts, root_events

__all__ = ["ZeroRun", "find_zeros", "blank_ends", "as_missing", "ZERO_TOL", "MIN_RUN", "JUMP_RATIO", "MIN_JUMP_DEG", "HOVER_DEG"]

ZERO_TOL = 1e-9  # |channel| at or below this reads as a written 0 (degrees; positions in file units)
MIN_RUN = 2  # frames of one joint (channel) at 0; a whole frame at 0 counts from one frame
JUMP_RATIO = 10.0  # edge jump over the next step above which the run is a dropout (clean takes: 6.0 at most)
MIN_JUMP_DEG = 0.5  # and the jump at least this many degrees
MAX_SHARE = 0.5  # a joint (channel) reading 0 in this share of the frames outside the run or more is left alone
HOVER_DEG = 1e-3  # a joint (channel) this close to 0 beside a run, two frames running, rests at 0 (exporter rounding)


@dataclass(frozen=True)
class ZeroRun:
    """Frames ``first``..``last`` (inclusive) written as 0: of one ``joint`` (``channel``: one of its channels, ""
    for all its rotation channels), or of every channel (``joint`` ""). ``filled``: the fill step filled them."""

    first: int
    last: int
    joint: str = ""
    channel: str = ""
    filled: bool = True

    def __str__(self) -> str:
        fate = "filled" if self.filled else "left as written (the fill step did not run)"
        return f"{self.what()}, {fate}"

    def what(self) -> str:
        """The run in words, without what became of it: ``"LeftHip frames 100-459: channels written as 0 (a
        dropout)"``."""
        a, b = self.first, self.last
        frames = frame_span(a, b)
        if not self.joint:
            return f"{frames}: every channel written as 0, the root's position too (a dropout)"
        what = f"{self.channel} written as 0" if self.channel else "channels written as 0"
        return f"{self.joint} {frames}: {what} (a dropout)"


def _angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.degrees(R.geodesic_angle(a, b))


def _jumps(dist: np.ndarray, step: np.ndarray, a: int, b: int) -> bool:
    """Whether run ``[a, b)`` jumps at one of its edges: ``dist`` (F,) the distance of each frame from 0 (degrees),
    ``step`` (F,) the step into each frame from the one before (degrees)."""
    F = len(dist)
    edges = []
    if a >= 2:  # the frame before the run, against its own step from the frame before it
        edges.append((dist[a - 1], step[a - 1]))
    if b + 1 < F:  # the frame after the run, against its step into the frame after it
        edges.append((dist[b], step[b + 1]))
    return any(d >= MIN_JUMP_DEG and d > JUMP_RATIO * max(s, 1e-3) for d, s in edges)


def _quiet(dist: np.ndarray, a: int, b: int) -> bool:
    """Whether run ``[a, b)`` rests at 0 at one of its edges: the frame beside it and the one beyond that read within
    ``HOVER_DEG`` of 0 (``dist`` (F,), degrees from 0). Such a joint (channel) sits at 0, and its zeros are the
    exporter's rounding (a straight elbow's off-axis channels, 1e-15 deg, written ``0.000000`` beside ``0.000001``)."""
    F = len(dist)
    if a >= 1 and dist[a - 1] <= HOVER_DEG and (a < 2 or dist[a - 2] <= HOVER_DEG):
        return True
    return b < F and dist[b] <= HOVER_DEG and (b + 1 >= F or dist[b + 1] <= HOVER_DEG)


def _runs(zero: np.ndarray, keep_out: np.ndarray, min_run: int) -> list[tuple[int, int]]:
    """Interior runs ``[a, b)`` of ``zero & ~keep_out`` at least ``min_run`` long whose both neighbours do not read 0
    (``zero`` (F,) bool; frames in ``keep_out`` (F,) belong to no run)."""
    F = len(zero)
    return [(a, b) for a, b in contact_segments(zero & ~keep_out)
            if b - a >= min_run and a > 0 and b < F and not zero[a - 1] and not zero[b]]


def _breaks(motion: Motion, ignore: np.ndarray, frames: np.ndarray) -> list[int]:
    """The frames the take breaks into, sorted: its cuts (:func:`~mocapkit.cleaning.take_breaks.cuts`, judged
    without the ``ignore`` (F, J) cells, a dropout's own jumps; a cut's frame is the first after its break) and
    the root's jumps that stay (:func:`~mocapkit.cleaning.take_breaks.root_events`), not those into or out of the all-zero ``frames``
    (F,) bool."""
    out = {c.frame for c in cuts(motion, ignore=ignore)}
    out |= {e.first for e in root_events(motion) if e.kind == "jump" and not frames[e.first - 1:e.first + 1].any()}
    return sorted(out)


def _kept(zero: np.ndarray, a: int, b: int, breaks: list[int]) -> bool:
    """Whether run ``[a, b)`` of ``zero`` (F,) is a dropout between the take's ``breaks``: no break within one frame
    of its edges or inside it (it opens or closes a stitched take: left, as at the take's ends), and the joint
    (channel) reads 0 in under ``MAX_SHARE`` of the frames outside the run of its segment between breaks."""
    if any(a - 1 <= t <= b + 1 for t in breaks):
        return False
    lo = max((t for t in breaks if t < a), default=0)
    hi = min((t for t in breaks if t > b), default=len(zero))
    rest = (hi - lo) - (b - a)
    return rest > 0 and (int(zero[lo:hi].sum()) - (b - a)) / rest < MAX_SHARE


def find_zeros(motion: Motion, values: np.ndarray | None = None) -> tuple[np.ndarray, tuple[ZeroRun, ...], np.ndarray]:
    """``(cells (F, J) bool, runs, frames (F,) bool)``: the joint samples written as 0 (a dropout, module docstring),
    the runs found (whole frames first, then by joint and frame), and the all-zero frames among them. ``values``:
    ``motion.channel_values()`` (F, C) when the caller has them already (None: made here)."""
    sk = motion.skeleton
    F, J = motion.num_frames, motion.num_joints
    cells = np.zeros((F, J), dtype=bool)
    frames = np.zeros(F, dtype=bool)
    if F < 3:
        return cells, (), frames
    if values is None:
        values = motion.channel_values()
    zero = np.abs(values) <= ZERO_TOL  # NaN (missing) is not 0
    channels = [sk.joint_channels(j) for j in range(J)]
    starts = channel_starts(channels)
    cols = [[(int(starts[j]) + k, c) for k, c in enumerate(chans)] for j, chans in enumerate(channels)]
    has = np.array([bool(c) for c in cols])
    runs: list[ZeroRun] = []
    if zero.shape[1]:
        every = zero.all(axis=1)
        for a, b in contact_segments(every):
            if a > 0 and b < F:
                frames[a:b] = True
                runs.append(ZeroRun(a, b - 1))
        cells[frames] = has
    rot_cols = [[k for k, c in cj if c.endswith("rotation")] for cj in cols]
    rotating = [j for j in range(J) if rot_cols[j]]
    # frames where every rotation reads 0 but something else does not: a rest pose, not a dropout
    rest = zero[:, [k for j in rotating for k in rot_cols[j]]].all(axis=1) if rotating else np.zeros(F, dtype=bool)
    rest &= ~frames  # a joint's run may hold all-zero frames (each named once, as a frame)
    rot = np.asarray(motion.rotations, dtype=np.float64)
    found = []  # (joint, channel, zero (F,), first, stop) of the runs that jump into or out of 0
    for j in rotating:
        jz = zero[:, rot_cols[j]].all(axis=1)
        dist = step = None
        for a, b in _runs(jz, rest, MIN_RUN):
            if frames[a:b].all():
                continue
            if dist is None:
                dist = _angles(rot[:, j], R.identity())
                step = np.zeros(F)
                step[1:] = _angles(rot[1:, j], rot[:-1, j])
            if _jumps(dist, step, a, b) and not _quiet(dist, a, b):
                found.append((j, "", jz, a, b))
        if len(rot_cols[j]) < 2:
            continue
        for k in rot_cols[j]:
            v = values[:, k]
            d = np.abs(v)
            s = np.zeros(F)
            s[1:] = np.abs(np.diff(v))
            others = values[:, [c for c in rot_cols[j] if c != k]]
            for a, b in _runs(zero[:, k], rest | frames | jz, MIN_RUN):
                if (others[a:b] == others[a]).all():  # the joint not animated there: its rest, not a lost value
                    continue
                if _jumps(d, s, a, b) and not _quiet(d, a, b):
                    found.append((j, sk.joint_channels(j)[k - cols[j][0][0]], zero[:, k], a, b))
    if found:  # a take stitched from several: each run judged within its own (module docstring)
        ignore = np.zeros((F, J), dtype=bool)
        for j, _, _, a, b in found:
            ignore[a:b, j] = True
        ignore[frames] = True
        breaks = _breaks(motion, ignore, frames)
        for j, channel, z, a, b in found:
            if _kept(z, a, b, breaks):
                cells[a:b, j] = True
                runs.append(ZeroRun(a, b - 1, sk.joint_names[j], channel))
    whole = [r for r in runs if not r.joint]
    parts = sorted((r for r in runs if r.joint), key=lambda r: (sk.index(r.joint), r.first))
    return cells, tuple(whole + parts), frames


def blank_ends(motion: Motion) -> tuple[int, int]:
    """``(lead, trail)``: how many frames open and close ``motion`` with every channel read as 0, the root's position
    too (within ``ZERO_TOL``): blank frames an exporter wrote before or after the take (a studio export with
    one such frame appended). No dropout (nothing on the other side to fill from): left as they are, and named, by
    :func:`mocapkit.cleaning.calibration.calibration_poses`, so that no later step reads the take's jump into them
    as a root jump, a cut or a turn-over. A take blank throughout gives ``(F, 0)``."""
    F = motion.num_frames

    def count(order) -> int:
        n = 0
        for lo in range(0, F, 16):
            idx = order[lo:lo + 16]
            v = motion[int(idx.min()):int(idx.max()) + 1].channel_values()
            if not v.shape[1]:
                return 0
            blank = (np.abs(v) <= ZERO_TOL).all(axis=1)[idx - idx.min()]
            n += int(np.argmin(blank)) if not blank.all() else len(idx)
            if not blank.all():
                break
        return n

    lead = count(np.arange(F))
    return (lead, 0) if lead == F else (lead, count(np.arange(F)[::-1]))


def as_missing(motion: Motion, cells: np.ndarray, frames: np.ndarray) -> Motion:
    """``motion`` with the rotations of ``cells`` (F, J) missing (NaN) and, on the all-zero ``frames`` (F,), the
    root's position missing too and the animated offsets (``translations``) linearly interpolated between the frames
    around (:func:`find_zeros`); every other sample as it was."""
    rot = np.array(motion.rotations)
    rot[cells] = np.nan
    root = np.array(motion.root_positions)
    root[frames] = np.nan
    tr = motion.translations
    if tr is not None and frames.any():
        tr = np.array(tr)
        seen = np.flatnonzero(~frames)
        at = np.flatnonzero(frames)
        F, J = tr.shape[:2]
        flat = tr.reshape(F, 3 * J)
        for c in range(3 * J):
            flat[at, c] = np.interp(at, seen, flat[seen, c])
        tr = flat.reshape(F, J, 3)
    return dataclasses.replace(motion, rotations=rot, root_positions=root, translations=tr)
