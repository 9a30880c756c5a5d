"""Root pytest settings shared by the tests and the doctests in src/ (tests/conftest.py reaches only tests/)."""

import os
import tempfile

import pytest


def _owned_settings() -> dict:
    """The ``NUMBA_*`` and ``MOCAPKIT_*`` environment variables: numba's and mocapkit's settings."""
    return {k: v for k, v in os.environ.items() if k.startswith(("NUMBA_", "MOCAPKIT_"))}


@pytest.fixture(autouse=True)
def settings_left_as_found():
    """A test leaves numba's and mocapkit's environment variables as it found them, checked after its ``monkeypatch``
    is undone (no autouse fixture asks for ``monkeypatch``: a test's is set up after this one, and torn down before).
    ``mocapkit.kernel_cache.ensure_cache_dir`` sets ``NUMBA_CACHE_DIR`` itself, and ``monkeypatch.delenv`` of a
    variable that was not set records nothing to put back: a test's temporary folder stayed numba's cache for every
    later test of its xdist worker and for every process they started, each compiling its kernels again, cold."""
    before = _owned_settings()
    yield
    after = _owned_settings()
    if after != before:
        changed = sorted(k for k in before.keys() | after.keys() if before.get(k) != after.get(k))
        pytest.fail(f"the test left the environment changed: {', '.join(f'{k}={after.get(k)!r}' for k in changed)}",
                    pytrace=False)


@pytest.fixture(autouse=True)
def doctest_temporary_folder(request, tmp_path_factory):
    """A doctest's ``tempfile.mkdtemp()`` lands in pytest's own temporary folder, which pytest prunes,
    not in the system's /tmp, where each run left four folders behind. (Its own MonkeyPatch, not the fixture: an
    autouse fixture asking for ``monkeypatch`` would set it up before :func:`settings_left_as_found`.)"""
    if type(request.node).__name__ != "DoctestItem":
        yield
        return
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(tempfile, "tempdir", str(tmp_path_factory.mktemp("doctest")))
        yield
