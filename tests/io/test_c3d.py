import numpy as np
import pytest

import mocapkit
from mocapkit.errors import MocapFormatError
from mocapkit.io.c3d import read_c3d

from .bounded import refusal_of_load


def test_bundled_gait_trial():
    ms = mocapkit.load(mocapkit.samples.path("Eb015pr.c3d"))
    assert ms.num_frames == 450 and ms.num_markers == 26 and ms.fps == 50.0
    assert ms.units == "mm" and ms.unit_cm == 0.1
    assert ms.labels[:3] == ("RFT1", "RFT2", "RFT3")
    # the README's validation found 1.9 % of samples flagged invalid (negative residual)
    assert ms.missing().mean() == pytest.approx(0.019316, abs=1e-5)
    # markers move smoothly: frame-to-frame steps of a gait trial at 50 Hz stay under 10 cm
    step = np.linalg.norm(np.diff(ms.positions, axis=0), axis=-1)
    assert np.nanmax(step) < 100.0


def test_every_c3d_in_shared_data_loads(shared_data):
    # expected marker counts and missing fractions from the data README (python `c3d` validation)
    expected = {
        "Eb015pi": (26, 0.019), "Eb015pr": (26, 0.019), "Dance": (40, 0.0), "golfswing": (29, 0.0),
        "phasespace_sample": (40, 0.046), "dynamic": (34, 0.355), "PiG_Motion-FlatFoot-Full": (193, 0.099),
        "PiG_Motion-FlatFoot-Hole": (193, 0.105), "Gait": (33, 0.602), "FunctionalWalk": (146, 0.261),
    }
    files = sorted((shared_data / "c3d_markers").glob("*.c3d"))
    assert files
    for f in files:
        ms = read_c3d(f)
        n, miss = expected[f.stem]
        assert ms.num_markers == n, f.name
        assert ms.missing().mean() == pytest.approx(miss, abs=0.0006), f.name
        # the trajectories are smooth (a data block read from the wrong offset is not): median step < 5 cm
        step = np.linalg.norm(np.diff(ms.positions, axis=0), axis=-1) * ms.unit_cm
        assert np.nanmedian(step) < 5.0, f.name


def test_the_two_pig_files_hold_the_same_trial(shared_data):
    full = read_c3d(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d")
    hole = read_c3d(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Hole.c3d")
    assert set(full.labels) == set(hole.labels)
    # the "Hole" file has more gaps than the complete one
    assert hole.missing().mean() > full.missing().mean()


def test_bad_c3d(tmp_path):
    bad = tmp_path / "bad.c3d"
    bad.write_bytes(b"\x00" * 100)
    with pytest.raises(MocapFormatError, match="bad.c3d"):
        mocapkit.load(bad)
    real = mocapkit.samples.path("Eb015pr.c3d").read_bytes()
    cut = tmp_path / "cut.c3d"
    cut.write_bytes(real[:1500])
    with pytest.raises(MocapFormatError, match="cut.c3d"):
        mocapkit.load(cut)


def write_c3d(path, n_frames=20, n_markers=3, rate=100.0):
    """A small C3D written by ezc3d: ``n_markers`` markers on smooth paths, every sample seen."""
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = np.array([rate])
    c["parameters"]["POINT"]["LABELS"]["value"] = tuple(f"M{i}" for i in range(n_markers))
    t = np.arange(n_frames)
    pts = np.ones((4, n_markers, n_frames))
    pts[:3] = (np.arange(n_markers)[None, :, None] * 100.0 + t[None, None, :]) * np.array([1.0, 2.0, 3.0])[:, None, None]
    c["data"]["points"] = pts
    c.write(str(path))
    return path


def test_a_point_rate_outside_1_to_1000_fps_is_refused(tmp_path):
    assert read_c3d(write_c3d(tmp_path / "ok.c3d", rate=1000.0)).fps == 1000.0
    for rate in (0.01, 20000.0):
        bad = write_c3d(tmp_path / f"rate_{rate:g}.c3d", rate=rate)
        with pytest.raises(MocapFormatError) as exc:
            read_c3d(bad)
        msg = str(exc.value)
        assert msg.startswith(f"{bad}: point frame rate must be a positive number from 1 to 1000"), msg
        assert "\n" not in msg


def parameter_offset(data: bytes, group: str, name: str) -> int:
    """Byte offset of the value of parameter GROUP:NAME in a little-endian C3D (walks the records)."""
    import struct

    i = (data[0] - 1) * 512 + 4
    groups, found = {}, {}
    while True:
        nlen, gid = abs(struct.unpack_from("b", data, i)[0]), struct.unpack_from("b", data, i + 1)[0]
        if nlen == 0 or gid == 0:
            break
        label = data[i + 2 : i + 2 + nlen].decode().upper()
        nxt = struct.unpack_from("<h", data, i + 2 + nlen)[0]
        body = i + 4 + nlen
        if gid < 0:
            groups[-gid] = label
        else:
            found[(gid, label)] = body + 2 + data[body + 1]  # after type, ndim and the dimensions
        if nxt == 0:
            break
        i = i + 2 + nlen + nxt
    gid = next(k for k, v in groups.items() if v == group)
    return found[(gid, name)]


def test_point_used_disagreeing_with_the_header_is_refused(tmp_path):
    import struct

    good = write_c3d(tmp_path / "good.c3d", n_markers=33)
    assert read_c3d(good).num_markers == 33
    data = bytearray(good.read_bytes())
    at = parameter_offset(bytes(data), "POINT", "USED")
    assert struct.unpack_from("<h", data, at)[0] == 33
    struct.pack_into("<h", data, at, 32767)  # was read as 32,767 markers, exit 0
    bad = tmp_path / "used.c3d"
    bad.write_bytes(bytes(data))
    msg = refusal_of_load(bad)
    assert msg == (
        f"{bad}: the parameter section disagrees with the header: POINT:USED is 32767 markers, the header says 33"
    )
