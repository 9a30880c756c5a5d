"""mocapkit.cleaning.ties: which changes are decided together, on rows made up for the rule (the real takes that
show each pattern are in test_decisions.py)."""

from __future__ import annotations

import numpy as np

from mocapkit.cleaning.ssa.cues import CAUSES
from mocapkit.cleaning.ties import STEPS_WHY, SWAP_WHY, split_message, swap_cells, tie_groups

F = frozenset


def test_the_two_sides_of_a_flagged_swap_are_tied_and_nothing_else_of_a_pair_is():
    # joints 0 and 1 are a left/right pair, 2 has no partner
    partner = [1, 0, 2]
    swaps = np.zeros((40, 3), dtype=bool)
    swaps[10:20, [0, 1]] = True
    rows = [(0, 5, 19, F({"repair"})),     # 0: a swap repaired, grown beyond the swap on this side
            (1, 10, 19, F({"repair"})),    # 1: its other side
            (0, 25, 30, F({"repair"})),    # 2: both sides repaired over the same frames, not flagged as a swap
            (1, 25, 30, F({"repair"})),    # 3
            (1, 0, 9, F({"denoise"})),     # 4: denoised beside the swap's side, disjoint steps: not tied
            (2, 10, 19, F({"repair"}))]    # 5: flagged over the swap's frames, no partner
    assert tie_groups(rows, swaps, partner) == [([0, 1], SWAP_WHY)]
    rows[4] = (1, 0, 9, F({"repair"}))     # the same step touching the swap's side: tied to it, so to both
    assert tie_groups(rows, swaps, partner) == [([0, 1, 4], f"{SWAP_WHY}; and {STEPS_WHY}")]


def test_touching_rows_of_nested_steps_are_tied_through_a_whole_run():
    swaps = np.zeros((300, 2), dtype=bool)
    rows = [(0, 0, 111, F({"denoise"})), (0, 112, 112, F({"repair", "denoise"})), (0, 113, 280, F({"denoise"})),
            (1, 0, 50, F({"fill"})), (1, 51, 60, F({"repair"})),            # touching, disjoint steps: not tied
            (1, 100, 120, F({"fill", "denoise"})), (1, 122, 130, F({"denoise"}))]  # a frame apart: not touching
    assert tie_groups(rows, swaps, [0, 1]) == [([0, 1, 2], STEPS_WHY)]
    assert tie_groups(rows[::-1], swaps, [0, 1]) == [([4, 5, 6], STEPS_WHY)]  # whatever order the rows come in


def test_swap_cells_and_the_refusal_words():
    bit = 1 << [name for name, _ in CAUSES].index("swap")
    causes = np.array([[0, bit], [bit | 1, 1]], dtype=np.uint16)
    assert swap_cells(causes, (2, 2)).tolist() == [[False, True], [True, False]]
    assert not swap_cells(None, (2, 2)).any()  # a record without causes ties no swap
    ids = ["a", "b", "c", "d", "e"]
    words = split_message(ids, ["accept", "reject", "accept", "accept", "accept"], "why")
    assert words == ("accepts a, c, d and 1 more but rejects b, which are decided together (why): accept or reject "
                     "them all")
