"""Compile the numba kernels of ``clean``'s later steps in a helper process while its first steps run.

numba compiles a kernel the first time it is called, in the calling thread
and under one lock per process, and with ``cache=True`` keeps the machine code
in its disk cache. With an empty cache (the first ``clean`` after a plain
``pip install``, or after an upgrade changed the sources) a clean of a short
take spends most of its time compiling, one kernel after the other, on one
core. :func:`start` launches ``python -m mocapkit.cleaning.precompile`` beside
it, which compiles, in the order ``clean`` reaches them, the kernels that
come after the start of detect: the ordering and row kernels the kNN search
calls, the row minima of the word-DTW lower bound, the MDM's timing-tolerant
angles, repair's warp and robust means and the EBF's risk terms, and writes
them to the same disk cache. When ``clean`` reaches a kernel the helper has
finished, numba loads it from the cache instead of compiling it; one the
helper has not finished ``clean`` compiles itself, as it would have alone.
Either way the machine code comes from the same source with the same
argument types, so the results are the same bit for bit. numba's cache is
made to be shared by processes (files are written whole under a temporary
name and renamed into place).

The helper compiles only the kernels of the steps asked for
(:func:`kernels_for`; ``mocapkit detect`` starts it for detection's). It
starts only where it can help: the word-DTW row kernel has no machine code
for the current source in the cache
(:func:`mocapkit.cleaning.ssa.twins.on_disk`), the process was not itself
started by :mod:`multiprocessing` (a worker of ``clean-batch`` or of a Dask
cluster: the other workers keep the cores busy), at least two cores are
available, and ``MOCAPKIT_PRECOMPILE`` is not ``0``. It has no terminal
input or output and writes nothing but numba's cache. It does not outlive
the command: when the process that started it exits with the helper still
compiling (a kernel ``clean`` did not need, or a run cut short), the helper
is stopped (a file numba was writing is left under a temporary name, never
half-written under its own), and it shares the command's process group, so
an interrupt from the terminal stops both; only a command killed outright
leaves it running, to the end of the kernel it is compiling.

The kernels are compiled through their public wrappers on tiny inputs (which
fix the argument types as ``clean``'s calls do) or, for kernels only other
kernels call, with the argument types those calls pass. A test checks that a
``clean`` of the bundled take after the helper ran compiles none of these
kernels again.
"""

from __future__ import annotations

import atexit
import multiprocessing
import os
import subprocess
import sys
from collections.abc import Callable

import numpy as np

from ..rotations import identity

__all__ = ["compile_kernels", "kernels_for", "needed", "start", "KERNELS"]

# About in the order clean first calls them on a take; the kNN search's callees come first, as clean compiles
# the row minima (0.5 s) before the helper has started, and the callees a second or two later.
KERNELS = ("knn_callees", "row_minima", "shift_angles", "warp", "robust_means", "risk_terms")
_STEP = {"knn_callees": "detect", "row_minima": "detect", "shift_angles": "detect", "warp": "repair",
         "robust_means": "repair", "risk_terms": "denoise"}
_started: list = []  # the helper this process started (kept so that it is not garbage-collected while it runs)


def _row_minima() -> None:
    from .ssa.word_dtw import word_dtw_lower_bounds

    D = np.zeros((15, 20), dtype=np.float32)  # the pose distances, float32 as the search computes them
    word_dtw_lower_bounds(D, np.zeros(0, dtype=np.int64), np.zeros(1, dtype=np.int64))


def _knn_callees() -> None:
    from numba import types

    from .ssa.dtw_rows import word_dtw_rows
    from .ssa.ordering import kth_smallest, sort_by_key

    i8, f8 = types.int64, types.float64
    kth_smallest.compile((f8[::1], i8, f8[::1]))
    sort_by_key.compile((i8[::1], f8[::1], i8[::1]))
    word_dtw_rows.compile((types.float32[:, ::1], i8, i8, i8, i8, i8, i8, f8[:, :, ::1], i8[:, :, ::1], f8[::1],
                           i8[::1]))


def _warp() -> None:
    from .ssa.word_dtw import warp_target_words

    S = identity((20, 2))
    members = np.arange(2)
    warp_target_words(S, S, members, 0, [0], [0], costs=np.zeros((20, 20), dtype=np.float32))


def _robust_means() -> None:
    from .ssa.word_means import robust_word_means

    robust_word_means(identity((1, 2, 15, 2)), np.ones((1, 2), dtype=bool), 0.1)


def _shift_angles() -> None:
    from .ssa.word_means import shift_tolerant_angles

    q = identity((4, 2))
    shift_tolerant_angles(q, q, 1)


def _risk_terms() -> None:
    from .deep.sure import risk_terms

    F, C, half = 8, 2, 3
    risk_terms(np.zeros((F + 2 * half, C), dtype=np.float32), np.zeros((F, C), dtype=np.float32),
               np.ones((F, C), dtype=bool), [0, F], [0.0, 0.5 * np.log(2.0)], half)


_COMPILE: dict[str, Callable[[], None]] = {
    "row_minima": _row_minima, "knn_callees": _knn_callees, "warp": _warp, "robust_means": _robust_means,
    "shift_angles": _shift_angles, "risk_terms": _risk_terms,
}


def kernels_for(steps) -> tuple[str, ...]:
    """The names of :data:`KERNELS` that ``steps`` (clean's step names: "detect", "repair", "denoise") call."""
    return tuple(name for name in KERNELS if _STEP[name] in steps)


def compile_kernels(names=KERNELS, stop: Callable[[], bool] = lambda: False) -> list[str]:
    """Compile (or load from numba's disk cache) the kernels ``names`` (of :data:`KERNELS`), in that order.

    ``stop`` is asked before each; once it returns True the rest are left out.
    Returns the names done.
    """
    done = []
    for name in names:
        if stop():
            break
        _COMPILE[name]()
        done.append(name)
    return done


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def needed() -> bool:
    """Whether :func:`start` would launch the helper now (the module docstring's conditions)."""
    from .ssa.dtw_rows import word_dtw_rows
    from .ssa.twins import on_disk

    return (os.environ.get("MOCAPKIT_PRECOMPILE", "1") != "0" and not _started
            and multiprocessing.parent_process() is None and _cores() >= 2 and on_disk(word_dtw_rows) is False)


def start(names=KERNELS) -> subprocess.Popen | None:
    """Launch the helper process to compile ``names`` (of :data:`KERNELS`) when :func:`needed`; returns it, or None
    when it was not needed.

    The helper inherits the environment (``NUMBA_CACHE_DIR`` included, so
    both processes use one cache), imports this copy of mocapkit (its folder
    first on ``PYTHONPATH``) and is told this process's id, to stop once it
    has ended; this process stops it at exit if it is still running.
    """
    unknown = set(names) - set(KERNELS)
    if unknown:
        raise ValueError(f"unknown kernels {sorted(unknown)}; expected some of {KERNELS}")
    if not needed():
        return None
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # the folder holding mocapkit
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [here, os.environ.get("PYTHONPATH")]))}
    try:
        helper = subprocess.Popen([sys.executable, "-m", __name__, str(os.getpid()), *names], env=env,
                                  stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except OSError:  # the interpreter cannot be started again here (a worker run as another user): compile in place
        return None
    _started.append(helper)
    atexit.register(_stop, helper)
    return helper


def _stop(helper: subprocess.Popen) -> None:
    """At exit: end the helper if it is still compiling (module docstring)."""
    if helper.poll() is None:
        helper.terminate()
        try:
            helper.wait(timeout=2.0)
        except subprocess.TimeoutExpired:
            helper.kill()
            helper.wait()


def main(argv=None) -> int:
    """``python -m mocapkit.cleaning.precompile [PARENT_PID [NAME ...]]``: compile the kernels NAME (default
    :data:`KERNELS`), stopping once the process PARENT_PID is no longer this one's parent."""
    argv = sys.argv[1:] if argv is None else argv
    parent = int(argv[0]) if argv else None
    compile_kernels(argv[1:] or KERNELS, stop=lambda: parent is not None and os.getppid() != parent)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
