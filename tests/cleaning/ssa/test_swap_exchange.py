"""A confirmed left/right swap put back by the mirrored exchange (mocapkit.cleaning.ssa.swap_exchange).

The real take is PyMO's AV_8Walk_Meredith (HumanIK rig, inches, a peer file in the shared data): its arms are
swapped over frames 146-216 as a labelling error swaps them, each arm taking its partner's mirrored rotation.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa.cues import mirrored_rotations
from mocapkit.cleaning.ssa.swap_exchange import root_depths, swap_exchanges
from mocapkit.cleaning.whole_take import detect_take

A, B = 146, 217  # the swapped frames a .. b - 1


@pytest.fixture(scope="module")
def swapped_take(shared_data):
    take = mocapkit.load(shared_data / "peer_files" / "omimo+PyMO" / "demos" / "data" / "AV_8Walk_Meredith_HVHA_Rep1.bvh")
    names = take.skeleton.joint_names
    arms = [names.index("LeftArm"), names.index("RightArm")]
    q = np.array(take.rotations)
    q[A:B, arms] = mirrored_rotations(take)[A:B, arms]
    return take, dataclasses.replace(take, rotations=q), arms


def test_a_detected_arm_swap_is_put_back_bit_for_bit(swapped_take):
    take, m, arms = swapped_take
    det = detect_take(m).detection
    assert det.swaps[A:B, arms].all()
    fixed = ssa.repair(m, det, foot_skate=False)
    assert np.array_equal(fixed.rotations[A:B, arms], take.rotations[A:B, arms])


def test_the_exchange_is_made_only_where_it_joins_the_take():
    F, t = 40, np.linspace(0.0, 1.0, 40)
    q = np.zeros((F, 2, 4))
    q[:, 0] = R.quaternion_from_axis_angle(np.array([1.0, 0.0, 0.0]), 0.5 * t)  # two slow, different tracks
    q[:, 1] = R.quaternion_from_axis_angle(np.array([0.0, 1.0, 0.0]), -0.5 * t)
    mirrored = q[:, ::-1].copy()  # a stand-in mirror: each side takes the other's rotation
    swapped = q.copy()
    swapped[10:20] = mirrored[10:20]
    cells = np.zeros((F, 2), dtype=bool)
    cells[10:20] = True
    values, done = swap_exchanges(swapped, swapped[:, ::-1], cells, [1, 0])
    assert np.array_equal(done, cells) and np.array_equal(values, q)
    # the same run on the unswapped take: exchanging would break the track at both ends, so nothing is done
    values, done = swap_exchanges(q, mirrored, cells, [1, 0])
    assert not done.any() and np.array_equal(values, q)
    assert not swap_exchanges(swapped, None, cells, [1, 0])[1].any()


# -- a swap flagged on one side only (swap_exchange.partner_swaps) -------------------------------------------------

def _knees_swapped(a: int, b: int):
    """The bundled Bandai Namco walk (tests/data, walk-turn-left_exhausted_005, 30 fps) and a copy with its shins
    swapped over frames a .. b (inclusive), each taking its partner's mirrored rotation, as ``corrupt --kind swap``
    does; the knee indices."""
    from pathlib import Path

    take = mocapkit.load(Path(__file__).parents[2] / "data" / "dataset-2_walk-turn-left_exhausted_005.bvh")
    names = take.skeleton.joint_names
    knees = [names.index("LowerLeg_L"), names.index("LowerLeg_R")]
    q = np.array(take.rotations)
    q[a : b + 1, knees] = mirrored_rotations(take)[a : b + 1, knees]
    return take, dataclasses.replace(take, rotations=q), knees


def test_a_swap_flagged_on_one_side_over_part_of_it_is_found_whole():
    """As in a studio's trial (Bandai walk_normal_001, ``corrupt --kind errors --seed 2``): the shins swapped over
    45-51, flagged on the right over 47-51 only (the knees pass each other at 45, 1.9 deg from each other's mirror
    image, and break little there). The partner's mirrored values join the take over the swap's own frames:
    found, confirmed, over 45-51, on both knees; on the clean take, or one knee bent alone, nothing is."""
    from mocapkit.cleaning.ssa.swap_exchange import partner_swaps
    from mocapkit.motion import mirror_pairs

    take, bad, (left, right) = _knees_swapped(45, 51)
    flags = np.zeros(bad.rotations.shape[:2], dtype=bool)
    flags[47:52, right] = True
    found = partner_swaps(bad.rotations, mirrored_rotations(bad), flags, mirror_pairs(bad.skeleton.joint_names),
                          bad.skeleton.parents, 30.0)
    assert [(s.joint, s.partner, s.start, s.end, s.confirmed) for s in found] == [(right, left, 45, 51, True)]
    clean = partner_swaps(take.rotations, mirrored_rotations(take), flags, mirror_pairs(take.skeleton.joint_names),
                          take.skeleton.parents, 30.0)
    assert clean == []
    # the right shin turned 14 deg more over 49-51 as well: the exchange fits better, but not at its exit (both left)
    q = np.array(bad.rotations)
    q[49:52, right] = R.quaternion_multiply(R.rotvec_to_quaternion(np.array([0.0, 0.0, np.radians(14.0)])),
                                            q[49:52, right])
    more = partner_swaps(q, mirrored_rotations(dataclasses.replace(bad, rotations=q)), flags,
                         mirror_pairs(take.skeleton.joint_names), take.skeleton.parents, 30.0)
    assert [(s.joint, s.partner, s.start, s.end, s.confirmed) for s in more] == [(right, left, 45, 51, False)]
    # one knee bent away from the take alone (an offset, its partner as captured): no swap
    off = np.array(take.rotations)
    off[47:52, right] = R.quaternion_multiply(R.rotvec_to_quaternion(np.array([0.0, 0.0, 0.5])), off[47:52, right])
    off_take = dataclasses.replace(take, rotations=off)
    assert partner_swaps(off, mirrored_rotations(off_take), flags, mirror_pairs(take.skeleton.joint_names),
                         take.skeleton.parents, 30.0) == []


def test_flags_left_past_a_swap_put_back_are_no_swap_of_their_own():
    """Detection's swap exchanged back, the flags one side keeps past its end are judged against the take as put
    back: no exchange of the clean frames after it (HDM05 mm kickLFront1Reps, ``real_errors`` seed 2001: the
    right shin's flags 64-67 past the swap 42-63, judged against the input's swapped frames, joined an exchange
    of the clean frames 64-77, 31 deg off)."""
    from mocapkit.cleaning.ssa.swap_exchange import partner_swaps
    from mocapkit.motion import mirror_pairs

    take, bad, (left, right) = _knees_swapped(45, 51)
    pairs = mirror_pairs(take.skeleton.joint_names)
    flags = np.zeros(bad.rotations.shape[:2], dtype=bool)
    flags[52:56, right] = True
    fixed = np.zeros_like(flags)
    fixed[45:52, [left, right]] = True  # exchanged back: the take's own values there
    assert partner_swaps(take.rotations, mirrored_rotations(bad), flags, pairs, take.skeleton.parents, 30.0,
                         fixed=fixed) == []


def test_a_shin_swap_detection_flags_on_one_side_is_exchanged_back_or_left_whole():
    """The bundled walk with its shins swapped over 45-51: detection flags the right one over 49-51 only, no swap.
    Exchanged back on both over the swap's own frames: the clean take's values. With the right shin 14 deg off as
    well over 49-51 (the exchange not joining at its exit), neither side is repaired from neighbour words, which
    would leave the left holding the right one's motion: both left as they came, named."""
    from mocapkit.cleaning.whole_take import take_params

    take, bad, (left, right) = _knees_swapped(45, 51)
    det = detect_take(bad, None, params=take_params()).detection
    assert not det.flags[:, left].any() and det.flags[49:52, right].all() and not det.swaps.any()
    out, _ = ssa.repair_with_left(bad, det, None, foot_skate=False)
    off = np.degrees(R.geodesic_angle(out.rotations[:, [left, right]], take.rotations[:, [left, right]]))
    assert off.max() < 1e-6  # the mirror of the mirror: the clean take's values to rounding
    q = np.array(bad.rotations)
    q[49:52, right] = R.quaternion_multiply(R.rotvec_to_quaternion(np.array([0.0, 0.0, np.radians(14.0)])),
                                            q[49:52, right])
    worse = dataclasses.replace(bad, rotations=q)
    det = detect_take(worse, None, params=take_params()).detection
    out, runs = ssa.repair_with_left(worse, det, None, foot_skate=False)
    assert np.array_equal(out.rotations[:, [left, right]], q[:, [left, right]])
    assert any(r.joint == "LowerLeg_R" and "a swap not confirmed" in r.reason for r in runs)


def test_a_twist_handed_between_the_joints_of_one_arm_is_no_swap(shared_data):
    """The CMU backflip (``cmu_asfamc/backflip.amc``) on LaFAN1's rig at 30 fps, a clean take: its left upper arm
    turns 179 deg about itself into frame 33 while the left wrist turns 173 deg back, and detection flags the
    right wrist over 35-37 alone. Judged on the joints' values, the hands exchanged over 33-40 join the take at
    both ends (a swap confirmed, both hands changed over 33-40); judged on each hand's orientation in the body,
    the exchange breaks the left hand's path (a 177 deg step where it turns 110), so nothing is exchanged and
    clean gives the left hand back bit for bit. The same take with its hands really swapped over 10-20,
    flagged on the right over 12-20, is still found whole and confirmed."""
    from mocapkit.cleaning.ssa.swap_exchange import exchanged_cells, partner_swaps
    from mocapkit.motion import mirror_pairs
    from tests.shared import lafan_spelling, motionbuilder_spelling

    take = lafan_spelling(motionbuilder_spelling(mocapkit.load(shared_data / "cmu_asfamc" / "backflip.amc")))[::4]
    names, parents = take.skeleton.joint_names, take.skeleton.parents
    pairs = mirror_pairs(names)
    left, right = names.index("LeftHand"), names.index("RightHand")
    mirrored = mirrored_rotations(take)
    flags = np.zeros(take.rotations.shape[:2], dtype=bool)
    flags[35:38, right] = True
    assert partner_swaps(take.rotations, mirrored, flags, pairs, parents, 30.0) == []
    out = mocapkit.clean(take).motion
    assert np.array_equal(out.rotations[:, left], take.rotations[:, left])
    assert not exchanged_cells(take.rotations, out.rotations, mirrored, pairs).any()
    q = np.array(take.rotations)
    q[10:21, [left, right]] = mirrored[10:21, [left, right]]
    bad = dataclasses.replace(take, rotations=q)
    flags = np.zeros(q.shape[:2], dtype=bool)
    flags[12:21, right] = True
    found = partner_swaps(q, mirrored_rotations(bad), flags, pairs, parents, 30.0)
    assert [(s.joint, s.partner, s.start, s.end, s.confirmed) for s in found] == [(right, left, 10, 20, True)]


def test_the_joins_read_from_a_tracks_steps_are_the_joins_of_its_frames():
    """end_join from join_steps (made once per track) gives, bit for bit, the angular acceleration of the join's
    own frames with the run written in (the second differences at its two frames), at every frame of a real clip,
    both ends, on the joints' values and on their orientations in the body, the take's ends included."""
    from mocapkit.cleaning.ssa.guard import angular_acceleration
    from mocapkit.cleaning.ssa.swap_exchange import end_join, join_steps, parent_orientations

    take = mocapkit.load(mocapkit.samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"))
    q, mirrored = take.rotations, mirrored_rotations(take)
    frames = parent_orientations(q, take.skeleton.parents)
    F = len(q)

    def windowed(track, new, f, entry):
        lo, hi = (max(f - 2, 0), min(f + 2, F)) if entry else (max(f - 1, 0), min(f + 3, F))
        if (f == 0) if entry else (f == F - 1):
            return 0.0, 0.0
        inside = np.arange(lo, hi) >= f if entry else np.arange(lo, hi) <= f
        written = np.where(inside[:, None], new[lo:hi], track[lo:hi])
        at = [i for i in ([f - 1 - lo, f - lo] if entry else [f - lo, f + 1 - lo]) if 0 < i < hi - lo - 1]
        return ((float(angular_acceleration(written)[at].max()), float(angular_acceleration(track[lo:hi])[at].max()))
                if at else (0.0, 0.0))

    for j in (take.skeleton.index("lfemur"), take.skeleton.index("rhumerus"), take.skeleton.index("lradius")):
        for track, new in ((q[:, j], mirrored[:, j]),
                           (R.quaternion_multiply(frames[:, j], q[:, j]), R.quaternion_multiply(frames[:, j], mirrored[:, j]))):
            steps = join_steps(track, new)
            for f in range(F):
                for entry in (True, False):
                    assert end_join(steps, f, entry) == windowed(track, new, f, entry), (j, f, entry)


# -- a swap whose steps the limbs' own fast motion hides (swap_exchange.joined_swaps) --------------------------------

def _bundled(name: str):
    from pathlib import Path

    return mocapkit.load(Path(__file__).parents[2] / "data" / name)


def test_a_thigh_swap_in_a_run_is_found_and_exchanged_back():
    """The bundled Bandai Namco run (run_active_049, 30 fps) with ``corrupt.real_errors(kinds=("swap",), seed=5)``:
    the thighs swapped over frames 23-37. Their breaks, under what the running legs' own motion reaches at 30 fps,
    named no swap, and the repair from neighbour words left them 43.6 deg off the clean take on average. Both
    exchanged join the take at both ends: detection names exactly the swapped cells, the repair puts back the
    clean take's values (the mirror of the mirror, to rounding) and changes nothing else; the clean run has no
    swap."""
    take = _bundled("dataset-2_run_active_049.bvh")
    bad, mask, records = corrupt.real_errors(take, kinds=("swap",), n_errors=1, seed=5)
    assert {(r.joint, r.start, r.end) for r in records} == {("UpperLeg_L", 23, 38), ("UpperLeg_R", 23, 38)}
    det = ssa.detect(bad)
    assert np.array_equal(det.swaps, mask)
    out = ssa.repair(bad, det)
    assert np.degrees(R.geodesic_angle(out.rotations[mask], take.rotations[mask])).max() < 1e-9
    assert np.array_equal(out.rotations[~mask], bad.rotations[~mask])
    assert not ssa.detect(take).swaps.any()


def test_two_shin_swaps_four_frames_apart_are_found_each_on_its_own():
    """The bundled run with its shins swapped over frames 20-26 and 31-37. The step out of the first swap is no
    step into another: exchanged, the clean frames 27-30 between the two join the swapped frames beside them, so
    each run is judged on the take with the swaps found before it exchanged back. Exactly the swapped cells."""
    from mocapkit.cleaning.ssa.cues import midpoint_residuals
    from mocapkit.cleaning.ssa.swap_exchange import joined_swaps
    from mocapkit.motion import mirror_pairs

    take = _bundled("dataset-2_run_active_049.bvh")
    names = take.skeleton.joint_names
    shins = [names.index("LowerLeg_L"), names.index("LowerLeg_R")]
    q = np.array(take.rotations)
    truth = np.zeros(q.shape[:2], dtype=bool)
    for a, b in ((20, 27), (31, 38)):
        q[a:b, shins] = mirrored_rotations(take)[a:b, shins]
        truth[a:b, shins] = True
    bad = dataclasses.replace(take, rotations=q)
    assert np.array_equal(ssa.detect(bad).swaps, truth)
    found = joined_swaps(q, mirrored_rotations(bad), midpoint_residuals(q), mirror_pairs(names), take.skeleton.parents,
                         30.0, 6.0, 1.0)
    assert np.array_equal(found, truth)



def test_root_depths_count_the_bones_from_the_root_of_a_real_skeleton():
    """On the bundled CMU walk's skeleton each joint lies one bone deeper than its parent, the root at 0, and
    the leaves of the legs (the toes) as deep as the chain root -> hip joint -> femur -> tibia -> foot -> toes."""
    from mocapkit import samples
    from mocapkit.io import load

    sk = load(samples.path("12_walk.amc")).skeleton
    parents = np.asarray(sk.parents)
    depth = root_depths(parents)
    assert depth[0] == 0 and (depth[1:] == depth[parents[1:]] + 1).all()
    names = list(sk.joint_names)
    assert depth[names.index("ltoes")] == depth[names.index("lfemur")] + 3


def test_a_foot_swap_exchanged_back_gets_no_foot_skate_cleanup():
    """The bundled run with its feet swapped over frames 20-31 (the repair finds it from one side's flags,
    ``partner_swaps``). Exchanged back, the feet hold the capture's own values, planted where they were captured:
    the foot-skate cleanup (on by default) has nothing to mend there. It moved 6 clean cells of the leg (up to 0.1
    deg) and the swapped ones off their exchange; now the swap comes back to 1e-9 deg and nothing else moves."""
    take = _bundled("dataset-2_run_active_049.bvh")
    names = take.skeleton.joint_names
    feet = [names.index("Foot_L"), names.index("Foot_R")]
    q = np.array(take.rotations)
    q[20:32, feet] = mirrored_rotations(take)[20:32, feet]
    truth = np.zeros(q.shape[:2], dtype=bool)
    truth[20:32, feet] = True
    bad = dataclasses.replace(take, rotations=q)
    out = ssa.repair(bad, ssa.detect(bad))
    assert np.degrees(R.geodesic_angle(out.rotations[truth], take.rotations[truth])).max() < 1e-9
    assert np.array_equal(out.rotations[~truth], bad.rotations[~truth])


def test_the_clean_frame_between_two_shin_swaps_is_left_as_it_came():
    """The bundled walk (walk-turn-left_exhausted_005) with its shins swapped over frames 36-50 and 52-65. The
    walking legs hide the steps from the check of two breaks; the entry of the first and the exit of the second
    join the take when exchanged, and the run between them holds frame 51. Put back as
    it came it joins the exchanged swaps beside it: a swap's break is its start or its end, not both. Exactly the
    swapped cells."""
    from mocapkit.cleaning.ssa.cues import midpoint_residuals
    from mocapkit.cleaning.ssa.swap_exchange import joined_swaps
    from mocapkit.motion import mirror_pairs

    take, bad, knees = _knees_swapped(36, 50)
    q = np.array(bad.rotations)
    q[52:66, knees] = mirrored_rotations(take)[52:66, knees]
    bad = dataclasses.replace(take, rotations=q)
    truth = np.zeros(q.shape[:2], dtype=bool)
    truth[36:51, knees] = truth[52:66, knees] = True
    found = joined_swaps(q, mirrored_rotations(bad), midpoint_residuals(q), mirror_pairs(take.skeleton.joint_names),
                         take.skeleton.parents, 30.0, 6.0, 1.0)
    assert np.array_equal(found, truth)
    assert np.array_equal(ssa.detect(bad).swaps, truth)
