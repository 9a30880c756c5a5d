"""Break events: a joint's break frames grouped into the events they belong to.

A break (a midpoint residual over the break level, :func:`~mocapkit.cleaning.ssa.cues.residual_breaks`) marks the
frames around a step or a spike, and one error makes several: a step from ``f`` to ``f + 1`` marks both frames, a
spike the frame before it and the one after it too. Break frames at most :data:`EVENT_GAP` apart are read as one
event, by every cue that judges breaks (the confirmation's spikes and offsets, a freeze's end, a spike's own frames,
the smooth-turn test). A grouping of this library, not of Aristidou et al. (2018).
"""

from __future__ import annotations

import numpy as np

__all__ = ["EVENT_GAP", "event_bounds"]

#: break frames at most this many frames apart are one break event
EVENT_GAP = 3


def event_bounds(frames: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sorted break frames (at least one) grouped into events, runs whose frames lie at most :data:`EVENT_GAP`
    apart: ``(first, last, event)``, the events' first and last frames (n,) and the event of each of ``frames``."""
    cut = np.flatnonzero(np.diff(frames) > EVENT_GAP) + 1
    event = np.zeros(len(frames), dtype=np.int64)
    event[cut] = 1
    event = np.cumsum(event)
    return frames[np.concatenate([[0], cut])], frames[np.concatenate([cut - 1, [len(frames) - 1]])], event
