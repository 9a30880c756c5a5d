"""Runs of True in frames-first masks (mocapkit.cleaning.runs)."""

from __future__ import annotations

import numpy as np

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning.runs import column_runs, run_cells, true_runs


def test_the_runs_of_every_column_are_each_column_s_runs_and_their_cells_the_mask():
    """131_01.bvh with gaps (corrupt.gaps, seed 3), one from the first frame, one to the last and a
    joint missing throughout: the runs of the (F, J) mask column by column, and their cells exactly its True cells."""
    take = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    gone = corrupt.gaps(take, seed=3)[0].missing()
    gone[:4, 2] = gone[-3:, 5] = gone[:, 7] = True
    col, start, end = column_runs(gone)
    want = [(c, s, e + 1) for c in range(gone.shape[1]) for s, e in true_runs(gone[:, c])]
    assert list(zip(col.tolist(), start.tolist(), end.tolist())) == want and len(want) > 20
    run, frame = run_cells(start, end)
    cells = np.zeros_like(gone)
    cells[frame, col[run]] = True
    assert np.array_equal(cells, gone) and len(frame) == gone.sum()
    assert np.array_equal(np.diff(frame)[np.diff(run) == 0], np.ones(int((np.diff(run) == 0).sum()), dtype=int))
