import numpy as np
import pytest

from mocapkit.errors import MocapFormatError
from mocapkit.io import load_markers, save_markers
from mocapkit.io.trc import read_trc, write_trc
from mocapkit.markerset import MarkerSet

from .bounded import refusal_of_load

TRC = "trc_markers"
PEER_TRC = "peer_files/BTKData/Input/TRCSamples"


def _file(shared_data, rel):
    path = shared_data / rel
    if not path.is_file():
        pytest.skip(f"{rel} not present")
    return path


@pytest.mark.parametrize("name, frames, markers, fps, first, last", [
    ("Gait.trc", 487, 105, 100.0, "R.Shoulder", "M105"),  # 33 labels, 66 stated markers, rows holding 105
    ("SprintMotion.trc", 788, 59, 250.0, "C7", "StartArr"),
    ("T.trc", 89, 41, 30.0, "RFHD", "LFHD"),
    ("ballet_reduced.trc", 100, 41, 30.0, "RFHD", "LFHD"),
])
def test_the_four_shared_takes(shared_data, name, frames, markers, fps, first, last):
    ms = read_trc(_file(shared_data, f"{TRC}/{name}"))
    assert (ms.num_frames, ms.num_markers, ms.fps, ms.units) == (frames, markers, fps, "mm")
    assert ms.labels[0] == first and ms.labels[-1] == last
    assert ms.reader == "trc" and ms.source.format == "trc" and ms.source.first_frame == 1
    assert ms.residuals is None and ms.unit_cm == 0.1


def test_golden_values(shared_data):
    # values as they stand in the files (and as BTK's TRC reader test reads them)
    t = read_trc(_file(shared_data, f"{TRC}/T.trc"))
    assert t.labels[1] == "LBHD" and t.positions[3, 1, 0] == -171.03949
    assert t.positions[0, 0].tolist() == [-336.42437, 1639.63722, -22.06800]
    assert t.positions[-1, 0].tolist() == [-331.72054, 1636.73486, -17.46424]
    ballet = read_trc(_file(shared_data, f"{TRC}/ballet_reduced.trc"))
    assert ballet.positions[82, 40, 2] == -112.24601
    sprint = read_trc(_file(shared_data, f"{TRC}/SprintMotion.trc"))
    assert sprint.positions[0, 0].tolist() == [161.60107, 69.74284, 728.04388]
    assert not sprint.missing().any()
    gait = read_trc(_file(shared_data, f"{TRC}/Gait.trc"))
    assert gait.missing()[0, :66].all()  # frame 1: empty fields up to the 66 markers the header states
    assert gait.positions[0, 66].tolist() == [4012.05127, 112.96879, 1347.57288]  # and a trajectory past them
    assert 0.5 < gait.missing().mean() < 0.9


def test_peer_files_with_occlusions_and_unnamed_markers(shared_data):
    knee = read_trc(_file(shared_data, f"{PEER_TRC}/Knee.trc"))
    assert (knee.num_frames, knee.num_markers, knee.fps) == (200, 71, 200.0)
    assert knee.positions[83, 1, 0] == 301.65476 and knee.missing()[82, 70]
    assert knee.labels[0] == "genou1_ NewMarker" and knee.labels[3] == "genou1_NewMarker3"  # stripped
    # NumMarkers 0 and no labels: the markers are counted from the rows
    u1 = read_trc(_file(shared_data, f"{PEER_TRC}/10002-20130626160334-Unnamed.trc"))
    assert (u1.num_frames, u1.num_markers, u1.fps) == (882, 10, 400.0)
    assert u1.labels == tuple(f"M{i:03d}" for i in range(1, 11))
    assert u1.missing()[:11].all() and u1.positions[11, 0].tolist() == [19.91857, 1362.18750, -124.33382]
    assert u1.positions[881, 3].tolist() == [-1837.97595, -1082.82910, -1182.05762] and u1.missing()[881, 4:].all()
    u2 = read_trc(_file(shared_data, f"{PEER_TRC}/10002-20130731010438-Unnamed.trc"))
    assert (u2.num_frames, u2.num_markers) == (1313, 37)
    assert u2.positions[1312, 32].tolist() == [950.22644, 1470.34619, 951.17596] and u2.missing()[1312, 31]


@pytest.mark.parametrize("name, reason", [
    ("Empty.trc", "empty file: a TRC file starts with a PathFileType line"),
    ("Truncated.trc", "truncated TRC header: 2 lines, the header needs 5 (PathFileType, names, values, Frame#/labels, X1 Y1 Z1)"),
])
def test_empty_and_truncated_files_are_refused(shared_data, name, reason):
    path = _file(shared_data, f"{PEER_TRC}/{name}")
    msg = refusal_of_load(path)
    assert msg.startswith(f"{path}") and msg.endswith(reason)


@pytest.mark.parametrize("name", ["Gait.trc", "SprintMotion.trc", "T.trc", "ballet_reduced.trc"])
def test_round_trip_exact_at_the_written_precision(shared_data, tmp_path, name):
    src = read_trc(_file(shared_data, f"{TRC}/{name}"))
    out = save_markers(src, tmp_path / name)
    back = load_markers(out)
    assert back.labels == src.labels and back.fps == src.fps and back.units == src.units
    assert back.num_frames == src.num_frames and back.source.first_frame == src.source.first_frame
    # the files hold 5 decimals, which the writer writes: the values come back bit for bit
    assert np.array_equal(back.positions, src.positions, equal_nan=True)
    for key in ("CameraRate", "OrigDataRate", "OrigDataStartFrame", "OrigNumFrames"):
        assert float(back.source.parameters[key]) == float(src.source.parameters[key])


def _markers(frames=12, markers=3, fps=60.0, seed=0):
    rng = np.random.default_rng(seed)
    pos = rng.normal(0.0, 500.0, (frames, markers, 3))
    pos[3:5, 1] = np.nan
    return MarkerSet(labels=tuple(f"m{i}" for i in range(markers)), positions=pos, fps=fps, units="mm", name="x")


def test_round_trip_rounds_to_the_decimals_written(tmp_path):
    ms = _markers()
    write_trc(ms, tmp_path / "a.trc")
    back = read_trc(tmp_path / "a.trc")
    expect = np.vectorize(lambda v: float(f"{v:.5f}"))(ms.positions)
    assert np.array_equal(back.positions, expect, equal_nan=True)
    assert np.array_equal(back.missing(), ms.missing()) and back.fps == 60.0
    write_trc(ms, tmp_path / "b.trc", decimals=2)
    assert np.array_equal(read_trc(tmp_path / "b.trc").positions, np.vectorize(lambda v: float(f"{v:.2f}"))(ms.positions), equal_nan=True)
    # the written file is what TRC readers expect: header names, one label over three columns, empty fields
    lines = (tmp_path / "a.trc").read_text().splitlines()
    assert lines[0].split("\t")[:3] == ["PathFileType", "4", "(X/Y/Z)"]
    assert lines[1].split("\t") == ["DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units", "OrigDataRate",
                                    "OrigDataStartFrame", "OrigNumFrames"]
    assert lines[2].split("\t")[:5] == ["60.00", "60.00", "12", "3", "mm"]
    assert lines[3].split("\t") == ["Frame#", "Time", "m0", "", "", "m1", "", "", "m2"]
    assert lines[4].split("\t")[2:5] == ["X1", "Y1", "Z1"]
    row = lines[6 + 3].split("\t")
    assert row[0] == "4" and row[5:8] == ["", "", ""]


def test_a_non_round_rate_survives(tmp_path):
    ms = _markers(fps=29.97002997)
    write_trc(ms, tmp_path / "r.trc")
    assert read_trc(tmp_path / "r.trc").fps == ms.fps


@pytest.mark.parametrize("text, reason, line", [
    ("hello\n", "not a TRC file: the first line starts with 'hello', not 'PathFileType'", 1),
    ("PathFileType\t4\t(X/Y/Z)\tx\nDataRate\tUnits\n0\tmm\nFrame#\tTime\tA\n\t\tX1\tY1\tZ1\n\n1\t0\t1\t2\t3\n",
     "DataRate must be a positive number from 1 to 10000 (frames per second), got 0.0", 3),
    ("PathFileType\t4\t(X/Y/Z)\tx\nDataRate\tUnits\n100\tparsecs\nFrame#\tTime\tA\n\t\tX1\tY1\tZ1\n\n1\t0\t1\t2\t3\n",
     "unknown length unit 'parsecs'", None),
    ("PathFileType\t4\t(X/Y/Z)\tx\nDataRate\tUnits\n100\tmm\nFrame#\tTime\tA\n\t\tX1\tY1\tZ1\n\n1\t0\t1\tabc\t3\n",
     "field 4 is 'abc', not a number", 7),
    ("PathFileType\t4\t(X/Y/Z)\tx\nDataRate\tUnits\n100\tmm\nFrame#\tTime\tA\n\t\tX1\tY1\tZ1\n\n",
     "the TRC file holds no data rows", None),
])
def test_malformed_files_are_refused_in_one_line_naming_the_line(tmp_path, text, reason, line):
    path = tmp_path / "bad.trc"
    path.write_text(text)
    with pytest.raises(MocapFormatError) as exc:
        read_trc(path)
    assert exc.value.line == line
    assert reason in exc.value.reason and "\n" not in str(exc.value)


def test_zeros_written_for_missing_samples_are_read_as_gaps(tmp_path):
    ms = _markers(frames=30)
    pos = np.nan_to_num(np.array(ms.positions), nan=0.0)  # an exporter writing 0 0 0 for unseen
    write_trc(MarkerSet(labels=ms.labels, positions=pos, fps=ms.fps), tmp_path / "z.trc")
    auto = read_trc(tmp_path / "z.trc")
    assert auto.zero_gaps == 2 and np.array_equal(auto.missing(), ms.missing())
    kept = read_trc(tmp_path / "z.trc", zeros_as_gaps=False)
    assert kept.zero_gaps == 0 and not kept.missing().any()


def test_labels_trc_cannot_hold_are_refused(tmp_path):
    ms = MarkerSet(labels=("a\tb",), positions=np.zeros((2, 1, 3)), fps=30.0)
    with pytest.raises(MocapFormatError, match="tab or line break"):
        write_trc(ms, tmp_path / "x.trc")
    assert not (tmp_path / "x.trc").exists()


def test_a_marker_count_the_file_does_not_hold_is_refused(tmp_path):
    path = tmp_path / "n.trc"
    path.write_text("PathFileType\t4\t(X/Y/Z)\tx\nDataRate\tNumMarkers\tUnits\n100\t999999999\tmm\n"
                    "Frame#\tTime\tA\n\t\tX1\tY1\tZ1\n\n1\t0\t1\t2\t3\n")
    with pytest.raises(MocapFormatError, match="NumMarkers says 999999999 markers, the file names and holds at most 1"):
        read_trc(path)
    path.write_text("PathFileType\t4\t(X/Y/Z)\tx\nDataRate\tUnits\n100\tmm\nFrame#\tTime\tA\n\t\tX1\tY1\tZ1\n\n"
                    "1\t0\t1\t2\t3\ninf\t0\t1\t2\t3\n")
    with pytest.raises(MocapFormatError, match="frame number 'inf' is not a number"):
        read_trc(path)


def _mutants(text: str, count: int, seed: int = 0):
    """``count`` deterministic mutants of a TRC text: lines dropped, doubled or swapped, fields replaced, cut short."""
    import random

    rng = random.Random(seed)
    tokens = ["", "0", "-0", "nan", "inf", "-inf", "1e308", "1e-320", "abc", "\t", " ", "999999999", "-1",
              "3.5", "PathFileType", "Frame#", "\x00", "é", "1,5"]
    for _ in range(count):
        lines = text.split("\n")
        for _ in range(rng.choice([1, 1, 2, 3])):
            i = rng.randrange(len(lines))
            kind = rng.randrange(5)
            if kind == 0:
                del lines[i]
            elif kind == 1:
                lines.insert(i, lines[i])
            elif kind == 2:
                j = rng.randrange(len(lines))
                lines[i], lines[j] = lines[j], lines[i]
            elif kind == 3:
                fields = lines[i].split("\t")
                fields[rng.randrange(len(fields))] = rng.choice(tokens)
                lines[i] = "\t".join(fields)
            else:
                lines = lines[: max(1, i)]
                lines[-1] = lines[-1][: rng.randrange(len(lines[-1]) + 1)]
        yield "\n".join(lines)
        if not lines:
            break


def test_mutated_trc_files_read_sanely_or_are_refused_in_one_line(tmp_path):
    ms = _markers(frames=8, markers=3)
    write_trc(ms, tmp_path / "seed.trc")
    seed = (tmp_path / "seed.trc").read_text()
    path = tmp_path / "mutant.trc"
    outcomes = {"ok": 0, "refused": 0}
    for text in _mutants(seed, 400):
        path.write_text(text, encoding="utf-8")
        try:
            got = read_trc(path)
        except MocapFormatError as exc:
            assert str(exc).startswith(str(path)) and "\n" not in str(exc), text
            outcomes["refused"] += 1
            continue
        assert got.num_frames >= 1 and got.num_markers >= 1, text
        assert got.positions.shape == (got.num_frames, got.num_markers, 3)
        assert not np.isinf(got.positions).any() and got.fps > 0 and got.unit_cm > 0
        outcomes["ok"] += 1
    # both paths exercised (mutants that lose rows are refused as cut short since NumFrames is checked, and those
    # with a doubled or swapped row, or a time out of step, since the Time column must go forward by whole frames)
    assert outcomes["ok"] > 20 and outcomes["refused"] > 50


# --- files cut short --------------------------------------------------------------------------------


def test_a_trc_cut_short_is_refused(shared_data, tmp_path):
    # the user trial: `head -c 200000 SprintMotion.trc` was read as a 111-frame take, exit 0
    data = _file(shared_data, f"{TRC}/SprintMotion.trc").read_bytes()
    cut = tmp_path / "t.trc"
    cut.write_bytes(data[:200000])
    assert refusal_of_load(cut) == (f"{cut}:117: truncated file: it has 111 of the 788 frames its header declares "
                                    "(NumFrames), the last cut mid-row; the file is cut short")
    lines = data.split(b"\n")
    cut.write_bytes(b"\n".join(lines[:50]) + b"\n")  # cut on a line break
    with pytest.raises(MocapFormatError, match="it has 44 of the 788 frames its header declares"):
        read_trc(cut)


def _trc_text(frames=6, markers=3, num_frames=None, last_row=None, end="\n"):
    """A small TRC text: ``frames`` rows of ``markers`` markers; NumFrames ``num_frames`` ("" for none)."""
    rows = [f"{i + 1}\t{i / 100:.6f}\t" + "\t".join(f"{100 * k + i + 0.5:.5f}" for k in range(3 * markers))
            for i in range(frames)]
    if last_row is not None:
        rows[-1] = last_row
    nf = str(frames) if num_frames is None else num_frames
    head = ["PathFileType\t4\t(X/Y/Z)\tx.trc", "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits",
            f"100.00\t100.00\t{nf}\t{markers}\tmm", "Frame#\tTime\t" + "\t\t\t".join(f"m{k}" for k in range(markers)),
            "\t\t" + "\t".join(f"X{k + 1}\tY{k + 1}\tZ{k + 1}" for k in range(markers)), ""]
    return "\n".join(head + rows) + end


def test_a_last_row_cut_mid_line_is_refused_without_numframes(tmp_path):
    path = tmp_path / "c.trc"
    text = _trc_text(num_frames="")
    path.write_text(text[: text.rindex("\t") - 3])  # cut inside the last row's 8th number, no NumFrames
    with pytest.raises(MocapFormatError) as exc:
        read_trc(path)
    assert exc.value.line == 12 and exc.value.reason == (
        "truncated file: the last row holds 8 of the 9 values its 3 markers need and ends without a line break; "
        "the file is cut short")
    path.write_text(text[: text.rindex("\t")] + "\t1.5e")  # cut inside an exponent
    with pytest.raises(MocapFormatError, match=r"field 11 is '1\.5e', not a number \(the file ends in this row "
                                               r"without a line break: cut short\?\)"):
        read_trc(path)


@pytest.mark.parametrize("variant", ["no NumFrames", "NumFrames 0", "NumFrames below the rows", "NumFrames not a number",
                                     "no final line break", "CRLF", "blank lines after", "trailing markers missing"])
def test_trc_variants_that_are_not_cut_short_still_read(tmp_path, variant):
    full = _trc_text()
    short_last = "6\t0.050000\t0.50000\t100.50000\t200.50000"  # markers 2 and 3 unseen in the last row
    text = {
        "no NumFrames": _trc_text(num_frames=""), "NumFrames 0": _trc_text(num_frames="0"),
        "NumFrames below the rows": _trc_text(num_frames="4"), "NumFrames not a number": _trc_text(num_frames="n/a"),
        "no final line break": _trc_text(end=""), "CRLF": full.replace("\n", "\r\n"),
        "blank lines after": full + "\n\n", "trailing markers missing": _trc_text(last_row=short_last),
    }[variant]
    path = tmp_path / "v.trc"
    path.write_bytes(text.encode())
    ms = read_trc(path)
    assert (ms.num_frames, ms.num_markers) == (6, 3)
    assert ms.positions[0, 2].tolist() == [600.5, 700.5, 800.5]
    assert ms.missing()[5, 1:].all() == (variant == "trailing markers missing")
    # a header counting fewer frames than the rows hold is said (all rows read); no other variant has a note
    below = "the header states NumFrames 4, the file holds 6 rows: all 6 are read"
    assert ms.notes == ((below,) if variant == "NumFrames below the rows" else ())


# --- what the file holds comes back (trial11) -------------------------------------------------------


def _crlf_trc(rows, labels=("A", "B"), num_markers=None, name="cap.trc", decimals=8, first=1, t0=0.0):
    """A TRC text as exporters write it: CRLF, trailing tabs, padded NumFrames, ``rows`` of coordinates (lists)."""
    nm = len(labels) if num_markers is None else num_markers
    head = [f"PathFileType\t4\t(X/Y/Z)\t{name}\t", "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\t"
            "OrigDataStartFrame\tOrigNumFrames\t", f"30.00\t30.00\t   {len(rows)}\t{nm}\tm\t30.00\t{first}\t   {len(rows)}\t",
            "Frame#\tTime\t" + "\t\t\t".join(labels) + "\t\t\t", "\t\t" + "\t".join(
                f"X{k + 1}\tY{k + 1}\tZ{k + 1}" for k in range(len(labels))) + "\t", ""]
    body = [f"{first + i}\t{t0 + i / 30:.3f}\t" + "\t".join("" if v is None else f"{v:.{decimals}f}" for v in r) + "\t"
            for i, r in enumerate(rows)]
    return ("\r\n".join(head + body) + "\r\n").encode()


def _rows(frames=40, markers=2, seed=3):
    rng = np.random.default_rng(seed)
    base = rng.normal(0.0, 0.5, (markers, 3))
    return [list((base + 0.001 * i + rng.normal(0.0, 1e-5, base.shape)).ravel()) for i in range(frames)]


def test_an_unchanged_take_is_written_back_byte_for_byte(tmp_path):
    # trial11: t4_metres.trc (8 decimals) came back rounded to 5, CRLF -> LF, trailing tabs dropped, the
    # PathFileType name replaced, NumFrames' padding removed, label spaces stripped
    path = tmp_path / "cap.trc"
    path.write_bytes(_crlf_trc(_rows(), labels=(" A ", "B")))
    ms = read_trc(path)
    assert ms.labels == ("A", "B")
    out = save_markers(ms, tmp_path / "out.trc")
    assert out.read_bytes() == path.read_bytes()


def test_a_changed_sample_rewrites_its_cells_only(tmp_path):
    path = tmp_path / "cap.trc"
    path.write_bytes(_crlf_trc(_rows()))
    ms = read_trc(path)
    pos = np.array(ms.positions)
    pos[5, 1] += 0.0012345678
    pos[9, 0] = np.nan
    out = save_markers(ms.with_positions(pos), tmp_path / "out.trc")
    a, b = path.read_bytes().split(b"\r\n"), out.read_bytes().split(b"\r\n")
    assert len(a) == len(b) and [i for i in range(len(a)) if a[i] != b[i]] == [6 + 5, 6 + 9]
    old5, new5 = a[11].split(b"\t"), b[11].split(b"\t")
    assert old5[:5] == new5[:5] and old5[8:] == new5[8:]  # marker B's three fields only
    assert new5[5] == f"{pos[5, 1, 0]:.8f}".encode()  # the file's 8 decimals, not the writer's 5
    assert b[15].split(b"\t")[2:5] == [b"", b"", b""]
    back = read_trc(out)
    assert np.array_equal(back.positions, np.vectorize(lambda v: float(f"{v:.8f}"))(pos), equal_nan=True)


def test_trajectories_past_num_markers_are_read_and_said(tmp_path):
    # trial11: Gait.trc states 66 markers and its rows hold 105: 10,005 cells dropped without a word
    rows = _rows(markers=3)
    path = tmp_path / "cap.trc"
    path.write_bytes(_crlf_trc(rows, labels=("A", "B"), num_markers=2))
    ms = read_trc(path)
    assert ms.labels == ("A", "B", "M003")
    assert ms.positions[4, 2].tolist() == [float(f"{v:.8f}") for v in rows[4][6:9]]
    assert ms.notes == ("the header states NumMarkers 2, the rows hold 3 trajectories: all 3 are read; 1 trajectory "
                        "without a label named M003 (M and the marker's place in the file)",)
    assert save_markers(ms, tmp_path / "out.trc").read_bytes() == path.read_bytes()
    # a file stating 0 markers: the same markers, by the same rule
    path.write_bytes(_crlf_trc(rows, labels=("A", "B"), num_markers=0))
    zero = read_trc(path)
    assert zero.labels == ms.labels and np.array_equal(zero.positions, ms.positions, equal_nan=True)
    assert zero.notes == ("1 trajectory without a label named M003 (M and the marker's place in the file)",)


def test_gait_trc_reads_every_trajectory_its_rows_hold(shared_data, tmp_path):
    gait = read_trc(_file(shared_data, f"{TRC}/Gait.trc"))
    assert gait.num_markers == 105 and int((~gait.missing()[:, 66:]).sum()) * 3 == 10005
    assert "NumMarkers 66, the rows hold 105 trajectories" in gait.notes[0]
    assert save_markers(gait, tmp_path / "g.trc").read_bytes() == (shared_data / TRC / "Gait.trc").read_bytes()


def test_fields_past_the_last_marker_are_said_and_kept_in_a_trc(tmp_path):
    # trial11: t3_extracol.trc's extra column '42' on each row was dropped silently
    path = tmp_path / "cap.trc"
    text = _crlf_trc(_rows(frames=5)).replace(b"\t\r\n", b"\t42\r\n")
    header_end = text.index(b"\r\n\r\n") + 4
    path.write_bytes(text[:header_end].replace(b"\t42\r\n", b"\t\r\n") + text[header_end:])
    ms = read_trc(path)
    assert ms.num_markers == 2
    assert ms.notes == ("5 rows hold fields past the last marker's X Y Z (line 7: field 9, 42): not coordinates, not "
                        "read; a TRC written from this take keeps them",)
    pos = np.array(ms.positions)
    pos[2, 0] += 1.0
    out = save_markers(ms.with_positions(pos), tmp_path / "out.trc").read_bytes().split(b"\r\n")
    assert all(line.endswith(b"\t42") for line in out[6:11])


def test_the_first_frame_number_and_time_are_kept(tmp_path):
    # trial11: t1_offset.trc (Frame# from 101, Time from 3.333) was written with times from 0
    path = tmp_path / "cap.trc"
    path.write_bytes(_crlf_trc(_rows(), first=101, t0=100 / 30))
    ms = read_trc(path)
    assert ms.source.first_frame == 101
    assert save_markers(ms, tmp_path / "same.trc").read_bytes() == path.read_bytes()
    for out in (save_markers(ms.select(["B"]), tmp_path / "b.trc"),  # a new file: its times go on from the file's
                save_markers(load_markers(save_markers(ms, tmp_path / "c.c3d")), tmp_path / "c.trc")):
        row = out.read_text().splitlines()[6].split("\t")
        assert row[0] == "101" and float(row[1]) == pytest.approx(100 / 30, abs=1e-3), out.name


def test_a_frame_the_file_skips_is_read_as_missing_and_said(tmp_path):
    # trial11: t2_skip.trc (Frame# 1..40, 42..89) was renumbered 1..88: frame 42 written as 41, at 1.333 s
    rows = _rows(frames=12)
    path = tmp_path / "cap.trc"
    text = _crlf_trc(rows).split(b"\r\n")
    del text[6 + 4]  # frame 5
    path.write_bytes(b"\r\n".join(text))
    ms = read_trc(path)
    assert ms.num_frames == 12 and ms.missing()[4].all() and not ms.missing()[[3, 5]].any()
    assert ms.positions[5, 0, 0] == float(f"{rows[5][0]:.8f}")
    assert ms.notes == ("the Frame# column skips frame 5 (at line 11): read as 1 frame with every marker missing, "
                        "so every frame keeps its time",)
    out = save_markers(ms, tmp_path / "out.trc").read_bytes().split(b"\r\n")
    assert out[6 + 4].split(b"\t")[:2] == [b"5", b"0.133"] and out[6 + 5] == text[6 + 4]
    assert out[2].split(b"\t")[2] == b"   12"  # NumFrames counts the frame inserted
    # a Frame# that goes back, its Time a frame on, is read by its time (this was refused: review4 D-TRC3)
    text[6 + 6] = b"3" + text[6 + 6][1:]  # frame 8 (line 13) numbered 3
    path.write_bytes(b"\r\n".join(text))
    ms = read_trc(path)
    assert ms.num_frames == 12 and ms.missing()[4].all() and not ms.missing()[[3, 5, 7]].any()
    assert ms.notes[0].startswith("the Frame# column is not consecutive (Frame# 3 follows 7, line 13) but the Time")
    assert "the Time column skips frame: 1 after 0.100 s (at line 11)" in ms.notes[1]
    assert save_markers(ms, tmp_path / "same.trc").read_bytes().split(b"\r\n")[6 + 7] == text[6 + 6]
    # a Time that goes back is refused in one line naming it
    text[6 + 6] = b"8\t0.100" + text[6 + 6][len(b"3\t0.233"):]
    path.write_bytes(b"\r\n".join(text))
    with pytest.raises(MocapFormatError, match="time 0.100 follows 0.200: the Time column goes back") as exc:
        read_trc(path)
    assert exc.value.line == 13


def _timed_trc(frames, times, rate=100, decimals=5, numframes=None):
    """A TRC text with Frame# texts ``frames`` and Time ``times`` (numbers, or texts as they are), 2 markers."""
    head = ["PathFileType\t4\t(X/Y/Z)\tx.trc", "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits",
            f"{rate}\t{rate}\t{len(frames) if numframes is None else numframes}\t2\tmm", "Frame#\tTime\tA\t\t\tB",
            "\t\tX1\tY1\tZ1\tX2\tY2\tZ2", ""]
    rows = [f"{f}\t{t if isinstance(t, str) else f'{t:.{decimals}f}'}\t{i}.5\t2.0\t3.0\t4.0\t5.0\t{i}.25"
            for i, (f, t) in enumerate(zip(frames, times))]
    return "\n".join(head + rows) + "\n"


def test_a_frame_inserted_on_write_gets_the_files_time(tmp_path):
    # review4 D-TRC1: Frame# 11, 12, 14 at Time 0.10, 0.11, 0.13 came back with "13  0.02000" (counted from 0)
    path = tmp_path / "t0.trc"
    path.write_text(_timed_trc([11, 12, 14, 15], [0.10, 0.11, 0.13, 0.14]))
    ms = read_trc(path)
    assert ms.num_frames == 5 and ms.missing()[2].all() and ms.source.first_frame == 11
    out = save_markers(ms, tmp_path / "out.trc", overwrite=True).read_text().splitlines()
    assert out[8] == "13\t0.12000\t\t\t\t\t\t" and out[2].split("\t")[2] == "5"
    pos = np.array(ms.positions)
    pos[2] = [[9, 9, 9], [8, 8, 8]]  # the inserted frame filled
    out = save_markers(ms.with_positions(pos), tmp_path / "filled.trc").read_text().splitlines()
    assert out[8].split("\t")[:3] == ["13", "0.12000", "9.00000"]
    assert out[6:8] + out[9:] == path.read_text().splitlines()[6:]
    back = read_trc(tmp_path / "filled.trc")
    assert back.notes == () and np.array_equal(back.positions, pos, equal_nan=True)
    # two frames skipped at 30 fps (times k / 30 to 3 decimals): the times of frames 102 and 103, not 3.333 + 1/30
    path.write_text(_timed_trc([101, 104], [100 / 30, 103 / 30], rate=30, decimals=3))
    out = save_markers(read_trc(path), tmp_path / "out.trc", overwrite=True).read_text().splitlines()
    assert [r.split("\t")[:2] for r in out[6:]] == [["101", "3.333"], ["102", "3.367"], ["103", "3.400"], ["104", "3.433"]]


def test_rows_a_frame_apart_in_time_are_consecutive_frames_whatever_their_frame_number(tmp_path):
    # review4 D-TRC2: a thinned export numbered by camera frame (1, 3, 5 ...) at Time steps of 1/DataRate was read
    # as twice the frames, every other one missing
    path = tmp_path / "thin.trc"
    path.write_text(_timed_trc([1, 3, 5, 7, 9], [i / 60 for i in range(5)], rate=60))
    ms = read_trc(path)
    assert ms.num_frames == 5 and not ms.missing().any() and ms.source.first_frame == 1
    assert ms.positions[:, 0, 0].tolist() == [0.5, 1.5, 2.5, 3.5, 4.5]
    assert ms.notes == ("the Frame# column is not consecutive (Frame# 3 follows 1, line 8) but the Time column steps "
                        "by 1/DataRate: the rows are placed by their time (Frame# kept as the file has it)",)
    assert save_markers(ms, tmp_path / "same.trc", overwrite=True).read_bytes() == path.read_bytes()
    pos = np.array(ms.positions)
    pos[2, 1, 2] = 7.0
    out = save_markers(ms.with_positions(pos), tmp_path / "out.trc", overwrite=True).read_text().splitlines()
    assert out[8].split("\t")[:2] == ["5", "0.03333"] and out[8].endswith("\t7.00000")  # Frame# text kept
    # where the Time column itself skips (2/60 s), one frame is inserted; its Frame# goes on in the file's steps
    path.write_text(_timed_trc([1, 3, 5, 9], [0, 1 / 60, 2 / 60, 4 / 60], rate=60))
    ms = read_trc(path)
    assert ms.num_frames == 5 and ms.missing()[3].all() and not ms.missing()[[0, 1, 2, 4]].any()
    assert ms.notes[1] == ("the Time column skips frame: 1 after 0.03333 s (at line 10): read as 1 frame with every "
                           "marker missing, so every frame keeps its time")
    out = save_markers(ms, tmp_path / "out.trc", overwrite=True).read_text().splitlines()
    assert out[9].split("\t")[:2] == ["7", "0.05000"] and out[2].split("\t")[2] == "5"
    assert read_trc(tmp_path / "out.trc").num_frames == 5


@pytest.mark.parametrize("frames", [["1"] * 5, ["1", "2", "3", "1", "2"], ["1.0", "1.5", "2.0", "2.5", "3.0"],
                                    ["", "", "", "", ""]])
def test_a_frame_number_that_repeats_restarts_or_is_fractional_is_read_by_its_time(tmp_path, frames):
    # review4 D-TRC3: these were refused ("the Frame# column must increase")
    path = tmp_path / "f.trc"
    path.write_text(_timed_trc(frames, [2 + i / 100 for i in range(5)]))
    ms = read_trc(path)
    assert ms.num_frames == 5 and not ms.missing().any() and ms.positions[:, 0, 0].tolist() == [0.5, 1.5, 2.5, 3.5, 4.5]
    assert len(ms.notes) == 1 and "the rows are placed by their time" in ms.notes[0]
    assert save_markers(ms, tmp_path / "same.trc", overwrite=True).read_bytes() == path.read_bytes()


@pytest.mark.parametrize("times, line, reason", [
    ([0, 0.01, 0.02, 0.01, 0.04], 10, "time 0.01000 follows 0.02000: the Time column goes back"),
    ([0, 0.01, 0.01, 0.02, 0.03], 9, "time 0.01000 follows 0.01000: the Time column repeats"),
    ([0, 0.01, 0.025, 0.035, 0.045], 9, "time 0.02500 follows 0.01000: a step of 1.5 frames at DataRate 100, not a "
                                        "whole number of frames"),
])
def test_a_time_out_of_step_is_refused_in_one_line_naming_it(tmp_path, times, line, reason):
    path = tmp_path / "t.trc"
    path.write_text(_timed_trc([1, 2, 3, 4, 5], times))
    with pytest.raises(MocapFormatError, match=reason) as exc:
        read_trc(path)
    assert exc.value.line == line and str(exc.value).startswith(str(path)) and "\n" not in str(exc.value)


def test_without_a_usable_time_column_frame_numbers_then_row_order_place_the_rows(tmp_path):
    path = tmp_path / "f.trc"
    # no times: Frame# places the rows, a skip inserts a frame, timed between its neighbours (none here)
    path.write_text(_timed_trc([1, 2, 4, 5], [""] * 4, numframes=5))
    ms = read_trc(path)
    assert ms.num_frames == 5 and ms.missing()[2].all()
    assert ms.notes == ("the Frame# column skips frame 3 (at line 9): read as 1 frame with every marker missing, "
                        "so every frame keeps its time",)
    assert save_markers(ms, tmp_path / "out.trc", overwrite=True).read_text().splitlines()[8] == "3\t\t\t\t\t\t\t"
    # times in milliseconds: Frame# places the rows, said; an inserted row's time is spaced between its neighbours'
    path.write_text(_timed_trc([1, 2, 4, 5], [10, 20, 40, 50], numframes=5))
    ms = read_trc(path)
    assert ms.num_frames == 5 and ms.missing()[2].all()
    assert ms.notes[0] == ("the Time column does not step by 1/DataRate (0.01 s; its steps are mostly 10 s): the rows "
                           "are placed by their Frame#")
    out = save_markers(ms, tmp_path / "out.trc", overwrite=True).read_text().splitlines()
    assert out[8].split("\t")[:2] == ["3", "30.00000"]
    # neither: Frame# repeats and no times: the rows in file order, said
    path.write_text(_timed_trc([1, 2, 2, 3], [""] * 4))
    ms = read_trc(path)
    assert ms.num_frames == 4 and not ms.missing().any() and ms.positions[:, 0, 0].tolist() == [0.5, 1.5, 2.5, 3.5]
    assert ms.notes == ("the Frame# column is not whole numbers that increase (Frame# 2 follows 2, line 9) and the "
                        "Time column has rows without a time: the rows are read in file order as consecutive frames",)
    assert save_markers(ms, tmp_path / "same.trc", overwrite=True).read_bytes() == path.read_bytes()
    # a Frame# that is text, not a number, is still refused
    path.write_text(_timed_trc([1, "x", 3], [0, 0.01, 0.02]))
    with pytest.raises(MocapFormatError, match="frame number 'x' is not a number"):
        read_trc(path)


def test_a_repeated_label_is_written_as_the_file_has_it(tmp_path):
    # trial11: t5_dup.trc's second RFHD was written as RFHD_2
    path = tmp_path / "cap.trc"
    path.write_bytes(_crlf_trc(_rows(markers=3), labels=("RFHD", "C7", "RFHD")))
    ms = read_trc(path)
    assert ms.labels == ("RFHD", "C7", "RFHD_2") and "the repeats are called RFHD_2 here" in ms.notes[0]
    pos = np.array(ms.positions)
    pos[3, 2] += 0.5
    out = save_markers(ms.with_positions(pos), tmp_path / "out.trc", overwrite=True)
    assert out.read_text().splitlines()[3].split("\t")[2::3] == ["RFHD", "C7", "RFHD", ""]
    c3d = load_markers(save_markers(ms, tmp_path / "out.c3d"))
    assert c3d.labels == ms.labels and c3d.notes == ms.notes


def test_every_shared_trc_written_back_unchanged_is_byte_identical(shared_data, tmp_path):
    files = sorted((shared_data / TRC).glob("*.trc")) + sorted((shared_data / PEER_TRC).glob("*.trc"))
    done = 0
    for f in files:
        try:
            ms = read_trc(f)
        except MocapFormatError:
            continue
        assert save_markers(ms, tmp_path / f.name, overwrite=True).read_bytes() == f.read_bytes(), f.name
        done += 1
    assert done >= 12


def test_a_file_without_a_final_line_break_comes_back_without_one(tmp_path):
    path = tmp_path / "v.trc"
    path.write_bytes(_trc_text(end="").encode())
    ms = read_trc(path)
    assert save_markers(ms, tmp_path / "same.trc", overwrite=True).read_bytes() == path.read_bytes()
    pos = np.array(ms.positions)
    pos[-1, 0] += 1.0
    text = save_markers(ms.with_positions(pos), tmp_path / "changed.trc").read_text()
    assert not text.endswith("\n") and text.splitlines()[-1].split("\t")[2] == f"{pos[-1, 0, 0]:.5f}"


def test_a_c3d_with_an_empty_and_a_repeated_label_converts_to_trc_and_back(tmp_path):
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = np.array([100.0])
    c["parameters"]["POINT"]["LABELS"]["value"] = ("A", "", "A")
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]  # stated: these points fit no unit by their span
    pts = np.ones((4, 3, 5))
    pts[:3] = np.arange(45).reshape(3, 3, 5) + 1.0
    c["data"]["points"] = pts
    c.write(str(tmp_path / "e.c3d"))
    ms = load_markers(tmp_path / "e.c3d")
    assert ms.labels == ("A", "M002", "A_2")
    trc = save_markers(ms, tmp_path / "e.trc")
    assert trc.read_text().splitlines()[3].split("\t")[2::3] == ["A", "", "A"]
    back = save_markers(load_markers(trc), tmp_path / "back.c3d")
    assert list(ezc3d.c3d(str(back))["parameters"]["POINT"]["LABELS"]["value"]) == ["A", "", "A"]


def test_a_take_keeps_its_frame_numbers_and_camera_rate_through_a_write(tmp_path):
    """A TRC whose frames start at 101 (a trimmed capture) is written with frames 101.., not renumbered from 1,
    and its CameraRate is kept: what lines the take up with its video and analog data."""
    write_trc(_markers(), tmp_path / "a.trc")
    lines = (tmp_path / "a.trc").read_text().splitlines()
    head = lines[2].split("\t")
    head[1] = "120.00"  # CameraRate
    lines[2] = "\t".join(head)
    for i in range(6, len(lines)):
        row = lines[i].split("\t")
        row[0] = str(int(row[0]) + 100)
        lines[i] = "\t".join(row)
    src = tmp_path / "trimmed.trc"
    src.write_text("\n".join(lines) + "\n")
    ms = read_trc(src)
    assert ms.source.first_frame == 101
    write_trc(ms, tmp_path / "out.trc")
    out = (tmp_path / "out.trc").read_text().splitlines()
    assert [r.split("\t")[0] for r in out[6:]] == [str(101 + i) for i in range(ms.num_frames)]
    assert out[2].split("\t")[1] == "120.00"
    assert read_trc(tmp_path / "out.trc").source.first_frame == 101


def test_an_empty_take_is_refused_and_nothing_written(tmp_path):
    empty = _markers()[:0]
    with pytest.raises(MocapFormatError, match="at least one marker and one frame"):
        write_trc(empty, tmp_path / "e.trc")
    assert not (tmp_path / "e.trc").exists()


def test_a_column_without_a_label_is_an_unlabelled_trajectory_and_stays_one(tmp_path):
    # trial14: Gait.trc's 72 columns past its 33 labels were kept in source.labels as M034..M105, names the file
    # does not give them: written anew (a part of the take) or to npz, they became labelled markers
    rows = _rows(markers=3)
    path = tmp_path / "cap.trc"
    path.write_bytes(_crlf_trc(rows, labels=("A", "B"), num_markers=2))
    ms = read_trc(path)
    assert ms.labels == ("A", "B", "M003") and ms.source.labels == ("A", "B", "")
    assert ms.unlabelled().tolist() == [False, False, True]
    part = save_markers(ms[2:], tmp_path / "part.trc")  # a part of the take: written anew
    assert part.read_text().splitlines()[3].split("\t")[2::3] == ["A", "B"]
    for out in (part, save_markers(ms, tmp_path / "t.npz")):
        back = load_markers(out)
        assert back.labels == ms.labels and back.unlabelled().tolist() == [False, False, True], out.name


def _blank_units(src, dst, scale=None, tmp=None):
    """``src`` TRC copied to ``dst`` with its Units field emptied; with ``scale``, first rewritten (by the TRC
    writer) with every coordinate times ``scale`` and the unit that makes (mm * 0.001: m)."""
    if scale is not None:
        ms = read_trc(src)
        unit = {0.001: "m", 0.1: "cm", 1.0: "mm"}[scale]
        scaled = MarkerSet(labels=ms.labels, positions=ms.positions * scale, fps=ms.fps, units=unit, name=ms.name)
        src = tmp / f"scaled_{unit}.trc"
        write_trc(scaled, src, decimals=8)
    lines = src.read_text().split("\n")
    keys, values = lines[1].split("\t"), lines[2].split("\t")
    values[keys.index("Units")] = ""
    lines[2] = "\t".join(values)
    dst.write_text("\n".join(lines))
    return dst


@pytest.mark.parametrize("name", ["Gait.trc", "SprintMotion.trc", "T.trc"])
def test_a_trc_that_states_no_unit_is_read_in_the_unit_its_marker_distances_fit(shared_data, tmp_path, name):
    src = _file(shared_data, f"{TRC}/{name}")
    stated = read_trc(src)
    assert (stated.units, stated.units_from) == ("mm", "file")
    mm = read_trc(_blank_units(src, tmp_path / "mm.trc"))
    assert (mm.units, mm.units_from) == ("mm", "data")
    np.testing.assert_array_equal(mm.positions, stated.positions)
    m = read_trc(_blank_units(src, tmp_path / "m.trc", scale=0.001, tmp=tmp_path))
    assert (m.units, m.units_from) == ("m", "data")  # read as mm before: a body 1.8 mm tall
    np.testing.assert_allclose(m.positions * 1000, stated.positions, atol=1e-4)
    assert read_trc(tmp_path / "m.trc", units="m").units_from == "given"


def test_a_unit_the_data_cannot_tell_is_asked_for_and_a_given_one_must_agree_with_the_file(shared_data, tmp_path):
    src = _file(shared_data, f"{TRC}/Gait.trc")
    cm = _blank_units(src, tmp_path / "cm.trc", scale=0.1, tmp=tmp_path)  # 1.2 m spans 120 units: neither mm nor m
    msg = refusal_of_load(cm)
    assert msg == (f"{cm}: the file states no length unit and its marker distances fit neither mm nor m; "
                   "name it with --unit mm|cm|m|in (Python: units=)")
    ms = read_trc(cm, units="cm")
    assert (ms.units, ms.units_from, ms.unit_cm) == ("cm", "given", 1.0)
    with pytest.raises(MocapFormatError, match=r"Gait\.trc: the file states its unit is 'mm', not 'm': a unit is given only for a file that states none"):
        read_trc(src, units="m")
    assert read_trc(src, units="mm").units_from == "file"


def test_a_take_read_in_an_inferred_unit_is_written_back_byte_for_byte(shared_data, tmp_path):
    src = _blank_units(_file(shared_data, f"{TRC}/T.trc"), tmp_path / "t.trc", scale=0.001, tmp=tmp_path)
    ms = read_trc(src)
    assert ms.units == "m"
    out = tmp_path / "out.trc"
    save_markers(ms, out)
    assert out.read_bytes() == src.read_bytes()  # the empty Units field kept, every row the file's


def test_a_c3ds_modelled_quantities_are_left_out_of_a_trc_and_named(shared_data, tmp_path):
    """A TRC holds markers under one unit (OpenSim reads every point as one): Plug-in Gait's angles (deg), forces,
    moments and powers were written as 80 'markers' under Units mm."""
    from mocapkit.io import marker_notes

    ms = load_markers(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d")
    kinds = ms.quantities()
    assert {k: int(np.sum(kinds == k)) for k in ("angles", "forces", "moments", "powers")} == \
        {"angles": 26, "forces": 20, "moments": 18, "powers": 16}
    assert "LHipAngles" in ms.labels and kinds[ms.labels.index("LHipAngles")] == "angles"
    save_markers(ms, tmp_path / "pig.trc")
    got = read_trc(tmp_path / "pig.trc")
    keep = [label for label, k in zip(ms.labels, kinds) if not k]
    assert got.labels == tuple(keep) and "LHipAngles" not in got.labels and "PELO" in got.labels  # positions kept
    assert np.allclose(got.positions, ms.select(keep).positions, atol=1e-5, equal_nan=True)
    assert (f"{tmp_path / 'pig.trc'}: left out 80 modelled quantities, not markers (26 angles, 20 forces, 18 moments, "
            "16 powers)") in marker_notes(ms, tmp_path / "pig.trc")[0]
    save_markers(ms, tmp_path / "all.trc", keep_modelled=True)  # asked for: every point, and no such note
    assert read_trc(tmp_path / "all.trc").labels == ms.labels
    assert not any("modelled quantities" in n for n in marker_notes(ms, tmp_path / "all.trc", keep_modelled=True))


def test_samples_a_trc_cannot_tell_from_recorded_ones_are_counted(tmp_path):
    """TRC has no residual column: a C3D's interpolated samples (residual 0) and a cleaning's fills read as recorded."""
    import mocapkit.samples
    from mocapkit.io import marker_notes

    ms = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    seen = ~ms.missing()
    interpolated = int(np.sum(seen & (ms.residuals == 0)))
    assert interpolated > 0 and np.any(ms.residuals[seen] > 0)
    notes = marker_notes(ms, tmp_path / "x.trc")
    assert any(n.startswith(f"{tmp_path / 'x.trc'}: {interpolated} samples the input marks as interpolated") for n in notes)
    filled = ms.missing()
    notes = marker_notes(ms, tmp_path / "x.trc", filled=filled, record=tmp_path / "x.clean.npz")
    assert (f"{tmp_path / 'x.trc'}: {int(filled.sum())} samples the cleaning wrote (gaps filled, spikes and duplicates replaced) are written like recorded ones: a TRC has no "
            f"residual column to tell them apart; {tmp_path / 'x.clean.npz'} lists them") in "\n".join(notes)
    assert not any("samples the cleaning wrote" in n or "interpolated" in n for n in marker_notes(ms, tmp_path / "x.c3d"))


@pytest.mark.parametrize("keep", [True, False])
def test_a_trc_written_from_a_c3d_says_which_points_are_modelled_and_cleaning_leaves_them(shared_data, tmp_path, keep):
    """A TRC has no POINT groups nor camera masks: Plug-in Gait's angles, forces, moments and powers written with
    --keep-modelled, and its modelled positions (segment axes, joint centres, centre of mass; kept either way) read
    back as markers and were cleaned as such. The header's ModelledPoints field states them; read back and cleaned,
    every modelled point comes back as read."""
    from mocapkit.cleaning.markers import clean_markers

    ms = load_markers(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d")
    out = tmp_path / "pig.trc"
    save_markers(ms, out, keep_modelled=keep)
    back = read_trc(out)
    cols = np.isin(back.labels, [label for label, m in zip(ms.labels, ms.modelled()) if m])
    assert int(cols.sum()) == (158 if keep else 78)
    res = clean_markers(back)
    assert np.array_equal(res.markers.positions[:, cols], back.positions[:, cols], equal_nan=True)
    assert res.changed[:, ~cols].any()  # the markers themselves are cleaned
    assert np.array_equal(back.modelled(), cols)
    want = dict(zip(ms.labels, ms.modelled_kinds()))
    assert back.modelled_kinds().tolist() == [want[label] for label in back.labels]
    save_markers(res.markers, tmp_path / "again.trc", keep_modelled=keep)  # the field kept through a TRC written from it
    assert np.array_equal(read_trc(tmp_path / "again.trc").modelled(), cols)


def test_a_bad_modelled_points_field_is_refused_in_one_line(tmp_path):
    text = ("PathFileType\t4\t(X/Y/Z)\tx.trc\nDataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tModelledPoints\n"
            "100\t100\t2\t2\tmm\t{}\nFrame#\tTime\tA\t\t\tB\nX1\tY1\tZ1\tX2\tY2\tZ2\n\n"
            "1\t0.00\t1\t2\t3\t4\t5\t6\n2\t0.01\t1\t2\t3\t4\t5\t6\n")
    (tmp_path / "ok.trc").write_text(text.format("angles=2"))
    assert read_trc(tmp_path / "ok.trc").quantities().tolist() == ["", "angles"]
    for bad, why in (("angles=3", "out of the file's 1-2"), ("angels=1", "unknown kind"), ("angles=x", "not a marker")):
        (tmp_path / "bad.trc").write_text(text.format(bad))
        with pytest.raises(MocapFormatError, match=why):
            read_trc(tmp_path / "bad.trc")


def test_a_trc_written_new_states_the_unit_s_symbol_where_the_input_spelt_it_otherwise(tmp_path):
    """Trial: c3d.org's FP1.C3D states POINT:UNITS "mete" (a 4-character field); `convert FP1.C3D fp1.trc` wrote
    Units "mete", which OpenSim and Motion Analysis do not read as metres. Eb015pr.c3d in metres, so spelt; a
    TRC's own spelling stays as it was."""
    import dataclasses

    import mocapkit.samples

    src = load_markers(mocapkit.samples.path("Eb015pr.c3d"))[:20]
    metres = dataclasses.replace(src, positions=src.positions / 1000, units="mete")
    out = save_markers(metres, tmp_path / "m.trc")
    header = out.read_text().splitlines()
    assert header[2].split("\t")[header[1].split("\t").index("Units")] == "m"
    back = load_markers(out)
    assert back.units == "m" and np.array_equal(back.positions, np.round(metres.positions, 5), equal_nan=True)
    spelt = tmp_path / "spelt.trc"
    spelt.write_text(out.read_text().replace("\tm\t", "\tmeters\t", 1))
    again = save_markers(load_markers(spelt).select(list(src.labels[:3])), tmp_path / "again.trc")
    assert again.read_text().splitlines()[2].split("\t")[4] == "meters"


def test_a_c3d_written_from_a_trc_says_it_rounds_the_coordinates_to_32_bit_floats(shared_data, tmp_path):
    """T.trc states 5 decimals of a mm; a C3D stores 32-bit floats (1639.63722 -> 1639.6372 mm): every coordinate
    is rounded, up to 6.1e-05 mm (5,521 come back another number at 5 decimals in a TRC written from the C3D),
    which no line said before 0.15.0. A take read from a C3D holds 32-bit floats already: no line."""
    import mocapkit.samples
    from mocapkit.io import marker_notes

    path = _file(shared_data, f"{TRC}/T.trc")
    ms = read_trc(path)
    out = tmp_path / "T.c3d"
    notes = [n for n in marker_notes(ms, out, path) if "32-bit" in n]
    assert notes == [f"{out}: C3D stores coordinates as 32-bit floats: 10,947 of 10,947 coordinates of {path} are "
                     "rounded to the nearest, up to 6.1e-05 mm off (a .trc or .npz output keeps them)"]
    back = load_markers(save_markers(ms, out))
    assert np.max(np.abs(back.positions - ms.positions)) == pytest.approx(6.1e-05, abs=5e-7)
    c3d = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    assert not any("32-bit" in n for n in marker_notes(c3d, tmp_path / "x.c3d"))


def test_a_changed_row_keeps_its_own_width_and_trailing_tab(tmp_path):
    # trialT3 8: a changed row was padded to the widest row's fields (Gait.trc: 102 -> 317), so a diff showed
    # every changed row rewritten whole; only the changed samples' fields are, extended no further than needed
    rows = _rows(frames=20, markers=3)
    lines = _crlf_trc(rows, labels=("A", "B", "C")).split(b"\r\n")
    for i in range(6 + 10, 6 + 20):  # rows 10-19 end after B's Z (and its tab): C is missing there
        lines[i] = b"\t".join(lines[i].split(b"\t")[:8]) + b"\t"
    path = tmp_path / "cap.trc"
    path.write_bytes(b"\r\n".join(lines))
    ms = read_trc(path)
    assert ms.missing()[10:, 2].all() and not ms.missing()[:10].any()
    pos = np.array(ms.positions)
    pos[12, 1] += 0.001  # inside the short row
    pos[15, 2] = pos[9, 2]  # C filled past the short row's end
    pos[3, 0] += 0.001  # a full row
    b = save_markers(ms.with_positions(pos), tmp_path / "out.trc").read_bytes().split(b"\r\n")
    assert [i - 6 for i in range(len(lines)) if lines[i] != b[i]] == [3, 12, 15]
    assert [len(b[6 + r].split(b"\t")) for r in (3, 12, 15)] == [12, 9, 11]  # own width; C's 3 fields and no more
    assert b[6 + 12].endswith(b"\t") and b[6 + 12].split(b"\t")[:5] == lines[6 + 12].split(b"\t")[:5]
    back = read_trc(tmp_path / "out.trc")
    assert np.allclose(back.positions[15, 2], pos[15, 2], atol=1e-8) and back.missing()[16:, 2].all()


def test_gait_trc_changed_rows_keep_their_own_width(shared_data, tmp_path):
    # trialT3 8 on the file it was found on: rows of 102 fields (33 markers and a trailing tab) of the 317 widest
    src = _file(shared_data, f"{TRC}/Gait.trc")
    gait = read_trc(src)
    a = src.read_bytes().split(b"\n")
    short = next(r for r in range(gait.num_frames) if len(a[6 + r].split(b"\t")) == 102)
    pos = np.array(gait.positions)
    pos[short, 0] += 1.0  # a sample inside the row
    b = save_markers(gait.with_positions(pos), tmp_path / "g.trc").read_bytes().split(b"\n")
    assert [i for i in range(len(a)) if a[i] != b[i]] == [6 + short]
    old, new = a[6 + short].split(b"\t"), b[6 + short].split(b"\t")
    assert len(new) == 102 and old[:2] == new[:2] and old[5:] == new[5:]
