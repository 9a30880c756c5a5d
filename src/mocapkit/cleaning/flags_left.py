"""The flags a cleaning left as they were, and why: said on each flag of the report and in clean-batch's line.

Detection flags a run of frames of a joint; repair may give a run back as it was when its result is no better
than the take (:class:`~mocapkit.cleaning.ssa.LeftRun`, a rule of this library: it would join the take less
smoothly or bridge faster than the joint ever turns), and without the repair step nothing changes a flag.
The console names those runs in a note; a reviewer reading the report's flags beside its changes, or a batch
log's counts, needs the same words, or an unchanged flag reads as one the cleaning forgot.
:func:`flag_outcomes` gives each flag what the cleaning did about it, :func:`left_line` the batch line's words.
"""

from __future__ import annotations

import numpy as np

from ..words import frame_span
from .decisions import flag_segments
from .ssa import LeftRun
from .ssa.flips import LASTS_TO_END, left_from_note

__all__ = ["flag_outcomes", "left_line"]


def flag_outcomes(result) -> list[dict]:
    """:func:`~mocapkit.cleaning.decisions.flag_segments` of ``result``, each with ``"left"``: "" where a step
    changed its cells, else why it was left as it was, in a reader's words (the repair guard's reason
    from the result's notes, a turn-over's reason for being left (:mod:`~mocapkit.cleaning.ssa.flips`), or that
    repair did not run). A flag changed in part, where the guard gave back a run inside it (a turn-over turned
    back, the frames before it left), says which frames were left and why (``"changed in part: frames 7-13 left
    as they were: the repair was not better than the take (...)"``): "changed" alone read as all of it changed.
    ``"left_reason"`` is the short why, ``"left_frames"`` ``[first, last]`` of the frames left (empty where none).

    ``result`` a :class:`~mocapkit.cleaning.clean_record.CleanResult` (a fresh one or one loaded from its record:
    the notes keep the guard's runs).
    """
    changed = np.asarray(result.changed, dtype=bool)
    runs = [r for r in (LeftRun.from_note(n) for n in result.notes) if r is not None]
    flips = [f for f in (left_from_note(n) for n in result.notes) if f is not None]  # turn-overs named and left
    repaired = any(s.name == "repair" for s in result.steps)
    out = []
    for seg in flag_segments(result):
        j, a, b = seg["joint_index"], seg["first"], seg["last"]
        left, reason, span = "", "", (a, b)
        turns = [w for js, f0, f1, w in flips if seg["joint"] in js and f0 <= b and a <= f1]
        if not changed[a:b + 1, j].any() and turns:
            back = "" if turns[0] == LASTS_TO_END else " and back"  # no way back before the take's end: not said
            reason = f"a half turn in one frame{back}, not turned back"
            left = f"left as it was: {reason} ({turns[0]})"
        elif not changed[a:b + 1, j].any():
            why = [r.reason for r in runs if r.joint == seg["joint"] and r.start <= b and a < r.end]
            reason = "the repair was not better than the take" if repaired else "the repair step did not run"
            left = f"left as it was: {reason}" + (f" ({why[0]})" if why and repaired else "")
        else:  # changed in part: a guard's run inside the flag was given back, and the rest of the flag was changed
            kept = [(r, max(a, r.start), min(b, r.end - 1)) for r in runs if r.joint == seg["joint"]
                    and r.start <= b and a < r.end and not changed[max(a, r.start):min(b, r.end - 1) + 1, j].any()]
            if kept:
                r, f0, f1 = kept[0]
                reason, span = "the repair was not better than the take", (f0, f1)
                frames = frame_span(f0, f1)
                left = f"changed in part: {frames} left as {'it was' if f0 == f1 else 'they were'}: {reason} ({r.reason})"
        out.append({**seg, "left": left, "left_reason": reason, "left_frames": list(span) if left else []})
    return out


def left_line(result) -> str:
    """``"1 flagged run left as it was (RightWrist 248-267: the repair was not better than the take)"``, the
    words clean-batch's line says of the flags :func:`flag_outcomes` finds unchanged; "" where there are none.
    Up to three runs are named, then how many more."""
    left = [f for f in flag_outcomes(result) if f["left"]]
    if not left:
        return ""
    # the frames left, not the flag's: a flag changed in part names only its run given back, so the counts add up
    # (flagged - repaired = the samples of the runs named)
    spans = [f.get("left_frames") or (f["first"], f["last"]) for f in left]
    named = [f"{f['joint']} {a}-{b}" for f, (a, b) in zip(left[:3], spans)] + \
        ([f"{len(left) - 3} more"] if len(left) > 3 else [])
    # each reason once, in the order of the runs named: sorted, "UpperLeg_R 7-13, Neck 25-30: a half turn ...; the
    # repair was not better" paired the leg with the neck's reason
    why = dict.fromkeys(f.get("left_reason") or f["left"].split(" (")[0].removeprefix("left as it was: ") for f in left)
    return (f"{len(left)} flagged run{' left as it was' if len(left) == 1 else 's left as they were'} ({', '.join(named)}: "
            f"{'; '.join(why)})")
