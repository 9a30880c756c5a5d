"""Fill marker gaps: fills in the moving frame of rigidly attached donors, model-averaged by self-validation.

A marker hidden for two seconds on a walking subject moves a metre in the
room, so interpolating its room coordinates (linear, spline) fails; in the
moving frame of three markers rigidly attached to it (same segment, or the
neighbouring one) it barely moves, so interpolating *there* and mapping back
works. That is the classic rigid-body fill (Vicon Nexus; the ``gapfill``
package) generalised: the fill interpolates the marker's coordinates in the
donors' frame between the last sample before and the first after the gap,
so it meets both ends exactly and still follows a marker that is not rigid
with its donors. A marker on the next segment (a thigh marker in the
pelvis' frame) moves in that frame with the other markers of its own
segment (the knee): the *regression* fill predicts its local coordinates
from theirs by a ridge regression fitted on the take's other frames (the
relational fill of Qualisys and Vicon, and Gløersen and Federolf's
inter-marker correlations, taken in a moving frame), and interpolates the
residual across the gap so it meets both ends too.

Which donors? Candidates are the markers whose distance to the gap marker
varies least over the take (:func:`mocapkit.cleaning.markers.rigid.donor_order`),
by no more than :data:`MAX_DONOR_SPREAD_MM` (:func:`donors_allowed`: a
prop's or another subject's markers are no donors), and that are seen
throughout the gap. Every triple of the first
``candidates`` of them, and the groups of the first 4 and 5, is a linear
fill model; the cubic in the frame of the first triple and of all
candidates, the cubic in room coordinates and the regression on the first
``predictors`` candidates in the frame of the first triple (a weakly and a
strongly shrunk fit) are models too. As Tits, Tilmanne and Dutoit (2018,
PLoS ONE 13(7): e0199744) do, the models are averaged with weights from
their error on the same marker's *observed* data: gaps of the same length
are cut just before and just after the real one (where the marker is seen;
in a short take, where a gap of that length does not fit, the longest
stretches that do, down to a fifth of it), each model fills them (from
one end only where the real gap touches the take's first or last frame, as
the real gap must be), and the best ``keep`` models are averaged with
weights 1 / error^2. The averaged
fill is then pulled to its usual distances from its rigid neighbours
(Tits et al.'s soft constraints,
:mod:`mocapkit.cleaning.markers.constraints`) where that brought the
validation gaps nearer the truth, their usual distances taken from the rest
of the take as the real gap's are, and the pull smoothed over time so it does
not jolt the fill where it switches on; those distances come from the frames the
gap does not hide, and a gap hiding poses the rest of the take does not show
is better left unconstrained. Where no donor group can fill (fewer than 3
seen throughout, or collinear), room-coordinate interpolation, the offset
from one of the two nearest markers (pattern fill) and the low-rank model of
the nearest markers (Gløersen and Federolf 2016,
:mod:`mocapkit.cleaning.markers.lowrank`) over a window around the gap
compete in the same way; with nothing seen at all the gap stays missing.
Frames where no marker of a subject is seen (the subject not yet in the
capture volume, gone from it, or out of it for a while mid-take; in a
multi-subject capture each subject's markers share a ``Subject:`` prefix,
:func:`mocapkit.markerset.subject_of`, and are one body) are left missing
too: nothing of that body is seen there to fill from, and a fill would be
made up (a fixed pose or a straight-line extrapolation, metres from where
the subject appears; another subject's markers say nothing about where
this one is). The stretches between them are filled as takes of their
own, a gap reaching those frames from one end, as a gap at the take's
edge is (:func:`nobody_seen` lists them).

Positions are (F, M, 3), frames first, in the capture's unit; NaN is unseen.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from itertools import combinations

import numpy as np
from threadpoolctl import threadpool_limits

from .constraints import enforce_distances
from .fill_error import SPANS, average, expected_error
from .lowrank import fill_lowrank
from .plausible import TakeLimits, implausible, take_limits
from .rigid import DistanceStats, distance_stats, donor_order, from_local, local_frames, to_local

__all__ = ["GapFill", "SMOOTH_S", "gap_runs", "fill_gaps", "nobody_seen", "error_limits", "MIN_ERROR_LIMIT_MM",
           "MAX_DONOR_SPREAD_MM", "donors_allowed", "TOO_LONG"]

TOO_LONG = "longer than --max-gap"
"""The start of :attr:`GapFill.implausible` for a gap left missing because it is longer than ``max_gap``: no fill
was tried, so it is no implausible fill (:meth:`MarkerFix.too_long <mocapkit.cleaning.markers.MarkerFix.too_long>`)."""

MIN_ERROR_LIMIT_MM = 50.0
"""The least default limit on a fill's expected error (mm): see :func:`error_limits`."""

MAX_DONOR_SPREAD_MM = 150.0
"""The most a donor's distance to the gap's marker may vary over the take (its spread, mm): :func:`donors_allowed`."""


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
        The best of the averaged models: ``"donors"`` (interpolation in the
        donors' moving frame, or the offset from one donor),
        ``"regression"`` (regression on the neighbours in the donors'
        frame), ``"cubic"`` or ``"linear"`` (in room coordinates), or
        ``"lowrank"``.
    donors : tuple of int
        The donors of the best model (empty for the room and low-rank fills).
    expected_error : float
        The fill's expected RMS error, in the capture's unit: its error on
        stretches of the gap's length cut where the marker is seen, with the
        gap's other hidden markers hidden there too, widened where the gap's
        frames are harder or the stretches few or short
        (:mod:`~mocapkit.cleaning.markers.fill_error`); NaN when no stretch
        could be cut (an unvalidated fill).
    constrained : bool
        Whether the soft distance constraints were applied to the gap (they
        brought the validation gaps nearer the truth).
    implausible : str
        Empty for a filled gap. Otherwise why no fill was plausible
        (:func:`~mocapkit.cleaning.markers.plausible.implausible`: the
        reason the best model's fill failed): the gap is left missing, and
        ``method``, ``donors`` and ``expected_error`` describe that rejected fill.
    models : int
        How many models' fills were averaged (weights 1 / error^2); 1 for a
        single model's fill. ``method`` and ``donors`` name the best of them,
        ``expected_error`` is the average's own.
    note : str
        Why the fill had no donor group although markers were seen
        throughout the gap: too few of them rigid enough to be donors
        (:func:`donors_allowed`); empty otherwise.
    basis : str
        How ``expected_error`` was widened beyond its stretches' figure (a
        harder gap, thin evidence: :func:`~mocapkit.cleaning.markers.fill_error.expected_error`),
        in words; empty where it was not.
    """

    marker: int
    start: int
    end: int
    method: str
    donors: tuple[int, ...] = ()
    expected_error: float = float("nan")
    constrained: bool = False
    implausible: str = ""
    models: int = 1
    note: str = ""
    basis: str = ""

    @property
    def filled(self) -> bool:
        """Whether the gap was filled (False: left missing, no plausible fill)."""
        return not self.implausible


def gap_runs(missing: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Starts and ends (exclusive) of the runs of True in a 1-D bool array."""
    d = np.diff(np.concatenate([[0], np.asarray(missing, dtype=np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def nobody_seen(missing: np.ndarray, subjects=None) -> list[tuple[str, int, int]]:
    """Per subject, the runs of frames where none of its markers is seen: ``(subject, start, end)``, ``start <= f < end``.

    ``missing``: (F, M) bool; ``subjects``: (M,) the subject of each marker
    (:func:`mocapkit.markerset.subject_of`; default: all one subject, "").
    A subject none of whose markers is ever seen has no runs (its markers
    are never seen). Sorted by start, then subject.
    """
    missing = np.asarray(missing, dtype=bool)
    names = [""] * missing.shape[1] if subjects is None else [str(x) for x in subjects]
    out = []
    for name in dict.fromkeys(names):
        cols = [i for i, x in enumerate(names) if x == name]
        none = np.all(missing[:, cols], axis=1)
        if none.all():
            continue
        out += [(name, int(a), int(b)) for a, b in zip(*gap_runs(none))]
    return sorted(out, key=lambda r: (r[1], r[0]))


def error_limits(stats: DistanceStats, unit_mm: float = 1.0) -> np.ndarray:
    """(M,) the default limit on a fill's expected error: each marker's median distance to its nearest marker.

    In the capture's unit, at least :data:`MIN_ERROR_LIMIT_MM`. A fill
    expected to be off by more than the distance between the marker and its
    nearest neighbour cannot tell the one from the other: a heel extrapolated
    0.6 m while out of the volume is a guess, not a measurement. NaN-free:
    a marker never seen with another gets the floor.
    """
    med = np.array(stats.median, dtype=np.float64)
    np.fill_diagonal(med, np.nan)
    with np.errstate(all="ignore"):
        near = np.nanmin(np.where(np.isfinite(med), med, np.inf), axis=1)
    return np.maximum(np.where(np.isfinite(near), near, 0.0), MIN_ERROR_LIMIT_MM / unit_mm)


def donors_allowed(stats: DistanceStats, m: int, unit_mm: float = 1.0) -> np.ndarray:
    """(M,) bool: the markers rigid enough with marker m to be its donors.

    A donor must move rigidly with the marker over the frames where both are
    seen: the spread of their distance (half its 10-90 % range,
    :class:`~mocapkit.cleaning.markers.rigid.DistanceStats`) at most
    :data:`MAX_DONOR_SPREAD_MM`. Markers of one body keep it (the loosest
    pair among the 4 most rigid neighbours of any marker of the recovery,
    c3d.org, BTKData and TRC captures: 106 mm, across Dance.c3d's elbow);
    a prop's or another subject's markers do not (SprintMotion.trc's start
    blocks against the sprinter's feet: 570-630 mm). Pairs never seen
    together are not donors.
    """
    spread = np.asarray(stats.spread[m], dtype=np.float64)
    with np.errstate(invalid="ignore"):
        out = spread <= MAX_DONOR_SPREAD_MM / unit_mm
    out[m] = False
    return out


def _donor_fill(pos: np.ndarray, m: int, a: int, b: int, donors, cubic: bool = False, side: int = 0,
                frames: dict | None = None) -> np.ndarray | None:
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
    ``side`` -1 (+1) uses only the end before (after) the gap, as a gap
    touching the take's last (first) frame must.

    ``frames``: a dict shared by the models of one gap (:func:`_fills`), which keeps each donor group's
    moving frames over the gap and its ends: the cubic fill in a group's frame needs those the linear fill
    of that group computed, and only its two outer frames more. Every frame's Kabsch fit is its own, so the
    frames are bit for bit those of one call over all of them (03_rolling.c3d: 67,000 of the 280,000 donor
    frames were such repeats).
    """
    f = pos.shape[0]
    n = b - a
    ends = [t for t, k in ((a - 1, -1), (b, 1)) if 0 <= t < f and side != -k and not np.any(np.isnan(pos[t, m]))]
    if not ends:
        return None
    outer = [a - 2, b + 1]
    if cubic and (len(ends) < 2 or outer[0] < 0 or outer[1] >= f or np.any(np.isnan(pos[outer, m]))):
        return None
    frames_at = np.concatenate([np.arange(a, b), ends, outer if cubic else []]).astype(int)
    donors = list(donors)
    if len(donors) == 1:  # pattern fill: the offset from one donor, interpolated
        d = pos[frames_at, donors[0]]
        if np.any(np.isnan(d)):
            return None
        est = _interpolate(pos[frames_at[n:], m] - d[n:], n, len(ends), cubic)
        return est + d[:n]
    if donors:
        d = pos[frames_at][:, donors]
        if np.any(np.isnan(d)):
            return None
        ref = d[n]
        sv = np.linalg.svd(ref - ref.mean(axis=0), compute_uv=False)
        if sv[1] <= 1e-3 * sv[0]:
            return None
        rot, origin = _group_frames(d, ref, n + len(ends), None if frames is None else (tuple(donors), a, b, side),
                                    frames)
        loc = to_local(pos[frames_at[n:], m], rot[n:], origin[n:])
    else:
        loc = pos[frames_at[n:], m]
    est = _interpolate(loc, n, len(ends), cubic)
    return from_local(est, rot[:n], origin[:n]) if donors else est


def _group_frames(d: np.ndarray, ref: np.ndarray, k: int, key, frames: dict | None):
    """:func:`~mocapkit.cleaning.markers.rigid.local_frames` of donors ``d`` (T, K, 3) on ``ref``, its first ``k``
    frames (the gap's and its ends') kept in ``frames`` under ``key`` and taken from there when kept already."""
    if frames is None:
        return local_frames(d, ref)
    if key in frames:
        rot, origin = frames[key]
        if len(rot) == len(d):
            return rot, origin
        more_rot, more_origin = local_frames(d[k:], ref)
        return np.concatenate([rot, more_rot]), np.concatenate([origin, more_origin])
    rot, origin = local_frames(d, ref)
    frames[key] = (rot[:k], origin[:k])
    return rot, origin


def _interpolate(loc: np.ndarray, n: int, ends: int, cubic: bool) -> np.ndarray:
    """(n, 3) values across a gap of n frames from ``loc``: the values at its ends (then, for ``cubic``, one frame further out).

    One end: held. Two: linear, or the cubic Hermite curve whose end
    tangents are the one-frame differences.
    """
    if ends == 1:
        return np.broadcast_to(loc[0], (n, 3)).copy()
    u = (np.arange(1, n + 1) / (n + 1))[:, None]
    if not cubic:
        return (1.0 - u) * loc[0] + u * loc[1]
    t0 = (loc[0] - loc[2]) * (n + 1)  # tangents per unit u (the gap spans n + 1 frames)
    t1 = (loc[3] - loc[1]) * (n + 1)
    return ((2 * u ** 3 - 3 * u ** 2 + 1) * loc[0] + (u ** 3 - 2 * u ** 2 + u) * t0
            + (-2 * u ** 3 + 3 * u ** 2) * loc[1] + (u ** 3 - u ** 2) * t1)


def _regress_fill(pos: np.ndarray, m: int, a: int, b: int, donors, predictors, ridges, side: int = 0) -> list[np.ndarray] | None:
    """Fill frames a..b-1 of marker m by regression on its neighbours in the donors' moving frame.

    In the moving frame of ``donors`` (a rigid triple, e.g. the pelvis
    markers) a marker on a neighbouring segment (the thigh) moves with that
    segment, and so do the other markers of the segment that stay seen (the
    knee): its local coordinates (3,) are close to a linear function of the
    ``predictors``' local coordinates (3P,). The function is fitted by ridge
    regression on the frames of a window around the gap (600 frames or three
    gap lengths either side) where all are seen, frames a..b-1 left out,
    each ridge of ``ridges`` giving one fill (the ridge is relative: a
    multiple of the mean eigenvalue of the centred predictors' scatter); the
    residual at the last seen frame before the gap and the first after is
    interpolated linearly across it, so the fill meets both ends (held from
    the one end where the gap touches the take's first or last frame, or
    ``side`` -1 (+1) asks for the end before (after) only). This is the
    relational / kinematic fill of Qualisys and Vicon generalised to any
    neighbours, and the inter-marker correlations of Gløersen and Federolf
    (2016) taken in a moving frame. None where the donors or predictors are
    not all seen over the gap and its ends, the marker is not seen at an end
    used, the donors are collinear or fewer than 30 frames train the fit.
    """
    f = pos.shape[0]
    n = b - a
    first = a - 1 if a >= 1 and side != 1 else a  # the frames from the end before to the end after, those used
    last = b if b < f and side != -1 else b - 1
    if first == a and last == b - 1:
        return None
    reach = max(3 * n, 600)
    lo, hi = max(0, a - reach), min(f, b + reach)
    donors, predictors = list(donors), [p for p in predictors if p != m]
    d = pos[lo:hi][:, donors]
    okd = ~np.any(np.isnan(d), axis=(1, 2))
    pr = pos[lo:hi][:, predictors]  # (W, P, 3)
    okp = okd & ~np.any(np.isnan(pr), axis=(1, 2))
    tgt = pos[lo:hi, m]
    okm = okp & ~np.any(np.isnan(tgt), axis=-1)
    if not (np.all(okp[first - lo:last + 1 - lo]) and (first == a or okm[first - lo]) and (last < b or okm[last - lo])):
        return None
    ref = pos[first if first < a else last, donors]
    sv = np.linalg.svd(ref - ref.mean(axis=0), compute_uv=False)
    if sv[1] <= 1e-3 * sv[0]:
        return None
    train = okm.copy()
    train[a - lo:b - lo] = False
    if np.count_nonzero(train) < max(30, 3 * len(predictors) + 5):
        return None
    # frames whose moving frame is needed: training (the marker seen) and the gap with its ends; a frame where only
    # the marker is unseen is neither, and each frame's Kabsch fit is its own (the others' are the same bits without it)
    use = okp & okm
    use[first - lo:last + 1 - lo] = True
    rot, origin = local_frames(d[use], ref)
    locp = np.einsum("tji,tpj->tpi", rot, pr[use] - origin[:, None, :]).reshape(len(rot), -1)
    loct = to_local(np.where(okm[use][:, None], tgt[use], 0.0), rot, origin)
    at = np.cumsum(use) - 1  # row of each window frame among the used ones
    tr = train[use]
    xm, ym = locp[tr].mean(axis=0), loct[tr].mean(axis=0)
    xc, yc = locp[tr] - xm, loct[tr] - ym
    g = xc.T @ xc
    rows = at[first - lo:last + 1 - lo]
    gap = rows[int(first < a):len(rows) - int(last >= b)]
    u = (np.arange(1, n + 1) / (n + 1))[:, None]
    out = []
    for ridge in ridges:
        w = np.linalg.solve(g + ridge * np.trace(g) / g.shape[0] * np.eye(g.shape[0]), xc.T @ yc)
        pred = (locp[rows] - xm) @ w + ym
        r0, r1 = loct[rows[0]] - pred[0], loct[rows[-1]] - pred[-1]
        if first < a and last >= b:
            est = pred[1:-1] + (1.0 - u) * r0 + u * r1
        elif first < a:
            est = pred[1:] + r0
        else:
            est = pred[:-1] + r1
        out.append(from_local(est, rot[gap], origin[gap]))
    return out


SMOOTH_S = 0.025  # the soft constraints' correction smoothed over this standard deviation (s): no frame-to-frame jolt
SMOOTH_FRAMES = SMOOTH_S * 120.0
RIDGES = (1e-3, 1e-1)  # the regression fills' relative ridges: one trusting the fit, one shrinking it


def _models(pos: np.ndarray, m: int, a: int, b: int, order: np.ndarray, candidates: int, predictors: int,
            rigid: np.ndarray | None = None):
    """Fill models (donor group, kind, extra) for marker m's gap a..b-1.

    Linear in the frame of every triple of the most rigid markers seen
    throughout, and of the first 4, 5, ...; cubic in the frame of the most
    rigid triple and of all candidates; cubic in room coordinates; and the
    regression on the ``predictors`` most rigid markers seen throughout in
    the frame of the most rigid triple, once per ridge of ``RIDGES``
    (``extra`` is then (predictors, ridge)). ``rigid`` (M,) bool: the
    markers that may be donors (:func:`donors_allowed`; default all); the
    predictors are not limited (a regression learns how they move).
    """
    f = pos.shape[0]
    span = slice(max(a - 1, 0), min(b + 1, f))
    seen = np.all(~np.any(np.isnan(pos[span]), axis=-1), axis=0)
    near = [int(d) for d in order[m] if d != m and seen[d]]
    cand = [d for d in near if rigid is None or rigid[d]][:candidates]
    if len(cand) < 3:
        return [((), "cubic", None)]
    groups = [tuple(c) for c in combinations(cand, 3)]
    groups += [tuple(cand[:k]) for k in range(4, len(cand) + 1)]
    out = [(g, "linear", None) for g in groups] + [(g, "cubic", None) for g in groups[:1] + groups[-1:]] + [((), "cubic", None)]
    if predictors:
        out += [(groups[0], "regress", (tuple(near[:predictors]), r)) for r in RIDGES]
    return out


def _fills(pos: np.ndarray, m: int, a: int, b: int, models, order: np.ndarray, stats: DistanceStats,
           side: int = 0) -> list[np.ndarray | None]:
    """Each model's fill (b - a, 3) of marker m's frames a..b-1, None where the model cannot fill them.

    ``side`` -1 (+1): fill from the end before (after) the frames only, as
    for a gap that touches the take's last (first) frame.
    """
    out: list[np.ndarray | None] = []
    regressed: dict = {}
    frames: dict = {}  # each donor group's moving frames over the gap and its ends (:func:`_donor_fill`)
    for g, kind, extra in models:
        if kind == "regress":
            key = (g, extra[0])
            if key not in regressed:
                regressed[key] = _regress_fill(pos, m, a, b, g, extra[0], RIDGES, side)
            fits = regressed[key]
            out.append(None if fits is None else fits[RIDGES.index(extra[1])])
        elif kind == "lowrank":
            out.append(_lowrank_fill(pos, m, a, b, order, stats))
        else:
            out.append(_donor_fill(pos, m, a, b, g, kind == "cubic", side, frames))
    return out


def _validation_spans(pos: np.ndarray, m: int, a: int, b: int, count: int = 2) -> list[tuple[int, int]]:
    """Up to ``count`` spans of b - a frames where marker m is seen (with one seen frame either side), near the gap.

    When fewer than ``count`` such spans fit (a long gap in a short take),
    the seen stretches nearest the gap give spans as long as they allow (at
    least a fifth of the gap), ending (starting) next to the gap: shorter
    spans understate every model's error, but still rank the models.
    """
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
    if len(out) < count:
        starts, ends = gap_runs(seen)
        runs = sorted(zip(starts, ends), key=lambda r: min(abs(r[1] - a), abs(r[0] - b)))
        for r0, r1 in runs:
            n = min(length, r1 - r0 - 2)
            if n < max(1, length // 5):
                continue
            s = r1 - 1 - n if r1 <= a else r0 + 1
            if (s, s + n) not in out and not any(s < e2 and s2 < s + n for s2, e2 in out):
                out.append((int(s), int(s + n)))
            if len(out) >= count:
                break
    return out[:count]


def _lowrank_fill(pos: np.ndarray, m: int, a: int, b: int, order: np.ndarray, stats: DistanceStats) -> np.ndarray | None:
    """Low-rank fill of marker m's frames a..b-1 (hidden if seen) from its 12 most rigid neighbours on a window around them."""
    f = pos.shape[0]
    side = max(2 * (b - a), 60)
    lo, hi = max(0, a - side), min(f, b + side)
    near = [m] + [int(d) for d in order[m][:12]]
    sub = pos[lo:hi, near]
    sub[a - lo:b - lo, 0] = np.nan
    if np.all(np.isnan(sub[:, 0])):
        return None
    med = stats.median[m, near[1:]]
    known = med[np.isfinite(med)]  # none when no neighbour was ever seen with the marker
    scale = max(float(np.median(known)), 1e-9) if known.size else 1.0
    w = np.concatenate([[1.0], np.exp(-np.nan_to_num(med, nan=1e9) / scale)])
    filled = fill_lowrank(sub, weights=w)
    out = filled[a - lo:b - lo, 0]
    return None if np.any(np.isnan(out)) else out


def fill_gaps(positions: np.ndarray, *, stats: DistanceStats | None = None, candidates: int = 4, keep: int = 3,
              max_gap: int | None = None, constrain: bool = True, predictors: int = 6, guard: bool = True,
              unit_mm: float = 1.0, smooth: float = SMOOTH_FRAMES, subjects=None,
              markers=None, max_error=None, first_frame: int = 0, progress=None,
              strict: bool | None = None) -> tuple[np.ndarray, list[GapFill]]:
    """Fill every gap of every marker that is seen at least once, except where none of its subject's markers is.

    Parameters
    ----------
    positions : float array (F, M, 3)
        Marker positions (any unit), NaN where unseen.
    stats : DistanceStats, optional
        The take's inter-marker distances (computed when not given).
    candidates : int
        How many of the most rigidly attached markers the donor groups are drawn from.
    keep : int
        How many of the best models are averaged.
    max_gap : int, optional
        Gaps longer than this many frames are left missing.
    constrain : bool
        Pull the filled samples of the gaps where that helped on the
        validation spans to their usual distances from their rigid
        neighbours (:func:`~mocapkit.cleaning.markers.constraints.enforce_distances`).
    predictors : int
        How many of the most rigidly attached markers the regression fills
        use (0: no regression fills).
    guard : bool
        Write only fills that pass the plausibility guard
        (:func:`~mocapkit.cleaning.markers.plausible.implausible`): the
        averaged fill, else the first of its models, best validated first,
        that passes; none passing, the gap is left missing. A constrained
        fill that fails after the constraints is written unconstrained.
    unit_mm : float
        Millimetres per unit of ``positions`` (the guard's floors are in mm).
    smooth : float
        The soft constraints' correction is smoothed over time by a Gaussian
        of this many frames (:func:`~mocapkit.cleaning.markers.constraints.smooth_correction`;
        0: frame by frame). The default is 0.025 s at 120 Hz;
        :func:`~mocapkit.cleaning.markers.clean.clean_markers` passes
        :data:`SMOOTH_S` at the take's rate.
    subjects : sequence of str (M,), optional
        The subject of each marker (:func:`mocapkit.markerset.subject_of`);
        default: all one. Frames where none of a subject's markers is seen
        stay missing for all of them (:func:`nobody_seen`), and the
        stretches between are filled as takes of their own.
    markers : sequence of int, optional
        Fill only these markers' gaps (default: every marker's); the others
        still serve as donors.
    max_error : float or float array (M,), optional
        A fill whose expected error (its RMS error on the validation gaps) is
        larger than this, in the capture's unit, is not written: the gap is
        left missing and its record says so. Default: :func:`error_limits`
        (each marker's distance to its nearest marker); ``inf``: no limit.
    strict : bool, optional
        Whether ``max_error`` is a limit the user gave: it is checked on the
        expected error, and an unvalidated fill (expected error unknown: no
        stretch to measure it on) fails a finite one (a limit cannot be
        checked on an unknown; ``inf`` still writes it). Default: True where
        ``max_error`` is given. False (the default limits) checks the limit
        on the fill's error on the two stretches that rank its models and
        writes unvalidated fills, as before 0.18.0 (the summary counts them
        apart): a take cleaned without a limit is written as it was.
    first_frame : int
        The frame number of ``positions``' first frame in the take it is part
        of: the frames a record's ``implausible`` names count from it.
    progress : callable, optional
        ``progress(done, more)``: called with ``(0, N)`` when ``N`` gaps are
        about to be filled (each stretch of a subject's frames announces its
        own) and ``(1, 0)`` as each is done (a command's progress bar).

    Returns
    -------
    filled : float array (F, M, 3)
        Observed samples unchanged (bit-identical); gaps filled; markers
        never seen, frames where none of a marker's subject's markers is
        seen, gaps nothing could fill and gaps no fill of which was
        plausible, still NaN.
    fills : list of GapFill
        One record per filled gap, and one per gap left missing for want of
        a plausible fill (``implausible`` says why; ``filled`` is False).

    BLAS runs on one thread (as in :func:`~mocapkit.cleaning.markers.clean.clean_markers`):
    the low-rank fills' SVDs run many times faster so on a busy machine, to the same bits.
    """
    strict = max_error is not None if strict is None else bool(strict)
    with threadpool_limits(1, user_api="blas"):
        return _fill_gaps(positions, stats, candidates, keep, max_gap, constrain, predictors, guard, unit_mm, smooth,
                          subjects, markers, max_error, first_frame, progress, strict)


def _fill_gaps(positions, stats, candidates, keep, max_gap, constrain, predictors, guard, unit_mm, smooth, subjects,
               markers, max_error, first_frame, progress, strict) -> tuple[np.ndarray, list[GapFill]]:
    """:func:`fill_gaps`' work, on one BLAS thread."""
    pos = np.array(positions, dtype=np.float64)
    f, m_count = pos.shape[:2]
    missing = np.any(np.isnan(pos), axis=-1)
    out = pos.copy()
    if not np.any(missing):
        return out, []
    if stats is None:
        stats = distance_stats(pos)
    names = [""] * m_count if subjects is None else [str(x) for x in subjects]
    todo = np.zeros(m_count, dtype=bool)
    todo[np.arange(m_count) if markers is None else np.asarray(markers, dtype=int)] = True
    todo &= np.any(missing, axis=0) & ~np.all(missing, axis=0)
    records = []
    for name in dict.fromkeys(names):
        group = np.array([i for i, x in enumerate(names) if x == name])
        mine = group[todo[group]]
        none = np.all(missing[:, group], axis=1)
        if not mine.size or not none.any():
            continue
        # nobody of this subject seen in some frames: left missing, each stretch between filled as a take of its own
        todo[mine] = False
        for lo, hi in zip(*gap_runs(~none)):
            lo, hi = int(lo), int(hi)
            inner, inner_records = fill_gaps(pos[lo:hi], stats=stats, candidates=candidates, keep=keep,
                                             max_gap=max_gap, constrain=constrain, predictors=predictors, guard=guard,
                                             unit_mm=unit_mm, smooth=smooth, subjects=names, markers=mine,
                                             max_error=error_limits(stats, unit_mm) if max_error is None else max_error,
                                             first_frame=first_frame + lo, progress=progress, strict=strict)
            out[lo:hi, mine] = inner[:, mine]
            records += [replace(r, start=r.start + lo, end=r.end + lo) for r in inner_records]
    if not todo.any():
        return out, sorted(records, key=lambda r: (r.marker, r.start))
    order = donor_order(stats)
    limits = take_limits(pos, stats, order, unit_mm) if guard else None
    worst = error_limits(stats, unit_mm) if max_error is None else np.broadcast_to(np.asarray(max_error, float), (m_count,))
    split = records
    records = []
    if progress is not None:
        progress(0, sum(len(gap_runs(missing[:, m])[0]) for m in np.flatnonzero(todo)))
    for m in np.flatnonzero(todo):
        for a, b in zip(*gap_runs(missing[:, m])):
            a, b = int(a), int(b)
            if max_gap is not None and b - a > max_gap:  # left missing, and said so
                records.append(GapFill(int(m), a, b, "", implausible=f"{TOO_LONG} ({max_gap} frames)"))
                if progress is not None:
                    progress(1, 0)
                continue
            rec = _fill_one(pos, out, int(m), a, b, order, stats, candidates, keep, predictors, constrain,
                            limits, unit_mm, smooth, float(worst[m]), first_frame, strict)
            if rec is not None:
                records.append(rec)
            if progress is not None:
                progress(1, 0)
    if constrain and any(r.constrained for r in records):
        free = np.zeros(missing.shape, dtype=bool)
        for r in records:
            free[r.start:r.end, r.marker] = r.constrained
        con = enforce_distances(out, free, stats, order, smooth=smooth)
        for k, r in enumerate(records):
            if not r.constrained:
                continue
            run = slice(r.start, r.end)
            if limits is not None and implausible(pos, r.marker, r.start, r.end, con[run, r.marker], limits, unit_mm):
                records[k] = replace(r, constrained=False)  # the constraints pulled it off: written as it passed the guard
            else:
                out[run, r.marker] = con[run, r.marker]
    return out, sorted(split + records, key=lambda r: (r.marker, r.start))


def _constraint_helps(pos: np.ndarray, m: int, checks, stats: DistanceStats, order: np.ndarray,
                      smooth: float = 0.0) -> bool:
    """Whether the soft constraints brought the fills of the validation spans nearer the truth.

    ``checks`` holds (s, e, fill) for each validation span. Each span is
    constrained as the real gap would be, with marker m's usual distances to
    its rigid neighbours taken from the frames outside the span (as the
    gap's are taken from the frames outside the gap). False without spans:
    no evidence, no change.
    """
    if not checks:
        return False
    near = [int(d) for d in order[m][:4]]
    seen_m = ~np.any(np.isnan(pos[:, m]), axis=-1)
    apart = {d: np.linalg.norm(pos[:, m] - pos[:, d], axis=-1) for d in near}  # per frame: the spans' subsets
    err = np.zeros(2)
    for s, e, est in checks:
        low, high = stats.low.copy(), stats.high.copy()
        keep = seen_m.copy()
        keep[s:e] = False
        for d in near:
            dist = apart[d][keep]
            dist = dist[~np.isnan(dist)]
            if dist.size >= 10:
                low[m, d], high[m, d] = np.percentile(dist, [1, 99])
            else:
                low[m, d] = high[m, d] = np.nan
            low[d, m], high[d, m] = low[m, d], high[m, d]
        s0, e0 = max(s - 1, 0), min(e + 1, pos.shape[0])  # with the seen samples either side, as the gap has
        sub = pos[s0:e0].copy()
        sub[s - s0:e - s0, m] = est
        free = np.zeros(sub.shape[:2], dtype=bool)
        free[s - s0:e - s0, m] = True
        con = enforce_distances(sub, free, DistanceStats(stats.median, low, high, stats.spread, stats.count), order,
                                smooth=smooth)
        truth = pos[s:e, m]
        err += [np.sum((est - truth) ** 2), np.sum((con[s - s0:e - s0, m] - truth) ** 2)]
    return bool(err[1] < err[0])


def _fill_one(pos, out, m, a, b, order, stats, candidates, keep, predictors, constrain,
              limits: TakeLimits | None = None, unit_mm: float = 1.0, smooth: float = 0.0,
              max_error: float = np.inf, first_frame: int = 0, strict: bool = False) -> GapFill | None:
    """Fill marker m's gap a..b-1 of ``pos`` into ``out``; its record, or None when nothing could fill it.

    The fills tried, in turn: the weighted average of the ``keep`` best
    validated models, then each usable model alone, best validated first
    (unvalidated ones last), then the low-rank fill and the room-coordinate
    interpolation. With ``limits`` the first that passes the plausibility
    guard, and whose expected error is at most ``max_error`` (unit of
    ``pos``; with ``strict`` an unknown expected error fails it too), is
    written; when none does, nothing is written and the record says why the
    first failed (``implausible``). The expected error of each fill tried is
    measured on stretches resembling the gap
    (:func:`~mocapkit.cleaning.markers.fill_error.expected_error`); the
    models are ranked and weighted on the two stretches next to it.
    """
    f = pos.shape[0]
    rigid = donors_allowed(stats, m, unit_mm)
    models = _models(pos, m, a, b, order, candidates, predictors, rigid)
    fills = _fills(pos, m, a, b, models, order, stats)
    note = ""
    if not any(est is not None and g for (g, _, _), est in zip(models, fills)):
        # no donor group could fill (too few seen, or degenerate): the room-coordinate and low-rank fills and the
        # offset from each of the two most rigidly attached markers seen throughout the gap (pattern fill) compete
        span = slice(max(a - 1, 0), min(b + 1, f))
        seen_gap = ~np.any(np.isnan(pos[span]), axis=(0, 2))
        seen_gap[m] = False
        near = [int(d) for d in order[m] if d != m and seen_gap[d] and rigid[d]][:2]
        loose = int(np.count_nonzero(seen_gap & ~rigid))
        if loose and np.count_nonzero(seen_gap & rigid) < 3:
            note = (f"{np.count_nonzero(seen_gap & rigid)} rigid donors seen throughout the gap; {loose} other seen "
                    f"markers not taken as donors: their distance to it varies over the take by more than "
                    f"{MAX_DONOR_SPREAD_MM:.0f} mm (another body, or a prop)")
        extra = [((), "linear", None), ((), "lowrank", None)] + [((d,), "linear", None) for d in near]
        models += extra
        fills += _fills(pos, m, a, b, extra, order, stats)
    spans = _validation_spans(pos, m, a, b)
    side = -1 if b == f else (1 if a == 0 else 0)  # a gap at the take's end is validated from one end too
    checks = [_fills(pos, m, s, e, models, order, stats, side) for s, e in spans]
    usable = [i for i, est in enumerate(fills) if est is not None]
    tries = []  # (fill, method, donors, expected error, validated fills of the spans or None)
    averaged = 1
    if usable:
        errs = np.full(len(models), np.inf)
        for i in usable:
            err = [np.mean(np.sum((c[i] - pos[s:e, m]) ** 2, axis=-1)) for (s, e), c in zip(spans, checks) if c[i] is not None]
            if err:
                errs[i] = np.sqrt(np.mean(err))
        if np.all(np.isinf(errs)):
            best, w = [usable[0]], np.ones(1)
        else:
            best = [int(i) for i in np.argsort(errs, kind="stable")[:keep] if np.isfinite(errs[i])]
            w = 1.0 / np.maximum(errs[best], 1e-6) ** 2
        validated = []
        for (s, e), c in zip(spans, checks):
            est = average([c[i] for i in best], w)  # the models that filled this stretch, weights renormalised
            if est is not None:
                validated.append((s, e, est))
        tries.append((average([fills[i] for i in best], w), best[0], validated))
        averaged = len(best)
        alone = sorted(usable, key=lambda i: errs[i])  # stable: unvalidated (inf) ones last, in model order
        tries += [(fills[i], i, [(s, e, c[i]) for (s, e), c in zip(spans, checks) if c[i] is not None]) for i in alone]
        recipes = [(best, w)] + [([i], np.ones(1)) for i in alone]
        tries = [(est, _method(models[i]), models[i][0], float(errs[i]) if np.isfinite(errs[i]) else float("nan"), v)
                 for est, i, v in tries]
        if validated and len(best) > 1:  # the average's own error on the validation gaps, not its best model's
            own = [np.mean(np.sum((v - pos[s:e, m]) ** 2, axis=-1)) for s, e, v in validated]
            tries[0] = tries[0][:3] + (float(np.sqrt(np.mean(own))),) + tries[0][4:]
    else:
        est = _lowrank_fill(pos, m, a, b, order, stats)
        if est is not None:
            tries.append((est, "lowrank", (), float("nan"), None))
        seen = ~np.any(np.isnan(pos[:, m]), axis=-1)
        t = np.flatnonzero(seen)
        if t.size:
            est = np.stack([np.interp(np.arange(a, b), t, pos[t, m, c]) for c in range(3)], axis=-1)
            tries.append((est, "linear", (), float("nan"), None))
    if not tries:
        return None
    first = None
    wide = _validation_spans(pos, m, a, b, SPANS) if usable else []
    parted = 1.0  # how much further the average's models part in the gap: a single model tried next keeps it
    made: dict = {}  # each model's fills of the stretches the expected error is measured on, for every fill tried
    for k, (est, method, donors, ranked, validated) in enumerate(tries):
        if k and len(tries) > 1 and np.array_equal(est, tries[0][0]):
            continue  # the average of one model is that model: tried already
        expected, basis = ranked, ""
        if usable and np.isfinite(ranked):  # measured on stretches that resemble the gap (fill_error)
            chosen, weights = recipes[k]
            # the ranking's stretches are filled already: only a low-rank fill sees the gap's other hidden markers
            known = ({} if any(models[i][1] == "lowrank" for i in chosen) else
                     {span: [c[i] for i in chosen] for span, c in zip(spans, checks)})
            expected, basis, parted = expected_error(pos, m, a, b, wide, [fills[i] for i in chosen], weights,
                                                     _recipe(m, models, chosen, order, stats, side, known, made),
                                                     parted)
        why = ""
        # a limit given is checked on the expected error (an unknown one fails it); the default limits on the error
        # on the two stretches that rank the models, as before 0.18.0: a take cleaned without a limit is unchanged
        judged = expected if strict else ranked
        if (np.isfinite(judged) or (strict and np.isfinite(max_error))) and not judged <= max_error:
            said = ((f"expected error {judged * unit_mm:.0f} mm, over" if strict else
                     f"error {judged * unit_mm:.0f} mm on the stretches next to the gap, over")
                    if np.isfinite(judged) else
                    "expected error unknown (no seen stretch to validate on), so not within")
            whose = ("the limit given: --max-fill-error, max_error_mm= in Python" if strict else
                     "the distance to its nearest marker; --max-fill-error, max_error_mm= in Python")
            why = f"{said} the {max_error * unit_mm:.0f} mm a fill may be off ({whose})"
        elif limits is not None:
            why = implausible(pos, m, a, b, est, limits, unit_mm, first_frame)
        rec = GapFill(m, a, b, method, tuple(donors), expected, False, why, averaged if k == 0 else 1, note, basis)
        first = first or rec
        if why:
            continue
        out[a:b, m] = est
        helps = constrain and validated is not None and _constraint_helps(pos, m, validated, stats, order, smooth)
        return replace(rec, constrained=bool(helps))
    return first


def _recipe(m: int, models, chosen, order: np.ndarray, stats: DistanceStats, side: int, known=None, made=None):
    """The written fill's recipe as a function ``(pos, s, e)`` -> the fills of marker m's frames s..e-1 by the
    ``chosen`` of ``models`` (None where one cannot fill them), as the gap's were made (``side``: from one end).
    ``known``: {(s, e): those fills} already made (the ranking's stretches, where the gap's hidden markers change
    none). ``made``: {(s, e, i): model i's fill} kept across the fills tried for one gap, whose stretches all get the
    same take with the same missing pattern copied on (:func:`~mocapkit.cleaning.markers.fill_error.span_errors`):
    a model tried alone after the average that failed is not fitted again on the stretches the average measured it
    on. Each model's fill is its own (:func:`_fills`), so it is the same bits fitted with the others or alone."""
    known = known or {}
    made = {} if made is None else made

    def fill(pos, s, e):
        if (s, e) in known:
            return known[(s, e)]
        todo = [i for i in chosen if (s, e, i) not in made]
        if todo:
            made.update(((s, e, i), est) for i, est in
                        zip(todo, _fills(pos, m, s, e, [models[i] for i in todo], order, stats, side)))
        return [made[(s, e, i)] for i in chosen]
    return fill


def _method(model) -> str:
    """The name a model's fill is reported by (see :class:`GapFill`)."""
    g, kind, _ = model
    return {"regress": "regression", "lowrank": "lowrank"}.get(kind, "donors" if g else kind)
