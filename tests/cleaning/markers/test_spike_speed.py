"""spike_mask at a low rate: the same mask, from far fewer pseudo-inverses and Kabsch calls.

At 24 Hz many more candidate runs are settled and judged than at 120 Hz; 0.13.0 fitted a cubic (a
pseudo-inverse) per run and per round, and each neighbour triple's moving frame (a Kabsch call) over
every frame of a run's window, one triple at a time: on CMU 85_02 taken every 5th frame (24 Hz) that
was 3,344 pseudo-inverses and 1,855 Kabsch calls (1.3 s, 20 times the per-frame cost at 120 Hz).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocapkit import rotations
from mocapkit.cleaning.markers import spikes
from mocapkit.cleaning.markers import rigid
from mocapkit.io.c3d import read_c3d

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"
# the mask on 85_02[::5] at 24 Hz: (frame, marker). Not LMT5 (9) at 112-113, a foot swinging at 8-9 m/s: its
# partner LTOE vouches for 112 (distance 6.6 mm off the usual, tolerance 7.7 mm, LTOE moving with it), and the
# neighbour triples then explain 113; at 120 Hz the take has no spike there. Nor RFWT (1) at 115-117 and LFIN (33)
# at 116-117: their paths bend as their neighbours' do (RFWT's second differences 15-63 mm a frame, RBWT's the
# same; LFIN's 14-87, LWRA's 34-92), the body moving faster than a cubic at 24 Hz follows.
MASK_24HZ = [(99, 11), (100, 11), (101, 11)]


def test_stacked_frames_are_local_frames_bit_for_bit():
    """Each frame's Kabsch fit is its own: G groups fitted in one call equal G calls of local_frames exactly,
    unseen frames (NaN) included."""
    x = np.asarray(read_c3d(CMU).positions, dtype=np.float64)[:300]
    rng = np.random.default_rng(3)
    groups = np.stack([rng.choice(x.shape[1], 3, replace=False) for _ in range(5)])
    donors = x[:, groups].transpose(1, 0, 2, 3).copy()  # (G, T, 3, 3)
    donors[1, 40:45, 2] = np.nan
    refs = x[rng.integers(0, x.shape[0], 5)[:, None], groups]  # (G, 3, 3)
    rot, origin = rigid.local_frames_stacked(donors, refs)
    for g in range(len(groups)):
        r1, o1 = rigid.local_frames(donors[g], refs[g])
        assert np.array_equal(rot[g], r1, equal_nan=True) and np.array_equal(origin[g], o1, equal_nan=True)
    assert np.all(np.isnan(rot[1, 40:45]))


def test_low_rate_spikes_take_few_fits_and_the_same_mask(monkeypatch):
    """85_02 at 24 Hz: MASK_24HZ, with each cubic's weights computed once per context shape and
    the neighbour triples' frames fitted together, on the frames read only (0.13.0: 3,344 pseudo-inverses,
    1,855 Kabsch calls; now under 100 and 400)."""
    x = np.asarray(read_c3d(CMU)[::5].positions, dtype=np.float64)
    count = {"pinv": 0, "kabsch": 0}
    pinv, kabsch = np.linalg.pinv, rotations.kabsch

    def counted_pinv(*a, **k):
        count["pinv"] += 1
        return pinv(*a, **k)

    def counted_kabsch(*a, **k):
        count["kabsch"] += 1
        return kabsch(*a, **k)

    monkeypatch.setattr(np.linalg, "pinv", counted_pinv)
    monkeypatch.setattr(rotations, "kabsch", counted_kabsch)
    for cached in ("_prediction_weights", "_offset_weights"):  # counted from cold, whatever ran before
        if hasattr(getattr(spikes, cached, None), "cache_clear"):
            getattr(spikes, cached).cache_clear()
    mask = spikes.spike_mask(x, fps=24.0)
    assert [tuple(map(int, t)) for t in np.argwhere(mask)] == MASK_24HZ
    assert count["pinv"] < 100 and count["kabsch"] < 400, count
