"""Repair on real clips: only flagged cells change, the error is fixed, contacts and foot skate respected."""

import dataclasses
import importlib

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from tests.cleaning.ssa.helpers import offset_on, turned, twin_of


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
    """The contact's frames put the ankle on its target exactly: the two-bone IK is analytic, so the miss is the
    target's distance beyond the leg's reach (zero here), up to round-off; without the contact it misses."""
    bad, mask, records, det = flipped
    r = records[0]
    sk = walk.skeleton
    foot = sk.index("LeftAnkle")
    knee = int(sk.parents[foot])
    hip = int(sk.parents[knee])
    target = walk.global_positions()[r.start + 5, foot]
    contact = ssa.Contact("LeftAnkle", r.start, r.start + 10, tuple(target))
    fixed = ssa.repair(bad, det, contacts=[contact], foot_skate=False)
    gp = fixed.global_positions()[r.start : r.start + 10]
    reach = np.linalg.norm(gp[:, foot] - target, axis=-1)
    thigh, shin = np.linalg.norm(sk.offsets[knee]), np.linalg.norm(sk.offsets[foot])
    d = np.linalg.norm(target - gp[:, hip], axis=-1)
    shortfall = np.maximum.reduce([np.zeros_like(d), d - (thigh + shin), abs(thigh - shin) - d])
    assert np.all(shortfall == 0)  # the target is within the leg's reach in every contact frame
    np.testing.assert_allclose(reach, shortfall, rtol=0, atol=1e-9 * (thigh + shin))
    free = ssa.repair(bad, det, foot_skate=False).global_positions()[r.start : r.start + 10, foot]
    assert np.linalg.norm(free - target, axis=-1).max() > 1e-3 * (thigh + shin)  # the contact is what moved the ankle


def test_repair_refuses_another_context(walk, flipped):
    bad, mask, records, det = flipped
    with pytest.raises(ValueError, match="context"):
        ssa.repair(bad, det, [twin_of(walk, "other")])
    with pytest.raises(ValueError, match="another clip"):
        ssa.repair(bad[:100], det)


def test_a_flagged_run_without_neighbour_words_is_bridged_from_its_ends(walk, flipped):
    """No neighbour to copy from: the run is slerped between its clean ends, not bent from its own values."""
    bad, mask, records, det = flipped
    j = walk.skeleton.index(records[0].joint)
    cells = det.flags[:, j] & mask[:, j]
    garbage = np.array(bad.rotations)
    rng = np.random.default_rng(0)
    garbage[cells, j] = R.quaternion_normalize(rng.normal(size=(int(cells.sum()), 4)))  # nothing to keep in there
    garbage = dataclasses.replace(bad, rotations=garbage)
    # flagged by the break rule alone (a transient offset's cells are not replaced but have their offset taken away,
    # which garbage has none of: test_a_transient_offset_is_repaired_by_taking_its_offset_away)
    orphan = dataclasses.replace(det, neighbor_pos=np.full_like(det.neighbor_pos, -1),
                                 offsets=np.zeros_like(det.offsets))
    fixed = ssa.repair(garbage, orphan, foot_skate=False)
    assert np.array_equal(fixed.rotations[~det.flags], garbage.rotations[~det.flags])
    after = np.degrees(R.geodesic_angle(walk.rotations[cells, j], fixed.rotations[cells, j]))
    assert np.median(after) < 20 and after.max() < 45


def test_an_error_between_two_breaks_is_flagged_and_repaired_between_them(walk):
    """A 60 deg knee error of 0.25 s on the walk: its digression spreads over the words around it, the flags do not."""
    frames = np.arange(300, 330)
    bad, j = turned(walk, "LeftKnee", frames, 60.0)
    det = ssa.detect(bad)
    margin = int(round(0.05 * walk.fps))
    assert (det.mdm[:, j] > 0.25).sum() > 3 * len(frames)  # the digression is wider than the error
    flagged = np.flatnonzero(det.flags[:, j])
    assert flagged.min() >= frames[0] - 1 - margin and flagged.max() <= frames[-1] + 1 + margin
    assert det.flags[frames, j].all()
    rep = ssa.repair(bad, det)
    err = np.degrees(R.geodesic_angle(rep.rotations[:, j], walk.rotations[:, j]))
    assert err[frames].max() < 20.0 and err.max() < 20.0  # was 60 in the window; no clean frame pushed far off


def _reference_blend_runs(orig, new, flags, window):
    """The blend of :func:`repair._blend_runs` one run at a time, as section 4 describes it."""
    from scipy.signal import savgol_filter

    from mocapkit.cleaning.ik import contact_segments
    from mocapkit.cleaning.ssa.texture import align_hemisphere

    F = len(orig)
    out, track = np.array(orig), np.array(orig)
    for a, b in contact_segments(flags):
        rep = align_hemisphere(new[a:b], np.broadcast_to(orig[a - 1] if a > 0 else new[a], new[a:b].shape))
        rep = R.quaternion_continuity(rep, axis=0)
        da = R.quaternion_log(R.quaternion_multiply(orig[a - 1], R.quaternion_inverse(rep[0]))) if a > 0 else np.zeros(3)
        db = R.quaternion_log(R.quaternion_multiply(orig[b], R.quaternion_inverse(rep[-1]))) if b < F else da * 0
        if a == 0:
            da = db
        if b == F:
            db = da
        u = (np.arange(a, b) - (a - 1)) / (b - (a - 1))
        delta = (1 - u)[:, None] * da + u[:, None] * db
        track[a:b] = R.quaternion_multiply(R.quaternion_exp(delta), rep)
    cont = R.quaternion_continuity(track, axis=0)
    smooth = savgol_filter(cont, window, 2, axis=0, mode="interp") if F >= window else cont
    smooth = R.quaternion_normalize(smooth)
    out[flags] = align_hemisphere(smooth[flags], orig[flags])
    return out


@pytest.mark.parametrize("seed", range(6))
def test_blend_runs_equal_the_one_run_at_a_time_reference(walk, seed):
    import importlib

    rp = importlib.import_module("mocapkit.cleaning.ssa.repair")  # the package's name repair is the function
    rng = np.random.default_rng(seed)
    j = 1 + seed % (walk.num_joints - 1)
    orig = np.array(walk.rotations[:, j])
    F = len(orig)
    new = R.quaternion_normalize(orig + rng.normal(0.0, 0.3, orig.shape))
    new *= np.where(rng.random(F) < 0.3, -1.0, 1.0)[:, None]  # sign flips inside runs
    flags = rng.random(F) < [0.05, 0.3, 0.6, 0.9, 0.02, 0.5][seed]
    flags[:3] = seed % 2 == 0  # runs touching the first and last frames, or not
    flags[-2:] = seed % 3 == 0
    flags[F // 2] = True  # at least one run
    if seed == 5:
        flags[:] = True  # one run over the whole track
    window = 31 if seed != 4 else F + 1
    got = rp._blend_runs(orig, new, flags, window)
    assert np.array_equal(got, _reference_blend_runs(orig, new, flags, window))
    assert np.array_equal(got[~flags], orig[~flags])


@pytest.mark.parametrize("seed", range(4))
def test_bridge_equals_the_one_run_at_a_time_slerp(walk, seed):
    import importlib

    from mocapkit.cleaning.ik import contact_segments

    rp = importlib.import_module("mocapkit.cleaning.ssa.repair")
    rng = np.random.default_rng(seed)
    track = np.array(walk.rotations[:, 3 + seed])
    F = len(track)
    mask = rng.random(F) < [0.1, 0.5, 0.9, 1.0][seed]
    mask[:2] = seed % 2 == 1  # runs at the ends, or not
    want = np.array(track)
    for a, b in contact_segments(mask):  # the plain loop: slerp between the frames around each run
        lo = want[a - 1] if a > 0 else None
        hi = want[b] if b < F else None
        if lo is None and hi is None:
            continue
        lo = hi if lo is None else lo
        hi = lo if hi is None else hi
        u = (np.arange(a, b) - (a - 1)) / (b - (a - 1))
        want[a:b] = R.slerp(np.broadcast_to(lo, (b - a, 4)), np.broadcast_to(hi, (b - a, 4)), u)
    got = np.array(track)
    bridged = rp._bridge(got, mask)
    assert np.array_equal(got, want)
    assert np.array_equal(bridged, mask if seed < 3 else np.zeros(F, dtype=bool))  # a run over all is left alone


def test_nearest_sorted_is_the_argmin_it_replaces():
    """The source word of each frame: the nearest word centre, the earlier on a tie, as the (F, W) argmin gave it
    (its 4 GB matrix on a 10-minute take is gone), on random, tied and out-of-range queries."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from mocapkit.cleaning.ssa.texture import nearest_sorted

    @settings(max_examples=200, deadline=None)
    @given(st.lists(st.integers(-50, 50), min_size=1, max_size=30), st.lists(st.integers(-80, 80), max_size=60),
           st.sampled_from([1.0, 0.5, 0.25]))
    def check(values, queries, scale):
        v = np.sort(np.asarray(values, dtype=np.float64)) * scale
        q = np.asarray(queries, dtype=np.float64) * scale * 0.5
        slow = np.argmin(np.abs(q[:, None] - v[None, :]), axis=1) if len(q) else np.zeros(0, dtype=np.int64)
        assert np.array_equal(nearest_sorted(v, q), slow)

    check()


def test_undone_offsets_take_away_a_constant_offset_in_either_frame_and_a_linear_drift():
    from mocapkit.cleaning.ssa.undo import undone_offsets

    t = np.arange(120) / 120.0
    axis = np.array([0.3, 0.8, 0.5]) / np.linalg.norm([0.3, 0.8, 0.5])
    track = R.quaternion_multiply(R.quaternion_from_axis_angle(axis, 2.0 * np.sin(3.0 * t)),
                                  R.quaternion_from_axis_angle(np.array([0.0, 0.0, 1.0]), 0.7 + t))
    mask = np.zeros(120, dtype=bool)
    mask[40:80] = True
    x = np.array([1.0, 0.0, 0.0])
    cases = {"parent": lambda ang, q: R.quaternion_multiply(R.quaternion_from_axis_angle(x, ang), q),
             "own": lambda ang, q: R.quaternion_multiply(q, R.quaternion_from_axis_angle(x, ang))}
    for name, apply in cases.items():
        for ang in (np.full(40, np.radians(60.0)), np.full(40, np.pi), np.radians(np.linspace(10.0, 40.0, 40))):
            if name == "own" and ang[0] != ang[-1]:
                continue  # a drift along a fixed axis of the joint's own frame turns that axis with the joint
            bad = np.array(track)
            bad[40:80] = apply(ang, track[40:80])
            got, undone = undone_offsets(bad, mask)
            assert np.array_equal(undone, mask)
            assert np.array_equal(got[~mask], bad[~mask])
            assert np.degrees(R.geodesic_angle(got[40:80], track[40:80])).max() < 0.5, name


@pytest.mark.parametrize("start, own_frame", [(200, False), (760, True)])
def test_a_transient_offset_is_repaired_by_taking_its_offset_away(walk, start, own_frame):
    """The offset across the wrist's own 133 and 76 deg turns (tests/cleaning/ssa/test_cues.py): neighbour words
    of a walk put back other wrist motion (60 -> 54 and 68 deg off); taking the offset measured at its two steps
    away keeps the wrist's own motion, under a degree from the truth, and no other cell changes."""
    frames = np.arange(start, start + 100)
    bad, j = offset_on(walk, "RightWrist", frames, 60.0, own_frame)
    det = ssa.detect(bad)
    fixed = ssa.repair(bad, det, foot_skate=False)
    assert np.array_equal(fixed.rotations[~det.flags], bad.rotations[~det.flags])
    err = np.degrees(R.geodesic_angle(fixed.rotations[frames, j], walk.rotations[frames, j]))
    assert err.max() < 1.0, err.max()


def test_repair_reads_the_words_its_detection_kept_bit_for_bit(flipped):
    """The neighbour words a detection keeps for its flags (Analysis.warped, warped on the search's own pose
    distances) are the words the repair would warp: the same repair, bit for bit, with them and without."""
    bad, mask, records, det = flipped
    assert det.analysis.warped  # the flagged words' neighbours, kept
    kept = ssa.repair(bad, det, foot_skate=False)
    bare = dataclasses.replace(det, analysis=dataclasses.replace(det.analysis, warped={}))
    assert not bare.analysis.warped
    warped = ssa.repair(bad, bare, foot_skate=False)
    assert np.array_equal(kept.rotations, warped.rotations)
    assert not np.array_equal(kept.rotations, bad.rotations)


@pytest.mark.parametrize("fail_first", [False, True])
def test_medoid_words_are_those_of_warping_every_candidate(flipped, fail_first):
    """The repair warps only the candidates its medoid may take (within reach of the nearest that warps), and those
    are what warping every candidate gives (the slow reference): the same words for the same candidates, the rest
    out of reach. With a nearest candidate that fails (its word runs past its clip), a second round reaches further."""
    from mocapkit.cleaning.ssa.neighbours import dropped_terms, near_neighbors, neighbor_words

    rp = importlib.import_module("mocapkit.cleaning.ssa.repair")
    bad, mask, records, det = flipped
    an = det.analysis
    src, full, words = an.source, an.texture, det.word_starts
    N, M = int(det.params.source_length), int(det.params.target_length)
    groups = [np.flatnonzero(det.group_masks[g]) for g in range(len(det.group_names))]
    end = int(full.clip_starts[1]) - M + 1  # a word here runs one frame past the take: never warped
    candidates = {}
    for g in range(len(groups)):
        for w in np.flatnonzero((det.neighbor_pos[g] >= 0).any(axis=1))[:6]:
            pos, dist = det.neighbor_pos[g, w], det.neighbor_dist[g, w]
            cands = [(k, float(dist[k]), int(q)) for k, q in enumerate(pos) if q >= 0]
            if fail_first:
                cands.append((len(pos), 0.5 * min(d for _, d, _ in cands), end))
            candidates[(g, int(w))] = cands
    bare = dataclasses.replace(an, warped={})
    got = rp._medoid_words(bare, src, full, groups, words, candidates, N, M)
    for (g, w), cands in candidates.items():
        members = groups[g]
        qs = np.array([q for _, _, q in cands])
        nws, ok = neighbor_words(src.values, full, members, dropped_terms(members), np.full(len(qs), words[w]), qs, N, M)
        assert ok.any() and not (fail_first and ok[-1])
        nearest = min(d for (_, d, _), good in zip(cands, ok) if good)
        for (k, d, _), nw, good in zip(cands, nws, ok):
            if good and near_neighbors(d, nearest):
                assert np.array_equal(got[g, w, k], nw)
            elif (g, w, k) in got:
                assert got[g, w, k] is None or not near_neighbors(d, nearest)
