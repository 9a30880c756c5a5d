"""Tests of mocapkit.warmup: every step of clean runs, and afterwards a clean compiles nothing."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from mocapkit import samples
from mocapkit.warmup import main, warm_up


def test_warm_up_runs_every_step_of_clean():
    # in this process alone: the install's warm-up (make install / make test) runs the two-process split every time,
    # and test_after_warm_up_a_clean_compiles_nothing checks what it caches
    out = warm_up(processes=1)
    assert list(out["steps"]) == ["fill", "detect", "repair", "denoise"]
    cells = out["steps"]  # detect changes no cell; repair changes only what detect flagged
    assert cells["fill"] > 0 and cells["repair"] > 0 and cells["denoise"] > 0, cells  # each step had work: its kernels ran


def test_main_refuses_arguments():
    with pytest.raises(SystemExit) as e:
        main(["--bogus"])
    assert e.value.code == 2


@pytest.mark.slow
def test_after_warm_up_a_clean_compiles_nothing(tmp_path):
    """With numba's cache in an empty folder, warm up, then clean a take, with the self-similarity kernels' serial
    twins (a short take's) and their parallel twins (a long take's), against the default context and alone: numba
    saves no new machine code."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "NUMBA_DEBUG_CACHE": "1"}
    subprocess.run([sys.executable, "-m", "mocapkit.warmup"], env=env, check=True, capture_output=True)
    code = ("import mocapkit; from mocapkit import corrupt; "
            f"m = mocapkit.load({str(samples.path('12_walk.amc'))!r}); "
            "from mocapkit.cleaning.ssa.twins import forced; "
            "b = corrupt.real_errors(m, n_errors=3, seed=1)[0]; mocapkit.clean(b); mocapkit.clean(b, context=False)\n"
            "with forced('parallel'): mocapkit.clean(b); mocapkit.clean(b, context=False)")
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True)
    assert "data loaded" in out.stdout
    assert "data saved" not in out.stdout
