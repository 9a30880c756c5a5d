"""The ``mocapkit`` command: thin wrappers that parse, call the library, and print.

Every command writes its outputs atomically (temporary file + rename), refuses
to overwrite its input, and on bad input prints one line naming the file and
the problem and exits with status 2.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from .errors import MocapError, MocapFormatError, SkeletonError

app = typer.Typer(
    name="mocapkit",
    help="Clean and reconstruct human motion-capture data (BVH, ASF/AMC, C3D, npz).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console()

EXIT_BAD_INPUT = 2


def _fail(message: str) -> None:
    raise MocapError(message)


def _check_output(inp: Path, out: Path) -> None:
    if out.exists() and inp.exists() and out.resolve() == inp.resolve():
        raise MocapFormatError(out, "refusing to overwrite the input file; choose another output path")


@app.command()
def info(
    file: Path = typer.Argument(..., help="A .bvh, .amc, .c3d or .npz file."),
    joints: bool = typer.Option(False, "--joints", help="Also list every joint with its parent and channels."),
    asf: Optional[Path] = typer.Option(None, help="Skeleton for an .amc file (default: the ASF beside it)."),
) -> None:
    """Print the skeleton, frame count, frame rate, duration and missing data of FILE."""
    from . import io
    from .io.c3d import MarkerSet
    from .motion import unit_scale_cm

    obj = io.load(file, **({"asf": asf} if asf is not None else {}))
    table = Table(show_header=False, box=None, pad_edge=False)
    table.add_column(style="bold")
    table.add_column()
    table.add_row("file", str(file))
    if isinstance(obj, MarkerSet):
        table.add_row("kind", f"markers (read with {obj.reader})")
        table.add_row("markers", str(obj.num_markers))
        table.add_row("frames", str(obj.num_frames))
        table.add_row("fps", f"{obj.fps:g}")
        table.add_row("duration", f"{obj.num_frames / obj.fps:.3f} s")
        table.add_row("units", obj.units)
        table.add_row("missing", f"{100.0 * obj.missing().mean():.2f} % of marker samples")
        console.print(table)
        if joints:
            console.print(", ".join(obj.labels))
        return
    m = obj
    sk = m.skeleton
    miss = m.missing()
    table.add_row("kind", "motion")
    table.add_row("name", m.name)
    table.add_row("joints", f"{sk.num_joints} (+{sk.num_end_sites} end sites), root {sk.joint_names[0]!r}")
    table.add_row("frames", str(m.num_frames))
    table.add_row("fps", f"{m.fps:g}")
    table.add_row("duration", f"{m.duration:.3f} s")
    try:
        scale = unit_scale_cm(sk)
        table.add_row("length unit", f"{scale:.4g} cm" + (" (stated by the file)" if sk.unit_cm else " (from bone lengths)"))
    except MocapError as exc:
        table.add_row("length unit", f"unknown ({exc})")
    table.add_row("channels", str(len(m.channel_names())))
    table.add_row(
        "missing",
        f"{100.0 * miss.mean():.2f} % of joint samples, {int(miss.any(axis=1).sum())} frames affected",
    )
    console.print(table)
    if joints:
        jt = Table("#", "joint", "parent", "channels")
        for j, name in enumerate(sk.joint_names):
            p = sk.parents[j]
            jt.add_row(str(j), name, "-" if p < 0 else sk.joint_names[p], " ".join(sk.joint_channels(j)))
        console.print(jt)


@app.command()
def convert(
    inp: Path = typer.Argument(..., metavar="IN", help="Input motion (.bvh, .amc, .npz)."),
    out: Path = typer.Argument(..., metavar="OUT", help="Output (.bvh or .npz), chosen by suffix."),
    fps: Optional[float] = typer.Option(None, "--fps", help="Resample to this frame rate (slerp)."),
    asf: Optional[Path] = typer.Option(None, help="Skeleton for an .amc input."),
) -> None:
    """Convert IN to OUT, optionally resampling to --fps."""
    from . import io
    from .motion import Motion

    _check_output(inp, out)
    m = io.load(inp, **({"asf": asf} if asf is not None else {}))
    if not isinstance(m, Motion):
        if fps is not None or out.suffix.lower() != ".npz":
            raise MocapFormatError(inp, "marker files convert to .npz only, without --fps")
        io.save(m, out)
        console.print(f"wrote {out}")
        return
    if fps is not None:
        m = m.resample(fps)
    io.save(m, out)
    console.print(f"wrote {out} ({m.num_frames} frames @ {m.fps:g} fps)")


@app.command()
def corrupt(
    inp: Path = typer.Argument(..., metavar="IN", help="Clean input motion."),
    out: Path = typer.Argument(..., metavar="OUT", help="Corrupted output (.bvh or .npz; gaps need .npz)."),
    kind: str = typer.Option(..., "--kind", help="noise | uniform | bias | spatial | gaps | errors, or one error kind: spike | flip | freeze | drift | swap"),
    amount: Optional[float] = typer.Option(
        None, "--amount", help="noise: std as a fraction of each channel's std (0.1/0.5/0.9); spatial: std in cm."
    ),
    seed: int = typer.Option(0, "--seed", help="Random seed: the same seed gives the same corruption."),
    mask_out: Optional[Path] = typer.Option(
        None, "--mask", help="Ground-truth mask file (default: OUT with suffix .mask.npz)."
    ),
) -> None:
    """Corrupt IN with known ground truth; writes OUT and a .mask.npz of what changed."""
    from . import corrupt as corrupt_mod
    from . import io
    from .io import atomic_write

    _check_output(inp, out)
    m = io.load(inp)
    params = {}
    if amount is not None:
        params["amount"] = amount
    try:
        result = corrupt_mod.corrupt(m, kind=kind, seed=seed, **params)
    except (TypeError, ValueError) as exc:
        raise MocapError(f"corrupt --kind {kind}: {exc}") from None
    bad, mask = result[0], result[1]
    records = result[2] if len(result) > 2 else []
    if np.isnan(bad.rotations).any() and out.suffix.lower() == ".bvh":
        raise MocapFormatError(out, "this corruption leaves missing values (NaN), which BVH cannot hold; write .npz")
    mask_path = mask_out or out.with_name(out.name[: -len(out.suffix)] + ".mask.npz")
    _check_output(inp, mask_path)
    io.save(bad, out)
    with atomic_write(mask_path, "wb") as fh:
        np.savez_compressed(
            fh,
            mask=mask,
            joint_names=np.array(m.skeleton.joint_names),
            kind=np.array(kind),
            seed=np.array(seed),
            params=np.array(json.dumps(params)),
            errors=np.array(json.dumps([_record(r) for r in records])),
        )
    frames = int(mask.any(axis=1).sum())
    console.print(
        f"wrote {out} and {mask_path}: {int(mask.sum())} joint samples changed in {frames} of {m.num_frames} frames"
    )
    for r in records:
        console.print(f"  {_record(r)}")


def _record(r) -> dict:
    if isinstance(r, dict):
        return r
    if hasattr(r, "_asdict"):
        return dict(r._asdict())
    import dataclasses

    if dataclasses.is_dataclass(r):
        return dataclasses.asdict(r)
    return {"error": str(r)}


@app.command()
def plot(
    reference: Path = typer.Argument(..., help="Reference motion (e.g. the clean clip)."),
    others: list[Path] = typer.Argument(..., metavar="OTHER...", help="Motions to compare (e.g. noisy, then cleaned)."),
    joint: str = typer.Option(..., "--joint", help="Joint whose rotation channels are plotted."),
    out: Path = typer.Option(..., "-o", "--out", help="PNG to write."),
    mask: Optional[Path] = typer.Option(None, "--mask", help="A .mask.npz from `mocapkit corrupt` to shade."),
) -> None:
    """Plot the rotation channels of one joint of two or more motions over time, as a PNG."""
    from . import io
    from .report import plot_channels

    motions = [io.load(reference)] + [io.load(p) for p in others]
    other = others[0]
    mask_arr = None
    mask_path = mask or other.with_name(other.name[: -len(other.suffix)] + ".mask.npz")
    if mask_path.is_file():
        with np.load(mask_path, allow_pickle=False) as z:
            mask_arr = z["mask"]
        if mask_arr.shape[0] != motions[1].num_frames:
            mask_arr = None
    try:
        plot_channels(motions, joint, out, labels=[reference.stem] + [p.stem for p in others], mask=mask_arr)
    except KeyError as exc:
        raise MocapError(str(exc.args[0])) from None
    console.print(f"wrote {out}")


db_app = typer.Typer(help="Build and inspect motion databases (the knowledge that search and cleaning compare against).", no_args_is_help=True)
app.add_typer(db_app, name="db")


def _feature_list(text: str) -> tuple[str, ...]:
    return tuple(t.strip() for t in text.split(",") if t.strip())


@db_app.command("build")
def db_build(
    out_dir: Path = typer.Argument(..., metavar="OUT_DIR", help="Folder to create for the database."),
    files: list[Path] = typer.Argument(..., metavar="FILES...", help="Motion files (.bvh, .amc, .npz) or folders."),
    fps: float = typer.Option(30.0, "--fps", help="Frame rate every clip is resampled to."),
    mirror: bool = typer.Option(False, "--mirror", help="Also add every clip's left/right mirror image."),
    features: str = typer.Option("F15", "--features", help="Comma-separated feature sets: F15, F30, F39, F15x3, F15x5, F30x3, F39x3."),
    executor: Optional[str] = typer.Option(
        None, "--executor", help="Where to load clips: 'processes' (default), 'serial', 'dask' (local cluster) or a Dask scheduler address."
    ),
    joint_map: Optional[Path] = typer.Option(None, "--joint-map", help="JSON object {clip joint: database joint} for clips of another skeleton."),
    overwrite: bool = typer.Option(False, "--overwrite", help="Replace OUT_DIR if it exists."),
) -> None:
    """Build a motion database from FILES and save it to OUT_DIR."""
    from .database import MotionDatabase
    from .parallel import describe_executor

    for f in files:
        if f.exists() and out_dir.exists() and out_dir.resolve() == f.resolve():
            raise MocapFormatError(out_dir, "refusing to overwrite an input; choose another output folder")
    if out_dir.exists() and not overwrite:
        raise MocapFormatError(out_dir, "already exists; pass --overwrite to replace it")
    jm = None
    if joint_map is not None:
        try:
            jm = json.loads(joint_map.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise MocapFormatError(joint_map, f"not a readable JSON joint map ({exc})") from None
        if not isinstance(jm, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in jm.items()):
            raise MocapFormatError(joint_map, "a joint map is a JSON object of joint name -> joint name")
    console.print(f"building from {len(files)} path(s) on {describe_executor(executor)}")
    try:
        db = MotionDatabase.build(files, fps=fps, features=_feature_list(features), mirror=mirror, joint_map=jm, executor=executor)
    except ValueError as exc:
        raise MocapError(str(exc)) from None
    db.save(out_dir, overwrite=overwrite)
    console.print(f"wrote {out_dir}: {db.num_clips} clips, {db.num_frames} frames @ {db.fps:g} fps, features {', '.join(db.feature_names)}")


@db_app.command("info")
def db_info(
    directory: Path = typer.Argument(..., metavar="DIR", help="A database folder."),
    clips: bool = typer.Option(False, "--clips", help="Also list every clip with its frame range."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of a table."),
) -> None:
    """Print the size, frame rate, features and clips of the database in DIR."""
    from .database import MotionDatabase

    db = MotionDatabase.open(directory)
    summary = db.summary()
    if as_json:
        if clips:
            summary["clip_list"] = [{"name": c.name, "start": c.start, "frames": c.frames, "source": c.source} for c in db.clips]
        print(json.dumps(summary))
        return
    table = Table(show_header=False, box=None, pad_edge=False)
    table.add_column(style="bold")
    table.add_column()
    for k, v in summary.items():
        table.add_row(k.replace("_", " "), ", ".join(f"{a} ({b})" for a, b in v.items()) if isinstance(v, dict) else str(v))
    console.print(table)
    if clips:
        ct = Table("#", "clip", "first frame", "frames", "source")
        for k, c in enumerate(db.clips):
            ct.add_row(str(k), c.name, str(c.start), str(c.frames), c.source)
        console.print(ct)


@app.command()
def search(
    db_dir: Path = typer.Argument(..., metavar="DB_DIR", help="A database folder (`mocapkit db build`)."),
    query: Path = typer.Argument(..., metavar="QUERY", help="Query motion (.bvh, .amc, .npz)."),
    k: int = typer.Option(10, "--k", help="Number of matches."),
    features: Optional[str] = typer.Option(None, "--features", help="Feature set (default: the database's first)."),
    neighbors: int = typer.Option(128, "--neighbors", help="Nearest neighbours per query frame in the lazy neighbourhood graph."),
    method: str = typer.Option("lng", "--method", help="lng (fast, Krüger 2010) or dtw (exact subsequence DTW)."),
    start: Optional[float] = typer.Option(None, "--start", help="Use the query from this time (s)."),
    end: Optional[float] = typer.Option(None, "--end", help="Use the query up to this time (s)."),
    as_json: bool = typer.Option(False, "--json", help="Print the matches as JSON."),
) -> None:
    """Rank the database segments most similar to QUERY (numerical similarity search)."""
    from . import io
    from .database import MotionDatabase
    from .motion import Motion

    db = MotionDatabase.open(db_dir)
    m = io.load(query)
    if not isinstance(m, Motion):
        raise MocapFormatError(query, "a marker file cannot be a query; give a motion")
    a = 0 if start is None else int(round(start * m.fps))
    b = m.num_frames if end is None else int(round(end * m.fps))
    if not 0 <= a < b <= m.num_frames:
        raise MocapFormatError(query, f"--start/--end select no frames (clip has {m.num_frames} frames, {m.duration:.2f} s)")
    try:
        results = db.search(m[a:b], k=k, features=features, neighbors=neighbors, method=method)
    except (KeyError, ValueError) as exc:
        raise MocapError(f"{db_dir}: {exc.args[0] if exc.args else exc}") from None
    if as_json:
        print(json.dumps([dict(r.as_dict(), start_s=r.start / db.fps, end_s=r.end / db.fps) for r in results]))
        return
    if not results:
        console.print("no match (try a larger --neighbors)")
        return
    table = Table("#", "clip", "start", "end", "seconds", "cost", "cost/frame")
    qlen = int(round((b - a) / m.fps * db.fps))
    for r_, r in enumerate(results, 1):
        table.add_row(
            str(r_), r.name, str(r.start), str(r.end), f"{r.start / db.fps:.2f}-{r.end / db.fps:.2f}", f"{r.cost:.1f}", f"{r.cost / max(qlen, 1):.2f}"
        )
    console.print(table)


def _load_context(paths: list[Path] | None):
    """--context: motion files, or one database folder (the same reader as clean-batch's)."""
    from .batch import load_context

    return load_context(paths)


def _detect(m, context, threshold: float, progress: bool = True, confirm: bool = True, jump_deg: float = 8.0):
    from .cleaning import ssa
    from .errors import SkeletonError

    try:
        return ssa.detect(m, context, threshold=threshold, progress=progress, confirm=confirm, jump_deg=jump_deg)
    except (ValueError, SkeletonError) as exc:
        raise MocapError(f"{m.name or 'input'}: {exc}") from None


@app.command()
def detect(
    inp: Path = typer.Argument(..., metavar="IN", help="Motion to check (.bvh, .amc, .npz)."),
    out: Path = typer.Option(..., "--out", "-o", help="Detection file to write (.npz): MDM, flags, neighbours."),
    context: Optional[list[Path]] = typer.Option(
        None, "--context", help="Related clips (repeat the option) or one database folder; default: the clip itself."
    ),
    threshold: float = typer.Option(0.5, "--threshold", help="MDM value above which a joint is flagged (0-1)."),
    confirm: bool = typer.Option(
        True, "--confirm/--no-confirm",
        help="Flag a digression only where the joint's own trajectory breaks (a step or spike); --no-confirm: MDM > threshold alone.",
    ),
    jump_deg: float = typer.Option(8.0, "--jump-deg", help="Confirmation: steps over 2x this, spikes over this (degrees)."),
    png: Optional[Path] = typer.Option(None, "--png", help="Also draw the movement digression map here."),
    as_json: bool = typer.Option(False, "--json", help="Print the flagged segments as JSON."),
) -> None:
    """Find erroneous joints by self-similarity (Aristidou et al. 2018): movement digression map + flags."""
    from . import io
    from .motion import Motion

    _check_output(inp, out)
    if png is not None:
        _check_output(inp, png)
    if out.suffix.lower() != ".npz":
        raise MocapFormatError(out, "the detection is written as .npz")
    m = io.load(inp)
    if not isinstance(m, Motion):
        raise MocapFormatError(inp, "a marker file cannot be checked; solve it to a skeleton first")
    ctx = _load_context(context)
    det = _detect(m, ctx, threshold, progress=not as_json, confirm=confirm, jump_deg=jump_deg)
    det.save(out)
    if png is not None:
        from .report.plots import plot_mdm

        plot_mdm(det.mdm, det.joint_names, det.fps, png, flags=det.flags, title=f"{inp.name}: movement digression map")
    segs = det.segments()
    if as_json:
        print(json.dumps([{"joint": j, "start": a, "end": b, "start_s": a / m.fps, "end_s": b / m.fps} for j, a, b in segs]))
        return
    console.print(f"wrote {out}" + (f" and {png}" if png else "") + f": {len(segs)} flagged segments")
    for j, a, b in segs[:50]:
        console.print(f"  {j:16s} frames {a}-{b} ({a / m.fps:.2f}-{b / m.fps:.2f} s)")
    if len(segs) > 50:
        console.print(f"  ... and {len(segs) - 50} more")


@app.command()
def repair(
    inp: Path = typer.Argument(..., metavar="IN", help="Motion to repair (.bvh, .amc, .npz)."),
    out: Path = typer.Option(..., "--out", "-o", help="Repaired motion (.bvh or .npz)."),
    context: Optional[list[Path]] = typer.Option(
        None, "--context", help="Related clips (repeat the option) or one database folder; default: the clip itself."
    ),
    detection: Optional[Path] = typer.Option(
        None, "--detection", help="Use this detection (from `mocapkit detect`, same --context) instead of detecting again."
    ),
    threshold: float = typer.Option(0.5, "--threshold", help="MDM value above which a joint is replaced (0-1)."),
    confirm: bool = typer.Option(
        True, "--confirm/--no-confirm", help="As for detect; ignored with --detection (the file's own rule is kept)."
    ),
    jump_deg: float = typer.Option(8.0, "--jump-deg", help="As for detect (degrees)."),
    foot_skate: bool = typer.Option(True, "--foot-skate/--no-foot-skate", help="Pin planted feet on repaired frames."),
) -> None:
    """Replace only the flagged joints in flagged frames by the median of their nearest motion words."""
    from . import io
    from .cleaning import ssa
    from .motion import Motion

    _check_output(inp, out)
    m = io.load(inp)
    if not isinstance(m, Motion):
        raise MocapFormatError(inp, "a marker file cannot be repaired; solve it to a skeleton first")
    ctx = _load_context(context)
    if detection is not None:
        det = ssa.Detection.load(detection).with_threshold(threshold)
    else:
        det = _detect(m, ctx, threshold, confirm=confirm, jump_deg=jump_deg)
    try:
        fixed = ssa.repair(m, det, ctx, foot_skate=foot_skate)
    except ValueError as exc:
        raise MocapError(f"{inp}: {exc}") from None
    io.save(fixed, out)
    n = int(det.flags.sum())
    console.print(f"wrote {out}: {n} joint samples replaced in {int(det.flags.any(axis=1).sum())} of {m.num_frames} frames")


def _deep_motion(inp: Path):
    from . import io
    from .motion import Motion

    m = io.load(inp)
    if not isinstance(m, Motion):
        raise MocapFormatError(inp, "a marker file has no joint angles; solve it to a skeleton first")
    return m


def _deep_model(path: Optional[Path], kind: str):
    """The model file at ``path`` (checked here so its errors name it), or None for the shipped one."""
    from .cleaning import deep

    if path is None:
        return None
    model = deep.load_model(path)
    if model.kind != kind:
        raise MocapFormatError(path, f"an {model.kind.upper()} model, but this command needs an {kind.upper()}")
    return model


def _reference(ref_path: Path, like):
    """The clean take at ``ref_path``, checked to have ``like``'s joints and frame count."""
    ref = _deep_motion(ref_path)
    if ref.num_frames != like.num_frames or ref.skeleton.joint_names != like.skeleton.joint_names:
        raise MocapFormatError(ref_path, "the reference must have the input's joints and frame count")
    return ref


def _reference_report(ref_path: Optional[Path], before, after) -> str:
    """' (RMS vs REF: a -> b deg)' over the non-root joint-angle channels, or '' without a reference."""
    if ref_path is None:
        return ""
    from .metrics import joint_angle_rms

    ref = _reference(ref_path, after)
    a = joint_angle_rms(ref, before, include_root=False)
    b = joint_angle_rms(ref, after, include_root=False)
    return f"; joint-angle RMS against {ref_path.name}: {a:.2f} -> {b:.2f} deg"


@app.command()
def denoise(
    inp: Path = typer.Argument(..., metavar="IN", help="Noisy motion (.bvh, .amc, .npz)."),
    out: Path = typer.Option(..., "--out", "-o", help="Denoised motion (.bvh or .npz)."),
    model: Optional[Path] = typer.Option(None, "--model", help="An EBF model file (default: the shipped one)."),
    reference: Optional[Path] = typer.Option(None, "--reference", help="A clean take to report the error against."),
) -> None:
    """Denoise every joint angle with the EBF network (Mall et al. 2017); the root trajectory is kept."""
    from . import io
    from .cleaning import deep
    from .metrics import joint_angle_rms

    _check_output(inp, out)
    m = _deep_motion(inp)
    net = _deep_model(model, "ebf")
    try:
        cleaned = deep.denoise(m, net)
    except SkeletonError as exc:
        raise MocapError(f"{inp}: {exc}") from None
    report = _reference_report(reference, m, cleaned)
    io.save(cleaned, out)
    change = joint_angle_rms(m, cleaned, include_root=False)
    console.print(f"wrote {out}: {m.num_frames} frames denoised, mean change {change:.2f} deg RMS{report}")


@app.command()
def fill(
    inp: Path = typer.Argument(..., metavar="IN", help="Motion with gaps (NaN joints in .npz; or any format)."),
    out: Path = typer.Option(..., "--out", "-o", help="Filled motion (.bvh or .npz)."),
    model: Optional[Path] = typer.Option(None, "--model", help="An EBD model file (default: the shipped one)."),
    denoiser: Optional[Path] = typer.Option(None, "--denoiser", help="The EBF that smooths the filled entries."),
    smooth: bool = typer.Option(True, "--smooth/--no-smooth", help="Run the EBF over the filled entries."),
    reference: Optional[Path] = typer.Option(None, "--reference", help="A clean take to report the error against."),
) -> None:
    """Fill missing joints with the EBD network (+ EBF); observed values are kept bit-identical."""
    from . import io
    from .cleaning import deep

    _check_output(inp, out)
    m = _deep_motion(inp)
    ebd, ebf = _deep_model(model, "ebd"), _deep_model(denoiser, "ebf")
    n = int(m.missing().sum())
    try:
        filled = deep.fill_gaps(m, ebd, ebf, smooth=smooth)
    except (SkeletonError, ValueError) as exc:
        raise MocapError(f"{inp}: {exc}") from None
    report = ""
    if reference is not None and n:
        from .metrics import geodesic_pose_distance

        ref = _reference(reference, filled)
        err = np.degrees(geodesic_pose_distance(ref, filled))[m.missing()]
        report = f"; mean rotation error of the filled joints against {reference.name}: {err.mean():.2f} deg"
    io.save(filled, out)
    console.print(f"wrote {out}: {n} missing joint samples filled{report}" if n else f"wrote {out}: no gaps to fill")


@app.command()
def train(
    what: str = typer.Argument(..., metavar="denoiser|gapfiller", help="Train the EBF denoiser or the EBD gap filler."),
    sources: list[Path] = typer.Argument(..., metavar="CLIPS...", help="Motion files, folders or database folders."),
    out: Path = typer.Option(..., "--out", "-o", help="Folder for checkpoint.pt and model.pt."),
    holdout: Optional[list[str]] = typer.Option(
        None, "--holdout", help="Validation clips: a name substring (repeat) or a count of random clips."
    ),
    folds: int = typer.Option(1, "--folds", min=1, help="Cross-validate on this many disjoint random holdouts (Mall: 5)."),
    epochs: int = typer.Option(40, "--epochs", min=1),
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
    init: str = typer.Option("xavier", "--init", help="xavier (the shipped models') or paper (uniform [-0.5, 0.5])."),
    seed: int = typer.Option(0, "--seed"),
    resume: bool = typer.Option(True, "--resume/--restart", help="Continue from out/checkpoint.pt if present."),
    executor: Optional[str] = typer.Option(None, "--executor", help="Where noisy pairs are made: processes, serial, dask or a scheduler address."),
    device: str = typer.Option("auto", "--device", help="auto (a GPU when present), cpu or cuda."),
) -> None:
    """Train an EBF or EBD on noisy/clean pairs made on the fly with mocapkit.corrupt (Mall et al. 2017, 4).

    Writes OUT/model.pt (the best epoch on the validation clips) and OUT/checkpoint.pt after every
    epoch; running the same command again resumes. With --folds K, OUT/fold_1 ... OUT/fold_K.
    """
    from .cleaning.deep import training

    kinds = {"denoiser": "ebf", "gapfiller": "ebd"}
    if what not in kinds:
        raise MocapError(f"train: expected denoiser or gapfiller, got {what!r}")
    if representation not in ("euler", "rot6d") or head not in ("gaussian", "free") or init not in ("xavier", "paper"):
        raise MocapError("train: --representation is euler or rot6d, --head gaussian or free, --init xavier or paper")
    if noise:
        from .cleaning.deep.training import noisy_motion

        for spec in noise:
            try:
                noisy_motion(None, spec, 0, check_only=True)
            except ValueError as exc:
                raise MocapError(f"train: --noise: {exc}") from None
    if not (0 < speed[0] <= speed[1]) or not offset >= 0 or not 0 <= patchy <= 1:
        raise MocapError(f"train: --speed needs 0 < LO <= HI (got {speed[0]:g} {speed[1]:g}), --offset >= 0 "
                         f"and --patchy in [0, 1] (got {patchy:g})")
    clips = training.load_clips(sources)
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
        splits, outs = [training.split_holdout(clips, hold, seed=seed)], [out]
    cfg = training.TrainConfig(
        kind=kinds[what], representation=representation, hidden=hidden, head=head, bias=bias,
        noise_input=noise_input, epochs=epochs, steps_per_epoch=steps, minutes=minutes, seed=seed, device=device, lr=lr, dropout=dropout,
        init=init, speed_range=(float(speed[0]), float(speed[1])), offset=offset, patchy=patchy,
        **({"noise": tuple(noise)} if noise else {}),
    )
    bests = []
    for (tr, val), o in zip(splits, outs):
        if not tr:
            raise MocapError("train: every clip is held out; nothing left to train on")
        try:
            model = training.train(tr, o, cfg, validation=val or None, resume=resume, executor=executor)
        except (SkeletonError, ValueError) as exc:
            raise MocapError(f"train: {exc}") from None
        h = model.meta["history"]
        bests.append(min(x["val_rmse"] for x in h))
        what_rms = "validation" if val else "training"
        console.print(f"wrote {o / 'model.pt'}: {len(tr)} clips, {len(h)} epochs, best {what_rms} RMS {bests[-1]:.3f}")
    if folds > 1:
        console.print(f"{folds} holdouts: validation RMS {np.mean(bests):.3f} +- {np.std(bests):.3f}")


_SIX_MARKERS = ("left_hand", "right_hand", "left_foot", "right_foot", "head")


def _default_use(sk) -> str:
    """Krüger's six markers (2010, sec. 5.2): the four end effectors, the head and the root."""
    from .motion import find_joint

    return ",".join([sk.joint_names[find_joint(sk, role)] for role in _SIX_MARKERS] + [sk.joint_names[0]])


def _performer_skeleton(path: Optional[Path], source, db):
    """--skeleton, else the control motion's own skeleton when it fits the database, else None (the database's)."""
    from . import io
    from .io.asfamc import read_asf
    from .motion import Motion

    if path is not None:
        sk = read_asf(path) if path.suffix.lower() == ".asf" else io.load(path)
        sk = sk.skeleton if isinstance(sk, Motion) else sk
        if not hasattr(sk, "joint_names") or not sk.is_compatible(db.skeletons[0]):
            raise MocapFormatError(path, "not a skeleton with the database's joints")
        return sk
    if isinstance(source, Motion) and source.skeleton.is_compatible(db.skeletons[0]):
        return source.skeleton
    return None


@app.command()
def reconstruct(
    db_dir: Path = typer.Option(..., "--db", help="The knowledge base: a database folder (`mocapkit db build`)."),
    out: Path = typer.Option(..., "--out", "-o", help="Reconstructed full-body motion (.bvh or .npz)."),
    markers: Optional[Path] = typer.Option(
        None, "--markers", help="A few marker trajectories (.c3d, marker .npz, or a motion whose joints become markers): local linear models (Krüger 2010, 5.2)."
    ),
    accelerometers: Optional[Path] = typer.Option(
        None, "--accelerometers", help="Accelerometer CSV (time,<sensor>.x,.y,.z,... in s and m/s^2), or a motion to simulate them on: online LNG + kernel priors (Tautges ch. 3)."
    ),
    ssg: Optional[Path] = typer.Option(
        None, "--ssg", help="Marker trajectories with gaps (.c3d, marker .npz, or a motion): the subsequence graph (Tautges ch. 4)."
    ),
    use: Optional[str] = typer.Option(
        None, "--use", help="Markers as LABEL[=JOINT],... (default for a motion: hands, feet, head and root)."
    ),
    up_axis: Optional[str] = typer.Option(None, "--up-axis", help="Vertical axis of a marker file (default z, the C3D convention)."),
    skeleton: Optional[Path] = typer.Option(
        None, "--skeleton", help="The performer's skeleton (.asf, or a motion file), same joints as the database; default: the input motion's, else the database's."
    ),
    reference: Optional[Path] = typer.Option(None, "--reference", help="The true motion, to report the joint-position error against."),
) -> None:
    """Reconstruct full-body motion from sparse control signals and a motion database."""
    from . import io
    from .database import MotionDatabase
    from .io.c3d import MarkerSet
    from .motion import Motion

    given = [(k, p) for k, p in (("markers", markers), ("accelerometers", accelerometers), ("ssg", ssg)) if p is not None]
    if len(given) != 1:
        raise MocapError("give exactly one of --markers, --accelerometers or --ssg")
    kind, inp = given[0]
    _check_output(inp, out)
    io.suffix_kind(out, io.WRITERS, "writing")
    db = MotionDatabase.open(db_dir)
    if kind == "accelerometers":
        from .reconstruct import accelerometers as acc
    if kind == "accelerometers" and inp.suffix.lower() == ".csv":
        from .io.readings import read_readings_csv

        times, readings, names = read_readings_csv(inp)
        source = None
        fps = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 else db.fps
        sensors = _sensors_named(names, db, inp)
    else:
        source = io.load(inp)
        if kind == "accelerometers" and not isinstance(source, Motion):
            raise MocapFormatError(inp, "accelerometers come as a CSV (or a motion to simulate them on), not markers")
    performer = _performer_skeleton(skeleton, source, db)
    try:
        if kind == "accelerometers":
            if source is not None:
                from .features import virtual_accelerometers

                readings, fps, sensors = virtual_accelerometers(source), source.fps, None
            what = f"{readings.shape[1]} accelerometers"
            result = acc.reconstruct(readings, db, fps, sensors, skeleton=performer, progress=True)
        else:
            from .reconstruct.control import control_markers

            if use is None and isinstance(source, MarkerSet):
                raise MocapFormatError(inp, "a marker file needs --use LABEL=JOINT,... to say which joint each marker sits on")
            spec = use if use is not None else _default_use(source.skeleton)
            pos, joints, fps = control_markers(source, spec, db.skeletons[0], up_axis=up_axis)
            what = f"{len(joints)} markers ({', '.join(joints)})"
            if kind == "markers":
                from .reconstruct import markers as method
            else:
                from .reconstruct import ssg as method
            result = method.reconstruct(pos, joints, db, fps, skeleton=performer, progress=True)
    except ValueError as exc:
        raise MocapError(f"{inp}: {exc}") from None
    report = ""
    if reference is not None:
        from .metrics import joint_position_rms

        ref = _deep_motion(reference)
        if ref.num_frames != result.num_frames or not ref.skeleton.is_compatible(result.skeleton):
            raise MocapFormatError(reference, f"the reference must have the database's joints and {result.num_frames} frames")
        # accelerometers see no heading: their error is measured with each motion's heading removed
        frame = "heading" if kind == "accelerometers" else True
        err = joint_position_rms(ref, result, root_relative=frame)
        how = "root and heading removed" if kind == "accelerometers" else "root-relative"
        report = f"; joint-position RMS against {reference.name} ({how}): {err:.2f} cm"
    io.save(result, out)
    console.print(f"wrote {out}: {result.num_frames} frames @ {result.fps:g} fps from {what}{report}")


def _sensors_named(names, db, path: Path):
    """The database skeleton's default sensors in the CSV's column order."""
    from .features import default_sensors

    table = {s.name: s for s in default_sensors(db.skeletons[0])}
    unknown = [n for n in names if n not in table]
    if unknown:
        raise MocapFormatError(path, f"unknown sensor(s) {', '.join(unknown)}; known: {', '.join(table)}")
    return [table[n] for n in names]


_CLEAN_STEPS_HELP = "Comma-separated steps: fill, detect, repair, denoise (they always run in that order)."


def _clean_steps(text: str) -> list[str]:
    from .cleaning.pipeline import parse_steps

    try:
        return list(parse_steps(text))
    except ValueError as exc:
        raise MocapError(f"--steps: {exc}") from None


@app.command()
def clean(
    inp: Path = typer.Argument(..., metavar="IN", help="Motion to clean (.bvh, .amc, .npz)."),
    out: Path = typer.Option(..., "--out", "-o", help="Cleaned motion (.bvh or .npz); OUT's stem + .clean.npz is written beside it."),
    context: Optional[list[Path]] = typer.Option(
        None, "--context", help="Related clips (repeat the option) or one database folder; default: the clip itself."
    ),
    steps: str = typer.Option("fill,detect,repair,denoise", "--steps", help=_CLEAN_STEPS_HELP),
    threshold: float = typer.Option(0.5, "--threshold", help="MDM value above which a joint is flagged and repaired (0-1)."),
    report: Optional[Path] = typer.Option(None, "--report", help="Also write the self-contained HTML report here."),
    png: Optional[Path] = typer.Option(None, "--png", help="Also write a static summary figure (MDM + before/after channels)."),
    reference: Optional[Path] = typer.Option(None, "--reference", help="The clean take, to print the error before and after."),
) -> None:
    """Clean a take: fill gaps, detect and repair erroneous joints, denoise only the noisy cells.

    Writes OUT and, beside it, OUT's stem + .clean.npz (MDM, flags, the cells each step changed and
    a record per step); everything not missing, flagged or noisy stays bit-identical.
    """
    from .batch import clean_file, sigterm_as_interrupt
    from .cleaning.pipeline import clean_path

    sigterm_as_interrupt()
    step_list = _clean_steps(steps)
    ref = _deep_motion(reference) if reference is not None else None
    original, res = clean_file(inp, out, context=context, steps=step_list, threshold=threshold, report=report, png=png, progress=True)
    m = res.motion
    F = res.num_frames
    console.print(f"wrote {out} and {clean_path(out)}" + "".join(f" and {p}" for p in (report, png) if p is not None)
                  + f": {F} frames @ {m.fps:g} fps, {int(res.changed.sum())} of {res.changed.size} joint samples changed "
                  f"({100.0 * (1 - res.changed.mean()):.1f} % untouched)", soft_wrap=True)
    for line in res.summary():
        console.print(f"  {line}", markup=False, soft_wrap=True)
    if res.detection is not None:
        segs = res.detection.segments()
        for j, a, b in segs[:12]:
            console.print(f"    flagged {j:16s} frames {a}-{b} ({a / m.fps:.2f}-{b / m.fps:.2f} s)", markup=False)
        if len(segs) > 12:
            console.print(f"    ... and {len(segs) - 12} more (all in {clean_path(out)})", markup=False)
    if ref is not None:
        from .cleaning import gapfill
        from .metrics import joint_position_rms, pose_error

        if ref.num_frames != F or tuple(ref.skeleton.joint_names) != res.joint_names:
            raise MocapFormatError(reference, "the reference must have the input's joints and frame count")
        # the input's gaps are filled linearly for the "before" figure (the error of a missing joint is undefined)
        before = gapfill.fill_motion(original, "linear") if original.missing().any() else original
        e0, e1 = float(np.nanmean(pose_error(ref, before))), float(np.nanmean(pose_error(ref, m)))
        c0, c1 = joint_position_rms(ref, before), joint_position_rms(ref, m)
        gaps = " (input gaps linearly filled)" if original.missing().any() else ""
        console.print(f"  error against {reference.name}{gaps}: eq. 2 {e0:.4f} -> {e1:.4f} per frame; "
                      f"joint positions {c0:.2f} -> {c1:.2f} cm RMS", markup=False, soft_wrap=True)


@app.command("clean-batch")
def clean_batch(
    in_dir: Path = typer.Argument(..., metavar="IN_DIR", help="Folder of takes (searched recursively)."),
    out_dir: Path = typer.Argument(..., metavar="OUT_DIR", help="Folder for the cleaned takes (same layout)."),
    context: Optional[list[Path]] = typer.Option(
        None, "--context", help="Related clips (repeat the option) or one database folder; default: each clip itself."
    ),
    steps: str = typer.Option("fill,detect,repair,denoise", "--steps", help=_CLEAN_STEPS_HELP),
    threshold: float = typer.Option(0.5, "--threshold", help="MDM value above which a joint is flagged (0-1)."),
    executor: Optional[str] = typer.Option(
        None, "--executor", help="processes (default), serial, dask (a local cluster) or a Dask scheduler address."
    ),
    report: bool = typer.Option(False, "--report", help="Also write STEM.report.html beside each output."),
    png: bool = typer.Option(False, "--png", help="Also write STEM.summary.png beside each output."),
    pattern: str = typer.Option("*.bvh,*.amc,*.npz", "--pattern", help="Comma-separated file name patterns to clean."),
    fmt: str = typer.Option("auto", "--format", help="Output format: auto (.bvh and .npz kept, others -> .bvh), bvh or npz."),
    as_json: bool = typer.Option(False, "--json", help="Print the per-take rows as JSON."),
) -> None:
    """Clean every take under IN_DIR into OUT_DIR: resumable, one failing take reported and skipped.

    A take is complete when its output and STEM.clean.npz both exist (the record is written last);
    complete takes are skipped, so running the command again resumes. Exits 1 if any take failed.
    """
    from .batch import clean_batch as run_batch
    from .batch import sigterm_as_interrupt

    sigterm_as_interrupt()
    step_list = _clean_steps(steps)
    patterns = tuple(p.strip() for p in pattern.split(",") if p.strip())
    if not patterns:
        raise MocapError("--pattern: give at least one file name pattern, e.g. '*.bvh,*.amc'")
    summary = run_batch(in_dir, out_dir, context=context, steps=step_list, threshold=threshold, patterns=patterns,
                        fmt=fmt, report=report, png=png, executor=executor, progress=not as_json)
    if as_json:
        print(json.dumps({"rows": summary.rows, "seconds": summary.seconds, "executor": summary.executor}))
    else:
        for r in summary.failed:
            console.print(f"failed {r['input']}: {r['reason']}", markup=False)
        n = len(summary.rows)
        console.print(f"{n} takes on {summary.executor} in {summary.seconds:.1f} s: {summary.count('done')} cleaned, "
                      f"{summary.count('skipped')} already complete, {summary.count('failed')} failed", markup=False)
    if summary.failed:
        raise typer.Exit(1)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script: runs the app, turning user errors into one line and exit 2."""
    try:
        app(args=argv)  # standalone: usage errors print their help and exit 2 themselves
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except MocapError as exc:
        print(f"mocapkit: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except FileNotFoundError as exc:
        print(f"mocapkit: error: {exc.filename or exc}: no such file", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("mocapkit: interrupted; no partial output was left", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
