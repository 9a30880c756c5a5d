"""The exception hierarchy: everything mocapkit raises on bad input derives from MocapError."""

from __future__ import annotations

import errno
import os

__all__ = ["MocapError", "MocapFormatError", "MissingFileError", "SkeletonError"]


class MocapError(Exception):
    """Base class of mocapkit's errors about user input (files, skeletons, parameters)."""


class MocapFormatError(MocapError, ValueError):
    """A file cannot be read or written: names the file, the line when known, and the reason.

    ``str(err)`` is one line, ``"PATH:LINE: REASON"`` (or ``"PATH: REASON"``),
    which is what the CLI prints before exiting with status 2.
    """

    def __init__(self, path: str | os.PathLike | None, reason: str, line: int | None = None):
        self.path = None if path is None else os.fspath(path)
        self.reason = reason
        self.line = line
        where = self.path if self.path is not None else "<input>"
        if line is not None:
            where = f"{where}:{line}"
        super().__init__(f"{where}: {reason}")

    def __reduce__(self):
        # rebuilt from its own arguments: the default (the message as the one argument) cannot call this
        # __init__, so an error raised in a worker process broke the process pool instead of reaching the caller
        return type(self), (self.path, self.reason, self.line)


class MissingFileError(MocapFormatError, FileNotFoundError):
    """A file that does not exist: a :class:`MocapFormatError` (one line naming it) that is also a
    ``FileNotFoundError``, so ``except FileNotFoundError`` and ``except OSError`` catch it as for ``open``."""

    def __new__(cls, path=None, reason: str = "no such file", line: int | None = None):
        return FileNotFoundError.__new__(cls)

    def __init__(self, path: str | os.PathLike | None, reason: str = "no such file", line: int | None = None):
        super().__init__(path, reason, line)
        self.errno, self.strerror, self.filename = errno.ENOENT, reason, self.path

    def __str__(self) -> str:
        return str(self.args[0])


class SkeletonError(MocapError, ValueError):
    """A skeleton is malformed or two skeletons do not match where they must."""
