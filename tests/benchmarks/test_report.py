"""benchmarks/report.py: every figure with its baseline, ratio, target and met; scripts without a result listed."""

import importlib.util
import json
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def load(name):
    spec = importlib.util.spec_from_file_location(f"bench_{name}", BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def result(name, **kw):
    r = {"benchmark": name, "date": "2026-01-02T03:04:05+00:00",
         "machine": {"cpu": "Test CPU", "cores": 2, "memory_gib": 4.0, "os": "Linux", "python": "3.11.7"},
         "command": f"python benchmarks/{name}.py --json --quick", "figures": {}, "baselines": {},
         "ratios": {}, "targets": {}, "met": {}, "details": {}}
    r.update(kw)
    return r


def test_every_figure_and_every_script(tmp_path):
    report = load("report")
    harness = load("_harness")
    figures, baselines = {"ms_per_query": 0.5, "frames": 1000, "found": None}, {"ms_per_query": 2.0}
    ratios = harness.ratios_of(figures, baselines)
    targets = {"ms_per_query": {"value": 0.2, "op": "<=", "of": "ratios"}, "found": {"value": 1, "op": ">=", "of": "figures"}}
    results = tmp_path / "results"
    results.mkdir()
    fast = result("fast", figures=figures, baselines=baselines, ratios=ratios, targets=targets,
                  met=harness.met_of(targets, figures, ratios), details={"baseline": "brute force, same run"})
    (results / "fast.json").write_text(json.dumps(fast))
    (results / "broken.json").write_text("{not json")
    out = tmp_path / "docs" / "benchmarks.md"
    report.main(["--results", str(results), "--out", str(out)])
    text = out.read_text()
    # the figure with a baseline: value, baseline, ratio 0.25 against a ratio target 0.2, not met
    assert "| ms_per_query | 0.5 | 2 | 0.25 | <= 0.2 (ratio) | no |" in text
    assert "| frames | 1,000 |" in text
    assert "| found | - |  |  | >= 1 | no |" in text
    assert "`python benchmarks/fast.py --json --quick`" in text and "Test CPU, 2 cores" in text
    assert "Baseline: brute force, same run." in text
    assert "| [fast](#fast) | 2026-01-02 (`--quick`) | 0 of 2 |" in text
    # every benchmark script in the folder without a result is listed with its command
    for script in sorted(BENCHMARKS.glob("[a-z]*.py")):
        if script.stem in report.NOT_BENCHMARKS:
            assert f"## {script.stem}\n" not in text
            continue
        assert f"## {script.stem}\n" in text
        assert f"python benchmarks/{script.stem}.py --json" in text
    assert "broken" not in text


def test_the_command_names_the_script_that_ran(monkeypatch):
    """A script that keeps a variant's result under another name (clean_untouched --all) still records itself."""
    harness = load("_harness")
    monkeypatch.setattr("sys.argv", ["benchmarks/clean_untouched.py", "--all", "--no-save"])
    assert harness._command("clean_untouched_all") == "python benchmarks/clean_untouched.py --all --json"
    monkeypatch.setattr("sys.argv", ["benchmarks/deep_speed.py", "--json"])
    assert harness._command("deep_speed") == "python benchmarks/deep_speed.py --json"
