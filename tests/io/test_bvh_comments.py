"""A BVH's `#` comment lines in its motion section and inside the take's hierarchy: read as nothing, carried
through where the file is written like its source (the hierarchy written anew included), and said in a note where
an output leaves them out (mocapkit.io.bvh_comments). The takes are real: the bundled CMU 131_01 and a Bandai Namco
take, with comment lines added as tools write them."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.io import motion_notes
from mocapkit.io.bvh import read_bvh
from mocapkit.io.bvh_comments import anchored, with_comments
from tests.io.prop_files import plain, take_lines


@pytest.fixture
def cmu() -> Path:
    return mocapkit.samples.path("131_01.bvh")


def _commented(source: Path, out: Path, frames: int = 20) -> Path:
    """``source``'s first ``frames`` frames with comment lines inside the hierarchy (after the root's CHANNELS)
    and in the motion section: before the first frame, between frames 5 and 6 (indented, CRLF) and after the last."""
    head, body, frame_time = take_lines(source, frames)
    h = next(i for i, t in enumerate(head) if t.strip() == "HIERARCHY") + 1
    text = ("".join(head[:h + 4]) + "\t# the legs, left first\n" + "".join(head[h + 4:]) + "MOTION\n"
            + f"Frames: {len(body)}\n" + frame_time + "# take 1, clean\n" + "".join(body[:5])
            + "  # marker swap fixed by hand below\r\n" + "".join(body[5:]) + "# end of take\n")
    out.write_bytes(text.encode())
    return out


@pytest.mark.parametrize("take", ["cmu", "bandai"])
def test_comment_lines_in_the_motion_section_are_read_as_nothing_and_kept(cmu, shared_data, tmp_path, take):
    """A user trial: `#` lines between a BVH's frames were refused ("non-numeric value '#'"), though comments
    elsewhere in the file are read."""
    source = cmu if take == "cmu" else shared_data / "secondary_bandai_namco_CC-BY-NC" / "dataset-1_kick_normal_001.bvh"
    path = _commented(source, tmp_path / "commented.bvh")
    m, alone = read_bvh(path), read_bvh(plain(source, tmp_path / "alone.bvh", frames=20))
    assert m.num_frames == 20 and m.skeleton.joint_names == alone.skeleton.joint_names
    np.testing.assert_array_equal(m.rotations, alone.rotations)
    np.testing.assert_array_equal(m.root_positions, alone.root_positions)
    mocapkit.save(m, tmp_path / "out.bvh")  # unchanged: the same file, comments where they were
    assert (tmp_path / "out.bvh").read_bytes() == path.read_bytes()
    assert motion_notes(m, tmp_path / "out.bvh") == []
    rot = np.array(m.rotations)
    rot[6, 3] = [np.cos(0.2), np.sin(0.2), 0.0, 0.0]
    mocapkit.save(dataclasses.replace(m, rotations=rot), tmp_path / "changed.bvh")
    a, b = path.read_text().splitlines(), (tmp_path / "changed.bvh").read_text().splitlines()
    assert len(a) == len(b) and [k for k in range(len(a)) if a[k] != b[k]] == [a.index("# take 1, clean") + 8]  # frame 6: after 5 frames and a comment


def test_a_bad_token_after_numbers_is_still_refused_with_its_line(cmu, tmp_path):
    head, body, frame_time = take_lines(cmu, 3)
    path = tmp_path / "bad.bvh"
    path.write_bytes("".join(head + ["MOTION\n", "Frames: 3\n", frame_time, body[0], body[1].rstrip("\n")
                                     + " # not a comment line\n", body[2]]).encode())
    with pytest.raises(mocapkit.MocapFormatError, match=r"bad\.bvh:\d+: non-numeric value '#'"):
        read_bvh(path)


def test_comments_inside_the_take_s_hierarchy_written_anew_stay_after_the_same_element(cmu, tmp_path):
    """A user trial: a take whose offsets changed is written with its hierarchy anew; the comments inside it were
    dropped, silently."""
    path = _commented(cmu, tmp_path / "commented.bvh")
    m = read_bvh(path)
    offsets = np.array(m.skeleton.offsets)
    offsets[4, 0] += 1.0
    moved = dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, offsets=offsets))
    mocapkit.save(moved, tmp_path / "out.bvh")
    lines = (tmp_path / "out.bvh").read_text().splitlines()
    at = lines.index("\t# the legs, left first")
    assert lines[at - 1].split()[:2] == ["CHANNELS", "6"] and lines[at + 1].split() == ["JOINT", "LHipJoint"]
    assert "# take 1, clean" in lines and "  # marker swap fixed by hand below" in lines and lines[-1] == "# end of take"
    back = read_bvh(tmp_path / "out.bvh")
    np.testing.assert_array_equal(back.skeleton.offsets, offsets)
    np.testing.assert_array_equal(back.rotations, m.rotations)
    assert motion_notes(moved, tmp_path / "out.bvh") == []


def test_an_output_that_cannot_keep_the_comments_says_how_many_it_leaves_out(cmu, tmp_path):
    path = _commented(cmu, tmp_path / "commented.bvh")
    m = read_bvh(path)
    assert motion_notes(m, tmp_path / "out.npz") == []  # the .npz keeps all 4 (test_an_npz_made_from_the_bvh_...)
    half = m.resample(60.0)
    assert motion_notes(half, tmp_path / "half.bvh") == [
        f"{tmp_path / 'half.bvh'}: not written: 4 comment lines of {path} (a .bvh keeps them only when written like "
        "its source, at its frames, rate and skeleton)"]
    assert motion_notes(half, tmp_path / "half.npz") == [
        f"{tmp_path / 'half.npz'}: not written: 4 comment lines of {path} (an .npz keeps them only at the take's "
        "frames, rate and skeleton)"]


def test_an_npz_made_from_the_bvh_keeps_its_motion_comments_where_they_stood(cmu, tmp_path):
    """A user trial: BVH -> npz -> BVH (``mocapkit convert``) lost the comment lines between the frames (the header's
    were kept): the npz kept no motion-section comments. Now the BVH written from the npz has each of them, byte for
    byte (the CRLF one too), before the same frame, the take read back the same, and a changed take keeps them."""
    path = _commented(cmu, tmp_path / "commented.bvh")
    m = read_bvh(path)
    mocapkit.save(m, tmp_path / "take.npz")
    n = mocapkit.load(tmp_path / "take.npz")
    mocapkit.save(n, tmp_path / "back.bvh")
    src, back = path.read_bytes().splitlines(keepends=True), (tmp_path / "back.bvh").read_bytes().splitlines(keepends=True)
    assert len(back) == len(src)
    assert [(i, t) for i, t in enumerate(back) if t.lstrip().startswith(b"#")] == [
        (i, t) for i, t in enumerate(src) if t.lstrip().startswith(b"#")]  # 4 lines: the header's and the motion's 3
    again = read_bvh(tmp_path / "back.bvh")
    np.testing.assert_array_equal(again.rotations, m.rotations)
    np.testing.assert_array_equal(again.root_positions, m.root_positions)
    rot = np.array(n.rotations)
    rot[6, 3] = [np.cos(0.2), np.sin(0.2), 0.0, 0.0]
    mocapkit.save(dataclasses.replace(n, rotations=rot), tmp_path / "changed.bvh")  # like: the npz it was read from
    changed = (tmp_path / "changed.bvh").read_bytes().splitlines(keepends=True)
    assert [k for k in range(len(back)) if back[k] != changed[k]] == [src.index(b"# take 1, clean\n") + 8]


def test_a_comment_goes_after_the_element_it_followed_whatever_the_file_s_layout():
    block = ["ROOT Hips\n", "{ OFFSET 0 0 0 CHANNELS 3 Zrotation Yrotation Xrotation\n", "# after the channels\n",
             "End Site { OFFSET 0 1 0 }\n", "}\n"]
    new = "ROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 3 Zrotation Yrotation Xrotation\n\tEnd Site\n\t{\n" \
          "\t\tOFFSET 0 2 0\n\t}\n}\n"
    assert anchored(block) == [(4, "# after the channels\n")]
    assert with_comments(new, anchored(block), 9).splitlines()[4] == "# after the channels"
    assert with_comments(new, anchored(block), 11) is None  # another hierarchy: no place is the same


def test_an_npz_s_motion_comments_are_written_only_as_comment_lines_of_its_frame_count(cmu, tmp_path):
    """The comments an .npz keeps are text a BVH writer puts between frames: kept only as whole comment lines, at
    frames the take has (a line that is no comment, or runs into the next, would change the take read back)."""
    import json

    from mocapkit.io.kept_channels import COMMENTS_KEY, kept_comments
    from mocapkit.io.npz import load_arrays

    path = _commented(cmu, tmp_path / "commented.bvh")
    mocapkit.save(read_bvh(path), tmp_path / "take.npz")
    arrays = load_arrays(tmp_path / "take.npz")
    assert json.loads(str(arrays[COMMENTS_KEY])) == [
        [0, "# take 1, clean\n"], [5, "  # marker swap fixed by hand below\r\n"], [20, "# end of take\n"]]
    assert kept_comments(tmp_path / "take.npz", 19) is None  # another frame count
    for bad in ([[3, "1.0 2.0 3.0\n"]], [[3, "# two\n# lines\n"]], [[3, "# runs on"], [4, "# next\n"]], [[3.0, "# x\n"]]):
        np.savez(tmp_path / "bad.npz", **{**arrays, COMMENTS_KEY: np.array(json.dumps(bad))})
        assert kept_comments(tmp_path / "bad.npz", 20) is None, bad


def test_a_comment_first_line_after_a_byte_order_mark_is_counted(cmu, tmp_path):
    """A BVH starting with a UTF-8 byte-order mark and a ``#`` first line (a Windows tool's signature line): the
    mark is no part of that line (io.sources.bom_length), so it is a comment like the others. Before 0.15.0 the
    note of an output leaving the comments out counted one fewer (4 -> 3 here; a file whose only comment is that
    line: no note at all)."""
    from mocapkit.io.bvh_comments import comment_lines

    plain_text = _commented(cmu, tmp_path / "commented.bvh").read_bytes()
    path = tmp_path / "marked.bvh"
    path.write_bytes(b"\xef\xbb\xbf# written by a tool\n" + plain_text)
    assert comment_lines(path.read_bytes()) == comment_lines(b"# written by a tool\n" + plain_text) == 5
    half = read_bvh(path).resample(60.0)
    assert motion_notes(half, tmp_path / "half.bvh") == [
        f"{tmp_path / 'half.bvh'}: not written: 5 comment lines of {path} (a .bvh keeps them only when written like "
        "its source, at its frames, rate and skeleton)"]
    assert motion_notes(read_bvh(path), tmp_path / "out.npz") == []  # the .npz keeps all 5, the first one too


@pytest.mark.parametrize("offsets", [False, True])
def test_blank_lines_after_the_last_frame_and_between_frames_are_kept(cmu, tmp_path, offsets):
    """A user trial: `(cat take.bvh; echo; echo) > t.bvh; mocapkit clean t.bvh -o out.bvh` said 100 % untouched and
    wrote 2 bytes fewer: the empty lines after the last frame were dropped. An unchanged take is the file byte for
    byte, and a changed one (its numbers, or its offsets: the hierarchy written anew) keeps them where they were."""
    head, body, frame_time = take_lines(cmu, 12)
    path = tmp_path / "blanks.bvh"
    path.write_bytes("".join(head + ["MOTION\n", f"Frames: {len(body)}\n", frame_time] + body[:4] + ["\n"] + body[4:]
                             + ["\n", "  \r\n", "# end\n", "\n"]).encode())
    m = read_bvh(path)
    mocapkit.save(m, tmp_path / "out.bvh")
    assert (tmp_path / "out.bvh").read_bytes() == path.read_bytes()
    assert motion_notes(m, tmp_path / "out.bvh") == []
    rot = np.array(m.rotations)
    rot[6, 3] = [np.cos(0.2), np.sin(0.2), 0.0, 0.0]
    changed = dataclasses.replace(m, rotations=rot)
    if offsets:
        sk = m.skeleton
        changed = dataclasses.replace(changed, skeleton=dataclasses.replace(sk, offsets=sk.offsets * 1.01))
    mocapkit.save(changed, tmp_path / "changed.bvh")
    text = (tmp_path / "changed.bvh").read_bytes().decode()
    assert text.endswith("\n\n  \r\n# end\n\n")
    motion = text.split("Frame Time:")[1].splitlines()[1:]
    assert motion[4] == "" and len(motion) == 12 + 5 and motion[7] != body[6].rstrip("\r\n")
