"""Multilinear models (Tautges 2012, ch. 2): ``multilinear build``; ``reconstruct --multilinear`` fits one."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Optional

import typer

from ..errors import MocapError
from .common import (FlagsCommand, FlagsGroup, amc_fps_option, asf_option, console, guard, overwrite_option, plural,
                     unit_option)

multilinear_app = typer.Typer(
    help="Build multilinear motion models of one motion class (Tautges 2012, ch. 2), for `reconstruct --multilinear`.",
    no_args_is_help=True,
    cls=FlagsGroup,
)

MODES = ("auto", "take")


def _ranks(text: Optional[str]) -> dict:
    """``--ranks MODE=R,...`` as a dict, refused in one line naming the option where it does not parse."""
    if text is None:
        return {}
    out = {}
    for item in (t.strip() for t in text.split(",") if t.strip()):
        name, _, value = item.partition("=")
        if not value.strip().isdigit() or int(value) < 1 or not name.strip():
            raise MocapError(f"--ranks must be MODE=R,... with R a positive integer (modes: dof, joint, frame and the "
                             f"natural ones), got {item!r}")
        out[name.strip()] = int(value)
    return out


@multilinear_app.command("build", cls=FlagsCommand)
def build(
    model_path: Path = typer.Argument(..., metavar="MODEL", help="The model file to write (.npz)."),
    files: list[Path] = typer.Argument(..., metavar="FILES...", help="Takes of one motion class (.bvh, .amc, .npz) or folders of them."),
    modes: str = typer.Option("auto", "--modes", help="The natural modes: auto (from the file names: HDM05 actor x repetition, Bandai Namco style [x repetition]) or take (one mode, each take an entry)."),
    fps: float = typer.Option(30.0, "--fps", help="Frame rate of the model's time axis."),
    frames: Optional[int] = typer.Option(None, "--frames", help="Length of the model's time axis (default: the median-length take's at --fps)."),
    missing: str = typer.Option("mean", "--missing", help="A grid cell no take fills: mean (the mean of its row along the last mode) or drop (keep the entries every row has)."),
    ranks: Optional[str] = typer.Option(None, "--ranks", help="Truncation ranks, MODE=R,... (dof, joint, frame, or a natural mode; default: full)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object (model, takes, modes, tensor shape) instead of the summary line."),
    asf: Optional[Path] = asf_option("input(s)"),
    amc_fps: Optional[float] = amc_fps_option("input(s)"),
    unit: Optional[str] = unit_option("input(s)"),
    overwrite: bool = overwrite_option(),
) -> None:
    """Build a multilinear model from takes of one motion class and save it to MODEL.

    The takes are aligned to the median-length one by DTW, stacked by their natural modes and decomposed
    by HOSVD (Tautges 2012, secs. 2.2-2.3); `reconstruct --multilinear MODEL --accelerometers TAKE` fits
    it to a take's sensors.
    """
    from ..database import FPS_RANGE, expand_sources
    from ..io.takes import CLI_AMC_NAMES, check_asf, load_motion
    from ..reconstruct.motion_tensor import name_labels
    from ..reconstruct.multilinear import MultilinearModel
    from ..reconstruct.multilinear_file import save_model
    from ..rigs import data_terms

    if modes not in MODES:  # before any work, naming the option
        raise MocapError(f"--modes must be auto or take, got {modes!r}")
    if missing not in ("mean", "drop"):
        raise MocapError(f"--missing must be mean or drop, got {missing!r}")
    if not FPS_RANGE[0] <= fps <= FPS_RANGE[1]:  # a database's range: the model's time axis is resampled as one
        raise MocapError(f"--fps must be a number from {FPS_RANGE[0]:g} to {FPS_RANGE[1]:g} (frames per second), got {fps:g}")
    if frames is not None and frames < 5:
        raise MocapError(f"--frames must be at least 5, got {frames}")
    rank = _ranks(ranks)
    if model_path.suffix.lower() != ".npz":
        raise MocapError(f"{model_path}: a model is written as .npz")
    paths = list(expand_sources(files))
    guard([model_path], [*files, *paths, asf], overwrite)  # not into a folder of takes, where it would be one
    check_asf(asf, paths, amc_fps, names=CLI_AMC_NAMES)
    if len(paths) < 2:
        raise MocapError(f"{files[0]}: a multilinear model needs at least 2 takes of its class, got {len(paths)}")
    if modes == "take":
        mode_names, labels, what = ("take",), [(Path(p).stem,) for p in paths], "takes"
    else:
        try:
            mode_names, labels, what = name_labels(paths)
        except ValueError as exc:  # names of neither dataset: the modes can be given; takes of several classes cannot
            raise MocapError(f"{exc}{'' if 'motion classes' in str(exc) else '; pass --modes take'}") from None
    clips = []
    for p in paths:
        clips.append(load_motion(p, asf, purpose="a multilinear model", fps=amc_fps, unit=unit, unit_option="--unit"))
    first = clips[0]
    for p, c in zip(paths, clips):
        if not c.skeleton.is_compatible(first.skeleton):
            raise MocapError(f"{p}: its joints differ from {paths[0]}'s; a model is of one skeleton (retarget it first)")
    if not as_json:
        console.print(f"aligning {plural(len(clips), 'take')} of {what} by DTW, modes {' x '.join(mode_names)}")
    try:
        model = MultilinearModel(ranks=rank or None, modes=mode_names, fps=fps, frames=frames, missing=missing,
                                 progress=not as_json).fit(clips, labels)
    except ValueError as exc:
        raise MocapError(f"{files[0]}: {' '.join(str(exc).split())}") from None
    licence = data_terms([c.skeleton for c in clips])
    save_model(model, model_path, sources=[Path(p).name for p in paths], licence=licence,
               motion_class=what if modes != "take" else "")
    t = model.tensor_
    shape = dict(zip(t.modes, t.shape))
    observed = int(t.observed.sum())
    if as_json:
        print(json.dumps({"model": str(model_path), "takes": len(clips), "class": what, "modes": shape,
                          "observed": observed, "frames": t.num_frames, "fps": t.fps,
                          "tensor": list(t.rotations.shape), "reference": t.reference,
                          **({"licence": licence} if licence else {})}))
        return
    grid = " x ".join(f"{m} ({n})" for m, n in shape.items())
    filled = math.prod(t.shape) - observed
    console.print(f"wrote {model_path}: {plural(len(clips), 'take')} of {what}, modes {grid}"
                  + (f" ({plural(filled, 'cell')} filled by --missing {missing})" if filled else "")
                  + f", {t.num_frames} frames @ {t.fps:g} fps, aligned to {t.reference}")
    if licence:
        console.print(f"note: the takes are {licence}: so is this model")

