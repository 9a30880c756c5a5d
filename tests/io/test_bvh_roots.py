"""BVH files with a second ROOT (a prop, a camera) and with comment lines: read, carried through, written back.

The files are real takes' text (the bundled CMU 131_01, a Bandai Namco take) with a prop's hierarchy and
numbers added by hand, as MotionBuilder and Blender export a sword or a camera beside the character.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.io.bvh import read_bvh, source_fits
from mocapkit.io.bvh_roots import extra_roots, humanoid_root
from tests.cli.helpers import run
from tests.io.prop_files import PROP, plain, prop_numbers, take_lines, with_prop

@pytest.fixture
def cmu() -> Path:
    return mocapkit.samples.path("131_01.bvh")


@pytest.mark.parametrize("before", [False, True])
def test_a_prop_root_is_read_beside_the_take_and_written_back_bit_identical(cmu, tmp_path, before):
    path = with_prop(cmu, tmp_path / "prop.bvh", before=before)
    m, alone = read_bvh(path), read_bvh(plain(cmu, tmp_path / "alone.bvh"))
    assert m.skeleton.joint_names == alone.skeleton.joint_names and m.skeleton.joint_names[0] == "Hips"
    np.testing.assert_array_equal(m.rotations, alone.rotations)
    np.testing.assert_array_equal(m.root_positions, alone.root_positions)
    assert [(e.name, e.joints, e.channels) for e in extra_roots(path)] == [("Sword", ("Sword", "Blade"), 9)]
    mocapkit.save(m, tmp_path / "out.bvh")
    assert (tmp_path / "out.bvh").read_bytes() == path.read_bytes()


@pytest.mark.parametrize("before", [False, True])
def test_a_changed_cell_rewrites_the_take_s_numbers_only_the_prop_s_stay_the_file_s_text(cmu, tmp_path, before):
    path = with_prop(cmu, tmp_path / "prop.bvh", before=before)
    m = read_bvh(path)
    rot = np.array(m.rotations)
    rot[5, 3] = [np.cos(0.2), np.sin(0.2), 0.0, 0.0]
    mocapkit.save(dataclasses.replace(m, rotations=rot), tmp_path / "out.bvh")
    a = path.read_bytes().decode().splitlines()
    b = (tmp_path / "out.bvh").read_bytes().decode().splitlines()
    first = a.index("Frame Time: .0083333") + 1
    assert b[:first] == a[:first]
    changed = [k for k in range(len(a)) if a[k] != b[k]]
    assert changed == [first + 5]
    prop = slice(0, 9) if before else slice(-9, None)
    assert b[first + 5].split()[prop] == a[first + 5].split()[prop] == prop_numbers(5).split()
    back = read_bvh(tmp_path / "out.bvh")
    assert np.abs(back.rotations[5, 3] - rot[5, 3]).max() < 1e-6
    assert extra_roots(tmp_path / "out.bvh") == extra_roots(path)


def test_a_new_skeleton_header_keeps_the_prop_s_hierarchy_lines_and_comments(cmu, tmp_path):
    path = with_prop(cmu, tmp_path / "prop.bvh", comments=True)
    m = read_bvh(path)
    offsets = np.array(m.skeleton.offsets)
    offsets[4, 0] += 1.0
    moved = dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, offsets=offsets))
    mocapkit.save(moved, tmp_path / "out.bvh")
    text = (tmp_path / "out.bvh").read_text()
    assert "".join(PROP) in text and "# a comment between the roots\n" in text
    assert text.startswith("# exported with a prop\nHIERARCHY\n")
    back = read_bvh(tmp_path / "out.bvh")
    np.testing.assert_array_equal(back.skeleton.offsets, offsets)
    rows = text.splitlines()[-30:]
    assert [r.split()[-9:] for r in rows] == [prop_numbers(f).split() for f in range(30)]


def test_the_take_is_the_root_with_a_hips_like_joint_and_most_joints():
    rope = [f"link{k}" for k in range(40)]
    body = ["Hips", "LeftUpLeg", "LeftLeg", "Spine", "Head"]
    assert humanoid_root(rope + body, [(0, 1, 9), (40, 10, 19)]) == 1  # a longer prop with no hips
    assert humanoid_root(["Camera"] + body, [(0, 1, 3), (1, 4, 9)]) == 1
    assert humanoid_root(["a", "b", "c", "d"], [(0, 1, 3), (1, 4, 9), (3, 10, 12)]) == 1  # no hips: most joints
    assert humanoid_root(["a", "b", "c", "d"], [(0, 1, 3), (2, 4, 9)]) == 0  # a tie: the first


def test_a_bandai_namco_take_with_a_prop_root_and_comments(shared_data, tmp_path):
    source = shared_data / "secondary_bandai_namco_CC-BY-NC" / "dataset-1_kick_normal_001.bvh"
    path = with_prop(source, tmp_path / "kick.bvh", frames=40, before=True, comments=True)
    m, alone = read_bvh(path), read_bvh(plain(source, tmp_path / "alone.bvh", frames=40))
    assert m.skeleton.joint_names == alone.skeleton.joint_names and m.skeleton.joint_names[0] == "joint_Root"
    np.testing.assert_array_equal(m.rotations, alone.rotations)
    mocapkit.save(m, tmp_path / "out.bvh")
    assert (tmp_path / "out.bvh").read_bytes() == path.read_bytes()


def test_comment_lines_are_read_as_nothing_and_kept_on_write(cmu, tmp_path):
    head, body, frame_time = take_lines(cmu, 20)
    h = next(i for i, t in enumerate(head) if t.strip() == "HIERARCHY") + 1
    text = ("# written by a tool that comments\r\n" + "".join(head[:h]) + "# the character\n" + "".join(head[h:h + 4])
            + "\t\t# inside a joint\n" + "".join(head[h + 4:]) + "MOTION\n# the frames\n"
            + f"Frames: {len(body)}\n" + "# the rate\n" + frame_time + "".join(body))
    path = tmp_path / "commented.bvh"
    path.write_bytes(text.encode())
    m, alone = read_bvh(path), read_bvh(plain(cmu, tmp_path / "alone.bvh", frames=20))
    assert m.skeleton.joint_names == alone.skeleton.joint_names
    np.testing.assert_array_equal(m.skeleton.offsets, alone.skeleton.offsets)
    np.testing.assert_array_equal(m.rotations, alone.rotations)
    assert extra_roots(path) == ()
    mocapkit.save(m, tmp_path / "out.bvh")
    assert (tmp_path / "out.bvh").read_bytes() == path.read_bytes()


def test_info_names_the_other_roots_and_other_formats_say_in_one_line_what_they_leave_out(cmu, tmp_path):
    path = with_prop(cmu, tmp_path / "prop.bvh")
    code, out, err = run("info", path)
    assert code == 0, err
    assert "other roots  'Sword' (2 joints, 9 channels)" in out
    code, out, err = run("convert", path, tmp_path / "prop.npz")  # it keeps the file's text: a BVH of it has them
    assert code == 0 and "note:" not in out, err + out
    code, out, err = run("convert", tmp_path / "prop.npz", tmp_path / "back.bvh")
    assert code == 0 and "note:" not in out and (tmp_path / "back.bvh").read_bytes() == path.read_bytes()
    code, out, err = run("convert", path, tmp_path / "half.npz", "--fps", "60")  # not at the file's frames: left out
    assert code == 0, err
    notes = [line for line in out.splitlines() if line.startswith("note:")]
    assert len(notes) == 1 and "half.npz: not written" in notes[0] and "'Sword'" in notes[0]
    code, out, err = run("convert", path, tmp_path / "same.bvh")  # a BVH like its source: nothing left out
    assert code == 0 and "note:" not in out and (tmp_path / "same.bvh").read_bytes() == path.read_bytes()
    code, out, err = run("convert", path, tmp_path / "slow.bvh", "--fps", "60")
    assert code == 0 and sum("note:" in line and "'Sword'" in line for line in out.splitlines()) == 1
    m = read_bvh(path)
    assert source_fits(m, path) and not source_fits(m.resample(60), path)


def test_a_take_whose_root_shares_the_hierarchy_line_is_still_written_whole(cmu, tmp_path):
    """``HIERARCHY ROOT Hips`` on one line: the take's block cannot be cut out of the header by lines, so a new
    skeleton is written as a whole hierarchy (alone), and with another root the take is not written like its
    source (the note says what is left out) rather than written without its HIERARCHY line."""
    path = tmp_path / "oneline.bvh"
    path.write_text("HIERARCHY ROOT Hips\n" + cmu.read_text().split("ROOT Hips", 1)[1])
    m = read_bvh(path)
    offsets = np.array(m.skeleton.offsets)
    offsets[3, 1] += 1.0
    moved = dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, offsets=offsets))
    mocapkit.save(moved, tmp_path / "out.bvh")
    np.testing.assert_array_equal(read_bvh(tmp_path / "out.bvh").skeleton.offsets, offsets)
    prop = with_prop(path, tmp_path / "prop.bvh")
    m = read_bvh(prop)
    moved = dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, offsets=offsets))
    assert source_fits(m, prop) and not source_fits(moved, prop)
    assert "'Sword'" in mocapkit.io.motion_notes(moved, tmp_path / "out2.bvh")[0]
