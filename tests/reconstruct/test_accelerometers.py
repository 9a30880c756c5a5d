"""Tests of reconstruction from four accelerometers (Tautges 2012, ch. 3) on real clips."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import metrics, samples
from mocapkit import rotations as R
from mocapkit.database import MotionDatabase
from mocapkit.features import default_sensors, virtual_accelerometers
from mocapkit.reconstruct import accelerometers as A
from mocapkit.reconstruct.accelerometers import kernels, knowledge

DB_CLIPS = ["12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", "HDM_bk_sneak2StepsLStart_004_120.amc"]
TEST_CLIP = "HDM_bk_sneak2StepsLStart_005_120.amc"


@pytest.fixture(scope="module")
def db():
    return MotionDatabase.build([samples.path(n) for n in DB_CLIPS], fps=25, mirror=True, executor="serial", progress=False)


@pytest.fixture(scope="module")
def test_motion():
    return mocapkit.load(samples.path(TEST_CLIP)).resample(25)


@pytest.fixture(scope="module")
def readings(test_motion):
    return virtual_accelerometers(test_motion)


@pytest.fixture(scope="module")
def result(db, readings):
    return A.reconstruct(readings, db, 25)


def test_reconstruction_beats_single_frame_nn(db, test_motion, readings, result):
    assert result.num_frames == test_motion.num_frames and result.fps == 25
    assert result.skeleton is db.skeletons[0]
    err = metrics.joint_position_rms(result, test_motion, root_relative="frame")
    nn = metrics.joint_position_rms(A.reconstruct_nearest_neighbor(readings, db, 25), test_motion, root_relative="frame")
    assert np.isfinite(err) and err < 16.0  # cm; a different take of the same sneak is in the 374-frame database
    assert err < nn


def test_mahalanobis_baseline_runs_and_differs(db, test_motion, readings):
    # the first 30 of the take's 62 frames (1.2 s, a sneak step): the kernel priors' error is 13.6 cm against the
    # Gaussians' 29.5 (13.3 against 36.7 on all 62), at half the cost of the two energy minimisations
    out = A.reconstruct_mahalanobis(readings[:30], db, 25)
    energy = A.reconstruct(readings[:30], db, 25, synthesis="energy")
    err = metrics.joint_position_rms(out, test_motion[:30], root_relative="frame")
    kernel = metrics.joint_position_rms(energy, test_motion[:30], root_relative="frame")
    assert np.isfinite(err) and kernel < err  # the kernel priors beat the Gaussian ones (thesis Fig. 3.21)
    assert not np.allclose(out.rotations, energy.rotations)


def test_online_push_equals_offline(db, readings, result):
    rec = A.AccelerometerReconstructor(db, 25)
    poses = [rec.push(r) for r in readings]
    np.testing.assert_array_equal(np.stack([p.rotations for p in poses]), result.rotations)
    np.testing.assert_array_equal(np.stack([p.root_position for p in poses]), result.root_positions)
    assert not poses[3].rotations.flags.writeable
    rec.reset()
    again = [rec.push(r) for r in readings[:10]]
    np.testing.assert_array_equal(np.stack([p.rotations for p in again]), result.rotations[:10])


def test_knowledge_base_cached_and_consistent(db, test_motion):
    kb = A.knowledge_base(db)
    assert A.knowledge_base(db) is kb
    assert A.knowledge_base(db, default_sensors(db.skeletons[0])) is kb  # equal sensors, same entry
    assert kb.readings.shape == (db.num_frames, 12)
    np.testing.assert_allclose(kb.readings[:5].reshape(5, 4, 3), virtual_accelerometers(db.clip(0))[:5])
    # the reduced pose coordinates lose nothing
    np.testing.assert_allclose(kb.pose_mean + kb.pose_coords @ kb.pose_basis.T, kb.poses, atol=1e-6)


def test_clear_cache_forgets_the_knowledge_base(db):
    kb = A.knowledge_base(db)
    A.clear_cache(db)
    again = A.knowledge_base(db)
    assert again is not kb and A.knowledge_base(db) is again
    np.testing.assert_array_equal(again.readings, kb.readings)


def test_fk_kernel_matches_motion_fk(test_motion):
    """The numba root-frame FK equals Motion.global_transforms expressed in the heading frame."""
    from mocapkit.features import detect_up_axis, root_frame

    sk = test_motion.skeleton
    sensors = default_sensors(sk)
    up = detect_up_axis(sk)
    vals = knowledge.clip_values(test_motion, sensors, up)
    J = sk.num_joints
    poses = vals[:, 12:12 + 3 * J]
    rig = kernels.Rig(sk, sensors)
    pts, srot = rig.points(poses)
    heading, _ = root_frame(test_motion, up_axis=up)
    grot, gpos = test_motion.global_transforms()
    hinv = R.quaternion_conjugate(heading)[:, None]
    ref = R.quaternion_rotate(hinv, gpos[:, 1:] - gpos[:, :1]) * rig.scale
    np.testing.assert_allclose(pts[:, :J - 1], ref, atol=1e-9)
    # sensor orientations: the readings rotated back are the specific force in the heading frame
    sj = [sk.index(s.joint) for s in sensors]
    qs = R.quaternion_multiply(R.quaternion_multiply(R.quaternion_conjugate(heading)[:, None], grot[:, sj]),
                               np.stack([s.rotation for s in sensors]))
    np.testing.assert_allclose(np.abs(np.sum(srot * qs, axis=-1)), 1.0, atol=1e-9)


def _random_problem(seed, d=5, n=40):
    rng = np.random.default_rng(seed)
    sk = mocapkit.load(samples.path(TEST_CLIP)).skeleton
    sensors = default_sensors(sk)
    rig = kernels.Rig(sk, sensors)
    P = 3 * sk.num_joints
    Q = rng.normal(scale=0.2, size=(n, P))
    w = A.path_weights(rng.uniform(1, 5, n))
    mu, B, lam, Z = A.weighted_pca(Q, w, 1.0, d)
    rperp2 = np.maximum(np.sum((Q - mu) ** 2, 1) - np.sum(Z**2, 1), 0)
    X0 = rig.points(mu[None])[0][0]
    M, S = rig.M, rig.S
    Xm = X0 + rng.normal(scale=3.0, size=(n, M, 3))
    Acc = rng.normal(scale=200.0, size=(n, M, 3))
    base = (-2 * X0 + X0) / 0.04**2
    Xc = X0[M - S:] + rng.normal(scale=3.0, size=(n, S, 3))
    return rig, w, mu, B, lam, Z, rperp2, Xm, Acc, base, Xc


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_numba_minimiser_matches_numpy_twin(seed):
    rig, w, mu, B, lam, Z, rperp2, Xm, Acc, base, Xc = _random_problem(seed)
    prob = kernels.FrameEnergy(rig, dict(A.DEFAULTS), "kernel", w, mu, B, lam, Z, rperp2, Xm, Acc, base, Xc, 0.04)
    z0 = np.full(B.shape[1], 0.05)
    z1, X1, E1, s1 = kernels.minimise(prob, z0, 12)
    z2, X2, E2, s2 = kernels.minimise_numpy(prob, z0, 12)
    E0 = prob.energy(z0, prob.fk(z0[None])[0])
    assert E1 < E0 and E2 < E0
    assert E1 == pytest.approx(prob.energy(z1, X1), rel=1e-9)
    np.testing.assert_allclose(z1, z2, atol=1e-6)
    assert E1 == pytest.approx(E2, rel=1e-7)


def test_minimiser_reaches_a_local_minimum():
    """No small move in PCA space lowers the energy the minimiser returns."""
    rig, w, mu, B, lam, Z, rperp2, Xm, Acc, base, Xc = _random_problem(3)
    prob = kernels.FrameEnergy(rig, dict(A.DEFAULTS), "kernel", w, mu, B, lam, Z, rperp2, Xm, Acc, base, Xc, 0.04)
    z, X, E, _ = kernels.minimise(prob, np.zeros(B.shape[1]), 60)
    rng = np.random.default_rng(0)
    for _ in range(30):
        zt = z + rng.normal(scale=1e-2, size=z.shape)
        assert prob.energy(zt, prob.fk(zt[None])[0]) >= E - 1e-9


def test_path_weights_eq_3_3():
    w = A.path_weights(np.array([1.0, 2.0, 4.0]))
    np.testing.assert_allclose(w, [3 / 5, 2 / 5, 0.0])
    np.testing.assert_allclose(A.path_weights(np.array([2.0, 2.0])), [0.5, 0.5])


def test_weighted_pca_keeps_variance():
    rng = np.random.default_rng(4)
    Q = rng.normal(size=(50, 3)) @ np.diag([10.0, 1.0, 0.01])
    w = np.full(50, 1 / 50)
    mu, B, lam, Z = A.weighted_pca(Q, w, 0.99, 10)
    assert B.shape == (3, 2)
    np.testing.assert_allclose(B.T @ B, np.eye(2), atol=1e-12)
    np.testing.assert_allclose(Z, (Q - mu) @ B)


def test_resampled_input_rate(db, test_motion):
    m50 = mocapkit.load(samples.path(TEST_CLIP)).resample(50)
    rd50 = virtual_accelerometers(m50)
    out = A.reconstruct(rd50, db, 50)
    assert out.fps == 50 and out.num_frames == m50.num_frames
    err = metrics.joint_position_rms(out, m50, root_relative="frame")
    assert np.isfinite(err) and err < 18.0
    # the online path at 50 fps holds every database-rate pose for two input samples
    rec = A.AccelerometerReconstructor(db, 50)
    poses = [rec.push(r) for r in rd50[:9]]
    np.testing.assert_array_equal(np.stack([p.rotations for p in poses]), out.rotations[:9])
    assert rec._n_grid == 5  # grid times 0, .04, .08, .12, .16 s <= 8/50 s
    np.testing.assert_array_equal(out.rotations[1], out.rotations[0])  # t = 0.02 s: no new grid step yet
    np.testing.assert_array_equal(out.rotations[3], out.rotations[2])
    assert not np.array_equal(out.rotations[2], out.rotations[1])
    nn = A.reconstruct_nearest_neighbor(rd50, db, 50)
    assert nn.num_frames == m50.num_frames and nn.fps == 50


def test_nan_frames_hold_the_previous_pose(db, readings):
    bad = readings.copy()
    bad[10, 2, 1] = np.nan
    bad[11] = np.inf
    out = A.reconstruct(bad, db, 25)
    np.testing.assert_array_equal(out.rotations[10], out.rotations[9])
    np.testing.assert_array_equal(out.rotations[11], out.rotations[9])
    np.testing.assert_array_equal(out.root_positions[11], out.root_positions[9])
    assert np.all(np.isfinite(out.rotations))
    # a stream starting with missing samples begins at the mean pose
    rec = A.AccelerometerReconstructor(db, 25)
    p0 = rec.push(np.full((4, 3), np.nan))
    assert np.all(np.isfinite(p0.rotations))


def test_bad_input(db, readings):
    with pytest.raises(ValueError, match=r"shape \(F, S, 3\)"):
        A.reconstruct(readings[:, :, :2], db, 25)
    with pytest.raises(ValueError, match="3 sensors but 4"):
        A.reconstruct(readings[:, :3], db, 25)
    with pytest.raises(ValueError, match="4 sensors but 3"):
        A.reconstruct(readings, db, 25, sensors=default_sensors(db.skeletons[0])[:3])
    with pytest.raises(ValueError, match="fps"):
        A.reconstruct(readings, db, 0)
    with pytest.raises(ValueError, match="unknown parameter"):
        A.reconstruct(readings, db, 25, K=5)
    rec = A.AccelerometerReconstructor(db)
    with pytest.raises(ValueError, match=r"expected shape \(4, 3\)"):
        rec.push(np.zeros(12))
    with pytest.raises(ValueError, match="MotionDatabase"):
        A.knowledge_base(object())


def test_empty_database_is_refused(db):
    empty = MotionDatabase.__new__(MotionDatabase)
    empty.__dict__.update(db.__dict__)
    empty.rotations = np.zeros((0,) + db.rotations.shape[1:], dtype=np.float32)
    with pytest.raises(ValueError, match="empty"):
        A.knowledge_base(empty)


def test_other_skeleton_is_used_for_output(db, readings):
    sk = mocapkit.load(samples.path(TEST_CLIP)).skeleton
    out = A.reconstruct(readings[:8], db, 25, skeleton=sk)
    assert out.skeleton is sk


# -- real data ------------------------------------------------------------------------------------


def test_hdm05_locomotion_other_actors(shared_data):
    """An mm jog from a database of the other four actors' jogs and sneaks beats the single-frame NN."""
    root = shared_data / "hdm05_asfamc"
    classes = ("jogLeftCircle4StepsRstart", "sneak2StepsLStart")
    paths = sorted(p for p in root.glob("HDM_*_120.amc") if any(c in p.name for c in classes))
    dbp = [p for p in paths if not p.name.startswith("HDM_mm_")]
    test = mocapkit.load([p for p in paths if p.name.startswith("HDM_mm_jog")][0]).resample(25)
    big = MotionDatabase.build(dbp, fps=25, mirror=True, executor="serial", progress=False)
    rd = virtual_accelerometers(test)
    out = A.reconstruct(rd, big, 25)
    err = metrics.joint_position_rms(out, test, root_relative="frame")
    nn = metrics.joint_position_rms(A.reconstruct_nearest_neighbor(rd, big, 25), test, root_relative="frame")
    assert err < nn and err < 20.0


# -- a rig whose pelvis is not the root (Bandai Namco: joint_Root on the floor, Hips moves) -------------------

@pytest.fixture(scope="module")
def bandai_clip():
    return mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh")


@pytest.fixture(scope="module")
def bandai_db(bandai_clip):
    return MotionDatabase.build([bandai_clip], fps=30, executor="serial", progress=False)


def test_bandai_knowledge_base_is_about_the_pelvis_with_y_up(bandai_db, bandai_clip):
    kb = A.knowledge_base(bandai_db)
    # the rest pose lies along x; the data stand along y
    assert kb.up.tolist() == [0.0, 1.0, 0.0]
    hips = bandai_clip.global_positions()[:, bandai_clip.skeleton.index("Hips")]
    np.testing.assert_allclose(kb.root_height, hips[:, 1], atol=1e-3)
    # the body (Hips and below: 21 joints) is posed, not the floor-bound root
    assert kb.poses.shape[1] == 3 * 21
    assert [s.joint for s in kb.sensors] == ["LowerArm_L", "LowerArm_R", "LowerLeg_L", "LowerLeg_R"]


def test_bandai_nearest_neighbour_of_its_own_readings_is_exact(bandai_db, bandai_clip):
    m = bandai_db.clip(0)
    out = A.reconstruct_nearest_neighbor(virtual_accelerometers(m), bandai_db, 30, skeleton=m.skeleton)
    assert out.skeleton.joint_names == m.skeleton.joint_names
    assert metrics.joint_position_rms(out, m, root_relative="heading") < 1e-3
    # the pelvis stands at its height; joint_Root stays at the origin as the database's take holds it, Hips'
    # position channels carrying the translation (not the root turned into root motion under the pelvis)
    hips = m.skeleton.index("Hips")
    g, gt = out.global_positions(), m.global_positions()
    np.testing.assert_allclose(g[:, hips, 1], gt[:, hips, 1], atol=1e-3)
    np.testing.assert_array_equal(out.root_positions, m.root_positions)
    np.testing.assert_array_equal(out.rotations[:, 0], m.rotations[:, 0])
    np.testing.assert_allclose(out.translations[:, hips], g[:, hips], atol=1e-9)


def test_bandai_reconstruction_keeps_the_pelvis_on_the_body(bandai_db, bandai_clip):
    m = bandai_db.clip(0)
    out = A.reconstruct(virtual_accelerometers(m), bandai_db, 30, skeleton=m.skeleton)
    hips = m.skeleton.index("Hips")
    g, gt = out.global_positions(), m.global_positions()
    assert np.all(np.abs(g[:, hips, 1] - gt[:, hips, 1]) < 10.0)  # cm
    assert metrics.joint_position_rms(out, m, root_relative="heading") < 5.0
    np.testing.assert_array_equal(out.root_positions, 0.0)  # joint_Root where the database holds it


def test_knowledge_base_saved_opens_memory_mapped_and_reconstructs_the_same(db, readings, tmp_path):
    kb = A.knowledge_base(db)
    A.save_knowledge_base(kb, tmp_path / "kb")
    back = A.open_knowledge_base(tmp_path / "kb")
    assert isinstance(back.readings, np.memmap) and back.path == tmp_path / "kb"
    for name in ("readings", "poses", "pose_mean", "pose_basis", "pose_coords", "velocities", "accelerations",
                 "root_velocity", "yaw_rate", "root_height", "clip_ids"):
        np.testing.assert_array_equal(np.asarray(getattr(back, name)), getattr(kb, name), err_msg=name)
    assert [s.name for s in back.sensors] == [s.name for s in kb.sensors]
    np.testing.assert_array_equal(back.up, kb.up)


def test_knowledge_base_cache_dir_reuses_a_matching_folder_only(db, bandai_db, readings, tmp_path):
    A.clear_cache(db)
    built = A.knowledge_base(db, cache_dir=tmp_path / "kb")
    assert built.path is None and (tmp_path / "kb" / "knowledge.json").is_file()
    A.clear_cache(db)
    opened = A.knowledge_base(db, cache_dir=tmp_path / "kb")
    assert opened.path == tmp_path / "kb"
    a = A.reconstruct(readings[:40], db, 25)
    A.clear_cache(db)
    b = A.reconstruct(readings[:40], db, 25)  # built in memory again
    np.testing.assert_allclose(a.rotations, b.rotations, atol=1e-9)
    # another database is not served from that folder
    A.clear_cache(bandai_db)
    other = A.knowledge_base(bandai_db, cache_dir=tmp_path / "kb")
    assert other.path is None and other.num_frames == bandai_db.num_frames


def test_open_knowledge_base_names_a_bad_folder(tmp_path):
    from mocapkit.errors import MocapFormatError

    with pytest.raises(MocapFormatError, match="knowledge base"):
        A.open_knowledge_base(tmp_path)


def _listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_cache_dir_of_other_files_is_refused_before_any_work_and_kept(db, tmp_path, monkeypatch):
    """Findings 1 and 9: a results folder (files, a sub-folder) given as cache_dir is refused in one line, untouched."""
    from mocapkit.errors import MocapFormatError

    results = tmp_path / "results"
    (results / "sub").mkdir(parents=True)
    (results / "thesis_notes.txt").write_text("notes")
    (results / "sub" / "figure.png").write_bytes(b"png")
    before = _listing(tmp_path)

    def no_work(*args, **kwargs):
        raise AssertionError("the knowledge base was built before the folder was checked")

    monkeypatch.setattr(knowledge, "clip_values", no_work)
    A.clear_cache(db)
    with pytest.raises(MocapFormatError, match=r"results: refusing to replace it with a knowledge base: it is not a "
                                               r"knowledge base \(no knowledge.json\)") as info:
        A.knowledge_base(db, cache_dir=results)
    assert "\n" not in str(info.value)
    monkeypatch.undo()
    kb = A.knowledge_base(db)
    (results / "knowledge.json").write_text('{"format": 1, "sensors": []}')  # a knowledge base with an extra file
    for folder, match in ((results, "it holds sub"), (tmp_path / "results" / "thesis_notes.txt", "is a file")):
        with pytest.raises(MocapFormatError, match=match):
            A.save_knowledge_base(kb, folder)
    (results / "knowledge.json").unlink()
    assert _listing(tmp_path) == before and (results / "thesis_notes.txt").read_text() == "notes"


@pytest.mark.usefixtures("python_sigint")
def test_an_interrupted_save_leaves_nothing_and_a_retry_works(db, tmp_path, monkeypatch):
    """Finding 9: Ctrl-C while the arrays are written: no partial folder, the old knowledge base kept, retry fine."""
    import os
    import signal

    kb = A.knowledge_base(db)
    real_save, calls = np.save, []

    def interrupted_save(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            os.kill(os.getpid(), signal.SIGINT)
        return real_save(*args, **kwargs)

    monkeypatch.setattr(np, "save", interrupted_save)
    with pytest.raises(KeyboardInterrupt):
        A.save_knowledge_base(kb, tmp_path / "kb")
    assert _listing(tmp_path) == []  # no partial, no hidden folder
    monkeypatch.undo()
    A.save_knowledge_base(kb, tmp_path / "kb")  # the retry in the same process
    saved = {p: p.read_bytes() for p in (tmp_path / "kb").iterdir()}
    calls.clear()
    monkeypatch.setattr(np, "save", interrupted_save)
    with pytest.raises(KeyboardInterrupt):
        A.save_knowledge_base(kb, tmp_path / "kb")  # replacing it, interrupted: the old one is whole
    monkeypatch.undo()
    assert {p: p.read_bytes() for p in (tmp_path / "kb").iterdir()} == saved
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kb"]
    A.save_knowledge_base(kb, tmp_path / "kb")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kb"]


def test_a_cached_knowledge_base_of_other_content_is_rebuilt(db, tmp_path):
    """Finding 4: a database rebuilt from edited takes (same names and lengths) does not reuse the old cache."""
    import json

    A.clear_cache(db)
    A.knowledge_base(db, cache_dir=tmp_path / "kb")
    rot = np.array(db.rotations)
    rot[:, 1:] = rot[::-1, 1:]  # other motion in the same clips
    edited = MotionDatabase(fps=db.fps, skeletons=db.skeletons, clips=db.clips, rotations=rot,
                            root_positions=db.root_positions, features=db.features, info=db.info)
    kb = A.knowledge_base(edited, cache_dir=tmp_path / "kb")
    assert kb.path is None  # built, not opened
    assert not np.allclose(kb.poses, A.knowledge_base(db).poses)  # the edited motion's, not the cached one's
    assert json.loads((tmp_path / "kb" / "knowledge.json").read_text())["database"]["digest"] == edited.digest
    A.clear_cache(edited)
    assert A.knowledge_base(edited, cache_dir=tmp_path / "kb").path == tmp_path / "kb"  # now a match
    # a database saved to disk: its digest is read from database.json, so the match costs no array read
    saved = MotionDatabase.open(edited.save(tmp_path / "db"))
    assert saved.digest == edited.digest
    assert A.knowledge_base(saved, cache_dir=tmp_path / "kb").path == tmp_path / "kb"


# -- the search key with history -----------------------------------------------------------------------------


def test_stacked_readings_clamp_lags_at_each_clip_start():
    rd = np.arange(30, dtype=np.float64).reshape(10, 3)
    cid = np.array([0, 0, 0, 0, 1, 1, 1, 1, 1, 1])
    out = knowledge.stacked_readings(rd, cid, (0, 2))
    assert out.shape == (10, 6)
    np.testing.assert_array_equal(out[:, :3], rd)
    np.testing.assert_array_equal(out[:, 3:], rd[[0, 0, 0, 1, 4, 4, 4, 5, 6, 7]])
    np.testing.assert_array_equal(knowledge.stacked_readings(rd, None, (0, 2))[:, 3:], rd[[0, 0, 0, 1, 2, 3, 4, 5, 6, 7]])


def test_history_key_of_a_database_clip_finds_its_own_frames(db):
    """The stream's key (this sample, 3 and 6 database frames back, its first sample before that) is the knowledge base's."""
    a, b = db.clip_range(1)
    rec = A.AccelerometerReconstructor(db, 25, k=8, n_paths=2, history=(0, 3, 6), standardise=False)
    own = np.asarray(rec.kb.readings[a:b]).reshape(b - a, -1, 3)
    for t in range(12):
        rec.push(own[t])
        key = np.concatenate([own[max(t - g, 0)].ravel() for g in (0, 3, 6)])
        dist, idx = rec.index.query(key[None], k=1)
        assert idx[0, 0] == a + t and dist[0, 0] < 1e-9
        assert a + t in rec.last_info["frames"]


def test_history_must_be_lags():
    for bad in ((), (0, -1), "03", (0, 1.5)):
        with pytest.raises(ValueError, match="history"):
            A.check_params({"history": bad})


def test_unwrap_rotvecs_keeps_the_rotations_and_makes_their_mean_meaningful():
    """Two rotations 0.2 rad apart about z, either side of pi: their rotation vectors are nearly opposite."""
    a, b = np.pi - 0.1, -(np.pi - 0.1)
    Q = np.array([[0.0, 0.0, a, 0.3, 0.0, 0.0], [0.0, 0.0, b, 0.2, 0.0, 0.0]])
    assert np.linalg.norm(Q.mean(axis=0)[:3]) < 1e-12  # the naive mean is the identity: wrong
    U = A.unwrap_rotvecs(Q, Q[0])
    qa = R.rotvec_to_quaternion(Q.reshape(2, 2, 3))
    qu = R.rotvec_to_quaternion(U.reshape(2, 2, 3))
    np.testing.assert_allclose(np.abs(np.sum(qa * qu, axis=-1)), 1.0, atol=1e-12)  # same rotations
    np.testing.assert_allclose(U[:, 3:], Q[:, 3:])  # a joint far from pi is left alone
    np.testing.assert_allclose(U.mean(axis=0)[:3], [0.0, 0.0, np.pi], atol=1e-12)  # the rotation half-way between them


def test_reading_scale_standardises_every_axis(db):
    kb = A.knowledge_base(db)
    scaled = np.asarray(kb.readings) * kb.reading_scale
    np.testing.assert_allclose(scaled.std(axis=0), 1.0, rtol=1e-9)
    a = 17
    dist, idx = kb.index("kdtree", (0,), True).query(scaled[a][None], k=1)
    assert idx[0, 0] == a and dist[0, 0] < 1e-9


def test_mean_synthesis_is_the_uniform_mean_of_the_neighbours_in_one_chart(db, readings):
    rec = A.AccelerometerReconstructor(db, 25, k=32, n_paths=8, standardise=True, weights="uniform", synthesis="mean")
    for r in readings[:6]:
        rec.push(r)
    info = rec.last_info
    np.testing.assert_allclose(info["weights"], 1.0 / len(info["frames"]))
    frames = info["frames"]
    expect = A.unwrap_rotvecs(rec.kb.poses[frames], rec.kb.poses[frames[0]]).mean(axis=0)
    np.testing.assert_allclose(rec._p, expect, atol=1e-12)


def test_standardised_search_changes_the_neighbours_only_by_scaling(db, readings):
    plain = A.AccelerometerReconstructor(db, 25, k=16, n_paths=4)
    std = A.AccelerometerReconstructor(db, 25, k=16, n_paths=4, standardise=True)
    plain.push(readings[0])
    std.push(readings[0])
    s = std.kb.reading_scale
    d = np.sqrt(np.sum(((np.asarray(std.kb.readings) - readings[0].ravel()) * s) ** 2, axis=1))
    np.testing.assert_array_equal(np.sort(std.olng.current_nodes), np.sort(np.argsort(d)[:16]))


def test_weights_and_synthesis_must_be_known():
    with pytest.raises(ValueError, match="weights"):
        A.check_params({"weights": "softmax"})
    with pytest.raises(ValueError, match="synthesis"):
        A.check_params({"synthesis": "median"})


# -- the locally weighted regression synthesis ------------------------------------------------------------------


def test_clip_starts_are_each_frames_first_frame_of_its_clip():
    np.testing.assert_array_equal(knowledge.clip_starts(np.array([3, 3, 7, 7, 7, 1])), [0, 0, 2, 2, 2, 5])
    assert knowledge.clip_starts(np.zeros(0, dtype=np.int64)).shape == (0,)


def test_regression_pose_recovers_a_linear_relation_and_tends_to_the_mean_under_a_large_ridge():
    rng = np.random.default_rng(3)
    X = rng.normal(size=(40, 5))
    a, Bm = rng.normal(size=7), rng.normal(size=(5, 7))
    Q = a + X @ Bm
    w = rng.uniform(0.1, 1.0, 40)
    w /= w.sum()
    np.testing.assert_allclose(A.regression_pose(Q, X, w, 0.0), a, atol=1e-10)
    assert not np.allclose(w @ Q, a, atol=1e-2)  # the weighted mean alone misses it
    np.testing.assert_allclose(A.regression_pose(Q, X, w, 1e12), w @ Q, atol=1e-8)
    # fewer candidates than inputs: the ridge keeps it finite
    assert np.all(np.isfinite(A.regression_pose(Q[:3], X[:3], np.full(3, 1 / 3), 1e-4)))


def test_regression_cap_bounds_the_move_from_the_mean_along_its_direction():
    rng = np.random.default_rng(5)
    X = rng.normal(size=(30, 3)) + 6.0  # the query (X = 0) lies far outside the candidates' readings
    Q = 0.1 + X @ rng.normal(size=(3, 4))
    w = np.full(30, 1 / 30)
    mean = w @ Q
    spread = np.sqrt(w @ np.sum((Q - mean) ** 2, axis=1))
    free = A.regression_pose(Q, X, w, 0.0)
    assert np.linalg.norm(free - mean) > 2 * spread  # extrapolated far beyond the candidates
    capped = A.regression_pose(Q, X, w, 0.0, cap=1.0)
    np.testing.assert_allclose(np.linalg.norm(capped - mean), spread, rtol=1e-12)
    np.testing.assert_allclose((capped - mean) / spread, (free - mean) / np.linalg.norm(free - mean), atol=1e-12)
    np.testing.assert_allclose(A.regression_pose(Q, X, w, 0.0, cap=0.0), mean, atol=1e-12)
    np.testing.assert_array_equal(A.regression_pose(Q, X, w, 0.0, cap=1e9), free)  # a loose cap changes nothing


def test_regression_synthesis_regresses_over_the_cheapest_nodes_with_clip_clamped_lags(db, readings):
    lags = (0, 2, 5)
    rec = A.AccelerometerReconstructor(db, 25, k=32, n_paths=4, synthesis="regression", regression_n=12,
                                       regression_lags=lags, ridge=1e-3)
    for r in readings[:4]:  # fewer samples than the longest lag: the stream's first sample stands in
        rec.push(r)
    kb = rec.kb
    nodes, costs = rec.olng.current_nodes, rec.olng.costs
    ok = np.flatnonzero((nodes >= 0) & np.isfinite(costs))
    order = ok[np.lexsort((nodes[ok], costs[ok]))][:12]
    frames = nodes[order]
    c = costs[order] - costs[order[0]]
    w = np.exp(-c / np.median(c))
    scale = np.tile(kb.reading_scale, len(lags))
    key = np.concatenate([readings[max(3 - g, 0)].ravel() for g in lags])
    X = (knowledge.stacked_readings(kb.readings, kb.clip_ids, lags)[frames] - key) * scale
    Q = A.unwrap_rotvecs(kb.poses[frames], kb.poses[rec.last_info["frames"][0]])
    np.testing.assert_allclose(rec._p, A.regression_pose(Q, X, w / w.sum(), 1e-3, 1.0), atol=1e-9)


def test_regression_synthesis_beats_single_frame_nn(db, test_motion, readings):
    out = A.reconstruct(readings, db, 25, synthesis="regression")
    err = metrics.joint_position_rms(out, test_motion, root_relative="frame")
    nn = metrics.joint_position_rms(A.reconstruct_nearest_neighbor(readings, db, 25), test_motion, root_relative="frame")
    assert np.isfinite(err) and err < nn


def test_regression_parameters_are_checked():
    for bad in ((), (0, -2), "0"):
        with pytest.raises(ValueError, match="regression_lags"):
            A.check_params({"regression_lags": bad})
    for bad in (0, 2.5, True):
        with pytest.raises(ValueError, match="regression_n"):
            A.check_params({"regression_n": bad})
    with pytest.raises(ValueError, match="ridge"):
        A.check_params({"ridge": -1.0})
    with pytest.raises(ValueError, match="regression_cap"):
        A.check_params({"regression_cap": -0.5})
    assert A.check_params({"regression_cap": None})["regression_cap"] is None
    assert A.check_params({"synthesis": "regression"})["synthesis"] == "regression"


def test_smoothing_is_a_causal_exponential_filter_of_the_pose_vectors(db, readings):
    raw = A.AccelerometerReconstructor(db, 25, k=32, n_paths=8)
    smooth = A.AccelerometerReconstructor(db, 25, k=32, n_paths=8, smoothing=0.4)
    raw.push(readings[0])
    smooth.push(readings[0])
    np.testing.assert_array_equal(smooth._p, raw._p)  # nothing to smooth with yet
    for r in readings[1:8]:
        before = smooth._p.copy()
        raw.push(r)
        smooth.push(r)
        expect = 0.4 * A.unwrap_rotvecs(before[None], raw._p)[0] + 0.6 * raw._p
        np.testing.assert_allclose(smooth._p, expect, atol=1e-12)
    with pytest.raises(ValueError, match="smoothing"):
        A.check_params({"smoothing": 1.0})


def test_cache_dir_is_written_when_the_knowledge_base_is_already_in_memory(db, readings, tmp_path):
    """A knowledge base this process holds (from a reconstruct) is still saved to the cache_dir asked for, then opened from it."""
    A.clear_cache(db)
    A.reconstruct(readings[:10], db, 25)  # builds and keeps it in memory
    kb = A.knowledge_base(db, cache_dir=tmp_path / "kb")
    assert (tmp_path / "kb" / "knowledge.json").is_file()
    assert kb is A.knowledge_base(db)  # the one in memory, not built again
    back = A.knowledge_base(db, cache_dir=tmp_path / "kb")
    assert back.path == tmp_path / "kb"
    np.testing.assert_array_equal(np.asarray(back.readings), kb.readings)
    A.clear_cache(db)


def test_readings_faster_than_the_database_are_low_passed_before_the_grid(db):
    """A 40 Hz vibration in 100 Hz readings would alias to 10 Hz on a 25 fps grid: it is filtered out first."""
    assert A.anti_alias_filter(25.0, 25.0) is None and A.anti_alias_filter(20.0, 25.0) is None
    S = len(A.knowledge_base(db).sensors)
    t = np.arange(400) / 100.0
    still = np.tile([0.0, 9.81, 0.0], (S, 1))
    stream = still[None] + (3.0 * np.sin(2 * np.pi * 40.0 * t))[:, None, None] * np.array([1.0, 0.0, 0.0])
    rec = A.AccelerometerReconstructor(db, 100)
    grid = []
    for r in stream:
        n = rec._n_grid
        rec.push(r)
        if rec._n_grid > n:
            grid.append(rec._recent[-1])
    late = np.stack(grid)[25:]  # after the filter's first second
    assert np.abs(late - still).max() < 0.1 * 3.0  # point-sampled: the vibration's full 3 m/s^2 aliased
    np.testing.assert_allclose(late.mean(axis=0), still, atol=0.05)
    # at the database's rate nothing is filtered: the samples reach the grid as given
    rec25 = A.AccelerometerReconstructor(db, 25)
    rec25.push(stream[1])
    np.testing.assert_array_equal(rec25._recent[-1], stream[1])


def test_no_output_is_written_inside_a_knowledge_base(db, tmp_path):
    """`clean x.bvh -o KB/x.bvh` wrote into an accelerometer knowledge base (`reconstruct --knowledge KB`), which
    the next `reconstruct --knowledge KB` then refused ("it holds x.bvh, which a knowledge base save does not
    write") or, rebuilt, would replace whole: every writer's guard refuses it in one line, as inside a database."""
    import json

    from mocapkit.errors import MocapFormatError
    from mocapkit.io.outputs import check_outputs
    from mocapkit.reconstruct.accelerometers.knowledge import check_knowledge_base_output

    kb = tmp_path / "kb"
    A.knowledge_base(db, cache_dir=kb, progress=False)
    for out in (kb / "x.bvh", kb / "sub" / "model.pt"):
        with pytest.raises(MocapFormatError, match=r"refusing to write inside an accelerometer knowledge base "
                                                   r"\(.*kb\), which `reconstruct --knowledge` replaces whole; "
                                                   r"choose another folder"):
            check_outputs([out], overwrite=True)
    check_outputs([tmp_path / "x.bvh"])  # beside it is fine
    other = tmp_path / "other"  # a knowledge.json that is not a mocapkit knowledge base's is no knowledge base
    other.mkdir()
    (other / "knowledge.json").write_text(json.dumps({"format": 1}))
    check_outputs([other / "x.bvh"])
    check_knowledge_base_output(kb)  # nothing was written there: it may still be replaced
