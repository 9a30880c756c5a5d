"""The exception hierarchy: errors keep their one-line form across a pickle, as raised in a worker process."""

from __future__ import annotations

import pickle

import pytest

from mocapkit.errors import MocapFormatError, SkeletonError
from mocapkit.parallel import map_ordered


def _raise_format_error(path):
    raise MocapFormatError(path, "skeleton differs from the database's", line=3)


def test_format_error_survives_a_pickle():
    err = pickle.loads(pickle.dumps(MocapFormatError("take.bvh", "cut short", line=12)))
    assert (err.path, err.reason, err.line, str(err)) == ("take.bvh", "cut short", 12, "take.bvh:12: cut short")
    assert str(pickle.loads(pickle.dumps(MocapFormatError(None, "no input")))) == "<input>: no input"
    assert str(pickle.loads(pickle.dumps(SkeletonError("two roots")))) == "two roots"


def test_format_error_in_a_worker_process_reaches_the_caller():
    # before, unpickling it in the parent failed and the pool reported BrokenProcessPool instead
    with pytest.raises(MocapFormatError, match=r"^[ab]\.bvh:3: skeleton differs"):
        map_ordered(_raise_format_error, ["a.bvh", "b.bvh"], executor="processes", progress=False, max_workers=2)


def test_a_missing_file_is_also_a_file_not_found_error(tmp_path):
    """A library user's ``except FileNotFoundError`` catches it; it stays one line naming the file, and pickles."""
    import pickle

    import mocapkit
    from mocapkit.errors import MissingFileError, MocapFormatError

    for call in (lambda: mocapkit.load(tmp_path / "gone.bvh"), lambda: mocapkit.clean(tmp_path / "gone.bvh")):
        with pytest.raises(FileNotFoundError) as err:
            call()
        assert isinstance(err.value, MissingFileError) and isinstance(err.value, MocapFormatError)
        assert str(err.value) == f"{tmp_path / 'gone.bvh'}: no such file" and err.value.filename == str(tmp_path / "gone.bvh")
        again = pickle.loads(pickle.dumps(err.value))
        assert type(again) is MissingFileError and str(again) == str(err.value) and again.errno == err.value.errno
    (tmp_path / "dir.bvh").mkdir()
    with pytest.raises(MocapFormatError) as err:
        mocapkit.load(tmp_path / "dir.bvh")
    assert not isinstance(err.value, FileNotFoundError)


def test_a_file_size_limit_is_said_in_words():
    import errno

    from mocapkit.errors import os_error_line

    line = os_error_line(OSError(errno.EFBIG, "File too large", "out.html"))
    assert line.startswith("out.html: file too large (over the file-size limit")
