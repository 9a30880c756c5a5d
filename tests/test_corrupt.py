import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt as C
from mocapkit import metrics
from mocapkit import rotations as R


@pytest.fixture(scope="module")
def clip():
    return mocapkit.load(mocapkit.samples.path("131_01.bvh")).resample(30)


def changed_cells(a, b):
    same = (a.rotations == b.rotations).all(-1) | (np.isnan(a.rotations).all(-1) & np.isnan(b.rotations).all(-1))
    out = ~same
    out[:, 0] |= np.any(a.root_positions != b.root_positions, axis=-1)
    return out


@pytest.mark.parametrize("kind", ["noise", "uniform", "bias", "spatial", "gaps", "errors"])
def test_mask_is_exactly_what_changed_and_seeded(clip, kind):
    bad, mask = C.corrupt(clip, kind, seed=4)[:2]
    assert mask.shape == (clip.num_frames, clip.num_joints) and mask.dtype == bool and mask.any()
    np.testing.assert_array_equal(mask, changed_cells(clip, bad))
    np.testing.assert_array_equal(bad.root_positions, clip.root_positions)  # root trajectory kept clean
    again = C.corrupt(clip, kind, seed=4)[0]
    np.testing.assert_array_equal(again.rotations, bad.rotations)
    other = C.corrupt(clip, kind, seed=5)[0]
    assert not np.array_equal(other.rotations, bad.rotations, equal_nan=True)


def test_angular_noise_has_the_requested_std(clip):
    for amount in (0.1, 0.5, 0.9):
        bad, _ = C.angular_noise(clip, amount=amount, seed=0)
        names = clip.channel_names()
        rot = np.array([n.endswith("rotation") and not n.startswith(clip.skeleton.joint_names[0] + ".") for n in names])
        a, b = clip.channel_values()[:, rot], bad.channel_values()[:, rot]
        std = a.std(axis=0)
        moving = std > 1.0  # channels that move enough for Euler wrap not to matter
        d = (b - a + 180.0) % 360.0 - 180.0
        ratio = d[:, moving].std(axis=0) / std[moving]
        assert np.median(ratio) == pytest.approx(amount, rel=0.1)


def test_spatial_noise_keeps_bone_lengths_and_has_the_requested_size(clip):
    bad, _ = C.spatial_noise(clip, std_cm=1.0, seed=2)
    sk = clip.skeleton
    p = bad.global_positions()
    lengths = np.linalg.norm(p[:, 1:] - p[:, sk.parents[1:]], axis=-1)
    np.testing.assert_allclose(lengths, np.broadcast_to(np.linalg.norm(sk.offsets[1:], axis=1), lengths.shape), atol=1e-9)
    err = metrics.joint_position_rms(clip, bad)
    assert 0.5 < err < 3.0  # about sqrt(3) cm per noisy joint, less where bones pin the joint


def test_gaps_follow_the_configured_distribution(clip):
    bad, mask = C.gaps(clip, start_prob=0.002, mean_length_s=0.2, max_length_s=1.0, seed=3)
    assert np.isnan(bad.rotations[mask]).all() and not np.isnan(bad.rotations[~mask]).any()
    assert not mask[:, 0].any()  # the root is never gapped
    # run lengths: mean close to 0.2 s (capped, at least one frame)
    runs = []
    for j in range(1, clip.num_joints):
        col = np.concatenate([[0], mask[:, j].astype(int), [0]])
        d = np.diff(col)
        runs += list(np.flatnonzero(d == -1) - np.flatnonzero(d == 1))
    assert len(runs) > 5
    assert 0.1 < np.mean(runs) / clip.fps < 0.35
    long_bad, long_mask = C.gaps(clip, start_prob=0.0005, long=True, seed=1)
    assert long_mask.any()


def test_real_errors_are_visible_where_masked_only(clip):
    bad, mask, records = C.real_errors(clip, n_errors=6, seed=11)
    assert records and {r.kind for r in records} <= {"spike", "flip", "freeze", "drift", "swap"}
    angle = np.degrees(R.geodesic_angle(bad.rotations, clip.rotations))
    np.testing.assert_array_equal(bad.rotations[~mask], clip.rotations[~mask])
    for r in records:
        j = clip.skeleton.index(r.joint)
        assert mask[r.start : r.end, j].any()
        if r.kind in ("spike", "flip"):
            assert angle[r.start : r.end, j].min() >= 15.0


def test_unknown_kind_is_a_clear_error(clip):
    with pytest.raises(ValueError, match="unknown corruption kind"):
        C.corrupt(clip, "fire", seed=0)
