"""Foreign stretches: a marker's label on another point from an edge up to a jump (mocapkit.cleaning.markers.foreign)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocapkit import samples
from mocapkit.cleaning.markers import clean_markers
from mocapkit.io import load_markers
from mocapkit.io.c3d import read_c3d

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"  # complete: 41 markers, 810 frames, 120 Hz, mm


@pytest.fixture(scope="module")
def eb015():
    return load_markers(samples.path("Eb015pr.c3d"))  # c3d.org's sample, 50 Hz, mm


def test_eb015pr_lft3s_first_43_frames_are_removed_and_its_good_samples_kept(eb015):
    # LFT3 sits 20-22 mm from LFT1 and 39-42 mm from LFT2 in frames 0-42, jumps 71 mm, and keeps the foot's geometry
    # (67-71, 75-80 mm) to the end. The wrong stretch goes; frames 43-45 (once removed as a "spike" bent towards
    # the wrong stretch) come back bit-identical.
    labels = list(eb015.labels)
    j = labels.index("LFT3")
    res = clean_markers(eb015)
    fix = [x for x in res.fixes if x.marker == "LFT3" and x.start < 46]
    assert [(x.kind, x.start, x.end) for x in fix] == [("foreign", 0, 43)]
    assert "71 mm jump" in fix[0].note and "LFT3 frames 0-42: another point under its label" in "\n".join(res.summary())
    out = res.markers.positions
    assert np.array_equal(out[43:300, j], eb015.positions[43:300, j])  # (a one-frame spike at 310 is removed)
    assert res.duplicate_mask[:43, j].all() and not res.duplicate_mask[43:, j].any()
    for other, lo, hi in (("LFT1", 60, 80), ("LFT2", 68, 88)):  # the fill keeps the foot's geometry
        d = np.linalg.norm(out[:43, j] - out[:43, labels.index(other)], axis=-1)
        assert np.all((d > lo) & (d < hi)), (other, d.min(), d.max())


def test_a_foreign_stretch_is_a_change_a_person_can_reject(eb015):
    from mocapkit.cleaning.markers.decisions import REJECT, apply, changes

    res = clean_markers(eb015)
    found = {c.id: c for c in changes(eb015, res.markers, res.fixes)}
    assert "foreign:LFT3:0-42" in found
    back = apply(eb015, res.markers, res.fixes, {"foreign:LFT3:0-42": REJECT})
    j = list(eb015.labels).index("LFT3")
    assert np.array_equal(back.positions[:43, j], eb015.positions[:43, j])


def test_no_foreign_stretch_on_a_complete_capture_nor_beside_its_occlusions():
    from mocapkit.cleaning.markers.foreign import find_foreign

    ms = read_c3d(CMU)
    x = np.asarray(ms.positions, dtype=np.float64)
    assert find_foreign(x) == []
    rng = np.random.default_rng(5)
    y = x.copy()
    for k in range(x.shape[1]):
        n = int(rng.integers(5, 61))
        s = int(rng.integers(0, x.shape[0] - n))
        y[s:s + n, k] = np.nan
        y[:int(rng.integers(0, 30)), k] = np.nan  # and a take that starts before each marker is seen
    assert find_foreign(y) == []


def test_a_label_on_another_point_after_an_occlusion_is_found():
    # 85_02's RWRA (1.3 mm spread to its wrist-bar partner RWRB) hidden for frames 300-330 comes back on a point
    # 40 mm further out along the bar that moves with the wrist for 20 frames, then jumps to the marker: the 20 frames
    # are found, nothing else.
    from mocapkit.cleaning.markers.foreign import find_foreign

    ms = read_c3d(CMU)
    x = np.asarray(ms.positions, dtype=np.float64)
    k = next(i for i, label in enumerate(ms.labels) if label.endswith("RWRA"))
    y = x.copy()
    y[300:331, k] = np.nan
    b = next(i for i, label in enumerate(ms.labels) if label.endswith("RWRB"))
    bar = x[331:351, k] - x[331:351, b]
    y[331:351, k] += 40.0 * bar / np.linalg.norm(bar, axis=-1, keepdims=True)  # 40 mm further along the bar
    found = find_foreign(y)
    assert [(g.marker, g.start, g.end) for g in found] == [(k, 331, 351)]
    y[331:351, k] = x[331:351, k]  # the marker itself back after the occlusion: nothing
    assert find_foreign(y) == []


def test_a_foreign_stretch_left_missing_by_max_gap_says_so_and_is_listed_with_the_gaps_left_missing(eb015, tmp_path):
    # Eb015pr's LFT3 0-42 (0.86 s) removed under --max-gap 0.3: no fill was tried, as for the 0.5-0.94 s gaps. It said
    # "left missing: no plausible fill" (a fill passes without --max-gap: 5.8 mm expected), was missing from
    # res.unfilled (the summary's and `info`'s "5 gaps left missing") and counted as "duplicate labels".
    res = clean_markers(eb015, max_gap_s=0.3)
    fix = next(x for x in res.fixes if x.kind == "foreign" and x.marker == "LFT3")
    assert not np.isfinite(fix.size_mm) and fix.too_long and fix.left == "longer than --max-gap (0.3 s)"
    assert fix.size_text.endswith("removed, left missing: longer than --max-gap (0.3 s)")
    assert "71 mm jump" in fix.note  # the evidence stays
    assert fix in res.unfilled and all(x.too_long for x in res.unfilled)
    text = "\n".join(res.summary())
    assert "no plausible fill" not in text
    assert "43 recorded samples removed as other points under their labels and left missing (longer than --max-gap)" in text
    assert "6 gaps (222 samples; 1 of them another point under a label, removed) left missing: longer than --max-gap" in text
    # `info` of the record counts them by the rule the summary uses (left_too_long, for a MarkerFix and a record's
    # dict alike): the CLI had its own copy of it on the dicts
    from mocapkit.cleaning.markers.clean import left_too_long
    from mocapkit.cleaning.markers.record import read_marker_record
    from tests.cli.helpers import run

    record = res.save(tmp_path / "eb.clean.npz")
    assert [left_too_long(d) for d in read_marker_record(record).unfilled] == [x.too_long for x in res.unfilled] == [True] * 6
    assert not left_too_long({"kind": "foreign", "note": "longer than --max-gap", "left": ""})  # its note is evidence
    assert not left_too_long({"kind": "gap", "note": "no plausible fill"}) and not left_too_long({"kind": "duplicate"})
    code, out, _ = run("info", record)
    assert code == 0 and "left missing 6 gaps (6 longer than --max-gap)" in " ".join(out.split())
