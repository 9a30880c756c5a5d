"""undo_swaps: swaps of far-apart markers and of fast, curving markers are found and undone exactly."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocapkit.cleaning.markers import undo_swaps
from mocapkit.cleaning.markers.rigid import distance_stats
from mocapkit.io.c3d import read_c3d

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"


def test_a_swap_of_markers_far_apart_is_undone():
    # A label swap between the two markers of the capture that are furthest apart (over 400 mm
    # throughout): both trajectories jump by that distance, and each lands where the other was going.
    x = np.asarray(read_c3d(CMU).positions)
    med = distance_stats(x).median
    i, j = np.unravel_index(np.nanargmax(np.where(np.isnan(med), -1.0, med)), med.shape)
    i, j = int(min(i, j)), int(max(i, j))
    assert np.min(np.linalg.norm(x[300:420, i] - x[300:420, j], axis=-1)) > 400.0
    y = x.copy()
    y[300:420, [i, j]] = y[300:420, [j, i]]
    z, swaps = undo_swaps(y)
    assert [(s.a, s.b, s.start, s.end) for s in swaps] == [(i, j, 300, 420)]
    assert np.array_equal(z, x)


def test_a_swap_of_fast_curving_markers_is_undone():
    # Two markers on a club swung from 9 rad/s and speeding up, 108 Hz, 1.0 and 0.92 m from the
    # hands: they miss their constant-velocity prediction by r (w dt)^2 = 20-47 mm over frames
    # 60-130, their constant-acceleration prediction by 3-10 mm.
    fps, f = 108.0, 160
    t = np.arange(f) / fps
    angle = 9.0 * t + 6.0 * t ** 2  # rad, speeding up
    radii = np.array([1000.0, 920.0])
    x = np.zeros((f, 2, 3))
    x[..., 0] = radii * np.cos(angle)[:, None]
    x[..., 1] = radii * np.sin(angle)[:, None]
    cv = np.linalg.norm(x[2:] - (2 * x[1:-1] - x[:-2]), axis=-1)
    assert cv[100:].min() > 15.0  # the swap's end is in frames no constant-velocity prediction meets
    y = x.copy()
    y[60:130, [0, 1]] = y[60:130, [1, 0]]
    z, swaps = undo_swaps(y)
    assert [(s.a, s.b, s.start, s.end) for s in swaps] == [(0, 1, 60, 130)]
    assert np.array_equal(z, x)


def test_unrelated_jumps_are_not_exchanged():
    # Two markers that jump at the same frame, each by its own amount and direction: neither
    # lands where the other was going, so nothing is re-labelled.
    f = 100
    t = np.arange(f, dtype=np.float64)
    x = np.zeros((f, 2, 3))
    x[:, 0, 0] = 2.0 * t
    x[:, 1, 0] = 2.0 * t + 300.0
    x[50:, 0, 1] += 40.0
    x[50:, 1, 2] -= 60.0
    z, swaps = undo_swaps(x)
    assert swaps == []
    assert np.array_equal(z, x)


def _thigh_and_knee():
    # LTHI and LKNE (216 mm apart): their distances to the hip and shin markers differ, so the
    # rigid neighbours tell the two labellings apart (markers placed symmetrically about their
    # neighbours, such as the toe and fifth metatarsal about the heel and ankle, they cannot).
    ms = read_c3d(CMU)
    return np.asarray(ms.positions), ms.labels.index("Male:LTHI"), ms.labels.index("Male:LKNE")


def test_a_swap_that_starts_as_a_marker_comes_back_from_an_occlusion_is_undone():
    # Marker i is hidden for frames 250-299 and comes back under j's label (and j under i's):
    # nothing predicts i at frame 300, so only the swap's end at 420 shows as two jumps. Its
    # distances to its rigid neighbours stay constant only with 300-419 exchanged.
    x, i, j = _thigh_and_knee()
    y = x.copy()
    y[250:300, i] = np.nan
    y[300:420, [i, j]] = y[300:420, [j, i]]
    z, swaps = undo_swaps(y)
    assert [(s.a, s.b, s.start, s.end) for s in swaps] == [(i, j, 300, 420)]
    truth = x.copy()
    truth[250:300, i] = np.nan
    assert np.array_equal(z, truth, equal_nan=True)


def test_a_swap_that_ends_as_a_marker_is_occluded_is_undone():
    # The swap starts in plain view at 300; marker i vanishes at 420 and comes back at 470 under
    # its own label, so the end never shows as two jumps: without the rigid neighbours' verdict
    # the exchange would run to the end of the take.
    x, i, j = _thigh_and_knee()
    y = x.copy()
    y[300:420, [i, j]] = y[300:420, [j, i]]
    y[420:470, i] = np.nan
    z, swaps = undo_swaps(y)
    assert [(s.a, s.b, s.start, s.end) for s in swaps] == [(i, j, 300, 420)]
    truth = x.copy()
    truth[420:470, i] = np.nan
    assert np.array_equal(z, truth, equal_nan=True)


# Chains of swaps sharing a marker, injected into two complete captures of two labs: CMU 85_02 (tests/data) and
# HDM05's HDM_bd_05-01_01_120 (Bastian), frames 0-599. Each swap exchanges the two markers' trajectories over its
# frames, applied in the order listed (the labeller's order); names without the subject prefix.
CHAINS = {
    "back to back": [("LTOE", "RTHI", 100, 200), ("RTHI", "LKNE", 200, 300)],
    "back to back, other order": [("RTHI", "LKNE", 100, 200), ("LTOE", "RTHI", 200, 300)],
    "three in a row": [("LTOE", "RTHI", 100, 200), ("RTHI", "LKNE", 200, 300), ("LKNE", "LFHD", 300, 400)],
    "overlapping": [("LTOE", "RTHI", 100, 200), ("RTHI", "LKNE", 150, 250)],
    "overlapping, later made first": [("RTHI", "LKNE", 150, 250), ("LTOE", "RTHI", 100, 200)],
}


def _capture(which, shared_data):
    from mocapkit.io import load_markers

    path = CMU if which == "85_02" else shared_data / "c3d_markers_recovery" / "HDM_bd_05-01_01_120.c3d"
    return load_markers(path)[:600]


def _inject(x, chain):
    """The capture with ``chain``'s swaps made in order, and each swap's (a, b) columns."""
    names = [label.split(":")[-1] for label in x.labels]
    q = np.array(x.positions)
    cols = []
    for u, v, s, e in chain:
        a, b = names.index(u), names.index(v)
        q[s:e, [a, b]] = q[s:e, [b, a]]
        cols.append((min(a, b), max(a, b), s, e))
    return q, cols


@pytest.mark.parametrize("which", ["85_02", "HDM_bd"])
@pytest.mark.parametrize("chain", list(CHAINS))
def test_chained_swaps_are_each_found_and_undone(which, chain, shared_data):
    # back to back, two swaps sharing a marker cycle three labels at the frame between them (no exchange of two
    # explains it): before, the three markers kept the wrong trajectories from there to the end of the take
    x = _capture(which, shared_data)
    truth = np.asarray(x.positions)
    q, cols = _inject(x, CHAINS[chain])
    y, swaps = undo_swaps(q)
    assert np.array_equal(y, truth, equal_nan=True)
    assert sorted((s.a, s.b, s.start, s.end) for s in swaps) == sorted(cols)
    from mocapkit.cleaning.markers.swaps import labelling  # composes the listing: it gives the labelling back

    assert np.array_equal(np.take_along_axis(q, labelling(swaps, q.shape[1], q.shape[0])[..., None], axis=1), y,
                          equal_nan=True)
