"""BVH (Biovision Hierarchy) reading and writing.

The reader takes any channel layout: 0 to 9 channels per joint in any order,
position channels on any joint (on the root they give ``root_positions``, on
other joints ``Motion.translations``; present axes replace the OFFSET, absent
ones keep it), scale channels (``Xscale Yscale Zscale``, as Maya and some game
exporters write them) when every value is 1 (the skeleton has no scale: they are
kept in ``Skeleton.channels`` and written back as 1; other values are refused),
``End Site`` blocks, tabs, CRLF, scientific notation,
``nan``, ``#`` comment lines in the header, and several ``ROOT`` hierarchies (a prop or a camera beside the
character: the take is one of them, the others are carried through, :mod:`mocapkit.io.bvh_roots`). The file is read once; the small hierarchy is parsed in Python and
the MOTION block by the numba number parser, then converted to quaternions in
one fused numba pass (bit for bit what ``Motion.from_channel_values`` gives,
which the tests check; it is 5x faster than the numpy route on whole clips).

The writer keeps the skeleton's own channel layout (``Skeleton.channels``);
ASF-derived skeletons (``Skeleton.axes`` set) are written with
``Zrotation Yrotation Xrotation`` on every rotating joint. The Euler angles
written are continuous over time, as a graph editor shows them: each frame
the equivalent triple (whole turns, and the other branch of the middle angle)
nearest its neighbours (:func:`mocapkit.rotations.continuous_euler`), so
there are no spurious 360-degree or flipped-branch jumps.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MocapFormatError, SkeletonError
from .outputs import check_file_path
from .. import rotations as R
from ..motion import MAX_JOINTS, Motion, Skeleton, channel_starts, check_fps, source_part
from . import atomic_write
from ._numparse import line_of_offset, parse_floats
from .bvh_hierarchy import (MAX_INDENT, check_bvh_names, depth_first_order, exact_number, fps_from_frame_time,
                            hierarchy_text, shortest, with_frame_count)
from .bvh_comments import anchored, comment_count, comment_lines, keyword_count, motion_comments, with_comments
from .bvh_roots import COMMENT, Layout, around_take, is_comment, layout
from .euler_branches import NEAR_SOURCE_DEG, continuous_rotations, measured_text
from .kept_channels import kept_comments, kept_header, kept_text, kept_values
from .sources import bom_length, recall, remember
from ..words import plural
from .bvh_channels import motion_from_channels


__all__ = ["read_bvh", "write_bvh", "check_bvh_names", "read_layout", "source_fits", "source_values", "source_kept",
           "dropped_comments", "written_values",
           "MAX_INDENT", "NEAR_SOURCE_DEG"]

_CHANNELS = {c.lower(): c for c in ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation",
                                     "Xscale", "Yscale", "Zscale")}
SCALE_TOLERANCE = 1e-6
"""How far from 1 a scale channel's value may be and still read as unit scale (float noise of exporters)."""
_MOTION_RE = re.compile(rb"^[ \t]*MOTION[ \t]*\r?$", re.M)
_FRAMES_RE = re.compile(r"^\s*Frames\s*:\s*(\S+)\s*$")
_FRAME_TIME_RE = re.compile(r"^\s*Frame\s+Time\s*:\s*(\S+)\s*$")
_LINE_RE = re.compile(r"[^\n]*\n|[^\n]+$")


# -- reading -------------------------------------------------------------------


class _Block:
    __slots__ = ("kind", "index", "name", "line", "offset", "channels")

    def __init__(self, kind: str, index: int, name: str, line: int):
        self.kind = kind  # "joint" or "end"
        self.index = index
        self.name = name
        self.line = line
        self.offset: tuple[float, float, float] | None = None
        self.channels: tuple[str, ...] | None = None


def _lines(text: str):
    """(1-based line number, whitespace-separated tokens) of each line of ``text``, one line at a time; blank lines
    and comment lines (:func:`mocapkit.io.bvh_roots.is_comment`) are left out."""
    pos, ln, n = 0, 1, len(text)
    while pos < n:
        nl = text.find("\n", pos)
        stop = n if nl < 0 else nl
        toks = text[pos:stop].split()
        if toks and not toks[0].startswith(COMMENT):
            yield ln, toks
        pos, ln = stop + 1, ln + 1


def _parse_hierarchy(path: Path, text: str, motion_line: int | None):
    """Parse the HIERARCHY section; returns (names, parents, offsets, channels, end_parents, end_offsets, roots).

    Every ROOT's hierarchy is read (a prop, a camera exported beside the character): joints in file order, each
    root with parent -1; ``roots`` lists each ROOT's (first joint, first line, closing-brace line), lines 1-based.

    Line by line, token by token: memory is the joints' own records, not a
    list of every token (a 100,000-joint hierarchy took 24x its text that way).
    """

    def fail(reason: str, line: int):
        raise MocapFormatError(path, reason, line=line)

    last_line = max(1, text.count("\n") + (0 if text.endswith("\n") else 1))
    names: list[str] = []
    seen_at: dict[str, int] = {}  # name -> the line it was first given on
    parents: list[int] = []
    blocks: list[_Block] = []  # per joint
    end_parents: list[int] = []
    end_offsets: list[tuple[float, float, float]] = []
    stack: list[_Block] = []
    pending: _Block | None = None  # declared, waiting for its "{"
    root_seen = False
    roots: list[list[int]] = []  # [first joint, ROOT line, closing-brace line] of each ROOT
    seen_first = False
    channel_sets: dict[tuple[str, ...], tuple[str, ...]] = {}  # one tuple per distinct layout

    def rest_of_line(toks: list[str], k: int) -> tuple[list[str], int]:
        """Tokens after position k on the line, up to a "{"; returns (tokens, index of the next token)."""
        j = k + 1
        while j < len(toks) and toks[j] != "{":
            j += 1
        return toks[k + 1 : j], j

    def number(toks: list[str], j: int, what: str, line: int) -> float:
        if j >= len(toks):
            fail(f"{what} needs 3 numbers on its line", line)
        tok = toks[j]
        try:
            v = float(tok)
        except ValueError:
            fail(f"{what}: {tok!r} is not a number", line)
        if not np.isfinite(v):
            fail(f"{what}: {tok!r} is not a finite number", line)
        return v

    done = False
    for line, toks in _lines(text):
        k = 0
        if not seen_first:
            if toks[0] != "HIERARCHY":
                fail(f"expected HIERARCHY, found {toks[0]!r}", line)
            seen_first = True
            k = 1
        while k < len(toks):
            tok = toks[k]
            if pending is not None and tok != "{":
                fail(f"expected '{{' after {'End Site' if pending.kind == 'end' else repr(pending.name)}, found {tok!r}", line)
            if tok in ("ROOT", "JOINT"):
                if tok == "ROOT":
                    if stack or pending is not None:
                        fail("ROOT inside a joint", line)
                    root_seen = True
                    roots.append([len(names), line, line])
                else:
                    if not stack:
                        fail("JOINT outside the ROOT block" if root_seen else "expected ROOT before JOINT", line)
                    if stack[-1].kind == "end":
                        fail("JOINT inside an End Site", line)
                words, k = rest_of_line(toks, k)
                if not words:
                    fail(f"{tok} without a name", line)
                if len(names) >= MAX_JOINTS:
                    fail(f"more than {MAX_JOINTS:,} joints: not a skeleton mocapkit reads", line)
                name = " ".join(words)
                if name in seen_at:
                    fail(f"joint name {name!r} is used twice (first at line {seen_at[name]}); every joint needs its own", line)
                seen_at[name] = line
                pending = _Block("joint", len(names), name, line)
                names.append(name)
                parents.append(stack[-1].index if stack else -1)
                blocks.append(pending)
                continue
            if tok == "End":
                if not stack:
                    fail("End Site outside the ROOT block", line)
                if stack[-1].kind == "end":
                    fail("End Site inside an End Site", line)
                words, k = rest_of_line(toks, k)
                if not words or words[0] != "Site":
                    fail("expected 'End Site'", line)
                pending = _Block("end", stack[-1].index, "End Site", line)
                continue
            if tok == "{":
                if pending is None:
                    fail("unexpected '{'", line)
                stack.append(pending)
                pending = None
                k += 1
                continue
            if tok == "}":
                if not stack:
                    fail("unbalanced '}'", line)
                blk = stack.pop()
                if blk.kind == "end":
                    if blk.offset is None:
                        fail("End Site has no OFFSET", blk.line)
                    end_parents.append(blk.index)
                    end_offsets.append(blk.offset)
                else:
                    if blk.channels is None:
                        fail(f"joint {blk.name!r} has no CHANNELS", blk.line)
                    if blk.offset is None:
                        if parents[blk.index] >= 0:
                            fail(f"joint {blk.name!r} has no OFFSET", blk.line)
                        blk.offset = (0.0, 0.0, 0.0)
                    if not stack:  # a ROOT's block closed
                        roots[-1][2] = line
                k += 1
                continue
            if tok == "OFFSET":
                if not stack:
                    fail("OFFSET outside a joint", line)
                blk = stack[-1]
                if blk.offset is not None:
                    fail("a second OFFSET in the same block", line)
                blk.offset = (number(toks, k + 1, "OFFSET", line), number(toks, k + 2, "OFFSET", line),
                              number(toks, k + 3, "OFFSET", line))
                k += 4
                if k < len(toks):
                    fail(f"OFFSET has more than 3 numbers ({toks[k]!r})", line)
                continue
            if tok == "CHANNELS":
                if not stack or stack[-1].kind == "end":
                    fail("CHANNELS outside a joint", line)
                blk = stack[-1]
                if blk.channels is not None:
                    fail(f"joint {blk.name!r} has a second CHANNELS line", line)
                if blk.index + 1 < len(names):
                    fail(f"CHANNELS of joint {blk.name!r} must come before its child joints", line)
                words, _ = rest_of_line(toks, k)
                if not words:
                    fail("CHANNELS without a count", line)
                try:
                    count = int(words[0])
                except ValueError:
                    fail(f"CHANNELS count {words[0]!r} is not an integer", line)
                if not 0 <= count <= 9:
                    fail(f"CHANNELS count {count} is not between 0 and 9 (X/Y/Z position, rotation and scale)", line)
                given = words[1:]
                if len(given) != count:
                    fail(f"CHANNELS says {count} but names {len(given)}", line)
                chans = []
                for c in given:
                    canon = _CHANNELS.get(c.lower())
                    if canon is None:
                        fail(f"unknown channel {c!r} (expected X/Y/Z position/rotation/scale)", line)
                    if canon in chans:
                        fail(f"channel {canon} repeated", line)
                    chans.append(canon)
                blk.channels = channel_sets.setdefault(tuple(chans), tuple(chans))
                k += 1 + len(words)
                continue
            if tok == "MOTION":
                done = True
                break
            fail(f"unexpected {tok!r} in the hierarchy", line)
        if done:
            break

    if not seen_first:
        fail("empty file: no HIERARCHY" if motion_line is None else "no HIERARCHY before MOTION", motion_line or 1)
    if pending is not None or stack:
        open_name = (pending or stack[-1]).name
        where = last_line if motion_line is None else motion_line
        reason = f"unbalanced braces: joint {open_name!r} is not closed"
        if motion_line is None:
            reason = f"truncated file: ends inside joint {open_name!r} (unbalanced braces)"
        fail(reason, where)
    if not root_seen:
        fail("no ROOT joint in the hierarchy", motion_line or last_line)
    if motion_line is None:
        fail("truncated file: no MOTION section after the hierarchy", last_line)
    offsets = np.array([b.offset for b in blocks], dtype=np.float64).reshape(-1, 3)
    channels = tuple(b.channels for b in blocks)
    return names, parents, offsets, channels, end_parents, end_offsets, [tuple(r) for r in roots]


def read_bvh(path) -> Motion:
    """Read a BVH file.

    Parameters
    ----------
    path : str or path-like
        The ``.bvh`` file.

    Returns
    -------
    Motion
        ``rotations`` (F, J, 4) local quaternions, w first; ``root_positions``
        (F, 3) in file units (the root OFFSET repeated when the root has no
        position channels); ``translations`` (F, J, 3) when non-root joints
        have position channels; ``fps`` = 1 / Frame Time, snapped to the
        nearest integer when the printed Frame Time is that rate's rounded
        period (``.0083333`` -> 120.0; ``0.0333667`` -> 30000/1001); ``name`` = file stem.
        ``skeleton.channels`` keeps the file's channel layout.

    Raises
    ------
    MocapFormatError
        Naming the file, the line and the problem: malformed hierarchy,
        a non-finite OFFSET, missing or bad ``Frames:`` / ``Frame Time:`` (a
        frame time so small its rate is infinite included), non-numeric or
        infinite values (``nan`` is read as missing),
        a line with the wrong number of channels, a scale channel whose value
        is not 1 (naming the joint and frame), zero frames, or fewer or
        more data lines than ``Frames:`` says.
    """
    return _read_bvh(path)[0]


def read_layout(path) -> Layout:
    """Where the take lies in the BVH file ``path`` (:class:`mocapkit.io.bvh_roots.Layout`: its columns and the
    other roots), from its hierarchy alone: the text as the take was read (:func:`mocapkit.io.sources.recall`),
    else the file. A file that cannot be read or parsed has one root and no extras."""
    path = Path(path)
    data = recall(path)
    if data is None:
        try:
            data = path.read_bytes()
        except OSError:
            return Layout((0, 0), 0, (0, 0), (0, 0))
    try:
        return _parse_header(path, data)[1]
    except MocapFormatError:
        return Layout((0, 0), 0, (0, 0), (0, 0))


def _parse_header(path: Path, data: bytes):
    """The hierarchy of ``data`` (a BVH file's bytes): (the parsed hierarchy of every root, its Layout, the MOTION
    match, the MOTION line)."""
    m = _MOTION_RE.search(data)
    head_end = m.start() if m else len(data)
    header = data[bom_length(data):head_end].decode("utf-8", errors="replace")  # a byte-order mark is not text
    motion_line = header.count("\n") + 1 if m else None
    parsed = _parse_hierarchy(path, header, motion_line)
    return parsed, layout(parsed[0], parsed[3], parsed[6]), m, motion_line


def _read_bvh(path, data: bytes | None = None) -> tuple[Motion, np.ndarray, Layout]:
    """:func:`read_bvh`'s Motion, the file's numbers as written: (F, C) the take's channel values in file order
    (degrees and file units, NaN where the file says ``nan``), which :func:`write_bvh` needs to stay on the file's
    branches, and the take's :class:`~mocapkit.io.bvh_roots.Layout` (its columns of each line, the other roots).
    ``data``: the file's bytes as read before (:func:`mocapkit.io.sources.recall`), else the file is read (and its
    bytes remembered: :func:`mocapkit.io.sources.remember`)."""
    path = Path(path)
    if data is None:
        try:
            data = path.read_bytes()
        except OSError as e:
            raise MocapFormatError(path, f"cannot read: {e.strerror or e}") from None
        remember(path, data)

    (names, parents, offsets, channels, end_parents, end_offsets, _), where, m, motion_line = _parse_header(path, data)

    # "Frames:" and "Frame Time:" lines after MOTION (blank lines allowed between).
    pos = m.end()
    if pos < len(data) and data[pos:pos + 1] == b"\n":
        pos += 1
    line = motion_line
    frames_decl = None
    frame_time = None
    while frame_time is None:
        if pos >= len(data):
            what = "Frames:" if frames_decl is None else "Frame Time:"
            raise MocapFormatError(path, f"truncated file: no {what} line after MOTION", line=line)
        nl = data.find(b"\n", pos)
        stop = len(data) if nl < 0 else nl
        text = data[pos:stop].decode("utf-8", errors="replace")
        line += 1
        pos = stop + 1
        if not text.strip() or is_comment(text):
            continue
        if frames_decl is None:
            fm = _FRAMES_RE.match(text)
            if fm is None:
                raise MocapFormatError(path, f"expected 'Frames: N', found {text.strip()!r}", line=line)
            try:
                frames_decl = int(fm.group(1))
            except ValueError:
                raise MocapFormatError(path, f"Frames: {fm.group(1)!r} is not an integer", line=line) from None
            if frames_decl <= 0:
                raise MocapFormatError(path, f"zero frames (Frames: {frames_decl})", line=line)
        else:
            tm = _FRAME_TIME_RE.match(text)
            if tm is None:
                raise MocapFormatError(path, f"expected 'Frame Time: SECONDS', found {text.strip()!r}", line=line)
            ft_token = tm.group(1)
            try:
                frame_time = float(ft_token)
            except ValueError:
                raise MocapFormatError(path, f"Frame Time {tm.group(1)!r} is not a number", line=line) from None
            if not (np.isfinite(frame_time) and frame_time > 0):
                raise MocapFormatError(path, f"Frame Time must be a positive number, got {tm.group(1)}", line=line)
            if not np.isfinite(1.0 / frame_time):
                raise MocapFormatError(path, f"Frame Time {tm.group(1)} is too small: 1 / it is not a finite rate",
                                       line=line)
            try:
                fps = check_fps(fps_from_frame_time(ft_token))
            except SkeletonError as exc:
                raise MocapFormatError(path, f"Frame Time {ft_token} s: {exc}", line=line) from None
    first_data_line = line + 1
    ncols = sum(len(c) for c in channels)
    if ncols == 0:
        raise MocapFormatError(path, "the hierarchy declares no channels", line=motion_line)

    body = np.frombuffer(data, dtype=np.uint8)[min(pos, len(data)):]
    values, counts, err = parse_floats(body, comment=COMMENT.encode())  # comment lines: read as nothing
    if err >= 0:
        bad_line = line_of_offset(body, err)
        tok_end = err
        while tok_end < body.shape[0] and body[tok_end] not in (9, 10, 11, 12, 13, 32):
            tok_end += 1
        tok = body[err:min(tok_end, err + 40)].tobytes().decode("utf-8", errors="replace")
        raise MocapFormatError(path, f"non-numeric value {tok!r} in the motion data", line=first_data_line + bad_line)
    nonblank = np.flatnonzero(counts)
    wrong = nonblank[counts[nonblank] != ncols]
    if wrong.size:
        k = int(wrong[0])
        hint = " (truncated file?)" if k == nonblank[-1] and counts[k] < ncols else ""
        raise MocapFormatError(
            path, f"frame line has {plural(counts[k], 'value')}, the hierarchy declares {plural(ncols, 'channel')}{hint}",
            line=first_data_line + k,
        )
    nframes = nonblank.size
    if nframes == 0:
        raise MocapFormatError(path, f"zero frames: Frames: says {frames_decl} but there is no motion data",
                               line=first_data_line - 1)
    if nframes < frames_decl:
        last = first_data_line + int(nonblank[-1])
        raise MocapFormatError(
            path, f"truncated file: Frames: says {frames_decl} but the data holds only {plural(nframes, 'frame')}", line=last
        )
    if nframes > frames_decl:
        extra = first_data_line + int(nonblank[frames_decl])
        raise MocapFormatError(
            path, f"more frame lines ({nframes}) than Frames: says ({frames_decl})", line=extra
        )

    table = values.reshape(nframes, ncols)
    if where.extras:  # the take's hierarchy and columns; the other roots stay in the file's text
        (j0, j1), (c0, c1) = where.joints, where.columns
        names, channels, offsets = names[j0:j1], channels[j0:j1], offsets[j0:j1]
        parents = [p - j0 if p >= 0 else -1 for p in parents[j0:j1]]
        ends = [k for k, p in enumerate(end_parents) if j0 <= p < j1]
        end_parents, end_offsets = [end_parents[k] - j0 for k in ends], [end_offsets[k] for k in ends]
        table = np.ascontiguousarray(table[:, c0:c1])
    infinite = np.flatnonzero(np.isinf(table).any(axis=1))
    if infinite.size:  # NaN means missing; an infinite angle or position means nothing
        f = int(infinite[0])
        c = int(np.flatnonzero(np.isinf(table[f]))[0])
        raise MocapFormatError(
            path, f"infinite value {float(table[f, c])!r} in frame {f + 1} (column {c + 1 + where.columns[0]}) of the "
            "motion data",
            line=first_data_line + int(nonblank[f]),
        )
    _check_unit_scale(path, names, channels, table, first_data_line + nonblank)
    try:
        skeleton = Skeleton(
            joint_names=tuple(names),
            parents=np.array(parents, dtype=np.int64),
            offsets=offsets,
            end_site_parents=np.array(end_parents, dtype=np.int64),
            end_site_offsets=np.array(end_offsets, dtype=np.float64).reshape(-1, 3),
            channels=channels,
        )
    except SkeletonError as e:
        raise MocapFormatError(path, str(e)) from None
    return motion_from_channels(skeleton, table, fps, path.stem, path), table, where


def _check_unit_scale(path: Path, names, channels, table: np.ndarray, lines: np.ndarray) -> None:
    """Refuse a scale channel whose value is not 1 (within :data:`SCALE_TOLERANCE`) in any frame.

    ``table`` (F, C) holds the file's values in file order, ``lines`` (F,) the file line of each frame. A
    Skeleton has no scale, so a unit scale is all mocapkit can read and write back as the file had it; a
    scaled joint would move its children where the offsets do not put them.
    """
    col = 0
    for name, chans in zip(names, channels):
        for ch in chans:
            if ch.endswith("scale"):
                v = table[:, col]
                bad = np.flatnonzero(~(np.abs(v - 1.0) <= SCALE_TOLERANCE))
                if bad.size:
                    f = int(bad[0])
                    raise MocapFormatError(
                        path, f"joint {name!r}: {ch} is {float(v[f])!r} in frame {f + 1}; scale channels are "
                        f"supported only at 1 (a skeleton has no scale)", line=int(lines[f]))
            col += 1


# -- writing -------------------------------------------------------------------

_POS3 = ("Xposition", "Yposition", "Zposition")
_ZYX = ("Zrotation", "Yrotation", "Xrotation")

def _rotating_joints(rotations: np.ndarray) -> np.ndarray:
    """(J,) bool: joints with a (finite) quaternion of ``rotations`` (F, J, 4) away from the identity."""
    v = np.abs(rotations[..., 1:])
    return np.any(np.where(np.isfinite(v), v, 0.0) > 1e-12, axis=(0, 2))


def _moving_axes(local: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(J, 3) bool: axes on which a (finite) local offset (F, J, 3) differs from the joint's ``offsets`` (J, 3)."""
    d = np.abs(local - offsets)
    return np.any(np.where(np.isfinite(d), d, 0.0) > 0.0, axis=0)


def _write_channels(motion: Motion) -> tuple[tuple[str, ...], ...]:
    """Channel layout that represents ``motion`` exactly as BVH."""
    sk = motion.skeleton
    J = sk.num_joints
    rotating = _rotating_joints(motion.rotations)
    moving = _moving_axes(motion.local_offsets(), sk.offsets)
    out = []
    for j in range(J):
        if sk.axes is None:
            chans = list(sk.joint_channels(j))
            if not sk.rotation_order(j) and rotating[j]:
                chans += list(_ZYX)
        else:
            has_rot = bool(sk.rotation_order(j)) or bool(rotating[j])
            chans = list(_POS3) if j == 0 else []
            chans += list(_ZYX) if has_rot else []
        if any(moving[j, k] and _POS3[k] not in chans for k in range(3)):
            chans = list(_POS3) + [c for c in chans if not c.endswith("position")]
        out.append(tuple(chans))
    if not any(out):  # a BVH needs at least one channel per frame line
        out[0] = _POS3
    return tuple(out)


def write_bvh(motion: Motion, path, precision: int = 6, allow_nan: bool = False, like=None) -> None:
    """Write ``motion`` as a BVH file (atomically: a failed write leaves no file).

    Parameters
    ----------
    motion : Motion
        The clip. With ``skeleton.axes`` None its own channel layout is kept
        (channels are added where the motion needs them: rotation on a joint
        declared without one, positions where offsets move); ASF-derived
        skeletons get ``Xposition Yposition Zposition`` on the root and
        ``Zrotation Yrotation Xrotation`` on every rotating joint. Joints are
        written depth first (each subtree contiguous, as BVH requires); a
        skeleton in another topological order reads back in that order.
    path : str or path-like
        Target ``.bvh`` file.
    precision : int
        Decimals of every channel value (degrees and file units). OFFSETs are
        written exactly (shortest round-trip form).
    allow_nan : bool
        Write missing values as ``nan`` (which :func:`read_bvh` reads back)
        instead of raising.
    like : str or path-like, optional
        The BVH file ``motion`` was read from (and then cleaned, denoised,
        ...). Where the two agree on joints and channels and the take holds the file's frames (all, or a
        contiguous slice's: :func:`mocapkit.motion.source_part`), every (frame, joint) cell whose rotation,
        position and offset are bit for bit what the file gives keeps the file's own text (a frame with no changed
        cell is the file's line, byte for byte, with its line ending; the header too when the
        skeleton and rate are the file's), and a changed joint's rotation is
        written as the Euler triple (whole turns, either branch of the middle
        angle) nearest the file's numbers of that cell where it turned less than
        :data:`NEAR_SOURCE_DEG` from the file's, else nearest its neighbours
        (:func:`mocapkit.io.euler_branches.continuous_rotations`; a repaired
        flip is written next to its neighbours, never on the branch of the
        broken value it replaces). An .npz made from a BVH keeps that file's
        text while the take is on its joints, channels and frames
        (:func:`mocapkit.io.kept_channels.kept_text`): as ``like`` it is that
        BVH, byte for byte where nothing changed. One that keeps only the file's
        numbers (made before 0.14.0, or from a cut take) gives the
        same choice of each cell's numbers, the text written anew (a number still the file's in its shortest
        exact form, not rounded to ``precision``). So a take that comes back unchanged is the same
        file, and a change touches only its own numbers. Without ``like`` (or
        when it is not such a file) each joint's angles start as the plain
        conversion gives them and every next frame takes the triple nearest
        the one before (an Euler filter; not across a jump of the rotation
        itself over 90 degrees). Ignored when ``like`` is not such a file.
        The file's other ROOTs (:mod:`mocapkit.io.bvh_roots`) and comment lines are written back as its text
        (:func:`source_fits` says whether ``motion`` is written so).

    Raises
    ------
    MocapFormatError
        When the motion has NaN and ``allow_nan`` is False, has no frames, or
        a joint name BVH cannot hold (:func:`check_bvh_names`); nothing is
        written then.
    """
    path = Path(check_file_path(path))  # "out/x/" names a folder: refused, not written as out/x
    precision = int(precision)
    if precision < 0:
        raise ValueError(f"precision must be >= 0, got {precision}")
    check_bvh_names(path, motion.skeleton.joint_names)
    F = motion.num_frames
    if F == 0:
        raise MocapFormatError(path, "motion has no frames; BVH needs at least one")
    if not allow_nan:
        bad = np.any(np.isnan(motion.rotations), axis=(1, 2)) | np.any(np.isnan(motion.root_positions), axis=1)
        if motion.translations is not None:
            bad |= np.any(np.isnan(motion.translations[:, 1:]), axis=(1, 2))
        n = int(np.count_nonzero(bad))
        if n:
            raise MocapFormatError(path, f"motion has missing values (NaN) in {plural(n, 'frame')}; fill them or save as .npz")

    out_motion, channels, order, source, values = _written(motion, like)
    sk = motion.skeleton
    if isinstance(source, _LikeSource):
        _write_like(path, out_motion, values, channels, source, precision)
        return
    header = kept_header(like, out_motion) if isinstance(source, _Kept) else None  # the source BVH's own text
    end = "\r\n" if header and header.endswith("\r\n") else "\n"
    parts = [header] if header else hierarchy_text(sk, channels, order) + [
        f"MOTION\nFrames: {F}\nFrame Time: {shortest(1.0 / motion.fps)}\n"]
    C = values.shape[1]
    row = " ".join([f"%.{precision}f"] * C) + end
    block = max(1, 2**18 // max(C, 1))  # frames formatted at once: a few MB of text, not the whole take
    kept, fmt = (source.values if isinstance(source, _Kept) else None), f"%.{precision}f"  # an .npz's file numbers
    measured = None if kept is None else measured_text(values, channels, kept)  # a filled cell's measured channels
    between = (kept_comments(like, F) if kept is not None else None) or [[]] * (F + 1)  # the motion's comment lines
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write("".join(parts))
        for f0 in range(0, F, block):
            rows = values[f0 : f0 + block]
            if kept is None:
                fh.write((row * rows.shape[0]) % tuple(rows.ravel().tolist()))
                continue
            file = kept[f0 : f0 + block]
            own = ((rows == file) | measured[f0 : f0 + block]).tolist()  # the file's number: exact, never rounded
            fh.write("".join("".join(c) + " ".join(exact_number(w) if o else fmt % v for v, w, o in zip(r, q, k)) + end
                             for r, q, k, c in zip(rows.tolist(), file.tolist(), own, between[f0 : f0 + block])))
        fh.write("".join(between[F]))


def written_values(motion: Motion, like=None) -> np.ndarray:
    """The numbers (F, C) a BVH written from ``motion`` holds (:func:`write_bvh`'s, ``like`` by default
    ``motion.source_file``): file units and degrees, joints depth first, each with its channels as written (a take
    read from a BVH: the file's, :meth:`~mocapkit.motion.Motion.channel_names`). Where the take holds that file's
    frames (all, or a slice's) an unchanged cell is the file's own number, a changed angle on the file's branch
    (:func:`mocapkit.io.euler_branches.continuous_rotations`), and in a cell the file leaves partly ``nan`` each
    channel it measures and the fill kept (:func:`mocapkit.io.euler_branches.measured_text`) the file's own number,
    bit for bit, as the file written holds it; else each joint's angles continuous over frames:
    the joint angles as the file gives them (CMU's 01_01.bvh Hips past 180 degrees), not the plain conversion of
    :meth:`~mocapkit.motion.Motion.channel_values`."""
    return _written(motion, motion.source_file if like is None else like)[4]


def _written(motion: Motion, like):
    """``(out_motion, channels, order, source, values)`` of :func:`write_bvh`: the take on the layout written
    (:func:`_as_written`), its depth-first order, what it keeps of ``like`` and the numbers written (F, C)."""
    out_motion, channels = _as_written(motion)
    values = out_motion.channel_values()
    # BVH lists joints depth first; a skeleton in another topological order (e.g. from an ASF
    # hierarchy) is written in depth-first order with its channel columns permuted to match.
    sk = motion.skeleton
    order = depth_first_order(sk)
    source = _source_numbers(like, out_motion, order)
    continuous_rotations(values, channels, source)
    if source is not None:  # a filled cell's measured channels: the file's numbers, as the writers keep their text
        values = np.where(measured_text(values, channels, source.values), source.values, values)
    if order != list(range(sk.num_joints)):
        starts = channel_starts(channels)
        values = values[:, [k for j in order for k in range(starts[j], starts[j + 1])]]
    return out_motion, channels, order, source, values


def _as_written(motion: Motion) -> tuple[Motion, tuple[tuple[str, ...], ...]]:
    """``motion`` on the skeleton and channel layout :func:`write_bvh` writes (:func:`_write_channels`)."""
    sk = motion.skeleton
    channels = _write_channels(motion)
    out_sk = Skeleton(
        joint_names=sk.joint_names,
        parents=sk.parents,
        offsets=sk.offsets,
        end_site_parents=sk.end_site_parents,
        end_site_offsets=sk.end_site_offsets,
        channels=channels,
    )
    out_motion = Motion(
        skeleton=out_sk,
        rotations=motion.rotations,
        root_positions=motion.root_positions,
        fps=motion.fps,
        name=motion.name,
        translations=motion.translations,
        source_file=motion.source_file,
        source_frames=motion.source_frames,  # the file's frames it holds: a slice is written with their lines
    )
    return out_motion, channels


def source_fits(motion: Motion, like) -> bool:
    """Whether :func:`write_bvh` writes ``motion`` like the BVH file ``like`` (its text kept where no cell changed,
    its other roots and comments carried through): the same joints, channels and frame count as the take read
    from it, and that file's text still kept (:func:`mocapkit.io.sources.recall`)."""
    if like is None or motion.num_frames == 0:
        return False
    out_motion, _ = _as_written(motion)
    return _like_source(like, out_motion, depth_first_order(motion.skeleton)) is not None


def source_values(motion: Motion, like) -> tuple[np.ndarray | None, tuple[tuple[str, ...], ...]]:
    """The numbers ``(F, C)`` of the file ``like`` (a BVH ``motion`` was read from, or an .npz keeping such a file's,
    :mod:`mocapkit.io.kept_channels`) in the channel layout :func:`write_bvh` writes ``motion`` with, and that
    layout; None for the numbers where ``like`` is not such a file (other joints, channels or frames)."""
    values, channels, _, _, _ = source_kept(motion, like)
    return values, channels


def source_kept(motion: Motion, like) -> tuple[np.ndarray | None, tuple[tuple[str, ...], ...], str | None,
                                                list[list[str]] | None, bytes | None]:
    """``(values, channels, header, comments, text)``: what an .npz made from ``motion`` keeps of the file ``like``
    (:mod:`mocapkit.io.kept_channels`), ``like``'s text parsed once.

    ``values``, ``channels``: as :func:`source_values`. ``header``: the header text (its lines up to Frame Time, as
    read) of the BVH ``like`` where ``motion`` has that file's skeleton, channels, frame count and rate, and the file
    no other ROOT; else None. ``comments``: the comment lines between its motion lines (or kept by an .npz made from
    one) that a BVH written from ``motion`` keeps, ``F + 1`` lists, the lines before each frame and after the last
    (line endings kept, :func:`mocapkit.io.bvh_comments.motion_comments`), where ``motion`` has that file's joints,
    channels and frame count; else None. ``text``: the bytes of that BVH (read from it, or kept by an .npz made
    from it: :func:`mocapkit.io.kept_channels.kept_text`) where ``motion`` has its joints, channels and frame count,
    so that a BVH written from the .npz keeps every unchanged cell's text; else None."""
    out_motion, channels = _as_written(motion)
    if motion.num_frames == 0:
        return None, channels, None, None, None
    source = _source_numbers(like, out_motion, depth_first_order(motion.skeleton))
    if source is None:
        return None, channels, None, None, None
    if isinstance(source, _Kept):
        return source.values, channels, None, kept_comments(like, motion.num_frames), None
    if not source.whole:  # a part of the file's frames: its numbers; the file's text is kept for the whole take only
        return source.values, channels, None, None, None
    header = None if source.header is None or source.layout.extras else "".join(source.header)
    comments = [[t for t in lines if t.strip()] for lines in source.between]  # what an .npz keeps: comments alone
    return source.values, channels, header, comments, source.text


def _source_numbers(like, motion: Motion, order: list[int]) -> "_LikeSource | _Kept | None":
    """What ``motion`` (as written: :func:`_as_written`) keeps of ``like``'s numbers: the source BVH itself
    (:func:`_like_source`: its text too), else the numbers an .npz made from one keeps (:func:`_kept_source`),
    else None (no ``like``, or not such a file for these joints, channels and frames)."""
    if like is None or like is False:
        return None
    source = _like_source(like, motion, order)
    return source if source is not None else _kept_source(like, motion, order)


@dataclass(frozen=True)
class _Kept:
    """The source numbers an .npz keeps (:mod:`mocapkit.io.kept_channels`) and the cells whose rotation changed."""

    turned: np.ndarray  # (F, J) bool
    values: np.ndarray  # (F, C) float


def _kept_source(like, motion: Motion, order: list[int]) -> _Kept | None:
    """The numbers of the BVH an .npz ``like`` was made from, where they fit ``motion`` (written in file order)."""
    if like is None or like is False or order != list(range(motion.skeleton.num_joints)):
        return None
    values = kept_values(like, motion.skeleton.channels, motion.num_frames)
    if values is None:
        return None
    ref = motion_from_channels(motion.skeleton, values, motion.fps, motion.name, Path(like))
    return _Kept(_differs(motion.rotations, ref.rotations), values)


@dataclass(frozen=True)
class _LikeSource:
    """What :func:`write_bvh` keeps of the file a motion was read from: its header and data lines, and which cells changed."""

    header: list[str] | None  # the lines up to Frame Time (line endings kept), when the skeleton and rate are the file's
    lines: list[str]  # the F data lines, as the file gives them (line endings kept)
    turned: np.ndarray  # (F, J) bool: cells whose rotation differs from the file's
    moved: np.ndarray  # (F, J) bool: cells whose position or offset differs from the file's
    values: np.ndarray  # (F, C) float: the file's numbers (its own 360-degree and Euler branches; NaN for "nan")
    layout: Layout  # the take's columns of each line and the other roots, kept as the file's text
    around: tuple[list[str], list[str]] | None  # header lines before the take's ROOT and after it (around_take)
    between: list[list[str]]  # the comment and blank lines before each data line, and after the last (bvh_comments)
    inside: list[tuple[int, str]]  # the comments inside the take's ROOT block, anchored (bvh_comments.anchored)
    keywords: int  # the hierarchy keywords of the take's ROOT block as the file writes it
    text: bytes  # the file's bytes as read, which an .npz made from the take keeps (kept_channels.TEXT_KEYS)
    whole: bool = True  # the take holds every frame of the file (else a contiguous part: motion.source_part)
    left_out: int = 0  # the comment lines of the motion section a part leaves out (those among other frames)


def _differs(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Elementwise "not the same float" (NaN equals NaN), reduced over the last axis."""
    return np.any((a != b) & ~(np.isnan(a) & np.isnan(b)), axis=-1)


def _like_source(like, motion: Motion, order: list[int]) -> _LikeSource | None:
    """The source BVH's lines and changed cells, or None when ``like`` is not the file ``motion`` came from: the BVH
    itself, or an .npz made from it that keeps its text (:func:`mocapkit.io.kept_channels.kept_text`)."""
    like = Path(like)
    if like.suffix.lower() not in (".bvh", ".npz") or order != list(range(motion.skeleton.num_joints)):
        return None
    # the text as the take was read from it, even if the file was removed or changed since; or as an .npz keeps it
    data = recall(like) if like.suffix.lower() == ".bvh" else kept_text(like, ".bvh")
    if data is None:
        return None
    try:
        ref, table, where = _read_bvh(like, data)
    except MocapFormatError:
        return None
    sk, rsk = motion.skeleton, ref.skeleton
    part = source_part(motion, ref.num_frames)  # the file's frames the take holds: all of them, or a slice's
    if (rsk.joint_names != sk.joint_names or not np.array_equal(rsk.parents, sk.parents)
            or tuple(map(tuple, rsk.channels)) != tuple(map(tuple, sk.channels)) or part is None):
        return None
    text = data
    lines = _LINE_RE.findall(data.decode("utf-8", errors="replace"))  # lines as the reader counts them (at "\n")
    at = next((i for i, t in enumerate(lines) if _FRAME_TIME_RE.match(t)), None)  # as the reader finds it
    if at is None:
        return None
    data, between = motion_comments(lines[at + 1:], blanks=True)  # blank lines kept: an unchanged take is the file
    if len(data) != ref.num_frames:
        return None
    whole, left_out = len(part) == ref.num_frames, comment_count(between)
    if not whole:  # a slice: its frames' lines and the comments before each (those after the last at the file's end)
        cut = slice(part.start, part.stop)
        data, between = data[cut], between[cut] + [between[-1] if part.stop == ref.num_frames else []]
        ref, table, lines = ref[cut], table[cut], with_frame_count(lines, at, motion.num_frames)
    left_out -= comment_count(between)  # the motion section's comments among other frames: not written
    turned = _differs(motion.rotations, ref.rotations)
    moved = _differs(motion.local_offsets(), ref.local_offsets())
    same_header = (ref.fps == motion.fps and np.array_equal(rsk.offsets, sk.offsets)
                   and np.array_equal(rsk.end_site_parents, sk.end_site_parents)
                   and np.array_equal(rsk.end_site_offsets, sk.end_site_offsets))
    around = None if same_header else around_take(
        lines, where, next((i for i, t in enumerate(lines) if _MOTION_RE.match(t.encode())), None))
    if not same_header and around is None:
        return None
    block = [] if same_header else lines[where.lines[0] - 1:where.lines[1]]
    return _LikeSource(lines[: at + 1] if same_header else None, data, turned, moved, table, where, around, between,
                       anchored(block), keyword_count(block), text, whole, left_out)



def _new_block(source: _LikeSource, sk, channels) -> tuple[str, int]:
    """The take's ROOT block written anew (the file's offsets changed), with the comments it held each after the
    same element (:func:`mocapkit.io.bvh_comments.with_comments`), and how many of them it could not place (all,
    or none)."""
    text = "".join(hierarchy_text(sk, channels, list(range(sk.num_joints)))[1:])
    if not source.inside:
        return text, 0
    placed = with_comments(text, source.inside, source.keywords)
    return (text, len(source.inside)) if placed is None else (placed, 0)


def dropped_comments(motion: Motion, like) -> int:
    """How many comment lines of the BVH file ``like`` a BVH written from ``motion`` (:func:`write_bvh` with
    ``like``) leaves out: none when it is written like that file (the header's, the motion section's and, where
    the take's hierarchy is written anew, those inside it, :mod:`mocapkit.io.bvh_comments`), every one when it is
    not (another frame count, rate or skeleton). 0 where ``like`` is no BVH whose text was read."""
    if like is None or Path(like).suffix.lower() != ".bvh" or motion.num_frames == 0:
        return 0
    data = recall(Path(like))
    total = comment_lines(data) if data is not None else 0
    if total == 0:
        return 0
    out_motion, channels = _as_written(motion)
    source = _like_source(like, out_motion, depth_first_order(motion.skeleton))
    if source is None:
        return total
    return source.left_out + (0 if source.header is not None else _new_block(source, out_motion.skeleton, channels)[1])


def _write_like(path: Path, motion: Motion, values: np.ndarray, channels, source: _LikeSource, precision: int) -> None:
    """Write ``values`` (F, C) keeping ``source``'s text wherever a cell did not change: a joint's rotation channels
    are written where its rotation changed, its position channels where its position did (a 6-channel joint whose
    rotation was repaired keeps the file's position text), and its scale channels never (always 1, as read); in a
    cell the file left partly ``nan`` the channels it measured keep their text where the fill put them back
    (:func:`~mocapkit.io.euler_branches.measured_text`). The changed angles in ``values`` are already on the
    branch of their unchanged neighbours (:func:`_continuous_rotations`)."""
    sk = motion.skeleton
    F = motion.num_frames
    starts = channel_starts(channels)
    first = source.layout.columns[0]  # the take's first number on a line: the other roots' numbers are kept as text
    is_rot = np.array([c.endswith("rotation") for cs in channels for c in cs], dtype=bool)
    is_pos = np.array([c.endswith("position") for cs in channels for c in cs], dtype=bool)
    fmt = f"%.{precision}f"
    kept = measured_text(values, channels, source.values)  # a filled cell's measured channels: the file's text
    with atomic_write(path, "w", encoding="utf-8", newline="") as fh:
        if source.header is not None:
            fh.write("".join(source.header))
        else:  # the take's hierarchy written anew between the file's own lines (comments, other roots)
            before, after = source.around
            block, _ = _new_block(source, sk, channels)  # comments it cannot place: said by dropped_comments
            fh.write("".join(before + [block] + after + [f"MOTION\nFrames: {F}\nFrame Time: {shortest(1.0 / motion.fps)}\n"]))
        for f in range(F):
            fh.write("".join(source.between[f]))
            line = source.lines[f]
            if source.header is None and not line.endswith("\n"):
                line += "\n"
            turned, moved = source.turned[f], source.moved[f]
            joints = np.flatnonzero(turned | moved)
            if joints.size == 0:
                fh.write(line)
                continue
            body = line.rstrip("\r\n")
            tokens = body.split()
            for j in joints:
                for c in range(starts[j], starts[j + 1]):
                    if not ((turned[j] and is_rot[c]) or (moved[j] and is_pos[c])) or kept[f, c]:
                        continue
                    tokens[first + c] = fmt % values[f, c]
            fh.write(" ".join(tokens) + (line[len(body):] or "\n"))
        fh.write("".join(source.between[F]))
