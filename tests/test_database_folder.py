"""The database folder: writing it loses nothing, opening it trusts nothing.

Every case saves a real database built from the bundled clips, then either
puts something worth keeping where the database would go, or corrupts one
thing in a copy of the folder and opens it: the answer must be one
:class:`MocapFormatError` line naming the file, never a traceback or a crash.
"""

import dataclasses
import json
import math
import os
import shutil

import numpy as np
import pytest

from mocapkit import database_folder, samples
from mocapkit.database import MotionDatabase, check_database_output
from mocapkit.database_folder import FORMAT, read_folder
from mocapkit.errors import MocapFormatError


@pytest.fixture(scope="module")
def saved(small_db, tmp_path_factory):
    """A saved copy of ``small_db`` (never modified: tests corrupt copies of it)."""
    return small_db.save(tmp_path_factory.mktemp("saved") / "db")


@pytest.fixture
def copy(saved, tmp_path):
    return shutil.copytree(saved, tmp_path / "db")


def _tree(folder):
    """Every file below ``folder`` with its bytes (to show nothing changed)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _refused(directory, match, **kwargs):
    with pytest.raises(MocapFormatError, match=match) as info:
        MotionDatabase.open(directory, **kwargs)
    assert "\n" not in str(info.value)
    return info.value


# -- writing: the output guard -----------------------------------------------------------------


@pytest.fixture
def takes(tmp_path):
    """The issue's folder p: p/takes holds a take (ASF + AMC), p/notes.txt a note."""
    p = tmp_path / "p"
    (p / "takes").mkdir(parents=True)
    for name in ("12.asf", "12_walk.amc"):
        shutil.copy(samples.path(name), p / "takes" / name)
    (p / "notes.txt").write_text("x")
    return p


def test_overwrite_refuses_a_folder_holding_an_input(small_db, takes):
    before = _tree(takes)
    amc = takes / "takes" / "12_walk.amc"
    with pytest.raises(MocapFormatError, match="holds an input"):
        check_database_output(takes, [amc], overwrite=True)
    with pytest.raises(MocapFormatError, match="holds an input"):
        small_db.save(takes, overwrite=True, inputs=[amc])
    # without being told the inputs, save still refuses: the folder is no database
    with pytest.raises(MocapFormatError, match="not a mocapkit database"):
        small_db.save(takes, overwrite=True)
    assert _tree(takes) == before
    assert sorted(p.name for p in takes.parent.iterdir()) == ["p"]  # no temporary folder left


def test_output_may_not_be_or_lie_in_an_input(takes):
    folder = takes / "takes"
    for out, inp in ((folder, folder), (folder / "db", folder), (folder / "12_walk.amc", folder / "12_walk.amc")):
        with pytest.raises(MocapFormatError, match="over or inside an input"):
            check_database_output(out, [inp], overwrite=True)
    # the same, reached through a symlink or through ".."
    link = takes.parent / "link"
    link.symlink_to(folder)
    with pytest.raises(MocapFormatError, match="over or inside an input"):
        check_database_output(link / "db", [folder])
    with pytest.raises(MocapFormatError, match="holds an input"):
        check_database_output(folder / ".." / "..", [link / "12_walk.amc"], overwrite=True)
    # a symlink inside the output that points elsewhere is still an input the output holds
    out = takes.parent / "out"
    out.mkdir()
    (out / "walk.amc").symlink_to(folder / "12_walk.amc")
    with pytest.raises(MocapFormatError, match="holds an input"):
        check_database_output(out, [out / "walk.amc"], overwrite=True)
    check_database_output(takes.parent / "new", [folder, folder / "12_walk.amc"])  # elsewhere: fine


def test_overwrite_replaces_only_a_database(small_db, saved, tmp_path):
    # the case: an existing folder of other things
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("x")
    with pytest.raises(MocapFormatError, match="no database.json"):
        small_db.save(other, overwrite=True)
    # a database.json that is not ours
    (other / "database.json").write_text(json.dumps({"format": "something-else"}))
    with pytest.raises(MocapFormatError, match="does not say so"):
        small_db.save(other, overwrite=True)
    (other / "database.json").write_text("[" * 100000)
    with pytest.raises(MocapFormatError, match="does not say so"):
        small_db.save(other, overwrite=True)
    assert (other / "notes.txt").read_text() == "x"
    # a database with something added to it: the addition would be lost
    for extra in ("notes.txt", "features/notes.txt", "takes/walk.amc"):
        db = shutil.copytree(saved, tmp_path / f"db_{extra.replace('/', '_')}")
        (db / extra).parent.mkdir(exist_ok=True)
        (db / extra).write_text("x")
        before = _tree(db)
        with pytest.raises(MocapFormatError, match=f"holds {extra.split('/')[0]}"):
            small_db.save(db, overwrite=True)
        assert _tree(db) == before
    # a database holding a link (deleting the folder would delete the link)
    db = shutil.copytree(saved, tmp_path / "db_link")
    (db / "features" / "F15.npy").unlink()
    (db / "features" / "F15.npy").symlink_to(saved / "features" / "F15.npy")
    with pytest.raises(MocapFormatError, match="holds features/F15.npy"):
        small_db.save(db, overwrite=True)
    # a file where the folder would go, and a folder below a file
    (tmp_path / "file").write_text("x")
    with pytest.raises(MocapFormatError, match="is a file"):
        small_db.save(tmp_path / "file", overwrite=True)
    with pytest.raises(MocapFormatError, match="is a file, not a folder"):
        small_db.save(tmp_path / "file" / "db")
    assert (tmp_path / "file").read_text() == "x"


def test_existing_database_replaced_only_with_overwrite(small_db, saved, tmp_path):
    db = shutil.copytree(saved, tmp_path / "db")
    (db / "clip_ids.npy").write_bytes(b"")  # damaged: still only database files, so replaceable
    with pytest.raises(MocapFormatError, match=r"already exists; pass overwrite=True to replace it"):
        small_db.save(db)  # a Python call is told the keyword, not the command line's flag
    assert (db / "clip_ids.npy").read_bytes() == b""
    assert small_db.save(db, overwrite=True) == db
    assert MotionDatabase.open(db).num_frames == small_db.num_frames
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(MocapFormatError, match="already exists"):
        small_db.save(empty)
    small_db.save(empty, overwrite=True)  # an empty folder holds nothing to lose
    assert MotionDatabase.open(empty).clips == small_db.clips
    # a symlink to a database: the database it points to is replaced, the link stays
    link = tmp_path / "link"
    link.symlink_to(db)
    small_db.save(link, overwrite=True)
    assert link.is_symlink() and MotionDatabase.open(link).clips == small_db.clips
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db", "empty", "link"]


def test_replace_keeps_the_old_database_when_writing_fails(small_db, saved, tmp_path, monkeypatch):
    db = shutil.copytree(saved, tmp_path / "db")
    before = _tree(db)
    real_save, calls = np.save, []

    def failing_save(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        return real_save(*args, **kwargs)

    monkeypatch.setattr(np, "save", failing_save)
    with pytest.raises(MocapFormatError, match=r"db: cannot write the database \(no space left on the device\)"):
        small_db.save(db, overwrite=True)
    monkeypatch.undo()
    assert _tree(db) == before and sorted(p.name for p in tmp_path.iterdir()) == ["db"]
    # the rename of the new folder into place fails: the old one is put back
    real_replace = os.replace

    def failing_replace(src, dst):
        if str(src).endswith(".part"):
            raise OSError(13, "Permission denied")
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(MocapFormatError, match="Permission denied"):
        small_db.save(db, overwrite=True)
    monkeypatch.undo()
    assert _tree(db) == before and sorted(p.name for p in tmp_path.iterdir()) == ["db"]


def test_feature_names_that_are_paths_are_never_written(small_db, tmp_path):
    bad = MotionDatabase(
        fps=small_db.fps,
        skeletons=small_db.skeletons,
        clips=small_db.clips,
        rotations=small_db.rotations,
        root_positions=small_db.root_positions,
        features={"../../secret": small_db.features["F15"]},
    )
    with pytest.raises(ValueError, match="not a file of the database layout"):
        bad.save(tmp_path / "db")
    assert list(tmp_path.iterdir()) == []


def test_save_refuses_the_folder_it_was_opened_from(saved, tmp_path):
    db = MotionDatabase.open(shutil.copytree(saved, tmp_path / "db"))
    with pytest.raises(MocapFormatError, match="opened from"):
        db.save(tmp_path / "." / "db", overwrite=True)


# -- opening: database.json ------------------------------------------------------------------------


def _edit(folder, change):
    desc = json.loads((folder / "database.json").read_text())
    change(desc)
    (folder / "database.json").write_text(json.dumps(desc))


def _set(*keys_and_value):
    *keys, value = keys_and_value

    def change(desc):
        d = desc
        for k in keys[:-1]:
            d = d[k]
        d[keys[-1]] = value

    return change


@pytest.mark.parametrize(
    "change, match",
    [
        (_set("fps", 0), "fps 0 is not a frame rate"),
        (_set("fps", -30), "fps -30 is not a frame rate"),
        (_set("fps", math.nan), "fps nan is not a frame rate"),
        (_set("fps", math.inf), "fps inf is not a frame rate"),
        (_set("fps", 1e9), "fps 1000000000.0 is not a frame rate"),
        (_set("fps", "30"), "fps '30' is not a frame rate"),
        (_set("fps", True), "fps True is not a frame rate"),
        (_set("num_frames", "172"), "num_frames '172' is not a positive integer"),
        (_set("num_frames", 10**12), "the clips cover|expected start"),
        (_set("format_version", 2), "format version 2; this mocapkit reads version 1"),
        (_set("format_version", "1"), "format version '1'"),
        (_set("format", "other"), "not a mocapkit motion database"),
        (_set("feature_unit", "m"), "feature_unit 'm'"),
        (_set("info", []), "info: expected a JSON object"),
        (_set("extra", 1), "unknown field.*'extra'"),
        (lambda d: d.pop("clips"), "missing clips"),
        (_set("features", {"../../secret": 15}), r"feature name '\.\./\.\./secret' is not a plain identifier"),
        (_set("features", {"/etc/passwd": 15}), "not a plain identifier"),
        (_set("features", {"F99": 15}), "unknown feature set 'F99'"),
        (_set("features", {"F15": 16}), "'F15' has 15 columns, not 16"),
        (_set("features", {}), "features: expected a non-empty"),
        (_set("features", [["F15", 15]]), "features: expected"),
        (_set("skeletons", []), "skeletons: expected a non-empty list"),
        (_set("skeletons", 0, "parents", 3, 99), "skeleton 0: parents must be in topological order"),
        (_set("skeletons", 0, "parents", 0, 0), "skeleton 0: the root must be joint 0"),
        (_set("skeletons", 0, "end_site_parents", 0, 500), "skeleton 0: end_site_parents must index joints"),
        (_set("skeletons", 0, "parents", 2, 1.5), "skeleton 0: wrong type or value of parents"),
        (_set("skeletons", 0, "joint_names", 1, 7), "skeleton 0: wrong type or value of joint_names"),
        (_set("skeletons", 0, "offsets", 1, ["a", 0, 0]), "wrong type or value of offsets"),
        (_set("skeletons", 0, "offsets", 1, [math.nan, 0, 0]), "wrong type or value of offsets"),
        (_set("skeletons", 0, "offsets", 1, [0, 0]), "wrong type or value of offsets"),
        (_set("skeletons", 0, "offsets", [[0, 0, 0]]), r"skeleton 0: offsets: expected shape \(31, 3\)"),
        (_set("skeletons", 0, "channels", 5), "wrong type or value of channels"),
        (_set("skeletons", 0, "unit_cm", -1), "wrong type or value of unit_cm"),
        (_set("skeletons", 0, "limits", 1, [["a", 1]]), "wrong type or value of limits"),
        (lambda d: d["skeletons"].append({**d["skeletons"][0], "joint_names": d["skeletons"][0]["joint_names"][::-1]}), r"skeleton \d+: other joints or parents than skeleton 0"),
        (_set("clips", {}), "clips: expected a non-empty list"),
        (_set("clips", 0, "skeleton", 99), r"clip 0 \('12_walk'\): skeleton 99 out of range"),
        (_set("clips", 0, "skeleton", -1), "skeleton -1 out of range"),
        (_set("clips", 1, "start", 10**6), "clip 1 .*start 1000000"),
        (_set("clips", 1, "frames", -5), "clip 1 .*-5 frames"),
        (_set("clips", 7, "frames", 10**6), "clip 7 .*1000000 frames"),
        (_set("clips", 1, "name", "12_walk"), "repeats an earlier clip's"),
        (_set("clips", 1, "name", 5), "clip 1: wrong type"),
        (_set("clips", 1, "mirrored", "yes"), "clip 1: wrong type"),
        (_set("clips", 1, "start", 5.0), "clip 1: wrong type"),
        (lambda d: d["clips"].pop(), "the clips cover .* frames, num_frames says"),
        (lambda d: d["clips"][0].pop("source"), "clip 0: missing source"),
        (_set("clips", 0, []), "clip 0: expected a JSON object"),
    ],
)
def test_open_refuses_a_bad_description(copy, change, match):
    _edit(copy, change)
    err = _refused(copy, match)
    assert err.path == str(copy / "database.json")


def test_open_refuses_unparsable_descriptions(copy):
    desc = copy / "database.json"
    # nested 100,000 deep: refused by its depth before the parser recurses
    desc.write_text('{"info": ' + "[" * 100000 + "]" * 100000 + "}")
    _refused(copy, "nests 100001 deep")
    for text, match in (("[1, 2]", "JSON list, not an object"), ("{", "unreadable database description"), ("", "unreadable")):
        desc.write_text(text)
        _refused(copy, match)
    desc.write_bytes(b'{"format": "\xff"}')
    _refused(copy, "unreadable")
    desc.write_text('{"fps": NaN}')
    _refused(copy, "missing")
    with open(desc, "wb") as fh:  # sparse: takes no disk space
        fh.truncate(17 * 2**20)
    _refused(copy, "over the .*-byte limit")
    desc.unlink()
    _refused(copy, "not a motion database")


def test_brackets_in_strings_do_not_count_as_depth(copy, small_db):
    _edit(copy, _set("info", {"note": "[[[[{{{{" * 100}))
    assert MotionDatabase.open(copy).info["note"].startswith("[[[[")


# -- opening: the arrays ----------------------------------------------------------------------------


def test_open_refuses_empty_truncated_and_padded_arrays(copy):
    rot = copy / "rotations.npy"
    data = rot.read_bytes()
    rot.write_bytes(b"")
    _refused(copy, r"rotations\.npy: unreadable array header")
    rot.write_bytes(data[:200])
    _refused(copy, r"rotations\.npy: holds .* bytes of data where its header declares .*truncated")
    rot.write_bytes(data[:-4])
    _refused(copy, "truncated")
    rot.write_bytes(data + b"\0" * 16)
    _refused(copy, "truncated or damaged")
    rot.write_bytes(b"not a numpy file at all")
    _refused(copy, "unreadable array")
    rot.write_bytes(data[:6] + b"\x03\x00" + data[8:])
    _refused(copy, "format version 3.0")


@pytest.mark.parametrize("mmap", [True, False])
def test_open_refuses_arrays_that_disagree(copy, saved, small_db, mmap):
    N, J = small_db.num_frames, small_db.num_joints
    cases = [
        ("features/F15.npy", np.zeros((3, 15)), r"F15\.npy: expected shape \(%d, 15\)" % N),
        ("features/F15x3.npy", np.zeros((N, 15)), r"F15x3\.npy: expected shape"),
        ("rotations.npy", np.zeros((N, J + 1, 4), np.float32), r"rotations\.npy: expected shape"),
        ("root_positions.npy", np.zeros((N - 1, 3), np.float32), r"root_positions\.npy: expected shape"),
        ("root_positions.npy", np.zeros((N, 3)), "expected a C-ordered float32 array, got a C-ordered float64"),
        ("root_positions.npy", np.asfortranarray(np.zeros((N, 3), np.float32)), "Fortran-ordered"),
        ("clip_ids.npy", np.zeros(N, np.int64), "expected a C-ordered int32"),
        ("translations.npy", np.zeros((N, J, 4), np.float32), r"translations\.npy: expected shape"),
    ]
    for rel, array, match in cases:
        np.save(copy / rel, array)
        _refused(copy, match, mmap=mmap)
        if (saved / rel).exists():
            shutil.copy(saved / rel, copy / rel)
        else:
            (copy / rel).unlink()
        MotionDatabase.open(copy, mmap=mmap)  # restored
    np.save(copy / "features" / "F15.npy", np.array([object()] * N * 15).reshape(N, 15), allow_pickle=True)
    _refused(copy, "expected a C-ordered float64 array, got a C-ordered object", mmap=mmap)


def test_open_refuses_clip_ids_out_of_range(copy, small_db, monkeypatch):
    ids = np.load(copy / "clip_ids.npy")
    for bad in (99, -1, 1):  # out of range, negative, in range but the wrong clip
        wrong = ids.copy()
        wrong[3] = bad
        np.save(copy / "clip_ids.npy", wrong)
        _refused(copy, r"clip_ids\.npy: clip numbers disagree with the clip ranges in database.json \(clip 0\)")
    # compared a few frames at a time: every chunk is checked, a good folder still opens
    monkeypatch.setattr(database_folder, "_CHUNK", 7)
    np.save(copy / "clip_ids.npy", ids)
    assert MotionDatabase.open(copy).clips == small_db.clips
    last = small_db.clips[-1]
    wrong = ids.copy()
    wrong[last.stop - 1] = 0
    np.save(copy / "clip_ids.npy", wrong)
    _refused(copy, r"\(clip %d\)" % (small_db.num_clips - 1))


def test_open_refuses_arrays_outside_the_folder(copy, tmp_path):
    secret = tmp_path / "secret.npy"
    shutil.copy(copy / "features" / "F15.npy", secret)
    (copy / "features" / "F15.npy").unlink()
    (copy / "features" / "F15.npy").symlink_to(secret)
    _refused(copy, r"F15\.npy: missing, not a regular file, or a link out of the database folder")
    (copy / "features" / "F15.npy").unlink()
    _refused(copy, "missing")
    (copy / "features" / "F15.npy").mkdir()
    _refused(copy, "not a regular file")


def test_a_checked_folder_reads_back_what_was_saved(saved, small_db):
    desc, arrays = read_folder(saved)
    assert desc.num_frames == small_db.num_frames and desc.fps == 30.0
    assert desc.features == {"F15": 15, "F15x3": 45}
    assert [c[0] for c in desc.clips] == list(small_db.clip_names)
    assert sorted(arrays) == ["clip_ids.npy", "features/F15.npy", "features/F15x3.npy", "root_positions.npy", "rotations.npy"]
    assert json.loads((saved / "database.json").read_text())["format"] == FORMAT


def test_mutated_folders_open_or_fail_in_one_line(saved, tmp_path):
    """Seeded byte-level damage to database.json and the array headers: a database or one error line."""
    rng = np.random.default_rng(20)
    files = ["database.json", "clip_ids.npy", "rotations.npy", "features/F15.npy"]
    originals = {f: (saved / f).read_bytes() for f in files}
    db = shutil.copytree(saved, tmp_path / "db")
    outcomes = {"opened": 0, "refused": 0}
    for trial in range(300):
        name = files[trial % len(files)]
        data = bytearray(originals[name])
        span = len(data) if name == "database.json" else 128  # the .npy header
        for _ in range(int(rng.integers(1, 4))):
            i = int(rng.integers(0, span))
            kind = rng.integers(0, 3)
            if kind == 0:
                data[i] = int(rng.integers(0, 256))
            elif kind == 1:
                del data[i : i + int(rng.integers(1, 8))]
            else:
                data[i:i] = bytes(rng.choice(list(b'[]{}",:0123456789-e.n'), size=int(rng.integers(1, 8))))
        (db / name).write_bytes(bytes(data))
        try:
            MotionDatabase.open(db)
            outcomes["opened"] += 1
        except MocapFormatError as exc:
            assert "\n" not in str(exc)
            outcomes["refused"] += 1
        (db / name).write_bytes(originals[name])
    assert outcomes["refused"] > 200, outcomes


# -- the swap, interrupts and killed writes --------------------------------------------------------


def _dead_pid():
    """The pid of a process that has exited (a child started and waited for)."""
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


@pytest.mark.usefixtures("python_sigint")
def test_an_interrupt_right_after_the_old_database_is_moved_aside_leaves_a_database(small_db, saved, tmp_path, monkeypatch):
    """Finding 8: SIGINT (SIGTERM alike) lands as the first rename returns; the swap finishes, then it is raised."""
    import signal

    db = shutil.copytree(saved, tmp_path / "db")
    real_replace = os.replace

    def replace(src, dst):
        real_replace(src, dst)
        if os.path.dirname(os.fspath(dst)).endswith(".old"):
            os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        small_db.save(db, overwrite=True)
    monkeypatch.undo()
    assert MotionDatabase.open(db).clip_names == small_db.clip_names  # the new one, whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db"]  # nothing hidden left


def test_a_database_hidden_by_a_killed_write_is_put_back_not_lost(small_db, saved, tmp_path):
    """kill -9 between the two renames (a real child process): target missing, the old database in .db.*.old."""
    import subprocess
    import sys

    db = shutil.copytree(saved, tmp_path / "db")
    before = _tree(db)
    script = (
        "import os, sys\n"
        "from pathlib import Path\n"
        "from mocapkit.database import MotionDatabase\n"
        "real = os.replace\n"
        "def replace(src, dst):\n"
        "    real(src, dst)\n"
        "    if Path(dst).parent.name.endswith('.old'):\n"
        "        os._exit(137)\n"
        "os.replace = replace\n"
        "MotionDatabase.open(sys.argv[1], mmap=False).save(sys.argv[2], overwrite=True)\n"
    )
    rc = subprocess.run([sys.executable, "-c", script, str(saved), str(db)], timeout=120).returncode
    assert rc == 137 and not db.exists()
    with pytest.raises(MocapFormatError, match=r"no such folder; an interrupted write left the previous database at .*\.old"):
        MotionDatabase.open(db)  # said when opening, nothing moved
    with pytest.raises(MocapFormatError, match=r"already exists \(put back from .*\.old.*; pass overwrite=True"):
        small_db.save(db)  # a write without --overwrite: put back, then refused as any existing database
    assert _tree(db) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db"]  # the unfinished .part swept with it
    small_db.save(db, overwrite=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db"]


def test_leftovers_of_dead_writers_are_swept_those_of_live_ones_kept(small_db, tmp_path):
    live = database_folder.staging_folder(tmp_path / "db")  # this very process: a writer at work
    (live / "rotations.npy").write_bytes(b"x")
    host = live.name.split(".")[2].split("-")[1]  # .db.PID-HOST-XXXXXXXX.part
    dead = tmp_path / f".db.{_dead_pid()}-{host}-abcd1234.part"
    other_host = tmp_path / f".db.{_dead_pid()}-{'0' * 6 if host != '000000' else '111111'}-abcd1234.part"
    not_ours = tmp_path / ".db.abcd1234.part"  # no owner in the name: never ours to judge
    for p in (dead, other_host, not_ours):
        p.mkdir()
        (p / "rotations.npy").write_bytes(b"x")
    small_db.save(tmp_path / "db")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["db", live.name, other_host.name, not_ours.name])


def test_saved_folders_get_the_umask_permissions_not_mkdtemps(small_db, tmp_path):
    old = os.umask(0o022)
    try:
        small_db.save(tmp_path / "db")
    finally:
        os.umask(old)
    assert oct((tmp_path / "db").stat().st_mode & 0o777) == oct(0o755)


def test_the_content_digest_is_stored_once_and_changes_with_any_sample(small_db, saved, tmp_path):
    stored = json.loads((saved / "database.json").read_text())["info"]["content_digest"]
    assert stored.startswith("blake2b-256:") and stored == small_db.digest
    opened = MotionDatabase.open(saved)
    assert opened.digest == stored  # read, not computed: no array is hashed on opening
    rot = np.array(small_db.rotations)
    rot[5, 3, 0] += 1e-3
    edited = MotionDatabase(fps=small_db.fps, skeletons=small_db.skeletons, clips=small_db.clips, rotations=rot,
                            root_positions=small_db.root_positions, features=small_db.features, info=small_db.info)
    assert edited.digest != stored
    assert json.loads((edited.save(tmp_path / "e") / "database.json").read_text())["info"]["content_digest"] == edited.digest
    noted = MotionDatabase(fps=small_db.fps, skeletons=small_db.skeletons, clips=small_db.clips, rotations=rot,
                           root_positions=small_db.root_positions, features=small_db.features,
                           info={**small_db.info, "label": "a note"})  # notes are no content (context.py sets them)
    assert noted.digest == edited.digest
    moved = MotionDatabase(fps=small_db.fps, skeletons=small_db.skeletons,
                           clips=[dataclasses.replace(c, source="../elsewhere/" + c.name) for c in small_db.clips],
                           rotations=rot, root_positions=small_db.root_positions, features=small_db.features)
    assert moved.digest == edited.digest  # where the clips were read from, as typed, is not content
    # a folder saved before the digest was kept opens, and its digest is computed from its arrays
    old = shutil.copytree(saved, tmp_path / "old")
    desc = json.loads((old / "database.json").read_text())
    del desc["info"]["content_digest"]
    (old / "database.json").write_text(json.dumps(desc))
    assert MotionDatabase.open(old).digest == stored
    desc["info"]["content_digest"] = "md5:0"
    (old / "database.json").write_text(json.dumps(desc))
    _refused(old, "digest: expected")


def test_a_database_replaced_while_it_is_opened_comes_back_whole(tmp_path, monkeypatch):
    """db build --overwrite swapping in a new build while another process opens the folder: the description of one
    build and the arrays of the other were possible; the open notices the folder changed and reads it again."""
    import mocapkit
    from mocapkit import corrupt

    walk = mocapkit.load(samples.path("12_walk.amc"))
    other = corrupt.angular_noise(walk, 0.5, seed=1)[0]  # the same shapes, other samples
    first, second = tmp_path / "db", tmp_path / "next"
    MotionDatabase.build([walk], fps=30, progress=False).save(first)
    MotionDatabase.build([other], fps=30, progress=False).save(second)
    expected = np.array(read_folder(second, mmap=False)[1]["rotations.npy"])
    real = database_folder._load_array
    swapped = []

    def swap_midway(directory, rel, shape, mmap):
        if not swapped and rel != "rotations.npy":  # the rotations read, then the new build is swapped in
            os.rename(first, tmp_path / "old")
            os.rename(second, first)
            swapped.append(rel)
        return real(directory, rel, shape, mmap)

    monkeypatch.setattr(database_folder, "_load_array", swap_midway)
    desc, arrays = read_folder(first, mmap=False)
    assert swapped and np.array_equal(arrays["rotations.npy"], expected)  # all of the new build


def test_a_database_a_killed_earlier_version_left_hidden_is_put_back(saved, tmp_path):
    """mocapkit 0.1.0 moved the old database to ``.NAME.XXXXXXXX.old/db`` before renaming the new one in; a kill
    between the two left only that hidden copy, which this version now finds and puts back (a minute on)."""
    hidden = tmp_path / ".db.k3j9x0ab.old"
    hidden.mkdir()
    shutil.copytree(saved, hidden / "db")
    old = 1_000_000_000
    os.utime(hidden, (old, old))
    target = tmp_path / "db"
    with pytest.raises(MocapFormatError, match=r"no such folder; an interrupted write left the previous database at .*\.db\.k3j9x0ab\.old"):
        read_folder(target)
    with pytest.raises(MocapFormatError, match=r"already exists \(put back from .*k3j9x0ab.*; pass overwrite=True"):
        check_database_output(target)
    assert read_folder(target)[0].num_frames == read_folder(saved)[0].num_frames and not hidden.exists()
    fresh = tmp_path / ".db.zz9x0abc.old"  # a minute has not passed: it may be a live 0.1.0 writer's
    fresh.mkdir()
    database_folder.recover_leftovers(target)
    assert fresh.is_dir()


def test_an_old_folder_beside_an_existing_database_is_swept_not_put_back(small_db, saved, tmp_path):
    """kill -9 after the new database was renamed in, before the old one was deleted: the new one stays."""
    db = shutil.copytree(saved, tmp_path / "db")
    before = _tree(db)
    live = database_folder.staging_folder(tmp_path / "db")
    host = live.name.split(".")[2].split("-")[1]  # .db.PID-HOST-XXXXXXXX.part
    shutil.rmtree(live)
    old = tmp_path / f".db.{_dead_pid()}-{host}-abcd1234.old"
    shutil.copytree(saved, old / "kept")
    (old / "kept" / "an_older_file").write_bytes(b"older")
    assert database_folder.recover_leftovers(db) is None
    assert _tree(db) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db"]


def test_leftovers_of_another_user_s_live_writer_are_kept(small_db, tmp_path, monkeypatch):
    """Asking another user's process gives PermissionError: it is alive, and its unfinished write is not ours to sweep."""
    live = database_folder.staging_folder(tmp_path / "db")
    host = live.name.split(".")[2].split("-")[1]
    shutil.rmtree(live)
    theirs = tmp_path / f".db.4242-{host}-abcd1234.part"
    theirs.mkdir()
    (theirs / "rotations.npy").write_bytes(b"x")

    def kill(pid, sig):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(os, "kill", kill)
    database_folder.recover_leftovers(tmp_path / "db")
    assert (theirs / "rotations.npy").read_bytes() == b"x"


def test_of_two_hidden_databases_the_newest_is_put_back_and_the_other_swept(saved, tmp_path):
    live = database_folder.staging_folder(tmp_path / "db")
    host = live.name.split(".")[2].split("-")[1]
    shutil.rmtree(live)
    older = tmp_path / f".db.{_dead_pid()}-{host}-aaaa1111.old"
    newer = tmp_path / f".db.{_dead_pid()}-{host}-bbbb2222.old"
    for p, when in ((older, 1_000_000_000), (newer, 1_500_000_000)):
        shutil.copytree(saved, p / "kept")
        (p / "kept" / "which").write_text(p.name)
        os.utime(p, (when, when))
    target = tmp_path / "db"
    assert database_folder.recover_leftovers(target) == newer / "kept"
    assert (target / "which").read_text() == newer.name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db"]


def test_a_full_disk_says_so_and_leaves_no_folder_it_made(small_db, tmp_path, monkeypatch):
    """Trial 20: numpy's tofile said "6200 requested and 5088 written" (no cause), and the folders made for the
    database stayed, empty. Each array now goes through Python's writes, which say ENOSPC."""
    import errno
    import io

    class FullDisk(io.BufferedWriter):
        def write(self, b):
            raise OSError(errno.ENOSPC, "No space left on device")

    def full_open(path, mode="r", *args, **kwargs):  # the arrays' files fill the disk
        return FullDisk(io.FileIO(path, "wb")) if mode == "wb" else open(path, mode, *args, **kwargs)

    monkeypatch.setattr(database_folder, "open", full_open, raising=False)
    with pytest.raises(MocapFormatError, match=r"new/a/db: cannot write the database \(no space left on the device\)"):
        small_db.save(tmp_path / "new" / "a" / "db")
    assert list(tmp_path.iterdir()) == []


def test_a_database_another_process_writes_meanwhile_is_said_to_have_appeared(small_db, saved, tmp_path, monkeypatch):
    # two `db build`s of one folder at once: the later one's refusal says what happened, not "pass overwrite=True"
    out = tmp_path / "db"
    staging = database_folder.staging_folder

    def other_build_lands_first(target):
        tmp = staging(target)
        shutil.copytree(saved, target)
        return tmp

    monkeypatch.setattr(database_folder, "staging_folder", other_build_lands_first)
    with pytest.raises(MocapFormatError, match=r"db: appeared while this command ran \(another program wrote it\); "
                                               r"nothing was written over it"):
        small_db.save(out)
    assert MotionDatabase.open(out).clips == MotionDatabase.open(saved).clips
    assert [p.name for p in tmp_path.iterdir()] == ["db"]  # no staging folder left


def test_no_other_output_is_written_inside_a_database_folder(saved, tmp_path):
    """`train -o DB` and `detect -o DB/x.npz` wrote into a database folder, which `db build --overwrite` then refused
    ("it holds det.npz, which a database save does not write"): every writer's guard refuses it in one line."""
    from mocapkit.io.outputs import check_outputs

    for out in (saved / "model.pt", saved / "fold_1" / "model.pt", saved / "features" / "det.npz"):
        with pytest.raises(MocapFormatError, match=r"refusing to write inside a motion database folder \(.*db\), which "
                                                   r"`db build --overwrite` replaces whole; choose another folder"):
            check_outputs([out], overwrite=True)
    check_outputs([saved.parent / "model.pt"])  # beside it is fine
    takes = tmp_path / "takes"  # a folder whose database.json is not a mocapkit database's is no database
    takes.mkdir()
    (takes / "database.json").write_text(json.dumps({"format": "someone-else"}))
    check_outputs([takes / "out.bvh"])
    check_database_output(saved, overwrite=True)  # nothing was written there: db build may still replace it


def test_a_database_folder_named_up_to_255_bytes_is_saved_and_its_leftovers_swept(small_db, tmp_path):
    """The hidden staging folder beside OUT (``.NAME.PID-HOST-XXXXXXXX.part``, 29 bytes and a pid longer than NAME)
    made ``db build`` of a 240-byte OUT fail 'cannot write the database (File name too long)' once the
    database was built. NAME is now cut to fit, and a dead writer's folder under the cut name is swept."""
    name = "d" * 255
    live = database_folder.staging_folder(tmp_path / name)
    host = live.name.rsplit(".", 2)[1].split("-")[1]
    dead = tmp_path / (live.name.rsplit(".", 2)[0] + f".{_dead_pid()}-{host}-abcd1234.part")
    dead.mkdir()
    (dead / "rotations.npy").write_bytes(b"x")
    small_db.save(tmp_path / name)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, live.name])
    small_db.save(tmp_path / name, overwrite=True)  # the replaced folder waits in a cut .old one, then goes
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, live.name])
