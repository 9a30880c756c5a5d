"""Running one function over many inputs: local processes by default, a Dask cluster when configured.

Batch work over a corpus (building a database, cleaning a folder) goes
through :func:`map_ordered`. ``executor`` chooses where it runs:

* ``None`` or ``"processes"``: a local :class:`~concurrent.futures.ProcessPoolExecutor`
  (one worker per core; in-process when there is a single input or core);
* ``"serial"``: in this process, one after another (debugging, tiny jobs);
* ``"dask"``: a local Dask cluster started for the job (``pip install "dask[distributed]"``);
* a scheduler address such as ``"tcp://10.0.0.5:8786"``: that Dask cluster;
* an object with ``submit`` (a :class:`concurrent.futures.Executor`, a
  ``distributed.Client``, a Ray ``ray.util.ActorPool``-like wrapper): used as is.

Results come back in input order; progress is shown with tqdm. An
interrupt (Ctrl-C) cancels what has not started and re-raises.
"""

from __future__ import annotations

import os
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from typing import Callable, Sequence

from tqdm.auto import tqdm

__all__ = ["map_ordered", "describe_executor"]


def describe_executor(executor) -> str:
    """A short human-readable name of where :func:`map_ordered` will run."""
    if executor is None or executor == "processes":
        return f"local processes ({os.cpu_count() or 1} cores)"
    if isinstance(executor, str):
        return "this process" if executor == "serial" else f"dask ({executor})"
    return type(executor).__name__


def _is_dask_client(executor) -> bool:
    return type(executor).__module__.startswith("distributed")


def map_ordered(
    fn: Callable,
    items: Sequence,
    executor=None,
    progress: bool = True,
    desc: str | None = None,
    max_workers: int | None = None,
) -> list:
    """``[fn(item) for item in items]``, run on ``executor`` (see the module docstring), in input order.

    ``fn`` and the items must be picklable for anything but ``"serial"``.
    The first exception raised by ``fn`` is re-raised here after the
    remaining work is cancelled.

    >>> map_ordered(abs, [-1, 2, -3], executor="serial", progress=False)
    [1, 2, 3]
    """
    items = list(items)
    n = len(items)
    if n == 0:
        return []
    bar = tqdm(total=n, desc=desc, disable=not progress, unit="item", leave=False)
    try:
        if executor == "serial" or (executor in (None, "processes") and (n == 1 or (max_workers or os.cpu_count() or 1) == 1)):
            out = []
            for it in items:
                out.append(fn(it))
                bar.update(1)
            return out
        if executor in (None, "processes"):
            workers = min(n, max_workers or os.cpu_count() or 1)
            with ProcessPoolExecutor(max_workers=workers) as pool:
                return _run(pool, fn, items, bar, as_completed)
        if isinstance(executor, str):
            return _run_dask(executor, fn, items, bar)
        if _is_dask_client(executor):
            from distributed import as_completed as dask_as_completed

            return _run(executor, fn, items, bar, dask_as_completed)
        if isinstance(executor, Executor) or hasattr(executor, "submit"):
            return _run(executor, fn, items, bar, as_completed)
        raise ValueError(f"executor: expected None, 'processes', 'serial', 'dask', a scheduler address or an executor, got {executor!r}")
    finally:
        bar.close()


def _run(pool, fn, items, bar, completed) -> list:
    futures = {pool.submit(fn, it): k for k, it in enumerate(items)}
    out: list = [None] * len(items)
    try:
        for fut in completed(list(futures)):
            out[futures[fut]] = fut.result()
            bar.update(1)
    except BaseException:
        for fut in futures:
            fut.cancel()
        raise
    return out


def _run_dask(spec: str, fn, items, bar) -> list:
    try:
        from distributed import Client, LocalCluster, as_completed as dask_as_completed
    except ImportError:
        raise ImportError('a Dask executor needs dask: pip install "dask[distributed]"') from None
    if spec == "dask":
        with LocalCluster(n_workers=os.cpu_count() or 1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            with Client(cluster) as client:
                return _run(client, fn, items, bar, dask_as_completed)
    with Client(spec) as client:
        return _run(client, fn, items, bar, dask_as_completed)
