"""Tests of mocapkit.cleaning.ik: two-bone IK, FABRIK, foot contacts and foot-skate cleanup on real clips."""

from __future__ import annotations

import dataclasses
from functools import lru_cache

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import mocapkit
from mocapkit import rotations as R
from mocapkit.cleaning import ik
from mocapkit.cleaning.ik import contact_segments, fabrik, foot_contacts, foot_skate_cleanup, reach, two_bone_ik
from mocapkit.errors import SkeletonError
from mocapkit.motion import find_joint, unit_scale_cm

CLIPS = ("12_walk.amc", "131_01.bvh")
LIMBS = ("left_foot", "right_foot", "left_hand", "right_hand")


@lru_cache(maxsize=None)
def clip(name: str) -> mocapkit.Motion:
    return mocapkit.load(mocapkit.samples.path(name))


def chain_of(m, role):
    e = find_joint(m.skeleton, role)
    p = int(m.skeleton.parents[e])
    return int(m.skeleton.parents[p]), p, e


def perturb(m, joints, scale, seed, frames=None):
    """The motion with random extra rotations (rotation vectors ~ N(0, scale) rad) on ``joints``."""
    rng = np.random.default_rng(seed)
    rot = np.array(m.rotations)
    fr = np.arange(m.num_frames) if frames is None else frames
    for j in joints:
        extra = R.rotvec_to_quaternion(rng.normal(scale=scale, size=(len(fr), 3)))
        rot[fr, j] = R.quaternion_multiply(rot[fr, j], extra)
    return dataclasses.replace(m, rotations=rot)


def bone_lengths(m):
    pos = m.global_positions()
    par = m.skeleton.parents
    return np.linalg.norm(pos[:, 1:] - pos[:, par[1:]], axis=-1)


def assert_only_changed(before, after, joints, frames=None):
    """Every rotation outside ``joints`` x ``frames`` bit-identical; positions and skeleton untouched."""
    changed = np.zeros(before.rotations.shape[:2], dtype=bool)
    rows = np.arange(before.num_frames) if frames is None else frames
    changed[np.ix_(rows, list(joints))] = True
    assert np.array_equal(after.rotations[~changed], before.rotations[~changed])
    assert np.array_equal(after.root_positions, before.root_positions)
    assert after.skeleton is before.skeleton and after.fps == before.fps


# -- two-bone IK ----------------------------------------------------------------------------------


@settings(max_examples=30, deadline=None)
@given(
    name=st.sampled_from(CLIPS),
    role=st.sampled_from(LIMBS),
    start=st.integers(0, 280),
    scale=st.floats(0.05, 1.2),
    seed=st.integers(0, 2**32 - 1),
)
def test_two_bone_reaches_targets_from_perturbed_poses(name, role, start, scale, seed):
    m = clip(name)[start : start + 60]
    a, b, c = chain_of(m, role)
    target = perturb(m, (a, b), scale, seed).global_positions()[:, c]  # reachable by construction
    out = two_bone_ik(m, role, target)
    pos, pos0 = out.global_positions(), m.global_positions()
    limb = np.linalg.norm(pos0[:, b] - pos0[:, a], axis=1) + np.linalg.norm(pos0[:, c] - pos0[:, b], axis=1)
    assert np.all(np.linalg.norm(pos[:, c] - target, axis=1) < 1e-6 * limb)
    np.testing.assert_allclose(bone_lengths(out), bone_lengths(m), rtol=0, atol=1e-9 * limb.max())
    assert_only_changed(m, out, (a, b))
    assert np.all(np.isfinite(out.rotations))
    np.testing.assert_allclose(np.linalg.norm(out.rotations, axis=-1), 1.0, atol=1e-12)


def test_two_bone_changes_only_selected_frames():
    m = clip("12_walk.amc")
    a, b, c = chain_of(m, "left_foot")
    target = perturb(m, (a, b), 0.4, 1).global_positions()[:, c]
    frames = np.array([3, 50, 51, 200, 342])
    out = two_bone_ik(m, "lfoot", target, frames=frames)
    assert_only_changed(m, out, (a, b), frames)
    np.testing.assert_allclose(out.global_positions()[frames, c], target[frames], atol=1e-9)
    # (n, 3) targets in frame order and a boolean mask give the same result, bit for bit
    mask = np.zeros(m.num_frames, dtype=bool)
    mask[frames] = True
    same = two_bone_ik(m, c, target[frames], frames=mask)
    assert np.array_equal(same.rotations, out.rotations)


def test_two_bone_out_of_reach_gives_a_straight_limb_pointing_at_the_target():
    m = clip("131_01.bvh")[::4]
    for role in ("left_foot", "right_hand"):
        a, b, c = chain_of(m, role)
        pos0 = m.global_positions()
        l_ab = np.linalg.norm(pos0[:, b] - pos0[:, a], axis=1)
        l_bc = np.linalg.norm(pos0[:, c] - pos0[:, b], axis=1)
        rng = np.random.default_rng(7)
        dirs = rng.normal(size=(m.num_frames, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        far = pos0[:, a] + dirs * ((l_ab + l_bc) * rng.uniform(1.01, 3.0, m.num_frames))[:, None]
        out = two_bone_ik(m, role, far)
        pos = out.global_positions()
        assert np.all(np.isfinite(pos))
        ac = pos[:, c] - pos[:, a]
        np.testing.assert_allclose(np.linalg.norm(ac, axis=1), l_ab + l_bc, rtol=1e-12)  # fully extended
        np.testing.assert_allclose(ac / np.linalg.norm(ac, axis=1, keepdims=True), dirs, atol=1e-9)
        knee_off_line = np.linalg.norm(np.cross(pos[:, b] - pos[:, a], ac / (l_ab + l_bc)[:, None]), axis=1)
        assert knee_off_line.max() < 1e-9 * (l_ab + l_bc).max()
        # a target at the hip (too near) folds the limb as far as it goes, without NaN
        folded = two_bone_ik(m, role, pos0[:, a])
        pf = folded.global_positions()
        assert np.all(np.isfinite(folded.rotations))
        np.testing.assert_allclose(np.linalg.norm(pf[:, c] - pf[:, a], axis=1), np.abs(l_ab - l_bc), atol=1e-9)


@settings(max_examples=25, deadline=None)
@given(start=st.integers(0, 330), offset=st.tuples(*[st.floats(-0.6, 0.6)] * 3))
def test_two_bone_keeps_the_knee_on_its_side(start, offset):
    """Without a pole the bend plane is kept: the knee folds the way it did (same side in the thigh frame)."""
    m = clip("12_walk.amc")[start : start + 12]
    a, b, c = chain_of(m, "right_foot")
    pos0 = m.global_positions()
    target = pos0[:, c] + np.asarray(offset)  # up to ~6 cm away along each axis
    out = two_bone_ik(m, "right_foot", target)

    def bend_normal(mm):
        grot, pos = mm.global_transforms()
        n = np.cross(pos[:, c] - pos[:, a], pos[:, b] - pos[:, a])
        return R.quaternion_rotate(R.quaternion_conjugate(grot[:, a]), n)  # in the thigh's frame

    limb = np.linalg.norm(pos0[:, b] - pos0[:, a], axis=1) + np.linalg.norm(pos0[:, c] - pos0[:, b], axis=1)
    bent = np.linalg.norm(target - pos0[:, a], axis=1) < 0.999 * limb  # out of reach -> straight, no side
    n0, n1 = bend_normal(m), bend_normal(out)
    assert np.all(np.sum(n0 * n1, axis=1)[bent] > 0)


def test_two_bone_pole_puts_the_knee_in_the_pole_plane():
    m = clip("12_walk.amc")[100:160]
    a, b, c = chain_of(m, "left_foot")
    pos0 = m.global_positions()
    target = pos0[:, c] + [0.3, 0.4, -0.2]
    rng = np.random.default_rng(3)
    pole = pos0[:, b] + rng.normal(scale=5.0, size=(m.num_frames, 3))
    out = two_bone_ik(m, "left_foot", target, pole=pole)
    pos = out.global_positions()
    np.testing.assert_allclose(pos[:, c], target, atol=1e-9)
    at = target - pos[:, a]
    normal = np.cross(at, pole - pos[:, a])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    assert np.abs(np.sum((pos[:, b] - pos[:, a]) * normal, axis=1)).max() < 1e-9
    d = at / np.linalg.norm(at, axis=1, keepdims=True)
    proj = lambda v: v - np.sum(v * d, axis=1, keepdims=True) * d
    assert np.all(np.sum(proj(pos[:, b] - pos[:, a]) * proj(pole - pos[:, a]), axis=1) > 0)


def test_two_bone_straight_limb_folds_the_way_the_clip_bends():
    """From an exactly straight leg the bend axis comes from the clip's usual hinge, not from jitter."""
    m = clip("12_walk.amc")
    a, b, c = chain_of(m, "left_foot")
    pos0 = m.global_positions()
    even = np.arange(0, m.num_frames, 2)
    straight = two_bone_ik(m, "left_foot", pos0[:, a] + 3.0 * (pos0[:, c] - pos0[:, a]), frames=even)
    ps = straight.global_positions()
    assert np.abs(np.cross(ps[even, b] - ps[even, a], ps[even, c] - ps[even, a])).max() < 1e-9
    out = two_bone_ik(straight, "left_foot", pos0[:, c], frames=even)
    np.testing.assert_allclose(out.global_positions()[:, c], pos0[:, c], atol=1e-9)
    # the knee comes back near where it was: forward, in about the plane it bent in
    knee_err = np.linalg.norm(out.global_positions()[even, b] - pos0[even, b], axis=1)
    thigh = np.linalg.norm(pos0[even, b] - pos0[even, a], axis=1)
    assert np.median(knee_err / thigh) < 0.05 and np.all(knee_err / thigh < 0.3)
    # with no bent frame to learn from, it still solves (any perpendicular bend) without NaN
    all_straight = two_bone_ik(m, "left_foot", pos0[:, a] + 3.0 * (pos0[:, c] - pos0[:, a]))
    again = two_bone_ik(all_straight, "left_foot", pos0[:, c])
    np.testing.assert_allclose(again.global_positions()[:, c], pos0[:, c], atol=1e-9)


def test_two_bone_uses_animated_offsets():
    """With per-frame translations (stretched shins) the solver uses the animated bone lengths."""
    m = clip("131_01.bvh")[200:260]
    a, b, c = chain_of(m, "left_foot")
    tr = m.local_offsets()
    tr[:, c] *= np.linspace(1.0, 1.2, m.num_frames)[:, None]
    m2 = dataclasses.replace(m, translations=tr)
    target = perturb(m2, (a, b), 0.5, 11).global_positions()[:, c]
    out = two_bone_ik(m2, "left_foot", target)
    np.testing.assert_allclose(out.global_positions()[:, c], target, atol=1e-9)
    assert np.array_equal(out.translations, m2.translations)


def test_two_bone_nan_targets_leave_their_frames_alone():
    m = clip("12_walk.amc")[:30]
    a, b, c = chain_of(m, "left_foot")
    target = m.global_positions()[:, c] + [0.0, 0.5, 0.0]
    target[[4, 9]] = np.nan
    out = two_bone_ik(m, "left_foot", target)
    assert np.array_equal(out.rotations[[4, 9]], m.rotations[[4, 9]])
    keep = np.setdiff1d(np.arange(30), [4, 9])
    np.testing.assert_allclose(out.global_positions()[keep, c], target[keep], atol=1e-9)


def test_two_bone_rejects_bad_input():
    m = clip("12_walk.amc")[:10]
    ok = m.global_positions()[:, 4]
    with pytest.raises(SkeletonError, match="grandparent"):
        two_bone_ik(m, "lhipjoint", ok)  # parent is the root: no grandparent
    with pytest.raises(SkeletonError, match="no joint or role"):
        two_bone_ik(m, "tail", ok)
    with pytest.raises(ValueError, match="targets"):
        two_bone_ik(m, "lfoot", ok[:, :2])
    with pytest.raises(ValueError, match="frames"):
        two_bone_ik(m, "lfoot", ok, frames=[1, 1])
    with pytest.raises(ValueError, match="frames"):
        two_bone_ik(m, "lfoot", ok, frames=np.ones(5, dtype=bool))


# -- FABRIK -----------------------------------------------------------------------------------------


@settings(max_examples=15, deadline=None)
@given(
    side=st.sampled_from(["l", "r"]),
    start=st.integers(0, 280),
    scale=st.floats(0.05, 0.5),
    seed=st.integers(0, 2**32 - 1),
)
@example(side="l", start=15, scale=0.34375, seed=1010)  # slow: 1.7e-3 from the target after 50 passes, 9.9e-4 after 100
def test_fabrik_converges_on_spine_to_wrist(side, start, scale, seed):
    m = clip("12_walk.amc")[start : start + 60]
    sk = m.skeleton
    chain = ["lowerback", f"{side}wrist"]  # the joints in between are filled in
    js = ik._resolve_chain(sk, chain)
    names = [sk.joint_names[j] for j in js]
    assert names == ["lowerback", "upperback", "thorax"] + [f"{side}{b}" for b in ("clavicle", "humerus", "radius", "wrist")]
    target = perturb(m, js[:-1], scale, seed).global_positions()[:, js[-1]]
    # the test asks for convergence, not its speed: FABRIK can need more than 50 passes (the example above)
    out = fabrik(m, chain, target, iterations=200, tolerance=1e-3)
    err = np.linalg.norm(out.global_positions()[:, js[-1]] - target, axis=1)
    assert err.max() <= 1e-3 * (1 + 1e-9)
    np.testing.assert_allclose(bone_lengths(out), bone_lengths(m), rtol=0, atol=1e-9)
    assert_only_changed(m, out, js[:-1])


def test_fabrik_default_iterations_reach_within_tolerance_and_out_of_reach_is_straight():
    m = clip("131_01.bvh")[::3]
    sk = m.skeleton
    js = ik._resolve_chain(sk, ["Chest", "RightWrist"])
    target = perturb(m, js[:-1], 0.3, 5).global_positions()[:, js[-1]]
    # FABRIK converges slowly for targets near full extension: the default 20 passes do 99 % of the
    # frames, 100 passes all of them
    err = np.linalg.norm(fabrik(m, ["Chest", "RightWrist"], target).global_positions()[:, js[-1]] - target, axis=1)
    assert np.mean(err <= 1e-3 * (1 + 1e-9)) > 0.98
    out = fabrik(m, ["Chest", "RightWrist"], target, iterations=100)
    assert np.linalg.norm(out.global_positions()[:, js[-1]] - target, axis=1).max() <= 1e-3 * (1 + 1e-9)
    # out of reach: a straight chain pointing at the target
    pos0 = m.global_positions()
    total = np.linalg.norm(pos0[:, js[1:]] - pos0[:, js[:-1]], axis=-1).sum(axis=1)
    d = np.array([0.6, 0.0, 0.8])
    far = fabrik(m, ["Chest", "RightWrist"], pos0[:, js[0]] + 2.0 * total[:, None] * d)
    pf = far.global_positions()
    bones = pf[:, js[1:]] - pf[:, js[:-1]]
    lengths = np.linalg.norm(bones, axis=-1)
    real = lengths > 1e-12  # 131_01 has zero-length bones (a joint on top of its parent)
    assert np.all(np.abs(bones[real] / lengths[real, None] - d) < 1e-9)
    np.testing.assert_allclose(bone_lengths(far), bone_lengths(m), atol=1e-9)


def test_fabrik_frames_and_errors():
    m = clip("12_walk.amc")[:40]
    js = ik._resolve_chain(m.skeleton, ["lhumerus", "lwrist"])
    target = perturb(m, js[:-1], 0.3, 2).global_positions()[:, js[-1]]
    frames = np.arange(0, 40, 3)
    out = fabrik(m, js, target, frames=frames)
    assert_only_changed(m, out, js[:-1], frames)
    with pytest.raises(SkeletonError, match="ancestor"):
        fabrik(m, ["lwrist", "lhumerus"], target)
    with pytest.raises(ValueError, match="at least two"):
        fabrik(m, ["lwrist"], target)


def test_reach_dispatches():
    m = clip("12_walk.amc")[:40]
    a, b, c = chain_of(m, "right_hand")
    target = perturb(m, (a, b), 0.4, 9).global_positions()[:, c]
    assert np.array_equal(reach(m, "right_hand", target).rotations, two_bone_ik(m, "right_hand", target).rotations)
    out = reach(m, "right_hand", target, method="fabrik", chain_length=3, iterations=100, tolerance=1e-4)
    err = np.linalg.norm(out.global_positions()[:, c] - target, axis=1)
    assert np.median(err) < 1e-4 and err.max() < 1e-2  # one target sits at 99.9 % of the arm's reach
    assert_only_changed(m, out, (a, b))
    with pytest.raises(ValueError, match="method"):
        reach(m, "right_hand", target, method="ccd")


# -- foot contacts ----------------------------------------------------------------------------------


def test_foot_contacts_on_a_walk_alternate():
    m = clip("12_walk.amc")
    c = foot_contacts(m)
    assert c.shape == (m.num_frames, 2) and c.dtype == bool
    frac = c.mean(axis=0)
    assert np.all((frac > 0.3) & (frac < 0.8)), frac
    segs = sorted((s, e, foot) for foot in (0, 1) for s, e in contact_segments(c[:, foot]))
    assert len(segs) >= 4
    assert all(x[2] != y[2] for x, y in zip(segs, segs[1:]))  # left, right, left, ...
    lengths = np.array([e - s for s, e, _ in segs]) / m.fps
    assert np.all((lengths > 0.3) & (lengths < 1.0)), lengths  # a walking stance, not jitter
    # during a plant the ankle barely moves; from one plant to the next of the same foot it strides
    ankle = m.global_positions()[:, find_joint(m.skeleton, "left_foot")] * unit_scale_cm(m.skeleton)
    plants = [np.median(ankle[s:e], axis=0) for s, e in contact_segments(c[:, 0])]
    for s, e in contact_segments(c[:, 0]):
        assert np.ptp(ankle[s:e], axis=0).max() < 15.0
    strides = np.linalg.norm(np.diff(plants, axis=0), axis=1)
    assert np.all((strides > 80.0) & (strides < 200.0)), strides


def test_foot_contacts_on_other_clips_and_units():
    m = clip("131_01.bvh")
    c = foot_contacts(m)
    frac = c.mean(axis=0)
    assert np.all((frac > 0.3) & (frac < 0.8)), frac
    assert 0.2 < np.median([e - s for s, e in contact_segments(c[:, 0])]) / m.fps < 1.5
    # the same motion in centimetres (stated unit) gives the same contacts
    cm = unit_scale_cm(m.skeleton)
    sk = dataclasses.replace(
        m.skeleton, offsets=m.skeleton.offsets * cm, end_site_offsets=m.skeleton.end_site_offsets * cm, unit_cm=1.0
    )
    m_cm = dataclasses.replace(m, skeleton=sk, root_positions=m.root_positions * cm)
    assert np.array_equal(foot_contacts(m_cm), c)
    # flat-foot contacts (toes too) are a subset of the ankle plants
    flat = foot_contacts(m, toes=True)
    assert flat.sum() <= c.sum() and flat.sum() > 0.5 * c.sum()


# -- foot-skate cleanup -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name,side,window,factor",
    [
        ("12_walk.amc", "left", (152, 180), 1e6),
        ("131_01.bvh", "right", (250, 275), 1e6),
        # late in this plant the hip has moved on: the plant is beyond the leg's reach, the leg straightens
        ("12_walk.amc", "right", (86, 124), 10),
    ],
)
def test_foot_skate_cleanup_pins_an_injected_slide(name, side, window, factor):
    m = clip(name)
    sk = m.skeleton
    hip, ankle, toe = (find_joint(sk, f"{side}_{r}") for r in ("hip", "foot", "toe"))
    contacts = foot_contacts(m)
    col = 0 if side == "left" else 1
    s, e = window
    assert contacts[s - 13 : e + 13, col].all()  # the window lies inside a plant, past the blend ramps
    # the slide: the femur turns up to 8 degrees and back within the window
    f = np.arange(s, e)
    bump = np.radians(8.0) * np.sin(np.pi * (f - s + 0.5) / (e - s)) ** 2
    rot = np.array(m.rotations)
    rot[s:e, hip] = R.quaternion_multiply(rot[s:e, hip], R.quaternion_from_axis_angle([1.0, 0.0, 0.3], bump))
    bad = dataclasses.replace(m, rotations=rot)
    fixed = foot_skate_cleanup(bad, frames=f, contacts=contacts)

    P0, Pb, Pf = m.global_positions(), bad.global_positions(), fixed.global_positions()
    drift = lambda P: np.linalg.norm(P[s:e, ankle] - P[s, ankle], axis=1).max()
    assert drift(Pb) > 0.5  # a real slide: over 2.8 cm
    assert drift(Pf) < drift(Pb) / factor
    assert drift(Pf) < max(drift(P0), 1e-9) + 1e-6  # no worse than the clean clip's own creep
    # the toes follow (foot orientation kept) instead of swinging with the corrected shin
    toe_drift = lambda P: np.linalg.norm(P[s:e, toe] - P[s, toe], axis=1).max()
    assert toe_drift(Pf) < toe_drift(Pb) / 2
    # frames outside the window are bit-identical
    outside = np.setdiff1d(np.arange(m.num_frames), f)
    assert np.array_equal(fixed.rotations[outside], bad.rotations[outside])
    assert np.array_equal(fixed.root_positions, bad.root_positions)
    # inside, only the leg changed: hip, knee and ankle joints of that side
    leg = [hip, int(sk.parents[ankle]), ankle]
    others = np.setdiff1d(np.arange(sk.num_joints), leg)
    assert np.array_equal(fixed.rotations[:, others], bad.rotations[:, others])


def test_foot_skate_cleanup_on_whole_clips_is_smooth_and_leaves_swing_alone():
    for name in ("12_walk.amc", "HDM_bk_sneak2StepsLStart_004_120.amc"):
        m = clip(name)
        contacts = foot_contacts(m)
        out = foot_skate_cleanup(m, contacts=contacts)
        sk = m.skeleton
        # no pops: per-frame rotation steps grow by a few degrees at most
        step0 = np.degrees(R.geodesic_angle(m.rotations[1:], m.rotations[:-1]))
        step1 = np.degrees(R.geodesic_angle(out.rotations[1:], out.rotations[:-1]))
        assert (step1 - step0).max() < 5.0
        # frames where neither foot is planted are untouched
        free = ~contacts.any(axis=1)
        assert np.array_equal(out.rotations[free], m.rotations[free])
        # planted ankles move less than before, away from the ramps
        for col, role in enumerate(("left_foot", "right_foot")):
            j = find_joint(sk, role)
            for s, e in contact_segments(contacts[:, col]):
                if e - s < 40:
                    continue
                core = slice(s + 13, e - 13)
                ptp = lambda P: np.ptp(P[core, j], axis=0).max()
                assert ptp(out.global_positions()) <= ptp(m.global_positions()) + 1e-9


def test_foot_skate_cleanup_input_checks():
    m = clip("12_walk.amc")[:50]
    with pytest.raises(ValueError, match="contacts"):
        foot_skate_cleanup(m, contacts=np.zeros((49, 2), dtype=bool))
    none = foot_skate_cleanup(m, contacts=np.zeros((50, 2), dtype=bool))
    assert none is m
    with pytest.raises(ValueError, match="soft_reach"):
        foot_skate_cleanup(m, soft_reach=1.5)
    assert contact_segments(np.array([True, True, False, True])) == [(0, 2), (3, 4)]
