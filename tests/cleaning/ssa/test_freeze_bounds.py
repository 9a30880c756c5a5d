"""A frozen channel's flags bounded to its frozen frames (mocapkit.cleaning.ssa.freeze_bounds).

The real take is bvh-python's test_mocapbank (30 fps, a peer file in the shared data): its left shoulder is
frozen as a tracker freezes one, repeating frame 190's rotation bit for bit through frame 208 and back on its
own path at 209. Its MDM runs over half the threshold from frame 154 on (live motion the take does not repeat),
and the freeze's end break confirmed all of it.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa.freeze_bounds import bounded_breaks, bounded_holds, freeze_end_breaks, held_repeats
from mocapkit.cleaning.whole_take import detect_take

HELD, BACK = 190, 209  # frame 190 is the sample the channel froze at; 191 .. 208 repeat it


@pytest.fixture(scope="module")
def frozen_take(shared_data):
    take = mocapkit.load(shared_data / "peer_files" / "20tab+bvh-python" / "tests" / "test_mocapbank.bvh")
    j = take.skeleton.joint_names.index("LeftShoulder")
    q = np.array(take.rotations)
    q[HELD:BACK, j] = q[HELD, j]
    return take, dataclasses.replace(take, rotations=q), j


def test_a_frozen_shoulder_is_flagged_and_repaired_on_its_frozen_frames_only(frozen_take):
    take, m, j = frozen_take
    det = detect_take(m).detection
    assert np.flatnonzero(det.frozen[:, j]).tolist() == list(range(HELD + 1, BACK))
    assert np.flatnonzero(det.flags[:, j]).tolist() == list(range(HELD + 1, BACK))  # not the live frames 154-190
    fixed = ssa.repair(m, det, foot_skate=False)
    live = np.r_[0:HELD + 1, BACK : m.num_frames]
    assert np.array_equal(fixed.rotations[live, j], m.rotations[live, j])
    assert not np.array_equal(fixed.rotations[HELD + 1 : BACK, j], m.rotations[HELD + 1 : BACK, j])


def test_the_break_that_ends_a_freeze_confirms_only_its_frozen_cells():
    F = 60
    breaks, frozen = np.zeros((F, 2), dtype=bool), np.zeros((F, 2), dtype=bool)
    frozen[31:40, 0] = True  # frames 31 .. 39 repeat frame 30; the step out of it marks 39 and 40
    breaks[39:41, 0] = True
    breaks[5:7, 0] = True  # another break of the same joint, far from the freeze
    breaks[39:41, 1] = True  # the same frames on a joint with no freeze
    assert np.flatnonzero(freeze_end_breaks(breaks, frozen)[:, 0]).tolist() == [39, 40]
    assert not freeze_end_breaks(breaks, frozen)[:, 1].any()

    def confirm(b):  # stands for confirm_flags: a break confirms frames 10 .. 45 of its joint, a digression run
        out = np.zeros_like(b)
        out[10:46] = b[10:46].any(axis=0)
        return out

    flags = bounded_breaks(confirm, breaks, frozen)
    assert np.flatnonzero(flags[:, 0]).tolist() == list(range(31, 40))  # the frozen cells, not the run's others
    assert np.array_equal(flags[:, 1], confirm(breaks)[:, 1])  # no freeze: as confirmed
    assert np.array_equal(bounded_breaks(confirm, breaks, None), confirm(breaks))


def test_a_hold_that_holds_a_freeze_keeps_its_frozen_cells_and_other_holds_stay_whole():
    holds, frozen = np.zeros((50, 1), dtype=bool), np.zeros((50, 1), dtype=bool)
    holds[20:30, 0] = holds[40:45, 0] = True
    frozen[21:30, 0] = True  # frame 20: the sample the channel froze at
    kept = bounded_holds(holds, frozen)[:, 0]
    assert np.flatnonzero(kept).tolist() == list(range(21, 30)) + list(range(40, 45))
    assert np.array_equal(bounded_holds(holds, None), holds)


def test_a_hold_flags_its_repeats_not_the_sample_it_holds():
    holds = np.zeros((12, 3), dtype=bool)
    holds[2:6, 0] = True  # a hold of frames 2-5: frame 2 is the sample frames 3-5 repeat
    holds[7:9, 1] = True  # one still step: nothing shows which frame is held, kept whole
    holds[0:3, 2] = True  # a hold from the take's first frame
    out = held_repeats(holds)
    assert np.flatnonzero(out[:, 0]).tolist() == [3, 4, 5]
    assert np.flatnonzero(out[:, 1]).tolist() == [7, 8] and np.flatnonzero(out[:, 2]).tolist() == [1, 2]


def test_a_held_toe_s_live_sample_is_not_flagged(hdm05_errors):
    """HDM05 bd sneak2StepsLStart 001 with real-style errors (seed 1001): the right toes held over frames 102-126
    at frame 101's value, a hold the similar motion judges (its exit no break of the toes' own); frame 101, the
    clean sample, is not flagged (its repair put it 4.2 deg off the clean take)."""
    ref, bad, mask, det = hdm05_errors("HDM_bd_sneak2StepsLStart_001_120.amc", 1001)
    j = ref.skeleton.index("rtoes")
    assert np.flatnonzero(mask[:, j]).tolist() == list(range(102, 127))
    assert np.flatnonzero(det.holds[:, j]).tolist() == list(range(102, 127))
    assert det.flags[102:127, j].all() and not det.flags[101, j]
