"""What the deep cleaners see: a Motion as per-frame joint-angle channels plus the root's angular velocity.

Mall et al. 2017 (section 3) feed the networks "the vector of 126 joint
angles x(t) ... plus the 3 global angular velocities of the root node", the
latter "assumed to be clean and used only for disambiguation" (angular
velocities rather than angles, so a heading change does not matter). This
module turns a :class:`~mocapkit.motion.Motion` into those arrays and back:

- ``representation="euler"`` (the paper's setting and the shipped models'):
  the file's rotation channels of every non-root joint in degrees, as
  :meth:`Motion.channel_values` gives them (for ASF skeletons the AMC degrees
  of freedom), unwrapped along time so a +-180 wrap never looks like a jump;
- ``representation="rot6d"``: the continuous 6-D representation (the first two
  columns of each joint's local rotation matrix in its channel frame), which
  has no wrap-around or gimbal branches; decoded by Gram-Schmidt and projected
  back onto the joint's degrees of freedom.

Root channels are never part of the model's channels: the root trajectory and
rotation pass through unchanged, as in the paper ("we assume that the
trajectory of the root of the skeleton is clean").
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numba import njit

from ... import rotations as R
from ...errors import SkeletonError
from ...io.euler_branches import continuous_rotations, three_axis_groups
from ...motion import Motion

__all__ = ["ChannelLayout", "layout_for", "euler_columns", "euler_values", "root_angular_velocity", "encode", "decode", "unwrap_degrees", "wrap_degrees", "channel_joints", "lerp_fill", "with_measured"]

REPRESENTATIONS = ("euler", "rot6d")


@dataclass(frozen=True)
class ChannelLayout:
    """Which channels a model reads and writes.

    ``names``: the model's channel names (``"joint.Xrotation"`` for Euler,
    ``"joint.r6_k"`` for 6-D); ``joints``: joint names with rotation channels
    (root excluded), in file order; ``representation``: "euler" or "rot6d".
    """

    names: tuple[str, ...]
    joints: tuple[str, ...]
    representation: str = "euler"

    @property
    def num_channels(self) -> int:
        return len(self.names)

    def check(self, motion: Motion, what: str | None = None) -> None:
        """Raise :class:`SkeletonError` (one line, prefixed ``what: ``) when ``motion`` lacks the model's channels."""
        have = layout_for(motion, self.representation)
        if have.names != self.names:
            missing = [n for n in self.names if n not in set(have.names)]
            extra = [n for n in have.names if n not in set(self.names)]
            detail = f"missing {missing[:4]}" if missing else f"unexpected {extra[:4]}"
            counts = ("as many as this one has, but other ones" if have.num_channels == self.num_channels
                      else f"and this one has {have.num_channels}")
            raise SkeletonError(
                f"{what + ': ' if what else ''}the model was trained on a skeleton with {self.num_channels} "
                f"{self.representation} channels {counts} ({detail}); train a model on this rig with `mocapkit train`"
            )


def layout_for(motion_or_skeleton, representation: str = "euler") -> ChannelLayout:
    """The :class:`ChannelLayout` of a Motion's (or Skeleton's) non-root rotation channels."""
    if representation not in REPRESENTATIONS:
        raise ValueError(f"representation must be one of {REPRESENTATIONS}, got {representation!r}")
    sk = getattr(motion_or_skeleton, "skeleton", motion_or_skeleton)
    names, joints = [], []
    for j in range(1, sk.num_joints):
        rot = [c for c in sk.joint_channels(j) if c.endswith("rotation")]
        if not rot:
            continue
        joints.append(sk.joint_names[j])
        if representation == "euler":
            names += [f"{sk.joint_names[j]}.{c}" for c in rot]
        else:
            names += [f"{sk.joint_names[j]}.r6_{k}" for k in range(6)]
    return ChannelLayout(tuple(names), tuple(joints), representation)


def euler_columns(motion_or_skeleton) -> np.ndarray:
    """Columns of the file channels that are non-root rotations (the Euler model channels)."""
    sk = getattr(motion_or_skeleton, "skeleton", motion_or_skeleton)
    cols, c = [], 0
    for j in range(sk.num_joints):
        for ch in sk.joint_channels(j):
            if j > 0 and ch.endswith("rotation"):
                cols.append(c)
            c += 1
    return np.array(cols, dtype=np.int64)


UNWRAP_ALPHA = 0.25  # reference follows the signal with a time constant of ~4 frames


@njit(cache=True)
def _unwrap_kernel(x, alpha):
    F, C = x.shape
    out = np.empty_like(x)
    for c in range(C):
        r = np.nan
        for t in range(F):
            v = x[t, c]
            if np.isnan(v):
                out[t, c] = np.nan
                continue
            if np.isnan(r):
                r = v
            u = r + ((v - r + 180.0) % 360.0 - 180.0)
            out[t, c] = u
            r = r + alpha * (u - r)
    return out


def unwrap_degrees(values: np.ndarray, alpha: float = UNWRAP_ALPHA) -> np.ndarray:
    """Unwrap (F, C) angle channels along time against a causal running reference; NaN skipped.

    ``np.unwrap`` compares each sample with the previous one, so on noisy
    channels (0.9 noise on a channel of 100 deg std) a single noisy step of
    more than 180 deg adds a spurious turn that then persists. Here each
    sample is placed within +-180 of an exponential running mean of the
    unwrapped signal (``r += alpha (u - r)``): noise never accumulates turns,
    real wraps of a smooth channel are followed, and being causal it runs the
    same way in a stream (:class:`~mocapkit.cleaning.deep.Denoiser`).
    """
    x = np.ascontiguousarray(values, dtype=np.float64)
    if x.ndim != 2:
        raise ValueError(f"expected (F, C) channels, got shape {x.shape}")
    return _unwrap_kernel(x, float(alpha))


def wrap_degrees(d):
    """Angle differences wrapped to [-180, 180] (numpy arrays or torch tensors; the turn count has no gradient)."""
    if isinstance(d, np.ndarray) or np.isscalar(d):
        return d - 360.0 * np.round(np.asarray(d) / 360.0)
    return d - 360.0 * (d / 360.0).round().detach()


def _local_dof_rotations(motion: Motion, joint_ids: np.ndarray) -> np.ndarray:
    """(F, n, 4) local rotations of ``joint_ids`` in their channel frame (ASF ``axis`` removed)."""
    q = motion.rotations[:, joint_ids]
    axes = motion.skeleton.axes
    if axes is not None:
        c = axes[joint_ids][None]
        q = R.quaternion_multiply(R.quaternion_multiply(R.quaternion_conjugate(c), q), c)
    return q


def root_angular_velocity(root_rotations: np.ndarray, fps: float) -> np.ndarray:
    """(F, 3) angular velocity of the root in its own frame, rad/s (Mall's 3 context channels).

    omega_t = rotvec(q_{t-1}^-1 q_t) * fps, a backward difference so a
    streaming run needs no extra frame; omega_0 = 0. Body-frame, so a heading
    change leaves it unchanged. Missing root rotations give 0 (the context is
    only for disambiguation). ``root_rotations``: (F, 4) quaternions.
    """
    q = np.asarray(root_rotations, dtype=np.float64)
    w = np.zeros((len(q), 3))
    if len(q) > 1:
        rel = R.quaternion_multiply(R.quaternion_conjugate(q[:-1]), q[1:])
        w[1:] = R.quaternion_to_rotvec(rel) * fps
    return np.nan_to_num(w)


def encode(motion: Motion, layout: ChannelLayout) -> tuple[np.ndarray, np.ndarray]:
    """(values (F, C), context (F, 3)) for the model: channels in the layout's representation and root omega.

    Euler values are degrees, each joint's triple on the branch nearest its
    previous frame's (:func:`mocapkit.io.euler_branches.continuous_rotations`,
    the rule every writer of Euler text follows), then unwrapped along time.
    The plain conversion (:meth:`Motion.channel_values`) of a joint near gimbal
    lock flips to the other branch, ``(z + 180, 180 - x, y + 180)``, on every
    frame whose noise pushes the middle angle past +-90 deg (a Bandai Namco
    ``Hips`` in a heading turn): read as it is, a smoother averages the two
    branches into rotations the joint never had. 6-D values are matrix
    entries in [-1, 1]. Missing joints (NaN rotations) give NaN channels.
    """
    layout.check(motion)
    ctx = root_angular_velocity(motion.rotations[:, 0], motion.fps)
    if layout.representation == "euler":
        return euler_values(motion.channel_values(), motion.skeleton), ctx
    ids = np.array([motion.skeleton.index(n) for n in layout.joints], dtype=np.int64)
    m = R.quaternion_to_matrix(_local_dof_rotations(motion, ids))  # (F, n, 3, 3)
    vals = np.concatenate([m[..., :, 0], m[..., :, 1]], axis=-1)  # (F, n, 6)
    return vals.reshape(len(vals), -1), ctx


def euler_values(rows: np.ndarray, skeleton) -> np.ndarray:
    """(F, C) the Euler model channels of file-channel rows (F, C_file; degrees, file order), one branch per joint.

    Each joint's triple is put on the branch nearest its previous frame's
    (:func:`mocapkit.io.euler_branches.continuous_rotations`), then the model's columns
    (:func:`euler_columns`) are unwrapped along time (:func:`unwrap_degrees`). The one encoding of every
    Euler path: :func:`encode` (rows from :meth:`Motion.channel_values`), the streaming
    :class:`~mocapkit.cleaning.deep.Denoiser` (one row at a time, the same numbers) and its batch counterpart
    :func:`~mocapkit.cleaning.deep.denoise_rows`: rows on either branch (the plain conversion's or a file's
    own) read as the same channels.
    """
    vals = np.array(rows, dtype=np.float64)
    continuous_rotations(vals, [skeleton.joint_channels(j) for j in range(skeleton.num_joints)])
    return unwrap_degrees(vals[:, euler_columns(skeleton)])


def with_measured(values: np.ndarray, measured: np.ndarray | None, skeleton) -> np.ndarray:
    """(F, C) Euler model channels ``values`` (:func:`euler_values`; NaN where a joint is missing) with the file's
    ``measured`` rotation numbers (F, C_file; :func:`mocapkit.cleaning.measured.measured_rotations`, NaN where
    none) put in: the channels a partly missing joint still measures, which a fill then conditions on instead of
    making the joint's whole rotation up. Each joint's measured angles of a cell are placed on the Euler branch,
    ``(z + 180, 180 - x, y + 180)`` or the triple as written (``-x`` for a repeated axis), and the whole turns
    nearest the channels' curve bridged over the gap (:func:`lerp_fill`), judged on the measured angles alone
    (the branch moves every angle of the triple, the missing one too). ``measured`` None: ``values`` as given.
    """
    if measured is None:
        return values
    cols = euler_columns(skeleton)
    meas = np.asarray(measured, dtype=np.float64)[:, cols]
    if values.shape != meas.shape or not np.isfinite(meas).any():
        return values
    near = lerp_fill(values)
    out = np.where(np.isfinite(meas), meas + 360.0 * np.round((near - meas) / 360.0), values)  # whole turns
    at = {int(c): k for k, c in enumerate(cols)}
    for order, idx in three_axis_groups(skeleton):
        for triple in (t for t in idx if int(t[0]) in at):  # the root's rotation is no model channel
            k = [at[int(c)] for c in triple]
            own, ref = meas[:, k], near[:, k]
            rows = np.isfinite(own).any(axis=1)
            if not rows.any():
                continue
            other = own[rows] + np.array([180.0, 0.0, 180.0])
            other[:, 1] = (-own[rows, 1]) if order[0] == order[2] else 180.0 - own[rows, 1]
            dist = []
            for cand in (own[rows], other):
                cand = cand + 360.0 * np.round((ref[rows] - cand) / 360.0)
                dist.append((np.nansum(np.abs(cand - ref[rows]), axis=1), cand))
            pick = np.where((dist[1][0] < dist[0][0])[:, None], dist[1][1], dist[0][1])
            sub = out[np.ix_(rows, k)]
            out[np.ix_(rows, k)] = np.where(np.isfinite(own[rows]), pick, sub)
    return out


def _gram_schmidt(v: np.ndarray) -> np.ndarray:
    """(..., 6) -> (..., 3, 3) rotation matrices (Zhou et al.'s 6-D decoding)."""
    a, b = v[..., :3], v[..., 3:]
    x = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), 1e-12)
    b = b - np.sum(x * b, axis=-1, keepdims=True) * x
    y = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), 1e-12)
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=-1)


def decode(values: np.ndarray, like: Motion, layout: ChannelLayout, keep: np.ndarray | None = None) -> Motion:
    """A Motion like ``like`` whose non-root rotations come from ``values`` (F, C).

    The root's rotation and trajectory, the skeleton, fps and name are
    ``like``'s, bit-identical. Where ``keep`` (F, J) is True the joint's
    rotation is also copied from ``like`` bit-identically (e.g. observed cells
    when only gaps were filled). Quaternion signs follow ``like`` where it is
    finite so no sign jumps appear.
    """
    F = like.num_frames
    values = np.asarray(values, dtype=np.float64)
    if values.shape != (F, layout.num_channels):
        raise ValueError(f"values: expected shape ({F}, {layout.num_channels}), got {values.shape}")
    sk = like.skeleton
    in_layout = np.zeros(sk.num_joints, dtype=bool)
    in_layout[[sk.index(n) for n in layout.joints]] = True
    if layout.representation == "euler":
        # only the cells that change (a layout joint, not kept) go from degrees to quaternions, joint by joint
        # with the conversions Motion.from_channel_values makes (elementwise: the same bits as converting all)
        wrapped = np.nan_to_num((values + 180.0) % 360.0 - 180.0)
        rot = np.array(like.rotations)
        col = 0
        for j in range(sk.num_joints):
            n = sum(1 for ch in sk.joint_channels(j) if ch.endswith("rotation")) if j > 0 else 0
            frames = np.flatnonzero(~np.asarray(keep[:, j], dtype=bool)) if keep is not None else np.arange(F)
            if n and in_layout[j] and len(frames):
                q = R.euler_to_quaternion(wrapped[frames, col : col + n], sk.rotation_order(j))
                if sk.axes is not None:
                    c = sk.axes[j]
                    q = R.quaternion_multiply(R.quaternion_multiply(c, q), R.quaternion_conjugate(c))
                rot[frames, j] = q
            col += n
    else:
        from ...corrupt import project_to_dofs

        ids = np.array([sk.index(n) for n in layout.joints], dtype=np.int64)
        q = R.matrix_to_quaternion(_gram_schmidt(values.reshape(F, len(ids), 6)))
        axes = sk.axes
        if axes is not None:
            c = axes[ids][None]
            q = R.quaternion_multiply(R.quaternion_multiply(c, q), R.quaternion_conjugate(c))
        rot = np.array(like.rotations)
        for k, j in enumerate(ids):
            rot[:, j] = project_to_dofs(sk, int(j), q[:, k])
    ref = like.rotations
    finite = np.all(np.isfinite(ref), axis=-1, keepdims=True)
    flip = finite & (np.sum(rot * np.nan_to_num(ref), axis=-1, keepdims=True) < 0.0)
    rot = np.where(flip, -rot, rot)
    rot[:, ~in_layout] = ref[:, ~in_layout]  # the root and joints without rotation channels
    if keep is not None:
        rot = np.where(np.asarray(keep, dtype=bool)[..., None], ref, rot)
    return dataclasses.replace(like, rotations=rot)


def channel_joints(layout: ChannelLayout) -> np.ndarray:
    """(C,) index of each model channel's joint in ``layout.joints`` (channel names are ``joint.channel``)."""
    idx = {j: k for k, j in enumerate(layout.joints)}
    return np.array([idx[n.rsplit(".", 1)[0]] for n in layout.names], dtype=np.int64)


def lerp_fill(values: np.ndarray) -> np.ndarray:
    """Fill NaN runs of (F, C) channels by linear interpolation; ends hold the nearest value; all-NaN -> 0."""
    x = np.array(values, dtype=np.float64)
    miss = np.isnan(x)
    if not miss.any():
        return x
    t = np.arange(len(x))
    for c in np.flatnonzero(miss.any(axis=0)):
        ok = ~miss[:, c]
        x[:, c] = np.interp(t, t[ok], x[ok, c]) if ok.any() else 0.0
    return x
