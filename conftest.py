"""Root pytest settings shared by the tests and the doctests in src/ (tests/conftest.py reaches only tests/)."""

import tempfile

import pytest


@pytest.fixture(autouse=True)
def doctest_temporary_folder(request, tmp_path_factory, monkeypatch):
    """A doctest's ``tempfile.mkdtemp()`` lands in pytest's own temporary folder, which pytest prunes,
    not in the system's /tmp, where each run left four folders behind."""
    if type(request.node).__name__ == "DoctestItem":
        monkeypatch.setattr(tempfile, "tempdir", str(tmp_path_factory.mktemp("doctest")))
