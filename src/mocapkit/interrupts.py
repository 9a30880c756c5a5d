"""Interrupts: SIGINT and SIGTERM end a command as ``KeyboardInterrupt``, so every atomic write cleans up.

Python turns SIGINT into ``KeyboardInterrupt`` but dies at once on SIGTERM, which leaves a
command's hidden ``.part`` files behind; :func:`interrupts_as_keyboard_interrupt` makes both
raise it. One place is unsafe for any exception: numba's JIT cache calls Python back from
LLVM's C++ (llvmlite's object-cache hooks), and an exception raised there cannot unwind through
it: the process crashed with SIGSEGV when Ctrl-C or SIGTERM landed while a kernel was loaded or
compiled. While a frame of llvmlite is on the stack the handler therefore sends the signal again
50 ms later instead of raising, so the interrupt lands right after the callback returns. The same
for numba's ``serialize`` module, which a compiled kernel calls back as it runs: an interrupt raised
there came out as a ``SystemError`` (a batch took the take for failed and went on).

The same holds in the ``with`` statement's hand-over into and out of the generator context managers
that keep outputs whole (:func:`whole_hand_over`: ``removed_on_failure``, ``atomic_write``,
:func:`interrupts_held`): an exception raised in contextlib's own ``__exit__`` before it resumes the
generator leaves the generator suspended, and its clean-up ran later, at garbage collection, after
the command had said what it kept (an interrupted ``train`` said its first checkpoint resumes, then
its put-back removed it). And in a short last step that must run whole once begun (:func:`whole_step`: the
clean-up after a ``removed_on_failure`` block, whose hidden links of the old outputs an interrupt there left).

A closed output stream (``mocapkit info take.bvh | head -1``: the reader gone) ends a command as SIGPIPE ends
``yes | head``, quietly and with status 141; Python ignores SIGPIPE and raises ``BrokenPipeError`` at the write
instead, which the CLI's stream guard turns into this interrupt (:func:`stream_closed`), so that the command
stops as on Ctrl-C: the outputs written are whole, the one being written is removed.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from contextlib import contextmanager

__all__ = ["interrupts_as_keyboard_interrupt", "interrupts_held", "in_native_callback", "whole_hand_over",
           "in_hand_over", "whole_step", "in_whole_step", "exit_status", "stream_closed", "by_closed_stream",
           "RETRY_S"]

RETRY_S = 0.05  # seconds before a deferred signal is sent again


#: the Python code that native code calls back: llvmlite's (LLVM's C++ below it), and numba's ``serialize`` module,
#: which a compiled kernel calls to unpickle its constants (the arguments of an exception it may raise): a
#: KeyboardInterrupt raised there reached the kernel's caller as ``SystemError: CPUDispatcher(...) returned a
#: result with an exception set``, which a batch took for a failed take and went on
_CALLBACK_FILES = (f"{os.sep}llvmlite{os.sep}", f"{os.sep}numba{os.sep}core{os.sep}serialize.py")


def in_native_callback(frame) -> bool:
    """True while ``frame`` or any of its callers runs Python code that native code called (:data:`_CALLBACK_FILES`:
    llvmlite's, numba's ``serialize``), where an exception cannot unwind as one."""
    while frame is not None:
        name = frame.f_code.co_filename
        if any(part in name for part in _CALLBACK_FILES):
            return True
        frame = frame.f_back
    return False


_HAND_OVERS: set = set()  # code objects of the generator functions given to whole_hand_over


def whole_hand_over(generator_function):
    """Mark a generator function (made a context manager with ``contextlib.contextmanager``) whose hand-over an
    interrupt must not land in; returns it unchanged.

    A signal that comes while contextlib's ``__enter__`` or ``__exit__`` of such a context manager runs its
    own code (the steps between the ``with`` block and the generator) is sent again :data:`RETRY_S` later, as
    one in llvmlite's callbacks is: it lands in the generator (whose ``try`` puts the outputs back) or after
    the block, never between the two, where it would leave the generator suspended and its clean-up to
    garbage collection.
    """
    _HAND_OVERS.add(generator_function.__code__)
    return generator_function


def in_hand_over(frame) -> bool:
    """True while ``frame`` is contextlib's ``__enter__`` or ``__exit__`` of a :func:`whole_hand_over` context
    manager (only that frame: the generator's own code, below it, handles an interrupt itself)."""
    code = frame.f_code
    if code.co_name not in ("__enter__", "__exit__") or code.co_filename != contextlib.__file__:
        return False
    generator = getattr(frame.f_locals.get("self"), "gen", None)
    return getattr(generator, "gi_code", None) in _HAND_OVERS


_WHOLE_STEPS: set = set()  # code objects of the functions given to whole_step


def whole_step(function):
    """Mark a short function that must run to its end once called (a few file names removed, context variables
    set back); returns it unchanged.

    A signal that comes while it, or anything it calls, runs is sent again :data:`RETRY_S` later, as one in
    llvmlite's callbacks is, so it lands after the function has returned. For clean-up in a ``finally``:
    :func:`interrupts_held` cannot guard it, since entering that ``with`` runs Python code (contextlib's, its
    own) where an interrupt still lands and cuts the clean-up off before it began. A call is a signal check
    only once the called function runs, so the step is guarded from its first line.
    """
    _WHOLE_STEPS.add(function.__code__)
    return function


def in_whole_step(frame) -> bool:
    """True while ``frame`` or any of its callers runs a :func:`whole_step` function."""
    while frame is not None:
        if frame.f_code in _WHOLE_STEPS:
            return True
        frame = frame.f_back
    return False


_last_signal: list[int] = []  # the signal that raised the last KeyboardInterrupt here (exit_status)


def _interrupt(signum, frame):
    if in_native_callback(frame) or (frame is not None and (in_hand_over(frame) or in_whole_step(frame))):
        timer = threading.Timer(RETRY_S, os.kill, (os.getpid(), signum))
        timer.daemon = True
        timer.start()
        return
    _last_signal[:] = [signum]
    raise KeyboardInterrupt(f"signal {signum}")


def stream_closed() -> KeyboardInterrupt:
    """The interrupt that ends a command whose output stream was closed by its reader (module docstring): recorded
    as SIGPIPE's (:func:`exit_status` 141, :func:`by_closed_stream` True), returned for the caller to raise."""
    _last_signal[:] = [int(signal.SIGPIPE)]
    return KeyboardInterrupt("output stream closed")


def by_closed_stream() -> bool:
    """Whether the last interrupt came from a closed output stream (:func:`stream_closed`): said by nothing, as
    SIGPIPE's is not."""
    return _last_signal[:1] == [int(signal.SIGPIPE)]


def exit_status() -> int:
    """The exit status of a command an interrupt ended: 128 + the signal's number, as a shell reports a process the
    signal ended (130 for Ctrl-C, 143 for SIGTERM, what a scheduler that stopped it expects); 130 for an interrupt
    no signal of ours raised; 141 for a closed output stream (SIGPIPE's, :func:`stream_closed`)."""
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
@whole_hand_over
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
