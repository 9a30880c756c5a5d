"""mocapkit.reference: a reference take is checked before any work, and the figures match mocapkit.metrics."""

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, metrics
from mocapkit.errors import MocapFormatError
from mocapkit.reference import check_reference, clean_errors, filled_error_deg, joint_angle_errors, position_error_cm

WALK = mocapkit.samples.path("12_walk.amc")


@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(WALK)


def test_check_reference_refuses_another_length_or_rig(walk):
    names = walk.skeleton.joint_names
    assert check_reference(walk, "ref.amc", frames=walk.num_frames, joint_names=names) is walk
    with pytest.raises(MocapFormatError, match=r"ref\.amc: .* 100 frames \(it has 343 frames\)"):
        check_reference(walk, "ref.amc", frames=100, joint_names=names)
    other = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[: walk.num_frames]
    with pytest.raises(MocapFormatError, match="its joints differ"):
        check_reference(other, "other.bvh", frames=walk.num_frames, joint_names=names)
    with pytest.raises(MocapFormatError, match="its joints differ"):
        check_reference(other, "other.bvh", frames=walk.num_frames, skeleton=walk.skeleton)


def test_figures_are_the_metrics(walk):
    noisy, _ = corrupt.angular_noise(walk, 0.5, seed=1)
    gappy, _ = corrupt.gaps(noisy, seed=2, start_prob=0.01)
    e = clean_errors(walk, gappy, noisy)
    assert e["gaps_filled"] and e["pose_after"] == pytest.approx(float(np.nanmean(metrics.pose_error(walk, noisy))))
    assert e["cm_after"] == pytest.approx(metrics.joint_position_rms(walk, noisy, end_sites=True)) and e["cm_after"] > 0
    assert clean_errors(walk, walk, walk)["pose_before"] == 0.0
    a, b = joint_angle_errors(walk, noisy, walk)
    assert b == 0.0 and a == pytest.approx(metrics.joint_angle_rms(walk, noisy, include_root=False))
    missing = gappy.missing()
    expected = np.degrees(metrics.geodesic_pose_distance(walk, noisy))[missing].mean()
    assert filled_error_deg(walk, noisy, missing) == pytest.approx(expected)
    assert filled_error_deg(walk, noisy, np.zeros_like(missing)) == 0.0
    assert position_error_cm(walk, noisy, heading=True) == pytest.approx(
        metrics.joint_position_rms(walk, noisy, root_relative="heading"))


def test_the_position_figure_sees_an_error_on_a_joint_whose_only_child_is_an_end_site(walk):
    """`make demo`: "joint positions 0.02 -> 0.00 cm RMS" for a take with five injected errors, two on the head and
    toes: their rotations move only end sites, which the figure left out. It counts the end sites now."""
    import dataclasses

    rot = np.array(walk.rotations)
    j = walk.skeleton.joint_names.index("head")
    rot[100:140, j] = mocapkit.rotations.quaternion_multiply(
        rot[100:140, j], mocapkit.rotations.euler_to_quaternion(np.array([40.0, 0.0, 0.0]), "XYZ"))
    bent = dataclasses.replace(walk, rotations=rot)
    assert metrics.joint_position_rms(walk, bent) == 0.0  # the joints alone cannot see it
    e = clean_errors(walk, bent, walk)
    assert e["cm_before"] > 0.1 and e["cm_after"] == 0.0
    assert metrics.joint_position_rms(walk, bent, end_sites=True, root_relative=False) > 0.1


def test_a_reference_of_unknown_unit_is_refused_in_the_callers_words(tmp_path):
    """The position error needs the reference's length unit: Python's caller is told ``unit=``, the CLI's
    ``--unit``."""
    from pathlib import Path

    from mocapkit.reference import check_reference
    from tests.shared import unnamed

    ref = unnamed(mocapkit.load(Path(__file__).parent / "data" / "dataset-1_bow_active_001.bvh"))
    with pytest.raises(MocapFormatError, match=r"ref\.bvh: .*give it with unit= \(mm, cm, m, in\)") as exc:
        check_reference(ref, "ref.bvh", frames=ref.num_frames)
    assert "--unit" not in str(exc.value)
    with pytest.raises(MocapFormatError, match=r"give it with --unit \(mm, cm, m, in\)"):
        check_reference(ref, "ref.bvh", frames=ref.num_frames, option="--unit")
