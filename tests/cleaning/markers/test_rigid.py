"""rigid: the distance statistics' percentiles, bit for bit numpy's nanpercentile (the slow reference kept here)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from mocapkit.cleaning.markers.rigid import distance_stats, local_frames, nan_percentiles
from mocapkit.io.c3d import read_c3d

EB015 = Path(__file__).resolve().parents[3] / "src" / "mocapkit" / "data" / "Eb015pr.c3d"
Q = [50, 1, 99, 10, 90]


def _reference(d, q):
    """numpy's nanpercentile: one column at a time (what distance_stats took before 0.18.0)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanpercentile(d, q, axis=0)


def test_nan_percentiles_are_numpys_bit_for_bit_on_a_real_take_with_gaps():
    # Eb015pr's 26 markers over 450 frames, with its own gaps and more cut in (markers 13-25): columns of many
    # counts of seen frames, none (a marker never seen: NaN) and all (markers 0-2 are seen throughout). Equal bits,
    # not close numbers: the fills read them.
    x = np.array(read_c3d(EB015).positions, dtype=np.float64)
    rng = np.random.default_rng(3)
    x[:, 13:][rng.random((len(x), 13)) < 0.2] = np.nan
    x[:, 4] = np.nan
    d = np.linalg.norm(x[:, :, None, :] - x[:, None, :, :], axis=-1)
    counts = np.unique(np.sum(~np.isnan(d), axis=0))
    assert counts[0] == 0 and counts[-1] == len(x) and len(counts) > 20
    got = nan_percentiles(d, Q)
    want = _reference(d, Q)
    assert got.shape == want.shape and np.array_equal(np.isnan(got), np.isnan(want))
    assert got.tobytes() == np.where(np.isnan(want), got, want).tobytes()


def test_nan_percentiles_of_small_and_odd_stacks():
    rng = np.random.default_rng(0)
    for s in (1, 2, 3, 7, 60):
        v = rng.normal(size=(s, 5, 4)) * 10.0 ** rng.uniform(-3, 3, size=(1, 5, 4))
        v[rng.random(v.shape) < 0.4] = np.nan
        got, want = nan_percentiles(v, Q), _reference(v, Q)
        assert np.array_equal(got, want, equal_nan=True)


def test_distance_stats_of_a_take_with_gaps_are_the_reference_ones():
    x = np.array(read_c3d(EB015).positions, dtype=np.float64)
    x[100:180, 3] = np.nan
    stats = distance_stats(x, max_frames=200)
    idx = np.unique(np.linspace(0, len(x) - 1, 200).round().astype(int))
    d = np.linalg.norm(x[idx][:, :, None, :] - x[idx][:, None, :, :], axis=-1)
    q = _reference(d, Q)
    for got, want in ((stats.median, q[0]), (stats.low, q[1]), (stats.high, q[2]), (stats.spread, 0.5 * (q[4] - q[3]))):
        np.fill_diagonal(want, np.nan)
        assert np.array_equal(got, want, equal_nan=True)


def test_each_frames_fit_is_its_own():
    # The gap filler keeps a donor group's moving frames over a gap and its ends, and computes only the frames a
    # cubic fill needs beyond them (gaps._group_frames): that is exact because every frame's Kabsch fit is its own,
    # bit for bit the same computed with any other frames. Checked on Eb015pr's markers, a group over 450 frames.
    x = np.asarray(read_c3d(EB015).positions, dtype=np.float64)
    for group in ([0, 1, 2], [6, 7, 8, 9], [16, 19, 20], [3, 4, 5]):  # the last with frames unseen (NaN frames)
        d = x[:, group]
        ref = d[200]
        rot, origin = local_frames(d, ref)
        for cut in (1, 37, 398, 449):
            parts = [local_frames(d[:cut], ref), local_frames(d[cut:], ref)]
            assert np.concatenate([p[0] for p in parts]).tobytes() == rot.tobytes()
            assert np.concatenate([p[1] for p in parts]).tobytes() == origin.tobytes()
