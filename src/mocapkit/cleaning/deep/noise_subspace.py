"""A channel's white-noise level from the noise subspace of its short windows, blind to fast motion.

The SURE calibration (:mod:`.sure`) needs each block's noise std ``s``. Second
differences measure it well where the motion is slow against the frame rate,
but at 30 fps a hand waving at 4-5 Hz, a foot striking the floor or a toe
snapping back moves by several degrees from one frame's trend to the next: the
second differences read that motion as noise (on the Bandai Namco rig's hands,
feet and toes 1.5 to 7 times the noise there is), the risk estimate then
believes the filter takes off noise where it takes off motion, and light noise
comes back worse than it came.

Motion is predictable from its neighbourhood and white noise is not. Over
windows of :data:`WINDOW` frames, a smooth trend and a few oscillations fill
only a few directions of the window space; white noise of std ``s`` puts
``s^2`` in every direction. The directions of least energy (the last
:data:`NOISE_RANK` eigenvectors of the windows' second-moment matrix) thus
hold the noise alone, as the smallest singular values of a trajectory
matrix do in singular spectrum analysis (Golyandina, Nekrutkin & Zhigljavsky
2001) and the weakest principal components of image patches do in blind
noise estimation (Liu, Tanaka & Okutomi 2013). Two measures keep the
estimate unbiased and robust: the directions are found on one half of the
block and the energy measured on the other half's windows (directions picked
from the same samples would be those where the noise happened to be weak),
so on white noise each window's energy is ``s^2`` times a chi-square with
:data:`NOISE_RANK` degrees of freedom; and ``s^2`` is their median over the
chi-square's median, which a few windows holding a sudden transient (a foot
strike) do not move.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.stats import chi2

__all__ = ["WINDOW", "NOISE_RANK", "subspace_noise_std"]

WINDOW = 16
"""Frames per window: half a second at 30 fps, long enough that a step's or a wave's motion fills only a few of
its directions."""

NOISE_RANK = 4
"""Directions of least energy read as noise out of :data:`WINDOW` (the motion of a step or a wave fills fewer than
the other 12). On the validation styles ("tired", "childish", 2 draws, with a larger keep margin) 3 of 12, 4 of 16
and 6 of 24 gave 0.654, 0.657 and 0.663 deg at 0.1 of Mall's noise and 3.74, 3.79, 3.72 at 0.9: no clear best;
16 frames is half a second at 30 fps."""

_MEDIAN_CHI2 = float(chi2.ppf(0.5, NOISE_RANK))


def _window_energy(train: np.ndarray, train_ok: np.ndarray, test: np.ndarray, test_ok: np.ndarray) -> np.ndarray:
    """Energy of each complete window of ``test`` (F2, C) in the :data:`NOISE_RANK` directions of least energy of
    ``train``'s (F1, C) complete windows: (C, M2), NaN for a window holding an unobserved sample (``*_ok`` bool)."""
    wa = np.transpose(sliding_window_view(train, WINDOW, axis=0), (1, 0, 2))  # (C, M1, WINDOW)
    oka = sliding_window_view(train_ok, WINDOW, axis=0).all(axis=-1).T  # (C, M1)
    wa = np.where(oka[..., None], wa, 0.0)
    _, vec = np.linalg.eigh(np.matmul(np.transpose(wa, (0, 2, 1)), wa))  # eigenvalues rising
    wb = np.transpose(sliding_window_view(test, WINDOW, axis=0), (1, 0, 2))  # (C, M2, WINDOW)
    okb = sliding_window_view(test_ok, WINDOW, axis=0).all(axis=-1).T
    e = np.sum(np.matmul(wb, vec[:, :, :NOISE_RANK]) ** 2, axis=2)
    return np.where(okb, e, np.nan)


def subspace_noise_std(x: np.ndarray, observed: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Per block and channel, the white-noise std measured in the noise subspace of the block's windows: (B, C);
    NaN where a block is too short (each half under two :data:`WINDOW` s) or holds fewer than :data:`WINDOW` complete
    windows on a channel.

    ``x`` (F, C) channels (degrees), ``observed`` (F, C) bool (filled gap entries
    False: a window holding one does not count), ``edges`` (B + 1,) block edges
    (:func:`mocapkit.cleaning.deep.sure.block_edges`). Each block's first half
    gives the directions for its second half's windows and the reverse.
    """
    x = np.asarray(x, dtype=np.float64)
    obs = np.asarray(observed, dtype=bool)
    B, C = len(edges) - 1, x.shape[1]
    out = np.full((B, C), np.nan)
    for b in range(B):
        lo, hi = int(edges[b]), int(edges[b + 1])
        h = (hi - lo) // 2
        if h < 2 * WINDOW:
            continue
        ok = obs[lo:hi]
        n = ok.sum(axis=0)
        mean = np.divide(np.where(ok, x[lo:hi], 0.0).sum(axis=0), n, out=np.zeros(C), where=n > 0)
        xb = x[lo:hi] - mean
        e = np.concatenate([_window_energy(xb[:h], ok[:h], xb[h:], ok[h:]),
                            _window_energy(xb[h:], ok[h:], xb[:h], ok[:h])], axis=1)
        enough = np.sum(~np.isnan(e), axis=1) >= WINDOW
        if enough.any():
            out[b, enough] = np.sqrt(np.nanmedian(e[enough], axis=1) / _MEDIAN_CHI2)
    return out
