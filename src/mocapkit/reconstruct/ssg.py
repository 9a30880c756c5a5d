"""Full-body motion from gappy marker trajectories by a subsequence graph (Tautges 2012, chapter 4).

The control signal is a few labelled marker trajectories in a global frame,
with NaN wherever a marker is not seen (flicker, long occlusions, whole frames
missing). The motion is synthesised by stitching original database clips
(sec. 4.3.2):

1. the signal is cut into windows of ``N`` frames overlapping by ``o``
   (:func:`control_windows`);
2. each window gets its ``k`` best database subsequences by subsequence DTW
   with the slope-limited steps and weights of eq. 4.2
   (:func:`mocapkit.search.dtw.subsequence_dtw`, ``steps="tautges"``) over
   the local cost of eq. 4.3: the point-cloud distance of Kovar et al. with
   the optimal rotation about the vertical and translation in the ground plane,
   on a Gaussian-weighted window of a quarter second around each frame
   (:func:`point_cloud_distance`, :func:`point_cloud_cost_matrix`);
3. the subsequences are the nodes of a layered graph, edges join consecutive
   windows and cost the distance of the two subsequences in their overlap after
   each was aligned to the control signal (eq. 4.4; :func:`subsequence_graph`);
4. the cheapest path through it (:func:`shortest_path`) is played back with
   C1 cross-fades in the overlaps (eq. 4.5; :func:`cross_fade`).

Gaps (frames with no marker at all) shorter than half a window are bridged by
the DTW (their local costs are zero: nothing to compare). Longer gaps split
the signal into observed segments; the subsequences of the window before a gap
are extended forward and those of the window after it backward through the
gap at their warping factor (sec. 4.3.5, "Gaps"), and each pair is joined
where the two extensions agree best. Gaps at the start or the end extend the
first or the last window's subsequences.

The result is placed in the markers' coordinate frame: every played-back
subsequence has its pelvis moved by its own optimal alignment with the
control signal, so the reconstruction overlays the markers. The vertical axis
is ``y`` (the database's up axis, as in HDM05, CMU and the Bandai Namco set).

Rigs: subsequences are played back as *bodies* (:func:`._common.body_motion`:
the pelvis, found by its role, and the joints below it), so on the Bandai
Namco game rig, whose root ``joint_Root`` stays on the floor while ``Hips``
carries the translation, the pelvis is what is aligned, cross-faded and
placed; ``joint_Root`` is put back on output as the database's takes hold it
(:func:`._common.held_above`: at the origin, ``Hips`` carrying the
translation; :func:`._common.whole_motion`), as :mod:`.markers` does. A marker on the
pelvis, where seen, places it (:func:`._common.onto_pelvis_marker`).

Departures from the thesis, all documented where they act: the local cost is
the *weighted mean* squared distance (eq. 4.3 divided by the sum of the
weights of the visible points), so frames with few visible markers are not
cheaper; node costs are DTW costs divided by the window length and transition
costs are mean squared joint distances, and the path cost is
``sum(node) + transition_weight * sum(edge)``; subsequences are played back
at the fractional database frames their warping paths give (slerp between
frames), so a slowed-down subsequence does not repeat frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from tqdm.auto import tqdm
from ..progress import bar_disabled, bar_size

from .. import rotations as R
from ..database import MotionDatabase
from ..motion import Motion, Skeleton
from ..search.dtw import subsequence_dtw
from .marker_units import check_marker_scale
from ._common import (align_about_vertical, body_skeleton, database_bodies, database_positions, in_database_units, in_units_of,
                      held_above, onto_marker_heights, onto_pelvis_marker, output_skeleton, per_clip, whole_motion)
from .control import warn_unseen
from .dofs import on_joint_dofs
from ..words import plural

__all__ = [
    "Alignment",
    "point_cloud_distance",
    "point_cloud_cost_matrix",
    "control_windows",
    "Subsequence",
    "SubsequenceGraph",
    "subsequence_graph",
    "shortest_path",
    "cross_fade_weights",
    "cross_fade",
    "reconstruct",
    "framewise",
]

_UP = np.array([0.0, 1.0, 0.0])
# added to a gap transition whose blend needs an extension that stands still at its clip's end:
# such joins are taken only when no pair of subsequences can be joined otherwise
_FROZEN_PENALTY = 1e6


# -- eq. 4.3: point-cloud distance with the optimal vertical rotation and ground translation -----


@dataclass(frozen=True)
class Alignment:
    """The rigid 2-D transform ``T_{theta, x0, z0}`` of eq. 4.3: rotate by ``theta`` about ``y``, then shift in x/z.

    ``theta`` in radians (right-handed about +y: x goes to ``(cos, 0, -sin)``),
    ``x0``, ``z0`` in length units.
    """

    theta: float = 0.0
    x0: float = 0.0
    z0: float = 0.0

    def quaternion(self) -> np.ndarray:
        """The rotation as a unit quaternion (4,), w first."""
        return R.quaternion_from_axis_angle(_UP, self.theta)

    def apply(self, points) -> np.ndarray:
        """``T p`` for points (..., 3)."""
        p = np.asarray(points, dtype=np.float64)
        c, s = np.cos(self.theta), np.sin(self.theta)
        out = np.empty(p.shape)
        out[..., 0] = c * p[..., 0] + s * p[..., 2] + self.x0
        out[..., 1] = p[..., 1]
        out[..., 2] = -s * p[..., 0] + c * p[..., 2] + self.z0
        return out


def point_cloud_distance(target, source, weights=None) -> tuple[float, Alignment]:
    """Eq. 4.3 in closed form: ``min_{theta, x0, z0} sum_j w_j ||p_j - T q_j||^2`` and the optimal ``T``.

    Kovar et al.'s point-cloud distance: the y components are compared as they
    are, the x/z components after the best rotation about y and translation in
    the ground plane (a weighted 2-D Procrustes fit without scaling,
    :func:`mocapkit.reconstruct._common.align_about_vertical`). With the
    weighted centroids removed, ``theta = atan2(S, C)`` with
    ``C = sum w (px qx + pz qz)`` and ``S = sum w (px qz - pz qx)``, and the
    minimum is ``sum w |p|^2 + sum w |q|^2 - 2 sqrt(C^2 + S^2)`` (x/z part), the
    expansion :func:`point_cloud_cost_matrix` evaluates for all pairs at once.

    Parameters
    ----------
    target : float array (K, 3)
        The points ``p_j`` (the control signal), length units, y up.
    source : float array (K, 3)
        The corresponding points ``q_j`` (the database).
    weights : float array (K,), optional
        ``lambda_j >= 0``; 1 when None. Points with a non-finite coordinate in
        either cloud get weight 0.

    Returns
    -------
    cost : float
        The weighted sum of squared distances after alignment (squared length units);
        0 when no point has positive weight.
    alignment : Alignment
        ``T`` with ``T source ~ target`` (the identity when no point counts).

    Examples
    --------
    >>> p = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 2.0], [-1.0, 0.5, 0.0]])
    >>> cost, T = point_cloud_distance(Alignment(0.3, 5.0, -2.0).apply(p), p)
    >>> round(cost, 12), round(T.theta, 12), round(T.x0, 12), round(T.z0, 12)
    (0.0, 0.3, 5.0, -2.0)
    """
    p = np.asarray(target, dtype=np.float64)
    q = np.asarray(source, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or q.shape != p.shape:
        raise ValueError(f"target and source: expected two arrays of shape (K, 3), got {p.shape} and {q.shape}")
    w = np.ones(p.shape[0]) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (p.shape[0],):
        raise ValueError(f"weights: expected shape ({p.shape[0]},), got {w.shape}")
    if np.any(w < 0):
        raise ValueError("weights: expected non-negative values")
    ok = np.isfinite(p).all(axis=1) & np.isfinite(q).all(axis=1) & np.isfinite(w) & (w > 0)
    if not ok.any():
        return 0.0, Alignment()
    p, q, w = p[ok], q[ok], w[ok]
    theta, t = align_about_vertical(q, p, _UP, weights=w)
    T = Alignment(float(theta), float(t[0]), float(t[2]))
    return float(np.sum(w * np.sum((p - T.apply(q)) ** 2, axis=1))), T


def _gaussian_taps(half_window: int) -> np.ndarray:
    """Temporal weights (2h+1,) of the point-cloud window, a Gaussian with sigma = (h+1)/2, peak 1."""
    ell = np.arange(-half_window, half_window + 1, dtype=np.float64)
    sigma = (half_window + 1) / 2.0
    return np.exp(-0.5 * (ell / sigma) ** 2)


def _clip_bounds(clip_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and last frame (N,) of every database frame's clip."""
    ids = np.asarray(clip_ids)
    n = ids.shape[0]
    change = np.flatnonzero(np.diff(ids) != 0) + 1
    starts = np.concatenate([[0], change])
    stops = np.concatenate([change, [n]])
    first = np.repeat(starts, stops - starts)
    last = np.repeat(stops - 1, stops - starts)
    return first, last


class _DatabaseClouds:
    """Database side of eq. 4.3 over all frames: windowed marker coordinates as (N, K) matrices, K = (2h+1) M.

    The x/z coordinates are taken relative to the mean x/z of the frame's own
    markers (a per-frame shift, which the optimal translation absorbs) so that
    the sums below stay small whatever the room coordinates; windows are
    clamped to the frame's clip (edge frames repeat).
    """

    def __init__(self, db_markers: np.ndarray, clip_ids: np.ndarray, half_window: int):
        P = np.asarray(db_markers, dtype=np.float64)
        N, M, _ = P.shape
        first, last = _clip_bounds(clip_ids)
        ell = np.arange(-half_window, half_window + 1)
        idx = np.clip(np.arange(N)[:, None] + ell[None, :], first[:, None], last[:, None])  # (N, L)
        centre = P[:, :, [0, 2]].mean(axis=1)  # (N, 2)
        win = P[idx]  # (N, L, M, 3)
        bx = (win[..., 0] - centre[:, None, None, 0]).reshape(N, -1)
        bz = (win[..., 2] - centre[:, None, None, 1]).reshape(N, -1)
        by = win[..., 1].reshape(N, -1)
        self.bx, self.bz, self.by = bx, bz, by
        # w @ [bx, bz, |b_xz|^2, by^2]^T in one product
        self.stack = np.ascontiguousarray(np.concatenate([bx, bz, bx * bx + bz * bz, by * by], axis=0).T)
        self.xz = np.ascontiguousarray(np.concatenate([bx, bz], axis=0).T)
        self.byT = np.ascontiguousarray(by.T)
        self.N = N
        self.K = bx.shape[1]


class _QueryClouds:
    """Query side of eq. 4.3: Gaussian-weighted, visibility-masked windowed markers (F, K)."""

    def __init__(self, markers: np.ndarray, half_window: int):
        X = np.asarray(markers, dtype=np.float64)
        F, M, _ = X.shape
        ell = np.arange(-half_window, half_window + 1)
        idx = np.arange(F)[:, None] + ell[None, :]
        inside = (idx >= 0) & (idx < F)
        win = X[np.clip(idx, 0, F - 1)]  # (F, L, M, 3)
        vis = np.isfinite(win).all(axis=-1) & inside[:, :, None]
        w = np.where(vis, _gaussian_taps(half_window)[None, :, None], 0.0)
        win = np.where(vis[..., None], win, 0.0)
        W = w.sum(axis=(1, 2))
        with np.errstate(invalid="ignore", divide="ignore"):
            centre = np.einsum("flm,flmc->fc", w, win[..., [0, 2]]) / W[:, None]
        centre[W == 0] = 0.0
        ax = (win[..., 0] - centre[:, None, None, 0]) * (w > 0)
        az = (win[..., 2] - centre[:, None, None, 1]) * (w > 0)
        ay = win[..., 1]
        self.w = w.reshape(F, -1)
        self.wax = (w * ax).reshape(F, -1)
        self.waz = (w * az).reshape(F, -1)
        self.way = (w * ay).reshape(F, -1)
        self.W = W
        self.Sx = self.wax.sum(axis=1)
        self.Sz = self.waz.sum(axis=1)
        self.Asq = (w * (ax * ax + az * az)).reshape(F, -1).sum(axis=1)
        self.Ayy = (w * ay * ay).reshape(F, -1).sum(axis=1)
        self.F = F


def _costs(qc: _QueryClouds, dc: _DatabaseClouds, rows: slice) -> np.ndarray:
    """Eq. 4.3 divided by the weight sum for query frames ``rows`` against every database frame: (rows, N)."""
    w = qc.w[rows]
    N = dc.N
    prod = w @ dc.stack  # (B, 4N)
    Bx, Bz, Bsq, Byy = prod[:, :N], prod[:, N : 2 * N], prod[:, 2 * N : 3 * N], prod[:, 3 * N :]
    px = qc.wax[rows] @ dc.xz  # (B, 2N): sum w ax bx, sum w ax bz
    pz = qc.waz[rows] @ dc.xz
    Ay = qc.way[rows] @ dc.byT
    W = qc.W[rows][:, None]
    Sx = qc.Sx[rows][:, None]
    Sz = qc.Sz[rows][:, None]
    safe = np.where(W > 0, W, 1.0)
    # the query side is already centred (Sx = Sz = 0 up to round-off); keep the terms for exactness
    Cc = px[:, :N] + pz[:, N:] - (Sx * Bx + Sz * Bz) / safe
    Ss = px[:, N:] - pz[:, :N] - (Sx * Bz - Sz * Bx) / safe
    var_a = qc.Asq[rows][:, None] - (Sx * Sx + Sz * Sz) / safe
    var_b = Bsq - (Bx * Bx + Bz * Bz) / safe
    xz = np.maximum(var_a + var_b - 2.0 * np.hypot(Cc, Ss), 0.0)
    y = np.maximum(qc.Ayy[rows][:, None] - 2.0 * Ay + Byy, 0.0)
    return np.where(W > 0, (xz + y) / safe, 0.0)


def _half_window(fps: float, seconds: float) -> int:
    return max(0, int(round(seconds * fps / 2.0 - 0.5)))


def point_cloud_cost_matrix(markers, db_markers, clip_ids=None, half_window: int = 3) -> np.ndarray:
    """The local cost matrix of eq. 4.3 over windows of frames: (F, N), squared length units.

    ``C[n, m]`` compares the point cloud of query frames ``n-h .. n+h`` (the
    visible markers, weighted by a Gaussian of the frame offset with
    ``sigma = (h+1)/2``) with database frames ``m-h .. m+h`` (clamped to
    ``m``'s clip) under one optimal rotation about y and ground translation,
    and divides by the sum of the weights: the weighted *mean* squared marker
    distance (eq. 4.3 itself is the weighted sum; dividing keeps frames with
    few visible markers from looking cheap). A query window with no visible
    marker costs 0 against everything: it carries no information, and DTW
    bridges it. The thesis's window is a quarter second (15 frames at 60 fps,
    ``h = 7``).

    Computed by matrix products over all frames at once (the closed form of
    :func:`point_cloud_distance` expands into weighted sums of coordinate
    products).

    Parameters
    ----------
    markers : float array (F, M, 3)
        Control markers, NaN where not seen.
    db_markers : float array (N, M, 3)
        The same markers in every database frame
        (:func:`mocapkit.reconstruct._common.database_positions`).
    clip_ids : int array (N,), optional
        Clip of each database frame (windows do not cross clips); one clip when None.
    half_window : int
        ``h``.

    Returns
    -------
    C : float array (F, N)
    """
    X, P = _check_pair_markers(markers, db_markers)
    ids = np.zeros(P.shape[0], dtype=np.int64) if clip_ids is None else np.asarray(clip_ids)
    if ids.shape != (P.shape[0],):
        raise ValueError(f"clip_ids: expected shape ({P.shape[0]},), got {ids.shape}")
    h = int(half_window)
    if h < 0:
        raise ValueError(f"half_window: expected a non-negative integer, got {half_window!r}")
    return _costs(_QueryClouds(X, h), _DatabaseClouds(P, ids, h), slice(None))


def _check_pair_markers(markers, db_markers):
    X = np.asarray(markers, dtype=np.float64)
    P = np.asarray(db_markers, dtype=np.float64)
    if X.ndim != 3 or X.shape[2] != 3:
        raise ValueError(f"markers: expected shape (F, M, 3), got {X.shape}")
    if P.ndim != 3 or P.shape[1:] != X.shape[1:]:
        raise ValueError(f"db_markers: expected shape (N, {X.shape[1]}, 3) like the markers, got {P.shape}")
    if not np.isfinite(P).all():
        raise ValueError("db_markers: the database markers must be finite")
    return X, P


# -- windows and gaps --------------------------------------------------------------------------


def control_windows(observed, window: int, overlap: int) -> list[list[tuple[int, int]]]:
    """Step 1 of sec. 4.3.2 with the gap rule of sec. 4.3.5: windows of the control signal, per observed segment.

    Runs of unobserved frames shorter than ``window / 2`` are ignored (the
    windows run over them); longer runs split the signal into segments, and
    leading/trailing runs of that length are left out. Inside a segment the
    windows are ``window`` frames long and consecutive ones overlap by
    ``overlap`` frames; the last one is moved back to end on the segment's end
    (so it may overlap its predecessor by more). A segment shorter than a
    window is one window (the fallback for short clips).

    Parameters
    ----------
    observed : bool array (F,)
        Frames with at least one visible marker.
    window, overlap : int
        ``N >= 2`` and ``1 <= o < N`` frames.

    Returns
    -------
    list of segments, each a list of ``(start, stop)`` frame ranges (stop exclusive).

    Examples
    --------
    >>> obs = np.ones(40, bool); obs[18:30] = False
    >>> control_windows(obs, 10, 5)
    [[(0, 10), (5, 15), (8, 18)], [(30, 40)]]
    """
    obs = np.asarray(observed, dtype=bool)
    if obs.ndim != 1:
        raise ValueError(f"observed: expected shape (F,), got {obs.shape}")
    _check_window(window, overlap)
    if not obs.any():
        raise ValueError("the control signal has no visible marker in any frame")
    F = obs.shape[0]
    big = max(1, (window + 1) // 2)
    # runs of unobserved frames
    d = np.diff(np.concatenate([[1], obs.astype(np.int8), [1]]))
    g0 = np.flatnonzero(d == -1)
    g1 = np.flatnonzero(d == 1)
    cuts = [(a, b) for a, b in zip(g0.tolist(), g1.tolist()) if b - a >= big]
    bounds = []
    lo = 0
    for a, b in cuts:
        if a > lo:
            bounds.append((lo, a))
        lo = b
    if lo < F:
        bounds.append((lo, F))
    step = window - overlap
    out = []
    for s, e in bounds:
        if e - s <= window:
            out.append([(s, e)])
            continue
        seg = []
        a = s
        while a + window < e:
            seg.append((a, a + window))
            a += step
        seg.append((e - window, e))
        out.append(seg)
    return out


def _check_window(window, overlap):
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 2:
        raise ValueError(f"window: expected at least 2 frames, got {window!r}")
    if isinstance(overlap, bool) or not isinstance(overlap, (int, np.integer)) or not 1 <= overlap < window:
        raise ValueError(f"overlap: expected 1 <= overlap < window ({window}) frames, got {overlap!r}")


# -- the subsequence graph ---------------------------------------------------------------------


@dataclass(eq=False)
class Subsequence:
    """A node of the SSG: one database subsequence aligned to one window of the control signal.

    Attributes
    ----------
    layer : int
        Window number (graph layer).
    window : (int, int)
        The control frames ``[start, stop)`` it was matched to.
    start, end : int
        Its database range (inclusive) and ``clip`` its clip number.
    cost : float
        Node cost: the eq. 4.2 DTW cost divided by the window length (mean squared marker distance).
    warping_factor : float
        Database frames per control frame over the warping path, in [1/2, 2] (sec. 4.3.5, footnote 3).
    alignment : Alignment
        Eq. 4.3 over the whole window (``lambda = 1``): the transform that puts
        the subsequence onto the control markers.
    lo, hi : int
        The control frames it covers, ``[lo, hi)``: the window, extended through a
        neighbouring large gap.
    frames : float array (hi - lo,)
        The (fractional) database frame played at each covered control frame.
    """

    layer: int
    window: tuple[int, int]
    start: int
    end: int
    clip: int
    cost: float
    warping_factor: float
    alignment: Alignment
    lo: int
    hi: int
    frames: np.ndarray = field(repr=False)


@dataclass(eq=False)
class SubsequenceGraph:
    """The layered SSG (sec. 4.3.4): ``nodes[i]`` the subsequences of window ``i``.

    ``edges[i]`` (k_i, k_{i+1}) are the transition costs (eq. 4.4, mean squared
    joint distance after each node's alignment) from layer ``i`` to ``i+1`` and
    ``blend[i]`` (k_i, k_{i+1}, 2) the control frames ``[c0, c1)`` where the two
    are cross-faded: the windows' overlap, or inside a large gap the stretch
    where the two extensions agree best. The source node of the thesis is
    implicit (every node of layer 0 may start a path).
    """

    nodes: list[list[Subsequence]]
    edges: list[np.ndarray]
    blend: list[np.ndarray]
    num_frames: int
    segments: list[list[tuple[int, int]]]


def _interp_frames(values: np.ndarray, frames: np.ndarray, first: int, last: int) -> np.ndarray:
    """``values`` (N, ...) linearly interpolated at fractional frames (T,) inside one clip ``[first, last]``."""
    f = np.clip(frames, first, last)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, last)
    a = (f - i0).reshape((-1,) + (1,) * (values.ndim - 1))
    return values[i0] * (1.0 - a) + values[i1] * a


def _frame_map(path: np.ndarray, length: int) -> np.ndarray:
    """Database frame (fractional) for every query row 0..length-1 of a warping path (rows skipped by a (2,1) step interpolated)."""
    rows = path[:, 0].astype(np.float64)
    return np.interp(np.arange(length, dtype=np.float64), rows, path[:, 1].astype(np.float64))


def _extend(frames: np.ndarray, before: int, after: int, rate: float, first: int, last: int) -> np.ndarray:
    """Frame map continued ``before`` frames backward and ``after`` forward at ``rate``, clamped to the clip."""
    pre = frames[0] - rate * np.arange(before, 0, -1)
    post = frames[-1] + rate * np.arange(1, after + 1)
    return np.clip(np.concatenate([pre, frames, post]), first, last)


class _Context:
    """What the graph needs from the database and the control signal."""

    def __init__(self, markers, db_markers, db_positions, clip_ids, half_window):
        self.X = markers
        self.P = db_markers
        self.pos = db_positions
        self.clip_ids = np.asarray(clip_ids)
        self.first, self.last = _clip_bounds(self.clip_ids)
        self.qc = _QueryClouds(markers, half_window)
        self.dc = _DatabaseClouds(db_markers, self.clip_ids, half_window)

    def frozen(self, node: Subsequence, lo: int, hi: int) -> np.ndarray:
        """(hi - lo,) bool: control frames where the node's extension is clamped to its clip's first or last frame."""
        f = node.frames[lo - node.lo : hi - node.lo]
        first, last = self.first[node.start], self.last[node.start]
        t = np.arange(lo, hi)
        outside = (t < node.window[0]) | (t >= node.window[1])
        return outside & ((f <= first) | (f >= last))

    def node_positions(self, node: Subsequence, lo: int, hi: int) -> np.ndarray:
        """Aligned global joint positions (hi - lo, J, 3) of a node over control frames [lo, hi)."""
        f = node.frames[lo - node.lo : hi - node.lo]
        first, last = self.first[node.start], self.last[node.start]
        return node.alignment.apply(_interp_frames(self.pos, f, first, last))


def _retrieve(ctx: _Context, layer: int, a: int, b: int, k: int) -> list[Subsequence]:
    """Step 2: the k best subsequences of window [a, b) by eq. 4.2 subsequence DTW on the eq. 4.3 costs."""
    C = _costs(ctx.qc, ctx.dc, slice(a, b))
    L = b - a
    matches = subsequence_dtw(
        None, None, clip_ids=ctx.clip_ids, k=k, steps="tautges", cost=C, max_overlap=max(0, L // 2)
    )
    if not matches:
        raise ValueError(
            f"no database subsequence matches control frames {a}..{b - 1}: the database clips are "
            f"shorter than half a window ({L} frames); use a smaller window or longer clips"
        )
    out = []
    Xw = ctx.X[a:b]
    for mt in matches:
        frames = _frame_map(mt.path, L)
        first, last = ctx.first[mt.start], ctx.last[mt.start]
        q = _interp_frames(ctx.P, frames, first, last)  # (L, M, 3)
        _, T = point_cloud_distance(Xw.reshape(-1, 3), q.reshape(-1, 3))
        rate = (frames[-1] - frames[0]) / (L - 1) if L > 1 else 1.0
        out.append(
            Subsequence(
                layer=layer,
                window=(a, b),
                start=mt.start,
                end=mt.end,
                clip=int(ctx.clip_ids[mt.start]),
                cost=float(mt.cost) / L,
                warping_factor=float(np.clip(rate, 0.5, 2.0)),
                alignment=T,
                lo=a,
                hi=b,
                frames=frames,
            )
        )
    return out


def _extend_node(ctx: _Context, node: Subsequence, lo: int, hi: int) -> None:
    """Extend a node's coverage to [lo, hi) through a large gap at its warping factor (sec. 4.3.5)."""
    before = node.lo - lo
    after = hi - node.hi
    if before <= 0 and after <= 0:
        return
    first, last = ctx.first[node.start], ctx.last[node.start]
    node.frames = _extend(node.frames, max(before, 0), max(after, 0), node.warping_factor, first, last)
    node.lo = min(node.lo, lo)
    node.hi = max(node.hi, hi)


def _mean_sq(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Mean over frames and joints of squared distances, pairwise: a (ka, T, J, 3), b (kb, T, J, 3) -> (ka, kb)."""
    d = a[:, None] - b[None, :]
    return np.mean(np.sum(d * d, axis=-1), axis=(-1, -2))


def subsequence_graph(
    markers,
    db_markers,
    db_positions,
    clip_ids,
    *,
    window: int,
    overlap: int,
    k: int,
    half_window: int,
    progress: bool = False,
) -> SubsequenceGraph:
    """Steps 1-3 of sec. 4.3.2: windows, their k best subsequences, and the transition costs between layers.

    Parameters
    ----------
    markers : float array (F, M, 3)
        Control markers at the database's frame rate, NaN where not seen.
    db_markers : float array (N, M, 3)
        The same markers in every database frame.
    db_positions : float array (N, J, 3)
        Global joint positions of every database frame (for eq. 4.4).
    clip_ids : int array (N,)
    window, overlap : int
        ``N`` and ``o`` in frames (:func:`control_windows`).
    k : int
        Subsequences per window.
    half_window : int
        Half width of the eq. 4.3 point-cloud window, frames.

    Returns
    -------
    SubsequenceGraph
    """
    X, P = _check_pair_markers(markers, db_markers)
    pos = np.asarray(db_positions, dtype=np.float64)
    if pos.ndim != 3 or pos.shape[0] != P.shape[0] or pos.shape[2] != 3:
        raise ValueError(f"db_positions: expected shape ({P.shape[0]}, J, 3), got {pos.shape}")
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k: expected a positive integer, got {k!r}")
    F = X.shape[0]
    observed = np.isfinite(X).all(axis=-1).any(axis=-1)
    segments = control_windows(observed, window, overlap)
    ctx = _Context(X, P, pos, clip_ids, int(half_window))
    flat = [(si, w) for si, seg in enumerate(segments) for w in seg]
    nodes = []
    for layer, (_, (a, b)) in enumerate(tqdm(flat, desc="windows", disable=bar_disabled(progress), **bar_size())):
        nodes.append(_retrieve(ctx, layer, a, b, int(k)))
    # large gaps: extend the subsequences next to them (first/last layer: to the ends of the signal)
    for j in range(len(nodes)):
        si, (a, b) = flat[j]
        lo = 0 if j == 0 else (flat[j - 1][1][1] if flat[j - 1][0] != si else a)
        hi = F if j == len(nodes) - 1 else (flat[j + 1][1][0] if flat[j + 1][0] != si else b)
        for nd in nodes[j]:
            _extend_node(ctx, nd, lo, hi)
    edges, blend = [], []
    for j in range(len(nodes) - 1):
        U, V = nodes[j], nodes[j + 1]
        a_next = flat[j + 1][1][0]
        b_prev = flat[j][1][1]
        E = np.empty((len(U), len(V)))
        Bl = np.empty((len(U), len(V), 2), dtype=np.int64)
        if flat[j][0] == flat[j + 1][0]:
            # eq. 4.4 on the windows' overlap
            c0, c1 = a_next, b_prev
            pu = np.stack([ctx.node_positions(u, c0, c1) for u in U])
            pv = np.stack([ctx.node_positions(v, c0, c1) for v in V])
            E[:] = _mean_sq(pu, pv)
            Bl[..., 0], Bl[..., 1] = c0, c1
        else:
            # a large gap [b_prev, a_next): both extensions cover it; join them where they agree best
            g0, g1 = b_prev, a_next
            ob = min(overlap, g1 - g0)
            pu = np.stack([ctx.node_positions(u, g0, g1) for u in U])  # (ku, G, J, 3)
            pv = np.stack([ctx.node_positions(v, g0, g1) for v in V])
            d = np.mean(np.sum((pu[:, None] - pv[None, :]) ** 2, axis=-1), axis=-1)  # (ku, kv, G)
            cs = np.cumsum(np.concatenate([np.zeros(d.shape[:2] + (1,)), d], axis=-1), axis=-1)
            run = (cs[..., ob:] - cs[..., :-ob]) / ob  # mean over each blend of ob frames
            # an extension that ran into its clip's end stands still: a blend position is valid
            # when u still moves up to the blend's end and v already moves from its start
            fu = np.stack([ctx.frozen(u, g0, g1) for u in U])  # (ku, G)
            fv = np.stack([ctx.frozen(v, g0, g1) for v in V])
            nu = np.cumsum(fu, axis=1)[:, ob - 1 :] > 0  # u frozen somewhere in [g0, c + ob)
            nv = np.cumsum(fv[:, ::-1], axis=1)[:, ::-1][:, : run.shape[-1]] > 0  # v frozen in [c, g1)
            bad = nu[:, None, :] | nv[None, :, :]
            run = run + np.where(bad, _FROZEN_PENALTY, 0.0)
            best = np.argmin(run, axis=-1)
            E[:] = np.take_along_axis(run, best[..., None], axis=-1)[..., 0]
            Bl[..., 0] = g0 + best
            Bl[..., 1] = g0 + best + ob
        edges.append(E)
        blend.append(Bl)
    return SubsequenceGraph(nodes=nodes, edges=edges, blend=blend, num_frames=F, segments=segments)


def shortest_path(graph: SubsequenceGraph, transition_weight: float = 1.0) -> list[int]:
    """Step 4: the cheapest path from the source through one node per layer (linear time, the graph is a DAG).

    The cost of a path is ``sum(node costs) + transition_weight * sum(edge costs)``
    (the thesis's "additional parameter ... to control the relative importance
    of both"). ``transition_weight=0`` picks every window's best subsequence.

    Returns
    -------
    list of int
        The node index chosen in every layer.
    """
    tw = float(transition_weight)
    if not np.isfinite(tw) or tw < 0:
        raise ValueError(f"transition_weight: expected a non-negative number, got {transition_weight!r}")
    acc = np.array([nd.cost for nd in graph.nodes[0]])
    back = []
    for j, E in enumerate(graph.edges):
        node = np.array([nd.cost for nd in graph.nodes[j + 1]])
        tot = acc[:, None] + tw * E if tw > 0 else np.broadcast_to(acc[:, None], E.shape)
        arg = np.argmin(tot, axis=0)
        back.append(arg)
        acc = tot[arg, np.arange(E.shape[1])] + node
    path = [int(np.argmin(acc))]
    for arg in reversed(back):
        path.append(int(arg[path[-1]]))
    return path[::-1]


# -- eq. 4.5: cross-fading ------------------------------------------------------------------------


def cross_fade_weights(o: int) -> np.ndarray:
    """``alpha(t)``, t = 1..o, of eq. 4.5: C1 (smoothstep) from ``alpha(1) = 1`` to ``alpha(o) = 0``.

    ``alpha = 1 - (3u^2 - 2u^3)`` with ``u = (t-1)/(o-1)``: zero slope at both
    ends, so the blend joins the two subsequences with continuous velocity.
    ``o = 1`` gives ``[0.5]``.

    >>> cross_fade_weights(5).round(4).tolist()
    [1.0, 0.8438, 0.5, 0.1562, 0.0]
    """
    o = int(o)
    if o < 1:
        raise ValueError(f"o: expected at least 1 frame, got {o}")
    if o == 1:
        return np.array([0.5])
    u = np.arange(o, dtype=np.float64) / (o - 1)
    return 1.0 - (3.0 * u * u - 2.0 * u * u * u)


def cross_fade(rot_a, root_a, rot_b, root_b) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 4.5 over one overlap: ``alpha a + (1 - alpha) b`` per frame, by slerp for rotations.

    Parameters
    ----------
    rot_a, rot_b : float array (o, J, 4)
        Local joint rotations (w first) of the outgoing and the incoming subsequence.
    root_a, root_b : float array (o, 3)
        Their root positions.

    Returns
    -------
    rotations (o, J, 4), root_positions (o, 3)
    """
    ra, rb = np.asarray(rot_a, dtype=np.float64), np.asarray(rot_b, dtype=np.float64)
    pa, pb = np.asarray(root_a, dtype=np.float64), np.asarray(root_b, dtype=np.float64)
    if ra.shape != rb.shape or ra.ndim != 3 or ra.shape[2] != 4:
        raise ValueError(f"rot_a, rot_b: expected two arrays of shape (o, J, 4), got {ra.shape} and {rb.shape}")
    if pa.shape != (ra.shape[0], 3) or pb.shape != pa.shape:
        raise ValueError(f"root_a, root_b: expected shape ({ra.shape[0]}, 3), got {pa.shape} and {pb.shape}")
    alpha = cross_fade_weights(ra.shape[0])
    rot = R.slerp(ra, rb, (1.0 - alpha)[:, None])
    root = alpha[:, None] * pa + (1.0 - alpha[:, None]) * pb
    return rot, root


def _play(db: MotionDatabase, bodies, node: Subsequence, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray]:
    """Body rotations (T, B, 4) and pelvis positions (T, 3) of a node at control frames [lo, hi), in the marker frame.

    ``bodies`` is :func:`._common.database_bodies` of ``db``.
    """
    rotations, pelvis = bodies
    f = node.frames[lo - node.lo : hi - node.lo]
    c0, c1 = db.clip_range(node.clip)
    f = np.clip(f, c0, c1 - 1)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, c1 - 1)
    a = f - i0
    q0 = np.asarray(rotations[i0], dtype=np.float64)
    q1 = np.asarray(rotations[i1], dtype=np.float64)
    rot = R.slerp(R.quaternion_normalize(q0), R.quaternion_normalize(q1), a[:, None])
    root = np.asarray(pelvis[i0], dtype=np.float64) * (1 - a[:, None]) + np.asarray(pelvis[i1], dtype=np.float64) * a[:, None]
    T = node.alignment
    rot[:, 0] = R.quaternion_multiply(T.quaternion(), rot[:, 0])
    return rot, T.apply(root)


def _synthesise(db: MotionDatabase, bodies, graph: SubsequenceGraph, path: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Step 5: play the path's subsequences' bodies (:func:`._common.database_bodies`) and cross-fade consecutive ones in their blend ranges.

    Returns body rotations (F, B, 4) and pelvis positions (F, 3).
    """
    F = graph.num_frames
    rot = np.empty((F, bodies[0].shape[1], 4))
    root = np.empty((F, 3))
    chosen = [graph.nodes[j][i] for j, i in enumerate(path)]
    cut = 0  # frames before `cut` are written
    for j, nd in enumerate(chosen):
        if j + 1 < len(chosen):
            c0, c1 = (int(v) for v in graph.blend[j][path[j], path[j + 1]])
        else:
            c0 = c1 = F
        r, p = _play(db, bodies, nd, cut, c0)
        rot[cut:c0], root[cut:c0] = r, p
        if c1 > c0:
            ra, pa = _play(db, bodies, nd, c0, c1)
            rb, pb = _play(db, bodies, chosen[j + 1], c0, c1)
            rot[c0:c1], root[c0:c1] = cross_fade(ra, pa, rb, pb)
        cut = c1
    return R.quaternion_normalize(rot), root


# -- the public entry point ------------------------------------------------------------------------


def _resample_markers(X: np.ndarray, fps: float, target: float) -> np.ndarray:
    """Markers (F, M, 3) at ``fps`` linearly resampled to ``target`` fps, covering the whole input duration.

    Sample times ``k / target`` up to the first one at or after the last input
    frame; a sample with a NaN (or absent) neighbour is NaN.
    """
    if fps == target:
        return X
    F = X.shape[0]
    n = int(np.ceil((F - 1) * target / fps - 1e-9)) + 1
    t = np.arange(n) * (fps / target)
    i0 = np.floor(t + 1e-9).astype(np.int64)
    a = np.clip(t - i0, 0.0, 1.0)
    i0 = np.minimum(i0, F - 1)
    i1 = np.minimum(i0 + 1, F - 1)
    out = X[i0] * (1 - a)[:, None, None] + X[i1] * a[:, None, None]
    exact = a < 1e-9
    out[exact] = X[i0[exact]]
    out[t > F - 1 + 1e-9] = np.nan
    return out


def _check_input(markers, joints, db: MotionDatabase, fps) -> tuple[np.ndarray, list[str], float]:
    """Validated markers (F, M, 3), marker joint names and frame rate of a public entry point."""
    X = np.asarray(markers, dtype=np.float64)
    names = [joints] if isinstance(joints, str) else list(joints)
    if X.ndim != 3 or X.shape[2] != 3:
        raise ValueError(f"markers: expected shape (F, M, 3), got {X.shape}")
    if X.shape[1] != len(names) or not names:
        raise ValueError(f"joints: expected {plural(X.shape[1], 'name')}, one per marker, got {len(names)}")
    sk_db = db.skeletons[0]
    known = set(sk_db.joint_names) | set(sk_db.end_site_names)
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"joints: {', '.join(map(repr, unknown))} not in the database skeleton (joints or end sites)")
    fps = float(fps)
    if not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps: expected a positive number, got {fps!r}")
    if X.shape[0] < 2:
        raise ValueError(f"markers: expected at least 2 frames, got {X.shape[0]}")
    if np.isinf(X).any():
        raise ValueError("markers: infinite values; mark unseen markers with NaN")
    if not np.isfinite(X).all(axis=-1).any():
        raise ValueError("markers: every value is NaN; at least one marker must be seen in one frame")
    check_marker_scale(X, names, db)
    return X, names, fps


def reconstruct(
    markers,
    joints,
    db: MotionDatabase,
    fps: float,
    *,
    window: float = 1 / 3,
    overlap: float = 1 / 6,
    k: int = 8,
    transition_weight: float = 1.0,
    cost_window: float = 0.25,
    skeleton: Skeleton | None = None,
    progress: bool = False,
) -> Motion:
    """Full-body motion from sparse, gappy marker trajectories by the subsequence graph (Tautges 2012, ch. 4).

    See the module notes for the algorithm. The markers are resampled
    (linearly, NaN-aware) to the database's frame rate, the motion is
    synthesised there and resampled back, so the result has the input's ``F``
    frames at ``fps``.

    Parameters
    ----------
    markers : float array (F, M, 3)
        Global marker positions in the database's length units and axes (y up),
        NaN where a marker is not seen; whole frames may be missing.
    joints : sequence of str (M,)
        The joint or end-site name each marker sits on (database skeleton names).
    db : MotionDatabase
        The knowledge base (motions similar to the performance).
    fps : float
        Frame rate of ``markers``.
    window, overlap : float
        Window length ``N`` and overlap ``o`` in seconds (the thesis: N = 20,
        o = 10 frames at 60 fps); converted to database frames (at least 2 and 1).
        A clip or observed stretch shorter than a window is one window.
    k : int
        Subsequences per window (the thesis: 8; 16 for head/back markers).
    transition_weight : float
        Weight of the eq. 4.4 transition costs against the node costs.
    cost_window : float
        Length in seconds of the eq. 4.3 point-cloud window (the thesis: 1/4 s).
    skeleton : Skeleton, optional
        The performer's skeleton (the database's topology); the database's first when None.
    progress : bool
        tqdm bar over the windows.

    Returns
    -------
    Motion
        ``F`` frames at ``fps`` on ``skeleton``, its root in the markers' frame.

    Raises
    ------
    ValueError
        Wrong shapes, unknown joint names, no visible marker at all, fewer than
        two frames, bad parameters, or a database with no usable subsequence.
    """
    X, names, fps = _check_input(markers, joints, db, fps)
    warn_unseen(X, names)
    for name, v in (("window", window), ("overlap", overlap), ("cost_window", cost_window)):
        if not np.isfinite(v) or v < 0:
            raise ValueError(f"{name}: expected a non-negative number of seconds, got {v!r}")
    given = output_skeleton(db, skeleton)
    out_sk, back = in_database_units(db, given)  # the markers are in the database's unit: so is the playback
    N = max(2, int(round(window * db.fps)))
    o = min(N - 1, max(1, int(round(overlap * db.fps))))
    h = _half_window(db.fps, cost_window)
    Xd = _resample_markers(X, fps, db.fps)
    P = database_positions(db, names)
    pos = per_clip(db, lambda m: m.global_positions())
    graph = subsequence_graph(Xd, P, pos, db.clip_ids, window=N, overlap=o, k=k, half_window=h, progress=progress)
    path = shortest_path(graph, transition_weight)
    rot, root = _synthesise(db, database_bodies(db), graph, path)
    root = onto_pelvis_marker(root, Xd, names, db.skeletons[0])
    root = onto_marker_heights(root, rot, Xd, names, out_sk, db.fps, _UP)
    out = in_units_of(whole_motion(Motion(body_skeleton(out_sk), rot, root, db.fps, name="ssg reconstruction"), out_sk, _UP, held_above(db)), given, back)
    if fps != db.fps:
        out = out.resample(fps)[: X.shape[0]]
    return on_joint_dofs(out)


def framewise(markers, joints, db: MotionDatabase, fps: float, *, cost_window: float = 0.25, skeleton: Skeleton | None = None) -> Motion:
    """Baseline: per frame the database pose of least eq. 4.3 cost, placed by its alignment.

    The frame-exact alternative that sec. 4.3.1 argues against for sparse,
    gappy input: every marker's trajectory is linearly interpolated over its
    gaps (held constant before its first and after its last sighting), then
    each frame independently takes the database frame with the least
    point-cloud cost (:func:`point_cloud_cost_matrix`) and that frame's pose,
    rotated and shifted by the frame's optimal alignment. Same inputs and
    output as :func:`reconstruct`.
    """
    X, names, fps = _check_input(markers, joints, db, fps)
    warn_unseen(X, names)
    given = output_skeleton(db, skeleton)
    out_sk, back = in_database_units(db, given)  # the markers are in the database's unit: so is the playback
    Xd = np.array(_resample_markers(X, fps, db.fps))  # a copy: filled in place below
    F = Xd.shape[0]
    t = np.arange(F)
    for j in range(Xd.shape[1]):
        ok = np.isfinite(Xd[:, j]).all(axis=1)
        if ok.any():
            for c in range(3):
                Xd[:, j, c] = np.interp(t, t[ok], Xd[ok, j, c])
    P = database_positions(db, names)
    C = point_cloud_cost_matrix(Xd, P, db.clip_ids, half_window=_half_window(db.fps, cost_window))
    best = np.argmin(C, axis=1)
    rotations, pelvis = database_bodies(db)
    rot = R.quaternion_normalize(np.asarray(rotations[best], dtype=np.float64))
    root = np.asarray(pelvis[best], dtype=np.float64)
    for f in range(F):
        _, T = point_cloud_distance(Xd[f], P[best[f]])
        rot[f, 0] = R.quaternion_multiply(T.quaternion(), rot[f, 0])
        root[f] = T.apply(root[f])
    root = onto_pelvis_marker(root, _resample_markers(X, fps, db.fps), names, db.skeletons[0])
    out = in_units_of(whole_motion(Motion(body_skeleton(out_sk), rot, root, db.fps, name="framewise nearest pose"), out_sk, _UP, held_above(db)), given, back)
    if fps != db.fps:
        out = out.resample(fps)[: X.shape[0]]
    return on_joint_dofs(out)
