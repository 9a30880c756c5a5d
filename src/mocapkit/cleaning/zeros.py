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
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .. import rotations as R
from ..motion import Motion
from ..words import frame_span
from .ik import contact_segments

__all__ = ["ZeroRun", "find_zeros", "as_missing", "ZERO_TOL", "MIN_RUN", "JUMP_RATIO", "MIN_JUMP_DEG"]

ZERO_TOL = 1e-9  # |channel| at or below this reads as a written 0 (degrees; positions in file units)
MIN_RUN = 2  # frames of one joint (channel) at 0; a whole frame at 0 counts from one frame
JUMP_RATIO = 10.0  # edge jump over the next step above which the run is a dropout (clean takes: 6.0 at most)
MIN_JUMP_DEG = 0.5  # and the jump at least this many degrees
MAX_SHARE = 0.5  # a joint (channel) reading 0 in this share of the frames outside the run or more is left alone


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


def _runs(zero: np.ndarray, keep_out: np.ndarray, min_run: int) -> list[tuple[int, int]]:
    """Interior runs ``[a, b)`` of ``zero & ~keep_out`` at least ``min_run`` long whose both neighbours do not read 0
    (``zero`` (F,) bool; frames in ``keep_out`` (F,) belong to no run)."""
    F = len(zero)
    total = int(zero.sum())
    out = []
    for a, b in contact_segments(zero & ~keep_out):
        rest_share = (total - (b - a)) / (F - (b - a)) if b - a < F else 1.0  # of the frames outside the run
        if b - a >= min_run and a > 0 and b < F and not zero[a - 1] and not zero[b] and rest_share < MAX_SHARE:
            out.append((a, b))
    return out


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
    cols, col = [], 0
    for j in range(J):
        chans = sk.joint_channels(j)
        cols.append([(col + k, c) for k, c in enumerate(chans)])
        col += len(chans)
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
            if _jumps(dist, step, a, b):
                cells[a:b, j] = True
                runs.append(ZeroRun(a, b - 1, sk.joint_names[j]))
        if len(rot_cols[j]) < 2:
            continue
        for k in rot_cols[j]:
            v = values[:, k]
            d = np.abs(v)
            s = np.zeros(F)
            s[1:] = np.abs(np.diff(v))
            for a, b in _runs(zero[:, k], rest | frames | jz, MIN_RUN):
                if _jumps(d, s, a, b):
                    cells[a:b, j] = True
                    runs.append(ZeroRun(a, b - 1, sk.joint_names[j], sk.joint_channels(j)[k - cols[j][0][0]]))
    whole = [r for r in runs if not r.joint]
    parts = sorted((r for r in runs if r.joint), key=lambda r: (sk.index(r.joint), r.first))
    return cells, tuple(whole + parts), frames


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
