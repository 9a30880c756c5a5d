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


def _plates_without_analogs(path) -> Path:
    """A C3D (written by ezc3d) of 3 markers, 20 frames at 100 Hz and one force plate stated on channels 1-6,
    with no analog channel."""
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [100.0]
    c["parameters"]["POINT"]["LABELS"]["value"] = ["A", "B", "C"]
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    pts = np.ones((4, 3, 20))
    pts[:3] = np.arange(3 * 3 * 20, dtype=float).reshape(3, 3, 20) * 10.0 + 100.0
    c["data"]["points"] = pts
    param = lambda typ, value: {"type": typ, "description": "", "is_locked": False, "value": value}  # noqa: E731
    c["parameters"]["FORCE_PLATFORM"] = {
        "__METADATA__": {"DESCRIPTION": "", "IS_LOCKED": False}, "USED": param(2, np.array([1])),
        "TYPE": param(2, np.array([2])), "CHANNEL": param(2, np.arange(1, 7).reshape(6, 1)),
        "ORIGIN": param(4, np.array([[0.0], [0.0], [-40.0]]))}
    c.write(str(path))
    return path


def test_a_file_of_plates_without_analog_channels_keeps_them_written_back(tmp_path):
    import ezc3d

    take = load_markers(_plates_without_analogs(tmp_path / "plates.c3d"))
    assert take.source.analogs is None
    back = ezc3d.c3d(str(save_markers(take, tmp_path / "back.c3d")))["parameters"]["FORCE_PLATFORM"]
    assert int(back["USED"]["value"][0]) == 1  # before: 0, every per-plate parameter dropped
    assert np.array_equal(np.ravel(back["CHANNEL"]["value"]), np.arange(1, 7))
    # a file with analog channels resampled (its channels not written) still leaves its plates out
    eb = load_markers(EB015PR)
    half = ezc3d.c3d(str(save_markers(eb[::2], tmp_path / "half.c3d")))["parameters"]["FORCE_PLATFORM"]
    assert int(half["USED"]["value"][0]) == 0


def _header_events(path) -> list[str]:
    """The labels of the header events of the C3D at ``path`` as ezc3d reads them, and its first frame (1-based)."""
    import ezc3d

    header = ezc3d.c3d(str(path))["header"]
    return [label.strip() for label in header["events"]["events_label"] if label.strip()], \
        header["points"]["first_frame"] + 1


def test_a_resampled_take_keeps_the_events_within_its_time_span(tmp_path):
    take = load_markers(EB015PR)  # 450 frames at 50 Hz; header events RIC 2.72 s, RHS 5.40 s, RTO 7.32 s
    # frames 151-399 every other one: 3.0 to 7.96 s at 25 Hz. The file's frame 151 read at 25 Hz put it at
    # 6.0 s and kept RTO alone; its first frame is written at 25 Hz (76: 3.0 s)
    assert _header_events(save_markers(take[150:400:2], tmp_path / "mid.c3d")) == (["RHS", "RTO"], 76)
    # from 2.0 s to the file's end at 16.7 Hz keeps all three (before: RTO alone, from 6.0 s)
    assert _header_events(save_markers(take[100::3], tmp_path / "end.c3d"))[0] == ["RIC", "RHS", "RTO"]
    # 0 to 5.96 s: RIC and RHS; the take at the file's rate is unchanged (a crop keeps its frame numbers)
    assert _header_events(save_markers(take[0:300:2], tmp_path / "start.c3d")) == (["RIC", "RHS"], 1)
    assert _header_events(save_markers(take[150:400], tmp_path / "crop.c3d")) == (["RHS", "RTO"], 151)


def test_a_resampled_take_written_like_its_own_file_keeps_its_events(tmp_path):
    """`save_markers(take[150:400:2], out, like=file)` kept none of the file's events: a take at another rate was
    taken for another trial. Its samples are the file's at the frames it came from: it is the file's trial, and keeps
    what it keeps written without like= (the same bytes); a take of other frames, or other samples, keeps none."""
    import dataclasses

    import ezc3d

    take = load_markers(EB015PR)
    for name, part in (("mid", take[150:400:2]), ("end", take[100::3]), ("half", take[::2])):
        alone = save_markers(part, tmp_path / f"{name}.c3d")
        like = save_markers(part, tmp_path / f"{name}_like.c3d", like=EB015PR)
        assert like.read_bytes() == alone.read_bytes(), name
    assert _header_events(tmp_path / "mid_like.c3d") == (["RHS", "RTO"], 76)  # before: ([], 76)
    assert _header_events(tmp_path / "end_like.c3d")[0] == ["RIC", "RHS", "RTO"]
    assert ezc3d.c3d(str(tmp_path / "half_like.c3d"))["data"]["points"].shape[2] == 225  # ezc3d reads it back
    part = take[150:400:2]
    shifted = dataclasses.replace(part, source=dataclasses.replace(part.source, first_frame=153))  # frames 153, 155...
    moved = dataclasses.replace(part, positions=part.positions + 5.0)  # 5 mm off the file's samples
    for name, other in (("shifted", shifted), ("moved", moved)):
        assert _header_events(save_markers(other, tmp_path / f"{name}.c3d", like=EB015PR))[0] == [], name


def _parameter_changes(before, after) -> list[str]:
    """What differs between two C3D files' parameter sections as ezc3d reads them: ``GROUP:NAME field`` for each
    parameter whose type, description, lock or values differ, ``+GROUP``/``-GROUP`` for a group added or lost,
    ``GROUP`` for a group's description or lock, ``+GROUP:NAME``/``-GROUP:NAME`` for a parameter."""
    import ezc3d

    a, b = ezc3d.c3d(str(before))["parameters"], ezc3d.c3d(str(after))["parameters"]
    out = [f"+{g}" for g in b if g not in a] + [f"-{g}" for g in a if g not in b]
    for g in (g for g in a if g in b):
        out += [g] if a[g]["__METADATA__"] != b[g]["__METADATA__"] else []
        out += [f"+{g}:{k}" for k in b[g] if k not in a[g]] + [f"-{g}:{k}" for k in a[g] if k not in b[g]]
        for k in (k for k in a[g] if k in b[g] and k != "__METADATA__"):
            x, y = a[g][k], b[g][k]
            out += [f"{g}:{k} {f}" for f in ("type", "description", "is_locked") if x[f] != y[f]]
            same = np.shape(x["value"]) == np.shape(y["value"]) and np.array_equal(np.asarray(x["value"]),
                                                                                   np.asarray(y["value"]))
            out += [] if same else [f"{g}:{k} value"]
    return sorted(out)


def test_a_changed_take_keeps_every_parameter_as_read(tmp_path):
    """trialT3 4: with a sample changed, Eb015pr.c3d came back with POINT:LABELS 48 -> 26 (the session's 12
    spare names), ANALOG:LABELS, DESCRIPTIONS, SCALE, OFFSET and UNITS 32 -> 16, POINT:DESCRIPTIONS 20 -> 26
    and ezc3d's own ROTATION and EZC3D groups added. Every parameter comes back as read, the data too."""
    take = load_markers(EB015PR)
    pos = np.array(take.positions)
    seen = np.flatnonzero(~take.missing()[:, 0])[:3]
    pos[seen, 0] += 1.0
    out = save_markers(take.with_positions(pos), tmp_path / "eb.c3d")
    assert _parameter_changes(EB015PR, out) == []
    back = load_markers(out)
    assert np.array_equal(back.source.analogs, take.source.analogs) and back.source.events == take.source.events
    assert np.array_equal(np.delete(back.positions, 0, 1), np.delete(take.positions, 0, 1), equal_nan=True)
    kept = np.ones(take.residuals.shape, bool)
    kept[seen, 0] = False
    assert np.array_equal(back.residuals[kept], take.residuals[kept])
    assert np.array_equal(back.cameras[kept], take.cameras[kept])
    assert back.residuals[seen, 0].tolist() == [0.0] * 3 and back.cameras[seen, 0].tolist() == [0] * 3
    # the c3d package, which other tools of a lab use, reads the file and its spare labels
    import c3d

    with open(out, "rb") as fh:
        labels = [s.strip() for s in c3d.Reader(fh).get("POINT:LABELS").string_array]
    assert len(labels) == 48 and labels[26:30] == ["TR2", "TR3", "RA", "LA"]


def test_a_choice_of_markers_keeps_the_label_slots_the_file_has_past_its_points(tmp_path):
    """Eb015pr.c3d lists 48 point labels for its 26 points (the session's spare names TR2, TR3, RA ... and 10
    blank slots). A part of its frames kept them; a choice of its markers (``select``: some, or all in another
    order) was written with its own labels only, 48 -> 25. Now the slots past the file's points follow the
    markers written, as ezc3d, the ``c3d`` package and read_c3d read them."""
    import c3d
    import ezc3d

    take = load_markers(EB015PR)
    stated = [s.strip() for s in ezc3d.c3d(str(EB015PR))["parameters"]["POINT"]["LABELS"]["value"]]
    assert len(stated) == 48 and stated[26:30] == ["TR2", "TR3", "RA", "LA"]
    for chosen in (["LFT1", "RSK2", "PV1"], list(reversed(take.labels))):
        out = save_markers(take.select(chosen), tmp_path / f"{len(chosen)}.c3d")
        point = ezc3d.c3d(str(out))["parameters"]["POINT"]
        assert point["USED"]["value"][0] == len(chosen)
        assert [s.strip() for s in point["LABELS"]["value"]] == chosen + stated[26:]  # before: chosen alone
        with open(out, "rb") as fh:
            assert [s.strip() for s in c3d.Reader(fh).get("POINT:LABELS").string_array] == chosen + stated[26:]
        back = load_markers(out)
        assert list(back.labels) == chosen
        assert np.array_equal(back.positions, take.select(chosen).positions, equal_nan=True)


def test_a_part_of_a_qualisys_take_keeps_every_parameter_but_its_length(shared_data, tmp_path):
    """trialT3 4: 03_rolling.c3d's ANALOG:DESCRIPTIONS, SCALE and UNITS lost their descriptions ('Analog
    Descriptions' ...) when written; a part of it differs from the file only in the frames it states."""
    path = shared_data / "c3d_markers_recovery" / "03_rolling.c3d"
    out = save_markers(load_markers(path)[:50], tmp_path / "part.c3d")
    assert _parameter_changes(path, out) == ["POINT:FRAMES value", "POINT:LONG_FRAMES value"]


def test_spare_entries_that_outgrow_ezc3ds_section_move_the_data_block_and_read_back(tmp_path):
    """The section keep_parameters writes is longer than ezc3d's where the file states more past USED than fits
    the room before the data block (here 229 spare labels of 40 characters, 9 KB): the data block moves on by
    whole blocks, and ezc3d, the c3d package and read_c3d all read the labels and the same data."""
    import dataclasses

    import c3d
    import ezc3d

    take = load_markers(EB015PR)
    params = {g: dict(p) for g, p in take.source.parameters.items()}
    spare = [f"SPARE{i:03d}".ljust(40, "x") for i in range(229)]
    params["POINT"]["LABELS"] = dict(params["POINT"]["LABELS"], value=list(take.labels) + spare)
    take = dataclasses.replace(take, source=dataclasses.replace(take.source, parameters=params))
    pos = np.array(take.positions)
    pos[5, 1] += 1.0
    out = save_markers(take.with_positions(pos), tmp_path / "spare.c3d")
    raw = out.read_bytes()
    data_start = struct.unpack_from("<H", raw, 16)[0]
    assert data_start > 11  # Eb015pr.c3d's block: the section outgrew it
    read = ezc3d.c3d(str(out))
    assert read["parameters"]["POINT"]["LABELS"]["value"] == list(take.labels) + spare
    assert read["parameters"]["POINT"]["DATA_START"]["value"][0] == data_start
    with open(out, "rb") as fh:
        assert len(c3d.Reader(fh).get("POINT:LABELS").string_array) == 255
    back = load_markers(out)
    assert np.array_equal(back.positions, pos, equal_nan=True) and np.array_equal(back.source.analogs,
                                                                                  take.source.analogs)


def test_texts_come_back_as_the_bytes_the_file_held():
    """A parameter text is written as ezc3d reads it back: UTF-8 (ezc3d's own writing), and a byte of another
    encoding (a Latin-1 file's 0xE9, read by ezc3d as '\\udce9') as that byte, not as a replacement."""
    from mocapkit.io.c3d_section import parameter_record

    body = parameter_record({"type": -1, "description": "caf\u00e9", "value": ["Ren\udce9", "Ren\u00e9"]})
    assert body == b"\xff\x02\x05\x02" + b"Ren\xe9 Ren\xc3\xa9" + b"\x05caf\xc3\xa9"


def test_a_latin_1_text_is_written_back_as_its_byte(tmp_path):
    """ezc3d reads a text byte that is no UTF-8 (a Latin-1 file's 'René': 0xE9) as '\\udce9' and refuses to write
    it back ('could not be converted to string'): such a take could not be written at all. Now it is, the byte
    as the file held it."""
    import dataclasses

    import ezc3d

    take = load_markers(EB015PR)
    params = {g: dict(p) for g, p in take.source.parameters.items()}
    params["SUBJECT"] = dict(params["SUBJECT"], NAME=dict(params["SUBJECT"]["NAME"], value=["Ren\udce9"]))
    take = dataclasses.replace(take, source=dataclasses.replace(take.source, parameters=params))
    out = save_markers(take, tmp_path / "latin.c3d")
    assert b"\x04Ren\xe9" in out.read_bytes()  # its length, then its 4 bytes
    assert ezc3d.c3d(str(out))["parameters"]["SUBJECT"]["NAME"]["value"] == ["Ren\udce9"]


CMU_85_02 = Path(__file__).resolve().parents[1] / "data" / "85_02.c3d"


def _numbers_equal(a: dict, b: dict) -> bool:
    """Whether two parameters in ezc3d's layout state the same type and values."""
    if a["type"] != b["type"]:
        return False
    if a["type"] == -1:
        return list(a["value"]) == list(b["value"])
    return np.array_equal(np.asarray(a["value"]), np.asarray(b["value"]))


def test_a_take_read_by_the_fallback_reader_is_written_with_every_parameter(tmp_path):
    """The ``c3d`` package (the reader of the files ezc3d cannot read) reads the parameter section's stated blocks
    only: a file whose records run on past them (c3d.org's Dance.c3d and golfswing.c3d) was written back without
    the groups there. CMU 85_02.c3d edited by two bytes' worth: its section stating 14 of its 17 blocks (TIMECODE,
    EVENT_CONTEXT and EVENT run past them) and its data block one whole frame short of the 810 stated, which sends
    it to the fallback reader. Its 12 EVENT_CONTEXT and EVENT parameters were lost; now every parameter is written
    as the unedited file states it, but the frame counts, which say the 809 frames written."""
    raw = bytearray(CMU_85_02.read_bytes())
    start = (raw[0] - 1) * 512
    assert raw[start + 2] == 17
    raw[start + 2] = 14
    path = tmp_path / "85_02_edited.c3d"
    path.write_bytes(bytes(raw[:(19 - 1) * 512 + 809 * 41 * 4 * 4]))  # data at block 19, 41 float points a frame
    take = load_markers(path)
    assert take.reader == "c3d" and take.num_frames == 809
    save_markers(take, tmp_path / "out.c3d")
    want = load_markers(CMU_85_02).source.parameters
    got = load_markers(tmp_path / "out.c3d").source.parameters
    lost = [f"{g}:{k}" for g, params in want.items() for k in params if k not in got.get(g, {})]
    assert lost == [], lost
    differ = sorted(f"{g}:{k}" for g, params in want.items() for k, p in params.items()
                    if k != "__METADATA__" and not _numbers_equal(p, got[g][k]))
    assert differ == ["POINT:FRAMES", "TRIAL:ACTUAL_END_FIELD"], differ
    assert got["EVENT"]["LABELS"]["value"] == want["EVENT"]["LABELS"]["value"]


def test_the_parameter_section_is_read_as_ezc3d_reads_it():
    """read_parameters (the fallback reader's parameters) gives every parameter of 85_02.c3d as ezc3d does."""
    import ezc3d

    from mocapkit.io.c3d_parameters import read_parameters

    mine = read_parameters(CMU_85_02.read_bytes())
    theirs = ezc3d.c3d(str(CMU_85_02))["parameters"]
    assert set(mine) == {"TRIAL", "SUBJECTS", "POINT", "TIMECODE", "EVENT_CONTEXT", "EVENT"}  # the file's groups
    for group in mine:  # ezc3d adds groups of its own (ROTATION, EZC3D, an empty ANALOG): not the file's
        for name, param in theirs[group].items():
            if name == "__METADATA__":
                continue
            got = mine[group][name]
            assert got["type"] == param["type"] and got["description"] == param["description"], (group, name)
            value = param["value"]
            assert (list(got["value"]) == list(value) if param["type"] == -1
                    else np.array_equal(got["value"], np.atleast_1d(value))), (group, name)
        assert set(mine[group]) - {"__METADATA__"} == set(theirs[group]) - {"__METADATA__"}, group


def test_the_phoenix_dance_take_keeps_its_analog_parameters(shared_data, tmp_path):
    """c3d.org's Dance.c3d (PhoeniX): ezc3d refuses it, the package read its POINT group only; written back, its
    ANALOG group was ezc3d's defaults and ANALOG:GAIN was dropped. Now its nine ANALOG parameters are the file's
    (OFFSET written as the C3D guide's integers, the PhoeniX file's floats 0.0 as 0)."""
    from mocapkit.io.c3d_parameters import read_parameters

    src = shared_data / "c3d_markers" / "Dance.c3d"
    take = load_markers(src)
    assert take.reader == "c3d"
    save_markers(take, tmp_path / "out.c3d")
    want = read_parameters(src.read_bytes())["ANALOG"]
    got = read_parameters((tmp_path / "out.c3d").read_bytes())["ANALOG"]
    assert set(want) <= set(got)
    assert all(np.array_equal(np.asarray(want[k]["value"], dtype=object if want[k]["type"] == -1 else float),
                              np.asarray(got[k]["value"], dtype=object if want[k]["type"] == -1 else float))
               for k in want if k != "__METADATA__"), [k for k in want if k != "__METADATA__"]
    assert list(got["GAIN"]["value"]) == [1.0] * 8
