"""The entry point: one error line and exit 2 for every failure, --version, --help."""

import io
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

import mocapkit
from mocapkit.cli import command, main
from tests.cli import helpers
from tests.cli.helpers import SAMPLE, one_error_line, run


def test_bad_input_is_one_line_and_exit_2(tmp_path):
    bad = tmp_path / "broken.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n")
    code, out, err = run("info", str(bad))
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "broken.bvh" in lines[0]
    code, _, err = run("info", str(tmp_path / "missing.bvh"))
    assert code == 2 and "missing.bvh" in err
    code, _, err = run("convert", SAMPLE, str(tmp_path / "x.fbx"))
    assert code == 2 and "unknown suffix" in err and not (tmp_path / "x.fbx").exists()


def test_never_overwrites_the_input(tmp_path):
    src = tmp_path / "in.bvh"
    src.write_bytes(open(SAMPLE, "rb").read())
    before = src.read_bytes()
    code, _, err = run("convert", str(src), str(src))
    assert code == 2 and "refusing to write over an input" in err
    assert src.read_bytes() == before


def test_help_reads_well():
    code, out, _ = run("--help")
    assert code == 0
    for cmd in ("info", "convert", "corrupt", "plot"):
        assert cmd in out


def test_every_commands_help_shows_flags_as_flags():
    """Typer's help showed an on/off option as ``--overwrite <bool>``, which reads as an option taking a value: in
    every command's help a flag stands alone (``--overwrite``, ``--smooth / --no-smooth``), with no type."""
    import typer

    from mocapkit.cli import app

    def commands(group, path=()):
        for name, cmd in group.commands.items():
            yield (*path, name)
            if hasattr(cmd, "commands"):  # a group: its own commands too
                yield from commands(cmd, (*path, name))

    every = [()] + list(commands(typer.main.get_command(app)))
    assert ("fill",) in every and ("db", "build") in every
    for path in every:
        code, out, _ = run(*path, "--help")
        assert code == 0 and "<bool>" not in out and "--help" in out, (path, out)
        # no Python annotation in a type column (typer showed <list[Path]>, <list[str]>, <int range>, <float,float>)
        assert not re.search(r"list\[|\w range>|<\w+,\w+>", out), (path, out)
    out = run("corrupt", "--help")[1]
    assert re.search(r"--overwrite\s+Replace output files", out), out  # no type between the flag and its help
    out = run("train", "--help")[1]
    assert re.search(r"--speed\s+<float> <float>", out) and re.search(r"--epochs\s+<int> \[x>=1\]\s+Epochs", out), out
    # the arguments as README.md names them (typer showed the Python names: {file}, {reference})
    assert "info [OPTIONS] {FILE}" in run("info", "--help")[1]
    assert "plot [OPTIONS] {REFERENCE} {OTHER...}" in run("plot", "--help")[1]


def test_a_commands_help_is_wrapped_by_the_terminal_not_by_its_docstring(monkeypatch):
    """At 80 columns the docstring's own line breaks (kept by typer after the first paragraph) and the terminal's
    wrap cut ``clean --help``'s text into ragged lines ("step changed and" / "a record per step; ..."): each line
    of a paragraph but its last is now as full as the next line's first word allows."""
    monkeypatch.setenv("COLUMNS", "80")
    for cmd in ("clean", "train", "clean-batch", "fill"):
        out = run(cmd, "--help")[1]
        text = out.split("Usage:", 1)[1].split("\u256d", 1)[0].splitlines()[2:]  # the description, before the panels
        short = [a for a, b in zip(text, text[1:])  # a line the next one's first word would still have fitted on
                 if a.strip() and b.strip() and len(a.rstrip()) + 1 + len(b.split()[0]) < 78]
        assert text and not short, (cmd, short)




# -- --version -------------------------------------------------------------------------------


def test_version_is_the_package_metadata(capsys):
    from importlib.metadata import version

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"mocapkit {version('mocapkit')}"
    code, out, _ = run("--version")
    assert code == 0 and out.strip() == f"mocapkit {version('mocapkit')}"


# -- --overwrite, parent folders, the output guard --------------------------------------------


def _commands():
    """(name, click command) of every command, db's sub-commands included."""
    import typer

    from mocapkit.cli import app

    root = typer.main.get_command(app)
    for name, cmd in root.commands.items():
        subs = getattr(cmd, "commands", None)
        if subs:
            yield from ((f"{name} {sub}", c) for sub, c in subs.items())
        else:
            yield name, cmd


READ_ONLY_COMMANDS = {"info", "search", "db info"}
FOLDER_COMMANDS = {"train"}  # resumes its folder; --overwrite replaces another training's model there


def test_every_writing_command_has_overwrite_and_says_what_it_does():
    names = set()
    for name, cmd in _commands():
        names.add(name)
        opts = {p.name: p for p in cmd.params}
        if name in READ_ONLY_COMMANDS:
            assert "overwrite" not in opts, name
            continue
        assert "overwrite" in opts, f"{name} has no --overwrite"
        text = opts["overwrite"].help
        if name in FOLDER_COMMANDS:
            assert "refused" in text and "resumes" in text, (name, text)
            continue
        assert "Missing parent folders are created" in text and "refused" in text, (name, text)
    assert {"clean", "clean-batch", "convert", "corrupt", "plot", "detect", "repair", "denoise", "fill", "reconstruct",
            "db build"} <= names


def test_amc_options_name_a_reference_only_where_the_command_reads_one():
    """--asf, --amc-fps and --unit said '.amc input(s) and reference' on detect, repair, convert, clean-batch...,
    which take no reference: a user looked for a --reference they could not give."""
    seen = set()
    for name, cmd in _commands():
        opts = {p.name: p for p in cmd.params}
        has_reference = "reference" in opts or name == "plot"  # plot's first argument is its reference take
        for option in ("asf", "amc_fps", "unit"):
            if option in opts:
                seen.add(name)
                assert ("reference" in opts[option].help) == has_reference, (name, option, opts[option].help)
    assert {"clean", "clean-batch", "detect", "repair", "convert", "fill", "denoise", "search", "plot"} <= seen


def test_existing_output_is_refused_without_overwrite(tmp_path, capsys):
    out = tmp_path / "new" / "deeper" / "walk.npz"  # missing parent folders are created
    assert main(["convert", SAMPLE, str(out)]) == 0
    first = out.read_bytes()
    assert main(["convert", SAMPLE, str(out), "--fps", "30"]) == 2
    err = capsys.readouterr().err
    assert "already exists; pass --overwrite" in err and str(out) in err
    assert out.read_bytes() == first
    assert main(["convert", SAMPLE, str(out), "--fps", "30", "--overwrite"]) == 0
    assert mocapkit.load(out).fps == 30


def _inputs(tmp_path):
    """A take, its ASF elsewhere, a context file and folder, a reference, a model, a mask and a detection file."""
    import shutil

    d = tmp_path / "in"
    (d / "skel").mkdir(parents=True)
    (d / "ctx_dir").mkdir()
    amc = d / "walk.amc"
    shutil.copy(mocapkit.samples.path("12_walk.amc"), amc)
    shutil.copy(mocapkit.samples.path("12.asf"), d / "skel" / "other.asf")
    for name in ("ctx.bvh", "ref.bvh", "ctx_dir/a.bvh"):
        shutil.copy(SAMPLE, d / name)
    for name in ("model.pt", "det.npz", "noisy.mask.npz", "map.json"):
        (d / name).write_bytes(b"x")
    return d


def _guard_cases(d):
    """(command line, the input its output names): every kind of input a command reads, reached several ways."""
    take, asf, ref, ctx = str(d / "walk.amc"), str(d / "skel" / "other.asf"), str(d / "ref.bvh"), str(d / "ctx.bvh")
    return [
        (["convert", take, take], take),
        (["convert", take, f"{d}/skel/../walk.amc"], take),  # ..
        (["convert", take, f"{d}/./walk.amc"], take),  # ./
        (["convert", take, str(d / "link.bvh"), "--overwrite"], take),  # a symlink to the input, even with --overwrite
        (["convert", take, asf, "--asf", asf], asf),
        (["clean", SAMPLE, "-o", ref, "--reference", ref], ref),
        (["clean", SAMPLE, "-o", ctx, "--context", ctx], ctx),
        (["clean", SAMPLE, "-o", str(d / "ctx_dir" / "out.bvh"), "--context", str(d / "ctx_dir")], d / "ctx_dir"),
        (["clean", take, "-o", str(d / "o.bvh"), "--report", take], take),
        (["clean", take, "-o", str(d / "o2.bvh"), "--png", asf, "--asf", asf], asf),
        (["detect", take, "-o", str(d / "det.npz"), "--context", str(d / "det.npz")], d / "det.npz"),
        (["repair", SAMPLE, "-o", str(d / "det.npz"), "--detection", str(d / "det.npz")], d / "det.npz"),
        (["denoise", SAMPLE, "-o", str(d / "model.pt"), "--model", str(d / "model.pt")], d / "model.pt"),
        (["fill", SAMPLE, "-o", str(d / "model.pt"), "--denoiser", str(d / "model.pt")], d / "model.pt"),
        (["denoise", SAMPLE, "-o", ref, "--reference", ref], ref),
        (["corrupt", take, str(d / "c.npz"), "--kind", "noise", "--mask", take], take),
        (["plot", SAMPLE, ref, "--joint", "LeftKnee", "-o", str(d / "noisy.mask.npz"), "--mask", str(d / "noisy.mask.npz")],
         d / "noisy.mask.npz"),
        (["reconstruct", "--db", str(d / "nodb"), "--markers", take, "-o", take], take),
        (["reconstruct", "--db", str(d / "nodb"), "--markers", SAMPLE, "-o", ref, "--skeleton", ref], ref),
        (["reconstruct", "--db", str(d / "ctx_dir"), "--markers", SAMPLE, "-o", str(d / "ctx_dir" / "r.bvh")], d / "ctx_dir"),
    ]


def test_no_output_may_resolve_to_an_input(tmp_path, capsys):
    d = _inputs(tmp_path)
    (d / "link.bvh").symlink_to(d / "walk.amc")
    before = helpers.tree(d)
    for argv, victim in _guard_cases(d):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert "refusing to write over an input" in err and one_error_line(err), (argv, err)
        assert str(victim) in err, (argv, err)
        assert helpers.tree(d) == before, argv  # nothing written, nothing replaced


def test_output_that_is_a_folder_or_under_a_file_is_refused(tmp_path, capsys):
    folder = tmp_path / "out.npz"
    folder.mkdir()
    assert main(["convert", SAMPLE, str(folder), "--overwrite"]) == 2
    err = capsys.readouterr().err
    assert "is a folder" in err and one_error_line(err)
    afile = tmp_path / "plain.txt"
    afile.write_text("x")
    assert main(["convert", SAMPLE, str(afile / "sub" / "out.npz")]) == 2
    err = capsys.readouterr().err
    assert "plain.txt is a file, not a folder" in err and one_error_line(err)
    assert afile.read_text() == "x" and folder.is_dir() and not any(folder.iterdir())


# -- one line, exit 2, whatever raised it -----------------------------------------------------


def test_write_errors_are_one_line_naming_the_output(tmp_path, monkeypatch, capsys):
    import errno
    import tempfile

    import mocapkit.io as mio

    out = tmp_path / "ro" / "walk.npz"

    def read_only(*args, **kwargs):  # what mkstemp raises in a read-only folder (tests may run as root, who may write)
        raise PermissionError(errno.EACCES, "Permission denied", str(tmp_path / "ro" / ".walk.npz.k2j4h1x9.part"))

    original = tempfile.mkstemp
    monkeypatch.setattr(mio.tempfile, "mkstemp", read_only)
    assert main(["convert", SAMPLE, str(out)]) == 2
    err = capsys.readouterr().err
    assert err.strip() == f"mocapkit: error: {out}: Permission denied"
    monkeypatch.setattr(mio.tempfile, "mkstemp", original)

    def disk_full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(mio.os, "fsync", disk_full)
    assert main(["convert", SAMPLE, str(out)]) == 2
    err = capsys.readouterr().err
    assert "no space left on the device" in err and one_error_line(err)
    assert not out.exists() and not out.parent.exists()  # the temporary file is gone too, and the folder made for it


def test_a_write_error_names_the_output_as_typed(tmp_path, monkeypatch):
    """-o ../ro/out.npz on a read-only file system said "/home/me/ro/out.npz: read-only file system": mkstemp makes
    the temporary file's name absolute, and the line was read from it."""
    import errno

    import mocapkit.io as mio

    def read_only(prefix="", suffix="", dir=None, **kwargs):  # as Python's own: the name it tried, made absolute
        name = os.path.abspath(os.path.join(dir, f"{prefix}k2j4h1x9{suffix}"))
        raise OSError(errno.EROFS, "Read-only file system", name)

    (tmp_path / "work").mkdir()
    monkeypatch.setattr(mio.tempfile, "mkstemp", read_only)
    for out in (os.path.join("..", "ro", "walk.npz"), "walk.npz"):
        code, _, err = run("convert", SAMPLE, out, cwd=tmp_path / "work")
        assert code == 2 and err.strip() == f"mocapkit: error: {out}: read-only file system", err


def test_overwriting_in_a_read_only_folder_names_the_output_as_typed(tmp_path, monkeypatch):
    """--overwrite sets the old OUT aside first (io.outputs.keep_aside: a hidden name made by mkstemp beside it); in
    a read-only folder that failed with the hidden name made absolute ("/home/me/ro/walk.npz: read-only file
    system") where atomic_write's own failure says "../ro/walk.npz". Root writes into read-only folders: mkstemp
    raises as it does there."""
    import errno

    import mocapkit.io.outputs as outputs

    (tmp_path / "work").mkdir()
    (tmp_path / "ro").mkdir()
    out = os.path.join("..", "ro", "walk.npz")
    assert run("convert", SAMPLE, out, cwd=tmp_path / "work")[0] == 0

    def read_only(prefix="", suffix="", dir=None, **kwargs):  # as Python's own: the name it tried, made absolute
        raise OSError(errno.EROFS, "Read-only file system", os.path.abspath(os.path.join(dir, f"{prefix}x{suffix}")))

    monkeypatch.setattr(outputs.tempfile, "mkstemp", read_only)
    code, _, err = run("convert", SAMPLE, out, "--overwrite", cwd=tmp_path / "work")
    assert code == 2 and err.strip() == f"mocapkit: error: {out}: read-only file system", err
    assert (tmp_path / "ro" / "walk.npz").is_file()


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_folder_for_real(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        code, _, err = run("convert", SAMPLE, ro / "walk.npz")
    finally:
        ro.chmod(0o755)
    assert code == 2 and one_error_line(err) and "walk.npz" in err and "Permission denied" in err


def test_unexpected_exceptions_are_one_line_and_interrupts_130(monkeypatch, capsys, tmp_path):
    import mocapkit.io.takes as takes

    def boom(*args, **kwargs):
        raise RuntimeError("boom\nsecond line")

    monkeypatch.setattr(takes, "load_take", boom)
    assert main(["info", SAMPLE]) == 2
    err = capsys.readouterr().err
    assert err.strip() == "mocapkit: error: RuntimeError: boom second line"

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(takes, "load_take", interrupted)
    assert main(["info", SAMPLE]) == 130


def test_usage_errors_are_one_line(capsys):
    assert main(["info", SAMPLE, "--no-such-option"]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and "--no-such-option" in err
    assert main(["no-such-command"]) == 2
    assert one_error_line(capsys.readouterr().err)


def _run_with_a_thread(tmp_path, argv, thread_s):
    """``cli.run`` in a fresh process holding a non-daemon thread that sleeps ``thread_s`` then writes a file."""
    code = ("import sys, threading, time\n"
            "from mocapkit import cli\n"
            f"def slow():\n    time.sleep({thread_s})\n    open({str(tmp_path / 'joined')!r}, 'w').close()\n"
            "threading.Thread(target=slow).start()\n"
            f"sys.argv = ['mocapkit', *{argv!r}]\n"
            "cli.run()\n")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


def test_run_joins_threads_after_success_and_not_after_a_failure(tmp_path):
    """A failed or interrupted command ends at once: a thread a killed process pool left waiting (it hung 3 of 47
    interrupted `db build`s at exit) is not joined; a command that succeeded ends as Python does, threads joined."""
    proc = _run_with_a_thread(tmp_path, ["info", str(tmp_path / "missing.bvh")], 600)
    assert proc.returncode == 2 and "no such file" in proc.stderr
    assert not (tmp_path / "joined").exists()
    proc = _run_with_a_thread(tmp_path, ["--version"], 1)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "joined").exists()


@pytest.mark.usefixtures("python_sigint")
def test_run_still_runs_the_exit_handlers_when_interrupted_while_joining(tmp_path):
    """Ctrl-C while the exit waits for a thread: the wait ends, the atexit handlers still run, exit 130."""
    code = ("import atexit, os, signal, sys, threading, time\n"
            "from mocapkit import cli\n"
            f"atexit.register(lambda: open({str(tmp_path / 'handled')!r}, 'w').close())\n"
            "threading.Thread(target=time.sleep, args=(600,)).start()\n"
            "threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT)).start()\n"
            "sys.argv = ['mocapkit', '--version']\n"
            "cli.run()\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 130, proc.stderr
    assert (tmp_path / "handled").exists()


@pytest.mark.usefixtures("python_sigint")
@pytest.mark.parametrize("when", ["as main starts", "as main has returned"])
def test_run_exits_130_for_a_ctrl_c_as_the_command_starts_or_ends(monkeypatch, capsys, when):
    """A Ctrl-C outside main's handling of it (before its handlers are ours, or after they were restored) raised past
    every handler of run: a traceback, and the process killed by SIGINT instead of exit 130. A profile function
    calls Python's SIGINT handler at the signal check the interpreter makes there (main's first, or the first after
    it returned): one phase, every run, not the scheduler's luck. The exit's own steps are recorded, not taken."""
    import atexit
    import threading

    from mocapkit import cli

    steps = []
    monkeypatch.setattr(threading, "_shutdown", lambda: steps.append("joined"))
    monkeypatch.setattr(atexit, "_run_exitfuncs", lambda: steps.append("handlers"))

    def exit_now(code):
        sys.setprofile(None)
        raise SystemExit(code)

    monkeypatch.setattr(os, "_exit", exit_now)
    monkeypatch.setattr(sys, "argv", ["mocapkit", "--version"])
    armed = []

    def profile(frame, event, arg):
        if event == "call" and frame.f_code is cli.main.__code__ and when == "as main starts":
            armed.append(frame)
        elif event == "return" and frame.f_code is cli.main.__code__ and when == "as main has returned":
            armed.append(frame)
            return
        if armed and event in ("call", "c_return") and len(armed) == 1:
            armed.append(frame)
            signal.getsignal(signal.SIGINT)(signal.SIGINT, frame)

    sys.setprofile(profile)
    try:
        cli.run()
        ended = "returned"
    except SystemExit as exc:
        ended = exc.code
    except KeyboardInterrupt:  # (caught here, or it would end the test run)
        ended = "KeyboardInterrupt raised out of run"
    finally:
        sys.setprofile(None)
    assert len(armed) == 2 and ended == 130 and steps == ["handlers"]  # no join after an interrupt
    if when == "as main starts":
        assert "mocapkit: interrupted" in capsys.readouterr().err


def test_a_rig_of_no_known_naming_is_one_line_before_any_output(tmp_path):
    """A rig whose joints say nothing (bn00, bn01, ...) raised a bare KeyError in db build, corrupt --kind spatial,
    train's default (spatial) noise, and clean --reference after writing its outputs."""
    import dataclasses

    from pathlib import Path

    m = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh")
    names = tuple(f"bn{k:02d}" for k in range(m.num_joints))  # the game rig, its tree too unlike a human's to read
    bare = dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, joint_names=names))
    take = tmp_path / "in" / "take.bvh"
    take.parent.mkdir()
    mocapkit.save(bare, take)
    before = sorted(p.name for p in tmp_path.rglob("*"))
    for argv, said in ((["db", "build", str(tmp_path / "db"), str(take)], "cannot compute features F15"),
                       (["corrupt", str(take), str(tmp_path / "c.npz"), "--kind", "spatial", "--amount", "1"],
                        "the length unit cannot be told from the bones"),
                       (["train", "denoiser", str(take.parent), "-o", str(tmp_path / "model"), "--epochs", "1"],
                        "give --noise without spatial"),
                       (["clean", str(take), "-o", str(tmp_path / "o.bvh"), "--reference", str(take)],
                        "the error in cm needs the reference's length unit")):
        code, _, err = run(*argv)
        assert code == 2 and one_error_line(err) and said in err and "KeyError" not in err, (argv, err)
        assert sorted(p.name for p in tmp_path.rglob("*")) == before, argv


def test_a_file_cut_short_is_an_error_not_an_interrupt(monkeypatch, tmp_path):
    import mocapkit.io.takes

    def cut_short(*args, **kwargs):
        raise EOFError("No data left in file")  # as numpy says it of an empty .npy inside an archive

    monkeypatch.setattr(mocapkit.io.takes, "load_take", cut_short)
    code, _, err = run("convert", SAMPLE, tmp_path / "out.npz")
    assert code == 2 and "interrupted" not in err and one_error_line(err) and "EOFError: No data left" in err


def test_without_torch_the_line_says_how_to_get_it(monkeypatch, tmp_path):
    import mocapkit.io.takes

    def no_torch(*args, **kwargs):
        raise ModuleNotFoundError("No module named 'torch'", name="torch")

    monkeypatch.setattr(mocapkit.io.takes, "load_take", no_torch)
    code, _, err = run("convert", SAMPLE, tmp_path / "out.npz")
    assert code == 2 and one_error_line(err) and "pip install torch==2.13.0" in err


def test_a_path_the_terminal_cannot_show_does_not_fail_the_command(tmp_path):
    src = tmp_path / "Ünïcødé 日本.bvh"
    src.write_bytes(open(SAMPLE, "rb").read())
    env = dict(os.environ, PYTHONIOENCODING="ascii")
    proc = subprocess.run([sys.executable, "-m", "mocapkit.cli", "convert", str(src), str(tmp_path / "é.npz")],
                          capture_output=True, env=env)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "é.npz").is_file() and b"\\xe9.npz" in proc.stdout  # said, escaped


def test_running_out_of_memory_names_the_take(monkeypatch, capsys):
    import mocapkit.io.takes as takes

    def too_big(*args, **kwargs):
        raise MemoryError("Unable to allocate 2.60 MiB for an array with shape (2751, 31, 4) and data type float64")

    monkeypatch.setattr(takes, "load_take", too_big)
    assert main(["info", SAMPLE]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err)
    assert err.strip().startswith(f"mocapkit: error: {SAMPLE}: out of memory (Unable to allocate 2.60 MiB")
    assert "MemoryError" not in err


def test_a_closed_stdout_ends_a_command_quietly_and_its_outputs_whole(tmp_path, monkeypatch):
    """``mocapkit ... | head -1``: a write to a pipe its reader closed ended the command with status 1 and no word
    (rich's console), as a batch with failed takes ends; now as SIGPIPE ends ``yes | head``: 141, quietly."""
    import numpy as np

    from mocapkit.io import load

    take = str(Path(__file__).resolve().parents[1] / "data" / "cmu_01_01_start.bvh")
    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    for args in (["info", take, "--joints"], ["convert", take, str(tmp_path / "a.npz")]):  # convert prints last
        r, w = os.pipe()
        os.close(r)  # the reader went away before the command printed
        with open(w, "w", buffering=1, encoding="utf-8") as gone:
            monkeypatch.setattr(sys, "stdout", gone)
            assert main(args) == 141
            print("after", file=gone)  # the descriptor now writes nowhere: nothing fails after the command
    assert err.getvalue() == ""
    assert np.array_equal(load(tmp_path / "a.npz").rotations, load(take).rotations)
    assert [p.name for p in tmp_path.iterdir()] == ["a.npz"]
    r, w = os.pipe()
    os.close(r)
    with open(w, "w", buffering=1, encoding="utf-8") as gone:  # `2>&1 | head -0`: a failure's line meets it too
        monkeypatch.setattr(sys, "stdout", gone)
        monkeypatch.setattr(sys, "stderr", gone)
        assert main(["info", str(tmp_path / "none.bvh")]) == 141


@pytest.mark.parametrize("closed", ["stdout", "stderr"])
def test_a_command_started_with_a_stream_closed_ends_without_a_traceback(monkeypatch, closed):
    """``mocapkit info take.bvh >&-`` (or ``2>&-``): Python starts with ``sys.stdout`` (``sys.stderr``) None, and
    run's last flush called None.flush(): an AttributeError traceback and status 1 after the command had succeeded
    (a failure's status 2 likewise turned 1). Now the command's own status. The exit's own steps are not taken."""
    import atexit
    import threading

    from mocapkit import cli

    monkeypatch.setattr(threading, "_shutdown", lambda: None)
    monkeypatch.setattr(atexit, "_run_exitfuncs", lambda: None)

    def exit_now(code):
        raise SystemExit(code)

    monkeypatch.setattr(os, "_exit", exit_now)
    monkeypatch.setattr(sys, closed, None)
    monkeypatch.setattr(sys, "stdout" if closed == "stderr" else "stderr", io.StringIO())
    take = str(Path(__file__).resolve().parents[1] / "data" / "cmu_01_01_start.bvh")
    for args, status in ((["info", take], 0), (["info", take + ".none"], 2)):
        monkeypatch.setattr(sys, "argv", ["mocapkit", *args])
        with pytest.raises(SystemExit) as ended:
            cli.run()
        assert ended.value.code == status


def test_the_command_tree_is_built_once_per_process():
    """main() run again in one process (a suite, a Python caller) reuses the click command typer built, which
    ~20-50 ms of building at every call would otherwise cost; each run still parses its own arguments."""
    assert run("--version")[0] == 0
    built = command.cache_info().misses
    code, out, _ = run("info", SAMPLE)
    assert code == 0 and "131_01" in out
    assert command.cache_info().misses == built and command.cache_info().hits >= 1
    assert run("info", "--no-such-option")[0] == 2  # the reused command still refuses what it does not know
