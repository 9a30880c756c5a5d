"""The break and hold cues under the 24 fps analysis rate (mocapkit.cleaning.ssa.coarse_cues), on real takes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit.cleaning.pipeline import clean
from mocapkit.cleaning.whole_take import detect_take, take_params


@pytest.fixture(scope="module")
def throw(shared_data):
    """CMU 131_02, a clean 120 fps take (a throw; its toes flick, its arm swings)."""
    return mocapkit.load(shared_data / "cmu_bvh" / "131_02.bvh")


@pytest.mark.parametrize("step", [8, 10])
def test_a_clean_take_cut_to_15_or_12_fps_comes_back_bit_identical(throw, step):
    """Every 8th (15 fps) or 10th (12 fps) real frame of 131_02: its toes' flicks (38-63 deg between two frames
    at 15 fps) were backed offsets, 19 toe cells repaired by up to 48 deg; at 12 fps a toe and an elbow that
    turned out and back between two frames were held, 4 cells repaired. Its right thumb's 180-degree turn-overs
    (mocapkit.cleaning.ssa.flips), defects of the file at any rate, are the only cells flagged or changed."""
    from mocapkit.cleaning.ssa.cues import CAUSES

    take = throw[::step]
    out = clean(take)
    flip = 1 << [name for name, _ in CAUSES].index("flip")
    turned = (np.asarray(out.causes).astype(np.int64) & flip) != 0
    thumbs = [j for j, n in enumerate(take.skeleton.joint_names) if "Thumb" in n]
    assert not (out.flags & ~turned).any()
    assert not np.delete(turned, thumbs, axis=1).any()
    keep = ~turned
    np.testing.assert_array_equal(out.motion.rotations[keep], take.rotations[keep])
    np.testing.assert_array_equal(out.motion.root_positions, take.root_positions)


def test_a_frozen_joint_at_15_fps_is_still_flagged(throw):
    """A knee frozen for 0.6 s (9 frames) at 15 fps, where it turns 3-17 deg a frame, is a hold of many still
    steps: still found there."""
    take = throw[::8]
    j = take.skeleton.index("LeftKnee")
    q = np.array(take.rotations)
    q[100:109, j] = q[99, j]
    det = detect_take(dataclasses.replace(take, rotations=q), params=take_params()).detection
    assert det.holds[100:109, j].any()
    assert det.flags[100:109, j].any()


def test_the_rate_under_which_the_cues_change():
    from mocapkit.cleaning.ssa import coarse_cues

    assert coarse_cues.hold_min_frames(12.0, 24.0) == coarse_cues.COARSE_HOLD_FRAMES == 3
    assert coarse_cues.hold_min_frames(23.976, 24.0) == 2  # NTSC film counts as 24 fps
    assert coarse_cues.hold_min_frames(30.0, 24.0) == 2
    assert not coarse_cues.backs_offsets(15.0, 24.0)
    assert coarse_cues.backs_offsets(24.0, 24.0) and coarse_cues.backs_offsets(120.0, 24.0)
