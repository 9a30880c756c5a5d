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


def test_the_kept_members_read_alone_are_those_the_whole_npz_holds(tmp_path):
    """The kept numbers, layout and text that every repair and denoise reads again from a take's .npz are read
    alone (``load_arrays(keys=...)``), not with the rotations: the same arrays as the whole npz's, the same
    absence where an .npz keeps none, and the same refusal where the whole npz is refused."""
    from mocapkit.errors import MocapFormatError
    from mocapkit.io import kept_channels as kc
    from mocapkit.io.npz import load_arrays

    amc, asf = samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"), samples.path("HDM_bd.asf")
    mocapkit.save(mocapkit.load(amc, asf=asf), tmp_path / "amc.npz")
    mocapkit.save(mocapkit.load(samples.path("131_01.bvh")), tmp_path / "bvh.npz")
    bare = mocapkit.load(tmp_path / "amc.npz")
    mocapkit.save(dataclasses.replace(bare, rotations=bare.rotations[::-1].copy()), tmp_path / "bare.npz")
    keys = (kc.VALUES_KEY, kc.LAYOUT_KEY, kc.HEADER_KEY, kc.COMMENTS_KEY, *kc.TEXT_KEYS.values())
    held = 0
    for name in ("amc.npz", "bvh.npz", "bare.npz"):
        whole = load_arrays(tmp_path / name)
        for key in keys:
            alone = load_arrays(tmp_path / name, keys=(key,))
            assert set(alone) == {key} & set(whole)
            if key in whole:
                held += 1
                assert alone[key].dtype == whole[key].dtype and np.array_equal(alone[key], whole[key])
        with pytest.raises(MocapFormatError, match="over the 1,000-byte limit"):
            load_arrays(tmp_path / name, max_bytes=1000, keys=(kc.LAYOUT_KEY,))  # refused as the whole npz is
    assert held >= 6  # the AMC's numbers, layout and text, the BVH's numbers, layout and text at least
    assert load_arrays(tmp_path / "bvh.npz", keys=()) == {}
