"""mocapkit.cleaning.decisions: the changes of a real cleaning, a person's choices, and the take they give."""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, samples
from mocapkit.cleaning import decisions as D
from mocapkit.cleaning.pipeline import CleanResult, clean
from mocapkit.cleaning.ties import STEPS_WHY, SWAP_WHY
from mocapkit.errors import MocapError, MocapFormatError

ROOT_GAP = slice(200, 212)  # frames whose root position is missing in the input


def _same_bits(a, b) -> bool:
    """Bit for bit, NaN included (``array_equal`` would call -0.0 and 0.0 equal and cannot compare NaN payloads)."""
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _groups_as_one(result, choice: dict) -> dict:
    """``choice`` with each group of changes decided together (:func:`D.tied`) decided as its first change is."""
    out = dict(choice)
    for ids, _ in D.tied(result):
        out.update({i: choice[ids[0]] for i in ids})
    return out


@pytest.fixture(scope="module")
def take():
    """12_walk with real-style errors, gaps, angular noise on two joints and a gap of the root position."""
    m = mocapkit.load(samples.path("12_walk.amc"))
    bad, _, _ = corrupt.real_errors(m, n_errors=4, seed=100)
    gappy, _ = corrupt.gaps(bad, seed=200)
    noisy, nmask = corrupt.angular_noise(gappy, amount=0.5, seed=300, joints=["lfemur", "rhumerus"])
    window = np.zeros(m.num_frames, dtype=bool)
    window[m.num_frames // 3: 2 * m.num_frames // 3] = True
    nmask &= window[:, None] & ~gappy.missing()
    rot = np.where(nmask[..., None], noisy.rotations, gappy.rotations)
    root = np.array(gappy.root_positions)
    root[ROOT_GAP] = np.nan
    return dataclasses.replace(gappy, rotations=rot, root_positions=root)


@pytest.fixture(scope="module")
def result(take):
    res = clean(take)
    # the corruption reaches every step: the list below then covers fill, repair and denoise
    assert res.filled.any() and res.repaired.any() and res.denoised.any()
    return res


@pytest.fixture(scope="module")
def found(result, take):
    return D.changes(result, take)


def test_changes_partition_the_changed_cells(result, take, found):
    cover = np.zeros(result.changed.shape, dtype=int)
    masks = {"fill": result.filled, "repair": result.repaired, "denoise": result.denoised}
    for c in found:
        assert 0 <= c.first <= c.last < take.num_frames and c.joint == take.skeleton.joint_names[c.joint_index]
        cover[c.first:c.last + 1, c.joint_index] += 1
        steps = c.step.split("+")
        for name, mask in masks.items():  # every cell of the change was changed by exactly its steps
            assert mask[c.first:c.last + 1, c.joint_index].all() == (name in steps)
            assert mask[c.first:c.last + 1, c.joint_index].any() == (name in steps)
        assert c.id == f"{c.step}:{c.joint}:{c.first}-{c.last}"
    assert np.array_equal(cover, result.changed.astype(int))  # each changed cell in exactly one change
    assert len({c.id for c in found}) == len(found)
    assert [(c.first, c.joint_index) for c in found] == sorted((c.first, c.joint_index) for c in found)
    assert {s for c in found for s in c.step.split("+")} == {"fill", "repair", "denoise"}


def test_change_sizes_and_reasons(result, take, found):
    cleaned = result.motion
    for c in found:
        q0, q1 = take.rotations[c.first:c.last + 1, c.joint_index], cleaned.rotations[c.first:c.last + 1, c.joint_index]
        ok = ~take.missing()[c.first:c.last + 1, c.joint_index]  # the root's cell: its position missing too
        if ok.any():
            dot = np.clip(np.abs(np.sum(q0[ok] * q1[ok], axis=-1)), 0, 1)
            assert c.max_deg == pytest.approx(np.degrees(2 * np.arccos(dot)).max(), abs=1e-9)
        else:
            assert np.isnan(c.max_deg) and c.as_dict()["max_deg"] is None and "was missing" in str(c)
        if "fill" in c.step:
            assert "missing in" in c.reason
        if "repair" in c.step:  # the rule that flagged it first, the MDM after it
            assert re.search(r"flagged(: [a-z/, -]+)? .*\(MDM up to \d\.\d\d\)", c.reason) or "flagged joint" in c.reason
        if "denoise" in c.step:
            assert "noisy" in c.reason
    json.dumps([c.as_dict() for c in found], allow_nan=False)  # the report embeds them as JSON


def test_a_small_change_never_reads_as_zero(found):
    c = dataclasses.replace(found[0], max_deg=0.0134)
    assert "(" + c.step + ", 0.013 deg)" in str(c)
    assert "2.0 deg)" in str(dataclasses.replace(found[0], max_deg=2.04))


def test_all_accept_gives_the_cleaned_take_and_all_reject_the_input(result, take, found):
    acc = D.apply(take, result, {})
    assert _same_bits(acc.rotations, result.motion.rotations)
    assert _same_bits(acc.root_positions, result.motion.root_positions)
    acc2 = D.apply(take, result, {c.id: D.ACCEPT for c in found})
    assert _same_bits(acc2.rotations, result.motion.rotations)
    rej = D.apply(take, result, {c.id: D.REJECT for c in found})
    assert _same_bits(rej.rotations, take.rotations) and _same_bits(rej.root_positions, take.root_positions)
    assert rej.skeleton == take.skeleton and rej.fps == take.fps and rej.name == take.name


def _check_cells(out, take, cleaned, acc):
    """Accepted cells hold the cleaned sample, every other cell the input's, bit for bit (root position too)."""
    for f, j in zip(*np.nonzero(np.ones(acc.shape, dtype=bool))):
        want = cleaned if acc[f, j] else take
        assert _same_bits(out.rotations[f, j], want.rotations[f, j]), (f, j)
    want_root = np.where(acc[:, :1], cleaned.root_positions, take.root_positions)
    assert _same_bits(out.root_positions, want_root)


def test_mixed_decisions_bit_identical_outside_accepted_changes(result, take, found):
    choice = _groups_as_one(result, {c.id: (D.ACCEPT if k % 2 else D.REJECT) for k, c in enumerate(found)})
    out = D.apply(take, result, choice)
    acc = np.zeros(result.changed.shape, dtype=bool)
    for c in found:
        acc[c.first:c.last + 1, c.joint_index] = choice[c.id] == D.ACCEPT
    assert np.array_equal(acc, D.accepted_cells(result, choice))
    assert acc.any() and (result.changed & ~acc).any()
    _check_cells(out, take, result.motion, acc)


def test_touching_changes_of_one_joint_made_by_one_step_are_decided_together(take):
    """Two changes of one joint that touch: a gap cut into the noisy stretch of lfemur is filled (and denoised with
    it) beside cells only denoised, so the joint's changes meet at a frame. The denoising ran across both joins: the
    three are tied, a split is refused, and decided as one they give the cleaned or the input's stretch."""
    j = take.skeleton.joint_names.index("lfemur")
    mid = take.num_frames // 2
    rot = np.array(take.rotations)
    rot[mid:mid + 6, j] = np.nan
    take = dataclasses.replace(take, rotations=rot)
    result = clean(take)
    found = D.changes(result, take)
    run = [c for c in found if c.joint_index == j]
    assert [c.step for c in run] == ["denoise", "fill+denoise", "denoise"]
    assert [a.last + 1 == b.first for a, b in zip(run, run[1:])] == [True, True]
    ids = [c.id for c in run]
    for odd in ids:
        with pytest.raises(ValueError, match=f"decided together .*{re.escape(STEPS_WHY)}"):
            D.apply(take, result, {odd: D.REJECT})
    assert [(g, why) for g, why in D.tied(result) if set(g) & set(ids)] == [(ids, STEPS_WHY)]
    a, b = run[0].first, run[-1].last + 1
    for choice, want in ((D.ACCEPT, result.motion), (D.REJECT, take)):
        out = D.apply(take, result, {i: choice for i in ids})
        assert _same_bits(out.rotations[a:b, j], want.rotations[a:b, j])


def test_root_translation_follows_the_root_change(result, take, found):
    root_changes = [c for c in found if c.joint_index == 0 and c.first <= ROOT_GAP.start <= c.last]
    assert root_changes and "fill" in root_changes[0].step
    c = root_changes[0]
    assert np.isnan(take.root_positions[ROOT_GAP]).all() and np.isfinite(result.motion.root_positions[ROOT_GAP]).all()
    rej = D.apply(take, result, {c.id: D.REJECT})
    assert _same_bits(rej.root_positions, take.root_positions)  # the gap comes back as it was (NaN)
    assert _same_bits(rej.rotations[c.first:c.last + 1, 0], take.rotations[c.first:c.last + 1, 0])
    acc = D.apply(take, result, {c.id: D.ACCEPT})
    assert _same_bits(acc.root_positions, result.motion.root_positions)


def test_record_file_applies_the_same_and_ids_are_stable(result, take, found, tmp_path):
    path = result.save(tmp_path / "walk.clean.npz")
    rec = CleanResult.load(path)
    assert rec.motion is None and rec.samples is not None
    assert [c.id for c in D.changes(rec, take)] == [c.id for c in found]
    choice = _groups_as_one(result, {c.id: (D.REJECT if k % 3 == 0 else D.ACCEPT) for k, c in enumerate(found)})
    a, b = D.apply(take, rec, choice), D.apply(take, result, choice)
    assert _same_bits(a.rotations, b.rotations) and _same_bits(a.root_positions, b.root_positions)
    # a record attached to a cleaned take read back from a lossy file still applies its own float64 samples
    q = np.round(result.motion.rotations, 3)
    blurred = dataclasses.replace(result.motion, rotations=q / np.linalg.norm(q, axis=-1, keepdims=True))
    rec2 = CleanResult.load(path, motion=blurred)
    assert _same_bits(D.apply(take, rec2, {}).rotations, result.motion.rotations)


def test_ids_are_the_same_on_a_second_run():
    m = mocapkit.load(samples.path("12_walk.amc"))
    bad, _, _ = corrupt.real_errors(m, n_errors=3, seed=11)
    runs = [[c.id for c in D.changes(clean(bad, steps="detect,repair"), bad)] for _ in range(2)]
    assert runs[0] and runs[0] == runs[1]


def test_a_record_without_samples_and_without_a_take_is_refused(result, take, tmp_path):
    path = dataclasses.replace(result, motion=None).save(tmp_path / "old.clean.npz")
    rec = CleanResult.load(path)
    assert rec.samples is None
    with pytest.raises(MocapError, match="no cleaned samples"):
        D.apply(take, rec, {})


def test_a_record_of_another_take_is_refused(result, take):
    with pytest.raises(MocapError, match="another take"):
        D.apply(take[:-1], result, {})
    with pytest.raises(MocapError, match="another rig"):
        D.changes(result, mocapkit.load(samples.path("131_01.bvh"))[: take.num_frames])


def test_unknown_ids_and_bad_choices_are_refused(result, take, found):
    with pytest.raises(ValueError, match="1 change id is not a change of this cleaning: 'repair:nosuchjoint:1-2'"):
        D.apply(take, result, {"repair:nosuchjoint:1-2": D.REJECT})
    with pytest.raises(ValueError, match="'accept' or 'reject'"):
        D.apply(take, result, {found[0].id: "maybe"})


# ---- the decisions file --------------------------------------------------------------------------


def _write(path, doc):
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def test_template_round_trips_through_a_file(result, take, found, tmp_path):
    doc = D.template(take, found, take="walk.amc", output="walk.bvh", decisions={found[0].id: D.REJECT})
    assert doc["format"] == D.FORMAT and doc["mocapkit"] == mocapkit.__version__ and doc["output"] == "walk.bvh"
    assert doc["take"] == {"name": "walk.amc", "frames": take.num_frames, "joints": take.num_joints,
                           "sha256": D.take_digest(take)}
    assert list(doc["decisions"]) == [c.id for c in found]
    assert doc["decisions"][found[0].id] == D.REJECT and set(list(doc["decisions"].values())[1:]) == {D.ACCEPT}
    path = _write(tmp_path / "d.json", doc)
    choice = D.check_decisions(D.read_decisions(path), path, take, result)
    out = D.apply(take, result, choice)
    c = found[0]
    assert _same_bits(out.rotations[c.first:c.last + 1, c.joint_index], take.rotations[c.first:c.last + 1, c.joint_index])
    review = D.review(take, result, take="walk.amc", output="walk.bvh")
    assert [x["id"] for x in review["changes"]] == [c.id for c in found]
    assert set(review["decisions"]["decisions"].values()) == {D.ACCEPT}


def test_take_digest_tells_takes_apart(take):
    assert D.take_digest(take) == D.take_digest(dataclasses.replace(take))
    rot = np.array(take.rotations)
    rot[5, 3, 1] = np.nextafter(rot[5, 3, 1], 1.0)  # one bit of one sample
    assert D.take_digest(dataclasses.replace(take, rotations=rot)) != D.take_digest(take)


@pytest.mark.parametrize("content, message", [
    ("{not json", "not JSON"),
    ('["a list"]', "not a mocapkit decisions file"),
    ('{"format": "mocapkit.decisions/9", "take": {"sha256": "x"}, "decisions": {}}', "this mocapkit reads"),
    ('{"format": "mocapkit.decisions/1", "decisions": {}}', "no \"take\""),
    ('{"format": "mocapkit.decisions/1", "take": {"sha256": "x"}, "decisions": []}', "must map change ids"),
    ('{"format": "mocapkit.decisions/1", "take": {"sha256": "x"}, "decisions": {"a": "yes"}}', "is \"accept\" or"),
])
def test_malformed_decisions_files_are_refused_in_one_line(tmp_path, content, message):
    path = tmp_path / "bad.json"
    path.write_text(content, encoding="utf-8")
    with pytest.raises(MocapFormatError, match=message) as err:
        D.read_decisions(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_decisions_for_another_take_or_another_cleaning_are_refused(result, take, found, tmp_path):
    other = dataclasses.replace(take, rotations=np.where(np.isnan(take.rotations), np.nan, take.rotations[::-1]))
    path = _write(tmp_path / "other.json", D.template(other, found, take="other.amc"))
    with pytest.raises(MocapFormatError, match=r"decisions for another take \(other.amc") as err:
        D.check_decisions(D.read_decisions(path), path, take, result)
    assert str(path) in str(err.value)
    doc = D.template(take, found)
    doc["decisions"]["repair:lfemur:0-9999"] = D.REJECT
    path = _write(tmp_path / "stale.json", doc)
    with pytest.raises(MocapFormatError, match="not a change of this cleaning") as err:
        D.check_decisions(D.read_decisions(path), path, take, result)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_take_digest_changes_with_the_root_trajectory(take):
    """Decisions made for a take whose root trajectory differs are for another take."""
    root = np.array(take.root_positions)
    root[5, 1] = np.nextafter(root[5, 1], np.inf)
    assert D.take_digest(dataclasses.replace(take, root_positions=root)) != D.take_digest(take)


def test_a_fill_change_counts_its_missing_frames_exactly(take, found):
    missing = take.missing()
    fills = [c for c in found if "fill" in c.step]
    assert fills
    for c in fills:
        n = int(missing[c.first:c.last + 1, c.joint_index].sum())
        assert f"missing in {n} of {c.frames} frames" in c.reason


def test_a_record_of_the_take_at_another_rate_is_refused(result, take):
    with pytest.raises(MocapError, match="another take"):
        D.apply(dataclasses.replace(take, fps=2 * take.fps), result, {})


def test_a_gap_of_the_root_position_alone_was_missing_and_keeps_the_root_rotation(result, take, found):
    """Frames missing only the root's position: the root's observed rotation comes back bit for bit, and the
    fill is listed as "was missing", not as a turn of a few rounding errors (1.7e-06 deg before)."""
    assert np.isfinite(take.rotations[ROOT_GAP, 0]).all()  # the fixture's root gap is of the position alone
    seen = np.isfinite(take.rotations[:, 0]).all(axis=-1) & ~result.repaired[:, 0] & ~result.denoised[:, 0]
    assert _same_bits(result.motion.rotations[seen, 0], take.rotations[seen, 0])
    gap = [c for c in found if c.joint_index == 0 and c.first <= ROOT_GAP.start and ROOT_GAP.stop - 1 <= c.last]
    assert len(gap) == 1 and np.isnan(gap[0].max_deg) and "was missing" in str(gap[0]), gap


def test_a_record_of_another_take_of_the_same_length_and_rig_is_refused(result, take, found, tmp_path):
    """The record keeps its take's digest: a take differing in one bit of one sample is another take."""
    rot = np.array(take.rotations)
    rot[5, 3, 1] = np.nextafter(rot[5, 3, 1], np.inf)
    other = dataclasses.replace(take, rotations=rot)
    rec = CleanResult.load(result.save(tmp_path / "walk.clean.npz"))
    assert rec.take_sha256 == result.take_sha256 == D.take_digest(take)
    for r in (result, rec):
        with pytest.raises(MocapError, match="the clean record is of another take .*other samples"):
            D.apply(other, r, {})
        with pytest.raises(MocapError, match="another take"):
            D.changes(r, other)
        with pytest.raises(MocapFormatError, match=r"walk\.clean\.npz: the clean record is of another take"):
            D.check_record(other, r, tmp_path / "walk.clean.npz")
    D.check_record(take, rec, tmp_path / "walk.clean.npz")  # its own take passes
    # a record written before the digest was kept: checked by rig, length and rate only (docs/upgrading.md)
    old = dataclasses.replace(rec, take_sha256="")
    assert D.record_problem(other, old) == "" and [c.id for c in D.changes(old, take)] == [c.id for c in found]


# ---- which cleaning a decisions file was made on (trial 24) ----------------------------------------------------


def _other_values(result):
    """``result`` with one cleaned rotation of one changed cell moved by one bit: the same ids, another cleaning."""
    rot = np.array(result.motion.rotations)
    f, j = np.argwhere(result.changed & np.isfinite(rot[..., 0]))[0]
    rot[f, j, 1] = np.nextafter(rot[f, j, 1], 2.0)
    return dataclasses.replace(result, motion=dataclasses.replace(result.motion, rotations=rot))


def test_decisions_apply_only_to_the_cleaning_they_were_made_on(result, take, found, tmp_path):
    """The report's file keeps the digest of the cleaning reviewed: the same ids with other values (another
    context, another threshold) are refused, whether from a record or a new cleaning; before, they were applied."""
    doc = D.template(take, found, decisions={found[0].id: D.REJECT}, result=result, record="walk.clean.npz")
    assert doc["cleaning"]["sha256"] == D.cleaning_digest(result) and doc["cleaning"]["record"] == "walk.clean.npz"
    path = _write(tmp_path / "d.json", doc)
    doc = D.read_decisions(path)
    for fresh in (False, True):  # the cleaning reviewed itself, as a record or cleaned again: applied
        assert D.check_decisions(doc, path, take, result, fresh=fresh) == {**doc["decisions"]}
    other = _other_values(result)
    assert [c.id for c in D.changes(other, take)] == [c.id for c in found]  # the ids alone cannot tell
    with pytest.raises(MocapFormatError, match=r"made on another cleaning than the record r\.clean\.npz .*"
                                               r"--record walk\.clean\.npz") as err:
        D.check_decisions(doc, path, take, other, record="r.clean.npz")
    assert str(err.value).startswith(str(path)) and "\n" not in str(err.value)
    asked = {**result.params, "request": {"context": "default", "threshold": 0.5}}
    again = dataclasses.replace(result, params={**asked, "request": {"context": ["ctx"], "threshold": 0.5}})
    reviewed = D.template(take, found, result=dataclasses.replace(result, params=asked), record="walk.clean.npz")
    with pytest.raises(MocapFormatError, match=r"reviewed without --context \(now --context ctx\); apply them to the reviewed "
                                               r"values: --record walk\.clean\.npz, or clean with the same options"):
        D.check_decisions(reviewed, path, take, again, fresh=True)
    with pytest.raises(MocapFormatError, match=r"reviewed without --context \(now --context ctx\)"):
        D.check_request(reviewed, path, again.params["request"])  # refused before cleaning
    D.check_request(reviewed, path, asked["request"])


def test_a_file_without_the_digest_is_taken_on_its_ids_for_a_record_and_refused_for_a_new_cleaning(result, take, found,
                                                                                                      tmp_path):
    doc = D.template(take, found, decisions={found[0].id: D.REJECT})  # as an earlier mocapkit wrote it
    assert "cleaning" not in doc
    path = _write(tmp_path / "old.json", doc)
    assert D.check_decisions(D.read_decisions(path), path, take, _other_values(result))[found[0].id] == D.REJECT
    assert any("keeps no digest" in n for n in D.applying_notes(doc, path, result))
    with pytest.raises(MocapFormatError, match="keeps no digest of the cleaning it was made on .* --record"):
        D.check_decisions(D.read_decisions(path), path, take, result, fresh=True)


def test_a_change_said_twice_is_refused_not_read_as_its_last_choice(take, found, tmp_path):
    doc = D.template(take, found)
    text = json.dumps(doc)
    cid = found[0].id
    twice = text.replace(f'"{cid}": "accept"', f'"{cid}": "reject", "{cid}": "accept"')
    path = tmp_path / "twice.json"
    path.write_text(twice, encoding="utf-8")
    with pytest.raises(MocapFormatError, match=f"change '{re.escape(cid)}' is named twice") as err:
        D.read_decisions(path)
    assert str(err.value).startswith(str(path)) and "\n" not in str(err.value)
    bom = tmp_path / "bom.json"
    bom.write_bytes(b"\xef\xbb\xbf" + text.encode())  # a Windows editor's UTF-8
    assert D.read_decisions(bom)["decisions"] == doc["decisions"]


def test_a_report_file_missing_a_change_is_refused_a_hand_written_one_says_what_it_accepted(result, take, found,
                                                                                              tmp_path):
    doc = D.template(take, found, result=result)
    del doc["decisions"][found[1].id]
    path = _write(tmp_path / "cut.json", doc)
    with pytest.raises(MocapFormatError, match=f"names {len(found) - 1} of the {len(found)} changes .*"
                                               f"'{re.escape(found[1].id)}'"):
        D.check_decisions(D.read_decisions(path), path, take, result)
    hand = {k: v for k, v in doc.items() if k != "cleaning"}
    hand["decisions"] = {found[0].id: D.REJECT}
    path = _write(tmp_path / "hand.json", hand)
    assert D.check_decisions(D.read_decisions(path), path, take, result) == {found[0].id: D.REJECT}
    assert f"{path} names 1 of {len(found)} changes: the {len(found) - 1} it does not name were accepted" in \
        D.applying_notes(hand, path, result)


def test_as_written_keeps_a_record_it_made_bit_for_bit(result, take):
    """An AMC bone with fewer dofs: as_written of a record as_written made gives its values back bit for bit (the
    arccos of the dot read 1e-16 as 1e-6 deg and replaced them), so the record's digest is the report's."""
    from mocapkit.io.asfamc import amc_dofs, amc_held_rotations

    dofs = amc_dofs(take.skeleton)
    held = D.as_written(result, take, lambda m: amc_held_rotations(m, dofs))
    twice = D.as_written(held, take, lambda m: amc_held_rotations(m, dofs))
    assert _same_bits(twice.motion.rotations, held.motion.rotations)
    assert D.cleaning_digest(twice) == D.cleaning_digest(held)


def test_one_side_of_a_real_swap_is_never_written_alone():
    """CMU walk 12 (bundled) with real-style errors, one a swap of the upper arms over frames 316-335 that the
    mirrored exchange puts back (each side takes its partner's mirrored rotation). Accepting one side and rejecting
    the other would write a right arm that is the left arm's mirror image: both limbs with one side's motion. Such
    decisions are refused; deciding both sides as one gives the capture's arms or the input's."""
    from mocapkit import rotations as R
    from mocapkit.cleaning.ssa.cues import mirrored_rotations

    ref = mocapkit.load(samples.path("12_walk.amc"))
    bad, _, _ = corrupt.real_errors(ref, n_errors=4, seed=11)
    result = clean(bad)
    names = bad.skeleton.joint_names
    arms = [names.index("lhumerus"), names.index("rhumerus")]
    sides = ["repair:lhumerus:316-335", "repair:rhumerus:316-335"]
    span = slice(316, 336)
    for kept, dropped in (sides, sides[::-1]):
        try:
            out = D.apply(bad, result, {kept: D.ACCEPT, dropped: D.REJECT})
        except ValueError as exc:
            assert f"accepts {kept} but rejects {dropped}, which are decided together ({SWAP_WHY})" in str(exc)
            continue
        q = out.rotations[span][:, arms]
        own = np.degrees(R.geodesic_angle(q, ref.rotations[span][:, arms])).max(axis=0)
        mirror = np.degrees(R.geodesic_angle(q[:, ::-1], mirrored_rotations(out)[span][:, arms[::-1]])).max()
        assert _same_bits(q, bad.rotations[span][:, arms]) or own.max() < 1e-9, (
            f"accepting {kept} alone wrote arms {own.round(1)} deg from the capture's, each the other's mirror image "
            f"(to {mirror:.1g} deg): both limbs hold one side's motion")
    assert (sides, SWAP_WHY) in D.tied(result)
    for choice, want in ((D.ACCEPT, ref), (D.REJECT, bad)):
        q = D.apply(bad, result, {s: choice for s in sides}).rotations[span][:, arms]
        assert np.degrees(R.geodesic_angle(q, want.rotations[span][:, arms])).max() < 1e-9


def test_a_repair_beside_a_denoised_run_is_not_rejected_alone(shared_data):
    """HDM05 grabHighR (bd, 001) with angular noise (0.5 of each channel's spread, seed 1): rtoes is denoised over
    most of the take, and a run of it next to that, also flagged, is repaired and denoised with it: two changes
    that touch. Rejecting the repair alone would put its noisy input beside smoothed neighbours: a step of degrees
    in one frame where the take cleaned steps under 1 deg. The touching changes are decided together."""
    from mocapkit import rotations as R

    take = mocapkit.load(shared_data / "hdm05_asfamc" / "HDM_bd_grabHighR_001_120.amc")
    bad = corrupt.corrupt(take, kind="noise", amount=0.5, seed=1)[0]
    result = clean(bad)
    j = bad.skeleton.joint_names.index("rtoes")
    rows = [c for c in D.changes(result, bad) if c.joint_index == j]
    pairs = [(a, b) for a, b in zip(rows, rows[1:]) if a.last + 1 == b.first
             and {a.step, b.step} == {"denoise", "repair+denoise"}]
    assert pairs, [c.id for c in rows]
    a, b = pairs[0]
    inner, outer = (a, b) if a.step == "repair+denoise" else (b, a)
    join = max(a.last, 1)  # the step from a's last frame to b's first
    steps = np.degrees(R.geodesic_angle(result.motion.rotations[1:, j], result.motion.rotations[:-1, j]))
    near = slice(max(join - 3, 0), join + 3)
    assert steps[near].max() < 1.0
    try:
        out = D.apply(bad, result, {inner.id: D.REJECT})
    except ValueError as exc:
        assert f"but rejects {inner.id}, which are decided together ({STEPS_WHY})" in str(exc)
    else:
        pop = np.degrees(R.geodesic_angle(out.rotations[1:, j], out.rotations[:-1, j]))[near]
        pytest.fail(f"rejecting {inner.id} alone was applied: rtoes steps {pop.round(1)} deg/frame around frame "
                    f"{join}, a pop the take cleaned ({steps[near].round(1)}) does not have")
    group = next(g for g, why in D.tied(result) if inner.id in g)
    assert outer.id in group
    frames = np.concatenate([np.arange(c.first, c.last + 1) for c in rows if c.id in group])
    for choice, want in ((D.ACCEPT, result.motion), (D.REJECT, bad)):
        out = D.apply(bad, result, {i: choice for i in group})
        assert _same_bits(out.rotations[frames, j], want.rotations[frames, j])
