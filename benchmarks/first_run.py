"""The first ``mocapkit clean`` after install: the bundled walk cleaned with an empty numba cache, and warm.

The command of ``make demo``: ``mocapkit corrupt src/mocapkit/data/12_walk.amc b.npz --kind errors
--seed 7``, then ``mocapkit clean b.npz -o c.bvh`` in a fresh process, timed end to end (start-up,
imports, compiling or loading the numba kernels, cleaning, writing):

- **cold**: ``NUMBA_CACHE_DIR`` set to an empty folder, so every kernel the command needs compiles;
- **warm**: ``NUMBA_CACHE_DIR`` set to a folder one earlier clean filled.

Runs alternate cold and warm (``--runs`` each); the figures are medians of wall-clock seconds, with
the CPU seconds of the same processes beside them (wall time on a shared machine grows with its
load, reported per run). A cold clean starts a helper process that compiles later steps' kernels on
a second core (:mod:`mocapkit.cleaning.precompile`); the clean waits for it at exit, so its CPU
seconds count in ``cpu_s``: a cold run's CPU exceeds its wall time. ``--baseline-src DIR`` times
another source tree (e.g. an earlier commit's ``src``: ``git archive COMMIT src | tar -x -C
/tmp/base``) in the same runs, alternately, as the baseline. Targets: cold <= 15 s, warm <= 3 s.

    python benchmarks/first_run.py --json [--runs 3] [--baseline-src /path/to/old/src]
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _harness as harness

REPO = Path(__file__).resolve().parents[1]
WALK = REPO / "src" / "mocapkit" / "data" / "12_walk.amc"
CLI = "import sys; from mocapkit.cli import main; sys.exit(main())"


def _cli(src: Path, args: list[str], cache: Path) -> dict:
    """Run ``mocapkit ARGS`` with ``src`` first on the path and numba's cache in ``cache``: wall and CPU seconds."""
    env = {**os.environ, "PYTHONPATH": str(src), "NUMBA_CACHE_DIR": str(cache)}
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", CLI, *args], env=env, check=True, capture_output=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall_s": round(wall, 2), "cpu_s": round(cpu, 2), "load": round(load, 2)}


def _medians(rows: list[dict]) -> dict:
    return {f"{k}_{m}": round(statistics.median(r[m] for r in rows if r["kind"] == k), 2)
            for k in ("cold", "warm") for m in ("wall_s", "cpu_s")}


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--runs", type=int, default=3, help="cold and warm runs each (default 3)")
    ap.add_argument("--baseline-src", type=Path, default=None, help="another source tree to time as the baseline")
    args = ap.parse_args()
    trees = {"ours": REPO / "src"}
    if args.baseline_src is not None:
        trees["baseline"] = args.baseline_src.resolve()
    rows: dict[str, list] = {name: [] for name in trees}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        take = work / "b.npz"
        _cli(trees["ours"], ["corrupt", str(WALK), str(take), "--kind", "errors", "--seed", "7"], work / "cache-corrupt")
        warm = {}
        for name, src in trees.items():  # one clean fills each tree's warm cache
            warm[name] = Path(tempfile.mkdtemp(dir=work))
            _cli(src, ["clean", str(take), "-o", str(work / f"{name}_fill.bvh")], warm[name])
        for i in range(args.runs):  # alternate trees and kinds run by run, so all see the same load
            for name, src in trees.items():
                for kind in ("cold", "warm"):
                    cache = Path(tempfile.mkdtemp(dir=work)) if kind == "cold" else warm[name]
                    out = work / f"{name}_{kind}_{i}.bvh"
                    rows[name].append({"kind": kind, **_cli(src, ["clean", str(take), "-o", str(out)], cache)})
                    if not args.json:
                        print(name, rows[name][-1], flush=True)
    figures = _medians(rows["ours"])
    baselines = _medians(rows["baseline"]) if "baseline" in rows else {}
    harness.emit("first_run", args, figures=figures, baselines=baselines,
                 targets={"cold_wall_s": {"value": 15.0, "op": "<="}, "warm_wall_s": {"value": 3.0, "op": "<="}},
                 details={"take": "12_walk.amc, --kind errors --seed 7 (343 frames at 120 fps)", "runs": rows,
                          "baseline_src": str(args.baseline_src) if args.baseline_src else None})


if __name__ == "__main__":
    main()
