"""Transient offsets undone: the offset a joint stepped off its path by, measured at both steps and taken away.

A transient offset (:func:`~mocapkit.cleaning.ssa.cues.transient_offsets`) is a joint that steps off its own
path and later steps back: a solver flipping a limb's twist, a marker cluster slipping and found again, a
channel shifted for a stretch. Between the two steps the joint still makes its own motion, carried by the
wrong offset. Replacing those frames by a neighbour word (Aristidou et al. 2018, section 4) throws that
motion away and puts in the medoid of similar motion, a few degrees off the truth on every frame. Taking the
offset away keeps the joint's own motion: the offset is measured where the joint steps off (from the path
the frames before were on to the path the frames after are on) and where it steps back, each both as a turn
in the parent's frame (the error turns the joint's whole rotation, as an offset on the first Euler channel
does) and as a turn in the joint's own frame (a flip about the bone, an offset on the last channel); the
frame in which the two ends agree better is taken, the offset interpolated between them (a constant offset
is taken away exactly, a drift that grows linearly about one axis too) and removed. Used by
:func:`~mocapkit.cleaning.ssa.repair`; a repair of this library, not of the paper.
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R
from ..ik import contact_segments, segment_frames

__all__ = ["offset_ends", "undone_offsets"]


def _path_at(q_a: np.ndarray, q_b: np.ndarray, dt: float) -> np.ndarray:
    """(n, 4): the constant-velocity path through rotations ``q_a`` then ``q_b`` (n, 4), one frame apart, taken
    ``dt`` frames past ``q_b`` (the velocity in the parent's frame, as the transient offsets' steps are measured)."""
    q_a = np.where((np.sum(q_a * q_b, axis=-1) < 0)[..., None], -q_a, q_a)
    v = R.quaternion_to_rotvec(R.quaternion_multiply(q_b, R.quaternion_inverse(q_a)))
    return R.quaternion_multiply(R.rotvec_to_quaternion(dt * v), q_b)


def offset_ends(q: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The offset of each run ``starts[i] .. ends[i] - 1`` of a joint's track ``q`` (F, 4) at its two ends.

    Returns ``(left, right)``, each (n, 2, 4): the offset of the wrong rotation from the good one at the
    step off (half a frame before the run's first frame) and at the step back (half a frame after its
    last), ``left`` as ``wrong = offset * good`` (parent's frame) and ``right`` as ``wrong = good * offset``
    (the joint's own frame). Each side's path is the constant-velocity line through its two frames nearest
    the step (``q[s - 2], q[s - 1]`` and ``q[s], q[s + 1]`` at the step off), taken at the step's middle, so
    the joint's own motion across the step cancels to first order. Runs need two frames and two frames
    beside them on each side (``2 <= s``, ``s + 2 <= e``, ``e + 2 <= F``).
    """
    s, e = np.asarray(starts, dtype=np.int64), np.asarray(ends, dtype=np.int64)
    good_before = _path_at(q[s - 2], q[s - 1], 0.5)  # the good path, carried to the step off
    wrong_after = _path_at(q[s + 1], q[s], 0.5)  # the wrong path, carried back to it
    wrong_before = _path_at(q[e - 2], q[e - 1], 0.5)  # the wrong path, carried to the step back
    good_after = _path_at(q[e + 1], q[e], 0.5)
    inv = R.quaternion_inverse
    left = np.stack([R.quaternion_multiply(wrong_after, inv(good_before)),
                     R.quaternion_multiply(wrong_before, inv(good_after))], axis=1)
    right = np.stack([R.quaternion_multiply(inv(good_before), wrong_after),
                      R.quaternion_multiply(inv(good_after), wrong_before)], axis=1)
    return left, right


def undone_offsets(q: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(track, undone)``: a joint's track ``q`` (F, 4) with the offset of each run of ``mask`` (F,) taken away.

    Each run's offset is measured at both its ends (:func:`offset_ends`), in the parent's frame and in the
    joint's own; the frame whose two ends lie closer together (geodesic angle) is taken, the offset slerped
    from the step off to the step back across the run and removed from every frame of it. ``undone`` (F,)
    bool: the frames changed, those of the runs with room to measure both ends (:func:`offset_ends`); the
    rest of ``track`` is ``q`` bit for bit.
    """
    q = np.asarray(q, dtype=np.float64)
    F = len(q)
    track = np.array(q)
    undone = np.zeros(F, dtype=bool)
    runs = np.array(contact_segments(np.asarray(mask, dtype=bool)), dtype=np.int64).reshape(-1, 2)
    runs = runs[(runs[:, 0] >= 2) & (runs[:, 1] - runs[:, 0] >= 2) & (runs[:, 1] + 2 <= F)]
    if not len(runs):
        return track, undone
    s, e = runs[:, 0], runs[:, 1]
    left, right = offset_ends(q, s, e)
    use_left = R.geodesic_angle(left[:, 0], left[:, 1]) <= R.geodesic_angle(right[:, 0], right[:, 1])
    ends = np.where(use_left[:, None, None], left, right)
    on = ends[:, 0]
    back = np.where((np.sum(on * ends[:, 1], axis=-1) < 0)[:, None], -ends[:, 1], ends[:, 1])
    idx, run_of, _ = segment_frames(s, e - s)
    u = (idx - s[run_of] + 0.5) / (e - s)[run_of]
    offset_inv = R.quaternion_inverse(R.slerp(on[run_of], back[run_of], u))
    lefty = use_left[run_of]
    fixed = np.where(lefty[:, None], R.quaternion_multiply(offset_inv, q[idx]), R.quaternion_multiply(q[idx], offset_inv))
    fixed = R.quaternion_normalize(fixed)
    track[idx] = np.where((np.sum(fixed * q[idx], axis=-1) < 0)[:, None], -fixed, fixed)
    undone[idx] = True
    return track, undone
