"""Find and undo swapped labels: two markers that trade trajectories for a while.

When two markers pass close, the labelling of an optical system may give
each the other's name (MotionBuilder's "swap with marker" and Vicon's
"exchange labels" fix it by hand). Each of the two trajectories then jumps
at the start of the swap by the distance between the markers, and jumps
back at its end. :func:`undo_swaps` walks the take once: at every frame
where two or more markers jump (their sample is far from both the
constant-velocity prediction of the two frames before and the
constant-acceleration prediction of the three before), it tries exchanging
each pair of jumping markers from that frame on, and keeps the exchange
when it explains both jumps (each marker's new sample then meets one of its
predictions within the threshold, and the total miss is cut to under a
third). The constant-acceleration prediction keeps a fast, curving marker
(a golf club head at 108 Hz misses its constant-velocity prediction by
20-30 mm in every frame of the downswing) from hiding a swap. How far apart
the two markers are does not matter: the test asks that each lands where
the other was going, which two unrelated jumps almost never do. An exchange
that starts a swap is undone by the one that ends it, so the corrected
trajectories are the recorded samples, re-labelled: the values stay
bit-identical.

Positions are (F, M, 3), frames first, NaN for unseen samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Swap", "undo_swaps"]


@dataclass(frozen=True)
class Swap:
    """Markers ``a`` and ``b`` exchanged their labels for frames ``start <= f < end``; ``distance`` between them at ``start`` (capture unit)."""

    a: int
    b: int
    start: int
    end: int
    distance: float


def _predictions(y: np.ndarray, t: int) -> np.ndarray:
    """(P, M, 3) predictions of frame t: constant velocity from t-2, t-1 and, where t >= 3, constant acceleration from t-3..t-1."""
    cv = 2.0 * y[t - 1] - y[t - 2]
    if t < 3:
        return cv[None]
    return np.stack([cv, 3.0 * y[t - 1] - 3.0 * y[t - 2] + y[t - 3]])


def _miss(pred: np.ndarray, samples: np.ndarray) -> np.ndarray:
    """(M,) distance of ``samples`` (M, 3) from the nearest of the predictions ``pred`` (P, M, 3).

    A prediction that needs an unseen frame is skipped; NaN where none can be made or the sample is unseen.
    """
    return np.fmin.reduce(np.linalg.norm(samples[None] - pred, axis=-1), axis=0)


def undo_swaps(positions: np.ndarray, unit_mm: float = 1.0, *,
               threshold_mm: float = 15.0) -> tuple[np.ndarray, list[Swap]]:
    """Re-label swapped samples.

    Parameters
    ----------
    positions : float array (F, M, 3)
        Marker positions, NaN where unseen.
    unit_mm : float
        Millimetres per unit of ``positions``.
    threshold_mm : float
        A sample "jumps" when it is this far from both its constant-velocity
        and its constant-acceleration prediction.

    Returns
    -------
    corrected : float array (F, M, 3)
        The samples with swapped labels exchanged back (the same values, re-labelled).
    swaps : list of Swap
        One per swapped interval (a swap that never ends runs to the last frame).
    """
    x = np.asarray(positions, dtype=np.float64)
    f = x.shape[0]
    y = x.copy()
    if f < 3:
        return y, []
    thr = threshold_mm / unit_mm
    with np.errstate(invalid="ignore"):
        raw = np.linalg.norm(x[2:] - (2.0 * x[1:-1] - x[:-2]), axis=-1)  # (F-2, M)
        acc = np.full_like(raw, np.nan)
        acc[1:] = np.linalg.norm(x[3:] - (3.0 * x[2:-1] - 3.0 * x[1:-2] + x[:-3]), axis=-1)
        jumping = np.nan_to_num(np.fmin(raw, acc), nan=0.0) > thr
    frames = np.flatnonzero(jumping.sum(axis=1) >= 2) + 2
    open_swaps: dict[tuple[int, int], tuple[int, float]] = {}
    swaps: list[Swap] = []
    for t in frames:
        pred = _predictions(y, t)
        miss = _miss(pred, y[t])
        jump = np.flatnonzero(np.nan_to_num(miss, nan=0.0) > thr)
        if jump.size < 2:
            continue
        pairs = []
        for i in range(jump.size):
            for j in range(i + 1, jump.size):
                a, b = int(jump[i]), int(jump[j])
                ma = _miss(pred[:, [a]], y[t, [b]])[0]
                mb = _miss(pred[:, [b]], y[t, [a]])[0]
                if ma <= thr and mb <= thr and ma + mb < (miss[a] + miss[b]) / 3.0:
                    pairs.append((ma + mb, a, b))
        used: set[int] = set()
        for _, a, b in sorted(pairs):
            if a in used or b in used:
                continue
            used.update((a, b))
            y[t:, [a, b]] = y[t:, [b, a]]
            key = (a, b)
            if key in open_swaps:
                s, dist = open_swaps.pop(key)
                swaps.append(Swap(a, b, s, int(t), dist))
            else:
                open_swaps[key] = (int(t), float(np.linalg.norm(x[t, a] - x[t, b])))
    for (a, b), (s, dist) in open_swaps.items():
        swaps.append(Swap(a, b, s, f, dist))
    swaps.sort(key=lambda s: (s.start, s.a, s.b))
    return y, swaps
