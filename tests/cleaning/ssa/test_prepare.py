"""One preparation serves detection and repair: the take is resampled to the analysis rate once."""

import dataclasses
import importlib

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.pipeline import clean
from mocapkit.motion import Motion
from tests.cleaning.ssa.helpers import twin_of

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
    context = [twin_of(walk)]
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


def _rotation_spread_joint_by_joint(motions, joints):
    """texture._rotation_spread's reference: one joint at a time."""
    from mocapkit.cleaning.ssa.texture import STILL_RAD

    sk = motions[0].skeleton
    spread = np.zeros(sk.num_joints)
    turns = np.zeros(sk.num_joints, dtype=bool)
    for j in joints:
        qs = np.concatenate([R.quaternion_continuity(np.asarray(m.rotations[:, j])) for m in motions])
        qs = qs[np.all(np.isfinite(qs), axis=1)]
        if len(qs) == 0:
            continue
        turns[j] = bool(np.max(R.geodesic_angle(qs, qs[0])) > STILL_RAD)
        if not turns[j]:
            continue
        mean = qs.mean(axis=0)
        if np.linalg.norm(mean) < 1e-9:
            spread[j] = np.pi
            continue
        mean = mean / np.linalg.norm(mean)
        spread[j] = float(np.mean(R.geodesic_angle(qs, mean)))
    return spread, turns


def test_rotation_spread_of_all_joints_at_once_is_the_joint_by_joint_reference():
    """Every joint's spread and turning in one pass (texture._rotation_spread) are, bit for bit, what one joint at a
    time gave: on a take, on a take and a context clip, and with NaN frames (then joint by joint)."""
    import dataclasses

    from mocapkit.cleaning.ssa import texture

    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    other = dataclasses.replace(walk[100:400], rotations=np.array(walk.rotations[100:400])[::-1].copy())
    gappy = np.array(walk.rotations)
    gappy[50:60, 4] = np.nan
    for motions in ([walk], [walk, other], [dataclasses.replace(walk, rotations=gappy)]):
        joints = np.arange(walk.num_joints)
        got = texture._rotation_spread(motions, joints)
        want = _rotation_spread_joint_by_joint(motions, joints)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
        assert want[1].any() and not want[1].all()  # still joints too
        sub = joints[::3]
        assert all(np.array_equal(a, b) for a, b in zip(texture._rotation_spread(motions, sub),
                                                         _rotation_spread_joint_by_joint(motions, sub)))


def retimed(motion, fps):
    """The take's own frames said to be sampled at ``fps`` (a BVH whose Frame Time is 1 s is a 1 fps take)."""
    return dataclasses.replace(motion, fps=float(fps))


def test_a_take_too_coarse_for_a_word_is_refused_before_its_texture_is_made(resamples):
    """150 frames at 1 fps were resampled to 3,577 frames at 24 fps (714 words, 25 s and more of word DTW) of
    slerp between samples a second apart: a word of 0.625 s lies inside one of the take's frame intervals."""
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:150]
    with pytest.raises(ValueError, match=r"^131_01: 1 fps is too coarse for motion words: a source word spans 0\.625 s "
                       r"\(15 frames at 24 fps\), 0\.62 of the take's frames; self-similarity judges takes of 12 fps"):
        ssa.prepare(retimed(walk, 1))
    with pytest.raises(ValueError, match=r"^131_01: 5 fps is too coarse for motion words: .*, 3\.1 of the take's frames"):
        ssa.prepare(retimed(walk, 5))
    assert resamples == []


def test_takes_from_the_lowest_judged_rate_up_are_prepared():
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:150]
    assert ssa.min_take_fps() == 12.0 and ssa.min_take_fps(ssa.SSAParams(analysis_fps=30)) == 15.0
    an = ssa.prepare(retimed(walk, 12))
    assert an.source.num_frames == 299  # the texture at most twice the take's frames
    assert ssa.too_coarse(12.0) == "" and ssa.too_coarse(1 / 0.0833334) == "" and ssa.too_coarse(11.9) != ""
    with pytest.raises(ValueError, match="too coarse"):
        ssa.prepare(retimed(walk, 11.9))


def test_a_context_clip_too_coarse_for_a_word_is_left_out_and_named(resamples):
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    coarse = dataclasses.replace(retimed(walk[400:550], 1), name="coarse")
    an = ssa.prepare(walk[:300], context=[coarse])
    assert not an.has_context and an.context == ()
    assert any(n.startswith("context clip 'coarse' left out: 1 fps is too coarse for motion words") for n in an.notes)
    assert resamples == [24.0]  # the take's texture only
