"""Offline inference on two cores with the same result on every run: fixed row parts, one torch thread each.

Why not torch's own threads: with two intra-op threads the EBD's and EBF's
results varied in their last bits from process to process (about one run in
seven of a 60 s take's fill on a 2-core machine), so the same take cleaned
twice could differ. In one thread they are the same on every run. The work
that dominates offline inference is row-parallel by nature (the EBD's windows,
the EBF's look-ahead runs, one per output frame: Mall et al. 2017, section 3),
and a row's result does not depend on which other rows share its batch, so
:func:`run_in_parts` cuts the rows into :data:`INFERENCE_PARTS` fixed
contiguous parts (fixed: never chosen from the machine or its load) and runs
them concurrently, each in one torch thread. The result is the one a single
thread gives, bit for bit (tests/cleaning/test_threads.py), on a machine with
one core or many.
"""

from __future__ import annotations

import ctypes
import os
import sys
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import Callable, TypeVar

import torch

__all__ = ["INFERENCE_THREADS", "INFERENCE_PARTS", "MIN_PART_ROWS", "torch_threads", "part_bounds", "run_in_parts",
           "release_freed_memory", "RELEASE_FRAMES"]

INFERENCE_THREADS = 1
"""Torch intra-op threads of offline inference: one (with two, the results' last bits varied from run to run;
see the module docstring)."""

INFERENCE_PARTS = 2
"""Row parts offline inference runs concurrently, each in its own thread with :data:`INFERENCE_THREADS`."""

MIN_PART_ROWS = 512
"""Fewer rows than this per part are not worth a thread (a part's start costs about 0.1 ms)."""

T = TypeVar("T")

_POOL: list[tuple[int, ThreadPoolExecutor]] = []  # (workers, pool): made on first use, its threads reused
# A forked child (a local process pool of clean-batch) inherits the pool but not its threads: it would queue
# work for threads that do not exist there, so the child starts without one.
os.register_at_fork(after_in_child=_POOL.clear)


@contextmanager
def torch_threads(threads: int = INFERENCE_THREADS):
    """Run torch in ``threads`` intra-op threads inside the block (default :data:`INFERENCE_THREADS`),
    restoring the thread count after."""
    n = torch.get_num_threads()
    torch.set_num_threads(int(threads))
    try:
        yield
    finally:
        torch.set_num_threads(n)


def part_bounds(n: int, parts: int = INFERENCE_PARTS, min_rows: int = MIN_PART_ROWS) -> list[tuple[int, int]]:
    """``[(lo, hi), ...]``: ``range(n)`` cut into at most ``parts`` contiguous parts of at least ``min_rows``
    rows (one part when ``n < 2 min_rows``); a function of its arguments only."""
    k = max(1, min(int(parts), int(n) // max(int(min_rows), 1)))
    edges = [round(i * n / k) for i in range(k + 1)]
    return [(edges[i], edges[i + 1]) for i in range(k)]


def _pool(workers: int) -> ThreadPoolExecutor:
    if not _POOL or _POOL[0][0] < workers:
        if _POOL:
            _POOL[0][1].shutdown(wait=False)  # a bigger one replaces it; its idle threads end
        _POOL[:] = [(workers, ThreadPoolExecutor(max_workers=workers, thread_name_prefix="mocapkit-inference"))]
    return _POOL[0][1]


def run_in_parts(fn: Callable[[int, int], T], n: int, parts: int = INFERENCE_PARTS,
                 min_rows: int = MIN_PART_ROWS) -> list[T]:
    """``[fn(lo, hi) for (lo, hi) in part_bounds(n, parts, min_rows)]``, the parts run concurrently.

    The first part runs in the calling thread, the others in worker threads
    that run torch in :data:`INFERENCE_THREADS` thread(s) under the caller's
    grad and inference modes (both are per thread in torch). ``fn`` must
    only read shared tensors. An exception in any part is raised here after
    every part has finished.
    """
    bounds = part_bounds(n, parts, min_rows)
    if len(bounds) == 1:
        return [fn(*bounds[0])]
    inference, grad = torch.is_inference_mode_enabled(), torch.is_grad_enabled()

    def worker(lo: int, hi: int) -> T:
        torch.set_num_threads(INFERENCE_THREADS)  # OpenMP's thread count is per thread: set it in this one
        with torch.inference_mode(inference), torch.set_grad_enabled(grad):
            return fn(lo, hi)

    futures = [_pool(len(bounds) - 1).submit(worker, lo, hi) for lo, hi in bounds[1:]]
    try:
        first = fn(*bounds[0])
    finally:
        rest = [f.result() if f.exception() is None else f for f in futures]  # waits for every part
    for f in futures:
        if f.exception() is not None:
            raise f.exception()
    return [first] + rest


#: Frames (at the network's rate) from which :func:`release_freed_memory` runs after a network's pass over a take:
#: below it, handing pages back costs more time than the memory it saves (the next step faults them in again).
#: ``mocapkit clean`` of a 60 s 120 fps take (7,200 frames) ran 2 % slower with it, side by side; ``mocapkit
#: fill`` of a 4.5-minute 30 fps session (8,100 frames) peaks 35 MB higher without it, of 18 minutes (32,400
#: frames) about 0.1 GB lower with it.
RELEASE_FRAMES = 10_000


def release_freed_memory() -> bool:
    """Hand the C heap's freed pages back to the system (glibc's ``malloc_trim(0)``); True when some were.

    Why: a long take's arrays of a few to 30 MB (a channel array of an 18-minute 30 fps take is 16 MB) are freed
    into glibc's heaps, which keep them (its mmap threshold rises to the largest block freed, up to 32 MB), and
    the inference threads of :func:`run_in_parts` each free into an arena of their own. After the EBF's run on
    such a take the process held about 240 MB it no longer used, under the gap prior's arrays that came next:
    ``mocapkit fill`` of an 18-minute Bandai Namco session peaked at 0.92 GB, with this after the run 0.80 GB.
    Only memory changes hands: every number is the same. Where the C library has no ``malloc_trim`` (not
    Linux, or musl) it does nothing and returns False."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        trim = ctypes.CDLL(None).malloc_trim
    except (OSError, AttributeError):
        return False
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return bool(trim(0))
