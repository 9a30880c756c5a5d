"""``mocapkit clean`` and ``clean-batch`` on marker captures, end to end: C3D in, C3D out, read back with ezc3d."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from mocapkit.cleaning.gapfill import fill_channels
from mocapkit.io import load_markers, save_markers

from .helpers import SAMPLE, one_error_line, run

CMU = Path(__file__).resolve().parents[1] / "data" / "85_02.c3d"


def _ezc3d_points(path: Path) -> np.ndarray:
    """(F, M, 3) points as ezc3d reads them, NaN where the residual is negative."""
    import ezc3d

    c = ezc3d.c3d(str(path))
    pts = np.asarray(c["data"]["points"][:3]).transpose(2, 1, 0)
    res = np.asarray(c["data"]["meta_points"]["residuals"][0]).T
    pts[res < 0] = np.nan
    return pts


@pytest.fixture(scope="module")
def cut_take(tmp_path_factory):
    """85_02 with four 0.8 s gaps, written with ezc3d: (path, truth, gap mask)."""
    d = tmp_path_factory.mktemp("cut")
    ms = load_markers(CMU)
    truth = np.array(ms.positions)
    y = truth.copy()
    mask = np.zeros(y.shape[:2], bool)
    for k, a in [(3, 150), (12, 300), (20, 420), (33, 560)]:
        mask[a:a + 96, k] = True
    y[mask] = np.nan
    path = d / "cut.c3d"
    save_markers(ms.with_positions(y), path)
    return path, truth, mask


def test_clean_c3d_end_to_end(cut_take, tmp_path):
    inp, truth, mask = cut_take
    out = tmp_path / "clean.c3d"
    code, stdout, stderr = run("clean", inp, "-o", out, "--report", tmp_path / "r.html", "--png", tmp_path / "p.png")
    assert code == 0, stderr
    assert "4 gaps filled" in stdout
    got = _ezc3d_points(out)
    before = _ezc3d_points(inp)
    assert not np.isnan(got).any()
    assert np.array_equal(got[~mask], before[~mask])  # observed samples unchanged, as written
    lin = fill_channels(before.reshape(len(before), -1), "linear").reshape(before.shape)
    err = np.sqrt(np.mean(np.sum((got[mask] - truth[mask]) ** 2, -1)))
    err_lin = np.sqrt(np.mean(np.sum((lin[mask] - truth[mask]) ** 2, -1)))
    assert err < 0.5 * err_lin
    with np.load(tmp_path / "clean.clean.npz") as rec:
        assert np.array_equal(rec["filled"], mask)
    page = (tmp_path / "r.html").read_text()
    assert "gap filled" in page and '"kind"' in page
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"


def test_clean_c3d_to_trc_and_refusals(cut_take, tmp_path):
    inp, _, _ = cut_take
    out = tmp_path / "clean.trc"
    code, _, stderr = run("clean", inp, "-o", out)
    assert code == 0, stderr
    assert not load_markers(out).missing().any()
    code, _, stderr = run("clean", inp, "-o", out)  # exists: refused without --overwrite
    assert code != 0 and one_error_line(stderr)
    code, _, stderr = run("clean", inp, "-o", tmp_path / "x.bvh")
    assert code != 0 and one_error_line(stderr) and not (tmp_path / "x.bvh").exists()
    code, _, stderr = run("clean", inp, "-o", tmp_path / "y.c3d", "--reference", inp)
    assert code != 0 and "--reference" in stderr and not (tmp_path / "y.c3d").exists()


def test_clean_batch_mixes_marker_and_skeletal_takes(cut_take, tmp_path):
    inp, _, _ = cut_take
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(inp, src / "markers.c3d")
    shutil.copy(SAMPLE, src / "walk.bvh")
    code, stdout, stderr = run("clean-batch", src, tmp_path / "out", "--executor", "serial")
    assert code == 0, stderr + stdout
    assert (tmp_path / "out" / "markers.c3d").exists() and (tmp_path / "out" / "markers.clean.npz").exists()
    assert (tmp_path / "out" / "walk.bvh").exists()
    assert "2 cleaned" in stdout
    assert not load_markers(tmp_path / "out" / "markers.c3d").missing().any()
