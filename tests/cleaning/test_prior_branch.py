"""The gap prior on one branch of each angle (mocapkit.cleaning.deep.prior, GapPrior.branch), on real Bandai takes.

The Bandai Namco rig's thighs sit at +-180 deg, and unwrapped along time a take lands on +180 or on -180: one Gaussian
over such channels saw modes 360 deg apart and a fill that read little drifted between them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import prior as P
from mocapkit.cleaning.deep.channels import encode, lerp_fill

TEST_TAKE = "dataset-1_kick_normal_001"
HELD = (TEST_TAKE, "dataset-1_walk_normal_002", "dataset-1_walk-left_normal_001")


@pytest.fixture(scope="module")
def bandai(shared_data):
    """({take: (F, C) channels}, channel names) of the full Bandai takes in ../shared/data (the shipped EBD's layout)."""
    folder = shared_data / "secondary_bandai_namco_CC-BY-NC"
    files = sorted(folder.glob("dataset-1_*.bvh"))
    if len(files) < 10:
        pytest.skip(f"{folder}: the Bandai takes are not there")
    layout = deep.shipped_model("ebd", mocapkit.load(files[0])).layout
    return {f.stem: encode(mocapkit.load(f), layout)[0] for f in files}, list(layout.names)


def _wrapped_rms(a, b, mask):
    return float(np.sqrt(np.mean(((a - b + 180.0) % 360.0 - 180.0)[mask] ** 2)))


def test_a_thigh_lost_to_the_takes_end_is_filled_on_its_own_branch(bandai):
    takes, names = bandai
    train = [x for k, x in takes.items() if k not in HELD]
    old = P.fit_gap_prior(train, 30.0, ramp=False)
    new = P.fit_gap_prior(train, 30.0, ramp=False, branch=True)
    c = names.index("UpperLeg_R.Zrotation")
    k = list(new.lags).index(0) * len(names) + c
    assert old.scale[k] > 100.0 and new.scale[k] < 30.0  # the training takes' +180 and -180 are one mode
    assert abs(abs(new.branch[c]) - 180.0) < 15.0
    y = takes[TEST_TAKE]
    F = len(y)
    x = y.copy()
    cols = [i for i, n in enumerate(names) if n.startswith("UpperLeg_R.")]
    x[F - 120:, cols] = np.nan  # 4 s, to the take's end: only one side is read
    miss = np.isnan(x)
    line = _wrapped_rms(lerp_fill(x), y, miss)
    before = _wrapped_rms(P.conditional_fill(x, old, 30.0), y, miss)
    after = _wrapped_rms(P.conditional_fill(x, new, 30.0), y, miss)
    assert before > line  # the two-mode prior drifts between +180 and -180 (26 deg against the line's 14)
    assert after < 0.6 * line  # 6.6 deg
    # the take on another branch: the same fill, 360 deg up, continuing its neighbours
    turned = x.copy()
    turned[:, cols] += 360.0
    a = P.conditional_fill(x, new, 30.0)
    b = P.conditional_fill(turned, new, 30.0)
    np.testing.assert_allclose(b[:, cols], a[:, cols] + 360.0, atol=1e-6)
    assert np.abs(b[F - 120, cols] - b[F - 121, cols]).max() < 5.0


def test_the_branch_is_kept_in_the_model_file_and_an_older_prior_fills_as_before(bandai, tmp_path):
    takes, names = bandai
    train = [x for k, x in takes.items() if k not in HELD][:4]
    new = P.fit_gap_prior(train, 30.0, branch=True)
    back = P.GapPrior.from_arrays(new.to_arrays())
    np.testing.assert_array_equal(back.branch, new.branch)
    arrays = new.to_arrays()
    del arrays["branch"]  # a file written before branches
    legacy = P.GapPrior.from_arrays(arrays)
    assert legacy.branch is None
    y = takes[TEST_TAKE][:200].copy()
    y[50:110, :6] = np.nan
    filled = P.conditional_fill(y, legacy, 30.0)
    assert np.isfinite(filled).all() and np.array_equal(filled[~np.isnan(y)], y[~np.isnan(y)])
    # the turns are a fill-time shift only: a prior without them is the one it was fitted as (mean, covariance)
    np.testing.assert_array_equal(legacy.cov, new.cov)
    with pytest.raises(ValueError, match="branch"):
        P.GapPrior.from_arrays(dict(new.to_arrays(), branch=np.zeros(3)))


def test_the_shipped_bandai_prior_is_on_one_branch():
    model = deep.load_model(Path(deep.__file__).resolve().parents[2] / "models" / "ebd_bandai.pt")
    pr = model.prior
    assert pr.branch is not None and pr.branch.shape == (pr.num_channels,)
    C = pr.num_channels
    at0 = list(pr.lags).index(0) * C
    names = list(model.layout.names)
    for n in ("UpperLeg_R.Zrotation", "UpperLeg_R.Yrotation", "UpperLeg_L.Zrotation"):
        assert pr.scale[at0 + names.index(n)] < 60.0  # was 175, 174 and 125 deg over two modes
