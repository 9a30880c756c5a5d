from pathlib import Path

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
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]  # stated: a few markers 100 mm apart fit no unit by their span
    t = np.arange(n_frames)
    pts = np.ones((4, n_markers, n_frames))
    pts[:3] = (np.arange(n_markers)[None, :, None] * 100.0 + t[None, None, :]) * np.array([1.0, 2.0, 3.0])[:, None, None]
    c["data"]["points"] = pts
    c.write(str(path))
    return path


def test_a_point_rate_outside_1_to_10000_fps_is_refused(tmp_path):
    assert read_c3d(write_c3d(tmp_path / "ok.c3d", rate=1000.0)).fps == 1000.0
    assert read_c3d(write_c3d(tmp_path / "fast.c3d", rate=2000.0)).fps == 2000.0  # a high-speed capture
    for rate in (0.01, 20000.0):
        bad = write_c3d(tmp_path / f"rate_{rate:g}.c3d", rate=rate)
        with pytest.raises(MocapFormatError) as exc:
            read_c3d(bad)
        msg = str(exc.value)
        assert msg.startswith(f"{bad}: point frame rate must be a positive number from 1 to 10000 "), msg
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


# --- writing, round trips, reader fixes on the peer files, zeros as gaps ------------------------------


def _params(markers):
    return markers.source.parameters


def test_round_trip_keeps_points_residuals_labels_rate_units_and_analogs(tmp_path):
    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    out = save_markers(src, tmp_path / "copy.c3d")
    back = load_markers(out)
    assert back.labels == src.labels and back.fps == src.fps and back.units == src.units
    assert np.array_equal(back.missing(), src.missing())
    # float C3D: coordinates exact at float32
    assert np.array_equal(back.positions, src.positions.astype(np.float32).astype(np.float64), equal_nan=True)
    seen = ~src.missing()
    assert np.array_equal(back.residuals[seen], src.residuals[seen]) and np.all(back.residuals[~seen] == -1)
    # the 16 analog channels at 4 samples per frame, values and labels kept
    assert back.source.analogs.shape == (16, 1800)
    assert np.array_equal(back.source.analogs, src.source.analogs.astype(np.float32).astype(np.float64))
    # the 16 channels' labels, then the 16 the file states past ANALOG:USED (trialT3 4: cut to 16)
    assert list(_params(back)["ANALOG"]["LABELS"]["value"]) == list(_params(src)["ANALOG"]["LABELS"]["value"])
    # every parameter group of the input is still there, with POINT:USED and POINT:FRAMES consistent
    assert set(_params(src)) <= set(_params(back))
    for group in set(_params(src)) - {"POINT", "ANALOG"}:
        for name, p in _params(src)[group].items():
            if name != "__METADATA__":
                assert np.array_equal(np.ravel(p["value"]), np.ravel(_params(back)[group][name]["value"])), (group, name)
    assert int(_params(back)["POINT"]["USED"]["value"][0]) == 26
    assert int(_params(back)["POINT"]["FRAMES"]["value"][0]) == 450


def test_written_back_every_parameter_keeps_its_description_and_lock(tmp_path):
    """Eb015pr.c3d's ANALOG:LABELS, DESCRIPTIONS and UNITS say what they are ("  Analog labels"); the writer
    rebuilds their values (one per channel written) and wrote them with empty descriptions."""
    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    back = load_markers(save_markers(src, tmp_path / "copy.c3d"))
    assert _params(src)["ANALOG"]["LABELS"]["description"] == "  Analog labels"
    for name in ("LABELS", "DESCRIPTIONS", "UNITS"):
        for key in ("description", "is_locked"):
            assert _params(back)["ANALOG"][name][key] == _params(src)["ANALOG"][name][key], (name, key)


def test_a_cleaned_take_written_back_changes_only_its_points(tmp_path):
    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    filled = np.where(np.isnan(src.positions), 1.0, src.positions)
    cleaned = src.with_positions(filled)
    back = load_markers(save_markers(cleaned, tmp_path / "clean.c3d"))
    assert not back.missing().any()
    assert np.all(back.positions[src.missing()] == 1.0)
    # filled samples get residual 0 (C3D: interpolated); the others keep theirs
    assert np.all(back.residuals[src.missing()] == 0.0)
    assert np.array_equal(back.residuals[~src.missing()], src.residuals[~src.missing()])
    assert back.source.analogs.shape == src.source.analogs.shape


def test_every_shared_c3d_round_trips_at_float32(shared_data, tmp_path):
    from mocapkit.io import load_markers, save_markers

    files = sorted((shared_data / "c3d_markers").glob("*.c3d")) + sorted((shared_data / "c3d_markers_recovery").glob("*.c3d"))
    for f in files:
        src = load_markers(f)
        back = load_markers(save_markers(src, tmp_path / f.name))
        assert back.reader == "ezc3d", f.name  # what ezc3d writes, ezc3d reads back
        assert back.labels == src.labels and back.fps == pytest.approx(src.fps) and back.num_frames == src.num_frames, f.name
        assert np.array_equal(back.positions, src.positions.astype(np.float32).astype(np.float64), equal_nan=True), f.name
        assert back.source.first_frame == src.source.first_frame, f.name
        if src.source.analogs is not None:
            assert np.array_equal(back.source.analogs, src.source.analogs.astype(np.float32)), f.name


def test_the_c3d_package_reads_what_the_writer_writes(tmp_path):
    import c3d

    src = mocapkit.load(mocapkit.samples.path("Eb015pr.c3d"))
    out = tmp_path / "w.c3d"
    from mocapkit.io.c3d import write_c3d

    write_c3d(src, out)
    with open(out, "rb") as fh:
        reader = c3d.Reader(fh)
        frames = np.array([p for _, p, _ in reader.read_frames()])
    assert frames.shape == (450, 26, 5)
    invalid = frames[..., 3] < 0
    assert np.array_equal(invalid, src.missing())
    assert np.all(frames[..., :3][invalid] == 0.0)  # ezc3d stores invalid points as 0 with residual -1
    assert np.allclose(frames[..., :3][~invalid], src.positions[~invalid], atol=1e-3)


def test_a_file_ezc3d_writes_with_a_point_scale_is_read(tmp_path):
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = np.array([100.0])
    c["parameters"]["POINT"]["LABELS"]["value"] = ("A", "B")
    c["parameters"]["POINT"]["SCALE"]["value"] = np.array([-0.1])  # header scale -1, POINT:SCALE -0.1
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    pts = np.ones((4, 2, 10))
    pts[:3] = np.arange(60).reshape(3, 2, 10) * 10.0
    c["data"]["points"] = pts
    c.write(str(tmp_path / "s.c3d"))
    ms = read_c3d(tmp_path / "s.c3d")
    assert ms.reader == "ezc3d" and ms.num_frames == 10
    assert np.array_equal(ms.positions, np.transpose(pts[:3], (2, 1, 0)))


def test_units_as_files_state_them(shared_data):
    from mocapkit.markerset import length_unit_cm

    fp1 = read_c3d(shared_data / "peer_files/BTKData/Input/C3DSamples/c3d.org/sample15/FP1.C3D")
    assert fp1.units == "mete" and fp1.unit_cm == 100.0
    assert length_unit_cm(" MM ") == 0.1 and length_unit_cm("inches") == 2.54
    with pytest.raises(ValueError, match="furlong"):
        length_unit_cm("furlong")


def test_an_unknown_unit_is_refused_at_read_time(tmp_path):
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = np.array([100.0])
    c["parameters"]["POINT"]["LABELS"]["value"] = ("A",)
    c["parameters"]["POINT"]["UNITS"]["value"] = ("px",)
    c["data"]["points"] = np.ones((4, 1, 5))
    c.write(str(tmp_path / "px.c3d"))
    msg = refusal_of_load(tmp_path / "px.c3d")
    assert msg.startswith(f"{tmp_path / 'px.c3d'}: unknown length unit 'px'") and "\n" not in msg


PEER = "peer_files"


def _peer(shared_data, rel):
    path = shared_data / PEER / rel
    if not path.is_file():
        pytest.skip(f"{rel} not present")
    return path


@pytest.mark.parametrize("rel, frames, points", [
    ("BTKData/Input/C3DSamples/PiG/PiG_Calibration-FlatFoot-Full.c3d", 94, 137),  # BODYMASS defined twice
    ("BTKData/Input/C3DSamples/PiG/PiG_Calibration-FlatFoot-Hole.c3d", 300, 203),
    ("BTKData/Input/C3DSamples/PiG/PiG_Calibration-FlatFoot-One.c3d", 1, 138),
    ("BTKData/Input/C3DSamples/PiG/PiG_Motion-FlatFoot-One.c3d", 255, 193),
    ("BTKData/Input/C3DSamples/c3d.org/sample10/TYPE-2.C3D", 199, 13),  # parameters of an undefined group
    ("BTKData/Input/C3DSamples/c3d.org/sample10/TYPE-4.C3D", 199, 13),
    ("BTKData/Input/C3DSamples/c3d.org/sample02/sgi_int.c3d", 89, 36),  # big-endian, 11-block section
    ("BTKData/Input/C3DSamples/c3d.org/sample02/sgi_real.c3d", 89, 36),
    ("pyomeca+ezc3d-testFiles/Optotrak.c3d", 29, 54),  # whole frames, fewer than stated: the frames that are there
    ("BTKData/Input/C3DSamples/c3d.org/sample28/type1.C3D", 296, 28),
    ("BTKData/Input/C3DSamples/c3d.org/sample15/FP1.C3D", 480, 8),
])
def test_files_a_peer_reads_are_read_as_the_peer_reads_them(shared_data, rel, frames, points):
    ms = read_c3d(_peer(shared_data, rel))
    assert (ms.num_frames, ms.num_markers) == (frames, points)
    step = np.linalg.norm(np.diff(ms.positions, axis=0), axis=-1) * ms.unit_cm
    if frames > 1:
        assert np.nanmedian(step) < 5.0  # smooth trajectories (type1 was read a metre per frame apart)


def test_the_sgi_files_hold_the_same_data_as_the_pc_ones(shared_data):
    pc = read_c3d(_peer(shared_data, "BTKData/Input/C3DSamples/c3d.org/sample02/pc_real.c3d"))
    for name in ("sgi_real.c3d", "sgi_int.c3d"):
        sgi = read_c3d(_peer(shared_data, f"BTKData/Input/C3DSamples/c3d.org/sample02/{name}"))
        assert sgi.labels == pc.labels
        assert np.allclose(sgi.positions, pc.positions, atol=0.5, equal_nan=True)


def test_type1_matches_its_sibling_dynamic(shared_data):
    # sample28's type1.C3D and dynamic.C3D are the same trial; type1 holds a subset of the markers
    t1 = read_c3d(_peer(shared_data, "BTKData/Input/C3DSamples/c3d.org/sample28/type1.C3D"))
    dyn = read_c3d(_peer(shared_data, "BTKData/Input/C3DSamples/c3d.org/sample28/dynamic.C3D"))
    # the same markers, named "RASI" in one and "r asis" in the other
    names = {label.replace(" ", "").lower(): label for label in dyn.labels}
    common = [label for label in t1.labels if label.lower() in names]
    assert len(common) >= 8
    a, b = t1.select(common).positions, dyn.select([names[label.lower()] for label in common]).positions
    both = ~np.isnan(a) & ~np.isnan(b)
    assert np.max(np.abs(a[both] - b[both])) < 1.0


@pytest.mark.parametrize("rel, reason", [
    ("pyomeca+ezc3d-testFiles/C3DRotationExample.c3d", "C3D file holds no 3D points (340 frames, 0 analog channels, rotations only)"),
    ("pyomeca+ezc3d-testFiles/Kistler.c3d", "C3D file holds no 3D points (3969 frames, 16 analog channels)"),
    ("BTKData/Input/C3DSamples/others/Empty.c3d", "not a C3D file: 0 bytes, shorter than the 512-byte header"),
    ("BTKData/Input/C3DSamples/c3d.org/sample06/MACsample.c3d",
     "the header's point scale 0.0551136 disagrees with POINT:SCALE 0.0215412, so the integer coordinates "
     "cannot be scaled with confidence; re-export the file from the capture software"),
])
def test_files_without_points_are_refused_with_a_reason(shared_data, rel, reason):
    # (the c3d package said "only 0-dimensional arrays can be converted to Python scalars" for the first)
    path = _peer(shared_data, rel)
    assert refusal_of_load(path) == f"{path}: {reason}"


def test_zeros_stored_as_gaps_are_read_as_missing(shared_data):
    path = shared_data / "c3d_markers_recovery" / "03_rolling.c3d"
    auto = read_c3d(path)
    kept = read_c3d(path, zeros_as_gaps=False)
    forced = read_c3d(path, zeros_as_gaps=True)
    zeros = np.all(kept.positions == 0.0, axis=-1)
    assert zeros.mean() == pytest.approx(0.2295, abs=1e-4)  # the README: 23 % of the samples
    assert auto.zero_gaps == int(zeros.sum()) == forced.zero_gaps and kept.zero_gaps == 0
    assert np.array_equal(auto.missing(), zeros) and not kept.missing().any()
    assert np.all(auto.residuals[zeros] == -1)
    # the gaps were jumps to the origin: after them the trajectories are smooth
    step = np.linalg.norm(np.diff(auto.positions, axis=0), axis=-1)
    assert np.nanmax(step) < 100.0 < np.nanmax(np.linalg.norm(np.diff(kept.positions, axis=0), axis=-1))


def test_zeros_are_kept_where_a_trajectory_reaches_the_origin_gradually():
    from mocapkit.markerset import zero_gap_mask

    t = np.linspace(-1.0, 1.0, 41)
    pos = np.zeros((41, 2, 3))
    pos[:, 0, 0] = t * 50.0  # passes smoothly through (0, 0, 0) at frame 20 (mm)
    pos[:, 1] = [500.0, 200.0, 900.0]
    pos[10:13, 1] = 0.0  # jumps 1 m to the origin and back: a stored gap
    mask = zero_gap_mask(pos, unit_cm=0.1)
    assert not mask[:, 0].any()
    assert mask[10:13, 1].all() and mask[:, 1].sum() == 3
    assert not zero_gap_mask(pos, unit_cm=0.1, skip=[1]).any()


def test_zero_gaps_are_decided_run_by_run_and_cleaning_moves_no_recorded_sample(shared_data, tmp_path):
    # CMU 135_02's left heel passes 50 mm from the lab origin at frame 4420; an exporter writes its occlusions as
    # exact zeros (residual >= 0): one right after that pass (4421-4439), one ordinary (4550-4599). Both are gaps: a
    # run is kept as a position only when the marker's samples on both sides lie within 10 cm of the origin (the
    # whole marker's zeros were kept as positions, because one run touched that area: 0 of 69 read as gaps, and
    # cleaning moved the recorded samples beside the runs up to 38 mm, removed as "spikes").
    from mocapkit.cleaning.markers import clean_markers
    from mocapkit.io import load_markers, save_markers

    take = load_markers(shared_data / "c3d_markers_recovery" / "135_02.c3d")[4200:4700]
    j = take.labels.index("male:LHEE")
    x = np.array(take.positions)
    zeros = np.zeros(x.shape[:2], dtype=bool)
    zeros[221:240, j] = zeros[350:400, j] = True
    assert np.linalg.norm(x[220, j]) < 60.0  # the heel just before the first run, mm from the origin
    x[zeros] = 0.0
    path = save_markers(take.with_positions(x, residuals=np.ones(x.shape[:2])), tmp_path / "zeros.c3d")
    back = load_markers(path)
    assert back.zero_gaps == 69 and np.array_equal(back.missing(), zeros)
    res = clean_markers(back)
    out = np.asarray(res.markers.positions)
    seen = ~back.missing()[:, j]
    assert np.array_equal(out[seen, j], np.asarray(back.positions)[seen, j])  # no recorded sample moved
    assert not np.any(np.all(out[:, j] == 0.0, axis=-1)) and res.filled[:, j].sum() == 69


def test_every_peer_marker_file_reads_or_is_refused_in_one_line(shared_data):
    """Walk the peer files: each C3D and TRC gives a sane MarkerSet or a one-line MocapFormatError."""
    from mocapkit.io import load_markers

    root = shared_data / PEER
    if not root.is_dir():
        pytest.skip("peer_files not present")
    files = sorted(p for p in root.rglob("*") if p.suffix.lower() in (".c3d", ".trc"))
    assert len(files) >= 80
    read, refused = 0, set()
    for f in files:
        try:
            ms = load_markers(f)
        except MocapFormatError as exc:
            assert str(exc).startswith(str(f)) and "\n" not in str(exc), f
            refused.add(f.name)
            continue
        assert ms.num_frames >= 1 and ms.num_markers >= 1, f
        assert not np.isinf(ms.positions).any(), f
        ms.unit_cm  # a known unit
        if ms.num_frames > 5 and (~ms.missing()).sum() > 10:
            step = np.linalg.norm(np.diff(ms.positions, axis=0), axis=-1) * ms.unit_cm
            if np.isfinite(step).any():
                assert np.nanmedian(step) < 5.0, f  # no data block read from the wrong place
        read += 1
    # refused, each for a reason the peers share: empty or truncated, parameter records pointing
    # backwards, a header scale disagreeing with POINT:SCALE, no 3D points at all
    assert refused == {
        "Empty.c3d", "Empty.trc", "Truncated.trc", "bad_parameter_section.c3d", "badParameterOffset.c3d",
        "mocap36.c3d", "MACsample.c3d", "1123x01EMG.c3d", "C3DRotationExample.c3d", "Kistler.c3d",
    }
    assert read == len(files) - len(refused)


def test_selected_markers_drop_the_descriptions_of_others_and_trc_frame_numbers_survive(tmp_path):
    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    assert len(_params(src)["POINT"]["DESCRIPTIONS"]["value"]) == 20  # for 26 markers
    back = load_markers(save_markers(src.select(["LFT1", "RFT1"]), tmp_path / "two.c3d"))
    assert back.labels == ("LFT1", "RFT1")
    assert list(_params(back)["POINT"]["DESCRIPTIONS"]["value"]) in ([], ["", ""])
    same = load_markers(save_markers(src, tmp_path / "all.c3d"))
    # as the file states them (trialT3 4: 6 blank ones were added)
    assert list(_params(same)["POINT"]["DESCRIPTIONS"]["value"]) == list(_params(src)["POINT"]["DESCRIPTIONS"]["value"])
    part = src[100:200]
    trc = load_markers(save_markers(part, tmp_path / "part.trc"))
    assert trc.source.first_frame == 101
    again = load_markers(save_markers(trc, tmp_path / "part.c3d"))
    assert again.source.first_frame == 101


def test_a_non_standard_file_does_not_make_ezc3d_take_gigabytes(shared_data):
    """c3d.org sample22 BKINtechnologies.c3d (583 KB): ezc3d touched 12 GB before refusing it; under the
    address-space budget its allocation fails at once and the fallback reader reads the 5,065 frames."""
    f = shared_data / PEER / "BTKData/Input/C3DSamples/c3d.org/sample22/BKINtechnologies.c3d"
    if not f.is_file():
        pytest.skip("peer_files not present")
    code = f"""
    from mocapkit.io import load_markers
    ms = load_markers({str(f)!r})
    hwm = [int(l.split()[1]) for l in open('/proc/self/status') if l.startswith('VmHWM')][0]
    print(ms.num_frames, ms.num_markers, ms.reader, hwm // 1024)
    """
    from tests.io.bounded import run_bounded

    res = run_bounded(code, limit=64 * 2**30)  # a cap far above what the budget allows: the budget must hold
    frames, markers, reader, peak_mb = res.stdout.split()
    assert (int(frames), int(markers), reader) == (5065, 2, "c3d"), res.stderr
    assert int(peak_mb) < 1024, f"peak resident memory {peak_mb} MB"


# --- files cut short; integer files written back bit for bit ------------------------------------------


@pytest.mark.parametrize("size, reason", [
    (600, "truncated file: the parameter section claims 9 blocks, the file ends inside it"),
    (3000, "truncated file: the parameter section claims 9 blocks, the file ends inside it"),
    (50000, "truncated file: the data block stops partway through frame 67 of the 450 frames the header and "
            "POINT:FRAMES declare (26 points and 64 analog samples a frame, stored as floats); the file is cut short"),
    (100000, "truncated file: the data block stops partway through frame 142 of the 450 frames"),
    (150000, "truncated file: the data block stops partway through frame 216 of the 450 frames"),
])
def test_a_c3d_cut_short_is_refused_as_truncated(tmp_path, size, reason):
    # cut inside its data block, the bundled trial was read short (66, 141, 215 frames), exit 0
    cut = tmp_path / "cut.c3d"
    cut.write_bytes(mocapkit.samples.path("Eb015pr.c3d").read_bytes()[:size])
    msg = refusal_of_load(cut)
    assert msg.startswith(f"{cut}: {reason}"), msg


@pytest.mark.parametrize("name", ["c3d_markers/Gait.c3d", "c3d_markers_recovery/85_12.c3d", "c3d_markers/Eb015pi.c3d"])
def test_shared_c3d_files_cut_anywhere_are_refused_as_truncated(shared_data, tmp_path, name):
    # BTK's Gait.c3d (DEC, 16-bit integers) cut at 50 KB said "unknown length unit 'mm\x00\x00'": its
    # header scale was read as an IEEE float (2e21, so floats), and the c3d package read the 54 frames there
    data = (shared_data / name).read_bytes()
    cut = tmp_path / "cut.c3d"
    for size in (600, 3000, 50000, 100000, 200000):
        if size >= len(data):
            continue
        cut.write_bytes(data[:size])
        with pytest.raises(MocapFormatError) as exc:
            read_c3d(cut)
        msg = str(exc.value)
        assert msg.startswith(f"{cut}: truncated file: ") and "\n" not in msg, (size, msg)
        if size >= 50000:
            assert msg.endswith("the file is cut short"), (size, msg)
    cut.write_bytes(data[:50000])
    if name.endswith("Gait.c3d"):
        assert refusal_of_load(cut).endswith("frame 55 of the 487 frames the header and POINT:FRAMES declare "
                                             "(33 points and 280 analog samples a frame, stored as 16-bit integers); "
                                             "the file is cut short")


def test_whole_frames_fewer_than_stated_are_read_and_a_cut_frame_refused(tmp_path):
    # whole frames, fewer than the header and POINT:FRAMES state, are read as ezc3d and the c3d package read
    # them (ezc3d-testFiles Optotrak.c3d); a header overstating its frames while POINT:FRAMES states what the
    # file holds is read too (a writer's quirk); a frame cut partway is a file cut short
    import struct

    data = bytearray(mocapkit.samples.path("Eb015pr.c3d").read_bytes())
    start = (struct.unpack_from("<H", data, 16)[0] - 1) * 512
    frame = (4 * 26 + 64) * 4
    whole = tmp_path / "whole.c3d"
    whole.write_bytes(bytes(data[: start + 100 * frame]))
    full = read_c3d(mocapkit.samples.path("Eb015pr.c3d"))
    assert np.array_equal(read_c3d(whole).positions, full.positions[:100], equal_nan=True)
    whole.write_bytes(bytes(data[: start + 100 * frame + 7]))
    with pytest.raises(MocapFormatError, match="stops partway through frame 101 of the 450 frames"):
        read_c3d(whole)
    struct.pack_into("<h", data, parameter_offset(bytes(data), "POINT", "FRAMES"), 100)
    stated = tmp_path / "stated.c3d"
    stated.write_bytes(bytes(data[: start + 100 * frame]))
    ms = read_c3d(stated)
    assert ms.num_frames == 100 and ms.reader == "c3d"
    assert np.array_equal(ms.positions, full.positions[:100], equal_nan=True)
    stated.write_bytes(bytes(data[: start + 99 * frame + 7]))
    with pytest.raises(MocapFormatError, match="stops partway through frame 100 of the 100 frames POINT:FRAMES declares"):
        read_c3d(stated)


def _integer_c3d(path, frames=30, rate=100.0, scale=0.1):
    """A small integer C3D (positive POINT:SCALE) written by the c3d package: three markers, one gap."""
    import warnings

    import c3d

    rng = np.random.default_rng(7)
    w = c3d.Writer(point_rate=rate, point_scale=scale)
    rows = []
    for i in range(frames):
        p = np.zeros((3, 5), dtype=np.float32)
        p[:, :3] = np.arange(3)[:, None] * 523.4567 + i * 1.37 + rng.normal(0.0, 3.0, (3, 3))
        p[:, 3] = 0.5 if i != 4 else -1.0  # frame 5: every marker occluded
        rows.append((p, np.zeros((0, 0))))
    w.add_frames(rows)
    w.set_point_labels(["A", "B", "C"])
    with open(path, "wb") as fh, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        w.write(fh)
    return path


def test_an_integer_c3d_written_back_reads_bit_identical(tmp_path):
    from mocapkit.io import load_markers, save_markers

    src = load_markers(_integer_c3d(tmp_path / "int.c3d"))
    assert src.reader == "ezc3d" and src.num_frames == 30 and src.missing()[4].all()
    # int16 * scale, as the float32 a float C3D holds (it was int16 * scale in float64, which float32 cannot hold)
    assert np.array_equal(src.positions, src.positions.astype(np.float32).astype(np.float64), equal_nan=True)
    back = load_markers(save_markers(src, tmp_path / "back.c3d"))
    assert np.array_equal(back.positions, src.positions, equal_nan=True)
    assert np.array_equal(back.residuals, src.residuals)
    # a command that changes some samples: the others come back bit for bit
    changed = np.array(src.positions)
    changed[10:12, 1] += 0.123456789
    back = load_markers(save_markers(src.with_positions(changed), tmp_path / "changed.c3d"))
    keep = np.ones(changed.shape[:2], dtype=bool)
    keep[10:12, 1] = False
    assert np.array_equal(back.positions[keep], src.positions[keep], equal_nan=True)


@pytest.mark.parametrize("name", ["Eb015pi.c3d", "Gait.c3d"])
def test_real_integer_c3d_files_round_trip_bit_identical(shared_data, tmp_path, name):
    # golden: `mocapkit convert Gait.c3d gg.c3d` gave back 2.6 % of Gait's samples identical (1.2e-4 mm off)
    from mocapkit.io import load_markers, save_markers

    path = shared_data / "c3d_markers" / name
    src = load_markers(path)
    assert float(_params(src)["POINT"]["SCALE"]["value"][0]) > 0  # stored as integers
    back = load_markers(save_markers(src, tmp_path / name))
    assert np.array_equal(back.positions, src.positions, equal_nan=True)
    seen = ~src.missing()
    assert np.array_equal(back.residuals[seen], src.residuals[seen])
    assert np.array_equal(back.source.analogs, src.source.analogs)
    again = load_markers(save_markers(back, tmp_path / f"again_{name}"))
    assert np.array_equal(again.positions, src.positions, equal_nan=True)


def test_the_integer_and_float_copies_of_one_trial_read_the_same(shared_data):
    # c3d.org's Eb015pi.c3d (integers, scale 1/12) and Eb015pr.c3d (floats) hold one trial: read the same,
    # bit for bit, now that the integers are read as the float32 a float C3D holds
    integer = read_c3d(shared_data / "c3d_markers" / "Eb015pi.c3d")
    real = read_c3d(shared_data / "c3d_markers" / "Eb015pr.c3d")
    assert integer.positions[0, 0].tolist() == [248.58334350585938, 226.83334350585938, 37.41666793823242]
    assert np.array_equal(integer.positions, real.positions, equal_nan=True)
    assert np.array_equal(integer.residuals, real.residuals)
    assert np.array_equal(integer.source.analogs, real.source.analogs)


def test_a_capture_without_analogs_keeps_its_analog_rate_of_zero(tmp_path):
    """A C3D whose ANALOG:RATE says 0 (no analog channels) came back stating the frame rate there."""
    import ezc3d

    src = Path(__file__).parents[1] / "data" / "85_02.c3d"
    assert float(ezc3d.c3d(str(src))["parameters"]["ANALOG"]["RATE"]["value"][0]) == 0.0
    out = tmp_path / "back.c3d"
    mocapkit.io.save_markers(mocapkit.io.load_markers(src), out)
    back = ezc3d.c3d(str(out))
    assert float(back["parameters"]["ANALOG"]["RATE"]["value"][0]) == 0.0 and back["header"]["analogs"]["frame_rate"] == 0
    assert np.array_equal(mocapkit.io.load_markers(out).positions, mocapkit.io.load_markers(src).positions, equal_nan=True)


def _c3d_package_words(path):
    """(F, M) residuals and camera masks as the ``c3d`` package reads them (the C3D guide's fourth word)."""
    import warnings

    import c3d

    with open(path, "rb") as fh, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        frames = [points[:, 3:5] for _, points, _ in c3d.Reader(fh).read_frames()]
    words = np.asarray(frames, dtype=np.float64)
    return words[..., 0], words[..., 1]


def test_residuals_and_camera_masks_are_read_and_written_as_the_c3d_guide_has_them(tmp_path):
    # trial11: every written C3D had its camera masks zeroed (ezc3d reads and writes the residual and
    # camera bytes of the fourth word the other way round: ezc3d issue #386)
    from mocapkit.io import load_markers, save_markers

    path = mocapkit.samples.path("Eb015pr.c3d")
    src = load_markers(path)
    res, cams = _c3d_package_words(path)
    seen = ~src.missing()
    assert src.residuals[0, :3].tolist() == pytest.approx([1.3333334, 2.0833335, 1.75])  # 16, 25, 21 / 12
    assert np.allclose(src.residuals[seen], res[seen], rtol=1e-6)
    assert np.array_equal(src.cameras[seen], cams[seen]) and src.cameras[0, :3].tolist() == [62, 63, 54]
    out = save_markers(src, tmp_path / "copy.c3d")
    res2, cams2 = _c3d_package_words(out)
    assert np.array_equal(res2, res) and np.array_equal(cams2[seen], cams[seen])
    back = load_markers(out)
    assert np.array_equal(back.residuals, src.residuals) and np.array_equal(back.cameras, src.cameras)
    # a sample a cleaner changed: residual 0 and no camera (no camera saw the value written there)
    changed = np.array(src.positions)
    changed[10, 0] += 1.0
    again = load_markers(save_markers(src.with_positions(changed), tmp_path / "changed.c3d"))
    assert again.residuals[10, 0] == 0.0 and again.cameras[10, 0] == 0
    keep = seen.copy()
    keep[10, 0] = False
    assert np.array_equal(again.cameras[keep], src.cameras[keep])


def test_header_events_are_kept(tmp_path):
    # trial11: Eb015pi/pr hold their gait events only in the header (no EVENT group): written back, lost
    import ezc3d

    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    assert [label for _, label, _ in src.source.events] == ["RIC ", "RHS ", "RTO "]
    out = save_markers(src, tmp_path / "copy.c3d")
    events = ezc3d.c3d(str(out))["header"]["events"]
    assert list(events["events_time"][:3]) == pytest.approx([2.72, 5.40, 7.32])
    assert list(events["events_label"][:3]) == ["RIC ", "RHS ", "RTO "]
    assert load_markers(out).source.events == src.source.events


def test_negative_zero_analog_samples_stay_negative(tmp_path):
    import dataclasses

    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    analogs = np.array(src.source.analogs)
    analogs[3, 10:20] = -0.0
    analogs[5, 7] = 0.0
    src = dataclasses.replace(src, source=dataclasses.replace(src.source, analogs=analogs))
    back = load_markers(save_markers(src, tmp_path / "z.c3d")).source.analogs
    assert np.array_equal(np.signbit(back), np.signbit(analogs.astype(np.float32)))
    assert np.array_equal(back, analogs.astype(np.float32))


def test_repeated_labels_and_descriptions_are_written_as_the_file_has_them(shared_data, tmp_path):
    # trial11: Gait.c3d written back had RKNE -> RKNE_2 (six labels) and all 33 POINT:DESCRIPTIONS emptied
    import ezc3d

    from mocapkit.io import load_markers, save_markers

    path = shared_data / "c3d_markers" / "Gait.c3d"
    src = load_markers(path)
    assert "RKNE_2" in src.labels and any("repeats are called RKNE_2" in n for n in src.notes)
    before = ezc3d.c3d(str(path))["parameters"]["POINT"]
    after = ezc3d.c3d(str(save_markers(src, tmp_path / "g.c3d")))["parameters"]["POINT"]
    assert list(after["LABELS"]["value"]) == [s.strip() for s in before["LABELS"]["value"]]
    assert list(after["LABELS"]["value"]).count("RKNE") == 2
    assert list(after["DESCRIPTIONS"]["value"]) == [s.strip() for s in before["DESCRIPTIONS"]["value"]]
    assert after["DESCRIPTIONS"]["value"][0] == "R.Shoulder"
    assert load_markers(tmp_path / "g.c3d").labels == src.labels
    # a part of the markers is no longer the file's own: unique names, no descriptions of others
    part = load_markers(save_markers(src.select(["RKNE_2", "RSHO"]), tmp_path / "p.c3d"))
    assert part.labels == ("RKNE_2", "RSHO")


@pytest.mark.parametrize("name", ["Eb015pi.c3d", "Gait.c3d"])
def test_an_integer_files_analogs_are_written_as_its_whole_numbers(shared_data, tmp_path, name):
    # trial11: written back as float32 of the scaled values under SCALE 1, OFFSET 0 (up to 5.8e-8 off)
    import ezc3d

    from mocapkit.io import load_markers, save_markers

    path = shared_data / "c3d_markers" / name
    out = save_markers(load_markers(path), tmp_path / name)
    before, after = ezc3d.c3d(str(path)), ezc3d.c3d(str(out))
    assert np.array_equal(after["data"]["analogs"], before["data"]["analogs"])  # as ezc3d reads them, float64
    # every channel's scale the file states, those past ANALOG:USED too (trialT3 4: cut to USED)
    assert np.array_equal(np.ravel(after["parameters"]["ANALOG"]["SCALE"]["value"]),
                          np.ravel(before["parameters"]["ANALOG"]["SCALE"]["value"]))


def test_residuals_are_read_where_ezc3d_reads_the_frames(shared_data):
    # c3d.org's MotionMonitorC3D.c3d: its header counts 16 analog samples a frame, ANALOG:USED 16 at 7 a
    # frame; the residual word is read in the frame layout ezc3d reads, so no seen sample turns missing
    import ezc3d

    path = _peer(shared_data, "BTKData/Input/C3DSamples/c3d.org/sample24/MotionMonitorC3D.c3d")
    ms = read_c3d(path)
    c = ezc3d.c3d(str(path))
    assert np.array_equal(ms.missing(), c["data"]["meta_points"]["residuals"][0].T < 0)


def test_the_trial_frame_range_follows_the_frames_written(tmp_path):
    """TRIAL:ACTUAL_START_FIELD / ACTUAL_END_FIELD (Vicon) say which frames the file holds: first .. first + F - 1."""
    import ezc3d

    from mocapkit.io.c3d import write_c3d

    ms = read_c3d(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")[10:20]
    write_c3d(ms, tmp_path / "out.c3d")
    trial = ezc3d.c3d(str(tmp_path / "out.c3d"))["parameters"]["TRIAL"]

    def frame(key):
        lo, hi = (int(v) for v in np.ravel(trial[key]["value"])[:2])
        return (lo & 0xFFFF) + (hi << 16)

    assert frame("ACTUAL_START_FIELD") == ms.source.first_frame
    assert frame("ACTUAL_END_FIELD") - frame("ACTUAL_START_FIELD") + 1 == ms.num_frames == 10


def test_parameter_names_keep_their_case_through_the_pure_python_reader(tmp_path):
    # trial: dynamic.c3d's SUBJECT:Address and Height came back as ADDRESS and HEIGHT in a cleaned file (the
    # c3d package upper-cases every name; ezc3d reads and writes them as written, and looks them up by case)
    import dataclasses
    import struct

    import ezc3d

    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    params = {g: dict(v) for g, v in src.source.parameters.items()}
    text = {"type": -1, "description": "", "is_locked": False, "value": ["12 Main St"]}
    params["SUBJECT"]["Address"] = text
    params["Lab_Info"] = {"__METADATA__": params["SUBJECT"]["__METADATA__"], "Room": dict(text, value=["B2"])}
    mixed = dataclasses.replace(src, source=dataclasses.replace(src.source, parameters=params))
    data = bytearray(save_markers(mixed, tmp_path / "mixed.c3d").read_bytes())
    # 100 whole frames, POINT:FRAMES saying so and the header 450: a file only the pure-Python reader reads
    points, analog = struct.unpack_from("<2H", data, 2)
    start = (struct.unpack_from("<H", data, 16)[0] - 1) * 512
    struct.pack_into("<h", data, parameter_offset(bytes(data), "POINT", "FRAMES"), 100)
    (tmp_path / "short.c3d").write_bytes(bytes(data[: start + 100 * (4 * points + analog) * 4]))
    ms = load_markers(tmp_path / "short.c3d")
    assert ms.reader == "c3d" and ms.num_frames == 100
    assert "Address" in ms.source.parameters["SUBJECT"] and "Room" in ms.source.parameters["Lab_Info"]
    assert "HEIGHT" in ms.source.parameters["SUBJECT"] and "LABELS" in ms.source.parameters["POINT"]
    back = ezc3d.c3d(str(save_markers(ms, tmp_path / "back.c3d")))["parameters"]
    assert list(back["SUBJECT"]["Address"]["value"]) == ["12 Main St"] and list(back["Lab_Info"]["Room"]["value"]) == ["B2"]
    assert "ADDRESS" not in back["SUBJECT"] and "LAB_INFO" not in back


@pytest.mark.parametrize("name", ["Gait.c3d", "Dance.c3d", "golfswing.c3d"])
def test_a_c3d_whose_point_units_is_blank_is_read_in_the_unit_its_marker_distances_fit(shared_data, tmp_path, name):
    src = shared_data / "c3d_markers" / name
    data = bytearray(src.read_bytes())
    at = parameter_offset(bytes(data), "POINT", "UNITS")
    size = data[at - 1]  # one dimension: the text's length
    assert bytes(data[at:at + size]).strip(b" \x00") == b"mm"
    data[at:at + size] = b" " * size
    blank = tmp_path / name
    blank.write_bytes(bytes(data))
    stated, read = read_c3d(src), read_c3d(blank)
    assert (stated.units, stated.units_from) == ("mm", "file")
    assert (read.units, read.units_from) == ("mm", "data")
    np.testing.assert_array_equal(read.positions, stated.positions)
    assert read_c3d(blank, units="cm").units_from == "given"


def _ezc3d_cut_short(monkeypatch, keep: int, finished: bool = False):
    """ezc3d's write on a full disk: the file cut short at ``keep`` bytes and no error (it checks none); the header's
    data start block, which it writes last, left at its placeholder 1 (as trial 20's file had it) unless ``finished``."""
    import ezc3d

    real = ezc3d.c3d.write

    def write(self, path, *args, **kwargs):
        real(self, path, *args, **kwargs)
        with open(path, "r+b") as fh:
            fh.truncate(keep)
            if not finished and keep >= 18:
                fh.seek(16)
                fh.write((1).to_bytes(2, "little"))

    monkeypatch.setattr(ezc3d.c3d, "write", write)


@pytest.mark.parametrize("keep, finished", [(300, False), (200_000, False), (302_080, False), (302_080, True)])
def test_a_c3d_ezc3d_cuts_short_on_a_full_disk_is_refused_naming_the_file(tmp_path, monkeypatch, keep, finished):
    import errno
    import os

    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))  # 306,176 bytes as ezc3d writes it
    _ezc3d_cut_short(monkeypatch, keep, finished)
    monkeypatch.setattr(os, "statvfs", lambda p: os.statvfs_result((4096, 4096, 100, 0, 0, 100, 0, 0, 0, 255)))
    out = tmp_path / "out" / "x.c3d"
    with pytest.raises(OSError) as caught:
        save_markers(src, out)
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(out)
    assert list(tmp_path.iterdir()) == []  # no output, nothing of ezc3d's, nor the folder made for it


def test_a_c3d_cut_short_with_room_left_is_refused_too(tmp_path, monkeypatch):
    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    _ezc3d_cut_short(monkeypatch, 200_000, finished=True)
    with pytest.raises(MocapFormatError, match=r"x\.c3d: cannot write C3D: ezc3d wrote 200000 bytes, not the "
                                               r"\d+ its header describes"):
        save_markers(src, tmp_path / "x.c3d")
    _ezc3d_cut_short(monkeypatch, 302_080)
    with pytest.raises(MocapFormatError, match=r"x\.c3d: cannot write C3D: ezc3d wrote 302080 bytes, its header "
                                               r"unfinished"):
        save_markers(src, tmp_path / "x.c3d")
    assert list(tmp_path.iterdir()) == []


def test_a_c3d_is_written_beside_its_output_not_in_the_temporary_folder(tmp_path, monkeypatch):
    import tempfile

    from mocapkit.io import load_markers, save_markers

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "no-such-tmp"))  # $TMPDIR gone (or full)
    out = save_markers(src, tmp_path / "x.c3d")
    assert load_markers(out).num_frames == src.num_frames
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.c3d"]


def test_written_back_keeps_empty_texts_and_the_analog_scales(shared_data, tmp_path):
    """FunctionalWalk.c3d written back unchanged: its empty texts (SUBJECTS:NAMES [''] ...) stay [''], not [],
    and its analogs (whole A/D counts stored as floats) keep ANALOG:SCALE and read back the very values, by
    ezc3d and by the c3d package (ezc3d writes ANALOG:OFFSET 0, the stored counts shifted by it)."""
    import warnings

    import c3d
    import ezc3d

    from mocapkit.io.c3d import write_c3d

    src = next(shared_data.rglob("FunctionalWalk.c3d"))
    out = tmp_path / "fw.c3d"
    write_c3d(read_c3d(src), out)
    a, b = ezc3d.c3d(str(src)), ezc3d.c3d(str(out))
    for key in ("NAMES", "LABEL_PREFIXES", "MARKER_SETS", "MODELS", "MODEL_PARAMS"):
        assert a["parameters"]["SUBJECTS"][key]["value"] == [""]
        assert b["parameters"]["SUBJECTS"][key]["value"] == [""], key
    assert np.array_equal(b["parameters"]["ANALOG"]["SCALE"]["value"], a["parameters"]["ANALOG"]["SCALE"]["value"])
    assert np.array_equal(b["data"]["analogs"], a["data"]["analogs"])

    def package_analogs(path):
        with open(path, "rb") as fh, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return np.array([an.copy() for _, _, an in c3d.Reader(fh).read_frames()])

    assert np.array_equal(package_analogs(out), package_analogs(src))


def test_values_past_float32s_range_are_kept_as_read_without_a_warning():
    """A damaged C3D's scale can make a sample larger than any float32 (fuzz_commands' mutant 437 of `info`
    warned "overflow encountered in cast" on standard error): it is kept as read, the others rounded as before."""
    import warnings

    from mocapkit.io import c3d

    values = np.array([1.0, 1e39, -1e300, np.nan, 0.1, np.inf])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = c3d._float32_values(values)
    assert out[1] == 1e39 and out[2] == -1e300 and np.isnan(out[3]) and out[5] == np.inf
    assert out[0] == 1.0 and out[4] == float(np.float32(0.1))


def _point_frames(path) -> np.ndarray:
    """(F, M, 5) x, y, z, residual and camera mask of every sample as the ``c3d`` package reads the file."""
    import c3d

    with open(path, "rb") as fh:
        return np.array([p.copy() for _, p, _ in c3d.Reader(fh).read_frames()])


def _same_points(a, b) -> bool:
    return bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def test_gaps_stored_as_zeros_are_written_back_as_stored_on_request(tmp_path):
    # CMU 85_02 (tests/data) with Male:LANK's frames 100-139 stored as an exporter stores an occlusion: (0, 0, 0)
    # with residual 2 (a non-negative residual: a reader that does not decide reads a marker at the lab origin)
    from mocapkit.io import load_markers, save_markers

    take = load_markers(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")[:300]
    x, res = np.array(take.positions), np.array(take.residuals)
    x[100:140, 7], res[100:140, 7] = 0.0, 2.0
    path = save_markers(take.with_positions(x, residuals=res), tmp_path / "zeros.c3d")
    back = load_markers(path)
    assert back.zero_gaps == 40 and back.missing()[100:140, 7].all()
    stored = np.zeros(x.shape[:2], dtype=bool)
    stored[100:140, 7] = True
    assert np.array_equal(~np.isnan(back.source.stored_zeros[..., 0]), stored)
    kept = save_markers(back, tmp_path / "kept.c3d", stored_zeros=True)
    assert _same_points(_point_frames(kept), _point_frames(path))  # bit for bit: zeros and residuals as stored
    plain = _point_frames(save_markers(back, tmp_path / "plain.c3d"))
    assert np.all(plain[100:140, 7, 3] == -1)  # by default a gap like every other: residual -1
    filled = np.array(back.positions)
    filled[120, 7] = [1.0, 2.0, 3.0]  # a sample written there since: written, not the stored zero
    part = _point_frames(save_markers(back.with_positions(filled), tmp_path / "part.c3d", stored_zeros=True))
    assert np.array_equal(part[120, 7, :3], [1.0, 2.0, 3.0])
    assert _same_points(part[[119, 121], 7], _point_frames(path)[[119, 121], 7])


def test_an_integer_c3d_keeps_its_storage_without_shared_data(tmp_path):
    # the same on a small integer file the c3d package writes (scale 0.1): the data block comes back as it was,
    # a changed sample on the nearest 0.1 step
    import struct

    from mocapkit.io import save_markers

    path = _integer_c3d(tmp_path / "int.c3d")
    take = read_c3d(path)
    raw, got = path.read_bytes(), save_markers(take, tmp_path / "back.c3d").read_bytes()
    start = lambda b: (struct.unpack_from("<H", b, 16)[0] - 1) * 512  # noqa: E731
    assert struct.unpack_from("<f", got, 12)[0] == pytest.approx(0.1)
    a = np.frombuffer(got, "<i2", 30 * 12, start(got)).reshape(30, 3, 4)
    b = np.frombuffer(raw, "<i2", 30 * 12, start(raw)).reshape(30, 3, 4)
    # frame 5 is occluded: written as the file stored it, its coordinates under word -1 kept (they were 0)
    assert np.array_equal(a, b) and np.all(b[4, :, 3] < 0) and np.any(b[4, :, :3] != 0)
    moved = take.positions.copy()
    moved[10, 1] += 0.123456789
    back = read_c3d(save_markers(take.with_positions(moved), tmp_path / "moved.c3d"))
    assert np.allclose(back.positions[10, 1], moved[10, 1], rtol=0, atol=0.05 + 1e-6)
    assert np.allclose(back.positions[10, 1] / np.float32(0.1), np.rint(back.positions[10, 1] / np.float32(0.1)))
