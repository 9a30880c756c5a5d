"""A gap fill's expected error, measured on stretches that resemble the gap.

Tits, Tilmanne and Dutoit (2018, PLoS ONE 13(7): e0199744) weight their fill
models by their error on gaps cut into the marker's *observed* data; mocapkit
does the same (:mod:`mocapkit.cleaning.markers.gaps`: two stretches of the
gap's length next to it rank and weight the models). Those two stretches
rank the models well, but as a statement of how far the written fill is off
they can be badly optimistic: they need not resemble the gap. A wrist hidden
for a quarter second during a fast arm swing, with the other wrist marker and
the elbow hidden too, was validated on two slow stretches with all its
neighbours seen: 5.6 mm expected, 55 mm RMS off the truth (HDM05
HDM_bd_05-01_01_120, seed 3, RWRB 3638-3669).

This module measures the expected error of the fill that is written (the
weighted average of the best models, with the weights the ranking gave) so
that it resembles the gap:

- on up to :data:`SPANS` stretches of the gap's length near it (not two),
  each with the gap's missing pattern copied onto it (:func:`transplant`):
  the markers hidden together with the gap's marker are hidden there too, so
  a model cannot lean on a neighbour the real gap does not have;
- widened by how much further the averaged models part inside the gap than
  on the stretches (:func:`disagreement`): each model filled the stretches
  well, yet where they disagree by centimetres in the gap the gap holds
  motion the stretches do not (RWRB above: the models part 3 to 87 mm off
  the truth; the estimate becomes 49 mm). Never narrowed: a gap where they
  agree keeps its stretches' figure;
- widened where the evidence is thin (:func:`thin_factor`): fewer stretches
  than :data:`SPANS`, or stretches shorter than the gap.

Calibration (gaps cut by ``mocapkit corrupt --kind gaps``, the fill measured
against the untouched capture): about 1 fill in 40 is more than 2x off its
estimate (the guide's markers page gives the figures).

Where no stretch could be cut the error stays unknown (NaN): the fill is
*unvalidated*, said so and counted apart, and a limit the user gives
(``--max-fill-error``) rejects it.

Positions are (F, M, 3), frames first, in the capture's unit; NaN is unseen.
Errors are RMS 3-D distances in the capture's unit.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = ["SPANS", "gap_pattern", "transplant", "average", "disagreement", "span_errors", "thin_factor",
           "expected_error"]

SPANS = 4
"""How many stretches of the gap's length the expected error is measured on (the ranking uses 2)."""

def gap_pattern(pos: np.ndarray, m: int, a: int, b: int) -> np.ndarray:
    """(b - a, M) bool: which markers are missing in each frame of marker m's gap a..b-1 (m's own column False)."""
    out = np.any(np.isnan(pos[a:b]), axis=-1)
    out[:, m] = False
    return out


def transplant(pos: np.ndarray, pattern: np.ndarray, s: int, e: int, copy: bool = True) -> np.ndarray:
    """``pos`` (a copy, or itself without ``copy``) with the gap's missing ``pattern`` (n, M) copied onto frames s..e-1.

    A stretch shorter than the gap gets the pattern's rows at evenly spaced
    places (its start and end match the gap's start and end).
    """
    out = pos.copy() if copy else pos
    n, length = pattern.shape[0], e - s
    rows = np.arange(length) * n // max(length, 1) if length != n else np.arange(n)
    sub = out[s:e]
    sub[pattern[rows]] = np.nan
    return out


def average(fills, weights) -> np.ndarray | None:
    """The weighted average (n, 3) of the ``fills`` (each (n, 3) or None; weights renormalised over the others)."""
    have = [k for k, est in enumerate(fills) if est is not None]
    if not have:
        return None
    w = np.asarray(weights, dtype=np.float64)[have]
    return np.tensordot(w / w.sum(), np.stack([fills[k] for k in have]), axes=1)


def disagreement(fills, weights) -> float:
    """How far the averaged models' ``fills`` lie from their average: the weighted RMS 3-D distance (0 for one).

    Models that each fill the marker's seen stretches well but part ways
    inside the gap say that the gap holds motion the stretches do not (a
    wrist turning while its neighbours are hidden): at least that much of
    the average is a guess.
    """
    have = [k for k, est in enumerate(fills) if est is not None]
    avg = average(fills, weights)
    if avg is None or len(have) < 2:
        return 0.0
    w = np.asarray(weights, dtype=np.float64)[have]
    d2 = [np.mean(np.sum((fills[k] - avg) ** 2, axis=-1)) for k in have]
    return float(np.sqrt(np.dot(w / w.sum(), d2)))


def span_errors(pos: np.ndarray, m: int, a: int, b: int, spans, weights,
                fill: Callable) -> list[tuple[int, int, float, float]]:
    """The written fill's RMS error and its models' :func:`disagreement` on each stretch of ``spans``.

    The gap's missing pattern is copied onto each stretch (:func:`transplant`).
    ``fill(pos, s, e)``: each averaged model's fill (e - s, 3) of frames
    s..e-1 of a take ``pos`` (None where one cannot fill them), averaged
    with ``weights`` as the gap's fill is. Returns (s, e, rms, disagreement)
    for the stretches it could fill.
    """
    pattern = gap_pattern(pos, m, a, b)
    out = []
    for s, e in spans:
        if pattern.any():
            kept = pos[s:e].copy()  # hidden in place and put back (bit for bit): no copy of the whole take per stretch
            try:
                transplant(pos, pattern, s, e, copy=False)
                got = fill(pos, s, e)
            finally:
                pos[s:e] = kept
        else:
            got = fill(pos, s, e)
        est = average(got, weights)
        if est is not None:
            rms = float(np.sqrt(np.mean(np.sum((est - pos[s:e, m]) ** 2, axis=-1))))
            out.append((s, e, rms, disagreement(got, weights)))
    return out


def thin_factor(spans, length: int, wanted: int = SPANS) -> float:
    """How much to widen an error measured on ``spans`` (s, e) for a gap of ``length`` frames: thin evidence.

    An RMS over k stretches scatters about the truth by roughly 1 / sqrt(2k)
    of itself; with fewer than ``wanted`` stretches the figure is widened by
    sqrt(wanted / k). A stretch shorter than the gap understates the error
    (a fill's error grows with the gap's length, about linearly for the
    interpolation in a moving frame), so the figure is scaled by the gap's
    length over the stretches' mean length. 1 for ``wanted`` full stretches.
    """
    if not spans:
        return 1.0
    k = len(spans)
    mean_len = float(np.mean([e - s for s, e in spans]))
    return float(np.sqrt(max(wanted, k) / k) * max(1.0, length / max(mean_len, 1.0)))


def expected_error(pos: np.ndarray, m: int, a: int, b: int, spans, fills, weights,
                   fill: Callable, least_ratio: float = 1.0) -> tuple[float, str, float]:
    """The expected RMS error of marker m's fill of a..b-1, and how it was widened, in words.

    ``spans``: stretches of the gap's length (or shorter) where m is seen;
    ``fills``, ``weights``: the averaged models' fills of the gap and their
    weights; ``fill``: the same models on other frames (:func:`span_errors`).
    The RMS error on the stretches, times :func:`thin_factor`, and times
    how much more the models disagree in the gap than on the stretches
    (their :func:`disagreement` ratio, where above 1): two doubts, both
    taken (on long one-ended gaps of CMU 85_02 the larger alone still fell
    short of a heel marker's real error). NaN and "" where no stretch
    could be filled: the fill is unvalidated.
    ``least_ratio``: the disagreement ratio to take at least (a single
    model tried after the average failed has no other model to part from:
    it gets the average's). Returns (expected error, words, the ratio used).
    """
    errs = span_errors(pos, m, a, b, spans, weights, fill)
    if not errs:
        return float("nan"), "", least_ratio
    used = [(s, e) for s, e, _, _ in errs]
    base = float(np.sqrt(np.mean([x ** 2 for _, _, x, _ in errs])))
    calm = float(np.sqrt(np.mean([x ** 2 for _, _, _, x in errs])))
    ratio = max(1.0, disagreement(fills, weights) / max(calm, 1e-9 * max(base, 1e-300))) if calm > 0 else 1.0
    ratio = max(ratio, least_ratio)
    thin = thin_factor(used, b - a)
    words = []
    if ratio > 1.0:
        words.append(f"x{ratio:.1f}: its models part {ratio:.1f} times as far in the gap as on seen stretches")
    if thin > 1.0:
        words.append(f"x{thin:.1f}: {len(used)} stretch{'es' if len(used) != 1 else ''} "
                     f"of {int(np.mean([e - s for s, e in used]))} frames to measure on")
    return base * ratio * thin, "; ".join(words), ratio
