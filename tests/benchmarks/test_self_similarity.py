"""benchmarks/_self_similarity.py: long gaps filled from the take's own motion words (deep_gapfill's words rows)."""

from __future__ import annotations

import numpy as np
import pytest

import mocapkit
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep.channels import encode

from .helpers import load

words = load("_self_similarity")


def _wrapped_rms(a, b, mask):
    d = (a - b + 180.0) % 360.0 - 180.0
    return float(np.sqrt(np.mean(d[mask] ** 2)))


@pytest.fixture(scope="module")
def walk_channels():
    """CMU subject 12's walk (2.9 s, 120 fps: three steps of each leg) as the shipped EBD's channels, and the EBD."""
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    ebd = deep.shipped_model("ebd")
    y, ctx = encode(walk, ebd.layout)
    return y, ctx, ebd


def test_a_walks_lost_knee_is_filled_from_its_own_steps(walk_channels):
    y, ctx, ebd = walk_channels
    joint = np.array([n.split(".")[0] for n in ebd.layout.names])
    x = y.copy()
    x[200:320, joint == "ltibia"] = np.nan  # the left knee lost for 1 s: the take's other steps hold its bend
    miss = np.isnan(x)
    prior = deep.fill_channels(x, ctx, ebd, smooth=False, method="prior")
    own = words.self_similar_fill(prior, miss, 120.0, d0=None)
    assert np.array_equal(own[~miss], x[~miss])  # observed entries bit-identical
    lerp = _wrapped_rms(deep.lerp_fill(x), y, miss)
    # measured: lerp 28.6 deg, the gap prior 10.2, the take's words 5.5
    assert _wrapped_rms(own, y, miss) < 0.3 * lerp
    assert _wrapped_rms(own, y, miss) < 0.7 * _wrapped_rms(prior, y, miss)
    blended = words.self_similar_fill(prior, miss, 120.0)
    w = words.word_fill(words.gaussian_filter1d(deep.lerp_fill(x), words.SMOOTH_S * 120.0, axis=0, mode="nearest"),
                        miss, 200, 320, np.flatnonzero(joint == "ltibia"), 120.0)
    weight = np.exp(-(w[1] / words.D0) ** 2)
    assert 0.0 < weight < 1.0
    assert np.allclose(blended[200:320, joint == "ltibia"],
                       (1.0 - weight) * prior[200:320, joint == "ltibia"] + weight * w[0])


def test_short_gaps_and_gaps_with_nothing_to_match_keep_the_given_fill(walk_channels):
    y, ctx, ebd = walk_channels
    x = y.copy()
    x[100:100 + int(words.MIN_S * 120) - 1, 5] = np.nan  # under MIN_S
    miss = np.isnan(x)
    filled = deep.lerp_fill(x)
    assert np.array_equal(words.self_similar_fill(filled, miss, 120.0, d0=None), filled)
    x = y.copy()
    x[: len(x) - words.K, 7] = np.nan  # the channel seen on K frames only: too few words to take a median of K
    miss = np.isnan(x)
    filled = deep.lerp_fill(x)
    assert words.word_fill(filled, miss, 0, len(x) - words.K, np.array([7]), 120.0) is None
    assert np.array_equal(words.self_similar_fill(filled, miss, 120.0, d0=None), filled)


def test_events_group_the_channels_lost_together():
    miss = np.zeros((10, 4), dtype=bool)
    miss[2:5, [0, 2]] = True
    miss[6:9, 1] = True
    ev = words.gap_events(miss)
    assert list(ev) == [(2, 5), (6, 9)]
    assert ev[(2, 5)].tolist() == [0, 2] and ev[(6, 9)].tolist() == [1]
