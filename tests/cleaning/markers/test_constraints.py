"""Soft distance constraints (cleaning/markers/constraints.py) on a real CMU capture."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocapkit.cleaning.markers import enforce_distances
from mocapkit.cleaning.markers.constraints import constraint_pairs, end_distances
from mocapkit.cleaning.markers.rigid import distance_stats, donor_order
from mocapkit.io.c3d import read_c3d

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"


def test_end_distances_are_those_at_the_frames_around_each_free_run():
    rng = np.random.default_rng(0)
    pos = rng.normal(size=(10, 2, 3))
    free = np.zeros((10, 2), bool)
    free[3:6, 0] = True
    free[8:, 0] = True  # runs to the end of the take: no frame after it
    t, i, d = np.array([3, 5, 8]), np.array([0, 0, 0]), np.array([1, 1, 1])
    before, after = end_distances(pos, free, t, i, d)
    dist = np.linalg.norm(pos[:, 0] - pos[:, 1], axis=-1)
    assert np.allclose(before, dist[[2, 2, 7]])
    assert np.allclose(after[:2], dist[[6, 6]]) and np.isnan(after[2])


def test_a_fill_whose_own_ends_lie_outside_the_usual_range_is_not_pulled_back():
    # The marker slipped 60 mm for a while and was hidden inside that while: the fill that
    # follows the slipped marker (the truth) must stay, not be pulled to the take's usual distances.
    x = np.asarray(read_c3d(CMU).positions, dtype=np.float64)
    stats = distance_stats(x)
    order = donor_order(stats)
    k = 5
    d0 = int(order[k][0])
    away = x[230, k] - x[230, d0]
    y = x.copy()
    y[150:310, k] += 60.0 * away / np.linalg.norm(away)  # 60 mm away from its most rigid neighbour
    free = np.zeros(x.shape[:2], bool)
    free[200:260, k] = True
    t, i, d = constraint_pairs(free, stats, order)
    dist = np.linalg.norm(y[t, i] - y[t, d], axis=-1)
    assert np.mean((dist < stats.low[i, d]) | (dist > stats.high[i, d])) > 0.25  # outside the usual range...
    z = enforce_distances(y, free, stats, order)
    assert np.max(np.linalg.norm(z[free] - y[free], axis=-1)) < 20.0  # ...yet left near where its ends put it (not 60 mm back)
    assert np.array_equal(z[~free], y[~free])
