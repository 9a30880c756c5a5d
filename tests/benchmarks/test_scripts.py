"""Every benchmark and script imports against the current library (a renamed function breaks it here, not in a run)."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = ("benchmarks", "scripts")

# One interpreter imports both folders' files (each folder on sys.path only while its own files import): the
# scripts and most benchmarks import torch and mocapkit's deep modules, ~3 s of CPU a fresh interpreter pays again.
_IMPORT_ALL = """
import importlib.util, sys
from pathlib import Path
for arg in sys.argv[1:]:
    root = Path(arg)
    sys.path.insert(0, str(root))
    for f in sorted(root.glob("[a-z]*.py")):
        spec = importlib.util.spec_from_file_location(f"bench_{root.name}_{f.stem}", f)
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module
        try:
            spec.loader.exec_module(module)
        except Exception as exc:
            print(f"{root.name}/{f.name}: {type(exc).__name__}: {exc}")
    sys.path.remove(str(root))
"""


@pytest.fixture(scope="module")
def imported():
    """The import run over :data:`FOLDERS`: (exit code, standard error, its report lines)."""
    p = subprocess.run([sys.executable, "-c", _IMPORT_ALL, *(str(ROOT / f) for f in FOLDERS)], capture_output=True,
                       text=True, timeout=600)
    return p.returncode, p.stderr, p.stdout.splitlines()


@pytest.mark.parametrize("folder, least", [("benchmarks", 30), ("scripts", 1)])
def test_every_script_imports(imported, folder, least):
    assert len(sorted((ROOT / folder).glob("[a-z]*.py"))) >= least
    returncode, stderr, lines = imported
    assert returncode == 0, stderr
    assert [ln for ln in lines if ln.startswith(folder + "/")] == []
    assert all(ln.split("/")[0] in FOLDERS for ln in lines), lines  # nothing else printed
