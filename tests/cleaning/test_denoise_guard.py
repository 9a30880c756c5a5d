"""mocapkit.cleaning.denoise_guard: a cell the denoiser moves further than the take's noise explains is kept.

The real take: HDM05's HDM_dg_squat1Reps_025_120.amc, whose own file turns lfemur by 180 deg on frames 78-82
(deep flexion); at 0.1 noise (seed 1) the EBF moved the good frame 77 by 128 deg and the Savitzky-Golay fallback
by 86, smoothing across that jump."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit import rotations as R
from mocapkit.cleaning.denoise_guard import (MARGIN_DEG, SIGMAS, departure_bounds, far_cells, guarded, held_cells,
                                             midpoint_deviation)
from mocapkit.cleaning.filters import savgol_smooth
from mocapkit.cleaning.whole_take import denoise_take

SQUAT = "hdm05_asfamc/HDM_dg_squat1Reps_025_120.amc"


@pytest.fixture(scope="module")
def squat(shared_data):
    truth = mocapkit.load(shared_data / SQUAT)
    noisy, _ = corrupt.corrupt(truth, "noise", seed=1, amount=0.1)
    return truth, noisy


def rotation_angle(a, b):
    """Degrees between rotations, as the guard measures them (mocapkit.rotations.geodesic_angle)."""
    return np.degrees(R.geodesic_angle(a, b))


def _worst_vs(truth, motion, joint):
    j = truth.skeleton.index(joint)
    return float(np.nanmax(rotation_angle(truth.rotations[:, j], motion.rotations[:, j])))


def test_denoise_take_does_not_spread_the_squats_own_flip_over_its_good_frames(squat):
    truth, noisy = squat
    out, method, note = denoise_take(noisy)
    assert method.startswith("EBF")
    worst_in = _worst_vs(truth, noisy, "lfemur")
    assert worst_in < 20.0
    # no lfemur frame ends further from the source than the noise put it, give or take the denoiser's own error
    assert _worst_vs(truth, out, "lfemur") <= worst_in + 5.0
    assert "kept as they came" in note and "lfemur" in note


def test_the_fallback_filter_is_guarded_too_and_kept_cells_are_bit_identical(squat):
    truth, noisy = squat

    def savgol(m, cells):
        den = savgol_smooth(m, window_s=0.1, polyorder=2, root=False)
        rot = np.where(np.asarray(cells)[..., None], den.rotations, m.rotations)
        return dataclasses.replace(den, rotations=rot), "SG", ""

    bare, _, _ = savgol(noisy, np.ones((noisy.num_frames, noisy.num_joints), bool))
    assert _worst_vs(truth, bare, "lfemur") > 60.0  # the filter alone smears the flip
    cells = np.zeros((noisy.num_frames, noisy.num_joints), bool)
    cells[:, 1:] = True
    out, method, note = guarded(noisy, cells, savgol)
    assert method == "SG" and note.startswith(f"{int(note.split()[0])} cells kept as they came")
    assert _worst_vs(truth, out, "lfemur") <= _worst_vs(truth, noisy, "lfemur") + 5.0
    moved = ~np.all(out.rotations == noisy.rotations, axis=-1)
    assert moved[:, 1:].mean() > 0.9  # the rest of the take is denoised
    bounds = departure_bounds(noisy.rotations, cells)
    assert not far_cells(noisy.rotations, out.rotations, bounds).any()
    assert np.array_equal(out.rotations[:, 0], noisy.rotations[:, 0])


def test_rotation_angle_and_midpoint_deviation_on_known_rotations():
    about_x = lambda deg: R.euler_to_quaternion(np.array([[deg, 0.0, 0.0]]), "XYZ")[0]
    a, b = about_x(10.0), about_x(-20.0)
    assert rotation_angle(a, b) == pytest.approx(30.0)
    assert rotation_angle(a, -b) == pytest.approx(30.0)  # either sign of a quaternion
    track = np.stack([about_x(d) for d in (0.0, 10.0, 20.0, 35.0)])[:, None]  # (F, 1, 4)
    dev = midpoint_deviation(track)
    assert np.isnan(dev[[0, -1], 0]).all()
    assert np.allclose(dev[1, 0], 0.0, atol=1e-9) and np.allclose(dev[2, 0], [-2.5, 0.0, 0.0])


@pytest.mark.parametrize("scales", [(2.0, 2.0, 2.0), (0.2, 4.0, 0.3)])
def test_departure_bounds_read_white_noise_along_its_widest_axis_and_ignore_a_few_jumps(scales):
    rng = np.random.default_rng(0)
    F = 4000
    vec = np.radians(rng.normal(size=(F, 3)) * np.array(scales))
    q = R.rotvec_to_quaternion(vec)[:, None]
    q[100:105] = R.quaternion_multiply(R.euler_to_quaternion(np.array([[180.0, 0.0, 0.0]]), "XYZ")[0], q[100:105])
    bound = departure_bounds(q, np.ones((F, 1), bool))[0]
    assert bound == pytest.approx(SIGMAS * max(scales) + MARGIN_DEG, rel=0.1)


def test_held_cells_keep_a_run_and_its_neighbours_but_leave_a_spike_to_the_denoiser():
    about_x = lambda degs: R.euler_to_quaternion(np.stack([degs, 0 * degs, 0 * degs], axis=-1), "XYZ")
    deg = np.arange(20.0)
    deg[5] += 90.0  # a spike: far from both neighbours
    deg[12:15] += 150.0  # a jump held for three frames
    q = about_x(deg)[:, None]
    far = np.ones((20, 1), bool)
    held = held_cells(q, far, np.array([10.0]))[:, 0]
    assert not held[5]
    assert held[11] and held[12:15].all() and held[15]
    assert held[[0, 19]].all()


def test_the_guard_measures_turns_by_the_one_geodesic_angle():
    """denoise_guard kept its own rotation_angle, a copy of rotations.geodesic_angle but for NaN handling: the guard
    now uses the shared one, whose NaN behaviour (NaN, quietly, where a joint is missing) is documented and tested
    (tests/test_rotations.py)."""
    from mocapkit.cleaning import denoise_guard

    assert not hasattr(denoise_guard, "rotation_angle")
    q = R.euler_to_quaternion(np.array([[0.0, 0.0, 0.0], [40.0, 0.0, 0.0], [80.0, 0.0, 0.0]]), "XYZ")[:, None]
    far = np.ones((3, 1), dtype=bool)
    assert not held_cells(q, far, np.array([1.0])).any()  # 40 deg from each neighbour: none held
    gone = q.copy()
    gone[1] = np.nan  # a missing cell: no step to or from it, so no neighbour to judge by (held)
    assert held_cells(gone, far, np.array([1.0])).all()
