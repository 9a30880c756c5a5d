"""mocapkit.progress: bars on a terminal, none in logs and pipes unless asked for."""

import io
import os
import re
from pathlib import Path

from tqdm.auto import tqdm

from mocapkit.progress import bar_disabled


def test_bars_follow_the_terminal_unless_forced(monkeypatch):
    monkeypatch.delenv("MOCAPKIT_PROGRESS", raising=False)
    assert bar_disabled(False) is True and bar_disabled(True) is None
    log = io.StringIO()  # a log file or a pipe: not a terminal
    with tqdm(range(3), file=log, disable=bar_disabled(True)) as bar:
        list(bar)
    assert log.getvalue() == ""
    monkeypatch.setenv("MOCAPKIT_PROGRESS", "1")
    assert bar_disabled(True) is False and bar_disabled(False) is True
    with tqdm(range(3), file=log, disable=bar_disabled(True), desc="clips") as bar:
        list(bar)
    assert "clips" in log.getvalue()
    monkeypatch.setenv("MOCAPKIT_PROGRESS", "0")
    assert bar_disabled(True) is True


def test_a_batch_log_holds_one_result_per_line(tmp_path, monkeypatch):
    import mocapkit
    from mocapkit import samples
    from tests.cli.helpers import run

    monkeypatch.delenv("MOCAPKIT_PROGRESS", raising=False)
    src = tmp_path / "in"
    src.mkdir()
    mocapkit.save(mocapkit.load(samples.path("131_01.bvh"))[:300], src / "a.bvh")  # lines, not length, are checked
    code, out, err = run("clean-batch", src, tmp_path / "out", "--steps", "fill")
    assert code == 0 and "\r" not in err + out and "%|" not in err
    assert any(line.startswith("cleaned ") for line in out.splitlines())
    # the batch's first line, at once: before it a log said nothing until the first take was done (112 s on a
    # cold numba cache in a user's trial); said on standard error, beside a bar's place
    assert err.splitlines()[0].startswith(f"cleaning 1 take in {src} on "), err
    assert "python -m mocapkit.warmup compiles them ahead" in err, err


def test_a_batch_says_it_started_before_its_first_take_and_only_with_takes_to_clean(tmp_path):
    """clean_batch(on_start=): called once, before the first row, with the takes to clean, the takes found and
    where they run; not at all when every take is complete (a resumed batch with nothing left)."""
    from mocapkit import samples
    from mocapkit.batch import clean_batch

    src = tmp_path / "in"
    src.mkdir()
    (src / "a.bvh").write_bytes(samples.path("131_01.bvh").read_bytes())
    said = []
    for _ in range(2):
        clean_batch(src, tmp_path / "out", steps=["fill"], executor="serial", progress=False,
                    on_start=lambda *a: said.append(("start", *a)), on_row=lambda row, n, total: said.append(n))
    assert said == [("start", 1, 1, "this process"), 1, 1], said


def _on_a_pty(args, rows: int, cols: int, tmp_path) -> tuple[int, str, str]:
    """Run ``python -m mocapkit ARGS`` with standard error on a pseudo-terminal that reports ``rows`` x ``cols``
    (0 x 0: as ``script`` and some CI runners open one), standard output to a file: (exit status, what the
    terminal got, stdout)."""
    import fcntl
    import pty
    import select
    import struct
    import subprocess
    import sys
    import termios

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", rows, cols, 0, 0))
    env = {k: v for k, v in os.environ.items() if k not in ("MOCAPKIT_PROGRESS", "COLUMNS", "LINES")}
    with open(tmp_path / "stdout.txt", "wb") as out:
        p = subprocess.Popen([sys.executable, "-m", "mocapkit", *map(str, args)], stdin=subprocess.DEVNULL,
                             stdout=out, stderr=slave, env=env)
        os.close(slave)
        got = b""
        while True:
            ready, _, _ = select.select([master], [], [], 0.5)
            if ready:
                try:
                    chunk = os.read(master, 65536)
                except OSError:  # the child closed the terminal
                    break
                if not chunk:
                    break
                got += chunk
            elif p.poll() is not None:
                break
        code = p.wait()
    os.close(master)
    return code, got.decode("utf-8", "replace"), (tmp_path / "stdout.txt").read_text()


def test_a_bar_is_drawn_on_a_terminal_that_reports_no_size(tmp_path):
    """A pseudo-terminal reporting 0 x 0 is a terminal: tqdm read 0 rows there and hid every bar (clean's ssa bar
    among them); bar_size gives it the 80 x 24 rich and shutil take it to be."""
    import mocapkit
    from mocapkit import samples

    take = tmp_path / "in" / "131_01.bvh"  # 300 of its 994 frames: the bar is drawn whatever the take's length
    take.parent.mkdir()
    mocapkit.save(mocapkit.load(samples.path("131_01.bvh"))[:300], take)
    code, said, stdout = _on_a_pty(["clean", take, "-o", tmp_path / "c.bvh"], 0, 0, tmp_path)
    assert code == 0, said + stdout
    assert re.search(r"ssa 131_01: +100%\|", said), said
    assert "%|" not in stdout
    from mocapkit.progress import bar_size

    assert bar_size(io.StringIO()) == {}  # no terminal: tqdm's own test hides the bar


def test_fill_shows_its_steps_on_a_terminal_and_nothing_in_a_pipe(tmp_path, monkeypatch):
    """`mocapkit fill` said nothing on standard error while its models loaded and it filled (28 s for the Bandai
    dance-short take's 1,901 frames on a loaded machine); its bar shows the steps there, on a terminal only.

    The terminal is a real process's (a pseudo-terminal); the pipe is standard error redirected to a buffer in this
    process (what the bar tests, ``console.is_terminal``, reads the same there, without a second start of Python and
    torch)."""
    import mocapkit
    from mocapkit import corrupt
    from tests.cli.helpers import run

    take = mocapkit.load(Path(__file__).resolve().parent / "data" / "bandai_dance-short_normal_001_first60.bvh")
    gapped, _ = corrupt.gaps(take, seed=2, start_prob=0.05)
    mocapkit.save(gapped, tmp_path / "gaps.npz")
    code, said, stdout = _on_a_pty(["fill", tmp_path / "gaps.npz", "-o", tmp_path / "f.npz"], 0, 0, tmp_path)
    assert code == 0, said + stdout
    assert "fill gaps.npz" in said and "loading the models" in said and "writing f.npz" in said, said
    assert "wrote " in stdout and "fill gaps.npz" not in stdout
    monkeypatch.delenv("MOCAPKIT_PROGRESS", raising=False)
    code, out, err = run("fill", tmp_path / "gaps.npz", "-o", tmp_path / "g.npz")
    assert code == 0 and "fill gaps.npz" not in err + out and "wrote " in out, err
