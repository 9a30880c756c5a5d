"""An animator's sentence for each change and flag of the report, the detector's words kept as its detail.

A reason such as "flagged: a digression its own break confirms (MDM up to 1.00)" names the rule of
self-similarity detection (Aristidou et al. 2018) that fired; a person reviewing a take wants to know what
is wrong with the motion and what the cleaning did about it. :func:`plain_sentence` says that in one sentence,
from the step that changed the cells and the rules that flagged them; the page shows it first and the rule's
words after it, so nothing the record says is lost.
"""

from __future__ import annotations

import numpy as np

from ..cleaning.ssa.cues import CAUSES, cause_names

__all__ = ["PLAIN_CAUSES", "plain_sentence", "with_plain_words"]

#: what each rule of :data:`~mocapkit.cleaning.ssa.cues.CAUSES` means for the motion, keyed by its name
PLAIN_CAUSES = {
    "break": "the joint breaks away from how it moves in the similar moments of the take",
    "held": "the joint stays still while it moves in the similar moments",
    "swap": "left and right look swapped",
    "offset": "the joint steps off its path and later steps back",
    "drift": "the joint drifts slowly off how it moves in the similar moments",
    "digression": "the joint moves unlike the similar moments of the take",
    "teleport": "the whole body jumps away and back (bad root samples)",
    "spike": "the joint spikes far past anything it does elsewhere",
    "reversed": "this stretch plays backwards",
    "frozen": "the joint's rotation sticks on one value while the body moves, then jumps",
    "flip": "the joint turns about half a turn in one frame and later turns back",
}
_BY_WORDS = {words: PLAIN_CAUSES[name] for name, words in CAUSES}
_STEPS = {
    "fill": "the joint's data was missing here and was filled in",
    "repair": "replaced by the take's own similar motion",
    "denoise": "jitter smoothed out",
}
#: what the repair step does instead of copying similar motion, for the causes it undoes exactly
#: (:mod:`mocapkit.cleaning.ssa.flips`, the root's teleports in :mod:`mocapkit.cleaning.whole_take`)
_UNDONE = {
    "flip": "turned back by the turn it made there (a half turn, or the turn measured at its two steps)",
    "teleport": "put back on the root's path between the frames around the jump",
}


def plain_sentence(step: str, why: list[str]) -> str:
    """One sentence for a change made by ``step`` (``"fill"``, ``"repair"``, ``"denoise"`` or several joined by
    ``"+"``; "" for a flag) on cells flagged by the rules ``why`` (the words of
    :data:`~mocapkit.cleaning.ssa.cues.CAUSES`, as :func:`~mocapkit.cleaning.ssa.cues.cause_names` gives them).

    >>> plain_sentence("repair", ["a transient offset (a step off its path and back)"])
    "The joint steps off its path and later steps back: replaced by the take's own similar motion."
    """
    what = "; ".join(_BY_WORDS.get(w, w) for w in why)
    done = "; ".join(_STEPS[s] for s in step.split("+") if s in _STEPS) if step else ""
    for cause, undone in _UNDONE.items():  # whole-take rules undo the error itself, not from the take's motion words
        if step and why and all(w == dict(CAUSES)[cause] for w in why):
            done = done.replace(_STEPS["repair"], undone)
    if step and "repair" in step.split("+") and not why:
        what = "moved with a flagged joint it is repaired with"
    text = f"{what}: {done}" if what and done else what or done
    return text[:1].upper() + text[1:] + "." if text else ""


def with_plain_words(review: dict, result) -> dict:
    """``review`` (:func:`mocapkit.cleaning.decisions.review`) with ``"plain"`` on each change and flag:
    :func:`plain_sentence` of its step and of the rules that flagged its cells in ``result`` (a
    :class:`~mocapkit.cleaning.clean_record.CleanResult`)."""
    causes = getattr(result, "causes", None)
    flags = np.asarray(result.flags, dtype=bool)

    def rules(j, a, b):
        if causes is None or not flags[a:b + 1, j].any():
            return []
        return cause_names(causes[a:b + 1, j])

    changes = [{**c, "plain": plain_sentence(c["step"], rules(c["joint_index"], c["first"], c["last"])
                                             if "repair" in c["step"].split("+") else [])}
               for c in review.get("changes", [])]
    flagged = [{**f, "plain": plain_sentence("", f.get("why") or [])} for f in review.get("flags", [])]
    return {**review, "changes": changes, "flags": flagged}
