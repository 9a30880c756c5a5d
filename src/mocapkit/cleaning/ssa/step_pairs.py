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

Where the movement digression is at hand, a loose pair also needs the stretch
between to stand out from the frames beside it, as a pair with events between
does (:func:`~mocapkit.cleaning.ssa.cues.stands_out`: an error's offset is the
take's alone, Aristidou et al. 2018, sec. 3.4); two steps that merely point
opposite ways are weaker evidence than a step and its inverse. In the same
backflip the right hand's 69 deg step at frame 134 ends a fast 6-frame swing and
a 6-frame spin burst (146-162 deg a frame, frames 160-165) 25 frames later points
roughly back; the smooth frames between hold the hand where it is before the
flip and after the burst, digress no more than the flip beside them, and were
turned 40-72 deg.
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R

#: a step back *undoes* a step off when the two, composed, leave a turn under this share of the larger one, in the
#: parent's frame or in the joint's own (a constant offset leaves none in one of them)
UNDO_RATIO = 0.25
#: a step back *returns* the joint when it turns at least this share of the step off
RETURN_RATIO = 0.5


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
