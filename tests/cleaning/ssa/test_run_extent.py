"""The frames a confirmed run's breaks give it (mocapkit.cleaning.ssa.run_extent), on one run's own frames."""

from __future__ import annotations

import numpy as np

from mocapkit.cleaning.ssa.run_extent import run_cells


def _run(low, breaks, spikes=None, margin=2, length=20):
    mask = np.zeros(length, dtype=bool)
    lo, br = mask.copy(), mask.copy()
    lo[list(low)] = True
    br[list(breaks)] = True
    sp = None if spikes is None else br.copy()
    return np.flatnonzero(run_cells(lo, br, sp, margin)).tolist()


def test_one_break_keeps_the_digression_before_it_up_to_the_margin_past_it():
    assert _run(range(2, 14), range(6, 10)) == list(range(2, 12))
    assert _run(range(6, 14), range(6, 8)) == list(range(6, 10))


def test_two_breaks_keep_the_digression_between_them_within_the_margin():
    assert _run(range(2, 14), [5, 6, 12, 13]) == list(range(3, 14))


def test_a_spike_only_run_is_its_spikes_frames_digressing_or_not():
    assert _run(range(2, 14), [7, 8, 9], spikes=True) == [8]
    assert _run([2, 3, 4, 5, 6, 10, 11], [6, 7, 8, 9], spikes=True) == [7, 8]  # the flipped frames do not digress
