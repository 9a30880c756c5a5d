"""Labels cycled at one frame, injected into real complete captures, are undone by clean_markers.

CMU 85_02 (tests/data) and HDM05's HDM_bd_05-01_01_120 (shared data), frames 0-599: from frame 100 on (to frame
200, or to the end of the take) the labels of three to five markers move round a ring, each taking the next one's
trajectory; a three-label cycle with one of its labels unseen over frames 97-102 (only two of the three jump), or
with one of its markers unseen over those frames (only one jumps as the labels move: the cycle is found where they
move back, at frame 200).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocapkit.cleaning.markers import clean_markers, undo_swaps
from mocapkit.cleaning.markers.swaps import labelling
from mocapkit.io import load_markers

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"

CASES = {
    "four labels": (["LTOE", "RTHI", "LKNE", "LFHD"], None, False),
    "five labels": (["LTOE", "RTHI", "LKNE", "LFHD", "RELB"], None, False),
    "three labels, one hidden at the start": (["LTOE", "RTHI", "LKNE"], "LTOE", False),
    "three labels, another hidden at the start": (["LTOE", "RTHI", "LKNE"], "RTHI", False),
    "three labels, a marker occluded at the start": (["LTOE", "RTHI", "LKNE"], "LTOE", True),
    "three labels, another marker occluded at the start": (["LTOE", "RTHI", "LKNE"], "LKNE", True),
}


def _inject(x, ring, hidden, occluded, end):
    """The capture with ``ring``'s labels cycled over frames 100..end-1, ``hidden``'s label (its marker where
    ``occluded``) unseen at 97-102; and the truth: the recorded trajectories with the samples hidden left out."""
    names = [label.split(":")[-1] for label in x.labels]
    truth = np.array(x.positions, dtype=np.float64)
    cols = [names.index(n) for n in ring]
    if occluded:
        truth[97:103, names.index(hidden)] = np.nan
    q = truth.copy()
    q[100:end, cols] = q[100:end, cols[1:] + cols[:1]]
    if hidden is not None and not occluded:
        h = names.index(hidden)
        q[97:103, h] = np.nan
        truth[97:100, h] = np.nan
        truth[100:103, cols[(cols.index(h) + 1) % len(cols)]] = np.nan
    return q, truth, len(ring) - 1


# a cycle whose start an occluded marker hides shows a single jump there: it is found where the labels move back
RUNS = [(case, end) for case in CASES for end in (200, 600) if not (CASES[case][2] and end == 600)]


@pytest.mark.parametrize("which", ["85_02", "HDM_bd"])
@pytest.mark.parametrize(("case", "end"), RUNS)
def test_labels_cycled_at_one_frame_are_undone(case, end, which, shared_data):
    # before, four or more labels cycled at one frame, and three whose cycle started with one of them unseen, kept
    # the wrong trajectories: no exchange of two, and no cycle of three jumping markers, explains the frame
    path = CMU if which == "85_02" else shared_data / "c3d_markers_recovery" / "HDM_bd_05-01_01_120.c3d"
    x = load_markers(path)[:600]
    q, truth, exchanges = _inject(x, *CASES[case], end)
    y, swaps = undo_swaps(q)
    assert np.array_equal(y, truth, equal_nan=True)
    assert len(swaps) == exchanges and all((s.start, s.end) == (100, end) for s in swaps)
    # each swap exchanges two recorded trajectories: composed, they give the corrected labelling back
    assert np.array_equal(np.take_along_axis(q, labelling(swaps, q.shape[1], q.shape[0])[..., None], axis=1), y,
                          equal_nan=True)
    res = clean_markers(x.with_positions(q))
    out = np.asarray(res.markers.positions)
    kept = ~res.filled & ~np.isnan(truth).any(axis=-1)
    assert np.allclose(out[kept], truth[kept], atol=1e-9, rtol=0)  # every marker back on its own trajectory
    listed = [f for f in res.fixes if f.kind == "swap"]
    assert len(listed) == exchanges and all((f.start, f.end) == (100, end) for f in listed)  # each one decision


def test_a_capture_as_recorded_has_no_cycle():
    x = load_markers(CMU)
    y, swaps = undo_swaps(np.asarray(x.positions))
    assert swaps == [] and np.array_equal(y, np.asarray(x.positions), equal_nan=True)


def test_a_label_unseen_most_of_the_time_closes_no_cycle(shared_data):
    # phasespace_sample.c3d (30 Hz, real gaps) as recorded: M028 and M029 were cycled from frame 71 with M040, unseen
    # over most of the frames judged, whose missing distances made the cycle look the more constant labelling
    x = load_markers(shared_data / "c3d_markers" / "phasespace_sample.c3d")
    keep = ~x.modelled() & ~x.unlabelled()
    y, swaps = undo_swaps(np.asarray(x.positions)[:, keep], 10 * x.unit_cm)
    assert swaps == []
