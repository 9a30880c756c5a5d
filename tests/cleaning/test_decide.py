"""A joint-angle take's decisions applied from Python (`mocapkit.clean(..., decisions=, record=)`) as the CLI applies
them, and a library cleaning's record and report that the CLI's `--decisions` takes: one digest both ways."""

from __future__ import annotations

import json

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.cleaning import decisions as D
from mocapkit.cleaning.decide import GIVEN
from mocapkit.report.html import write_clean_report

from ..cli.helpers import one_error_line, run
from ..shared import corrupted_walk, report_review

REJECT = ("repair:lhumerus:41-108", "repair:ltoes:269-297")  # two changes tied to no other


def _decisions(report, path, reject=REJECT) -> dict:
    """The report's *Download decisions* document with the changes ``reject`` rejected, written to ``path``."""
    doc = report_review(report)["decisions"]
    for cid in reject:
        assert cid in doc["decisions"]
        doc["decisions"][cid] = D.REJECT
    path.write_text(json.dumps(doc), encoding="utf-8")
    return doc


@pytest.fixture(scope="module")
def reviewed(tmp_path_factory):
    """The real CMU walk 12 (bundled) with four real-style errors, cleaned without context twice: by the command
    (record and report) and in Python (its record saved and its report written by write_clean_report)."""
    d = tmp_path_factory.mktemp("decide")
    inp = corrupted_walk(d)
    code, _, err = run("clean", inp, "-o", d / "cli.npz", "--context", "none", "--report", d / "cli.html")
    assert code == 0, err
    res = mocapkit.clean(inp, context="none")
    res.save(d / "lib.clean.npz")
    write_clean_report(d / "lib.html", mocapkit.load(inp), res, inp=inp, output="lib.npz", record=d / "lib.clean.npz")
    return d, inp, res


def test_a_library_cleanings_report_keeps_the_digest_the_command_computes(reviewed):
    d, inp, res = reviewed
    cli, lib = report_review(d / "cli.html"), report_review(d / "lib.html")
    assert cli["decisions"]["cleaning"]["sha256"] == lib["decisions"]["cleaning"]["sha256"]
    assert cli["decisions"]["cleaning"]["request"] == lib["decisions"]["cleaning"]["request"]
    assert [c["id"] for c in cli["changes"]] == [c["id"] for c in lib["changes"]] and len(cli["changes"]) == 5
    assert lib["decisions"]["cleaning"]["record"] == str(d / "lib.clean.npz")
    assert lib["command"] == {"input": str(inp), "options": []}  # the page's command, as the command's page says it


def test_decisions_from_either_page_give_the_same_bytes_by_either_path(reviewed, tmp_path):
    """The CLI's page and the library's, each applied from its record or a new cleaning, by the command and by
    mocapkit.clean: one output, byte for byte, holding only the accepted changes."""
    d, inp, _ = reviewed
    outs = []
    for page, record in (("cli", d / "cli.clean.npz"), ("lib", d / "lib.clean.npz")):
        path = tmp_path / f"{page}.decisions.json"
        _decisions(d / f"{page}.html", path)
        for rec in (record, None):
            got = mocapkit.clean(inp, context="none", decisions=path, record=rec)
            mocapkit.save(got.motion, tmp_path / f"lib_{page}_{rec is not None}.npz", like=inp)  # as the command
            outs.append(tmp_path / f"lib_{page}_{rec is not None}.npz")
            out = tmp_path / f"cli_{page}_{rec is not None}.npz"
            code, stdout, err = run("clean", inp, "-o", out, "--context", "none", "--decisions", path,
                                    *(["--record", rec] if rec is not None else []))
            assert code == 0, err
            outs.append(out)
            assert stdout.split(": ", 1)[1].splitlines()[0] == got.summary()[0]  # the same decided headline
    first = outs[0].read_bytes()
    assert all(p.read_bytes() == first for p in outs[1:])
    take, got = mocapkit.load(inp), mocapkit.load(outs[0])
    res = D.apply(take, mocapkit.clean(inp, context="none"), {})
    assert got.rotations.tobytes() != take.rotations.tobytes() and got.rotations.tobytes() != res.rotations.tobytes()


def test_the_result_says_it_was_decided_as_the_command_does(reviewed, tmp_path):
    d, inp, _ = reviewed
    path = tmp_path / "d.json"
    _decisions(d / "cli.html", path)
    got = mocapkit.clean(inp, decisions=path, record=d / "cli.clean.npz")
    code, stdout, _ = run("clean", inp, "-o", tmp_path / "o.npz", "--decisions", path, "--record",
                          d / "cli.clean.npz")
    assert code == 0
    said = [line.strip() for line in stdout.split(": ", 1)[1].splitlines()]
    assert [line.strip() for line in got.summary()] == said
    assert got.summary()[0].startswith(f"{path} applied to the record {d / 'cli.clean.npz'} (nothing cleaned again): "
                                       "3 of 5 changes accepted, 2 rejected")
    assert got.decided is not None and sum("rejected repair:" in line for line in got.summary()) == 2
    assert not (got.repaired & ~D.accepted_cells(mocapkit.clean(inp, context="none"),
                                                 {c: D.REJECT for c in REJECT})).any()


def test_decisions_as_a_dict_apply_as_their_file_does(reviewed, tmp_path):
    d, inp, _ = reviewed
    doc = _decisions(d / "lib.html", tmp_path / "d.json")
    kept = json.dumps(doc)
    a = mocapkit.clean(inp, decisions=doc, record=d / "lib.clean.npz")
    b = mocapkit.clean(inp, decisions=tmp_path / "d.json", record=d / "lib.clean.npz")
    assert a.motion.rotations.tobytes() == b.motion.rotations.tobytes() and json.dumps(doc) == kept
    assert a.summary()[0].startswith(f"{GIVEN} applied to the record")


def test_reject_all_gives_the_input_back_bit_identical(reviewed, tmp_path):
    d, inp, _ = reviewed
    doc = _decisions(d / "lib.html", tmp_path / "all.json", reject=())
    doc["decisions"] = {k: D.REJECT for k in doc["decisions"]}
    take = mocapkit.load(inp)
    for rec in (d / "lib.clean.npz", None):
        got = mocapkit.clean(inp, context="none", decisions=doc, record=rec).motion
        for name in ("rotations", "root_positions"):
            assert np.ascontiguousarray(getattr(got, name)).tobytes() == \
                np.ascontiguousarray(getattr(take, name)).tobytes()
        mocapkit.save(got, tmp_path / "back.npz")
        assert mocapkit.load(tmp_path / "back.npz").rotations.tobytes() == take.rotations.tobytes()


def test_decisions_for_another_cleaning_are_refused_in_the_commands_words(reviewed, tmp_path):
    """Made with another context than the new cleaning's, or applied to the record of another cleaning: the
    library's line is the command's, naming the options that differ and the record to pass (as ``record=`` in
    Python, ``--record`` in the command)."""
    d, inp, _ = reviewed
    path = tmp_path / "d.json"
    _decisions(d / "cli.html", path)
    with pytest.raises(mocapkit.MocapFormatError) as lib:
        mocapkit.clean(inp, threshold=0.4, context="none", decisions=path)
    code, _, err = run("clean", inp, "-o", tmp_path / "x.npz", "--threshold", "0.4", "--context", "none",
                       "--decisions", path)
    record = d / "cli.clean.npz"
    assert code != 0 and one_error_line(err)
    # each in its caller's words: keywords to Python, the flags as typed to the command, the line otherwise one
    assert str(lib.value).replace(f"record={str(record)!r}", f"--record {record}").replace(
        "threshold=0.5", "--threshold 0.5") in err
    assert "reviewed with threshold=0.5 (now 0.4)" in str(lib.value) and f"record={str(record)!r}" in str(lib.value)
    assert "reviewed with --threshold 0.5 (now 0.4)" in err
    assert not (tmp_path / "x.npz").exists()

    other = tmp_path / "other.clean.npz"  # the record of another cleaning of the take: fill and detect only
    mocapkit.clean(inp, context="none", steps="fill,detect,repair", threshold=0.45).save(other)
    with pytest.raises(mocapkit.MocapFormatError) as lib:
        mocapkit.clean(inp, decisions=path, record=other)
    code, _, err = run("clean", inp, "-o", tmp_path / "y.npz", "--decisions", path, "--record", other)
    assert code != 0 and str(lib.value).replace(f"record={str(record)!r}", f"--record {record}") in err
    assert "made on another cleaning than the record" in str(lib.value) and "--record" not in str(lib.value)


def test_decisions_for_another_take_and_a_record_alone_are_refused(reviewed, tmp_path):
    d, inp, _ = reviewed
    path = tmp_path / "d.json"
    _decisions(d / "cli.html", path)
    walk = mocapkit.load(samples.path("12_walk.amc"))
    with pytest.raises(mocapkit.MocapFormatError, match="decisions for another take"):
        mocapkit.clean(walk, decisions=path)
    with pytest.raises(mocapkit.MocapError, match="applied with decisions; give the decisions file"):
        mocapkit.clean(inp, record=d / "cli.clean.npz")
    with pytest.raises(mocapkit.MocapFormatError, match=f"{GIVEN}: not a mocapkit decisions file"):
        mocapkit.clean(inp, decisions={"decisions": {}})
