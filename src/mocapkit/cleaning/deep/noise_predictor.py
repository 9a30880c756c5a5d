"""A channel's white-noise level read through the block's own best interpolator, blind to fast motion.

The SURE calibration (:mod:`.sure`) needs each block's noise std ``s``. Second
differences measure it well where the motion is slow against the frame rate,
but at 30 fps a hand waving at 4-5 Hz, a foot striking the floor or a toe
snapping back moves by degrees from one frame's trend to the next: the second
differences read that motion as noise (on the Bandai Namco rig's hands, feet
and toes 1.5 to 7 times the noise there is), the risk estimate then believes
the filter takes off noise where it takes off motion, and light noise comes
back worse than it came.

Motion is predictable from its neighbours and white noise is not. The second
difference is one fixed interpolator, ``x_t - (x_{t-1} + x_{t+1}) / 2``; per
block and channel this module fits the symmetric one of :data:`ORDER` taps,
``e_t = x_t - sum_k a_k (x_{t-k} + x_{t+k})``, by least squares (a linear
predictor, as in linear-prediction analysis of speech: Makhoul 1975, with
the frame itself left out of its own prediction). A smooth trend or an
oscillation is predicted almost exactly (a sinusoid of frequency ``w`` by
``a_1 = 1 / (2 cos w)``), and for white noise of std ``s`` the residual's
variance is ``s^2 (1 + 2 sum_k a_k^2)`` whatever the taps: that sum divided
out gives ``s^2``, an upper bound where motion is left in the residual and
tighter than the second differences' wherever they are not the best
interpolator (on white noise alone a little low: the fit takes ~6 % of it
over a 4 s block at 30 fps; :data:`mocapkit.cleaning.deep.sure.PREDICTOR_MARGIN`
covers that). ``s^2`` is taken from the median of the squared residuals
(over the median of a chi-square with one degree of freedom), which a few
frames holding a sudden transient (a foot strike) do not move. The noise
(white, independent of the taps) is what the risk estimate assumes too; a
take's own jitter is indistinguishable from it.
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit

__all__ = ["ORDER", "MIN_FRAMES", "predictor_noise_std"]

ORDER = 3
"""Taps on each side of the interpolator (frames t - 3 .. t + 3 but t): a 30 fps step's or wave's motion over a
fifth of a second is predicted from them (chosen with the subspace estimate's windows of 16 frames in mind, not
tuned)."""

MIN_FRAMES = 16
"""The fewest frames of a block and channel whose interpolator is fitted (their ``2 ORDER + 1`` frames all
observed): fewer give no estimate."""


@functools.cache
def _median_chi2_1() -> float:
    """The median of a chi-square with one degree of freedom (0.455), computed on first use (importing
    ``scipy.stats`` takes ~0.5 s, which most commands never need)."""
    from scipy.stats import chi2

    return float(chi2.ppf(0.5, 1))


@njit(cache=True)
def _solve_spd(g, h):
    """``g^-1 h`` for a small symmetric positive definite ``g`` (p, p) by Cholesky, in place of a LAPACK call per
    block and channel."""
    p = h.shape[0]
    L = np.zeros((p, p))
    for i in range(p):
        for j in range(i + 1):
            v = g[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = np.sqrt(max(v, 1e-300)) if i == j else v / L[j, j]
    z = np.empty(p)
    for i in range(p):
        v = h[i]
        for k in range(i):
            v -= L[i, k] * z[k]
        z[i] = v / L[i, i]
    a = np.empty(p)
    for i in range(p - 1, -1, -1):
        v = z[i]
        for k in range(i + 1, p):
            v -= L[k, i] * a[k]
        a[i] = v / L[i, i]
    return a


@njit(cache=True)
def _predictor_noise(x, usable, edges, p, med, out):
    C = x.shape[0]  # channels-first inside: each channel's frames contiguous; usable (C, F): _usable
    B = edges.shape[0] - 1
    for c in range(C):
        for b in range(B):
            lo, hi = edges[b], edges[b + 1]
            g = np.zeros((p, p))
            h = np.zeros(p)
            u = np.empty(p)
            n = 0
            for t in range(lo, hi):
                if not usable[c, t]:
                    continue
                n += 1
                for k in range(p):
                    u[k] = x[c, t - k - 1] + x[c, t + k + 1]
                for i in range(p):
                    h[i] += u[i] * x[c, t]
                    for j in range(p):
                        g[i, j] += u[i] * u[j]
            if n < MIN_FRAMES:
                continue
            ridge = 1e-9 * (np.trace(g) / p + 1e-12)
            for i in range(p):
                g[i, i] += ridge
            a = _solve_spd(g, h)
            e2 = np.empty(n)
            m = 0
            for t in range(lo, hi):
                if not usable[c, t]:
                    continue
                r = x[c, t]
                for k in range(p):
                    r -= a[k] * (x[c, t - k - 1] + x[c, t + k + 1])
                e2[m] = r * r
                m += 1
            gain = 1.0 + 2.0 * np.sum(a * a)
            out[b, c] = np.sqrt(np.median(e2) / med / gain)


def predictor_noise_std(x: np.ndarray, observed: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Per block and channel, the white-noise std read through the block's best symmetric interpolator of
    :data:`ORDER` taps a side: (B, C); NaN where fewer than :data:`MIN_FRAMES` frames of the block have their own
    and their neighbours' samples observed.

    ``x`` (F, C) channels (degrees), ``observed`` (F, C) bool (filled gap
    entries False: a frame next to one does not count), ``edges`` (B + 1,)
    block edges (:func:`mocapkit.cleaning.deep.sure.block_edges`); a frame's
    neighbours may lie in the next or previous block.
    """
    x = np.asarray(x, dtype=np.float64)
    out = np.full((len(edges) - 1, x.shape[1]), np.nan)
    _predictor_noise(np.ascontiguousarray(x.T), np.ascontiguousarray(_usable(observed, ORDER).T),
                     np.asarray(edges, dtype=np.int64), ORDER, _median_chi2_1(), out)
    return out


def _usable(observed: np.ndarray, p: int) -> np.ndarray:
    """(F, C) bool: the frames whose own sample and ``p`` neighbours on each side are all ``observed`` (F, C) (a
    frame within ``p`` of either end has too few neighbours: False), those the interpolator is fitted on."""
    obs = np.asarray(observed, dtype=bool)
    F = obs.shape[0]
    out = np.zeros_like(obs)
    if F > 2 * p:
        win = np.lib.stride_tricks.sliding_window_view(obs, 2 * p + 1, axis=0)  # (F - 2p, C, 2p + 1)
        out[p:F - p] = win.all(axis=-1)
    return out
