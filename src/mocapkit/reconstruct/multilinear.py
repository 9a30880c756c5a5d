"""Multilinear motion models: HOSVD motion tensors of one motion class fitted to sparse accelerations (Tautges 2012, ch. 2).

The clips of one motion class (e.g. HDM05 ``sneak2StepsLStart``) are put in
temporal correspondence by DTW against a reference clip, resampled to a
common length and stacked into two tensors (sec. 2.2.2): the joint rotations
``Theta_q`` with modes DOF (4 quaternion components) x joint x frame x the
natural modes (``("actor", "repetition")`` by default; the thesis has style x
actor x repetition), and the root positions ``Theta_p`` with modes DOF (3) x
frame x the natural modes. Both are decomposed by a (truncated) higher-order
SVD (eq. 2.1). A new motion is synthesised from one weight vector per
natural mode (eqs. 2.3/2.4/2.12)::

    m(lambda) = Phi_t  x_{t+1} (lambda_{t+1} U_{t+1})  ...  x_{t+n} (lambda_{t+n} U_{t+n})

and the weights are fitted to the global, gravity-free coordinate
accelerations of a few sensors (eq. 2.8) under the rotation-invariant
distance of eq. 2.10, whose optimal rotation about the vertical has a closed
form (:func:`acceleration_distance`).

Departures from the thesis, all stated where they happen:

* each clip's pelvis is normalised before stacking (ground-plane position of
  the first aligned frame at the origin, its heading turned to the fixed
  forward axis) and the quaternions are put in one hemisphere per joint
  (against the reference clip), so that linear combinations of quaternion
  components mean something; synthesised quaternions are renormalised;
* the weights of each mode are affine (they sum to one): the optimiser works
  on ``lambda_k = 1/d_k + N_k z_k`` with ``N_k`` an orthonormal basis of the
  sum-zero vectors, so ``z = 0`` is the mean motion of the class and a small
  ridge term pulls towards it; the thesis leaves the scale free;
* timing: the recording is assumed to hold one instance of the class (the
  thesis' pre-segmentation). The model's time axis is first mapped linearly
  onto the recording; then, alternately, the weights are fitted and the time
  map is re-estimated by DTW between the recording and the fitted model's
  accelerations (accepted only when the eq. 2.10 distance drops). The model
  accelerations are always computed on the recording's own time line and
  frame rate (a slower performance has smaller accelerations).
* HDM05 has no style mode and an unequal number of repetitions per actor;
  the tensor grid is completed by ``missing="mean"`` (a missing cell gets the
  mean of the same actor's repetitions) or made complete by
  ``missing="drop"`` (only the repetitions every actor has).

Rigs: the model is of the *body*, the pelvis (found by its role,
:func:`mocapkit.rigs.pelvis_index`) and the joints below it, as the motion
tensors hold it (:mod:`.motion_tensor`): ``Theta_p`` is the pelvis's
trajectory, the sensors' accelerations are simulated on the body, and the
joints above the pelvis are put back on every motion the model gives
(:func:`~mocapkit.reconstruct._common.whole_motion`) as the training clips
hold them (the Bandai Namco ``joint_Root`` at the origin, ``Hips``' position
channels carrying the translation), else on the ground under the pelvis. The
vertical is the clips' (:func:`~mocapkit.features.find_up_axis`). A take's
own layout, a root it moves with the body included, is given back by
:func:`mocapkit.reconstruct.output.laid_out_like`.

The thesis calls the approach restricted (sec. 2.6): one tensor per motion
class, clips of the same "semantic length" (steps, repetitions), and the
recording must be of that class too.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.ndimage import gaussian_filter1d
from scipy.optimize import minimize
from tqdm.auto import tqdm

from .. import rotations as R
from ..features import (Sensor, default_sensors, five_point_derivative, parse_up_axis, virtual_accelerometers,
                        virtual_markers)
from ..motion import Motion, Skeleton, unit_scale_cm
from ..progress import bar_disabled, bar_size
from ..search.dtw import dtw
from ..words import plural
from ._common import body_skeleton, whole_motion
from .hosvd import hosvd, mode_product, reconstruct_tensor, unfold
from .motion_tensor import FIRST_NATURAL_P, FIRST_NATURAL_Q, MotionTensor, hdm05_labels, motion_tensor, time_map

__all__ = [
    "MotionTensor",
    "hdm05_labels",
    "motion_tensor",
    "mode_product",
    "unfold",
    "hosvd",
    "reconstruct_tensor",
    "acceleration_distance",
    "MultilinearModel",
    "simulated_readings",
    "marker_accelerations",
]

# -- the rotation-invariant acceleration distance (eq. 2.10) -------------------------------


def acceleration_distance(a: np.ndarray, b: np.ndarray, up_axis=(0.0, 1.0, 0.0)) -> tuple[float, float]:
    """Eq. 2.10: ``min_theta sum_{f,s} |a_fs - T_theta b_fs|^2`` over rotations about the vertical, in closed form.

    With ``u`` the unit up axis and ``T_theta v = cos(theta) v + sin(theta) u x v
    + (1 - cos(theta)) (u.v) u`` (right-handed rotation by ``theta`` about
    ``u``), ``sum a . T_theta b = A cos(theta) + B sin(theta) + C`` with
    ``A = sum a.b - (u.a)(u.b)``, ``B = sum a.(u x b)``, ``C = sum (u.a)(u.b)``,
    so the optimum is ``theta = atan2(B, A)`` and the distance is
    ``sum |a|^2 + sum |b|^2 - 2 (sqrt(A^2 + B^2) + C)`` (Kovar et al. 2002's
    2-D registration without the translation, which accelerations do not see).

    Parameters
    ----------
    a, b : float arrays (F, S, 3) (any leading shape, the same for both)
        Global coordinate accelerations, e.g. m/s^2. Cells where either is
        non-finite are left out.
    up_axis : axis spec or (3,) vector
        The vertical (``"y"``, 1, ``(0, 1, 0)``).

    Returns
    -------
    distance : float
        The minimal sum of squared differences (units of ``a`` squared).
    theta : float
        Radians; ``T_theta b`` is the best match of ``a``.

    >>> a = np.random.default_rng(0).normal(size=(10, 4, 3))
    >>> q = R.quaternion_from_axis_angle(np.array([0.0, 1.0, 0.0]), 0.7)
    >>> d, th = acceleration_distance(R.quaternion_rotate(q, a), a)
    >>> round(d, 9), round(th, 6)
    (0.0, 0.7)
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape or a.shape[-1:] != (3,):
        raise ValueError(f"acceleration_distance: expected two arrays of one shape (..., 3), got {a.shape} and {b.shape}")
    u = _unit_up(up_axis)
    ok = np.all(np.isfinite(a), axis=-1) & np.all(np.isfinite(b), axis=-1)
    a = a[ok]
    b = b[ok]
    ua = a @ u
    ub = b @ u
    C = float(ua @ ub)
    A = float(np.sum(a * b)) - C
    B = float(np.sum(a * np.cross(u, b)))
    d = float(np.sum(a * a) + np.sum(b * b)) - 2.0 * float(np.hypot(A, B) + C)
    return max(d, 0.0), float(np.arctan2(B, A))


def _unit_up(up_axis) -> np.ndarray:
    if isinstance(up_axis, (str, int, np.integer)):
        return parse_up_axis(up_axis)
    u = np.asarray(up_axis, dtype=np.float64).reshape(-1)
    if u.shape != (3,) or not np.isfinite(u).all() or np.linalg.norm(u) == 0:
        raise ValueError(f"up_axis: expected an axis name or a non-zero (3,) vector, got {up_axis!r}")
    return u / np.linalg.norm(u)


# -- the model (secs. 2.2.3, 2.3) -----------------------------------------------------------


def _sum_zero_basis(d: int) -> np.ndarray:
    """Orthonormal basis (d, d-1) of the vectors whose entries sum to zero."""
    if d == 1:
        return np.zeros((1, 0))
    Q, _ = np.linalg.qr(np.concatenate([np.ones((d, 1)), np.eye(d)[:, : d - 1]], axis=1))
    return Q[:, 1:d]


def _contract(B: np.ndarray, xs: Sequence[np.ndarray]) -> np.ndarray:
    """``B`` times one row vector per trailing (natural) mode, those modes contracted away (eq. 2.12)."""
    out = B
    for x in reversed(xs):
        out = out @ x  # the last axis is the last remaining natural mode
    return out


class MultilinearModel:
    """A multilinear motion model of one motion class and its fit to sparse accelerations (Tautges 2012, ch. 2).

    Parameters
    ----------
    ranks : dict, optional
        Truncation rank per mode name: ``"dof"``, ``"joint"``, ``"frame"`` or a
        natural mode (``"actor"``, ``"repetition"``); modes not named keep
        their full size. The same ranks truncate the root tensor (its DOF mode
        capped at 3). Natural-mode ranks larger than the mode raise.
    modes : sequence of str
        Natural modes (see :func:`motion_tensor`).
    fps : float
        Frame rate of the model time axis.
    frames : int, optional
        Length of the model time axis (the reference clip's when None).
    missing : {"mean", "drop", "raise"}
        Grid completion (see :func:`motion_tensor`).
    regularization : float
        Weight of the ridge term ``sum |z|^2`` (towards the mean motion)
        added to the normalised eq. 2.10 distance.
    warp_iterations : int
        Rounds of "re-estimate the time map by DTW, refit the weights" after
        the fit on the linear time map.
    warp_smoothing : float
        Seconds; Gaussian smoothing of every DTW time map (clip alignment and
        the recording's time map).
    starts : int
        Besides the mean motion, the optimiser also starts from the weights of
        the ``starts`` training clips whose accelerations fit best.
    up_axis : optional
        The vertical; detected from the skeleton when None.
    progress : bool

    Attributes (after :meth:`fit`)
    ------------------------------
    tensor_ : MotionTensor
    core_q_, factors_q_ : core and factor matrices of the rotation tensor
    core_p_, factors_p_ : the same for the root tensor
    skeleton_ : Skeleton
    modes_ : tuple of str
    entries_ : tuple of tuples (the labels along each natural mode)
    """

    def __init__(
        self,
        ranks: dict | None = None,
        modes: Sequence[str] = ("actor", "repetition"),
        fps: float = 30.0,
        frames: int | None = None,
        missing: str = "mean",
        regularization: float = 1e-3,
        warp_iterations: int = 2,
        warp_smoothing: float = 0.1,
        starts: int = 3,
        up_axis=None,
        progress: bool = False,
    ):
        self.ranks = ranks
        self.modes = modes
        self.fps = fps
        self.frames = frames
        self.missing = missing
        self.regularization = regularization
        self.warp_iterations = warp_iterations
        self.warp_smoothing = warp_smoothing
        self.starts = starts
        self.up_axis = up_axis
        self.progress = progress

    # -- fitting the model ---------------------------------------------------------------
    def fit(self, clips: Sequence[Motion] | MotionTensor, labels: Sequence[Sequence] | None = None) -> "MultilinearModel":
        """Build the motion tensors from ``clips`` (or take a :class:`MotionTensor`) and decompose them by HOSVD."""
        if isinstance(clips, MotionTensor):
            tensor = clips
        else:
            tensor = motion_tensor(
                clips, labels, modes=self.modes, fps=self.fps, frames=self.frames, missing=self.missing,
                warp_smoothing=self.warp_smoothing, up_axis=self.up_axis, progress=self.progress,
            )
        ranks = dict(self.ranks or {})
        names_q = ("dof", "joint", "frame") + tensor.modes
        unknown = set(ranks) - set(names_q)
        if unknown:
            raise ValueError(f"ranks name unknown modes {sorted(unknown)}; modes are {names_q}")
        sizes_q = tensor.rotations.shape
        for k, n in enumerate(names_q):
            if n in ranks and not 1 <= int(ranks[n]) <= sizes_q[k]:
                what = "clips" if k >= FIRST_NATURAL_Q else "entries"
                raise ValueError(
                    f"rank {ranks[n]} for mode {n!r} needs at least that many {what}; the tensor has {sizes_q[k]}"
                )
        if tensor.observed.sum() < 2:
            raise ValueError("a multilinear model needs at least 2 observed clips")
        self.tensor_ = tensor
        self.skeleton_ = tensor.skeleton
        self.modes_ = tensor.modes
        self.entries_ = tensor.entries
        self.up_ = np.asarray(tensor.up, dtype=np.float64) if self.up_axis is None else parse_up_axis(self.up_axis)
        rq = [ranks.get(n) for n in names_q]
        names_p = ("dof", "frame") + tensor.modes
        rp = [ranks.get(n) for n in names_p]
        if rp[0] is not None:
            rp[0] = min(int(rp[0]), 3)
        self.core_q_, self.factors_q_ = hosvd(tensor.rotations, rq)
        self.core_p_, self.factors_p_ = hosvd(tensor.root, rp)
        # Phi_t of eq. 2.12: the core times all technical factor matrices, computed once.
        Bq = self.core_q_
        for k in range(FIRST_NATURAL_Q):
            Bq = mode_product(Bq, self.factors_q_[k], k)
        Bp = self.core_p_
        for k in range(FIRST_NATURAL_P):
            Bp = mode_product(Bp, self.factors_p_[k], k)
        self.phi_q_ = Bq  # (4, J, L, r_1..r_n)
        self.phi_p_ = Bp  # (3, L, r_1..r_n)
        return self

    def _check_fitted(self):
        if not hasattr(self, "phi_q_"):
            raise ValueError("this MultilinearModel is not fitted yet; call fit(clips) first")

    # -- weights -----------------------------------------------------------------------
    def _weights(self, weights) -> list[np.ndarray]:
        self._check_fitted()
        shape = self.tensor_.shape
        if weights is None:
            return [np.full(d, 1.0 / d) for d in shape]
        if isinstance(weights, dict):
            unknown = set(weights) - set(self.modes_)
            if unknown:
                raise ValueError(f"weights name unknown modes {sorted(unknown)}; modes are {self.modes_}")
            weights = [weights.get(m, np.full(d, 1.0 / d)) for m, d in zip(self.modes_, shape)]
        weights = list(weights)
        if len(weights) != len(shape):
            raise ValueError(f"{plural(len(weights), 'weight vector')} for the {plural(len(shape), 'mode')} {self.modes_}")
        out = []
        for m, d, w in zip(self.modes_, shape, weights):
            w = np.asarray(w, dtype=np.float64).reshape(-1)
            if w.shape != (d,) or not np.isfinite(w).all():
                raise ValueError(f"weights of mode {m!r}: expected {d} finite values, got shape {np.shape(w)}")
            out.append(w)
        return out

    def clip_weights(self, index: Sequence[int] | Sequence) -> list[np.ndarray]:
        """One-hot weights of a grid cell (eq. 2.2): ``index`` as positions or as labels per mode."""
        self._check_fitted()
        out = []
        for k, (i, ent) in enumerate(zip(index, self.entries_)):
            if i in ent:
                pos = ent.index(i)
            elif isinstance(i, (int, np.integer)):
                pos = int(i)
            else:
                raise ValueError(f"no entry {i!r} in mode {self.modes_[k]!r}; entries are {ent}")
            if not 0 <= pos < len(ent):
                raise ValueError(f"entry {i!r} out of range for mode {self.modes_[k]!r} ({plural(len(ent), 'entry', 'entries')})")
            w = np.zeros(len(ent))
            w[pos] = 1.0
            out.append(w)
        return out

    def _coefficients(self, weights: list[np.ndarray]):
        """x_k = lambda_k U_k (eq. 2.4) for the rotation and the root tensor."""
        xq = [w @ U for w, U in zip(weights, self.factors_q_[FIRST_NATURAL_Q:])]
        xp = [w @ U for w, U in zip(weights, self.factors_p_[FIRST_NATURAL_P:])]
        return xq, xp

    def _synth_arrays(self, weights, phi_q=None, phi_p=None) -> tuple[np.ndarray, np.ndarray]:
        """Rotations (L, J, 4) and root (L, 3) of eq. 2.12 (on the model time axis unless other Phi_t are given)."""
        xq, xp = self._coefficients(weights)
        q = _contract(self.phi_q_ if phi_q is None else phi_q, xq)  # (4, J, L)
        p = _contract(self.phi_p_ if phi_p is None else phi_p, xp)  # (3, L)
        q = np.transpose(q, (2, 1, 0))
        n = np.linalg.norm(q, axis=-1, keepdims=True)
        q = np.where(n > 1e-12, q / np.where(n > 1e-12, n, 1.0), R.identity())
        return q, p.T

    def synthesize(self, weights=None, skeleton: Skeleton | None = None) -> Motion:
        """The motion of eq. 2.3 / 2.12 for one weight vector per natural mode, on the model time axis.

        Parameters
        ----------
        weights : list of arrays (d_k,) or dict mode -> array, optional
            lambda_k per natural mode; uniform (``1/d_k``: the mean motion of
            the class) when None or for a mode a dict leaves out.
        skeleton : Skeleton, optional
            Same topology as the model's; the reference clip's when None.

        Returns
        -------
        Motion with ``frames`` frames at the model fps, the pelvis normalised,
        the joints above it as the training clips hold them (module docstring).
        """
        w = self._weights(weights)
        q, p = self._synth_arrays(w)
        return self._whole(q, p, self._skeleton(skeleton), self.tensor_.fps)

    def _whole(self, q: np.ndarray, p: np.ndarray, skeleton: Skeleton, fps: float) -> Motion:
        """Body rotations (F, B, 4) and pelvis positions (F, 3) as a Motion on the whole ``skeleton``."""
        body = Motion(body_skeleton(skeleton), q, p, fps, name="multilinear")
        return whole_motion(body, skeleton, self.up_, self.tensor_.held)

    def _skeleton(self, skeleton):
        if skeleton is None:
            return self.skeleton_
        if not skeleton.is_compatible(self.skeleton_):
            raise ValueError("the skeleton has a different joint layout from the model's; retarget it first")
        return skeleton

    # -- fitting readings (secs. 2.3.1-2.3.3) ----------------------------------------------
    def _warped_phi(self, u: np.ndarray):
        """Phi_t sampled at fractional model times ``u`` (N,).

        Synthesis is linear, so sampling Phi_t equals sampling the synthesised
        motion. A natural cubic spline along the frame mode keeps the sampled
        trajectories C2: linear interpolation would put acceleration spikes at
        every model frame once the recording has a higher frame rate.
        """
        L = self.tensor_.num_frames
        u = np.clip(np.asarray(u, dtype=np.float64), 0.0, L - 1)
        W = CubicSpline(np.arange(L), np.eye(L), bc_type="natural")(u)  # (N, L)
        phq = np.moveaxis(np.tensordot(W, self.phi_q_, axes=(1, 2)), 0, 2)
        php = np.moveaxis(np.tensordot(W, self.phi_p_, axes=(1, 1)), 0, 1)
        return phq, php

    def fit_readings(
        self,
        accelerations: np.ndarray,
        fps: float,
        sensors: Sequence | None = None,
        orientations: np.ndarray | None = None,
        gravity: float = 9.81,
        skeleton: Skeleton | None = None,
        maxiter: int = 60,
        optimize: bool = True,
        return_info: bool = False,
    ):
        """Fit the mode weights to sparse accelerations (eq. 2.8 with the distance of eq. 2.10).

        Parameters
        ----------
        accelerations : float array (N, S, 3)
            Global, gravity-free coordinate accelerations of ``S`` sensors in
            m/s^2 (eq. 2.7), in any world frame sharing the skeleton's up axis
            (its heading is found by eq. 2.10). With ``orientations``: raw
            accelerometer readings in each sensor's frame (specific force, as
            :func:`~mocapkit.features.virtual_accelerometers` simulates); they
            are turned into the global frame and gravity is removed
            (sec. 2.3.1, eq. 2.6).
        fps : float
            Frame rate of the recording.
        sensors : sequence of Sensor or joint/end-site names (S,), optional
            Where the sensors sit on the model's skeleton;
            :func:`~mocapkit.features.default_sensors` (forearms and shins
            near wrists and ankles) when None.
        orientations : float array (N, S, 4), optional
            Global sensor orientations (w first), when ``accelerations`` are
            sensor-frame readings.
        gravity : float
            m/s^2, removed from readings given with ``orientations``.
        skeleton : Skeleton, optional
            The performer's skeleton (same topology): the model is animated on
            it, so its bone lengths shape the simulated accelerations.
        maxiter : int
            L-BFGS iterations per start.
        optimize : bool
            False keeps the mean motion (uniform weights) on the linear time
            map, only its heading fitted by eq. 2.10: the baseline.
        return_info : bool
            Also return a dict with the distance, heading and time map.

        Returns
        -------
        weights : list of arrays (d_k,)
            lambda per natural mode (affine: each sums to one).
        motion : Motion
            N frames at ``fps`` on the recording's time line, heading turned
            into the recording's world frame (the pelvis's translation starts
            at the ground-plane origin: accelerations do not see it), on
            ``skeleton``, the joints above the pelvis as the training clips
            hold them (module docstring).
        info : dict, only with ``return_info``
            ``distance`` (eq. 2.10, (m/s^2)^2 summed), ``relative_distance``
            (divided by the readings' sum of squares), ``theta`` (radians),
            ``time_map`` (N,) model frame per recording frame, ``mean_distance``
            (the mean motion's relative distance on the linear time map).
        """
        self._check_fitted()
        fps = float(fps)
        if not np.isfinite(fps) or fps <= 0:
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        sk = self._skeleton(skeleton)
        body = body_skeleton(sk)  # the sensors ride on the body the model animates
        if sensors is None:
            sensors = default_sensors(sk, up_axis=self.up_)
        sensors = list(sensors)
        a = np.asarray(accelerations, dtype=np.float64)
        if a.ndim != 3 or a.shape[1:] != (len(sensors), 3):
            raise ValueError(f"accelerations: expected shape (N, {len(sensors)}, 3) for {plural(len(sensors), 'sensor')}, got {a.shape}")
        if a.shape[0] < 5:
            raise ValueError(f"accelerations: need at least 5 frames, got {a.shape[0]}")
        if orientations is not None:
            o = np.asarray(orientations, dtype=np.float64)
            if o.shape != a.shape[:2] + (4,):
                raise ValueError(f"orientations: expected shape {a.shape[:2] + (4,)} (w first), got {o.shape}")
            a = R.quaternion_rotate(o, a) - gravity * self.up_
        if not np.isfinite(a).any():
            raise ValueError("accelerations: no finite value")
        N = a.shape[0]
        L = self.tensor_.num_frames
        scale = unit_scale_cm(sk) / 100.0
        # The fit runs at the model's frame rate: the readings are low-passed (Gaussian, half a model
        # frame) and sampled there. A model built at 30 fps cannot produce the jitter a 120 fps
        # recording carries, and the fit is 4x cheaper.
        rate = self.tensor_.fps
        ratio = fps / rate
        n_fit = max(int(np.floor((N - 1) / ratio + 1e-9)) + 1, 5)
        r = np.minimum(np.arange(n_fit) * ratio, N - 1)  # recording frame of each fit frame
        a_s = gaussian_filter1d(a, 0.5 * ratio, axis=0, mode="nearest") if ratio > 1 else a
        a_fit = np.stack([[np.interp(r, np.arange(N), a_s[:, s_, c]) for c in range(3)] for s_ in range(a.shape[1])])
        a_fit = np.transpose(a_fit, (2, 0, 1))
        norm = float(np.nansum(a_fit * a_fit)) or 1.0
        shape = self.tensor_.shape
        bases = [_sum_zero_basis(d) for d in shape]
        sizes = [b.shape[1] for b in bases]

        def unpack(z):
            out, i = [], 0
            for d, B, s in zip(shape, bases, sizes):
                out.append(1.0 / d + B @ z[i : i + s])
                i += s
            return out

        def pack(weights):
            return np.concatenate([B.T @ (w - 1.0 / d) for w, B, d in zip(weights, bases, shape)])

        def simulate(ws, phq, php):
            """Sensor accelerations (K, n_fit, S, 3) for K weight sets, one forward-kinematics pass."""
            qs, ps = zip(*(self._synth_arrays(w, phq, php) for w in ws))
            K = len(ws)
            m = Motion(body, np.concatenate(qs), np.concatenate(ps), rate)
            pos = _sensor_positions(m, sensors).reshape(K, n_fit, len(sensors), 3)
            return five_point_derivative(pos * scale, rate, order=2, axis=1)

        def distance(w, phq, php):
            return acceleration_distance(a_fit, simulate([w], phq, php)[0], self.up_)

        def fit_weights(u, z_starts):
            phq, php = self._warped_phi(u)
            n = sum(sizes)
            step = 1e-6

            def objective(z):
                # Value and forward-difference gradient from one batched simulation of z and its n shifts.
                zs = [z] + [z + step * e for e in np.eye(n)]
                sims = simulate([unpack(zz) for zz in zs], phq, php)
                f = np.array([acceleration_distance(a_fit, sim, self.up_)[0] / norm + self.regularization * float(zz @ zz)
                              for sim, zz in zip(sims, zs)])
                return f[0], (f[1:] - f[0]) / step

            best = None
            for z0 in z_starts:
                res = minimize(objective, z0, jac=True, method="L-BFGS-B", options={"maxiter": int(maxiter)})
                if best is None or res.fun < best.fun:
                    best = res
            return best.x, best.fun

        # u: model frame of every fit frame; first the linear map of the model onto the recording.
        u = np.linspace(0.0, L - 1, n_fit)
        phq, php = self._warped_phi(u)
        mean_rel = distance(unpack(np.zeros(sum(sizes))), phq, php)[0] / norm
        if not optimize:
            z = np.zeros(sum(sizes))
            return self._finish(unpack(z), distance, u, r, N, sk, fps, norm, mean_rel, return_info)
        # Starting points: the mean and the training clips that already fit best.
        cells = np.argwhere(self.tensor_.observed)
        sims = simulate([[np.eye(d)[i] for d, i in zip(shape, c)] for c in cells], phq, php)
        cell_cost = [acceleration_distance(a_fit, sim, self.up_)[0] for sim in sims]
        order = np.argsort(cell_cost)[: max(int(self.starts), 0)]
        z_starts = [np.zeros(sum(sizes))] + [pack([np.eye(d)[i] for d, i in zip(shape, cells[j])]) for j in order]
        z, f = fit_weights(u, z_starts)
        target = np.nan_to_num(a_fit.reshape(n_fit, -1))
        for _ in tqdm(range(int(self.warp_iterations)), desc="time warp", disable=bar_disabled(self.progress), **bar_size()):
            # Re-estimate the time map: DTW between the recording and the fitted model's accelerations
            # (turned into the recording's frame by eq. 2.10's rotation) under the current map.
            phq, php = self._warped_phi(u)
            sim = simulate([unpack(z)], phq, php)[0]
            _, theta = acceleration_distance(a_fit, sim, self.up_)
            sim_r = R.quaternion_rotate(R.quaternion_from_axis_angle(self.up_, theta), sim).reshape(n_fit, -1)
            _, path = dtw(target, sim_r, steps="tautges")
            if path.shape[0] == 0:
                break
            t = time_map(path[:, ::-1], n_fit, self.warp_smoothing * rate)
            u_new = np.interp(t, np.arange(n_fit), u)
            z_new, f_new = fit_weights(u_new, [z])
            if f_new >= f:
                break
            u, z, f = u_new, z_new, f_new

        return self._finish(unpack(z), distance, u, r, N, sk, fps, norm, mean_rel, return_info)

    def _finish(self, w, distance, u, r, N, sk, fps, norm, mean_rel, return_info):
        """The output of :meth:`fit_readings`: the motion on the recording's frames, turned to its heading."""
        dist, theta = distance(w, *self._warped_phi(u))
        # The time map is carried over from the fit frames to the recording's own frames.
        u_full = np.interp(np.arange(N), r, u)
        q, p = self._synth_arrays(w, *self._warped_phi(u_full))
        heading = R.quaternion_from_axis_angle(self.up_, theta)
        q = np.array(q)
        q[:, 0] = R.quaternion_multiply(heading, q[:, 0])
        p = R.quaternion_rotate(heading, p)
        motion = self._whole(q, p, sk, fps)
        if not return_info:
            return w, motion
        info = {
            "distance": dist,
            "relative_distance": dist / norm,
            "mean_distance": mean_rel,
            "theta": theta,
            "time_map": u_full,
        }
        return w, motion, info


def simulated_readings(motion: Motion, sensors: Sequence[Sensor] | None = None) -> tuple[list, np.ndarray, np.ndarray]:
    """Accelerometers simulated on ``motion`` with their orientations: what :meth:`MultilinearModel.fit_readings`
    takes from a recording with ``orientations`` (sec. 2.3.1: the IMU gives each sensor's orientation, which turns
    its readings into the world frame).

    ``sensors``: :func:`~mocapkit.features.default_sensors` (forearms and shins, near wrists and ankles) when
    None, placed with the vertical of the motion's frames (:func:`~mocapkit.features.find_up_axis`: the Bandai
    Namco rest pose lies along x). Returns ``(sensors, readings (F, S, 3) m/s^2 in each sensor's frame, gravity
    included (:func:`~mocapkit.features.virtual_accelerometers`), orientations (F, S, 4) global, w first)``.
    """
    from ..features import find_up_axis

    up = find_up_axis(motion.skeleton, motion.global_positions())
    sensors = list(default_sensors(motion.skeleton, up_axis=up) if sensors is None else sensors)
    readings = virtual_accelerometers(motion, sensors, up_axis=up)
    grot, _ = motion.global_transforms()
    joints = [motion.skeleton.index(s.joint) for s in sensors]
    orientations = R.quaternion_multiply(grot[:, joints], np.stack([s.rotation for s in sensors]))
    return sensors, readings, orientations


def marker_accelerations(positions: np.ndarray, fps: float, skeleton: Skeleton) -> np.ndarray:
    """The global coordinate accelerations (F, M, 3), m/s^2, of marker trajectories (F, M, 3) in ``skeleton``'s
    length unit: the second derivative by the five-point stencil (:func:`~mocapkit.features.five_point_derivative`,
    Tautges 2012 eq. 3.2). These are what eq. 2.7 asks of a sensor, gravity-free and in the world frame, at the
    joints the markers sit on: :meth:`MultilinearModel.fit_readings` takes them with the joint names as sensors.
    A marker not seen (NaN) gives NaN within two frames of it, which the fit leaves out (eq. 2.10).
    """
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim != 3 or p.shape[-1] != 3:
        raise ValueError(f"positions: expected shape (F, M, 3), got {p.shape}")
    return five_point_derivative(p * (unit_scale_cm(skeleton) / 100.0), float(fps), order=2, axis=0)


def _sensor_positions(motion: Motion, sensors: Sequence) -> np.ndarray:
    """Global positions (F, S, 3), file units, of Sensors (joint frame + offset) or joint / end-site names."""
    if all(isinstance(s, Sensor) for s in sensors):
        sk = motion.skeleton
        idx = [sk.index(s.joint) for s in sensors]
        grot, gpos = motion.global_transforms()
        offs = np.stack([s.offset for s in sensors])
        return gpos[:, idx] + R.quaternion_rotate(grot[:, idx], offs)
    if any(isinstance(s, Sensor) for s in sensors):
        raise ValueError("sensors: give either Sensor objects or joint names, not a mix")
    return virtual_markers(motion, list(sensors))
