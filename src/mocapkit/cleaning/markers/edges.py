"""Find glitches at the edges of what is seen: a few wrong samples beside an occlusion or the take's first or last frame.

A marker going behind something, or coming back, is partly hidden: the
camera sees part of the ball, or a reflection beside it, and the centroid
lands centimetres off for a frame or two just before the gap or just after
it. The spike test of :mod:`~mocapkit.cleaning.markers.spikes` judges a run
from the cubic through ``context`` seen samples on *both* sides, so it
cannot judge these runs (nor a spike in the first or last ``context``
frames of a take), and a gap fill then bends towards them.

Here such a run is judged from its one seen side, by the two predictions
the spike test requires both to miss it, in their one-sided forms:

* **in time**: the straight line through the two seen samples next to the
  run on its seen side, extrapolated across it. Those samples and the one
  after them must lie on a line themselves (second difference at most half
  the threshold): a context that holds the jump is no context, and the run
  on its other side is the glitch, judged in its own right.
* **in space**: the marker's coordinates in the moving frame of each triple
  of its 4 most rigid neighbours (Kabsch fit,
  :func:`~mocapkit.cleaning.markers.rigid.local_frames`) at the seen sample
  next to the run, held over the run and mapped back: the one-ended case of
  the rigid-body fill of :mod:`~mocapkit.cleaning.markers.gaps` (Tits,
  Tilmanne and Dutoit 2018, PLoS ONE 13(7): e0199744, on inter-marker
  relations). A fast segment moves its markers together and some triple
  follows it; a glitch moves one marker. As in
  :func:`~mocapkit.cleaning.markers.spikes.rigid_deviation`, the triple that
  best predicts the marker's own never-suspected samples nearby (the same
  prediction, the same number of frames ahead) is allowed its miss there.

A run is a glitch when every one of its samples misses both by more than
the marker's spike threshold, and some neighbour triple is seen to judge it:
where none is, nothing is removed. Each edge gives at most one run (of at
most ``max_len`` samples, starting within ``context`` samples of the edge),
the one that misses most. Positions are (F, M, 3), frames first, NaN for
unseen samples, in the capture's unit.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

from .rigid import from_local, local_frames, to_local

__all__ = ["edge_glitch_mask", "one_sided_rigid_miss"]


def one_sided_rigid_miss(track: np.ndarray, neighbours: np.ndarray, run: np.ndarray, anchor: int,
                         clear: np.ndarray, reach: int = 8) -> float:
    """How far the run of one marker lies from where its rigid neighbours put it, judged from one seen sample.

    ``track`` (F, 3) is the marker's samples, ``neighbours`` (F, K, 3) those
    of its K >= 3 most rigid neighbours (most rigid first), ``run`` the
    frames judged (int array) and ``anchor`` the seen frame next to them on
    their seen side. For each triple of the neighbours seen at the run and
    the anchor, the marker's coordinates in the triple's moving frame at the
    anchor are mapped back at the run's frames; the run's smallest distance
    to that prediction is the triple's miss. ``clear`` (F,) marks the
    marker's samples taken as surely right: the same prediction (the same
    frames ahead, the same direction) is tried on them within ``reach``
    frames of the anchor, away from the run, and the triple that misses them
    least is allowed that miss (its miss lessened by it, never below 0).
    Returns the smallest over triples (capture unit); ``inf`` when fewer than
    3 neighbours are seen there (it cannot be judged).
    """
    f = track.shape[0]
    step = 1 if anchor > run[0] else -1  # the run lies on the side opposite to ``step`` from the anchor
    ahead = np.abs(run - anchor)  # (n,) frames from the anchor to each run sample
    frames = np.concatenate([[anchor], run])
    ok = ~np.any(np.isnan(neighbours[frames]), axis=(0, 2))
    cand = np.flatnonzero(ok)[:4]
    if cand.size < 3:
        return float("inf")
    # validation anchors: a clear sample whose samples at the same offsets are clear too, on the anchor's seen side
    lo, hi = max(anchor - reach, 0), min(anchor + reach + 1, f)
    anchors = np.arange(lo, hi)
    targets = anchors[:, None] - step * ahead[None, :]  # (S, n)
    inside = np.all((targets >= 0) & (targets < f), axis=1)
    anchors, targets = anchors[inside], targets[inside]
    away = np.all(step * (targets - anchor) >= 0, axis=1) & (step * (anchors - anchor) >= 0)
    valid = clear[anchors] & np.all(clear[targets], axis=1) & away
    anchors, targets = anchors[valid], targets[valid]
    best, validated = float("inf"), []
    for g in combinations(cand.tolist(), 3):
        d = neighbours[:, list(g)]
        rot, origin = local_frames(d[frames], d[anchor])
        loc = to_local(track[[anchor]], rot[:1], origin[:1])
        pred = from_local(np.repeat(loc, run.size, axis=0), rot[1:], origin[1:])
        miss = float(np.min(np.linalg.norm(track[run] - pred, axis=-1)))
        best = min(best, miss)
        if anchors.size:
            seen = ~np.any(np.isnan(d[anchors]), axis=(1, 2)) & ~np.any(np.isnan(d[targets]), axis=(1, 2, 3))
            if seen.any():
                a, t = anchors[seen], targets[seen]
                n = t.shape[1]
                ra, oa = local_frames(d[a], d[anchor])
                rt, ot = local_frames(d[t.ravel()], d[anchor])
                la = to_local(track[a], ra, oa)  # (S, 3)
                est = from_local(np.repeat(la, n, axis=0), rt, ot).reshape(t.shape + (3,))
                natural = float(np.max(np.min(np.linalg.norm(track[t] - est, axis=-1), axis=1)))
                validated.append((natural, miss))
    if validated:
        natural, miss = min(validated)
        best = min(best, max(miss - natural, 0.0))
    return best


def _edges(seen: np.ndarray) -> list[tuple[int, int]]:
    """(first, step) of each edge of the seen runs of one marker's ``seen`` (F,): the run's first frame with step +1
    (it follows a gap or the take's start), its last with step -1 (a gap or the take's end follows)."""
    d = np.diff(np.concatenate([[0], seen.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return [(int(s), 1) for s in starts] + [(int(e) - 1, -1) for e in ends]


def edge_glitch_mask(positions: np.ndarray, suspect: np.ndarray, thr: np.ndarray, order: np.ndarray,
                     max_len: int = 5, context: int = 3, reach: int = 8) -> np.ndarray:
    """Boolean (F, M) mask of glitch runs at the edges of the seen runs (see the module's docstring).

    ``positions`` (F, M, 3), NaN where unseen; ``suspect`` (F, M) the samples
    already found to be spikes (neither judged again nor used as context);
    ``thr`` (M,) each marker's spike threshold (capture unit); ``order`` each
    marker's neighbours, most rigid first
    (:func:`~mocapkit.cleaning.markers.rigid.donor_order`); ``max_len`` the
    longest run in frames; ``context`` how far from the edge a run may start
    (and how many seen samples its seen side needs); ``reach`` how far the
    validation of the rigid prediction looks.
    """
    x = np.asarray(positions, dtype=np.float64)
    f, m = x.shape[:2]
    mask = np.zeros((f, m), dtype=bool)
    seen = ~np.any(np.isnan(x), axis=-1)
    clear = seen & ~suspect
    for mk in range(m):
        track = x[:, mk]
        nb = np.asarray([int(d) for d in order[mk] if d != mk])
        if nb.size < 3:
            continue
        neighbours = x[:, nb]
        for edge, step in _edges(seen[:, mk]):
            best, pick = 1.0, None
            for a in range(context):
                for b in range(a + 1, a + max_len + 1):
                    ctx = edge + step * np.arange(b, b + context)  # the seen side: b, b + 1, b + 2 from the edge
                    if ctx[-1] < 0 or ctx[-1] >= f:
                        break
                    if not np.all(clear[ctx, mk]):
                        continue
                    run = edge + step * np.arange(a, b)
                    if not np.all(seen[run, mk]) or np.any(suspect[run, mk]):
                        break
                    p, q, r = track[ctx[0]], track[ctx[1]], track[ctx[2]]
                    if np.linalg.norm(p - 2.0 * q + r) > 0.5 * thr[mk]:  # the context holds a jump
                        continue
                    span = edge + step * np.arange(0, b)  # the run and the samples between it and the edge
                    line = p[None, :] + (p - q)[None, :] * np.abs(span - ctx[0])[:, None]
                    off = np.linalg.norm(track[span] - line, axis=-1)
                    miss = float(np.min(off[a:]))
                    if miss <= best * thr[mk] or np.any(off[:a] > thr[mk]):  # samples left beside the edge go on with it
                        continue
                    rigid = one_sided_rigid_miss(track, neighbours, run, int(ctx[0]), clear[:, mk], reach)
                    score = min(miss, rigid) / thr[mk]
                    if np.isfinite(rigid) and score > best:
                        best, pick = score, run
            if pick is not None:
                mask[pick, mk] = True
    return mask
