"""Reading a take the way every command does: any supported file, an ASF given for AMC files, motion only where needed.

:func:`mocapkit.io.load` reads one file by its suffix. Commands need a little
more, and the same everywhere:

- an AMC file's skeleton may be given explicitly (the CLI's ``--asf``, the
  Python ``asf=``); otherwise the reader looks for the ASF beside the AMC.
  The explicit skeleton applies to ``.amc`` files only, and giving one when
  no input is an AMC file is an error rather than silently ignored; so does
  an AMC's frame rate (``--amc-fps``, ``fps=``: an AMC has no field for it,
  :func:`mocapkit.io.asfamc.amc_rate`);
- the length unit of a take whose file states none (``--unit``, ``unit=``):
  a BVH's bones, a marker file with an empty unit field; one that disagrees
  with a unit the file states is refused (:func:`with_unit`);
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

from ..errors import MissingFileError, MocapFormatError

__all__ = ["load_take", "load_motion", "check_asf", "asf_of", "asf_for_output", "place_asf", "file_first_frame",
           "with_unit", "check_unit", "UNIT_CHOICES", "CLI_AMC_NAMES"]

UNIT_CHOICES = ("mm", "cm", "m", "in")
"""The length units ``--unit`` names (millimetres, centimetres, metres, inches)."""

CLI_AMC_NAMES = ("--asf", "--amc-fps")
"""What the command line calls an AMC's skeleton and frame rate (:func:`check_asf`'s ``names``)."""


def _is_amc(path: os.PathLike | str) -> bool:
    return Path(path).suffix.lower() == ".amc"


def check_asf(asf: os.PathLike | str | None, inputs: Iterable[os.PathLike | str | None], fps: float | None = None,
              *, names: tuple[str, str] = ("asf=", "amc_fps=")) -> None:
    """Refuse an explicit ASF skeleton that no input can use, or that is not a readable ``.asf`` file; and an AMC
    frame rate (``fps``) when no input is an AMC file or it is no rate mocapkit reads.

    ``inputs``: the motion files the skeleton is meant for (``None`` entries
    ignored). ``names``: what the caller calls the skeleton and the rate, said in
    the refusals: the library's keywords by default, the command line's
    :data:`CLI_AMC_NAMES` (``--asf``, ``--amc-fps``) from a command. Raises
    :class:`~mocapkit.errors.MocapFormatError` naming the ASF
    (:class:`~mocapkit.errors.MocapError` for the rate).
    """
    asf_name, fps_name = names
    inputs = [p for p in inputs if p is not None]
    if fps is not None:
        from ..errors import MocapError
        from ..motion import check_fps

        check_fps(fps, fps_name.rstrip("="))
        if not any(_is_amc(p) for p in inputs):
            raise MocapError(f"{fps_name} is the frame rate of an .amc input, and no input is an .amc file")
    if asf is None:
        return
    asf = Path(asf)
    if asf.suffix.lower() != ".asf":
        raise MocapFormatError(asf, f"an ASF skeleton file (.asf) is expected for {asf_name}")
    if not asf.is_file():
        raise (MocapFormatError(asf, "not a regular file") if asf.exists() else MissingFileError(asf))
    if not any(_is_amc(p) for p in inputs if p is not None):
        raise MocapFormatError(asf, f"{asf_name} is the skeleton of an .amc input, and no input is an .amc file")


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


def unread_amc_note(out: os.PathLike | str, source: os.PathLike | str | None) -> str | None:
    """One line for an AMC just written to ``out`` that no ASF beside it reads back, else None.

    An AMC holds no skeleton (:func:`mocapkit.io.asfamc.find_asf`); a take read from ``.npz`` keeps its
    skeleton but no ASF file to copy beside the output (:func:`asf_for_output` copies only a file), so the
    written AMC reads back only with ``--asf``: said when it is written, not when a later command fails on it.
    ``source``: the input file the take was read from, named in the line.
    """
    if not _is_amc(out):
        return None
    from .asfamc import find_asf

    try:
        find_asf(out)
        return None
    except MocapFormatError:
        came = f" ({Path(source).name} keeps the skeleton but no .asf file to copy)" if source is not None else ""
        return (f"{out}: no ASF beside it{came}: read it back with --asf FILE (asf= in Python), the skeleton "
                "the take was first read with")


def load_take(path: os.PathLike | str, asf: os.PathLike | str | None = None, fps: float | None = None,
              unit: str | None = None, unit_option: str = "unit=", zeros_as_gaps: bool | None = None):
    """Read a motion (:class:`~mocapkit.motion.Motion`) or marker take (:class:`~mocapkit.io.c3d.MarkerSet`).

    ``asf``: the skeleton of an ``.amc`` file (ignored for other formats, so one
    ``asf`` can serve a list of mixed inputs; :func:`check_asf` refuses an
    ``asf`` that serves none). Without it, an AMC's ASF is looked for beside it.
    ``fps``: an ``.amc`` file's frame rate (ignored for other formats; by default
    :func:`mocapkit.io.asfamc.amc_rate`). ``unit``: the length unit (one of
    :data:`UNIT_CHOICES`) of a take whose file states none (:func:`with_unit`; ``unit_option``: how a refusal
    names it, Python's ``unit=`` by default, the CLI passes its ``--unit``). ``zeros_as_gaps``: how a .c3d or .trc
    file's samples at exactly (0, 0, 0) are read (True gaps, False positions, None decided from the data:
    :func:`mocapkit.io.c3d.apply_zero_gaps`; ignored for other formats, as ``asf`` is).
    """
    from . import load

    check_unit(unit, unit_option)
    kwargs = {}
    if _is_amc(path):
        if asf is not None:
            kwargs["asf"] = Path(asf)
        if fps is not None:
            kwargs["fps"] = float(fps)
    if unit is not None and Path(path).suffix.lower() in (".c3d", ".trc"):
        kwargs["units"] = unit  # the reader needs it before reading a file that states none (zero gaps)
    if zeros_as_gaps is not None and Path(path).suffix.lower() in (".c3d", ".trc"):
        kwargs["zeros_as_gaps"] = bool(zeros_as_gaps)
    take = load(path, **kwargs)
    return with_unit(take, unit, path, unit_option) if unit is not None and "units" not in kwargs else take


def check_unit(unit: str | None, option: str = "unit=") -> None:
    """Refuse a unit that is none of :data:`UNIT_CHOICES` (:class:`~mocapkit.errors.MocapError`); None passes.
    ``option``: how the message names it (Python's ``unit=`` by default, the CLI's ``--unit``)."""
    if unit is not None and unit not in UNIT_CHOICES:
        from ..errors import MocapError

        lead = option.rstrip()
        raise MocapError(f"{lead}{'' if lead.endswith('=') else ' '}{unit!r}: one of {', '.join(UNIT_CHOICES)} "
                         "is expected")


def with_unit(take, unit: str | None, path: os.PathLike | str, option: str = "unit="):
    """``take`` with the length unit ``unit`` (mm, cm, m, in) where its file states none.

    A :class:`~mocapkit.motion.Motion` gets ``skeleton.unit_cm`` (what
    :func:`~mocapkit.motion.unit_scale_cm` reads instead of guessing from the
    bones, which assumes an adult); a marker take read from an npz keeps its
    stated unit. A unit that disagrees with one the file states (an ASF's
    ``:units``, an npz's) is refused: :class:`~mocapkit.errors.MocapFormatError`
    naming ``path`` and the option as the caller spells it (``option``: Python's ``unit=`` by default, the CLI's
    ``--unit``).
    None: ``take`` as it is.
    """
    if unit is None:
        return take
    import dataclasses

    from ..markerset import MarkerSet, length_unit_cm
    from ..motion import Motion

    check_unit(unit, option)
    cm = length_unit_cm(unit)
    if isinstance(take, MarkerSet):
        stated = length_unit_cm(take.units)
    elif isinstance(take, Motion):
        stated = take.skeleton.unit_cm
    else:
        return take
    if stated is not None and abs(float(stated) - cm) > 1e-9 * cm:
        raise MocapFormatError(path, f"the file states its length unit ({float(stated):.4g} cm), not {unit}: "
                                     f"{option} is for a file that states none")
    if isinstance(take, MarkerSet) or stated is not None:
        return take
    return dataclasses.replace(take, skeleton=dataclasses.replace(take.skeleton, unit_cm=cm))


def load_motion(path: os.PathLike | str, asf: os.PathLike | str | None = None, purpose: str = "this command",
                fps: float | None = None, unit: str | None = None, unit_option: str = "unit=",
                instead: str = "solve it to a skeleton first"):
    """Read a take that must have joint angles (a :class:`~mocapkit.motion.Motion`); a marker file is refused.

    ``purpose``: who needs the angles ("clean", "a query", ...), used in the
    one-line refusal ``PATH: a marker file has no joint angles, which clean needs; ...``; ``instead``: what the
    line ends with, what to do with a marker file (a command that has a marker counterpart names it).
    ``fps``, ``unit``, ``unit_option``: as for :func:`load_take`.
    """
    from ..motion import Motion

    take = load_take(path, asf, fps=fps, unit=unit, unit_option=unit_option)
    if not isinstance(take, Motion):
        raise MocapFormatError(path, f"a marker file has no joint angles, which {purpose} needs; {instead}")
    return take


def asf_for_output(out: os.PathLike | str, source: os.PathLike | str | None, overwrite: bool = False,
                   how: str = "pass overwrite=True") -> Path | None:
    """Where the ASF ``source`` must be copied so that the AMC written to ``out`` reads back with it.

    An AMC holds no skeleton: it is read with the ASF beside it (:func:`mocapkit.io.asfamc.find_asf`).
    None when ``out`` is no AMC, ``source`` is None, or the ASF ``out`` would be read with already holds
    ``source``'s bytes. Otherwise ``source``'s own name when its stem is a prefix of ``out``'s (``HDM_bd.asf``
    for ``HDM_bd_walk.amc``), else ``out``'s stem + ``.asf``: a name ``find_asf`` picks whatever else the
    folder holds. Checked before any work (:class:`~mocapkit.errors.MocapFormatError`): that file existing
    with other contents is refused unless ``overwrite``, and so is a copy that would change the ASF
    another AMC of the folder is read with (one that read with the folder's only ASF). ``how``: what the
    refusal tells the caller to do to replace it (the library's parameter; the command line's ``use --overwrite``).
    """
    out = Path(out)
    if source is None or not _is_amc(out):
        return None
    from .asfamc import pick_asf

    source = Path(source)
    data = source.read_bytes()
    try:
        present = sorted(p for p in out.parent.iterdir() if p.suffix.lower() == ".asf" and p.is_file())
    except OSError:  # the folder does not exist yet
        present = []
    found = pick_asf(out.name, present)
    if found is not None and Path(found).read_bytes() == data:
        return None
    same_name = out.parent / source.name
    by_prefix = pick_asf(out.name, sorted({*present, same_name}), only_one=False) == same_name
    dst = same_name if by_prefix else out.with_suffix(".asf")
    replaced = dst.exists() and (not dst.is_file() or dst.read_bytes() != data)
    after = sorted({*present, dst})
    for amc in sorted(p for p in out.parent.glob("*") if p.suffix.lower() == ".amc" and p.name != out.name):
        was = pick_asf(amc.name, present)
        # another AMC here reads with the ASF the copy would replace, or with another one the copy would displace
        if was is not None and (was != pick_asf(amc.name, after) or (replaced and Path(was) == dst)):
            raise MocapFormatError(dst, f"the AMC output needs its skeleton ({source}) here, which would change the "
                                        f"skeleton {amc.name} is read with; write the AMC to another folder")
    if replaced and not overwrite:
        raise MocapFormatError(dst, f"exists and differs from the skeleton ({source}) the AMC output needs beside it; "
                                    f"{how} to replace it, or write another format")
    return dst


def place_asf(dst: os.PathLike | str | None, source: os.PathLike | str | None) -> None:
    """Copy ``source`` to ``dst`` (from :func:`asf_for_output`) atomically; nothing when ``dst`` is None."""
    if dst is None or source is None:
        return
    from . import atomic_write

    data = Path(source).read_bytes()
    with atomic_write(Path(dst), "wb") as fh:
        fh.write(data)


def file_first_frame(path: os.PathLike | str, take=None) -> int | None:
    """The number the input file gives its first frame, or None for a file that does not number its frames.

    An AMC numbers each frame (usually from 1), a TRC's ``Frame#`` column and a C3D's header give the
    first frame's number (:attr:`MarkerSource.first_frame` of ``take.source``, from ``take`` when it is the marker capture
    read from ``path``); a BVH or an npz of a motion does not number them. mocapkit's frames are
    0-based indexes into the take whatever the file says (the change ids of the decisions files keep
    them), and the summary and report say how they relate to this number.
    """
    from ..markerset import MarkerSet

    if isinstance(take, MarkerSet):
        src = take.source
        return None if src is None else int(src.first_frame)
    if not _is_amc(path):
        return None
    from .asfamc import amc_header

    try:
        with open(path, "rb") as fh:
            data = fh.read(1 << 20)  # the header and the first frame's number
    except OSError:
        return None
    at, _, _ = amc_header(data)
    token = data[at:].split(b"\n", 1)[0].split(b"#", 1)[0].strip()
    return int(token) if token.isdigit() else None
