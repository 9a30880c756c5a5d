"""Running one function over many inputs: local processes by default, a Dask cluster when configured.

Batch work over a corpus (building a database, cleaning a folder) goes
through :func:`map_ordered`. ``executor`` chooses where it runs:

* ``None`` or ``"processes"``: a local :class:`~concurrent.futures.ProcessPoolExecutor`
  (one worker per core; in-process when there is a single input or core);
* ``"serial"``: in this process, one after another (debugging, tiny jobs);
* ``"dask"``: a local Dask cluster started for the job (``pip install "mocapkit[dask]"``);
* a scheduler address such as ``"tcp://10.0.0.5:8786"``: that Dask cluster;
* an object with ``submit`` (a :class:`concurrent.futures.Executor`, a
  ``distributed.Client``, a Ray ``ray.util.ActorPool``-like wrapper): used as is.

Results come back in input order; progress is shown with tqdm. An
``on_result`` callback sees each result in this process as soon as it is
done (completion order), and may stop the work: a log then holds every
finished item even if the run is cut short. An interrupt (Ctrl-C) cancels
what has not started and re-raises.

:func:`check_executor` refuses anything else in one line
(:class:`~mocapkit.errors.MocapError`) before any work starts; a scheduler
address is probed first (connect and read the scheduler's opening handshake,
at most 64 KiB, within a few seconds), so an unreachable address or a peer
that does not speak the Dask protocol fails fast instead of hanging or
allocating what a junk length prefix asks for.

**Work dies with the process that handed it out.** Local worker processes
get a parent-death signal (``prctl(PR_SET_PDEATHSIG, SIGKILL)`` on Linux) and
a watcher thread that kills the worker once its parent pid changes (every
platform); the workers of a local Dask cluster are children of this process
and Dask stops them with it. Work that writes files calls :func:`owner_alive`
right before each final rename and writes nothing once it is false: in a
local worker, the parent is gone; in a Dask task, the scheduler has released
the task because the client that submitted it went away (a remote cluster's
workers live on). Work handed to an executor object given by the caller is
not watched; there :func:`owner_alive` is always true.

A SIGTERM that someone else sends to a local worker (``kill <worker pid>``)
is passed on to this process, where the work ends as if it had been sent here;
one this process's own pool sends to stop its workers never comes back to it
(on Linux and the BSDs, where a worker can tell who sent it).
"""

from __future__ import annotations

import os
import re
import signal
import socket
import struct
import sys
import threading
import time
from concurrent.futures import FIRST_COMPLETED, CancelledError, Executor, ProcessPoolExecutor, as_completed, wait
from contextlib import contextmanager
from concurrent.futures.process import BrokenProcessPool
from typing import Callable, Sequence

from tqdm.auto import tqdm
from .progress import bar_disabled, bar_size

from .errors import MocapError
from .interrupts import interrupts_held

__all__ = ["map_ordered", "describe_executor", "check_executor", "check_jobs", "executor_said", "owner_alive", "unblock_sigterm"]

EXECUTOR_NAMES = ("processes", "serial", "dask")
_ADDRESS_RE = re.compile(r"^tcp://(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(?P<port>[0-9]{1,5})/?$")
_ACCEPTED = "processes, serial, dask or a Dask scheduler address tcp://HOST:PORT"
_HANDSHAKE_MAX = 64 * 1024  # bytes of the scheduler's opening message the probe will read
_PROBE_S = 5.0  # seconds the whole probe (name lookup, connect, handshake) may take
_WATCH_S = 0.5  # seconds between a local worker's checks of its parent pid
_OWNER_PID: int | None = None  # set in local pool workers: the pid of the process that started them
_FORWARD_S = 0.5  # seconds a local worker waits before passing a SIGTERM it took on to the process that started it


def describe_executor(executor, max_workers: int | None = None) -> str:
    """A short human-readable name of where :func:`map_ordered` will run; ``max_workers``: the local processes
    it may use at once (:func:`check_jobs`; one runs the work in this process, as :func:`map_ordered` does)."""
    if executor is None or executor == "processes":
        cores = os.cpu_count() or 1
        if max_workers == 1 or cores == 1:
            return "this process" if max_workers == 1 else "local processes (1 core)"
        return f"local processes ({max_workers} at once, {cores} cores)" if max_workers else f"local processes ({cores} cores)"
    if isinstance(executor, str):
        return "this process" if executor == "serial" else f"dask ({executor})"
    return type(executor).__name__


def executor_said(option: str, spec=None) -> str:
    """The executor option as the caller gave it, for a refusal: ``option`` is the command line's ``--executor``
    (``--executor tcp://HOST:PORT``) or Python's keyword ``executor=`` (``executor='tcp://HOST:PORT'``); without
    ``spec`` the option alone."""
    if spec is None:
        return option
    return f"{option}{spec!r}" if option.endswith("=") else f"{option} {spec}"


def check_jobs(jobs, executor, option: str = "jobs=", executor_option: str = "executor=") -> None:
    """Refuse, in one line naming ``option``, a number of local processes ``jobs`` that is not a whole number
    of at least 1, or one given with an ``executor`` other than local processes (``None``, ``"processes"``):
    a Dask cluster has its own workers, and ``"serial"`` is one process. None (one process per core) passes."""
    if jobs is None:
        return
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise MocapError(f"{option} must be a whole number of processes, at least 1, got {jobs!r}")
    if executor not in (None, "processes"):
        has = "cleans one take at a time in this process" if executor == "serial" else "has workers of its own"
        raise MocapError(f"{option} sets how many local processes clean at once; {executor_option} {executor} "
                         f"{has} (leave out one of the two)")


def check_executor(executor, timeout: float = _PROBE_S, option: str = "executor="):
    """Return ``executor`` if :func:`map_ordered` can run on it; else raise :class:`MocapError` in one line.

    Accepted: ``None``, ``"processes"``, ``"serial"``, ``"dask"`` (needs
    ``distributed`` installed), a scheduler address ``"tcp://HOST:PORT"``, or an
    object with a ``submit`` method (a :class:`concurrent.futures.Executor`, a
    ``distributed.Client``). An address is probed within ``timeout`` seconds:
    it must accept a TCP connection and open with a Dask handshake (read at
    most 64 KiB), so unreachable and non-Dask peers are refused here. ``option``: how a refusal names the option,
    as the caller gave it (:func:`executor_said`): Python's ``executor=`` or the command line's ``--executor``.

    >>> check_executor("serial")
    'serial'
    >>> try:
    ...     check_executor("garbage")
    ... except MocapError as exc:
    ...     print(exc)
    executor='garbage': expected processes, serial, dask or a Dask scheduler address tcp://HOST:PORT
    >>> try:
    ...     check_executor("garbage", option="--executor")
    ... except MocapError as exc:
    ...     print(exc)
    --executor: expected processes, serial, dask or a Dask scheduler address tcp://HOST:PORT, got 'garbage'
    """
    said = executor_said(option, executor) if isinstance(executor, str) else option
    flag = not option.endswith("=")
    if executor is None or executor in ("processes", "serial"):
        return executor
    if isinstance(executor, str):
        if executor == "dask":
            try:
                import distributed  # noqa: F401
            except ImportError:
                raise MocapError(f'{said} needs Dask: pip install "mocapkit[dask]"') from None
            return executor
        match = _ADDRESS_RE.match(executor.strip())
        if match is None:
            raise MocapError(f"--executor: expected {_ACCEPTED}, got {executor!r}" if flag
                             else f"{said}: expected {_ACCEPTED}")
        port = int(match["port"])
        if not 0 < port < 65536:
            raise MocapError(f"{said}: port {port} is out of range (1-65535)")
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise MocapError(f'{said}: a Dask scheduler needs Dask: pip install "mocapkit[dask]"') from None
        _probe_scheduler(said, match["host"].strip("[]"), port, timeout)
        return executor
    if callable(getattr(executor, "submit", None)):
        return executor
    raise MocapError(f"{option}{': expected' if flag else ' expects'} {_ACCEPTED} or an object with submit(), got "
                     f"{type(executor).__name__} {executor!r}")


def _probe_scheduler(said: str, host: str, port: int, timeout: float) -> None:
    """Connect to ``host:port`` and read the opening handshake a Dask server sends; MocapError if it does not, its line
    opening with ``said``, the option and address as the caller gave them (:func:`executor_said`)."""
    deadline = time.monotonic() + timeout
    found: list = []

    def lookup():  # getaddrinfo has no timeout of its own: run it where we can stop waiting
        try:
            found.append(socket.getaddrinfo(host, port, type=socket.SOCK_STREAM))
        except OSError as exc:
            found.append(exc)

    worker = threading.Thread(target=lookup, daemon=True)
    worker.start()
    worker.join(timeout)
    if not found:
        raise MocapError(f"{said}: cannot resolve {host!r} within {timeout:g} s")
    if isinstance(found[0], OSError):
        raise MocapError(f"{said}: cannot resolve {host!r} ({found[0].strerror or found[0]})")
    family, kind, proto, _, sockaddr = found[0][0]
    sock = socket.socket(family, kind, proto)
    try:
        sock.settimeout(max(deadline - time.monotonic(), 0.1))
        try:
            sock.connect(sockaddr)
            head = _recv_exactly(sock, 8, deadline)
            (nbytes,) = struct.unpack("<Q", head)
            if not 0 < nbytes <= _HANDSHAKE_MAX:
                raise ValueError(f"its first message announces {nbytes} bytes")
            body = _recv_exactly(sock, nbytes, deadline)
        except (socket.timeout, TimeoutError):
            raise MocapError(f"{said}: no Dask scheduler answered within {timeout:g} s") from None
        except ValueError as exc:
            raise MocapError(f"{said}: not a Dask scheduler ({exc})") from None
        except OSError as exc:
            raise MocapError(f"{said}: cannot connect ({exc.strerror or exc})") from None
        if b"pickle-protocol" not in body:
            raise MocapError(f"{said}: not a Dask scheduler (no Dask handshake)")
    finally:
        sock.close()


def _recv_exactly(sock: socket.socket, n: int, deadline: float) -> bytes:
    chunks, got = [], 0
    while got < n:
        left = deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError
        sock.settimeout(left)
        chunk = sock.recv(min(n - got, 65536))
        if not chunk:
            raise ValueError("it closed the connection before a handshake")
        chunks.append(chunk)
        got += len(chunk)
    return b"".join(chunks)


def owner_alive() -> bool:
    """True while the process that handed out the current work still wants its result.

    Call it right before a final rename: once it is false, write nothing.
    In a local pool worker of :func:`map_ordered`: the parent process is
    alive. In a Dask task: the scheduler still has the task running for a
    client (a client that dies has its tasks cancelled). Elsewhere (this
    process, a caller's own executor): always true.
    """
    if _OWNER_PID is not None:
        return os.getppid() == _OWNER_PID
    if "distributed" in sys.modules:
        try:
            from distributed import get_worker

            worker = get_worker()
        except (ImportError, ValueError):  # not inside a Dask task
            return True
        status = getattr(getattr(worker, "status", None), "name", "running")
        if status not in ("running", "paused"):  # closing: its scheduler (a local cluster's: this batch) is gone
            return False
        key = worker.get_current_task()
        state = getattr(worker, "state", None)
        task = state.tasks.get(key) if state is not None and key is not None else None
        if task is not None:
            return task.state in ("executing", "long-running")
        return key is None  # a task the worker no longer knows has been released
    return True


def _die_with_parent(parent_pid: int) -> None:
    """Pool initializer: this worker ends (SIGKILL) when ``parent_pid``, the process that started it, is gone,
    and ignores SIGINT: on Ctrl-C (sent to the whole process group) the parent stops the pool
    (:func:`_stop_pool`). A worker that raised KeyboardInterrupt itself could die halfway through sending a
    result, and the pool's manager thread then waited for the rest of it for ever, and the exit with it
    (3 of 60 interrupted ``db build`` runs hung at exit). A SIGTERM raises nothing here either
    (:func:`_take_sigterm`): one from someone else is passed on to ``parent_pid``, which ends the work as
    interrupted (exit 143), as a SIGTERM sent to it does; one from ``parent_pid`` itself ends this worker."""
    global _OWNER_PID
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's handler: a SIGTERM that gets here ends the worker
        if hasattr(signal, "pthread_sigmask"):  # forked with SIGINT held back (_run): a pending one is now ignored
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    except (ValueError, OSError):  # not the main thread of this worker: it cannot take its own interrupts either
        pass
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):  # no prctl: the watcher below still works
            pass
    _take_sigterm(parent_pid)
    _OWNER_PID = os.getppid()  # the parent (or, under forkserver, the server that dies with it)
    if _OWNER_PID != parent_pid and not _pid_alive(parent_pid):
        _kill_self()  # the parent died before the death signal was armed
    threading.Thread(target=_watch_parent, name="mocapkit-parent-watch", daemon=True).start()


def _take_sigterm(parent_pid: int) -> None:
    """A worker's SIGTERM acts by its sender; called in the worker's main thread before it starts any thread.

    ``parent_pid`` sends one when its own pool stops workers (``concurrent.futures`` terminates the other
    workers of a pool that a dead worker broke): the worker must then end, and never signal the parent,
    which may be a notebook or a test runner that asked for no SIGTERM and dies of one (and a batch whose
    worker the OOM killer took would exit 143 as interrupted instead of 2). Anyone else's
    (``kill <worker pid>``, a scheduler stopping the process group) is passed on to ``parent_pid``, which
    ends the work as interrupted (exit 143), after :data:`_FORWARD_S`, unless the parent has ended this
    worker by then (it does when the whole group got the signal).

    SIGTERM is blocked in every thread of the worker (threads started later inherit the mask) and one
    thread takes it with ``sigwaitinfo``, which names the sender (``si_pid``). Where ``sigwaitinfo`` is
    missing (macOS, Windows) the sender cannot be known: the worker dies of it (SIG_DFL) and the parent
    reports a worker that ended abruptly.

    A process a work function forks (``os.fork``, a ``multiprocessing`` pool or process of the fork start
    method) starts with SIGTERM as the worker had it before (:func:`unblock_sigterm`, run after every fork in
    the child), so its own ``terminate()`` ends it. A program started by ``subprocess`` (or a ``spawn`` or
    ``forkserver`` start) inherits the blocked SIGTERM: CPython forks and execs those in C, where no Python
    runs in the child before the program (no fork hook; ``preexec_fn`` is the caller's), and unblocking
    SIGTERM in the worker while the work function runs would let a SIGTERM end the worker unseen by the
    thread that names its sender. Stop such a program with SIGKILL (``Popen.kill``), or start it with
    ``preexec_fn=mocapkit.parallel.unblock_sigterm``."""
    if not hasattr(signal, "sigwaitinfo"):
        return
    held = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    if signal.SIGTERM not in held:  # the mask a process forked here would have had
        os.register_at_fork(after_in_child=unblock_sigterm)
    threading.Thread(target=_sigterm_watch, args=(parent_pid,), name="mocapkit-term-watch", daemon=True).start()


def unblock_sigterm() -> None:
    """Unblock SIGTERM in the calling thread: run after each fork in a child of a pool worker (whose blocked
    SIGTERM it would inherit, :func:`_take_sigterm`), or as ``subprocess.Popen(..., preexec_fn=...)`` of a work
    function so that the program it starts can be ended by SIGTERM."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})


def _sigterm_watch(parent_pid: int) -> None:
    """The thread of :func:`_take_sigterm`: takes the worker's SIGTERMs for as long as it lives."""
    forward_at, forwarded = None, False  # when someone else's SIGTERM is to be passed on; whether it was
    while True:
        if forward_at is None:
            info = signal.sigwaitinfo({signal.SIGTERM})
        else:
            info = signal.sigtimedwait({signal.SIGTERM}, max(forward_at - time.monotonic(), 0.0))
        if info is None:  # none from the parent meanwhile: pass it on, once
            forward_at, forwarded = None, True
            if _pid_alive(parent_pid):
                os.kill(parent_pid, signal.SIGTERM)
        elif info.si_pid == parent_pid:
            _kill_self()
        elif forward_at is None and not forwarded:
            forward_at = time.monotonic() + _FORWARD_S


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, but not ours to signal
        return True
    return True


def _watch_parent() -> None:
    while os.getppid() == _OWNER_PID:
        time.sleep(_WATCH_S)
    _kill_self()


def _kill_self() -> None:
    if hasattr(signal, "SIGKILL"):
        os.kill(os.getpid(), signal.SIGKILL)
    os._exit(1)


def _is_dask_client(executor) -> bool:
    return type(executor).__module__.startswith("distributed")


def map_ordered(
    fn: Callable,
    items: Sequence,
    executor=None,
    progress: bool = True,
    desc: str | None = None,
    max_workers: int | None = None,
    done: int = 0,
    on_result: Callable[[int, object], bool | None] | None = None,
    option: str = "executor=",
) -> list:
    """``[fn(item) for item in items]``, run on ``executor`` (see the module docstring), in input order.

    ``fn`` and the items must be picklable for anything but ``"serial"``. ``done``: items of the same
    job the caller already did (the progress bar counts them). ``on_result(index, result)``: called in
    this process as each item finishes, in completion order, with the progress bar cleared while it
    runs (it may print); a true return stops the work: items not started are dropped (their slots
    stay None), items under way on local processes or a ``concurrent.futures`` executor are waited
    for and passed to ``on_result`` too, and on Dask they are cancelled (:func:`owner_alive` turns
    false for them).
    The first exception raised by ``fn`` is re-raised here after the
    remaining work is cancelled. ``executor`` is checked first
    (:func:`check_executor`): a bad one raises :class:`MocapError`, naming it as ``option`` says (Python's
    ``executor=``, or the command line's ``--executor``), as does a Dask cluster that fails under way.

    >>> map_ordered(abs, [-1, 2, -3], executor="serial", progress=False)
    [1, 2, 3]
    """
    check_executor(executor, option=option)
    items = list(items)
    n = len(items)
    if n == 0:
        return []
    bar = tqdm(total=n + done, initial=done, desc=desc, disable=bar_disabled(progress), **bar_size(), unit="item",
               leave=False)
    try:
        if executor == "serial" or (executor in (None, "processes") and (n == 1 or (max_workers or os.cpu_count() or 1) == 1)):
            out = [None] * n
            for k, it in enumerate(items):
                out[k] = fn(it)
                bar.update(1)
                if _tell(on_result, k, out[k]):
                    break
            return out
        if executor in (None, "processes"):
            workers = min(n, max_workers or os.cpu_count() or 1)
            pool = ProcessPoolExecutor(max_workers=workers, initializer=_die_with_parent, initargs=(os.getpid(),))
            try:
                out = _run_windowed(pool, fn, items, bar, workers, on_result=on_result)
                pool.shutdown(wait=True)
            except BrokenProcessPool:
                _stop_pool(pool)
                raise MocapError("a worker process ended abruptly (killed, out of memory, or interrupted while "
                                 "it started); the work was stopped") from None
            except BaseException:  # an interrupt during the shutdown too
                with interrupts_held():  # a second SIGTERM (passed on by a worker) waits until the pool is stopped
                    _stop_pool(pool)
                raise
            return out
        if isinstance(executor, str):
            return _run_dask(executor, fn, items, bar, on_result, executor_said(option, executor))
        if _is_dask_client(executor):
            from distributed import as_completed as dask_as_completed

            return _run(executor, fn, items, bar, dask_as_completed, on_result=on_result)
        return _run(executor, fn, items, bar, as_completed, on_result=on_result)
    finally:
        bar.close()


def _tell(on_result, k: int, result) -> bool:
    """``on_result(k, result)`` with the progress bar cleared meanwhile; True when it asks to stop."""
    if on_result is None:
        return False
    with tqdm.external_write_mode():
        return bool(on_result(k, result))


def _cancelled(fut) -> bool:
    """True for a future that was cancelled (a ``concurrent.futures`` or a Dask one)."""
    return fut.cancelled() if callable(getattr(fut, "cancelled", None)) else getattr(fut, "status", "") == "cancelled"


def _finish_stopped(futures: dict, got: set, out: list, bar, on_result) -> None:
    """After ``on_result`` asked to stop: cancel what has not finished; the items still under way that cannot be
    cancelled (a local worker's) are waited for and passed to ``on_result``, and so is any result already in."""
    for fut, k in futures.items():
        if k not in got and not fut.done():
            fut.cancel()
    for fut, k in futures.items():
        if k in got or _cancelled(fut):
            continue
        try:
            out[k] = fut.result()
        except CancelledError:
            continue
        except Exception as exc:  # a Dask future cancelled meanwhile raises its own kind
            if "Cancelled" in type(exc).__name__:
                continue
            raise
        got.add(k)
        bar.update(1)
        _tell(on_result, k, out[k])


def _run(pool, fn, items, bar, completed, cancel: bool = True, on_result=None) -> list:
    """Submit every item to an executor that is not a local pool (:func:`_run_windowed` is that one's), then gather
    the results in input order (``on_result``: :func:`map_ordered`'s)."""
    futures = {pool.submit(fn, it): k for k, it in enumerate(items)}
    out: list = [None] * len(items)
    got: set = set()
    try:
        for fut in completed(list(futures)):
            k = futures[fut]
            out[k] = fut.result()
            got.add(k)
            bar.update(1)
            if _tell(on_result, k, out[k]):
                _finish_stopped(futures, got, out, bar, on_result)
                break
    except BaseException:
        for fut in futures if cancel else ():
            fut.cancel()
        raise
    return out


def _run_windowed(pool, fn, items, bar, window: int, on_result=None) -> list:
    """:func:`_run` for a local pool, handing it at most ``window`` items (its workers) at a time, the next as each
    finishes. A :class:`ProcessPoolExecutor` moves submitted items into its call queue ahead of its workers, and an
    item there can no longer be cancelled: given every item at once, a stop asked by ``on_result`` (a full disk in a
    batch) would still start the queued ones. Handed out this way, a stop starts nothing new; the items under way
    finish and are passed to ``on_result``, and one handed out that the pool has not yet taken is cancelled. SIGINT is held back while items are handed out, when the pool forks its
    workers: a worker forked with it pending would die of it before its initializer ignores it, breaking the pool;
    this process takes it after."""
    out: list = [None] * len(items)
    got: set = set()
    futures: dict = {}
    pending = iter(enumerate(items))

    def hand_out(n: int) -> set:
        new = set()
        held = _hold_sigint()
        try:
            for _ in range(n):
                nxt = next(pending, None)
                if nxt is None:
                    break
                fut = pool.submit(fn, nxt[1])
                futures[fut] = nxt[0]
                new.add(fut)
        finally:
            if held:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        return new

    live = hand_out(max(1, window))
    while live:
        done, live = wait(live, return_when=FIRST_COMPLETED)
        for fut in done:
            k = futures[fut]
            out[k] = fut.result()
            got.add(k)
            bar.update(1)
            if _tell(on_result, k, out[k]):
                _finish_stopped({f: futures[f] for f in live | done}, got, out, bar, on_result)
                return out
        live |= hand_out(len(done))
    return out


def _hold_sigint() -> bool:
    """Block SIGINT in this thread (the main one, where Python takes signals); True when it was blocked here."""
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        return False
    return signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    """End a local pool at once after an error or an interrupt: its workers killed, its queued work dropped.

    Cancelling the futures one by one while Ctrl-C also reaches the workers (one process group) raced
    Python 3.11's pool manager: it set an exception on a cancelled future when the pool broke
    (InvalidStateError in its thread), and the exit then waited on it for ever (4 of 10 interrupted
    ``db build`` runs hung). Killed workers leave nothing of theirs behind that a caller does not
    sweep (``batch_folder.sweep``); there is no public way to kill them before Python 3.14.
    """
    procs = list((getattr(pool, "_processes", None) or {}).values())
    writer = getattr(getattr(pool, "_result_queue", None), "_writer", None)  # before shutdown() drops the queue
    queue = getattr(pool, "_call_queue", None)
    if queue is not None:  # its feeder thread, writing to a dead worker's pipe, would hold the exit
        queue.cancel_join_thread()
    for p in procs:
        try:
            p.kill()
        except (OSError, ValueError, AttributeError):
            pass
    try:
        pool.shutdown(wait=False, cancel_futures=True)
    except Exception:
        pass
    for p in procs:
        try:
            p.join(timeout=5)
        except (OSError, ValueError, AttributeError, AssertionError):
            pass
    # a worker killed while sending its result leaves half a message in the result pipe, and the pool's
    # manager thread waits for the rest for ever (and an exit that joins it). With the workers dead this
    # process holds the pipe's last write end: closing it ends that wait (EOF), as for a broken pool.
    try:
        if writer is not None:
            writer.close()
    except OSError:
        pass


def _run_dask(spec: str, fn, items, bar, on_result=None, said: str = "") -> list:
    """:func:`_run` on a local Dask cluster (``spec`` "dask") or the scheduler at the address ``spec``; a failure is one
    line opening with ``said``, the option as the caller gave it (:func:`executor_said`)."""
    from distributed import Client, LocalCluster, as_completed as dask_as_completed

    if spec == "dask":
        cluster = LocalCluster(n_workers=os.cpu_count() or 1, threads_per_worker=1, processes=True, dashboard_address=None)
        client = None
        try:
            client = Client(cluster)
            return _run(client, fn, items, bar, dask_as_completed, on_result=on_result)
        finally:  # the work is done: the nannies' "Worker process still alive ... killing" at shutdown is no news
            with _quiet_dask():
                if client is not None:
                    client.close()
                cluster.close()
    with _quiet_dask():
        try:
            client = Client(spec, timeout=_PROBE_S * 2)
        except Exception as exc:  # it speaks Dask but is no scheduler (a worker, a nanny), or went away since the probe
            reason = (str(exc).strip().splitlines() or [""])[0]
            raise MocapError(f"{said}: cannot start a Dask client there ({type(exc).__name__}: {reason})") from None
        with client:
            try:
                client.wait_for_workers(1, timeout=WORKERS_S)
            except Exception:  # distributed's TimeoutError
                raise MocapError(f"{said}: the scheduler has no workers (none joined within {WORKERS_S:g} s); "
                                 f"start some with `dask worker {spec}`") from None
            return _run_remote(client, said, fn, items, bar, on_result)


#: seconds a remote scheduler may go without a worker (at the start, or once they are all gone) before the work stops
WORKERS_S = 20.0


@contextmanager
def _quiet_dask():
    """distributed's client logs a lost scheduler as tracebacks on stderr, and a local cluster's nannies log the workers
    they stop at shutdown: the command says what matters in one line instead."""
    import logging

    loggers = [logging.getLogger(n) for n in ("distributed", "distributed.client", "distributed.comm", "distributed.nanny",
                                              "distributed.process", "tornado")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def _run_remote(client, said: str, fn, items, bar, on_result=None) -> list:
    """:func:`_run` on a remote scheduler's client, watched: when no worker is left for :data:`WORKERS_S` seconds,
    or the scheduler is lost, the work stops with one line saying how much of it was done (a rerun resumes it)."""
    from distributed import as_completed as dask_as_completed

    futures = {client.submit(fn, it, pure=False): k for k, it in enumerate(items)}
    out: list = [None] * len(items)
    done, seen_workers, asked = 0, time.monotonic(), 0.0
    got: set = set()
    pending = dask_as_completed(list(futures))
    try:
        while not pending.is_empty():
            batch = pending.next_batch(block=False)
            if not batch:  # nothing finished: look at the workers once a second, then wait a little
                now = time.monotonic()
                if now - asked >= 1.0:
                    asked = now
                    if _workers(client) > 0:
                        seen_workers = now
                    elif now - seen_workers > WORKERS_S:
                        raise MocapError(f"{said}: no worker has been connected to the scheduler for "
                                         f"{WORKERS_S:g} s; {done} of {len(items)} done (a rerun resumes)")
                time.sleep(0.1)
                continue
            seen_workers = time.monotonic()  # something finished: a worker was there
            for fut in batch:
                try:
                    out[futures[fut]] = fut.result()
                except Exception as exc:
                    if _lost(exc):
                        raise MocapError(f"{said}: the Dask scheduler was lost ({type(exc).__name__}); "
                                         f"{done} of {len(items)} done (a rerun resumes)") from None
                    raise
                done += 1
                got.add(futures[fut])
                bar.update(1)
                if _tell(on_result, futures[fut], out[futures[fut]]):
                    _finish_stopped(futures, got, out, bar, on_result)
                    return out
    except BaseException:
        for fut in futures:
            fut.cancel()
        raise
    return out


def _workers(client) -> int:
    try:
        return len(client.scheduler_info().get("workers", {}))
    except Exception:  # the scheduler is gone: as good as no workers
        return 0


def _lost(exc: BaseException) -> bool:
    """True for what distributed raises when the client lost its scheduler (not an error of the work)."""
    return type(exc).__name__ in ("FutureCancelledError", "CancelledError", "CommClosedError") or \
        "scheduler-connection-lost" in str(exc)
