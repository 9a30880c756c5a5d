"""The exception hierarchy: everything mocapkit raises on bad input derives from MocapError."""

from __future__ import annotations

import errno
import os
import re

__all__ = ["MocapError", "MocapFormatError", "MissingFileError", "SkeletonError", "NotJudgedError", "LicenceWarning", "TEMP_NAME",
           "os_error_line", "OUTPUT_STOPPERS", "output_stopper"]


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


class NotJudgedError(MocapError, ValueError):
    """A take self-similarity cannot judge: shorter than one motion word (0.625 s: 15 frames at 24 fps) or too
    coarse for one (under 12 fps), raised by :func:`mocapkit.cleaning.ssa.detect` where ``mocapkit.clean`` and
    ``mocapkit detect`` skip the take and say so.

    ``str(err)`` is one line, ``"TAKE: REASON: not judged"``, the reason naming the length or rate a word needs
    (the words ``clean``'s summary says); ``take`` and ``reason`` hold its parts.
    """

    def __init__(self, take: str, reason: str):
        self.take, self.reason = take, reason
        super().__init__(f"{take}: {reason}: not judged")

    def __reduce__(self):
        return type(self), (self.take, self.reason)


class LicenceWarning(UserWarning):
    """A model whose licence restricts use (the non-commercial Bandai Namco models) was used: said by the library
    functions that pick a model themselves (:func:`mocapkit.cleaning.deep.denoise`, ``fill_gaps``), as the CLI and
    ``clean``'s summary say it."""


# a temporary file of mocapkit.io.atomic_write (or a staging folder): ".NAME.RANDOM.part" beside NAME
TEMP_NAME = re.compile(r"^(?P<dir>.*?)\.(?P<name>[^/]+)\.[^./]+\.part$")


def os_error_line(exc: OSError) -> str:
    """``PATH: reason`` for a filesystem error, naming the output rather than its temporary file or staging folder:
    the one line the CLI prints for it, and a batch's row for a take that failed so (no Python repr, no errno)."""
    name, writing = exc.filename, False
    if isinstance(name, str):
        found = TEMP_NAME.match(name)
        if found:
            name, writing = found.group("dir") + found.group("name"), True
    reason = exc.strerror or str(exc)
    if writing and exc.errno == errno.ENOENT:  # the folder takes no new file (/proc, a folder removed meanwhile)
        reason = "cannot be written there (no such file or directory)"
    if exc.errno == errno.ENOSPC:
        reason = "no space left on the device"
    elif exc.errno == errno.EROFS:
        reason = "read-only file system"
    elif exc.errno == errno.EDQUOT:
        reason = "disk quota exceeded"
    elif exc.errno == errno.EFBIG:
        reason = "file too large (over the file-size limit this process runs under, ulimit -f, or the file system's)"
    return f"{name}: {reason}" if name else reason


#: Filesystem errors that no later write to the same place can escape: a full disk, a used-up quota, a read-only
#: file system. A batch stops at the first one instead of failing every take after it the same way.
OUTPUT_STOPPERS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS})


def output_stopper(exc: BaseException) -> str | None:
    """The errno name (``"ENOSPC"``, ``"EDQUOT"``, ``"EROFS"``) when ``exc``, or an exception it was raised from or
    while handling, is an :class:`OSError` of :data:`OUTPUT_STOPPERS`; else None.

    >>> output_stopper(OSError(errno.ENOSPC, "No space left on device"))
    'ENOSPC'
    >>> output_stopper(PermissionError(errno.EACCES, "Permission denied")) is None
    True
    """
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, OSError) and exc.errno in OUTPUT_STOPPERS:
            return errno.errorcode[exc.errno]
        exc = exc.__cause__ or exc.__context__
    return None
