"""Repeated frames: a capture that stutters writes a frame again, bit for bit, while the body moves on.

:func:`find_stutters` names each run of frames that repeat the frame before
them exactly (every rotation, the root's position, animated offsets; missing
equal to missing) while the take moves around the run: the frame before the
run differs from its own predecessor and the frame after the run differs from
the run. A take that holds still bit for bit at its start or end (a pose held
by the exporter) is no stutter. A run of frames written as 0
(:mod:`mocapkit.cleaning.zeros`) repeats itself too and is named there instead.

``clean`` names stutters and leaves them as they are: a repeated frame may
stand in for a sample the capture lost (the timing is right, the value stale)
or be one frame too many (everything after it comes one frame late), and the
take alone does not tell which. Removing frames would change the take's length
and timing (its sync with sound, video or other takes) and interpolating them
would invent motion; a person who knows which it is can do either.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..motion import Motion
from .ik import contact_segments

__all__ = ["Stutter", "find_stutters", "stutter_frames"]


@dataclass(frozen=True)
class Stutter:
    """Frames ``first``..``last`` (inclusive) repeat frame ``first - 1`` bit for bit."""

    first: int
    last: int

    def __str__(self) -> str:
        a, b = self.first, self.last
        frames = f"frame {a} repeats" if a == b else f"frames {a}-{b} repeat"
        return (f"{frames} frame {a - 1} bit for bit while the take moves (a capture stutter), left as "
                f"{'it is' if a == b else 'they are'}: clean keeps the take's frames and timing")


def _rows(motion: Motion) -> np.ndarray:
    F = motion.num_frames
    parts = [np.asarray(motion.rotations).reshape(F, -1), np.asarray(motion.root_positions)]
    if motion.translations is not None:
        parts.append(np.asarray(motion.translations).reshape(F, -1))
    return np.concatenate(parts, axis=1)


def find_stutters(motion: Motion, skip: np.ndarray | None = None) -> tuple[Stutter, ...]:
    """The stutters of ``motion`` (module docstring), by first frame; frames in ``skip`` ((F,) bool, e.g. the
    all-zero frames of :func:`mocapkit.cleaning.zeros.find_zeros`) are in none."""
    F = motion.num_frames
    if F < 3:
        return ()
    x = _rows(motion)
    same = np.zeros(F, dtype=bool)
    same[1:] = np.all((x[1:] == x[:-1]) | (np.isnan(x[1:]) & np.isnan(x[:-1])), axis=1)
    if skip is not None:
        same &= ~np.asarray(skip, dtype=bool)
    out = []
    for a, b in contact_segments(same):
        if a >= 2 and b < F and not same[a - 1] and (skip is None or not skip[a - 1]):
            out.append(Stutter(a, b - 1))
    return tuple(out)


def stutter_frames(stutters, num_frames: int) -> np.ndarray:
    """(F,) bool: the frames of ``stutters`` (:func:`find_stutters`) in a take of ``num_frames`` frames."""
    out = np.zeros(int(num_frames), dtype=bool)
    for s in stutters:
        out[s.first:s.last + 1] = True
    return out
