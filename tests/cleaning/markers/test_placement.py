"""The column permutations of label swaps (maths only: labels and frame ranges, no motion)."""

from __future__ import annotations

import numpy as np

from mocapkit.cleaning.markers import MarkerFix
from mocapkit.cleaning.markers.placement import destinations, sources

LABELS = ("a", "b", "c", "d")


def _swap(m, o, start, end):
    return MarkerFix(m, start, end, "swap", 1.0, o)


def test_sources_exchange_recorded_trajectories_over_each_swap_in_order_of_first_frame():
    # chained swaps: a/b over frames 2-5, then b/c over 4-7; each exchanges the two recorded trajectories it names
    # wherever the one before put them, so the three cycle in frames 4-5
    swaps = [_swap("b", "c", 4, 8), _swap("a", "b", 2, 6)]
    src = sources(swaps, LABELS, 10)
    x = np.tile(np.arange(4), (10, 1))  # each column's own index: applying the swaps by hand
    x[2:4] = [1, 0, 2, 3]
    x[4:6] = [2, 0, 1, 3]  # column a holds c's samples, b a's, c b's
    x[6:8] = [0, 2, 1, 3]
    assert np.array_equal(src, x)
    # apart, they are column exchanges, in either order
    apart = sources([_swap("a", "b", 2, 4), _swap("b", "c", 4, 8)], LABELS, 10)
    assert apart[2].tolist() == [1, 0, 2, 3] and apart[5].tolist() == [0, 2, 1, 3] and apart[8].tolist() == [0, 1, 2, 3]


def test_destinations_follow_the_kept_swaps_only():
    swaps = [_swap("a", "b", 2, 6), _swap("c", "d", 3, 5)]
    src = sources(swaps, LABELS, 8)
    assert np.array_equal(destinations(src, src), np.tile(np.arange(4), (8, 1)))  # all kept: where they are
    none = sources([], LABELS, 8)
    assert np.array_equal(destinations(src, none), src)  # none kept: back to the recorded column
    dest = destinations(src, sources(swaps[1:], LABELS, 8))  # a/b rejected, c/d kept
    assert dest[3].tolist() == [1, 0, 2, 3] and dest[7].tolist() == [0, 1, 2, 3]
