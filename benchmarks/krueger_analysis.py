"""Krüger et al. 2010, sec. 3.3 and 4.2, on our real data: Fig. 2's rank correlations and LNG against DTW per feature set.

Usage::

    python benchmarks/krueger_analysis.py [--data DIR] [--samples 1024] [--neighbors 256]
        [--pose-clips N] [--queries 64] [--lng-k 128] [--out DIR] [--seed 0] [--json]

**Part 1, pose-based rank correlations (Fig. 2).** The sample database is
every HDM05 clip of ``../shared/data/hdm05_asfamc`` (280 hand-cut clips of 11
classes and 5 actors, about 17,500 frames at 30 fps; the paper used 76 clips
of 9 classes), or with ``--pose-clips N`` N of them taken class by class in
turn. ``--samples`` (default 1024) random frames; for each, the
``--neighbors`` (default 256) nearest frames by the feature set of the row
(exact kd-tree, the frame itself excluded, no other exclusion, as in the
paper). Entry = mean over the random frames of Spearman's rho between the
row's feature distances and the column's distances on those neighbours.

Rows: F15, F30, F39, F15x3, F15x5, F30x3 (:func:`mocapkit.features.feature_set`,
cm) and Fpca8, Fpca16, Fpca25 (:class:`mocapkit.features.PCAFeatures` of all
normalised joint positions in cm, fitted on the sample database; one
25-component fit, the first 8 / 16 components are the smaller ones).
Columns: the same nine (Euclidean distance) and

* ``D_quat``: sum over all joints of the geodesic angle (rad) between the
  local joint rotations; the root's rotation with its heading (turn about
  the vertical) removed, so that it measures only the tilt of the pelvis.
* ``D_euler``: Euclidean distance (degrees) of the ASF/AMC Euler channels
  (:meth:`Motion.channel_values`) without the root's position channels; the
  root's rotation channels are those of the heading-free root rotation.
* ``D_pc1``, ``D_pc11``: Kovar and Gleicher's point cloud distance (2004) on
  a window of 1 or 11 frames (clamped at clip ends) of all joint positions
  (cm), equal weights, minimised over a rotation about the vertical axis and
  a ground-plane translation. Closed form: with horizontal coordinates as
  complex numbers ``u`` centred per window and heights ``y``, the optimal
  turn aligns the windows' cross-correlation, so
  ``D^2 = (|u_a|^2 + |u_b|^2 - 2 |<u_a, u_b>| + |y_a - y_b|^2) / n_points``
  (reported as the RMS distance in cm).
* ``D_wb``: Lee et al. (2002) / Wang and Bodenheimer (2003) style transition
  cost on the hips, knees, shoulders and elbows only:
  ``sum_k w_k theta_k^2 + nu sum_k w_k |omega_a,k - omega_b,k|^2`` with
  ``theta_k`` the geodesic angle (rad) between the local rotations and
  ``omega`` the local angular velocity (rad/s, central difference). Our
  weights, not WB's optimised values: hips and shoulders 1.0, knees and
  elbows 0.5, ``nu = 0.01 s^2`` (the velocity term compares the angles
  turned in 0.1 s).

**Part 2, LNG against subsequence DTW (sec. 4.1/4.2).** The real database of
``benchmarks/_corpus.py`` (CMU and HDM05 ASF/AMC at 30 fps, held-out clips
removed), feature sets F15, F30, F15x3 and Fpca16 (PCA fitted on the
database clips). ``--queries`` (default 64) random 1 s and as many 3 s
windows of the held-out clips (HDM05 actor mm, CMU charleston2). Per
feature set: exact subsequence DTW (classic steps) against the lazy
neighbourhood graph with K = ``--lng-k`` (default 128) exact kd-tree
neighbours per query frame, both single-threaded: Spearman of the best
matches' global distances (a query where the LNG finds no path counts as
infinite; ``spearman_found_only`` leaves those out), share of identical best
matches (same range, same cost to 1e-9), share of queries with any LNG path,
mean time per query (LNG: kNN search included). On this small database of
short hand-cut clips many held-out queries have no chain of consecutive
frames inside their K-neighbourhoods, so the LNG finds no path for them
(``found_share``); the paper's 0.99 was measured with queries of a large
database.

Writes ``--out`` (default ``benchmarks/out/``) ``krueger_fig2.png``, prints
the tables, and ends with the shared JSON object of ``benchmarks/_harness.py``
(an analysis: figures, no baseline or target).
"""

from __future__ import annotations

import dataclasses
import os
import re
import sys
import time
from pathlib import Path

import numpy as np
from scipy.stats import rankdata, spearmanr

import _harness as harness
from _corpus import DEFAULT_DATA, heldout_motions, random_windows, real_database

import mocapkit
from mocapkit import rotations as R
from mocapkit.features import PCAFeatures, detect_up_axis, feature_set, root_frame
from mocapkit.motion import Motion, find_joint, unit_scale_cm
from mocapkit.search.dtw import subsequence_dtw
from mocapkit.search.knn import KNNIndex
from mocapkit.search.lng import lazy_neighborhood_graph

FEATURE_ROWS = ("F15", "F30", "F39", "F15x3", "F15x5", "F30x3", "Fpca8", "Fpca16", "Fpca25")
MEASURE_COLUMNS = FEATURE_ROWS + ("D_quat", "D_euler", "D_pc1", "D_pc11", "D_wb")
GEOMETRIC = ("F15", "F30", "F39", "F15x3", "F15x5", "F30x3")
PCA_SIZES = {"Fpca8": 8, "Fpca16": 16, "Fpca25": 25}
# Wang-Bodenheimer-style joint weights (ours; see the module docstring) and the velocity weight in s^2.
WB_WEIGHTS = {
    "left_hip": 1.0,
    "right_hip": 1.0,
    "left_knee": 0.5,
    "right_knee": 0.5,
    "left_shoulder": 1.0,
    "right_shoulder": 1.0,
    "left_elbow": 0.5,
    "right_elbow": 0.5,
}
WB_NU = 0.01
LNG_FEATURES = ("F15", "F30", "F15x3", "Fpca16")
LNG_K = 128
CHUNK = 32  # random frames per vectorised batch in part 1


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


# -- part 1: the sample database and its per-frame measures -----------------------------------------


def hdm05_paths(data: Path, n_clips: int = 0) -> list[Path]:
    """The HDM05 clips; with ``n_clips`` > 0, that many taken class by class in turn (actors interleaved)."""
    paths = sorted((data / "hdm05_asfamc").glob("*.amc"))
    if not paths:
        raise SystemExit(f"no HDM05 ASF/AMC clips under {data / 'hdm05_asfamc'}; pass --data")
    if n_clips <= 0 or n_clips >= len(paths):
        return paths
    by_class: dict[str, list[Path]] = {}
    for p in paths:
        m = re.match(r"HDM_([a-z]+)_(.+)_\d+_\d+$", p.stem)
        by_class.setdefault(m.group(2) if m else p.stem, []).append(p)
    queues = []
    for cls in sorted(by_class):
        # interleave actors inside the class so a small subset still mixes performers
        by_actor: dict[str, list[Path]] = {}
        for p in by_class[cls]:
            by_actor.setdefault(p.stem.split("_")[1], []).append(p)
        order = []
        lists = [by_actor[a] for a in sorted(by_actor)]
        for i in range(max(len(x) for x in lists)):
            order += [x[i] for x in lists if i < len(x)]
        queues.append(order)
    out: list[Path] = []
    i = 0
    while len(out) < n_clips:
        for q in queues:
            if i < len(q) and len(out) < n_clips:
                out.append(q[i])
        i += 1
    return sorted(out)


def _window_index(F: int, offsets: np.ndarray) -> np.ndarray:
    """(F, L) frame indices ``t + offset`` clamped to the clip."""
    return np.clip(np.arange(F)[:, None] + offsets[None, :], 0, F - 1)


def _point_clouds(gpos_cm: np.ndarray, up: np.ndarray, half: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame centred horizontal (complex, (F, L*J)) and vertical ((F, L*J)) window clouds, L = 2 half + 1."""
    k = int(np.flatnonzero(up)[0])
    a, b = (k + 1) % 3, (k + 2) % 3
    u = gpos_cm[..., a] + 1j * gpos_cm[..., b]  # (F, J); a proper turn about `up` is a unit complex factor
    y = gpos_cm[..., k] * up[k]
    win = _window_index(len(u), np.arange(-half, half + 1))
    U = u[win].reshape(len(u), -1)
    U = U - U.mean(axis=1, keepdims=True)  # optimal ground-plane translation: match the centroids
    return U, y[win].reshape(len(u), -1)


def _angular_velocity(rot: np.ndarray, fps: float) -> np.ndarray:
    """Local angular velocity (F, K, 3) in rad/s by central differences (one-sided at clip ends)."""
    F = len(rot)
    if F < 2:
        return np.zeros(rot.shape[:-1] + (3,))
    prev = np.clip(np.arange(F) - 1, 0, F - 1)
    nxt = np.clip(np.arange(F) + 1, 0, F - 1)
    d = R.quaternion_multiply(R.quaternion_conjugate(rot[prev]), rot[nxt])
    return R.quaternion_to_rotvec(d) * (fps / (nxt - prev))[:, None, None]


@dataclasses.dataclass
class PoseData:
    """Everything the distance measures of Fig. 2 need, one row per frame of the sample database."""

    clips: list[str]
    clip_ids: np.ndarray
    features: dict  # name -> (N, D) cm (PCA: coefficients in cm)
    quat: np.ndarray  # (N, J, 4) local rotations, root heading removed
    euler: np.ndarray  # (N, C) degrees
    pc: dict  # "D_pc1"/"D_pc11" -> (U (N, P) complex, Y (N, P), |U|^2 + |Y|^2 (N,))
    wb_quat: np.ndarray  # (N, 8, 4)
    wb_vel: np.ndarray  # (N, 8, 3) rad/s
    wb_weights: np.ndarray  # (8,)
    pca_explained: list

    @property
    def num_frames(self) -> int:
        return len(self.clip_ids)


def build_pose_data(paths: list[Path], fps: float = 30.0) -> PoseData:
    motions = [mocapkit.load(p).resample(fps) for p in paths]
    feats = {n: [] for n in GEOMETRIC}
    quat, euler, wbq, wbv, cid = [], [], [], [], []
    pcs = {1: ([], []), 11: ([], [])}
    sk0 = motions[0].skeleton
    wb_roles = list(WB_WEIGHTS)
    wb_idx = [find_joint(sk0, r) for r in wb_roles]
    for c, m in enumerate(motions):
        sk = m.skeleton
        if sk.joint_names != sk0.joint_names:
            raise SystemExit(f"{m.name}: its skeleton's joints differ from {motions[0].name}'s")
        for n in GEOMETRIC:
            feats[n].append(feature_set(m, n, scale_cm=True).values)
        heading, _ = root_frame(m)
        rot = np.array(m.rotations)
        rot[:, 0] = R.quaternion_multiply(R.quaternion_conjugate(heading), rot[:, 0])
        quat.append(rot)
        flat = dataclasses.replace(m, rotations=rot)
        keep = [i for i, name in enumerate(flat.channel_names()) if not name.endswith("position")]
        euler.append(flat.channel_values()[:, keep])
        gpos = m.global_positions() * unit_scale_cm(sk)
        up = detect_up_axis(sk)
        for L in pcs:
            U, Y = _point_clouds(gpos, up, L // 2)
            pcs[L][0].append(U)
            pcs[L][1].append(Y)
        wbq.append(rot[:, wb_idx])
        wbv.append(_angular_velocity(rot[:, wb_idx], m.fps))
        cid.append(np.full(m.num_frames, c, dtype=np.int64))
    features = {n: np.concatenate(v) for n, v in feats.items()}
    pca = PCAFeatures(max(PCA_SIZES.values()), scale_cm=True).fit(motions)
    coeff = np.concatenate([pca.transform(m) for m in motions])
    for name, n in PCA_SIZES.items():
        features[name] = np.ascontiguousarray(coeff[:, :n])
    pc = {}
    for L, (Us, Ys) in pcs.items():
        U, Y = np.concatenate(Us), np.concatenate(Ys)
        pc[f"D_pc{L}"] = (U, Y, np.sum(np.abs(U) ** 2, axis=1) + np.sum(Y**2, axis=1))
    return PoseData(
        clips=[m.name for m in motions],
        clip_ids=np.concatenate(cid),
        features=features,
        quat=np.concatenate(quat),
        euler=np.concatenate(euler),
        pc=pc,
        wb_quat=np.concatenate(wbq),
        wb_vel=np.concatenate(wbv),
        wb_weights=np.array([WB_WEIGHTS[r] for r in wb_roles]),
        pca_explained=[float(pca.explained_variance_ratio_[:n].sum()) for n in PCA_SIZES.values()],
    )


def measure_distances(pd: PoseData, name: str, q: np.ndarray, nb: np.ndarray) -> np.ndarray:
    """Distances (Q, K) by measure ``name`` between frames ``q`` (Q,) and their neighbours ``nb`` (Q, K)."""
    if name in pd.features:
        X = pd.features[name]
        return np.linalg.norm(X[nb] - X[q][:, None], axis=-1)
    if name == "D_quat":
        return R.geodesic_angle(pd.quat[q][:, None], pd.quat[nb]).sum(axis=-1)
    if name == "D_euler":
        return np.linalg.norm(pd.euler[nb] - pd.euler[q][:, None], axis=-1)
    if name in pd.pc:
        U, Y, sq = pd.pc[name]
        cross = np.abs(np.einsum("qp,qkp->qk", U[q].conj(), U[nb]))
        dot_y = np.einsum("qp,qkp->qk", Y[q], Y[nb])
        d2 = sq[q][:, None] + sq[nb] - 2.0 * (cross + dot_y)
        return np.sqrt(np.maximum(d2, 0.0) / U.shape[1])
    if name == "D_wb":
        w = pd.wb_weights
        theta = R.geodesic_angle(pd.wb_quat[q][:, None], pd.wb_quat[nb])
        dv = np.sum((pd.wb_vel[nb] - pd.wb_vel[q][:, None, :, :]) ** 2, axis=-1)
        return (theta**2) @ w + WB_NU * (dv @ w)
    raise KeyError(name)


def _rowwise_spearman(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Spearman's rho of each row of ``a`` with the same row of ``b`` (Q, K) -> (Q,); NaN for constant rows."""
    ra = rankdata(a, axis=1)
    rb = rankdata(b, axis=1)
    ra -= ra.mean(axis=1, keepdims=True)
    rb -= rb.mean(axis=1, keepdims=True)
    den = np.sqrt(np.sum(ra * ra, axis=1) * np.sum(rb * rb, axis=1))
    num = np.sum(ra * rb, axis=1)
    return np.divide(num, den, out=np.full(len(num), np.nan), where=den > 0)


def pose_correlations(pd: PoseData, samples: int, neighbors: int, rng: np.random.Generator) -> dict:
    """Fig. 2: mean Spearman rho (rows x columns) over ``samples`` random frames."""
    N = pd.num_frames
    if neighbors + 1 > N:
        raise SystemExit(f"--neighbors {neighbors} needs a database of more than {neighbors + 1} frames, got {N}")
    q_all = rng.choice(N, size=min(samples, N), replace=False)
    rho_sum = np.zeros((len(FEATURE_ROWS), len(MEASURE_COLUMNS)))
    rho_n = np.zeros_like(rho_sum)
    knn_ms = {}
    for r, row in enumerate(FEATURE_ROWS):
        X = pd.features[row]
        index = KNNIndex(X)
        t = time.perf_counter()
        d, idx = index.query(X[q_all], k=neighbors + 1)
        knn_ms[row] = (time.perf_counter() - t) / len(q_all) * 1e3
        keep = idx != q_all[:, None]
        keep &= np.cumsum(keep, axis=1) <= neighbors  # the frame itself out; if it tied away, drop the last
        nb_all = idx[keep].reshape(len(q_all), neighbors)
        dr_all = d[keep].reshape(len(q_all), neighbors)
        for a in range(0, len(q_all), CHUNK):
            q, nb, dr = q_all[a : a + CHUNK], nb_all[a : a + CHUNK], dr_all[a : a + CHUNK]
            for c, col in enumerate(MEASURE_COLUMNS):
                dc = dr if col == row else measure_distances(pd, col, q, nb)
                rho = _rowwise_spearman(dr, dc)
                ok = np.isfinite(rho)
                rho_sum[r, c] += rho[ok].sum()
                rho_n[r, c] += ok.sum()
        _log(f"  row {row}: done")
    mean = rho_sum / np.maximum(rho_n, 1)
    mean[rho_n == 0] = np.nan
    return {"matrix": mean, "counts": rho_n, "knn_ms_per_query": knn_ms, "samples": len(q_all)}


# -- part 2: LNG against subsequence DTW per feature set ---------------------------------------------


def _spearman(a: np.ndarray, b: np.ndarray) -> float | None:
    """Spearman's rho of two samples (infinite values rank last); None where it is undefined."""
    if len(a) < 3 or np.unique(a).size < 2 or np.unique(b).size < 2:
        return None
    return float(spearmanr(a, b).statistic)


def lng_vs_dtw(db, windows: list[Motion], lengths: np.ndarray, K: int = LNG_K) -> dict:
    clips = [db.clip(c) for c in range(db.num_clips)]
    clip_ids = np.asarray(db.clip_ids)
    pca = PCAFeatures(16, scale_cm=True).fit(clips)
    out = {}
    for name in LNG_FEATURES:
        if name in db.features:
            data = np.asarray(db.features[name])
            queries = [db.query_features(w, name) for w in windows]
        elif name == "Fpca16":
            data = np.concatenate([pca.transform(m) for m in clips])
            queries = [pca.transform(w) for w in windows]
        else:
            data = np.concatenate([feature_set(m, name, scale_cm=True).values for m in clips])
            queries = [feature_set(w, name, scale_cm=True).values for w in windows]
        index = db.index(name) if name in db.features else KNNIndex(data)
        # warm numba and caches
        subsequence_dtw(queries[0][:5], data[:1000], clip_ids[:1000])
        d, i = index.query(queries[0], k=16)
        lazy_neighborhood_graph(i, d, clip_ids)
        dtw_cost, lng_cost, same = [], [], []
        dtw_s, knn_s, graph_s = np.zeros(len(queries)), np.zeros(len(queries)), np.zeros(len(queries))
        for n, q in enumerate(queries):
            t0 = time.perf_counter()
            m_dtw = subsequence_dtw(q, data, clip_ids, k=1)
            t1 = time.perf_counter()
            d, i = index.query(q, k=K)
            t2 = time.perf_counter()
            m_lng = lazy_neighborhood_graph(i, d, clip_ids, k=1)
            t3 = time.perf_counter()
            dtw_s[n], knn_s[n], graph_s[n] = t1 - t0, t2 - t1, t3 - t2
            dc = m_dtw[0].cost if m_dtw else np.inf
            lc = m_lng[0].cost if m_lng else np.inf
            dtw_cost.append(dc)
            lng_cost.append(lc)
            same.append(
                bool(m_dtw and m_lng)
                and (m_lng[0].start, m_lng[0].end) == (m_dtw[0].start, m_dtw[0].end)
                and abs(lc - dc) <= 1e-9 * max(1.0, dc)
            )
        dtw_cost, lng_cost, same = np.array(dtw_cost), np.array(lng_cost), np.array(same)
        found = np.isfinite(lng_cost)
        res = {
            "dim": int(data.shape[1]),
            "spearman": _spearman(lng_cost, dtw_cost),
            "spearman_found_only": _spearman(lng_cost[found], dtw_cost[found]),
            "same_best_share": float(same.mean()),
            "found_share": float(found.mean()),
            "cost_ratio_mean": float(np.mean(lng_cost[found] / np.maximum(dtw_cost[found], 1e-12))) if found.any() else None,
            "dtw_ms_per_query": float(dtw_s.mean() * 1e3),
            "lng_ms_per_query": float((knn_s + graph_s).mean() * 1e3),
            "knn_ms_per_query": float(knn_s.mean() * 1e3),
            "graph_ms_per_query": float(graph_s.mean() * 1e3),
            "speedup": float(dtw_s.sum() / max((knn_s + graph_s).sum(), 1e-12)),
            "per_length": {},
        }
        for L in np.unique(lengths):
            sel = lengths == L
            res["per_length"][f"{L / db.fps:g}s"] = {
                "queries": int(sel.sum()),
                "spearman": _spearman(lng_cost[sel], dtw_cost[sel]),
                "same_best_share": float(same[sel].mean()),
                "found_share": float(found[sel].mean()),
                "dtw_ms_per_query": float(dtw_s[sel].mean() * 1e3),
                "lng_ms_per_query": float((knn_s[sel] + graph_s[sel]).mean() * 1e3),
            }
        out[name] = res
        _log(f"  LNG vs DTW {name}: spearman {res['spearman']}, same best {res['same_best_share']:.3f}")
    return out


# -- output -------------------------------------------------------------------------------------------


def heat_map(matrix: np.ndarray, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(13, 7.5))
    lo = min(0.0, float(np.nanmin(matrix)))
    im = ax.imshow(matrix, cmap="viridis", vmin=lo, vmax=1.0, aspect="auto")
    ax.set_xticks(range(len(MEASURE_COLUMNS)), MEASURE_COLUMNS, rotation=45, ha="right")
    ax.set_yticks(range(len(FEATURE_ROWS)), FEATURE_ROWS)
    ax.set_xlabel("distance measure evaluated on the neighbours")
    ax.set_ylabel("feature set choosing the neighbours")
    for r in range(matrix.shape[0]):
        for c in range(matrix.shape[1]):
            v = matrix[r, c]
            shade = (v - lo) / (1.0 - lo) if np.isfinite(v) else 0.0
            ax.text(c, r, "-" if not np.isfinite(v) else f"{v:.2f}", ha="center", va="center", fontsize=9,
                    color="black" if shade > 0.6 else "white")
    fig.colorbar(im, ax=ax, label="mean Spearman rho")
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    os.replace(tmp, path)


def format_matrix(matrix: np.ndarray) -> str:
    w = 8
    lines = [" " * w + "".join(f"{c:>{w}}" for c in MEASURE_COLUMNS)]
    for r, row in enumerate(FEATURE_ROWS):
        lines.append(f"{row:<{w}}" + "".join(f"{v:>{w}.3f}" for v in matrix[r]))
    return "\n".join(lines)


def format_lng(res: dict) -> str:
    def f(v, spec):
        return "n/a" if v is None else format(v, spec)

    head = (
        f"{'features':<9}{'dim':>4}{'spearman':>10}{'(found)':>9}{'same best':>10}{'found':>7}{'cost ratio':>11}"
        f"{'DTW ms':>8}{'LNG ms':>8}{'(kNN)':>7}{'speedup':>8}"
    )
    lines = [head]
    for name, r in res.items():
        lines.append(
            f"{name:<9}{r['dim']:>4}{f(r['spearman'], '.4f'):>10}{f(r['spearman_found_only'], '.4f'):>9}"
            f"{r['same_best_share']:>10.3f}{r['found_share']:>7.3f}{f(r['cost_ratio_mean'], '.4f'):>11}"
            f"{r['dtw_ms_per_query']:>8.2f}{r['lng_ms_per_query']:>8.2f}{r['knn_ms_per_query']:>7.2f}{r['speedup']:>8.2f}"
        )
    for name, r in res.items():
        parts = [
            f"{L}: spearman {f(v['spearman'], '.4f')}, same best {v['same_best_share']:.3f}, found {v['found_share']:.3f}, "
            f"DTW {v['dtw_ms_per_query']:.2f} ms, LNG {v['lng_ms_per_query']:.2f} ms"
            for L, v in r["per_length"].items()
        ]
        lines.append(f"  {name}: " + "; ".join(parts))
    return "\n".join(lines)


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--data", type=os.path.abspath, default=str(DEFAULT_DATA))
    ap.add_argument("--samples", type=int, default=1024, help="random frames for the rank correlations (paper: 1024)")
    ap.add_argument("--neighbors", type=int, default=256, help="nearest neighbours per random frame (paper: 256)")
    ap.add_argument("--pose-clips", type=int, default=0, help="HDM05 clips in the sample database (0: all; paper: 76)")
    ap.add_argument("--queries", type=int, default=64, help="LNG/DTW queries of each length, 1 s and 3 s")
    ap.add_argument("--lng-k", type=int, default=LNG_K, help="kNN per query frame for the LNG (paper/default: 128)")
    ap.add_argument("--out", type=os.path.abspath, default=str(Path(__file__).resolve().parent / "out"))
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    if args.samples < 1 or args.neighbors < 2 or args.queries < 3 or args.lng_k < 1:
        raise SystemExit("--samples must be >= 1, --neighbors >= 2, --queries >= 3, --lng-k >= 1")
    data_dir = Path(args.data)
    out_dir = Path(args.out)
    t_start = time.perf_counter()

    # part 1
    t0 = time.perf_counter()
    paths = hdm05_paths(data_dir, args.pose_clips)
    _log(f"sample database: {len(paths)} HDM05 clips")
    pd = build_pose_data(paths)
    t_build = time.perf_counter() - t0
    rng = np.random.default_rng(args.seed)
    t0 = time.perf_counter()
    corr = pose_correlations(pd, args.samples, args.neighbors, rng)
    t_corr = time.perf_counter() - t0
    n_classes = len({re.sub(r"^HDM_[a-z]+_|_\d+_\d+$", "", p.stem) for p in paths})
    pose_desc = (
        f"{len(paths)} HDM05 clips ({n_classes} classes), {pd.num_frames} frames at 30 fps; "
        f"{corr['samples']} random frames x {args.neighbors} nearest neighbours (exact kd-tree, self excluded)"
    )
    fig_path = out_dir / "krueger_fig2.png"
    heat_map(corr["matrix"], fig_path, f"Rank correlations (Krüger et al. 2010, Fig. 2)\n{pose_desc}")

    # part 2
    t0 = time.perf_counter()
    db = real_database(data_dir)
    held = heldout_motions(data_dir)
    fps = int(db.fps)
    windows = random_windows(held, fps, args.queries, rng) + random_windows(held, 3 * fps, args.queries, rng)
    lengths = np.array([w.num_frames for w in windows])
    lng = lng_vs_dtw(db, windows, lengths, args.lng_k)
    t_lng = time.perf_counter() - t0
    runtime = time.perf_counter() - t_start

    print(f"Fig. 2 rank correlations: {pose_desc}")
    print("rows: feature set choosing the neighbours; columns: distance measure; entry: mean Spearman rho")
    print(format_matrix(corr["matrix"]))
    print("PCA explained variance (8/16/25 components): " + ", ".join(f"{v:.3f}" for v in pd.pca_explained))
    print(f"heat map: {fig_path}")
    print()
    print(
        f"LNG (K={args.lng_k}) vs subsequence DTW on the real database ({db.num_frames} frames, {db.num_clips} clips), "
        f"{len(windows)} held-out queries ({args.queries} x 1 s, {args.queries} x 3 s), single-threaded:"
    )
    print(format_lng(lng))
    print()
    print(f"runtime {runtime:.1f} s (sample database {t_build:.1f} s, correlations {t_corr:.1f} s, LNG/DTW {t_lng:.1f} s)")

    m = corr["matrix"]
    result = {
        "pose": {
            "database": pose_desc,
            "clips": len(paths),
            "classes": n_classes,
            "frames": pd.num_frames,
            "samples": corr["samples"],
            "neighbors": args.neighbors,
            "rows": list(FEATURE_ROWS),
            "columns": list(MEASURE_COLUMNS),
            "matrix": {
                row: {col: (float(m[r, c]) if np.isfinite(m[r, c]) else None) for c, col in enumerate(MEASURE_COLUMNS)}
                for r, row in enumerate(FEATURE_ROWS)
            },
            "pca_explained_variance": dict(zip(PCA_SIZES, pd.pca_explained)),
            "knn_ms_per_query": corr["knn_ms_per_query"],
            "wb_weights": WB_WEIGHTS,
            "wb_velocity_weight_s2": WB_NU,
            "figure": str(fig_path),
        },
        "lng_vs_dtw": {
            "database": f"real CMU and HDM05 ASF/AMC clips at 30 fps without the held-out ones: {db.num_frames} frames, {db.num_clips} clips",
            "frames": db.num_frames,
            "queries": len(windows),
            "query_lengths_s": [1, 3],
            "neighbors": args.lng_k,
            "per_feature": lng,
        },
        "runtime_s": runtime,
        "runtime_parts_s": {"sample_database": t_build, "correlations": t_corr, "lng_vs_dtw": t_lng},
        "threads": 1,
    }
    pairs = (("F30", "F39"), ("F15x3", "F15x5"), ("F15", "F30"), ("Fpca16", "Fpca25"), ("Fpca8", "F15"))
    figures = {}
    for row, col in pairs:
        v = m[FEATURE_ROWS.index(row), MEASURE_COLUMNS.index(col)]
        figures[f"rank correlation {row} ~ {col}"] = float(v) if np.isfinite(v) else None
    harness.emit("krueger_analysis", args, figures=figures, details=result)


if __name__ == "__main__":
    main()
