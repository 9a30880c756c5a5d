"""Serial and parallel twins of a numba kernel: two compilations of one Python body, chosen by problem size.

A kernel whose outer loop is a ``prange`` can be compiled with
``parallel=True`` (the loop split over numba's threads) or without (``prange``
is then ``range``). The parallel build pays on long takes but costs about
twice the compile time and a thread start per call, which small problems (a
few seconds of motion, a word against a word) never earn back; so each kernel
is compiled both ways and :meth:`Twins.pick` takes the serial twin below a
size threshold and the parallel one from it on.

A parallel twin that is neither compiled in this process nor in numba's
on-disk cache costs its compilation (seconds) on top of the work, which a
single call earns back only on a very large problem. Until it is ready, the
serial twin runs below ``COLD_FACTOR`` times the threshold: a first clean
with an empty cache (a bundled walk against the default context is above
the thresholds) compiles only the serial twins, and ``python -m
mocapkit.warmup`` (run at install) compiles and caches both, after which the
size alone decides. Either twin gives the same result, bit for bit.

numba's on-disk cache names its index files after the function's
``__qualname__`` and first line, and keys entries by signature and bytecode,
not by the ``parallel`` flag: two dispatchers of one function object would
load each other's machine code. The parallel twin is therefore a copy of the
function (same code, globals, defaults and closure) whose ``__qualname__``
ends in ``__parallel``.

:func:`forced` makes every twin take one side inside a block, whatever the
size: :mod:`mocapkit.warmup` uses it to compile the parallel twins on a short
take, and the tests to compare the two.
"""

from __future__ import annotations

import sys
import threading
import types
from contextlib import contextmanager

from numba import njit

__all__ = ["Twins", "twin_kernels", "forced", "on_disk", "start_threads", "PARALLEL_SUFFIX", "COLD_FACTOR"]

PARALLEL_SUFFIX = "__parallel"
# A parallel twin not yet compiled runs only from COLD_FACTOR x its threshold: the thresholds sit near
# 3-10 ms of serial work, so this is 6-20 s of serial work, about what compiling the parallel twin costs.
COLD_FACTOR = 2000
_forced: list[str | None] = [None]  # "serial", "parallel" or None (by size)
_started = [False]  # whether numba's thread pool was started here (start_threads)


class Twins:
    """A serial and a parallel numba dispatcher of one kernel and the problem size from which the parallel one runs."""

    __slots__ = ("serial", "parallel", "threshold", "__name__", "_ready")

    def __init__(self, serial, parallel, threshold: int):
        self.serial = serial
        self.parallel = parallel
        self.threshold = int(threshold)
        self.__name__ = serial.py_func.__name__
        self._ready = False

    def parallel_ready(self) -> bool:
        """Whether the parallel twin runs without compiling: compiled in this process, or in numba's disk cache
        (:func:`on_disk`; where that cannot be told the twin counts as ready)."""
        if self._ready or self.parallel.overloads or on_disk(self.parallel) is not False:
            self._ready = True
        return self._ready

    def pick(self, size: int):
        """The dispatcher for a problem of ``size`` (the kernel's own work measure): parallel from ``threshold`` on
        (from ``COLD_FACTOR * threshold`` while the parallel twin is not compiled or cached, see the module docstring).

        Only the main thread runs the parallel twin: a kernel called from a worker thread (a Dask
        worker runs its tasks in a thread pool, beside the other workers' processes) gets the serial
        one, since numba's thread pool launched from such threads ran 15-30x slower than serial
        code on a 2-core machine, where the other workers already keep the cores busy.
        """
        side = _forced[0]
        if side == "serial":
            return self.serial
        if side == "parallel":
            start_threads()
            return self.parallel
        if threading.current_thread() is not threading.main_thread() or size < self.threshold:
            return self.serial
        if size >= COLD_FACTOR * self.threshold or self.parallel_ready():
            start_threads()
            return self.parallel
        return self.serial

    def __repr__(self) -> str:
        return f"<Twins {self.__name__} parallel from size {self.threshold}>"


def start_threads() -> None:
    """Start numba's thread pool (once per process) before a parallel twin runs, leaving torch's thread count as
    the caller set it.

    Started by the first parallel kernel itself, numba's OpenMP pool set the process's OpenMP thread count to
    the core count, which torch (sharing that OpenMP runtime) then reported and used: a caller's
    ``torch.set_num_threads(1)`` was undone by the first ``clean`` that ran a parallel twin. Started here
    (``numba.get_num_threads`` starts it), with torch's count put back if it moved, later kernels leave it alone.
    torch is not imported here: only a caller that imported it has a count to keep.
    """
    if _started[0]:
        return
    import numba

    torch = sys.modules.get("torch")
    threads = torch.get_num_threads() if torch is not None else None
    try:
        numba.get_num_threads()
    finally:
        _started[0] = True
        if threads is not None and torch.get_num_threads() != threads:
            torch.set_num_threads(threads)


def on_disk(dispatcher) -> bool | None:
    """Whether numba's disk cache holds machine code of ``dispatcher`` (a numba dispatcher) for the current source.

    Read from the dispatcher's cache index (one file per function, listing the
    compiled signatures, void when the source changed since): True when it
    lists one, False when it is missing, stale or empty, None where numba's
    cache object is not there to ask (caching off, another numba).
    """
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    load_index = getattr(cache_file, "_load_index", None)
    if load_index is None:
        return None
    try:
        return bool(load_index())
    except Exception:  # an unreadable index: numba compiles again, as for a missing one
        return False


def twin_kernels(threshold: int, **options):
    """Decorator: compile the function as :class:`Twins` (``njit(cache=True, **options)``, and with ``parallel=True``).

    ``threshold`` is the problem size (in the unit the caller passes to
    :meth:`Twins.pick`) from which the parallel twin runs.
    """

    def make(func):
        serial = njit(cache=True, **options)(func)
        copy = types.FunctionType(func.__code__, func.__globals__, func.__name__ + PARALLEL_SUFFIX,
                                  func.__defaults__, func.__closure__)
        copy.__qualname__ = func.__qualname__ + PARALLEL_SUFFIX
        copy.__module__ = func.__module__
        copy.__doc__ = func.__doc__
        copy.__kwdefaults__ = func.__kwdefaults__
        parallel = njit(cache=True, parallel=True, **options)(copy)
        return Twins(serial, parallel, threshold)

    return make


@contextmanager
def forced(side: str | None):
    """Inside the block every :class:`Twins` picks ``side`` ("serial" or "parallel"; None: by size again)."""
    if side not in ("serial", "parallel", None):
        raise ValueError(f"side must be 'serial', 'parallel' or None, got {side!r}")
    before = _forced[0]
    _forced[0] = side
    try:
        yield
    finally:
        _forced[0] = before
