"""A BVH, TRC, ASF or AMC that starts with a UTF-8 byte-order mark (Windows tools write one) is read as the same file
without it, and an output written back from its text keeps it: byte for byte the input (before, each was refused in
one line: ``expected HIERARCHY, found '\\ufeffHIERARCHY'``, ``bone values before the first frame number``, ``not a
TRC file``)."""

import dataclasses
import shutil

import numpy as np

import mocapkit
from mocapkit import samples
from mocapkit.io import load_markers, save_markers
from mocapkit.io.sources import BOM

ASF_WITHOUT_COMMENTS = b"".join(line for line in samples.path("12.asf").read_bytes().splitlines(keepends=True)
                                if not line.startswith(b"#"))  # ':version' first: the mark is on a keyword line


def _with_mark(src, dst, data=None):
    dst.write_bytes(BOM + (src.read_bytes() if data is None else data))
    return dst


def _same_take(a, b):
    assert a.skeleton.joint_names == b.skeleton.joint_names and a.fps == b.fps
    np.testing.assert_array_equal(a.rotations, b.rotations)
    np.testing.assert_array_equal(a.root_positions, b.root_positions)


def test_a_bvh_with_a_byte_order_mark_is_read_and_written_back_with_it(tmp_path):
    plain = samples.path("131_01.bvh")
    inp = _with_mark(plain, tmp_path / "in.bvh")
    m = mocapkit.load(inp)
    _same_take(m, mocapkit.load(plain))
    for out in ("out.bvh", "out.npz"):
        mocapkit.save(m, tmp_path / out, like=inp)
    mocapkit.save(mocapkit.load(tmp_path / "out.npz"), tmp_path / "back.bvh", like=tmp_path / "out.npz")
    assert (tmp_path / "out.bvh").read_bytes() == inp.read_bytes()
    assert (tmp_path / "back.bvh").read_bytes() == inp.read_bytes()
    rot = np.array(m.rotations)  # one cell changed: the rest of the text, the mark included, as read
    rot[3, 2] = [1.0, 0.0, 0.0, 0.0]
    mocapkit.save(dataclasses.replace(m, rotations=rot), tmp_path / "changed.bvh", like=inp)
    assert (tmp_path / "changed.bvh").read_bytes().startswith(BOM + b"HIERARCHY")


def test_an_asf_and_amc_with_a_byte_order_mark_are_read_and_the_amc_written_back_with_it(tmp_path):
    _with_mark(samples.path("12.asf"), tmp_path / "12.asf", ASF_WITHOUT_COMMENTS)
    inp = _with_mark(samples.path("12_walk.amc"), tmp_path / "12_walk.amc")
    m = mocapkit.load(inp)
    shutil.copy(samples.path("12.asf"), tmp_path / "plain.asf")
    _same_take(m, mocapkit.load(samples.path("12_walk.amc"), asf=tmp_path / "plain.asf"))
    mocapkit.save(m, tmp_path / "out.amc", like=inp)
    assert (tmp_path / "out.amc").read_bytes() == inp.read_bytes()
    mocapkit.save(m, tmp_path / "out.npz", like=inp)
    mocapkit.save(mocapkit.load(tmp_path / "out.npz"), tmp_path / "back.amc", like=tmp_path / "out.npz")
    assert (tmp_path / "back.amc").read_bytes() == inp.read_bytes()


def test_a_trc_with_a_byte_order_mark_is_read_and_written_back_with_it(tmp_path, shared_data):
    plain = shared_data / "trc_markers" / "T.trc"
    inp = _with_mark(plain, tmp_path / "T.trc")
    mk, ref = load_markers(inp), load_markers(plain)
    assert mk.labels == ref.labels and mk.fps == ref.fps and mk.units == ref.units
    np.testing.assert_array_equal(mk.positions, ref.positions)
    save_markers(mk, tmp_path / "out.trc")
    assert (tmp_path / "out.trc").read_bytes() == inp.read_bytes()
