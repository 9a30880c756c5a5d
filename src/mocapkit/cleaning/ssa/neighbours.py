"""Nearest neighbour words and the mean motion texture (sections 3.2-3.4).

*Motion words* are windows of the motion texture on groups of joints (whole
body, upper, lower, left, right): source words of N = 15 frames every 5
frames, target words of M = 20 frames at every frame. Each source word is
compared with every target word of a context (the clip itself, or related
clips) by the constrained DTW of the appendix over the pose distance of eq. 1
(the kernels of :mod:`mocapkit.cleaning.ssa.word_dtw`); its K = 5 nearest
neighbours are the K smallest local minima of that distance function (section
3.3). The matched part of each neighbour is resampled to the source word's
length with a polyphase filter, the neighbours are averaged into a *mean
motion word*, and overlapping mean words into the *mean motion texture*.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ... import rotations as R
from . import self_costs, word_dtw, word_means
from .params import SSAParams
from .texture import MotionTexture, align_hemisphere

__all__ = [
    "Neighbors",
    "NEIGHBOR_RATIO",
    "nearest_words",
    "neighbor_words",
    "near_neighbors",
    "mean_motion_texture",
    "flagged_words",
    "KEEP_WORDS_BYTES",
    "TEXTURE_CHUNK_WORDS",
    "unseen_words",
    "robust_means",
    "dropped_terms",
    "local_minima_knn",
    "word_distance",
    "CHUNK_BYTES",
    "SELF_MATRIX_BYTES",
    "chunk_words",
]

_D = SSAParams()

_LARGE_GROUP = 12  # groups with at least this many joints drop 3 joint terms, smaller ones 1
#: the most bytes of a take's self-distance matrices (joint groups x frames x frames, float32) computed whole, half
#: their cells mirrored (about 100 s at 24 fps); a longer take's are computed in rows, chunk by chunk
SELF_MATRIX_BYTES = 128 << 20
#: the most bytes of pose distances (source frames x context frames x joint groups, float32) one chunk of source words
#: holds against a context: a 900 s context at 24 fps takes ~20 words a chunk instead of 96 (218 MB -> 48 MB)
CHUNK_BYTES = 48 << 20
_PCA_SAMPLE = 2000  # target words the prefilter's PCA basis is fitted on
#: the most bytes of warped neighbour words :func:`mean_motion_texture` keeps (``keep``) while a detection runs, so that
#: its repair reads the words of the flagged cells (:func:`flagged_words`) instead of warping them again: a 60 s take's
#: five groups hold about 21 MiB
KEEP_WORDS_BYTES = 64 << 20
#: source words :func:`mean_motion_texture` warps and averages at a time (a multiple of the 256 of robust_means'
#: batches): a 22-joint group's warped neighbours of 256 words are 14 MB, whatever the take's length
TEXTURE_CHUNK_WORDS = 256


def word_distance(a: np.ndarray, b: np.ndarray, drop: int = 3, min_width: int = 11, max_run: int = 3):
    """Duration-invariant distance between two motion words (section 3.2 and appendix).

    a : (N, m, 4) source word, b : (M, m, 4) target word (N <= M), quaternions
    of the same joints. Returns ``(distance, i_end, j_end)``: the mean eq. 1
    cost (squared half-angle radians, ``drop`` largest joint terms ignored) over
    the matched frame pairs of the constrained DTW path, and where it ends.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    D = word_dtw.group_pose_distances(a, b, np.ones((1, a.shape[1]), dtype=bool), [drop])[0]
    return word_dtw.word_dtw(D, min_width=min_width, max_run=max_run)



def dropped_terms(members) -> int:
    """Joint terms eq. 1 ignores for a group: 3 of a large (whole-body) word, 1 of a small one (section 5)."""
    return 3 if len(members) >= _LARGE_GROUP else 1


@dataclass
class Neighbors:
    """K nearest target words per (group, source word): positions in the context texture, DTW ends, distances."""

    pos: np.ndarray  # (G, W, K) int64, -1 = none
    iend: np.ndarray  # (G, W, K) int16
    jend: np.ndarray  # (G, W, K) int16
    dist: np.ndarray  # (G, W, K) float32
    # the take's self pose-distance matrices (G, F, F) float32 when the search computed them whole (context = the
    # take), with the groups' rows they are of: the warps of the mean texture read them instead of computing again
    self_costs: np.ndarray | None = None
    self_groups: tuple = ()


def local_minima_knn(dist, tgt, k, exclude_center, half):
    """K smallest local minima per row of ``dist`` (W, T) over target starts ``tgt`` (T,) (section 3.3)."""
    W, T = dist.shape
    d = dist.astype(np.float64, copy=True)
    consecutive = np.zeros(T + 1, dtype=bool)
    consecutive[1:-1] = tgt[1:] == tgt[:-1] + 1
    left = np.full_like(d, np.inf)
    right = np.full_like(d, np.inf)
    left[:, 1:] = np.where(consecutive[None, 1:-1], d[:, :-1], np.inf)
    right[:, :-1] = np.where(consecutive[None, 1:-1], d[:, 1:], np.inf)
    is_min = (d <= left) & (d < right) & np.isfinite(d)
    if exclude_center is not None:  # minima of the whole function, then the source's own place left out
        is_min &= np.abs(tgt[None, :] - exclude_center[:, None]) > half
    cand = np.where(is_min, d, np.inf)
    kk = min(k, T)
    idx = np.argpartition(cand, kk - 1, axis=1)[:, :kk] if T > kk else np.tile(np.arange(T), (W, 1))
    vals = np.take_along_axis(cand, idx, axis=1)
    order = np.argsort(vals, axis=1, kind="stable")
    idx = np.take_along_axis(idx, order, axis=1)
    vals = np.take_along_axis(vals, order, axis=1)
    if kk < k:
        pad = k - kk
        idx = np.concatenate([idx, np.zeros((W, pad), dtype=idx.dtype)], axis=1)
        vals = np.concatenate([vals, np.full((W, pad), np.inf)], axis=1)
    return idx, vals


def _descriptors(values: np.ndarray, starts: np.ndarray, members: np.ndarray, length: int) -> np.ndarray:
    """Cheap word descriptors for the kd-tree prefilter: 6-D rotations of the group at 3 frames of the word."""
    offs = np.array([0, length // 2, length - 1])
    q = values[starts[:, None] + offs[None, :]][:, :, members]  # (P, 3, m, 4)
    mats = R.quaternion_to_matrix(q)[..., :, :2]  # first two columns: continuous, no sign ambiguity
    return mats.reshape(len(starts), -1)


def chunk_words(word_starts: np.ndarray, context_frames: int, groups: int, N: int, chunk: int = 96,
                budget: int = CHUNK_BYTES) -> int:
    """Source words per chunk of the exact search: at most ``chunk``, and fewer where their pose distances against
    a context of ``context_frames`` frames in ``groups`` joint groups (float32) would pass ``budget`` bytes; at least 1.

    The distances of a cell do not depend on the chunk it is computed in, so the neighbours are the same for any
    chunk size; only the peak memory changes (a 900 s context at 24 fps: 4.4 MB per source frame).
    """
    W = len(word_starts)
    step = max(1, int(word_starts[-1] - word_starts[0]) // (W - 1)) if W > 1 else 1
    rows = budget // max(1, 4 * groups * int(context_frames))  # source frames the budget holds
    return int(max(1, min(chunk, (rows - N) // step + 1)))


def nearest_words(
    source: MotionTexture,
    context: MotionTexture,
    groups: Sequence[np.ndarray],
    word_starts: np.ndarray,
    k: int = 5,
    source_length: int = 15,
    target_length: int = 20,
    min_width: int = 11,
    max_run: int = 3,
    self_clip: int | None = 0,
    prefilter: bool = False,
    candidates: int = 48,
    chunk: int = 96,
    progress=None,
    exhaustive: bool = False,
    chunk_bytes: int = CHUNK_BYTES,
    self_bytes: int = SELF_MATRIX_BYTES,
) -> Neighbors:
    """The K nearest target words of each source word, per joint group (section 3.3).

    groups : list of (m_g,) row indices into the textures' joints. With
    ``prefilter`` a kd-tree on cheap word descriptors (6-D rotations of three
    frames, reduced by PCA) proposes ``candidates`` target positions per source
    word and only those are ranked by DTW (section 7's suggestion); otherwise
    every target position is compared, and the neighbours are the K smallest
    local minima of the distance function, minima within N/2 frames of the
    source word in its own clip left out (found by
    :func:`~mocapkit.cleaning.ssa.word_dtw.word_knn_profile`, which skips the
    positions a lower bound proves too far: the same neighbours, 1.7x faster
    on a 20 s take and more on longer ones; ``exhaustive=True`` computes the whole distance function
    instead, the reference benchmarks/ssa_speed.py times it against). With the
    prefilter the source's own clip is left out a whole word either side,
    since sparse candidates cannot tell a minimum from the slope down into the
    source's own place. ``self_clip`` is the clip of
    ``context`` that ``source`` is (its neighbours closer than N/2 frames to the
    source word are excluded), or None. When ``context`` is ``source`` itself
    (local analysis) the pose distances are its symmetric self-distance
    matrix, computed once with half the cells
    (:func:`~mocapkit.cleaning.ssa.word_dtw.self_pose_distances`) while it
    stays under ``self_bytes`` (128 MiB, about 100 s of take); a longer take
    computes the rows of each chunk of source words
    (:func:`~mocapkit.cleaning.ssa.self_costs.self_pose_rows`, the same
    checked polynomial terms: the same cells, bit for bit, 5x faster than
    one ``acos`` per joint term). Against
    another context each chunk of source words holds its pose distances to
    every context frame; either way a chunk holds at most ``chunk_bytes``
    (:func:`chunk_words`; the same neighbours for any budget). ``progress`` (a tqdm bar) advances by
    one per (group, word) searched.
    """
    N, M = source_length, target_length
    G, W = len(groups), len(word_starts)
    m = source.values.shape[1]
    drops = np.array([dropped_terms(g) for g in groups])
    masks = np.zeros((G, m), dtype=bool)
    for gi, g in enumerate(groups):
        masks[gi, g] = True
    out = Neighbors(
        np.full((G, W, k), -1, dtype=np.int64),
        np.zeros((G, W, k), dtype=np.int16),
        np.zeros((G, W, k), dtype=np.int16),
        np.full((G, W, k), np.inf, dtype=np.float32),
    )
    tgt = context.target_starts(M)
    if len(tgt) == 0 or W == 0:
        return out
    offset = int(context.clip_starts[self_clip]) if self_clip is not None else 0
    half = N // 2
    if prefilter:
        from ...search.knn import KNNIndex

        tclip = context.clip_of(tgt)
        for gi in range(G):
            desc_t = _descriptors(context.values, tgt, groups[gi], N)
            desc_s = _descriptors(source.values, word_starts, groups[gi], N)
            mean = desc_t.mean(axis=0)
            # the PCA basis from at most ~2,000 evenly spaced target words: an SVD of every word of a 900 s
            # context (22,000 x 432) took 25 s per joint group on two cores, for a basis that only proposes candidates
            sample = desc_t[:: max(1, len(desc_t) // _PCA_SAMPLE)] - mean
            _, _, vt = np.linalg.svd(sample, full_matrices=False)
            basis = vt[: min(24, vt.shape[0])].T
            index = KNNIndex((desc_t - mean) @ basis)
            kq = min(candidates, len(tgt))
            _, cidx = index.query((desc_s - mean) @ basis, k=kq)
            cidx = np.where(cidx < 0, 0, cidx)
            src_rep = np.repeat(word_starts, kq)
            d, ie, je = word_dtw.word_distance_pairs(
                source.values, context.values, masks[gi], drops[gi], src_rep, tgt[cidx].ravel(), N, M, min_width, max_run
            )
            d = d.reshape(W, kq).astype(np.float64)
            pos = tgt[cidx]
            # sparse candidates cannot tell a minimum from the slope into the source's own place, so the
            # source's own clip is left out a whole word either side (not half a word, as with the full profile)
            lo = word_starts + offset - N if self_clip is not None else np.full(W, -1)
            hi = word_starts + offset + N + 1 if self_clip is not None else np.full(W, -1)
            chosen = word_means.select_separated_minima(d, pos, tclip[cidx], k, half + 1, lo, hi)
            for w in range(W):
                for kk in range(k):
                    p = chosen[w, kk]
                    if p < 0:
                        continue
                    c = int(np.flatnonzero(pos[w] == p)[0])
                    out.pos[gi, w, kk] = p
                    out.iend[gi, w, kk] = ie[w * kq + c]
                    out.jend[gi, w, kk] = je[w * kq + c]
                    out.dist[gi, w, kk] = d[w, c]
            if progress is not None:
                progress.update(W)
        return out
    whole = None  # the clip against itself: the symmetric matrix once, half its cells computed
    itself = context.values is source.values
    if itself and G * source.num_frames**2 * 4 <= self_bytes:
        whole = word_dtw.self_pose_distances(source.values, masks, drops)
        out.self_costs, out.self_groups = whole, tuple(np.asarray(g) for g in groups)
    else:
        chunk = chunk_words(word_starts, len(context.values), G, N, chunk, chunk_bytes)
    rows = max(int(word_starts[c0 : c0 + chunk].max() - word_starts[c0 : c0 + chunk].min()) + N
               for c0 in range(0, W, chunk))  # the most rows a chunk holds
    if itself and whole is None:
        values = np.ascontiguousarray(source.values, dtype=np.float64)
        members, offsets = self_costs.pack_groups(masks)
        lanes = self_costs.frame_lanes(values)
        held_rows = np.empty((G, rows, len(values)), dtype=np.float32)  # every chunk's rows, written in place
    D, held = None, (0, 0)  # the chunk's pose distances and the frames of their rows
    work = None  # the row minima of the pruned search, one buffer for every chunk and group
    if not exhaustive:
        work = word_dtw.knn_workspace(rows, len(tgt), N, M, max_run)
    for c0 in range(0, W, chunk):
        ws = word_starts[c0 : c0 + chunk]
        f0, f1 = int(ws.min()), int(ws.max()) + N
        if whole is not None:
            D = whole[:, f0:f1]
        elif itself:
            D = _self_rows(held_rows, held, f0, f1, values, members, offsets, drops.astype(np.int64), lanes)
            held = (f0, f1)
        else:
            D = word_dtw.group_pose_distances(source.values[f0:f1], context.values, masks, drops)
        for gi in range(G):
            excl = ws + offset if self_clip is not None else None
            if exhaustive:
                dist, ie, je = word_dtw.word_distance_profile(D[gi], ws - f0, tgt, N, M, min_width, max_run)
                idx, vals = local_minima_knn(dist, tgt, k, excl, half)
                idx = np.where(np.isfinite(vals), idx, -1)
                ie = np.take_along_axis(ie, np.maximum(idx, 0), axis=1)
                je = np.take_along_axis(je, np.maximum(idx, 0), axis=1)
                vals = np.where(idx >= 0, vals, np.inf).astype(np.float32)
            else:
                idx, vals, ie, je = word_dtw.word_knn_profile(D[gi], ws - f0, tgt, k, excl, half, N, M, min_width, max_run,
                                                              work=work)
            sl = slice(c0, c0 + len(ws))
            out.pos[gi, sl] = np.where(idx >= 0, tgt[np.maximum(idx, 0)], -1)
            out.iend[gi, sl] = ie
            out.jend[gi, sl] = je
            out.dist[gi, sl] = vals
            if progress is not None:
                progress.update(len(ws))
    return out


def _self_rows(buf, held, f0: int, f1: int, values, members, offsets, drops, lanes) -> np.ndarray:
    """Rows ``f0..f1-1`` of the take's self pose-distance matrix, (G, f1 - f0, F) float32: a view of the first
    rows of ``buf`` (G, R, F), which holds the chunk before's rows ``held = (h0, h1)`` from its row 0 on.

    Chunks of source words 5 frames apart overlap by N - 5 = 10 rows, which each chunk computed again: a fifth
    of the rows of a 30-minute take's chunks (about 55 rows each), 6% of a 10-minute take's. Those rows are moved
    to the front of ``buf`` and the others written after them by
    :func:`~mocapkit.cleaning.ssa.self_costs.self_pose_rows`; the same cells, bit for bit, as one call for all
    of them, without a chunk's rows (~48 MB) allocated and its shared rows copied and joined to them each time."""
    h0, h1 = held
    n = min(f1, h1) - f0 if h0 <= f0 < h1 else 0  # rows the chunk before holds
    if n > 0 and f0 > h0:
        buf[:, :n] = buf[:, f0 - h0 : f0 - h0 + n]  # numpy copies through a temporary where the two overlap
    if f0 + n < f1:
        self_costs.self_pose_rows(values, f0 + n, f1, members, offsets, drops, lanes=lanes, out=buf, at=n)
    return buf[:, : f1 - f0]


def neighbor_words(
    source_values, context: MotionTexture, members, drop, src_starts, pos, N, M, min_width=_D.min_width, out_rows=None,
    costs=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Neighbour words time-warped onto their source words' N frames (section 3.2), (P, N, m_g, 4).

    For each pair the constrained DTW path between the source word at
    ``src_starts[p]`` and the target word at ``pos[p]`` (on the rows
    ``members``, ignoring ``drop`` largest joint terms) is found; every source
    frame takes the mean of the target frames matched to it (the time-warped
    target). When the target word ran out first (path ending before the last
    source frame) the warped part is resized to N frames with the polyphase
    filter ``scipy.signal.resample_poly``, as the paper does. ``out_rows``
    warps other rows of the target along the path found on ``members``
    (sparse reconstruction: matched on a few joints, copied for all).
    ``costs``: the search's pose distances of the source against the context
    on ``members`` (float32, source frames x context frames), read instead of
    computed again.

    Returns ``words`` (P, N, len(rows), 4) and ``ok`` (P,) bool (False where
    the target word does not fit its clip or no admissible path exists; those
    words are NaN). The DTW, path and warp run in one numba kernel
    (:func:`mocapkit.cleaning.ssa.word_dtw.warp_target_words`); the warped parts
    shorter than N frames are resized with ``resample_poly``, one call per length.
    """
    src_starts = np.asarray(src_starts, dtype=np.int64)
    pos = np.asarray(pos, dtype=np.int64)
    rows = members if out_rows is None else out_rows
    clip = context.clip_of(pos)
    fits = (pos >= 0) & (pos + M <= context.clip_starts[np.maximum(clip, 0) + 1])
    idx = np.flatnonzero(fits)
    words = np.full((len(pos), N, len(rows), 4), np.nan)
    ok = np.zeros(len(pos), dtype=bool)
    if len(idx) == 0:
        return words, ok
    warped, iend = word_dtw.warp_target_words(
        source_values, context.values, members, drop, src_starts[idx], pos[idx], N, M, min_width, 3, rows, costs
    )
    short = np.unique(iend[(iend >= 0) & (iend + 1 != N)]) + 1
    if len(short):
        from scipy.signal import resample_poly  # here: importing scipy.signal takes ~1 s
    for L in short:
        sel = np.flatnonzero(iend + 1 == L)
        part = R.quaternion_continuity(warped[sel, :L], axis=1).reshape(len(sel), L, -1)
        warped[sel] = resample_poly(part, N, L, axis=1, padtype="line").reshape(len(sel), N, len(rows), 4)
    good = iend >= 0
    words[idx[good]] = R.quaternion_normalize(warped[good])
    ok[idx[good]] = True
    return words, ok



NEIGHBOR_RATIO = 2.0  # neighbour words farther than this times the nearest's distance (+ 0.001) are not examples of it


def near_neighbors(dist, best, ratio: float = NEIGHBOR_RATIO):
    """Which word distances ``dist`` lie within ``ratio`` times the nearest one's, ``best`` (+ 0.001).

    When the context repeats a word fewer than K times, the other local
    minima are different motions, not examples of it: the mean texture
    leaves them out, and so does the repair's medoid.
    """
    return dist <= ratio * best + 1e-3


def robust_means(words: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean word and spread of each source word's hemisphere-aligned neighbours, robust to outliers.

    words : (W, K, N, m, 4), valid : (W, K) which of the K are neighbours (at
    least one per row). Per cell the neighbours far from the cell's medoid
    (more than twice the median distance to it, plus 5 degrees) are left out of
    the chordal mean: a neighbour that overlaps an error of the clip itself (a
    long error outlasts the N/2 exclusion zone of section 3.3) must not pull
    the mean towards the error. Returns the means (W, N, m, 4) and the spread
    (W, N, m), the RMS angle of the kept neighbours from the mean in radians
    (0 where a word has one neighbour, whose word is the mean). The cell loop
    is :func:`mocapkit.cleaning.ssa.word_means.robust_word_means`.
    """
    return word_means.robust_word_means(words, valid, np.radians(5.0))


def unseen_words(neighbors: Neighbors, groups, max_word_angle_deg) -> np.ndarray:
    """Drop, in place, the neighbours of source words the context has nothing like; returns (G, W) bool of them.

    A word's nearest neighbour at eq. 1 distance ``d`` (the mean over matched
    frames of the summed squared half-angles of the group's joints, the
    ``drop`` largest left out) differs from it by an RMS joint angle of
    ``2 sqrt(d / (m_g - drop))``; above ``max_word_angle_deg`` the neighbours
    are other motions, their mean says nothing about errors, and the word is
    not judged (section 7: self-similarity needs the motion to have been seen).
    """
    G, W = neighbors.pos.shape[:2]
    unseen = np.zeros((G, W), dtype=bool)
    if max_word_angle_deg is None:
        return unseen
    for gi, members in enumerate(groups):
        terms = max(len(members) - dropped_terms(members), 1)
        best = neighbors.dist[gi, :, 0].astype(np.float64)
        rms = np.degrees(2.0 * np.sqrt(np.maximum(best, 0.0) / terms))
        unseen[gi] = np.isfinite(best) & (rms > max_word_angle_deg)
    neighbors.pos[unseen] = -1
    neighbors.dist[unseen] = np.inf
    return unseen


def mean_motion_texture(
    source: MotionTexture,
    context: MotionTexture,
    groups,
    word_starts,
    neighbors: Neighbors,
    source_length: int = 15,
    target_length: int = 20,
    return_spread: bool = False,
    neighbor_ratio: float = NEIGHBOR_RATIO,
    keep: dict | None = None,
    chunk: int = TEXTURE_CHUNK_WORDS,
):
    """Mean motion texture per group, (G, F, m, 4) (section 3.4).

    Each source word's K neighbours (time-warped to N frames) are averaged into
    a mean motion word; overlapping mean words are averaged per frame. Rows of
    a group's non-members and frames no word covers are NaN. Averages of
    quaternions are the normalised sums of hemisphere-aligned values (the
    chordal mean), accurate for the nearby rotations averaged here.
    Neighbours whose word distance exceeds ``neighbor_ratio`` times the best
    one's (plus 0.001) are left out: when the context repeats a word only
    twice, the other local minima are different motions, not examples of it. With
    ``return_spread`` also the neighbours' spread (G, F, m): the RMS angle
    (radians) of the K words from their mean, averaged like the texture. ``keep``: a dict that takes, per group
    (its rows as bytes), the words warped: ``(source word starts, positions, words, ok)`` as :func:`neighbor_words`
    makes them, while they total at most :data:`KEEP_WORDS_BYTES` (see :func:`flagged_words`).

    The source words go ``chunk`` at a time (:data:`TEXTURE_CHUNK_WORDS`, a multiple of the 256 words
    :func:`robust_means` takes at once), their warped neighbours let go before the next chunk's: the memory a
    group holds stays that of one chunk (K x N x m_g quaternions a word, 53 KB for 22 joints) instead of
    growing with the take. Every word's mean and every frame's sum are those of the whole take at once, bit for
    bit (the overlapping words are added to each frame in the same order).
    """
    if chunk < 1:
        raise ValueError(f"chunk must be at least 1 word, got {chunk}")
    N = source_length
    G = len(groups)
    F, m = source.values.shape[:2]
    W = len(word_starts)
    out = np.full((G, F, m, 4), np.nan)
    spread = np.full((G, F, m), np.nan)
    K = neighbors.pos.shape[2]
    for gi, members in enumerate(groups):
        dists = neighbors.dist[gi]  # (W, K)
        best = np.min(dists, axis=1, keepdims=True).astype(np.float64)  # inf where a word has none: all pass
        use = (neighbors.pos[gi] >= 0) & near_neighbors(dists, best, neighbor_ratio)
        costs = None
        if (neighbors.self_costs is not None and context.values is source.values and gi < len(neighbors.self_groups)
                and np.array_equal(neighbors.self_groups[gi], members)):
            costs = neighbors.self_costs[gi]
        words_bytes = int(use.sum()) * N * len(members) * 4 * 8  # the group's warped words, float64
        room = keep is not None and sum(v[2].nbytes for v in keep.values()) + words_bytes <= KEEP_WORDS_BYTES
        kept = [] if room else None
        acc, sacc, cnt = np.zeros((F, len(members), 4)), np.zeros((F, len(members))), np.zeros(F)
        for c0 in range(0, max(W, 1), chunk):  # one (empty) chunk where there are no words
            starts = word_starts[c0 : c0 + chunk]
            wi, ki = np.nonzero(use[c0 : c0 + chunk])
            pos = neighbors.pos[gi][c0 + wi, ki]
            nws, ok = neighbor_words(source.values, context, members, dropped_terms(members), starts[wi], pos, N,
                                     target_length, costs=costs)
            if kept is not None:
                kept.append((starts[wi], pos, nws, ok))
            means, spreads, has = _word_means(nws, ok, wi, ki, len(starts), K)
            _overlap_sums(acc, sacc, cnt, starts[has], means[has], spreads[has])
        if kept is not None:
            keep[np.asarray(members, dtype=np.int64).tobytes()] = tuple(np.concatenate(a) for a in zip(*kept))
        ok = cnt > 0
        vals = np.full((F, len(members), 4), np.nan)
        vals[ok] = R.quaternion_normalize(acc[ok])
        out[gi][:, members] = vals
        sp = np.full((F, len(members)), np.nan)
        sp[ok] = sacc[ok] / cnt[ok, None]
        spread[gi][:, members] = sp
    return (out, spread) if return_spread else out


def _word_means(nws, ok, wi, ki, W, K):
    """Mean words and spreads (:func:`robust_means`) of ``W`` source words from their warped neighbours ``nws``
    (P, N, m, 4) (``ok`` (P,) those warped, word ``wi`` (P,) and rank ``ki`` (P,) of each): ``(means (W, N, m, 4),
    spreads (W, N, m), has (W,))``, ``has`` the words with a neighbour (the others' rows zero)."""
    N, m = nws.shape[1:3]
    # (W, K, N, m_g, 4) in neighbour order, each word's aligned with its first neighbour, not the
    # source: a broken source joint may sit 90 degrees away in quaternion space, where hemispheres
    # are arbitrary
    valid = np.zeros((W, K), dtype=bool)
    vw, vk = wi[ok], ki[ok]
    valid[vw, vk] = True
    stacked = np.zeros((W, K, N, m, 4))
    stacked[vw, vk] = nws[ok]
    has = valid.any(axis=1)
    first = np.argmax(valid, axis=1)
    # the words there are (a zero word stays zero whatever its reference): each quaternion as by the whole array
    ref = stacked[np.arange(W), first]
    stacked[vw, vk] = align_hemisphere(stacked[vw, vk], ref[vw])
    means = np.zeros((W, N, m, 4))
    spreads = np.zeros((W, N, m))
    for c0 in range(0, W, 256):
        sl = np.flatnonzero(has[c0 : c0 + 256]) + c0
        if len(sl):
            means[sl], spreads[sl] = robust_means(stacked[sl], valid[sl])
    return means, spreads, has


def flagged_words(kept: dict, groups, flags: np.ndarray, best_group: np.ndarray, word_of: np.ndarray,
                  words: np.ndarray) -> dict:
    """The words of ``kept`` (:func:`mean_motion_texture`'s ``keep``) that a repair of ``flags`` reads: those of each
    flagged cell's source word (``word_of`` (F,), :func:`~mocapkit.cleaning.ssa.texture.frame_words`, into ``words``)
    in the cell's group (``best_group`` (F, J), indices into ``groups``, the rows of each), as ``kept`` holds them."""
    out = {}
    fi, ji = np.nonzero(flags)
    g_of = np.asarray(best_group)[fi, ji]
    for gi, members in enumerate(groups):
        key = np.asarray(members, dtype=np.int64).tobytes()
        at = g_of == gi
        if key not in kept or not at.any():
            continue
        starts, pos, nws, ok = kept[key]
        sel = np.isin(starts, words[np.unique(word_of[fi[at]])])
        out[key] = (starts[sel], pos[sel], nws[sel], ok[sel])
    return out


def _overlap_sums(acc: np.ndarray, sacc: np.ndarray, cnt: np.ndarray, starts: np.ndarray, means: np.ndarray,
                  spreads: np.ndarray) -> None:
    """Mean words added, in place, to the sums of the frames they overlap: ``acc`` (F, m, 4), ``sacc`` (F, m),
    ``cnt`` (F,).

    ``means`` (n, N, m, 4) and ``spreads`` (n, N, m) of the words at frames
    ``starts`` (n,). Per frame the words are added in ``starts`` order, each
    aligned with the hemisphere of the sum so far (of itself where the sum is
    still zero), their spreads summed and counted. The cells go in rounds,
    round k adding every frame's k-th word, so the sums are those of one word
    at a time, and words given over several calls add up as given in one.
    """
    n, N, m = means.shape[:3]
    frames, rounds = _word_cells(starts, N)
    mw, sw = means.reshape(-1, m, 4), spreads.reshape(-1, m)
    for k in range(int(rounds.max(initial=-1)) + 1):
        c = np.flatnonzero(rounds == k)
        f = frames[c]  # distinct frames
        so_far = acc[f]
        ref = np.where(np.linalg.norm(so_far, axis=-1, keepdims=True) > 0, so_far, mw[c])
        acc[f] = so_far + align_hemisphere(mw[c], ref)
        sacc[f] = sacc[f] + sw[c]
        cnt[f] = cnt[f] + 1


def _word_cells(starts: np.ndarray, N: int) -> tuple[np.ndarray, np.ndarray]:
    """``(frames, rounds)``, both (n * N,) in word-major order: the frame of each cell of the words of ``N``
    frames at ``starts`` (n,), and how many earlier words (in ``starts`` order) cover that frame too."""
    frames = (np.asarray(starts, dtype=np.int64)[:, None] + np.arange(N)).ravel()
    order = np.argsort(frames, kind="stable")  # by frame, word order kept
    f = frames[order]
    pos = np.arange(len(f))
    first = np.maximum.accumulate(np.where(np.concatenate([[True], f[1:] != f[:-1]]), pos, 0))
    rounds = np.empty(len(f), dtype=np.int64)
    rounds[order] = pos - first
    return frames, rounds
