"""Tests of mocapkit._numba_quaternions: the scalar kernels agree with their array twins in mocapkit.rotations."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from mocapkit import rotations as R
from mocapkit._numba_quaternions import qexp, qmul, qrot


@numba.njit
def _batch(q, p, v, r):
    """The three helpers applied row by row, as a kernel calls them: (N, 4) products, (N, 3) rotated, (N, 4) exps."""
    n = q.shape[0]
    prod = np.empty((n, 4))
    rot = np.empty((n, 3))
    ex = np.empty((n, 4))
    for i in range(n):
        prod[i, 0], prod[i, 1], prod[i, 2], prod[i, 3] = qmul(q[i, 0], q[i, 1], q[i, 2], q[i, 3],
                                                             p[i, 0], p[i, 1], p[i, 2], p[i, 3])
        rot[i, 0], rot[i, 1], rot[i, 2] = qrot(q[i, 0], q[i, 1], q[i, 2], q[i, 3], v[i, 0], v[i, 1], v[i, 2])
        ex[i, 0], ex[i, 1], ex[i, 2], ex[i, 3] = qexp(r[i, 0], r[i, 1], r[i, 2])
    return prod, rot, ex


@pytest.fixture(scope="module")
def samples():
    rng = np.random.default_rng(5)
    q = rng.normal(size=(64, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    p = rng.normal(size=(64, 4))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    v = rng.normal(scale=10.0, size=(64, 3))
    r = rng.normal(size=(64, 3)) * rng.choice([1e-14, 1e-7, 1e-3, 1.0, 3.0], size=(64, 1))  # near zero to near pi
    return q, p, v, r


def test_qmul_is_the_hamilton_product(samples):
    q, p, v, r = samples
    prod, _, _ = _batch(q, p, v, r)
    np.testing.assert_allclose(prod, R.quaternion_multiply(q, p), atol=1e-14)


def test_qrot_rotates_like_quaternion_rotate(samples):
    q, p, v, r = samples
    _, rot, _ = _batch(q, p, v, r)
    np.testing.assert_allclose(rot, R.quaternion_rotate(q, v), atol=1e-12)


def test_qexp_matches_rotvec_to_quaternion_near_zero_and_far(samples):
    q, p, v, r = samples
    _, _, ex = _batch(q, p, v, r)
    np.testing.assert_allclose(np.linalg.norm(ex, axis=1), 1.0, atol=1e-15)
    ref = R.rotvec_to_quaternion(r)
    ref = ref * np.where(np.sum(ref * ex, axis=1, keepdims=True) < 0, -1.0, 1.0)  # q and -q: the same rotation
    np.testing.assert_allclose(ex, ref, atol=1e-14)


def test_quaternion_multiply_runs_the_numba_loop_with_numpys_numbers_bit_for_bit(monkeypatch):
    """From KERNEL_ROWS rows quaternion_multiply is multiply_rows: each finite product the same bits as the numpy
    reference (values spread over 1e-150..1e150, signed zeros, broadcasting one joint's rotation over frames); an
    input or result that is not finite (NaN, inf, an overflow) gets numpy's bits, NaN signs included."""
    import mocapkit._numba_quaternions as NQ

    calls = []
    real = NQ.multiply_rows
    monkeypatch.setattr(NQ, "multiply_rows", lambda a, b, out: calls.append(len(a)) or real(a, b, out))
    rng = np.random.default_rng(11)
    F, J = 900, 7
    a = rng.normal(size=(F, J, 4)) * np.exp(rng.normal(size=(F, J, 4)) * 60.0)
    b = rng.normal(size=(F, J, 4))
    a[rng.random(a.shape) < 0.02] = 0.0
    b[rng.random(b.shape) < 0.02] = -0.0

    def same(x, y):
        return x.shape == y.shape and np.array_equal(x.view(np.uint64), y.view(np.uint64))

    assert F * J >= R.KERNEL_ROWS
    assert same(R.quaternion_multiply(a, b), R.quaternion_multiply_numpy(a, b)) and calls == [F * J]
    axes = b[0]  # (J, 4) against (F, J, 4), either side
    assert same(R.quaternion_multiply(axes, a), R.quaternion_multiply_numpy(axes, a))
    conj = R.quaternion_conjugate(a)
    assert same(R.quaternion_multiply(conj, axes), R.quaternion_multiply_numpy(conj, axes))
    frozen = a.copy()
    frozen.flags.writeable = False  # as a Motion's rotations: copied, so the kernel has one signature
    assert same(R.quaternion_multiply(frozen[:, ::-1], b), R.quaternion_multiply_numpy(frozen[:, ::-1], b))
    assert len(calls) == 4 and len(real.signatures) == 1
    bad = a.copy()
    bad[5, 2] = np.nan
    bad[7, 3, 1] = np.inf
    with np.errstate(invalid="ignore", over="ignore"):
        assert same(R.quaternion_multiply(bad, b), R.quaternion_multiply_numpy(bad, b))
        huge = np.full((F, J, 4), 1e300)
        assert same(R.quaternion_multiply(huge, huge), R.quaternion_multiply_numpy(huge, huge))  # overflow: inf - inf
    assert len(calls) == 6  # the loop ran, then numpy's
    small = a[:10]
    assert same(R.quaternion_multiply(small, b[:10]), R.quaternion_multiply_numpy(small, b[:10])) and len(calls) == 6
