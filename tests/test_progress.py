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
