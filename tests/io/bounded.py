"""Run a snippet of Python in a child process whose address space is capped (RLIMIT_AS).

A reader that would allocate gigabytes for a hostile file then fails with
MemoryError (or is killed) instead of taking the machine down; the tests
check that the child refuses the file in one line and exits normally.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

LIMIT_BYTES = 2 * 2**30

_PRELUDE = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit}))
"""


def run_bounded(code: str, limit: int = LIMIT_BYTES) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter limited to ``limit`` bytes of address space; returns the result."""
    src = _PRELUDE.format(limit=int(limit)) + textwrap.dedent(code)
    env = dict(os.environ)
    root = Path(__file__).resolve().parents[2]
    env["PYTHONPATH"] = os.pathsep.join([str(root / "src"), str(root), env.get("PYTHONPATH", "")])
    return subprocess.run([sys.executable, "-c", src], capture_output=True, text=True, env=env)


def refusal_of_load(path, **kwargs) -> str:
    """The one-line MocapFormatError message ``mocapkit.load(path)`` gives in a 2 GiB child, or fail the test."""
    code = f"""
    import mocapkit
    from mocapkit.errors import MocapError
    try:
        mocapkit.load({str(path)!r}, **{kwargs!r})
    except MocapError as exc:
        print("REFUSED", exc)
    else:
        print("LOADED")
    """
    res = run_bounded(code)
    assert res.returncode == 0, f"child died (rc {res.returncode}): {res.stderr[-2000:]}"
    out = res.stdout.strip()
    assert out.startswith("REFUSED "), out
    line = out[len("REFUSED "):]
    assert "\n" not in line
    return line
