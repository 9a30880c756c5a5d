"""The gap prior on one branch of each angle (mocapkit.cleaning.deep.prior, GapPrior.branch), on real Bandai takes.

The Bandai Namco rig's thighs sit at +-180 deg, and unwrapped along time a take lands on +180 or on -180: one Gaussian
over such channels saw modes 360 deg apart and a fill that read little drifted between them.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import prior as P
from mocapkit.cleaning.deep.channels import encode, lerp_fill

# the Bandai Namco models' licence is said by a LicenceWarning, tested in test_deep_shipped.py
pytestmark = pytest.mark.filterwarnings("ignore::mocapkit.errors.LicenceWarning")

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


def _turning_takes(n: int, F: int, seed: int) -> list[np.ndarray]:
    """(F, 4) synthetic takes at 30 fps: joint 0 (channels 0 and 1) a heading that turns over 180 deg in every
    take and a lean that follows its turning rate; joint 1 (channels 2 and 3) a swing 30 deg either way."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        t = np.arange(F) / 30.0
        rate = rng.uniform(60.0, 120.0) * rng.choice([-1.0, 1.0])
        heading = rng.uniform(-180.0, 180.0) + rate * t
        lean = 0.05 * rate + rng.normal(0.0, 0.5, F)
        swing = 30.0 * np.sin(2.0 * np.pi * rng.uniform(0.5, 1.5) * t + rng.uniform(0, 6.3))
        out.append(np.stack([heading, lean, swing, 0.5 * swing + 10.0], axis=1))
    return out


def test_a_joint_that_turns_freely_is_held_at_its_one_seen_end():
    """A heading has no branch and no mean to fall back on: lost to the take's end, read as it is, its fill drifted
    to the training clips' heading; now its joint is held at its one seen end, the other joints read it, and a gap
    between two seen ends is filled by the field as before."""
    prior = P.fit_gap_prior(_turning_takes(40, 150, 1), 30.0, branch=True)
    assert np.isnan(prior.branch[0]) and not np.isnan(prior.branch[1:]).any()
    joints = np.array([0, 0, 1, 1])
    assert P.held_channels(prior, joints).tolist() == [True, True, False, False]
    assert P.held_channels(prior).tolist() == [True, False, False, False]
    assert P.held_channels(P.fit_gap_prior(_turning_takes(8, 150, 1), 30.0)) is None  # no branch: none held
    with pytest.raises(ValueError, match="one joint per channel"):
        P.held_channels(prior, np.array([0, 1]))
    y = _turning_takes(1, 150, 7)[0]
    x = y.copy()
    x[90:, 0] = np.nan  # the heading lost for the take's last 2 s
    x[60:100, 2:] = np.nan  # and the other joint inside
    for kw in ({}, {"joints": joints}):
        out = P.conditional_fill(x, prior, 30.0, **kw)
        assert np.array_equal(out[~np.isnan(x)], x[~np.isnan(x)])
        assert np.allclose(out[90:, 0], y[89, 0], atol=1e-6)  # held: the field alone drifted 38 deg off it
        assert np.isfinite(out).all()
    x[90:, 1] = np.nan  # the whole joint lost: both its channels held
    out = P.conditional_fill(x, prior, 30.0, joints=joints)
    assert np.ptp(out[90:, :2], axis=0).max() < 1e-9  # held: the lean (noisy) at its reading there
    assert np.abs(out[90:, :2] - y[89, :2]).max() < 1.0
    unseen = y.copy()
    unseen[:, 0] = np.nan  # no seen end to hold: the field's fill, as before
    assert np.isfinite(P.conditional_fill(unseen, prior, 30.0, joints=joints)).all()
    inner = y.copy()
    inner[60:90, :2] = np.nan  # between two seen ends: the field's fill, near the truth
    out = P.conditional_fill(inner, prior, 30.0, joints=joints)
    assert np.abs(out[60:90, 0] - y[60:90, 0]).max() < 15.0 and np.ptp(out[60:90, 0]) > 20.0


def test_the_bandai_pelvis_lost_to_a_dances_end_is_held_not_swung(shared_data):
    """The shipped Bandai prior on the first 10 s of the dance-short take, the pelvis lost over the last 3 s: its
    fill swung the pelvis up to 112 deg off the truth (the hold: 12 deg); now it is held at its last seen frame."""
    from mocapkit import rotations as R

    path = shared_data / "secondary_bandai_namco_CC-BY-NC" / "dataset-1_dance-short_normal_001.bvh"
    if not path.is_file():
        pytest.skip(f"{path}: not there")
    take = mocapkit.load(path)[:300]
    j = take.skeleton.joint_names.index("Hips")
    rot = np.array(take.rotations)
    rot[210:, j] = np.nan
    filled = deep.fill_gaps(dataclasses.replace(take, rotations=rot))
    off = np.degrees(R.geodesic_angle(filled.rotations[210:, j], take.rotations[210:, j]))
    held = np.degrees(R.geodesic_angle(filled.rotations[210:, j], take.rotations[209, j]))
    assert off.max() < 15.0 and held.max() < 1e-3
    np.testing.assert_array_equal(filled.rotations[:210], take.rotations[:210])


def test_branch_windows_are_shifted_in_place_with_the_same_numbers():
    """branch_lagged shifts each lag's block of the windows in place: a long take's (F, C * L) windows are the fill's
    largest array (a 9-minute session: 63 MB), and the shift made three more of them; the numbers are the same."""
    import tracemalloc

    model = deep.load_model(Path(deep.__file__).resolve().parents[2] / "models" / "ebd_bandai.pt")
    pr = model.prior
    take = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh")
    x = lerp_fill(encode(take, model.layout)[0])
    v = P.lagged(x, pr.lags)
    before = v - 360.0 * np.tile(P.branch_turns(x, pr.branch), (1, len(pr.lags)))  # the expression it replaced
    assert (before != v).any()  # the take's thighs are shifted by whole turns
    tracemalloc.start()
    try:
        got = P.branch_lagged(x, pr.lags, pr.branch)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert np.array_equal(got, before) and got.dtype == before.dtype
    assert peak < 1.5 * v.nbytes  # the windows and one (F, C) array of turns; was 3 windows' worth more


def _long_bandai_windows(model, copies: int = 25):
    """A Bandai Namco take (142 frames) joined end to end ``copies`` times with gaps, its standardised lagged windows ``z`` as
    the gap prior reads them, and its missing entries."""
    from mocapkit.motion import concatenate

    pr = model.prior
    take = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "dataset-1_bye_giant_001.bvh")
    x = encode(concatenate([take] * copies), model.layout)[0]
    for k, at in enumerate(range(30, len(x) - 40, 97)):  # gaps of 2-11 frames in a few channels each
        x[at:at + 2 + k % 10, (7 * k) % x.shape[1]:(7 * k) % x.shape[1] + 3] = np.nan
    miss = np.isnan(x)
    z = P.branch_lagged(lerp_fill(x), pr.lags, pr.branch)
    z -= pr.mean
    z /= pr.scale
    return z, miss


def test_the_take_update_reads_the_complete_windows_in_place_with_the_same_numbers():
    """_take_update pools the prior with the take's complete windows: it copied them (``z[rows]``, 114 MB beside
    ``z``'s own 114 MB on an 18-minute 30 fps Bandai session); they are now moved to ``z``'s front
    (:func:`complete_rows`) and centred there, the same numbers, bit for bit."""
    import tracemalloc

    model = deep.load_model(Path(deep.__file__).resolve().parents[2] / "models" / "ebd_bandai.pt")
    pr = model.prior
    z, miss = _long_bandai_windows(model)
    rows = ~P.lagged(np.any(miss, axis=1)[:, None], pr.lags).any(axis=1)
    n = int(rows.sum())
    assert 0.5 * len(z) < n < len(z)  # gaps all over the take: most rows complete, not all
    d = z[rows]  # the computation it replaced, written out
    m = d.mean(axis=0)
    d -= m
    w = n / (n + 30.0)
    want = w * m, (1.0 - w) * pr.cov + w * (d.T @ d / n) + w * (1.0 - w) * np.outer(m, m)
    del d
    tracemalloc.start()
    try:
        got = P._take_update(z, miss, pr, 30.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    assert peak < 0.5 * z.nbytes  # no copy of the windows (it was 0.9 z.nbytes more): 1 MiB of rows, (D, D) sums


@pytest.mark.parametrize("block", [1, 3, 4096])
def test_complete_rows_are_moved_to_the_front_in_order(block):
    rng = np.random.default_rng(block)
    z = rng.normal(size=(50, 4))
    rows = rng.random(50) < 0.7
    rows[:5] = True  # rows already in place
    want, rest = z[rows], z[rows.sum():].copy()
    got = P.complete_rows(z, rows, block=block)
    assert np.array_equal(got, want) and np.shares_memory(got, z) and np.array_equal(z[rows.sum():], rest)
    with pytest.raises(ValueError, match="C-contiguous"):
        P.complete_rows(np.asfortranarray(z), rows)
