"""A BVH file's ``#`` comment lines, carried through where mocapkit writes the file anew around them.

Some tools write comment lines (first non-blank character ``#``, :func:`mocapkit.io.bvh_roots.is_comment`) in the
hierarchy, around ``Frames:`` / ``Frame Time:`` and between the motion lines. The reader reads them as nothing.
A BVH written like its source (:func:`mocapkit.io.bvh.write_bvh` with ``like``) keeps them where the file has them:
the motion section's between the same frames (:func:`motion_comments`), the header's as its text; where the take's
hierarchy is written anew (new offsets), each comment inside it goes after the same element of the new text
(:func:`anchored` and :func:`with_comments`: the element is counted by the hierarchy's keywords, which the new
text writes one to a line). :func:`comment_lines` counts the comments of a file, for the note a command prints when
an output cannot keep them (another format, or a BVH not written like its source).
"""

from __future__ import annotations

from .bvh_roots import is_comment
from .sources import bom_length

__all__ = ["KEYWORDS", "motion_comments", "comment_count", "anchored", "keyword_count", "with_comments", "comment_lines"]

#: The tokens that open an element of a BVH hierarchy; :func:`mocapkit.io.bvh_hierarchy.hierarchy_text` starts a
#: line with each.
KEYWORDS = frozenset({"ROOT", "JOINT", "End", "{", "}", "OFFSET", "CHANNELS"})


def motion_comments(lines: list[str], blanks: bool = False) -> tuple[list[str], list[list[str]]]:
    """The motion lines after ``Frame Time:`` (``lines``, line endings kept) split into the frame lines and the
    comment lines before each: ``(frames, before)``, ``before`` one list per frame plus one for the comments after
    the last frame. Blank lines are left out, as the reader leaves them; with ``blanks`` they are kept in ``before``
    where they stand (a file's empty lines after its last frame, written back by a BVH written like it)."""
    frames: list[str] = []
    before: list[list[str]] = []
    pending: list[str] = []
    for t in lines:
        if not t.strip():
            if blanks:
                pending.append(t)
            continue
        if is_comment(t):
            pending.append(t)
            continue
        before.append(pending)
        pending = []
        frames.append(t)
    before.append(pending)
    return frames, before


def comment_count(before: list[list[str]]) -> int:
    """How many comment lines the lists ``before`` (:func:`motion_comments`) hold, blank lines left out."""
    return sum(1 for lines in before for t in lines if t.strip())


def _keywords(line: str) -> int:
    return sum(tok in KEYWORDS for tok in line.split())


def keyword_count(block: list[str]) -> int:
    """How many hierarchy keywords (:data:`KEYWORDS`) the lines ``block`` hold, comment lines left out."""
    return sum(_keywords(t) for t in block if not is_comment(t))


def anchored(block: list[str]) -> list[tuple[int, str]]:
    """Each comment line of a hierarchy ``block`` (the take's ROOT block, line endings kept) with the number of
    hierarchy keywords (:data:`KEYWORDS`) before it: where it stands in the hierarchy, whatever the file's layout."""
    out, seen = [], 0
    for t in block:
        if is_comment(t):
            out.append((seen, t if t.endswith("\n") else t + "\n"))
        else:
            seen += _keywords(t)
    return out


def with_comments(text: str, comments: list[tuple[int, str]], keywords: int | None = None) -> str | None:
    """``text`` (a hierarchy written anew, one keyword to a line) with each of ``comments`` (:func:`anchored`)
    after the line where as many keywords have been written. ``keywords``: how many the block the comments came
    from holds; None when the new text holds another number (another hierarchy: no place is the same) or a line
    holds two."""
    lines = text.splitlines(keepends=True)
    counts = [_keywords(t) for t in lines]
    if any(c > 1 for c in counts) or (keywords is not None and sum(counts) != keywords):
        return None
    out, k, seen = [], 0, 0
    for t, c in zip(lines, counts):
        while k < len(comments) and comments[k][0] <= seen:
            out.append(comments[k][1])
            k += 1
        out.append(t)
        seen += c
    out += [t for _, t in comments[k:]]
    return "".join(out)


def comment_lines(data: bytes) -> int:
    """How many comment lines a BVH file's text ``data`` holds (header and motion section). A UTF-8 byte-order mark
    (:func:`mocapkit.io.sources.bom_length`) is no part of the first line: a first line ``#`` after it is a comment."""
    return sum(is_comment(t) for t in data[bom_length(data):].decode("utf-8", errors="replace").splitlines())
