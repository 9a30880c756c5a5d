import dataclasses
from pathlib import Path

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


def test_a_frame_rate_outside_1_to_10000_fps_is_refused(tmp_path):
    # `denoise` on an npz at fps 0.01 used 8 GB
    m = random_motion(15, frames=300)
    path = mocapkit.save(m, tmp_path / "m.npz")
    with np.load(path) as z:
        arrays = dict(z)
    for fps in (0.01, 50000.0):
        arrays["fps"] = np.array(fps)
        bad = tmp_path / f"fps_{fps:g}.npz"
        np.savez(bad, **arrays)
        msg = refusal_of_load(bad)
        assert msg == f"{bad}: fps must be a positive number from 1 to 10000 (frames per second), got {fps!r}"


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


def _patch_declared_size(path, member: str, size: int) -> None:
    """Make the zip's local and central headers of ``member`` declare ``size`` uncompressed bytes."""
    import struct
    import zipfile

    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo(member)
    struct.pack_into("<I", data, info.header_offset + 22, size)  # local header: uncompressed size
    name = member.encode()
    central = data.find(b"PK\x01\x02")
    while data[central + 46 : central + 46 + len(name)] != name:  # the entry of ``member``
        central = data.find(b"PK\x01\x02", central + 4)
        assert central > 0
    struct.pack_into("<I", data, central + 24, size)  # central directory: uncompressed size
    path.write_bytes(bytes(data))


def test_an_npz_bomb_is_refused_from_its_declared_shape_before_inflating(tmp_path):
    # a 4.2 MB file holding a 4 GB array loaded (and was copied again: 9 GB); here the member's .npy header
    # and the zip directory declare 3.5 GiB of float64 while the stream holds a little: it must be refused
    # on the declaration, inside a 2 GiB address space
    import struct
    import zipfile

    m = random_motion(17, frames=10)
    path = mocapkit.save(m, tmp_path / "bomb.npz")
    with np.load(path) as z:
        arrays = dict(z)
    n = 3584 * 2**20 // 8
    hdr = np.lib.format.header_data_from_array_1_0(np.zeros(1))
    hdr["shape"] = (n // 124, 31, 4)
    import io

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, hdr)
    raw = buf.getvalue() + bytes(2**20)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for key, a in arrays.items():
            if key == "rotations":
                zf.writestr("rotations.npy", raw)
            else:
                b = io.BytesIO()
                np.save(b, a)
                zf.writestr(f"{key}.npy", b.getvalue())
    declared = len(buf.getvalue()) + (n // 124) * 124 * 8
    _patch_declared_size(path, "rotations.npy", declared)
    msg = refusal_of_load(path)
    assert msg.startswith(f"{path}: array 'rotations' of shape ({n // 124}, 31, 4) and dtype float64 brings the arrays to")
    assert msg.endswith("over the 536,870,912-byte limit (refused before inflating)")


def test_load_arrays_counts_every_member_and_small_dtypes_as_float64(tmp_path):
    from mocapkit.io.npz import load_arrays

    path = tmp_path / "a.npz"
    np.savez_compressed(path, a=np.zeros((1000, 100), dtype=np.int8), b=np.zeros(100))
    assert set(load_arrays(path, max_bytes=1000 * 100 * 8 + 800)) == {"a", "b"}
    with pytest.raises(MocapFormatError, match=r"a\.npz: array 'a' of shape \(1000, 100\) and dtype int8 brings the arrays to 800,000 bytes"):
        load_arrays(path, max_bytes=799_999)
    with pytest.raises(MocapFormatError, match=r"array 'b' .* 800,800 bytes, over the 800,799-byte limit"):
        load_arrays(path, max_bytes=800_799)
    obj = tmp_path / "obj.npz"
    np.savez(obj, o=np.array([{"a": 1}], dtype=object))
    with pytest.raises(MocapFormatError, match=r"obj\.npz: array 'o' holds Python objects"):
        load_arrays(obj)


def test_a_zip_listing_too_many_members_is_refused_before_its_directory_is_parsed(tmp_path):
    import zipfile

    from mocapkit.io.npz import load_arrays

    path = tmp_path / "many.npz"
    with zipfile.ZipFile(path, "w") as zf:
        for i in range(300):
            zf.writestr(f"m{i}.npy", b"")
    with pytest.raises(MocapFormatError, match=r"many\.npz: the zip lists 300 members, more than the 200 an npz may have"):
        load_arrays(path, max_members=200)


def test_a_marker_npz_keeps_the_first_frame_and_the_files_labels(tmp_path):
    # trial11: FunctionalWalk.c3d (first frame 480) -> npz -> c3d came back from frame 1
    import dataclasses

    ms = read_c3d(mocapkit.samples.path("Eb015pr.c3d"))[100:200]
    assert ms.source.first_frame == 101
    back = mocapkit.load(mocapkit.save(ms, tmp_path / "part.npz"))
    assert back.source.first_frame == 101 and back.file_labels() == back.labels
    # a label the file repeats: unique in memory (and in "labels"), the file's own kept beside them
    raw = ms.labels[:2] + (ms.labels[0],) + ms.labels[3:]
    dup = dataclasses.replace(ms, labels=ms.labels[:2] + (ms.labels[0] + "_2",) + ms.labels[3:],
                              source=dataclasses.replace(ms.source, labels=raw))
    again = mocapkit.load(mocapkit.save(dup, tmp_path / "dup.npz"))
    assert again.labels == dup.labels and again.file_labels() == raw
    # an npz written before first_frame was stored still reads, from frame 1
    with np.load(tmp_path / "part.npz") as z:
        arrays = {k: z[k] for k in z.files if k != "first_frame"}
    np.savez(tmp_path / "old.npz", **arrays)
    assert mocapkit.load(tmp_path / "old.npz").source.first_frame == 1


def test_a_marker_npz_tells_fills_from_recorded_samples_and_reads_them_back(tmp_path):
    # A C3D marks a fill by residual 0, a TRC says it in a note; a marker npz has its bool filled (F, M) beside the
    # positions: the cleaning's fills (a gap cut in CMU 85_02 and filled), read back by the reader and by info.
    from pathlib import Path

    from mocapkit.io import load_markers, save_markers
    from mocapkit.marker_files import clean_marker_file

    from ..cli.helpers import run

    m = load_markers(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")
    p = np.array(m.positions)
    p[200:230, m.labels.index("Male:LKNE")] = np.nan
    save_markers(m.with_positions(p), tmp_path / "in.c3d")
    _, res = clean_marker_file(tmp_path / "in.c3d", tmp_path / "out.npz")
    assert res.fill_mask.sum() == 30
    back = mocapkit.io.load_markers(tmp_path / "out.npz")
    assert np.array_equal(back.source.filled, res.fill_mask)
    assert np.array_equal(back[200:210].source.filled, res.fill_mask[200:210])
    code, out, _ = run("info", tmp_path / "out.npz")
    assert code == 0 and "30 of 33210 marker samples are no recorded ones (the npz's filled mask)" in out
    # converted on, the mask goes with the samples: npz to npz keeps it
    save_markers(back, tmp_path / "again.npz")
    assert np.array_equal(mocapkit.io.load_markers(tmp_path / "again.npz").source.filled, res.fill_mask)
    # a mask of the wrong shape is refused, naming the file
    with np.load(tmp_path / "out.npz") as z:
        arrays = dict(z)
    arrays["filled"] = arrays["filled"][:5]
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(MocapFormatError, match="bad.npz.*filled"):
        mocapkit.io.load_markers(tmp_path / "bad.npz")


def test_a_marker_npz_keeps_which_points_are_modelled(shared_data, tmp_path):
    """A C3D written as a marker npz lost its modelled points: Plug-in Gait's 80 angles, forces, moments and powers
    (POINT:ANGLES, ...) and 78 modelled positions (segment axes, joint centres, centre of mass) read back as markers,
    to be cleaned as such. The npz's ``modelled`` array keeps each point's kind; a bad one is refused."""
    from mocapkit.io import load_markers, save_markers

    ms = load_markers(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d")
    assert int(np.sum(ms.quantities() != "")) == 80 and int(np.sum(ms.modelled())) == 158
    save_markers(ms, tmp_path / "pig.npz")
    back = load_markers(tmp_path / "pig.npz")
    assert np.array_equal(back.quantities(), ms.quantities()) and np.array_equal(back.modelled(), ms.modelled())
    assert np.array_equal(back.modelled_kinds(), ms.modelled_kinds())
    with np.load(tmp_path / "pig.npz") as z:
        arrays = dict(z)
    arrays["modelled"] = np.array(["angels"] * len(ms.labels))
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(MocapFormatError, match="npz modelled must be"):
        load_markers(tmp_path / "bad.npz")
    plain = read_c3d(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")  # CMU: markers only, no array
    assert not plain.modelled().any()
    save_markers(plain, tmp_path / "plain.npz")
    with np.load(tmp_path / "plain.npz") as z:
        assert "modelled" not in z.files


def test_a_bvh_saved_from_a_take_read_from_its_npz_keeps_the_bvhs_numbers_as_the_cli_does(tmp_path):
    """``mocapkit.save(mocapkit.load("x.npz"), "y.bvh")`` with no ``like=``: the numbers the .npz keeps of the BVH it
    was made from come back, as the command line (which passes the .npz as ``like``) writes them; a filled take too,
    its untouched cells the source's."""
    from mocapkit import corrupt
    from mocapkit.cleaning.gapfill import fill_motion

    src = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"  # Euler branches past 180
    x = tmp_path / "x.npz"
    mocapkit.save(mocapkit.load(src), x)
    holed = corrupt.gaps(mocapkit.load(x), seed=3, start_prob=0.01)[0]
    for name, take in (("y", mocapkit.load(x)), ("f", fill_motion(holed, method="linear"))):
        mocapkit.save(take, tmp_path / f"{name}.bvh")
        mocapkit.save(take, tmp_path / f"{name}_like.bvh", like=x)
        assert (tmp_path / f"{name}.bvh").read_bytes() == (tmp_path / f"{name}_like.bvh").read_bytes(), name
    got, want = (np.loadtxt(p.read_text().splitlines()[p.read_text().splitlines().index("MOTION") + 3:], ndmin=2)
                 for p in (tmp_path / "y.bvh", src))
    np.testing.assert_allclose(got, want, atol=1e-6)  # the file's own numbers, not a plain conversion's branch


def test_a_bvh_from_its_npz_gives_the_files_numbers_bit_for_bit(tmp_path):
    """A BVH written from the .npz made from a BVH wrote every number at 6 decimals, its own numbers included: 802
    of dataset-1_dash_normal_001's 2640 came back changed (5.1072e-06 as 0.000005); a number still the file's is
    now written exact, a changed one at ``precision``."""
    from mocapkit.io.bvh import source_values

    src = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"
    x = tmp_path / "x.npz"
    mocapkit.save(mocapkit.load(src), x)
    take = mocapkit.load(x)
    rot = np.array(take.rotations)
    rot[5, 3] = rot[6, 3]  # one cell changed: written at 6 decimals, the rest the file's
    changed = dataclasses.replace(take, rotations=rot)
    for name, m in (("same", take), ("changed", changed)):
        mocapkit.save(m, tmp_path / f"{name}.bvh", like=x)
    want = source_values(take, x)[0]
    got = mocapkit.load(tmp_path / "same.bvh")
    assert np.array_equal(source_values(got, tmp_path / "same.bvh")[0], want)
    text = (tmp_path / "changed.bvh").read_text().splitlines()
    lines = text[text.index("MOTION") + 3:]
    numbers = np.array([[float(t) for t in ln.split()] for ln in lines])
    differ = np.argwhere(numbers != want)
    assert len(differ) and set(differ[:, 0]) == {5}  # frame 5's changed joint alone
    assert "5.1072e-06" in lines[0].split()


def test_a_bvh_from_its_npz_keeps_the_files_header_text(tmp_path):
    """The header of a BVH written from an .npz was mocapkit's own: a CHANNELS line's trailing space, the OFFSETs'
    ``0.00000`` and a Frame Time as the file wrote it (``0.0333333``, read as 30 fps) came back otherwise. The .npz
    keeps the file's header, written while the take is on its skeleton and rate, and written anew once not."""
    for name in ("cmu_01_01_start.bvh", "dataset-1_dash_normal_001.bvh"):
        src = Path(__file__).resolve().parents[1] / "data" / name
        x = tmp_path / "x.npz"
        mocapkit.save(mocapkit.load(src), x, overwrite=True)
        take = mocapkit.load(x)
        mocapkit.save(take, tmp_path / "y.bvh", like=x, overwrite=True)
        lines, want = ((tmp_path / "y.bvh").read_bytes().splitlines(True), src.read_bytes().splitlines(True))
        at = next(i for i, t in enumerate(want) if t.startswith(b"Frame Time")) + 1
        assert lines[:at] == want[:at], name
    moved = dataclasses.replace(take, skeleton=dataclasses.replace(take.skeleton, offsets=take.skeleton.offsets * 2))
    mocapkit.save(moved, tmp_path / "z.bvh", like=x)
    assert mocapkit.load(tmp_path / "z.bvh").skeleton.offsets.tolist() == moved.skeleton.offsets.tolist()
    assert b"Frame Time: 0.03333333333333333" in (tmp_path / "z.bvh").read_bytes()  # the header written anew


def test_arrays_no_reader_reads_are_said_left_out(tmp_path):
    """An .npz holding arrays mocapkit does not read (a user's own beside the take, a reconstruction's
    ``licence`` ...) gave outputs without them and no word: convert and clean of it to .npz or .bvh, of a marker
    npz to .trc. Now a note names them; an npz of the format's own arrays alone gets none."""
    from mocapkit.io import marker_notes, motion_notes
    from mocapkit.io.npz import unread_arrays, write_npz

    data = Path(mocapkit.__file__).parent / "data"
    motion, markers = mocapkit.load(data / "131_01.bvh"), read_c3d(data / "Eb015pr.c3d")
    for take, plain in ((motion, tmp_path / "m.npz"), (markers, tmp_path / "k.npz")):
        write_npz(take, plain)
        added = tmp_path / f"added_{plain.name}"
        np.savez(added, **dict(np.load(plain)), my_labels=np.arange(3), notes=np.array("left foot taped"))
        assert unread_arrays(plain) == [] and unread_arrays(added) == ["my_labels", "notes"]
        read = mocapkit.load(added)
        for out in ("out.npz", "out.trc" if take is markers else "out.bvh"):
            notes = marker_notes(read, out, added) if take is markers else motion_notes(read, out, added)
            said = f"{out}: not written: 2 arrays of {added} that mocapkit does not read (my_labels, notes)"
            assert said in notes, notes
            plain_notes = marker_notes(read, out, plain) if take is markers else motion_notes(mocapkit.load(plain), out)
            assert not [n for n in plain_notes if "does not read" in n]


def test_clean_batch_names_a_marker_npz_s_unread_arrays(tmp_path):
    """clean-batch's row of a marker npz said what TRC or C3D leave out of it but not the npz's own arrays no
    reader reads (a motion npz's row did): now both kinds of take say them."""
    from mocapkit.batch import clean_batch
    from mocapkit.io.npz import write_npz

    src = tmp_path / "in"
    src.mkdir()
    write_npz(read_c3d(Path(mocapkit.__file__).parent / "data" / "Eb015pr.c3d")[:100], tmp_path / "e.npz")
    np.savez(src / "e.npz", **dict(np.load(tmp_path / "e.npz")), force=np.zeros(3))
    row, = clean_batch(src, tmp_path / "out", executor="serial", progress=False).rows
    assert row["status"] == "done", row
    assert any("not written: 1 array of" in w and w.endswith("that mocapkit does not read (force)")
               for w in row["file_notes"]), row["file_notes"]


def test_clean_batch_names_the_file_of_each_note_once(tmp_path):
    """User trial B (clean-batch on a folder of takes): a note naming the file it is about (what the output's
    format leaves out) was printed as a warning prefixed with the take's input, its output named after it as the
    worker saw it (``warning: in/e.npz: /abs/out/e.npz: not written: 1 array of /abs/in/e.npz ...``). It is
    printed as ``clean`` prints it, ``note: LINE``, each file named once, as the caller gave it."""
    from mocapkit.io.npz import write_npz
    from tests.cli import helpers

    (tmp_path / "in").mkdir()
    write_npz(read_c3d(Path(mocapkit.__file__).parent / "data" / "Eb015pr.c3d")[:100], tmp_path / "e.npz")
    np.savez(tmp_path / "in" / "e.npz", **dict(np.load(tmp_path / "e.npz")), force=np.zeros(3))
    code, out, err = helpers.run("clean-batch", "in", "out", "--executor", "serial", cwd=tmp_path)
    assert code == 0, (out, err)
    said = [line for line in out.splitlines() if "does not read" in line]
    assert said == ["note: out/e.npz: not written: 1 array of in/e.npz that mocapkit does not read (force)"], out
