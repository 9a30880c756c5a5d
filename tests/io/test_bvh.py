"""BVH reading and writing: real files, round trips, an independent FK oracle, edge cases, bad files."""

from tests.shared import curated_files
import dataclasses
from pathlib import Path
import os
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mocapkit
from mocapkit.errors import MocapFormatError
from mocapkit.io.bvh import read_bvh, write_bvh
from mocapkit.motion import Motion, Skeleton
from mocapkit.rotations import euler_to_quaternion, geodesic_angle, quaternion_multiply, quaternion_normalize
from tests.naive import naive_bvh_fk, naive_bvh_parse
from tests.io.bounded import refusal_of_load, run_bounded


def skeleton_size(m: Motion) -> float:
    rest = m.skeleton.rest_positions(end_sites=True)
    return float(np.linalg.norm(np.ptp(rest, axis=0)))


def assert_same_motion(a: Motion, b: Motion, pos_tol: float = 1e-6):
    """Rotations within 1e-4 degrees, root positions / translations within ``pos_tol``, same FK."""
    assert a.num_frames == b.num_frames
    assert a.fps == b.fps
    assert a.skeleton.joint_names == b.skeleton.joint_names
    np.testing.assert_array_equal(a.skeleton.parents, b.skeleton.parents)
    np.testing.assert_array_equal(a.skeleton.offsets, b.skeleton.offsets)
    np.testing.assert_array_equal(a.skeleton.end_site_parents, b.skeleton.end_site_parents)
    np.testing.assert_array_equal(a.skeleton.end_site_offsets, b.skeleton.end_site_offsets)
    ang = np.degrees(geodesic_angle(a.rotations, b.rotations))
    assert np.array_equal(np.isnan(ang), np.isnan(a.rotations).any(-1))
    assert np.nanmax(ang, initial=0.0) < 1e-4
    np.testing.assert_allclose(a.root_positions, b.root_positions, rtol=0, atol=pos_tol)
    np.testing.assert_allclose(a.local_offsets(), b.local_offsets(), rtol=0, atol=pos_tol)
    assert (a.translations is None) == (b.translations is None)
    # 1e-4 degrees of rotation error at most moves a point by size * 1.7e-6; files keep 6 decimals
    tol = 1e-7 * skeleton_size(a) + 2 * pos_tol
    np.testing.assert_allclose(a.global_positions(end_sites=True), b.global_positions(end_sites=True), rtol=0, atol=tol)


def round_trip(m: Motion, tmp_path, **kw) -> Motion:
    out = tmp_path / f"{m.name or 'clip'}_rt.bvh"
    write_bvh(m, out, **kw)
    return read_bvh(out)


def check_fk_against_naive(path, m: Motion, frames):
    naive = naive_bvh_fk(path, frames)
    ours = m.global_positions(end_sites=True)[frames]
    tol = 1e-9 * skeleton_size(m)
    np.testing.assert_allclose(ours, naive, rtol=0, atol=tol)


# -- real files ---------------------------------------------------------------------


def test_every_bvh_in_shared_data_round_trips(shared_data, tmp_path):
    files = curated_files(shared_data, "*.bvh")
    assert files
    for f in files:
        m = read_bvh(f)
        _, _, frames, _ = naive_bvh_parse(f)
        assert m.num_frames == len(frames) and m.name == f.stem
        assert m.skeleton.channels is not None
        assert_same_motion(m, round_trip(m, tmp_path))
        # the written file keeps the file's own channel layout
        assert read_bvh(tmp_path / f"{m.name}_rt.bvh").skeleton.channels == m.skeleton.channels


def check_fused_conversion(path):
    """The reader's numba conversion agrees with the numpy reference route (Motion.from_channel_values)."""
    m = read_bvh(path)
    raw = np.array(naive_bvh_parse(path)[2])
    ref = Motion.from_channel_values(m.skeleton, raw, m.fps, name=m.name, animated_offsets=True)
    np.testing.assert_allclose(m.rotations, ref.rotations, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(m.root_positions, ref.root_positions)
    assert (m.translations is None) == (ref.translations is None)
    np.testing.assert_array_equal(m.local_offsets(), ref.local_offsets())


def test_fused_conversion_on_shared_data(shared_data):
    for f in curated_files(shared_data, "*.bvh"):
        check_fused_conversion(f)


def test_fused_conversion_on_sample_and_odd_layouts(tmp_path, rng):
    check_fused_conversion(mocapkit.samples.path("131_01.bvh"))
    odd = tmp_path / "odd.bvh"
    odd.write_text(bvh_text(ODD, odd_rows(rng).tolist()))
    check_fused_conversion(odd)


def test_shared_data_facts(shared_data):
    cmu = read_bvh(shared_data / "cmu_bvh" / "01_01.bvh")
    assert (cmu.num_frames, cmu.num_joints, cmu.fps) == (2752, 31, 120.0)
    assert cmu.translations is None and cmu.skeleton.num_end_sites == 7  # head, 2 thumbs, 2 hands, 2 toes
    for f in sorted((shared_data / "secondary_bandai_namco_CC-BY-NC").glob("*.bvh")):
        m = read_bvh(f)
        assert m.fps == 30.0 and m.num_joints == 22 and m.translations is not None
        assert all(len(c) == 6 for c in m.skeleton.channels)


def test_bundled_sample_round_trips(tmp_path):
    path = mocapkit.samples.path("131_01.bvh")
    m = mocapkit.load(path)
    assert (m.num_frames, m.num_joints, m.fps, m.name) == (994, 31, 120.0, "131_01")
    assert_same_motion(m, round_trip(m, tmp_path))
    out = tmp_path / "via_save.bvh"
    assert mocapkit.save(m, out) == out
    assert_same_motion(m, mocapkit.load(out))


def test_round_trip_is_stable_on_second_write(tmp_path):
    m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    a = tmp_path / "a.bvh"
    b = tmp_path / "b.bvh"
    write_bvh(m, a)
    write_bvh(read_bvh(a), b)
    assert a.read_text().split("MOTION")[1] == b.read_text().split("MOTION")[1]


# -- FK oracle ----------------------------------------------------------------------


def test_fk_matches_naive_matrices_on_shared_data(shared_data):
    for f in curated_files(shared_data, "*.bvh"):
        m = read_bvh(f)
        F = m.num_frames
        check_fk_against_naive(f, m, sorted({0, 1, F // 3, F // 2, F - 1}))


def test_fk_matches_naive_matrices_on_sample():
    path = mocapkit.samples.path("131_01.bvh")
    m = read_bvh(path)
    check_fk_against_naive(path, m, [0, 1, 100, 500, 993])


# -- edge cases ----------------------------------------------------------------------


def bvh_text(blocks: str, rows, frame_time="0.0333333", frames=None) -> str:
    lines = ["HIERARCHY", blocks.strip("\n"), "MOTION", f"Frames: {len(rows) if frames is None else frames}",
             f"Frame Time: {frame_time}"]
    lines += [" ".join(str(v) for v in r) for r in rows]
    return "\n".join(lines) + "\n"


ODD = """ROOT Hips
{
  OFFSET 1.5 -2 3
  CHANNELS 6 Yposition Xrotation Zposition Zrotation Xposition Yrotation
  JOINT One
  {
    OFFSET 0 10 0
    CHANNELS 1 Yrotation
    JOINT Two
    {
      OFFSET 2 3 -1
      CHANNELS 2 Xrotation Zrotation
      End Site
      {
        OFFSET 0 4 0
      }
    }
  }
  JOINT Three
  {
    OFFSET -3 0 1
    CHANNELS 3 Yposition Xrotation Zposition
    End Site
    {
      OFFSET 1 1 1
    }
  }
  JOINT Still
  {
    OFFSET 0 -5 0
    CHANNELS 0
    JOINT Six
    {
      OFFSET 0.5 0.5 0.5
      CHANNELS 6 Zposition Yrotation Xposition Xrotation Yposition Zrotation
      End Site
      {
        OFFSET 0 0 2
      }
    }
  }
}"""
ODD_NCOLS = 6 + 1 + 2 + 3 + 0 + 6


def odd_rows(rng, n=7):
    return np.round(rng.uniform(-170, 170, size=(n, ODD_NCOLS)), 4)


def test_odd_channel_orders_match_naive_fk(tmp_path, rng):
    rows = odd_rows(rng)
    path = tmp_path / "odd.bvh"
    path.write_text(bvh_text(ODD, rows.tolist()))
    m = read_bvh(path)
    sk = m.skeleton
    assert sk.joint_names == ("Hips", "One", "Two", "Three", "Still", "Six")
    assert sk.parents.tolist() == [-1, 0, 1, 0, 0, 4]
    assert [len(c) for c in sk.channels] == [6, 1, 2, 3, 0, 6]
    assert sk.rotation_order(0) == "XZY" and sk.rotation_order(2) == "XZ" and sk.rotation_order(3) == "X"
    assert sk.end_site_parents.tolist() == [2, 3, 5]
    np.testing.assert_array_equal(sk.end_site_offsets, [[0, 4, 0], [1, 1, 1], [0, 0, 2]])
    # root position channels replace the OFFSET; joint "Three" keeps its OFFSET x, takes y and z from channels
    np.testing.assert_array_equal(m.root_positions, rows[:, [4, 0, 2]])
    assert m.translations is not None
    np.testing.assert_array_equal(m.translations[:, 3], np.stack([np.full(7, -3.0), rows[:, 9], rows[:, 11]], 1))
    np.testing.assert_array_equal(m.translations[:, 5], rows[:, [14, 16, 12]])
    np.testing.assert_array_equal(m.translations[:, 1], np.broadcast_to([0.0, 10.0, 0.0], (7, 3)))
    np.testing.assert_array_equal(m.rotations[:, 4], np.broadcast_to([1.0, 0, 0, 0], (7, 4)))
    check_fk_against_naive(path, m, list(range(7)))
    # channel values come back as the file wrote them: positions exactly, 1- and 2-axis rotations too (they have
    # no third-axis component); 3-axis rotations may come back as the other Euler solution of the same rotation
    exact_cols = [0, 2, 4, 6, 7, 8, 9, 10, 11, 12, 14, 16]
    np.testing.assert_allclose(m.channel_values()[:, exact_cols], rows[:, exact_cols], rtol=0, atol=1e-9)
    back = round_trip(m, tmp_path)
    assert back.skeleton.channels == sk.channels
    assert_same_motion(m, back)
    check_fk_against_naive(tmp_path / "odd_rt.bvh", back, list(range(7)))


def test_tabs_crlf_and_scientific_notation(tmp_path, rng):
    rows = odd_rows(rng, 4)
    plain = bvh_text(ODD, rows.tolist())
    p1 = tmp_path / "plain.bvh"
    p1.write_text(plain)
    # same numbers in scientific notation, tabs for indentation and between values, CRLF line ends
    sci = plain.split("Frame Time: 0.0333333\n")[0] + "Frame Time: 3.33333e-002\n"
    sci += "".join("\t".join(f"{v:.6e}" for v in r) + " \t\n" for r in rows)
    sci = re.sub(r"^ +", lambda mm: "\t" * (len(mm.group()) // 2), sci, flags=re.M).replace("\n", "\r\n")
    p2 = tmp_path / "sci_tabs_crlf.bvh"
    p2.write_bytes(sci.encode())
    a, b = read_bvh(p1), read_bvh(p2)
    assert b.fps == 30.0
    np.testing.assert_array_equal(a.channel_values(), b.channel_values())
    np.testing.assert_array_equal(a.global_positions(True), b.global_positions(True))
    tiny = tmp_path / "tiny.bvh"
    tiny.write_text(bvh_text("ROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n}",
                             [["3.64024e-015", "1E+2", "-.5e1"], ["+1.", ".0083", "-0"]]))
    np.testing.assert_array_equal(read_bvh(tiny).root_positions, [[3.64024e-15, 100.0, -5.0], [1.0, 0.0083, -0.0]])


def test_blank_lines_and_trailing_spaces_in_motion(tmp_path):
    text = bvh_text("ROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n}", [[1, 2, 3], [4, 5, 6]])
    text = text.replace("1 2 3\n", "1 2 3   \n\n   \n")
    (tmp_path / "blank.bvh").write_text(text + "\n\n")
    np.testing.assert_array_equal(read_bvh(tmp_path / "blank.bvh").root_positions, [[1, 2, 3], [4, 5, 6]])


@pytest.mark.parametrize(
    "offset, channels, expect",
    [
        ("OFFSET 0 0 0", "CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation", "channels"),
        ("OFFSET 10 20 30", "CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation", "channels"),
        ("OFFSET 10 20 30", "CHANNELS 3 Zrotation Yrotation Xrotation", "offset"),
        ("", "CHANNELS 3 Zrotation Yrotation Xrotation", "zero"),
        ("", "CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation", "channels"),
    ],
)
def test_root_offset_and_position_channels(tmp_path, offset, channels, expect):
    n = int(channels.split()[1])
    rows = [[float(k + 3 * f) for k in range(n)] for f in range(3)]
    blocks = f"ROOT Hips\n{{\n{offset}\n{channels}\nJOINT Leg\n{{\nOFFSET 0 -4 0\nCHANNELS 1 Xrotation\n}}\n}}"
    path = tmp_path / "root.bvh"
    path.write_text(bvh_text(blocks, [r + [30.0] for r in rows]))
    m = read_bvh(path)
    if expect == "channels":
        np.testing.assert_array_equal(m.root_positions, np.array(rows)[:, :3])
    elif expect == "offset":
        np.testing.assert_array_equal(m.root_positions, np.broadcast_to([10.0, 20.0, 30.0], (3, 3)))
    else:
        np.testing.assert_array_equal(m.root_positions, np.zeros((3, 3)))
    assert m.translations is None
    check_fk_against_naive(path, m, [0, 1, 2])
    assert_same_motion(m, round_trip(m, tmp_path))


@pytest.mark.parametrize(
    "frame_time, fps", [
        (".0083333", 120.0), ("0.0333333", 30.0), ("0.04", 25.0), ("1", 1.0), ("8.3333e-03", 120.0),
        ("0.0104167", 96.0), ("0.0125001", 1 / 0.0125001), ("0.1234", 1 / 0.1234),
        # NTSC rates at the digits shown (29.97 written to 6 or 7 decimals), not 29.9697
        ("0.033367", 30000 / 1001), ("0.0333667", 30000 / 1001), ("0.03337", 30000 / 1001),
        ("0.016683", 60000 / 1001), ("0.041708", 24000 / 1001), ("0.0333", 1 / 0.0333),
    ]
)
def test_frame_time_to_fps(tmp_path, frame_time, fps):
    path = tmp_path / "ft.bvh"
    path.write_text(bvh_text("ROOT r\n{\nCHANNELS 1 Xposition\n}", [[1.0]], frame_time=frame_time))
    assert read_bvh(path).fps == fps


@pytest.mark.parametrize("fps", [29.97, 30000 / 1001, 59.94, 60000 / 1001, 119.88, 23.976, 50.5, 2000.0, 120.0])
def test_a_rate_mocapkit_writes_reads_back_exactly(tmp_path, fps):
    """The writer prints 1 / fps in full (repr); 1 / that is not always fps (29.970000000000002): the reader takes
    the rate with fewest decimals whose 1 / fps is the number printed."""
    src = mocapkit.samples.path("131_01.bvh")
    m = dataclasses.replace(read_bvh(src), fps=fps)
    out = tmp_path / "r.bvh"
    write_bvh(m, out)
    assert read_bvh(out).fps == fps
    same = tmp_path / "same.bvh"
    write_bvh(read_bvh(src), same, like=src)
    assert same.read_bytes() == src.read_bytes()  # an untouched BVH keeps its Frame Time text


def test_nan_values_read_and_write(tmp_path, rng):
    rows = odd_rows(rng, 5).astype(object)
    rows[1, 0] = "nan"  # root Yposition
    rows[3, 7] = "NaN"  # joint Two Xrotation
    path = tmp_path / "gaps.bvh"
    path.write_text(bvh_text(ODD, rows.tolist()))
    m = read_bvh(path)
    assert np.isnan(m.root_positions[1, 1]) and not np.isnan(m.root_positions[[0, 2, 3, 4]]).any()
    assert np.isnan(m.rotations[3, 2]).all() and np.isnan(m.rotations).any(-1).sum() == 1
    assert m.missing().sum() == 2
    back = round_trip(m, tmp_path, allow_nan=True)
    assert "nan" in (tmp_path / "gaps_rt.bvh").read_text()
    assert_same_motion(m, back)
    np.testing.assert_array_equal(np.isnan(back.root_positions), np.isnan(m.root_positions))


def test_writing_nan_without_allow_nan_raises_and_leaves_no_file(tmp_path, rng):
    m = read_bvh(mocapkit.samples.path("131_01.bvh"))[:20]
    rot = np.array(m.rotations)
    rot[[3, 7], 4] = np.nan
    bad = Motion(m.skeleton, rot, m.root_positions, m.fps, "gappy")
    out = tmp_path / "gappy.bvh"
    with pytest.raises(MocapFormatError, match=r"missing values \(NaN\) in 2 frames; fill them or save as \.npz") as e:
        write_bvh(bad, out)
    assert "gappy.bvh" in str(e.value)
    assert not out.exists() and os.listdir(tmp_path) == []
    # an existing file is left untouched
    write_bvh(m, out)
    before = out.read_bytes()
    with pytest.raises(MocapFormatError):
        mocapkit.save(bad, out)
    assert out.read_bytes() == before and os.listdir(tmp_path) == ["gappy.bvh"]


def test_written_angles_are_unwrapped(tmp_path):
    F = 200
    sk = Skeleton(("root", "spin"), [-1, 0], [[0, 0, 0], [0, 1, 0]], channels=(("Xposition", "Yposition", "Zposition"),
                                                                                ("Zrotation", "Yrotation", "Xrotation")))
    angles = np.zeros((F, 3))
    angles[:, 0] = np.linspace(0, 1000, F)  # about Z, several turns
    angles[:, 2] = np.linspace(0, -400, F)  # about X
    rot = np.stack([np.tile([1.0, 0, 0, 0], (F, 1)), euler_to_quaternion(angles, "ZYX")], axis=1)
    m = Motion(sk, rot, np.zeros((F, 3)), 60.0, "spin")
    path = tmp_path / "spin.bvh"
    write_bvh(m, path)
    _, _, frames, _ = naive_bvh_parse(path)
    cols = np.array(frames)[:, 3:]
    assert np.abs(np.diff(cols, axis=0)).max() < 30.0
    assert_same_motion(m, read_bvh(path))


def test_asf_style_skeleton_is_written_as_zyx(tmp_path, rng):
    J = 4
    axes = quaternion_normalize(rng.normal(size=(J, 4)))
    chans = (
        ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"),
        ("Xrotation", "Zrotation"),
        (),
        ("Yrotation",),
    )
    sk = Skeleton(("root", "a", "b", "c"), [-1, 0, 1, 1], rng.normal(size=(J, 3)), [2, 3], rng.normal(size=(2, 3)),
                  channels=chans, axes=axes)
    values = np.concatenate([rng.normal(size=(9, 3)) * 10, rng.uniform(-90, 90, size=(9, 6))], axis=1)
    m = Motion.from_channel_values(sk, values, fps=120.0, name="asf")
    path = tmp_path / "asf.bvh"
    write_bvh(m, path)
    back = read_bvh(path)
    assert back.skeleton.axes is None
    assert back.skeleton.channels == (
        ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),
        ("Zrotation", "Yrotation", "Xrotation"),
        (),
        ("Zrotation", "Yrotation", "Xrotation"),
    )
    assert_same_motion(m, back)


def test_breadth_first_skeleton_is_written_depth_first(tmp_path, rng):
    # ASF hierarchies may list joints breadth first: 0 -> (1, 2), 1 -> 3, 2 -> 4
    names = ("root", "l1", "r1", "l2", "r2")
    sk = Skeleton(names, [-1, 0, 0, 1, 2], rng.normal(size=(5, 3)), [3, 4], rng.normal(size=(2, 3)))
    F = 6
    rot = quaternion_normalize(rng.normal(size=(F, 5, 4)))
    m = Motion(sk, rot, rng.normal(size=(F, 3)), 120.0, "bfs")
    path = tmp_path / "bfs.bvh"
    write_bvh(m, path)
    back = read_bvh(path)
    assert back.skeleton.joint_names == ("root", "l1", "l2", "r1", "r2")
    perm = [names.index(n) for n in back.skeleton.joint_names]
    assert back.skeleton.parents.tolist() == [-1, 0, 1, 0, 3]
    np.testing.assert_array_equal(back.skeleton.offsets, sk.offsets[perm])
    assert np.degrees(geodesic_angle(back.rotations, m.rotations[:, perm])).max() < 1e-4
    np.testing.assert_allclose(back.global_positions(), m.global_positions()[:, perm], atol=1e-5)
    np.testing.assert_allclose(back.end_site_positions(), m.end_site_positions(), atol=1e-5)
    check_fk_against_naive(path, back, list(range(F)))


def test_animated_offsets_are_written_even_without_position_channels(tmp_path, rng):
    m = read_bvh(mocapkit.samples.path("131_01.bvh"))[:10]
    tr = np.array(m.local_offsets())
    tr[:, 5] += rng.normal(size=(10, 3))
    moved = Motion(m.skeleton, m.rotations, m.root_positions, m.fps, "moved", translations=tr)
    back = round_trip(moved, tmp_path)
    assert back.skeleton.channels[5][:3] == ("Xposition", "Yposition", "Zposition")
    assert_same_motion(moved, back)


@given(st.lists(st.floats(-1e4, 1e4, allow_nan=False), min_size=6, max_size=6), st.integers(3, 8))
@settings(max_examples=30, deadline=None)
def test_precision_bounds_round_trip_error(tmp_path_factory, row, precision):
    path = tmp_path_factory.mktemp("prec") / "p.bvh"
    path.write_text(bvh_text("ROOT r\n{\nCHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation\n}",
                             [row]))
    m = read_bvh(path)
    write_bvh(m, path, precision=precision)
    back = read_bvh(path)
    assert np.abs(back.root_positions - m.root_positions).max() <= 0.5 * 10.0**-precision * (1 + 1e-9) + 1e-9
    # three angles each rounded by at most half a unit of the last decimal
    assert np.degrees(geodesic_angle(back.rotations, m.rotations)).max() <= 1.5 * 10.0**-precision + 1e-9


# -- bad files ---------------------------------------------------------------------

GOOD_LINES = [
    "HIERARCHY",                                                                  # 1
    "ROOT Hips",                                                                  # 2
    "{",                                                                          # 3
    "\tOFFSET 0 0 0",                                                             # 4
    "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation",   # 5
    "\tJOINT Spine",                                                              # 6
    "\t{",                                                                        # 7
    "\t\tOFFSET 0 10 0",                                                          # 8
    "\t\tCHANNELS 3 Zrotation Yrotation Xrotation",                               # 9
    "\t\tEnd Site",                                                               # 10
    "\t\t{",                                                                      # 11
    "\t\t\tOFFSET 0 5 0",                                                         # 12
    "\t\t}",                                                                      # 13
    "\t}",                                                                        # 14
    "}",                                                                          # 15
    "MOTION",                                                                     # 16
    "Frames: 3",                                                                  # 17
    "Frame Time: 0.0333333",                                                      # 18
    "0 90 0 1 2 3 4 5 6",                                                         # 19
    "0 91 0 1 2 3 4 5 6",                                                         # 20
    "0 92 0 1 2 3 4 5 6",                                                         # 21
]


def test_good_template_reads(tmp_path):
    path = tmp_path / "good.bvh"
    path.write_text("\n".join(GOOD_LINES) + "\n")
    m = read_bvh(path)
    assert m.num_frames == 3 and m.num_joints == 2 and m.skeleton.num_end_sites == 1


def _edit(lines, replace=None, delete=(), insert=None, cut=None):
    out = list(lines)
    for k, v in (replace or {}).items():
        out[k - 1] = v
    for k in sorted(delete, reverse=True):
        del out[k - 1]
    if insert:
        k, v = insert
        out.insert(k - 1, v)
    if cut is not None:
        out = out[:cut]
    return out


BAD = {
    "truncated in hierarchy": (_edit(GOOD_LINES, cut=9), 9, "truncated"),
    "truncated last line": ("\n".join(GOOD_LINES[:-1]) + "\n0 92 0 1", 21, "truncated"),
    "missing frame lines": (_edit(GOOD_LINES, cut=20), 20, "Frames: says 3 but the data holds only 2"),
    "more frame lines": (GOOD_LINES + ["0 93 0 1 2 3 4 5 6"], 22, "more frame lines"),
    "wrong channel count": (_edit(GOOD_LINES, replace={20: "0 91 0 1 2 3 4 5 6 7"}), 20, "has 10 values"),
    "non-numeric value": (_edit(GOOD_LINES, replace={21: "0 92 0 1 2 abc 4 5 6"}), 21, "non-numeric value 'abc'"),
    "bad number": (_edit(GOOD_LINES, replace={19: "0 90 0 1.2.3 2 3 4 5 6"}), 19, "non-numeric value '1.2.3'"),
    "zero frames": (_edit(GOOD_LINES, replace={17: "Frames: 0"}, cut=18), 17, "zero frames"),
    "no data at all": (_edit(GOOD_LINES, cut=18), 18, "zero frames"),
    "bad frames count": (_edit(GOOD_LINES, replace={17: "Frames: many"}), 17, "not an integer"),
    "missing frame time": (_edit(GOOD_LINES, delete=[18]), 18, "Frame Time"),
    "bad frame time": (_edit(GOOD_LINES, replace={18: "Frame Time: 0"}), 18, "positive"),
    "no MOTION": (_edit(GOOD_LINES, cut=15), 15, "no MOTION"),
    "extra closing brace": (_edit(GOOD_LINES, insert=(15, "}")), 16, "unbalanced '}'"),
    "missing closing brace": (_edit(GOOD_LINES, delete=[14]), 15, "unbalanced braces"),
    "missing OFFSET": (_edit(GOOD_LINES, delete=[8]), 6, "no OFFSET"),
    "missing CHANNELS": (_edit(GOOD_LINES, delete=[9]), 6, "no CHANNELS"),
    "unknown channel": (_edit(GOOD_LINES, replace={9: "\t\tCHANNELS 3 Zrotation Wrotation Xrotation"}), 9,
                        "unknown channel 'Wrotation'"),
    "channel count mismatch": (_edit(GOOD_LINES, replace={9: "\t\tCHANNELS 4 Zrotation Yrotation Xrotation"}), 9,
                               "CHANNELS says 4 but names 3"),
    "bad OFFSET": (_edit(GOOD_LINES, replace={8: "\t\tOFFSET 0 ten 0"}), 8, "'ten' is not a number"),
    "short OFFSET": (_edit(GOOD_LINES, replace={12: "\t\t\tOFFSET 0 5"}), 12, "OFFSET needs 3 numbers"),
    "no HIERARCHY": (_edit(GOOD_LINES, delete=[1]), 1, "expected HIERARCHY"),
    "unknown keyword": (_edit(GOOD_LINES, insert=(9, "\t\tSCALE 2")), 9, "unexpected 'SCALE'"),
    "empty file": ([""], 1, "empty file"),
}


@pytest.mark.parametrize("kind", sorted(BAD))
def test_bad_files_raise_with_file_and_line(tmp_path, kind):
    content, line, reason = BAD[kind]
    text = content if isinstance(content, str) else "\n".join(content) + "\n"
    path = tmp_path / f"bad_{kind.replace(' ', '_')}.bvh"
    path.write_text(text)
    with pytest.raises(MocapFormatError) as e:
        mocapkit.load(path)
    msg = str(e.value)
    assert msg.startswith(f"{path}:{line}: "), msg
    assert reason in msg, msg
    assert e.value.line == line and path.name in msg and "\n" not in msg


def test_unknown_suffix_and_missing_file(tmp_path):
    with pytest.raises(MocapFormatError, match="unknown suffix"):
        mocapkit.load("x.xyz")
    with pytest.raises(MocapFormatError, match="no such file"):
        mocapkit.load(tmp_path / "absent.bvh")


def test_a_frame_rate_outside_1_to_10000_fps_is_refused_at_reading(tmp_path):
    # 300 frames with "Frame Time: 1000" (0.001 fps): `clean` once resampled it to 7,176,001 frames (24 GB)
    m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:300]
    good = tmp_path / "good.bvh"
    write_bvh(m, good)
    lines = good.read_text().split("\n")
    k = next(i for i, s in enumerate(lines) if s.startswith("Frame Time:"))
    for frame_time, bad in (("1000", "0.001"), ("0.00001", "100000.0")):
        lines[k] = f"Frame Time: {frame_time}"
        slow = tmp_path / f"rate_{frame_time}.bvh"
        slow.write_text("\n".join(lines))
        msg = refusal_of_load(slow)
        assert msg.startswith(f"{slow}:{k + 1}: Frame Time {frame_time} s: fps must be a positive number from 1 to 10000 ")
        assert msg.endswith(f"got {bad}")


def chain_bvh_text(depth: int, frames: int = 2) -> str:
    """A BVH of one chain ``depth`` joints deep, no indentation, every rotation 0.5 degrees."""
    lines = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0", "CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation"]
    for j in range(1, depth):
        lines += [f"JOINT j{j}", "{", "OFFSET 0 1 0", "CHANNELS 3 Zrotation Yrotation Xrotation"]
    lines += ["End Site", "{", "OFFSET 0 1 0", "}"] + ["}"] * depth
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    lines += [" ".join(["0.5"] * (3 + 3 * depth))] * frames
    return "\n".join(lines) + "\n"


def test_deep_chains_are_written_in_linear_size_and_read_back_identically(tmp_path):
    # the writer indented each line by its depth: a 3,000-deep chain came out 41x its input, 100,000 deep ran out of memory
    sizes = {}
    for depth in (1500, 3000):
        src = tmp_path / f"chain_{depth}.bvh"
        src.write_text(chain_bvh_text(depth))
        m = read_bvh(src)
        out = tmp_path / f"chain_{depth}_out.bvh"
        write_bvh(m, out)
        sizes[depth] = out.stat().st_size
        assert sizes[depth] < 4 * src.stat().st_size
        back = read_bvh(out)
        assert back.skeleton == m.skeleton and back.skeleton.channels == m.skeleton.channels
        np.testing.assert_allclose(back.rotations, m.rotations, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(back.global_positions(), m.global_positions())
    assert sizes[3000] < 2.05 * sizes[1500]  # linear, not quadratic, in depth


def test_fk_of_a_deep_chain_matches_naive_matrices():
    m = Motion(
        Skeleton(tuple(f"j{j}" for j in range(2000)), np.arange(-1, 1999), np.tile([0.0, 1.0, 0.0], (2000, 1))),
        quaternion_normalize(np.random.default_rng(3).normal(size=(2, 2000, 4))),
        np.zeros((2, 3)),
        fps=30.0,
    )
    gpos = m.global_positions()
    # the naive product of rotation matrices along the chain, frame 1
    from mocapkit.rotations import to_scipy

    mats = to_scipy(m.rotations[1]).as_matrix()
    pos = m.root_positions[1].copy()
    rot = mats[0]
    for j in range(1, 2000):
        pos = pos + rot @ m.skeleton.offsets[j]
        rot = rot @ mats[j]
        if j in (1, 999, 1999):
            np.testing.assert_allclose(gpos[1, j], pos, rtol=0, atol=1e-9 * j)


def test_a_20_000_joint_chain_is_read_walked_and_written_within_2_gib(tmp_path):
    src = tmp_path / "chain.bvh"
    src.write_text(chain_bvh_text(20_000, frames=1))
    code = f"""
    from mocapkit.io.bvh import read_bvh, write_bvh
    m = read_bvh({str(src)!r})
    m.global_positions()
    write_bvh(m, {str(tmp_path / 'out.bvh')!r})
    back = read_bvh({str(tmp_path / 'out.bvh')!r})
    print(back.num_joints, back.skeleton == m.skeleton)
    """
    res = run_bounded(code)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.split() == ["20000", "True"]
    assert (tmp_path / "out.bvh").stat().st_size < 4 * src.stat().st_size


@pytest.mark.parametrize(
    "name, problem",
    [
        ("lone\ud800surrogate", "is not encodable as UTF-8"),
        ("tab\tname", "holds whitespace"),
        ("new\nline", "holds whitespace"),
        ("two  spaces", "holds whitespace"),
        (" leading", "holds whitespace"),
        ("brace{", "holds a brace"),
        ("}", "holds a brace"),
        ("", "is empty"),
    ],
)
def test_names_bvh_cannot_hold_are_refused_before_writing(tmp_path, name, problem):
    m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:3]
    names = list(m.skeleton.joint_names)
    names[5] = name
    import dataclasses

    m = dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, joint_names=tuple(names)))
    out = tmp_path / "named.bvh"
    with pytest.raises(MocapFormatError) as exc:
        write_bvh(m, out)
    msg = str(exc.value)
    assert msg.startswith(f"{out}: joint 5 name {ascii(name)} {problem}") and "\n" not in msg
    msg.encode("utf-8")  # the message itself can be printed
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_names_with_single_inner_spaces_round_trip(tmp_path):
    m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:3]
    names = list(m.skeleton.joint_names)
    names[1:3] = ["Bip01 L Thigh", "Bip01 L Calf é"]
    import dataclasses

    m = dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, joint_names=tuple(names)))
    assert read_bvh(mocapkit.save(m, tmp_path / "spaces.bvh")).skeleton.joint_names == tuple(names)


def test_a_hierarchy_over_max_joints_is_refused_at_the_joint_that_passes_it(tmp_path, monkeypatch):
    import mocapkit.io.bvh as bvh_module
    import mocapkit.motion as motion_module

    assert motion_module.MAX_JOINTS == 100_000
    monkeypatch.setattr(bvh_module, "MAX_JOINTS", 500)
    monkeypatch.setattr(motion_module, "MAX_JOINTS", 500)
    ok = tmp_path / "ok.bvh"
    ok.write_text(chain_bvh_text(500))
    assert read_bvh(ok).num_joints == 500
    big = tmp_path / "big.bvh"
    big.write_text(chain_bvh_text(501))
    with pytest.raises(MocapFormatError) as exc:
        read_bvh(big)
    assert str(exc.value) == f"{big}:{6 + 4 * 499}: more than 500 joints: not a skeleton mocapkit reads"
    from mocapkit.errors import SkeletonError

    with pytest.raises(SkeletonError, match="501 joints, more than the 500 a skeleton may have"):
        Skeleton(tuple(f"j{j}" for j in range(501)), np.arange(-1, 500), np.zeros((501, 3)))


# -- writing with like=: the source file's text kept where nothing changed --------------------

BUNDLED = Path(mocapkit.__file__).parent / "data" / "131_01.bvh"
BANDAI = Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh"


def _data_lines(path: Path) -> list[str]:
    lines = path.read_text().splitlines()
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time"))
    return [t for t in lines[at + 1:] if t.strip()]


@pytest.mark.parametrize("src", [BUNDLED, BANDAI], ids=["cmu-3dsmax", "bandai"])
def test_unchanged_take_written_like_its_file_is_the_same_file(src, tmp_path):
    m = read_bvh(src)
    out = tmp_path / "same.bvh"
    write_bvh(m, out, like=src)
    assert out.read_bytes() == src.read_bytes()  # line endings (CRLF in 131_01) included
    plain = tmp_path / "plain.bvh"
    write_bvh(m, plain)  # without like= the writer formats every value itself (and may differ in text)
    assert np.array_equal(read_bvh(plain).rotations.shape, m.rotations.shape)


def test_a_frame_time_line_spaced_by_a_tab_is_found_as_the_reader_finds_it(tmp_path):
    """'Frame<TAB>Time:' reads (any whitespace); the writer must find it too, or it rewrote every line (a user trial)."""
    src = tmp_path / "tabs.bvh"
    src.write_bytes(BANDAI.read_bytes().replace(b"Frame Time:", b"Frame\tTime:"))
    out = tmp_path / "same.bvh"
    write_bvh(read_bvh(src), out, like=src)
    assert out.read_bytes() == src.read_bytes()


@pytest.mark.parametrize("src", [BUNDLED, BANDAI], ids=["cmu-3dsmax", "bandai"])
def test_only_changed_cells_change_their_text(src, tmp_path):
    m = read_bvh(src)
    rot = np.array(m.rotations)
    j, frames = 5, slice(10, 20)
    turn = euler_to_quaternion(np.array([0.0, 0.0, 30.0]), "XYZ")
    rot[frames, j] = quaternion_multiply(rot[frames, j], turn)
    edited = dataclasses.replace(m, rotations=rot)
    out = tmp_path / "edited.bvh"
    write_bvh(edited, out, like=src)
    before, after = _data_lines(src), _data_lines(out)
    assert len(before) == len(after)
    starts = np.cumsum([0] + [len(c) for c in m.skeleton.channels])
    for f, (a, b) in enumerate(zip(before, after)):
        ta, tb = a.split(), b.split()
        differ = {c for c in range(len(ta)) if ta[c] != tb[c]}
        if 10 <= f < 20:
            rotation_columns = {starts[j] + i for i, c in enumerate(m.skeleton.channels[j]) if c.endswith("rotation")}
            assert differ and differ <= rotation_columns  # a 6-channel joint's position text kept (Bandai)
        else:
            assert a == b
    back = read_bvh(out)
    assert geodesic_angle(back.rotations[frames, j], rot[frames, j]).max() < 1e-3
    keep = np.ones(m.num_frames, bool)
    keep[frames] = False
    assert np.array_equal(back.rotations[keep], m.rotations[keep])


def test_like_of_another_rig_or_length_writes_as_without(tmp_path):
    m = read_bvh(BUNDLED)
    out1, out2 = tmp_path / "a.bvh", tmp_path / "b.bvh"
    short = mocapkit.concatenate([m[:25], m[30:55]])  # none of the file's frames in order: its text cannot serve
    write_bvh(short, out1, like=BUNDLED)
    write_bvh(short, out2)
    assert out1.read_bytes() == out2.read_bytes()
    write_bvh(m, out1, like=BANDAI)  # another rig
    write_bvh(m, out2)
    assert out1.read_bytes() == out2.read_bytes()


def test_a_joint_name_used_twice_is_refused_at_its_line(tmp_path):
    text = BANDAI.read_text()
    first = text.index("JOINT UpperArm_R")
    dup = tmp_path / "dup.bvh"
    dup.write_text(text[:first] + text[first:].replace("JOINT UpperArm_R", "JOINT UpperArm_L", 1))
    line = text[:first].count("\n") + 1
    with pytest.raises(MocapFormatError, match=rf"dup.bvh:{line}: joint name 'UpperArm_L' is used twice \(first at line \d+\)"):
        read_bvh(dup)


def test_a_moved_root_written_like_its_file_keeps_the_move(tmp_path):
    """like=: a root-position edit is a changed cell too (not only rotations); unchanged frames keep their text."""
    m = read_bvh(BANDAI)
    pos = np.array(m.root_positions)
    pos[10:20] += [5.0, 0.0, -2.5]
    edited = dataclasses.replace(m, root_positions=pos)
    out = tmp_path / "moved.bvh"
    write_bvh(edited, out, like=BANDAI)
    back = read_bvh(out)
    np.testing.assert_allclose(back.root_positions, pos, rtol=0, atol=1e-5)
    before, after = _data_lines(BANDAI), _data_lines(out)
    assert [f for f in range(len(before)) if before[f] != after[f]] == list(range(10, 20))


def test_an_animated_offset_written_like_its_file_keeps_the_change(tmp_path):
    """like=: an edit of a non-root joint's animated offset (BANDAI animates every joint's position) is written."""
    m = read_bvh(BANDAI)
    tr = np.array(m.local_offsets())
    tr[30:35, 5] += [0.0, 1.5, 0.0]
    edited = dataclasses.replace(m, translations=tr)
    out = tmp_path / "offset.bvh"
    write_bvh(edited, out, like=BANDAI)
    np.testing.assert_allclose(read_bvh(out).local_offsets(), tr, rtol=0, atol=1e-5)


def test_a_new_channel_layout_is_not_written_into_the_file_s_columns(tmp_path):
    """like= of a file whose channel layout the motion no longer has (a joint now translates): values stay in
    their own columns (the file's text cannot serve)."""
    m = read_bvh(BUNDLED)  # CMU: non-root joints have rotation channels only
    tr = np.array(m.local_offsets())
    tr[:, 5] += [0.0, 0.25, 0.0]  # joint 5 now needs position channels
    edited = dataclasses.replace(m, translations=tr)
    out, plain = tmp_path / "like.bvh", tmp_path / "plain.bvh"
    write_bvh(edited, out, like=BUNDLED)
    write_bvh(edited, plain)
    assert out.read_bytes() == plain.read_bytes()


def test_a_new_frame_rate_is_written_not_the_file_s_frame_time(tmp_path):
    m = read_bvh(BANDAI)
    edited = dataclasses.replace(m, fps=2 * m.fps)
    out = tmp_path / "fast.bvh"
    write_bvh(edited, out, like=BANDAI)
    assert read_bvh(out).fps == pytest.approx(edited.fps, rel=1e-9)


def test_new_bone_lengths_are_written_not_the_file_s_header(tmp_path):
    m = read_bvh(BUNDLED)
    sk = dataclasses.replace(m.skeleton, offsets=np.asarray(m.skeleton.offsets) * 1.25)
    out = tmp_path / "longer.bvh"
    write_bvh(dataclasses.replace(m, skeleton=sk), out, like=BUNDLED)
    np.testing.assert_array_equal(read_bvh(out).skeleton.offsets, sk.offsets)
    sk2 = dataclasses.replace(m.skeleton, end_site_offsets=np.asarray(m.skeleton.end_site_offsets) * 2.0)
    write_bvh(dataclasses.replace(m, skeleton=sk2), out, like=BUNDLED)
    np.testing.assert_array_equal(read_bvh(out).skeleton.end_site_offsets, sk2.end_site_offsets)


def test_a_changed_cell_keeps_the_file_s_360_degree_branch(tmp_path):
    """A channel the file writes as ~+370 deg stays near +370 where the edit changed it (not jumping to ~10)."""
    lines = BANDAI.read_bytes().decode().splitlines(keepends=True)
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time"))
    m0 = read_bvh(BANDAI)
    starts = np.cumsum([0] + [len(c) for c in m0.skeleton.channels])
    j = 5
    col = starts[j] + list(m0.skeleton.channels[j]).index("Zrotation")
    for i in range(at + 1, len(lines)):
        if lines[i].strip():
            body = lines[i].rstrip("\r\n")
            tok = body.split()
            tok[col] = repr(float(tok[col]) + 360.0)
            lines[i] = " ".join(tok) + lines[i][len(body):]
    src = tmp_path / "wound.bvh"
    src.write_bytes("".join(lines).encode())
    m = read_bvh(src)
    rot = np.array(m.rotations)
    rot[10:20, j] = quaternion_multiply(rot[10:20, j], euler_to_quaternion(np.array([0.0, 0.0, 3.0]), "XYZ"))
    out = tmp_path / "edited.bvh"
    write_bvh(dataclasses.replace(m, rotations=rot), out, like=src)
    was = np.array([float(t.split()[col]) for t in _data_lines(src)])
    now = np.array([float(t.split()[col]) for t in _data_lines(out)])
    assert np.abs(now - was).max() < 30.0  # same branch: a few degrees, never ~360


def test_changed_lines_keep_the_file_s_crlf_line_endings(tmp_path):
    src = tmp_path / "crlf.bvh"
    src.write_bytes(BANDAI.read_bytes().replace(b"\r\n", b"\n").replace(b"\n", b"\r\n"))  # a Windows file
    m = read_bvh(src)
    rot = np.array(m.rotations)
    rot[10:20, 5] = quaternion_multiply(rot[10:20, 5], euler_to_quaternion(np.array([0.0, 0.0, 30.0]), "XYZ"))
    out = tmp_path / "edited.bvh"
    write_bvh(dataclasses.replace(m, rotations=rot), out, like=src)
    data = out.read_bytes()
    assert data != src.read_bytes() and b"\n" not in data.replace(b"\r\n", b"")  # changed lines end in CRLF too


def test_a_joint_declared_without_channels_that_now_rotates_gets_rotation_channels(tmp_path, rng):
    path = tmp_path / "odd.bvh"
    path.write_text(bvh_text(ODD, odd_rows(rng).tolist()))
    m = read_bvh(path)
    still = m.skeleton.joint_names.index("Still")
    rot = np.array(m.rotations)
    rot[:, still] = euler_to_quaternion(np.array([0.0, 0.0, 40.0]), "XYZ")
    out = tmp_path / "rotated.bvh"
    write_bvh(dataclasses.replace(m, rotations=rot), out)
    back = read_bvh(out)
    assert back.skeleton.rotation_order(still)
    assert np.degrees(geodesic_angle(back.rotations[:, still], rot[:, still])).max() < 1e-4


def test_missing_animated_offsets_are_refused_like_missing_rotations(tmp_path):
    m = read_bvh(BANDAI)
    tr = np.array(m.local_offsets())
    tr[3, 5] = np.nan
    out = tmp_path / "gap.bvh"
    with pytest.raises(MocapFormatError, match="missing values"):
        write_bvh(dataclasses.replace(m, translations=tr), out)
    assert not out.exists()


def test_a_take_with_no_frames_is_refused_and_nothing_written(tmp_path):
    m = read_bvh(BANDAI)
    out = tmp_path / "empty.bvh"
    with pytest.raises(MocapFormatError, match="no frames"):
        write_bvh(m[:0], out)
    assert not out.exists()


def with_scale_channels(path: Path, out: Path, joints: int, scale: str = "1") -> list[str]:
    """Copy of the BVH ``path`` with ``Xscale Yscale Zscale`` after the channels of its first ``joints`` joints
    (as Maya writes them), every scale value ``scale`` (a token, written as given); returns the data lines."""
    lines = path.read_text().splitlines()
    at = lines.index("MOTION")
    widths, head = [], []
    for line in lines[:at]:
        toks = line.split()
        if toks and toks[0] == "CHANNELS":
            widths.append(int(toks[1]))
            if len(widths) <= joints:
                ind = line[: len(line) - len(line.lstrip())]
                line = f"{ind}CHANNELS {int(toks[1]) + 3} {' '.join(toks[2:])} Xscale Yscale Zscale"
        head.append(line)
    starts = np.cumsum([0] + widths)
    data = []
    for line in lines[at + 3:]:
        toks = line.split()
        for j in reversed(range(joints)):
            toks[starts[j + 1]:starts[j + 1]] = [scale] * 3
        data.append(" ".join(toks))
    out.write_text("\n".join(head + lines[at:at + 3] + data) + "\n")
    return data


def test_unit_scale_channels_are_read_and_written_back_as_the_file_has_them(tmp_path):
    """Issue 6: Maya and game exporters write Xscale Yscale Zscale (value 1); the take reads as the same motion,
    and a cleaned joint is rewritten while the scale columns keep the file's text."""
    plain = read_bvh(BANDAI)
    path = tmp_path / "scaled.bvh"
    with_scale_channels(BANDAI, path, joints=4)
    m = read_bvh(path)
    assert m.skeleton.joint_channels(1)[-3:] == ("Xscale", "Yscale", "Zscale")
    assert m.skeleton.rotation_order(1) == plain.skeleton.rotation_order(1)
    np.testing.assert_array_equal(m.rotations, plain.rotations)
    np.testing.assert_array_equal(m.local_offsets(), plain.local_offsets())
    rot = np.array(m.rotations)
    rot[5:8, 2] = euler_to_quaternion(np.array([10.0, 20.0, 30.0]), "ZXY")
    out = tmp_path / "cleaned.bvh"
    write_bvh(dataclasses.replace(m, rotations=rot), out, like=path)
    src, got = path.read_text().splitlines(), out.read_text().splitlines()
    assert got[: src.index("MOTION") + 3] == src[: src.index("MOTION") + 3]
    changed = [f for f, (a, b) in enumerate(zip(src, got)) if a != b]
    assert changed and min(changed) > src.index("MOTION")
    names = [c for line in src[: src.index("MOTION")] if line.split()[:1] == ["CHANNELS"] for c in line.split()[2:]]
    scale = [k for k, c in enumerate(names) if c.endswith("scale")]
    assert len(scale) == 12
    rows = slice(src.index("MOTION") + 3, None)
    assert [[r.split()[k] for k in scale] for r in got[rows]] == [[r.split()[k] for k in scale] for r in src[rows]]
    back = read_bvh(out)
    assert np.degrees(geodesic_angle(back.rotations, rot)).max() < 1e-4
    fresh = tmp_path / "fresh.bvh"
    write_bvh(m, fresh)  # without like: the layout is kept, the scales written as 1
    again = read_bvh(fresh)
    assert again.skeleton.channels == m.skeleton.channels
    assert np.degrees(geodesic_angle(again.rotations, m.rotations)).max() < 1e-4


@pytest.mark.parametrize("scale, what", [("0.5", "Xscale is 0.5 in frame 1"), ("nan", "Xscale is nan in frame 1")])
def test_a_scale_other_than_one_is_refused_naming_the_file_joint_and_scale(tmp_path, scale, what):
    path = tmp_path / "scaled.bvh"
    with_scale_channels(BANDAI, path, joints=2, scale=scale)
    with pytest.raises(MocapFormatError) as err:
        read_bvh(path)
    msg = str(err.value)
    assert "scaled.bvh" in msg and "'joint_Root'" in msg and what in msg and "scale channels" in msg
    assert "\n" not in msg


def test_a_nine_channel_joint_reads_and_a_tenth_channel_is_refused_naming_the_kinds(tmp_path):
    path = tmp_path / "nine.bvh"
    with_scale_channels(BANDAI, path, joints=1)
    assert read_bvh(path).skeleton.joint_channels(0)[-1] == "Zscale"
    text = path.read_text().replace("CHANNELS 9 Xposition", "CHANNELS 10 Xposition Wscale", 1)
    path.write_text(text)
    with pytest.raises(MocapFormatError, match="between 0 and 9 .X/Y/Z position, rotation and scale"):
        read_bvh(path)
