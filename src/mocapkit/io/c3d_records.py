"""The records of a C3D's parameter section, walked once for every reader of them.

The parameter section is a chain of records (C3D User Guide, "The parameter
section"): a group's (negative group id: name, description) or a
parameter's (name, type, dimensions, values, description), each pointing
to the next by a 16-bit offset. :func:`section_records` walks that chain
within the file's bytes and says where it is malformed; the structure check
(:func:`~mocapkit.io.c3d_structure.check_structure`, before any C++ reader
sees a file), the pure-Python parameter reading
(:func:`~mocapkit.io.c3d_parameters.read_parameters`) and the writer's
record edits (:func:`~mocapkit.io.c3d_layout.parameter_at`, :mod:`~mocapkit.io.c3d_section`) all read
its records. C3D format: Motion Lab Systems, "The C3D File Format User
Guide" (c3d.org).
"""

from __future__ import annotations

import struct
from typing import Iterator, NamedTuple

__all__ = ["Record", "SectionError", "readable_records", "section_records", "section_start"]

BLOCK = 512


class SectionError(ValueError):
    """A record of the parameter section that cannot be read whole or is malformed; the message says which."""


class Record(NamedTuple):
    """One record of the parameter section; offsets are bytes from the file's start.

    ``gid``: group id, negative for a group's own record; ``name``: as
    written (bytes); ``locked``: a negative name length; ``start``: the
    record's first byte; ``at``: its offset-to-next word; ``next``: that
    word's value (0 on the last record); ``typ``: a parameter's type (-1
    text, 1 byte, 2 16-bit integer, 4 float), 0 for a group; ``dims``: a
    parameter's dimensions (first index fastest); ``first``: a parameter's
    first value, a group's description length byte; ``size``: a parameter's
    value bytes (0 for a group); ``description``: the description's bytes.
    """

    gid: int
    name: bytes
    locked: bool
    start: int
    at: int
    next: int
    typ: int
    dims: tuple[int, ...]
    first: int
    size: int
    description: bytes

    @property
    def label(self) -> str:
        """The name upper-cased, as readers look it up."""
        return self.name.decode("latin-1").upper()


def section_start(raw) -> tuple[int, str, int]:
    """``(start, byte order, section end)`` of the parameter section of the C3D ``raw``: its first byte (the
    header's block pointer), ``">"`` for a big-endian (MIPS, processor type 86) file else ``"<"``, and the end of
    the blocks the section states. ``raw`` holds the section's first 4 bytes."""
    start = (raw[0] - 1) * BLOCK
    return start, ">" if raw[start + 3] == 86 else "<", start + raw[start + 2] * BLOCK


def section_records(raw, order: str | None = None) -> Iterator[Record]:
    """Yield every record of the parameter section of the C3D ``raw`` (its bytes), in file order.

    The walk ends at a record of name length or group id 0, at the last
    record (offset to the next 0), or, past the blocks the section states,
    where bytes no longer read as a record (a name not printable ASCII or a
    type not -1, 1, 2 or 4: the data block of c3d.org's sgi_int.c3d). It
    raises :class:`SectionError` naming the record where one runs past the
    file's end, has a malformed name or type within the stated blocks, more
    than 7 dimensions, a group id of 128 or one defined twice, or an offset
    to the next record that points backwards or inside it. ``order``: the
    byte order (``"<"`` or ``">"``); None: the file's, as its processor type
    says (:func:`section_start`).
    """
    start, e, section_end = section_start(raw)
    e = order or e
    n = len(raw)
    past_end = f"runs past the end of the file ({n} bytes): the file is cut short or its parameter section malformed"
    groups: dict[int, str] = {}
    i = start + 4
    while i + 2 <= n:
        length, gid = struct.unpack_from("bb", raw, i)
        nlen = abs(length)
        if nlen == 0 or gid == 0:
            return  # the end of the parameters
        name = bytes(raw[i + 2:i + 2 + nlen])
        at = i + 2 + nlen
        if at + 2 > n:
            raise SectionError(f"parameter record at byte {i} {past_end}")
        if not all(32 <= c < 127 for c in name):
            if i >= section_end:
                return  # past the section's stated blocks, this is data, not a record
            raise SectionError(f"parameter record at byte {i} has a malformed name {name!r}")
        nxt = struct.unpack_from(e + "h", raw, at)[0]
        body = at + 2
        typ, dims, first, size = 0, (), body, 0
        if gid < 0:
            if gid == -128:
                raise SectionError(f"parameter record at byte {i}: group id 128 is out of range (1 to 127)")
            if -gid in groups:
                raise SectionError(f"parameter section defines group id {-gid} twice ({groups[-gid]}, "
                                   f"{name.decode().upper()})")
            groups[-gid] = name.decode().upper()
            need = 1 + (raw[body] if body + 1 <= n else 0)
        else:
            if body + 2 > n:
                raise SectionError(f"parameter {name.decode()} {past_end}")
            typ, ndim = struct.unpack_from("b", raw, body)[0], raw[body + 1]
            if typ not in (-1, 1, 2, 4):
                if i >= section_end:
                    return
                raise SectionError(f"parameter {name.decode()} has type {typ} (expected -1, 1, 2 or 4)")
            if ndim > 7 or body + 2 + ndim > n:
                raise SectionError(f"parameter {name.decode()} has {ndim} dimensions")
            dims = tuple(raw[body + 2:body + 2 + ndim])
            size = abs(typ)
            for d in dims:
                size *= d
            first = body + 2 + ndim
            need = 2 + ndim + size + 1
            if body + need <= n:
                need += raw[body + need - 1]
        if body + need > n:
            raise SectionError(f"parameter record {name.decode()} {past_end}")
        described = first + size  # the description's length byte
        yield Record(gid, name, length < 0, i, at, nxt, typ, dims, first, size,
                     bytes(raw[described + 1:described + 1 + raw[described]]))
        if nxt == 0:
            return
        if nxt < 0 or nxt < need + 2:
            raise SectionError(f"parameter record {name.decode()}: the offset to the next record ({nxt}) points "
                               "backwards or inside it")
        i = at + nxt


def readable_records(raw, order: str | None = None) -> list[Record]:
    """The records :func:`section_records` walks, up to the first that cannot be read whole or is malformed (no
    :class:`SectionError`): what a reader of a file already checked, or written by ezc3d, takes as the section."""
    out: list[Record] = []
    try:
        for record in section_records(raw, order):
            out.append(record)
    except SectionError:
        pass
    return out
