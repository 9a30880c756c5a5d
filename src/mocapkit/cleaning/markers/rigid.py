"""Rigid frames from groups of markers, and the distances between markers.

Optical markers on one body segment keep their distances (a rigid cluster);
markers on neighbouring segments keep them nearly. Gløersen and Federolf
(2016, PLoS ONE 11(3): e0152616) exploit the inter-correlations of all
markers; Tits, Tilmanne and Dutoit (2018, PLoS ONE 13(7): e0199744) keep
inter-marker distances near their usual values ("soft skeleton
constraints"). This module gives both ingredients:

- :func:`distance_stats`: the usual distance between every pair of markers
  and how much it varies (a low spread marks a rigid pair), over the frames
  where both are seen;
- :func:`donor_order`: for every marker, the others sorted from most to least
  rigidly attached;
- :func:`local_frames`: the per-frame rotation and origin of a donor group
  (Kabsch 1976 / Arun et al. 1987 least-squares fit to a reference shape),
  which turns a marker's trajectory into coordinates in the donors' moving
  frame, where it varies far less than in the room.

Positions are (F, M, 3) arrays, frames first, in the capture's length unit;
NaN marks an unseen sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ... import rotations as R

__all__ = ["DistanceStats", "distance_stats", "nan_percentiles", "donor_order", "local_frames", "local_frames_stacked", "to_local",
           "from_local"]


@dataclass(frozen=True)
class DistanceStats:
    """Usual inter-marker distances of one take.

    Attributes
    ----------
    median, low, high, spread : float arrays (M, M)
        Median, 1st and 99th percentile and robust spread (half the
        10-90 % range) of the distance between markers i and j over the frames
        where both are seen, in the capture's unit; NaN for pairs never seen
        together (and on the diagonal).
    count : int array (M, M)
        Frames where both are seen.
    """

    median: np.ndarray
    low: np.ndarray
    high: np.ndarray
    spread: np.ndarray
    count: np.ndarray


def distance_stats(positions: np.ndarray, max_frames: int = 600) -> DistanceStats:
    """Inter-marker distance statistics from at most ``max_frames`` evenly spaced frames.

    ``positions`` is (F, M, 3) with NaN for unseen samples. Subsampling keeps
    the cost at O(max_frames * M^2) whatever the take's length.
    """
    pos = np.asarray(positions, dtype=np.float64)
    f, m = pos.shape[:2]
    idx = np.unique(np.linspace(0, f - 1, min(f, max_frames)).round().astype(int)) if f else np.zeros(0, int)
    sub = pos[idx]
    d = np.linalg.norm(sub[:, :, None, :] - sub[:, None, :, :], axis=-1)  # (S, M, M), NaN where either unseen
    count = np.sum(~np.isnan(d), axis=0)
    out = np.full((4, m, m), np.nan)
    seen = count > 0
    if np.any(seen):
        q = nan_percentiles(d, [50, 1, 99, 10, 90])
        out[0], out[1], out[2] = q[0], q[1], q[2]
        out[3] = 0.5 * (q[4] - q[3])
    for k in range(4):
        np.fill_diagonal(out[k], np.nan)
    return DistanceStats(median=out[0], low=out[1], high=out[2], spread=out[3], count=count)


def nan_percentiles(values: np.ndarray, q) -> np.ndarray:
    """``np.nanpercentile(values, q, axis=0)`` bit for bit, without its Python loop over the columns.

    ``values`` (S, ...) float, NaN where missing; ``q`` (Q,) percentiles. Returns (Q, ...), NaN (and no
    warning) for a column with no value. numpy's ``nanpercentile`` drops each column's NaNs and takes
    the percentiles of what is left one column at a time: for a (600, 68, 68) stack of distances
    (:func:`distance_stats` of 03_rolling.c3d) 4,624 calls, most of the function's time. Here the
    columns with the same count of values are taken together: sorted (NaN last) and cut to that count,
    each is the same numbers, and ``np.percentile`` along an axis does for every column the
    arithmetic the one-column call does (the same order statistics and interpolation weights).
    """
    v = np.asarray(values, dtype=np.float64)
    flat = v.reshape(v.shape[0], -1)
    count = np.count_nonzero(~np.isnan(flat), axis=0)
    out = np.full((len(q), flat.shape[1]), np.nan)
    full = count == flat.shape[0]
    if flat.shape[0] and np.any(full):
        out[:, full] = np.percentile(flat[:, full], q, axis=0)
    rest = np.flatnonzero(~full & (count > 0))
    if rest.size:
        part = np.sort(flat[:, rest], axis=0)  # each column's values first, NaN last
        for n in np.unique(count[rest]):
            cols = count[rest] == n
            out[:, rest[cols]] = np.percentile(part[:n, cols], q, axis=0)
    return out.reshape((len(q),) + v.shape[1:])


def donor_order(stats: DistanceStats, min_count: int = 10) -> np.ndarray:
    """(M, M-1) int array: for each marker, the other markers from most to least rigidly attached.

    Rigidity is the spread of the pair's distance, plus a tenth of the
    median distance so that near markers win among equally rigid ones;
    pairs seen together in fewer than ``min_count`` sampled frames come last.
    """
    m = stats.median.shape[0]
    score = stats.spread + 0.1 * stats.median
    score = np.where((stats.count >= min_count) & np.isfinite(score), score, np.inf)
    np.fill_diagonal(score, np.inf)
    order = np.argsort(score, axis=1, kind="stable")
    return order[:, : max(m - 1, 0)]


def local_frames(donors: np.ndarray, reference: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame rotation and origin of a donor group.

    Parameters
    ----------
    donors : float array (T, K, 3)
        Positions of K >= 3 donor markers (NaN rows give NaN frames).
    reference : float array (K, 3), optional
        The donors' reference shape; default: their positions in the first
        frame where all are seen.

    Returns
    -------
    rot : float array (T, 3, 3)
        Rotation taking reference (centred) coordinates to the room, so that
        ``donors[t] ~ rot[t] @ (reference - mean) + origin[t]``.
    origin : float array (T, 3)
        The donors' centroid.
    """
    donors = np.asarray(donors, dtype=np.float64)
    t = donors.shape[0]
    ok = ~np.any(np.isnan(donors), axis=(1, 2))
    rot = np.full((t, 3, 3), np.nan)
    origin = donors.mean(axis=1)
    if not np.any(ok):
        return rot, origin
    if reference is None:
        reference = donors[np.argmax(ok)]
    ref = reference - reference.mean(axis=0)
    cur = donors[ok] - origin[ok][:, None, :]
    rot[ok] = R.kabsch(ref, cur)
    return rot, origin


def local_frames_stacked(donors: np.ndarray, references: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`local_frames` of G donor groups in one call: ``donors`` (G, T, K, 3), ``references`` (G, K, 3).

    Returns rot (G, T, 3, 3) and origin (G, T, 3), bit for bit
    ``local_frames(donors[g], references[g])``: every frame's Kabsch fit is
    its own, so one stack of G x T fits does the work of G calls at a
    fraction of the per-call cost (a spike's rigid check tries 4 neighbour
    triples, each over a few dozen frames).
    """
    donors = np.asarray(donors, dtype=np.float64)
    g, t = donors.shape[:2]
    flat = donors.reshape((g * t,) + donors.shape[2:])
    ok = ~np.any(np.isnan(flat), axis=(1, 2))
    rot = np.full((g * t, 3, 3), np.nan)
    origin = flat.mean(axis=1)
    if np.any(ok):
        ref = np.repeat(np.stack([r - r.mean(axis=0) for r in np.asarray(references, dtype=np.float64)]), t, axis=0)
        rot[ok] = R.kabsch(ref[ok], flat[ok] - origin[ok][:, None, :])
    return rot.reshape(g, t, 3, 3), origin.reshape(g, t, 3)


def to_local(points: np.ndarray, rot: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """Room points (T, 3) in the moving frame: ``rot[t]^T (points[t] - origin[t])``."""
    return np.einsum("tji,tj->ti", rot, points - origin)


def from_local(local: np.ndarray, rot: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """Moving-frame points (T, 3) back in the room: ``rot[t] local[t] + origin[t]``."""
    return np.einsum("tij,tj->ti", rot, local) + origin
