"""Corruption with known ground truth: noise, gaps and the errors a real capture shows.

Every function takes a Motion and a ``seed`` (int or ``numpy.random.Generator``)
and returns ``(corrupted, mask)`` where ``mask`` is a boolean (F, J) array that
is True exactly where a joint's rotation (for the root: or its position) was
changed. The input is never modified. :func:`real_errors` also returns a list
of :class:`ErrorRecord` as a third element.

Noise models follow Mall et al. 2017, section 4; the error kinds follow
Aristidou et al. 2018, section 6.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from . import rotations as R
from .motion import Motion, find_joint, mirror_pairs, unit_scale_cm

__all__ = [
    "angular_noise",
    "uniform_noise",
    "bias",
    "spatial_noise",
    "gaps",
    "real_errors",
    "corrupt",
    "ErrorRecord",
    "KINDS",
]

KINDS = ("noise", "uniform", "bias", "spatial", "gaps", "errors")


def _rng(seed) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def _joint_set(motion: Motion, joints, include_root: bool) -> np.ndarray:
    J = motion.num_joints
    if joints is None:
        sel = np.ones(J, dtype=bool)
        sel[0] = include_root
        return sel
    sel = np.zeros(J, dtype=bool)
    for j in joints:
        sel[motion.skeleton.index(j) if isinstance(j, str) else int(j)] = True
    return sel


def _changed(a: Motion, b: Motion) -> np.ndarray:
    """(F, J) mask of joints whose rotation (root: or position) differs between a and b."""
    diff = np.any(a.rotations != b.rotations, axis=-1)
    diff &= ~(np.isnan(a.rotations).all(-1) & np.isnan(b.rotations).all(-1))
    diff[:, 0] |= np.any(a.root_positions != b.root_positions, axis=-1) & ~np.isnan(a.root_positions).any(-1)
    return diff


def _rotation_columns(motion: Motion, sel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns of ``channel_values`` that are rotations of selected joints, and their joint index."""
    sk = motion.skeleton
    cols, owner, c = [], [], 0
    for j in range(sk.num_joints):
        for ch in sk.joint_channels(j):
            if ch.endswith("rotation") and sel[j]:
                cols.append(c)
                owner.append(j)
            c += 1
    return np.array(cols, dtype=np.int64), np.array(owner, dtype=np.int64)


def _channel_noise(motion: Motion, noise: np.ndarray, sel: np.ndarray) -> tuple[Motion, np.ndarray]:
    values = motion.channel_values()
    cols, _ = _rotation_columns(motion, sel)
    values[:, cols] += noise
    out = Motion.from_channel_values(
        motion.skeleton, values, motion.fps, motion.name, animated_offsets=motion.translations is not None
    )
    # keep the root trajectory and unselected joints bit-identical
    rot = np.where(sel[None, :, None], out.rotations, motion.rotations)
    out = dataclasses.replace(motion, rotations=rot)
    return out, _changed(motion, out)


def angular_noise(motion: Motion, amount: float = 0.5, seed=None, joints=None, include_root: bool = False):
    """Gaussian noise on every joint-angle channel, std = ``amount`` x that channel's std (Mall 4).

    0.5 is Mall et al.'s default "0.5 noise" (6 dB SNR); they also use 0.1 and
    0.9. Applied to the file's channels (degrees); the root trajectory is kept
    clean, as in the paper, and the root rotation too unless ``include_root``.
    """
    rng = _rng(seed)
    sel = _joint_set(motion, joints, include_root)
    cols, _ = _rotation_columns(motion, sel)
    std = np.nanstd(motion.channel_values()[:, cols], axis=0)
    noise = rng.normal(size=(motion.num_frames, len(cols))) * (amount * std)
    return _channel_noise(motion, noise, sel)


def uniform_noise(motion: Motion, amount: float = 0.5, seed=None, joints=None, include_root: bool = False):
    """Uniform noise with the same std as :func:`angular_noise` (``amount`` x channel std)."""
    rng = _rng(seed)
    sel = _joint_set(motion, joints, include_root)
    cols, _ = _rotation_columns(motion, sel)
    std = np.nanstd(motion.channel_values()[:, cols], axis=0)
    half_width = np.sqrt(3.0) * amount * std
    noise = rng.uniform(-1.0, 1.0, size=(motion.num_frames, len(cols))) * half_width
    return _channel_noise(motion, noise, sel)


def bias(
    motion: Motion,
    amount: float = 0.5,
    kind: str = "constant",
    period_s: float = 2.0,
    seed=None,
    joints=None,
    include_root: bool = False,
):
    """Non-zero-mean noise (Mall 4.1): a per-channel offset of ``amount`` x channel std.

    ``kind="constant"`` adds a random-sign constant; ``"sinusoidal"`` a sine of
    that amplitude with period ``period_s`` and a random phase per channel.
    """
    if kind not in ("constant", "sinusoidal"):
        raise ValueError(f"bias kind must be 'constant' or 'sinusoidal', got {kind!r}")
    rng = _rng(seed)
    sel = _joint_set(motion, joints, include_root)
    cols, _ = _rotation_columns(motion, sel)
    std = np.nanstd(motion.channel_values()[:, cols], axis=0)
    amp = amount * std * rng.choice([-1.0, 1.0], size=len(cols))
    if kind == "constant":
        noise = np.broadcast_to(amp, (motion.num_frames, len(cols))).copy()
    else:
        t = np.arange(motion.num_frames)[:, None] / motion.fps
        phase = rng.uniform(0, 2 * np.pi, size=len(cols))
        noise = amp * np.sin(2 * np.pi * t / period_s + phase)
    return _channel_noise(motion, noise, sel)


def spatial_noise(
    motion: Motion, std_cm: float = 0.5, end_effector_scale: float = 1.0, seed=None, amount: float | None = None
):
    """Gaussian noise on joint positions turned back into rotations, bone lengths kept (Mall 4).

    Each joint's global position gets 3D noise of ``std_cm`` (wrists and ankles
    ``end_effector_scale`` times more). Then, in topological order, every
    parent is given the minimal-arc (swing) rotation that points its bone at
    the noisy child position; for a joint with several children the swing
    aims the first child and the others follow rigidly. Bone lengths are
    therefore exactly the skeleton's. The root trajectory stays clean.
    ``amount`` is an alias of ``std_cm`` (the CLI's ``--amount``).
    """
    if amount is not None:
        std_cm = amount
    rng = _rng(seed)
    sk = motion.skeleton
    scale = unit_scale_cm(sk)
    grot, gpos = motion.global_transforms()
    sigma = np.full(sk.num_joints, std_cm / scale)
    for role in ("left_hand", "right_hand", "left_foot", "right_foot"):
        try:
            sigma[find_joint(sk, role)] *= end_effector_scale
        except KeyError:
            pass
    target = gpos + rng.normal(size=gpos.shape) * sigma[None, :, None]
    target[:, 0] = gpos[:, 0]
    local = np.array(motion.rotations)
    offsets = motion.local_offsets()
    new_grot = np.empty_like(grot)
    new_pos = np.empty_like(gpos)
    new_grot[:, 0] = grot[:, 0]
    new_pos[:, 0] = gpos[:, 0]
    first_child = {}
    for j in range(1, sk.num_joints):
        first_child.setdefault(int(sk.parents[j]), j)
    for j in range(sk.num_joints):
        p = int(sk.parents[j])
        if j > 0:
            new_grot[:, j] = R.quaternion_multiply(new_grot[:, p], local[:, j])
            new_pos[:, j] = new_pos[:, p] + R.quaternion_rotate(new_grot[:, p], offsets[:, j])
        c = first_child.get(j)
        if c is None or np.allclose(sk.offsets[c], 0.0):
            continue
        cur = R.quaternion_rotate(new_grot[:, j], offsets[:, c])
        want = target[:, c] - new_pos[:, j]
        swing = _swing(cur, want)
        new_grot[:, j] = R.quaternion_multiply(swing, new_grot[:, j])
        parent_rot = new_grot[:, p] if j > 0 else R.identity((motion.num_frames,))
        local[:, j] = R.quaternion_multiply(R.quaternion_conjugate(parent_rot), new_grot[:, j])
        if j == 0:
            local[:, 0] = new_grot[:, 0]
    out = dataclasses.replace(motion, rotations=R.quaternion_normalize(local))
    return out, _changed(motion, out)


def _swing(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Minimal-arc rotations (N, 4) taking directions a (N, 3) to b (N, 3)."""
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    w = 1.0 + np.sum(a * b, axis=-1, keepdims=True)
    q = np.concatenate([w, np.cross(a, b)], axis=-1)
    return R.quaternion_normalize(q)


def gaps(
    motion: Motion,
    start_prob: float = 0.1 / 120.0,
    mean_length_s: float = 0.25,
    max_length_s: float = 2.0,
    seed=None,
    joints=None,
    long: bool = False,
):
    """Runs of missing data (NaN) per joint with exponentially distributed lengths (Mall 4).

    A gap starts at each (joint, frame) with probability ``start_prob``; its
    length is exponential with mean ``mean_length_s`` seconds, capped at
    ``max_length_s`` and at least one frame. Gaps are per joint: the whole
    rotation is missing, which is what ``Motion.missing()`` reports. With
    ``long=True`` gap lengths are uniform in 1-5 s (Mall's long-gap test for
    the EBD). The root is never gapped.

    Note: Mall et al. state a 10% start probability "per channel and frame" at
    120 fps with short gaps; the default here, 0.1/120 per joint-frame, gives
    about one gap start per joint per 10 s, which keeps most of the clip
    observed as their experiments require. Pass ``start_prob=0.1`` for the literal setting.
    """
    rng = _rng(seed)
    sel = _joint_set(motion, joints, include_root=False)
    F, J = motion.num_frames, motion.num_joints
    rot = np.array(motion.rotations)
    starts = (rng.random((F, J)) < start_prob) & sel[None, :]
    for f, j in zip(*np.nonzero(starts)):
        if long:
            n = int(round(rng.uniform(1.0, 5.0) * motion.fps))
        else:
            n = int(round(min(rng.exponential(mean_length_s), max_length_s) * motion.fps))
        rot[f : f + max(n, 1), j] = np.nan
    out = dataclasses.replace(motion, rotations=rot)
    return out, _changed(motion, out)


@dataclass(frozen=True)
class ErrorRecord:
    """One injected error: its kind, joint name and frame range [start, end)."""

    kind: str
    joint: str
    start: int
    end: int


def real_errors(
    motion: Motion,
    kinds=("spike", "flip", "freeze", "drift", "swap"),
    n_errors: int = 4,
    duration_s: tuple[float, float] = (0.1, 0.6),
    seed=None,
    joints=None,
):
    """Inject the errors a real capture shows (Aristidou 6) on a few joints in short windows.

    Kinds: ``spike`` (a 30-90 deg rotation offset for 1-3 frames), ``flip``
    (the joint turned 180 deg about its bone axis), ``freeze`` (the joint holds
    its first value of the window; windows are chosen where it moves at least
    15 deg), ``drift`` (an offset growing linearly to 20-40 deg), ``swap``
    (a joint and its left/right partner take each other's mirrored rotations,
    as when marker labels swap sides). Returns
    ``(motion, mask, records)``; records list what was injected where.
    """
    rng = _rng(seed)
    sk = motion.skeleton
    F = motion.num_frames
    sel = _joint_set(motion, joints, include_root=False)
    candidates = np.flatnonzero(sel & (sk.bone_lengths() >= 0))
    perm = mirror_pairs(sk.joint_names)
    rot = np.array(motion.rotations)
    records: list[ErrorRecord] = []
    kinds = list(kinds)
    mirrored = None
    for _ in range(n_errors):
        kind = kinds[int(rng.integers(len(kinds)))]
        j = int(rng.choice(candidates))
        if kind == "spike":
            n = int(rng.integers(1, 4))
        else:
            n = int(round(rng.uniform(*duration_s) * motion.fps))
        n = int(np.clip(n, 1, max(F - 2, 1)))
        s = int(rng.integers(1, max(F - n, 2)))
        e = min(s + n, F)
        if kind == "spike":
            axis = rng.normal(size=3)
            ang = np.radians(rng.uniform(30, 90))
            off = R.quaternion_from_axis_angle(axis, ang)
            rot[s:e, j] = R.quaternion_multiply(rot[s:e, j], off)
        elif kind == "flip":
            kids = sk.children(j)
            bone = sk.offsets[kids[0]] if kids else np.array([0.0, 1.0, 0.0])
            if np.linalg.norm(bone) < 1e-9:
                bone = np.array([0.0, 1.0, 0.0])
            rot[s:e, j] = R.quaternion_multiply(rot[s:e, j], R.quaternion_from_axis_angle(bone, np.pi))
        elif kind == "freeze":
            # choose a window where the joint moves
            motion_range = None
            for _try in range(20):
                ang = R.geodesic_angle(rot[s, j], rot[s:e, j])
                if np.nanmax(ang) >= np.radians(15):
                    motion_range = True
                    break
                s = int(rng.integers(1, max(F - n, 2)))
                e = min(s + n, F)
            if motion_range is None:
                continue
            rot[s:e, j] = rot[s, j]
            s += 1  # the first frame of the window is unchanged
        elif kind == "drift":
            axis = rng.normal(size=3)
            peak = np.radians(rng.uniform(20, 40))
            ramp = np.linspace(peak / (e - s), peak, e - s)
            rot[s:e, j] = R.quaternion_multiply(rot[s:e, j], R.quaternion_from_axis_angle(axis, ramp))
        elif kind == "swap":
            paired = np.flatnonzero((perm != np.arange(len(perm))) & sel)
            if len(paired) == 0:
                continue
            j = int(rng.choice(paired))
            k = int(perm[j])
            # Swapped labels put each limb's motion on the other side: the partner's mirrored rotation.
            if mirrored is None:
                mirrored = motion.mirror().rotations
            rot[s:e, j], rot[s:e, k] = mirrored[s:e, j], mirrored[s:e, k]
            records.append(ErrorRecord(kind, sk.joint_names[k], s, e))
        else:
            raise ValueError(f"unknown error kind {kind!r}; kinds are spike, flip, freeze, drift, swap")
        records.append(ErrorRecord(kind, sk.joint_names[j], s, e))
    out = dataclasses.replace(motion, rotations=rot)
    # The mask is what actually changed by more than round-off (a swap of two equal rotations changes nothing).
    changed = R.geodesic_angle(out.rotations, motion.rotations) > 1e-9
    changed &= np.isfinite(motion.rotations).all(-1)
    out = dataclasses.replace(motion, rotations=np.where(changed[..., None], out.rotations, motion.rotations))
    return out, changed, records


def corrupt(motion: Motion, kind: str = "noise", seed=None, **params):
    """Dispatch by name (the CLI's ``--kind``): noise, uniform, bias, spatial, gaps, errors.

    Returns ``(motion, mask)`` or, for ``errors``, ``(motion, mask, records)``.
    """
    table = {
        "noise": angular_noise,
        "uniform": uniform_noise,
        "bias": bias,
        "spatial": spatial_noise,
        "gaps": gaps,
        "errors": real_errors,
    }
    if kind not in table:
        raise ValueError(f"unknown corruption kind {kind!r}; kinds are: {', '.join(table)}")
    if kind in ("gaps", "errors") and "amount" in params:
        raise ValueError(f"--amount does not apply to {kind}")
    return table[kind](motion, seed=seed, **params)
