"""The root's own gaps (a pelvis root's rotation or position missing over a stretch) filled from the body."""

import dataclasses
import functools
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import rotations as R
from mocapkit import samples
from mocapkit.cleaning import deep
from mocapkit.cleaning.gapfill import fill_motion
from mocapkit.cleaning.root_gaps import (contact_path, fill_pelvis, fill_root, fill_root_gaps, fill_root_rotation,
                                        foot_joints, heading_and_tilt)
from mocapkit.cleaning.whole_take import fill_take
from mocapkit.joints import unit_scale_cm
from mocapkit.rigs import pelvis_index
from tests.shared import daz_spelling, motionbuilder_spelling, respelled

ASF = {"12_walk.amc": "12.asf", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc": "HDM_bd.asf",
       "HDM_bk_sneak2StepsLStart_004_120.amc": "HDM_bk.asf"}


@functools.lru_cache(maxsize=None)
def clip(name: str):
    kw = {"asf": samples.path(ASF[name])} if name in ASF else {}
    return mocapkit.load(samples.path(name), **kw)


def without(take, first: int, last: int, what: str):
    """``take`` with its root rotation (``what`` "rotation") or position missing over frames first..last-1."""
    rot, pos = np.array(take.rotations), np.array(take.root_positions)
    if what == "rotation":
        rot[first:last, 0] = np.nan
    else:
        pos[first:last] = np.nan
    return dataclasses.replace(take, rotations=rot, root_positions=pos)


def rotation_rms_deg(a, b) -> float:
    return float(np.sqrt(np.mean(np.degrees(R.geodesic_angle(a, b)) ** 2)))


def position_rms_cm(take, a, b) -> float:
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=-1))) * unit_scale_cm(take.skeleton))


# (clip, first, last, the line's rotation error (deg), bound, the line's position error (cm), bound): the line
# between the gap's ends is what the networks' fill gave a pelvis root before; the bounds sit well under it
CASES = [("131_01.bvh", 300, 480, 53.4, 35.0, 43.5, 15.0),
         ("12_walk.amc", 100, 220, 7.7, 5.0, 2.7, 1.5)]


@pytest.mark.parametrize("name,first,last,line_deg,bound_deg,line_cm,bound_cm", CASES)
def test_a_lost_pelvis_root_is_filled_from_the_body_by_the_fill_step(name, first, last, line_deg, bound_deg,
                                                                      line_cm, bound_cm):
    """A CMU walk's root (the pelvis) lost for 1-1.5 s: its rotation came back 53 deg RMS off and its position
    44 cm off, the line between the gap's ends; the feet's contacts carry the position, the heading's curve and
    the body's tilt the rotation. Every other number is the take's, bit for bit."""
    take = clip(name)
    gone = without(take, first, last, "rotation")
    out = fill_take(gone).motion
    err = rotation_rms_deg(out.rotations[first:last, 0], take.rotations[first:last, 0])
    assert err < bound_deg < line_deg
    keep = np.ones(take.num_frames, dtype=bool)
    keep[first:last] = False
    assert np.array_equal(out.rotations[keep], take.rotations[keep])
    assert np.array_equal(out.rotations[:, 1:], take.rotations[:, 1:])
    assert np.array_equal(out.root_positions, take.root_positions)

    gone = without(take, first, last, "position")
    out = fill_take(gone).motion
    err = position_rms_cm(take, out.root_positions[first:last], take.root_positions[first:last])
    assert err < bound_cm < line_cm
    assert np.array_equal(out.root_positions[keep], take.root_positions[keep])
    assert np.array_equal(out.rotations, take.rotations)


def test_the_line_is_what_the_bounds_beat():
    """The figures the bounds above are set against: the line between the gap's ends on the same gaps."""
    for name, first, last, line_deg, _, line_cm, _ in CASES:
        take = clip(name)
        t = ((np.arange(first, last) - first + 1) / (last - first + 1))[:, None]
        p = (1 - t) * take.root_positions[first - 1] + t * take.root_positions[last]
        assert position_rms_cm(take, p, take.root_positions[first:last]) == pytest.approx(line_cm, abs=0.1)
        q = R.slerp(np.broadcast_to(take.rotations[first - 1, 0], (last - first, 4)),
                    np.broadcast_to(take.rotations[last, 0], (last - first, 4)), t[:, 0])
        assert rotation_rms_deg(q, take.rotations[first:last, 0]) == pytest.approx(line_deg, abs=1.0)


def test_a_partly_missing_root_position_keeps_its_measured_axes():
    """A root whose height alone is missing (an AMC's ``ty`` written nan): X and Z are the take's, bit for bit, and
    the height comes from the feet."""
    take = clip("12_walk.amc")
    pos = np.array(take.root_positions)
    pos[100:220, 1] = np.nan
    out, how = fill_root(dataclasses.replace(take, root_positions=pos))
    assert np.array_equal(out.root_positions[:, [0, 2]], take.root_positions[:, [0, 2]])
    assert np.array_equal(out.root_positions[~np.isnan(pos)], take.root_positions[~np.isnan(pos)])
    assert not np.isnan(out.root_positions).any()
    assert how == {("position", 100, 220): "contacts"}
    cm = unit_scale_cm(take.skeleton)
    assert np.sqrt(np.mean((out.root_positions[100:220, 1] - take.root_positions[100:220, 1]) ** 2)) * cm < 1.5


def test_a_jump_falls_back_to_the_spline():
    """Where the feet leave the ground the contacts' path misses the far end: the cubic spline fills the gap."""
    take = clip("131_01.bvh")
    F = take.num_frames
    feet = np.zeros((F, 1, 3))
    feet[:, 0, 1] = -30.0  # one foot under the root that never moves relative to it: a root standing still ...
    pos = np.array(take.root_positions)
    path, miss = contact_path(pos, 300, 480, feet, np.array([0.0, 1.0, 0.0]))
    assert np.allclose(path[0], pos[299] + (pos[480] - pos[299]) / 181)  # ... bent linearly onto the far end
    assert miss == pytest.approx(np.linalg.norm(pos[480] - pos[299]))


def test_heading_and_tilt_rebuild_the_rotation():
    take = clip("131_01.bvh")
    up = np.array([0.0, 1.0, 0.0])
    heading, tilt = heading_and_tilt(take.rotations[:, 0], up)
    back = R.quaternion_multiply(R.quaternion_from_axis_angle(np.broadcast_to(up, (len(heading), 3)), heading),
                                 R.rotvec_to_quaternion(tilt))
    assert np.allclose(np.degrees(R.geodesic_angle(back, take.rotations[:, 0])), 0.0, atol=1e-6)
    assert np.allclose(tilt @ up, 0.0, atol=1e-9)  # the tilt has no turn about the vertical


def test_a_rotation_gap_touching_the_take_end_holds_and_the_rest_is_kept():
    take = clip("12_walk.amc")
    q = np.array(take.rotations[:, 0])
    gap = np.zeros(len(q), dtype=bool)
    gap[-30:] = True
    q[gap] = np.nan
    out, chosen = fill_root_rotation(q, gap, take.fps)
    assert chosen == {(len(q) - 30, len(q)): "spline"}
    assert np.array_equal(out[~gap], take.rotations[~gap, 0])
    assert np.allclose(np.degrees(R.geodesic_angle(out[gap], take.rotations[-31, 0])), 0.0, atol=1e-6)


BANDAI_WALK = "dataset-2_walk_normal_001_first120.bvh"


def bandai(name: str):
    return mocapkit.load(Path(__file__).resolve().parents[1] / "data" / name)


def test_a_lost_game_rig_pelvis_path_is_filled_from_the_feet():
    """A Bandai Namco walk whose Hips offset (the body's path over a still joint_Root) is lost for 1.3 s, its
    rotation measured: the line between the gap's ends is 4.7 cm RMS off; the feet's contacts carry it within 1 cm.
    Every other number is the take's, bit for bit."""
    take = bandai(BANDAI_WALK)
    j = pelvis_index(take.skeleton)
    assert take.skeleton.joint_names[j] == "Hips"
    tr = np.array(take.translations)
    tr[40:80, j] = np.nan
    gone = dataclasses.replace(take, translations=tr)
    out, how = fill_pelvis(gone, dataclasses.replace(gone, translations=np.where(np.isnan(tr), 0.0, tr)))
    assert how == {("position", 40, 80): "contacts"}
    t = ((np.arange(40, 80) - 39) / 41)[:, None]
    line = (1 - t) * take.translations[39, j] + t * take.translations[80, j]
    truth = take.translations[40:80, j]
    assert position_rms_cm(take, line, truth) == pytest.approx(4.65, abs=0.05)
    assert position_rms_cm(take, out.translations[40:80, j], truth) < 1.0
    keep = ~np.isnan(tr)
    assert np.array_equal(out.translations[keep], take.translations[keep])
    assert np.array_equal(out.rotations, take.rotations)
    rot = np.array(take.rotations)  # the networks refill the Hips cells whose offset alone is lost: read through the
    rot[40:80, j] = R.identity()    # measured rotation, the path is the same
    again = fill_pelvis(gone, dataclasses.replace(gone, rotations=rot, translations=np.where(keep, tr, 0.0)))[0]
    assert np.array_equal(again.translations[:, j], out.translations[:, j])


def test_a_game_rig_pelvis_lost_with_its_rotation_is_not_filled_from_the_feet():
    """With the Hips rotation lost over the same frames the contacts would swing about a rotation that is itself a
    fill: the path is the line or the spline, whichever refills the take's measured stretches best."""
    take = bandai("bandai_dance-short_normal_001_first240.bvh")
    j = pelvis_index(take.skeleton)
    tr, rot = np.array(take.translations), np.array(take.rotations)
    tr[100:145, j] = rot[100:145, j] = np.nan
    gone = dataclasses.replace(take, translations=tr, rotations=rot)
    body = dataclasses.replace(take, translations=np.where(np.isnan(tr), 0.0, tr))
    out, how = fill_pelvis(gone, body)
    assert how[("position", 100, 145)] in ("line", "spline")
    assert np.array_equal(out.translations[~np.isnan(tr)], take.translations[~np.isnan(tr)])
    assert np.array_equal(out.rotations, body.rotations)


def test_a_pelvis_root_is_not_the_game_rigs_fill():
    take = clip("131_01.bvh")
    gone = without(take, 300, 480, "position")
    assert fill_pelvis(gone, gone) == (gone, {})


def test_a_root_lost_whole_is_not_placed_by_the_feet():
    """HDM05 bk sneak 004 with its root's rotation and position lost together for 1 s (frames 77-196): the feet,
    turned about the root by the filled rotation, put the path 9.4 cm RMS off; the cubic spline fills it within
    2.6 cm. A position lost alone is still the contacts' (0.8 cm)."""
    take = clip("HDM_bk_sneak2StepsLStart_004_120.amc")
    gone = without(without(take, 77, 197, "rotation"), 77, 197, "position")
    out, how = fill_root(gone)
    assert how[("position", 77, 197)] == "spline"
    assert position_rms_cm(take, out.root_positions[77:197], take.root_positions[77:197]) < 3.0
    assert np.array_equal(out.root_positions[~np.isnan(gone.root_positions)],
                          take.root_positions[~np.isnan(gone.root_positions)])
    alone, how = fill_root(without(take, 77, 197, "position"))
    assert how == {("position", 77, 197): "contacts"}
    assert position_rms_cm(take, alone.root_positions[77:197], take.root_positions[77:197]) < 1.0


def test_a_rig_without_toes_is_placed_by_its_ankles():
    """HDM05 bk sneak 004 on the Daz release's rig (no toes), its root position lost for 1 s (frames 77-196): the
    cubic spline is 2.5 cm RMS off; the ankles' contacts carry it within 1 cm."""
    take = daz_spelling(motionbuilder_spelling(clip("HDM_bk_sneak2StepsLStart_004_120.amc")))
    assert [take.skeleton.joint_names[j] for j in foot_joints(take.skeleton)] == ["lFoot", "rFoot"]
    out, how = fill_root(without(take, 77, 197, "position"))
    assert how == {("position", 77, 197): "contacts"}
    assert position_rms_cm(take, out.root_positions[77:197], take.root_positions[77:197]) < 1.0
    assert np.array_equal(out.root_positions[:77], take.root_positions[:77])
    assert np.array_equal(out.root_positions[197:], take.root_positions[197:])


def test_a_rig_no_network_serves_has_its_root_filled_from_the_body_too():
    """CMU 131_01 on a rig without clavicles (no shipped network serves it: the cubic spline fills its joints) with
    its root position lost for 1.5 s (frames 300-479): the spline is 28.9 cm RMS off; the feet's
    contacts, as where the networks fill the body, carry it within 10 cm. Every measured number is the take's."""
    take = respelled(clip("131_01.bvh"), {}, drop=("LeftCollar", "RightCollar"))
    gone = without(take, 300, 480, "position")
    done = fill_take(gone)
    assert done.method == deep.FALLBACK_FILL
    out = done.motion
    assert position_rms_cm(take, out.root_positions[300:480], take.root_positions[300:480]) < 10.0
    assert np.array_equal(out.root_positions[~np.isnan(gone.root_positions)],
                          take.root_positions[~np.isnan(gone.root_positions)])
    assert np.array_equal(out.rotations, take.rotations)
    same, how = fill_root_gaps(gone, fill_motion(gone, "cubic"))  # the one root fill, whatever fills the rest
    assert how["root"] == {("position", 300, 480): "contacts"}
    assert np.array_equal(same.root_positions, out.root_positions)
