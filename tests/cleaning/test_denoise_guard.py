"""mocapkit.cleaning.denoise_guard: a cell the denoiser moves further than the take's noise explains is kept.

The real take: HDM05's HDM_dg_squat1Reps_025_120.amc, whose own file turns lfemur by 180 deg on frames 78-82
(deep flexion); at 0.1 noise (seed 1) the EBF moved the good frame 77 by 128 deg and the Savitzky-Golay fallback
by 86, smoothing across that jump. HDM05's grabHighR at 0.5 noise: one large noise sample that sits near one
neighbour is noise's, not a held jump. CMU's backflip.amc holds one-frame flips of 150-179 deg in its own file:
no noise sample, kept as they came, and the good frames beside them are not dragged."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit import rotations as R
from mocapkit.cleaning.denoise_guard import (MARGIN_DEG, SIGMAS, SPIKE_P, departure_bounds, displaced_runs,
                                             far_cells, guarded, held_cells, jump_bounds, jump_cells,
                                             midpoint_deviation)
from mocapkit.cleaning.filters import savgol_smooth
from mocapkit.cleaning.whole_take import denoise_take

SQUAT = "hdm05_asfamc/HDM_dg_squat1Reps_025_120.amc"
GRAB = "hdm05_asfamc/HDM_dg_grabHighR_014_120.amc"
BACKFLIP = "cmu_asfamc/backflip.amc"


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
    far = far_cells(noisy.rotations, out.rotations, bounds)
    assert not held_cells(noisy.rotations, far, bounds).any()  # what is left far is lone noise, the filter's
    assert np.array_equal(out.rotations[:, 0], noisy.rotations[:, 0])


def test_the_python_denoiser_keeps_what_the_command_keeps():
    """Trial T1: ``deep.denoise``, the Python denoiser the guides show, had no guard: on the clean CMU 131_02 it
    turned RThumb by up to 58 deg (the 3dsMax BVH's own thumb flips, smoothed as noise) where ``mocapkit denoise``
    keeps those cells. It now takes the command's path (``denoise_take``), bit for bit, its note a UserWarning;
    ``guard=False`` gives the network's own output. The bundled 131_01, same converter: 49 deg -> kept."""
    from mocapkit.cleaning import deep

    take = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[160:260]
    j = take.skeleton.index("RThumb")
    with pytest.warns(UserWarning, match=r"^131_01: \d+ cells kept as they came: .*RThumb"):
        out = deep.denoise(take)
    assert np.array_equal(out.rotations, denoise_take(take)[0].rotations)
    assert np.max(rotation_angle(take.rotations[:, j], out.rotations[:, j])) < 3.0
    raw = deep.denoise(take, guard=False)
    assert np.max(rotation_angle(take.rotations[:, j], raw.rotations[:, j])) > 30.0


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


def _worst_all(truth, motion):
    return float(np.nanmax(rotation_angle(truth.rotations[:, 1:], motion.rotations[:, 1:])))


def test_a_large_noise_sample_near_one_neighbour_is_denoised_not_kept(shared_data):
    truth = mocapkit.load(shared_data / GRAB)
    noisy, _ = corrupt.corrupt(truth, "noise", seed=4, amount=0.5)
    out, _, _ = denoise_take(noisy)
    worst_in = _worst_all(truth, noisy)
    assert worst_in > 80.0  # rhumerus frame 181: a noise sample of 82 deg beside a neighbour noise put near it
    assert _worst_all(truth, out) < 0.5 * worst_in


def test_the_backflips_one_frame_flips_are_kept_and_drag_no_good_frame(shared_data):
    truth = mocapkit.load(shared_data / BACKFLIP)
    q = truth.rotations
    step = rotation_angle(q[1:], q[:-1])
    flips = np.zeros(q.shape[:2], bool)
    flips[1:-1] = (step[:-1] > 120.0) & (step[1:] > 120.0)  # away from both neighbours by 120+ deg
    flips[:, 0] = False
    assert flips.sum() >= 3  # lhand frames 129-130, rthumb frame 134
    out, _, note = denoise_take(truth)
    assert np.array_equal(out.rotations[flips], q[flips])  # the file's flips as they came
    assert _worst_all(truth, out) < 20.0  # no good frame dragged towards them (134.6 deg before)
    assert "kept as they came" in note


def test_the_squats_own_flip_is_not_hidden_at_heavy_noise(shared_data):
    truth = mocapkit.load(shared_data / SQUAT)
    noisy, _ = corrupt.corrupt(truth, "noise", seed=6, amount=0.5)
    out, _, _ = denoise_take(noisy)
    assert _worst_vs(truth, out, "lfemur") <= _worst_vs(truth, noisy, "lfemur") + 5.0


def _about_x(degs):
    degs = np.asarray(degs, dtype=np.float64)
    return R.euler_to_quaternion(np.stack([degs, 0 * degs, 0 * degs], axis=-1), "XYZ")


def test_a_far_sample_near_one_plain_neighbour_is_not_held():
    deg = np.arange(20.0)
    deg[8] += 50.0  # a large noise sample ...
    deg[9] += 45.0  # ... whose next frame noise put near it, but not far
    q = _about_x(deg)[:, None]
    far = np.zeros((20, 1), bool)
    far[8] = True
    assert not held_cells(q, far, np.array([10.0]))[8, 0]
    far[9] = True  # two far cells side by side that agree: held
    assert held_cells(q, far, np.array([10.0]))[[8, 9], 0].all()


def test_jump_cells_keep_a_one_frame_flip_and_a_held_flip_whole_but_not_noise():
    rng = np.random.default_rng(3)
    F = 400
    deg = np.linspace(0.0, 40.0, F) + rng.normal(size=F) * 2.0  # 2 deg of white noise
    deg[100] += 170.0  # a one-frame flip
    deg[200:205] += 180.0  # a flip held for five frames
    q = _about_x(deg)[:, None]
    cells = np.ones((F, 1), bool)
    bound = jump_bounds(q, cells)
    assert bound[0] == pytest.approx(np.sqrt(2.0) * 6.696 * 2.0 + MARGIN_DEG, rel=0.15)  # chi(3) at SPIKE_P
    assert SPIKE_P == pytest.approx(1e-9)
    far = np.zeros((F, 1), bool)
    far[[99, 100, 101, 199, 202, 205, 300]] = True  # the flips, frames dragged beside them, a noise sample
    kept = jump_cells(q, far, bound)[:, 0]
    assert kept[100] and kept[200:205].all()
    assert not kept[[99, 101, 199, 205, 300]].any()  # dragged frames: a run around the flip denoises them
    one = np.zeros((F, 1), bool)
    one[[199, 250]] = True  # a single jump (no flip between two): the far run touching it is kept
    base = np.linspace(0.0, 40.0, F) + rng.normal(size=F) * 2.0
    q2 = _about_x(np.where(np.arange(F) >= 200, base + 180.0, base))[:, None]
    assert jump_cells(q2, one, bound)[199, 0] and not jump_cells(q2, one, bound)[250, 0]


def test_displaced_runs_find_a_run_moved_the_same_way_each_cell_within_the_bound():
    rng = np.random.default_rng(5)
    F = 600
    q = R.rotvec_to_quaternion(np.radians(rng.normal(size=(F, 3)) * 10.0))[:, None]  # 10 deg of noise
    moved = np.zeros(F)
    moved[300:305] = 40.0  # five frames moved 40 deg one way: under the 43 deg bound each, a run together
    moved[100] = 40.0  # one frame alone: noise's
    den = R.quaternion_multiply(q, _about_x(-moved)[:, None])
    cells = np.ones((F, 1), bool)
    assert departure_bounds(q, cells)[0] > 40.0
    runs = displaced_runs(q, den, cells)[:, 0]
    assert runs[300:305].all() and not runs[100]
    assert not runs[:297].any() and not runs[308:].any()  # a window may reach a frame or two past the run


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


def test_the_squats_own_flip_is_read_between_window_means_when_one_step_cannot_show_it(shared_data):
    """At 0.5 noise (seed 0) lfemur's noise std is 23 deg: the single-step jump bound (221 deg) passes any turn, so
    the jump rule saw no flip, nothing was kept, and the EBF dragged the good frame 77 138 deg off the source. The
    5-frame flip (78-82) is plain between the means of the frames either side (bound 100 deg)."""
    truth = mocapkit.load(shared_data / SQUAT)
    noisy, _ = corrupt.corrupt(truth, "noise", seed=0, amount=0.5)
    out, _, note = denoise_take(noisy)
    assert _worst_vs(truth, out, "lfemur") <= _worst_vs(truth, noisy, "lfemur") + 5.0
    assert "lfemur" in note


def test_jump_steps_find_a_held_flip_under_noise_too_heavy_for_one_step():
    from mocapkit.cleaning.denoise_guard import jump_steps, window_steps

    rng = np.random.default_rng(7)
    F = 300
    deg = np.linspace(0.0, 60.0, F) + rng.normal(size=F) * 20.0  # 20 deg of noise: one step's bound > 180 deg
    deg[150:155] += 180.0  # a flip held for five frames
    q = _about_x(deg)[:, None]
    cells = np.ones((F, 1), bool)
    bound = jump_bounds(q, cells)
    assert bound[0] > 180.0
    assert not jump_steps(q, bound)[:, 0].any()  # single steps: blind
    found = np.flatnonzero(jump_steps(q, bound, np.array([0.2]))[:, 0]) + 1  # the first frame after each jump
    assert set(found) <= {149, 150, 151, 154, 155, 156} and len(found) == 2
    assert np.allclose(window_steps(q, 1)[:, 0], rotation_angle(q[1:, 0], q[:-1, 0]))


def test_the_window_step_table_holds_each_windows_steps_and_far_joints_alone_are_read():
    """window_step_table's row n - 1 is window_steps(q, n) bit for bit (missing cells and a take too short for the
    widest windows included), and jump_cells reads the same jumps from the table as without it."""
    from mocapkit.cleaning.denoise_guard import RUN_FRAMES, window_step_table, window_steps

    rng = np.random.default_rng(3)
    q = np.stack([_about_x(np.cumsum(rng.normal(0.0, 6.0, 40)) + 180.0 * (np.arange(40) % 17 == 5)) for _ in range(3)],
                 axis=1)
    q[11, 1] = np.nan
    table = window_step_table(q, RUN_FRAMES)
    assert table.shape == (RUN_FRAMES, 39, 3)
    for n in range(1, RUN_FRAMES + 1):
        assert np.array_equal(table[n - 1], window_steps(q, n), equal_nan=True)
    assert np.isnan(window_step_table(q[:9], RUN_FRAMES)[RUN_FRAMES - 1]).all()  # 9 frames: no two 8-frame windows
    far = np.zeros((40, 3), bool)
    far[4:8, [0, 2]] = True
    bounds, speed = np.full(3, 20.0), np.full(3, 3.0)
    assert np.array_equal(jump_cells(q, far, bounds, speed, table), jump_cells(q, far, bounds, speed))



def _kept_reading_every_joint(q, den, judged, std):
    """kept_cells as it read every joint before it read the judged and the far ones alone: the reference."""
    import mocapkit.cleaning.denoise_guard as G

    bounds = departure_bounds(q, judged, std)
    far = far_cells(q, den, bounds) & judged
    runs = displaced_runs(q, den, judged, std)
    if not far.any():
        return runs
    jumps = jump_cells(q, far, jump_bounds(q, judged, std), G.motion_speed(den, judged),
                       G.window_step_table(q, G.RUN_FRAMES))
    return jumps | runs | held_cells(q, far & ~jumps & ~G.beside(jumps, far), bounds)


@pytest.fixture(scope="module")
def jog_flipped():
    """A real bundled take (HDM05 bd jog) with injected flips under 0.3 noise, and its Savitzky-Golay smoothing."""
    from mocapkit import samples

    take = mocapkit.load(samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"))
    noisy = corrupt.corrupt(corrupt.corrupt(take, "flip", seed=4)[0], "noise", seed=2, amount=0.3)[0]
    return noisy.rotations, savgol_smooth(noisy, window_s=0.1, polyorder=2, root=False).rotations


def test_kept_cells_reads_only_the_joints_with_a_far_cell_and_finds_what_reading_all_finds(jog_flipped, monkeypatch):
    """kept_cells makes window steps for the joints the denoiser moved a cell of too far, not for all 31 (on the
    benchmark's 60 s take, 1.1 s of 9.5 s), and returns the cells the whole-table reading returns, bit for bit."""
    import mocapkit.cleaning.denoise_guard as G

    q, den = jog_flipped
    judged = np.ones(q.shape[:2], bool)
    judged[:, 0] = False
    std = G.noise_std(q, judged)
    far = far_cells(q, den, departure_bounds(q, judged, std)) & judged
    cols = np.flatnonzero(far.any(axis=0))
    assert 0 < len(cols) < q.shape[1]
    whole = _kept_reading_every_joint(q, den, judged, std)
    assert whole[far].any() and (whole & ~far).any()  # jumps and held cells, and displaced runs
    widths = []
    real = G.window_step_table
    monkeypatch.setattr(G, "window_step_table", lambda r, most: widths.append(r.shape[1]) or real(r, most))
    memo: dict = {}
    assert np.array_equal(G.kept_cells(q, den, judged, std, memo), whole)
    assert widths == [len(cols)]
    assert np.array_equal(G.kept_cells(q, den, judged, std, memo), whole) and widths == [len(cols)]  # memo: once


def test_kept_cells_reads_only_the_judged_joints_and_finds_what_reading_all_finds(jog_flipped, monkeypatch):
    """Denoising three noisy joints, the guard reads those three (the benchmark's take: 3 of 31; 0.4 s of its
    guard's 0.8 s went to joints nothing was judged in), with the same cells kept as reading all of them."""
    import mocapkit.cleaning.denoise_guard as G

    q, den = jog_flipped
    std_all = G.noise_std(q, np.ones(q.shape[:2], bool))
    far_all = far_cells(q, den, departure_bounds(q, np.ones(q.shape[:2], bool), std_all))
    joints = np.concatenate([np.flatnonzero(far_all.any(axis=0))[:2], [np.flatnonzero(~far_all.any(axis=0))[-1]]])
    judged = np.zeros(q.shape[:2], bool)
    judged[20:, joints] = True
    whole = _kept_reading_every_joint(q, den, judged, G.noise_std(q, judged))
    assert whole.any()
    widths = []
    real = G.far_cells
    monkeypatch.setattr(G, "far_cells", lambda a, b, c: widths.append(a.shape[1]) or real(a, b, c))
    assert np.array_equal(G.kept_cells(q, den, judged), whole)
    assert np.array_equal(G.kept_cells(q, den, judged, G.noise_std(q, judged)), whole)
    assert widths == [3, 3]
