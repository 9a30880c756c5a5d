"""Interrupts: SIGINT and SIGTERM end a command as ``KeyboardInterrupt``, so every atomic write cleans up.

Python turns SIGINT into ``KeyboardInterrupt`` but dies at once on SIGTERM, which leaves a
command's hidden ``.part`` files behind; :func:`interrupts_as_keyboard_interrupt` makes both
raise it. One place is unsafe for any exception: numba's JIT cache calls Python back from
LLVM's C++ (llvmlite's object-cache hooks), and an exception raised there cannot unwind through
it: the process crashed with SIGSEGV when Ctrl-C or SIGTERM landed while a kernel was loaded or
compiled. While a frame of llvmlite is on the stack the handler therefore sends the signal again
50 ms later instead of raising, so the interrupt lands right after the callback returns.
"""

from __future__ import annotations

import os
import signal
import threading
from contextlib import contextmanager

__all__ = ["interrupts_as_keyboard_interrupt", "interrupts_held", "in_native_callback", "exit_status", "RETRY_S"]

RETRY_S = 0.05  # seconds before a deferred signal is sent again


def in_native_callback(frame) -> bool:
    """True while ``frame`` or any of its callers runs llvmlite's Python code (C++ may be below it)."""
    while frame is not None:
        if f"{os.sep}llvmlite{os.sep}" in frame.f_code.co_filename:
            return True
        frame = frame.f_back
    return False


_last_signal: list[int] = []  # the signal that raised the last KeyboardInterrupt here (exit_status)


def _interrupt(signum, frame):
    if in_native_callback(frame):
        timer = threading.Timer(RETRY_S, os.kill, (os.getpid(), signum))
        timer.daemon = True
        timer.start()
        return
    _last_signal[:] = [signum]
    raise KeyboardInterrupt(f"signal {signum}")


def exit_status() -> int:
    """The exit status of a command an interrupt ended: 128 + the signal's number, as a shell reports a process the
    signal ended (130 for Ctrl-C, 143 for SIGTERM, what a scheduler that stopped it expects); 130 for an interrupt
    no signal of ours raised."""
    return 128 + (_last_signal[0] if _last_signal else int(signal.SIGINT))


def _replaceable(handler) -> bool:
    """Python's own behaviour for the signal (not ignored, not someone else's handler)."""
    return handler in (signal.SIG_DFL, signal.default_int_handler, _interrupt)


def _set_handlers(handler, replaceable) -> dict:
    """``handler`` for SIGINT and SIGTERM where ``replaceable(current)``; returns the handlers replaced."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    before = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            current = signal.getsignal(sig)
            if replaceable(current):
                signal.signal(sig, handler)
                before[sig] = current
        except (ValueError, OSError):  # not the main thread of the interpreter (embedded, some workers)
            pass
    return before


def _restore(before: dict) -> None:
    for sig, handler in before.items():
        try:
            signal.signal(sig, handler)
        except (ValueError, OSError):
            pass


@contextmanager
def interrupts_as_keyboard_interrupt():
    """While the block runs, SIGINT and SIGTERM raise KeyboardInterrupt (outside llvmlite's callbacks); then the handlers are restored."""
    before = _set_handlers(_interrupt, _replaceable)
    _last_signal.clear()
    try:
        yield
    finally:
        _restore(before)


@contextmanager
def interrupts_held():
    """While the block runs, SIGINT and SIGTERM wait; when it ends, the first one that came acts as usual.

    For the few file operations that must finish whole once begun: putting back the files a failed
    write replaced (:func:`mocapkit.io.outputs.put_back`), a folder swapped for its new version. A
    second Ctrl-C must not cut them in two. Only the main thread can hold signals; elsewhere the block
    runs as it is (a worker thread never receives them in Python).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []

    def hold(signum, frame):
        pending.append(signum)

    before = _set_handlers(hold, lambda current: current not in (signal.SIG_IGN, None))  # ignored stays ignored
    try:
        yield
    finally:
        _restore(before)
        if pending:
            signal.raise_signal(pending[0])  # delivered now, to the handler the block found
