"""Whether a joint's step back ends a transient offset: the tests that pair two steps into one.

:func:`~mocapkit.cleaning.ssa.cues.transient_offsets` pairs a step off a joint's
path with a later step back. A step back *undoes* the step off when the two
compose to nearly nothing (:data:`UNDO_RATIO`, :func:`steps_back`); a looser
pair, two steps pointing roughly opposite ways, stands for an offset the joint's
own motion bends while it is off (a drift that grows and snaps back returns by
more than it left). Either way the step back must *return* the joint
(:func:`returns`): a twitch a quarter the size of the step off leaves the joint
about as far off after it as between the two, so the stretch between them is no
offset that ended. In the CMU backflip the left hand's 42 deg step (a solver's
hand spinning 110-155 deg a frame on frames 127-131) was paired with an 11 deg
one-frame twitch at frame 160, and the 25 frames of real hand motion between
were turned 67-78 deg while the spin stayed. Steps are rotation vectors (3,) in
radians, as the cues measure them.

A loose pair's two events must also be *steps* (:func:`is_step`): a jump
between two frames breaks the midpoint residuals of the two frames beside it,
so its event spans at most :data:`MAX_STEP_FRAMES` frames. A longer event is a
burst (a solver's joint spinning for several frames), and the constant-velocity
paths beside it measure where the burst's recovery is heading, not a step back.
In the same backflip the right hand's 69 deg step at frame 134 (one frame,
ending a fast swing) was paired with the 6-frame spin burst of frames 159-164
(146-162 deg a frame), 113 deg roughly back: the 25 smooth frames between, which
hold the hand where it is before the flip and after frame 172, were turned
40-72 deg while the burst stayed.
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R

#: a step back *undoes* a step off when the two, composed, leave a turn under this share of the larger one, in the
#: parent's frame or in the joint's own (a constant offset leaves none in one of them)
UNDO_RATIO = 0.25
#: a step back *returns* the joint when it turns at least this share of the step off
RETURN_RATIO = 0.5
#: the most frames a step's event spans (a jump between frames f and f + 1 breaks the residuals at both; one frame
#: of slack where a neighbouring frame breaks too)
MAX_STEP_FRAMES = 3


def undo_left(a: np.ndarray, b: np.ndarray) -> float:
    """Radians: the turn left by rotation vector ``b`` (3,) after ``a`` (3,) (0 where ``b`` undoes ``a``)."""
    return float(R.geodesic_angle(R.rotvec_to_quaternion(a), R.rotvec_to_quaternion(-np.asarray(b))))


def steps_back(frames: tuple, k: int, m: int, ratio: float) -> bool:
    """Whether step ``m`` takes step ``k`` back, composed with it leaving under ``ratio`` times the larger of the two.

    ``frames``: the events' steps (n, 3) in one or more frames (the parent's, the joint's own); one that holds is
    enough (a constant offset composes to nothing in one of them).
    """
    return any(undo_left(v[k], v[m]) <= ratio * max(np.linalg.norm(v[k]), np.linalg.norm(v[m])) for v in frames)


def returns(off: np.ndarray, back: np.ndarray, ratio: float = RETURN_RATIO) -> bool:
    """Whether the step ``back`` (3,) turns at least ``ratio`` times as far as the step ``off`` (3,)."""
    return bool(np.linalg.norm(back) >= ratio * np.linalg.norm(off))


def is_step(span: int, most: int = MAX_STEP_FRAMES) -> bool:
    """Whether a break event of ``span`` frames (its last frame less its first, plus one) is a step, a jump between
    two frames (at most ``most`` frames), rather than a burst of several frames (:data:`MAX_STEP_FRAMES`)."""
    return 0 < int(span) <= int(most)


def offset_step_breaks(breaks: np.ndarray, offsets: np.ndarray, gap: int = 3) -> np.ndarray:
    """(F, J) bool: the cells of ``breaks`` whose break event is a step of a flagged transient offset.

    A transient offset flagged on frames ``s .. e - 1`` (a run of ``offsets``) starts with a step
    between frames ``s - 1`` and ``s`` and ends with one between ``e - 1`` and ``e``; each shows as a
    break at both its frames. The offset rule explains those two breaks and flags exactly the frames
    between them, and the repair takes the offset away there
    (:func:`~mocapkit.cleaning.ssa.undo.undone_offsets`). The digression just outside them comes from the
    neighbour words the error led astray (a word spans 0.6 s), so these breaks must not confirm it
    (:func:`~mocapkit.cleaning.ssa.cues.flag_causes` passes the offsets that are no side swap: a swap's cells are
    replaced by neighbour words, not undone, and keep the break rule's flags as before): on HDM05 ``tr_throwBasketball_014`` the right hand
    flips by 180 deg on frames 201-245, and the breaks of its two steps confirmed the digression of
    frames 198-200 and 246-252, real motion that was replaced by neighbour words and joined the take 9-12
    deg off. An event is a run of break frames at most ``gap`` frames apart (as the cues group them);
    it is a step of the offset when it holds ``s - 1``, ``s``, ``e - 1`` or ``e``. ``breaks``,
    ``offsets``: (F, J) bool.
    """
    breaks = np.asarray(breaks, dtype=bool)
    offsets = np.asarray(offsets, dtype=bool)
    if breaks.shape != offsets.shape or breaks.ndim != 2:
        raise ValueError(f"breaks and offsets must be the same (F, J) shape, got {breaks.shape} and {offsets.shape}")
    out = np.zeros_like(breaks)
    for j in np.flatnonzero(offsets.any(axis=0) & breaks.any(axis=0)):
        edge = np.diff(offsets[:, j].astype(np.int8), prepend=0, append=0)
        s, e = np.flatnonzero(edge == 1), np.flatnonzero(edge == -1)  # each run's first frame and the frame after it
        ends = np.concatenate([s - 1, s, e - 1, e])
        frames = np.flatnonzero(breaks[:, j])
        event = np.concatenate([[0], np.cumsum(np.diff(frames) > gap)])  # the event of each break frame
        at_step = np.zeros(event[-1] + 1, dtype=bool)
        at_step[event[np.isin(frames, ends)]] = True
        out[frames[at_step[event]], j] = True
    return out
