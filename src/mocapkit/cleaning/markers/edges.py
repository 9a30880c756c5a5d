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
  on its other side is the glitch, judged in its own right. The line's miss
  of real motion grows with the square of the sample interval, so the run
  must also miss it by more than the marker's own motion ever does one
  frame ahead away from the take's edges (:func:`line_misses`): at 30 Hz a
  wrist's real deceleration at a take's start (CMU 85_02's RWRA) misses
  it by 46 mm.
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
the marker's spike threshold, and some neighbour triple is seen to judge it,
validated on the marker's own samples: where none is, nothing is removed. Each edge gives at most one run (of at
most ``max_len`` samples, starting within ``context`` samples of the edge),
the one that misses most. Positions are (F, M, 3), frames first, NaN for
unseen samples, in the capture's unit.

Runs are judged from one side only at :data:`EDGE_MIN_FPS` and above: at
lower rates a real change of speed between two frames (a golf club's
marker slowing at the take's start, judged against a neighbour at rest, at
27 Hz) misses both one-sided predictions as a glitch does, and the edge is
left to the gap fill as before.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

from .rigid import from_local, local_frames, to_local

#: The lowest capture rate (frames per second) at which a run beside a gap or a take's end is judged from its one
#: seen side; optical marker captures run at 100-250 Hz.
EDGE_MIN_FPS = 50.0

__all__ = ["EDGE_MIN_FPS", "edge_glitch_mask", "edge_candidates", "line_misses", "one_sided_rigid_miss"]


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
    3 neighbours are seen there, or no clear samples to validate on (it cannot
    be judged: beside gaps at a low rate, in fast motion, an unvalidated
    prediction removed real samples of c3d.org's 30 Hz phasespace_sample).
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
    if not validated:  # how far the prediction misses the marker's real motion here is unknown: it cannot judge
        return float("inf")
    natural, miss = min(validated)
    return min(best, max(miss - natural, 0.0))


def _edges(seen: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(E,) frame, step and marker of each edge of the seen runs in ``seen`` (F, M): a run's first frame with step
    +1 (it follows a gap or the take's start), its last with step -1 (a gap or the take's end follows)."""
    f, m = seen.shape
    pad = np.zeros((1, m), dtype=np.int8)
    d = np.diff(np.concatenate([pad, seen.astype(np.int8), pad]), axis=0)  # (F + 1, M)
    t1, m1 = np.nonzero(d == 1)
    t2, m2 = np.nonzero(d == -1)
    return (np.concatenate([t1, t2 - 1]), np.concatenate([np.ones(t1.size, int), -np.ones(t2.size, int)]),
            np.concatenate([m1, m2]))


def line_misses(positions: np.ndarray, clear: np.ndarray, ahead: int, context: int = 3) -> np.ndarray:
    """(M, ahead + 1) the largest miss of each marker's own motion by the straight line in time, ``h`` frames ahead.

    For each ``h`` in 1..``ahead``: the line through two clear samples
    extrapolated ``h`` frames on (either way in time), measured at clear
    samples whose line samples and the samples between are clear too, and
    which lie more than ``context`` frames from a gap or the take's ends (the
    edges are what is judged: their own glitches must not excuse
    themselves). The largest such miss over the take is how far real motion
    of this marker departs from the line at this rate: it grows with the
    square of the sample interval, and a run at an edge is judged against
    it. Column 0 is 0; ``inf`` where a marker has no such sample
    (its real motion's miss is unknown).
    """
    x = np.asarray(positions, dtype=np.float64)
    f, m = x.shape[:2]
    out = np.full((m, ahead + 1), np.inf)
    out[:, 0] = 0.0
    seen = ~np.any(np.isnan(x), axis=-1)
    # inner: clear and more than ``context`` frames from an unseen sample or the take's ends
    blocked = np.pad(~seen, ((context, context), (0, 0)), constant_values=True).astype(np.int32)
    cs = np.cumsum(np.pad(blocked, ((1, 0), (0, 0))), axis=0)
    w = 2 * context + 1  # the frames within ``context`` of each
    inner = clear & ((cs[w:] - cs[:-w]) == 0)
    ck = np.cumsum(np.pad(inner.astype(np.int32), ((1, 0), (0, 0))), axis=0)
    for h in range(1, ahead + 1):
        if f < h + 2:
            break
        n = f - h - 1
        span = (ck[h + 2:] - ck[:n]) == h + 2  # (n, M): frames t .. t + h + 1 all inner
        best = np.full(m, -np.inf)
        for tgt, p, q in ((x[:n], x[h:h + n], x[h + 1:]),  # backward: t from t + h, t + h + 1
                          (x[h + 1:], x[1:1 + n], x[:n])):  # forward: t + h + 1 from t + 1, t
            e = np.linalg.norm(tgt - (p + h * (p - q)), axis=-1)
            best = np.maximum(best, np.max(np.where(span, e, -np.inf), axis=0))
        out[:, h] = np.where(np.isfinite(best), best, np.inf)
    return out


def edge_candidates(positions: np.ndarray, suspect: np.ndarray, thr: np.ndarray, max_len: int = 5,
                    context: int = 3) -> list[tuple[int, int, np.ndarray, int, float]]:
    """The runs at edges that the test in time takes (see the module's docstring), before the rigid test.

    Returns ``(marker, edge frame, run frames, anchor frame, miss)``: the run's frames
    (from the edge in), the seen frame next to it on its seen side, and its
    samples' smallest distance to the straight line, measured against the
    larger of the spike threshold and the marker's own largest one-frame-ahead
    line miss away from the edges (its largest second difference there,
    :func:`line_misses`) and given in units of the threshold (capture unit:
    a miss over ``thr`` is over both). All
    edges are tested at once for each of the few (start, length) pairs.
    """
    x = np.asarray(positions, dtype=np.float64)
    f = x.shape[0]
    seen = ~np.any(np.isnan(x), axis=-1)
    clear = seen & ~suspect
    edge, step, mk = _edges(seen)
    if edge.size == 0:
        return []
    natural = line_misses(x, clear, 1, context)[:, 1]  # (M,) the largest one-frame-ahead miss of real motion
    k = np.arange(context + max_len + context)
    frames = edge[:, None] + step[:, None] * k[None, :]  # (E, K) frames from the edge in
    inside = (frames >= 0) & (frames < f)
    fr = np.clip(frames, 0, f - 1)
    tr = x[fr, mk[:, None]]  # (E, K, 3)
    ok = clear[fr, mk[:, None]] & inside
    sn = seen[fr, mk[:, None]] & inside
    t = thr[mk]
    out = []
    for a in range(context):
        for b in range(a + 1, a + max_len + 1):
            p, q, r = tr[:, b], tr[:, b + 1], tr[:, b + 2]
            use = ok[:, b:b + context].all(axis=1) & sn[:, :b].all(axis=1) & ok[:, a:b].all(axis=1)
            use &= np.linalg.norm(p - 2.0 * q + r, axis=-1) <= 0.5 * t  # a context that holds a jump is none
            line = p[:, None, :] + (p - q)[:, None, :] * (b - np.arange(b))[None, :, None]
            tol = np.maximum(t, natural[mk])[:, None]  # (E, 1): what real motion may depart from the line by
            off = np.linalg.norm(tr[:, :b] - line, axis=-1) / tol * t[:, None]  # (E, b), in units of t
            miss = np.min(off[:, a:], axis=1)
            use &= (miss > t) & np.all(off[:, :a] <= t[:, None], axis=1)  # samples left by the edge go on with it
            for e in np.flatnonzero(use):
                out.append((int(mk[e]), int(edge[e]), frames[e, a:b], int(frames[e, b]), float(miss[e])))
    return out


def edge_glitch_mask(positions: np.ndarray, suspect: np.ndarray, thr: np.ndarray, order: np.ndarray,
                     max_len: int = 5, context: int = 3, reach: int = 8,
                     candidates: list | None = None) -> np.ndarray:
    """Boolean (F, M) mask of glitch runs at the edges of the seen runs (see the module's docstring).

    ``positions`` (F, M, 3), NaN where unseen; ``suspect`` (F, M) the samples
    already found to be spikes (neither judged again nor used as context);
    ``thr`` (M,) each marker's spike threshold (capture unit); ``order`` each
    marker's neighbours, most rigid first
    (:func:`~mocapkit.cleaning.markers.rigid.donor_order`); ``max_len`` the
    longest run in frames; ``context`` how far from the edge a run may start
    (and how many seen samples its seen side needs); ``reach`` how far the
    validation of the rigid prediction looks; ``candidates``
    :func:`edge_candidates`' answer, when already computed.
    """
    x = np.asarray(positions, dtype=np.float64)
    mask = np.zeros(x.shape[:2], dtype=bool)
    if candidates is None:
        candidates = edge_candidates(x, suspect, thr, max_len, context)
    clear = ~np.any(np.isnan(x), axis=-1) & ~suspect
    best: dict[tuple[int, int], tuple[float, np.ndarray]] = {}  # (marker, edge frame) -> (score, run)
    for mk, edge, run, anchor, miss in candidates:
        nb = np.asarray([int(d) for d in order[mk] if d != mk])
        if nb.size < 3:
            continue
        key = (mk, edge)
        rigid = one_sided_rigid_miss(x[:, mk], x[:, nb], run, anchor, clear[:, mk], reach)
        score = min(miss, rigid) / thr[mk]
        if np.isfinite(rigid) and score > 1.0 and score > best.get(key, (1.0, None))[0]:
            best[key] = (score, run)
    for (mk, _), (_, run) in best.items():
        mask[run, mk] = True
    return mask
