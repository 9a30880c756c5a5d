"""Long gaps filled from the take's own motion words (Aristidou et al. 2018, section 4), blended with a fill given.

A benchmark method of ``deep_gapfill.py`` (its ``words+ebf`` and ``prior_words+ebf`` rows), not part of the
shipped fill: on the held-out clips it does not beat the gap prior alone (docs/models.md).

Human motion repeats within a take: a walk's steps, a squat's repetitions. Aristidou et al. (2018) compare each
*motion word* (the rotations of a group of joints over a short window around a frame) with the other words of the
same take and replace a broken joint's values at a frame "with corresponding values taken from the median of the
KNN set of the word around this frame". Here the word of a frame ``t`` is the vector of the channels observed
around a gap event at the gap prior's frame offsets (:func:`mocapkit.cleaning.deep.prior.lag_frames`: 0, +-8,
16, 32 frames at 120 fps, +-0.27 s), each channel over its standard deviation in the take (+1 degree), read through
the 58 ms Gaussian (:data:`mocapkit.cleaning.deep.prior.SMOOTH_S`: the motion, not the capture noise). Every frame
of a long gap event (the channels missing over the same frames: a whole joint lost together is one event), and the
observed frames within the lags' reach either side, looks up its :data:`K` nearest words (Euclidean) among the
frames where the event's channels are observed; its missing channels are the median of theirs, smoothed by the
same Gaussian, and offset by a linear ramp between the mean offsets to the observed samples' reading over those
frames either side, so the fill meets the take at the gap's ends. Aristidou's word distance is a DTW; candidate
words at 0.7-1.4 times the lags' spacing (a repetition performed faster or slower) changed the fill's error by
under 0.5 % on the validation clips, so one speed is compared.

Each event's fill is ``(1 - w) given + w words`` with ``w = exp(-(d / d0)^2)``, ``d`` the RMS distance (standard
deviations per word entry) of the gap frames' nearest words: a close repetition weighs, a far one leaves the
given fill (the gap prior's conditional mean). Shapes frames-first: (F, C) channels in degrees (:mod:`mocapkit.
cleaning.deep.channels`).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

from mocapkit.cleaning.deep.channels import lerp_fill
from mocapkit.cleaning.deep.prior import SMOOTH_S, lag_frames, lagged
from mocapkit.cleaning.runs import column_runs

K = 4
"""Nearest words each frame reads (chosen on the validation clips among 4, 8 and 16; Aristidou et al. take the
median of the KNN set)."""

D0 = 0.5
"""RMS word distance (standard deviations per entry) at which the words weigh ``exp(-1)`` against the given fill;
chosen on the Bandai Namco validation styles among 0.1-1.2 (on the HDM05 validation actor no value helps)."""

MIN_S = 0.5
"""Seconds: the shortest gap event filled from the take's words (a shorter one keeps the given fill)."""


def gap_events(miss: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    """``{(start, end): channels (k,) int}`` of (F, C) bool ``miss``: the channels missing over exactly the frames
    ``start:end`` (a joint lost together is one event), in time order."""
    col, s, e = column_runs(miss)
    events: dict[tuple[int, int], list[int]] = {}
    for c, a, b in zip(col.tolist(), s.tolist(), e.tolist()):
        events.setdefault((a, b), []).append(c)
    return {k: np.asarray(v) for k, v in sorted(events.items())}


def word_fill(reading: np.ndarray, miss: np.ndarray, s: int, e: int, chans: np.ndarray, fps: float,
              k: int = K) -> tuple[np.ndarray, float] | None:
    """((e - s, len(chans)) degrees, RMS word distance) of one gap event from the take's nearest words, or None.

    ``reading`` (F, C) degrees: the take as read (58 ms Gaussian, gaps bridged); ``miss`` (F, C) bool. The words
    read the channels observed over the event's frames and twice the lags' reach around them; the candidates are
    the frames where every one of ``chans`` is observed. None: no channel to compare on, or ``k`` candidates or
    fewer.
    """
    F = len(reading)
    lags = lag_frames(fps)
    reach = int(np.abs(lags).max())
    a0, a1 = max(0, s - reach), min(F, e + reach)  # the queries: the gap and the observed frames either side
    read = np.flatnonzero(~miss[max(0, a0 - reach):min(F, a1 + reach)].any(axis=0))
    cand = np.flatnonzero(~miss[:, chans].any(axis=1))
    if len(read) == 0 or len(cand) <= k:
        return None
    words = lagged(reading[:, read] / (reading[:, read].std(axis=0) + 1.0), lags)  # (F, L * R)
    q, w = words[a0:a1], words[cand]
    d2 = np.sum(q * q, axis=1)[:, None] + np.sum(w * w, axis=1)[None, :] - 2.0 * (q @ w.T)  # (Q, N)
    near = np.argpartition(d2, k, axis=1)[:, :k]
    pred = np.median(reading[cand[near]][:, :, chans], axis=1)  # (Q, len(chans)): each frame's KNN median
    pred = gaussian_filter1d(pred, SMOOTH_S * fps, axis=0, mode="nearest")
    off_l = (reading[a0:s, chans] - pred[:s - a0]).mean(axis=0) if s > a0 else None
    off_r = (reading[e:a1, chans] - pred[e - a0:]).mean(axis=0) if a1 > e else None
    if off_l is None and off_r is None:
        off = np.zeros(len(chans))
    elif off_l is None or off_r is None:
        off = off_l if off_r is None else off_r
    else:
        r = (np.arange(s, e) - (s - 1))[:, None] / (e - (s - 1))
        off = (1.0 - r) * off_l + r * off_r
    dist = np.take_along_axis(d2, near, axis=1)[s - a0:e - a0]
    return pred[s - a0:e - a0] + off, float(np.sqrt(max(0.0, float(dist.mean())) / words.shape[1]))


def self_similar_fill(filled: np.ndarray, miss: np.ndarray, fps: float, d0: float | None = D0, k: int = K,
                      min_s: float = MIN_S) -> np.ndarray:
    """(F, C) ``filled`` with each gap event of at least ``min_s`` seconds blended towards the take's own words.

    ``filled`` (F, C) degrees: a complete fill (the gap prior's), observed entries as measured; ``miss`` (F, C)
    bool: the entries it filled. ``d0``: the word distance at which the words weigh ``exp(-1)`` (:data:`D0`);
    None: the words alone (weight 1). Events with nothing to compare on keep ``filled``; observed entries are
    returned bit-identical.
    """
    out = np.array(filled, dtype=np.float64, copy=True)
    miss = np.asarray(miss, dtype=bool)
    if not miss.any():
        return out
    reading = gaussian_filter1d(lerp_fill(np.where(miss, np.nan, out)), SMOOTH_S * fps, axis=0, mode="nearest")
    for (s, e), chans in gap_events(miss).items():
        got = word_fill(reading, miss, s, e, chans, fps, k) if e - s >= min_s * fps else None
        if got is None:
            continue
        words, d = got
        w = 1.0 if d0 is None else float(np.exp(-(d / d0) ** 2))
        out[s:e, chans] = (1.0 - w) * out[s:e, chans] + w * words
    return out
