"""What a marker file holds besides its trajectories (``mocapkit info``'s lines), on real captures."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit.samples
from mocapkit.io import load_markers
from mocapkit.io.c3d_contents import marker_file_contents

CMU = Path(__file__).resolve().parents[1] / "data" / "85_02.c3d"


def test_a_c3d_with_analogs_force_plates_and_header_events():
    rows = dict(marker_file_contents(load_markers(mocapkit.samples.path("Eb015pr.c3d"))))
    assert rows == {"analogs": "16 channels at 200 Hz", "force plates": "2 (type 2)",
                    "events": "3 (1 RIC, 1 RHS, 1 RTO)"}


def test_only_what_is_present_is_listed():
    assert marker_file_contents(load_markers(CMU)) == []  # no analogs, plates or events; frames from 1
    assert marker_file_contents(dataclasses.replace(load_markers(CMU), source=None)) == []  # read from no file


def test_functional_walk_starts_at_frame_480_with_36_analogs_at_1080_hz(shared_data):
    rows = dict(marker_file_contents(load_markers(shared_data / "c3d_markers" / "FunctionalWalk.c3d")))
    assert rows["first frame"] == "480"
    assert rows["analogs"] == "36 channels at 1080 Hz"
    assert rows["force plates"] == "3 (type 2)"
    assert rows["events"] == "11 (6 Foot Strike, 5 Foot Off)"


def test_written_like_another_trial_keeps_no_force_plates_nor_events(tmp_path):
    # trial 2026-12-06: 85_02's markers written like Eb015pr.c3d listed Eb015pr's 2 force plates (their 16
    # analog channels not written: another trial's frames) and its 3 gait events (another trial's times)
    import ezc3d

    from mocapkit.io import save_markers

    out = save_markers(load_markers(CMU), tmp_path / "x.c3d", like=mocapkit.samples.path("Eb015pr.c3d"))
    assert marker_file_contents(load_markers(out)) == []
    c = ezc3d.c3d(str(out))  # ezc3d reads it back: no plate, no event, the 810 frames
    assert list(c["parameters"]["FORCE_PLATFORM"]["USED"]["value"]) == [0]
    assert load_markers(out).source.events == ()
    assert c["data"]["points"].shape[2] == 810


def test_a_crop_keeps_its_analogs_plates_and_the_events_inside_it(tmp_path):
    from mocapkit.io import save_markers

    take = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    crop = dict(marker_file_contents(load_markers(save_markers(take[100:300], tmp_path / "crop.c3d"))))
    assert crop["force plates"] == "2 (type 2)"  # frames 101-300 (2.0-5.98 s): RTO at 7.32 s is outside
    assert crop["events"] == "2 (1 RIC, 1 RHS)"
    same = dict(marker_file_contents(load_markers(save_markers(take, tmp_path / "same.c3d",
                                                              like=mocapkit.samples.path("Eb015pr.c3d")))))
    assert same == dict(marker_file_contents(take))  # its own file as like=: every plate and event kept


def test_a_crop_written_like_its_whole_file_keeps_the_events_inside_it(tmp_path):
    # 2026-12-06: take[100:300] written like=Eb015pr.c3d (its own file, 450 frames) lost all 3 events, its analogs
    # and its plates (the file was taken for another trial: another first frame and length); now it is the file
    # without like=, byte for byte: frames 101-300 (2.0-5.98 s) keep RIC (2.72 s) and RHS (5.40 s), not RTO (7.32 s)
    import ezc3d

    from mocapkit.io import save_markers

    path = mocapkit.samples.path("Eb015pr.c3d")
    take = load_markers(path)
    alone = save_markers(take[100:300], tmp_path / "alone.c3d")
    for like in (path, take):
        out = save_markers(take[100:300], tmp_path / "like.c3d", like=like, overwrite=True)
        assert out.read_bytes() == alone.read_bytes()
        crop = load_markers(out)
        assert [(round(t, 2), label) for t, label, _ in crop.source.events] == [(2.72, "RIC "), (5.40, "RHS ")]
        assert dict(marker_file_contents(crop))["force plates"] == "2 (type 2)"
        c = ezc3d.c3d(str(out))  # ezc3d reads it back: frame 101 first (0-based 100), the 200 frames, 2 events
        assert c["header"]["points"]["first_frame"] == 100 and c["data"]["points"].shape[2] == 200
        assert list(c["header"]["events"]["events_time"][:2]) == pytest.approx([2.72, 5.40])


def test_another_trial_of_the_same_rate_start_and_length_keeps_no_events(tmp_path):
    # Eb015pr's markers 200 frames on (another moment of the gait, as another trial would hold): same rate, first
    # frame and length as Eb015pr.c3d, which was enough to take its 3 events; the samples disagree, so none is kept.
    # The take itself moved by 0.3 mm everywhere (a smoothing) is still the file's trial and keeps all 3.
    from mocapkit.io import save_markers

    path = mocapkit.samples.path("Eb015pr.c3d")
    take = load_markers(path)
    other = take.with_positions(np.roll(take.positions, 200, axis=0))
    out = save_markers(other, tmp_path / "other.c3d", like=path)
    assert load_markers(out).source.events == ()
    moved = take.with_positions(take.positions + 0.3 / np.sqrt(3))
    out = save_markers(moved, tmp_path / "moved.c3d", like=path)
    assert load_markers(out).source.events == take.source.events


def test_an_event_past_the_file_s_last_frame_is_kept_while_the_take_reaches_it(shared_data, tmp_path):
    # c3d.org's FP1.C3D (480 frames at 60 Hz: 0 to 7.98 s) lists L. E at 8.0 s, past its last frame: written back
    # whole it was lost. Only a crop that cuts the file's end (frames 1-240) leaves it out now.
    from mocapkit.io import save_markers

    take = load_markers(shared_data / "peer_files" / "BTKData" / "Input" / "C3DSamples" / "c3d.org" / "sample15"
                        / "FP1.C3D")
    assert [t for t, _, _ in take.source.events] == pytest.approx([0.0, 8.0, 1 / 30, 0.0])
    whole = load_markers(save_markers(take, tmp_path / "whole.c3d"))
    assert whole.source.events == take.source.events
    head = load_markers(save_markers(take[:240], tmp_path / "head.c3d"))
    assert [label for _, label, _ in head.source.events] == ["R. I", "L. I", "R. E"]
    tail = load_markers(save_markers(take[240:], tmp_path / "tail.c3d"))
    assert [label for _, label, _ in tail.source.events] == ["L. E"]


def test_a_file_s_own_plates_are_kept_as_it_has_them(shared_data, tmp_path):
    # BTK's shd01.c3d holds 6 analog channels and states 2 plates, the second on channels 8-13: written back
    # unchanged, both plates were left out (USED 0) as if its channels had been dropped; every channel is written
    import ezc3d

    from mocapkit.io import save_markers

    path = shared_data / "peer_files" / "BTKData" / "Input" / "C3DSamples" / "others" / "shd01.c3d"
    out = save_markers(load_markers(path), tmp_path / "shd01.c3d")
    before, after = (ezc3d.c3d(str(p))["parameters"]["FORCE_PLATFORM"] for p in (path, out))
    for key in ("USED", "CHANNEL", "TYPE", "CORNERS", "ORIGIN"):
        assert np.array_equal(after[key]["value"], before[key]["value"]), key
