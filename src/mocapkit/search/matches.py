"""The result of a global (subsequence) match: a database range, its cost and its warping path."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Match"]


@dataclass(frozen=True, eq=False)
class Match:
    """One database segment aligned to a query.

    Attributes
    ----------
    start, end : int
        First and last database frame index of the segment (inclusive).
    cost : float
        Global distance: the accumulated local cost along ``path`` (with the
        step weights of the method that produced it).
    path : int array (L, 2)
        The warping path, rows ``(query frame, database frame)`` in increasing
        order; ``path[0, 1] == start`` and ``path[-1, 1] == end``.
    """

    start: int
    end: int
    cost: float
    path: np.ndarray

    def __post_init__(self):
        p = np.asarray(self.path, dtype=np.int64)
        if p.ndim != 2 or p.shape[1] != 2:
            raise ValueError(f"path: expected shape (L, 2), got {p.shape}")
        p = p.copy()
        p.setflags(write=False)
        object.__setattr__(self, "path", p)
        object.__setattr__(self, "start", int(self.start))
        object.__setattr__(self, "end", int(self.end))
        object.__setattr__(self, "cost", float(self.cost))

    @property
    def length(self) -> int:
        """Number of database frames covered, ``end - start + 1``."""
        return self.end - self.start + 1

    def overlaps(self, other: "Match") -> bool:
        """True when the two database ranges share a frame."""
        return self.start <= other.end and other.start <= self.end

    def __repr__(self) -> str:
        return f"Match(start={self.start}, end={self.end}, cost={self.cost:.6g}, path={len(self.path)} steps)"
