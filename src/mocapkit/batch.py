"""Cleaning files and corpora: one take to disk (:func:`clean_file`), every take of a folder (:func:`clean_batch`).

What is on disk after a take is cleaned, beside each other:

- ``OUT`` (``.bvh`` or ``.npz``): the cleaned motion;
- ``OUT``'s stem + ``.clean.npz`` (:func:`mocapkit.cleaning.clean_record.clean_path`):
  the MDM, the flags and what each step changed (:meth:`CleanResult.save`);
- optionally the HTML report and the PNG summary.

Every file is written atomically (temporary file + rename), reports first,
then ``OUT``, then the ``.clean.npz`` **last**: its presence is the completion
marker, and it keeps the take's request (:func:`clean_request`: steps,
threshold, drifts, context, models, ...; a marker capture's: :func:`marker_request`, its unit, gap length
and fill error limits). :func:`clean_batch` skips a take whose
output and marker both exist and whose request and reports are this run's,
so an interrupted corpus run resumes where it stopped (a take made with
another request is refused without ``overwrite``, cleaned again with it); a take interrupted
after ``OUT`` was renamed but before its marker is removed again, so an
interrupt never leaves an output without its record.

Folder layout is mirrored: ``IN_DIR/a/b/take.amc`` -> ``OUT_DIR/a/b/take.bvh``
(+ ``take.clean.npz``). **Takes that would share a file** (``take.amc`` and
``take.bvh`` in one folder both become ``take.bvh`` + ``take.clean.npz``;
``take.bvh`` and ``take.npz`` or ``take.c3d`` share ``take.clean.npz``) **are named
after their input's format**, every one of them, joined to the stem by a hyphen:
``take-amc.bvh`` + ``take-amc.clean.npz`` and ``take-bvh.bvh`` + ``take-bvh.clean.npz``
(``BatchSummary.renamed``; the command says so for each). Takes that would still share a
file after that (an input literally named ``take-amc.bvh`` beside
``take.amc`` and ``take.bvh``) refuse the batch, naming both inputs.

**Nothing is cleaned until every output of the batch is checked**
(:func:`mocapkit.io.outputs.check_outputs` and one index of all inputs):
no output, record or report may resolve (symlinks, ``..``, hard links) to
any input take or ``--context`` file, nor lie inside a ``--context`` folder
or inside ``IN_DIR`` (an ``OUT_DIR`` below ``IN_DIR`` is allowed: it is left
out of the inputs, and so is any folder below ``IN_DIR`` holding the
:data:`BATCH_MARK` an earlier batch left in its ``OUT_DIR``); two takes may not write one file; ``OUT_DIR`` may not be
``IN_DIR``. A take is cleaned again only when it is not complete, and any of
its files that already exists (an output without its record, a report left
by another tool) is replaced only with ``overwrite``.

**No write outlives the batch.** A worker cleans a take into a hidden
staging folder beside its output (``.NAME.*.part``) and moves the files
into place itself (reports, ``OUT``, record last), asking
:func:`mocapkit.parallel.owner_alive` right before each rename: once the
batch process is gone (``kill -9`` included) or, on Dask, the scheduler has
cancelled the take because its client went away, nothing more is moved and
what was moved for that take is removed. Local workers also die with the
batch process (:mod:`mocapkit.parallel`). Staging folders and temporary
files a killed worker could not remove are swept before and after a batch;
a worker killed between the rename of ``OUT`` and of its record leaves an
output without a record, which the next run refuses without ``overwrite``.

One failing take is reported (file and a one-line reason) and skipped (one whose output, record or report name
a file system cannot hold, :func:`mocapkit.io.outputs.name_too_long`, before any take is cleaned); the
others go on, except after a full disk, a used-up quota or a read-only file
system (:func:`mocapkit.errors.output_stopper`): no later take could be
written either, so the batch hands out no more takes, lets those under way
finish, and says how many are complete (a rerun resumes the rest). Each row
is handed to ``on_row`` as its take finishes, so a log shows the takes done
even when the batch is cut short. Work runs through :func:`mocapkit.parallel.map_ordered`: local
processes by default, in this process (``"serial"``), on a local Dask
cluster (``"dask"``) or on the Dask scheduler at an address.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import tempfile
import time
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Callable, Sequence

from .errors import MocapError, MocapFormatError, os_error_line, output_stopper
from .batch_decided import decided_entry, is_own_record, stamp_decided
from .batch_folder import BATCH_MARK, mark, only_batch, prune, sweep, unmark_if_empty
from .batch_plan import DEFAULT_PATTERNS, check_batch_outputs, find_inputs, output_for, plan_outputs, unwritable
from .batch_request import REQUEST_DEFAULTS, clean_request, request_change
from .interrupts import interrupts_as_keyboard_interrupt, interrupts_held, whole_step
from .marker_files import clean_marker_file, joint_angle_options, marker_request, refuse_marker_options
from .report.batch_index import INDEX_NAME, is_batch_index
from .words import plural

__all__ = ["clean_file", "clean_marker_file", "clean_request", "marker_request", "refuse_marker_options", "clean_batch", "find_inputs", "output_for", "BatchSummary", "DEFAULT_PATTERNS", "BATCH_MARK",
           "REQUEST_DEFAULTS"]

#: How a refusal names an option to its caller: Python's keywords, or (``flags``) the command line's flags.
SAID = {False: {"overwrite": "overwrite=True", "asf": "asf=", "amc_fps": "amc_fps=", "unit": "unit=", "jobs": "jobs="},
        True: {"overwrite": "--overwrite", "asf": "--asf", "amc_fps": "--amc-fps", "unit": "--unit", "jobs": "--jobs"}}



@lru_cache(maxsize=4)
def _context(paths: tuple[str, ...], default: bool, progress: bool, prefer: str | None, tell=None, joint_map=()):
    """The context ``paths`` name (:func:`mocapkit.context.resolve_context`), resolved once per process."""
    from .context import resolve_context

    return resolve_context(list(paths), default=default, progress=progress, prefer=prefer, tell=tell,
                           joint_map=dict(joint_map) or None)


def load_context(paths: Sequence | None, *, default: bool = True, progress: bool = False, take=None,
                 tell: Callable[[str], None] | None = None, joint_map: dict | None = None):
    """``--context``: a database folder, a folder of takes or motion files (built once and cached), ``none``;
    None or empty: the bundled default context (with ``default``), else the clip itself. ``take``: the
    Motion it is for (a folder of mixed rigs then gives the takes on its skeleton). ``tell``: called with a line as
    a build of files starts and as it ends (:func:`mocapkit.context.build_context`; nothing for a cached one).
    ``joint_map`` (``--joint-map``, :func:`mocapkit.database.read_joint_map`): the names a folder's build gives
    the joints of a rig whose names say no roles."""
    from .context import topology_id

    prefer = topology_id(take.skeleton) if take is not None else None
    return _context(tuple(str(p) for p in (paths or ())), default, progress, prefer, tell,
                    tuple(sorted((joint_map or {}).items())))


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
    asf=None,
    overwrite: bool = False,
    motion=None,
    decisions=None,
    record=None,
    drifts: bool = False,
    models: dict | None = None,
    skeleton_copy: tuple | None = None,
    amc_fps: float | None = None,
    unit: str | None = None,
    noise_deg: float | None = None,
    max_gap_s: float | None = None,
    max_error_mm: float | None = None,
    placed=None,
    joint_map: dict | None = None,
    flags: bool = False,
    zeros_as_gaps: bool | None = None,
):
    """Clean the take at ``inp`` and write ``out``, its ``.clean.npz`` record and optional reports.

    Returns ``(original, result)``: the take as read and the
    :class:`~mocapkit.cleaning.clean_record.CleanResult` (with ``decisions``, the decided one, what ``out`` holds:
    :func:`mocapkit.cleaning.decide.decided_result`, its ``decided`` the summary). ``context``: what
    ``--context`` gives (:func:`load_context`; empty: the bundled default
    context, fitted to the take by :func:`mocapkit.context.fit_context`, whose
    note joins the result's notes); ``asf``: the skeleton of an
    ``.amc`` input; ``amc_fps``: its frame rate (an AMC states none:
    :func:`mocapkit.io.asfamc.amc_rate`); ``unit``: the length unit of a take
    whose file states none (:func:`mocapkit.io.takes.with_unit`); ``motion``:
    the take already read from ``inp`` (it is not read again). ``overwrite``: replace existing outputs (never an input).
    ``decisions``: a decisions file (:mod:`mocapkit.cleaning.decisions`):
    ``out`` then holds only the changes it accepts (the record still lists
    every change); ``record``: the ``.clean.npz`` of an earlier run on this
    take, used instead of cleaning again (needs ``decisions``; nothing but
    ``out`` and the reports is written). ``drifts``: also flag smooth drifts
    (:func:`mocapkit.cleaning.pipeline.clean`); ``models``: ``{"ebf": ..., "ebd": ...}`` model files (or
    shipped names, :func:`mocapkit.cleaning.deep.load_model`) instead of the shipped models chosen for
    the take's rig. ``skeleton_copy``: ``(destination, source)`` of the ASF an AMC ``out`` is read with
    (:func:`mocapkit.io.takes.asf_for_output`), written first, with the outputs. ``noise_deg``: the
    noisy-cell level (:func:`mocapkit.cleaning.pipeline.clean`; None: its default). ``placed``: where ``out``
    is moved once written (a batch writes each take into a staging folder first): the report names the record
    beside it, where the user will find it. ``joint_map``: :func:`load_context`'s. ``flags``: refusals name the
    command line's flags (``--overwrite``), not Python's keywords (:data:`SAID`). ``zeros_as_gaps``: how a marker
    capture's samples at exactly (0, 0, 0) are read (:func:`clean_marker_file`; a joint-angle take ignores it). A
    marker capture, cleaned whole, refuses the joint-angle options given (``steps`` other than all or detect, a
    ``threshold`` other than 0.5, ``drifts``, ``context``, ``noise_deg``, ``models``, ``joint_map``) in one line, named as
    ``flags`` says (:func:`mocapkit.marker_files.joint_angle_options`), before anything is written.

    Every output is checked against every input
    (:func:`mocapkit.io.outputs.check_outputs`) before anything is read; the
    outputs are written after the take is cleaned, reports first and the
    record last (the completion marker; an old one is removed first), and a
    failure or interrupt while writing leaves the outputs as they were
    (:func:`mocapkit.io.outputs.removed_on_failure`). Raises
    :class:`~mocapkit.errors.MocapError` (one line) on bad input.
    """
    from . import io
    from .cleaning import decisions as dec
    from .cleaning.pipeline import NOISE_DEG, STEPS, clean, clean_path, parse_steps
    from .io.outputs import check_outputs, file_facts, input_facts, removed_on_failure
    from .io.takes import check_asf, load_motion, load_take
    from .markerset import MarkerSet

    inp, out = Path(inp), Path(out)
    asked = parse_steps(steps or STEPS)
    # a joint-angle take's options, named as the caller gave them: a batch's CLI user typed --drifts, not drifts
    not_for_markers = joint_angle_options({key: value for key, value, given in (
        ("steps", asked, asked not in (STEPS, ("detect",))), ("threshold", threshold, threshold != 0.5),
        ("drifts", drifts, drifts), ("context", context, bool(context)),
        ("noise_deg", noise_deg, noise_deg is not None), ("models", models, bool(models)),
        ("joint_map", joint_map, joint_map is not None)) if given}, flags)
    as_markers = dict(report=report, png=png, overwrite=overwrite, unit=unit, max_gap_s=max_gap_s,
                      max_error_mm=max_error_mm, decisions=decisions, record=record, review=asked == ("detect",),
                      placed=placed, zeros_as_gaps=zeros_as_gaps, flags=flags)
    if isinstance(motion, MarkerSet) or (motion is None and inp.suffix.lower() in (".c3d", ".trc")):
        refuse_marker_options(inp, not_for_markers)
        check_asf(asf, [inp], amc_fps, names=(SAID[flags]['asf'], SAID[flags]['amc_fps']))  # refused, not ignored
        return clean_marker_file(inp, out, markers=motion, **as_markers)
    reuse = record is not None
    if reuse and decisions is None:
        raise MocapError(f"{record}: an earlier run's record is applied with decisions; give the decisions file")
    record = Path(record) if reuse else clean_path(out)
    outputs = [out, None if reuse else record, report, png]
    given = [Path(m) for m in (models or {}).values() if isinstance(m, (str, Path))]
    check_outputs(outputs, [inp, asf, decisions, record if reuse else None, *(context or []), *given],
                  overwrite=overwrite, how=f"pass {SAID[flags]['overwrite']}")
    check_asf(asf, [inp], amc_fps, names=(SAID[flags]['asf'], SAID[flags]['amc_fps']))
    said_unit = SAID[flags]["unit"]
    if motion is None and inp.suffix.lower() == ".npz" and isinstance(
            take := load_take(inp, unit=unit, unit_option=said_unit), MarkerSet):
        refuse_marker_options(inp, not_for_markers)
        return clean_marker_file(inp, out, markers=take, **as_markers)
    io.suffix_kind(out, io.WRITERS, "writing")
    doc = dec.read_decisions(decisions) if decisions is not None else None
    taken = None if reuse else input_facts(inp)  # the take as read: a later batch tells a replaced input by it
    m = motion if motion is not None else load_motion(inp, asf, purpose="clean", fps=amc_fps, unit=unit,
                                                      unit_option=said_unit)
    io.check_writable(m, out)
    request = None if reuse else clean_request(steps, threshold, drifts, context, models, noise_deg, amc_fps, unit,
                                               joint_map)

    def cleaning():
        from .cleaning.take_context import unread_context
        from .context import fit_context, terms_note

        unread = unread_context(m, context) if "detect" in asked else ""  # a take detect does not judge reads none
        ctx, ctx_note = (fit_context(m, load_context(context, progress=progress, take=m, joint_map=joint_map)) if unread is None
                         else (None, unread))  # only detection reads a context: none is loaded or spoken of without it
        try:
            res = clean(m, ctx, steps=steps or STEPS, threshold=threshold, progress=progress, drifts=drifts,
                        models=models, noise_deg=NOISE_DEG if noise_deg is None else noise_deg)
            notes = tuple(n for n in (ctx_note, terms_note(ctx)) if n)  # the context's terms: repairs come from it
            return replace(res, notes=res.notes + notes, params={**res.params, "request": request})
        except (ValueError, TypeError) as exc:
            raise MocapError(f"{inp}: {exc}") from None
        except MocapError as exc:  # the library names the take (its stem): the line names the file instead
            msg, name = str(exc), f"{m.name or 'motion'}: "
            raise MocapError(msg if str(inp) in msg else f"{inp}: {msg.removeprefix(name)}") from None

    def prepared(res):
        return replace(res, frames_note=dec.frames_note(inp))  # the summary says how its frames relate to the file's

    from .io.euler_branches import written_layout

    # how OUT holds the rotations (io.save writes that layout below): an AMC (each bone on its ASF dofs), a BVH of
    # one- or two-channel joints; None for a file keeping every rotation (an .npz, a BVH without such joints)
    _, held_of = written_layout(m, out, asf, inp)

    def held(res):  # sizes, report and record say what the file holds (dec.as_written)
        try:
            return dec.as_written(res, m, held_of)
        except MocapFormatError:
            raise
        except MocapError as exc:  # a record without its cleaned samples
            raise MocapError(f"{record}: {exc}") from None

    partial = held_of is not None
    chosen = decided = None
    if doc is not None:  # the checks and order of the library's clean_and_decide
        from .cleaning.decide import decide_take

        res, chosen, decided = decide_take(m, cleaning, doc, decisions, record=record if reuse else None,
                                           request=request, take=inp.name,
                                           option=dec.RECORD_FLAG if flags else dec.RECORD_KEYWORD,
                                           prepared=prepared, named=record,
                                           held=held if partial else None, source=inp)
    else:
        res = prepared(cleaning())
        res = held(res) if partial else res
    cleaned = res.motion if decided is None else decided.motion
    filled_rejected = decided is not None and bool((res.filled & ~decided.filled).any())
    io.check_complete(cleaned, out, "the cleaned take still has missing joints (NaN)",
                      "the decisions reject fill changes: accept them or write .npz" if filled_rejected
                      else "add the fill step or write .npz")
    with removed_on_failure([*outputs, skeleton_copy[0] if skeleton_copy else None], overwrite=overwrite,
                            marker=None if reuse else record):
        if skeleton_copy:
            from .io.takes import place_asf

            place_asf(*skeleton_copy)  # first: an AMC output is never left without the ASF it is read with
        if report is not None:
            from .cleaning.decided import apply_command
            from .report.html import write_clean_report  # lazy: the viewer is optional

            write_clean_report(report, m, res, inp=inp, output=out.name, decisions=chosen,
                               record=record if reuse or placed is None else clean_path(placed),
                               applied=Path(decisions).name if doc else "",
                               command=apply_command(inp, asf=asf, amc_fps=amc_fps, unit=unit))
        if png is not None:
            from .report.summary import plot_summary

            plot_summary(dataclasses.replace(res, motion=cleaned), m, png, title=inp.name)
        io.save(cleaned, out, like=inp, asf=asf, copy_asf=False)  # the ASF: skeleton_copy, or the batch's
        if reuse and is_own_record(record, out):  # decided in place: a later batch keeps OUT (batch_decided)
            stamp_decided(record, decisions, out, decided.decided.holds())
        if not reuse:  # last: the completion marker, keeping what was read and written (_not_complete)
            # a new cleaning, decided: its record says so, as one decided in place does (batch_decided)
            said = {} if decided is None else {"decided": decided_entry(decisions, out, decided.decided.holds())}
            res = replace(res, params={**res.params, "written": {"input": taken, "output": file_facts(out)}, **said})
            res.save(record)
    return m, res if decided is None else decided


def _not_complete(inp: Path, files: dict, request: dict, markers: dict | None = None,
                  flags: bool = False) -> tuple[str, bool, str]:
    """Why a take whose output and record exist is not complete for this run ("" when it is), whether it is
    cleaned again as it is (True: its input was replaced since, and the output is this batch's own, of the old take)
    or refused without ``overwrite`` (an output changed outside mocapkit, another request, a missing report, the
    output of another folder's take of the same name: :func:`mocapkit.io.outputs.other_input`), and the
    decisions file that wrote its output ("" where none did: :func:`mocapkit.batch_decided.decided_by`).
    ``request``: this run's :func:`clean_request`; ``markers``: its :func:`marker_request`, which a marker capture's
    record is held to (default: the defaults); ``flags``: another request's options are named as the command line's
    flags, else as Python's keywords (:func:`mocapkit.batch_request.request_change`).

    The record keeps the size, SHA-256 and path digest of the input as read and the size and SHA-256 of the output as
    written (``params["written"]``, :func:`mocapkit.io.outputs.input_facts`, ``file_facts``); a record without them (an earlier mocapkit's) is taken at its word. An
    output decisions were applied to in place is as written when it is as those decisions wrote it; where its input
    changed since, it is not cleaned again as it is (``anew`` False): that would discard the decisions.
    """
    from .batch_decided import decided_by
    from .cleaning.pipeline import CleanResult
    from .io.outputs import file_facts, other_input

    missing = [k for k in ("report", "png") if files.get(k) is not None and not Path(files[k]).is_file()]
    if missing:
        return f"its {' and '.join(missing)} {'is' if len(missing) == 1 else 'are'} missing", False, ""
    try:
        params = CleanResult.load_params(files["record"])
    except MocapFormatError as exc:
        return f"its record {Path(files['record']).name} is {exc.reason}", False, ""
    written = (params or {}).get("written")
    decided = decided_by(params, files["output"])
    if isinstance(written, dict):
        was, out = written.get("output") or {}, Path(files["output"])
        size = out.stat().st_size
        if not decided and (size != was.get("size") or file_facts(out) != was):
            return (f"its output was changed since that run wrote it ({size} bytes, {was.get('size')} when "
                    "written)" if size != was.get("size") else "its output was changed since that run wrote it"), False, ""
        kept = written.get("input") or {}
        if file_facts(inp) != {k: kept.get(k) for k in ("size", "sha256")}:
            if decided:
                return f"its input changed since it was decided by {decided}", False, decided
            if other_input(kept, inp):  # another folder's take of the same name: not this batch's output
                return "it was cleaned from another file of the same name", False, ""
            return "its input changed since it was cleaned", True, ""
    done = None if params is None else params.get("request")
    if params is not None and params.get("kind") == "markers":  # held to the marker request, kept or not
        request, done = markers if markers is not None else marker_request(), done if isinstance(done, dict) else {}
    if not isinstance(done, dict):  # a record written before requests were kept
        return "", False, decided
    return request_change(done, request, flags), False, decided


def _kept(why: str, decided: str, overwrite: str = SAID[False]["overwrite"]) -> str:
    """A skipped take's reason: complete, kept as its decisions wrote it (:mod:`mocapkit.batch_decided`), or kept
    although its input changed since it was decided (``why``), because cleaning it again discards the decisions.
    ``overwrite``: how the caller asks for that (:data:`SAID`)."""
    if not why:
        return f"kept: decided by {decided}" if decided else "complete"
    return f"kept: {why}; {overwrite} cleans it again and discards those decisions"


# -- corpora -------------------------------------------------------------------------------


@dataclass
class BatchSummary:
    """What :func:`clean_batch` did: per-take rows and the totals.

    ``rows``: one dict per take, sorted by input: ``input``, ``output``,
    ``status`` (``done``/``skipped``/``failed``), ``reason`` (one line),
    ``seconds`` and, for cleaned takes and those skipped as complete (read from the record the earlier run wrote
    beside the output), the counts of cells changed, ``cuts`` (each
    :class:`~mocapkit.cleaning.take_breaks.Cut`'s fields: two takes joined, or frames dropped), ``warnings`` (a step's fallback, a model's
    licence: lines that name no file) and ``file_notes`` (what the reader did, what the output's format leaves out:
    each line names the file it is about, as ``clean`` prints them; paths as the caller gave them).
    ``renamed``: the inputs whose output is named after the input's format because
    another take would have written the same file (module docstring).
    ``earlier``: folders below IN_DIR left out as an earlier batch's outputs.
    ``stopped``: empty, or the one line saying why the batch stopped early (a
    full disk: module docstring), how many takes are complete and that a rerun
    resumes; the takes never started then have no row (``not_started`` counts them).
    """

    rows: list = field(default_factory=list)
    seconds: float = 0.0
    executor: str = ""
    renamed: list = field(default_factory=list)
    earlier: list = field(default_factory=list)
    stopped: str = ""
    not_started: int = 0
    index: Path | None = None

    def count(self, status: str) -> int:
        return sum(r["status"] == status for r in self.rows)

    @property
    def failed(self) -> list:
        return [r for r in self.rows if r["status"] == "failed"]


def _one_line(exc: BaseException) -> str:
    """A failed take's reason in one line: a MocapError's own, a filesystem error's as the CLI says it (the output's
    name, not its temporary file's; "no space left on the device"), else the exception's name and first line."""
    if isinstance(exc, OSError) and not isinstance(exc, MocapError):
        return os_error_line(exc)
    text = str(exc).strip().splitlines()
    msg = text[0] if text else ""
    return msg if isinstance(exc, MocapError) else f"{type(exc).__name__}: {msg}"


_GONE = "not written: the batch that started this take is gone"


def _batch_job(job: dict) -> dict:
    """Worker: clean one take; never raises an Exception (failures come back as rows), interrupts propagate.

    The take is cleaned into a staging folder beside its output, then its
    files are renamed into place (reports, output, record last), each rename
    only while :func:`mocapkit.parallel.owner_alive`. An earlier run's record
    is removed before the first rename, so a take killed half-way never reads
    as complete; if the take fails, is interrupted or the batch is gone, what
    it moved is removed again and the earlier run's files are put back.
    """
    with interrupts_as_keyboard_interrupt():  # SIGTERM too, in a pool's worker and in this process alike
        return _clean_job(job)


@whole_step
def _undo_take(finals: list[Path], kept: dict[Path, Path], moved: list[Path]) -> None:
    """A failed or interrupted take's files undone, whole (:func:`mocapkit.interrupts.whole_step`): what it moved into
    place removed, an earlier run's files put back. A second Ctrl-C as the undo began skipped the put-back, and the
    clean-up then dropped the hidden links of the earlier run's files (``--overwrite``): they were lost."""
    from .io.outputs import put_back

    put_back(finals, kept, {os.path.abspath(p) for p in moved})


def _clean_job(job: dict) -> dict:
    from .cleaning.pipeline import clean_path
    from .io import marker_notes, motion_notes
    from .io.outputs import drop_kept, keep_aside, temp_prefix
    from .parallel import owner_alive

    t = time.perf_counter()
    row = {"input": job["input"], "output": job["output"], "status": "done", "reason": ""}
    out = Path(job["output"])
    finals = [Path(job[k]) for k in ("report", "png") if job.get(k)] + [out, clean_path(out)]
    if not owner_alive():
        row.update(status="failed", reason=_GONE, seconds=time.perf_counter() - t)
        return row
    moved: list[Path] = []
    kept: dict[Path, Path] = {}  # an earlier run's files (--overwrite): put back if this take's cannot all be placed

    stage = None
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        stage = Path(tempfile.mkdtemp(prefix=temp_prefix(out.name), suffix=".part", dir=out.parent))
        staged = {f: stage / f.name for f in finals}
        taken, res = clean_file(job["input"], staged[out], context=job["context"], steps=job["steps"], threshold=job["threshold"],
                            joint_map=job.get("joint_map"),
                            report=staged[Path(job["report"])] if job.get("report") else None,
                            png=staged[Path(job["png"])] if job.get("png") else None, asf=job.get("asf"),
                            drifts=bool(job.get("drifts")), models=job.get("models"), amc_fps=job.get("amc_fps"),
                            unit=job.get("unit"), noise_deg=job.get("noise_deg"), max_gap_s=job.get("max_gap_s"),
                            max_error_mm=job.get("max_error_mm"), placed=out, zeros_as_gaps=job.get("zeros_as_gaps"),
                            flags=bool(job.get("flags")))
        keep_aside(finals, kept)  # kept filled as each link is made: an interrupt in it leaves none behind
        if finals[-1] in kept:  # the old record goes first: the take reads as incomplete while its files are replaced
            os.unlink(finals[-1])
        for final in finals:  # the record last: the completion marker
            if not owner_alive():
                raise _Orphaned
            if final.exists():
                shutil.copymode(final, staged[final])
            os.replace(staged[final], final)
            moved.append(final)
        if hasattr(res, "fixes"):  # a marker capture (cleaning.markers.MarkerCleanResult)
            from .cleaning.markers.counts import fill_counts, sample_counts

            # every kind of change counted (duplicate labels and foreign stretches too), and the unvalidated fills
            # apart, as the clean's summary says them: the take's line and the index
            row.update(frames=res.markers.num_frames, **sample_counts(res), **fill_counts(res), notes=res.summary()[1:],
                       warnings=[],  # what the reader did, what OUT cannot hold, an npz's arrays no reader reads:
                       file_notes=marker_notes(res.original, out, job["input"], filled=res.fill_mask,
                                               record=clean_path(out)))  # each line names its file
        else:
            from .cleaning.flags_left import left_line
            from .cleaning.judged import not_judged_note

            said = " ".join(s.note for s in res.steps)  # a step's fallback or its model's licence: warnings
            row.update(frames=res.num_frames, filled=int(res.filled.sum()), repaired=int(res.repaired.sum()),
                       denoised=int(res.denoised.sum()), flagged=int(res.flags.sum()), notes=list(res.notes),
                       left=left_line(res), judged=not_judged_note(res.detection, res.num_frames),
                       cuts=[dataclasses.asdict(c) for c in res.cuts],  # named, no sample changed for them
                       warnings=[n for n in res.notes if n in said],
                       file_notes=motion_notes(taken, out, job["input"]))  # each line names its file (OUT)
    except _Orphaned:
        _undo_take(finals, kept, moved)
        row.update(status="failed", reason=_GONE)
    except FileNotFoundError as exc:
        _undo_take(finals, kept, moved)
        row.update(status="failed", reason=_unstaged(f"{exc.filename or exc}: no such file", stage, out.parent))
    except Exception as exc:  # one bad take must not stop the corpus: report it in one line
        _undo_take(finals, kept, moved)
        row.update(status="failed", reason=_unstaged(_one_line(exc), stage, out.parent))
        stopper = output_stopper(exc)
        if stopper:  # a full disk: the batch stops handing out takes (module docstring)
            row["errno"] = stopper
    except BaseException:
        _undo_take(finals, kept, moved)  # an output without its record would pass for complete-but-unrecorded
        raise
    finally:
        drop_kept(kept)
        if stage is not None:
            shutil.rmtree(stage, ignore_errors=True)
    row["seconds"] = time.perf_counter() - t
    return row


def _unstaged(reason: str, stage: Path | None, folder: Path) -> str:
    """``reason`` with the staging folder's path replaced by the output folder's: messages name the files the user asked for."""
    return reason if stage is None else reason.replace(str(stage), str(folder))


class _Orphaned(Exception):
    """The process that started a take is gone: move nothing more into place."""


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
    overwrite: bool = False,
    asf=None,
    drifts: bool = False,
    models: dict | None = None,
    amc_fps: float | None = None,
    unit: str | None = None,
    noise_deg: float | None = None,
    max_gap_s: float | None = None,
    max_error_mm: float | None = None,
    zeros_as_gaps: bool | None = None,
    on_row: Callable[[dict, int, int], None] | None = None,
    on_context: Callable[[str], None] | None = None,
    on_start: Callable[[int, int, str], None] | None = None,
    joint_map: dict | None = None,
    flags: bool = False,
    jobs: int | None = None,
) -> BatchSummary:
    """Clean every take under ``in_dir`` into the mirrored layout under ``out_dir`` (module docstring).

    Complete takes (output and ``.clean.npz`` present, made with this request) are skipped; failures
    are rows with a one-line reason. ``report``/``png``: also write
    ``<stem>.report.html`` / ``<stem>.summary.png`` beside each output.
    Takes that would share a file are named after their input's format
    (``take.amc`` -> ``take-amc.bvh``; listed in ``BatchSummary.renamed``).
    Every output is checked before any take is cleaned: none may resolve to
    an input, and an existing file that is not part of a complete take is
    replaced only with ``overwrite``. ``asf``: the skeleton of every ``.amc``
    take (default: the ASF beside each AMC); ``amc_fps``: the frame rate of
    every ``.amc`` take (default: :func:`mocapkit.io.asfamc.amc_rate`);
    ``unit``: the length unit of every take whose file states none; ``noise_deg``: the noisy-cell level
    of every take (:func:`clean_file`); ``max_gap_s``, ``max_error_mm``: the gap-length and fill-error limits of
    every marker capture (:func:`mocapkit.cleaning.markers.clean_markers`; joint-angle takes ignore them; a
    marker capture's record keeps them with its unit, :func:`marker_request`, and a capture cleaned with other
    ones is refused without ``overwrite`` and cleaned again with it, as a joint-angle take cleaned with another
    request is); ``zeros_as_gaps``: how every marker capture's samples at exactly (0, 0, 0) are read (True gaps,
    False positions, None decided from the data; kept in its request alike). ``drifts``: also flag smooth
    drifts in every take (:func:`mocapkit.cleaning.pipeline.clean`); ``models``: model files (or shipped
    names) for every take, as :func:`clean_file`'s. ``on_row(row, n, total)``: called in this process
    with each take's row as soon as it is known, the complete takes first (input order), then each take
    cleaned or failed as it finishes (completion order); ``n`` counts the rows so far, ``total`` the takes.
    ``on_context(line)``: called with a line as the ``context`` files start to be built into a database, before
    the first take, and one as the build ends (its clips and seconds; nothing when the cache holds it).
    ``on_start(todo, total, where)``: called in this process as the first take is handed out, with the takes to clean,
    the takes found and where they run (``BatchSummary.executor``); not called when every take is complete. The first
    row may come minutes later (numba compiles the kernels on a cold cache): a log says the batch started.
    ``joint_map``: the names the ``context`` build gives a rig's joints (:func:`load_context`).
    ``jobs``: how many takes local processes clean at once (default: one per core); a machine shared overnight
    keeps the rest of its cores. Only for local processes (``executor`` None or ``"processes"``).
    ``flags``: refusals name the command line's flags (``--overwrite``, ``--asf``, ``--executor``, ``--max-gap``),
    not Python's keywords (``overwrite=True``, ``asf=``, ``executor=``, ``max_gap_s=``: :data:`SAID`).
    A take that fails on a full disk, a used-up quota or a read-only file system stops the batch
    (``BatchSummary.stopped``). Raises
    :class:`~mocapkit.errors.MocapError` (one line) on a bad folder, format,
    step list, context or executor (:func:`mocapkit.parallel.check_executor`)
    and on a refused output; nothing is written then.
    """
    from .batch_written import skipped_counts
    from .cleaning.pipeline import STEPS, check_noise_deg, parse_steps
    from .context import is_off
    from .io.outputs import check_outputs, inside, missing_folders, resolved
    from .parallel import check_executor, check_jobs, describe_executor, map_ordered

    in_dir, out_dir = Path(in_dir), Path(out_dir)
    if not in_dir.is_dir():
        raise MocapFormatError(in_dir, "not a folder")
    if resolved(out_dir) == resolved(in_dir):
        raise MocapFormatError(out_dir, "refusing to write into the input folder; choose another output folder")
    if fmt not in ("auto", "bvh", "amc", "npz"):
        raise MocapError(f"format must be auto, bvh, amc or npz, got {fmt!r}")
    executor_option = "--executor" if flags else "executor="
    check_executor(executor, option=executor_option)
    check_jobs(jobs, executor, SAID[flags]["jobs"], executor_option)
    try:
        steps = list(parse_steps(steps or STEPS))
    except ValueError as exc:
        raise MocapError(f"steps: {exc}") from None
    if noise_deg is not None:
        try:
            check_noise_deg(noise_deg)
        except ValueError as exc:
            raise MocapError(str(exc)) from None
    ctx = [Path(c) for c in (context or [])]
    if ctx:
        load_context(ctx, progress=progress, tell=on_context, joint_map=joint_map)  # fail early, in one line, on a bad context; a folder is built and cached once
    t0 = time.perf_counter()
    below = inside(out_dir, in_dir)  # an OUT_DIR below IN_DIR is left out of the inputs, IN_DIR itself is not
    earlier: list[Path] = []  # folders below IN_DIR holding an earlier batch's outputs: left out too
    inputs = find_inputs(in_dir, patterns, exclude=out_dir if below else None, earlier=earlier)
    if asf is not None or amc_fps is not None or unit is not None:
        from .io.takes import check_asf, check_unit

        check_asf(asf, inputs, amc_fps, names=(SAID[flags]['asf'], SAID[flags]['amc_fps']))
        check_unit(unit, SAID[flags]["unit"])
    plans, renamed = plan_outputs(inputs, in_dir, out_dir, fmt, report, png)
    summary = BatchSummary(executor=describe_executor(executor, jobs), renamed=[str(p) for p in renamed],
                           earlier=[str(p) for p in earlier if not (below and resolved(p) == resolved(out_dir))])
    todo, stale, again = [], [], {}
    request = clean_request(steps, threshold, drifts, ctx, models, noise_deg, amc_fps, unit, joint_map)
    markers = marker_request(unit, max_gap_s, max_error_mm, zeros_as_gaps=zeros_as_gaps)
    for inp, files in zip(inputs, plans):
        if why := unwritable(files):  # before any take is cleaned: that take fails in one line, the others go on
            summary.rows.append({"input": str(inp), "output": str(files["output"]), "status": "failed",
                                 "reason": why, "seconds": 0.0})
            continue
        if files["output"].is_file() and files["record"].is_file():
            why, anew, decided = _not_complete(inp, files, request, markers, flags)
            if not why or (decided and why.startswith("its input") and not overwrite):
                summary.rows.append({"input": str(inp), "output": str(files["output"]), "status": "skipped",
                                     "reason": _kept(why, decided, SAID[flags]["overwrite"]), "seconds": 0.0,
                                     **skipped_counts(inp, files["output"], files["record"])})  # the earlier run's
                continue
            if anew:  # a new version of the take: its old output is this batch's own, cleaned again as it is
                again[inp] = f"cleaned again: {why}"
            elif decided and why.startswith("its input"):  # told to (overwrite): the decisions go, and the line says so
                again[inp] = f"cleaned again: {why}; those decisions were discarded"
            else:
                stale.append((files["output"], why + (f" (its output was decided by {decided}: cleaning it again "
                                                      "discards those decisions)" if decided else "")))
        todo.append((inp, files))
    folders = [] if below else [in_dir]
    earlier_outputs = {out for out, _ in stale} | {files["output"] for inp, files in todo if inp in again}
    check_batch_outputs(plans, todo if overwrite else [t for t in todo if t[1]["output"] not in earlier_outputs],
                        inputs, folders, ctx, overwrite, f"pass {SAID[flags]['overwrite']}")  # an output that is an input: refused first
    index = out_dir / INDEX_NAME if report else None  # the overview of every take, the batch's own file
    if index is not None:
        check_outputs([index], [*ctx, *folders], overwrite=overwrite or is_batch_index(index),
                      how=f"it is not a batch's overview; pass {SAID[flags]['overwrite']}")
    if stale and not overwrite:  # an earlier run's take, made otherwise: not this run's to skip, nor to replace silently
        more = f" ({len(stale) - 1} more take{'s' if len(stale) > 2 else ''} alike)" if len(stale) > 1 else ""
        raise MocapFormatError(stale[0][0], f"exists from an earlier run, but {stale[0][1]}; use {SAID[flags]['overwrite']} to clean "
                                            f"it again{more}")
    # every path absolute: a remote Dask worker resolves a relative one against its own working folder
    work = [{"input": _abs(inp), "output": _abs(files["output"]), "steps": steps,
             "context": [str(c) if is_off(c) else _abs(c) for c in ctx],  # 'none' stays a word
             "threshold": float(threshold), "drifts": bool(drifts), "joint_map": joint_map,
             "models": {k: _abs(v) if Path(v).exists() else str(v) for k, v in (models or {}).items()} or None,
             "report": _abs(files["report"]) if files["report"] else None,
             "png": _abs(files["png"]) if files["png"] else None,
             "asf": _abs(asf) if asf is not None and inp.suffix.lower() == ".amc" else None,
             "amc_fps": float(amc_fps) if amc_fps is not None and inp.suffix.lower() == ".amc" else None,
             "unit": unit, "noise_deg": None if noise_deg is None else float(noise_deg),
             "max_gap_s": max_gap_s, "max_error_mm": max_error_mm, "zeros_as_gaps": zeros_as_gaps,
             "flags": flags} for inp, files in todo]
    skeletons = _asf_copies(inputs, plans, asf, overwrite, SAID[flags]) if fmt == "amc" else {}
    expected = [f for files in plans for f in files.values() if f is not None]
    made = missing_folders([out_dir, *(Path(files["output"]).parent for _, files in todo)])
    total, told = len(inputs), 0
    said: set[int] = set()  # the takes of todo whose rows were told

    def tell(row: dict, k: int | None = None) -> None:
        nonlocal told
        # its number, its line and its being said as one, interrupts held: one that landed after the line was
        # written and before the take was marked said had it told again from its record (twice in the log), one
        # before the line had its number counted (the row told from its record came numbered one past it)
        with interrupts_held():
            told += 1
            if on_row is not None:
                on_row(row, told, total)
            if k is not None:
                said.add(k)

    for row in summary.rows:  # the complete takes
        tell(row)

    def finished_take(k: int, row: dict) -> bool:
        inp, files = todo[k]
        _as_given(row, inp, files, again.get(inp))
        tell(row, k)
        if row.get("errno") and not summary.stopped:
            summary.stopped = row["reason"]
        return bool(summary.stopped)

    with only_batch(out_dir):
        sweep(expected)
        finished = False
        try:
            if work:
                mark(out_dir, in_dir)
                if on_start is not None:
                    on_start(len(work), total, summary.executor)
            rows = map_ordered(_batch_job, work, executor=executor, progress=progress, desc="clean", max_workers=jobs,
                               on_result=finished_take, option=executor_option) if work else []
            finished = True
            if index is not None:
                summary.index = _write_index(index, summary.rows + [r for r in rows if r is not None], plans, inputs,
                                             in_dir, out_dir, request)
        except BaseException:  # an interrupt: a take written whose row never came is said from its record
            _tell_written(todo, said, request, markers, tell)
            raise
        finally:
            try:  # also after an interrupt: every complete AMC output reads back
                _place_asfs(skeletons, quiet=not finished)
            finally:
                sweep(expected)  # what a killed worker could not remove
                unmark_if_empty(out_dir)
                prune(made)  # the folders made for takes that failed
    summary.rows += [r for r in rows if r is not None]
    summary.rows.sort(key=lambda r: r["input"])
    if summary.stopped:
        summary.not_started = sum(r is None for r in rows)
        complete = summary.count("done") + summary.count("skipped")
        summary.stopped = (f"{summary.stopped}; stopped: {complete} of {plural(total, 'take')} complete, "
                           f"{summary.not_started} not started; the same command resumes the rest")
    summary.seconds = time.perf_counter() - t0
    return summary


def _write_index(index: Path, rows: list, plans: list, inputs: list, in_dir: Path, out_dir: Path,
                 request: dict) -> Path | None:
    """Write the batch's overview ``index`` (:func:`mocapkit.report.batch_index.write_batch_index`) of ``rows``, each
    with its report and, for a complete take skipped this run, the decisions file that decided it, read from its
    record (its counts are in its row: :func:`mocapkit.batch_written.skipped_counts`); None (nothing written) where
    no take is complete: the folder keeps no page of failures."""
    from . import __version__
    from .batch_decided import decided_by
    from .cleaning.pipeline import CleanResult
    from .report.batch_index import write_batch_index

    files_of = {str(inp): files for inp, files in zip(inputs, plans)}
    shown = []
    for row in rows:
        files = files_of.get(row["input"]) or {}
        row = {**row, "report": files.get("report") if row["status"] != "failed" else None}
        if row["status"] == "skipped" and files:  # its counts are the row's own (clean_batch read them)
            try:
                params = CleanResult.load_params(files["record"])
            except MocapError:  # an unreadable record: the take is listed, without its counts
                params = None
            row.update(decided=decided_by(params, files["output"]))
        shown.append(row)
    if not any(r["status"] != "failed" for r in shown):
        return None
    context = request.get("context")
    said = [f"steps {','.join(request.get('steps') or [])}", f"threshold {request.get('threshold'):g}",
            "the default context" if context == "default" else f"context {', '.join(map(str, context or []))}"]
    return write_batch_index(index, shown, in_dir=in_dir, out_dir=out_dir, request=", ".join(said),
                             version=__version__)


def _tell_written(todo: list, said: set, request: dict, markers: dict, tell: Callable[[dict], None]) -> None:
    """Tell the row of each take of ``todo`` not in ``said`` that is complete on disk for this run's ``request`` /
    ``markers`` (:func:`mocapkit.batch_written.found_written`); nothing that goes wrong here masks the interrupt."""
    from .batch_written import found_written

    try:
        for k, row in found_written([(k, inp, files) for k, (inp, files) in enumerate(todo) if k not in said],
                                    lambda inp, files: not _not_complete(inp, files, request, markers)[0]):
            _as_given(row, *todo[k], None)
            tell(row)
    except Exception:  # noqa: BLE001 - the interrupt is what the caller must see; the next run says these takes
        pass


def _as_given(row: dict, inp: Path, files: dict, again: str | None) -> None:
    """A worker's row with the paths as the caller gave them (the worker saw absolute ones); ``again``: why a
    take done before was cleaned again."""
    row.update(input=str(inp), output=str(files["output"]))
    if row["status"] == "done" and again:
        row["reason"] = again
    if row.get("file_notes"):  # each names its file already: as given, so the line names it once, as the take line
        row["file_notes"] = [_given(note, inp, files) for note in row["file_notes"]]
    if row["status"] == "failed":  # a reader's "PATH:LINE: ..." names the input as given, so its line says it once
        row["reason"] = _given(row["reason"], inp, files)


def _given(line: str, inp: Path, files: dict) -> str:
    """``line`` with the absolute paths a worker saw of the take's output and input as the caller gave them."""
    for path in (files["output"], inp):
        line = line.replace(_abs(path), str(path))
    return line


def _asf_copies(inputs: list[Path], plans: list[dict], asf, overwrite: bool,
                said: dict = SAID[False]) -> dict[Path, tuple[Path, list[str]]]:
    """For ``--format amc``: each ASF skeleton the AMC outputs need beside them, checked before any take is cleaned.

    An AMC holds no skeleton: read back, it takes the ASF beside it (named
    after its prefix, or the only one in its folder; :func:`mocapkit.io.asfamc.find_asf`),
    so each input AMC's ASF is copied, under its own name, into its output's
    folder. Returns ``{destination: (source ASF, [input AMCs that need it])}``.
    A destination that exists with other contents is replaced only with
    ``overwrite`` (else :class:`~mocapkit.errors.MocapFormatError`, nothing
    written); two different ASFs of one name for one folder are refused.
    The list holds the AMC outputs (not the inputs) that read with the copy.
    """
    from .io.takes import asf_of

    out: dict[Path, tuple[Path, list[str]]] = {}
    for inp, files in zip(inputs, plans):
        if files["output"].suffix.lower() != ".amc":
            continue
        src = asf_of(inp, asf)
        if src is None:
            continue  # the take cannot be read either: its row says so
        dst = files["output"].parent / src.name
        if dst in out and out[dst][0] != src and out[dst][0].read_bytes() != src.read_bytes():  # read once per ASF
            raise MocapFormatError(dst, f"two different skeletons of this name ({out[dst][0]}, {src}) would be "
                                        f"copied here for the AMC outputs; give {said['asf']} or write another format")
        out.setdefault(dst, (src, []))[1].append(str(files["output"]))
    for dst, (src, _) in out.items():
        if dst.exists() and not overwrite and (not dst.is_file() or dst.read_bytes() != src.read_bytes()):
            raise MocapFormatError(dst, f"exists and differs from the skeleton ({src}) the AMC outputs need beside "
                                        f"them; use {said['overwrite']} to replace it")
    return out


def _place_asfs(skeletons: dict[Path, tuple[Path, list[str]]], quiet: bool = False) -> None:
    """Copy each ASF of :func:`_asf_copies` (atomically) where an AMC output that reads with it is complete
    (the output and its record are there: written by this run or an earlier one). A copy that fails raises
    :class:`~mocapkit.errors.MocapFormatError` naming it, or, ``quiet`` (the batch is already ending on another
    error or an interrupt, which must not be masked), is left out."""
    from .cleaning.pipeline import clean_path
    from .io import atomic_write

    for dst, (src, outputs) in skeletons.items():
        if not any(Path(o).is_file() and clean_path(o).is_file() for o in outputs):
            continue
        try:
            data = src.read_bytes()
            if dst.is_file() and dst.read_bytes() == data:
                continue
            dst.parent.mkdir(parents=True, exist_ok=True)
            with atomic_write(dst, "wb") as fh:
                fh.write(data)
        except OSError as exc:
            if not quiet:
                raise MocapFormatError(dst, f"cannot copy the skeleton {src} there, which its AMC outputs read "
                                            f"with ({exc.strerror or exc})") from None


def _abs(p) -> str:
    return os.path.abspath(os.fspath(p))

