"""Fill marker gaps: interpolation in the moving frame of rigidly attached donors, model-averaged.

A marker hidden for two seconds on a walking subject moves a metre in the
room, so interpolating its room coordinates (linear, spline) fails; in the
moving frame of three markers rigidly attached to it (same segment, or the
neighbouring one) it barely moves, so interpolating *there* and mapping back
works. That is the classic rigid-body fill (Vicon Nexus; the ``gapfill``
package) generalised: the fill interpolates the marker's coordinates in the
donors' frame between the last sample before and the first after the gap,
so it meets both ends exactly, keeps the distances to the donors near their
usual values (Tits, Tilmanne and Dutoit 2018's soft skeleton constraints),
and still follows a marker that is not rigid with its donors.

Which donors? Candidates are the markers whose distance to the gap marker
varies least over the take (:func:`mocapkit.cleaning.markers.rigid.donor_order`)
and that are seen throughout the gap. Every triple of the first
``candidates`` of them, and the groups of the first 4 and 5, is a fill
model. As Tits et al. (2018, PLoS ONE 13(7): e0199744) do, the models are
averaged with weights from their error on the same marker's *observed*
data: gaps of the same length are cut just before and just after the real
one (where the marker and the model's donors are seen), each model fills
them, and the best ``keep`` models are averaged with weights
1 / error^2. The filled samples are then pulled to their usual
distances from their rigid neighbours (Tits et al.'s soft constraints,
:mod:`mocapkit.cleaning.markers.constraints`). A gap with fewer than 3 donors seen throughout is filled by
the low-rank model of the nearest markers (Gløersen and Federolf 2016,
:mod:`mocapkit.cleaning.markers.lowrank`) over a window around it, or, with
nothing seen at all, left missing.

Positions are (F, M, 3), frames first, in the capture's unit; NaN is unseen.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from .constraints import enforce_distances
from .lowrank import fill_lowrank
from .rigid import DistanceStats, distance_stats, donor_order, from_local, local_frames, to_local

__all__ = ["GapFill", "gap_runs", "fill_gaps"]


@dataclass(frozen=True)
class GapFill:
    """One filled gap.

    Attributes
    ----------
    marker : int
        Marker index.
    start, end : int
        The gap's frames, ``start <= f < end``.
    method : str
        ``"donors"`` (model-averaged moving-frame interpolation; the best
        model used donors), ``"cubic"`` (the best model was the cubic in room
        coordinates), ``"lowrank"`` or ``"linear"`` (too little seen around
        the gap for the others).
    donors : tuple of int
        The donors of the best model (empty for the other methods).
    expected_error : float
        RMS error of the fill on the validation gaps cut into the marker's
        observed data, in the capture's unit (NaN when there were none).
    """

    marker: int
    start: int
    end: int
    method: str
    donors: tuple[int, ...] = ()
    expected_error: float = float("nan")


def gap_runs(missing: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Starts and ends (exclusive) of the runs of True in a 1-D bool array."""
    d = np.diff(np.concatenate([[0], np.asarray(missing, dtype=np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def _donor_fill(pos: np.ndarray, m: int, a: int, b: int, donors, cubic: bool = False) -> np.ndarray | None:
    """Fill frames a..b-1 of marker m by interpolation in the donors' moving frame.

    The marker's coordinates in the frame of ``donors`` at the last seen
    frame before the gap (a - 1) and the first after it (b) are interpolated
    over the gap, linearly or (``cubic``) by the cubic Hermite curve whose
    end tangents are the one-frame differences at a - 2 and b + 1, and
    mapped back through the donors' frame of each gap frame; held where the
    gap touches the take's first or last frame. With no donors (an empty
    group) the room coordinates are interpolated. None where the donors are
    not all seen from a - 1 to b (a - 2 to b + 1 for ``cubic``), the marker
    is seen at neither end, or the donors' shape is degenerate (collinear).
    """
    f = pos.shape[0]
    n = b - a
    ends = [t for t in (a - 1, b) if 0 <= t < f and not np.any(np.isnan(pos[t, m]))]
    if not ends:
        return None
    outer = [a - 2, b + 1]
    if cubic and (len(ends) < 2 or outer[0] < 0 or outer[1] >= f or np.any(np.isnan(pos[outer, m]))):
        return None
    frames = np.concatenate([np.arange(a, b), ends, outer if cubic else []]).astype(int)
    donors = list(donors)
    if donors:
        d = pos[frames][:, donors]
        if np.any(np.isnan(d)):
            return None
        ref = d[n]
        sv = np.linalg.svd(ref - ref.mean(axis=0), compute_uv=False)
        if sv[1] <= 1e-3 * sv[0]:
            return None
        rot, origin = local_frames(d, ref)
        loc = to_local(pos[frames[n:], m], rot[n:], origin[n:])
    else:
        loc = pos[frames[n:], m]
    if len(ends) == 1:
        est = np.broadcast_to(loc[0], (n, 3))
    else:
        u = (np.arange(1, n + 1) / (n + 1))[:, None]
        if cubic:
            t0 = (loc[0] - loc[2]) * (n + 1)  # tangents per unit u (the gap spans n + 1 frames)
            t1 = (loc[3] - loc[1]) * (n + 1)
            est = ((2 * u ** 3 - 3 * u ** 2 + 1) * loc[0] + (u ** 3 - 2 * u ** 2 + u) * t0
                   + (-2 * u ** 3 + 3 * u ** 2) * loc[1] + (u ** 3 - u ** 2) * t1)
        else:
            est = (1.0 - u) * loc[0] + u * loc[1]
    return from_local(est, rot[:n], origin[:n]) if donors else est


def _models(pos: np.ndarray, m: int, a: int, b: int, order: np.ndarray, candidates: int) -> list[tuple[tuple[int, ...], bool]]:
    """Fill models (donor group, cubic) for marker m's gap a..b-1.

    Linear in the frame of every triple of the most rigid markers seen
    throughout, and of the first 4, 5, ...; cubic in the frame of the most
    rigid triple and of all candidates; cubic in room coordinates.
    """
    f = pos.shape[0]
    span = slice(max(a - 1, 0), min(b + 1, f))
    seen = np.all(~np.any(np.isnan(pos[span]), axis=-1), axis=0)
    cand = [int(d) for d in order[m] if d != m and seen[d]][:candidates]
    if len(cand) < 3:
        return [((), True)]
    groups = [tuple(c) for c in combinations(cand, 3)]
    groups += [tuple(cand[:k]) for k in range(4, len(cand) + 1)]
    return [(g, False) for g in groups] + [(g, True) for g in groups[:1] + groups[-1:]] + [((), True)]


def _validation_spans(pos: np.ndarray, m: int, a: int, b: int, count: int = 2) -> list[tuple[int, int]]:
    """Up to ``count`` spans of b - a frames where marker m is seen (with one seen frame either side), near the gap."""
    f = pos.shape[0]
    length = b - a
    seen = ~np.any(np.isnan(pos[:, m]), axis=-1)
    out = []
    for k in range(1, 4):
        for s in (a - k * (length + 2), b + 2 + (k - 1) * (length + 2)):
            e = s + length
            if s >= 1 and e + 1 <= f and np.all(seen[s - 1:e + 1]):
                out.append((s, e))
        if len(out) >= count:
            break
    return out[:count]


def _lowrank_fill(pos: np.ndarray, m: int, a: int, b: int, order: np.ndarray, stats: DistanceStats) -> np.ndarray | None:
    """Low-rank fill of marker m's gap from its 12 most rigid neighbours on a window around it."""
    f = pos.shape[0]
    side = max(2 * (b - a), 60)
    lo, hi = max(0, a - side), min(f, b + side)
    near = [m] + [int(d) for d in order[m][:12]]
    sub = pos[lo:hi, near]
    if np.all(np.isnan(sub[:, 0])):
        return None
    med = stats.median[m, near[1:]]
    w = np.concatenate([[1.0], np.exp(-np.nan_to_num(med, nan=1e9) / max(np.nanmedian(med), 1e-9))])
    filled = fill_lowrank(sub, weights=w)
    out = filled[a - lo:b - lo, 0]
    return None if np.any(np.isnan(out)) else out


def fill_gaps(positions: np.ndarray, *, stats: DistanceStats | None = None, candidates: int = 4, keep: int = 3,
              max_gap: int | None = None, constrain: bool = True) -> tuple[np.ndarray, list[GapFill]]:
    """Fill every gap of every marker that is seen at least once.

    Parameters
    ----------
    positions : float array (F, M, 3)
        Marker positions (any unit), NaN where unseen.
    stats : DistanceStats, optional
        The take's inter-marker distances (computed when not given).
    candidates : int
        How many of the most rigidly attached markers the donor groups are drawn from.
    keep : int
        How many of the best donor groups are averaged.
    max_gap : int, optional
        Gaps longer than this many frames are left missing.
    constrain : bool
        Finally pull the filled samples to their usual distances from their
        rigid neighbours (:func:`~mocapkit.cleaning.markers.constraints.enforce_distances`).

    Returns
    -------
    filled : float array (F, M, 3)
        Observed samples unchanged (bit-identical); gaps filled; markers
        never seen, and gaps nothing could fill, still NaN.
    fills : list of GapFill
        One record per filled gap.
    """
    pos = np.array(positions, dtype=np.float64)
    f, m_count = pos.shape[:2]
    missing = np.any(np.isnan(pos), axis=-1)
    out = pos.copy()
    if not np.any(missing):
        return out, []
    if stats is None:
        stats = distance_stats(pos)
    order = donor_order(stats)
    records = []
    for m in np.flatnonzero(np.any(missing, axis=0) & ~np.all(missing, axis=0)):
        for a, b in zip(*gap_runs(missing[:, m])):
            a, b = int(a), int(b)
            if max_gap is not None and b - a > max_gap:
                continue
            rec = _fill_one(pos, out, int(m), a, b, order, stats, candidates, keep)
            if rec is not None:
                records.append(rec)
    if constrain and records:
        filled = np.zeros(missing.shape, dtype=bool)
        for r in records:
            filled[r.start:r.end, r.marker] = True
        out = enforce_distances(out, filled, stats, order)
    return out, records


def _fill_one(pos, out, m, a, b, order, stats, candidates, keep) -> GapFill | None:
    """Fill marker m's gap a..b-1 of ``pos`` into ``out``; the record, or None when nothing could fill it."""
    groups = _models(pos, m, a, b, order, candidates)
    fills, errors = [], []
    spans = _validation_spans(pos, m, a, b)
    for g, cubic in groups:
        est = _donor_fill(pos, m, a, b, g, cubic)
        if est is None:
            continue
        err = []
        for s, e in spans:
            v = _donor_fill(pos, m, s, e, g, cubic)
            if v is not None:
                err.append(np.mean(np.sum((v - pos[s:e, m]) ** 2, axis=-1)))
        fills.append((g, est))
        errors.append(np.sqrt(np.mean(err)) if err else np.nan)
    if fills:
        errs = np.asarray(errors)
        if np.all(np.isnan(errs)):
            best = [0]
            w = np.ones(1)
        else:
            errs = np.where(np.isnan(errs), np.inf, errs)
            best = list(np.argsort(errs, kind="stable")[:keep])
            best = [i for i in best if np.isfinite(errs[i])]
            w = 1.0 / np.maximum(errs[best], 1e-6) ** 2
        est = np.tensordot(w / w.sum(), np.stack([fills[i][1] for i in best]), axes=1)
        out[a:b, m] = est
        expected = float(errs[best[0]]) if np.isfinite(errs[best[0]]) else float("nan")
        return GapFill(m, a, b, "donors" if fills[best[0]][0] else "cubic", fills[best[0]][0], expected)
    est = _lowrank_fill(pos, m, a, b, order, stats)
    if est is not None:
        out[a:b, m] = est
        return GapFill(m, a, b, "lowrank")
    seen = ~np.any(np.isnan(pos[:, m]), axis=-1)
    t = np.flatnonzero(seen)
    if t.size == 0:
        return None
    out[a:b, m] = np.stack([np.interp(np.arange(a, b), t, pos[t, m, c]) for c in range(3)], axis=-1)
    return GapFill(m, a, b, "linear")
