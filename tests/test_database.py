"""MotionDatabase: building, frame bookkeeping, saving/opening, executors, search."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.database import MotionDatabase
from mocapkit.errors import MocapFormatError
from mocapkit.features import feature_set

SNEAK_4 = "HDM_bk_sneak2StepsLStart_004_120"
SNEAK_5 = "HDM_bk_sneak2StepsLStart_005_120"


def test_frames_clips_and_lookups(small_db):
    db = small_db
    assert db.num_clips == 8 and sum(c.mirrored for c in db.clips) == 4
    starts = [c.start for c in db.clips]
    assert starts[0] == 0 and all(a.stop == b.start for a, b in zip(db.clips, db.clips[1:]))
    assert db.clips[-1].stop == db.num_frames
    # consecutive indices within a clip, a new clip id exactly at each start
    ids = np.asarray(db.clip_ids)
    assert np.all(np.diff(ids) >= 0)
    assert set(np.flatnonzero(np.diff(ids)) + 1) == set(starts[1:])
    for c, info in enumerate(db.clips):
        for f in (0, info.frames - 1):
            i = db.index_of(info.name, f)
            assert db.locate(i) == (c, f)
    clip, frame = db.locate(np.arange(db.num_frames))
    np.testing.assert_array_equal(clip, ids)
    with pytest.raises(IndexError):
        db.locate(db.num_frames)
    with pytest.raises(KeyError, match="no clip named"):
        db.clip_number("nope")


def test_clips_equal_the_resampled_files(small_db):
    m = mocapkit.load(samples.path(SNEAK_4 + ".amc")).resample(30)
    got = small_db.clip(SNEAK_4)
    assert got.num_frames == m.num_frames and got.fps == 30
    np.testing.assert_allclose(np.abs((got.rotations * m.rotations).sum(-1)), 1.0, atol=1e-6)
    np.testing.assert_allclose(got.root_positions, m.root_positions, rtol=1e-6, atol=1e-5)
    f = feature_set(m, "F15", scale_cm=True).values
    a, b = small_db.clip_range(SNEAK_4)
    np.testing.assert_allclose(small_db.features["F15"][a:b], f, atol=1e-9)
    # the mirrored clip holds the mirror image
    mir = small_db.clip(SNEAK_4 + " (mirrored)")
    np.testing.assert_allclose(mir.global_positions(), m.mirror().global_positions(), atol=1e-4)


def test_segment_cannot_cross_clips(small_db):
    b = small_db.clips[0].stop
    with pytest.raises(ValueError, match="crosses a clip boundary"):
        small_db.segment(b - 2, b + 2)
    assert small_db.segment(b - 2, b).num_frames == 2


def test_other_skeleton_rejected_with_a_clear_message():
    with pytest.raises(MocapFormatError, match=r"131_01\.bvh.*skeleton differs from the database's.*joint map"):
        MotionDatabase.build([samples.path("12_walk.amc"), samples.path("131_01.bvh")], executor="serial", progress=False)


def test_joint_map_retargets_renamed_skeleton():
    m = mocapkit.load(samples.path("12_walk.amc"))
    renamed = dataclasses.replace(m.skeleton, joint_names=tuple(f"j_{n}" for n in m.skeleton.joint_names))
    other = dataclasses.replace(m, skeleton=renamed, name="renamed")
    jm = {f"j_{n}": n for n in m.skeleton.joint_names}
    db = MotionDatabase.build([m, other], fps=30, joint_map=jm, executor="serial", progress=False)
    a, b = db.clip_range("12_walk")
    c, d = db.clip_range("renamed")
    np.testing.assert_array_equal(db.rotations[a:b], db.rotations[c:d])
    np.testing.assert_array_equal(db.features["F15"][a:b], db.features["F15"][c:d])


def test_bad_sources(tmp_path):
    with pytest.raises(MocapFormatError, match="no such file"):
        MotionDatabase.build([tmp_path / "missing.bvh"], progress=False)
    with pytest.raises(MocapFormatError, match="holds no motion files"):
        MotionDatabase.build([tmp_path], progress=False)
    with pytest.raises(MocapFormatError, match="marker file|cannot go into"):
        MotionDatabase.build([samples.path("Eb015pr.c3d")], progress=False)
    with pytest.raises(ValueError, match="unknown feature set"):
        MotionDatabase.build([samples.path("12_walk.amc")], features=("F16",), progress=False)


def test_save_open_round_trip(small_db, tmp_path):
    path = small_db.save(tmp_path / "db")
    db = MotionDatabase.open(path)
    assert isinstance(db.rotations, np.memmap) and isinstance(db.features["F15"], np.memmap)
    assert not db.rotations.flags.writeable
    assert db.clips == small_db.clips and db.fps == small_db.fps
    assert [s.joint_names for s in db.skeletons] == [s.joint_names for s in small_db.skeletons]
    for a, b in zip(db.skeletons, small_db.skeletons):
        np.testing.assert_array_equal(a.offsets, b.offsets)
        assert a.channels == b.channels and a.limits == b.limits and a.unit_cm == b.unit_cm
    np.testing.assert_array_equal(db.rotations, small_db.rotations)
    np.testing.assert_array_equal(db.clip_ids, small_db.clip_ids)
    for n in small_db.feature_names:
        np.testing.assert_array_equal(db.features[n], small_db.features[n])
    q = np.asarray(small_db.features["F15"][::7])
    d1, i1 = db.index("F15").query(q, k=8)
    d2, i2 = small_db.index("F15").query(q, k=8)
    np.testing.assert_array_equal(i1, i2)
    np.testing.assert_array_equal(d1, d2)
    query = small_db.clip(SNEAK_4)[10:40]
    r1 = [r.as_dict() for r in db.search(query, k=3)]
    r2 = [r.as_dict() for r in small_db.search(query, k=3)]
    assert r1 == r2
    m = db.clip(3)
    assert m.rotations.dtype == np.float64 and m.skeleton.joint_names == small_db.skeletons[0].joint_names


def test_save_refuses_existing_and_overwrites_atomically(small_db, tmp_path):
    path = small_db.save(tmp_path / "db")
    with pytest.raises(MocapFormatError, match="already exists"):
        small_db.save(path)
    small_db.save(path, overwrite=True)
    assert MotionDatabase.open(path).num_frames == small_db.num_frames
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db"]


def test_interrupted_save_leaves_nothing(small_db, tmp_path, monkeypatch):
    calls = []

    def failing_save(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real_save(*args, **kwargs)

    real_save = np.save
    monkeypatch.setattr(np, "save", failing_save)
    with pytest.raises(KeyboardInterrupt):
        small_db.save(tmp_path / "db")
    assert list(tmp_path.iterdir()) == []


def test_open_rejects_what_is_not_a_database(tmp_path, small_db):
    with pytest.raises(MocapFormatError, match="not a motion database"):
        MotionDatabase.open(tmp_path)
    path = small_db.save(tmp_path / "db")
    np.save(path / "features" / "F15.npy", np.zeros((3, 15)))
    with pytest.raises(MocapFormatError, match=r"F15\.npy: expected shape"):
        MotionDatabase.open(path)
    desc = json.loads((path / "database.json").read_text())
    desc["format_version"] = 99
    (path / "database.json").write_text(json.dumps(desc))
    with pytest.raises(MocapFormatError, match="format version"):
        MotionDatabase.open(path)


def _sample_paths():
    return [samples.path(n) for n in ("12_walk.amc", SNEAK_4 + ".amc", SNEAK_5 + ".amc")]


def test_process_pool_build_equals_serial():
    a = MotionDatabase.build(_sample_paths(), executor="serial", progress=False)
    b = MotionDatabase.build(_sample_paths(), executor="processes", progress=False)
    assert a.clips == b.clips
    np.testing.assert_array_equal(a.features["F15"], b.features["F15"])


def test_dask_cluster_build_equals_serial():
    distributed = pytest.importorskip("distributed")
    a = MotionDatabase.build(_sample_paths(), executor="serial", progress=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            b = MotionDatabase.build(_sample_paths(), executor=client, progress=False)
            c = MotionDatabase.build(_sample_paths(), executor=cluster.scheduler_address, progress=False)
    for other in (b, c):
        assert a.clips == other.clips
        np.testing.assert_array_equal(a.rotations, other.rotations)


def test_search_finds_the_query_itself_and_the_other_take(small_db):
    query = small_db.clip(SNEAK_4)[5:35]
    best = small_db.search(query, k=3)[0]
    assert best.name == SNEAK_4 and best.start == 5 and best.end == 34
    assert best.cost == pytest.approx(0.0, abs=1e-3)  # float32 storage of the rotations
    # without its own clip, the query finds the other take of the same motion
    a, b = small_db.clip_range(SNEAK_4)
    for method in ("lng", "dtw"):
        res = small_db.search(query, k=3, exclude=(a, b), method=method)
        assert res[0].name == SNEAK_5, method
        assert all(not (a <= r.match.start < b) for r in res)
        assert [r.cost for r in res] == sorted(r.cost for r in res)


def test_lng_search_equals_dtw_search_on_real_data(small_db):
    query = small_db.clip(SNEAK_5)[20:50]
    a, b = small_db.clip_range(SNEAK_5)
    lng = small_db.search(query, k=1, exclude=(a, b), neighbors=small_db.num_frames)[0]
    dtw = small_db.search(query, k=1, exclude=(a, b), method="dtw")[0]
    assert (lng.name, lng.start, lng.end) == (dtw.name, dtw.start, dtw.end)
    assert lng.cost == pytest.approx(dtw.cost, rel=1e-9)



@pytest.mark.parametrize("method", ["lng", "dtw"])
def test_search_returns_no_segment_of_another_speed(method):
    """Classic DTW steps let a path stay on one frame: a 2.5 s sneak "matched" single held frames of the bundled
    context (47-47) once fewer real matches than k existed. Every result lasts a third to three times the query."""
    from pathlib import Path

    db = MotionDatabase.open(Path(mocapkit.__file__).parent / "data" / "context")
    query = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    M = len(db.query_features(query, db.feature_names[0]))
    spans = lambda rs: [r.end - r.start + 1 for r in rs]  # noqa: E731
    loose = spans(db.search(query, k=30, method=method, max_warp=1e9))
    assert min(loose) < M / 3  # the degenerate matches exist
    strict = spans(db.search(query, k=30, method=method))
    assert strict and all(M / 3 <= n <= 3 * M for n in strict)
    with pytest.raises(ValueError, match="max_warp"):
        db.search(query, max_warp=0.5)


def test_logical_search_grows_the_result_set(small_db):
    query = small_db.clip(SNEAK_4)[5:35]
    numeric = small_db.search(query, k=2)
    logical = small_db.logical_search(query, k=2, iterations=3)
    assert len(logical) >= len(numeric)
    for i, r in enumerate(logical):
        assert not any(r.match.overlaps(o.match) for o in logical[i + 1 :])


def test_logical_search_returns_no_segment_of_another_speed_than_the_query(small_db):
    # trial 2026-12-06: round two searched with round one's 10-frame segments and kept their 4-frame matches
    # (a third of a third of the 30-frame query); the limit is the query's, every round
    query = small_db.clip(SNEAK_4)[30:60]
    lengths = [r.end - r.start + 1 for r in small_db.logical_search(query, k=10, iterations=2)]
    assert len(lengths) > 10  # round two still adds segments
    assert all(10 <= n <= 90 for n in lengths), lengths


def test_lng_search_widens_small_neighbourhoods(small_db):
    import mocapkit

    other_rig = mocapkit.load(samples.path("131_01.bvh"))[240:360]  # 1 s of another skeleton, at 120 fps
    res = small_db.search(other_rig, k=3, neighbors=2)
    assert len(res) == 3
    assert [r.cost for r in res] == sorted(r.cost for r in res)
    fixed = small_db.search(other_rig, k=3, neighbors=2, max_neighbors=2)
    assert len(fixed) < 3  # two neighbours per frame are not enough to chain 30 frames


def test_logical_search_iterates_past_a_zero_cost_self_match(small_db):
    query = small_db.clip(SNEAK_4)[5:35]
    numeric = small_db.search(query, k=3)
    assert numeric[0].cost < 0.01  # round one finds the query itself
    logical = small_db.logical_search(query, k=3, iterations=3)
    assert logical[0].name == SNEAK_4
    # the later rounds add segments the numerical search did not return, within the cost bound
    bound = 2.0 * max(r.cost / 30 for r in numeric)
    extra = [r for r in logical if not any(r.match.overlaps(n.match) for n in numeric)]
    assert extra and all(r.cost / (r.match.path[-1, 0] + 1) <= bound + 1e-9 for r in extra)


def test_values_beyond_float32_are_refused_not_stored_as_infinity():
    """The database stores float32: a finite root position of 1e39 file units would become inf."""
    m = mocapkit.load(samples.path("131_01.bvh"))[:40]
    root = np.array(m.root_positions)
    root[:, 1] = 1e39
    huge = dataclasses.replace(m, root_positions=root)
    with pytest.raises(MocapFormatError, match="root positions beyond"):
        MotionDatabase.build([huge], fps=30, executor="serial", progress=False)
    db = MotionDatabase.build([m], fps=30, executor="serial", progress=False)  # the same clip, in range, builds
    assert np.isfinite(db.root_positions).all()


def test_a_take_with_missing_joints_is_refused_naming_it_not_stored_as_nan(tmp_path):
    """A take with gaps went into the database as NaN poses and features: `search` then dropped the clip (its own
    exact match included) and `reconstruct` failed naming the query file. Refused at build, naming the take."""
    m = mocapkit.load(samples.path("131_01.bvh"))[:40]
    rot = np.array(m.rotations)
    rot[10:12, 5] = np.nan
    gappy = tmp_path / "gappy.npz"
    mocapkit.save(dataclasses.replace(m, rotations=rot), gappy)
    with pytest.raises(MocapFormatError, match=r"gappy\.npz: 2 frames have missing joints \(NaN\); fill the gaps"):
        MotionDatabase.build([samples.path("131_01.bvh"), gappy], fps=30, executor="serial", progress=False)


def test_a_mirrored_clip_of_a_rig_whose_frames_differ_by_side_lands_on_the_reflected_take():
    """A mirrored clip's rotations are reused on the database skeleton: on the Bandai Namco game rig (no
    reflection maps it onto itself) the mirror image keeps the clip's own skeleton, so the mirrored clip posed on
    the database skeleton lands where the reflected take lands; a symmetric rig mirrors as before."""
    from pathlib import Path

    from mocapkit.motion import MIRROR_MISMATCH_MAX, mirror_mismatch

    path = Path(__file__).resolve().parent / "data" / "dataset-2_run_active_049.bvh"
    take = mocapkit.load(path)
    assert mirror_mismatch(take.skeleton) > MIRROR_MISMATCH_MAX
    db = MotionDatabase.build([path], fps=30, mirror=True, progress=False, executor="serial")
    assert [c.mirrored for c in db.clips] == [False, True] and len(db.skeletons) == 1
    assert db.skeletons[0] == take.skeleton
    posed = db.clip(1)
    want = take.mirror().global_positions()
    err = np.linalg.norm(posed.global_positions() - want, axis=-1)
    assert err.max() < 0.01  # centimetres: float32 storage
    assert MotionDatabase.build([samples.path("12_walk.amc")], fps=30, mirror=True, progress=False,
                                executor="serial").num_clips == 2


def test_a_file_named_twice_goes_in_once(tmp_path):
    # a file given and also found in a folder given went into the database twice ("... #2"), and its matches twice
    import shutil

    from mocapkit.database import expand_sources

    folder = tmp_path / "takes"
    folder.mkdir()
    walk = folder / "walk.amc"
    shutil.copy(mocapkit.samples.path("12_walk.amc"), walk)
    shutil.copy(mocapkit.samples.path("12.asf"), folder / "12.asf")
    (tmp_path / "link.amc").symlink_to(walk)
    assert expand_sources([walk, folder, tmp_path / "link.amc", str(walk)]) == [walk]


def test_a_build_hands_its_workers_absolute_paths(tmp_path, monkeypatch):
    """A remote Dask worker resolves a relative path against its own folder: every clip goes out absolute, and keeps
    the path as given as its source (the content digest does not depend on where the files lie)."""
    import os
    import shutil

    from tests.shared import record_map_ordered

    for name in ("12_walk.amc", "12.asf"):
        shutil.copy(samples.path(name), tmp_path / name)
    shutil.copy(samples.path("12_walk.amc"), tmp_path / "12_again.amc")
    monkeypatch.chdir(tmp_path)
    db = MotionDatabase.build(["12_walk.amc", "12_again.amc"], fps=30, progress=False, executor="serial")
    assert [c.source for c in db.clips] == ["12_walk.amc", "12_again.amc"]  # kept as given
    seen = record_map_ordered(monkeypatch)
    MotionDatabase.build(["12_walk.amc", "12_again.amc"], fps=30, progress=False, executor="serial")
    assert seen and all(os.path.isabs(path) for path, _ in seen)  # what the workers read


def test_a_database_of_bandai_namco_takes_keeps_and_says_their_non_commercial_licence(tmp_path):
    # the trial: `db build` from Bandai Namco takes (CC BY-NC 4.0) wrote a database that said nothing of it, while
    # docs/guide says what is built from them is non-commercial; the rig tells the takes' data set (mocapkit.rigs)
    data = Path(__file__).resolve().parent / "data"
    takes = [data / "dataset-1_dash_normal_001.bvh", data / "dataset-1_bow_active_001.bvh"]
    db = MotionDatabase.build(takes, fps=30)
    assert "CC BY-NC 4.0" in db.info["licence"] and "non-commercial" in db.info["licence"]
    db.save(tmp_path / "db")
    opened = MotionDatabase.open(tmp_path / "db")
    assert opened.summary()["licence"] == db.info["licence"]  # what `db info` and `info` print
    cmu = MotionDatabase.build([mocapkit.samples.path("131_01.bvh")], fps=30)
    assert "licence" not in cmu.info and "licence" not in cmu.summary()


def _unknown_names(m, name):
    """``m`` on joints named ``kt_00``, ``kt_01``, ... (names that say no role), and the map back."""
    names = tuple(f"kt_{j:02d}" for j in range(len(m.skeleton.joint_names)))
    sk = dataclasses.replace(m.skeleton, joint_names=names)
    return dataclasses.replace(m, skeleton=sk, name=name), dict(zip(names, m.skeleton.joint_names))


def test_joint_map_applies_to_the_first_clip_too():
    m = mocapkit.load(samples.path("131_01.bvh"))
    a, jm = _unknown_names(m, "a")
    b, _ = _unknown_names(m[: m.num_frames // 2], "b")
    db = MotionDatabase.build([a, b], fps=30, joint_map=jm, executor="serial", progress=False)
    assert db.skeletons[0].joint_names == m.skeleton.joint_names  # the database's names are the map's
    plain = MotionDatabase.build([m], fps=30, executor="serial", progress=False)
    np.testing.assert_array_equal(db.features["F15"][slice(*db.clip_range("a"))], plain.features["F15"])


def test_joint_map_refuses_two_joints_renamed_alike():
    m = mocapkit.load(samples.path("131_01.bvh"))
    a, jm = _unknown_names(m, "a")
    jm["kt_01"] = jm["kt_02"]
    with pytest.raises(MocapFormatError, match="two of the clip's joints"):
        MotionDatabase.build([a], fps=30, joint_map=jm, executor="serial", progress=False)


def test_build_refuses_an_amc_skeleton_or_rate_when_no_source_is_an_amc():
    """asf= and amc_fps= apply to .amc sources only: given for a BVH they are refused in the library's words."""
    bvh = mocapkit.samples.path("131_01.bvh")
    with pytest.raises(mocapkit.MocapError, match=r"amc_fps= is the frame rate of an \.amc input"):
        MotionDatabase.build([bvh], fps=30, amc_fps=60, executor="serial", progress=False)
    with pytest.raises(mocapkit.MocapError, match=r"asf= is the skeleton of an \.amc input"):
        MotionDatabase.build([bvh], fps=30, asf=mocapkit.samples.path("HDM_bd.asf"), executor="serial", progress=False)


def test_excluding_a_clip_excludes_its_mirror_too(small_db):
    """Leave-one-out: the query's own mirror image is no match (it ranked second with exclude=clip_range)."""
    query = small_db.clip(SNEAK_4)[5:35]
    own = {SNEAK_4, SNEAK_4 + " (mirrored)"}
    for method in ("lng", "dtw"):
        res = small_db.search(query, k=3, exclude=small_db.clip_range(SNEAK_4), method=method)
        assert res and not own & {r.name for r in res}, method
        kept = small_db.search(query, k=3, exclude=small_db.clip_range(SNEAK_4), method=method, exclude_mirrors=False)
        assert SNEAK_4 + " (mirrored)" in {r.name for r in kept}, method
    mask = small_db.excluded_frames(small_db.clip_range(SNEAK_4))
    a, b = small_db.clip_range(SNEAK_4 + " (mirrored)")
    assert mask[a:b].all() and mask.sum() == 2 * (b - a)
    assert small_db.excluded_frames(None) is None


def test_fewer_matches_than_k_come_with_a_warning_that_says_why():
    """A CMU walk in a database of HDM05 sneaks: no segment of a plausible speed for the default LNG; it says so."""
    db = MotionDatabase.build([samples.path(n) for n in (SNEAK_4 + ".amc", SNEAK_5 + ".amc")], fps=30,
                              executor="serial", progress=False)
    walk = mocapkit.load(samples.path("12_walk.amc"))
    for method in ("lng", "dtw"):
        with pytest.warns(UserWarning, match=r"of the 5 matches asked for: .*max_warp") as rec:
            res = db.search(walk, k=5, method=method)
        assert len(res) < 5 and str(len(res)) in str(rec[0].message)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # k reached: no warning
        assert len(db.search(db.clip(SNEAK_4)[5:35], k=1)) == 1
