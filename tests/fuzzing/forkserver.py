"""A fork server for the command fuzzer: one interpreter imports what a ``mocapkit`` start imports, then forks each run.

A fresh ``python -c LAUNCHER`` per run (``tests/fuzzing/commands.py``) spends its
first part starting the interpreter and importing ``mocapkit.cli`` (numpy, rich,
typer) before the command does anything. The server (:data:`SERVER`) starts once per
harness thread with the runs' environment (:func:`tests.fuzzing.commands.run_env`
values: one thread per library, set before its imports), imports exactly what the
launcher imports before it calls the entry point (``from mocapkit.cli import main``:
the command's own lazy imports, numba and scipy among them, stay in the child, so
RLIMIT_AS headroom and what the oracle sees are those of a fresh start), and then,
per request, forks a child that does what the launcher does after its imports:
new session, ``chdir``, standard input from ``/dev/null``, standard output and
error to the run's files, RLIMIT_AS / CPU / FSIZE / CORE, ``sys.argv``, the entry
point, its exit through the interpreter's own exit path (``SystemExit``, uncaught
exception printed by ``sys.excepthook``, atexit handlers, flushed streams).

The server waits for its child with ``os.wait4`` and reports the wait status,
user + system CPU seconds and ``ru_maxrss`` (KiB) to the harness, which keeps the
wall-clock kill of the child's process group and the orphan check. A forked
child's CPU time starts at zero (the launcher's own imports are not counted) and
its peak RSS includes the pages it shares with the server, as a fresh process's
includes its imports.

Fork safety: the server forks only while it has a single thread (checked in
``/proc/self/task``, which also counts OpenMP or BLAS pools, before every fork);
none of numpy, rich, typer or mocapkit.cli starts one at import.

Protocol (the server's standard input and output): each message is a 4-byte
little-endian length and a :mod:`marshal` payload. Hello: ``(tasks, threads,
modules)``. Request: ``(cwd, argv, stdout, stderr, mem, cpu, fsize, entry)``
(paths and arguments as bytes, ``os.fsencode``). Replies: ``(pid, tasks)``
(``pid`` 0: not forked, the server had ``tasks`` threads), then ``(status,
cpu_s, maxrss_kib)``.
"""

from __future__ import annotations

import atexit
import marshal
import os
import shutil
import subprocess
import sys
import tempfile
import threading

__all__ = ["SERVER", "ForkServer", "acquire", "release", "close_all"]

# After the hello and the loop, only the child reaches the lines below _serve(): they are the launcher's tail.
SERVER = r"""
import resource, sys
from mocapkit.cli import main
import os, marshal

def _send(obj):
    b = marshal.dumps(obj)
    b = len(b).to_bytes(4, "little") + b
    while b:
        b = b[os.write(1, b):]

def _read(n):
    b = b""
    while len(b) < n:
        chunk = os.read(0, n - len(b))
        if not chunk:
            return None
        b += chunk
    return b

def _tasks():
    return len(os.listdir("/proc/self/task"))

def _serve():
    th = sys.modules.get("threading")
    _send((_tasks(), th.active_count() if th else 1, sorted(sys.modules)))
    while True:
        head = _read(4)
        if head is None:
            os._exit(0)
        req = marshal.loads(_read(int.from_bytes(head, "little")))
        tasks = _tasks()
        if tasks != 1:
            _send((0, tasks))
            continue
        pid = os.fork()
        if pid == 0:
            cwd, argv, out, err = req[:4]
            os.setsid()
            os.chdir(cwd)
            for fd, (path, flags) in enumerate(((os.devnull, os.O_RDONLY),
                                                (out, os.O_WRONLY | os.O_CREAT | os.O_TRUNC),
                                                (err, os.O_WRONLY | os.O_CREAT | os.O_TRUNC))):
                f = os.open(path, flags, 0o644)
                os.dup2(f, fd)
                os.close(f)
            return [os.fsdecode(a) for a in argv], *req[4:]
        _send((pid, tasks))
        _, status, ru = os.wait4(pid, 0)
        _send((status, ru.ru_utime + ru.ru_stime, ru.ru_maxrss))

args, mem, cpu, fsize, entry = _serve()
del _serve, _send, _read, _tasks
"""


def _tail(launcher: str) -> str:
    """The launcher's lines from its first ``setrlimit`` on: the same limits, argv and entry call in both modes."""
    return launcher[launcher.index("resource.setrlimit"):]


class ForkServer:
    """One server process (see the module docstring); ``spawn`` then ``wait`` run one command at a time."""

    def __init__(self, env: dict, launcher: str):
        self.home = tempfile.mkdtemp(prefix="mocapkit-forkserver-")  # its cwd while importing: nothing to import there
        self.log = tempfile.TemporaryFile()
        self.proc = subprocess.Popen([sys.executable, "-c", SERVER + _tail(launcher)], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self.log, env=env, cwd=self.home)
        tasks, threads, self.modules = self._recv()
        if tasks != 1 or threads != 1:
            self.close()
            raise RuntimeError(f"fork server has {tasks} OS threads ({threads} Python threads) after its imports: "
                               "forking it is not safe")

    def _recv(self):
        head = self.proc.stdout.read(4)
        if len(head) < 4:
            self.log.seek(0)
            raise RuntimeError("fork server died: " + self.log.read().decode("utf-8", "replace")[-2000:])
        return marshal.loads(self.proc.stdout.read(int.from_bytes(head, "little")))

    def spawn(self, cwd, argv, out, err, mem: int, cpu: int, fsize: int, entry: str) -> int:
        """Fork a child running ``entry`` with ``argv`` in ``cwd`` under the limits; its pid (its process group)."""
        args = [os.fsencode(a) for a in argv]  # what Popen does with an argument (and its errors)
        if any(b"\0" in a for a in args):
            raise ValueError("embedded null byte")
        req = marshal.dumps((os.fsencode(str(cwd)), args, os.fsencode(str(out)), os.fsencode(str(err)),
                             int(mem), int(cpu), int(fsize), entry))
        self.proc.stdin.write(len(req).to_bytes(4, "little") + req)
        self.proc.stdin.flush()
        pid, tasks = self._recv()
        if pid == 0:
            raise RuntimeError(f"fork server refused to fork with {tasks} OS threads")
        return pid

    def wait(self) -> tuple[int, float, int]:
        """``(wait status, CPU seconds user + system, ru_maxrss KiB)`` of the child of the last :meth:`spawn`."""
        return self._recv()

    def close(self) -> None:
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            self.proc.kill()
            self.proc.wait()
        self.proc.stdout.close()
        self.log.close()
        shutil.rmtree(self.home, ignore_errors=True)


_IDLE: dict[tuple, list[ForkServer]] = {}
_LOCK = threading.Lock()


def acquire(env: dict, launcher: str) -> ForkServer:
    """An idle server started with ``env`` and ``launcher``'s tail, or a new one (one per harness thread at a time)."""
    key = (tuple(sorted(env.items())), launcher)
    with _LOCK:
        idle = _IDLE.setdefault(key, [])
        if idle:
            return idle.pop()
    return ForkServer(env, launcher)


def release(server: ForkServer, env: dict, launcher: str, broken: bool = False) -> None:
    """Give a server back for the next run, or close it when its last run went wrong in the harness."""
    if broken or server.proc.poll() is not None:
        server.close()
        return
    with _LOCK:
        _IDLE.setdefault((tuple(sorted(env.items())), launcher), []).append(server)


@atexit.register
def close_all() -> None:
    """Stop every idle server (each also exits by itself when its standard input closes)."""
    with _LOCK:
        servers = [s for idle in _IDLE.values() for s in idle]
        _IDLE.clear()
    for s in servers:
        s.close()
