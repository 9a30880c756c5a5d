"""mocapkit.io.takes: any take with an explicit ASF for AMC files; motion only where joint angles are needed."""

import shutil

import numpy as np
import pytest

import mocapkit
from mocapkit.errors import MocapFormatError
from mocapkit import samples
from mocapkit.io.takes import asf_for_output, check_asf, load_motion, load_take, place_asf


@pytest.fixture
def amc_apart(tmp_path):
    """12_walk.amc in one folder, its ASF under another name in another."""
    (tmp_path / "takes").mkdir()
    (tmp_path / "skel").mkdir()
    amc = tmp_path / "takes" / "walk.amc"
    shutil.copy(mocapkit.samples.path("12_walk.amc"), amc)
    asf = tmp_path / "skel" / "actor.asf"
    shutil.copy(mocapkit.samples.path("12.asf"), asf)
    return amc, asf


def test_asf_given_explicitly_reads_the_same_take(amc_apart):
    amc, asf = amc_apart
    with pytest.raises(MocapFormatError, match="no skeleton"):
        load_take(amc)
    m = load_motion(amc, asf)
    ref = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    np.testing.assert_array_equal(m.rotations, ref.rotations)
    assert m.skeleton.joint_names == ref.skeleton.joint_names


def test_asf_is_ignored_for_other_formats_but_must_serve_some_input(amc_apart):
    amc, asf = amc_apart
    bvh = mocapkit.samples.path("131_01.bvh")
    assert load_take(bvh, asf).num_frames == 994  # one asf= for a list of mixed inputs
    check_asf(asf, [bvh, amc, None])
    with pytest.raises(MocapFormatError, match="no input is an .amc file") as err:
        check_asf(asf, [bvh])
    assert str(asf) in str(err.value)
    with pytest.raises(MocapFormatError, match="no such file"):
        check_asf(asf.with_name("missing.asf"), [amc])
    with pytest.raises(MocapFormatError, match=r"\(\.asf\) is expected"):
        check_asf(bvh, [amc])
    check_asf(None, [])


def test_a_marker_file_is_refused_where_joint_angles_are_needed():
    c3d = mocapkit.samples.path("Eb015pr.c3d")
    assert load_take(c3d).num_markers > 0
    with pytest.raises(MocapFormatError, match="no joint angles, which clean needs") as err:
        load_motion(c3d, purpose="clean")
    assert "Eb015pr.c3d" in str(err.value) and "\n" not in str(err.value)


def test_asf_for_output_names_the_skeleton_an_amc_reads_back_with(tmp_path):
    src = samples.path("HDM_bd.asf")
    out = tmp_path / "o"
    assert asf_for_output(out / "x.bvh", src) is None  # not an AMC
    assert asf_for_output(out / "x.amc", None) is None
    assert asf_for_output(out / "HDM_bd_walk.amc", src) == out / "HDM_bd.asf"  # its own name: a prefix of the AMC's
    assert asf_for_output(out / "walk.amc", src) == out / "walk.asf"  # else the AMC's stem, picked whatever is there
    out.mkdir()
    (out / "HDM_bd.asf").write_bytes(src.read_bytes())
    assert asf_for_output(out / "HDM_bd_walk.amc", src) is None  # already there
    (out / "walk.asf").write_text("another skeleton")
    with pytest.raises(MocapFormatError, match="walk.asf: exists and differs"):
        asf_for_output(out / "walk.amc", src)
    assert asf_for_output(out / "walk.amc", src, overwrite=True) == out / "walk.asf"
    lone = tmp_path / "lone"
    lone.mkdir()
    (lone / "12.asf").write_bytes(samples.path("12.asf").read_bytes())
    (lone / "take.amc").write_text("")  # read with the folder's only ASF: a second one would change that
    with pytest.raises(MocapFormatError, match="would change the skeleton .*take.amc"):
        asf_for_output(lone / "jog.amc", src)


def test_place_asf_copies_it_whole(tmp_path):
    src = samples.path("HDM_bd.asf")
    place_asf(tmp_path / "HDM_bd.asf", src)
    place_asf(None, src)
    assert (tmp_path / "HDM_bd.asf").read_bytes() == src.read_bytes() and len(list(tmp_path.iterdir())) == 1


def test_asf_for_output_never_swaps_the_skeleton_another_amc_reads_with(tmp_path):
    """--overwrite replaces a file of the name, but not the ASF another AMC of the folder is read with."""
    out = tmp_path / "o"
    out.mkdir()
    (out / "HDM_bd.asf").write_bytes(samples.path("HDM_bd.asf").read_bytes())
    (out / "HDM_bd_01.amc").write_text("")  # reads with HDM_bd.asf
    other = tmp_path / "HDM_bd.asf"  # another actor's skeleton under the same name
    other.write_bytes(samples.path("HDM_bk.asf").read_bytes())
    for overwrite in (False, True):
        with pytest.raises(MocapFormatError, match="would change the skeleton HDM_bd_01.amc is read with"):
            asf_for_output(out / "HDM_bd_02.amc", other, overwrite=overwrite)
    assert (out / "HDM_bd.asf").read_bytes() == samples.path("HDM_bd.asf").read_bytes()


def test_check_asf_speaks_the_callers_language(amc_apart):
    """The library's keywords by default, the command line's flags where a command passes CLI_AMC_NAMES."""
    from mocapkit.errors import MocapError
    from mocapkit.io.takes import CLI_AMC_NAMES

    amc, asf = amc_apart
    bvh = mocapkit.samples.path("131_01.bvh")
    with pytest.raises(MocapFormatError, match=r"asf= is the skeleton of an \.amc input"):
        check_asf(asf, [bvh])
    with pytest.raises(MocapError, match=r"amc_fps= is the frame rate of an \.amc input"):
        check_asf(None, [bvh], 60)
    with pytest.raises(MocapFormatError, match=r"--asf is the skeleton of an \.amc input"):
        check_asf(asf, [bvh], names=CLI_AMC_NAMES)
    with pytest.raises(MocapError, match=r"--amc-fps is the frame rate of an \.amc input"):
        check_asf(None, [bvh], 60, names=CLI_AMC_NAMES)


def test_a_python_callers_unit_refusals_name_unit_not_the_clis_flag():
    """load_take, load_motion, with_unit and check_unit refused with the command line's ``--unit`` by default, which a
    Python caller has no way to give: by default they name ``unit=``; the CLI passes its own spelling."""
    from mocapkit.errors import MocapError
    from mocapkit.io.takes import check_unit, with_unit

    amc = samples.path("12_walk.amc")  # its ASF states its unit
    for call in (lambda: load_take(amc, unit="mm"), lambda: load_motion(amc, unit="mm"),
                 lambda: with_unit(mocapkit.load(amc), "mm", amc)):
        with pytest.raises(MocapFormatError) as exc:
            call()
        assert str(exc.value).endswith("not mm: unit= is for a file that states none") and "--unit" not in str(exc.value)
    for call in (lambda: load_take(amc, unit="furlong"), lambda: check_unit("furlong")):
        with pytest.raises(MocapError) as exc:
            call()
        assert str(exc.value).startswith("unit='furlong': one of") and "--unit" not in str(exc.value)
    with pytest.raises(MocapError, match=r"^--unit 'furlong': one of"):
        load_take(amc, unit="furlong", unit_option="--unit")
    with pytest.raises(MocapFormatError, match="not mm: --unit is for a file that states none"):
        load_motion(amc, unit="mm", unit_option="--unit")
