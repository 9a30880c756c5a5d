"""A left/right swap from the take's first frame or to its last: one break (mocapkit.cleaning.ssa.edge_swaps).

The real take is the bundled Bandai Namco run (tests/data, run_active_049, 65 frames at 30 fps) with a pair's
limbs swapped as ``corrupt --kind swap`` swaps them, each taking its partner's mirrored rotation.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa.cues import mirrored_rotations

RUN = Path(__file__).parents[2] / "data" / "dataset-2_run_active_049.bvh"


def _swapped(pair, runs, path=RUN):
    """The take ``path`` (the run), a copy with ``pair`` (two joint names) swapped over each of ``runs`` ``(a, b)``
    (frames a .. b - 1), and the swapped cells (F, J) bool."""
    take = mocapkit.load(path)
    names = take.skeleton.joint_names
    cols = [names.index(n) for n in pair]
    q = np.array(take.rotations)
    truth = np.zeros(q.shape[:2], dtype=bool)
    for a, b in runs:
        q[a:b, cols] = mirrored_rotations(take)[a:b, cols]
        truth[a:b, cols] = True
    return take, dataclasses.replace(take, rotations=q), truth


@pytest.mark.parametrize("runs", [
    # the thighs swapped over frames 0-8: one break, at 8 -> 9. Exchanged back over 0-8 they join the take there,
    # and the pair digresses from the take's neighbour words over those frames (39.6 deg on average), not beyond
    # (4.7)
    [(0, 9)],
    # and again over 20-29: the first swap's one break, paired in time order with the second's entry, exchanged
    # the clean frames 9-19 between them and left both swaps (22 clean cells named a swap); read as a swap from
    # the take's first frame, each swap is found on its own frames
    [(0, 9), (20, 30)],
])
def test_a_swap_from_the_first_frame_is_found_and_exchanged_back_on_its_own_frames(runs):
    """Detection names exactly the swapped cells, the repair puts back the clean values and changes nothing
    else."""
    take, bad, truth = _swapped(("UpperLeg_L", "UpperLeg_R"), runs)
    det = ssa.detect(bad)
    assert np.array_equal(det.swaps, truth)
    out = ssa.repair(bad, det)
    assert np.degrees(R.geodesic_angle(out.rotations[truth], take.rotations[truth])).max() < 1e-9
    assert np.array_equal(out.rotations[~truth], bad.rotations[~truth])


@pytest.mark.parametrize("name, pair, runs", [
    # the run's shins over frames 0-4 and 10-16: read in time order, the clean frames 5-9 between were the swap
    ("dataset-2_run_active_049.bvh", ("LowerLeg_L", "LowerLeg_R"), [(0, 5), (10, 17)]),
    # dash_chimpira_001's thighs over frames 0-7 and 17-23: the clean frames 8-16 were the swap
    ("dataset-1_dash_chimpira_001.bvh", ("UpperLeg_L", "UpperLeg_R"), [(0, 8), (17, 24)]),
    # bow_active_001's forearms over frames 0-6 and 10-16: the first's break and the second's entry one break
    # event, held whole with the first's break (the clean frames 7-9 were the swap)
    ("dataset-1_bow_active_001.bvh", ("LowerArm_L", "LowerArm_R"), [(0, 7), (10, 17)]),
])
def test_a_swap_from_the_first_frame_whose_break_a_fast_limb_hides_is_found_on_its_own_frames(name, pair, runs):
    """Bundled Bandai Namco runs with a pair of legs swapped from the first frame and again a few frames later.
    The running limbs move faster than the two lie apart, so at the first swap's break neither lands nearer its
    partner's mirror image than its own step: no swap step there, and the break was paired in time order with the
    second swap's entry. Read from the edge at the steps the rules of two breaks start or end a swap at, each swap
    is found on its own frames and put back."""
    take, bad, truth = _swapped(pair, runs, RUN.parent / name)
    det = ssa.detect(bad)
    assert np.array_equal(det.swaps, truth)
    out = ssa.repair(bad, det)
    assert np.degrees(R.geodesic_angle(out.rotations[truth], take.rotations[truth])).max() < 1e-9


def test_a_swap_from_the_first_frame_leaves_the_break_before_the_last_to_the_swap_it_ends():
    """run_masculinity_001 with its feet swapped over frames 0-9 and 26-32: the first swap is found from the first
    frame; read apart, the last edge took the second's exit (32 -> 33) for a possible swap over 33-58 and held it,
    and the second swap went unfound. Read with the first swap found, that break ends the second: exactly the
    swapped cells, both put back."""
    take, bad, truth = _swapped(("Foot_L", "Foot_R"), [(0, 10), (26, 33)],
                                RUN.parent / "dataset-1_run_masculinity_001.bvh")
    det = ssa.detect(bad)
    assert np.array_equal(det.swaps, truth)
    assert not [n for n in det.notes if "possible left/right swap" in n]
    out = ssa.repair(bad, det)
    assert np.degrees(R.geodesic_angle(out.rotations[truth], take.rotations[truth])).max() < 1e-9


def test_a_swap_whose_entry_the_limbs_passing_hides_is_found_on_its_own_frames():
    """The bundled Bandai Namco run_masculinity_001 with its feet swapped over frames 4-11. The feet pass each other
    at the entry (the right foot's value joins frame 4 exchanged at 11.6 against 23.2 deg/frame^2, half), so the
    swap reads as one from the take's first frame to its exit: frames 0-3 were named swapped with it, and the
    repair exchanged them too (44 deg off the capture). The run from the entry, exchanged, joins every track better
    than the input: exactly the swapped cells are named, and the frames before the entry come back as they came."""
    take, bad, truth = _swapped(("Foot_L", "Foot_R"), [(4, 12)], RUN.parent / "dataset-1_run_masculinity_001.bvh")
    det = ssa.detect(bad)
    assert np.array_equal(det.swaps, truth)
    out = ssa.repair(bad, det)
    feet = [take.skeleton.index("Foot_L"), take.skeleton.index("Foot_R")]
    assert np.array_equal(out.rotations[:4, feet], bad.rotations[:4, feet])


def test_a_swap_to_the_last_frame_the_digression_does_not_tell_is_named_and_left():
    """The thighs swapped over frames 35-44 and 56-64, the last frame's: the second's one break, 55 -> 56, and the
    pair digresses less over 56-64 (7.9 deg on average) than over the frames before the break (12.2), so which
    side is swapped is not said. The first swap is found and exchanged back; the second is named in the notes as
    a possible swap and its cells come back as they were given."""
    take, bad, truth = _swapped(("UpperLeg_L", "UpperLeg_R"), [(35, 45), (56, 65)])
    det = ssa.detect(bad)
    assert np.array_equal(det.swaps, truth & (np.arange(take.num_frames) < 45)[:, None])
    notes = [n for n in det.notes if "possible left/right swap" in n]
    assert len(notes) == 1 and "UpperLeg_L and UpperLeg_R" in notes[0] and "56-64" in notes[0]
    out = ssa.repair(bad, det)
    assert np.array_equal(out.rotations[56:], bad.rotations[56:])


def test_clean_bundled_takes_have_no_swap_at_their_edges():
    """Clean takes (the run, the bundled Bandai walk, the CMU start) break at their edges as motion does: no swap
    found, none named possible."""
    for name in ("dataset-2_run_active_049.bvh", "dataset-2_walk-turn-left_exhausted_005.bvh", "cmu_01_01_start.bvh"):
        det = ssa.detect(mocapkit.load(RUN.parent / name))
        assert not det.swaps.any(), name
        assert not [n for n in det.notes if "possible left/right swap" in n], name


def test_unexplained_counts_the_events_no_run_starts_or_ends_at():
    """Three events, steps 6, 33 and 40: the runs 0-6 and 34-40 start or end at each; the run 7-33 leaves 40."""
    from mocapkit.cleaning.ssa.edge_swaps import unexplained

    events = (np.array([6, 33, 40]), np.array([6, 33, 40]))
    cells = np.zeros(60, dtype=bool)
    cells[0:7] = cells[34:41] = True
    assert unexplained(cells, events) == 0
    other = np.zeros(60, dtype=bool)
    other[7:34] = True
    assert unexplained(other, events) == 1
