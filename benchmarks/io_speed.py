"""BVH loading speed: mocapkit against numpy.loadtxt of the same MOTION block and PyPI BVH readers.

Usage::

    python benchmarks/io_speed.py [--data DIR] [--repeats N] [--json]

Every ``.bvh`` under DIR (default ``../shared/data`` beside the repository) is
loaded N times (default 5) by each contender; a file's time is the best of its
N runs and a contender's total is the sum over files. The contenders:

* ``mocapkit.load``: hierarchy, numbers and conversion to quaternions (a full Motion);
* ``numpy.loadtxt`` of the MOTION block only (``skiprows`` past the header): the baseline;
* the PyPI peers, each with the call that parses a whole file into per-frame values:
  ``pybvh.read_bvh_file`` (angles in radians, ``world_up`` given so no detection runs),
  ``bvhio.readAsBvh`` (keyframes on every joint) and ``bvh.Bvh`` plus a float
  conversion of its frames (it keeps them as strings).

A peer that fails on a file has the failure recorded and that file left out of
its total; its speed-up is computed against mocapkit on the same files. Numba
is warmed up before timing; the first call of this process is reported as
``first_call_s`` and a first call with an empty numba cache (run in a child
process) as ``first_call_uncached_s``.

The last line of stdout is the shared JSON object of ``benchmarks/_harness.py``:
figure ``load_s`` (mocapkit, all files) against baseline ``load_s`` (loadtxt),
target ratio <= 1.5; figure ``speedup_vs_fastest_peer``, target >= 5; the first
calls; the per-peer times and failures in ``details``.
"""

from __future__ import annotations

import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import _harness as harness

REPO = Path(__file__).resolve().parents[1]
DEFAULT_DATA = REPO.parent / "shared" / "data"

RATIO_TARGET = 1.5
SPEEDUP_TARGET = 5.0


def _best(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def _header_lines(path: Path) -> int:
    """Lines before the first frame line (through ``Frame Time:``), for ``loadtxt(skiprows=...)``."""
    with open(path, "rb") as fh:
        for k, line in enumerate(fh, start=1):
            if line.lstrip().startswith(b"Frame Time"):
                return k
    raise ValueError(f"{path}: no 'Frame Time' line")


def _peer_calls():
    """name -> (callable(path) or None, why it is unavailable)."""
    peers = {}
    try:
        import pybvh

        def run_pybvh(p):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return pybvh.read_bvh_file(p, world_up="+y").joint_angles

        peers["pybvh"] = (run_pybvh, None)
    except Exception as e:  # noqa: BLE001 - an optional peer may fail to import in any way
        peers["pybvh"] = (None, f"import failed: {e}")
    try:
        import bvhio

        peers["bvhio"] = (lambda p: bvhio.readAsBvh(str(p)), None)
    except Exception as e:  # noqa: BLE001
        peers["bvhio"] = (None, f"import failed: {e}")
    try:
        import bvh

        def run_bvh(p):
            with open(p) as fh:
                mocap = bvh.Bvh(fh.read())
            return np.asarray(mocap.frames, dtype=np.float64)

        peers["bvh"] = (run_bvh, None)
    except Exception as e:  # noqa: BLE001
        peers["bvh"] = (None, f"import failed: {e}")
    return peers


def _uncached_first_call(path: Path) -> float | None:
    """Seconds of the first ``mocapkit.load`` in a fresh process with an empty numba cache."""
    code = (
        "import time, mocapkit, sys; t = time.perf_counter(); mocapkit.load(sys.argv[1]); "
        "print(time.perf_counter() - t)"
    )
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        try:
            out = subprocess.run([sys.executable, "-c", code, str(path)], env=env, capture_output=True, text=True,
                                 timeout=600, check=True)
            return float(out.stdout.strip().splitlines()[-1])
        except (subprocess.SubprocessError, ValueError, IndexError):
            return None


def main(argv=None) -> int:
    ap = harness.parser(__doc__)
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder searched recursively for .bvh files")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs per file and contender (best is kept)")
    ap.add_argument("--no-peers", action="store_true", help="time only mocapkit and loadtxt")
    args = ap.parse_args(argv)

    files = sorted(args.data.rglob("*.bvh")) if args.data.is_dir() else []
    if not files:
        print(f"no .bvh files under {args.data}", file=sys.stderr)
        return 2
    repeats = max(1, args.repeats)

    import mocapkit

    first_call_uncached = _uncached_first_call(files[0])
    t = time.perf_counter()
    mocapkit.load(files[0])
    first_call = time.perf_counter() - t

    mk: dict[Path, float] = {}
    lt: dict[Path, float] = {}
    frames_total = 0
    for f in files:
        m = mocapkit.load(f)  # warm (numba, file cache)
        frames_total += m.num_frames
        mk[f] = _best(lambda: mocapkit.load(f), repeats)
        skip = _header_lines(f)
        lt[f] = _best(lambda: np.loadtxt(f, skiprows=skip), repeats)

    peers = {} if args.no_peers else _peer_calls()
    peer_s: dict[str, float | None] = {}
    peer_files: dict[str, int] = {}
    peer_fail: dict[str, list[str]] = {}
    peer_per_file: dict[str, dict[Path, float]] = {}
    speedup: dict[str, float | None] = {}
    for name, (fn, why) in peers.items():
        peer_fail[name] = []
        peer_per_file[name] = {}
        if fn is None:
            peer_s[name], peer_files[name], speedup[name] = None, 0, None
            peer_fail[name].append(why)
            continue
        total = mine = 0.0
        ok = 0
        for f in files:
            try:
                fn(f)
            except Exception as e:  # noqa: BLE001 - record any peer failure and go on
                msg = str(e).splitlines()[0] if str(e) else type(e).__name__
                peer_fail[name].append(f"{f.name}: {type(e).__name__}: {msg[:160]}")
                continue
            peer_per_file[name][f] = _best(lambda: fn(f), repeats)
            total += peer_per_file[name][f]
            mine += mk[f]
            ok += 1
        peer_s[name] = total if ok else None
        peer_files[name] = ok
        speedup[name] = total / mine if ok else None

    mocapkit_s = sum(mk.values())
    loadtxt_s = sum(lt.values())
    ratio = mocapkit_s / loadtxt_s
    ranked = [n for n in speedup if speedup[n] is not None]
    fastest = min(ranked, key=lambda n: speedup[n]) if ranked else None
    fastest_speedup = speedup[fastest] if fastest else None

    # -- human-readable table
    w = max(len(f.name) for f in files)
    print(f"BVH load, best of {repeats}, {len(files)} files, {frames_total} frames "
          f"({platform.python_implementation()} {platform.python_version()}, numpy {np.__version__})")
    head = f"{'file':<{w}}  {'frames':>6}  {'mocapkit ms':>11}  {'loadtxt ms':>10}"
    for name in peers:
        head += f"  {name + ' ms':>10}"
    print(head)
    for f in files:
        row = f"{f.name:<{w}}  {mocapkit.load(f).num_frames:>6}  {mk[f] * 1e3:>11.2f}  {lt[f] * 1e3:>10.2f}"
        for name in peers:
            t = peer_per_file[name].get(f)
            row += f"  {'fail':>10}" if t is None else f"  {t * 1e3:>10.2f}"
        print(row)
    total_row = f"{'total':<{w}}  {frames_total:>6}  {mocapkit_s * 1e3:>11.2f}  {loadtxt_s * 1e3:>10.2f}"
    for name in peers:
        total_row += f"  {'-':>10}" if peer_s[name] is None else f"  {peer_s[name] * 1e3:>10.2f}"
    print(total_row)
    print(f"ratio mocapkit / loadtxt = {ratio:.3f} (target <= {RATIO_TARGET})")
    for name in peers:
        if peer_s[name] is None:
            print(f"{name}: no result ({'; '.join(peer_fail[name])[:200]})")
        else:
            print(f"{name}: {peer_s[name] * 1e3:.1f} ms on {peer_files[name]}/{len(files)} files; "
                  f"mocapkit is {speedup[name]:.1f}x faster on those files"
                  + (f"; failed on {len(peer_fail[name])}" if peer_fail[name] else ""))
    if fastest:
        print(f"fastest peer: {fastest}, mocapkit speed-up {fastest_speedup:.1f}x (target >= {SPEEDUP_TARGET})")
    print(f"first call: {first_call * 1e3:.1f} ms (numba cache as found); "
          + (f"{first_call_uncached:.2f} s with an empty numba cache" if first_call_uncached is not None
             else "uncached first call not measured"))

    harness.emit(
        "io_speed", args,
        figures={"load_s": mocapkit_s, "speedup_vs_fastest_peer": fastest_speedup, "first_call_s": first_call,
                 "first_call_uncached_s": first_call_uncached, "files": len(files), "frames_total": frames_total},
        baselines={"load_s": loadtxt_s},
        targets={"load_s": {"value": RATIO_TARGET, "op": "<=", "of": "ratios"},
                 "speedup_vs_fastest_peer": {"value": SPEEDUP_TARGET, "op": ">=", "of": "figures"}},
        details={"repeats": repeats, "baseline": "numpy.loadtxt of the MOTION block, same files, best of N",
                 "peers_s": peer_s, "peer_files": peer_files, "peer_failures": peer_fail,
                 "speedup_vs_peer": speedup, "fastest_peer": fastest},
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
