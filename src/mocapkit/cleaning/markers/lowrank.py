"""Low-rank (PCA) fill of marker gaps from the inter-correlations of all markers.

Gløersen and Federolf (2016, "Predicting missing marker trajectories in
human motion data using marker intercorrelations", PLoS ONE 11(3):
e0152616): the markers of a body move together, so the (F, 3M) matrix of a
take is close to low rank; the coordinates of a missing marker follow from
the others through the principal components. They normalise every
coordinate, weight markers by their distance to the missing one (near
markers count more), and reconstruct the missing entries from the leading
components. :func:`fill_lowrank` does that iteratively (Federolf 2013's
"iterate until the reconstruction stops changing"): start from linear
interpolation, then alternate a rank-r reconstruction of the weighted,
normalised matrix and re-imputing the missing entries only; the observed
entries are never changed.

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
    cur = _interp_columns(np.where(fill, np.nan, z))
    cur[:, never] = 0.0
    for _ in range(iterations):
        u, s, vt = np.linalg.svd(cur, full_matrices=False)
        e = np.cumsum(s ** 2)
        r = int(np.searchsorted(e, energy * e[-1]) + 1) if e[-1] > 0 else 1
        if max_rank is not None:
            r = min(r, max_rank)
        rec = (u[:, :r] * s[:r]) @ vt[:r]
        change = np.sqrt(np.mean((rec[fill] - cur[fill]) ** 2))
        cur[fill] = rec[fill]
        if change < tol:
            break
    out = cur / wc * std + mean
    out = np.where(fill, out, x)
    out[:, never] = np.nan
    return out.reshape(f, m, 3)
