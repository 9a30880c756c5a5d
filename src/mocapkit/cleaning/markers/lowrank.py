"""Low-rank (PCA) fill of marker gaps from the inter-correlations of all markers.

Gløersen and Federolf (2016, "Predicting missing marker trajectories in
human motion data using marker intercorrelations", PLoS ONE 11(3):
e0152616): the markers of a body move together, so the (F, 3M) matrix of a
take is close to low rank; the coordinates of a missing marker follow from
the others through the principal components. They normalise every
coordinate, weight markers by their distance to the missing one (near
markers count more), and reconstruct the missing entries from the leading
components. :func:`fill_lowrank` takes the components of the frames where
every marker is seen and gives each gapped frame's missing coordinates from
the least-squares scores of its observed ones; with too few complete frames
it iterates instead (Federolf 2013): start from linear interpolation, then
alternate a rank-r reconstruction and re-imputing the missing entries. The
observed entries are never changed.

Used whole-take as the benchmark's Gløersen-Federolf baseline, and on a
window around a gap over the gap marker's nearest markers as one of the
fills :mod:`mocapkit.cleaning.markers.gaps` averages.
"""

from __future__ import annotations

import numpy as np

__all__ = ["fill_lowrank"]


def _interp_columns(x: np.ndarray) -> np.ndarray:
    """Columns of (F, C) with NaN linearly interpolated (held at the ends); all-NaN columns become 0."""
    out = x.copy()
    t = np.arange(x.shape[0])
    for c in range(x.shape[1]):
        ok = ~np.isnan(x[:, c])
        if not np.any(ok):
            out[:, c] = 0.0
        elif not np.all(ok):
            out[~ok, c] = np.interp(t[~ok], t[ok], x[ok, c])
    return out


def fill_lowrank(positions: np.ndarray, weights: np.ndarray | None = None, energy: float = 0.995,
                 max_rank: int | None = None, iterations: int = 40, tol: float = 1e-4) -> np.ndarray:
    """Fill the NaN samples of ``positions`` from a low-rank model of all markers.

    Parameters
    ----------
    positions : float array (F, M, 3)
        Marker positions in any one unit, NaN where unseen.
    weights : float array (M,), optional
        Per-marker weight in the PCA (Gløersen-Federolf weight near markers
        more); default 1.
    energy : float
        The rank is the fewest components that hold this share of the
        variance of the (weighted, normalised) matrix.
    max_rank : int, optional
        Upper bound on the rank.
    iterations, tol : int, float
        At most ``iterations`` rounds; stop when the imputed entries change by
        less than ``tol`` (normalised units, RMS).

    Returns
    -------
    float array (F, M, 3)
        ``positions`` with every NaN sample of a marker seen at least once
        replaced; observed samples unchanged; markers never seen stay NaN.
    """
    pos = np.asarray(positions, dtype=np.float64)
    f, m = pos.shape[:2]
    x = pos.reshape(f, 3 * m)
    miss = np.isnan(x)
    never = np.all(miss, axis=0)
    if not np.any(miss[:, ~never]):
        return pos.copy()
    with np.errstate(all="ignore"):
        mean = np.where(never, 0.0, np.nanmean(np.where(never, 0.0, x), axis=0))
        std = np.where(never, 1.0, np.nanstd(np.where(never, 0.0, x), axis=0))
    std = np.where(std > 1e-9, std, 1.0)
    w = np.ones(m) if weights is None else np.asarray(weights, dtype=np.float64)
    wc = np.repeat(w, 3)
    wc = np.where(wc > 0, wc, 1e-6)
    z = (x - mean) / std * wc
    z[:, never] = 0.0
    fill = miss & ~never
    complete = ~np.any(fill, axis=1)
    if np.count_nonzero(complete) >= max(10, 2 * _rank_cap(max_rank, m)):
        out = _project(z, fill, complete, energy, max_rank)
    else:
        out = _iterate(z, fill, energy, max_rank, iterations, tol)
    out = out / wc * std + mean
    out = np.where(fill, out, x)
    out[:, never] = np.nan
    return out.reshape(f, m, 3)


def _rank_cap(max_rank: int | None, markers: int) -> int:
    """The largest rank allowed: ``max_rank`` or 3 per marker."""
    return 3 * markers if max_rank is None else max_rank


def _rank(s: np.ndarray, energy: float, max_rank: int | None) -> int:
    e = np.cumsum(s ** 2)
    r = int(np.searchsorted(e, energy * e[-1]) + 1) if e[-1] > 0 else 1
    return r if max_rank is None else min(r, max_rank)


def _project(z: np.ndarray, fill: np.ndarray, complete: np.ndarray, energy: float, max_rank: int | None) -> np.ndarray:
    """Gløersen-Federolf: principal components of the complete frames; each gapped frame's missing
    coordinates from the least-squares scores of its observed ones."""
    _, s, vt = np.linalg.svd(z[complete], full_matrices=False)
    out = z.copy()
    rows = np.flatnonzero(np.any(fill, axis=1))
    patterns, inverse = np.unique(fill[rows], axis=0, return_inverse=True)
    for k, pat in enumerate(patterns):
        sel = rows[inverse.ravel() == k]
        obs = ~pat
        r = min(_rank(s, energy, max_rank), max(int(obs.sum()) - 1, 1))
        v = vt[:r].T  # (C, r)
        scores, *_ = np.linalg.lstsq(v[obs], z[np.ix_(sel, obs)].T, rcond=None)
        out[np.ix_(sel, pat)] = (v[pat] @ scores).T
    return out


def _iterate(z: np.ndarray, fill: np.ndarray, energy: float, max_rank: int | None, iterations: int, tol: float) -> np.ndarray:
    """Too few complete frames: start from linear interpolation and alternate a low-rank reconstruction and re-imputing."""
    cur = _interp_columns(np.where(fill, np.nan, z))
    for _ in range(iterations):
        u, s, vt = np.linalg.svd(cur, full_matrices=False)
        r = _rank(s, energy, max_rank)
        rec = (u[:, :r] * s[:r]) @ vt[:r]
        change = np.sqrt(np.mean((rec[fill] - cur[fill]) ** 2))
        cur[fill] = rec[fill]
        if change < tol:
            break
    return cur
