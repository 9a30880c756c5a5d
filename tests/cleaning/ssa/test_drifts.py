"""Smooth drifts: the agreement statistic, the run rule, and detect on a walk against a context that repeats it."""

import dataclasses

import numpy as np
import pytest

from mocapkit import corrupt
from mocapkit import rotations as R
from mocapkit.cleaning import ssa
from mocapkit.cleaning.ssa.drifts import (body_agreement, chain_level, crossed_turns, excursions, group_agreement,
                                         group_offset_change, group_offset_turn, offset_turn, other_joints_level,
                                         smooth_drift_flags)
from tests.cleaning.ssa.helpers import twin_of


def slow_agreement(d, analysed):
    """Reference: cell by cell, the median of the other analysed joints' finite values."""
    F, J = d.shape
    out = np.full((F, J), np.nan)
    cols = np.flatnonzero(analysed)
    if len(cols) < 2:
        return out
    for f in range(F):
        for j in cols:
            rest = [d[f, k] for k in cols if k != j and np.isfinite(d[f, k])]
            if rest:
                out[f, j] = np.median(rest)
    return out


def test_body_agreement_is_the_median_of_the_other_analysed_joints():
    rng = np.random.default_rng(0)
    d = rng.uniform(0, 1, size=(40, 7))
    d[rng.uniform(size=d.shape) < 0.1] = np.nan
    analysed = np.array([True, True, False, True, True, True, False])
    got = body_agreement(d, analysed)
    assert np.allclose(got, slow_agreement(d, analysed), equal_nan=True)
    assert np.isnan(got[:, ~analysed]).all()
    # a joint's own digression never lowers (or raises) its own evidence
    d2 = d.copy()
    d2[:, 0] = 100.0
    assert np.allclose(body_agreement(d2, analysed)[:, 0], got[:, 0], equal_nan=True)
    assert np.isnan(body_agreement(d, np.eye(7, dtype=bool)[0])).all()  # one analysed joint: no other joints
    with pytest.raises(ValueError, match="analysed"):
        body_agreement(d, analysed[:3])



def test_group_agreement_is_the_other_joints_angle_from_the_words_that_judge_the_joint():
    """The body agrees with the words that judge a joint, not with each other joint's closest words: joint 0's
    group 1 matches it best while the rest of the body is far from group 1's words (12 deg); each other joint is
    close to some other group's (1 deg), and the median of those smallest angles (what body_agreement reads)
    says the body agrees."""
    F = 20
    d = np.full((3, F, 4), np.nan)
    d[0] = np.radians([5.0, 1.0, 1.0, 1.0])  # group 0 holds every joint: the others close, joint 0 not
    d[1, :, :3] = np.radians([0.5, 12.0, 12.0])  # group 1 (joints 0-2) matches joint 0 and nothing else
    d[2, :, [0, 3]] = np.radians(2.0)  # group 2 holds joints 0 and 3 only
    best = np.nanargmin(d, axis=0)
    assert (best[:, 0] == 1).all()
    got = np.degrees(group_agreement(d, best))
    assert np.allclose(got[:, 0], 12.0)  # the median of joints 1 and 2 in group 1
    assert np.allclose(np.degrees(body_agreement(np.nanmin(d, axis=0), np.ones(4, dtype=bool)))[:, 0], 1.0)
    assert np.allclose(got[:, 3], 1.0)  # joint 3 judged by group 0: joints 0 (5), 1 and 2 (1 each)
    assert np.allclose(np.degrees(group_agreement(d, np.full((F, 4), 2)))[:, 3], 2.0)  # group 2: joint 0 alone
    lone = np.full((1, F, 4), np.nan)
    lone[0, :, 0] = 0.1
    assert np.isnan(group_agreement(lone, np.zeros((F, 4), dtype=int))).all()  # no other joint in the group
    with pytest.raises(ValueError, match="best"):
        group_agreement(d, best[:, :3])

def drift_case(F=100, fps=100.0, J=3):
    """A 40-frame excursion on joint 0 (consistency up to 6), the body agreeing (1 deg) everywhere."""
    jumps = np.zeros((F, J), dtype=bool)
    agreement = np.full((F, J), np.radians(1.0))
    consistency = np.full((F, J), 0.5)
    consistency[30:70, 0] = 1.0 + 5.0 * np.sin(np.linspace(0, np.pi, 42)[1:-1])
    return jumps, agreement, consistency, fps


def test_smooth_drift_flags_whole_excursions_where_the_body_agrees():
    jumps, agreement, consistency, fps = drift_case()
    flags = smooth_drift_flags(jumps, agreement, consistency, fps, repeat_deg=5.0, z_min=3.0, min_s=0.25)
    assert np.flatnonzero(flags[:, 0]).tolist() == list(range(30, 70))  # the whole excursion, down to z = 0.5
    assert not flags[:, 1:].any()
    strong = int((consistency[:, 0] >= 3.0).sum())
    # too short: fewer strong cells than min_s asks
    assert not smooth_drift_flags(jumps, agreement, consistency, fps, min_s=(strong + 1) / fps).any()
    assert smooth_drift_flags(jumps, agreement, consistency, fps, min_s=strong / fps)[:, 0].any()
    # the rest of the body far from its neighbours: the context does not repeat the motion
    far = np.full_like(agreement, np.radians(8.0))
    assert not smooth_drift_flags(jumps, far, consistency, fps, repeat_deg=5.0).any()
    assert smooth_drift_flags(jumps, far, consistency, fps, repeat_deg=10.0)[:, 0].any()
    # no evidence (NaN: no context, or the pelvis) is never flagged
    assert not smooth_drift_flags(jumps, np.full_like(agreement, np.nan), consistency, fps).any()
    # a break in the run or within the margin: confirmation's business, not a smooth drift
    broken = jumps.copy()
    broken[72, 0] = True
    assert not smooth_drift_flags(broken, agreement, consistency, fps, margin_s=0.05).any()
    assert smooth_drift_flags(broken, agreement, consistency, fps, margin_s=0.01)[:, 0].any()
    with pytest.raises(ValueError, match="same"):
        smooth_drift_flags(jumps[:, :2], agreement, consistency, fps)
    with pytest.raises(ValueError, match="z_min"):
        smooth_drift_flags(jumps, agreement, consistency, fps, z_min=0.4)  # below the run's extent


@pytest.fixture(scope="module")
def drifted(walk):
    bad, mask, records = corrupt.smooth_drifts(walk, n_drifts=1, peak_deg=35.0, duration_s=(1.0, 1.0), seed=3,
                                               joints=["LeftElbow"])
    return bad, mask, records


def test_detect_flags_a_smooth_drift_against_a_context_that_repeats_the_motion(walk, drifted):
    """The walk's twin as context: the neighbours match every joint, so the drifting elbow alone digresses."""
    bad, mask, records = drifted
    twin = twin_of(walk)
    (r,) = records
    j = walk.skeleton.index(r.joint)
    assert not ssa.discontinuities(bad)[:, j].any()  # no break: confirmation alone never flags it
    det = ssa.detect(bad, [twin], drift=True)
    visible = mask[:, j] & (det.digression[:, j] > np.radians(10.0))
    assert det.flags[visible, j].all()
    assert np.array_equal(det.flags, (det.flags & ~det.drifts()) | det.drifts())
    drift_bit = 1 << [name for name, _ in ssa.cues.CAUSES].index("drift")
    assert np.array_equal(det.causes() != 0, det.flags) and np.array_equal((det.causes() & drift_bit) != 0, det.drifts())
    assert not det.drifts()[:, np.arange(walk.num_joints) != j].any()
    assert not ssa.detect(bad, [twin]).flags[:, j].any()  # the rule is off by default
    assert not ssa.detect(walk, [twin], drift=True).drifts().any()  # the clean take: nothing
    assert not ssa.detect(bad, drift=True).drifts().any()  # analysed alone: no evidence that the motion repeats
    assert det.with_threshold(0.3).flags[visible, j].all()


def test_detection_keeps_the_drift_evidence_through_save_and_load(walk, drifted, tmp_path):
    bad, _, _ = drifted
    det = ssa.detect(bad, [twin_of(walk)], drift=True)
    back = ssa.Detection.load(det.save(tmp_path / "d.npz"))
    assert np.array_equal(back.change, det.change, equal_nan=True)
    assert np.array_equal(back.drifts(), det.drifts()) and det.drifts().any()


def slow_other_level(c, judged, others):
    """Reference: cell by cell, the (others + 1)-th largest finite value among the other judged joints."""
    F, J = c.shape
    out = np.full((F, J), -np.inf)
    for f in range(F):
        for j in range(J):
            rest = sorted((c[f, k] for k in range(J) if k != j and judged[f, k] and np.isfinite(c[f, k])), reverse=True)
            if len(rest) > others:
                out[f, j] = rest[others]
    return out


@pytest.mark.parametrize("others", [0, 1, 2])
def test_other_joints_level_counts_the_other_judged_joints(others):
    rng = np.random.default_rng(others)
    c = rng.uniform(0, 8, size=(30, 6)).round(0)  # ties included
    c[rng.uniform(size=c.shape) < 0.1] = np.nan
    judged = rng.uniform(size=c.shape) < 0.8
    got = other_joints_level(c, judged, others)
    assert np.array_equal(got, slow_other_level(c, judged, others))
    with pytest.raises(ValueError, match="others"):
        other_joints_level(c, judged, -1)
    with pytest.raises(ValueError, match="shape"):
        other_joints_level(c, judged[:, :3], 1)


def test_smooth_drift_flags_one_joint_drifts_two_may_at_once_several_are_a_style():
    jumps, agreement, consistency, fps = drift_case(J=4)
    assert smooth_drift_flags(jumps, agreement, consistency, fps)[:, 0].any()
    two = consistency.copy()
    two[:, 1] = consistency[:, 0]  # a second joint drifting at the same time: both flagged
    flags = smooth_drift_flags(jumps, agreement, two, fps, others=1)
    assert flags[:, 0].any() and flags[:, 1].any()
    assert not smooth_drift_flags(jumps, agreement, two, fps, others=0).any()
    three = two.copy()
    three[:, 2] = consistency[:, 0]  # three joints away from their neighbours together: not a drift of one
    assert not smooth_drift_flags(jumps, agreement, three, fps, others=1).any()
    assert smooth_drift_flags(jumps, agreement, three, fps, others=None)[:, :3].any(axis=0).all()
    # a joint without evidence (the pelvis: agreement NaN) is never counted among the others
    no_ev = agreement.copy()
    no_ev[:, 1:3] = np.nan
    assert smooth_drift_flags(jumps, no_ev, three, fps, others=0)[:, 0].any()


def test_smooth_drift_flags_a_joint_whose_partner_digresses_too_is_a_style():
    """Joints 0 and 1 a left/right pair: joint 0's excursion is a drift while its partner stays among its neighbours,
    and no evidence where the partner digresses by partner_ratio * z_min or more (a two-sided style)."""
    jumps, agreement, consistency, fps = drift_case(J=4)
    partners = np.array([1, 0, 2, 3])
    assert smooth_drift_flags(jumps, agreement, consistency, fps, partners=partners)[:, 0].any()
    both = consistency.copy()
    both[30:70, 1] = 1.6  # the partner at 0.53 z_min over the whole excursion
    assert not smooth_drift_flags(jumps, agreement, both, fps, partners=partners, partner_ratio=0.5).any()
    assert smooth_drift_flags(jumps, agreement, both, fps, partners=partners, partner_ratio=0.6)[:, 0].any()
    assert smooth_drift_flags(jumps, agreement, both, fps)[:, 0].any()  # not asked without partners
    unpaired = consistency.copy()
    unpaired[30:70, 2] = 1.6  # an unpaired joint (its own partner) at that level changes nothing
    assert smooth_drift_flags(jumps, agreement, unpaired, fps, partners=partners)[:, 0].any()
    nan = both.copy()
    nan[:, 1] = np.nan  # a partner not analysed is no evidence either way
    assert smooth_drift_flags(jumps, agreement, nan, fps, partners=partners)[:, 0].any()
    with pytest.raises(ValueError, match="partners"):
        smooth_drift_flags(jumps, agreement, consistency, fps, partners=partners[:3])
    with pytest.raises(ValueError, match="partner_ratio"):
        smooth_drift_flags(jumps, agreement, consistency, fps, partners=partners, partner_ratio=0.0)


def slow_chain_level(c, judged, parents):
    """Reference: cell by cell, the largest finite value among the joint's judged parent and children."""
    F, J = c.shape
    out = np.full((F, J), -np.inf)
    for f in range(F):
        for j in range(J):
            kin = [k for k in range(J) if k == parents[j] or parents[k] == j]
            vals = [c[f, k] for k in kin if judged[f, k] and np.isfinite(c[f, k])]
            if vals:
                out[f, j] = max(vals)
    return out


def test_chain_level_is_the_largest_of_the_judged_parent_and_children():
    rng = np.random.default_rng(7)
    parents = np.array([-1, 0, 1, 2, 1, 4, 0])  # a root, a chain 1-2-3, a branch 1-4-5, a leaf 6 on the root
    c = rng.uniform(0, 6, size=(30, 7))
    c[rng.uniform(size=c.shape) < 0.1] = np.nan
    judged = rng.uniform(size=c.shape) < 0.8
    judged[:, 0] = False  # the root carries no evidence (as agreement is NaN there)
    got = chain_level(c, judged, parents)
    assert np.array_equal(got, slow_chain_level(c, judged, parents))
    assert np.isneginf(chain_level(c, judged, np.full(7, -1))).all()  # no chains: no kin
    with pytest.raises(ValueError, match="parents"):
        chain_level(c, judged, parents[:3])


def test_smooth_drift_flags_a_joint_whose_parent_or_child_digresses_too_is_a_style():
    """Joint 1 the parent of joint 0, joint 2 its child: joint 0's excursion is a drift while the chain stays among
    its neighbours, and no evidence where its parent or child digresses by chain_ratio * z_min or more (a style
    bends a chain; a drift turns one joint)."""
    jumps, agreement, consistency, fps = drift_case(J=4)
    parents = np.array([1, -1, 0, 1])
    assert smooth_drift_flags(jumps, agreement, consistency, fps, parents=parents)[:, 0].any()
    for kin in (1, 2):
        bent = consistency.copy()
        bent[30:70, kin] = 1.6  # the parent (or the child) at 0.53 z_min over the whole excursion
        assert not smooth_drift_flags(jumps, agreement, bent, fps, parents=parents, chain_ratio=0.5).any()
        assert smooth_drift_flags(jumps, agreement, bent, fps, parents=parents, chain_ratio=0.6)[:, 0].any()
        assert smooth_drift_flags(jumps, agreement, bent, fps)[:, 0].any()  # not asked without parents
        unjudged = agreement.copy()
        unjudged[:, kin] = np.nan  # a joint with no evidence (the root, the pelvis) is no evidence either way
        assert smooth_drift_flags(jumps, unjudged, bent, fps, parents=parents)[:, 0].any()
    sibling = consistency.copy()
    sibling[30:70, 3] = 1.6  # a sibling (joint 3 on the parent too) is no kin
    assert smooth_drift_flags(jumps, agreement, sibling, fps, parents=parents)[:, 0].any()
    with pytest.raises(ValueError, match="chain_ratio"):
        smooth_drift_flags(jumps, agreement, consistency, fps, parents=parents, chain_ratio=1.5)


def test_smooth_drift_flags_a_run_cut_by_the_take_must_show_the_joint_leave_or_come_back():
    jumps, agreement, consistency, fps = drift_case()
    bump = consistency[30:70, 0].copy()
    # the take starts at the peak of the excursion (a pose held from before the take): not a drift
    held = consistency.copy()
    held[:, 0] = 0.5
    held[:30, 0] = bump[10:]  # 4.4 at the first frame, the peak 9 frames later
    assert not smooth_drift_flags(jumps, agreement, held, fps, min_s=0.2).any()
    assert smooth_drift_flags(jumps, agreement, held, fps, min_s=0.2, return_ratio=1.0)[:, 0].any()
    # the take starts inside the excursion but before its peak: the joint is seen leaving, flagged
    rising = consistency.copy()
    rising[:, 0] = 0.5
    rising[:39, 0] = bump[1:]
    assert 0.5 < rising[0, 0] <= 0.3 * bump.max()
    assert np.flatnonzero(smooth_drift_flags(jumps, agreement, rising, fps)[:, 0]).tolist() == list(range(39))
    assert not smooth_drift_flags(jumps, agreement, rising, fps, return_ratio=0.25).any()
    # the same at the take's end
    end = consistency.copy()
    end[:, 0] = 0.5
    end[-30:, 0] = bump[:30]
    assert not smooth_drift_flags(jumps, agreement, end, fps, min_s=0.2).any()
    assert smooth_drift_flags(jumps, agreement, end, fps, min_s=0.2, return_ratio=1.0)[:, 0].any()
    with pytest.raises(ValueError, match="return_ratio"):
        smooth_drift_flags(jumps, agreement, consistency, fps, return_ratio=0.0)


def slow_excursions(c, r):
    """Reference: recursive cuts at the deepest valley left of the peak, else right of it."""
    def rec(a, b):
        p = a + int(np.argmax(c[a:b]))
        left = [(c[v], v) for v in range(a + 1, p)]
        if left:
            v = min(left)[1]
            if c[v] <= r * min(c[p], max(c[a:v])):
                return rec(a, v + 1) + rec(v, b)
        right = [(c[v], v) for v in range(p + 1, b - 1)]
        if right:
            v = min(right)[1]
            if c[v] <= r * min(c[p], max(c[v + 1 : b])):
                return rec(a, v + 1) + rec(v, b)
        return [(a, b)]
    return rec(0, len(c))


def test_excursions_cut_where_the_joint_comes_back_between_two_peaks():
    bump = np.sin(np.linspace(0, np.pi, 12)[1:-1])  # ten frames up and down
    two = np.concatenate([6 * bump, [0.6], 4 * bump])
    assert excursions(two, 0.3) == [(0, 11), (10, 21)]  # 0.6 <= 0.3 * 4: back among the neighbours in between
    assert excursions(two, 0.1) == [(0, 21)]  # 0.6 > 0.1 * 4: one excursion with a dip
    three = np.concatenate([two, [0.5], 5 * bump])
    assert excursions(three, 0.3) == [(0, 11), (10, 22), (21, 32)]
    rng = np.random.default_rng(1)
    for _ in range(200):
        c = rng.uniform(0.5, 8.0, size=int(rng.integers(1, 40)))
        for r in (0.2, 0.3, 0.6, 1.0):
            got = excursions(c, r)
            assert got == sorted(slow_excursions(c, r))
            assert got[0][0] == 0 and got[-1][1] == len(c)
            assert all(b0 - 1 == a1 for (_, b0), (a1, _) in zip(got, got[1:]))  # consecutive, sharing the valley
    with pytest.raises(ValueError, match="return_ratio"):
        excursions(two, 0.0)


def test_smooth_drift_flags_judge_each_excursion_of_a_run_alone():
    jumps, agreement, consistency, fps = drift_case(F=160)
    bump = consistency[30:70, 0].copy()
    # a style digression next to the drift, with the joint back among its neighbours (z 1) between them, and the
    # rest of the body far from its neighbours there: the drift alone is flagged
    consistency[70:72, 0] = 1.0
    consistency[72:112, 0] = bump
    agreement[72:112] = np.radians(8.0)
    flags = smooth_drift_flags(jumps, agreement, consistency, fps)
    assert np.flatnonzero(flags[:, 0]).tolist() == list(range(30, 71))
    assert np.flatnonzero(smooth_drift_flags(jumps, agreement, consistency, fps, return_ratio=1.0)[:, 0]).tolist() == list(range(30, 112))


def slow_offset_change(r, scale):
    """Reference: per joint, the component-wise median offset over its judged frames, then frame by frame."""
    F, J, _ = r.shape
    out = np.full((F, J), np.nan)
    for j in range(J):
        rows = [f for f in range(F) if np.isfinite(r[f, j]).all() and np.isfinite(scale[f, j]) and scale[f, j] > 0]
        if not rows:
            continue
        m = np.array([np.median([r[f, j, c] for f in rows]) for c in range(3)])
        for f in rows:
            out[f, j] = np.sqrt(np.sum((r[f, j] - m) ** 2)) / scale[f, j]
    return out


def gappy_offsets(seed: int, F: int, J: int):
    """Random offsets (F, J, 3) and scales (F, J), a tenth of the offsets and a twentieth of the scales NaN."""
    rng = np.random.default_rng(seed)
    r = rng.normal(0, 0.2, size=(F, J, 3))
    scale = rng.uniform(0.05, 0.2, size=(F, J))
    r[rng.uniform(size=(F, J)) < 0.1] = np.nan
    scale[rng.uniform(size=(F, J)) < 0.05] = np.nan
    return r, scale


def test_offset_change_is_the_offset_less_the_one_held_over_the_take():
    F, J = 60, 4
    r, scale = gappy_offsets(4, F, J)
    scale[3, 1] = 0.0
    r[:, 3] = np.nan  # a joint never judged
    got = ssa.offset_change(r, scale)
    assert np.allclose(got, slow_offset_change(r, scale), equal_nan=True)
    assert np.isnan(got[3, 1]) and np.isnan(got[:, 3]).all()
    # a style: the same turn at every frame changes nothing; a drift over it changes by its own size
    held = np.tile([0.3, -0.1, 0.2], (F, 1, 1))
    bump = held.copy()
    bump[20:35, 0] += [0.0, 0.5, 0.0]
    one = np.full((F, 1), 0.1)
    assert np.allclose(ssa.offset_change(held, one), 0.0)
    assert np.allclose(ssa.offset_change(bump, one)[20:35, 0], 5.0)
    assert np.allclose(np.delete(ssa.offset_change(bump, one)[:, 0], np.arange(20, 35)), 0.0)
    with pytest.raises(ValueError, match="offsets"):
        ssa.offset_change(r[..., :2], scale)



def test_group_offset_change_takes_the_held_offset_in_each_group_against_its_own_mean():
    """A joint held off each group's mean by that group's own constant turn changes nothing, whichever group judges
    a frame; a drift over it changes by its own size in every group. The median of whichever group's offsets was
    best at each frame (the offset read before) mixes the groups' turns and sees a change where the best group
    switches (on the Bandai Namco rig, once an ``upper`` group judged the arms: a style flagged as a drift)."""
    F = 60
    held = np.stack([np.tile([0.3, 0.0, 0.0], (F, 1, 1)), np.tile([0.0, 0.3, 0.0], (F, 1, 1))])  # (G, F, 1, 3)
    scale = np.full((2, F, 1), 0.1)
    best = np.where((np.arange(F) // 10) % 3 == 1, 1, 0)[:, None]  # group 1 judges a third of the frames
    assert np.allclose(group_offset_change(held, scale, best), 0.0)
    mixed = ssa.offset_change(np.take_along_axis(held, best[None, :, :, None], axis=0)[0], scale[0])
    assert mixed[best == 1].min() > 4.0  # the pooled median: 0.42 rad off at every frame group 1 judges
    bump = held.copy()
    bump[:, 25:30, 0] += [0.0, 0.0, 0.5]
    got = group_offset_change(bump, scale, best)
    assert np.allclose(got[25:30, 0], 5.0) and np.allclose(np.delete(got[:, 0], np.arange(25, 30)), 0.0)
    nan = held.copy()
    nan[1, :, 0] = np.nan  # a group that does not hold the joint
    assert np.isnan(group_offset_change(nan, scale, best)[best == 1]).all()
    with pytest.raises(ValueError, match="best"):
        group_offset_change(held, scale, best[:-1])

def test_detect_a_joint_held_off_its_neighbours_for_most_of_the_take_is_a_style_not_a_drift(walk):
    """The walk with one elbow carried 30 deg off from 1.5 s to 1.5 s before the end (eased in and out over
    0.5 s), against its twin: the rule reading the angle alone calls it a drift; with the joint's change from
    the offset it holds (the default) it is the performer's carriage."""
    twin = twin_of(walk)
    j = walk.skeleton.index("LeftElbow")
    F, fps = walk.num_frames, walk.fps
    t = np.arange(F) / fps
    ease = np.clip(np.minimum(t - 1.0, t[-1] - 1.0 - t) / 0.5, 0.0, 1.0)
    w = 0.5 - 0.5 * np.cos(np.pi * ease)  # 0 at the ends, 1 from 1.5 s to 1.5 s before the end
    q = np.array(walk.rotations, dtype=np.float64)
    turn = R.quaternion_from_axis_angle(np.tile([1.0, 0.0, 0.0], (F, 1)), np.radians(30.0) * w)
    q[:, j] = R.quaternion_multiply(turn, q[:, j])
    styled = dataclasses.replace(walk, rotations=q, name="styled")
    det = ssa.detect(styled, [twin], drift=True)
    held = w == 1.0
    assert det.change is not None and np.nanmax(det.change[held, j]) < 1.0 < np.nanmin(det.consistency[held, j])
    assert not det.drifts().any()
    assert dataclasses.replace(det, change=None).drifts()[:, j].any()  # the angle alone calls the carriage a drift
    assert ssa.detect(styled, [twin], drift=True, drift_change=False).drifts()[:, j].any()
    assert ssa.detect(styled, [twin]).change is None  # only the drift rule reads it


def test_detect_the_drift_evidence_is_the_change_alone(walk, drifted, tmp_path):
    """A drift that turns a joint back across the offset its style holds brings it near its neighbours' mean at
    the drift's height: the angle ratio (``consistency``) falls there while the change from the held offset does
    not. The evidence is the change alone: the angle ratio no longer caps it."""
    bad, mask, _ = drifted
    det = ssa.detect(bad, [twin_of(walk)], drift=True)
    assert det.drifts().any()
    near = dataclasses.replace(det, consistency=np.where(np.isfinite(det.consistency), 0.0, np.nan))
    assert np.array_equal(near.drifts(), det.drifts())
    # without the change the angle ratio is the evidence, and a joint on its neighbours' mean shows none
    assert not dataclasses.replace(near, params=near.params.replace(drift_change=False)).drifts().any()
    back = ssa.Detection.load(det.save(tmp_path / "d.npz"))  # the chains' parents travel with the file
    assert det.parents is not None and np.array_equal(back.parents, det.parents)


def test_offset_turn_is_the_change_whose_length_offset_change_gives():
    F, J = 50, 3
    r, scale = gappy_offsets(5, F, J)
    scale[2, 1] = 0.0
    turn = offset_turn(r, scale)
    assert turn.shape == (F, J, 3)
    assert np.array_equal(np.linalg.norm(turn, axis=2) / scale, ssa.offset_change(r, scale), equal_nan=True)
    assert np.isnan(turn[2, 1]).all()
    held = np.stack([np.tile([0.3, 0.0, 0.0], (F, 1, 1)), np.tile([0.0, 0.3, 0.0], (F, 1, 1))])  # (G, F, 1, 3)
    held[:, 20:25, 0] += [0.0, 0.0, 0.5]
    best = np.where(np.arange(F) % 2 == 0, 0, 1)[:, None]
    got = group_offset_turn(held, np.full((2, F, 1), 0.1), best)
    assert got.shape == (F, 1, 3) and np.allclose(got[20:25, 0], [0.0, 0.0, 0.5]) and np.allclose(got[:20], 0.0)
    assert np.isnan(group_offset_turn(held, np.full((2, F, 1), 0.1), np.full((F, 1), -1))).all()


def pair_case():
    """Joints 0 and 1 a left/right pair, both in one excursion at once (each stops the other's evidence), and
    their changes' directions: ``turns`` (F, 4, 3) to be filled."""
    jumps, agreement, consistency, fps = drift_case(J=4)
    consistency[30:70, 1] = consistency[30:70, 0]
    return jumps, agreement, consistency, fps, np.array([1, 0, 2, 3]), np.zeros((100, 4, 3))


@pytest.mark.parametrize("axes, found", [(([1, 0, 0], [0, 1, 0]), True), (([1, 0, 0], [1, 0.1, 0]), False),
                                         (([1, 0, 0], [-1, 0, 0.1]), False)])
def test_smooth_drift_flags_two_partners_turned_about_crossed_axes_are_two_drifts(axes, found):
    """Both sides digressing at once stop each other at the partner gate (a two-sided style); turned about crossed
    axes they are two drifts and both are flagged, turned alike (or mirrored, the opposite way) a style."""
    jumps, agreement, consistency, fps, partners, turns = pair_case()
    assert not smooth_drift_flags(jumps, agreement, consistency, fps, partners=partners).any()
    turns[30:70, 0], turns[30:70, 1] = axes
    got = smooth_drift_flags(jumps, agreement, consistency, fps, partners=partners, turns=turns)
    assert got[30:70, :2].all() == found and not got[:, 2:].any() and not got[:30].any() and not got[70:].any()
    assert not smooth_drift_flags(jumps, agreement, consistency, fps, partners=partners, turns=turns,
                                  cross_cos=0.0).any()  # never crossed enough


def test_smooth_drift_flags_crossed_turns_need_both_joints_to_be_drift_candidates():
    """A joint stopped by a partner that is no drift candidate itself (the rest of the body far from its
    neighbours where the partner is judged, or the partner under z_min) is not freed by crossed turns."""
    jumps, agreement, consistency, fps, partners, turns = pair_case()
    turns[30:70, 0], turns[30:70, 1] = [1, 0, 0], [0, 1, 0]
    weak = consistency.copy()
    weak[30:70, 1] = np.minimum(weak[30:70, 1], 2.0)  # over partner_ratio * z_min, never z_min
    assert not smooth_drift_flags(jumps, agreement, weak, fps, partners=partners, turns=turns).any()
    with pytest.raises(ValueError, match="turns"):
        smooth_drift_flags(jumps, agreement, consistency, fps, partners=partners, turns=turns[:, :3])


def test_smooth_drift_flags_a_parent_and_child_turned_about_crossed_axes_are_two_drifts():
    jumps, agreement, consistency, fps = drift_case(J=4)
    parents = np.array([1, -1, 0, 1])
    consistency[30:70, 1] = consistency[30:70, 0]
    turns = np.zeros((100, 4, 3))
    turns[30:70, 0], turns[30:70, 1] = [0, 0, 1], [1, 0, 0]
    assert not smooth_drift_flags(jumps, agreement, consistency, fps, parents=parents).any()
    got = smooth_drift_flags(jumps, agreement, consistency, fps, parents=parents, turns=turns)
    assert got[30:70, :2].all() and not got[:, 2:].any()
    turns[30:70, 1] = [0, 0.2, 1]  # bent about one axis: a style
    assert not smooth_drift_flags(jumps, agreement, consistency, fps, parents=parents, turns=turns).any()


def test_crossed_turns_reads_the_highest_neighbour_and_the_turns_summed_over_the_excursion():
    F, J = 20, 3
    stopped = np.zeros((F, J), dtype=bool)
    stopped[5:15, 0] = stopped[5:15, 1] = True
    level = np.zeros((F, J))
    level[5:15, 1], level[5:15, 2] = 4.0, 2.0
    turns = np.zeros((F, J, 3))
    turns[5:15, 0], turns[5:15, 1], turns[5:15, 2] = [1, 0, 0], [0, 1, 0], [1, 0, 0]
    neighbours = [[1, 2], [0], []]
    got = crossed_turns(stopped, np.zeros_like(stopped), turns, level, neighbours)
    assert got[5:15, 0].all() and got[5:15, 1].all() and not got[:, 2].any()
    level[5:15, 2] = 5.0  # joint 2 (turned alike, not stopped or flagged) now the one that stops joint 0
    assert not crossed_turns(stopped, np.zeros_like(stopped), turns, level, neighbours)[:, 0].any()
    flagged = np.zeros_like(stopped)
    flagged[10, 2] = True
    turns[5:15, 2] = [0, 0, 1]
    assert crossed_turns(stopped, flagged, turns, level, neighbours)[5:15, 0].all()
    turns[5:10, 0] = [0, 0, 1]  # half the excursion turned about joint 2's axis: summed, cos 0.5
    assert not crossed_turns(stopped, flagged, turns, level, neighbours)[:, 0].any()


@pytest.mark.parametrize("joints", [("LeftKnee", "RightKnee"), ("LeftShoulder", "LeftElbow")])
def test_detect_finds_two_drifts_at_once_on_a_left_right_pair_or_a_chain(walk, joints, tmp_path):
    """The CMU walk 131_01 with two 35 deg drifts that overlap in time on both knees (a left/right pair) or on the
    left shoulder and elbow (a parent and its child), against the walk's twin: each joint's digression stops the
    other's at the partner or chain gate, and the two turn about crossed axes, so both are flagged; with
    ``drift_cross_cos`` None neither is."""
    bad, mask, records = corrupt.smooth_drifts(walk, n_drifts=2, peak_deg=35.0, duration_s=(1.0, 1.0), seed=29,
                                               joints=list(joints))
    assert {r.joint for r in records} == set(joints)
    a, b = records
    assert a.start < b.end and b.start < a.end  # at once
    det = ssa.detect(bad, [twin_of(walk)], drift=True)
    js = [walk.skeleton.index(r.joint) for r in records]
    off = dataclasses.replace(det, params=det.params.replace(drift_cross_cos=None))
    assert not off.drifts()[:, js].any()
    got = det.drifts()
    for r, j in zip(records, js):
        assert got[r.start:r.end, j].mean() > 0.7 and not got[:r.start, j].any() and not got[r.end:, j].any()
    assert not np.delete(got, js, axis=1).any()
    assert det.turn.shape == bad.rotations.shape[:2] + (3,)
    back = ssa.Detection.load(det.save(tmp_path / "d.npz"))
    assert np.array_equal(back.turn, det.turn, equal_nan=True) and np.array_equal(back.drifts(), got)
    assert not dataclasses.replace(back, turn=None).drifts()[:, js].any()  # saved before: the rule as it was
