"""A Gaussian prior of the joint-angle channels around a frame, and gap filling by its conditional mean.

Mall et al. 2017 (section 4.2, Fig. 10) fill long gaps with the EBD because "the
remarkably accurate reconstructions can be attributed to learning correlations of the
missing joint channel with all other joint channels in the skeleton, as well as temporal
coherence". The simplest learnt model of exactly those correlations is a Gaussian over the
vector of every channel at a few time offsets, ``v(t) = [x(t + l) for l in lags]`` (the
dimensionality-reduction fills Mall et al. cite, Liu and McMillan 2006, Park and Hodgins
2006, are its low-rank cases). Given the channels observed around a gap, the missing
channel's expected value is the Gaussian's conditional mean,

    E[x_m | v_o] = mu_m + S_mo (S_oo + lambda I)^-1 (v_o - mu_o),

in standardised units (each entry of ``v`` minus its training mean, over its training
standard deviation plus one degree), ``lambda`` a ridge that keeps the solve stable and
stands for the noise of the observed channels. The fill then meets the observed samples at
both ends of the gap by a linear ramp of the prediction's offsets there, so a gap closes
without a step (with nothing to condition on, that ramp is the linear fill).

Before it conditions, the take updates the prior: the mean and covariance of its own complete
frames are pooled with the prior's, the prior counting as :data:`PRIOR_S` seconds of frames. A
performer's own way of moving, and a motion the take repeats (the self-similarity Aristidou et
al. 2018 build on), then outweigh the training clips' average.

A :class:`GapPrior` belongs to an EBD model (fitted on the same training clips, saved in
the same file, :func:`fit_gap_prior`); :func:`~mocapkit.cleaning.deep.inference.fill_channels`
uses it where it validated better than the network (see that function).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..markers.gaps import gap_runs
from .channels import lerp_fill

__all__ = ["GapPrior", "fit_gap_prior", "conditional_fill", "lagged", "LAG_S", "RIDGE", "PRIOR_S"]

SMOOTH_S = 0.058
"""Std (s) of the Gaussian that smooths the observed channels before they are read as evidence (Mall's 58 ms
baseline filter): the regression reads the motion, not the capture noise. The filled values are the
prediction, offset to meet these smoothed samples on either side of the gap."""


@dataclass(frozen=True)
class GapPrior:
    """Mean and covariance of lagged channel vectors, standardised.

    lags : (L,) int frame offsets at the model's frame rate, 0 among them;
    mean, scale : (C * L,) the training mean and standard deviation (+1 degree) of each
    entry of ``v(t)`` (lag-major: entry ``l * C + c`` is channel ``c`` at ``lags[l]``);
    cov : (C * L, C * L) covariance of the standardised entries; ridge : ``lambda``
    added to the observed block before solving; frames : training frames used.
    """

    lags: np.ndarray
    mean: np.ndarray
    scale: np.ndarray
    cov: np.ndarray
    ridge: float
    frames: int

    @property
    def num_channels(self) -> int:
        return len(self.mean) // len(self.lags)

    @cached_property
    def precision(self) -> np.ndarray:
        """``(cov + ridge I)^-1``: with it the conditional mean of the entries ``u`` not observed is
        ``-P_uu^-1 P_uo v_o`` (the same as ``S_uo (S_oo + ridge I)^-1 v_o``), a solve of the few unobserved
        entries instead of the many observed ones."""
        return _precision(self.cov, self.ridge)

    def to_arrays(self) -> dict:
        """The prior as plain arrays (for a model file)."""
        return {"lags": np.asarray(self.lags, dtype=np.int64), "mean": self.mean, "scale": self.scale,
                "cov": self.cov, "ridge": np.float64(self.ridge), "frames": np.int64(self.frames)}

    @classmethod
    def from_arrays(cls, d: dict) -> "GapPrior":
        lags = np.asarray(d["lags"], dtype=np.int64).reshape(-1)
        mean = np.asarray(d["mean"], dtype=np.float64).reshape(-1)
        scale = np.asarray(d["scale"], dtype=np.float64).reshape(-1)
        cov = np.asarray(d["cov"], dtype=np.float64)
        n = len(mean)
        if (0 not in lags.tolist() or n % len(lags) or scale.shape != (n,) or cov.shape != (n, n)
                or not np.all(scale > 0) or not np.all(np.isfinite(cov))):
            raise ValueError("inconsistent gap prior arrays")
        return cls(lags, mean, scale, cov, float(d["ridge"]), int(d["frames"]))


def lagged(x: np.ndarray, lags) -> np.ndarray:
    """(F, C) channels -> (F, C * L) vectors ``[x(t + l) for l in lags]``, frames clamped at the ends."""
    F = len(x)
    t = np.arange(F)
    return np.concatenate([x[np.clip(t + int(l), 0, max(F - 1, 0))] for l in lags], axis=1)


LAG_S = 0.25
"""The prior's time offsets: the channels a quarter second before and after each frame, and at it (chosen on
held-out actors among 0.125-0.5 s, which differed by a few per cent)."""

RIDGE = 0.1
"""``lambda``, in units of the standardised entries' variance (chosen as :data:`LAG_S`)."""

PRIOR_S = 1.0
"""How many seconds of the take's own frames the prior counts as when the take's complete frames update it
(:func:`conditional_fill`; chosen on the validation actor and styles among 0.5-10 s, 0.5-2 s within a few
per cent)."""


def fit_gap_prior(takes, fps: float, lag_s: float = LAG_S, ridge: float = RIDGE) -> GapPrior:
    """Fit a :class:`GapPrior` on clean takes' channels (list of (F, C) arrays in degrees at ``fps``).

    Lags are ``-lag_s, 0, +lag_s`` seconds rounded to frames; one frame in
    ``round(fps / 30)`` enters (neighbouring frames say little more).
    """
    lag = max(1, int(round(lag_s * fps)))
    lags = np.array([-lag, 0, lag], dtype=np.int64)
    stride = max(1, int(round(fps / 30.0)))
    v = [lagged(np.asarray(x, dtype=np.float64), lags)[::stride] for x in takes if len(x)]
    v = np.concatenate(v) if v else np.zeros((0, 0))
    if len(v) < 2 or not np.all(np.isfinite(v)):
        raise ValueError("the gap prior needs finite training channels, two frames at least")
    mean = v.mean(axis=0)
    scale = v.std(axis=0) + 1.0
    z = (v - mean) / scale
    cov = z.T @ z / len(z)
    return GapPrior(lags, mean, scale, cov, float(ridge), len(v))


def _precision(cov: np.ndarray, ridge: float) -> np.ndarray:
    """``(cov + ridge I)^-1``, the precision of the standardised entries (observed ones read with ``ridge``)."""
    return np.linalg.inv(cov + ridge * np.eye(len(cov)))


def _take_update(z: np.ndarray, miss: np.ndarray, prior: GapPrior, n0: float):
    """(mean shift (D,), covariance (D, D) or None): the prior's standardised mean (0) and covariance pooled with
    those of the take's complete rows of ``z`` (no channel missing within the lags' reach), ``n0`` frames' worth
    of prior against the rows' count; (0, None) when fewer than 10 rows or ``n0`` is infinite."""
    rows = ~(lagged(miss.astype(np.float64), prior.lags) > 0).any(axis=1)
    n = int(rows.sum())
    if n < 10 or not np.isfinite(n0):
        return np.zeros(z.shape[1]), None
    zo = z[rows]
    m = zo.mean(axis=0)
    d = zo - m
    w = n / (n + max(float(n0), 0.0))
    cov = (1.0 - w) * prior.cov + w * (d.T @ d / n) + w * (1.0 - w) * np.outer(m, m)
    return w * m, cov


def conditional_fill(values: np.ndarray, prior: GapPrior, fps: float, prior_s: float = PRIOR_S,
                     smoothed: np.ndarray | None = None) -> np.ndarray:
    """Fill the NaN entries of (F, C) channels by the prior's conditional mean; observed entries returned as is.

    The take teaches the prior first: its own complete frames (no channel
    missing within the lags' reach) give a mean and covariance, blended with
    the prior's as ``n`` frames against ``prior_s`` seconds' worth
    (``w = n / (n + prior_s * fps)``; the blend is the pooled mean and second
    moment of the two). A performer's own relations between joints, and a
    motion that repeats in the take (the self-similarity of Aristidou et al.
    2018), then outweigh the training clips' average; a short take or one
    mostly missing keeps the prior. ``prior_s=inf`` uses the prior alone.

    Each gap event (the channels missing over the same frames: a whole joint
    lost together is one event) is predicted from the channels observed over
    the gap and ``max |lag|`` frames around it; a channel missing anywhere
    there is not read. The prediction is then offset to meet the observed
    (smoothed) samples on either side of the gap, linearly across it; at a take's
    end, the one observed side's offset holds. ``fps`` is the channels' rate
    (the prior's lags are frames at that rate).

    ``smoothed``: the channels as the regression reads them, (F, C), NaN
    where missing (linearly bridged here): the observed samples denoised,
    e.g. by the EBF (:func:`~mocapkit.cleaning.deep.inference.fill_channels`
    passes it at low rates, where the fixed Gaussian leaves much noise: on
    held-out Bandai Namco styles at 30 fps, 2.8 % less gap error). Default:
    the 58 ms Gaussian of :data:`SMOOTH_S`.
    """
    x = np.asarray(values, dtype=np.float64)
    F, C = x.shape
    if C != prior.num_channels:
        raise ValueError(f"the gap prior has {prior.num_channels} channels, the values {C}")
    miss = np.isnan(x)
    out = x.copy()
    if not miss.any():
        return out
    if smoothed is None:
        base = gaussian_filter1d(lerp_fill(x), SMOOTH_S * fps, axis=0, mode="nearest")
    else:
        read = np.asarray(smoothed, dtype=np.float64)
        if read.shape != x.shape or not np.isfinite(read[~miss]).all():
            raise ValueError(f"smoothed must be (F, C) = {x.shape} channels, finite where observed; got {read.shape}")
        base = lerp_fill(np.where(miss, np.nan, read))
    z = (lagged(base, prior.lags) - prior.mean) / prior.scale
    reach = int(np.abs(prior.lags).max())
    L = len(prior.lags)
    lag0 = int(np.flatnonzero(prior.lags == 0)[0])
    events: dict[tuple[int, int], list[int]] = {}
    for c in np.flatnonzero(miss.any(axis=0)):
        for s, e in zip(*gap_runs(miss[:, c])):
            events.setdefault((int(s), int(e)), []).append(int(c))
    solved: dict[bytes, np.ndarray] = {}
    shift, cov = _take_update(z, miss, prior, prior_s * fps)
    z = z - shift
    mean = prior.mean + shift * prior.scale
    prec = prior.precision if cov is None else _precision(cov, prior.ridge)
    for (s, e), chans in sorted(events.items()):
        lo, hi = max(0, s - 1 - reach), min(F, e + 1 + reach)
        read = ~miss[lo:hi].any(axis=0)
        keep = np.tile(read, L)
        tgt = np.asarray(chans) + lag0 * C
        key = keep.tobytes() + np.asarray(chans, dtype=np.int64).tobytes()
        w = solved.get(key)
        if w is None:  # (kept entries, targets): S_ok (S_oo + ridge I)^-1 through the precision's unobserved block
            unseen = np.flatnonzero(~keep)
            rows = np.searchsorted(unseen, tgt)
            w = -np.linalg.solve(prec[np.ix_(unseen, unseen)], prec[np.ix_(unseen, np.flatnonzero(keep))])[rows].T
            solved[key] = w
        f0, f1 = max(s - 1, 0), min(e + 1, F)  # the gap and its observed neighbours
        pred = (z[f0:f1][:, keep] @ w) * prior.scale[tgt] + mean[tgt]
        gap = pred[s - f0 : s - f0 + (e - s)]
        left = base[s - 1, chans] - pred[0] if s > 0 else None
        right = base[e, chans] - pred[-1] if e < F else None
        if left is None and right is None:
            off = np.zeros((e - s, len(chans)))
        elif left is None or right is None:
            off = np.broadcast_to(left if right is None else right, (e - s, len(chans)))
        else:
            r = (np.arange(s, e) - (s - 1))[:, None] / (e - (s - 1))
            off = (1.0 - r) * left + r * right
        out[s:e, chans] = gap + off
    return out
