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
The projection works frame by frame, so the frames where a pair leaves
its range are pulled and their neighbours are not: on a long gap the
correction switched on and off from one frame to the next and the fill
jolted (a 2 s head gap: 30 mm/frame^2 where the marker never exceeds 2.3).
With ``smooth`` the correction of each filled run is low-passed over time
(a Gaussian of ``smooth`` frames, zero beyond a run's end where a seen
sample adjoins, so the fill still meets it).

:func:`violation` measures the share of such pairs outside their range.
Positions are (F, M, 3), frames first, in the capture's unit.
"""

from __future__ import annotations

import numpy as np

from ..ik import contact_segments
from .rigid import DistanceStats

__all__ = ["constraint_pairs", "enforce_distances", "smooth_correction", "violation"]


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
                      neighbours: int = 4, iterations: int = 10, margin: float = 0.0, smooth: float = 0.0) -> np.ndarray:
    """Move the samples in ``free`` (F, M) so their distances to rigid neighbours fall in the usual range.

    ``margin`` widens each range by that many times the pair's spread on
    both sides (0: the 1-99 % range). ``smooth`` > 0: the correction of
    each run of ``free`` frames is smoothed over time by a Gaussian of that
    standard deviation in frames (see the module's notes). Returns a copy
    of ``positions``; samples outside ``free`` are bit-identical, NaN
    samples are left alone.
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
    if smooth > 0:
        pos = smooth_correction(np.asarray(positions, dtype=np.float64), pos, free, smooth)
    return pos


def smooth_correction(before: np.ndarray, after: np.ndarray, free: np.ndarray, sigma: float) -> np.ndarray:
    """``before`` plus the correction ``after - before`` low-passed over time within each run of ``free``.

    before, after : (F, M, 3); free : (F, M) bool, the samples that may move;
    sigma : the Gaussian's standard deviation in frames. Outside a run the
    correction is taken as zero where a sample is seen (it never moves) and
    as the run's last correction beyond the take's first or last frame.
    Samples outside ``free`` and NaN samples keep ``after``'s values.
    """
    out = after.copy()
    f = free.shape[0]
    pad = int(np.ceil(4 * sigma)) + 1
    for m in np.flatnonzero(np.any(free, axis=0)):
        for a, b in contact_segments(free[:, m]):
            corr = after[a:b, m] - before[a:b, m]
            ok = np.all(np.isfinite(corr), axis=-1)
            if not np.all(ok):
                continue  # a NaN sample in the run: left as projected
            left = np.repeat(corr[:1] if a == 0 else np.zeros((1, 3)), pad, axis=0)
            right = np.repeat(corr[-1:] if b == f else np.zeros((1, 3)), pad, axis=0)
            from scipy.ndimage import gaussian_filter1d  # here: importing scipy.ndimage takes ~0.2 s

            low = gaussian_filter1d(np.concatenate([left, corr, right]), sigma, axis=0, mode="nearest")
            out[a:b, m] = before[a:b, m] + low[pad:pad + b - a]
    return out
