"""`mocapkit info`, `convert`, `corrupt` and `plot` on real takes."""

from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.cli import main
from tests.cli.helpers import SAMPLE, WALK, one_error_line, run


def test_info_on_bvh_and_c3d(capsys):
    assert main(["info", SAMPLE]) == 0
    out = capsys.readouterr().out
    assert "994" in out and "120" in out and "31" in out and "5.644 cm" in out
    assert main(["info", str(mocapkit.samples.path("Eb015pr.c3d"))]) == 0
    out = capsys.readouterr().out
    assert "26" in out and "1.93 %" in out
    # what the C3D holds besides markers, one line each (info said nothing of them)
    for line in ("analogs       16 channels at 200 Hz", "force plates  2 (type 2)", "events        3 (1 RIC, 1 RHS, 1 RTO)"):
        assert line in out
    assert "first frame" not in out  # numbered from 1, as files are: nothing to say


def test_convert_resamples_and_round_trips(tmp_path):
    out = tmp_path / "clip30.npz"
    assert main(["convert", SAMPLE, str(out), "--fps", "30"]) == 0
    m = mocapkit.load(out)
    ref = mocapkit.load(SAMPLE)
    assert m.fps == 30 and m.num_frames == 249
    np.testing.assert_array_equal(m.rotations, ref.rotations[::4])


def test_corrupt_writes_motion_and_ground_truth(tmp_path):
    out = tmp_path / "noisy.bvh"
    assert main(["corrupt", SAMPLE, str(out), "--kind", "noise", "--amount", "0.5", "--seed", "3"]) == 0
    mask_file = tmp_path / "noisy.mask.npz"
    assert out.is_file() and mask_file.is_file()
    with np.load(mask_file) as z:
        mask = z["mask"]
        assert z["joint_names"].tolist() == list(mocapkit.load(SAMPLE).skeleton.joint_names)
    assert mask.shape == (994, 31) and mask.any()
    bad = mocapkit.load(out)
    ref = mocapkit.load(SAMPLE)
    changed = np.degrees(mocapkit.rotations.geodesic_angle(bad.rotations, ref.rotations)) > 1e-3
    assert not changed[~mask].any()



@pytest.mark.parametrize("take", [SAMPLE, str(WALK)], ids=["bvh", "amc"])
def test_corrupt_keeps_the_inputs_text_where_no_cell_changed(take, tmp_path):
    """A corrupted copy differs from its input only in the masked cells' text: the header as written (mixed line
    endings, the Frame Time, comment lines) and every frame without a changed joint (every line was rewritten:
    1,508 angles of 131_01 on other 360-degree branches, the AMC's header comments dropped)."""
    out = tmp_path / ("bad" + Path(take).suffix)
    assert main(["corrupt", take, str(out), "--kind", "errors", "--seed", "4"]) == 0
    with np.load(tmp_path / "bad.mask.npz") as z:
        mask = z["mask"]
    src, got = Path(take).read_bytes().splitlines(keepends=True), out.read_bytes().splitlines(keepends=True)
    assert len(src) == len(got)
    differ = [i for i, (a, b) in enumerate(zip(src, got)) if a != b]
    assert differ and len(differ) <= mask.any(axis=1).sum() * (mask.shape[1] if take.endswith(".amc") else 1)
    assert len(differ) < 0.5 * len(src)


def test_plot_writes_png(tmp_path):
    noisy = tmp_path / "noisy.bvh"
    assert main(["corrupt", SAMPLE, str(noisy), "--kind", "noise", "--seed", "1"]) == 0
    png = tmp_path / "knee.png"
    assert main(["plot", SAMPLE, str(noisy), "--joint", "LeftKnee", "-o", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_gaps_cannot_go_to_bvh_and_leave_nothing(tmp_path):
    out = tmp_path / "gappy.bvh"
    code, _, err = run("corrupt", SAMPLE, str(out), "--kind", "gaps", "--seed", "1")
    assert code == 2 and one_error_line(err)
    assert "this corruption leaves missing values (NaN), which BVH cannot hold; write .npz" in " ".join(err.split())
    assert list(tmp_path.iterdir()) == []
    out = tmp_path / "gappy.npz"
    code, _, _ = run("corrupt", SAMPLE, str(out), "--kind", "gaps", "--seed", "1")
    assert code == 0 and mocapkit.load(out).missing().any()




# -- names through rich, rigs without human joints, long paths, --asf -----------------------------


def _renamed(m, names: dict, clip: str):
    """``m`` with joints renamed (old -> new) and the clip called ``clip``."""
    import dataclasses

    sk = dataclasses.replace(m.skeleton, joint_names=tuple(names.get(n, n) for n in m.skeleton.joint_names))
    return dataclasses.replace(m, skeleton=sk, name=clip)


@pytest.mark.parametrize("knee, root, clip, file", [
    ("[/b]", "[bold]root", "[/]", "[red]take[/].npz"),  # rich markup
    ("repair:b:3-4", ":smile:", ":ok:", "take:b:.npz"),  # emoji codes: ``:b:`` of a change id read as an emoji
])
def test_markup_and_emoji_codes_in_names_are_printed_as_is(tmp_path, capsys, knee, root, clip, file):
    """Joint, take and file names print as given: rich read ``[bold]`` as markup and ``:b:`` of a change id
    ``repair:b:3-4`` as an emoji (``repair🅱3-4``)."""
    m = _renamed(mocapkit.load(SAMPLE)[:120], {"LeftKnee": knee, "Hips": root}, clip)
    inp = tmp_path / file
    mocapkit.save(m, inp)
    assert main(["info", str(inp), "--joints"]) == 0
    out = capsys.readouterr().out
    assert knee in out and root in out and str(inp) in out and clip in out
    assert "\N{NEGATIVE SQUARED LATIN CAPITAL LETTER B}" not in out
    dest = tmp_path / f"{clip}out.npz"
    assert main(["convert", str(inp), str(dest)]) == 0
    assert str(dest) in capsys.readouterr().out and dest.is_file()


def test_info_on_a_rig_without_human_joints(tmp_path, capsys):
    from mocapkit.motion import ROLES, Motion, Skeleton

    sk = Skeleton(("Base", "Link1", "Link2"), np.array([-1, 0, 1]), np.array([[0, 0, 0], [0, 1, 0], [0, 1, 0]], float))
    rot = np.zeros((10, 3, 4))
    rot[..., 0] = 1
    inp = tmp_path / "arm.npz"
    mocapkit.save(Motion(sk, rot, np.zeros((10, 3)), 30.0, "arm"), inp)
    assert main(["info", str(inp), "--joints"]) == 0
    out = capsys.readouterr().out
    assert "3 joints" in out and "10" in out and "Link2" in out
    # pelvis falls back to the root joint; every other role is named as missing
    missing = [r for r in ROLES if r != "pelvis"]
    assert f"human roles  1 of {len(ROLES)} found; missing: {', '.join(missing)}" in out
    assert "length unit  unknown" in out


def test_one_joint_is_singular(tmp_path, capsys):
    from mocapkit.motion import Motion, Skeleton

    sk = Skeleton(("Root",), np.array([-1]), np.zeros((1, 3)))
    rot = np.zeros((1, 1, 4))
    rot[..., 0] = 1
    inp = tmp_path / "dot.npz"
    mocapkit.save(Motion(sk, rot, np.zeros((1, 3)), 30.0, "dot"), inp)
    assert main(["info", str(inp)]) == 0
    out = capsys.readouterr().out
    assert "1 joint (+0 end sites)" in out and "1 joints" not in out and "0 frames affected" in out


def test_info_prints_long_paths_whole(tmp_path, capsys):
    deep = tmp_path.joinpath(*(["a_rather_long_folder_name_for_a_take"] * 6))
    deep.mkdir(parents=True)
    inp = deep / "walk.npz"
    mocapkit.save(mocapkit.load(SAMPLE)[:10], inp)
    assert main(["info", str(inp)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert f"file         {inp}" in lines  # on one line, not cut or wrapped


def test_asf_option_reads_an_amc_whose_skeleton_is_elsewhere(tmp_path, capsys):
    import shutil

    (tmp_path / "takes").mkdir()
    (tmp_path / "skeletons").mkdir()
    amc = tmp_path / "takes" / "walk.amc"
    shutil.copy(mocapkit.samples.path("12_walk.amc"), amc)
    asf = tmp_path / "skeletons" / "subject.asf"
    shutil.copy(mocapkit.samples.path("12.asf"), asf)
    assert main(["info", str(amc)]) == 2
    err = capsys.readouterr().err
    assert "no skeleton" in err and one_error_line(err)
    assert main(["info", str(amc), "--asf", str(asf)]) == 0
    assert "31 joints" in capsys.readouterr().out
    out = tmp_path / "walk.npz"
    assert main(["convert", str(amc), str(out), "--asf", str(asf)]) == 0
    ref = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    np.testing.assert_array_equal(mocapkit.load(out).rotations, ref.rotations)
    capsys.readouterr()
    assert main(["corrupt", str(amc), str(tmp_path / "n.npz"), "--kind", "noise", "--asf", str(asf)]) == 0
    capsys.readouterr()
    assert main(["info", SAMPLE, "--asf", str(asf)]) == 2  # an ASF no input can use is an error, not ignored
    err = capsys.readouterr().err
    assert "no input is an .amc file" in err and one_error_line(err)
    assert main(["info", str(amc), "--asf", str(tmp_path / "missing.asf")]) == 2
    assert "missing.asf: no such file" in capsys.readouterr().err


def test_plot_refuses_a_mask_of_another_take(tmp_path, capsys):
    noisy = tmp_path / "noisy.npz"
    assert main(["corrupt", SAMPLE, str(noisy), "--kind", "noise", "--seed", "1"]) == 0
    short = tmp_path / "short.mask.npz"
    from mocapkit.io.masks import write_mask

    write_mask(short, np.zeros((5, 31), bool), mocapkit.load(SAMPLE).skeleton.joint_names, kind="noise", seed=0)
    capsys.readouterr()
    png = tmp_path / "p.png"
    assert main(["plot", SAMPLE, str(noisy), "--joint", "LeftKnee", "-o", str(png), "--mask", str(short)]) == 2
    err = capsys.readouterr().err
    assert "short.mask.npz: the mask has 5 frames and the take 994" in err and not png.exists()


def test_convert_marker_files_between_c3d_trc_and_npz(tmp_path, capsys):
    from mocapkit.io import load_markers

    c3d = str(mocapkit.samples.path("Eb015pr.c3d"))
    src = load_markers(c3d)
    for name in ("m.trc", "m.npz", "m.c3d"):
        assert main(["convert", c3d, str(tmp_path / name)]) == 0
        assert "26 markers, 450 frames @ 50 fps" in capsys.readouterr().out
        back = load_markers(tmp_path / name)
        assert back.labels == src.labels and np.array_equal(back.missing(), src.missing())
    # TRC -> C3D -> TRC keeps the values at the TRC's 5 decimals
    assert main(["convert", str(tmp_path / "m.trc"), str(tmp_path / "t.c3d")]) == 0
    assert main(["convert", str(tmp_path / "t.c3d"), str(tmp_path / "t.trc")]) == 0
    a, b = load_markers(tmp_path / "m.trc"), load_markers(tmp_path / "t.trc")
    assert np.allclose(a.positions, b.positions, atol=1e-4, equal_nan=True)
    assert main(["info", str(tmp_path / "m.trc")]) == 0
    assert "read with trc" in capsys.readouterr().out


def test_convert_and_info_count_markers_apart_from_modelled_quantities(shared_data, tmp_path):
    """`convert PiG.c3d pig.trc` said "113 markers ... 9.95 % missing" (the share over all 193 points, 80 of them
    modelled angles, forces, moments, powers) where `info pig.trc` said 0.59 %, and `info PiG.c3d` said
    "markers 193": the markers are counted apart from the modelled quantities, and the share is the markers'."""
    c3d = shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d"
    code, out, _ = run("convert", c3d, tmp_path / "pig.trc")
    assert code == 0
    assert "113 markers, 315 frames @ 100 fps, 0.59 % of marker samples missing, 80 modelled quantities left out" in out
    code, out, _ = run("info", tmp_path / "pig.trc")
    assert code == 0 and "0.59 % of marker samples" in out
    code, out, _ = run("info", c3d)
    assert code == 0
    assert "113 (+80 modelled quantities" in out and "0.59 % of marker samples" in out and "193" not in out


def test_convert_states_zero_gaps_and_keeps_them_on_request(tmp_path, capsys):
    from mocapkit.io import load_markers, save_markers
    from mocapkit.markerset import MarkerSet

    ms = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    zeros = MarkerSet(labels=ms.labels, positions=np.nan_to_num(ms.positions, nan=0.0), fps=ms.fps)
    save_markers(zeros, tmp_path / "z.trc")
    assert main(["convert", str(tmp_path / "z.trc"), str(tmp_path / "a.npz")]) == 0
    n = int(ms.missing().sum())
    assert f"read {n} samples stored as exact (0, 0, 0) as gaps" in capsys.readouterr().out
    assert np.array_equal(load_markers(tmp_path / "a.npz").missing(), ms.missing())
    assert main(["convert", str(tmp_path / "z.trc"), str(tmp_path / "b.npz"), "--keep-zeros"]) == 0
    assert not load_markers(tmp_path / "b.npz").missing().any()


def test_convert_refuses_marker_to_motion_and_fps_for_markers(tmp_path):
    c3d = str(mocapkit.samples.path("Eb015pr.c3d"))
    code, _, err = run("convert", c3d, tmp_path / "x.bvh")
    assert code == 2 and one_error_line(err) and "unknown suffix '.bvh' for writing markers" in err
    code, _, err = run("convert", c3d, tmp_path / "x.trc", "--fps", "25")
    assert code == 2 and one_error_line(err) and "--fps resamples joint angles" in err
    assert not (tmp_path / "x.trc").exists() and not (tmp_path / "x.bvh").exists()
    code, _, err = run("convert", SAMPLE, tmp_path / "x.c3d")
    assert code == 2 and one_error_line(err)


def test_convert_amc_to_amc_and_bvh_to_amc_refused(tmp_path, capsys):
    from mocapkit import rotations as R
    from mocapkit.io.asfamc import read_amc

    walk = mocapkit.samples.path("12_walk.amc")
    out = tmp_path / "walk60.amc"
    assert main(["convert", str(walk), str(out), "--fps", "60"]) == 0
    back, ref = read_amc(out, mocapkit.samples.path("12.asf"), fps=60), mocapkit.load(walk).resample(60)
    assert back.num_frames == ref.num_frames
    assert np.degrees(R.geodesic_angle(back.rotations, ref.rotations)).max() < 1e-4
    capsys.readouterr()
    assert main(["convert", SAMPLE, str(tmp_path / "x.amc")]) == 2
    assert "ASF" in capsys.readouterr().err and not (tmp_path / "x.amc").exists()


def test_what_an_amc_cannot_hold_of_a_resampled_take_is_a_note_line_not_a_python_warning(tmp_path):
    # upsampled by slerp, CMU's 2-dof feet and hands turn a little about their third axis, which the AMC drops: said
    # as the command's other notes are, not in Python's warning format (source file, line and code on stderr)
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code, said, err = run("convert", mocapkit.samples.path("12_walk.amc"), tmp_path / "w240.amc", "--fps", "240")
    assert code == 0, err
    text = " ".join(said.split())
    assert "note: " in said and "rotations of lfoot, rfoot, lhand" in text and "the AMC holds only the angles" in text
    assert not [w for w in caught if w.category is UserWarning] and "UserWarning" not in err


def test_convert_at_the_takes_own_rate_keeps_the_input_text(tmp_path):
    # AMC to AMC and BVH to BVH without --fps give the input file back, byte for byte (its bone order, digits, line ends)
    crlf = tmp_path / "walk.amc"
    crlf.write_bytes(mocapkit.samples.path("12_walk.amc").read_bytes().replace(b"\n", b"\r\n"))
    asf = mocapkit.samples.path("12.asf")
    for inp, out in ((crlf, tmp_path / "o.amc"), (Path(SAMPLE), tmp_path / "o.bvh")):
        extra = ["--asf", str(asf)] if inp.suffix == ".amc" else []
        assert run("convert", inp, out, *extra)[0] == 0
        assert out.read_bytes() == inp.read_bytes()


def test_plot_names_the_file_that_lacks_the_joint_and_writes_nothing(tmp_path):
    """A --joint missing from a take, or without rotation channels there, is one line naming that take; no PNG."""
    noisy = tmp_path / "noisy.npz"
    assert run("corrupt", SAMPLE, noisy, "--kind", "noise", "--seed", "1")[0] == 0
    png = tmp_path / "p.png"
    code, _, err = run("plot", SAMPLE, noisy, "--joint", "Nope", "-o", png)
    assert code == 2 and one_error_line(err) and "Traceback" not in err and "ValueError" not in err
    assert f"{SAMPLE}: --joint: no joint 'Nope'" in " ".join(err.split())
    walk = str(mocapkit.samples.path("12_walk.amc"))  # the ASF spelling: no 'LeftKnee'
    code, _, err = run("plot", SAMPLE, walk, "--joint", "LeftKnee", "-o", png)
    assert code == 2 and one_error_line(err) and "is not in list" not in err
    assert f"{walk}: --joint: no joint 'LeftKnee'" in " ".join(err.split())
    code, _, err = run("plot", walk, walk, "--joint", "lhipjoint", "-o", png)  # an ASF joint without DOFs
    assert code == 2 and one_error_line(err)
    assert f"{walk}: --joint: joint 'lhipjoint' has no rotation channels to plot" in " ".join(err.split())
    import dataclasses

    m = mocapkit.load(SAMPLE)  # LeftKnee without its Yrotation channel
    channels = list(m.skeleton.channels)
    channels[m.skeleton.index("LeftKnee")] = ("Zrotation", "Xrotation")
    two = tmp_path / "two.bvh"
    with pytest.warns(UserWarning, match="rotations of LeftKnee"):  # the Y angles the file cannot hold are said
        mocapkit.save(dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, channels=tuple(channels))), two)
    assert not png.exists()
    code, out, err = run("plot", SAMPLE, two, "--joint", "LeftKnee", "-o", png)  # the same rig: drawn in SAMPLE's
    assert code == 0 and "two.bvh drawn in" in " ".join(out.split()), err        # channels (its Y angle is 0)


def test_corrupt_amount_is_one_check_for_every_kind(tmp_path):
    """--amount must be finite and > 0 whatever the kind: one line naming --amount, exit 2, nothing written."""
    for kind in ("noise", "uniform", "bias", "spatial", "gaps"):
        for amount in ("nan", "-1", "0", "inf"):
            out = tmp_path / f"{kind}.npz"
            code, _, err = run("corrupt", SAMPLE, out, "--kind", kind, f"--amount={amount}")
            assert code == 2 and one_error_line(err), (kind, amount, err)
            assert "--amount must be a finite number greater than 0" in err, (kind, amount, err)
    assert list(tmp_path.iterdir()) == []
    assert run("corrupt", SAMPLE, tmp_path / "s.npz", "--kind", "spatial", "--amount", "0.5")[0] == 0


def test_convert_names_fps_when_it_is_out_of_range(tmp_path):
    out = tmp_path / "o.bvh"
    for fps in ("-5", "nan"):
        code, _, err = run("convert", SAMPLE, out, "--fps", fps)
        assert code == 2 and one_error_line(err)
        assert "--fps must be a positive number from 1 to 10000 " in err, err
    assert not out.exists()


def test_info_says_whether_the_networks_serve_a_rig_read_from_its_tree(tmp_path, shared_data):
    # it said "the networks serve it through them" for every rig read from its tree, while denoise fell back on
    # bvhio's example.bvh (no lower back to share the trunk's turn with)
    from tests.shared import unnamed

    served = tmp_path / "unnamed.bvh"
    mocapkit.save(unnamed(mocapkit.load(Path(__file__).parents[1] / "data" / "cmu_01_01_start.bvh")), served)
    code, out, _ = run("info", served)
    assert code == 0 and "roles read from its tree and rest pose (the networks serve it through them)" in out
    code, out, _ = run("info", shared_data / "peer_files" / "Wasserwecken+bvhio" / "bvhio" / "tests" / "example.bvh")
    text = " ".join(out.split())
    assert code == 0 and "(the networks fall back: " in text and "lacks lowerback" in text


def test_an_amc_written_to_another_folder_reads_back(tmp_path):
    """convert and clean copy the input's ASF beside an AMC output (an AMC holds no skeleton), and say so."""
    amc = mocapkit.samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc")
    code, out, err = run("convert", amc, tmp_path / "a" / "jog.amc")
    assert code == 0, err
    assert "copied the skeleton" in out and (tmp_path / "a" / "jog.asf").read_bytes() == mocapkit.samples.path("HDM_bd.asf").read_bytes()
    code, out, err = run("clean", amc, "-o", tmp_path / "b" / "HDM_bd_clean.amc")
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == ["HDM_bd.asf", "HDM_bd_clean.amc", "HDM_bd_clean.clean.npz"]
    for f in (tmp_path / "a" / "jog.amc", tmp_path / "b" / "HDM_bd_clean.amc"):
        np.testing.assert_array_equal(mocapkit.load(f).rotations, mocapkit.load(amc).rotations)
    code, out, err = run("convert", amc, tmp_path / "b" / "more.amc")  # the folder's only ASF is its: nothing copied
    assert code == 0 and "copied" not in out and [p.name for p in (tmp_path / "b").glob("*.asf")] == ["HDM_bd.asf"]
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "jog.asf").write_text("not this skeleton")
    code, out, err = run("convert", amc, tmp_path / "c" / "jog.amc")
    assert code == 2 and one_error_line(err) and "exists and differs" in err and not (tmp_path / "c" / "jog.amc").exists()


def test_an_output_folder_that_takes_no_file_names_the_output(tmp_path, capsys):
    """/proc takes no new file: the line names OUT, not the hidden temporary file the write began with."""
    assert main(["convert", SAMPLE, "/proc/mocapkit-test.npz"]) == 2
    err = capsys.readouterr().err
    assert "/proc/mocapkit-test.npz: cannot be written there" in err and ".part" not in err


def test_plot_draws_an_amc_take_and_its_bvh_conversion_in_one_convention(tmp_path):
    amc = mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")
    code, _, err = run("convert", amc, tmp_path / "same.bvh")
    assert code == 0, err
    code, out, err = run("plot", amc, tmp_path / "same.bvh", "--joint", "rhumerus", "-o", tmp_path / "p.png")
    assert code == 0, err
    assert "same.bvh drawn in HDM_bk_sneak2StepsLStart_004_120.amc's channels" in " ".join(out.split())


def test_info_describes_the_files_mocapkit_writes(tmp_path):
    take = tmp_path / "take.bvh"
    mocapkit.save(mocapkit.load(SAMPLE)[:200], take)
    assert run("clean", take, "-o", tmp_path / "c.bvh", "--context", "none")[0] == 0
    assert run("detect", take, "-o", tmp_path / "d.npz", "--context", "none")[0] == 0
    assert run("corrupt", take, tmp_path / "k.bvh", "--kind", "spike", "--seed", "1")[0] == 0
    assert run("db", "build", tmp_path / "db", take)[0] == 0
    for path, kind in ((tmp_path / "c.clean.npz", "cleaning record"), (tmp_path / "d.npz", "detection"),
                       (tmp_path / "k.mask.npz", "corruption mask"), (tmp_path / "db", "motion database"),
                       (mocapkit.samples.path("12_walk.amc").parent.parent / "models" / "ebf.pt", "EBF model")):
        code, out, err = run("info", path)
        assert code == 0 and kind in out, (path, out, err)


def test_an_interrupted_corrupt_overwrite_keeps_the_earlier_take_and_its_ground_truth(tmp_path, monkeypatch):
    import mocapkit.io.masks

    out = tmp_path / "bad.bvh"
    assert run("corrupt", SAMPLE, out, "--kind", "noise", "--seed", "1")[0] == 0
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt  # the new take is written, its ground truth is not

    monkeypatch.setattr(mocapkit.io.masks, "write_mask", interrupted)
    code, _, err = run("corrupt", SAMPLE, out, "--kind", "spike", "--seed", "2", "--overwrite")
    assert code == 130 and "interrupted" in err
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before  # never a take beside another's mask


def test_an_amc_output_is_never_left_without_its_asf(tmp_path, monkeypatch):
    from mocapkit import io

    amc, asf = mocapkit.samples.path("12_walk.amc"), mocapkit.samples.path("12.asf")
    out = tmp_path / "elsewhere" / "walk.amc"

    def interrupted(*args, **kwargs):
        assert (tmp_path / "elsewhere" / "12.asf").is_file() or (tmp_path / "elsewhere" / "walk.asf").is_file()
        raise KeyboardInterrupt

    monkeypatch.setattr(io, "save", interrupted)
    code, _, _ = run("convert", amc, out, "--asf", asf)
    assert code == 130 and not [p for p in tmp_path.rglob("*") if p.is_file()]


def test_info_describes_mocapkit_s_json_files(tmp_path):
    import json

    from mocapkit.batch import BATCH_MARK

    (tmp_path / "take.decisions.json").write_text(json.dumps({
        "format": "mocapkit.decisions/1", "mocapkit": "0.2.0", "take": {"name": "walk.bvh", "sha256": "0" * 64},
        "output": "w.bvh", "decisions": {"repair:Neck:1-2": "reject", "fill:b:3-4": "accept"}}))
    code, text, err = run("info", tmp_path / "take.decisions.json")
    assert code == 0, err
    assert "review decisions" in text and "1 accepted, 1 rejected" in text
    (tmp_path / BATCH_MARK).write_text(json.dumps({"format": 1, "input": "/data/takes"}))
    code, text, err = run("info", tmp_path / BATCH_MARK)
    assert code == 0 and "clean-batch's mark" in " ".join(text.split()) and "/data/takes" in text, err
    (tmp_path / "other.json").write_text("{}")
    code, _, err = run("info", tmp_path / "other.json")
    assert code == 2 and one_error_line(err)


DATA = Path(__file__).resolve().parents[1] / "data"


def _child(tmp_path, scale: float) -> Path:
    """A real Bandai take (cm) with the body made ``scale`` times the size, still in cm: a child's take."""
    import dataclasses

    m = mocapkit.load(DATA / "dataset-1_dash_normal_001.bvh")
    sk = m.skeleton
    small = dataclasses.replace(sk, offsets=sk.offsets * scale, end_site_offsets=sk.end_site_offsets * scale)
    child = dataclasses.replace(m, skeleton=small, root_positions=np.asarray(m.root_positions) * scale)
    path = tmp_path / f"child{int(scale * 100)}.bvh"
    mocapkit.save(child, path)
    return path


def test_unit_names_the_length_unit_a_bvh_does_not_state(tmp_path):
    """The unit read from the bones assumes an adult; --unit states it, on every command that measures lengths."""
    child = _child(tmp_path, 0.65)
    code, out, _ = run("info", child)
    assert code == 0 and "--unit mm|cm|m|in" in out  # unknown, and how to name it
    code, out, _ = run("info", child, "--unit", "cm")
    assert code == 0 and "length unit  1 cm (given with --unit)" in out, out
    code, _, err = run("corrupt", child, tmp_path / "sp.bvh", "--kind", "spatial", "--amount", "0.5")
    assert code == 2 and one_error_line(err) and "--unit mm|cm|m|in" in err and not (tmp_path / "sp.bvh").exists()
    code, out, err = run("corrupt", child, tmp_path / "sp.bvh", "--kind", "spatial", "--amount", "0.5", "--unit", "cm")
    assert code == 0, err
    code, out, err = run("clean", tmp_path / "sp.bvh", "-o", tmp_path / "c.bvh", "--steps", "fill", "--reference",
                         child, "--unit", "cm", "--context", "none")
    assert code == 0 and "positions of joints and end sites" in out, (out, err)
    code, _, err = run("info", WALK, "--unit", "cm")  # an ASF states its unit
    assert code == 2 and one_error_line(err) and "states its length unit (5.644 cm), not cm" in err
    code, _, err = run("info", child, "--unit", "furlong")
    assert code == 2 and one_error_line(err) and "--unit 'furlong': one of mm, cm, m, in" in err


def test_info_says_where_an_amc_s_frame_rate_comes_from(shared_data, tmp_path):
    (tmp_path / "86.asf").write_bytes((shared_data / "cmu_asfamc" / "11.asf").read_bytes())
    amc = tmp_path / "86_30.amc"  # CMU's subject 86, trial 30: no 30 fps take
    amc.write_bytes((shared_data / "cmu_asfamc" / "11_01.amc").read_bytes())
    code, out, _ = run("info", amc)
    assert code == 0 and "fps          120 (the file states none: 120, the CMU and HDM05 rate; --amc-fps sets it)" in out
    assert "duration     4.975 s" in out
    code, out, _ = run("info", amc, "--amc-fps", "60")
    assert code == 0 and "60 (given with --amc-fps)" in out and "9.950 s" in out
    hdm = shared_data / "hdm05_asfamc" / "HDM_bd_squat1Reps_001_120.amc"
    assert "120 (from the HDM05 file name)" in run("info", hdm)[1]
    code, _, err = run("info", SAMPLE, "--amc-fps", "60")
    assert code == 2 and one_error_line(err) and "--amc-fps is the frame rate of an .amc input" in err


def test_an_amc_converted_to_another_rate_reads_back_at_it(shared_data, tmp_path):
    hdm = shared_data / "hdm05_asfamc" / "HDM_bd_squat1Reps_001_120.amc"
    for name in ("squat_60fps.amc", "squat_30_120.amc"):
        out = tmp_path / name
        code, said, err = run("convert", hdm, out, "--fps", "60")
        assert code == 0 and "@ 60 fps" in said, err
        code, said, _ = run("info", out)
        assert "60 (stated in the file's mocapkit comment line)" in said and "duration     1.167 s" in said
        bvh = out.with_suffix(".bvh")
        assert run("convert", out, bvh)[0] == 0
        assert mocapkit.load(bvh).fps == 60.0
    same = tmp_path / "same.amc"
    assert run("convert", hdm, same)[0] == 0
    assert same.read_bytes() == hdm.read_bytes()  # at its own rate: the file as it was


def test_info_describes_a_marker_capture_s_cleaning_record(tmp_path):
    from mocapkit.io import load_markers, save_markers

    ms = load_markers(DATA / "85_02.c3d")
    pos = np.array(ms.positions[:240])
    pos[100:130, 5] = np.nan  # a gap to fill
    take = tmp_path / "take.trc"
    save_markers(mocapkit.io.MarkerSet(labels=ms.labels, positions=pos, fps=ms.fps, units=ms.units, name="take"), take)
    code, _, err = run("clean", take, "-o", tmp_path / "c.trc")
    assert code == 0, err
    code, out, err = run("info", tmp_path / "c.clean.npz")
    assert code == 0, err
    assert "marker cleaning record" in out and "frames   240" in out and "markers  41" in out
    assert "1 gap filled" in out and "(filled 30," in out


def test_info_and_clean_say_a_marker_file_s_unit_was_inferred(shared_data, tmp_path):
    from mocapkit.io import load_markers, save_markers

    src = load_markers(shared_data / "trc_markers" / "T.trc")
    metres = mocapkit.io.MarkerSet(labels=src.labels, positions=src.positions / 1000, fps=src.fps, units="m",
                                   name="t")
    take = tmp_path / "t.trc"
    save_markers(metres, take)
    lines = take.read_text().split("\n")
    lines[2] = lines[2].replace("\tm\t", "\t\t")  # the Units field emptied
    take.write_text("\n".join(lines))
    code, out, _ = run("info", take)
    assert code == 0 and "units     m (the file states none: inferred from the marker distances; --unit sets it)" in out
    code, out, err = run("clean", take, "-o", tmp_path / "c.trc")
    assert code == 0 and "length unit m: the file states none (inferred from the marker distances" in out, (out, err)
    code, out, _ = run("info", take, "--unit", "mm")
    assert code == 0 and "units     mm (given with --unit; the file states none)" in out


def test_info_on_a_missing_file_says_no_such_file_whatever_its_suffix(tmp_path):
    """Docs trial: `info nonexist.pt` said "unknown suffix '.pt' for reading" though info reads models."""
    for name in ("model.pt", "base.kb", "take.bvh", "take.clean.npz", "noext"):
        code, _, err = run("info", str(tmp_path / name))
        assert code == 2 and one_error_line(err) and err.strip().endswith(f"{tmp_path / name}: no such file"), err


def test_info_prints_the_digest_a_hand_written_decisions_file_needs(tmp_path):
    """The guide says a decisions file written by hand (no `cleaning`) applies with `--record`, but it is refused
    without the take's sha256, which nothing printed: `info` gives it, for a take and a marker capture."""
    from mocapkit.cleaning.decisions import take_digest
    from mocapkit.io import load_markers

    code, out, _ = run("info", WALK)
    assert code == 0 and f"sha256       {take_digest(mocapkit.load(WALK))}" in out
    c3d = mocapkit.samples.path("Eb015pr.c3d")
    code, out, _ = run("info", c3d)
    assert code == 0 and take_digest(load_markers(c3d)) in out


def test_help_says_what_info_reads_and_corrupts_default_amount():
    """`info --help` said --asf/--amc-fps apply to "input(s) and reference" (info has no reference); `corrupt --help`
    did not say --amount's default."""
    code, out, _ = run("info", "--help")
    assert code == 0 and "reference" not in " ".join(out.split())
    code, out, _ = run("corrupt", "--help")
    assert code == 0 and "Default: 0.5 (noise, uniform, bias), 0.5 cm (spatial)" in " ".join(out.replace("│", " ").split())


def test_corrupt_prints_each_injected_error_as_a_plain_line(tmp_path):
    """`corrupt --kind errors` printed each error record as a Python dict (``{'kind': 'swap', ..., 'partner':
    None}``); each is now one line a user reads: what, which joint (and partner), which frames, how large."""
    import re

    out = tmp_path / "bad.bvh"
    code, said, err = run("corrupt", SAMPLE, out, "--kind", "errors", "--seed", "4")
    assert code == 0, err
    lines = said.split("\n  note: ")[0].splitlines()[1:]  # the note on the drifts below them
    assert lines and "{" not in said and "None" not in said, said
    for line in lines:
        assert re.fullmatch(r"  (spike|flip|freeze|drift|swap): \S+( with \S+)?, frames? \d+(-\d+)? "
                            r"\(\d+ frames?, \d+\.\d\d s\), turned by up to \d+\.\d deg", line), line


def test_corrupt_says_its_drifts_are_stepped_not_the_smooth_drifts_the_drift_rule_flags(tmp_path):
    """Trial G, finding 5: `corrupt --kind drift` drew 0.13 s "drifts" that `detect --drifts` (at least 0.15 s,
    `drift_min_s`) cannot flag; they step off the path, so the break rules find them, and corrupt now says so."""
    take = Path(__file__).resolve().parents[1] / "data" / "dataset-2_walk_normal_001_first120.bvh"
    code, said, err = run("corrupt", take, tmp_path / "drift.bvh", "--kind", "drift", "--seed", "5")
    assert code == 0, err
    text = " ".join(said.split())
    assert "drift: " in text and "0.13 s" in text  # Foot_R, frames 41-44: shorter than drift_min_s
    assert ("note: a drift here steps off its path by 15 deg and ramps to 25-40 deg over 0.1-0.6 s (Aristidou's drift "
            "error): detect finds it by its step, as a break; `--drifts` flags smooth drifts, which have no step and "
            "last at least 0.15 s") in text
    code, said, err = run("corrupt", take, tmp_path / "spike.bvh", "--kind", "spike", "--seed", "5")
    assert code == 0 and "note:" not in said, err


def test_corrupt_lists_a_swap_once(tmp_path):
    """A user trial: `corrupt --kind errors` listed each swap twice (`swap: UpperLeg_L with UpperLeg_R` and `swap:
    UpperLeg_R with UpperLeg_L`), so four injected errors read as five. One line per injected error; the mask keeps
    a record per joint of the pair (what `clean --reference` scores per joint)."""
    import json

    out = tmp_path / "bad.bvh"
    code, said, err = run("corrupt", SAMPLE, out, "--kind", "errors", "--seed", "4")
    assert code == 0, err
    lines = said.splitlines()[1:]
    with np.load(tmp_path / "bad.mask.npz") as kept:
        records = json.loads(str(kept["errors"]))
    swaps = [r for r in records if r["kind"] == "swap"]
    assert len(swaps) == 2 and {swaps[0]["joint"], swaps[1]["joint"]} == {"LeftKnee", "RightKnee"}
    assert len(lines) == len(records) - 1 == 4, said
    assert [ln.split(",")[0] for ln in lines if "swap" in ln] == ["  swap: LeftKnee with RightKnee"], said


def test_info_and_clean_say_how_many_samples_stored_as_zeros_were_read_as_gaps(tmp_path):
    """Trial: `convert` said that 35,965 of Qualisys 03_rolling.c3d's samples, stored as exact (0, 0, 0), were read
    as gaps, but `info` (22.95 % missing) and `clean` (194 gaps filled) did not, so the user of either never
    learnt where the missing share came from. A TRC whose exporter wrote 0 for unseen markers (Eb015pr's gaps)."""
    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))[:200]
    take = tmp_path / "zeros.trc"
    save_markers(src, take)
    rows = [ln.split("\t") for ln in take.read_text().split("\n")]
    for row in rows[6:]:
        row[2:] = ["0" if (cell == "" and k < 3 * src.num_markers) else cell for k, cell in enumerate(row[2:])]
    take.write_text("\n".join("\t".join(row) for row in rows))
    n = int(src.missing().sum())
    assert load_markers(take).zero_gaps == n > 0
    said = f"read {n} samples stored as exact (0, 0, 0) as gaps"
    code, out, _ = run("info", take)
    assert code == 0 and f"% of marker samples ({said})" in out, out
    code, out, err = run("clean", take, "-o", tmp_path / "c.trc")
    assert code == 0 and f"\n  {said} (--keep-zeros keeps them as positions)\n" in out, (out, err)


def test_plot_names_a_take_and_its_cleaned_copy_of_the_same_name_apart(tmp_path, monkeypatch):
    """`clean-batch` keeps a take's name in OUT_DIR: the legend said 'walk vs walk', not which line is which."""
    import mocapkit.report

    (tmp_path / "in").mkdir()
    (tmp_path / "out").mkdir()
    take, cleaned = tmp_path / "in" / "walk.bvh", tmp_path / "out" / "walk.bvh"
    mocapkit.save(mocapkit.load(SAMPLE)[:40], take)
    mocapkit.save(mocapkit.load(take), cleaned)
    drawn = []
    monkeypatch.setattr(mocapkit.report, "plot_channels", lambda motions, joint, out, labels, mask: drawn.append(labels))
    assert main(["plot", str(take), str(cleaned), "--joint", "LeftKnee", "-o", str(tmp_path / "p.png")]) == 0
    assert drawn == [[str(take), str(cleaned)]]
    amc = mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")  # a take and its conversion: the file names
    assert main(["convert", str(amc), str(tmp_path / "HDM_bk_sneak2StepsLStart_004_120.bvh")]) == 0
    assert main(["plot", str(amc), str(tmp_path / "HDM_bk_sneak2StepsLStart_004_120.bvh"), "--joint", "rhumerus",
                 "-o", str(tmp_path / "q.png")]) == 0
    assert drawn[1] == ["HDM_bk_sneak2StepsLStart_004_120.amc", "HDM_bk_sneak2StepsLStart_004_120.bvh"]


def test_an_amc_written_from_an_npz_says_it_reads_back_only_with_asf(tmp_path):
    """An .npz keeps the skeleton but no ASF file to copy: the AMC written from it said only 'wrote', and
    the next command on it failed ('no skeleton'); the write now says so in a note naming the file."""
    amc = mocapkit.samples.path("12_walk.amc")
    (tmp_path / "a").mkdir()
    npz, out = tmp_path / "a" / "walk.npz", tmp_path / "b" / "walk.amc"
    assert run("convert", amc, npz)[0] == 0
    code, said, err = run("convert", npz, out)
    assert code == 0, err
    said = " ".join(said.split())
    assert f"note: {out}: no ASF beside it (walk.npz keeps the skeleton but no .asf file to copy): read it back with --asf" in said
    back = mocapkit.load(out, asf=mocapkit.samples.path("12.asf"))
    assert np.array_equal(back.rotations, mocapkit.load(amc).rotations)
    code, said, _ = run("convert", amc, tmp_path / "b" / "again.amc")  # its ASF copied beside it: nothing to say
    assert code == 0 and "no ASF beside it" not in said and "copied the skeleton" in said


@pytest.mark.parametrize("args", [
    ("convert", SAMPLE, "{out}/x.bvh/"),
    ("corrupt", SAMPLE, "{out}/x.npz/", "--kind", "noise"),
    ("clean", SAMPLE, "-o", "{out}/x.bvh/"),
    ("clean", SAMPLE, "-o", "{out}/x.bvh", "--report", "{out}/r.html/"),
    ("denoise", SAMPLE, "--out={out}/x.bvh/"),
    ("detect", SAMPLE, "-o", "{out}/x.npz/"),
    ("repair", SAMPLE, "-o", "{out}/x.bvh/"),
    ("plot", SAMPLE, SAMPLE, "--joint", "Hips", "-o", "{out}/x.png/"),
])
def test_an_output_path_ending_with_a_slash_is_refused_naming_it(tmp_path, args):
    """`convert a.bvh out/x.bvh/` named a folder; before 0.15.0 it wrote out/x.bvh (the slash is lost once typer
    makes a Path of it). Every command's output guard (cli.common.guard -> io.outputs.check_outputs) refuses it in
    one line naming the path as typed, before any work."""
    words = [a.format(out=tmp_path / "o") for a in args]
    code, _, err = run(*words)
    typed = next(w.split("=", 1)[-1] for w in words if w.endswith("/"))
    assert code == 2 and one_error_line(err) and f"{typed}: ends with a path separator" in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("joined", ["-o{out}/x.bvh/", "-o={out}/x.bvh/"])
def test_an_output_path_ending_with_a_slash_joined_to_a_short_option_is_refused(tmp_path, monkeypatch, joined):
    """`denoise a.bvh -oout/x.bvh/` (the value joined to -o; `-o=out/x.bvh/` click reads as `=out/x.bvh/`) named a
    folder too; before 0.15.0 it wrote out/x.bvh (`=out/x.bvh`): cli.common.as_typed read only a separate word or a
    long option's `=`."""
    monkeypatch.chdir(tmp_path)  # a path made of `=o/x.bvh/` is relative: it would land here
    word = joined.format(out="o")
    code, _, err = run("denoise", str(Path(SAMPLE).absolute()), word)
    assert code == 2 and one_error_line(err) and f"{word[2:]}: ends with a path separator" in err, err
    assert not (tmp_path / "o").exists() and not list(tmp_path.glob("=*"))


def test_info_says_which_part_of_the_missing_share_is_markers_never_seen(tmp_path, capsys):
    # Vicon's FunctionalWalk.c3d: "29.09 % of marker samples" missing, all of it 32 labels the capture never saw,
    # while `clean` then fills 0 gaps. CMU 85_02 (complete) with LFWT and RFWT never seen: said, and named.
    from mocapkit.io import load_markers, save_markers

    ms = load_markers(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")
    pos = np.array(ms.positions)
    pos[:, :2] = np.nan
    save_markers(ms.with_positions(pos), tmp_path / "t.trc")
    assert main(["info", str(tmp_path / "t.trc")]) == 0
    out = capsys.readouterr().out
    assert "4.88 % of marker samples (2 of 41 markers never seen: Male:LFWT, Male:RFWT)" in out, out
    assert main(["info", str(mocapkit.samples.path("Eb015pr.c3d"))]) == 0
    assert "never seen" not in capsys.readouterr().out  # every marker seen: the line as before


@pytest.mark.parametrize("choices, said", [
    ('{"repair:Hips:1-2": "reject", "repair:Spine:3-4": "Reject"}',
     "refused by clean --decisions: change 'repair:Spine:3-4': 'Reject'; a decision is \"accept\" or \"reject\""),
    ('{"repair:Neck:1-2": "maybe"}', "refused by clean --decisions: change 'repair:Neck:1-2': 'maybe'"),
    ('{"repair:Neck:1-2": "reject", "repair:Neck:1-2": "accept"}',
     "refused by clean --decisions: change 'repair:Neck:1-2' is named twice: JSON would keep only the last"),
    ('{"repair:Neck:1-2": true}', "refused by clean --decisions: change 'repair:Neck:1-2': True"),
    ('{"repair:Neck:1-2": "reject"}',
     "0 accepted, 1 rejected; a change of the cleaning it does not name is accepted (a file written by hand)"),
])
def test_info_says_what_clean_decisions_does_with_a_decisions_file(tmp_path, choices, said):
    """`info D.json` counted every choice but exactly "reject" as accepted ("Reject", "maybe", true) and a change
    named twice by its last choice: the very files `clean --decisions` refuses, and a hand-written file's unnamed
    changes (accepted by clean) went unsaid. It now reads the file as clean does and says what clean would do."""
    path = tmp_path / "d.json"
    path.write_text('{"format": "mocapkit.decisions/1", "take": {"name": "t.bvh", "sha256": "%s"}, "decisions": %s}'
                    % ("0" * 64, choices))
    code, text, err = run("info", path)
    assert code == 0, err
    row = " ".join(next(ln for ln in text.splitlines() if ln.startswith("decisions")).split()[1:])
    assert row.startswith(said), row
    assert "accepted" not in row or not row.startswith("refused")


def test_info_says_the_namespace_set_aside_to_find_the_family(tmp_path):
    """A user trial: a Bandai Namco take exported as `mixamorig:Hips`, `mixamorig:UpperLeg_L` ... was of "none known"
    family; now `info` names the family and the prefix set aside to find it (the file's names are kept)."""
    import re
    from pathlib import Path

    source = Path(__file__).parents[1] / "data" / "dataset-1_dash_normal_001.bvh"
    take = tmp_path / "ns.bvh"
    take.write_bytes(re.sub(rb"^(\s*(?:ROOT|JOINT)\s+)", rb"\1mixamorig:", source.read_bytes(), flags=re.M))
    code, out, err = run("info", take, "--joints")
    assert code == 0, err
    said = " ".join(out.replace("│", " ").split())
    assert "rig family bandai_namco (its names read without the prefix 'mixamorig:' they share" in said, out
    assert "mixamorig:UpperLeg_L" in said


def _dag_named(bvh: str, namespace: str) -> str:
    """A BVH's text with every joint named by its full Maya DAG path (``|Hips|LHipJoint|LeftHip``), each part under
    ``namespace``; line endings and the motion kept."""
    import re

    path: list[str] = []  # the open blocks' joints (None for an end site)
    pending = None
    out = []
    for line in bvh.splitlines(keepends=True):
        m = re.match(r"(\s*(?:ROOT|JOINT)\s+)(\S+)", line)
        if m:
            pending = namespace + m.group(2)
            line = m.group(1) + "".join("|" + p for p in path if p) + "|" + pending + line[m.end():]
        elif line.strip().startswith("End"):
            pending = None
        elif line.strip() == "{":
            path.append(pending)
        elif line.strip() == "}":
            path.pop()
        out.append(line)
    return "".join(out)


def test_info_reads_joints_named_by_their_dag_paths_as_the_bare_take(tmp_path):
    """131_01 with every joint named by its full Maya DAG path (`|Hips|LHipJoint|LeftHip`, under a namespace
    `|Character1:Hips|...`) was of "none known" family; `info` now gives it the family, roles and unit of the bare
    take and says how its names were read, the file's names kept."""
    source = mocapkit.samples.path("131_01.bvh")
    base = run("info", source)[1].splitlines()
    for namespace in ("", "Character1:"):
        take = tmp_path / f"dag{len(namespace)}.bvh"
        take.write_bytes(_dag_named(source.read_bytes().decode(), namespace).encode())
        code, out, err = run("info", take, "--joints")
        assert code == 0, err
        said = " ".join(out.replace("│", " ").split())
        assert ("rig family cmu_bvh_3dsmax (its names read as the last part of their DAG paths"
                + (f", without the prefix {namespace!r} they share" if namespace else "") + ";") in said, out
        assert f"|{namespace}Hips|{namespace}LHipJoint|{namespace}LeftHip " in said
        kept = ("human roles", "length unit", "channels", "missing")
        assert [ln for ln in out.splitlines() if ln.startswith(kept)] == [ln for ln in base if ln.startswith(kept)]


def test_info_names_each_cut_in_one_line_and_none_in_a_whole_take(tmp_path, capsys):
    """Two real takes joined (HDM05 bk sneak 004 to 005, the smoothest join they allow): `info` says where the
    second begins, frame 200, with its score and what it means, on one line; a whole take (131_01) has no cut line."""
    from tests.shared import joined_sneaks

    take = tmp_path / "joined.bvh"
    mocapkit.save(joined_sneaks(), take)
    assert main(["info", str(take)]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("cut ")]
    assert len(lines) == 1, lines
    assert "frame 200: 70 % of the moving joints jump at once between frames 199 and 200" in lines[0]
    assert "two takes joined here (frame 200 the second's first), or frames dropped" in lines[0]
    assert main(["info", SAMPLE]) == 0
    assert "cut " not in capsys.readouterr().out
