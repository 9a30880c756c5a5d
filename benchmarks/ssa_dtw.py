"""Speed and correctness of the self-similarity DTW kernels against dtaidistance's C DTW (Aristidou et al. 2018, appendix).

Usage::

    python benchmarks/ssa_dtw.py [--clip REL] [--target-step S] [--repeats R (5)] [--quick] [--json]

Word pairs come from a real clip (default ``cmu_asfamc/lambada.amc`` of
``../shared/data``): its motion texture (``ssa.motion_texture``, 24 fps, the
24 informative joints, root heading removed) gives source words of 15 frames
every 5 frames and target words of 20 frames at every ``--target-step``-th
frame (default 1: 85 x 417 = 35,445 pairs for lambada).

**Speed** (microseconds per word pair, best of ``--repeats``, numba compile
and first calls excluded). Both sides get the same per-frame data, the
texture's 24 unit quaternions (96 numbers a frame):

* ``ours_profile``: what :func:`mocapkit.cleaning.ssa.detect` runs, eq. 1 pose
  distances of every source frame to every target frame
  (``group_pose_distances``, whole body, 3 largest joint terms dropped)
  followed by the constrained DTW of every pair (``word_distance_profile``);
  the pose-distance time is included;
* ``ours_kernel``: the DTW alone on that precomputed pose-distance matrix;
* ``ours_pairs``: ``word_distance_pairs``, the kd-tree-prefilter path, where
  the eq. 1 cost of every cell of every pair is computed on the fly;
* ``dtai_matrix``: ``dtaidistance.dtw_ndim.distance_matrix_fast`` (C,
  dependent multivariate DTW, squared Euclidean inner distance) on the same
  quaternions as 96-D vectors, the source x target block in one call;
  ``dtai_per_call`` is ``dtw_ndim.distance_fast`` called once per pair (on a
  subset), ``dtai_dp_only_1d`` the same block on 1-D series (one component),
  i.e. dtaidistance's dynamic programme with a negligible inner distance.

Single thread for both (``numba.set_num_threads(1)``, dtaidistance
``parallel=False``); our numba-parallel times (all cores) and dtaidistance's
OpenMP times are reported separately. The headline ``speed_ratio`` is
``dtai_matrix / ours_profile`` (target >= 1, "at least as fast");
``speed_ratio_kernel`` and ``speed_ratio_pairs`` use ``ours_kernel`` and
``ours_pairs``. The kernels do different work per cell: ours keeps 7 states
(slope constraint) and, for eq. 1, 24 ``acos``; dtaidistance one state and a
96-D squared distance.

**Agreement.** The two DTWs differ in their constraints: ours stops when
either word ends (last row or column), allows at most 3 consecutive
horizontal or vertical steps, and returns the **mean** cost over the matched
pairs; dtaidistance's path runs unconstrained to the corner ``(N-1, M-1)`` and
returns ``sqrt(sum of costs)``. Both are fed the same cost,
``C[i, j] = ||x_i - y_j||^2`` over the 96-D frame vectors (precomputed for
ours). Where dtaidistance's optimal path is admissible for ours (runs <= 3, no
cell on the last row or column before the corner) and ours ends at the
corner, ``sqrt(mean * path length)`` (length from ``word_dtw_path``) must equal
dtaidistance's value; everywhere ours ending at the corner can be no smaller
(a constrained minimum). Two settings:

* ``corner``: N = M = 15, ``min_width = 15``, so the corner is our only
  admissible end (``word_dtw_path``);
* ``paper``: N = 15, M = 20, ``min_width = 11`` (the paper's parameters,
  ``word_distance_profile``), on the pairs whose best end is the corner.

``pairs_vs_profile`` checks that ``word_distance_pairs`` (float64 costs)
gives the distances and end cells of ``word_distance_profile`` (float32
pose-distance matrix) on every pair, up to float32 rounding.

    python benchmarks/ssa_dtw.py --json           # full run (~1 min on 2 cores)
    python benchmarks/ssa_dtw.py --quick --json   # every 3rd target position (~15 s)

The last line with ``--json`` is one JSON object: ``us_per_pair``,
``speed_ratio`` (target >= 1, ``target_met``) and ``agreement`` (fraction of
pairs where the constraints agree, max abs difference there).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO / "benchmarks"))

import _harness as harness  # noqa: E402
import numba  # noqa: E402

import mocapkit  # noqa: E402
from mocapkit.cleaning import ssa  # noqa: E402
from mocapkit.cleaning.ssa import word_dtw as K  # noqa: E402

DATA = REPO.parent / "shared" / "data"
N, M, STRIDE, MIN_WIDTH, DROP = 15, 20, 5, 11, 3


def best_of(fn, repeats: int) -> float:
    """Smallest wall time in seconds of ``repeats`` calls of ``fn``."""
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def admissible(path, n: int, m: int, max_run: int = 3) -> bool:
    """Whether a warping path (list of (i, j)) from (0, 0) to (n-1, m-1) satisfies our kernel's constraints.

    Steps (1,0), (0,1), (1,1); at most ``max_run`` consecutive horizontal or
    vertical steps; no cell on the last row or column before the corner (our
    path stops as soon as either word ends, so the corner is entered diagonally).
    """
    p = np.asarray(path)
    if p[0].tolist() != [0, 0] or p[-1].tolist() != [n - 1, m - 1]:
        return False
    if np.any(p[:-1, 0] == n - 1) or np.any(p[:-1, 1] == m - 1):
        return False
    d = np.diff(p, axis=0)
    kind = np.where((d[:, 0] == 1) & (d[:, 1] == 1), 0, np.where(d[:, 1] == 1, 1, 2))
    run, prev = 0, -1
    for k in kind:
        run = run + 1 if k == prev else 1
        prev = k
        if k != 0 and run > max_run:
            return False
    return True


def sq_dists(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Squared Euclidean distances (Fa, Fb) between the rows of X and Y, exact (no expansion round-off)."""
    out = np.empty((len(X), len(Y)))
    for a in range(len(X)):
        out[a] = np.sum((Y - X[a]) ** 2, axis=1)
    return out


def speed(V, src, tgt, repeats, dtw_ndim, dtw):
    """Microseconds per pair of every variant, single thread, then parallel."""
    m = V.shape[1]
    whole = np.ones((1, m), dtype=bool)
    sr = np.repeat(src, len(tgt))
    tr = np.tile(tgt, len(src))
    P = len(sr)
    X = np.ascontiguousarray(V.reshape(len(V), -1), dtype=np.float64)
    s_words = [np.ascontiguousarray(X[s : s + N]) for s in src]
    t_words = [np.ascontiguousarray(X[t : t + M]) for t in tgt]
    series = s_words + t_words
    block = ((0, len(src)), (len(src), len(series)))
    series_1d = [np.ascontiguousarray(w[:, 0]) for w in series]
    f0, f1 = int(src.min()), int(src.max()) + N

    def ours_profile():
        D = K.group_pose_distances(V[f0:f1], V, whole, [DROP])[0]
        return K.word_distance_profile(D, src - f0, tgt, N, M, MIN_WIDTH, 3)

    D_pre = K.group_pose_distances(V[f0:f1], V, whole, [DROP])[0]

    def ours_kernel():
        return K.word_distance_profile(D_pre, src - f0, tgt, N, M, MIN_WIDTH, 3)

    def ours_pairs():
        return K.word_distance_pairs(V, V, whole[0], DROP, sr, tr, N, M, MIN_WIDTH, 3)

    def dtai_matrix(parallel=False):
        return dtw_ndim.distance_matrix_fast(series, block=block, parallel=parallel)

    sub = [(a, b) for a in s_words[:: max(1, len(s_words) // 10)] for b in t_words]

    def dtai_per_call():
        for a, b in sub:
            dtw_ndim.distance_fast(a, b)

    def dtai_1d():
        return dtw.distance_matrix_fast(series_1d, block=block, parallel=False)

    # warm-up: numba compilation and first calls excluded
    for fn in (ours_profile, ours_kernel, ours_pairs, dtai_matrix, dtai_1d):
        fn()
    threads_all = numba.get_num_threads()
    single = {"ours_profile": ours_profile, "ours_kernel": ours_kernel, "ours_pairs": ours_pairs,
              "dtai_matrix": dtai_matrix, "dtai_per_call": dtai_per_call, "dtai_dp_only_1d": dtai_1d}
    per = {k: (len(sub) if k == "dtai_per_call" else P) for k in single}
    # interleaved (one call of each per round, best round kept), so a busy machine slows all alike
    out = {k: np.inf for k in single}
    numba.set_num_threads(1)
    try:
        for _ in range(repeats):
            for k, fn in single.items():
                out[k] = min(out[k], best_of(fn, 1) / per[k] * 1e6)
    finally:
        numba.set_num_threads(threads_all)
    par = {"threads": threads_all}
    parallel = {"ours_profile": ours_profile, "ours_kernel": ours_kernel, "ours_pairs": ours_pairs,
                "dtai_matrix_openmp": lambda: dtai_matrix(parallel=True)}
    try:
        dtai_matrix(parallel=True)
    except Exception as e:  # noqa: BLE001 - no OpenMP build: report, do not fail
        parallel.pop("dtai_matrix_openmp")
        par["dtai_openmp_error"] = str(e)
    for k in parallel:
        par[k] = np.inf
    for _ in range(repeats):
        for k, fn in parallel.items():
            par[k] = min(par[k], best_of(fn, 1) / P * 1e6)
    # word_distance_pairs (float64 costs) against word_distance_profile (float32 pose-distance matrix)
    dp, ip, jp = ours_profile()
    dq, iq, jq = ours_pairs()
    dp, ip, jp = dp.ravel(), ip.ravel(), jp.ravel()
    fin = np.isfinite(dp) & np.isfinite(dq)
    par["pairs_vs_profile"] = {
        "max_rel_diff": float(np.max(np.abs(dq[fin] - dp[fin]) / np.maximum(np.abs(dp[fin]), 1e-30))),
        "same_finiteness": bool(np.array_equal(np.isfinite(dp), np.isfinite(dq))),
        "same_end_cell_fraction": float(np.mean((ip == iq) & (jp == jq))),
    }
    # the block is the only part computed; everything else NaN
    dm = dtai_matrix()
    dm = np.asarray(dm)[: len(src), len(src) :]
    return out, par, dm


def agreement_corner(X, src, tgt, dtw_ndim):
    """N = M = 15, corner the only end: sqrt(our mean * length) against dtaidistance where dtai's path is admissible."""
    n = N
    Cfull = sq_dists(X, X)
    s_words = [np.ascontiguousarray(X[s : s + n]) for s in src]
    t_words = [np.ascontiguousarray(X[t : t + n]) for t in tgt]
    series = s_words + t_words
    dm = np.asarray(dtw_ndim.distance_matrix_fast(series, block=((0, len(src)), (len(src), len(series)))))
    dm = dm[: len(src), len(src) :]
    ours = np.full(dm.shape, np.nan)
    ok = np.zeros(dm.shape, dtype=bool)
    length_consistent = True
    for a, s in enumerate(src):
        for b, t in enumerate(tgt):
            C = Cfull[s : s + n, t : t + n]
            mean, path = K.word_dtw_path(C, min_width=n)
            if len(path) == 0:
                continue
            total = mean * len(path)
            length_consistent &= bool(np.isclose(total, C[path[:, 0], path[:, 1]].sum(), rtol=1e-12, atol=1e-12))
            ours[a, b] = np.sqrt(total)
            dpath = dtw_ndim.warping_path(s_words[a], t_words[b], use_c=True)
            ok[a, b] = admissible(dpath, n, n)
    return summarise(ours, dm, ok, ours_defined=np.isfinite(ours), length_consistent=length_consistent)


def agreement_paper(X, src, tgt, dm_dtai, dtw_ndim):
    """N = 15, M = 20, min_width 11 (``word_distance_profile``): pairs whose best end is the corner."""
    Cfull = sq_dists(X, X)
    dist, ie, je = K.word_distance_profile(Cfull, src, tgt, N, M, MIN_WIDTH, 3)
    corner = (ie == N - 1) & (je == M - 1)
    ours = np.full(dist.shape, np.nan)
    ok = np.zeros(dist.shape, dtype=bool)
    length_consistent = True
    for a, b in zip(*np.nonzero(corner)):
        s, t = src[a], tgt[b]
        C = Cfull[s : s + N, t : t + M]
        mean, path = K.word_dtw_path(C, min_width=MIN_WIDTH)
        # the profile stores float32 means; the path call gives the float64 mean of the same path
        length_consistent &= bool(np.isclose(mean, dist[a, b], rtol=1e-6))
        ours[a, b] = np.sqrt(mean * len(path))
        dpath = dtw_ndim.warping_path(X[s : s + N], X[t : t + M], use_c=True)
        ok[a, b] = admissible(dpath, N, M)
    res = summarise(ours, dm_dtai, ok, ours_defined=corner, length_consistent=length_consistent)
    res["corner_end_fraction"] = float(corner.mean())
    res["note"] = "pairs and fractions are over the pairs whose best end is the corner"
    return res


def summarise(ours, dtai, ok, ours_defined, length_consistent):
    pairs = int(ours_defined.sum())
    agree = ok & ours_defined
    diff = np.abs(ours - dtai)
    rel = diff / np.maximum(np.abs(dtai), 1e-300)
    equal = ours_defined & (rel <= 1e-9)
    return {
        "pairs": pairs,
        "constraints_agree_fraction": float(agree.sum() / max(pairs, 1)),
        "max_abs_diff_where_agree": float(diff[agree].max()) if agree.any() else None,
        "max_rel_diff_where_agree": float(rel[agree].max()) if agree.any() else None,
        "equal_fraction_all": float(equal.sum() / max(pairs, 1)),
        "ours_never_below_dtai": bool(np.all(ours[ours_defined] >= dtai[ours_defined] * (1 - 1e-9))),
        "mean_times_length_is_path_sum": bool(length_consistent),
        "dtai_distance_range": [float(np.nanmin(dtai)), float(np.nanmax(dtai))],
    }


def main(argv=None) -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--clip", default="cmu_asfamc/lambada.amc", help="clip under ../shared/data")
    ap.add_argument("--target-step", type=int, default=1, help="target words at every S-th frame")
    ap.add_argument("--agree-step", type=int, default=2, help="target positions of the N=M agreement check, every S-th")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="every 3rd target position, 2 repeats (~15 s)")
    args = ap.parse_args(argv)
    if args.quick:
        args.target_step, args.agree_step, args.repeats = max(args.target_step, 3), max(args.agree_step, 6), 2
    try:
        import dtaidistance
        from dtaidistance import dtw, dtw_ndim
        from dtaidistance.dtw import try_import_c

        if not try_import_c(verbose=False):
            raise ImportError("dtaidistance's C library is not available")
    except ImportError as e:
        sys.exit(f"ssa_dtw: needs dtaidistance with its C extension (pip install 'mocapkit[bench]'): {e}")

    load0 = os.getloadavg()  # other jobs on the machine make the parallel figures meaningless
    motion = mocapkit.load(DATA / args.clip)
    joints = ssa.informative_joints([motion], 24)
    tex = ssa.motion_texture(motion, 24.0, joints)
    V = np.ascontiguousarray(tex.values, dtype=np.float64)
    F = len(V)
    src = np.arange(0, F - N + 1, STRIDE)
    tgt = np.arange(0, F - M + 1, args.target_step)
    X = np.ascontiguousarray(V.reshape(F, -1))

    t0 = time.perf_counter()
    us, par, dm = speed(V, src, tgt, args.repeats, dtw_ndim, dtw)
    t_speed = time.perf_counter() - t0
    tgt_corner = np.arange(0, F - N + 1, args.agree_step)
    corner = agreement_corner(X, src, tgt_corner, dtw_ndim)
    paper = agreement_paper(X, src, tgt, dm, dtw_ndim)

    ratio = us["dtai_matrix"] / us["ours_profile"]
    result = {
        "clip": args.clip,
        "texture_frames": F,
        "joints": int(len(joints)),
        "source_length": N,
        "target_length": M,
        "min_width": MIN_WIDTH,
        "max_run": 3,
        "pairs": int(len(src) * len(tgt)),
        "features": "texture quaternions (24 joints x 4 = 96-D per frame) for both; "
                    "ours: eq. 1 cost, dtaidistance: squared Euclidean",
        "threads": 1,
        "us_per_pair": {k: round(v, 3) for k, v in us.items()},
        "speed_ratio": round(ratio, 3),
        "speed_ratio_kernel": round(us["dtai_matrix"] / us["ours_kernel"], 3),
        "speed_ratio_pairs": round(us["dtai_matrix"] / us["ours_pairs"], 3),
        "baseline": "dtaidistance's C multivariate DTW (distance matrix), same word pairs, single thread",
        "pairs_vs_profile": par.pop("pairs_vs_profile"),
        "parallel_us_per_pair": {k: (round(v, 3) if isinstance(v, float) else v) for k, v in par.items()},
        "agreement": {"corner": corner, "paper": paper},
        "dtaidistance": dtaidistance.__version__,
        "numba": numba.__version__,
        "speed_seconds": round(t_speed, 1),
        "load_average_at_start": [round(x, 2) for x in load0],
    }
    if not args.json:
        print(f"{args.clip}: {F} frames at 24 fps, {len(src)} source x {len(tgt)} target words = {result['pairs']} pairs")
        print("single thread, microseconds per pair:")
        for k, v in us.items():
            print(f"  {k:16s} {v:9.3f}")
        print(f"  speed ratio dtai/ours: profile {ratio:.2f}, kernel {result['speed_ratio_kernel']:.2f}, "
              f"pairs {result['speed_ratio_pairs']:.2f}  (target >= 1: {ratio >= 1.0})")
        print(f"parallel ({par['threads']} threads): " + ", ".join(
            f"{k} {v:.3f}" for k, v in par.items() if k != "threads" and isinstance(v, float)))
        for name, a in (("corner N=M=15", corner), ("paper N=15 M=20", paper)):
            print(f"agreement {name}: {a['pairs']} pairs, constraints agree on {a['constraints_agree_fraction']:.3f}, "
                  f"max |diff| there {a['max_abs_diff_where_agree']}, equal on {a['equal_fraction_all']:.3f}, "
                  f"never below dtai: {a['ours_never_below_dtai']}")
    harness.emit(
        "ssa_dtw", args,
        figures={"us_per_pair": us["ours_profile"], "us_per_pair_kernel": us["ours_kernel"],
                 "us_per_pair_candidates": us["ours_pairs"]},
        baselines={"us_per_pair": us["dtai_matrix"], "us_per_pair_kernel": us["dtai_matrix"],
                   "us_per_pair_candidates": us["dtai_matrix"]},
        targets={"us_per_pair": {"value": 1.0, "op": "<=", "of": "ratios"}},
        details=result,
    )


if __name__ == "__main__":
    main()
