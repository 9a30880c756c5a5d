"""Find spikes: short runs of marker samples that jump off the trajectory and back.

An optical system that briefly tracks a reflection, or fits a marker to the
wrong blob, gives a few samples far from where the marker really was. Two
independent predictions of a sample must both miss it for it to count as an
error:

* **in time**: a marker's trajectory at 100+ Hz is smooth over a few frames,
  so a run of ``L`` samples (1 <= L <= ``max_len``) is a candidate when
  every one of them lies far from the cubic fitted through the ``context``
  samples on either side of the run. Testing every run start and every
  length finds a candidate of any length up to ``max_len`` exactly: windows
  that also cover good samples fail the "every sample far" test, and windows
  whose context holds spike samples predict the spike and do not flag. This
  is the "remove and re-fill" outlier test of robust smoothing (e.g. Woltring
  1986 on marker data, and Aristidou et al. 2018's idea of judging a sample
  by what the rest of the motion predicts), made exact for short runs by
  trying each run.
* **by its rigid partners**: the markers whose distance to it the take
  shows nearly constant (a wrist-bar pair, heel and ankle;
  :func:`partner_motion`). A biomechanist's first check: where the marker
  left its cubic but stayed at its usual distance from a partner that left
  its own cubic with it, the segment moved faster than the cubic follows
  (a strike, a heel strike, a wrist turning) and the samples are real. A
  spike moves one marker; its partners stay on their cubic. The partners
  judge each sample (:func:`partner_vouched`): a run is cut to the samples
  none of them vouches for, not condemned whole for one of its samples
  (a punch's first frame off the wrist bar). A partner off itself beside
  the run (its distance broken on a frame where the marker is good) vouches
  for nothing there. This check can only keep samples; where no partner is
  seen it says nothing.
* **in space**: a marker rides on a body segment with other markers. The
  candidate run is predicted from the moving frame of rigidly attached
  markers (:func:`rigid_deviation`: its coordinates in the frame of each
  triple of its 4 most rigid neighbours, interpolated across the run and
  mapped back, the short-gap case of the rigid-body fill of
  :mod:`~mocapkit.cleaning.markers.gaps`). A fast strike or an impact moves
  the whole segment, so its markers leave the cubic together and the
  neighbours explain it; a reflection moves one marker. A candidate some
  neighbour triple predicts within the threshold is real motion and stays.
  The triples include markers across a joint (a wrist's hand and forearm
  markers), which do not turn with a fast-turning wrist: hence the partners
  first.
  Tits, Tilmanne and Dutoit (2018, PLoS ONE 13(7): e0199744) use the same
  inter-marker relations as soft constraints on recovered markers.
* **by the path's bend**: a spike jumps off the path and back, so the
  marker's path bends at its entry and exit by about its size while its
  neighbours' paths go on; a segment braking or striking bends all of
  them (:func:`bends_with_neighbours`). A flagged stretch whose path bends
  no more than some rigid neighbour's, frame by frame within the
  threshold, is motion: a hand turning about the wrist as a punch ends,
  which neither a partner nor a rigid triple explains.

The threshold is ``threshold_mm`` millimetres, or more for a marker whose
single-frame prediction error is naturally large (``noise_factor`` robust
standard deviations of it), so that a noisy marker does not lose good
samples. Positions are (F, M, 3), frames first, NaN for unseen samples.

At a low frame rate a frame lasts longer, and both predictions miss real
motion by more (at 30 Hz, 30 times as many samples of CMU 135_02 miss both
by 15 mm as at 120 Hz). What the rules count in frames follows the rate or
the take: a run is at most 1/12 s long (``max_seconds``, given ``fps``); the
noise is the smaller of the cubic's and the rigid neighbours' median miss;
and the rigid prediction is allowed the miss it makes on the marker's own
never-suspected samples near the run (:func:`rigid_deviation`, ``nearby``).
"""

from __future__ import annotations

from functools import lru_cache
from itertools import combinations

import numpy as np

from .edges import EDGE_MIN_FPS, edge_candidates, edge_glitch_mask
from .rigid import DistanceStats, distance_stats, donor_order, from_local, local_frames_stacked, to_local

__all__ = ["spike_mask", "prediction_matrix", "rigid_deviation", "partner_motion", "partner_vouched",
           "bends_with_neighbours", "longest_spike"]


def longest_spike(fps: float | None, max_len: int = 5, max_seconds: float = 5.0 / 60.0) -> int:
    """The longest spike run in frames at ``fps`` (frames per second): ``max_len``, and with a rate no longer than
    ``max_seconds`` (at least 1 frame); see :func:`spike_mask`."""
    if fps is not None and fps > 0:
        return max(1, min(max_len, int(np.floor(max_seconds * fps + 1e-9))))
    return max_len


def prediction_matrix(length: int, context: int = 3, degree: int = 3) -> np.ndarray:
    """(length, 2 * context) least-squares weights predicting a run of ``length`` samples from ``context`` on each side.

    The run occupies times 0..length-1, the context -context..-1 and
    length..length+context-1; a polynomial of ``degree`` is fitted to the
    context and evaluated on the run.
    """
    tc = np.concatenate([np.arange(-context, 0), np.arange(length, length + context)]).astype(np.float64)
    tr = np.arange(length, dtype=np.float64)
    centre = (length - 1) / 2.0
    vc = np.vander(tc - centre, degree + 1)
    vr = np.vander(tr - centre, degree + 1)
    return vr @ np.linalg.pinv(vc)


@lru_cache(maxsize=256)
def _prediction_weights(length: int, context: int) -> np.ndarray:
    """:func:`prediction_matrix` (cubic), computed once per (length, context) and read-only: :func:`_settle` asks
    for the same few matrices every round of every flagged region (a pseudo-inverse each)."""
    w = prediction_matrix(length, context)
    w.flags.writeable = False
    return w


@lru_cache(maxsize=4096)
def _offset_weights(length: int, offsets: tuple) -> np.ndarray:
    """:func:`_cubic_weights` of a run of ``length`` frames starting at frame 0 with its context at frames
    ``offsets``, read-only and cached. Frames enter the fit only as offsets from the run's centre, exact in floating
    point (integers and half-integers), so a run starting at frame ``a`` with its context at ``a + offsets`` has
    these very weights, bit for bit."""
    w = _cubic_weights(0, length, np.asarray(offsets))
    w.flags.writeable = False
    return w


def _cubic_weights(a: int, b: int, ctx: np.ndarray) -> np.ndarray:
    """(b - a, len(ctx)) least-squares weights of the cubic through the samples at frames ``ctx`` (any, around the
    run) evaluated at frames ``a .. b - 1``: :func:`prediction_matrix` for a context with frames missing."""
    centre = (a + b - 1) / 2.0
    return np.vander(np.arange(a, b) - centre, 4) @ np.linalg.pinv(np.vander(ctx - centre, 4))


def _run_deviation(x: np.ndarray, length: int, context: int) -> np.ndarray:
    """(S, M) smallest distance between each run's samples and their prediction, for run starts s = context..F-length-context.

    NaN where a sample of the run or its context is unseen.
    """
    f = x.shape[0]
    n = f - length - 2 * context + 1
    if n <= 0:
        return np.full((0, x.shape[1]), np.nan)
    w = _prediction_weights(length, context)
    offs = np.concatenate([np.arange(0, context), np.arange(context + length, 2 * context + length)])
    ctx = np.stack([x[o:o + n] for o in offs], axis=0)  # (2c, S, M, 3)
    dev = None
    for j in range(length):
        pred = np.tensordot(w[j], ctx, axes=1)
        d = np.linalg.norm(x[context + j:context + j + n] - pred, axis=-1)
        dev = d if dev is None else np.minimum(dev, d)
    return dev


def _second_differences(track: np.ndarray) -> np.ndarray:
    """(F,) ``|x[t-1] - 2 x[t] + x[t+1]|`` of one marker's ``track`` (F, 3): how far sample t + 1 lies from the straight
    line through t - 1 and t (and t - 1 from the line through t + 1 and t); NaN at the ends and where a sample is unseen."""
    x = np.asarray(track, dtype=np.float64)
    d2 = np.full(x.shape[0], np.nan)
    if x.shape[0] >= 3:
        d2[1:-1] = np.linalg.norm(x[:-2] - 2.0 * x[1:-1] + x[2:], axis=-1)
    return d2


def _smooth_for(d2: np.ndarray, t: int, step: int, jump: float, cap: int) -> int:
    """How many samples go on past sample ``t`` in direction ``step`` (+1, -1), each within ``jump`` of the straight line
    through the two before it (``d2``: :func:`_second_differences` of the marker's recorded track); at most ``cap``."""
    k = 0
    c = t
    while k < cap and 0 < c < d2.shape[0] - 1 and d2[c] <= jump:  # d2[c] spans c - 1, c, c + 1: one sample on
        k += 1
        c += step
    return k


def _one_ended(seg: np.ndarray, a: int, b: int, before: np.ndarray, after: np.ndarray, d2: np.ndarray | None,
               lo: int, jump: float, limit: int) -> bool:
    """Whether the run ``a <= t < b`` of ``seg`` (n, 3) sits beside a step into a run too long for a spike.

    A spike jumps off the trajectory and back: its first sample lies far
    (over ``jump``) from the straight line through the two seen samples
    before it (of ``before``, the frames of its context), and its last from
    the line through the two after it. A run that jumps at one end only and
    on the other goes on smoothly with the track (``d2``, the recorded
    track's :func:`_second_differences`; ``lo``: the frame of ``seg[0]``) for
    more than ``limit`` frames, itself included, is one side of a step: the
    good side of a step into a long wrong run (a marker put on another's
    position for a second), or the start of that wrong run, which is no
    spike either. Nor is a run that jumps at neither end: it goes on
    smoothly from both sides, and leaves the cubic only because its context
    holds a step (the last good samples and the first wrong one). Such runs
    are not taken. A departure of at most ``limit`` frames can still go
    piecewise: its first runs jump in, its last out.
    """
    if d2 is None or len(before) < 2 or len(after) < 2:
        return False

    def miss(t, p, q):  # sample t against the straight line through samples p and q
        return float(np.linalg.norm(seg[t] - (seg[q] + (seg[q] - seg[p]) * (t - q) / (q - p))))

    jumps_in = miss(a, before[-2], before[-1]) > jump
    jumps_out = miss(b - 1, after[1], after[0]) > jump
    if jumps_in and jumps_out:
        return False
    if not jumps_in and not jumps_out:  # it goes on smoothly from both sides: it holds the step (or the cubic missed)
        return True
    if jumps_in:  # it goes on smoothly through b (the line through b and b + 1 met b - 1), and on from there
        own = (b - a) + 1 + _smooth_for(d2, lo + b, 1, jump, limit)
    else:
        own = (b - a) + 1 + _smooth_for(d2, lo + a - 1, -1, jump, limit)
    return own > limit


def _settle(seg: np.ndarray, thr: float, max_len: int, context: int, d2: np.ndarray | None = None,
            lo: int = 0, limit: int | None = None) -> list[tuple[int, int]]:
    """Spike runs (start, length) of one marker's samples ``seg`` (n, 3), most certain first.

    Each round tries every run of 1..max_len seen samples against the cubic
    through the ``context`` nearest seen samples on either side (skipping
    removed ones, within ``max_len`` extra frames), takes the run whose
    smallest deviation is largest, and removes it; it stops when no run's
    samples are all further than ``thr``. With ``d2`` (the marker's recorded
    track's :func:`_second_differences`; ``seg`` starts at its frame ``lo``),
    a run beside a step into a run longer than ``limit`` frames (default
    4 x ``max_len``: a departure the runs can still remove piecewise) is not
    taken (:func:`_one_ended`). Beside such a step every run on either side
    leaves the cubic, which bridges the step; the good side, nearer its
    context, missed it most and was removed sample by sample (CMU 85_02 with
    LFWT put on RFWT for 120 frames: 11 good samples removed and refilled up
    to 200 mm off, the wrong run kept).
    """
    n = seg.shape[0]
    limit = 4 * max_len if limit is None else limit
    runs = []
    # Each run's deviation from the cubic through its whole context (NaN without one), per length. Removing a run
    # makes NaN exactly the runs whose samples or context touch it (NaN propagates through the fit); the others'
    # inputs are unchanged, so they are computed once, not every round.
    devs = {}
    for length in range(1, max_len + 1):
        fast = np.full(n - length + 1, np.nan)
        dev = _run_deviation(seg[:, None, :], length, context)[:, 0]
        fast[context:context + dev.size] = dev
        devs[length] = fast
    while True:
        seen = ~np.any(np.isnan(seg), axis=-1)
        idx = np.flatnonzero(seen)
        best, where = 1.0, None

        def stepside(a, b, before=None, after=None):
            if before is None:
                before, after = np.arange(a - context, a), np.arange(b, b + context)
            return _one_ended(seg, a, b, before, after, d2, lo, 0.5 * thr, limit)

        for length in range(1, max_len + 1):
            fast = devs[length]
            over = np.flatnonzero(fast > best * thr)  # the largest deviation first (the first of equals)
            for a in over[np.argsort(-fast[over], kind="stable")].tolist():
                if not stepside(a, a + length):
                    best, where = fast[a] / thr, (a, length)
                    break
            run_seen = np.convolve(seen.astype(np.int8), np.ones(length, dtype=np.int8), mode="valid") == length
            # runs whose context skips removed samples: those with `context` seen samples on each side, the
            # furthest within `context + max_len` frames of the run
            starts = np.flatnonzero(np.isnan(fast) & run_seen)
            k0 = np.searchsorted(idx, starts)
            k1 = np.searchsorted(idx, starts + length)
            whole = (k0 >= context) & (k1 + context <= idx.size)
            starts, k0, k1 = starts[whole], k0[whole], k1[whole]
            near = ((starts - idx[k0 - context] <= context + max_len)
                    & (idx[k1 + context - 1] - (starts + length - 1) <= context + max_len))
            starts, k0, k1 = starts[near], k0[near], k1[near]
            if not starts.size:
                continue
            ctx = np.concatenate([idx[k0[:, None] + np.arange(-context, 0)], idx[k1[:, None] + np.arange(context)]],
                                 axis=1)  # (S, 2 context) the frames of each run's context
            w = np.stack([_offset_weights(length, tuple(o)) for o in (ctx - starts[:, None]).tolist()])
            pred = np.matmul(w, seg[ctx])  # (S, length, 3): each run's `w @ seg[ctx]`, the same product per run
            score = np.min(np.linalg.norm(seg[starts[:, None] + np.arange(length)] - pred, axis=-1), axis=1) / thr
            # the run of largest score (the first of equals) not beside a step, as a scan in frame order finds it
            for i in np.argsort(-score, kind="stable").tolist():
                if not score[i] > best:
                    break
                a, b = int(starts[i]), int(starts[i]) + length
                if not stepside(a, b, ctx[i, :context], ctx[i, context:]):
                    best, where = score[i], (a, length)
                    break
        if where is None:
            return runs
        runs.append(where)
        seg[where[0]:where[0] + where[1]] = np.nan
        for length, fast in devs.items():  # the runs that reach the removed samples with their context
            fast[max(where[0] - length - context + 1, 0):where[0] + where[1] + context] = np.nan


def rigid_deviation(positions: np.ndarray, good: np.ndarray, marker: int, start: int, end: int,
                    order: np.ndarray, candidates: int = 4, reach: int = 8, nearby: np.ndarray | None = None,
                    suspect: np.ndarray | None = None) -> float:
    """How far the run of ``marker`` (frames ``start <= f < end``) lies from what its rigid neighbours predict.

    ``positions`` (F, M, 3) are the recorded samples (NaN where unseen);
    ``good`` (F,) marks the frames of ``marker`` taken as right (its
    suspected runs excluded). For every triple of the first ``candidates``
    markers of ``order[marker]`` (most rigid first) seen from the marker's
    last good frame before the run to its first good frame after it, the
    marker's coordinates in the triple's moving frame (Kabsch fit,
    :func:`~mocapkit.cleaning.markers.rigid.local_frames`) at those two
    frames are interpolated linearly across the run and mapped back to the
    room. The neighbours' recorded samples are used even where they are
    suspected too: a segment whose markers all leave the cubic together is
    motion (or one glitch of the whole segment, which nothing here could
    undo). Returns the smallest, over triples, of the run's smallest distance
    to that prediction (capture unit): large only when every sample of the
    run is far from every triple's prediction. ``inf`` when it cannot be
    judged: no good frame within ``reach`` frames on a side, or fewer than 3
    neighbours seen.

    With ``nearby`` (F,) bool, the marker's samples taken as surely right
    (never suspected), each triple is validated as the gap fill's models
    are: the most that the same prediction (the same number of frames
    between two ends) misses those samples within ``reach`` frames of the
    run, on frames where no marker of the triple is in ``suspect`` (F, M),
    if given (a neighbour's spike is no miss of the marker's). The triple
    that misses them least is allowed that miss: its distance to the run,
    lessened by it (never below 0), is returned when smaller. By the
    triangle inequality, a run that lies no further than the threshold plus
    that miss from the prediction may be within the threshold of where the
    marker really was. Only the best-validated triple is allowed it: a
    triple of near-coincident markers (golfswing's club channels, 1-6 mm
    apart) or one holding a spiking neighbour misses everything, nearby
    samples included, and would excuse any spike. The prediction interpolates
    across 1/rate seconds per frame, so its miss on real motion grows as the
    rate falls (on CMU 135_02, single-sample misses of 15 mm or more go
    from 0.02 % of samples at 120 Hz to 0.6 % at 30 Hz, on elbows, fingers
    and wrists swinging fast); this allowance follows it at any rate, from
    the take itself, and is a millimetre or two at 100 Hz and above.
    """
    f = positions.shape[0]
    before = np.flatnonzero(good[max(start - reach, 0):start])
    after = np.flatnonzero(good[end:min(end + reach, f)])
    if before.size == 0 or after.size == 0:
        return float("inf")
    p, q = max(start - reach, 0) + int(before[-1]), end + int(after[0])
    span = positions[p:q + 1]
    ok = ~np.any(np.isnan(span), axis=(0, 2))
    cand = [int(d) for d in order[marker] if d != marker and ok[d]][:candidates]
    if len(cand) < 3:
        return float("inf")
    u = ((np.arange(start, end) - p) / (q - p))[:, None]
    # the same prediction's validation runs: q - p - 1 frames between two good ends, on good frames within reach
    n = q - p - 1
    lo, hi = max(p - reach, 0), min(q + reach + 1, f)
    starts = np.zeros(0, dtype=int)
    if nearby is not None:
        window = nearby[lo:hi].copy()
        window[p - lo + 1:q - lo] = False  # the run and what lies between its ends
        whole = np.convolve(window.astype(np.int8), np.ones(n + 2, dtype=np.int8), mode="valid") == n + 2
        starts = np.flatnonzero(whole) + lo  # the first end of each validation run
        starts = starts[(starts + n + 1 <= p) | (starts >= q)]
    best = float("inf")
    validated = []  # (the triple's largest miss on the marker's samples nearby, its miss of the run)
    # Only the frames a prediction reads are fitted: the run's two ends and its own frames, and the validation runs'.
    # Each frame's Kabsch fit is its own (the same rotation, bit for bit, whichever frames share the call), and at a
    # low rate the runs are many and the validation windows long: fitting every frame of the window was most of
    # the time spike_mask took there.
    triples = [list(g) for g in combinations(cand, 3)]
    uses = []
    for cols in triples:
        use = starts
        if starts.size:
            seen = ~np.any(np.isnan(positions[lo:hi][:, cols]), axis=(1, 2))
            if suspect is not None:
                seen &= ~np.any(suspect[lo:hi][:, cols], axis=1)
            # a validation run is used when the triple is seen (and not suspected) on its n + 2 frames
            whole = np.convolve(seen.astype(np.int8), np.ones(n + 2, dtype=np.int8), mode="valid") == n + 2
            use = starts[whole[starts - lo]]
        uses.append(use)
    need = np.unique(np.concatenate([[p, q], np.arange(start, end)] + [(used[:, None] + np.arange(n + 2)).ravel()
                                                                      for used in uses]))
    # every triple's frames at `need`, reference: frame p
    rots, origins = local_frames_stacked(positions[need][:, triples].transpose(1, 0, 2, 3), positions[p][triples])
    ends = np.searchsorted(need, [p, q])
    run = np.searchsorted(need, np.arange(start, end))
    for rot, origin, use in zip(rots, origins, uses):
        loc = to_local(positions[[p, q], marker], rot[ends], origin[ends])
        pred = from_local((1.0 - u) * loc[0] + u * loc[1], rot[run], origin[run])
        miss = float(np.min(np.linalg.norm(positions[start:end, marker] - pred, axis=-1)))
        if use.size:
            first, last = np.searchsorted(need, use), np.searchsorted(need, use + n + 1)
            l0 = to_local(positions[use, marker], rot[first], origin[first])
            l1 = to_local(positions[use + n + 1, marker], rot[last], origin[last])
            v = np.arange(1, n + 1) / (n + 1)
            frames = use[:, None] + np.arange(1, n + 1)  # (S, n) the validation runs' inner frames
            inner = np.searchsorted(need, frames)
            est = (1.0 - v)[None, :, None] * l0[:, None, :] + v[None, :, None] * l1[:, None, :]
            room = np.einsum("snij,snj->sni", rot[inner], est) + origin[inner]
            natural = float(np.max(np.min(np.linalg.norm(positions[frames, marker] - room, axis=-1), axis=1)))
            validated.append((natural, miss))
        best = min(best, miss)
    if validated:  # the triple that predicts the marker best nearby, allowed its miss there
        natural, miss = min(validated)
        best = min(best, max(miss - natural, 0.0))
    return best


def partner_vouched(positions: np.ndarray, good: np.ndarray, marker: int, start: int, end: int,
                    partners: np.ndarray, median: np.ndarray, tol: np.ndarray, suspect: np.ndarray,
                    step: float, context: int = 3, reach: int = 8, share: float = 0.25,
                    flagged: np.ndarray | None = None) -> np.ndarray | None:
    """(end - start,) bool: the samples of ``marker``'s run (frames ``start <= f < end``) its rigid partners vouch for.

    ``positions`` (F, M, 3), NaN where unseen; ``good`` (F,) the marker's
    frames taken as right (seen, its suspected runs excluded); ``partners``
    the markers whose distance to it the take shows nearly constant;
    ``median`` and ``tol`` (M,) their usual distance to it and how far from
    it a sample may lie (capture unit); ``suspect`` (F, M) the samples found
    far from their cubic (spike candidates); ``step`` how far (capture unit)
    a sample's distance to a partner may move from one frame to the next.
    The marker's departure from the cubic through its ``context`` nearest
    good samples on either side (within ``reach`` frames), and each
    partner's departure from the cubic through the same frames, are compared
    sample by sample.

    The distance to a partner *holds* at a frame when it lies within ``tol``
    of the usual one. A partner *keeps* a sample when the distance holds
    there, lies within ``step`` of the distance at each adjacent frame where
    it holds too (it does not jump; beside the run, only a ``good`` frame is
    such a reference), and the partner leaves its own cubic by
    at least ``share`` of the marker's departure: the segment moved fast,
    both markers with it, and the distance held. A partner not itself
    suspected there *breaks* a sample whose distance to it does not hold. A
    spike moves one marker: its partners stay on their cubic, and the
    distance to them changes unless the jump happens to lie on the sphere
    about them. A sample is vouched for when some partner keeps it and none
    breaks it. Each sample is judged on its own: a run that holds a broken
    sample (the marker off for a frame or two as a fast strike starts) is
    motion on the samples whose distance held, and a sample beside the run
    that is itself off is not their reference.

    A partner that is ``flagged`` (F, M; default ``suspect``: the samples
    still taken as spikes) on a context frame where its distance to the
    marker, good there, does not hold is off itself there: its cubic through
    those frames bends to its own spike, and its departure from it says
    nothing of the segment's motion. It keeps no sample of the run (it may
    still break one). A spike beside the partner's own spike may otherwise
    land on the sphere about it and be vouched for (CMU 85_02 at 60 Hz with
    RWRB moved 100 mm on two frames and RWRA 81 mm on the next, 1.0 mm from
    its usual distance to RWRB). Once the partner's flags there are released
    as motion, it vouches again.

    Returns None when no partner is seen over the run and its context, or
    the marker's context is missing (nothing to judge by: the caller falls
    back to its other rules).
    """
    f = positions.shape[0]
    flagged = suspect if flagged is None else flagged
    before = np.flatnonzero(good[max(start - reach, 0):start]) + max(start - reach, 0)
    after = np.flatnonzero(good[end:min(end + reach, f)]) + end
    if before.size < context or after.size < context or len(partners) == 0:
        return None
    ctx = np.concatenate([before[-context:], after[:context]])
    w = _offset_weights(end - start, tuple((ctx - start).tolist()))  # _cubic_weights(start, end, ctx), cached
    frames = np.concatenate([ctx, np.arange(start, end)])
    own = np.linalg.norm(positions[start:end, marker] - w @ positions[ctx, marker], axis=-1)
    kept = np.zeros(end - start, dtype=bool)
    broken = np.zeros(end - start, dtype=bool)
    judged = False
    around = np.arange(start - 1, end + 1)  # the run and the frame on each side of it
    inside = (around >= 0) & (around < f)
    reference = np.ones(around.size, dtype=bool)  # the run's samples, and a frame beside it the marker's good
    reference[[0, -1]] = [start > 0 and good[start - 1], end < f and good[min(end, f - 1)]]
    for j in partners:
        if np.any(np.isnan(positions[frames, j])):
            continue  # the partner is missing here: it cannot vouch for the marker
        judged = True
        dist = np.full(around.size, np.nan)
        dist[inside] = np.linalg.norm(positions[around[inside], marker] - positions[around[inside], j], axis=-1)
        with np.errstate(invalid="ignore"):
            holds = np.abs(dist - median[j]) <= tol[j]  # False where unseen
            jump = np.abs(np.diff(dist)) > step  # (run + 1,) between consecutive frames
        own_holds = holds[1:-1]
        broken |= ~own_holds & ~suspect[start:end, j]
        held = np.abs(np.linalg.norm(positions[ctx, marker] - positions[ctx, j], axis=-1) - median[j]) <= tol[j]
        if np.any(flagged[ctx, j] & ~held):
            continue  # off itself on a context frame where the marker is good: its cubic bends to its own spike
        moved = np.linalg.norm(positions[start:end, j] - w @ positions[ctx, j], axis=-1)
        # a jump counts against a sample only towards an adjacent frame whose distance holds as well (beside
        # the run, a good frame of the marker: a spike candidate there may be off itself)
        back = jump[:-1] & (holds & reference)[:-2]
        ahead = jump[1:] & (holds & reference)[2:]
        kept |= own_holds & ~back & ~ahead & (moved >= share * own)
    if not judged:
        return None
    return kept & ~broken


def bends_with_neighbours(positions: np.ndarray, marker: int, start: int, end: int, order: np.ndarray,
                          flagged: np.ndarray, threshold: float, candidates: int = 4) -> bool:
    """Whether ``marker``'s path over a flagged stretch bends no more than its rigid neighbours' paths do.

    ``positions`` (F, M, 3), NaN where unseen; the stretch is the run
    ``start <= f < end`` grown to the marker's whole stretch of touching
    ``flagged`` (F, M) samples. Every second difference that holds a sample
    of the stretch (:func:`_second_differences`, frames ``start - 1`` to
    ``end``: the entry and the exit too) is compared with the largest one of
    its first ``candidates`` neighbours in ``order`` (most rigid first) whose
    three samples there are seen and not flagged. True when none exceeds it
    by more than ``threshold`` (capture unit). A spike jumps off the path
    and back: its entry and exit bend the path by about its size while the
    segment's other markers go on smoothly (135_02's real spikes: 20-184 mm
    more than the neighbours' at their worst frame). A hand braking at a
    punch's end bends the finger's path as much as the wrist's (135_02's
    RFIN 2709-2711, 7 -> 2 m/s: 12-29 mm a frame, the wrist markers 3-38),
    though the hand turns about the wrist and no rigid triple predicts it.
    The whole flagged stretch is judged, not a piece: inside a linear ramp
    away from the track (a bad source fill) the path does not bend, only at
    its ends. False where a second difference of the marker, or every
    neighbour's at some frame, cannot be judged.
    """
    f = positions.shape[0]
    mine = flagged[:, marker]
    while start > 0 and mine[start - 1]:
        start -= 1
    while end < f and mine[end]:
        end += 1
    if start < 2 or end + 2 > f:
        return False
    win = np.arange(start - 2, end + 2)  # the samples of the second differences at start - 1 .. end
    p = positions[win]
    d2 = np.linalg.norm(p[:-2] - 2.0 * p[1:-1] + p[2:], axis=-1)  # (end - start + 2, M)
    own = d2[:, marker]
    if np.any(np.isnan(own)):
        return False
    near = [int(d) for d in order[marker] if d != marker][:candidates]
    off = flagged[win][:, near]
    usable = ~np.isnan(d2[:, near]) & ~(off[:-2] | off[1:-1] | off[2:])
    most = np.max(np.where(usable, d2[:, near], -np.inf), axis=1)
    return bool(np.all(own <= most + threshold))


def partner_motion(positions: np.ndarray, good: np.ndarray, marker: int, start: int, end: int,
                   partners: np.ndarray, median: np.ndarray, tol: np.ndarray, suspect: np.ndarray,
                   step: float, context: int = 3, reach: int = 8, share: float = 0.25) -> bool | None:
    """Whether the run of ``marker`` (frames ``start <= f < end``) is real motion by its rigid partners' account.

    True when every sample of the run is vouched for (:func:`partner_vouched`,
    same arguments), False when some sample is not, None when no partner can
    judge the run.
    """
    vouched = partner_vouched(positions, good, marker, start, end, partners, median, tol, suspect, step,
                              context=context, reach=reach, share=share)
    return None if vouched is None else bool(np.all(vouched))


def _rigid_noise(x: np.ndarray, marker: int, order: np.ndarray, candidates: int = 4, frames: int = 600,
                 fits: dict | None = None) -> float:
    """Median one-sample miss of ``marker`` by the moving frame of its rigid neighbours (capture unit; inf if none).

    On at most ``frames`` evenly spaced frames t of ``x`` (F, M, 3), the
    marker's coordinates in the frame of each triple of its first
    ``candidates`` neighbours in ``order`` at t - 1 and t + 1 are averaged
    and mapped back at t (:func:`rigid_deviation` for a one-sample run); the
    best triple's miss is taken per frame, and the median over frames where
    all are seen returned. ``fits`` (a dict, optional) keeps each triple's frames for the next marker of the same
    ``x`` and ``frames``: a triple's fit does not depend on the marker.
    """
    f = x.shape[0]
    if f < 3:
        return float("inf")
    t = np.unique(np.linspace(1, f - 2, min(f - 2, frames)).round().astype(int))
    cand = [int(d) for d in order[marker] if d != marker][:candidates]
    best = np.full(t.size, np.inf)
    fit = np.unique(np.concatenate([t - 1, t, t + 1]))  # each frame fitted once (the Kabsch fit is per frame)
    rows = np.searchsorted(fit, np.concatenate([t - 1, t, t + 1]))
    fits = {} if fits is None else fits
    new = [g for g in combinations(cand, 3) if g not in fits]
    if new:  # each triple's reference: its first frame where all three are seen
        refs = []
        for g in new:
            d = x[:, list(g)]
            refs.append(d[np.argmax(~np.any(np.isnan(d), axis=(1, 2)))])
        rots, origins = local_frames_stacked(x[fit][:, [list(g) for g in new]].transpose(1, 0, 2, 3), np.stack(refs))
        fits.update(zip(new, zip(rots, origins)))
    for g in combinations(cand, 3):
        rot, origin = fits[g][0][rows], fits[g][1][rows]
        n = t.size
        loc = to_local(np.concatenate([x[t - 1, marker], x[t + 1, marker]]), np.concatenate([rot[:n], rot[2 * n:]]),
                       np.concatenate([origin[:n], origin[2 * n:]]))
        pred = from_local(0.5 * (loc[:n] + loc[n:]), rot[n:2 * n], origin[n:2 * n])
        miss = np.linalg.norm(x[t, marker] - pred, axis=-1)
        best = np.fmin(best, np.where(np.isnan(miss), np.inf, miss))
    best = best[np.isfinite(best)]
    return float(np.median(best)) if best.size else float("inf")


def spike_mask(positions: np.ndarray, unit_mm: float = 1.0, *, threshold_mm: float = 15.0, max_len: int = 5,
               context: int = 3, noise_factor: float = 8.0, rigid: bool = True,
               order: np.ndarray | None = None, partner_mm: float = 3.0, keep_mm: float = 3.0,
               keep_spreads: float = 3.0, stats: DistanceStats | None = None, fps: float | None = None,
               max_seconds: float = 5.0 / 60.0) -> np.ndarray:
    """Boolean (F, M) mask of spike samples.

    Parameters
    ----------
    positions : float array (F, M, 3)
        Marker positions, NaN where unseen.
    unit_mm : float
        Millimetres per unit of ``positions``.
    threshold_mm : float
        A run is a spike when each of its samples is at least this far from
        the cubic through its context (raised per marker by ``noise_factor``
        robust standard deviations of the single-sample prediction error)
        and, with ``rigid``, at least as far from what every triple of its
        rigid neighbours predicts (:func:`rigid_deviation`).
    max_len : int
        Longest spike, in frames; with ``fps``, no longer than ``max_seconds`` either.
    context : int
        Seen samples used on each side of a run.
    noise_factor : float
        The per-marker threshold is at least ``noise_factor`` robust standard
        deviations (1.4826 x median) of the marker's single-sample prediction
        error: a noisy marker needs a larger departure to count. With
        ``rigid``, the error is the smaller of the cubic's and the rigid
        neighbours' (:func:`_rigid_noise`): at a low rate the cubic misses the
        motion itself, which is no noise.
    rigid : bool
        Keep only candidates that neither the marker's rigid partners
        (:func:`partner_motion`) nor its rigid neighbours
        (:func:`rigid_deviation`) explain.
    order : int array (M, M-1), optional
        Each marker's neighbours, most rigid first
        (:func:`~mocapkit.cleaning.markers.rigid.donor_order`); computed from ``stats`` when not given.
    partner_mm : float
        A marker's rigid partners are the markers whose distance to it
        varies by at most this many millimetres over the take (robust spread:
        half the 10-90 % range, :func:`~mocapkit.cleaning.markers.rigid.distance_stats`).
        A wrist-bar pair varies by 0.7-1.4 mm on CMU captures, a heel and an
        ankle by 2-3 mm; a hand or forearm marker by 5 mm or more from a wrist.
    keep_mm, keep_spreads : float
        A partner keeps a sample when their distance lies within
        max(``keep_mm``, ``keep_spreads`` x spread) of its usual (median) value
        and within ``keep_mm`` of the distance at each adjacent frame where it
        lies that near too (millimetres; :func:`partner_vouched`).
    stats : DistanceStats, optional
        The take's usual inter-marker distances (capture unit); computed from
        ``positions`` when not given. Pass the whole take's when judging a
        part of it.
    fps : float, optional
        The capture's rate (frames per second). A glitch is brief in time: 5
        frames are 42 ms at 120 Hz but 167 ms at 30 Hz, where a foot's fast
        swing, or a labelling error lasting a third of a second (CMU 85_12's
        RTOE and RMT5 at 19.9-20.1 s, 100-200 mm off their usual distances to
        RANK and each other, which no 120 Hz run of 5 frames covers), fits in
        5 frames. So with ``fps`` a run is at most ``max_seconds`` long (at
        least 1 frame): 5 frames at 60 Hz and above, 2 at 24-30 Hz. (Runs
        that touch are still removed one after the other, as at any rate: a
        longer departure can go piecewise.)
    max_seconds : float
        See ``fps``.
    """
    x = np.asarray(positions, dtype=np.float64)
    max_len = longest_spike(fps, max_len, max_seconds)
    f, m = x.shape[:2]
    mask = np.zeros((f, m), dtype=bool)
    if f < 2 * context + 1:
        return mask
    d1 = _run_deviation(x, 1, context)
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            scale = 1.4826 * np.nanmedian(d1, axis=0)
    scale = np.nan_to_num(scale, nan=0.0)
    raised = np.flatnonzero(noise_factor * scale > threshold_mm / unit_mm)
    if rigid and raised.size:
        # The cubic misses a marker's motion more as the rate falls (its context spans 1/rate s a frame): at
        # 24 Hz its median one-sample miss on CMU 85_02 is 2-9 mm, which is motion, not noise, and raised
        # thresholds to 50-105 mm. A noisy marker misses every prediction; a fast one misses the cubic, not
        # the moving frame of its rigid neighbours. So the noise is the smaller of the two medians.
        if stats is None:
            stats = distance_stats(x)
        if order is None:
            order = donor_order(stats)
        fits: dict = {}  # a triple's moving frames, shared by the markers it is a neighbour triple of
        for mk in raised:
            scale[mk] = min(scale[mk], 1.4826 * _rigid_noise(x, int(mk), order, fits=fits))
    thr = np.maximum(threshold_mm / unit_mm, noise_factor * scale)  # (M,)
    hits = np.zeros((f, m), dtype=bool)
    for length in range(1, max_len + 1):
        dev = d1 if length == 1 else _run_deviation(x, length, context)
        st, mk = np.nonzero(np.nan_to_num(dev, nan=0.0) > thr)
        for j in range(length):
            hits[st + context + j, mk] = True
    # Windows whose context holds spike samples flag good samples too: settle each
    # flagged region greedily, most certain run first, removing it before looking again
    # (the context then skips the removed samples).
    pad = context + max_len
    runs = []
    for mk in np.flatnonzero(hits.any(axis=0)):
        grown = np.convolve(hits[:, mk].astype(np.int8), np.ones(2 * pad + 1, dtype=np.int8), mode="same") > 0
        d = np.diff(np.concatenate([[0], grown.astype(np.int8), [0]]))
        for lo, hi in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            lo, hi = max(lo - pad, 0), min(hi + pad, f)
            for a, length in _settle(x[lo:hi, mk].copy(), thr[mk], max_len, context, _second_differences(x[:, mk]), lo):
                mask[lo + a:lo + a + length, mk] = True
                runs.append((int(mk), int(lo + a), int(lo + a + length)))
    if rigid and runs:
        if stats is None:
            stats = distance_stats(x)
        if order is None:
            order = donor_order(stats)
        good = ~mask & ~np.any(np.isnan(x), axis=-1)
        suspect = mask.copy()
        clear = good.copy()  # never suspected: what the rigid prediction's miss on real motion is measured on
        spread = np.where(stats.count >= 10, stats.spread, np.nan)
        # A run is judged from the marker's good samples around it; a neighbouring run of the same marker
        # (fast motion makes several) takes them away until it is itself found to be motion. So the runs are
        # judged again, with the released samples good, until no more is released (each pass releases one
        # sample at least): the outcome does not depend on the order the runs were found in.
        while runs:
            left = []
            for mk, a, b in runs:
                # its rigid partners first (real fast motion keeps their distances), then the neighbour triples
                partners = np.flatnonzero(spread[mk] * unit_mm <= partner_mm)
                tol = np.maximum(keep_mm / unit_mm, keep_spreads * np.nan_to_num(spread[mk], nan=np.inf))
                vouched = partner_vouched(x, good[:, mk], mk, a, b, partners, stats.median[mk], tol, suspect,
                                          keep_mm / unit_mm, context=context, reach=pad, flagged=mask)
                vouched = np.zeros(b - a, dtype=bool) if vouched is None else vouched
                if not vouched.all() and rigid_deviation(x, good[:, mk], mk, a, b, order, reach=pad,
                                                         nearby=clear[:, mk], suspect=mask) <= thr[mk]:
                    vouched[:] = True
                if not vouched.all() and bends_with_neighbours(x, mk, a, b, order, mask, thr[mk]):
                    vouched[:] = True
                if not vouched.any():
                    left.append((mk, a, b))
                    continue
                # the samples a partner vouches for are motion: the run is cut to the others, judged again
                mask[a:b, mk] &= ~vouched
                good[a:b, mk] |= vouched
                edge = np.diff(np.concatenate([[1], vouched.astype(np.int8), [1]]))
                left.extend((mk, a + int(s0), a + int(s1)) for s0, s1 in zip(np.flatnonzero(edge == -1),
                                                                             np.flatnonzero(edge == 1)))
            if sum(b - a for _, a, b in left) == sum(b - a for _, a, b in runs):
                break
            runs = left
    one_sided = rigid and (fps is None or fps >= EDGE_MIN_FPS)  # under it, real speed changes read as glitches
    edges = edge_candidates(x, mask, thr, max_len=max_len, context=context) if one_sided else []
    if edges:  # runs beside a gap or the take's ends, which the two-sided test above cannot judge
        if stats is None:
            stats = distance_stats(x)
        if order is None:
            order = donor_order(stats)
        mask |= edge_glitch_mask(x, mask, thr, order, max_len=max_len, context=context, reach=pad, candidates=edges)
    return mask
