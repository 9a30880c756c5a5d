"""Write docs/benchmarks.md from the benchmarks' result files.

Usage::

    python benchmarks/report.py [--results DIR] [--out FILE]

Every benchmark ends with ``_harness.emit``, which keeps its last JSON line in
``benchmarks/results/NAME.json``. This script reads those files and writes one
Markdown page: a summary table (date, targets met), then one section per
benchmark with the command that reproduces it, the machine and date of the run,
what the baseline is, and every figure with its baseline, ratio, target and
whether the target is met. A benchmark script with no result file is listed as
"not run yet" with its command. The page is generated: edit the benchmarks, run
them, and run this script again; never edit the page by hand.
"""

from __future__ import annotations

import argparse
import ast
import json
import math
import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
NOT_BENCHMARKS = {"report", "train_shipped"}  # this script; a training script, not a benchmark


def scripts(folder: Path) -> dict[str, str]:
    """``{name: first docstring line}`` of every benchmark script in ``folder`` (not ``_*.py``, not this one)."""
    out = {}
    for p in sorted(folder.glob("*.py")):
        if p.name.startswith("_") or p.stem in NOT_BENCHMARKS:
            continue
        try:
            doc = ast.get_docstring(ast.parse(p.read_text(encoding="utf-8"))) or ""
        except (SyntaxError, UnicodeDecodeError):
            doc = ""
        out[p.stem] = doc.strip().split("\n")[0] if doc else ""
    return out


def results(folder: Path) -> dict[str, dict]:
    """``{benchmark: result}`` of every readable ``*.json`` in ``folder``; unreadable files are skipped with a warning."""
    out = {}
    for p in sorted(folder.glob("*.json")) if folder.is_dir() else []:
        try:
            r = json.loads(p.read_text(encoding="utf-8"))
        except (OSError, ValueError) as e:
            print(f"report.py: {p}: skipped ({e})", file=sys.stderr)
            continue
        if isinstance(r, dict) and isinstance(r.get("figures"), dict):
            out[str(r.get("benchmark") or p.stem)] = r
        else:
            print(f"report.py: {p}: skipped (not a benchmark result: no 'figures')", file=sys.stderr)
    return out


def fmt(v) -> str:
    """A figure as a table cell: 4 significant digits, integers whole, booleans yes/no, missing as a dash."""
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return f"{v:,}"
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
            return f"{v:.3g}"
        return f"{v:.4g}" if abs(v) < 1000 else f"{v:,.0f}"
    text = str(v).replace("|", "\\|").replace("\n", " ")
    return text if len(text) <= 60 else text[:57] + "..."


def target_text(t: dict | None) -> str:
    if not t:
        return ""
    of = " (ratio)" if t.get("of") == "ratios" else ""
    return f"{t.get('op', '')} {fmt(t.get('value'))}{of}"


def machine_text(m) -> str:
    if isinstance(m, dict):
        parts = [m.get("cpu"), f"{m['cores']} cores" if m.get("cores") else None,
                 f"{m['memory_gib']} GiB" if m.get("memory_gib") else None, m.get("os"),
                 f"Python {m['python']}" if m.get("python") else None]
        return ", ".join(str(p) for p in parts if p)
    return str(m or "unknown")


def section(name: str, summary: str, r: dict | None) -> list[str]:
    lines = [f"## {name}", ""]
    if summary:
        lines += [summary, ""]
    if r is None:
        lines += ["**Not run yet.** Reproduce with:", "", f"    python benchmarks/{name}.py --json", ""]
        return lines
    lines += [f"Reproduce with: `{r.get('command') or f'python benchmarks/{name}.py --json'}`", "",
              f"Run {r.get('date', 'at an unknown date')} on {machine_text(r.get('machine'))}.", ""]
    details = r.get("details") if isinstance(r.get("details"), dict) else {}
    baseline = details.get("baseline_figures") or details.get("baseline")
    if isinstance(baseline, str):
        lines += [f"Baseline: {baseline.rstrip('.')}.", ""]
    figures, baselines = r.get("figures") or {}, r.get("baselines") or {}
    ratios, targets, met = r.get("ratios") or {}, r.get("targets") or {}, r.get("met") or {}
    lines += ["| figure | value | baseline | ratio | target | met |", "|---|---|---|---|---|---|"]
    for k, v in figures.items():
        lines.append(f"| {fmt(k)} | {fmt(v)} | {fmt(baselines.get(k)) if k in baselines else ''} | "
                     f"{fmt(ratios.get(k)) if k in ratios else ''} | {target_text(targets.get(k))} | "
                     f"{fmt(met.get(k)) if k in met else ''} |")
    lines.append("")
    return lines


def render(script_docs: dict[str, str], found: dict[str, dict]) -> str:
    names = sorted(set(script_docs) | set(found))
    out = ["# Benchmarks", "",
           "Generated by `python benchmarks/report.py` from `benchmarks/results/*.json`, which every benchmark",
           "writes through `benchmarks/_harness.py`; do not edit this page by hand. Each figure comes with the",
           "baseline measured in the same run, their ratio (figure / baseline), the target where there is one,",
           "and whether it is met. Timings depend on the machine and on what else runs on it: compare figures",
           "from the same machine and date.", "",
           "| benchmark | run (flags other than the defaults) | targets met |", "|---|---|---|"]
    for n in names:
        r = found.get(n)
        if r is None:
            out.append(f"| [{n}](#{n}) | not run yet | |")
            continue
        met = r.get("met") or {}
        score = f"{sum(bool(v) for v in met.values())} of {len(met)}" if met else "no target"
        flags = [f for f in str(r.get("command", "")).split()[2:] if f != "--json"]
        setting = f" (`{' '.join(flags)}`)" if flags else ""
        out.append(f"| [{n}](#{n}) | {str(r.get('date', ''))[:10]}{setting} | {score} |")
    out.append("")
    for n in names:
        out += section(n, script_docs.get(n, ""), found.get(n))
    return "\n".join(out).rstrip() + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", type=Path, default=HERE / "results", help="folder of NAME.json result files")
    ap.add_argument("--out", type=Path, default=REPO / "docs" / "benchmarks.md", help="the page to write")
    args = ap.parse_args(argv)
    text = render(scripts(HERE), results(args.results))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(f".{args.out.name}.part")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
