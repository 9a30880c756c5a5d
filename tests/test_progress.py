"""mocapkit.progress: bars on a terminal, none in logs and pipes unless asked for."""

import io

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
    from mocapkit import samples
    from tests.cli.helpers import run

    monkeypatch.delenv("MOCAPKIT_PROGRESS", raising=False)
    src = tmp_path / "in"
    src.mkdir()
    (src / "a.bvh").write_bytes(samples.path("131_01.bvh").read_bytes())
    code, out, err = run("clean-batch", src, tmp_path / "out", "--steps", "fill")
    assert code == 0 and "\r" not in err + out and "%|" not in err
    assert any(line.startswith("cleaned ") for line in out.splitlines())
