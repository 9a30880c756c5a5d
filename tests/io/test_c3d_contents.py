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
