"""mocapkit.cleaning.pipeline: clean() on real bundled clips with known corruption."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, metrics, samples
from mocapkit import rotations as R
from mocapkit.cleaning import gapfill
from mocapkit.cleaning.pipeline import CleanResult, clean, clean_path, noise_direction, noise_level, noisy_cells
from mocapkit.cleaning.runs import true_runs
from mocapkit.errors import MocapError, MocapFormatError
from mocapkit.words import frame_runs
from tests.cleaning.ssa.helpers import twin_of
from tests.shared import unknown_rig


def _mixed(m, seed=0):
    """Real-style errors + gaps + angular noise (0.5) on two joints over the middle third; masks of each."""
    bad, err, _ = corrupt.real_errors(m, n_errors=4, seed=100 + seed)
    gappy, gap = corrupt.gaps(bad, seed=200 + seed)
    noise_joints = ["lfemur", "rhumerus"]
    noisy, nmask = corrupt.angular_noise(gappy, amount=0.5, seed=300 + seed, joints=noise_joints)
    F = m.num_frames
    window = np.zeros(F, dtype=bool)
    window[F // 3 : 2 * F // 3] = True
    nmask = nmask & window[:, None] & ~gap & ~err
    rot = np.where(nmask[..., None], noisy.rotations, gappy.rotations)
    out = dataclasses.replace(gappy, rotations=rot)
    return out, err, gap, nmask


@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(samples.path("12_walk.amc"))


@pytest.fixture(scope="module")
def cleaned(walk):
    bad, err, gap, nmask = _mixed(walk)
    return bad, err, gap, nmask, clean(bad)


def test_clean_changes_only_gaps_flags_and_noise(walk, cleaned):
    bad, err, gap, nmask, res = cleaned
    out = res.motion
    assert not out.missing().any()
    assert np.array_equal(res.filled, bad.missing())
    untouched = ~res.changed
    assert np.array_equal(out.rotations[untouched], bad.rotations[untouched])  # bit-identical
    assert np.array_equal(out.root_positions, bad.root_positions)
    # repair changes flagged cells only (foot-skate cleanup off), denoise only cells over the noise level
    assert not (res.repaired & ~res.flags).any()
    assert res.denoised.any() and not (res.denoised & ~(res.noise > 1.0)).any()
    corrupted = err | gap | nmask
    share = float((~res.changed[~corrupted]).mean())
    assert share > 0.9, share


def test_clean_lowers_the_error(walk, cleaned):
    bad, err, gap, nmask, res = cleaned
    before = gapfill.fill_motion(bad, "linear")
    e0, e1 = metrics.pose_error(walk, before).mean(), metrics.pose_error(walk, res.motion).mean()
    assert e1 < 0.5 * e0, (e0, e1)
    c0, c1 = metrics.joint_position_rms(walk, before), metrics.joint_position_rms(walk, res.motion)
    assert c1 < c0
    # the noise is found where it was added, and reduced there
    assert res.denoised[nmask].mean() > 0.8
    d0 = metrics.geodesic_pose_distance(walk, bad)[nmask].mean()
    d1 = metrics.geodesic_pose_distance(walk, res.motion)[nmask].mean()
    assert d1 < 0.7 * d0, (d0, d1)
    # a good share of the injected errors is flagged (measured: 98 of 204 cells)
    assert (res.flags & err).sum() > 0.35 * err.sum()


def test_step_records(cleaned):
    res = cleaned[-1]
    assert [s.name for s in res.steps] == ["fill", "detect", "repair", "denoise"]
    by = {s.name: s for s in res.steps}
    assert by["fill"].method.startswith("EBD's gap prior (shipped)") and by["fill"].cells == int(res.filled.sum())
    assert by["repair"].cells == int(res.repaired.sum()) > 0
    assert by["denoise"].method == "EBF (shipped)" and by["denoise"].cells == int(res.denoised.sum())
    assert all(s.seconds >= 0 for s in res.steps)
    assert res.detection is not None and res.detection.flags.shape == res.flags.shape
    assert any("fill" in line for line in res.summary())


def test_save_load_round_trip(cleaned, tmp_path):
    res = cleaned[-1]
    p = res.save(tmp_path / "take.clean.npz")
    back = CleanResult.load(p, motion=res.motion)
    for name in ("flags", "filled", "repaired", "denoised", "changed"):
        assert np.array_equal(getattr(back, name), getattr(res, name)), name
    assert np.allclose(back.mdm, res.mdm, atol=1e-6)
    assert [dataclasses.replace(s, seconds=0.0) for s in back.steps] == [dataclasses.replace(s, seconds=0.0)
                                                                         for s in res.steps]
    assert all(np.isnan(s.seconds) for s in back.steps)  # not saved: see below
    assert back.joint_names == res.joint_names and back.fps == res.fps
    assert not list(tmp_path.glob(".*.part"))
    # the same result saved after steps of other durations is the same file (the timings made every record differ)
    slower = dataclasses.replace(res, steps=tuple(dataclasses.replace(s, seconds=s.seconds + 1.5) for s in res.steps))
    assert slower.save(tmp_path / "again.clean.npz").read_bytes() == p.read_bytes()
    np.savez(tmp_path / "other.npz", mdm=np.zeros(3))
    with pytest.raises(MocapFormatError, match="not a mocapkit clean file"):
        CleanResult.load(tmp_path / "other.npz")


def test_a_missing_record_or_a_mask_file_is_said_as_what_it_is(tmp_path):
    """`clean --record` given a path that is not there, or corrupt's mask file: "no such file", and what the npz
    lacks (before: "not a mocapkit clean file (... [Errno 2] ...)" and a bare KeyError, "('meta')")."""
    from mocapkit.errors import MissingFileError
    from mocapkit.io.masks import write_mask

    with pytest.raises(MissingFileError, match=r"nope\.clean\.npz: no such file$"):
        CleanResult.load(tmp_path / "nope.clean.npz")
    mask = write_mask(tmp_path / "bad.mask.npz", np.zeros((4, 2), bool), ["a", "b"], kind="gaps", seed=1)
    with pytest.raises(MocapFormatError, match=r"bad\.mask\.npz: not a mocapkit clean file: it holds no 'meta' "
                                               r"\(it is a mask file.*give the \.clean\.npz") as err:
        CleanResult.load(mask)
    assert "\n" not in str(err.value)


def test_clean_path():
    assert clean_path("a/walk.bvh").as_posix() == "a/walk.clean.npz"
    assert clean_path("walk.npz").name == "walk.clean.npz"


def test_steps_subset_and_order(walk):
    bad, err, gap, _ = _mixed(walk, seed=1)
    res = clean(bad, steps="denoise,fill")  # any order: runs fill, then denoise
    assert [s.name for s in res.steps] == ["fill", "denoise"]
    assert res.detection is None and not res.repaired.any() and not res.flags.any()
    with pytest.raises(MocapError, match="add the fill step"):
        clean(bad, steps=("detect", "repair"))
    with pytest.raises(ValueError, match="needs the detect step"):
        clean(walk, steps=("repair",))
    with pytest.raises(ValueError, match="unknown step"):
        clean(walk, steps=("fill", "polish"))


def test_clean_take_is_left_alone(walk):
    res = clean(walk[:120], steps=("fill", "denoise"))
    # a clean real take: no gap, (almost) nothing above the noise level
    assert not res.filled.any()
    assert res.denoised.mean() < 0.05
    assert np.array_equal(res.motion.rotations[~res.denoised], walk[:120].rotations[~res.denoised])


def test_another_rig_falls_back_with_notes(tmp_path):
    m = unknown_rig(tmp_path / "odd.bvh")  # a real take on a rig of no known family
    gappy, gap = corrupt.gaps(m, seed=4, start_prob=0.02)
    noisy, _ = corrupt.angular_noise(gappy, amount=0.5, seed=5, joints=["bone16"])
    res = clean(noisy, steps=("fill", "denoise"))
    by = {s.name: s for s in res.steps}
    assert by["fill"].method == "cubic spline" and "does not serve this rig" in by["fill"].note
    assert by["denoise"].method.startswith("Savitzky-Golay") and "does not serve this rig" in by["denoise"].note
    assert len(res.notes) == 2
    assert not res.motion.missing().any() and np.array_equal(res.filled, noisy.missing())
    assert res.denoised[:, m.skeleton.index("bone16")].mean() > 0.5  # most of a 2.5 s take's noisy joint
    untouched = ~res.changed
    assert np.array_equal(res.motion.rotations[untouched], noisy.rotations[untouched])


def test_a_retargeted_rig_gets_the_networks():
    """The CMU 3dsMax-friendly conversion (arms down at rest): the Acclaim networks through the joint map."""
    m = mocapkit.load(samples.path("131_01.bvh"))[:240]
    gappy, gap = corrupt.gaps(m, seed=4, start_prob=0.02)
    noisy, _ = corrupt.angular_noise(gappy, amount=0.5, seed=5, joints=["LeftHip"])
    res = clean(noisy, steps=("fill", "denoise"))
    by = {s.name: s for s in res.steps}
    assert by["fill"].method == "EBD's gap prior (shipped, via the cmu_bvh_3dsmax joint map)"
    assert by["denoise"].method == "EBF (shipped, via the cmu_bvh_3dsmax joint map)"
    assert _only_terms(res.notes) and _only_terms([by["fill"].note])  # no fallback: the pair's licence lines only
    assert not res.motion.missing().any() and np.array_equal(res.filled, noisy.missing())
    hip = m.skeleton.index("LeftHip")
    assert res.denoised[:, hip].mean() > 0.8
    seen = ~noisy.missing()[:, hip]

    def rms(x):
        return np.sqrt(np.mean(np.degrees(R.geodesic_angle(x.rotations[seen, hip], m.rotations[seen, hip])) ** 2))

    assert rms(res.motion) < 0.5 * rms(noisy)
    untouched = ~res.changed
    assert np.array_equal(res.motion.rotations[untouched], noisy.rotations[untouched])


def test_bad_and_tiny_inputs(walk):
    nan = dataclasses.replace(walk[:50], rotations=np.full((50, walk.num_joints, 4), np.nan))
    with pytest.raises(MocapError, match="every joint is missing"):
        clean(nan)
    with pytest.raises(MocapError, match="at least 2"):
        clean(walk[0])
    rot = np.array(walk.rotations[:100])
    rot[:, 3] = np.nan
    with pytest.raises(MocapError, match="missing in every frame"):
        clean(dataclasses.replace(walk[:100], rotations=rot))
    short = clean(walk[:40])  # 0.33 s: shorter than a motion word
    assert any("shorter than one motion word" in n for n in short.notes)
    assert [s.method for s in short.steps if s.name == "detect"] == ["skipped"]
    assert "repair" not in [s.name for s in short.steps]
    tiny = clean(walk[:5])
    assert any("denoise skipped" in n for n in tiny.notes) and not tiny.changed.any()
    with pytest.raises(ValueError, match="threshold"):
        clean(walk, threshold=1.5)


def test_context_is_used():
    ctx = [mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))]
    m = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    bad, err, _ = corrupt.real_errors(m, n_errors=2, seed=7)  # a 0.5 s freeze of lfemur and a spike
    # the context repeats the sneak once: of the K neighbour words only one is near, and a medoid of all
    # of them put the femur 42 degrees off (repair now takes the medoid among the near ones)
    res = clean(bad, ctx, steps=("detect", "repair"))
    assert "1 context clip" in res.steps[0].method
    assert res.repaired.any() and not (res.repaired & ~res.flags).any()
    assert metrics.pose_error(m, res.motion).mean() < metrics.pose_error(m, bad).mean()


def test_drifts_are_repaired_only_when_asked_for_against_a_repeating_context():
    """A smooth 35 degree drift of one knee, the take's own twin as context: repaired with drifts=True only."""
    m = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    twin = twin_of(m)
    bad, mask, records = corrupt.smooth_drifts(m, n_drifts=1, duration_s=(1.0, 1.0), seed=0, joints=["ltibia"])
    j = m.skeleton.index("ltibia")
    off = clean(bad, [twin], steps=("detect", "repair"))
    assert not off.flags[:, j].any() and not off.changed.any()
    on = clean(bad, [twin], steps=("detect", "repair"), drifts=True)
    # every cell the drift moved visibly (5 deg, the benchmark's truth) is flagged; its faint ends need not be
    seen = mask[:, j] & (np.degrees(R.geodesic_angle(bad.rotations[:, j], m.rotations[:, j])) >= 5.0)
    assert on.flags[seen, j].all() and not on.flags[~mask[:, j], j].any() and not (on.repaired & ~on.flags).any()
    err = lambda x: np.degrees(R.geodesic_angle(x.rotations[:, j], m.rotations[:, j])).max()  # noqa: E731
    assert err(on.motion) < err(bad) / 3
    assert not clean(m, [twin], steps=("detect", "repair"), drifts=True).changed.any()  # the clean take: untouched


def test_noise_level(walk):
    lv = noise_level(walk)
    assert lv.shape == (walk.num_frames, walk.num_joints)
    moving = np.array([j > 0 and bool(walk.skeleton.rotation_order(j)) for j in range(walk.num_joints)])
    assert np.percentile(lv[:, moving], 50) < 0.5
    noisy, mask = corrupt.angular_noise(walk, amount=0.5, seed=0, joints=["lfemur", "ltibia"])
    lv2 = noise_level(noisy)
    j = walk.skeleton.index("lfemur")
    assert np.median(lv2[:, j]) > 2.0 > np.median(lv[:, j])
    still = dataclasses.replace(walk, rotations=np.broadcast_to(walk.rotations[:1], walk.rotations.shape))
    assert np.nanmax(noise_level(still)) < 1e-6
    cells, _ = noisy_cells(noisy)
    assert not cells[:, 0].any()  # the root is never denoised
    assert noise_level(walk[:4]).shape == (4, walk.num_joints) and np.isnan(noise_level(walk[:4])).all()


def test_noise_level_stays_where_the_noise_is(walk):
    """A noisy stretch is noisy and the frames around it are not; an isolated jump is not noise."""
    j = walk.skeleton.index("ltibia")
    noisy, _ = corrupt.angular_noise(walk, amount=0.5, seed=1, joints=["ltibia"])
    rot = np.array(walk.rotations)
    a, b = 100, 220
    rot[a:b, j] = noisy.rotations[a:b, j]
    spike = dataclasses.replace(walk, rotations=rot)
    cells, _ = noisy_cells(spike)
    assert cells[a + 10 : b - 10, j].mean() > 0.9
    margin = int(0.05 * walk.fps)
    outside = np.ones(walk.num_frames, dtype=bool)
    outside[a - margin : b + margin] = False
    assert not cells[outside, j].any()
    jump = np.array(walk.rotations)
    jump[300, j] = R.quaternion_multiply(R.quaternion_from_axis_angle([1.0, 0.0, 0.0], np.radians(40.0)), jump[300, j])
    cells, _ = noisy_cells(dataclasses.replace(walk, rotations=jump))
    assert not cells[:, j].any()


def test_clean_equals_its_steps_run_the_slow_way(cleaned):
    """clean() against its steps run one by one: the EBF on the whole filled take, its output kept on the noisy
    cells; detection of the take so denoised; a repair of the filled take that prepares it again (as from a saved
    detection); the EBF on the whole repaired take, its output kept on the same noisy cells. Bit-identical."""
    from mocapkit.cleaning import deep, ssa
    from mocapkit.cleaning.pipeline import MAX_WORD_ANGLE_DEG

    bad, *_, res = cleaned
    ebf = deep.shipped_model("ebf")
    filled = deep.fill_gaps(bad, deep.shipped_model("ebd"), ebf)
    noisy, _ = noisy_cells(filled)
    first = deep.denoise(filled, ebf, guard=False)  # the network's own output
    judged = dataclasses.replace(filled, rotations=np.where(noisy[..., None], first.rotations, filled.rotations))
    det = ssa.detect(judged, max_word_angle_deg=MAX_WORD_ANGLE_DEG)
    assert np.array_equal(det.mdm, res.mdm) and np.array_equal(det.flags, res.flags)
    repaired = ssa.repair(filled, dataclasses.replace(det, analysis=None), foot_skate=False)
    whole = deep.denoise(repaired, ebf, guard=False)
    expected = np.where(noisy[..., None], whole.rotations, repaired.rotations)
    assert res.denoised.any() and res.repaired.any()
    assert np.array_equal(res.motion.rotations, expected)


def test_summary_counts_say_1_joint_not_1_joints():
    from mocapkit.cleaning.pipeline import StepRecord

    assert str(StepRecord("repair", 0.1, 1, "medoid")) == "repair (0.10 s): medoid, 1 joint sample changed"
    assert str(StepRecord("repair", 0.1, 2, "medoid")) == "repair (0.10 s): medoid, 2 joint samples changed"


def test_one_flagged_segment_on_one_joint_is_said_in_the_singular(walk):
    singular = False
    for seed in range(6):  # one real-style error: most seeds flag one segment on one joint
        bad, _, _ = corrupt.real_errors(walk, n_errors=1, seed=seed)
        res = clean(bad, steps="detect")
        n_seg, n_joint = len(res.detection.segments()), int(res.flags.any(axis=0).sum())
        assert res.steps[0].note.startswith(f"{n_seg} flagged segment{'' if n_seg == 1 else 's'} on "
                                            f"{n_joint} joint{'' if n_joint == 1 else 's'}")
        singular |= n_seg == 1 and n_joint == 1
    assert singular  # the case the rule is about was met


def test_the_cmu_bvh_spelling_is_cleaned_by_the_networks(walk):
    """clean applies deep.served_by like denoise and fill: the BVH spelling of the walk gets the EBD and EBF."""
    from tests.shared import motionbuilder_spelling

    bvh = motionbuilder_spelling(walk[:240])
    gappy, _ = corrupt.gaps(bvh, seed=4, start_prob=0.02)
    res = clean(gappy, steps=("fill", "denoise"))
    by = {s.name: s for s in res.steps}
    assert by["fill"].method == "EBD's gap prior (shipped, via the cmu_bvh_motionbuilder joint map)"
    assert _only_terms(res.notes) and not res.motion.missing().any()
    untouched = ~res.changed
    assert np.array_equal(res.motion.rotations[untouched], gappy.rotations[untouched])


TEST_DATA = Path(__file__).resolve().parents[1] / "data"


def test_clean_leaves_a_calibration_pose_alone_and_names_it(tmp_path):
    """CMU 01_01 (cgspeed BVH): frame 0 is the converter's T-pose; clean neither flags, repairs nor denoises it,
    the jump out of it confirms no flag next to it, and the summary says so."""
    m = mocapkit.load(TEST_DATA / "cmu_01_01_start.bvh")
    res = clean(m)
    assert [str(c) for c in res.calibration] == ["frame 0: calibration T-pose, left alone"]
    assert res.summary()[0] == "frame 0: calibration T-pose, left alone"
    assert res.params["analysed"] == [1, m.num_frames]
    assert np.array_equal(res.motion.rotations[0], m.rotations[0]) and not res.flags[0].any()
    assert not res.changed.any()  # the motion after it is clean too
    assert res.detection is not None and res.detection.flags.shape == (m.num_frames, m.num_joints)
    back = CleanResult.load(res.save(tmp_path / "r.clean.npz"))
    assert back.calibration == res.calibration


def test_clean_with_drifts_puts_every_detection_array_back_at_the_take_frames():
    """With a calibration pose left out of the analysis, the drift rule's evidence (``Detection.change``) is put
    back at the take's frames like the rest, so the detection can be flagged again at another threshold."""
    m = mocapkit.load(TEST_DATA / "cmu_01_01_start.bvh")
    res = clean(m, [twin_of(m)], steps=("detect",), drifts=True)
    det = res.detection
    assert res.params["analysed"] == [1, m.num_frames]
    assert det.change.shape == det.consistency.shape == (m.num_frames, m.num_joints)
    assert np.isnan(det.change[0]).all()
    assert det.with_threshold(0.4).flags.shape == (m.num_frames, m.num_joints)


def test_clean_30_fps_studio_take_changes_at_most_1_percent():
    """Bandai Namco run (30 fps, game rig, post-processed studio data): a clean take stays (almost) untouched."""
    m = mocapkit.load(TEST_DATA / "dataset-2_run_active_049.bvh")
    assert noise_level(m)[:, 1:].max() > 1.0  # the level alone calls fast clean motion at 30 fps noisy
    res = clean(m)
    assert res.changed.mean() <= 0.01, res.summary()
    untouched = ~res.changed
    assert np.array_equal(res.motion.rotations[untouched], m.rotations[untouched])


def test_clean_leaves_a_throw_at_24_fps_alone(shared_data):
    """CMU 131_02 as delivered at 24 fps (every fifth frame of the BVH, each value a real capture sample): the
    right arm, still for most of the take, throws twice (its shoulder turning up to 51 deg in one frame; the
    right hip swings 29 deg in one).
    Its breaks passed the level of its own motion over the take and confirmed digressions in a take judged
    against itself (21 of 48 words without a neighbour): repair turned the shoulder by up to 132 deg and the
    still elbow after the throw by up to 107 deg. The arm's speed beside the breaks explains them
    (``ssa.cues.motion_explained``): the arm comes back untouched."""
    m = mocapkit.load(shared_data / "cmu_bvh" / "131_02.bvh")[::5]
    assert m.fps == 24.0
    res = clean(m)
    arm = [m.skeleton.index(n) for n in ("RightShoulder", "RightElbow", "RightWrist", "RightHip")]
    assert not res.changed[:, arm].any(), res.summary()
    assert res.changed.mean() <= 0.01, res.summary()
    untouched = ~res.changed
    assert np.array_equal(res.motion.rotations[untouched], m.rotations[untouched])


def test_noise_direction_tells_jitter_from_fast_motion():
    """Steps of white noise turn back (median cosine near -0.5); fast real motion at 30 fps keeps its direction."""
    m = mocapkit.load(TEST_DATA / "dataset-2_run_active_049.bvh")
    j = m.skeleton.index("UpperArm_R")
    assert np.median(noise_direction(m)[:, j]) > 0.5
    noisy, nmask = corrupt.angular_noise(m, amount=0.5, seed=1, joints=["UpperArm_R"])
    assert -0.7 < np.median(noise_direction(noisy)[:, j]) < -0.3
    found, _ = noisy_cells(noisy)
    assert found[:, j].mean() > 0.9 and not found[:, np.arange(m.num_joints) != j].any()
    assert not noisy_cells(m)[0].any()


def test_noise_rule_leaves_a_toe_that_flicks_between_still_frames_alone():
    """A dash at 30 fps (Bandai Namco, studio data): the left toe pushes off in each stride, two or three frames
    out and back, and is still between. Its level is over 1 deg and its steps turn back, so the level and
    direction tests alone call it noise; its median step is a third of its level: not noise. The same toe
    under Mall's noise with its leg is noisy; alone at this rate it is not told from a toe's own wobble
    (:mod:`mocapkit.cleaning.noise_scope`)."""
    m = mocapkit.load(TEST_DATA / "dataset-1_dash_chimpira_001.bvh")
    j = m.skeleton.index("Toes_L")
    level = noise_level(m)
    assert level[:, j].max() > 2.0 and np.median(noise_direction(m)[6:24, j]) < -0.2
    assert not noisy_cells(m)[0].any()
    res = clean(m)
    assert not res.denoised.any() and res.changed.mean() <= 0.01, res.summary()
    bad, _ = corrupt.angular_noise(m, amount=0.5, seed=1, joints=["Toes_L", "UpperLeg_L"])
    found, _ = noisy_cells(bad)
    assert found[:, j].mean() > 0.8
    bad, _ = corrupt.angular_noise(m, amount=0.5, seed=1, joints=["Toes_L"])
    assert not noisy_cells(bad)[0].any()


# Acclaim bone names in Mixamo's spelling (the side letter first in the ASF: lfemur -> LeftUpLeg)
_MIXAMO_MID = {"root": "Hips", "lowerback": "Spine", "upperback": "Spine1", "thorax": "Spine2", "lowerneck": "Neck",
               "upperneck": "Neck1", "head": "Head"}
_MIXAMO_SIDE = {"hipjoint": "HipJoint", "femur": "UpLeg", "tibia": "Leg", "foot": "Foot", "toes": "ToeBase",
                "clavicle": "Shoulder", "humerus": "Arm", "radius": "ForeArm", "wrist": "ForeArmRoll", "hand": "Hand",
                "fingers": "HandIndex1", "thumb": "HandThumb1"}


def _mixamo_rig(m, z_up: bool):
    """``m`` (an Acclaim take) on another rig showing the same motion: Mixamo names (``mixamorig:LeftUpLeg``),
    the joints in another order (children listed last to first), BVH channels and no ASF axes, Z up if asked.
    Returns the Motion and ``order`` (its joint k is ``m``'s joint ``order[k]``)."""
    from mocapkit.motion import Motion, Skeleton

    sk = m.skeleton
    kids: dict = {}
    for k, p in enumerate(sk.parents):
        kids.setdefault(int(p), []).append(k)
    order, stack = [], [0]
    while stack:  # depth first, the last child first
        k = stack.pop()
        order.append(k)
        stack += kids.get(k, [])
    order = np.array(order)
    inv = np.argsort(order)
    names = []
    for o in order:
        n = sk.joint_names[o]
        names.append("mixamorig:" + (_MIXAMO_MID[n] if n in _MIXAMO_MID else
                                     {"l": "Left", "r": "Right"}[n[0]] + _MIXAMO_SIDE[n[1:]]))
    rot, pos = np.array(m.rotations[:, order]), np.array(m.root_positions)
    if z_up:
        up = R.quaternion_from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi / 2)  # y -> z
        rot[:, 0], pos = R.quaternion_multiply(up, rot[:, 0]), R.quaternion_rotate(up, pos)
    channels = (("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),) + (
        ("Zrotation", "Xrotation", "Yrotation"),) * (len(order) - 1)
    rig = Skeleton(tuple(names), np.array([-1] + [inv[sk.parents[o]] for o in order[1:]]), np.array(sk.offsets[order]),
                   inv[np.asarray(sk.end_site_parents)], np.array(sk.end_site_offsets), channels=channels,
                   unit_cm=sk.unit_cm)
    return Motion(rig, rot, pos, m.fps, "respelled"), order


@pytest.mark.parametrize("z_up", [False, True])
def test_clean_leaves_a_take_alone_on_other_names_joint_order_rate_and_up_axis(walk, z_up):
    """Nothing in clean's rules assumes the Acclaim or Bandai Namco rigs: the CMU walk on Mixamo-style names,
    reordered joints, 60 fps and (or not) Z up shows the same motion, and clean with its defaults leaves it alone."""
    other, order = _mixamo_rig(walk, z_up)
    ref = walk.global_positions()[:, order]
    if z_up:
        ref = R.quaternion_rotate(R.quaternion_from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi / 2), ref)
    assert np.allclose(other.global_positions(), ref, atol=1e-6)  # the same motion
    take = other.resample(60.0)
    res = mocapkit.clean(take)
    assert res.changed.mean() <= 0.001, res.summary()
    untouched = ~res.changed
    assert np.array_equal(res.motion.rotations[untouched], take.rotations[untouched])
    bad, mask, records = corrupt.real_errors(take, kinds=("flip",), n_errors=1, seed=0)
    found = mocapkit.clean(bad)
    j = take.skeleton.index(records[0].joint)
    assert found.repaired[records[0].start : records[0].end, j].mean() > 0.5, found.summary()


def test_noise_level_is_the_running_median_of_the_cubic_fit_residual(walk):
    """The level against its definition: a (window, 1) median over the residual of a cubic fit, gaps NaN."""
    from scipy.ndimage import median_filter
    from scipy.signal import savgol_filter

    noisy, _ = corrupt.angular_noise(walk, amount=0.5, seed=4, joints=["lfemur", "rhumerus"])
    gappy, gap = corrupt.gaps(noisy, seed=5)
    for m in (noisy, gappy, gappy[:40]):
        q = np.array(m.rotations)
        miss = ~np.all(np.isfinite(q), axis=-1)
        q[miss] = R.identity()
        q = R.quaternion_continuity(q, axis=0)
        w = max(7, int(round(0.06 * m.fps)) | 1)
        fit = savgol_filter(q, w, 3, axis=0, mode="interp")
        fit /= np.maximum(np.linalg.norm(fit, axis=-1, keepdims=True), 1e-12)
        res = np.degrees(4.0 * np.arcsin(np.clip(np.linalg.norm(q - fit, axis=-1) / 2.0, 0.0, 1.0)))
        res[miss] = 0.0
        ref = median_filter(res, size=(max(3, int(round(0.5 * m.fps)) | 1), 1), mode="nearest")
        ref[miss] = np.nan
        assert np.array_equal(noise_level(m), ref, equal_nan=True)
    assert gap.any()


def test_load_params_names_a_record_it_cannot_read(tmp_path):
    good = tmp_path / "good.clean.npz"
    res = clean(mocapkit.load(samples.path("131_01.bvh"))[:30], steps=("fill",))
    res.save(good)
    assert isinstance(CleanResult.load_params(good), dict)
    for name, data in (("empty", b""), ("garbage", b"garbage"), ("cut", good.read_bytes()[:400])):
        bad = tmp_path / f"{name}.clean.npz"
        bad.write_bytes(data)
        with pytest.raises(MocapFormatError, match=f"{name}.clean.npz: not a readable mocapkit clean record"):
            CleanResult.load_params(bad)
    np.savez(tmp_path / "other.npz", x=np.zeros(2))
    with pytest.raises(MocapFormatError, match="other.npz: not a readable mocapkit clean record"):
        CleanResult.load_params(tmp_path / "other.npz")
    np.savez(tmp_path / "markers.clean.npz", kind=np.array("markers"), filled=np.zeros((2, 2), bool))
    assert CleanResult.load_params(tmp_path / "markers.clean.npz") is None  # a marker capture's record keeps none


def test_a_take_mostly_missing_is_filled_with_a_warning():
    take = mocapkit.load(samples.path("12_walk.amc"))
    # the note reads the share of missing samples, not the take's length: 150 of the 343 frames (the fill's cost grows
    # with the gap's length); the gap ends as near the take's end as 40:300 of the whole take did, within reach of
    # the fill's longest lag, so the same clamped windows fill it
    rot = np.array(take.rotations[:150])
    rot[20:133, 1:] = np.nan  # 73 % of the joint samples (the root stays)
    res = clean(dataclasses.replace(take[:150], rotations=rot), steps=("fill",))
    said = [n for n in res.notes if "made up most of what it returns" in n]
    assert said and said[0].startswith("73 % of the take's joint samples were missing")
    assert said[0] in res.steps[0].note  # a step's note: clean prints it as a warning line
    few = clean(corrupt.gaps(take, seed=1)[0], steps=("fill",))
    assert not [n for n in few.notes if "made up" in n]


def test_a_record_says_which_version_wrote_it(tmp_path):
    import json

    res = clean(mocapkit.load(samples.path("131_01.bvh"))[:30], steps=("fill",))
    res.save(tmp_path / "r.clean.npz")
    with np.load(tmp_path / "r.clean.npz") as data:
        assert json.loads(str(data["meta"]))["mocapkit"] == mocapkit.__version__


def test_a_limb_held_still_through_a_moving_take_is_named():
    take = mocapkit.load(samples.path("12_walk.amc"))
    assert not [n for n in clean(take, steps=("detect",)).notes if "bit for bit" in n]
    k = take.skeleton.index("lradius")
    rot = np.array(take.rotations)
    rot[:, k] = rot[0, k]  # the elbow's channel frozen at its first value
    said = [n for n in clean(dataclasses.replace(take, rotations=rot), steps=("detect",)).notes if "bit for bit" in n]
    assert said and said[0].startswith("lradius holds one rotation, bit for bit, through the whole take")


def test_with_a_calibration_pose_the_change_masks_are_at_the_take_frames():
    """The analysed span starts after the pose (frame 1): what repair changed is recorded at the take's frames,
    so the report, the decisions and the untouched guarantee point at the cells that really changed."""
    m = mocapkit.load(TEST_DATA / "cmu_01_01_start.bvh")
    bad, _, _ = corrupt.real_errors(m, n_errors=4, seed=7)
    res = clean(bad, steps="detect,repair")
    assert res.calibration and res.params["analysed"][0] >= 1
    assert res.repaired.any()
    really = ~np.all(res.motion.rotations == bad.rotations, axis=-1)
    assert np.array_equal(really, res.repaired)
    assert not (res.repaired & ~res.flags).any()


def test_denoise_alone_never_records_a_missing_cell_as_changed(walk):
    gappy, gap = corrupt.gaps(walk, seed=5)
    noisy, _ = corrupt.angular_noise(gappy, amount=0.5, seed=6, joints=["lfemur"])
    res = clean(noisy, steps="denoise")
    assert gap.any() and not (res.denoised & gap).any()
    assert np.array_equal(res.motion.missing(), noisy.missing())  # the gaps stay gaps


def test_fill_of_a_root_gap_keeps_every_observed_root_sample_bit_identical(walk):
    """A gap in the root (rotation and position) is filled; the root's observed frames stay the input's, bit for bit."""
    gappy, _ = corrupt.gaps(walk, seed=11)
    rot, pos = np.array(gappy.rotations), np.array(gappy.root_positions)
    rot[100:115, 0] = np.nan
    pos[100:115] = np.nan
    take = dataclasses.replace(gappy, rotations=rot, root_positions=pos)
    res = clean(take, steps="fill")
    seen = ~take.missing()[:, 0]
    assert (~seen).any() and not res.motion.missing().any()
    assert res.motion.rotations[seen, 0].tobytes() == take.rotations[seen, 0].tobytes()
    assert res.motion.root_positions[seen].tobytes() == take.root_positions[seen].tobytes()
    observed = ~take.missing()
    assert res.motion.rotations[observed].tobytes() == take.rotations[observed].tobytes()


def test_clean_reads_the_takes_channels_once_for_zeros_and_interpolated_frames(monkeypatch):
    # the dropouts and the interpolated frames read the same file channels: made once, the same flags as alone
    from mocapkit.cleaning.inbetweens import find_inbetweens
    from mocapkit.cleaning.zeros import find_zeros
    from mocapkit.motion import Motion

    m = mocapkit.load(samples.path("131_01.bvh"))[:400]
    x = m.channel_values()
    x[100:103, 9:12] = 0.0  # a joint's channels written as 0 for three frames
    m = Motion.from_channel_values(m.skeleton, x, m.fps, name="zeroed")
    alone = find_zeros(m)
    calls = []
    read = Motion.channel_values
    monkeypatch.setattr(Motion, "channel_values", lambda self: calls.append(self is m) or read(self))
    res = clean(m, steps="fill")
    assert sum(calls) == 1
    assert np.array_equal(res.zeros, alone[0]) and res.zero_runs and find_inbetweens(m) == ()


def _only_terms(notes) -> bool:
    """Every note is a shipped model's licence line (the Acclaim pair's research terms) or the denoise guard's line
    of cells kept as they came (a line of its own): no fallback was said."""
    return bool(notes) and all(n.startswith("licence of the EB") or " cells kept as they came: " in n for n in notes)


def test_a_noisy_take_is_judged_denoised_and_comes_back_no_worse(shared_data):
    """Angular noise (Mall et al.'s model, 0.3 of each channel's std) on a real grab (HDM05): detection judges the
    take denoised, so noise on the fast right arm is not taken for errors; judged noisy, that arm was "repaired"
    from motion words far from the truth (worst cell 40.7 -> 72.1 deg against the clean source)."""
    truth = mocapkit.load(shared_data / "hdm05_asfamc" / "HDM_bd_grabHighR_001_120.amc")
    bad, _ = corrupt.angular_noise(truth, amount=0.3, seed=7)
    res = clean(bad)
    err_in = np.degrees(R.geodesic_angle(truth.rotations, bad.rotations))  # (F, J)
    err_out = np.degrees(R.geodesic_angle(truth.rotations, res.motion.rotations))
    assert res.denoised.any()
    assert err_out.max() <= err_in.max()
    changed = res.changed
    assert err_out[changed].mean() < err_in[changed].mean()
    assert not (err_out > err_in + 10.0).any()  # no cell made far worse than the noise left it


def test_a_noisy_take_with_errors_is_repaired_against_the_default_context():
    """Detection judges the take denoised and repair works on the take as filled: the detection's prepared take
    serves only the take it judged, so repair prepares the filled one against the same context (the bundled
    default here); given none, it fell back to the clip alone and refused ("repair needs the context the detection
    was made with")."""
    from mocapkit.warmup import broken_walk  # the bundled walk with gaps, real-style errors, noise on two joints

    from mocapkit.context import fit_context, resolve_context

    take = broken_walk()
    context, _ = fit_context(take, resolve_context(None))  # as `mocapkit clean` and the install's warm-up give it
    res = clean(take, context)
    assert res.denoised.any() and res.repaired.any()
    assert [s.name for s in res.steps] == ["fill", "detect", "repair", "denoise"]


_SAME_CLEAN = """
import hashlib, sys, numpy as np, torch, mocapkit
from mocapkit import corrupt
from mocapkit.cleaning.pipeline import clean
torch.set_num_threads(2)
bad, _ = corrupt.corrupt(mocapkit.load(sys.argv[1]), "noise", seed=1, amount=0.1)
res = clean(bad)
print(hashlib.sha1(np.ascontiguousarray(res.motion.rotations).tobytes() + res.repaired.tobytes()
                   + res.denoised.tobytes()).hexdigest())
"""


def test_clean_gives_the_same_bits_twice_in_one_process_and_in_another(shared_data):
    """A real take with its own one-frame flips (CMU backflip, where one run was measured 179.6 deg off and another
    151), noisy: cleaned with the serial and the parallel numba twins, and with torch and OpenMP at other thread
    counts in a second process, it comes back bit for bit the same."""
    import hashlib
    import os
    import subprocess
    import sys

    import torch

    from mocapkit.cleaning.ssa.twins import forced

    path = shared_data / "cmu_asfamc" / "backflip.amc"
    bad, _ = corrupt.corrupt(mocapkit.load(path), "noise", seed=1, amount=0.1)

    def digest(res):
        return hashlib.sha1(np.ascontiguousarray(res.motion.rotations).tobytes() + res.repaired.tobytes()
                            + res.denoised.tobytes()).hexdigest()

    threads = torch.get_num_threads()
    try:
        with forced("serial"):
            torch.set_num_threads(1)
            first = digest(clean(bad))
        with forced("parallel"):
            torch.set_num_threads(2)
            second = digest(clean(bad))
    finally:
        torch.set_num_threads(threads)
    assert first == second
    env = {**os.environ, "OMP_NUM_THREADS": "2", "NUMBA_NUM_THREADS": "2"}
    out = subprocess.run([sys.executable, "-c", _SAME_CLEAN, str(path)], env=env, capture_output=True, text=True,
                         check=True, timeout=600)
    assert out.stdout.split()[-1] == first


def test_importing_the_pipeline_loads_no_heavy_library():
    """`clean`, `detect` and `fill` start without torch, matplotlib or the scipy subpackages that take ~1.5 s to
    import (scipy.signal pulls scipy.stats); the steps import them where they use them."""
    import subprocess
    import sys

    heavy = ("torch", "matplotlib", "scipy.signal", "scipy.stats", "scipy.optimize", "scipy.ndimage", "scipy.interpolate")
    code = ("import sys, mocapkit.cleaning.pipeline, mocapkit.cli.clean, mocapkit.cli.ssa; "
            f"print(sorted(m for m in {heavy!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_a_take_missing_one_frame_is_refused_in_words_for_one():
    """Detection refuses a take with gaps, counting the frames: "1 frame has missing joints" (it said "1 frames
    have"), from clean without the fill step, from detect_take (`mocapkit detect`, `repair`) and from the
    self-similarity analysis itself."""
    from mocapkit.cleaning.ssa.texture import prepare
    from mocapkit.cleaning.whole_take import detect_take

    walk = mocapkit.load(samples.path("12_walk.amc"))[:120]
    rot = np.array(walk.rotations)
    rot[60, 3] = np.nan
    take = dataclasses.replace(walk, rotations=rot)
    with pytest.raises(MocapError, match=r": 1 frame has missing joints; detect needs complete frames: add the fill"):
        clean(take, context=False, steps="detect")
    with pytest.raises(MocapError, match=r": 1 frame has missing joints; detect needs complete frames \(fill"):
        detect_take(take)
    with pytest.raises(ValueError, match=r": 1 frame has missing rotations \(first: 60\)"):
        prepare(take)
    rot[61, 3] = np.nan
    with pytest.raises(MocapError, match=r": 2 frames have missing joints"):
        detect_take(dataclasses.replace(walk, rotations=rot))


def test_cells_the_denoise_keeps_as_they_came_stay_so_in_the_take_clean_writes():
    """After a repair, clean() denoises again; that second denoise judged its guard afresh on the repaired take, said
    nothing, and the record kept the first denoise's "N cells kept as they came", while the take written had them
    denoised (a Bandai punch at 0.3 noise: Head frames 249-257, moved by up to 25 deg, frame 251 from 1.5 to 16.1 deg
    off the truth). The cells the denoise keeps alone (``steps=("fill", "denoise")``) are kept in the full clean,
    bit for bit, but for those the repair changed; the count said is the count kept; and the guard's line is its own
    note, not joined onto the licence's warning."""
    import re

    take = mocapkit.load(TEST_DATA / "dataset-2_raise-up-right-hand_active_060_flip.bvh")  # a flip in its own file
    bad, _ = corrupt.corrupt(take, "noise", seed=1, amount=0.3)
    alone, full = clean(bad, steps=("fill", "denoise")), clean(bad)
    noisy = noisy_cells(bad)[0]
    same = lambda res: np.all(res.motion.rotations == bad.rotations, axis=-1)  # noqa: E731
    kept = noisy & same(alone)
    assert full.repaired.any() and (kept & full.repaired).any() and (kept & ~full.repaired).sum() > 10
    assert same(full)[kept & ~full.repaired].all()  # 44 of them were moved
    said = [n for n in full.notes if "kept as they came: the denoiser" in n]
    assert len(said) == 1 and "licence" not in said[0] and said[0] in full.steps[-1].note
    repaired = [int(re.search(r"(\d+) cells? the repair changed", n).group(1)) for n in full.notes
                if "kept as the repair made" in n]
    assert repaired and repaired[0] >= (kept & full.repaired).sum()  # the rest are the repair's, and said
    # the cells kept as they came are those bit-identical to the input, each joint's runs said exactly: the line
    # said "76 cells kept as they came (..., Foot_R frames 20-36)", 7 of them (Foot_R 27-31, 33-34) the repair's
    came, names = noisy & same(full), bad.skeleton.joint_names
    assert int(re.match(r"(\d+) cells kept", said[0]).group(1)) == came.sum()
    runs = ", ".join(f"{names[j]} {frame_runs(true_runs(came[:, j]), most=6)}" for j in np.flatnonzero(came.any(0))[:3])
    assert f"({runs}" in said[0], said[0]
    assert not (came & full.repaired).any()  # the repair's cells on their own line, each run as exactly
    by_repair = next(n for n in full.notes if "kept as the repair made" in n)
    named = re.search(r"\((\w+) (frames? [^;]+);", by_repair)
    j = names.index(named.group(1))
    assert named.group(2) == frame_runs(true_runs(kept[:, j] & full.repaired[:, j])), by_repair
