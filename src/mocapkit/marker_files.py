"""One marker capture file cleaned: read, cleaned (or its earlier record reused), decided, written.

What ``mocapkit clean`` and :func:`mocapkit.batch.clean_batch` do with a
marker capture (.c3d, .trc, marker .npz): :func:`clean_marker_file` writes the
cleaned capture (or, with a decisions file, the input with only the accepted
changes; in review mode the input unchanged), its ``.clean.npz`` record and
the reports; :func:`marker_request` is what its record keeps of the options
it was cleaned with; :func:`refuse_marker_options` refuses the options of
joint-angle takes.
"""

from __future__ import annotations

from collections.abc import Mapping
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Sequence

from .batch_decided import decided_entry, is_own_record, stamp_decided
from .errors import MocapError

__all__ = ["clean_marker_file", "the_input", "zeros_read_lines", "gaps_bar", "marker_request", "joint_angle_options",
           "refuse_marker_options"]


def marker_request(unit: str | None = None, max_gap_s: float | None = None, max_error_mm: float | None = None,
                   review: bool = False, zeros_as_gaps: bool | None = None) -> dict:
    """What a marker capture was asked to be cleaned with, as its record keeps it (``request``): the length unit of a
    file that states none, the longest gap filled (s) and the largest expected fill error (mm), None for the
    defaults, ``review``: whether it was only reviewed (``--steps detect``: nothing changed), and ``zeros_as_gaps``:
    how its samples at exactly (0, 0, 0) were read (``--zeros-as-gaps``/``--keep-zeros``; None: decided from the
    data), which makes another capture of the same file. :func:`clean_batch` takes a capture as complete only when its record holds the same request, as
    :func:`clean_request` is for a joint-angle take; a record written before it kept one reads as the defaults."""
    return {"unit": unit, "max_gap_s": None if max_gap_s is None else float(max_gap_s),
            "max_error_mm": None if max_error_mm is None else float(max_error_mm), "review": bool(review),
            "zeros_as_gaps": None if zeros_as_gaps is None else bool(zeros_as_gaps)}


def joint_angle_options(given: Mapping[str, object], flags: bool) -> list[str]:
    """The joint-angle options ``given`` (request key -> value, only those the caller set: ``steps`` a subset of the
    steps, ``threshold``, ``drifts``, ``context``, ``models`` a ``{kind: model}`` map, ``noise_deg``, ``joint_map``)
    named as the caller gave them, for :func:`refuse_marker_options`: the command line's flags (``--steps
    fill,denoise``, ``--threshold``, ``--ebf``: :data:`mocapkit.cleaning.request_words.OPTION_FLAGS`) or Python's
    keywords as a call writes them (``steps='fill,denoise'``, ``threshold=``, ``models=``: ``OPTION_KEYWORDS``). The
    steps come with their value (only some are refused), as typed when given as text (``--steps denoise,fill``), each
    model by its own flag. The one table of these words: ``mocapkit clean``, :func:`mocapkit.batch.clean_file` and
    :func:`mocapkit.clean` each refuse what it names."""
    from .cleaning.request_words import OPTION_FLAGS, OPTION_KEYWORDS, said_option

    said = []
    for key, value in given.items():
        if key == "steps":
            said.append(said_option(key, value if isinstance(value, str) else list(value), flags))
        elif key == "models" and flags and isinstance(value, Mapping):
            said.extend(f"--{kind}" for kind in value)
        else:
            said.append(OPTION_FLAGS[key] if flags else f"{OPTION_KEYWORDS[key]}=")
    return said


def refuse_marker_options(inp, names: Sequence[str]) -> None:
    """Refuse, in one line, what a marker capture's cleaning cannot honour: a marker capture is cleaned whole.

    ``names``: the options given that only a joint-angle take's cleaning has (a subset of its steps, a
    threshold, a context, models); cleaning the capture anyway would not do what its user asked.
    """
    if names:
        raise MocapError(f"{inp}: a marker capture is cleaned whole (label swaps, spikes, gaps): "
                         f"{', '.join(names)} {'applies' if len(names) == 1 else 'apply'} only to joint-angle takes")


@contextmanager
def gaps_bar(name: str, progress: bool):
    """A tqdm bar over the gaps a marker cleaning fills (``desc`` "fill NAME", unit "gap"): yields the
    ``progress(done, more)`` callback :func:`~mocapkit.cleaning.markers.clean_markers` takes, or None without
    ``progress``. The fills are most of a marker cleaning's time (36 s of silence to minutes on a loaded machine
    for Qualisys's 03_rolling.c3d, 194 gaps); the bar is drawn from the start, its total set when the gaps are
    counted, and only on a terminal (:func:`mocapkit.progress.bar_disabled`), on standard error."""
    if not progress:
        yield None
        return
    from tqdm.auto import tqdm

    from .progress import bar_disabled, bar_size

    # standard error's size (80 x 24 where a pseudo-terminal reports 0 x 0: mocapkit.progress.bar_size)
    bar = tqdm(total=0, desc=f"fill {name}", unit="gap", disable=bar_disabled(True), **bar_size())

    def tick(done: int, more: int = 0) -> None:
        if more:
            bar.total += more
            bar.refresh()
        if done:
            bar.update(done)

    try:
        yield tick
    finally:
        bar.close()


def zeros_read_lines(zero_gaps: int | None, flags: bool = True) -> list[str]:
    """The reader's reading of samples stored as exact (0, 0, 0) as gaps, in words, with how to undo it (``flags``:
    the command line's ``--keep-zeros``, else Python's ``zeros_as_gaps=False``); [] where it read none.

    It drives the fills (all but 5 of 03_rolling.c3d's 24,405 changed samples are its 35,965 zeros read as
    gaps), yet only the console said it: the report's summary (:func:`mocapkit.report.markers.write_marker_report`'s
    ``read``) and ``info`` of the record (its ``written["read"]["zero_gaps"]``) say it too, for a reviewer
    working from them after the run."""
    from .io.c3d_contents import zero_gaps_line

    if not zero_gaps:
        return []
    how = "--keep-zeros" if flags else "zeros_as_gaps=False"
    return [f"{zero_gaps_line(int(zero_gaps))} ({how} keeps them as positions)"]


def the_input(inp, out, original, output) -> bool:
    """Whether the capture ``output`` written to ``out`` is the file ``inp`` itself: the same format (suffix) and
    not one sample changed (:func:`~mocapkit.cleaning.markers.decisions.differs`: position, residual or camera
    mask), as in review mode (``--steps detect``), with every change rejected, or for a capture with nothing to
    clean. :func:`clean_marker_file` then writes ``inp``'s bytes: a C3D written anew is not its input (ezc3d lays
    out the parameter section its own way, and a file that states no length unit would gain POINT:UNITS), while
    the guides promise the input file back. ``original``: the capture read from ``inp``."""
    from .cleaning.markers.decisions import differs

    if Path(inp).suffix.lower() != Path(out).suffix.lower():
        return False
    if output is original:
        return True
    return (tuple(output.labels) == tuple(original.labels) and output.num_frames == original.num_frames
            and not differs(original, output).any())


def clean_marker_file(inp, out, *, report=None, png=None, overwrite: bool = False, markers=None, steps=None,
                      unit: str | None = None, max_gap_s: float | None = None, max_error_mm: float | None = None,
                      decisions=None, record=None, review: bool = False, keep_modelled: bool = False,
                      placed=None, zeros_as_gaps: bool | None = None, flags: bool = False, progress: bool = False):
    """Clean the marker capture at ``inp`` (.c3d, .trc, marker .npz) into ``out`` (.c3d, .trc or .npz).

    :func:`mocapkit.cleaning.markers.clean_markers`, then the reports (HTML
    marker viewer with the accept/reject list, per-marker PNG), ``out`` written like the input
    (``save_markers(..., like=input)``: a C3D keeps its parameters and
    analogs, and a gap it stored as exact (0, 0, 0) that the cleaning left
    missing comes back as it stored it; where no sample changed, in the input's
    format, ``out`` is the input's bytes: :func:`the_input`) and the ``.clean.npz`` record last. ``max_gap_s``, ``max_error_mm``: as for
    :func:`~mocapkit.cleaning.markers.clean_markers`. ``decisions``: a decisions file
    (:mod:`mocapkit.cleaning.markers.decisions`): ``out`` then holds only the changes it accepts, every other
    sample the input's; ``record``: the ``.clean.npz`` of an earlier run on this capture, reused instead of
    cleaning again (needs ``decisions``; only ``out`` and the reports are written). ``review``: the review mode
    (``--steps detect``): the record and reports say what cleaning would change and ``out`` holds the input's
    samples unchanged. Returns ``(original, result)``: the capture as read and the
    :class:`~mocapkit.cleaning.markers.MarkerCleanResult` given back
    (:func:`~mocapkit.cleaning.markers.decisions.clean_and_decide`: in review mode the cleaning with ``review``
    set, with decisions the decided capture and its ``decided`` summary; the report draws it); the record keeps
    the whole cleaning (rebuilt from ``record`` when one is reused). ``keep_modelled``: a .trc ``out`` keeps
    the C3D's modelled quantities (:func:`mocapkit.io.save_markers`); refused where it means nothing
    (:func:`mocapkit.io.check_keep_modelled`: ``out`` not a .trc, ``inp`` not a .c3d).
    ``placed``: where ``out`` is moved once written (a batch's staging folder): the report names the record there.
    ``zeros_as_gaps``: how a .c3d or .trc ``inp``'s samples at exactly (0, 0, 0) are read when ``markers`` is not
    given (:func:`mocapkit.io.load_markers`; None: decided from the data), kept in the record's request and said in
    the report's command. ``flags``: a refusal names the command line's options (``--record``, ``--overwrite``,
    ``--steps detect``), else Python's keywords (``record=``, ``overwrite=True``, ``steps='detect'``).
    ``progress``: a progress bar over the gaps as they are filled (:func:`gaps_bar`; on standard error, drawn only
    on a terminal, as the joint-angle cleaning's bar).
    """
    from .cleaning import decisions as dec
    from .cleaning.decided import apply_command
    from .cleaning.markers import decisions as mdec
    from .cleaning.pipeline import clean_path
    from .io import MARKER_FORMATS, atomic_write, check_keep_modelled, load_markers, save_markers, suffix_kind
    from .io.outputs import check_outputs, file_facts, input_facts, removed_on_failure
    from .io.takes import file_first_frame

    inp, out = Path(inp), Path(out)
    if keep_modelled:
        check_keep_modelled(inp, out)
    reuse = record is not None
    if reuse and decisions is None:
        raise MocapError(f"{record}: an earlier run's record is applied with decisions; give the decisions file")
    option = dec.RECORD_FLAG if flags else dec.RECORD_KEYWORD
    if review and decisions is not None:
        raise MocapError(f"{inp}: review mode ({dec.review_mode(option)}) changes nothing; decisions apply to a cleaning")
    record = Path(record) if reuse else clean_path(out)
    outputs = [out, None if reuse else record, report, png]
    check_outputs(outputs, [inp, decisions, record if reuse else None], overwrite=overwrite,
                  how="pass --overwrite" if flags else "pass overwrite=True")
    suffix_kind(out, MARKER_FORMATS, "writing markers")
    taken = input_facts(inp)
    zeros = {} if zeros_as_gaps is None or inp.suffix.lower() not in (".c3d", ".trc") else {"zeros_as_gaps": zeros_as_gaps}
    ms = markers if markers is not None else load_markers(inp, **({} if unit is None else {"units": unit}), **zeros)
    request = marker_request(unit, max_gap_s, max_error_mm, review, zeros_as_gaps)
    with gaps_bar(inp.name, progress and not reuse) as tick:  # minutes on a long capture: said as it goes
        res, given = mdec.clean_and_decide(ms, name=str(inp), steps=steps, max_gap_s=max_gap_s,
                                           max_error_mm=max_error_mm, decisions=decisions,
                                           record=record if reuse else None, review=review, request=request,
                                           take=inp.name, option=option, progress=tick)
    read = zeros_read_lines(ms.zero_gaps, flags)  # the reader's decision the fills rest on: in the report and the record
    note = dec.frames_note(inp, ms)  # the summary says how its frames relate to the file's
    res, given = replace(res, frames_note=note), replace(given, frames_note=note)
    chosen = None if given.decided is None else dec.read_decisions(decisions)["decisions"]
    with removed_on_failure(outputs, overwrite=overwrite, marker=None if reuse else record):
        if report is not None:
            from .report.markers import write_marker_report

            what = ("review mode, nothing changed" if review else f"{Path(decisions).name} applied" if chosen is not None
                    else "")
            write_marker_report(report, given, title=f"{inp.name}: cleaned" + (f" ({what})" if what else ""),
                                review=mdec.review(ms, res.markers, res.fixes, take=inp.name, output=out.name,
                                                   decisions=chosen, first_frame=file_first_frame(inp, ms),
                                                   request=request,
                                                   record=record if reuse or placed is None else clean_path(placed),
                                                   command=apply_command(inp, unit=unit,
                                                                         zeros_as_gaps=zeros_as_gaps)),
                                review_mode=review, read=read)
        if png is not None:
            from .report.markers import plot_marker_fixes

            plot_marker_fixes(png, given, title=f"{inp.name}: before (grey) and after")
        if the_input(inp, out, ms, given.output):  # a review, every change rejected, nothing to change
            with atomic_write(out, "wb") as fh:
                fh.write(inp.read_bytes())
        else:
            save_markers(given.output, out, like=ms, stored_zeros=True, keep_modelled=keep_modelled,
                         filled=given.fill_mask, overwrite=True)  # out: checked by the output guard before the work
        if reuse and chosen is not None and is_own_record(record, out):  # decided in place: a later batch keeps OUT
            stamp_decided(record, decisions, out, given.decided.holds())
        if not reuse:  # last: the completion marker
            # a new cleaning, decided: its record says so, as one decided in place does (batch_decided)
            said = {"read": {"zero_gaps": int(ms.zero_gaps)}} if ms.zero_gaps else {}  # info of the record says it
            res.save(record, written={"input": taken, "output": file_facts(out), **said}, request=request,
                     decided=None if chosen is None else decided_entry(decisions, out, given.decided.holds()))
    return ms, given
