"""The ``mocapkit`` command: thin wrappers that parse, call the library, and print.

One module per command group: :mod:`.motion` (info, convert, corrupt, plot),
:mod:`.db` (db build, db info, search), :mod:`.ssa` (detect, repair),
:mod:`.deep` (denoise, fill, train), :mod:`.reconstruct`, :mod:`.multilinear` (multilinear build)
and :mod:`.clean` (clean, clean-batch); :mod:`.common` holds what they share.

What every command guarantees:

- every output is checked against every input before any work
  (:func:`mocapkit.io.outputs.check_outputs`): no output may resolve to an
  input or lie in an input folder; an existing output is replaced only with
  ``--overwrite``; missing parent folders are created;
- outputs are written atomically (temporary file + rename), and a run that
  fails leaves none of the files it created;
- every failure ends in one line on stderr, ``mocapkit: error: ...``, and exit
  status 2 (1 for a batch with failed takes; 130 when interrupted, 143 after SIGTERM), never a
  traceback (:func:`main`);
- a reader that closes the output early (``| head -1``) ends the command as SIGPIPE ends
  ``yes | head``: quietly, status 141, the outputs written whole (:mod:`.streams`).
"""

from __future__ import annotations

import atexit
import functools
import os
import sys
import threading

import typer

from ..errors import TEMP_NAME, MocapError, os_error_line
from . import clean as clean_cmds
from . import db, deep, motion, multilinear, reconstruct, ssa
from .common import FlagsCommand, FlagsGroup

__all__ = ["app", "command", "main", "version"]

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130

app = typer.Typer(
    name="mocapkit",
    help="Clean and reconstruct human motion-capture data (BVH, ASF/AMC, C3D, TRC, npz).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    cls=FlagsGroup,
)


def version() -> str:
    """The installed package's version (package metadata), else the source tree's."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as dist_version

    try:
        return dist_version("mocapkit")
    except PackageNotFoundError:
        from .. import __version__

        return __version__


def _show_version(value: bool) -> None:
    if value:
        print(f"mocapkit {version()}")
        raise typer.Exit(0)


@app.callback()
def _root(
    show_version: bool = typer.Option(
        False, "--version", callback=_show_version, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """Clean and reconstruct human motion-capture data (BVH, ASF/AMC, C3D, TRC, npz)."""


for _fn in (motion.info, motion.convert, motion.corrupt, motion.plot, db.search, ssa.detect, ssa.repair,
            deep.denoise, deep.fill, deep.train, reconstruct.reconstruct, clean_cmds.clean):
    app.command(cls=FlagsCommand)(_fn)
app.command("clean-batch", cls=FlagsCommand)(clean_cmds.clean_batch)
app.add_typer(db.db_app, name="db")
app.add_typer(multilinear.multilinear_app, name="multilinear")

def _fail(message: str, code: int = EXIT_BAD_INPUT) -> int:
    text = " ".join(str(message).split())  # one line, whatever the message held
    print(f"mocapkit: error: {text}", file=sys.stderr)
    return code


def _usage_error(exc: BaseException) -> int | None:
    """Exit status for a command-line parsing error (typer's click exceptions), after printing it in one line."""
    code, fmt = getattr(exc, "exit_code", None), getattr(exc, "format_message", None)
    if not isinstance(code, int) or not callable(fmt) or isinstance(exc, MocapError):
        return None
    if type(exc).__name__ == "NoArgsIsHelpError":  # the help was printed while the error was made
        message = fmt().strip()
        if message:
            print(message)
        return code
    ctx = getattr(exc, "ctx", None)
    hint = f" (see '{ctx.command_path} --help')" if getattr(exc, "cmd", None) is not None or ctx is not None else ""
    return _fail(f"{fmt()}{hint}", code)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script: runs the app and turns every failure into one line.

    Returns the exit status: 0, 2 for any failure (bad input, usage, a
    filesystem error, an unexpected exception: ``mocapkit: error: ...`` on
    stderr, no traceback), 1 for a batch with failed takes (the command says
    which), 130 when interrupted (143 by SIGTERM), 141 saying nothing when the reader of stdout or stderr went
    away (:mod:`.streams`).
    """
    from .streams import guarded_streams

    for stream in (sys.stdout, sys.stderr):  # a path the terminal's encoding cannot show must not fail the command
        try:
            stream.reconfigure(errors="backslashreplace")
        except (AttributeError, ValueError):  # not a text file of the io module (a test's StringIO)
            pass
    with guarded_streams():  # a closed stdout or stderr as SIGPIPE (streams), the failure's own line included
        try:
            return _run_app(argv)
        except KeyboardInterrupt:  # the line saying a failure met a closed stream: nothing can say anything
            from ..interrupts import by_closed_stream

            if by_closed_stream():
                return interrupted_status()
            raise


@functools.cache
def command():
    """The click command that typer builds from :data:`app`, built once per process.

    Calling ``app(...)`` builds the whole command tree again (~20-50 ms) at
    each call; a process running :func:`main` many times (a test suite, a
    Python caller driving the CLI) builds it once. The commands keep no state
    between calls: click makes a new context for each.
    """
    return typer.main.get_command(app)


def _run_app(argv: list[str] | None) -> int:
    """:func:`main`'s work: the app run, every failure turned into its line and exit status."""
    from ..interrupts import interrupts_as_keyboard_interrupt
    from .common import GIVEN_ARGS

    GIVEN_ARGS.set(tuple(sys.argv[1:] if argv is None else argv))  # an output path as typed (common.as_typed)
    try:
        with interrupts_as_keyboard_interrupt():  # SIGTERM too, so atomic writes clean up (see mocapkit.interrupts)
            result = command()(args=argv, standalone_mode=False)
    except BaseException as exc:  # noqa: BLE001 - every failure ends in one line and an exit status
        return _exit_status(exc, sys.argv[1:] if argv is None else list(argv))
    if result == EXIT_INTERRUPTED:  # typer turns an interrupt inside a command into Exit(130)
        return _said_interrupted()
    return result if isinstance(result, int) else 0


def run() -> None:
    """The console script and ``python -m mocapkit``: :func:`main`, then the process ends without the
    interpreter's teardown of its modules (0.6 s of torch's alone, after every output was written and closed).

    What an ordinary exit does first still happens: the ``atexit`` handlers run (the numba precompile
    helper is stopped, multiprocessing's children are ended, temporary folders removed), stdout and stderr
    are flushed and, after a command that succeeded, thread pools are stopped and non-daemon threads
    joined (after a failure or an interrupt nothing is left to finish, and no thread a stopped pool
    left behind may hold the exit).
    """
    # CPython's own first steps of an exit (Py_FinalizeEx), looked up before the command: from main's return to the
    # guarded join below no signal check is left, where a Ctrl-C (the command's handlers restored) raised past
    # every handler: a traceback, and the process killed by SIGINT instead of exit 130
    join_threads, run_exitfuncs = getattr(threading, "_shutdown", None), getattr(atexit, "_run_exitfuncs", None)
    try:
        code = main()
    except KeyboardInterrupt:  # as the command began or ended, outside main's own handling of it
        code = _said_interrupted()
    if join_threads is None or run_exitfuncs is None:
        sys.exit(code)
    if code == 0:  # thread pools told to stop (their atexit hooks), then every non-daemon thread joined
        try:
            join_threads()
        except KeyboardInterrupt:  # Ctrl-C while waiting: stop waiting, still run the handlers below
            code = EXIT_INTERRUPTED
    # else the work stopped (an interrupt, an error) and nothing is left to finish: a thread a
    # stopped pool left behind (a manager waiting on a killed worker, which hung 3 of 47
    # interrupted `db build`s before parallel._stop_pool ended it) must not hold the exit
    try:
        run_exitfuncs()
    except KeyboardInterrupt:
        code = code or EXIT_INTERRUPTED
    try:  # the loop inside: its step to the next stream is a signal check too
        for stream in (sys.stdout, sys.stderr):
            if stream is None:  # started with it closed (>&-, 2>&-): Python's None, nothing to flush
                continue
            try:
                stream.flush()
            except (OSError, ValueError):  # a closed pipe (| head): nothing more can reach it
                pass
    except KeyboardInterrupt:  # Ctrl-C while a slow reader holds the pipe: what it has not read is not waited for
        code = code or EXIT_INTERRUPTED
    os._exit(code)


def interrupted_status() -> int:
    """Exit status of an interrupted command: 130 after Ctrl-C, 143 after SIGTERM (:func:`mocapkit.interrupts.exit_status`)."""
    from ..interrupts import exit_status

    return exit_status()


def _said_interrupted() -> int:
    """The one line of an interrupted command, on stderr; returns its exit status (:func:`interrupted_status`).
    Nothing for a command whose reader closed its output (141), as a shell says nothing of ``yes | head``."""
    from ..interrupts import by_closed_stream

    if by_closed_stream():
        return interrupted_status()
    print("mocapkit: interrupted; no partial output was left", file=sys.stderr)
    return interrupted_status()


def memory_line(args: list[str], exc: MemoryError) -> str:
    """The one line for running out of memory: the command's first argument that is a file (the take or folder it
    was working on; ``mocapkit`` itself when none is), what ran out, and what numpy asked for when it says so."""
    first = next((a for a in args[1:] if not a.startswith("-") and os.path.exists(a)), None)
    asked = f" ({exc})" if str(exc) else ""
    return (f"{first or 'mocapkit ' + (args[0] if args else '')}: out of memory{asked}; "
            f"give it more memory, or a shorter take")


def _exit_status(exc: BaseException, args: list[str] = ()) -> int:
    """Print the one line for a failure and return the exit status (see :func:`main`); ``args`` the command's."""
    if isinstance(exc, typer.Abort) and isinstance(exc.__cause__, EOFError):  # click's Abort for a file cut short
        return _fail(f"a file ended before its data did (EOFError: {exc.__cause__})")
    if isinstance(exc, (KeyboardInterrupt, typer.Abort)):
        return _said_interrupted()
    if isinstance(exc, SystemExit):
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else EXIT_BAD_INPUT)
    if isinstance(exc, typer.Exit):
        return exc.exit_code
    if isinstance(exc, MocapError):
        return _fail(str(exc))
    usage = _usage_error(exc)
    if usage is not None:
        return usage
    if isinstance(exc, FileNotFoundError) and not (isinstance(exc.filename, str) and TEMP_NAME.match(exc.filename)):
        return _fail(f"{exc.filename or exc}: no such file")
    if isinstance(exc, OSError):
        return _fail(os_error_line(exc))
    if isinstance(exc, ModuleNotFoundError) and exc.name == "torch":  # installed without its declared dependency
        return _fail("the networks (fill, denoise, train) need PyTorch: pip install torch==2.13.0 (the CPU wheel); "
                     "or leave those steps out (clean --steps detect,repair)")
    if isinstance(exc, MemoryError):
        return _fail(memory_line(list(args), exc))
    if not isinstance(exc, Exception):  # GeneratorExit and the like: not ours to swallow
        raise exc
    return _fail(f"{type(exc).__name__}: {exc}")  # anything unexpected: still one line, naming the exception
