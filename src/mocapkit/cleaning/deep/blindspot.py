"""Each joint-angle channel predicted from the other channels of the same take, never from its own sample.

The gap prior (:mod:`.prior`) reads the observed channels around a gap to
fill it; on a noisy take it reads them denoised. The EBF (Mall et al. 2017)
denoises each channel with a filter over its own samples; what the *other*
joints say about a channel (a walk's arms answer its legs, a joint's three
Euler channels move together) it uses only to choose that filter's width.
This module adds the other joints' word: per take, a ridge regression of each
channel on the other channels smoothed (Gaussians of :data:`SIGMA_S` and twice
that) and on its own samples either side (the same Gaussian with its centre
tap removed), fitted on the frames where the channel is observed.

The prediction never reads the channel's own sample at the frame it predicts
(a *blind spot*: Batson and Royer 2019, "Noise2Self", a J-invariant
function; the coefficients, fitted over the take, see it as one frame of
many). Noise that is independent from channel to channel and frame to
frame is then not in the inputs of the sample it corrupts, so a regression
fitted on the noisy take itself estimates the clean channel (its target's
noise averages out), and no clean motion is needed.
:func:`mocapkit.cleaning.deep.prior.conditional_fill` reads the observed
channels around a gap as a weighted average of this prediction and the
channels smoothed (by the EBF at low rates, else a Gaussian): at most
:data:`WEIGHT`, scaled per channel by :func:`noise_share`, the share of the
prediction's residual that white noise explains, so a clean take is read
about as it was.

Units: channels in degrees (unwrapped), frames first, (F, C).
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.ndimage import convolve1d, gaussian_filter1d

from .channels import lerp_fill
from .networks import observed_second_differences

__all__ = ["SIGMA_S", "RIDGE", "WEIGHT", "MIN_SECONDS", "blind_kernel", "standardised_inputs", "cross_channel_prediction",
           "noise_share"]

SIGMA_S = 0.058
"""Seconds: the std of the Gaussian that smooths the regression's inputs (Mall's 58 ms baseline filter); the
other channels enter also at twice that width."""

RIDGE = 0.6
"""Ridge weight per fitted frame on the standardised inputs. Chosen with :data:`WEIGHT` on the Bandai Namco
validation styles (1-4 s whole-joint gaps at 0.5 noise: 0.1-1.5 per frame, or a fixed 30-300, all within 0.7 %)."""

WEIGHT = 0.7
"""The prediction's largest weight in the gap prior's reading (0.5 and 0.7 within 0.3 % on the validation
styles and 0.3 % apart on the Acclaim validation actor, 0.7 the better on both; 1.0 worse)."""

MIN_SECONDS = 1.0
"""A take needs this many seconds of complete frames to be predicted (the ridge keeps the fit steady on fewer
frames than inputs)."""


def blind_kernel(sigma: float) -> np.ndarray:
    """The normalised Gaussian taps (2 h + 1,), ``h = ceil(4 sigma)``, of std ``sigma`` frames with the centre tap 0.

    A width under half a frame is taken as half a frame (the two neighbours then carry almost all the weight;
    narrower, their taps would underflow to 0)."""
    sigma = max(float(sigma), 0.5)
    h = int(np.ceil(4.0 * sigma))
    t = np.arange(-h, h + 1, dtype=np.float64)
    k = np.exp(-0.5 * (t / sigma) ** 2)
    k[h] = 0.0
    return k / k.sum()


def standardised_inputs(xf: np.ndarray, sigma: float) -> np.ndarray:
    """(F, 3 C) the regression's inputs of complete channels ``xf`` (F, C) degrees: the channels smoothed by a
    Gaussian of std ``sigma`` frames, by one of ``2 sigma``, and by :func:`blind_kernel` (``sigma``), each column
    standardised over the take (mean 0, std 1; a column constant over the take is 0).

    Written into one array and standardised in place: the three smoothed parts, their concatenation, the centred
    inputs and the scaled ones were four arrays of a long take's size (49 MB each on an 18-minute 30 fps Bandai
    Namco session of 63 channels), now one; the same numbers, bit for bit, as
    ``(Z - Z.mean(axis=0)) / Z.std(axis=0)`` of the concatenated parts."""
    F, C = xf.shape
    Z = np.empty((F, 3 * C))
    gaussian_filter1d(xf, sigma, axis=0, mode="nearest", output=Z[:, :C])
    gaussian_filter1d(xf, 2.0 * sigma, axis=0, mode="nearest", output=Z[:, C:2 * C])
    convolve1d(xf, blind_kernel(sigma), axis=0, mode="nearest", output=Z[:, 2 * C:])
    sd = Z.std(axis=0)
    sd[sd < 1e-9] = np.inf  # an input constant over the take carries nothing
    Z -= Z.mean(axis=0)
    Z /= sd
    return Z


def cross_channel_prediction(values: np.ndarray, fps: float, ridge: float = RIDGE,
                             sigma_s: float = SIGMA_S) -> np.ndarray | None:
    """Each channel of ``values`` (F, C) predicted from the others and its own neighbouring samples, or None.

    NaN entries are missing: they are linearly bridged for the inputs, and
    each channel's regression is fitted on the frames where it is observed.
    Returns (F, C) degrees, the prediction on every frame (a channel that does
    not move where it is observed is returned as it is, NaN where missing), or
    None when the take has less than :data:`MIN_SECONDS` of complete frames
    (too short to fit on). ``fps``: the channels' rate.
    """
    x = np.asarray(values, dtype=np.float64)
    if x.ndim != 2:
        raise ValueError(f"values: expected (F, C) channels, got {x.shape}")
    F, C = x.shape
    miss = np.isnan(x)
    if C < 2 or int((~miss.any(axis=1)).sum()) < MIN_SECONDS * float(fps):
        return None
    Z = standardised_inputs(lerp_fill(x), sigma_s * float(fps))
    G_all, S_all = Z.T @ Z, Z.sum(axis=0)
    with warnings.catch_warnings():  # a channel with no observed sample has no mean: it is not predicted
        warnings.simplefilter("ignore", RuntimeWarning)
        x_mean, x_sd = np.nanmean(x, axis=0), np.nanstd(x, axis=0)
    rhs = Z.T @ np.where(miss, 0.0, x - x_mean)  # each channel's inputs times its centred target, observed frames
    B = np.zeros((3 * C, C))  # every channel's coefficients on all inputs (0 on its own and the blind-spot others')
    offset = np.zeros(C)
    eye = np.eye(2 * C - 1)
    patterns: dict = {}  # channels observed on the same frames share one Gram matrix
    for c in range(C):
        patterns.setdefault(miss[:, c].tobytes(), []).append(c)
    for chans in patterns.values():
        gone = miss[:, chans[0]]
        n = int((~gone).sum())
        if n < 2:  # nothing to fit on: returned as it is
            continue
        Zm = Z[gone]
        S = S_all - Zm.sum(axis=0)  # the inputs' sums and centred Gram over the frames these channels are observed
        G = G_all - Zm.T @ Zm - np.outer(S, S) / n
        for c in chans:
            if not x_sd[c] > 1e-9:  # a channel that does not move is returned as it is
                continue
            others = np.delete(np.arange(C), c)
            idx = np.concatenate([others, C + others, [2 * C + c]])
            B[idx, c] = np.linalg.solve(G[np.ix_(idx, idx)] + ridge * n * eye, rhs[idx, c])
            offset[c] = x_mean[c] - S[idx] @ B[idx, c] / n
    pred = Z @ B
    del Z
    pred += offset
    moving = B.any(axis=0)
    return np.where(moving, pred, x)


def noise_share(values: np.ndarray, prediction: np.ndarray) -> np.ndarray:
    """Per channel (C,), the share of the prediction's residual that white noise explains, in [0, 1].

    The residual ``x - prediction`` over the observed frames has the variance
    of the noise plus the prediction's own error; the noise variance is
    estimated from the channel's second differences (white noise of std ``s``
    gives them variance ``6 s^2``; a robust median estimate). Their ratio is the
    weight the prediction earns against the sample it never read (the two
    estimates' inverse variances): small on a clean take, where the
    prediction's own error is most of its residual (at 30 fps a smooth
    motion's second differences are not all noise, so not 0).
    """
    x = np.asarray(values, dtype=np.float64)
    d2, valid = observed_second_differences(x, ~np.isnan(x))
    C = x.shape[1]
    out = np.zeros(C)
    for c in range(C):
        d = d2[valid[:, c], c]
        r = x[:, c] - prediction[:, c]
        r = r[np.isfinite(r)]
        if len(d) < 3 or len(r) < 3:
            continue
        noise = (1.4826 * np.median(np.abs(d))) ** 2 / 6.0
        resid = float(np.mean(r * r))
        out[c] = min(noise / resid, 1.0) if resid > 0 else 0.0
    return out
