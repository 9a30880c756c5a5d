"""AMC writing: golden round trips on real clips, the source file's text kept where nothing changed, refusals."""

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import io
from mocapkit import rotations as R
from mocapkit.errors import MocapFormatError
from mocapkit.io.amc_writer import check_amc_writable, write_amc
from mocapkit.io.asfamc import amc_dofs, find_asf, read_amc
from tests.shared import curated_files

SAMPLES = [
    ("12_walk.amc", "12.asf"),
    ("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", "HDM_bd.asf"),
    ("HDM_bk_sneak2StepsLStart_004_120.amc", "HDM_bk.asf"),
]


def _sample(name):
    amc, asf = (mocapkit.samples.path(n) for n in name)
    return amc, asf, read_amc(amc, asf)


def _turned(m, f, joint, deg):
    """``m`` with joint ``joint`` at frame ``f`` turned by ``deg`` about the bone frame's first dof axis."""
    j = m.skeleton.joint_names.index(joint)
    rot = np.array(m.rotations)
    axis = amc_dofs(m.skeleton)[j][0][1]
    c = m.skeleton.axes[j]
    extra = R.quaternion_multiply(R.quaternion_multiply(c, R.euler_to_quaternion([deg], axis)), R.quaternion_conjugate(c))
    rot[f, j] = R.quaternion_multiply(rot[f, j], extra)
    return dataclasses.replace(m, rotations=rot)


def _assert_same_motion(a, b, deg=1e-4):
    assert np.degrees(R.geodesic_angle(a.rotations, b.rotations)).max() < deg
    np.testing.assert_allclose(a.root_positions, b.root_positions, atol=1e-5)


@pytest.mark.parametrize("name", SAMPLES)
def test_bundled_clip_written_like_itself_is_the_same_file(name, tmp_path):
    amc, asf, m = _sample(name)
    out = tmp_path / "same.amc"
    io.save(m, out, like=amc)
    assert out.read_bytes() == amc.read_bytes()


@pytest.mark.parametrize("name", SAMPLES)
def test_fresh_write_reads_back_with_the_same_asf(name, tmp_path):
    amc, asf, m = _sample(name)
    out = tmp_path / "fresh.amc"
    write_amc(m, out)
    text = out.read_text()
    assert text.startswith(":FULLY-SPECIFIED\n:DEGREES\n1\nroot ")
    back = read_amc(out, asf)
    assert back.num_frames == m.num_frames and back.skeleton.joint_names == m.skeleton.joint_names
    _assert_same_motion(m, back)


def test_every_amc_in_shared_data_round_trips(shared_data, tmp_path):
    files = curated_files(shared_data, "**/*.amc")
    assert files
    for amc in files:
        m = mocapkit.load(amc)
        out = tmp_path / "x.amc"
        io.save(m, out, like=amc, overwrite=True)  # each file's own ASF beside x.amc, replacing the last one's
        assert out.read_bytes() == amc.read_bytes(), amc
        write_amc(m, out)
        _assert_same_motion(m, read_amc(out, find_asf(amc)))


def test_a_changed_cell_rewrites_only_its_bone_line(tmp_path):
    amc, asf, m = _sample(SAMPLES[0])
    edited = _turned(m, 10, "rfemur", 5.0)
    out = tmp_path / "one.amc"
    io.save(edited, out, like=amc)
    a, b = amc.read_text().splitlines(), out.read_text().splitlines()
    assert len(a) == len(b)
    diff = [i for i, (x, y) in enumerate(zip(a, b)) if x != y]
    assert len(diff) == 1 and b[diff[0]].startswith("rfemur ")
    back = read_amc(out, asf)
    _assert_same_motion(edited, back)
    changed = np.degrees(R.geodesic_angle(m.rotations, back.rotations)) > 1e-9
    assert changed.sum() == 1 and changed[10, m.skeleton.joint_names.index("rfemur")]


def test_changed_angles_stay_on_the_file_branch(tmp_path):
    amc, asf, m = _sample(SAMPLES[0])
    lines = amc.read_text().splitlines(keepends=True)
    text = "".join("lfemur " + " ".join(f"{float(v) + 360.0:.6f}" for v in ln.split()[1:]) + "\n"
                   if ln.startswith("lfemur ") else ln for ln in lines)
    src = tmp_path / "wrapped.amc"
    src.write_text(text)  # the same rotations, every lfemur angle 360 degrees up: the file's branch
    m = read_amc(src, asf)
    edited = _turned(m, 20, "lfemur", 1.0)  # frame 20: every frame lists lfemur
    out = tmp_path / "out.amc"
    io.save(edited, out, like=src)
    new = [ln for ln in out.read_text().splitlines() if ln.startswith("lfemur ")][20]
    old = [ln for ln in text.splitlines() if ln.startswith("lfemur ")][20]
    assert new != old
    assert all(abs(float(x) - float(y)) < 5.0 for x, y in zip(new.split()[1:], old.split()[1:]))
    _assert_same_motion(edited, read_amc(out, asf))


def test_a_bone_the_frame_did_not_list_is_added(tmp_path):
    amc, asf, m = _sample(SAMPLES[0])
    lines = amc.read_text().splitlines(keepends=True)
    at = [i for i, ln in enumerate(lines) if ln.startswith("rtibia ")][3]
    src = tmp_path / "short.amc"
    src.write_text("".join(lines[:at] + lines[at + 1:]))  # frame 4 omits rtibia: read as the identity
    m = read_amc(src, asf)
    edited = _turned(m, 3, "rtibia", 20.0)
    out = tmp_path / "out.amc"
    io.save(edited, out, like=src)
    back = read_amc(out, asf)
    _assert_same_motion(edited, back)
    assert out.read_text().count("\nrtibia ") == src.read_text().count("\nrtibia ") + 1


def test_radians_file_keeps_its_units(tmp_path):
    amc, asf, m = _sample(SAMPLES[0])
    plain = tmp_path / "deg.amc"
    write_amc(m, plain)
    dofs = dict(zip(m.skeleton.joint_names, amc_dofs(m.skeleton)))
    out_lines = []
    for ln in plain.read_text().splitlines():
        tok = ln.split()
        if ln == ":DEGREES":
            ln = ":RADIANS"
        elif tok and tok[0] in dofs:
            ln = " ".join([tok[0]] + [f"{np.radians(float(v)):.9f}" if d[0] == "r" else v
                                      for d, v in zip(dofs[tok[0]], tok[1:])])
        out_lines.append(ln)
    src = tmp_path / "rad.amc"
    src.write_text("\n".join(out_lines) + "\n")
    m = read_amc(src, asf)
    edited = _turned(m, 5, "lhumerus", 10.0)
    out = tmp_path / "out.amc"
    io.save(edited, out, like=src)
    assert ":RADIANS" in out.read_text()
    _assert_same_motion(edited, read_amc(out, asf))


def test_refusals_name_the_file_and_write_nothing(tmp_path):
    bvh = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    out = tmp_path / "x.amc"
    with pytest.raises(MocapFormatError, match=r"x\.amc.*ASF"):
        io.save(bvh, out)
    amc, asf, m = _sample(SAMPLES[0])
    rot = np.array(m.rotations)
    rot[3, 5] = np.nan
    with pytest.raises(MocapFormatError, match="NaN"):
        write_amc(dataclasses.replace(m, rotations=rot), out)
    check_amc_writable(dataclasses.replace(m, rotations=rot), out, missing_ok=True)  # before a fill: allowed
    still = next(j for j, d in enumerate(amc_dofs(m.skeleton)) if j and not d)
    rot = np.array(m.rotations)
    rot[:, still] = R.euler_to_quaternion(np.array([[30.0, 0.0, 0.0]]), "XYZ")
    with pytest.raises(MocapFormatError, match="no rotation dof"):
        write_amc(dataclasses.replace(m, rotations=rot), out)
    with pytest.raises(MocapFormatError, match="ASF"):
        io.check_writable(bvh, out)
    assert list(tmp_path.iterdir()) == []


def test_an_asf_listing_root_rotations_first_gets_its_own_order(tmp_path):
    amc, asf, m = _sample(SAMPLES[0])
    text = asf.read_text()
    assert "order TX TY TZ RX RY RZ" in text
    other = tmp_path / "subject.asf"
    other.write_text(text.replace("order TX TY TZ RX RY RZ", "order RX RY RZ TX TY TZ"))
    lines = []
    for ln in amc.read_text().splitlines(keepends=True):  # the same frames with the root line in that order
        if ln.startswith("root "):
            v = ln.split()[1:]
            ln = "root " + " ".join(v[3:] + v[:3]) + "\n"
        lines.append(ln)
    src = tmp_path / "subject_walk.amc"
    src.write_text("".join(lines))
    m = read_amc(src, other)
    _assert_same_motion(m, read_amc(amc, asf), deg=1e-9)
    out = tmp_path / "same.amc"
    io.save(m, out, like=src, asf=other)
    assert out.read_bytes() == src.read_bytes()
    edited = _turned(m, 7, "rfemur", 5.0)
    for like in (src, None):  # kept like the source, or written whole in the ASF's order
        io.save(edited, out, like=like, asf=other)
        _assert_same_motion(edited, read_amc(out, other))


@pytest.mark.parametrize("name", SAMPLES[:2])
def test_a_moved_root_written_like_its_file_keeps_the_move(name, tmp_path):
    """like=: a root-position edit (a filled root gap, a user's fix) is a changed cell too, not only rotations."""
    amc, asf, m = _sample(name)
    pos = np.array(m.root_positions)
    pos[10:15] += [2.0, 0.0, -1.0]
    edited = dataclasses.replace(m, root_positions=pos)
    out = tmp_path / "moved.amc"
    io.save(edited, out, like=amc)
    back = read_amc(out, asf)
    _assert_same_motion(edited, back)
    assert out.read_bytes() != amc.read_bytes()


def test_a_bone_added_to_a_crlf_frame_ends_its_line_as_the_file_does(tmp_path):
    amc, asf, m = _sample(SAMPLES[0])
    lines = amc.read_text().splitlines(keepends=True)
    at = [i for i, ln in enumerate(lines) if ln.startswith("rtibia ")][3]
    src = tmp_path / "crlf.amc"
    src.write_bytes("".join(lines[:at] + lines[at + 1:]).replace("\n", "\r\n").encode("latin-1"))  # frame 4 omits rtibia
    m = read_amc(src, asf)
    io.save(_turned(m, 3, "rtibia", 20.0), tmp_path / "out.amc", like=src)
    data = (tmp_path / "out.amc").read_bytes()
    assert b"\n" not in data.replace(b"\r\n", b"")  # the added rtibia line too


def test_a_take_at_another_rate_is_written_with_its_rate_and_reads_back_at_it(tmp_path):
    """An AMC has no rate field: a take at 60 fps gets mocapkit's comment line first (skipped by other readers as
    every '#' line), whatever its name says; at 120 fps the file is written as before, without it."""
    from tests.naive import naive_amc_parse

    amc, asf, m = _sample(SAMPLES[1])
    half = m.resample(60)
    for name in ("squat_60fps.amc", "HDM_bd_squat_001_120.amc", "86_30.amc"):
        out = tmp_path / name
        write_amc(half, out)
        text = out.read_text()
        assert text.startswith("# frame rate: 60 fps (mocapkit)\n:FULLY-SPECIFIED\n:DEGREES\n1\nroot "), name
        back = read_amc(out, asf)
        assert back.fps == 60.0 and back.num_frames == half.num_frames
        _assert_same_motion(half, back)
        frames, radians = naive_amc_parse(out)  # a reader that knows nothing of the line reads the same frames
        assert len(frames) == half.num_frames and not radians
    plain = tmp_path / "plain.amc"
    write_amc(m, plain)
    assert plain.read_text().startswith(":FULLY-SPECIFIED\n:DEGREES\n1\nroot ")  # 120 fps: as before, no rate line


def test_a_take_read_at_a_given_rate_written_like_its_file_keeps_every_frame_and_states_the_rate(tmp_path):
    amc, asf, _ = _sample(SAMPLES[0])
    m = read_amc(amc, asf, fps=60)
    out = tmp_path / "walk.amc"
    io.save(m, out, like=amc)
    data, src = out.read_bytes(), amc.read_bytes()
    line = b"# frame rate: 60 fps (mocapkit)\r\n"  # the file's line endings
    assert data == line + src
    assert read_amc(out, asf).fps == 60.0
    again = tmp_path / "again.amc"
    io.save(read_amc(out, asf), again, like=out)  # read at its stated rate: the same file
    assert again.read_bytes() == data
    back120 = tmp_path / "back120.amc"
    io.save(dataclasses.replace(read_amc(out, asf), fps=120.0), back120, like=out)
    assert back120.read_bytes() == src  # the stated rate, no longer needed, goes


def _bone_numbers(text, bone):
    """Per frame the numbers of ``bone``'s line in an AMC's text."""
    return np.array([[float(v) for v in ln.split()[1:]] for ln in text.splitlines() if ln.startswith(bone + " ")])


def test_a_bone_changed_in_every_frame_stays_on_each_frames_file_branch(tmp_path):
    """A denoised bone (every frame turned a little) is written on the branch the file has at each frame, also where
    the file's own numbers change branch mid-take (an angle wrapped past 180), not chained from its first frame."""
    amc, asf, m = _sample(SAMPLES[0])
    lines = amc.read_text().splitlines(keepends=True)
    seen, out_lines = 0, []
    for ln in lines:
        if ln.startswith("lfemur "):
            seen += 1
            if seen > 100:  # the same rotations, from frame 101 on every lfemur angle 360 degrees up
                ln = "lfemur " + " ".join(f"{float(v) + 360.0:.6f}" for v in ln.split()[1:]) + "\n"
        out_lines.append(ln)
    src = tmp_path / "wrapped.amc"
    src.write_text("".join(out_lines))
    m = read_amc(src, asf)
    j = m.skeleton.joint_names.index("lfemur")
    rot = np.array(m.rotations)
    wobble = np.radians(1.0) * np.sin(np.arange(m.num_frames) / 5.0)
    rot[:, j] = R.quaternion_multiply(rot[:, j], np.stack([np.cos(wobble / 2), np.sin(wobble / 2), 0 * wobble,
                                                           0 * wobble], axis=1))
    edited = dataclasses.replace(m, rotations=rot)
    out = tmp_path / "out.amc"
    io.save(edited, out, like=src)
    new, old = _bone_numbers(out.read_text(), "lfemur"), _bone_numbers(src.read_text(), "lfemur")
    assert new.shape == old.shape
    assert np.abs(new - old).max() < 5.0  # each frame on the file's branch of that frame
    _assert_same_motion(edited, read_amc(out, asf))


@pytest.mark.parametrize("name", SAMPLES)
def test_an_amc_written_from_an_npz_made_from_an_amc_keeps_the_files_numbers(name, tmp_path):
    """``convert take.amc take.npz`` then ``fill take.npz -o out.amc``: every untouched cell is the file's own number
    (its branch, no rounding), and a changed cell is the triple nearest the file's numbers of that cell."""
    amc, asf, m = _sample(name)
    z = io.save(m, tmp_path / "take.npz", like=amc)
    back = mocapkit.load(z)
    edited = _turned(back, 10, "rfemur", 3.0)
    out = io.save(edited, tmp_path / "out.amc", like=z, copy_asf=False)
    src_text, out_text = amc.read_text(encoding="latin-1"), out.read_text(encoding="latin-1")
    for bone in [n for n, d in zip(m.skeleton.joint_names, amc_dofs(m.skeleton)) if d]:
        a, b = _bone_numbers(src_text, bone), _bone_numbers(out_text, bone)
        assert a.shape == b.shape, bone
        rows = np.arange(len(a)) != 10 if bone == "rfemur" else np.ones(len(a), dtype=bool)
        assert np.array_equal(a[rows], b[rows]), bone  # the same numbers, not only the same rotations
    fem_a, fem_b = _bone_numbers(src_text, "rfemur")[10], _bone_numbers(out_text, "rfemur")[10]
    assert not np.array_equal(fem_a, fem_b) and np.abs(fem_a - fem_b).max() < 5.0
    _assert_same_motion(edited, read_amc(out, asf))


def test_an_output_that_cannot_keep_the_amc_comments_says_how_many_it_leaves_out(tmp_path):
    """HDM05's AMC opens with a ``#!OML:ASF`` comment line naming its skeleton's file. An AMC or .npz written like
    the file keeps it; a BVH, a resampled AMC or .npz, or a slice drops it, and said nothing of it before 0.15.0
    (a BVH's comments were said): now one line says how many it leaves out."""
    from mocapkit.io import motion_notes

    amc, asf, m = _sample(SAMPLES[2])
    assert motion_notes(m, tmp_path / "same.amc") == [] and motion_notes(m, tmp_path / "same.npz") == []
    why = "(an AMC's are kept only in an .amc or .npz written like it, at its frames and skeleton)"
    for out, take in (("out.bvh", m), ("half.amc", m.resample(60.0)), ("part.npz", m[10:50])):
        unit = [io.unit_note(take, tmp_path / out)] if out.endswith(".bvh") else []  # nor the ASF's length unit
        assert motion_notes(take, tmp_path / out) == [f"{tmp_path / out}: not written: 1 comment line of {amc} {why}"] + unit
    assert motion_notes(m[10:50], tmp_path / "part.amc") == []  # a slice written like the AMC: its header kept
    io.save(m, tmp_path / "same.npz")  # the .npz keeps the AMC's text: an AMC from it keeps the line, a BVH not
    kept = mocapkit.load(tmp_path / "same.npz")
    assert motion_notes(kept, tmp_path / "back.amc") == []
    assert motion_notes(kept, tmp_path / "back.bvh") == [
        f"{tmp_path / 'back.bvh'}: not written: 1 comment line of {tmp_path / 'same.npz'} {why}",
        io.unit_note(kept, tmp_path / "back.bvh")]
