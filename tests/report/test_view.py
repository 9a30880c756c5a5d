"""Framing of the report's viewer: up axis from the data, units, and a camera that keeps the body in the panel."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.features import detect_up_axis
from mocapkit.motion import unit_scale_cm
from mocapkit.report.view import (
    HALF_FOV,
    MARGIN,
    body_points,
    camera_distance,
    find_up_axis,
    fit_view,
    rotation_to_y,
)
from mocapkit.rotations import quaternion_multiply

DATA = Path(__file__).resolve().parents[1] / "data"
BANDAI = DATA / "bandai_dance-short_normal_001_first60.bvh"  # Y up, cm; rest pose lying along x
ZUP = DATA / "pybvh_test1_zup.bvh"  # Z up, inches


def turn_root_z_up(motion):
    """The take turned +90 deg about x at its root: the data is Z up, the rig's rest pose still Y up."""
    q = np.array([math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0])  # w first
    rot = np.array(motion.rotations)
    rot[:, 0] = quaternion_multiply(np.broadcast_to(q, rot[:, 0].shape), rot[:, 0])
    root = np.asarray(motion.root_positions) @ rotation_to_y([0, 0, 1])  # rows times R = R.T p: y -> z
    return dataclasses.replace(motion, rotations=rot, root_positions=root, name=motion.name + "_zup")


@pytest.fixture(scope="module")
def takes():
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    return {
        "acclaim": walk[:160],
        "bandai": mocapkit.load(BANDAI),
        "zup_file": mocapkit.load(ZUP),
        "zup_turned": turn_root_z_up(walk[:160]),
    }


def test_turned_take_is_the_walk_rotated(takes):
    a, b = takes["acclaim"], takes["zup_turned"]
    turn = np.linalg.inv(rotation_to_y([0, 0, 1]))  # y -> z
    np.testing.assert_allclose(b.global_positions(), a.global_positions() @ turn.T, atol=1e-9)


@pytest.mark.parametrize("name, up", [("acclaim", [0, 1, 0]), ("bandai", [0, 1, 0]),
                                      ("zup_file", [0, 0, 1]), ("zup_turned", [0, 0, 1])])
def test_up_axis_comes_from_the_data(takes, name, up):
    m = takes[name]
    assert find_up_axis(m.skeleton, m.global_positions()).tolist() == up
    # the caller's answer is taken as given
    assert find_up_axis(m.skeleton, m.global_positions(), up_axis="-x").tolist() == [-1, 0, 0]


def test_rest_pose_alone_would_lie_the_figure_down(takes):
    # why the data decides: these rigs' rest poses do not say where up is in the take
    assert np.abs(detect_up_axis(takes["bandai"].skeleton)).tolist() == [1, 0, 0]
    assert detect_up_axis(takes["zup_turned"].skeleton).tolist() == [0, 1, 0]
    # without frames the rest pose is the fallback
    assert find_up_axis(takes["zup_file"].skeleton).tolist() == [0, 0, 1]


def test_up_axis_majority_survives_a_few_upside_down_frames(takes):
    pos = takes["acclaim"].global_positions()
    flipped = pos.copy()
    flipped[:40, :, 1] *= -1  # a quarter of the frames upside down
    assert find_up_axis(takes["acclaim"].skeleton, flipped).tolist() == [0, 1, 0]


def test_mostly_lying_take_keeps_its_standing_rest_pose_up(takes):
    """An actor lying on the floor in 70 % of the frames (HDM05's lieDownFloor takes) stays Y up."""
    walk = takes["acclaim"]
    q = np.array([math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)])  # 90 deg about z: lying along -x
    rot = np.array(walk.rotations)
    rot[48:, 0] = quaternion_multiply(np.broadcast_to(q, rot[48:, 0].shape), rot[48:, 0])
    lying = dataclasses.replace(walk, rotations=rot)
    pos = lying.global_positions()
    sk = lying.skeleton
    d = pos[:, sk.index("head")] - pos[:, sk.index("lfoot")]
    assert np.mean(np.argmax(np.abs(d), axis=1) == 0) > 0.6  # most frames vote for x
    assert find_up_axis(sk, pos).tolist() == [0, 1, 0]
    # lying in every frame, it is drawn as the votes say: the root turns the rig (see zup_turned)
    rot[:, 0] = quaternion_multiply(np.broadcast_to(q, rot[:, 0].shape), np.asarray(walk.rotations)[:, 0])
    assert find_up_axis(sk, dataclasses.replace(walk, rotations=rot).global_positions()).tolist() == [-1, 0, 0]


def test_rig_without_head_or_feet_uses_its_tallest_extent(takes):
    """Joint names that say nothing: the head and feet come from the tree (``rigs.roles_by_topology``), so the Z-up
    file's rest pose tells its axis; a rig whose tree is no body either (every joint hung from the root) gets the
    axis of its tallest extent over the frames, and +y with nothing to go on."""
    m = takes["zup_file"]
    names = tuple(f"j{i}" for i in range(m.num_joints))
    nameless = dataclasses.replace(m.skeleton, joint_names=names)
    assert find_up_axis(nameless, m.global_positions()).tolist() == [0, 0, 1]
    assert find_up_axis(nameless).tolist() == [0, 0, 1]
    rest = nameless.rest_positions()
    star = dataclasses.replace(nameless, parents=np.r_[-1, np.zeros(m.num_joints - 1, dtype=np.int64)],
                               offsets=np.r_[rest[:1], rest[1:] - rest[0]])
    assert find_up_axis(star, m.global_positions()).tolist() == [0, 0, 1]
    assert find_up_axis(star).tolist() == [0, 1, 0]


@pytest.mark.parametrize("up", [[0, 1, 0], [0, -1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1]])
def test_rotation_to_y_is_proper_and_lifts_up(up):
    R = rotation_to_y(up)
    np.testing.assert_allclose(R @ up, [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)


def page_points(motion):
    """(N, P, 3) cm, +y up: what the report draws."""
    pos = motion.global_positions(end_sites=True)
    up = find_up_axis(motion.skeleton, pos[:, :motion.num_joints])
    return pos @ (rotation_to_y(up) * unit_scale_cm(motion.skeleton)).T


def test_bandai_floor_reference_is_not_body(takes):
    m = takes["bandai"]
    hidden = ~body_points(m.skeleton, m.global_positions(end_sites=True))
    assert [n for n, h in zip(m.skeleton.joint_names, hidden) if h] == ["joint_Root"]
    for name in ("acclaim", "zup_file"):
        assert body_points(takes[name].skeleton, takes[name].global_positions(end_sites=True)).all()


def test_units_do_not_change_the_view(takes):
    """The Bandai clip in metres gives the page the same centimetres and the same framing."""
    m = takes["bandai"]
    sk = m.skeleton
    metres = dataclasses.replace(
        m,
        skeleton=dataclasses.replace(sk, offsets=np.asarray(sk.offsets) / 100,
                                     end_site_offsets=np.asarray(sk.end_site_offsets) / 100),
        root_positions=np.asarray(m.root_positions) / 100,
        translations=None if m.translations is None else np.asarray(m.translations) / 100,
    )
    assert unit_scale_cm(metres.skeleton) == 100.0
    a, b = page_points(m), page_points(metres)
    np.testing.assert_allclose(a, b, atol=1e-6)
    fa = fit_view([a], fps=30, body=body_points(sk, m.global_positions(end_sites=True)))
    fb = fit_view([b], fps=30, body=body_points(metres.skeleton, metres.global_positions(end_sites=True)))
    assert fa.hidden.tolist() == fb.hidden.tolist() and fa.hidden.sum() == 1
    assert fa.radius_fixed == pytest.approx(fb.radius_fixed) and fa.floor == pytest.approx(fb.floor, abs=1e-6)


def project(points, target, dist, yaw, pitch, width, height):
    """The page's camera (viewer.js ``camera`` and ``project``) in numpy: (..., 3) -> (..., 2) pixels."""
    cp = math.cos(pitch)
    eye = target + dist * np.array([cp * math.sin(yaw), math.sin(pitch), cp * math.cos(yaw)])
    f = (target - eye) / np.linalg.norm(target - eye)
    r = np.cross(f, [0, 1, 0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    focal = 0.5 * min(width, height) / math.tan(HALF_FOV)
    d = points - eye
    zc = d @ f
    return np.stack([width / 2 + focal * (d @ r) / zc, height / 2 - focal * (d @ u) / zc], axis=-1)


@pytest.mark.parametrize("name", ["acclaim", "bandai", "zup_file", "zup_turned"])
def test_fitted_camera_keeps_every_point_in_the_panel(takes, name):
    m = takes[name]
    pts = page_points(m)
    view = fit_view([pts], fps=m.fps, body=body_points(m.skeleton, m.global_positions(end_sites=True)))
    body = pts[:, ~view.hidden]
    assert not np.isnan(body).any()
    for follow in (False, True):
        dist = view.distance(follow)
        worst = 0.0
        for w, h in ((600, 540), (150, 280), (800, 300)):
            for yaw in np.linspace(0, 2 * math.pi, 7):
                for pitch in (-0.8, 0.0, 0.25, 1.2):
                    for i in range(0, m.num_frames, 7):
                        target = (view.centre if not follow else
                                  np.array([view.track[i, 0], view.track_height, view.track[i, 1]]))
                        px = project(body[i], target, dist, yaw, pitch, w, h)
                        # distance from the panel's centre as a share of its smaller half-size
                        off = np.abs(px - [w / 2, h / 2]).max() / (min(w, h) / 2)
                        worst = max(worst, off)
        assert worst <= 1 - MARGIN + 1e-9, (name, follow, worst)
        assert worst > 0.45, (name, follow, worst)  # and the figure is not a speck
    # a figure that walks away is followed; one that stays is framed as a whole
    assert view.follow == (view.radius_fixed > 1.5 * view.radius_follow)


def test_camera_distance_bound():
    # the sphere's silhouette half-angle asin(r / d) is the margin-scaled half field of view
    d = camera_distance(100.0)
    assert math.tan(math.asin(100.0 / d)) == pytest.approx((1 - MARGIN) * math.tan(HALF_FOV))


def test_fit_view_ignores_missing_points_and_rejects_bad_shapes():
    pts = np.full((5, 4, 3), np.nan)
    v = fit_view([pts])
    assert v.radius_fixed > 0 and v.track.shape == (5, 2)
    pts[2, 1] = [10.0, 100.0, 0.0]
    pts[3, 2] = [10.0, 0.0, 0.0]
    v = fit_view([pts])
    assert v.centre.tolist() == [10.0, 50.0, 0.0] and v.radius_fixed == pytest.approx(50.0)
    with pytest.raises(ValueError, match=r"\(N, P, 3\)"):
        fit_view([np.zeros((5, 4, 3)), np.zeros((4, 4, 3))])
