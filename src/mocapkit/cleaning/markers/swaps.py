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
the other was going, which two unrelated jumps almost never do. Two swaps
that share a marker back to back (LTOE/RTHI up to frame 199, RTHI/LKNE from
200) cycle three labels at the frame between them, and a labeller can
cycle four or more at once, which no exchange of two explains: the cycles
among the jumping markers no pair explained
(:func:`~mocapkit.cleaning.markers.cycles.find_cycles`, the same tests) are
re-labelled as exchanges of two made one after the other
(:func:`~mocapkit.cleaning.markers.cycles.as_exchanges`). A cycle of three
whose start one of its labels hides (unseen at the frame it starts, so
that only an open chain of two jumps shows) is closed through that label
(:func:`~mocapkit.cleaning.markers.cycles.hidden_member_cycles`) when the
rigid neighbours say so (:func:`_hidden_cycle`). An exchange
that starts a swap is undone by the one that ends it, so the corrected
trajectories are the recorded samples, re-labelled: the values stay
bit-identical.

One end of a swap can be hidden from the jump test: a marker that comes
back from an occlusion under the other's label has no prediction to miss,
and two markers that pass within the threshold of each other make no jump
worth the name. An exchange seen at one end only is then either the start
of a swap that runs to a hidden end, or the end of one that began at a
hidden start. Each candidate hidden boundary (the first and the last frame
of an occlusion of either marker, the closest approach of a near pass) is
judged by the rigid-cluster consistency of the two labellings over the
whole stretch: the labelling under which the pair's distances to their
most rigidly attached markers (:mod:`~mocapkit.cleaning.markers.rigid`)
stay most constant wins, whichever of the two holds in most of the frames
(distances kept near their usual values are the soft skeleton constraints
of Tits, Tilmanne and Dutoit 2018, PLoS ONE 13(7): e0199744). Without such
evidence (two markers placed symmetrically about their neighbours, or with
no rigid neighbours), a swap seen only at its start runs to the end of the
take, as before.

Positions are (F, M, 3), frames first, NaN for unseen samples.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from .cycles import apply_exchanges, as_exchanges, find_cycles, hidden_member_cycles
from .rigid import distance_stats, donor_order

__all__ = ["Swap", "undo_swaps", "recorded_swaps", "labelling"]


@dataclass(frozen=True)
class Swap:
    """Markers ``a`` and ``b`` exchanged their labels for frames ``start <= f < end``; ``distance`` between them at ``start`` (capture unit).

    ``order``: where the swap comes among the take's swaps when they are
    composed (:func:`labelling`: by ``order``, then first frame). 0 but for a
    swap the labeller made on top of one that starts after it and shares a
    marker over shared frames (RTHI/LKNE over 150-249 made first, LTOE/RTHI
    over 100-199 on top: the latter's order is 1).
    """

    a: int
    b: int
    start: int
    end: int
    distance: float
    order: int = 0


def labelling(swaps, markers: int, frames: int) -> np.ndarray:
    """(F, M) int: the recorded column each corrected column holds at each frame, given ``swaps``.

    ``swaps``: objects with ``a``, ``b`` (recorded columns), ``start``, ``end``
    (frames) and ``order``, composed by ``(order, start, a, b)``: each
    exchanges the two recorded trajectories it names over its frames,
    wherever the swaps before it put them. :func:`recorded_swaps` is its
    inverse.
    """
    src = np.tile(np.arange(markers, dtype=np.int64), (frames, 1))
    for x in sorted(swaps, key=lambda x: (x.order, x.start, x.a, x.b)):
        seg = src[x.start:x.end]
        src[x.start:x.end] = np.where(seg == x.a, x.b, np.where(seg == x.b, x.a, seg))
    return src


def _predictions(y: np.ndarray, t: int) -> np.ndarray:
    """(P, M, 3) predictions of frame t.

    Constant velocity from frames t-2 and t-1 and, where t >= 3, constant
    acceleration from t-3 to t-1.
    """
    cv = 2.0 * y[t - 1] - y[t - 2]
    if t < 3:
        return cv[None]
    return np.stack([cv, 3.0 * y[t - 1] - 3.0 * y[t - 2] + y[t - 3]])


def _miss(pred: np.ndarray, samples: np.ndarray) -> np.ndarray:
    """(M,) distance of ``samples`` (M, 3) from the nearest of the predictions ``pred`` (P, M, 3).

    A prediction that needs an unseen frame is skipped; NaN where none can be made or the sample is unseen.
    """
    return np.fmin.reduce(np.linalg.norm(samples[None] - pred, axis=-1), axis=0)


def undo_swaps(positions: np.ndarray, unit_mm: float = 1.0, *, threshold_mm: float = 15.0,
               ratio: float = 0.8) -> tuple[np.ndarray, list[Swap]]:
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
    ratio : float
        A swap seen at one end only gets a hidden other end (an occlusion,
        or the two markers within the threshold) when its distances to the
        rigid neighbours then stay more constant than with the walk's
        default: under ``ratio`` times its cost (:func:`_constancy`).

    Returns
    -------
    corrected : float array (F, M, 3)
        The samples with swapped labels exchanged back (the same values, re-labelled).
    swaps : list of Swap
        One per swapped interval (a swap seen only at its start whose end
        nothing shows runs to the last frame).
    """
    x = np.asarray(positions, dtype=np.float64)
    f = x.shape[0]
    y = x.copy()
    if f < 3:
        return y, []
    col = np.tile(np.arange(x.shape[1]), (f, 1))  # the recorded column each column of y holds, per frame
    thr = threshold_mm / unit_mm
    floor = 2.0 / unit_mm  # the smallest spread a distance is judged by (2 mm)
    with np.errstate(invalid="ignore"):
        raw = np.linalg.norm(x[2:] - (2.0 * x[1:-1] - x[:-2]), axis=-1)  # (F-2, M)
        acc = np.full_like(raw, np.nan)
        acc[1:] = np.linalg.norm(x[3:] - (3.0 * x[2:-1] - 3.0 * x[1:-2] + x[:-3]), axis=-1)
        jumping = np.nan_to_num(np.fmin(raw, acc), nan=0.0) > thr
    frames = np.flatnonzero(jumping.sum(axis=1) >= 2) + 2
    open_swaps: dict[tuple[int, int], tuple[int, float]] = {}
    swaps: list[Swap] = []
    last: dict[int, int] = {}  # marker -> the frame of its latest exchange
    stats = order = None
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
        steps = []  # (a, b, whether a hidden start may be looked for): the exchanges to make at t, in order
        for _, a, b in sorted(pairs):
            if a not in used and b not in used:
                used.update((a, b))
                steps.append((a, b, True))
        for cycle in find_cycles(pred, y[t], [int(k) for k in jump if k not in used], miss, thr):
            used.update(cycle)
            pairs_of = as_exchanges(cycle, open_swaps)
            start = None
            if not any(pair in open_swaps for pair in pairs_of):  # it ends no swap seen to start: a hidden start?
                if stats is None:
                    stats = distance_stats(x)
                    order = donor_order(stats)
                start = _hidden_cycle_start(y, cycle, int(t), jumping, last, thr, stats, order, ratio, floor)
            if start is None:
                steps += [(*pair, False) for pair in pairs_of]
                continue
            y[start:t] = apply_exchanges(y[start:t].transpose(0, 2, 1), pairs_of[::-1]).transpose(0, 2, 1)
            col[start:t] = apply_exchanges(col[start:t], pairs_of[::-1])
            last.update((k, int(t)) for k in cycle)
        free = [int(k) for k in jump if k not in used]
        cands = hidden_member_cycles(pred, y[t], free, _blind(y, t) & ~np.isin(np.arange(y.shape[1]), list(used)), thr)
        if cands:
            if stats is None:
                stats = distance_stats(x)
                order = donor_order(stats)
            cycle = _hidden_cycle(y, cands, int(t), jumping, last, stats, order, ratio, floor)
            if cycle is not None:
                steps += [(*pair, False) for pair in as_exchanges(cycle, open_swaps)]
        for a, b, may_hide in steps:
            key = (a, b)
            if key in open_swaps:  # the end of a swap whose start was seen
                y[t:, [a, b]] = y[t:, [b, a]]
                col[t:, [a, b]] = col[t:, [b, a]]
                s, dist = open_swaps.pop(key)
                swaps.append(Swap(a, b, s, int(t), dist))
                last[a] = last[b] = int(t)
                continue
            if stats is None:
                stats = distance_stats(x)
                order = donor_order(stats)
            after = np.flatnonzero(jumping[t + 1:, [a, b]].any(axis=1)) + t + 3  # jumping[k] is frame k + 2
            hi = int(after[0]) if after.size else f
            start = None if not may_hide else _hidden_start(y, a, b, int(t), max(last.get(a, 0), last.get(b, 0)),
                                                            hi, thr, stats, order, ratio, floor)
            if start is not None:  # the end of a swap whose start was hidden
                y[start:t, [a, b]] = y[start:t, [b, a]]
                col[start:t, [a, b]] = col[start:t, [b, a]]
                swaps.append(Swap(a, b, start, int(t), _first_distance(y, a, b, start, int(t), x)))
                last[a] = last[b] = int(t)
                continue
            y[t:, [a, b]] = y[t:, [b, a]]
            col[t:, [a, b]] = col[t:, [b, a]]
            open_swaps[key] = (int(t), float(np.linalg.norm(x[t, a] - x[t, b])))
            last[a] = last[b] = int(t)
    for (a, b), (t, dist) in sorted(open_swaps.items(), key=lambda kv: kv[1][0]):
        if stats is None:
            stats = distance_stats(x)
            order = donor_order(stats)
        later = max(last.get(a, 0), last.get(b, 0)) > t  # a later exchange was found in this labelling
        lo = max([sw.end for sw in swaps if {sw.a, sw.b} & {a, b} and sw.end <= t] + [0])
        end = f if later else _hidden_end(y, a, b, t, lo, thr, stats, order, ratio, floor)
        if end < f:  # the exchange is undone from a hidden end on
            y[end:, [a, b]] = y[end:, [b, a]]
            col[end:, [a, b]] = col[end:, [b, a]]
        swaps.append(Swap(a, b, t, end, dist))
    return y, recorded_swaps(col, x)


def recorded_swaps(col: np.ndarray, x: np.ndarray) -> list[Swap]:
    """The swaps of recorded trajectories that give the labelling ``col``, one per swapped interval.

    ``col`` (F, M) int: the recorded column each corrected column holds at
    each frame; ``x`` (F, M, 3): the recorded positions (for the distances).
    Each Swap names two recorded trajectories (columns of ``x``), ``a < b``,
    and the frames where their labels are exchanged; composed by
    :func:`labelling` (by ``order``, then first frame, each exchanging the
    two trajectories wherever the swaps before it put them), they give
    ``col`` back. Chained swaps are so listed as the labeller's errors, each
    of which a person can accept or reject without the other: LTOE/RTHI
    swapped over frames 100-199 and RTHI/LKNE over 150-249 (three labels
    cycled in 150-199), or back to back, RTHI/LKNE over 200-299; and a chain
    whose later swap was made first (RTHI/LKNE over 150-249, then LTOE/RTHI
    over 100-199 on top of it: that one gets ``order`` 1). The walk of
    :func:`undo_swaps` sees such a chain as exchanges of its own corrected
    columns (LTOE/LKNE from frame 150), which name no recorded pair.

    At each frame where the labelling changes, the change (a permutation of
    recorded trajectories) first ends the open swaps it contains, then opens
    a swap per exchange left. An open swap is ended as the last made, seen
    through the swaps opened after it; else, where that does not fit, as
    made before them (the swaps opened after it then exchange the
    trajectories it put under their labels, and come first in the order).
    Where a listing with the latter does not give ``col`` back, the former
    alone is used.
    """
    for under in (True, False):
        swaps = _listing(col, x, under)
        if np.array_equal(labelling(swaps, col.shape[1], col.shape[0]), col):
            break
    return swaps


def _listing(col: np.ndarray, x: np.ndarray, under: bool) -> list[Swap]:
    """:func:`recorded_swaps`' walk; ``under``: an open swap may end as made before those opened after it."""
    f, m = col.shape
    ident = np.arange(m)
    recs: list[list[int]] = []  # [u, v, start, end] of every swap
    seq: list[int] = []  # indexes into recs, in the order the swaps are composed
    active: list[int] = []  # the open ones, in that order
    prev = ident
    changed = np.flatnonzero(np.any(col != np.vstack([ident[None], col[:-1]]), axis=1))
    for t in changed:
        inv = np.empty(m, dtype=np.int64)
        inv[prev] = ident
        tau = col[t][inv]  # the change: col[t] = tau o prev, as maps of recorded columns
        closing = True
        while closing and np.any(tau != ident):
            closing = False
            for first in (True, False) if under else (True,):
                for i in range(len(active)):
                    u, v = recs[active[i]][:2]
                    later = ident.copy()  # the swaps opened after i, composed: where they put u and v
                    if first:
                        for k in active[i + 1:]:
                            later = np.where(later == recs[k][0], recs[k][1],
                                             np.where(later == recs[k][1], recs[k][0], later))
                    p, q = later[u], later[v]
                    rest = tau.copy()
                    rest[[p, q]] = tau[[q, p]]  # tau o (p q): what is left once swap i ends
                    if np.sum(rest != ident) >= np.sum(tau != ident):
                        continue
                    if not first:  # made before the ones opened after it: they exchange what it put there
                        moved = active[i + 1:]
                        for k in moved:
                            recs[k][:2] = sorted(int(np.where(w == u, v, np.where(w == v, u, w)))
                                                 for w in recs[k][:2])
                        seq = [k for k in seq if k not in moved]
                        seq[seq.index(active[i]):seq.index(active[i])] = moved
                    recs[active.pop(i)][3] = int(t)
                    tau, closing = rest, True
                    break
                if closing:
                    break
        opened = []
        while np.any(tau != ident):  # the exchanges left, peeled off the last applied first
            u = int(np.flatnonzero(tau != ident)[0])
            v = int(tau[u])
            recs.append([min(u, v), max(u, v), int(t), f])
            opened.append(len(recs) - 1)
            tau = np.where(tau == u, v, np.where(tau == v, u, tau))  # (u v) o tau: u now stays
        active += opened[::-1]
        seq += opened[::-1]
        prev = col[t]
    order = {}
    for n, k in enumerate(seq):  # the least order that composes each after the ones it overlaps and follows
        u, v, s0, e = recs[k]
        order[k] = max([order[j] + ((recs[j][2], recs[j][0], recs[j][1]) > (s0, u, v)) for j in seq[:n]
                        if {u, v} & set(recs[j][:2]) and recs[j][2] < e and s0 < recs[j][3]] + [0])
    swaps = []
    for k, (u, v, s0, e) in enumerate(recs):
        d = np.linalg.norm(x[s0:e, u] - x[s0:e, v], axis=-1)
        seen = np.flatnonzero(~np.isnan(d))
        swaps.append(Swap(u, v, s0, e, float(d[seen[0]]) if seen.size else float("nan"), int(order[k])))
    swaps.sort(key=lambda s: (s.start, s.a, s.b))
    return swaps


def _hidden_boundaries(p: np.ndarray, a: int, b: int, thr: float) -> np.ndarray:
    """(F+1,) bool: an exchange of a and b from frame u on would not show as two jumps.

    True at the take's ends, where either marker is unseen at u-2, u-1 or u
    (no prediction to miss: a marker often comes back from an occlusion under
    the wrong label), and where the two are closer than ``thr`` (the jump is
    no bigger than noise).
    """
    f = p.shape[0]
    unseen = np.any(np.isnan(p[:, [a, b]]), axis=(1, 2))
    with np.errstate(invalid="ignore"):
        near = np.linalg.norm(p[:, a] - p[:, b], axis=-1) < thr
    blind = unseen.copy()  # unseen at u, u-1 or u-2
    blind[1:] |= unseen[:-1]
    blind[2:] |= unseen[:-2]
    hidden = np.ones(f + 1, dtype=bool)
    hidden[1:f] = (blind | near)[1:]
    return hidden


def _first_distance(y: np.ndarray, a: int, b: int, start: int, end: int, fallback: np.ndarray) -> float:
    """Distance between markers a and b at the first frame of start..end-1 where both are seen."""
    d = np.linalg.norm(y[start:end, a] - y[start:end, b], axis=-1)
    seen = np.flatnonzero(~np.isnan(d))
    return float(d[seen[0]]) if seen.size else float(np.linalg.norm(fallback[start, a] - fallback[start, b]))


def _candidates(p: np.ndarray, a: int, b: int, thr: float, offset: int) -> np.ndarray:
    """One hidden boundary per run of them (:func:`_hidden_boundaries` of ``p``, frames numbered from ``offset``).

    In a run caused by an occlusion there are two: its first unseen frame
    and the first frame after its last unseen one (a marker comes back
    under the wrong label there); in a run where the two markers pass
    within ``thr``, their closest approach; at the ends of ``p``, the end
    itself.
    """
    f = p.shape[0]
    hidden = _hidden_boundaries(p, a, b, thr)
    unseen = np.any(np.isnan(p[:, [a, b]]), axis=(1, 2))
    with np.errstate(invalid="ignore"):
        dist = np.nan_to_num(np.linalg.norm(p[:, a] - p[:, b], axis=-1), nan=np.inf)
    d = np.diff(np.concatenate([[0], hidden.astype(np.int8), [0]]))
    out = []
    for lo, hi in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
        ends = [u for u, edge in ((0, lo == 0), (f, hi == f + 1)) if edge]
        out += ends
        inner = slice(max(lo, 1), min(hi, f))
        gone = np.flatnonzero(unseen[inner]) + inner.start
        if gone.size:  # the labels may change as the occlusion starts or as it ends
            out += [int(gone[0]), int(gone[-1]) + 1]
        elif not ends:
            out.append(inner.start + int(np.argmin(dist[inner])))
    return np.unique(np.asarray(out, dtype=int)) + offset


def _constancy(p: np.ndarray, members, nbrs, scale: np.ndarray) -> float:
    """How much the distances of ``members`` (columns of ``p``) to their rigid neighbours ``nbrs`` vary.

    Each distance's mean absolute deviation from its median over the
    frames, in units of its usual spread ``scale`` (M, M), summed. The
    labelling of the members under which these distances stay most
    constant over a stretch of the take is the right one, whichever
    labelling holds in most of its frames.
    """
    total = 0.0
    for k, ns in zip(members, nbrs):
        d = np.linalg.norm(p[:, [k]] - p[:, ns], axis=-1)
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a neighbour unseen throughout: all-NaN columns
            dev = np.nanmean(np.abs(d - np.nanmedian(d, axis=0)), axis=0)
        total += float(np.nansum(dev / scale[k, ns]))
    return total


def _blind(y: np.ndarray, t: int) -> np.ndarray:
    """(M,) bool: the markers unseen at frame t, t-1 or t-2 (no sample or no prediction to test for a jump)."""
    return np.any(np.isnan(y[max(t - 2, 0):t + 1]), axis=(0, 2))


def _ring_window(y: np.ndarray, ring, lo: int, hi: int, stats, order: np.ndarray, floor: float, count: int = 4):
    """Frames lo..hi-1 of the markers ``ring`` (as columns 0..k-1) and of their ``count`` most rigid neighbours.

    Returns those positions, each ring marker's neighbours (the ring's own
    left out) renumbered to match, and their usual spreads (at least
    ``floor``), as :func:`_constancy` takes them.
    """
    nbrs = [[int(n) for n in order[k] if n not in ring and np.isfinite(stats.median[k, n])][:count] for k in ring]
    cols = list(ring) + sorted({n for ns in nbrs for n in ns})
    pos = {c: n for n, c in enumerate(cols)}
    scale = np.maximum(np.nan_to_num(stats.spread, nan=np.inf), floor)
    return y[lo:hi][:, cols], [[pos[n] for n in ns] for ns in nbrs], scale[np.ix_(cols, cols)]


def _seen_either_side(win: np.ndarray, k: int, t: int) -> bool:
    """Whether each of the first ``k`` columns of ``win`` (F, K, 3) is seen in at least half the frames before ``t``
    and in half those from ``t`` on: a labelling that puts a marker's samples under a label unseen most of the
    time would only look constant for want of distances to measure."""
    seen = ~np.isnan(win[:, :k]).any(axis=-1)
    return bool(t > 0 and t < win.shape[0] and np.all(seen[:t].mean(axis=0) >= 0.5)
                and np.all(seen[t:].mean(axis=0) >= 0.5))


def _hidden_cycle_start(y: np.ndarray, cycle, t: int, jumping: np.ndarray, last: dict, thr: float, stats,
                        order: np.ndarray, ratio: float, floor: float) -> int | None:
    """Where a cycle of labels seen at t (:func:`~mocapkit.cleaning.markers.cycles.find_cycles`) began, if it ends at t.

    As :func:`_hidden_start` for a pair: a cycle seen at t with no swap of
    its markers open either starts there or ends one whose start an
    occlusion hid (a marker back from it under another's label). For each
    candidate start s (:func:`_candidates` of each two markers next in the
    cycle, after the markers' latest exchange), the labelling with s..t-1
    cycled back is set against the one with t on cycled, over the frames
    from that exchange to the next jump of any of them, by how constant the
    markers' distances to their rigid neighbours (the cycle's own left out)
    stay; the best start is taken when its cost is under ``ratio`` times
    the other's. None: the cycle starts at t.
    """
    f, k = y.shape[0], len(cycle)
    lo = max(last.get(c, 0) for c in cycle)
    starts = np.unique(np.concatenate([_candidates(y[lo:t], cycle[n], cycle[(n + 1) % k], thr, lo) for n in range(k)]))
    starts = starts[(starts > lo) & (starts < t)]
    if starts.size == 0:
        return None
    after = np.flatnonzero(jumping[t + 1:, list(cycle)].any(axis=1)) + t + 3  # jumping[k] is frame k + 2
    hi = int(after[0]) if after.size else f
    win, local, sc = _ring_window(y, cycle, lo, hi, stats, order, floor)
    if not _seen_either_side(win, k, t - lo):
        return None
    ring, back = list(range(k)), list(range(1, k)) + [0]
    moved = win.copy()
    moved[t - lo:, ring] = win[t - lo:, back]  # each takes the next one's samples from t on
    best, where = ratio * _constancy(moved, ring, local, sc), None
    for s in starts:
        q = win.copy()
        q[s - lo:t - lo, back] = win[s - lo:t - lo, ring]  # the next one takes each one's samples before t
        c = _constancy(q, ring, local, sc)
        if c < best:
            best, where = c, int(s)
    return where


def _hidden_cycle(y: np.ndarray, cands, t: int, jumping: np.ndarray, last: dict, stats, order: np.ndarray,
                  ratio: float, floor: float):
    """Of the cycles ``cands`` (:func:`~mocapkit.cleaning.markers.cycles.hidden_member_cycles`), the one to undo at t.

    Each cycle's markers are taken over as many frames either side of t
    as lie between the latest exchange of any of them and the next frame
    where one jumps (so that neither labelling holds in most of them); the
    cycle undone from t on is set against the recorded labels by how
    constant the markers' distances to their rigid neighbours (the cycle's
    own markers left out) stay (:func:`_constancy`), and the best is taken
    when its cost is under ``ratio`` times the recorded labels'.
    """
    f = y.shape[0]
    best, pick = np.inf, None
    for ring in cands:
        lo = max(last.get(k, 0) for k in ring)
        after = np.flatnonzero(jumping[t + 1:, list(ring)].any(axis=1)) + t + 3  # jumping[k] is frame k + 2
        hi = int(after[0]) if after.size else f
        w = min(t - lo, hi - t)  # as many frames either side of t: neither labelling holds in most of them
        lo, hi = t - w, t + w
        win, local, sc = _ring_window(y, ring, lo, hi, stats, order, floor)
        if not _seen_either_side(win, len(ring), t - lo):
            continue
        members = range(len(ring))
        moved = win.copy()
        moved[t - lo:, [0, 1, 2]] = win[t - lo:, [1, 2, 0]]  # each takes the next one's samples
        c = _constancy(moved, members, local, sc)
        if c < ratio * _constancy(win, members, local, sc) and c < best:
            best, pick = c, ring
    return pick


def _neighbours(order: np.ndarray, stats, a: int, b: int, floor: float,
                count: int = 4) -> tuple[tuple[list[int], list[int]], np.ndarray]:
    """The ``count`` most rigid neighbours of a and of b (the other of the pair left out).

    Also returns the (M, M) usual spreads of the distances, at least ``floor``.
    """
    pick = lambda k, o: [int(n) for n in order[k] if n != o and np.isfinite(stats.median[k, n])][:count]  # noqa: E731
    return (pick(a, b), pick(b, a)), np.maximum(np.nan_to_num(stats.spread, nan=np.inf), floor)


def _local(y: np.ndarray, lo: int, hi: int, a: int, b: int, nbrs: tuple[list[int], list[int]], scale: np.ndarray):
    """Frames lo..hi-1 of a and b (as columns 0 and 1) and of their neighbours only.

    Returns those positions, the neighbour lists and the (K, K) scales renumbered to match.
    """
    cols = [a, b] + sorted((set(nbrs[0]) | set(nbrs[1])) - {a, b})
    pos = {c: k for k, c in enumerate(cols)}
    return (y[lo:hi][:, cols], ([pos[n] for n in nbrs[0]], [pos[n] for n in nbrs[1]]),
            scale[np.ix_(cols, cols)])


def _hidden_start(y: np.ndarray, a: int, b: int, t: int, lo: int, hi: int, thr: float, stats, order: np.ndarray,
                  ratio: float, floor: float) -> int | None:
    """Where a swap of a and b that ends at t began, if its start was hidden and the rigid neighbours say so.

    An exchange seen at t with no open swap of the pair either starts a swap
    (the usual case) or ends one whose start the jump test could not see
    (:func:`_hidden_boundaries`: a marker back from an occlusion under the
    other's label, or the two passing within the threshold). ``y`` holds
    frames ``lo`` (the pair's latest exchange) to t corrected and the
    recorded frames from t on; ``hi`` is the next frame where a or b jumps.
    For each candidate start s (:func:`_candidates`), the labelling with
    s..t-1 exchanged is set against the one with t..hi-1 exchanged, over
    lo..hi-1, by how constant the pair's distances to their rigid
    neighbours stay (:func:`_constancy`); the best start is taken when its
    cost is under ``ratio`` times the other's. None: a swap starts at t.
    """
    starts = _candidates(y[lo:t], a, b, thr, lo)
    starts = starts[(starts > lo) & (starts < t)]  # from lo, it would only exchange the whole stretch
    if starts.size == 0:
        return None
    win, nbrs, scale = _local(y, lo, hi, a, b, *_neighbours(order, stats, a, b, floor))
    after = win.copy()
    after[t - lo:, [0, 1]] = after[t - lo:, [1, 0]]
    best, where = ratio * _constancy(after, (0, 1), nbrs, scale), None
    for s in starts:
        q = win.copy()
        q[s - lo:t - lo, [0, 1]] = q[s - lo:t - lo, [1, 0]]
        c = _constancy(q, (0, 1), nbrs, scale)
        if c < best:
            best, where = c, int(s)
    return where


def _hidden_end(y: np.ndarray, a: int, b: int, t: int, lo: int, thr: float, stats, order: np.ndarray,
                ratio: float, floor: float) -> int:
    """Where a swap of a and b that started at t and never showed its end ends: the take's end, or a hidden boundary.

    ``y`` holds the exchange from t on; ``lo`` is the pair's exchange before
    t. Each candidate end e after t (:func:`_candidates`) is set against the
    take's end over lo..F-1 by :func:`_constancy`; the best is taken when
    its cost is under ``ratio`` times the other's.
    """
    f = y.shape[0]
    ends = _candidates(y[t:], a, b, thr, t)
    ends = ends[(ends > t) & (ends < f)]
    if ends.size == 0:
        return f
    win, nbrs, scale = _local(y, lo, f, a, b, *_neighbours(order, stats, a, b, floor))
    best, where = ratio * _constancy(win, (0, 1), nbrs, scale), f
    for e in ends:
        q = win.copy()
        q[e - lo:, [0, 1]] = q[e - lo:, [1, 0]]
        c = _constancy(q, (0, 1), nbrs, scale)
        if c < best:
            best, where = c, int(e)
    return where
