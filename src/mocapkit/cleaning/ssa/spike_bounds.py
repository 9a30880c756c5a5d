"""A spike's flags: the frames the spike holds, not the frames beside it that digress.

A spike (:func:`~mocapkit.cleaning.ssa.spikes.spike_breaks`: the joint leaves its path for a few frames and comes
back to it, such as a hand flipped 180 degrees for two frames and flipped back) is its own evidence: its frames
lie off the path that the frames on both sides share. The frames beside it are on that path; the digression
there says nothing about them. The neighbour words a spike leads astray span a whole word (0.6 s), and a
context whose clips hold the same flip (a performer's other takes, captured with the same solver) holds the
flipped pose as the norm, so the good frames around the flip digress and the flipped frames do not. Read as
any digression's break (:func:`~mocapkit.cleaning.ssa.cues.confirm_flags`), a spike confirmed the digressing
frames within the margin on both sides and none of its own: HDM05's HDM_dg_throwBasketball_007 right hand,
flipped 180 degrees at frames 152-153, was left flipped, and the nine good frames around it (moving under a
degree a frame) were turned by 62 to 148 degrees against a context of dg's other throws.

So a run whose breaks are all spikes is flagged on the spikes' own frames only, whatever the digression there:
the run's digression (over the threshold somewhere within the margin of a spike) confirms that the run is an
error, and the spike says which frames are. A cue of this library, not of Aristidou et al. (2018).
"""

from __future__ import annotations

import numpy as np

from .events import event_bounds

__all__ = ["spike_frames"]


def spike_frames(breaks: np.ndarray) -> np.ndarray:
    """The frames a joint's spikes hold, from their sorted break frames ``breaks`` (n,) int (at least one).

    A spike of k frames (``f .. f + k - 1``) breaks at the frame before it and the one after it too (the
    midpoint residual of its neighbours), so an event (:func:`~mocapkit.cleaning.ssa.events.event_bounds`) that
    spans three frames or more holds the frames strictly inside it; a shorter event (a spike at the take's
    edge, or one whose neighbours did not break) holds all of its frames. Returns the sorted frames (m,) int.
    """
    first, last, _ = event_bounds(np.asarray(breaks, dtype=np.int64))
    wide = last - first >= 2
    lo, hi = np.where(wide, first + 1, first), np.where(wide, last - 1, last)
    return np.concatenate([np.arange(a, b + 1) for a, b in zip(lo, hi)])
