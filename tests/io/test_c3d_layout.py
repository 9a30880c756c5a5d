"""A C3D written back keeps the file's own layout where ezc3d would write its own: stored analog numbers and
ANALOG:OFFSET, the header's interpolation gap, where the data block starts."""

import struct

import numpy as np
import pytest

from mocapkit.io.c3d import read_c3d, write_c3d
from mocapkit.io.c3d_layout import parameter_at, put_parameter, stored_analogs


def _find(shared_data, name):
    found = sorted(p for p in shared_data.rglob("*") if p.name == name)
    assert found, name
    return found[0]


def _stored(path):
    """(A, F * ratio) the analog numbers a little-endian C3D stores, as stored (16-bit integers or floats), read
    from its header and ANALOG:USED alone."""
    import ezc3d

    raw = path.read_bytes()
    assert raw[(raw[0] - 1) * 512 + 3] == 84  # Intel files only here
    points, per_frame, first, last = struct.unpack_from("<4H", raw, 2)
    scale, = struct.unpack_from("<f", raw, 12)
    data_start, = struct.unpack_from("<H", raw, 16)
    channels = int(ezc3d.c3d(str(path))["parameters"]["ANALOG"]["USED"]["value"][0])
    frames, dtype = last - first + 1, "<i2" if scale > 0 else "<f4"
    block = np.frombuffer(raw, dtype=dtype, count=frames * (4 * points + per_frame),
                          offset=(data_start - 1) * 512).reshape(frames, -1)
    ratio = per_frame // channels
    return block[:, 4 * points:].reshape(frames, ratio, channels).transpose(2, 0, 1).reshape(channels, -1).astype(np.float64)


@pytest.mark.parametrize("name", ["Eb015pi.c3d", "FunctionalWalk.c3d", "shd01.c3d", "PiG_Motion-FlatFoot-Full.c3d",
                                  "ADemo1_rewrite_c3d_pc_float.c3d"])
def test_analogs_are_written_as_the_numbers_and_offsets_stored(tmp_path, shared_data, name):
    """Eb015pi: 16-bit integers with OFFSET 2048; FunctionalWalk: floats holding A/D counts, UNSIGNED, OFFSET
    -32768 (32768); shd01: UNSIGNED, OFFSET -32752 read as 32784; PiG: floats storing volts; ADemo1's float copy: floats under
    ANALOG:SCALE -0.05, where several floats read as one float32 sample (335 were written one step off before
    0.15.0, as the float32 nearest the sample's reading). Written back, the file stores the same
    numbers (as floats: see the guide) under the same ANALOG:OFFSET, SCALE and GEN_SCALE, and reads the same."""
    import ezc3d

    path = _find(shared_data, name)
    take = read_c3d(path)
    out = tmp_path / "out.c3d"
    write_c3d(take, out)
    before, after = _stored(path), _stored(out)
    assert np.array_equal(after, before) and np.array_equal(np.signbit(after), np.signbit(before))
    src, new = ezc3d.c3d(str(path))["parameters"]["ANALOG"], ezc3d.c3d(str(out))["parameters"]["ANALOG"]
    channels = before.shape[0]
    for key in ("OFFSET", "SCALE", "GEN_SCALE"):
        n = 1 if key == "GEN_SCALE" else channels
        assert np.array_equal(np.ravel(new[key]["value"])[:n], np.ravel(src[key]["value"])[:n]), key
    assert np.array_equal(read_c3d(out).source.analogs, take.source.analogs)


def test_a_part_of_a_float_file_keeps_its_stored_analog_numbers(tmp_path, shared_data):
    """Frames 100-299 of ADemo1's float copy (4 analog samples a frame) written alone store the numbers the file
    stored for those frames, each channel's samples read as before."""
    path = _find(shared_data, "ADemo1_rewrite_c3d_pc_float.c3d")
    part = read_c3d(path)[100:300]
    out = tmp_path / "part.c3d"
    write_c3d(part, out)
    ratio = part.source.analogs.shape[1] // part.num_frames
    assert np.array_equal(_stored(out), _stored(path)[:, 100 * ratio : 300 * ratio])
    assert np.array_equal(read_c3d(out).source.analogs, part.source.analogs)


def test_a_changed_analog_channel_is_written_as_its_values(tmp_path, shared_data):
    """A channel changed in Python is no longer the file's numbers: written as the values (ANALOG:SCALE 1,
    OFFSET 0), read back the same."""
    import dataclasses

    take = read_c3d(_find(shared_data, "Eb015pi.c3d"))
    analogs = take.source.analogs.copy()
    analogs[0] *= 1.0 + 1e-3
    analogs = analogs.astype(np.float32).astype(np.float64)
    take = dataclasses.replace(take, source=dataclasses.replace(take.source, analogs=analogs))
    assert stored_analogs(analogs, take.source.parameters) is None
    out = tmp_path / "out.c3d"
    write_c3d(take, out)
    back = read_c3d(out)
    assert np.array_equal(back.source.analogs, analogs)
    offsets = np.ravel(back.source.parameters["ANALOG"]["OFFSET"]["value"])
    assert not np.any(offsets[:16])  # the 16 channels written; the 16 the file states past them as it had them
    assert np.array_equal(offsets[16:], np.ravel(take.source.parameters["ANALOG"]["OFFSET"]["value"])[16:])


def test_stored_analogs_keep_the_sign_of_zero():
    """A zero read under a negative step is -0.0 from a stored +0 (and +0.0 from a stored -0.0): the numbers found
    read back as the samples, signs of zero included."""
    params = {"POINT": {"SCALE": {"value": np.array([-0.1])}},
              "ANALOG": {"SCALE": {"value": np.array([-0.5, 0.25])}, "GEN_SCALE": {"value": np.array([2.0])},
                         "OFFSET": {"value": np.array([0, 0])}}}
    analogs = np.array([[-0.0, 0.0, 1.0, -3.0], [0.0, -0.0, 0.5, 1.5]])
    stored, scales, offsets, gen = stored_analogs(analogs, params)
    back = (stored - offsets[:, None]) * scales[:, None] * gen
    assert np.array_equal(back, analogs) and np.array_equal(np.signbit(back), np.signbit(analogs))
    assert np.array_equal(stored, [[0.0, -0.0, -1.0, 3.0], [0.0, -0.0, 1.0, 3.0]])


def _header(raw):
    gap, = struct.unpack_from("<H", raw, 10)
    data_start, = struct.unpack_from("<H", raw, 16)
    return gap, data_start


@pytest.mark.parametrize("name", ["85_02.c3d", "Eb015pi.c3d", "TESTBPI.c3d", "FunctionalWalk.c3d"])
def test_header_gap_and_data_start_are_kept(tmp_path, shared_data, name):
    """85_02 (interpolation gap 0, data at block 19), Eb015pi (10, 11), TESTBPI (parameters at block 11, data at
    20), FunctionalWalk (0, 35): ezc3d writes gap 10 and the data right after its own parameter section; both are
    the file's again, POINT:DATA_START agreeing, and every reader reads the take as before."""
    import ezc3d

    path = _find(shared_data, name)
    take = read_c3d(path)
    out = tmp_path / "out.c3d"
    write_c3d(take, out)
    assert _header(out.read_bytes()) == _header(path.read_bytes())
    params = ezc3d.c3d(str(out))["parameters"]
    assert int(params["POINT"]["DATA_START"]["value"][0]) == _header(path.read_bytes())[1]
    back = read_c3d(out)
    assert back.reader == "ezc3d"
    assert np.array_equal(back.positions, take.positions, equal_nan=True)
    assert np.array_equal(back.residuals, take.residuals) and np.array_equal(back.cameras, take.cameras)


def test_data_start_moves_only_where_the_parameters_no_longer_fit(tmp_path, shared_data):
    """561xxa01_anonym.C3D's data starts at block 6; the parameter section ezc3d writes for it ends later, so the
    data follows it, and the header and POINT:DATA_START say where."""
    import ezc3d

    path = _find(shared_data, "561xxa01_anonym.C3D")
    out = tmp_path / "out.c3d"
    write_c3d(read_c3d(path), out)
    raw = out.read_bytes()
    gap, data_start = _header(raw)
    assert gap == _header(path.read_bytes())[0] and data_start > _header(path.read_bytes())[1]
    assert int(ezc3d.c3d(str(out))["parameters"]["POINT"]["DATA_START"]["value"][0]) == data_start


def test_data_start_keeps_its_description(tmp_path):
    """POINT:DATA_START was left out of the parameters ezc3d was given, so ezc3d wrote its own without the file's
    description (Eb015pr's '* First record of video/analog data') and lock; its value is ezc3d's still."""
    import ezc3d

    from mocapkit import samples

    path = samples.path("Eb015pr.c3d")
    out = tmp_path / "out.c3d"
    write_c3d(read_c3d(path), out)
    was, now = (ezc3d.c3d(str(p))["parameters"]["POINT"]["DATA_START"] for p in (path, out))
    assert was["description"] == "* First record of video/analog data"
    assert (now["description"], now["is_locked"]) == (was["description"], was["is_locked"])
    assert int(now["value"][0]) == _header(out.read_bytes())[1] == _header(path.read_bytes())[1]


@pytest.mark.parametrize("name", ["ADemo1_rewrite_c3d_pc_float.c3d", "Qualisys.c3d"])
def test_the_fallback_reader_keeps_the_stored_analog_numbers_as_ezc3d_does(tmp_path, shared_data, monkeypatch, name):
    """Without ezc3d the ``c3d`` package reads the file; it scales the analog samples in float32, and before
    0.15.0 it kept no stored numbers (``MarkerSource.analog_numbers`` None), so a float file written back stored
    some numbers one float32 step off (ADemo1's float copy: 335 of 16,384; Qualisys: 1,377 of 234,600). Now it
    keeps the numbers the ezc3d path keeps, and the file written back stores the numbers the input stored."""
    import sys

    path = _find(shared_data, name)
    with monkeypatch.context() as m:
        m.setitem(sys.modules, "ezc3d", None)  # `import ezc3d` fails: the fallback reader reads it
        take = read_c3d(path)
    assert take.reader == "c3d"
    kept = read_c3d(path).source.analog_numbers
    assert kept is not None and np.array_equal(take.source.analog_numbers, kept)
    out = tmp_path / "out.c3d"
    write_c3d(take, out)
    assert np.array_equal(_stored(out), _stored(path))


def _offset_file(path, fmt, offsets, stored):
    """A float C3D of 4 frames (1 point, analog channels at the frame rate) storing ``stored`` (A, 4) under
    ANALOG:SCALE 1, ANALOG:FORMAT ``fmt`` and ANALOG:OFFSET ``offsets`` (A,), the 16-bit values the file holds."""
    import ezc3d

    a = len(offsets)
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = np.array([100.0])
    c["parameters"]["POINT"]["UNITS"] = {"type": -1, "description": "", "is_locked": False, "value": ["mm"]}
    c["parameters"]["POINT"]["LABELS"]["value"] = ["A"]
    c["parameters"]["ANALOG"]["RATE"]["value"] = np.array([100.0])
    c["parameters"]["ANALOG"]["USED"]["value"] = np.array([a])
    c["parameters"]["ANALOG"]["LABELS"]["value"] = [f"ch{i}" for i in range(a)]
    c["parameters"]["ANALOG"]["FORMAT"]["value"] = [fmt]
    pts = np.ones((4, 1, 4))
    pts[:3] = np.arange(12.0).reshape(3, 1, 4) * 100
    c["data"]["points"] = pts
    c["data"]["meta_points"]["residuals"] = np.zeros((1, 1, 4))
    c["data"]["analogs"] = np.asarray(stored, dtype=np.float64)[None]
    c.write(str(path))
    data = bytearray(path.read_bytes())
    assert put_parameter(data, "ANALOG", "OFFSET", offsets)
    path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize("fmt, offsets, stored, values", [
    # UNSIGNED: offsets unsigned (-32752 is 32784), as the C3D guide, BTK and the c3d package read them
    ("UNSIGNED", [-32752, 100, -32768], [[32800, 32784, 32000, 0], [100, 90, 0, 65535], [32768, 40000, 1, 2]],
     [[16, 0, -784, -32784], [0, -10, -100, 65435], [0, 7232, -32767, -32766]]),
    # SIGNED: signed (-5 is -5), but for -32768, 0x8000, read as 32768 (Analysis.c3d's 0 V)
    ("SIGNED", [-5, -32768, 7], [[-5, 10, 0, -32767], [32768, 32770, 0, 65535], [7, 0, 8, 6]],
     [[0, 15, 5, -32762], [0, 2, -32768, 32767], [0, -7, 1, -1]]),
])
def test_analog_offsets_are_read_as_the_c3d_guide_has_them_by_both_readers(tmp_path, monkeypatch, fmt, offsets,
                                                                           stored, values):
    """ANALOG:OFFSET under ANALOG:FORMAT (c3d_layout.offset_values): the value read is ``stored - offset``, the
    same by ezc3d's path (which subtracted each offset's magnitude: 48 for 16 above, -10 for 0) and by the
    ``c3d`` package's (65,536 for Analysis.c3d's 0), and a take written back keeps the file's OFFSET bytes."""
    import sys

    path = _offset_file(tmp_path / "offsets.c3d", fmt, offsets, stored)
    take = read_c3d(path)
    assert take.reader == "ezc3d"
    assert np.array_equal(take.source.analogs, np.asarray(values, dtype=np.float64))
    out = tmp_path / "out.c3d"
    write_c3d(take, out)
    assert np.array_equal(read_c3d(out).source.analogs, take.source.analogs)
    at, typ, count = parameter_at(bytearray(out.read_bytes()), "ANALOG", "OFFSET")
    assert typ == 2 and np.frombuffer(out.read_bytes(), "<i2", count=count, offset=at).tolist()[:3] == offsets
    monkeypatch.setitem(sys.modules, "ezc3d", None)  # the fallback reader
    fallback = read_c3d(path)
    assert fallback.reader == "c3d"
    assert np.array_equal(fallback.source.analogs, take.source.analogs)


def test_both_readers_read_analysis_and_shd01_analogs_alike(shared_data, monkeypatch):
    """BTK's Analysis.c3d (SIGNED, OFFSET -32768, every sample 32768) reads 0 V by either reader, and shd01.c3d
    (UNSIGNED, OFFSET -32752, -32701, -32704 on Fx, Fz, Mx) the same by both: Fz 23.5 (its units) below ezc3d's reading."""
    import sys

    import ezc3d

    analysis, shd01 = _find(shared_data, "Analysis.c3d"), _find(shared_data, "shd01.c3d")
    first = [read_c3d(analysis).source.analogs, read_c3d(shd01).source.analogs]
    assert np.array_equal(first[0], np.zeros_like(first[0]))
    c = ezc3d.c3d(str(shd01))
    fz = c["data"]["analogs"][0, 2] - (32835 - 32701) * c["parameters"]["ANALOG"]["SCALE"]["value"][2]
    assert np.allclose(first[1][2], fz, rtol=1e-6) and np.allclose(first[1][1], c["data"]["analogs"][0, 1], rtol=1e-6)
    monkeypatch.setitem(sys.modules, "ezc3d", None)
    for path, values in zip((analysis, shd01), first):
        fallback = read_c3d(path)
        assert fallback.reader == "c3d" and np.array_equal(fallback.source.analogs, values), path.name


def _event_section(raw: bytes) -> bytes:
    """The header's event section, words 150-234 (bytes 298-467): key, count, times, flags, labels."""
    return raw[298:468]


def test_the_header_event_slots_no_event_uses_are_kept(tmp_path, shared_data):
    """FP1.C3D lists 4 events and flags its 14 unused slots 1 with labels of spaces; Eb015pr.c3d sets word 152:
    ezc3d wrote zeros there. The whole event section is the file's again, every reader reading the same events,
    and a part of the take that leaves an event out leaves its slot empty (never the old event's bytes)."""
    from mocapkit import samples

    for path in (samples.path("Eb015pr.c3d"), _find(shared_data, "FP1.C3D")):
        take = read_c3d(path)
        out = tmp_path / f"{path.stem}.c3d"
        write_c3d(take, out)
        assert _event_section(out.read_bytes()) == _event_section(path.read_bytes()), path.name
        assert read_c3d(out).source.events == take.source.events
    fp1 = path.read_bytes()
    part = take[2:]  # from 1/30 s on: the two events at 0 s are left out, L. I (1/30 s) and L. E (8 s) kept
    write_c3d(part, tmp_path / "part.c3d")
    raw = (tmp_path / "part.c3d").read_bytes()
    kept = read_c3d(tmp_path / "part.c3d").source.events
    assert [label for _, label, _ in kept] == ["L. E", "L. I"]
    n = len(take.source.events)
    assert raw[376 + len(kept):376 + n] == bytes(n - len(kept)) and raw[396 + 4 * len(kept):396 + 4 * n] == bytes(4 * (n - len(kept)))
    # the slots the file itself left unused (flags, times, labels): as the file had them
    assert raw[376 + n:394] == fp1[376 + n:394] and raw[396 + 4 * n:468] == fp1[396 + 4 * n:468]
    assert raw[304 + 4 * n:376] == fp1[304 + 4 * n:376]
