"""A batch output decided in place (mocapkit.batch_decided): the next clean-batch keeps it, and discards its
decisions only when told to, saying so. End to end through the commands on a real take (CMU 12_walk with
real-style errors)."""

from __future__ import annotations

import json
import re

import pytest

import mocapkit
from mocapkit import corrupt, samples
from mocapkit.cleaning import decisions as D
from mocapkit.cleaning.pipeline import CleanResult

from .cli.helpers import digest, run


def _bad_walk(path, seed):
    m = mocapkit.load(samples.path("12_walk.amc"))
    bad, _, _ = corrupt.real_errors(m, n_errors=4, seed=seed)
    mocapkit.save(bad, path)


def _reject_first(report, path):
    """The report's decisions document with its first change rejected, written to ``path``."""
    found = re.search(r'<script type="application/json" id="mocapkit-review">(.*?)</script>',
                      report.read_text(encoding="utf-8"), re.S)
    doc = json.loads(found.group(1))["decisions"]
    first = next(iter(doc["decisions"]))
    doc["decisions"][first] = D.REJECT
    path.write_text(json.dumps(doc), encoding="utf-8")
    return first


@pytest.fixture(scope="module")
def decided(tmp_path_factory):
    """A batch of two takes, one of them then decided in place over the batch's output (--overwrite, OUT's record)."""
    d = tmp_path_factory.mktemp("decided")
    takes, out = d / "takes", d / "out"
    takes.mkdir()
    _bad_walk(takes / "a.npz", 11)
    _bad_walk(takes / "b.npz", 12)
    code, said, err = run("clean-batch", takes, out, "--report", "--executor", "serial")
    assert code == 0, err
    decisions = d / "a.decisions.json"
    rejected = _reject_first(out / "a.report.html", decisions)
    code, said, err = run("clean", takes / "a.npz", "-o", out / "a.npz", "--decisions", decisions, "--overwrite")
    assert code == 0, err
    return d, takes, out, decisions, rejected


def test_the_record_says_which_decisions_wrote_the_output(decided):
    d, takes, out, decisions, rejected = decided
    params = CleanResult.load_params(out / "a.clean.npz")
    assert params["decided"]["decisions"] == str(decisions)
    assert params["decided"]["output"]["sha256"] == digest(out / "a.npz")
    res = CleanResult.load(out / "a.clean.npz")  # the cleaning itself is untouched: its decisions still apply
    assert rejected in D.template(mocapkit.load(takes / "a.npz"), D.changes(res, mocapkit.load(takes / "a.npz")),
                                  result=res)["decisions"]


def test_info_on_the_record_says_its_output_was_decided(decided):
    """User trial U2: after `clean --decisions` over a batch output, `info` on its record said "changed 31 joint
    samples" with no word that the output beside it holds only the accepted changes (22 on that take)."""
    d, takes, out, decisions, rejected = decided
    code, said, err = run("info", out / "a.clean.npz")
    assert code == 0, err
    said = " ".join(said.split())
    assert (f"decided its output was then written by clean --decisions with only the changes {decisions} accepts: "
            "4 of 5 changes accepted, 1 rejected; ") in said and "; the counts here are the cleaning reviewed" in said
    code, said, err = run("info", out / "b.clean.npz")  # the take not decided: no such row
    assert code == 0 and "\ndecided " not in said


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_later_batch_keeps_the_decided_take(decided, overwrite):
    d, takes, out, decisions, _ = decided
    before = digest(out / "a.npz")
    code, said, err = run("clean-batch", takes, out, "--report", "--executor", "serial",
                          *(["--overwrite"] if overwrite else []))
    assert code == 0, err
    assert f"skipped {takes / 'a.npz'}: kept: decided by {decisions}" in said
    assert f"skipped {takes / 'b.npz'}: complete" in said
    assert digest(out / "a.npz") == before


def test_a_decided_take_whose_input_changed_is_cleaned_again_only_when_told(decided, tmp_path):
    import shutil

    d, takes, out, decisions, _ = decided
    takes2, out2 = tmp_path / "takes", tmp_path / "out"
    shutil.copytree(takes, takes2)
    shutil.copytree(out, out2)
    out2.joinpath(".mocapkit-batch.json").unlink(missing_ok=True)
    _bad_walk(takes2 / "a.npz", 13)  # a new version of the take
    before = digest(out2 / "a.npz")
    code, said, err = run("clean-batch", takes2, out2, "--report", "--executor", "serial")
    assert code == 0, err
    line = next(ln for ln in said.splitlines() if str(takes2 / "a.npz") in ln)
    assert line.startswith("skipped") and f"its input changed since it was decided by {decisions}" in line
    assert "--overwrite cleans it again and discards those decisions" in line
    assert digest(out2 / "a.npz") == before
    code, said, err = run("clean-batch", takes2, out2, "--report", "--executor", "serial", "--overwrite")
    assert code == 0, err
    line = next(ln for ln in said.splitlines() if str(takes2 / "a.npz") in ln)
    assert line.startswith("cleaned") and "those decisions were discarded" in line
    assert "decided" not in (CleanResult.load_params(out2 / "a.clean.npz") or {})
