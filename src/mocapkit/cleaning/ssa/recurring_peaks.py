"""Breaks a joint's own motion makes again elsewhere in the take: at low frame rates, motion, not an error.

The confirmation's breaks (:func:`~mocapkit.cleaning.ssa.cues.own_breaks`) stand out from what the joint's own
motion reaches (:func:`~mocapkit.cleaning.ssa.cues.own_level`: ten times its median midpoint residual or three
times its 95th percentile), a level capped at what the fastest limb motion can make at the take's rate,
``MAX_ACCEL_DEG_S2 / (2 fps^2)`` (33 deg at 30 fps), so that heavy noise on a joint does not hide an error's
breaks. Two kinds of real motion still break it at 30 fps. A joint whose motion is a rhythm of fast one-frame
peaks (a hand waving) reaches the cap with its motion, not its noise, and a peak that rises past it breaks
"whatever the speed": on the untouched Bandai Namco ``dataset-1_byebye_angry_001`` the left hand's wave peaks at
frames 30, 38, 42 and 46-47 (residuals 35.8, 30.6, 35.6 and 17-21 deg; its own level 95 deg), and the one at
frame 42, where the neighbour words happened to digress, was flagged and cut off the wave (``bye_angry_001``'s
right hand the same at frames 31 and 62). And a short take's percentile misses a motion made once a stride: a
dashing toe pushes off by 23-29 deg residuals at frames 2, 23, 44 and 65 of ``dash_masculinity_001`` (its level
22.5 deg), and the push-off at frame 2 was flagged.

:func:`recurring_breaks` leaves out such a break event: under what motion reaches at that rate (the joint's own
uncapped level or the cap, whichever is larger), while the joint's residual reaches :data:`RECUR_RATIO` of the
event's largest, and at most its inverse (80 to 125 %), at :data:`RECUR_TIMES` other places of the take or more
(frames outside the event and the two frames beside it, grouped into events as
:func:`~mocapkit.cleaning.ssa.events.event_bounds` does). At 30 fps a frame is a large share of a fast limb's
swing, so the same motion sampled at another phase leaves a residual some 20 % smaller or larger: the ratio, both
ways. An error is the take's once: it stands out of the joint's own peaks, two errors of one joint of the same
size hide each other only where a third place of the joint's motion makes that size too, and much larger breaks
elsewhere (another error's steps: a flip's 90 deg beside a drift's 19 deg end, on a corrupted Bandai Namco take)
are not the same motion. Breaks past what motion reaches are kept, and so is every break where the cap is under
the break threshold (``jump_deg``; over about 60 fps, where no limb motion breaks at all: nothing changes at 120
fps). The spikes the digression backs (:func:`~mocapkit.cleaning.ssa.backed.backed_spikes`, off the path three
times the joint's largest residual elsewhere) still confirm. What it costs: at 24-30 fps an error whose residual
lies within 80-125 % of the peaks the joint's own motion makes at two other places in the take confirms no
digression (Aristidou et al. 2018, section 3.4, flag the digression alone; this library asks for a break). On 28
Bandai Namco takes (every 97th, 5 errors of ``corrupt.real_errors`` each, 2 seeds) and 28 HDM05 clips at 30 fps,
no error record is lost (304 of 336 and 171 of 324 found, as before), and the Bandai Namco dance at 30 fps keeps
all 69 of its error word pairs (``benchmarks/ssa_detection.py``, ``dance_30fps``; its untouched take's flagged
cells 30 -> 23).
A cue of this library, not of the paper. All (F, J) arrays at the take's own frame rate.
"""

from __future__ import annotations

import numpy as np

from .cues import MAX_ACCEL_DEG_S2, own_level
from .events import event_bounds

__all__ = ["RECUR_RATIO", "RECUR_TIMES", "recurring_breaks"]

#: the share of a break event's largest residual the joint must reach elsewhere, and at most its inverse, to recur
RECUR_RATIO = 0.8
#: at how many other places of the take (each an event of its own) it must reach it
RECUR_TIMES = 2


def recurring_breaks(resid: np.ndarray, breaks: np.ndarray, fps: float, jump_deg: float, ratio: float = RECUR_RATIO,
                     times: int = RECUR_TIMES) -> np.ndarray:
    """``breaks`` (F, J) bool without the break events under what motion reaches at ``fps`` that the joint's own
    residuals reach, within ``ratio`` to ``1 / ratio`` of the event's largest, at ``times`` other places or more
    (module docstring);
    ``breaks`` unchanged where the cap is under ``jump_deg`` (degrees).

    ``resid`` (F, J) radians (:func:`~mocapkit.cleaning.ssa.cues.midpoint_residuals`), ``breaks`` the joint's own
    breaks (:func:`~mocapkit.cleaning.ssa.cues.own_breaks` with ``fps``), ``fps`` the take's rate.
    """
    out = np.array(breaks, dtype=bool)
    resid = np.asarray(resid, dtype=np.float64)
    F = len(resid)
    cap = np.radians(MAX_ACCEL_DEG_S2 / (2.0 * float(fps) ** 2))
    if F < 3 or not out.any() or cap <= np.radians(jump_deg):
        return out  # over about 60 fps no limb motion breaks at all
    reach = np.maximum(own_level(resid), cap)  # (J,) what the joint's motion, or any limb's at this rate, reaches
    for j in np.flatnonzero(out.any(axis=0)):
        first, last, _ = event_bounds(np.flatnonzero(out[:, j]))
        for a, b in zip(first, last):
            peak = resid[a : b + 1, j].max()
            if peak >= reach[j]:
                continue  # past what motion reaches: a break, recurring or not
            rest = np.array(resid[:, j])
            rest[max(a - 2, 0) : b + 3] = 0.0
            near = np.flatnonzero((rest >= ratio * peak) & (rest <= peak / ratio))  # the same motion's size
            if len(near) and len(event_bounds(near)[0]) >= times:
                out[a : b + 1, j] = False
    return out
