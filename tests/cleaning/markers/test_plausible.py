"""The plausibility guard of marker gap fills, the gap lines' duration/method/expected error, and computed points.

trial16: on 03_rolling.c3d's real gaps fills left the body (3.5 m from every
seen marker), teleported (311 m/s), went under the floor, held a foot marker
where it was last seen for 10.8 s while the subject rolled away, and a
constrained fill jumped 1.78 m at both ends; gap lines gave no duration,
method or expected error; Plug-in Gait's segment axes and centre of mass
were cleaned as markers. Synthetic takes here (and the complete CMU capture
tests/data/85_02.c3d) so the tests run without ../shared.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from mocapkit.cleaning.markers import clean_markers, fill_gaps
from mocapkit.cleaning.markers.rigid import distance_stats, donor_order
from mocapkit.io.c3d import read_c3d
from mocapkit.markerset import MarkerSet

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"


def _walk(f: int = 200):
    """(f, 5, 3) mm: a rigid 4-marker "foot" (0-3) walking along x at 10 mm/frame, and a marker 4 standing 1.2 m away."""
    t = np.arange(f, dtype=np.float64)
    foot = np.array([[5.0, 5, 20], [150, 5, 20], [60, 70, 60], [100, 30, 90]])
    x = np.empty((f, 5, 3))
    x[:, :4] = foot + np.stack([10.0 * t, np.zeros(f), np.zeros(f)], axis=1)[:, None]
    x[:, 4] = [5.0, 1200.0, 900.0]
    x[:, 4, 2] += 3.0 * np.sin(t / 7.0)  # it sways a little: not a fixed point
    return x


def test_a_gap_to_the_takes_end_follows_the_seen_rigid_neighbour_not_the_room():
    # trial16 #1 (LR_FM5): the marker and two of its foot's markers vanish to the take's end; only the third
    # (the heel: rigid with it, but not the most rigid) stays seen. The old fallback tried the offset from the two
    # most rigid markers (both hidden) and held the last room position: the fill stood still while the foot walked
    # away (3.8 m from the heel in the capture). Now the offset from the seen rigid neighbour fills it.
    x = _walk()
    y = x.copy()
    y[120:, [1, 2, 3]] = np.nan  # marker 3 hidden to the end with its two most rigid neighbours; marker 0 stays seen
    out, records = fill_gaps(y)
    rec = [r for r in records if r.marker == 3][0]
    assert rec.method == "donors" and rec.donors == (0,) and getattr(rec, "filled", True)
    usual = np.linalg.norm(x[0, 3] - x[0, 0])
    dist = np.linalg.norm(out[120:, 3] - out[120:, 0], axis=-1)
    assert np.max(np.abs(dist - usual)) < 1.0  # it stays on the foot
    assert np.max(np.linalg.norm(out[120:, 3] - x[120:, 3], axis=-1)) < 1.0


def test_a_fill_nothing_plausible_supports_is_left_missing_and_said():
    # The whole foot vanishes from frame 120 to the take's end; only a marker 1.2 m away stays seen. Held room
    # positions, the low-rank fill and the offset from that far marker all put the foot where it is not (it walks
    # on at 10 mm/frame, and a fill 1.2 m from every seen marker is on no body the take shows): left missing, and
    # the record says why; the old code filled it.
    x = _walk()
    y = x.copy()
    y[120:, :4] = np.nan
    out, records = fill_gaps(y)
    assert np.all(np.isnan(out[120:, :4]))
    assert len(records) == 4 and not any(r.filled for r in records)
    assert all("mm" in r.implausible for r in records)
    # clean_markers names them in the summary as left missing, with the reason
    take = MarkerSet(labels=("A", "B", "C", "D", "E"), positions=y, fps=100.0)
    res = clean_markers(take)
    assert not res.filled.any() and len(res.unfilled) == 4
    assert all(u.note and u.kind == "gap" and u.seconds == 0.8 for u in res.unfilled)
    assert any("4 gaps (320 samples) left missing: no plausible fill" in line for line in res.summary())
    assert "left missing: no plausible fill" in res.unfilled[0].size_text


def test_a_spike_run_no_fill_can_replace_is_listed_as_a_change_left_missing(monkeypatch):
    # review: a spike run whose every fill failed the guard lost its recorded samples, and neither the fixes nor
    # the left-missing list named it (phasespace_sample.c3d: 37 of 54 removed samples listed nowhere). Here the
    # guard rejects every fill: the spike's samples are removed (a change), listed among the fixes and as left
    # missing, and the summary counts them.
    from mocapkit.cleaning.markers import gaps

    monkeypatch.setattr(gaps, "implausible", lambda *a, **k: "rejected here")
    x = _walk()
    y = x.copy()
    y[80:82, 2] += np.array([0.0, 60.0, 0.0])  # a two-sample spike of 60 mm
    res = clean_markers(MarkerSet(labels=("A", "B", "C", "D", "E"), positions=y, fps=100.0))
    out = np.asarray(res.markers.positions)
    assert res.spikes[80:82, 2].all() and np.all(np.isnan(out[80:82, 2]))
    gone = np.isfinite(y).all(-1) & ~np.isfinite(out).all(-1)
    listed = np.zeros_like(gone)
    for fix in tuple(res.fixes) + tuple(res.unfilled):
        listed[fix.start:fix.end, "ABCDE".index(fix.marker)] = True
    assert gone.any() and not (gone & ~listed).any()
    spike = [u for u in res.unfilled if u.kind == "spike"]
    assert spike and spike[0] in res.fixes and "removed: left missing: no plausible fill" in spike[0].size_text
    assert any("1 of them spikes removed" in line for line in res.summary())


def test_the_guard_rejects_jumps_far_fills_and_fills_under_the_floor():
    from mocapkit.cleaning.markers.plausible import implausible, take_limits

    x = np.asarray(read_c3d(CMU).positions, dtype=np.float64)
    y = x.copy()
    y[300:340, 9] = np.nan
    stats = distance_stats(y)
    limits = take_limits(y, stats, donor_order(stats))
    good = x[300:340, 9]
    assert implausible(y, 9, 300, 340, good, limits) == ""  # the truth passes
    jump = good + [0.0, 0.0, 0.0]
    jump[0] += [400.0, 0, 0]  # a step at the gap's start (the ends must be met)
    assert "step" in implausible(y, 9, 300, 340, jump, limits)
    away = good + [0.0, 1500.0, 0.0]  # off the body: its rigid neighbours are seen (the steps at its ends aside)
    assert "rigid neighbour" in implausible(y, 9, 300, 340, away, dataclasses.replace(limits, step=limits.step + 1e9))
    axis, side, level = limits.floor
    assert (axis, side) == (2, -1)  # CMU is z-up: the samples pile up on the floor
    sunk = good.copy()
    sunk[:, 2] = np.linspace(good[0, 2], level - 60.0, 40)  # through the floor (rigid check aside)
    assert implausible(y, 9, 300, 340, sunk, dataclasses.replace(limits, neighbours=0))


def test_gap_lines_give_duration_method_and_expected_error():
    # trial16 #2: a gap line said only its frames and 'fill up to N mm off the straight line'
    cmu = read_c3d(CMU)
    x = np.asarray(cmu.positions, dtype=np.float64).copy()
    x[300:360, 9] = np.nan
    res = clean_markers(dataclasses.replace(cmu, positions=x))
    gap = [fx for fx in res.fixes if fx.kind == "gap"][0]
    assert gap.seconds == 60 / cmu.fps and gap.method in ("donors", "regression", "cubic", "linear", "lowrank")
    assert np.isfinite(gap.expected_mm) and gap.expected_mm > 0
    text = gap.size_text
    # an average of models is named so, after its best (it was named after the best alone: "linear, expected error
    # 184 mm; fill up to 83 mm off the straight line" for a fill that was no straight line)
    how = f"average of {gap.models} fills, the best {gap.method}" if gap.models > 1 else gap.method
    assert gap.models == 3 and text.startswith(f"{60 / cmu.fps:.2f} s, {how}")
    assert f"expected error {gap.expected_mm:.1f} mm" in text


def test_computed_points_are_modelled_and_left_as_read():
    # trial16 #5: Plug-in Gait's segment axes (HEDO/HEDA/HEDL/HEDP), CentreOfMass and CentreOfMassFloor are listed
    # in no POINT group; they were gap-filled as markers (the floor point's z, 0 by definition, filled at -3..15 mm)
    cmu = read_c3d(CMU)
    x = np.asarray(cmu.positions, dtype=np.float64)
    f = x.shape[0]
    head = x[:, :4].mean(axis=1)
    rng = np.random.default_rng(1)
    axes = np.linalg.qr(rng.normal(size=(3, 3)))[0] * 80.0  # an orthonormal triad, 80 mm long
    spin = np.cumsum(rng.normal(scale=0.01, size=(f, 3)), axis=0)
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_rotvec(spin).as_matrix()
    triad = head[:, None] + np.einsum("tij,kj->tki", rot, axes)
    com = x.mean(axis=1)
    floor = com * [1.0, 1.0, 0.0]
    extra = np.concatenate([head[:, None], triad, com[:, None], floor[:, None]], axis=1)
    extra[:30, :4] = np.nan  # gaps in the computed points, as in PiG_Motion-FlatFoot-Full.c3d
    extra[100:120, 5] = np.nan
    labels = tuple(cmu.labels) + ("HEDO", "HEDA", "HEDL", "HEDP", "CentreOfMass", "CentreOfMassFloor")
    take = MarkerSet(labels=labels, positions=np.concatenate([x, extra], axis=1), fps=cmu.fps)
    m = x.shape[1]
    assert take.computed().tolist() == [False] * m + [True] * 6
    res = clean_markers(take)
    assert np.array_equal(np.asarray(res.markers.positions)[:, m:], extra, equal_nan=True)
    assert not res.changed.any()
    # real markers named like a triad stay markers: four skin markers are no exact orthogonal triad
    fake = MarkerSet(labels=tuple(cmu.labels[:-4]) + ("KNEO", "KNEA", "KNEL", "KNEP"), positions=x, fps=cmu.fps)
    assert not fake.computed().any()
    # a file that records camera masks: a point no camera saw at any sample is computed, the others are not
    cams = np.ones(x.shape[:2], dtype=np.int64)
    cams[:, 3] = 0
    take = dataclasses.replace(cmu, cameras=cams, residuals=np.where(cams > 0, 0.5, 0.0))
    assert take.computed().tolist() == [i == 3 for i in range(m)]
    assert not cmu.computed().any()  # CMU records no camera masks at all: no evidence, all markers
