"""One preparation serves detection and repair: the take is resampled to the analysis rate once."""

import dataclasses
import importlib

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning import ssa
from mocapkit.cleaning.pipeline import clean
from mocapkit.motion import Motion

repair_module = importlib.import_module("mocapkit.cleaning.ssa.repair")  # the package's `repair` is the function


@pytest.fixture(scope="module")
def flipped():
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    bad, _, _ = corrupt.real_errors(walk, kinds=("flip",), n_errors=1, seed=1, joints=["LeftKnee"])
    return bad


@pytest.fixture
def resamples(monkeypatch):
    """The frame rates Motion.resample is called with, in order."""
    calls = []
    original = Motion.resample

    def counted(self, fps):
        calls.append(float(fps))
        return original(self, fps)

    monkeypatch.setattr(Motion, "resample", counted)
    return calls


def test_repair_reuses_the_preparation_of_detect(flipped, resamples, monkeypatch):
    det = ssa.detect(flipped)
    assert resamples == [24.0]  # the take, once, to the analysis rate
    assert det.analysis is not None and det.analysis.motion is flipped and det.flags.any()
    monkeypatch.setattr(repair_module, "prepare", lambda *a, **k: pytest.fail("repair prepared the take again"))
    fixed = ssa.repair(flipped, det, foot_skate=False)
    assert resamples == [24.0]
    assert not np.array_equal(fixed.rotations, flipped.rotations)
    # the same preparation behind a new threshold
    assert ssa.repair(flipped, det.with_threshold(0.4), foot_skate=False) is not None and resamples == [24.0]


def test_a_saved_detection_is_prepared_again_with_the_same_result(flipped, resamples, tmp_path):
    det = ssa.detect(flipped)
    back = ssa.Detection.load(det.save(tmp_path / "det.npz"))
    assert back.analysis is None
    del resamples[:]
    again = ssa.repair(flipped, back, foot_skate=False)
    assert resamples == [24.0]
    assert np.array_equal(again.rotations, ssa.repair(flipped, det, foot_skate=False).rotations)


def test_a_context_is_reused_only_when_it_is_the_one_given_to_detect(flipped, resamples):
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    context = [dataclasses.replace(walk, name="twin")]
    det = ssa.detect(flipped, context)
    assert resamples == [24.0, 24.0, 24.0]  # informative joints need none; the take, then the take and its context
    del resamples[:]
    same = ssa.repair(flipped, det, context, foot_skate=False)
    own = ssa.repair(flipped, det, foot_skate=False)  # None: the detection's own context
    assert resamples == []
    other = ssa.repair(flipped, det, list(context), foot_skate=False)  # an equal list, not the same: prepared again
    assert resamples == [24.0, 24.0, 24.0]
    assert np.array_equal(same.rotations, own.rotations) and np.array_equal(same.rotations, other.rotations)


def test_clean_resamples_the_take_once(flipped, resamples):
    res = clean(flipped, steps="detect,repair")
    assert res.repaired.any()
    assert resamples == [24.0]
