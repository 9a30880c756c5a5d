"""Options given beside a replayed record (`mocapkit.clean(..., record=)`, `mocapkit clean --record`): honoured where
the record's cleaning was asked for with them, refused in one line naming the record and the caller's own spelling of
each option where not (mocapkit.cleaning.replay)."""

from __future__ import annotations

import json

import pytest

import mocapkit
from mocapkit import samples
from mocapkit.cleaning import decisions as D

from ..cli.helpers import one_error_line, run
from ..shared import corrupted_walk, report_review


@pytest.fixture(scope="module")
def reviewed(tmp_path_factory):
    """The real CMU walk 12 (bundled) with four real-style errors, cleaned by the command without context (record
    and report), and the report's decisions document with its first change rejected."""
    d = tmp_path_factory.mktemp("replay")
    inp = corrupted_walk(d)
    code, _, err = run("clean", inp, "-o", d / "out.npz", "--context", "none", "--report", d / "out.html")
    assert code == 0, err
    doc = report_review(d / "out.html")["decisions"]
    doc["decisions"][next(iter(doc["decisions"]))] = D.REJECT
    (d / "d.json").write_text(json.dumps(doc), encoding="utf-8")
    return d, inp, d / "out.clean.npz", d / "d.json"


def test_an_option_the_record_was_not_cleaned_with_is_refused_naming_the_python_keyword(reviewed):
    """A user trial: `mocapkit.clean(take, threshold=0.3, decisions=D, record=R)` applied D to R's cleaning (made at
    0.5) and said nothing of the threshold; the same option as the record's is honoured."""
    d, inp, record, dec = reviewed
    same = mocapkit.clean(inp, context="none", decisions=dec, record=record)
    assert same.decided is not None
    with pytest.raises(mocapkit.MocapError) as exc:
        mocapkit.clean(inp, context="none", threshold=0.3, drifts=True, decisions=dec, record=record)
    said = str(exc.value)
    assert said.startswith(f"{record}: threshold=0.3, drifts=True given beside record=") and "\n" not in said
    assert "(threshold=0.5, drifts=False in the record)" in said and "--" not in said
    with pytest.raises(mocapkit.MocapError, match=r"noise_deg=2 given beside record=.*\(noise_deg=1 in the"):
        mocapkit.clean(inp, noise_deg=2.0, decisions=dec, record=record)
    with pytest.raises(mocapkit.MocapError) as exc:  # said as a Python caller writes them ("steps= detect" before)
        mocapkit.clean(inp, context="none", steps="detect", models={"ebf": "ebf.pt"}, decisions=dec, record=record)
    said = str(exc.value)
    assert said.startswith(f"{record}: steps='detect', models={{'ebf': ") and "given beside record=" in said, said
    assert "(steps='fill,detect,repair,denoise', models not given in the record)" in said, said


def test_the_command_refuses_a_flag_beside_the_record_naming_the_flag(reviewed, tmp_path):
    d, inp, record, dec = reviewed
    code, out, err = run("clean", inp, "-o", tmp_path / "a.npz", "--decisions", dec, "--record", record,
                         "--context", "none")
    assert code == 0, err
    code, out, err = run("clean", inp, "-o", tmp_path / "b.npz", "--decisions", dec, "--record", record,
                         "--threshold", "0.3")
    assert code == 2 and one_error_line(err), err
    assert f"{record}: --threshold 0.3 given beside --record" in err and "threshold=" not in err
    assert not (tmp_path / "b.npz").exists()


def test_refusals_of_a_replay_name_the_python_keyword_in_python(reviewed):
    """Decisions that keep no digest of their cleaning are refused for a new cleaning, saying to give the record:
    as `record=` from Python, `--record` from the command."""
    d, inp, record, dec = reviewed
    doc = json.loads(dec.read_text(encoding="utf-8"))
    doc.pop("cleaning")
    with pytest.raises(mocapkit.MocapFormatError) as exc:
        mocapkit.clean(inp, context="none", decisions=doc)
    assert "give that cleaning's record with record=" in str(exc.value) and "--record" not in str(exc.value)
    stamp = {"record": str(record)}
    assert D.record_wanted(stamp, D.RECORD_KEYWORD) == f"record={str(record)!r}"
    assert D.record_wanted(stamp) == f"--record {record}"


def test_a_marker_captures_longest_gap_beside_its_record_is_refused(tmp_path):
    from tests.shared import marker_decisions_file

    inp = samples.path("Eb015pr.c3d")
    code, _, err = run("clean", inp, "-o", tmp_path / "out.c3d")
    assert code == 0, err
    dec = marker_decisions_file(tmp_path, inp, {})
    code, _, err = run("clean", inp, "-o", tmp_path / "b.c3d", "--decisions", dec, "--record",
                       tmp_path / "out.clean.npz", "--max-gap", "0.5")
    assert code == 2 and one_error_line(err), err
    assert "--max-gap 0.5 given beside --record" in err and "(--max-gap not given in the record)" in err


def test_an_option_given_at_its_default_beside_a_record_counts_as_given(tmp_path):
    """A user trial: `mocapkit.clean(take, threshold=0.5, decisions=D, record=R)` with R made at 0.3 applied R's 0.3
    cleaning and said nothing: 0.5 is the default, and a default was taken for an option left out. Given (not None),
    it is checked against the record like any other value; left out, it is not."""
    inp = corrupted_walk(tmp_path)
    code, _, err = run("clean", inp, "-o", tmp_path / "out.npz", "--context", "none", "--threshold", "0.3",
                       "--report", tmp_path / "out.html")
    assert code == 0, err
    dec = tmp_path / "d.json"
    dec.write_text(json.dumps(report_review(tmp_path / "out.html")["decisions"]), encoding="utf-8")
    record = tmp_path / "out.clean.npz"
    assert mocapkit.clean(inp, context="none", decisions=dec, record=record).decided is not None
    assert mocapkit.clean(inp, context="none", threshold=0.3, drifts=False, steps="fill,detect,repair,denoise",
                          decisions=dec, record=record).decided is not None
    with pytest.raises(mocapkit.MocapError) as exc:
        mocapkit.clean(inp, context="none", threshold=0.5, decisions=dec, record=record)
    assert str(exc.value) == (f"{record}: threshold=0.5 given beside record=, whose cleaning is applied as it was "
                              "made (threshold=0.3 in the record): leave it out, or clean anew without record=")
    code, _, err = run("clean", inp, "-o", tmp_path / "b.npz", "--decisions", dec, "--record", record,
                       "--context", "none", "--threshold", "0.5")  # the command, as Python
    assert code == 2 and one_error_line(err) and f"{record}: --threshold 0.5 given beside --record" in err, err
    code, _, err = run("clean", inp, "-o", tmp_path / "c.npz", "--decisions", dec, "--record", record,
                       "--context", "none", "--threshold", "0.3")
    assert code == 0, err
