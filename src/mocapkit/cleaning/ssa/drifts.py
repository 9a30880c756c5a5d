"""Smooth drifts: digressions with no break, flagged where the context repeats the motion (section 3.4).

Confirmation by a break (:func:`~mocapkit.cleaning.ssa.confirm_flags`) keeps the
detector from flagging motion the context has not seen, but it cannot see what
the movement digression map exists to show (Aristidou et al. 2018, section 3.4
and Figure 1): one joint that leaves the path its neighbour words take, smoothly,
and comes back, with no step anywhere (a slipping marker cluster, a drifting
inertial sensor, a solver easing into a wrong pose).

Where the context repeats the motion, such a digression can be told from
unseen motion by the rest of the body: the neighbour words match the other
joints closely (the context holds this motion), they agree among themselves on
the joint (their spread is small), and the joint alone is far from them. The
statistic, per cell ``(f, j)``:

- ``agreement``: the median, over the other analysed joints, of their angle
  from the mean motion texture at frame ``f`` (radians) -- how well the
  neighbours match the rest of the body (:func:`body_agreement`);
- ``consistency``: the joint's angle from the mean texture over the
  neighbours' spread at the cell and the capture noise, ``a / sqrt(s^2 +
  noise^2)`` (the ``"spread"`` z-score of :func:`detect`).

A run of cells that digress by more than the capture noise and holds no
break is a smooth drift when, for at least ``min_s`` seconds of it,
``agreement <= repeat_deg`` and ``consistency >= z_min``: the whole
excursion is flagged, down to where the joint is back among its
neighbours. Where the context does not repeat the motion (the rest of the
body digresses too) nothing is flagged here: a lone joint's
digression is then indistinguishable from motion the context lacks. For the
same reason :func:`~mocapkit.cleaning.ssa.detect` looks for smooth drifts only
against a context beyond the take itself: analysed alone, a take that raises
one arm once (a wave, a reach) shows exactly what a drift shows, the arm far
from neighbour words (the take's other moments) that match the rest of the
body. Nor on the pelvis or the root, whose rotation carries the path's heading
on rigs whose root stays on the floor.
"""

from __future__ import annotations

import numpy as np

__all__ = ["body_agreement", "smooth_drift_flags"]


def body_agreement(digression: np.ndarray, analysed: np.ndarray) -> np.ndarray:
    """(F, J) median angle from the mean motion texture of the *other* analysed joints at each frame.

    ``digression`` float (F, J) angles in radians (NaN where not analysed or
    not judged); ``analysed`` bool (J,). The value at ``(f, j)`` leaves joint
    ``j`` itself out, so a drifting joint does not lower its own evidence.
    NaN on joints not analysed, at frames where no other joint has a value,
    and everywhere when fewer than two joints are analysed.
    """
    d = np.asarray(digression, dtype=np.float64)
    analysed = np.asarray(analysed, dtype=bool)
    if d.ndim != 2 or analysed.shape != (d.shape[1],):
        raise ValueError(f"need digression (F, J) and analysed (J,), got {d.shape} and {analysed.shape}")
    out = np.full(d.shape, np.nan)
    cols = np.flatnonzero(analysed)
    if len(cols) < 2:
        return out
    sub = d[:, cols]
    for i, j in enumerate(cols):
        rest = np.delete(sub, i, axis=1)
        ok = np.isfinite(rest).any(axis=1)
        if ok.any():
            out[ok, j] = np.nanmedian(rest[ok], axis=1)
    return out


def smooth_drift_flags(
    jumps: np.ndarray,
    agreement: np.ndarray,
    consistency: np.ndarray,
    fps: float,
    repeat_deg: float = 5.0,
    z_min: float = 3.0,
    min_s: float = 0.25,
    margin_s: float = 0.05,
    extent: float = 0.5,
) -> np.ndarray:
    """(F, J) bool: the smooth drifts of a take (module docstring).

    ``jumps`` bool (F, J) the joints' own breaks; ``agreement`` radians and
    ``consistency`` (a ratio) float (F, J) from :func:`body_agreement` and
    :func:`detect` (NaN: no evidence, never flagged). Per joint, a run is a
    connected stretch of cells with ``consistency > extent``: the joint
    outside its neighbours' spread and the capture noise (``extent`` 1), the
    whole excursion down to where it is back among them. The run is flagged
    whole when no break lies within ``margin_s`` seconds of it (runs with a break are
    :func:`confirm_flags`' to judge) and at least ``min_s`` seconds of its
    cells have ``agreement <= repeat_deg`` (degrees: the context repeats the
    motion there) and ``consistency >= z_min`` (the neighbours agree the joint
    is elsewhere).
    """
    from scipy import ndimage

    jumps = np.asarray(jumps, dtype=bool)
    agreement = np.asarray(agreement, dtype=np.float64)
    consistency = np.asarray(consistency, dtype=np.float64)
    if not (jumps.ndim == 2 and jumps.shape == agreement.shape == consistency.shape):
        raise ValueError(
            f"jumps, agreement and consistency must be the same (F, J) shape, got "
            f"{jumps.shape}, {agreement.shape} and {consistency.shape}"
        )
    if not (margin_s >= 0 and min_s >= 0 and repeat_deg >= 0 and 0 < extent <= z_min and fps > 0):
        raise ValueError(f"need margin_s, min_s, repeat_deg >= 0, 0 < extent <= z_min and fps > 0, got "
                         f"{margin_s!r}, {min_s!r}, {repeat_deg!r}, {extent!r}, {z_min!r} and {fps!r}")
    with np.errstate(invalid="ignore"):
        low = consistency > extent
        strong = low & (agreement <= np.radians(repeat_deg)) & (consistency >= z_min)
    if not strong.any():
        return np.zeros(jumps.shape, dtype=bool)
    n = int(round(margin_s * fps))
    near = ndimage.binary_dilation(jumps, structure=np.ones((2 * n + 1, 1), dtype=bool)) if n > 0 else jumps
    along_time = np.array([[0, 1, 0], [0, 1, 0], [0, 1, 0]], dtype=bool)  # runs never join across joints
    labels, count = ndimage.label(low, structure=along_time)
    idx = np.arange(1, count + 1)
    broken = ndimage.maximum(near, labels, idx).astype(bool)
    evidence = ndimage.sum(strong, labels, idx)
    need = max(int(np.ceil(min_s * fps)), 1)
    keep = np.concatenate([[False], (~broken) & (evidence >= need)])
    return keep[labels]
