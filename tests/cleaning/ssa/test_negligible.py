"""Repairs too small to see given back (mocapkit.cleaning.ssa.negligible).

The real take is CMU 131_01 (bundled): its right elbow is held bit-still over frames 952-973 while the similar
motion moves, and the hold rule flags frames 961-965 (960, the last live sample the hold repeats, is not flagged); the
medoid neighbour word, blended to meet the take at both ends, moves them by hundredths of a degree at most: six changed cells and a lost bit-identity for nothing.
"""

from __future__ import annotations

import numpy as np

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning.ssa.negligible import NEGLIGIBLE_DEG, negligible_runs
from mocapkit.cleaning.ssa.repair import repair_with_left
from mocapkit.cleaning.whole_take import detect_take


def test_negligible_runs_are_the_runs_that_move_no_cell_by_the_bound():
    orig = np.tile([1.0, 0.0, 0.0, 0.0], (20, 1))
    out = orig.copy()
    out[3:6] = R.rotvec_to_quaternion(np.array([[np.radians(0.1), 0.0, 0.0]] * 3))  # 0.1 deg: nothing to see
    out[10:12] = R.rotvec_to_quaternion(np.array([[np.radians(5.0), 0.0, 0.0]] * 2))  # a repair
    changed = np.any(out != orig, axis=-1)
    runs = negligible_runs(orig, out, changed)
    assert [r[:2] for r in runs] == [(3, 6)]
    assert "0.100 deg" in runs[0][2]
    assert negligible_runs(orig, out, changed, min_deg=0.05) == []
    assert NEGLIGIBLE_DEG == 0.5


def test_a_held_elbow_repaired_by_hundredths_of_a_degree_is_given_back(walk):
    j = walk.skeleton.joint_names.index("RightElbow")
    det = detect_take(walk).detection  # as `mocapkit clean` detects it
    assert det.flags[961:966, j].all() and not det.flags[960, j]  # the hold is flagged, from its first repeat ...
    fixed, left = repair_with_left(walk, det, foot_skate=False)
    assert np.array_equal(fixed.rotations[:, j], walk.rotations[:, j])  # ... and left bit-identical
    run = [r for r in left if r.joint == "RightElbow" and r.start <= 961 < r.end]
    assert len(run) == 1 and "nothing to see" in run[0].reason
