"""Which takes a batch cleans and which files each writes (:func:`mocapkit.batch.clean_batch`), decided before any
take is cleaned.

:func:`find_inputs` finds the takes of IN_DIR (an earlier batch's outputs left out); :func:`output_for` and
:func:`take_files` name each take's output, record and reports in the mirrored layout; :func:`plan_outputs` names
takes of one folder that would share a file after their input's format; :func:`unwritable` says which take has a
name no file system holds; :func:`check_batch_outputs` refuses the batch where an output would replace an input or
another output (module docstring of :mod:`mocapkit.batch`).
"""

from __future__ import annotations

import fnmatch
import os
from pathlib import Path
from typing import Sequence

from .batch_folder import BATCH_MARK, marked_input
from .errors import MocapFormatError

__all__ = ["DEFAULT_PATTERNS", "find_inputs", "output_for", "take_files", "plan_outputs", "unwritable", "KIND",
           "check_batch_outputs"]

#: The file names a batch takes as inputs, unless told otherwise (``--pattern``).
DEFAULT_PATTERNS = ("*.bvh", "*.amc", "*.npz", "*.c3d", "*.trc")


def find_inputs(in_dir, patterns: Sequence[str] = DEFAULT_PATTERNS, exclude=None, earlier: list | None = None) -> list[Path]:
    """Every file under ``in_dir`` (recursive) whose name matches one of ``patterns``, sorted; left out: files
    under ``exclude``, ``.clean.npz``/``.mask.npz`` records, and the folders below ``in_dir`` that hold an
    earlier batch's outputs (a :data:`BATCH_MARK` file; appended to ``earlier`` when given)."""
    in_dir = Path(in_dir)
    excl = Path(exclude).resolve() if exclude is not None else None
    found = []
    skipped: list[tuple[Path, Path | None]] = []  # (an earlier OUT_DIR, its own IN_DIR when inside it)
    for folder, dirs, files in os.walk(in_dir):
        here = Path(folder)
        dirs.sort()
        if here != in_dir and BATCH_MARK in files:
            own = marked_input(here)
            skipped.append((here, own))
            if earlier is not None:
                earlier.append(here)
            if own is None:
                dirs[:] = []
                continue
        if any(_below(here, out) and not (own is not None and _below(here, own)) for out, own in skipped):
            continue  # an earlier batch's output folder (its files, not its own inputs below it)
        found.extend(here / f for f in files)
    out = []
    for p in sorted(found):
        if not p.is_file() or p.name.startswith("."):
            continue
        if p.name.endswith((".clean.npz", ".mask.npz")):
            continue
        if not any(fnmatch.fnmatch(p.name.lower(), pat.lower()) for pat in patterns):
            continue
        if excl is not None and (excl == p.resolve() or excl in p.resolve().parents):
            continue
        out.append(p)
    return out


def output_for(inp: Path, in_dir: Path, out_dir: Path, fmt: str = "auto", keep_suffix: bool = False) -> Path:
    """The mirrored output path of ``inp``: same sub-folder, suffix ``.bvh``/``.amc``/``.npz``.

    ``fmt``: ``"bvh"``, ``"amc"``, ``"npz"`` or ``"auto"`` (the input's suffix
    for .bvh, .npz, .c3d and .trc; .bvh for an AMC, which then needs no ASF
    beside it to be read; ``"amc"`` writes AMC takes as AMC, read back with
    their ASF, and leaves BVH and .npz takes as they are; marker captures keep their format). ``keep_suffix``: the
    input's format joins the stem after a hyphen (``take.amc`` -> ``take-amc.bvh``, ``take.c3d`` ->
    ``take-c3d.c3d``), the name :func:`clean_batch` gives takes of one folder that would otherwise share a file
    (an output, a record or a report): one rule for every format, and never a doubled suffix.

    >>> output_for(Path("in/a/take.amc"), Path("in"), Path("out")).as_posix()
    'out/a/take.bvh'
    >>> output_for(Path("in/a/take.amc"), Path("in"), Path("out"), keep_suffix=True).as_posix()
    'out/a/take-amc.bvh'
    >>> output_for(Path("in/a/take.c3d"), Path("in"), Path("out"), keep_suffix=True).as_posix()
    'out/a/take-c3d.c3d'
    >>> output_for(Path("in/b/take.bvh"), Path("in"), Path("out"), fmt="amc").as_posix()
    'out/b/take.bvh'
    """
    rel = Path(inp).relative_to(in_dir)
    if fmt == "auto":
        suffix = rel.suffix.lower() if rel.suffix.lower() in (".bvh", ".npz", ".c3d", ".trc") else ".bvh"
    elif rel.suffix.lower() in (".c3d", ".trc") and fmt.lstrip(".").lower() in ("bvh", "amc"):
        suffix = rel.suffix.lower()  # marker captures have no joint angles to write as BVH: they keep their format
    elif rel.suffix.lower() in (".bvh", ".npz") and fmt.lstrip(".").lower() == "amc":
        # AMC is read with the ASF beside it, which only an AMC take has to copy: a BVH take failed, and an .npz take
        # was written as AMC without one (read back with another actor's ASF in the folder, 14 cm off)
        suffix = rel.suffix.lower()
    else:
        suffix = "." + fmt.lstrip(".").lower()
    if keep_suffix:
        return Path(out_dir) / rel.with_name(f"{rel.stem}-{rel.suffix[1:].lower()}{suffix}")
    return Path(out_dir) / rel.with_suffix(suffix)


def take_files(inp: Path, in_dir: Path, out_dir: Path, fmt: str, report: bool, png: bool, keep_suffix: bool) -> dict:
    """The files one take writes: ``output``, ``record`` and optionally ``report``/``png`` (None when not asked)."""
    from .cleaning.clean_record import clean_path

    out = output_for(inp, in_dir, out_dir, fmt, keep_suffix=keep_suffix)
    stem = out.name[: -len(out.suffix)]
    return {"output": out, "record": clean_path(out),
            "report": out.with_name(stem + ".report.html") if report else None,
            "png": out.with_name(stem + ".summary.png") if png else None}


def plan_outputs(inputs: list[Path], in_dir: Path, out_dir: Path, fmt: str, report: bool, png: bool) -> tuple[list[dict], list[Path]]:
    """Each input's files (module docstring: colliding takes keep their suffix); refuses takes that still share a file."""
    plans = [take_files(p, in_dir, out_dir, fmt, report, png, False) for p in inputs]
    users: dict[str, list[int]] = {}
    for k, files in enumerate(plans):
        for f in files.values():
            if f is not None:
                users.setdefault(str(f), []).append(k)
    clash = sorted({k for ks in users.values() if len(ks) > 1 for k in ks})
    for k in clash:
        plans[k] = take_files(inputs[k], in_dir, out_dir, fmt, report, png, True)
    owner: dict[str, int] = {}
    for k, files in enumerate(plans):
        for f in files.values():
            if f is None:
                continue
            other = owner.setdefault(str(f), k)
            if other != k:
                raise MocapFormatError(inputs[k], f"would write {f}, as {inputs[other]} does; rename one of them")
    return plans, [inputs[k] for k in clash]


def unwritable(files: dict) -> str:
    """Why a take of the batch is not cleaned, in one line, where one of its ``files`` (:func:`take_files`) has a
    name longer than a file system holds (:func:`mocapkit.io.outputs.name_too_long`); "" where every one fits."""
    from .io.outputs import name_too_long

    for kind, f in files.items():
        if f is not None and (why := name_too_long(f)):
            ending = f.name[len(files["output"].stem):] if kind != "output" else f.suffix
            return f"not cleaned: its {KIND[kind]} (STEM{ending}) cannot be written: {why}; shorten the take's name"
    return ""


KIND = {"output": "output", "record": "record", "report": "report", "png": "summary figure"}


def check_batch_outputs(plans: list[dict], todo: list[tuple[Path, dict]], inputs: list[Path], folders: list[Path],
                        context: list[Path], overwrite: bool, how: str = "pass overwrite=True") -> None:
    """Refuse the batch before any take is cleaned if one of its outputs would replace an input or another output.

    First one index of every input (resolved path and inode) against every
    take's files, complete takes included (an output that *is* an input means
    OUT_DIR reaches into IN_DIR), and against each other; then, per take to
    clean, :func:`mocapkit.io.outputs.check_outputs` against its own input,
    the context and the input folder (folders, parents), and last the existing files of every take, all named in
    one refusal (:func:`mocapkit.io.outputs.refuse_existing`). A
    corpus of N takes costs O(N), not O(N^2).
    """
    from .io.outputs import check_outputs, refuse_existing, resolved

    by_path = {resolved(p): p for p in inputs}
    by_inode = {}
    for p in inputs:
        st = os.stat(p)
        by_inode[(st.st_dev, st.st_ino)] = p
    written: dict[Path, Path] = {}
    for files in plans:
        for out in (f for f in files.values() if f is not None):
            r = resolved(out)
            hit = by_path.get(r)
            if hit is None and os.path.exists(r):
                st = os.stat(r)
                hit = by_inode.get((st.st_dev, st.st_ino))
            if hit is not None:
                raise MocapFormatError(out, f"refusing to write over an input ({hit}); choose another output folder")
            if r in written:
                raise MocapFormatError(out, f"given as two outputs ({written[r]}); each output needs its own path")
            written[r] = out
    existing: list[Path] = []  # every take's outputs in the way, named in one refusal (not one per run)
    for inp, files in todo:
        check_outputs([f for f in files.values() if f is not None], [inp, *context, *folders], overwrite=overwrite,
                      how=how, existing=existing)
    refuse_existing(existing, how)


def _below(p: Path, folder: Path) -> bool:
    return p == folder or folder in p.parents
