"""A take whose left and right labels are exchanged throughout (a rig mapped left for right) is named, from the
body's geometry alone, by `info` and by `clean`'s summary and record, and nothing is changed for it; takes whose
names are right are never named."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.cleaning.pipeline import CleanResult
from mocapkit.joints import standard_joints
from mocapkit.side_labels import exchanged_sides, side_agreement

from tests.cli import helpers
from tests.shared import unnamed

DATA = Path(__file__).parent / "data"
CMU = DATA / "cmu_01_01_start.bvh"  # the MotionBuilder names: LeftUpLeg, LeftArm ...
BANDAI = DATA / "dataset-2_walk_normal_001_first120.bvh"  # the game rig: UpperLeg_L ...; a rest pose along one axis


def exchanged_copy(src: Path, dst: Path, left: str, right: str, only: str = "") -> Path:
    """``src`` (a real BVH) with its joints' ``left`` and ``right`` side markers exchanged in the hierarchy (those of
    the joints whose names contain ``only``); the motion lines byte for byte as they were."""
    text = src.read_text()
    head, motion = text.split("MOTION", 1)

    def swap(m: re.Match) -> str:
        name = m.group(2)
        if only and only not in name:
            return m.group(0)
        return m.group(1) + name.replace(left, "\0").replace(right, left).replace("\0", right)

    head = re.sub(r"((?:ROOT|JOINT)\s+)(\S+)", swap, head)
    dst.write_text(head + "MOTION" + motion)
    return dst


@pytest.fixture
def cmu_exchanged(tmp_path) -> Path:
    return exchanged_copy(CMU, tmp_path / "exchanged.bvh", "Left", "Right")


def test_a_cmu_take_with_its_sides_exchanged_is_named_in_the_rest_pose_and_over_the_take(cmu_exchanged):
    assert exchanged_sides(mocapkit.load(CMU)) is None
    found = exchanged_sides(mocapkit.load(cmu_exchanged))
    assert found is not None and found.pairs == ("legs", "arms") and found.named_left == ("LeftUpLeg", "LeftArm")
    assert all(a < -0.95 for a in found.agreement) and all(r is not None and r < -0.95 for r in found.rest)
    assert "LeftUpLeg and LeftArm (named left) lie on the body's right" in str(found)


def test_a_game_rig_whose_rest_pose_cannot_tell_is_named_from_its_motion(tmp_path):
    """The Bandai Namco rig's rest pose lies along one axis: its straight legs and feet give no left, and the
    line says so; the walk's knees and ankles give it."""
    assert exchanged_sides(mocapkit.load(BANDAI)) is None
    found = exchanged_sides(mocapkit.load(exchanged_copy(BANDAI, tmp_path / "x.bvh", "_L", "_R")))
    assert found is not None and found.named_left == ("UpperLeg_L", "UpperArm_L") and found.rest == (None, None)
    assert all(a < -0.95 for a in found.agreement) and "the rest pose cannot tell" in str(found)


def test_only_the_limbs_exchanged_are_named(tmp_path):
    legs = exchanged_copy(CMU, tmp_path / "legs.bvh", "Left", "Right", only="Leg")  # LeftUpLeg, LeftLeg, ...
    m = mocapkit.load(legs)
    j = standard_joints(m.skeleton)
    assert m.skeleton.joint_names[j["left_hip"]] == "LeftUpLeg"  # the name, on the right leg now
    found = exchanged_sides(m)
    assert found is not None and found.pairs == ("legs",) and found.named_left == ("LeftUpLeg",)


def test_agreement_is_the_negative_when_the_names_are_exchanged():
    m = mocapkit.load(samples.path("131_01.bvh"))
    j = standard_joints(m.skeleton)
    swapped = {k.replace("left_", "@").replace("right_", "left_").replace("@", "right_"): v for k, v in j.items()}
    pos = m.global_positions()
    a, bend = side_agreement(pos, j)
    b, _ = side_agreement(pos, swapped)
    assert bend > 1 and a["legs"] > 0.9 and a["arms"] > 0.9
    assert np.allclose([b["legs"], b["arms"]], [-a["legs"], -a["arms"]])


def test_a_rig_whose_names_carry_no_sides_is_not_judged():
    """Its sides were read from its rest pose: nothing to exchange."""
    m = unnamed(mocapkit.load(CMU))
    assert exchanged_sides(m) is None


@pytest.mark.parametrize("path", sorted(DATA.glob("*.bvh")) + [samples.path(n) for n in (
    "131_01.bvh", "12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc",
    "HDM_bk_sneak2StepsLStart_004_120.amc", "HDM_bk_sneak2StepsLStart_005_120.amc")], ids=lambda p: p.name)
def test_real_takes_whose_names_are_right_are_not_named(path):
    assert exchanged_sides(mocapkit.load(path)) is None


def test_real_takes_of_every_rig_in_shared_data_are_not_named(shared_data):
    """HDM05 and CMU ASF/AMC, the CMU BVH releases and the Bandai Namco takes beside the checkout: no false alarm,
    and each with its sides exchanged is named (the full sweep, with every Bandai take and the respelled rigs, is
    in the commit that added this check)."""
    paths = (sorted((shared_data / "hdm05_asfamc").glob("*.amc"))[::10] + sorted((shared_data / "cmu_asfamc").glob("*.amc"))
             + sorted((shared_data / "cmu_bvh").glob("*.bvh"))
             + sorted((shared_data / "secondary_bandai_namco_CC-BY-NC").glob("*.bvh")))
    assert len(paths) > 40
    named = [p.name for p in paths if exchanged_sides(mocapkit.load(p)) is not None]
    assert named == []


def test_info_and_clean_name_it_in_one_line_and_change_nothing(cmu_exchanged, tmp_path):
    rc, text, err = helpers.run("info", cmu_exchanged)
    assert rc == 0, err
    sides = [ln for ln in text.splitlines() if ln.startswith("sides")]
    assert len(sides) == 1 and "left and right exchanged: LeftUpLeg and LeftArm (named left)" in sides[0]
    rc, text, err = helpers.run("info", CMU)
    assert rc == 0 and not any(ln.startswith("sides") for ln in text.splitlines())
    out = tmp_path / "out.bvh"
    rc, text, err = helpers.run("clean", cmu_exchanged, "-o", out, "--steps", "fill")
    assert rc == 0, err
    said = [ln for ln in text.splitlines() if "left and right exchanged" in ln]
    assert len(said) == 1 and said[0].strip().startswith("note: left and right exchanged: LeftUpLeg and LeftArm")
    assert out.read_bytes() == cmu_exchanged.read_bytes()  # named, nothing changed
    record = CleanResult.load(out.with_name("out.clean.npz"))
    assert [n for n in record.notes if n.startswith("left and right exchanged")] == [said[0].strip()[len("note: "):]]


def test_clean_batch_names_it_in_the_take_line_short(cmu_exchanged, tmp_path):
    """`clean-batch`'s one line per take says it as its JSON row and the record do (the long note), shortly; the
    take whose names are right gets no such words."""
    src = tmp_path / "in"
    src.mkdir()
    cmu_exchanged.rename(src / "exchanged.bvh")
    (src / "right.bvh").write_bytes(CMU.read_bytes())
    rc, text, err = helpers.run("clean-batch", src, tmp_path / "out", "--executor", "serial", "--steps", "fill")
    assert rc == 0, err
    lines = {name: [ln for ln in text.splitlines() if ln.startswith("cleaned ") and f"{name}.bvh ->" in ln]
             for name in ("exchanged", "right")}
    assert len(lines["exchanged"]) == 1 and len(lines["right"]) == 1
    assert "left and right exchanged: LeftUpLeg and LeftArm on the body's right (names kept)" in lines["exchanged"][0]
    assert "exchanged" not in lines["right"][0].split("->", 1)[1]
    record = CleanResult.load(tmp_path / "out" / "exchanged.clean.npz")
    assert any(n.startswith("left and right exchanged: LeftUpLeg and LeftArm (named left)") for n in record.notes)
    rc, text, err = helpers.run("clean-batch", src, tmp_path / "out2", "--executor", "serial", "--steps", "fill",
                                "--json")
    assert rc == 0, err
    rows = {Path(r["input"]).stem: r for r in json.loads(text)["rows"]}
    assert any(n.startswith("left and right exchanged: LeftUpLeg") for n in rows["exchanged"]["notes"])
