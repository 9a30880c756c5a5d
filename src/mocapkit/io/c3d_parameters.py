"""The parameter section of a C3D read in Python, every record of it, in ezc3d's parsed layout.

The files ezc3d cannot read are read by the pure-Python ``c3d`` package
(:mod:`mocapkit.io.c3d`), whose parameter reading stops at the section's
stated block count and leaves out a parameter it cannot shape. Real files
understate that count and write records past it (c3d.org's PhoeniX samples
Dance.c3d and golfswing.c3d: 3 blocks, 1,536 bytes, stated; 11 records start
past them, up to byte 2,602 of Dance's section: POINT:DESCRIPTIONS and the
ANALOG group's nine parameters), which a take read by the package alone
would be written back without. :func:`read_parameters` reads every record the section holds, in the
one walk :func:`~mocapkit.io.c3d_structure.check_structure` checks
(:func:`~mocapkit.io.c3d_records.section_records`: records past the stated blocks while they are well
formed; a parameter of a group the section never defines left out, as ezc3d and the package leave
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

import numpy as np

from .c3d_frames import stored_values
from .c3d_records import readable_records

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


def read_parameters(raw: bytes, records=None) -> dict:
    """Every parameter of the C3D file ``raw`` (its bytes): group -> name -> {type, description, is_locked
    (False: :func:`mocapkit.io.c3d._with_written_case` sets them), value}, each group's ``__METADATA__``
    {DESCRIPTION, IS_LOCKED}, names upper-cased, as the module says. ``records``: the section's records as
    :func:`~mocapkit.io.c3d_structure.check_structure` walked them (a sequence of
    :class:`~mocapkit.io.c3d_records.Record`); None: walked here (:func:`~mocapkit.io.c3d_records.readable_records`:
    up to a record that cannot be read whole or is malformed)."""
    proc = raw[(raw[0] - 1) * BLOCK + 3]
    groups: dict[int, tuple[str, dict]] = {}
    params: list[tuple[int, str, dict]] = []
    for record in readable_records(raw) if records is None else records:
        desc = _text(record.description).rstrip()
        if record.gid < 0:
            groups.setdefault(-record.gid, (record.label, {"__METADATA__": {"DESCRIPTION": desc, "IS_LOCKED": False}}))
            continue
        values = raw[record.first:record.first + record.size]
        value = _texts(values, record.dims) if record.typ == -1 else _numbers(values, record.typ, record.dims, proc)
        params.append((record.gid, record.label, {"type": record.typ, "description": desc, "is_locked": False,
                                                  "value": value}))
    out: dict[str, dict] = {}
    for label, group in groups.values():
        out.setdefault(label, group)
    for gid, label, param in params:
        if gid in groups:  # a group the section never defines: its parameters left out (TYPE-2.C3D)
            groups[gid][1].setdefault(label, param)  # stated twice: the first
    return out
