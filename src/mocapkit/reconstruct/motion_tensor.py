"""Motion tensors: time-aligned clips of one motion class stacked by their natural modes (Tautges 2012, sec. 2.2.2).

The clips are put in temporal correspondence by DTW against a reference clip,
resampled to a common length and stacked into two tensors: the joint
rotations ``Theta_q`` with modes DOF (4 quaternion components) x joint x
frame x the natural modes (``("actor", "repetition")`` by default; the thesis
has style x actor x repetition), and the root positions ``Theta_p`` with
modes DOF (3) x frame x the natural modes. :mod:`.multilinear` decomposes
them (:mod:`.hosvd`) into a multilinear model.

Rigs: the tensors hold the *body*, the pelvis (found by its role,
:func:`mocapkit.rigs.pelvis_index`) and the joints below it
(:func:`~mocapkit.reconstruct._common.body_motion`): ``Theta_p`` is the
pelvis's trajectory and the pelvis's rotation is its global one. On
Acclaim and most BVH rigs that is the whole skeleton. On the Bandai Namco game
rig the root ``joint_Root`` stays on the floor (or follows the body on it) and
``Hips`` carries the translation; a tensor of its root would hold no
translation at all. The joints above the pelvis are kept as the clips hold
them (:attr:`MotionTensor.held`, :func:`~mocapkit.reconstruct._common.held_above`)
and put back on every motion the tensor gives
(:func:`~mocapkit.reconstruct._common.whole_motion`). The vertical axis
comes from the clips' frames (:func:`~mocapkit.features.find_up_axis`), not
from the rest pose, which lies along x on that rig.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.ndimage import gaussian_filter1d
from tqdm.auto import tqdm

from .. import rotations as R
from ..features import feature_set, find_up_axis, parse_up_axis, root_frame
from ..motion import Motion, Skeleton
from ..progress import bar_disabled, bar_size
from ..search.dtw import dtw
from ..words import plural
from ._common import body_motion, body_skeleton, held_above, whole_motion

__all__ = ["MotionTensor", "hdm05_labels", "held_by_all", "motion_tensor", "name_labels", "time_map", "FIRST_NATURAL_Q",
           "FIRST_NATURAL_P"]

#: Index of the first natural mode in the rotation tensor (DOF, joint, frame, natural...).
FIRST_NATURAL_Q = 3
#: Index of the first natural mode in the root tensor (DOF, frame, natural...).
FIRST_NATURAL_P = 2


# -- motion tensors (sec. 2.2.2) ------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class MotionTensor:
    """Time-aligned clips of one motion class as the two tensors of sec. 2.2.2.

    Attributes
    ----------
    rotations : float array (4, B, L, d_1, ..., d_n)
        ``Theta_q``: DOF (w, x, y, z) x joint x frame x natural modes; local
        rotations of the B body joints (the pelvis and the joints below it,
        pelvis first: its global rotation), one hemisphere per joint, the
        pelvis's heading normalised.
    root : float array (3, L, d_1, ..., d_n)
        ``Theta_p``: pelvis positions, file units, first aligned frame's
        ground-plane position at the origin.
    modes : tuple of str (n,)
        Names of the natural modes.
    entries : tuple of n tuples
        The labels along each natural mode, sorted.
    observed : bool array (d_1, ..., d_n)
        Cells filled by a clip (False: filled by ``missing="mean"``).
    skeleton : Skeleton
        The reference clip's skeleton (all clips share its topology), the
        joints above the pelvis included.
    fps : float
        Frame rate of the model time axis.
    reference : str
        Name of the clip every other clip was aligned to.
    names : tuple of str
        Clip name per observed cell, in ``np.argwhere(observed)`` order.
    up : float array (3,)
        The unit vertical axis of the clips' frames.
    held : Motion or None
        The joints above the pelvis as every clip holds them still (one frame,
        :func:`~mocapkit.reconstruct._common.held_above`: the Bandai Namco
        ``joint_Root`` at the origin); None when the pelvis is the root or the
        clips move them (the root then goes on the ground under the pelvis).
    """

    rotations: np.ndarray
    root: np.ndarray
    modes: tuple
    entries: tuple
    observed: np.ndarray
    skeleton: Skeleton
    fps: float
    reference: str
    names: tuple
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))
    held: Motion | None = None

    @property
    def num_frames(self) -> int:
        return int(self.rotations.shape[2])

    @property
    def shape(self) -> tuple:
        """Sizes of the natural modes."""
        return tuple(self.rotations.shape[FIRST_NATURAL_Q:])

    def clip(self, index: Sequence[int]) -> Motion:
        """The aligned clip (or filled cell) at natural-mode ``index`` as a Motion at :attr:`fps` on :attr:`skeleton`."""
        idx = (Ellipsis,) + tuple(int(i) for i in index)
        q = np.moveaxis(self.rotations[idx], (0, 1, 2), (2, 1, 0))
        body = Motion(body_skeleton(self.skeleton), R.quaternion_normalize(q), self.root[idx].T, self.fps, name=f"cell{tuple(index)}")
        return whole_motion(body, self.skeleton, self.up, self.held)


def held_by_all(clips: Sequence[Motion]) -> Motion | None:
    """The joints above the pelvis as every clip of ``clips`` (one topology) holds them still, or None.

    :func:`~mocapkit.reconstruct._common.held_above` over the clips' frames
    taken together: a one-frame Motion on the first clip's skeleton where
    every clip holds those joints at one pose (the Bandai Namco dataset-2
    ``joint_Root`` at the origin), None where the pelvis is the root, or where
    any clip moves them or holds them elsewhere (dataset 1's ``joint_Root``
    that travels with the body in a few takes).
    """
    first = clips[0]
    tr = None
    if all(c.translations is not None for c in clips):
        tr = np.concatenate([np.asarray(c.translations, dtype=np.float64) for c in clips])
    together = Motion(first.skeleton, np.concatenate([np.asarray(c.rotations, dtype=np.float64) for c in clips]),
                      np.concatenate([np.asarray(c.root_positions, dtype=np.float64) for c in clips]), first.fps,
                      first.name, tr)
    return held_above(together)


def hdm05_labels(clips: Sequence) -> list[tuple[str, int]]:
    """``(actor, repetition ordinal)`` per clip (Motion, path or name) from HDM05 names (``HDM_bk_sneak2StepsLStart_004_120``).

    The repetition mode needs comparable entries across actors, so the file's
    take number becomes its rank among that actor's clips (0, 1, ...).
    """
    parsed = []
    for c in clips:
        name = Path(str(getattr(c, "name", c))).name
        parts = name.split("_")
        if len(parts) < 4 or parts[0] != "HDM" or not parts[-2].isdigit():
            raise ValueError(f"{name!r} is not an HDM05 clip name (HDM_<actor>_<class>_<take>_<fps>); pass labels")
        parsed.append((parts[1], int(parts[-2])))
    out = []
    for actor, take in parsed:
        takes = sorted(t for a, t in parsed if a == actor)
        out.append((actor, takes.index(take)))
    return out


def name_labels(names: Sequence) -> tuple[tuple[str, ...], list[tuple], str]:
    """The natural modes, each clip's labels and the one motion class, read from the clips' file names.

    ``names``: paths, names or Motions (their ``name``), one per clip. Two datasets name their takes by
    class and natural mode:

    * HDM05, ``HDM_<actor>_<class>_<take>_<fps>``: modes ``("actor", "repetition")``, the repetition the
      take's rank among its actor's (:func:`hdm05_labels`);
    * Bandai Namco, ``dataset-<n>_<content>_<style>_<take>``: mode ``("style",)``, or ``("style",
      "repetition")`` where a style has more than one take (the take's rank among its style's).

    Returns ``(modes, labels, class)``. Raises ValueError naming the first clip whose name is of neither
    kind, or the classes when the clips are of more than one: a multilinear model is of one motion class
    (Tautges 2012, sec. 2.6).
    """
    stems = [Path(str(getattr(n, "name", n))).name.split(".")[0] for n in names]
    parts = [s.split("_") for s in stems]
    if stems and all(len(p) >= 5 and p[0] == "HDM" and p[-2].isdigit() for p in parts):
        classes = ["_".join(p[2:-2]) for p in parts]
        modes, labels = ("actor", "repetition"), hdm05_labels(stems)
    elif stems and all(len(p) == 4 and p[0].startswith("dataset-") and p[3].isdigit() for p in parts):
        classes = [p[1] for p in parts]  # dataset 1 and 2 share the rig: a run is a run
        styles = [p[2] for p in parts]
        ranks = [sorted(int(q[3]) for q in parts if q[2] == p[2]).index(int(p[3])) for p in parts]
        several = len(set(styles)) < len(styles)
        modes = ("style", "repetition") if several else ("style",)
        labels = [(s, r) if several else (s,) for s, r in zip(styles, ranks)]
    else:
        bad = next((s for s, p in zip(stems, parts) if not ((len(p) >= 5 and p[0] == "HDM" and p[-2].isdigit())
                                                             or (len(p) == 4 and p[0].startswith("dataset-")))), stems[0] if stems else "")
        raise ValueError(f"{bad!r} is named neither as an HDM05 take (HDM_<actor>_<class>_<take>_<fps>) nor as a "
                         "Bandai Namco one (dataset-<n>_<content>_<style>_<take>): the natural modes are read from the names")
    found = sorted(set(classes))
    if len(found) > 1:
        raise ValueError(f"takes of {len(found)} motion classes ({', '.join(found)}): a multilinear model is of one class")
    return modes, labels, found[0]


def _sample(rotations: np.ndarray, root: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations (F, J, 4) and root (F, 3) at fractional frame times ``t`` (L,): slerp and lerp."""
    F = rotations.shape[0]
    t = np.clip(np.asarray(t, dtype=np.float64), 0.0, F - 1)
    i0 = np.minimum(np.floor(t).astype(np.int64), F - 1)
    i1 = np.minimum(i0 + 1, F - 1)
    a = t - i0
    rot = R.slerp(rotations[i0], rotations[i1], a[:, None])
    pos = root[i0] * (1.0 - a)[:, None] + root[i1] * a[:, None]
    return rot, pos


def time_map(path: np.ndarray, n_ref: int, sigma: float = 0.0) -> np.ndarray:
    """Clip time (n_ref,) of every reference frame from a DTW path (L, 2) of (clip, reference) rows.

    The mean clip frame per reference frame, Gaussian-smoothed with ``sigma``
    reference frames and made non-decreasing. DTW paths are staircases, and a
    time map with kinks puts its second derivative into every acceleration
    (``d^2/ds^2 p(t(s)) = p'' t'^2 + p' t''``), so the smoothing matters.
    The straight line between the end points is taken out before smoothing so
    that the ends stay fixed.
    """
    sums = np.bincount(path[:, 1], weights=path[:, 0].astype(np.float64), minlength=n_ref)
    counts = np.bincount(path[:, 1], minlength=n_ref)
    seen = counts > 0
    # Slope-limited steps skip frames; those get the time between their neighbours.
    t = np.interp(np.arange(n_ref), np.flatnonzero(seen), sums[seen] / counts[seen])
    if sigma > 0 and n_ref > 2:
        line = np.linspace(t[0], t[-1], n_ref)
        t = line + gaussian_filter1d(t - line, sigma, mode="nearest")
    return np.maximum.accumulate(t)


def _normalize_root(motion: Motion, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations and root with the first frame's heading turned to the forward axis and its ground position at 0."""
    heading, ground = root_frame(motion, up)
    inv = R.quaternion_conjugate(heading[0])
    rot = np.array(motion.rotations)
    rot[:, 0] = R.quaternion_multiply(inv, rot[:, 0])
    root = R.quaternion_rotate(inv, motion.root_positions - ground[0])
    return rot, root


def motion_tensor(
    clips: Sequence[Motion],
    labels: Sequence[Sequence] | None = None,
    modes: Sequence[str] = ("actor", "repetition"),
    fps: float = 30.0,
    frames: int | None = None,
    reference: int | None = None,
    missing: str = "raise",
    warp_smoothing: float = 0.1,
    up_axis=None,
    progress: bool = False,
) -> MotionTensor:
    """Stack time-aligned clips of one motion class into the tensors of sec. 2.2.2.

    Each clip is resampled to ``fps``, aligned to the reference clip by
    classic DTW on Krüger's F15 features (wrists, ankles, head in the root
    frame, cm; Tautges' slope-limited steps give jerkier time maps and a
    worse fit here), the warping path is turned into a smooth monotone time map
    (mean clip frame per reference frame, Gaussian-smoothed) and the clip
    is sampled at the mapped times (slerp) on ``frames`` points of the
    reference's time axis. The tensors hold each clip's body (the pelvis
    and the joints below it, module docstring); the pelvis is normalised
    (first frame's ground position at the origin, heading to the forward
    axis) and each joint's quaternions are put in the reference's hemisphere.

    Parameters
    ----------
    clips : sequence of Motion
        One motion class, one skeleton topology (bone lengths may differ).
    labels : sequence of tuples, optional
        One tuple per clip with one label per natural mode; from
        :func:`hdm05_labels` (actor, repetition ordinal) when None.
    modes : sequence of str
        Names of the natural modes (as many as each label tuple has entries).
    fps : float
        Frame rate of the model time axis.
    frames : int, optional
        Length of the model time axis; the reference's length at ``fps`` when None.
    reference : int, optional
        Index of the reference clip; the clip of median length when None.
    missing : {"raise", "mean", "drop"}
        What to do with grid cells no clip fills: raise; fill with the mean of
        the observed cells along the last mode (e.g. the actor's other
        repetitions; the mean of all clips if there are none); or drop the
        entries of the last mode that are not observed everywhere.
    warp_smoothing : float
        Standard deviation in seconds of the Gaussian that smooths each DTW
        time map (a kinked time map adds spurious accelerations).
    up_axis : optional
        The vertical; found from the clips' frames when None
        (:func:`~mocapkit.features.find_up_axis`).
    progress : bool
        Show a progress bar over the clips.

    Returns
    -------
    MotionTensor
    """
    clips = list(clips)
    if len(clips) < 2:
        raise ValueError(f"a motion tensor needs at least 2 clips, got {len(clips)}")
    for c in clips:
        if not isinstance(c, Motion):
            raise ValueError(f"clips must be Motions, got {type(c).__name__}")
    sk0 = clips[0].skeleton
    for c in clips[1:]:
        if not c.skeleton.is_compatible(sk0):
            raise ValueError(
                f"clip {c.name!r} has a different joint layout from {clips[0].name!r}; "
                "a motion tensor needs one skeleton topology (retarget first)"
            )
    modes = tuple(str(m) for m in modes)
    if not modes:
        raise ValueError("a motion tensor needs at least one natural mode")
    if labels is None:
        labels = hdm05_labels(clips)
    labels = [tuple(lab) if isinstance(lab, (tuple, list)) else (lab,) for lab in labels]
    if len(labels) != len(clips):
        raise ValueError(f"{plural(len(labels), 'label')} for {plural(len(clips), 'clip')}")
    for lab in labels:
        if len(lab) != len(modes):
            raise ValueError(f"label {lab!r} has {plural(len(lab), 'entry', 'entries')} for the {plural(len(modes), 'mode')} {modes}")
    if len(set(labels)) != len(labels):
        dup = sorted({str(lab) for lab in labels if labels.count(lab) > 1})
        raise ValueError(f"two clips share the labels {', '.join(dup)}; every grid cell holds one clip")
    if missing not in ("raise", "mean", "drop"):
        raise ValueError(f"missing must be 'raise', 'mean' or 'drop', got {missing!r}")
    fps = float(fps)
    if not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    for c in clips:
        if c.num_frames < 2 or not (np.isfinite(c.rotations).all() and np.isfinite(c.root_positions).all()):
            raise ValueError(f"clip {c.name!r} has fewer than 2 frames or missing (NaN) values; fill gaps first")
    if up_axis is None:
        up = find_up_axis(sk0, np.concatenate([c.global_positions() for c in clips]))
    else:
        up = parse_up_axis(up_axis)

    res = [c.resample(fps) for c in clips]
    lengths = np.array([m.num_frames for m in res])
    if reference is None:
        reference = int(np.argsort(lengths, kind="stable")[len(lengths) // 2])
    if not 0 <= int(reference) < len(clips):
        raise ValueError(f"reference {reference} out of range for {plural(len(clips), 'clip')}")
    reference = int(reference)
    n_ref = int(lengths[reference])
    L = n_ref if frames is None else int(frames)
    if L < 5:
        raise ValueError(f"frames must be at least 5, got {frames}")
    grid_t = np.linspace(0.0, n_ref - 1, L)
    ref_feat = feature_set(res[reference], "F15", up_axis=up, scale_cm=True).values

    aligned = []
    for m in tqdm(res, desc="aligning clips", disable=bar_disabled(progress), **bar_size()):
        feat = feature_set(m, "F15", up_axis=up, scale_cm=True).values
        _, path = dtw(feat, ref_feat)
        t = np.interp(grid_t, np.arange(n_ref), time_map(path, n_ref, warp_smoothing * fps))
        b = body_motion(m)
        rot, pos = _sample(R.quaternion_continuity(b.rotations), b.root_positions, t)
        rot, pos = _normalize_root(Motion(b.skeleton, rot, pos, fps), up)
        aligned.append((R.quaternion_continuity(rot), pos))
    ref_rot = aligned[reference][0]
    for i, (rot, pos) in enumerate(aligned):
        sign = np.where(np.sum(rot * ref_rot, axis=(0, 2)) < 0.0, -1.0, 1.0)
        aligned[i] = (rot * sign[None, :, None], pos)

    entries = [tuple(sorted({lab[k] for lab in labels})) for k in range(len(modes))]
    shape = tuple(len(e) for e in entries)
    index = [tuple(entries[k].index(lab[k]) for k in range(len(modes))) for lab in labels]
    J = aligned[0][0].shape[1]
    Q = np.zeros((4, J, L) + shape)
    P = np.zeros((3, L) + shape)
    observed = np.zeros(shape, dtype=bool)
    for (rot, pos), idx in zip(aligned, index):
        Q[(Ellipsis,) + idx] = np.transpose(rot, (2, 1, 0))
        P[(Ellipsis,) + idx] = pos.T
        observed[idx] = True
    names_by_cell = {idx: clips[i].name for i, idx in enumerate(index)}

    if not observed.all():
        if missing == "raise":
            absent = [tuple(entries[k][i] for k, i in enumerate(idx)) for idx in np.argwhere(~observed)]
            raise ValueError(
                f"{len(absent)} grid cells have no clip (e.g. {absent[0]}); pass missing='mean' or 'drop', "
                "or give labels forming a full grid"
            )
        if missing == "drop":
            keep = np.flatnonzero(observed.reshape(-1, shape[-1]).all(axis=0))
            if keep.size == 0:
                raise ValueError(f"no entry of mode {modes[-1]!r} is observed for every combination of the other modes")
            Q, P, observed = Q[..., keep], P[..., keep], observed[..., keep]
            old = entries[-1]
            entries[-1] = tuple(old[i] for i in keep)
            names_by_cell = {
                idx[:-1] + (int(np.flatnonzero(keep == idx[-1])[0]),): n for idx, n in names_by_cell.items() if idx[-1] in keep
            }
        else:
            all_q = Q[..., observed].mean(axis=-1)
            all_p = P[..., observed].mean(axis=-1)
            tq, tp = (slice(None),) * FIRST_NATURAL_Q, (slice(None),) * FIRST_NATURAL_P
            for idx in np.argwhere(~observed):
                idx = tuple(int(i) for i in idx)
                line = observed[idx[:-1]]  # the observed cells along the last mode at these other entries
                if line.any():
                    Q[tq + idx] = Q[tq + idx[:-1]][..., line].mean(axis=-1)
                    P[tp + idx] = P[tp + idx[:-1]][..., line].mean(axis=-1)
                else:
                    Q[tq + idx], P[tp + idx] = all_q, all_p
    names = tuple(names_by_cell[tuple(int(i) for i in idx)] for idx in np.argwhere(observed))
    return MotionTensor(
        rotations=Q,
        root=P,
        modes=modes,
        entries=tuple(entries),
        observed=observed,
        skeleton=clips[reference].skeleton,
        fps=fps,
        reference=clips[reference].name,
        names=names,
        up=up,
        held=held_by_all(clips),
    )
