"""Markers in another length unit than the database's are refused; real takes of other performers are not."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.database import MotionDatabase
from mocapkit.features import virtual_markers
from mocapkit.reconstruct import markers, ssg
from mocapkit.reconstruct.marker_units import SIZE_RANGE, check_marker_scale, marker_scale

SIX = ["lhand", "rhand", "lfoot", "rfoot", "head", "root"]
BANDAI_SIX = ["Hand_L", "Hand_R", "Foot_L", "Foot_R", "Head", "Hips"]


@pytest.fixture(scope="module")
def bandai():
    clip = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh")
    return clip, MotionDatabase.build([clip], fps=30, executor="serial", progress=False)


def test_other_hdm05_actors_and_a_cmu_subject_pass(small_db, shared_data):
    """Every HDM05 actor's takes (the database holds bd and bk only) and a CMU subject are the database's size."""
    root = shared_data / "hdm05_asfamc"
    takes = [sorted(root.glob(f"HDM_{a}_*_120.amc"))[0] for a in ("bd", "bk", "dg", "mm", "tr")]
    takes.append(mocapkit.samples.path("12_walk.amc"))
    for path in takes:
        t = mocapkit.load(path).resample(30)
        for joints in (SIX, SIX[:4]):
            s = marker_scale(virtual_markers(t, joints), joints, small_db)
            assert SIZE_RANGE[0] < s < SIZE_RANGE[1], (path.name, joints, s)
            check_marker_scale(virtual_markers(t, joints), joints, small_db)


@pytest.mark.parametrize("factor, unit", [(2.54 / 0.45, "centimetres"), (25.4 / 0.45, "millimetres"),
                                          (2.54 / 0.45 / 100, "metres"), (1 / 0.45, "inches")])
def test_hdm05_database_refuses_markers_in_another_unit(small_db, factor, unit):
    t = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")).resample(30)[:60]
    x = virtual_markers(t, SIX) * factor  # the database is in HDM05's unit, 5.644 cm
    with pytest.raises(ValueError, match=rf"look like {unit} while the database is in HDM05/Acclaim units"):
        markers.reconstruct(x, SIX, small_db, fps=30)
    with pytest.raises(ValueError, match=rf"look like {unit}"):
        ssg.reconstruct(x[:, :4], SIX[:4], small_db, fps=30)


def test_bandai_markers_in_metres_are_refused_naming_both_units(bandai):
    """The trial's case: a centimetre Bandai Namco database given markers in metres (it gave 311 cm of error)."""
    clip, db = bandai
    x = virtual_markers(clip, BANDAI_SIX)
    check_marker_scale(x, BANDAI_SIX, db)  # centimetres: its own unit
    with pytest.raises(ValueError, match="look like metres while the database is in centimetres") as err:
        markers.reconstruct(x / 100.0, BANDAI_SIX, db, fps=30)
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="look like metres while the database is in centimetres"):
        ssg.reconstruct(x[:, :4] / 100.0, BANDAI_SIX[:4], db, fps=30)


def test_a_cloud_of_no_seen_pair_is_not_judged(small_db):
    x = np.full((5, 3, 3), np.nan)
    x[:, 0] = 1.0  # one marker seen: no distance
    assert np.isnan(marker_scale(x, SIX[:3], small_db))
    check_marker_scale(x, SIX[:3], small_db)
