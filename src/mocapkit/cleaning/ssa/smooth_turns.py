"""Fast smooth turns: breaks of a joint's track that its own motion makes, not an error.

The confirmation (:func:`~mocapkit.cleaning.ssa.cues.own_breaks`) reads a midpoint residual over ``jump_deg`` (8 deg)
as a break: at 120 fps smooth motion stays far under it (:func:`~mocapkit.cleaning.ssa.cues.discontinuities`). A hand
flicked at the end of an arm's swing does not: CMU 131_01's right wrist turns 10, 22, 40, 55, 34 and 12 deg in
successive frames around frame 236 (midpoint residuals 6-20 deg over six frames), and again at frame 808; 131_02 and
131_03 make the same flick about the same axis, by the same 80-110 deg and with the same overshoot, at the moment
the arm stops (slower there: 20-40 deg a frame). The break confirmed the digression beside it and the flick was
flagged as an error. Its shape tells it from one: the joint speeds up and slows down over several frames and never
turns back. An error (:func:`mocapkit.corrupt.real_errors`: spikes, flips, freezes, drifts and swaps; a capture's
spike or a gap filled by a straight line) steps off the joint's path at once:

* it turns back (a spike, a swap and its undoing, a flip), so two successive steps point more than 90 deg apart;
* or it leaves and rejoins the joint's own pace at once: neither the frame before its first break nor the one after
  its last accelerates by half the break level, where a real turn builds its speed up or lets it die down over the
  frames around its breaks (a gap a capture filled by a straight line turns at a steady speed and breaks at its two
  corners only: HDM05 mm grabHighR 018's right arm, 32 deg a frame);
* or one step is more than :data:`SPEED_RATIO` times the step beside it (a step out of a slow or held track);
* or a joint up its chain breaks meanwhile, and moves it: a capture's turn-over of a thigh, which its foot follows
  around in smooth frames (:func:`smooth_turn_breaks`).

A break event (:func:`~mocapkit.cleaning.ssa.events.event_bounds`) that does none of these, over its own steps and the
two beside it, is a smooth turn and confirms nothing (:func:`smooth_turn_breaks`). Measured on the 224 break events
of 69 clean takes (10 CMU; 59 HDM05, every fourth by name of actors bd, bk, dg and mm) and the 1,372 events of the
errors :func:`mocapkit.corrupt.real_errors` injects in them (three seeds, four errors each): no injected error's
event is a smooth turn (the least speed ratio among them 4.9); eight clean events are (131_01's two wrist flicks
and 131_03's, a turn of 131_03's right thumb, the pirouette's right foot, three of the backflip's thigh and arm
swings). What it costs: an error smaller than the steps of a turn this fast, where it happens, confirms nothing (a
30 deg spike at the peak of a turn of 40-55 deg a frame; one of 60 deg turns the path back and still breaks). A
cue of this library, not of the paper (Aristidou et al. 2018 flag ``MDM > threshold``, section 3.4).

At low frame rates the same flick is sampled too coarsely for that shape: the frame time is a large share of the
turn, so its overshoot and return fall between two frames and the steps point every way. CMU 131_01 at 30 fps (every
4th frame, as ``benchmarks/clean_untouched.py``'s ``cmu_bvh_30fps``) turns the right wrist 75, 87 and 54 deg in
three successive frames (frames 58-61, steps 150 deg apart, midpoint residuals up to 69 deg: a turn back by the
first test, and a speed ratio of 14 as it stops), 131_03 at 30 fps 87, 74 and 115 deg (frames 62-65, 112 deg
apart); at 120 fps both are the smooth flicks above. The break confirmed the digression beside it and the flick was
repaired (131_03's wrist moved by up to 163 deg). An error at that rate still steps off the joint's path at once: a
spike's step out and back, a flip's, drift's, freeze's or swap's step on or off, is one or two fast steps between
steps at the joint's own pace (a freeze's held frames do not move at all). A fast turn keeps moving:
:data:`COARSE_RUN` successive steps or more, each at least :data:`COARSE_SHARE` of the event's largest midpoint
residual (:func:`coarse_turn`), asked of the events past what limb motion can make at the take's rate (33 deg at 30
fps), which no speed beside them explains (:func:`~mocapkit.cleaning.ssa.cues.motion_explained`); a smaller one (a
swap's 10 deg end step on an arm moving 10 deg a frame) is that rule's. Where no limb motion can break (the
:data:`~mocapkit.cleaning.ssa.cues.MAX_ACCEL_DEG_S2` cap under the break level: over about 60 fps) the test is not
made, so nothing changes at 120 fps. Measured at 30 fps (every 4th frame) on 45 clean takes (every 20th HDM05 clip,
the CMU ASF/AMC and BVH takes, every 150th Bandai Namco take) and the 810 errors of
:func:`mocapkit.corrupt.real_errors` that break there (three seeds, six errors each): every error keeps a break
(one swap of a thumb keeps fewer cells); 14 break cells of the clean takes go. Through detect at 30 fps, every
HDM05 clip (280) and 446 Bandai Namco takes (two of every 12) keep every break; of the CMU takes, 131_01's and 131_03's
wrist flicks, one thumb step of 131_01 and one arm swing of the backflip go. What it costs, at 24-30 fps only: an
error on a joint already turning three quarters of the error's size a frame, right where it turns, confirms nothing
(a 60 deg spike on a wrist turning 45 deg a frame, a flip on one turning 68 deg a frame).

Under 30 fps that share falls with the rate (:func:`coarse_share`: 0.6 at 24 fps, 0.5 at 20). A turn's midpoint
residual is second order in the frame time and its steps first order (``|alpha| dt^2 / 2`` against ``|omega| dt``),
so where a frame is longer the same turn's residual grows more than the steps around it: CMU 131_03 at 24 fps
(every 5th frame, as ``mocapkit convert --fps 24`` delivers it) turns the right wrist 71, 94 and 125 deg in three
frames (49-52) around a residual of 108 deg, its arm's step into the flick 0.66 of it, where at 30 fps the same flick
turns 87, 74 and 115 deg around 84 deg. That holds while a frame is shorter than a fast turn (:data:`FAST_TURN_S`,
0.05 s: 20 fps); under that rate the turn falls within one frame, its residual grows no more while the joint's steps
beside it do, and the share rises again (0.67 at 15 fps). Measured at 24, 20 and 15 fps on 26 takes (the three 131
takes, the nine CMU ASF/AMC takes, every 20th HDM05 clip) and held out on 35 (14 other HDM05 clips, every 150th
Bandai Namco take, three secondary Bandai Namco clips), with the errors of :func:`mocapkit.corrupt.real_errors`
(three seeds, six errors each): none of the 2,769 break events of the errors at 24 and 20 fps becomes a coarse turn;
three clean events do (131_03's wrist flick at 24 fps, the backflip's right hand at 24 and left arm at 20), none of
the held-out takes'; at 15 fps the same events are coarse turns as with three quarters (a share falling on to 0.375
there would take the breaks of three errors, steps of 150-180 deg out and back beside the joint's 50-80). The rate also decides how much of a
flick its samples keep, and where it falls between two frames the flick is one or two steps of 100-125 deg beside
the joint's own pace (every 5th frame of 131_01 from its frame 3 or 4 and of 131_03 from its frame 4; every 6th of
131_01 from frame 4 or 5 and of 131_03 from frame 1 or 2): an error's step to this rule, which leaves it a break. At
15 fps and under the test is seldom asked: a residual must pass what limb motion makes at the rate
(``MAX_ACCEL_DEG_S2 / (2 fps^2)``: 133 deg at 15 fps, more than any turn at 12).
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R
from .cues import MAX_ACCEL_DEG_S2
from .events import event_bounds

__all__ = ["CHAIN_DEPTH", "COARSE_FPS", "COARSE_RUN", "COARSE_SHARE", "FAST_TURN_S", "SPEED_RATIO", "TURN_BACK_DEG",
           "coarse_share", "coarse_turn", "smooth_turn", "smooth_turn_breaks"]

#: the most one step of a smooth turn may be of the step beside it, either way (131_01's flick: 2.9, as its
#: 34 deg step slows to 12; every injected error's event over 4.8)
SPEED_RATIO = 4.0
#: two successive steps of a smooth turn point less than this far apart (a turn back points about 180 deg away)
TURN_BACK_DEG = 90.0
#: successive fast steps a coarsely sampled turn makes at least (an error's step: one; a spike out and back: two)
COARSE_RUN = 3
#: a fast step of a coarsely sampled turn at :data:`COARSE_FPS`: at least this share of the event's largest midpoint
#: residual (:func:`coarse_share` at other rates)
COARSE_SHARE = 0.75
#: the rate :data:`COARSE_SHARE` holds at (frames per second; under it the share falls in proportion to the rate)
COARSE_FPS = 30.0
#: how long a fast turn lasts, seconds: 131_01's wrist flick turns 10-55 deg a frame for 6 frames at 120 fps; at
#: rates under its inverse (20 fps) the whole turn falls within one frame (:func:`coarse_share`)
FAST_TURN_S = 0.05
#: how many joints up the chain :func:`smooth_turn_breaks` looks for a break that moves the joint
CHAIN_DEPTH = 3


def smooth_turn(q: np.ndarray, resid: np.ndarray, first: int, last: int, jump_deg: float) -> bool:
    """Whether the break event ``first .. last`` (frames) of one joint's track is a smooth turn (module docstring).

    ``q`` (F, 4) the joint's unit quaternions, ``resid`` (F,) its midpoint residuals in radians
    (:func:`~mocapkit.cleaning.ssa.cues.midpoint_residuals`), ``jump_deg`` the break level in degrees. The steps read
    are ``q[first - 2] -> q[first - 1]`` to ``q[last + 1] -> q[last + 2]``; an event too near the take's ends for
    them is no smooth turn (kept as a break).
    """
    F = len(q)
    if first < 2 or last + 2 >= F:
        return False
    if max(resid[first - 1], resid[last + 1]) < 0.5 * np.radians(jump_deg):
        return False  # the turn neither built up nor died down over the frames beside its breaks
    seg = np.asarray(q[first - 2 : last + 3], dtype=np.float64)
    if not np.isfinite(seg).all():
        return False
    v = R.quaternion_to_rotvec(R.quaternion_multiply(seg[1:], R.quaternion_inverse(seg[:-1])))  # steps, radians
    s = np.linalg.norm(v, axis=-1)
    if (s <= 0.0).any():
        return False  # a held frame: a freeze let go, not a turn
    if (np.maximum(s[1:] / s[:-1], s[:-1] / s[1:]) > SPEED_RATIO).any():
        return False
    cos = np.sum(v[1:] * v[:-1], axis=-1) / (s[1:] * s[:-1])
    return bool((cos > np.cos(np.radians(TURN_BACK_DEG))).all())


def coarse_share(fps: float) -> float:
    """The share of a break event's largest midpoint residual each step of a coarsely sampled turn reaches at ``fps``.

    :data:`COARSE_SHARE` at :data:`COARSE_FPS` and over; under it, that share times ``fps / COARSE_FPS`` down to
    ``1 / FAST_TURN_S`` (0.6 at 24 fps, 0.5 at 20), and under that 0.5 times ``20 / fps`` (0.67 at 15 fps). While a
    frame is shorter than a fast turn, the turn's midpoint residual is second order in the frame time and its steps
    first order (:func:`~mocapkit.cleaning.ssa.cues.discontinuities`: ``|alpha| dt^2 / 2`` against ``|omega| dt``):
    at a lower rate the residual grows by the square of the frame time's growth, the steps by the growth alone, and
    the share the steps reach of the residual falls in proportion to the rate. Once a frame spans the whole turn
    (:data:`FAST_TURN_S`), the turn is a step between two frames: its residual grows no more, while the joint's own
    steps beside it still grow with the frame time, and the share rises in proportion to the frame time.
    """
    rate = min(float(fps), COARSE_FPS)
    edge = 1.0 / FAST_TURN_S
    if rate >= edge:
        return COARSE_SHARE * rate / COARSE_FPS
    return COARSE_SHARE * (edge / COARSE_FPS) * (edge / rate)


def coarse_turn(q: np.ndarray, resid: np.ndarray, first: int, last: int, fps: float) -> bool:
    """Whether the break event ``first .. last`` (frames) of one joint's track is a fast turn sampled coarsely.

    ``q`` (F, 4) the joint's unit quaternions, ``resid`` (F,) its midpoint residuals in radians, ``fps`` the take's
    rate. The event's largest residual must pass what limb motion can make at that rate
    (:data:`~mocapkit.cleaning.ssa.cues.MAX_ACCEL_DEG_S2` ``/ (2 fps^2)``, 33 deg at 30 fps: the breaks no speed
    explains, :func:`~mocapkit.cleaning.ssa.cues.motion_explained`; those under it are that rule's and
    :mod:`~mocapkit.cleaning.ssa.recurring_peaks`'), and the steps read, ``q[first - 2] -> q[first - 1]`` to
    ``q[last + 1] -> q[last + 2]`` as :func:`smooth_turn` reads them, hold :data:`COARSE_RUN` successive ones or more
    that each turn at least :func:`coarse_share` of that residual at the take's rate, none held (module docstring).
    An event too near the take's ends for them is not one (kept as a break). Over about 60 fps no limb motion breaks
    at all: :func:`smooth_turn_breaks` asks it under that only.
    """
    F = len(q)
    if first < 2 or last + 2 >= F:
        return False
    peak = float(np.max(resid[first : last + 1]))
    if peak <= np.radians(MAX_ACCEL_DEG_S2 / (2.0 * float(fps) ** 2)):
        return False
    seg = np.asarray(q[first - 2 : last + 3], dtype=np.float64)
    if not np.isfinite(seg).all():
        return False
    s = R.geodesic_angle(seg[1:], seg[:-1])  # (last - first + 4,) radians
    if (s <= 0.0).any():
        return False  # a held frame: a freeze let go, not a turn
    fast = s >= coarse_share(fps) * peak
    run = longest = 0
    for f in fast:
        run = run + 1 if f else 0
        longest = max(longest, run)
    return longest >= COARSE_RUN


def smooth_turn_breaks(q: np.ndarray, resid: np.ndarray, breaks: np.ndarray, jump_deg: float,
                       parents=None, fps: float | None = None) -> np.ndarray:
    """``breaks`` (F, J) bool without the events that are smooth turns (:func:`smooth_turn`).

    ``q`` (F, J, 4) local rotations, ``resid`` (F, J) radians (:func:`~mocapkit.cleaning.ssa.cues.midpoint_residuals`),
    ``jump_deg`` the break level the breaks were found at (degrees). With ``parents`` (J,), an event during which a
    joint up the chain (:data:`CHAIN_DEPTH` levels at most) breaks too (its residual over ``jump_deg`` over the
    event's frames and the two beside them) is kept whatever its shape: the chain's break moves it (HDM05
    dg_squat1Reps_026's right foot turns 180 deg in 9 smooth frames around the frame its thigh turns back over in
    one, a turn-over of the capture's own: the toes swing 6-18 times their usual speed). Used for the breaks that
    confirm a digression (:func:`~mocapkit.cleaning.ssa.detect`'s ``jumps``); the frozen channels' own breaks are left
    as they are. With ``fps`` (the take's rate) under about 60 (where
    :data:`~mocapkit.cleaning.ssa.cues.MAX_ACCEL_DEG_S2` lets limb motion break), the events that are fast turns
    sampled coarsely (:func:`coarse_turn`) are left out too, unless a joint up the chain breaks by its own
    ``breaks`` meanwhile (at that rate a fast arm's own motion passes ``jump_deg`` as the wrist flicks at its end).
    """
    out = np.array(breaks, dtype=bool)
    F = len(out)
    level = np.radians(jump_deg)
    coarse = fps is not None and MAX_ACCEL_DEG_S2 / (2.0 * float(fps) ** 2) > jump_deg
    for j in np.flatnonzero(out.any(axis=0)):
        frames = np.flatnonzero(out[:, j])
        first, last, event = event_bounds(frames)
        ups = _ancestors(parents, int(j)) if parents is not None else []
        smooth = np.array([(smooth_turn(q[:, j], resid[:, j], int(a), int(b), jump_deg)
                            and not (resid[max(a - 2, 0) : min(b + 3, F)][:, ups] > level).any())
                           or (coarse and coarse_turn(q[:, j], resid[:, j], int(a), int(b), fps)
                               and not breaks[max(a - 2, 0) : min(b + 3, F)][:, ups].any())
                           for a, b in zip(first, last)], dtype=bool)
        out[frames[smooth[event]], j] = False
    return out


def _ancestors(parents, j: int) -> list[int]:
    """The joints up ``j``'s chain, nearest first, :data:`CHAIN_DEPTH` at most."""
    parents = np.asarray(parents)
    ups = []
    while len(ups) < CHAIN_DEPTH and parents[j] >= 0:
        j = int(parents[j])
        ups.append(j)
    return ups
