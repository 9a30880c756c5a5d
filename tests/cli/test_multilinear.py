"""`mocapkit multilinear build` and `reconstruct --multilinear` on bundled real takes: the model file (versioned,
refused in one line when it is not one), the fit as the library makes it, and the --reference figures."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import metrics, samples
from mocapkit.features import default_sensors
from mocapkit.motion import unit_scale_cm
from mocapkit.reconstruct.multilinear import MultilinearModel, marker_accelerations, simulated_readings
from mocapkit.reconstruct.multilinear_file import FORMAT_VERSION, load_model, save_model
from tests.cli.helpers import one_error_line, run

SNEAK = [samples.path(f"HDM_bk_sneak2StepsLStart_00{i}_120.amc") for i in (4, 5)]
DATA = Path(__file__).resolve().parents[1] / "data"
RUNS = [DATA / "dataset-2_run_active_049.bvh", DATA / "dataset-1_run_masculinity_001.bvh"]


@pytest.fixture(scope="module")
def sneak_model(tmp_path_factory):
    path = tmp_path_factory.mktemp("ml") / "sneak.npz"
    code, stdout, err = run("multilinear", "build", path, *SNEAK)
    assert code == 0, err
    line = " ".join(stdout.split())
    assert "wrote" in line and "2 takes of sneak2StepsLStart, modes actor (1) x repetition (2)" in line, stdout
    return path


def test_a_built_model_reads_back_as_the_model_built_in_python(sneak_model):
    """The file keeps the motion tensors; read back and decomposed again it is the model `fit` makes."""
    clips = [mocapkit.load(p) for p in SNEAK]
    here = MultilinearModel(missing="mean").fit(clips)
    back, desc = load_model(sneak_model)
    assert desc["class"] == "sneak2StepsLStart" and desc["modes"] == ["actor", "repetition"]
    assert back.tensor_.entries == here.tensor_.entries and back.skeleton_.joint_names == here.skeleton_.joint_names
    np.testing.assert_allclose(back.tensor_.rotations, here.tensor_.rotations, atol=1e-12)
    np.testing.assert_allclose(back.synthesize().global_positions(), here.synthesize().global_positions(), atol=1e-9)


def test_reconstruct_with_a_model_fits_the_take_and_reports_every_joint(sneak_model, tmp_path):
    """--multilinear MODEL --accelerometers TAKE: the four default sensors simulated on the take, the model's
    weights fitted to them as `fit_readings` fits them; --reference compares all 31 joints, the fit closer than
    the class mean."""
    take = mocapkit.load(SNEAK[1])
    out = tmp_path / "rec.bvh"
    code, stdout, err = run("reconstruct", "--multilinear", sneak_model, "--accelerometers", SNEAK[1], "-o", out,
                            "--reference", SNEAK[1], "--json")
    assert code == 0, err
    rep = json.loads(stdout)
    rec = mocapkit.load(out)
    assert rep["method"] == "multilinear" and rec.num_frames == take.num_frames and rec.fps == take.fps
    model, _ = load_model(sneak_model)
    _, local, orient = simulated_readings(take)
    weights, want = model.fit_readings(local, take.fps, orientations=orient, skeleton=take.skeleton)
    np.testing.assert_allclose(rec.global_positions(), want.global_positions(), atol=1e-3)  # the BVH's decimals
    assert rep["weights"]["repetition"] == pytest.approx(weights[1].tolist(), abs=1e-6)
    _, mean = model.fit_readings(local, take.fps, orientations=orient, skeleton=take.skeleton, optimize=False)
    assert rep["joint_position_rms_cm"] == pytest.approx(metrics.joint_position_rms(take, rec, root_relative="heading"),
                                                         abs=0.01)
    assert rep["joint_position_rms_cm"] < metrics.joint_position_rms(take, mean, root_relative="heading")
    assert rep["compared"] == list(take.skeleton.joint_names) and "pelvis_height_rms_cm" in rep
    assert rep["relative_distance"] < rep["mean_distance"]


def test_reconstruct_with_a_model_from_markers_fits_their_accelerations(sneak_model, tmp_path):
    """--multilinear MODEL --markers TAKE: the six default markers (hands, feet, head, root) on the take's joints,
    their second derivatives the global accelerations the model is fitted to; a marker file with --use the same
    way, and without it refused in one line."""
    from mocapkit.features import virtual_markers
    from mocapkit.io import save_markers
    from mocapkit.markerset import MarkerSet

    take = mocapkit.load(SNEAK[1])
    out = tmp_path / "rec.bvh"
    code, stdout, err = run("reconstruct", "--multilinear", sneak_model, "--markers", SNEAK[1], "-o", out, "--json")
    assert code == 0, err
    rep = json.loads(stdout)
    joints = ["lwrist", "rwrist", "lfoot", "rfoot", "head", "root"]
    assert rep["from"] == f"6 markers ({', '.join(joints)})", rep["from"]
    model, _ = load_model(sneak_model)
    accel = marker_accelerations(virtual_markers(take, joints), take.fps, take.skeleton)
    _, want = model.fit_readings(accel, take.fps, sensors=joints, skeleton=take.skeleton)
    np.testing.assert_allclose(mocapkit.load(out).global_positions(), want.global_positions(), atol=1e-3)
    markers = tmp_path / "m.npz"  # the same trajectories as a marker file, in its own labels
    labels = ("LWR", "RWR", "LFT", "RFT", "HEAD", "ROOT")
    cm = virtual_markers(take, joints) * unit_scale_cm(take.skeleton)
    save_markers(MarkerSet(labels, cm, take.fps, "cm"), markers)
    code, _, err = run("reconstruct", "--multilinear", sneak_model, "--markers", markers, "-o", tmp_path / "m.bvh")
    assert code == 2 and one_error_line(err) and "needs --use" in err
    use = ",".join(f"{a}={j}" for a, j in zip(labels, joints))
    code, _, err = run("reconstruct", "--multilinear", sneak_model, "--markers", markers, "--use", use, "--up-axis",
                       "y", "-o", tmp_path / "m.bvh")
    assert code == 0, err
    np.testing.assert_allclose(mocapkit.load(tmp_path / "m.bvh").global_positions(), want.global_positions(),
                               atol=1e-3)


def test_a_bandai_model_keeps_joint_root_where_the_take_holds_it(tmp_path):
    """Two runs on the game rig, named by dataset, content and style: one class (run), mode style; the result's
    joint_Root stays at the origin as the take's, and the line compares it and names all 22 joints."""
    model = tmp_path / "run.npz"
    code, stdout, err = run("multilinear", "build", model, *RUNS)
    assert code == 0, err
    assert "2 takes of run, modes style (2)" in " ".join(stdout.split())
    assert sum("CC BY-NC 4.0" in ln for ln in stdout.splitlines()) == 1  # the takes' terms, said and kept
    assert "CC BY-NC 4.0" in load_model(model)[1]["licence"]
    out = tmp_path / "rec.bvh"
    code, stdout, err = run("reconstruct", "--multilinear", model, "--accelerometers", RUNS[0], "-o", out,
                            "--reference", RUNS[0])
    assert code == 0, err
    line = " ".join(stdout.split())
    assert "joint_Root 0.00 cm (where the reference holds it still)" in line
    assert "compared: all 22 joints of dataset-2_run_active_049.bvh" in line
    np.testing.assert_array_equal(mocapkit.load(out).root_positions, 0.0)


def test_a_file_that_is_no_model_or_of_another_version_is_refused_in_one_line(sneak_model, tmp_path):
    take = tmp_path / "take.npz"
    mocapkit.save(mocapkit.load(SNEAK[0]), take)
    with np.load(sneak_model, allow_pickle=False) as z:
        arrays = dict(z)
    arrays["format_version"] = np.array(FORMAT_VERSION + 1)
    newer = tmp_path / "newer.npz"
    np.savez(newer, **arrays)
    text = tmp_path / "text.npz"
    text.write_text("not a zip")
    out = tmp_path / "rec.bvh"
    for model, said in ((take, "not a multilinear model (an npz of kind 'motion'"),
                        (newer, f"a multilinear model of format version {FORMAT_VERSION + 1}; this mocapkit reads "
                                f"version {FORMAT_VERSION}"),
                        (text, "text.npz")):
        code, _, err = run("reconstruct", "--multilinear", model, "--accelerometers", SNEAK[1], "-o", out)
        assert code == 2 and one_error_line(err) and said in err and str(model.name) in err, err
        assert not out.exists()
    code, stdout, err = run("info", sneak_model)  # what a model holds, as info says it of a database
    assert code == 0, err
    rows = dict(ln.split(None, 1) for ln in stdout.splitlines() if ln.strip())
    assert rows["kind"] == "multilinear model (reconstruct --multilinear)" and rows["class"] == "sneak2StepsLStart"
    assert rows["modes"] == "actor (1) x repetition (2)" and rows["takes"].startswith("2 of 2 cells")
    code, _, err = run("info", newer)
    assert code == 2 and one_error_line(err) and "format version 2" in err
    arrays["kind"] = np.array("something")
    np.savez(newer, **arrays)
    code, _, err = run("info", newer)
    assert code == 2 and one_error_line(err) and "not a multilinear model (an npz of kind 'something'" in err
    other = tmp_path / "other.npz"  # no model's arrays, of another kind: the take reader names its kind
    np.savez(other, kind=np.array("something"), format_version=np.array(1))
    code, _, err = run("info", other)
    assert code == 2 and one_error_line(err) and "an npz of kind 'something', not a motion or markers" in err


@pytest.mark.parametrize("args, said", [
    (("--ssg",), "--multilinear fits accelerations: give the take as --accelerometers or --markers, not --ssg"),
    (("--accelerometers", "--use", "head"), "--use does not apply to --multilinear --accelerometers"),
    (("--accelerometers", "--db", "DB"), "give exactly one knowledge base"),
    (("--accelerometers", "--neighbours", "8"), "--neighbours does not apply to --multilinear"),
])
def test_what_a_model_cannot_take_is_refused_before_any_work(sneak_model, tmp_path, args, said):
    out = tmp_path / "rec.bvh"
    signal, *rest = args
    rest = [str(tmp_path) if a == "DB" else a for a in rest]
    code, _, err = run("reconstruct", "--multilinear", sneak_model, signal, SNEAK[1], "-o", out, *rest)
    assert code == 2 and one_error_line(err) and said in err, err
    assert not out.exists()


def test_build_refuses_takes_of_several_classes_or_unnamed_ones_and_writes_nothing(tmp_path):
    model = tmp_path / "m.npz"
    jog = samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc")
    code, _, err = run("multilinear", "build", model, SNEAK[0], jog)
    assert code == 2 and one_error_line(err) and "takes of 2 motion classes" in err and "--modes take" not in err
    code, _, err = run("multilinear", "build", model, samples.path("131_01.bvh"), SNEAK[0])
    assert code == 2 and one_error_line(err) and "'131_01' is named neither" in err and "pass --modes take" in err
    code, _, err = run("multilinear", "build", model, SNEAK[0])
    assert code == 2 and one_error_line(err) and "at least 2 takes" in err
    assert not model.exists()
    code, stdout, err = run("multilinear", "build", model, *SNEAK, "--modes", "take", "--json")
    assert code == 0, err
    said = json.loads(stdout)
    assert said["modes"] == {"take": 2} and said["takes"] == 2 and load_model(model)[1]["modes"] == ["take"]
    code, _, err = run("multilinear", "build", model, *SNEAK)
    assert code == 2 and one_error_line(err) and "--overwrite" in err


def test_save_model_keeps_the_settings(tmp_path):
    clips = [mocapkit.load(p) for p in SNEAK]
    model = MultilinearModel(ranks={"repetition": 1}, regularization=0.01, starts=1).fit(clips)
    back, desc = load_model(save_model(model, tmp_path / "m.npz", sources=[p.name for p in SNEAK]))
    assert back.ranks == {"repetition": 1} and back.regularization == 0.01 and back.starts == 1
    assert back.phi_q_.shape == model.phi_q_.shape and desc["sources"] == [p.name for p in SNEAK]
    assert default_sensors(back.skeleton_, up_axis=back.up_)[0].name == "left_wrist"
