"""Dynamic time warping: classic global DTW and subsequence DTW over a motion database.

Conventions. Query frames are indexed by ``n`` (rows, ``0 .. M-1``), database
frames by ``m`` (columns, ``0 .. N-1``). The local cost ``C(n, m)`` is the
Euclidean distance between the feature rows (what a kd-tree reports), or a
precomputed matrix. A feature row with a non-finite value has infinite local
cost against everything; nothing raises on missing data.

Two step-size conditions are offered (``steps=``):

``"classic"``
    Steps ``(1, 1)``, ``(1, 0)``, ``(0, 1)`` with unit weights: the cost of a
    path is the plain sum of the local costs of its cells. For subsequence DTW
    (Müller 2007, sec. 4.4) this is ``D(0, m) = C(0, m)`` (free start) and
    ``D(n, m) = C(n, m) + min(D(n-1, m-1), D(n, m-1), D(n-1, m))``. It is
    exactly the path cost of the lazy neighbourhood graph (Krüger et al. 2010,
    sec. 4.1): nodes cost their local distance, edges are the diagonal step,
    the "next database frame, same query frame" step and the "same database
    frame, next query frame" step, so the graph's optimal paths are these
    paths whenever all their cells are among the reported neighbours.
``"tautges"``
    Tautges (2012) eq. 4.2: steps ``(1, 1)`` and ``(1, 2)`` with weight 1 and
    ``(2, 1)`` with weight 2 (the skipped query frame is paid for), so slopes
    stay within ``[1/2, 2]`` and the cost is a sum of ``M`` weighted local
    costs whatever the alignment; the classic unit-weight subsequence DTW is
    biased towards short paths (Tautges sec. 4.3.3). The first row is
    ``D(0, m) = C(0, m)`` and ``D(n, m) = inf`` at the first frame of a clip for
    ``n > 0``. The cost of a path is ``sum C(cell) * w`` with ``w`` the query
    advance of the step into the cell (1 for the first cell).

Database structure. ``clip_ids (N,)`` marks which frames are consecutive frames
of one clip; no step ever connects two clips (at the first frame of a clip only
steps within the same database frame are allowed). ``exclude (N,)`` marks
frames no path may use. A frame is *unusable* when it is excluded or its local
cost is infinite for every query frame (a NaN feature row); a ``(1, 2)`` step
may not skip over an unusable frame, so a match's database range
``[start, end]`` never contains one (for the classic steps this holds anyway:
classic paths visit every frame of their range).

Tie-breaking (deterministic, the same everywhere, oracles included): among the
predecessors of a cell with equal accumulated cost, the **diagonal** step wins,
then the step that advances **further in the database** (``(0, 1)``, resp.
``(1, 2)``), then the step that advances **further in the query** (``(1, 0)``,
resp. ``(2, 1)``). Candidate match ends with equal cost are taken in increasing
database index.

Memory. :func:`subsequence_dtw` and :func:`subsequence_dtw_costs` run column by
column (one database frame at a time) and keep O(M) state plus O(N) outputs;
for every cell they carry the database index where its optimal path started
(Müller's trick), so the full ``M x N`` matrix is never stored. The local cost
is computed inside the numba kernel from the feature rows. Matches' warping
paths are then recovered by a global DTW restricted to the matched range with
both ends fixed, whose cost equals the subsequence cost bit for bit (the
restricted paths are a subset of the subsequence paths that contains an
optimal one; floating-point sums are monotone in their terms).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .matches import Match

__all__ = [
    "STEPS",
    "local_cost_matrix",
    "dtw",
    "accumulated_cost",
    "subsequence_dtw",
    "subsequence_dtw_costs",
]

STEPS = ("classic", "tautges")

_INF = np.inf
_CLIP_START = np.uint8(1)
_EXCLUDED = np.uint8(2)
# local_cost_matrix works on blocks of about this many cells (8 bytes each).
_CHUNK_CELLS = 1 << 21

# direction codes of the global DTW backtracking table
_DIAG = 0
_DB = 1  # classic (0, 1): same query frame, previous database frame; tautges (1, 2)
_QUERY = 2  # classic (1, 0): previous query frame, same database frame; tautges (2, 1)
_NONE = 3


# -- input checks -----------------------------------------------------------------------


_ROWS = {"query": "M", "data": "N", "x": "n", "y": "m"}


def _features(name: str, x, ncols: int | None = None) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2:
        raise ValueError(f"{name}: expected shape ({_ROWS[name]}, D), got {a.shape}")
    if ncols is not None and a.shape[1] != ncols:
        raise ValueError(f"{name}: expected {ncols} feature columns like the query, got shape {a.shape}")
    return np.ascontiguousarray(a)


def _check_steps(steps) -> bool:
    """True for the Tautges steps."""
    if steps not in STEPS:
        raise ValueError(f"steps: expected one of {STEPS}, got {steps!r}")
    return steps == "tautges"


def _cost_matrix(cost, shape=None) -> np.ndarray:
    """A Fortran-ordered float64 copy of a local cost matrix, NaN replaced by inf."""
    c = np.asarray(cost, dtype=np.float64)
    if c.ndim != 2:
        raise ValueError(f"cost: expected shape (M, N), got {c.shape}")
    if shape is not None and c.shape != shape:
        raise ValueError(f"cost: expected shape {shape}, got {c.shape}")
    c = np.array(c, dtype=np.float64, order="F", copy=True)
    c[np.isnan(c)] = _INF
    if np.any(c < 0):
        raise ValueError("cost: local costs must be non-negative")
    return c


def _flags(n_frames: int, clip_ids, exclude) -> np.ndarray:
    """Per database frame: bit 1 = first frame of a clip, bit 2 = excluded."""
    flags = np.zeros(n_frames, dtype=np.uint8)
    if n_frames == 0:
        return flags
    if clip_ids is None:
        flags[0] = _CLIP_START
    else:
        ids = np.asarray(clip_ids)
        if ids.shape != (n_frames,):
            raise ValueError(f"clip_ids: expected shape ({n_frames},), got {ids.shape}")
        if ids.dtype.kind not in "iub":
            raise ValueError(f"clip_ids: expected integers, got dtype {ids.dtype}")
        flags[0] = _CLIP_START
        flags[1:][ids[1:] != ids[:-1]] = _CLIP_START
    if exclude is not None:
        ex = np.asarray(exclude)
        if ex.shape != (n_frames,):
            raise ValueError(f"exclude: expected shape ({n_frames},), got {ex.shape}")
        if ex.dtype != np.bool_:
            raise ValueError(f"exclude: expected a boolean mask, got dtype {ex.dtype}")
        flags[ex] |= _EXCLUDED
    return flags


def _query_arrays(q: np.ndarray):
    """The query transposed to (D, M) with bad rows zeroed, and a per-row penalty (0 or inf)."""
    bad = ~np.isfinite(q).all(axis=1)
    qT = np.ascontiguousarray(np.where(bad[:, None], 0.0, q).T)
    pen = np.where(bad, _INF, 0.0)
    return qT, pen


# Every 2-D array a kernel takes is C-ordered (the cost matrix and the recorded matrix transposed, (N, M)): numba
# types an array that is both C- and F-contiguous (one row or one column) as C, so an F-ordered argument would
# compile the kernel again for each such shape; C-ordered ones give one signature per kernel, whatever the shapes.
_DUMMY_C = np.zeros((2, 2))


class _Problem:
    """Validated inputs of a subsequence search, in the layout the kernels want."""

    def __init__(self, query, data, clip_ids, exclude, cost, steps):
        self.tautges = _check_steps(steps)
        if cost is not None:
            if query is not None or data is not None:
                raise ValueError("give either query and data, or cost (with query=None, data=None), not both")
            self.CT = _cost_matrix(cost).T  # (N, M), C-ordered
            self.N, self.M = self.CT.shape
            self.use_cost = True
            self.query_ok = True
            self.q = self.qT = self.data = _DUMMY_C
            self.qpen = np.zeros(self.M)
        else:
            if query is None or data is None:
                raise ValueError("give query and data, or a precomputed cost matrix")
            self.q = _features("query", query)
            self.data = _features("data", data, self.q.shape[1])
            self.M, self.N = self.q.shape[0], self.data.shape[0]
            self.use_cost = False
            self.CT = _DUMMY_C
            self.qT, self.qpen = _query_arrays(self.q)
            self.query_ok = not np.isinf(self.qpen).any()
        if self.M == 0:
            raise ValueError("query: expected at least one frame, got 0")
        self.flags = _flags(self.N, clip_ids, exclude)

    def run(self, record: bool):
        end_costs = np.empty(self.N)
        starts = np.empty(self.N, dtype=np.int64)
        full_t = np.empty((self.N, self.M)) if record else _DUMMY_C
        kernel = _sdtw_tautges if self.tautges else _sdtw_classic
        kernel(self.qT, self.qpen, self.data, self.CT, self.use_cost, self.flags, record, full_t, end_costs, starts)
        starts[~np.isfinite(end_costs)] = -1
        return end_costs, starts, (full_t.T if record else None)

    def window_cost(self, start: int, end: int) -> np.ndarray:
        """Local costs (M, end - start + 1) of the database range, bit-identical to the kernel's."""
        if self.use_cost:
            out = np.array(self.CT[start : end + 1].T, order="C")
        else:
            out = np.empty((self.M, end - start + 1))
            _window_cost(self.qT, self.qpen, self.data, start, end, out)
        m = np.nonzero(self.flags[start : end + 1] & _EXCLUDED)[0]
        out[:, m] = _INF
        return out


# -- local costs ----------------------------------------------------------------------------


def local_cost_matrix(query, data) -> np.ndarray:
    """Euclidean distances between every query frame and every database frame.

    Vectorised numpy, computed in blocks of database frames so that the
    temporary memory stays bounded; the squared differences are summed feature
    by feature in order, exactly as the DTW kernels do, so the values are
    bit-identical to the costs they use. Rows with a non-finite value give
    ``inf``.

    Parameters
    ----------
    query : float array (M, D)
    data : float array (N, D)

    Returns
    -------
    C : float array (M, N)
        ``C[n, m] = ||query[n] - data[m]||`` in feature units.

    Examples
    --------
    >>> local_cost_matrix([[0.0, 0.0], [np.nan, 1.0]], [[3.0, 4.0], [0.0, 1.0]])
    array([[ 5.,  1.],
           [inf, inf]])
    """
    q = _features("query", query)
    x = _features("data", data, q.shape[1])
    M, D = q.shape
    N = x.shape[0]
    qbad = ~np.isfinite(q).all(axis=1)
    xbad = ~np.isfinite(x).all(axis=1)
    q = np.where(qbad[:, None], 0.0, q)
    x = np.where(xbad[:, None], 0.0, x)
    out = np.empty((M, N))
    step = max(1, _CHUNK_CELLS // max(1, M))
    with np.errstate(over="ignore"):
        for a in range(0, N, step):
            b = min(N, a + step)
            acc = np.zeros((M, b - a))
            for d in range(D):
                t = q[:, d, None] - x[None, a:b, d]
                acc += t * t
            out[:, a:b] = np.sqrt(acc)
    out[qbad, :] = _INF
    out[:, xbad] = _INF
    return out


@njit(cache=True, inline="always")
def _features_column(qT, qpen, data, m, c):
    """c[n] = ||query[n] - data[m]|| for all n; returns False (and c = inf) for a non-finite data row.

    The squares are added feature by feature in order (``((0 + t0^2) + t1^2) + ...``),
    four features per pass over the column, which is bit-identical to
    :func:`local_cost_matrix`.
    """
    M = c.shape[0]
    D = qT.shape[0]
    s = 0.0
    for d in range(D):
        s += data[m, d] * 0.0
    if s != 0.0:  # NaN: the row holds a NaN or an infinity
        for n in range(M):
            c[n] = np.inf
        return False
    for n in range(M):
        c[n] = 0.0
    d = 0
    while d + 4 <= D:
        x0 = data[m, d]
        x1 = data[m, d + 1]
        x2 = data[m, d + 2]
        x3 = data[m, d + 3]
        for n in range(M):
            t0 = qT[d, n] - x0
            t1 = qT[d + 1, n] - x1
            t2 = qT[d + 2, n] - x2
            t3 = qT[d + 3, n] - x3
            c[n] = (((c[n] + t0 * t0) + t1 * t1) + t2 * t2) + t3 * t3
        d += 4
    while d < D:
        x0 = data[m, d]
        for n in range(M):
            t0 = qT[d, n] - x0
            c[n] += t0 * t0
        d += 1
    for n in range(M):
        c[n] = math.sqrt(c[n]) + qpen[n]
    return True


@njit(cache=True, inline="always")
def _load_column(qT, qpen, data, CT, use_cost, flag, m, c):
    """Fill c with the local costs of database frame m (from the transposed cost matrix ``CT`` (N, M) when
    ``use_cost``); returns whether the frame is usable."""
    M = c.shape[0]
    if flag & 2:
        for n in range(M):
            c[n] = np.inf
        return False
    if use_cost:
        for n in range(M):
            c[n] = CT[m, n]
    else:
        if not _features_column(qT, qpen, data, m, c):
            return False
    for n in range(M):
        if c[n] < np.inf:
            return True
    return False


@njit(cache=True)
def _window_cost(qT, qpen, data, start, end, out):
    c = np.empty(out.shape[0])
    for m in range(start, end + 1):
        _features_column(qT, qpen, data, m, c)
        for n in range(out.shape[0]):
            out[n, m - start] = c[n]


# -- subsequence kernels ------------------------------------------------------------------


# The kernels carry path starts as float64 (exact below 2**53): an int64 select
# compiles to cmov, which LLVM turns into a badly predicted branch on the
# loop-carried chain (several times slower), a float select to a masked move.
# Where the float select still became a branch (Tautges' kernel) the start is
# chosen by the arithmetic blend ``s + t * (s2 - s)``, t in {0, 1}, exact on
# integers. The columns live in ring buffers of rows of one
# 2D array, which LLVM vectorises better than swapped 1D arrays.


@njit(cache=True)
def _sdtw_classic(qT, qpen, data, CT, use_cost, flags, record, full_t, end_costs, starts):
    """Subsequence DTW with the classic unit-weight steps, one database column at a time.

    Keeps the previous column of D and of the path starts; writes the last row
    (end_costs, starts) and, when ``record``, the whole matrix transposed into
    ``full_t`` (N, M). ``CT``: the local costs transposed (N, M), read when ``use_cost``.
    """
    M = qpen.shape[0]
    N = flags.shape[0]
    c = np.empty(M)
    RD = np.full((2, M), np.inf)
    RS = np.full((2, M), -1.0)
    for m in range(N):
        fl = flags[m]
        _load_column(qT, qpen, data, CT, use_cost, fl, m, c)
        cD = RD[m & 1]
        cS = RS[m & 1]
        pD = RD[1 - (m & 1)]
        pS = RS[1 - (m & 1)]
        cur = c[0]
        cs = float(m)
        cD[0] = cur
        cS[0] = cs
        if fl & 1:
            # first frame of a clip: only the step (n-1, m) -> (n, m)
            for n in range(1, M):
                cur = c[n] + cur
                cD[n] = cur
                cS[n] = cs
        else:
            for n in range(1, M):
                # diagonal, then (n, m-1) [database advance], then (n-1, m) [query advance]
                d = pD[n - 1]
                ds = pS[n - 1]
                v = pD[n]
                vs = pS[n]
                t = v < d
                b = v if t else d
                bs = vs if t else ds
                u = cur < b
                b = cur if u else b
                cs = cs if u else bs
                cur = c[n] + b
                cD[n] = cur
                cS[n] = cs
        end_costs[m] = cD[M - 1]
        starts[m] = np.int64(cS[M - 1])
        if record:
            for n in range(M):
                full_t[m, n] = cD[n]


@njit(cache=True)
def _sdtw_tautges(qT, qpen, data, CT, use_cost, flags, record, full_t, end_costs, starts):
    """Subsequence DTW with Tautges' eq. 4.2 steps, keeping the two previous columns (arguments as
    :func:`_sdtw_classic`'s)."""
    M = qpen.shape[0]
    N = flags.shape[0]
    c = np.empty(M)
    RD = np.full((3, M), np.inf)
    RS = np.full((3, M), -1.0)
    prev_ok = False  # column m-1 may be skipped by a (1, 2) step into column m
    for m in range(N):
        fl = flags[m]
        usable = _load_column(qT, qpen, data, CT, use_cost, fl, m, c)
        i = m % 3
        cD = RD[i]
        cS = RS[i]
        pD = RD[(i + 2) % 3]
        pS = RS[(i + 2) % 3]
        ppD = RD[(i + 1) % 3]
        ppS = RS[(i + 1) % 3]
        cD[0] = c[0]
        cS[0] = float(m)
        if fl & 1:
            for n in range(1, M):
                cD[n] = np.inf
                cS[n] = -1.0
        elif M > 1:
            # n = 1: no (2, 1) step
            b = pD[0] + c[1]
            bs = pS[0]
            if prev_ok:
                v = ppD[0] + c[1]
                t = 1.0 if v < b else 0.0
                b = v if v < b else b
                bs = bs + t * (ppS[0] - bs)
            cD[1] = b
            cS[1] = bs
            # diagonal, then (1, 2) [database advance], then (2, 1) [query advance];
            # no dependency along the column, so these loops vectorise
            if prev_ok:
                for n in range(2, M):
                    cn = c[n]
                    b = pD[n - 1] + cn
                    bs = pS[n - 1]
                    v = ppD[n - 1] + cn
                    t = 1.0 if v < b else 0.0
                    b = v if v < b else b
                    bs = bs + t * (ppS[n - 1] - bs)
                    v = pD[n - 2] + 2.0 * cn
                    t = 1.0 if v < b else 0.0
                    cD[n] = v if v < b else b
                    cS[n] = bs + t * (pS[n - 2] - bs)
            else:
                for n in range(2, M):
                    cn = c[n]
                    b = pD[n - 1] + cn
                    bs = pS[n - 1]
                    v = pD[n - 2] + 2.0 * cn
                    t = 1.0 if v < b else 0.0
                    cD[n] = v if v < b else b
                    cS[n] = bs + t * (pS[n - 2] - bs)
        # a (1, 2) step into column m+1 skips column m: allowed when m is usable and
        # m, m+1 lie in one clip (the latter is checked through column m+1's own flag)
        prev_ok = usable and not (fl & 1)
        end_costs[m] = cD[M - 1]
        starts[m] = np.int64(cS[M - 1])
        if record:
            for n in range(M):
                full_t[m, n] = cD[n]


# -- global DTW ---------------------------------------------------------------------------------


@njit(cache=True)
def _global_dtw(C, tautges, usable):
    """Global DTW over a local cost matrix (n, m), both ends fixed; returns (cost, path (L, 2))."""
    n_, m_ = C.shape
    D = np.full((n_, m_), np.inf)
    arg = np.full((n_, m_), _NONE, dtype=np.uint8)
    D[0, 0] = C[0, 0]
    for i in range(n_):
        for j in range(m_):
            if i == 0 and j == 0:
                continue
            cij = C[i, j]
            b = np.inf
            a = _NONE
            if tautges:
                if i >= 1 and j >= 1:
                    b = D[i - 1, j - 1] + cij
                    a = _DIAG
                    if j >= 2 and usable[j - 1]:
                        v = D[i - 1, j - 2] + cij
                        if v < b:
                            b = v
                            a = _DB
                    if i >= 2:
                        v = D[i - 2, j - 1] + 2.0 * cij
                        if v < b:
                            b = v
                            a = _QUERY
            else:
                if i >= 1 and j >= 1:
                    b = D[i - 1, j - 1]
                    a = _DIAG
                if j >= 1:
                    v = D[i, j - 1]
                    if a == _NONE or v < b:
                        b = v
                        a = _DB
                if i >= 1:
                    v = D[i - 1, j]
                    if a == _NONE or v < b:
                        b = v
                        a = _QUERY
                b = cij + b
            D[i, j] = b
            arg[i, j] = a
    cost = D[n_ - 1, m_ - 1]
    if not cost < np.inf:
        return np.inf, np.empty((0, 2), dtype=np.int64)
    # backtrack
    path = np.empty((n_ + m_, 2), dtype=np.int64)
    i, j = n_ - 1, m_ - 1
    L = 0
    while True:
        path[L, 0] = i
        path[L, 1] = j
        L += 1
        if i == 0 and j == 0:
            break
        a = arg[i, j]
        if a == _DIAG:
            i -= 1
            j -= 1
        elif a == _DB:
            if tautges:
                i -= 1
                j -= 2
            else:
                j -= 1
        else:
            if tautges:
                i -= 2
                j -= 1
            else:
                i -= 1
    return cost, path[:L][::-1].copy()


def _usable_columns(C: np.ndarray) -> np.ndarray:
    return ~np.isinf(C).all(axis=0)


def dtw(x=None, y=None, cost=None, steps: str = "classic"):
    """Classic global DTW between two feature sequences (or over a local cost matrix).

    Boundary (the path runs from ``(0, 0)`` to ``(n-1, m-1)``), monotonicity
    and continuity; steps ``(1, 1)``, ``(1, 0)``, ``(0, 1)`` with unit weights,
    so the cost is the sum of the local costs along the path (Müller 2007,
    sec. 4.1). ``steps="tautges"`` uses the slope-limited steps and weights of
    Tautges (2012) eq. 4.2 instead (a ``(1, 2)`` step never skips a column whose
    local costs are all infinite). Ties: diagonal, then the database step,
    then the query step (see the module notes).

    Parameters
    ----------
    x : float array (n, D)
    y : float array (m, D)
    cost : float array (n, m), optional
        Precomputed local costs, instead of ``x`` and ``y`` (``dtw(cost=C)``).
    steps : {"classic", "tautges"}

    Returns
    -------
    cost : float
        Accumulated cost of the optimal path; ``inf`` when no path has finite cost.
    path : int64 array (L, 2)
        Rows ``(i, j)`` from ``(0, 0)`` to ``(n-1, m-1)``; empty (0, 2) when the
        cost is infinite.

    Examples
    --------
    >>> cost, path = dtw([[0.0], [1.0], [2.0]], [[0.0], [0.0], [1.0], [2.5]])
    >>> cost
    0.5
    >>> path.tolist()
    [[0, 0], [0, 1], [1, 2], [2, 3]]
    """
    tautges = _check_steps(steps)
    if cost is not None:
        if x is not None or y is not None:
            raise ValueError("give either x and y, or cost, not both")
        C = np.ascontiguousarray(_cost_matrix(cost))
    else:
        if x is None or y is None:
            raise ValueError("give x and y, or a precomputed cost matrix")
        xa = _features("x", x)
        ya = _features("y", y, xa.shape[1])
        qT, pen = _query_arrays(xa)
        C = np.empty((xa.shape[0], ya.shape[0]))
        if C.size:
            _window_cost(qT, pen, ya, 0, ya.shape[0] - 1, C)
    if C.shape[0] == 0 or C.shape[1] == 0:
        raise ValueError(f"dtw: both sequences need at least one frame, got cost shape {C.shape}")
    c, path = _global_dtw(C, tautges, _usable_columns(C))
    return float(c), path


# -- subsequence DTW ---------------------------------------------------------------------------


def accumulated_cost(query, data, clip_ids=None, steps: str = "classic", cost=None, exclude=None) -> np.ndarray:
    """The full subsequence-DTW accumulated cost matrix (for tests, figures and small inputs).

    ``steps="classic"``: ``D(0, m) = C(0, m)`` and
    ``D(n, m) = C(n, m) + min(D(n-1, m-1), D(n, m-1), D(n-1, m))`` (Müller 2007,
    sec. 4.4, unit weights; at the first frame of a clip only ``D(n-1, m)``).
    ``steps="tautges"``: Tautges (2012) eq. 4.2 with ``D = inf`` outside the
    matrix and at the first frame of each clip for ``n > 0``. See the module
    notes for clips, excluded frames and ties. Memory is O(M N): use
    :func:`subsequence_dtw_costs` for large databases.

    Parameters
    ----------
    query : float array (M, D) or None
    data : float array (N, D) or None
    clip_ids : int array (N,), optional
        Clip of every database frame; ``None`` is one clip.
    steps : {"classic", "tautges"}
    cost : float array (M, N), optional
        Precomputed local costs instead of ``query`` and ``data`` (both None).
    exclude : bool array (N,), optional
        Database frames no path may use.

    Returns
    -------
    D : float array (M, N)

    Examples
    --------
    >>> accumulated_cost([[0.0], [1.0]], [[1.0], [0.0], [1.0], [3.0]])
    array([[1., 0., 1., 3.],
           [1., 1., 0., 2.]])
    """
    prob = _Problem(query, data, clip_ids, exclude, cost, steps)
    if prob.N == 0:
        return np.empty((prob.M, 0))
    _, _, full = prob.run(record=True)
    return np.ascontiguousarray(full)


def subsequence_dtw_costs(query, data, clip_ids=None, steps: str = "classic", exclude=None, cost=None):
    """Last row of the subsequence-DTW matrix and where each optimal path starts, in O(N) memory.

    Computes :func:`accumulated_cost` column by column, keeping only the
    columns the recursion needs, and carries for every cell the database index
    of the first cell of its optimal path (Müller 2007, sec. 4.4).

    Parameters
    ----------
    query : float array (M, D) or None
    data : float array (N, D) or None
    clip_ids, steps, exclude, cost
        As in :func:`accumulated_cost`.

    Returns
    -------
    end_costs : float array (N,)
        ``D(M-1, m)``: cost of the best alignment of the whole query that ends
        at database frame ``m`` (``inf`` where none exists).
    starts : int64 array (N,)
        Database frame where that alignment starts; -1 where the cost is ``inf``.

    Examples
    --------
    >>> costs, starts = subsequence_dtw_costs([[0.0], [1.0]], [[1.0], [0.0], [1.0], [3.0]])
    >>> costs
    array([1., 1., 0., 2.])
    >>> starts
    array([0, 1, 1, 1])
    """
    prob = _Problem(query, data, clip_ids, exclude, cost, steps)
    if prob.N == 0:
        return np.empty(0), np.empty(0, dtype=np.int64)
    end_costs, starts, _ = prob.run(record=False)
    return end_costs, starts


@njit(cache=True)
def _select(order, starts, k, max_overlap, acc_s, acc_e, n_acc):
    """Greedy scan of candidate ends (in the given order); appends accepted ranges, returns the count."""
    for i in range(order.shape[0]):
        if n_acc >= k:
            break
        e = order[i]
        s = starts[e]
        ok = True
        for j in range(n_acc):
            lo = s if s > acc_s[j] else acc_s[j]
            hi = e if e < acc_e[j] else acc_e[j]
            if hi - lo + 1 > max_overlap:
                ok = False
                break
        if ok:
            acc_s[n_acc] = s
            acc_e[n_acc] = e
            n_acc += 1
    return n_acc


def _select_matches(end_costs, starts, k, max_overlap):
    """The ends of the k best mutually (nearly) non-overlapping alignments, by (cost, end index)."""
    finite = np.isfinite(end_costs)
    n_fin = int(finite.sum())
    acc_s = np.empty(k, dtype=np.int64)
    acc_e = np.empty(k, dtype=np.int64)
    if n_fin == 0:
        return acc_s[:0], acc_e[:0]
    take = min(n_fin, max(256, 32 * k))
    while True:
        if take >= n_fin:
            idx = np.flatnonzero(finite)
        else:
            t = np.partition(np.where(finite, end_costs, np.inf), take - 1)[take - 1]
            idx = np.flatnonzero(end_costs <= t)
        # idx is increasing: a stable sort orders by (cost, end index)
        order = idx[np.argsort(end_costs[idx], kind="stable")]
        n_acc = _select(order, starts, k, max_overlap, acc_s, acc_e, 0)
        if n_acc >= k or idx.shape[0] >= n_fin:
            return acc_s[:n_acc], acc_e[:n_acc]
        take = min(n_fin, take * 8)


def subsequence_dtw(
    query,
    data,
    clip_ids=None,
    k: int = 1,
    steps: str = "classic",
    exclude=None,
    cost=None,
    max_overlap: int = 0,
) -> list[Match]:
    """The k best database subsequences aligned to the query by subsequence DTW.

    Runs :func:`subsequence_dtw_costs` (O(N) memory), then takes candidate ends
    in increasing order of ``D(M-1, m)`` (ties: smaller ``m`` first) and accepts
    a candidate when its range ``[start, end]`` shares at most ``max_overlap``
    frames with every match accepted so far; this discards the slightly shifted
    copies of a match (Müller 2007, sec. 4.4; Tautges 2012, sec. 4.3.3). The
    warping path of each match is recovered by a global DTW over
    ``data[start:end+1]`` with both ends fixed, whose cost equals ``Match.cost``.

    Parameters
    ----------
    query : float array (M, D) or None
    data : float array (N, D) or None
    clip_ids : int array (N,), optional
        Clip of every database frame; no match spans two clips.
    k : int
        Number of matches wanted; fewer come back when fewer exist.
    steps : {"classic", "tautges"}
    exclude : bool array (N,), optional
        Database frames no match may use (e.g. the query's own neighbourhood).
    cost : float array (M, N), optional
        Precomputed non-negative local costs instead of ``query`` and ``data``.
    max_overlap : int
        Frames two accepted matches may share (0: disjoint ranges).

    Returns
    -------
    list of Match
        Sorted by cost; database indices; path rows ``(query frame, database
        frame)``. A query with a non-finite feature row gives ``[]``.

    Examples
    --------
    >>> q = np.array([[0.0], [1.0], [2.0]])
    >>> data = np.array([[5.0], [0.0], [1.0], [1.0], [2.0], [7.0], [0.0], [2.0]])
    >>> best, second = subsequence_dtw(q, data, k=2)
    >>> best
    Match(start=1, end=4, cost=0, path=4 steps)
    >>> best.path.tolist()
    [[0, 1], [1, 2], [1, 3], [2, 4]]
    >>> second.start, second.end, second.cost
    (6, 7, 1.0)
    """
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k: expected a positive integer, got {k!r}")
    if isinstance(max_overlap, bool) or not isinstance(max_overlap, (int, np.integer)) or max_overlap < 0:
        raise ValueError(f"max_overlap: expected a non-negative integer, got {max_overlap!r}")
    prob = _Problem(query, data, clip_ids, exclude, cost, steps)
    if prob.N == 0 or not prob.query_ok:
        return []
    end_costs, starts, _ = prob.run(record=False)
    acc_s, acc_e = _select_matches(end_costs, starts, int(k), int(max_overlap))
    out = []
    for s, e in zip(acc_s.tolist(), acc_e.tolist()):
        C = prob.window_cost(s, e)
        _, path = _global_dtw(C, prob.tautges, _usable_columns(C))
        path[:, 1] += s
        out.append(Match(start=s, end=e, cost=float(end_costs[e]), path=path))
    return out
