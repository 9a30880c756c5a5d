"""The fixed cases of the command fuzzer: the hand-made inputs of issue 20, each with what the command must do.

Each entry of :data:`FIXED_CASES` makes a :class:`~tests.fuzzing.commands.Case`:
files (trimmed bundled clips, edited by hand) and the command lines a careless or
hostile user ran on them, with the verdict each must reach: ``"ok"`` (a valid
input, exit 0), ``"refuse"`` (one line, exit 2, nothing written) or ``"any"``
(either, within the limits). Inputs are listed so that the oracle protects them
whatever the command writes. The cases need only the bundled samples.

:func:`zip_bomb_npz` makes the npz zip bomb (a ~4 MB file whose ``rotations``
member inflates to 4 GB, with a correct CRC computed by :func:`crc32_of_zeros`
without making the 4 GB).
"""

from __future__ import annotations

import functools
import io
import json
import re
import struct
import tempfile
import threading
import zlib
from pathlib import Path
from typing import Callable

import numpy as np

from . import readers
from .commands import TRIM_FRAMES, Case, Step, Symlink, npz_of

__all__ = ["FIXED_CASES", "BIG_CASES", "fixed_case", "about", "zip_bomb_npz", "crc32_of_zeros"]


# -- the zip bomb --------------------------------------------------------------------------------


def _gf2_times(mat: list[int], vec: int) -> int:
    s, i = 0, 0
    while vec:
        if vec & 1:
            s ^= mat[i]
        vec >>= 1
        i += 1
    return s


def _gf2_square(mat: list[int]) -> list[int]:
    return [_gf2_times(mat, mat[k]) for k in range(32)]


def _crc32_combine(crc1: int, crc2: int, len2: int) -> int:
    """CRC-32 of A + B from crc(A), crc(B) and len(B): zlib's crc32_combine (GF(2) matrix powers)."""
    if len2 <= 0:
        return crc1
    odd = [0xEDB88320] + [1 << k for k in range(31)]
    even = _gf2_square(odd)
    odd = _gf2_square(even)
    while True:
        even = _gf2_square(odd)
        if len2 & 1:
            crc1 = _gf2_times(even, crc1)
        len2 >>= 1
        if not len2:
            break
        odd = _gf2_square(even)
        if len2 & 1:
            crc1 = _gf2_times(odd, crc1)
        len2 >>= 1
        if not len2:
            break
    return crc1 ^ crc2


@functools.lru_cache(maxsize=None)
def _crc32_zeros(n: int) -> int:
    """``zlib.crc32(bytes(n))``: halves share their CRC, so a 4 GB run costs two 1 MiB CRCs and one combine a level."""
    if n <= 1 << 20:
        return zlib.crc32(bytes(n))
    half = n // 2
    return _crc32_combine(_crc32_zeros(half), _crc32_zeros(n - half), n - half)


def crc32_of_zeros(n: int, start: int = 0) -> int:
    """``zlib.crc32(bytes(n), start)`` without making ``n`` bytes (for a 4 GB member's CRC in milliseconds):
    ``start`` is the CRC of what comes before, combined with the CRC of the zeros."""
    return _crc32_combine(start, _crc32_zeros(n), n)


def _npy_header(descr: str, shape: tuple) -> bytes:
    hdr = repr({"descr": descr, "fortran_order": False, "shape": shape}).encode("latin-1")
    pad = 64 - (10 + len(hdr) + 1) % 64
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(hdr) + pad + 1) + hdr + b" " * pad + b"\n"


def _zip(members: list[tuple[str, bytes, int, int, int]]) -> bytes:
    """A zip of ``(name, stored bytes, method, crc, uncompressed size)`` members (sizes < 4 GiB, no zip64)."""
    out = bytearray()
    central = bytearray()
    for name, body, method, crc, usize in members:
        fname = name.encode()
        offset = len(out)
        out += struct.pack("<IHHHHHIIIHH", 0x04034B50, 20, 0, method, 0, 0x21, crc, len(body), usize, len(fname), 0)
        out += fname + body
        central += struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 20, 20, 0, method, 0, 0x21, crc, len(body), usize,
                               len(fname), 0, 0, 0, 0, 0, offset)
        central += fname
    cd_at = len(out)
    out += central
    out += struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, len(members), len(members), len(central), cd_at, 0)
    return bytes(out)


def zip_bomb_npz(npz: bytes, key: str = "rotations", nbytes: int = 4_000_000_000) -> bytes:
    """``npz`` with member ``key`` replaced by a valid deflated .npy of about ``nbytes`` zero bytes (~4 MB on disk).

    The .npy header declares shape (nbytes // (J * 4 * 8), J, 4) float64 for a rotations array
    of J joints (else (nbytes // 8,)); the CRC is right, so a reader that inflates it gets a
    real 4 GB array. Everything else is stored as it was.
    """
    with np.load(io.BytesIO(npz), allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    a = arrays[key]
    per = int(np.prod(a.shape[1:])) * 8 if a.ndim > 1 else 8
    shape = (nbytes // per,) + tuple(a.shape[1:])
    header = _npy_header("<f8", shape)
    zeros = shape[0] * per
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    head = c.compress(header) + c.flush(zlib.Z_FULL_FLUSH)
    mib = 1 << 20
    block = c.compress(bytes(mib)) + c.flush(zlib.Z_FULL_FLUSH)
    again = c.compress(bytes(mib)) + c.flush(zlib.Z_FULL_FLUSH)
    if again != block:  # pragma: no cover - a full flush resets the compressor, so blocks repeat
        raise RuntimeError("deflate blocks of zeros differ after a full flush")
    count, rest = divmod(zeros, mib)
    tail = c.compress(bytes(rest)) + c.flush()
    stream = head + block * count + tail
    crc = crc32_of_zeros(zeros, zlib.crc32(header))
    members = []
    for k, v in arrays.items():
        if k == key:
            members.append((k + ".npy", stream, 8, crc, len(header) + zeros))
        else:
            buf = io.BytesIO()
            np.save(buf, v)
            raw = buf.getvalue()
            members.append((k + ".npy", raw, 0, zlib.crc32(raw), len(raw)))
    return _zip(members)


# -- fixed cases: the hand-made inputs of issue 20 ---------------------------------------------------


def _bundled(name: str, frames: int | None = None) -> bytes:
    from mocapkit import samples

    data = samples.path(name).read_bytes()
    if frames is None:
        return data
    return readers.trim_amc(data, frames) if name.endswith(".amc") else readers.trim_bvh(data, frames)


def _bvh(frames: int = TRIM_FRAMES) -> bytes:
    return _bundled("131_01.bvh", frames)


def _walk_npz(frames: int) -> bytes:
    """The npz of the bundled CMU walk (12_walk.amc, the shipped deep models' rig), first ``frames`` frames."""
    from mocapkit.io import load
    from mocapkit.io.npz import write_npz

    with tempfile.TemporaryDirectory(prefix="mocapkit-fuzz-npz-") as d:
        (Path(d) / "walk.amc").write_bytes(_bundled("12_walk.amc", frames))
        (Path(d) / "walk.asf").write_bytes(_bundled("12.asf"))
        write_npz(load(Path(d) / "walk.amc"), Path(d) / "walk.npz")
        return (Path(d) / "walk.npz").read_bytes()


def _motion_npz(frames: int = TRIM_FRAMES, walk: bool = False, **changes) -> bytes:
    """The npz of the bundled BVH's (or with ``walk`` the CMU walk's) first ``frames`` frames, ``changes`` made to its arrays."""
    raw = _walk_npz(frames) if walk else npz_of(readers.Seed("s.bvh", "bvh", _bvh(frames)))
    with np.load(io.BytesIO(raw), allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    for k, v in changes.items():
        arrays[k] = v(arrays) if callable(v) else v
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _chain_bvh(depth: int, frames: int = 2) -> bytes:
    """A BVH whose joints form one chain ``depth`` deep, written without indentation."""
    lines = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0", "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    for k in range(1, depth):
        lines += [f"JOINT j{k}", "{", "OFFSET 0 1 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
    lines += ["End Site", "{", "OFFSET 0 1 0", "}"] + ["}"] * depth
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    row = " ".join(["0"] * (6 + 3 * (depth - 1)))
    lines += [row] * frames
    return ("\n".join(lines) + "\n").encode()


def _robot_bvh(frames: int = 40) -> bytes:
    """A three-joint arm, Base/Link1/Link2: no joint plays a human role."""
    lines = ["HIERARCHY", "ROOT Base", "{", "  OFFSET 0 0 0", "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
             "  JOINT Link1", "  {", "    OFFSET 0 10 0", "    CHANNELS 3 Zrotation Xrotation Yrotation",
             "    JOINT Link2", "    {", "      OFFSET 0 10 0", "      CHANNELS 3 Zrotation Xrotation Yrotation",
             "      End Site", "      {", "        OFFSET 0 5 0", "      }", "    }", "  }", "}",
             "MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    for f in range(frames):
        lines.append(f"0 0 0 0 0 0 {f % 30} 0 0 0 {2 * (f % 20)} 0")
    return ("\n".join(lines) + "\n").encode()


def _c3d_point_used(value: int) -> bytes:
    from mocapkit import samples

    b = bytearray(samples.path("Eb015pr.c3d").read_bytes())
    p = next(p for p in readers.c3d_parameters(bytes(b)) if p["group"] == "POINT" and p["name"] == "USED")
    struct.pack_into("<H", b, p["data_at"], value)
    return bytes(b)


_TEMPLATE_DB: dict | None = None
_TEMPLATE_LOCK = threading.Lock()


def _template_db() -> dict:
    """The files of a small real database (the bundled BVH's first 150 frames at 30 fps, F15), built once."""
    global _TEMPLATE_DB
    with _TEMPLATE_LOCK:
        if _TEMPLATE_DB is None:
            from mocapkit.database import MotionDatabase

            with tempfile.TemporaryDirectory(prefix="mocapkit-fuzz-db-") as d:
                src = Path(d) / "take.bvh"
                src.write_bytes(_bvh())
                MotionDatabase.build([src], fps=30, features=("F15",), executor="serial", progress=False).save(Path(d) / "db")
                _TEMPLATE_DB = {str(p.relative_to(d)): p.read_bytes() for p in sorted((Path(d) / "db").rglob("*")) if p.is_file()}
        return dict(_TEMPLATE_DB)


def _db_with(edit: Callable[[dict, dict], None]) -> dict:
    """The template database's files after ``edit(description, files)`` (database.json re-serialised)."""
    files = _template_db()
    desc = json.loads(files["db/database.json"])
    edit(desc, files)
    files["db/database.json"] = json.dumps(desc).encode()
    return files


def _npy(a) -> bytes:
    buf = io.BytesIO()
    np.save(buf, np.asarray(a))
    return buf.getvalue()


def _db_steps(search: bool = False) -> tuple[Step, ...]:
    """``db info db --clips`` (and ``search db q.bvh``) on a broken database: both must refuse in one line."""
    return (Step(("db", "info", "db", "--clips"), "refuse"),) + ((Step(("search", "db", "q.bvh"), "refuse"),) if search else ())


def _two_outputs_or_refused(root: Path, results: list) -> list[str]:
    if not results or results[-1].returncode != 0:
        return []
    outs = [p for p in (root / "out").rglob("*") if p.is_file() and not p.name.endswith(".clean.npz")]
    if len(outs) < 2:
        return [f"clean-batch exited 0 with {len(outs)} cleaned output(s) for take.amc and take.bvh: one result lost"]
    return []


def _build_fixed() -> dict[str, Callable[[], Case]]:
    bvh = _bvh
    reg: dict[str, Callable[[], Case]] = {}

    def case(name: str, about: str):
        def deco(fn):
            def make() -> Case:
                c = fn()
                c.name, c.about = name, about
                return c
            make.about = about
            reg[name] = make
            return fn
        return deco

    @case("bvh-frame-time-1000", "a 300-frame BVH with Frame Time: 1000 (clean built a 7,176,001-frame array: 24 GB)")
    def _():
        data = re.sub(rb"Frame Time:[^\n]*", b"Frame Time: 1000", bvh(300))
        return Case("", {"slow.bvh": data}, (Step(("clean", "slow.bvh", "-o", "out.bvh"), "any", ("out.bvh", "out.clean.npz")),),
                    inputs=("slow.bvh",))

    @case("npz-fps-0.01", "denoise on an npz with fps 0.01 (used 8 GB)")
    def _():
        return Case("", {"slow.npz": _motion_npz(300, walk=True, fps=np.array(0.01))},
                    (Step(("denoise", "slow.npz", "-o", "out.bvh"), "any", ("out.bvh",)),), inputs=("slow.npz",))

    @case("npz-zip-bomb", "a 4 MB npz whose rotations member inflates to 4 GB (loaded and copied: 9 GB)")
    def _():
        bomb = zip_bomb_npz(_motion_npz())
        return Case("", {"bomb.npz": bomb}, (Step(("info", "bomb.npz"), "refuse"),
                                             Step(("convert", "bomb.npz", "out.bvh"), "refuse", ("out.bvh",))),
                    inputs=("bomb.npz",))

    @case("bvh-chain-3000", "a 3,000-deep joint chain (the writer's output grew with depth squared: 93x the input)")
    def _():
        return Case("", {"chain.bvh": _chain_bvh(3000)},
                    (Step(("info", "chain.bvh"), "any"),
                     Step(("convert", "chain.bvh", "out.bvh"), "any", ("out.bvh",), max_output_ratio=10.0)),
                    inputs=("chain.bvh",))

    @case("c3d-point-used-32767", "POINT:USED 32,767 against the header's 26 points (read as 32,767 markers, exit 0)")
    def _():
        return Case("", {"used.c3d": _c3d_point_used(32767)},
                    (Step(("info", "used.c3d"), "refuse"), Step(("convert", "used.c3d", "out.npz"), "refuse", ("out.npz",))),
                    inputs=("used.c3d",))

    @case("markup-names-npz", "joint [/b] and clip [/] through rich markup (MarkupError after writing)")
    def _():
        def names(a):
            n = [str(x) for x in a["joint_names"]]
            n[3] = "[/b]"
            return np.array(n)

        data = _motion_npz(joint_names=names, name=np.array("[/]"))
        return Case("", {"m.npz": data}, (
            Step(("info", "m.npz", "--joints"), "ok"),
            Step(("convert", "m.npz", "out.bvh"), "ok", ("out.bvh",)),
            Step(("detect", "m.npz", "-o", "det.npz"), "ok", ("det.npz",)),
            Step(("db", "build", "db", "m.npz", "--executor", "serial"), "ok", ("db",)),
            Step(("db", "info", "db", "--clips"), "ok"),
            Step(("search", "db", "m.npz"), "ok"),
        ), inputs=("m.npz",))

    @case("markup-names-bvh", "a BVH named [/b]take.bvh with a joint [/b] (info, convert, detect print it)")
    def _():
        data = re.sub(rb"JOINT[ \t]+LeftHip\b", b"JOINT [/b]", bvh())
        return Case("", {"[/b]take.bvh": data}, (
            Step(("info", "[/b]take.bvh", "--joints"), "ok"),
            Step(("convert", "[/b]take.bvh", "[/]out.bvh"), "ok", ("[/]out.bvh",)),
            Step(("detect", "[/b]take.bvh", "-o", "[b]det.npz", "--json"), "ok", ("[b]det.npz",)),
        ), inputs=("[/b]take.bvh",))

    @case("lone-surrogate-joint", "a joint name holding a lone surrogate, written to BVH (UnicodeEncodeError)")
    def _():
        def names(a):
            n = [str(x) for x in a["joint_names"]]
            n[2] = "bad\ud800name"
            return np.array(n)

        return Case("", {"s.npz": _motion_npz(joint_names=names)}, (
            Step(("info", "s.npz", "--joints"), "any"),
            Step(("convert", "s.npz", "out.bvh"), "any", ("out.bvh",)),
        ), inputs=("s.npz",))

    @case("lone-surrogate-bvh-bytes", "a BVH joint name of the bytes ED A0 80 (a UTF-8-encoded surrogate)")
    def _():
        data = re.sub(rb"JOINT[ \t]+LeftHip\b", b"JOINT Left\xed\xa0\x80Hip", bvh())
        return Case("", {"s.bvh": data}, (
            Step(("info", "s.bvh", "--joints"), "any"),
            Step(("convert", "s.bvh", "out.bvh"), "any", ("out.bvh",)),
        ), inputs=("s.bvh",))

    @case("info-base-link1-link2", "info on a Base/Link1/Link2 skeleton (KeyError: no joint plays the role 'left_foot')")
    def _():
        return Case("", {"arm.bvh": _robot_bvh()}, (Step(("info", "arm.bvh"), "ok"), Step(("info", "arm.bvh", "--joints"), "ok")),
                    inputs=("arm.bvh",))

    @case("clean-output-is-reference", "clean a.bvh -o ref.bvh --reference ref.bvh (wrote over the reference)")
    def _():
        return Case("", {"a.bvh": bvh(), "ref.bvh": bvh()},
                    (Step(("clean", "a.bvh", "-o", "ref.bvh", "--reference", "ref.bvh"), "refuse", ("ref.bvh", "ref.clean.npz")),),
                    inputs=("a.bvh", "ref.bvh"))

    @case("clean-output-is-context", "clean a.bvh -o ctx.bvh --context ctx.bvh (wrote over the context)")
    def _():
        return Case("", {"a.bvh": bvh(), "ctx.bvh": bvh()},
                    (Step(("clean", "a.bvh", "-o", "ctx.bvh", "--context", "ctx.bvh"), "refuse", ("ctx.bvh", "ctx.clean.npz")),),
                    inputs=("a.bvh", "ctx.bvh"))

    @case("clean-output-is-input-via-symlink", "clean a.bvh -o link.bvh where link.bvh -> a.bvh")
    def _():
        return Case("", {"a.bvh": bvh(), "link.bvh": Symlink("a.bvh")},
                    (Step(("clean", "a.bvh", "-o", "link.bvh", "--steps", "fill"), "refuse", ("link.bvh", "link.clean.npz")),),
                    inputs=("a.bvh", "link.bvh"))

    @case("db-build-overwrite-over-inputs", "db build p p/takes/backflip.amc --overwrite (deleted the take and notes.txt)")
    def _():
        return Case("", {"p/takes/backflip.amc": _bundled("12_walk.amc", TRIM_FRAMES), "p/takes/backflip.asf": _bundled("12.asf"),
                         "p/notes.txt": b"my notes\n"},
                    (Step(("db", "build", "p", "p/takes/backflip.amc", "--overwrite"), "refuse", ("p",)),),
                    inputs=("p/takes/backflip.amc", "p/takes/backflip.asf", "p/notes.txt"))

    @case("executor-garbage", "--executor garbage (a traceback after up to 31 s)")
    def _():
        return Case("", {"a.bvh": bvh(), "in/a.bvh": bvh()}, (
            Step(("db", "build", "db", "a.bvh", "a.bvh", "--executor", "garbage"), "refuse", ("db",)),
            Step(("clean-batch", "in", "out", "--executor", "garbage", "--steps", "fill"), "refuse", ("out",)),
        ), inputs=("a.bvh", "in"))

    @case("executor-unreachable", "--executor tcp://127.0.0.1:1: must fail in one line (within 10 s: its wall time is in the benchmark's findings)")
    def _():
        return Case("", {"a.bvh": bvh(), "b.bvh": bvh()}, (
            Step(("db", "build", "db", "a.bvh", "b.bvh", "--executor", "tcp://127.0.0.1:1"), "refuse", ("db",)),
        ), inputs=("a.bvh", "b.bvh"))

    @case("output-in-readonly-folder", "convert a.bvh ro/out.bvh with ro read-only (traceback)")
    def _():
        return Case("", {"a.bvh": bvh(), "ro": None}, (
            Step(("convert", "a.bvh", "ro/out.bvh"), "refuse", ("ro/out.bvh",)),
            Step(("clean", "a.bvh", "-o", "ro/out.bvh", "--steps", "fill"), "refuse", ("ro/out.bvh", "ro/out.clean.npz")),
        ), inputs=("a.bvh",), readonly=("ro",))

    @case("output-onto-folder", "an output path that is an existing folder")
    def _():
        return Case("", {"a.bvh": bvh(), "out.bvh/keep.txt": b"keep\n"}, (
            Step(("convert", "a.bvh", "out.bvh"), "refuse", ("out.bvh",)),
            Step(("clean", "a.bvh", "-o", "out.bvh", "--steps", "fill"), "refuse", ("out.bvh", "out.clean.npz")),
        ), inputs=("a.bvh", "out.bvh"))

    @case("output-under-a-file", "an output whose parent is a file (notes.txt/out.bvh)")
    def _():
        return Case("", {"a.bvh": bvh(), "notes.txt": b"notes\n"}, (
            Step(("convert", "a.bvh", "notes.txt/out.bvh"), "refuse", ("notes.txt/out.bvh",)),
            Step(("db", "build", "notes.txt/db", "a.bvh"), "refuse", ("notes.txt/db",)),
        ), inputs=("a.bvh", "notes.txt"))

    @case("existing-output-needs-overwrite", "an existing output is replaced only with --overwrite")
    def _():
        return Case("", {"a.bvh": bvh(), "b.bvh": b"precious\n", "b.clean.npz": b"precious\n"}, (
            Step(("convert", "a.bvh", "b.bvh"), "refuse", ("b.bvh",)),
            Step(("clean", "a.bvh", "-o", "b.bvh", "--steps", "fill"), "refuse", ("b.bvh", "b.clean.npz")),
        ), inputs=("a.bvh", "b.bvh", "b.clean.npz"))

    @case("missing-parent-folders", "outputs in folders that do not exist yet are written (parents created)")
    def _():
        return Case("", {"a.bvh": bvh()}, (
            Step(("convert", "a.bvh", "x/y/out.bvh"), "ok", ("x/y/out.bvh",)),
            Step(("clean", "a.bvh", "-o", "z/w/out.bvh", "--steps", "fill"), "ok", ("z/w/out.bvh", "z/w/out.clean.npz")),
        ), inputs=("a.bvh",))

    @case("clean-reference-other-length", "--reference of another length: refused before OUT and .clean.npz are written")
    def _():
        return Case("", {"a.bvh": bvh(), "short.bvh": bvh(40)}, (
            Step(("clean", "a.bvh", "-o", "out.bvh", "--reference", "short.bvh", "--report", "rep.html", "--steps", "fill,detect"),
                 "refuse", ("out.bvh", "out.clean.npz", "rep.html")),
        ), inputs=("a.bvh", "short.bvh"))

    @case("clean-batch-same-stem", "take.amc and take.bvh in one folder: both results kept, or the batch refused")
    def _():
        c = Case("", {"in/take.amc": _bundled("12_walk.amc", TRIM_FRAMES), "in/take.asf": _bundled("12.asf"), "in/take.bvh": bvh()},
                 (Step(("clean-batch", "in", "out", "--steps", "fill", "--executor", "serial"), "any", ("out",)),),
                 inputs=("in",))
        c.check = _two_outputs_or_refused
        return c

    @case("db-nested-json", "database.json nested 100,000 deep (RecursionError)")
    def _():
        files = _template_db()
        files["db/database.json"] = b"[" * 100_000 + b"]" * 100_000
        return Case("", {**files, "q.bvh": bvh()}, _db_steps(), inputs=("db", "q.bvh"))

    @case("db-clip-ids-out-of-range", "clip_ids.npy pointing past the clips (IndexError)")
    def _():
        def edit(desc, files):
            ids = np.load(io.BytesIO(files["db/clip_ids.npy"]))
            files["db/clip_ids.npy"] = _npy(np.full_like(ids, 7))
        return Case("", {**_db_with(edit), "q.bvh": bvh()}, _db_steps(search=True), inputs=("db", "q.bvh"))

    @case("db-empty-npy", "a 0-byte rotations.npy (\"Aborted.\")")
    def _():
        def edit(desc, files):
            files["db/rotations.npy"] = b""
        return Case("", {**_db_with(edit), "q.bvh": bvh()}, _db_steps(), inputs=("db", "q.bvh"))

    @case("db-feature-name-is-a-path", "a feature named ../../secret maps a file outside the database")
    def _():
        def edit(desc, files):
            d = desc["features"].pop("F15")
            desc["features"]["../../secret"] = d
            files["secret.npy"] = files.pop("db/features/F15.npy")
        return Case("", {**_db_with(edit), "q.bvh": bvh()}, _db_steps(), inputs=("db", "q.bvh", "secret.npy"))

    @case("db-fps-zero", "database.json fps 0")
    def _():
        return Case("", {**_db_with(lambda desc, files: desc.update(fps=0)), "q.bvh": bvh()}, _db_steps(), inputs=("db", "q.bvh"))

    @case("db-fps-nan", "database.json fps NaN")
    def _():
        return Case("", {**_db_with(lambda desc, files: desc.update(fps=float("nan"))), "q.bvh": bvh()}, _db_steps(),
                    inputs=("db", "q.bvh"))

    @case("db-skeleton-index-out-of-range", "a clip whose skeleton index is past the skeletons")
    def _():
        def edit(desc, files):
            desc["clips"][0]["skeleton"] = 5
        return Case("", {**_db_with(edit), "q.bvh": bvh()}, _db_steps(), inputs=("db", "q.bvh"))

    return reg


FIXED_CASES: dict[str, Callable[[], Case]] = _build_fixed()


def _big_amc(megabytes: float = 50.0) -> bytes:
    """The bundled CMU walk's AMC, its frames repeated (renumbered) to ``megabytes`` MB."""
    text = _bundled("12_walk.amc").decode()
    lines = text.split("\n")
    first = next(i for i, ln in enumerate(lines) if ln.strip().isdigit())
    header, body = lines[:first], lines[first:]
    frames: list[list[str]] = []
    for ln in body:
        if ln.strip().isdigit():
            frames.append([])
        elif ln.strip() and frames:
            frames[-1].append(ln)
    out, size, k = header[:], 0, 0
    target = int(megabytes * 1e6)
    while size < target:
        f = frames[k % len(frames)]
        k += 1
        chunk = "\n".join([str(k)] + f)
        out.append(chunk)
        size += len(chunk) + 1
    return ("\n".join(out) + "\n").encode()


def _build_big() -> dict[str, Callable[[], Case]]:
    reg: dict[str, Callable[[], Case]] = {}

    def big_amc() -> Case:
        return Case("amc-50mb", {"big.amc": _big_amc(50.0), "big.asf": _bundled("12.asf")},
                    (Step(("info", "big.amc"), "any"), Step(("convert", "big.amc", "out.npz"), "any", ("out.npz",))),
                    inputs=("big.amc", "big.asf"), cpu_s=300.0,
                    about="a 50 MB AMC (the reader held about 30x the file in memory): under 2 GB or refused")

    big_amc.about = "a 50 MB AMC (the reader held about 30x the file in memory): under 2 GB or refused"
    reg["amc-50mb"] = big_amc
    return reg


# Cases too slow for the quick test (a 50 MB file): the benchmark runs them.
BIG_CASES: dict[str, Callable[[], Case]] = _build_big()


def about(name: str) -> str:
    """What the fixed case ``name`` tries, and what went wrong before (one line)."""
    return {**FIXED_CASES, **BIG_CASES}[name].about


def fixed_case(name: str) -> Case:
    """The fixed case ``name`` (a key of :data:`FIXED_CASES`), its files made now."""
    return FIXED_CASES[name]()
