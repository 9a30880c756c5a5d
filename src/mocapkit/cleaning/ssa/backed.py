"""Breaks the movement digression map backs: errors that stay under a joint's own motion level at low frame rates.

The confirmation (:func:`~mocapkit.cleaning.ssa.cues.own_breaks`) asks a break to stand out from what the
joint's own motion reaches, three times its 95th-percentile midpoint residual. At 30 fps a game rig's toe
rolling off the floor reaches 10-15 deg residuals, so that level sits near the 33 deg cap, and two errors
the digression map (Aristidou et al. 2018, section 3.4) marks at MDM 1 confirm nothing: a 2-frame spike of
60 deg breaks by 30 deg at each of its four frames, and a 40 deg offset held for a second breaks by 20 deg
where it starts and ends. Their shape tells them from the toe's motion, where the digression agrees:

- :func:`backed_spikes`: a short event whose frames leave the slerp between the frames beside it by
  :data:`SPIKE_RATIO` times the joint's largest residual anywhere else in the take;
- :func:`backed_offsets`: two steps of one joint, the second undoing the first
  (:data:`~mocapkit.cleaning.ssa.cues.UNDO_RATIO`), at most :data:`OFFSET_MAX_S` apart, around a stretch
  that digresses from the neighbour words by at least half the step while the frames beside it do not
  (:func:`~mocapkit.cleaning.ssa.cues.stands_out`): a style or a roll of the toe that the take repeats is
  held by the neighbour words too.

Both return break frames that :func:`~mocapkit.cleaning.ssa.detect` adds to the joint's ``jumps``, so a
cell is still flagged only where :func:`~mocapkit.cleaning.ssa.cues.confirm_flags` finds the MDM over the
threshold beside them. All (F, J) arrays are at the take's own frame rate. Cues of this library, not of
the paper.
"""

from __future__ import annotations

import numpy as np

from .cues import (
    UNDO_RATIO,
    event_steps,
    off_path,
    residual_breaks,
    row_norms,
    stands_out,
    uncompensated_breaks,
)
from .events import event_bounds
from .step_pairs import undo_left
from ..ik import segment_frames
from .params import SSAParams

__all__ = ["SPIKE_RATIO", "SPIKE_MIN_DEG", "SPIKE_MAX_FRAMES", "OFFSET_MAX_S", "TAKE_PERCENTILE", "backed_spikes",
           "backed_offsets", "backed_breaks"]

_D = SSAParams()

#: :func:`backed_spikes`: how many times the joint's largest midpoint residual elsewhere a spike's frames must leave
#: its path by (on 56 clean Bandai Namco takes at 30 fps the spike-shaped events under MDM > 0.5 reach 2.2)
SPIKE_RATIO = 3.0
SPIKE_MIN_DEG = 20.0  #: the fewest degrees a backed spike leaves the path by
SPIKE_MAX_FRAMES = 3  #: off the path for at most this many frames
OFFSET_MAX_S = 2.0  #: :func:`backed_offsets`: the longest offset, seconds between its two steps


def _breaks(q, resid, analysed, parents, jump_deg, memo):
    """(F, J) bool: midpoint residuals over ``jump_deg`` on ``analysed`` joints, less those the chain undoes."""
    breaks = residual_breaks(resid, jump_deg) & np.asarray(analysed, dtype=bool)[None, :]
    return breaks if parents is None else uncompensated_breaks(q, parents, breaks, memo)


def _cores(resid: np.ndarray, first: np.ndarray, last: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(first, last)`` of each event's core: its first and last frame whose residual (``resid`` (F,) radians, one
    joint) reaches half the event's largest. A spike on a moving toe joins the toe's own breaks beside it into one
    event (residuals of 9, 10, 13 and then the spike's 30, 30, 30, 30 deg); its core is the spike's frames."""
    frames, event, start = segment_frames(first, last - first + 1)
    seg = resid[frames]
    big = seg >= 0.5 * np.maximum.reduceat(seg, start)[event]
    at = np.where(big, frames, -1)
    lo = np.minimum.reduceat(np.where(big, frames, np.iinfo(np.int64).max), start)
    return lo, np.maximum.reduceat(at, start)


def backed_spikes(q: np.ndarray, resid: np.ndarray, analysed: np.ndarray, parents=None, jump_deg: float = _D.jump_deg, ratio: float = SPIKE_RATIO,
                  min_deg: float = SPIKE_MIN_DEG, max_frames: int = SPIKE_MAX_FRAMES,
                  memo: dict | None = None) -> np.ndarray:
    """(F, J) bool: the break frames of spikes that leave the joint's path far past its own residuals elsewhere.

    A break event (midpoint residuals over ``jump_deg``, grouped as :func:`~mocapkit.cleaning.ssa.cues.event_bounds`
    does, less those the joint's chain undoes with ``parents``), inside the take, is such a spike when it is off the
    path for at most ``max_frames`` frames, its frames lie at least ``min_deg`` off the slerp between the frames
    beside it (:func:`~mocapkit.cleaning.ssa.cues.off_path`) and that is twice the turn between those two frames or
    more (a return to the path), at least ``ratio`` times the joint's largest residual outside it (a midpoint
    residual is how far one frame leaves the path through its two neighbours). A k-frame spike of s degrees leaves residuals of s / 2 around it, so at 30 fps a 60 deg
    2-frame spike on a toe whose roll reaches 14 deg residuals stays under :func:`~mocapkit.cleaning.ssa.cues.own_breaks`'
    level (three times the 95th percentile, 30 deg) while it leaves the path by four times what the toe ever does.
    Such a break confirms only a digression (the MDM over the threshold beside it, as every break does).
    ``q`` (F, J, 4) rotations, ``resid`` (F, J) radians, ``analysed`` (J,) bool;
    ``memo``: :func:`~mocapkit.cleaning.ssa.cues.uncompensated_breaks`' events already judged on ``q``.
    """
    F, J = resid.shape
    out = np.zeros((F, J), dtype=bool)
    breaks = _breaks(q, resid, analysed, parents, jump_deg, memo)
    for j in np.flatnonzero(breaks.any(axis=0)):
        first, last = _cores(resid[:, j], *event_bounds(np.flatnonzero(breaks[:, j]))[:2])
        inside = (first >= 1) & (last <= F - 2)
        first, last = first[inside], last[inside]
        if not len(first):
            continue
        off, turn = off_path(q[:, j], first, last)
        short = np.where(last - first >= 2, last - first - 1, last - first + 1) <= max_frames
        for i in np.flatnonzero(short & (off >= np.radians(min_deg)) & (off >= 2.0 * turn)):
            a, b = first[i], last[i]
            own = np.array(resid[:, j])
            own[max(a - 2, 0) : b + 3] = 0.0
            if off[i] >= ratio * own.max():
                out[a : b + 1, j] = True
    return out


def backed_offsets(q: np.ndarray, resid: np.ndarray, digression: np.ndarray, analysed: np.ndarray, fps: float,
                   parents=None, jump_deg: float = _D.jump_deg, min_offset_deg: float = _D.offset_min_deg,
                   max_s: float = OFFSET_MAX_S, memo: dict | None = None) -> np.ndarray:
    """(F, J) bool: the break frames of two break events of a joint around a stretch that alone digresses from the
    neighbour words, by twice ``min_offset_deg`` or more.

    Break events as :func:`backed_spikes` takes them. Event ``k`` pairs with the nearest later event ``m`` starting at
    most ``max_s`` seconds after it where the frames between (from the frame after ``k``'s first to ``m``'s first)
    digress, as a median, by at least ``2 * min_offset_deg`` and twice what as many frames on either side do
    (:func:`~mocapkit.cleaning.ssa.cues.stands_out`), at least half of them judged. A held offset is the take's
    alone: the neighbour words are off it by about the offset from its first step to its last, and on it again
    beside; a toe that bends at push-off and back at landing is bent so in every stride, and the neighbour words
    bend it too. (The steps of a toe's own roll at 30 fps are as large as an offset's and join its steps into one
    event, so whether the second step undoes the first, :func:`~mocapkit.cleaning.ssa.cues.offsets_from_residuals`'
    test, says nothing here.) The stretch must also stand out of the joint's digression over the whole take: its
    median at least twice the joint's digression elsewhere at its :data:`TAKE_PERCENTILE` (90th) percentile (all but
    the stretch and two frames either side; :func:`_over_the_take`). Where the neighbour words judge a joint loosely all
    through the take, a stretch that digresses twice as far as the frames beside it is still the joint's own motion:
    on the untouched Bandai Namco ``dataset-1_byebye_angry_001`` (55 frames) the right forearm's first wave stops
    with residuals of 10 and 18 deg at frames 4-5, and frames 5-12 digress by 22 deg (median) where the frames
    beside them digress by 7 and the forearm's 90th percentile elsewhere is 15: paired with the next wave's breaks
    (frames 12-21), frames 5-10 of a clean swing were turned 26-50 deg. A pair that fails it is dropped, and neither
    event pairs with another (the test only ever takes pairs away). What it costs: an error on a joint the
    neighbour words judge loosely all through the take confirms nothing by this rule; on 28 Bandai Namco takes
    (every 97th, 5 errors of ``corrupt.real_errors`` each, 2 seeds) one of 112 swap records, a 20 deg swap of a
    turning walk's foot whose digression elsewhere reaches 10.5 deg at its 90th percentile (304 -> 303 of 336
    records found). ``digression`` (F, J) radians, NaN where not judged; ``fps`` the take's rate.
    """
    F, J = resid.shape
    out = np.zeros((F, J), dtype=bool)
    breaks = _breaks(q, resid, analysed, parents, jump_deg, memo)
    longest = int(round(max_s * fps))
    low = 2.0 * np.radians(min_offset_deg)
    for j in np.flatnonzero(breaks.any(axis=0)):
        first, last, _ = event_bounds(np.flatnonzero(breaks[:, j]))
        k = 0
        while k < len(first) - 1:
            for m in range(k + 1, len(first)):
                if first[m] - first[k] > longest:
                    break
                a, b = first[k] + 1, first[m] + 1
                d = digression[a:b, j]
                d = d[np.isfinite(d)]
                if 2 * len(d) >= b - a and np.median(d) >= low and stands_out(digression[:, j], a, b):
                    if _over_the_take(digression[:, j], a, b, np.median(d)):  # else no offset, and neither
                        out[first[k] : last[k] + 1, j] = True  # event pairs with another
                        out[first[m] : last[m] + 1, j] = True
                    k = m
                    break
            k += 1
    return out


#: :func:`backed_offsets`: the percentile of a joint's digression over the rest of the take that a backed offset's
#: stretch must digress twice as far as (its median)
TAKE_PERCENTILE = 90.0


def _over_the_take(digression: np.ndarray, a: int, b: int, inside: float) -> bool:
    """Whether a stretch's median digression ``inside`` (radians) of frames ``a .. b - 1`` is at least twice the
    :data:`TAKE_PERCENTILE` of the joint's ``digression`` (F,) radians (NaN: not judged) over the rest of the take (all
    of it but the stretch and two frames either side; True where none of it is judged)."""
    rest = np.delete(digression, np.arange(max(a - 2, 0), min(b + 2, len(digression))))
    rest = rest[np.isfinite(rest)]
    return not len(rest) or inside >= 2.0 * np.percentile(rest, TAKE_PERCENTILE)


def backed_breaks(q: np.ndarray, resid: np.ndarray, digression: np.ndarray, analysed: np.ndarray, fps: float, parents=None, jump_deg: float = _D.jump_deg,
                  min_offset_deg: float = _D.offset_min_deg, memo: dict | None = None, offsets: bool = True) -> np.ndarray:
    """(F, J) bool: :func:`backed_spikes` or :func:`backed_offsets`, the break frames to add to a take's ``jumps``;
    ``offsets=False`` leaves the backed offsets out (under the analysis rate:
    :func:`~mocapkit.cleaning.ssa.coarse_cues.backs_offsets`)."""
    spikes = backed_spikes(q, resid, analysed, parents, jump_deg, memo=memo)
    if not offsets:
        return spikes
    return spikes | backed_offsets(q, resid, digression, analysed, fps, parents, jump_deg, min_offset_deg, memo=memo)
