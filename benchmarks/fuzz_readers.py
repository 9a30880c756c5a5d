"""Mutation fuzzing of the readers (BVH, ASF/AMC, C3D, npz): no crash but MocapFormatError, no hang, bounded memory.

Usage::

    python benchmarks/fuzz_readers.py --json [--count 100000] [--workers 2] [--seed 0]
        [--timeout 5] [--mem-gb 2] [--data DIR] [--before REV] [--before-count 10000] [--quick]

Seeds are real files trimmed to 12 frames (``tests/fuzzing/readers.py``, ``load_seeds``:
the bundled samples plus a few of ``../shared/data``); ``--count`` mutants are
split across formats by :data:`SHARE` (BVH 25 %, AMC 25 %, ASF 10 %, C3D 25 %,
npz 15 %), each format's seeds taken in turn. Mutant ``k`` of a seed is
``mutate(seed, seed_offset + k)`` with ``seed_offset = --seed * 10**7``, so every
failure is reproduced by (seed name, mutant number). Reads run in ``--workers``
forked processes under ``RLIMIT_AS = --mem-gb`` GiB with ``--timeout`` seconds per
read (over it: a hang, the worker replaced); a MemoryError or a dead worker is
a memory failure.

Baselines measured in the same run: the clean seeds' read time (the ratio is the
mean mutant read time over it), and with ``--before REV`` the same fuzzing
(``--before-count`` mutants, same seeds and mutators) against the readers of
git revision REV (``git archive`` of ``src/`` into a temp folder, run in a
child process): the crash count before the fixes.

The last stdout line is the JSON object of ``benchmarks/_harness.py``. Figures:
mutants, successes, format_errors, crashes (inconsistent results included),
inconsistent, hangs, memory_failures (targets: all three zero), slowest_input_s,
peak_worker_rss_mb, mutants_per_s, mutant_read_mean_s (its baseline: the clean
seeds' read time) and, with ``--before``, crashes_before (the baseline of crashes).
Details: mutants and status counts per format, the distinct failure kinds, up to 20
failures with the reproducing seed and mutant number, the slowest input.
"""

from __future__ import annotations

import collections
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))  # the fuzzer lives in tests/fuzzing (not in the installed package)
sys.path.insert(0, str(REPO / "benchmarks"))

import _harness as harness  # noqa: E402
from tests.fuzzing import readers as fuzz_readers  # noqa: E402

DEFAULT_DATA = REPO.parent / "shared" / "data"
SHARE = {"bvh": 0.25, "amc": 0.25, "asf": 0.10, "c3d": 0.25, "npz": 0.15}
FAIL = ("crash", "inconsistent", "hang", "memory", "killed")


def split_counts(total: int) -> dict[str, int]:
    counts = {f: int(total * s) for f, s in SHARE.items()}
    counts["bvh"] += total - sum(counts.values())
    return counts


def make_tasks(seeds, total: int, seed: int) -> list[tuple[int, int]]:
    by_fmt = collections.defaultdict(list)
    for i, s in enumerate(seeds):
        by_fmt[s.fmt].append(i)
    tasks = []
    base = seed * 10**7
    for fmt, count in split_counts(total).items():
        idx = by_fmt[fmt]
        for k in range(count):
            tasks.append((idx[k % len(idx)], base + k // len(idx)))
    # interleave formats so progress and throughput are even
    import random

    random.Random(seed).shuffle(tasks)
    return tasks


def fuzz(args) -> dict:
    t_start = time.perf_counter()
    seeds = fuzz_readers.load_seeds(args.data if args.data and args.data.is_dir() else None)
    # Baseline: the clean seeds, read in this process (warm) a few times each.
    work = Path(tempfile.mkdtemp(prefix="fuzz-bench-"))
    try:
        fuzz_readers.warm_up(seeds)
        seed_times = []
        for s in seeds:
            best = float("inf")
            for _ in range(3):
                out = fuzz_readers.execute(s.fmt, s.data, s.companion, work)
                if out.status != "ok":
                    raise SystemExit(f"seed {s.name} does not read cleanly: {out.status} {out.detail}")
                best = min(best, out.elapsed)
            seed_times.append(best)
    finally:
        shutil.rmtree(work, ignore_errors=True)

    tasks = make_tasks(seeds, args.count, args.seed)
    pool = fuzz_readers.FuzzPool(seeds, workers=args.workers, timeout=args.timeout, mem_bytes=int(args.mem_gb * (1 << 30)))
    per_format = {f: collections.Counter() for f in SHARE}
    failures = []
    failure_kinds = collections.Counter()
    slowest = (0.0, None)
    peak_rss = 0
    read_total = 0.0
    bar = None
    if not args.no_progress:
        from tqdm import tqdm

        bar = tqdm(total=len(tasks), file=sys.stderr, unit="mutant", mininterval=1.0, smoothing=0.05)
    t0 = time.perf_counter()
    for idx, out, rss in pool.run(tasks):
        s, n = tasks[idx]
        fmt = seeds[s].fmt
        per_format[fmt][out.status] += 1
        read_total += out.elapsed
        peak_rss = max(peak_rss, rss)
        if out.elapsed > slowest[0]:
            slowest = (out.elapsed, {"seed": seeds[s].name, "mutant": n, "status": out.status})
        if out.status in FAIL:
            key = (fmt, out.status, out.error_type, out.detail[:60])
            failure_kinds[key] += 1
            if len(failures) < 20 and failure_kinds[key] == 1:
                failures.append({"format": fmt, "seed": seeds[s].name, "mutant": n, "status": out.status,
                                 "error": out.detail[:400], "traceback": out.tb[-1500:]})
        if bar is not None:
            bar.update(1)
            if failure_kinds and bar.n % 500 == 0:
                bar.set_postfix(failures=sum(failure_kinds.values()))
    if bar is not None:
        bar.close()
    fuzz_s = time.perf_counter() - t0
    totals = collections.Counter()
    for c in per_format.values():
        totals.update(c)
    n_done = sum(totals.values())
    seed_mean = sum(seed_times) / len(seed_times)
    mutant_mean = read_total / max(1, n_done)
    return {
        "mutants": n_done,
        "mutants_per_format": {f: sum(c.values()) for f, c in per_format.items()},
        "per_format": {f: dict(c) for f, c in per_format.items()},
        "seeds": len(seeds),
        "seeds_per_format": dict(collections.Counter(s.fmt for s in seeds)),
        "successes": totals["ok"],
        "format_errors": totals["format_error"],
        "crashes": totals["crash"] + totals["inconsistent"],
        "inconsistent": totals["inconsistent"],
        "hangs": totals["hang"],
        "memory_failures": totals["memory"] + totals["killed"],
        "distinct_failures": len(failure_kinds),
        "failure_kinds": [dict(zip(("format", "status", "type", "detail"), k), count=v)
                          for k, v in failure_kinds.most_common(40)],
        "failures": failures,
        "slowest_input_s": round(slowest[0], 4),
        "slowest_input": slowest[1],
        "peak_worker_rss_mb": round(peak_rss / 2**20, 1),
        "worker_restarts": pool.restarts,
        "workers": args.workers,
        "timeout_s": args.timeout,
        "rlimit_as_gb": args.mem_gb,
        "fuzz_s": round(fuzz_s, 2),
        "total_s": round(time.perf_counter() - t_start, 2),
        "mutants_per_s": round(n_done / fuzz_s, 1),
        "seed_read_mean_s": round(seed_mean, 5),
        "mutant_read_mean_s": round(mutant_mean, 5),
    }


def before(args) -> dict:
    """The same fuzzing against the readers of git revision ``args.before`` (in a child process)."""
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-before-"))
    try:
        archive = subprocess.run(["git", "-C", str(REPO), "archive", args.before, "src"], check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
        # the fuzzer itself is today's, from tests/fuzzing (it only uses the readers' public API)
        cmd = [sys.executable, __file__, "--json", "--no-save", "--no-progress", "--count", str(args.before_count),
               "--workers", str(args.workers), "--seed", str(args.seed), "--timeout", str(args.timeout),
               "--mem-gb", str(args.mem_gb), "--data", str(args.data)]
        env = dict(os.environ, PYTHONPATH=str(tmp / "src"), NUMBA_CACHE_DIR=str(tmp / "numba-cache"))
        print(f"before: fuzzing the readers of {args.before} ({args.before_count} mutants)", file=sys.stderr)
        res = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if res.returncode != 0:
            return {"rev": args.before, "error": res.stderr[-2000:]}
        out = json.loads(res.stdout.strip().splitlines()[-1])
        merged = {**out["details"], **out["figures"]}
        keep = ("mutants", "mutants_per_format", "successes", "format_errors", "crashes", "inconsistent", "hangs",
                "memory_failures", "distinct_failures", "failure_kinds", "slowest_input_s", "peak_worker_rss_mb")
        return {"rev": args.before, **{k: merged[k] for k in keep if k in merged}}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


FIGURES = ("mutants", "successes", "format_errors", "crashes", "inconsistent", "hangs", "memory_failures",
           "slowest_input_s", "peak_worker_rss_mb", "mutants_per_s", "mutant_read_mean_s")


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--count", type=int, default=100_000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--timeout", type=float, default=5.0, help="seconds per read")
    ap.add_argument("--mem-gb", type=float, default=2.0, help="RLIMIT_AS of each worker, GiB")
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--before", default=None, help="git revision whose readers to fuzz as the baseline")
    ap.add_argument("--before-count", type=int, default=10_000)
    ap.add_argument("--quick", action="store_true", help="2,000 mutants (development)")
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args()
    if args.quick:
        args.count = min(args.count, 2000)
        args.before_count = min(args.before_count, 2000)
    result = fuzz(args)
    figures = {k: result.pop(k) for k in FIGURES}
    baselines = {"mutant_read_mean_s": result["seed_read_mean_s"]}
    if args.before:
        result["before"] = before(args)
        if "crashes" in result["before"]:
            figures["crashes_before"] = result["before"]["crashes"]
            baselines["crashes"] = result["before"]["crashes"]
    targets = {k: {"value": 0, "op": "<=", "of": "figures"} for k in ("crashes", "hangs", "memory_failures")}
    harness.emit("fuzz_readers", args, figures=figures, baselines=baselines, targets=targets, details=result)


if __name__ == "__main__":
    main()
