"""stdout and stderr guarded against a reader that goes away: ``mocapkit info take.bvh | head -1``.

Python ignores SIGPIPE, so a write to a pipe whose reader has closed it raises ``BrokenPipeError`` wherever the
command printed (rich's console turned it into ``SystemExit(1)``: the command ended with status 1 and no word, as
a batch with failed takes does). :func:`guarded_streams` makes it end as SIGPIPE ends ``yes | head``: the stream's
file descriptor is pointed at ``os.devnull`` (nothing written after fails again, the interpreter's last flush
included) and the command is interrupted (:func:`mocapkit.interrupts.stream_closed`), so it stops as on Ctrl-C, its
outputs written whole and the one being written removed, and :func:`mocapkit.cli.main` returns 141 saying
nothing.
"""

from __future__ import annotations

import errno
import os
import sys
from contextlib import contextmanager

__all__ = ["PipeGuard", "guarded_streams"]


class PipeGuard:
    """A text stream (``sys.stdout``, ``sys.stderr``) whose write or flush to a closed pipe interrupts the command
    once (module docstring), every later write going nowhere; everything else is the stream's own."""

    def __init__(self, stream):
        self._stream = stream
        self.closed_by_reader = False

    def _gone(self) -> KeyboardInterrupt | None:
        """The stream's reader went away: its descriptor pointed at os.devnull; the interrupt to raise the first
        time, None after."""
        from ..interrupts import stream_closed

        try:
            null = os.open(os.devnull, os.O_WRONLY)
            try:
                os.dup2(null, self._stream.fileno())
            finally:
                os.close(null)
        except (AttributeError, OSError, ValueError):  # no descriptor (a test's StringIO): the text is dropped below
            pass
        if self.closed_by_reader:
            return None
        self.closed_by_reader = True
        return stream_closed()

    def _guarded(self, call, *args):
        if self.closed_by_reader and not _has_descriptor(self._stream):
            return None  # a stream without a descriptor: nothing reaches its reader any more
        try:
            return call(*args)
        except OSError as exc:
            if not isinstance(exc, BrokenPipeError) and exc.errno != errno.EPIPE:
                raise
            stop = self._gone()
            if stop is not None:
                raise stop from None
            return None

    def write(self, text):
        return self._guarded(self._stream.write, text)

    def writelines(self, lines):
        return self._guarded(self._stream.writelines, lines)

    def flush(self):
        return self._guarded(self._stream.flush)

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _has_descriptor(stream) -> bool:
    try:
        stream.fileno()
        return True
    except (AttributeError, OSError, ValueError):
        return False


@contextmanager
def guarded_streams():
    """While the block runs, ``sys.stdout`` and ``sys.stderr`` are :class:`PipeGuard` s of themselves; then they
    are put back (their descriptors stay on os.devnull where the reader went away)."""
    before = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = (s if s is None or isinstance(s, PipeGuard) else PipeGuard(s) for s in before)
    try:
        yield
    finally:
        sys.stdout, sys.stderr = before
