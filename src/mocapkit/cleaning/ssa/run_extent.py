"""Which frames of a confirmed run are flagged: the extent a run's breaks give it.

:func:`~mocapkit.cleaning.ssa.cues.confirm_flags` finds the runs of digression that hold a break of the joint's own
trajectory; the breaks then say which of the run's frames the error holds (Aristidou et al. 2018 flag every
frame of MDM over the threshold; the neighbour words an error leads astray span a whole word, 0.6 s, so the
digression spreads past the error on both sides, and a context whose clips hold the same defect digresses on
the good frames instead of the bad ones):

* **Only spikes**: the spikes' own frames (:func:`~mocapkit.cleaning.ssa.spike_bounds.spike_frames`), digressing
  or not: a spike is its own evidence, the frames beside it lie on the path it left.
* **Two break events or more** (separate steps): the digressing frames from the first break to the last, within
  the margin: an error starts and ends with a break.
* **One break event** (a drift that grows smoothly, a frozen channel, each ending in a step): the digressing frames
  before the break, up to the margin past it; an error ends with a break, and past its last one the joint is
  back on its path.

A rule of this library, not of the paper.
"""

from __future__ import annotations

import numpy as np

from .spike_bounds import spike_frames

__all__ = ["run_cells"]


def run_cells(low: np.ndarray, breaks: np.ndarray, spikes: np.ndarray | None, margin: int) -> np.ndarray:
    """(L,) bool: the flagged frames of one confirmed run of one joint (module docstring).

    ``low`` (L,) bool, the run's frames digressing over half the threshold; ``breaks`` (L,) bool, its frames of
    the joint's own breaks (at least one; a step from f to f + 1 marks both); ``spikes`` (L,) bool or None, the
    break frames that are spikes (:func:`~mocapkit.cleaning.ssa.spikes.spike_breaks`; None: no break is taken for
    a spike); ``margin`` frames, the confirmation's margin at the take's rate. Frames are the run's own, 0-based.
    """
    low = np.asarray(low, dtype=bool)
    at = np.flatnonzero(breaks)
    out = np.zeros(len(low), dtype=bool)
    if spikes is not None and np.asarray(spikes, dtype=bool)[at].all():
        out[spike_frames(at)] = True
        return out
    out[: at[-1] + margin + 1] = low[: at[-1] + margin + 1]  # past its last break a run digresses only
    if (np.diff(at) > 2).any():  # two break events or more (a step marks two adjacent frames): from the first
        out[: max(at[0] - margin, 0)] = False
    return out
