"""clean_markers and its parts on real captures: a complete CMU capture (tests/data/85_02.c3d) and the shipped Eb015pr.c3d."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mocapkit.cleaning.gapfill import fill_channels
from mocapkit.cleaning.markers import clean_markers, fill_gaps, spike_mask, undo_swaps
from mocapkit.cleaning.markers.rigid import distance_stats, from_local, local_frames, to_local
from mocapkit.cleaning.markers.spikes import prediction_matrix
from mocapkit.io.c3d import read_c3d
from mocapkit.markerset import MarkerSet
from mocapkit import samples

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"


@pytest.fixture(scope="module")
def cmu():
    return read_c3d(CMU)


def test_local_frames_recover_a_rigid_motion():
    rng = np.random.default_rng(0)
    ref = rng.normal(size=(4, 3)) * 100
    from scipy.spatial.transform import Rotation

    rots = Rotation.random(20, random_state=1).as_matrix()
    shift = rng.normal(size=(20, 3)) * 500
    donors = np.einsum("tij,kj->tki", rots, ref - ref.mean(0)) + shift[:, None]
    rot, origin = local_frames(donors, ref)
    assert np.allclose(rot, rots, atol=1e-9)
    p = rng.normal(size=(20, 3))
    assert np.allclose(from_local(to_local(p, rot, origin), rot, origin), p)


def test_prediction_matrix_reproduces_cubics():
    w = prediction_matrix(3, 3)
    t = np.r_[-3:0, 3:6].astype(float)
    poly = lambda u: 2 - u + 0.5 * u ** 2 - 0.1 * u ** 3  # noqa: E731
    assert np.allclose(w @ poly(t), poly(np.arange(3.0)))


def test_gap_fill_beats_linear_on_cut_gaps(cmu):
    x = np.asarray(cmu.positions)
    rng = np.random.default_rng(3)
    y = x.copy()
    mask = np.zeros(x.shape[:2], bool)
    for k in rng.choice(x.shape[1], 4, replace=False):
        a = int(rng.integers(150, 500))
        mask[a:a + 120, k] = True  # 1 s gaps
    y[mask] = np.nan
    filled, records = fill_gaps(y)
    lin = fill_channels(y.reshape(len(y), -1), "linear").reshape(y.shape)
    err = np.sqrt(np.mean(np.sum((filled[mask] - x[mask]) ** 2, -1)))
    err_lin = np.sqrt(np.mean(np.sum((lin[mask] - x[mask]) ** 2, -1)))
    assert err < 0.5 * err_lin
    assert len(records) == 4
    assert np.array_equal(filled[~mask], x[~mask])  # observed samples bit-identical


def test_spikes_are_found_and_replaced(cmu):
    x = np.asarray(cmu.positions)
    y = x.copy()
    truth = np.zeros(x.shape[:2], bool)
    rng = np.random.default_rng(5)
    for k, (start, length) in enumerate([(100, 1), (250, 3), (400, 5), (600, 2)]):
        v = rng.normal(size=3)
        y[start:start + length, 7 * k + 3] += 40 * v / np.linalg.norm(v)
        truth[start:start + length, 7 * k + 3] = True
    found = spike_mask(y)
    assert np.array_equal(found, truth)
    res = clean_markers(dataclasses.replace(cmu, positions=y))
    assert np.array_equal(res.spikes, truth)
    got = res.markers.positions
    assert np.sqrt(np.mean(np.sum((got[truth] - x[truth]) ** 2, -1))) < 2.0
    assert np.array_equal(got[~truth], x[~truth])
    assert {f.kind for f in res.fixes} == {"spike"}


def test_swaps_are_undone(cmu):
    x = np.asarray(cmu.positions)
    stats = distance_stats(x)
    i = 0
    j = int(np.nanargmin(stats.median[i]))
    y = x.copy()
    y[300:420, [i, j]] = y[300:420, [j, i]]
    z, swaps = undo_swaps(y)
    assert [(s.a, s.b, s.start, s.end) for s in swaps] == [(min(i, j), max(i, j), 300, 420)]
    assert np.array_equal(z, x)


def test_complete_capture_comes_back_bit_identical(cmu):
    res = clean_markers(cmu)
    assert not res.changed.any()
    assert np.array_equal(res.markers.positions, cmu.positions)
    assert res.fixes == ()


def test_real_gaps_filled_and_never_seen_marker_kept_missing(tmp_path):
    ms = read_c3d(samples.path("Eb015pr.c3d"))
    pos = np.array(ms.positions)
    pos[:, 2] = np.nan  # a marker missing in the whole take
    ms = dataclasses.replace(ms, positions=pos)
    res = clean_markers(ms, steps="gaps")
    assert res.never_seen == (ms.labels[2],)
    assert np.all(np.isnan(res.markers.positions[:, 2]))
    others = np.ones(ms.num_markers, bool)
    others[2] = False
    missing_before = ms.missing()[:, others].sum()
    assert missing_before > 0
    assert res.markers.missing()[:, others].sum() < missing_before
    assert any("whole take" in line for line in res.summary())
    path = res.save(tmp_path / "r.clean.npz")
    with np.load(path) as z:
        assert z["filled"].shape == pos.shape[:2] and str(z["kind"]) == "markers"


def test_unknown_step_refused(cmu):
    with pytest.raises(ValueError, match="unknown step"):
        clean_markers(cmu, steps="gaps,smooth")


def test_soft_constraints_pull_filled_samples_into_range_and_leave_observed_alone(cmu):
    from mocapkit.cleaning.markers import constraint_violation, enforce_distances
    from mocapkit.cleaning.markers.rigid import donor_order

    x = np.asarray(cmu.positions)
    stats = distance_stats(x)
    order = donor_order(stats)
    free = np.zeros(x.shape[:2], bool)
    free[200:260, 5] = True
    y = x.copy()
    y[free] += np.array([60.0, -40.0, 30.0])  # a fill 80 mm off
    before = constraint_violation(y, stats, order, free)
    z = enforce_distances(y, free, stats, order)
    assert before > 0.8
    assert constraint_violation(z, stats, order, free) < before - 0.1
    assert np.array_equal(z[~free], x[~free])
    err = lambda p: np.sqrt(np.mean(np.sum((p[free] - x[free]) ** 2, -1)))  # noqa: E731
    assert err(z) < 0.75 * err(y)


def test_modelled_points_are_left_alone(shared_data):
    # Vicon's PiG file holds joint angles, forces, moments and powers as points (POINT:ANGLES, ...):
    # not markers, so clean neither flags their jumps as spikes nor fills them.
    # Its model positions (segment axes PELO/PELA/..., centre of mass) are listed nowhere: found as computed points.
    ms = read_c3d(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d")
    modelled = ms.modelled()
    names = {ms.labels[i] for i in np.flatnonzero(modelled)}
    assert modelled.sum() == 158 and {"LAnkleMoment", "PELO", "LFEA", "CentreOfMass", "CentreOfMassFloor"} <= names
    assert not names & {"LASI", "RASI", "LKNE", "RKNE", "LANK", "RHEE", "LFHD"}  # the markers stay markers
    res = clean_markers(ms)
    assert not res.changed[:, modelled].any()
    assert not (res.filled | res.spikes | res.swapped)[:, modelled].any()
    assert res.filled[:, ~modelled].any()  # the markers' gaps are filled
    assert not any(f.marker in {ms.labels[i] for i in np.flatnonzero(modelled)} for f in res.fixes)


def test_frames_where_no_marker_is_seen_at_the_edges_stay_missing(cmu):
    # The subject not yet in view (frames 0-59) and gone (from 700): nothing there to fill from, so those frames stay
    # missing; a marker's gap reaching the first seen frame is filled from that end, near the truth.
    truth = np.asarray(cmu.positions, dtype=np.float64)
    x = truth.copy()
    x[:60] = np.nan
    x[700:] = np.nan
    x[60:80, 5] = np.nan
    res = clean_markers(dataclasses.replace(cmu, positions=x), steps="gaps")
    out = np.asarray(res.markers.positions)
    assert np.all(np.isnan(out[:60])) and np.all(np.isnan(out[700:]))
    assert np.all(np.isfinite(out[60:700]))
    seen = ~np.isnan(x)
    assert np.array_equal(out[seen], x[seen])
    err = np.linalg.norm(out[60:80, 5] - truth[60:80, 5], axis=-1)
    assert err.max() < 30.0  # mm
    assert res.unseen_start == (0, 60) and res.unseen_end == (700, len(x))
    assert any("frames 0-59 at the take's start see no marker" in line for line in res.summary())
    (gap,) = [fx for fx in res.fixes if fx.kind == "gap"]
    assert (gap.start, gap.end) == (60, 80) and np.isfinite(gap.size_mm)


def test_an_undone_swap_keeps_the_residuals_and_camera_masks_of_its_samples(cmu):
    # trial11: undoing a label swap gave the swapped samples residual 0 (the file had 0.2 and 0.45)
    x = np.asarray(cmu.positions)
    i = 0
    j = int(np.nanargmin(distance_stats(x).median[i]))
    res = np.where(np.isnan(x[..., 0]), -1.0, 0.2)
    res[:, j] = np.where(np.isnan(x[:, j, 0]), -1.0, 0.45)
    cams = np.full(res.shape, 3)
    cams[:, j] = 96
    y, ry, cy = x.copy(), res.copy(), cams.copy()
    for a in (y, ry, cy):  # the capture system swapped the labels of i and j, each sample with its residual
        a[300:420, [i, j]] = a[300:420, [j, i]]
    taken = dataclasses.replace(cmu, positions=y, residuals=ry, cameras=cy)
    out = clean_markers(taken, steps="swaps").markers
    assert np.array_equal(out.positions, x)
    assert np.array_equal(out.residuals, np.where(np.isnan(x[..., 0]), -1.0, res))
    assert np.array_equal(out.cameras, cams)


def test_unlabelled_trajectories_are_left_as_read_and_used_for_nothing(cmu):
    # trial14: Gait.trc's unlabelled fragments (TRC columns without a label) are seen in frames where no labelled
    # marker is; clean filled every labelled marker there with a made-up pose 1.7 m away (2 m jumps where the
    # subject came into view) and filled each fragment over the whole take.
    from mocapkit.markerset import MarkerSet, MarkerSource, unique_labels

    truth = np.asarray(cmu.positions, dtype=np.float64)
    f, m = truth.shape[:2]
    x = truth.copy()
    x[:60] = np.nan  # no labelled marker seen before frame 60 ...
    x[300:340, 5] = np.nan  # ... and a labelled marker's gap
    extra = np.full((f, 3, 3), np.nan)
    extra[10:50, 0] = truth[10:50, 0] + 2000.0  # ... but a fragment is (elsewhere in the room)
    extra[200:400, 1] = truth[200:400, 5]  # a phantom copy of marker 5, seen through its gap
    extra[420:470, 2] = truth[420:470, 7]
    extra[440, 2] += 60.0  # a jump in a fragment: not a spike to repair (its identity is unknown)
    raw = cmu.labels + ("", "*0", "*1")  # a TRC column without a label; Vicon's unlabelled trajectories
    take = MarkerSet(labels=unique_labels(raw, m + 3), positions=np.concatenate([x, extra], axis=1), fps=cmu.fps,
                     source=MarkerSource(format="trc", labels=raw))
    res = clean_markers(take)
    out = np.asarray(res.markers.positions)
    assert np.all(np.isnan(out[:60, :m])) and np.all(np.isfinite(out[60:, :m]))  # nobody (labelled) seen there
    assert np.array_equal(out[:, m:], extra, equal_nan=True)  # left exactly as read
    assert take.unlabelled().tolist() == [False] * m + [True] * 3
    assert not (res.filled | res.spikes | res.swapped)[:, m:].any() and not any(fx.marker in res.unlabelled
                                                                                 for fx in res.fixes)
    assert res.unseen_start == (0, 60) and res.unseen_end == (f, f)
    assert res.unlabelled == (take.labels[m], "*0", "*1")
    lines = res.summary()
    assert any("frames 0-59 at the take's start see no labelled marker" in line for line in lines)
    assert any(line.startswith("3 unlabelled trajectories") for line in lines)
    # the phantom copy lends the gap nothing: the fill is the one made without the unlabelled trajectories
    alone = clean_markers(dataclasses.replace(cmu, positions=x))
    assert np.array_equal(out[:, :m], np.asarray(alone.markers.positions), equal_nan=True)


def test_smoothed_correction_has_no_frame_to_frame_jolt_and_meets_the_seen_samples():
    # A correction switched on and off from one frame to the next (the frame-by-frame projection's pattern) is
    # low-passed: the filled run's second differences drop, the correction fades to nothing where a seen sample
    # adjoins, is held where the run reaches the take's edge, and nothing outside the run moves.
    from mocapkit.cleaning.markers.constraints import smooth_correction

    f = 200
    t = np.arange(f, dtype=float)
    before = np.stack([np.stack([np.sin(t / 30), np.cos(t / 30), t / 50], axis=-1)] * 2, axis=1) * 100  # (F, 2, 3)
    free = np.zeros((f, 2), bool)
    free[50:150, 0] = True
    free[170:, 1] = True  # reaches the take's last frame
    after = before.copy()
    after[50:150, 0, 0] += np.where(np.arange(100) % 3 == 0, 20.0, 0.0)  # on every third frame
    after[170:, 1, 2] += 15.0
    out = smooth_correction(before, after, free, sigma=6.0)
    acc = lambda y: np.abs(y[2:] - 2 * y[1:-1] + y[:-2]).max()  # noqa: E731
    assert acc(out[49:151, 0, 0]) < 0.1 * acc(after[49:151, 0, 0])
    mean_corr = (out[50:150, 0, 0] - before[50:150, 0, 0])[20:-20].mean()
    assert abs(mean_corr - 20.0 / 3) < 0.5  # the correction's mean kept inside the run
    assert abs(out[50, 0, 0] - before[50, 0, 0]) < 0.7 * mean_corr  # fading where seen frame 49 adjoins
    assert np.allclose(out[-1, 1, 2] - before[-1, 1, 2], 15.0)  # held at the take's edge
    assert np.array_equal(out[~free], after[~free])


def test_long_gap_fill_with_soft_constraints_does_not_jolt(cmu):
    # A whole head (4 markers) hidden for 2 s of real motion: the constrained fill, smoothed, moves no harder than
    # the frame-by-frame one (which jolts where pairs leave their range), at the same distance from the truth.
    x = np.asarray(cmu.positions, dtype=np.float64)
    labels = [name.split(":")[-1] for name in cmu.labels]
    head = [labels.index(n) for n in ("LFHD", "RFHD", "LBHD", "RBHD")]
    a, b = 300, 540
    y = x.copy()
    y[a:b, head] = np.nan
    acc = lambda p, m: np.linalg.norm(p[a - 1:b + 1, m][2:] - 2 * p[a - 1:b + 1, m][1:-1] + p[a - 1:b + 1, m][:-2], axis=-1).max()  # noqa: E731
    rms = lambda p: np.sqrt(np.mean(np.sum((p[a:b, head] - x[a:b, head]) ** 2, axis=-1)))  # noqa: E731
    raw, records = fill_gaps(y, smooth=0.0)
    smooth, _ = fill_gaps(y)
    assert any(r.constrained for r in records)
    worst_raw = max(acc(raw, m) / acc(x, m) for m in head)
    worst_smooth = max(acc(smooth, m) / acc(x, m) for m in head)
    assert worst_smooth < 0.8 * worst_raw
    assert rms(smooth) < 1.02 * rms(raw)


def test_frames_where_nobody_is_seen_mid_take_stay_missing_per_subject(cmu, tmp_path):
    # The performer out of the volume for 2 s mid-take (all 41 markers hidden 300-539): every one of the 9,840
    # samples was filled (RMS 647 mm from the truth, up to 1.7 m: a whole body invented); they stay missing and the
    # summary says why. A marker's gap reaching into those frames is filled up to them, from its one seen end.
    truth = np.asarray(cmu.positions, dtype=np.float64)
    x = truth.copy()
    x[300:540] = np.nan
    x[280:300, 5] = np.nan
    res = clean_markers(dataclasses.replace(cmu, positions=x), steps="gaps")
    out = np.asarray(res.markers.positions)
    assert np.all(np.isnan(out[300:540])) and np.all(np.isfinite(out[:300])) and np.all(np.isfinite(out[540:]))
    assert np.linalg.norm(out[280:300, 5] - truth[280:300, 5], axis=-1).max() < 30.0  # mm
    assert res.nobody_seen == (("Male", 300, 540),)
    assert "Male: frames 300-539: nobody seen (out of the volume?), left missing" in res.summary()
    # two subjects: Alice out of the volume 300-419 while Bob (the same walk, 2.5 m away) is seen; Bob's markers
    # say nothing about where she is, so her frames stay missing there too, and Bob comes back as he went in
    alice = truth.copy()
    alice[300:420] = np.nan
    bob = truth + [2500.0, 0.0, 0.0]
    labels = tuple("Alice:" + s.split(":")[-1] for s in cmu.labels) + tuple("Bob:" + s.split(":")[-1] for s in cmu.labels)
    two = MarkerSet(labels=labels, positions=np.concatenate([alice, bob], axis=1), fps=cmu.fps, units="mm")
    res = clean_markers(two, steps="gaps")
    out = np.asarray(res.markers.positions)
    assert np.all(np.isnan(out[300:420, :41])) and np.array_equal(out[:, 41:], bob)
    assert res.nobody_seen == (("Alice", 300, 420),) and not res.fixes and not res.unfilled
    assert "Alice: frames 300-419: nobody seen (out of the volume?), left missing" in res.summary()
    from mocapkit.cleaning.markers.record import read_marker_record

    assert read_marker_record(res.save(tmp_path / "two.clean.npz")).nobody_seen == (("Alice", 300, 420),)


def test_fills_expected_to_be_off_by_more_than_the_marker_spacing_are_left_missing(shared_data):
    # BTS.c3d (a real gait walk-in): markers enter the volume between frames 239 and 401; each was extrapolated back
    # to 239 from its one seen end and written, "r heel 239-294 donors (LATT), expected error 593 mm" among them.
    # A fill expected to be off by more than the marker's distance to its nearest marker is left missing and named.
    from mocapkit.cleaning.markers.gaps import error_limits

    ms = read_c3d(shared_data / "peer_files" / "pyomeca+ezc3d-testFiles" / "BTS.c3d")
    res = clean_markers(ms)
    heel = [x for x in res.unfilled if x.marker == "r heel" and x.start == 239]
    assert len(heel) == 1 and "at frame 0 " not in heel[0].note  # frames named in the take's numbers
    assert np.all(np.isnan(np.asarray(res.markers.positions)[239:295, ms.labels.index("r heel")]))
    # the default limit is checked on the error on the stretches that rank the models (the expected error shown is
    # that, widened where those stretches resemble the gap poorly: cleaning.markers.fill_error)
    over = [x for x in res.unfilled if "over the" in x.note]
    assert over and all("mm on the stretches next to the gap, over the" in x.note for x in over)
    limit = error_limits(distance_stats(np.asarray(ms.positions)))  # mm: BTS is in mm
    gaps = [x for x in res.fixes if x.kind == "gap"]
    assert gaps and all(x.expected_mm <= limit[ms.labels.index(x.marker)] + 1e-9 or x.fill_basis for x in gaps
                        if np.isfinite(x.expected_mm))
    one = [x for x in gaps if x.start == 239]  # a gap from the frame the walker comes in: one seen end
    assert one and all(x.ends == 1 and "extrapolated from its one seen end" in x.size_text for x in one)
    # no limit: every plausible fill written, none left missing for its expected error
    free = clean_markers(ms, max_error_mm=float("inf"))
    assert not any("over the" in x.note for x in free.unfilled)
    assert int(free.filled.sum()) > int(res.filled.sum())
    # r heel 239-294 had LATT as its donor (expected error 593 mm), whose distance to it varies by over 150 mm:
    # no donor now, and no other fill is plausible, so it stays missing, and its record says why
    (heel,) = [x for x in free.unfilled if x.marker == "r heel" and x.start == 239]
    assert "0 rigid donors seen throughout the gap" in heel.fill_note


def test_a_take_whose_residuals_are_all_zero_is_told_its_fills_cannot_be_told_apart(cmu):
    # a C3D whose every residual is 0 (s3_res0.c3d of trial C): fills get residual 0 too, as C3D has it
    x = np.asarray(cmu.positions, dtype=np.float64).copy()
    x[300:360, 9] = np.nan
    take = dataclasses.replace(cmu, positions=x, residuals=np.zeros(x.shape[:2]))
    lines = clean_markers(take).summary()
    assert any("residuals are all 0" in line and ".clean.npz" in line for line in lines)
    measured = dataclasses.replace(cmu, positions=x, residuals=np.ones(x.shape[:2]))  # as CMU's file is not
    assert not any("residuals are all 0" in line for line in clean_markers(measured).summary())


def test_gaps_skipped_by_max_gap_are_not_called_implausible_fills(cmu):
    """A gap longer than max_gap_s is never filled, so no fill of it was implausible: the summary and the fix say
    "longer than --max-gap (N s)", apart from the gaps whose fills were rejected."""
    pos = np.array(cmu.positions)
    pos[100:160, 3] = np.nan  # 0.5 s: over the 0.25 s limit
    pos[300:310, 7] = np.nan  # 10 frames: under it, filled
    res = clean_markers(cmu.with_positions(pos), max_gap_s=0.25)
    assert [(x.marker, x.start, x.end) for x in res.unfilled] == [(cmu.labels[3], 100, 160)]
    assert res.unfilled[0].too_long and res.filled[300:310, 7].all()
    said = [line for line in res.summary() if "left missing" in line]
    assert said == [f"1 gap (60 samples) left missing: longer than --max-gap (0.25 s): {cmu.labels[3]} frames "
                    "100-159 (0.50 s)"]
    assert res.unfilled[0].size_text == "0.50 s: left missing: longer than --max-gap (0.25 s)"


def test_one_sample_left_missing_is_counted_as_one():
    """The summary counts a one-sample gap left missing as "1 gap (1 sample)" (it said "1 samples")."""
    import mocapkit
    from mocapkit.io import load_markers

    m = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    seen = ~m.missing()[:200].any(axis=0)
    take = m.select([label for label, s in zip(m.labels, seen) if s][:12])[:200]
    p = np.array(take.positions)
    p[100, 2] = np.nan
    lines = clean_markers(take.with_positions(p), max_gap_s=0.0, steps="gaps").summary()
    assert any(line.startswith("1 gap (1 sample) left missing: longer than --max-gap") for line in lines), lines
