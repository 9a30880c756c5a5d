"""Every benchmark and script imports against the current library (a renamed function breaks it here, not in a run)."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

_IMPORT_ALL = """
import importlib.util, sys
from pathlib import Path
root = Path(sys.argv[1])
sys.path.insert(0, str(root))
for f in sorted(root.glob("[a-z]*.py")):
    spec = importlib.util.spec_from_file_location("bench_" + f.stem, f)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        print(f"{f.name}: {type(exc).__name__}: {exc}")
"""


@pytest.mark.parametrize("folder, least", [("benchmarks", 30), ("scripts", 1)])
def test_every_script_imports(folder, least):
    assert len(sorted((ROOT / folder).glob("[a-z]*.py"))) >= least
    p = subprocess.run([sys.executable, "-c", _IMPORT_ALL, str(ROOT / folder)], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert p.stdout == "", p.stdout
