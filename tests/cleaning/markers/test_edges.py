"""Glitches beside an occlusion or at a take's ends (mocapkit.cleaning.markers.edges), on a real capture."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocapkit.cleaning.markers import clean_markers, spike_mask
from mocapkit.io.c3d import read_c3d

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"  # complete: 41 markers, 810 frames, 120 Hz, mm


@pytest.fixture(scope="module")
def cmu():
    ms = read_c3d(CMU)
    return ms, np.asarray(ms.positions, dtype=np.float64)


def _index(labels, name):
    return next(i for i, label in enumerate(labels) if label == name or label.endswith(":" + name))


@pytest.mark.parametrize("name", ["LHEE", "RTOE", "LFWT", "RELB"])
def test_a_glitch_on_each_side_of_an_occlusion_is_found(cmu, name):
    # The marker hidden for frames 300-330, 2 samples 40 mm off just before the gap and 2 samples 49.5 mm off just
    # after it (a partly hidden marker's centroid): the two-sided spike test has no context there.
    ms, x = cmu
    k = _index(ms.labels, name)
    y = x.copy()
    y[300:331, k] = np.nan
    y[298:300, k] += [0.0, -40.0, 0.0]
    y[331:333, k] += [35.0, 35.0, 0.0]
    hidden = x.copy()
    hidden[300:331, k] = np.nan
    mask = spike_mask(y, fps=ms.fps)
    expected = spike_mask(hidden, fps=ms.fps)
    expected[[298, 299, 331, 332], k] = True
    assert np.array_equal(mask, expected)


def test_a_spike_in_a_takes_first_or_last_frames_is_found(cmu):
    ms, x = cmu
    f = x.shape[0]
    a, b = _index(ms.labels, "LANK"), _index(ms.labels, "RHEE")
    y = x.copy()
    y[0, a] += [100.0, 0.0, 0.0]
    y[f - 2:, b] += [0.0, 60.0, 0.0]
    y[1, b] += [0.0, 0.0, 30.0]  # one frame in from the edge: the sample at frame 0 stays
    mask = spike_mask(y, fps=ms.fps)
    expected = spike_mask(x, fps=ms.fps)
    expected[0, a] = expected[f - 2:, b] = expected[1, b] = True
    assert np.array_equal(mask, expected)


def test_a_whole_body_jolt_at_the_takes_start_is_motion(cmu):
    # Every marker 30 mm off its track in the first 2 frames: the rigid neighbours moved with it.
    ms, x = cmu
    y = x.copy()
    y[:2] += [30.0, 0.0, 0.0]
    assert np.array_equal(spike_mask(y, fps=ms.fps), spike_mask(x, fps=ms.fps))


def test_real_samples_beside_occlusions_are_kept(cmu):
    # Runs of 5-40 frames blanked on every marker at random places: the samples beside them are real and stay.
    ms, x = cmu
    f, m = x.shape[:2]
    rng = np.random.default_rng(3)
    y = x.copy()
    for k in range(m):
        for _ in range(3):
            n = int(rng.integers(5, 41))
            s = int(rng.integers(0, f - n))
            y[s:s + n, k] = np.nan
    mask = spike_mask(y, fps=ms.fps)
    assert not (mask & ~spike_mask(x, fps=ms.fps)).any()


def test_edge_glitches_are_named_as_spikes_and_filled_with_the_gap(cmu):
    ms, x = cmu
    k = _index(ms.labels, "LHEE")
    y = x.copy()
    y[300:331, k] = np.nan
    y[298:300, k] += [0.0, -40.0, 0.0]
    res = clean_markers(ms.with_positions(y) if hasattr(ms, "with_positions") else ms, steps="spikes,gaps")
    spikes = [(fx.start, fx.end) for fx in res.fixes if fx.kind == "spike" and fx.marker == ms.labels[k]]
    assert (298, 300) in spikes
    assert res.spikes[298:300, k].all()
    assert np.nanmax(np.linalg.norm(res.markers.positions[290:331, k] - x[290:331, k], axis=-1)) < 15.0
