"""Interpolated frames: a frame another tool wrote between two recorded ones, the midpoint of its neighbours.

A retiming, a frame-rate change or a dropped-frame fix in another tool writes a frame that copies no frame: the
midpoint of the frames around it, by slerp of each joint's rotation or by linear blend of each channel. Such a
frame holds no motion of its own, and like a stutter (:mod:`mocapkit.cleaning.stutters`) it shifts every later
frame of the take by one frame time. :func:`find_inbetweens` names the runs of such frames so that detection can
analyse the take without them (:mod:`mocapkit.cleaning.ssa.repeats`) and ``clean`` can say so.

A frame *is the midpoint of its neighbours* when, on EVERY channel the file writes, it is so to within the
file's written precision, and the frames around it differ by more than that precision (the body moves there):

- the precision: the step between two numbers the file can write at each value (:func:`written_steps`): ``10^-d``
  where the take's values are written with ``d`` fixed decimals (CMU BVH: 4), ``10^(e - s + 1)`` for a value of
  exponent ``e`` where they are written with ``s`` significant digits (HDM05 and CMU AMC, Bandai Namco BVH: 6),
  else the float's own (a take built in memory or read from npz). Each written value is within half a step of
  the value meant, so a midpoint of three written frames is within ``h_t + (h_{t-1} + h_{t+1}) / 2`` of exact
  (``h``: half steps);
- linear: every channel (:meth:`~mocapkit.motion.Motion.channel_values`, degrees and file units) within that
  bound of the mean of its neighbours' values; or
- slerp: every rotation channel within the sum of its joint's rotation channels' bounds of the channel the file
  writes for the slerp midpoint of the neighbours' rotations (a joint with fewer than three channels writes the
  midpoint's nearest rotation it can hold), and every position channel linear as above.

Real motion is smooth but never that linear on every channel at once: on the clean takes (HDM05's 280 AMC,
CMU AMC and BVH at 120 fps, the 2,675 Bandai Namco takes at 30 fps: 447,000 frames) no frame is the midpoint of its neighbours by
either rule (``tests/cleaning/test_inbetweens.py`` keeps a sample of them). Runs of up to :data:`MAX_RUN` frames
are named (a frame, or a few, inserted; each frame of an evenly spaced run is the midpoint of its own neighbours);
a longer straight stretch (a gap another tool bridged linearly on every joint) is motion the analysis judges. Runs
at a regular step through the take are its own rate, an upsampling, not frames inserted (:func:`upsampling`).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from .. import rotations as R
from ..motion import Motion
from .ik import contact_segments

__all__ = ["Inbetween", "MAX_RUN", "MIN_PERIODS", "find_inbetweens", "inbetweens_note", "interpolated_note",
           "midpoint_frames", "midpoint_runs", "upsampling", "written_steps"]

#: the longest run of interpolated frames named (module docstring)
MAX_RUN = 3

#: the share of a take's nonzero values that must fit a written precision for the take to be read as written in it
_FIT_SHARE = 0.99


@dataclass(frozen=True)
class Inbetween:
    """Frames ``first``..``last`` (inclusive) lie evenly between frames ``first - 1`` and ``last + 1``."""

    first: int
    last: int

    def __str__(self) -> str:
        a, b = self.first, self.last
        frames = f"frame {a} is" if a == b else f"frames {a}-{b} are"
        return (f"{frames} the midpoint of {'its' if a == b else 'their'} neighbours on every channel (an "
                f"interpolated frame, as a retiming or a dropped-frame fix writes), analysed with the frames "
                f"around {'it' if a == b else 'them'} and left as {'it is' if a == b else 'they are'}")


def _fits(x: np.ndarray, step: np.ndarray) -> np.ndarray:
    """(N,) bool: ``x`` is a whole number of ``step`` s, to the float noise of a value read and converted back."""
    k = x / step
    return np.abs(k - np.round(k)) <= 1e-6 + 1e-9 * np.abs(k)


def written_steps(values: np.ndarray) -> np.ndarray:
    """(F, C) float: the step between two numbers the file can write at each of ``values`` (F, C) (a take's
    :meth:`~mocapkit.motion.Motion.channel_values`, degrees and file units). Two ways of writing are tried: the
    fewest fixed decimals ``d`` (0-9; step ``10^-d``) and the fewest significant digits ``s`` (1-12; step
    ``10^(e - s + 1)`` at a value of exponent ``e``) that at least 99 % of the nonzero values fit; of those that
    fit, the coarser (the larger mean log step: a file written one way fits the other only with finer steps) is
    the file's. Never under the float's own spacing (times 16), which is all a take that fits neither gets. A
    value that does not fit keeps a step finer than its own, so such a frame is told from a midpoint by less,
    never more."""
    x = np.asarray(values, dtype=np.float64)
    floor = 16 * np.spacing(np.maximum(np.abs(x), 1.0))
    nz = np.isfinite(x) & (x != 0)
    flat = x[nz]
    if flat.size == 0:
        return floor
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.floor(np.log10(np.abs(x)))
    candidates = []
    for d in range(10):
        if _share_fits(flat, lambda a, b, d=d: 10.0 ** -d):
            candidates.append(np.full(x.shape, 10.0 ** -d))
            break
    low = e[nz].min()  # the exponents are a few whole numbers: each power made once, read by index
    which = (e[nz] - low).astype(np.int64)
    exps = low + np.arange(which.max() + 1, dtype=np.float64)
    for s in range(1, 13):
        powers = 10.0 ** (exps - s + 1)
        if _share_fits(flat, lambda a, b, p=powers: p[which[a:b]]):
            candidates.append(np.where(nz, 10.0 ** (np.where(nz, e, 0.0) - s + 1), 0.0))
            break
    if not candidates:
        return floor
    best = max(candidates, key=lambda c: float(np.mean(np.log10(c[nz]))))
    return np.maximum(best, floor)


#: the parts :func:`_share_fits` reads a take's values in (no part under 2,048 values)
_PARTS = 16


def _share_fits(flat: np.ndarray, steps) -> bool:
    """Whether at least :data:`_FIT_SHARE` of ``flat`` (N,) are whole numbers of their steps (``steps(a, b)``: the
    steps of ``flat[a:b]``, or one step for all), read a part at a time (:data:`_PARTS`) and decided as soon as the
    values that do not fit already leave less than that share: the same answer as
    ``np.mean(_fits(flat, step)) >= _FIT_SHARE`` (the share a count of whole values over N either way), most
    candidate precisions refused after one part."""
    n = flat.size
    misses = 0
    part = max(2048, -(-n // _PARTS))
    for a in range(0, n, part):
        b = min(a + part, n)
        misses += int(np.count_nonzero(~_fits(flat[a:b], steps(a, b))))
        if (n - misses) / n < _FIT_SHARE:
            return False
    return True


_MIDPOINTS: "weakref.WeakKeyDictionary[Motion, np.ndarray]" = weakref.WeakKeyDictionary()


def midpoint_frames(motion: Motion, values: np.ndarray | None = None) -> np.ndarray:
    """(F,) bool, read-only: the frames that are the midpoint of their neighbours (module docstring: linear or
    slerp, on every channel, to the file's written precision, the neighbours apart by more than it); the first
    and last frames never. Kept per Motion (an immutable take) while it lives: ``clean``'s note, detection and
    repair ask it of the same take. ``values``: ``motion.channel_values()`` when the caller has them already
    (None: made here)."""
    got = _MIDPOINTS.get(motion)
    if got is None:
        got = _midpoint_frames(motion, values)
        got.flags.writeable = False
        _MIDPOINTS[motion] = got
    return got


def _midpoint_frames(motion: Motion, values: np.ndarray | None = None) -> np.ndarray:
    """:func:`midpoint_frames`, computed. The slerp midpoints are made only at the frames the cheap tests leave
    open (the body moves, the frame is not linear, every position channel is): a frame that fails those is no
    slerp midpoint, and real motion fails them nearly everywhere (its root moves)."""
    F = motion.num_frames
    out = np.zeros(F, dtype=bool)
    if F < 3:
        return out
    sk = motion.skeleton
    x = motion.channel_values() if values is None else np.asarray(values, dtype=np.float64)
    h = written_steps(x) / 2
    bound = (h[1:-1] + (h[:-2] + h[2:]) / 2) * 1.01 + 1e-12  # (F-2, C)
    off = np.abs(x[1:-1] - (x[:-2] + x[2:]) / 2)
    moves = np.any(np.abs(x[2:] - x[:-2]) > 2 * bound, axis=1)
    linear = np.all(off <= bound, axis=1)
    joint_of = np.array([j for j in range(sk.num_joints) for _ in sk.joint_channels(j)], dtype=np.int64)
    is_rot = np.array([c.endswith("rotation") for j in range(sk.num_joints) for c in sk.joint_channels(j)], dtype=bool)
    slerp = np.all(off[:, ~is_rot] <= bound[:, ~is_rot], axis=1)
    if is_rot.any():
        at = np.flatnonzero(slerp & moves & ~linear)  # (n,) the open frames, as rows of frames 1..F-2
        slerp[:] = False
        if len(at):
            q = np.asarray(motion.rotations)
            root = np.asarray(motion.root_positions)
            tr = None if motion.translations is None else (motion.translations[at] + motion.translations[at + 2]) / 2
            mid = Motion(sk, R.slerp(q[at], q[at + 2], 0.5), (root[at] + root[at + 2]) / 2,
                         motion.fps, translations=tr).channel_values()
            per_joint = np.zeros((len(at), sk.num_joints))
            np.add.at(per_joint.T, joint_of[is_rot], bound[at][:, is_rot].T)
            d = np.abs(x[at + 1][:, is_rot] - mid[:, is_rot]) % 360.0
            slerp[at] = np.all(np.minimum(d, 360.0 - d) <= per_joint[:, joint_of[is_rot]], axis=1)
    out[1:-1] = (linear | slerp) & moves
    return out


def find_inbetweens(motion: Motion, skip: np.ndarray | None = None,
                    values: np.ndarray | None = None) -> tuple[Inbetween, ...]:
    """The runs of at most :data:`MAX_RUN` frames of ``motion`` that are each the midpoint of their neighbours
    (:func:`midpoint_frames`), by first frame; frames in ``skip`` ((F,) bool: all-zero frames, stutters) are in
    none, nor next to one (a run that would hold or touch one is left out whole). ``()`` when the runs are the
    take's own rate, a regular upsampling (:func:`upsampling`): those frames are at their true times. ``values``:
    ``motion.channel_values()`` when the caller has them already."""
    found = midpoint_runs(motion, skip, values)
    return () if upsampling(found, motion.num_frames) else found


def midpoint_runs(motion: Motion, skip: np.ndarray | None = None,
                  values: np.ndarray | None = None) -> tuple[Inbetween, ...]:
    """:func:`find_inbetweens` before the upsampling test: every run of at most :data:`MAX_RUN` midpoint frames
    away from ``skip``, by first frame."""
    mid = midpoint_frames(motion, values)
    near = np.zeros(motion.num_frames + 1, dtype=bool)
    if skip is not None:
        skip = np.asarray(skip, dtype=bool)
        near[:-1] = skip
        near[1:] |= skip
    return tuple(Inbetween(int(a), int(b) - 1) for a, b in contact_segments(mid)
                 if b - a <= MAX_RUN and not near[a:b + 1].any())


#: the fewest runs, one period apart, that make a regular upsampling (:func:`upsampling`)
MIN_PERIODS = 8


def upsampling(found, num_frames: int) -> int:
    """The period ``P`` (frames) when the runs ``found`` (:func:`midpoint_runs`) are a regular upsampling of the
    take, else 0: runs of one length ``L`` starting every ``P`` frames (the most common step between runs), at
    least :data:`MIN_PERIODS` such steps, covering at least half the take (``L / P`` of its frames, half of them).

    A frame-rate change by slerp or linear blend (``convert --fps 240`` of a 120 fps take: every other frame a
    midpoint; 30 to 120 fps: three of every four) writes midpoints at regular times, each at its true time on the
    file's own rate. Left out, the take would be analysed with half (a quarter) of its frames at the file's rate,
    its motion at twice (four times) its speed: a 120 fps CMU take upsampled by slerp to 240 fps then had 10 motion
    words of 23 judged where the take at 120 fps had 48, and a 279-frame HDM05 take failed as shorter than a word.
    A frame another tool inserted once in a while lies at no regular step; those are left out as before."""
    found = tuple(found)
    if len(found) <= MIN_PERIODS:
        return 0
    first = np.array([b.first for b in found], dtype=np.int64)
    length = np.array([b.last - b.first + 1 for b in found], dtype=np.int64)
    steps = np.diff(first)
    values, counts = np.unique(steps, return_counts=True)
    period = int(values[np.argmax(counts)])
    regular = (steps == period) & (length[1:] == length[:-1])
    if regular.sum() < MIN_PERIODS:
        return 0
    run = int(np.bincount(length[1:][regular]).argmax())
    covered = int(length[1:][regular & (length[1:] == run)].sum())
    return period if covered >= 0.5 * num_frames * run / period else 0


def interpolated_note(motion: Motion, skip: np.ndarray | None = None, values: np.ndarray | None = None) -> str:
    """The line ``clean`` and ``detect`` say of ``motion``'s interpolated frames: :func:`inbetweens_note` of
    :func:`find_inbetweens`, or, when they are a regular upsampling (:func:`upsampling`), that the take is
    analysed at its own rate with them; ``""`` for none."""
    found = midpoint_runs(motion, skip, values)
    period = upsampling(found, motion.num_frames)
    if not period:
        return inbetweens_note(found)
    n = sum(b.last - b.first + 1 for b in found)
    return (f"{n} of {motion.num_frames} frames are the midpoint of their neighbours on every channel, about "
            f"{round(n * period / motion.num_frames)} of every {period} (the take looks upsampled by slerp or "
            f"linear blend, as `convert --fps` writes): they are the take's own frames at its rate, analysed "
            f"and repaired as the others are")


def inbetweens_note(found) -> str:
    """One line counting the interpolated frames of ``found`` (:func:`find_inbetweens`) and naming the first
    eight runs; ``""`` for none."""
    found = tuple(found)
    if not found:
        return ""
    n = sum(b.last - b.first + 1 for b in found)
    shown = ", ".join(str(b.first) if b.first == b.last else f"{b.first}-{b.last}" for b in found[:8])
    more = f" and {len(found) - 8} more runs" if len(found) > 8 else ""
    s = "s" if n > 1 else ""
    return (f"{n} frame{s} ({shown}{more}) look{'' if n > 1 else 's'} interpolated: the midpoint of "
            f"{'their' if n > 1 else 'its'} neighbours on every channel, to the file's precision (as a retiming or "
            f"a dropped-frame fix writes); detection analyses the take without {'them' if n > 1 else 'it'} and "
            f"repair changes {'them' if n > 1 else 'it'} only where the frames around are changed")
