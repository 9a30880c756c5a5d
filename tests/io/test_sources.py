"""mocapkit.io.sources: a BVH or AMC written like its input keeps the input's text as read, whatever the path holds
at write time (trial 20: an input removed while `clean` ran gave an output without its CRLF line ends, with no word)."""

import dataclasses
import shutil

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.errors import MocapFormatError


def _changed(m):
    """The take with one joint's rotation changed in one frame (the rest must keep the input's text)."""
    rot = np.array(m.rotations)
    rot[3, 2] = [1.0, 0.0, 0.0, 0.0]
    return dataclasses.replace(m, rotations=rot)


def _bvh(tmp_path):
    inp = tmp_path / "in.bvh"
    shutil.copy(samples.path("131_01.bvh"), inp)  # CRLF line ends: written generically, they would be LF
    return inp


def _amc(tmp_path):
    shutil.copy(samples.path("12.asf"), tmp_path / "12.asf")
    inp = tmp_path / "12_walk.amc"
    shutil.copy(samples.path("12_walk.amc"), inp)
    return inp


@pytest.mark.parametrize("make", [_bvh, _amc])
def test_an_input_removed_after_it_was_read_still_gives_its_text(tmp_path, make):
    inp = make(tmp_path)
    m = mocapkit.load(inp)
    cleaned = _changed(m)
    ref = mocapkit.save(cleaned, tmp_path / f"ref{inp.suffix}", like=inp)
    m = mocapkit.load(inp)  # read again, as a command does, then the input goes away
    inp.unlink()
    out = mocapkit.save(cleaned, tmp_path / f"out{inp.suffix}", like=inp)
    assert out.read_bytes() == ref.read_bytes()


@pytest.mark.parametrize("make", [_bvh, _amc])
def test_an_input_changed_after_it_was_read_whose_text_was_let_go_is_refused(tmp_path, make, monkeypatch):
    from mocapkit.io import sources

    inp = make(tmp_path)
    monkeypatch.setattr(sources, "MAX_KEPT_BYTES", 0)  # only the digest is kept (a large corpus read since)
    cleaned = _changed(mocapkit.load(inp))
    data = inp.read_bytes()
    inp.write_bytes(data.replace(b"0", b"1", 1) if inp.suffix == ".amc" else data.replace(b"\r\n", b"\n"))
    with pytest.raises(MocapFormatError, match=r"in\.bvh: removed or changed after its take was read|"
                                               r"12_walk\.amc: removed or changed after its take was read"):
        mocapkit.save(cleaned, tmp_path / f"out{inp.suffix}", like=inp)
    assert not (tmp_path / f"out{inp.suffix}").exists()
