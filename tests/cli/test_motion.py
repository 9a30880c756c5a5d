"""`mocapkit info`, `convert`, `corrupt` and `plot` on real takes."""

import numpy as np

import mocapkit
from mocapkit.cli import main
from tests.cli.helpers import SAMPLE, one_error_line, run


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


def test_gaps_cannot_go_to_bvh_and_leave_nothing(tmp_path):
    out = tmp_path / "gappy.bvh"
    code, _, err = run("corrupt", SAMPLE, str(out), "--kind", "gaps", "--seed", "1")
    assert code == 2 and "NaN" in err
    assert list(tmp_path.iterdir()) == []
    out = tmp_path / "gappy.npz"
    code, _, _ = run("corrupt", SAMPLE, str(out), "--kind", "gaps", "--seed", "1")
    assert code == 0 and mocapkit.load(out).missing().any()


