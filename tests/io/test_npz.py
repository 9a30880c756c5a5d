import numpy as np
import pytest

import mocapkit
from mocapkit.errors import MocapFormatError
from mocapkit.io.c3d import read_c3d

from ..test_motion import random_motion
from .bounded import refusal_of_load


@pytest.mark.parametrize("kw", [{}, {"with_axes": True}, {"with_translations": True}])
def test_npz_round_trip_is_lossless_nan_included(tmp_path, kw):
    m = random_motion(11, **kw)
    rot = np.array(m.rotations)
    rot[0, 1] = np.nan
    rot[-1, 3] = np.nan
    import dataclasses

    m = dataclasses.replace(m, rotations=rot)
    path = mocapkit.save(m, tmp_path / "m.npz")
    back = mocapkit.load(path)
    np.testing.assert_array_equal(back.rotations, m.rotations)  # assert_array_equal treats NaN == NaN
    assert back.skeleton == m.skeleton and back.fps == m.fps and back.name == m.name
    if m.translations is not None:
        np.testing.assert_array_equal(back.translations, m.translations)


def test_npz_round_trip_of_a_real_clip(tmp_path):
    m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    back = mocapkit.load(mocapkit.save(m, tmp_path / "clip.npz"))
    np.testing.assert_array_equal(back.rotations, m.rotations)
    np.testing.assert_array_equal(back.root_positions, m.root_positions)
    assert back.skeleton.channels == m.skeleton.channels
    np.testing.assert_array_equal(back.global_positions(end_sites=True), m.global_positions(end_sites=True))


def test_marker_set_round_trip(tmp_path):
    ms = read_c3d(mocapkit.samples.path("Eb015pr.c3d"))
    back = mocapkit.load(mocapkit.save(ms, tmp_path / "markers.npz"))
    np.testing.assert_array_equal(back.positions, ms.positions)
    assert back.labels == ms.labels and back.fps == ms.fps


def test_bad_npz_files(tmp_path):
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip at all")
    with pytest.raises(MocapFormatError, match="junk.npz: not a readable .npz"):
        mocapkit.load(junk)
    other = tmp_path / "other.npz"
    np.savez(other, a=np.zeros(3))
    with pytest.raises(MocapFormatError, match="not a mocapkit npz"):
        mocapkit.load(other)
    # a truncated copy of a real file
    good = mocapkit.save(mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:10], tmp_path / "good.npz")
    cut = tmp_path / "cut.npz"
    cut.write_bytes(good.read_bytes()[:200])
    with pytest.raises(MocapFormatError, match="cut.npz"):
        mocapkit.load(cut)


def test_a_frame_rate_outside_1_to_1000_fps_is_refused(tmp_path):
    # `denoise` on an npz at fps 0.01 used 8 GB
    m = random_motion(15, frames=300)
    path = mocapkit.save(m, tmp_path / "m.npz")
    with np.load(path) as z:
        arrays = dict(z)
    for fps in (0.01, 5000.0):
        arrays["fps"] = np.array(fps)
        bad = tmp_path / f"fps_{fps:g}.npz"
        np.savez(bad, **arrays)
        msg = refusal_of_load(bad)
        assert msg == f"{bad}: fps must be a positive number from 1 to 1000 (frames per second), got {fps!r}"


def test_names_npz_would_change_are_refused_and_others_round_trip(tmp_path):
    import dataclasses

    m = random_motion(16, frames=3)
    names = list(m.skeleton.joint_names)
    names[2] = "lone\ud800 tab\there"  # npz holds these
    ok = dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, joint_names=tuple(names)))
    assert mocapkit.load(mocapkit.save(ok, tmp_path / "ok.npz")).skeleton.joint_names == tuple(names)
    names[3] = "nul\x00"  # numpy drops trailing NULs
    bad = dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, joint_names=tuple(names)))
    out = tmp_path / "bad.npz"
    with pytest.raises(MocapFormatError, match=r"bad\.npz: joint 3 name 'nul\\x00' ends in a NUL character"):
        mocapkit.save(bad, out)
    assert not out.exists()
