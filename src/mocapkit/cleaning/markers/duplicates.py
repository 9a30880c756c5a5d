"""Find duplicate labels: one marker put on another marker's position.

A labelling solver that gives one reconstructed point two labels puts one
marker exactly on another for a while (CMU 85_02 with LFWT on RFWT: 0.0 mm
apart for 1 s). Two real markers cannot sit within a few millimetres of each
other: they are balls 6-25 mm wide. So two labelled markers that are usually
apart (at least ``apart_mm`` in the frames where they do not coincide) but lie
within ``tol_mm`` (1 mm) of each other over one frame or more cannot both be
right there: one of them is a duplicate. A copy may jitter about the other
marker by a few millimetres (a median distance over 9 frames under ``jitter_mm``,
4 mm, counts too: :func:`coincide`), and it may cover most of the take (how
far apart they usually are is taken where they do not coincide). Trajectories that are one physical marker under
two labels all the time (golfswing's club channels, 1-6 mm apart; a model's
points that coincide by construction, c3d.org's sub_labels RFOO and RTOP)
are usually that close and are left alone; so are markers that only come
near (a hand on the head, two feet together: centimetres, not 0.0 mm).

Which of the two is the copy is told by its rigid neighbours (the markers
the gap fill takes as donors, :func:`~mocapkit.cleaning.markers.rigid.donor_order`):
in the moving frame of each triple of them, a marker keeps nearly the same
coordinates from just before the run to just after it; the copy lies far
from where they put it over the run (over ``off_mm``, and ``ratio`` times
further than the other: 213 against 21 mm for LFWT and RFWT above), the right
one near. Where one has no seen neighbours, by the jumps: the copy jumps
into the shared position and out of it (over ``off_mm`` from the straight
line through its two samples before, or after), the right one moves on
smoothly. Where neither tells, the run is reported and both are left as
recorded. Positions are (F, M, 3), frames first, NaN for
unseen samples, in the capture's unit.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from .gaps import gap_runs
from .rigid import DistanceStats, distance_stats, donor_order, from_local, local_frames, to_local

__all__ = ["Duplicate", "find_duplicates", "coincide"]


@dataclass(frozen=True)
class Duplicate:
    """Markers ``marker`` and ``other`` at the same position for frames ``start <= f < end``.

    ``resolved``: ``marker`` is the copy (on ``other``'s position) and its
    samples there are wrong; False when which one is the copy could not be
    told (both are kept). ``distance``: the largest distance between the two
    over the run (capture unit). ``why``: how it was told, or why not, in words.
    """

    marker: int
    other: int
    start: int
    end: int
    distance: float
    resolved: bool
    why: str


def _rigid_miss(x: np.ndarray, m: int, other: int, start: int, end: int, order: np.ndarray,
                neighbours: int) -> float:
    """How far (capture unit) ``m`` lies over the run from where its rigid neighbours put it; NaN if they cannot say.

    For each triple of ``m``'s first ``neighbours`` rigid neighbours
    (``order[m]``, ``other`` left out), ``m``'s coordinates in the triple's
    moving frame (:func:`~mocapkit.cleaning.markers.rigid.local_frames`) are
    taken as their median over the frames about the run (as many on each
    side as the run is long, at least 10) and mapped back over the run; the
    median distance of ``m``'s samples there from that prediction, for the
    triple that predicts it best, is returned. A copy on another marker's
    position lies that marker's distance off (hundreds of millimetres for
    the other side's marker), a right sample tens at most.
    """
    f = x.shape[0]
    reach = max(end - start, 10)
    lo, hi = max(start - reach, 0), min(end + reach, f)
    run = np.zeros(hi - lo, dtype=bool)
    run[start - lo:end - lo] = True
    cand = [int(n) for n in order[m] if int(n) not in (m, other)][:neighbours]
    best = float("nan")
    for g in combinations(cand, 3):
        rot, origin = local_frames(x[lo:hi][:, list(g)])
        loc = to_local(x[lo:hi, m], rot, origin)  # NaN where m or the triple is unseen
        about = loc[~run]
        about = about[~np.any(np.isnan(about), axis=-1)]
        if about.shape[0] < 3:
            continue
        ref = np.median(about, axis=0)
        pred = from_local(np.broadcast_to(ref, (end - start, 3)), rot[run], origin[run])
        miss = np.linalg.norm(x[start:end, m] - pred, axis=-1)
        if np.all(np.isnan(miss)):
            continue
        best = float(np.nanmin([best, np.nanmedian(miss)]))
    return best


def coincide(distance: np.ndarray, tol: float, jitter: float, width: int = 9) -> np.ndarray:
    """(F,) bool: the frames where two markers sit at the same position, from their distance (F,) (NaN: unseen).

    A frame coincides where the distance is under ``tol``, or its median
    over the ``width`` (odd) frames about it under ``jitter``: a copy that jitters about the other
    marker (a second label on a re-reconstructed point, a few mm off from
    frame to frame) stays one run instead of breaking wherever its noise
    reaches ``tol``, and the median keeps the run's edges where the copy
    jumps on and off. Unseen frames never coincide.
    """
    from scipy.ndimage import median_filter

    d = np.where(np.isnan(distance), np.inf, distance)
    return ((d < tol) | (median_filter(d, size=width, mode="nearest") < jitter)) & np.isfinite(d)


def _jumps(x: np.ndarray, m: int, start: int, end: int, unit_mm: float, off_mm: float) -> list[bool]:
    """Whether ``m`` jumps into the run at ``start`` and out of it at ``end`` (one entry per end with two seen samples
    beyond it): its sample there over ``off_mm`` from the straight line through the two samples beyond."""
    out = []
    f = x.shape[0]
    for t, p, q in ((start, start - 2, start - 1), (end - 1, end + 1, end)):
        if p < 0 or p >= f or q < 0 or q >= f:
            continue
        pts = x[[t, p, q], m]
        if np.any(np.isnan(pts)):
            continue
        out.append(float(np.linalg.norm(pts[0] - (2.0 * pts[2] - pts[1]))) * unit_mm > off_mm)
    return out


def find_duplicates(positions: np.ndarray, unit_mm: float = 1.0, *, tol_mm: float = 1.0, jitter_mm: float = 4.0,
                    apart_mm: float = 10.0,
                    off_mm: float = 15.0, ratio: float = 3.0, stats: DistanceStats | None = None, order: np.ndarray | None = None,
                    neighbours: int = 4) -> list[Duplicate]:
    """Runs of frames where two labelled markers sit at the same position, and which one is the copy.

    Parameters
    ----------
    positions : float array (F, M, 3)
        Marker positions, NaN where unseen (labelled markers only).
    unit_mm : float
        Millimetres per unit of ``positions``.
    tol_mm, jitter_mm : float
        Two markers closer than ``tol_mm`` (mm), or whose median distance
        over 9 frames is under ``jitter_mm`` (:func:`coincide`), are at the
        same position: two real markers' centres are at least a ball's width
        apart (6 mm for the smallest).
    apart_mm : float
        Only pairs at least this far apart (mm) in 90 % of the frames where
        they are seen and do not coincide are judged: nearer ones are one
        physical marker under two labels (golfswing's club channels: 0.1-15
        mm apart). Those frames, not the whole take: a copy covering over
        half of it would make the pair's usual distance 0.
    off_mm, ratio : float
        The copy lies more than ``off_mm`` (mm) from where its rigid
        neighbours put it, and ``ratio`` times further than the other
        (:func:`_rigid_miss`); without neighbours, it jumps by more than
        ``off_mm`` from its straight-line prediction into the run and out of it.
    stats, order : optional
        The take's usual distances and rigid neighbours
        (:func:`~mocapkit.cleaning.markers.rigid.distance_stats`, :func:`donor_order`).
    neighbours : int
        Rigid neighbours asked per marker.

    Returns
    -------
    list of Duplicate, by start frame.
    """
    x = np.asarray(positions, dtype=np.float64)
    f, m = x.shape[:2]
    found: list[Duplicate] = []
    if m < 2 or f == 0:
        return found
    tol = tol_mm / unit_mm
    for i in range(m - 1):
        with np.errstate(invalid="ignore"):
            near = np.linalg.norm(x[:, i + 1:] - x[:, i:i + 1], axis=-1)  # (F, M - i - 1), NaN where unseen
        for k in np.flatnonzero(np.any(near < max(tol, jitter_mm / unit_mm), axis=0)):
            j = i + 1 + int(k)
            close = coincide(near[:, k], tol, jitter_mm / unit_mm)
            apart = near[:, k][~close & ~np.isnan(near[:, k])]
            if apart.size < 10 or not np.percentile(apart, 10) * unit_mm >= apart_mm:
                continue  # one physical marker under two labels (or too rarely seen apart to tell)
            if stats is None:
                stats = distance_stats(x)
            if order is None:
                order = donor_order(stats)
            for s, e in zip(*gap_runs(close)):
                s, e = int(s), int(e)
                dist = float(np.max(np.linalg.norm(x[s:e, i] - x[s:e, j], axis=-1)))
                miss = {a: _rigid_miss(x, a, b, s, e, order, neighbours) * unit_mm for a, b in ((i, j), (j, i))}
                copy, why = None, ""
                if np.isfinite(miss[i]) and np.isfinite(miss[j]):
                    # the copy lies far off where its neighbours put it, and much further than the right one
                    for a, b in ((i, j), (j, i)):
                        if miss[a] > max(off_mm, ratio * miss[b]):
                            copy = a
                            why = (f"its rigid neighbours put it {miss[a]:.0f} mm away, "
                                   f"{miss[b]:.0f} mm for the other")
                    if copy is None:
                        why = f"their rigid neighbours put them {miss[i]:.0f} and {miss[j]:.0f} mm away"
                else:  # by the jumps into and out of the run
                    jumps = {a: _jumps(x, a, s, e, unit_mm, off_mm) for a in (i, j)}
                    copy = next((a for a, b in ((i, j), (j, i))
                                 if jumps[a] and all(jumps[a]) and jumps[b] and not any(jumps[b])), None)
                    why = ("no rigid neighbours seen; it jumps into that position and out of it, the other moves on"
                           if copy is not None else "no rigid neighbours seen, and the jumps do not tell")
                if copy is None:
                    found.append(Duplicate(i, j, s, e, dist, False, why))
                else:
                    found.append(Duplicate(copy, j if copy == i else i, s, e, dist, True, why))
    found.sort(key=lambda d: (d.start, d.marker))
    return found
