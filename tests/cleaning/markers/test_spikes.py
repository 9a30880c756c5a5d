"""Spike detection (cleaning/markers/spikes.py): in time and in the moving frame of rigid neighbours, on a real CMU capture."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocapkit.cleaning.markers import spike_mask
from mocapkit.cleaning.markers.rigid import distance_stats, donor_order
from mocapkit.cleaning.markers.spikes import rigid_deviation
from mocapkit.io.c3d import read_c3d

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"


@pytest.fixture(scope="module")
def cmu():
    return np.asarray(read_c3d(CMU).positions, dtype=np.float64)


def test_many_spikes_on_one_marker_of_a_short_take_are_all_found(cmu):
    # A marker's own spikes must not raise its threshold: 12 spikes (25-60 mm) on one marker of 810 frames.
    x = cmu
    y = x.copy()
    truth = np.zeros(x.shape[:2], bool)
    rng = np.random.default_rng(7)
    k = 10
    for j, start in enumerate(range(40, 770, 60)):
        n = 1 + j % 4
        v = rng.normal(size=(n, 3))
        y[start:start + n, k] += v * (rng.uniform(25, 60, size=n) / np.linalg.norm(v, axis=1))[:, None]
        truth[start:start + n, k] = True
    assert np.array_equal(spike_mask(y), truth)


def test_a_whole_body_jolt_is_motion_not_spikes(cmu):
    # Every marker leaves its cubic by the same 30 mm for 2 frames: the rigid neighbours explain it.
    y = cmu.copy()
    y[400:402] += np.array([30.0, 0.0, 0.0])
    assert not spike_mask(y).any()
    assert spike_mask(y, rigid=False)[400:402].all()  # in time alone, every marker would be a spike


def test_a_segment_moving_with_its_marker_vetoes_only_that_marker(cmu):
    # A jolt shared by a marker's three most rigid neighbours is motion; the same jolt alone is a spike.
    x = cmu
    order = donor_order(distance_stats(x))
    k = 3
    seg = [k] + [int(d) for d in order[k][:4]]
    jolt = np.array([0.0, 25.0, 20.0])
    y = x.copy()
    y[300:303, seg] += jolt
    good = np.ones(len(x), bool)
    good[300:303] = False
    assert rigid_deviation(y, good, k, 300, 303, order) < 1.0
    y = x.copy()
    y[300:303, k] += jolt
    assert rigid_deviation(y, good, k, 300, 303, order) == pytest.approx(np.linalg.norm(jolt), abs=3.0)
    assert spike_mask(y)[300:303, k].all()


def test_rigid_deviation_cannot_judge_without_good_ends(cmu):
    order = donor_order(distance_stats(cmu))
    good = np.ones(len(cmu), bool)
    good[290:320] = False
    assert rigid_deviation(cmu, good, 3, 300, 303, order, reach=8) == np.inf
