import dataclasses
import functools
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mocapkit
from mocapkit import corrupt as C
from mocapkit import metrics
from mocapkit import rotations as R
from mocapkit.joint_spread import joint_rotation_spread
from mocapkit.motion import Motion, Skeleton, find_joint, mirror_pairs

ALL_KINDS = C.KINDS + C.ERROR_KINDS


# -- fixtures -----------------------------------------------------------------------


def toy_skeleton() -> Skeleton:
    """A 17-joint humanoid in cm: legs and arms as chains, a chest with three children."""
    joints = [
        ("Hips", -1, [0, 0, 0]),
        ("LeftHip", 0, [9, -5, 0]), ("LeftKnee", 1, [0, -42, 0]), ("LeftAnkle", 2, [0, -40, 0]),
        ("RightHip", 0, [-9, -5, 0]), ("RightKnee", 4, [0, -42, 0]), ("RightAnkle", 5, [0, -40, 0]),
        ("Spine", 0, [0, 10, 0]), ("Chest", 7, [0, 25, 0]), ("Neck", 8, [0, 20, 0]), ("Head", 9, [0, 10, 0]),
        ("LeftShoulder", 8, [15, 15, 0]), ("LeftElbow", 11, [28, 0, 0]), ("LeftWrist", 12, [25, 0, 0]),
        ("RightShoulder", 8, [-15, 15, 0]), ("RightElbow", 14, [-28, 0, 0]), ("RightWrist", 15, [-25, 0, 0]),
    ]
    names, parents, offsets = zip(*joints)
    return Skeleton(
        names, list(parents), np.array(offsets, dtype=float),
        end_site_parents=[3, 6, 10, 13, 16],
        end_site_offsets=[[0, -5, 12], [0, -5, 12], [0, 15, 0], [8, 0, 0], [-8, 0, 0]],
        unit_cm=1.0,
    )


@functools.lru_cache(maxsize=None)
def toy_motion(frames: int = 300, fps: float = 60.0, seed: int = 0) -> Motion:
    """Smooth random joint angles (sines of 10-40 deg around a random pose) and a root walking along z."""
    sk = toy_skeleton()
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None, None] / fps
    J = sk.num_joints
    amp = rng.uniform(10, 40, size=(1, J, 3))
    freq = rng.uniform(0.3, 1.5, size=(1, J, 3))
    phase = rng.uniform(0, 2 * np.pi, size=(1, J, 3))
    base = rng.uniform(-30, 30, size=(1, J, 3))
    angles = base + amp * np.sin(2 * np.pi * freq * t + phase)
    rot = R.euler_to_quaternion(angles, "ZYX")
    root = np.stack([np.zeros(frames), 95 + np.sin(np.arange(frames) / 10), np.arange(frames) * 1.5], axis=1)
    return Motion(sk, rot, root, fps, name="toy")


@pytest.fixture(scope="module")
def bvh():
    return mocapkit.load(mocapkit.samples.path("131_01.bvh"))


@pytest.fixture(scope="module")
def amc():
    return mocapkit.load(mocapkit.samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"))


@pytest.fixture(scope="module", params=["toy", "bvh", "amc"])
def clip(request):
    if request.param == "toy":
        return toy_motion()
    return request.getfixturevalue(request.param)


def changed_cells(a, b):
    """Reference for the masks: any quaternion component or root coordinate differs (NaN == NaN)."""
    def differs(x, y):
        return ~((x == y) | (np.isnan(x) & np.isnan(y)))

    out = differs(a.rotations, b.rotations).any(-1)
    out[:, 0] |= differs(a.root_positions, b.root_positions).any(-1)
    return out


def runs(column: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Starts and ends [s, e) of True runs in a boolean vector."""
    d = np.diff(np.concatenate([[0], column.astype(int), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def wrapped(d):
    return (d + 180.0) % 360.0 - 180.0


def rotation_columns(m, include_root=False):
    sk = m.skeleton
    return np.array(
        [c.endswith("rotation") and (include_root or j > 0) for j in range(sk.num_joints) for c in sk.joint_channels(j)]
    )


# -- the contract every corruption keeps ----------------------------------------------


@pytest.mark.parametrize("kind", ALL_KINDS)
def test_mask_is_exactly_what_changed_and_seeded(clip, kind):
    rot_before, root_before = np.array(clip.rotations), np.array(clip.root_positions)
    result = C.corrupt(clip, kind, seed=4)
    bad, mask = result[:2]
    assert mask.shape == (clip.num_frames, clip.num_joints) and mask.dtype == bool and mask.any()
    np.testing.assert_array_equal(mask, changed_cells(clip, bad))
    # unmasked cells bit-identical, input untouched, root trajectory clean
    np.testing.assert_array_equal(bad.rotations[~mask], clip.rotations[~mask])
    np.testing.assert_array_equal(clip.rotations, rot_before)
    np.testing.assert_array_equal(clip.root_positions, root_before)
    np.testing.assert_array_equal(bad.root_positions, clip.root_positions)
    assert bad.skeleton is clip.skeleton and bad.fps == clip.fps
    again = C.corrupt(clip, kind, seed=4)
    np.testing.assert_array_equal(again[0].rotations, bad.rotations)
    np.testing.assert_array_equal(again[1], mask)
    other = C.corrupt(clip, kind, seed=5)[0]
    assert not np.array_equal(other.rotations, bad.rotations, equal_nan=True)
    if kind in ("errors",) + C.ERROR_KINDS:
        assert len(result) == 3 and result[2]
    else:
        assert len(result) == 2


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), kind=st.sampled_from(ALL_KINDS))
def test_mask_contract_for_any_seed(seed, kind):
    m = toy_motion()
    bad, mask = C.corrupt(m, kind, seed=seed)[:2]
    np.testing.assert_array_equal(mask, changed_cells(m, bad))
    np.testing.assert_array_equal(bad.rotations[~mask], m.rotations[~mask])
    np.testing.assert_array_equal(bad.root_positions, m.root_positions)
    # quaternions stay unit and in the input's hemisphere wherever they are present
    q = bad.rotations[mask & ~np.isnan(bad.rotations).any(-1)]
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-12)
    assert np.all(np.sum(q * m.rotations[mask & ~np.isnan(bad.rotations).any(-1)], axis=-1) >= -1e-12)


def test_a_generator_is_a_seed():
    m = toy_motion()
    a = C.angular_noise(m, seed=np.random.default_rng(7))[0]
    b = C.angular_noise(m, seed=np.random.default_rng(7))[0]
    np.testing.assert_array_equal(a.rotations, b.rotations)


# -- angular, uniform and biased noise ---------------------------------------------------


def channel_noise(clean, noisy, amount):
    """Wrapped channel differences of moving rotation channels, their clean std, and std ratio to the target."""
    cols = rotation_columns(clean)
    a, b = clean.channel_values()[:, cols], noisy.channel_values()[:, cols]
    std = a.std(axis=0)
    moving = std > 1.0  # channels that move enough for Euler wrap not to matter
    d = wrapped(b - a)[:, moving]
    return d, std[moving], d.std(axis=0) / (amount * std[moving])


# Re-reading the noisy rotations as Euler angles can land on the other Euler branch where the
# middle angle is pushed past +-90 deg: those channels then show ~180 deg jumps. Rare at 0.1/0.5.
@pytest.mark.parametrize("amount, share", [(0.1, 0.95), (0.5, 0.9), (0.9, 0.8)])
def test_angular_noise_has_the_requested_std_per_channel(bvh, amount, share):
    bad, _ = C.angular_noise(bvh, amount=amount, seed=0)
    d, std_moving, ratio = channel_noise(bvh, bad, amount)
    # ~994 frames: the sample std of one channel is within ~7% (3 sigma) of the true one
    assert np.median(ratio) == pytest.approx(1.0, abs=0.03)
    assert np.mean(np.abs(ratio - 1.0) < 0.1) > share
    assert np.median(np.abs(d.mean(axis=0)) / std_moving) < 3 * amount / np.sqrt(len(d))


def test_angular_noise_keeps_the_root_unless_asked(bvh):
    bad, mask = C.angular_noise(bvh, seed=1)
    assert not mask[:, 0].any()
    bad, mask = C.angular_noise(bvh, seed=1, include_root=True)
    assert mask[:, 0].all()
    np.testing.assert_array_equal(bad.root_positions, bvh.root_positions)
    bad, mask = C.angular_noise(bvh, seed=1, joints=["LeftKnee", "Head"])
    assert set(np.flatnonzero(mask.any(0))) == {bvh.skeleton.index("LeftKnee"), bvh.skeleton.index("Head")}


def test_noise_keeps_asf_joints_within_their_degrees_of_freedom(amc):
    for func in (C.angular_noise, C.uniform_noise, C.bias, C.spatial_noise):
        bad, mask = func(amc, seed=3)
        # joints without rotation channels are never touched
        no_dof = [j for j in range(amc.num_joints) if not amc.skeleton.rotation_order(j)]
        assert no_dof and not mask[:, no_dof].any()
        back = Motion.from_channel_values(amc.skeleton, bad.channel_values(), amc.fps)
        assert np.degrees(R.geodesic_angle(back.rotations, bad.rotations)).max() < 1e-6


def test_uniform_noise_is_bounded_with_the_same_std(bvh):
    amount = 0.5
    bad, _ = C.uniform_noise(bvh, amount=amount, seed=2)
    d, std_moving, ratio = channel_noise(bvh, bad, amount)
    assert np.median(ratio) == pytest.approx(1.0, abs=0.03)
    width = np.sqrt(3) * amount * std_moving
    inside = np.abs(d) <= width * (1 + 1e-6) + 1e-6
    assert inside.mean() > 0.99  # all but Euler-branch changes near gimbal lock


def noise_scale(m, std):
    """The noise scale of each non-root rotation channel: ``std`` (C,), at most its joint's rotation spread."""
    sk = m.skeleton
    owner = [j for j in range(1, sk.num_joints) for c in sk.joint_channels(j) if c.endswith("rotation")]
    return np.minimum(std, joint_rotation_spread(m.rotations)[owner])


def test_bias_constant_and_sinusoidal(bvh):
    cols = rotation_columns(bvh)
    a = bvh.channel_values()[:, cols]
    std = noise_scale(bvh, a.std(axis=0))
    moving = std > 1.0
    bad, _ = C.bias(bvh, amount=0.5, kind="constant", seed=0)
    d = wrapped(bad.channel_values()[:, cols] - a)[:, moving]
    np.testing.assert_allclose(np.median(np.abs(d), axis=0), 0.5 * std[moving], rtol=1e-6)
    assert np.mean(np.abs(d.std(axis=0)) < 1e-6) > 0.9  # constant per channel
    period = 1.0  # 120 frames at 120 fps
    bad, _ = C.bias(bvh, amount=0.5, kind="sinusoidal", period_s=period, seed=0)
    d = wrapped(bad.channel_values()[:, cols] - a)[:, moving]
    shift = int(period * bvh.fps)
    assert np.median(np.abs(d[shift:] - d[:-shift])) < 1e-6  # periodic
    amplitude = np.max(np.abs(d), axis=0) / (0.5 * std[moving])
    assert np.mean(np.abs(amplitude - 1.0) < 0.02) > 0.9  # all but Euler-branch changes
    with pytest.raises(ValueError, match="constant"):
        C.bias(bvh, kind="linear")
    noisy, _ = C.corrupt(bvh, "bias", seed=0, bias_kind="sinusoidal", noise=0.5)
    assert metrics.joint_angle_rms(bvh, noisy) > metrics.joint_angle_rms(bvh, bad)


# -- spatial noise -------------------------------------------------------------------------


@pytest.mark.parametrize("end_effector_scale", [1.0, 3.0])
def test_spatial_noise_keeps_bone_lengths(clip, end_effector_scale):
    bad, mask = C.spatial_noise(clip, std_cm=2.0, end_effector_scale=end_effector_scale, seed=2)
    sk = clip.skeleton
    p = bad.global_positions(end_sites=True)
    J = sk.num_joints
    parents = np.concatenate([sk.parents[1:], sk.end_site_parents])
    lengths = np.linalg.norm(p[:, 1:] - p[:, parents], axis=-1)
    rest = np.linalg.norm(np.concatenate([sk.offsets[1:], sk.end_site_offsets]), axis=1)
    np.testing.assert_allclose(lengths, np.broadcast_to(rest, lengths.shape), rtol=0, atol=1e-9)
    assert not mask[:, 0].any()  # root rotation and position clean by default
    assert J == mask.shape[1]


def test_spatial_noise_has_about_the_requested_size(bvh):
    std_cm = 1.0
    bad, _ = C.spatial_noise(bvh, std_cm=std_cm, seed=2)
    scale = mocapkit.motion.unit_scale_cm(bvh.skeleton)
    d = (bad.global_positions(end_sites=True) - bvh.global_positions(end_sites=True)) * scale
    moved = np.linalg.norm(d, axis=-1).max(axis=0) > 0
    per_axis = d[:, moved].std(axis=0).mean()
    # the noise along each bone cannot be followed (bone lengths are kept): about sqrt(2/3) of it stays
    assert 0.6 * std_cm < per_axis < 1.1 * std_cm
    assert 1.0 * std_cm < metrics.joint_position_rms(bvh, bad) < 2.0 * std_cm
    # wrists and ankles get more with end_effector_scale
    big, _ = C.spatial_noise(bvh, std_cm=std_cm, end_effector_scale=4.0, seed=2)
    sk = bvh.skeleton
    ends = [find_joint(sk, r) for r in ("left_hand", "right_hand", "left_foot", "right_foot")]

    def err(m):
        return np.linalg.norm(m.global_positions()[:, ends] - bvh.global_positions()[:, ends], axis=-1).mean() * scale

    assert err(big) > 2.0 * err(bad)


def test_spatial_noise_fits_a_branching_joint_by_least_squares():
    m = toy_motion()
    sk = m.skeleton
    bad, mask = C.spatial_noise(m, std_cm=1.0, seed=0)
    chest = sk.index("Chest")
    assert mask[:, chest].all()
    # the chest's three children move about as much as the noise, not more
    kids = sk.children(chest)
    d = np.linalg.norm(bad.global_positions()[:, kids] - m.global_positions()[:, kids], axis=-1)
    assert d.mean() < 3.0


def test_spatial_noise_leaves_missing_joints_and_their_subtrees():
    m = toy_motion()
    rot = np.array(m.rotations)
    elbow = m.skeleton.index("LeftElbow")
    rot[100:110, elbow] = np.nan
    gappy = dataclasses.replace(m, rotations=rot)
    bad, mask = C.spatial_noise(gappy, seed=0)
    assert np.isnan(bad.rotations[100:110, elbow]).all() and not mask[100:110, elbow].any()
    wrist = m.skeleton.index("LeftWrist")
    np.testing.assert_array_equal(bad.rotations[100:110, wrist], m.rotations[100:110, wrist])
    assert np.isfinite(bad.rotations[:100]).all() and np.isfinite(bad.rotations[110:]).all()


# -- gaps ------------------------------------------------------------------------------------


def test_gap_lengths_and_starts_follow_the_configured_distribution():
    m = toy_motion(frames=20000, fps=60.0)
    p, mean_s, max_s = 0.01, 0.2, 0.5
    bad, mask = C.gaps(m, start_prob=p, mean_length_s=mean_s, max_length_s=max_s, seed=3)
    assert np.isnan(bad.rotations[mask]).all() and not np.isnan(bad.rotations[~mask]).any()
    assert not mask[:, 0].any()  # the root is not gapped by default
    lengths, n_gaps, eligible = [], 0, 0
    for j in range(1, m.num_joints):
        s, e = runs(mask[:, j])
        lengths += list((e - s)[e < m.num_frames])  # the last one may be cut by the clip's end
        n_gaps += len(s)
        # frames that could start a gap: observed ones not right after a gap
        eligible += int((~mask[:, j]).sum()) - int(np.sum(e < m.num_frames))
    lengths = np.array(lengths)
    q, cap = 1.0 / (mean_s * m.fps), int(max_s * m.fps)
    expected_mean = (1 - (1 - q) ** cap) / q  # E[min(Geometric(q), cap)]
    assert lengths.mean() == pytest.approx(expected_mean, rel=0.05)
    assert lengths.min() >= 1 and lengths.max() == cap
    assert np.mean(lengths == cap) == pytest.approx((1 - q) ** (cap - 1), abs=0.03)
    assert np.mean(lengths == 1) == pytest.approx(q, abs=0.02)  # geometric: P(1) = q
    assert n_gaps / eligible == pytest.approx(p, rel=0.08)


def test_gaps_defaults_long_gaps_and_root():
    m = toy_motion(frames=6000, fps=60.0)
    bad, mask = C.gaps(m, seed=0)
    assert 0.01 < mask[:, 1:].mean() < 0.05  # about 2.5% of each joint missing
    np.testing.assert_array_equal(mask, m.missing() ^ bad.missing())
    bad, mask = C.gaps(m, start_prob=0.002, long=True, seed=1)
    lengths = []
    for j in range(1, m.num_joints):
        s, e = runs(mask[:, j])
        lengths += list((e - s)[e < m.num_frames])
    lengths = np.array(lengths) / m.fps
    assert len(lengths) > 5 and lengths.min() >= 1.0 and lengths.max() <= 5.0
    bad, mask = C.gaps(m, start_prob=0.01, joints=["Hips"], seed=2)
    assert mask[:, 0].any() and not mask[:, 1:].any()
    np.testing.assert_array_equal(np.isnan(bad.root_positions).any(-1), mask[:, 0])
    with pytest.raises(ValueError, match="probability"):
        C.gaps(m, start_prob=1.5)


def test_gaps_leave_joints_without_rotation_channels_alone():
    """The trial's `corrupt --kind gaps` gapped rhipjoint of an HDM05 take, a bone with no dof: clean then listed
    "fill" changes on a bone nothing can move. CMU 12_walk (ASF/AMC): lhipjoint and rhipjoint have no dof."""
    m = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    bare = [j for j in range(1, m.num_joints) if not m.skeleton.rotation_order(j)]
    assert {m.skeleton.joint_names[j] for j in bare} >= {"lhipjoint", "rhipjoint"}
    _, mask = C.gaps(m, start_prob=0.05, seed=0)
    assert not mask[:, bare].any()
    moving = [j for j in range(1, m.num_joints) if j not in bare]
    assert mask[:, moving].any(axis=0).all()  # every joint the file animates still gets its gaps
    _, mask = C.gaps(m, start_prob=0.05, joints=["rhipjoint"], seed=0)  # named: as asked
    assert mask[:, m.skeleton.index("rhipjoint")].any()


# -- real errors -----------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(6))
def test_real_errors_are_visible_where_masked_and_nowhere_else(clip, seed):
    bad, mask, records = C.real_errors(clip, n_errors=7, seed=seed)
    sk = clip.skeleton
    assert {r.kind for r in records} == set(C.ERROR_KINDS)  # each kind once before repeats
    assert records == sorted(records, key=lambda r: (r.start, r.joint))
    angle = np.degrees(metrics.geodesic_pose_distance(clip, bad))
    covered = np.zeros_like(mask)
    freeze = np.zeros_like(mask)
    for r in records:
        j = sk.index(r.joint)
        assert 0 <= r.start < r.end <= clip.num_frames
        assert not covered[max(r.start - 1, 0) : r.end + 1, j].any()  # no overlap, never touching
        covered[r.start : r.end, j] = True
        if r.kind == "freeze":
            freeze[r.start : r.end, j] = True
            held = clip.rotations[r.start - 1, j]
            assert np.degrees(R.geodesic_angle(bad.rotations[r.start : r.end, j], held)).max() < 1e-6
            assert angle[r.start : r.end, j].max() >= 15.0
        else:
            assert mask[r.start : r.end, j].all()
        if r.kind == "spike":
            assert r.end - r.start <= 3
        if r.kind == "swap":
            assert sk.index(r.partner) == mirror_pairs(sk.joint_names)[j]
    assert not (mask & ~covered).any()
    # the geodesic metric finds exactly the masked cells (freeze aside: it depends on the motion)
    score = metrics.precision_recall((angle >= 15.0 - 1e-6) & ~freeze, mask & ~freeze)
    assert (score.precision, score.recall) == (1.0, 1.0)
    assert np.all(angle[~mask] == 0.0)


def test_a_swap_on_a_rig_whose_frames_differ_by_side_is_a_real_swap():
    """Bandai Namco game rig (a real take): a swapped joint under an unpaired parent points its bone where the
    partner's bone points, reflected across the parent's mirror plane (the plane between the two sockets), as
    when the labels of a symmetric body swap; the plain mirror's rotations would point it elsewhere."""
    from pathlib import Path

    run = mocapkit.load(Path(__file__).resolve().parent / "data" / "dataset-2_run_active_049.bvh")
    sk = run.skeleton
    perm = mirror_pairs(sk.joint_names)
    seen = set()
    for seed in range(6):
        bad, mask, records = C.real_errors(run, kinds=("swap",), n_errors=1, seed=seed)
        r = records[0]
        j, p = sk.index(r.joint), sk.index(r.partner)
        par = int(sk.parents[j])
        if perm[par] != par:
            continue
        seen.add(sk.joint_names[par])
        n = (sk.offsets[j] - sk.offsets[p]) / np.linalg.norm(sk.offsets[j] - sk.offsets[p])
        reflect = np.eye(3) - 2.0 * np.outer(n, n)
        c = sk.children(j)[0]
        bone = R.quaternion_rotate(bad.rotations[r.start : r.end, j], sk.offsets[c])
        partner = R.quaternion_rotate(run.rotations[r.start : r.end, p], sk.offsets[perm[c]]) @ reflect.T
        cos = np.sum(bone * partner, axis=-1) / np.linalg.norm(bone, axis=-1) / np.linalg.norm(partner, axis=-1)
        assert np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).max() < 0.1, (seed, r.joint)
    assert seen == {"Chest", "Hips"}


def test_real_errors_stay_within_asf_degrees_of_freedom(amc):
    for seed in range(5):
        bad, mask, _ = C.real_errors(amc, n_errors=8, seed=seed)
        back = Motion.from_channel_values(amc.skeleton, bad.channel_values(), amc.fps)
        assert np.degrees(R.geodesic_angle(back.rotations, bad.rotations)).max() < 1e-6
        no_dof = [j for j in range(amc.num_joints) if not amc.skeleton.rotation_order(j)]
        assert not mask[:, no_dof].any()


def test_real_errors_avoid_missing_data_and_respect_joint_choice():
    m = toy_motion()
    gappy, gap_mask = C.gaps(m, start_prob=0.01, seed=0)
    bad, mask, records = C.real_errors(gappy, n_errors=10, seed=1)
    assert not (mask & gap_mask).any()
    for r in records:
        assert np.isfinite(gappy.rotations[r.start : r.end, m.skeleton.index(r.joint)]).all()
    bad, mask, records = C.real_errors(m, kinds=("spike", "drift"), joints=["LeftKnee"], n_errors=3, seed=2)
    assert {r.joint for r in records} == {"LeftKnee"} and len(records) == 3
    assert set(np.flatnonzero(mask.any(0))) == {m.skeleton.index("LeftKnee")}
    with pytest.raises(ValueError, match="unknown error kind"):
        C.real_errors(m, kinds=("wobble",))


@pytest.mark.parametrize("seed", range(4))
def test_smooth_drifts_rise_to_the_peak_and_back_without_a_step(clip, seed):
    bad, mask, records = C.smooth_drifts(clip, n_drifts=3, peak_deg=35.0, duration_s=(0.5, 1.0), seed=seed)
    sk = clip.skeleton
    assert records and {r.kind for r in records} == {"smooth_drift"}
    angle = np.degrees(R.geodesic_angle(clip.rotations, bad.rotations))
    covered = np.zeros_like(mask)
    for r in records:
        j = sk.index(r.joint)
        assert j != 0 and not covered[max(r.start - 1, 0) : r.end + 1, j].any()
        covered[r.start : r.end, j] = True
        n = r.end - r.start
        assert 0.5 * clip.fps - 1 <= n <= 1.0 * clip.fps + 1
        t = (np.arange(n) + 0.5) / n
        want = 35.0 * 0.5 * (1.0 - np.cos(2.0 * np.pi * t))  # one Euler channel: the geodesic change is the offset
        assert np.allclose(angle[r.start : r.end, j], want, atol=1e-6)
        # no step: the added angle changes by at most pi * peak / n per frame, far below any break
        assert np.abs(np.diff(angle[r.start - 1 : r.end + 1, j])).max() <= np.pi * 35.0 / n + 1e-6
    assert not (mask & ~covered).any() and mask[covered].mean() > 0.9
    assert np.array_equal(bad.rotations[~covered], clip.rotations[~covered])


def test_smooth_drifts_respect_joints_missing_data_and_refuse_bad_input():
    m = toy_motion()
    bad, mask, records = C.smooth_drifts(m, n_drifts=2, joints=["LeftKnee"], duration_s=(0.2, 0.3), seed=0)
    assert {r.joint for r in records} == {"LeftKnee"}
    assert set(np.flatnonzero(mask.any(0))) == {m.skeleton.index("LeftKnee")}
    gappy, gap_mask = C.gaps(m, start_prob=0.01, seed=0)
    _, mask, _ = C.smooth_drifts(gappy, n_drifts=4, duration_s=(0.1, 0.2), seed=1)
    assert not (mask & gap_mask).any()
    with pytest.raises(ValueError, match="peak_deg"):
        C.smooth_drifts(m, peak_deg=0.0)
    with pytest.raises(ValueError, match="duration_s"):
        C.smooth_drifts(m, duration_s=(2.0, 1.0))


def test_umbrella_dispatch_and_errors():
    m = toy_motion()
    bad, mask, records = C.corrupt(m, "flip", seed=0, n_errors=2)
    assert {r.kind for r in records} == {"flip"}
    spatial, _ = C.corrupt(m, "spatial", seed=0, amount=2.0)
    np.testing.assert_array_equal(spatial.rotations, C.spatial_noise(m, std_cm=2.0, seed=0)[0].rotations)
    with pytest.raises(ValueError, match="unknown corruption kind"):
        C.corrupt(m, "fire", seed=0)
    with pytest.raises(ValueError, match="does not apply"):
        C.corrupt(m, "gaps", seed=0, amount=0.5)


def test_aim_gives_no_rotation_for_a_bone_with_a_missing_end():
    """The swing that re-aims a bone after spatial noise: a NaN end gives NaN, never the identity."""
    rest = np.array([[1.0, 0.0, 0.0]])  # one bone: the minimal-arc branch
    cur = np.array([[[1.0, 0.0, 0.0]], [[np.nan, 0.0, 0.0]]])
    want = np.array([[[0.0, 1.0, 0.0]], [[0.0, 1.0, 0.0]]])
    q = C._aim(cur, want, rest)
    np.testing.assert_allclose(R.quaternion_rotate(q[0], [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-12)
    assert np.isnan(q[1]).all()
    two = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # two bones at an angle: the Kabsch branch
    cur2 = np.stack([two, two * np.nan])
    q2 = C._aim(cur2, np.stack([two, two]), two)
    np.testing.assert_allclose(np.abs(q2[0, 0]), 1.0, atol=1e-12)  # the same bones: no turn
    assert np.isnan(q2[1]).all()


# -- the scale of the noise on channels that wrap at +-180 deg -----------------------------


def bandai_thigh():
    """A real Bandai Namco take whose right thigh's Z channel crosses +-180 deg, and that channel's column."""
    m = mocapkit.load(Path(__file__).parent / "data" / "dataset-1_bow_active_001.bvh")
    sk = m.skeleton
    names = [f"{sk.joint_names[j]}.{ch}" for j in range(sk.num_joints) for ch in sk.joint_channels(j)]
    return m, names.index("UpperLeg_R.Zrotation")


def test_a_wrapping_channel_gets_noise_at_the_spread_of_its_motion():
    m, c = bandai_thigh()
    x = m.channel_values()[:, c]
    assert np.abs(np.diff(x)).max() > 300  # the channel crosses +-180 deg
    motion_std = np.std(np.unwrap(x, period=360.0))  # it never turns round: its unwrapped spread is its motion's
    assert motion_std < 15 < np.std(x)
    amount = 0.5
    for func in (C.angular_noise, C.uniform_noise):
        bad, _ = func(m, amount=amount, seed=4, joints=["UpperLeg_R"])
        d = wrapped(bad.channel_values()[:, c] - x)
        # 128 frames: the sample std is within ~20% of the drawn one; the raw values' std would give ~10x
        assert d.std() == pytest.approx(amount * motion_std, rel=0.2)
    bad, _ = C.bias(m, amount=amount, seed=4, joints=["UpperLeg_R"])
    np.testing.assert_allclose(np.abs(wrapped(bad.channel_values()[:, c] - x)), amount * motion_std, rtol=1e-6)
    assert C.channel_spread(x[:, None])[0] == pytest.approx(motion_std, rel=1e-9)


def test_channel_spread_reads_angles_on_the_circle():
    t = np.linspace(0, 4 * np.pi, 400)
    near_180 = wrapped(180.0 + 5.0 * np.sin(t))  # -175 .. 180 .. 175
    spins = wrapped(3.0 * np.degrees(t))  # turns round six times: its circular spread stays bounded
    still = 40.0 + 20.0 * np.sin(t)
    gappy = still.copy()
    gappy[50:80] = np.nan
    values = np.stack([near_180, spins, still, gappy, np.full_like(t, np.nan)], axis=1)
    s = C.channel_spread(values)
    assert s[0] == pytest.approx(np.std(5.0 * np.sin(t)), rel=1e-6)
    assert 90 < s[1] < 110
    # channels that never wrap: the plain nanstd of the array, bit for bit (the noise the Acclaim rigs always had)
    np.testing.assert_array_equal(s[2:4], np.nanstd(values[:, 2:4], axis=0))
    assert s[4] == 0.0
    assert C.channel_spread(np.zeros((10, 0))).shape == (0,)


@pytest.mark.parametrize("name", ["131_01.bvh", "12_walk.amc", "HDM_bk_sneak2StepsLStart_004_120.amc"])
def test_samples_get_the_plain_std_capped_at_the_joints_turn(name):
    m = mocapkit.load(mocapkit.samples.path(name))
    cols = rotation_columns(m)
    values = m.channel_values()[:, cols]
    np.testing.assert_array_equal(C.channel_spread(values), np.nanstd(values, axis=0))
    bad, _ = C.angular_noise(m, amount=0.5, seed=6)
    full = m.channel_values()
    scale = noise_scale(m, np.nanstd(values, axis=0))
    full[:, cols] += np.random.default_rng(6).normal(size=values.shape) * (0.5 * scale)
    expected = Motion.from_channel_values(m.skeleton, full, m.fps)
    assert np.degrees(R.geodesic_angle(bad.rotations, expected.rotations)).max() < 1e-6
    # the cap binds only where a joint's Euler channels move more than the joint turns: on no AMC degree of
    # freedom that moves, on the CMU BVH's elbows and knees (ZXY triples of what the AMC gives as a hinge)
    sk = m.skeleton
    owner = [sk.joint_names[j] for j in range(1, sk.num_joints) for c in sk.joint_channels(j) if c.endswith("rotation")]
    capped = {owner[k] for k in np.flatnonzero(scale < np.nanstd(values, axis=0) - 1e-9)}
    assert capped == ({"LeftKnee", "RightKnee", "LeftElbow", "RightElbow"} if name.endswith(".bvh") else set())


def test_noise_near_gimbal_lock_is_the_size_of_the_joints_turn():
    # A ZXY joint at Z = 90 (the Bandai Namco Hips) turning 120 deg about its X channel: the read-back X stops at
    # 90 and Z, Y jump by 180 (gimbal lock), so their spread (78 deg) is the Euler singularity's, not the motion's.
    sk = Skeleton(("root", "a"), [-1, 0], [[0, 0, 0], [0, 1, 0]])
    vals = np.zeros((300, 9))
    vals[:, 6:9] = [90.0, 0.0, 10.0]
    vals[:, 7] = np.linspace(0.0, 120.0, 300)
    m = Motion.from_channel_values(sk, vals, 30.0)
    assert C.channel_spread(m.channel_values()[:, 6:9]).max() > 70.0  # the singular channels
    turn = np.std(vals[:, 7])  # one-axis turn: its angle's std is how far the joint turns (34.8 deg)
    for amount in (0.1, 0.5):
        bad, _ = C.angular_noise(m, amount, seed=4)
        g = np.degrees(R.geodesic_angle(bad.rotations[:, 1], m.rotations[:, 1]))
        # each channel's noise turns the joint by its own size, each at most amount x the joint's spread
        assert np.sqrt(np.mean(g**2)) <= 1.1 * np.sqrt(3.0) * amount * turn


def test_gaps_on_a_marker_capture_and_the_others_refuse_it_in_one_line():
    """Trial T1: corrupt.gaps(load_markers(...)) raised AttributeError 'num_joints'. Gaps in markers are what the
    marker cleaning fills: the same runs per marker (NaN, residual -1), every other sample bit-identical. The
    corruptions of joint rotations refuse a marker capture in one line."""
    from pathlib import Path

    from mocapkit.errors import MocapError
    from mocapkit.io import load_markers

    take = load_markers(Path(__file__).resolve().parent / "data" / "85_02.c3d")[:300]
    out, mask = C.gaps(take, seed=1, start_prob=0.01)
    assert mask.shape == (300, take.num_markers) and 0 < mask.sum() < mask.size // 4
    assert np.array_equal(out.missing(), take.missing() | mask) and np.all(out.residuals[mask] == -1)
    assert np.array_equal(out.positions[~mask], take.positions[~mask], equal_nan=True)
    one, only = C.gaps(take, seed=1, start_prob=0.01, joints="Male:LFWT")
    assert only[:, 0].any() and not only[:, 1:].any()
    for kind in ("noise", "spike", "spatial"):
        with pytest.raises(MocapError, match=r"^85_02: corrupt\.\w+ works on skeletal takes \(joint rotations\), not "
                                             r"marker captures; corrupt\.gaps makes gaps in markers$"):
            C.corrupt(take, kind, seed=1)
