"""A take an interrupted batch wrote but never said (mocapkit.batch_written): its row is told from its record, so a
log has the line of every take kept on disk."""

from __future__ import annotations

import shutil

import pytest

import mocapkit
import mocapkit.parallel
from mocapkit import corrupt, samples
from mocapkit.batch import clean_batch
from mocapkit.batch_written import WRITTEN_NOTE, row_from_record
from mocapkit.cleaning.pipeline import CleanResult


@pytest.fixture
def takes(tmp_path):
    """IN_DIR with two real takes (CMU 131_01, its first 90 frames, and the same with a real-style gap)."""
    src = tmp_path / "in"
    src.mkdir()
    walk = mocapkit.load(samples.path("131_01.bvh"))[:90]
    mocapkit.save(walk, src / "a.bvh")
    gappy, _ = corrupt.gaps(walk, mean_length_s=0.1, max_length_s=0.2, seed=3)
    mocapkit.save(gappy, src / "b.npz")
    return src


def test_a_take_written_before_the_interrupt_is_told_from_its_record(tmp_path, takes, monkeypatch):
    """A user trial: Ctrl-C in `clean-batch > log` after a worker had written a take (output and record in place)
    but before its row came back left that take complete on disk with no line in the log."""
    real = mocapkit.parallel.map_ordered

    def interrupted(fn, items, **kwargs):  # the first take is written by the real worker; then the interrupt
        fn(items[0])
        raise KeyboardInterrupt

    monkeypatch.setattr(mocapkit.parallel, "map_ordered", interrupted)
    rows = []
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        clean_batch(takes, out, steps=["fill"], executor="serial", progress=False,
                    on_row=lambda row, n, total: rows.append((row, n, total)))
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["a.bvh", "a.clean.npz"]
    assert len(rows) == 1
    row, n, total = rows[0]
    assert (row["input"], row["output"], row["status"], n, total) == (str(takes / "a.bvh"), str(out / "a.bvh"),
                                                                       "done", 1, 2)
    assert row["reason"] == WRITTEN_NOTE and row["frames"] == 90 and row["filled"] == 0
    monkeypatch.setattr(mocapkit.parallel, "map_ordered", real)
    resumed = clean_batch(takes, out, steps=["fill"], executor="serial", progress=False)
    assert [r["status"] for r in resumed.rows] == ["skipped", "done"]  # the take said is the one the rerun finds


def test_a_row_from_a_record_counts_what_the_take_had_changed(tmp_path, takes):
    shutil.copy(takes / "b.npz", tmp_path / "b.npz")
    summary = clean_batch(takes, tmp_path / "out", steps=["fill"], executor="serial", progress=False)
    done = {r["input"]: r for r in summary.rows}[str(takes / "b.npz")]
    record = tmp_path / "out" / "b.clean.npz"
    row = row_from_record(takes / "b.npz", tmp_path / "out" / "b.npz", record)
    assert row["filled"] == done["filled"] == int(CleanResult.load(record).filled.sum()) > 0
    assert {k: row[k] for k in ("repaired", "denoised", "flagged", "frames")} == \
        {k: done[k] for k in ("repaired", "denoised", "flagged", "frames")}


@pytest.mark.usefixtures("python_sigint")  # a held interrupt is a real SIGINT, raised as the hold ends
def test_an_interrupt_as_a_take_is_told_says_it_once_and_numbers_it_right(tmp_path):
    """An interrupt inside the telling of a take's row (after its line was written, before the take was marked
    said) had the row told again from its record: the take twice in the log; one before the line was written had
    its number counted, and the row told from its record came numbered one past it. A profile function calls the
    installed SIGINT handler at each signal check in the telling's and the line's own frames, one per run (as the
    interpreter would: a Python function starting, a builtin returning)."""
    import signal
    import sys

    import mocapkit.batch
    from mocapkit.interrupts import interrupts_as_keyboard_interrupt

    src = tmp_path / "in"
    src.mkdir()
    mocapkit.save(mocapkit.load(samples.path("131_01.bvh"))[:40], src / "a.bvh")

    def told(frame) -> bool:  # in the batch's telling of a row, or in the line's writing it calls
        code = frame.f_code
        return code.co_name in ("tell", "on_row") and code.co_filename in (mocapkit.batch.__file__, __file__)

    def run(k: int):
        lines, seen = [], []

        def on_row(row, n, total):  # a log's line, then what print_row does after it (its warnings)
            lines.append((row["input"], n, total))
            for _ in row.get("warnings", ()):
                pass

        def profile(frame, event, arg):
            if event in ("call", "c_return") and told(frame):
                seen.append(event)
                if len(seen) - 1 == k:
                    signal.getsignal(signal.SIGINT)(signal.SIGINT, frame)

        out = tmp_path / f"out{k}"
        with interrupts_as_keyboard_interrupt():
            sys.setprofile(profile)
            try:
                clean_batch(src, out, steps=["fill"], executor="serial", progress=False, on_row=on_row)
            except KeyboardInterrupt:
                pass
            finally:
                sys.setprofile(None)
        complete = (out / "a.clean.npz").exists()
        return len(seen), lines, complete

    checks, lines, complete = run(-1)
    assert checks > 3 and complete and lines == [(str(src / "a.bvh"), 1, 1)]
    wrong = {}
    for k in range(checks):
        _, lines, complete = run(k)
        if lines != [(str(src / "a.bvh"), 1, 1)] * complete:  # said once, numbered 1, exactly when kept
            wrong[k] = lines
    assert not wrong, wrong
