"""What the report says of the frames detection never judged and of the flags the cleaning left as they were.

On CMU 131_01 (shipped, BVH, 120 fps) detection judges some frames on no joint or on some joints only (no
similar motion in the take), and the repair of RightElbow's hold (frames 960-965) is given back as it was (it moves the
elbow by 0.012 deg at most: nothing to see).
A heat map cell nothing judged has MDM 0 and was drawn dark, as if found clean; a flag left unchanged was listed
under "the changes above are what the cleaning did about them" with no word of why.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.cleaning.decisions import flag_segments
from mocapkit.cleaning.judged import not_judged, not_judged_cells, not_judged_note
from mocapkit.cleaning.pipeline import clean
from mocapkit.cleaning.ssa import LeftRun
from mocapkit.cleaning.ssa.flips import left_from_note
from mocapkit.report.html import write_clean_report

from .test_html import browser, open_page, page_data  # noqa: F401  (fixtures)

STRIPES = ((173, 181, 189), (222, 226, 230))
DARK = (68, 1, 84)  # the colour ramp's 0


@pytest.fixture(scope="module")
def cleaned_131_01():
    take = mocapkit.load(samples.path("131_01.bvh"))
    res = clean(take, steps=("detect", "repair"))
    none, some = not_judged(res.detection)
    assert none + some > 0  # the take has frames nothing judged: what the page must say
    return take, res


@pytest.fixture(scope="module")
def report(tmp_path_factory, cleaned_131_01):
    take, res = cleaned_131_01
    return write_clean_report(tmp_path_factory.mktemp("judged") / "131_01.html", take, res,
                              inp=samples.path("131_01.bvh"))


def test_not_judged_cells_are_those_of_analysed_joints_without_a_digression(cleaned_131_01):
    _, res = cleaned_131_01
    det = res.detection
    cells = not_judged_cells(det)
    assert cells.shape == det.digression.shape and not cells[:, ~det.analysed].any()
    assert np.array_equal(cells[:, det.analysed], ~np.isfinite(det.digression[:, det.analysed]))
    none, some = not_judged(det)
    rows = cells[:, det.analysed]
    assert (int(rows.all(axis=1).sum()), int((rows.any(axis=1) & ~rows.all(axis=1)).sum())) == (none, some)


def test_frames_not_judged_are_striped_and_counted_not_drawn_as_found_clean(open_page, report, cleaned_131_01):
    take, res = cleaned_131_01
    cells = not_judged_cells(res.detection)
    pg = open_page(report)
    assert pg.errors == []
    summary = pg.js("document.getElementById('summary').textContent")
    assert not_judged_note(res.detection, take.num_frames) in summary
    assert "frames not judged" in summary or "judged on some joints only" in summary
    assert "not judged by detection" in pg.js("document.querySelector('.heat .note').textContent")
    lay = pg.js("window.mocapkitReport.heatmapLayout()")
    dpr = pg.js("window.devicePixelRatio || 1")
    F = take.num_frames

    def ink(j, first, last, rgb):  # pixels of joint j's heat row over frames first..last-1 close to rgb
        x0 = (lay["left"] + lay["width"] * first / F) * dpr + 1
        x1 = (lay["left"] + lay["width"] * last / F) * dpr - 1
        y = int((lay["top"] + (j + 0.5) * lay["rowHeight"]) * dpr)
        return pg.ink("heatmap", rgb=rgb, region=[int(x0), y, max(1, int(x1 - x0)), 1])

    # the analysed joint with the longest run of frames nothing judged, and nothing flagged there
    best = None
    for j in np.flatnonzero(res.analysed):
        col = cells[:, j] & ~res.flags[:, j]
        edges = np.flatnonzero(np.diff(np.r_[0, col.astype(int), 0]))
        for a, b in zip(edges[::2], edges[1::2]):
            if best is None or b - a > best[2] - best[1]:
                best = (int(j), int(a), int(b))
    assert best is not None and best[2] - best[1] >= 20
    j, a, b = best
    assert sum(ink(j, a, b, c) for c in STRIPES) > 10 and ink(j, a, b, DARK) == 0
    judged = np.flatnonzero(~cells[:, j] & (res.mdm[:, j] == 0) & ~res.flags[:, j])
    assert judged.size  # a cell judged and found clean stays dark
    run = judged[:20] if np.all(np.diff(judged[:20]) == 1) else judged[:1]
    assert ink(j, int(run[0]), int(run[-1]) + 1, DARK) > 0


def test_a_flag_left_as_it_was_says_why_and_a_repaired_one_points_to_its_change(open_page, report, cleaned_131_01):
    take, res = cleaned_131_01
    runs = [LeftRun.from_note(n) for n in res.notes if n.startswith("left: repair not better than the take: ")]
    assert runs and all(runs) and any(r.joint == "RightElbow" for r in runs)
    pg = open_page(report)
    assert pg.errors == []
    assert "a flag it left as it was says why" in pg.js("document.querySelector('#flags .note').textContent")
    rows = pg.js("""() => [...document.querySelectorAll('#flags tbody tr')].map(
        tr => [tr.dataset.flag, tr.querySelector('td.outcome').textContent])""")
    assert len(rows) == len(flag_segments(res))
    left = 0
    for flag, outcome in rows:
        joint, span = flag.rsplit(":", 1)
        a, b = (int(x) for x in span.split("-"))
        if res.changed[a:b + 1, take.skeleton.index(joint)].any():
            assert outcome == "changed: see the changes above"
            continue
        turns = [f for f in (left_from_note(n) for n in res.notes) if f and joint in f[0] and f[1] <= b and a <= f[2]]
        if turns:  # the sample's own RThumb flip whose two steps disagree (mocapkit.cleaning.ssa.flips)
            assert outcome == f"left as it was: a half turn in one frame and back, not turned back ({turns[0][3]})"
            continue
        why = [r.reason for r in runs if r.joint == joint and r.start <= b and a < r.end]
        assert why and outcome == f"left as it was: the repair was not better than the take ({why[0]})"
        left += 1
    assert left >= 1 and any(f.startswith("RightElbow:") and "left as it was" in o for f, o in rows)


def test_clean_batch_line_says_the_flags_left_and_the_frames_not_judged(tmp_path, capsys, cleaned_131_01):
    from mocapkit.cli import main

    take, res = cleaned_131_01
    src = tmp_path / "in"
    src.mkdir()
    (src / "131_01.bvh").write_bytes(samples.path("131_01.bvh").read_bytes())
    assert main(["clean-batch", str(src), str(tmp_path / "out"), "--steps", "detect,repair"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("cleaned "))
    assert "flagged runs left as they were (" in line and "RightElbow 96" in line  # and RThumb 237-242's flip
    assert "the repair was not better than the take" in line
    assert not_judged_note(res.detection, take.num_frames) in line


def test_the_batch_line_says_one_run_left_as_it_was_and_two_as_they_were(monkeypatch):
    """Docs trial A: clean-batch said "2 flagged runs left as it was (RThumb 237-242, RightElbow 960-965: ...)"."""
    from mocapkit.cleaning import flags_left

    runs = [{"joint": "RThumb", "first": 237, "last": 242, "left": "left as it was: a half turn in one frame and back"},
            {"joint": "RightElbow", "first": 960, "last": 965, "left": "left as it was: the repair was not better than the take"}]
    monkeypatch.setattr(flags_left, "flag_outcomes", lambda result: runs[:1])
    assert flags_left.left_line(None).startswith("1 flagged run left as it was (RThumb 237-242: a half turn")
    monkeypatch.setattr(flags_left, "flag_outcomes", lambda result: runs)
    assert flags_left.left_line(None).startswith("2 flagged runs left as they were (RThumb 237-242, RightElbow 960-965: ")


def test_each_change_and_flag_reads_as_an_animators_sentence_with_the_rule_as_detail(open_page, report, cleaned_131_01):
    """The trial: reasons read "a digression its own break confirms", "MDM up to 0.00". Each row now opens with what
    is wrong with the motion and what was done, the detector's words kept after it in brackets."""
    take, res = cleaned_131_01
    pg = open_page(report)
    assert pg.errors == []
    cells = pg.js("""() => [...document.querySelectorAll('#changes td.reason, #flags td.reason')].map(
        td => [td.textContent, td.querySelector('.detail').textContent])""")
    assert len(cells) == pg.js("() => document.querySelectorAll('#changes tbody tr, #flags tbody tr').length") > 0
    for text, detail in cells:
        sentence = text[:len(text) - len(detail)].strip()
        assert sentence and sentence[0].isupper() and sentence.endswith(".")
        assert "MDM" not in sentence and "digression" not in sentence and "confirms" not in sentence
        assert detail.startswith("(") and detail.endswith(")")
    elbow = pg.js("""() => [...document.querySelectorAll('#flags tr')].filter(tr => (tr.dataset.flag || '')
        .startsWith('RightElbow:')).map(tr => tr.querySelector('td.reason').textContent)""")
    assert elbow and all(t.startswith("The joint stays still while it moves in the similar moments.")
                         and "(held still while the similar motion moves" in t for t in elbow)


def test_a_flag_a_break_confirms_reads_as_an_animators_sentence():
    """The sample's flags no longer hold a break-confirmed one (its wrist flick is a smooth turn): the sentence said
    directly."""
    from mocapkit.report.plain import plain_sentence

    assert plain_sentence("", ["a digression its own break confirms"]) == (
        "The joint breaks away from how it moves in the similar moments of the take.")


def test_a_flag_changed_in_part_says_the_frames_left_and_why():
    """User trial U2 (40 Bandai Namco takes through clean-batch): on raise-up-right-hand_active_060 with a flip
    (`mocapkit corrupt --kind flip --seed 2`), detection flags UpperLeg_R over frames 7-26; repair turns the
    turn-over at 14-26 back and its guard gives 7-13 back as they were (the entry would join the take less
    smoothly). The report's flag said "changed: see the changes above" and the batch line "44 flagged samples,
    31 repaired samples; 1 flagged run left as it was (Neck 25-30: ...)": 7 flagged samples left with no word.
    The flag now says which frames were left and why, and the line names them, so the counts add up."""
    from mocapkit.cleaning.flags_left import flag_outcomes, left_line

    take = mocapkit.load(Path(__file__).parents[1] / "data" / "dataset-2_raise-up-right-hand_active_060_flip.bvh")
    res = clean(take, steps=("detect", "repair"))
    [leg] = [f for f in flag_outcomes(res) if f["joint"] == "UpperLeg_R"]
    j = take.skeleton.index("UpperLeg_R")
    assert (leg["first"], leg["last"]) == (7, 26) and res.changed[14:27, j].all() and not res.changed[7:14, j].any()
    assert leg["left"].startswith("changed in part: frames 7-13 left as they were: the repair was not better "
                                  "than the take (its entry joins the take less smoothly")
    line = left_line(res)
    # Neck's flip 8-24 is turned back and its frames 0-7 (clean, flagged with it) left; the half turn 31-45 that
    # lasts to the take's end is left: every cell of the output is the clean take's (0.0 deg off)
    assert line.startswith("3 flagged runs left as they were (Neck 0-7, UpperLeg_R 7-13, Neck 31-45: the repair was not "
                           "better than the take; a half turn in one frame, not turned back)")
    left = [f["left_frames"] for f in flag_outcomes(res) if f["left"]]
    assert int(res.flags.sum()) - int((res.flags & res.changed).sum()) == sum(b - a + 1 for a, b in left)


def test_the_record_counts_the_flags_the_report_lists_turn_overs_included():
    """User trial B (40 Bandai Namco takes through clean-batch): on raise-up-right-hand_active_060 with a flip
    (`mocapkit corrupt --kind flip --seed 2`) the record said "detect: 4 flagged segments" and the report
    "Flags (5)": the repair step flags the turn-overs' cells too (Neck 25-30 a flag of its own), and no step's
    note counted them. Detect's note still counts what detection flagged; the step that flags more says the
    flags in all, as the report lists them (:func:`flag_segments`), in review mode (detect alone) too."""
    import re

    take = mocapkit.load(Path(__file__).parents[1] / "data" / "dataset-2_raise-up-right-hand_active_060_flip.bvh")
    for steps, last in ((("detect", "repair"), "repair"), (("detect",), "detect")):
        res = clean(take, steps=steps)
        notes = {s.name: s.note for s in res.steps}
        assert notes["detect"].startswith(f"{len(res.detection.segments())} flagged segments"), notes
        listed = len(flag_segments(res))
        assert listed > len(res.detection.segments()), (steps, listed)  # the turn-overs' flags: what the trial saw
        said = re.search(r"(\d+) flagged segments in all with the turn-overs' cells \((\d+) before\)", notes[last])
        assert said and int(said[1]) == listed and int(said[2]) == len(res.detection.segments()), notes[last]
