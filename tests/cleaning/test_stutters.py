"""Repeated frames (mocapkit.cleaning.stutters): named by clean, left as they are."""

from __future__ import annotations

import numpy as np

import mocapkit
from mocapkit import samples
from mocapkit.cleaning.pipeline import CleanResult, clean
from mocapkit.cleaning.stutters import Stutter, find_stutters
from mocapkit.motion import concatenate


def _repeat(m, at: int, n: int):
    """``m`` with frame ``at`` written ``n`` more times after itself (a capture stutter)."""
    return concatenate([m[:at + 1]] + [m[at:at + 1]] * n + [m[at + 1:]], name=m.name)


def test_untouched_takes_have_none():
    for name in ("131_01.bvh", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", "12_walk.amc"):
        assert find_stutters(mocapkit.load(samples.path(name))) == (), name


def test_repeated_frames_are_named_and_kept(tmp_path):
    m = mocapkit.load(samples.path("131_01.bvh"))
    bad = _repeat(_repeat(m, 504, 1), 700, 5)  # frame 505 repeats 504; 701-705 repeat 700
    assert find_stutters(bad) == (Stutter(505, 505), Stutter(701, 705))
    res = clean(bad, steps="fill,detect")
    lines = res.summary()
    assert ("frame 505 repeats frame 504 bit for bit while the take moves (a capture stutter), left as it is: "
            "clean keeps the take's frames and timing") in lines
    assert any(line.startswith("frames 701-705 repeat frame 700 bit for bit") for line in lines)
    assert res.motion.num_frames == bad.num_frames and not res.changed.any()
    back = CleanResult.load(res.save(tmp_path / "r.clean.npz"))
    assert back.stutters == res.stutters


def test_a_pose_held_at_the_ends_is_no_stutter():
    m = mocapkit.load(samples.path("12_walk.amc"))
    held = concatenate([m[:1]] * 10 + [m[1:-1]] + [m[-1:]] * 10, name=m.name)
    assert find_stutters(held) == ()
    still = concatenate([m[:1]] * 40, name=m.name)  # a take that never moves
    assert find_stutters(still) == ()
    assert np.array_equal(still.rotations[0], m.rotations[0])
