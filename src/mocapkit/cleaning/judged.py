"""How much of a take detection judged: the frames no neighbour word examined, said beside the untouched share.

Self-similarity judges a frame's joint against the similar motion of the take
and its context (Aristidou et al. 2018, section 3); where a word has no
neighbour within ``max_word_angle_deg`` nothing judges it, and a cleaning that
changed nothing there did not find it clean. On a rig the bundled context does
not hold, a take with little repetition leaves most of its frames unjudged
(an OptiTrack Motive take: 509 of 683 frames), and "99.8 % untouched" alone
reads as if all of it had been checked. :func:`not_judged` counts those frames
and :func:`not_judged_note` says them in the words the summary prints.
"""

from __future__ import annotations

import numpy as np

__all__ = ["not_judged", "not_judged_cells", "not_judged_note"]


def not_judged_cells(detection) -> np.ndarray:
    """(F, J) bool: the cells of the analysed joints, in the analysed span, that no neighbour word judged.

    ``detection`` a :class:`~mocapkit.cleaning.ssa.Detection`. Such a cell has MDM 0 and nothing flags it:
    the report draws it as not judged (striped) rather than as a cell found clean. Joints not analysed at all
    and frames outside the ``span`` (calibration poses left alone) are False here: the report says those apart.
    """
    dig = np.asarray(detection.digression, dtype=np.float64)
    analysed = np.asarray(detection.analysed, dtype=bool)
    out = np.zeros(dig.shape, dtype=bool)
    lo, hi = (0, dig.shape[0]) if detection.span is None else detection.span
    out[lo:hi] = ~np.isfinite(dig[lo:hi]) & analysed[None, :]
    return out


def not_judged(detection) -> tuple[int, int]:
    """``(none, some)``: frames of the analysed span where no analysed joint is judged, and frames where some are.

    ``detection`` a :class:`~mocapkit.cleaning.ssa.Detection` (a joint is judged at a frame where its
    ``digression`` is finite; only the :attr:`~mocapkit.cleaning.ssa.Detection.analysed` joints count; frames
    outside its ``span``, the calibration poses left alone, are not counted). ``(0, 0)`` where every frame is
    judged on every analysed joint, or where no joint was analysed at all.
    """
    dig = np.asarray(detection.digression, dtype=np.float64)
    analysed = np.asarray(detection.analysed, dtype=bool)
    if not analysed.any():
        return 0, 0
    lo, hi = (0, dig.shape[0]) if detection.span is None else detection.span
    judged = np.isfinite(dig[lo:hi][:, analysed])  # (frames, analysed joints)
    none = int((~judged.any(axis=1)).sum())
    some = int((~judged.all(axis=1)).sum()) - none
    return none, some


def not_judged_note(detection, num_frames: int) -> str:
    """``"509 of 683 frames not judged: no similar motion in the take or its context"`` (and how many more are
    judged on some joints only); "" where detection judged every analysed joint of every frame, or did not run
    (``detection`` None). ``num_frames``: the take's. A take judged against itself alone (no context given, or
    one of another rig, as the bundled default context is for every rig but the Acclaim one: its
    ``context_clips`` hold the take only) reads "no similar motion in the take (judged against itself alone)":
    "or its context" told a studio batching its own rig that a context had been searched."""
    if detection is None:
        return ""
    none, some = not_judged(detection)
    if not none and not some:
        return ""
    parts = []
    if none:
        parts.append(f"{none} of {num_frames} frames not judged")
    if some:
        parts.append(f"{some} {'more ' if none else ''}{'frame' if some == 1 else 'frames'} judged on some joints only"
                     + ("" if none else f" (of {num_frames})"))
    alone = len(getattr(detection, "context_clips", None) or ((), ())) == 1  # clip 0 is the take itself
    return "; ".join(parts) + (": no similar motion in the take (judged against itself alone)" if alone
                               else ": no similar motion in the take or its context")
