"""What the reconstruction methods share: per-clip database values, the output skeleton, eq. 4.3."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mocapkit
from mocapkit import rotations as R
from mocapkit import samples
from mocapkit.database import MotionDatabase
from mocapkit.features import virtual_markers
from mocapkit.motion import Motion
from mocapkit.reconstruct._common import (
    align_about_vertical,
    body_joints,
    body_motion,
    body_skeleton,
    database_positions,
    held_above,
    output_skeleton,
    whole_motion,
)

UP = np.array([0.0, 1.0, 0.0])


@settings(max_examples=25, deadline=None)
@given(
    theta=st.floats(-3.1, 3.1),
    tx=st.floats(-50, 50),
    tz=st.floats(-50, 50),
    seed=st.integers(0, 2**31 - 1),
)
def test_alignment_recovers_a_known_rotation_and_translation(theta, tx, tz, seed):
    rng = np.random.default_rng(seed)
    a = rng.normal(scale=10.0, size=(6, 3))
    b = R.quaternion_rotate(R.quaternion_from_axis_angle(UP, theta), a) + [tx, 0.0, tz]
    th, t = align_about_vertical(a, b, UP)
    assert abs(np.angle(np.exp(1j * (th - theta)))) < 1e-8
    assert np.allclose(t, [tx, 0.0, tz], atol=1e-7)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_alignment_is_optimal_against_brute_force(seed):
    """Eq. 4.3's closed form beats every angle of a fine grid (with that angle's best translation)."""
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))

    def cost(th):
        ra = R.quaternion_rotate(R.quaternion_from_axis_angle(UP, th), a)
        t = (b - ra).mean(axis=0)
        t[1] = 0.0
        return np.sum((ra + t - b) ** 2)

    th, t = align_about_vertical(a, b, UP)
    ra = R.quaternion_rotate(R.quaternion_from_axis_angle(UP, th), a)
    best = np.sum((ra + t - b) ** 2)
    grid = min(cost(g) for g in np.linspace(-np.pi, np.pi, 181))
    assert best <= grid + 1e-9


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), up=st.sampled_from([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]]))
def test_weighted_alignment_is_the_fit_of_the_weighted_points(seed, up):
    """Integer weights equal repeating the points; zero weights drop them (any up axis, batched rows)."""
    up = np.array(up)
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(2, 5, 3)), rng.normal(size=(2, 5, 3))
    w = rng.integers(0, 4, size=(2, 5)).astype(float)
    w[:, 0] = 1.0
    th, t = align_about_vertical(a, b, up, weights=w)
    for r in range(2):
        rep = np.repeat(np.arange(5), w[r].astype(int))
        th_r, t_r = align_about_vertical(a[r, rep], b[r, rep], up)
        assert abs(np.angle(np.exp(1j * (th[r] - th_r)))) < 1e-9
        assert np.allclose(t[r], t_r, atol=1e-9)
    zero_th, zero_t = align_about_vertical(a[0], b[0], up, weights=np.zeros(5))
    assert zero_th == 0.0 and np.all(zero_t == 0.0)


def test_database_positions_are_per_clip_forward_kinematics():
    db = MotionDatabase.build([samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")], fps=30, mirror=True,
                              executor="serial", progress=False)
    pos = database_positions(db, ["lhand", "head"])
    assert pos.shape == (db.num_frames, 2, 3)
    a, b = db.clip_range(1)
    np.testing.assert_allclose(pos[a:b], virtual_markers(db.clip(1), ["lhand", "head"]))
    assert output_skeleton(db, None) is db.skeletons[0]
    with pytest.raises(ValueError, match="joint layout"):
        import mocapkit

        output_skeleton(db, mocapkit.load(samples.path("131_01.bvh")).skeleton)


BANDAI = Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh"


def test_body_motion_reroots_at_the_pelvis_and_keeps_every_body_position():
    m = mocapkit.load(BANDAI)
    idx = body_joints(m.skeleton)
    assert m.skeleton.joint_names[idx[0]] == "Hips" and 0 not in idx and idx.size == m.num_joints - 1
    b = body_motion(m)
    assert b.skeleton.joint_names[0] == "Hips" and b.skeleton.parents[0] == -1
    np.testing.assert_allclose(b.global_positions(), m.global_positions()[:, idx], atol=1e-9)
    # and back: the body where it was, the floor-bound root on the ground under the pelvis
    w = whole_motion(b, m.skeleton, UP)
    g = w.global_positions()
    np.testing.assert_allclose(g[:, idx], m.global_positions()[:, idx], atol=1e-9)
    np.testing.assert_allclose(g[:, 0, 1], 0.0, atol=1e-12)
    np.testing.assert_allclose(g[:, 0, [0, 2]], g[:, idx[0], [0, 2]], atol=1e-9)


def test_body_motion_of_a_pelvis_rooted_rig_is_the_motion_itself():
    m = mocapkit.load(samples.path("12_walk.amc"))[:10]
    assert body_motion(m) is m and body_skeleton(m.skeleton) is m.skeleton
    assert whole_motion(m, m.skeleton, UP) is m


def test_the_body_goes_back_under_a_root_held_where_the_bandai_take_holds_it():
    """joint_Root at the origin in every frame: written there again, Hips' channels carrying the translation, the
    take's every channel back bit for bit (the root is not turned into root motion under the pelvis)."""
    m = mocapkit.load(BANDAI)
    held = held_above(m)
    assert held is not None and held.num_frames == 1
    np.testing.assert_array_equal(held.root_positions, 0.0)
    w = whole_motion(body_motion(m), m.skeleton, UP, held)
    np.testing.assert_array_equal(w.channel_values(), m.channel_values())
    np.testing.assert_array_equal(w.global_positions(), m.global_positions())
    # a database of the take holds it the same: what a reconstruction is laid out as without an input skeleton
    db = MotionDatabase.build([m], fps=30, executor="serial", progress=False)
    np.testing.assert_array_equal(held_above(db).root_positions, 0.0)


def test_unreal_root_held_or_moving_is_kept_as_the_take_has_it():
    """Unreal's ``root`` above ``pelvis`` (Bandai takes under its names): an in-place take (dataset 2, the root at
    the origin) is held and comes back bit for bit; root motion (dataset 1's dash, the root moving along z) is
    not held, and :func:`laid_out_like` keeps its root frame by frame where the body follows the take, and
    relative to the pelvis's ground frame where it does not."""
    from mocapkit.reconstruct.output import laid_out_like
    from tests.shared import unreal_spelling

    m = unreal_spelling(mocapkit.load(BANDAI))
    assert m.skeleton.joint_names[:2] == ("root", "pelvis")
    w = whole_motion(body_motion(m), m.skeleton, UP, held_above(m))
    np.testing.assert_array_equal(w.channel_values(), m.channel_values())
    dash = unreal_spelling(mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"))
    assert held_above(dash) is None and np.ptp(dash.root_positions[:, 2]) > 100.0
    floor = whole_motion(body_motion(dash), dash.skeleton, UP)  # the root on the floor under the pelvis
    carried = laid_out_like(floor, dash)  # the body where the take has it: the root where the take has it too
    np.testing.assert_allclose(carried.root_positions, dash.root_positions, atol=1e-9)
    np.testing.assert_allclose(carried.global_positions(), dash.global_positions(), atol=1e-9)
    kept = laid_out_like(floor, dash, follow=True)
    np.testing.assert_allclose(kept.root_positions, dash.root_positions, atol=1e-9)
    np.testing.assert_allclose(kept.global_positions(), dash.global_positions(), atol=1e-9)
    # a root-motion result laid out like the in-place take: the root back at the origin, the body where it was
    back = laid_out_like(whole_motion(body_motion(m), m.skeleton, UP), m)
    np.testing.assert_array_equal(back.root_positions, 0.0)
    np.testing.assert_allclose(back.global_positions(), m.global_positions(), atol=1e-9)


def test_a_pelvis_rooted_rig_holds_nothing_above_the_pelvis():
    m = mocapkit.load(samples.path("12_walk.amc"))[:10]
    assert held_above(m) is None
    assert whole_motion(m, m.skeleton, UP, held_above(m)) is m


def _root_in_pelvis_frame(m):
    """The root's position (F, 3) in the pelvis's ground frame (heading about y and floor position removed), and its
    global rotation there (F, 4)."""
    from mocapkit.features import root_frame

    h, t = root_frame(m, UP)
    inv = R.quaternion_conjugate(h)
    grot, gpos = m.global_transforms()
    return R.quaternion_rotate(inv, gpos[:, 0] - t), R.quaternion_multiply(inv, grot[:, 0])


def test_a_moving_root_is_carried_with_a_body_placed_elsewhere():
    """Dataset 1's dash moves its ``joint_Root`` along the floor with the body (2.7 m over 20 frames). A body put
    elsewhere (turned 90 degrees about the vertical, 5 m away, as a reconstruction from accelerometers integrates
    it) gets the root where the take has it relative to the pelvis's ground frame, frame by frame, the body's
    joints unmoved, not at the origin where the database's takes hold it, metres from the body."""
    from mocapkit.reconstruct.output import carried_above, laid_out_like

    dash = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh")
    b = body_motion(dash)
    turn = R.quaternion_from_axis_angle(UP, np.pi / 2)
    rot = np.array(b.rotations)
    rot[:, 0] = R.quaternion_multiply(turn, rot[:, 0])
    moved = Motion(b.skeleton, rot, R.quaternion_rotate(turn, b.root_positions) + [500.0, 0.0, -300.0], b.fps, b.name,
                   b.translations)
    still = whole_motion(moved, dash.skeleton, UP, held_above(mocapkit.load(BANDAI)))  # joint_Root at the origin
    want_p, want_q = _root_in_pelvis_frame(dash)
    got_p, _ = _root_in_pelvis_frame(still)
    assert np.linalg.norm(got_p - want_p, axis=-1).min() > 100.0  # cm: the still root is far from the body
    out = laid_out_like(still, dash)
    got_p, got_q = _root_in_pelvis_frame(out)
    np.testing.assert_allclose(got_p, want_p, atol=1e-9)
    np.testing.assert_allclose(np.abs(np.sum(got_q * want_q, axis=-1)), 1.0, atol=1e-12)
    np.testing.assert_allclose(out.global_positions()[:, 1:], still.global_positions()[:, 1:], atol=1e-9)
    np.testing.assert_allclose(out.root_positions[:, 1], 0.0, atol=1e-9)  # on the floor, where the take's is
    assert carried_above(dash, dash).root_positions == pytest.approx(dash.root_positions, abs=1e-9)



def test_a_moving_root_is_not_carried_where_the_take_misses_its_pelvis():
    """A gap in the dash's Hips leaves no ground frame to carry the root from: the result comes back as it was,
    no root made up (NaN) in the gap."""
    from mocapkit.reconstruct.output import carried_above, laid_out_like

    dash = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh")
    still = whole_motion(body_motion(dash), dash.skeleton, UP, held_above(mocapkit.load(BANDAI)))
    rot = np.array(dash.rotations)
    rot[5:8, dash.skeleton.index("Hips")] = np.nan
    gappy = Motion(dash.skeleton, rot, dash.root_positions, dash.fps, dash.name, dash.translations)
    assert carried_above(gappy, still) is None
    assert laid_out_like(still, gappy) is still
