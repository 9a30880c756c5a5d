"""Corruption with known ground truth: noise, gaps and the errors a real capture shows.

Every function takes a Motion and a ``seed`` (int, None or a
``numpy.random.Generator``) and returns ``(corrupted, mask)`` where ``mask``
is a boolean (F, J) array that is True exactly where a joint's rotation (for
the root: or its position) differs from the input; every cell where it is
False is bit-identical to the input. The input is never modified. The same
seed gives the same result. :func:`real_errors` also returns a list of
:class:`ErrorRecord` as a third element (what was injected, where).

Noise models follow Mall et al. 2017, section 4 (angular, uniform, biased and
spatial noise; gaps with exponentially decaying lengths); the error kinds
follow Aristidou et al. 2018, section 6 (spikes, flipped and frozen joints,
drift, swapped limbs).

Changes made in joint-angle space (noise, bias, spikes, drift) are made on the
file's own channels (:meth:`Motion.channel_values`), so the result is still a
motion the skeleton's file format can hold: an ASF joint with one degree of
freedom keeps one. Returned quaternions are sign-aligned with the input (same
hemisphere), so a corruption never adds a quaternion sign jump.

Examples
--------
>>> import mocapkit
>>> from mocapkit import corrupt
>>> m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
>>> noisy, mask = corrupt.angular_noise(m, amount=0.5, seed=0)   # Mall et al.'s "0.5 noise"
>>> mask.shape, bool(mask[:, 0].any())                           # the root is kept clean
((994, 31), False)
>>> bad, mask, records = corrupt.real_errors(m, n_errors=3, seed=1)
>>> all(mask[r.start : r.end, m.skeleton.index(r.joint)].any() for r in records)
True
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np

from . import rotations as R
from .errors import MocapError, SkeletonError
from .joint_spread import joint_rotation_spread, noise_spread
from .mirroring import mirror_for_rig
from .markerset import MarkerSet
from .motion import Motion, bone_moving_joints, find_joint, mirror_pairs, unit_scale_cm
from .words import frame_span

__all__ = [
    "angular_noise",
    "uniform_noise",
    "bias",
    "spatial_noise",
    "gaps",
    "real_errors",
    "smooth_drifts",
    "corrupt",
    "channel_spread",
    "ErrorRecord",
    "describe_error",
    "describe_errors",
    "KINDS",
    "ERROR_KINDS",
]

KINDS = ("noise", "uniform", "bias", "spatial", "gaps", "errors")
ERROR_KINDS = ("spike", "flip", "freeze", "drift", "swap")


# -- helpers ----------------------------------------------------------------------


def _rng(seed) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def skeletal(motion, what: str) -> None:
    """Refuse a :class:`~mocapkit.markerset.MarkerSet` given to ``what`` (a corruption of joint rotations) in one
    line: a marker capture has no joints to turn; :func:`gaps` is the corruption that takes one."""
    if isinstance(motion, MarkerSet):
        raise MocapError(f"{motion.name or 'markers'}: corrupt.{what} works on skeletal takes (joint rotations), not "
                         "marker captures; corrupt.gaps makes gaps in markers")


def joint_set(motion: Motion, joints, include_root: bool) -> np.ndarray:
    """Boolean (J,) selection: all joints but the root (unless ``include_root``), or exactly ``joints``."""
    J = motion.num_joints
    if joints is None:
        sel = np.ones(J, dtype=bool)
        sel[0] = include_root
        return sel
    if isinstance(joints, (str, int, np.integer)):
        joints = [joints]
    sel = np.zeros(J, dtype=bool)
    for j in joints:
        if isinstance(j, str):
            sel[motion.skeleton.index(j)] = True
        else:
            j = int(j)
            if not 0 <= j < J:
                raise ValueError(f"joint index {j} out of range for {J} joints")
            sel[j] = True
    return sel


def _changed(a: Motion, rot: np.ndarray, root: np.ndarray | None = None) -> np.ndarray:
    """(F, J) mask of cells whose rotation (root: or position) differs from ``a``'s; NaN equals NaN."""
    ra = a.rotations
    diff = np.any(~((ra == rot) | (np.isnan(ra) & np.isnan(rot))), axis=-1)
    if root is not None:
        pa = a.root_positions
        diff[:, 0] |= np.any(~((pa == root) | (np.isnan(pa) & np.isnan(root))), axis=-1)
    return diff


def _same_hemisphere(q: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``q`` with signs flipped where it lies opposite ``ref`` (same rotations, no sign jumps)."""
    dot = np.sum(q * ref, axis=-1, keepdims=True)
    return np.where(dot < 0.0, -q, q)


def _rotation_columns(motion: Motion, sel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns of ``channel_values`` that are rotations of selected joints, and the joint owning each."""
    sk = motion.skeleton
    cols, owner, c = [], [], 0
    for j in range(sk.num_joints):
        for ch in sk.joint_channels(j):
            if ch.endswith("rotation") and sel[j]:
                cols.append(c)
                owner.append(j)
            c += 1
    return np.array(cols, dtype=np.int64), np.array(owner, dtype=np.int64)


def channel_spread(values: np.ndarray) -> np.ndarray:
    """Std (C,) in degrees of each Euler channel of ``values`` (F, C) as motion, reading angles on the circle.

    A channel wraps when two of its successive values (NaN skipped) differ by more than 180 deg:
    no joint turns that far in one frame, so the channel crossed +-180 (a Bandai Namco thigh:
    -175 -> 180 -> -179 -> 179). Its spread is the std of its values' deviations from their circular
    mean, each taken the short way round: the few degrees the joint moves, not the ~170 deg the raw
    values show. Unwrapping instead would count the turns of a channel that spins through a gimbal
    lock (hundreds of degrees); the circular deviations stay within +-180. A channel that never
    wraps gets the plain ``nanstd`` of its raw values, bit for bit: the noise Mall et al. 2017
    (section 4) define, unchanged for channels that do not cross +-180. NaN is ignored; a channel
    with no value has spread 0.
    """
    values = np.asarray(values, dtype=np.float64)
    if not values.size:
        return np.zeros(values.shape[1] if values.ndim == 2 else 0)
    with warnings.catch_warnings(), np.errstate(invalid="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN channel: its spread is 0 below
        spread = np.nanstd(values, axis=0)
        span = np.nanmax(values, axis=0) - np.nanmin(values, axis=0)
        for c in np.flatnonzero(span > 180.0):  # only a channel spanning more than 180 deg can jump by as much
            x = values[~np.isnan(values[:, c]), c]
            if not np.any(np.abs(np.diff(x)) > 180.0):
                continue
            rad = np.deg2rad(x)
            centre = np.rad2deg(np.arctan2(np.mean(np.sin(rad)), np.mean(np.cos(rad))))
            spread[c] = np.std((x - centre + 180.0) % 360.0 - 180.0)
    return np.nan_to_num(spread)


def _channel_std(motion: Motion, cols: np.ndarray, owner: np.ndarray) -> np.ndarray:
    """Noise scale (degrees) of the rotation channels ``cols`` of ``motion``, owned by joints ``owner``.

    Each channel's spread (:func:`channel_spread`), at most its joint's rotation spread
    (:func:`mocapkit.joint_spread.noise_spread`): a channel near gimbal lock, whose values swing far more
    than its joint turns, gets noise the size of the joint's motion, not of the Euler singularity's.
    """
    return noise_spread(channel_spread(motion.channel_values()[:, cols]), owner, joint_rotation_spread(motion.rotations))


def _add_to_channels(motion: Motion, noise: np.ndarray, sel: np.ndarray) -> tuple[Motion, np.ndarray]:
    """Add (F, C_sel) ``noise`` to the selected joints' rotation channels; other cells stay bit-identical."""
    cols, owner = _rotation_columns(motion, sel)
    values = motion.channel_values()
    values[:, cols] += noise
    new = Motion.from_channel_values(
        motion.skeleton, values, motion.fps, motion.name, animated_offsets=motion.translations is not None
    )
    # A (frame, joint) cell is touched when any of its channels got a non-zero value.
    touched = np.zeros((motion.num_frames, motion.num_joints), dtype=bool)
    for k, j in enumerate(owner):
        touched[:, j] |= noise[:, k] != 0.0
    rot = np.where(touched[..., None], _same_hemisphere(new.rotations, motion.rotations), motion.rotations)
    out = dataclasses.replace(motion, rotations=rot)
    return out, _changed(motion, rot)


def _dof_frame(sk, j: int, q: np.ndarray, inverse: bool = False) -> np.ndarray:
    """Express local rotations of joint ``j`` in its channel (ASF ``axis``) frame, or back with ``inverse``."""
    if sk.axes is None:
        return q
    c = sk.axes[j]
    if inverse:
        return R.quaternion_multiply(R.quaternion_multiply(c, q), R.quaternion_conjugate(c))
    return R.quaternion_multiply(R.quaternion_multiply(R.quaternion_conjugate(c), q), c)


def _offset_channel(sk, j: int, q: np.ndarray, channel: int, delta_deg: np.ndarray) -> np.ndarray:
    """Rotations (n, 4) of joint ``j`` with ``delta_deg`` (n,) added to its ``channel``-th rotation channel.

    Adding an angle to one Euler channel is a rotation by exactly that angle
    (it composes with an elementary rotation at its place in the product), so
    the geodesic change equals ``|delta|`` (mod 360).
    """
    order = sk.rotation_order(j)
    ang = R.quaternion_to_euler(_dof_frame(sk, j, q), order)
    ang[:, channel] += delta_deg
    return _same_hemisphere(_dof_frame(sk, j, R.euler_to_quaternion(ang, order), inverse=True), q)


def project_to_dofs(sk, j: int, q: np.ndarray) -> np.ndarray:
    """Nearest rotation (by Euler projection) the joint's channels can hold; 3-DOF joints unchanged."""
    order = sk.rotation_order(j)
    if len(order) >= 3:
        return q
    ang = R.quaternion_to_euler(_dof_frame(sk, j, q), order)
    return _dof_frame(sk, j, R.euler_to_quaternion(ang, order), inverse=True)


# -- noise (Mall et al. 2017, section 4) ---------------------------------------------


def angular_noise(motion: Motion, amount: float = 0.5, seed=None, joints=None, include_root: bool = False):
    """Gaussian noise on every joint-angle channel, std = ``amount`` x that channel's std (Mall 4).

    0.5 is Mall et al.'s default "0.5 noise" (6 dB SNR); they also use 0.1
    (20 dB) and 0.9 (1 dB). The noise is added to the file's rotation channels
    in degrees (``channel_values`` -> add -> ``from_channel_values``); a
    channel's std is its spread over the clip read on the circle
    (:func:`channel_spread`: a channel crossing +-180 deg has the spread of
    its motion, one that never wraps its plain std). The root trajectory
    is kept clean, as in the paper, and the root rotation too unless
    ``include_root`` (or ``joints`` names the root). Joints without rotation
    channels are never changed.

    Returns ``(motion, mask)``.
    """
    skeletal(motion, "angular_noise")
    rng = _rng(seed)
    sel = joint_set(motion, joints, include_root)
    cols, owner = _rotation_columns(motion, sel)
    std = _channel_std(motion, cols, owner)
    noise = rng.normal(size=(motion.num_frames, len(cols))) * (amount * std)
    return _add_to_channels(motion, noise, sel)


def uniform_noise(motion: Motion, amount: float = 0.5, seed=None, joints=None, include_root: bool = False):
    """Zero-mean uniform noise with the std of :func:`angular_noise` (``amount`` x channel std).

    Each sample is uniform on ``[-w, w]`` with ``w = sqrt(3) * amount * std``
    (Mall 4.1, "uniform noise"). Returns ``(motion, mask)``.
    """
    skeletal(motion, "uniform_noise")
    rng = _rng(seed)
    sel = joint_set(motion, joints, include_root)
    cols, owner = _rotation_columns(motion, sel)
    half_width = np.sqrt(3.0) * amount * _channel_std(motion, cols, owner)
    noise = rng.uniform(-1.0, 1.0, size=(motion.num_frames, len(cols))) * half_width
    return _add_to_channels(motion, noise, sel)


def bias(
    motion: Motion,
    amount: float = 0.5,
    kind: str = "constant",
    period_s: float = 2.0,
    seed=None,
    joints=None,
    include_root: bool = False,
    noise: float = 0.0,
):
    """Non-zero-mean noise (Mall 4.1): a per-channel offset of ``amount`` x channel std.

    ``kind="constant"`` adds a constant of random sign to each channel;
    ``"sinusoidal"`` a sine of that amplitude with period ``period_s`` seconds
    and a random phase per channel. ``noise`` adds Gaussian noise of
    ``noise`` x channel std on top (Mall test "0.5 noise plus a bias" with
    ``noise=0.5``). Returns ``(motion, mask)``.
    """
    skeletal(motion, "bias")
    if kind not in ("constant", "sinusoidal"):
        raise ValueError(f"bias kind must be 'constant' or 'sinusoidal', got {kind!r}")
    if not period_s > 0:
        raise ValueError(f"period_s must be positive, got {period_s!r}")
    rng = _rng(seed)
    sel = joint_set(motion, joints, include_root)
    cols, owner = _rotation_columns(motion, sel)
    std = _channel_std(motion, cols, owner)
    F = motion.num_frames
    amp = amount * std * rng.choice([-1.0, 1.0], size=len(cols))
    if kind == "constant":
        offset = np.broadcast_to(amp, (F, len(cols))).copy()
    else:
        t = np.arange(F)[:, None] / motion.fps
        phase = rng.uniform(0.0, 2.0 * np.pi, size=len(cols))
        offset = amp * np.sin(2.0 * np.pi * t / period_s + phase)
    if noise:
        offset = offset + rng.normal(size=(F, len(cols))) * (noise * std)
    return _add_to_channels(motion, offset, sel)


def spatial_noise(
    motion: Motion,
    std_cm: float = 0.5,
    end_effector_scale: float = 1.0,
    seed=None,
    amount: float | None = None,
    include_root: bool = False,
    scale_cm: float | None = None,
):
    """Gaussian noise on joint positions, turned back into rotations with bone lengths kept (Mall 4).

    Every joint and end site gets isotropic 3D Gaussian noise of ``std_cm``
    per axis (wrists and ankles ``end_effector_scale`` times more, Mall's
    "larger variance at wrist and ankle end effectors"); centimetres are
    converted with :func:`unit_scale_cm` unless ``scale_cm`` is given.
    ``amount`` is an alias of ``std_cm`` (the CLI's ``--amount``).

    The noisy positions are then fitted by rotations only, so bone lengths are
    exactly the skeleton's by construction (the output is still forward
    kinematics of the skeleton). Joints are visited in topological order;
    each joint's position is already fixed by its (re-fitted) parent, and its
    global rotation is changed by the smallest rotation that points its bones
    at the noisy positions of what hangs from it:

    - one child bone (joint or end site): the minimal-arc (swing) rotation
      taking the current bone direction to the direction of the noisy child;
    - several non-collinear child bones: the least-squares rotation (Kabsch)
      taking the current bone vectors to the vectors towards the noisy
      children; collinear ones (e.g. ASF clavicles and neck leaving the
      thorax along one line) are aimed as one by the swing of their mean.

    Zero-length bones are skipped (they cannot be aimed). A joint whose file
    channels have fewer than three rotation DOFs (ASF) gets the nearest
    rotation those channels can hold, and one without rotation channels is
    left alone; the next joints aim from where their parent really is, so the
    projection does not accumulate. The root position is never changed and
    the root rotation only with ``include_root``. A joint whose parent chain
    is missing (NaN) keeps its rotation.

    Returns ``(motion, mask)``.
    """
    skeletal(motion, "spatial_noise")
    if amount is not None:
        std_cm = amount
    if std_cm < 0 or end_effector_scale < 0:
        raise ValueError("std_cm and end_effector_scale must be non-negative")
    rng = _rng(seed)
    sk = motion.skeleton
    F, J, E = motion.num_frames, sk.num_joints, sk.num_end_sites
    scale = unit_scale_cm(sk) if scale_cm is None else float(scale_cm)
    grot, gpos = motion.global_transforms()
    end_pos = motion.end_sites_from(grot, gpos)
    sigma = np.full(J + E, std_cm / scale)
    for role in ("left_hand", "right_hand", "left_foot", "right_foot"):
        try:
            sigma[find_joint(sk, role)] *= end_effector_scale
        except KeyError:
            pass
    noise = rng.normal(size=(F, J + E, 3)) * sigma[None, :, None]
    target = np.concatenate([gpos, end_pos], axis=1) + noise
    offsets = motion.local_offsets()

    # What hangs from each joint: (index into target, offset (F, 3)) for child joints and end sites.
    hanging: list[list[tuple[int, np.ndarray]]] = [[] for _ in range(J)]
    for c in range(1, J):
        if np.linalg.norm(sk.offsets[c]) > 1e-9:
            hanging[int(sk.parents[c])].append((c, offsets[:, c]))
    for e, p in enumerate(sk.end_site_parents):
        if np.linalg.norm(sk.end_site_offsets[e]) > 1e-9:
            hanging[int(p)].append((J + e, np.broadcast_to(sk.end_site_offsets[e], (F, 3))))

    local = np.array(motion.rotations)
    new_grot = np.empty_like(grot)
    new_pos = np.empty_like(gpos)
    for j in range(J):
        p = int(sk.parents[j])
        if j == 0:
            parent_rot = R.identity((F,))
            pos = gpos[:, 0]
        else:
            parent_rot = new_grot[:, p]
            pos = new_pos[:, p] + R.quaternion_rotate(parent_rot, offsets[:, j])
        g = R.quaternion_multiply(parent_rot, local[:, j])
        kids = hanging[j]
        if kids and (j > 0 or include_root) and sk.rotation_order(j):
            cur = np.stack([R.quaternion_rotate(g, off) for _, off in kids], axis=1)  # (F, k, 3)
            want = np.stack([target[:, t] for t, _ in kids], axis=1) - pos[:, None]
            fix = _aim(cur, want, np.stack(_rest_offsets(sk, kids)))
            g_new = R.quaternion_multiply(fix, g)
            l_new = R.quaternion_multiply(R.quaternion_conjugate(parent_rot), g_new)
            l_new = _same_hemisphere(R.quaternion_normalize(project_to_dofs(sk, j, l_new)), local[:, j])
            ok = np.all(np.isfinite(l_new), axis=-1)
            local[ok, j] = l_new[ok]
            g = R.quaternion_multiply(parent_rot, local[:, j])
        new_grot[:, j] = g
        new_pos[:, j] = pos
    out = dataclasses.replace(motion, rotations=local)
    return out, _changed(motion, local)


def _rest_offsets(sk, kids) -> list[np.ndarray]:
    J = sk.num_joints
    return [sk.offsets[t] if t < J else sk.end_site_offsets[t - J] for t, _ in kids]


def _aim(cur: np.ndarray, want: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """Global rotations (F, 4) taking bone vectors ``cur`` (F, k, 3) towards ``want`` (F, k, 3).

    One bone or collinear rest bones (``rest`` (k, 3)): minimal-arc swing of the
    mean direction; otherwise the Kabsch least-squares rotation.
    """
    unit = rest / np.linalg.norm(rest, axis=1, keepdims=True)
    k = len(rest)
    collinear = k == 1 or np.max(np.linalg.norm(np.cross(unit[:, None], unit[None, :]), axis=-1)) < 0.1
    if collinear:
        sign = np.sign(unit @ unit[0])  # anti-parallel bones count with their direction reversed
        a = np.sum(cur * sign[None, :, None], axis=1)
        b = np.sum(want / np.linalg.norm(want, axis=-1, keepdims=True)
                   * np.linalg.norm(cur, axis=-1, keepdims=True) * sign[None, :, None], axis=1)
        out = R.shortest_arc(a, b)
        out[~(np.isfinite(a).all(axis=-1) & np.isfinite(b).all(axis=-1))] = np.nan  # a missing bone: no rotation
        return out
    good = np.all(np.isfinite(cur), axis=(1, 2)) & np.all(np.isfinite(want), axis=(1, 2))
    out = np.full((cur.shape[0], 4), np.nan)
    if np.any(good):
        out[good] = R.matrix_to_quaternion(R.kabsch(cur[good], want[good]))
    return out


# -- gaps (Mall et al. 2017, section 4) -------------------------------------------


def gaps(
    motion: Motion,
    start_prob: float | None = None,
    mean_length_s: float = 0.25,
    max_length_s: float = 2.0,
    seed=None,
    joints=None,
    long: bool = False,
):
    """Runs of missing data (NaN) per joint with exponentially decaying lengths (Mall 4).

    Gaps are per joint: a gapped joint's whole rotation (all four components)
    is NaN, which is what :meth:`Motion.missing` reports. Each selected joint
    is an independent renewal process along the frames: every observed frame
    starts a gap with probability ``start_prob``, except the frame right
    after a gap, which is always observed so that two gaps never merge into
    one run (observed stretches between gaps are thus 1 + geometric).

    Gap lengths in frames are geometric (the discrete exponential: each
    longer length is less likely by a constant factor) with mean
    ``mean_length_s * fps`` frames, at least one frame and clipped at
    ``max_length_s``. With ``long=True`` lengths are uniform in 1-5 s
    instead, Mall's long-gap test for the EBD (up to 600 frames at 120 fps).
    A gap that would run past the last frame is cut there.

    ``start_prob`` defaults to ``0.1 / fps`` (on average one gap start per
    joint per 10 s of observed motion), ``0.02 / fps`` with ``long``. Mall et
    al. quote "a 10% probability of starting a gap in a specific joint
    channel at a specific frame" but also note that under their model very
    few channels are missing at the same time, which a literal 10% per frame
    (about three quarters of every channel missing with 0.25 s gaps) would
    contradict; the default keeps about 2.5% of each joint missing. Pass
    ``start_prob=0.1`` for the literal reading.

    The root is not gapped unless ``joints`` names it; a gapped root loses its
    position too. A joint the file gives no rotation channel (an ASF bone with
    no dof, such as CMU's and HDM05's ``lhipjoint``) is not gapped unless
    ``joints`` names it: no capture loses what it never records, and a fill
    there would be a change to a bone nothing can move. The mask is the cells
    that became missing (cells already NaN in the input are not "changed").

    A :class:`~mocapkit.markerset.MarkerSet` gets the same runs per marker (positions NaN, residual -1: what
    ``clean`` fills): every marker but the modelled points and the unlabelled trajectories
    (:meth:`~mocapkit.markerset.MarkerSet.modelled`, ``unlabelled``: cleaning leaves them alone) unless
    ``joints`` names markers by label or index; the mask is (F, M).

    Returns ``(motion, mask)``.
    """
    fps = motion.fps
    if start_prob is None:
        start_prob = (0.02 if long else 0.1) / fps
    if not 0.0 <= start_prob <= 1.0:
        raise ValueError(f"start_prob must be a probability in [0, 1], got {start_prob!r}")
    if not long and not (mean_length_s > 0 and max_length_s > 0):
        raise ValueError("mean_length_s and max_length_s must be positive")
    rng = _rng(seed)
    runs = _gap_runs(rng, motion.num_frames, fps, start_prob, mean_length_s, max_length_s, long)
    if isinstance(motion, MarkerSet):
        return _marker_gaps(motion, joints, runs)
    sel = joint_set(motion, joints, include_root=False)
    # only joints the file animates lose samples; the others still draw theirs, so a seed gaps the rest alike
    keep = sel & (joints is not None or np.array([bool(motion.skeleton.rotation_order(j))
                                                   for j in range(motion.num_joints)]))
    rot = np.array(motion.rotations)
    root = np.array(motion.root_positions)
    for j in np.flatnonzero(sel):
        for f, n in runs():
            if keep[j]:
                rot[f : f + n, j] = np.nan
            if j == 0:
                root[f : f + n] = np.nan
    out = dataclasses.replace(motion, rotations=rot, root_positions=root)
    return out, _changed(motion, rot, root)


def _gap_runs(rng, F: int, fps: float, start_prob: float, mean_length_s: float, max_length_s: float, long: bool):
    """A function giving, on each call, one column's gaps of :func:`gaps` as ``(first frame, length)`` pairs,
    drawn from ``rng`` (none when ``start_prob`` is 0)."""
    mean_frames = max(mean_length_s * fps, 1.0)
    max_frames = max(int(round(max_length_s * fps)), 1)
    long_lo, long_hi = max(int(round(1.0 * fps)), 1), max(int(round(5.0 * fps)), 1)

    def runs():
        if start_prob <= 0.0:
            return
        f = int(rng.geometric(start_prob)) - 1  # observed frames before the first gap
        while f < F:
            if long:
                n = int(rng.integers(long_lo, long_hi + 1))
            else:
                n = min(int(rng.geometric(1.0 / mean_frames)), max_frames)
            yield f, n
            f += n + int(rng.geometric(start_prob))  # >= 1 observed frame in between

    return runs


def _marker_gaps(markers: MarkerSet, labels, runs) -> tuple[MarkerSet, np.ndarray]:
    """:func:`gaps` of a marker capture: ``runs`` (:func:`_gap_runs`) for each marker chosen (``labels``: names or
    indexes; None: the markers cleaning fills), its positions NaN there. Returns ``(markers, (F, M) mask)``."""
    if labels is None:
        sel = ~(markers.modelled() | markers.unlabelled())
    else:
        sel = np.zeros(markers.num_markers, dtype=bool)
        for k in [labels] if isinstance(labels, (str, int, np.integer)) else labels:
            if isinstance(k, str) and k not in markers.labels:
                raise MocapError(f"{markers.name or 'markers'}: no marker {k!r}")
            sel[markers.labels.index(k) if isinstance(k, str) else int(k)] = True
    pos = np.array(markers.positions)
    for m in np.flatnonzero(sel):
        for f, n in runs():
            pos[f : f + n, m] = np.nan
    out = markers.with_positions(pos)
    return out, out.missing() & ~markers.missing()


# -- real errors (Aristidou et al. 2018, section 6) ---------------------------------


@dataclass(frozen=True)
class ErrorRecord:
    """One injected error: its kind, joint name and frame range ``[start, end)``.

    ``end`` is exclusive, the first frame after the error, as in Python's slices: ``start 89, end 120`` is
    the summary's inclusive "frames 89-119" (0-based take indexes, as everywhere in mocapkit).

    For a ``swap`` there is one record per joint of the pair, each naming the
    other as ``partner``.
    """

    kind: str
    joint: str
    start: int
    end: int
    partner: str | None = None


def describe_error(record, original: Motion, corrupted: Motion) -> str:
    """One plain line for an injected error, as a user reads it: what, which joint, which frames, how large.

    ``record``: an :class:`ErrorRecord` (or its dict, as a ``.mask.npz`` keeps it); ``original``, ``corrupted``:
    the take before and after. The size is the largest rotation, in degrees, between the joint's rotation in the
    two takes over the error's frames (NaN-free frames only). E.g. ``swap: LeftShoulder with RightShoulder,
    frames 673-728 (56 frames, 0.47 s), turned by up to 34.2 deg``.
    """
    r = record if isinstance(record, dict) else dataclasses.asdict(record)
    start, end = int(r["start"]), int(r["end"])
    n = end - start
    what = f"{r['kind']}: {r['joint']}" + (f" with {r['partner']}" if r.get("partner") else "")
    frames = frame_span(start, end - 1)
    line = f"{what}, {frames} ({n} frame{'s' if n != 1 else ''}, {n / original.fps:.2f} s)"
    j = original.skeleton.index(r["joint"])
    a, b = original.rotations[start:end, j], corrupted.rotations[start:end, j]
    ok = np.isfinite(a).all(axis=-1) & np.isfinite(b).all(axis=-1)
    if ok.any():
        line += f", turned by up to {np.degrees(R.geodesic_angle(a[ok], b[ok])).max():.1f} deg"
    return line


def describe_errors(records, original: Motion, corrupted: Motion) -> list[str]:
    """One line per injected error (:func:`describe_error`), in the records' order.

    A swap is one error kept as two records, one per joint of the pair, each
    naming the other (what a mask and ``clean --reference`` score per joint);
    it reads as one line, its first record's (``swap: UpperLeg_L with
    UpperLeg_R``), so the lines count the errors injected.
    """
    lines, paired = [], set()
    for record in records:
        r = record if isinstance(record, dict) else dataclasses.asdict(record)
        key = (r["kind"], r["joint"], r.get("partner"), int(r["start"]), int(r["end"]))
        if r.get("partner") and key in paired:
            paired.discard(key)
            continue
        if r.get("partner"):
            paired.add((r["kind"], r["partner"], r["joint"], int(r["start"]), int(r["end"])))
        lines.append(describe_error(r, original, corrupted))
    return lines


def _error_setup(motion: Motion, joints, duration_s, seed):
    """What :func:`real_errors` and :func:`smooth_drifts` start from: the checked error lengths, the generator,
    the skeleton, (F, J), the selected joints (J,) bool and the joints with rotation channels (J,) bool."""
    if not 0 < duration_s[0] <= duration_s[1]:
        raise ValueError(f"duration_s must be (min, max) seconds with 0 < min <= max, got {duration_s!r}")
    sk = motion.skeleton
    sel = joint_set(motion, joints, include_root=False)
    has_dofs = np.array([bool(sk.rotation_order(j)) for j in range(sk.num_joints)])
    return _rng(seed), sk, motion.num_frames, sk.num_joints, sel, has_dofs


def real_errors(
    motion: Motion,
    kinds=ERROR_KINDS,
    n_errors: int = 4,
    duration_s: tuple[float, float] = (0.1, 0.6),
    seed=None,
    joints=None,
    min_angle_deg: float = 15.0,
):
    """Inject the errors a real capture shows (Aristidou 6) on a few joints in short windows.

    Kinds (each changes the local rotation of one joint, or of a left/right
    pair, in a window of ``duration_s`` seconds; spikes last 1-3 frames):

    - ``spike``: one rotation channel jumps by 30-90 deg (random sign);
    - ``flip``: the joint turned 180 deg about its bone (the direction to its
      longest child bone), as when a solver flips a limb's twist; a joint with
      fewer than 3 rotation DOFs (ASF) turns 180 deg about one of its DOF axes;
    - ``freeze``: the joint holds its value from the frame before the window;
      windows are chosen where the joint moves by at least ``min_angle_deg``
      from that value, but frames early in the window may differ little;
    - ``drift``: one rotation channel drifts away linearly, from
      ``min_angle_deg`` at the window's first frame to 25-40 deg at its last
      (a step off the path, then a ramp: the break rules find it; a window of
      ``duration_s``, which may be shorter than the 0.15 s the smooth-drift
      rule, ``SSAParams.drift_min_s``, asks of a drift with no step: such a
      drift is :func:`smooth_drifts`');
    - ``swap``: a joint and its left/right partner (:func:`mirror_pairs`) take
      each other's mirrored rotations (the take's mirror image on its own
      skeleton, :func:`mocapkit.mirroring.mirror_for_rig`), as when marker
      labels swap sides; the
      window is chosen where the two sides differ by ``min_angle_deg`` at
      every frame.

    So every changed cell of a spike, flip, drift or swap is at least
    ``min_angle_deg`` away (geodesic) from the input. Spike and drift are made
    on the file's channels (a single Euler channel offset is a rotation of
    exactly that angle), so they stay within an ASF joint's DOFs.

    Errors never overlap or touch (one clean frame at least between two
    errors on the same joint), only joints with rotation channels that move
    a bone get them (never the root unless ``joints`` names it), and windows
    avoid missing frames. The first ``len(kinds)`` errors use each kind once,
    in random order; later ones draw kinds at random. An error that cannot be
    placed (a clip too short, no mirror pairs, a joint that never moves for a
    freeze) is skipped: the records are the authority.

    Returns ``(motion, mask, records)``: records are :class:`ErrorRecord` sorted
    by start frame; ``mask`` is True on exactly the cells whose rotation changed
    (all of each record's window except, for a freeze, frames where the joint
    happens to sit at the held value).
    """
    skeletal(motion, "real_errors")
    kinds = tuple(kinds)
    bad = [k for k in kinds if k not in ERROR_KINDS]
    if bad or not kinds:
        raise ValueError(f"unknown error kind(s) {bad or kinds!r}; kinds are {', '.join(ERROR_KINDS)}")
    rng, sk, F, J, sel, has_dofs = _error_setup(motion, joints, duration_s, seed)
    moves_bone = bone_moving_joints(sk)
    candidates = np.flatnonzero(sel & has_dofs & moves_bone)
    if len(candidates) == 0:
        candidates = np.flatnonzero(sel & has_dofs)
    if len(candidates) == 0:
        raise ValueError("no selected joint has rotation channels to carry an error")
    perm = mirror_pairs(sk.joint_names)
    pairs = [j for j in candidates if perm[j] != j and sel[perm[j]] and has_dofs[perm[j]]]
    src = motion.rotations
    finite = np.all(np.isfinite(src), axis=-1)
    rot = np.array(src)
    busy = np.zeros((F, J), dtype=bool)  # cells taken by an error, dilated by one frame
    thresh = np.radians(min_angle_deg)
    mirrored = None
    records: list[ErrorRecord] = []

    def free(s, e, j):
        return not busy[max(s - 1, 0) : e + 1, j].any() and finite[max(s - 1, 0) : e, j].all()

    def free_frames(j):
        """(F,) frames f for which ``free(f, f + 1, j)`` holds, vectorised."""
        b = busy[:, j]
        near = b.copy()
        near[1:] |= b[:-1]
        near[:-1] |= b[1:]
        fin = finite[:, j].copy()
        fin[1:] &= finite[:-1, j]
        return ~near & fin

    def window(n):
        n = int(np.clip(n, 1, max(F - 1, 1)))
        s = int(rng.integers(1, max(F - n, 1) + 1)) if F > 1 else 0
        return s, min(s + n, F)

    sequence = [kinds[int(i)] for i in rng.permutation(len(kinds))]
    sequence += [kinds[int(i)] for i in rng.integers(len(kinds), size=n_errors)]
    for kind in sequence[:n_errors]:
        for _attempt in range(100):
            if kind == "spike":
                n = int(rng.integers(1, 4))
            else:
                n = max(int(round(rng.uniform(*duration_s) * motion.fps)), 2)
            s, e = window(n)
            if kind == "swap":
                if not pairs:
                    break
                j = int(rng.choice(pairs))
                k = int(perm[j])
                if mirrored is None:
                    try:
                        mirrored = mirror_for_rig(motion).rotations
                    except SkeletonError:
                        pairs = []
                        break
                # frames where both sides differ visibly from their mirrored partner, and are free
                vis = (R.geodesic_angle(src[:, j], mirrored[:, j]) >= thresh) & (
                    R.geodesic_angle(src[:, k], mirrored[:, k]) >= thresh
                )
                ok = vis & free_frames(j) & free_frames(k)
                starts, length = _run_starts(ok, e - s)
                if len(starts) == 0:
                    continue
                s = int(rng.choice(starts))
                e = s + length
                for a in (j, k):
                    rot[s:e, a] = _same_hemisphere(mirrored[s:e, a], src[s:e, a])
                    busy[s:e, a] = True
                records.append(ErrorRecord("swap", sk.joint_names[j], s, e, sk.joint_names[k]))
                records.append(ErrorRecord("swap", sk.joint_names[k], s, e, sk.joint_names[j]))
                break
            j = int(rng.choice(candidates))
            if not free(s, e, j):
                continue
            q = src[s:e, j]
            order = sk.rotation_order(j)
            if kind == "spike":
                delta = rng.uniform(30.0, 90.0) * rng.choice([-1.0, 1.0])
                new = _offset_channel(sk, j, q, int(rng.integers(len(order))), np.full(e - s, delta))
            elif kind == "drift":
                peak = max(rng.uniform(25.0, 40.0), min_angle_deg)
                ramp = np.linspace(min_angle_deg, peak, e - s) * rng.choice([-1.0, 1.0])
                new = _offset_channel(sk, j, q, int(rng.integers(len(order))), ramp)
            elif kind == "flip":
                if len(order) >= 3:
                    axis = _bone_axis(sk, j)
                    new = R.quaternion_multiply(q, R.quaternion_from_axis_angle(axis, np.pi))
                    new = _same_hemisphere(new, q)
                else:
                    new = _offset_channel(sk, j, q, int(rng.integers(len(order))), np.full(e - s, 180.0))
            else:  # freeze
                held = src[s - 1, j] if s > 0 else src[s, j]
                if np.max(R.geodesic_angle(q, held)) < thresh:
                    continue
                new = _same_hemisphere(np.broadcast_to(held, q.shape), q)
            if kind != "freeze" and np.min(R.geodesic_angle(q, new)) < thresh - 1e-9:
                continue  # an Euler projection ate part of the error (joint outside its DOFs): try again
            rot[s:e, j] = new
            busy[s:e, j] = True
            records.append(ErrorRecord(kind, sk.joint_names[j], s, e))
            break
    out = dataclasses.replace(motion, rotations=rot)
    records.sort(key=lambda r: (r.start, r.joint))
    return out, _changed(motion, rot), records


def smooth_drifts(
    motion: Motion,
    n_drifts: int = 2,
    peak_deg: float = 35.0,
    duration_s: tuple[float, float] = (1.0, 2.0),
    seed=None,
    joints=None,
):
    """Smooth there-and-back drifts: one rotation channel leaves its path and comes back with no step anywhere.

    Each drift adds a raised cosine ``peak_deg * (1 - cos(2 pi t / T)) / 2``
    to one rotation channel of one joint over a window of ``T`` seconds drawn
    from ``duration_s`` (so the joint is ``peak_deg`` away at the window's
    middle, after ``T / 2`` of smooth travel, and back at its end), with a
    random sign and channel. The added angle is 0 at both ends and its rate
    at most ``pi * peak_deg / T`` deg/s, so no frame-to-frame step shows it:
    what a slipping marker cluster or a drifting inertial sensor does, and what
    the self-similarity analysis exists to see (Aristidou et al. 2018,
    section 3.4). Unlike :func:`real_errors`' ``drift`` (a linear ramp that
    starts at ``min_angle_deg`` and ends in a step) the changed cells start
    and end near 0 deg, so a score counts only the visible ones.

    ``joints``: names or indices that may carry a drift (default: every joint
    with rotation channels that moves a bone, never the root). Drifts never
    overlap or touch on one joint, and windows avoid missing frames. Returns
    ``(motion, mask, records)`` as :func:`real_errors` does, with kind
    ``"smooth_drift"``; ``mask`` is True on the cells whose rotation changed.
    """
    skeletal(motion, "smooth_drifts")
    if not (np.isfinite(peak_deg) and 0 < peak_deg < 180):
        raise ValueError(f"peak_deg must be in (0, 180) degrees, got {peak_deg!r}")
    rng, sk, F, J, sel, has_dofs = _error_setup(motion, joints, duration_s, seed)
    candidates = np.flatnonzero(sel & has_dofs & bone_moving_joints(sk))
    if len(candidates) == 0:
        raise ValueError("no selected joint has rotation channels that move a bone")
    src = motion.rotations
    finite = np.all(np.isfinite(src), axis=-1)
    rot = np.array(src)
    busy = np.zeros((F, J), dtype=bool)
    records: list[ErrorRecord] = []
    for _ in range(int(n_drifts)):
        for _attempt in range(100):
            n = max(int(round(rng.uniform(*duration_s) * motion.fps)), 3)
            if n + 2 > F:
                break
            s = int(rng.integers(1, F - n))
            e = s + n
            j = int(rng.choice(candidates))
            if busy[max(s - 1, 0) : e + 1, j].any() or not finite[s:e, j].all():
                continue
            t = (np.arange(n) + 0.5) / n
            delta = peak_deg * 0.5 * (1.0 - np.cos(2.0 * np.pi * t)) * rng.choice([-1.0, 1.0])
            order = sk.rotation_order(j)
            rot[s:e, j] = _offset_channel(sk, j, src[s:e, j], int(rng.integers(len(order))), delta)
            busy[s:e, j] = True
            records.append(ErrorRecord("smooth_drift", sk.joint_names[j], s, e))
            break
    out = dataclasses.replace(motion, rotations=rot)
    records.sort(key=lambda r: (r.start, r.joint))
    return out, _changed(motion, rot), records


def _run_starts(ok: np.ndarray, n: int) -> tuple[np.ndarray, int]:
    """Start frames of windows where ``ok`` holds throughout, and their length.

    The length is ``n`` if such windows exist, else ``n`` halved until some do
    (down to 1 frame); no start comes back when ``ok`` is nowhere true.
    """
    n = max(int(n), 1)
    c = np.concatenate([[0], np.cumsum(ok.astype(np.int64))])
    while n >= 1:
        starts = np.flatnonzero(c[n:] - c[:-n] == n) if n <= len(ok) else np.zeros(0, dtype=np.int64)
        if len(starts):
            return starts, n
        n //= 2
    return np.zeros(0, dtype=np.int64), 0


def _bone_axis(sk, j: int) -> np.ndarray:
    """Direction (in joint j's frame) of j's longest child bone (joint or end site)."""
    offs = [sk.offsets[c] for c in sk.children(j)]
    offs += [sk.end_site_offsets[e] for e in np.flatnonzero(sk.end_site_parents == j)]
    if offs:
        best = max(offs, key=lambda o: float(np.linalg.norm(o)))
        if np.linalg.norm(best) > 1e-9:
            return best / np.linalg.norm(best)
    return np.array([0.0, 1.0, 0.0])


# -- one entry point -----------------------------------------------------------------


def corrupt(motion: Motion, kind: str = "noise", seed=None, **params):
    """Dispatch by name (the CLI's ``--kind``).

    ``kind`` is one of :data:`KINDS` (noise, uniform, bias, spatial, gaps,
    errors) or one error kind of :data:`ERROR_KINDS` (spike, flip, ...), which
    runs :func:`real_errors` with only that kind. ``amount`` means the noise
    fraction for noise/uniform/bias, the std in cm for spatial, and is refused
    for gaps and errors. For ``bias`` pass ``bias_kind`` ("constant" or
    "sinusoidal") since ``kind`` is taken.

    Returns ``(motion, mask)`` or, for errors, ``(motion, mask, records)``.
    """
    table = {
        "noise": angular_noise,
        "uniform": uniform_noise,
        "bias": bias,
        "spatial": spatial_noise,
        "gaps": gaps,
        "errors": real_errors,
    }
    if kind in ERROR_KINDS:
        params = {**params, "kinds": (kind,)}
        func = real_errors
    elif kind in table:
        func = table[kind]
    else:
        raise ValueError(f"unknown corruption kind {kind!r}; kinds are: {', '.join(KINDS + ERROR_KINDS)}")
    if func in (gaps, real_errors) and "amount" in params:
        raise ValueError(f"amount= (--amount on the command line) does not apply to {kind}")
    if func is bias and "bias_kind" in params:
        params = dict(params)
        params["kind"] = params.pop("bias_kind")
    return func(motion, seed=seed, **params)
