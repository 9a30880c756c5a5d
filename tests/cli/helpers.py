"""Running the real command in tests: in a subprocess (exit status, stdout, stderr) or in-process via ``main``."""

from __future__ import annotations

import contextlib
import hashlib
import io
import subprocess
import sys
from pathlib import Path

import mocapkit
from mocapkit.cli import main

SAMPLE = str(mocapkit.samples.path("131_01.bvh"))
WALK = mocapkit.samples.path("12_walk.amc")


def run(*args, cwd=None):
    """Run the command in this process (:func:`mocapkit.cli.main`, what the console script calls): exit status,
    stdout, stderr.

    The same code path as ``mocapkit ARGS`` after start-up, without a new interpreter importing torch and the
    kernels for every command (about 3 s each). :func:`run_process` runs the real console entry point where a
    test needs a process of its own.
    """
    out, err = io.StringIO(), io.StringIO()
    where = contextlib.chdir(cwd) if cwd is not None else contextlib.nullcontext()
    with where, contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def run_process(*args, cwd=None):
    """Run the console entry point (``python -m mocapkit.cli``) in a subprocess: exit code, stdout, stderr."""
    p = subprocess.run([sys.executable, "-m", "mocapkit.cli", *map(str, args)], capture_output=True, text=True, cwd=cwd)
    return p.returncode, p.stdout, p.stderr


def one_error_line(err: str) -> bool:
    """Exactly one error line (progress bars may precede it on stderr), and it is the last line; no traceback."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    return (bool(lines) and sum(ln.startswith("mocapkit: error:") for ln in lines) == 1
            and lines[-1].startswith("mocapkit: error:") and "Traceback" not in err)


def digest(p: Path) -> str:
    return hashlib.sha256(Path(p).read_bytes()).hexdigest()


def tree(d: Path) -> dict:
    """{relative path: sha256} of every file under ``d``."""
    return {str(p.relative_to(d)): digest(p) for p in sorted(Path(d).rglob("*")) if p.is_file()}
