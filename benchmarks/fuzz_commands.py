"""Fuzzing whole commands: info, convert, clean, db build, detect and denoise on mutated real files, under limits.

Usage::

    python benchmarks/fuzz_commands.py --json [--count 500] [--workers 2] [--seed 0] [--mem-gb 2]
        [--data DIR] [--no-fixed] [--no-big] [--keep-failures DIR]

Each run is ``mocapkit ...`` in a subprocess, in its own folder, under
``RLIMIT_AS = --mem-gb`` GiB and a CPU budget per command kind (3x its CPU time
on the unmutated seed plus 10 s), killed with its process group after
``--wall`` seconds (``tests/fuzzing/commands.py``). Cases: the command kinds on
unmutated seeds (the baseline), the hand-made cases of issue 20
(``tests/fuzzing/issue20.py``; with a 50 MB AMC unless ``--no-big``) unless
``--no-fixed``, and ``--count`` mutants:
``mutant_case(seeds, seed * 10**6 + k)``, each a real file (bundled samples and,
when ``--data`` is a folder, a few files of ``../shared/data``, trimmed to 150
frames) through the readers' mutators or with hostile names, run by one command.

The last stdout line is the JSON object of ``benchmarks/_harness.py``. Figures
(runs with at least one finding of the kind; targets: all zero): tracebacks,
over_limit_runs, inputs_lost_or_changed, partial_outputs, orphan_processes,
expectation_failures (fixed cases: valid input refused or bad input accepted, a
blown-up output); also runs, cases, fixed_cases_failing, mean_run_cpu_s (its
baseline: the unmutated seeds' mean), max_run_cpu_s, max_peak_rss_mb. Details:
the CPU budgets, the failing fixed cases and their findings, every fixed case's
runs (exit, wall and CPU seconds, peak RSS), the mutants' exit codes by command, the distinct
failure kinds with counts and an example case each, and up to 300 findings
(case, command, kind, detail, wall, CPU, peak RSS). ``--keep-failures DIR``
lays each failing mutant's files out in DIR/<case>/ with its command line in
``command.txt``, to rerun by hand.
"""

from __future__ import annotations

import collections
import statistics
import sys
import shutil
import tempfile
import time
from functools import partial
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))  # the fuzzer lives in tests/fuzzing (not in the installed package)
sys.path.insert(0, str(REPO / "benchmarks"))

import _harness as harness  # noqa: E402
from tests.fuzzing import commands, issue20  # noqa: E402

DEFAULT_DATA = REPO.parent / "shared" / "data"
GROUP_FIGURES = {"tracebacks": "tracebacks", "over_limit": "over_limit_runs", "inputs_lost_or_changed": "inputs_lost_or_changed",
                 "partial_outputs": "partial_outputs", "orphan_processes": "orphan_processes",
                 "expectation_failures": "expectation_failures"}
CPU_FACTOR, CPU_SLACK_S = 3.0, 10.0


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--count", type=int, default=500, help="mutated cases (one command each)")
    ap.add_argument("--workers", type=int, default=2, help="cases run at once")
    ap.add_argument("--seed", type=int, default=0, help="mutant numbers start at seed * 10**6")
    ap.add_argument("--mem-gb", type=float, default=2.0, help="RLIMIT_AS of each run, GiB")
    ap.add_argument("--wall", type=float, default=300.0, help="wall-clock seconds before a run is killed (a hang)")
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--no-fixed", action="store_true", help="skip the fixed cases of issue 20")
    ap.add_argument("--no-big", action="store_true", help="skip the fixed cases with a 50 MB input")
    ap.add_argument("--keep-failures", type=Path, default=None, help="lay failing mutants out here")
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args()

    t_start = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="fuzz-commands-"))
    try:
        data = args.data if args.data and args.data.is_dir() else None
        seeds = commands.command_seeds(data)
        mem = int(args.mem_gb * (1 << 30))
        base_cpu, base_results = commands.baseline_cpu(seeds, work, commands.Limits(mem_bytes=mem, cpu_s={"default": 600.0},
                                                                                     wall_s=args.wall))
        budgets = {k: round(CPU_FACTOR * v + CPU_SLACK_S, 1) for k, v in base_cpu.items() if v == v}
        budgets["default"] = max(budgets.values())
        limits = commands.Limits(mem_bytes=mem, cpu_s=budgets, wall_s=args.wall)
        registry = {**issue20.FIXED_CASES, **({} if args.no_big else issue20.BIG_CASES)}
        names = [] if args.no_fixed else list(registry)
        first = args.seed * 10**6
        cases = [registry[n] for n in names] + [partial(commands.mutant_case, seeds, first + k)
                                                          for k in range(args.count)]
        bar = None
        if not args.no_progress:
            from tqdm import tqdm

            bar = tqdm(total=len(cases), file=sys.stderr, unit="case", mininterval=2.0)

        def tick(case, result):
            if bar is not None:
                bar.update(1)

        t0 = time.perf_counter()
        results = commands.run_cases(cases, work, limits, workers=args.workers, on_result=tick)
        fuzz_s = time.perf_counter() - t0
        if bar is not None:
            bar.close()
    finally:
        shutil.rmtree(work, ignore_errors=True)

    everything = base_results + results
    summary = commands.summarize(everything)
    steps = [s for r in everything for s in r.steps]
    mutant_steps = [s for r in results[len(names):] for s in r.steps]
    fixed = {n: r for n, r in zip(names, results[: len(names)])}
    failing_fixed = {n: [{"command": c, "kind": f.kind, "detail": f.detail} for c, f in r.all_findings]
                     for n, r in fixed.items() if r.all_findings}
    kinds = collections.Counter()
    example = {}
    for row in summary["findings"]:
        cmd = row["command"].split()
        key = (commands.command_kind(cmd[1:]) if len(cmd) > 1 else "", row["kind"], row["detail"][:70])
        kinds[key] += 1
        example.setdefault(key, row["case"])
    if args.keep_failures is not None:
        for r in results[len(names):]:
            if r.all_findings:
                case = commands.mutant_case(seeds, int(r.name.split("-")[1]))
                d = args.keep_failures / r.name
                commands.write_case(case, d)
                (d / "command.txt").write_text("mocapkit " + " ".join(repr(a) if " " in a else a for a in case.steps[0].argv) + "\n")

    figures = {GROUP_FIGURES[g]: summary[g] for g in GROUP_FIGURES}
    figures.update(
        runs=summary["runs"], cases=summary["cases"], mutants=args.count, fixed_cases=len(names),
        fixed_cases_failing=len(failing_fixed),
        mean_run_cpu_s=round(statistics.fmean(s.cpu_s for s in mutant_steps), 3) if mutant_steps else None,
        max_run_cpu_s=round(max(s.cpu_s for s in steps), 2), max_peak_rss_mb=round(max(s.peak_rss_mb for s in steps), 1),
        runs_per_min=round(60 * len(steps) / max(fuzz_s, 1e-9), 1),
    )
    baselines = {"mean_run_cpu_s": round(statistics.fmean(base_cpu.values()), 3)}
    targets = {GROUP_FIGURES[g]: {"value": 0, "op": "<=", "of": "figures"} for g in GROUP_FIGURES}
    details = {
        "cpu_budget_s": budgets, "baseline_cpu_s": base_cpu, "rlimit_as_gb": args.mem_gb, "wall_limit_s": args.wall,
        "workers": args.workers, "seeds": [s.name for s in seeds], "skipped": summary["skipped"],
        "failing_fixed_cases": failing_fixed,
        "passing_fixed_cases": [n for n in names if n not in failing_fixed and not fixed[n].skipped],
        "fixed_case_runs": {n: [{"command": "mocapkit " + " ".join(s.argv), "exit": s.returncode, "signal": s.signal,
                                 "wall_s": s.wall_s, "cpu_s": s.cpu_s, "peak_rss_mb": s.peak_rss_mb} for s in r.steps]
                            for n, r in fixed.items()},
        "failure_kinds": [{"command": k[0], "kind": k[1], "detail": k[2], "count": v, "example": example[k]}
                          for k, v in kinds.most_common(60)],
        "mutant_exits": dict(collections.Counter(
            f"{commands.command_kind(s.argv)}: {'signal %d' % s.signal if s.signal else 'exit %s' % s.returncode}"
            for s in mutant_steps).most_common()),
        "findings": summary["findings"][:300],
        "fuzz_s": round(fuzz_s, 1), "total_s": round(time.perf_counter() - t_start, 1),
    }
    harness.emit("fuzz_commands", args, figures=figures, baselines=baselines, targets=targets, details=details)


if __name__ == "__main__":
    main()
