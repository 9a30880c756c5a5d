"""A C3D of more than 255 points: C3D states their labels and descriptions past the 255th in POINT:LABELS2,
DESCRIPTIONS2 ... (a parameter's dimension is one byte). Read and written back, every point keeps its label,
its samples and its description past the 255th."""

import sys
from pathlib import Path

import numpy as np

import mocapkit
from mocapkit.io.c3d import read_c3d, write_c3d

EB015PR = Path(mocapkit.__file__).parent / "data" / "Eb015pr.c3d"


def _tiled(path: Path, points: int = 300) -> list[str]:
    """A C3D of ``points`` markers (Eb015pr.c3d's 26 tiled, each copy 10 mm further along x) written by ezc3d
    with its LABELS2/DESCRIPTIONS2; returns the labels."""
    import ezc3d

    c = ezc3d.c3d(str(EB015PR))
    pts = c["data"]["points"]
    n = pts.shape[1]
    names = c["parameters"]["POINT"]["LABELS"]["value"][:n]
    copies = -(-points // n)
    labels = [f"{name}_{r}" for r in range(copies) for name in names][:points]
    new = ezc3d.c3d()
    new["parameters"]["POINT"]["RATE"]["value"] = c["parameters"]["POINT"]["RATE"]["value"]
    new["parameters"]["POINT"]["UNITS"]["value"] = c["parameters"]["POINT"]["UNITS"]["value"]
    new["parameters"]["POINT"]["LABELS"]["value"] = labels
    tiled = np.concatenate([pts + np.array([10.0 * r, 0, 0, 0])[:, None, None] for r in range(copies)], axis=1)
    tiled[3] = 1
    new["data"]["points"] = tiled[:, :points, :100]
    # ezc3d states its own blank first 255 descriptions; the points past the 255th get theirs in DESCRIPTIONS2
    new["parameters"]["POINT"]["DESCRIPTIONS2"] = {"type": -1, "description": "", "is_locked": False,
                                                   "value": [f"point {i + 1}" for i in range(255, points)]}
    new.write(str(path))
    return labels


def test_a_c3d_of_300_points_is_written_back_whole(tmp_path, monkeypatch):
    """Before 0.16.0 the writer handed ezc3d one list of 300 POINT:DESCRIPTIONS, which ezc3d stated as 44 (its
    count cut to a byte): ezc3d refused the file written ('The format is not standard'), the ``c3d`` package
    read it with points 256-300 called M256... And the ``c3d`` package's reader (mocapkit's fallback) read no
    LABELS2: a file of 300 points read as 255 labels and 45 made-up names."""
    import ezc3d

    src, out = tmp_path / "m300.c3d", tmp_path / "out.c3d"
    labels = _tiled(src)
    take = read_c3d(src)
    assert list(take.labels) == labels
    write_c3d(take, out)
    back = ezc3d.c3d(str(out))  # raised OSError before
    point = back["parameters"]["POINT"]
    assert point["LABELS"]["value"] + point["LABELS2"]["value"] == labels
    assert point["DESCRIPTIONS2"]["value"] == [f"point {i + 1}" for i in range(255, 300)]
    again = read_c3d(out)
    assert list(again.labels) == labels and np.array_equal(again.positions, take.positions, equal_nan=True)
    for path in (src, out):  # the fallback reader names every point as the file does
        with monkeypatch.context() as m:
            m.setitem(sys.modules, "ezc3d", None)  # `import ezc3d` fails: the fallback reader reads it
            with_package = read_c3d(path)
        assert with_package.reader == "c3d" and list(with_package.labels) == labels
        assert np.array_equal(with_package.positions, take.positions, equal_nan=True)



def test_the_descriptions_of_300_points_are_written_whole(tmp_path):
    """Past 255 points ezc3d states its own blank first 255 POINT:DESCRIPTIONS (a list of 255 is not one per
    point to it); the writer puts the take's over them (c3d_section.keep_parameters), DESCRIPTIONS2 beside."""
    import ezc3d

    src, out = tmp_path / "m300.c3d", tmp_path / "out.c3d"
    _tiled(src)
    take = read_c3d(src)
    said = [f"marker number {i + 1}" for i in range(300)]
    point = take.source.parameters["POINT"]
    point["DESCRIPTIONS"]["value"], point["DESCRIPTIONS2"]["value"] = said[:255], said[255:]
    write_c3d(take, out)
    back = ezc3d.c3d(str(out))
    assert back["parameters"]["POINT"]["DESCRIPTIONS"]["value"] + back["parameters"]["POINT"]["DESCRIPTIONS2"]["value"] == said
    again = read_c3d(out)
    assert again.labels == take.labels and np.array_equal(again.positions, take.positions, equal_nan=True)


def test_a_c3d_of_300_analog_channels_is_written_back_whole(tmp_path):
    """ANALOG:LABELS, DESCRIPTIONS, UNITS, SCALE and OFFSET of 300 channels were handed to ezc3d as one list
    each: a file ezc3d refused to read. Now they go on in LABELS2, UNITS2 ..., every channel's samples, label,
    unit and description kept."""
    import ezc3d

    c = ezc3d.c3d(str(EB015PR))
    src, out = tmp_path / "a300.c3d", tmp_path / "out.c3d"
    n = c["data"]["points"].shape[1]
    new = ezc3d.c3d()
    for key in ("RATE", "UNITS"):
        new["parameters"]["POINT"][key]["value"] = c["parameters"]["POINT"][key]["value"]
    new["parameters"]["POINT"]["LABELS"]["value"] = c["parameters"]["POINT"]["LABELS"]["value"][:n]
    new["data"]["points"] = c["data"]["points"][:, :, :100]
    new["parameters"]["ANALOG"]["RATE"]["value"] = c["parameters"]["ANALOG"]["RATE"]["value"]
    new["parameters"]["ANALOG"]["LABELS"]["value"] = [f"ch{i}" for i in range(300)]
    analogs = c["data"]["analogs"][:, :, :400]
    new["data"]["analogs"] = np.concatenate([analogs + r for r in range(19)], axis=1)[:, :300]
    new.write(str(src))
    take = read_c3d(src)
    analog = take.source.parameters["ANALOG"]
    units, said = ["mV"] * 255 + ["N"] * 45, [f"channel {i}" for i in range(300)]
    analog["UNITS"]["value"], analog["UNITS2"]["value"] = units[:255], units[255:]
    analog["DESCRIPTIONS"]["value"], analog["DESCRIPTIONS2"]["value"] = said[:255], said[255:]
    write_c3d(take, out)
    back = ezc3d.c3d(str(out))  # raised OSError before
    params = back["parameters"]["ANALOG"]
    assert params["LABELS"]["value"] + params["LABELS2"]["value"] == [f"ch{i}" for i in range(300)]
    assert params["UNITS"]["value"] + params["UNITS2"]["value"] == units
    assert params["DESCRIPTIONS"]["value"] + params["DESCRIPTIONS2"]["value"] == said
    assert np.array_equal(back["data"]["analogs"], ezc3d.c3d(str(src))["data"]["analogs"])
    assert np.array_equal(read_c3d(out).positions, take.positions, equal_nan=True)


def _scaled_300(path: Path) -> np.ndarray:
    """A C3D of 300 analog channels (Eb015pr.c3d's 26 points, 100 frames, 2 samples a frame) written by ezc3d,
    channels 256-300 with their own ANALOG:SCALE2 and OFFSET2 (21 of the 45 offsets negative: a SIGNED file), then
    the numbers it stores replaced by known whole numbers. Returns those (300, 200)."""
    import struct

    import ezc3d

    c = ezc3d.c3d(str(EB015PR))
    n, rng = c["data"]["points"].shape[1], np.random.default_rng(0)
    new = ezc3d.c3d()
    for key in ("RATE", "UNITS"):
        new["parameters"]["POINT"][key]["value"] = c["parameters"]["POINT"][key]["value"]
    new["parameters"]["POINT"]["LABELS"]["value"] = c["parameters"]["POINT"]["LABELS"]["value"][:n]
    new["data"]["points"] = c["data"]["points"][:, :, :100]
    new["parameters"]["ANALOG"]["RATE"]["value"] = [2 * float(c["parameters"]["POINT"]["RATE"]["value"][0])]
    new["parameters"]["ANALOG"]["LABELS"]["value"] = [f"ch{i}" for i in range(300)]
    new["data"]["analogs"] = np.zeros((1, 300, 200))
    analog = new["parameters"]["ANALOG"]
    for key, typ, value in (("SCALE2", 4, np.round(rng.uniform(0.001, 0.01, 45), 6)),
                            ("OFFSET2", 2, rng.integers(-100, 100, 45)), ("UNITS2", -1, ["N"] * 45),
                            ("DESCRIPTIONS2", -1, [f"channel {i}" for i in range(255, 300)])):
        analog[key] = {"type": typ, "description": "", "is_locked": False, "value": value}
    new.write(str(path))
    raw = bytearray(path.read_bytes())
    start, per = (struct.unpack_from("<H", raw, 16)[0] - 1) * 512, struct.unpack_from("<H", raw, 4)[0]
    stored = rng.integers(-2000, 2000, size=(300, 200)).astype(np.float64)
    block = np.frombuffer(raw, "<f4", count=100 * (4 * n + per), offset=start).reshape(100, 4 * n + per).copy()
    block[:, 4 * n:] = stored.reshape(300, 100, 2).transpose(1, 2, 0).reshape(100, per)
    raw[start:start + block.nbytes] = block.tobytes()
    path.write_bytes(bytes(raw))
    return stored


def test_channels_past_255_are_read_with_their_scale2_and_offset2_and_written_back_as_stored(tmp_path):
    """Channel 256 on are read with ANALOG:SCALE2 and OFFSET2 as the C3D guide has it, ``(stored - offset) * scale
    * GEN_SCALE``: before, the reader took the scales and offsets from SCALE and OFFSET alone, so the 21 channels
    of negative OFFSET2 kept ezc3d's reading (its magnitude subtracted), twice the offset off; written back they
    held those readings under SCALE2 1 and OFFSET2 0, the file's numbers lost. Now the file's numbers, scales,
    offsets, units, descriptions and labels come back as it stored them."""
    import struct

    import ezc3d

    src, out = tmp_path / "a300.c3d", tmp_path / "out.c3d"
    stored = _scaled_300(src)
    params = ezc3d.c3d(str(src))["parameters"]["ANALOG"]

    def both(key):
        return np.concatenate([np.ravel(params[key]["value"]), np.ravel(params[key + "2"]["value"])])

    scale, offset, gen = both("SCALE"), both("OFFSET").astype(np.int64), float(params["GEN_SCALE"]["value"][0])
    assert (offset[255:] < 0).sum() == 21 and (offset[:255] == 0).all()
    take = read_c3d(src)
    want = ((stored - offset[:, None]) * scale[:, None] * gen).astype(np.float32).astype(np.float64)
    assert np.array_equal(take.source.analogs, want)  # before: 21 channels off
    write_c3d(take, out)
    back = ezc3d.c3d(str(out))["parameters"]["ANALOG"]
    for key in ("SCALE", "OFFSET", "UNITS", "DESCRIPTIONS", "LABELS"):
        assert np.array_equal(np.ravel(back[key + "2"]["value"]), np.ravel(params[key + "2"]["value"])), key
    raw, n = out.read_bytes(), take.num_markers
    start, per = (struct.unpack_from("<H", raw, 16)[0] - 1) * 512, struct.unpack_from("<H", raw, 4)[0]
    block = np.frombuffer(raw, "<f4", count=100 * (4 * n + per), offset=start).reshape(100, 4 * n + per)
    assert np.array_equal(block[:, 4 * n:].reshape(100, 2, 300).transpose(2, 0, 1).reshape(300, 200), stored)
    assert np.array_equal(read_c3d(out).source.analogs, want)


def test_a_parameter_a_c3d_cannot_state_is_refused_not_written_cut(tmp_path):
    """300 events (EVENT:TIMES 2 x 300, LABELS ... of 300) or a description of 300 characters: a C3D states each
    dimension in one byte, and ezc3d wrote them cut to it, a file it refused to read back and the ``c3d``
    package read as 44 events. Now one line names the parameter and nothing is written."""
    import dataclasses

    import pytest

    from mocapkit.errors import MocapFormatError

    take, out = read_c3d(EB015PR), tmp_path / "out.c3d"
    event = {"__METADATA__": {"DESCRIPTION": "", "IS_LOCKED": False},
             "USED": {"type": 2, "description": "", "is_locked": False, "value": np.array([300])},
             "LABELS": {"type": -1, "description": "", "is_locked": False, "value": ["Foot Strike"] * 300},
             "TIMES": {"type": 4, "description": "", "is_locked": False,
                       "value": np.vstack([np.zeros(300), 0.5 + np.arange(300) * 0.01])}}
    with_events = dataclasses.replace(take.source, parameters={**take.source.parameters, "EVENT": event})
    with pytest.raises(MocapFormatError, match=r"EVENT:\w+ holds (300 texts|2 x 300 values), more than the 255"):
        write_c3d(dataclasses.replace(take, source=with_events), out)
    take.source.parameters["POINT"]["DESCRIPTIONS"]["value"][0] = "x" * 300
    with pytest.raises(MocapFormatError, match="POINT:DESCRIPTIONS holds a text of 300 characters"):
        write_c3d(take, out)
    assert list(tmp_path.iterdir()) == []
