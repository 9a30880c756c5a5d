"""benchmarks/ssa_detection.py's ground truth: the clean clips' own glitches are of unknown truth, not scored."""

import numpy as np
import pytest

from .helpers import load


@pytest.fixture(scope="module")
def charleston2(shared_data):
    import mocapkit

    path = shared_data / "cmu_asfamc" / "charleston2.amc"
    if not path.is_file():
        pytest.skip(f"{path} is missing")
    return mocapkit.load(path)


def test_a_stutter_of_the_clean_clip_is_of_unknown_truth_on_the_joints_it_holds_off(charleston2):
    bench = load("ssa_detection")
    knee, hand = (charleston2.skeleton.joint_names.index(n) for n in ("rtibia", "lhand"))
    # frames 247-251 repeat frame 246 bit for bit while the right knee turns 6-7 deg a frame on both sides, and the
    # step to frame 252 turns it 31.3 deg: slower than the speed rule's 5,000 deg/s, so only the stutter rule sees it
    q = np.asarray(charleston2.rotations)
    assert all(np.array_equal(q[f], q[246]) for f in range(247, 252))
    assert not (bench.baselines.angular_speed(charleston2)[240:256, knee] > 5000.0).any()
    cells = bench.glitches(charleston2, 5000.0)
    assert cells[245:255, knee].all()  # the run and the step out of it, within 2 frames
    assert not cells[235:243, knee].any() and not cells[256:266, knee].any()
    # the left hand stands still through the stutter (under 5 deg out of it): its truth there is known
    assert np.degrees(bench.R.geodesic_angle(q[252, hand], q[251, hand])) < 5.0
    assert not cells[240:260, hand].any()
    # a speed-only rule (glitch speed 0 scores everything) leaves the stutter scored
    assert not bench.glitches(charleston2, 1e9, visible_deg=np.inf)[:, knee].any()


def test_a_break_of_the_untouched_take_says_how_far_past_limb_motion_and_the_joints_own_it_lies(shared_data):
    import mocapkit

    path = shared_data / "cmu_asfamc" / "lambada.amc"
    if not path.is_file():
        pytest.skip(f"{path} is missing")
    bench = load("ssa_detection")
    take = mocapkit.load(path)
    flags = np.zeros((take.num_frames, take.num_joints), dtype=bool)
    hand, toes = (take.skeleton.joint_names.index(n) for n in ("rhand", "ltoes"))
    flags[580, hand] = True  # the right hand turns 19 then 30 deg in two frames, once in the take
    flags[1000, toes] = True  # the left toes at an ordinary frame
    rows = {r["joint"]: r for r in bench.take_breaks(take, flags)}
    assert rows["rhand"]["resid_deg"] == pytest.approx(24.7, abs=0.05)  # 710,000 deg/s^2 at 120 fps
    assert rows["rhand"]["resid_p99_deg"] == pytest.approx(1.8, abs=0.05)
    assert rows["rhand"]["resid_elsewhere"] == 0
    assert rows["ltoes"]["resid_deg"] < 2 * rows["ltoes"]["resid_p99_deg"] and rows["ltoes"]["resid_elsewhere"] > 2
