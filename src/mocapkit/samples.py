"""Small real clips bundled with the package (see ``mocapkit/data/README.md`` for sources)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

__all__ = ["path", "names"]


def _root() -> Path:
    return Path(str(resources.files("mocapkit") / "data"))


def names() -> list[str]:
    """File names of the bundled clips."""
    return sorted(p.name for p in _root().iterdir() if p.suffix.lower() in {".bvh", ".amc", ".asf", ".c3d"})


def path(name: str) -> Path:
    """Path of a bundled clip by file name, e.g. ``path("131_01.bvh")``.

    >>> path("131_01.bvh").name
    '131_01.bvh'
    """
    p = _root() / name
    if not p.is_file():
        raise FileNotFoundError(f"no bundled sample {name!r}; samples are: {', '.join(names())}")
    return p
