"""The report's changes list (review.js) end to end in headless Chromium: reject a change, download, apply."""

from __future__ import annotations

import contextlib
import json
import os

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, samples
from mocapkit.cleaning import decisions as D
from mocapkit.cleaning.pipeline import CleanResult
from mocapkit.cli import main
from mocapkit.report.plain import plain_sentence

CHROMIUM = os.environ.get("MOCAPKIT_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]


@pytest.fixture(scope="module")
def browser():
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (pip install -e '.[test]')")
    if not os.access(CHROMIUM, os.X_OK):
        pytest.skip(f"no Chromium executable at {CHROMIUM} (apt-get install chromium, or set MOCAPKIT_CHROMIUM)")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()


@contextlib.contextmanager
def opened(browser, path):
    """A Chromium page on the report at ``path``, once drawn and its review ready; no page error by its close."""
    ctx = browser.new_context(viewport={"width": 1280, "height": 900})
    pg = ctx.new_page()
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.goto(path.resolve().as_uri())
    pg.wait_for_function("() => window.mocapkitReport && window.mocapkitReview && window.mocapkitReport.drawCount() > 0",
                         timeout=60000)
    yield pg
    ctx.close()
    assert errors == []


@pytest.fixture(scope="module")
def cleaned(tmp_path_factory):
    """12_walk with real-style errors, cleaned by `mocapkit clean` with its report."""
    d = tmp_path_factory.mktemp("review")
    bad, _, _ = corrupt.real_errors(mocapkit.load(samples.path("12_walk.amc")), n_errors=4, seed=11)
    inp = d / "walk_bad.npz"
    mocapkit.save(bad, inp)
    assert main(["clean", str(inp), "-o", str(d / "walk.npz"), "--report", str(d / "walk.html")]) == 0
    return d, inp


@pytest.fixture
def page(browser, cleaned):
    d, _ = cleaned
    ctx = browser.new_context(accept_downloads=True, viewport={"width": 1280, "height": 900})
    pg = ctx.new_page()
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    pg.goto((d / "walk.html").resolve().as_uri())
    pg.wait_for_function("() => window.mocapkitReport && window.mocapkitReview && window.mocapkitReport.drawCount() > 0",
                         timeout=60000)
    yield pg
    ctx.close()
    assert errors == []


def test_page_lists_every_change_with_accept_and_jump(page, cleaned):
    d, inp = cleaned
    found = D.changes(CleanResult.load(d / "walk.clean.npz"), mocapkit.load(inp))
    rows = page.locator("#changes tbody tr")
    assert rows.count() == len(found) > 1
    for k, c in enumerate(found):
        cells = rows.nth(k).locator("td")
        assert rows.nth(k).get_attribute("data-change") == c.id
        assert cells.nth(1).inner_text() == c.joint and cells.nth(3).inner_text() == c.step
        assert cells.nth(2).inner_text() == f"{c.first}-{c.last}"
        assert cells.nth(4).inner_text() == f"{c.max_deg:.1f} deg"
        assert rows.nth(k).locator("input.accept").is_checked()  # accepted by default
    assert page.inner_text("#decision-count") == f"{len(found)} accepted, 0 rejected"
    c = found[-1]
    rows.nth(len(found) - 1).locator("button.jump").click()
    assert page.evaluate("() => window.mocapkitReport.frame()") == c.first
    assert page.evaluate("() => window.mocapkitReport.selectedJointName()") == c.joint


IN_VIEW = """(sel) => { const r = document.querySelector(sel).getBoundingClientRect();
    return r.bottom > 0 && r.top < window.innerHeight; }"""


def test_the_viewer_steps_through_the_changes_and_the_reviewer_keeps_their_place(page, cleaned):
    """From a row's jump, the viewer's own bar shows, accepts or rejects the next and previous changes
    without scrolling, and takes the reviewer back to the row of the change on show."""
    d, inp = cleaned
    found = D.changes(CleanResult.load(d / "walk.clean.npz"), mocapkit.load(inp))
    assert len(found) >= 3
    page.set_viewport_size({"width": 1280, "height": 500})  # the list below the fold
    page.locator("#changes tbody tr").nth(0).locator("button.jump").click()
    assert page.evaluate(IN_VIEW, "#viewer") and page.evaluate(IN_VIEW, "#change-nav")
    assert not page.evaluate(IN_VIEW, '#changes tbody tr[data-change="%s"]' % found[1].id)
    y = page.evaluate("() => window.scrollY")
    for k in (1, 2):
        page.click("#next-change")
        c = found[k]
        assert page.evaluate("() => [window.mocapkitReport.frame(), window.mocapkitReport.selectedJointName()]") == \
            [c.first, c.joint]
        assert page.inner_text("#change-label").startswith(f"change {k + 1} of {len(found)}: {c.joint}")
        assert page.evaluate("() => window.scrollY") == y  # the viewer stays where it is
    page.uncheck("#change-accept")  # reject the change on show from the viewer's bar
    assert page.evaluate("() => window.mocapkitReview.decisions().decisions")[found[2].id] == "reject"
    assert not page.locator(f'#changes tbody tr[data-change="{found[2].id}"] input.accept').is_checked()
    page.click("#prev-change")
    assert page.evaluate("() => window.mocapkitReport.frame()") == found[1].first
    assert page.is_checked("#change-accept")
    page.click("#back-to-list")
    row = f'#changes tbody tr[data-change="{found[1].id}"]'
    assert page.evaluate(IN_VIEW, row) and "current" in page.get_attribute(row, "class")


def test_reject_download_and_apply(page, cleaned, tmp_path, capsys):
    d, inp = cleaned
    ids = page.evaluate("() => window.mocapkitReview.changes()")
    rejected = ids[1]
    page.locator(f'#changes tr[data-change="{rejected}"] input.accept').uncheck()
    assert page.locator(f'#changes tr[data-change="{rejected}"]').get_attribute("class") == "rejected"
    assert page.inner_text("#decision-count") == f"{len(ids) - 1} accepted, 1 rejected"
    with page.expect_download() as info:
        page.click("#download-decisions")
    download = info.value
    assert download.suggested_filename == "walk_bad.decisions.json"
    path = tmp_path / download.suggested_filename
    download.save_as(path)
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert doc["format"] == D.FORMAT and doc["take"]["name"] == "walk_bad.npz"
    assert doc["decisions"] == {i: (D.REJECT if i == rejected else D.ACCEPT) for i in ids}

    out = tmp_path / "walk_final.npz"
    rc = main(["clean", str(inp), "-o", str(out), "--decisions", str(path), "--record", str(d / "walk.clean.npz")])
    assert rc == 0, capsys.readouterr()
    take, res, got = mocapkit.load(inp), CleanResult.load(d / "walk.clean.npz"), mocapkit.load(out)
    acc = D.accepted_cells(res, {rejected: D.REJECT})
    c = next(c for c in D.changes(res, take) if c.id == rejected)
    assert not acc[c.first:c.last + 1, c.joint_index].any() and acc.sum() == res.changed.sum() - c.frames
    full = D.apply(take, res, {})
    want = np.where(acc[..., None], full.rotations, take.rotations)
    assert np.ascontiguousarray(got.rotations).tobytes() == want.tobytes()
    assert np.ascontiguousarray(got.root_positions).tobytes() == np.ascontiguousarray(take.root_positions).tobytes()


def test_reject_all_and_accept_all(page):
    ids = page.evaluate("() => window.mocapkitReview.changes()")
    page.click("#reject-all")
    assert set(page.evaluate("() => window.mocapkitReview.decisions().decisions").values()) == {D.REJECT}
    assert page.locator("#changes input.accept:checked").count() == 0
    page.click("#accept-all")
    assert page.locator("#changes input.accept:checked").count() == len(ids)


def test_review_mode_lists_every_flag_with_the_rule_that_raised_it(browser, tmp_path):
    """`clean --steps detect --report`: nothing is changed, and the report lists every flagged segment with why."""
    bad, _, _ = corrupt.real_errors(mocapkit.load(samples.path("12_walk.amc")), n_errors=4, seed=11)
    inp = tmp_path / "walk_bad.npz"
    mocapkit.save(bad, inp)
    assert main(["clean", str(inp), "-o", str(tmp_path / "walk.npz"), "--steps", "detect",
                 "--report", str(tmp_path / "walk.html")]) == 0
    res = CleanResult.load(tmp_path / "walk.clean.npz")
    flags = D.flag_segments(res)
    assert not res.changed.any() and len(flags) > 1 and all(f["why"] for f in flags)
    assert sum(f["last"] - f["first"] + 1 for f in flags) == res.flags.sum()
    with opened(browser, (tmp_path / "walk.html")) as pg:
        assert pg.inner_text("#changes p:last-of-type").strip() == "The cleaning changed nothing."
        # nothing to decide, and the page says so: no accept/reject/download buttons that would do nothing
        assert pg.inner_text("#nothing-to-decide").startswith("Nothing to decide: the cleaning changed no sample")
        assert "review mode" in pg.inner_text("#nothing-to-decide")
        assert "Accept or reject each one" not in pg.inner_text("#changes")
        for button in ("#accept-all", "#reject-all", "#download-decisions", "#decision-count", "#change-nav"):
            assert pg.locator(button).count() == 0, button
        rows = pg.locator("#flags tbody tr")
        assert rows.count() == len(flags)
        for k, f in enumerate(flags):
            cells = rows.nth(k).locator("td")
            assert cells.nth(0).inner_text() == f["joint"]
            assert cells.nth(1).inner_text() == (str(f["first"]) if f["first"] == f["last"] else f"{f['first']}-{f['last']}")
            # an animator's sentence first, the rules' words as its detail
            assert cells.nth(2).locator(".detail").inner_text() == "(" + ", ".join(f["why"]) + ")"
            assert cells.nth(2).inner_text().startswith(plain_sentence("", f["why"]))
            assert cells.nth(3).inner_text() == "left as it was: the repair step did not run"
        f = flags[-1]
        rows.nth(len(flags) - 1).locator("button.jump").click()
        assert pg.evaluate("() => window.mocapkitReport.frame()") == f["first"]
        assert pg.evaluate("() => window.mocapkitReport.selectedJointName()") == f["joint"]


def test_jump_lands_on_each_change_and_flag_of_a_long_take(browser, tmp_path):
    """A take over max_frames (every 3rd frame shown): each "jump to frame N" shows frame N itself, rejected or not."""
    from mocapkit.cleaning.pipeline import clean
    from mocapkit.motion import concatenate, unit_scale_cm
    from mocapkit.report.html import write_report

    take = concatenate([mocapkit.load(samples.path("12_walk.amc"))] * 3)[:1000]
    bad, _, _ = corrupt.real_errors(take, n_errors=6, seed=11)
    res = clean(bad)
    found = D.changes(res, bad)
    assert sum(c.first % 3 != 0 for c in found) >= 3  # most jump targets are off the grid 0, 3, 6, ...
    rejected = next(c for c in found if c.first % 3)
    chosen = {rejected.id: D.REJECT}
    cleaned, changed = D.apply(bad, res, chosen), D.accepted_cells(res, chosen)
    assert not changed[rejected.first, rejected.joint_index]
    out = write_report(tmp_path / "long.html", bad, cleaned, mdm=res.mdm, flags=res.flags, changed=changed,
                       max_frames=400, review=D.review(bad, res, take="bad.npz", output="out.npz", decisions=chosen))
    with opened(browser, out) as pg:
        assert pg.evaluate("() => window.mocapkitReport.info.stride") == 3
        scale = unit_scale_cm(take.skeleton)
        rows = pg.locator("#changes tbody tr")
        assert rows.count() == len(found)
        for k, c in enumerate(found):
            rows.nth(k).locator("button.jump").click()
            assert pg.evaluate("() => [window.mocapkitReport.frame(), window.mocapkitReport.selectedJointName()]") == \
                [c.first, c.joint], c.id
            # the pose drawn is that frame's, in both panels
            for which, motion in (("original", bad), ("cleaned", cleaned)):
                got = np.array(pg.evaluate(f"() => window.mocapkitReport.position('{which}', {c.first}, {c.joint_index})"), float)
                want = motion[c.first].global_positions()[0, c.joint_index] * scale
                assert np.abs(got - want).max() < 0.06, (c.id, which)
        flags = D.flag_segments(res)
        frows = pg.locator("#flags tbody tr")
        assert frows.count() == len(flags) > 0
        for k, f in enumerate(flags):
            frows.nth(k).locator("button.jump").click()
            assert pg.evaluate("() => window.mocapkitReport.frame()") == f["first"]


def test_decisions_from_a_cleaning_with_a_context_apply_to_its_values_only(browser, tmp_path, capsys):
    """Trial 24: reviewed a cleaning with --context, rejected one change, applied as the page said without
    --record: the take was cleaned again with the default context, the ids matched, and every accepted cell got
    values nobody saw. Now the page names the record, the file keeps the digest of the cleaning reviewed, and
    applying without the record is refused; with it OUT holds exactly the reviewed values."""
    take = mocapkit.load(samples.path("12_walk.amc"))
    bad, _, _ = corrupt.real_errors(take, n_errors=4, seed=11)
    inp, ctx = tmp_path / "walk_bad.npz", tmp_path / "ctx"
    ctx.mkdir()
    mocapkit.save(bad, inp)
    mocapkit.save(take, ctx / "walk_ref.npz")
    record = tmp_path / "walk.clean.npz"
    assert main(["clean", str(inp), "-o", str(tmp_path / "walk.npz"), "--report", str(tmp_path / "walk.html"),
                 "--context", str(ctx)]) == 0
    bctx = browser.new_context(accept_downloads=True, viewport={"width": 1280, "height": 900})
    pg = bctx.new_page()
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.goto((tmp_path / "walk.html").resolve().as_uri())
    pg.wait_for_function("() => window.mocapkitReport && window.mocapkitReview && window.mocapkitReport.drawCount() > 0",
                         timeout=60000)
    assert f"--decisions walk_bad.decisions.json --record {record}" in pg.inner_text("#apply-command")
    ids = pg.evaluate("() => window.mocapkitReview.changes()")
    rejected = ids[0]
    pg.locator(f'#changes tr[data-change="{rejected}"] input.accept').uncheck()
    with pg.expect_download() as info:
        pg.click("#download-decisions")
    path = tmp_path / info.value.suggested_filename
    info.value.save_as(path)
    bctx.close()
    assert errors == []
    capsys.readouterr()

    out = tmp_path / "final.npz"
    assert main(["clean", str(inp), "-o", str(out), "--decisions", str(path)]) == 2  # as the page said before
    err = capsys.readouterr().err
    assert f"{path}: made on another cleaning than this new one: reviewed with --context {ctx.resolve()} (now " \
           f"without it)" in err and f"--record {record}" in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists() and not (tmp_path / "final.clean.npz").exists()

    ctx.rename(tmp_path / "ctx_moved")  # the page's command (with --record) reads no context: one moved since is fine
    assert main(["clean", str(inp), "-o", str(out), "--decisions", str(path), "--record", str(record)]) == 0
    res, got = CleanResult.load(record), mocapkit.load(out)
    acc = D.accepted_cells(res, {rejected: D.REJECT})
    assert acc.sum() == res.changed.sum() - next(c for c in D.changes(res, bad) if c.id == rejected).frames
    want = np.array(bad.rotations)
    want[acc] = res.samples["rotations"][acc[res.changed]]  # the values the report showed, bit for bit
    assert np.ascontiguousarray(got.rotations).tobytes() == want.tobytes()


def test_the_pages_apply_command_works_as_copied_for_an_amc_whose_asf_is_elsewhere(browser, tmp_path):
    """An AMC read with --asf from another folder and --amc-fps: the page's command names the input as given, its
    --asf and --amc-fps (without them the take read has no skeleton or another rate: refused), and run as shown,
    from another folder, it applies the downloaded decisions."""
    import shlex
    import shutil

    from tests.cli.helpers import run

    (tmp_path / "skel").mkdir()
    (tmp_path / "takes").mkdir()
    (tmp_path / "elsewhere").mkdir()
    asf = tmp_path / "skel" / "12.asf"
    shutil.copy(samples.path("12.asf"), tmp_path / "takes" / "walk_bad.asf")
    bad, _, _ = corrupt.real_errors(mocapkit.load(samples.path("12_walk.amc")), n_errors=4, seed=11)
    inp = mocapkit.save(bad, tmp_path / "takes" / "walk_bad.amc")
    shutil.move(tmp_path / "takes" / "walk_bad.asf", asf)  # the ASF is not beside the AMC
    code, _, err = run("clean", inp, "-o", tmp_path / "walk.bvh", "--asf", asf, "--amc-fps", "60",
                       "--steps", "fill,detect,repair", "--report", tmp_path / "walk.html")
    assert code == 0, err
    bctx = browser.new_context(accept_downloads=True, viewport={"width": 1280, "height": 900})
    pg = bctx.new_page()
    pg.goto((tmp_path / "walk.html").resolve().as_uri())
    pg.wait_for_function("() => window.mocapkitReview && window.mocapkitReview.changes().length > 0", timeout=60000)
    text = pg.inner_text("#apply-command")
    rejected = pg.evaluate("() => window.mocapkitReview.changes()")[0]
    pg.locator(f'#changes tr[data-change="{rejected}"] input.accept').uncheck()
    with pg.expect_download() as info:
        pg.click("#download-decisions")
    info.value.save_as(tmp_path / "elsewhere" / info.value.suggested_filename)
    bctx.close()
    command = shlex.split(text.split("run: ", 1)[1].split(" (the record", 1)[0])
    assert command[:2] == ["mocapkit", "clean"] and command[2] == str(inp)
    assert command[command.index("--asf") + 1] == str(asf) and command[command.index("--amc-fps") + 1] == "60"
    command[command.index("OUT")] = "final.bvh"
    code, out, err = run(*command[1:], cwd=tmp_path / "elsewhere")
    assert code == 0, err
    assert "1 rejected" in out and (tmp_path / "elsewhere" / "final.bvh").is_file()


def test_unticking_one_side_of_a_swap_unticks_the_other_and_says_why(page, cleaned):
    # walk_bad's upper arms are swapped over frames 316-335 and put back by the mirrored exchange: one side alone
    # would leave both arms with one side's motion (mocapkit.cleaning.ties), so the two rows move together
    from mocapkit.cleaning.ties import SWAP_WHY

    sides = ["repair:lhumerus:316-335", "repair:rhumerus:316-335"]
    n = len(page.evaluate("() => window.mocapkitReview.changes()"))

    def boxes():
        return [page.locator(f'#changes tr[data-change="{i}"] input.accept').is_checked() for i in sides]

    page.locator(f'#changes tr[data-change="{sides[1]}"] input.accept').uncheck()
    assert boxes() == [False, False]
    assert page.inner_text("#decision-count") == f"{n - 2} accepted, 2 rejected"
    assert [page.evaluate("() => window.mocapkitReview.decisions()")["decisions"][i] for i in sides] == ["reject"] * 2
    why = page.locator(f'#changes tr[data-change="{sides[1]}"] td.reason').inner_text()
    assert f"(accepted or rejected with {sides[0]}: {SWAP_WHY})" in why
    page.locator(f'#changes tr[data-change="{sides[0]}"] input.accept').check()
    assert boxes() == [True, True]
    # the viewer's own accept box, on one side, decides both
    k = page.evaluate("() => window.mocapkitReview.changes()").index(sides[0])
    page.evaluate(f"() => window.mocapkitReview.jump({k})")
    page.locator("#change-accept").uncheck()
    assert boxes() == [False, False]


def test_tied_changes_are_accepted_and_rejected_together(browser, tmp_path):
    # CMU 85_02 (tests/data) with two swaps chained over one marker whose cleaned samples are not what exchanging
    # their recorded trajectories in order gives (their columns exchanged instead), and a spike inside them:
    # mocapkit.cleaning.markers.decisions.tied ties the three, and the row says why
    import dataclasses
    from pathlib import Path

    from mocapkit.cleaning.markers import MarkerFix, clean_markers
    from mocapkit.cleaning.markers import decisions as md
    from mocapkit.io import load_markers
    from mocapkit.report.markers import write_marker_report

    x = load_markers(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")[:300]
    a, b, k = 10, 11, 5
    p = np.array(x.positions)
    p[100:200, [a, b]] = p[100:200, [b, a]]
    p[150:250, [b, k]] = p[150:250, [k, b]]
    p[170, k] += [0.0, 0.0, 1.0]
    lab = x.labels
    fixes = (MarkerFix(lab[a], 100, 200, "swap", 1.0, lab[b]), MarkerFix(lab[b], 150, 250, "swap", 1.0, lab[k]),
             MarkerFix(lab[k], 170, 171, "spike", 1.0))
    cleaned = x.with_positions(p)
    res = dataclasses.replace(clean_markers(x, steps=["swaps"]), markers=cleaned, fixes=fixes)
    review = md.review(x, cleaned, fixes, take="in.c3d", output="out.c3d")
    ids = [c["id"] for c in review["changes"]]
    assert md.tied(x, cleaned, fixes) == [ids]
    write_marker_report(tmp_path / "r.html", res, review=review)
    ctx = browser.new_context(viewport={"width": 1280, "height": 900})
    pg = ctx.new_page()
    pg.goto((tmp_path / "r.html").resolve().as_uri())
    pg.wait_for_function("() => window.mocapkitReview", timeout=60000)
    pg.locator(f'#changes tr[data-change="{ids[1]}"] input.accept').uncheck()
    boxes = [pg.locator(f'#changes tr[data-change="{i}"] input.accept').is_checked() for i in ids]
    assert boxes == [False, False, False]
    why = pg.locator(f'#changes tr[data-change="{ids[0]}"] td.reason').inner_text()
    assert "accepted or rejected with" in why and "could put a trajectory under another marker's label" in why
    pg.locator(f'#changes tr[data-change="{ids[2]}"] input.accept').check()
    assert all(pg.locator(f'#changes tr[data-change="{i}"] input.accept').is_checked() for i in ids)
    ctx.close()


def test_a_put_back_teleport_is_not_said_to_be_replaced_by_similar_motion():
    """The repair step puts a root teleport back on the path between the frames around it (whole_take), as it turns
    a flip back by the turn it made: neither copies the take's similar motion, which the sentence said of both."""
    from mocapkit.cleaning.ssa.cues import CAUSES

    words = dict(CAUSES)
    assert plain_sentence("repair", [words["teleport"]]) == (
        "The whole body jumps away and back (bad root samples): put back on the root's path between the frames "
        "around the jump.")
    # the turn undone: a half turn exactly, or the offsets measured at its steps (CMU 131_03's thumb, 158-164 deg)
    assert plain_sentence("repair", [words["flip"]]) == (
        "The joint turns about half a turn in one frame and later turns back: turned back by the turn it made there "
        "(a half turn, or the turn measured at its two steps).")
    assert plain_sentence("repair", [words["offset"]]).endswith(": replaced by the take's own similar motion.")


def test_a_cut_is_listed_with_its_score_and_said_in_the_summary_not_offered_as_a_change(browser, tmp_path):
    """Two real takes joined (HDM05 bk sneak 004 to 005, the smoothest join they allow), cleaned with its report:
    the cut at frame 200 changes no sample, and the page listed nothing (its summary and its changes said "the
    cleaning changed nothing"). It is listed under the changes with its score, what it means and that the cleaning
    changed no sample for it, with no accept box; the summary says it; its jump lands on frame 200; the record keeps
    it."""
    from mocapkit.cleaning.take_breaks import Cut
    from tests.shared import joined_sneaks

    inp, out, html = tmp_path / "joined.bvh", tmp_path / "out.bvh", tmp_path / "out.html"
    mocapkit.save(joined_sneaks(), inp)
    assert main(["clean", str(inp), "-o", str(out), "--report", str(html)]) == 0
    res = CleanResult.load(tmp_path / "out.clean.npz")
    assert res.cuts == (Cut(200, 0.7),) and not res.changed[195:206].any()
    with opened(browser, html) as pg:
        assert pg.evaluate("() => window.mocapkitReview.cuts()") == [200]
        row = pg.locator("#changes #cuts tbody tr")
        assert row.count() == 1 and row.get_attribute("data-cut") == "200"
        cells = row.locator("td")
        assert cells.nth(0).inner_text() == "200" and cells.nth(1).inner_text() == "70 % of the joints"
        assert "jump at once between frames 199 and 200" in cells.nth(2).inner_text()
        assert cells.nth(3).inner_text().startswith("nothing: no sample changed for it")
        assert row.locator("input").count() == 0  # not a change: nothing to accept or reject
        assert "1 cut at frame 200 (two takes joined, or frames dropped): no sample changed for it" in pg.inner_text("#summary")
        row.locator("button.jump").click()
        assert pg.evaluate("() => window.mocapkitReport.frame()") == 200
        assert pg.evaluate("() => window.mocapkitReview.changes()") == [c.id for c in D.changes(res, mocapkit.load(inp))]
