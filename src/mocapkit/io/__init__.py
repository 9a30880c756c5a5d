"""Readers and writers; ``load`` and ``save`` choose the format by the file suffix.

Readers return a :class:`~mocapkit.motion.Motion` (C3D: a
:class:`~mocapkit.io.c3d.MarkerSet`), writers take one. Every reader raises
:class:`~mocapkit.errors.MocapFormatError` naming the file, the line when
known, and the problem. Writers write to a temporary file in the target
folder and rename it, so a failed or interrupted write leaves no partial file.
"""

from __future__ import annotations

import os
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path

from ..errors import MocapFormatError

__all__ = ["load", "save", "atomic_write", "READERS", "WRITERS"]

READERS = {".bvh": "bvh", ".amc": "asfamc", ".npz": "npz", ".c3d": "c3d"}
WRITERS = {".bvh": "bvh", ".npz": "npz"}


def suffix_kind(path: Path, table: dict, verb: str) -> str:
    suf = path.suffix.lower()
    if suf not in table:
        known = ", ".join(sorted(table))
        raise MocapFormatError(path, f"unknown suffix {suf or '(none)'!r} for {verb}; known: {known}")
    return table[suf]


def load(path, **kwargs):
    """Read a motion file, choosing the format by suffix (.bvh, .amc, .npz; .c3d gives a MarkerSet).

    Keyword arguments go to the format's reader (e.g. ``asf=`` and ``fps=`` for AMC).
    """
    path = Path(path)
    kind = suffix_kind(path, READERS, "reading")
    if not path.is_file():
        raise MocapFormatError(path, "no such file" if not path.exists() else "not a regular file")
    if kind == "bvh":
        from .bvh import read_bvh as reader
    elif kind == "asfamc":
        from .asfamc import read_amc as reader
    elif kind == "npz":
        from .npz import read_npz as reader
    else:
        from .c3d import read_c3d as reader
    return reader(path, **kwargs)


def save(motion, path, like=None, **kwargs) -> Path:
    """Write ``motion`` to ``path`` (.bvh or .npz) atomically; returns the path.

    ``like``: the file ``motion`` was read from. A BVH written from a BVH keeps
    that file's text wherever the motion did not change (see
    :func:`mocapkit.io.bvh.write_bvh`), so an untouched take comes back the
    same file; other pairs of formats ignore it.
    """
    path = Path(path)
    kind = suffix_kind(path, WRITERS, "writing")
    if kind == "bvh":
        from .bvh import write_bvh

        write_bvh(motion, path, like=like, **kwargs)
    else:
        from .npz import write_npz

        write_npz(motion, path, **kwargs)
    return path


def _final_mode(path: Path) -> int:
    try:
        return stat.S_IMODE(path.stat().st_mode)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


@contextmanager
def atomic_write(path, mode: str = "w", **open_kwargs):
    """Open a temporary file beside ``path`` for writing and rename it over ``path`` on success.

    On any exception (KeyboardInterrupt included) the temporary file is removed
    and ``path`` is untouched. The file gets the permissions an ordinary
    ``open(path, "w")`` would give it (those of the file it replaces, else
    0o666 less the umask), not the temporary file's private 0o600.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    try:
        with os.fdopen(fd, mode, **open_kwargs) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, _final_mode(path))
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
