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
    ("Gait.trc", 487, 66, 100.0, "R.Shoulder", "M066"),  # 33 labels over 66 stated markers
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
    assert gait.missing()[0].all()  # frame 1 is all empty fields
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
     "DataRate must be a positive number from 1 to 1000 (frames per second), got 0.0", 3),
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
    # both paths exercised (44 read: mutants that lose rows are refused as cut short since NumFrames is checked)
    assert outcomes["ok"] > 30 and outcomes["refused"] > 50


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
