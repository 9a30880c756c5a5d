"""BVH files with several ROOTs, and comment lines: which hierarchy is the take, and what is carried through.

MotionBuilder, Blender and game exporters write a prop (a sword, a ball), a camera or a light as a second
``ROOT`` beside the character, its channels on the same motion lines. mocapkit analyses and cleans one
skeleton, so one root is the take (:func:`humanoid_root`): the :class:`~mocapkit.motion.Motion` holds its
hierarchy and channel columns; the other roots (:class:`ExtraRoot`) are not read into it but carried through:
a BVH written like its source (:func:`mocapkit.io.bvh.write_bvh` with ``like``) keeps their hierarchy lines
and each motion line's numbers for their channels as the file's own text. A format that holds one skeleton
(AMC, npz), or a BVH that cannot be written like its source (a resampled take), leaves them out, and
:func:`left_out_note` says so in one line.

Lines whose first non-blank character is ``#`` (:data:`COMMENT`) are comments: some tools write them in the
hierarchy and around ``Frames:`` / ``Frame Time:``. They are read as nothing and, being text of the file's
header, kept by a BVH written like its source.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

__all__ = ["COMMENT", "ExtraRoot", "Layout", "layout", "humanoid_root", "extra_roots", "left_out_note", "is_comment",
           "around_take"]

COMMENT = "#"
"""The character that starts a comment line of a BVH header."""

_HIPS = re.compile(r"hip|pelvis", re.I)


def is_comment(line: str) -> bool:
    """Whether a header ``line`` of a BVH is a comment (first non-blank character ``#``)."""
    return line.lstrip().startswith(COMMENT)


@dataclass(frozen=True)
class ExtraRoot:
    """A ROOT of a BVH file that is not the take (:func:`humanoid_root`), carried through as the file gives it.

    ``name``: its ROOT's name; ``joints``: its hierarchy's joint names (the root first); ``channels``: how many
    numbers of each motion line are its own; ``lines``: its block's first and last line in the file (1-based).
    """

    name: str
    joints: tuple[str, ...]
    channels: int
    lines: tuple[int, int]

    def describe(self) -> str:
        """``'Sword' (2 joints, 6 channels)``: how a command names it."""
        n = len(self.joints)
        return (f"{self.name!r} ({n} joint{'s' if n != 1 else ''}, "
                f"{self.channels} channel{'s' if self.channels != 1 else ''})")


def humanoid_root(names, roots) -> int:
    """Which of a BVH file's ROOTs is the take: its index in ``roots``.

    ``names`` (J,) are every joint's in file order; ``roots`` lists each ROOT's first joint
    (its hierarchy runs to the next root's). The rule: of the roots whose hierarchy holds a hips-like joint (a
    name with ``hip`` or ``pelvis`` in it, any case: ``Hips``, ``LeftHip``, ``pelvis``, ``Bip01 Pelvis``), else
    of all roots, the one with the most joints; on a tie, the first in the file. A character has tens of
    joints and hips; a prop, a camera or a light has one to a few and none.
    """
    firsts = [int(r[0]) for r in roots]
    stops = firsts[1:] + [len(names)]
    sizes = [b - a for a, b in zip(firsts, stops)]
    hips = [any(_HIPS.search(n) for n in names[a:b]) for a, b in zip(firsts, stops)]
    pool = [k for k in range(len(roots)) if hips[k]] or list(range(len(roots)))
    return max(pool, key=lambda k: (sizes[k], -k))


def extra_roots(path) -> tuple[ExtraRoot, ...]:
    """The ROOTs of the BVH file ``path`` that are not the take (empty for one root, another format, or a file
    neither kept (:func:`mocapkit.io.sources.recall`) nor readable): the text as the take was read from it."""
    from .bvh import read_layout

    if path is None or Path(path).suffix.lower() != ".bvh":
        return ()
    return read_layout(path).extras


def left_out_note(motion, out, like, carried: bool) -> str | None:
    """The one line a command prints when writing ``motion`` to ``out`` leaves out the other roots of the BVH it
    was read from (``like``, by default ``motion.source_file``), or None when there are none or they are kept.

    ``carried``: whether the writer keeps them (a BVH written like its source:
    :func:`mocapkit.io.bvh.source_fits`).
    """
    src = like if like is not None else motion.source_file
    extras = extra_roots(src) if src else ()
    if not extras or carried:
        return None
    kind = Path(out).suffix.lower()
    why = ("BVH is written like its source only at the source's frames, rate and skeleton"
           if kind == ".bvh" else f"{kind[1:].upper() or 'this format'} holds one skeleton")
    what = ", ".join(e.describe() for e in extras)
    return (f"{out}: not written, as {why}: {src}'s other root{'s' if len(extras) > 1 else ''} {what} "
            f"(a .bvh written from it at its own frames keeps them)")


@dataclass(frozen=True)
class Layout:
    """Where the take lies in a BVH file's hierarchy and motion lines.

    ``columns``: the take's first and stop column of each motion line (its root's hierarchy is contiguous, and
    so are its channels); ``width``: the numbers of a motion line; ``joints``: the take's first and stop joint
    in file order; ``lines``: its ROOT block's first and last line (1-based); ``extras``: the other roots.
    """

    columns: tuple[int, int]
    width: int
    joints: tuple[int, int]
    lines: tuple[int, int]
    extras: tuple[ExtraRoot, ...] = ()


def layout(names, channels, roots) -> Layout:
    """The :class:`Layout` of a parsed hierarchy: ``names`` (J,) and ``channels`` (J,) per joint in file order,
    ``roots`` each ROOT's (first joint, first line, last line); the take is :func:`humanoid_root`'s."""
    firsts = [int(r[0]) for r in roots]
    stops = firsts[1:] + [len(names)]
    starts = [0]
    for c in channels:
        starts.append(starts[-1] + len(c))
    k = humanoid_root(names, roots)
    extras = tuple(ExtraRoot(names[a], tuple(names[a:b]), starts[b] - starts[a], (int(r[1]), int(r[2])))
                   for i, (a, b, r) in enumerate(zip(firsts, stops, roots)) if i != k)
    a, b = firsts[k], stops[k]
    return Layout((starts[a], starts[b]), starts[-1], (a, b), (int(roots[k][1]), int(roots[k][2])), extras)


def around_take(lines: list[str], where: Layout, motion_at: int | None) -> tuple[list[str], list[str]] | None:
    """The header ``lines`` of a BVH (line endings kept) before the take's ROOT block (``where.lines``, 1-based) and
    after it up to MOTION (line ``motion_at``, 0-based; None: none): the comments and other roots a new hierarchy
    of the take is written between. None where the take's block shares a line with other text (``HIERARCHY ROOT
    Hips``), so cannot be cut out by lines, and the file has other roots; with none, the hierarchy is written
    whole, as ``HIERARCHY`` and the take's block."""
    (r0, r1) = where.lines
    before = lines[: r0 - 1]
    heads = [t.split()[0] for t in before if t.strip() and not is_comment(t)]
    if (motion_at is None or heads[:1] != ["HIERARCHY"] or lines[r0 - 1].split()[:1] != ["ROOT"]
            or lines[r1 - 1].split() != ["}"]):
        return None if where.extras else (["HIERARCHY\n"], [])
    return before, lines[r1:motion_at]
