"""Fuzzing the readers: mutants of real files raise MocapFormatError or read consistently; regressions of found crashes.

The seeded fuzz runs a few thousand mutants in rlimited worker processes
(``tests/fuzzing/readers.py``); ``benchmarks/fuzz_readers.py`` runs 100,000. Each
regression test below is the minimal form of a mutant the fuzzer found, with
what the reader did before the fix.
"""

from __future__ import annotations

import io
import struct
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.errors import MocapFormatError, SkeletonError
from mocapkit.io.asfamc import read_amc, read_asf
from mocapkit.io.npz import write_npz
from tests.fuzzing import readers as fuzz_readers

FAIL = ("crash", "inconsistent", "hang", "memory", "killed")


@pytest.fixture(scope="module")
def seeds(request):
    from tests.conftest import SHARED_DATA

    return fuzz_readers.load_seeds(SHARED_DATA if SHARED_DATA.is_dir() else None)


def _fuzz_run(seeds, per_format: dict[str, int], base: int):
    by_fmt: dict[str, list[int]] = {}
    for i, s in enumerate(seeds):
        by_fmt.setdefault(s.fmt, []).append(i)
    tasks = []
    for fmt, count in per_format.items():
        idx = by_fmt[fmt]
        tasks += [(idx[k % len(idx)], base + k // len(idx)) for k in range(count)]
    pool = fuzz_readers.FuzzPool(seeds, workers=2, timeout=5.0, mem_bytes=2 << 30)
    status: dict[str, dict[str, int]] = {f: {} for f in per_format}
    failures = []
    for idx, out, _ in pool.run(tasks):
        s, n = tasks[idx]
        fmt = seeds[s].fmt
        status[fmt][out.status] = status[fmt].get(out.status, 0) + 1
        if out.status in FAIL:
            failures.append((seeds[s].name, n, out.status, out.detail, out.tb[-800:]))
    return status, failures


def test_seeds_are_real_files_that_read_cleanly(seeds, tmp_path):
    assert {s.fmt for s in seeds} == set(fuzz_readers.FORMATS)
    for s in seeds:
        out = fuzz_readers.execute(s.fmt, s.data, s.companion, tmp_path)
        assert out.status == "ok", (s.name, out.detail)
    # trimmed, not invented: the BVH seed is the first frames of the bundled clip
    bvh = next(s for s in seeds if s.name == "131_01.bvh")
    (tmp_path / "t.bvh").write_bytes(bvh.data)
    short, full = mocapkit.load(tmp_path / "t.bvh"), mocapkit.load(samples.path("131_01.bvh"))
    assert short.num_frames == fuzz_readers.TRIM_FRAMES
    np.testing.assert_array_equal(short.rotations, full.rotations[: fuzz_readers.TRIM_FRAMES])


def test_mutants_are_deterministic_and_differ(seeds):
    s = seeds[0]
    assert fuzz_readers.mutate(s, 7, seeds) == fuzz_readers.mutate(s, 7, seeds)
    assert len({fuzz_readers.mutate(s, n, seeds) for n in range(50)}) > 40


def test_oracle_flags_inconsistent_results():
    m = mocapkit.load(samples.path("131_01.bvh"))[:5]
    assert fuzz_readers.consistency_problems(m) == []
    bad_root = np.array(m.root_positions)
    bad_root[2, 1] = np.inf
    bad_rot = np.array(m.rotations)
    bad_rot[1, 3] *= 2.0
    bad_rot[3, 4, 0] = np.nan
    import dataclasses

    with pytest.raises(SkeletonError, match="unit length"):  # a Motion refuses such rotations itself
        dataclasses.replace(m, rotations=bad_rot)
    with pytest.raises(SkeletonError, match="infinite"):  # and an infinite root position
        dataclasses.replace(m, root_positions=bad_root)
    bad = dataclasses.replace(m)
    object.__setattr__(bad, "root_positions", bad_root)  # as a reader that built its arrays around the checks would
    object.__setattr__(bad, "rotations", bad_rot)
    probs = fuzz_readers.consistency_problems(bad)
    assert "root_positions holds inf" in probs
    assert "a rotation is not a unit quaternion" in probs
    assert "a quaternion is partly NaN" in probs


def test_fuzz_readers_seeded(seeds):
    """1,500 mutants: every one raises MocapFormatError or reads consistently, none hangs or runs out of memory
    (test_fuzz_readers_30000, marked slow, and benchmarks/fuzz_readers.py run more)."""
    per_format = {"bvh": 350, "amc": 350, "asf": 150, "c3d": 400, "npz": 250}
    status, failures = _fuzz_run(seeds, per_format, base=1_000_000)
    assert failures == []
    for fmt, counts in status.items():
        assert sum(counts.values()) == per_format[fmt]
        # the mutants exercise both outcomes: rejected files and files that still read
        assert counts.get("format_error", 0) > 0.2 * per_format[fmt], (fmt, counts)
        assert counts.get("ok", 0) > 0.03 * per_format[fmt], (fmt, counts)


@pytest.mark.slow
def test_fuzz_readers_30000(seeds):
    per_format = {"bvh": 7500, "amc": 7500, "asf": 3000, "c3d": 7500, "npz": 4500}
    status, failures = _fuzz_run(seeds, per_format, base=2_000_000)
    assert failures == []


# -- regressions: the minimal form of each crash the fuzzer found ------------------------------------


def _bvh(tmp_path, edit) -> Path:
    text = fuzz_readers.trim_bvh(samples.path("131_01.bvh").read_bytes(), 3).decode()
    p = tmp_path / "m.bvh"
    p.write_text(edit(text))
    return p


def test_bvh_tiny_frame_time(tmp_path):
    # was OverflowError (round(1 / 1e-320 = inf))
    p = _bvh(tmp_path, lambda t: t.replace("Frame Time: .0083333", "Frame Time: 1e-320"))
    with pytest.raises(MocapFormatError, match=r"m\.bvh:\d+: Frame Time 1e-320 is too small"):
        mocapkit.load(p)


@pytest.mark.parametrize("token", ["nan", "inf", "1e309"])
def test_bvh_non_finite_offset(tmp_path, token):
    # was a Motion with a NaN / infinite skeleton offset
    p = _bvh(tmp_path, lambda t: t.replace("OFFSET 1.24777 -1.64261", f"OFFSET {token} -1.64261"))
    with pytest.raises(MocapFormatError, match=r"m\.bvh:\d+: OFFSET: .* is not a finite number"):
        mocapkit.load(p)


def test_bvh_infinite_channel_value(tmp_path):
    # was a Motion with infinite root positions (and NaN quaternions for infinite angles)
    def edit(t):
        head, body = t.split("Frame Time: .0083333\n")
        rows = body.splitlines()
        vals = rows[1].split()
        vals[1] = "-inf"
        rows[1] = " ".join(vals)
        return head + "Frame Time: .0083333\n" + "\n".join(rows) + "\n"

    p = _bvh(tmp_path, edit)
    line = p.read_text().splitlines().index(edit(p.read_text()).splitlines()[-2]) + 1
    with pytest.raises(MocapFormatError, match=rf"m\.bvh:{line}: infinite value -inf in frame 2 \(column 2\)"):
        mocapkit.load(p)


def test_amc_infinite_value(tmp_path):
    # was RuntimeWarning "invalid value encountered in cos" (an error under the test settings)
    lines = fuzz_readers.trim_amc(samples.path("12_walk.amc").read_bytes(), 2).decode().split("\n")
    lines[6] = "upperback 3.47255 inf 1.65684"
    p = tmp_path / "m.amc"
    p.write_text("\n".join(lines))
    with pytest.raises(MocapFormatError, match=r"m\.amc:7: infinite value inf"):
        read_amc(p, asf=samples.path("12.asf"))


@pytest.mark.parametrize(
    "old, new, message",
    [
        ("length 0.45", "length 1e-320", "units length must be a positive number"),  # was unit_cm = inf
        ("direction 0.734638 -0.55547", "direction nan -0.55547", "direction: values must be finite"),
        ("direction 0.734638 -0.55547", "direction 1e308 -0.55547", None),  # direction * length overflowed: RuntimeWarning
        ("axis 0 0 20", "axis 0 0 1e308", None),  # a NaN axis quaternion
    ],
)
def test_asf_non_finite_geometry(tmp_path, old, new, message):
    text = samples.path("12.asf").read_text()
    assert old in text, old
    p = tmp_path / "m.asf"
    p.write_text(text.replace(old, new, 1))
    if new.startswith("axis"):  # huge but finite degrees are a valid angle; in radians they overflow to inf
        p.write_text(text.replace(old, new, 1).replace("angle deg", "angle rad"))
        message = "axis angles .* give no finite rotation"
    if message is None:
        message = "direction \\* length is not finite"
    with pytest.raises(MocapFormatError, match=rf"m\.asf:\d+: .*{message}|m\.asf: .*{message}"):
        read_asf(p)


def _npz_arrays(kind="motion"):
    obj = mocapkit.load(samples.path("131_01.bvh"))[:3] if kind == "motion" else mocapkit.load(samples.path("Eb015pr.c3d"))[:3]
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "x.npz"
        write_npz(obj, p, compress=False)
        with np.load(p) as z:
            return {k: z[k] for k in z.files}


def _save(tmp_path, arrays, compress=False) -> Path:
    p = tmp_path / "m.npz"
    (np.savez_compressed if compress else np.savez)(p, **arrays)
    return p


@pytest.mark.parametrize(
    "key, value, message",
    [
        ("format_version", np.array([1, 1]), "must be a scalar"),  # was TypeError
        ("format_version", np.array("markers"), "expected a number"),  # was ValueError from int()
        ("channels", np.array("[" * 5000), "not valid JSON"),  # was RecursionError
        ("rotations", "complex", "expected real numbers"),  # was ComplexWarning
        ("parents", np.array([np.nan] * 31), "expected integers"),  # was "invalid value encountered in cast"
        ("fps", np.array(-50.0), "fps must be a positive number"),  # was a Motion... (SkeletonError) / MarkerSet with fps -50
        ("rotations", "inf", "holds infinite values"),  # was a Motion with infinite rotations
        ("rotations", "scaled", "not unit quaternions"),
        ("rotations", "partnan", "partly NaN"),
        ("end_site_offsets", "nan", "non-finite"),
    ],
)
def test_npz_inconsistent_contents(tmp_path, key, value, message):
    a = _npz_arrays()
    if isinstance(value, str):
        r = np.array(a[key], dtype=np.float64)
        if value == "complex":
            r = r.astype(np.complex128)
        elif value == "inf":
            r[1, 2, 0] = np.inf
        elif value == "scaled":
            r[1, 2] *= 1.5
        elif value == "partnan":
            r[1, 2, 3] = np.nan
        elif value == "nan":
            r[0, 0] = np.nan
        value = r
    a[key] = value
    with pytest.raises(MocapFormatError, match=rf"m\.npz: .*{message}"):
        mocapkit.load(_save(tmp_path, a))


def test_npz_markers_bad_fps(tmp_path):
    a = _npz_arrays("markers")
    a["fps"] = np.array(0.0)  # was a MarkerSet with fps 0
    with pytest.raises(MocapFormatError, match="fps must be a positive number"):
        mocapkit.load(_save(tmp_path, a))


def test_npz_header_claiming_a_huge_array_is_refused_before_allocating(tmp_path):
    # was MemoryError ("Unable to allocate 8.00 TiB") from numpy's .npy reader
    a = _npz_arrays()
    p = tmp_path / "m.npz"
    with zipfile.ZipFile(p, "w") as zf:
        for name, arr in a.items():
            item = io.BytesIO()
            np.save(item, arr)
            raw = item.getvalue()
            if name == "rotations":
                hdr = repr({"descr": "<f8", "fortran_order": False, "shape": (2**40,)}).encode()
                pad = 64 - (10 + len(hdr) + 1) % 64
                raw = b"\x93NUMPY\x01\x00" + struct.pack("<H", len(hdr) + pad + 1) + hdr + b" " * pad + b"\n"
            zf.writestr(name + ".npy", raw)
    with pytest.raises(MocapFormatError, match=r"array 'rotations' claims shape \(1099511627776,\)"):
        mocapkit.load(p)


def test_npz_corrupt_deflate_stream(tmp_path):
    # was zlib.error ("Error -3 while decompressing data")
    p = _save(tmp_path, _npz_arrays(), compress=True)
    b = bytearray(p.read_bytes())
    with zipfile.ZipFile(p) as zf:
        info = zf.getinfo("rotations.npy")
    at = info.header_offset + 30 + len(info.filename) + len(info.extra) + 20
    b[at: at + 8] = b"\xff" * 8
    p.write_bytes(bytes(b))
    with pytest.raises(MocapFormatError, match=r"m\.npz: not a readable \.npz file"):
        mocapkit.load(p)


# C3D: ezc3d crashed the process (SIGSEGV) or looped on these; run each in a child process.

def _c3d_seed() -> bytearray:
    return bytearray(fuzz_readers.trim_c3d(samples.path("Eb015pr.c3d").read_bytes()))


def _param(b: bytes, group: str, name: str) -> dict:
    return next(p for p in fuzz_readers.c3d_parameters(bytes(b)) if p["group"] == group and p["name"] == name)


def _load_in_child(p: Path) -> str:
    code = (
        "import sys, mocapkit\n"
        "from mocapkit.errors import MocapFormatError\n"
        "try:\n    m = mocapkit.load(sys.argv[1])\n    print('OK', m.num_frames, m.num_markers, m.fps)\n"
        "except MocapFormatError as e:\n    print('MocapFormatError', e)\n"
    )
    res = subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, f"reader died: rc {res.returncode}: {res.stderr[-2000:]}"
    return res.stdout.strip()


def test_c3d_byte_inserted_in_parameter_section(tmp_path):
    # was SIGSEGV in ezc3d (mutant Eb015pr.c3d #157); another insert made ezc3d loop forever (Eb015pi.c3d #20)
    b = _c3d_seed()
    at = _param(b, "POINT", "LABELS")["data_at"] + 3
    b[at:at] = b"\x07"
    p = tmp_path / "m.c3d"
    p.write_bytes(bytes(b))
    out = _load_in_child(p)
    assert out.startswith("MocapFormatError") and "m.c3d: parameter" in out, out


def test_c3d_parameter_of_unexpected_type(tmp_path):
    # ANALOG:USED stored as char: SIGSEGV in ezc3d (mutant Eb015pr.c3d #2); now read by the fallback or refused
    b = _c3d_seed()
    b[_param(b, "ANALOG", "USED")["type_at"]] = 0xFF
    p = tmp_path / "m.c3d"
    p.write_bytes(bytes(b))
    out = _load_in_child(p)
    assert out.startswith(("OK 12 26", "MocapFormatError")), out


def test_c3d_negative_rate_and_infinite_coordinates(tmp_path):
    b = _c3d_seed()
    struct.pack_into("<f", b, 20, -1.0)  # header rate and POINT:RATE -1: was a MarkerSet with fps -1
    struct.pack_into("<f", b, _param(b, "POINT", "RATE")["data_at"], -1.0)
    p = tmp_path / "m.c3d"
    p.write_bytes(bytes(b))
    with pytest.raises(MocapFormatError, match=r"m\.c3d: (point frame rate must be a positive number|not a readable C3D)"):
        mocapkit.load(p)
    b = _c3d_seed()
    data_at = (struct.unpack_from("<H", b, 16)[0] - 1) * 512
    struct.pack_into("<f", b, data_at + 4, np.inf)  # frame 1, marker 1, y
    p.write_bytes(bytes(b))
    try:  # an infinite coordinate is refused or read as missing, never returned
        m = mocapkit.load(p)
    except MocapFormatError as exc:
        assert "infinite coordinate of marker" in str(exc)
    else:
        assert not np.isinf(m.positions).any() and np.isnan(m.positions[0, 0]).all()


def test_c3d_header_claims_more_frames_than_the_file_holds(tmp_path):
    b = _c3d_seed()
    struct.pack_into("<H", b, 8, 0xFFFF)  # last frame 65535
    p = tmp_path / "m.c3d"
    p.write_bytes(bytes(b))
    # read as ezc3d and the c3d package read a file of whole frames, fewer than stated (ezc3d-testFiles
    # Optotrak.c3d): the whole frames there
    assert mocapkit.load(p).num_frames == fuzz_readers.TRIM_FRAMES
    p.write_bytes(bytes(b[: (struct.unpack_from("<H", b, 16)[0] - 1) * 512 + 100]))  # not even one frame
    with pytest.raises(MocapFormatError, match="truncated file: 65535 frames of 26 points .* not even one whole frame"):
        mocapkit.load(p)


def test_c3d_duplicate_group_id(tmp_path):
    # POINT:LABELS' group byte turned into -1 (a second group with id 1): SIGSEGV in ezc3d (dynamic.c3d #30000179)
    b = _c3d_seed()
    b[_param(b, "POINT", "LABELS")["record"] + 1] = 0xFF
    p = tmp_path / "m.c3d"
    p.write_bytes(bytes(b))
    out = _load_in_child(p)
    assert out.startswith("MocapFormatError") and "defines group id 1 twice" in out, out


def test_c3d_analog_offset_in_another_group(tmp_path):
    # ANALOG:OFFSET moved to group POINT: SIGSEGV in ezc3d (Eb015pi.c3d #50000206); the fallback reads it
    b = _c3d_seed()
    b[_param(b, "ANALOG", "OFFSET")["record"] + 1] = 1
    p = tmp_path / "m.c3d"
    p.write_bytes(bytes(b))
    assert _load_in_child(p).startswith("OK 12 26 50.0")


def test_npz_garbled_npy_header(tmp_path):
    # an unbalanced bracket in the .npy header dict: tokenize.TokenError from numpy (131_01.npz #30000260)
    p = tmp_path / "m.npz"
    hdr = b"{'descr': '<f8', 'fortran_order': False, 'shape': (3, "
    pad = 64 - (10 + len(hdr) + 1) % 64
    with zipfile.ZipFile(p, "w") as zf:
        zf.writestr("format_version.npy", b"\x93NUMPY\x01\x00" + struct.pack("<H", len(hdr) + pad + 1) + hdr + b" " * pad + b"\n")
    with pytest.raises(MocapFormatError, match=r"m\.npz: not a readable \.npz file"):
        mocapkit.load(p)


def test_c3d_group_id_out_of_range(tmp_path):
    # POINT:LABELS' group byte 0x80: a group with id 128, SIGSEGV in ezc3d (dynamic.c3d #2000756)
    b = _c3d_seed()
    b[_param(b, "POINT", "LABELS")["record"] + 1] = 0x80
    p = tmp_path / "m.c3d"
    p.write_bytes(bytes(b))
    out = _load_in_child(p)
    assert out.startswith("MocapFormatError") and "group id 128 is out of range" in out, out
