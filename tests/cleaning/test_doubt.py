"""Which gap fills are said as doubtful (mocapkit.cleaning.deep.doubt), and how ``clean`` says them."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import doubt as D
from mocapkit.cleaning.deep.channels import encode


def test_the_end_line_joins_a_gaps_ends_and_holds_a_one_ended_one():
    x = np.array([[0.0, 170.0], [np.nan, np.nan], [np.nan, np.nan], [30.0, -170.0], [np.nan, 5.0]])
    line = D.end_line(x)
    assert np.allclose(line[:, 0], [0, 10, 20, 30, 30])  # the take's last frame: the seen end held
    assert np.allclose(line[1:3, 1], [170 + 20 / 3, 170 + 40 / 3])  # the short way round, not through 0
    assert np.array_equal(line[~np.isnan(x)], x[~np.isnan(x)])


def test_a_fill_far_from_the_line_is_doubtful_where_the_take_holds_the_channel_still():
    """A channel the take shows still (spread ~0) whose fill swings 20 deg off the line between the gap's ends is
    said; the same swing on a channel that moves 10 deg elsewhere in the take, or a fill on the line, is not."""
    F = 120
    t = np.arange(F)
    x = np.stack([np.full(F, 5.0), 10.0 * np.sin(t / 5.0), np.full(F, -3.0)], axis=1)
    gappy = x.copy()
    gappy[40:80] = np.nan
    bump = 20.0 * np.sin(np.pi * (t[40:80] - 39) / 41)
    fill = D.end_line(gappy)
    fill[40:80, 0] += bump
    fill[40:80, 1] += bump
    runs = D.doubtful_runs(gappy, fill, np.array([0, 1, 2]))
    assert [(g, a, b) for g, a, b, *_ in runs] == [(0, 40, 79)]
    assert runs[0][3] == pytest.approx(20.0, abs=0.1) and runs[0][4] == pytest.approx(0.0)
    assert D.doubtful_runs(gappy, D.end_line(gappy), np.array([0, 1, 2])) == []
    # one joint of three channels: its run is said once, by its farthest doubtful channel
    assert [(g, a, b) for g, a, b, *_ in D.doubtful_runs(gappy, fill, np.zeros(3, dtype=int))] == [(0, 40, 79)]
    # below DOUBT_MIN_DEG a departure is never said
    small = D.end_line(gappy)
    small[40:80, 0] += 0.4 * bump
    assert D.doubtful_runs(gappy, small, np.array([0, 1, 2])) == []


def test_clean_says_a_doubtful_fill_and_keeps_it(monkeypatch):
    """``clean``'s fill step and notes name a joint's run whose fill departs far from the line between the gap's
    ends (a still joint swung 40 deg); the fill is returned as made; a fill on the line says nothing."""
    from mocapkit.cleaning.deep import inference

    take = mocapkit.load(Path(__file__).parents[1] / "data" / "dataset-2_run_active_049.bvh")
    lay = deep.shipped_model("ebd", take).layout
    j = take.skeleton.joint_names.index("Head")
    rot = np.array(take.rotations)
    rot[:, j] = rot[0, j]  # the head held still through the take
    rot[15:50, j] = np.nan
    gappy = dataclasses.replace(take, rotations=rot)
    c = [k for k, n in enumerate(lay.names) if n.startswith("Head.")][0]
    bump = 40.0 * np.sin(np.pi * (np.arange(35) + 1) / 36)

    def swung(values, *a, **k):
        out = D.end_line(values)
        out[15:50, c] += bump
        return out

    monkeypatch.setattr(inference, "fill_channels", swung)
    res = mocapkit.clean(gappy, steps="fill")
    line = [n for n in res.notes if "look at it before use" in n]
    assert len(line) == 1 and line[0].startswith("Head frames 15-49: the gap prior's fill departs up to 40 deg")
    assert any(line[0] in s for s in res.summary() if s.startswith("fill"))
    made = encode(res.motion, lay)[0][15:50, c] - D.end_line(encode(gappy, lay)[0])[15:50, c]
    assert np.allclose((made + 180.0) % 360.0 - 180.0, bump, atol=1e-6)  # the fill is kept as made
    monkeypatch.setattr(inference, "fill_channels", lambda values, *a, **k: D.end_line(values))
    assert not any("look at it before use" in n for n in mocapkit.clean(gappy, steps="fill").notes)


def test_a_doubtful_run_at_the_takes_end_is_said_against_its_one_seen_end():
    """A run at the take's start or end has no line between two ends: its reference is its one seen end held, and
    the note says so (the first version said "the line between the gap's ends" of a gap that had one)."""
    F = 120
    x = np.stack([np.full(F, 5.0), np.full(F, -3.0)], axis=1)
    gappy = x.copy()
    gappy[90:, 0] = np.nan  # to the take's end
    gappy[:20, 1] = np.nan  # from the take's start
    fill = D.end_line(gappy)
    assert np.allclose(fill[90:, 0], 5.0) and np.allclose(fill[:20, 1], -3.0)
    fill[90:, 0] += np.linspace(0.0, 30.0, 30)  # drifts 30 deg off the held end
    fill[:20, 1] += np.linspace(25.0, 0.0, 20)
    runs = D.doubtful_runs(gappy, fill, np.array([0, 1]))
    assert [(g, a, b, side) for g, a, b, _, _, side in runs] == [(0, 90, 119, "end"), (1, 0, 19, "start")]
    assert runs[0][3] == pytest.approx(30.0)
    inner = gappy.copy()
    inner[90:, 0] = x[90:, 0]
    inner[40:60, 0] = np.nan
    swung = D.end_line(inner)
    swung[40:60, 0] += 20.0
    assert [(r[1], r[5]) for r in D.doubtful_runs(inner, swung, np.array([0, 1]))] == [(40, None)]
    note = deep.inference.doubt_note([("Hips", *runs[0][1:])])
    assert note.startswith("Hips frames 90-119: the gap prior's fill departs up to 30 deg from the gap's one seen end "
                           "(the gap runs to the take's end; the channel spreads 0 deg over the take's seen frames)")
    assert "line between" not in note
    assert "from the line between the gap's ends" in deep.inference.doubt_note([("Head", 40, 59, 20.0, 0.0, None)])
