"""Self-similarity analysis (Aristidou et al. 2018): ``detect`` and ``repair``."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import MocapError, MocapFormatError
from ..words import frame_span
from .common import (amc_fps_option, asf_option, console, context_option, joint_map_option, listed, read_map, guard, overwrite_option, plural, save_take,
                     unit_option)


def _named(inp: Path, m, exc: MocapError) -> MocapError:
    """``exc``'s line naming the file ``inp`` rather than the take ``m``'s name (the file's stem), as the
    library names it."""
    msg, name = str(exc), f"{m.name or 'motion'}: "
    return MocapError(f"{inp}: {msg[len(name):] if msg.startswith(name) else msg}")


def _detect(inp: Path, m, context, threshold: float, progress: bool = True, drifts: bool = False, **overrides):
    """The take's detection as `clean --steps detect` makes it (calibration poses left out, clean's word gate;
    gaps and channels written as 0 where the capture lost data refused): ``(TakeDetection, Detection)``; a take
    with nothing to analyse is refused in one line naming ``inp``."""
    from ..cleaning.whole_take import detect_take, take_params

    try:
        params = take_params(drifts=drifts, **overrides)
    except ValueError as exc:
        raise MocapError(f"{inp}: {exc}") from None
    try:
        found = detect_take(m, context, threshold=threshold, params=params, progress=progress)
    except MocapError as exc:
        raise _named(inp, m, exc) from None
    if found.detection is None:
        raise MocapError(f"{inp}: {found.skipped}")
    return found, found.detection


def _take_notes(m, found, det) -> list[str]:
    """The lines `clean --steps detect` says of the take besides its flags: the calibration poses, a limb held
    still through the take, the stutters, then the detection's own notes (the root's path, cuts, words not
    judged)."""
    from ..cleaning.inbetweens import interpolated_note
    from ..cleaning.pipeline import capped_lines, held_still_note
    from ..cleaning.stutters import find_stutters, stutter_frames

    held = held_still_note(m)
    stutters = find_stutters(m)
    interpolated = interpolated_note(m, skip=stutter_frames(stutters, m.num_frames))
    return ([str(c) for c in found.calibration] + ([held] if held else [])
            + capped_lines(stutters, "stutters", "") + ([interpolated] if interpolated else []) + list(det.notes))


def detect(
    inp: Path = typer.Argument(..., metavar="IN", help="Motion to check (.bvh, .amc, .npz)."),
    out: Path = typer.Option(..., "--out", "-o", help="Detection file to write (.npz): MDM, flags, neighbours."),
    context: Optional[list[Path]] = context_option(),
    joint_map: Optional[Path] = joint_map_option(),
    threshold: float = typer.Option(0.5, "--threshold", help="MDM value above which a joint is flagged (0-1)."),
    confirm: bool = typer.Option(
        True, "--confirm/--no-confirm",
        help="Flag a digression only where the joint's own trajectory breaks (a step or spike); --no-confirm: MDM > threshold alone.",
    ),
    jump_deg: float = typer.Option(8.0, "--jump-deg", help="Confirmation: steps over 2x this, spikes over this (degrees)."),
    drifts: bool = typer.Option(
        False, "--drifts",
        help="Also flag smooth drifts (no break) where the --context repeats the take's motion (docs/guide/cleaning.md).",
    ),
    png: Optional[Path] = typer.Option(None, "--png", help="Also draw the movement digression map here."),
    as_json: bool = typer.Option(
        False, "--json", help="Print one JSON object: the flagged segments, the joints not analysed and why, the notes."),
    asf: Optional[Path] = asf_option("input(s)"),
    amc_fps: Optional[float] = amc_fps_option("input(s)"),
    unit: Optional[str] = unit_option("input(s)"),
    overwrite: bool = overwrite_option(),
) -> None:
    """Find erroneous joints by self-similarity (Aristidou et al. 2018): movement digression map + flags.

    The flags are those of `clean --steps detect` on the same take and options: calibration poses at the
    take's ends are left out (named in a note), and words with no neighbour within 8 degrees are not judged.
    The root's teleports and the turn-overs the repair step would name (a bone turned 180 degrees in one frame
    and back) are printed and flagged with them, none put back; OUT keeps self-similarity's flags alone (those
    repair replaces).
    """
    import json

    from ..batch import load_context
    from ..cleaning import precompile
    from ..cleaning.take_context import unread_context
    from ..cleaning.whole_take import review_whole, with_flips, with_teleports
    from ..context import context_label, fit_context
    from ..io.outputs import removed_on_failure
    from ..io.takes import CLI_AMC_NAMES, check_asf, load_motion

    guard([out, png], [inp, asf, context, joint_map], overwrite)
    jm = read_map(joint_map)
    check_asf(asf, [inp], amc_fps, names=CLI_AMC_NAMES)
    if out.suffix.lower() != ".npz":
        raise MocapFormatError(out, "the detection is written as .npz")
    if png is not None and png.suffix.lower() != ".png":
        raise MocapFormatError(png, "the map is written as .png")
    m = load_motion(inp, asf, purpose="detect", fps=amc_fps, unit=unit, unit_option="--unit",
                    instead="`mocapkit clean --steps detect` reviews a marker file (gaps, spikes, label swaps)")
    precompile.start(precompile.kernels_for(["detect"]))  # with an empty numba cache: beside the context's loading
    unread = unread_context(m, context)  # a take too coarse for detection: refused below in one line, no context built
    ctx, note = (None, unread) if unread is not None else fit_context(m, load_context(context, progress=not as_json,
                                                                                      take=m, joint_map=jm))
    found, det = _detect(inp, m, ctx, threshold, progress=not as_json, confirm=confirm, jump_deg=jump_deg,
                         drifts=drifts)
    # the teleports and turn-overs the repair step would name, flagged and said as clean --steps detect says them
    # (none put back); the detection file keeps self-similarity's flags alone, those that repair --detection replaces
    seen = review_whole(m, det, ctx, poses=found.calibration)
    flags, causes = with_flips(*with_teleports(det.flags, det.causes(), seen.teleported), seen.turn_overs.flagged)
    with removed_on_failure([out, png], overwrite=overwrite, marker=out):  # the detection last
        if png is not None:
            from ..report.plots import plot_mdm, shown_mdm

            shown, grey = shown_mdm(det.mdm, det.analysed, det)  # grey, not an MDM of 0, where nothing was judged
            plot_mdm(shown, det.joint_names, det.fps, png, flags=flags, title=f"{inp.name}: movement digression map",
                     grey=grey)
        det.save(out)
    from ..cleaning.ssa.cues import cause_names
    from ..cleaning.ssa.detect import flag_runs

    segs = flag_runs(flags, det.joint_names)
    why = [cause_names(causes[a:b, det.joint_names.index(j)]) for j, a, b in segs]
    if as_json:  # end: the frame after the segment (Python's slice); last: its last frame, as the lines print it
        # not_analysed: joint -> why; nothing flags those joints because nothing checked them
        print(json.dumps({
            "segments": [{"joint": j, "start": a, "end": b, "last": b - 1, "start_s": a / m.fps, "end_s": b / m.fps,
                          "causes": w} for (j, a, b), w in zip(segs, why)],
            "not_analysed": det.not_analysed(),
            "notes": ([note] if note else []) + _take_notes(m, found, det) + list(seen.lines),
        }))
        return
    console.print(f"wrote {listed(p for p in (out, png) if p)}: {plural(len(segs), 'flagged segment')}"
                  f" (judged against {context_label(ctx)})")
    for line in ([note] if note else []) + _take_notes(m, found, det) + list(seen.lines):
        console.print(f"  note: {line}")
    for (j, a, b), w in zip(segs[:50], why):
        # the first and last frame's times (frame f is at f / fps, as the report's viewer labels it)
        console.print(f"  {j:16s} {frame_span(a, b - 1, m.fps)}: {', '.join(w)}")
    if len(segs) > 50:
        console.print(f"  ... and {len(segs) - 50} more")


def repair(
    inp: Path = typer.Argument(..., metavar="IN", help="Motion to repair (.bvh, .amc, .npz)."),
    out: Path = typer.Option(..., "--out", "-o", help="Repaired motion (.bvh, .amc for a take read from ASF/AMC, or .npz)."),
    context: Optional[list[Path]] = context_option(),
    joint_map: Optional[Path] = joint_map_option(),
    detection: Optional[Path] = typer.Option(
        None, "--detection", help="Use this detection (from `mocapkit detect`, same --context) instead of detecting again."
    ),
    threshold: float = typer.Option(0.5, "--threshold", help="MDM value above which a joint is replaced (0-1)."),
    confirm: bool = typer.Option(
        True, "--confirm/--no-confirm", help="As for detect; ignored with --detection (the file's own rule is kept)."
    ),
    jump_deg: float = typer.Option(8.0, "--jump-deg", help="As for detect (degrees)."),
    drifts: bool = typer.Option(
        False, "--drifts", help="As for detect: also replace smooth drifts; ignored with --detection."
    ),
    foot_skate: bool = typer.Option(
        False, "--foot-skate/--no-foot-skate",
        help="Also pin planted feet on repaired frames: this moves the hip and knee of a leg whose foot is planted, "
             "joints that were not flagged (off by default, as in clean).",
    ),
    asf: Optional[Path] = asf_option("input(s)"),
    amc_fps: Optional[float] = amc_fps_option("input(s)"),
    unit: Optional[str] = unit_option("input(s)"),
    overwrite: bool = overwrite_option(),
) -> None:
    """Replace only the flagged joints in flagged frames by the medoid (the median word) of their nearest motion words.

    The flags are those of `clean --steps detect` (or --detection's), and OUT is what
    `clean --steps detect,repair` writes: calibration poses at the take's ends are left alone, the root's
    teleports (a jump away and back within 0.5 s) are put back, every other unflagged sample stays
    bit-identical (unless --foot-skate). A take with gaps, or channels written as 0 where the capture lost
    data, is refused: fill it first. Prints the joint samples and frames that changed.
    """
    from .. import io
    from ..batch import load_context
    from ..cleaning import ssa
    from ..cleaning.take_context import unread_context
    from ..cleaning.whole_take import check_no_zeros, repair_whole, with_flips, with_teleports
    from ..context import fit_context
    from ..io.euler_branches import bvh_written, written_layout
    from ..io.takes import CLI_AMC_NAMES, check_asf, load_motion

    import numpy as np

    guard([out], [inp, asf, context, detection, joint_map], overwrite)
    jm = read_map(joint_map)
    check_asf(asf, [inp], amc_fps, names=CLI_AMC_NAMES)
    # IN first: a marker capture is IN's problem, whatever OUT's suffix (a .c3d OUT would be the wrong complaint)
    m = load_motion(inp, asf, purpose="repair", fps=amc_fps, unit=unit, unit_option="--unit",
                    instead="`mocapkit clean` cleans a marker file (fills gaps, removes spikes, undoes swaps)")
    io.suffix_kind(out, io.WRITERS, "writing")
    io.check_writable(m, out)
    det = None
    if detection is not None:
        det = ssa.Detection.load(detection).with_threshold(threshold)
        if det.flags.shape != (m.num_frames, m.skeleton.num_joints):
            raise MocapFormatError(detection, f"the detection is of {plural(det.flags.shape[0], 'frame')} x {plural(det.flags.shape[1], 'joint')}, "
                                              f"the take {plural(m.num_frames, 'frame')} x {plural(m.skeleton.num_joints, 'joint')}; detect this take again")
    unread = unread_context(m, context)  # a take too coarse for detection: refused below in one line, no context built
    ctx, note = (None, "") if unread is not None else fit_context(m, load_context(context, progress=True, take=m,
                                                                                           joint_map=jm))
    if note:
        console.print(f"note: {note}")
    poses = None
    if det is None:
        found, det = _detect(inp, m, ctx, threshold, confirm=confirm, jump_deg=jump_deg, drifts=drifts)
        poses = found.calibration
        for line in _take_notes(m, found, det):  # as detect says them
            console.print(f"note: {line}")
    else:  # as detect refuses them: a detection of the take with its lost samples written as 0 is no reason to repair
        try:
            check_no_zeros(m, span=det.span)
        except MocapError as exc:
            raise _named(inp, m, exc) from None
    # the path clean's repair step takes: the flagged cells, then the root's teleports put back
    done = repair_whole(m, det, ctx, foot_skate=foot_skate, poses=poses)
    layout = written_layout(m, out, asf, inp)  # read once (an AMC's: its ASF) for the write and the count
    written = bvh_written(m, done.motion, out, asf, inp, layout)  # a hinge, a bone of fewer dofs: what is written is counted
    save_take(written, out, inp, asf, overwrite, like=inp)
    changed = np.array(done.changed)
    if written is not done.motion:  # a hinge's cell whose change was only about another axis: the file's again
        hinge = layout[0]
        changed[:, hinge] &= ~np.all(np.asarray(written.rotations)[:, hinge] == np.asarray(m.rotations)[:, hinge],
                                     axis=-1)
    flags, _ = with_flips(*with_teleports(det.flags, None, done.teleported), done.turn_flags)
    extra = int((done.repaired & ~det.flags).sum())
    said = f"{int(flags.sum())} flagged" + (f"; {extra} more moved by the foot-skate cleanup" if extra else "")
    console.print(f"wrote {out}: {plural(int(changed.sum()), 'joint sample')} changed in {int(changed.any(axis=1).sum())} "
                  f"of {plural(m.num_frames, 'frame')} ({said})")
    for line in done.put_back + done.left + done.flips + ((done.measured,) if done.measured else ()):  # as clean says them
        console.print(f"  {line}")
