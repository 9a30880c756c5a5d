"""fill_gaps: the regression fill, validation in short takes, the validated soft constraints, the fallbacks.

Maths on synthetic markers; quality on the complete CMU capture tests/data/85_02.c3d.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocapkit.cleaning.markers import fill_gaps
from mocapkit.cleaning.markers.rigid import distance_stats
from mocapkit.io.c3d import read_c3d

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"


@pytest.fixture(scope="module")
def cmu():
    return np.asarray(read_c3d(CMU).positions, dtype=np.float64)


def _err(filled, truth, mask):
    return float(np.sqrt(np.mean(np.sum((filled[mask] - truth[mask]) ** 2, axis=-1))))


def _thigh_take():
    """A rigid "pelvis" (3 markers) moving through the room; a "knee" swinging about a hip point fixed in the pelvis;
    a "thigh" marker 30 % of the way from hip to knee, so in the pelvis' frame its coordinates are a linear function
    of the knee's. Returns the (900, 5, 3) positions in mm and distance statistics that make the pelvis the thigh
    marker's most rigid neighbours."""
    f = 900
    t = np.arange(f) / 120.0
    pelvis = np.array([[0.0, 0, 0], [120, 0, 0], [60, 80, 10]])
    hip = np.array([60.0, -40, -60])
    rots = Rotation.from_rotvec(np.stack([0.3 * np.sin(0.7 * t), 0.2 * np.cos(0.5 * t), 0.5 * t], axis=1)).as_matrix()
    shift = np.stack([800 * np.sin(0.3 * t), 400 * t, 900 + 20 * np.sin(2 * t)], axis=1)
    swing = np.stack([0.8 * np.sin(2.1 * t), 0.3 * np.sin(1.3 * t + 1), np.zeros(f)], axis=1)
    knee = hip + Rotation.from_rotvec(swing).apply([0.0, 0.0, -420.0])
    thigh = hip + 0.3 * (knee - hip)
    local = np.concatenate([np.broadcast_to(pelvis, (f, 3, 3)), knee[:, None], thigh[:, None]], axis=1)
    x = np.einsum("tij,tkj->tki", rots, local) + shift[:, None]
    stats = distance_stats(x)
    spread = stats.spread.copy()
    spread[4, :3] = spread[:3, 4] = 0.0  # the pelvis is what the thigh marker's fills hang from
    spread[4, 3] = spread[3, 4] = 1e3
    return x, dataclasses.replace(stats, spread=spread)


@pytest.mark.parametrize("start, end", [(300, 540), (660, 900)])
def test_regression_fill_recovers_a_marker_on_the_next_segment(start, end):
    # The regression fill recovers the thigh marker over 2 s, inside the take (misfit interpolated between the
    # ends) and up to its last frame (misfit held from the one end); interpolation in the pelvis' frame cannot.
    x, stats = _thigh_take()
    mask = np.zeros(x.shape[:2], dtype=bool)
    mask[start:end, 4] = True
    y = x.copy()
    y[mask] = np.nan
    with_regression, records = fill_gaps(y, stats=stats, constrain=False)
    without, _ = fill_gaps(y, stats=stats, constrain=False, predictors=0, guard=False)  # (the guard leaves it missing)
    assert records[0].method == "regression"
    assert _err(with_regression, x, mask) < 1.0  # mm
    assert _err(without, x, mask) > 20.0
    assert np.array_equal(with_regression[~mask], x[~mask])


def test_degenerate_donors_fall_back_to_the_offset_from_a_neighbour():
    # Four markers on one rod (every triple collinear, no moving frame) translating along a curve:
    # the offset from the nearest marker is constant, so the pattern fill is exact where a room spline is not.
    f = 400
    t = np.arange(f) / 100.0
    path = np.stack([500 * np.sin(1.5 * t), 300 * np.cos(t), 100 * t], axis=1)
    x = path[:, None, :] + np.array([[0.0, 0, 0], [50, 0, 0], [120, 0, 0], [200, 0, 0]])
    mask = np.zeros(x.shape[:2], dtype=bool)
    mask[150:250, 1] = True
    y = x.copy()
    y[mask] = np.nan
    filled, records = fill_gaps(y, constrain=False)
    assert records[0].method == "donors" and len(records[0].donors) == 1
    assert _err(filled, x, mask) < 1e-9


def test_a_long_gap_in_a_short_take_is_still_validated(cmu):
    # 85_02 is 6.75 s: a 3.5 s gap leaves no stretch of its length on either side, so the validation spans
    # are the longest stretches that fit (the fill's expected error is then known, not NaN).
    y = cmu.copy()
    y[250:670, 10] = np.nan
    _, records = fill_gaps(y)
    assert len(records) == 1 and np.isfinite(records[0].expected_error)


def _cut_gaps(x, seed, markers, starts, lengths):
    """``x`` with one gap on each of ``markers`` random markers (start and length drawn from the ranges)."""
    rng = np.random.default_rng(seed)
    y = x.copy()
    mask = np.zeros(x.shape[:2], dtype=bool)
    for k in rng.choice(x.shape[1], markers, replace=False):
        a, n = int(rng.integers(*starts)), int(rng.integers(*lengths))
        mask[a:a + n, k] = True
    y[mask] = np.nan
    return y, mask


def test_soft_constraints_touch_only_the_gaps_they_helped_on(cmu):
    y, mask = _cut_gaps(cmu, 7, 8, (100, 500), (5, 240))
    con, records = fill_gaps(y)
    free, _ = fill_gaps(y, constrain=False)
    flags = {r.constrained for r in records}
    assert flags == {True, False}  # both kinds occur in this draw
    moved = [not np.array_equal(con[r.start:r.end, r.marker], free[r.start:r.end, r.marker]) for r in records]
    assert not any(m for m, r in zip(moved, records) if not r.constrained)  # unconstrained gaps: the plain fill
    assert any(m for m, r in zip(moved, records) if r.constrained)
    assert np.array_equal(con[~mask], cmu[~mask])


def test_regression_models_help_on_long_gaps_of_a_real_capture(cmu):
    # 1.5-2.5 s gaps on four markers at once, in the capture's varied second half.
    y, mask = _cut_gaps(cmu, 11, 4, (300, 450), (180, 300))
    with_regression, _ = fill_gaps(y, constrain=False)
    without, _ = fill_gaps(y, constrain=False, predictors=0)
    assert _err(with_regression, cmu, mask) < 0.9 * _err(without, cmu, mask)


def test_a_gap_at_the_end_of_the_take_is_validated_from_one_end():
    # Two markers, too few for a moving frame: a marker moving at constant velocity is filled exactly by a straight
    # line between its two ends, but hidden up to the last frame it can only be held at its last position, and its
    # validation gaps are filled that way too, so the error expected of the fill is the hold's, not zero.
    f = 600
    t = np.arange(f, dtype=float)[:, None]
    x = np.stack([np.hstack([2.0 * t, 0.5 * t, 0 * t + 900]), np.hstack([300 + 0.002 * t ** 2, 0 * t, 0 * t + 900])], axis=1)
    at_end, inside = x.copy(), x.copy()
    at_end[500:, 0] = np.nan
    inside[400:500, 0] = np.nan
    filled, (end_record,) = fill_gaps(at_end, constrain=False)
    _, (inside_record,) = fill_gaps(inside, constrain=False)
    assert inside_record.expected_error < 1e-6
    assert end_record.expected_error > 10.0  # mm: the marker moves 2 mm a frame
    assert np.all(np.isfinite(filled))


def test_a_marker_whose_neighbours_are_never_seen_fills_without_a_warning():
    # BTK's Gait.trc: 13 of its 66 markers are never seen; the low-rank fill's neighbour weights took the median of
    # their distances, all NaN, and numpy printed "All-NaN slice encountered" to the user's terminal
    import warnings

    # (marker 3 is seen only while marker 0 is not: never with it, so no distance to it is known either; with no
    # marker seen in the gap's frames, they would stay missing: nobody seen there)
    t = np.arange(100, dtype=float)
    x = np.full((100, 4, 3), np.nan)
    x[:, 0] = np.stack([t, 0.5 * t, 900 + 0 * t], axis=1)
    x[40:60, 3] = x[40:60, 0] + 300.0
    x[40:60, 0] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        filled, records = fill_gaps(x, constrain=False)
    assert [r.marker for r in records if r.marker != 3] == [0] and np.all(np.isfinite(filled[:, 0]))
    assert np.all(np.isnan(filled[:, 1:3]))


def _labels(path):
    return [str(s).split(":")[-1] for s in read_c3d(path).labels]


def test_a_props_hidden_markers_take_no_donor_from_the_body(cmu, shared_data):
    # A real rigid cluster, the head markers of CMU 135_02, set 1.5 m beside the subject of 85_02 as a prop. With
    # three of its four markers hidden for 1 s, their fills took the subject's head and shoulder markers as donors
    # (their distance to the prop varies by 600-800 mm over the take): the fill followed another body. Now only
    # the prop's own seen marker is a donor, and the record says why there is no donor group.
    other = np.asarray(read_c3d(shared_data / "c3d_markers_recovery" / "135_02.c3d").positions, dtype=np.float64)
    head = [_labels(shared_data / "c3d_markers_recovery" / "135_02.c3d").index(n) for n in ("LFHD", "RFHD", "LBHD", "RBHD")]
    prop = other[1000:1000 + len(cmu)][:, head] + np.array([1500.0, 0.0, 0.0])
    x = np.concatenate([cmu, prop], axis=1)
    body = cmu.shape[1]
    y = x.copy()
    y[300:420, body:body + 3] = np.nan
    _, records = fill_gaps(y, smooth=3.0)
    assert [r.marker for r in records] == [body, body + 1, body + 2]
    for r in records:
        assert all(d >= body for d in r.donors)
        assert "rigid donors" in r.note and "over the take by more than 150 mm" in r.note


def test_cleaning_and_filling_run_blas_on_one_thread(monkeypatch):
    # The low-rank fills' SVDs ran on OpenBLAS's threads: on two busy cores 03_rolling.c3d's 760 took 53 s of a 76 s
    # clean, 2 s on one thread, to the same bits. clean_markers and fill_gaps hold BLAS at one thread whatever the
    # caller set (two here, as a 2-core machine has by default).
    from threadpoolctl import threadpool_info, threadpool_limits

    from mocapkit.cleaning.markers import clean, clean_markers, gaps
    from mocapkit.markerset import MarkerSet

    if not any(i["user_api"] == "blas" for i in threadpool_info()):
        pytest.skip("no BLAS library threadpoolctl can see")
    seen = []

    def spy(real):
        def call(*args, **kwargs):
            seen.append(real.__name__)
            assert {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"} == {1}, real.__name__
            return real(*args, **kwargs)
        return call

    monkeypatch.setattr(clean, "distance_stats", spy(clean.distance_stats))  # the pipeline's steps
    monkeypatch.setattr(gaps, "donor_order", spy(gaps.donor_order))  # inside the gap filler
    take = read_c3d(CMU)[:300]
    y = np.asarray(take.positions, dtype=np.float64).copy()
    y[100:130, 5] = np.nan
    with threadpool_limits(2, user_api="blas"):
        fill_gaps(y, constrain=False)
        clean_markers(MarkerSet(labels=take.labels, positions=y, fps=take.fps, units=take.units), steps="gaps")
    assert seen == ["donor_order", "distance_stats", "donor_order"]
