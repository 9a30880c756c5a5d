"""Plausibility guard: is a gap's fill something the take itself shows a marker can do?

A fill is a guess. Self-validation (:mod:`~mocapkit.cleaning.markers.gaps`)
measures how good the guess was on stretches where the marker is seen, but
those stretches can look nothing like the gap (a subject rolling on the floor
hides a foot in poses the rest of the take never shows, and a donor that
looked rigid in the frames it was seen with the marker is not), so a fill can
validate at 10 mm and still leave the body. This module checks the fill
itself, against what the rest of the take shows, before it is written:

- **speed**: no step between consecutive samples of the fill, nor between
  the last seen sample and the fill's first or its last and the next seen
  sample, longer than twice the take's 99.9th percentile one-frame step (of
  all markers, or of this marker when it is faster), or 1.5 times this
  marker's fastest seen step, plus 2 mm: a fill
  that jumps at its ends or teleports inside is not motion;
- **rigid neighbours**: at every filled frame, its distance to each of its
  ``neighbours`` most rigidly attached markers (those seen in that frame,
  and rigid: the pair's 1-99 % range over the take no wider than a quarter
  of its median distance, or 50 mm) within that range widened by twice the
  range's width (at least 50 mm) on each side (a gap can hide poses the rest
  of the take does not show): a shank marker 1.6 m from its heel is not on
  the shank;
- **the floor**: where the take's samples pile up against one side of
  one axis (at least 5 % of them within 30 mm of the take's extreme there,
  three times as many as at any other side: the floor a standing or lying
  subject touches, whatever the axis is called), no filled sample more
  than 20 mm beyond that extreme: markers rest on the floor, not under it;
- **the body**: its distance to the nearest marker seen in that frame no
  more than twice the largest such distance the take shows while the marker
  is seen (and at least that plus 150 mm): a fill metres from every seen
  marker is not on the subject.

The thresholds are deliberately wide: they are there to catch fills that
cannot be right, not to grade good ones. A fill that fails is not written
(:func:`~mocapkit.cleaning.markers.gaps.fill_gaps` tries its other models,
then leaves the gap missing and says why).

Positions are (F, M, 3), frames first, in the capture's unit; ``unit_mm``
converts the millimetre floors above into it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .rigid import DistanceStats

__all__ = ["TakeLimits", "take_limits", "implausible"]


@dataclass(frozen=True)
class TakeLimits:
    """What the take shows its markers do (all in the capture's unit).

    Attributes
    ----------
    step : float array (M,)
        Largest plausible one-frame step of each marker.
    nearest : float array (M,)
        Largest plausible distance from each marker to the nearest seen marker.
    low, high : float arrays (M, M)
        Plausible range of each pair's distance (NaN: pair never seen
        together, or not rigid enough to judge by).
    usual_low, usual_high : float arrays (M, M)
        The pair's 1-99 % range over the take (for the messages).
    order : int array (M, M-1)
        Each marker's others from most to least rigidly attached.
    floor : (axis, side, level) or None
        The boundary the samples pile up against: coordinate ``axis``
        (0-2), ``side`` -1 (the low end) or +1, at ``level``; a filled
        sample beyond ``level`` by more than ``floor_margin`` is implausible.
    floor_margin : float
    neighbours : int
        How many of the most rigid neighbours the distance check uses.
    """

    step: np.ndarray
    nearest: np.ndarray
    low: np.ndarray
    high: np.ndarray
    usual_low: np.ndarray
    usual_high: np.ndarray
    order: np.ndarray
    neighbours: int = 4
    floor: tuple | None = None
    floor_margin: float = 20.0


def take_limits(pos: np.ndarray, stats: DistanceStats, order: np.ndarray, unit_mm: float = 1.0,
                neighbours: int = 4, max_frames: int = 600) -> TakeLimits:
    """The plausible steps, neighbour distances and distance to the body of every marker of ``pos``.

    ``pos`` (F, M, 3) holds the observed samples (NaN where unseen);
    ``stats``/``order`` its distance statistics and donor order
    (:mod:`~mocapkit.cleaning.markers.rigid`); ``unit_mm`` millimetres per
    unit. The distance to the nearest seen marker is taken on at most
    ``max_frames`` evenly spaced frames.
    """
    pos = np.asarray(pos, dtype=np.float64)
    f, m = pos.shape[:2]
    mm = 1.0 / unit_mm
    steps = np.linalg.norm(np.diff(pos, axis=0), axis=-1)  # (F-1, M), NaN where either unseen
    with np.errstate(all="ignore"):
        own = np.array([np.percentile(s[~np.isnan(s)], 99.9) if np.any(~np.isnan(s)) else 0.0 for s in steps.T])
        every = steps[~np.isnan(steps)]
        take = float(np.percentile(every, 99.9)) if every.size else 0.0
        fastest = np.array([np.max(s[~np.isnan(s)]) if np.any(~np.isnan(s)) else 0.0 for s in steps.T])
    step = np.maximum(2.0 * np.maximum(own, take), 1.5 * fastest) + 2.0 * mm
    idx = np.unique(np.linspace(0, f - 1, min(f, max_frames)).round().astype(int)) if f else np.zeros(0, int)
    sub = pos[idx]
    d = np.linalg.norm(sub[:, :, None, :] - sub[:, None, :, :], axis=-1)
    d[:, np.arange(m), np.arange(m)] = np.nan
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            near = np.nanmin(d, axis=2)  # (S, M): each seen marker's nearest seen other
            ref = np.nanmax(near, axis=0)
    ref = np.where(np.isfinite(ref), ref, np.inf)
    nearest = np.maximum(2.0 * ref, ref + 150.0 * mm)
    width = np.maximum(2.0 * (stats.high - stats.low), 50.0 * mm)
    rigid = (stats.high - stats.low) <= np.maximum(0.25 * stats.median, 50.0 * mm)
    low = np.where(rigid, stats.low - width, np.nan)
    return TakeLimits(step=step, nearest=nearest, low=low, high=stats.high + width,
                      usual_low=stats.low, usual_high=stats.high, order=order, neighbours=neighbours,
                      floor=_floor(pos, 30.0 * mm), floor_margin=20.0 * mm)


def _floor(pos: np.ndarray, near: float) -> tuple | None:
    """(axis, side, level) of the side of an axis the seen samples pile up against (see the module), or None."""
    v = pos[~np.any(np.isnan(pos), axis=-1)]
    if len(v) < 100:
        return None
    shares = []
    for axis in range(3):
        lo, hi = float(v[:, axis].min()), float(v[:, axis].max())
        shares += [(float(np.mean(v[:, axis] < lo + near)), axis, -1, lo),
                   (float(np.mean(v[:, axis] > hi - near)), axis, 1, hi)]
    shares.sort(reverse=True)
    (best, axis, side, level), second = shares[0], shares[1][0]
    return (axis, side, level) if best >= 0.05 and best >= 3 * second else None


def implausible(pos: np.ndarray, m: int, a: int, b: int, est: np.ndarray, limits: TakeLimits,
                unit_mm: float = 1.0, first: int = 0) -> str:
    """Why the fill ``est`` (b - a, 3) of marker m's frames a..b-1 of ``pos`` is implausible; "" when it is not.

    ``pos`` holds the observed samples (the gap NaN). The reason names the
    first check failed, with its numbers in millimetres. ``first``: the
    take's frame number of ``pos``'s first frame (``pos`` a part of the
    take), for the frames the reason names.
    """
    f = pos.shape[0]
    est = np.asarray(est, dtype=np.float64)
    if est.shape != (b - a, 3) or not np.all(np.isfinite(est)):
        return "no fill"
    path = [est]
    if a > 0 and not np.any(np.isnan(pos[a - 1, m])):
        path.insert(0, pos[a - 1:a, m])
    if b < f and not np.any(np.isnan(pos[b, m])):
        path.append(pos[b:b + 1, m])
    track = np.concatenate(path)
    if len(track) > 1:
        steps = np.linalg.norm(np.diff(track, axis=0), axis=-1)
        k = int(np.argmax(steps))
        if steps[k] > limits.step[m]:
            return (f"a step of {steps[k] * unit_mm:.0f} mm in one frame (the limit the take sets for this marker: "
                    f"{limits.step[m] * unit_mm:.0f} mm)")
    seen = ~np.any(np.isnan(pos[a:b]), axis=-1)  # (n, M) observed in the gap's frames
    seen[:, m] = False
    for d in limits.order[m][:limits.neighbours]:
        lo, hi = limits.low[m, d], limits.high[m, d]
        if not (np.isfinite(lo) and np.isfinite(hi)):
            continue
        t = np.flatnonzero(seen[:, d])
        if t.size == 0:
            continue
        dist = np.linalg.norm(est[t] - pos[a + t, d], axis=-1)
        bad = (dist < lo) | (dist > hi)
        if np.any(bad):
            k = int(np.argmax(np.abs(dist - np.clip(dist, lo, hi))))
            return (f"{dist[k] * unit_mm:.0f} mm from a rigid neighbour at frame {first + a + int(t[k])} "
                    f"(the take shows {limits.usual_low[m, d] * unit_mm:.0f}-{limits.usual_high[m, d] * unit_mm:.0f})")
    if limits.floor is not None:
        axis, side, level = limits.floor
        beyond = side * (est[:, axis] - level)
        if np.any(beyond > limits.floor_margin):
            k = int(np.argmax(beyond))
            edge = "lowest" if side < 0 else "highest"
            return (f"{beyond[k] * unit_mm:.0f} mm beyond the floor (the take's {edge} recorded samples along "
                    f"{'xyz'[axis]}) at frame {first + a + k}")
    if np.isfinite(limits.nearest[m]):
        dist = np.linalg.norm(est[:, None, :] - pos[a:b], axis=-1)  # (n, M)
        dist[~seen] = np.inf
        near = dist.min(axis=1)
        near[np.isinf(near)] = np.nan
        if np.any(near > limits.nearest[m]):
            k = int(np.nanargmax(near))
            return (f"{near[k] * unit_mm:.0f} mm from every seen marker at frame {first + a + k} "
                    f"(allowed: {limits.nearest[m] * unit_mm:.0f}, twice the most the take shows)")
    return ""
