"""What every command shares: the console, the output guard, option texts and small formatting helpers.

The console prints with rich markup **off**: joint, clip and file names come
from user files and may contain ``[/b]`` or ``[/]``, which rich would read as
markup (and crash on, or hide). Emoji codes are off too: a change id
``repair:b:3-4`` or a joint named ``:smile:`` printed as an emoji
(``repair🅱3-4``). Nothing this package prints uses markup or emoji, so no
user string needs escaping case by case. Lines are not wrapped or cut
(``soft_wrap``), so a long path prints whole.
"""

from __future__ import annotations

import contextlib
import inspect
import math
import os
import re
import warnings
from contextvars import ContextVar
from pathlib import Path
from typing import Iterable, Optional

import typer
from rich.console import Console
from typer.core import TyperCommand, TyperGroup

from ..words import listed, plural

__all__ = [
    "console",
    "guard",
    "percent",
    "plural",
    "listed",
    "print_fields",
    "print_table",
    "overwrite_option",
    "asf_option",
    "amc_fps_option",
    "unit_option",
    "context_option",
    "joint_map_option",
    "warnings_as_notes",
    "read_map",
    "CONTEXT_HELP",
    "executor_option",
    "check_executor",
    "OVERWRITE_HELP",
    "STEPS_HELP",
    "FlagsCommand",
    "FlagsGroup",
]

console = Console(markup=False, emoji=False, highlight=False, soft_wrap=True)


def _cli_type(shown: str) -> str:
    """The type column typer shows for a parameter (``<list[Path]>``, ``<list[str]>``, ``<int range>``,
    ``<float,float>...``: Python annotations) in the words of the other options (``<path>``, ``<str>``, ``<int>``,
    ``<float> <float>``). A repeated option or an argument taking many values says so by its ``...`` or its help."""
    shown = re.sub(r"list\[(\w+)\]", lambda m: m.group(1).lower(), shown)
    shown = shown.replace(" range>", ">")
    if re.fullmatch(r"<\w+(,\w+)+>\.\.\.", shown):  # a tuple option (--speed LO HI)
        shown = " ".join(f"<{t}>" for t in shown[1:-4].split(","))
    return shown


def _flags_without_type(params, ctx=None):
    """``params`` with each on/off option's type column left empty: typer's help shows ``--overwrite <bool>``, which
    reads as an option taking a value; a flag is given alone (``--mirror``, or ``--smooth / --no-smooth``).
    Every other type column reads as a command line's (:func:`_cli_type`), not as a Python annotation."""
    for p in params:
        if getattr(p, "is_flag", False) and p.metavar is None:
            p.metavar = ""
        elif ctx is not None and hasattr(p, "display_type_rich"):
            shown = p.display_type_rich(ctx)
            if shown and _cli_type(shown) != shown:
                if p.param_type_name == "option":
                    p.metavar = _cli_type(shown)
                else:  # an argument's metavar would rename it (FILES...): only its type column changes
                    p.display_type_rich = lambda ctx, _shown=_cli_type(shown): _shown
    return params


def _unwrapped(text: str | None) -> str | None:
    """A command's help with each paragraph on one line: typer keeps the docstring's line breaks after the first
    paragraph, so at 80 columns the terminal's wrap and the docstring's broke the text into ragged lines. Paragraphs
    stay apart (a blank line); one that starts with ``\\b`` (click's "keep as written") is left as it is."""
    if not text:
        return text
    paragraphs = inspect.cleandoc(text).split("\n\n")
    return "\n\n".join(p if p.startswith("\b") else " ".join(line.strip() for line in p.splitlines()) for p in paragraphs)


class FlagsCommand(TyperCommand):
    """A command whose ``--help`` shows flags as flags (:func:`_flags_without_type`) and its text as paragraphs
    the terminal wraps (:func:`_unwrapped`)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.help = _unwrapped(self.help)

    def get_params(self, ctx):
        return _flags_without_type(super().get_params(ctx), ctx)


class FlagsGroup(TyperGroup):
    """A command group whose commands (and its own ``--help``) show flags as flags (:class:`FlagsCommand`)."""

    command_class = FlagsCommand

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.help = _unwrapped(self.help)

    def get_params(self, ctx):
        return _flags_without_type(super().get_params(ctx), ctx)

OVERWRITE_HELP = ("Replace output files that already exist (without it they are refused; an input is never "
                  "replaced). Missing parent folders are created.")
STEPS_HELP = "Comma-separated steps: fill, detect, repair, denoise (they always run in that order)."


def overwrite_option():
    """The ``--overwrite`` option of every command that writes files."""
    return typer.Option(False, "--overwrite", help=OVERWRITE_HELP)


def asf_option(what: str = "input(s) and reference"):
    """The ``--asf`` option of every command that reads AMC files; ``what``: the files it reads (``info``: "input")."""
    return typer.Option(None, "--asf", help=f"Skeleton (.asf) for the .amc {what} (default: the ASF beside each AMC).")


def amc_fps_option(what: str = "input(s) and reference"):
    """The ``--amc-fps`` option of every command that reads AMC files (an AMC states no rate of its own)."""
    return typer.Option(None, "--amc-fps", metavar="FPS",
                        help=f"Frame rate of the .amc {what} (default: the rate the file states in "
                             "mocapkit's comment line, else the one an HDM05 name ends with, else 120, the CMU and "
                             "HDM05 rate).")


def noise_deg_option():
    """The ``--noise-deg`` option of ``clean`` and ``clean-batch`` (:func:`mocapkit.cleaning.pipeline.noisy_cells`)."""
    return typer.Option(None, "--noise-deg", metavar="DEG",
                        help="Noise level in degrees over which a joint's cells are denoised (a run of at least "
                             "0.4 s; default 1). Raise it for takes at 24-30 fps whose fingers and toes wobble "
                             "(docs/guide/cleaning.md: takes delivered at 24-30 fps).")


def check_noise_deg(noise_deg: float | None) -> None:
    """Refuse a ``--noise-deg`` that is not a positive number of degrees, in one line."""
    if noise_deg is not None and not (math.isfinite(noise_deg) and noise_deg > 0):
        from ..errors import MocapError

        raise MocapError(f"--noise-deg must be a positive number of degrees, got {noise_deg:g}")


def unit_option(what: str = "input(s) and reference"):
    """The ``--unit`` option of the commands that measure lengths (:func:`mocapkit.io.takes.with_unit`); ``what``: the
    files it applies to (``info``: "input")."""
    return typer.Option(None, "--unit", metavar="mm|cm|m|in",
                        help=f"Length unit of the {what} where the file states none (a BVH; a marker "
                             "file with an empty unit field). Default: read from the bones, assuming an adult, or from "
                             "the marker distances.")


def max_gap_option(batch: bool = False):
    """The ``--max-gap`` option of ``clean`` and ``clean-batch`` (marker captures: ``clean_markers(max_gap_s=)``)."""
    who = "Marker captures" if batch else "A marker capture"
    return typer.Option(None, "--max-gap", metavar="S", min=0.0,
                        help=f"{who}: gaps longer than S seconds are left missing.")


def max_fill_error_option(batch: bool = False):
    """The ``--max-fill-error`` option of ``clean`` and ``clean-batch`` (marker captures:
    ``clean_markers(max_error_mm=)``; a batch's joint-angle takes ignore it and ``--max-gap``)."""
    who = "Marker captures" if batch else "A marker capture"
    return typer.Option(
        None, "--max-fill-error", metavar="MM", min=0.0,
        help=f"{who}: a fill expected to be off by more than MM millimetres (its error on stretches like the gap "
             "where the marker is seen), or whose error is unknown (unvalidated), is left missing (default: the "
             "marker's distance to its nearest marker, at least 50 mm; unvalidated fills written)."
             + (" Joint-angle takes ignore this and --max-gap." if batch else ""))


def zeros_option(who: str = "Marker files"):
    """The ``--zeros-as-gaps/--keep-zeros`` option of ``convert``, ``clean`` and ``clean-batch``: how a .c3d or .trc
    marker file's samples at exactly (0, 0, 0) are read (the readers' ``zeros_as_gaps``: True, False, None to decide
    from the data, docs/guide/markers.md)."""
    return typer.Option(
        None, "--zeros-as-gaps/--keep-zeros",
        help=f"{who}: read samples at exactly (0, 0, 0) as gaps, or keep them (default: decided from the data).")


def keep_modelled_option():
    """The ``--keep-modelled`` option of ``convert``, ``corrupt`` and ``clean``: a .trc output written from a C3D keeps its
    modelled quantities (angles, forces, moments, powers) as points (:func:`mocapkit.io.save_markers`)."""
    return typer.Option(
        False, "--keep-modelled",
        help="A .c3d marker capture to .trc: also write the C3D's modelled quantities (joint angles, forces, "
             "moments, powers) as points, under the TRC's length unit; left out by default (a TRC holds markers: "
             "OpenSim). Refused for any other input or output (a .c3d or .npz output keeps every point).")


CONTEXT_HELP = ("What the take is compared with: a motion database folder, a folder of takes or motion files "
                "(repeat the option; built into a database once and cached under $MOCAPKIT_CACHE_DIR/contexts, else "
                "$XDG_CACHE_HOME/mocapkit/contexts or ~/.cache/mocapkit/contexts), or 'none' for the clip alone. Default: the bundled default context "
                "(common human motion on the CMU/HDM05 Acclaim skeleton; takes on another skeleton are judged against "
                "themselves).")


JOINT_MAP_HELP = ("JSON object {this rig's joint: joint of a known rig}, e.g. {\"kt_b04\": \"Hand_L\"}, for a rig whose joint "
                  "names say no roles (hands, feet, head): the clips of a database or --context folder get these "
                  "names (docs/guide/databases-and-search.md). One file serves every command.")


def joint_map_option():
    """The ``--joint-map`` option of ``db build`` and the commands that build a ``--context`` folder."""
    return typer.Option(None, "--joint-map", help=JOINT_MAP_HELP)


def read_map(path):
    """The ``--joint-map`` file's map (:func:`mocapkit.database.read_joint_map`), None when not given."""
    from ..database import read_joint_map

    return None if path is None else read_joint_map(path)


def context_option():
    """The ``--context`` option of the self-similarity commands (:func:`mocapkit.context.resolve_context`)."""
    return typer.Option(None, "--context", help=CONTEXT_HELP)


def executor_option(what: str):
    """The ``--executor`` option (where ``what`` runs)."""
    return typer.Option(None, "--executor", help=f"Where {what}: processes (default), serial (this process), dask "
                                                 "(a local cluster) or a Dask scheduler address tcp://HOST:PORT.")


def check_executor(spec: Optional[str]) -> None:
    """Refuse an ``--executor`` value before any work (:func:`mocapkit.parallel.check_executor`), naming the flag."""
    from ..parallel import check_executor as check

    check(spec, option="--executor")


def guard(outputs: Iterable, inputs: Iterable, overwrite: bool = False) -> None:
    """The output guard of every command, run before any work: :func:`mocapkit.io.outputs.check_outputs`.

    ``inputs`` may hold lists (``--context``) and ``None`` entries.
    """
    from ..io.outputs import check_outputs

    flat = []
    for i in inputs:
        if isinstance(i, (list, tuple)):
            flat.extend(i)
        else:
            flat.append(i)
    check_outputs([as_typed(o) for o in outputs], flat, overwrite=overwrite, how="pass --overwrite")


#: The command line's words as typed (set by :func:`mocapkit.cli.main`): a path option's value as the user wrote
#: it, which the Path typer makes of it no longer shows (``out/x.bvh/`` becomes ``out/x.bvh``).
GIVEN_ARGS: ContextVar[tuple[str, ...]] = ContextVar("mocapkit_given_args", default=())


def as_typed(path):
    """``path`` (a command's output Path) as the user typed it where that ends with a path separator (the user named
    a folder, which :func:`mocapkit.io.outputs.check_outputs` refuses); else ``path``. The value is a word of its
    own (``-o out/x.bvh/``), after a long option's ``=`` (``--out=out/x.bvh/``) or joined to a short option
    (``-oout/x.bvh/``; ``-o=x/``, whose value click takes as ``=x/``)."""
    if path is None:
        return None
    for word in GIVEN_ARGS.get():
        values = [word]
        if word.startswith("--") and "=" in word:
            values.append(word.split("=", 1)[1])
        elif word.startswith("-") and len(word) > 2:  # a short option with its value joined to it
            values.append(word[2:])
        for value in values:
            if value.endswith(tuple({"/", os.sep})) and len(value) > 1 and Path(value) == Path(path):
                return value
    return path


def percent(part: int, whole: int) -> str:
    """``part`` of ``whole`` as a percentage that never rounds to 100 or 0 unless it is: "99.98", "> 99.999".

    One decimal where that tells the share apart from 100 and from 0, more where it does not (14 of
    85,312 samples changed read "100.0 % untouched", as if nothing had), up to three, then "> 99.999"
    or "< 0.001".
    """
    if whole <= 0 or part in (0, whole):
        return "100" if whole > 0 and part == whole else "0"
    share = 100.0 * part / whole
    for digits in (1, 2, 3):
        text = f"{share:.{digits}f}"
        if 0.0 < float(text) < 100.0:
            return text
    return "> 99.999" if share > 50 else "< 0.001"


def print_fields(rows: Iterable[tuple[str, str]]) -> None:
    """Print ``name  value`` lines, names aligned, values whole (never cut or wrapped)."""
    rows = list(rows)
    width = max((len(k) for k, _ in rows), default=0)
    for k, v in rows:
        console.print(f"{k:<{width}}  {v}")


def print_table(header: Iterable[str], rows: Iterable[Iterable[str]]) -> None:
    """Print a table as aligned columns, one line per row, cells whole (a long path is never cut or folded)."""
    table = [list(map(str, header))] + [list(map(str, r)) for r in rows]
    widths = [max(len(r[c]) for r in table) for c in range(len(table[0]))]
    for r in table:
        console.print("  ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip())


@contextlib.contextmanager
def warnings_as_notes(notes: list):
    """Within the block, a plain :class:`UserWarning` (what :func:`mocapkit.io.save` says a file cannot hold, e.g.
    :func:`mocapkit.io.euler_branches.off_axis_note`: a hinge turned about other axes) is appended to ``notes``, for
    the command to print as a ``note:`` line beside its others, instead of Python's warning format (its source
    file and line); every other warning (a subclass, a RuntimeWarning) is given on as it was raised."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        yield notes
    for w in caught:
        if w.category is UserWarning:
            notes.append(str(w.message))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)


def save_take(motion, out: Path, inp: Path | None, asf=None, overwrite: bool = False, **kwargs) -> None:
    """``io.save`` of a command's output take, and, for an AMC output, the input's ASF beside it where the
    output's folder lacks it (:func:`mocapkit.io.takes.asf_for_output`: an AMC is read with the ASF beside
    it), said in one line, and what OUT leaves out of the input (:func:`mocapkit.io.motion_notes`: a BVH's other
    roots) in a ``note:`` line. Checked before anything is written."""
    from .. import io
    from ..io.outputs import removed_on_failure
    from ..io.takes import asf_for_output, asf_of, place_asf, unread_amc_note

    skeleton = asf_of(inp, asf) if inp is not None else None
    copy = asf_for_output(out, skeleton, overwrite, how="use --overwrite")
    notes = io.motion_notes(motion, out, kwargs.get("like"))  # before the write: what OUT leaves out of the input
    with removed_on_failure([copy, out], overwrite=overwrite):
        place_asf(copy, skeleton)  # first: an AMC is never left without the ASF it is read with
        with warnings_as_notes(notes):  # what OUT cannot hold of the take (a hinge's other axes): said below
            io.save(motion, out, asf=skeleton if skeleton is not None else asf, copy_asf=False, **kwargs)
    if copy is not None:
        console.print(f"copied the skeleton {skeleton} to {copy}: an AMC is read with the ASF beside it")
    unread = unread_amc_note(out, inp)
    for note in notes + ([unread] if unread else []):
        console.print(f"note: {note}")


def database_rows(summary: dict) -> list[tuple[str, str]]:
    """``MotionDatabase.summary()`` as the (label, text) rows ``db info`` and ``info`` print."""
    return [(k.replace("_", " "), ", ".join(f"{a} ({b})" for a, b in v.items()) if isinstance(v, dict) else str(v))
            for k, v in summary.items()]
