"""The Makefile's test install: what `make test` runs before pytest, read from `make -n` (nothing is executed)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def test_install_recipe() -> list[str]:
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    out = subprocess.run(["make", "-n", "-B", "--no-print-directory", ".venv/.installed-test"], cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout
    return out.replace("\\\n", " ").splitlines()  # a recipe line continued with a backslash is one shell command


def test_the_tests_bytecode_is_written_once_beside_the_warm_up(test_install_recipe):
    """One pytest collection writes the tests' rewritten bytecode and the sources' before the xdist workers start,
    even where PYTHONDONTWRITEBYTECODE is set, in the background of the warm-up (one shell command, waited for)."""
    line = next((c for c in test_install_recipe if "mocapkit.warmup" in c), None)
    assert line is not None, test_install_recipe
    collect, _, rest = line.partition("&")
    assert "-m pytest --collect-only" in collect and "env -u PYTHONDONTWRITEBYTECODE" in collect, line
    assert rest.index("-m mocapkit.warmup") < rest.index("wait"), line
    assert "exit" in rest.split("wait", 1)[1], line  # the warm-up's exit status is the recipe's


def test_pytest_runs_one_worker_per_cpu_this_process_may_use():
    """`make test` starts one xdist worker per CPU it may run on (at most 4), as `nproc` counts them, not xdist's
    `auto`, which counts physical cores (one on a 2-vCPU machine whose vCPUs are hyperthreads of one core). The
    count is read from make itself (a rule added on standard input prints it), nothing of `make test` is run."""
    import os
    import re

    if shutil.which("make") is None or shutil.which("nproc") is None:
        pytest.skip("make or nproc is not installed")
    recipe = (ROOT / "Makefile").read_text()
    assert re.search(r"-m pytest -q .*--numprocesses=\$\(WORKERS\) ", recipe), "make test's pytest line"
    out = subprocess.run(["make", "-s", "--no-print-directory", "-f", "Makefile", "-f", "-", "print-workers"],
                         input="print-workers:\n\t@echo $(WORKERS)\n", cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout
    assert int(out.strip()) == min(len(os.sched_getaffinity(0)), 4), out


def test_one_pip_run_pins_torch_and_byte_compiles_on_every_core(test_install_recipe):
    """torch==2.13.0 (the CPU wheel on disk) is asked for in the same pip run as the package, so the resolver never
    picks a CUDA build for the package's torch>=2.2; pip writes no bytecode (--no-compile: one file at a time on one
    core) and compileall writes the same .pyc files on every core (-j 0), before the warm-up imports anything."""
    pips = [c for c in test_install_recipe if "-m pip install" in c and "--upgrade pip" not in c]
    assert len(pips) == 1, pips
    assert "torch==2.13.0" in pips[0] and "-e '.[test]'" in pips[0] and "--no-compile" in pips[0], pips[0]
    order = [i for i, c in enumerate(test_install_recipe) if "-m pip install" in c and "--upgrade pip" not in c
             or "-m compileall" in c or "mocapkit.warmup" in c]
    pip, compile_, warm = order
    assert "-j 0" in test_install_recipe[compile_] and "site.getsitepackages()" in test_install_recipe[compile_]
    assert "mocapkit.warmup" in test_install_recipe[warm], test_install_recipe
