"""The lazy neighbourhood graph against subsequence DTW on a million frames (Krüger et al. 2010, sec. 4.1-4.2).

Usage::

    python benchmarks/lng_vs_dtw.py [--data DIR] [--frames N] [--queries Q] [--neighbors 64,128,256] [--json]

Database: ``benchmarks/_corpus.py`` (real ASF/AMC clips at 30 fps, mirrored
and repeated with small perturbations to ``--frames``, default 1,000,000),
feature set F15 (cm). Two query sets, ``--queries`` (default 128) random 1 s
and as many random 3 s windows each:

* ``in_database`` (the paper's protocol, and what self-similarity cleaning
  does): windows of the real clips inside the database, with the query's
  own frames excluded from both methods (so the match is another take, a
  mirror, or a perturbed repeat, never the query itself);
* ``held_out``: windows of held-out real clips (HDM05 actor mm, CMU
  charleston2), motion of an actor the database has never seen.

For every query, the best match of exact subsequence DTW
(:func:`mocapkit.search.dtw.subsequence_dtw`, classic steps, Euclidean local
cost: the reference and the baseline) and of the LNG on the K nearest
neighbours of each query frame (:class:`~mocapkit.search.knn.KNNIndex`
exact kd-tree + :func:`~mocapkit.search.lng.lazy_neighborhood_graph`), both
single-threaded. Reported per K:

* ``spearman``: Spearman rank correlation between the LNG's and DTW's global
  distances over all queries (target >= 0.99; a query where the LNG finds no
  path counts with infinite distance);
* ``same_best_share``: share of queries whose LNG best match is DTW's (same
  database range, same cost to 1e-9);
* ``found_share``: share of queries with any LNG path;
* ``cost_ratio_mean``: mean LNG cost / DTW cost (>= 1: DTW is optimal);
* ``speedup``: total DTW time / total LNG time (kNN search included);
  target >= 100 at 1 M frames.

The headline (top-level keys) is K = 128, the default of ``MotionDatabase.search``.
The same figures on the real database alone are under ``real_only``.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

import _harness as harness
from _corpus import DEFAULT_DATA, describe, heldout_motions, large_database, random_windows, real_database

from mocapkit.search.dtw import subsequence_dtw
from mocapkit.search.lng import lazy_neighborhood_graph

SPEARMAN_TARGET = 0.99
SPEEDUP_TARGET = 100.0
HEADLINE_K = 128


def run(db, queries: list[tuple[np.ndarray, tuple[int, int] | None]], neighbors: list[int], progress: bool) -> dict:
    data = np.asarray(db.features["F15"])
    clip_ids = np.asarray(db.clip_ids)
    index = db.index("F15")
    # warm numba and the caches
    subsequence_dtw(queries[0][0][:5], data[:1000], clip_ids[:1000])
    d, i = index.query(queries[0][0], k=16)
    lazy_neighborhood_graph(i, d, clip_ids)

    dtw_cost, dtw_range, dtw_s = [], [], 0.0
    for n, (q, excl) in enumerate(queries):
        mask = None
        if excl is not None:
            mask = np.zeros(len(data), dtype=bool)
            mask[excl[0] : excl[1]] = True
        t = time.perf_counter()
        m = subsequence_dtw(q, data, clip_ids, k=1, exclude=mask)
        dtw_s += time.perf_counter() - t
        dtw_cost.append(m[0].cost if m else np.inf)
        dtw_range.append((m[0].start, m[0].end) if m else None)
        if progress and n % 32 == 31:
            print(f"  dtw {n + 1}/{len(queries)}: {dtw_s / (n + 1) * 1e3:.1f} ms/query", flush=True)
    dtw_cost = np.array(dtw_cost)
    out = {"dtw_ms_per_query": dtw_s / len(queries) * 1e3, "per_k": {}}
    for K in neighbors:
        lng_cost, same, knn_s, graph_s = [], 0, 0.0, 0.0
        for (q, excl), dc, dr in zip(queries, dtw_cost, dtw_range):
            t0 = time.perf_counter()
            dist, idx = index.query(q, k=K, exclude=excl)
            t1 = time.perf_counter()
            m = lazy_neighborhood_graph(idx, dist, clip_ids, k=1)
            t2 = time.perf_counter()
            knn_s += t1 - t0
            graph_s += t2 - t1
            c = m[0].cost if m else np.inf
            lng_cost.append(c)
            same += bool(m) and (m[0].start, m[0].end) == dr and abs(c - dc) <= 1e-9 * max(1.0, dc)
        lng_cost = np.array(lng_cost)
        found = np.isfinite(lng_cost)
        rho = float(spearmanr(lng_cost, dtw_cost).statistic)
        lng_s = knn_s + graph_s
        out["per_k"][K] = {
            "spearman": rho,
            "spearman_found_only": float(spearmanr(lng_cost[found], dtw_cost[found]).statistic) if found.sum() > 2 else None,
            "same_best_share": same / len(queries),
            "found_share": float(found.mean()),
            "cost_ratio_mean": float(np.mean(lng_cost[found] / np.maximum(dtw_cost[found], 1e-12))) if found.any() else None,
            "lng_ms_per_query": lng_s / len(queries) * 1e3,
            "knn_ms_per_query": knn_s / len(queries) * 1e3,
            "graph_ms_per_query": graph_s / len(queries) * 1e3,
            "speedup": dtw_s / lng_s,
        }
        if progress:
            r = out["per_k"][K]
            print(f"  K={K}: spearman {rho:.4f}, same best {r['same_best_share']:.3f}, found {r['found_share']:.3f}, speedup x{r['speedup']:.0f}", flush=True)
    return out


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--data", type=os.path.abspath, default=str(DEFAULT_DATA))
    ap.add_argument("--frames", type=int, default=1_000_000)
    ap.add_argument("--queries", type=int, default=128, help="queries of each length (1 s and 3 s)")
    ap.add_argument("--neighbors", default="64,128,256")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    neighbors = sorted({int(k) for k in args.neighbors.split(",")} | {HEADLINE_K})
    data_dir = Path(args.data)
    real = real_database(data_dir)
    big = large_database(args.frames, data_dir)
    rng = np.random.default_rng(args.seed)
    held = heldout_motions(data_dir)
    fps = int(big.fps)
    windows = random_windows(held, fps, args.queries, rng) + random_windows(held, 3 * fps, args.queries, rng)
    held_out = [(big.query_features(w, "F15"), None) for w in windows]
    progress = not args.json

    def in_database(db) -> list:
        """Windows of the real clips of ``db`` (the large one starts with them), each excluding itself."""
        real_clips = db.clips[: real.num_clips]
        out = []
        for length in (fps, 3 * fps):
            pool = [c for c in real_clips if c.frames >= length]
            w = np.array([c.frames - length + 1 for c in pool], dtype=float)
            for c in rng.choice(len(pool), size=args.queries, p=w / w.sum()):
                a = pool[c].start + int(rng.integers(0, pool[c].frames - length + 1))
                out.append((np.asarray(db.features["F15"][a : a + length]), (a, a + length)))
        return out

    sets = {}
    for label, db in (("large", big), ("real_only", real)):
        for qname, qs in (("in_database", in_database(db)), ("held_out", held_out)):
            if progress:
                print(f"{label} / {qname}: {len(qs)} queries on {db.num_frames} frames", flush=True)
            sets[f"{label}/{qname}"] = run(db, qs, neighbors, progress)
    head = sets["large/in_database"]["per_k"][HEADLINE_K]
    held_head = sets["large/held_out"]["per_k"][HEADLINE_K]
    harness.emit(
        "lng_vs_dtw", args,
        figures={"spearman": head["spearman"], "same_best_share": head["same_best_share"],
                 "found_share": head["found_share"], "speedup": head["speedup"],
                 "ms_per_query": head["lng_ms_per_query"],
                 "held_out_spearman": held_head["spearman"], "held_out_found_share": held_head["found_share"]},
        baselines={"ms_per_query": sets["large/in_database"]["dtw_ms_per_query"]},
        targets={"spearman": {"value": SPEARMAN_TARGET, "op": ">=", "of": "figures"},
                 "speedup": {"value": SPEEDUP_TARGET, "op": ">=", "of": "figures"}},
        details={"baseline": "subsequence DTW over the whole database, same queries, same run",
                 "database": describe(big, real), "frames": big.num_frames, "features": "F15",
                 "queries": 2 * args.queries, "query_lengths_s": [1, 3],
                 "headline_queries": "in_database (own frames excluded)", "neighbors": HEADLINE_K,
                 "held_out": {k: held_head[k] for k in ("spearman", "same_best_share", "found_share", "speedup")},
                 "threads": 1, "sets": sets},
    )

if __name__ == "__main__":
    main()
