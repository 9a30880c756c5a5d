"""Frames repeating the frame before (mocapkit.cleaning.ssa.repeats): analysed once, so detection stays local."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mocapkit
from mocapkit import corrupt, samples
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa.repeats import expand, frame_index, repeat_runs, without_repeats
from mocapkit.cleaning.whole_take import detect_take, repair_whole
from mocapkit.cleaning.inbetweens import midpoint_frames
from mocapkit.motion import concatenate
from tests.cleaning.ssa.helpers import with_midpoints


def _repeat(m, at: int, n: int = 1):
    """``m`` with frame ``at`` written ``n`` more times after itself (a stutter)."""
    return concatenate([m[:at + 1]] + [m[at:at + 1]] * n + [m[at + 1:]], name=m.name)


def test_frame_index_and_expand():
    runs = ((3, 4), (7, 7))
    assert frame_index(runs, 9).tolist() == [0, 1, 2, 2, 2, 3, 4, 4, 5]
    assert expand(np.arange(6) * 10, runs, 9).tolist() == [0, 10, 20, 20, 20, 30, 40, 40, 50]


def test_a_frame_written_twice_changes_no_flag_but_its_own(tmp_path):
    # one frame written twice shifted the 24 fps analysis grid of the rest of the take: on CMU 131_01 with four
    # errors, flags changed hundreds of frames away from it (4 to 18 cells more than two words away)
    m = mocapkit.load(samples.path("131_01.bvh"))[1:]
    bad, _, _ = corrupt.real_errors(m, seed=1)
    t = 496
    stutter = _repeat(bad, t)
    assert repeat_runs(stutter) == ((t + 1, t + 1),)
    d0 = detect_take(bad).detection
    d1 = detect_take(stutter).detection
    assert d0.flags.any()
    keep = np.r_[np.arange(t + 1), np.arange(t + 2, stutter.num_frames)]
    assert np.array_equal(d1.flags[keep], d0.flags)
    assert np.array_equal(d1.causes()[keep], d0.causes())
    assert np.array_equal(d1.flags[t + 1], d1.flags[t])  # the repeat holds what its frame holds
    r0 = repair_whole(bad, d0).motion
    r1 = repair_whole(stutter, d1).motion
    assert np.array_equal(r1.rotations[keep], r0.rotations)
    assert np.array_equal(r1.rotations[t + 1], r1.rotations[t])  # still a repeat
    back = ssa.Detection.load(d1.save(tmp_path / "d.npz"))
    assert back.repeats == d1.repeats
    assert np.array_equal(repair_whole(stutter, back).motion.rotations, r1.rotations)
    assert np.array_equal(back.with_threshold(0.4).flags[keep], d0.with_threshold(0.4).flags)


def test_a_take_without_repeats_is_analysed_as_before():
    m = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    assert repeat_runs(m) == () and without_repeats(m, ()) is m
    assert ssa.detect(m).repeats == ()


def test_interpolated_frames_change_no_flag_far_away(tmp_path):
    # three frames another tool interpolated into CMU 131_01 (slerp midpoints written at the file's four decimals)
    # shifted the analysis grid of the rest of the take: flags appeared more than 1.25 s (150 frames) away
    src = Path(samples.path("131_01.bvh"))
    after = [387, 460, 961]
    m = mocapkit.load(src)
    retimed = mocapkit.load(with_midpoints(src, after, tmp_path / "retimed.bvh", 4))
    inserted = np.array(after) + np.arange(1, len(after) + 1)
    kept = np.setdiff1d(np.arange(retimed.num_frames), inserted)
    assert np.array_equal(retimed.rotations[kept], m.rotations)
    d0 = detect_take(m).detection
    d1 = detect_take(retimed).detection
    far = np.min(np.abs(kept[:, None] - inserted[None]), axis=1) > 1.25 * m.fps
    new = d1.flags[kept] & ~d0.flags
    assert not new[far].any(), f"{int(new[far].sum())} new flags far from the inserted frames"
    assert np.array_equal(d1.flags[kept], d0.flags)  # the take without them is analysed as the take itself
    assert d1.inbetweens == tuple((int(t), int(t)) for t in inserted)
    r0 = repair_whole(m, d0).motion
    r1 = repair_whole(retimed, d1).motion
    assert np.array_equal(r1.rotations[kept], r0.rotations)
    untouched = ~(d1.flags[inserted - 1] | d1.flags[inserted + 1])  # (3, J): joints not flagged around an insert
    assert np.array_equal(r1.rotations[inserted][untouched], retimed.rotations[inserted][untouched])
    assert midpoint_frames(r1)[inserted].all()  # still interpolated frames
