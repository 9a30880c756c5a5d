"""kNN speed on a million-frame database: kd-tree against brute force (Krüger et al. 2010, Table 1).

Usage::

    python benchmarks/knn_speed.py [--data DIR] [--frames N] [--queries Q] [--json]

The database (``benchmarks/_corpus.py``) is every real ASF/AMC clip of
``../shared/data`` at 30 fps, mirrored and repeated with small perturbations
(random speed 0.8-1.25x, every joint turned by ~2 degrees) up to ``--frames``
(default 1,000,000); the figures are also given for the real clips alone.
Two query sets: ``in_database``, random frames of the real clips in the
database (Krüger's Table 1 setting, and what self-similarity cleaning asks),
and ``held_out``, frames of held-out real clips (HDM05 actor mm, CMU
charleston2) that are in neither database — an actor the database has never
seen, whose 16th neighbour lies ~19 cm away, which makes a kd-tree visit
far more leaves. The headline figures are ``in_database``; ``held_out`` is
reported beside them.

For F15 and F15x3 and for 16 and 256 neighbours: mean time per query of an
exact batch query of ``--queries`` (default 10,000) points on one core
(``KNNIndex``, scipy cKDTree, ``workers=1``), and of numpy brute force
(``KNNIndex(backend="brute")``, same thread count) on a subset of 200
queries; the answers on that subset are compared (``identical``: same
indices, or where distances tie to 1e-9, same distances). ε = 0.5
approximate search and FAISS HNSW32 (recall against exact) are reported for
F15 16-NN.

The last line is the shared JSON object of ``benchmarks/_harness.py``: figure
``ms_per_query_16nn_f15`` (target <= 0.05 ms) against baseline
``ms_per_query_16nn_f15`` (numpy brute force), ``identical``, and every table in
``details``.
"""

from __future__ import annotations

import os
import time

import numpy as np

import _harness as harness
from _corpus import DEFAULT_DATA, describe, heldout_motions, large_database, real_database

from mocapkit.search.knn import KNNIndex

TARGET_MS = 0.05
BRUTE_QUERIES = 200


def _identical(d1, i1, d2, i2) -> bool:
    same_idx = i1 == i2
    tie = np.isclose(d1, d2, rtol=0, atol=1e-9)
    return bool(np.all(same_idx | tie) and np.allclose(d1, d2, rtol=0, atol=1e-9))


def _time_query(index: KNNIndex, q: np.ndarray, k: int, **kw) -> tuple[float, np.ndarray, np.ndarray]:
    index.query(q[:50], k=k, **kw)  # warm caches
    t = time.perf_counter()
    d, i = index.query(q, k=k, **kw)
    return (time.perf_counter() - t) / len(q) * 1e3, d, i


def measure(db, queries: dict, n_queries: int, rng, with_brute: bool = True) -> dict:
    out = {}
    for name in ("F15", "F15x3"):
        data = np.asarray(db.features[name])
        src = queries[name]
        q = src[rng.integers(0, len(src), n_queries)]
        t = time.perf_counter()
        tree = KNNIndex(data)
        build_s = time.perf_counter() - t
        brute = KNNIndex(data, backend="brute") if with_brute else None
        for k in (16, 256):
            ms, d, i = _time_query(tree, q, k)
            row = {"ms_per_query": ms, "build_s": build_s}
            if brute is not None:
                bms, bd, bi = _time_query(brute, q[:BRUTE_QUERIES], k)
                row.update(ms_per_query_bruteforce=bms, speedup=bms / ms, identical=_identical(d[:BRUTE_QUERIES], i[:BRUTE_QUERIES], bd, bi))
            out[f"{name}_{k}nn"] = row
        if name == "F15":
            ms, d_eps, _ = _time_query(tree, q, 16, eps=0.5)
            out["F15_16nn"]["ms_per_query_eps0.5"] = ms
            exact = out["F15_16nn"]
            d_true = tree.query(q[:2000], k=16)[0][:, -1]
            # how much farther the approximate 16th neighbour is than the true one, on average
            exact["eps0.5_kth_distance_ratio_mean"] = float(np.mean(d_eps[:2000, -1] / np.maximum(d_true, 1e-12)))
            try:
                import faiss  # noqa: F401

                faiss.omp_set_num_threads(1)
                t = time.perf_counter()
                hnsw = KNNIndex(data, backend="faiss", faiss_factory="HNSW32")
                hb = time.perf_counter() - t
                fms, _, fi = _time_query(hnsw, q, 16)
                _, ei = tree.query(q, k=16)
                recall = np.mean([len(set(a) & set(b)) / 16 for a, b in zip(fi[:2000], ei[:2000])])
                exact["faiss_hnsw32"] = {"ms_per_query": fms, "build_s": hb, "recall_at_16": float(recall)}
            except ImportError:
                exact["faiss_hnsw32"] = None
    return out


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--data", type=os.path.abspath, default=str(DEFAULT_DATA))
    ap.add_argument("--frames", type=int, default=1_000_000)
    ap.add_argument("--queries", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    from pathlib import Path

    real = real_database(Path(args.data))
    big = large_database(args.frames, Path(args.data))
    rng = np.random.default_rng(args.seed)
    held = heldout_motions(Path(args.data))
    held_q = {n: np.concatenate([real.query_features(m, n) for m in held]) for n in ("F15", "F15x3")}
    # the large database starts with the real clips, so real frames are rows 0 .. real.num_frames-1 of both
    indb_q = {n: np.asarray(real.features[n]) for n in ("F15", "F15x3")}
    large = measure(big, indb_q, args.queries, rng)
    small = measure(real, indb_q, args.queries, rng)
    large_held = measure(big, held_q, args.queries, rng)
    small_held = measure(real, held_q, args.queries, rng)
    head = large["F15_16nn"]
    if not args.json:
        for label, table in (("large", large), ("real only", small), ("large, held-out", large_held), ("real only, held-out", small_held)):
            print(f"{label}:")
            for k, v in table.items():
                extra = f"  brute {v['ms_per_query_bruteforce']:.3f} ms  x{v['speedup']:.0f}  identical={v['identical']}" if "speedup" in v else ""
                print(f"  {k:10s} {v['ms_per_query']:.4f} ms/query{extra}")
    harness.emit(
        "knn_speed", args,
        figures={"ms_per_query_16nn_f15": head["ms_per_query"],
                 "held_out_ms_per_query_16nn_f15": large_held["F15_16nn"]["ms_per_query"],
                 "frames": big.num_frames,
                 "identical": all(v["identical"] for t in (large, small, large_held, small_held) for v in t.values())},
        baselines={"ms_per_query_16nn_f15": head["ms_per_query_bruteforce"]},
        targets={"ms_per_query_16nn_f15": {"value": TARGET_MS, "op": "<=", "of": "figures"}},
        details={"baseline": f"numpy brute force (KNNIndex backend='brute') on {BRUTE_QUERIES} of the queries",
                 "database": describe(big, real), "real_frames": real.num_frames, "queries": args.queries,
                 "headline_queries": "in_database", "held_out_frames": int(len(held_q["F15"])),
                 "paper_ms_16nn_f15_cmu_1m": 1.65, "threads": 1, "large": large, "real_only": small,
                 "large_held_out": large_held, "real_only_held_out": small_held},
    )


if __name__ == "__main__":
    main()
