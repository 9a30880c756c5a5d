"""SIGINT and SIGTERM as KeyboardInterrupt, deferred while llvmlite's code is on the stack."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from mocapkit import interrupts
from mocapkit.interrupts import in_native_callback, interrupts_as_keyboard_interrupt


def _in_fake_llvmlite(fn):
    """Run ``fn`` in a frame whose code claims to be llvmlite's (as its object-cache hook is)."""
    path = os.path.join(os.sep, "site-packages", "llvmlite", "binding", "executionengine.py")
    scope = {"fn": fn, "sys": sys}
    exec(compile("result = fn(sys._getframe())", path, "exec"), scope)
    return scope["result"]


def test_in_native_callback_looks_through_the_callers():
    assert not in_native_callback(sys._getframe())
    assert _in_fake_llvmlite(in_native_callback)
    assert _in_fake_llvmlite(lambda frame: in_native_callback(sys._getframe()))  # a callee of that frame


def test_handlers_installed_for_the_block_and_restored():
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    with interrupts_as_keyboard_interrupt():
        assert signal.getsignal(signal.SIGTERM) is interrupts._interrupt  # a private name, in its own module's test
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before


def test_an_ignored_signal_stays_ignored():
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with interrupts_as_keyboard_interrupt():
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, old)


def test_a_signal_inside_llvmlite_lands_after_it():
    """The handler does not raise in the callback; the signal comes again and raises once the callback has returned."""
    with interrupts_as_keyboard_interrupt():
        handler = signal.getsignal(signal.SIGTERM)
        t0 = time.perf_counter()
        assert _in_fake_llvmlite(lambda frame: handler(signal.SIGTERM, frame)) is None  # deferred: no exception
        with pytest.raises(KeyboardInterrupt):
            time.sleep(5)
        assert time.perf_counter() - t0 >= interrupts.RETRY_S * 0.9


def test_sigterm_on_any_command_leaves_no_part_file(tmp_path):
    """``db build`` (not only clean) is interrupted by SIGTERM as by Ctrl-C: exit 143 (130 for Ctrl-C), its one line, nothing written."""
    from mocapkit import samples

    out = tmp_path / "db"
    code = (
        "import os, signal, sys\n"
        "import numpy as np\n"
        "from mocapkit.cli import main\n"
        "real, calls = np.save, []\n"
        "def save(*a, **k):\n"  # the first array is written into the hidden staging folder, then SIGTERM
        "    real(*a, **k)\n"
        "    calls.append(1)\n"
        "    if len(calls) == 1:\n"
        "        os.kill(os.getpid(), signal.SIGTERM)\n"
        "np.save = save\n"
        f"sys.exit(main(['db', 'build', {str(out)!r}, {str(samples.path('131_01.bvh'))!r}, '--executor', 'serial']))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert proc.returncode == 143, proc.stderr  # 128 + SIGTERM, as a shell reports it
    assert "interrupted; no partial output was left" in proc.stderr
    assert not out.exists() and list(tmp_path.iterdir()) == []  # the staging folder removed too


def test_held_interrupts_wait_for_the_block_then_act():
    from mocapkit.interrupts import interrupts_held

    done = []
    before = signal.signal(signal.SIGINT, signal.default_int_handler)  # Python's own, whatever the runner set
    try:
        with pytest.raises(KeyboardInterrupt):
            with interrupts_held():
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(0.05)  # the handler has run by now: it only noted the signal
                done.append("finished")
        assert done == ["finished"]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
        with interrupts_held():  # nothing pending: nothing raised
            pass
    finally:
        signal.signal(signal.SIGINT, before)


def test_the_exit_status_names_the_signal():
    before = signal.signal(signal.SIGTERM, signal.SIG_DFL)
    before_int = signal.signal(signal.SIGINT, signal.default_int_handler)  # whatever the test runner set
    try:
        for sig, status in ((signal.SIGTERM, 143), (signal.SIGINT, 130)):
            with pytest.raises(KeyboardInterrupt):
                with interrupts_as_keyboard_interrupt():
                    os.kill(os.getpid(), sig)
                    time.sleep(1.0)
            assert interrupts.exit_status() == status
        with interrupts_as_keyboard_interrupt():  # a new block forgets the last one's signal
            assert interrupts.exit_status() == 130
    finally:
        signal.signal(signal.SIGTERM, before)
        signal.signal(signal.SIGINT, before_int)


def _landing_in_hand_over(handler, generator_name: str):
    """A trace function that calls ``handler`` (SIGINT) once, with the frame of contextlib's ``__exit__`` of the
    context manager made from ``generator_name``, as the interpreter does when a signal comes while that frame
    runs; an exception the handler raises is raised there."""
    import contextlib

    fired = []

    def trace(frame, event, arg):
        code = frame.f_code
        if (event == "call" and not fired and code.co_name == "__exit__" and code.co_filename == contextlib.__file__
                and getattr(getattr(frame.f_locals.get("self"), "gen", None), "__name__", "") == generator_name):
            fired.append(frame)
            handler(signal.SIGINT, frame)
        return None

    return trace, fired


def _interrupt_within(seconds: float) -> bool:
    """Whether a KeyboardInterrupt came within ``seconds``."""
    try:
        time.sleep(seconds)
    except KeyboardInterrupt:
        return True
    return False


@pytest.mark.usefixtures("python_sigint")  # the deferred interrupt is a real SIGINT, sent again
def test_an_interrupt_in_the_hand_over_of_a_finished_block_lands_after_it(tmp_path):
    """An interrupted ``train`` said its first checkpoint resumes, and then the checkpoint was gone: the
    interrupt had come in contextlib's ``__exit__`` before it resumed ``removed_on_failure``, which was left
    suspended and put the outputs back at garbage collection. Now the interrupt lands after the block, and
    the block's complete outputs stay."""
    import gc

    from mocapkit.io import atomic_write
    from mocapkit.io.outputs import removed_on_failure

    out = tmp_path / "checkpoint.pt"
    with interrupts_as_keyboard_interrupt():
        trace, fired = _landing_in_hand_over(signal.getsignal(signal.SIGINT), "removed_on_failure")
        sys.settrace(trace)
        try:
            with removed_on_failure([out], overwrite=True):
                with atomic_write(out) as fh:
                    fh.write("epoch 1")
            seen = "the block ended"
        except KeyboardInterrupt:
            seen = "interrupted in the hand-over"
        finally:
            sys.settrace(None)
        later = _interrupt_within(5)  # the interrupt, sent again RETRY_S later
    assert fired and seen == "the block ended" and later
    fired.clear()
    gc.collect()  # what a suspended generator would have put back
    assert out.read_text() == "epoch 1" and sorted(p.name for p in tmp_path.iterdir()) == ["checkpoint.pt"]


@pytest.mark.usefixtures("python_sigint")  # the deferred interrupt is a real SIGINT, sent again
def test_an_interrupt_in_the_hand_over_of_a_failed_block_puts_back_at_once(tmp_path):
    """The block failed (a full disk) and the interrupt came in ``__exit__`` before the failure reached the
    generator: the outputs are put back before the failure is seen, not at garbage collection."""
    from mocapkit.io import atomic_write
    from mocapkit.io.outputs import removed_on_failure

    first, second = tmp_path / "model.pt", tmp_path / "checkpoint.pt"
    second.write_text("old")
    with interrupts_as_keyboard_interrupt():
        trace, fired = _landing_in_hand_over(signal.getsignal(signal.SIGINT), "removed_on_failure")
        sys.settrace(trace)
        try:
            with removed_on_failure([first, second], overwrite=True):
                with atomic_write(first) as fh:
                    fh.write("new")
                with atomic_write(second) as fh:
                    fh.write("new")
                raise OSError(28, "No space left on device")
        except BaseException as exc:  # noqa: BLE001 - which one came first is the point
            seen = type(exc).__name__, first.exists(), second.read_text(), sorted(p.name for p in tmp_path.iterdir())
        finally:
            sys.settrace(None)
        later = _interrupt_within(5)
    assert fired and later
    assert seen == ("OSError", False, "old", ["checkpoint.pt"])  # put back before the error was seen


@pytest.mark.usefixtures("python_sigint")  # the deferred interrupt is a real SIGINT, sent again
def test_a_signal_as_a_numba_kernel_calls_python_back_lands_after_it():
    """A compiled kernel calls numba's ``serialize._numba_unpickle`` back as it runs (reading a BVH: its fused
    channel conversion); Ctrl-C landing there came out of the kernel as ``SystemError: CPUDispatcher(...)
    returned a result with an exception set``, which clean-batch took for a failed take, going on with the rest
    (1 of 10 interrupted batches under load). The handler, called with that frame as the interpreter calls it,
    now sends the signal again; it lands after the kernel, as a KeyboardInterrupt."""
    import mocapkit
    from mocapkit import samples

    path = samples.path("131_01.bvh")
    mocapkit.load(path)  # the kernel compiled or loaded from the cache first: the read below runs it
    with interrupts_as_keyboard_interrupt():
        handler, fired = signal.getsignal(signal.SIGINT), []

        def profile(frame, event, arg):
            if event == "call" and not fired and frame.f_code.co_name == "_numba_unpickle":
                fired.append(frame.f_code.co_filename)
                handler(signal.SIGINT, frame)

        sys.setprofile(profile)
        try:
            mocapkit.load(path)
            seen = "read"
        except KeyboardInterrupt:
            seen = "interrupted in the callback"
        except SystemError as exc:
            seen = f"SystemError: {exc}"
        finally:
            sys.setprofile(None)
        later = _interrupt_within(5)
    assert fired and seen == "read" and later, (fired, seen)
