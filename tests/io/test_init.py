"""``mocapkit.io``'s entry points: ``load`` and ``load_markers`` given what is not one file."""

import pytest

from mocapkit.errors import MocapFormatError
from mocapkit.io import load, load_markers, save_markers

from .bounded import refusal_of_load


@pytest.mark.parametrize("name", ["takes", "takes.c3d"])
def test_a_folder_is_refused_as_a_folder(tmp_path, name):
    # `mocapkit info FOLDER` said "unknown suffix '(none)' for reading"
    folder = tmp_path / name
    folder.mkdir()
    assert refusal_of_load(folder) == (f"{folder}: a folder, not a file: give one of the files in it "
                                       "(.amc, .bvh, .c3d, .npz, .trc)")
    with pytest.raises(MocapFormatError) as exc:
        load_markers(folder)
    assert str(exc.value) == f"{folder}: a folder, not a file: give one of the files in it (.c3d, .npz, .trc)"
    with pytest.raises(MocapFormatError, match="no such file"):
        load(folder / "missing.bvh")


def test_save_writes_a_marker_set_by_its_suffix(tmp_path):
    # `mocapkit.save(markers, "x.c3d")` said "unknown suffix '.c3d' for writing; known: .amc, .bvh, .npz"
    import numpy as np

    from mocapkit import samples
    from mocapkit.io import save

    ms = load(samples.path("Eb015pr.c3d"))
    for suffix in (".c3d", ".trc", ".npz"):
        back = load(save(ms, tmp_path / f"m{suffix}"))
        assert back.labels == ms.labels and np.allclose(back.positions, ms.positions, equal_nan=True, atol=1e-3)


def test_save_keeps_the_text_of_the_file_the_take_was_read_from(tmp_path):
    """`mocapkit.save(result.motion, "x.bvh")` (the README's recipe) rewrote every line of an untouched take (other
    number text, other Euler branches) where the CLI kept them: a take remembers its file, and save writes like it."""
    import dataclasses

    import numpy as np

    import mocapkit
    from mocapkit import samples

    src = samples.path("131_01.bvh")
    res = mocapkit.clean(src, steps="fill")  # nothing to fill: the take as read
    assert res.motion.source_file == str(src.resolve())
    out = mocapkit.save(res.motion, tmp_path / "same.bvh")
    assert out.read_bytes() == src.read_bytes()
    m = mocapkit.load(src)
    rot = np.array(m.rotations)
    rot[7, 3] = [0.0, 1.0, 0.0, 0.0]
    mocapkit.save(dataclasses.replace(m, rotations=rot), tmp_path / "one.bvh")
    a, b = src.read_text().splitlines(), (tmp_path / "one.bvh").read_text().splitlines()
    assert len(a) == len(b) and sum(x != y for x, y in zip(a, b)) == 1
    whole = mocapkit.save(m, tmp_path / "whole.bvh", like=False)  # written whole, as a take made in Python
    assert whole.read_bytes() != src.read_bytes()
    assert np.degrees(mocapkit.rotations.geodesic_angle(mocapkit.load(whole).rotations, m.rotations)).max() < 1e-4
    with pytest.raises(TypeError, match="like must be a path"):
        mocapkit.save(m, tmp_path / "x.bvh", like=1)


def test_an_amc_saved_from_python_gets_its_asf_beside_it(tmp_path):
    """An AMC written by `mocapkit.save` could not be read back (no ASF beside it): the ASF the take was read with is
    copied there first, as the CLI does, and the AMC keeps its input's text."""
    import mocapkit
    from mocapkit import samples

    src = samples.path("12_walk.amc")
    m = mocapkit.load(src)
    assert m.skeleton.source_file == str((src.parent / "12.asf").resolve())
    out = mocapkit.save(m[:], tmp_path / "walk_clean.amc")
    assert out.read_bytes() == src.read_bytes()
    assert (tmp_path / "walk_clean.asf").read_bytes() == (src.parent / "12.asf").read_bytes()
    back = mocapkit.load(out)
    assert back.num_frames == m.num_frames
    other = tmp_path / "other"
    mocapkit.save(m, other / "12_walk.amc", copy_asf=False)
    with pytest.raises(MocapFormatError, match="no skeleton"):
        mocapkit.load(other / "12_walk.amc")
    assert mocapkit.load(other / "12_walk.amc", asf=src.parent / "12.asf").num_frames == m.num_frames


def test_save_never_replaces_a_differing_asf_it_was_not_asked_for(tmp_path):
    """`mocapkit.save(walk, "12_walk_clean.amc")` (the README's line) replaced a user's edited `12.asf` beside the
    output with the take's skeleton: the ASF is replaced only with an explicit `overwrite=True`, and the refusal
    names the library's parameter, not the CLI's flag."""
    import mocapkit
    from mocapkit import samples

    src = samples.path("12_walk.amc")
    walk = mocapkit.load(src)
    edited = (src.parent / "12.asf").read_bytes() + b"# my edited skeleton\n"
    (tmp_path / "12.asf").write_bytes(edited)
    with pytest.raises(MocapFormatError, match="pass overwrite=True") as exc:
        mocapkit.save(walk, tmp_path / "12_walk_clean.amc")
    assert "--overwrite" not in str(exc.value)
    assert (tmp_path / "12.asf").read_bytes() == edited
    assert not (tmp_path / "12_walk_clean.amc").exists()
    mocapkit.save(walk, tmp_path / "12_walk_clean.amc", overwrite=True)  # asked for: replaced, as --overwrite does
    assert (tmp_path / "12.asf").read_bytes() == (src.parent / "12.asf").read_bytes()


def test_save_markers_refuses_an_existing_file_and_its_like(tmp_path):
    """`save_markers(m, its_input)` rewrote the capture as floats without being asked: an existing file is
    refused unless overwrite=True, and the file given as like= is refused always."""
    import shutil

    from mocapkit import samples
    from mocapkit.io import save_markers

    c3d = tmp_path / "take.c3d"
    shutil.copy(samples.path("Eb015pr.c3d"), c3d)
    before = c3d.read_bytes()
    ms = load(c3d)
    with pytest.raises(MocapFormatError, match="already exists; pass overwrite=True"):
        save_markers(ms, c3d)
    with pytest.raises(MocapFormatError, match="like="):
        save_markers(ms, c3d, like=c3d, overwrite=True)
    assert c3d.read_bytes() == before
    out = save_markers(ms, tmp_path / "out.trc")
    save_markers(ms, out, overwrite=True)
    with pytest.raises(MocapFormatError, match="already exists"):
        save_markers(ms, out)


@pytest.mark.parametrize("name,kwargs,wrong", [("131_01.bvh", {"fps": 30}, "fps="),
                                               ("Eb015pr.c3d", {"fps": 30, "asf": "x.asf"}, "fps=, asf="),
                                               ("12_walk.amc", {"units": "mm"}, "units=")])
def test_a_keyword_the_formats_reader_does_not_take_is_refused_in_one_line(name, kwargs, wrong):
    """Trial T1: load(bvh, fps=30) raised "TypeError: read_bvh() got an unexpected keyword argument 'fps'", which
    `except MocapError` misses; now one line naming the file and which keyword fits which format."""
    from mocapkit import samples

    path = samples.path(name)
    suffix = name.rsplit(".", 1)[1]
    with pytest.raises(MocapFormatError) as exc:
        load(path, **kwargs)
    assert str(exc.value) == (f"{path}: load takes no {wrong} for .{suffix} files; the keywords by format: .amc: asf=, "
                              "fps=, dofs=; .bvh, .npz: none; .c3d, .trc: zeros_as_gaps=, units=")


@pytest.mark.parametrize("name,kwargs,wrong", [("Eb015pr.c3d", {"fps": 30}, "fps="), ("walk.trc", {"asf": "x"}, "asf="),
                                               ("walk.npz", {"zeros_as_gaps": True}, "zeros_as_gaps=")])
def test_load_markers_refuses_a_keyword_its_reader_does_not_take_in_one_line(tmp_path, name, kwargs, wrong):
    """load_markers(c3d, fps=30) raised a raw TypeError (a marker npz: a TypeError of its own), which
    `except MocapError` misses; now the one line of :func:`load`, by marker format."""
    from mocapkit import samples

    path = samples.path("Eb015pr.c3d")
    if not name.endswith(".c3d"):  # the same markers as a TRC and a marker npz
        path = save_markers(load_markers(path)[:5], tmp_path / name)
    with pytest.raises(MocapFormatError) as exc:
        load_markers(path, **kwargs)
    assert str(exc.value) == (f"{path}: load_markers takes no {wrong} for {path.suffix} files; the keywords by format: "
                              ".c3d, .trc: zeros_as_gaps=, units=; .npz: none")
