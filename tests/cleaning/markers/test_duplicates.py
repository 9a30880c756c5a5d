"""Duplicate labels (cleaning/markers/duplicates.py): a marker put on another marker's position, on real captures."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mocapkit.cleaning.markers import clean_markers, find_duplicates
from mocapkit.cleaning.markers.record import read_marker_record
from mocapkit.io import load_markers
from mocapkit.io.c3d import read_c3d

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"


@pytest.fixture(scope="module")
def cmu():
    return read_c3d(CMU)


def _label(labels, name):
    return [str(s).split(":")[-1] for s in labels].index(name)


@pytest.mark.parametrize("copy,right", [("LFWT", "RFWT"), ("RFWT", "LFWT")])
def test_a_marker_put_on_anothers_position_is_removed_filled_and_named(cmu, copy, right, tmp_path):
    # CMU 85_02 with one hip marker put on the other's position for 1 s (a labeller giving one point two labels):
    # before, the 120 copied samples were kept (up to 226 mm off) and 11 good samples beside them removed as spikes.
    x = np.asarray(cmu.positions, dtype=np.float64)
    a, b = _label(cmu.labels, copy), _label(cmu.labels, right)
    y = x.copy()
    y[405:525, a] = x[405:525, b]
    res = clean_markers(dataclasses.replace(cmu, positions=y))
    want = np.zeros(y.shape[:2], dtype=bool)
    want[405:525, a] = True
    assert np.array_equal(res.duplicates, want)
    assert np.array_equal(res.changed, want)  # every other sample comes back as recorded
    assert not res.spikes.any() and not res.filled.any()
    err = np.linalg.norm(res.markers.positions[405:525, a] - x[405:525, a], axis=-1)
    assert err.max() < 60.0  # the fill, 1 s long (the copy was 200-226 mm off)
    (fix,) = res.fixes
    assert (fix.kind, fix.marker, fix.other, fix.start, fix.end) == ("duplicate", cmu.labels[a], cmu.labels[b], 405, 525)
    said = "\n".join(res.summary())
    assert f"{cmu.labels[a]} frames 405-524: on {cmu.labels[b]}'s position (a duplicate label" in said
    assert "removed and filled" in said
    rec = read_marker_record(res.save(tmp_path / "take.clean.npz"))
    assert np.array_equal(rec.duplicates, want) and rec.count("duplicate") == 1


def test_two_markers_on_one_position_that_cannot_be_told_apart_are_named_and_left(cmu):
    # Both hip markers put on the point midway between them: the rigid neighbours put each about 110 mm away,
    # neither much further than the other, so which label is the copy is unknown: both are kept, and said so.
    x = np.asarray(cmu.positions, dtype=np.float64)
    a, b = _label(cmu.labels, "LFWT"), _label(cmu.labels, "RFWT")
    y = x.copy()
    y[405:525, a] = y[405:525, b] = 0.5 * (x[405:525, a] + x[405:525, b])
    (d,) = find_duplicates(y)
    assert not d.resolved and (d.start, d.end) == (405, 525)
    res = clean_markers(dataclasses.replace(cmu, positions=y), steps="swaps,duplicates")
    assert not res.duplicates.any() and not res.changed.any()
    (c,) = res.coincident
    assert c.kind == "coincident" and {c.marker, c.other} == {cmu.labels[a], cmu.labels[b]}
    assert any("which one cannot be told" in line for line in res.summary())


def test_markers_that_come_near_are_no_duplicates(cmu):
    # A hand on the head, two feet together: centimetres apart, not 0.0 mm. Put LFWT 5 mm from RFWT for 1 s.
    x = np.asarray(cmu.positions, dtype=np.float64)
    a, b = _label(cmu.labels, "LFWT"), _label(cmu.labels, "RFWT")
    y = x.copy()
    y[405:525, a] = x[405:525, b] + np.array([5.0, 0.0, 0.0])
    assert find_duplicates(y) == []


def test_real_captures_hold_no_duplicate(shared_data):
    # golfswing's club channels (1-6 mm apart, 0.0-0.03 mm in 250 frames) are one physical marker under several
    # labels; c3d.org's sub_labels RFOO/RTOP coincide by construction (0.0 mm in 224 of 333 frames): usually that
    # close, so not judged. No labelled pair of the complete captures is ever within 1 mm.
    names = ["c3d_markers/golfswing.c3d", "c3d_markers_recovery/85_12.c3d",
             "peer_files/BTKData/Input/C3DSamples/c3d.org/sample04/sub_labels.c3d"]
    for name in names:
        ms = load_markers(shared_data / name)
        keep = ~ms.modelled() & ~ms.unlabelled()
        assert find_duplicates(np.asarray(ms.positions)[:, keep], 10.0 * ms.unit_cm) == [], name


@pytest.mark.parametrize("start,end,jitter", [(405, 525, 1.0), (100, 600, 0.0), (100, 600, 1.0)])
def test_a_copy_that_jitters_or_covers_most_of_the_take_is_found(cmu, start, end, jitter):
    # LFWT on RFWT's position with 1 mm of noise per axis (1.6 mm apart on average, up to 4 mm: it broke into dozens
    # of 1-5 frame runs, most not told apart), or for 500 of the 810 frames (the pair's median distance over the take
    # was then 0.0 mm, and it was taken for one marker under two labels: nothing found).
    x = np.asarray(cmu.positions, dtype=np.float64)
    a, b = _label(cmu.labels, "LFWT"), _label(cmu.labels, "RFWT")
    y = x.copy()
    y[start:end, a] = x[start:end, b] + np.random.default_rng(1).normal(0.0, jitter, (end - start, 3))
    (d,) = find_duplicates(y)
    assert (d.marker, d.other, d.start, d.end, d.resolved) == (a, b, start, end, True)
    res = clean_markers(dataclasses.replace(cmu, positions=y), steps="swaps,duplicates")
    want = np.zeros(y.shape[:2], dtype=bool)
    want[start:end, a] = True
    assert np.array_equal(res.changed, want)
    err = np.linalg.norm(res.markers.positions[start:end, a] - x[start:end, a], axis=-1)
    assert err.max() < 60.0  # the fill (the copy was 200-230 mm off)
