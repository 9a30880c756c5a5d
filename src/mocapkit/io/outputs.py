"""The output guard: one check, for every command and library writer, that an output may be written.

A cleaning tool must never lose what it was given. Before any work is done,
every path a command will write is checked against every path it reads:

- no output may resolve (symlinks, ``./``, ``..``, hard links) to an input
  file, nor lie inside an input folder (a ``--context`` folder, a database);
- no two outputs may be the same file;
- an existing output file is replaced only when ``overwrite`` is true;
- an output that exists and is a folder, or whose parent is a file, is refused;
- missing parent folders are created only when the output is written
  (:func:`mocapkit.io.atomic_write` does that), never by the check.

A command that writes several files writes them inside
:func:`removed_on_failure`, so a run that fails half-way leaves none of the
files it created (a report without its take, a take without its record).

The check raises :class:`~mocapkit.errors.MocapFormatError` naming the output
and the problem, which the CLI prints as one line.

>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> (d / "a.bvh").write_text("x")
1
>>> check_outputs([d / "out.bvh"], [d / "a.bvh"])
>>> try:
...     check_outputs([d / "a.bvh"], [d / "a.bvh"])
... except MocapFormatError as exc:
...     print(exc.reason.split(" (")[0])
refusing to write over an input
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator

from ..errors import MocapFormatError

__all__ = ["check_outputs", "same_file", "inside", "removed_on_failure"]


def resolved(path: os.PathLike | str) -> Path:
    """The absolute path with symlinks, ``.`` and ``..`` resolved (also for paths that do not exist yet)."""
    return Path(os.path.realpath(os.path.abspath(os.fspath(path))))


def same_file(a: os.PathLike | str, b: os.PathLike | str) -> bool:
    """True when ``a`` and ``b`` name one file: the same resolved path, or the same inode (hard links)."""
    ra, rb = resolved(a), resolved(b)
    if ra == rb:
        return True
    try:
        return os.path.samefile(ra, rb)
    except OSError:
        return False


def inside(path: os.PathLike | str, folder: os.PathLike | str) -> bool:
    """True when ``path`` resolves to ``folder`` itself or to something below it."""
    rp, rf = resolved(path), resolved(folder)
    return rp == rf or rf in rp.parents


def check_outputs(
    outputs: Iterable[os.PathLike | str | None],
    inputs: Iterable[os.PathLike | str | None] = (),
    *,
    overwrite: bool = False,
) -> None:
    """Refuse, before any work, outputs that would replace an input, each other, or an existing file.

    Parameters
    ----------
    outputs : paths the caller will write (``None`` entries are ignored).
    inputs : every path the caller reads: files and folders (``None`` ignored).
        An output equal to an input file, or inside an input folder, is refused.
    overwrite : allow replacing an existing output *file* (never an input, never a folder).

    Raises
    ------
    MocapFormatError
        One line naming the output and what is wrong with it.
    """
    outs = [Path(o) for o in outputs if o is not None]
    ins = [Path(i) for i in inputs if i is not None]
    seen: list[Path] = []
    for out in outs:
        for inp in ins:
            if same_file(out, inp) or (resolved(inp).is_dir() and inside(out, inp)):
                raise MocapFormatError(out, f"refusing to write over an input ({inp}); choose another output path")
            if out.exists() and out.is_dir() and inside(inp, out):
                raise MocapFormatError(out, f"refusing to replace a folder that holds an input ({inp})")
        for other in seen:
            if same_file(out, other):
                raise MocapFormatError(out, f"given as two outputs ({other}); each output needs its own path")
        seen.append(out)
        if out.is_dir():
            raise MocapFormatError(out, "is a folder; give a file path for this output")
        parent = out.parent
        while not parent.exists() and parent != parent.parent:
            parent = parent.parent
        if parent.exists() and not parent.is_dir():
            raise MocapFormatError(out, f"cannot create it: {parent} is a file, not a folder")
        if out.exists() and not overwrite:
            raise MocapFormatError(out, "already exists; pass --overwrite to replace it")


@contextmanager
def removed_on_failure(outputs: Iterable[os.PathLike | str | None]) -> Iterator[None]:
    """Remove, if the block raises (interrupts included), every output it created; then re-raise.

    Only files that did not exist when the block started are removed: an
    output that existed before (replaced with ``overwrite``) is never deleted.
    Each output is still written atomically, so a file is either complete or absent.
    """
    outs = [Path(o) for o in outputs if o is not None]
    existed = {o for o in outs if os.path.lexists(o)}
    try:
        yield
    except BaseException:
        for o in outs:
            if o not in existed:
                try:
                    o.unlink()
                except (FileNotFoundError, IsADirectoryError, PermissionError):
                    pass
        raise
