"""Whether a joint's step back returns it to its path: the test that pairs two steps into a transient offset.

:func:`~mocapkit.cleaning.ssa.cues.transient_offsets` pairs a step off a joint's
path with a later step back. A step back *undoes* the step off when the two
compose to nearly nothing (:data:`UNDO_RATIO`); a looser pair, two steps pointing
roughly opposite ways, stands for an offset the joint's own motion bends while it
is off. Both must *return* the joint: a second step that takes back a small part
of the first leaves the joint off its path after it as much as between the two,
so the stretch between them is no offset that ended. In the CMU backflip
(frames 127-160) the left hand's 42 deg step (a solver's hand spinning for six
frames) was paired with an 11 deg twitch 32 frames later, and 25 frames of real
hand motion were turned 67-78 deg while the spin stayed. Steps are rotation
vectors in radians (:func:`~mocapkit.cleaning.ssa.cues.transient_offsets`' event steps).
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R

#: a step back *undoes* a step off when the two, composed, leave a turn under this share of the larger one, in the
#: parent's frame or in the joint's own (a constant offset leaves none in one of them)
UNDO_RATIO = 0.25
#: a step back *returns* the joint when the two, composed, leave a turn under this share of the larger one (in one
#: frame or the other): it takes back at least half the offset
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
