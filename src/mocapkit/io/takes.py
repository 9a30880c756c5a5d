"""Reading a take the way every command does: any supported file, an ASF given for AMC files, motion only where needed.

:func:`mocapkit.io.load` reads one file by its suffix. Commands need a little
more, and the same everywhere:

- an AMC file's skeleton may be given explicitly (the CLI's ``--asf``, the
  Python ``asf=``); otherwise the reader looks for the ASF beside the AMC.
  The explicit skeleton applies to ``.amc`` files only, and giving one when
  no input is an AMC file is an error rather than silently ignored;
- most commands need joint angles, so a marker file (C3D) is refused with a
  line that says what to do instead.

Every error is a one-line :class:`~mocapkit.errors.MocapFormatError` naming
the file.

>>> import mocapkit
>>> m = load_motion(mocapkit.samples.path("12_walk.amc"))
>>> m.skeleton.num_joints > 20
True
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

from ..errors import MocapFormatError

__all__ = ["load_take", "load_motion", "check_asf", "asf_of"]


def _is_amc(path: os.PathLike | str) -> bool:
    return Path(path).suffix.lower() == ".amc"


def check_asf(asf: os.PathLike | str | None, inputs: Iterable[os.PathLike | str | None]) -> None:
    """Refuse an explicit ASF skeleton that no input can use, or that is not a readable ``.asf`` file.

    ``inputs``: the motion files the skeleton is meant for (``None`` entries
    ignored). Raises :class:`~mocapkit.errors.MocapFormatError` naming the ASF.
    """
    if asf is None:
        return
    asf = Path(asf)
    if asf.suffix.lower() != ".asf":
        raise MocapFormatError(asf, "an ASF skeleton file (.asf) is expected for --asf")
    if not asf.is_file():
        raise MocapFormatError(asf, "no such file" if not asf.exists() else "not a regular file")
    if not any(_is_amc(p) for p in inputs if p is not None):
        raise MocapFormatError(asf, "--asf is the skeleton of an .amc input, and no input is an .amc file")


def asf_of(path: os.PathLike | str, asf: os.PathLike | str | None = None) -> Path | None:
    """The ASF an AMC take at ``path`` is read with: ``asf`` when given, else the one beside it; None otherwise."""
    if not _is_amc(path):
        return None
    if asf is not None:
        return Path(asf)
    from .asfamc import find_asf

    try:
        return find_asf(path)
    except MocapFormatError:
        return None


def load_take(path: os.PathLike | str, asf: os.PathLike | str | None = None):
    """Read a motion (:class:`~mocapkit.motion.Motion`) or marker take (:class:`~mocapkit.io.c3d.MarkerSet`).

    ``asf``: the skeleton of an ``.amc`` file (ignored for other formats, so one
    ``asf`` can serve a list of mixed inputs; :func:`check_asf` refuses an
    ``asf`` that serves none). Without it, an AMC's ASF is looked for beside it.
    """
    from . import load

    if asf is not None and _is_amc(path):
        return load(path, asf=Path(asf))
    return load(path)


def load_motion(path: os.PathLike | str, asf: os.PathLike | str | None = None, purpose: str = "this command"):
    """Read a take that must have joint angles (a :class:`~mocapkit.motion.Motion`); a marker file is refused.

    ``purpose``: who needs the angles ("clean", "a query", ...), used in the
    one-line refusal ``PATH: a marker file has no joint angles, which clean needs; ...``.
    """
    from ..motion import Motion

    take = load_take(path, asf)
    if not isinstance(take, Motion):
        raise MocapFormatError(path, f"a marker file has no joint angles, which {purpose} needs; solve it to a skeleton first")
    return take
