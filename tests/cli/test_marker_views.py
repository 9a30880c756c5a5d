"""Every view of one marker cleaning says the same changes (trial T3: findings 1, 5 and 6).

One batch of two short takes cut from the bundled 85_02.c3d (120 frames each) is cleaned once: ``dup.c3d`` with a
duplicate label (RTOE put on RMT5's position for 60 frames: its only change) and ``zeros.c3d`` with ten samples of
LKNE stored as exact (0, 0, 0) (read as gaps and filled). ``blind.c3d`` (300 frames) has RFHD hidden from frame 30
to its end (no seen stretch to validate the fill on: an unvalidated fill) and LWRA 100-139 (validated). The batch's
line, its index, the take's report and ``info`` of its record are read from that one run.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from mocapkit.io import load_markers, save_markers

from .helpers import run

CMU = Path(__file__).resolve().parents[1] / "data" / "85_02.c3d"


@pytest.fixture(scope="module")
def views(tmp_path_factory):
    """(in_dir, out_dir, stdout of clean-batch --report) of the two takes (module docstring)."""
    d = tmp_path_factory.mktemp("views")
    ms = load_markers(CMU)[:120]
    labels = list(ms.labels)
    dup = ms.positions.copy()
    dup[40:100, labels.index("Male:RTOE")] = dup[40:100, labels.index("Male:RMT5")]
    zeros = ms.positions.copy()
    zeros[50:60, labels.index("Male:LKNE")] = 0.0
    blind = load_markers(CMU)[:300]
    hidden = np.array(blind.positions)
    hidden[30:, labels.index("Male:RFHD")] = np.nan
    hidden[100:140, labels.index("Male:LWRA")] = np.nan
    (d / "in").mkdir()
    save_markers(blind.with_positions(hidden), d / "in" / "blind.c3d")
    save_markers(ms.with_positions(dup), d / "in" / "dup.c3d")
    save_markers(ms.with_positions(zeros), d / "in" / "zeros.c3d")
    code, stdout, stderr = run("clean-batch", d / "in", d / "out", "--jobs", "1", "--report")
    assert code == 0, stdout + stderr
    return d / "in", d / "out", stdout


def test_a_take_whose_only_change_is_a_duplicate_label_is_counted_changed_in_every_view(views):
    """Finding 1: the batch line said "nothing to change" and the index filed the take "untouched" (changed samples
    0) while 60 samples of RTOE were removed and filled; the clean's totals line did not count them."""
    _, out, stdout = views
    line = next(ln for ln in stdout.splitlines() if "dup.c3d ->" in ln)
    assert "nothing to change" not in line and "60 duplicate-label samples" in line, line
    index = (out / "index.html").read_text()
    row = next(r for r in index.split("<tr") if "dup.c3d" in r and "<td" in r)
    assert row.startswith(' class="changed"'), row
    assert '<td class="n">60</td><td>60 duplicate labels removed</td>' in row, row
    report = (out / "dup.report.html").read_text()
    assert "0 label swaps undone (0 samples), 1 duplicate label removed (60 samples)" in report
    code, said, _ = run("info", out / "dup.clean.npz")
    assert code == 0 and "changed  60 marker samples (filled 0, spikes removed 0, re-labelled 0, duplicate labels " \
                          "removed 60)" in said, said


def test_the_batch_row_read_back_from_a_record_counts_the_removed_samples_too(views):
    """The row of a take found written after an interrupt (batch_written) is read from its record: the same counts."""
    from mocapkit.batch_written import row_from_record
    from mocapkit.report.batch_index import take_counts

    inp, out, _ = views
    row = row_from_record(inp / "dup.c3d", out / "dup.c3d", out / "dup.clean.npz")
    assert (row["changed"], row["duplicates"], row["foreign"]) == (60, 60, 0)
    assert take_counts(row) == (60, "60 duplicate labels removed")


def test_unvalidated_fills_are_counted_apart_in_every_view(views):
    """The clean's summary and ``info`` said "2 gaps filled (310 samples; 1 of them unvalidated: expected error
    unknown)"; the batch's line ("310 filled samples"), its index ("310 filled") and a row read back from the record
    said the fills with no word of the one written unchecked."""
    from mocapkit.batch_written import row_from_record
    from mocapkit.report.batch_index import take_counts

    inp, out, stdout = views
    said = "1 of 2 gaps unvalidated: expected error unknown"
    line = next(ln for ln in stdout.splitlines() if "blind.c3d ->" in ln)
    assert f"310 filled samples ({said})" in line, line
    index = (out / "index.html").read_text()
    row = next(r for r in index.split("<tr") if "blind.c3d" in r and "<td" in r)
    assert f'<td class="n">310</td><td>310 filled ({said})</td>' in row, row
    back = row_from_record(inp / "blind.c3d", out / "blind.c3d", out / "blind.clean.npz")
    assert (back["gaps"], back["unvalidated"]) == (2, 1) and take_counts(back) == (310, f"310 filled ({said})")
    report = (out / "blind.report.html").read_text()
    assert "2 gaps filled (310 samples; 1 of them unvalidated: expected error unknown)" in report
    code, info, _ = run("info", out / "blind.clean.npz")
    assert code == 0 and "2 gaps filled (1 of them unvalidated: expected error unknown)" in info, info
    line = next(ln for ln in stdout.splitlines() if "dup.c3d ->" in ln)  # a take with no unvalidated fill: no word
    assert "unvalidated" not in line and "unvalidated" not in index.split("dup.c3d")[1].split("</tr>")[0]


def test_samples_read_from_zeros_as_gaps_are_said_in_the_report_and_the_record(views):
    """Finding 5: the reader's reading of exact (0, 0, 0) samples as gaps, which drives the fills, was said on the
    console only: the report's summary and ``info`` of the record never named it."""
    _, out, _ = views
    said = "read 10 samples stored as exact (0, 0, 0) as gaps (--keep-zeros keeps them as positions)"
    report = (out / "zeros.report.html").read_text()
    summary = report[report.index("<ul>"):report.index("</ul>")]
    assert f"<li>{said}</li>" in summary, summary
    code, info, _ = run("info", out / "zeros.clean.npz")
    assert code == 0 and f"zeros    {said}" in info, info
    code, info, _ = run("info", out / "dup.clean.npz")  # no zeros read: no such row
    assert "(0, 0, 0)" not in info


def test_marker_clean_draws_a_progress_bar_over_its_gaps(views, tmp_path, monkeypatch):
    """Finding 6: the marker path said nothing while it filled (36 s to minutes on 03_rolling.c3d); the bar is the
    joint-angle path's (tqdm on standard error, drawn where MOCAPKIT_PROGRESS=1 or on a terminal)."""
    inp, _, _ = views
    monkeypatch.setenv("MOCAPKIT_PROGRESS", "1")
    code, stdout, stderr = run("clean", inp / "zeros.c3d", "-o", tmp_path / "z.c3d")
    assert code == 0, stdout + stderr
    done = re.findall(r"fill zeros\.c3d: 100%.*?(\d+)/(\d+) ", stderr)
    assert done and done[-1][0] == done[-1][1] != "0", stderr
    assert "fill zeros.c3d" not in stdout


def test_sample_counts_split_the_removed_samples_into_duplicate_labels_and_foreign_stretches():
    """The record's one ``duplicates`` mask holds both kinds; the counts tell them apart by the fixes (Eb015pr's
    LFT3 0-42 is a foreign stretch: 43 samples the batch's line and index left out)."""
    from mocapkit.cleaning.markers.counts import counts_words, sample_counts
    from mocapkit.cleaning.markers.record import MarkerRecord
    from mocapkit.report.batch_index import take_counts

    f, m = 50, 3
    none = np.zeros((f, m), bool)
    filled, dups = none.copy(), none.copy()
    filled[10:15, 0] = True
    dups[0:43, 1] = True
    dups[20:25, 2] = True
    rec = MarkerRecord(labels=("A", "B", "C"), filled=filled, spikes=none, swapped=none, changed=filled | dups,
                       fixes=({"kind": "gap", "marker": "A", "start": 10, "end": 15},
                              {"kind": "foreign", "marker": "B", "start": 0, "end": 43},
                              {"kind": "duplicate", "marker": "C", "start": 20, "end": 25}),
                       unfilled=(), never_seen=(), unlabelled=(), duplicates=dups)
    counts = sample_counts(rec)
    assert counts == {"changed": 53, "filled": 5, "spikes": 0, "swapped": 0, "duplicates": 5, "foreign": 43}
    assert counts_words(counts) == "5 filled, 5 duplicate labels removed, 43 other points under their labels removed"
    assert take_counts({"spikes": 0, **counts}) == (53, counts_words(counts))
