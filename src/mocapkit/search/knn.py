"""k-nearest-neighbour search over frame features (Krüger et al. 2010, sec. 3.3 and Table 1).

Krüger et al. show that medium-dimensional geometric features (15-90 dims)
are searched fast enough by a kd-tree to make every neighbourhood-based
method practical on millions of frames. :class:`KNNIndex` is that index over
any feature matrix, with one interface and three backends:

* ``"kdtree"`` (default): :class:`scipy.spatial.cKDTree`, exact or
  ε-approximate (the ANN library's ε of the paper: every returned distance is
  at most ``(1 + eps)`` times the true k-th distance).
* ``"brute"``: exact brute force in numpy (chunked), the reference.
* ``"faiss"``: a FAISS index (``pip install faiss-cpu``) built from a factory
  string (``"Flat"`` exact, ``"HNSW32"``, ``"IVF4096,Flat"``, ...), for
  databases where a kd-tree no longer fits memory comfortably. FAISS works
  in float32, so its distances agree with the others to about 1e-6 relative.

Every query supports a fixed radius with at most ``k`` results (the search
of the lazy neighbourhood graph and of fat graphs), batches, and excluding a
range of database frames per query (self-similarity: no neighbours from the
query's own temporal neighbourhood). Missing answers are reported as distance
``inf`` and index ``-1``; non-finite query rows get only missing answers and
non-finite database rows are never returned.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["KNNIndex", "BACKENDS"]

BACKENDS = ("kdtree", "brute", "faiss")

_BRUTE_CHUNK_BYTES = 64 * 2**20


def _as_points(x, dim: int | None, what: str) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1 and dim is not None and a.shape[0] == dim:
        a = a[None]
    if a.ndim != 2 or (dim is not None and a.shape[1] != dim):
        want = f"(Q, {dim})" if dim is not None else "(N, D)"
        raise ValueError(f"{what}: expected shape {want}, got {a.shape}")
    return a


class KNNIndex:
    """An index answering k-nearest-neighbour queries on the rows of ``data``.

    Parameters
    ----------
    data : float array (N, D)
        One feature vector per database frame. Rows with NaN/inf are kept out
        of the index (they can never be a neighbour); indices returned are
        always row numbers of ``data``.
    backend : {"kdtree", "brute", "faiss"}
    leafsize : int
        kd-tree leaf size (``kdtree`` only).
    faiss_factory : str
        FAISS ``index_factory`` string (``faiss`` only); indexes that need
        training are trained on the data itself.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> data = rng.normal(size=(1000, 15))
    >>> index = KNNIndex(data)
    >>> dist, idx = index.query(data[:3], k=2)
    >>> idx[:, 0].tolist(), dist[:, 0].tolist()
    ([0, 1, 2], [0.0, 0.0, 0.0])
    >>> _, idx = index.query(data[:3], k=2, exclude=[(0, 1), (1, 2), (2, 3)])
    >>> bool((idx[:, 0] != [0, 1, 2]).all())
    True
    """

    def __init__(self, data, backend: str = "kdtree", leafsize: int = 16, faiss_factory: str = "Flat"):
        if backend not in BACKENDS:
            raise ValueError(f"unknown kNN backend {backend!r}; known: {', '.join(BACKENDS)}")
        data = _as_points(data, None, "data")
        self.backend = backend
        self.num_points, self.dim = data.shape
        finite = np.isfinite(data).all(axis=1)
        # rows kept in the index -> row numbers of `data` (None: all rows, identity)
        self._rows = None if finite.all() else np.flatnonzero(finite)
        kept = data if self._rows is None else data[self._rows]
        self._size = kept.shape[0]
        self._tree = None
        self._faiss = None
        if backend == "kdtree":
            self._tree = cKDTree(kept, leafsize=leafsize, compact_nodes=True, balanced_tree=False) if self._size else None
        elif backend == "brute":
            self._data = np.ascontiguousarray(kept)
            self._sqnorm = np.einsum("ij,ij->i", self._data, self._data)
        else:
            try:
                import faiss
            except ImportError:
                raise ImportError("the 'faiss' kNN backend needs faiss: pip install faiss-cpu") from None
            x = np.ascontiguousarray(kept, dtype=np.float32)
            self._faiss = faiss.index_factory(self.dim, faiss_factory, faiss.METRIC_L2)
            if not self._faiss.is_trained:
                self._faiss.train(x)
            if self._size:
                self._faiss.add(x)

    def __len__(self) -> int:
        return self.num_points

    def __repr__(self) -> str:
        return f"KNNIndex({self.num_points} points x {self.dim} dims, backend={self.backend!r})"

    # -- queries ---------------------------------------------------------------------

    def query(self, points, k: int = 16, eps: float = 0.0, radius: float = np.inf, exclude=None, workers: int = 1):
        """The ``k`` nearest rows of ``data`` to each query point, nearest first.

        Parameters
        ----------
        points : float array (Q, D) or (D,)
        k : int
            Number of neighbours per query.
        eps : float
            Approximation factor (``kdtree``): the j-th returned distance is at
            most ``(1 + eps)`` times the true j-th distance. 0 is exact.
        radius : float
            Fixed-radius search: only neighbours within this distance, at most
            ``k`` of them (Krüger sec. 4.1 and 5.3).
        exclude : (lo, hi) or int array (Q, 2), optional
            Half-open ranges ``[lo, hi)`` of database rows that may not be
            returned, one for all queries or one per query (e.g. the query
            frame's own neighbourhood in self-similarity analysis).
        workers : int
            Threads for batch queries (``kdtree``; -1 for all cores).

        Returns
        -------
        dist : float array (Q, k)
            Euclidean distances, ascending; ``inf`` where fewer than ``k``
            neighbours exist.
        idx : int64 array (Q, k)
            Row numbers of ``data``; ``-1`` where the distance is ``inf``.
        """
        pts = _as_points(points, self.dim, "points")
        if int(k) != k or k < 1:
            raise ValueError(f"k must be a positive integer, got {k}")
        k = int(k)
        if eps < 0:
            raise ValueError(f"eps must be >= 0, got {eps}")
        if not radius > 0:
            raise ValueError(f"radius must be > 0, got {radius}")
        Q = pts.shape[0]
        ranges = self._exclude_ranges(exclude, Q)
        dist = np.full((Q, k), np.inf)
        idx = np.full((Q, k), -1, dtype=np.int64)
        good = np.isfinite(pts).all(axis=1)
        if not good.any() or self._size == 0:
            return dist, idx
        q = pts if good.all() else pts[good]
        rg = None if ranges is None else (ranges if good.all() else ranges[good])
        # ask for enough extra neighbours that the excluded ones can be dropped exactly
        extra = 0 if rg is None else int(np.clip(rg[:, 1] - rg[:, 0], 0, None).max())
        kk = min(k + extra, self._size)
        d, i = self._raw_query(q, kk, eps, radius, workers)
        if self._rows is not None:
            i = np.where(i >= 0, self._rows[np.clip(i, 0, None)], -1)
        if rg is not None:
            banned = (i >= rg[:, :1]) & (i < rg[:, 1:2])
            d = np.where(banned, np.inf, d)
            i = np.where(banned, -1, i)
            # stable sort keeps the backend's order among the survivors
            order = np.argsort(d, axis=1, kind="stable")
            d = np.take_along_axis(d, order, axis=1)
            i = np.take_along_axis(i, order, axis=1)
        m = min(k, d.shape[1])
        if good.all():
            dist[:, :m], idx[:, :m] = d[:, :m], i[:, :m]
        else:
            dist[good, :m], idx[good, :m] = d[:, :m], i[:, :m]
        return dist, idx

    def query_radius(self, points, radius: float, k: int = 256, exclude=None, workers: int = 1):
        """Fixed-radius search with at most ``k`` results: ``query(points, k, radius=radius)``."""
        return self.query(points, k=k, radius=radius, exclude=exclude, workers=workers)

    def _exclude_ranges(self, exclude, Q: int):
        if exclude is None:
            return None
        r = np.asarray(exclude, dtype=np.int64)
        if r.shape == (2,):
            r = np.broadcast_to(r, (Q, 2))
        if r.shape != (Q, 2):
            raise ValueError(f"exclude: expected (lo, hi) or shape ({Q}, 2), got {r.shape}")
        return r

    def _raw_query(self, q, k, eps, radius, workers):
        """(dist, idx) in the index's own row numbers, -1/inf for missing."""
        if self.backend == "kdtree":
            d, i = self._tree.query(q, k=k, eps=eps, distance_upper_bound=radius, workers=workers)
            if k == 1:
                d, i = d[:, None], i[:, None]
            i = np.where(np.isfinite(d), i, -1).astype(np.int64)
            return d, i
        if self.backend == "brute":
            return self._brute(q, k, radius)
        d2, i = self._faiss.search(np.ascontiguousarray(q, dtype=np.float32), k)
        d = np.sqrt(np.maximum(d2.astype(np.float64), 0.0))
        missing = (i < 0) | (d > radius)
        return np.where(missing, np.inf, d), np.where(missing, -1, i).astype(np.int64)

    def _brute(self, q, k, radius):
        Q, N = q.shape[0], self._size
        dist = np.empty((Q, k))
        idx = np.empty((Q, k), dtype=np.int64)
        chunk = max(1, _BRUTE_CHUNK_BYTES // (8 * max(N, 1)))
        for a in range(0, Q, chunk):
            qa = q[a : a + chunk]
            d2 = np.einsum("ij,ij->i", qa, qa)[:, None] - 2.0 * (qa @ self._data.T) + self._sqnorm[None]
            # candidates by the fast expansion, then exact distances for the ranking
            cand = np.argpartition(d2, k - 1, axis=1)[:, :k] if k < N else np.broadcast_to(np.arange(N), (len(qa), N))
            diff = self._data[cand] - qa[:, None, :]
            dc = np.sqrt(np.einsum("qkd,qkd->qk", diff, diff))
            order = _order_by_distance_then_index(dc, cand)
            dist[a : a + chunk] = np.take_along_axis(dc, order, axis=1)
            idx[a : a + chunk] = np.take_along_axis(cand, order, axis=1)
        far = dist > radius
        dist[far], idx[far] = np.inf, -1
        return dist, idx


def _order_by_distance_then_index(d: np.ndarray, i: np.ndarray) -> np.ndarray:
    """Row-wise argsort by distance, ties broken by the smaller index."""
    order = np.argsort(i, axis=1, kind="stable")
    d2 = np.take_along_axis(d, order, axis=1)
    return np.take_along_axis(order, np.argsort(d2, axis=1, kind="stable"), axis=1)
