"""Soft distance constraints: keep filled markers at their usual distances from their rigid neighbours.

Tits, Tilmanne and Dutoit (2018, PLoS ONE 13(7): e0199744) correct a
recovered marker so that its distances to the markers of its body part
stay within what the take shows elsewhere ("soft skeleton constraints").
:func:`enforce_distances` does that on the filled samples only: each filled
sample and its ``neighbours`` most rigidly attached markers form pairs
whose usual range is the 1st-99th percentile of their distance over the
take (:class:`~mocapkit.cleaning.markers.rigid.DistanceStats`); a pair
outside its range pulls the filled sample along the line between the two
onto the nearest bound (half each when both are filled). The corrections
of all pairs are averaged and applied, ``iterations`` times (a Jacobi
projection, as in position-based dynamics). Observed samples never move.

:func:`violation` measures the share of such pairs outside their range.
Positions are (F, M, 3), frames first, in the capture's unit.
"""

from __future__ import annotations

import numpy as np

from .rigid import DistanceStats

__all__ = ["constraint_pairs", "enforce_distances", "violation"]


def constraint_pairs(mask: np.ndarray, stats: DistanceStats, order: np.ndarray, neighbours: int = 4):
    """(t, i, d) index arrays: every sample (t, i) in ``mask`` with its ``neighbours`` most rigid markers d of known range."""
    t, i = np.nonzero(mask)
    if t.size == 0 or order.shape[1] == 0:
        return t, i, i
    k = min(neighbours, order.shape[1])
    d = order[i, :k]  # (S, k)
    t, i, d = np.repeat(t, k), np.repeat(i, k), d.ravel()
    ok = np.isfinite(stats.low[i, d]) & np.isfinite(stats.high[i, d])
    return t[ok], i[ok], d[ok]


def violation(positions: np.ndarray, stats: DistanceStats, order: np.ndarray, mask: np.ndarray,
              neighbours: int = 3) -> float:
    """Share of (sample in ``mask``, rigid neighbour) distances outside the pair's 1-99 % range (NaN: no pair)."""
    t, i, d = constraint_pairs(mask, stats, order, neighbours)
    dist = np.linalg.norm(positions[t, i] - positions[t, d], axis=-1)
    ok = ~np.isnan(dist)
    if not np.any(ok):
        return float("nan")
    out = (dist < stats.low[i, d]) | (dist > stats.high[i, d])
    return float(out[ok].mean())


def enforce_distances(positions: np.ndarray, free: np.ndarray, stats: DistanceStats, order: np.ndarray, *,
                      neighbours: int = 4, iterations: int = 10, margin: float = 0.0) -> np.ndarray:
    """Move the samples in ``free`` (F, M) so their distances to rigid neighbours fall in the usual range.

    ``margin`` widens each range by that many times the pair's spread on
    both sides (0: the 1-99 % range). Returns a copy of ``positions``;
    samples outside ``free`` are bit-identical, NaN samples are left alone.
    """
    pos = np.array(positions, dtype=np.float64)
    t, i, d = constraint_pairs(free, stats, order, neighbours)
    if t.size == 0:
        return pos
    lo, hi = stats.low[i, d] - margin * stats.spread[i, d], stats.high[i, d] + margin * stats.spread[i, d]
    both = free[t, d]
    share = np.where(both, 0.5, 1.0)
    for _ in range(iterations):
        diff = pos[t, i] - pos[t, d]
        dist = np.linalg.norm(diff, axis=-1)
        target = np.clip(dist, lo, hi)
        bad = np.isfinite(dist) & (target != dist) & (dist > 0)
        if not np.any(bad):
            break
        step = ((target - dist) / np.where(dist > 0, dist, 1.0))[:, None] * diff * share[:, None]
        acc = np.zeros_like(pos)
        cnt = np.zeros(pos.shape[:2])
        np.add.at(acc, (t[bad], i[bad]), step[bad])
        np.add.at(cnt, (t[bad], i[bad]), 1.0)
        sel = bad & both
        np.add.at(acc, (t[sel], d[sel]), -step[sel])
        np.add.at(cnt, (t[sel], d[sel]), 1.0)
        moved = cnt > 0
        pos[moved] += acc[moved] / cnt[moved][:, None]
    return pos
