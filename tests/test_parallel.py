"""map_ordered: the same results in input order on every executor; errors surface; executors checked up front; workers tied to their parent."""

from __future__ import annotations

import ctypes
import os
import signal
import socket
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import pytest

from mocapkit.errors import MocapError
from mocapkit.parallel import check_executor, describe_executor, map_ordered, owner_alive


def square(x):
    return x * x


def fail_on_three(x):
    if x == 3:
        raise ValueError("three")
    return x


def worker_state(_):
    """(pid, owner_alive(), parent-death signal, a parent watcher runs) as seen inside a worker."""
    sig = ctypes.c_int(0)
    if sys.platform.startswith("linux"):
        ctypes.CDLL(None).prctl(2, ctypes.byref(sig), 0, 0, 0)  # PR_GET_PDEATHSIG
    watched = any(t.name == "mocapkit-parent-watch" for t in threading.enumerate())
    return os.getpid(), owner_alive(), sig.value, watched


@pytest.mark.parametrize("executor", ["serial", "processes", None])
def test_results_in_input_order(executor):
    assert map_ordered(square, range(20), executor=executor, progress=False) == [x * x for x in range(20)]


def test_any_executor_with_submit():
    with ThreadPoolExecutor(3) as pool:
        assert map_ordered(square, [3, 1, 2], executor=pool, progress=False) == [9, 1, 4]
        assert check_executor(pool) is pool


def test_first_error_is_raised():
    with pytest.raises(ValueError, match="three"):
        map_ordered(fail_on_three, range(6), executor="processes", progress=False)


def test_empty_and_bad_executor():
    assert map_ordered(square, [], progress=False) == []
    with pytest.raises(MocapError, match="^executor= expects .* got int 42"):  # Python's keyword: the caller's
        map_ordered(square, [1, 2], executor=42, progress=False)
    with pytest.raises(MocapError, match="^executor='garbage': expected"):
        map_ordered(square, [], executor="garbage", progress=False)  # checked even when there is nothing to do
    with pytest.raises(MocapError, match="^--executor: expected .* got int 42"):  # the command line's flag
        map_ordered(square, [1, 2], executor=42, progress=False, option="--executor")
    assert "local processes" in describe_executor(None)


@pytest.mark.parametrize("spec", [None, "processes", "serial"])
def test_named_executors_pass(spec):
    assert check_executor(spec) == spec


@pytest.mark.parametrize("spec", ["garbage", "Processes", "tcp://", "tcp://host", "tcp://host:port", "http://127.0.0.1:8786",
                                  "127.0.0.1:8786", "tcp://127.0.0.1:8786; rm -rf /", ""])
def test_malformed_executor_is_one_line(spec):
    accepted = "expected processes, serial, dask or a Dask scheduler address tcp://HOST:PORT"
    with pytest.raises(MocapError) as info:
        check_executor(spec, option="--executor")
    assert str(info.value) == f"--executor: {accepted}, got {spec!r}"
    with pytest.raises(MocapError) as info:  # a Python caller passed executor=, not --executor
        check_executor(spec)
    assert str(info.value) == f"executor={spec!r}: {accepted}"


def test_port_out_of_range():
    with pytest.raises(MocapError, match="port 99999 is out of range"):
        check_executor("tcp://127.0.0.1:99999")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_is_refused():
    port = _free_port()  # bound and released: nothing listens there now
    with pytest.raises(MocapError, match=f"^--executor tcp://127.0.0.1:{port}: cannot connect"):
        check_executor(f"tcp://127.0.0.1:{port}", option="--executor")
    with pytest.raises(MocapError, match=f"^executor='tcp://127.0.0.1:{port}': cannot connect"):
        check_executor(f"tcp://127.0.0.1:{port}")


class _Server:
    """A loopback TCP server answering each connection with ``reply`` (then closing), or with nothing."""

    def __init__(self, reply: bytes | None):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(4)
        self.address = "tcp://127.0.0.1:%d" % self.sock.getsockname()[1]
        self.reply, self.conns = reply, []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            if self.reply is not None:
                conn.sendall(self.reply)
                conn.close()

    def close(self):
        self.sock.close()
        for c in self.conns:
            c.close()


@pytest.mark.parametrize("reply, reason", [
    (b"\xff" * 64, r"not a Dask scheduler \(its first message announces 18446744073709551615 bytes\)"),  # a huge length prefix
    (b"HTTP/1.1 400 Bad Request\r\n\r\n", "not a Dask scheduler"),
    ((40).to_bytes(8, "little") + b"x" * 40, r"not a Dask scheduler \(no Dask handshake\)"),  # framed, but not Dask's
    (b"", "not a Dask scheduler .it closed the connection"),
])
def test_non_dask_peer_is_refused_without_reading_what_it_announces(reply, reason):
    server = _Server(reply)
    try:
        with pytest.raises(MocapError, match=reason):
            check_executor(server.address)
    finally:
        server.close()


def test_silent_peer_times_out():
    server = _Server(None)  # accepts, never speaks
    try:
        with pytest.raises(MocapError, match="no Dask scheduler answered within 0.5 s"):
            check_executor(server.address, timeout=0.5)
    finally:
        server.close()


@pytest.fixture(scope="module")
def cluster():
    """One local Dask cluster (a scheduler and one single-threaded worker process) that the tests of a real scheduler
    share: each start costs a worker process and its imports; none of them changes the cluster for the next."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        yield cluster


def test_real_scheduler_passes(cluster):
    assert check_executor(cluster.scheduler_address) == cluster.scheduler_address
    assert map_ordered(square, [1, 2, 3], executor=cluster.scheduler_address, progress=False) == [1, 4, 9]
    assert map_ordered(worker_state, [0], executor=cluster.scheduler_address, progress=False)[0][1] is True  # the client waits
    worker = next(iter(cluster.scheduler_info["workers"]))  # speaks Dask, but is no scheduler
    with pytest.raises(MocapError, match="cannot start a Dask client there"):
        map_ordered(square, [1, 2], executor=worker, progress=False)


def test_a_scheduler_without_workers_is_one_line_not_a_wait(monkeypatch):
    distributed = pytest.importorskip("distributed")
    import mocapkit.parallel

    monkeypatch.setattr(mocapkit.parallel, "WORKERS_S", 1.0)
    with distributed.LocalCluster(n_workers=0, processes=True, dashboard_address=None) as cluster:
        t0 = time.monotonic()
        with pytest.raises(MocapError, match=f"^executor={cluster.scheduler_address!r}: the scheduler has no workers"):
            map_ordered(square, [1, 2], executor=cluster.scheduler_address, progress=False)  # named as passed
        assert time.monotonic() - t0 < 30


def test_waiting_on_a_remote_scheduler_does_not_spin(monkeypatch, cluster):
    """The client looks at the workers about once a second while it waits (a deadline set once made every later
    look immediate: 29,600 looks and 3 s of CPU for one 4-second task). A 2-second task: 2-3 looks; one every
    0.1 s (the wait's step) would be 20."""
    import mocapkit.parallel

    looks = []
    real = mocapkit.parallel._workers
    monkeypatch.setattr(mocapkit.parallel, "_workers", lambda client: looks.append(1) or real(client))
    cpu = time.process_time()
    assert map_ordered(time.sleep, [2.0], executor=cluster.scheduler_address, progress=False) == [None]
    assert len(looks) <= 10 and time.process_time() - cpu < 2.0


def test_owner_alive_here_and_in_pool_workers():
    assert owner_alive()  # not a worker: the owner is this process
    states = map_ordered(worker_state, range(4), executor="processes", max_workers=2, progress=False)
    assert all(alive and watched for _, alive, _, watched in states)  # every platform: a watcher of the parent pid
    assert os.getpid() not in {pid for pid, _, _, _ in states}
    if sys.platform.startswith("linux"):
        assert {sig for _, _, sig, _ in states} == {int(signal.SIGKILL)}  # and on Linux the kernel's parent-death signal


def test_stopping_a_pool_ends_a_manager_left_waiting_on_half_a_result():
    """A worker killed while sending its result leaves half a message in the result pipe: the pool's manager thread
    waited for the rest for ever, and so did the exit that joins it (interrupted `db build` runs hung)."""
    import struct
    import time
    from concurrent.futures import ProcessPoolExecutor

    from mocapkit.parallel import _stop_pool  # this module's own test

    pool = ProcessPoolExecutor(max_workers=1)
    assert pool.submit(abs, -1).result() == 1  # the workers and the manager thread are up
    manager = pool._executor_manager_thread
    writer = pool._result_queue._writer
    # a header announcing 1,000 bytes, then 10 of them, as a worker killed mid-send leaves it
    os.write(writer.fileno(), struct.pack("!i", 1000) + b"x" * 10)
    time.sleep(0.5)
    assert manager.is_alive()  # waiting for the other 990 bytes
    _stop_pool(pool)
    manager.join(timeout=10)
    assert not manager.is_alive()


def test_the_bar_counts_what_the_caller_did_already(capsys, monkeypatch):
    monkeypatch.setenv("MOCAPKIT_PROGRESS", "1")  # the bar, though the captured stderr is no terminal
    assert map_ordered(abs, [-1, 2], executor="serial", progress=True, desc="clips", done=1) == [1, 2]
    assert "1/3" in capsys.readouterr().err  # starts at what was done, out of all: db build reads its first clip itself


def _die(x):
    os._exit(1)  # as a worker killed by the OOM killer or a signal before it could answer


def test_a_worker_that_dies_is_one_line_not_broken_process_pool():
    with pytest.raises(MocapError, match="a worker process ended abruptly"):
        map_ordered(_die, [1, 2], executor="processes", progress=False, max_workers=2)


def slow_square(x):
    time.sleep(0.05 * x)
    return x * x


def square_after_gate(item):
    """``(x, gate)``: x * x, once the file ``gate`` exists when one is named (at most 20 s of waiting)."""
    x, gate = item
    deadline = time.monotonic() + 20
    while gate and not os.path.exists(gate) and time.monotonic() < deadline:
        time.sleep(0.005)
    return x * x


@pytest.mark.parametrize("executor", ["serial", "processes"])
def test_on_result_sees_each_result_as_it_finishes_and_can_stop_the_work(executor, tmp_path):
    """A batch's log: each item is handed back in this process as soon as it is done, and a true answer stops
    handing out work (items under way on local processes still finish and are handed back).

    On processes the first item waits at a gate that on_result opens: the others are handed back before it
    however slowly any process runs (a 0.15 s head start was the whole test once)."""
    gate = str(tmp_path / "gate") if executor == "processes" else None
    seen = []

    def log(k, r):
        seen.append((k, r))
        open(tmp_path / "gate", "w").close()

    # two workers whatever the core count: on one core "processes" runs serially, and the held item came first
    assert map_ordered(square_after_gate, [(3, gate), (0, None), (1, None)], executor=executor, progress=False,
                       max_workers=2, on_result=log) == [9, 0, 1]
    assert sorted(seen) == [(0, 9), (1, 0), (2, 1)]
    if executor == "processes":
        assert seen[0][0] != 0  # completion order: the held first item is not waited for

    seen.clear()
    out = map_ordered(square, range(40), executor=executor, progress=False, max_workers=2,
                      on_result=lambda k, r: seen.append(k) or True)  # stop at the first result
    if executor == "serial":
        assert seen == [0] and out == [0] + [None] * 39
    assert [k for k, r in enumerate(out) if r is not None] == sorted(seen)  # every item that ran is handed back
    assert all(out[k] == k * k for k in seen)


def test_a_stop_starts_nothing_new_on_a_local_pool(tmp_path, monkeypatch):
    """on_result's stop (a batch's full disk): no item is handed to the pool after it, and the one under way beside
    it finishes and is handed back. A ProcessPoolExecutor moves submitted items into its call queue ahead of its
    workers, where they can no longer be cancelled: given all 40 items at once, a stop at the first result still
    started up to three more on two workers (four in a trial's full-disk batch).

    The first item waits until the pool has taken the second (it is running: it can no longer be cancelled), and
    the others wait at a gate that opens once the stop is asked. Opening the first gate as soon as nothing was
    pending raced the pool's manager thread: the second item, submitted but not yet queued, was cancelled at the
    stop, rightly (it never started), and the test failed once in CI."""
    from concurrent.futures import ProcessPoolExecutor

    import mocapkit.parallel

    futures = []

    class Recorded(ProcessPoolExecutor):
        def submit(self, *args, **kwargs):
            futures.append(super().submit(*args, **kwargs))
            return futures[-1]

    monkeypatch.setattr(mocapkit.parallel, "ProcessPoolExecutor", Recorded)
    first, rest, asked = tmp_path / "first", tmp_path / "rest", threading.Event()

    def open_gates():
        deadline = time.monotonic() + 20
        while not (len(futures) > 1 and futures[1].running()) and time.monotonic() < deadline:
            time.sleep(0.005)
        first.touch()
        asked.wait(60)
        rest.touch()

    opener = threading.Thread(target=open_gates, daemon=True)
    opener.start()
    seen = []
    items = [(k, str(rest if k else first)) for k in range(40)]
    out = map_ordered(square_after_gate, items, executor="processes", progress=False, max_workers=2,
                      on_result=lambda k, r: seen.append(k) or asked.set() or True)
    opener.join(10)
    assert seen[0] == 0 and len(futures) == 2  # the stopping item and the one under way beside it: nothing more
    assert sorted(seen) == [0, 1] and not any(f.cancelled() for f in futures)
    assert [k for k, r in enumerate(out) if r is not None] == [0, 1] and out[:2] == [0, 1]


def test_a_stop_cancels_a_handed_out_item_the_pool_has_not_taken(monkeypatch):
    """The other side of the race above: an item handed out but not yet taken into the pool's call queue when the
    stop comes is cancelled (it never starts, its slot stays None) rather than started and waited for."""
    from concurrent.futures import Future

    import mocapkit.parallel

    class Lagging:  # a pool whose manager thread has taken only the first item when it finishes
        def __init__(self, max_workers=None, **kwargs):
            self.futures = []

        def submit(self, fn, *args):
            fut = Future()
            if not self.futures:
                fut.set_running_or_notify_cancel()
                fut.set_result(fn(*args))
            else:  # taken a second later, unless cancelled by then: a pool that waited for it hands it back
                threading.Timer(1.0, lambda: fut.set_running_or_notify_cancel() and fut.set_result(fn(*args))).start()
            self.futures.append(fut)
            return fut

        def shutdown(self, wait=True, cancel_futures=False):
            pass

    pools = []
    monkeypatch.setattr(mocapkit.parallel, "ProcessPoolExecutor", lambda **kw: pools.append(Lagging(**kw)) or pools[-1])
    seen = []
    out = map_ordered(square, range(40), executor="processes", progress=False, max_workers=2,
                      on_result=lambda k, r: seen.append(k) or True)
    assert seen == [0] and out == [0] + [None] * 39
    assert len(pools[0].futures) == 2 and pools[0].futures[1].cancelled()


def test_a_local_pool_is_handed_its_items_as_its_workers_free(tmp_path, monkeypatch):
    """Without a stop every item runs, in input order of results, though at most two are handed out at a time."""
    from concurrent.futures import ProcessPoolExecutor

    import mocapkit.parallel

    most, handed = [0], []

    class Counted(ProcessPoolExecutor):
        def submit(self, *args, **kwargs):
            handed.append(super().submit(*args, **kwargs))
            most[0] = max(most[0], sum(not f.done() for f in handed))  # done() is set before any waiter wakes
            return handed[-1]

    monkeypatch.setattr(mocapkit.parallel, "ProcessPoolExecutor", Counted)
    assert map_ordered(square, range(25), executor="processes", progress=False, max_workers=2) == [
        k * k for k in range(25)]
    assert most[0] <= 2


def test_on_result_on_a_dask_scheduler_sees_each_result_and_stops_the_work(cluster):
    seen = []
    assert map_ordered(square, [1, 2, 3], executor=cluster.scheduler_address, progress=False,
                       on_result=lambda k, r: seen.append((k, r))) == [1, 4, 9]
    assert sorted(seen) == [(0, 1), (1, 4), (2, 9)]
    seen.clear()
    out = map_ordered(slow_square, [1] * 30, executor=cluster.scheduler_address, progress=False,
                      on_result=lambda k, r: seen.append(k) or True)
    assert seen and len(seen) < 30 and [k for k, r in enumerate(out) if r is not None] == sorted(seen)


def pid_then_sleep(folder):
    """A worker's task: write its pid under ``folder``, then wait to be stopped."""
    from pathlib import Path

    Path(folder, str(os.getpid())).write_text("")
    time.sleep(60)


_INTERRUPTED_POOL = """
import signal, sys
signal.signal(signal.SIGINT, signal.SIG_DFL)  # a child started in the background inherits SIGINT ignored
signal.signal(signal.SIGTERM, signal.SIG_DFL)
from mocapkit.interrupts import exit_status, interrupts_as_keyboard_interrupt
from mocapkit.parallel import map_ordered
from tests.test_parallel import pid_then_sleep
with interrupts_as_keyboard_interrupt():
    try:
        map_ordered(pid_then_sleep, [sys.argv[1]] * 2, executor="processes", max_workers=2, progress=False)
    except KeyboardInterrupt:
        print("interrupted")
        sys.exit(exit_status())
"""


@pytest.mark.parametrize("target", ["worker", "parent", "group"])
def test_a_sigterm_to_a_pool_worker_or_its_parent_ends_the_work_as_interrupted(tmp_path, target):
    """A worker that took a SIGTERM died of it with its traceback and broke the pool: `clean-batch` said "a worker
    process ended abruptly" and exited 2; now the parent ends the work as a SIGTERM sent to it does, exit 143.
    "group": a scheduler stopping the job signals its whole process group, the parent and its workers at once."""
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    proc = subprocess.Popen([sys.executable, "-c", _INTERRUPTED_POOL, str(tmp_path)], cwd=root, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while len(list(tmp_path.iterdir())) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.1)
        workers = sorted(int(p.name) for p in tmp_path.iterdir())
        assert len(workers) == 2, proc.communicate(timeout=10)
        if target == "group":
            os.killpg(proc.pid, signal.SIGTERM)
        else:
            os.kill(workers[0] if target == "worker" else proc.pid, signal.SIGTERM)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert out.strip() == "interrupted" and "Traceback" not in err, err
    for pid in workers:  # the workers are gone
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def quick_die_or_hold(item):
    """``(what, gate)``: "quick" returns at once; "die" waits for the file ``gate`` (at most 20 s), then ends its
    worker as the OOM killer would; "hold" waits 60 s."""
    what, gate = item
    deadline = time.monotonic() + 20
    while what == "die" and not os.path.exists(gate) and time.monotonic() < deadline:
        time.sleep(0.005)
    if what == "die":
        os._exit(1)
    if what == "hold":
        time.sleep(60)
    return os.getpid()


_BROKEN_POOL_BUSY_PARENT = """
import signal, sys, time
signal.signal(signal.SIGTERM, signal.SIG_DFL)  # a library user's process (a notebook): a SIGTERM ends it
from mocapkit.errors import MocapError
from mocapkit.parallel import map_ordered
from tests.test_parallel import quick_die_or_hold
gate = sys.argv[1]

def busy_log(k, pid):  # still busy when the pool breaks: concurrent.futures SIGTERMs the other worker meanwhile
    print(pid, flush=True)
    open(gate, "w").close()
    time.sleep(1.5)

try:
    map_ordered(quick_die_or_hold, [("quick", gate), ("die", gate), ("hold", gate)], executor="processes",
                max_workers=2, progress=False, on_result=busy_log)
except MocapError as exc:
    print(exc)
"""


def test_a_pool_that_stops_its_own_workers_never_signals_the_process_that_runs_it(tmp_path):
    """A worker dies; concurrent.futures then sends SIGTERM to the pool's other workers. A worker that took it as
    someone else's passed it on to its parent half a second later: the process that called map_ordered (here a
    plain one, as a notebook is) died of a SIGTERM it never asked for, while its on_result was still busy. The
    parent's own SIGTERM ends a worker; the call says one worker ended abruptly."""
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    proc = subprocess.run([sys.executable, "-c", _BROKEN_POOL_BUSY_PARENT, str(tmp_path / "gate")], cwd=root,
                          text=True, capture_output=True, timeout=60)
    assert proc.returncode == 0, (proc.returncode, proc.stderr)
    lines = proc.stdout.splitlines()
    assert len(lines) == 2 and lines[1].startswith("a worker process ended abruptly"), proc.stdout
    with pytest.raises(ProcessLookupError):  # the worker that did the quick item is gone too
        os.kill(int(lines[0]), 0)


def _blocked(status: str) -> bool:
    """Whether SIGTERM is in the ``SigBlk`` mask of a /proc/PID/status text."""
    line = next(ln for ln in status.splitlines() if ln.startswith("SigBlk:"))
    return bool(int(line.split()[1], 16) >> (signal.SIGTERM - 1) & 1)


def masks_of_worker_and_forked_child(_):
    """(the worker's SIGTERM is blocked, a child it forks has it blocked), seen inside a pool worker."""
    with open("/proc/self/status") as fh:
        worker = _blocked(fh.read())
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: its own mask, then out without running the parent's cleanup
        try:
            os.close(r)
            with open("/proc/self/status") as fh:
                os.write(w, fh.read().encode())
        finally:
            os._exit(0)
    os.close(w)
    with os.fdopen(r) as fh:
        child = _blocked(fh.read())
    os.waitpid(pid, 0)
    return worker, child


def mask_of_a_program_started_with_unblock_sigterm(_):
    """Whether a program a pool worker runs by subprocess, with unblock_sigterm as preexec_fn, has SIGTERM blocked."""
    import subprocess

    from mocapkit.parallel import unblock_sigterm

    return _blocked(subprocess.run(["cat", "/proc/self/status"], capture_output=True, text=True,
                                   preexec_fn=unblock_sigterm, check=True).stdout)


_MASKS = pytest.mark.skipif(not hasattr(signal, "sigwaitinfo") or not sys.platform.startswith("linux"),
                            reason="the worker blocks SIGTERM only where sigwaitinfo names its sender; /proc masks")


@_MASKS
def test_a_process_a_work_function_forks_starts_with_sigterm_unblocked():
    """The worker keeps SIGTERM blocked for its watcher thread; a child it forks gets the mask it would have had,
    so a nested pool's terminate() can end it."""
    got = map_ordered(masks_of_worker_and_forked_child, [0, 1], executor="processes", max_workers=2, progress=False)
    assert got == [(True, False)] * 2


@_MASKS
def test_a_program_a_work_function_starts_with_unblock_sigterm_can_be_terminated():
    """subprocess forks and execs in C (no fork hook runs): unblock_sigterm as preexec_fn gives it the mask."""
    got = map_ordered(mask_of_a_program_started_with_unblock_sigterm, [0, 1], executor="processes", max_workers=2,
                      progress=False)
    assert got == [False, False]
