"""The deep models (Mall et al. 2017): ``denoise`` (EBF), ``fill`` (EBD) and ``train``."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Optional

import typer

from ..errors import MocapError, MocapFormatError, SkeletonError
from .common import (amc_fps_option, asf_option, check_executor, console, executor_option, guard, overwrite_option,
                     plural, save_take, unit_option)


def _model(path: Optional[Path], kind: str):
    """The model file at ``path`` (checked here so its errors name it), or None for the shipped one."""
    from ..cleaning import deep

    if path is None:
        return None
    return deep.load_model(path, kind)


def _reference(path: Optional[Path], take, asf: Optional[Path] = None, fps: Optional[float] = None,
               unit: Optional[str] = None):
    """``--reference``, read and checked against ``take`` (same joints and frames) before any work."""
    from ..io.takes import load_motion
    from ..reference import check_reference

    if path is None:
        return None
    return check_reference(load_motion(path, asf, purpose="a reference", fps=fps, unit=unit, unit_option="--unit"), path,
                           frames=take.num_frames,
                           joint_names=take.skeleton.joint_names, option="--unit")


def _marker_reason(command: str) -> str:
    return (f"a marker capture; {command} works on skeletal takes (.bvh, .amc, .npz), and `mocapkit clean` cleans "
            "marker files (fills gaps, removes spikes, undoes swaps)")


def _motion_for(inp: Path, out: Path, asf: Optional[Path], command: str, fps: Optional[float] = None,
                unit: Optional[str] = None):
    """IN read as a motion once OUT's suffix is checked; a marker capture is refused in one line naming IN (before
    OUT's suffix, which would be the wrong complaint: a .c3d or .trc by its suffix, a marker .npz once read)."""
    from .. import io
    from ..io.takes import load_take
    from ..motion import Motion

    if inp.suffix.lower() in (".c3d", ".trc"):
        raise MocapFormatError(inp, _marker_reason(command))
    bad_out = None
    try:
        io.suffix_kind(out, io.WRITERS, "writing")
    except MocapFormatError as exc:
        if inp.suffix.lower() != ".npz" or not inp.is_file():
            raise
        bad_out = exc  # a marker .npz is named as one first
    take = load_take(inp, asf, fps=fps, unit=unit, unit_option="--unit")
    if not isinstance(take, Motion):
        raise MocapFormatError(inp, _marker_reason(command))
    if bad_out is not None:
        raise bad_out
    return take


def _no_fallback_option():
    return typer.Option(False, "--no-fallback", help="Fail (exit 2) instead of falling back when the network does "
                                                     "not serve this rig (see docs/guide/deep-models.md).")


def _served(inp: Path, motion, net, kind: str, no_fallback: bool, given: Optional[Path] = None):
    """The one-line error naming ``inp`` when a model named by ``--model`` (``net``), or with ``--no-fallback`` the
    shipped one, does not serve the take: a named model is used or refused (:func:`mocapkit.cleaning.deep.refusal`)."""
    from ..cleaning import deep

    if net is not None or no_fallback:
        sv = deep.served_by(motion, net if net is not None else deep.shipped_model(kind, motion))
        if isinstance(sv, str) and net is not None:
            raise MocapError(f"{inp}: {deep.refusal(net, sv, given)}")  # the model named as typed
        if isinstance(sv, str):
            raise MocapError(f"{inp}: the shipped {kind.upper()} does not serve this rig ({sv})")


def denoise(
    inp: Path = typer.Argument(..., metavar="IN", help="Noisy motion (.bvh, .amc, .npz)."),
    out: Path = typer.Option(..., "--out", "-o", help="Denoised motion (.bvh, .amc for a take read from ASF/AMC, or .npz)."),
    model: Optional[Path] = typer.Option(None, "--model", help="An EBF model file, or a shipped one's name: ebf.pt, "
                                                               "ebf_bandai.pt (default: the one for the take's rig)."),
    reference: Optional[Path] = typer.Option(None, "--reference", help="A clean take to report the error against."),
    no_fallback: bool = _no_fallback_option(),
    asf: Optional[Path] = asf_option(),
    amc_fps: Optional[float] = amc_fps_option(),
    unit: Optional[str] = unit_option(),
    overwrite: bool = overwrite_option(),
) -> None:
    """Denoise every joint angle with the EBF network (Mall et al. 2017); the root trajectory is kept.

    On a rig the shipped network does not serve, a Savitzky-Golay filter (0.1 s) denoises instead, with a
    warning line (as `clean` does); --no-fallback makes that an error. A --model that does not serve the take
    is refused (exit 2), never replaced by the filter.
    """
    from .. import io
    from ..cleaning.pipeline import capped_lines, noise_fit_frames
    from ..cleaning.whole_take import denoise_take
    from ..cleaning.zeros import find_zeros
    from ..io.euler_branches import bvh_written
    from ..io.takes import CLI_AMC_NAMES, check_asf
    from ..metrics import joint_angle_rms
    from ..reference import joint_angle_errors

    guard([out], [inp, asf, model, reference], overwrite)
    check_asf(asf, [inp, reference], amc_fps, names=CLI_AMC_NAMES)
    m = _motion_for(inp, out, asf, "denoise", amc_fps, unit)
    if m.num_frames < noise_fit_frames(m.fps):  # as clean skips it: too few frames to tell noise from motion
        raise MocapError(f"{inp}: {plural(m.num_frames, 'frame')} is shorter than the noise criterion's fit "
                         f"({noise_fit_frames(m.fps)} frames): too short to denoise")
    io.check_writable(m, out)
    ref = _reference(reference, m, asf, amc_fps, unit)
    net = _model(model, "ebf")  # torch: only once the input is read (a bad file fails at once)
    _served(inp, m, net, "ebf", no_fallback, model)
    zeros = find_zeros(m)  # channels written as 0 where the capture lost data: left as written, as clean leaves them
    try:  # the path clean's denoise step takes
        cleaned, method, note = denoise_take(m, net, options={"ebf": "--model"}, zeros=zeros)
    except SkeletonError as exc:
        raise MocapError(f"{inp}: {exc}") from None
    cleaned = bvh_written(m, cleaned, out, asf, inp)  # a BVH hinge, an AMC bone of fewer dofs: what is written is reported
    save_take(cleaned, out, inp, asf, overwrite, like=inp)
    if note:
        console.print(f"warning: {inp}: {note}")
    change = joint_angle_rms(m, cleaned, include_root=False)
    line = f"wrote {out}: {plural(m.num_frames, 'frame')} denoised by {method}, mean change {change:.2f} deg RMS"
    if ref is not None:
        a, b = joint_angle_errors(ref, m, cleaned)
        line += f"; joint-angle RMS against {reference.name}: {a:.2f} -> {b:.2f} deg"
    console.print(line)
    left = [dataclasses.replace(z, filled=False) for z in zeros[1]]
    for said in capped_lines(left, "runs written as 0", ""):  # as clean without its fill step names them
        console.print(f"  {said}")


def fill(
    inp: Path = typer.Argument(..., metavar="IN", help="Motion with gaps (NaN joints in .npz; or any format)."),
    out: Path = typer.Option(..., "--out", "-o", help="Filled motion (.bvh, .amc for a take read from ASF/AMC, or .npz)."),
    model: Optional[Path] = typer.Option(None, "--model", help="An EBD model file, or a shipped one's name: ebd.pt, "
                                                               "ebd_bandai.pt (default: the one for the take's rig)."),
    denoiser: Optional[Path] = typer.Option(None, "--denoiser", help="The EBF that smooths the network's filled "
                                                                    "entries, or through which the gap prior reads "
                                                                    "a take of 60 fps or less (a file or a shipped "
                                                                    "name, as --model)."),
    smooth: bool = typer.Option(True, "--smooth/--no-smooth", help="Use the EBF (--denoiser); --no-smooth: none."),
    by: str = typer.Option("auto", "--by", help="What fills the gaps: prior (the EBD model's Gaussian gap prior), "
                                                "ebd (the network), auto (the prior when the model has one)."),
    reference: Optional[Path] = typer.Option(None, "--reference", help="A clean take to report the error against."),
    always_write: bool = typer.Option(False, "--always-write", help="Write OUT even when IN has no gaps "
                                                                     "(IN in OUT's format)."),
    no_fallback: bool = _no_fallback_option(),
    asf: Optional[Path] = asf_option(),
    amc_fps: Optional[float] = amc_fps_option(),
    unit: Optional[str] = unit_option(),
    overwrite: bool = overwrite_option(),
) -> None:
    """Fill missing joints with the EBD model (its gap prior or the network, + EBF); observed values are kept bit-identical.

    Channels written as 0 where the capture lost data (a joint, one channel or a whole frame jumping to 0
    and back) are gaps too, named and filled, as `clean` fills them. On a rig the network does not serve,
    a cubic spline fills the gaps instead, with a warning line (as `clean` does); --no-fallback makes that
    an error. A --model that does not serve the take is refused (exit 2), never replaced by the spline. A take without gaps is reported and OUT is not written unless --always-write.
    """
    from .. import io
    from ..cleaning import deep
    from ..cleaning.pipeline import capped_lines
    from ..cleaning.whole_take import fill_take
    from ..cleaning.zeros import as_missing, find_zeros
    from ..io.euler_branches import bvh_written
    from ..io.takes import CLI_AMC_NAMES, check_asf
    from ..progress import steps_bar
    from ..reference import filled_error_deg

    import numpy as np

    if by not in deep.FILL_METHODS:
        raise MocapError(f"--by must be one of {', '.join(deep.FILL_METHODS)}, got {by!r}")
    guard([out], [inp, asf, model, denoiser, reference], overwrite)
    check_asf(asf, [inp, reference], amc_fps, names=CLI_AMC_NAMES)
    m = _motion_for(inp, out, asf, "fill", amc_fps, unit)
    io.check_writable(m, out)
    ref = _reference(reference, m, asf, amc_fps, unit)

    def fill_steps(step):
        """The fill, its steps said by ``step``: (filled, done, zeros, gappy, missing, n, method), or None for a
        take without gaps (written unchanged with --always-write)."""
        ebd, ebf = _model(model, "ebd"), _model(denoiser, "ebf")
        zeros = find_zeros(m)  # channels written as 0 where the capture lost data: gaps, as clean's fill step finds them
        gappy = as_missing(m, zeros[0], zeros[2]) if zeros[1] else m
        missing = gappy.missing()
        n = int(missing.sum())
        if not n:
            if always_write:
                save_take(m, out, inp, asf, overwrite, like=inp)
            return None
        never = [m.skeleton.joint_names[j] for j in np.flatnonzero(missing.all(axis=0))]
        if never:
            raise MocapError(f"{inp}: joint(s) {', '.join(never[:4])} are missing in every frame; nothing to fill them from")
        _served(inp, m, ebd, "ebd", no_fallback, model)
        step(f"filling {plural(n, 'missing joint sample')}")
        try:  # the path clean's fill step takes; an own-rig EBD's pair beside it is found there, said in done.note
            # as clean says it (a warning line: a model file the command was not given)
            done = fill_take(m, ebd, ebf, smooth=smooth, method=by, options={"ebd": "--model", "ebf": "--denoiser"},
                             zeros=zeros)
        except (SkeletonError, ValueError) as exc:
            raise MocapError(f"{inp}: {exc}") from None
        filled, method = bvh_written(m, done.motion, out, asf, inp), done.method  # a hinge holds its axis' angle
        step(f"writing {out.name}")
        save_take(filled, out, inp, asf, overwrite, like=inp)
        return filled, done, zeros, gappy, missing, n, method

    # a bar over the command's steps on standard error (a terminal only: mocapkit.progress): the models' loading
    # and a long take's fill were a minute of silence
    with steps_bar(f"fill {inp.name}", 3) as step:
        step("loading the models")
        got = fill_steps(step)
    if got is None:
        console.print(f"no gaps in {inp}; nothing to fill; wrote it unchanged to {out}" if always_write
                      else f"no gaps in {inp}; nothing to fill (nothing written; --always-write writes it)")
        return
    filled, done, zeros, gappy, missing, n, method = got
    for said in (done.note, *done.warnings):
        if said:
            console.print(f"warning: {inp}: {said}")
    left = int((missing & filled.missing()).sum())
    if left:  # never say filled for what is still NaN
        console.print(f"warning: {inp}: {plural(left, 'missing joint sample')} could not be filled and stay missing")
    line = f"wrote {out}: {plural(n - left, 'missing joint sample')} filled by {method}"
    if zeros[1]:
        line += f" ({int(zeros[0].sum())} of them written as 0 where the capture lost data)"
    root = int(np.isnan(gappy.root_positions).any(axis=-1).sum())  # the networks fill rotations: positions apart
    pelvis, hips, moved = 0, 0, 0
    if gappy.translations is not None:  # a game rig's pelvis carries the path in its animated offset (root_gaps)
        from ..rigs import pelvis_index

        lost = np.isnan(gappy.translations).any(axis=-1)
        pelvis = pelvis_index(gappy.skeleton)
        hips = int(lost[:, pelvis].sum()) if pelvis else 0
        moved = int(lost[:, 1:].sum()) - hips
    if root:  # cleaning.root_gaps.fill_root_gaps, whatever fills the rest: the feet's contacts, else a spline
        line += f" (the {root} missing root position(s) among them from the feet's contacts or a cubic spline)"
    if hips:  # cleaning.root_gaps.fill_pelvis
        line += (f" (the {hips} missing {gappy.skeleton.joint_names[pelvis]} position(s) among them from the feet's"
                 " contacts, a cubic spline or the line between the gap's ends, whichever refills the take's"
                 " measured stretches best)")
    if moved and method != deep.FALLBACK_FILL:  # any other animated offset's gap is a straight line
        line += f" (the {moved} missing position(s) of other joints among them interpolated linearly)"
    if ref is not None:
        line += (f"; mean rotation error of the filled joints against {reference.name}: "
                 f"{filled_error_deg(ref, filled, missing):.2f} deg")
    console.print(line)
    for said in capped_lines(done.zero_runs, "runs written as 0", ""):  # as clean's summary names them
        console.print(f"  {said}")


def train(
    what: str = typer.Argument(..., metavar="denoiser|gapfiller", help="Train the EBF denoiser or the EBD gap filler."),
    sources: list[Path] = typer.Argument(..., metavar="CLIPS...", help="Motion files, folders or database folders."),
    out: Path = typer.Option(..., "--out", "-o", help="Folder for checkpoint.pt and model.pt (created; "
                                                       "the same training there is resumed, see --resume; "
                                                       "another one's files are refused, see --overwrite)."),
    holdout: Optional[list[str]] = typer.Option(
        None, "--holdout", help="Validation clips: a name substring (repeat) or a count of random clips."
    ),
    folds: int = typer.Option(1, "--folds", min=1, help="Cross-validate on this many disjoint random holdouts (Mall: 5)."),
    epochs: int = typer.Option(40, "--epochs", min=1, help="Epochs to train (each --steps optimiser steps, then a validation)."),
    steps: int = typer.Option(100, "--steps", min=1, help="Optimiser steps per epoch."),
    minutes: Optional[float] = typer.Option(None, "--minutes", help="Stop after the epoch that passes this budget."),
    hidden: Optional[int] = typer.Option(None, "--hidden", help="LSTM units per direction (EBF 126, EBD 32)."),
    representation: str = typer.Option("euler", "--representation", help="euler (the file's angles) or rot6d."),
    head: str = typer.Option("gaussian", "--head", help="EBF filter: gaussian or free (31 taps)."),
    bias: bool = typer.Option(False, "--bias/--no-bias", help="EBF: also predict a per-channel bias."),
    noise_input: bool = typer.Option(
        False, "--noise-input/--no-noise-input", help="EBF: the encoder also reads each channel's noise-level estimate."
    ),
    noise: Optional[list[str]] = typer.Option(
        None, "--noise", help="Noise settings to train on (repeat): angular:A, uniform:A, spatial:CM, "
        "bias-constant:A, bias-sinusoidal:A, clean (default: angular 0.1/0.5/0.9, uniform 0.5, spatial 0.5/1.0)."
    ),
    lr: float = typer.Option(2e-3, "--lr", help="Adam learning rate (halved on validation plateaus)."),
    dropout: float = typer.Option(0.1, "--dropout", help="Dropout on the LSTM inputs (Mall: 0.5)."),
    speed: tuple[float, float] = typer.Option(
        (1.0, 1.0), "--speed", help="Augmentation: replay the training clips at a random speed in LO HI (e.g. 0.7 1.4)."
    ),
    offset: float = typer.Option(0.0, "--offset", help="Denoiser augmentation: random channel offsets, x channel std."),
    patchy: float = typer.Option(
        0.0, "--patchy", help="Denoiser augmentation: share of crops with noise on some channels and over one stretch."
    ),
    crop: Optional[int] = typer.Option(
        None, "--crop", min=1, help="Denoiser: output frames per training crop (plus 15 each side); "
        "default 1 s of the clips' rate (30 at 30 fps, 120 at 120 fps). Clips shorter than a crop are refused."),
    mirror: bool = typer.Option(
        False, "--mirror", help="Also train on each training clip's left/right mirror image (doubles a small set)."),
    init: str = typer.Option("xavier", "--init", help="xavier (the shipped models') or paper (uniform [-0.5, 0.5])."),
    seed: int = typer.Option(0, "--seed"),
    licence: Optional[str] = typer.Option(
        None, "--licence", metavar="TEXT", help="The model's licence, kept in model.pt (mocapkit info shows it; a "
        "non-commercial one is said wherever the model is used). Default: the takes' own where known (Bandai Namco "
        "takes: CC BY-NC 4.0), else not stated."),
    resume: bool = typer.Option(True, "--resume/--restart", help="Continue from OUT/checkpoint.pt of the same settings "
                                "and clips (default), or start over there, replacing OUT's model and checkpoint."),
    overwrite: bool = typer.Option(False, "--overwrite", help="Replace a model.pt or checkpoint.pt of another training "
                                   "in OUT (refused without it); the same training still resumes."),
    executor: Optional[str] = executor_option("noisy pairs are made"),
    device: str = typer.Option("auto", "--device", help="auto (a GPU when present), cpu or cuda."),
    asf: Optional[Path] = asf_option("input(s)"),
    amc_fps: Optional[float] = amc_fps_option("input(s)"),
    unit: Optional[str] = unit_option("input(s)"),
) -> None:
    """Train an EBF or EBD on noisy/clean pairs made on the fly with mocapkit.corrupt (Mall et al. 2017, 4).

    Writes OUT/model.pt (the best epoch on the validation clips) and OUT/checkpoint.pt after every
    epoch; running the same command again resumes. An OUT holding the model or checkpoint of another
    training (other settings, or clips of other names or content) is refused before any work unless
    --restart or --overwrite is given. With --folds K, OUT/fold_1 ... OUT/fold_K. With
    --mirror the training clips' mirror images join them (validation clips stay as they are).

    model.pt keeps its card: the rig family of the clips, the training data (folders, takes,
    frames, hold-out) and the licence. A model inherits the licence of its training takes: on the
    Bandai Namco takes (CC BY-NC 4.0) it is non-commercial, and denoise, fill and clean say so
    wherever it is used; --licence states it for other takes (else "not stated").
    """
    kinds = {"denoiser": "ebf", "gapfiller": "ebd"}
    if what not in kinds:  # before torch is imported: a mistyped command fails at once
        raise MocapError(f"train: expected denoiser or gapfiller, got {what!r}")
    import numpy as np

    from ..cleaning.deep import training
    from ..cleaning.deep.provenance import data_licence, rms_unit, training_rig
    from ..mirroring import mirror_for_rig

    # the model folder must not be, or lie inside, a source (a folder of takes, a database); its own files are
    # resumed or replaced (--resume/--restart/--overwrite: training.check_out_dir, below), not refused here
    guard([out / "model.pt", out / "model.layout.json", out / "checkpoint.pt"], sources, overwrite=True)
    check_executor(executor)
    try:  # every setting is checked by TrainConfig before a clip is read
        cfg = training.TrainConfig(
            kind=kinds[what], representation=representation, hidden=hidden, head=head, bias=bias,
            noise_input=noise_input, epochs=epochs, steps_per_epoch=steps, minutes=minutes, seed=seed, device=device,
            lr=lr, dropout=dropout, init=init, speed_range=(float(speed[0]), float(speed[1])), offset=offset,
            patchy=patchy, crop=crop, **({"noise": tuple(noise)} if noise else {}),
        )
    except ValueError as exc:
        raise MocapError(f"train: {exc}") from None
    if asf is not None or amc_fps is not None:
        from ..database import expand_sources
        from ..io.takes import CLI_AMC_NAMES, check_asf

        check_asf(asf, expand_sources([s for s in sources if not (s / "database.json").is_file()]), amc_fps, names=CLI_AMC_NAMES)
    if unit is not None:
        from ..io.takes import check_unit

        check_unit(unit, "--unit")
    clips = training.load_clips(sources, asf, amc_fps, unit=unit, unit_option="--unit")
    if not clips:
        raise MocapError(f"train: no .bvh, .amc or .npz clips in {', '.join(map(str, sources))}")
    # --holdout is a count of random clips (one number) or name substrings
    count = int(holdout[0]) if holdout and len(holdout) == 1 and holdout[0].isdigit() else None
    if folds > 1:
        try:
            splits = training.holdout_folds(clips, folds, count, seed=seed)
        except ValueError as exc:
            raise MocapError(f"train: {exc}") from None
        outs = [out / f"fold_{k + 1}" for k in range(folds)]
    else:
        hold: list[str] | int = count if count is not None else list(holdout or []) or 0
        if isinstance(hold, list):  # a name that holds out nothing is a typo, not a choice to validate on nothing
            unmatched = [h for h in hold if not any(h in c.name for c in clips)]
            if unmatched:
                raise MocapError(f"--holdout {' '.join(unmatched)}: no clip's name contains it; clips are "
                                 f"{', '.join(c.name for c in clips[:8])}" + (", ..." if len(clips) > 8 else ""))
        splits, outs = [training.split_holdout(clips, hold, seed=seed)], [out]
        if isinstance(hold, int) and hold >= len(clips):  # split_holdout keeps one clip to train on
            console.print(f"note: --holdout {hold} of {plural(len(clips), 'clip')}: {len(splits[0][1])} held out, "
                          f"{len(splits[0][0])} to train on")
    mirrors = {}  # each clip's mirror image, made once (a clip trains in several folds) and before any training
    for c in clips if mirror else ():
        try:
            mirrors[id(c)] = mirror_for_rig(c)
        except SkeletonError as exc:
            raise MocapError(f"train --mirror: {c.name}: {exc}") from None
    if any(n.startswith("spatial") for n in cfg.noise):  # in cm: the rig's length unit, told before any work
        from ..motion import unit_scale_cm

        try:
            unit_scale_cm(clips[0].skeleton)
        except SkeletonError as exc:
            raise MocapError(f"train: spatial noise (in cm{', a default' if not noise else ''}) needs the clips' "
                             f"length unit: {exc}; give it with --unit (mm, cm, m, in), or give --noise without spatial: "
                             "(e.g. --noise angular:0.5)") from None
    runs = []
    for (tr, val), o in zip(splits, outs):
        if not tr:
            raise MocapError("train: every clip is held out; nothing left to train on")
        runs.append((tr + [mirrors[id(c)] for c in tr] if mirror else tr, val, o))
    try:  # every fold's folder before the first fold trains: a model of another training is never replaced unasked
        for tr, val, o in runs:
            training.check_clip_lengths(tr, cfg)
            training.check_out_dir(o, tr, cfg, val or None, resume=resume, overwrite=overwrite)
    except ValueError as exc:
        raise MocapError(f"train: {exc}") from None
    known = data_licence(clips)
    if licence and known and licence != known:  # the user's word is kept, the data's terms said beside it
        console.print(f"note: these takes are of the {training_rig(clips[:1])} rig, whose data set's licence is "
                      f"{known}; the model keeps --licence as given")
    given = {"training_data": {"folders": [str(s.absolute()) for s in sources], "holdout": " ".join(holdout or []),
                               "mirrored": mirror}, **({"licence": licence} if licence else {})}
    bests = []
    for tr, val, o in runs:
        try:
            model = training.train(tr, o, cfg, validation=val or None, resume=resume, executor=executor,
                                   overwrite=overwrite, meta=given, executor_option="--executor")
        except (SkeletonError, ValueError) as exc:
            raise MocapError(f"train: {exc}") from None
        except KeyboardInterrupt:  # a checkpoint is a whole file, kept on purpose: say so beside "interrupted"
            if (o / "checkpoint.pt").is_file():
                again = "the same command without --restart" if not resume else "the same command"
                console.print(f"note: {o / 'checkpoint.pt'} keeps the last finished epoch; {again} resumes")
            raise
        h = model.meta["history"]
        bests.append(min(x["val_rmse"] for x in h))
        what_rms = "validation" if val else "training"
        unit = " " + rms_unit(model.layout.representation)
        console.print(f"wrote {o / 'model.pt'}: {plural(len(tr), 'clip')}, {plural(len(h), 'epoch')}, "
                      f"best {what_rms} RMS {bests[-1]:.3f}{unit}")
    if folds > 1:
        console.print(f"{folds} holdouts: validation RMS {np.mean(bests):.3f} +- {np.std(bests):.3f}{unit}")
    if known and (not licence or licence == known):  # inherited from the takes (model_card), as info shows it
        console.print(f"note: {'model.pt keeps' if len(runs) == 1 else 'each model.pt keeps'} its takes' licence, {known}")
