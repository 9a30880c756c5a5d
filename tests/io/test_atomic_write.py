"""mocapkit.io.atomic_write: the rename is all-or-nothing and the result has ordinary permissions."""

import os
import stat

import pytest

import mocapkit
from mocapkit.io import atomic_write


def _mode(p):
    return stat.S_IMODE(p.stat().st_mode)


def test_new_files_get_the_umask_permissions_not_the_temp_files(tmp_path):
    old = os.umask(0o022)
    try:
        out = tmp_path / "walk.bvh"
        mocapkit.save(mocapkit.load(mocapkit.samples.path("12_walk.amc"))[:5], out)
        assert _mode(out) == 0o644
    finally:
        os.umask(old)


def test_a_replaced_file_keeps_its_permissions(tmp_path):
    out = tmp_path / "a.txt"
    out.write_text("old")
    out.chmod(0o640)
    with atomic_write(out) as fh:
        fh.write("new")
    assert out.read_text() == "new" and _mode(out) == 0o640


def test_an_error_leaves_the_old_file_and_no_temp(tmp_path):
    out = tmp_path / "a.txt"
    out.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_write(out) as fh:
            fh.write("half")
            raise RuntimeError("boom")
    assert out.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_a_full_disk_names_the_output(tmp_path, monkeypatch):
    import errno
    import os

    out = tmp_path / "take.bvh"

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(OSError) as info:
        with atomic_write(out) as fh:
            fh.write("x")
    assert info.value.filename == str(out) and not list(tmp_path.iterdir())


def test_a_failed_write_removes_the_folders_it_made(tmp_path, monkeypatch):
    # trial 20: `plot -o new/a/p.png` on a full disk left new/a behind, empty
    import errno
    import os

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    (tmp_path / "kept").mkdir()
    for out in (tmp_path / "new" / "a" / "p.png", tmp_path / "kept" / "b" / "q.png"):
        with pytest.raises(OSError):
            with atomic_write(out, "wb") as fh:
                fh.write(b"x")
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["kept"]  # a folder that was there before stays
