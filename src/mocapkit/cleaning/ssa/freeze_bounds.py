"""A frozen channel's flags: its frozen frames, not the live frames on either side of them.

A frozen channel (:func:`~mocapkit.cleaning.ssa.freezes.frozen_channels`) repeats the last sample the joint
had, then jumps to where the limb has gone: the break at its end is the freeze's own. Read as any digression's
break (:func:`~mocapkit.cleaning.ssa.cues.confirm_flags`), it confirmed the whole run of digression over half
the threshold that reaches it, and on a 30 fps take that run goes on through live motion before the freeze (the
neighbour words the freeze leads astray span 0.6 s; motion the take does not repeat digresses by itself): a
left shoulder of bvh-python's test_mocapbank (30 fps) frozen for 18 frames had the 38 live frames before it
repaired too, up to 33.8 deg away from the capture. Two rules here:

* **The break that ends a freeze confirms the freeze**: the digression it confirms is kept on the frozen
  frames only, and the joint's other breaks confirm what they confirm without it (:func:`bounded_breaks`).
* **A hold that is a freeze is the freeze**: the cells :func:`~mocapkit.cleaning.ssa.cues.held_joints` flags
  in a hold that holds a frozen stretch are kept on the frozen frames (:func:`bounded_holds`); a hold's
  first frame is the last live sample, the one the channel froze at, and is right.

And for every hold of three frames or more, frozen bit for bit or not: **a hold's first frame is the sample it
holds** (:func:`held_repeats`): a held joint's flags are its repeats, as a frozen channel's are. A hold that no
exact-freeze rule bounds (its exit no break of the joint's own) otherwise has that live sample repaired too:
HDM05 bd ``sneak2StepsLStart`` 001 with ``real_errors`` seed 1001, the right toes held over frames 102-126 at
frame 101's value, whose repair from frame 101 put that clean frame 4.2 deg off the clean take.

Where a joint has no frozen stretch nothing changes but that first frame. A cue of this library, not of
Aristidou et al. (2018).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..runs import true_runs
from .events import event_bounds

__all__ = ["freeze_end_breaks", "bounded_breaks", "bounded_holds", "held_repeats"]


def freeze_end_breaks(breaks: np.ndarray, frozen: np.ndarray) -> np.ndarray:
    """(F, J) bool: the break events of ``breaks`` that end a frozen stretch of ``frozen``.

    ``breaks`` (F, J) bool, a joint's breaks (a step from ``f`` to ``f + 1`` marks both frames); ``frozen`` (F, J)
    bool, the frozen channels' cells (the repeats of each hold, :func:`~mocapkit.cleaning.ssa.freezes.frozen_channels`).
    A stretch of frames ``s .. e`` ends in the break event (:func:`~mocapkit.cleaning.ssa.events.event_bounds`) that
    holds frame ``e`` or ``e + 1``; that event's frames are returned, the joint's other breaks are not.
    """
    breaks, frozen = np.asarray(breaks, dtype=bool), np.asarray(frozen, dtype=bool)
    if breaks.shape != frozen.shape or breaks.ndim != 2:
        raise ValueError(f"breaks and frozen must be the same (F, J) shape, got {breaks.shape} and {frozen.shape}")
    out = np.zeros_like(breaks)
    for j in np.flatnonzero(breaks.any(axis=0) & frozen.any(axis=0)):
        frames = np.flatnonzero(breaks[:, j])
        _, _, event = event_bounds(frames)  # the event of each break frame
        for _, e in true_runs(frozen[:, j]):
            ending = np.unique(event[(frames == e) | (frames == e + 1)])
            out[frames[np.isin(event, ending)], j] = True
    return out


def bounded_breaks(confirm: Callable[[np.ndarray], np.ndarray], breaks: np.ndarray, frozen) -> np.ndarray:
    """(F, J) bool: the digressions ``confirm`` confirms by ``breaks``, those of a freeze's end on its frozen cells only.

    ``confirm`` maps (F, J) bool breaks to (F, J) bool flags (:func:`~mocapkit.cleaning.ssa.cues.confirm_flags`
    of the take's MDM); ``frozen`` (F, J) bool or None (none: ``confirm(breaks)`` as it is). The flags are those
    the breaks that end no freeze confirm, and those all of them confirm on frozen cells.
    """
    confirmed = confirm(breaks)
    if frozen is None:
        return confirmed
    frozen = np.asarray(frozen, dtype=bool)
    ends = freeze_end_breaks(breaks, frozen)
    if not ends.any():
        return confirmed
    return confirm(np.asarray(breaks, dtype=bool) & ~ends) | (confirmed & frozen)


def bounded_holds(holds: np.ndarray, frozen) -> np.ndarray:
    """(F, J) bool: ``holds`` with each hold that holds a frozen stretch cut to its frozen cells.

    ``holds`` (F, J) bool, :func:`~mocapkit.cleaning.ssa.cues.held_joints`' cells; ``frozen`` (F, J) bool or None
    (none: ``holds`` as they are). A hold with no frozen cell is kept whole.
    """
    holds = np.array(holds, dtype=bool)
    if frozen is None:
        return holds
    frozen = np.asarray(frozen, dtype=bool)
    for j in np.flatnonzero(holds.any(axis=0) & frozen.any(axis=0)):
        for a, b in true_runs(holds[:, j]):
            if frozen[a : b + 1, j].any():
                holds[a : b + 1, j] &= frozen[a : b + 1, j]
    return holds


def held_repeats(holds: np.ndarray) -> np.ndarray:
    """(F, J) bool: ``holds`` (F, J) bool, :func:`~mocapkit.cleaning.ssa.cues.held_joints`' cells, less the first
    frame of each run of three held frames or more: the live sample the hold repeats (module docstring).

    A run of two frames (one still step, the shortest hold at 24-30 fps) is kept whole: its repeats hold no still
    step of their own, so nothing shows which of the two frames the channel holds (CMU charleston2 at 30 fps: the
    left wrist still for one step at frames 129-130 as it slows, 0.015 deg, whose repair of frame 130 alone moved a
    clean frame 1.4 deg where the repair of both is given back by the guard).
    """
    holds = np.asarray(holds, dtype=bool)
    out = holds.copy()
    F = len(holds)
    if F < 3:
        return out
    prev = np.zeros_like(holds)
    prev[1:] = holds[:-1]
    nxt = np.zeros_like(holds)
    nxt[:-1] = holds[1:]
    nxt2 = np.zeros_like(holds)
    nxt2[:-2] = holds[2:]
    out[holds & ~prev & nxt & nxt2] = False  # the first frame of a run of three or more
    return out
