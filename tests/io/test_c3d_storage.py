"""C3D storage written back as the file has it: byte order (big-endian SGI files written as their Intel twins) and
16-bit integer points (kept as the file's own numbers). Golden checks on c3d.org's sample01 (../shared; skipped
without it)."""

from pathlib import Path

import numpy as np
import pytest

from mocapkit.io.c3d import read_c3d


def test_a_big_endian_c3d_is_written_as_its_little_endian_twin(shared_data, tmp_path):
    # c3d.org's sample01 holds one trial as Intel (Eb015pi/pr) and SGI big-endian (Eb015si/sr) files, integer and
    # float. The big-endian ones (read by the c3d package: ezc3d reads no processor type 3) read back unequal:
    # 8,357 residuals 2e-7 mm off (the package's float32 products), and every parameter of more than one dimension
    # transposed (FORCE_PLATFORM:CHANNEL read back as plate 1 on channels 1 and 9), locks and leading spaces of
    # descriptions lost. Written, each is now byte for byte its Intel twin written (ezc3d writes Intel files only).
    import ezc3d

    from mocapkit.io import save_markers

    sample = shared_data / "peer_files" / "BTKData" / "Input" / "C3DSamples" / "c3d.org" / "sample01"
    for big, intel in (("Eb015si", "Eb015pi"), ("Eb015sr", "Eb015pr")):
        take = read_c3d(sample / f"{big}.c3d")
        assert take.reader == "c3d"
        out = save_markers(take, tmp_path / f"{big}.c3d")
        assert out.read_bytes() == save_markers(read_c3d(sample / f"{intel}.c3d"), tmp_path / f"{intel}.c3d").read_bytes()
        back = read_c3d(out)
        assert np.array_equal(back.positions, take.positions, equal_nan=True)
        assert np.array_equal(back.residuals, take.residuals) and np.array_equal(back.cameras, take.cameras)
        assert (back.labels, back.fps, back.units, back.source.events) == (take.labels, take.fps, take.units,
                                                                           take.source.events)
        assert np.array_equal(back.source.analogs, take.source.analogs)
        plates = ezc3d.c3d(str(out))["parameters"]["FORCE_PLATFORM"]
        assert plates["CHANNEL"]["value"][:, 0].tolist() == [1, 2, 3, 4, 5, 6]


def test_an_integer_c3d_is_written_back_as_its_own_16_bit_numbers(shared_data, tmp_path):
    # c3d.org's Eb015pi.c3d stores int16 * POINT:SCALE (0.0833 mm). It came back as a float file twice its size,
    # whose samples other readers (ezc3d: float64 products) read up to half a float32 step off the input's. Now
    # its data block is the input's, bit for bit; a changed sample is rounded to the file's step, and a cleaning's
    # notes say so.
    import struct

    import ezc3d

    from mocapkit.io import marker_notes, save_markers

    path = shared_data / "c3d_markers" / "Eb015pi.c3d"
    take = read_c3d(path)
    raw, got = path.read_bytes(), save_markers(take, tmp_path / "same.c3d").read_bytes()
    assert len(got) == len(raw) and struct.unpack_from("<f", got, 12)[0] == pytest.approx(1 / 12)
    block = slice(10 * 512, 10 * 512 + 450 * (4 * 26 + 16 * 4) * 2)  # data block 11 in both: 450 frames, int16
    assert got[block] == raw[block]
    step = float(np.float32(1 / 12))
    f, m = next((f, m) for f in range(100, 450) for m in range(26) if not take.missing()[f, m])
    moved = take.positions.copy()
    moved[f, m] += 0.01  # mm: 0.12 of a step
    out = save_markers(take.with_positions(moved), tmp_path / "moved.c3d")
    back = read_c3d(out)
    assert np.all(np.abs(back.positions[f, m] - moved[f, m]) <= step / 2)
    assert np.array_equal(back.positions[f, m], take.positions[f, m])  # rounded back to the step it was on
    a, b = ezc3d.c3d(str(path))["data"]["points"], ezc3d.c3d(str(out))["data"]["points"]
    seen = ~take.missing().T
    assert np.array_equal(a[:3][:, seen], b[:3][:, seen])  # every reader reads the input's values
    notes = marker_notes(take, out, path, filled=np.zeros(take.missing().shape, dtype=bool))
    assert any("16-bit integers in steps of 0.08333 mm" in note and "0.042 mm at most" in note for note in notes)
    far = take.positions.copy()
    far[f, m, 0] = 3000.0  # mm: past the 32,767 steps (2.73 m) a 16-bit number holds: the file is written as floats
    out = save_markers(take.with_positions(far), tmp_path / "far.c3d")
    assert struct.unpack_from("<f", out.read_bytes(), 12)[0] < 0
    assert np.array_equal(read_c3d(out).positions, far, equal_nan=True)
    other = read_c3d(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")  # another trial: not rounded
    out = save_markers(other, tmp_path / "other.c3d", like=path)
    assert struct.unpack_from("<f", out.read_bytes(), 12)[0] < 0


def test_a_c3d_that_states_no_unit_is_written_with_one_and_a_note_says_so(shared_data, tmp_path):
    # Trial with C3D captures: cleaning a C3D without POINT:UNITS (Motion Lab Systems' dynamic.c3d) wrote
    # `POINT:UNITS mm` without a word. The unit the take was read in is written (leaving it out would lose a unit
    # given with --unit and make every later reader guess again), and one note says what was assumed and why.
    from mocapkit.io import load_markers, marker_notes, save_markers

    path = shared_data / "c3d_markers" / "dynamic.c3d"
    for given, why in ((None, "inferred from the marker distances; --unit sets it"), ("mm", "given with --unit")):
        take = load_markers(path, units=given)
        assert "UNITS" not in take.source.parameters["POINT"] and take.units_from != "file"
        out = tmp_path / "out.c3d"
        notes = marker_notes(take, out, path)
        assert f"{out}: POINT:UNITS mm written, the unit the take was read in ({why}); {path} states no length unit" \
            in notes, notes
    back = read_c3d(save_markers(take, out))
    assert back.units == "mm" and back.units_from == "file"  # what the note says is what the file states
    assert not any("POINT:UNITS" in n for n in marker_notes(back, tmp_path / "again.c3d", out))  # stated: no note


def test_a_review_gives_the_c3d_back_byte_for_byte(tmp_path):
    # Trial T2: `clean X.c3d --steps detect` (and every change rejected) wrote the capture anew with ezc3d: another
    # parameter section and header, where the guides promise the input file back.
    from mocapkit.marker_files import clean_marker_file

    path = Path(__file__).resolve().parents[1] / "data" / "85_02.c3d"  # 85_02_det.c3d differed from byte 19
    out = tmp_path / "review.c3d"
    clean_marker_file(path, out, review=True)
    assert out.read_bytes() == path.read_bytes()


def test_an_output_that_is_the_input_says_no_unit_was_written(shared_data, tmp_path):
    # dynamic.c3d states no POINT:UNITS: its review output is its own bytes, so no note may say the unit was written
    import shutil

    from mocapkit.io import load_markers, marker_notes

    path = shared_data / "c3d_markers" / "dynamic.c3d"
    out = Path(shutil.copyfile(path, tmp_path / "out.c3d"))
    assert not any("POINT:UNITS" in n for n in marker_notes(load_markers(path), out, path))
