"""The checks :func:`~mocapkit.io.c3d.read_c3d` makes on a C3D's header and parameter section before any reader
sees the file (:func:`check_structure`).

ezc3d (C++) crashes, loops or allocates what a malformed header claims, so the
header, every parameter record and the size of the data block are walked here,
in Python and within the file's size; a file ezc3d cannot read soundly (a
parameter it relies on of another type, analog samples without ANALOG:RATE,
fewer whole frames than stated) goes to the pure-Python ``c3d`` package. C3D
format: Motion Lab Systems, "The C3D File Format User Guide" (c3d.org).
"""

from __future__ import annotations

import struct

import numpy as np

from ..errors import MocapFormatError
from .c3d_frames import read_float, sample_bytes
from .c3d_records import Record, SectionError, section_records
from ..words import plural

__all__ = ["check_structure"]


# Types ezc3d takes for granted (a char ANALOG:USED crashes it): parameters of another type or
# without a value send the file to the pure-Python reader instead.
_EXPECTED_TYPES = {
    ("POINT", "USED"): (2,), ("POINT", "FRAMES"): (2, 4), ("POINT", "DATA_START"): (2,),
    ("POINT", "SCALE"): (4,), ("POINT", "RATE"): (4,), ("POINT", "LABELS"): (-1,), ("POINT", "LABELS2"): (-1,),
    ("POINT", "DESCRIPTIONS"): (-1,), ("POINT", "UNITS"): (-1,), ("ANALOG", "USED"): (2,),
    ("ANALOG", "RATE"): (4,), ("ANALOG", "SCALE"): (4,), ("ANALOG", "GEN_SCALE"): (4,), ("ANALOG", "OFFSET"): (2,),
    ("ANALOG", "LABELS"): (-1,), ("ANALOG", "UNITS"): (-1,), ("ANALOG", "FORMAT"): (-1,), ("ANALOG", "BITS"): (2,),
    ("TRIAL", "ACTUAL_START_FIELD"): (2,), ("TRIAL", "ACTUAL_END_FIELD"): (2,), ("TRIAL", "CAMERA_RATE"): (4,),
    ("FORCE_PLATFORM", "USED"): (2,), ("FORCE_PLATFORM", "TYPE"): (2,), ("FORCE_PLATFORM", "CHANNEL"): (2,),
    ("FORCE_PLATFORM", "CORNERS"): (4,), ("FORCE_PLATFORM", "ORIGIN"): (4,), ("FORCE_PLATFORM", "ZERO"): (2,),
}

# One entry per point, channel or plate: an empty list is well formed when there are none (ezc3d
# writes them so), and ezc3d reads it.
_PER_CHANNEL = {
    ("POINT", "LABELS"), ("POINT", "LABELS2"), ("POINT", "DESCRIPTIONS"), ("POINT", "UNITS"),
    ("ANALOG", "LABELS"), ("ANALOG", "UNITS"), ("ANALOG", "DESCRIPTIONS"), ("ANALOG", "SCALE"),
    ("ANALOG", "OFFSET"), ("ANALOG", "BITS"), ("ANALOG", "FORMAT"),
    ("FORCE_PLATFORM", "TYPE"), ("FORCE_PLATFORM", "CHANNEL"), ("FORCE_PLATFORM", "CORNERS"), ("FORCE_PLATFORM", "ORIGIN"),
}


def check_structure(path: Path, b: bytes) -> tuple[bool, dict, tuple[Record, ...] | None]:
    """Refuse a C3D whose header or parameter section is malformed, before any C++ reader sees it.

    ezc3d (C++) crashes or loops on some malformed parameter sections and
    allocates what the header claims; this walk checks, in Python and within
    the file's size: the header key, the parameter section pointer and its
    block count, every parameter record (name, type -1/1/2/4, at most 7
    dimensions, its data and description inside the section, the pointer to
    the next record moving forward), that the data block the header
    describes (points, analog samples, frames, integer or float) fits in the
    file (one that stops partway through a frame is cut short and refused:
    :func:`_frames_held`), and that an integer
    ``POINT:USED`` agrees with the header's point count (a section claiming
    32,767 markers against a header of 33 is refused, not read). Returns
    whether ezc3d may read the file: False when a parameter it relies on has
    an unexpected type or no value, or the file holds fewer whole frames than
    the header states (the pure-Python reader copes with those and reads the
    frames there); the parameter names as the file writes them, (GROUP,
    NAME) upper-cased -> (group, name, locked) (a group's own record keyed (GROUP, ""):
    :func:`_with_written_case`); and the section's records as walked
    (:func:`~mocapkit.io.c3d_records.section_records`), which
    :func:`~mocapkit.io.c3d_parameters.read_parameters` reads without walking again (None where the section
    states no blocks: nothing is checked there).
    """
    n = len(b)

    def fail(reason: str):
        raise MocapFormatError(path, reason)

    if n < 512:
        fail(f"not a C3D file: {n} bytes, shorter than the 512-byte header")
    if b[1] != 0x50:
        fail(f"not a C3D file: header key is {b[1]:#04x}, expected 0x50")
    pblock = b[0]
    start = (pblock - 1) * 512
    if pblock < 2 or start + 4 > n:
        fail(f"parameter section at block {pblock} is outside the file ({n} bytes)")
    proc = b[start + 3]
    if proc not in (84, 85, 86):
        fail(f"unknown processor type {proc} in the parameter section (expected 84, 85 or 86)")
    e = ">" if proc == 86 else "<"
    nblocks = b[start + 2]
    if start + nblocks * 512 > n:
        fail(f"truncated file: the parameter section claims {nblocks} blocks, the file ends inside it")
    # real files understate the block count (c3d.org's Dance, golfswing): records may run on past it
    groups: dict[int, str] = {}
    typed: list[tuple[int, str, int, int]] = []  # (group id, name, type, data bytes)
    value_at: dict[tuple[int, str], int] = {}  # (group id, name) -> byte offset of its data
    spelled: dict[int, str] = {}  # group id -> its name as written
    names: list[tuple[int, str, bool]] = []  # (group id, parameter name as written, locked)
    locked_groups: dict[int, bool] = {}  # group id -> locked
    records = []
    try:
        for record in section_records(b) if nblocks else ():
            records.append(record)
            name = record.name.decode()
            if record.gid < 0:
                groups[-record.gid] = name.upper()
                spelled[-record.gid] = name
                locked_groups[-record.gid] = record.locked
            else:
                typed.append((record.gid, name.upper(), record.typ, record.size if record.typ != -1 or record.dims
                              else -1))
                names.append((record.gid, name, record.locked))
                value_at[(record.gid, name.upper())] = record.first
    except SectionError as exc:
        fail(str(exc))
    walked = tuple(records) if nblocks else None
    # Parameters of a group id the section never defines (c3d.org TYPE-2.C3D, TYPE-4.C3D) are
    # ignored, as ezc3d and the c3d package ignore them.
    typed = [t for t in typed if t[0] in groups]
    written = {(g.upper(), ""): (g, "", locked_groups[gid]) for gid, g in spelled.items()}
    written.update({(groups[gid], n.upper()): (spelled[gid], n, lock) for gid, n, lock in names if gid in groups})
    # A parameter defined twice (Vicon's PiG_Calibration files: PROCESSING:BODYMASS) is read by
    # ezc3d, which keeps the first; the c3d package refuses it.
    ezc3d_ok = True
    points, analog, first, last = struct.unpack_from(e + "4H", b, 2)
    for gid, name, typ, size in typed:
        want = _EXPECTED_TYPES.get((groups[gid], name))
        # a per-channel list may be empty (ezc3d writes them so) when there are no such channels
        empty_ok = size == 0 and ((groups[gid], name) in _PER_CHANNEL) and not (
            groups[gid] == "ANALOG" and analog and name not in ("FORMAT", "BITS", "UNITS", "DESCRIPTIONS"))
        if want is not None and (typ not in want or (size < abs(typ) and not empty_ok)):
            ezc3d_ok = False
        if typ == -1 and size < 0:  # a string without dimensions (ezc3d: SIGSEGV)
            ezc3d_ok = False
    have = {(groups[gid], name) for gid, name, _, _ in typed}
    if analog and not {("ANALOG", k) for k in ("USED", "OFFSET", "SCALE", "GEN_SCALE")} <= have:
        ezc3d_ok = False  # analog samples without their scaling parameters (ezc3d: SIGSEGV)
    if points and ("POINT", "USED") not in have:
        ezc3d_ok = False
    scale = read_float(b, proc, 12)
    data_start = struct.unpack_from(e + "H", b, 16)[0]
    if points == 0:
        # some writers leave the header empty; the parameters decide (the fallback reader)
        return ezc3d_ok, written, walked
    used = _int_parameter(b, e, groups, typed, value_at, "POINT", "USED")
    if analog and (("ANALOG", "RATE") not in have or _int_parameter(b, e, groups, typed, value_at, "ANALOG", "USED") == 0):
        # analog samples in the header's frames but no ANALOG:RATE (or ANALOG:USED 0): ezc3d then takes
        # 0 analog samples per frame and reads the data block with the wrong frame size (c3d.org
        # sample28/type1.C3D: markers jump a metre per frame); the c3d package follows the header
        ezc3d_ok = False
    if used is not None and used != points:
        fail(f"the parameter section disagrees with the header: POINT:USED is {used} markers, "
             f"the header says {points}")
    if last < first:
        fail(f"header: last frame {last} comes before the first frame {first}")
    if data_start < 2:
        fail(f"header: data block at block {data_start}")
    held, partial, frames, declared, who = _frames_held(b, proc, e, groups, typed, value_at, points, analog, first,
                                                        last, data_start, scale)
    if held >= frames:
        return ezc3d_ok, written, walked
    if held == 0:
        need = (data_start - 1) * 512 + frames * (4 * points + analog) * sample_bytes(scale)
        fail(f"truncated file: {plural(frames, 'frame')} of {points} points and {analog} analog samples need "
             f"{need} bytes, the file has {n}, not even one whole frame")
    if held < declared and partial:
        # A copy or download cut short. The c3d package read the whole frames there, so a cut file passed for
        # a short take, or failed on what it then read (BTK's Gait.c3d cut at 50 KB: "unknown length unit").
        fail(f"truncated file: the data block stops partway through frame {held + 1} of the {declared} frames "
             f"{who} ({points} points and {analog} analog samples a frame, stored as "
             f"{'16-bit integers' if sample_bytes(scale) == 2 else 'floats'}); the file is cut short")
    # Whole frames, fewer than stated (ezc3d-testFiles Optotrak.c3d: 29 of 1,149, a file every peer reader reads
    # so), or a header stating more frames than POINT:FRAMES: the pure-Python reader reads the frames there.
    return False, written, walked


def _frames_held(b, proc, e, groups, typed, value_at, points, analog, first, last, data_start, scale):
    """How many whole frames the data block holds, against what the header and the parameters declare.

    Returns ``(held, partial, frames, declared, who)``: ``frames`` the
    header's count, ``declared`` the smaller of it and ``POINT:FRAMES`` (a
    take trimmed by rewriting the header's last frame is not cut short),
    ``who`` naming which declares it, ``partial`` whether bytes of a frame
    not whole follow the last whole one. The storage format is the header
    scale's sign (negative: 4-byte floats, else 16-bit integers); where
    ``POINT:SCALE`` has the other sign, the format holding more frames counts.
    """
    frames = last - first + 1
    counts = [frames]
    param_frames = _int_parameter(b, e, groups, typed, value_at, "POINT", "FRAMES")
    if param_frames is None:
        at = _param_at(groups, typed, value_at, "POINT", "FRAMES", 4)
        if at is not None:
            value = read_float(b, proc, at)
            param_frames = int(value) if np.isfinite(value) and 0 < value < 2**31 else None
    if param_frames:
        counts.append(param_frames)
    declared = min(counts)
    who = ("the header and POINT:FRAMES declare" if counts == [frames, frames]
           else "the header declares" if declared == frames else "POINT:FRAMES declares")
    sizes = {sample_bytes(scale)}
    at = _param_at(groups, typed, value_at, "POINT", "SCALE", 4)
    if at is not None:
        sizes.add(sample_bytes(read_float(b, proc, at)))
    body = max(len(b) - (data_start - 1) * 512, 0)
    held, rest = max(divmod(body, (4 * points + analog) * size) for size in sizes)
    return held, rest > 0, frames, declared, who


def _param_at(groups: dict, typed: list, value_at: dict, group: str, name: str, typ: int) -> int | None:
    """Byte offset of the first value of parameter GROUP:NAME when it has type ``typ`` and a value, else None."""
    for gid, pname, ptyp, size in typed:
        if groups.get(gid) == group and pname == name and ptyp == typ and size >= abs(typ):
            return value_at[(gid, pname)]
    return None


def _int_parameter(b: bytes, e: str, groups: dict, typed: list, value_at: dict, group: str, name: str) -> int | None:
    """The first value of an integer parameter GROUP:NAME (read as unsigned, like the header's counts), or None."""
    at = _param_at(groups, typed, value_at, group, name, 2)
    return None if at is None else struct.unpack_from(e + "H", b, at)[0]
