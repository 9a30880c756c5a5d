"""mocapkit.context: --context resolved to a database (opened, built and cached, or the bundled default)."""

import dataclasses
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import context as C
from mocapkit.database import MotionDatabase
from mocapkit.errors import MocapError, MocapFormatError
from mocapkit.motion import Motion, Skeleton


@pytest.fixture
def takes(tmp_path):
    """A folder of three small Acclaim takes, each AMC beside its ASF, in two subfolders."""
    d = tmp_path / "takes"
    (d / "cmu").mkdir(parents=True)
    (d / "hdm").mkdir()
    for n in ("12.asf", "12_walk.amc"):
        shutil.copy(mocapkit.samples.path(n), d / "cmu" / n)
    for n in ("HDM_bk.asf", "HDM_bk_sneak2StepsLStart_004_120.amc", "HDM_bk_sneak2StepsLStart_005_120.amc"):
        shutil.copy(mocapkit.samples.path(n), d / "hdm" / n)
    return d


def _other_rig_take(path):
    """A short BVH on a three-joint chain (another rig than the Acclaim takes)."""
    sk = Skeleton(joint_names=("hips", "spine", "head"), parents=np.array([-1, 0, 1]),
                  offsets=np.array([[0.0, 0, 0], [0, 10, 0], [0, 10, 0]]),
                  end_site_parents=np.array([2]), end_site_offsets=np.array([[0.0, 5, 0]]))
    rot = np.zeros((40, 3, 4))
    rot[..., 0] = 1.0
    mocapkit.save(Motion(sk, rot, np.zeros((40, 3)), 30.0, "chain"), path)


def test_none_false_and_off_turn_the_context_off():
    for spec in (False, "none", "NONE", ["none"], ("off",)):
        assert C.is_off(spec) and C.resolve_context(spec) is None
    assert C.resolve_context(None, default=False) is None and C.resolve_context([], default=False) is None


def test_the_default_context_is_bundled_small_and_named():
    db = C.resolve_context(None)
    assert isinstance(db, MotionDatabase) and db.info.get("default") is True
    assert db.fps == C.BUILD_FPS and db.num_clips >= 20 and db.duration >= 60.0
    size = sum(p.stat().st_size for p in C.default_context_path().rglob("*") if p.is_file())
    assert size < 20 * 2**20
    sources = db.info["sources"]
    assert not [s for s in sources if s.startswith("HDM_mm_") or s.startswith("131_")]
    assert C.context_label(db).startswith("the bundled default context (") and f"{db.num_clips} clips" in C.context_label(db)


def test_a_folder_is_built_once_then_reused_and_a_changed_file_makes_a_new_key(takes, tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    db = C.resolve_context(takes, cache_dir=cache)
    assert db.num_clips == 3 and db.fps == C.BUILD_FPS
    assert C.context_label(db).startswith(f"the takes of {takes} (3 clips")
    entries = [p for p in cache.iterdir()]
    assert len(entries) == 1 and (entries[0] / "database.json").is_file()  # no staging folder left
    built = []
    monkeypatch.setattr(C, "build_context", lambda *a, **k: built.append(1) or pytest.fail("rebuilt"))
    again = C.resolve_context(takes, cache_dir=cache)  # opened from the cache, not built
    assert again.path == entries[0] and not built and np.array_equal(again.rotations, db.rotations)
    monkeypatch.undo()
    amc = takes / "cmu" / "12_walk.amc"
    st = amc.stat()
    os.utime(amc, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))  # edited (same size, newer)
    C.resolve_context(takes, cache_dir=cache)
    assert len(list(cache.iterdir())) == 2
    shutil.copy(amc, takes / "cmu" / "12_walk2.amc")  # added
    assert C.resolve_context(takes, cache_dir=cache).num_clips == 4 and len(list(cache.iterdir())) == 3



def test_a_cached_context_with_nan_poses_is_noted_as_a_database_given_is(takes, tmp_path):
    """A context cache entry a build of mocapkit 0.14.0 or earlier left (NaN poses for a take with gaps) is opened
    under its key still; an explicit database was checked on open (MotionDatabase.missing_note), the cache was not:
    its NaN poses went unsaid. Both now go through one check (context.noted_missing), which names the entry."""
    cache = tmp_path / "cache"
    assert not any("missing joints" in n for n in C.resolve_context(takes, cache_dir=cache).info["notes"])
    (entry,) = cache.iterdir()
    rot = np.load(entry / "rotations.npy", mmap_mode="r+")  # what 0.14.0 cached for a take with a gap
    rot[10:13, 5] = np.nan
    rot.flush()
    del rot
    db = C.resolve_context(takes, cache_dir=cache)
    assert db.path == entry and db.missing_frames() == 3  # opened from the cache, not rebuilt
    said = (f"{entry}: 3 frames of {db.num_frames} have missing joints (NaN), kept by mocapkit 0.14.0 or earlier; "
            "a search leaves their clips out and a reconstruction may fail: remove this cache entry to build it "
            "again (a take with gaps is then left out, named)")
    assert [n for n in db.info["notes"] if "missing joints" in n] == [said]
    assert said in C.fit_context(mocapkit.load(takes / "cmu" / "12_walk.amc"), db)[1]  # clean's context note
    shutil.copytree(entry, tmp_path / "db")  # the same database given as a folder: the same check, its own advice
    given = C.resolve_context(tmp_path / "db")
    assert [n for n in given.info["notes"] if "missing joints" in n] == [given.missing_note()]
    assert given.missing_note().startswith(f"{tmp_path / 'db'}: 3 frames of") and "`mocapkit fill`" in given.missing_note()

def test_the_key_covers_files_settings_and_the_asf(takes):
    files = C.context_files(takes)
    k = C.context_key(files)
    assert k == C.context_key(list(files)) and k != C.context_key(files[:-1]) and k != C.context_key(files, fps=30)
    asf = takes / "hdm" / "HDM_bk.asf"
    st = asf.stat()
    os.utime(asf, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    assert C.context_key(files) != k


def test_a_list_of_files_is_built_like_a_folder(takes, tmp_path):
    files = [takes / "hdm" / "HDM_bk_sneak2StepsLStart_004_120.amc", takes / "cmu" / "12_walk.amc"]
    db = C.resolve_context([str(f) for f in files], cache_dir=tmp_path / "cache")
    assert db.clip_names == ("HDM_bk_sneak2StepsLStart_004_120", "12_walk")


def test_two_builders_of_one_key_both_get_a_complete_database(takes, tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    real = C.build_context
    calls = []

    def racing(files, **kw):  # another process finishes the same key while this one builds
        calls.append(1)
        if len(calls) == 1:
            C.cached_context(files, cache_dir=cache)
        return real(files, **kw)

    monkeypatch.setattr(C, "build_context", racing)
    db = C.cached_context(C.context_files(takes), cache_dir=cache)
    assert len(calls) == 2 and db.num_clips == 3
    assert [p.name for p in cache.iterdir()] == [db.path.name]  # the loser's copy is gone


def test_an_interrupted_build_leaves_nothing_that_looks_complete(takes, tmp_path, monkeypatch):
    cache = tmp_path / "cache"

    def killed(self, directory, **kw):
        os.makedirs(directory)
        (directory / "rotations.npy").write_bytes(b"partial")
        raise KeyboardInterrupt

    monkeypatch.setattr(MotionDatabase, "save", killed)
    with pytest.raises(KeyboardInterrupt):
        C.cached_context(C.context_files(takes), cache_dir=cache)
    assert list(cache.iterdir()) == []
    monkeypatch.undo()
    assert C.cached_context(C.context_files(takes), cache_dir=cache).num_clips == 3


def test_takes_on_another_rig_are_left_out_with_one_note(takes, tmp_path):
    _other_rig_take(takes / "chain.bvh")
    db, notes = C.build_context(C.context_files(takes))
    assert db.num_clips == 3 and len(notes) == 1 and "chain.bvh" in notes[0] and "1 of 4" in notes[0]
    cached = C.resolve_context(takes, cache_dir=tmp_path / "cache")
    walk = mocapkit.load(takes / "cmu" / "12_walk.amc")
    assert C.fit_context(walk, cached)[1] == notes[0]  # said again on every run that uses it


def test_a_take_on_the_minority_rig_of_a_folder_gets_the_takes_on_its_own(takes, tmp_path):
    bvh = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    for k in range(4):  # most of the folder is another rig (CMU's BVH spelling)
        mocapkit.save(bvh[100 * k:100 * k + 60], takes / f"bvh{k}.bvh")
    walk = mocapkit.load(takes / "cmu" / "12_walk.amc")
    cache = tmp_path / "cache"
    majority = C.resolve_context(takes, cache_dir=cache)
    assert majority.skeletons[0].joint_names == bvh.skeleton.joint_names and majority.num_clips == 4
    assert C.resolve_context(takes, cache_dir=cache, prefer=C.topology_id(bvh.skeleton)) is not None
    assert len(list(cache.iterdir())) == 1  # the majority's build serves its rig
    mine = C.resolve_context(takes, cache_dir=cache, prefer=C.topology_id(walk.skeleton))
    assert mine.num_clips == 3 and mine.skeletons[0].joint_names == walk.skeleton.joint_names
    ctx, note = C.fit_context(walk, mine)
    assert ctx is mine and "left out 4 of 7 takes on another skeleton than this take's" in note
    assert len(list(cache.iterdir())) == 2  # and the take's, cached too
    fresh = C.resolve_context(takes, cache_dir=tmp_path / "fresh", prefer=C.topology_id(walk.skeleton))
    assert fresh.num_clips == 3 and len(list((tmp_path / "fresh").iterdir())) == 1  # no majority build first
    res = mocapkit.clean(walk, takes, steps="fill,detect")  # the Python API asks for the take's rig, as the CLI does
    assert "3 clips" in res.steps[1].method and "than this take's" in " ".join(res.notes)


def test_files_of_a_folder_that_cannot_be_context_are_left_out_and_named_files_refused(takes, tmp_path):
    mocapkit.save(mocapkit.load(mocapkit.samples.path("Eb015pr.c3d")), takes / "markers.npz")
    walk = mocapkit.load(takes / "cmu" / "12_walk.amc")
    rot = walk.rotations.copy()
    rot[5:9, 3] = np.nan
    mocapkit.save(dataclasses.replace(walk, rotations=rot), takes / "gappy.npz")
    db = C.resolve_context(takes, cache_dir=tmp_path / "cache")
    assert db.num_clips == 3
    note = " ".join(db.info["notes"])
    assert "left out 2 of 5 files that cannot be context" in note and "gappy.npz" in note
    assert C.fit_context(walk, db)[1] == note
    for named in ("markers.npz", "gappy.npz"):
        with pytest.raises(MocapFormatError, match=named):
            C.resolve_context([takes / "cmu" / "12_walk.amc", takes / named], cache_dir=tmp_path / "cache")


def test_cleaning_records_and_hidden_files_are_not_context(takes):
    (takes / "x.clean.npz").write_bytes(b"")
    (takes / ".hidden.bvh").write_bytes(b"")
    assert all(not p.name.endswith(".clean.npz") and not p.name.startswith(".") for p in C.context_files(takes))


def test_bad_context_paths_are_refused_naming_the_file(takes, tmp_path, small_db):
    with pytest.raises(MocapFormatError, match="no such file"):
        C.context_files([tmp_path / "missing"])
    (tmp_path / "notes.txt").write_text("x")
    with pytest.raises(MocapFormatError, match="notes.txt"):
        C.context_files([tmp_path / "notes.txt"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(MocapFormatError, match="no motion files"):
        C.context_files([tmp_path / "empty"])
    small_db.save(tmp_path / "db")
    with pytest.raises(MocapFormatError, match="must be the only context given"):
        C.resolve_context([tmp_path / "db", takes], cache_dir=tmp_path / "cache")
    assert C.resolve_context(tmp_path / "db").num_clips == small_db.num_clips
    lone = tmp_path / "lone"
    lone.mkdir()
    shutil.copy(takes / "cmu" / "12_walk.amc", lone / "12_walk.amc")  # its ASF is not beside it
    with pytest.raises(MocapFormatError, match="12_walk.amc"):
        C.resolve_context(lone, cache_dir=tmp_path / "cache")
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").iterdir())


def test_fit_context_renames_a_database_on_the_same_rig_and_refuses_another():
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    db = C.default_context()
    same, note = C.fit_context(walk, db)  # same joint names
    assert same is db and note == ""
    sk = walk.skeleton
    renamed_take = dataclasses.replace(walk, skeleton=dataclasses.replace(sk, joint_names=tuple(n.upper() for n in sk.joint_names)))
    served, note = C.fit_context(renamed_take, db)
    assert served.skeletons[0].joint_names == renamed_take.skeleton.joint_names and "matched by hierarchy" in note
    assert np.shares_memory(served.rotations, db.rotations)
    bvh = mocapkit.load(mocapkit.samples.path("131_01.bvh"))  # the 3dsMax conversion: arms at another rest pose
    none, note = C.fit_context(bvh, db)
    assert none is None and "not used" in note and "rest pose" in note
    explicit = _chosen_copy(db)
    with pytest.raises(MocapError, match="joints differ"):
        C.fit_context(bvh, explicit)
    motions = [walk]
    assert C.fit_context(bvh, motions) == (motions, "")  # lists go to the analysis as they are


def test_fit_context_serves_the_context_names_under_a_namespace_without_a_note():
    """A take whose joints are the context's names under a namespace (`rig|lfemur`, `Character1:lfemur`: the
    prefix is set aside for the rig family, mocapkit.rigs.family_names) gets the context by name, with no note, as
    the bare names do: the same summary, whatever the prefix."""
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    db = C.default_context()
    sk = walk.skeleton
    for prefix in ("rig|", "Character1:"):
        take = dataclasses.replace(walk, skeleton=dataclasses.replace(sk, joint_names=tuple(prefix + n for n in sk.joint_names)))
        served, note = C.fit_context(take, db)
        assert served.skeletons[0].joint_names == take.skeleton.joint_names and note == ""
        assert np.shares_memory(served.rotations, db.rotations)


def _chosen_copy(db) -> MotionDatabase:
    """``db``'s arrays as a database the user chose (not the bundled default, which is dropped, not refused)."""
    return MotionDatabase(fps=db.fps, skeletons=db.skeletons, clips=db.clips, rotations=db.rotations,
                          root_positions=db.root_positions, features=db.features, info={"label": "mine"})


def test_fit_context_refuses_a_context_in_another_basis_under_the_same_names():
    """A Z-up export of an Acclaim take keeps its joint names, but its local rotations are in another basis: the
    Y-up default context's rotations, copied in by repair, doubled its errors (a user trial: 12.7 -> 23.6 deg)."""
    from mocapkit import rotations as R

    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    c = R.quaternion_from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi / 2)  # Y up -> Z up, every frame and bone
    rot = R.quaternion_multiply(R.quaternion_multiply(c[None, None], walk.rotations), R.quaternion_conjugate(c)[None, None])
    sk = walk.skeleton
    zsk = dataclasses.replace(sk, offsets=R.quaternion_rotate(c[None], sk.offsets),
                              end_site_offsets=R.quaternion_rotate(c[None], sk.end_site_offsets))
    zup = dataclasses.replace(walk, skeleton=zsk, rotations=rot, root_positions=R.quaternion_rotate(c[None], walk.root_positions))
    assert zup.skeleton.joint_names == walk.skeleton.joint_names
    db = C.default_context()
    none, note = C.fit_context(zup, db)
    assert none is None and "not used" in note and "rest pose" in note
    explicit = _chosen_copy(db)
    with pytest.raises(MocapError, match="rest pose"):
        C.fit_context(zup, explicit)



def test_a_context_on_the_same_names_serves_a_rig_whose_toes_point_elsewhere(shared_data):
    """Actors of one naming differ in a bone or two (CMU's backflip.asf and HDM05's mm: the toes 33 deg apart): the
    same names on the same up axis serve as they are (a stricter rest check refused them); only a basis change
    (another up axis) is refused."""
    backflip = mocapkit.load(shared_data / "cmu_asfamc" / "backflip.amc", asf=shared_data / "cmu_asfamc" / "backflip.asf")
    hdm = shared_data / "hdm05_asfamc"
    mm = mocapkit.load(hdm / "HDM_mm_grabHighR_017_120.amc", asf=hdm / "HDM_mm.asf")
    db = MotionDatabase.build([mm], fps=24, executor="serial", progress=False)
    assert C._same_rest(backflip.skeleton, db.skeletons[0])  # the toes
    served, note = C.fit_context(backflip, db)
    assert served is db


def test_mocapkit_clean_uses_the_default_and_says_so():
    take = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    res = mocapkit.clean(take, steps="detect")
    assert "the bundled default context" in res.steps[0].method and res.params["context"].startswith("the bundled")
    alone = mocapkit.clean(take, context=False, steps="detect")
    assert "the clip itself" in alone.steps[0].method and alone.params["context"] == "none"
    other = mocapkit.clean(mocapkit.load(mocapkit.samples.path("131_01.bvh"))[1:200], steps="detect")
    assert "the clip itself" in other.steps[0].method and any("not used" in n for n in other.notes)


def test_the_build_script_selects_what_is_shipped(shared_data):
    import importlib.util

    spec = importlib.util.spec_from_file_location("build_default_context", C.default_context_path().parents[3] / "scripts" / "build_default_context.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    chosen = mod.select(shared_data, 3)
    desc = json.loads((C.default_context_path() / "database.json").read_text())
    assert [p.name for p in chosen] == desc["info"]["sources"]
    assert [c["name"] for c in desc["clips"]] == [p.stem for p in chosen]
    assert not set(p.name for p in chosen) & set(mod.BENCHMARK_QUERIES)


def test_two_processes_building_one_key_at_once(takes, tmp_path):
    """Real concurrent builds of the same folder: both succeed, one complete entry stays, nothing half-written."""
    import subprocess
    import sys

    cache = tmp_path / "cache"
    code = ("import sys; from mocapkit import context as C; "
            "db = C.resolve_context(sys.argv[1], cache_dir=sys.argv[2]); print(db.path.name, db.num_clips)")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    procs = [subprocess.Popen([sys.executable, "-c", code, str(takes), str(cache)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=env) for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [e for _, e in outs]
    names = {o.split()[0] for o, _ in outs}
    assert len(names) == 1 and all(o.split()[1] == "3" for o, _ in outs)
    assert [p.name for p in cache.iterdir()] == list(names)
    assert MotionDatabase.open(cache / names.pop()).num_clips == 3


def test_a_take_of_the_folders_own_rig_builds_it_once(takes, tmp_path, monkeypatch):
    """A take on the majority's skeleton asks with its preference first (clean, detect), a batch without one: one
    build, cached once, serves both."""
    builds = []
    real = C.build_context
    monkeypatch.setattr(C, "build_context", lambda *a, **k: builds.append(k.get("prefer")) or real(*a, **k))
    walk = mocapkit.load(takes / "cmu" / "12_walk.amc")
    cache = tmp_path / "cache"
    first = C.resolve_context(takes, cache_dir=cache, prefer=C.topology_id(walk.skeleton))
    second = C.resolve_context(takes, cache_dir=cache)
    again = C.resolve_context(takes, cache_dir=cache, prefer=C.topology_id(walk.skeleton))
    assert len(builds) == 1 and len(list(cache.iterdir())) == 1
    assert first.num_clips == second.num_clips == again.num_clips == 3


def test_no_home_folder_does_not_stop_a_folder_context(monkeypatch, tmp_path):
    """A container run under an unknown user has no home folder for the cache: the context is built and used from
    memory, and its notes say it was not cached."""
    import shutil

    import mocapkit.context
    from mocapkit import samples
    from mocapkit.context import cached_context

    def no_home():
        raise RuntimeError("Could not determine home directory.")

    monkeypatch.setattr(mocapkit.context, "cache_root", no_home)
    shutil.copy(samples.path("12_walk.amc"), tmp_path / "12_walk.amc")
    shutil.copy(samples.path("12.asf"), tmp_path / "12.asf")
    db = cached_context([tmp_path / "12_walk.amc"])
    assert db.num_clips == 1 and any("not cached" in n for n in db.info["notes"])


def test_context_motions_clean_a_take_bit_for_bit_as_their_files_do(tmp_path, monkeypatch):
    """``mocapkit.clean(take, context=[Motion])`` and ``context=[path]`` for that Motion's file: the same cleaned take,
    flags and MDM bit for bit (both are built into one context database: resampled by slerp, stored as float32)."""
    from mocapkit import corrupt, samples

    monkeypatch.setenv("MOCAPKIT_CACHE_DIR", str(tmp_path / "cache"))
    take = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    bad, _, _ = corrupt.real_errors(take, n_errors=3, seed=5)
    path = samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")
    by_file = mocapkit.clean(bad, [path])
    by_motion = mocapkit.clean(bad, [mocapkit.load(path)])
    assert by_file.repaired.any()
    np.testing.assert_array_equal(by_motion.motion.rotations, by_file.motion.rotations)
    np.testing.assert_array_equal(by_motion.motion.root_positions, by_file.motion.root_positions)
    np.testing.assert_array_equal(by_motion.mdm, by_file.mdm)
    np.testing.assert_array_equal(by_motion.repaired, by_file.repaired)
    assert "context Motions (1 clip" in by_motion.steps[1].method


def _unknown_names(path, out):
    """The Bandai Namco take at ``path`` written to ``out`` on joints named ``kt_00``, ``kt_01``, ... (names that say
    no role, as a studio's own rig), and the joint map back to the Bandai names."""
    m = mocapkit.load(path)
    names = tuple(f"kt_{j:02d}" for j in range(len(m.skeleton.joint_names)))
    mocapkit.save(dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, joint_names=names)), out)
    return dict(zip(names, m.skeleton.joint_names))


def test_a_folder_of_a_rig_of_unknown_names_is_context_under_its_joint_map(tmp_path):
    data = Path(__file__).parent / "data"
    folder = tmp_path / "kt"
    folder.mkdir()
    for n in ("dataset-1_dash_normal_001", "dataset-1_dash_chimpira_001"):
        jm = _unknown_names(data / f"{n}.bvh", folder / f"{n}.bvh")
    _unknown_names(data / "dataset-1_run_masculinity_001.bvh", tmp_path / "take.bvh")
    take = mocapkit.load(tmp_path / "take.bvh")
    cache = tmp_path / "cache"
    with pytest.raises(MocapFormatError, match=r"dataset-1_dash_chimpira_001\.bvh: .*left_hand.*--joint-map"):
        C.resolve_context(folder, cache_dir=cache)  # the file, not <motion ...>
    db = C.resolve_context(folder, cache_dir=cache, joint_map=jm, prefer=C.topology_id(take.skeleton))
    assert db.skeletons[0].joint_names[9] == "Hand_L" and db.num_clips == 2
    served, note = C.fit_context(take, db)
    assert served.skeletons[0].joint_names == take.skeleton.joint_names and "joint map" in note
    files = C.context_files(folder)
    assert C.context_key(files, joint_map=jm) != C.context_key(files)
    assert len([p for p in cache.iterdir() if not p.name.startswith(".")]) == 1  # built once
