"""The overview page of a batch (mocapkit.report.batch_index) and clean_batch writing it beside the takes."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from mocapkit.batch import clean_batch
from mocapkit.errors import MocapFormatError
from mocapkit.report.batch_index import INDEX_NAME, is_batch_index, ordered_rows, take_counts, write_batch_index

from ..test_batch import short_bvh  # noqa: F401  (fixture)


def _row(name, status="done", **counts):
    return {"input": f"in/{name}.bvh", "output": f"out/{name}.bvh", "status": status, "reason": "", **counts}


def test_the_takes_to_look_at_come_first_failed_then_most_changed_then_flagged_then_untouched():
    rows = [_row("quiet", frames=10, filled=0, repaired=0, denoised=0, flagged=0),
            _row("left", frames=10, filled=0, repaired=0, denoised=0, flagged=4, left="1 flagged run left as it was"),
            _row("some", frames=10, filled=1, repaired=2, denoised=0, flagged=2),
            _row("broken", status="failed", reason="in/broken.bvh:1: expected HIERARCHY"),
            _row("most", frames=10, filled=0, repaired=9, denoised=3, flagged=1),
            {"input": "in/m.c3d", "output": "out/m.c3d", "status": "done", "frames": 5, "filled": 4, "spikes": 1,
             "swapped": 0}]
    assert [Path(r["input"]).stem for r in ordered_rows(rows)] == ["broken", "most", "m", "some", "left", "quiet"]
    assert take_counts(rows[4]) == (12, "9 repaired, 3 denoised")
    assert take_counts(rows[5]) == (5, "4 filled, 1 spikes removed")


def test_the_page_links_each_report_relative_to_out_dir_and_escapes_what_it_shows(tmp_path):
    out = tmp_path / "out"
    rows = [{**_row("a<b>", frames=3, filled=0, repaired=1, denoised=0, flagged=1),
             "input": str(tmp_path / "in" / "sub" / "a<b>.bvh"), "report": out / "sub" / "a<b>.report.html",
             "decided": "d.json"},
            _row("bad", status="failed", reason="'<script>' is no BVH")]
    page_path = write_batch_index(out / INDEX_NAME, rows, in_dir=tmp_path / "in", out_dir=out, request="steps fill")
    page = page_path.read_text(encoding="utf-8")
    assert 'href="sub/a&lt;b&gt;.report.html"' in page and "<script>" not in page
    assert "decided by d.json" in page and "sub/" in page
    assert "2 takes: 1 failed, 1 changed, 0 flagged and left as they were, 0 untouched." in page
    assert is_batch_index(page_path)
    (tmp_path / "mine.html").write_text("<html>mine</html>")
    assert not is_batch_index(tmp_path / "mine.html") and not is_batch_index(tmp_path / "missing.html")


def test_a_batch_with_reports_writes_its_overview_and_a_rerun_counts_complete_takes_from_their_records(tmp_path,
                                                                                                        short_bvh):
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    shutil.copy(short_bvh, src / "walk.bvh")
    (src / "bad.bvh").write_text("junk\n")
    first = clean_batch(src, out, steps=["fill", "detect"], executor="serial", progress=False, report=True)
    assert first.index == out / INDEX_NAME
    page = first.index.read_text(encoding="utf-8")
    assert 'href="walk.report.html"' in page and "expected HIERARCHY" in page
    again = clean_batch(src, out, steps=["fill", "detect"], executor="serial", progress=False, report=True)
    assert again.count("skipped") == 1
    rerun = again.index.read_text(encoding="utf-8")
    walk = next(line for line in rerun.splitlines() if "walk.report.html" in line)
    assert f'<td class="n">{first.rows[1]["frames"]}</td>' in walk  # the counts read back from its record
    assert clean_batch(src, tmp_path / "plain", steps=["fill"], executor="serial", progress=False).index is None
    assert not (tmp_path / "plain" / INDEX_NAME).exists()


def test_a_users_own_index_is_replaced_only_with_overwrite_and_a_batch_of_failures_writes_none(tmp_path, short_bvh):
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    shutil.copy(short_bvh, src / "walk.bvh")
    out.mkdir()
    (out / INDEX_NAME).write_text("<html>mine</html>")
    with pytest.raises(MocapFormatError, match="not a batch's overview; pass overwrite=True"):
        clean_batch(src, out, steps=["fill"], executor="serial", progress=False, report=True)
    assert sorted(p.name for p in out.iterdir()) == [INDEX_NAME]  # refused before any take: nothing written
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "bad.bvh").write_text("junk\n")
    s = clean_batch(bad, tmp_path / "out2", steps=["fill"], executor="serial", progress=False, report=True)
    assert s.count("failed") == 1 and s.index is None
    assert not (tmp_path / "out2" / INDEX_NAME).exists()


def test_each_takes_cuts_are_named_in_its_row_and_a_take_with_cuts_comes_first_in_its_group(tmp_path):
    """A take spliced from two captures (the rows' ``cuts``, as a batch gives them) was listed as untouched with
    nothing said: its cuts are named in its row, it comes before the untouched takes without one, and the page
    counts the takes with cuts."""
    from mocapkit.cleaning.take_breaks import cuts_phrase

    out = tmp_path / "out"
    cuts = [{"frame": 200, "share": 0.76, "root_cm": 78.4}, {"frame": 504, "share": 0.7, "root_cm": 0.0}]
    rows = [_row("plain", frames=600, filled=0, repaired=0, denoised=0, flagged=0, cuts=[]),
            _row("spliced", frames=600, filled=0, repaired=0, denoised=0, flagged=0, cuts=cuts)]
    assert [Path(r["input"]).stem for r in ordered_rows(rows)] == ["spliced", "plain"]
    said = ("2 cuts at frames 200 and 504 (two takes joined, or frames dropped; the root jumps 78 cm at frame 200): "
            "no sample changed for them")
    assert cuts_phrase(cuts) == said and cuts_phrase([]) == ""
    page = write_batch_index(out / INDEX_NAME, rows, in_dir=tmp_path / "in", out_dir=out).read_text(encoding="utf-8")
    spliced = next(line for line in page.splitlines() if "spliced.bvh" in line)
    assert said in spliced and 'class="untouched cut"' in spliced
    assert "cut at" not in next(line for line in page.splitlines() if "plain.bvh" in line)
    assert "1 take has cuts (two takes joined, or frames dropped), named in its row" in page
