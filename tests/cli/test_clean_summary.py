"""`mocapkit clean`'s summary: the share of untouched samples, and how its frame numbers relate to the file's."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, samples
from mocapkit.cleaning import decisions as D
from mocapkit.cli import main


@pytest.mark.parametrize("part, whole, text", [
    (85298, 85312, "99.98"),  # 14 of 85,312 changed: "100.0" before
    (999_999, 1_000_000, "> 99.999"), (1, 1_000_000, "< 0.001"), (14, 85312, "0.02"),
    (1, 3, "33.3"), (5, 5, "100"), (0, 5, "0"),
])
def test_a_share_never_rounds_to_all_or_nothing(part, whole, text):
    from mocapkit.cli.common import percent

    assert percent(part, whole) == text


def test_one_changed_sample_does_not_read_as_all_untouched(tmp_path, capsys):
    m = mocapkit.load(samples.path("12_walk.amc"))
    root = np.array(m.root_positions)
    root[100] = np.nan  # one root cell to fill, nothing else changed
    inp = tmp_path / "gap.npz"
    mocapkit.save(dataclasses.replace(m, root_positions=root), inp)
    assert main(["clean", str(inp), "-o", str(tmp_path / "o.npz"), "--steps", "fill"]) == 0
    out = capsys.readouterr().out
    assert f"1 of {m.num_frames * m.num_joints} joint samples changed (99.99 % untouched)" in out, out


def test_the_untouched_share_says_the_frames_not_judged(tmp_path, capsys):
    # a real take on a rig the default context does not hold (pybvh's HumanIK clip, 75 frames at 30 fps): judged
    # against itself, where 19 frames have no similar motion in any joint; "100 % untouched" alone read as all checked
    inp = Path(__file__).resolve().parents[1] / "data" / "pybvh_test1_zup.bvh"
    assert main(["clean", str(inp), "-o", str(tmp_path / "o.bvh")]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("wrote "))
    assert re.search(r"% untouched; 19 of 75 frames not judged; 18 more frames judged on some joints only: no similar "
                     r"motion in the take \(judged against itself alone\)\)$", line), line
    assert "37 frames have joints that no neighbour word judges (19 of them no joint at all)" in out  # detect agrees


def _amc_frame_labels(path) -> list[int]:
    return [int(s) for s in (ln.strip() for ln in open(path, encoding="latin-1")) if re.fullmatch(r"\d+", s)]


def test_the_summary_and_report_say_how_frames_relate_to_an_amcs_numbers(tmp_path, capsys):
    """Frames are 0-based take indexes everywhere (ids, JSON, record, report); an AMC numbers them from 1, said."""
    shutil.copy(samples.path("12.asf"), tmp_path / "bad.asf")
    bad, _, _ = corrupt.real_errors(mocapkit.load(samples.path("12_walk.amc")), n_errors=4, seed=11)
    inp, out, rep = tmp_path / "bad.amc", tmp_path / "out.amc", tmp_path / "r.html"
    mocapkit.save(bad, inp)
    assert _amc_frame_labels(inp)[0] == 1
    assert main(["clean", str(inp), "-o", str(out), "--report", str(rep)]) == 0
    text = capsys.readouterr().out
    note = "frame numbers count from 0, the take's first frame, which is bad.amc's frame 1: its frame 11 is frame 10 here"
    assert f"\n  {note}\n" in text, text  # a summary line, as mocapkit.clean's summary() says it
    first, last, t0, t1 = re.search(r"flagged \w+ +frames (\d+)-(\d+) \((\d+\.\d+)-(\d+\.\d+) s\)", text).groups()
    first, last = int(first), int(last)
    # the times are the first and last frame's, as the report's viewer labels them (frame f at f / fps)
    assert (t0, t1) == (f"{first / bad.fps:.2f}", f"{last / bad.fps:.2f}")
    block = json.loads(re.search(r'id="mocapkit-review">(.*?)</script>', rep.read_text(), re.S).group(1))
    assert block["frames"] == note
    # the indexes are the take's: index i is the AMC's frame i + 1
    labels = _amc_frame_labels(out)
    assert (labels[first], labels[last]) == (first + 1, last + 1)
    # a BVH numbers no frames: nothing to say beyond the count from 0
    bvh = tmp_path / "bad.bvh"
    mocapkit.save(bad, bvh)
    assert main(["clean", str(bvh), "-o", str(tmp_path / "o.bvh"), "--report", str(tmp_path / "b.html")]) == 0
    assert "is frame 10 here" not in capsys.readouterr().out
    block = json.loads(re.search(r'id="mocapkit-review">(.*?)</script>', (tmp_path / "b.html").read_text(), re.S).group(1))
    assert block["frames"] == D.frame_note("bad.bvh") == "frame numbers count from 0, the take's first frame"


def test_joints_not_analysed_are_named_in_summary_record_and_report(tmp_path, capsys):
    """/tmp/trial19 R3: the summary, the record and the report hid which joints detection analysed, and the report's
    heat map drew the others at MDM 0, looking checked and clean. They are named, with the reason, and striped."""
    import base64
    import re

    from mocapkit.cleaning.pipeline import CleanResult

    walk = mocapkit.load(samples.path("12_walk.amc"))  # CMU ASF: hip joints with no dof, still clavicles and fingers
    inp = tmp_path / "walk.npz"
    mocapkit.save(walk, inp)
    out, report = tmp_path / "o.npz", tmp_path / "r.html"
    assert main(["clean", str(inp), "-o", str(out), "--steps", "detect", "--report", str(report)]) == 0
    text = capsys.readouterr().out
    line = [s for s in text.splitlines() if "not analysed" in s]
    assert line and "lhipjoint, rhipjoint (no rotation channels)" in line[0], text
    res = CleanResult.load(out.with_name("o.clean.npz"))
    why = dict(res.left_out)
    assert why["lhipjoint"] == "no rotation channels" and why["lfingers"] == "rotation never changes"
    assert why["rthumb"] == "beyond the 24 analysed (body first)"
    assert int((~res.analysed).sum()) == len(why) and res.analysed[walk.skeleton.index("lfemur")]
    assert not res.analysed[walk.skeleton.index("lhipjoint")]
    page = report.read_text(encoding="utf-8")
    data = json.loads(re.search(r'id="mocapkit-data">(.*?)</script>', page, re.S).group(1))
    assert [data["names"][j] for j in data["notAnalysed"]] == list(why)
    # the MDM the page holds is 0 there: only the list tells a joint not checked from one found clean
    mdm = np.frombuffer(base64.b64decode(data["mdm"]), dtype=np.uint8).reshape(-1, data["numJoints"])
    assert not mdm[:, data["notAnalysed"]].any()
