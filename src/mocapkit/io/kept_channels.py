"""The source BVH's own channel values kept in an .npz made from it, for the Euler writer of a later step.

A take read from a BVH and written as .npz (``mocapkit corrupt take.bvh g.npz``, ``mocapkit convert take.bvh
take.npz``) holds unit quaternions: which of a rotation's Euler triples the file wrote (its whole turns, its
branch of the middle angle) is lost, and a BVH written from the .npz later (``mocapkit fill g.npz -o f.bvh``)
would write every cell, untouched ones included, on the branch the plain conversion gives: the same rotation,
but a 180 or 360 degree jump in a curve editor and in any channel diff. So the .npz keeps the file's numbers,
``(F, C)`` degrees and file units in the columns of the channel layout the BVH writer writes
(:data:`LAYOUT_KEY`, JSON), and :func:`mocapkit.io.bvh.write_bvh` given such an .npz as ``like`` writes every cell
whose rotation is still the file's with the file's numbers, and a changed one on the branch nearest them. It keeps
the BVH's header text too (:data:`HEADER_KEY`: up to its Frame Time line, comments, spacing, a CHANNELS line's
trailing space and the Frame Time as written), which a BVH written from it keeps while the take is on that skeleton,
rate and frame count (:func:`kept_header`), and the ``#`` comment lines of its motion section with the frame each
stood before (:data:`COMMENTS_KEY`, JSON), which a BVH written from it puts back between the same frames while the
take has that frame count and channel layout (:func:`kept_comments`). Where the take is still on the file's joints,
channels and frame count, it keeps the file's whole text too (:data:`TEXT_KEYS`, its bytes as read), so that a BVH or
AMC written from the .npz keeps the text of every cell that did not change, byte for byte as ``clean``'s BVH -> BVH
and AMC -> AMC do (:func:`kept_text`; ``5.2300``, not ``5.23``; trailing spaces, line endings, other ROOTs). It costs
what the text compresses to: 131_01.bvh's 716 KB add 264 KB to its 1.04 MB .npz (+25%).
:func:`mocapkit.io.npz.read_npz` ignores these arrays; the Motion read is the same.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

__all__ = ["VALUES_KEY", "LAYOUT_KEY", "HEADER_KEY", "COMMENTS_KEY", "TEXT_KEYS", "kept_arrays", "kept_values",
           "kept_header", "kept_comments", "kept_text"]

VALUES_KEY = "source_channel_values"
LAYOUT_KEY = "source_channel_layout"
HEADER_KEY = "source_bvh_header"
COMMENTS_KEY = "source_bvh_motion_comments"
#: The array keeping the whole text of the file an .npz was made from, by the file's format: a 0-d void array of
#: the file's bytes as read (every byte kept, NULs included; counted at its size by ``load_arrays``' limit).
TEXT_KEYS = {".bvh": "source_bvh_text", ".amc": "source_amc_text"}


def kept_arrays(values: np.ndarray | None, channels, header: str | None = None,
                comments: list[list[str]] | None = None, text: tuple[str, bytes] | None = None) -> dict[str, np.ndarray]:
    """The arrays an .npz keeps beside a take (``write_npz``'s ``extra``): the source file's ``values`` (F, C) in
    the columns of ``channels`` (one tuple of channel names per joint) and, for a BVH, its ``header`` text
    (:func:`mocapkit.io.bvh.source_kept`) and its motion section's comment lines (``comments``: F + 1 lists, the
    lines before each frame and after the last, line endings kept), as
    ``[frame, line]`` pairs; ``text``: (the file's suffix, its bytes) where the take is still on its joints,
    channels and frames (:data:`TEXT_KEYS`); none when ``values`` is None."""
    if values is None:
        return {}
    out = {VALUES_KEY: np.asarray(values, dtype=np.float64), LAYOUT_KEY: np.array(json.dumps([list(c) for c in channels]))}
    if text is not None and text[0] in TEXT_KEYS and text[1]:
        out[TEXT_KEYS[text[0]]] = np.array(np.void(bytes(text[1])))
    if header:
        out[HEADER_KEY] = np.array(header)
    pairs = [[f, t] for f, lines in enumerate(comments or ()) for t in lines]
    if pairs and len(comments) == len(values) + 1:
        out[COMMENTS_KEY] = np.array(json.dumps(pairs))
    return out


def kept_comments(path, num_frames: int) -> list[list[str]] | None:
    """The comment lines of the BVH an .npz at ``path`` was made from that stood between its motion lines
    (:data:`COMMENTS_KEY`): ``num_frames + 1`` lists, the lines (line endings kept) before each frame and after the
    last, for a take of that many frames; None when ``path`` keeps none, or keeps them for another frame count, or
    they are not comment lines of one line each (a BVH written with them must read back as the same take)."""
    from ..errors import MocapError
    from .bvh_roots import is_comment
    from .npz import load_arrays

    path = Path(path) if path is not None and path is not False else None
    if path is None or path.suffix.lower() != ".npz" or not path.is_file():
        return None
    try:
        kept = load_arrays(path, keys=(COMMENTS_KEY,)).get(COMMENTS_KEY)
        if kept is None or kept.dtype.kind != "U" or kept.ndim != 0:
            return None
        pairs = json.loads(str(kept))
    except (MocapError, OSError, ValueError):
        return None
    out: list[list[str]] = [[] for _ in range(num_frames + 1)]
    for pair in pairs if isinstance(pairs, list) else [None]:
        if not (isinstance(pair, list) and len(pair) == 2 and type(pair[0]) is int and isinstance(pair[1], str)):
            return None
        f, line = pair
        body = line[:-2] if line.endswith("\r\n") else line[:-1] if line.endswith("\n") else line
        if not 0 <= f <= num_frames or not is_comment(body) or "\n" in body or "\r" in body:
            return None
        out[f].append(line)
    if any(not t.endswith("\n") for f, t in pairs[:-1]):  # a line that ran into the next
        return None
    return out


def kept_header(path, motion) -> str | None:
    """The header text of the BVH an .npz at ``path`` was made from (:data:`HEADER_KEY`), where ``motion`` is on the
    take's skeleton (joints, offsets, end sites, channels), rate and frame count that the .npz holds, so the header
    says what a BVH of ``motion`` holds; None otherwise, or where the .npz keeps none."""
    from ..errors import MocapError
    from .npz import load_arrays, read_npz

    path = Path(path) if path is not None and path is not False else None
    if path is None or path.suffix.lower() != ".npz" or not path.is_file() or motion.num_frames == 0:
        return None
    try:
        header = load_arrays(path, keys=(HEADER_KEY,)).get(HEADER_KEY)
        if header is None or header.dtype.kind != "U" or header.ndim != 0:
            return None
        ref = read_npz(path)
    except (MocapError, OSError, ValueError):
        return None
    a, b = getattr(ref, "skeleton", None), motion.skeleton
    same = (a is not None and ref.fps == motion.fps and ref.num_frames == motion.num_frames and a.axes is None
            and b.axes is None and a.joint_names == b.joint_names and np.array_equal(a.parents, b.parents)
            and np.array_equal(a.offsets, b.offsets) and np.array_equal(a.end_site_parents, b.end_site_parents)
            and np.array_equal(a.end_site_offsets, b.end_site_offsets)
            and tuple(map(tuple, a.channels or ())) == tuple(map(tuple, b.channels or ())))
    return str(header) if same else None


def kept_values(path, channels, num_frames: int) -> np.ndarray | None:
    """The source file's numbers (F, C) an .npz at ``path`` keeps for a take written with ``channels`` (one tuple per
    joint) over ``num_frames`` frames; None when ``path`` is no such .npz, keeps none, or keeps them for another
    layout or length (the take was cut, resampled or put on other channels since)."""
    from ..errors import MocapError
    from .npz import load_arrays

    path = Path(path)
    if path.suffix.lower() != ".npz" or not path.is_file():
        return None
    try:
        data = load_arrays(path, keys=(VALUES_KEY, LAYOUT_KEY))
        values, layout = data.get(VALUES_KEY), data.get(LAYOUT_KEY)
        if values is None or layout is None or layout.dtype.kind != "U" or layout.ndim != 0:
            return None
        said = json.loads(str(layout))
    except (MocapError, OSError, ValueError):
        return None
    width = sum(len(c) for c in channels)
    if ([list(c) for c in channels] != said or values.dtype.kind != "f"
            or values.shape != (num_frames, width)):
        return None
    return np.asarray(values, dtype=np.float64)


def kept_text(path, suffix: str) -> bytes | None:
    """The bytes of the ``suffix`` file (``.bvh``, ``.amc``) an .npz at ``path`` was made from (:data:`TEXT_KEYS`),
    which its writer reads as it reads that file itself (:func:`mocapkit.io.sources.recall`); None when ``path`` is
    no .npz or keeps no such text (an .npz written before 0.14.0, or from a take no longer on that file's joints,
    channels and frames)."""
    from ..errors import MocapError
    from .npz import load_arrays

    path = Path(path) if path is not None and path is not False else None
    if path is None or path.suffix.lower() != ".npz" or suffix not in TEXT_KEYS or not path.is_file():
        return None
    try:
        kept = load_arrays(path, keys=(TEXT_KEYS[suffix],)).get(TEXT_KEYS[suffix])
    except (MocapError, OSError, ValueError):
        return None
    if kept is None or kept.dtype.kind != "V" or kept.ndim != 0 or kept.dtype.names is not None:
        return None
    return kept.tobytes() or None
