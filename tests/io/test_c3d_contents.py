"""What a marker file holds besides its trajectories (``mocapkit info``'s lines), on real captures."""

from __future__ import annotations

import dataclasses
from pathlib import Path

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
