"""Neighbour words and their means against one-at-a-time references (sections 3.2-3.4)."""

import numpy as np
import pytest
from scipy.signal import resample_poly

from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa import neighbours, texture, word_dtw
from tests.naive import naive_local_minima_knn


def _reference_neighbor_word(
    source_word, context, members, drop, pos, N, M, min_width=11, out_rows=None
):
    """The oracle of ``neighbours.neighbor_words``: one neighbour word time-warped onto the source word's N frames (section 3.2), (N, m_g, 4).

    The constrained DTW path between ``source_word`` (N, m, 4) and the target
    word at ``pos`` is recomputed; every source frame takes the mean of the
    target frames matched to it (the time-warped target). When the target word
    ran out first (path ending before the last source frame) the warped part
    is resized to N frames with the polyphase filter ``scipy.signal.resample_poly``
    as the paper does. Returns None when the target does not fit its clip.
    ``out_rows`` warps other rows of the target along the path found on
    ``members`` (sparse reconstruction: matched on a few joints, copied for all).
    """
    clip = int(context.clip_of(pos))
    end = int(context.clip_starts[clip + 1])
    if pos + M > end:
        return None
    rows = members if out_rows is None else out_rows
    target = R.quaternion_continuity(context.values[pos : pos + M], axis=0)
    src = source_word[:, members]
    D = word_dtw.group_pose_distances(src, target[:, members], np.ones((1, len(members)), dtype=bool), [drop])[0]
    _, path = word_dtw.word_dtw_path(D, min_width=min_width)
    if len(path) == 0:
        return None
    target = target[:, rows]
    i_end = int(path[-1, 0])
    acc = np.zeros((i_end + 1, len(rows), 4))
    ref = target[path[0, 1]]
    np.add.at(acc, path[:, 0], target[path[:, 1]] * np.where(np.sum(target[path[:, 1]] * ref[None], axis=-1, keepdims=True) < 0, -1.0, 1.0))
    warped = R.quaternion_normalize(acc)
    if i_end + 1 != N:
        flat = R.quaternion_continuity(warped, axis=0).reshape(i_end + 1, -1)
        warped = resample_poly(flat, N, i_end + 1, axis=0, padtype="line").reshape(N, len(rows), 4)
    return R.quaternion_normalize(warped)


@pytest.mark.parametrize("group", ["whole", "left"])
def test_neighbor_words_equal_the_one_at_a_time_reference(walk, flipped, group):
    det = flipped[3]
    an = ssa.prepare(flipped[0], None, joints=det.texture_joints)
    src, full = an.source, an.texture
    g = det.group_names.index(group)
    members = np.flatnonzero(det.group_masks[g])
    wi, ki = np.nonzero(det.neighbor_pos[g] >= 0)
    starts, pos = det.word_starts[wi], det.neighbor_pos[g][wi, ki]
    pos = np.append(pos, full.num_frames - 5)  # a target that runs past its clip
    starts = np.append(starts, 0)
    words, ok = neighbours.neighbor_words(src.values, full, members, neighbours.dropped_terms(members), starts, pos, 15, 20)
    resized = 0
    for q in range(len(pos)):
        ref = _reference_neighbor_word(src.values[starts[q] : starts[q] + 15], full, members, neighbours.dropped_terms(members), int(pos[q]), 15, 20)
        assert ok[q] == (ref is not None)
        if ref is not None:
            np.testing.assert_allclose(texture.align_hemisphere(words[q], ref), ref, atol=1e-12)
        else:
            assert np.isnan(words[q]).all()
    assert not ok[-1] and ok[:-1].all()
    # some paths end on the target's last column, so the polyphase resize is exercised
    _, iend = word_dtw.warp_target_words(src.values, full.values, members, neighbours.dropped_terms(members), starts[:-1], pos[:-1])
    assert np.any(iend < 14)


def _reference_robust_mean(words: np.ndarray) :
    """Mean word and spread of K hemisphere-aligned words (K, N, m, 4), robust to outlier neighbours.

    Per cell the neighbours far from the cell's medoid (more than twice the
    median distance to it, plus 5 degrees) are left out of the chordal mean:
    a neighbour that overlaps an error of the clip itself (a long error
    outlasts the N/2 exclusion zone of section 3.3) must not pull the mean
    towards the error. The spread (N, m) is the RMS angle of the kept
    neighbours from the mean, in radians.
    """
    K = words.shape[0]
    if K == 1:
        return words[0], np.zeros(words.shape[1:3])
    pair = R.geodesic_angle(words[:, None], words[None, :])  # (K, K, N, m)
    med = np.argmin(pair.sum(axis=1), axis=0)  # (N, m) medoid per cell
    to_med = np.take_along_axis(pair, med[None, None], axis=1)[:, 0]  # (K, N, m)
    keep = to_med <= 2.0 * np.median(to_med, axis=0) + np.radians(5.0)
    mean = R.quaternion_normalize(np.sum(words * keep[..., None], axis=0))
    dev = R.geodesic_angle(words, mean[None])
    spread = np.sqrt(np.sum(np.where(keep, dev**2, 0.0), axis=0) / np.maximum(keep.sum(axis=0), 1))
    return mean, spread


def test_robust_word_means_equal_the_per_word_reference():
    rng = np.random.default_rng(5)
    W, K, N, m = 30, 5, 15, 4
    base = R.quaternion_normalize(rng.normal(size=(N, m, 4)))
    outlier = 0.8 * (rng.random((W, K, 1, 1, 1)) < 0.2)  # some neighbours far off: the rule must drop them
    words = R.quaternion_normalize(base[None, None] + 0.08 * rng.normal(size=(W, K, N, m, 4)) + outlier)
    words = texture.align_hemisphere(words, base[None, None])
    valid = rng.random((W, K)) < 0.7
    valid[:, 0] |= ~valid.any(axis=1)
    valid[0] = [False, False, True, False, False]  # a single neighbour is the mean
    mean, spread = neighbours.robust_means(np.where(valid[..., None, None, None], words, 0.0), valid)
    dropped = 0
    for w in range(W):
        ref_mean, ref_spread = _reference_robust_mean(words[w][valid[w]])
        np.testing.assert_allclose(mean[w], ref_mean, atol=1e-12)
        np.testing.assert_allclose(spread[w], ref_spread, atol=1e-12)
        dropped += np.abs(ref_mean - R.quaternion_normalize(words[w][valid[w]].sum(axis=0))).max() > 1e-6
    assert np.array_equal(mean[0], words[0, 2]) and np.all(spread[0] == 0)
    assert dropped > 0


def test_minima_are_those_of_the_whole_distance_function():
    """Section 3.3: minima next to the source's own place are minima of the function, not of a masked one."""
    tgt = np.arange(60)
    dist = np.abs(tgt - 30.0)[None] * 0.1 + 1.0  # falls all the way into the source at 30: no minimum near it
    dist[0, 50] = 0.5  # a real repetition
    idx, vals = neighbours.local_minima_knn(dist, tgt, 3, np.array([30]), 7)
    got = [int(i) for i, v in zip(idx[0], vals[0]) if np.isfinite(v)]
    assert got == [50]  # not 22 or 38, the edges of the excluded zone
    assert naive_local_minima_knn(dist, tgt, 3, np.array([30]), 7)[0] == [(0.5, 50)]


def _reference_overlap_sums(F, starts, means, spreads):
    """The mean words added one word at a time, as section 3.4 averages overlapping words."""
    n, N, m = means.shape[:3]
    acc, sacc, cnt = np.zeros((F, m, 4)), np.zeros((F, m)), np.zeros(F)
    for s, mean_word, word_spread in zip(starts, means, spreads):
        ref = np.where(np.linalg.norm(acc[s : s + N], axis=-1, keepdims=True) > 0, acc[s : s + N], mean_word)
        acc[s : s + N] += texture.align_hemisphere(mean_word, ref)
        sacc[s : s + N] += word_spread
        cnt[s : s + N] += 1
    return acc, sacc, cnt


@pytest.mark.parametrize("order", ["stride", "shuffled"])
def test_overlap_sums_equal_the_one_word_at_a_time_reference(walk, order):
    """Words added in rounds give, bit for bit, the sums of one word at a time (any word order, sign flips), in one
    call or split over several."""
    rng = np.random.default_rng(1)
    q = np.asarray(walk.rotations[:200, 1:7], dtype=np.float64)  # real rotations, (200, 6, 4)
    starts = np.append(np.arange(0, 186, 5), [185, 40])  # a word flush with the end, one repeated
    if order == "shuffled":
        starts = rng.permutation(starts)
    means = np.stack([q[s : s + 15] for s in starts]) * rng.choice([-1.0, 1.0], (len(starts), 15, 6, 1))
    means += rng.normal(0.0, 0.01, means.shape)
    spreads = rng.random((len(starts), 15, 6))
    want = _reference_overlap_sums(230, starts, means, spreads)
    for cuts in ([], [1, 7, 8, 30]):
        got = np.zeros((230, 6, 4)), np.zeros((230, 6)), np.zeros(230)
        for sl in np.split(np.arange(len(starts)), cuts):
            neighbours._overlap_sums(*got, starts[sl], means[sl], spreads[sl])
        for g, w in zip(got, want):
            assert np.array_equal(g, w)
    assert got[2].max() == 4 and got[2][205:].sum() == 0


def test_mean_texture_of_a_few_words_at_a_time_equals_it_of_all_at_once(walk, flipped):
    """The real walk with a flipped knee, its warps computing their pose costs (no self matrix handed over, as on a
    take over ~100 s): the mean texture, its spread and the kept words are the same, bit for bit, whether the
    source words go 1, 7 or all at a time; and with no room to keep words, none are kept."""
    det = flipped[3]
    an, p = det.analysis, det.params
    grows = list(an.group_rows)
    nb = neighbours.Neighbors(det.neighbor_pos, det.neighbor_iend, det.neighbor_jend, det.neighbor_dist)
    args = (an.source, an.texture, grows, an.words, nb, p.source_length, p.target_length)
    want_keep: dict = {}
    want = neighbours.mean_motion_texture(*args, return_spread=True, keep=want_keep, chunk=len(an.words))
    assert len(an.words) > 7 and len(want_keep) == len(grows)
    for chunk in (1, 7):
        keep: dict = {}
        got = neighbours.mean_motion_texture(*args, return_spread=True, keep=keep, chunk=chunk)
        for a, b in zip(got, want):
            assert np.array_equal(a, b, equal_nan=True)
        assert keep.keys() == want_keep.keys()
        for key in keep:
            for a, b in zip(keep[key], want_keep[key]):
                assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True)
    full = {b"x": (None, None, np.zeros(neighbours.KEEP_WORDS_BYTES // 8), None)}
    neighbours.mean_motion_texture(*args, keep=full, chunk=7)
    assert list(full) == [b"x"]
    with pytest.raises(ValueError, match="chunk"):
        neighbours.mean_motion_texture(*args, chunk=0)


def test_exact_search_gives_the_same_neighbours_for_any_chunk_memory(walk):
    """The real walk against a context of its own other half: chunks cut small by the memory budget (one word each)
    find the same neighbours, bit for bit, as the default chunks."""
    import dataclasses

    ctx = [dataclasses.replace(walk[400:], name="rest"), dataclasses.replace(walk[400:].mirror(), name="mirrored")]
    an = ssa.prepare(walk[:400], ctx)
    grows = list(an.group_rows)
    whole = neighbours.nearest_words(an.source, an.texture, grows, an.words, self_clip=0)
    assert neighbours.chunk_words(an.words, len(an.texture.values), len(grows), 15, budget=1) == 1
    small = neighbours.nearest_words(an.source, an.texture, grows, an.words, self_clip=0, chunk_bytes=1)
    for a in ("pos", "iend", "jend", "dist"):
        assert np.array_equal(getattr(whole, a), getattr(small, a))
    assert (whole.pos >= 0).any()


def test_chunk_words_stays_under_its_budget():
    starts = np.arange(0, 500, 5)
    n = neighbours.chunk_words(starts, context_frames=22000, groups=5, N=15)
    assert 1 <= n < 96
    assert 4 * 5 * 22000 * ((n - 1) * 5 + 15) <= neighbours.CHUNK_BYTES
    assert neighbours.chunk_words(starts, context_frames=200, groups=5, N=15) == 96


def test_long_take_rows_give_the_short_take_neighbours_without_acos_matrices(walk, monkeypatch):
    """The real walk against itself with the whole-matrix cap set below its size (the path of a take over ~100 s):
    its chunks' rows of the self matrix come from the checked polynomial terms, never from the ``acos`` kernel of
    ``group_pose_distances``, each self-matrix row computed once (chunks overlap by N - 5 rows: a chunk takes those
    from the chunk before), written into one buffer that every chunk reuses, and the neighbours are those of the
    whole matrix, bit for bit."""
    an = ssa.prepare(walk)
    grows = list(an.group_rows)
    F = len(an.source.values)
    whole = neighbours.nearest_words(an.source, an.source, grows, an.words, self_clip=0)
    assert whole.self_costs is not None
    acos_cells, rows = [], []
    exact, polynomial = word_dtw.group_pose_distances, neighbours.self_costs.self_pose_rows

    def count_exact(A, B, *args):
        acos_cells.append(len(A) * len(B))
        return exact(A, B, *args)

    def count_rows(A, r0, r1, *args, **kwargs):
        rows.append((r0, r1))
        buffers.append(kwargs.get("out"))
        return polynomial(A, r0, r1, *args, **kwargs)

    buffers = []

    monkeypatch.setattr(word_dtw, "group_pose_distances", count_exact)
    monkeypatch.setattr(neighbours.self_costs, "self_pose_rows", count_rows)
    long = neighbours.nearest_words(an.source, an.source, grows, an.words, self_clip=0, self_bytes=0,
                                    chunk_bytes=4 * len(grows) * F * 40)
    assert acos_cells == []
    assert len(rows) > 3  # several chunks
    covered = np.zeros(F, dtype=int)
    for r0, r1 in rows:
        covered[r0:r1] += 1
    assert covered.max() == 1 and covered[an.words.min() : an.words.max() + 15].min() == 1
    # every chunk's rows written into one buffer, none allocated per chunk and joined to the rows it shares
    assert buffers[0] is not None and all(b is buffers[0] for b in buffers)
    assert long.self_costs is None
    for a in ("pos", "iend", "jend", "dist"):
        assert np.array_equal(getattr(whole, a), getattr(long, a))
    assert (whole.pos >= 0).any()


def test_knn_search_in_a_reused_workspace_finds_what_a_fresh_one_does(walk):
    """The pruned search's row minima written into one buffer that chunk after chunk reuses (a long take allocated
    ~50 MB per chunk and group anew): a dirty buffer, larger than a chunk needs, shared by chunks of different
    lengths, gives every neighbour, distance and end cell a fresh array gives, bit for bit."""
    an = ssa.prepare(walk)
    g = list(an.group_rows)[0]
    F = len(an.source.values)
    D = word_dtw.group_pose_distances(an.source.values, an.source.values, np.isin(np.arange(an.source.values.shape[1]),
                                      g)[None], [0])[0]
    tgt = an.source.target_starts(20)
    work = word_dtw.knn_workspace(120, len(tgt))
    work[:] = np.nan  # whatever a chunk before left there
    assert work.size == 5 * 120 * len(tgt)
    for lo, n in ((0, 12), (60, 21), (F - 75, 3)):  # chunks of 12, 21 and 3 words: 70, 115 and 25 rows
        ws = an.words[(an.words >= lo)][:n]
        f0, f1 = int(ws.min()), int(ws.max()) + 15
        args = (D[f0:f1], ws - f0, tgt, 5, ws, 7)
        fresh = word_dtw.word_knn_profile(*args, return_evaluated=True)
        reused = word_dtw.word_knn_profile(*args, return_evaluated=True, work=work)
        for a, b in zip(fresh, reused, strict=True):
            assert a.dtype == b.dtype and np.array_equal(a, b)
        assert (fresh[0] >= 0).any()
