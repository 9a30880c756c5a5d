"""Features of motion: root normalisation, Krüger's feature sets, virtual markers and accelerometers.

Everything here is a function over whole arrays, frames first:

* **Root normalisation** (Krüger et al. 2010, sec. 3.2, "normalized root
  positions and orientations"): :func:`root_frame` gives, per frame, a
  rotation about the vertical axis (the facing direction of the pelvis) and a
  ground-plane translation (the root projected onto the floor);
  :func:`normalize_positions` expresses global points in that frame.
* **Feature sets** (Krüger et al. 2010, sec. 3.2): :func:`feature_set` builds
  ``F15`` (wrists, ankles, head), ``F30`` (+ elbows, knees, chest), ``F39``
  (+ shoulders, lower back) and the windowed ``F15x3``, ``F15x5``, ``F30x3``,
  ``F39x3``; :class:`PCAFeatures` is ``F_pca^n``, principal components of
  normalised joint positions (sec. 3.1).
* **Virtual markers**: :func:`virtual_markers`, positions of joints or end
  sites with optional local offsets and noise.
* **Virtual accelerometers** (Tautges 2012, sec. 3.3): :class:`Sensor`,
  :func:`default_sensors` (Fig. 3.3), :func:`virtual_accelerometers` (local
  readings in m/s^2, gravity included), :func:`global_accelerations`
  (coordinate accelerations) and the five-point stencils of eqs. 3.1/3.2
  (:func:`five_point_derivative`).

Units. Positions and features stay in the file's length units unless
``scale_cm=True`` is passed (then centimetres, via
:func:`~mocapkit.motion.unit_scale_cm`); a :class:`Features` records which in
``unit_cm`` (centimetres per unit of its values). Accelerations are always in
m/s^2.

The vertical axis of a motion is found from its frames (:func:`find_up_axis`:
the axis along which head - feet points in most frames, unless a straight
standing rest pose says otherwise; right on every Bandai Namco take, whose rest
pose lies along x, where the rest-pose rule :func:`detect_up_axis` is not; a
skeleton without frames uses the rest pose) and can be overridden with ``up_axis`` (``"y"``,
``"-z"``, ``1``, ...). After normalisation, for an up axis ``k`` the body faces
``+axis (k + 1) % 3`` and its left is ``+axis (k + 2) % 3``: for Y-up data
(CMU, HDM05, most BVH) forward is +Z and left is +X, the height stays in Y.

Missing data (NaN) passes through: a NaN rotation or root position makes the
affected frames NaN and nothing else.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import numpy as np

from . import rotations as R
from .errors import SkeletonError
from .motion import Motion, Skeleton, readonly_view, find_joint, unit_scale_cm

__all__ = [
    "detect_up_axis",
    "find_up_axis",
    "REST_POSE_MIN_SHARE",
    "root_frame",
    "normalize_positions",
    "FEATURE_SETS",
    "WINDOWED_SETS",
    "Features",
    "window_offsets",
    "feature_set",
    "PCAFeatures",
    "virtual_markers",
    "Sensor",
    "default_sensors",
    "five_point_derivative",
    "virtual_accelerometers",
    "global_accelerations",
]

# -- the vertical axis ------------------------------------------------------------------

_AXIS_LETTERS = {"x": 0, "y": 1, "z": 2}


def parse_up_axis(up_axis) -> np.ndarray:
    """A signed coordinate axis from ``"y"``, ``"-z"``, ``"+x"``, ``1`` or a 3-vector along an axis."""
    if isinstance(up_axis, str):
        s = up_axis.strip().lower()
        sign = -1.0 if s.startswith("-") else 1.0
        s = s.lstrip("+-")
        if s not in _AXIS_LETTERS:
            raise ValueError(f"up_axis: expected 'x', 'y' or 'z' (optionally signed, e.g. '-z'), got {up_axis!r}")
        v = np.zeros(3)
        v[_AXIS_LETTERS[s]] = sign
        return v
    if isinstance(up_axis, (int, np.integer)):
        if not 0 <= int(up_axis) <= 2:
            raise ValueError(f"up_axis: an axis index must be 0, 1 or 2, got {up_axis}")
        v = np.zeros(3)
        v[int(up_axis)] = 1.0
        return v
    v = np.asarray(up_axis, dtype=np.float64)
    if v.shape != (3,) or np.count_nonzero(v) != 1 or not np.all(np.isfinite(v)):
        raise ValueError(f"up_axis: expected 'x'/'y'/'z', an index or a vector along one axis, got {up_axis!r}")
    return np.sign(v)


def detect_up_axis(skeleton: Skeleton) -> np.ndarray:
    """The vertical axis of ``skeleton`` as a signed unit coordinate vector (3,).

    In the rest pose (identity rotations) the head sits above the feet: the
    coordinate axis with the largest component of ``head - mean(ankles)`` is
    up, with that component's sign. CMU, HDM05 and most BVH rigs give
    ``(0, 1, 0)``. A skeleton without a head (by name or by its tree:
    :func:`~mocapkit.motion.find_joint`) gets ``(0, 1, 0)``, the BVH
    convention, as :func:`find_up_axis` gives a take with nothing to go on.

    >>> import mocapkit
    >>> detect_up_axis(mocapkit.load(mocapkit.samples.path("131_01.bvh")).skeleton).tolist()
    [0.0, 1.0, 0.0]
    """
    rest = skeleton.rest_positions()
    try:
        head = rest[find_joint(skeleton, "head")]
    except KeyError:
        return np.array([0.0, 1.0, 0.0])
    feet = []
    for role in ("left_foot", "right_foot"):
        try:
            feet.append(rest[find_joint(skeleton, role)])
        except KeyError:
            pass
    base = np.mean(feet, axis=0) if feet else rest[0]
    d = head - base
    k = int(np.argmax(np.abs(d)))
    if d[k] == 0.0:
        raise ValueError("cannot detect the up axis: the head and feet coincide in the rest pose; pass up_axis")
    v = np.zeros(3)
    v[k] = np.sign(d[k])
    return v


def _up(skeleton: Skeleton, up_axis) -> np.ndarray:
    return detect_up_axis(skeleton) if up_axis is None else parse_up_axis(up_axis)


def _axis(k: int, sign: float) -> np.ndarray:
    v = np.zeros(3)
    v[k] = 1.0 if sign >= 0 else -1.0
    return v


def _head_and_feet(skeleton: Skeleton) -> tuple[int, list[int]] | None:
    """(head, [feet]) joint indices, or None when the rig has no head or no foot."""
    try:
        head = find_joint(skeleton, "head")
    except KeyError:
        return None
    feet = []
    for role in ("left_foot", "right_foot"):
        try:
            feet.append(find_joint(skeleton, role))
        except KeyError:
            pass
    return (head, feet) if feet else None


#: a straight rest pose is up unless fewer than this share of the take's frames stand along it.
REST_POSE_MIN_SHARE = 0.1


def _standing_rest_axis(skeleton: Skeleton, head: int, feet: list[int]) -> int | None:
    """Vote index (2 axis + (sign > 0)) of the rest pose's head - feet axis, if the rest pose stands straight.

    Straight: head - mean(feet) is at least 0.7 of the bone path from a foot to
    the head and lies within about 25 deg of one coordinate axis (T-pose, A-pose).
    The Bandai Namco rig's rest pose folds its legs against its spine: not straight.
    """
    rest = skeleton.rest_positions()
    d = rest[head] - rest[feet].mean(axis=0)

    def chain(j):
        out = [j]
        while skeleton.parents[out[-1]] >= 0:
            out.append(int(skeleton.parents[out[-1]]))
        return out

    a, b = chain(feet[0]), chain(head)
    common = next(j for j in a if j in set(b))
    path = sum(float(np.linalg.norm(rest[j] - rest[skeleton.parents[j]]))
               for c in (a, b) for j in c[:c.index(common)])
    n = float(np.linalg.norm(d))
    k = int(np.argmax(np.abs(d)))
    if path <= 0 or n < 0.7 * path or abs(d[k]) < 0.9 * n:
        return None
    return 2 * k + int(d[k] > 0)


def find_up_axis(skeleton: Skeleton, positions: np.ndarray | None = None, up_axis=None) -> np.ndarray:
    """The signed coordinate axis (3,) that is up in a take, e.g. ``[0, 1, 0]`` or ``[0, 0, 1]``.

    Parameters
    ----------
    skeleton : Skeleton
        The take's rig; its joint names give the head and the feet.
    positions : float array (F, >=J, 3), optional
        Global joint positions (file units, any scale) of the take's frames, joints
        first (end sites after them are ignored).
    up_axis : str, int or 3-vector, optional
        The caller's answer (``"y"``, ``"-z"``, ``2``, ...; see
        :func:`mocapkit.features.parse_up_axis`): returned as given, nothing is guessed.

    Each frame where the head and a foot are present votes for the axis along
    which ``head - mean(feet)`` has its largest component, with that component's
    sign. Lying down is symmetric to standing up in these votes (an actor who
    lies on the floor for most of a take outvotes the frames he stands in), so a
    rest pose that stands straight (T-pose, A-pose: most mocap rigs) keeps its
    axis unless fewer than ``REST_POSE_MIN_SHARE`` of the frames stand along it
    (a file whose root turns a Y-up rig to Z up). A rest pose that does not stand
    (the Bandai Namco rig's folds along x) leaves the decision to the most voted
    axis. Without frames the rest pose decides
    (:func:`detect_up_axis`). A rig without a head or feet gets
    the axis along which the figure's extent is largest in most frames, pointing
    +; a take with nothing to go on gets +y. A take that lies on the floor
    throughout on a rig whose rest pose does not stand is drawn standing: pass
    ``up_axis``.

    >>> import mocapkit
    >>> m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:20]
    >>> find_up_axis(m.skeleton, m.global_positions()).tolist()
    [0.0, 1.0, 0.0]
    """
    if up_axis is not None:
        return parse_up_axis(up_axis)
    roles = _head_and_feet(skeleton)
    pos = None if positions is None else np.asarray(positions, dtype=np.float64)
    if roles is not None and pos is not None and pos.shape[0]:
        head, feet = roles
        with warnings.catch_warnings():  # frames without a foot give NaN, not a warning
            warnings.simplefilter("ignore", RuntimeWarning)
            d = pos[:, head] - np.nanmean(pos[:, feet], axis=1)
        ok = np.all(np.isfinite(d), axis=1) & np.any(d != 0, axis=1)
        if ok.any():
            d = d[ok]
            k = np.argmax(np.abs(d), axis=1)
            s = np.sign(d[np.arange(len(d)), k]) > 0
            votes = np.bincount(k * 2 + s, minlength=6)
            best = int(np.argmax(votes))
            rest = _standing_rest_axis(skeleton, head, feet)
            if rest is not None and votes[rest] >= REST_POSE_MIN_SHARE * votes.sum():
                best = rest
            return _axis(best // 2, 1.0 if best % 2 else -1.0)
    if roles is not None:
        try:
            return detect_up_axis(skeleton)
        except ValueError:
            pass
    if pos is not None and pos.shape[0]:
        with warnings.catch_warnings():  # frames without a point give NaN, not a warning
            warnings.simplefilter("ignore", RuntimeWarning)
            extent = np.nanmax(pos, axis=1) - np.nanmin(pos, axis=1)  # (F, 3)
        ok = np.all(np.isfinite(extent), axis=1)
        if ok.any():
            k = np.bincount(np.argmax(extent[ok], axis=1), minlength=3)
            return _axis(int(np.argmax(k)), 1.0)
    return _axis(1, 1.0)


def _forward_axis(up: np.ndarray) -> np.ndarray:
    """The fixed facing direction of the normalised frame: +axis ``(k + 1) % 3`` for up axis ``k``."""
    k = int(np.flatnonzero(up)[0])
    f = np.zeros(3)
    f[(k + 1) % 3] = 1.0
    return f


def _rest_body_axes(skeleton: Skeleton, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Left and forward unit vectors (3,) of the rest pose, horizontal, from the hips (else shoulders)."""
    rest = skeleton.rest_positions()
    lateral = None
    for left, right in (("left_hip", "right_hip"), ("left_shoulder", "right_shoulder"), ("left_foot", "right_foot")):
        try:
            d = rest[find_joint(skeleton, left)] - rest[find_joint(skeleton, right)]
        except KeyError:
            continue
        d = d - np.dot(d, up) * up
        if np.linalg.norm(d) > 1e-9:
            lateral = d / np.linalg.norm(d)
            break
    if lateral is None:
        raise ValueError(
            "cannot tell left from right in the rest pose: no left/right hip, shoulder or foot joints found"
        )
    forward = np.cross(lateral, up)
    return lateral, forward / np.linalg.norm(forward)


# -- root normalisation (Krüger et al. 2010, sec. 3.2) ----------------------------------


def root_frame(motion: Motion, up_axis=None) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame body frame for root normalisation (Krüger et al. 2010, sec. 3.2).

    The facing direction comes from the pelvis's global orientation: the
    rest-pose forward vector (left-right hip vector crossed with up) and the
    rest-pose left vector crossed with up are both rotated by the pelvis and
    projected onto the ground plane, and their sum is the heading. Either
    alone degenerates when the pelvis pitches (forward) or rolls (left) by
    90 degrees; the sum's angle is exactly the twist of the pelvis rotation
    about the up axis (swing-twist decomposition), undefined (NaN) only for
    a half turn about a horizontal axis.

    Parameters
    ----------
    motion : Motion
    up_axis : str, int or array, optional
        The vertical axis (``"y"``, ``"-z"``, 1, ...); found from the motion's
        frames by :func:`find_up_axis` when None.

    Returns
    -------
    rotation : float array (F, 4)
        Rotation about the up axis taking the normalised frame's fixed forward
        axis (+Z for Y-up) onto the body's heading, w first.
    translation : float array (F, 3)
        The root (pelvis) position projected onto the ground plane (its
        height component zeroed), file units.

    A global point ``p`` is ``rotate(rotation, p_local) + translation``.
    """
    grot, gpos = motion.global_transforms()
    return _root_frame(motion.skeleton, grot, gpos, find_up_axis(motion.skeleton, gpos, up_axis))


def _root_frame(sk: Skeleton, grot: np.ndarray, gpos: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`root_frame` from already computed global transforms (F, J, 4), (F, J, 3)."""
    lateral, forward = _rest_body_axes(sk, up)
    pelvis = find_joint(sk, "pelvis")
    q = grot[:, pelvis]
    f = R.quaternion_rotate(q, forward)
    left = R.quaternion_rotate(q, lateral)
    heading = f + np.cross(left, up)
    heading = heading - (heading @ up)[:, None] * up
    target = _forward_axis(up)
    # Signed angle about ``up`` from the fixed forward axis to the heading.
    angle = np.arctan2(np.cross(target, heading) @ up, heading @ target)
    with np.errstate(invalid="ignore"):
        degenerate = np.linalg.norm(heading, axis=-1) < 1e-9
    angle = np.where(degenerate, np.nan, angle)
    rotation = R.quaternion_from_axis_angle(up, angle)
    root = gpos[:, pelvis]
    translation = root - (root @ up)[:, None] * up
    return rotation, translation


def normalize_positions(
    motion: Motion, positions: np.ndarray, up_axis=None, frame: tuple[np.ndarray, np.ndarray] | None = None
) -> np.ndarray:
    """Express global points in the body frame of :func:`root_frame` (Krüger et al. 2010, sec. 3.2).

    Ground-plane translation is removed and the facing direction is turned to
    the fixed forward axis (+Z for Y-up); heights are kept.

    Parameters
    ----------
    motion : Motion
        Gives the per-frame body frame (unless ``frame`` is passed).
    positions : float array (F, N, 3) or (F, 3)
        Global points, file units.
    up_axis : optional
        As in :func:`root_frame`.
    frame : (rotation (F, 4), translation (F, 3)), optional
        A precomputed :func:`root_frame`.

    Returns
    -------
    float array, same shape as ``positions``, file units.
    """
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim not in (2, 3) or p.shape[-1] != 3 or p.shape[0] != motion.num_frames:
        raise ValueError(f"positions: expected shape ({motion.num_frames}, N, 3) or ({motion.num_frames}, 3), got {p.shape}")
    rot, tr = root_frame(motion, up_axis) if frame is None else frame
    if p.ndim == 2:
        return R.quaternion_rotate(R.quaternion_conjugate(rot), p - tr)
    return R.quaternion_rotate(R.quaternion_conjugate(rot)[:, None], p - tr[:, None])


# -- Krüger's feature sets (sec. 3.2) -----------------------------------------------------

#: Joints (roles of :func:`mocapkit.motion.find_joint`) of the frame-based feature sets, in column order.
FEATURE_SETS: dict[str, tuple[str, ...]] = {
    "F15": ("left_hand", "right_hand", "left_foot", "right_foot", "head"),
}
FEATURE_SETS["F30"] = FEATURE_SETS["F15"] + ("left_elbow", "right_elbow", "left_knee", "right_knee", "chest")
FEATURE_SETS["F39"] = FEATURE_SETS["F30"] + ("left_shoulder", "right_shoulder", "lower_back")

#: Windowed sets: name -> (frame-based set, samples in the 0.3 s window).
WINDOWED_SETS: dict[str, tuple[str, int]] = {"F15x3": ("F15", 3), "F15x5": ("F15", 5), "F30x3": ("F30", 3), "F39x3": ("F39", 3)}


@dataclass(frozen=True, eq=False)
class Features:
    """A feature matrix with its column names.

    Attributes
    ----------
    values : float array (F, D)
        One row per frame.
    names : tuple of str, (D,)
        Column names: ``"<role>.<axis>"`` (``"left_hand.x"``) for frame-based
        sets, ``"<role>.<axis>@<offset>"`` (``"left_hand.x@-18"``, offset in
        frames) for windowed sets, ``"pc<k>"`` for PCA.
    fps : float
        Frame rate of the rows.
    unit_cm : float or None
        Centimetres per unit of the positional values (1.0 when scaled to
        centimetres; None when the file's unit could not be determined).
    """

    values: np.ndarray
    names: tuple[str, ...]
    fps: float
    unit_cm: float | None = None

    def __post_init__(self):
        v = np.asarray(self.values, dtype=np.float64)
        names = tuple(str(n) for n in self.names)
        if v.ndim != 2 or v.shape[1] != len(names):
            raise ValueError(f"values: expected shape (F, {len(names)}), got {v.shape}")
        object.__setattr__(self, "values", readonly_view(v))
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "fps", float(self.fps))

    @property
    def dim(self) -> int:
        return int(self.values.shape[1])

    def __len__(self) -> int:
        return int(self.values.shape[0])

    def __repr__(self) -> str:
        return f"Features({self.values.shape[0]} frames x {self.dim} dims @ {self.fps:g} fps)"


def window_offsets(fps: float, samples: int, window: float = 0.3) -> np.ndarray:
    """Frame offsets of ``samples`` frames spread evenly over a ``window``-second window centred on 0.

    Offsets are ``round(linspace(-window/2, window/2, samples) * fps)``, halves
    rounded away from zero so the offsets stay symmetric (Krüger et al. 2010,
    sec. 3.2: 3 or 5 frames on a 0.3 s window).

    >>> window_offsets(120, 3).tolist(), window_offsets(120, 5).tolist()
    ([-18, 0, 18], [-18, -9, 0, 9, 18])
    >>> window_offsets(30, 3).tolist(), window_offsets(30, 5).tolist()
    ([-5, 0, 5], [-5, -2, 0, 2, 5])
    """
    if samples < 1:
        raise ValueError(f"samples must be at least 1, got {samples}")
    t = np.linspace(-window / 2, window / 2, samples) * float(fps)
    return (np.sign(t) * np.floor(np.abs(t) + 0.5 + 1e-9)).astype(np.int64)


def _scale(motion: Motion, scale_cm: bool) -> tuple[float, float | None]:
    """(factor to apply to file units, unit_cm of the result)."""
    if scale_cm:
        return unit_scale_cm(motion.skeleton), 1.0
    try:
        return 1.0, unit_scale_cm(motion.skeleton)
    except (SkeletonError, KeyError):  # not a human-sized rig, or no head/ankle: the unit is unknown
        return 1.0, None


def feature_set(motion: Motion, name: str = "F15", up_axis=None, scale_cm: bool = False) -> Features:
    """Krüger et al.'s geometric feature sets (2010, sec. 3.2) as a :class:`Features`.

    ``F15``: wrists, ankles and head in the normalised root frame
    (:func:`normalize_positions`), 5 x 3 values. ``F30``: F15 plus elbows,
    knees and one chest joint. ``F39``: F30 plus shoulders and one lower-back
    joint. Joints are found by role (:func:`mocapkit.motion.find_joint`) and
    appear in :data:`FEATURE_SETS` order, x, y, z each.

    Windowed sets ``F15x3``, ``F15x5``, ``F30x3``, ``F39x3`` stack the
    frame-based set at the 3 or 5 frame offsets of :func:`window_offsets`
    (0.3 s window centred on the frame; indices clamped to the clip), offset
    blocks in increasing order.

    Parameters
    ----------
    motion : Motion
    name : str
        One of ``F15``, ``F30``, ``F39``, ``F15x3``, ``F15x5``, ``F30x3``, ``F39x3``.
    up_axis : optional
        As in :func:`root_frame`.
    scale_cm : bool
        False (default) keeps the file's length units, like the rest of
        mocapkit; True converts to centimetres (needed to compare clips from
        rigs in different units). ``Features.unit_cm`` records which.

    Returns
    -------
    Features
        ``values`` (F, D) with D = 15, 30, 39, 45, 75, 90 or 117.

    >>> import mocapkit
    >>> m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    >>> f = feature_set(m, "F15x3")
    >>> f.values.shape, f.names[:2]
    ((994, 45), ('left_hand.x@-18', 'left_hand.y@-18'))
    """
    if name in FEATURE_SETS:
        base, samples = name, 1
    elif name in WINDOWED_SETS:
        base, samples = WINDOWED_SETS[name]
    else:
        known = ", ".join(list(FEATURE_SETS) + list(WINDOWED_SETS))
        raise ValueError(f"unknown feature set {name!r}; known: {known}")
    roles = FEATURE_SETS[base]
    sk = motion.skeleton
    idx = [find_joint(sk, r) for r in roles]
    factor, unit_cm = _scale(motion, scale_cm)
    grot, gpos = motion.global_transforms()
    frame = _root_frame(sk, grot, gpos, find_up_axis(sk, gpos, up_axis))
    local = normalize_positions(motion, gpos[:, idx], frame=frame) * factor
    F = motion.num_frames
    frame_names = [f"{r}.{c}" for r in roles for c in "xyz"]
    flat = local.reshape(F, -1)
    if samples == 1:
        return Features(flat, tuple(frame_names), motion.fps, unit_cm)
    offsets = window_offsets(motion.fps, samples)
    frames = np.arange(F)
    blocks, names = [], []
    for off in offsets:
        blocks.append(flat[np.clip(frames + off, 0, max(F - 1, 0))])
        names.extend(f"{n}@{int(off):+d}".replace("@+0", "@0") for n in frame_names)
    return Features(np.concatenate(blocks, axis=1), tuple(names), motion.fps, unit_cm)


def _base_values(motion: Motion, base: str, up_axis, scale_cm: bool) -> np.ndarray:
    if base == "joint_positions":
        factor, _ = _scale(motion, scale_cm)
        grot, gpos = motion.global_transforms()
        frame = _root_frame(motion.skeleton, grot, gpos, find_up_axis(motion.skeleton, gpos, up_axis))
        local = normalize_positions(motion, gpos, frame=frame) * factor
        return local.reshape(motion.num_frames, -1)
    return feature_set(motion, base, up_axis, scale_cm).values


class PCAFeatures:
    """Principal components of normalised joint positions: Krüger et al.'s ``F_pca^n`` (2010, sec. 3.1).

    Follows the scikit-learn contract: parameters in ``__init__``, ``fit``
    returns ``self``, learned state ends in ``_``.

    Parameters
    ----------
    n_components : int
        Number of principal components ``n`` kept (Krüger uses 8, 16, 25).
    base : str
        ``"joint_positions"``: all joints in the body frame of
        :func:`normalize_positions`, (F, 3J); or a :func:`feature_set` name.
    up_axis, scale_cm :
        As in :func:`feature_set`.

    Attributes
    ----------
    mean_ : float array (D,)
    components_ : float array (n_components, D)
        Orthonormal rows, largest variance first.
    explained_variance_ : float array (n_components,)
    explained_variance_ratio_ : float array (n_components,)
    n_features_in_ : int
    joint_names_ : tuple of str
        Joints of the skeleton it was fitted on; ``transform`` checks them.

    Frames with any NaN are left out of the fit; they transform to NaN.
    """

    def __init__(self, n_components: int = 16, base: str = "joint_positions", up_axis=None, scale_cm: bool = False):
        self.n_components = n_components
        self.base = base
        self.up_axis = up_axis
        self.scale_cm = scale_cm

    def _values(self, motion: Motion) -> np.ndarray:
        return _base_values(motion, self.base, self.up_axis, self.scale_cm)

    def fit(self, motions: Motion | Iterable[Motion]) -> "PCAFeatures":
        """Fit on one Motion or several (same skeleton topology); returns ``self``."""
        if isinstance(motions, Motion):
            motions = [motions]
        motions = list(motions)
        if not motions:
            raise ValueError("fit needs at least one motion")
        first = motions[0].skeleton
        for m in motions[1:]:
            if not m.skeleton.is_compatible(first):
                raise ValueError(f"cannot fit on {m.name!r}: its skeleton differs from {motions[0].name!r}'s")
        X = np.concatenate([self._values(m) for m in motions])
        X = X[np.all(np.isfinite(X), axis=1)]
        n, d = X.shape
        k = int(self.n_components)
        if not 1 <= k <= min(n, d):
            raise ValueError(f"n_components={k} must be between 1 and min(n_frames={n}, n_features={d})")
        self.mean_ = X.mean(axis=0)
        _, s, vt = np.linalg.svd(X - self.mean_, full_matrices=False)
        var = s**2 / max(n - 1, 1)
        total = var.sum()
        self.components_ = vt[:k]
        self.explained_variance_ = var[:k]
        self.explained_variance_ratio_ = var[:k] / total if total > 0 else np.zeros(k)
        self.n_features_in_ = d
        self.joint_names_ = first.joint_names
        return self

    def _check(self, motion: Motion) -> None:
        if not hasattr(self, "components_"):
            raise ValueError("this PCAFeatures is not fitted yet; call fit(motions) first")
        if motion.skeleton.joint_names != self.joint_names_:
            raise ValueError(f"{motion.name!r}: its skeleton differs from the one this PCA was fitted on")

    def transform(self, motion: Motion) -> np.ndarray:
        """Coefficients (F, n_components) of ``motion``'s normalised poses."""
        self._check(motion)
        return (self._values(motion) - self.mean_) @ self.components_.T

    def fit_transform(self, motions) -> np.ndarray:
        if isinstance(motions, Motion):
            motions = [motions]
        motions = list(motions)
        self.fit(motions)
        return np.concatenate([self.transform(m) for m in motions])

    def inverse_transform(self, coefficients: np.ndarray) -> np.ndarray:
        """Poses (F, D) in the base representation from coefficients (F, n_components)."""
        if not hasattr(self, "components_"):
            raise ValueError("this PCAFeatures is not fitted yet; call fit(motions) first")
        return np.asarray(coefficients, dtype=np.float64) @ self.components_ + self.mean_

    def features(self, motion: Motion) -> Features:
        """:meth:`transform` wrapped as a :class:`Features` with names ``pc0``, ``pc1``, ..."""
        vals = self.transform(motion)
        unit = 1.0 if self.scale_cm else _scale(motion, False)[1]
        return Features(vals, tuple(f"pc{i}" for i in range(vals.shape[1])), motion.fps, unit)

    def __repr__(self) -> str:
        return f"PCAFeatures(n_components={self.n_components}, base={self.base!r})"


# -- virtual markers --------------------------------------------------------------------


def _frames_of(motion: Motion, names: Sequence) -> tuple[np.ndarray, np.ndarray]:
    """Global rotation (F, M, 4) and position (F, M, 3) of named joints / end sites (or joint indices)."""
    sk = motion.skeleton
    grot, gpos = motion.global_transforms()
    jn = {n: i for i, n in enumerate(sk.joint_names)}
    en = {n: i for i, n in enumerate(sk.end_site_names)}
    ends = None
    rots, poss = [], []
    for n in names:
        if isinstance(n, (int, np.integer)):
            if not 0 <= int(n) < sk.num_joints:
                raise KeyError(f"joint index {n} out of range for {sk.num_joints} joints")
            j = int(n)
            rots.append(grot[:, j])
            poss.append(gpos[:, j])
        elif n in jn:
            rots.append(grot[:, jn[n]])
            poss.append(gpos[:, jn[n]])
        elif n in en:
            if ends is None:
                ends = motion.end_sites_from(grot, gpos)
            e = en[n]
            rots.append(grot[:, sk.end_site_parents[e]])
            poss.append(ends[:, e])
        else:
            raise KeyError(f"no joint or end site named {n!r}; joints are: {', '.join(sk.joint_names)}")
    F = motion.num_frames
    if not names:
        return np.zeros((F, 0, 4)), np.zeros((F, 0, 3))
    return np.stack(rots, axis=1), np.stack(poss, axis=1)


def virtual_markers(
    motion: Motion,
    names: Sequence[str],
    local_offsets: np.ndarray | None = None,
    noise_std: float = 0.0,
    seed=None,
) -> np.ndarray:
    """Positions (F, M, 3) of virtual markers on joints or end sites, file units.

    A marker on joint ``j`` sits at ``p_j + rotate(q_j, offset)``: the offset is
    in the joint's global frame (the frame in which its children's offsets
    are given, i.e. the bone leaving ``j``). A marker on an end site uses the
    frame of the end site's parent joint.

    Parameters
    ----------
    motion : Motion
    names : sequence of str (M,)
        Joint or end-site names (``skeleton.end_site_names``); joint indices allowed.
    local_offsets : float array (M, 3) or (3,), optional
        Offsets in each marker's bone frame, file units; zero when None.
    noise_std : float
        Standard deviation of isotropic Gaussian noise added to every coordinate, file units.
    seed : int or numpy Generator, optional
        Seed of the noise.
    """
    names = list(names)
    grot, gpos = _frames_of(motion, names)
    out = gpos
    if local_offsets is not None:
        off = np.asarray(local_offsets, dtype=np.float64)
        off = np.broadcast_to(off, (len(names), 3)) if off.shape in ((3,), (len(names), 3)) else None
        if off is None:
            raise ValueError(f"local_offsets: expected shape ({len(names)}, 3) or (3,), got {np.shape(local_offsets)}")
        out = gpos + R.quaternion_rotate(grot, off)
    if noise_std < 0:
        raise ValueError(f"noise_std must be >= 0, got {noise_std}")
    if noise_std > 0:
        rng = np.random.default_rng(seed)
        out = out + rng.normal(0.0, noise_std, size=out.shape)
    return np.array(out)


# -- virtual accelerometers (Tautges 2012, sec. 3.3) --------------------------------------


@dataclass(frozen=True, eq=False)
class Sensor:
    """A virtual inertial sensor rigidly attached to a joint's frame.

    Attributes
    ----------
    name : str
    joint : str
        The joint whose global frame carries the sensor (for a sensor on the
        lower arm: the elbow, whose frame moves the forearm).
    rotation : float array (4,)
        Sensor frame relative to the joint's global frame, w first: the
        sensor's global orientation is ``q_joint * rotation``.
    offset : float array (3,)
        Sensor position in the joint's frame, file units.
    """

    name: str
    joint: str
    rotation: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        q = np.asarray(self.rotation, dtype=np.float64).reshape(-1)
        o = np.asarray(self.offset, dtype=np.float64).reshape(-1)
        if q.shape != (4,):
            raise ValueError(f"sensor {self.name!r}: rotation must be a quaternion (4,), w first, got {q.shape}")
        if o.shape != (3,):
            raise ValueError(f"sensor {self.name!r}: offset must be (3,), got {o.shape}")
        q = q / np.linalg.norm(q)
        q.setflags(write=False)
        o.setflags(write=False)
        object.__setattr__(self, "rotation", q)
        object.__setattr__(self, "offset", o)


def default_sensors(skeleton: Skeleton, fraction: float = 0.9, up_axis=None) -> list[Sensor]:
    """Four sensors on the lower arms and lower legs next to the wrists and ankles (Tautges 2012, Fig. 3.3).

    Placement: each sensor rides on the segment ending at the wrist or ankle
    (the joint's parent: elbow / knee, whose frame moves the forearm / shin),
    ``fraction`` of the way from the elbow/knee to the wrist/ankle.

    Orientation (Fig. 3.3), built in the rest pose, where the parent's global
    frame is the identity:

    * X along the bone, pointing away from the body centre (elbow -> wrist,
      knee -> ankle).
    * Arms: Z points up when the arm is stretched out sideways with the palm
      down. The rest arm is turned by the smallest rotation onto the
      horizontal outward direction (a T-pose); Z is that rotation's preimage
      of up. A T-pose rig gives Z = up; a rig with hanging arms gives Z
      pointing laterally outwards (palms assumed to face the thighs).
    * Legs: Z points forward, orthogonal to X and to the knee axis (taken as
      the body's left-right axis).
    * Y completes a right-handed frame (Y = Z x X).

    Returns sensors named ``left_wrist``, ``right_wrist``, ``left_ankle``,
    ``right_ankle`` in that order.
    """
    up = _up(skeleton, up_axis)
    left, forward = _rest_body_axes(skeleton, up)
    out = []
    for sname, role, side, kind in (
        ("left_wrist", "left_hand", 1.0, "arm"),
        ("right_wrist", "right_hand", -1.0, "arm"),
        ("left_ankle", "left_foot", 1.0, "leg"),
        ("right_ankle", "right_foot", -1.0, "leg"),
    ):
        end = find_joint(skeleton, role)
        parent = int(skeleton.parents[end])
        if parent < 0:
            raise ValueError(f"the {role} joint {skeleton.joint_names[end]!r} is the root; cannot place a sensor")
        bone = skeleton.offsets[end]
        length = np.linalg.norm(bone)
        if length < 1e-9:
            raise ValueError(f"the bone ending at {skeleton.joint_names[end]!r} has zero length")
        x = bone / length
        if kind == "arm":
            outward = side * left
            z = R.quaternion_to_matrix(R.shortest_arc(x, outward)).T @ up
        else:
            z = forward
        z = z - np.dot(z, x) * x
        if np.linalg.norm(z) < 1e-6:  # bone along the preferred Z: fall back to up, then forward
            for cand in (up, forward):
                z = cand - np.dot(cand, x) * x
                if np.linalg.norm(z) > 1e-6:
                    break
        z = z / np.linalg.norm(z)
        y = np.cross(z, x)
        q = R.matrix_to_quaternion(np.stack([x, y, z], axis=1))
        out.append(Sensor(sname, skeleton.joint_names[parent], q, fraction * bone))
    return out


def five_point_derivative(x: np.ndarray, fps: float, order: int = 1, axis: int = 0) -> np.ndarray:
    """First or second time derivative by the five-point stencil (Tautges 2012, sec. 3.3, eqs. 3.1/3.2).

    Interior samples use the central five-point stencils, error O(h^4)::

        v(t) = (-x(t+2h) + 8 x(t+h) - 8 x(t-h) + x(t-2h)) / (12 h)
        a(t) = (-x(t+2h) + 16 x(t+h) - 30 x(t) + 16 x(t-h) - x(t-2h)) / (12 h^2)

    (eq. 3.2 printed with ``v`` inside is read as this standard stencil on
    positions). The two samples at each end use four-point one-sided
    (first sample) or off-centre / three-point central (second sample)
    stencils, all exact on cubic polynomials. Series of fewer than four
    samples use the three-point stencils when they can (F = 3) and are
    treated as at rest (zeros) otherwise.

    Parameters
    ----------
    x : float array, time along ``axis``
    fps : float
        Samples per second; h = 1 / fps.
    order : 1 or 2
    axis : int

    Returns
    -------
    Array of ``x``'s shape, units of ``x`` per second (per second squared).
    NaN at sample k reaches only the derivatives at samples k-3 .. k+3.

    >>> t = np.arange(10) / 10.0
    >>> np.allclose(five_point_derivative(t**3, 10.0, order=2), 6 * t)
    True
    """
    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, got {order}")
    x = np.moveaxis(np.asarray(x, dtype=np.float64), axis, 0)
    h = 1.0 / float(fps)
    n = x.shape[0]
    out = np.zeros_like(x)
    if n < 3:
        return np.moveaxis(out, 0, axis)
    # Every stencil is written on differences from one sample so that a constant
    # signal gives exactly zero (a sensor at rest reads exactly g) and round-off
    # does not grow with the distance from the origin.
    d = lambda i, j: x[i] - x[j]  # noqa: E731
    with np.errstate(invalid="ignore"):
        if n == 3:
            if order == 1:
                out[0] = (4 * d(1, 0) - d(2, 0)) / (2 * h)
                out[1] = d(2, 0) / (2 * h)
                out[2] = (3 * d(2, 0) - 4 * d(1, 0)) / (2 * h)
            else:
                out[:] = (d(2, 1) - d(1, 0)) / h**2
            return np.moveaxis(out, 0, axis)
        if order == 1:
            if n >= 5:
                out[2:-2] = (8 * (x[3:-1] - x[1:-3]) - (x[4:] - x[:-4])) / (12 * h)
            out[0] = (18 * d(1, 0) - 9 * d(2, 0) + 2 * d(3, 0)) / (6 * h)
            out[1] = (-3 * d(1, 0) + 6 * d(2, 0) - d(3, 0)) / (6 * h)
            out[-2] = (-3 * d(-2, -1) + 6 * d(-3, -1) - d(-4, -1)) / (-6 * h)
            out[-1] = (18 * d(-2, -1) - 9 * d(-3, -1) + 2 * d(-4, -1)) / (-6 * h)
        else:
            if n >= 5:
                c = x[2:-2]
                out[2:-2] = (16 * ((x[3:-1] - c) + (x[1:-3] - c)) - ((x[4:] - c) + (x[:-4] - c))) / (12 * h**2)
            out[0] = (-5 * d(1, 0) + 4 * d(2, 0) - d(3, 0)) / h**2
            out[1] = (d(0, 1) + d(2, 1)) / h**2
            out[-2] = (d(-1, -2) + d(-3, -2)) / h**2
            out[-1] = (-5 * d(-2, -1) + 4 * d(-3, -1) - d(-4, -1)) / h**2
    return np.moveaxis(out, 0, axis)


def _metres_per_unit(motion: Motion, unit_cm: float | None) -> float:
    return (unit_scale_cm(motion.skeleton) if unit_cm is None else float(unit_cm)) / 100.0


def _sensor_up(sk: Skeleton, gpos: np.ndarray, up_axis) -> np.ndarray:
    """The up axis of :func:`virtual_accelerometers`: given, the straight rest pose's, or the frames' (:func:`find_up_axis`)."""
    if up_axis is not None:
        return parse_up_axis(up_axis)
    roles = _head_and_feet(sk)
    if roles is not None and _standing_rest_axis(sk, *roles) is not None:
        return detect_up_axis(sk)
    return find_up_axis(sk, gpos)


def virtual_accelerometers(
    motion: Motion,
    sensors: Sequence[Sensor] | None = None,
    gravity: float = 9.81,
    up_axis=None,
    unit_cm: float | None = None,
) -> np.ndarray:
    """Simulated accelerometer readings (F, S, 3) in m/s^2, each in its sensor's frame (Tautges 2012, sec. 3.3).

    Sensor positions come from forward kinematics; their second derivative by
    the five-point stencil (:func:`five_point_derivative`) is the coordinate
    acceleration ``a(t)``, converted to metres with the skeleton's unit
    (:func:`~mocapkit.motion.unit_scale_cm`, e.g. 5.644 cm per CMU/HDM05
    unit). An accelerometer measures specific force ``a(t) - g`` with ``g``
    pointing down, so a sensor at rest reads ``gravity`` upwards; the result
    is rotated into each sensor's local frame.

    Parameters
    ----------
    motion : Motion
    sensors : sequence of Sensor, optional
        :func:`default_sensors` (wrists and ankles) when None.
    gravity : float
        Magnitude of g in m/s^2.
    up_axis : optional
        The direction gravity pulls against; when None the rest pose's
        (:func:`detect_up_axis`) if it stands straight (T-pose, A-pose), else
        found from the frames (:func:`find_up_axis`: a rig whose rest pose lies
        down, as the Bandai Namco rig's); also for the default sensors.
    unit_cm : float, optional
        Centimetres per file unit; from :func:`~mocapkit.motion.unit_scale_cm` when None.

    Returns
    -------
    float array (F, S, 3), m/s^2. NaN in a frame's pose gives NaN readings
    only within three frames of it.
    """
    sk = motion.skeleton
    grot, gpos = motion.global_transforms()
    up = _sensor_up(sk, gpos, up_axis)
    if sensors is None:
        sensors = default_sensors(sk, up_axis=up)
    sensors = list(sensors)
    scale = _metres_per_unit(motion, unit_cm)
    joints = [sk.index(s.joint) for s in sensors]
    F = motion.num_frames
    if not sensors:
        return np.zeros((F, 0, 3))
    qj = grot[:, joints]
    offs = np.stack([s.offset for s in sensors])
    qs = np.stack([s.rotation for s in sensors])
    pos = gpos[:, joints] + R.quaternion_rotate(qj, offs)
    acc = five_point_derivative(pos * scale, motion.fps, order=2, axis=0)
    specific = acc + gravity * up
    q_sensor = R.quaternion_multiply(qj, qs)
    return R.quaternion_rotate(R.quaternion_conjugate(q_sensor), specific)


def global_accelerations(motion: Motion, joints: Sequence, unit_cm: float | None = None) -> np.ndarray:
    """Coordinate accelerations (F, N, 3) of joints or end sites in the global frame, m/s^2, gravity-free.

    The second derivative of the global positions by the five-point stencil
    (Tautges 2012, sec. 3.3, eq. 3.2), as used with the multilinear models.

    Parameters
    ----------
    motion : Motion
    joints : sequence of str or int (N,)
        Joint or end-site names (or joint indices).
    unit_cm : float, optional
        Centimetres per file unit; from :func:`~mocapkit.motion.unit_scale_cm` when None.
    """
    _, pos = _frames_of(motion, list(joints))
    return five_point_derivative(pos * _metres_per_unit(motion, unit_cm), motion.fps, order=2, axis=0)
