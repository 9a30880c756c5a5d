"""The parameter section of a C3D read in Python, every record of it, in ezc3d's parsed layout.

The files ezc3d cannot read are read by the pure-Python ``c3d`` package
(:mod:`mocapkit.io.c3d`), whose parameter reading stops at the section's
stated block count and leaves out a parameter it cannot shape. Real files
understate that count and write records past it (c3d.org's PhoeniX samples
Dance.c3d and golfswing.c3d: 3 blocks, 1,536 bytes, stated; 11 records start
past them, up to byte 2,602 of Dance's section: POINT:DESCRIPTIONS and the
ANALOG group's nine parameters), which a take read by the package alone
would be written back without. :func:`read_parameters` reads every record the section holds, walked
as :func:`~mocapkit.io.c3d_structure.check_structure` walks and checks it
(records past the stated blocks while they are well formed; a parameter of
a group the section never defines left out, as ezc3d and the package leave
it; a parameter stated twice: the first, as ezc3d keeps it), for the three
processor types (Intel, DEC, MIPS big-endian IEEE). Values are laid out as
:func:`mocapkit.io.c3d.read_c3d` and the writer take them (names
upper-cased; texts stripped; numbers as arrays of the dimensions, first
index fastest, as ezc3d shapes them), texts decoded as ezc3d decodes them (UTF-8, a byte that is
none kept as a lone surrogate, written back as that byte). C3D format: Motion
Lab Systems, "The C3D File Format User Guide" (c3d.org: "The parameter
section").
"""

from __future__ import annotations

import struct

import numpy as np

from .c3d_frames import stored_values

__all__ = ["read_parameters"]

BLOCK = 512


def _text(raw: bytes) -> str:
    return raw.decode("utf-8", "surrogateescape")


def _numbers(raw: bytes, typ: int, dims: tuple[int, ...], proc: int) -> np.ndarray:
    """The values of a numeric record (``typ`` 1, 2 or 4 bytes each) of dimensions ``dims`` (first index fastest):
    an array of shape ``dims`` (one value: shape (1,)), int for integers, float64 holding float32 values."""
    count = int(np.prod(dims)) if dims else 1
    if typ == 4:  # as the data block's floats are read (DEC's too)
        cells = np.frombuffer(raw, dtype=np.uint8, count=4 * count).reshape(count, 4)
        flat = stored_values(cells, proc, ">" if proc == 86 else "<", 4)
    else:
        dtype = np.int8 if typ == 1 else (">i2" if proc == 86 else "<i2")
        flat = np.frombuffer(raw, dtype=dtype, count=count).astype(int)
    return np.atleast_1d(flat.reshape(dims, order="F") if dims else flat)


def _texts(raw: bytes, dims: tuple[int, ...]) -> list[str]:
    """A text record's values: one text (no or one dimension), else one per column of ``dims[0]`` characters."""
    if len(dims) <= 1:
        return [_text(raw).strip()]
    width, count = dims[0], int(np.prod(dims[1:]))
    return [_text(raw[k * width:(k + 1) * width]).strip() for k in range(count)]


def read_parameters(raw: bytes) -> dict:
    """Every parameter of the C3D file ``raw`` (its bytes): group -> name -> {type, description, is_locked
    (False: :func:`mocapkit.io.c3d._with_written_case` sets them), value}, each group's ``__METADATA__``
    {DESCRIPTION, IS_LOCKED}, names upper-cased, as the module says. ``raw`` has passed
    :func:`~mocapkit.io.c3d_structure.check_structure`, which refuses a section whose records run past the
    file's end; a record that cannot be read whole ends the walk here too."""
    start = (raw[0] - 1) * BLOCK
    proc = raw[start + 3]
    e = ">" if proc == 86 else "<"
    n = len(raw)
    groups: dict[int, tuple[str, dict]] = {}
    params: list[tuple[int, str, dict]] = []
    i = start + 4
    while i + 4 <= n:
        nlen, gid = abs(struct.unpack_from("b", raw, i)[0]), struct.unpack_from("b", raw, i + 1)[0]
        if nlen == 0 or gid == 0:
            break
        name = raw[i + 2:i + 2 + nlen]
        at = i + 2 + nlen
        if at + 2 > n or not all(32 <= c < 127 for c in name):
            break  # past the stated blocks: data, not a record (c3d.org sgi_int.c3d); check_structure refused others
        nxt = struct.unpack_from(e + "h", raw, at)[0]
        body = at + 2
        label = name.decode("ascii").upper()
        if gid < 0:
            if body >= n:
                break
            size = raw[body]
            desc = _text(raw[body + 1:body + 1 + size]).rstrip()
            groups.setdefault(-gid, (label, {"__METADATA__": {"DESCRIPTION": desc, "IS_LOCKED": False}}))
        else:
            if body + 2 > n:
                break
            typ, ndim = struct.unpack_from("b", raw, body)[0], raw[body + 1]
            if typ not in (-1, 1, 2, 4) or body + 2 + ndim > n:
                break  # past the stated blocks, data; within them check_structure refused it
            dims = tuple(raw[body + 2:body + 2 + ndim])
            size = abs(typ) * (int(np.prod(dims)) if ndim else 1)
            first = body + 2 + ndim
            if first + size + 1 > n:
                break
            values = raw[first:first + size]
            dlen = raw[first + size]
            desc = _text(raw[first + size + 1:first + size + 1 + dlen]).rstrip()
            value = _texts(values, dims) if typ == -1 else _numbers(values, typ, dims, proc)
            params.append((gid, label, {"type": typ, "description": desc, "is_locked": False, "value": value}))
        if nxt == 0:
            break
        i = at + nxt
    out: dict[str, dict] = {}
    for label, group in groups.values():
        out.setdefault(label, group)
    for gid, label, param in params:
        if gid in groups:  # a group the section never defines: its parameters left out (TYPE-2.C3D)
            groups[gid][1].setdefault(label, param)  # stated twice: the first
    return out
