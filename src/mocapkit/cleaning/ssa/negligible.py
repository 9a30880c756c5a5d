"""Repairs too small to see: a repaired run that moves no cell by :data:`NEGLIGIBLE_DEG` is given back as it was.

A flag can be right and its repair still change nothing a person could see: a joint held bit-still while the
similar motion moves (:func:`~mocapkit.cleaning.ssa.cues.held_joints`) whose medoid neighbour word hardly
moves either comes back within hundredths of a degree of its input once the blend makes it meet the take at
both ends (CMU 131_01's RightElbow, frames 960-965: 0.012 deg at most). Such a run costs the take its
bit-identity and a reviewer one row per cell for nothing, so it is given back bit for bit and named like the
guard's runs (:class:`~mocapkit.cleaning.ssa.guard.LeftRun`). The bound lies under the denoise step's 1-degree
noise level and far under every error :func:`mocapkit.corrupt.real_errors` makes (10 deg and more). A rule of
this library, not of Aristidou et al. (2018).
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R
from ..runs import true_runs

__all__ = ["NEGLIGIBLE_DEG", "negligible_runs"]

#: degrees: a repaired run whose cells all move less than this is no visible repair
NEGLIGIBLE_DEG = 0.5


def negligible_runs(orig: np.ndarray, out: np.ndarray, changed: np.ndarray,
                    min_deg: float = NEGLIGIBLE_DEG) -> list[tuple[int, int, str]]:
    """The maximal runs of ``changed`` (F,) bool whose largest change from ``orig`` to ``out`` (F, 4) one joint's
    input and repaired tracks is under ``min_deg`` degrees, as ``(start, end, reason)`` (end exclusive)."""
    runs = true_runs(np.asarray(changed, dtype=bool))
    moved = np.degrees(R.geodesic_angle(np.asarray(orig, dtype=np.float64), np.asarray(out, dtype=np.float64)))
    out_runs = []
    for s, last in runs:
        e = last + 1
        most = float(moved[s:e].max())
        if most < min_deg:
            out_runs.append((int(s), int(e), f"moves it by {most:.3f} deg at most, under {min_deg:g}: nothing to see"))
    return out_runs
