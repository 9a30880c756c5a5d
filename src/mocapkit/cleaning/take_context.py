"""Whether a take's context is read at all: not for a take too coarse for self-similarity.

A context (``--context``, ``context=``) serves detection and repair only, which do not run on a take under
:func:`~mocapkit.cleaning.ssa.texture.min_take_fps` (12 fps: a motion word of 0.625 s would hold fewer than half
of the take's own frames, :func:`~mocapkit.cleaning.ssa.texture.too_coarse`). A folder of takes named for such a
take was built all the same, each clip resampled to 24 fps and cached, for nothing: this module says, before
anything is built or read, that the context is left unread and why. ``clean`` (:func:`mocapkit.clean`,
``mocapkit clean``), ``detect`` and ``repair`` ask it first.
"""

from __future__ import annotations

from ..context import is_off
from ..motion import Motion
from .ssa.texture import min_take_fps, too_coarse
from .whole_take import take_params

__all__ = ["unread_context"]


def unread_context(motion: Motion, spec) -> str | None:
    """Whether the context ``spec`` is left unread for ``motion``: None when it is to be read, else the line that
    says why ("" where there is nothing to say).

    ``spec``: what ``--context`` or ``context=`` gave (None or empty: the bundled default context; False or
    "none": none; paths, Motions or a database). A take at a rate no motion word judges (under 12 fps with clean's
    parameters, :func:`~mocapkit.cleaning.whole_take.take_params`) reads none, and the line names the rate and the
    rate a word needs; the bundled default (no one's choice) and no context leave nothing unsaid: "" (the skipped
    detection says the rest)."""
    params = take_params()
    if not too_coarse(motion.fps, params):
        return None
    if is_off(spec) or spec is None or (isinstance(spec, (list, tuple)) and len(spec) == 0):
        return ""
    return (f"the context given was neither built nor read: at {motion.fps:g} fps detect and repair do not run "
            f"(self-similarity judges takes of {min_take_fps(params):g} fps or more)")
