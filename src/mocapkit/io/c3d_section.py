"""The parameter section of a C3D ezc3d wrote, made to state the parameters of the file read.

ezc3d (1.7) writes the parameter section from its own model of a file, not
from the parameters it is handed. What it changes, seen on every C3D of the
test data written with a few samples changed:

- POINT:LABELS and ANALOG:LABELS, DESCRIPTIONS, UNITS, SCALE and OFFSET cut to
  the points and channels stored (USED): Eb015pr.c3d's 48 point labels (12 of
  them the session's spare names, RA, LA, RK ...) to 26, its 32 analog
  channels' parameters to 16; POINT:DESCRIPTIONS of another count than the
  points dropped and written blank;
- descriptions of the parameters it rebuilds blanked (03_rolling.c3d's
  ANALOG:DESCRIPTIONS "Analog Descriptions"), locks dropped (POINT:SCALE),
  byte parameters written as 16-bit integers (EVENT:GENERIC_FLAGS);
- two groups of its own added, ROTATION and EZC3D.

:func:`keep_parameters` writes the section again from the parameters the
writer means (``wanted``: the file's, with those a change must update, in
ezc3d's parsed layout): every record ezc3d wrote that does not state a
wanted parameter as it is (type, dimensions, values, description, lock) is
written from ``wanted``, a wanted parameter ezc3d left out is added, a group
``wanted`` does not hold is left out (a parameter of ezc3d's own in a group kept, such as ANALOG:BITS where
the file read has none, is kept: a file read by the ``c3d`` package, which leaves out parameters with no
values, is written as its twin read by ezc3d); the values of the parameters that
describe the data written (:data:`UPDATED`: the counts and the data start) are
ezc3d's. A C3D parameter may hold more entries than USED: the C3D guide's
POINT and ANALOG groups count the points and channels stored in USED and
readers take the first USED of each list (Motion Lab Systems, "The C3D File
Format User Guide", c3d.org: "The parameter section").
"""

from __future__ import annotations

import struct

import numpy as np

from .c3d_layout import put_parameter
from .c3d_records import readable_records

__all__ = ["keep_parameters", "UPDATED", "parameter_record"]

BLOCK = 512

#: (GROUP, NAME) whose values describe the data written, ezc3d's kept: its lock and description are the file's.
UPDATED = frozenset({("POINT", "USED"), ("POINT", "FRAMES"), ("POINT", "DATA_START"), ("ANALOG", "USED")})


def _text(value) -> bytes:
    """A text's bytes as ezc3d reads them back into the same text: UTF-8, a byte that is none read by ezc3d as a
    lone surrogate (a Latin-1 file's 0xE9: '\\udce9') written back as that byte."""
    try:
        return str(value).encode("utf-8", "surrogateescape")
    except UnicodeEncodeError:  # a surrogate no byte stands for
        return str(value).encode("utf-8", "replace")


def parameter_record(param: dict) -> bytes:
    """The bytes of a parameter record after its offset word (type, dimensions, values, description), Intel
    order, for ``param`` in ezc3d's parsed layout ({type, description, value}), laid out as ezc3d lays out its
    own: a text list of n > 1 entries as an (as wide as the longest, at least 1, n) array, one text as its
    characters, none as (0, 0); a number array by its shape, first index fastest, one value with no dimension."""
    typ = int(param["type"])
    value = param["value"]
    if typ == -1:
        texts = [_text(v) for v in (value if isinstance(value, (list, tuple)) else np.ravel(value).tolist())]
        if not texts:
            dims, body = (0, 0), b""
        elif len(texts) == 1:
            dims, body = (max(1, len(texts[0])),), texts[0].ljust(1)
        else:
            width = max(1, max(len(t) for t in texts))
            dims, body = (width, len(texts)), b"".join(t.ljust(width) for t in texts)
    else:
        arr = np.asarray(value)
        dims = tuple(arr.shape) if arr.shape != (1,) else ()
        flat = np.ravel(arr, order="F")
        if typ == 4:
            body = flat.astype("<f4").tobytes()
        elif typ == 2:
            body = (flat.astype(np.int64) & 0xFFFF).astype("<u2").tobytes()
        else:
            body = (flat.astype(np.int64) & 0xFF).astype("u1").tobytes()
    description = _text(param.get("description", ""))[:255]
    return (struct.pack("bB", typ, len(dims)) + bytes(dims) + body + bytes([len(description)]) + description)


def _records(data) -> list[dict]:
    """The records of ``data``'s parameter section (a C3D ezc3d wrote: Intel order), in file order
    (:func:`~mocapkit.io.c3d_records.readable_records`): ``gid`` (negative for a group), ``name`` (as written),
    ``locked``, ``body`` (the bytes after the offset word) and, for a parameter, ``values`` (the body up to its
    description)."""
    out = []
    for r in readable_records(data, "<"):
        described = r.first + r.size  # the description's length byte
        out.append({"gid": r.gid, "name": r.name.decode("latin-1"), "locked": r.locked,
                    "body": bytes(data[r.at + 2:described + 1 + data[described]]),
                    "values": b"" if r.gid < 0 else bytes(data[r.at + 2:described])})
    return out


def _record(name: str, gid: int, locked: bool, body: bytes, last: bool) -> bytes:
    label = _text(name)
    return (struct.pack("bb", -len(label) if locked else len(label), gid) + label
            + struct.pack("<h", 0 if last else 2 + len(body)) + body)


def keep_parameters(data: bytearray, wanted: dict, keep: tuple[str, ...] = ()) -> bytearray:
    """``data`` (a C3D ezc3d wrote) with its parameter section stating ``wanted`` (group -> name -> {type,
    description, is_locked, value}, each group's ``__METADATA__`` {DESCRIPTION, IS_LOCKED}), as the module
    says. ``keep``: groups of ezc3d's own kept as it wrote them: ROTATION for a trial past 65,535 frames, whose
    POINT:FRAMES is 65,535 and whose end ezc3d finds by ROTATION:DATA_START (without it ezc3d reads the zero
    bytes that end the data block's last block as 16 more frames of a 70,000-frame take).

    The section is written group by group in ezc3d's order (a group's record, then its parameters),
    into the zero bytes before the data block where it fits, else the data block moves on by whole
    blocks (header word 9, POINT:DATA_START and the section's block count say where).
    """
    records = _records(data)
    if not records:
        return data
    names = {-r["gid"]: r["name"].upper() for r in records if r["gid"] < 0}
    want = {g.upper(): (g, params) for g, params in wanted.items() if isinstance(params, dict)}
    for group in keep:  # stated as ezc3d wrote it
        want.setdefault(group.upper(), (group, {}))
    kept: dict[int, list[tuple[str, bool, bytes]]] = {}
    order = [-r["gid"] for r in records if r["gid"] < 0 and names[-r["gid"]] in want]
    for r in records:
        group = names.get(abs(r["gid"]))
        if group is None or group not in want:  # a group ezc3d adds on its own (ROTATION, EZC3D)
            continue
        params = want[group][1]
        if r["gid"] < 0:
            meta = params.get("__METADATA__")
            description = _text(meta.get("DESCRIPTION", ""))[:255] if meta is not None else b""
            kept.setdefault(-r["gid"], []).insert(0, (r["name"], r["locked"], r["body"]) if meta is None else (
                r["name"], bool(meta.get("IS_LOCKED", r["locked"])), bytes([len(description)]) + description))
            continue
        spelled = {k.upper(): k for k in params if k != "__METADATA__"}
        key = spelled.get(r["name"].upper())
        if key is None or not isinstance(params[key], dict) or "value" not in params[key]:
            kept.setdefault(r["gid"], []).append((r["name"], r["locked"], r["body"]))  # ezc3d's own (needed)
            continue
        param = params[key]
        description = _text(param.get("description", ""))[:255]
        body = (r["values"] + bytes([len(description)]) + description if (group, key.upper()) in UPDATED
                else parameter_record(param))
        kept.setdefault(r["gid"], []).append((r["name"], bool(param.get("is_locked", r["locked"])), body))
    free = iter(sorted(set(range(1, 128)) - set(names)))
    for group, (spelt, params) in want.items():
        gid = next((g for g, n in names.items() if n == group), None)
        if gid is None:  # a group ezc3d did not write
            gid = next(free)
            meta = params.get("__METADATA__", {})
            description = _text(meta.get("DESCRIPTION", ""))[:255]
            kept[gid] = [(spelt, bool(meta.get("IS_LOCKED", False)), bytes([len(description)]) + description)]
            order.append(gid)
        written = {n.upper() for n, _, _ in kept.get(gid, [])[1:]}
        for key, param in params.items():
            if key != "__METADATA__" and isinstance(param, dict) and "value" in param and key.upper() not in written:
                kept.setdefault(gid, []).append((key, bool(param.get("is_locked", False)), parameter_record(param)))
    flat = [(name, gid if i else -gid, locked, body) for gid in order for i, (name, locked, body) in enumerate(kept[gid])]
    section = b"".join(_record(name, gid, locked, body, k == len(flat) - 1)
                       for k, (name, gid, locked, body) in enumerate(flat))
    start = (data[0] - 1) * BLOCK
    data_start, = struct.unpack_from("<H", data, 16)
    room = (data_start - 1) * BLOCK - start - 4
    extra = max(0, -(-(len(section) - room) // BLOCK))
    out = (bytearray(data[:start + 4]) + section + bytes(room + extra * BLOCK - len(section))
           + data[(data_start - 1) * BLOCK:])
    if extra:
        struct.pack_into("<H", out, 16, data_start + extra)
        put_parameter(out, "POINT", "DATA_START", [data_start + extra])
    out[start + 2] = max(out[start + 2], -(-(len(section) + 4) // BLOCK))
    return out
