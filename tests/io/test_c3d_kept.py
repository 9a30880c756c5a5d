"""What write_c3d keeps of a C3D written back: stored coordinates under a missing sample's word, force plates of
a file without analog channels, the events of a resampled take."""

import struct
from pathlib import Path

import numpy as np

import mocapkit
from mocapkit.io import load_markers, save_markers

EB015PR = Path(mocapkit.__file__).parent / "data" / "Eb015pr.c3d"
ADEMO1_INT = "peer_files/BTKData/Input/C3DSamples/others/ADemo1_rewrite_c3d_pc_integer.c3d"


def _point_frames(path) -> np.ndarray:
    """(F, M, 5) x, y, z, residual and camera mask of every sample as the ``c3d`` package reads the file."""
    import c3d

    with open(path, "rb") as fh:
        return np.array([p.copy() for _, p, _ in c3d.Reader(fh).read_frames()])


def _marked_missing(tmp_path, cells) -> Path:
    """Eb015pr.c3d (float, 26 points, 64 analog samples a frame, data at block 11) with the fourth word of each
    (frame, point) in ``cells`` set to -1: missing, its coordinates still stored."""
    raw = bytearray(EB015PR.read_bytes())
    start, width = 10 * 512, (4 * 26 + 64) * 4
    for f, m in cells:
        struct.pack_into("<f", raw, start + f * width + (4 * m + 3) * 4, -1.0)
    path = tmp_path / "marked.c3d"
    path.write_bytes(bytes(raw))
    return path


def test_a_missing_sample_keeps_the_coordinates_the_file_stored(tmp_path):
    import ezc3d

    path = _marked_missing(tmp_path, [(10, 2), (11, 2), (40, 7)])
    take = load_markers(path)
    assert take.missing()[[10, 11, 40], [2, 2, 7]].all()
    same = _point_frames(save_markers(take, tmp_path / "same.c3d"))
    assert np.array_equal(same, _point_frames(path))  # before: (0, 0, 0) under the three words
    assert np.isnan(ezc3d.c3d(str(tmp_path / "same.c3d"))["data"]["points"][0, 2, 10])  # still missing to ezc3d
    # a sample given a value is written as the take has it; a part of the take keeps its own samples' numbers
    filled = take.positions.copy()
    filled[10, 2] = take.positions[9, 2]
    out = _point_frames(save_markers(take.with_positions(filled), tmp_path / "filled.c3d"))
    assert np.allclose(out[10, 2, :3], _point_frames(path)[9, 2, :3]) and out[10, 2, 3] == 0
    assert np.array_equal(out[11, 2], _point_frames(path)[11, 2])
    part = _point_frames(save_markers(take[11:50], tmp_path / "part.c3d"))
    assert np.array_equal(part, _point_frames(path)[11:50])


def test_ademo1_integer_copy_written_unchanged_reads_back_whole(shared_data, tmp_path):
    src = shared_data / ADEMO1_INT
    take = load_markers(src)
    back = _point_frames(save_markers(take, tmp_path / "back.c3d"))
    assert np.array_equal(back, _point_frames(src))  # before: 85 samples' coordinates 0
    assert len(take.source.missing_stored) == 85
