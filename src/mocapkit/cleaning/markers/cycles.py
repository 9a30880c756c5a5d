"""Labels cycled at one frame: three or more markers that each took another's trajectory.

When a labeller mixes up several markers at once (a cluster of close
markers after an occlusion, two swaps that share a marker back to back),
the labels move round a cycle at one frame: LTOE gets RTHI's trajectory,
RTHI gets LKNE's and LKNE gets LTOE's (a cycle of three), or four or more
labels round one ring. No exchange of two explains such a frame. The walk
of :func:`~mocapkit.cleaning.markers.swaps.undo_swaps` finds the cycles
among the markers whose jumps no pair explained (:func:`find_cycles`) and
undoes each as exchanges of two made one after the other
(:func:`as_exchanges`); each exchange is listed as its own swap, which a
person can reject on its own.

A cycle can also start where one of its markers is hidden (an occlusion at
the frame the labels move): that marker has no prediction to meet, so the
cycle shows as an open chain of jumps, one marker's sample meeting
another's prediction and a third jump that nothing explains.
:func:`hidden_member_cycles` lists the cycles of three that close such a
chain through a marker hidden there; which of them (if any) is taken is
left to the rigid-neighbour evidence of the caller (Tits, Tilmanne and
Dutoit 2018, PLoS ONE 13(7): e0199744: distances to rigidly attached
markers stay near their usual values).

Positions are (F, M, 3), frames first, NaN for unseen samples; a cycle is
a tuple of marker columns ``(c0, c1, ..., ck-1)`` in which each marker's
corrected trajectory is the next one's recorded sample: column ``c0``
takes ``c1``'s samples, ``c1`` takes ``c2``'s, ..., ``ck-1`` takes ``c0``'s.
"""

from __future__ import annotations

import numpy as np

__all__ = ["find_cycles", "as_exchanges", "apply_exchanges", "hidden_member_cycles"]


def _fits(pred: np.ndarray, samples: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """(K, K): ``fit[r, c]`` the distance of marker idx[c]'s sample from the nearest of marker idx[r]'s predictions.

    ``pred`` (P, M, 3), ``samples`` (M, 3); NaN where a prediction or a sample is missing.
    """
    d = np.linalg.norm(samples[idx][None, None] - pred[:, idx][:, :, None], axis=-1)
    return np.fmin.reduce(d, axis=0)


def find_cycles(pred: np.ndarray, samples: np.ndarray, free: list[int], miss: np.ndarray,
                thr: float) -> list[tuple[int, ...]]:
    """Cycles of three or more jumping markers whose labels moved round at one frame, none sharing a marker.

    ``pred`` (P, M, 3): each marker's predictions of the frame; ``samples``
    (M, 3): its samples; ``free``: the jumping markers no exchange of two
    explained; ``miss`` (M,): each sample's distance from its own
    predictions; ``thr``: the jump threshold (capture unit). The
    re-labelling that explains the most jumps at the least total distance is
    found as an assignment (scipy's ``linear_sum_assignment``: marker r takes
    marker c's sample at the cost of c's sample's distance from r's
    predictions, allowed within ``thr``; keeping its own sample costs its
    miss). A cycle of it is kept when it has three or more markers and its
    total distance is under a third of their summed misses, the test an
    exchange of two must pass.
    """
    if len(free) < 3:
        return []
    idx = np.asarray(free)
    fit = _fits(pred, samples, idx)
    big = 1e6 * (np.nansum(miss[idx]) + 1.0)
    cost = np.where(np.nan_to_num(fit, nan=np.inf) <= thr, fit, big)
    np.fill_diagonal(cost, miss[idx])
    from scipy.optimize import linear_sum_assignment  # here: importing scipy.optimize takes ~0.3 s

    rows, cols = linear_sum_assignment(cost)
    take = dict(zip(rows.tolist(), cols.tolist()))  # row r takes col take[r]'s sample
    out, seen = [], set()
    for r0 in range(idx.size):
        if r0 in seen or take[r0] == r0:
            continue
        ring = [r0]
        while take[ring[-1]] != r0:
            ring.append(take[ring[-1]])
        seen.update(ring)
        total = sum(cost[r, take[r]] for r in ring)
        if len(ring) >= 3 and total < big and total < miss[idx[ring]].sum() / 3.0:
            out.append(tuple(int(idx[r]) for r in ring))
    return out


def apply_exchanges(cols: np.ndarray, exchanges) -> np.ndarray:
    """``cols`` (..., M) with each exchange (a, b) of ``exchanges`` made in turn on its last axis."""
    out = np.array(cols, copy=True)
    for a, b in exchanges:
        out[..., [a, b]] = out[..., [b, a]]
    return out


def as_exchanges(cycle: tuple[int, ...], open_swaps) -> list[tuple[int, int]]:
    """The cycle (see the module) as exchanges of two made one after the other, those that end open swaps first.

    A cycle of k markers is k - 1 exchanges; each ring of them read from
    each of its markers, either way round (``(i j), (j k), ...``), is tried,
    and of the sequences that give the cycle the one whose leading exchanges
    end swaps seen to start (``open_swaps``: pairs ``a < b``) is taken, so
    that a chain is read as swaps ending where the next begin and a cycle
    undone at its end closes the exchanges that opened it. Pairs ``a < b``.
    """
    k = len(cycle)
    m = max(cycle) + 1
    want = np.arange(m)
    want[list(cycle)] = [cycle[(n + 1) % k] for n in range(k)]
    key = lambda p: (min(p), max(p))  # noqa: E731
    ways = []
    for ring in (list(cycle), list(cycle)[::-1]):
        for r in range(k):
            rot = ring[r:] + ring[:r]
            way = [key((rot[n], rot[n + 1])) for n in range(k - 1)]
            if np.array_equal(apply_exchanges(np.arange(m), way), want):
                ways.append(way)
    return max(ways, key=lambda w: tuple(p in open_swaps for p in w))


def hidden_member_cycles(pred: np.ndarray, samples: np.ndarray, free: list[int], blind: np.ndarray,
                         thr: float) -> list[tuple[int, int, int]]:
    """Cycles of three that close an open chain of jumps through a marker hidden at the frame.

    ``free``: the jumping markers nothing else explained; ``blind`` (M,)
    bool: the markers with no prediction or no sample at the frame (unseen
    there or in one of the two frames before). ``(r, c, h)``: c's sample
    meets r's prediction within ``thr``, and h, hidden, closes the ring (r
    takes c's samples, c takes h's, h takes r's). h's sample, where it is
    seen, must meet c's prediction; r's cannot be checked (h has no
    prediction). Every candidate is returned: the caller judges them.
    """
    hidden = np.flatnonzero(blind)
    if len(free) < 2 or hidden.size == 0:
        return []
    idx = np.asarray(free)
    fit = _fits(pred, samples, idx)
    out = []
    for r, c in zip(*np.nonzero(np.nan_to_num(fit, nan=np.inf) <= thr)):
        if r == c:
            continue
        for h in hidden:
            back = np.fmin.reduce(np.linalg.norm(samples[h] - pred[:, idx[c]], axis=-1))
            if np.isnan(back) or back <= thr:
                out.append((int(idx[r]), int(idx[c]), int(h)))
    return out
