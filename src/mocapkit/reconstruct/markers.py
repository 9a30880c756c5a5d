"""Full-body motion from a few markers: kNN local linear models and a per-frame fit (Krüger et al. 2010, sec. 5.2).

Krüger et al. replace the neighbourhood graph of Chai & Hodgins (2005) by a
kd-tree search on medium-dimensional features and reconstruct motions from six
markers (hands, feet, head, root; Tables 3 and 4). For every frame ``t``:

1. **Control features** (sec. 3.2): the observed markers in a *normalised root
   frame* -- ground-plane translation removed and the heading turned to the
   fixed forward axis. The root's orientation is not observed, so the frame is
   *tracked*: the heading and ground translation of the previous reconstructed
   frame give a first guess (the ground translation is the root marker's
   ground projection whenever a root marker is given), and it is then refined
   by the closed-form optimal rotation about the vertical plus ground
   translation (Tautges 2012, eq. 4.3, :func:`._common.align_about_vertical`) that maps
   the nearest database frame's normalised markers onto the observed ones;
   the search is repeated in the refined frame. The first frame (no
   history) is aligned by brute force: eq. 4.3 against every database frame.
   This keeps the heading in the database's own convention (the neighbours'
   normalised frames), which is what the search compares with.
2. **kNN** (sec. 4.1, :class:`~mocapkit.search.knn.KNNIndex`): the ``k``
   database frames whose same markers, in their own normalised root frame,
   are nearest, each marker's coordinates scaled by its search weight (the
   head's 1.5, :func:`search_weights`; not in the paper, whose distance
   weighs every marker alike). Missing markers (NaN) are filled, for the
   search only, with the previous reconstructed frame's marker positions.
3. **Local linear model** (Chai & Hodgins 2005, sec. 5): PCA of the
   neighbours' poses. A pose is the stacked rotation vectors (radians) of
   every joint relative to the neighbours' mean rotation (sign-aligned
   quaternion average), the root's entry being its *tilt*
   ``yaw^-1 * q_root`` (its orientation in the normalised frame). Components
   are kept up to ``variance`` of the total, at most ``max_components``.
4. **Per-frame optimisation** (the Chai-Hodgins energy):
   ``E = sum_m |FK_m(z) - c_m|^2 + prior_weight * |u|^2
   + ((heading - heading_0) / heading_std)^2
   + smooth_weight * mean_j |p_j(t) - 2 p_j(t-1) + p_j(t-2)|^2``, lengths
   in centimetres, over ``z = (u, heading, root position)`` where ``u`` are
   the whitened PCA coefficients (so ``|u|^2`` is the Mahalanobis distance of
   the pose to the local model) and ``heading_0`` is the eq. 4.3 heading of
   step 1. The marker term drops missing markers; the smoothness term runs on
   all joint positions (first order on the second frame; its weight is per
   30 fps frame and scaled to the database's rate); the root position is
   free (pinned by the root marker when there is one; otherwise a prior on
   its height above the ground, from the neighbours, joins in). The heading
   term is not in Chai & Hodgins: without it the weak prior lets the pelvis
   turn about the vertical while the limbs compensate, most of all without a
   root marker. Solved by
   :func:`scipy.optimize.least_squares` (Levenberg-Marquardt) from the
   previous frame's pose projected into the new model, with the analytic
   Jacobian of the forward kinematics (:mod:`.model_kinematics`; the forward
   differences it replaced, ``_Problem.jac_numeric``, check it in the tests).
5. **Joint ranges** (not in the papers): ``E`` also holds
   ``limit_weight * excess`` for every joint and principal axis, the radians
   by which the pose leaves the range the database's frames give that joint
   (:func:`joint_ranges`; zero inside). Six markers leave each limb's swivel
   about the line from its root to its end unobserved, and the fit, which
   only has to place the ankle, can bend a knee backwards and keep it so
   frame after frame (the smoothness term holds it there). When the fit from
   the previous pose ends beyond a range, a second fit starts from the
   neighbours' mean pose (``u = 0``) and the lower energy wins.

The defaults (``k`` = :func:`default_neighbours`: 256 neighbours up to a
database of 16,384 frames, ``2 sqrt(N)`` beyond; 99.99 % of the variance up
to 60 components, a weak prior 0.01) favour a broad local model: neighbours
from other performers rarely contain the exact pose, so a model the markers
can pull on beats a tight one of 10-20 components. 256 was chosen over 64,
128 and 512 on three of the five HDM05 leave-one-actor-out folds (bd, dg, mm
held out; ``benchmarks/reconstruct_markers.py --leave-one-out``); the
growth with the database's size and the head marker's weight of 1.5 in the
search (:func:`search_weights`) on all five folds and six held-out Bandai
Namco styles, and checked on held-out Bandai Namco takes the benchmark does
not use.

Forward kinematics runs on the performer's skeleton (``skeleton``), so bone
lengths are the performer's. When ``skeleton`` is given, the database's
control features are those of its poses *on the performer's bones*
(:func:`retarget_clip`: the local rotations kept, the pelvis height scaled by
the ratio of the rest-pose pelvis heights), so a tall performer's markers are
compared with database poses struck by a body of his size; the pose
statistics are the database's local rotations.

Rigs: the method works on the *body*, the pelvis (found by its role,
:func:`mocapkit.rigs.pelvis_index`) and the joints below it
(:func:`._common.body_motion`); on the Bandai Namco game rig, whose root
``joint_Root`` stays on the floor while ``Hips`` carries the translation, the
joints above the pelvis are put back on output as the database's takes hold
them (:func:`._common.held_above`: ``joint_Root`` at the origin, ``Hips``
carrying the translation; :func:`._common.whole_motion`). The vertical axis comes from the
database's frames (:func:`._common.database_up`), not from the rest pose. Frames with no marker at all keep the previous local
model and are carried by the prior and the smoothness term (an
extrapolation at constant velocity); frames before the first frame with three
observed markers copy that frame's pose.

Departures from the papers: Chai & Hodgins search neighbours of the previous
synthesised poses in a precomputed graph, Krüger et al. (and this module)
search the kd-tree directly; neither paper says how the unobserved heading
enters the features -- here it is tracked and refined by eq. 4.3 as above.
The weights were chosen on held-out HDM05 actors (``benchmarks/reconstruct_markers.py``).
The local PCA uses ``eigh`` of the covariance: OpenBLAS's threaded SVD of
such small matrices is slow on a busy machine (also consider
``OPENBLAS_NUM_THREADS=1``).

>>> import mocapkit
>>> from mocapkit.database import MotionDatabase
>>> from mocapkit.features import virtual_markers
>>> db = MotionDatabase.build([mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")], fps=30,
...                           executor="serial", progress=False)
>>> truth = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")).resample(30)[:20]
>>> joints = ["lhand", "rhand", "lfoot", "rfoot", "head", "root"]
>>> out = reconstruct(virtual_markers(truth, joints), joints, db, fps=30)
>>> out.num_frames, out.fps
(20, 30.0)
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits
from tqdm.auto import tqdm
from ..progress import bar_disabled, bar_size

from .. import rotations as R
from ..database import MotionDatabase
from ..features import parse_up_axis, root_frame, virtual_markers
from ..motion import Motion, Skeleton, unit_scale_cm
from ..search.knn import KNNIndex
from ..rigs import pelvis_index, roles
from .marker_units import check_marker_scale
from ._common import (align_about_vertical, database_up, body_joints, body_motion, body_skeleton, in_database_units, in_units_of,
                      held_above, output_skeleton, per_clip, whole_motion)
from .control import marker_residuals, warn_unseen
from .dofs import on_joint_dofs
from .model_kinematics import (carried_by, fk_model_pose, fk_model_poses, point_jacobian, range_coordinates,
                               range_excess_jacobian)
from ..words import plural

__all__ = ["reconstruct", "nearest_neighbor", "marker_residuals", "default_neighbours", "search_weights"]

_STEP = 1e-6  # forward-difference step of the Jacobian (whitened PCA units, radians, centimetres)
_MIN_HEIGHT_STD_CM = 2.0  # floor of the neighbours' root-height spread in the height prior
_RANGE_PERCENTILES = (0.1, 99.9)  # the database's range of each joint axis, robust to its rare glitches
_RANGE_MARGIN = np.radians(10.0)  # beyond the database's range before the joint-range term starts
_RANGE_FRAMES = 50_000  # at most this many evenly spaced database frames give the ranges
HEAD_SEARCH_WEIGHT = 1.5  # weight of the head marker in the neighbour search (the others: 1)


# -- closed-form alignment about the vertical (Tautges 2012, eq. 4.3) ------------------------


# -- what the database gives, cached per (database, markers) ----------------------------------


@dataclass(frozen=True, eq=False)
class _MarkerDatabase:
    """Per-frame values of one database for one marker set (and one performer skeleton, when retargeted)."""

    index: KNNIndex
    features: np.ndarray  # (N, M, 3) markers in each frame's normalised root frame, file units
    tilt: np.ndarray  # (N, 4) root rotation in the normalised frame, yaw^-1 * q_root
    root: np.ndarray  # (N, 3) root position in the normalised frame (its height along up)
    rotations: np.ndarray  # (N, B, 4) local rotations of the body joints (pelvis first; its entry unused)
    ranges: "_JointRanges"  # what each body joint does in the database (pelvis: its tilt)
    weights: np.ndarray  # (M,) each marker's weight in the kd-tree's coordinates


@dataclass(frozen=True)
class _JointRanges:
    """The range of each joint's local rotation over a database, along the joint's principal axes.

    A rotation ``q`` of joint ``j`` is ``mean[j] * exp(v)``; ``axes[j] @ v``
    (radians) lies in ``[lo[j], hi[j]]`` on the database's frames (robust
    percentiles, widened by a margin). A knee bends one way and an elbow
    does not bend backwards: six markers leave a limb's swivel about the line
    from its root to its end unobserved, and a fit that only has to place
    the hand or the ankle can bend the joint the other way, which no frame
    of the database does.
    """

    mean: np.ndarray  # (B, 4)
    axes: np.ndarray  # (B, 3, 3) rows: principal axes of the rotation vectors
    lo: np.ndarray  # (B, 3) radians
    hi: np.ndarray  # (B, 3) radians

    def excess(self, q: np.ndarray) -> np.ndarray:
        """Radians (..., B, 3) by which local rotations ``q`` (..., B, 4) leave the ranges, 0 inside."""
        v = R.quaternion_to_rotvec(_same_hemisphere(R.quaternion_multiply(R.quaternion_conjugate(self.mean), q)))
        c = np.einsum("jab,...jb->...ja", self.axes, v)
        return np.maximum(c - self.hi, 0.0) + np.maximum(self.lo - c, 0.0)


def _same_hemisphere(q: np.ndarray) -> np.ndarray:
    """``q`` with ``w >= 0``: the rotation vector of the shorter way round."""
    return np.where(q[..., :1] < 0, -q, q)


def joint_ranges(rotations: np.ndarray) -> _JointRanges:
    """The :class:`_JointRanges` of local rotations (N, B, 4) (the root's entry: its tilt).

    Per joint: the mean rotation (signs aligned to the principal quaternion), the principal axes of the
    rotation vectors relative to it (eigenvectors of their 3x3 covariance),
    and along each axis the 0.1 and 99.9 percentiles of the frames, widened
    by 10 degrees on either side. At most 50,000 evenly spaced frames are
    read (a memory-mapped database stays mostly on disk).
    """
    q = np.asarray(rotations)
    step = max(1, -(-len(q) // _RANGE_FRAMES))
    q = np.array(q[::step], dtype=np.float64)
    # signs aligned to each joint's principal quaternion (the top eigenvector of sum q q^T, w >= 0), which no frame's
    # order or sign changes: aligned to the first frame, a database of the same clips in another order gave other
    # ranges (and reconstructions up to 7 cm apart)
    ref = np.linalg.eigh(np.einsum("nbi,nbj->bij", q, q))[1][..., -1]  # (B, 4)
    ref = _same_hemisphere(ref)
    q = np.where(np.sum(q * ref[None], axis=-1, keepdims=True) < 0, -q, q)
    mean = R.quaternion_normalize(q.mean(axis=0))
    v = R.quaternion_to_rotvec(_same_hemisphere(R.quaternion_multiply(R.quaternion_conjugate(mean), q)))
    B = q.shape[1]
    axes, lo, hi = np.zeros((B, 3, 3)), np.zeros((B, 3)), np.zeros((B, 3))
    for j in range(B):
        vj = v[:, j]
        _, vec = np.linalg.eigh(np.cov(vj.T) if len(vj) > 1 else np.eye(3))
        ax = vec[:, ::-1].T
        big = np.argmax(np.abs(ax), axis=1)  # each axis' sign fixed by its largest component, not by eigh's choice
        axes[j] = ax * np.where(ax[np.arange(3), big] < 0, -1.0, 1.0)[:, None]
        c = vj @ axes[j].T
        lo[j], hi[j] = np.percentile(c, _RANGE_PERCENTILES, axis=0)
    return _JointRanges(mean, axes, lo - _RANGE_MARGIN, hi + _RANGE_MARGIN)


_CACHE: "weakref.WeakKeyDictionary[MotionDatabase, dict]" = weakref.WeakKeyDictionary()


def pelvis_height(skeleton: Skeleton, up: np.ndarray) -> float:
    """Rest-pose height (file units) of the pelvis above the lowest joint or end site along the unit ``up``.

    The leg length that sets how high a performer carries the pelvis: the
    scale of the root height when database poses are put on another
    performer's skeleton (:func:`retarget_clip`).
    """
    rest = skeleton.rest_positions(end_sites=True)
    p = pelvis_index(skeleton)
    return float(np.max((rest[p] - rest) @ up))


def retarget_clip(m: Motion, skeleton: Skeleton | None, up: np.ndarray) -> Motion:
    """A database clip's body (:func:`._common.body_motion`) posed on the body of the performer's ``skeleton``.

    The local rotations are kept; the bone offsets are the performer's
    (animated non-root offsets are dropped), and the pelvis height above the
    floor (the plane through the origin orthogonal to ``up``) is scaled by the
    ratio of the two skeletons' :func:`pelvis_height`: the pose a performer of
    the other proportions would strike, as Krüger et al.'s features need to
    compare performers of other sizes (their HDM05 actors differ by up to 15 %
    in leg length). With ``skeleton`` None the body as it is.
    """
    b = body_motion(m)
    if skeleton is None:
        return b
    target = body_skeleton(skeleton)
    h0, h1 = pelvis_height(b.skeleton, up), pelvis_height(target, up)
    ratio = h1 / h0 if h0 > 0 and h1 > 0 else 1.0
    root = np.asarray(b.root_positions, dtype=np.float64)
    root = root + (ratio - 1.0) * (root @ up)[:, None] * up
    return Motion(target, b.rotations, root, b.fps, b.name)


def default_neighbours(num_frames: int) -> int:
    """The default ``k`` of :func:`reconstruct` for a database of ``num_frames`` frames: ``max(256, round(2 sqrt(N)))``.

    At least 256: a local model of up to 60 components needs several times
    as many poses, and 256 was chosen over 64, 128 and 512 on the HDM05
    leave-one-actor-out folds, a database of about 14,000 frames (512 is a
    little better on four folds and 0.35 cm worse on the fifth). Beyond
    16,384 frames the neighbourhood grows with the k-nearest-neighbour rule
    of thumb ``k ~ sqrt(N)``: more frames in it as the database grows, a
    smaller part of the database. About 1,060 neighbours for the Bandai Namco
    takes (280,000 frames at 30 fps).
    """
    return max(256, int(round(2.0 * np.sqrt(max(int(num_frames), 0)))))


def search_weights(skeleton: Skeleton, joints: Sequence[str]) -> np.ndarray:
    """Default per-marker weights (M,) of the neighbour search: :data:`HEAD_SEARCH_WEIGHT` for a marker on the head, 1 elsewhere.

    The head marker is the one on the joint of the head role
    (:func:`mocapkit.rigs.roles`) or on an end site of it. Relative to the
    root marker it carries the trunk's lean and crouch, which six markers
    otherwise see nowhere; in an unweighted distance the hands and feet,
    which swing by tens of centimetres through a stride, outvote it, and
    the neighbours' spines, shoulders and elbows follow the limbs' phase
    rather than the performer's carriage.
    """
    head = roles(skeleton).get("head")
    w = np.ones(len(joints))
    if head is None:
        return w
    jl = {n: i for i, n in enumerate(skeleton.joint_names)}
    el = {n: i for i, n in enumerate(skeleton.end_site_names)}
    for m, name in enumerate(joints):
        j = jl[name] if name in jl else (skeleton.end_site_parents[el[name]] if name in el else -1)
        if j == head:
            w[m] = HEAD_SEARCH_WEIGHT
    return w


def _marker_database(db: MotionDatabase, joints: tuple[str, ...], up: np.ndarray, skeleton: Skeleton | None = None,
                     weights: np.ndarray | None = None) -> _MarkerDatabase:
    """The per-frame values of ``db`` for markers ``joints``, on the performer's ``skeleton`` when given (cached).

    ``weights`` (M,) scale each marker's coordinates in the kd-tree (default 1);
    ``features`` stay unweighted.
    """
    w = np.ones(len(joints)) if weights is None else np.asarray(weights, dtype=np.float64)
    per_db = _CACHE.setdefault(db, {})
    key = (joints, tuple(up.tolist()), w.tobytes(),
           None if skeleton is None else (skeleton.offsets.tobytes(), skeleton.end_site_offsets.tobytes()))
    if key in per_db:
        return per_db[key]

    def values(m: Motion) -> np.ndarray:
        b = retarget_clip(m, skeleton, up)
        rot, tr = root_frame(b, up_axis=up)
        pos = virtual_markers(b, list(joints))
        return np.concatenate([rot, tr, np.asarray(b.root_positions), pos.reshape(len(pos), -1)], axis=1)

    vals = per_clip(db, values)
    yaw, ground, root_pos = vals[:, :4], vals[:, 4:7], vals[:, 7:10]
    pos = vals[:, 10:].reshape(len(vals), len(joints), 3)
    inv = R.quaternion_conjugate(yaw)
    feats = R.quaternion_rotate(inv[:, None], pos - ground[:, None])
    if body_joints(db.skeletons[0])[0] == 0:
        rotations = db.rotations  # the pelvis is the root: the database's own (memory-mapped) array
    else:
        rotations = per_clip(db, lambda m: body_motion(m).rotations)
    rot0 = np.asarray(rotations[:, 0], dtype=np.float64)
    tilt = R.quaternion_normalize(R.quaternion_multiply(inv, rot0))
    root = R.quaternion_rotate(inv, root_pos - ground)
    step = max(1, -(-len(tilt) // _RANGE_FRAMES))  # read only the frames joint_ranges uses
    rng_rot = np.array(rotations[::step], dtype=np.float64)
    rng_rot[:, 0] = tilt[::step]  # the pelvis by its tilt, as the local models hold it
    out = _MarkerDatabase(KNNIndex((feats * w[:, None]).reshape(len(feats), -1)), feats, tilt, root, rotations,
                          joint_ranges(rng_rot), w)
    per_db[key] = out
    return out


# -- input checks ------------------------------------------------------------------------------


def _marker_columns(sk: Skeleton, joints: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """Per marker: the joint carrying it (M,) (an end site's parent) and its offset (M, 3) in that joint's frame."""
    jl = {n: i for i, n in enumerate(sk.joint_names)}
    el = {n: i for i, n in enumerate(sk.end_site_names)}
    index = np.zeros(len(joints), dtype=np.int64)
    offset = np.zeros((len(joints), 3))
    for m, name in enumerate(joints):
        if name in jl:
            index[m] = jl[name]
        else:
            e = el[name]
            index[m] = sk.end_site_parents[e]
            offset[m] = sk.end_site_offsets[e]
    return index, offset


def _check(markers, joints, db, fps) -> tuple[np.ndarray, tuple[str, ...]]:
    if not isinstance(db, MotionDatabase):
        raise ValueError(f"db must be a MotionDatabase, got {type(db).__name__}")
    if db.num_frames == 0:
        raise ValueError("the database is empty: build it from at least one clip")
    x = np.asarray(markers, dtype=np.float64)
    if isinstance(joints, str):
        raise ValueError("joints: expected a sequence of joint or end-site names, got a single string")
    joints = tuple(str(j) for j in joints)
    if x.ndim != 3 or x.shape[2] != 3 or x.shape[1] != len(joints):
        raise ValueError(f"markers: expected shape (F, {len(joints)}, 3) for {plural(len(joints), 'joint')}, got {x.shape}")
    if len(joints) < 3:
        raise ValueError(f"need at least 3 markers to reconstruct a pose, got {len(joints)}")
    if x.shape[0] == 0:
        raise ValueError("markers: no frames")
    if not np.all(np.isfinite(x) | np.isnan(x)):
        raise ValueError("markers: infinite values; mark missing samples with NaN")
    sk = db.skeletons[0]
    known = set(sk.joint_names) | set(sk.end_site_names)
    unknown = [j for j in joints if j not in known]
    if unknown:
        raise ValueError(
            f"unknown joint or end-site name(s) {', '.join(map(repr, unknown))}; "
            f"the database skeleton has joints {', '.join(sk.joint_names)} and end sites {', '.join(sk.end_site_names)}"
        )
    fps = float(fps)
    if not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    return x, joints


def _resample_markers(x: np.ndarray, fps: float, target_fps: float) -> np.ndarray:
    """Markers (F, M, 3) at ``fps`` linearly interpolated to ``target_fps``, covering the whole clip (last sample held)."""
    F = x.shape[0]
    n = int(np.ceil((F - 1) * target_fps / fps - 1e-9)) + 1
    t = np.minimum(np.arange(n) * (fps / target_fps), F - 1)
    i0 = np.minimum(np.floor(t + 1e-9).astype(np.int64), F - 1)
    i1 = np.minimum(i0 + 1, F - 1)
    a = (t - i0)[:, None, None]
    out = x[i0] * (1 - a) + x[i1] * a
    exact = (a[:, 0, 0] <= 1e-9)
    out[exact] = x[i0[exact]]  # a NaN neighbour does not spoil an exact sample
    return out


# -- the per-frame model and its residuals -------------------------------------------------------


@dataclass
class _LocalModel:
    """A local linear pose model: ``rotvec = mean_rotvec + basis @ (sqrt(lam) * u)`` relative to ``mean`` (J, 4)."""

    mean: np.ndarray  # (J, 4) mean local rotations (root: mean tilt)
    mu: np.ndarray  # (3J,) mean rotation vectors relative to ``mean``
    basis: np.ndarray  # (3J, d) scaled by sqrt(lam): whitened coordinates
    height: float  # mean root height along up, file units
    height_std: float  # file units

    @property
    def dim(self) -> int:
        return self.basis.shape[1]

    def project(self, local: np.ndarray) -> np.ndarray:
        """Whitened coordinates (d,) of a pose (J, 4) (least squares in the model's span)."""
        r = R.quaternion_to_rotvec(R.quaternion_multiply(R.quaternion_conjugate(self.mean), local)).ravel()
        if self.dim == 0:
            return np.zeros(0)
        # the basis columns are orthogonal with norms sqrt(lam): an orthogonal projection
        return (self.basis.T @ (r - self.mu)) / np.sum(self.basis**2, axis=0)

    def decode(self, u: np.ndarray) -> np.ndarray:
        """Local rotations (B, J, 4) (root = tilt) of whitened coordinates (B, d)."""
        r = self.mu + u @ self.basis.T
        J = self.mean.shape[0]
        return R.quaternion_multiply(self.mean, R.rotvec_to_quaternion(r.reshape(len(u), J, 3)))


def _local_model(rotations: np.ndarray, root_height: np.ndarray, variance: float, max_components: int) -> _LocalModel:
    """PCA of neighbour poses (K, J, 4) (root = tilt) with their root heights (K,)."""
    q = np.asarray(rotations, dtype=np.float64)
    K, J, _ = q.shape
    q = np.where(np.sum(q * q[:1], axis=-1, keepdims=True) < 0, -q, q)
    mean = R.quaternion_normalize(q.mean(axis=0))
    r = R.quaternion_to_rotvec(R.quaternion_multiply(R.quaternion_conjugate(mean), q)).reshape(K, -1)
    mu = r.mean(axis=0)
    d = 0
    basis = np.zeros((3 * J, 0))
    if K > 1:
        # eigh of the (3J, 3J) covariance rather than an SVD of the data: LAPACK's SVD of these small
        # matrices is slow where OpenBLAS threads compete for busy cores
        xc = r - mu
        lam, v = np.linalg.eigh(xc.T @ xc / (K - 1))
        lam, vt = np.clip(lam[::-1], 0.0, None), v[:, ::-1].T
        total = lam.sum()
        if total > 0:
            frac = np.cumsum(lam) / total
            d = int(np.searchsorted(frac, variance - 1e-12) + 1)
            d = min(d, max_components, int(np.sum(lam > 1e-10 * lam[0])))
            basis = vt[:d].T * np.sqrt(lam[:d])
    h = np.asarray(root_height, dtype=np.float64)
    return _LocalModel(mean, mu, basis, float(h.mean()), float(h.std()))


@dataclass
class _Problem:
    """Everything the residuals of one frame need."""

    sk: Skeleton
    model: _LocalModel
    up: np.ndarray
    scale: float  # cm per file unit
    index: np.ndarray  # (M,) int64 joint carrying each marker (an end site's parent)
    offset: np.ndarray  # (M, 3) marker offset in that joint's global frame (end-site offset or 0)
    observed: np.ndarray  # (M,) bool
    target: np.ndarray  # (M, 3) file units
    prior: float  # sqrt of the prior weight
    smooth: float  # sqrt of the smoothness weight per joint
    history: np.ndarray  # (h, J, 3) previous global joint positions, newest first (h = 0, 1 or 2)
    height_prior: bool
    parents: np.ndarray  # (J,) int64
    offsets: np.ndarray  # (J, 3) file units
    heading: float  # the search frame's heading (eq. 4.3 against the nearest neighbour), radians
    heading_std: float  # radians
    ranges: _JointRanges | None = None  # the database's joint ranges; None: no joint-range term
    limit: float = 0.0  # cm of residual per radian beyond a joint's range
    mask: np.ndarray | None = None  # (J + M, J) :func:`.model_kinematics.carried_by` (computed when None)
    _last: tuple | None = field(default=None, repr=False)  # the last :meth:`_frame`, by its parameters' bytes

    def pose(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations (B, J, 4) with the global root rotation and root positions (B, 3) of parameters (B, n)."""
        d = self.model.dim
        q = self.model.decode(z[:, :d])
        yaw = R.quaternion_from_axis_angle(self.up, z[:, d])
        q[:, 0] = R.quaternion_multiply(yaw, q[:, 0])
        return q, z[:, d + 1 : d + 4] / self.scale

    def positions(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Global joint (B, J, 3) and marker (B, M, 3) positions of parameters (B, n), file units."""
        d = self.model.dim
        B, J = len(z), self.sk.num_joints
        rel = (self.model.mu + z[:, :d] @ self.model.basis.T).reshape(B, J, 3)
        yaw = R.quaternion_from_axis_angle(self.up, z[:, d])
        root = np.ascontiguousarray(z[:, d + 1 : d + 4]) / self.scale
        gpos = np.empty((B, J, 3))
        mpos = np.empty((B, len(self.index), 3))
        fk_model_poses(self.model.mean, rel, yaw, root, self.parents, self.offsets, self.index, self.offset, gpos, mpos)
        return gpos, mpos

    def residuals(self, z: np.ndarray) -> np.ndarray:
        """Residual vectors (B, n_res) of parameters (B, n): markers, prior, height prior, smoothness (cm)."""
        gpos, p = self.positions(z)
        return self._assemble(z, gpos, p)

    def _assemble(self, z: np.ndarray, gpos: np.ndarray, p: np.ndarray, excess: np.ndarray | None = None) -> np.ndarray:
        """The residuals (B, n_res) of parameters (B, n) with joint (B, J, 3), marker (B, M, 3) positions (and the
        joint-range excess (B, J, 3) when known)."""
        parts = [((p[:, self.observed] - self.target[self.observed]) * self.scale).reshape(len(z), -1)]
        parts.append(self.prior * z[:, : self.model.dim])
        parts.append(((z[:, self.model.dim] - self.heading) / self.heading_std)[:, None])
        if self.height_prior:
            h = (z[:, self.model.dim + 1 : self.model.dim + 4] / self.scale) @ self.up
            std = max(self.model.height_std, _MIN_HEIGHT_STD_CM / self.scale)
            parts.append(((h - self.model.height) / std)[:, None])
        if self.ranges is not None and self.limit > 0:
            if excess is None:
                excess = self.ranges.excess(self.model.decode(z[:, : self.model.dim]))
            parts.append(self.limit * excess.reshape(len(z), -1))
        if len(self.history) == 2:
            acc = gpos - 2 * self.history[0] + self.history[1]
            parts.append((self.smooth * self.scale * acc).reshape(len(z), -1))
        elif len(self.history) == 1:
            parts.append((self.smooth * self.scale * (gpos - self.history[0])).reshape(len(z), -1))
        return np.concatenate(parts, axis=1)

    def _frame(self, z: np.ndarray) -> tuple:
        """Joint (J, 3), marker (M, 3) positions, global rotations (J, 3, 3), rotation vectors (J, 3) of z (n,).

        The last one is kept: the solver asks for the Jacobian where it has just evaluated the residuals.
        """
        key = z.tobytes()
        if self._last is None or self._last[0] != key:
            d, J = self.model.dim, self.sk.num_joints
            rel = (self.model.mu + self.model.basis @ z[:d]).reshape(J, 3)
            yaw = R.quaternion_from_axis_angle(self.up, z[d : d + 1])[0]
            gpos, mpos, grot = np.empty((J, 3)), np.empty((len(self.index), 3)), np.empty((J, 3, 3))
            fk_model_pose(self.model.mean, rel, yaw, z[d + 1 : d + 4] / self.scale, self.parents, self.offsets,
                          self.index, self.offset, gpos, mpos, grot)
            vc = None
            if self.ranges is not None and self.limit > 0:
                vc = np.empty((J, 3)), np.empty((J, 3))
                range_coordinates(self.model.mean, rel, self.ranges.mean, self.ranges.axes, *vc)
            self._last = (key, (gpos, mpos, grot, rel, vc))
        return self._last[1]

    def fun(self, z: np.ndarray) -> np.ndarray:
        gpos, mpos, _, _, vc = self._frame(z)
        rg = self.ranges
        excess = None if vc is None else np.maximum(vc[1] - rg.hi, 0.0) + np.maximum(rg.lo - vc[1], 0.0)
        return self._assemble(z[None], gpos[None], mpos[None], excess)[0]

    def leaves_range(self, z: np.ndarray) -> bool:
        """Whether the pose of parameters (n,) takes a joint beyond its database range (:class:`_JointRanges`)."""
        if self.ranges is None or self.limit <= 0:
            return False
        return bool(np.any(self.ranges.excess(self.model.decode(z[None, : self.model.dim])) > 0))

    def jac_numeric(self, z: np.ndarray) -> np.ndarray:
        """The Jacobian (n_res, n) by forward differences (step 1e-6), one batched FK call: the reference of :meth:`jac`."""
        n = len(z)
        batch = np.vstack([z, z + _STEP * np.eye(n)])
        res = self.residuals(batch)
        return ((res[1:] - res[0]) / _STEP).T

    def jac(self, z: np.ndarray) -> np.ndarray:
        """The Jacobian (n_res, n) of :meth:`fun`, analytic (:func:`.model_kinematics.point_jacobian`)."""
        gpos, mpos, grot, rel, vc = self._frame(z)
        d, J, n = self.model.dim, len(gpos), len(z)
        if self.mask is None:
            self.mask = carried_by(self.parents, self.index)
        dp = point_jacobian(np.concatenate([gpos, mpos]), gpos, grot, rel, self.model.basis, self.mask, self.up,
                            self.scale)
        rows = [self.scale * dp[J:][self.observed].reshape(-1, n), np.zeros((d + 1, n))]
        rows[1][:d, :d] = self.prior * np.eye(d)
        rows[1][d, d] = 1.0 / self.heading_std
        if self.height_prior:
            std = max(self.model.height_std, _MIN_HEIGHT_STD_CM / self.scale)
            rows.append(np.zeros((1, n)))
            rows[-1][0, d + 1 :] = self.up / self.scale / std
        if self.ranges is not None and self.limit > 0:
            rows.append(np.zeros((3 * J, n)))
            rg = self.ranges
            rows[-1][:, :d] = self.limit * range_excess_jacobian(rel, *vc, self.model.basis, rg.axes, rg.lo, rg.hi)
        if len(self.history):
            rows.append(self.smooth * self.scale * dp[:J].reshape(-1, n))
        return np.concatenate(rows, axis=0)


# -- the reconstruction --------------------------------------------------------------------------


def _first_frame(mdb: _MarkerDatabase, obs: np.ndarray, seen: np.ndarray, up: np.ndarray) -> tuple[int, float, np.ndarray]:
    """Brute-force start: eq. 4.3 against every database frame; (frame, heading, ground translation) of the best fit."""
    a = mdb.features[:, seen]
    b = obs[seen]
    theta, t = align_about_vertical(a, b, up)
    fitted = R.quaternion_rotate(R.quaternion_from_axis_angle(up, theta)[:, None], a) + t[:, None]
    err = np.sum((fitted - b) ** 2, axis=(1, 2))
    err[~np.isfinite(err)] = np.inf
    n = int(np.argmin(err))
    return n, float(theta[n]), t[n]


def _normalised(points: np.ndarray, theta: float, ground: np.ndarray, up: np.ndarray) -> np.ndarray:
    return R.quaternion_rotate(R.quaternion_from_axis_angle(up, -theta), points - ground)


def _run(*args, **kwargs) -> Motion:
    """:func:`_solve` on one BLAS thread: the local models' sums are then the same to the last bit however many cores
    the machine has (two threads and one gave frames up to 2 degrees apart)."""
    with threadpool_limits(1, user_api="blas"):
        return _solve(*args, **kwargs)


def _solve(
    markers,
    joints,
    db: MotionDatabase,
    fps: float,
    *,
    k: int | None,
    skeleton: Skeleton | None,
    weights,
    variance: float,
    max_components: int,
    prior_weight: float,
    smooth_weight: float,
    max_iterations: int,
    heading_std: float,
    limit_weight: float,
    root_joint: str | None,
    up_axis,
    solve: bool,
    progress: bool,
) -> Motion:
    x, joints = _check(markers, joints, db, fps)
    check_marker_scale(x, joints, db)
    warn_unseen(x, joints, stacklevel=4)  # _solve <- _run <- reconstruct <- the user's call
    if k is None:
        k = default_neighbours(db.num_frames)
    if int(k) != k or k < 1:
        raise ValueError(f"k must be a positive integer, got {k}")
    if not 0 < variance <= 1:
        raise ValueError(f"variance must be in (0, 1], got {variance}")
    if prior_weight < 0 or smooth_weight < 0 or limit_weight < 0:
        raise ValueError("prior_weight, smooth_weight and limit_weight must be >= 0")
    given = output_skeleton(db, skeleton)
    whole, back = in_database_units(db, given)  # the markers are in the database's unit: so is the fit
    if skeleton is not None:
        skeleton = whole
    sk = body_skeleton(whole)  # the pelvis and the joints below it (the whole skeleton on Acclaim rigs)
    known = set(sk.joint_names) | set(sk.end_site_names)
    if any(j not in known for j in joints):
        raise ValueError(
            "the output skeleton lacks some of the marker joints, or they lie above the pelvis; "
            "pass a skeleton with the database's layout"
        )
    fps = float(fps)
    F_in = x.shape[0]
    run_fps = float(db.fps)
    if run_fps != fps:
        x = _resample_markers(x, fps, run_fps)
    up = database_up(db) if up_axis is None else parse_up_axis(up_axis)
    if weights is None:
        weights = search_weights(sk, joints)
    weights = np.asarray(weights, dtype=np.float64)
    if weights.shape != (len(joints),) or not np.all(np.isfinite(weights)) or np.any(weights <= 0):
        raise ValueError(f"search_weights: expected {len(joints)} positive finite weights, got {weights!r}")
    mdb = _marker_database(db, joints, up, skeleton, weights)
    scale = unit_scale_cm(sk)
    index, offset = _marker_columns(sk, joints)
    parents = np.asarray(sk.parents, dtype=np.int64)
    offsets = np.ascontiguousarray(sk.offsets, dtype=np.float64)
    root_name = sk.joint_names[0] if root_joint is None else root_joint
    root_col = [m for m, j in enumerate(joints) if j == root_name]
    root_col = root_col[0] if root_col else None
    K = int(min(k, len(mdb.index)))
    # the smoothness weight is stated per (cm / frame^2)^2 at 30 fps: the same acceleration costs the same
    smooth = np.sqrt(smooth_weight / sk.num_joints) * (run_fps / 30.0) ** 2

    F, J = x.shape[0], sk.num_joints
    seen = np.isfinite(x).all(axis=2)
    good = np.flatnonzero(seen.sum(axis=1) >= 3)
    if len(good) == 0:
        raise ValueError("no frame has 3 or more observed (finite) markers")
    t0 = int(good[0])
    local = np.zeros((F, J, 4))  # root entry: tilt
    theta = np.zeros(F)
    root = np.zeros((F, 3))
    gpos = np.zeros((F, J, 3))
    mpos = np.zeros((F, len(joints), 3))
    model = None
    for t in tqdm(range(t0, F), disable=bar_disabled(progress), **bar_size(), desc="frames", unit="frame"):
        obs, m_seen = x[t], seen[t]
        n_seen = int(m_seen.sum())
        if t == t0:
            n, th, g = _first_frame(mdb, obs, m_seen, up)
            first = True
        else:
            th = theta[t - 1]
            g = root[t - 1] - (root[t - 1] @ up) * up
            if root_col is not None and m_seen[root_col]:
                g = obs[root_col] - (obs[root_col] @ up) * up
            first = False
        if n_seen > 0:
            if first:
                fill = R.quaternion_rotate(R.quaternion_from_axis_angle(up, th), mdb.features[n]) + g
            else:
                fill = mpos[t - 1]
            query = np.where(m_seen[:, None], obs, fill)
            for refine in range(1 if first else 2):
                _, nn = mdb.index.query((_normalised(query, th, g, up) * mdb.weights[:, None]).ravel(), k=K)
                nn = nn[0][nn[0] >= 0]
                if n_seen >= 2:
                    th, g = align_about_vertical(mdb.features[nn[0]][m_seen], obs[m_seen], up)
                    th = float(th)
            neighbours = nn
        yaw = R.quaternion_from_axis_angle(up, th)
        if not solve:
            # baseline: the nearest database pose, placed by the alignment (root on the root marker when seen)
            n0 = neighbours[0]
            local[t] = mdb.rotations[n0]
            local[t, 0] = mdb.tilt[n0]
            theta[t] = th
            root[t] = R.quaternion_rotate(yaw, mdb.root[n0]) + g
            if root_col is not None and m_seen[root_col]:
                root[t] = obs[root_col]
        else:
            if n_seen > 0 or model is None:
                rots = np.array(mdb.rotations[neighbours], dtype=np.float64)
                rots[:, 0] = mdb.tilt[neighbours]
                model = _local_model(rots, mdb.root[neighbours] @ up, variance, max_components)
            if t == t0:
                u0 = np.zeros(model.dim)
                r0 = R.quaternion_rotate(yaw, mdb.root[neighbours[0]]) + g
            else:
                u0 = model.project(local[t - 1])
                r0 = root[t - 1].copy()
                if root_col is not None and m_seen[root_col]:
                    r0 = obs[root_col].copy()
            z0 = np.concatenate([u0, [th], r0 * scale])
            hist = gpos[[t - 1, t - 2]] if t - 2 >= t0 else (gpos[[t - 1]] if t - 1 >= t0 else np.zeros((0, J, 3)))
            problem = _Problem(
                sk,
                model,
                up,
                scale,
                index,
                offset,
                m_seen,
                np.nan_to_num(obs),
                np.sqrt(prior_weight),
                smooth,
                hist,
                root_col is None or not m_seen[root_col],
                parents,
                offsets,
                th,
                np.radians(heading_std),
                mdb.ranges,
                limit_weight,
            )
            sol = least_squares(problem.fun, z0, jac=problem.jac, method="lm", max_nfev=max_iterations)
            if t > t0 and problem.leaves_range(sol.x):
                # the fit from the previous pose ends with a joint bent beyond what the database does (a
                # knee or an elbow bent backwards stays so frame after frame: a local minimum the swivel
                # the markers leave free gets into); start again from the neighbours' mean pose and keep
                # the better of the two
                z1 = np.concatenate([np.zeros(model.dim), [th], r0 * scale])
                other = least_squares(problem.fun, z1, jac=problem.jac, method="lm", max_nfev=max_iterations)
                if other.cost < sol.cost:
                    sol = other
            z = sol.x
            q, rp = problem.pose(z[None])
            d = model.dim
            theta[t] = z[d]
            root[t] = rp[0]
            local[t] = q[0]
            local[t, 0] = R.quaternion_multiply(R.quaternion_conjugate(R.quaternion_from_axis_angle(up, z[d])), q[0, 0])
        fk_model_poses(
            local[t],
            np.zeros((1, J, 3)),
            R.quaternion_from_axis_angle(up, theta[t : t + 1]),
            root[t : t + 1],
            parents,
            offsets,
            index,
            offset,
            gpos[t : t + 1],
            mpos[t : t + 1],
        )
    glob = local.copy()
    glob[:, 0] = R.quaternion_multiply(R.quaternion_from_axis_angle(up, theta), local[:, 0])
    glob[:t0], root[:t0] = glob[t0], root[t0]
    out = whole_motion(Motion(sk, R.quaternion_normalize(glob), root, run_fps, name="reconstruction"), whole, up, held_above(db))
    out = in_units_of(out, given, back)
    if run_fps != fps:
        out = out.resample(fps)[:F_in]
    return on_joint_dofs(out)


def reconstruct(
    markers,
    joints: Sequence[str],
    db: MotionDatabase,
    fps: float,
    *,
    k: int | None = None,
    skeleton: Skeleton | None = None,
    search_weights: Sequence[float] | None = None,
    variance: float = 0.9999,
    max_components: int = 60,
    prior_weight: float = 0.01,
    smooth_weight: float = 0.01,
    max_iterations: int = 20,
    heading_std: float = 10.0,
    limit_weight: float = 100.0,
    root_joint: str | None = None,
    up_axis=None,
    progress: bool = False,
) -> Motion:
    """Full-body motion from a few marker trajectories (Krüger et al. 2010, sec. 5.2; Chai & Hodgins 2005).

    Per frame: kNN of the markers in a tracked normalised root frame, PCA of
    the neighbours' poses, and a least-squares fit of the markers under that
    prior and a smoothness term (see the module docstring for the details).

    Parameters
    ----------
    markers : float array (F, M, 3)
        Global marker positions in the database's length units (file units),
        NaN where a marker is occluded.
    joints : sequence of str (M,)
        The joints or end sites the markers sit on (HDM05/CMU:
        ``"lhand"``, ``"rhand"``, ``"lfoot"``, ``"rfoot"``, ``"head"``,
        ``"root"``, or end sites such as ``"ltoes_end"``); at least 3.
    db : MotionDatabase
        The knowledge base (any fps; the markers are resampled to it and the
        result back).
    fps : float
        Frame rate of ``markers`` and of the result.
    k : int, optional
        Neighbours per frame for the local model; default
        :func:`default_neighbours` of the database's frame count.
    skeleton : Skeleton, optional
        The performer's skeleton (the database's layout); the result is
        written on it and the fit uses its bone lengths. Default: the
        database's first skeleton.
    search_weights : sequence of float (M,), optional
        Weight of each marker in the neighbour search (its coordinates are
        scaled by it in the kd-tree's distance); default
        :func:`search_weights` (1.5 for the head marker, 1 elsewhere).
    variance : float
        Fraction of the neighbours' pose variance the local model keeps.
    max_components : int
        At most this many principal components.
    prior_weight : float
        Weight of the Mahalanobis prior term (per unit of squared
        whitened coordinate; the marker term is in cm^2).
    smooth_weight : float
        Weight of the mean squared joint acceleration (cm/frame^2 at 30 fps).
    max_iterations : int
        Residual evaluations per frame for the solver.
    heading_std : float
        Standard deviation (degrees) of the prior tying the pelvis heading to
        the eq. 4.3 heading of the search frame.
    limit_weight : float
        Centimetres of residual per radian by which a joint leaves the range
        the database's frames give it (:func:`joint_ranges`; 0 turns the term
        off). Within the range the term is zero.
    root_joint : str, optional
        Which marker (if any) is the root marker; default the pelvis's name
        (the root on Acclaim rigs, ``Hips`` on the Bandai Namco rig). A root marker pins the ground translation of the search
        frame and the root position.
    up_axis : optional
        Vertical axis (as in :func:`mocapkit.features.root_frame`); detected
        from the database skeleton by default.
    progress : bool
        Show a tqdm bar over frames.

    Returns
    -------
    Motion
        ``F`` frames at ``fps`` on ``skeleton``.

    Raises
    ------
    ValueError
        Unknown joint names, shape mismatches, fewer than 3 markers, an empty
        database, no frame with 3 observed markers.
    """
    return _run(
        markers,
        joints,
        db,
        fps,
        k=k,
        skeleton=skeleton,
        weights=search_weights,
        variance=variance,
        max_components=max_components,
        prior_weight=prior_weight,
        smooth_weight=smooth_weight,
        max_iterations=max_iterations,
        heading_std=heading_std,
        limit_weight=limit_weight,
        root_joint=root_joint,
        up_axis=up_axis,
        solve=True,
        progress=progress,
    )


def nearest_neighbor(
    markers,
    joints: Sequence[str],
    db: MotionDatabase,
    fps: float,
    *,
    skeleton: Skeleton | None = None,
    search_weights: Sequence[float] | None = None,
    root_joint: str | None = None,
    up_axis=None,
    progress: bool = False,
) -> Motion:
    """The baseline of :func:`reconstruct`: each frame's nearest database pose, no local model, no optimisation.

    The same tracked root frame and kd-tree search as :func:`reconstruct`;
    the nearest frame's pose is placed by the eq. 4.3 alignment (the root on
    the root marker when it is observed). Arguments as in :func:`reconstruct`.
    """
    return _run(
        markers,
        joints,
        db,
        fps,
        k=1,
        skeleton=skeleton,
        weights=search_weights,
        variance=1.0,
        max_components=0,
        prior_weight=0.0,
        smooth_weight=0.0,
        max_iterations=1,
        heading_std=1.0,
        limit_weight=0.0,
        root_joint=root_joint,
        up_axis=up_axis,
        solve=False,
        progress=progress,
    )
