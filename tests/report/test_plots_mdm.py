"""The movement digression map picture (Aristidou et al. 2018, Fig. 1 bottom, Fig. 9)."""

import struct

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, metrics, samples
from mocapkit.report import plots
from mocapkit.report.plots import plot_mdm


def png_size(path) -> tuple[int, int]:
    """(width, height) in pixels from a PNG's IHDR chunk."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def expected_size(frames, names):
    lay = plots._mdm_layout(frames, names)
    w, h = lay["size"]
    assert lay["pixels"] == (round(w * plots._MDM_DPI), round(h * plots._MDM_DPI))
    return lay["pixels"]


@pytest.fixture(scope="module")
def walk_mdm():
    """A digression-like map from a real clip with injected errors: 1 - exp(-(d / mean d)^2) per joint."""
    m = mocapkit.load(samples.path("12_walk.amc"))
    bad, truth, _ = corrupt.real_errors(m, n_errors=5, seed=0)
    d = metrics.geodesic_pose_distance(m, bad) + 0.01 * np.abs(np.sin(np.arange(m.num_frames)))[:, None]
    M = d / d.mean(axis=0, keepdims=True)
    return m, 1.0 - np.exp(-(M**2)), truth


def test_writes_png_of_the_expected_size(tmp_path, walk_mdm):
    m, mdm, truth = walk_mdm
    flags = mdm > 0.5
    out = plot_mdm(mdm, m.skeleton.joint_names, m.fps, tmp_path / "sub" / "mdm.png", flags=flags, truth=truth,
                   title="12_walk", start_frame=100)
    assert out == tmp_path / "sub" / "mdm.png"
    assert out.stat().st_size > 10_000
    assert png_size(out) == expected_size(m.num_frames, m.skeleton.joint_names)
    assert not [p for p in out.parent.iterdir() if p.name != "mdm.png"]  # no temporary file left
    # the picture shows the map: hot cells are bright, the background dark
    import matplotlib.image as mpimg

    img = mpimg.imread(out)
    assert img.shape[:2] == png_size(out)[::-1]
    assert img[..., :3].std() > 0.1


def test_size_scales_with_joints_and_clip_length_and_is_capped(tmp_path):
    names = [f"joint{i}" for i in range(31)]
    sizes = {}
    for frames, J in [(200, 31), (800, 31), (100_000, 31), (200, 10), (200, 60)]:
        path = plot_mdm(np.zeros((frames, J)), (names * 2)[:J], 120.0, tmp_path / f"{frames}_{J}.png", threshold=None)
        sizes[frames, J] = png_size(path)
        assert sizes[frames, J] == expected_size(frames, (names * 2)[:J])
    assert sizes[800, 31][0] > sizes[200, 31][0]
    assert sizes[100_000, 31][0] <= 100 * (plots._MDM_AXES_W_IN[1] + 4.0)  # width capped
    assert sizes[200, 10][1] < sizes[200, 31][1] < sizes[200, 60][1]
    # every joint gets at least a 0.2 in row up to 120 joints: labels stay readable
    lay = plots._mdm_layout(200, names)
    assert lay["axes_h"] == pytest.approx(0.2 * 31) and lay["fontsize"] >= 7.0


def test_nan_cells_and_all_nan_blocks_do_not_crash(tmp_path):
    rng = np.random.default_rng(0)
    mdm = rng.uniform(0, 1, size=(5000, 8))
    mdm[:, 3] = np.nan            # a joint never analysed
    mdm[1000:3000] = np.nan       # frames never analysed (whole display blocks all NaN)
    flags = np.zeros(mdm.shape, dtype=bool)
    flags[2500, 5] = True         # one flagged cell inside the NaN stretch
    path = plot_mdm(mdm, list("abcdefgh"), 30.0, tmp_path / "nan.png", flags=flags)
    assert path.stat().st_size > 0 and png_size(path) == expected_size(5000, list("abcdefgh"))
    one = plot_mdm(np.full((1, 1), np.nan), ["root"], 120.0, tmp_path / "one.png")
    assert one.stat().st_size > 0


def test_outline_follows_cell_edges():
    mask = np.zeros((6, 4), dtype=bool)
    mask[1:4, 1] = True     # 3 frames on joint 1
    mask[2, 2] = True       # and one cell beside it
    segs = plots._mask_outline(mask, x0=10.0)
    # total outline length = perimeter of the union of cells: 2*(3+1) + 4 - 2 (shared edge) = 10
    assert np.sum(np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1)) == pytest.approx(10.0)
    assert segs[..., 0].min() == pytest.approx(10.0 + 1 - 0.5) and segs[..., 0].max() == pytest.approx(10.0 + 4 - 0.5)
    assert segs[..., 1].min() == pytest.approx(0.5) and segs[..., 1].max() == pytest.approx(2.5)
    assert plots._mask_outline(np.zeros((3, 3), dtype=bool), 0.0).shape == (0, 2, 2)


def test_block_max_keeps_single_frame_spikes():
    a = np.zeros((10, 2))
    a[7, 0] = 0.9
    a[:, 1] = np.nan
    b = plots._bin_max(a, 4)
    assert b.shape == (3, 2) and b[1, 0] == 0.9 and np.all(np.isnan(b[:, 1]))


def test_bad_input_raises_clear_errors(tmp_path):
    names = ["a", "b", "c"]
    p = tmp_path / "x.png"
    with pytest.raises(ValueError, match=r"\(frames, joints\) array"):
        plot_mdm(np.zeros(10), names, 120.0, p)
    with pytest.raises(ValueError, match="3 joint names"):
        plot_mdm(np.zeros((10, 4)), names, 120.0, p)
    with pytest.raises(ValueError, match="empty"):
        plot_mdm(np.zeros((0, 3)), names, 120.0, p)
    with pytest.raises(ValueError, match=r"flags must have the shape of mdm \(10, 3\)"):
        plot_mdm(np.zeros((10, 3)), names, 120.0, p, flags=np.zeros((10, 2), dtype=bool))
    with pytest.raises(ValueError, match="truth must have the shape"):
        plot_mdm(np.zeros((10, 3)), names, 120.0, p, truth=np.zeros((3, 10), dtype=bool))
    bad = np.zeros((10, 3))
    bad[4, 1] = 1.5
    with pytest.raises(ValueError, match=r"\[0, 1\].*frame 4, joint 'b'"):
        plot_mdm(bad, names, 120.0, p)
    bad[4, 1] = np.inf
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        plot_mdm(bad, names, 120.0, p)
    with pytest.raises(ValueError, match="fps"):
        plot_mdm(np.zeros((10, 3)), names, 0.0, p)
    with pytest.raises(ValueError, match="threshold"):
        plot_mdm(np.zeros((10, 3)), names, 120.0, p, threshold=2.0)
    assert not p.exists()
