"""ASF/AMC reading: every real clip against an independent FK oracle, the AMC's own numbers,
skeleton conversion, skeleton lookup, bad files, and a golden comparison with a BVH conversion."""

from tests.shared import curated_files
import dataclasses
import re

import numpy as np
import pytest

import mocapkit
from mocapkit.errors import MocapFormatError
from mocapkit.io.asfamc import find_asf, fps_from_name, read_amc, read_asf
from mocapkit.motion import Motion, unit_scale_cm
from mocapkit.rotations import euler_to_quaternion, geodesic_angle
from tests.naive import naive_amc_parse, naive_asf_parse, naive_asfamc_fk
from tests.io.bounded import run_bounded

SAMPLES = [
    ("12_walk.amc", "12.asf"),
    ("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", "HDM_bd.asf"),
    ("HDM_bk_sneak2StepsLStart_004_120.amc", "HDM_bk.asf"),
]


def skeleton_size(m: Motion) -> float:
    rest = m.skeleton.rest_positions(end_sites=True)
    return float(np.linalg.norm(np.ptp(rest, axis=0)))


def oracle_positions(m: Motion, asf, amc, frames) -> np.ndarray:
    """The oracle's points arranged like ``global_positions(end_sites=True)``: root, bone starts, leaf tips."""
    sk = m.skeleton
    out = np.empty((len(frames), sk.num_joints + sk.num_end_sites, 3))
    for k, res in enumerate(naive_asfamc_fk(asf, amc, frames)):
        out[k, 0] = res["root"]
        for j, name in enumerate(sk.joint_names[1:], start=1):
            out[k, j] = res[name][0]
        for e, j in enumerate(sk.end_site_parents):
            out[k, sk.num_joints + e] = res[sk.joint_names[j]][1]
    return out


def check_against_oracle(m: Motion, asf, amc, frames):
    ours = m.global_positions(end_sites=True)[frames]
    ref = oracle_positions(m, asf, amc, frames)
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-9 * skeleton_size(m), err_msg=str(amc))


def amc_lines(name: str) -> list[str]:
    return mocapkit.samples.path(name).read_text(encoding="latin-1").splitlines()


def first_frame_line(lines: list[str]) -> int:
    return next(i for i, line in enumerate(lines) if line.strip() == "1")


# -- real clips against the oracle ----------------------------------------------------


def test_every_amc_in_shared_data_loads_and_matches_the_oracle(shared_data):
    files = curated_files(shared_data, "*.amc")
    assert len(files) >= 280
    for f in files:
        m = mocapkit.load(f)  # the ASF is found automatically
        frames, _ = naive_amc_parse(f, only=set())
        assert m.num_frames == len(frames) and m.name == f.stem, f.name
        assert m.num_joints == 31 and np.isfinite(m.rotations).all(), f.name
        assert m.fps == 120.0
        picks = sorted({0, 1, m.num_frames // 3, m.num_frames - 1})
        check_against_oracle(m, find_asf(f), f, picks)


@pytest.mark.parametrize("amc,asf", SAMPLES)
def test_bundled_clips_match_the_oracle(amc, asf):
    path = mocapkit.samples.path(amc)
    assert find_asf(path) == mocapkit.samples.path(asf)
    m = mocapkit.load(path)
    assert m.fps == 120.0 and m.num_joints == 31 and m.name == path.stem
    frames = sorted({0, 7, m.num_frames // 2, m.num_frames - 1})
    check_against_oracle(m, mocapkit.samples.path(asf), path, frames)


def test_cmu_root_positions_and_units(shared_data):
    m = mocapkit.load(shared_data / "cmu_asfamc" / "01_01.amc")
    frames, _ = naive_amc_parse(shared_data / "cmu_asfamc" / "01_01.amc")
    np.testing.assert_array_equal(m.root_positions, [f["root"][:3] for f in frames])
    for f in curated_files(shared_data, "*.asf"):
        sk = read_asf(f)
        assert sk.unit_cm == pytest.approx(2.54 / 0.45, rel=1e-15), f.name
        assert unit_scale_cm(sk) == pytest.approx(2.54 / 0.45, rel=1e-15), f.name


# -- the AMC's own numbers --------------------------------------------------------------


def amc_columns(m: Motion, amc_frames) -> tuple[np.ndarray, np.ndarray]:
    """The AMC values rearranged into ``channel_values()`` columns, and which columns are 3-dof middles."""
    sk = m.skeleton
    cols, middle = [], []
    for j, name in enumerate(sk.joint_names):
        chans = sk.joint_channels(j)
        vals = np.array([f.get(name, [0.0] * len(chans)) for f in amc_frames]).reshape(len(amc_frames), -1)
        if j == 0:  # TX TY TZ RX RY RZ -> positions, then rotations reversed
            vals = vals[:, [0, 1, 2, 5, 4, 3]]
        else:  # dof order reversed
            vals = vals[:, ::-1]
        n_rot = sum(c.endswith("rotation") for c in chans)
        for k in range(vals.shape[1]):
            cols.append(vals[:, k])
            middle.append(n_rot == 3 and k == len(chans) - 2)
    return np.stack(cols, axis=1), np.array(middle)


@pytest.mark.parametrize("amc", ["12_walk.amc", "HDM_bk_sneak2StepsLStart_004_120.amc"])
def test_channel_values_are_the_amc_numbers(amc):
    path = mocapkit.samples.path(amc)
    m = mocapkit.load(path)
    frames, _ = naive_amc_parse(path)
    expected, middle = amc_columns(m, frames)
    got = m.channel_values()
    assert got.shape == expected.shape
    names = m.channel_names()
    assert names[:6] == ["root.Xposition", "root.Yposition", "root.Zposition",
                         "root.Zrotation", "root.Yrotation", "root.Xrotation"]
    assert names[names.index("lfemur.Zrotation") + 2] == "lfemur.Xrotation"
    np.testing.assert_array_equal(got[:, :3], expected[:, :3])
    diff = (got[:, 3:] - expected[:, 3:] + 180.0) % 360.0 - 180.0  # angles are equal modulo 360
    # Away from gimbal lock the Euler triple is unique: the middle angle of 3-dof joints stays below 85 degrees.
    far = np.all(np.abs(expected[:, 3:][:, middle[3:]]) < 85.0, axis=1)
    assert far.mean() > 0.9
    assert np.abs(diff[far]).max() < 1e-6


def test_a_bone_missing_from_a_frame_gets_the_identity(tmp_path):
    lines = amc_lines("12_walk.amc")
    start = first_frame_line(lines)
    nxt = next(i for i in range(start + 1, len(lines)) if lines[i].strip() == "2")
    lfemur = next(i for i in range(nxt, nxt + 31) if lines[i].startswith("lfemur "))
    del lines[lfemur]
    p = tmp_path / "12_gap.amc"
    p.write_text("\n".join(lines) + "\n", encoding="latin-1")
    m = read_amc(p, asf=mocapkit.samples.path("12.asf"))
    full = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    j = m.skeleton.index("lfemur")
    np.testing.assert_allclose(m.rotations[1, j], [1.0, 0.0, 0.0, 0.0], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(m.rotations[0], full.rotations[0])
    np.testing.assert_array_equal(np.delete(m.rotations[1], j, axis=0), np.delete(full.rotations[1], j, axis=0))


# -- the skeleton ---------------------------------------------------------------------


def test_skeleton_conversion_follows_the_asf():
    path = mocapkit.samples.path("12.asf")
    sk = read_asf(path)
    asf = naive_asf_parse(path)
    bones = asf["bones"]
    assert sk.joint_names[:7] == ("root", "lhipjoint", "lfemur", "ltibia", "lfoot", "ltoes", "rhipjoint")
    assert sorted(sk.joint_names[1:]) == sorted(bones)
    for j, name in enumerate(sk.joint_names[1:], start=1):
        p = sk.parents[j]
        parent = sk.joint_names[p]
        assert name in asf["children"][parent]
        expected = np.zeros(3) if parent == "root" else bones[parent]["direction"] * bones[parent]["length"]
        np.testing.assert_array_equal(sk.offsets[j], expected)
        b = bones[name]
        np.testing.assert_allclose(sk.axes[j], euler_to_quaternion(b["axis"], b["axis_order"]), atol=1e-15)
        dof = b["dof"]
        assert sk.joint_channels(j) == tuple(f"{d[1].upper()}rotation" for d in reversed(dof))
        assert sk.rotation_order(j) == "".join(d[1].upper() for d in reversed(dof))
    leaves = [n for n in bones if n not in asf["children"]]
    assert sorted(sk.joint_names[j] for j in sk.end_site_parents) == sorted(leaves)
    for e, j in enumerate(sk.end_site_parents):
        b = bones[sk.joint_names[j]]
        np.testing.assert_array_equal(sk.end_site_offsets[e], b["direction"] * b["length"])
    assert sk.joint_channels(0) == ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
    # limits follow the channels: lfemur "limits (-160 20) (-70 70) (-60 70)" for rx ry rz, stored reversed
    assert sk.limits[sk.index("lfemur")] == ((-60.0, 70.0), (-70.0, 70.0), (-160.0, 20.0))
    assert sk.limits[sk.index("lfoot")] == ((-70.0, 20.0), (-45.0, 90.0))
    assert sk.limits[sk.index("lhipjoint")] == ()
    assert sk.unit_cm == pytest.approx(2.54 / 0.45)


TINY_ASF = """\
# a hand-made skeleton: comments, documentation, CRLF and Latin-1 (Müller)
:version 1.10
:name tiny
:units
  mass 1.0
  length {length}
  angle {angle}
:documentation
   Anything here is ignored: begin end dof rx  # and so are these words
:root
   order TX TY TZ RZ RY RX
   axis XYZ
   position 0 0 0
   orientation {orient}
:bonedata
  begin
     id 1
     name hip
     direction 0 -1 0
     length 2
     axis {axis1} ZYX
    dof rz rx
    limits ({lo1} {hi1})
           ({lo2} {hi2})
  end
  begin
     id 2
     name knee
     direction 0 0 1
     length 3
     axis 0 0 0 XYZ
     bodymass 2.0
    dof ry
    limits (-inf inf)
  end
  begin
     id 3
     name spine
     direction 0 1 0
     length 4
     axis 0 0 0 XYZ
  end
:hierarchy
  begin
    root hip spine
    hip knee
  end
"""

TINY_AMC = """\
# motion for the tiny skeleton
:FULLY-SPECIFIED
:{unit}
0
root 1 2 3 {r1} {r2} {r3}
hip {h1} {h2}
knee {k1}
spine
1
root 1.5 2 3 {r1} {r2} {r3}
knee {k1}
hip {h1} {h2}
"""


def write_tiny(folder, radians: bool, crlf: bool = False):
    conv = np.radians if radians else (lambda v: v)
    f = lambda v: repr(float(conv(v)))  # noqa: E731
    asf = TINY_ASF.format(
        length=0.5, angle="rad" if radians else "deg", orient=" ".join(f(v) for v in (10, 20, 30)),
        axis1=" ".join(f(v) for v in (15, -25, 35)), lo1=f(-60), hi1=f(60), lo2=f(-10), hi2=f(170),
    )
    amc = TINY_AMC.format(
        unit="RADIANS" if radians else "DEGREES", r1=f(40), r2=f(-50), r3=f(60), h1=f(30), h2=f(-45), k1=f(70)
    )
    nl = "\r\n" if crlf else "\n"
    (folder / "tiny.asf").write_bytes(asf.replace("\n", nl).encode("latin-1"))
    (folder / "tiny_01.amc").write_bytes(amc.replace("\n", nl).encode("latin-1"))
    return folder / "tiny.asf", folder / "tiny_01.amc"


@pytest.mark.parametrize("radians,crlf", [(False, False), (False, True), (True, False)])
def test_hand_made_skeleton(tmp_path, radians, crlf):
    asf, amc = write_tiny(tmp_path, radians, crlf)
    sk = read_asf(asf)
    assert sk.joint_names == ("root", "hip", "knee", "spine")
    np.testing.assert_array_equal(sk.parents, [-1, 0, 1, 0])
    np.testing.assert_allclose(sk.offsets, [[0, 0, 0], [0, 0, 0], [0, -2, 0], [0, 0, 0]])
    np.testing.assert_array_equal(sk.end_site_parents, [2, 3])
    np.testing.assert_allclose(sk.end_site_offsets, [[0, 0, 3], [0, 4, 0]])
    assert sk.channels == (
        ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"),
        ("Xrotation", "Zrotation"),
        ("Yrotation",),
        (),
    )
    np.testing.assert_allclose(sk.limits[1], ((-10, 170), (-60, 60)), atol=1e-12)
    assert sk.limits[2] == ((-np.inf, np.inf),)
    assert sk.unit_cm == pytest.approx(5.08)
    np.testing.assert_allclose(sk.axes[1], euler_to_quaternion([15, -25, 35], "zyx"), atol=1e-14)
    np.testing.assert_allclose(sk.axes[0], euler_to_quaternion([10, 20, 30], "xyz"), atol=1e-14)
    m = read_amc(amc)
    assert m.num_frames == 2 and m.fps == 120.0 and m.name == "tiny_01"
    np.testing.assert_array_equal(m.root_positions, [[1, 2, 3], [1.5, 2, 3]])
    check_against_oracle(m, asf, amc, [0, 1])
    # the spine has no dof: identity; bones listed in any order
    np.testing.assert_array_equal(m.rotations[:, 3], [[1, 0, 0, 0]] * 2)
    np.testing.assert_allclose(m.rotations[0, 1:3], m.rotations[1, 1:3], atol=1e-15)
    ch = m.channel_values()
    np.testing.assert_allclose(ch[0], [1, 2, 3, 60, -50, 40, -45, 30, 70], atol=1e-9)


def test_radians_files_give_the_same_motion(tmp_path):
    (tmp_path / "deg").mkdir()
    (tmp_path / "rad").mkdir()
    a = read_amc(write_tiny(tmp_path / "deg", False)[1])
    b = read_amc(write_tiny(tmp_path / "rad", True)[1])
    assert np.degrees(geodesic_angle(a.rotations, b.rotations)).max() < 1e-9
    np.testing.assert_allclose(a.global_positions(end_sites=True), b.global_positions(end_sites=True), atol=1e-12)


def test_skeleton_given_directly(tmp_path):
    path = mocapkit.samples.path("12_walk.amc")
    sk = read_asf(mocapkit.samples.path("12.asf"))
    a = read_amc(path, asf=sk, fps=30)
    b = mocapkit.load(path)
    assert a.fps == 30.0 and a.skeleton is sk
    np.testing.assert_array_equal(a.rotations, b.rotations)
    np.testing.assert_array_equal(a.root_positions, b.root_positions)


# -- finding the skeleton, the frame rate ----------------------------------------------


def _touch(folder, *names, amc_text=None):
    folder.mkdir(parents=True, exist_ok=True)
    asf = mocapkit.samples.path("12.asf").read_bytes()
    for n in names:
        (folder / n).write_bytes(amc_text if n.endswith(".amc") and amc_text else asf)
    return folder


@pytest.mark.parametrize(
    "amc,others,expected",
    [
        ("07_01.amc", ["07.asf", "08.asf", "0.asf", "07_0.asf", "07_01x.asf"], "07.asf"),
        ("HDM_bd_kick_001_120.amc", ["HDM_bd.asf", "HDM_b.asf", "HDM_bk.asf", "HDM.asf"], "HDM_bd.asf"),
        ("charleston1.amc", ["charleston.asf", "lambada.asf", "charle.asf"], "charleston.asf"),
        ("12_from_examples_02_01.amc", ["12.asf", "1.asf", "02.asf", "12_from.asf"], "12_from.asf"),
        ("12_from_examples_02_01.amc", ["12.asf", "1.asf", "02.asf"], "12.asf"),
        ("walk.amc", ["subject.asf"], "subject.asf"),
        ("walk.amc", ["WALK.ASF", "other.asf"], "WALK.ASF"),
    ],
)
def test_skeleton_lookup(tmp_path, amc, others, expected):
    folder = _touch(tmp_path / "d", *others)
    assert find_asf(folder / amc).name == expected


def test_missing_skeleton_names_the_file_looked_for(tmp_path):
    folder = _touch(tmp_path / "none", "08.asf", "10.asf")
    amc = folder / "09_01.amc"
    amc.write_bytes(mocapkit.samples.path("12_walk.amc").read_bytes())
    with pytest.raises(MocapFormatError, match=r"09_01\.amc: no skeleton: looked for .*09\.asf"):
        mocapkit.load(amc)
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "HDM_xx_walk_001_120.amc").write_bytes(amc.read_bytes())
    with pytest.raises(MocapFormatError, match=r"HDM\.asf.*no ASF files"):
        read_amc(empty / "HDM_xx_walk_001_120.amc")
    with pytest.raises(MocapFormatError, match=r"nope\.asf: no such ASF file"):
        read_amc(amc, asf=tmp_path / "nope.asf")
    m = read_amc(amc, asf=mocapkit.samples.path("12.asf"), fps=60)
    assert m.fps == 60.0 and m.name == "09_01"


def test_fps_from_name():
    # only HDM05's naming carries a rate; a number ending any other name is no rate (CMU's SUBJECT_TRIAL)
    assert fps_from_name("HDM_bd_kick_001_120") == 120.0
    assert fps_from_name("HDM_tr_05-01_01_120") == 120.0
    assert fps_from_name("clip_60") is None
    assert fps_from_name("86_30") is None and fps_from_name("135_100") is None
    assert fps_from_name("07_01") is None
    assert fps_from_name("charleston1") is None
    assert fps_from_name("HDM_bd_take_20000") is None
    assert fps_from_name("120") is None
    assert fps_from_name("walk") is None


def test_fps_comes_from_the_hdm05_name_else_120(tmp_path):
    folder = _touch(tmp_path, "12.asf")
    body = mocapkit.samples.path("12_walk.amc").read_bytes()
    for name, fps in [("12_walk_60.amc", 120.0), ("12_30.amc", 120.0), ("12_walk.amc", 120.0),
                      ("12_HDM_bd_walk_001_60.amc", 120.0)]:
        (folder / name).write_bytes(body)
        assert mocapkit.load(folder / name).fps == fps, name
    _copy(tmp_path, "12.asf", "HDM_bd.asf")
    (folder / "HDM_bd_walk_001_60.amc").write_bytes(body)
    assert mocapkit.load(folder / "HDM_bd_walk_001_60.amc").fps == 60.0
    assert mocapkit.load(folder / "12_walk_60.amc", fps=25).fps == 25.0


def test_a_cmu_trial_numbered_30_reads_at_120_fps(shared_data, tmp_path):
    """CMU names its takes SUBJECT_TRIAL: trial 30 of subject 86 is no 30 fps take (CMU captured at 120 Hz)."""
    from mocapkit.io.asfamc import amc_rate

    src = shared_data / "cmu_asfamc" / "11_01.amc"
    (tmp_path / "86.asf").write_bytes((shared_data / "cmu_asfamc" / "11.asf").read_bytes())
    (tmp_path / "86_30.amc").write_bytes(src.read_bytes())
    m = read_amc(tmp_path / "86_30.amc")
    ref = read_amc(src)
    assert m.fps == ref.fps == 120.0 and m.num_frames == ref.num_frames == 597
    assert m.duration == pytest.approx(4.975)
    assert amc_rate(tmp_path / "86_30.amc") == (120.0, "default")
    assert amc_rate(tmp_path / "86_30.amc", 60) == (60.0, "given")
    assert amc_rate(shared_data / "hdm05_asfamc" / "HDM_bd_squat1Reps_001_120.amc") == (120.0, "name")


def test_the_rate_a_file_states_in_its_comment_line_wins_over_the_name(tmp_path):
    from mocapkit.io.asfamc import amc_rate, rate_comment

    folder = _touch(tmp_path, "HDM_bd.asf")
    body = mocapkit.samples.path("12_walk.amc").read_bytes()
    assert rate_comment(60) == "# frame rate: 60 fps (mocapkit)"
    assert rate_comment(30000 / 1001) == f"# frame rate: {30000 / 1001!r} fps (mocapkit)"
    for fps in (60.0, 30000 / 1001, 2000.0):
        amc = folder / "HDM_bd_walk_001_120.amc"
        amc.write_bytes(rate_comment(fps).encode() + b"\n" + body)
        assert read_amc(amc).fps == fps and amc_rate(amc) == (fps, "file")
        assert read_amc(amc, fps=50).fps == 50.0
    # a comment of anyone else's is no rate, and a comment after the first frame is not read for one
    amc.write_bytes(b"# frame rate of the cameras was 60 fps\n" + body)
    assert read_amc(amc).fps == 120.0
    assert body.startswith(b"#!OML:ASF")  # the CMU header comment line the reader skips
    first = re.search(rb"\n1\r?\n", body).end()
    amc.write_bytes(body[:first] + rate_comment(60).encode() + b"\n" + body[first:])
    assert read_amc(amc).fps == 120.0
    amc.write_bytes(rate_comment(0.5).encode() + b"\n" + body)
    with pytest.raises(MocapFormatError, match=r"HDM_bd_walk_001_120\.amc: frame rate: fps must be a positive number"):
        read_amc(amc)


def _copy(folder, name, new=None):
    dst = folder / (new or name)
    dst.write_bytes(mocapkit.samples.path(name).read_bytes())
    return dst


def test_prefix_must_end_at_a_boundary(tmp_path):
    amc = _copy(tmp_path, "12_walk.amc", "071_01.amc")
    _copy(tmp_path, "12.asf", "07.asf")
    _copy(tmp_path, "12.asf", "08.asf")
    with pytest.raises(MocapFormatError, match="071.asf"):
        find_asf(amc)
    dance = tmp_path / "dance"
    dance.mkdir()
    amc = _copy(dance, "12_walk.amc", "charleston1.amc")
    _copy(dance, "12.asf", "charleston.asf")
    _copy(dance, "12.asf", "lambada.asf")
    assert find_asf(amc).name == "charleston.asf"


# -- bad files ------------------------------------------------------------------------


@pytest.fixture
def walk():
    lines = amc_lines("12_walk.amc")
    start = first_frame_line(lines)
    second = next(i for i in range(start + 1, len(lines)) if lines[i].strip() == "2")
    return lines, start, second


def _write(tmp_path, name, lines):
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n", encoding="latin-1")
    return p


def _edit(lines, i, text):
    out = list(lines)
    out[i] = text
    return out


def test_bad_amc_files(tmp_path, walk):
    lines, start, second = walk
    asf = mocapkit.samples.path("12.asf")
    first_bone = lines[start + 2]
    cases = [
        ("unknown.amc", _edit(lines, start + 3, "tail 1 2 3"), start + 4,
         r"AMC names joint 'tail' that the ASF 12\.asf lacks"),
        ("few.amc", _edit(lines, start + 2, first_bone.rsplit(" ", 1)[0]), start + 3,
         r"joint lowerback needs 3 values \(rx ry rz\), got 2"),
        ("many.amc", _edit(lines, start + 2, first_bone + " 4"), start + 3, r"needs 3 values .*got 4"),
        ("nonnum.amc", _edit(lines, start + 2, "lowerback 1 x 3"), start + 3, r"non-numeric value 'x'"),
        ("gap.amc", _edit(lines, second, "5"), second + 1,
         r"frame 5 follows frame 1: frame numbers must be consecutive"),
        ("back.amc", _edit(lines, second, "1"), second + 1, r"frame 1 follows frame 1"),
        ("twice.amc", _edit(lines, start + 3, first_bone), start + 4, r"appears twice in frame 1"),
        ("framenum.amc", _edit(lines, second, "2 3"), second + 1, r"expected a frame number"),
        ("early.amc", lines[:start] + lines[start + 1 :], start + 1, r"before the first frame number"),
    ]
    for name, text, line, message in cases:
        with pytest.raises(MocapFormatError, match=rf"{re.escape(name)}:{line}: (.* )?{message}"):
            read_amc(_write(tmp_path, name, text), asf=asf)
    with pytest.raises(MocapFormatError, match=r"zero\.amc: no frames"):
        read_amc(_write(tmp_path, "zero.amc", lines[:start]), asf=asf)
    with pytest.raises(MocapFormatError, match=r"trunc\.amc:\d+: truncated: the last frame \(2\) lists 4 of 29 joints"):
        read_amc(_write(tmp_path, "trunc.amc", lines[: second + 5]), asf=asf)
    with pytest.raises(MocapFormatError, match=r"cut\.amc:\d+: .*needs 3 values"):
        read_amc(_write(tmp_path, "cut.amc", lines[: second + 4] + [lines[second + 4].rsplit(" ", 1)[0]]), asf=asf)


def test_bad_asf_files(tmp_path):
    good = mocapkit.samples.path("12.asf").read_text(encoding="latin-1")

    def bad(text, name="bad.asf"):
        p = tmp_path / name
        p.write_text(text, encoding="latin-1")
        return p

    with pytest.raises(MocapFormatError, match=r"bad\.asf:\d+: dof l .*not supported"):
        read_asf(bad(good.replace("dof rx\n", "dof rx l\n", 1)))
    with pytest.raises(MocapFormatError, match=r"bad\.asf:\d+: .*tx on a bone .*not supported"):
        read_asf(bad(good.replace("dof rx\n", "dof rx tx\n", 1)))
    with pytest.raises(MocapFormatError, match=r"bad\.asf:\d+: hierarchy names bone 'lfemr'"):
        read_asf(bad(good.replace("lhipjoint lfemur", "lhipjoint lfemr")))
    with pytest.raises(MocapFormatError, match=r"bad\.asf:\d+: bone 'ltibia' has 2 limits for 1 dofs"):
        read_asf(bad(good.replace("limits (-10.0 170.0)", "limits (-10.0 170.0)\n (0 1)", 1)))
    with pytest.raises(MocapFormatError, match=r"bad\.asf:\d+: direction: non-numeric"):
        read_asf(bad(good.replace("direction 0.34202 -0.939693 0", "direction 0.34202 -0.9x 0", 1)))
    with pytest.raises(MocapFormatError, match=r"bad\.asf: bones not reachable from root.*lthumb"):
        read_asf(bad(re.sub(r"lwrist lhand lthumb", "lwrist lhand", good)))
    with pytest.raises(MocapFormatError, match=r"bad\.asf:\d+: units angle must be deg or rad"):
        read_asf(bad(good.replace("angle deg", "angle grad")))


# -- golden: the same take converted to BVH by cgspeed ------------------------------------


def test_cmu_amc_equals_its_cgspeed_bvh_conversion(shared_data):
    """01_01.amc read here against cgspeed's BVH of the same take (which adds a T-pose as frame 0).

    Found empirically: same joint order (root/Hips, lhipjoint/LHipJoint, ...), same length unit
    (scale 1), offsets equal to the BVH's 5 decimals, except that the converter writes zero offsets
    for Neck, the shoulders (collapsing the thorax bone), the finger bases and thumbs (collapsing the
    wrist bone). With those seven offsets zeroed, every joint and end site of every frame agrees to
    1e-4 units (0.6 mm), the precision of the BVH's printed numbers.
    """
    amc = mocapkit.load(shared_data / "cmu_asfamc" / "01_01.amc")
    bvh = mocapkit.load(shared_data / "cmu_bvh" / "01_01.bvh")
    assert bvh.num_frames == amc.num_frames + 1
    assert bvh.fps == pytest.approx(amc.fps)
    pairs = dict(zip(amc.skeleton.joint_names, bvh.skeleton.joint_names))
    assert [pairs[n] for n in ("root", "lfemur", "ltibia", "thorax", "lowerneck", "lclavicle", "lhand", "rthumb")] == [
        "Hips", "LeftUpLeg", "LeftLeg", "Spine1", "Neck", "LeftShoulder", "LeftFingerBase", "RThumb"
    ]
    np.testing.assert_array_equal(amc.skeleton.parents, bvh.skeleton.parents)
    np.testing.assert_array_equal(amc.skeleton.end_site_parents, bvh.skeleton.end_site_parents)
    collapsed = np.linalg.norm(bvh.skeleton.offsets, axis=1) == 0
    had_length = np.linalg.norm(amc.skeleton.offsets, axis=1) > 0
    names = {amc.skeleton.joint_names[j] for j in np.flatnonzero(collapsed & had_length)}
    assert names == {"lowerneck", "lclavicle", "rclavicle", "lhand", "lthumb", "rhand", "rthumb"}
    offsets = np.array(amc.skeleton.offsets)
    offsets[collapsed] = 0.0
    np.testing.assert_allclose(offsets, bvh.skeleton.offsets, rtol=0, atol=1e-5)
    np.testing.assert_allclose(amc.skeleton.end_site_offsets, bvh.skeleton.end_site_offsets, rtol=0, atol=1e-5)
    as_bvh = dataclasses.replace(amc, skeleton=dataclasses.replace(amc.skeleton, offsets=offsets))
    ours = as_bvh.global_positions(end_sites=True)
    theirs = bvh.global_positions(end_sites=True)[1:]
    assert np.abs(ours - theirs).max() < 1e-4
    # without the collapse the head and arms sit a thorax length (2.06 units) away
    gap = np.linalg.norm(amc.global_positions() - bvh.global_positions()[1:], axis=-1).max(axis=0)
    thorax_length = np.linalg.norm(amc.skeleton.offsets[amc.skeleton.index("lowerneck")])
    assert gap[amc.skeleton.index("head")] == pytest.approx(thorax_length, abs=1e-3)


# -- round trips through the other formats ----------------------------------------------------


def test_amc_motions_round_trip_through_bvh_and_npz(tmp_path, shared_data):
    files = curated_files(shared_data, "*.amc")[::25] + [mocapkit.samples.path("12_walk.amc")]
    for f in files:
        m = mocapkit.load(f)
        ref = m.global_positions(end_sites=True)
        size = np.ptp(ref.reshape(-1, 3), axis=0).max()
        for suffix in (".bvh", ".npz"):
            back = mocapkit.load(mocapkit.save(m, tmp_path / (f.stem + suffix)))
            got = back.global_positions(end_sites=True)
            tol = 1e-5 * size if suffix == ".bvh" else 0.0  # BVH holds 6 decimals; npz is exact
            np.testing.assert_allclose(got, ref, atol=tol, rtol=0, err_msg=f"{f.name} via {suffix}")


def test_a_frame_rate_outside_1_to_10000_fps_is_refused(tmp_path):
    amc = mocapkit.samples.path("12_walk.amc")
    asf = mocapkit.samples.path("12.asf")
    for fps in (0.01, 1e6):
        with pytest.raises(MocapFormatError) as exc:
            read_amc(amc, asf=asf, fps=fps)
        assert str(exc.value) == (
            f"{amc}: frame rate: fps must be a positive number from 1 to 10000 (frames per second), got {fps!r}"
        )


def test_missing_skeleton_says_how_to_name_one_on_the_command_line_and_in_python(tmp_path):
    amc = tmp_path / "09_01.amc"
    amc.write_bytes(mocapkit.samples.path("12_walk.amc").read_bytes())
    with pytest.raises(MocapFormatError) as exc:
        read_amc(amc)
    msg = str(exc.value)
    assert msg.endswith("name the skeleton with --asf FILE (command line) or asf=FILE (Python)") and "\n" not in msg


@pytest.mark.parametrize("chunk", [300, 4096])
def test_frames_straddling_chunks_read_as_one_piece(tmp_path, walk, monkeypatch, chunk):
    # the body is parsed in pieces of about _CHUNK_BYTES; tiny pieces split frames and bone lines everywhere
    from mocapkit.io import asfamc

    lines, start, second = walk
    asf = mocapkit.samples.path("12.asf")
    text = list(lines)
    text.insert(second + 3, "# a comment between two bone lines")
    path = _write(tmp_path, "walk.amc", text)
    whole = read_amc(path, asf=asf)
    monkeypatch.setattr(asfamc, "_CHUNK_BYTES", chunk)
    pieces = read_amc(path, asf=asf)
    np.testing.assert_array_equal(pieces.rotations, whole.rotations)
    np.testing.assert_array_equal(pieces.root_positions, whole.root_positions)
    first_bone = lines[start + 2]
    cases = [
        ("twice.amc", _edit(lines, second + 20, first_bone), second + 21, r"appears twice in frame 2"),
        ("gap.amc", _edit(lines, second, "5"), second + 1, r"frame 5 follows frame 1"),
        ("unknown.amc", _edit(lines, second + 25, "tail 1 2 3"), second + 26, r"AMC names joint 'tail'"),
    ]
    for name, bad, line, message in cases:
        with pytest.raises(MocapFormatError, match=rf"{re.escape(name)}:{line}: (.* )?{message}"):
            read_amc(_write(tmp_path, name, bad), asf=asf)
    with pytest.raises(MocapFormatError, match=r"trunc\.amc:\d+: truncated: the last frame \(2\) lists 4 of 29 joints"):
        read_amc(_write(tmp_path, "trunc.amc", lines[: second + 5]), asf=asf)


def test_an_overlong_line_is_refused_without_parsing_it(tmp_path, walk):
    lines, start, second = walk
    path = _write(tmp_path, "long.amc", lines[: second + 1] + ["lowerback " + "1 " * 600_000] + lines[second + 1 :])
    with pytest.raises(MocapFormatError, match=rf"long\.amc:{second + 2}: line longer than 1,048,576 bytes"):
        read_amc(path, asf=mocapkit.samples.path("12.asf"))


def test_reading_a_large_amc_holds_a_small_multiple_of_the_file(tmp_path, walk):
    # the reader held about 19x the file (its vectorised temporaries over the whole text) before checking lines
    lines, start, second = walk
    frame = lines[start + 1 : second]  # the bone lines of frame 1
    out = lines[:start]
    for k in range(1, 12_001):
        out.append(str(k))
        out.extend(frame)
    path = _write(tmp_path, "long_take.amc", out)
    size = path.stat().st_size
    assert size > 8_000_000
    code = f"""
    import resource
    import mocapkit
    from mocapkit.io.asfamc import read_amc
    asf = mocapkit.samples.path("12.asf")
    read_amc(mocapkit.samples.path("12_walk.amc"), asf=asf)  # compiled and warmed up
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    m = read_amc({str(path)!r}, asf=asf)
    print(m.num_frames, (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) * 1024)
    """
    res = run_bounded(code)
    assert res.returncode == 0, res.stderr[-2000:]
    frames, growth = map(int, res.stdout.split())
    assert frames == 12_000
    assert growth < 4 * size, growth / size  # the Motion itself is about 1.3x the text


@pytest.mark.parametrize("new_name", ["x" * 2**20, "lhumérus✓"])
def test_a_very_long_or_non_latin1_joint_name_is_looked_up_without_a_huge_table(new_name):
    # names are matched through a (joints, longest name) byte table: 31 joints x 1 MiB would be 31 MiB per chunk
    sk = read_asf(mocapkit.samples.path("12.asf"))
    names = list(sk.joint_names)
    names[names.index("lhumerus")] = new_name
    renamed = dataclasses.replace(sk, joint_names=tuple(names))
    with pytest.raises(MocapFormatError, match=r"12_walk\.amc:\d+: AMC names joint 'lhumerus' that the ASF skeleton lacks"):
        read_amc(mocapkit.samples.path("12_walk.amc"), asf=renamed)


def test_an_asf_with_more_bones_than_a_skeleton_may_hold_is_refused(monkeypatch):
    from mocapkit.io import asfamc

    monkeypatch.setattr(asfamc, "MAX_JOINTS", 10)
    asf = mocapkit.samples.path("12.asf")
    begins = [i + 1 for i, s in enumerate(asf.read_text(encoding="latin-1").splitlines()) if s.strip() == "begin"]
    with pytest.raises(MocapFormatError) as exc:
        read_asf(asf)
    assert str(exc.value) == f"{asf}:{begins[9]}: more than 9 bones: not a skeleton mocapkit reads"
