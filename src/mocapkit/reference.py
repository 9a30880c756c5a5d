"""Comparing a command's result with a reference take (the truth), checked before any work is done.

Commands that clean, denoise, fill or reconstruct a take can print how far
the input and the result are from a clean reference take (the CLI's
``--reference``). The reference is checked first, against what the result
will be (its frame count and joints), so that a reference of another length
or rig is refused before anything is computed or written, not after.

The figures are the ones of :mod:`mocapkit.metrics`: the mean per-frame pose
error (Aristidou et al. 2018, eq. 2), joint-position RMS in centimetres,
non-root joint-angle RMS in degrees and the mean rotation error of filled
joints in degrees.

>>> import mocapkit
>>> walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
>>> ref = check_reference(walk, "walk.amc", frames=walk.num_frames, joint_names=walk.skeleton.joint_names)
>>> clean_errors(ref, walk, walk)["pose_after"]
0.0
"""

from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from .errors import MocapFormatError
from .words import plural

__all__ = ["check_reference", "clean_errors", "joint_angle_errors", "filled_error_deg", "global_errors_cm", "position_error_cm",
           "skeleton_error_cm", "unplaced_errors_cm"]


def check_reference(reference, path: os.PathLike | str, *, frames: int, joint_names: Sequence[str] | None = None,
                    skeleton=None, whose: str = "the input's", option: str = "unit="):
    """Return ``reference`` if it can be compared with a result of ``frames`` frames, else refuse.

    Parameters
    ----------
    reference : Motion
        The reference take as read from ``path``.
    path : the reference's file, named in the error.
    frames : the result's frame count.
    joint_names : the result's joint names, in order (same rig, same names); or
    skeleton : a Skeleton the reference must be compatible with (same joints,
        any offsets: :meth:`~mocapkit.motion.Skeleton.is_compatible`).
    whose : what the result is, for the message (``"the reconstruction's"``: the database's skeleton).
    option : how the caller gives the length unit, named where the reference's is unknown (Python's ``unit=``
        of :func:`mocapkit.io.takes.load_motion`; the command line's ``--unit``).

    Raises
    ------
    MocapFormatError
        ``PATH: the reference must have ...`` with both frame counts.
    """
    same_rig = True
    if joint_names is not None:
        same_rig = tuple(reference.skeleton.joint_names) == tuple(joint_names)
    if skeleton is not None:
        same_rig = same_rig and reference.skeleton.is_compatible(skeleton)
    if reference.num_frames != frames or not same_rig:
        rig = "" if same_rig else "; its joints differ"
        raise MocapFormatError(path, f"the reference must have {whose} joints and {plural(frames, 'frame')} "
                                     f"(it has {plural(reference.num_frames, 'frame')}{rig})")
    from .errors import SkeletonError
    from .motion import unit_scale_cm

    try:
        unit_scale_cm(reference.skeleton)  # the position errors are in cm: told before any work, not after
    except SkeletonError as exc:
        raise MocapFormatError(path, f"the error in cm needs the reference's length unit: {exc}; give it with "
                                     f"{option} (mm, cm, m, in)") from None
    return reference


def clean_errors(reference, original, cleaned) -> dict:
    """The input's and the cleaned take's error against ``reference`` (all three the same frames and joints).

    Returns a dict: ``pose_before``/``pose_after`` (mean per-frame pose error,
    eq. 2, unitless: the sum over joints of the squared half-angle of each joint's rotation error, radians^2),
    ``cm_before``/``cm_after`` (position RMS, cm, root-relative, over the joints and the end sites below the
    pelvis, so that an error on the head or the toes, whose only child is an end site, is seen) and
    ``gaps_filled`` (True when the input had missing joints, which are filled
    linearly for the "before" figures: the error of a missing joint is undefined).
    """
    from .metrics import joint_position_rms, pose_error

    gaps = bool(original.missing().any())
    if gaps:
        from .cleaning import gapfill

        original = gapfill.fill_motion(original, "linear")
    return {
        "pose_before": float(np.nanmean(pose_error(reference, original))),
        "pose_after": float(np.nanmean(pose_error(reference, cleaned))),
        "cm_before": float(joint_position_rms(reference, original, end_sites=True)),
        "cm_after": float(joint_position_rms(reference, cleaned, end_sites=True)),
        "gaps_filled": gaps,
    }


def joint_angle_errors(reference, before, after) -> tuple[float, float]:
    """Non-root joint-angle RMS (degrees) of ``before`` and ``after`` against ``reference``."""
    from .metrics import joint_angle_rms

    return (float(joint_angle_rms(reference, before, include_root=False)),
            float(joint_angle_rms(reference, after, include_root=False)))


def filled_error_deg(reference, filled, missing: np.ndarray) -> float:
    """Mean rotation error (degrees) of the joints that were missing, ``missing`` (F, J) bool, against ``reference``."""
    from .metrics import geodesic_pose_distance

    if not missing.any():
        return 0.0
    return float(np.degrees(geodesic_pose_distance(reference, filled))[missing].mean())


def global_errors_cm(reference, result) -> tuple[float, float]:
    """Where the result lies, not only its pose: the pelvis's position RMS and the body's joint-position RMS (cm), global.

    A root-relative figure (:func:`position_error_cm`) is blind to a body put
    metres from its markers; these compare positions as they are, in the
    reference's frame (a reconstruction from markers is placed in the
    markers'). The pelvis is found by its role; the body is it and the joints
    below it (:func:`mocapkit.metrics.joint_position_rms`, ``"pelvis"`` and
    ``"body"``). Returns ``(pelvis_cm, body_cm)``.
    """
    from .metrics import joint_position_rms

    return (float(joint_position_rms(reference, result, root_relative="pelvis")),
            float(joint_position_rms(reference, result, root_relative="body")))


def skeleton_error_cm(reference, result) -> float:
    """The whole skeleton's joint-position RMS (cm), global: every joint, those above the pelvis too (a game rig's
    root, ``joint_Root`` on the Bandai Namco rig), which :func:`global_errors_cm`' body leaves out: a result that
    moves a root the reference holds at the origin shows here (:func:`mocapkit.metrics.joint_position_rms`,
    ``root_relative=False``)."""
    from .metrics import joint_position_rms

    return float(joint_position_rms(reference, result, root_relative=False))


def position_error_cm(reference, result, heading: bool = False) -> float:
    """Joint-position RMS (cm), root-relative; ``heading``: each motion's heading removed too (accelerometers see none)."""
    from .metrics import joint_position_rms

    return float(joint_position_rms(reference, result, root_relative="heading" if heading else True))


def unplaced_errors_cm(reference, result) -> dict:
    """The joints a heading-free figure (:func:`position_error_cm` with ``heading``) leaves out, for a result that
    does not place the body (accelerometers, a multilinear model: Tautges 2012, chs. 2-3, see no heading and
    integrate no floor position): the pelvis's height and the joints above the pelvis (a game rig's root,
    ``joint_Root`` on the Bandai Namco rig).

    Both are compared in each motion's ground frame (:func:`mocapkit.features.root_frame`: the pelvis's heading
    about the vertical and its position on the floor, the vertical the reference's), where such a result can
    be right: the pelvis's position there is its height above the floor; a joint above the pelvis is where it
    lies from the body (a root that travels with it: root motion). Where the reference holds those joints
    still (the ``joint_Root`` of Bandai Namco dataset 2 at the origin,
    :func:`mocapkit.reconstruct._common.held_above`) their global positions are compared instead: a result
    laid out as the take holds them there too (:func:`mocapkit.reconstruct.output.laid_out_like`), while
    their place from the body is the body's integrated travel, not theirs.

    Returns ``{"pelvis_height_rms_cm": cm}``, with ``"above_pelvis_rms_cm"`` (RMS over those joints and frames,
    cm), ``"above_pelvis_is"`` (``"held still: global"`` or ``"in the pelvis's ground frame"``) and
    ``"above_pelvis"`` (their names) where the rig has joints above its pelvis. NaN frames are left out.
    """
    from .features import find_up_axis, normalize_positions
    from .motion import unit_scale_cm
    from .reconstruct._common import body_joints, held_above
    from .rigs import pelvis_index

    sk = reference.skeleton
    scale = unit_scale_cm(sk)
    ga, gb = reference.global_positions(), result.global_positions()
    up = find_up_axis(sk, ga)

    def rms(d) -> float:
        d2 = np.sum(d * d, axis=-1)
        d2 = d2[np.isfinite(d2)]
        return float(np.sqrt(d2.mean()) * scale) if d2.size else float("nan")

    la, lb = normalize_positions(reference, ga, up), normalize_positions(result, gb, up)  # the pelvis's ground frame
    p = pelvis_index(sk)
    out = {"pelvis_height_rms_cm": rms(la[:, p] - lb[:, p])}
    above = np.setdiff1d(np.arange(sk.num_joints), body_joints(sk))
    if above.size:
        still = held_above(reference) is not None
        d = (ga - gb)[:, above] if still else (la - lb)[:, above]
        out.update(above_pelvis_rms_cm=rms(d), above_pelvis_is="held still: global" if still else
                   "in the pelvis's ground frame", above_pelvis=[sk.joint_names[j] for j in above])
    return out
