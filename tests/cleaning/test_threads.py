"""Offline inference in fixed row parts on worker threads: the same numbers as one thread, every thread in one
torch thread, errors and grad modes carried over."""

import dataclasses
import os
import sys
import threading

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import threads
from mocapkit.motion import concatenate


@given(st.integers(0, 100_000), st.integers(1, 8), st.integers(1, 2000))
def test_part_bounds_cut_the_rows_into_contiguous_parts(n, parts, min_rows):
    b = threads.part_bounds(n, parts, min_rows)
    assert 1 <= len(b) <= parts
    assert b[0][0] == 0 and b[-1][1] == n
    assert all(b[i][1] == b[i + 1][0] for i in range(len(b) - 1))
    if len(b) > 1:
        assert min(hi - lo for lo, hi in b) >= min_rows
    assert b == threads.part_bounds(n, parts, min_rows)  # a function of its arguments, nothing else


def test_run_in_parts_returns_the_parts_in_order_from_several_threads():
    names = []

    def fn(lo, hi):
        names.append(threading.current_thread().name)
        return list(range(lo, hi))

    out = threads.run_in_parts(fn, 3000, parts=3, min_rows=10)
    assert [x for part in out for x in part] == list(range(3000))
    assert len(set(names)) > 1 and threading.current_thread().name in names


@pytest.mark.parametrize("bad_part", [0, 1])
def test_an_error_in_any_part_is_raised_after_every_part_ran(bad_part):
    done = []

    def fn(lo, hi):
        if lo == (0, 1500)[bad_part]:
            raise ValueError(f"part at {lo}")
        done.append(lo)
        return lo

    with pytest.raises(ValueError, match="part at"):
        threads.run_in_parts(fn, 3000, parts=2, min_rows=10)
    assert done == [(1500, 0)[bad_part]]


def test_workers_run_under_the_callers_grad_and_inference_modes():
    def modes(lo, hi):
        return torch.is_inference_mode_enabled(), torch.is_grad_enabled()

    with torch.inference_mode():
        assert set(threads.run_in_parts(modes, 3000, min_rows=10)) == {(True, False)}
    with torch.no_grad():
        assert set(threads.run_in_parts(modes, 3000, min_rows=10)) == {(False, False)}
    assert set(threads.run_in_parts(modes, 3000, min_rows=10)) == {(False, True)}


@torch.inference_mode()
def test_the_networks_in_parts_give_the_one_thread_result_bit_for_bit():
    gen = torch.Generator().manual_seed(3)
    with threads.torch_threads():
        ebf = deep.shipped_model("ebf").net
        x = torch.randn(1, 3000, ebf.lstm1.fwd.input_size, generator=gen)
        whole = ebf.lstm1.backward_outputs(x)
        assert torch.equal(ebf.lstm1.backward_outputs(x, parts=2), whole)
        assert torch.equal(ebf.lstm1.backward_outputs(x, parts=3), whole)
        ebd = deep.shipped_model("ebd").net
        F, C = 2500, ebd.channels
        tracks = torch.randn(F, C, generator=gen) * ebd.std + ebd.mean
        mask = (torch.rand(F, C, generator=gen) < 0.2).float()
        ctx = torch.randn(F, 3, generator=gen)
        centres = torch.arange(100, 2400)
        one = ebd.forward_at(tracks, mask, ctx, centres)
        assert torch.equal(ebd.forward_at(tracks, mask, ctx, centres, parts=2), one)


def test_offline_inference_runs_every_part_in_one_torch_thread_whatever_the_process_has(monkeypatch):
    """Two torch threads made the results differ from run to run in their last bits; one is the same every time."""
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    take = concatenate([walk] * 4)  # 1,372 frames: enough rows for two parts
    assert take.num_frames >= 2 * threads.MIN_PART_ROWS
    noisy, _ = corrupt.angular_noise(take, amount=0.5, seed=2)
    seen = set()
    tanh = torch.tanh

    def spy(*a, **k):
        seen.add((threading.current_thread().name.startswith("mocapkit-inference"), torch.get_num_threads()))
        return tanh(*a, **k)

    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        monkeypatch.setattr(torch, "tanh", spy)
        deep.denoise(noisy, deep.shipped_model("ebf"))
        gappy = np.array(noisy.rotations)
        gappy[200:1300, 5] = np.nan
        deep.fill_gaps(dataclasses.replace(noisy, rotations=gappy), deep.shipped_model("ebd"))
        assert torch.get_num_threads() == 2  # restored
    finally:
        torch.set_num_threads(before)
    assert seen == {(False, 1), (True, 1)}


def test_torch_threads_restores_the_thread_count():
    before = torch.get_num_threads()
    with threads.torch_threads(1):
        assert torch.get_num_threads() == 1
    assert torch.get_num_threads() == before


def _parts_in_child(queue):
    queue.put(threads.run_in_parts(lambda lo, hi: hi - lo, 3000, min_rows=10))


def test_a_forked_child_runs_parts_on_threads_of_its_own():
    """A local process pool forks after the parent's inference made the worker threads; the child has none."""
    import multiprocessing

    assert threads.run_in_parts(lambda lo, hi: hi - lo, 3000, min_rows=10) == [1500, 1500]  # the pool exists
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_parts_in_child, args=(queue,))
    child.start()
    child.join(60)
    alive = child.is_alive()
    if alive:
        child.kill()
    assert not alive, "the child waited for threads it does not have"
    assert queue.get(timeout=5) == [1500, 1500]


def _rss() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's heaps")
def test_freed_memory_is_handed_back():
    """Arrays of a few MB freed into glibc's heap stay in the process (its mmap threshold rises to the largest block
    freed): after the EBF's run on an 18-minute take about 240 MB; release_freed_memory hands them back."""
    import ctypes

    try:
        ctypes.CDLL(None).malloc_trim
    except AttributeError:
        pytest.skip("no malloc_trim (not glibc)")
    np.ones(24 << 17)  # a 24 MiB block freed: glibc's threshold rises, the next ones come from its heap
    blocks = [np.ones(4 << 17) for _ in range(24)]  # 24 x 4 MiB, every page written
    keep = blocks[-1]
    del blocks  # freed, all but the last: below it, glibc cannot shrink its heap by itself
    before = _rss()
    assert threads.release_freed_memory()
    assert before - _rss() > 40 << 20  # most of the 92 MiB freed
    assert keep.sum() == 4 << 17
