"""The HIERARCHY section of a BVH file as text: the names it can hold, the joints' file order, the lines written.

A BVH lists joints depth first, each subtree contiguous, with a ``ROOT`` / ``JOINT`` line naming the joint,
an ``OFFSET`` and a ``CHANNELS`` line, and an ``End Site`` block per end site. :func:`mocapkit.io.bvh.write_bvh`
writes a skeleton's hierarchy with :func:`hierarchy_text`. The ``Frame Time:`` line that closes the header gives the
take's rate: read by :func:`fps_from_frame_time` as the rate it was written for, written exactly by :func:`shortest`.
"""

from __future__ import annotations

import re
from decimal import Decimal, InvalidOperation

from ..errors import MocapFormatError
from ..motion import Skeleton

__all__ = ["MAX_INDENT", "NTSC_FPS", "check_bvh_names", "depth_first_order", "fps_from_frame_time", "hierarchy_text",
           "shortest", "with_frame_count"]

_FRAMES_LINE = re.compile(r"^\s*Frames\s*:\s*(\S+)\s*$")


def shortest(x: float) -> str:
    """``x`` in its shortest round-trip decimal form (an OFFSET or a frame time written exactly)."""
    return repr(float(x))

def exact_number(x: float) -> str:
    """``x`` as a motion line's number that reads back as ``x`` exactly: its shortest round-trip form, a whole number
    without its ``.0`` (a file's ``0`` stays ``0``)."""
    t = repr(float(x))
    return t[:-2] if t.endswith(".0") else t


NTSC_FPS = tuple(x for r in (24, 30, 48, 60, 120, 240) for x in (r * 1000 / 1001, float(f"{r * 1000 / 1001:.5g}")))
"""The NTSC rates (r * 1000 / 1001: 23.976..., 29.97..., 59.94...), each followed by the decimal it is called by
(23.976, 29.97, 59.94): rates a Frame Time is read as when it is one of theirs at the digits it shows."""


def fps_from_frame_time(token: str) -> float:
    """Frames per second from the ``Frame Time:`` token.

    ``1 / t`` is snapped to the integer ``r``, else to an NTSC rate
    (:data:`NTSC_FPS`), when the printed frame time is ``1 / r`` rounded to
    the digits it shows and ``1 / t`` is within 1e-3 relative of ``r``:
    ``.0083333`` gives 120, NTSC's ``0.0333667`` or ``0.033367`` (0.1 % from
    30) 30000/1001. A token with 15 or more significant digits (mocapkit
    writes ``repr(1 / fps)``) gives the rate with fewest decimals whose
    ``1 / fps`` is that number, so a written rate reads back as it was (29.97
    stays 29.97, where ``1 / t`` is 29.970000000000002).
    """
    t = float(token)
    fps = 1.0 / t
    try:
        shown = Decimal(token).as_tuple()
    except InvalidOperation:
        return fps
    last_digit = shown.exponent
    if not isinstance(last_digit, int):
        return fps
    half = 0.5 * 10.0**last_digit * (1 + 1e-9)
    for r in (round(fps), *NTSC_FPS):
        if r >= 1 and abs(fps - r) <= 1e-3 * r and abs(t - 1.0 / r) <= half:
            return float(r)
    if len(shown.digits) - next((i for i, d in enumerate(shown.digits) if d), 0) >= 15:
        for k in range(16):
            r = round(fps, k)
            if r > 0 and 1.0 / r == t:
                return r
    return fps


MAX_INDENT = 32
"""Most tabs the writer puts before a line: a 100,000-deep chain would otherwise need 5e9 of them."""


def check_bvh_names(path, names) -> None:
    """Refuse joint names a BVH file cannot hold, naming the first such joint.

    A BVH name is the rest of its ``ROOT`` / ``JOINT`` line, read back as its
    whitespace-separated words joined by one space. So a name must be
    encodable as UTF-8 (no lone surrogates), non-empty, hold no brace, and
    have no whitespace but single inner spaces (``"Bip01 L Thigh"`` is fine;
    a tab, a newline, a double space or a leading space is not), or it would
    not read back as itself.

    Raises
    ------
    MocapFormatError
        One line naming ``path``, the joint (``ascii()`` of its name) and the problem.
    """
    for j, name in enumerate(names):
        problem = None
        try:
            name.encode("utf-8")
        except UnicodeEncodeError:
            problem = "is not encodable as UTF-8 (a lone surrogate?)"
        else:
            if not name:
                problem = "is empty"
            elif "{" in name or "}" in name:
                problem = "holds a brace"
            elif " ".join(name.split()) != name:
                problem = "holds whitespace other than single spaces between words"
        if problem is not None:
            raise MocapFormatError(path, f"joint {j} name {ascii(name)} {problem}: BVH cannot hold it; rename the joint")


def depth_first_order(sk: Skeleton) -> list[int]:
    """Joint indices in depth-first (file) order, children in index order."""
    children: list[list[int]] = [[] for _ in range(sk.num_joints)]
    for j in range(1, sk.num_joints):
        children[int(sk.parents[j])].append(j)
    order: list[int] = []
    todo = [0]
    while todo:
        j = todo.pop()
        order.append(j)
        todo.extend(reversed(children[j]))
    return order


def indent(depth: int) -> str:
    """Leading tabs of a line at nesting ``depth``, capped at :data:`MAX_INDENT` (readers ignore them)."""
    return "\t" * min(depth, MAX_INDENT)


def hierarchy_text(sk: Skeleton, channels, order: list[int]) -> list[str]:
    """The HIERARCHY section as a list of strings, joints written in depth-first ``order``.

    Indentation is capped at :data:`MAX_INDENT` tabs, so the text grows
    linearly with the number of joints however deep the hierarchy is.
    """
    J = sk.num_joints
    ends: list[list[int]] = [[] for _ in range(J)]
    for e, p in enumerate(sk.end_site_parents):
        ends[int(p)].append(e)
    parts = ["HIERARCHY\n"]
    open_joints: list[int] = []

    def close() -> None:
        open_joints.pop()
        parts.append(indent(len(open_joints)) + "}\n")

    for j in order:
        p = int(sk.parents[j])
        while open_joints and open_joints[-1] != p:
            close()
        ind = indent(len(open_joints))
        off = sk.offsets[j]
        chans = channels[j]
        parts.append(
            f"{ind}{'ROOT' if j == 0 else 'JOINT'} {sk.joint_names[j]}\n{ind}{{\n"
            f"{ind}\tOFFSET {shortest(off[0])} {shortest(off[1])} {shortest(off[2])}\n"
            f"{ind}\tCHANNELS {len(chans)}{''.join(' ' + c for c in chans)}\n"
        )
        for e in ends[j]:
            eo = sk.end_site_offsets[e]
            parts.append(
                f"{ind}\tEnd Site\n{ind}\t{{\n{ind}\t\tOFFSET {shortest(eo[0])} {shortest(eo[1])} {shortest(eo[2])}\n{ind}\t}}\n"
            )
        open_joints.append(j)
    while open_joints:
        close()
    return parts


def with_frame_count(lines: list[str], at: int, frames: int) -> list[str]:
    """``lines`` (a BVH's, line endings kept; ``at``: its ``Frame Time:`` line) with the number of its ``Frames:``
    line (the last before ``at``) made ``frames``, the rest of that line (spacing, line ending) as the file has it:
    the header of a slice of the file's frames, its ``Frame Time:`` line the file's."""
    k = next(i for i in range(at - 1, -1, -1) if _FRAMES_LINE.match(lines[i]))
    m = _FRAMES_LINE.match(lines[k])
    return lines[:k] + [lines[k][:m.start(1)] + str(frames) + lines[k][m.end(1):]] + lines[k + 1:]
