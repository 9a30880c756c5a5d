"""Mutation fuzzing of the readers: seeds, mutators, the oracle and a pool of rlimited workers.

Used by ``tests/io/test_fuzz.py``, ``benchmarks/fuzz_readers.py`` and the command
fuzzer (``tests/fuzzing/commands.py``). It lives beside the tests, not in the
installed package: it forks workers under ``RLIMIT_AS`` (POSIX only) and is of
no use to a user of mocapkit.

* **Seeds** (:func:`load_seeds`) are real files: the bundled samples and, when
  given, a few files of ``../shared/data``, trimmed to their first frames so a
  read takes milliseconds (BVH: the hierarchy and 12 frames with ``Frames:``
  set to match; AMC: the header and 12 frames; C3D: the header's last frame and
  the data block cut to 12 frames; npz: :func:`~mocapkit.io.npz.write_npz` of
  those). Every seed reads cleanly.
* **Mutators** (:func:`mutate`) are byte level (bit flips, interesting bytes,
  insert / delete / duplicate a range, truncate, splice with another seed) and
  format aware: text files get numbers replaced by huge / negative / NaN / inf /
  garbage tokens, lines duplicated, deleted or swapped, and their keywords
  changed (BVH ``CHANNELS`` counts and names, braces, ``Frames:``,
  ``Frame Time:``; AMC frame numbers, bone names, ``:RADIANS``; ASF ``:units``,
  ``dof`` lists, ``axis`` orders, ``limits``, ``:hierarchy`` lines); C3D files get
  header words (parameter block, points, analog channels, first / last frame,
  scale, data start, rate) and parameter records (type, dimensions, values of
  ``POINT:USED``, ``POINT:FRAMES``, ``POINT:DATA_START``, ``POINT:SCALE``,
  ``POINT:RATE``, ``LABELS`` ...) changed; npz files get an array replaced by one
  of another shape, dtype or value, dropped, or a ``.npy`` header that claims a
  huge shape. A mutant is a pure function of (seed, integer), so a failure is
  reproduced from two numbers.
* **The oracle** (:func:`execute`): reading a mutant either raises
  :class:`~mocapkit.errors.MocapFormatError` or returns an object that passes
  :func:`consistency_problems`; anything else (another exception, a
  RuntimeWarning from mocapkit, an inconsistent result) is a crash. ASF mutants
  are read alone and as the skeleton of a valid AMC; AMC mutants with a valid ASF.
* **The pool** (:class:`FuzzPool`): forked worker processes, each under
  ``RLIMIT_AS``; a read over the time limit is a hang (the worker is killed and
  replaced), a MemoryError or a killed worker a memory failure.
"""

from __future__ import annotations

import os
import random
import re
import resource
import shutil
import struct
import tempfile
import time
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = [
    "Seed", "load_seeds", "mutate", "execute", "consistency_problems", "FuzzPool", "FORMATS", "Outcome",
    "warm_up", "reproduce", "trim_bvh", "trim_amc", "trim_c3d", "c3d_parameters", "hash_name",
]

FORMATS = ("bvh", "amc", "asf", "c3d", "npz")
TRIM_FRAMES = 12

# -- seeds ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Seed:
    """A real file to mutate: ``fmt`` in FORMATS, its bytes, and for amc/asf the valid partner file."""

    name: str
    fmt: str
    data: bytes
    companion: bytes | None = None  # amc: its ASF; asf: an AMC it reads


def trim_bvh(data: bytes, frames: int = TRIM_FRAMES) -> bytes:
    """The hierarchy and the first ``frames`` frames of a BVH, ``Frames:`` set to match."""
    m = re.search(rb"^[ \t]*MOTION[ \t]*\r?$", data, re.M)
    head = data[: m.end()]
    rest = data[m.end():].split(b"\n")
    out = [b"", None]
    k = 0
    for line in rest[1:]:
        s = line.strip()
        if not s:
            continue
        if s.startswith(b"Frames"):
            continue
        if s.startswith(b"Frame Time"):
            out.append(line)
            continue
        out.append(line)
        k += 1
        if k == frames:
            break
    out[1] = b"Frames: %d" % k
    return head + b"\n".join(out) + b"\n"


def trim_amc(data: bytes, frames: int = TRIM_FRAMES) -> bytes:
    """The header and the first ``frames`` frames of an AMC."""
    out = []
    k = 0
    for line in data.split(b"\n"):
        s = line.strip()
        if s and s.split()[0].isdigit():
            k += 1
            if k > frames:
                break
        out.append(line)
    return b"\n".join(out) + b"\n"


def trim_c3d(data: bytes, frames: int = TRIM_FRAMES) -> bytes:
    """A C3D cut to its first ``frames`` frames: header last frame set, data block truncated."""
    b = bytearray(data)
    points, analog, first = struct.unpack_from("<3H", b, 2)
    scale = struct.unpack_from("<f", b, 12)[0]
    data_start = struct.unpack_from("<H", b, 16)[0]
    size = 4 if scale < 0 else 2
    per_frame = (4 * points + analog) * size
    struct.pack_into("<H", b, 8, first + frames - 1)
    return bytes(b[: (data_start - 1) * 512 + frames * per_frame])


def load_seeds(shared_data: Path | None = None) -> list[Seed]:
    """Seeds from the bundled samples and, when ``shared_data`` is a folder, a few of its files."""
    from mocapkit import samples
    from mocapkit.io import load
    from mocapkit.io.npz import write_npz

    seeds: list[Seed] = []

    def bvh(p: Path) -> None:
        seeds.append(Seed(p.name, "bvh", trim_bvh(p.read_bytes())))

    def amc(p: Path, asf: Path) -> None:
        a, s = trim_amc(p.read_bytes()), asf.read_bytes()
        seeds.append(Seed(p.name, "amc", a, s))
        if not any(x.fmt == "asf" and x.name == asf.name for x in seeds):
            seeds.append(Seed(asf.name, "asf", s, a))

    def c3d(p: Path) -> None:
        seeds.append(Seed(p.name, "c3d", trim_c3d(p.read_bytes())))

    bvh(samples.path("131_01.bvh"))
    amc(samples.path("12_walk.amc"), samples.path("12.asf"))
    amc(samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"), samples.path("HDM_bd.asf"))
    amc(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"), samples.path("HDM_bk.asf"))
    c3d(samples.path("Eb015pr.c3d"))
    if shared_data is not None and Path(shared_data).is_dir():
        d = Path(shared_data)
        for rel in ("cmu_bvh/01_01.bvh", "cmu_bvh/131_02.bvh"):
            if (d / rel).is_file():
                bvh(d / rel)
        for rel, asf in (("cmu_asfamc/backflip.amc", "cmu_asfamc/backflip.asf"),
                         ("cmu_asfamc/11_01.amc", "cmu_asfamc/11.asf"),
                         ("hdm05_asfamc/HDM_bd_depositFloorR_001_120.amc", "hdm05_asfamc/HDM_bd.asf")):
            if (d / rel).is_file() and (d / asf).is_file():
                amc(d / rel, d / asf)
        for rel in ("c3d_markers/dynamic.c3d", "c3d_markers/phasespace_sample.c3d", "c3d_markers/Eb015pi.c3d",
                    "c3d_markers/golfswing.c3d"):
            if (d / rel).is_file():
                c3d(d / rel)
    # npz seeds: the native format of the trimmed clips.
    work = Path(tempfile.mkdtemp(prefix="mocapkit-fuzz-seeds-"))
    try:
        picks = [next(s for s in seeds if s.fmt == f) for f in ("bvh", "amc", "c3d")]
        for s in picks:
            src = work / f"seed.{s.fmt}"
            src.write_bytes(s.data)
            kw = {}
            if s.fmt == "amc":
                (work / "seed.asf").write_bytes(s.companion)
                kw = {"asf": work / "seed.asf"}
            obj = load(src, **kw)
            for compress in (False, True):
                out = work / f"seed_{s.fmt}_{int(compress)}.npz"
                write_npz(obj, out, compress=compress)
                seeds.append(Seed(f"{Path(s.name).stem}{'_z' if compress else ''}.npz", "npz", out.read_bytes()))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return seeds


# -- mutators ------------------------------------------------------------------------------

_TOKENS = [
    b"1e309", b"-1e309", b"1e308", b"-1e308", b"1e-320", b"nan", b"NaN", b"-nan", b"inf", b"-inf", b"Infinity",
    b"0", b"-0", b"-1", b"1", b"2", b"7", b"255", b"65535", b"65536", b"2147483647", b"2147483648", b"-2147483649",
    b"9223372036854775808", b"99999999999999999999999", b"1" + b"0" * 400, b"0." + b"0" * 400 + b"1",
    b"1e99999", b"1e-99999", b"0x10", b"1_000", b"1e", b".", b"-", b"+", b"--1", b"1.2.3", b"1,5", b"abc", b"",
    b"\xd9\xa1", b"\x00", b"1e5", b"-3.5", b"100000000", b"1000000",
]
_NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_INTERESTING_BYTES = [0, 1, 9, 10, 13, 32, 35, 40, 41, 45, 46, 48, 57, 58, 123, 125, 127, 128, 255]
_BVH_WORDS = [b"HIERARCHY", b"ROOT", b"JOINT", b"End", b"Site", b"{", b"}", b"OFFSET", b"CHANNELS", b"MOTION",
              b"Frames:", b"Frame Time:", b"Xposition", b"Yrotation", b"Zrotation", b"Wrotation"]
_ASF_WORDS = [b":units", b":root", b":bonedata", b":hierarchy", b"begin", b"end", b"name", b"direction", b"length",
              b"axis", b"dof", b"limits", b"order", b"position", b"orientation", b"mass", b"angle", b"deg", b"rad",
              b"rx", b"ry", b"rz", b"tx", b"l", b"XYZ", b"ZZZ", b"root", b"(", b")", b"(-inf", b"inf)"]
_AMC_WORDS = [b":FULLY-SPECIFIED", b":DEGREES", b":RADIANS", b"root", b"lowerback", b"rfemur", b"#", b"1", b"0",
              b"-1", b"99999999"]


def _bytes_mutation(rng: random.Random, b: bytearray, others: list[bytes]) -> None:
    n = len(b)
    op = rng.randrange(9)
    if n == 0:
        b.extend(rng.randbytes(rng.randint(1, 64)))
        return
    if op == 0:  # bit flips
        for _ in range(rng.randint(1, 8)):
            i = rng.randrange(n)
            b[i] ^= 1 << rng.randrange(8)
    elif op == 1:  # interesting bytes
        for _ in range(rng.randint(1, 4)):
            b[rng.randrange(n)] = rng.choice(_INTERESTING_BYTES)
    elif op == 2:  # insert random bytes
        i = rng.randrange(n + 1)
        b[i:i] = rng.randbytes(rng.choice([1, 2, 4, 16, 256]))
    elif op == 3:  # delete a range
        i = rng.randrange(n)
        del b[i: i + rng.choice([1, 2, 4, 16, 64, 512, 4096])]
    elif op == 4:  # duplicate a range
        i = rng.randrange(n)
        j = min(n, i + rng.choice([1, 4, 16, 64, 512, 4096]))
        b[j:j] = b[i:j] * rng.choice([1, 2, 8])
    elif op == 5:  # truncate
        del b[rng.randrange(n):]
    elif op == 6 and others:  # splice with another seed
        o = rng.choice(others)
        i = rng.randrange(n)
        j = rng.randrange(len(o)) if o else 0
        b[i:] = o[j:]
    elif op == 7:  # move a range
        i, j = sorted(rng.randrange(n) for _ in range(2))
        chunk = bytes(b[i:j])
        del b[i:j]
        k = rng.randrange(len(b) + 1)
        b[k:k] = chunk
    else:  # overwrite with random bytes
        i = rng.randrange(n)
        k = rng.choice([1, 2, 4, 8])
        b[i: i + k] = rng.randbytes(k)


def _number_mutation(rng: random.Random, text: bytes) -> bytes:
    spans = [m.span() for m in _NUMBER.finditer(text)]
    if not spans:
        return text
    out = bytearray(text)
    for a, z in sorted(rng.sample(spans, min(len(spans), rng.choice([1, 1, 2, 5]))), reverse=True):
        r = rng.random()
        if r < 0.6:
            tok = rng.choice(_TOKENS)
        elif r < 0.8:
            tok = text[a:z] + rng.choice([b"0", b"e5", b"e-5", b"9" * 20, b".", b"x"])
        else:
            tok = str(rng.choice([-1, 1]) * 10 ** rng.randint(0, 30)).encode()
        out[a:z] = tok
    return bytes(out)


def _line_mutation(rng: random.Random, text: bytes) -> bytes:
    lines = text.split(b"\n")
    n = len(lines)
    op = rng.randrange(6)
    i = rng.randrange(n)
    if op == 0:
        del lines[i: i + rng.choice([1, 1, 2, 5])]
    elif op == 1:
        lines[i:i] = lines[i: i + rng.choice([1, 3])] * rng.choice([1, 2, 10])
    elif op == 2:
        j = rng.randrange(n)
        lines[i], lines[j] = lines[j], lines[i]
    elif op == 3:  # a line in the middle of another
        j = rng.randrange(n)
        k = rng.randrange(len(lines[i]) + 1)
        lines[i] = lines[i][:k] + lines[j] + lines[i][k:]
    elif op == 4:  # reshuffle tokens of a line
        toks = lines[i].split()
        rng.shuffle(toks)
        lines[i] = b" ".join(toks)
    else:  # drop one token of a line
        toks = lines[i].split()
        if toks:
            del toks[rng.randrange(len(toks))]
        lines[i] = b" ".join(toks)
    return b"\n".join(lines)


def _word_mutation(rng: random.Random, text: bytes, words: list[bytes]) -> bytes:
    """Replace, insert or delete a keyword-like token."""
    toks = list(re.finditer(rb"\S+", text))
    if not toks:
        return text
    m = rng.choice(toks)
    r = rng.random()
    if r < 0.5:
        new = rng.choice(words)
    elif r < 0.75:
        new = m.group() + b" " + rng.choice(words)
    else:
        new = b""
    return text[: m.start()] + new + text[m.end():]


def _replace_field(rng: random.Random, text: bytes, pattern: bytes, values, group: int = 0, first: bool = False,
                   flags: int = 0) -> bytes | None:
    """``text`` with ``group`` of one match of ``pattern`` (a random one, or the first) set to one of ``values``.

    None when the pattern does not occur (the caller falls back to a word mutation).
    """
    if first:
        m = re.search(pattern, text, flags)
    else:
        ms = list(re.finditer(pattern, text, flags))
        m = rng.choice(ms) if ms else None
    if m is None:
        return None
    return text[: m.start(group)] + rng.choice(values) + text[m.end(group):]


# Format-aware fields: (pattern, group, values, first match only), one per mutation kind.
_BVH_FIELDS = [
    (rb"CHANNELS[ \t]+(\d+)", 1, [b"0", b"1", b"2", b"5", b"6", b"7", b"-1", b"3.0", b"99", b"x", b""], False),
    (rb"Frames:[ \t]*(\S*)", 1, [b"0", b"-1", b"1", b"11", b"13", b"24", b"1000000000", b"99999999999999999999", b"1e3",
                               b"12.0", b"nan", b""], True),
    (rb"Frame Time:[ \t]*(\S*)", 1, [b"0", b"-0.0083", b"1e-320", b"5e-324", b"1e-300", b"1e300", b"inf", b"nan",
                                   b"0.0333667", b".0083333", b"1", b"x", b"", b"1e309"], True),
    (rb"[XYZ](?:position|rotation)", 0, [b"Xposition", b"Yposition", b"Zposition", b"Xrotation", b"Yrotation",
                                         b"Zrotation", b"xrotation", b"Wrotation", b""], False),
    (rb"[{}]", 0, [b"", b"{", b"}", b"{ {", b"} }"], False),
]
_ASF_FIELDS = [
    (rb"dof([^\n]*)", 1, [b" rx ry rz", b" rx rx", b" tx ry", b" l", b" rx ry rz rx", b"", b" rq", b" RZ RX",
                          b" rz ry rx tx ty tz"], False),
    (rb"(mass|length|angle)[ \t]+(\S+)", 2, [b"0", b"-0.45", b"1e-320", b"1e309", b"nan", b"inf", b"rad", b"deg",
                                             b"grad", b""], True),
    (rb"\b([XYZxyz]{3})\b", 1, [b"XYZ", b"ZYX", b"XXY", b"XY", b"XYZW", b"xyz", b"ABC"], False),
    (rb"\(([^)\n]*)\)", 1, [b"-inf inf", b"1 2 3", b"", b"nan nan", b"1e309 -1e309", b"a b", b"(1 2", b"1,2"], False),
]


def _bvh_mutation(rng: random.Random, text: bytes) -> bytes:
    op = rng.randrange(len(_BVH_FIELDS) + 1)
    if op < len(_BVH_FIELDS):  # CHANNELS count, Frames:, Frame Time:, channel names, braces
        pattern, group, values, first = _BVH_FIELDS[op]
        out = _replace_field(rng, text, pattern, values, group, first)
        if out is not None:
            return out
    return _word_mutation(rng, text, _BVH_WORDS)


def _asf_mutation(rng: random.Random, text: bytes) -> bytes:
    op = rng.randrange(len(_ASF_FIELDS) + 1)
    if op < len(_ASF_FIELDS):  # dof lists, :units, axis orders, limits
        pattern, group, values, first = _ASF_FIELDS[op]
        out = _replace_field(rng, text, pattern, values, group, first)
        if out is not None:
            return out
    else:  # hierarchy lines
        m = re.search(rb":hierarchy(.*?)\n\s*end", text, re.S)
        if m:
            lines = m.group(1).split(b"\n")
            i = rng.randrange(len(lines))
            r = rng.random()
            if r < 0.3:
                lines[i] = lines[i] + b" root"
            elif r < 0.6:
                j = rng.randrange(len(lines))
                lines[i] = lines[i] + b" " + b" ".join(lines[j].split()[:1])
            else:
                lines[i] = b" ".join(lines[i].split()[::-1])
            return text[: m.start(1)] + b"\n".join(lines) + text[m.end(1):]
    return _word_mutation(rng, text, _ASF_WORDS)


def _amc_mutation(rng: random.Random, text: bytes) -> bytes:
    op = rng.randrange(4)
    if op == 0:  # frame numbers
        out = _replace_field(rng, text, rb"^(\d+)[ \t\r]*$", [b"0", b"-1", b"1", b"3", b"1.5", b"99999999999999999999",
                                                             b"1e5", b"nan", b"inf", b""], 1, flags=re.M)
        if out is not None:
            return out
    elif op == 1:  # bone names
        ms = list(re.finditer(rb"^([a-z]+) ", text, re.M))
        if len(ms) > 1:
            m, o = rng.sample(ms, 2)
            return text[: m.start(1)] + o.group(1) + text[m.end(1):]
    elif op == 2:
        v = rng.choice([b":RADIANS", b":DEGREES", b":FULLY-SPECIFIED", b"#", b""])
        return v + b"\n" + text if rng.random() < 0.5 else text.replace(b":DEGREES", v, 1)
    return _word_mutation(rng, text, _AMC_WORDS)


# C3D header words (1-based 16-bit words) worth changing, and the float fields.
_C3D_WORDS = [1, 2, 3, 4, 5, 6, 9, 10]  # word 1: parameter block (low byte) and key 0x50
_C3D_FLOATS = [(12, "scale"), (20, "rate")]
_C3D_INT16 = [0, 1, 2, 3, 0x7FFF, 0x8000, 0xFFFF, 0x0100, 0x1000, 12, 11, 13, 24]
_C3D_FLOAT_VALUES = [0.0, -0.0, 1.0, -1.0, float("nan"), float("inf"), -float("inf"), 1e38, -1e38, 1e-38, 1e-45,
                     -1e-45, 0.1, -0.1, 1e10, 3.4e38]


def c3d_parameters(b: bytes) -> list[dict]:
    """Parameter records of an Intel C3D: name, group, offsets of the type byte and data, dims, type."""
    out: list[dict] = []
    if len(b) < 512:
        return out
    start = (b[0] - 1) * 512
    i = start + 4
    groups: dict[int, str] = {}
    while 0 <= i < len(b) - 4 and len(out) < 2000:
        nlen = abs(struct.unpack_from("<b", b, i)[0])
        gid = struct.unpack_from("<b", b, i + 1)[0]
        if nlen == 0 or i + 2 + nlen + 2 > len(b):
            break
        name = bytes(b[i + 2: i + 2 + nlen]).decode("latin-1").upper()
        off_at = i + 2 + nlen
        nxt = struct.unpack_from("<h", b, off_at)[0]
        body = off_at + 2
        if gid < 0:
            groups[-gid] = name
        elif body + 2 <= len(b):
            typ = struct.unpack_from("<b", b, body)[0]
            nd = b[body + 1]
            dims = list(b[body + 2: body + 2 + nd])
            out.append({"record": i, "name": name, "gid": gid, "off_at": off_at, "type_at": body, "type": typ,
                        "ndim": nd, "dims": dims, "data_at": body + 2 + nd})
        if nxt <= 0:
            break
        i = off_at + nxt
    for p in out:
        p["group"] = groups.get(p["gid"], "?")
    return out


def _c3d_mutation(rng: random.Random, b: bytearray) -> None:
    op = rng.randrange(10)
    if len(b) < 512:
        _bytes_mutation(rng, b, [])
        return
    if op < 3:  # a header word
        w = rng.choice(_C3D_WORDS)
        old = struct.unpack_from("<H", b, 2 * (w - 1))[0]
        v = rng.choice(_C3D_INT16 + [old + 1, max(old - 1, 0), min(old * 2, 0xFFFF), old // 2])
        if w == 1 and rng.random() < 0.5:  # only the parameter block byte
            b[0] = rng.choice([0, 1, 2, 3, 200, 255])
        else:
            struct.pack_into("<H", b, 2 * (w - 1), v & 0xFFFF)
    elif op == 3:  # header floats
        at, _ = rng.choice(_C3D_FLOATS)
        struct.pack_into("<f", b, at, rng.choice(_C3D_FLOAT_VALUES))
    elif op < 8:  # parameter records
        params = c3d_parameters(bytes(b))
        if not params:
            _bytes_mutation(rng, b, [])
            return
        pri = [p for p in params if p["group"] in ("POINT", "ANALOG", "TRIAL")]
        p = rng.choice(pri if pri and rng.random() < 0.8 else params)
        what = rng.randrange(6)
        if what == 0:  # the value
            at = p["data_at"]
            if p["type"] == 2 and at + 2 <= len(b):
                struct.pack_into("<H", b, at, rng.choice(_C3D_INT16))
            elif p["type"] == 4 and at + 4 <= len(b):
                struct.pack_into("<f", b, at, rng.choice(_C3D_FLOAT_VALUES))
            elif at < len(b):
                b[at] = rng.choice(_INTERESTING_BYTES)
        elif what == 1:  # the type byte
            b[p["type_at"]] = rng.choice([0xFF, 1, 2, 4, 0, 3, 8, 0x80, 0xFE])
        elif what == 2:  # number of dimensions
            b[p["type_at"] + 1] = rng.choice([0, 1, 2, 3, 7, 255])
        elif what == 3 and p["ndim"]:  # a dimension
            b[p["type_at"] + 2 + rng.randrange(p["ndim"])] = rng.choice([0, 1, 2, 255, 128])
        elif what == 4:  # offset to the next record
            struct.pack_into("<h", b, p["off_at"], rng.choice([0, 1, -1, 2, 0x7FFF, -0x8000, 4]))
        else:  # name length / group id
            b[p["record"] + rng.randrange(2)] = rng.choice([0, 1, 0x7F, 0x80, 0xFF, 40])
    elif op == 8:  # number of parameter blocks, processor type
        start = (b[0] - 1) * 512
        if 0 <= start < len(b) - 4:
            k = start + 2 + rng.randrange(2)
            b[k] = rng.choice([0, 1, 2, 3, 84, 85, 86, 255])
    else:  # data block values: huge floats / NaN in the points
        data_start = (struct.unpack_from("<H", b, 16)[0] - 1) * 512
        if 0 <= data_start < len(b) - 4:
            for _ in range(rng.randint(1, 8)):
                at = data_start + 4 * rng.randrange(max(1, (len(b) - data_start) // 4))
                if at + 4 <= len(b):
                    struct.pack_into("<f", b, at, rng.choice(_C3D_FLOAT_VALUES))


def _npz_mutation(rng: random.Random, data: bytes) -> bytes:
    """Rebuild the npz with one array changed, dropped or added; or craft a lying .npy header."""
    import io

    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except Exception:
        return data
    keys = sorted(arrays)
    k = rng.choice(keys)
    a = arrays[k]
    op = rng.randrange(12)
    if op == 0:
        del arrays[k]
    elif op == 1:
        arrays[k] = np.array(rng.choice(["", "motion", "markers", "x" * 1000, "[[[[", "null", '[["Xrotation"]]',
                                         "[1, 2]", '{"a": 1}', "[" * 5000]))
    elif op == 2:
        arrays[k] = np.asarray(a).reshape(-1)
    elif op == 3:
        arrays[k] = np.asarray(a)[:1] if np.ndim(a) else np.array([a, a])
    elif op == 4:
        try:
            arrays[k] = np.asarray(a).astype(rng.choice([np.int64, np.int8, np.float32, np.complex128, np.bool_, "U3"]))
        except (ValueError, TypeError):
            arrays[k] = np.array([1, 2, 3])
    elif op == 5 and np.asarray(a).dtype.kind == "f" and np.size(a):
        b = np.array(a, dtype=np.float64, copy=True)
        flat = b.reshape(-1)
        for _ in range(rng.randint(1, 5)):
            flat[rng.randrange(flat.size)] = rng.choice([np.nan, np.inf, -np.inf, 1e308, -1e308, 0.0, 5.0, -1.0])
        arrays[k] = b
    elif op == 6:
        arrays[k] = rng.choice([np.array(-1), np.array(0), np.array(np.nan), np.array(np.inf), np.array(1e308),
                                np.array(2**62), np.zeros((0,)), np.zeros((0, 3)), np.zeros((2, 0, 4)),
                                np.array([[1, 2], [3, 4]])])
    elif op == 7 and np.ndim(a) >= 1 and np.shape(a)[0] > 1:
        arrays[k] = np.concatenate([a, a[:1]]) if rng.random() < 0.5 else a[1:]
    elif op == 8:
        arrays[k] = np.asarray(a).T if np.ndim(a) > 1 else np.atleast_1d(a)[::-1]
    elif op == 9:  # a .npy header that claims a huge shape over the real data
        return _lying_npz(rng, arrays, k)
    elif op == 10:
        arrays[rng.choice(["translations", "axes", "extra", "labels"])] = np.zeros((3, 3))
    elif np.asarray(a).dtype.kind in "iuf":
        arrays[k] = np.asarray(a) * rng.choice([-1, 2, 1e300, 0])
    buf = io.BytesIO()
    (np.savez_compressed if rng.random() < 0.5 else np.savez)(buf, **arrays)
    return buf.getvalue()


def _lying_npz(rng: random.Random, arrays: dict, key: str) -> bytes:
    import io
    import zipfile

    buf = io.BytesIO()
    huge = rng.choice([(2**40,), (10**6, 10**6), (2**31, 31, 4), (2**62,), (50_000_000,), (-1,)])
    with zipfile.ZipFile(buf, "w", compression=rng.choice([zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED])) as zf:
        for name, arr in arrays.items():
            item = io.BytesIO()
            np.save(item, arr)
            raw = item.getvalue()
            if name == key:
                hdr = repr({"descr": "<f8", "fortran_order": False, "shape": huge}).encode("latin-1")
                pad = 64 - (10 + len(hdr) + 1) % 64
                header = b"\x93NUMPY\x01\x00" + struct.pack("<H", len(hdr) + pad + 1) + hdr + b" " * pad + b"\n"
                raw = header + b"\x00" * rng.choice([0, 8, 4096])
            zf.writestr(name + ".npy", raw)
    return buf.getvalue()


def mutate(seed: Seed, n: int, seeds: list[Seed]) -> bytes:
    """The ``n``-th mutant of ``seed`` (deterministic): 1 to 3 mutations, byte level or format aware."""
    rng = random.Random((hash_name(seed.name) << 32) ^ n)
    others = [s.data for s in seeds if s.fmt == seed.fmt and s.name != seed.name] or [s.data for s in seeds]
    data = seed.data
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        try:
            data = _mutate_once(rng, seed, data, others)
        except Exception:  # a mutation that does not apply to this input is skipped, not a reader failure
            pass
    return data


def _mutate_once(rng: random.Random, seed: Seed, data: bytes, others: list[bytes]) -> bytes:
    if True:
        r = rng.random()
        if seed.fmt == "c3d":
            b = bytearray(data)
            (_c3d_mutation if r < 0.7 else _bytes_mutation)(rng, b, *([others] if r >= 0.7 else []))
            data = bytes(b)
        elif seed.fmt == "npz":
            if r < 0.75:
                data = _npz_mutation(rng, data)
            else:
                b = bytearray(data)
                _bytes_mutation(rng, b, others)
                data = bytes(b)
        else:
            if r < 0.3:
                b = bytearray(data)
                _bytes_mutation(rng, b, others)
                data = bytes(b)
            elif r < 0.55:
                data = _number_mutation(rng, data)
            elif r < 0.75:
                data = _line_mutation(rng, data)
            else:
                data = {"bvh": _bvh_mutation, "asf": _asf_mutation, "amc": _amc_mutation}[seed.fmt](rng, data)
    return data


def hash_name(name: str) -> int:
    """A stable (not salted) 32-bit hash of a seed name."""
    h = 2166136261
    for c in name.encode():
        h = ((h ^ c) * 16777619) & 0xFFFFFFFF
    return h


# -- the oracle ----------------------------------------------------------------------------


def _finite_or_nan(a: np.ndarray) -> bool:
    return not np.any(np.isinf(a))


def consistency_problems(obj) -> list[str]:
    """What is wrong with a successful read (empty when the result is consistent).

    A Motion: at least one frame; ``rotations`` (F, J, 4), ``root_positions``
    (F, 3), ``translations`` None or (F, J, 3); fps finite and positive; no
    infinite value anywhere (NaN is the one "missing"); each quaternion either
    all NaN or of unit norm (1e-5); skeleton offsets and end-site offsets
    finite; axes (when set) finite unit quaternions; ``unit_cm`` None or finite
    positive; channels one tuple per joint. A MarkerSet: at least one frame and
    one marker, positions (F, M, 3) with one label per marker, fps finite and
    positive, no infinite position. A Skeleton (from read_asf): the skeleton
    checks.
    """
    from mocapkit.io.c3d import MarkerSet
    from mocapkit.motion import Motion, Skeleton

    p: list[str] = []

    def skeleton(sk: Skeleton) -> None:
        J = sk.num_joints
        if sk.offsets.shape != (J, 3) or not np.all(np.isfinite(sk.offsets)):
            p.append("skeleton offsets not finite (J, 3)")
        if not np.all(np.isfinite(sk.end_site_offsets)):
            p.append("end-site offsets not finite")
        if sk.axes is not None:
            if sk.axes.shape != (J, 4) or not np.all(np.isfinite(sk.axes)):
                p.append("axes not finite (J, 4)")
            elif np.any(np.abs(np.linalg.norm(sk.axes, axis=-1) - 1) > 1e-5):
                p.append("axes are not unit quaternions")
        if sk.unit_cm is not None and not (np.isfinite(sk.unit_cm) and sk.unit_cm > 0):
            p.append(f"unit_cm {sk.unit_cm!r} not finite positive")
        if sk.channels is not None and len(sk.channels) != J:
            p.append("channels not one per joint")

    if isinstance(obj, Motion):
        sk = obj.skeleton
        J = sk.num_joints
        F = obj.rotations.shape[0]
        if F < 1:
            p.append("no frames")
        if obj.rotations.shape != (F, J, 4):
            p.append(f"rotations shape {obj.rotations.shape}")
        if obj.root_positions.shape != (F, 3):
            p.append(f"root_positions shape {obj.root_positions.shape}")
        if obj.translations is not None and obj.translations.shape != (F, J, 3):
            p.append(f"translations shape {obj.translations.shape}")
        if not (np.isfinite(obj.fps) and obj.fps > 0):
            p.append(f"fps {obj.fps!r}")
        for name, a in (("rotations", obj.rotations), ("root_positions", obj.root_positions),
                        ("translations", obj.translations)):
            if a is not None and not _finite_or_nan(a):
                p.append(f"{name} holds inf")
        q = obj.rotations
        nan = np.isnan(q)
        if np.any(nan.any(-1) != nan.all(-1)):
            p.append("a quaternion is partly NaN")
        norm = np.linalg.norm(np.where(nan, 0.0, q), axis=-1)
        if np.any(np.abs(norm[~nan.any(-1)] - 1.0) > 1e-5):
            p.append("a rotation is not a unit quaternion")
        skeleton(sk)
    elif isinstance(obj, MarkerSet):
        F, M = obj.positions.shape[:2]
        if F < 1 or M < 1:
            p.append(f"empty marker set {obj.positions.shape}")
        if obj.positions.shape != (F, len(obj.labels), 3):
            p.append(f"positions shape {obj.positions.shape} for {len(obj.labels)} labels")
        if not (np.isfinite(obj.fps) and obj.fps > 0):
            p.append(f"fps {obj.fps!r}")
        if not _finite_or_nan(obj.positions):
            p.append("positions hold inf")
    elif isinstance(obj, Skeleton):
        skeleton(obj)
    else:
        p.append(f"unexpected result type {type(obj).__name__}")
    return p


@dataclass
class Outcome:
    """What one read gave: status is ok, format_error, crash, inconsistent, memory, hang or killed."""

    status: str
    detail: str = ""
    elapsed: float = 0.0
    error_type: str = ""
    tb: str = ""


def execute(fmt: str, data: bytes, companion: bytes | None, workdir: Path) -> Outcome:
    """Write the mutant under ``workdir`` and read it; classify what happens."""
    from mocapkit.errors import MocapFormatError
    from mocapkit.io import load
    from mocapkit.io.asfamc import read_amc, read_asf

    workdir = Path(workdir)
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            # as in the test suite (pyproject filterwarnings): a RuntimeWarning from mocapkit is an error
            warnings.filterwarnings("error", category=RuntimeWarning, module=r"mocapkit(\.|$)")
            if fmt == "asf":
                p = workdir / "mutant.asf"
                p.write_bytes(data)
                (workdir / "valid.amc").write_bytes(companion)
                results = []
                try:
                    results.append(read_asf(p))
                except MocapFormatError:
                    pass
                results.append(read_amc(workdir / "valid.amc", asf=p))
            elif fmt == "amc":
                p = workdir / "mutant.amc"
                p.write_bytes(data)
                (workdir / "valid.asf").write_bytes(companion)
                results = [load(p, asf=workdir / "valid.asf")]
            else:
                p = workdir / f"mutant.{fmt}"
                p.write_bytes(data)
                results = [load(p)]
    except MocapFormatError as exc:
        msg = str(exc)
        if "\n" in msg or not msg.startswith(str(workdir)):
            return Outcome("crash", f"MocapFormatError not one line naming the file: {msg!r}",
                           time.perf_counter() - t0, "MocapFormatError")
        return Outcome("format_error", msg, time.perf_counter() - t0)
    except MemoryError as exc:
        return Outcome("memory", f"MemoryError: {exc}", time.perf_counter() - t0, "MemoryError", traceback.format_exc())
    except Exception as exc:  # the oracle: anything else is a crash
        return Outcome("crash", f"{type(exc).__name__}: {exc}"[:2000], time.perf_counter() - t0,
                       type(exc).__name__, traceback.format_exc())
    elapsed = time.perf_counter() - t0
    problems = [q for r in results for q in consistency_problems(r)]
    if problems:
        return Outcome("inconsistent", "; ".join(problems), elapsed, "inconsistent")
    return Outcome("ok", "", elapsed)


# -- the pool ------------------------------------------------------------------------------


def _worker(conn, seeds: list[Seed], mem_bytes: int) -> None:
    if mem_bytes:
        resource.setrlimit(resource.RLIMIT_AS, (mem_bytes, mem_bytes))
    try:
        os.nice(5)
    except OSError:
        pass
    workdir = Path(tempfile.mkdtemp(prefix="mocapkit-fuzz-"))
    try:
        while True:
            try:
                task = conn.recv()
            except EOFError:
                break
            if task is None:
                break
            idx, s, n = task
            seed = seeds[s]
            data = mutate(seed, n, seeds) if n >= 0 else seed.data
            out = execute(seed.fmt, data, seed.companion, workdir)
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
            conn.send((idx, out, rss))
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


@dataclass
class FuzzPool:
    """Forked workers under ``RLIMIT_AS`` = ``mem_bytes``, one task at a time each, ``timeout`` s per read.

    :meth:`run` takes tasks ``(seed index, mutant number)`` (-1: the seed itself)
    and yields ``(task index, Outcome, worker peak RSS in bytes)`` as they finish,
    in any order. A read over ``timeout`` gives an Outcome ``hang`` and a worker
    that dies one ``killed`` (its exit code or signal in ``detail``); either way
    a fresh worker takes its place.
    """

    seeds: list[Seed]
    workers: int = 2
    timeout: float = 5.0
    mem_bytes: int = 2 << 30
    restarts: int = field(default=0, init=False)

    def _spawn(self):
        import multiprocessing as mp

        ctx = mp.get_context("fork")
        parent, child = ctx.Pipe()
        proc = ctx.Process(target=_worker, args=(child, self.seeds, self.mem_bytes), daemon=True)
        proc.start()
        child.close()
        return proc, parent

    def run(self, tasks: list[tuple[int, int]]):
        from multiprocessing.connection import wait

        warm_up(self.seeds)
        todo = list(enumerate(tasks))[::-1]
        slots = [self._spawn() for _ in range(max(1, min(self.workers, len(tasks))))]
        busy: dict[int, tuple[int, float]] = {}  # slot -> (task index, start time)

        def feed(k: int) -> None:
            if todo:
                idx, (s, n) = todo.pop()
                slots[k][1].send((idx, s, n))
                busy[k] = (idx, time.monotonic())

        try:
            for k in range(len(slots)):
                feed(k)
            while busy:
                conns = {slots[k][1]: k for k in busy}
                now = time.monotonic()
                left = min(self.timeout - (now - t) for _, t in busy.values())
                ready = wait(list(conns), timeout=max(0.0, left))
                for c in ready:
                    k = conns[c]
                    idx, _ = busy.pop(k)
                    try:
                        got = c.recv()
                    except (EOFError, OSError):
                        proc = slots[k][0]
                        proc.join(1)
                        code = proc.exitcode
                        how = f"signal {-code}" if code is not None and code < 0 else f"exit code {code}"
                        yield idx, Outcome("killed", f"worker died ({how})", 0.0, "killed"), 0
                        self._replace(slots, k)
                    else:
                        yield got
                    feed(k)
                now = time.monotonic()
                for k, (idx, t) in list(busy.items()):
                    if now - t >= self.timeout and slots[k][1] not in ready:
                        busy.pop(k)
                        yield idx, Outcome("hang", f"over {self.timeout:g} s", now - t, "hang"), 0
                        self._replace(slots, k)
                        feed(k)
        finally:
            for proc, conn in slots:
                try:
                    conn.send(None)
                except (OSError, BrokenPipeError):
                    pass
            for proc, conn in slots:
                proc.join(2)
                if proc.is_alive():
                    proc.kill()
                    proc.join()

    def _replace(self, slots, k: int) -> None:
        proc, conn = slots[k]
        if proc.is_alive():
            proc.kill()
        proc.join()
        conn.close()
        slots[k] = self._spawn()
        self.restarts += 1


def warm_up(seeds: list[Seed]) -> None:
    """Read every format once in this process so forked workers inherit compiled numba kernels."""
    work = Path(tempfile.mkdtemp(prefix="mocapkit-fuzz-warm-"))
    try:
        seen = set()
        for s in seeds:
            if s.fmt not in seen:
                seen.add(s.fmt)
                execute(s.fmt, s.data, s.companion, work)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def reproduce(seeds: list[Seed], s: int, n: int) -> bytes:
    """The bytes of mutant ``n`` of seed ``s`` (for a report or a regression file)."""
    return mutate(seeds[s], n, seeds) if n >= 0 else seeds[s].data
