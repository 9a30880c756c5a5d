"""`mocapkit clean --decisions`: a person's accept/reject per change applied to the take; `--steps detect` reviews only."""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, samples
from mocapkit.cleaning import decisions as D
from mocapkit.cleaning.pipeline import CleanResult
from mocapkit.cli import main

from .helpers import digest, one_error_line


def _same_bits(a, b) -> bool:
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def review_block(report) -> dict:
    """The changes list and decisions document the report embeds for the page."""
    found = re.search(r'<script type="application/json" id="mocapkit-review">(.*?)</script>',
                      report.read_text(encoding="utf-8"), re.S)
    assert found, "the report has no changes list"
    return json.loads(found.group(1))


@pytest.fixture(scope="module")
def cleaned(tmp_path_factory):
    """walk_bad.npz (12_walk with real-style errors), cleaned by the command with its report."""
    d = tmp_path_factory.mktemp("decide")
    m = mocapkit.load(samples.path("12_walk.amc"))
    bad, _, _ = corrupt.real_errors(m, n_errors=4, seed=11)
    inp = d / "walk_bad.npz"
    mocapkit.save(bad, inp)
    mocapkit.save(m, d / "walk_ref.npz")
    assert main(["clean", str(inp), "-o", str(d / "walk.npz"), "--report", str(d / "walk.html")]) == 0
    return d, inp


def _decide(cleaned, tmp_path, reject=(0,)):
    """A decisions file from the report's document, rejecting the changes at the positions ``reject``."""
    d, inp = cleaned
    doc = review_block(d / "walk.html")["decisions"]
    ids = list(doc["decisions"])
    for k in reject:
        doc["decisions"][ids[k]] = D.REJECT
    path = tmp_path / "walk.decisions.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path, ids


def _check_output(out, inp, record, choice):
    """OUT holds the cleaned samples in the accepted cells and the input's, bit for bit, everywhere else."""
    take, res = mocapkit.load(inp), CleanResult.load(record)
    got = mocapkit.load(out)
    acc = D.accepted_cells(res, choice)
    want = D.apply(take, res, choice)
    assert _same_bits(got.rotations, want.rotations) and _same_bits(got.root_positions, want.root_positions)
    assert _same_bits(got.rotations[~acc], take.rotations[~acc])
    assert acc.any() and (res.changed & ~acc).any()
    return acc


def test_report_lists_every_change_with_a_decisions_document(cleaned):
    d, inp = cleaned
    block = review_block(d / "walk.html")
    res = CleanResult.load(d / "walk.clean.npz")
    take = mocapkit.load(inp)
    assert [c["id"] for c in block["changes"]] == [c.id for c in D.changes(res, take)] != []
    doc = block["decisions"]
    assert doc["take"]["name"] == "walk_bad.npz" and doc["take"]["sha256"] == D.take_digest(take)
    assert doc["output"] == "walk.npz" and set(doc["decisions"].values()) == {D.ACCEPT}
    for c in block["changes"]:
        assert {"joint", "first", "last", "step", "max_deg", "reason"} <= set(c)


def test_decisions_reuse_the_record_beside_out(cleaned, tmp_path, capsys):
    d, inp = cleaned
    dec, ids = _decide(cleaned, tmp_path)
    record = d / "walk.clean.npz"
    before = digest(record), digest(inp)
    out = d / "walk.npz"
    import shutil

    shutil.copy(record, d / "walk.before.clean.npz")
    capsys.readouterr()
    assert main(["clean", str(inp), "-o", str(out), "--decisions", str(dec)]) == 2  # OUT exists: --overwrite
    assert "--overwrite" in capsys.readouterr().err
    rc = main(["clean", str(inp), "-o", str(out), "--decisions", str(dec), "--overwrite"])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "nothing cleaned again" in text and f"{len(ids) - 1} of {len(ids)} changes accepted, 1 rejected" in text
    assert f"rejected {ids[0]}" in text and "ssa" not in text
    assert digest(inp) == before[1]
    # the record's cleaning is read, not changed: it only notes the decisions that wrote OUT (mocapkit.batch_decided)
    assert _same_record(record, d / "walk.before.clean.npz")
    assert CleanResult.load_params(record)["decided"] == {"decisions": str(dec), "output": {
        "size": out.stat().st_size, "sha256": digest(out)}, "holds": f"{len(ids) - 1} of {len(ids)} changes accepted, "
        f"1 rejected; {int(D.accepted_cells(CleanResult.load(record), {ids[0]: D.REJECT}).sum())} joint samples of 10633 changed"}
    _check_output(out, inp, record, {ids[0]: D.REJECT})


def _same_record(a, b) -> bool:
    """Two records with the same arrays, bit for bit, and the same meta but for ``params["decided"]``."""
    with np.load(a) as x, np.load(b) as y:
        if sorted(x.files) != sorted(y.files):
            return False
        meta = [json.loads(str(z["meta"])) for z in (x, y)]
        for m in meta:
            m["params"].pop("decided", None)
        return meta[0] == meta[1] and all(_same_bits(x[k], y[k]) for k in x.files if k != "meta")


def test_decisions_with_an_explicit_record_and_a_report(cleaned, tmp_path, capsys):
    d, inp = cleaned
    dec, ids = _decide(cleaned, tmp_path, reject=(0, 1))
    out, rep = tmp_path / "final.npz", tmp_path / "final.html"
    rc = main(["clean", str(inp), "-o", str(out), "--decisions", str(dec), "--record", str(d / "walk.clean.npz"),
               "--report", str(rep), "--reference", str(d / "walk_ref.npz")])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert f"wrote {out} and {rep}: " in text
    before, after = map(float, re.search(r"error against walk_ref.npz: pose error ([\d.]+) -> ([\d.]+)", text).groups())
    assert after < before  # the accepted changes still repair
    assert not (tmp_path / "final.clean.npz").exists()  # no new cleaning, no new record
    assert main(["clean", "--help"]) == 0  # and the help says so, where it said a record is written beside OUT
    assert "with --decisions --record of another file: not written" in " ".join(capsys.readouterr().out.replace("│", " ").split())
    _check_output(out, inp, d / "walk.clean.npz", {ids[0]: D.REJECT, ids[1]: D.REJECT})
    block = review_block(rep)  # the new report starts from the decisions taken
    assert [block["decisions"]["decisions"][i] for i in ids[:3]] == [D.REJECT, D.REJECT, D.ACCEPT]


def test_decisions_without_a_record_clean_first(cleaned, tmp_path, capsys):
    d, inp = cleaned
    dec, ids = _decide(cleaned, tmp_path)
    out = tmp_path / "fresh.bvh"
    rc = main(["clean", str(inp), "-o", str(out), "--decisions", str(dec)])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert f"wrote {out} and {tmp_path / 'fresh.clean.npz'}: " in text and "a new cleaning" in text
    record = tmp_path / "fresh.clean.npz"
    assert [c.id for c in D.changes(CleanResult.load(record), mocapkit.load(inp))] == ids  # same changes again
    take, got = mocapkit.load(inp), mocapkit.load(out)
    acc = D.accepted_cells(CleanResult.load(record), {ids[0]: D.REJECT})
    # BVH holds the channels as text (6 decimals, the writer's channel order): outside the accepted cells the
    # rotations are the input's to that precision, inside them the cleaned ones
    cleaned = D.apply(take, CleanResult.load(record), {})
    dot = np.abs(np.sum(got.rotations * np.where(acc[..., None], cleaned.rotations, take.rotations), axis=-1))
    assert np.degrees(2 * np.arccos(np.clip(dot, 0, 1))).max() < 1e-3
    moved = np.abs(np.sum(take.rotations * cleaned.rotations, axis=-1))
    assert np.degrees(2 * np.arccos(np.clip(moved[acc], 0, 1))).max() > 1.0  # the accepted changes are there
    # the record beside the decided OUT says so, by which file, and what OUT holds (it said the full cleaning's
    # counts and no word of the decisions); `info` shows it, as for OUT's own record decided in place
    entry = CleanResult.load(record).params["decided"]
    n = len(ids)
    assert entry["decisions"] == str(dec.resolve()) and entry["output"]["sha256"] == digest(out)
    assert entry["holds"] == f"{n - 1} of {n} changes accepted, 1 rejected; {int(acc.sum())} joint samples of {acc.size} changed"
    assert main(["info", str(record)]) == 0
    said = " ".join(capsys.readouterr().out.split())
    assert f"decided its output was then written by clean --decisions with only the changes {dec.resolve()} accepts: {entry['holds']}" in said


def test_decisions_for_another_take_are_refused_and_nothing_is_written(cleaned, tmp_path, capsys):
    d, inp = cleaned
    dec, ids = _decide(cleaned, tmp_path)
    other = tmp_path / "other.npz"
    bad, _, _ = corrupt.real_errors(mocapkit.load(samples.path("12_walk.amc")), n_errors=4, seed=12)
    mocapkit.save(bad, other)  # the same clip with other errors: same frames and joints, other samples
    out = tmp_path / "o.npz"
    for args in (["clean", str(other), "-o", str(out), "--decisions", str(dec), "--record", str(d / "walk.clean.npz")],
                 ["clean", str(other), "-o", str(out), "--decisions", str(dec)]):
        assert main(args) == 2
        err = capsys.readouterr().err
        if "--record" in args:  # the decisions and the record agree: the input is the take that does not match
            assert one_error_line(err) and err.startswith(f"mocapkit: error: {other}: not the take that {dec.name} "
                                                          "and the record walk.clean.npz were made for"), err
        else:
            assert one_error_line(err) and str(dec) in err and "decisions for another take (walk_bad.npz" in err, err
        assert not out.exists() and not (tmp_path / "o.clean.npz").exists()


def test_unknown_ids_and_misuse_are_refused(cleaned, tmp_path, capsys):
    d, inp = cleaned
    dec, ids = _decide(cleaned, tmp_path)
    doc = json.loads(dec.read_text())
    doc["decisions"]["repair:nosuchjoint:1-2"] = D.REJECT
    dec.write_text(json.dumps(doc))
    out = tmp_path / "o.npz"
    assert main(["clean", str(inp), "-o", str(out), "--decisions", str(dec), "--record", str(d / "walk.clean.npz")]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and "'repair:nosuchjoint:1-2'" in err and str(dec) in err
    assert main(["clean", str(inp), "-o", str(out), "--record", str(d / "walk.clean.npz")]) == 2
    assert "--record" in capsys.readouterr().err and not out.exists()


def test_steps_detect_is_the_review_mode(cleaned, tmp_path, capsys):
    d, inp = cleaned
    out = tmp_path / "review.npz"
    rc = main(["clean", str(inp), "-o", str(out), "--steps", "detect", "--report", str(tmp_path / "r.html")])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "review mode (--steps detect): flags only, the take unchanged" in text and "flagged" in text
    take, got = mocapkit.load(inp), mocapkit.load(out)
    assert _same_bits(got.rotations, take.rotations) and _same_bits(got.root_positions, take.root_positions)
    rec = CleanResult.load(tmp_path / "review.clean.npz")
    assert rec.flags.any() and not rec.changed.any()
    assert review_block(tmp_path / "r.html")["changes"] == []


def _other_take(tmp_path, n_frames=None):
    """12_walk with other errors than the fixture's take: the same rig and rate (and length unless ``n_frames``)."""
    bad, _, _ = corrupt.real_errors(mocapkit.load(samples.path("12_walk.amc")), n_errors=4, seed=12)
    other = tmp_path / "other.npz"
    mocapkit.save(bad if n_frames is None else bad[:n_frames], other)
    return other, mocapkit.load(other)


def test_a_record_of_another_take_of_the_same_length_is_refused_naming_the_record(cleaned, tmp_path, capsys):
    """Decisions made for THIS take (its digest) with the record of another take: the record is refused.

    Before the record kept its take's digest, the other take's cleaned values were written into this one.
    """
    d, inp = cleaned
    other, take = _other_take(tmp_path)
    record = d / "walk.clean.npz"
    found = D.changes(CleanResult.load(record), mocapkit.load(inp))  # the record's changes, listed against its take
    dec = tmp_path / "d.json"
    dec.write_text(json.dumps(D.template(take, found, take=other.name)))
    out = tmp_path / "o.npz"
    assert main(["clean", str(other), "-o", str(out), "--decisions", str(dec), "--record", str(record)]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and f"{record}: the clean record is of another take" in err, err
    assert not out.exists() and not (tmp_path / "o.clean.npz").exists()
    assert CleanResult.load(record).take_sha256 == D.take_digest(mocapkit.load(inp)) != D.take_digest(take)


def test_a_record_of_another_length_is_blamed_not_the_decisions(cleaned, tmp_path, capsys):
    """The record is checked against the take before the decisions against the record."""
    d, inp = cleaned
    other, take = _other_take(tmp_path, n_frames=200)
    doc = D.template(take, [], take=other.name, decisions={})
    doc["decisions"] = {"repair:lfemur:10-20": D.REJECT}  # not a change of the record: the record is wrong first
    dec = tmp_path / "d.json"
    dec.write_text(json.dumps(doc))
    out = tmp_path / "o.npz"
    assert main(["clean", str(other), "-o", str(out), "--decisions", str(dec), "--record", str(d / "walk.clean.npz")]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and f"{d / 'walk.clean.npz'}: the clean record is of another take (" in err, err
    assert str(dec) not in err and not out.exists()


def test_a_record_written_before_the_take_digest_still_applies_with_a_note(cleaned, tmp_path, capsys):
    """Decisions from an earlier version's report keep applying to its record (docs/upgrading.md), said once."""
    d, inp = cleaned
    dec, ids = _decide(cleaned, tmp_path)
    with np.load(d / "walk.clean.npz") as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays["meta"]))
    meta.pop("take_sha256", None)
    arrays["meta"] = np.array(json.dumps(meta))
    old = tmp_path / "old.clean.npz"
    np.savez_compressed(old, **arrays)
    out = tmp_path / "o.npz"
    rc = main(["clean", str(inp), "-o", str(out), "--decisions", str(dec), "--record", str(old)])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert f"note: {old} was written by an earlier mocapkit and keeps no digest of its take" in text
    _check_output(out, inp, old, {ids[0]: D.REJECT})


def _deg(p, q):
    return np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(p * q, axis=-1)), 0, 1)))


@pytest.mark.parametrize("seed", [5, 11])
def test_an_amc_output_reports_and_records_what_the_file_holds(tmp_path, capsys, seed):
    """A bone with fewer than three dofs holds only its dofs' part of a repair: the change list's sizes and the
    record's cleaned values are those of the written file (before, up to several degrees off)."""
    import shutil

    shutil.copy(samples.path("12.asf"), tmp_path / "bad.asf")
    bad, _, _ = corrupt.real_errors(mocapkit.load(samples.path("12_walk.amc")), n_errors=4, seed=seed)
    inp, out = tmp_path / "bad.amc", tmp_path / "out.amc"
    mocapkit.save(bad, inp)
    assert main(["clean", str(inp), "-o", str(out), "--report", str(tmp_path / "r.html")]) == 0, capsys.readouterr()
    take, got, res = mocapkit.load(inp), mocapkit.load(out), CleanResult.load(tmp_path / "out.clean.npz")
    moved = _deg(take.rotations, got.rotations)
    found = D.changes(res, take)
    few = {j for j, d in enumerate(mocapkit.io.asfamc.amc_dofs(take.skeleton)) if 0 < len(d) < 3}
    assert any(c.joint_index in few and c.max_deg > 1 for c in found)  # the case the file cannot hold whole
    for c in found:  # the file's numbers have 6 decimals (degrees)
        assert c.max_deg == pytest.approx(moved[c.first:c.last + 1, c.joint_index].max(), abs=1e-4), c
    assert _deg(res.samples["rotations"], got.rotations[res.changed]).max() < 1e-4
    shown = {c["id"]: c["max_deg"] for c in review_block(tmp_path / "r.html")["changes"]}
    assert shown == {c.id: round(c.max_deg, 3) for c in found}
    # the undo round trip stays exact: every change rejected gives the input file back, every change accepted
    # the cleaning's own file, byte for byte
    doc = review_block(tmp_path / "r.html")["decisions"]
    for choice, want in ((D.REJECT, inp), (D.ACCEPT, out)):
        doc["decisions"] = {k: choice for k in doc["decisions"]}
        (tmp_path / "d.json").write_text(json.dumps(doc))
        again = tmp_path / f"{choice}.amc"
        assert main(["clean", str(inp), "-o", str(again), "--decisions", str(tmp_path / "d.json"),
                     "--record", str(tmp_path / "out.clean.npz")]) == 0
        assert again.read_bytes() == want.read_bytes()


# ---- decisions apply to the values reviewed, and say what they did (trial 24) --------------------------------------


def test_a_new_cleaning_with_other_options_is_refused_naming_the_record(cleaned, tmp_path, capsys):
    """The page's decisions applied without --record to a cleaning with other options: refused before cleaning,
    naming the options and the record to pass. Before, the take was cleaned again, the ids matched, and values
    nobody reviewed were written."""
    d, inp = cleaned
    dec, ids = _decide(cleaned, tmp_path)
    out = tmp_path / "o.npz"
    assert main(["clean", str(inp), "-o", str(out), "--decisions", str(dec), "--threshold", "0.45"]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and err.startswith(f"mocapkit: error: {dec}: made on another cleaning"), err
    assert "reviewed with --threshold 0.5 (now 0.45)" in err and f"--record {d / 'walk.clean.npz'}" in err
    assert not out.exists() and not (tmp_path / "o.clean.npz").exists()


def test_a_file_without_the_digest_applies_to_a_record_with_notes_and_not_to_a_new_cleaning(cleaned, tmp_path,
                                                                                               capsys):
    """A hand-written file naming some changes: applied to the record, saying it was taken on its ids and how many
    unnamed changes were accepted; refused for a new cleaning (nothing tells it is the one reviewed)."""
    d, inp = cleaned
    dec, ids = _decide(cleaned, tmp_path)
    doc = json.loads(dec.read_text())
    del doc["cleaning"]
    doc["decisions"] = {ids[0]: D.REJECT}
    dec.write_text(json.dumps(doc))
    out = tmp_path / "o.npz"
    rc = main(["clean", str(inp), "-o", str(out), "--decisions", str(dec), "--record", str(d / "walk.clean.npz")])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert f"note: {dec} keeps no digest of the cleaning it was made on" in text
    assert f"note: {dec} names 1 of {len(ids)} changes: the {len(ids) - 1} it does not name were accepted" in text
    _check_output(out, inp, d / "walk.clean.npz", {ids[0]: D.REJECT})
    assert main(["clean", str(inp), "-o", str(tmp_path / "p.npz"), "--decisions", str(dec)]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and "keeps no digest of the cleaning it was made on" in err and "--record" in err
    assert not (tmp_path / "p.npz").exists()


def test_decisions_naming_changes_with_a_review_mode_record_say_it_holds_none(cleaned, tmp_path, capsys):
    d, inp = cleaned
    dec, ids = _decide(cleaned, tmp_path)
    assert main(["clean", str(inp), "-o", str(tmp_path / "review.npz"), "--steps", "detect"]) == 0
    record = tmp_path / "review.clean.npz"
    capsys.readouterr()
    assert main(["clean", str(inp), "-o", str(tmp_path / "o.npz"), "--decisions", str(dec), "--record",
                 str(record)]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and f"{record}: the clean record is from review mode (--steps detect) and holds no " \
                                   f"changes, while {dec.name} names {len(ids)}" in err, err


def test_a_missing_record_or_a_mask_file_as_record_says_what_it_is(cleaned, tmp_path, capsys):
    d, inp = cleaned
    dec, _ = _decide(cleaned, tmp_path)
    out = tmp_path / "o.npz"
    assert main(["clean", str(inp), "-o", str(out), "--decisions", str(dec), "--record", str(tmp_path / "no.npz")]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and f"{tmp_path / 'no.npz'}: no such file" in err and "Errno" not in err, err
    mask = tmp_path / "walk_bad.mask.npz"
    from mocapkit.io.masks import write_mask

    write_mask(mask, np.zeros((4, 2), bool), ["a", "b"], kind="gaps", seed=1)
    assert main(["clean", str(inp), "-o", str(out), "--decisions", str(dec), "--record", str(mask)]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and "holds no 'meta'" in err and "mask file" in err, err
    assert not out.exists()


def test_a_decisions_file_naming_a_change_twice_is_refused(cleaned, tmp_path, capsys):
    d, inp = cleaned
    dec, ids = _decide(cleaned, tmp_path)
    text = dec.read_text().replace(f'"{ids[0]}": "reject"', f'"{ids[0]}": "reject", "{ids[0]}": "accept"')
    dec.write_text(text)
    out = tmp_path / "o.npz"
    assert main(["clean", str(inp), "-o", str(out), "--decisions", str(dec), "--record", str(d / "walk.clean.npz")]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and f"change '{ids[0]}' is named twice" in err and not out.exists()


# ---- a batch's record applied to an AMC output; a refusal never asks for what was given (trial 33) --------------


def test_decisions_on_a_batch_bvh_record_apply_to_an_amc_output(tmp_path, capsys, shared_data):
    """clean-batch writes an AMC take as .bvh, its record holding the cleaned rotations whole; the decisions its
    report offers apply to that record for an .amc OUT too, where a bone with two dofs holds only its dofs' part
    (CMU backflip: lhand repaired; before: refused as made on another cleaning, naming the very --record given)."""
    import shutil

    takes, out = tmp_path / "takes", tmp_path / "out"
    takes.mkdir()
    shutil.copy(shared_data / "cmu_asfamc" / "backflip.asf", takes / "bad.asf")
    shutil.copy(shared_data / "cmu_asfamc" / "backflip.amc", takes / "bad.amc")
    assert main(["clean-batch", str(takes), str(out), "--report", "--executor", "serial"]) == 0, capsys.readouterr()
    record = out / "bad.clean.npz"
    take, res = mocapkit.load(takes / "bad.amc"), CleanResult.load(record)
    few = {j for j, d in enumerate(mocapkit.io.asfamc.amc_dofs(take.skeleton)) if 0 < len(d) < 3}
    assert any(c.joint_index in few for c in D.changes(res, take))  # the case an AMC cannot hold whole
    doc = review_block(out / "bad.report.html")["decisions"]
    for choice in (D.ACCEPT, D.REJECT):
        doc["decisions"] = {k: choice for k in doc["decisions"]}
        (tmp_path / "d.json").write_text(json.dumps(doc))
        final = tmp_path / f"{choice}.amc"
        capsys.readouterr()
        code = main(["clean", str(takes / "bad.amc"), "-o", str(final), "--decisions", str(tmp_path / "d.json"),
                     "--record", str(record)])
        assert code == 0, capsys.readouterr().err
    assert (tmp_path / "reject.amc").read_bytes() == (takes / "bad.amc").read_bytes()  # every change undone
    assert main(["clean", str(takes / "bad.amc"), "-o", str(tmp_path / "fresh.amc")]) == 0
    assert (tmp_path / "accept.amc").read_bytes() == (tmp_path / "fresh.amc").read_bytes()  # the cleaning, as AMC


def test_a_record_rewritten_since_the_review_is_not_asked_for_again(cleaned, tmp_path, capsys):
    """The decisions name record R, and R now holds another cleaning (the take cleaned again over it): the
    refusal says so, and does not tell the user to give --record R, which they gave."""
    d, inp = cleaned
    dec, _ = _decide(cleaned, tmp_path)
    assert main(["clean", str(inp), "-o", str(tmp_path / "again.npz"), "--threshold", "0.45"]) == 0
    again = tmp_path / "again.clean.npz"
    doc = json.loads(dec.read_text())
    doc["cleaning"]["record"] = str(again)  # the record the review was of, since written over
    dec.write_text(json.dumps(doc))
    capsys.readouterr()
    assert main(["clean", str(inp), "-o", str(tmp_path / "o.npz"), "--decisions", str(dec), "--record",
                 str(again)]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and f"{dec}: made on another cleaning than the record {again}" in err, err
    assert f"--record {again}" not in err and "written again since the review" in err


def test_an_edited_take_is_named_as_the_file_that_does_not_match(cleaned, tmp_path, capsys):
    """The decisions and the record are of one take, the input an edited copy of it: the refusal names the input
    and why, not the decisions file; without a record the decisions' refusal names the input by its file name."""
    d, inp = cleaned
    dec, _ = _decide(cleaned, tmp_path)
    take = mocapkit.load(inp)
    rot = np.array(take.rotations)
    rot[3, 2] = rot[4, 2]  # one sample edited
    edited = tmp_path / "edited.npz"
    mocapkit.save(dataclasses.replace(take, rotations=rot), edited)
    capsys.readouterr()
    assert main(["clean", str(edited), "-o", str(tmp_path / "o.npz"), "--decisions", str(dec), "--record",
                 str(d / "walk.clean.npz")]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and err.startswith(f"mocapkit: error: {edited}: not the take that {dec.name} and "
                                                  "the record walk.clean.npz were made for"), err
    assert main(["clean", str(edited), "-o", str(tmp_path / "o.npz"), "--decisions", str(dec)]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and err.startswith(f"mocapkit: error: {dec}: decisions for another take"), err
    assert "not edited.npz (" in err
    assert not (tmp_path / "o.npz").exists()


def test_a_file_that_decides_one_side_of_a_swap_alone_is_refused_and_nothing_is_written(cleaned, tmp_path, capsys):
    # walk_bad's upper arms are swapped over frames 316-335 and put back by the mirrored exchange: the report ties
    # the two sides; a file edited to reject one alone would write both arms with the left arm's motion
    from mocapkit.cleaning.ties import SWAP_WHY

    d, inp = cleaned
    block = review_block(d / "walk.html")
    sides = ["repair:lhumerus:316-335", "repair:rhumerus:316-335"]
    rows = {c["id"]: c for c in block["changes"]}
    assert all(rows[s]["tied"] == sides and rows[s]["tied_why"] == SWAP_WHY for s in sides)
    doc = block["decisions"]
    doc["decisions"][sides[1]] = D.REJECT
    dec = tmp_path / "walk.decisions.json"
    dec.write_text(json.dumps(doc), encoding="utf-8")
    out = tmp_path / "o.npz"
    args = ["clean", str(inp), "-o", str(out), "--decisions", str(dec), "--record", str(d / "walk.clean.npz")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and err.startswith(f"mocapkit: error: {dec}: accepts {sides[0]} but rejects {sides[1]}, "
                                                  f"which are decided together ({SWAP_WHY})"), err
    assert not out.exists()
    doc["decisions"][sides[0]] = D.REJECT  # both sides: the input's arms back
    dec.write_text(json.dumps(doc), encoding="utf-8")
    assert main(args) == 0
    assert _same_bits(mocapkit.load(out).rotations[316:336], mocapkit.load(inp).rotations[316:336])


def test_clean_says_which_changes_are_decided_together(cleaned, tmp_path, capsys):
    from mocapkit.cleaning.ties import SWAP_WHY

    d, inp = cleaned
    assert main(["clean", str(inp), "-o", str(tmp_path / "w.npz")]) == 0
    out = capsys.readouterr().out
    said = [line.strip() for line in out.splitlines() if "accepted or rejected together" in line]
    assert said == [f"repair:lhumerus:316-335, repair:rhumerus:316-335: accepted or rejected together, as {SWAP_WHY}"]
