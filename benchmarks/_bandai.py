"""The Bandai Namco Research Motiondataset 1 and 2 for benchmarks: where it is, and which takes.

The archive (``../shared/data/bandai_namco_full/bandai_namco.tar.xz``, 76 MB,
201 min of clean studio motion at 30 fps, one 22-joint game rig, CC BY-NC 4.0)
is unpacked once, outside the repository, into ``$MOCAPKIT_BANDAI_DIR`` or
``~/.cache/mocapkit/bandai_namco`` (476 MB, 10-20 s), and read from there.
Tests never need it; benchmarks that do call :func:`bandai_root`.

Each take ``dataset-N_{content}_{style}_{id}.bvh`` has its labels in the file
name (and a ``.json`` beside it); :func:`bandai_takes` lists them with content
and style so a benchmark can hold out by style, never by cutting takes.
"""

from __future__ import annotations

import os
import re
import sys
import tarfile
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ARCHIVE = REPO.parent / "shared" / "data" / "bandai_namco_full" / "bandai_namco.tar.xz"

__all__ = ["BandaiTake", "bandai_root", "bandai_takes", "split_by_style", "HELD_OUT_D2"]


@dataclass(frozen=True)
class BandaiTake:
    """One take: its BVH path, dataset (1 or 2), content (``walk``), style (``happy``) and id."""

    path: Path
    dataset: int
    content: str
    style: str
    take_id: int


def _default_dir() -> Path:
    env = os.environ.get("MOCAPKIT_BANDAI_DIR")
    return Path(env) if env else Path.home() / ".cache" / "mocapkit" / "bandai_namco"


def bandai_root(archive: Path = ARCHIVE, target: Path | None = None) -> Path:
    """The folder holding ``dataset/Bandai-Namco-Research-Motiondataset-{1,2}``; unpacks the archive on first use.

    Unpacks into a temporary sibling folder and renames it into place, so an
    interrupted unpack never leaves a half-filled folder that looks complete.
    """
    target = _default_dir() if target is None else Path(target)
    if (target / "dataset").is_dir():
        return target
    if not archive.is_file():
        raise SystemExit(f"{archive}: the Bandai Namco archive is missing; set MOCAPKIT_BANDAI_DIR to an unpacked copy")
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(target.name + f".unpacking-{os.getpid()}")
    print(f"unpacking {archive.name} into {target} (once, 10-20 s)", file=sys.stderr)
    with tarfile.open(archive, "r:xz") as tar:
        tar.extractall(tmp, filter="data")
    os.replace(tmp, target)
    return target


_NAME = re.compile(r"dataset-(\d)_(.+)_([a-z-]+)_(\d+)\.bvh$")


def bandai_takes(root: Path | None = None) -> list[BandaiTake]:
    """Every take, sorted by path, with its content and style parsed from the file name."""
    root = bandai_root() if root is None else Path(root)
    out = []
    for p in sorted(root.glob("dataset/*/data/*.bvh")):
        m = _NAME.search(p.name)
        if m is None:
            continue
        out.append(BandaiTake(p, int(m.group(1)), m.group(2), m.group(3), int(m.group(4))))
    if not out:
        raise SystemExit(f"{root}: no Bandai Namco takes found under dataset/*/data/")
    return out


#: dataset-2 styles held out of the large database (with every dataset-1 style that dataset-2 lacks)
HELD_OUT_D2 = ("elderly",)


def split_by_style(takes):
    """(database takes, held-out takes): dataset-2 ``elderly`` and the dataset-1 styles absent from dataset-2 held out."""
    d2_styles = {t.style for t in takes if t.dataset == 2}
    held = [t for t in takes if (t.dataset == 2 and t.style in HELD_OUT_D2) or (t.dataset == 1 and t.style not in d2_styles)]
    held_set = {t.path for t in held}
    return [t for t in takes if t.path not in held_set], held
