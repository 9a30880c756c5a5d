"""Spike detection (cleaning/markers/spikes.py): in time, by rigid partners and in the moving frame of rigid neighbours, on real CMU captures."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocapkit.cleaning.markers import clean_markers, spike_mask
from mocapkit.cleaning.markers.rigid import DistanceStats, distance_stats, donor_order
from mocapkit.cleaning.markers.spikes import bends_with_neighbours, partner_motion, partner_vouched, rigid_deviation
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


# --- rigid partners: a marker that keeps its distance to a partner moving with it is moving, not spiking ---

SLICES = Path(__file__).resolve().parents[2] / "data" / "135_02_arms_feet.npz"
PUNCH = Path(__file__).resolve().parents[2] / "data" / "135_02_punch.npz"


def _label(labels, name):
    return [str(s).split(":")[-1] for s in labels].index(name)


def _turn(x, pair, start, angles, moving=None):
    """``x`` with markers ``moving`` (default: both of ``pair``) turned by ``angles`` (rad, one per frame from
    ``start``) about the pair's midpoint, around the horizontal axis perpendicular to the pair: a fast flick of
    a rigid pair keeps their distance exactly."""
    y = x.copy()
    for t, angle in enumerate(angles):
        f = start + t
        mid = 0.5 * (x[f, pair[0]] + x[f, pair[1]])
        axis = np.cross(x[f, pair[1]] - x[f, pair[0]], [0.0, 0.0, 1.0])
        rot = Rotation.from_rotvec(angle * axis / np.linalg.norm(axis)).as_matrix()
        for k in pair if moving is None else moving:
            y[f, k] = mid + rot @ (x[f, k] - mid)
    return y


FLICK = np.array([0.25, 0.5, 0.6, 0.5, 0.25])  # rad: each wrist marker leaves its cubic by up to ~40 mm


def test_a_fast_flick_of_a_rigid_pair_is_motion_and_comes_back_bit_identical(cmu):
    # 85_02's RWRA-RWRB distance varies by 1.3 mm over the take; the pair turns 0.6 rad about its midpoint in
    # 5 frames while the forearm and hand markers do not follow (a wrist turning fast): both markers leave
    # their cubic by 18-43 mm and no triple of neighbours explains it, but each stays at its usual distance
    # from the other, which moves with it. Before the partner rule, both were removed as 5-frame spikes.
    ms = read_c3d(CMU)
    a, b = _label(ms.labels, "RWRA"), _label(ms.labels, "RWRB")
    y = _turn(cmu, [a, b], 300, FLICK)
    assert np.linalg.norm(y[300:305, a] - cmu[300:305, a], axis=-1).max() > 40.0
    assert spike_mask(y, rigid=False)[300:305, [a, b]].all()  # in time alone they are spikes
    assert not spike_mask(y)[300:305, [a, b]].any()
    res = clean_markers(dataclasses.replace(ms, positions=y))
    assert not res.changed.any()
    assert np.array_equal(res.markers.positions, y)


def test_a_marker_on_the_sphere_about_its_still_partner_is_a_spike(cmu):
    # The same turn for RWRA alone, about RWRB: its distance to RWRB is kept exactly, but RWRB stays on its
    # cubic, so it vouches for nothing (135_02's RWRB at 2419: an 84 mm jump 2.7 mm off its pair distance).
    labels = read_c3d(CMU).labels
    a, b = _label(labels, "RWRA"), _label(labels, "RWRB")
    y = cmu.copy()
    for t, angle in enumerate(FLICK):
        f = 300 + t
        d = cmu[f, a] - cmu[f, b]
        axis = np.cross(d, [0.0, 0.0, 1.0])
        y[f, a] = cmu[f, b] + Rotation.from_rotvec(angle * axis / np.linalg.norm(axis)).as_matrix() @ d
    assert np.allclose(np.linalg.norm(y[:, a] - y[:, b], axis=-1), np.linalg.norm(cmu[:, a] - cmu[:, b], axis=-1))
    mask = spike_mask(y)
    assert mask[300:305, a].all() and not mask[300:305, b].any()


def test_a_partner_off_in_the_runs_context_vouches_for_nothing(cmu):
    # 85_02 at 60 Hz (every 2nd frame) with the spikes marker_clean's low-rate row cuts into it: RWRB moved
    # 100 mm on 363-364 and RWRA 81 mm on 365. RWRA's 365 lands 1.0 mm from its usual distance to RWRB (spread
    # 1.3 mm), and RWRB, whose cubic through RWRA's context frames bends to its own spike, seems to move with
    # it: RWRB vouched for RWRA's spike, which was kept.
    labels = read_c3d(CMU).labels
    a, b = _label(labels, "RWRA"), _label(labels, "RWRB")
    x = cmu[::2]
    y = x.copy()
    y[363:365, b] += [34.9, -19.2, 86.4]
    y[365, a] += [34.7, 38.5, -62.6]
    stats = distance_stats(x)
    assert abs(np.linalg.norm(y[365, a] - y[365, b]) - stats.median[a, b]) < 1.5
    mask = spike_mask(y, fps=60.0)
    assert mask[363:365, b].all() and mask[365, a]
    assert mask.sum() == 3
    # RWRB breaks its distance to RWRA on 363-364, where RWRA is good: it is off there, and cannot vouch
    run = np.zeros(y.shape[:2], bool)
    run[363:365, b] = run[365, a] = True
    good = ~run[:, a]
    tol = np.maximum(3.0, 3.0 * stats.spread[a])
    vouched = partner_vouched(y, good, a, 365, 366, np.array([b]), stats.median[a], tol, run, 3.0, reach=8)
    assert vouched.tolist() == [False]


def test_a_head_marker_whose_partners_spike_beside_it_is_kept_as_it_bends_with_them(cmu):
    # 85_02 at 30 Hz (every 4th frame) with three of the spikes marker_clean's low-rate row cuts into it, on
    # LFHD's rigid partners: LBHD at 118, RBHD at 118-119, RFHD at 122. LFHD's own samples at 119-121 are as
    # recorded (the head moving faster than the cubic at 30 Hz follows). Its partners, flagged on its context
    # frames and off their distance to it there, vouch for nothing; its path bends as its neighbours' do: kept.
    labels = read_c3d(CMU).labels
    x = cmu[::4]
    y = x.copy()
    y[118, _label(labels, "LBHD")] += [-30.6, -19.3, -15.4]
    y[118:120, _label(labels, "RBHD")] += [-5.7, 53.4, -66.8]
    y[122, _label(labels, "RFHD")] += [1.9, -67.3, -49.2]
    mask = spike_mask(y, fps=30.0)
    assert mask[118, _label(labels, "LBHD")] and mask[118:120, _label(labels, "RBHD")].all()
    assert mask[122, _label(labels, "RFHD")]
    assert not mask[110:130, _label(labels, "LFHD")].any()


def test_without_its_partner_a_flick_is_judged_by_the_other_rules(cmu):
    # RWRB unseen around the flick: nothing vouches for RWRA (partner_motion gives None) and the cubic and
    # rigid-triple rules decide, as before the partner rule: the flick is removed.
    labels = read_c3d(CMU).labels
    a, b = _label(labels, "RWRA"), _label(labels, "RWRB")
    y = _turn(cmu, [a, b], 300, FLICK)
    y[290:315, b] = np.nan
    stats = distance_stats(cmu)
    good = np.ones(len(y), bool)
    good[300:305] = False
    tol = np.full(y.shape[1], 3.0)
    assert partner_motion(y, good, a, 300, 305, np.array([b]), stats.median[a], tol,
                          np.zeros(y.shape[:2], bool), 3.0) is None
    assert spike_mask(y)[300:305, a].all()


def _slice(part, path=SLICES):
    d = np.load(path)
    stats = DistanceStats(*(d[f"{part}_{k}"] for k in ("median", "low", "high", "spread", "count")))
    return d[part].astype(np.float64), [str(s) for s in d[f"{part}_labels"]], int(d[f"{part}_first"]), stats


@pytest.mark.parametrize("part,kept,removed", [
    # fast strikes the tester found removed (each within 0.2-2.7 mm of its usual distance to its wrist-bar
    # partner, which moved with it); the real glitches next to them (258 mm off the pair; an 84 mm one-frame jump)
    # RFIN 2709-2711: the hand braking at a punch's end (7 -> 2 m/s), its path bending 12-29 mm a frame while the
    # wrist markers' bend 3-38 mm; no partner within 3 mm, and the hand turns about the wrist (no triple predicts it)
    ("arm", [("LWRA", 2688, 2693), ("LWRB", 2694, 2699), ("RWRA", 3223, 3228), ("RFIN", 2709, 2712)],
     # LWRA 2503: a one-frame jump out and back (second differences 95, 130, 99 mm while LWRB's are 11), its
     # distance to LWRB 5 mm from the previous frame's and 3.7 mm from the next one's, where that distance holds
     [("RWRA", 3875, 3882), ("RWRB", 2419, 2420), ("RWRB", 2446, 2449), ("LWRA", 2503, 2504)]),
    # a heel strike: LHEE and LANK keep their distance while LMT5 glitches 150 mm
    ("foot", [("LHEE", 4485, 4487), ("LANK", 4485, 4487)], [("LMT5", 4484, 4488)]),
])
def test_135_02_fast_strikes_are_kept_and_its_glitches_removed(part, kept, removed):
    # Real samples of CMU 135_02 (tests/data/135_02_arms_feet.npz: the arm markers of frames 2380-3899 and the
    # left foot's of 4400-4599, with the whole take's usual inter-marker distances).
    x, labels, first, stats = _slice(part)
    mask = spike_mask(x, stats=stats)
    for name, a, b in kept:
        assert not mask[a - first:b - first, labels.index(name)].any(), (name, a)
    for name, a, b in removed:
        assert mask[a - first:b - first, labels.index(name)].all(), (name, a)


def test_a_path_that_bends_with_its_neighbours_is_motion_judged_over_the_whole_flagged_stretch():
    # 135_02's RFIN 2709-2711 bends no more than its neighbours (at most 7.6 mm more than the most bent one);
    # RWRA 3875-3881, a linear ramp away from RWRB and a jump back (a bad source fill), bends only at its
    # ends: a piece from inside it passes alone, but the whole flagged stretch is judged.
    x, labels, first, stats = _slice("arm")
    order = donor_order(stats)
    fin, wra = labels.index("RFIN"), labels.index("RWRA")
    flagged = np.zeros(x.shape[:2], bool)
    flagged[2709 - first:2712 - first, fin] = True
    flagged[2711 - first, wra] = True
    assert bends_with_neighbours(x, fin, 2709 - first, 2712 - first, order, flagged, 15.0)
    assert not bends_with_neighbours(x, fin, 2709 - first, 2712 - first, order, flagged, 5.0)
    piece = np.zeros(x.shape[:2], bool)
    piece[3876 - first:3879 - first, wra] = True
    assert bends_with_neighbours(x, wra, 3876 - first, 3879 - first, order, piece, 15.0)
    piece[3875 - first:3882 - first, wra] = True
    assert not bends_with_neighbours(x, wra, 3876 - first, 3879 - first, order, piece, 15.0)


def test_135_02_a_punch_its_wrist_bar_partner_holds_is_kept_sample_by_sample():
    # Real samples of CMU 135_02 (tests/data/135_02_punch.npz: the left arm's markers in frames 1100-1299, with
    # the whole take's usual distances). LWRA punches at 6-9 m/s in 1189-1195; on every sample its distance to
    # LWRB (spread 1.4 mm over the take) lies within 3 mm of the usual one, and LWRB moves with it. The first two
    # samples of the run the cubic flags, 1187-1188, are off that distance by +15.4 and +6.5 mm. The run was
    # condemned whole for them (and for the distance at its far end, 1196, itself 11.5 mm off), and 1187-1195 were
    # refilled up to 41 mm from the recording.
    x, labels, first, stats = _slice("punch", PUNCH)
    a, b = labels.index("LWRA"), labels.index("LWRB")
    mask = spike_mask(x, stats=stats, fps=120.0)
    assert not mask[1189 - first:1196 - first, a].any()
    assert not mask[:, b].any()
    # the partner's account is per sample: in the run 1187-1191 (1192-1195 suspected too) it vouches for 1189-1191
    run = np.zeros(x.shape[:2], bool)
    run[1187 - first:1196 - first, a] = True
    good = ~run[:, a]
    tol = np.maximum(3.0, 3.0 * stats.spread[a])
    vouched = partner_vouched(x, good, a, 1187 - first, 1192 - first, np.array([b]), stats.median[a], tol, run,
                              3.0, reach=8)
    assert vouched.tolist() == [False, False, True, True, True]


def test_the_good_side_of_a_step_into_a_long_wrong_run_is_not_a_spike(cmu):
    # CMU 85_02 with LFWT put on RFWT's position for 1 s (frames 405-524, a labeller's duplicate): every run beside
    # each step leaves the cubic, which bridges the step. The good side missed it most, and 11 good LFWT samples
    # (400-404, 525-530) were removed and refilled up to 200 mm off, while the wrong run stayed. A run that jumps at
    # one end only and goes on smoothly for more than 4 runs at the other is a step's side, not a spike.
    ms = read_c3d(CMU)
    a, b = _label(ms.labels, "LFWT"), _label(ms.labels, "RFWT")
    y = cmu.copy()
    y[405:525, a] = cmu[405:525, b]
    mask = spike_mask(y, fps=ms.fps)
    assert not mask[:, a].any()
    assert np.array_equal(mask, spike_mask(cmu, fps=ms.fps))


def test_a_departure_a_few_runs_long_still_goes_piecewise(cmu):
    # A marker 60 mm off for 8 frames (over the 5-frame run): its first runs jump in, its last jumps out, and it
    # goes whole (before the step rule, only its 2 first and 2 last samples went).
    y = cmu.copy()
    y[300:308, 20] += np.array([60.0, 0.0, 0.0])
    mask = spike_mask(y, fps=120.0)
    assert mask[300:308, 20].all() and not mask[290:300, 20].any() and not mask[308:318, 20].any()
