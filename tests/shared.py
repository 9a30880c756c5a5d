"""The curated real takes of ``../shared/data`` that golden I/O tests walk.

``peer_files/`` (other projects' test files, many deliberately odd) and
``bandai_namco_full/`` (an archive to unpack) are not curated takes: the I/O
tests read the former by name, and nothing in ``make test`` needs the latter.
"""

from pathlib import Path

NOT_CURATED = ("peer_files", "bandai_namco_full")


def curated_files(shared_data: Path, pattern: str) -> list[Path]:
    """Every file under ``shared_data`` matching ``pattern`` (recursive), sorted, outside :data:`NOT_CURATED`."""
    return sorted(p for p in shared_data.rglob(pattern) if not set(p.relative_to(shared_data).parts) & set(NOT_CURATED))
