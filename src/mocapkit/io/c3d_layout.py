"""What :func:`~mocapkit.io.c3d.write_c3d` keeps of a C3D's own layout that ezc3d would write otherwise.

ezc3d (1.7) writes the file whole from the parsed parameters and the values
read. Four things it writes its own way, which other tools of a lab see in
the file even though every reader's values are the same:

- the analog samples: it writes ``value / (ANALOG:SCALE * GEN_SCALE)`` as
  floats with every ANALOG:OFFSET 0. :func:`stored_analogs` finds the numbers
  the file stored (and the offsets, scales and GEN_SCALE they are read with),
  :func:`put_analogs` and :func:`put_parameter` write them over ezc3d's;
- the header's maximum interpolation gap (word 6), always 10:
  :func:`put_header_gap` writes the file's own;
- where the data block starts (header word 9 and ``POINT:DATA_START``): right
  after ezc3d's own parameter section, usually fewer blocks than the file's.
  :func:`keep_data_start` moves the data block back to the file's block where
  ezc3d's section ends before it (zero bytes between, as C3D files pad).
- the data block of an integer file (positive POINT:SCALE), which it writes as
  floats: :func:`integer_data` stores it as 16-bit numbers again, where the
  file's own scale is the take's (:func:`integer_scale`), and
  :func:`stored_scale` reads which storage a file has.
- the header's event slots that no event uses (of 18): ezc3d writes them as zeros, where a file
  may have set their display flags and padded their labels with spaces (c3d.org's FP1.C3D: 4
  events, the other 14 flagged 1 and labelled "    "). :func:`spare_events` keeps them and
  :func:`put_spare_events` writes them back; no reader looks past the event count, so every
  reader sees the same events either way.

Each works on the bytes ezc3d wrote (Intel byte order, float data, the
parameter section at block 2). C3D format: Motion Lab Systems, "The C3D File
Format User Guide" (c3d.org).
"""

from __future__ import annotations

import struct

import numpy as np

from .c3d_records import readable_records

__all__ = ["parameter_values", "channel_values", "header_layout", "analog_unsigned", "offset_values", "analog_offsets",
           "with_offsets", "held_analogs", "stored_analogs", "parameter_at", "put_parameter", "put_analogs",
           "put_header_gap", "keep_data_start", "integer_data", "integer_scale", "stored_scale", "spare_events",
           "put_spare_events", "header_events", "put_header_events", "EVENT_SLOTS", "PARAMETER_ENTRIES", "text_chunks",
           "oversized_parameter"]

BLOCK = 512
"""Bytes in a C3D block: the header, the parameter section and the data block start on one."""

PARAMETER_ENTRIES = 255
"""Most entries one C3D parameter holds along a dimension (a dimension is one byte): a file of more points states
their LABELS and DESCRIPTIONS on in LABELS2, DESCRIPTIONS2 ... (C3D User Guide, POINT group)."""


def text_chunks(name: str, param: dict, values) -> dict[str, dict]:
    """``values`` (one per point or analog channel: texts, or an array of scales or offsets) as the parameters
    NAME, NAME2, NAME3 ... of up to 255 entries each.

    ezc3d 1.7 writes a list of more than 255 entries with its count cut to
    the low byte (300 descriptions stated as 44): the file ezc3d then refuses
    to read back, and the ``c3d`` package reads the rest of the section
    misplaced. Split as the C3D guide has it, every entry keeps its place.
    ``param``: the parameter as the file had it (description, lock), put on
    each part. ezc3d's writer states its own first part of POINT:DESCRIPTIONS
    and ANALOG:DESCRIPTIONS, UNITS, SCALE and OFFSET where the list is not one
    per point or channel (blank texts, scale 1, offset 0):
    :func:`~mocapkit.io.c3d_section.keep_parameters` writes the first part over it.
    """
    parts = [values[i:i + PARAMETER_ENTRIES] for i in range(0, len(values), PARAMETER_ENTRIES)] or [values[:0]]
    return {name + (str(i + 1) if i else ""): dict(param, value=part) for i, part in enumerate(parts)}


def header_layout(raw: bytes) -> dict[str, int]:
    """The header words of a C3D file (``raw``, any processor type) that :func:`keep_data_start` and
    :func:`put_header_gap` keep: ``interpolation_gap`` (word 6, frames), ``data_start`` (word 9, the data block's
    first 512-byte block, 1-based) and ``parameter_blocks`` (the parameter section's stated block count)."""
    proc = raw[(raw[0] - 1) * BLOCK + 3]
    e = ">" if proc == 86 else "<"
    gap, = struct.unpack_from(e + "H", raw, 10)
    data_start, = struct.unpack_from(e + "H", raw, 16)
    return {"interpolation_gap": int(gap), "data_start": int(data_start),
            "parameter_blocks": int(raw[(raw[0] - 1) * BLOCK + 2])}


#: The header's event section (C3D User Guide, "the header"): 16-bit words 150-234 from 1, as byte offsets from
#: 0: the key 12345 (word 150), the count (151), a reserved word (152), 18 times (floats, 153-188), 18 display
#: flag bytes (189-197), a reserved word (198) and 18 four-character labels (199-234).
EVENT_SLOTS = 18
# C3D header event section (16-bit words from 1): word 150 the key 12345, 151 the event count (at most 18), 152
# reserved, 153-188 the times (floats, seconds), 189-197 a display flag byte per event, 198 reserved, 199-234 the
# labels (4 characters each). Byte offsets of each, and of the section's end:
_KEY, _COUNT, _RESERVED_1, _TIMES, _FLAGS, _RESERVED_2, _LABELS, _END = 298, 300, 302, 304, 376, 394, 396, 468


def header_events(raw: bytes) -> tuple[tuple[float, str, int], ...]:
    """The events the C3D header lists: (time s, 4-character label, display flag) each; () for none.

    Files older than the EVENT parameter group (c3d.org's Eb015pi.c3d: RIC,
    RHS, RTO) hold their gait events only here.
    """
    from .c3d_frames import read_float  # lazy: c3d_frames imports this module

    proc = raw[(raw[0] - 1) * BLOCK + 3]
    e = ">" if proc == 86 else "<"
    count, = struct.unpack_from(e + "h", raw, _COUNT)
    if not 0 < count <= EVENT_SLOTS:
        return ()
    out = []
    for i in range(count):
        t = read_float(raw, proc, _TIMES + 4 * i)
        label = raw[_LABELS + 4 * i:_LABELS + 4 * i + 4].decode("latin-1")
        out.append((float(t) if np.isfinite(t) else 0.0, label, raw[_FLAGS + i]))
    return tuple(out)


def put_header_events(data: bytearray, events) -> None:
    """Write the C3D header's event section (see :func:`header_events`) for up to 18 events (Intel byte order)."""
    events = list(events)[:EVENT_SLOTS]
    if not events:
        return
    struct.pack_into("<hh", data, _KEY, 12345, len(events))
    for i, (t, label, flag) in enumerate(events):
        struct.pack_into("<f", data, _TIMES + 4 * i, float(t))
        data[_FLAGS + i] = int(flag) & 0xFF
        data[_LABELS + 4 * i:_LABELS + 4 * i + 4] = label.encode("latin-1", "replace")[:4].ljust(4)


def spare_events(raw: bytes) -> dict[str, object]:
    """The bytes of the header's event section that no event of the file uses, to write back as the file had them.

    ``{}`` where the header has no event section (no key 12345, or a count outside 0..18). Else
    ``event_spare_from`` (the file's event count: the first slot no event uses), ``event_flags`` and
    ``event_labels`` (those slots' flag bytes and 4-byte labels: bytes, alike in every processor type),
    ``event_reserved`` (words 152 and 198, as bytes: c3d.org's big-endian Eb015si.c3d holds word 152 in the
    same bytes as its Intel twin) and ``event_times`` (those slots' floats, in the byte order written, Intel: a
    big-endian file's bytes reversed, a DEC file's converted as its events' times are,
    :func:`~mocapkit.io.c3d_frames.read_float`). A slot that held an event is never among them, so an event a
    crop leaves out is not written back into its slot.
    """
    from .c3d_frames import read_float

    proc = raw[(raw[0] - 1) * BLOCK + 3]
    e = ">" if proc == 86 else "<"
    if len(raw) < _END:
        return {}
    key, count = struct.unpack_from(e + "hh", raw, _KEY)
    if key != 12345 or not 0 <= count <= EVENT_SLOTS:
        return {}
    slots = range(count, EVENT_SLOTS)
    if proc == 84:
        times = bytes(raw[_TIMES + 4 * count:_FLAGS])
    elif proc == 86:  # big-endian IEEE: the same float, its bytes reversed
        times = b"".join(raw[_TIMES + 4 * i:_TIMES + 4 * i + 4][::-1] for i in slots)
    else:
        times = b"".join(struct.pack("<f", read_float(raw, proc, _TIMES + 4 * i)) for i in slots)
    words = (raw[_RESERVED_1:_RESERVED_1 + 2], raw[_RESERVED_2:_RESERVED_2 + 2])
    return {"event_spare_from": int(count), "event_flags": bytes(raw[_FLAGS + count:_FLAGS + EVENT_SLOTS]),
            "event_labels": bytes(raw[_LABELS + 4 * count:_END]), "event_times": times,
            "event_reserved": b"".join(bytes(w) for w in words)}


def put_spare_events(data: bytearray, layout, used: int) -> None:
    """Write back into ``data`` (the header ezc3d wrote, with ``used`` events written by the caller) the event
    section's bytes that the file read used for no event (:func:`spare_events` in ``layout``); slots between
    ``used`` and the file's own count (events a crop left out) stay zero. A file with an event section keeps it
    where no event is written (the key and a count of 0, as the file read with none had them)."""
    start = layout.get("event_spare_from") if layout else None
    if start is None or used > start:
        return
    if used == 0:
        struct.pack_into("<hh", data, _KEY, 12345, 0)
    data[_FLAGS + start:_FLAGS + EVENT_SLOTS] = layout["event_flags"]
    data[_LABELS + 4 * start:_END] = layout["event_labels"]
    data[_TIMES + 4 * start:_FLAGS] = layout["event_times"]
    data[_RESERVED_1:_TIMES] = layout["event_reserved"][:2]
    data[_RESERVED_2:_LABELS] = layout["event_reserved"][2:]


def parameter_values(parameters, group: str, name: str) -> np.ndarray:
    """The values of parameter ``GROUP:NAME`` in ezc3d's parsed layout, flattened (empty where the file has none)."""
    grp = parameters.get(group, {})
    param = grp.get(name) if isinstance(grp, dict) else None
    return np.ravel(param.get("value", [])) if isinstance(param, dict) else np.array([])


def channel_values(parameters, group: str, name: str) -> np.ndarray:
    """The values of ``GROUP:NAME`` and of its continuations NAME2, NAME3 ... in ezc3d's parsed layout, in one
    flattened array: one entry per point or analog channel, however many.

    A parameter's dimension is one byte, so a file of more than 255 analog
    channels states the scales and offsets of channels 256 on in
    ANALOG:SCALE2, OFFSET2 ... (C3D User Guide, ANALOG group; written so by
    :func:`text_chunks`). ezc3d 1.7 reads its samples with them; read without
    them, channel 256 would be read with no scale and no offset.
    """
    parts = [parameter_values(parameters, group, name)]
    for i in range(2, 100):
        grp = parameters.get(group, {})
        if not isinstance(grp, dict) or f"{name}{i}" not in grp:
            break
        parts.append(parameter_values(parameters, group, f"{name}{i}"))
    return np.concatenate(parts) if len(parts) > 1 else parts[0]


def analog_unsigned(parameters) -> bool:
    """Whether ANALOG:FORMAT in ezc3d's parsed layout ``parameters`` says UNSIGNED: 16-bit analog samples and
    ANALOG:OFFSET stored unsigned (:func:`offset_values`); signed where it says SIGNED or is absent."""
    fmt = parameter_values(parameters, "ANALOG", "FORMAT")
    return len(fmt) > 0 and str(fmt[0]).strip().upper() == "UNSIGNED"


def offset_values(raw, unsigned: bool) -> np.ndarray:
    """(A,) int: the offsets that ANALOG:OFFSET's 16-bit values ``raw`` (A,) (as parsed, -32768 to 32767) stand for.

    The one rule both readers and the writer use: a sample reads ``(stored - offset) * SCALE * GEN_SCALE``.
    C3D guide (Motion Lab Systems, "The C3D File Format User Guide", c3d.org: ANALOG:OFFSET, ANALOG:FORMAT,
    "Notes for programmers - integer analog data"): where ANALOG:FORMAT is UNSIGNED (``unsigned``) the
    offsets are unsigned, 0 to 65535 (shd01.c3d: -32752 is 32784, as BTK and the ``c3d`` package read it),
    else signed. One value is read unsigned in either format: -32768 (0x8000), which the guide's ANALOG:FORMAT
    page and integer glossary leave out of the signed range (-32767 to +32767), is 32768, the zero of a
    16-bit converter's offset binary: Analysis.c3d (SIGNED, BITS 16) stores every sample as 32768, 0 V so
    read (as ezc3d and mocapkit before 0.16.0 read it), 65,536 V as BTK and the ``c3d`` package read it.
    ezc3d 1.7 reads every offset as its magnitude (shd01.c3d: 32752; a SIGNED -5 as 5).
    """
    raw = np.asarray(raw, dtype=np.int64)
    return np.where(unsigned | (raw == -32768), raw & 0xFFFF, raw)


def analog_offsets(parameters, channels: int) -> np.ndarray:
    """(A,) int: the offset each of ``channels`` analog channels is read with (0 where the file has none).

    ANALOG:OFFSET's values in ezc3d's parsed layout ``parameters``, read as
    :func:`offset_values` says under the file's ANALOG:FORMAT.
    """
    offsets = offset_values(channel_values(parameters, "ANALOG", "OFFSET"), analog_unsigned(parameters))
    out = np.zeros(channels, dtype=np.int64)
    out[: min(len(offsets), channels)] = offsets[:channels]
    return out


def with_offsets(analogs: np.ndarray, parameters, read_with) -> np.ndarray:
    """(A, N) float64: ``analogs`` (A, N), read by a peer with the offsets ``read_with`` (A,), as
    :func:`analog_offsets` reads them: ``(read_with - offset) * ANALOG:SCALE * GEN_SCALE`` added on each channel
    whose offsets differ (scale and GEN_SCALE 1 where absent, as readers take them); the others as they are."""
    a = analogs.shape[0]
    shift = np.zeros(a, dtype=np.int64)
    given = np.asarray(read_with, dtype=np.int64)[:a]
    shift[: len(given)] = given
    shift -= analog_offsets(parameters, a)
    if not shift.any():
        return analogs
    scales = np.ones(a)
    found = channel_values(parameters, "ANALOG", "SCALE").astype(np.float64)[:a]
    scales[: len(found)] = found
    gen = parameter_values(parameters, "ANALOG", "GEN_SCALE").astype(np.float64)
    step = scales * (float(gen[0]) if len(gen) else 1.0)
    out = np.array(analogs, dtype=np.float64)
    moved = shift != 0
    out[moved] += (shift[moved] * step[moved])[:, None]
    return out


def _analog_step(parameters, channels: int):
    """``(step, offsets, integer)``: the (A, 1) ANALOG:SCALE * GEN_SCALE and (A, 1) offsets samples are read with,
    and whether POINT:SCALE says integer storage; None where the scales are absent, not finite or 0."""
    point_scale = parameter_values(parameters, "POINT", "SCALE")
    if not len(point_scale) or not np.isfinite(float(point_scale[0])):
        return None
    scales = channel_values(parameters, "ANALOG", "SCALE").astype(np.float64)
    gen = parameter_values(parameters, "ANALOG", "GEN_SCALE").astype(np.float64)
    if len(scales) < channels or not len(gen):
        return None
    step = scales[:channels, None] * gen[0]
    if not np.all(np.isfinite(step)) or np.any(step == 0):
        return None
    return step, analog_offsets(parameters, channels)[:, None], float(point_scale[0]) > 0


def held_analogs(analogs: np.ndarray, parameters) -> np.ndarray | None:
    """(A, N) float64: the float32 numbers a float C3D stored for its analog samples, from ``analogs`` (A, N) as
    the reader computed them in float64, ``(stored - offset) * scale * gen``, before they are rounded to float32.

    Rounding the readings to float32 loses which number the file stored: under an ANALOG:SCALE below 1 several
    float32 numbers read as the same float32 sample (BTK's ADemo1_rewrite_c3d_pc_float.c3d, scale -0.05:
    1,456 of its 16,384 samples), so :func:`stored_analogs` keeps these where they read as the sample and a
    file written back holds the numbers it had. None for an integer file (its whole numbers are recovered
    exactly) or where the scales are unusable. C3D format: "The C3D File Format User Guide" (c3d.org), ANALOG.
    """
    if analogs is None or np.ndim(analogs) != 2 or analogs.size == 0:
        return None
    found = _analog_step(parameters, analogs.shape[0])
    if found is None or found[2]:
        return None
    step, off, _ = found
    with np.errstate(over="ignore", invalid="ignore"):
        held = (np.asarray(analogs, dtype=np.float64) / step + off).astype(np.float32).astype(np.float64)
    return held


def stored_analogs(analogs: np.ndarray, parameters, held: np.ndarray | None = None):
    """``(stored, scales, offsets, gen)``: numbers whose reading ``(stored - offset) * scale * gen`` is ``analogs``.

    ``analogs`` (A, N): the samples as :func:`~mocapkit.io.c3d.read_c3d` reads
    them (float32 values, in the file's units); ``parameters``: the file's
    parsed parameter section (POINT:SCALE says integer or float storage,
    ANALOG:SCALE, OFFSET and GEN_SCALE how samples are read). The
    stored numbers are those the file held: whole numbers in an integer file
    (positive POINT:SCALE, |stored| within 16 bits) and in the float files
    that store A/D counts (Vicon's FunctionalWalk.c3d), else the float32
    nearest ``value / (scale * gen) + offset``. Each is checked to read back as
    the sample, its sign of zero included; where one does not (a channel
    changed in Python, a scale of 0 or missing), None: the caller writes the
    values as they are (scale 1, offset 0). Returns ``stored`` (A, N) float64,
    ``scales`` (A,) ANALOG:SCALE, ``offsets`` (A,) int, ANALOG:OFFSET as the
    file has it (the values are read as :func:`analog_offsets` says),
    ``gen`` ANALOG:GEN_SCALE. ``held`` (A, N): the numbers the file stored
    (:func:`held_analogs`, kept by the reader), taken wherever they still read as the sample, since rounded
    to float32 a sample of a float file no longer says which of several numbers the file held.
    """
    a = analogs.shape[0]
    found = _analog_step(parameters, a)
    if found is None:
        return None
    step, off, integer = found
    scales = channel_values(parameters, "ANALOG", "SCALE").astype(np.float64)[:a]
    gen = parameter_values(parameters, "ANALOG", "GEN_SCALE").astype(np.float64)
    written = np.zeros(a, dtype=np.int64)
    given = channel_values(parameters, "ANALOG", "OFFSET").astype(np.int64)[:a]
    written[: len(given)] = given
    exact = analogs / step + off
    whole = np.rint(exact) + 0.0  # no -0.0: a stored 0 that is not the offset is +0 (a 16-bit 0)
    if integer and np.any((whole < -32768) | (whole > 65535)):
        return None

    def reads(stored):  # what readers make of stored numbers, at float32
        return ((stored - off) * step).astype(np.float32).astype(np.float64)

    # whole numbers where they read as the sample (every one in an integer file), else the nearest float32
    fits = np.abs(whole) <= 2**24  # whole numbers float32 holds
    stored = whole if integer else np.where(fits & (reads(whole) == analogs), whole,
                                            exact.astype(np.float32).astype(np.float64))
    if not integer and held is not None and np.shape(held) == analogs.shape:
        with np.errstate(over="ignore", invalid="ignore"):
            own = (reads(held) == analogs) & (np.signbit(reads(held)) == np.signbit(analogs))
        stored = np.where(own, held, stored)
    # the sign of a zero read: (stored - offset) is -0.0 only where stored is -0.0 and the offset 0
    zero = (stored - off == 0) & (off == 0)
    stored = np.where(zero, np.where(np.signbit(analogs) != (step < 0), -0.0, 0.0), stored)
    back = reads(stored)
    if not (np.array_equal(back, analogs) and np.array_equal(np.signbit(back), np.signbit(analogs))):
        return None
    return stored, scales, written, float(gen[0])


def parameter_at(data, group: str, name: str) -> tuple[int, int, int] | None:
    """``(byte offset of its first value, type, number of values)`` of parameter GROUP:NAME in a C3D ezc3d wrote
    (Intel byte order), or None. Types: -1 text, 1 byte, 2 16-bit integer, 4 float."""
    groups: dict[int, str] = {}
    found = []
    for r in readable_records(data, "<"):
        if r.gid < 0:
            groups[-r.gid] = r.label
        elif r.label == name.upper():
            found.append((r.gid, (r.first, r.typ, int(np.prod(r.dims)) if r.dims else 1)))
    return next((where for gid, where in found if groups.get(gid) == group.upper()), None)


def oversized_parameter(parameters: dict) -> str | None:
    """``"GROUP:NAME holds ..."`` for the first parameter of ``parameters`` (ezc3d's layout, as handed to its
    writer) that a C3D cannot state: more than 255 entries along a dimension (EVENT:TIMES of 300 events) or a
    text longer than 255 characters, each a dimension the parameter section stores in one byte; None where
    every one fits. ezc3d writes such a parameter with the dimension cut to its low byte, a file it then
    refuses to read and the ``c3d`` package reads wrongly (44 of 300 events). POINT:LABELS and ANALOG:LABELS
    are counted by ezc3d's writer, which states them in LABELS2 ... past 255."""
    for group, params in parameters.items():
        for name, param in params.items():
            if name == "__METADATA__" or not isinstance(param, dict) or "value" not in param:
                continue
            value = param["value"]
            if param.get("type") == -1 or (isinstance(value, list) and value and isinstance(value[0], str)):
                texts = [str(v) for v in np.ravel(np.asarray(value, dtype=object))] if len(value) else []
                if name != "LABELS" and len(texts) > PARAMETER_ENTRIES:
                    return f"{group}:{name} holds {len(texts)} texts"
                longest = max((len(t) for t in texts), default=0)
                if longest > PARAMETER_ENTRIES:
                    return f"{group}:{name} holds a text of {longest} characters"
            elif any(d > PARAMETER_ENTRIES for d in np.shape(value)):
                return f"{group}:{name} holds {' x '.join(str(d) for d in np.shape(value))} values"
    return None


def put_parameter(data: bytearray, group: str, name: str, values) -> bool:
    """Write ``values`` over the first values of the 16-bit integer or float parameter GROUP:NAME in place (as
    many as it holds); False where the file has no such parameter of those types."""
    where = parameter_at(data, group, name)
    if where is None or where[1] not in (2, 4):
        return False
    at, typ, count = where
    values = np.ravel(np.asarray(values))[:count]
    packed = (values.astype(np.int64) & 0xFFFF).astype("<u2") if typ == 2 else values.astype("<f4")
    data[at:at + packed.nbytes] = packed.tobytes()
    return True


def put_analogs(data: bytearray, frames: int, points: int, stored: np.ndarray) -> None:
    """Write the (A, F * ratio) ``stored`` analog numbers into the float data block of a C3D ezc3d wrote, which
    holds ``frames`` frames of ``points`` points: a frame holds its analog samples subframe by subframe, every
    channel in each."""
    if stored.size == 0 or frames == 0 or stored.shape[1] % frames:
        return
    a, n = stored.shape
    analog, data_start = struct.unpack_from("<H", data, 4)[0], struct.unpack_from("<H", data, 16)[0]
    width = 4 * points + analog
    block = np.frombuffer(data, dtype="<f4", count=frames * width, offset=(data_start - 1) * BLOCK).reshape(frames, width)
    block[:, 4 * points:] = stored.reshape(a, frames, n // frames).transpose(1, 2, 0).reshape(frames, a * n // frames)


def put_header_gap(data: bytearray, gap: int) -> None:
    """Write header word 6, the maximum interpolation gap in frames (ezc3d writes 10 whatever the file had)."""
    struct.pack_into("<H", data, 10, int(gap) & 0xFFFF)


def keep_data_start(data: bytearray, layout: dict) -> bytearray:
    """``data`` (a C3D ezc3d wrote) with its data block at the block ``layout["data_start"]`` says, where the
    parameter section ezc3d wrote ends before it (zero bytes between); else ``data`` as it is, its data block
    right after ezc3d's parameter section, since a section cannot shrink without losing parameters.

    Header word 9 and POINT:DATA_START are set to the block; the parameter section's block count is kept at
    ``layout["parameter_blocks"]`` where that still covers ezc3d's section and ends before the data, else it is
    the count ezc3d wrote. ``layout``: :func:`header_layout` of the file read.
    """
    want = int(layout.get("data_start", 0))
    now, = struct.unpack_from("<H", data, 16)
    param_block, param_blocks = data[0], data[(data[0] - 1) * BLOCK + 2]
    if want <= now or want > 32767:  # POINT:DATA_START is a signed 16-bit integer
        return data
    out = data[:(now - 1) * BLOCK] + bytes((want - now) * BLOCK) + data[(now - 1) * BLOCK:]
    struct.pack_into("<H", out, 16, want)
    put_parameter(out, "POINT", "DATA_START", [want])
    blocks = int(layout.get("parameter_blocks", 0))
    if param_blocks <= blocks <= want - param_block:
        out[(param_block - 1) * BLOCK + 2] = blocks
    return out


def integer_data(data: bytearray, frames: int, points: int, scale: float) -> bytearray | None:
    """``data`` (a C3D ezc3d wrote, float data block) stored as 16-bit integers under POINT:SCALE ``scale`` (> 0),
    the storage of the integer file it was read from; None where a value does not fit one.

    ezc3d writes float data only, but an integer file's samples are ``int16 * scale``, which a float32 cannot
    all hold (ezc3d reads them in float64: 97 % of BTK's Gait.c3d samples 1.2e-4 mm off, written as floats), so
    a float copy is not the file. Written back as integers, every sample a command did not change is the
    file's own 16-bit number (``round(value / scale)`` of the float32 read gives it back: the value is within
    3e-8 of a step of it), bit for bit for every reader; a changed one is rounded to the nearest step of
    ``scale`` (half a step at most: 0.042 mm for Eb015pi.c3d's 0.0833 mm). Each point's fourth word is the
    16-bit word the float block holds as a float (residual byte, camera bits, -1 where missing: a missing
    sample's coordinates are 0, or those the file stored there: :func:`~mocapkit.io.c3d_frames.put_missing_stored`); analog samples are the whole numbers the file stored (:func:`stored_analogs`),
    written in 16 bits (over 32767: ANALOG:FORMAT UNSIGNED, the same bits). None (the caller keeps the float
    file) where a coordinate is past 32,767 steps, a fourth word or an analog sample is no whole 16-bit number
    (an analog channel changed in Python), or a coordinate of a sample not missing is not finite. The header's
    scale and POINT:SCALE get ``scale``; the data block is padded with zeros to a whole 512-byte block, as
    C3D files are. C3D User Guide, "Data storage" (c3d.org).
    """
    analog, data_start = struct.unpack_from("<H", data, 4)[0], struct.unpack_from("<H", data, 16)[0]
    width = 4 * points + analog
    start = (data_start - 1) * BLOCK
    block = np.frombuffer(data, dtype="<f4", count=frames * width, offset=start).reshape(frames, width)
    block = block.astype(np.float64)
    pts = block[:, :4 * points].reshape(frames, points, 4)
    word, xyz = pts[..., 3], pts[..., :3]
    missing = word < 0
    with np.errstate(invalid="ignore", over="ignore"):
        # a missing sample's coordinates: 0, or the file's own where it stored some (put_missing_stored)
        steps = np.where(missing[..., None] & ~np.isfinite(xyz), 0.0, np.rint(xyz / scale))
    samples = block[:, 4 * points:]
    if not (np.all(np.isfinite(steps)) and np.all(np.abs(steps) <= 32767)
            and np.all(np.rint(word) == word) and np.all((word >= -32768) & (word <= 32767))
            and np.all(np.rint(samples) == samples) and np.all((samples >= -32768) & (samples <= 65535))):
        return None
    out = np.empty((frames, width), dtype="<u2")
    pts_out = out[:, :4 * points].reshape(frames, points, 4)
    pts_out[..., :3] = steps.astype(np.int64) & 0xFFFF
    pts_out[..., 3] = word.astype(np.int64) & 0xFFFF
    out[:, 4 * points:] = samples.astype(np.int64) & 0xFFFF
    body = out.tobytes()
    result = bytearray(data[:start]) + body + bytes(-len(body) % BLOCK)
    struct.pack_into("<f", result, 12, float(scale))
    put_parameter(result, "POINT", "SCALE", [scale])
    return result


def integer_scale(parameters, units: str) -> float | None:
    """POINT:SCALE of a C3D's parsed ``parameters`` where the file stores 16-bit integers (a positive scale, in
    its POINT:UNITS) and ``units``, the length unit of the take written, is that unit; else None: a take in
    another unit is no number of the file's steps, and a float file stays float (:func:`integer_data`)."""
    scale = parameter_values(parameters, "POINT", "SCALE")
    stated = parameter_values(parameters, "POINT", "UNITS")
    if not len(scale) or not np.isfinite(float(scale[0])) or float(scale[0]) <= 0:
        return None
    if not len(stated) or str(stated[0]).strip() != str(units).strip():
        return None
    return float(scale[0])


def stored_scale(path) -> float | None:
    """The point scale the header of the C3D file at ``path`` states (positive: 16-bit integer samples in steps
    of it, negative: floats); None where the file cannot be read as one. What a command reads of the file it
    wrote, to say that the changed samples were rounded to the steps (:func:`integer_data`)."""
    from .c3d_frames import read_float

    try:
        with open(path, "rb") as fh:
            head = fh.read(BLOCK)
            fh.seek((head[0] - 1) * BLOCK)
            proc = fh.read(4)[3]
        scale = read_float(head, proc, 12)
    except (OSError, IndexError, ValueError, struct.error):
        return None
    return float(scale) if np.isfinite(scale) else None
