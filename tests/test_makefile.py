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
