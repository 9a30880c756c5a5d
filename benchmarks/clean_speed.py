"""``clean`` on clean_takes' 60 s take at 120 fps, side by side with an earlier commit: time and identical results.

The take is :func:`clean_takes.long_take` (HDM05 actor mm clips concatenated, cut at 60 s, 7200
frames) with clean_takes' mixed corruption (``mixed(take, 7)``: 4 real-style errors, gaps, Mall's
0.5 angular noise on 3 joints), saved once as npz. ``--seconds S`` cuts it at S seconds instead; past mm's
clips (about 100 s) the take goes on with the other HDM05 actors' clips read on mm's skeleton, so
``--seconds 540`` times a 9-minute take (it gave mm's 100 s for any S over 100 before). Two worker
processes load it, one importing this tree's ``src`` and one the baseline's (``--base``, default
``314138e``: main with issue 21's rule changes, before issue 23's data-flow merge f7358ba, so the outputs
can be compared bit for bit;
extracted with ``git archive`` into a temporary folder; or ``--baseline-src DIR``). Each warms up
as ``make install`` leaves an installation (``mocapkit.warmup.warm_up()``: every kernel compiled or
loaded, serial and parallel twins), then cleans a short clip once (shipped models loaded),
then the workers clean the take alternately, ``--runs`` times each after one untimed run, so both
see the same machine load. Figures: the median wall-clock seconds of ``mocapkit.cleaning.pipeline.clean``
(and the CPU seconds of the same runs, and per step), baseline the same of the other tree; target
ratio <= 0.5 (2x faster). The outputs of the last run of each are compared bit for bit: the cleaned
rotations and root trajectory, the MDM, the flags, the filled/repaired/denoised masks and the noise
level (``identical``, True only if every array is equal, NaN where NaN).

Torch runs one intra-op thread in both workers by default (``--torch-threads``; 0 leaves each tree its
own choice, which for the baseline is two threads on an idle 2-core machine). This tree's offline
inference also cuts the networks' rows into two fixed parts run on two threads of one torch thread each
(:mod:`mocapkit.cleaning.deep.threads`: the one-thread result, bit for bit), which the pin does not
stop; run with ``--torch-threads 0`` to compare against the baseline's own threads as well.
numba's threads are left as they are unless ``--numba-threads`` is given (1: the work alone, without
the parallel kernels, the least load-sensitive comparison on a shared machine).

    python benchmarks/clean_speed.py --json [--runs 5] [--base 314138e | --baseline-src DIR] [--torch-threads 1]
                                     [--numba-threads N]
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import _harness as harness

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO / "benchmarks"))

ARRAYS = ("rotations", "root_positions", "mdm", "flags", "filled", "repaired", "denoised", "noise")

WORKER = r'''
import json, sys, time
import numpy as np
threads = int(sys.argv[3])
if threads:
    import torch
    torch.set_num_threads(threads)
import mocapkit
from mocapkit.cleaning.pipeline import clean
from mocapkit.warmup import warm_up
warm_up()
take, warm = mocapkit.load(sys.argv[1]), mocapkit.load(sys.argv[2])
clean(warm)
print("ready", flush=True)
for line in sys.stdin:
    out = line.strip()
    t, c = time.perf_counter(), time.process_time()
    res = clean(take)
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    m = res.motion
    np.savez(out, rotations=m.rotations, root_positions=m.root_positions, mdm=res.mdm, flags=res.flags,
             filled=res.filled, repaired=res.repaired, denoised=res.denoised, noise=res.noise)
    print(json.dumps({"wall_s": wall, "cpu_s": cpu, "steps": {s.name: s.seconds for s in res.steps}}), flush=True)
'''


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def extract(ref: str, into: Path) -> Path:
    """The ``src`` folder of commit ``ref`` of this repository, unpacked under ``into``."""
    archive = into / "base.tar"
    with open(archive, "wb") as fh:
        subprocess.run(["git", "-C", str(REPO), "archive", ref, "src"], stdout=fh, check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(into / "base", filter="data")
    return into / "base" / "src"


def identical(a: Path, b: Path) -> dict:
    import numpy as np

    x, y = np.load(a), np.load(b)
    return {k: bool(x[k].shape == y[k].shape and np.array_equal(x[k], y[k], equal_nan=x[k].dtype.kind == "f"))
            for k in ARRAYS}


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--runs", type=int, default=5, help="timed runs per tree (default 5), after one untimed")
    ap.add_argument("--base", default="314138e", help="commit to compare with (default 314138e)")
    ap.add_argument("--baseline-src", type=Path, default=None, help="a source tree to compare with instead of --base")
    ap.add_argument("--torch-threads", type=int, default=1, help="torch threads in both workers (0: each tree's own)")
    ap.add_argument("--numba-threads", type=int, default=0, help="NUMBA_NUM_THREADS in both workers (0: as set)")
    ap.add_argument("--seconds", type=float, default=60.0, help="take length in seconds (default 60; past 100 the other actors' clips)")
    args = ap.parse_args()

    import mocapkit
    from clean_takes import held_out, long_take, mixed

    with tempfile.TemporaryDirectory(prefix="clean_speed_") as tmp:
        work = Path(tmp)
        take, n_clips = long_take(args.seconds)
        bad, _ = mixed(take, 7)
        mocapkit.save(bad, work / "take.npz")
        mocapkit.save(mixed(mocapkit.load(held_out(True)[0])[:240], 3)[0], work / "warm.npz")
        base_src = args.baseline_src.resolve() if args.baseline_src else extract(args.base, work)
        trees = {"ours": REPO / "src", "baseline": base_src}
        procs = {}
        for name, src in trees.items():
            env = {**os.environ, "PYTHONPATH": str(src)}
            if args.numba_threads:
                env["NUMBA_NUM_THREADS"] = str(args.numba_threads)
            procs[name] = subprocess.Popen(
                [sys.executable, "-c", WORKER, str(work / "take.npz"), str(work / "warm.npz"), str(args.torch_threads)],
                env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        for name, p in procs.items():
            if p.stdout.readline().strip() != "ready":
                sys.exit(f"clean_speed: the {name} worker did not start")
        rows: dict[str, list] = {name: [] for name in trees}
        try:
            for i in range(args.runs + 1):  # alternate, so both see the same load; run 0 untimed
                for name, p in procs.items():
                    p.stdin.write(str(work / f"{name}_{i}.npz") + "\n")
                    p.stdin.flush()
                    row = json.loads(p.stdout.readline())
                    log(f"{name:8s} run {i}: {row['wall_s']:.2f} s wall, {row['cpu_s']:.2f} s CPU; "
                        + ", ".join(f"{k} {v:.2f}" for k, v in row["steps"].items()))
                    if i:
                        rows[name].append(row)
        finally:
            for p in procs.values():
                p.stdin.close()
                p.wait()
        same = identical(work / f"ours_{args.runs}.npz", work / f"baseline_{args.runs}.npz")

    def med(name, key):
        return round(statistics.median(r[key] for r in rows[name]), 3)

    def steps(name):
        return {s: round(statistics.median(r["steps"][s] for r in rows[name]), 3) for s in rows[name][0]["steps"]}

    figures = {"take_clean_wall_s": med("ours", "wall_s"), "take_clean_cpu_s": med("ours", "cpu_s"),
               "identical": bool(all(same.values()))}
    baselines = {"take_clean_wall_s": med("baseline", "wall_s"), "take_clean_cpu_s": med("baseline", "cpu_s")}
    targets = {"take_clean_wall_s": {"value": 0.5, "op": "<=", "of": "ratios"},
               "identical": {"value": 1, "op": ">=", "of": "figures"}}
    details = {"take": f"{bad.num_frames} frames at {bad.fps:g} fps ({n_clips} held-out HDM05 mm clips concatenated), "
                       "clean_takes.mixed(take, 7)",
               "baseline": str(args.baseline_src) if args.baseline_src else f"commit {args.base}",
               "speedup_wall": round(figures["take_clean_wall_s"] and baselines["take_clean_wall_s"] / figures["take_clean_wall_s"], 3),
               "speedup_cpu": round(baselines["take_clean_cpu_s"] / figures["take_clean_cpu_s"], 3),
               "step_seconds": {"ours": steps("ours"), "baseline": steps("baseline")},
               "identical_arrays": same, "torch_threads": args.torch_threads or "each tree's own",
               "numba_threads": args.numba_threads or "as set", "runs": rows}
    log(f"ours {figures['take_clean_wall_s']} s, baseline {baselines['take_clean_wall_s']} s: "
        f"{details['speedup_wall']}x wall, {details['speedup_cpu']}x CPU; identical {figures['identical']}")
    harness.emit("clean_speed", args, figures=figures, baselines=baselines, targets=targets, details=details)


if __name__ == "__main__":
    main()
