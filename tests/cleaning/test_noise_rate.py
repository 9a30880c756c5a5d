"""The rate under which clean's noise rule cannot tell capture noise from motion (mocapkit.cleaning.noise_rate)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning.noise_rate import NOISE_MIN_FPS, noise_too_coarse
from mocapkit.cleaning.pipeline import clean, noisy_cells

TEST_DATA = Path(__file__).resolve().parents[1] / "data"
SAID = "too coarse to tell capture noise from motion"


def test_the_line_is_24_fps_and_23_976_counts_as_24():
    assert NOISE_MIN_FPS == 24.0
    assert noise_too_coarse(24.0) == "" and noise_too_coarse(30.0) == "" and noise_too_coarse(24000 / 1001) == ""
    line = noise_too_coarse(20.0)
    assert SAID in line and "20 fps" in line and "24 fps or more" in line and "\n" not in line


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.array_equal(a.rotations, b.rotations) and np.array_equal(a.root_positions, b.root_positions))


@pytest.mark.parametrize("take, step", [
    ("dataset-1_dash_chimpira_001.bvh", 3),  # Bandai Namco game rig at 10 fps: 134 cells denoised before
    ("dataset-1_bow_active_001.bvh", 2),  # at 15 fps: 9 cells of the right foot denoised before
])
def test_a_clean_studio_take_under_24_fps_comes_back_bit_identical_and_says_why(take, step):
    """Every ``step``-th frame of a clean 30 fps studio take (each value a real capture sample): its feet and hands
    move at frequencies a 7-frame fit at 10-15 fps passes into its residual, and the noise rule read them as
    noise. The take comes back bit for bit, with one line in the summary."""
    m = mocapkit.load(TEST_DATA / take)[::step]
    assert m.fps < NOISE_MIN_FPS
    res = clean(m, steps="fill,denoise")
    assert not res.denoised.any(), res.summary()
    assert _same(res.motion, m)
    said = [n for n in res.notes if SAID in n]
    assert len(said) == 1 and said[0].startswith("denoise skipped: ")
    assert res.steps[-1].name == "denoise" and res.steps[-1].method == "skipped"


@pytest.mark.parametrize("step", [6, 12])
def test_cmu_131_02_at_20_and_10_fps_is_left_alone(shared_data, step):
    """CMU 131_02 (a Michael Jackson styled walk) as every 6th / 12th frame of the 120 fps BVH: at 20 fps the
    left knee's swing, at 10 fps 420 cells of toes, wrist, elbow and thumb were denoised (toes by up to
    52 deg). Below the line they are not judged: the take comes back bit for bit, saying why."""
    m = mocapkit.load(shared_data / "cmu_bvh" / "131_02.bvh")[::step]
    assert m.fps == 120 / step
    res = clean(m, steps="fill,denoise")
    assert not res.denoised.any() and _same(res.motion, m), res.summary()
    assert any(SAID in n for n in res.notes)
    assert not noisy_cells(m)[0].any()


def test_noise_at_24_fps_is_still_found_and_denoised(shared_data):
    """At the line (every 5th frame of CMU 131_02, 24 fps) Mall's 0.5 noise on the left knee is still judged and
    denoised, and the clean joints are left as they were."""
    m = mocapkit.load(shared_data / "cmu_bvh" / "131_02.bvh")[::5]
    assert m.fps == NOISE_MIN_FPS
    j = m.skeleton.index("LeftKnee")
    bad, _ = corrupt.angular_noise(m, amount=0.5, seed=1, joints=["LeftKnee"])
    found, _ = noisy_cells(bad)
    assert found[:, j].mean() > 0.5
    res = clean(bad, steps="fill,denoise")
    assert res.denoised[:, j].mean() > 0.5 and not any(SAID in n for n in res.notes)
