"""Frozen channels found from the take alone (mocapkit.cleaning.ssa.freezes), on a real take.

The shipped CMU take 131_01 (BVH, 120 fps) is cut to its first 480 frames; its right shoulder turns 88 deg over
frames 180-224. A freeze is made as a tracker makes one: the shoulder repeats frame 180's rotation bit for bit
through frame 223, then is back on its own path at 224 (a jump).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa.cues import CAUSES, own_breaks, midpoint_residuals
from mocapkit.cleaning.ssa.freezes import frozen_channels
from mocapkit.samples import path

A, B = 180, 224  # the held frames a .. b - 1


@pytest.fixture(scope="module")
def take():
    return mocapkit.load(path("131_01.bvh"))[:480]


def _frozen(m, name="RightShoulder", a=A, b=B):
    j = m.skeleton.joint_names.index(name)
    q = np.array(m.rotations)
    q[a:b, j] = q[a, j]
    return dataclasses.replace(m, rotations=q), j


def _breaks(m):
    return own_breaks(midpoint_residuals(m.rotations), 8.0, m.fps, m.rotations)


def _rule(m):
    return frozen_channels(m.rotations, _breaks(m), np.ones(m.num_joints, dtype=bool), m.fps)


def test_a_freeze_ending_in_a_jump_is_found_and_clean_holds_are_not(take):
    m, j = _frozen(take)
    q = np.asarray(m.rotations)
    assert np.degrees(R.geodesic_angle(q[B - 1, j], q[B, j])) > 40  # the jump back to its own path
    out = _rule(m)
    # frame A is the sample the channel froze at: the repeats of it are flagged
    assert np.flatnonzero(out[:, j]).tolist() == list(range(A + 1, B)) and out.sum() == B - A - 1
    # the take as captured: its knees clamp at the rest pose, its fingers and toes never move: nothing
    assert not _rule(take).any()
    # the whole body held (a repeated pose, a padded stretch): no freeze
    q2 = np.array(take.rotations)
    q2[A:B] = q2[A]
    assert not _rule(dataclasses.replace(take, rotations=q2)).any()
    # the same hold eased out of (no break at its end): a joint held still, not frozen
    q3 = np.array(q)
    q3[B : B + 60, j] = R.slerp(q[B - 1, j], q[B + 60, j], np.linspace(0, 1, 62)[1:-1])
    assert not _rule(dataclasses.replace(m, rotations=q3))[:, j].any()
    # held at exactly the rest pose (every channel 0): a solver's clamp, not frozen
    q4 = np.array(q)
    q4[A:B, j] = R.identity()
    assert not _rule(dataclasses.replace(m, rotations=q4))[:, j].any()
    # a hold that runs to the last frame shows no break at its end
    tail, _ = _frozen(take, a=400, b=480)
    assert not _rule(tail).any()
    # a joint the rule does not analyse is never flagged
    none = frozen_channels(m.rotations, _breaks(m), np.arange(m.num_joints) != j, m.fps)
    assert not none.any()


def test_detect_names_a_freeze_no_similar_motion_judges(take):
    # words judged only within 1e-6 deg of a neighbour: nothing in the take is judged, as on a rig no context
    # holds whose motion the take does not repeat
    m, j = _frozen(take)
    det = ssa.detect(m, max_word_angle_deg=1e-6)
    assert not np.isfinite(det.digression[:, det.analysed]).any()  # no frame judged
    assert det.flags[A + 1 : B, j].all()
    frozen_bit = 1 << [name for name, _ in CAUSES].index("frozen")
    assert (det.causes()[A + 1 : B, j] & frozen_bit).all()
    assert np.flatnonzero(det.frozen[:, j]).tolist() == list(range(A + 1, B))
    # made again from its fields (a saved detection read back), the same causes
    assert np.array_equal(dataclasses.replace(det).causes(), det.causes())
    # the take as captured: nothing frozen
    assert not ssa.detect(take, max_word_angle_deg=1e-6).frozen.any()


def test_an_unjudged_freeze_is_bridged_like_a_gap_and_nothing_else_moves(take):
    m, j = _frozen(take)
    det = ssa.detect(m, max_word_angle_deg=1e-6)
    out, left = ssa.repair_with_left(m, det, foot_skate=False)
    q, r = np.asarray(m.rotations), np.asarray(out.rotations)
    changed = np.any(q != r, axis=-1)
    assert not left and np.array_equal(np.flatnonzero(changed.any(axis=0)), [j])  # only the frozen joint
    assert changed[:, j].any() and not changed[: A + 1, j].any() and not changed[B:, j].any()
    # the jump out of the hold spread over the bridge: no step past the take's own
    steps = np.degrees(R.geodesic_angle(r[1:, j], r[:-1, j]))
    own = np.degrees(R.geodesic_angle(q[1:, j], q[:-1, j]))
    own[A - 1 : B] = 0.0  # the joint's steps elsewhere in the take, not the freeze's 0s and jump
    assert steps[A : B].max() < own.max() < 40


def test_recurring_holds_are_the_same_in_blocks_as_from_the_whole_matrix(take):
    """The (n, n) angles of a long take's holds are taken in blocks of rows (their memory grew as n^2: 400 MB on
    a 9-minute session); any block size gives the whole matrix's answer, bit for bit."""
    from mocapkit.cleaning.ssa.freezes import recurring

    j = take.skeleton.joint_names.index("RightAnkle")
    held = np.asarray(take.rotations[::2, j], dtype=np.float64)  # 240 real rotations, about half within 1 deg of another
    recur = np.radians(1.0)
    near = R.geodesic_angle(held[:, None], held[None, :]) <= recur
    np.fill_diagonal(near, False)
    whole = near.any(axis=1)
    assert whole.any() and not whole.all()
    for cells in (1, 239, 240 * 7 + 5, 1 << 18):  # one row a block, blocks not dividing n, the whole at once
        assert np.array_equal(recurring(held, recur, block_cells=cells), whole)
    assert not recurring(held[:1], recur).any() and recurring(held[:0], recur).shape == (0,)
