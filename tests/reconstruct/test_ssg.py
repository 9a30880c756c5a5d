"""Subsequence-graph reconstruction (Tautges 2012, ch. 4): closed forms against brute force, and real clips."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

import mocapkit
from mocapkit import rotations as R
from mocapkit import samples
from mocapkit.database import MotionDatabase
from mocapkit.features import virtual_markers
from mocapkit.motion import Motion, unit_scale_cm
from mocapkit.reconstruct import ssg

HANDS_FEET = ["lhand", "rhand", "lfoot", "rfoot"]
HEAD_BACK = ["head", "upperneck", "thorax", "upperback"]
QUERY = "HDM_bk_sneak2StepsLStart_005_120.amc"
KNOWLEDGE = ["12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", "HDM_bk_sneak2StepsLStart_004_120.amc"]


# -- reference twins -------------------------------------------------------------------------


def brute_force_alignment(p, q, w):
    """min over (theta, x0, z0) of sum w ||p - T q||^2 by a numerical optimiser from several starts."""

    def f(x):
        return float(np.sum(w * np.sum((p - ssg.Alignment(*x).apply(q)) ** 2, axis=1)))

    best = None
    for th in np.linspace(-np.pi, np.pi, 8, endpoint=False):
        x0 = p[:, [0, 2]].mean(axis=0) - q[:, [0, 2]].mean(axis=0)
        r = minimize(f, [th, x0[0], x0[1]], method="BFGS", options={"gtol": 1e-10})
        if best is None or r.fun < best.fun:
            best = r
    return best.fun, best.x


def loop_cost_matrix(X, P, clip_ids, h):
    """Eq. 4.3 cell by cell: build both windowed point clouds and call the closed form."""
    F, N = X.shape[0], P.shape[0]
    first, last = ssg._clip_bounds(np.asarray(clip_ids))
    taps = ssg._gaussian_taps(h)
    C = np.empty((F, N))
    for n in range(F):
        for m in range(N):
            pts_p, pts_q, wts = [], [], []
            for i, ell in enumerate(range(-h, h + 1)):
                if not 0 <= n + ell < F:
                    continue
                mm = min(max(m + ell, first[m]), last[m])
                for j in range(X.shape[1]):
                    pts_p.append(X[n + ell, j])
                    pts_q.append(P[mm, j])
                    wts.append(taps[i])
            p, q, w = np.array(pts_p), np.array(pts_q), np.array(wts)
            ok = np.isfinite(p).all(axis=1)
            cost, _ = ssg.point_cloud_distance(p, q, w)
            C[n, m] = cost / w[ok].sum() if ok.any() else 0.0
    return C


coords = st.floats(-50, 50, allow_nan=False, allow_infinity=False)


@settings(max_examples=30, deadline=None)
@given(st.integers(2, 7), st.integers(0, 2**32 - 1))
def test_point_cloud_distance_equals_brute_force(K, seed):
    rng = np.random.default_rng(seed)
    p = rng.normal(0, 10, (K, 3)) + rng.normal(0, 30, 3)
    q = rng.normal(0, 10, (K, 3))
    w = rng.uniform(0.1, 2.0, K)
    cost, T = ssg.point_cloud_distance(p, q, w)
    ref, x = brute_force_alignment(p, q, w)
    assert cost == pytest.approx(ref, rel=1e-7, abs=1e-7)
    # the returned transform attains the cost
    assert np.sum(w * np.sum((p - T.apply(q)) ** 2, axis=1)) == pytest.approx(cost, rel=1e-9, abs=1e-9)


@settings(max_examples=40, deadline=None)
@given(st.floats(-3.1, 3.1), coords, coords, st.integers(0, 2**32 - 1))
def test_point_cloud_distance_recovers_a_rigid_transform(theta, x0, z0, seed):
    q = np.random.default_rng(seed).normal(0, 20, (6, 3))
    T0 = ssg.Alignment(theta, x0, z0)
    cost, T = ssg.point_cloud_distance(T0.apply(q), q)
    assert cost == pytest.approx(0.0, abs=1e-8)
    assert np.allclose([np.cos(T.theta), np.sin(T.theta), T.x0, T.z0], [np.cos(theta), np.sin(theta), x0, z0], atol=1e-8)


def test_alignment_quaternion_matches_its_point_map():
    T = ssg.Alignment(0.7, 3.0, -1.0)
    v = np.array([[1.0, 2.0, 3.0], [-2.0, 0.5, 1.0]])
    assert np.allclose(R.quaternion_rotate(T.quaternion(), v) + [3.0, 0.0, -1.0], T.apply(v))


def test_point_cloud_distance_ignores_missing_points():
    rng = np.random.default_rng(1)
    p, q = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    p2 = p.copy()
    p2[2] = np.nan
    keep = [0, 1, 3, 4]
    assert ssg.point_cloud_distance(p2, q)[0] == pytest.approx(ssg.point_cloud_distance(p[keep], q[keep])[0])
    assert ssg.point_cloud_distance(np.full((3, 3), np.nan), q[:3]) == (0.0, ssg.Alignment())


def test_cost_matrix_equals_the_cell_by_cell_closed_form_and_brute_force():
    rng = np.random.default_rng(7)
    F, N, M, h = 9, 14, 3, 2
    # database: two clips of a smooth random walk, far from the origin (round-off check)
    P = np.cumsum(rng.normal(0, 1.0, (N, M, 3)), axis=0) + [400.0, 0.0, -300.0]
    clip_ids = np.repeat([0, 1], [6, 8])
    X = np.cumsum(rng.normal(0, 1.0, (F, M, 3)), axis=0)
    X[3, 1] = np.nan  # one marker missing
    X[5] = np.nan  # a whole frame missing
    C = ssg.point_cloud_cost_matrix(X, P, clip_ids, half_window=h)
    ref = loop_cost_matrix(X, P, clip_ids, h)
    assert np.allclose(C, ref, rtol=1e-9, atol=1e-9)
    # a few cells against the numerical optimiser
    taps = ssg._gaussian_taps(h)
    for n, m in [(0, 0), (4, 5), (5, 6), (8, 13)]:
        p, q, w = [], [], []
        for i, ell in enumerate(range(-h, h + 1)):
            if 0 <= n + ell < F:
                lo, hi = (0, 5) if m < 6 else (6, 13)
                for j in range(M):
                    if np.isfinite(X[n + ell, j]).all():
                        p.append(X[n + ell, j])
                        q.append(P[min(max(m + ell, lo), hi), j])
                        w.append(taps[i])
        fun, _ = brute_force_alignment(np.array(p), np.array(q), np.array(w))
        assert C[n, m] * np.sum(w) == pytest.approx(fun, rel=1e-6, abs=1e-6)


def test_cost_matrix_no_information_is_zero_cost():
    P = np.random.default_rng(0).normal(size=(5, 2, 3))
    X = np.full((7, 2, 3), np.nan)
    X[0] = P[0]
    C = ssg.point_cloud_cost_matrix(X, P, half_window=1)
    assert np.all(C[3:] == 0.0) and np.all(C[:2] >= 0.0) and C[0, 0] == pytest.approx(0.0, abs=1e-12)


# -- windows, graph, cross-fades -----------------------------------------------------------


def test_control_windows_cover_the_signal_and_split_at_large_gaps():
    obs = np.ones(100, bool)
    obs[20:23] = False  # small gap: bridged
    obs[50:70] = False  # large gap: split
    segs = ssg.control_windows(obs, 20, 10)
    assert len(segs) == 2
    assert segs[0][0][0] == 0 and segs[0][-1][1] == 50 and segs[1][0][0] == 70 and segs[1][-1][1] == 100
    for seg in segs:
        for (a, b), (c, d) in zip(seg, seg[1:]):
            assert b - a == 20 and d - c == 20 and c < b and b - c >= 10
    # a clip shorter than a window is one window
    assert ssg.control_windows(np.ones(7, bool), 20, 10) == [[(0, 7)]]
    # leading and trailing large gaps are left out
    obs = np.zeros(60, bool)
    obs[15:45] = True
    assert ssg.control_windows(obs, 10, 5) == [[(15, 25), (20, 30), (25, 35), (30, 40), (35, 45)]]


@pytest.mark.parametrize("window,overlap", [(1, 0), (10, 0), (10, 10), (10.0, 5)])
def test_control_windows_bad_parameters(window, overlap):
    with pytest.raises(ValueError):
        ssg.control_windows(np.ones(30, bool), window, overlap)


def test_shortest_path_equals_enumeration():
    rng = np.random.default_rng(3)
    sizes = [3, 4, 2, 3]
    nodes = [[ssg.Subsequence(i, (0, 1), 0, 0, 0, float(rng.uniform()), 1.0, ssg.Alignment(), 0, 1, np.zeros(1)) for _ in range(s)] for i, s in enumerate(sizes)]
    edges = [rng.uniform(size=(a, b)) for a, b in zip(sizes, sizes[1:])]
    g = ssg.SubsequenceGraph(nodes, edges, [None] * 3, 1, [])
    for tw in (0.0, 0.5, 3.0):
        best = min(
            itertools.product(*[range(s) for s in sizes]),
            key=lambda p: sum(nodes[i][j].cost for i, j in enumerate(p)) + tw * sum(edges[i][p[i], p[i + 1]] for i in range(3)),
        )
        assert tuple(ssg.shortest_path(g, tw)) == best
    with pytest.raises(ValueError):
        ssg.shortest_path(g, -1.0)


def test_cross_fade_is_c1_and_exact_on_equal_inputs():
    a = ssg.cross_fade_weights(10)
    assert a[0] == 1.0 and a[-1] == 0.0 and np.all(np.diff(a) <= 0)
    # zero slope at both ends (C1 join with the frames outside): first differences vanish quadratically
    assert abs(a[1] - a[0]) < 0.05 and abs(a[-1] - a[-2]) < 0.05
    assert ssg.cross_fade_weights(1).tolist() == [0.5]
    rng = np.random.default_rng(0)
    q = R.quaternion_normalize(rng.normal(size=(6, 3, 4)))
    p = rng.normal(size=(6, 3))
    rot, root = ssg.cross_fade(q, p, -q, p)  # -q is the same rotation
    assert np.allclose(np.abs(np.sum(rot * q, axis=-1)), 1.0) and np.allclose(root, p)
    rot, root = ssg.cross_fade(q, p, q, p + 1.0)
    assert np.allclose(root[0], p[0]) and np.allclose(root[-1], p[-1] + 1.0)


# -- real clips ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def knowledge():
    """Bundled knowledge base without the query clip: a sneak, a jog and a CMU walk, mirrored, 30 fps."""
    return MotionDatabase.build([samples.path(n) for n in KNOWLEDGE], fps=30, mirror=True, executor="serial", progress=False)


@pytest.fixture(scope="module")
def with_query():
    """The same plus the query clip itself."""
    return MotionDatabase.build([samples.path(n) for n in KNOWLEDGE + [QUERY]], fps=30, mirror=True, executor="serial", progress=False)


@pytest.fixture(scope="module")
def truth():
    return mocapkit.load(samples.path(QUERY))


def mean_error_cm(a: Motion, b: Motion) -> np.ndarray:
    """Per-frame mean joint distance (F,), cm, global positions."""
    d = np.linalg.norm(a.global_positions() - b.global_positions(), axis=-1).mean(axis=1)
    return d * unit_scale_cm(a.skeleton)


def test_identical_copy_when_the_clip_is_in_the_database(with_query):
    """Thesis sec. 4.4: a clip in the knowledge base comes back as an identical copy, however sparse the markers."""
    clip = with_query.clip("HDM_bk_sneak2StepsLStart_005_120")
    T = ssg.Alignment(1.0, 50.0, -20.0)  # markers in another room frame
    X = T.apply(virtual_markers(clip, HANDS_FEET))
    X[30:52] = np.nan  # a large gap
    X[:5, 1] = np.nan  # one marker missing
    out = ssg.reconstruct(X, HANDS_FEET, with_query, clip.fps, k=4, skeleton=clip.skeleton)
    rot = clip.rotations.copy()
    rot[:, 0] = R.quaternion_multiply(T.quaternion(), rot[:, 0])
    ref = Motion(clip.skeleton, rot, T.apply(clip.root_positions), clip.fps)
    assert out.num_frames == clip.num_frames and out.fps == clip.fps
    assert mean_error_cm(out, ref).max() < 1e-6


def test_reconstruction_of_a_held_out_sneak(knowledge, truth):
    X = virtual_markers(truth, HANDS_FEET)
    out = ssg.reconstruct(X, HANDS_FEET, knowledge, truth.fps, skeleton=truth.skeleton)
    assert out.num_frames == truth.num_frames and out.fps == truth.fps and out.skeleton is truth.skeleton
    err = mean_error_cm(out, truth)
    assert np.isfinite(err).all()
    assert err.mean() < 9.5  # measured 8.3 cm (mean over joints and frames, global)


def test_head_and_back_markers_beat_the_framewise_baseline_with_an_80_frame_gap(knowledge, truth):
    X = virtual_markers(truth, HEAD_BACK)
    X[100:180] = np.nan  # 80 frames at 120 fps: every marker
    X[230:250] = np.nan
    out = ssg.reconstruct(X, HEAD_BACK, knowledge, truth.fps, skeleton=truth.skeleton)
    base = ssg.framewise(X, HEAD_BACK, knowledge, truth.fps, skeleton=truth.skeleton)
    e, eb = mean_error_cm(out, truth), mean_error_cm(base, truth)
    assert np.isfinite(e).all()
    assert e.mean() < 13.0  # measured 11.4 cm
    assert e.mean() < 0.8 * eb.mean()  # measured 11.4 vs 16.4 cm
    assert e[100:180].mean() < 16.0  # inside the gap (measured about 13 cm)


def test_hands_and_feet_with_an_80_frame_gap_beat_the_window_best(knowledge, truth):
    """With a large gap the graph picks the pair of extensions that join best; k = 1 has no choice."""
    X = virtual_markers(truth, HANDS_FEET)
    X[100:180] = np.nan
    X[230:250] = np.nan
    out = ssg.reconstruct(X, HANDS_FEET, knowledge, truth.fps, skeleton=truth.skeleton)
    one = ssg.reconstruct(X, HANDS_FEET, knowledge, truth.fps, k=1, skeleton=truth.skeleton)
    e, e1 = mean_error_cm(out, truth), mean_error_cm(one, truth)
    assert e.mean() < 10.5  # measured 9.0 cm
    assert e.mean() < e1.mean()  # measured 9.0 vs 10.5 cm
    # the output is smooth through the gap: no frame-to-frame jump of the root beyond a sprint's speed
    step = np.linalg.norm(np.diff(out.root_positions, axis=0), axis=1) * unit_scale_cm(truth.skeleton) * truth.fps
    assert step.max() < 800.0  # cm/s


def test_input_is_not_modified_and_rates_differ(knowledge, truth):
    X = virtual_markers(truth, HANDS_FEET)[::2]  # 60 fps
    X[10:20, 0] = np.nan
    keep = X.copy()
    out = ssg.reconstruct(X, HANDS_FEET, knowledge, 60.0, skeleton=truth.skeleton)
    ssg.framewise(X, HANDS_FEET, knowledge, 60.0)
    assert np.array_equal(X, keep, equal_nan=True)
    assert out.num_frames == X.shape[0] and out.fps == 60.0
    # a clip shorter than one window is one window
    short = ssg.reconstruct(X[:6], HANDS_FEET, knowledge, 60.0, window=1.0)
    assert short.num_frames == 6 and np.isfinite(short.rotations).all()


def test_bad_input(knowledge, truth):
    X = virtual_markers(truth, HANDS_FEET)
    with pytest.raises(ValueError, match="shape"):
        ssg.reconstruct(X[:, :, :2], HANDS_FEET, knowledge, 120.0)
    with pytest.raises(ValueError, match="names"):
        ssg.reconstruct(X, HANDS_FEET[:3], knowledge, 120.0)
    with pytest.raises(ValueError, match="not in the database skeleton"):
        ssg.reconstruct(X, ["lhand", "rhand", "lfoot", "nose"], knowledge, 120.0)
    with pytest.raises(ValueError, match="every value is NaN"):
        ssg.reconstruct(np.full_like(X, np.nan), HANDS_FEET, knowledge, 120.0)
    with pytest.raises(ValueError, match="at least 2 frames"):
        ssg.reconstruct(X[:1], HANDS_FEET, knowledge, 120.0)
    with pytest.raises(ValueError, match="fps"):
        ssg.reconstruct(X, HANDS_FEET, knowledge, 0.0)
    with pytest.raises(ValueError, match="k"):
        ssg.reconstruct(X, HANDS_FEET, knowledge, 120.0, k=0)
    with pytest.raises(ValueError, match="window"):
        ssg.reconstruct(X, HANDS_FEET, knowledge, 120.0, window=-1.0)
    other = mocapkit.load(samples.path("131_01.bvh")).skeleton
    with pytest.raises(ValueError, match="joint layout"):
        ssg.reconstruct(X, HANDS_FEET, knowledge, 120.0, skeleton=other)
    with pytest.raises(ValueError, match="db_markers"):
        ssg.point_cloud_cost_matrix(X[:, :2], np.zeros((5, 3, 3)))


# -- a rig whose pelvis is not the root (Bandai Namco: joint_Root on the floor, Hips moves) -------------------

BANDAI_MARKERS = ["Hand_L", "Hand_R", "Foot_L", "Foot_R", "Head"]


@pytest.fixture(scope="module")
def bandai_clip():
    from pathlib import Path

    return mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh").resample(30)


@pytest.fixture(scope="module")
def bandai_db(bandai_clip):
    return MotionDatabase.build([bandai_clip], fps=30, executor="serial", progress=False)


@pytest.mark.parametrize("method", ["reconstruct", "framewise"])
def test_bandai_body_overlays_its_markers_moved_on_the_ground(bandai_db, bandai_clip, method):
    # the database's own take, its markers moved 3 m along x and turned: the played-back body is aligned and
    # moved by its pelvis (Hips), not by the floor-bound joint_Root, so every joint lands where the truth's does
    m = bandai_db.clip(0)
    q = R.quaternion_from_axis_angle(np.array([0.0, 1.0, 0.0]), 0.7)
    g = R.quaternion_rotate(q, m.global_positions(end_sites=True)) + np.array([300.0, 0.0, -120.0])
    X = R.quaternion_rotate(q, virtual_markers(m, BANDAI_MARKERS)) + np.array([300.0, 0.0, -120.0])
    out = getattr(ssg, method)(X, BANDAI_MARKERS, bandai_db, 30.0, skeleton=m.skeleton)
    err = np.linalg.norm(out.global_positions(end_sites=True) - g, axis=-1)
    assert err[:, 1:].max() < 1.0  # cm, every joint but the root (the truth's joint_Root is moved with the markers)
    hips = m.skeleton.index("Hips")
    # joint_Root at the origin as the database's take holds it, Hips' channels carrying the world translation
    np.testing.assert_array_equal(out.root_positions, m.root_positions)
    np.testing.assert_allclose(out.translations[:, hips], out.global_positions()[:, hips], atol=1e-9)


def test_bandai_pelvis_lies_on_its_marker_where_seen(bandai_db, bandai_clip):
    # a marker on the pelvis (found by its role: Hips) places it where the played-back subsequence would not:
    # the truth lifted 5 cm; where the Hips marker is hidden the offset is interpolated, never a jump
    m = bandai_db.clip(0)
    joints = BANDAI_MARKERS + ["Hips"]
    X = virtual_markers(m, joints) + np.array([0.0, 5.0, 0.0])
    X[20:30, -1] = np.nan
    out = ssg.reconstruct(X, joints, bandai_db, 30.0, skeleton=m.skeleton)
    hips = out.global_positions()[:, m.skeleton.index("Hips")]
    seen = np.isfinite(X[:, -1, 0])
    np.testing.assert_allclose(hips[seen], X[seen, -1], atol=1e-6)
    truth = m.global_positions()[:, m.skeleton.index("Hips")] + [0.0, 5.0, 0.0]
    assert np.linalg.norm(hips - truth, axis=-1).max() < 1.0


def test_bandai_performer_skeleton_in_metres_is_played_back_in_metres(bandai_db, bandai_clip):
    import dataclasses

    m = bandai_db.clip(0)
    sk = m.skeleton
    s = unit_scale_cm(sk) / 100.0
    metres = dataclasses.replace(sk, offsets=sk.offsets * s, end_site_offsets=sk.end_site_offsets * s, unit_cm=100.0)
    X = virtual_markers(m, BANDAI_MARKERS)  # the database's unit (cm)
    out = ssg.reconstruct(X, BANDAI_MARKERS, bandai_db, 30.0, skeleton=metres)
    assert out.skeleton is metres
    err = np.linalg.norm(out.global_positions() * 100.0 - m.global_positions() * unit_scale_cm(sk), axis=-1)
    assert err[:, 1:].max() < 1.0


def test_a_marker_never_seen_is_left_out_with_a_warning(knowledge, truth):
    """From Python too (the command line says it in a note): a marker NaN in every frame is named, not dropped
    silently."""
    take = truth.resample(30)[:30]
    X = virtual_markers(take, HANDS_FEET)
    X[:, 1] = np.nan
    with pytest.warns(UserWarning, match=rf"marker\(s\) on {HANDS_FEET[1]} never seen in any frame"):
        ssg.framewise(X, HANDS_FEET, knowledge, 30.0, skeleton=take.skeleton)


def test_without_a_pelvis_marker_the_body_meets_the_markers_heights(knowledge, truth):
    """Eq. 4.3 places a subsequence on the ground plane only: markers 30 cm below any database pose's (a floor
    lower than the database's, or a pose the database lacks played at another height) leave the body floating
    unless its height is taken from the markers."""
    take = truth.resample(30)[:60]
    X = virtual_markers(take, HANDS_FEET)
    drop = 30.0 / unit_scale_cm(take.skeleton)
    X[..., 1] -= drop
    out = ssg.reconstruct(X, HANDS_FEET, knowledge, 30.0, skeleton=take.skeleton)
    dy = (X - virtual_markers(out, HANDS_FEET))[..., 1] * unit_scale_cm(take.skeleton)
    assert abs(np.median(dy)) < 3.0, np.median(dy)  # 23 cm before the heights were taken from the markers
