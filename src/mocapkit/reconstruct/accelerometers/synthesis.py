"""Per-frame synthesis from accelerometer readings (Tautges 2012, secs. 3.4-3.6).

**Search** (sec. 3.4): the K nearest readings of every new sample (with its recent past, below) in the
knowledge base (:mod:`.knowledge`) feed an
:class:`~mocapkit.search.lng.OnlineLazyNeighborhoodGraph` (window M = 13);
the I cheapest paths ending in the newest column give the poses ``Q^t`` and,
by eq. 3.3, the weights ``W^t`` (:func:`path_weights`).

**Synthesis** (sec. 3.5): with ``synthesis="energy"`` the pose minimises
the energy of eq. 3.4 in the weighted-PCA space of ``Q^t`` keeping 99 % of
the variance (:func:`weighted_pca`, :mod:`.kernels`), starting from the
previous pose; by default (``"mean"``) it is the weighted mean pose of
``Q^t`` (below); with ``synthesis="regression"`` a locally weighted linear
regression of the pose on the recent readings over the graph's cheapest
nodes (below). The root follows the weighted mean root motion of ``Q^t``
(sec. 3.6.4).

The thesis' method is ``standardise=False, n_paths=None,
synthesis="energy"``. The defaults depart from it because held-out takes
say so: on a validation style of the Bandai Namco takes and on a validation
actor of HDM05, standardised readings and the mean of the 16 cheapest paths
do better than the energy (``benchmarks/reconstruct_accelerometers_bandai.py
--validate``; docs/guide/reconstruction.md).

Departures from the thesis:

* Optionally (``history``), the kd-tree key is not one sample's readings
  but the readings now and some database frames back (e.g. ``(0, 3, 6, 9)``:
  0.3 s at 30 fps; :func:`~.knowledge.stacked_readings`, lags clamped at a
  clip's or the stream's first sample). The thesis searches one sample and
  leaves time to the lazy neighbourhood graph (the default, ``(0,)``). On
  the Bandai Namco knowledge base (280,000 frames) the single-sample
  neighbours are so ambiguous that the graph's paths barely beat the nearest
  neighbour; a 0.3 s key cuts the nearest neighbour's own error by a sixth
  (``benchmarks/reconstruct_accelerometers_bandai.py --validate``, on a
  validation style).
* The neighbours' pose vectors are put in one chart of rotation vectors
  (:func:`unwrap_rotvecs`, around the cheapest path's pose) before the
  weighted PCA: a joint turned by about pi (a game rig's thighs) otherwise
  has neighbours whose rotation vectors lie 2 pi apart.
* By default (``standardise``), the search runs on readings scaled to unit
  spread per sensor axis (:attr:`~.knowledge.KnowledgeBase.reading_scale`),
  so that the sensors that swing most (the wrists) do not decide the
  neighbours alone; the graph's node costs are these distances.
* Optionally (``weights="uniform"``), the I paths get equal weights instead
  of eq. 3.3's, which gives the costliest path kept weight 0 (with I = 2 the
  synthesis then sees a single pose).
* By default (``synthesis="mean"``), the pose is the weighted mean of ``Q^t``
  (the weighted-PCA mean) instead of the minimiser of eq. 3.4: a kNN
  regression in pose space, with no priors and no control term.
* Optionally (``synthesis="regression"``, :func:`regression_pose`), the pose
  is regressed, not averaged: over the ``regression_n`` nodes of the newest
  graph column with the lowest path costs (weights
  ``exp(-(c - c_min) / median)``), a weighted ridge regression of their pose
  vectors on their standardised readings now and ``regression_lags`` frames
  back, evaluated at the stream's, and moved from the candidates' weighted
  mean by at most their RMS spread (``regression_cap``). The mean of neighbours whose readings lie
  around the query's on one side is biased; the local linear trend corrects
  it to first order. On a large knowledge base the graph's ranking often
  passes over candidates closer to the truth than the pose it picks, which
  a regression over many of them partly recovers
  (``benchmarks/reconstruct_accelerometers_bandai.py --validate``); on small
  databases (a few hundred frames) the regression has too few candidates
  per input and the mean does better, hence not the default.
* Optionally (``smoothing``), the synthesised pose vector is smoothed
  exponentially, causally: ``a * previous + (1 - a) * new``.
* The control term (eqs. 3.12/3.13) uses the neighbours' sensor velocities
  ``v_i^{t+1}``; ``alpha^{t+1}`` is turned into the root frame by the sensor
  orientations of the previous synthesised pose, and gravity is subtracted.
* The output is posed on the database's first skeleton or the performer's
  (same topology).
* K, the neighbours per sample, defaults to 1 % of the database's frames
  within [128, 4096] (:func:`default_k`; the thesis' 4096 is 0.7 % of its
  560,000 frames): on small databases the thesis' fixed value takes a third
  of the database into every column. I, the paths kept, defaults to 16
  (``n_paths=None``: K / 16, the thesis' 256 of 4096).

Sampling rates. The synthesis runs at the database's rate. Readings at another
rate are linearly interpolated onto the database's time grid as they arrive;
readings at a higher rate are first low-passed at the database's Nyquist
frequency (:func:`anti_alias_filter`, a causal Butterworth filter run sample
by sample), since the knowledge base's readings are differentiated at the
database's rate and carry little above it, while point-sampled faster
readings alias their higher frequencies into the search key (120 Hz readings
of 9 held-out HDM05 takes of actor mm: 15.66 cm point-sampled, 14.98 cm
filtered, 14.44 cm for the same takes' 30 Hz readings; the filter adds about
0.03 s of delay at 30 fps);
the pose returned for a reading is the latest one synthesised at or before its
time (a zero-order hold, at most one database frame late), so the output has
one pose per input sample at the input's rate.

Rigs. The synthesis poses the body: the pelvis (found by its role,
:func:`mocapkit.rigs.pelvis_index`) and the joints below it
(:func:`~mocapkit.reconstruct._common.body_motion`); joints above the pelvis
(the floor-bound root of a game rig) are put back on output as the database's
takes hold them (:func:`~mocapkit.reconstruct._common.held_above`: the Bandai
Namco ``joint_Root`` at the origin, ``Hips`` carrying the translation), else
the root on the ground under the pelvis
(:func:`~mocapkit.reconstruct._common.whole_motion`). A take's own layout, a
root it moves with the body included, is given back by
:func:`mocapkit.reconstruct.output.laid_out_like` (``mocapkit reconstruct``
does it for a motion file given as the readings' source).

Missing readings. A sample with any non-finite value holds the previous pose
(state unchanged, the graph not updated); before the first valid sample the
pose is the knowledge base's mean pose at the origin.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import signal
from tqdm.auto import tqdm
from ...progress import bar_disabled, bar_size

from ... import rotations as R
from ...database import MotionDatabase
from ...features import find_up_axis
from ...motion import Motion, Skeleton, readonly_view, unit_scale_cm
from ...search.lng import OnlineLazyNeighborhoodGraph
from .._common import body_skeleton, held_above, output_skeleton, whole_motion
from ..dofs import on_joint_dofs
from .kernels import FrameEnergy, Rig, minimise
from .knowledge import clip_starts, knowledge_base
from ...words import plural

__all__ = [
    "DEFAULTS",
    "check_params",
    "default_k",
    "anti_alias_filter",
    "path_weights",
    "unwrap_rotvecs",
    "weighted_pca",
    "regression_pose",
    "Pose",
    "AccelerometerReconstructor",
    "reconstruct",
    "reconstruct_mahalanobis",
    "reconstruct_nearest_neighbor",
    "motion_of_poses",
]

#: Default parameters of :class:`AccelerometerReconstructor` (weights of sec. 3.5.3).
DEFAULTS: dict = {
    "k": None,  # kNN per sample; None: 1 % of the database's frames, clamped to [128, 4096] (see default_k)
    "n_paths": 16,  # I, the best OLNG paths kept; None: K / 16 (the thesis' 256 of 4096)
    "history": (0,),  # search key: the readings now and these many database frames back; (0,) is the thesis' one sample
    "window": 13,  # OLNG window M (Fig. 3.19)
    "penalty_factor": 2.0,  # OLNG shortness penalty (Fig. 3.8)
    "extra_steps": True,  # OLNG steps of Fig. 3.10 c
    "w_contr": 1.0,
    "w_prior": 5.0,
    "w_pose": 0.6,
    "w_motion": 0.2,
    "w_smooth": 0.2,
    "variance": 0.99,  # weighted-PCA variance kept (sec. 3.5.3)
    "max_components": 24,
    "iterations": 12,  # majorise-minimise / Gauss-Newton steps per frame
    "synthesis": "mean",  # "mean": the weighted mean pose of Q^t; "energy": minimise eq. 3.4 (the thesis);
    # "regression": locally weighted linear regression of the pose on the recent readings (see regression_pose)
    "regression_n": 256,  # candidates of the regression: the graph's cheapest nodes
    "regression_lags": (0, 3, 6),  # its inputs: the readings now and these many database frames back
    "ridge": 4e-4,  # its ridge, in squared standardised reading units
    "regression_cap": 1.0,  # its pose moves from the candidates' mean by at most this times their RMS spread; None: no bound
    "smoothing": 0.0,  # a in [0, 1): each synthesised pose vector becomes a * previous + (1 - a) * new (causal)
    "prior": "kernel",  # "kernel" (eqs. 3.7-3.13) or "mahalanobis" (sec. 3.6.2 comparison)
    "standardise": True,  # search on readings at unit spread per sensor axis (KnowledgeBase.reading_scale); the thesis: False
    "weights": "cost",  # neighbour weights: "cost" (eq. 3.3) or "uniform" over the I paths kept
    "backend": "kdtree",  # KNNIndex backend ("kdtree" as the thesis; "brute" is faster for large K / small N)
    "eps": 0.0,  # kd-tree approximation factor
    "gravity": 9.81,  # m/s^2
}


def default_k(num_frames: int) -> int:
    """The number of nearest neighbours per sample for a database of ``num_frames`` frames.

    The thesis uses K = 4096 on about 560,000 frames (0.7 %). On databases of
    a few ten thousand frames a fixed 4096 takes a third of the database into
    every column, and the lazy neighbourhood graph then strings together
    paths whose poses have little to do with the readings (the sweep of
    ``benchmarks/reconstruct_accelerometers.py --sweep``). Hence 1 % of the
    frames, at least 128 and at most the thesis' 4096.

    >>> default_k(12_000), default_k(560_000), default_k(1_000)
    (128, 4096, 128)
    """
    return int(min(4096, max(128, round(0.01 * num_frames))))


def path_weights(costs: np.ndarray) -> np.ndarray:
    """Normalised weights of eq. 3.3, ``(max C - c_i) / sum_j (max C - c_j)``; uniform if all costs are equal."""
    c = np.asarray(costs, dtype=np.float64)
    w = c.max() - c
    total = w.sum()
    if not total > 0:
        return np.full(c.shape, 1.0 / c.size)
    return w / total


def unwrap_rotvecs(poses: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Pose vectors (I, 3J) re-expressed joint by joint in the chart of rotation vectors nearest ``ref`` (3J,).

    A rotation by ``theta`` about ``n`` is also the rotation vector
    ``(theta - 2 pi) n``; near ``theta = pi`` the two lie on opposite sides
    of the sphere of radius pi, so neighbouring rotations can have rotation
    vectors 2 pi apart. Per joint the one of ``v`` and ``v (1 - 2 pi / |v|)``
    closer to ``ref``'s is kept: the same rotations, in a chart where means,
    PCA and distances between the neighbours mean what they say (radians).

    >>> v = np.array([[0.0, 0.0, np.pi - 0.1]]); r = np.array([0.0, 0.0, -(np.pi - 0.1)])
    >>> (np.round(unwrap_rotvecs(v, r), 4) + 0.0).tolist()
    [[0.0, 0.0, -3.2416]]
    """
    Q = np.asarray(poses, dtype=np.float64)
    I, D = Q.shape
    V = Q.reshape(I, D // 3, 3)
    r = np.asarray(ref, dtype=np.float64).reshape(1, D // 3, 3)
    th = np.linalg.norm(V, axis=2, keepdims=True)
    alt = V * (1.0 - 2.0 * np.pi / np.maximum(th, 1e-12))
    use = (np.sum((alt - r) ** 2, axis=2) < np.sum((V - r) ** 2, axis=2)) & (th[..., 0] > 1e-12)
    return np.where(use[..., None], alt, V).reshape(I, D)


def weighted_pca(Q: np.ndarray, w: np.ndarray, variance: float = 0.99, max_components: int = 24):
    """Weighted PCA of poses ``Q`` (I, P) with weights ``w`` (I,) summing to 1 (sec. 3.5.3).

    Returns ``mean`` (P,), ``basis`` (P, d) orthonormal columns keeping
    ``variance`` of the weighted variance (at most ``max_components``),
    ``eigenvalues`` (d,) and ``coords`` (I, d) of the samples.
    """
    mu = w @ Q
    D = Q - mu
    Y = D * np.sqrt(w)[:, None]
    lam, vec = np.linalg.eigh(Y.T @ Y)  # ascending
    lam = np.maximum(lam[::-1], 0.0)
    total = lam.sum()
    if not total > 1e-24:
        return mu, np.zeros((Q.shape[1], 0)), np.zeros(0), np.zeros((Q.shape[0], 0))
    d = int(np.searchsorted(np.cumsum(lam) / total, variance - 1e-12) + 1)
    d = max(1, min(d, max_components, lam.size))
    B = np.ascontiguousarray(vec[:, ::-1][:, :d])
    return mu, B, lam[:d], D @ B


def regression_pose(Q: np.ndarray, X: np.ndarray, w: np.ndarray, ridge: float, cap: float | None = None) -> np.ndarray:
    """The pose (P,) a locally weighted linear regression of the poses ``Q`` (n, P) on inputs ``X`` (n, d) predicts at ``X = 0``.

    ``X`` holds each candidate's inputs minus the query's (standardised
    readings now and some frames back), ``w`` (n,) the candidates' weights
    (summing to 1). Solves ``min sum_i w_i |Q_i - b - X_i beta|^2 + ridge |beta|^2``
    and returns the intercept ``b``: the candidates' weighted mean pose
    moved along the first-order trend of pose against readings to where the
    query's readings are. ``ridge`` (squared standardised reading units)
    keeps ``beta`` finite where the candidates' readings span fewer than
    ``d`` directions; with ``ridge`` large the result tends to the
    weighted mean ``w @ Q``. ``cap`` (if given) bounds how far the result
    may move from that mean: at most ``cap`` times the candidates' weighted
    RMS distance to it (same units as ``Q``), the move shortened along its
    direction otherwise. A query whose readings lie outside the candidates'
    would otherwise be extrapolated to a pose none of them is near.

    A departure from Tautges 2012, whose synthesis (sec. 3.5) fits a local
    linear model too (the weighted PCA of the neighbours' poses) but
    relates it to the readings only through the control term of eq. 3.13.

    >>> Q = np.array([[0.0], [1.0], [2.0]]); X = np.array([[-1.0], [0.0], [1.0]]) + 0.5
    >>> float(np.round(regression_pose(Q, X, np.full(3, 1 / 3), 0.0)[0], 6))
    0.5
    """
    Q = np.asarray(Q, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    D = np.concatenate([np.ones((len(X), 1)), X], axis=1)
    DW = D * w[:, None]
    G = D.T @ DW
    G[1:, 1:] += float(ridge) * np.eye(X.shape[1])
    try:
        beta = np.linalg.solve(G, DW.T @ Q)
    except np.linalg.LinAlgError:
        beta = np.linalg.lstsq(G, DW.T @ Q, rcond=None)[0]
    if cap is None:
        return beta[0]
    mean = w @ Q
    shift = beta[0] - mean
    spread = float(np.sqrt(w @ np.sum((Q - mean) ** 2, axis=1)))
    norm = float(np.linalg.norm(shift))
    if norm <= cap * spread:
        return beta[0]
    return mean + shift * (cap * spread / norm)


class Pose(NamedTuple):
    """One synthesised frame of the body: local rotations (B, 4) of the pelvis and the joints below it, w first, and the pelvis position (3,) in skeleton units.

    On a rig whose pelvis is the root (B = J) these are the skeleton's joints
    and root position. Arrays are read-only. :func:`motion_of_poses` stacks
    them into a ``Motion`` on the whole skeleton.
    """

    rotations: np.ndarray
    root_position: np.ndarray


def check_params(params: dict) -> dict:
    """The method's parameters: :data:`DEFAULTS` updated by ``params``, each checked; ValueError naming the first
    bad one (an unknown name included)."""
    unknown = set(params) - set(DEFAULTS)
    if unknown:
        raise ValueError(f"unknown parameter(s) {', '.join(sorted(unknown))}; known: {', '.join(DEFAULTS)}")
    p = {**DEFAULTS, **params}
    for name in ("k", "n_paths", "window", "max_components", "iterations", "regression_n"):
        v = p[name]
        if name in ("k", "n_paths") and v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < (0 if name == "iterations" else 1):
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
        p[name] = int(v)
    for name in ("w_contr", "w_prior", "w_pose", "w_motion", "w_smooth", "penalty_factor", "eps", "gravity", "ridge", "smoothing"):
        v = float(p[name])
        if not np.isfinite(v) or v < 0:
            raise ValueError(f"{name} must be a finite number >= 0, got {p[name]!r}")
        p[name] = v
    if p["regression_cap"] is not None:
        v = float(p["regression_cap"])
        if not np.isfinite(v) or v < 0:
            raise ValueError(f"regression_cap must be a finite number >= 0 or None, got {p['regression_cap']!r}")
        p["regression_cap"] = v
    if not 0 <= p["smoothing"] < 1:
        raise ValueError(f"smoothing must be in [0, 1), got {p['smoothing']!r}")
    if not 0 < float(p["variance"]) <= 1:
        raise ValueError(f"variance must be in (0, 1], got {p['variance']!r}")
    for name in ("history", "regression_lags"):
        h = p[name]
        if (isinstance(h, (str, bytes)) or not hasattr(h, "__len__") or len(h) == 0
                or any(isinstance(g, bool) or not isinstance(g, (int, np.integer)) or g < 0 for g in h)):
            raise ValueError(f"{name} must be a non-empty sequence of lags (integers >= 0, database frames), got {h!r}")
        p[name] = tuple(int(g) for g in h)
    if p["synthesis"] not in ("energy", "mean", "regression"):
        raise ValueError(f"synthesis must be 'energy', 'mean' or 'regression', got {p['synthesis']!r}")
    if p["weights"] not in ("cost", "uniform"):
        raise ValueError(f"weights must be 'cost' or 'uniform', got {p['weights']!r}")
    p["standardise"] = bool(p["standardise"])
    if p["prior"] not in ("kernel", "mahalanobis"):
        raise ValueError(f"prior must be 'kernel' or 'mahalanobis', got {p['prior']!r}")
    return p


def _check_fps(fps, what="fps") -> float:
    f = float(fps)
    if not np.isfinite(f) or f <= 0:
        raise ValueError(f"{what} must be a positive number, got {fps!r}")
    return f


def anti_alias_filter(fps: float, db_fps: float, order: int = 4) -> np.ndarray | None:
    """The low-pass filter (second-order sections, :func:`scipy.signal.butter`) of readings at ``fps`` Hz before they are sampled at ``db_fps`` Hz.

    Cut at the database's Nyquist frequency ``db_fps / 2``; None when the
    readings are not faster than the database (nothing to remove). Causal,
    so :meth:`AccelerometerReconstructor.push` runs it one sample at a time.
    """
    if fps <= db_fps:
        return None
    return signal.butter(order, db_fps / 2.0, btype="low", fs=fps, output="sos")


class AccelerometerReconstructor:
    """Online reconstruction from a stream of accelerometer readings (Tautges 2012, secs. 3.4-3.6).

    Parameters
    ----------
    db : MotionDatabase
        The knowledge base's motions (:func:`knowledge_base` is cached per db and sensors).
    fps : float, optional
        Rate of the readings; the database's when None. Another rate is
        interpolated onto the database's time grid (see the module notes).
    sensors : sequence of Sensor, optional
        :func:`~mocapkit.features.default_sensors` of the database skeleton when None.
    skeleton : Skeleton, optional
        The performer's skeleton (same topology as the database's) to pose the output on.
    **params
        Overrides of :data:`DEFAULTS` (``k``, ``n_paths``, the weights ``w_*``, ``prior``, ...).

    :meth:`push` takes one sample ``(S, 3)`` (m/s^2, sensor frames) and
    returns a :class:`Pose`; :meth:`reset` starts a new stream.
    """

    def __init__(self, db: MotionDatabase, fps: float | None = None, sensors=None, *, skeleton: Skeleton | None = None, **params):
        self.params = check_params(params)
        self.kb = knowledge_base(db, sensors)
        self.sensors = self.kb.sensors
        self.db_fps = float(db.fps)
        self.fps = self.db_fps if fps is None else _check_fps(fps)
        self.skeleton = output_skeleton(db, skeleton)
        self.body = body_skeleton(self.skeleton)
        self.rig = Rig(self.body, self.sensors)
        self.lags = self.params["history"]
        self._clip_start = clip_starts(self.kb.clip_ids) if self.params["synthesis"] == "regression" else None
        self._keep = max(max(self.lags), max(self.params["regression_lags"]) if self._clip_start is not None else 0) + 1
        self.index = self.kb.index(self.params["backend"], self.lags, self.params["standardise"])
        self._key_scale = np.tile(self.kb.reading_scale, len(self.lags)) if self.params["standardise"] else None
        k = self.params["k"]
        self.k = min(default_k(self.kb.num_frames) if k is None else k, self.kb.num_frames)
        n_paths = self.params["n_paths"]
        self.n_paths = max(1, self.k // 16) if n_paths is None else min(n_paths, self.k)
        self.olng = OnlineLazyNeighborhoodGraph(
            self.kb.clip_ids, window=self.params["window"], extra_steps=self.params["extra_steps"],
            penalty_factor=self.params["penalty_factor"],
        )
        self._mean_pose = self.kb.poses.mean(axis=0)
        self._sos = anti_alias_filter(self.fps, self.db_fps)
        self.reset()

    # -- state ------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget the stream: the next :meth:`push` is the first sample."""
        self.olng.reset()
        self._n_in = 0  # input samples pushed
        self._n_grid = 0  # database-rate steps taken
        self._last_in = None
        self._zi = None  # the anti-alias filter's state (sections, 2, 3S), started at the first valid sample
        self._recent: list = []  # the last valid database-rate samples the search key and the regression need, oldest first
        self._p = None  # pose vector of the last synthesised frame
        self._x = None  # its root-frame points (M, 3)
        self._x2 = None  # the frame before's
        self._srot = None  # its sensor orientations (S, 4)
        self._heading = 0.0
        self._ground = np.zeros(3)  # root position on the ground plane, cm
        self._pose = self._make_pose(self._mean_pose, float(np.mean(self.kb.root_height)))
        self.last_info: dict = {}

    def __repr__(self) -> str:
        return (f"AccelerometerReconstructor({self.kb.num_frames} frames @ {self.db_fps:g} fps, input {self.fps:g} fps, "
                f"K={self.k}, I={self.n_paths}, prior={self.params['prior']!r}, pushed={self._n_in})")

    @property
    def pose(self) -> Pose:
        """The pose returned by the last :meth:`push`."""
        return self._pose

    def _make_pose(self, p: np.ndarray, height: float) -> Pose:
        J = self.rig.J
        q = R.rotvec_to_quaternion(p.reshape(J, 3))
        up = self.kb.up
        h = R.quaternion_from_axis_angle(up, self._heading)
        q[0] = R.quaternion_multiply(h, q[0])
        root = (self._ground + height * up) / self.rig.scale
        q = on_joint_dofs(Motion(self.body, q[None], root[None], self.db_fps)).rotations[0]  # the skeleton's dofs
        return Pose(readonly_view(q), readonly_view(root))

    # -- input ------------------------------------------------------------------------------

    def push(self, reading) -> Pose:
        """Add one sample (S, 3) in m/s^2 (sensor frames) and return the pose at its time.

        A sample with a non-finite value holds the previous pose.
        """
        a = np.asarray(reading, dtype=np.float64)
        S = len(self.sensors)
        if a.shape != (S, 3):
            raise ValueError(f"reading: expected shape ({S}, 3) for {plural(S, 'sensor')}, got {a.shape}")
        n = self._n_in
        if self._sos is not None and np.all(np.isfinite(a)):  # a missing sample passes (and holds the pose), the filter skips it
            if self._zi is None:
                self._zi = signal.sosfilt_zi(self._sos)[:, :, None] * a.ravel()
            y, self._zi = signal.sosfilt(self._sos, a.reshape(1, -1), axis=0, zi=self._zi)
            a = y.reshape(S, 3)
        if self.fps == self.db_fps:
            self._step(a)
        else:
            # database-grid times k / db_fps in (t_{n-1}, t_n], linearly interpolated
            t_n = n / self.fps
            while self._n_grid / self.db_fps <= t_n + 1e-9:
                tau = self._n_grid / self.db_fps
                if n == 0 or self._last_in is None:
                    v = a
                else:
                    t_prev = (n - 1) / self.fps
                    f = min(max((tau - t_prev) * self.fps, 0.0), 1.0)
                    v = a if f >= 1.0 else self._last_in * (1.0 - f) + a * f
                self._step(v)
            self._last_in = a.copy()
        self._n_in += 1
        return self._pose

    def _step(self, a: np.ndarray) -> None:
        """One database-rate frame of synthesis from the sample ``a`` (S, 3)."""
        self._n_grid += 1
        if not np.all(np.isfinite(a)):
            self.last_info = {"held": True}
            return
        p, kb = self.params, self.kb
        dt = 1.0 / self.db_fps
        self._recent = (self._recent + [a])[-self._keep:]
        # the search key: this sample and those ``lags`` frames back, the stream's first where it is shorter
        key = np.concatenate([self._recent[max(len(self._recent) - 1 - g, 0)].ravel() for g in self.lags])
        if self._key_scale is not None:
            key = key * self._key_scale
        dist, idx = self.index.query(key[None], k=self.k, eps=p["eps"])
        costs = self.olng.push(idx[0], dist[0])
        good = np.flatnonzero(np.isfinite(costs))
        if good.size == 0:
            self.last_info = {"held": True}
            return
        n = min(self.n_paths, good.size)
        sel = good if n == good.size else good[np.argpartition(costs[good], n - 1)[:n]]
        sel = sel[np.lexsort((idx[0, sel], costs[sel]))]
        frames = idx[0, sel]
        w = path_weights(costs[sel]) if p["weights"] == "cost" else np.full(n, 1.0 / n)
        # one chart for all neighbours: a joint turned by about pi (the game rig's thighs) has rotation
        # vectors on both sides of the sphere of radius pi, whose mean and PCA would be meaningless
        Q = unwrap_rotvecs(kb.poses[frames], kb.poses[frames[0]])
        X = None  # the synthesised pose's root-frame points, where the synthesis gives them
        if p["synthesis"] == "energy":
            pose, mu, X, E, steps, d = self._minimise_energy(a, Q, w, frames, dt)
        else:  # the weighted mean pose of Q^t, or the regression's: no PCA, no energy
            mu = w @ Q
            pose = mu if p["synthesis"] == "mean" else self._regression(idx[0], costs, good, kb.poses[frames[0]])
            E, steps, d = float("nan"), 0, 0
        a_s = p["smoothing"]
        if a_s > 0 and self._p is not None:  # exponential smoothing of the pose vector, in the new pose's chart
            pose = a_s * unwrap_rotvecs(self._p[None], pose)[0] + (1.0 - a_s) * pose
            X = None
        points, srot = (x[0] for x in self.rig.points(pose[None]))
        X = points if X is None else X
        # sec. 3.6.4: the weighted mean root motion of Q^t
        up = kb.up
        v = w @ kb.root_velocity[frames]
        v = v - (v @ up) * up
        self._ground = self._ground + R.quaternion_rotate(R.quaternion_from_axis_angle(up, self._heading), v) * dt
        self._heading += float(w @ kb.yaw_rate[frames]) * dt
        height = float(w @ kb.root_height[frames])
        self._x2, self._x, self._srot, self._p = self._x, X, srot, pose
        self._pose = self._make_pose(pose, height)
        self.last_info = {"held": False, "energy": E, "steps": steps, "components": d, "paths": n,
                          "best_cost": float(costs[sel[0]]), "frames": frames, "weights": w, "mean_pose": mu}


    def _regression(self, idx: np.ndarray, costs: np.ndarray, good: np.ndarray, ref: np.ndarray) -> np.ndarray:
        """The pose of :func:`regression_pose` over the graph's ``regression_n`` cheapest nodes (``synthesis="regression"``).

        Candidates: the nodes of the newest column with the lowest path costs
        (``costs`` over the K neighbours ``idx``; ``good`` the finite ones),
        weighted ``exp(-(c - c_min) / median(c - c_min))``. Inputs: their
        standardised readings now and ``regression_lags`` frames back (clamped at
        their clip's first frame) minus the stream's (clamped at its first
        sample). Poses in the rotation-vector chart of ``ref`` (:func:`unwrap_rotvecs`).
        """
        p, kb = self.params, self.kb
        n = min(p["regression_n"], good.size)
        order = good[np.lexsort((idx[good], costs[good]))][:n]
        frames = idx[order]
        c = costs[order] - costs[order[0]]
        h = float(np.median(c))
        w = np.exp(-c / h) if h > 0 else np.ones(n)
        w = w / w.sum()
        scale = kb.reading_scale
        start = self._clip_start[frames]
        X = np.concatenate([
            (np.asarray(kb.readings[np.maximum(frames - g, start)], dtype=np.float64)
             - self._recent[max(len(self._recent) - 1 - g, 0)].ravel()) * scale
            for g in p["regression_lags"]], axis=1)
        return regression_pose(unwrap_rotvecs(kb.poses[frames], ref), X, w, p["ridge"], p["regression_cap"])

    def _minimise_energy(self, a: np.ndarray, Q: np.ndarray, w: np.ndarray, frames: np.ndarray, dt: float):
        """Eq. 3.4 minimised in the weighted-PCA space of the neighbour poses ``Q`` (I, 3J), from the previous pose.

        Returns the pose vector (3J,), the weighted-PCA mean (3J,), the root-frame
        points (M, 3, cm), the energy, the steps taken and the PCA dimension.
        """
        p, kb = self.params, self.kb
        mu, B, lam, Z = weighted_pca(Q, w, p["variance"], p["max_components"])
        rperp2 = np.maximum(np.sum((Q - mu) ** 2, axis=1) - np.sum(Z * Z, axis=1), 0.0)
        V = kb.velocities[frames].astype(np.float64)
        A = kb.accelerations[frames].astype(np.float64)
        Xm = Xc = As = base = None
        if self._x is not None:
            Xm = self._x + V * dt + 0.5 * A * dt * dt
            # eq. 3.12: the reading turned into the root frame by the previous pose's sensor frames, gravity removed
            f = R.quaternion_rotate(self._srot, a)
            alpha = (f - p["gravity"] * kb.up) * 100.0  # cm/s^2
            sens = slice(self.rig.J - 1, self.rig.M)
            Xc = self._x[sens] + V[:, sens] * dt + 0.5 * alpha * dt * dt
            if self._x2 is not None:
                As = A
                base = (-2.0 * self._x + self._x2) / dt**2
        prob = FrameEnergy(self.rig, p, p["prior"], w, mu, B, lam, Z, rperp2, Xm, As, base, Xc, dt)
        z0 = np.zeros(B.shape[1]) if self._p is None else (unwrap_rotvecs(self._p[None], mu)[0] - mu) @ B
        z, X, E, steps = minimise(prob, z0, p["iterations"])
        return prob.pose(z), mu, X, E, steps, B.shape[1]


# -- offline -----------------------------------------------------------------------------------


def _check_readings(readings, sensors) -> np.ndarray:
    a = np.asarray(readings, dtype=np.float64)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"readings: expected shape (F, S, 3), got {a.shape}")
    if a.shape[1] != len(sensors):
        raise ValueError(f"readings have {plural(a.shape[1], 'sensor')} but {plural(len(sensors), 'sensor')} {'was' if len(sensors) == 1 else 'were'} given")
    return a


def motion_of_poses(poses: list[Pose], skeleton: Skeleton, fps: float, name: str = "reconstruction", up=None,
                    held: Motion | None = None) -> Motion:
    """The Motion (F frames at ``fps`` on ``skeleton``) of the poses :meth:`AccelerometerReconstructor.push` returned.

    Poses of the body of a rig whose pelvis is not the root are put back on
    the whole skeleton (:func:`~mocapkit.reconstruct._common.whole_motion`),
    the joints above the pelvis as ``held`` has them (the database's takes hold
    them still: :func:`~mocapkit.reconstruct._common.held_above`), else the
    root on the ground plane orthogonal to ``up`` (found from the poses
    when None). Each joint is turned only about its skeleton's rotation dofs
    (:func:`~mocapkit.reconstruct.dofs.on_joint_dofs`: what an AMC keeps).
    """
    body = body_skeleton(skeleton)
    if not poses:
        return Motion(skeleton, np.zeros((0, skeleton.num_joints, 4)), np.zeros((0, 3)), fps, name)
    m = Motion(body, np.stack([p.rotations for p in poses]), np.stack([p.root_position for p in poses]), fps, name)
    if body is skeleton:
        return on_joint_dofs(m)
    if up is None:
        up = find_up_axis(body, m.global_positions())
    return on_joint_dofs(whole_motion(m, skeleton, np.asarray(up, dtype=np.float64), held))


def reconstruct(readings, db: MotionDatabase, fps: float, sensors=None, *, skeleton: Skeleton | None = None,
                progress: bool = False, **params) -> Motion:
    """Reconstruct a motion from accelerometer readings (Tautges 2012, ch. 3): :meth:`AccelerometerReconstructor.push` per sample.

    Parameters
    ----------
    readings : float array (F, S, 3)
        m/s^2 in each sensor's frame, as :func:`~mocapkit.features.virtual_accelerometers` gives them.
    db : MotionDatabase
    fps : float
        Rate of the readings; the output has one frame per sample at this rate.
    sensors : sequence of Sensor (S,), optional
        :func:`~mocapkit.features.default_sensors` of the database skeleton when None.
    skeleton : Skeleton, optional
        Performer's skeleton for the output (same topology as the database's).
    progress : bool
        Show a tqdm bar.
    **params
        Overrides of :data:`DEFAULTS`.

    Returns
    -------
    Motion (F frames at ``fps``) on ``skeleton`` or the database's first skeleton.
    """
    fps = _check_fps(fps)
    rec = AccelerometerReconstructor(db, fps, sensors, skeleton=skeleton, **params)
    a = _check_readings(readings, rec.sensors)
    poses = [rec.push(r) for r in tqdm(a, desc="frames", disable=bar_disabled(progress), **bar_size(), leave=False)]
    return motion_of_poses(poses, rec.skeleton, fps, "reconstruction", up=rec.kb.up, held=held_above(db))


def reconstruct_mahalanobis(readings, db: MotionDatabase, fps: float, sensors=None, *, skeleton=None,
                            progress: bool = False, **params) -> Motion:
    """Baseline of sec. 3.6.2: every prior and the control term as a weighted Gaussian (Mahalanobis), not kernels.

    :func:`reconstruct` with ``prior="mahalanobis"`` and ``synthesis="energy"``: the pose prior is the
    Gaussian of the PCA space (``0.5 sum z_k^2 / lambda_k``), the motion,
    smoothness and control terms Gaussians fitted (weighted, ridge-regularised)
    to the same samples as the kernels use.
    """
    return reconstruct(readings, db, fps, sensors, skeleton=skeleton, progress=progress, **{**params, "prior": "mahalanobis", "synthesis": "energy"})


def _grid_map(F: int, fps: float, db_fps: float):
    """Database-grid readings times (G,) and, per input sample, the grid step it holds (F,), as the stream does."""
    if F == 0:
        return np.zeros(0), np.zeros(0, dtype=np.int64)
    t_last = (F - 1) / fps
    G = int(np.floor(t_last * db_fps + 1e-9 * db_fps)) + 1
    tau = np.arange(G) / db_fps
    held = np.floor((np.arange(F) / fps + 1e-9) * db_fps).astype(np.int64)
    return tau, np.minimum(held, G - 1)


def reconstruct_nearest_neighbor(readings, db: MotionDatabase, fps: float, sensors=None, *, skeleton=None) -> Motion:
    """Baseline: each sample's single nearest database reading, its pose and root motion (no graph, no priors).

    The same knowledge base, rate handling and root integration as
    :func:`reconstruct`; a non-finite sample holds the previous pose.
    """
    fps = _check_fps(fps)
    kb = knowledge_base(db, sensors)
    a = _check_readings(readings, kb.sensors)
    whole = output_skeleton(db, skeleton)
    sk = body_skeleton(whole)
    F = a.shape[0]
    db_fps = float(db.fps)
    if fps == db_fps:
        g, held = a, np.arange(F)
    else:
        tau, held = _grid_map(F, fps, db_fps)
        t = np.arange(F) / fps
        flat = a.reshape(F, -1)
        g = np.stack([np.interp(tau, t, flat[:, c]) for c in range(flat.shape[1])], axis=1).reshape(len(tau), -1, 3)
    _, idx = kb.index("kdtree").query(g.reshape(len(g), -1), k=1)
    idx = idx[:, 0]
    J, up, dt = sk.num_joints, kb.up, 1.0 / db_fps
    scale = unit_scale_cm(sk)
    rot = np.empty((len(g), J, 4))
    root = np.empty((len(g), 3))
    p = kb.poses.mean(axis=0)
    ground, heading, height = np.zeros(3), 0.0, float(np.mean(kb.root_height))
    for k, i in enumerate(idx):
        if i >= 0:
            p = kb.poses[i]
            v = kb.root_velocity[i] - (kb.root_velocity[i] @ up) * up
            ground = ground + R.quaternion_rotate(R.quaternion_from_axis_angle(up, heading), v) * dt
            heading += float(kb.yaw_rate[i]) * dt
            height = float(kb.root_height[i])
        q = R.rotvec_to_quaternion(p.reshape(J, 3))
        q[0] = R.quaternion_multiply(R.quaternion_from_axis_angle(up, heading), q[0])
        rot[k], root[k] = q, (ground + height * up) / scale
    return on_joint_dofs(whole_motion(Motion(sk, rot[held], root[held], fps, "nearest neighbour"), whole, up, held_above(db)))
