"""What every benchmark shares: the ``--json`` flag, machine info, and one schema for the last line.

Every benchmark ends by calling :func:`emit`, which prints one JSON object as
the last line of standard output and keeps a copy in
``benchmarks/results/NAME.json`` (what ``benchmarks/report.py`` turns into
``docs/benchmarks.md``). The object always has these keys:

- ``benchmark``: the script's name (``clean_takes``);
- ``date``: UTC time of the run, ISO 8601; ``machine``: CPU, cores, memory, OS, Python;
- ``command``: how to reproduce it (``python benchmarks/NAME.py --json`` plus the flags given);
- ``figures``: ``{name: value}``, the measured numbers (floats, ints or short strings);
- ``baselines``: ``{name: value}``, each the figure of the baseline measured in the same run
  (same name as the figure it is compared with);
- ``ratios``: ``{name: figure / baseline}``;
- ``targets``: ``{name: {"value": v, "op": "<=" | ">=", "of": "figures" | "ratios"}}``;
- ``met``: ``{name: bool}`` for every target;
- ``details``: anything else the benchmark reports (tables, per-clip rows, notes).

Usage::

    args = harness.parser(__doc__).parse_args()   # has --json; add your own flags first
    ...
    harness.emit("clean_takes", args, figures=..., baselines=..., targets=..., details=...)
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import os
import platform
import sys
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"

__all__ = ["parser", "machine", "ratios_of", "met_of", "emit", "RESULTS"]


def parser(doc: str | None = None) -> argparse.ArgumentParser:
    """An ``ArgumentParser`` with the shared ``--json`` flag and ``--no-save``."""
    ap = argparse.ArgumentParser(description=(doc or "").split("\n")[0])
    ap.add_argument("--json", action="store_true", help="print only one JSON object as the last line")
    ap.add_argument("--no-save", action="store_true", help="do not keep a copy in benchmarks/results/")
    return ap


def machine() -> dict:
    """CPU model, core count, memory (GiB), load average (1, 5, 15 min), OS and Python of the machine the figures come from."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = None
    try:
        mem = round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1)
    except (ValueError, OSError, AttributeError):
        pass
    try:
        load = [round(x, 2) for x in os.getloadavg()]
    except (OSError, AttributeError):
        load = None
    return {"cpu": cpu, "cores": os.cpu_count(), "memory_gib": mem, "load_average": load, "os": platform.platform(),
            "python": platform.python_version()}


def ratios_of(figures: dict, baselines: dict) -> dict:
    """``figure / baseline`` for every name present in both with a finite, non-zero baseline."""
    out = {}
    for k, b in baselines.items():
        f = figures.get(k)
        if isinstance(f, (int, float)) and isinstance(b, (int, float)) and b and math.isfinite(b):
            out[k] = round(f / b, 4)
    return out


def met_of(targets: dict, figures: dict, ratios: dict) -> dict:
    """Whether each target holds: ``targets[name] = {"value", "op", "of"}`` checked on figures or ratios."""
    met = {}
    for k, t in targets.items():
        source = ratios if t.get("of", "figures") == "ratios" else figures
        v = source.get(k)
        if not isinstance(v, (int, float)) or not math.isfinite(v):
            met[k] = False
            continue
        met[k] = bool(v <= t["value"]) if t["op"] == "<=" else bool(v >= t["value"])
    return met


def _command(name: str) -> str:
    """The command that reproduces the run: the script that ran (a script may keep a variant's result under
    another ``name``, e.g. ``--all``) and its flags, with ``--json``."""
    flags = [a for a in sys.argv[1:] if a != "--no-save"]
    if "--json" not in flags:
        flags.append("--json")
    script = Path(sys.argv[0]).name if sys.argv and sys.argv[0].endswith(".py") else f"{name}.py"
    return " ".join(["python", f"benchmarks/{script}", *flags])


def emit(name: str, args=None, *, figures: dict, baselines: dict | None = None, targets: dict | None = None,
         details: dict | None = None, ratios: dict | None = None) -> dict:
    """Print the benchmark's result as one JSON line (last line of stdout) and keep it in ``results/``.

    ``ratios`` default to figure / baseline for every shared name; ``met`` is computed from ``targets``.
    With ``args.json`` false the object is also pretty-printed first, for a person reading it.
    """
    baselines = dict(baselines or {})
    targets = dict(targets or {})
    ratios = ratios_of(figures, baselines) if ratios is None else dict(ratios)
    result = {
        "benchmark": name,
        "date": _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat(),
        "machine": machine(),
        "command": _command(name),
        "figures": figures,
        "baselines": baselines,
        "ratios": ratios,
        "targets": targets,
        "met": met_of(targets, figures, ratios),
        "details": details or {},
    }
    text = json.dumps(result, default=float)
    if args is not None and not getattr(args, "json", False):
        print(json.dumps(result, indent=1, default=float))
    if args is None or not getattr(args, "no_save", False):
        RESULTS.mkdir(exist_ok=True)
        tmp = RESULTS / f".{name}.json.part"
        tmp.write_text(text + "\n")
        os.replace(tmp, RESULTS / f"{name}.json")
    print(text, flush=True)
    return result
