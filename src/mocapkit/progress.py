"""Progress bars: on a terminal while long work runs, not in logs and pipes.

Every bar of mocapkit (tqdm) is made with ``disable=bar_disabled(progress)``:
asked for and writing to a terminal, it is drawn; written to a file or a pipe
(a batch's log, ``2>&1 | tee``) it is left out, so the log holds the result
lines only, one per line. ``MOCAPKIT_PROGRESS=1`` draws the bars anyway (a
supervisor that reads them), ``MOCAPKIT_PROGRESS=0`` never.

A terminal is a terminal whatever size it reports: a pseudo-terminal opened
without one (``script``, some CI runners) reports 0 x 0, and tqdm, which hides
a bar whose line is past the screen's last row, hid every bar there. Each bar
is made with ``**bar_size()`` (:func:`bar_size`: 80 x 24 where the terminal
reports 0). A command whose work has steps rather than items (``mocapkit fill``:
its models load, the gaps fill, the take is written) shows them on a rich bar
(:func:`steps_bar`), under the same rule.

>>> bar_disabled(False)
True
"""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager

__all__ = ["bar_disabled", "bar_size", "steps_bar"]


def bar_disabled(progress: bool) -> bool | None:
    """tqdm's ``disable`` for a bar the caller asks for (``progress``): True (never drawn), False (always), or
    None (drawn only when its stream is a terminal; tqdm's own test)."""
    if not progress:
        return True
    forced = os.environ.get("MOCAPKIT_PROGRESS", "").strip()
    if forced in ("0", "1"):
        return forced == "0"
    return None


def bar_size(stream=None) -> dict[str, int]:
    """tqdm's ``ncols`` and ``nrows`` for a bar on ``stream`` (standard error by default): ``{}`` (tqdm reads the
    size itself) where the stream is no terminal or the terminal reports its size, else the 80 x 24 a terminal is
    taken to be where it reports 0 columns or 0 rows (a pseudo-terminal opened without a size), as rich and
    :func:`shutil.get_terminal_size` take it: tqdm's own reading gave 0 rows there, and hid the bar."""
    stream = sys.stderr if stream is None else stream
    try:
        size = os.get_terminal_size(stream.fileno())
    except (AttributeError, ValueError, OSError):  # no file descriptor (a StringIO), or not a terminal
        return {}
    if size.columns and size.lines:
        return {}
    return {"ncols": size.columns or 80, "nrows": size.lines or 24}


@contextmanager
def steps_bar(name: str, total: int, progress: bool = True):
    """A rich bar on standard error over ``total`` steps of one command's work on ``name`` ("fill take.bvh: loading
    the models", then "filling ...", with the time elapsed): yields ``step(words)``, which starts the next step and
    says it (the first call the first step; each step drawn as it starts). Drawn where :func:`bar_disabled` says (a terminal of any size,
    ``MOCAPKIT_PROGRESS``), transient: gone once the work is done, so the command's own lines stay as they were."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    mode = bar_disabled(progress)
    console = Console(stderr=True, force_terminal=True if mode is False else None, markup=False, emoji=False,
                      highlight=False)
    bar = Progress(TextColumn("{task.fields[what]}", markup=False), BarColumn(), MofNCompleteColumn(),
                   TimeElapsedColumn(),
                   TextColumn("{task.description}", markup=False), console=console, transient=True,
                   disable=mode is True or (mode is None and not console.is_terminal))
    task = bar.add_task("", total=total, what=name)  # a field: a name's braces are no format
    started = []

    def step(words: str) -> None:
        if started:
            bar.advance(task)
        started.append(words)
        bar.update(task, description=words)
        bar.refresh()  # each step drawn once at least, however soon the next one comes

    with bar:
        yield step
        bar.update(task, completed=total)
