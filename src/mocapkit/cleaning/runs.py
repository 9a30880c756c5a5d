"""Runs of True in a frames-first mask: the stretches a fix, a freeze or a gap spans."""

from __future__ import annotations

import numpy as np

__all__ = ["true_runs", "column_runs", "run_cells"]


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The runs of True of a (F,) bool ``mask`` as ``(first, last)`` frames, inclusive, in order."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask).astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), (np.flatnonzero(edges == -1) - 1).tolist()))


def column_runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The runs of True of every column of a (F, C) bool ``mask`` (a gap of every channel): ``(column, start,
    end)``, each (R,), ``start`` the run's first frame and ``end`` the first after it (exclusive), ordered by column,
    then by start."""
    F, C = mask.shape
    padded = np.zeros((C, F + 2), dtype=np.int8)
    padded[:, 1:-1] = mask.T
    d = np.diff(padded, axis=1)  # (C, F + 1)
    column, start = np.nonzero(d == 1)
    _, end = np.nonzero(d == -1)  # row-major order: same column order, starts and ends alternate
    return column, start, end


def run_cells(start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(run, frame)``: the run index and frame of every cell of the runs ``[start, end)`` (R,), run after run."""
    n = end - start
    run = np.repeat(np.arange(len(n)), n)
    first = np.cumsum(n) - n
    frame = start[run] + (np.arange(int(n.sum())) - first[run])
    return run, frame
