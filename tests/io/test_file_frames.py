"""A take's frames as its file's: a slice written with the file's own lines, the numbers as the file gives them,
and what a BVH of an ASF take leaves out (its length unit)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.io import motion_notes

DATA = Path(__file__).resolve().parents[1] / "data"
FLIP = DATA / "dataset-2_raise-up-right-hand_active_060_flip.bvh"


def _bvh_parts(path):
    """(header lines up to Frame Time, frame lines) of a BVH without comment lines, line endings kept."""
    lines = open(path, encoding="utf-8", newline="").read().splitlines(keepends=True)
    at = next(i for i, t in enumerate(lines) if t.lstrip().startswith("Frame Time"))
    return lines[: at + 1], [t for t in lines[at + 1:] if t.strip()]


def _file_numbers(path):
    return np.array([[float(x) for x in t.split()] for t in _bvh_parts(path)[1]])


def test_a_bvh_slice_and_a_slice_of_it_are_written_with_the_files_lines(tmp_path):
    src = samples.path("131_01.bvh")  # CMU: "Frame Time: .0083333", 4-decimal numbers
    m = mocapkit.load(src)
    head, rows = _bvh_parts(src)
    for part, (a, b) in ((m[100:200], (100, 200)), (m[100:200][10:50], (110, 150)), (m[993], (993, 994))):
        out = tmp_path / f"s{a}.bvh"
        mocapkit.save(part, out)
        h, r = _bvh_parts(out)
        assert r == rows[a:b]  # every line byte for byte
        assert part.source_frames == range(a, b)
        assert h[-1] == head[-1] and h[-2].split() == ["Frames:", str(b - a)] and h[:-2] == head[:-2]
        back = mocapkit.load(out)
        assert np.array_equal(back.rotations, part.rotations) and back.fps == m.fps
    edited = m[100:200]
    rot = np.array(edited.rotations)
    rot[5, 3] = [1.0, 0.0, 0.0, 0.0]
    mocapkit.save(dataclasses.replace(edited, rotations=rot), tmp_path / "e.bvh")
    r = _bvh_parts(tmp_path / "e.bvh")[1]
    assert [k for k in range(100) if r[k] != rows[100 + k]] == [5]  # only the changed frame's line is new


def test_a_concatenation_resampling_or_strided_slice_is_written_whole(tmp_path):
    from mocapkit.motion import source_part

    m = mocapkit.load(samples.path("131_01.bvh"))
    _, rows = _bvh_parts(samples.path("131_01.bvh"))
    joined = mocapkit.concatenate([m[:100], m[200:300]])
    assert len(joined.source_frames) == 0 and source_part(joined, m.num_frames) is None
    for take in (joined, m.resample(60)[10:20], m[::2][5:10]):
        assert source_part(take, m.num_frames) is None
        mocapkit.save(take, tmp_path / "w.bvh")
        mocapkit.save(take, tmp_path / "whole.bvh", like=False)
        assert (tmp_path / "w.bvh").read_bytes() == (tmp_path / "whole.bvh").read_bytes()
    chained = mocapkit.concatenate([m[100:150], m[150:200]])  # consecutive slices: the file's frames 100-199
    assert chained.source_frames == range(100, 200)
    mocapkit.save(chained, tmp_path / "c.bvh")
    assert _bvh_parts(tmp_path / "c.bvh")[1] == rows[100:200]


def test_an_amc_slice_is_written_with_the_files_frame_blocks(tmp_path):
    src = samples.path("12_walk.amc")  # CMU: CRLF, a #!OML:ASF line, frames numbered from 1
    m = mocapkit.load(src)
    lines = open(src, encoding="latin-1", newline="").read().splitlines(keepends=True)
    part = m[10:40][5:25]  # the file's frames 15-34, numbered 16-35 in the file
    mocapkit.save(part, tmp_path / "p.amc")
    out = open(tmp_path / "p.amc", encoding="latin-1", newline="").read().splitlines(keepends=True)
    first, start, stop = lines.index("1\r\n"), lines.index("16\r\n"), lines.index("36\r\n")
    assert out == lines[:first] + lines[start:stop]  # the header and those frames' blocks, byte for byte
    back = mocapkit.load(tmp_path / "p.amc", asf=samples.path("12.asf"))
    assert np.array_equal(back.rotations, part.rotations) and np.array_equal(back.root_positions, part.root_positions)


def test_written_values_are_the_files_numbers_where_channel_values_wrap():
    from mocapkit.io.bvh import written_values

    m = mocapkit.load(FLIP)  # Bandai: 8 cells written past 180 degrees
    file = _file_numbers(FLIP)
    assert np.abs(m.channel_values() - file).max() == pytest.approx(360.0)
    assert np.array_equal(written_values(m), file)
    assert np.array_equal(written_values(m[10:30]), file[10:30])


def test_written_values_of_cmu_01_01_are_the_files(shared_data):
    from mocapkit.io.bvh import written_values

    path = shared_data / "cmu_bvh" / "01_01.bvh"  # Hips written on other branches than the plain conversion's
    m = mocapkit.load(path)
    file = _file_numbers(path)
    assert int((np.abs(m.channel_values() - file) > 1e-6).sum()) > 2000
    assert np.abs(written_values(m) - file).max() <= 1e-9
    assert np.abs(written_values(m[1200:1300]) - file[1200:1300]).max() <= 1e-9


def test_a_bvh_of_an_asf_take_says_it_leaves_out_the_length_unit(tmp_path):
    h = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    out = tmp_path / "h.bvh"
    note = next((n for n in motion_notes(h, out) if "length unit" in n), None)
    assert note == (f"{out}: not written: the length unit, 5.644 cm (stated by {samples.path('HDM_bk.asf')}): "
                    "a BVH has no field for it, a reader guesses it from the bones (an .npz keeps it)")
    from mocapkit.io import unit_note

    assert note == unit_note(h, out)
    assert unit_note(h, tmp_path / "h.npz") is None and unit_note(h, tmp_path / "h.amc") is None
    assert unit_note(mocapkit.load(samples.path("131_01.bvh")), out) is None  # a BVH states no unit to lose


def test_a_slice_keeps_the_comments_among_its_frames_and_says_how_many_it_leaves_out(tmp_path):
    lines = open(samples.path("131_01.bvh"), encoding="utf-8", newline="").read().splitlines(keepends=True)
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    src = tmp_path / "c.bvh"
    src.write_text("".join(lines[:1] + ["# header\n"] + lines[1:at + 5] + ["# 5\n"] + lines[at + 5:at + 150] + ["# 150\n"]
                           + lines[at + 150:] + ["# end\n"]), encoding="utf-8", newline="")
    m = mocapkit.load(src)
    for part, kept in ((m[100:200], ["# header", "# 150"]), (m[900:], ["# header", "# end"])):
        mocapkit.save(part, tmp_path / "o.bvh")
        assert [t.strip() for t in open(tmp_path / "o.bvh", encoding="utf-8") if t.startswith("#")] == kept
        assert motion_notes(part, tmp_path / "o.bvh") == [f"{tmp_path / 'o.bvh'}: not written: 2 comment lines of {src} "
                                                          "(a slice keeps the header's and those among its own frames)"]
