"""Commands on one take: ``info``, ``convert``, ``corrupt``, ``plot``."""

from __future__ import annotations


import math
from pathlib import Path
from typing import Optional

import typer

from ..errors import MissingFileError, MocapError, MocapFormatError
from .common import (amc_fps_option, asf_option, console, database_rows, guard, keep_modelled_option, overwrite_option,
                     plural, print_fields, print_table, save_take, unit_option, zeros_option)


def info(
    file: Path = typer.Argument(..., metavar="FILE", help="A .bvh, .amc, .c3d, .trc or .npz file; or what mocapkit writes: a database "
                                          "folder, a .clean.npz record, a detection, a .mask.npz, a .pt model or "
                                          "checkpoint, a knowledge base, a decisions file, a batch mark."),
    joints: bool = typer.Option(False, "--joints", help="Also list every joint with its parent and channels."),
    asf: Optional[Path] = asf_option("input"),
    amc_fps: Optional[float] = amc_fps_option("input"),
    unit: Optional[str] = unit_option("input"),
) -> None:
    """Print the skeleton, frame count, frame rate, duration and missing data of FILE (or what a mocapkit file holds)."""
    from ..digest import take_digest
    from ..io.bvh_roots import extra_roots
    from ..io.c3d import MarkerSet
    from ..io.c3d_contents import marker_counts, marker_file_contents, never_seen_line, zero_gaps_line
    from ..io.takes import CLI_AMC_NAMES, check_asf, load_take
    from ..motion import ROLES, standard_joints, unit_scale_cm
    from ..joints import DAG_PATH
    from ..rigs import family_prefix, rig_family, roles_by_topology
    from ..side_labels import exchanged_sides

    check_asf(asf, [file], amc_fps, names=CLI_AMC_NAMES)
    if not file.exists():  # before the suffix: a missing model or knowledge base is missing, not of unknown kind
        raise MissingFileError(file)
    if _info_of_own_file(file):  # a database, a cleaning record, a detection, a mask or a model: not a take
        return
    obj = load_take(file, asf, fps=amc_fps, unit=unit, unit_option="--unit")
    rows = [("file", str(file))]
    if isinstance(obj, MarkerSet):
        markers, modelled, missing = marker_counts(obj)
        rows += [("kind", f"markers (read with {obj.reader})"),
                 ("markers", str(markers) + (f" (+{plural(modelled, 'modelled quantity', 'modelled quantities')}: angles, forces, moments, "
                                             "powers; not markers)" if modelled else "")),
                 ("frames", str(obj.num_frames)), ("fps", f"{obj.fps:g}"),
                 ("duration", f"{obj.num_frames / obj.fps:.3f} s"), ("units", obj.units + _UNITS_FROM[obj.units_from]),
                 ("missing", f"{100.0 * missing:.2f} % of marker samples"
                             + (f" ({zero_gaps_line(obj.zero_gaps)})" if obj.zero_gaps else "")
                             + (f" ({never})" if (never := never_seen_line(obj)) else ""))]
        rows += marker_file_contents(obj)
        rows.append(("sha256", f"{take_digest(obj)} (of the samples: a decisions file's \"take\" digest)"))
        print_fields(rows)
        for note in obj.notes:  # what the reader did (labels repeated, trajectories the header does not count), as clean says
            console.print(f"note: {file}: {note}")
        if joints:
            console.print(", ".join(obj.labels))
        return
    m, sk = obj, obj.skeleton
    miss = m.missing()
    rows += [("kind", "motion"), ("name", m.name),
             ("joints", f"{plural(sk.num_joints, 'joint')} (+{plural(sk.num_end_sites, 'end site')}), root {sk.joint_names[0]!r}"),
             ("frames", str(m.num_frames)), ("fps", f"{m.fps:g}" + _amc_rate_note(file, amc_fps)),
             ("duration", f"{m.duration:.3f} s")]
    extras = extra_roots(file)
    if extras:  # a prop or a camera beside the character: kept in a BVH written like this file, not analysed
        rows.append(("other roots", ", ".join(e.describe() for e in extras)
                     + f"; the take is the hierarchy under {sk.joint_names[0]!r} (of the roots with a hips-like joint, "
                       "the one with most joints); the others are carried through to a .bvh output, not analysed"))
    roles = standard_joints(sk)
    missing_roles = [r for r in ROLES if r not in roles]
    try:
        scale = unit_scale_cm(sk)
        how = " (given with --unit)" if unit is not None else " (stated by the file)"
        rows.append(("length unit", f"{scale:.4g} cm" + (how if sk.unit_cm else " (from bone lengths, assuming an adult; "
                                                                              "--unit mm|cm|m|in sets it)")))
    except (MocapError, KeyError) as exc:  # KeyError: a rig without the human joints the estimate measures
        reason = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        rows.append(("length unit", f"unknown ({reason})"))
    rows.append(("human roles", f"{len(roles)} of {len(ROLES)} found"
                 + (f"; missing: {', '.join(missing_roles)}" if missing_roles else "")))
    family = rig_family(sk)
    if family is None:
        family = ("none known; roles read from its tree and rest pose" + _served_note(m)
                  if roles_by_topology(sk) else "none known (no joint map: the networks fall back)")
    elif (prefix := family_prefix(sk)).startswith(DAG_PATH):  # Maya DAG paths (|Root|Hips): matched by their last part
        family += (" (its names read as the last part of their DAG paths"
                   + (f", without the prefix {prefix[len(DAG_PATH):]!r} they share" if prefix != DAG_PATH else "")
                   + "; the file's names are kept)")
    elif prefix:  # a namespace before every name (Character1_Hips): matched without it
        family += f" (its names read without the prefix {prefix!r} they share; the file's names are kept)"
    rows.append(("rig family", family))
    sides = exchanged_sides(m)  # a rig mapped left for right, read from the body, not the names
    if sides is not None:
        rows.append(("sides", str(sides)))
    rows += [("channels", str(len(m.channel_names()))),
             ("missing", f"{100.0 * miss.mean():.2f} % of joint samples, {plural(int(miss.any(axis=1).sum()), 'frame')} affected"),
             ("sha256", f"{take_digest(m)} (of the samples: a decisions file's \"take\" digest)")]
    from ..reconstruct.output import kept_licence

    licence = kept_licence(file)  # a reconstruction's: the terms of the database's takes its poses come from
    if licence:
        rows.append(("licence", licence))
    rows += _cut_rows(m)
    print_fields(rows)
    if joints:
        print_table(("#", "joint", "parent", "channels"),
                    ((j, name, "-" if sk.parents[j] < 0 else sk.joint_names[sk.parents[j]], " ".join(sk.joint_channels(j)))
                     for j, name in enumerate(sk.joint_names)))


def _cut_rows(m) -> list[tuple[str, str]]:
    """One ``cut`` row per cut of the take (:func:`mocapkit.cleaning.whole_take.take_cuts`: two takes joined, or
    frames dropped), at most :data:`~mocapkit.cleaning.clean_record.MAX_LINES` then a count; none for a take without."""
    from ..cleaning.clean_record import capped_lines
    from ..cleaning.whole_take import take_cuts

    found = take_cuts(m)
    lines = capped_lines([f"frame {c.frame}: {c.meaning}" for c in found], "cuts", " (`mocapkit detect` lists them all)")
    return [("cut", line) for line in lines]


_UNITS_FROM = {"file": "", "given": " (given with --unit; the file states none)",
               "data": " (the file states none: inferred from the marker distances; --unit sets it)"}


def _amc_rate_note(path: Path, given: float | None) -> str:
    """Where an AMC's frame rate comes from, for ``info`` (an AMC has no field for it); "" for other files."""
    if path.suffix.lower() != ".amc":
        return ""
    from ..io.asfamc import amc_rate

    return {"given": " (given with --amc-fps)", "file": " (stated in the file's mocapkit comment line)",
            "name": " (from the HDM05 file name)",
            "default": " (the file states none: 120, the CMU and HDM05 rate; --amc-fps sets it)"}[amc_rate(path, given)[1]]


def convert(
    inp: Path = typer.Argument(..., metavar="IN", help="Input take (.bvh, .amc, .npz) or marker file (.c3d, .trc, marker .npz)."),
    out: Path = typer.Argument(..., metavar="OUT", help="Output, chosen by suffix: .bvh, .amc (a take read from ASF/AMC) or .npz for a motion; .c3d, .trc or .npz for markers."),
    fps: Optional[float] = typer.Option(None, "--fps", help="Resample a motion to this frame rate (slerp)."),
    zeros_as_gaps: Optional[bool] = zeros_option(),
    asf: Optional[Path] = asf_option("input(s)"),
    amc_fps: Optional[float] = amc_fps_option("input(s)"),
    unit: Optional[str] = unit_option("input(s)"),
    keep_modelled: bool = keep_modelled_option(),
    overwrite: bool = overwrite_option(),
) -> None:
    """Convert IN to OUT: a motion between BVH, AMC and npz (optionally resampled to --fps), markers between C3D, TRC and npz."""
    from .. import io
    from ..io.takes import CLI_AMC_NAMES, check_asf, check_unit, load_take
    from ..motion import Motion, check_fps

    if fps is not None:
        check_fps(fps, "--fps")  # before any work, naming the option
    guard([out], [inp, asf], overwrite)
    check_asf(asf, [inp], amc_fps, names=CLI_AMC_NAMES)
    check_unit(unit, "--unit")
    marker_input = inp.suffix.lower() in (".c3d", ".trc")
    if marker_input:
        io.suffix_kind(out, io.MARKER_FORMATS, "writing markers")
    else:
        io.suffix_kind(out, {**io.WRITERS, **io.MARKER_FORMATS} if inp.suffix.lower() == ".npz" else io.WRITERS, "writing")
    if marker_input:
        m = io.load_markers(inp, zeros_as_gaps=zeros_as_gaps, **({} if unit is None else {"units": unit}))
    else:
        m = load_take(inp, asf, fps=amc_fps, unit=unit, unit_option="--unit")
    if not isinstance(m, Motion):
        if fps is not None:
            raise MocapFormatError(inp, "--fps resamples joint angles; a marker file converts at its own rate")
        io.suffix_kind(out, io.MARKER_FORMATS, "writing markers")
        if keep_modelled:
            io.check_keep_modelled(inp, out)
        io.save_markers(m, out, keep_modelled=keep_modelled, overwrite=overwrite)
        from ..io.c3d_contents import marker_counts, zero_gaps_line

        markers, modelled, missing = marker_counts(m)
        quantities = plural(modelled, "modelled quantity", "modelled quantities")
        kept = "" if not modelled else (f", {quantities} kept" if keep_modelled or out.suffix.lower() != ".trc"
                                        else f", {quantities} left out")
        console.print(f"wrote {out} ({plural(markers, 'marker')}, {plural(m.num_frames, 'frame')} @ {m.fps:g} fps, "
                      f"{100.0 * missing:.2f} % of marker samples missing{kept})")
        if m.zero_gaps:
            console.print(f"{zero_gaps_line(m.zero_gaps)} (--keep-zeros keeps them as positions)")
        # what the reader did, what OUT's format cannot hold or tell apart
        for note in io.marker_notes(m, out, inp, keep_modelled=keep_modelled):
            console.print(f"note: {note}")
        return
    if zeros_as_gaps is not None:
        raise MocapError("--zeros-as-gaps/--keep-zeros apply to marker files; IN is a motion")
    if keep_modelled:
        raise MocapError("--keep-modelled applies to marker files; IN is a motion")
    io.check_writable(m, out)
    r = m.resample(fps) if fps is not None else m
    resampled, m = r is not m, r
    # a BVH to BVH or AMC to AMC conversion at the take's own rate keeps the input's text (io.save's like);
    # an AMC output gets the input's ASF beside it
    save_take(m, out, inp, asf, overwrite, like=False if resampled else inp)
    console.print(f"wrote {out} ({plural(m.num_frames, 'frame')} @ {m.fps:g} fps)")


def corrupt(
    inp: Path = typer.Argument(..., metavar="IN", help="Clean input take (.bvh, .amc, .npz) or marker file (.c3d, .trc, marker .npz: --kind gaps)."),
    out: Path = typer.Argument(..., metavar="OUT", help="Corrupted output (.bvh, .amc or .npz; gaps need .npz); markers: .c3d, .trc or .npz."),
    kind: str = typer.Option(..., "--kind", help="noise | uniform | bias | spatial | gaps | errors, or one error kind: spike | flip | freeze | drift | swap; a marker file takes gaps"),
    amount: Optional[float] = typer.Option(
        None, "--amount", help="noise, uniform, bias: std as a fraction of each channel's std (0.1/0.5/0.9; a "
                               "channel that crosses +-180 deg: the std of its motion, read on the circle); "
                               "spatial: std in cm. A finite number > 0 (0 would change nothing); gaps and the "
                               "error kinds take none. Default: 0.5 (noise, uniform, bias), 0.5 cm (spatial)."
    ),
    seed: int = typer.Option(0, "--seed", help="Random seed: the same seed gives the same corruption."),
    mask_out: Optional[Path] = typer.Option(
        None, "--mask", help="Ground-truth mask file (default: OUT with suffix .mask.npz)."
    ),
    asf: Optional[Path] = asf_option("input(s)"),
    amc_fps: Optional[float] = amc_fps_option("input(s)"),
    unit: Optional[str] = unit_option("input(s)"),
    keep_modelled: bool = keep_modelled_option(),
    overwrite: bool = overwrite_option(),
) -> None:
    """Corrupt IN with known ground truth; writes OUT and a .mask.npz of what changed."""
    from .. import corrupt as corrupt_mod
    from .. import io
    from ..io.masks import mask_path_for, write_mask
    from ..io.outputs import removed_on_failure
    from ..io.takes import CLI_AMC_NAMES, check_asf, load_take
    from ..markerset import MarkerSet

    if amount is not None and not (math.isfinite(amount) and amount > 0):  # one rule for every kind, before any work
        raise MocapError(f"--amount must be a finite number greater than 0, got {amount:g}")
    # before the output guard: a marker file (by suffix; a marker npz once read) takes gaps alone, written as markers
    if inp.suffix.lower() in (".c3d", ".trc"):
        _check_marker_kind(inp, kind)
        io.suffix_kind(out, io.MARKER_FORMATS, "writing markers")
    elif inp.suffix.lower() != ".npz" and out.suffix.lower() in (".c3d", ".trc"):
        raise MocapFormatError(out, _SKELETON_OUT)
    mask_path = mask_out or mask_path_for(out)
    guard([out, mask_path], [inp, asf], overwrite)
    check_asf(asf, [inp], amc_fps, names=CLI_AMC_NAMES)
    m = load_take(inp, asf, fps=amc_fps, unit=unit, unit_option="--unit")
    if isinstance(m, MarkerSet):
        _check_marker_kind(inp, kind)
        io.suffix_kind(out, io.MARKER_FORMATS, "writing markers")
        if keep_modelled:
            io.check_keep_modelled(inp, out)
        return _corrupt_markers(m, inp, out, mask_path, kind, seed, amount, keep_modelled, overwrite)
    if keep_modelled:
        raise MocapError("--keep-modelled applies to marker files; IN is a motion")
    if out.suffix.lower() in (".c3d", ".trc"):
        raise MocapFormatError(out, _SKELETON_OUT)
    io.suffix_kind(out, io.WRITERS, "writing")
    io.check_writable(m, out)
    params = {} if amount is None else {"amount": amount}
    try:
        result = corrupt_mod.corrupt(m, kind=kind, seed=seed, **params)
    except (TypeError, ValueError) as exc:
        raise MocapError(f"corrupt --kind {kind}: {exc}") from None
    bad, mask = result[0], result[1]
    records = result[2] if len(result) > 2 else []
    io.check_complete(bad, out, "this corruption leaves missing values (NaN)", "write .npz")
    with removed_on_failure([out, mask_path], overwrite=overwrite, marker=mask_path):  # the ground truth last
        save_take(bad, out, inp, asf, overwrite, like=inp)  # the input's text kept where no cell changed
        write_mask(mask_path, mask, m.skeleton.joint_names, kind=kind, seed=seed, params=params, records=records)
    frames = int(mask.any(axis=1).sum())
    console.print(f"wrote {out} and {mask_path}: {plural(int(mask.sum()), 'joint sample')} changed in "
                  f"{frames} of {plural(m.num_frames, 'frame')}")
    for line in corrupt_mod.describe_errors(records, m, bad):  # a swap's two records (one per joint): one line
        console.print(f"  {line}")
    if any((r["kind"] if isinstance(r, dict) else r.kind) == "drift" for r in records):
        console.print("  note: a drift here steps off its path by 15 deg and ramps to 25-40 deg over 0.1-0.6 s "
                      "(Aristidou's drift error): detect finds it by its step, as a break; `--drifts` flags smooth "
                      "drifts, which have no step and last at least 0.15 s (docs/guide/cleaning.md, Smooth drifts)")


#: corrupt's refusal of a skeleton take written to a marker format (said before the output guard when IN's suffix
#: tells, after reading where IN is an .npz)
_SKELETON_OUT = "a skeleton take is written as .bvh, .amc or .npz; .c3d and .trc hold markers"


def _check_marker_kind(inp: Path, kind: str) -> None:
    """Refuse, in one line naming the marker file ``inp``, a ``--kind`` other than gaps: the other kinds turn joint
    rotations, which a marker capture has none of (:func:`mocapkit.corrupt.gaps` takes a MarkerSet)."""
    from .. import corrupt as corrupt_mod

    if kind != "gaps":
        known = kind in corrupt_mod.KINDS + corrupt_mod.ERROR_KINDS
        raise MocapFormatError(inp, f"--kind {kind} " + ("changes joint rotations, which a marker capture has none of"
                                                         if known else "is no corruption kind")
                               + "; the kind that works on marker files (.c3d, .trc, marker .npz): gaps")


def _corrupt_markers(m, inp: Path, out: Path, mask_path: Path, kind: str, seed: int, amount, keep_modelled: bool,
                     overwrite: bool) -> None:
    """``corrupt --kind gaps`` of a marker capture (:func:`mocapkit.corrupt.gaps`: per-marker runs, positions NaN,
    every marker but the modelled points and unlabelled trajectories): writes OUT (.c3d, .trc or .npz) and the
    ground truth, an (F, M) mask over OUT's points with their ``labels`` (:func:`mocapkit.io.masks.write_mask`; a
    .trc leaves a C3D's modelled quantities out unless ``keep_modelled``, and its mask with them)."""
    import numpy as np

    from .. import corrupt as corrupt_mod
    from .. import io
    from ..io.masks import write_mask
    from ..io.outputs import removed_on_failure

    params = {} if amount is None else {"amount": amount}
    try:
        bad, mask = corrupt_mod.corrupt(m, kind=kind, seed=seed, **params)
    except (TypeError, ValueError) as exc:
        raise MocapError(f"corrupt --kind {kind}: {exc}") from None
    kept = np.ones(m.num_markers, dtype=bool)
    if out.suffix.lower() == ".trc" and not keep_modelled:
        kept = m.quantities() == ""  # the points write_trc keeps
    with removed_on_failure([out, mask_path], overwrite=overwrite, marker=mask_path):  # the ground truth last
        # a gap the file stored as exact (0, 0, 0) that the corruption did not touch is written as stored
        io.save_markers(bad, out, keep_modelled=keep_modelled, overwrite=overwrite, stored_zeros=True)
        write_mask(mask_path, mask[:, kept], [lb for lb, k in zip(bad.labels, kept) if k], kind=kind, seed=seed,
                   params=params, markers=True)
    frames = int(mask.any(axis=1).sum())
    console.print(f"wrote {out} and {mask_path}: {plural(int(mask.sum()), 'marker sample')} made missing in "
                  f"{frames} of {plural(m.num_frames, 'frame')}")
    for note in io.marker_notes(bad, out, inp, keep_modelled=keep_modelled):
        console.print(f"note: {note}")


def plot(
    reference: Path = typer.Argument(..., metavar="REFERENCE", help="Reference take (e.g. the clean clip)."),
    others: list[Path] = typer.Argument(..., metavar="OTHER...", help="Takes to compare (e.g. noisy, then cleaned)."),
    joint: str = typer.Option(..., "--joint", help="Joint whose rotation channels are plotted."),
    out: Path = typer.Option(..., "-o", "--out", help="PNG to write."),
    mask: Optional[Path] = typer.Option(None, "--mask", help="A .mask.npz from `mocapkit corrupt` to shade (default: the first OTHER's, if present)."),
    asf: Optional[Path] = asf_option(),
    amc_fps: Optional[float] = amc_fps_option(),
    overwrite: bool = overwrite_option(),
) -> None:
    """Plot the rotation channels of one joint of two or more takes over time, as a PNG."""
    from ..io.masks import mask_path_for, read_mask
    from ..io.takes import CLI_AMC_NAMES, check_asf, load_motion
    from ..report import plot_channels

    implicit = mask_path_for(others[0])
    mask_path = mask if mask is not None else (implicit if implicit.is_file() else None)
    guard([out], [reference, *others, asf, mask_path], overwrite)
    check_asf(asf, [reference, *others], amc_fps, names=CLI_AMC_NAMES)
    if out.suffix.lower() != ".png":
        raise MocapFormatError(out, "the plot is written as .png")
    motions = [load_motion(p, asf, purpose="plot", fps=amc_fps) for p in (reference, *others)]
    motions, redrawn = _in_reference_channels(motions)
    _check_plot_joint(joint, [reference, *others], motions)
    mask_arr = None
    if mask_path is not None:
        try:
            mask_arr = read_mask(mask_path, frames=motions[1].num_frames)
        except MocapFormatError:
            if mask is not None:  # asked for: its problem is an error; a mask merely found beside OTHER is skipped
                raise
    plot_channels(motions, joint, out, labels=_plot_labels([reference, *others]), mask=mask_arr)
    console.print(f"wrote {out}")
    for k in redrawn:
        console.print(f"note: {others[k - 1]} drawn in {reference.name}'s channels (its own order or axes differ; "
                      "the rotations are the same)")


def _plot_labels(paths: list[Path]) -> list[str]:
    """The legend's and title's name of each plotted file: its stem, else (stems shared: a take and its
    conversion, ``take.amc`` and ``take.bvh``) its file name, else (names shared: a take and its cleaned copy
    that ``clean-batch`` names alike in another folder) the path as given, so no two lines carry one name."""
    for label in (lambda p: p.stem, lambda p: p.name, str):
        labels = [label(p) for p in paths]
        if len(set(labels)) == len(labels):
            return labels
    return labels  # one file given twice: the same name is the truth


def _in_reference_channels(motions: list) -> tuple[list, list[int]]:
    """Each take drawn in the reference's channels (:func:`mocapkit.motion.with_channels_of`: the same motion as
    AMC and as BVH plotted -80 against +80 deg); returns the takes and the indices of those re-expressed."""
    from ..motion import with_channels_of

    out = [motions[0]] + [with_channels_of(m, motions[0].skeleton) for m in motions[1:]]
    return out, [k for k in range(1, len(out)) if out[k] is not motions[k]]


def _info_of_own_file(path: Path) -> bool:
    """``info`` of a file mocapkit writes that is no take; False for anything else (read as a take)."""
    import numpy as np

    from ..database_folder import DESCRIPTION

    name = path.name.lower()
    if path.is_dir() and (path / "knowledge.json").is_file():
        return _describe_json(path, path / "knowledge.json", "accelerometer knowledge base (reconstruct --accelerometers)")
    if name.endswith(".json") and path.is_file():
        return _describe_json(path, path, None)
    if path.is_dir() and (path / DESCRIPTION).is_file():
        from ..database import MotionDatabase

        summary = MotionDatabase.open(path).summary()
        summary.pop("path", None)
        print_fields([("file", str(path)), ("kind", "motion database (mocapkit db info DIR --clips lists its clips)")]
                     + database_rows(summary))
        return True
    if name.endswith(".pt") and path.is_file():
        from ..cleaning.deep.layouts import layout_beside
        from ..cleaning.deep.provenance import model_licence, model_rig, training_rows

        model = layout_beside(path)  # the JSON train wrote beside the model: no torch (about 2.5 s to import)
        if model is None:  # none, or of another file: the .pt itself, as a shipped model's or an earlier train's
            from ..cleaning import deep

            if _describe_checkpoint(path):
                return True
            model = deep.load_model(path)
        meta = model.meta if isinstance(model.meta, dict) else {}
        rig = model_rig(model)
        print_fields([("file", str(path)), ("kind", f"{model.kind.upper()} model"),
                      ("rig", rig or "not stated (no rig family known for its joints)"),
                      ("channels", str(model.layout.num_channels)),
                      ("fps", f"{model.fps:g}" if getattr(model, "fps", None) else "?"),
                      ("training clips", str(len(meta.get("train_clips", ()))))]
                     + _training_data_rows(meta.get("training_data")) + training_rows(meta)
                     + [("licence", model_licence(model))])
        return True
    if not (name.endswith(".npz") and path.is_file()):
        return False
    try:
        with np.load(path, allow_pickle=False) as z:
            keys = set(z.files)  # the archive's listing: nothing inflated
    except Exception:  # noqa: BLE001 - not a readable archive: the take reader says why, naming the file
        return False
    if {"kind", "format_version", "description", "rotations", "root", "observed"} <= keys:  # multilinear build's
        from ..reconstruct.multilinear_file import load_model

        model, desc = load_model(path)  # refused in one line where it is no model of this version
        t = model.tensor_
        rows = [("file", str(path)), ("kind", "multilinear model (reconstruct --multilinear)"),
                ("class", str(desc.get("class") or "?")),
                ("modes", " x ".join(f"{m} ({len(e)})" for m, e in zip(t.modes, t.entries))),
                ("takes", f"{int(t.observed.sum())} of {plural(int(t.observed.size), 'cell')}, aligned to {t.reference}"),
                ("frames", f"{t.num_frames} @ {t.fps:g} fps"), ("joints", str(t.skeleton.num_joints))]
        print_fields(rows + ([("licence", str(desc["licence"]))] if desc.get("licence") else []))
        return True
    if name.endswith(".clean.npz") and "meta" in keys and "changed" in keys:
        from ..cleaning.pipeline import CleanResult

        res = CleanResult.load(path)
        print_fields([("file", str(path)), ("kind", "cleaning record (mocapkit clean)"),
                      ("frames", str(res.num_frames)), ("joints", str(len(res.joint_names))),
                      ("changed", f"{plural(int(res.changed.sum()), 'joint sample')} (filled {int(res.filled.sum())}, "
                                  f"repaired {int(res.repaired.sum())}, denoised {int(res.denoised.sum())})"),
                      ("flagged", plural(int(res.flags.sum()), "joint sample"))] + _decided_rows(res.params))
        for line in res.summary():
            console.print(f"  {line}")
        return True
    if name.endswith(".clean.npz") and {"kind", "changed", "labels"} <= keys:
        from ..cleaning.markers.clean import left_too_long
        from ..cleaning.markers.counts import KINDS, sample_counts, unvalidated
        from ..cleaning.markers.record import read_marker_record
        from ..cleaning.pipeline import CleanResult

        rec = read_marker_record(path)
        counts = sample_counts(rec)
        try:  # what a cleaning was asked, and decisions applied (a damaged member: left unsaid, as before)
            kept = CleanResult.load_params(path) or {}
        except MocapFormatError:
            kept = {}
        review = isinstance(kept.get("request"), dict) and kept["request"].get("review") is True
        written = kept.get("written") if isinstance(kept.get("written"), dict) else {}
        zeros = (written.get("read") or {}).get("zero_gaps") if isinstance(written.get("read"), dict) else None
        rows = [("file", str(path)), ("kind", "marker cleaning record (mocapkit clean of a marker capture)"
                                              + (", review mode (--steps detect)" if review else "")),
                ("frames", str(rec.num_frames)), ("markers", str(len(rec.labels))),
                # the kinds every view of a cleaning counts (cleaning.markers.counts): the clean, the batch, the index
                ("changed", f"{plural(counts['changed'], 'marker sample')} ("
                            + ", ".join(f"{what} {counts[key]}" for k, (key, what) in enumerate(KINDS)
                                        if k < 3 or counts[key]) + ")"),
                ("fixes", f"{plural(rec.count('gap'), 'gap')} filled"
                          + (f" ({unvalidated(rec.fixes)} of them unvalidated: expected error unknown)"
                             if unvalidated(rec.fixes) else "")
                          + f", {plural(rec.count('spike'), 'spike')} removed, "
                          f"{plural(rec.count('swap'), 'label swap')} undone"
                          + (f", {plural(rec.count('duplicate'), 'duplicate label')} removed" if rec.count('duplicate') else "")
                          + (f", {plural(rec.count('foreign'), 'foreign stretch', 'foreign stretches')} removed"
                             if rec.count('foreign') else ""))]
        if isinstance(zeros, int) and zeros > 0:  # the reader's decision the fills rest on, as clean said it
            from ..marker_files import zeros_read_lines

            rows.append(("zeros", zeros_read_lines(zeros)[0]))
        if rec.coincident:
            rows.append(("coincident", f"{plural(len(rec.coincident), 'run')} of two markers at one position, "
                                       "which is the duplicate not told (left as recorded)"))
        if rec.unfilled:
            long = sum(map(left_too_long, rec.unfilled))  # the rule the clean's summary counts them by
            why = [f"{n} {what}" for n, what in ((len(rec.unfilled) - long, "no plausible fill"),
                                                 (long, "longer than --max-gap")) if n]
            rows.append(("left missing", f"{plural(len(rec.unfilled), 'gap')} ({', '.join(why)})"))
        if rec.never_seen:
            rows.append(("never seen", ", ".join(rec.never_seen)))
        if rec.unlabelled:
            rows.append(("unlabelled", f"{plural(len(rec.unlabelled), 'trajectory', 'trajectories')} left as read"))
        if review:  # the counts are the cleaning's, not its output's (the input's samples): a BVH's says "changed 0"
            said = dict(rows)
            rows = [(k, "none: its output holds the input's samples; cleaning would "
                        f"change {said[k]}" if k == "changed" else
                        f"none; cleaning would have: {said[k]}" if k == "fixes" else v) for k, v in rows]
        print_fields(rows + _decided_rows({"decided": kept.get("decided")}))
        return True
    if name.endswith(".mask.npz") and "mask" in keys:
        from ..io.masks import read_mask

        mask = read_mask(path)
        what = "marker" if "labels" in keys else "joint"  # a marker capture's gaps (corrupt --kind gaps)
        print_fields([("file", str(path)), ("kind", "corruption mask (mocapkit corrupt)"),
                      ("frames", str(mask.shape[0])), (what + "s", str(mask.shape[1])),
                      ("corrupted", f"{plural(int(mask.sum()), what + ' sample')} in "
                                    f"{plural(int(mask.any(axis=1).sum()), 'frame')}")])
        return True
    if {"mdm", "flags"} <= keys and "format_version" not in keys:
        from ..cleaning.ssa import Detection

        det = Detection.load(path)
        print_fields([("file", str(path)), ("kind", "detection (mocapkit detect)"),
                      ("frames", str(det.flags.shape[0])), ("joints", str(det.flags.shape[1])),
                      ("flagged", f"{plural(int(det.flags.sum()), 'joint sample')} in "
                                  f"{plural(len(det.segments()), 'segment')}")])
        return True
    return False


def _training_data_rows(data) -> list[tuple[str, str]]:
    """``info``'s lines on a trained model's data (its card's ``training_data``; none in older model files)."""
    if not isinstance(data, dict):
        return []
    rows = [("trained on", f"{plural(int(data.get('takes', 0)), 'take')}, {plural(int(data.get('frames', 0)), 'frame')}"
                           + (" (with their mirror images)" if data.get("mirrored") else ""))]
    if data.get("folders"):
        rows.append(("from", ", ".join(map(str, data["folders"]))))
    held = f"{plural(int(data.get('held_out_takes', 0)), 'take')}, {plural(int(data.get('held_out_frames', 0)), 'frame')}"
    rows.append(("held out", held + (f" (--holdout {data['holdout']})" if data.get("holdout") else "")))
    return rows


def _describe_json(path: Path, doc_path: Path, kind: str | None) -> bool:
    """``info`` of mocapkit's JSON files: a knowledge base's description, a decisions file, a batch's mark; False
    for any other JSON (refused then as no take)."""
    import json

    from ..batch import BATCH_MARK

    try:
        doc = json.loads(doc_path.read_text(encoding="utf-8")[: 2**22])
    except (OSError, ValueError):
        return False
    if not isinstance(doc, dict):
        return False
    if kind is not None:  # a knowledge base folder
        sensors = [s.get("name", "?") for s in doc.get("sensors", []) if isinstance(s, dict)]
        rows = [("file", str(path)), ("kind", kind), ("sensors", ", ".join(sensors) or "?"),
                ("fps", f"{doc.get('fps', '?')}"), ("built in", f"{float(doc.get('build_seconds', 0)):.1f} s")]
        if doc.get("licence"):  # the terms of the takes of the database it was built from (save_knowledge_base)
            rows.append(("licence", str(doc["licence"])))
        print_fields(rows)
        return True
    if str(doc.get("format", "")).startswith("mocapkit.decisions"):
        from ..cleaning.decisions import what_clean_does  # read as clean --decisions reads it, refusals too

        take = doc.get("take", {}) if isinstance(doc.get("take"), dict) else {}
        print_fields([("file", str(path)), ("kind", "review decisions (clean --decisions applies them)"),
                      ("take", str(take.get("name", "?"))), ("output", str(doc.get("output", "?"))),
                      ("decisions", what_clean_does(path)),
                      ("written by", f"mocapkit {doc.get('mocapkit', '?')}")])
        return True
    if path.name == BATCH_MARK and "input" in doc:
        print_fields([("file", str(path)), ("kind", "clean-batch's mark of its output folder (a later batch of the "
                                                     "input folder leaves this folder out)"),
                      ("input folder", str(doc.get("input")))])
        return True
    return False


def _decided_rows(params: dict | None) -> list[tuple[str, str]]:
    """The ``decided`` row of a record whose output was then written by ``clean --decisions`` over it in place
    (:mod:`mocapkit.batch_decided`): the counts above it are the cleaning reviewed, not the output beside it,
    which holds only the accepted changes; without the row they read as what the output holds."""
    entry = (params or {}).get("decided")
    if not isinstance(entry, dict) or not entry.get("decisions"):
        return []
    holds = f": {entry['holds']}" if entry.get("holds") else ""
    return [("decided", f"its output was then written by clean --decisions with only the changes "
                        f"{entry['decisions']} accepts{holds}; the counts here are the cleaning reviewed")]


def _describe_checkpoint(path: Path) -> bool:
    """``info`` of a training checkpoint (``mocapkit train``'s ``checkpoint.pt``); False when ``path`` is none."""
    import json

    import torch

    try:
        ck = torch.load(path, map_location="cpu", weights_only=True)
    except Exception:  # noqa: BLE001 - not a torch file of ours: the model reader says why
        return False
    if not (isinstance(ck, dict) and {"config", "data", "epoch", "state"} <= set(ck)):
        return False
    try:
        cfg, data = json.loads(ck["config"]), json.loads(ck["data"])
        train = list(data.get("train", []))
    except (TypeError, ValueError, AttributeError):
        cfg, train = {}, []
    digests = bool(train) and all(isinstance(r, list) for r in train)
    print_fields([("file", str(path)), ("kind", f"training checkpoint ({str(cfg.get('kind', '?')).upper()}, "
                                                 "mocapkit train: the same command resumes it)"),
                  ("epochs done", str(int(ck["epoch"]) + 1)), ("training clips", str(len(train))),
                  ("clip content", "digests kept" if digests else
                   "names only (an earlier mocapkit: it cannot be resumed; --restart)")])
    return True


def _served_note(m) -> str:
    """Whether the shipped networks serve a rig read from its tree, as denoise, fill and clean decide
    (``deep.served_by``: the roles found may still leave a trunk segment unmapped). The shipped networks' layouts
    are read from the JSON kept beside them (``deep.shipped_layout``), so ``info`` does not import torch."""
    from ..cleaning.deep.layouts import shipped_layout
    from ..cleaning.deep.retarget import served_by

    sv = served_by(m, shipped_layout("ebf", m))
    return " (the networks serve it through them)" if not isinstance(sv, str) else f" (the networks fall back: {sv})"


def _check_plot_joint(joint: str, paths: list[Path], motions: list) -> None:
    """Refuse ``--joint`` unless every take has it, with the reference's rotation channels: one line naming the file.

    The channels are those the plot draws (:func:`mocapkit.report.plots.channel_names`), so the check and the
    plot cannot disagree.
    """
    from ..report.plots import channel_names

    first = None
    for path, m in zip(paths, motions):
        try:
            m.skeleton.index(joint)
            names = [n[len(joint) + 1:] for n in channel_names(m, joint)]  # "LeftKnee.Zrotation" -> "Zrotation"
        except (KeyError, ValueError) as exc:
            raise MocapFormatError(path, f"--joint: {exc.args[0]}") from None
        if first is None:
            first = names
        lacking = [c for c in first if c not in names]
        if lacking:
            raise MocapFormatError(path, f"--joint: joint {joint!r} lacks the {', '.join(lacking)} channel(s) that "
                                         f"{paths[0]} plots")
