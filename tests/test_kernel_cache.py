"""mocapkit.kernel_cache: numba gets a place for the kernels when the install and the home are read-only."""

import os
from pathlib import Path

import numba
import pytest

from mocapkit import kernel_cache


@pytest.fixture
def numba_cache_dir_unset(monkeypatch):
    """``NUMBA_CACHE_DIR`` unset for the test and put back as it was after it, whatever ensure_cache_dir set meanwhile.
    ``monkeypatch.delenv`` of a variable that is not set records nothing to undo; setting it first records it as it
    was (put back last, after any later change is undone). Without it the folder ensure_cache_dir chose under the
    test's tmp_path stayed numba's cache for every later test of the worker and every process they started."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", "")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)  # restored after the test


@pytest.mark.usefixtures("numba_cache_dir_unset")
def test_a_private_temporary_folder_when_nothing_else_is_writable(monkeypatch, tmp_path):
    monkeypatch.setattr(kernel_cache, "writable", lambda folder: False)  # read-only site-packages and home
    monkeypatch.setattr(kernel_cache.tempfile, "gettempdir", lambda: str(tmp_path))
    folder = kernel_cache.ensure_cache_dir()
    assert folder is not None and Path(folder).parent == tmp_path and os.environ["NUMBA_CACHE_DIR"] == folder
    assert numba.config.CACHE_DIR == folder  # numba was imported first: its setting follows


def test_nothing_changes_where_numba_has_a_place(monkeypatch, tmp_path):
    assert kernel_cache.writable(tmp_path / "new" / "deep") and not kernel_cache.writable(Path("/proc/nope"))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    assert kernel_cache.ensure_cache_dir() is None and os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "mine")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setattr(kernel_cache, "writable", lambda folder: "__pycache__" not in str(folder))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert kernel_cache.ensure_cache_dir() is None and "NUMBA_CACHE_DIR" not in os.environ


@pytest.mark.usefixtures("numba_cache_dir_unset")
def test_a_folder_others_can_write_in_is_never_numbas_cache(monkeypatch, tmp_path):
    """numba's cache holds pickles: a folder of the expected name that others may write in (planted by another user)
    is passed over for a fresh private one."""
    monkeypatch.setattr(kernel_cache, "writable", lambda folder: False)
    monkeypatch.setattr(kernel_cache.tempfile, "gettempdir", lambda: str(tmp_path))
    who = os.getuid() if hasattr(os, "getuid") else "user"
    planted = tmp_path / f"mocapkit-numba-{who}"
    planted.mkdir()
    os.chmod(planted, 0o777)
    folder = Path(kernel_cache.ensure_cache_dir())
    assert folder != planted and folder.parent == tmp_path and (folder.stat().st_mode & 0o077) == 0
    os.chmod(planted, 0o700)  # its own, closed folder is used as it is
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    assert Path(kernel_cache.ensure_cache_dir()) == planted
