"""The output folder of a batch (:func:`mocapkit.batch.clean_batch`): its lock, its mark, and its leftovers.

One batch writes into an ``OUT_DIR`` at a time (:func:`only_batch`); it leaves :data:`BATCH_MARK` there so a
later batch of a folder above it leaves those outputs out of its inputs (:func:`mark`, :func:`marked_input`,
removed again by :func:`unmark_if_empty` when nothing was written); :func:`sweep` removes what a killed
worker left (``.NAME.*.part`` temporaries and staging folders) and :func:`prune` the folders made for
takes that were not written.
"""

from __future__ import annotations

import json
import os
import shutil
from contextlib import contextmanager
from pathlib import Path

from .errors import MocapFormatError

__all__ = ["BATCH_MARK", "only_batch", "marked_input", "mark", "unmark_if_empty", "prune", "sweep"]

#: The hidden file :func:`mocapkit.batch.clean_batch` leaves in its OUT_DIR: a later batch leaves a folder holding it
#: out of its inputs.
BATCH_MARK = ".mocapkit-batch.json"


@contextmanager
def only_batch(out_dir: Path):
    """Hold an exclusive lock on ``out_dir`` (``flock`` on the folder) while a batch writes into it.

    Two batches into one folder would sweep each other's staging folders and judge each other's half-written
    takes; the second is refused in one line instead. The folder is made first (:func:`prune` removes it
    again if nothing was written). Without ``fcntl`` (not POSIX), or where the file system refuses locks, no lock.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    out_dir.mkdir(parents=True, exist_ok=True)
    fd = os.open(out_dir, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise MocapFormatError(out_dir, "another clean-batch is writing into this folder; wait for it to end, "
                                            "or choose another output folder") from None
        except OSError:  # a file system without locks (some network mounts)
            pass
        yield
    finally:
        os.close(fd)


def marked_input(out_dir: Path) -> Path | None:
    """The IN_DIR an earlier batch recorded in its :data:`BATCH_MARK`, when it lies inside that OUT_DIR."""
    try:
        recorded = Path(json.loads((out_dir / BATCH_MARK).read_text(encoding="utf-8"))["input"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    try:
        rel = recorded.relative_to(out_dir.resolve())
    except ValueError:
        return None
    return out_dir / rel if rel.parts else None


def mark(out_dir: Path, in_dir: Path) -> None:
    """Leave :data:`BATCH_MARK` in OUT_DIR (atomically): a later batch of a folder above it leaves it out."""
    from .io import atomic_write

    mark = Path(out_dir) / BATCH_MARK
    text = json.dumps({"format": 1, "what": "outputs of mocapkit clean-batch", "input": str(Path(in_dir).resolve())})
    if mark.is_file() and mark.read_text(encoding="utf-8", errors="replace") == text:
        return
    with atomic_write(mark, "w", encoding="utf-8") as fh:
        fh.write(text)


def unmark_if_empty(out_dir: Path) -> None:
    """Remove :data:`BATCH_MARK` again when no take was written beside it (an interrupted or failed first run)."""
    mark = Path(out_dir) / BATCH_MARK
    try:
        if mark.is_file() and not any(p != mark and not p.is_dir() for p in Path(out_dir).rglob("*")):
            mark.unlink()
    except OSError:
        pass


def prune(folders: list[Path]) -> None:
    """Remove the folders of :func:`mocapkit.io.outputs.missing_folders` that the batch made and left empty (no take of theirs was
    written), deepest first; a folder holding anything stays."""
    for f in folders:
        try:
            f.rmdir()
        except OSError:  # not empty, or never made
            pass


def sweep(paths) -> None:
    """Remove what a killed worker left beside ``paths``: ``.NAME.*.part`` temporaries and staging folders.

    One listing per folder (not one glob per path): a corpus of N takes costs O(N).
    """
    from .io.outputs import temp_prefix

    by_folder: dict[Path, set] = {}
    for p in paths:
        p = Path(p)
        by_folder.setdefault(p.parent, set()).add(temp_prefix(p.name)[1:-1])  # NAME as its temporaries start
    for folder, names in by_folder.items():
        try:
            entries = list(os.scandir(folder))
        except OSError:  # not made yet, or unreadable: nothing of ours there
            continue
        for entry in entries:
            stem = entry.name[1:-len(".part")].rpartition(".")[0]  # .NAME.RANDOM.part -> NAME (RANDOM has no dot)
            if not (entry.name.startswith(".") and entry.name.endswith(".part") and stem in names):
                continue
            try:
                if entry.is_dir(follow_symlinks=False):
                    shutil.rmtree(entry.path)
                else:
                    os.unlink(entry.path)
            except OSError:
                pass
