"""The main job: ``clean`` one take and ``clean-batch`` a folder of takes."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Optional

import typer

from ..errors import MocapError, MocapFormatError
from ..words import frame_span
from .common import (STEPS_HELP, amc_fps_option, asf_option, check_executor, check_noise_deg, console, context_option, joint_map_option, read_map,
                     executor_option, guard, keep_modelled_option, max_fill_error_option, max_gap_option,
                     listed, noise_deg_option, overwrite_option, percent, plural, unit_option, zeros_option)


def _steps(text: str) -> list[str]:
    from ..cleaning.pipeline import parse_steps

    try:
        return list(parse_steps(text))
    except ValueError as exc:
        raise MocapError(f"--steps: {exc}") from None


def _model_option(kind: str):
    """``--ebf`` / ``--ebd``: the model a step uses instead of the one shipped for the take's rig."""
    role = "denoises" if kind == "ebf" else "fills gaps"
    return typer.Option(None, f"--{kind}", help=f"The {kind.upper()} that {role}: a model file or a shipped one's "
                                                f"name, {kind}.pt or {kind}_bandai.pt (default: the one for the take's "
                                                "rig).")


def clean(
    ctx: typer.Context,
    inp: Path = typer.Argument(..., metavar="IN", help="Motion (.bvh, .amc, .npz) or marker capture (.c3d, .trc, marker .npz) to clean."),
    out: Path = typer.Option(..., "--out", "-o", help="Cleaned take (.bvh, .amc for a take read from ASF/AMC, or .npz; a marker capture: .c3d, .trc or .npz); OUT's stem + .clean.npz is written beside it (with --decisions --record of another file: not written)."),
    context: Optional[list[Path]] = context_option(),
    joint_map: Optional[Path] = joint_map_option(),
    steps: str = typer.Option("fill,detect,repair,denoise", "--steps",
                              help=STEPS_HELP + " --steps detect is the review mode: flags, record and report; OUT "
                                                "holds the input's samples unchanged."),
    threshold: float = typer.Option(0.5, "--threshold", help="MDM value above which a joint is flagged and repaired (0-1)."),
    noise_deg: Optional[float] = noise_deg_option(),
    drifts: bool = typer.Option(
        False, "--drifts",
        help="Also flag and repair smooth drifts (no break) where the --context repeats the take's motion "
             "(docs/guide/cleaning.md).",
    ),
    report: Optional[Path] = typer.Option(None, "--report", help="Also write the self-contained HTML report here."),
    png: Optional[Path] = typer.Option(None, "--png", help="Also write a static summary figure (MDM + before/after channels)."),
    reference: Optional[Path] = typer.Option(None, "--reference", help="The clean take, to print the error before and after."),
    decisions: Optional[Path] = typer.Option(
        None, "--decisions", help="Accept/reject per change (the report's 'Download decisions'): OUT gets only the "
                                  "accepted changes. The record of the earlier run (--record, else OUT's .clean.npz "
                                  "if it exists) is reused; without one the take is cleaned first."),
    record: Optional[Path] = typer.Option(None, "--record", help="With --decisions: the .clean.npz of the earlier run "
                                                                 "(default: OUT's, if it exists). Another file than "
                                                                 "OUT's: no record is written beside OUT."),
    ebf: Optional[Path] = _model_option("ebf"),
    ebd: Optional[Path] = _model_option("ebd"),
    asf: Optional[Path] = asf_option(),
    amc_fps: Optional[float] = amc_fps_option(),
    unit: Optional[str] = unit_option(),
    max_gap: Optional[float] = max_gap_option(),
    max_fill_error: Optional[float] = max_fill_error_option(),
    keep_modelled: bool = keep_modelled_option(),
    zeros_as_gaps: Optional[bool] = zeros_option(),
    overwrite: bool = overwrite_option(),
) -> None:
    """Clean a take: fill gaps, detect and repair erroneous joints, denoise only the noisy cells.

    Writes OUT and, beside it, OUT's stem + .clean.npz (MDM, flags, the cells each step changed and
    a record per step); everything not missing, flagged or noisy stays bit-identical. The report
    (--report) lists every change for a person to accept or reject; --decisions then writes OUT
    with only the accepted changes, every other sample bit-identical to IN, and the record beside
    OUT says by which file and what OUT holds (its counts stay the cleaning reviewed): OUT's own
    record is reused and stamped, or, with no record, the new cleaning's is written stamped; with
    --record naming another record, none is written beside OUT (that record stays as it was). A marker
    capture (.c3d, .trc) gets swapped labels undone, spikes removed and gaps filled instead, each a
    change to accept or reject the same way (--steps detect reviews it; the other options of
    joint-angle takes are refused for it); every other sample stays bit-identical.
    """
    from ..batch import clean_file
    from ..cleaning.pipeline import STEPS, clean_path
    from ..io import motion_notes
    from ..io.takes import asf_for_output, asf_of, CLI_AMC_NAMES, check_asf, load_motion, unread_amc_note
    from ..marker_files import joint_angle_options
    from ..reference import check_reference

    if record is not None and decisions is None:
        raise MocapError("--record: the earlier run's record is read with --decisions; give the decisions file")
    step_list = _steps(steps)  # an unknown step is refused for any take
    def said(*options) -> list[str]:  # the flags given, in marker_files' one table of joint-angle options
        return joint_angle_options({key: value for key, value, given in options if given}, flags=True)

    models_given = {kind: model for kind, model in (("ebf", ebf), ("ebd", ebd)) if model is not None}
    not_for_markers = (said(("steps", steps, tuple(step_list) not in (STEPS, ("detect",))),
                            ("threshold", threshold, threshold != 0.5), ("noise_deg", noise_deg, noise_deg is not None),
                            ("context", context, bool(context)), ("drifts", drifts, drifts),
                            ("joint_map", joint_map, joint_map is not None))
                       + ["--reference"] * (reference is not None)  # the command's own: no Python call has it
                       + said(("models", models_given, bool(models_given))))
    _check_out_early(inp, out)
    record_said = "--record"
    if decisions is not None and record is None and clean_path(out).is_file():
        record = clean_path(out)  # the earlier run's record beside OUT: apply the decisions, clean nothing again
        record_said = "OUT's record"
    if record is not None:
        guard([out, report, png], [inp, asf, context, reference, decisions, record, ebf, ebd, joint_map], overwrite)
    else:
        guard([out, clean_path(out), report, png], [inp, asf, context, reference, decisions, ebf, ebd, joint_map],
              overwrite)
    jm = read_map(joint_map)
    check_asf(asf, [inp, reference], amc_fps, names=CLI_AMC_NAMES)
    check_noise_deg(noise_deg)
    if _clean_marker_take(inp, out, report=report, png=png, overwrite=overwrite, not_for_markers=not_for_markers,
                          unit=unit, max_gap_s=max_gap, max_error_mm=max_fill_error, decisions=decisions,
                          record=record, record_said=record_said, review=tuple(step_list) == ("detect",),
                          keep_modelled=keep_modelled, zeros_as_gaps=zeros_as_gaps):
        return
    for name, given in (("--max-gap", max_gap), ("--max-fill-error", max_fill_error),
                        ("--keep-modelled", keep_modelled or None),
                        ("--zeros-as-gaps" if zeros_as_gaps else "--keep-zeros", zeros_as_gaps)):
        if given is not None:
            raise MocapError(f"{inp}: {name} applies only to marker captures (.c3d, .trc, marker .npz)")
    models = _models(ebf, ebd)
    if record is not None:  # options that shape a cleaning: only those the record's own cleaning was asked for
        from ..batch_request import clean_request
        from ..cleaning.replay import check_replay, given_options

        given = set(given_options(step_list, threshold, drifts, bool(context), models, noise_deg))
        given |= {key for key in ("steps", "threshold", "drifts")  # a flag typed at its default is given too
                  if getattr(ctx.get_parameter_source(key), "name", "") == "COMMANDLINE"}
        given |= {"joint_map"} if jm is not None else set()
        check_replay(record, clean_request(step_list, threshold, drifts, context, models, noise_deg, amc_fps, unit, jm),
                     given, True, record_said)
    skeleton = asf_of(inp, asf)
    skeleton_copy = asf_for_output(out, skeleton, overwrite, how="use --overwrite")  # an AMC output reads back with its ASF beside it
    take = load_motion(inp, asf, purpose="clean", fps=amc_fps, unit=unit, unit_option="--unit")
    ref = None
    if reference is not None:  # refused before cleaning, not after OUT is written
        ref = check_reference(load_motion(reference, asf, purpose="a reference", fps=amc_fps, unit=unit,
                                          unit_option="--unit"), reference,
                              frames=take.num_frames,
                              joint_names=take.skeleton.joint_names, option="--unit")
    original, res = clean_file(inp, out, context=context, steps=step_list, threshold=threshold, report=report, png=png,
                               progress=True, asf=asf if inp.suffix.lower() == ".amc" else None, overwrite=overwrite,
                               motion=take, drifts=drifts, decisions=decisions, noise_deg=noise_deg,
                               record=record, models=models, amc_fps=amc_fps, unit=unit, joint_map=jm, flags=True,
                               skeleton_copy=(skeleton_copy, skeleton) if skeleton_copy is not None else None)
    if skeleton_copy is not None:
        console.print(f"copied the skeleton {skeleton} to {skeleton_copy}: an AMC is read with the ASF beside it")
    unread = unread_amc_note(out, inp)  # an AMC from an .npz: no ASF to copy beside it
    for note in motion_notes(original, out, inp) + ([unread] if unread else []):  # what OUT's format leaves out
        console.print(f"note: {note}")
    if res.decided is not None:  # clean_file applied the decisions: res is what OUT holds
        _print_decided(_written(out, record, report, png), res.decided, res.frames_note)
        _print_reference(ref, reference, original, res.motion)
        return
    from ..cleaning.judged import not_judged_note

    m = res.motion
    review = [s for s in res.steps if s.name != "detect"] == [] and res.detection is not None
    unjudged = not_judged_note(res.detection, res.num_frames)  # said beside the untouched share: not examined
    console.print(f"wrote {listed(p for p in (out, clean_path(out), report, png) if p is not None)}"
                  + f": {plural(res.num_frames, 'frame')} @ {m.fps:g} fps, "
                  + ("review mode (--steps detect): flags only, the take unchanged"
                     + (f"; {unjudged}" if unjudged else "") if review else
                     f"{int(res.changed.sum())} of {plural(res.changed.size, 'joint sample')} changed "
                     f"({percent(int((~res.changed).sum()), res.changed.size)} % untouched"
                     + (f"; {unjudged}" if unjudged else "") + ")"))
    # a step's fallback or its model's licence: a warning, word for word as denoise and fill say it, and only there
    warned = res.warnings
    for line in res.summary():
        for note in warned:
            line = line.replace(f"; {note}", "")
        console.print(f"  {line}")
    for note in warned:
        console.print(f"warning: {inp}: {note}")
    from ..cleaning.decisions import tied_lines

    for line in tied_lines(res):  # changes a person must decide together, and why
        console.print(f"  {line}")
    if res.detection is not None:
        from ..cleaning.decisions import flag_segments

        segs = flag_segments(res)
        for g in segs[:12]:
            a, last = g["first"], g["last"]
            why = ": " + ", ".join(g["why"]) if g["why"] else ""
            # each frame's time, as the viewer labels it
            console.print(f"    flagged {g['joint']:16s} {frame_span(a, last, m.fps)}{why}")
        if len(segs) > 12:
            console.print(f"    ... and {len(segs) - 12} more (all in {clean_path(out)})")
    _print_reference(ref, reference, original, m)


def _check_out_early(inp: Path, out: Path) -> None:
    """Before the output guard: OUT's suffix for the input's kind (when its suffix tells the kind), and the record
    beside OUT landing on the input (``clean a.clean.npz -o a.npz``), each said as what it is."""
    from .. import io
    from ..cleaning.pipeline import clean_path
    from ..io.outputs import same_file

    kind = inp.suffix.lower()
    if kind in (".bvh", ".amc"):
        io.suffix_kind(out, io.WRITERS, "writing")
    elif kind in (".c3d", ".trc"):
        io.suffix_kind(out, io.MARKER_FORMATS, "writing markers")
    if inp.exists() and same_file(clean_path(out), inp):
        raise MocapFormatError(clean_path(out), f"the record of {out} (its stem + .clean.npz) would be written over "
                                                "this input; choose another output name")


def _models(ebf: Optional[Path], ebd: Optional[Path]) -> dict | None:
    """``--ebf`` / ``--ebd`` checked (a model of that kind, or a shipped one's name) before any work; None: shipped."""
    given = {k: p for k, p in (("ebf", ebf), ("ebd", ebd)) if p is not None}
    if not given:
        return None
    from ..cleaning.pipeline import check_models

    check_models(given)  # a missing, malformed or wrong-kind file: one line naming it (mocapkit.clean's check)
    return {k: str(p) for k, p in given.items()}


def _print_reference(ref, reference, original, m) -> None:
    """The error against ``--reference`` before and after (nothing without one)."""
    from ..reference import clean_errors

    if ref is None:
        return
    e = clean_errors(ref, original, m)
    gaps = " (input gaps linearly filled)" if e["gaps_filled"] else ""
    console.print(f"  error against {reference.name}{gaps}: pose error {e['pose_before']:.4f} -> {e['pose_after']:.4f} "
                  "per frame (Aristidou et al. 2018 eq. 2: sum over joints of the squared half-angle of each "
                  f"rotation error, rad^2); positions of joints and end sites {e['cm_before']:.2f} -> {e['cm_after']:.2f} "
                  "cm RMS (root-relative)")


def _print_decided(written, decided, frames_note: str) -> None:
    """The summary of ``clean --decisions``, for a joint-angle take and a marker capture alike: the files written,
    then :meth:`~mocapkit.cleaning.decided.Decided.lines` (what was applied to what, its notes, the rejected
    changes)."""
    head, *rest = decided.lines(frames_note)
    console.print(f"wrote {listed(written)}: {head}")
    for line in rest:
        console.print(line if line.startswith("note: ") else f"  {line}")


def _clean_marker_take(inp: Path, out: Path, *, report, png, overwrite: bool, not_for_markers: list[str],
                       unit: str | None = None, max_gap_s: float | None = None,
                       max_error_mm: float | None = None, decisions=None, record=None, record_said: str = "--record",
                       review: bool = False, keep_modelled: bool = False, zeros_as_gaps: bool | None = None) -> bool:
    """Clean ``inp`` as a marker capture when it is one (writing OUT, its record and reports); False for a motion.

    ``not_for_markers``: the options given that apply only to joint-angle takes, refused for a marker capture;
    ``unit``: ``--unit``, the length unit of a file that states none; ``decisions``, ``record``, ``review``,
    ``keep_modelled``, ``zeros_as_gaps`` (``--zeros-as-gaps/--keep-zeros``): :func:`mocapkit.marker_files.clean_marker_file`'s; ``record_said``: how the record was given
    (``--record``, or OUT's found by ``--decisions``), for a refusal of options beside it.
    """
    from ..batch import clean_marker_file, refuse_marker_options
    from ..cleaning.markers.decisions import tied_lines
    from ..cleaning.pipeline import clean_path
    from ..io import marker_notes
    from ..io.c3d_contents import marker_counts
    from ..marker_files import zeros_read_lines
    from ..io.takes import load_take
    from ..markerset import MarkerSet

    if inp.suffix.lower() not in (".c3d", ".trc", ".npz"):
        return False
    take = load_take(inp, unit=unit, unit_option="--unit", zeros_as_gaps=zeros_as_gaps)
    if not isinstance(take, MarkerSet):
        return False
    refuse_marker_options(inp, not_for_markers)
    if record is not None:  # a longest gap or fill error: only that of the record's own cleaning
        from ..cleaning.replay import check_replay
        from ..marker_files import marker_request

        check_replay(record, marker_request(unit, max_gap_s, max_error_mm), [
            key for key, value in (("max_gap_s", max_gap_s), ("max_error_mm", max_error_mm)) if value is not None],
            True, record_said)
    _, res = clean_marker_file(inp, out, report=report, png=png, overwrite=overwrite, markers=take,
                               max_gap_s=max_gap_s, max_error_mm=max_error_mm, decisions=decisions, record=record,
                               review=review, keep_modelled=keep_modelled, zeros_as_gaps=zeros_as_gaps, flags=True,
                               progress=True)  # a bar over the gaps filled, as the joint-angle path has (a terminal only)
    if res.decided is not None:
        _print_decided(_written(out, record, report, png), res.decided, res.frames_note)
        for note in marker_notes(take, out, inp, keep_modelled=keep_modelled, filled=res.fill_mask):
            console.print(f"note: {note}")
        return True
    # markers counted as info and convert count them: a C3D's modelled quantities (angles, forces, ...) apart, left as read
    markers, quantities, _ = marker_counts(take)
    also = f" (+{plural(quantities, 'modelled quantity', 'modelled quantities')}, left as read)" if quantities else ""
    console.print(f"wrote {listed(x for x in (out, clean_path(out), report, png) if x is not None)}: {plural(take.num_frames, 'frame')} x "
                  f"{plural(markers, 'marker')}{also}" + ("" if res.review else  # summary()'s first line says it
                  f", {int(res.changed.sum())} of {plural(take.num_frames * markers, 'marker sample')} changed"))
    if take.units_from != "file":  # the unit every mm figure below rests on
        how = "given with --unit" if take.units_from == "given" else "inferred from the marker distances; --unit sets it"
        console.print(f"  length unit {take.units}: the file states none ({how})")
    for line in zeros_read_lines(take.zero_gaps):  # the gaps below include these; the report and record say it too
        console.print(f"  {line}")
    for line in res.summary():
        console.print(f"  {line}")
    for line in tied_lines(take, res.markers, res.fixes):  # changes a person must decide together, and why
        console.print(f"  {line}")
    # what the reader did, what OUT's format cannot hold or tell apart
    for note in marker_notes(take, out, inp, keep_modelled=keep_modelled, filled=res.fill_mask, record=clean_path(out)):
        console.print(f"note: {note}")
    for fix in res.fixes[:12]:
        other = f" with {fix.other}" if fix.other and fix.kind == "swap" else ""  # a duplicate's says it in words
        console.print(f"    {fix.kind:9s} {fix.marker:16s} {frame_span(fix.start, fix.end - 1)}{other} ({fix.size_text})")
    if len(res.fixes) > 12:
        console.print(f"    ... and {len(res.fixes) - 12} more (all in {clean_path(out)})")
    return True


def _written(out: Path, record, report, png) -> list:
    """The files ``clean --decisions`` wrote: OUT, its record when it cleaned again (no ``record`` given), the
    reports."""
    from ..cleaning.pipeline import clean_path

    return [out] + ([clean_path(out)] if record is None else []) + [p for p in (report, png) if p is not None]


def _take_line(row: dict, done: str = "cleaned") -> str:
    """One line per take of a batch: what was found and fixed, or why it failed or was skipped; ``done``: the word
    a take done starts with ("reviewed" in review mode, --steps detect, where nothing is changed)."""
    from ..cleaning.markers.counts import unvalidated_words
    from ..cleaning.take_breaks import cuts_phrase
    from ..side_labels import exchanged_phrase

    if row["status"] == "failed":
        reason, name = str(row["reason"]), str(row["input"])
        # a reader's reason names the file already ("PATH:LINE: ..."): the path once
        named = reason.startswith(name) and reason[len(name):len(name) + 1] == ":"
        return f"failed  {reason}" if named else f"failed  {name}: {reason}"
    if row["status"] == "skipped":
        return f"skipped {row['input']}: {row.get('reason') or 'complete'}"
    found = [plural(row[k], what) for k, what in (("filled", "filled sample"), ("flagged", "flagged sample"),
                                                   ("repaired", "repaired sample"), ("denoised", "denoised sample"),
                                                   ("spikes", "spike sample"), ("swapped", "re-labelled sample"),
                                                   ("duplicates", "duplicate-label sample"))
             if row.get(k)]
    blind = unvalidated_words(row)  # set apart as the clean's summary and info set them apart
    if blind and row.get("filled"):
        found[0] += f" ({blind})"
    if row.get("foreign"):  # the kinds of cleaning.markers.counts: every changed sample said, none filed as unchanged
        found.append(plural(row["foreign"], "sample of another point under a label",
                            "samples of other points under their labels"))
    what = ", ".join(found) if found else "nothing to change"
    # flags left as they were and frames detection never judged: the counts alone read as all of it checked
    what = "; ".join([what] + [row[k] for k in ("left", "judged") if row.get(k)])
    cuts = cuts_phrase(row.get("cuts") or ())  # named for a person to decide: no sample changed for them
    what += f"; {cuts}" if cuts else ""
    sides = exchanged_phrase(row.get("notes"))  # a rig mapped left for right: the record and the JSON say it whole
    what += f"; {sides}" if sides else ""
    # "cleaned again: its input changed ...", or a take found written after an interrupt (no time measured)
    seconds = row.get("seconds", 0.0)
    said = [f"{seconds:.1f} s" if seconds is not None else "", row.get("reason") or ""]
    return f"{done} {row['input']} -> {row['output']}: {what} ({'; '.join(x for x in said if x)})"


def files_line(out_dir, *, report: bool, png: bool, any_take: bool) -> str:
    """The line ``clean-batch`` ends with that says where each take's files are, "" where no take was cleaned or
    is complete (``any_take`` False). The take lines name the outputs only: a person looking for what the cleaning
    did needs the record beside each (``STEM.clean.npz``: the changes, flags and cuts, to accept or reject) and, with
    ``--report``, the report; without it, that no report was written and how to get one, so that the overview
    (``OUT_DIR/index.html``) is not looked for where it was never asked for."""
    if not any_take:
        return ""
    files = ["STEM.clean.npz (its record: changes, flags and cuts)"]
    files += ["STEM.report.html (its report)"] if report else []
    files += ["STEM.summary.png (its summary figure)"] if png else []
    line = f"each take's files are beside its output in {out_dir}: {listed(files)}"
    if report:
        return line
    return (line + "; no reports were asked for: --report writes STEM.report.html beside each output and "
            f"{Path(out_dir) / 'index.html'} over them (with --overwrite for the takes already complete)")


def start_line(in_dir, todo: int, total: int, where: str) -> str:
    """The line ``clean-batch`` prints on standard error as its first take is handed out (``todo`` of ``total``
    takes under ``in_dir``, cleaned on ``where``: ``BatchSummary.executor``): a log said nothing until the first
    take was done. On a cold cache numba compiles the kernels the first takes call, once (90 s before the first
    take of two Bandai Namco takes in one process here; a user's trial of 40 on 2 cores: 112 s);
    ``python -m mocapkit.warmup`` (:mod:`mocapkit.warmup`, which ``make install`` runs) compiles them ahead:
    ``cleaning 3 of 40 takes in takes (37 already complete) on this process; on a cold numba cache the first
    takes wait for numerical kernels to compile (1-2 min, once; python -m mocapkit.warmup compiles them ahead)``.
    """
    which = plural(total, "take") if todo == total else f"{todo} of {plural(total, 'take')}"
    done = f" ({total - todo} already complete)" if todo < total else ""
    return (f"cleaning {which} in {in_dir}{done} on {where}; on a cold numba cache the first takes wait for "
            "numerical kernels to compile (1-2 min, once; python -m mocapkit.warmup compiles them ahead)")


def clean_batch(
    in_dir: Path = typer.Argument(..., metavar="IN_DIR", help="Folder of takes (searched recursively)."),
    out_dir: Path = typer.Argument(..., metavar="OUT_DIR", help="Folder for the cleaned takes (same layout)."),
    context: Optional[list[Path]] = context_option(),
    joint_map: Optional[Path] = joint_map_option(),
    steps: str = typer.Option("fill,detect,repair,denoise", "--steps", help=STEPS_HELP),
    threshold: float = typer.Option(0.5, "--threshold", help="MDM value above which a joint is flagged (0-1)."),
    noise_deg: Optional[float] = noise_deg_option(),
    drifts: bool = typer.Option(
        False, "--drifts",
        help="Also flag and repair smooth drifts (no break) where the --context repeats the takes' motion "
             "(docs/guide/cleaning.md).",
    ),
    executor: Optional[str] = executor_option("takes are cleaned"),
    jobs: Optional[int] = typer.Option(
        None, "--jobs", metavar="N",
        help="Takes cleaned at once on local processes (default: one per core). --jobs 1 cleans them one by one "
             "in this process, leaving the other cores free.",
    ),
    report: bool = typer.Option(False, "--report", help="Also write STEM.report.html beside each output, and OUT_DIR/index.html: every take linked to its report, failed and most changed first."),
    png: bool = typer.Option(False, "--png", help="Also write STEM.summary.png beside each output."),
    pattern: str = typer.Option("*.bvh,*.amc,*.npz,*.c3d,*.trc", "--pattern", help="Comma-separated file name patterns to clean."),
    fmt: str = typer.Option("auto", "--format", help="Output format: auto (.bvh, .npz, .c3d and .trc kept, .amc -> .bvh), bvh, amc (ASF/AMC takes as AMC, each take's ASF copied beside it; BVH and .npz takes keep their format) or npz; marker captures keep their format."),
    as_json: bool = typer.Option(False, "--json", help="Print the per-take rows as JSON."),
    ebf: Optional[Path] = _model_option("ebf"),
    ebd: Optional[Path] = _model_option("ebd"),
    asf: Optional[Path] = asf_option("input(s)"),
    amc_fps: Optional[float] = amc_fps_option("input(s)"),
    unit: Optional[str] = unit_option("input(s)"),
    max_gap: Optional[float] = max_gap_option(batch=True),
    max_fill_error: Optional[float] = max_fill_error_option(batch=True),
    zeros_as_gaps: Optional[bool] = zeros_option(),
    overwrite: bool = typer.Option(
        False, "--overwrite",
        help="Replace existing outputs that are not complete takes of an earlier run (without it they are refused; "
             "complete takes are skipped either way). Missing parent folders are created.",
    ),
) -> None:
    """Clean every take under IN_DIR into OUT_DIR: resumable, one failing take reported and skipped.

    A take is complete when its output and STEM.clean.npz both exist (the record is written last),
    the output is as written and the input as cleaned (the record keeps their sizes and digests);
    complete takes are skipped, so running the command again resumes, and a take whose input was
    replaced since is cleaned again. Takes of one folder that would share a file (take.amc and take.bvh,
    take.bvh and take.c3d) are named after their input's format (take-amc.bvh, take-bvh.bvh, take-c3d.c3d),
    each said in a note line. Every output is checked against every input before any take is cleaned.
    Prints one line per take as it finishes (completion order; the complete ones first), each ending
    "[N/TOTAL]" when stdout is not a terminal, then the totals and where each take's record (and reports) are;
    exits 1 if any take failed. A full disk,
    a used-up quota or a read-only file system stops the batch: the takes under way finish, the rest are
    left for a rerun to resume.
    """
    from ..batch import clean_batch as run_batch
    check_executor(executor)
    jm = read_map(joint_map)
    step_list = _steps(steps)
    patterns = tuple(p.strip() for p in pattern.split(",") if p.strip())
    if not patterns:
        raise MocapError("--pattern: give at least one file name pattern, e.g. '*.bvh,*.amc'")
    models = _models(ebf, ebd)
    counted = not sys.stdout.isatty()  # no bar in a log: each line says how far the batch is, after its take
    done = "reviewed" if tuple(step_list) == ("detect",) else "cleaned"  # review mode changes nothing

    def print_context(line: str) -> None:  # a build of --context before the first take: a minute a log said nothing
        print(line, file=sys.stderr, flush=True)

    def print_start(todo: int, total: int, where: str) -> None:  # the first take's line may come minutes later
        print(start_line(in_dir, todo, total, where), file=sys.stderr, flush=True)

    def print_row(row: dict, n: int, total: int) -> None:
        console.print(_take_line(row, done) + (f" [{n}/{total}]" if counted else ""))
        for note in row.get("warnings", ()):  # as clean says them: a fallback, a model's licence
            console.print(f"warning: {row['input']}: {note}")
        for note in row.get("file_notes", ()):  # as clean says them: each names its file (OUT) already
            console.print(f"note: {note}")

    try:
        summary = run_batch(in_dir, out_dir, context=context, steps=step_list, threshold=threshold, patterns=patterns,
                            fmt=fmt, report=report, png=png, executor=executor, progress=not as_json,
                            overwrite=overwrite, asf=asf, drifts=drifts, models=models, amc_fps=amc_fps, unit=unit,
                            max_gap_s=max_gap, max_error_mm=max_fill_error, zeros_as_gaps=zeros_as_gaps,
                            noise_deg=noise_deg, on_row=None if as_json else print_row,
                            on_context=print_context if counted else None, on_start=print_start, joint_map=jm,
                            flags=True, jobs=jobs)
    except KeyboardInterrupt:  # "no partial output" alone reads as if nothing was kept
        if out_dir.is_dir() and any(out_dir.rglob("*.clean.npz")):
            console.print(f"note: the takes finished in {out_dir} are kept; the same command resumes the others")
        raise
    if as_json:
        print(json.dumps({"rows": summary.rows, "seconds": summary.seconds, "executor": summary.executor,
                          "earlier": summary.earlier, "renamed": summary.renamed, "stopped": summary.stopped,
                          "index": None if summary.index is None else str(summary.index)}))
    else:
        for folder in summary.earlier:
            console.print(f"left out {folder}: an earlier batch's outputs")
        for name in summary.renamed:
            console.print(f"note: {name}: its files are named after its format ({Path(name).suffix[1:].lower()}): "
                          "another take of its folder has the same stem")
        console.print(f"{plural(len(summary.rows) + summary.not_started, 'take')} on {summary.executor} in "
                      f"{summary.seconds:.1f} s: {summary.count('done')} {done}, {summary.count('skipped')} already "
                      f"complete, {summary.count('failed')} failed"
                      + (f", {summary.not_started} not started" if summary.stopped else ""))
        if summary.index is not None:
            console.print(f"wrote {summary.index}: every take with its report, the takes to look at first")
        where = files_line(out_dir, report=report, png=png, any_take=any(r["status"] != "failed" for r in summary.rows))
        if where:
            console.print(where)
        if not summary.rows and not summary.not_started:  # a mistyped folder or pattern said only "0 takes"
            print(f"warning: {in_dir}: no file matches --pattern {','.join(patterns)} (searched recursively"
                  + (", earlier batches' output folders left out" if summary.earlier else "") + "); nothing cleaned",
                  file=sys.stderr)
    if summary.stopped:  # a full disk: one error line, as any command says a filesystem error (exit 2)
        raise MocapError(summary.stopped)
    if summary.failed:
        raise typer.Exit(1)
