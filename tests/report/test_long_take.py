"""The joint-angle report on a long take built from the bundled walk: framing, heat-map clicks, the last frame.

The take is 12_walk joined end to end (the walker jumps back to the start at each join, as takes joined
into one do), about 100 s at 120 fps, with a one-frame root jump of 8 m in the input; the report keeps
2,000 frames at a uniform rate, so one heat-map column holds about ten frames.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit.motion import concatenate, unit_scale_cm
from mocapkit.report.html import shown_frames, write_report
from tests.report.test_html import chromium_page, page_data

JUMP = 5000  # the input's root is 8 m away at this frame


@pytest.fixture(scope="module")
def takes():
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    long = concatenate([walk] * -(-12000 // walk.num_frames))[:12000]
    root = np.array(long.root_positions)
    root[JUMP, 0] += 800.0 / unit_scale_cm(long.skeleton)
    return walk, long, dataclasses.replace(long, root_positions=root)


@pytest.fixture(scope="module")
def flagged(takes):
    """One- to three-frame flag runs on odd frames of random joints, and an MDM high on them."""
    _, long, _ = takes
    F, J = long.num_frames, long.num_joints
    rng = np.random.default_rng(4)
    flags = np.zeros((F, J), bool)
    runs = []
    for f in np.sort(rng.choice(np.arange(101, F - 100, 2), 40, replace=False)):
        j, n = int(rng.integers(1, J)), int(rng.integers(1, 4))
        flags[f:f + n, j] = True
        runs.append((j, int(f)))
    mdm = np.clip(0.3 * rng.random((F, J)) + 0.6 * flags, 0, 1)
    return flags, mdm, runs


@pytest.fixture(scope="module")
def report(tmp_path_factory, takes, flagged):
    _, long, jumped = takes
    flags, mdm, _ = flagged
    return write_report(tmp_path_factory.mktemp("long") / "long.html", jumped, long, mdm=mdm, flags=flags,
                        max_frames=2000)


def test_the_last_frame_is_shown():
    for F, m in ((12000, 2000), (11003, 7200), (36000, 7200)):
        frames, _, _ = shown_frames(F, m)
        assert frames[-1] == F - 1
        flags = np.zeros(F, bool)
        flags[F // 2] = True
        assert shown_frames(F, m, flags)[0][-1] == F - 1


def test_a_joined_long_take_is_followed_at_the_size_of_one_clip(tmp_path, takes, report):
    walk, _, _ = takes
    one = page_data(write_report(tmp_path / "one.html", walk, walk))["view"]
    view = page_data(report)["view"]
    assert view["follow"]  # the whole take spans the room: its fixed framing would be a speck
    # the walker jumps back at every join, and the input's root 8 m away for a frame: neither shrinks the figure
    assert view["radius"]["follow"] < 1.25 * min(one["radius"]["fixed"], one["radius"]["follow"])


@pytest.fixture(scope="module")
def page(report):
    yield from chromium_page(report, "() => window.mocapkitReport && window.mocapkitReport.drawCount() > 0")


def test_a_click_on_a_red_cell_lands_on_a_flagged_frame_of_that_joint(page, flagged):
    flags, _, runs = flagged
    L = page.evaluate("() => window.mocapkitReport.heatmapLayout()")
    W, F = round(L["width"]), L["frames"]
    assert F / W > 5  # a column holds many frames
    names = page.evaluate("() => window.mocapkitReport.info.names")
    page.locator("#heatmap").scroll_into_view_if_needed()
    box = page.locator("#heatmap").bounding_box()
    for j, first in runs:
        c = next(c for c in range(W) if c * F // W <= first < (c + 1) * F // W)  # the image column holding it
        page.mouse.click(box["x"] + L["left"] + (c + 0.5) * L["width"] / W, box["y"] + L["top"] + (j + 0.5) * L["rowHeight"])
        got = page.evaluate("() => [window.mocapkitReport.frame(), window.mocapkitReport.selectedJointName()]")
        assert got[1] == names[j]
        assert flags[got[0], j], (names[j], first, got[0])


def test_the_last_frame_can_be_reached(page):
    page.evaluate("() => window.mocapkitReport.setFrame(11999)")
    assert page.evaluate("() => window.mocapkitReport.frame()") == 11999
    assert page.inner_text("#frame-label").startswith("frame 11999 / 11999")
    page.evaluate("() => { const s = document.getElementById('scrub'); s.value = s.max; s.dispatchEvent(new Event('input')); }")
    assert page.evaluate("() => window.mocapkitReport.frame()") == 11999


def test_the_frames_around_each_cut_are_shown_where_the_take_is_thinned(tmp_path, takes):
    """The walk joined end to end has a cut at every join (frame 343, 686, ...). Thinned to 2,000 of its 12,000
    frames, the viewer kept every 6th frame and the cuts' frames only where that stride fell on them; a cut's
    jump button then landed on the shown frame before it. Listed in the review, both frames around each cut are
    shown."""
    import base64

    from mocapkit.cleaning.whole_take import take_cuts
    from mocapkit.report.html import cut_rows

    _, long, _ = takes
    cuts = take_cuts(long)
    assert [c.frame for c in cuts[:3]] == [343, 686, 1029] and len(cuts) == 34
    review = {"changes": [], "decisions": {}, "cuts": cut_rows(cuts)}

    def shown(path):
        data = page_data(path)
        return set(np.frombuffer(base64.b64decode(data["frameList"]), dtype="<i4").tolist())

    around = {f for c in cuts for f in (c.frame - 1, c.frame)}
    assert not around <= shown(write_report(tmp_path / "bare.html", long, long, max_frames=2000))
    assert around <= shown(write_report(tmp_path / "cuts.html", long, long, max_frames=2000, review=review))
