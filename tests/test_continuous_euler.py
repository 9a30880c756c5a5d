"""rotations.continuous_euler, the branch choice of every writer of Euler text: its numba kernel against a slow
pure-Python reference of the same rule (brute-force candidates, every split tried), and the properties a writer needs
(same rotations, fixed cells bit for bit, continuity through gimbal lock, no flip carried across a jump)."""

import itertools
import zlib

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocapkit import rotations as R


# The whole turns tried on each angle, in itertools.product order: (-3, -3, -3), (-3, -3, -2), ...
_TURNS = {n: np.array(list(itertools.product(range(-3, 4), repeat=n)), dtype=float) for n in (1, 2, 3)}


def _equivalents(a, order, period):
    """Every triple (or pair, or angle) equivalent to ``a`` within 3 turns, the branch ``a`` gives first: an array
    (candidates, n), row after row as itertools.product enumerates the turns."""
    half = period / 2
    n = len(a)
    branches = [np.array(a, dtype=float)]
    if n == 3:
        proper = order.lower()[0] == order.lower()[2]
        branches.append(np.array([a[0] + half, -a[1] if proper else half - a[1], a[2] + half]))
    return np.concatenate([b + period * _TURNS[n] for b in branches])


def _nearest(a, ref, order, period, flip):
    """Brute force: the candidate nearest ``ref`` (sum of |differences|); the first branch on a tie."""
    best, cost = None, np.inf
    cands = _equivalents(a, order, period)
    if not flip:
        cands = cands[: 7 ** len(a)]
    dist = np.abs(cands - ref).sum(axis=1).tolist()  # each row's sum as np.abs(c - ref).sum() adds it
    for i, d in enumerate(dist):  # in order, a later candidate only when nearer by more than 1e-12
        if d < cost - 1e-12:
            best, cost = cands[i], d
    return best


def _step_deg(a, b, order, degrees):
    """Geodesic angle (degrees) between the rotations of Euler angles ``a`` and ``b``, by scipy."""
    ra = Rotation.from_euler(order, a, degrees=degrees)
    rb = Rotation.from_euler(order, b, degrees=degrees)
    return np.degrees((ra.inv() * rb).magnitude())


def reference(angles, order, fixed=None, start=None, degrees=True, max_step=90.0):
    """The rule of rotations.continuous_euler, slowly: per column, runs of unfixed finite cells chained from their
    fixed ends (forward, backward), the split of least total variation nearest the middle."""
    a = np.asarray(angles, dtype=float)
    F, K, n = a.shape
    period = 360.0 if degrees else 2 * np.pi
    fixed = np.zeros((F, K), bool) if fixed is None else fixed
    out = a.copy()
    three = n == 3

    def chain(col, idx, ref, qref_angles):
        written, prev, prev_a = [], ref, qref_angles
        for r in idx:
            flip = three and _step_deg(prev_a, col[r], order, degrees) <= max_step
            w = _nearest(col[r], prev, order, period, flip)
            written.append(w)
            prev, prev_a = w, col[r]
        return written

    for k in range(K):
        col = a[:, k]
        rows = [f for f in range(F) if not np.isnan(col[f]).any()]
        t = 0
        while t < len(rows):
            if fixed[rows[t], k]:
                t += 1
                continue
            lo = t
            while t < len(rows) and not fixed[rows[t], k]:
                t += 1
            hi = t - 1
            run = rows[lo:hi + 1]
            left = col[rows[lo - 1]] if lo > 0 else None
            right = col[rows[hi + 1]] if hi + 1 < len(rows) else None
            if right is None:
                if left is not None:
                    ref = left
                elif start is not None and not np.isnan(start[k]).any():
                    ref = start[k]
                else:
                    ref = col[run[0]]
                got = chain(col, run, ref, ref)
            elif left is None:
                got = chain(col, run[::-1], right, right)[::-1]
            else:
                fw = chain(col, run, left, left)
                bw = chain(col, run[::-1], right, right)[::-1]
                mid = sum(1 for r in run if r - rows[lo - 1] <= rows[hi + 1] - r)
                costs = []
                for s in range(len(run) + 1):
                    seq = [left] + fw[:s] + bw[s:] + [right]
                    costs.append(sum(np.abs(seq[i + 1] - seq[i]).sum() for i in range(len(seq) - 1)))
                least = min(costs)
                s = min((s for s in range(len(run) + 1) if costs[s] <= least + 1e-9 * period),
                        key=lambda s: (abs(s - mid), s))
                got = fw[:s] + bw[s:]
            for r, w in zip(run, got):
                out[r, k] = w
    return out


ORDERS = ["ZYX", "YZX", "xyz", "zxz", "ZX", "y"]


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("degrees", [True, False])
def test_kernel_matches_the_slow_reference(order, degrees):
    # a seed of its own per case (Python's hash of a string changes from one process to the next)
    rng = np.random.default_rng(zlib.crc32(f"{order}-{degrees}".encode()))
    n = len(order)
    for _ in range(25):  # 300 random takes over the 12 cases; the reference's enumeration is what costs
        F, K = int(rng.integers(1, 14)), int(rng.integers(1, 4))
        scale = 1.0 if degrees else np.pi / 180
        # a random walk (small steps, some big jumps), any branch per cell, some NaN cells, some fixed ones
        steps = rng.normal(0, 15, (F, K, n)) + (rng.random((F, K, 1)) < 0.15) * rng.uniform(-300, 300, (F, K, n))
        walk = np.cumsum(steps, axis=0)
        given = R.quaternion_to_euler(R.euler_to_quaternion(walk, order), order)  # the plain conversion's branch
        wound = given + 360.0 * rng.integers(-1, 2, (F, K, n)) * (rng.random((F, K, 1)) < 0.3)
        a = wound * scale
        a[rng.random((F, K)) < 0.1] = np.nan
        fixed = rng.random((F, K)) < rng.choice([0.0, 0.3, 0.7])
        start = None if rng.random() < 0.5 else rng.uniform(-200, 200, (K, n)) * scale
        got = R.continuous_euler(a, order, fixed=fixed, start=start, degrees=degrees)
        want = reference(a, order, fixed=fixed, start=start, degrees=degrees)
        np.testing.assert_allclose(got, want, atol=1e-9, equal_nan=True)


@pytest.mark.parametrize("order", ["ZYX", "zxz", "XZ", "y"])
def test_same_rotations_fixed_and_nan_cells_bit_for_bit(order):
    rng = np.random.default_rng(1)
    a = rng.uniform(-500, 500, (40, 5, len(order)))
    a[3, 1] = np.nan
    fixed = rng.random((40, 5)) < 0.4
    out = R.continuous_euler(a, order, fixed=fixed)
    assert np.array_equal(out[fixed], a[fixed], equal_nan=True)
    assert np.isnan(out[3, 1]).all()
    ok = ~np.isnan(a).any(axis=-1)
    if len(order) == 3:  # another triple of the same rotation
        dots = np.abs(np.sum(R.euler_to_quaternion(out[ok], order) * R.euler_to_quaternion(a[ok], order), axis=-1))
        np.testing.assert_allclose(dots, 1.0, atol=1e-12)
    else:  # fewer than 3 axes: whole turns only, never the other branch
        turns = (out[ok] - a[ok]) / 360.0
        np.testing.assert_allclose(turns, np.round(turns), atol=1e-9)


def test_a_path_through_gimbal_lock_is_written_continuous():
    """The middle angle goes 30 -> 150 deg (a continuous rotation): the plain conversion folds it back at 90 and
    jumps 180 deg on the other two; the filtered angles follow the path."""
    F = 121
    path = np.stack([np.linspace(10, 40, F), np.linspace(30, 150, F), np.linspace(-20, 20, F)], axis=1)
    plain = R.quaternion_to_euler(R.euler_to_quaternion(path, "ZYX"), "ZYX")
    assert np.abs(np.diff(plain, axis=0)).max() > 170  # what a writer without the filter gives
    out = R.continuous_euler(plain, "ZYX")
    np.testing.assert_allclose(out, path, atol=1e-9)


def test_changed_cells_follow_their_fixed_neighbours_branch():
    """Anchors on the other branch (a file written that way) and +360 up: the changed cells between follow them,
    whatever branch their old (broken) values were on."""
    F = 30
    path = np.stack([np.linspace(0, 50, F), np.linspace(20, 60, F), np.linspace(5, -5, F)], axis=1)
    file = np.stack([path[:, 0] + 180 + 360, 180 - path[:, 1], path[:, 2] + 180], axis=1)  # same rotations
    plain = R.quaternion_to_euler(R.euler_to_quaternion(path, "ZYX"), "ZYX")
    fixed = np.ones(F, bool)
    fixed[10:20] = False
    out = R.continuous_euler(np.where(fixed[:, None], file, plain), "ZYX", fixed=fixed)
    np.testing.assert_allclose(out, file, atol=1e-9)


def test_a_column_with_no_fixed_cell_starts_from_start():
    path = np.stack([np.linspace(0, 50, 10), np.linspace(20, 60, 10), np.zeros(10)], axis=1)
    flipped = np.stack([path[:, 0] + 180, 180 - path[:, 1], path[:, 2] + 180], axis=1)
    out = R.continuous_euler(path, "ZYX", start=flipped[0] + [0.5, -0.5, 0.0])  # the file's (old) first frame
    np.testing.assert_allclose(out, flipped, atol=1e-9)
    np.testing.assert_array_equal(R.continuous_euler(path, "ZYX"), path)  # without: the plain conversion's branch


def test_a_jump_of_the_motion_does_not_carry_the_other_branch():
    """A T-pose frame 0 then the motion (CMU 01_01's LeftForeArm): nearest to all-zero angles is the flipped triple,
    but across a 136-degree step nothing is continuous, and the take keeps the branch the conversion gives."""
    take = np.array([[0.0, 0.0, 0.0], [154.407, -36.804, -111.358], [154.5, -36.7, -111.2], [154.6, -36.6, -111.0]])
    out = R.continuous_euler(take, "ZYX")
    np.testing.assert_array_equal(out, take)
    assert not np.array_equal(R.continuous_euler(take, "ZYX", max_step=180.0), take)  # the plain Euler filter


def test_shapes_and_errors():
    a = np.zeros((5, 3))
    assert R.continuous_euler(a, "XYZ").shape == (5, 3)
    assert R.continuous_euler(np.zeros((0, 2, 3)), "XYZ").shape == (0, 2, 3)
    with pytest.raises(ValueError, match="expected shape"):
        R.continuous_euler(np.zeros((5, 2)), "XYZ")
