"""Frames that hold no motion of their own, analysed once: repeats of the frame before and interpolated frames.

The self-similarity analysis resamples a take to the analysis rate (24 fps) on a time grid that starts at its
first frame (:func:`~mocapkit.cleaning.ssa.texture.motion_texture`), and the take is its own context: its words
are the neighbour words of every other word (Aristidou et al. 2018, section 3). One frame written twice shifts
every later frame of the take by one frame time, so every later analysis frame samples the motion at another
instant; the neighbour words found, their mean texture and each joint's row scale change along the whole take,
and the flags with them. On CMU 131_01 (120 fps) with errors of :func:`mocapkit.corrupt.real_errors`, one frame
written twice changed 4 to 18 flagged cells more than two words (1.25 s) from it, up to 613 frames away, and the
digression of 18 % of the cells before it by over a degree.

A repeated frame holds no motion of its own, so :func:`~mocapkit.cleaning.ssa.detect` analyses the take without
its repeats (:func:`without_repeats`) and gives each repeat what the frame it repeats was given
(:func:`expand`): a frame written twice then changes nothing but its own row, and the flags of the take and of
the take with the frame written once agree everywhere else. :func:`~mocapkit.cleaning.ssa.repair` mends the take
without its repeats the same way and writes each repeat as its frame was written, so a repeat stays a repeat
(``clean`` names stutters and keeps the take's frames and timing, :mod:`mocapkit.cleaning.stutters`).

A frame another tool inserted between two recorded ones (an interpolated frame, the midpoint of its neighbours on
every channel to the file's precision: :func:`~mocapkit.cleaning.inbetweens.find_inbetweens`) shifts the grid the
same way: one to three slerp midpoints put into 30 HDM05, CMU BVH and Bandai Namco takes (clean and with
:func:`mocapkit.corrupt.real_errors`) changed 21 flagged cells at the take's own frames, 7 of them more than
1.25 s away. It is analysed once too (:func:`inbetween_runs`): the take is analysed without it, and it is given what the
frames it lies between were given, its marks (flags, causes, cues: bool and bit arrays) those of either
(:func:`expand`), its values (MDM, digression) the frame before's. :func:`~mocapkit.cleaning.ssa.repair` writes
it, where a frame it lies between was changed, as the same blend of the changed frames, and leaves it bit for bit
elsewhere, so an interpolated frame stays one.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ... import rotations as R
from ...motion import Motion
from ..inbetweens import find_inbetweens
from ..stutters import find_stutters

__all__ = [
    "analysed_frames", "analysed_once", "blend_inbetweens", "expand", "frame_index", "inbetween_runs", "repeat_runs",
    "without_repeats",
]


def repeat_runs(motion: Motion) -> tuple[tuple[int, int], ...]:
    """``((first, last), ...)``: the runs of frames that repeat frame ``first - 1`` bit for bit
    (:func:`~mocapkit.cleaning.stutters.find_stutters`: rotations, root position and animated offsets all equal,
    the take's first two frames never a repeat), by first frame; ``()`` when none."""
    return tuple((int(s.first), int(s.last)) for s in find_stutters(motion))


def inbetween_runs(motion: Motion, repeats=()) -> tuple[tuple[int, int], ...]:
    """``((first, last), ...)``: the runs of frames that lie evenly between frames ``first - 1`` and ``last + 1``
    (:func:`~mocapkit.cleaning.inbetweens.find_inbetweens`: each the midpoint of its neighbours on every channel,
    to the file's written precision; at most :data:`~mocapkit.cleaning.inbetweens.MAX_RUN` frames), none in or
    next to the ``repeats`` (:func:`repeat_runs`), by first frame; ``()`` when none."""
    skip = ~kept_frames(repeats, motion.num_frames) if repeats else None
    return tuple((int(b.first), int(b.last)) for b in find_inbetweens(motion, skip=skip))


def analysed_once(repeats, inbetweens=()) -> tuple[tuple[int, int], ...]:
    """The runs of frames the take is analysed without: ``repeats`` and ``inbetweens`` together, by first frame."""
    return tuple(sorted((int(a), int(b)) for a, b in tuple(repeats) + tuple(inbetweens)))


def analysed_frames(motion: Motion) -> int:
    """The frames of ``motion`` that :func:`~mocapkit.cleaning.ssa.detect` analyses: its frames less its repeats
    (:func:`repeat_runs`) and interpolated frames (:func:`inbetween_runs`), the length the take's words are
    counted in."""
    runs = repeat_runs(motion)
    once = analysed_once(runs, inbetween_runs(motion, runs))
    return motion.num_frames - sum(b - a + 1 for a, b in once)


def kept_frames(runs, num_frames: int) -> np.ndarray:
    """(F,) bool: the frames that repeat no frame (False on the ``runs``' frames, :func:`repeat_runs`)."""
    keep = np.ones(int(num_frames), dtype=bool)
    for a, b in runs:
        keep[int(a) : int(b) + 1] = False
    return keep


def frame_index(runs, num_frames: int) -> np.ndarray:
    """(F,) int64: for each frame of the take, its frame in the take without its repeats (a repeat: the frame it
    repeats)."""
    return np.cumsum(kept_frames(runs, num_frames)) - 1


def without_repeats(motion: Motion, runs) -> Motion:
    """``motion`` without the frames of ``runs`` (:func:`repeat_runs`): rotations, root positions and animated
    offsets; the name, skeleton and frame rate kept. ``motion`` itself when ``runs`` is empty."""
    if not runs:
        return motion
    keep = kept_frames(runs, motion.num_frames)
    tr = None if motion.translations is None else np.asarray(motion.translations)[keep]
    return dataclasses.replace(motion, rotations=np.asarray(motion.rotations)[keep],
                               root_positions=np.asarray(motion.root_positions)[keep], translations=tr)


def expand(a: np.ndarray, runs, num_frames: int, inbetweens=()) -> np.ndarray:
    """``a`` (F', ...) at the frames of the take without the frames of ``runs`` (:func:`analysed_once`), put at
    the take's ``num_frames`` frames (F, ...): each frame of a run takes the row of the frame before the run (a
    repeat: the frame it repeats). A frame of an ``inbetweens`` run (which ``runs`` holds) lies between the frames
    around its run: where ``a`` holds marks (bool, or unsigned bit flags) it takes those of either."""
    a = np.asarray(a)
    index = frame_index(runs, num_frames)
    out = a[index]
    if inbetweens and (a.dtype == bool or np.issubdtype(a.dtype, np.unsignedinteger)):
        frames = np.concatenate([np.arange(f, l + 1) for f, l in inbetweens])
        after = np.concatenate([np.full(l - f + 1, index[l + 1]) for f, l in inbetweens])
        out[frames] |= a[after]
    return out


def blend_inbetweens(motion: Motion, repaired: Motion, inbetweens) -> Motion:
    """``repaired`` (``motion`` mended, the same frames) with each frame of the ``inbetweens`` runs
    (:func:`inbetween_runs`) written again as ``motion`` wrote it: bit for bit where the frames around its run
    (``first - 1`` and ``last + 1``) are unchanged, and where they were changed (a joint's rotation: slerp; the
    root's position and animated offsets: linear) the same blend of the changed frames (frame ``t`` at
    ``(t - first + 1) / (last - first + 2)`` of the way), so an interpolated frame stays one."""
    if not inbetweens:
        return repaired
    t = np.concatenate([np.arange(a, b + 1) for a, b in inbetweens])
    p = np.concatenate([np.full(b - a + 1, a - 1) for a, b in inbetweens])
    n = np.concatenate([np.full(b - a + 1, b + 1) for a, b in inbetweens])
    w = (t - p) / (n - p)

    def blend(orig, new, mix):
        orig, new = np.asarray(orig), np.array(new)
        changed = np.any((new[p] != orig[p]) | (new[n] != orig[n]), axis=-1)
        new[t] = np.where(changed[..., None], mix(new[p], new[n]), orig[t])
        return new

    def lerp(a, b):
        return a + (b - a) * w.reshape((-1,) + (1,) * (a.ndim - 1))

    rot = blend(motion.rotations, repaired.rotations, lambda a, b: R.slerp(a, b, w[:, None]))
    root = blend(motion.root_positions, repaired.root_positions, lerp)
    tr = None if repaired.translations is None else blend(motion.translations, repaired.translations, lerp)
    return dataclasses.replace(repaired, rotations=rot, root_positions=root, translations=tr)
