"""Cleaning files and corpora: one take to disk (:func:`clean_file`), every take of a folder (:func:`clean_batch`).

What is on disk after a take is cleaned, beside each other:

- ``OUT`` (``.bvh`` or ``.npz``): the cleaned motion;
- ``OUT``'s stem + ``.clean.npz`` (:func:`mocapkit.cleaning.pipeline.clean_path`):
  the MDM, the flags and what each step changed (:meth:`CleanResult.save`);
- optionally the HTML report and the PNG summary.

Every file is written atomically (temporary file + rename), reports first,
then ``OUT``, then the ``.clean.npz`` **last**: its presence is the completion
marker. :func:`clean_batch` skips a take whose output and marker both exist,
so an interrupted corpus run resumes where it stopped; a take interrupted
after ``OUT`` was renamed but before its marker is removed again, so an
interrupt never leaves an output without its record. Temporary files that a
killed worker could not remove (``.NAME.*.part`` beside an expected output)
are swept before and after a batch.

Folder layout is mirrored: ``IN_DIR/a/b/take.amc`` -> ``OUT_DIR/a/b/take.bvh``
(+ ``take.clean.npz``). One failing take is reported (file and a one-line
reason) and skipped; the others go on. Work runs through
:func:`mocapkit.parallel.map_ordered`: local processes by default, in this
process (``"serial"``), on a local Dask cluster (``"dask"``) or on the Dask
scheduler at an address.
"""

from __future__ import annotations

import fnmatch
import os
import signal
import threading
import time
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Sequence

from .errors import MocapError, MocapFormatError

__all__ = ["clean_file", "clean_batch", "find_inputs", "BatchSummary", "sigterm_as_interrupt", "DEFAULT_PATTERNS"]

DEFAULT_PATTERNS = ("*.bvh", "*.amc", "*.npz")


def sigterm_as_interrupt() -> None:
    """Make SIGTERM raise KeyboardInterrupt (as SIGINT does) so atomic writes clean up; main thread only."""
    if threading.current_thread() is not threading.main_thread():
        return

    def handler(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    try:
        signal.signal(signal.SIGTERM, handler)
    except (ValueError, OSError):  # not the main thread of the interpreter (embedded, some workers)
        pass


def _temp_files(path: Path) -> list[Path]:
    """Leftover temporaries of :func:`mocapkit.io.atomic_write` for ``path``."""
    if not path.parent.is_dir():
        return []
    return [p for p in path.parent.glob(f".{path.name}.*.part") if p.is_file()]


@lru_cache(maxsize=4)
def _context(paths: tuple[str, ...]):
    """Context clips (or one database folder), loaded once per process."""
    from . import io
    from .database import MotionDatabase
    from .motion import Motion

    if not paths:
        return None
    ps = [Path(p) for p in paths]
    if len(ps) == 1 and ps[0].is_dir():
        return MotionDatabase.open(ps[0])
    out = []
    for p in ps:
        if p.is_dir():
            raise MocapFormatError(p, "a database folder must be the only --context")
        m = io.load(p)
        if not isinstance(m, Motion):
            raise MocapFormatError(p, "a marker file cannot be context; give motions")
        out.append(m)
    return out


def load_context(paths: Sequence | None):
    """``--context``: motion files, or one database folder (None or empty: the clip itself)."""
    return _context(tuple(str(p) for p in (paths or ())))


def _check_paths(inp: Path, outs: Sequence[Path]) -> None:
    for o in outs:
        if o.exists() and inp.exists() and o.resolve() == inp.resolve():
            raise MocapFormatError(o, "refusing to overwrite the input file; choose another output path")


def clean_file(
    inp,
    out,
    *,
    context: Sequence | None = None,
    steps=None,
    threshold: float = 0.5,
    report=None,
    png=None,
    progress: bool = False,
):
    """Clean the take at ``inp`` and write ``out``, its ``.clean.npz`` record and optional reports.

    Returns ``(original, result)``: the take as read and the
    :class:`~mocapkit.cleaning.pipeline.CleanResult`. ``context``: paths of
    context clips or of one database folder. Raises
    :class:`~mocapkit.errors.MocapError` (one line) on bad input; nothing is
    written then, nor when interrupted.
    """
    from . import io
    from .cleaning.pipeline import STEPS, clean, clean_path
    from .report.summary import plot_summary
    from .motion import Motion

    inp, out = Path(inp), Path(out)
    record = clean_path(out)
    extra = [Path(p) for p in (report, png) if p is not None]
    _check_paths(inp, [out, record, *extra])
    if out == record or len({out, record, *extra}) != 2 + len(extra):
        raise MocapFormatError(out, "the output, its .clean.npz record and the reports must be different files")
    io.suffix_kind(out, io.WRITERS, "writing")
    m = io.load(inp)
    if not isinstance(m, Motion):
        raise MocapFormatError(inp, "a marker file has no joint angles to clean; solve it to a skeleton first")
    ctx = load_context(context)
    try:
        res = clean(m, ctx, steps=steps or STEPS, threshold=threshold, progress=progress)
    except (ValueError, TypeError) as exc:
        raise MocapError(f"{inp}: {exc}") from None
    except MocapError as exc:
        msg = str(exc)
        raise MocapError(msg if str(inp) in msg else f"{inp}: {msg}") from None
    cleaned = res.motion
    if out.suffix.lower() == ".bvh" and cleaned.missing().any():
        raise MocapFormatError(out, "the cleaned take still has missing joints (NaN), which BVH cannot hold; "
                               "add the fill step or write .npz")
    if report is not None:
        from .report.html import write_report  # lazy: the viewer is optional

        write_report(report, m, cleaned, mdm=res.mdm, flags=res.flags, changed=res.changed,
                     title=f"{inp.name}: cleaned")
    if png is not None:
        plot_summary(res, m, png, title=inp.name)
    wrote_out = False
    try:
        io.save(cleaned, out)
        wrote_out = True
        res.save(record)  # last: the completion marker
    except BaseException:
        if wrote_out:  # an output without its record would pass for complete-but-unrecorded: remove it
            try:
                out.unlink()
            except FileNotFoundError:
                pass
        raise
    return m, res


# -- corpora -------------------------------------------------------------------------------


def find_inputs(in_dir, patterns: Sequence[str] = DEFAULT_PATTERNS, exclude=None) -> list[Path]:
    """Every file under ``in_dir`` (recursive) whose name matches one of ``patterns``, sorted; files under ``exclude`` and ``.clean.npz``/``.mask.npz`` records left out."""
    in_dir = Path(in_dir)
    excl = Path(exclude).resolve() if exclude is not None else None
    out = []
    for p in sorted(in_dir.rglob("*")):
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


def output_for(inp: Path, in_dir: Path, out_dir: Path, fmt: str = "auto") -> Path:
    """The mirrored output path: same sub-folder, suffix ``.bvh``/``.npz`` (``auto``: the input's if writable, else .bvh)."""
    rel = inp.relative_to(in_dir)
    if fmt == "auto":
        suffix = inp.suffix.lower() if inp.suffix.lower() in (".bvh", ".npz") else ".bvh"
    else:
        suffix = "." + fmt.lstrip(".").lower()
    return out_dir / rel.with_suffix(suffix)


@dataclass
class BatchSummary:
    """What :func:`clean_batch` did: per-take rows and the totals."""

    rows: list = field(default_factory=list)  # dicts: input, output, status (done/skipped/failed), reason, seconds, cells...
    seconds: float = 0.0
    executor: str = ""

    def count(self, status: str) -> int:
        return sum(r["status"] == status for r in self.rows)

    @property
    def failed(self) -> list:
        return [r for r in self.rows if r["status"] == "failed"]


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    msg = text[0] if text else ""
    return msg if isinstance(exc, MocapError) else f"{type(exc).__name__}: {msg}"


def _batch_job(job: dict) -> dict:
    """Worker: clean one take; never raises an Exception (failures come back as rows), interrupts propagate."""
    sigterm_as_interrupt()
    t = time.perf_counter()
    row = {"input": job["input"], "output": job["output"], "status": "done", "reason": ""}
    try:
        _, res = clean_file(job["input"], job["output"], context=job["context"], steps=job["steps"],
                            threshold=job["threshold"], report=job.get("report"), png=job.get("png"))
        row.update(frames=res.num_frames, filled=int(res.filled.sum()), repaired=int(res.repaired.sum()),
                   denoised=int(res.denoised.sum()), flagged=int(res.flags.sum()), notes=list(res.notes))
    except FileNotFoundError as exc:
        row.update(status="failed", reason=f"{exc.filename or exc}: no such file")
    except Exception as exc:  # one bad take must not stop the corpus: report it in one line
        row.update(status="failed", reason=_one_line(exc))
    row["seconds"] = time.perf_counter() - t
    return row


def clean_batch(
    in_dir,
    out_dir,
    *,
    context: Sequence | None = None,
    steps=None,
    threshold: float = 0.5,
    patterns: Sequence[str] = DEFAULT_PATTERNS,
    fmt: str = "auto",
    report: bool = False,
    png: bool = False,
    executor=None,
    progress: bool = True,
) -> BatchSummary:
    """Clean every take under ``in_dir`` into the mirrored layout under ``out_dir`` (module docstring).

    Complete outputs (output and ``.clean.npz`` present) are skipped; failures
    are rows with a one-line reason. ``report``/``png``: also write
    ``<stem>.report.html`` / ``<stem>.summary.png`` beside each output.
    """
    from .cleaning.pipeline import STEPS, parse_steps, clean_path
    from .parallel import describe_executor, map_ordered

    in_dir, out_dir = Path(in_dir), Path(out_dir)
    if not in_dir.is_dir():
        raise MocapFormatError(in_dir, "not a folder")
    if out_dir.exists() and out_dir.resolve() == in_dir.resolve():
        raise MocapFormatError(out_dir, "refusing to write into the input folder; choose another output folder")
    if fmt not in ("auto", "bvh", "npz"):
        raise MocapError(f"format must be auto, bvh or npz, got {fmt!r}")
    steps = list(parse_steps(steps or STEPS))
    if context:
        load_context(context)  # fail early, in one line, on a bad context
    t0 = time.perf_counter()
    summary = BatchSummary(executor=describe_executor(executor))
    jobs, expected = [], []
    for inp in find_inputs(in_dir, patterns, exclude=out_dir):
        out = output_for(inp, in_dir, out_dir, fmt)
        record = clean_path(out)
        stem = out.name[: -len(out.suffix)]
        rep = out.with_name(stem + ".report.html") if report else None
        pic = out.with_name(stem + ".summary.png") if png else None
        expected += [p for p in (out, record, rep, pic) if p is not None]
        if out.is_file() and record.is_file():
            summary.rows.append({"input": str(inp), "output": str(out), "status": "skipped", "reason": "complete", "seconds": 0.0})
            continue
        jobs.append({"input": str(inp), "output": str(out), "context": [str(c) for c in (context or [])], "steps": steps,
                     "threshold": float(threshold), "report": str(rep) if rep else None, "png": str(pic) if pic else None})
    _sweep(expected)
    try:
        rows = map_ordered(_batch_job, jobs, executor=executor, progress=progress, desc="clean") if jobs else []
    finally:
        _sweep(expected)  # what a killed worker could not remove
    summary.rows += rows
    summary.rows.sort(key=lambda r: r["input"])
    summary.seconds = time.perf_counter() - t0
    return summary


def _sweep(paths) -> None:
    for p in paths:
        for tmp in _temp_files(Path(p)):
            try:
                os.unlink(tmp)
            except OSError:
                pass
