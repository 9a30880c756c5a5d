"""Spikes: a joint that leaves its path for a few frames and comes back to it (a hand flipped for two frames).

:func:`spike_breaks` tells which break events of the take are spikes rather than steps (the run they confirm is
then flagged on the spikes' own frames, :mod:`~mocapkit.cleaning.ssa.spike_bounds`); :func:`lone_spikes` flags
the spikes far past the joint's own motion where no neighbour word judges them. Both read the midpoint residuals
of :func:`~mocapkit.cleaning.ssa.cues.midpoint_residuals` on (F, J) arrays at the take's own frame rate. Cues of
this library, beside the digression of Aristidou et al. (2018).
"""

from __future__ import annotations

import numpy as np

from ..ik import segment_frames
from .cues import event_steps, off_path, residual_breaks, row_norms, uncompensated_breaks
from .events import event_bounds
from .params import SSAParams

__all__ = ["LONE_SPIKE_MAX_FRAMES", "LONE_SPIKE_MIN_DEG", "LONE_SPIKE_RATIO", "lone_spikes", "spike_breaks"]

_D = SSAParams()


def spike_breaks(q: np.ndarray, resid: np.ndarray, breaks: np.ndarray, ratio: float = 0.5) -> np.ndarray:
    """(F, J) bool: the break events (``breaks``, grouped as :func:`~mocapkit.cleaning.ssa.events.event_bounds` does) that are spikes.

    A spike leaves the joint on the path it was on: the step across its
    event (:func:`~mocapkit.cleaning.ssa.cues.event_steps`, from the path before to the path after) is
    under ``ratio`` times the event's largest midpoint residual ``resid``.
    A step of s degrees between two frames leaves residuals of s / 2 and
    a step of s, a ratio of 2; a one-frame spike of s degrees a residual of s
    and no step. Events touching the take's ends are not called spikes.
    ``q`` (F, J, 4) rotations, ``resid`` (F, J) radians, ``breaks`` (F, J) bool.
    """
    out = np.zeros(breaks.shape, dtype=bool)
    for j in np.flatnonzero(breaks.any(axis=0)):
        frames = np.flatnonzero(breaks[:, j])
        first, last, event = event_bounds(frames)
        span, _, start = segment_frames(first, last - first + 1)  # the frames first .. last of each event
        peak = np.maximum.reduceat(resid[span, j], start)
        spike = row_norms(event_steps(q[:, j], first, last)) < ratio * peak  # NaN (ends of the take): no spike
        out[frames[spike[event]], j] = True
    return out


#: :func:`lone_spikes`: how many times the joint's largest residual elsewhere a spike's must reach, and the fewest
#: degrees it must leave the path by (real motion's spike-shaped breaks reach 3.1 times that level on the CMU,
#: HDM05 and Bandai Namco takes at 30 and 120 fps; the captures' own glitches, a hand flipping for a few frames,
#: 5 to 100 times; corrupt.real_errors' spikes of 30 to 90 deg, 5 to 50 times)
LONE_SPIKE_RATIO = 5.0
LONE_SPIKE_MIN_DEG = 20.0
LONE_SPIKE_MAX_FRAMES = 3  # off the path for at most this many frames (corrupt.real_errors' spikes: 1-3)


def lone_spikes(q: np.ndarray, resid: np.ndarray, judged: np.ndarray, analysed: np.ndarray, parents=None,
                jump_deg: float = _D.jump_deg, ratio: float = LONE_SPIKE_RATIO,
                min_deg: float = LONE_SPIKE_MIN_DEG, max_frames: int = LONE_SPIKE_MAX_FRAMES,
                memo: dict | None = None) -> np.ndarray:
    """(F, J) bool: the frames of spikes far past the joint's own motion, where no neighbour word judges them.

    The movement digression map flags only motion the take (or its context) repeats: a word with no neighbour within
    the gate is not judged (Aristidou et al. 2018 find an error by similar motion, section 3.4), and 30 to 90 deg
    spikes in a dance or a take lying down went through unflagged. A spike is an error whatever the motion around
    it: the joint leaves its path and comes back within a few frames by far more than its own motion ever does. A
    break event (midpoint residuals over ``jump_deg``, grouped as :func:`~mocapkit.cleaning.ssa.events.event_bounds` does, less those the joint's
    chain undoes, :func:`~mocapkit.cleaning.ssa.cues.uncompensated_breaks`, with ``parents``) is such a spike when it holds at most
    ``max_frames`` frames between its first and last break (a joint under noise breaks at every frame, one long
    event), its frames lie at least ``min_deg`` off the slerp between the frames beside it and (a return to the
    path) that is twice the turn between those two frames or more, or :func:`spike_breaks` calls it one; and when
    its largest residual is at least ``ratio`` times the joint's largest residual outside it and outside the joint's
    largest other such spike (so that two errors on one joint do not hide each other, while a flick the joint makes
    in every stride does not stand out). The frames flagged are the spike's own, between its first and last break (a
    spike of k frames breaks at the frame before it and the one after too), and only where no cell is judged
    (``judged`` (F, J) bool, a finite digression; the rest is the digression's to judge) and the joint is
    ``analysed`` ((J,) bool): there :func:`~mocapkit.cleaning.ssa.repair` has no neighbour word and bridges them by
    slerp between the frames beside them. ``q`` (F, J, 4) rotations, ``resid`` (F, J) radians
    (:func:`~mocapkit.cleaning.ssa.cues.midpoint_residuals`). ``memo``: :func:`~mocapkit.cleaning.ssa.cues.uncompensated_breaks`' events already judged on ``q``. A cue
    of this library, not of the paper.
    """
    F, J = resid.shape
    out = np.zeros((F, J), dtype=bool)
    breaks = residual_breaks(resid, jump_deg) & np.asarray(analysed, dtype=bool)[None, :]
    if parents is not None:
        breaks = uncompensated_breaks(q, parents, breaks, memo)
    low = np.radians(min_deg)
    for j in np.flatnonzero(breaks.any(axis=0)):
        first, last, _ = event_bounds(np.flatnonzero(breaks[:, j]))
        inside = (first >= 1) & (last <= F - 2)
        first, last = first[inside], last[inside]
        if not len(first):
            continue
        peak = np.array([resid[a : b + 1, j].max() for a, b in zip(first, last)])
        off, turn = off_path(q[:, j], first, last)
        stepped = row_norms(event_steps(q[:, j], first, last)) < 0.5 * peak  # spike_breaks' test (NaN: no)
        short = np.where(last - first >= 2, last - first - 1, last - first + 1) <= max_frames
        big = short & (off >= low) & ((off >= 2.0 * turn) | stepped)
        for i in np.flatnonzero(big):
            own = np.array(resid[:, j])
            others = np.flatnonzero(big & (np.arange(len(first)) != i))
            for k in [i] + ([int(others[np.argmax(peak[others])])] if len(others) else []):
                own[max(first[k] - 2, 0) : last[k] + 3] = 0.0
            if peak[i] < ratio * own.max():
                continue
            a, b = (first[i] + 1, last[i] - 1) if last[i] - first[i] >= 2 else (first[i], last[i])
            if not np.asarray(judged[a : b + 1, j]).any():
                out[a : b + 1, j] = True
    return out
