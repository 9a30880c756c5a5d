"""C3D trials longer than the 65,535 frames a header can state: read whole, written so every reader finds them."""

import functools
import struct
import warnings

import numpy as np
import pytest

from mocapkit.errors import MocapFormatError
from mocapkit.io.c3d import read_c3d, write_c3d
from mocapkit.io.c3d_frames import FRAME_CAP, long_trial_frames, read_frames
from mocapkit.markerset import MarkerSet

FRAMES = 70_000  # past the header's cap, 4,465 frames more
M, CHANNELS, RATIO = 3, 2, 2


@functools.lru_cache(maxsize=None)
def _known_take(frames: int = FRAMES):
    """Points (F, M, 3) float32-exact mm, fourth words (F, M) (residual byte, camera byte, -1 missing) and
    analogs (A, F * ratio): what the generated file holds, for comparing what is read with. Drawn once and
    read-only: the tests share them."""
    rng = np.random.default_rng(7)
    xyz = (np.cumsum(rng.normal(size=(frames, M, 3)), axis=0) * 10).astype(np.float32).astype(np.float64)
    words = (rng.integers(0, 100, size=(frames, M)) | (rng.integers(1, 127, size=(frames, M)) << 8)).astype(np.int64)
    words[::997, 1] = -1  # missing samples, some past the cap
    analogs = rng.normal(size=(CHANNELS, frames * RATIO)).astype(np.float32).astype(np.float64)
    for a in (xyz, words, analogs):
        a.setflags(write=False)
    return xyz, words, analogs


def _long_c3d(path, *, trial: bool = True, keep_frames: int | None = None):
    """A C3D of :data:`FRAMES` frames as Vicon stores a long trial: ezc3d writes every frame of data with the
    header (and POINT:FRAMES) at 65,535; ``trial``: TRIAL:ACTUAL_START_FIELD/END_FIELD state the length
    (two 16-bit words each); ``keep_frames``: the data block cut after that many whole frames."""
    import ezc3d

    xyz, words, analogs = _known_take()
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = np.array([100.0])
    c["parameters"]["POINT"]["UNITS"] = {"type": -1, "description": "", "is_locked": False, "value": ["mm"]}
    c["parameters"]["POINT"]["LABELS"]["value"] = ["A", "B", "C"]
    c["parameters"]["ANALOG"]["RATE"]["value"] = np.array([100.0 * RATIO])
    c["parameters"]["ANALOG"]["USED"]["value"] = np.array([CHANNELS])
    c["parameters"]["ANALOG"]["LABELS"]["value"] = ["Fz", "EMG"]
    if trial:
        c["parameters"]["TRIAL"] = {
            "__METADATA__": {"DESCRIPTION": "", "IS_LOCKED": False},
            "ACTUAL_START_FIELD": {"type": 2, "description": "", "is_locked": False, "value": np.array([1, 0])},
            # 70,000 = 4464 + 1 * 65536
            "ACTUAL_END_FIELD": {"type": 2, "description": "", "is_locked": False, "value": np.array([4464, 1])},
        }
    pts = np.ones((4, M, FRAMES))
    pts[:3] = xyz.transpose(2, 1, 0)
    c["data"]["points"] = pts
    c["data"]["meta_points"]["residuals"] = np.zeros((1, M, FRAMES))
    c["data"]["analogs"] = analogs[None]
    c.write(str(path))
    raw = bytearray(path.read_bytes())
    data_start = struct.unpack_from("<H", raw, 16)[0]
    width = 4 * M + CHANNELS * RATIO
    block = np.frombuffer(raw, dtype="<f4", count=FRAMES * width, offset=(data_start - 1) * 512).reshape(FRAMES, width)
    block[:, 3:4 * M:4] = words  # the fourth word as the C3D guide has it
    block[:, 0:4 * M:4][words < 0] = 0.0
    if keep_frames is not None:
        raw = raw[:(data_start - 1) * 512 + keep_frames * width * 4]
    path.write_bytes(bytes(raw))
    assert struct.unpack_from("<H", raw, 8)[0] == FRAME_CAP  # the header says 65,535 frames
    return path


@pytest.fixture(scope="module")
def long_trial(tmp_path_factory):
    """The :func:`_long_c3d` file with its TRIAL length, written once (ezc3d, 70,000 frames) and only read by the
    tests that take it."""
    return _long_c3d(tmp_path_factory.mktemp("long") / "long.c3d")


def _expected_positions(xyz, words):
    out = xyz.copy()
    out[words < 0] = np.nan
    return out


def test_every_frame_of_a_long_trial_is_read(long_trial):
    path = long_trial
    ms = read_c3d(path)
    xyz, words, analogs = _known_take()
    assert ms.num_frames == FRAMES
    assert np.array_equal(ms.positions, _expected_positions(xyz, words), equal_nan=True)
    assert np.array_equal(ms.residuals, np.where(words < 0, -1.0, (words & 0xFF) * 1.0))
    assert np.array_equal(ms.cameras, np.where(words < 0, 0, words >> 8))
    assert np.array_equal(ms.source.analogs, analogs)


def test_long_trial_agrees_with_the_c3d_package(long_trial):
    c3d = pytest.importorskip("c3d")
    path = long_trial
    ms = read_c3d(path)
    with open(path, "rb") as fh, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        frames = [(p.copy(), a.copy()) for _, p, a in c3d.Reader(fh).read_frames()]
    points = np.array([p for p, _ in frames])  # (F, M, 5): x y z residual cameras
    assert points.shape[0] == ms.num_frames == FRAMES
    assert np.array_equal(ms.positions, np.where(points[..., 3:4] < 0, np.nan, points[..., :3]), equal_nan=True)
    assert np.array_equal(ms.residuals, np.where(points[..., 3] < 0, -1.0, points[..., 3]))
    assert np.array_equal(ms.cameras, np.where(points[..., 3] < 0, 0, points[..., 4]))
    analogs = np.array([a for _, a in frames])  # (F, A, ratio)
    assert np.array_equal(ms.source.analogs, analogs.transpose(1, 0, 2).reshape(CHANNELS, -1))


def test_long_trial_cut_short_is_refused(tmp_path):
    path = _long_c3d(tmp_path / "cut.c3d", keep_frames=68_000)
    with pytest.raises(MocapFormatError) as err:
        read_c3d(path)
    message = str(err.value)
    assert "cut.c3d" in message and "70000 frames" in message and "68000" in message and "\n" not in message


def test_capped_header_with_bytes_no_count_of_frames_explains_is_refused(tmp_path):
    """A header at the cap, no parameter stating the length, and more than a block's padding after the last
    whole frame: how many frames the file holds cannot be told, so it is refused, not read as 65,535."""
    points = 40  # 640-byte frames: wider than a block, so padding cannot pass for a frame
    raw = bytearray(512 * 2 + FRAME_CAP * points * 16 + 640 + 600)  # 65,536 frames and 600 bytes more
    raw[0], raw[1], raw[512 + 3] = 2, 0x50, 84
    struct.pack_into("<HHHH", raw, 2, points, 0, 1, FRAME_CAP)
    struct.pack_into("<H", raw, 16, 3)
    with pytest.raises(MocapFormatError, match=r"odd\.c3d.*its length cannot be told"):
        long_trial_frames(tmp_path / "odd.c3d", bytes(raw), {}, FRAME_CAP, points, 0, -1.0)
    # 300 bytes more instead: one more frame and a block's padding
    assert long_trial_frames(tmp_path / "odd.c3d", bytes(raw[:-300]), {}, FRAME_CAP, points, 0, -1.0) == FRAME_CAP + 1


def test_long_take_written_and_read_back_equal(tmp_path, long_trial):
    ms = read_c3d(long_trial)
    out = tmp_path / "out.c3d"
    write_c3d(ms, out)
    back = read_c3d(out)
    assert back.num_frames == FRAMES
    assert np.array_equal(back.positions, ms.positions, equal_nan=True)
    assert np.array_equal(back.residuals, ms.residuals) and np.array_equal(back.cameras, ms.cameras)
    assert np.array_equal(back.source.analogs, ms.source.analogs)


def test_written_long_take_states_its_length_for_every_reader(tmp_path):
    """ezc3d alone writes the header and POINT:FRAMES at 65,535: the TRIAL fields and POINT:LONG_FRAMES
    must say 70,000, or readers that go by them (the c3d package) stop at 65,535."""
    import ezc3d

    c3d = pytest.importorskip("c3d")
    rng = np.random.default_rng(3)
    ms = MarkerSet(labels=("A", "B"), positions=rng.normal(size=(FRAMES, 2, 3)).astype(np.float32).astype(float),
                   fps=120.0, units="mm")
    out = tmp_path / "new.c3d"
    write_c3d(ms, out)
    params = ezc3d.c3d(str(out))["parameters"]
    assert [int(v) & 0xFFFF for v in params["TRIAL"]["ACTUAL_START_FIELD"]["value"]] == [1, 0]
    assert [int(v) & 0xFFFF for v in params["TRIAL"]["ACTUAL_END_FIELD"]["value"]] == [4464, 1]
    assert float(params["POINT"]["LONG_FRAMES"]["value"][0]) == FRAMES
    with open(out, "rb") as fh, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert c3d.Reader(fh).frame_count == FRAMES
    assert np.array_equal(read_c3d(out).positions, ms.positions)


def test_short_take_drops_a_stale_long_frame_count(tmp_path, long_trial):
    ms = read_c3d(long_trial)
    out = tmp_path / "part.c3d"
    write_c3d(ms[:100], out)
    import ezc3d

    params = ezc3d.c3d(str(out))["parameters"]
    assert "LONG_FRAMES" not in params["POINT"]
    assert [int(v) & 0xFFFF for v in params["TRIAL"]["ACTUAL_END_FIELD"]["value"]] == [100, 0]
    assert read_c3d(out).num_frames == 100


def test_numpy_frames_match_ezc3d_on_real_files(shared_data):
    """read_frames (the frames past ezc3d's) reads real files' data blocks as ezc3d does: float and integer
    storage, Intel and DEC processors, signed and UNSIGNED analogs with offsets."""
    import ezc3d

    names = ["Gait.c3d", "Eb015pi.c3d", "FunctionalWalk.c3d", "PiG_Motion-FlatFoot-Full.c3d"]
    files = {p.name: p for p in shared_data.rglob("*.c3d") if p.name in names}
    assert set(files) == set(names)
    for name, path in sorted(files.items()):
        c = ezc3d.c3d(str(path))
        pts, a = c["data"]["points"], c["data"]["analogs"]
        frames, points = pts.shape[2], pts.shape[1]
        per_frame = a.shape[1] * (a.shape[2] // frames)
        scale = float(c["parameters"]["POINT"]["SCALE"]["value"][0])
        xyz, analogs = read_frames(path.read_bytes(), 0, frames, points, per_frame, scale, c["parameters"])
        seen = ~np.isnan(pts[:3].transpose(2, 1, 0))
        assert np.allclose(xyz[seen], pts[:3].transpose(2, 1, 0)[seen], rtol=1e-6, atol=1e-9), name
        if a.size:
            assert np.allclose(analogs, a[0], rtol=1e-6, atol=1e-9), name


def _tiled_capture(path, shared_data, markers: int, frames: int = 70_001):
    """A real capture (85_02.c3d's first ``markers`` markers) tiled to ``frames`` frames and written by ezc3d as
    ezc3d writes a long trial: the header at 65,535 and no TRIAL:ACTUAL_END_FIELD or POINT:LONG_FRAMES.
    Returns the path and the (F, M, 3) coordinates written (gaps as zeros, float32-exact)."""
    import ezc3d

    take = read_c3d(shared_data / "c3d_markers_recovery" / "85_02.c3d")
    xyz = np.nan_to_num(np.resize(take.positions[:, :markers], (frames, markers, 3))).astype(np.float32)
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = np.array([take.fps])
    c["parameters"]["POINT"]["LABELS"]["value"] = list(take.labels[:markers])
    c["parameters"]["POINT"]["UNITS"] = {"type": -1, "description": "", "is_locked": False, "value": [take.units]}
    pts = np.ones((4, markers, frames))
    pts[:3] = xyz.transpose(2, 1, 0)
    c["data"]["points"] = pts
    c["data"]["meta_points"]["residuals"] = np.zeros((1, markers, frames))
    c.write(str(path))
    params = ezc3d.c3d(str(path))["parameters"]
    assert "LONG_FRAMES" not in params["POINT"] and "TRIAL" not in params
    assert struct.unpack_from("<H", path.read_bytes(), 8)[0] == FRAME_CAP
    return path, xyz.astype(np.float64)


def test_capped_trial_of_narrow_frames_without_a_length_is_refused(tmp_path, shared_data):
    """8 markers (128-byte frames) and 70,001 frames: the last 512-byte block's padding (384 bytes) holds whole
    frames, so 70,001 to 70,004 frames fit the file; none is read as frames nor any real frame dropped."""
    path, _ = _tiled_capture(tmp_path / "tiled.c3d", shared_data, markers=8)
    with pytest.raises(MocapFormatError) as err:
        read_c3d(path)
    message = str(err.value)
    assert "tiled.c3d" in message and "70000 to 70004 frames" in message and "cannot be told" in message
    assert "\n" not in message


def test_capped_trial_of_wide_frames_without_a_length_is_read_whole(tmp_path, shared_data):
    """41 markers (656-byte frames): one count alone leaves at most a block of padding, and it is read."""
    path, xyz = _tiled_capture(tmp_path / "tiled.c3d", shared_data, markers=41)
    ms = read_c3d(path, zeros_as_gaps=False)
    assert ms.num_frames == 70_001
    assert np.array_equal(ms.positions, xyz)


def test_a_files_own_long_frame_count_is_kept_stating_the_frames_written(tmp_path):
    """Qualisys states POINT:LONG_FRAMES in every file, long or not (03_rolling.c3d: 2305.0). Written back it is
    kept, stating the frames written (a part of the take: its own count), not dropped as a parameter of the
    file's lost; a file without one gets none."""
    import dataclasses
    from pathlib import Path

    import ezc3d

    take = read_c3d(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")
    assert "LONG_FRAMES" not in take.source.parameters["POINT"]
    write_c3d(take, tmp_path / "plain.c3d")
    assert "LONG_FRAMES" not in ezc3d.c3d(str(tmp_path / "plain.c3d"))["parameters"]["POINT"]
    params = {g: dict(p) for g, p in take.source.parameters.items()}
    params["POINT"]["LONG_FRAMES"] = {"type": 4, "description": "Number of frames (not limited to 65535)",
                                      "is_locked": False, "value": np.array([float(take.num_frames)])}
    qualisys = dataclasses.replace(take, source=dataclasses.replace(take.source, parameters=params))
    for part, frames in ((qualisys, take.num_frames), (qualisys[:100], 100)):
        out = tmp_path / f"{frames}.c3d"
        write_c3d(part, out)
        got = ezc3d.c3d(str(out))["parameters"]["POINT"]["LONG_FRAMES"]
        assert float(got["value"][0]) == frames
        assert got["description"] == "Number of frames (not limited to 65535)"
        assert read_c3d(out).num_frames == frames


def test_a_part_of_a_long_trial_keeps_its_frame_numbers(tmp_path, monkeypatch):
    """A part of a long trial starting past frame 65,535 (written with TRIAL:ACTUAL_START_FIELD) read back
    numbered one frame early (66,001 as 66,000: the ``c3d`` package takes the field's high word as 65,535
    frames) and, a short one, with one frame more than written (read from the padding past the data block);
    ezc3d, reading the header's word alone, read a take numbered from 70,001 as 4,465. The header now holds
    the cap, the field the number, and both readers number the frames the take's."""
    import sys

    from mocapkit.markerset import MarkerSource

    xyz = _known_take()[0]
    whole = tmp_path / "whole.c3d"
    write_c3d(MarkerSet(labels=("a", "b", "c"), positions=xyz, fps=100.0, units="mm"), whole)
    taken = read_c3d(whole)
    own = MarkerSet(labels=("a", "b", "c"), positions=xyz[:10], fps=100.0, units="mm",
                    source=MarkerSource(format="npz", first_frame=70_001))
    for take, first in ((taken[66_000:69_000], 66_001), (taken[69_990:], 69_991), (own, 70_001)):
        out = tmp_path / "part.c3d"
        write_c3d(take, out)
        for reader in ("ezc3d", "c3d"):
            with monkeypatch.context() as m:
                if reader == "c3d":
                    m.setitem(sys.modules, "ezc3d", None)  # `import ezc3d` fails: the fallback reader reads it
                back = read_c3d(out)
            assert back.reader == reader and back.source.first_frame == first
            assert np.array_equal(back.positions, take.positions, equal_nan=True)
