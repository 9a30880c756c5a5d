"""mocapkit.cleaning.ssa.word_means: the kernels on neighbour words (separated minima, shift-tolerant angles)."""

from __future__ import annotations

import numpy as np

from mocapkit import rotations as R
from mocapkit.cleaning.ssa import word_means as WM


def _random_quats(rng, shape):
    return R.quaternion_normalize(rng.normal(size=shape + (4,)))


def test_select_separated_minima():
    dist = np.array([[0.1, 0.2, 0.3, 0.05, 0.4, 0.5]])
    pos = np.array([[10, 12, 40, 100, 60, 80]])
    clips = np.array([[0, 0, 0, 0, 1, 0]])
    out = WM.select_separated_minima(dist, pos, clips, 3, 7, np.array([95]), np.array([105]))
    # 100 is in the excluded zone; 12 is too close to 10; 40 next
    assert out.tolist() == [[10, 40, 60]]


def test_shift_tolerant_angles_equal_the_numpy_reading(rng):
    inp, ref = _random_quats(rng, (30, 4)), _random_quats(rng, (30, 4))
    ref[5:8, 1] = np.nan
    for shift in (0, 2):
        got = WM.shift_tolerant_angles(inp, ref, shift)
        want = np.full((30, 4), np.inf)
        for d in range(-shift, shift + 1):
            g = np.clip(np.arange(30) + d, 0, 29)
            a = R.geodesic_angle(inp, ref[g])
            want = np.fmin(want, np.where(np.isnan(a), np.inf, a))
        want[np.isinf(want)] = np.nan
        np.testing.assert_allclose(got, want, atol=1e-12)
    assert np.isnan(WM.shift_tolerant_angles(inp, ref, 0)[6, 1]) and np.isfinite(WM.shift_tolerant_angles(inp, ref, 2)[6, 1])
