"""An .npz made from a BVH or an AMC keeps the file's text, so that the file written back from it is the file."""

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import samples


def _turned(motion, joint=3, frames=slice(10, 20)):
    """``motion`` with one joint's rotation changed in a few frames (its quaternion's first two parts swapped)."""
    r = motion.rotations.copy()
    q = r[frames, joint][:, [1, 0, 2, 3]]
    r[frames, joint] = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return dataclasses.replace(motion, rotations=r)


def test_a_bvh_written_from_the_npz_made_from_it_is_that_bvh_byte_for_byte(tmp_path):
    """`convert 131_01.bvh x.npz` then `convert x.npz y.bvh` wrote every number in Python's shortest form (`5.2300`
    as `5.23`, `0.0000` as `0`: 626,431 bytes of its 716,137). Now the .npz keeps the file's text: an unchanged
    take comes back the file, byte for byte (through a second .npz too), and a take changed after it is written as
    the BVH itself would be written (`clean`'s BVH -> BVH): the changed cells anew, every other cell's text kept."""
    src = samples.path("131_01.bvh")
    m = mocapkit.load(src)
    mocapkit.save(m, tmp_path / "x.npz")
    n = mocapkit.load(tmp_path / "x.npz")
    mocapkit.save(n, tmp_path / "y.bvh")
    assert (tmp_path / "y.bvh").read_bytes() == src.read_bytes()
    mocapkit.save(n, tmp_path / "again.npz")
    mocapkit.save(mocapkit.load(tmp_path / "again.npz"), tmp_path / "again.bvh")
    assert (tmp_path / "again.bvh").read_bytes() == src.read_bytes()
    mocapkit.save(_turned(m), tmp_path / "direct.bvh")
    mocapkit.save(_turned(n), tmp_path / "via.bvh")
    via = (tmp_path / "via.bvh").read_bytes()
    assert via == (tmp_path / "direct.bvh").read_bytes() and via != src.read_bytes()
    assert b" 0.0000 0.0000 0.0000 " in via.split(b"Frame Time")[1].splitlines()[11]  # a changed frame's kept cells


def test_an_amc_written_from_the_npz_made_from_it_is_that_amc_byte_for_byte(tmp_path):
    """AMC -> npz -> AMC lost the file's comment line, its bones' order in a frame and its numbers' text
    (`2.00773e-014`); now kept as AMC -> AMC keeps them, and a changed take is written as from the AMC itself."""
    amc, asf = samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"), samples.path("HDM_bd.asf")
    m = mocapkit.load(amc, asf=asf)
    mocapkit.save(m, tmp_path / "x.npz")
    n = mocapkit.load(tmp_path / "x.npz")
    for name, take in (("same", n), ("direct", _turned(m)), ("via", _turned(n))):
        (tmp_path / name).mkdir()
        if name == "same":
            mocapkit.save(take, tmp_path / name / "t.amc", asf=asf)
            continue
        with pytest.warns(UserWarning, match="rotations of ltibia"):  # turned about axes its 1-dof tibia lacks: said
            mocapkit.save(take, tmp_path / name / "t.amc", asf=asf)
    assert (tmp_path / "same" / "t.amc").read_bytes() == amc.read_bytes()
    assert (tmp_path / "via" / "t.amc").read_bytes() == (tmp_path / "direct" / "t.amc").read_bytes() != amc.read_bytes()
