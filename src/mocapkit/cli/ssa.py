"""Self-similarity analysis (Aristidou et al. 2018): ``detect`` and ``repair``."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import MocapError, MocapFormatError, SkeletonError
from .common import asf_option, console, context_option, guard, overwrite_option, plural, save_take


def _detect(m, context, threshold: float, progress: bool = True, confirm: bool = True, jump_deg: float = 8.0,
            drifts: bool = False):
    from ..cleaning import ssa
    from ..cleaning.pipeline import MAX_WORD_ANGLE_DEG

    try:  # clean's word gate: a word with no neighbour that close is not judged (the flags of `clean --steps detect`)
        return ssa.detect(m, context, threshold=threshold, progress=progress, confirm=confirm, jump_deg=jump_deg,
                          drift=drifts, max_word_angle_deg=MAX_WORD_ANGLE_DEG)
    except (ValueError, SkeletonError) as exc:
        raise MocapError(f"{m.name or 'input'}: {exc}") from None


def detect(
    inp: Path = typer.Argument(..., metavar="IN", help="Motion to check (.bvh, .amc, .npz)."),
    out: Path = typer.Option(..., "--out", "-o", help="Detection file to write (.npz): MDM, flags, neighbours."),
    context: Optional[list[Path]] = context_option(),
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
    as_json: bool = typer.Option(False, "--json", help="Print the flagged segments as JSON."),
    asf: Optional[Path] = asf_option(),
    overwrite: bool = overwrite_option(),
) -> None:
    """Find erroneous joints by self-similarity (Aristidou et al. 2018): movement digression map + flags."""
    import json

    from ..batch import load_context
    from ..cleaning import precompile
    from ..context import context_label, fit_context
    from ..io.outputs import removed_on_failure
    from ..io.takes import check_asf, load_motion

    guard([out, png], [inp, asf, context], overwrite)
    check_asf(asf, [inp])
    if out.suffix.lower() != ".npz":
        raise MocapFormatError(out, "the detection is written as .npz")
    if png is not None and png.suffix.lower() != ".png":
        raise MocapFormatError(png, "the map is written as .png")
    m = load_motion(inp, asf, purpose="detect")
    precompile.start(precompile.kernels_for(["detect"]))  # with an empty numba cache: beside the context's loading
    ctx, note = fit_context(m, load_context(context, progress=not as_json, take=m))
    det = _detect(m, ctx, threshold, progress=not as_json, confirm=confirm, jump_deg=jump_deg, drifts=drifts)
    with removed_on_failure([out, png], overwrite=overwrite, marker=out):  # the detection last
        if png is not None:
            from ..report.plots import plot_mdm

            plot_mdm(det.mdm, det.joint_names, det.fps, png, flags=det.flags, title=f"{inp.name}: movement digression map")
        det.save(out)
    from ..cleaning.ssa.cues import cause_names

    segs = det.segments()
    causes = det.causes()
    why = [cause_names(causes[a:b, det.joint_names.index(j)]) for j, a, b in segs]
    if as_json:  # end: the frame after the segment (Python's slice); last: its last frame, as the lines print it
        print(json.dumps([{"joint": j, "start": a, "end": b, "last": b - 1, "start_s": a / m.fps, "end_s": b / m.fps,
                           "causes": w} for (j, a, b), w in zip(segs, why)]))
        return
    console.print(f"wrote {out}" + (f" and {png}" if png else "") + f": {plural(len(segs), 'flagged segment')}"
                  f" (judged against {context_label(ctx)})")
    for line in ([note] if note else []) + list(det.notes):
        console.print(f"  note: {line}")
    for (j, a, b), w in zip(segs[:50], why):
        console.print(f"  {j:16s} frames {a}-{b - 1} ({a / m.fps:.2f}-{b / m.fps:.2f} s): {', '.join(w)}")
    if len(segs) > 50:
        console.print(f"  ... and {len(segs) - 50} more")


def repair(
    inp: Path = typer.Argument(..., metavar="IN", help="Motion to repair (.bvh, .amc, .npz)."),
    out: Path = typer.Option(..., "--out", "-o", help="Repaired motion (.bvh, .amc for a take read from ASF/AMC, or .npz)."),
    context: Optional[list[Path]] = context_option(),
    detection: Optional[Path] = typer.Option(
        None, "--detection", help="Use this detection (from `mocapkit detect`, same --context) instead of detecting again."
    ),
    threshold: float = typer.Option(0.5, "--threshold", help="MDM value above which a joint is replaced (0-1)."),
    confirm: bool = typer.Option(
        True, "--confirm/--no-confirm", help="As for detect; ignored with --detection (the file's own rule is kept)."
    ),
    jump_deg: float = typer.Option(8.0, "--jump-deg", help="As for detect (degrees)."),
    foot_skate: bool = typer.Option(True, "--foot-skate/--no-foot-skate", help="Pin planted feet on repaired frames."),
    asf: Optional[Path] = asf_option(),
    overwrite: bool = overwrite_option(),
) -> None:
    """Replace only the flagged joints in flagged frames by the median of their nearest motion words."""
    from .. import io
    from ..batch import load_context
    from ..cleaning import ssa
    from ..context import fit_context
    from ..io.takes import check_asf, load_motion

    guard([out], [inp, asf, context, detection], overwrite)
    check_asf(asf, [inp])
    io.suffix_kind(out, io.WRITERS, "writing")
    m = load_motion(inp, asf, purpose="repair")
    io.check_writable(m, out)
    det = None
    if detection is not None:
        det = ssa.Detection.load(detection).with_threshold(threshold)
        if det.flags.shape != (m.num_frames, m.skeleton.num_joints):
            raise MocapFormatError(detection, f"the detection is of {det.flags.shape[0]} frames x {det.flags.shape[1]} joints, "
                                              f"the take {m.num_frames} x {m.skeleton.num_joints}; detect this take again")
    ctx, note = fit_context(m, load_context(context, progress=True, take=m))
    if note:
        console.print(f"note: {note}")
    if det is None:
        det = _detect(m, ctx, threshold, confirm=confirm, jump_deg=jump_deg)
    try:
        fixed = ssa.repair(m, det, ctx, foot_skate=foot_skate)
    except ValueError as exc:
        raise MocapError(f"{inp}: {exc}") from None
    save_take(fixed, out, inp, asf, overwrite, like=inp)
    n = int(det.flags.sum())
    console.print(f"wrote {out}: {plural(n, 'joint sample')} replaced in {int(det.flags.any(axis=1).sum())} of "
                  f"{plural(m.num_frames, 'frame')}")
