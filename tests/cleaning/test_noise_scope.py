"""The noise rule's extremities: the hands' and toes' own wobble at 30 fps is left, noise of the body is not."""

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, samples
from mocapkit.cleaning.noise_scope import extremities, with_body_noise
from mocapkit.cleaning.pipeline import clean, noisy_cells


@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(samples.path("12_walk.amc"))  # CMU subject 12, 120 fps


def test_extremities_of_the_acclaim_rig_are_the_hands_and_toes(walk):
    sk = walk.skeleton
    names = {sk.joint_names[j] for j in np.flatnonzero(extremities(sk))}
    assert names == {f"{s}{n}" for s in "lr" for n in ("wrist", "hand", "fingers", "thumb", "toes")}


def test_the_toes_own_wobble_at_30_fps_is_not_noise(walk):
    """Every 4th frame of a clean CMU walk: the left toe's wobble, resolved at 120 fps, reverses frame to frame at
    30 fps and passes every test of one track (40 cells called noisy by them); the rest of the body is smooth."""
    m = walk[::4]
    j = m.skeleton.index("ltoes")
    assert not noisy_cells(walk)[0].any()
    found, level = noisy_cells(m)
    assert np.nanmax(level[:, j]) > 1.0  # over the level: the per-track tests are what is at stake
    assert not found.any()
    res = clean(m, steps="denoise")
    assert not res.denoised.any()
    assert np.array_equal(res.motion.rotations, m.rotations)


def test_the_toes_of_a_lafan1_rig_at_30_fps_are_left_alone(walk):
    """The same walk at 30 fps on LaFAN1's rig (``LeftToe``, position channels on every joint) comes back from
    clean bit for bit: its toes' wobble was denoised (40 cells) while the HumanIK family did not name them. Toes
    whose name no family knows are the joints below the foot."""
    import dataclasses

    from tests.shared import lafan_spelling, motionbuilder_spelling

    m = lafan_spelling(motionbuilder_spelling(walk))[::4]
    res = clean(m)
    assert not res.changed.any() and np.array_equal(res.motion.rotations, m.rotations)
    sk = m.skeleton
    odd = dataclasses.replace(sk, joint_names=tuple(n.replace("Toe", "Toe_tip") for n in sk.joint_names))
    names = {odd.joint_names[j] for j in np.flatnonzero(extremities(odd))}
    assert {"LeftToe_tip", "RightToe_tip"} <= names and not {"LeftFoot", "RightFoot"} & names


def test_noise_on_the_body_is_still_found_on_the_toes_and_hands_at_30_fps(walk):
    """Mall's 0.5 noise on every joint at 30 fps: the limbs are noisy, so the toes' and hands' runs beside them
    stay noisy."""
    m = walk[::4]
    noisy, mask = corrupt.angular_noise(m, amount=0.5, seed=3)
    found, _ = noisy_cells(noisy)
    ext = extremities(m.skeleton)
    assert (found & mask)[:, ext].sum() > 0.5 * mask[:, ext].sum()
    assert (found & mask)[:, ~ext].sum() > 0.5 * mask[:, ~ext].sum()


def test_noise_on_a_toe_and_its_leg_is_found_on_both_at_30_fps(walk):
    m = walk[::4]
    noisy, _ = corrupt.angular_noise(m, amount=0.5, seed=1, joints=["ltoes", "lfemur"])
    found, _ = noisy_cells(noisy)
    sk = m.skeleton
    assert found[:, sk.index("ltoes")].mean() > 0.8 and found[:, sk.index("lfemur")].mean() > 0.8


def test_at_120_fps_a_toe_alone_under_noise_is_noise(walk):
    """At 120 fps the fit spans 0.06 s and the toes' wobble is not called noise: the body's company is not asked."""
    noisy, _ = corrupt.angular_noise(walk, amount=0.5, seed=1, joints=["ltoes"])
    found, _ = noisy_cells(noisy)
    assert found[:, walk.skeleton.index("ltoes")].mean() > 0.8


def test_with_body_noise_keeps_an_extremity_run_only_where_the_body_is_noisy(walk):
    sk = walk.skeleton
    F = 40
    noisy = np.zeros((F, sk.num_joints), dtype=bool)
    t, f = sk.index("ltoes"), sk.index("lfemur")
    noisy[2:10, t] = True  # alone
    noisy[20:30, t] = True  # the femur noisy at one of its frames
    noisy[29:35, f] = True
    out = with_body_noise(noisy, sk)
    assert not out[2:10, t].any() and out[20:30, t].all() and out[29:35, f].all()
    assert out.sum() == 16
    assert not with_body_noise(np.zeros_like(noisy), sk).any()
