"""The command fuzzer's fork server: a forked run is judged exactly as a fresh process is.

Each behaviour (a clean exit, a traceback, a signal, an exit code, a CPU-limit kill,
a memory blow-up, a left-behind process) is run by :func:`tests.fuzzing.commands.run_step`
twice, ``launch="fresh"`` and ``launch="fork"``, through an entry point written into the
run's folder that imports ``mocapkit.cli`` first (the footprint of a real start) and then
misbehaves; the oracle must say the same of both.
"""

from __future__ import annotations

import dataclasses
import os
import signal

import pytest

from tests.fuzzing import commands, forkserver

MISBEHAVE = '''
import os, signal, sys, time
import mocapkit.cli

def main():
    what = sys.argv[1]
    if what == "ok":
        print("fine", " ".join(sys.argv[2:]), os.getcwd() == os.environ.get("EXPECT_CWD", os.getcwd()))
        return 0
    if what == "modules":
        print("\\n".join(sorted(m for m in sys.modules if m != "misbehave")))
        return 0
    if what == "stdin":
        print(repr(sys.stdin.read()), os.getsid(0) == os.getpid())
        return 0
    if what == "traceback":
        raise ValueError("a bad thing")
    if what == "signal":
        os.kill(os.getpid(), signal.SIGSEGV)
    if what == "exit":
        return 3
    if what == "cpu":
        while True:
            pass
    if what == "memory":
        hold = []
        while True:
            hold.append(b"\\x01" * (32 << 20))
    if what == "orphan":
        if os.fork() == 0:
            time.sleep(60)
            os._exit(0)
        return 0
    if what == "hang":
        time.sleep(600)
'''

LIM = commands.Limits(mem_bytes=1536 << 20, cpu_s={"default": 20.0}, wall_s=120.0)


def _both(tmp_path, argv, limits=LIM, wall_s=None):
    (tmp_path / "misbehave.py").write_text(MISBEHAVE)
    out = {}
    for mode in ("fresh", "fork"):
        lim = dataclasses.replace(limits, launch=mode)
        res = commands.run_step(argv, tmp_path, lim, wall_s=wall_s, entry="misbehave:main")
        out[mode] = (res, res.findings + commands.judge(res, commands.Step(tuple(argv)), lim))
    return out


def _same(out):
    (a, fa), (b, fb) = out["fresh"], out["fork"]
    assert (a.returncode, a.signal) == (b.returncode, b.signal)
    assert sorted(f.kind for f in fa) == sorted(f.kind for f in fb)
    return a, b, fa, fb


def test_clean_exit_argv_and_cwd_as_fresh(tmp_path):
    a, b, fa, fb = _same(_both(tmp_path, ("ok", "x y", "\udcff", "[/b]")))
    assert fa == fb == [] and a.returncode == 0
    assert a.stdout == b.stdout and a.stdout.startswith("fine x y ") and a.stdout.endswith(" [/b] True\n")
    assert a.stderr == b.stderr == ""


def test_stdin_is_empty_and_the_run_leads_its_session(tmp_path):
    a, b, _, _ = _same(_both(tmp_path, ("stdin",)))
    assert a.stdout == b.stdout == "'' True\n"


def test_traceback_exit_code_and_signal_as_fresh(tmp_path):
    a, b, fa, fb = _same(_both(tmp_path, ("traceback",)))
    assert a.returncode == 1 and [f.kind for f in fa] == ["traceback"] and fa[0].detail == fb[0].detail
    assert fa[0].detail.startswith("ValueError: a bad thing")
    assert a.stderr.splitlines()[-1] == b.stderr.splitlines()[-1] == "ValueError: a bad thing"
    a, b, fa, fb = _same(_both(tmp_path, ("exit",)))
    assert a.returncode == 3 and [f.kind for f in fa] == ["exit"] and fa == fb
    a, b, fa, fb = _same(_both(tmp_path, ("signal",)))
    assert a.signal == signal.SIGSEGV and [f.kind for f in fa] == ["signal"] and fa == fb


def test_cpu_limit_kill_as_fresh(tmp_path):
    a, b, fa, fb = _same(_both(tmp_path, ("cpu",), dataclasses.replace(LIM, cpu_s={"default": 1.0})))
    assert a.signal == signal.SIGXCPU and {f.kind for f in fa} == {"time"}
    assert 1.5 < b.cpu_s < 4.0 and 1.5 < a.cpu_s < 4.0  # RLIMIT_CPU of int(1.0) + 1 s


def test_memory_blow_up_as_fresh(tmp_path):
    a, b, fa, fb = _same(_both(tmp_path, ("memory",)))
    assert {f.kind for f in fa} == {"memory", "traceback"}
    assert "MemoryError" in a.stderr and "MemoryError" in b.stderr
    # the peak RSS of a forked child counts the pages it shares with the server, as a fresh one counts its imports
    limit_mb = LIM.mem_bytes / (1 << 20)
    assert 0.5 * limit_mb < a.peak_rss_mb < limit_mb and 0.5 * limit_mb < b.peak_rss_mb < limit_mb
    assert abs(a.peak_rss_mb - b.peak_rss_mb) < 0.1 * limit_mb


def test_orphan_and_hang_as_fresh(tmp_path):
    a, b, fa, fb = _same(_both(tmp_path, ("orphan",)))
    assert [f.kind for f in fa] == ["orphan_process"]
    a, b, fa, fb = _same(_both(tmp_path, ("hang",), wall_s=3.0))
    assert a.signal == signal.SIGKILL and [f.kind for f in fa] == ["hang"]


def test_forked_run_sees_the_modules_of_a_fresh_start(tmp_path):
    a, b, _, _ = _same(_both(tmp_path, ("modules",)))
    assert a.stdout == b.stdout and "mocapkit.cli" in a.stdout.split()
    assert "numba" not in a.stdout.split() and "scipy" not in a.stdout.split()  # the commands import them, lazily


def test_server_is_single_threaded_and_imports_what_a_start_imports(tmp_path):
    env = commands.run_env()
    server = forkserver.ForkServer(env, commands.LAUNCHER)
    try:
        assert "mocapkit.cli" in server.modules and "numba" not in server.modules
        (tmp_path / "misbehave.py").write_text(MISBEHAVE)
        pid = server.spawn(tmp_path, ("ok",), tmp_path / "o", tmp_path / "e", LIM.mem_bytes, 20, LIM.fsize_bytes,
                           "misbehave:main")
        status, cpu_s, _ = server.wait()
        assert pid > 0 and os.waitstatus_to_exitcode(status) == 0 and (tmp_path / "o").read_text().startswith("fine")
        with pytest.raises(ValueError, match="null byte"):
            server.spawn(tmp_path, ("a\0b",), tmp_path / "o", tmp_path / "e", LIM.mem_bytes, 20, LIM.fsize_bytes,
                         "misbehave:main")
    finally:
        server.close()
