import subprocess
import sys

import numpy as np
import pytest

import mocapkit
from mocapkit.cli import main

SAMPLE = str(mocapkit.samples.path("131_01.bvh"))


def run(*args):
    """Run the real console entry point in a subprocess: exit code, stdout, stderr."""
    p = subprocess.run([sys.executable, "-m", "mocapkit.cli", *args], capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def test_info_on_bvh_and_c3d(capsys):
    assert main(["info", SAMPLE]) == 0
    out = capsys.readouterr().out
    assert "994" in out and "120" in out and "31" in out and "5.644 cm" in out
    assert main(["info", str(mocapkit.samples.path("Eb015pr.c3d"))]) == 0
    out = capsys.readouterr().out
    assert "26" in out and "1.93 %" in out


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


def test_plot_writes_png(tmp_path):
    noisy = tmp_path / "noisy.bvh"
    assert main(["corrupt", SAMPLE, str(noisy), "--kind", "noise", "--seed", "1"]) == 0
    png = tmp_path / "knee.png"
    assert main(["plot", SAMPLE, str(noisy), "--joint", "LeftKnee", "-o", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bad_input_is_one_line_and_exit_2(tmp_path):
    bad = tmp_path / "broken.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n")
    code, out, err = run("info", str(bad))
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "broken.bvh" in lines[0]
    code, _, err = run("info", str(tmp_path / "missing.bvh"))
    assert code == 2 and "missing.bvh" in err
    code, _, err = run("convert", SAMPLE, str(tmp_path / "x.fbx"))
    assert code == 2 and "unknown suffix" in err and not (tmp_path / "x.fbx").exists()


def test_never_overwrites_the_input(tmp_path):
    src = tmp_path / "in.bvh"
    src.write_bytes(open(SAMPLE, "rb").read())
    before = src.read_bytes()
    code, _, err = run("convert", str(src), str(src))
    assert code == 2 and "refusing to overwrite the input" in err
    assert src.read_bytes() == before


def test_gaps_cannot_go_to_bvh_and_leave_nothing(tmp_path):
    out = tmp_path / "gappy.bvh"
    code, _, err = run("corrupt", SAMPLE, str(out), "--kind", "gaps", "--seed", "1")
    assert code == 2 and "NaN" in err
    assert list(tmp_path.iterdir()) == []
    out = tmp_path / "gappy.npz"
    code, _, _ = run("corrupt", SAMPLE, str(out), "--kind", "gaps", "--seed", "1")
    assert code == 0 and mocapkit.load(out).missing().any()


def test_help_reads_well():
    code, out, _ = run("--help")
    assert code == 0
    for cmd in ("info", "convert", "corrupt", "plot"):
        assert cmd in out


def _db_sources():
    return [str(mocapkit.samples.path(n)) for n in ("12_walk.amc", "HDM_bk_sneak2StepsLStart_004_120.amc", "HDM_bk_sneak2StepsLStart_005_120.amc")]


def test_db_build_info_and_search(tmp_path, capsys):
    import json

    db_dir = tmp_path / "db"
    assert main(["db", "build", str(db_dir), *_db_sources(), "--mirror", "--features", "F15,F30", "--executor", "serial"]) == 0
    assert "6 clips" in capsys.readouterr().out
    assert main(["db", "info", str(db_dir), "--json"]) == 0
    info = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert info["clips"] == 6 and info["mirrored_clips"] == 3 and info["features"] == {"F15": 15, "F30": 30}
    query = mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")
    assert main(["search", str(db_dir), str(query), "--k", "2", "--start", "0.5", "--end", "1.5", "--json"]) == 0
    res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert res[0]["name"] == "HDM_bk_sneak2StepsLStart_005_120" and res[0]["start"] == 15 and res[0]["end"] == 44
    assert res[0]["cost"] < 0.01 and res[1]["cost"] > res[0]["cost"]
    assert main(["search", str(db_dir), str(query), "--k", "2", "--features", "F30", "--json"]) == 0
    res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert res[0]["name"] == "HDM_bk_sneak2StepsLStart_005_120"
    # a query on another rig works: features are joint positions by role, in centimetres
    assert main(["search", str(db_dir), SAMPLE, "--k", "1", "--start", "2", "--end", "3"]) == 0
    assert "cost/frame" in capsys.readouterr().out


def one_error_line(err: str) -> bool:
    """Exactly one error line (progress bars may precede it on stderr), and it is the last line."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    return sum(ln.startswith("mocapkit: error:") for ln in lines) == 1 and lines[-1].startswith("mocapkit: error:")


def test_db_errors_are_one_line(tmp_path):
    db_dir = tmp_path / "db"
    code, _, err = run("db", "build", str(db_dir), str(mocapkit.samples.path("12_walk.amc")), SAMPLE, "--executor", "serial")
    assert code == 2 and one_error_line(err) and "131_01.bvh" in err and "skeleton differs" in err
    assert not db_dir.exists()
    code, _, err = run("db", "info", str(tmp_path))
    assert code == 2 and "not a motion database" in err and one_error_line(err)
    assert main(["db", "build", str(db_dir), str(mocapkit.samples.path("12_walk.amc")), "--executor", "serial"]) == 0
    code, _, err = run("db", "build", str(db_dir), str(mocapkit.samples.path("12_walk.amc")))
    assert code == 2 and "already exists" in err
    code, _, err = run("search", str(db_dir), str(mocapkit.samples.path("Eb015pr.c3d")))
    assert code == 2 and "Eb015pr.c3d" in err and one_error_line(err)
    code, _, err = run("search", str(db_dir), str(mocapkit.samples.path("12_walk.amc")), "--features", "F39")
    assert code == 2 and "no feature set 'F39'" in err and one_error_line(err)
