"""Frames that repeat the frame before bit for bit (a capture's or an exporter's stutter), analysed once.

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

A frame inserted that repeats no frame (an interpolated one) is still analysed as a frame of the take.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...motion import Motion
from ..stutters import find_stutters

__all__ = ["expand", "frame_index", "repeat_runs", "without_repeats"]


def repeat_runs(motion: Motion) -> tuple[tuple[int, int], ...]:
    """``((first, last), ...)``: the runs of frames that repeat frame ``first - 1`` bit for bit
    (:func:`~mocapkit.cleaning.stutters.find_stutters`: rotations, root position and animated offsets all equal,
    the take's first two frames never a repeat), by first frame; ``()`` when none."""
    return tuple((int(s.first), int(s.last)) for s in find_stutters(motion))


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


def expand(a: np.ndarray, runs, num_frames: int) -> np.ndarray:
    """``a`` (F', ...) at the frames of the take without its repeats, put at the take's ``num_frames`` frames (F,
    ...): each repeat takes the row of the frame it repeats."""
    return np.asarray(a)[frame_index(runs, num_frames)]
