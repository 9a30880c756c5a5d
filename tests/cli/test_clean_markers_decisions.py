"""``mocapkit clean IN.c3d -o OUT.c3d --decisions D.json`` and ``--steps detect`` on a real marker capture.

CMU 85_02 (41 markers, 120 Hz; tests/data, from the shared data's c3d_markers_recovery) cut to 600 frames, with a
60 mm one-sample spike on LKNE, a 40-frame gap on LANK and LTOE/RTHI swapped for 40 frames, put in by hand.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from mocapkit.cleaning.markers import decisions as md
from mocapkit.cleaning.markers.record import read_marker_record
from mocapkit.io import load_markers, save_markers

from ..shared import marker_decisions_file
from .helpers import one_error_line, run

CMU = Path(__file__).resolve().parents[1] / "data" / "85_02.c3d"
CHROMIUM = os.environ.get("MOCAPKIT_CHROMIUM", "/usr/bin/chromium")


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    """(folder, input, plain clean's output, its record): the capture with its errors, cleaned once with a report."""
    d = tmp_path_factory.mktemp("mdec")
    ms = load_markers(CMU)[:600]
    p = np.array(ms.positions)
    p[200, 5] += [60.0, 0.0, 0.0]                       # Male:LKNE: a spike
    p[300:340, 7] = np.nan                              # Male:LANK: a gap
    a = p[400:440, 10].copy()                           # Male:LTOE and Male:RTHI: a swap
    p[400:440, 10], p[400:440, 11] = p[400:440, 11], a
    inp = d / "in.c3d"
    save_markers(ms.with_positions(p), inp)
    out = d / "out.c3d"
    code, stdout, stderr = run("clean", inp, "-o", out, "--report", d / "out.html")
    assert code == 0, stderr + stdout
    return d, inp, out, d / "out.clean.npz"


def _same(a, b, cells=None) -> bool:
    """Positions (NaN-aware), residuals and camera masks of two captures equal (only at ``cells`` (F, M) if given)."""
    sel = np.ones(a.positions.shape[:2], bool) if cells is None else cells
    pa, pb = a.positions[sel], b.positions[sel]
    return (np.array_equal(pa, pb, equal_nan=True) and np.array_equal(a.residuals[sel], b.residuals[sel])
            and np.array_equal(a.cameras[sel], b.cameras[sel]))


_decide = marker_decisions_file


def test_each_fix_is_a_change_with_a_stable_id(capture):
    d, inp, out, record = capture
    ms = load_markers(inp)
    res = md.result_from_record(ms, read_marker_record(record))
    ids = [c.id for c in md.changes(ms, res.markers, res.fixes)]
    assert ids == ["spike:Male:LKNE:200-200", "gap:Male:LANK:300-339", "swap:Male:LTOE:400-439"]


@pytest.mark.parametrize("reject", ["spike:Male:LKNE:200-200", "gap:Male:LANK:300-339", "swap:Male:LTOE:400-439"])
def test_a_rejected_change_gets_the_input_back_and_only_there(capture, tmp_path, reject):
    d, inp, out, _ = capture
    dec = _decide(d, inp, {reject: "reject"}, f"{reject.split(':')[0]}.json")
    got = tmp_path / "decided.c3d"
    code, stdout, stderr = run("clean", inp, "-o", got, "--decisions", dec, "--record", d / "out.clean.npz")
    assert code == 0, stderr + stdout
    assert f"rejected {reject}" in stdout
    a, b, c = load_markers(inp), load_markers(out), load_markers(got)
    kind, marker, frames = reject.split(":", 1)[0], reject.rsplit(":", 1)[0].split(":", 1)[1], reject.rsplit(":", 1)[1]
    first, last = map(int, frames.split("-"))
    undone = np.zeros(a.positions.shape[:2], bool)
    cols = [a.labels.index(marker)] + ([a.labels.index("Male:RTHI")] if kind == "swap" else [])
    undone[first:last + 1, cols] = True
    assert _same(c, a, undone) and _same(c, b, ~undone)  # the input's samples there (missing: residual -1), clean's elsewhere
    assert not _same(a, b, undone)


def test_reject_all_gives_the_input_and_accept_all_plain_clean(capture, tmp_path):
    d, inp, out, _ = capture
    names = ["spike:Male:LKNE:200-200", "gap:Male:LANK:300-339", "swap:Male:LTOE:400-439"]
    none = _decide(d, inp, {k: "reject" for k in names}, "none.json")
    every = _decide(d, inp, {}, "all.json")
    for dec, want in ((none, inp), (every, out)):
        got = tmp_path / f"{dec.stem}.c3d"
        code, stdout, stderr = run("clean", inp, "-o", got, "--decisions", dec)  # no record: cleaned again
        assert code == 0, stderr + stdout
        assert _same(load_markers(got), load_markers(want))


def test_decisions_apply_only_to_the_cleaning_reviewed(capture, tmp_path):
    """A file made by the report keeps the digest of the samples reviewed: a new cleaning with other options (a
    shorter --max-gap leaves the gap unfilled) gives other samples and is refused, naming the record to pass;
    a hand-written file (no digest) is refused for a new cleaning and taken on its ids with --record; a report's
    file with a change taken out is refused (nobody reviewed the change left out)."""
    d, inp, out, record = capture
    dec = _decide(d, inp, {"spike:Male:LKNE:200-200": "reject"})
    got = tmp_path / "x.c3d"
    code, _, stderr = run("clean", inp, "-o", got, "--decisions", dec, "--max-gap", "0.1")
    assert code != 0 and "another cleaning" in stderr and f"--record {record}" in stderr and not got.exists()
    hand = _decide(d, inp, {"spike:Male:LKNE:200-200": "reject"}, "hand.json", stamped=False)
    code, _, stderr = run("clean", inp, "-o", got, "--decisions", hand)
    assert code != 0 and "no digest" in stderr and len(stderr.strip().splitlines()) == 1 and not got.exists()
    code, _, stderr = run("clean", inp, "-o", got, "--decisions", hand, "--record", record)
    assert code == 0, stderr
    doc = json.loads(dec.read_text())
    del doc["decisions"]["gap:Male:LANK:300-339"]
    cut = tmp_path / "cut.json"
    cut.write_text(json.dumps(doc))
    code, _, stderr = run("clean", inp, "-o", tmp_path / "y.c3d", "--decisions", cut, "--record", record)
    assert code != 0 and "not named" in stderr


@pytest.mark.parametrize("case", ["other capture", "truncated", "unknown id"])
def test_bad_decisions_are_refused_in_one_line_and_nothing_is_written(capture, tmp_path, case):
    d, inp, out, record = capture
    dec = json.loads(_decide(d, inp, {}, "ok.json").read_text())
    bad = tmp_path / "bad.json"
    if case == "other capture":
        dec["take"]["sha256"] = md.template(load_markers(CMU), [])["take"]["sha256"]
        bad.write_text(json.dumps(dec))
    elif case == "truncated":
        bad.write_text(json.dumps(dec)[:-40])
    else:
        dec["decisions"]["spike:Male:LKNE:201-201"] = "reject"
        bad.write_text(json.dumps(dec))
    code, stdout, stderr = run("clean", inp, "-o", tmp_path / "x.c3d", "--decisions", bad, "--record", record)
    assert code == 2 and one_error_line(stderr) and str(bad) in stderr, stderr + stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.json"]


def test_review_mode_names_the_changes_and_writes_the_capture_unchanged(capture, tmp_path):
    d, inp, out, _ = capture
    got = tmp_path / "review.c3d"
    code, stdout, stderr = run("clean", inp, "-o", got, "--steps", "detect", "--report", tmp_path / "r.html")
    assert code == 0, stderr + stdout
    assert "review mode (--steps detect): the capture unchanged" in stdout
    assert all(re.search(rf"^    {kind}\s+Male:{marker}\s", stdout, re.M)
               for kind, marker in (("swap", "LTOE"), ("spike", "LKNE"), ("gap", "LANK"))), stdout
    assert _same(load_markers(got), load_markers(inp))
    page = (tmp_path / "r.html").read_text()
    assert "review mode (--steps detect)" in page and "swap:Male:LTOE:400-439" in page
    # what the cleaning would do is said so: "1 gap filled (40 samples), 1 spike removed" read as done on a capture
    # whose samples are the input's, and `info` said the record as a real clean's ("changed 87 marker samples")
    assert re.search(r"^  would fill 1 gap \(40 samples\), remove 1 spike \(1 sample\), undo 1 label swap", stdout, re.M)
    assert not re.search(r"\d+ gaps? filled \(", stdout), stdout
    code, said, err = run("info", tmp_path / "review.clean.npz")
    assert code == 0, err
    said = " ".join(said.split())
    assert "marker cleaning record (mocapkit clean of a marker capture), review mode (--steps detect)" in said
    assert "changed none: its output holds the input's samples; cleaning would change " in said, said
    code, said, err = run("info", d / "out.clean.npz")  # a real clean's record says what it changed
    assert code == 0 and "review mode" not in said and "would" not in said and re.search(r"changed\s+\d+ marker samples", said)


def test_reject_one_change_in_the_report_download_and_apply(capture, tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api")
    if not os.access(CHROMIUM, os.X_OK):
        pytest.skip(f"no Chromium executable at {CHROMIUM}")
    d, inp, out, record = capture
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--headless", "--no-sandbox", "--disable-gpu"])
        try:
            page = browser.new_context(accept_downloads=True).new_page()
            errors = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto((d / "out.html").as_uri())
            assert page.evaluate("window.mocapkitReview.changes()") == [
                "spike:Male:LKNE:200-200", "gap:Male:LANK:300-339", "swap:Male:LTOE:400-439"]
            page.uncheck("tr[data-change='gap:Male:LANK:300-339'] input.accept")
            page.click("tr[data-change='gap:Male:LANK:300-339'] button.jump")
            assert page.evaluate("window.markerReport.frame()") == 300
            with page.expect_download() as info:
                page.click("#download-decisions")
            path = tmp_path / info.value.suggested_filename
            info.value.save_as(path)
            assert not errors, errors
        finally:
            browser.close()
    assert path.name == "in.decisions.json"
    got = tmp_path / "decided.c3d"
    code, stdout, stderr = run("clean", inp, "-o", got, "--decisions", path, "--record", record)
    assert code == 0, stderr + stdout
    a, b, c = load_markers(inp), load_markers(out), load_markers(got)
    undone = np.zeros(a.positions.shape[:2], bool)
    undone[300:340, a.labels.index("Male:LANK")] = True
    assert _same(c, a, undone) and _same(c, b, ~undone)
    assert np.isnan(c.positions[300:340, a.labels.index("Male:LANK")]).all()


def test_the_decided_summary_says_what_a_joint_angle_takes_says(capture, tmp_path):
    """One printer for both kinds of take: a hand-written file naming one change, applied to the record, gets the
    same notes (taken on its ids; the changes it does not name accepted) and the same words as a joint-angle take's
    (tests/cli/test_clean_decisions.py)."""
    d, inp, out, record = capture
    hand = _decide(d, inp, {"gap:Male:LANK:300-339": "reject"}, "hand1.json", stamped=False)
    doc = json.loads(hand.read_text())
    doc["decisions"] = {"gap:Male:LANK:300-339": "reject"}
    hand.write_text(json.dumps(doc))
    got = tmp_path / "one.c3d"
    code, stdout, stderr = run("clean", inp, "-o", got, "--decisions", hand, "--record", record)
    assert code == 0, stderr + stdout
    lines = stdout.splitlines()
    assert lines[0] == (f"wrote {got}: {hand} applied to the record {record} (nothing cleaned again): 2 of 3 changes "
                        f"accepted, 1 rejected; 81 marker samples of {load_markers(inp).positions[:, :, 0].size} "
                        f"changed, every other sample is in.c3d's"), lines[0]
    assert lines[1] == (f"note: {hand} keeps no digest of the cleaning it was made on (an earlier mocapkit's file, or "
                        "written by hand): it was applied to the record as its change ids match; make sure that record "
                        "is the one reviewed")
    assert lines[2] == f"note: {hand} names 1 of 3 changes: the 2 it does not name were accepted"
    assert lines[3].startswith("  rejected gap:Male:LANK:300-339: Male:LANK frames 300-339 (gap, ")


def _report_data(path: Path) -> dict:
    import re

    text = path.read_text(encoding="utf-8")
    return json.loads(re.search(r'<script id="data" type="application/json">(.*?)</script>', text, re.S)
                      .group(1).replace("<\\/", "</"))


def test_a_decided_report_draws_the_capture_written(capture, tmp_path):
    """The report rendered after decisions draws OUT: a rejected gap fill is missing there (not drawn filled), an
    accepted swap is drawn undone; its fixes table lists the accepted fixes, its list every change."""
    d, inp, out, record = capture
    dec = _decide(d, inp, {"gap:Male:LANK:300-339": "reject"}, "report.json")
    got, page = tmp_path / "decided.c3d", tmp_path / "decided.html"
    code, stdout, stderr = run("clean", inp, "-o", got, "--decisions", dec, "--record", record, "--report", page)
    assert code == 0, stderr + stdout
    D = _report_data(page)
    assert D["frames"] == list(range(600))
    written = load_markers(got)
    lank, ltoe = written.labels.index("Male:LANK"), written.labels.index("Male:LTOE")
    assert all(D["pos"][f][lank] is None and D["kind"][f][lank] == 0 for f in range(300, 340))
    assert np.isnan(written.positions[300:340, lank]).all()
    assert all(D["kind"][f][ltoe] == 3 for f in range(400, 440))
    text = page.read_text()
    assert "Fixes (2)" in text and "swap:Male:LTOE:400-439" in text and "gap:Male:LANK:300-339" in text


def test_jump_to_rings_and_names_its_marker_in_the_viewer(capture):
    """A change's jump (the accept/reject list) and a fix's link (the fixes table) select its marker: the viewer
    rings it in blue and names it; nothing is ringed before."""
    from tests.report.test_html import chromium_page

    d, inp, out, record = capture
    blue = """() => { const c = document.getElementById('view');
        const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; let n = 0;
        for (let i = 0; i < d.length; i += 4) if (Math.abs(d[i] - 31) < 20 && Math.abs(d[i + 1] - 120) < 20
            && Math.abs(d[i + 2] - 180) < 20 && d[i + 3] > 200) n++;
        return n; }"""
    for page in chromium_page(d / "out.html", "() => document.getElementById('flabel').textContent.length > 0"):
        assert page.evaluate(blue) == 0
        page.click("tr[data-change='spike:Male:LKNE:200-200'] button.jump")
        assert page.evaluate("window.markerReport.frame()") == 200
        assert page.evaluate("window.markerReport.selected()") == load_markers(inp).labels.index("Male:LKNE")
        assert page.evaluate(blue) > 40 and "Male:LKNE" in page.inner_text("#flabel")
        page.click("a.fix[data-frame='400']")
        assert page.evaluate("window.markerReport.selected()") == load_markers(inp).labels.index("Male:LTOE")
        assert page.evaluate(blue) > 40 and "Male:LTOE" in page.inner_text("#flabel")


def test_reject_all_gives_back_gaps_the_file_stored_as_zeros_bit_for_bit(tmp_path):
    # an exporter that stores an occlusion as (0, 0, 0) with a non-negative residual (Qualisys: 03_rolling.c3d):
    # read as gaps and filled by the cleaning; rejecting every fill gives back the zeros and residuals as stored
    import c3d

    ms = load_markers(CMU)[:400]
    p, res = np.array(ms.positions), np.array(ms.residuals)
    p[200:230, 7], res[200:230, 7] = 0.0, 2.0  # Male:LANK
    inp = save_markers(ms.with_positions(p, residuals=res), tmp_path / "in.c3d")
    code, stdout, stderr = run("clean", inp, "-o", tmp_path / "out.c3d", "--report", tmp_path / "out.html")
    assert code == 0, stderr + stdout
    base = load_markers(inp)
    rec = md.result_from_record(base, read_marker_record(tmp_path / "out.clean.npz"))
    ids = [c.id for c in md.changes(base, rec.markers, rec.fixes)]
    assert "gap:Male:LANK:200-229" in ids
    dec = _decide(tmp_path, inp, {k: "reject" for k in ids})
    got = tmp_path / "none.c3d"
    code, stdout, stderr = run("clean", inp, "-o", got, "--decisions", dec, "--record", tmp_path / "out.clean.npz")
    assert code == 0, stderr + stdout

    def points(path):
        with open(path, "rb") as fh:
            return np.array([f.copy() for _, f, _ in c3d.Reader(fh).read_frames()])  # (F, M, 5): x y z res cams

    a, b = points(inp), points(got)
    assert np.all((a == b) | (np.isnan(a) & np.isnan(b)))
