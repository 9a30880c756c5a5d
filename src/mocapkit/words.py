"""Counts and lists in the words a person reads them: ``"1 file"``, ``"3 files"``, ``"A, B and C"``.

Every note and error that counts something (files left out of a context, takes complete, frames a rule
could not judge) says ``"1 of 1 file"``, never ``"1 of 1 files"``, and a "wrote ..." line lists its files
as a sentence does. A small module of plain text helpers that every layer may use (it imports nothing of
mocapkit's), so the library's notes and the command line's lines share one wording.
"""

from __future__ import annotations

from typing import Iterable

__all__ = ["plural", "listed", "frame_span", "frame_runs"]


def plural(n: int, word: str, many: str | None = None) -> str:
    """``n`` and ``word``, plural unless one: ``"1 joint"``, ``"2 joints"`` (``many``: an irregular plural,
    ``plural(2, "modelled quantity", "modelled quantities")``)."""
    return f"{n} {word if n == 1 else (many or word + 's')}"


def listed(items: Iterable) -> str:
    """``items`` as a person lists them: ``"A"``, ``"A and B"``, ``"A, B and C"`` (``""`` for none)."""
    words = [str(i) for i in items]
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}" if words else ""


def frame_span(first: int, last: int, fps: float | None = None) -> str:
    """Frames ``first`` to ``last`` (inclusive) as a person reads them: ``"frame 255"``, ``"frames 250-252"``, and
    with ``fps`` each frame's time in seconds: ``"frame 255 (8.50 s)"``, ``"frames 250-252 (8.33-8.40 s)"``. One
    frame was printed ``"frames 255-255 (8.50-8.50 s)"``; every line naming a run of frames says it this way."""
    first, last = int(first), int(last)
    if first == last:
        return f"frame {first}" + (f" ({first / fps:.2f} s)" if fps else "")
    return f"frames {first}-{last}" + (f" ({first / fps:.2f}-{last / fps:.2f} s)" if fps else "")


def frame_runs(runs: Iterable[tuple[int, int]], most: int | None = None) -> str:
    """Runs of frames, ``(first, last)`` inclusive and in order, each said exactly: ``"frame 252"``,
    ``"frames 249-251 and 253-257"``, ``"frames 20-26, 32 and 35-36"``; past ``most`` runs a count
    (``"frames 1-2, 4-5 and 3 more runs"``); ``""`` for none. A line naming the cells a rule kept or changed says
    their runs so: one span from the first to the last named frames between them it did not."""
    runs = [(int(a), int(b)) for a, b in runs]
    if not runs:
        return ""
    words = [str(a) if a == b else f"{a}-{b}" for a, b in runs]
    if most is not None and len(words) > most:
        words = words[:most] + [plural(len(words) - most, "more run")]
    return f"{'frame' if words == [str(runs[0][0])] else 'frames'} {listed(words)}"
