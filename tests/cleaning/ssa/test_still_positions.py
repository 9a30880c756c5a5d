import dataclasses

import numpy as np

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning.ssa.cues import CAUSES, midpoint_residuals, residual_breaks
from mocapkit.cleaning.ssa.still_positions import position_kept_breaks
from tests.cleaning.ssa.helpers import turned


def _turned_over(walk, frames):
    """``walk`` with the left thigh turned 180 deg about its bone on ``frames`` and the shank turned back by as much:
    every joint where it was, the rotations of both breaking."""
    sk = walk.skeleton
    hip, knee = sk.index("LeftHip"), sk.index("LeftKnee")
    axis = sk.offsets[knee] / np.linalg.norm(sk.offsets[knee])
    flip = R.quaternion_from_axis_angle(axis, np.array(np.pi))
    rot = np.array(walk.rotations)
    rot[frames, hip] = R.quaternion_multiply(rot[frames, hip], flip)
    rot[frames, knee] = R.quaternion_multiply(R.quaternion_inverse(flip), rot[frames, knee])
    return dataclasses.replace(walk, rotations=rot), hip, knee


def _kept(m):
    resid = midpoint_residuals(m.rotations)
    breaks = residual_breaks(resid, 8.0)
    return breaks, position_kept_breaks(m.global_positions(), m.skeleton.parents, breaks, resid)


def test_a_chain_turned_over_in_place_confirms_nothing_an_error_in_it_still_does(walk):
    over, hip, knee = _turned_over(walk, np.arange(300, walk.num_frames))
    assert np.allclose(over.global_positions(), walk.global_positions(), atol=1e-6)
    breaks, kept = _kept(over)
    assert breaks[299:301, hip].all() and breaks[299:301, knee].all()
    assert not kept[290:310, hip].any() and not kept[290:310, knee].any()
    assert np.array_equal(kept[:, :hip], breaks[:, :hip])  # the walk's own breaks elsewhere stay
    # the thigh turned alone (nothing in its chain turns with it): judged as before
    alone, _ = turned(walk, "LeftHip", np.arange(300, walk.num_frames), 40.0)
    breaks, kept = _kept(alone)
    assert breaks[299:301, hip].all() and np.array_equal(kept, breaks)
    # thigh and shank stepping at once, the foot off its path: an error of the chain, judged as before
    both, _ = turned(alone, "LeftKnee", np.arange(300, walk.num_frames), 40.0)
    breaks, kept = _kept(both)
    assert breaks[299:301, knee].all() and np.array_equal(kept, breaks)


def test_the_squat_whose_legs_turn_over_in_place_is_not_blended_from_words(shared_data):
    """HDM05 dg_squat1Reps_026: both femurs turn 180 deg about themselves at frames 80-81 and back at 100-101, every
    joint staying on its path. No motion-word repair blends them (it swung the feet 22 cm): the hips, knees and
    ankles stay where they were, the legs turned back exactly or left (:mod:`mocapkit.cleaning.ssa.flips`)."""
    m = mocapkit.load(shared_data / "hdm05_asfamc" / "HDM_dg_squat1Reps_026_120.amc")
    res = mocapkit.clean(m)
    legs = [m.skeleton.index(n) for n in ("lfemur", "rfemur", "ltibia", "rtibia", "lfoot", "rfoot")]
    assert np.allclose(res.motion.global_positions()[:, legs], m.global_positions()[:, legs], atol=1e-9)
    thighs_shanks = legs[:4]
    flip = 1 << [name for name, _ in CAUSES].index("flip")
    assert (res.causes[:, thighs_shanks][res.changed[:, thighs_shanks]] & flip).all()  # no other repair
