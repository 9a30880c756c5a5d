"""Tests of mocapkit.cleaning.precompile: the helper compiles what clean calls, with clean's argument types."""

from __future__ import annotations

import hashlib
import importlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from mocapkit.cleaning import precompile
from mocapkit.cleaning.ssa.twins import on_disk

_KERNEL_MODULE = '''
from numba import njit


@njit(cache=True)
def plus_one(x):
    return x + {n}
'''


def _fresh_module(folder, n=None, mtime=None):
    """Import ``cachedmod`` from ``folder`` again, first rewritten to add ``n`` (None: as it is)."""
    path = folder / "cachedmod.py"
    if n is not None:
        path.write_text(_KERNEL_MODULE.format(n=n))
    if mtime is not None:
        os.utime(path, (mtime, mtime))
    sys.modules.pop("cachedmod", None)
    importlib.invalidate_caches()
    return importlib.import_module("cachedmod")


def test_on_disk_tells_a_fresh_cache_entry_from_a_missing_or_stale_one(tmp_path, monkeypatch):
    """numba caches beside the source here (tmp_path/__pycache__), or in NUMBA_CACHE_DIR keyed by its path."""
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    mod = _fresh_module(tmp_path, 1)
    assert on_disk(mod.plus_one) is False  # nothing compiled yet
    assert mod.plus_one(1) == 2
    assert on_disk(mod.plus_one) is True
    assert on_disk(_fresh_module(tmp_path).plus_one) is True  # another dispatcher of the same source
    assert on_disk(_fresh_module(tmp_path, 2, mtime=1e9).plus_one) is False  # the source changed: the entry is stale
    sys.modules.pop("cachedmod", None)


def test_on_disk_cannot_tell_without_a_cache():
    from numba import njit

    assert on_disk(njit(lambda x: x)) is None


def test_the_helper_is_needed_only_with_a_cold_cache_and_when_not_switched_off(monkeypatch):
    from mocapkit.cleaning.ssa import twins

    precompile.compile_kernels(["knn_callees"])  # the row kernel the check reads is now in the cache
    assert not precompile.needed()
    monkeypatch.setattr(twins, "on_disk", lambda d: False)  # as with an empty cache
    monkeypatch.delenv("MOCAPKIT_PRECOMPILE", raising=False)
    assert precompile.needed() == (len(os.sched_getaffinity(0)) >= 2)  # one core: nothing to run it beside
    monkeypatch.setenv("MOCAPKIT_PRECOMPILE", "0")
    assert not precompile.needed()


def test_kernels_for_names_what_the_steps_call_in_the_helpers_order():
    assert precompile.kernels_for(["fill", "detect"]) == ("knn_callees", "row_minima", "shift_angles")
    assert precompile.kernels_for(["detect", "repair", "denoise"]) == precompile.KERNELS
    assert precompile.kernels_for(["denoise"]) == ("risk_terms",)
    with pytest.raises(ValueError, match="unknown kernels"):
        precompile.start(["warp", "everything"])


def test_compile_kernels_stops_when_asked():
    calls = []
    assert precompile.compile_kernels(stop=lambda: calls.append(1) or len(calls) > 2) == ["knn_callees", "row_minima"]
    assert precompile.main([str(os.getpid())]) == 0  # not our parent: stops before the first kernel


_CLEAN = """
import mocapkit
from mocapkit.warmup import broken_walk
mocapkit.clean(broken_walk())
"""


def _cache_subpath(folder: Path) -> str:
    """The folder numba gives the kernels of the sources in ``folder`` under ``NUMBA_CACHE_DIR``: its name and the
    SHA-1 of its absolute path (numba.core.caching, ``get_suitable_cache_subpath``)."""
    folder = os.path.abspath(folder)
    return os.path.basename(folder) + "_" + hashlib.sha1(folder.encode()).hexdigest()


def _copy_other_kernels(cache: Path, leave_out: set[str]) -> int:
    """Copy into the ``NUMBA_CACHE_DIR`` folder ``cache`` what this checkout's numba cache holds (beside the sources,
    or in this process's ``NUMBA_CACHE_DIR``) for every kernel of mocapkit but those named in ``leave_out``
    (``module.function``); returns how many kernels. A cache entry is keyed by its source file's time stamp and
    size, not by where the cache lies, so the entries copied are loaded, not compiled again, by a process that
    uses ``cache``; a kernel missing here is compiled as before."""
    import mocapkit

    root = Path(mocapkit.__file__).parent
    copied = 0
    for folder in {p.parent for p in root.rglob("*.py")}:
        places = [folder / "__pycache__"]
        if os.environ.get("NUMBA_CACHE_DIR"):
            places.append(Path(os.environ["NUMBA_CACHE_DIR"]) / _cache_subpath(folder))
        for place in places:
            for index in place.glob("*.nbi"):
                kernel = index.name.split("-")[0]
                if kernel in leave_out:
                    continue
                to = cache / _cache_subpath(folder)
                if (to / index.name).exists():
                    continue
                to.mkdir(parents=True, exist_ok=True)
                for f in place.glob(index.name[: -len(".nbi")] + ".*"):
                    shutil.copy2(f, to / f.name)
                copied += 1
    return copied


@pytest.mark.slow  # ~23 s compiling into an empty cache: `pytest -m slow`
def test_the_helper_fills_an_empty_cache_with_what_clean_then_loads(tmp_path):
    """With numba's cache in an empty folder the helper starts, compiles its kernels into that cache and exits; a
    process then finds them there (and would not start it again), and a clean of the bundled walk with every defect
    (fill, detect, repair and denoise all change cells), the helper switched off, loads them: numba saves none of
    them again, so the helper compiled each with the argument types clean calls it with.

    The kernels the helper does not compile are copied into that cache from this checkout's (warm after
    ``python -m mocapkit.warmup``), so that the clean loads them rather than spending half a minute compiling
    what this test does not look at; a kernel the copy lacks it compiles, as before."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "MOCAPKIT_PRECOMPILE": "1"}
    code = ("from mocapkit.cleaning import precompile\n"
            "assert precompile.needed()\n"
            "p = precompile.start()\n"
            "print(p.wait())\n"
            "from mocapkit.cleaning.ssa.dtw_rows import word_dtw_rows\n"
            "from mocapkit.cleaning.ssa.twins import on_disk\n"
            "print(precompile.needed(), on_disk(word_dtw_rows))\n")
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True)
    assert out.stdout.split() == ["0", "False", "True"]
    helper = {p.name.split("-")[0] for p in (tmp_path / "cache").rglob("*.nbi")}
    assert {"ordering.kth_smallest", "ordering.sort_by_key", "dtw_rows.word_dtw_rows", "word_dtw._row_minima",
            "word_means._shift_angles", "word_dtw._warp", "word_means._robust_means", "sure._risk_terms"} <= helper
    _copy_other_kernels(tmp_path / "cache", helper)
    env.update(NUMBA_DEBUG_CACHE="1", MOCAPKIT_PRECOMPILE="0")
    out = subprocess.run([sys.executable, "-c", _CLEAN], env=env, check=True, capture_output=True, text=True)
    saved = {line.rsplit("/", 1)[1].split("-")[0] for line in out.stdout.splitlines() if "data saved" in line}
    loaded = {line.rsplit("/", 1)[1].split("-")[0] for line in out.stdout.splitlines() if "data loaded" in line}
    assert not saved & helper, saved & helper  # clean compiled the rest (or loaded it as copied), not these
    assert loaded & helper, out.stdout[-2000:]  # and it loaded the helper's, as numba's debug lines say


def test_the_helper_does_not_outlive_the_command(tmp_path):
    """A process that started the helper and exits at once (the helper still importing or compiling) stops it."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "MOCAPKIT_PRECOMPILE": "1"}
    code = "from mocapkit.cleaning import precompile\nprint(precompile.start().pid)\n"
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True)
    with pytest.raises(ProcessLookupError):
        os.kill(int(out.stdout.split()[-1]), 0)
