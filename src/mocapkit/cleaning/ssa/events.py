"""Break events: a joint's break frames grouped into the events they belong to.

A break (a midpoint residual over the break level, :func:`~mocapkit.cleaning.ssa.cues.residual_breaks`) marks the
frames around a step or a spike, and one error makes several: a step from ``f`` to ``f + 1`` marks both frames, a
spike the frame before it and the one after it too. Break frames at most :data:`EVENT_GAP` apart are read as one
event, by every cue that judges breaks (the confirmation's spikes and offsets, a freeze's end, a spike's own frames,
the smooth-turn test). A grouping of this library, not of Aristidou et al. (2018).
"""

from __future__ import annotations

import numpy as np

__all__ = ["EVENT_GAP", "event_bounds", "pair_events"]

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


def pair_events(breaks: np.ndarray, j: int, p: int, held: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The break events a left/right pair ``j``, ``p`` shares, as a label exchange makes them: ``(first, last)``
    (n,) int, the events (:func:`event_bounds`) of the frames where ``p`` breaks within a frame of a break of ``j``
    (``breaks`` (F, J) bool), less the ``held`` frames ((F, J) bool; None: none) held on both joints (the break of
    a swap with one break, paired with no other). The frames of such an event beside them stay an event of their
    own: the break of a swap from the take's first frame and the next swap's entry four frames later are one
    event, and held whole it would take the second swap's entry with it (bundled bow_active_001, forearms swapped
    over frames 0-6 and 10-16: read so, only the clean frames 7-9 are a swap). Empty where fewer than two such
    frames are."""
    from scipy import ndimage

    frames = np.flatnonzero(ndimage.binary_dilation(breaks[:, j], structure=np.ones(3, dtype=bool)) & breaks[:, p])
    if held is not None:
        frames = frames[~(held[frames, j] & held[frames, p])]
    if len(frames) < 2:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    first, last, _ = event_bounds(frames)
    return first, last
