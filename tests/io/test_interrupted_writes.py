"""An interrupt at each point where Python can deliver one, inside removed_on_failure and atomic_write: the outputs
stay whole and nothing hidden is left behind, wherever it lands.

CPython runs a signal's handler only at its checks: when a Python function starts (or a generator resumes), and
after a builtin returns. A profile function sees exactly those points ('call', 'c_return'), so calling the
installed handler there, with the frame the interpreter would give it, is a signal landing there, one point per
run: a test of every phase, not of the scheduler's luck (a CI run once lost a checkpoint to one such phase).
"""

from __future__ import annotations

import contextlib
import signal
import sys
import tempfile
import time

import pytest

import mocapkit.interrupts
import mocapkit.io
from mocapkit.interrupts import interrupts_as_keyboard_interrupt
from mocapkit.io import atomic_write
from mocapkit.io import outputs
from mocapkit.io.outputs import removed_on_failure

_OURS = {removed_on_failure.__wrapped__.__code__, atomic_write.__wrapped__.__code__}


def _under_ours(frame) -> bool:
    """Whether ``frame`` is, or is called from, the generator of removed_on_failure or atomic_write, or contextlib's
    hand-over into or out of one (the block itself, the caller's code, is the ordinary case)."""
    while frame is not None:
        code = frame.f_code
        if code in _OURS:
            return True
        if code.co_filename == contextlib.__file__ and getattr(getattr(frame.f_locals.get("self"), "gen", None),
                                                               "gi_code", None) in _OURS:
            return True
        frame = frame.f_back
    return False


# the checks counted: those in these modules' frames (in pathlib's, os.path's, a signal lands as in the line that
# called them, whose check, as the call starts, is counted); tempfile's, since mkstemp makes the file
_FILES = {outputs.__file__, mocapkit.io.__file__, mocapkit.interrupts.__file__, contextlib.__file__, tempfile.__file__}


def _landing_at(k: int):
    """A profile function that counts the signal checks under :func:`_under_ours` and, at the ``k``-th, calls the
    handler installed then (SIGINT) with that frame, as the interpreter would; ``k`` < 0: only counts."""
    seen = []

    def profile(frame, event, arg):
        if event not in ("call", "c_return") or frame.f_code.co_filename not in _FILES or not _under_ours(frame):
            return
        seen.append(event)
        if len(seen) - 1 == k:
            signal.getsignal(signal.SIGINT)(signal.SIGINT, frame)

    return profile, seen


def _write(tmp_path, overwrite, k: int):
    """One write of take.bvh ("new" over "old" with ``overwrite``, else a new file), interrupted at the ``k``-th
    check; returns the number of checks seen and what the run left: the folder's names, take.bvh's text, whether
    the writers' context is as before, whether a KeyboardInterrupt came (at once, held, or sent again later)."""
    out = tmp_path / "take.bvh"
    if overwrite:
        out.write_text("old")
    before = outputs._NEW_ONLY.get(), outputs._WRITTEN.get()  # private: its own package's test
    profile, seen = _landing_at(k)
    came = False
    with interrupts_as_keyboard_interrupt():
        try:
            sys.setprofile(profile)
            try:
                with removed_on_failure([out], overwrite=overwrite):
                    with atomic_write(out) as fh:
                        fh.write("new")
            finally:
                sys.setprofile(None)
            if len(seen) > k >= 0:
                time.sleep(60)  # a deferred interrupt, sent again RETRY_S later, ends this wait
        except KeyboardInterrupt:
            came = True
    return len(seen), _left(tmp_path, out, before, came)


def _left(tmp_path, out, before, came):
    """What a run left, then cleared for the next: the folder's names, OUT's text, whether the writers' context is
    as ``before``, and ``came`` (the interrupts that reached the caller)."""
    left = sorted(p.name for p in tmp_path.iterdir())
    state = (left, out.read_text() if out.exists() else None,
             (outputs._NEW_ONLY.get(), outputs._WRITTEN.get()) == before, came)
    for p in tmp_path.iterdir():
        p.unlink()
    return state


@pytest.mark.usefixtures("python_sigint")  # a deferred interrupt is a real SIGINT, sent again RETRY_S later
@pytest.mark.parametrize("overwrite", [True, False], ids=["replacing", "new"])
def test_an_interrupt_anywhere_in_the_write_leaves_it_whole_and_nothing_hidden(tmp_path, overwrite, monkeypatch):
    """An interrupt that landed as mkstemp had made a temporary file, or between keep_aside and the try that drops
    its links, left a hidden ``.take.bvh.*.part`` behind (and the block's context set); one in the last steps of a
    finished block left the old version's hidden link."""
    monkeypatch.setattr(mocapkit.interrupts, "RETRY_S", 0.002)  # a deferred one sent again sooner (less waiting)
    checks, whole = _write(tmp_path, overwrite, -1)
    assert checks > 20 and whole == (["take.bvh"], "new", True, False)
    wrong, k = {}, 0
    while True:  # one run per check, until a run has no k-th (the count varies by a few: tempfile's first call)
        seen, state = _write(tmp_path, overwrite, k)
        if seen <= k:
            break
        if state[0] != ["take.bvh"] * (state[1] is not None) or state[1] not in ("new", "old" if overwrite else None) \
                or not state[2] or not state[3]:
            wrong[k] = state
        k += 1
    assert k > 20 and not wrong, wrong


def _undo(tmp_path, k: int):
    """take.bvh written "new" over "old", then the block interrupted (a first Ctrl-C), and a second interrupt at the
    ``k``-th check while removed_on_failure undoes the write; returns the number of checks seen and what was left."""
    out = tmp_path / "take.bvh"
    out.write_text("old")
    before = outputs._NEW_ONLY.get(), outputs._WRITTEN.get()
    landing, seen = _landing_at(k)

    def profile(frame, event, arg):  # the generator entered by throw() (the first interrupt) is no check: CPython's
        if event != "call" or frame.f_code is not removed_on_failure.__wrapped__.__code__:  # throwflag path skips
            landing(frame, event, arg)  # RESUME, where a resumed or started frame checks for signals

    came, second = 0, False
    with interrupts_as_keyboard_interrupt():
        try:
            try:
                with removed_on_failure([out], overwrite=True):
                    with atomic_write(out) as fh:
                        fh.write("new")
                    sys.setprofile(profile)  # the checks counted: those after the first interrupt
                    raise KeyboardInterrupt("the first Ctrl-C")
            finally:
                sys.setprofile(None)
        except KeyboardInterrupt as exc:
            came += 1
            second = str(exc) != "the first Ctrl-C"  # the second one raised at once, in place of the first
        if len(seen) > k >= 0 and not second:
            try:
                time.sleep(60)  # a deferred second interrupt, sent again RETRY_S later, ends this wait
            except KeyboardInterrupt:
                came += 1
    return len(seen), _left(tmp_path, out, before, came)


@pytest.mark.usefixtures("python_sigint")
def test_a_second_interrupt_while_a_failed_write_is_undone_still_puts_the_old_file_back(tmp_path, monkeypatch):
    """A second Ctrl-C that landed as removed_on_failure began undoing an interrupted block (before put_back held
    interrupts) skipped the put-back, and the clean-up then dropped the hidden link of the old version: the file
    the user had was gone for good, the half-written new set left in its place."""
    monkeypatch.setattr(mocapkit.interrupts, "RETRY_S", 0.002)
    checks, state = _undo(tmp_path, -1)
    assert checks > 3 and state == (["take.bvh"], "old", True, 1)
    wrong = {}
    for k in range(checks + 3):
        seen, state = _undo(tmp_path, k)
        if seen <= k:
            break
        if state[:3] != (["take.bvh"], "old", True) or state[3] not in (1, 2):
            wrong[k] = state
    assert not wrong, wrong
