"""Repair on real clips: only flagged cells change, the error is fixed, contacts and foot skate respected."""

import dataclasses

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from tests.cleaning.ssa.helpers import turned


def test_repair_changes_only_flagged_cells_and_fixes_the_error(walk, flipped):
    bad, mask, records, det = flipped
    fixed = ssa.repair(bad, det, foot_skate=False)
    keep = ~det.flags
    assert np.array_equal(fixed.rotations[keep], bad.rotations[keep])
    assert np.array_equal(fixed.root_positions, bad.root_positions)
    r = records[0]
    j = walk.skeleton.index(r.joint)
    before = np.degrees(R.geodesic_angle(bad.rotations[r.start : r.end, j], walk.rotations[r.start : r.end, j]))
    after = np.degrees(R.geodesic_angle(fixed.rotations[r.start : r.end, j], walk.rotations[r.start : r.end, j]))
    assert before.mean() > 100 and after.mean() < 20
    assert np.allclose(np.linalg.norm(fixed.rotations, axis=-1), 1.0)


def test_repair_with_foot_skate_touches_only_legs(walk, flipped):
    bad, mask, records, det = flipped
    fixed = ssa.repair(bad, det)
    changed = np.any(fixed.rotations != bad.rotations, axis=-1) & ~det.flags
    legs = set()
    for role in ("left_foot", "right_foot"):
        j = mocapkit.motion.find_joint(walk.skeleton, role)
        while j > 0:
            legs.add(j)
            j = int(walk.skeleton.parents[j])
    assert set(np.flatnonzero(changed.any(axis=0))) <= legs


def test_contact_constraint_is_met(walk, flipped):
    """The contact's frames put the ankle on its target exactly: the two-bone IK is analytic, so the miss is the
    target's distance beyond the leg's reach (zero here), up to round-off; without the contact it misses."""
    bad, mask, records, det = flipped
    r = records[0]
    sk = walk.skeleton
    foot = sk.index("LeftAnkle")
    knee = int(sk.parents[foot])
    hip = int(sk.parents[knee])
    target = walk.global_positions()[r.start + 5, foot]
    contact = ssa.Contact("LeftAnkle", r.start, r.start + 10, tuple(target))
    fixed = ssa.repair(bad, det, contacts=[contact], foot_skate=False)
    gp = fixed.global_positions()[r.start : r.start + 10]
    reach = np.linalg.norm(gp[:, foot] - target, axis=-1)
    thigh, shin = np.linalg.norm(sk.offsets[knee]), np.linalg.norm(sk.offsets[foot])
    d = np.linalg.norm(target - gp[:, hip], axis=-1)
    shortfall = np.maximum.reduce([np.zeros_like(d), d - (thigh + shin), abs(thigh - shin) - d])
    assert np.all(shortfall == 0)  # the target is within the leg's reach in every contact frame
    np.testing.assert_allclose(reach, shortfall, rtol=0, atol=1e-9 * (thigh + shin))
    free = ssa.repair(bad, det, foot_skate=False).global_positions()[r.start : r.start + 10, foot]
    assert np.linalg.norm(free - target, axis=-1).max() > 1e-3 * (thigh + shin)  # the contact is what moved the ankle


def test_repair_refuses_another_context(walk, flipped):
    bad, mask, records, det = flipped
    with pytest.raises(ValueError, match="context"):
        ssa.repair(bad, det, [dataclasses.replace(walk, name="other")])
    with pytest.raises(ValueError, match="another clip"):
        ssa.repair(bad[:100], det)


def test_a_flagged_run_without_neighbour_words_is_bridged_from_its_ends(walk, flipped):
    """No neighbour to copy from: the run is slerped between its clean ends, not bent from its own values."""
    bad, mask, records, det = flipped
    j = walk.skeleton.index(records[0].joint)
    cells = det.flags[:, j] & mask[:, j]
    garbage = np.array(bad.rotations)
    rng = np.random.default_rng(0)
    garbage[cells, j] = R.quaternion_normalize(rng.normal(size=(int(cells.sum()), 4)))  # nothing to keep in there
    garbage = dataclasses.replace(bad, rotations=garbage)
    orphan = dataclasses.replace(det, neighbor_pos=np.full_like(det.neighbor_pos, -1))
    fixed = ssa.repair(garbage, orphan, foot_skate=False)
    assert np.array_equal(fixed.rotations[~det.flags], garbage.rotations[~det.flags])
    after = np.degrees(R.geodesic_angle(walk.rotations[cells, j], fixed.rotations[cells, j]))
    assert np.median(after) < 20 and after.max() < 45


def test_an_error_between_two_breaks_is_flagged_and_repaired_between_them(walk):
    """A 60 deg knee error of 0.25 s on the walk: its digression spreads over the words around it, the flags do not."""
    frames = np.arange(300, 330)
    bad, j = turned(walk, "LeftKnee", frames, 60.0)
    det = ssa.detect(bad)
    margin = int(round(0.05 * walk.fps))
    assert (det.mdm[:, j] > 0.25).sum() > 3 * len(frames)  # the digression is wider than the error
    flagged = np.flatnonzero(det.flags[:, j])
    assert flagged.min() >= frames[0] - 1 - margin and flagged.max() <= frames[-1] + 1 + margin
    assert det.flags[frames, j].all()
    rep = ssa.repair(bad, det)
    err = np.degrees(R.geodesic_angle(rep.rotations[:, j], walk.rotations[:, j]))
    assert err[frames].max() < 20.0 and err.max() < 20.0  # was 60 in the window; no clean frame pushed far off
