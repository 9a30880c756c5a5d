"""N-mode algebra and the higher-order SVD of motion tensors (Tautges 2012, sec. 2.2.1; De Lathauwer et al. 2000).

A tensor of order N has N modes; its mode-k vectors are the columns of its
mode-k unfolding (:func:`unfold`), and the mode-k product with a matrix
(:func:`mode_product`) turns every mode-k vector by it. The higher-order SVD
(:func:`hosvd`, eq. 2.1) writes a tensor as a core tensor times one
orthonormal factor matrix per mode; :func:`reconstruct_tensor` multiplies it
back. The multilinear motion models (:mod:`.multilinear`) decompose their
motion tensors (:mod:`.motion_tensor`) with it.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = ["unfold", "mode_product", "hosvd", "reconstruct_tensor"]


# -- n-mode algebra (sec. 2.2.1) -----------------------------------------------------------


def unfold(tensor: np.ndarray, mode: int) -> np.ndarray:
    """Mode-``mode`` matricization (d_mode, prod of the other sizes): the mode-k vectors as columns."""
    t = np.asarray(tensor, dtype=np.float64)
    if not -t.ndim <= mode < t.ndim:
        raise ValueError(f"mode {mode} out of range for a tensor of order {t.ndim}")
    return np.moveaxis(t, mode, 0).reshape(t.shape[mode], -1)


def mode_product(tensor: np.ndarray, matrix: np.ndarray, mode: int) -> np.ndarray:
    """The mode-k product ``tensor x_k matrix`` (sec. 2.2.1): every mode-k vector ``v`` becomes ``matrix @ v``.

    Parameters
    ----------
    tensor : float array (d_1, ..., d_N)
    matrix : float array (e, d_k), or a row vector (d_k,) treated as (1, d_k)
        (eq. 2.2's product with one row of a mode matrix).
    mode : int
        k, counted from 0.

    Returns
    -------
    float array (d_1, ..., e, ..., d_N): mode k has size ``e`` (1 for a vector).

    >>> t = np.arange(24.0).reshape(2, 3, 4)
    >>> mode_product(t, np.ones((5, 3)), 1).shape
    (2, 5, 4)
    """
    t = np.asarray(tensor, dtype=np.float64)
    m = np.asarray(matrix, dtype=np.float64)
    if m.ndim == 1:
        m = m[None, :]
    if m.ndim != 2:
        raise ValueError(f"matrix: expected shape (e, d_k) or (d_k,), got {np.shape(matrix)}")
    if not -t.ndim <= mode < t.ndim:
        raise ValueError(f"mode {mode} out of range for a tensor of order {t.ndim}")
    if m.shape[1] != t.shape[mode]:
        raise ValueError(f"matrix has {m.shape[1]} columns but mode {mode} of the tensor has size {t.shape[mode]}")
    return np.moveaxis(np.tensordot(m, t, axes=(1, mode)), 0, mode)


def hosvd(tensor: np.ndarray, ranks=None) -> tuple[np.ndarray, list[np.ndarray]]:
    """(Truncated) higher-order SVD ``tensor ~ core x_1 U_1 ... x_N U_N`` (eq. 2.1, Fig. 2.2).

    ``U_k`` holds the leading ``r_k`` left singular vectors of the mode-k
    unfolding (orthonormal columns); the core is ``tensor x_1 U_1^T ... x_N
    U_N^T``. With full ranks the decomposition is exact. Truncation is the
    plain truncated HOSVD of the thesis (no HOOI refinement).

    Parameters
    ----------
    tensor : float array (d_1, ..., d_N)
    ranks : sequence of N ints or None, optional
        ``r_k`` per mode; None (or a None entry) keeps ``min(d_k, prod of the
        other sizes)``, the full rank of that unfolding.

    Returns
    -------
    core : float array (r_1, ..., r_N)
    factors : list of N float arrays (d_k, r_k)
    """
    t = np.asarray(tensor, dtype=np.float64)
    if not np.all(np.isfinite(t)):
        raise ValueError("hosvd: the tensor has non-finite values")
    if ranks is None:
        ranks = [None] * t.ndim
    ranks = list(ranks)
    if len(ranks) != t.ndim:
        raise ValueError(f"hosvd: {len(ranks)} ranks given for a tensor of order {t.ndim}")
    factors = []
    for k in range(t.ndim):
        A = unfold(t, k)
        r = min(A.shape) if ranks[k] is None else int(ranks[k])
        if not 1 <= r <= t.shape[k]:
            raise ValueError(f"hosvd: rank {ranks[k]} for mode {k} must be between 1 and its size {t.shape[k]}")
        U, _, _ = np.linalg.svd(A, full_matrices=False)
        if r > U.shape[1]:
            # The unfolding has fewer columns than rows: complete U by an orthonormal complement
            # (its core slices are zero, so the decomposition stays exact).
            Q, _ = np.linalg.qr(np.concatenate([U, np.eye(t.shape[k])], axis=1))
            U = np.concatenate([U, Q[:, U.shape[1] : t.shape[k]]], axis=1)
        factors.append(U[:, :r])
    core = t
    for k, U in enumerate(factors):
        core = mode_product(core, U.T, k)
    return core, factors


def reconstruct_tensor(core: np.ndarray, factors: Sequence[np.ndarray]) -> np.ndarray:
    """``core x_1 U_1 x_2 ... x_N U_N`` (eq. 2.1)."""
    out = np.asarray(core, dtype=np.float64)
    if len(factors) != out.ndim:
        raise ValueError(f"{len(factors)} factors for a core of order {out.ndim}")
    for k, U in enumerate(factors):
        out = mode_product(out, U, k)
    return out
