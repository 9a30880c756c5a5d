"""docs/architecture.md's rules, checked on the source: imports go one way between layers, no private name is
imported across modules, no module passes 1,000 lines."""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "mocapkit"

# the layers of docs/architecture.md, left (0) to right; -1: the small modules every layer may use
LAYERS = {
    "errors": -1, "rotations": -1, "interrupts": -1, "progress": -1, "parallel": -1, "kernel_cache": -1,
    "_numba_quaternions": -1, "_numba_euler": -1, "words": -1,
    "motion": 0, "joints": 0, "rigs": 0, "markerset": 0, "digest": 0, "mirroring": 0, "samples": 0, "_numba_fk": 0,
    "side_labels": 0,
    "io": 1,
    "features": 2, "metrics": 2, "corrupt": 2, "joint_spread": 2,
    "database": 3, "database_folder": 3, "context": 3, "search": 3,
    "cleaning": 4, "reconstruct": 4, "reference": 4,
    "report": 5,
    "batch": 6, "batch_decided": 6, "batch_folder": 6, "batch_plan": 6, "batch_request": 6, "batch_written": 6, "warmup": 6, "marker_files": 6,
    "cli": 7, "__main__": 7, "": 7,  # the package's __init__: mocapkit.clean, load, save at the top
}


def _module(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(["mocapkit", *parts])


def _layer(module: str) -> int:
    top = module.split(".")[1] if "." in module else ""
    if top not in LAYERS:
        raise AssertionError(f"{module}: no layer in tests/test_architecture.py (add it there and to docs/architecture.md)")
    return LAYERS[top]


def _imports(path: Path):
    """``(line, module imported from, name or None)`` for every import of a mocapkit module in ``path``."""
    mod = _module(path)
    package = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                full = ".".join(base + ([node.module] if node.module else []))
            else:
                full = node.module or ""
            if full == "mocapkit" or full.startswith("mocapkit."):
                for alias in node.names:
                    sub = f"{full}.{alias.name}"
                    is_module = (SRC.parent / Path(*sub.split("."))).with_suffix(".py").is_file() or \
                        (SRC.parent / Path(*sub.split("."))).is_dir()
                    yield node.lineno, (sub if is_module else full), (None if is_module else alias.name)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("mocapkit"):
                    yield node.lineno, alias.name, None


FILES = sorted(SRC.rglob("*.py"))


@pytest.fixture(scope="module")
def imports() -> dict:
    """``{path: [(line, module, name), ...]}`` of :func:`_imports` for every source file, parsed once for the two
    tests that read them."""
    return {path: list(_imports(path)) for path in FILES}


def test_imports_go_one_way_between_layers(imports):
    wrong = []
    for path in FILES:
        mod = _module(path)
        here = _layer(mod)
        for line, target, name in imports[path]:
            there = -1 if (target, name) == ("mocapkit", "__version__") else _layer(target)
            if there > here or (here == -1 and there >= 0):
                wrong.append(f"{path.relative_to(SRC)}:{line} ({mod}, layer {here}) imports {target} (layer {there})")
    assert not wrong, "\n".join(wrong)


def test_no_private_name_is_imported_across_modules(imports):
    wrong = []
    for path in FILES:
        mod = _module(path)
        for line, target, name in imports[path]:
            if name and name.startswith("_") and not name.startswith("__") and target != mod:
                wrong.append(f"{path.relative_to(SRC)}:{line} imports {name} from {target}")
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(SRC)))
def test_no_module_passes_1000_lines(path):
    assert len(path.read_text(encoding="utf-8").splitlines()) <= 1000
