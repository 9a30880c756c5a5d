"""What `clean` and `clean-batch` say of a take made of two real takes joined: the cut, with the root's jump where
the second capture starts elsewhere, in one line; the batch's lines, JSON and overview name the cut per take; and the
batch's last lines say where each take's record and report are, or that none was asked for."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

import mocapkit
from mocapkit.cleaning.pipeline import CleanResult
from mocapkit.cleaning.take_breaks import Cut
from mocapkit.report.batch_index import INDEX_NAME
from mocapkit.report.html import cut_rows

from tests.shared import joined_sneaks_apart

from . import helpers

DANCE = Path(__file__).parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh"
CUT = "1 cut at frame 200 (two takes joined, or frames dropped; the root jumps 78 cm there): no sample changed for it"


@pytest.fixture(scope="module")
def takes(tmp_path_factory):
    """IN_DIR of two real takes: HDM05 bk sneak 004 then 005 joined (a cut at frame 200, the root 78 cm away after
    it) and the first 60 frames of a Bandai Namco dance (no cut)."""
    d = tmp_path_factory.mktemp("cuts") / "in"
    d.mkdir()
    mocapkit.save(joined_sneaks_apart(), d / "joined.bvh")
    shutil.copy(DANCE, d / "dance.bvh")
    return d


def test_a_cut_where_the_root_jumps_is_one_line_naming_both(takes, tmp_path):
    """The root of sneak 005 starts 78 cm from where 004's frame 199 left it: `clean` said only "frame 200: the root
    (root) jumps 78 cm and stays there (an offset, or a cut); left as it is: which side is right is not known", and
    the record and report knew a cut with no word of the jump. Now one line names the cut and the jump, and the
    record's cut keeps its size."""
    out = tmp_path / "o.bvh"
    rc, text, err = helpers.run("clean", takes / "joined.bvh", "-o", out, "--steps", "detect")
    assert rc == 0, err
    said = [ln for ln in text.splitlines() if "frame 200" in ln]
    assert len(said) == 1 and ("frame 200: the whole body jumps (76 % of the joints at once, and the root jumps 78 cm "
                               "with them): a cut, or dropped frames") in said[0], text
    assert "stays there" not in text
    cuts = CleanResult.load(out.with_name("o.clean.npz")).cuts
    assert len(cuts) == 1 and cuts[0].frame == 200 and round(cuts[0].root_cm) == 78
    row = cut_rows(cuts)[0]  # the report's Cuts table
    assert "and the root jumps 78 cm with them: two takes joined here" in row["meaning"]
    assert str(Cut(200, 0.7)) == ("frame 200: the whole body jumps (70 % of the joints at once): a cut, or dropped "
                                  "frames; its breaks confirm no repair, the motion on either side is kept")


def test_the_batch_names_each_takes_cuts_in_its_line_its_json_and_its_overview(takes, tmp_path):
    """A batch named the cut nowhere: its line, `--json` and `index.html` read as for a take with nothing in it."""
    out = tmp_path / "out"
    rc, text, err = helpers.run("clean-batch", takes, out, "--executor", "serial", "--steps", "fill,detect",
                                "--report")
    assert rc == 0, err
    line = next(ln for ln in text.splitlines() if ln.startswith(f"cleaned {takes / 'joined.bvh'}"))
    assert f"nothing to change; {CUT}" in line
    dance = next(ln for ln in text.splitlines() if ln.startswith(f"cleaned {takes / 'dance.bvh'}"))
    assert " cut at frame" not in dance
    page = (out / INDEX_NAME).read_text(encoding="utf-8")
    row = next(ln for ln in page.splitlines() if "joined.report.html" in ln)
    assert CUT in row and 'class="untouched cut"' in row
    assert "1 take has cuts (two takes joined, or frames dropped), named in its row" in page
    rc, text, err = helpers.run("clean-batch", takes, tmp_path / "json", "--executor", "serial", "--steps",
                                "fill,detect", "--json")
    assert rc == 0, err
    rows = {r["input"].rsplit("/", 1)[-1]: r for r in json.loads(text)["rows"]}
    assert rows["dance.bvh"]["cuts"] == []
    (cut,) = rows["joined.bvh"]["cuts"]
    assert cut["frame"] == 200 and round(cut["root_cm"]) == 78 and 0.6 <= cut["share"] <= 1


def test_a_take_skipped_as_complete_says_what_its_earlier_run_found_and_fixed(takes, tmp_path):
    """`clean-batch --json` run again over the same OUT_DIR skipped both takes with no counts and no ``cuts``: the
    joined sneaks' cut at frame 200 was said only by the run that cleaned it. Now a skipped row reads them from the
    take's record beside its output, the same as the first run's row."""
    out = tmp_path / "out"
    runs = []
    for _ in range(2):
        rc, text, err = helpers.run("clean-batch", takes, out, "--executor", "serial", "--steps", "fill,detect",
                                    "--json")
        assert rc == 0, err
        runs.append({r["input"].rsplit("/", 1)[-1]: r for r in json.loads(text)["rows"]})
    first, again = runs
    said = ("frames", "filled", "repaired", "denoised", "flagged", "left", "cuts")
    for name in ("joined.bvh", "dance.bvh"):
        assert first[name]["status"] == "done" and again[name]["status"] == "skipped"
        assert {k: again[name][k] for k in said} == {k: first[name][k] for k in said}, name
    (cut,) = again["joined.bvh"]["cuts"]
    assert cut["frame"] == 200 and round(cut["root_cm"]) == 78
    assert again["dance.bvh"]["frames"] == 60 and again["dance.bvh"]["cuts"] == []


def test_the_batch_says_where_each_takes_record_and_report_are_and_that_none_was_asked_for(takes, tmp_path):
    """Without --report a batch wrote each take's record, and no report or overview; its last line said only the
    totals, so a person looked for an index.html that was never asked for. Now a line says where the files are and,
    without --report, how to get the reports; no file is added."""
    out = tmp_path / "out"
    rc, text, err = helpers.run("clean-batch", takes, out, "--executor", "serial", "--steps", "fill", "--png")
    assert rc == 0, err
    assert text.splitlines()[-1] == (
        f"each take's files are beside its output in {out}: STEM.clean.npz (its record: changes, flags and cuts) "
        "and STEM.summary.png (its summary figure); no reports were asked for: --report writes STEM.report.html "
        f"beside each output and {out / INDEX_NAME} over them (with --overwrite for the takes already complete)")
    written = sorted(p.name for p in out.iterdir())
    assert {"dance.clean.npz", "joined.clean.npz", "joined.summary.png"} <= set(written), written
    assert not [n for n in written if n.endswith(".html")]  # no report or overview: none was asked for
    rc, text, err = helpers.run("clean-batch", takes, out, "--executor", "serial", "--steps", "fill", "--png",
                                "--report", "--overwrite")
    assert rc == 0, err
    assert text.splitlines()[-2:] == [
        f"wrote {out / INDEX_NAME}: every take with its report, the takes to look at first",
        f"each take's files are beside its output in {out}: STEM.clean.npz (its record: changes, flags and cuts), "
        "STEM.report.html (its report) and STEM.summary.png (its summary figure)"]
    assert (out / "joined.report.html").is_file() and (out / INDEX_NAME).is_file()
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "b.bvh").write_text("junk\n")
    rc, text, _ = helpers.run("clean-batch", bad, tmp_path / "none", "--executor", "serial", "--steps", "fill")
    assert rc == 1 and "each take's files" not in text  # no take written: nothing to point at
