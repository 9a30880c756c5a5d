"""Self-similarity analysis on real clips: detection finds injected errors on the right joint, repair
touches only flagged cells, the analysis is exact where the answer is known (a twin context)."""

import dataclasses

import numpy as np
import pytest
from scipy.signal import resample_poly

import mocapkit
from mocapkit import corrupt
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa import cues, neighbours, texture, word_dtw
from mocapkit.errors import SkeletonError
from mocapkit.motion import concatenate
from tests.naive import naive_local_minima_knn


@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(mocapkit.samples.path("131_01.bvh"))


@pytest.fixture(scope="module")
def flipped(walk):
    bad, mask, records = corrupt.real_errors(walk, kinds=("flip",), n_errors=1, seed=1, joints=["LeftKnee"])
    return bad, mask, records, ssa.detect(bad)


def test_shapes_and_range(walk, flipped):
    det = flipped[3]
    F, J = walk.num_frames, walk.num_joints
    assert det.mdm.shape == det.flags.shape == (F, J)
    assert np.all((det.mdm >= 0) & (det.mdm <= 1))
    assert det.params.confirm
    cues = det.holds | det.swaps | det.offsets
    assert np.array_equal(det.flags, ssa.confirm_flags(det.mdm, det.jumps, det.threshold, det.fps) | cues)
    assert not (det.flags & ~cues & (det.mdm <= det.threshold / 2)).any()
    assert not (det.jumps | cues)[:, ~det.analysed].any()
    assert det.joint_names == tuple(walk.skeleton.joint_names)
    assert det.analysed.sum() == 24 and det.analysed[0]
    assert np.all(det.mdm[:, ~det.analysed] == 0)


def test_injected_flip_is_flagged_on_its_joint_and_not_its_neighbours(walk, flipped):
    bad, mask, records, det = flipped
    sk = walk.skeleton
    r = records[0]
    j = sk.index(r.joint)
    window = slice(r.start, r.end)
    assert det.flags[window, j].mean() > 0.9
    assert not det.flags[window, sk.parents[j]].any()
    for c in sk.children(j):
        assert not det.flags[window, c].any()


def test_twin_context_reproduces_the_clip(walk):
    """With the clip's exact twin as context and K = 1, every word's neighbour is itself: no digression."""
    twin = dataclasses.replace(walk, name="twin")
    det = ssa.detect(walk, [twin], k=1)
    d = np.degrees(det.digression[:, det.analysed])
    assert np.nanmedian(d) < 0.5
    assert np.nanpercentile(d, 95) < 2.0
    # every word but the last (a 20-frame target cannot start within 20 frames of the end) finds itself
    assert (det.neighbor_dist[:, :-2, 0] < 1e-9).all()


def test_repeated_walk_is_mostly_below_threshold(walk):
    """A walk played three times: every word has exact repeats; flags are rare (the CMU thumbs flip on their own)."""
    rep = concatenate([walk, walk, walk], name="rep")
    det = ssa.detect(rep)
    assert det.flags.mean() < 0.01
    body = [walk.skeleton.index(n) for n in ("LeftKnee", "RightKnee", "LeftHip", "RightHip", "Chest", "Neck")]
    assert det.mdm[:, body].max() < det.threshold


def test_repair_changes_only_flagged_cells_and_fixes_the_error(walk, flipped):
    bad, mask, records, det = flipped
    fixed = ssa.repair(bad, det, foot_skate=False)
    keep = ~det.flags
    assert np.array_equal(fixed.rotations[keep], bad.rotations[keep])
    assert np.array_equal(fixed.root_positions, bad.root_positions)
    r = records[0]
    j = walk.skeleton.index(r.joint)
    before = np.degrees(R.geodesic_angle(bad.rotations[r.start : r.end, j], walk.rotations[r.start : r.end, j]))
    after = np.degrees(R.geodesic_angle(fixed.rotations[r.start : r.end, j], walk.rotations[r.start : r.end, j]))
    assert before.mean() > 100 and after.mean() < 20
    assert np.allclose(np.linalg.norm(fixed.rotations, axis=-1), 1.0)


def test_repair_with_foot_skate_touches_only_legs(walk, flipped):
    bad, mask, records, det = flipped
    fixed = ssa.repair(bad, det)
    changed = np.any(fixed.rotations != bad.rotations, axis=-1) & ~det.flags
    legs = set()
    for role in ("left_foot", "right_foot"):
        j = mocapkit.motion.find_joint(walk.skeleton, role)
        while j > 0:
            legs.add(j)
            j = int(walk.skeleton.parents[j])
    assert set(np.flatnonzero(changed.any(axis=0))) <= legs


def test_contact_constraint_is_met(walk, flipped):
    bad, mask, records, det = flipped
    r = records[0]
    foot = "LeftAnkle"
    target = walk.global_positions()[r.start + 5, walk.skeleton.index(foot)]
    contact = ssa.Contact(foot, r.start, r.start + 10, tuple(target))
    fixed = ssa.repair(bad, det, contacts=[contact], foot_skate=False)
    got = fixed.global_positions()[r.start : r.start + 10, walk.skeleton.index(foot)]
    reach = np.linalg.norm(got - target, axis=-1)
    assert reach.max() < 1e-6 * np.linalg.norm(walk.skeleton.offsets[walk.skeleton.index(foot)]) + 1e-6 or reach.max() < 1.0


def test_detection_round_trip(tmp_path, flipped):
    det = flipped[3]
    path = det.save(tmp_path / "det.npz")
    back = ssa.Detection.load(path)
    assert det.analysis is not None and back.analysis is None  # the prepared take is not saved
    for f in dataclasses.fields(det):
        if f.name == "analysis":
            continue
        a, b = getattr(det, f.name), getattr(back, f.name)
        if isinstance(a, np.ndarray):
            assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), f.name
        else:
            assert a == b, f.name
    assert list(tmp_path.iterdir()) == [path]


def test_repair_refuses_another_context(walk, flipped):
    bad, mask, records, det = flipped
    with pytest.raises(ValueError, match="context"):
        ssa.repair(bad, det, [dataclasses.replace(walk, name="other")])
    with pytest.raises(ValueError, match="another clip"):
        ssa.repair(bad[:100], det)


def test_bad_inputs(walk):
    hdm = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    with pytest.raises(SkeletonError, match="joints differ"):
        ssa.detect(walk, [hdm])
    with pytest.raises(ValueError, match="shorter than one motion word"):
        ssa.detect(walk[:20])
    holes = np.array(walk.rotations)
    holes[5, 3] = np.nan
    with pytest.raises(ValueError, match="missing rotations"):
        ssa.detect(dataclasses.replace(walk, rotations=holes))
    with pytest.raises(ValueError, match="threshold"):
        ssa.detect(walk, threshold=1.5)
    with pytest.raises(ValueError, match="jump_deg"):
        ssa.detect(walk, jump_deg=0)
    with pytest.raises(ValueError, match="confirm_margin_s"):
        ssa.detect(walk, confirm_margin_s=-0.1)
    with pytest.raises(ValueError, match="hold_travel_deg"):
        ssa.detect(walk, hold_travel_deg=0.0)


def test_context_clip_equal_to_the_input_is_left_out(walk):
    det = ssa.detect(walk[:400], [walk[:400]])
    assert any("the input itself" in n for n in det.notes)
    assert len(det.context_clips) == 1


def test_small_context_and_prefilter_find_the_error():
    """HDM05 sneak: one actor's take against another take of the same actor (bundled), kd-tree prefilter on."""
    a = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    b = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    bad, mask, records = corrupt.real_errors(a, kinds=("flip",), n_errors=1, seed=2, joints=["rtibia"])
    for prefilter in (False, True):
        det = ssa.detect(bad, [b], prefilter=prefilter)
        r = records[0]
        assert det.flags[r.start : r.end, a.skeleton.index("rtibia")].mean() > 0.8
        assert det.params.prefilter == prefilter


def test_prefilter_agrees_with_exhaustive_search(walk):
    ctx = [dataclasses.replace(walk[400:], name="rest")]
    ex = ssa.detect(walk[:400], ctx, prefilter=False)
    pf = ssa.detect(walk[:400], ctx, prefilter=True, candidates=64)
    # the kd-tree proposes candidates, DTW ranks them: the best neighbour is found for most words
    same = np.abs(ex.neighbor_dist[:, :, 0] - pf.neighbor_dist[:, :, 0]) <= 1e-6 + 0.05 * ex.neighbor_dist[:, :, 0]
    assert same.mean() > 0.8


def test_two_stage_matches_single_stage_on_the_error():
    a = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    b = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    bad, mask, records = corrupt.real_errors(a, kinds=("flip",), n_errors=1, seed=2, joints=["rtibia"])
    det = ssa.detect(bad, [b], two_stage=True)
    r = records[0]
    assert det.params.two_stage
    assert det.flags[r.start : r.end, a.skeleton.index("rtibia")].mean() > 0.8


def test_joint_groups_of_cmu_rig(walk):
    g = ssa.joint_groups(walk.skeleton)
    names = walk.skeleton.joint_names
    assert set(g) == {"whole", "upper", "lower", "left", "right"}
    assert "LeftKnee" in [names[j] for j in g["lower"]] and "LeftKnee" in [names[j] for j in g["left"]]
    assert "LeftElbow" in [names[j] for j in g["upper"]] and "LeftElbow" not in [names[j] for j in g["right"]]
    assert "Head" not in [names[j] for j in g["lower"]]


def test_informative_joints_take_left_and_right_partners_together():
    """On the sneak take the right hand alone ranked 25th (its partner made the 24); now the pair comes in together."""
    from mocapkit.motion import mirror_pairs

    take = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    sk = take.skeleton
    perm = mirror_pairs(sk.joint_names)
    for count in (24, 9, 5):
        sel = ssa.informative_joints([take], count)
        assert len(sel) == count and 0 in sel
        unpaired = [j for j in sel if perm[j] != j and perm[j] not in sel]
        assert len(unpaired) <= 1, [sk.joint_names[j] for j in unpaired]  # only a last slot a pair could not fill
    sel = ssa.informative_joints([take], 24)
    assert sk.index("lhand") in sel and sk.index("rhand") in sel
    assert np.array_equal(ssa.informative_joints([take.mirror()], 24), np.sort(perm[sel]))  # mirrored take: mirrored set


def test_facing_aligned_removes_heading(walk, rng):
    up = np.array([0.0, 1.0, 0.0])
    turn = R.quaternion_from_axis_angle(up, rng.uniform(-np.pi, np.pi))
    turned = np.array(walk.rotations)
    turned[:, 0] = R.quaternion_multiply(turn, turned[:, 0])
    a = ssa.facing_aligned(walk.rotations, up)
    b = ssa.facing_aligned(turned, up)
    assert np.allclose(R.geodesic_angle(a, b), 0.0, atol=1e-6)


# -- the batched neighbour-word warp against the one-word-at-a-time reference ---------------------


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


def test_unseen_words_are_not_judged(walk, flipped):
    bad = flipped[0]
    none = ssa.detect(bad, max_word_angle_deg=0.01)  # nothing in the clip is this close to anything else
    assert np.all(none.mdm == 0) and not none.holds.any()
    # steps off the path and back need no neighbour word: the flip is still found, and nothing else is
    assert np.array_equal(none.flags, none.swaps | none.offsets)
    r = flipped[2][0]
    assert none.flags[r.start : r.end, walk.skeleton.index(r.joint)].all()
    assert any("not judged" in n for n in none.notes)
    loose = ssa.detect(bad, max_word_angle_deg=180.0)
    assert np.array_equal(loose.mdm, flipped[3].mdm)


def test_a_flagged_run_without_neighbour_words_is_bridged_from_its_ends(walk, flipped):
    """No neighbour to copy from: the run is slerped between its clean ends, not bent from its own values."""
    bad, mask, records, det = flipped
    j = walk.skeleton.index(records[0].joint)
    cells = det.flags[:, j] & mask[:, j]
    garbage = np.array(bad.rotations)
    rng = np.random.default_rng(0)
    garbage[cells, j] = R.quaternion_normalize(rng.normal(size=(int(cells.sum()), 4)))  # nothing to keep in there
    garbage = dataclasses.replace(bad, rotations=garbage)
    orphan = dataclasses.replace(det, neighbor_pos=np.full_like(det.neighbor_pos, -1))
    fixed = ssa.repair(garbage, orphan, foot_skate=False)
    assert np.array_equal(fixed.rotations[~det.flags], garbage.rotations[~det.flags])
    after = np.degrees(R.geodesic_angle(walk.rotations[cells, j], fixed.rotations[cells, j]))
    assert np.median(after) < 20 and after.max() < 45


# -- confirmation by the joint's own discontinuities ---------------------------------------


def _turned(motion, joint, frames, angle_deg):
    """``motion`` with ``joint`` turned by ``angle_deg`` (scalar, or one per frame) about x on ``frames``."""
    j = motion.skeleton.index(joint)
    rot = np.array(motion.rotations)
    ang = np.broadcast_to(np.radians(angle_deg), (len(frames),))
    turn = R.quaternion_from_axis_angle(np.array([1.0, 0.0, 0.0]), ang)
    rot[frames, j] = R.quaternion_multiply(rot[frames, j], turn)
    return dataclasses.replace(motion, rotations=rot), j


def test_discontinuities_mark_steps_and_spikes_not_smooth_motion(walk):
    body = [walk.skeleton.index(n) for n in ("LeftHip", "LeftKnee", "RightKnee", "LeftShoulder", "LeftElbow", "Chest")]
    assert not ssa.discontinuities(walk)[:, body].any()  # a real walk at 120 fps is smooth
    stepped, j = _turned(walk, "LeftElbow", np.arange(300, walk.num_frames), 20.0)
    jumps = ssa.discontinuities(stepped)
    assert set(np.flatnonzero(jumps[:, j])) == {299, 300}  # both sides of the 20 deg step
    assert np.array_equal(jumps[:, np.arange(walk.num_joints) != j], ssa.discontinuities(walk)[:, np.arange(walk.num_joints) != j])
    small, j = _turned(walk, "LeftElbow", np.arange(300, walk.num_frames), 12.0)
    assert not ssa.discontinuities(small)[:, j].any()  # a 12 deg step is under 2 x 8 deg
    spiked, j = _turned(walk, "LeftElbow", np.array([400]), 10.0)
    assert np.flatnonzero(ssa.discontinuities(spiked)[:, j]).tolist() == [400]
    with pytest.raises(ValueError, match="jump_deg"):
        ssa.discontinuities(walk, jump_deg=float("nan"))


def test_confirm_flags_keep_whole_runs_that_reach_the_threshold_and_hold_a_break():
    F, fps = 100, 100.0
    mdm = np.zeros((F, 3))
    mdm[10:30, 0] = 0.3
    mdm[15:20, 0] = 0.8  # run 10-30 reaches 0.8; a break 4 frames before its start confirms it (margin 5 frames)
    mdm[60:70, 0] = 0.9  # a clear digression with no break near: distinct motion, not an error
    mdm[70:80, 1] = 0.4  # a break, but the run never exceeds the threshold
    mdm[40:50, 2] = 0.9  # the break near it is on joint 0, not this one
    jumps = np.zeros((F, 3), dtype=bool)
    jumps[6, 0] = jumps[75, 1] = jumps[45, 0] = True
    flags = ssa.confirm_flags(mdm, jumps, 0.5, fps, margin_s=0.05)
    expect = np.zeros((F, 3), dtype=bool)
    expect[10:30, 0] = True
    assert np.array_equal(flags, expect)
    assert not ssa.confirm_flags(mdm, jumps, 0.5, fps, margin_s=0.03)[:, 0].any()  # the break is 4 frames off
    # a run holding two break events is cut to them (within the margin); with one it is kept whole
    long = np.zeros((F, 1))
    long[10:70, 0] = 0.8
    steps = np.zeros((F, 1), dtype=bool)
    steps[30:32, 0] = True  # a step marks the frames on both of its sides
    assert np.flatnonzero(ssa.confirm_flags(long, steps, 0.5, fps)).tolist() == list(range(10, 70))
    steps[50, 0] = True
    assert np.flatnonzero(ssa.confirm_flags(long, steps, 0.5, fps)).tolist() == list(range(25, 56))
    early = np.zeros((F, 1))
    early[0:70, 0] = 0.8  # a run from the first frame, its first break within the margin of it
    first = np.zeros((F, 1), dtype=bool)
    first[2, 0] = first[50, 0] = True
    assert np.flatnonzero(ssa.confirm_flags(early, first, 0.5, fps)).tolist() == list(range(0, 56))
    with pytest.raises(ValueError, match="shape"):
        ssa.confirm_flags(mdm, jumps[:, :2], 0.5, fps)


def test_an_error_between_two_breaks_is_flagged_and_repaired_between_them(walk):
    """A 60 deg knee error of 0.25 s on the walk: its digression spreads over the words around it, the flags do not."""
    frames = np.arange(300, 330)
    bad, j = _turned(walk, "LeftKnee", frames, 60.0)
    det = ssa.detect(bad)
    margin = int(round(0.05 * walk.fps))
    assert (det.mdm[:, j] > 0.25).sum() > 3 * len(frames)  # the digression is wider than the error
    flagged = np.flatnonzero(det.flags[:, j])
    assert flagged.min() >= frames[0] - 1 - margin and flagged.max() <= frames[-1] + 1 + margin
    assert det.flags[frames, j].all()
    rep = ssa.repair(bad, det)
    err = np.degrees(R.geodesic_angle(rep.rotations[:, j], walk.rotations[:, j]))
    assert err[frames].max() < 20.0 and err.max() < 20.0  # was 60 in the window; no clean frame pushed far off


def test_a_smooth_distinct_gesture_is_flagged_only_without_confirmation(walk):
    """A 70 deg elbow bump over 0.6 s, once in the take: the paper's rule flags it, confirmation does not (no break)."""
    frames = np.arange(500, 572)
    bump = 70.0 * np.sin(np.linspace(0.0, np.pi, len(frames))) ** 2
    gesture, j = _turned(walk, "LeftElbow", frames, bump)
    confirmed = ssa.detect(gesture)
    paper = ssa.detect(gesture, confirm=False)
    assert np.array_equal(confirmed.mdm, paper.mdm)
    assert np.array_equal(paper.flags, paper.mdm > paper.threshold)
    assert paper.flags[frames, j].mean() > 0.3
    assert not confirmed.flags[frames, j].any()
    # the same bump with a break in it (the second half held at zero: a dropout) is an error
    broken, j = _turned(walk, "LeftElbow", frames[:36], bump[:36])
    assert ssa.detect(broken).flags[frames[:36], j].mean() > 0.3


def test_with_threshold_applies_the_detection_rule(flipped):
    det = flipped[3]
    assert np.array_equal(det.with_threshold(det.threshold).flags, det.flags)
    low = det.with_threshold(0.3)
    assert np.array_equal(low.flags, ssa.confirm_flags(det.mdm, det.jumps, 0.3, det.fps) | det.holds | det.swaps | det.offsets)
    assert (low.flags >= det.flags).all()
    plain = dataclasses.replace(det, params=det.params.replace(confirm=False))
    assert np.array_equal(plain.with_threshold(0.3).flags, det.mdm > 0.3)
    with pytest.raises(ValueError, match="threshold"):
        det.with_threshold(0.0)


def test_a_detection_file_without_jumps_loads_with_none(tmp_path, flipped):
    """Files written before confirmation existed have no jumps array; their flags were MDM > threshold."""
    det = dataclasses.replace(flipped[3], params=flipped[3].params.replace(confirm=False))
    path = det.save(tmp_path / "det.npz")
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files if k not in ("jumps", "holds", "swaps", "offsets")}
    np.savez(tmp_path / "old.npz", **arrays)
    back = ssa.Detection.load(tmp_path / "old.npz")
    assert back.jumps.shape == back.holds.shape == back.swaps.shape == back.offsets.shape == det.mdm.shape
    assert not (back.jumps.any() or back.holds.any() or back.swaps.any() or back.offsets.any())
    assert np.array_equal(back.with_threshold(0.4).flags, det.mdm > 0.4)


def _swinging(walk, joint, angle_deg):
    """``walk`` with ``joint`` set to a turn of ``angle_deg`` (one per frame) about x: a one-channel test signal."""
    j = walk.skeleton.index(joint)
    rot = np.array(walk.rotations)
    rot[:, j] = R.quaternion_from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(angle_deg))
    return dataclasses.replace(walk, rotations=rot), j


def test_held_joints_find_a_frozen_channel_and_leave_motion_alone(walk):
    F = walk.num_frames
    t = np.arange(F) / walk.fps
    swing = 30.0 * np.sin(2 * np.pi * t)  # the joint swings +-30 deg once a second
    frozen = swing.copy()
    frozen[300:340] = swing[299]  # held for 1/3 s at a value inside its range
    clamped = np.maximum(swing, -20.0)  # held at -20 deg in every swing: a joint limit the solver clamps at
    at_peak = swing.copy()
    peak = int(np.argmax(swing[200:320])) + 200
    at_peak[peak : peak + 40] = swing[peak]  # frozen once at the top of its swing, the edge of its range
    moving = np.full((F, walk.num_joints), 50.0)  # every joint analysed, its mean texture moving at 50 deg/s
    for name, signal_deg in (("frozen", frozen), ("clamped", clamped), ("at_peak", at_peak)):
        m, j = _swinging(walk, "LeftElbow", signal_deg)
        moving[:, j] = 2 * np.pi * 30.0 * np.abs(np.cos(2 * np.pi * t))  # the unfrozen swing's speed, deg/s
        held = ssa.held_joints(m, moving)
        if name == "frozen":
            assert np.flatnonzero(held[:, j]).tolist() == list(range(299, 340))
        elif name == "at_peak":
            assert np.flatnonzero(held[:, j]).tolist() == list(range(peak, peak + 40))
        else:
            assert (clamped == -20.0).sum() > 100 and not held.any()
    rest = swing.copy()
    rest[300:340] = 0.0  # held once at exactly the rest pose (a solver's straight knee), not frozen
    m, j = _swinging(walk, "LeftElbow", rest)
    assert not ssa.held_joints(m, moving).any()
    rest[300:340] = 0.05  # the same hold a twentieth of a degree off the rest pose is a freeze
    m, j = _swinging(walk, "LeftElbow", rest)
    assert np.flatnonzero(ssa.held_joints(m, moving)[:, j]).tolist() == list(range(300, 340))
    m, j = _swinging(walk, "LeftElbow", frozen)
    still_context = moving.copy()
    still_context[:, j] = 0.0  # the similar motion holds there too: no error
    assert not ssa.held_joints(m, still_context).any()
    repeated = np.array(m.rotations)
    repeated[300:340] = repeated[299]  # the whole pose held: a repeated frame, not one joint
    assert not ssa.held_joints(dataclasses.replace(m, rotations=repeated), moving).any()
    mostly, j = _swinging(walk, "LeftElbow", np.where(t < 0.6 * t[-1], 5.0, swing))  # still for 60 % of the take
    assert not ssa.held_joints(mostly, moving).any()
    with pytest.raises(ValueError, match="mean_speed"):
        ssa.held_joints(m, moving[:, :3])
    with pytest.raises(ValueError, match="travel_deg"):
        ssa.held_joints(m, moving, travel_deg=0.0)
    with pytest.raises(ValueError, match="recur_deg"):
        ssa.held_joints(m, moving, recur_deg=-1.0)
    with pytest.raises(ValueError, match="rest_deg"):
        ssa.held_joints(m, moving, rest_deg=-1.0)
    # the speeds come from a cheaper angle than rotations.geodesic_angle: the same to 1e-6 rad, also off unit length
    q = walk.rotations * 1.001
    assert np.allclose(cues.step_angles(q), R.geodesic_angle(walk.rotations[1:], walk.rotations[:-1]), atol=1e-6)


def test_detect_flags_a_freeze_from_its_first_held_frame(walk):
    bad, mask, records = corrupt.real_errors(walk, kinds=("freeze",), n_errors=1, seed=4, joints=["RightElbow"])
    r = records[0]
    j = walk.skeleton.index(r.joint)
    det = ssa.detect(bad)
    assert det.holds[r.start : r.end, j].mean() > 0.9 and (det.flags >= det.holds).all()
    assert det.flags[r.start : r.start + 5, j].all()  # where the held value is still close to the truth
    paper = ssa.detect(bad, confirm=False)
    assert not paper.flags[r.start : r.start + 5, j].any()
    others = np.arange(walk.num_joints) != j
    assert not det.holds[:, others].any()


def test_side_swaps_find_both_joints_of_a_label_swap_and_nothing_in_clean_takes(walk):
    for name in ("131_01.bvh", "12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"):
        assert not ssa.side_swaps(mocapkit.load(mocapkit.samples.path(name))).any(), name
    bad, mask, records = corrupt.real_errors(walk, kinds=("swap",), n_errors=1, seed=2)
    assert {r.kind for r in records} == {"swap"} and len(records) == 2
    swaps = ssa.side_swaps(bad)
    expect = np.zeros_like(swaps)
    for r in records:
        expect[r.start : r.end, walk.skeleton.index(r.joint)] = True
    assert np.array_equal(swaps, expect)
    one = records[0]
    j = walk.skeleton.index(one.joint)
    assert not ssa.side_swaps(bad, joints=np.arange(walk.num_joints) != j).any()  # the pair needs both joints
    assert not ssa.side_swaps(bad, max_s=0.9 * (one.end - one.start) / walk.fps).any()  # breaks too far apart
    # one side breaking alone (a step on one joint) is not a swap
    stepped, _ = _turned(walk, one.joint, np.arange(one.start, one.end), 40.0)
    assert not ssa.side_swaps(stepped).any()
    with pytest.raises(ValueError, match="max_s"):
        ssa.side_swaps(walk, max_s=0.0)
    det = ssa.detect(bad)
    assert np.array_equal(det.swaps, expect & det.analysed[None, :]) and (det.flags >= det.swaps).all()


def test_transient_offsets_flag_exactly_a_drift_or_flip_between_its_two_steps(walk):
    """A drift or flip steps off the joint's path and back: flagged from its first to its last frame, exactly."""
    for kind, seed in (("drift", 0), ("drift", 2), ("flip", 1), ("flip", 3)):
        bad, mask, records = corrupt.real_errors(walk, kinds=(kind,), n_errors=1, seed=seed)
        r = records[0]
        j = walk.skeleton.index(r.joint)
        offsets = ssa.transient_offsets(bad)
        assert np.flatnonzero(offsets[:, j]).tolist() == list(range(r.start, r.end)), (kind, seed)
        clean_joints = np.arange(walk.num_joints) != j
        assert np.array_equal(offsets[:, clean_joints], ssa.transient_offsets(walk)[:, clean_joints])
        assert not ssa.transient_offsets(bad, max_s=0.9 * (r.end - r.start) / walk.fps)[:, j].any()  # steps too far apart
        assert not ssa.transient_offsets(bad, joints=clean_joints)[:, j].any()
        det = ssa.detect(bad)
        assert (det.flags >= det.offsets).all() and det.offsets[r.start : r.end, j].all()


def test_transient_offsets_leave_smooth_motion_spikes_and_one_way_steps_alone(walk):
    for name in ("12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"):
        assert not ssa.transient_offsets(mocapkit.load(mocapkit.samples.path(name))).any(), name
    # the walk's own right-thumb glitches (180 deg turns in one frame and back) are the only ones in it
    own = ssa.transient_offsets(walk)
    assert set(np.flatnonzero(own.any(axis=0))) <= {walk.skeleton.index("RThumb")}
    others = np.ones(walk.num_joints, dtype=bool)
    others[walk.skeleton.index("RThumb")] = False
    spiked, _, records = corrupt.real_errors(walk, kinds=("spike",), n_errors=1, seed=2)  # out and back in one event
    assert not ssa.transient_offsets(spiked, joints=others).any()
    # a step that never comes back, and two steps the same way, are not a transient offset
    j = walk.skeleton.index("LeftElbow")
    stepped, _ = _turned(walk, "LeftElbow", np.arange(400, walk.num_frames), 30.0)
    assert not ssa.transient_offsets(stepped)[:, j].any()
    twice, _ = _turned(stepped, "LeftElbow", np.arange(450, walk.num_frames), 30.0)
    assert not ssa.transient_offsets(twice)[:, j].any()
    back, _ = _turned(walk, "LeftElbow", np.arange(400, 450), 30.0)
    assert np.flatnonzero(ssa.transient_offsets(back)[:, j]).tolist() == list(range(400, 450))
    with pytest.raises(ValueError, match="max_s"):
        ssa.transient_offsets(walk, max_s=0.0)


def test_transient_offsets_at_30_fps_find_errors_and_leave_fast_motion_alone():
    """At 30 fps fast motion breaks too: the untouched takes give nothing, a flip and a drift are found exactly."""
    for name in ("12_walk.amc", "131_01.bvh", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"):
        assert not ssa.transient_offsets(mocapkit.load(mocapkit.samples.path(name)).resample(30.0)).any(), name
    walk30 = mocapkit.load(mocapkit.samples.path("12_walk.amc")).resample(30.0)
    for kind, seed in (("flip", 0), ("drift", 1)):
        bad, _, records = corrupt.real_errors(walk30, kinds=(kind,), n_errors=1, seed=seed)
        r = records[0]
        offsets = ssa.transient_offsets(bad)
        assert np.flatnonzero(offsets[:, walk30.skeleton.index(r.joint)]).tolist() == list(range(r.start, r.end)), kind
        assert offsets.sum() == r.end - r.start
