"""The energy of one synthesised frame and its minimiser (Tautges 2012, sec. 3.5).

The pose minimises eq. 3.4,
``w_prior (w_pose E_pose + w_motion E_motion + w_smooth E_smooth) + w_contr E_contr``,
with the square-root kernels of eqs. 3.7, 3.9, 3.10 and 3.13, in the
weighted-PCA space of the neighbour poses ``Q^t`` (:class:`FrameEnergy`;
``prior="mahalanobis"`` replaces every kernel by a weighted Gaussian, the
comparison of sec. 3.6.2). Points are in the root frame
(:mod:`.knowledge`), centimetres.

Departures from the thesis:

* Minimiser (:func:`minimise`): instead of MATLAB's ``lsqnonlin``,
  majorise-minimise with Gauss-Newton steps: each square-root kernel
  ``sqrt(|r|)`` is bounded by a quadratic tangent at the current residual
  (iteratively reweighted least squares), forward kinematics is linearised
  by finite differences in the PCA coordinates, and a halving line search
  keeps every step downhill on the true energy (eq. 3.4). The kernel prior
  runs in numba (forward kinematics on scalars,
  :mod:`mocapkit._numba_quaternions`); :func:`minimise_numpy` is its slow
  twin for any prior.
* The pose prior (eq. 3.7) measures ``|q_i - q|`` between rotation-vector
  pose vectors (the thesis: joint angles); the residual of ``q_i`` outside
  the PCA subspace stays in the distance.
* The control term (eqs. 3.12/3.13) uses the sensor positions themselves (on
  the forearm / shin) as the "joints next to the sensors".
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..._numba_quaternions import qexp, qmul, qrot
from ...motion import Skeleton, unit_scale_cm

__all__ = ["Rig", "FrameEnergy", "minimise", "minimise_numpy"]

_EPS_POSE = 1e-4  # rad: floor of the pose residual in the reweighting
_EPS_POS = 1e-3  # cm (cm/s^2 for the smoothness residual)
_FD_STEP = 1e-4  # finite-difference step in PCA coordinates


# -- forward kinematics in the root frame ---------------------------------------------------


@numba.njit(cache=True)
def _fk_one(pose, parents, offsets, sens_joint, sens_off, sens_rot, pts, srot, g, p):
    """Forward kinematics of one pose vector (3J,) into ``pts`` (M, 3) and ``srot`` (S, 4); ``g``, ``p`` scratch."""
    J = parents.shape[0]
    S = sens_joint.shape[0]
    for j in range(J):
        q0, q1, q2, q3 = qexp(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2])
        par = parents[j]
        if par < 0:
            g[j, 0], g[j, 1], g[j, 2], g[j, 3] = q0, q1, q2, q3
            p[j, 0] = 0.0
            p[j, 1] = 0.0
            p[j, 2] = 0.0
        else:
            a0, a1, a2, a3 = g[par, 0], g[par, 1], g[par, 2], g[par, 3]
            g[j, 0], g[j, 1], g[j, 2], g[j, 3] = qmul(a0, a1, a2, a3, q0, q1, q2, q3)
            ox, oy, oz = qrot(a0, a1, a2, a3, offsets[j, 0], offsets[j, 1], offsets[j, 2])
            p[j, 0] = p[par, 0] + ox
            p[j, 1] = p[par, 1] + oy
            p[j, 2] = p[par, 2] + oz
    for j in range(1, J):
        pts[j - 1, 0] = p[j, 0]
        pts[j - 1, 1] = p[j, 1]
        pts[j - 1, 2] = p[j, 2]
    for k in range(S):
        j = sens_joint[k]
        a0, a1, a2, a3 = g[j, 0], g[j, 1], g[j, 2], g[j, 3]
        ox, oy, oz = qrot(a0, a1, a2, a3, sens_off[k, 0], sens_off[k, 1], sens_off[k, 2])
        pts[J - 1 + k, 0] = p[j, 0] + ox
        pts[J - 1 + k, 1] = p[j, 1] + oy
        pts[J - 1 + k, 2] = p[j, 2] + oz
        srot[k, 0], srot[k, 1], srot[k, 2], srot[k, 3] = qmul(
            a0, a1, a2, a3, sens_rot[k, 0], sens_rot[k, 1], sens_rot[k, 2], sens_rot[k, 3]
        )


@numba.njit(cache=True)
def _fk_points(poses, parents, offsets, sens_joint, sens_off, sens_rot, pts, srot):
    """Root-frame points of pose vectors (forward kinematics, root rotation = tilt, root at the origin).

    poses (B, 3J) rotation vectors; parents (J,); offsets (J, 3) cm; sensors on
    joints ``sens_joint`` (S,) at ``sens_off`` (S, 3) cm with ``sens_rot``
    (S, 4). Writes ``pts`` (B, J-1+S, 3) (joints 1..J-1, then the sensors) and
    ``srot`` (B, S, 4), the sensors' orientations in the root frame.
    """
    J = parents.shape[0]
    g = np.empty((J, 4))
    p = np.empty((J, 3))
    for b in range(poses.shape[0]):
        _fk_one(poses[b], parents, offsets, sens_joint, sens_off, sens_rot, pts[b], srot[b], g, p)
    return pts, srot


@numba.njit(cache=True)
def _kernel_energy(z, X, Z, rperp2, w, Xm, A, base, Xc, use, coef, dt, s0):
    """Eq. 3.4 with the square-root kernels (eqs. 3.7, 3.9, 3.10, 3.13) at PCA coordinates z, points X (M, 3)."""
    n, d = Z.shape
    M = X.shape[0]
    e = 0.0
    for i in range(n):
        r2 = rperp2[i]
        for k in range(d):
            t = z[k] - Z[i, k]
            r2 += t * t
        e += coef[0] * w[i] * r2 ** 0.25
    inv = 1.0 / (dt * dt)
    for i in range(n):
        if use[0]:
            r2 = 0.0
            for m in range(M):
                for c in range(3):
                    t = X[m, c] - Xm[i, m, c]
                    r2 += t * t
            e += coef[1] * w[i] * r2 ** 0.25
        if use[1]:
            r2 = 0.0
            for m in range(M):
                for c in range(3):
                    t = X[m, c] * inv + base[m, c] - A[i, m, c]
                    r2 += t * t
            e += coef[2] * dt * w[i] * r2 ** 0.25
        if use[2]:
            r2 = 0.0
            for m in range(Xc.shape[1]):
                for c in range(3):
                    t = X[s0 + m, c] - Xc[i, m, c]
                    r2 += t * t
            e += coef[3] * w[i] * r2 ** 0.25
    return e


@numba.njit(cache=True)
def _kernel_minimise(z0, mu, Bf, Z, rperp2, w, Xm, A, base, Xc, use, coef, dt, iterations, h, eps_pose, eps_pos,
                     parents, offsets, sens_joint, sens_off, sens_rot):
    """Majorise-minimise / Gauss-Newton for the kernel energy (see :func:`minimise`); returns (z, X, E, steps)."""
    d = z0.shape[0]
    n = Z.shape[0]
    J = parents.shape[0]
    S = sens_joint.shape[0]
    M = J - 1 + S
    s0 = J - 1
    g4 = np.empty((J, 4))
    p3 = np.empty((J, 3))
    srot = np.empty((S, 4))
    P = np.empty((d + 1, M, 3))
    Pn = np.empty((d + 1, M, 3))
    z = z0.copy()
    zn = np.empty(d)
    pose = np.empty(mu.shape[0])

    def fk_all(zz, out, nb):
        for b in range(nb):
            for q in range(mu.shape[0]):
                v = mu[q]
                for k in range(d):
                    v += Bf[q, k] * (zz[k] + (h if b == k + 1 else 0.0))
                pose[q] = v
            _fk_one(pose, parents, offsets, sens_joint, sens_off, sens_rot, out[b], srot, g4, p3)

    fk_all(z, P, d + 1)
    E = _kernel_energy(z, P[0], Z, rperp2, w, Xm, A, base, Xc, use, coef, dt, s0)
    steps = 0
    inv = 1.0 / (dt * dt)
    Jx = np.empty((3 * M, d))
    Dsum = np.empty(3 * M)
    for _ in range(iterations):
        X = P[0]
        for m in range(M):
            for c in range(3):
                for k in range(d):
                    Jx[3 * m + c, k] = (P[k + 1, m, c] - X[m, c]) / h
        JtJ = np.zeros((d, d))
        JsJs = np.zeros((d, d))
        for r in range(3 * M):
            for a in range(d):
                v = Jx[r, a]
                if v != 0.0:
                    for b in range(a, d):
                        JtJ[a, b] += v * Jx[r, b]
                        if r >= 3 * s0:
                            JsJs[a, b] += v * Jx[r, b]
        for a in range(d):
            for b in range(a):
                JtJ[a, b] = JtJ[b, a]
                JsJs[a, b] = JsJs[b, a]
        H = np.zeros((d, d))
        g = np.zeros(d)
        # pose prior (eq. 3.7): residual z - Z_i plus the constant part outside the subspace
        csum = 0.0
        for i in range(n):
            r2 = rperp2[i]
            for k in range(d):
                t = z[k] - Z[i, k]
                r2 += t * t
            ci = coef[0] * w[i] * 0.25 * max(r2, eps_pose * eps_pose) ** -0.75
            csum += ci
            for k in range(d):
                g[k] += ci * (z[k] - Z[i, k])
        for k in range(d):
            H[k, k] += csum
        for term in range(3):
            if not use[term]:
                continue
            Dsum[:] = 0.0
            csum = 0.0
            for i in range(n):
                r2 = 0.0
                if term == 0:
                    for m in range(M):
                        for c in range(3):
                            t = X[m, c] - Xm[i, m, c]
                            r2 += t * t
                elif term == 1:
                    for m in range(M):
                        for c in range(3):
                            t = X[m, c] * inv + base[m, c] - A[i, m, c]
                            r2 += t * t
                else:
                    for m in range(S):
                        for c in range(3):
                            t = X[s0 + m, c] - Xc[i, m, c]
                            r2 += t * t
                nr = math.sqrt(r2)
                if term == 0:
                    ci = coef[1] * w[i] * 0.25 * max(nr, eps_pos) ** -1.5
                    for m in range(M):
                        for c in range(3):
                            Dsum[3 * m + c] += ci * (X[m, c] - Xm[i, m, c])
                elif term == 1:
                    ci = coef[2] * dt * w[i] * 0.25 * max(nr, eps_pos) ** -1.5
                    for m in range(M):
                        for c in range(3):
                            Dsum[3 * m + c] += ci * (X[m, c] * inv + base[m, c] - A[i, m, c])
                else:
                    ci = coef[3] * w[i] * 0.25 * max(nr, eps_pos) ** -1.5
                    for m in range(S):
                        for c in range(3):
                            Dsum[3 * (s0 + m) + c] += ci * (X[s0 + m, c] - Xc[i, m, c])
                csum += ci
            scale_h = csum if term != 1 else csum * inv * inv
            scale_g = 1.0 if term != 1 else inv
            for a in range(d):
                acc = 0.0
                for r in range(3 * M):
                    acc += Jx[r, a] * Dsum[r]
                g[a] += scale_g * acc
                for b in range(d):
                    H[a, b] += scale_h * (JsJs[a, b] if term == 2 else JtJ[a, b])
        tr = 0.0
        for k in range(d):
            tr += H[k, k]
        for k in range(d):
            H[k, k] += 1e-9 * (tr / d + 1.0)
        delta = -np.linalg.solve(H, g)
        t = 1.0
        accepted = False
        En = E
        for _ls in range(6):
            for k in range(d):
                zn[k] = z[k] + t * delta[k]
            fk_all(zn, Pn, 1)
            En = _kernel_energy(zn, Pn[0], Z, rperp2, w, Xm, A, base, Xc, use, coef, dt, s0)
            if En <= E:
                accepted = True
                break
            t *= 0.5
        if not accepted:
            break
        steps += 1
        step2 = 0.0
        zz = 0.0
        for k in range(d):
            step2 += (t * delta[k]) ** 2
            zz += z[k] ** 2
        z[:] = zn
        P, Pn = Pn, P
        E = En
        if math.sqrt(step2) < 1e-5 * (1.0 + math.sqrt(zz)) or E == 0.0:
            break
        fk_all(z, P, d + 1)
    return z, P[0].copy(), E, steps


class Rig:
    """The output skeleton and the sensors on it as the FK kernel needs them (offsets in cm).

    ``J`` joints, ``S`` sensors, ``M = J - 1 + S`` root-frame points (joints
    1..J-1, then the sensors); ``scale`` is centimetres per skeleton unit.
    """

    def __init__(self, skeleton: Skeleton, sensors):
        self.skeleton = skeleton
        self.scale = unit_scale_cm(skeleton)
        self.parents = np.asarray(skeleton.parents, dtype=np.int64)
        self.offsets = np.ascontiguousarray(skeleton.offsets, dtype=np.float64) * self.scale
        self.sens_joint = np.array([skeleton.index(s.joint) for s in sensors], dtype=np.int64)
        self.sens_off = np.stack([s.offset for s in sensors]).astype(np.float64) * self.scale
        self.sens_rot = np.stack([s.rotation for s in sensors]).astype(np.float64)
        self.J = skeleton.num_joints
        self.S = len(sensors)
        self.M = self.J - 1 + self.S

    def points(self, poses: np.ndarray):
        """Root-frame points (B, M, 3) cm and sensor orientations (B, S, 4) of pose vectors (B, 3J)."""
        poses = np.ascontiguousarray(poses, dtype=np.float64)
        B = poses.shape[0]
        pts = np.empty((B, self.M, 3))
        srot = np.empty((B, self.S, 4))
        return _fk_points(poses, self.parents, self.offsets, self.sens_joint, self.sens_off, self.sens_rot, pts, srot)


# -- the energy in numpy, and the minimiser ---------------------------------------------------


class FrameEnergy:
    """The energy of eq. 3.4 for one frame, in PCA coordinates ``z`` (pose ``mean + basis z``).

    ``kind="kernel"``: the square-root kernel sums of eqs. 3.7, 3.9, 3.10,
    3.13; ``kind="mahalanobis"``: each term replaced by a weighted Gaussian's
    negative log-likelihood ``0.5 (r - mu)^T Sigma^-1 (r - mu)`` (sec. 3.6.2).
    A term without its history (first frames) is left out.

    Parameters
    ----------
    rig : Rig
    p : dict
        The reconstruction parameters (the weights ``w_*``).
    kind : "kernel" or "mahalanobis"
    w : float array (I,)
        Path weights of the neighbours (eq. 3.3), summing to 1.
    mu : float array (3J,), B : float array (3J, d), lam : float array (d,)
        Weighted-PCA mean pose, basis and eigenvalues of the neighbour poses.
    Z : float array (I, d), rperp2 : float array (I,)
        The neighbours' PCA coordinates and squared residual outside the subspace.
    Xm : float array (I, M, 3) or None
        Points predicted from the previous frame by each neighbour's motion (eq. 3.9), cm.
    A : float array (I, M, 3) or None, base : float array (M, 3) or None
        Neighbour accelerations and the previous frames' part of the
        second difference (eq. 3.10), cm/s^2.
    Xc : float array (I, S, 3) or None
        Sensor positions predicted by the measured accelerations (eq. 3.13), cm.
    dt : float
        Frame interval, seconds.
    """

    def __init__(self, rig, p, kind, w, mu, B, lam, Z, rperp2, Xm, A, base, Xc, dt):
        self.rig, self.kind, self.w, self.mu, self.B = rig, kind, w, mu, B
        self.Z, self.rperp2, self.Xm, self.A, self.base, self.Xc, self.dt = Z, rperp2, Xm, A, base, Xc, dt
        self.c_pose = p["w_prior"] * p["w_pose"]
        self.c_motion = p["w_prior"] * p["w_motion"]
        self.c_smooth = p["w_prior"] * p["w_smooth"]
        self.c_contr = p["w_contr"]
        self.sens = slice(rig.J - 1, rig.M)
        if kind == "mahalanobis":
            self.lam = np.maximum(lam, 1e-8 + 1e-6 * (lam.max() if lam.size else 0.0))
            self.gm = [None, None, None]
            for t, X in enumerate((Xm, A, Xc)):
                if X is not None:
                    self.gm[t] = _gaussian(X.reshape(X.shape[0], -1), w)

    def pose(self, z):
        """The pose vector (3J,) of PCA coordinates ``z`` (d,)."""
        return self.mu + self.B @ z

    def fk(self, zs):
        """Points (B, M, 3) of PCA coordinates ``zs`` (B, d)."""
        return self.rig.points(self.mu + zs @ self.B.T)[0]

    def energy(self, z, X) -> float:
        """Eq. 3.4 at PCA coordinates ``z`` (d,) whose root-frame points are ``X`` (M, 3)."""
        w, e = self.w, 0.0
        if self.kind == "kernel":
            e += self.c_pose * float(w @ (np.sum((self.Z - z) ** 2, axis=1) + self.rperp2) ** 0.25)
            if self.Xm is not None:
                e += self.c_motion * float(w @ np.sqrt(np.linalg.norm((X - self.Xm).reshape(len(w), -1), axis=1)))
            if self.A is not None:
                a = X / self.dt**2 + self.base
                e += self.c_smooth * self.dt * float(w @ np.sqrt(np.linalg.norm((a - self.A).reshape(len(w), -1), axis=1)))
            if self.Xc is not None:
                e += self.c_contr * float(w @ np.sqrt(np.linalg.norm((X[self.sens] - self.Xc).reshape(len(w), -1), axis=1)))
            return e
        e += self.c_pose * 0.5 * float(np.sum(z * z / self.lam))
        for c, g, r in self._maha_residuals(X):
            e += c * 0.5 * float(r @ r)
        return e

    def _maha_residuals(self, X):
        out = []
        if self.gm[0] is not None:
            m, W = self.gm[0]
            out.append((self.c_motion, W, W @ (X.ravel() - m)))
        if self.gm[1] is not None:
            m, W = self.gm[1]
            out.append((self.c_smooth, W, W @ ((X / self.dt**2 + self.base).ravel() - m)))
        if self.gm[2] is not None:
            m, W = self.gm[2]
            out.append((self.c_contr, W, W @ (X[self.sens].ravel() - m)))
        return out

    def normal_equations(self, z, X, Jx):
        """Gauss-Newton system ``(H, g)`` of the quadratic majoriser at ``z`` (Jx (3M, d) = dX/dz)."""
        d = z.size
        w = self.w
        H = np.zeros((d, d))
        g = np.zeros(d)
        n = len(w)
        Js = Jx.reshape(self.rig.M, 3, d)[self.sens].reshape(-1, d)
        if self.kind == "kernel":
            Dz = z - self.Z
            r2 = np.sum(Dz * Dz, axis=1) + self.rperp2
            c = self.c_pose * w * 0.25 * np.maximum(r2, _EPS_POSE**2) ** -0.75
            H += c.sum() * np.eye(d)
            g += c @ Dz
            terms = []
            if self.Xm is not None:
                terms.append((self.c_motion, (X - self.Xm).reshape(n, -1), Jx))
            if self.A is not None:
                terms.append((self.c_smooth * self.dt, (X / self.dt**2 + self.base - self.A).reshape(n, -1), Jx / self.dt**2))
            if self.Xc is not None:
                terms.append((self.c_contr, (X[self.sens] - self.Xc).reshape(n, -1), Js))
            for coef, D, Jt in terms:
                nr = np.linalg.norm(D, axis=1)
                c = coef * w * 0.25 * np.maximum(nr, _EPS_POS) ** -1.5
                H += c.sum() * (Jt.T @ Jt)
                g += Jt.T @ (c @ D)
            return H, g
        H += self.c_pose * np.diag(1.0 / self.lam)
        g += self.c_pose * z / self.lam
        jac = [Jx, Jx / self.dt**2, Js]
        for (c, W, r), Jt in zip(self._maha_residuals(X), [jac[t] for t in range(3) if self.gm[t] is not None]):
            Jw = W @ Jt
            H += c * (Jw.T @ Jw)
            g += c * (Jw.T @ r)
        return H, g


def _gaussian(X: np.ndarray, w: np.ndarray):
    """Weighted mean (D,) and whitening matrix W (D, D), ``W^T W = (Sigma + ridge)^-1``, of samples X (I, D)."""
    m = w @ X
    D = (X - m) * np.sqrt(w)[:, None]
    C = D.T @ D
    ridge = 1e-3 * np.trace(C) / C.shape[0] + 1e-6
    L = np.linalg.cholesky(C + ridge * np.eye(C.shape[0]))
    return m, np.linalg.inv(L)


def minimise(prob: FrameEnergy, z0: np.ndarray, iterations: int):
    """Minimise ``prob`` from PCA coordinates ``z0`` (d,) in at most ``iterations`` steps; returns ``(z, X, energy, steps)``.

    Majorise-minimise with Gauss-Newton steps and a halving line search (module
    docstring). The kernel prior runs in the numba kernel, any other prior
    in :func:`minimise_numpy`. ``X`` (M, 3) are the root-frame points of the
    result, cm.
    """
    if z0.size > 0 and prob.kind == "kernel":
        rig = prob.rig
        e0 = np.empty((1, 1, 3))
        use = np.array([prob.Xm is not None, prob.A is not None, prob.Xc is not None])
        coef = np.array([prob.c_pose, prob.c_motion, prob.c_smooth, prob.c_contr])
        return _kernel_minimise(
            np.ascontiguousarray(z0, dtype=np.float64), prob.mu, np.ascontiguousarray(prob.B), np.ascontiguousarray(prob.Z),
            prob.rperp2, prob.w, e0 if prob.Xm is None else prob.Xm, e0 if prob.A is None else prob.A,
            np.zeros((1, 3)) if prob.base is None else prob.base, e0 if prob.Xc is None else prob.Xc, use, coef, prob.dt,
            int(iterations), _FD_STEP, _EPS_POSE, _EPS_POS, rig.parents, rig.offsets, rig.sens_joint, rig.sens_off, rig.sens_rot,
        )
    return minimise_numpy(prob, z0, iterations)


def minimise_numpy(prob: FrameEnergy, z0: np.ndarray, iterations: int):
    """The iteration of :func:`minimise` in numpy, for any prior kind (the slow twin of the numba kernel)."""
    d = z0.size
    z = z0.copy()
    h = _FD_STEP
    steps = 0
    if d == 0:
        X = prob.fk(z[None])[0]
        return z, X, prob.energy(z, X), 0
    batch = np.vstack([z, z + h * np.eye(d)])
    P = prob.fk(batch)
    X = P[0]
    E = prob.energy(z, X)
    for _ in range(iterations):
        Jx = ((P[1:] - X) / h).reshape(d, -1).T  # (3M, d)
        H, g = prob.normal_equations(z, X, Jx)
        H[np.diag_indices(d)] += 1e-9 * (np.trace(H) / d + 1.0)
        try:
            delta = -np.linalg.solve(H, g)
        except np.linalg.LinAlgError:
            break
        t = 1.0
        accepted = False
        for _ in range(6):
            zn = z + t * delta
            batch = np.vstack([zn, zn + h * np.eye(d)])
            Pn = prob.fk(batch)
            En = prob.energy(zn, Pn[0])
            if En <= E:
                accepted = True
                break
            t *= 0.5
        if not accepted:
            break
        steps += 1
        small = np.linalg.norm(t * delta) < 1e-6 * (1.0 + np.linalg.norm(z))
        z, P, X, E = zn, Pn, Pn[0], En
        if small or E == 0:
            break
    return z, X, E, steps
