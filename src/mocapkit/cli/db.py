"""Databases and search: ``db build``, ``db info``, ``search``."""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path
from typing import Optional

import typer

from ..errors import MocapError, MocapFormatError
from .common import (FlagsCommand, FlagsGroup, amc_fps_option, asf_option, check_executor, console, database_rows,
                     executor_option, joint_map_option, plural, print_fields, print_table, unit_option)

db_app = typer.Typer(
    help="Build and inspect motion databases (the knowledge that search and cleaning compare against).",
    no_args_is_help=True,
    cls=FlagsGroup,
)


def _feature_list(text: str) -> tuple[str, ...]:
    """The feature sets ``--features`` names (comma-separated); one it does not know, or none, is refused in one
    line naming the option and the accepted values, before any work."""
    from ..features import FEATURE_SETS, WINDOWED_SETS

    names = tuple(t.strip() for t in text.split(",") if t.strip())
    known = list(FEATURE_SETS) + list(WINDOWED_SETS)
    bad = [n for n in names if n not in known]
    if bad or not names:
        got = f"got {', '.join(bad)}" if bad else f"got {text!r}"
        raise MocapError(f"--features must be one or more of {', '.join(known)} (comma-separated), {got}")
    return names


@db_app.command("build", cls=FlagsCommand)
def db_build(
    out_dir: Path = typer.Argument(..., metavar="OUT_DIR", help="Folder to create for the database."),
    files: list[Path] = typer.Argument(..., metavar="FILES...", help="Motion files (.bvh, .amc, .npz) or folders."),
    fps: float = typer.Option(30.0, "--fps", help="Frame rate every clip is resampled to."),
    mirror: bool = typer.Option(False, "--mirror", help="Also add every clip's left/right mirror image."),
    features: str = typer.Option("F15", "--features", help="Comma-separated feature sets: F15, F30, F39, F15x3, F15x5, F30x3, F39x3."),
    executor: Optional[str] = executor_option("clips are loaded"),
    joint_map: Optional[Path] = joint_map_option(),
    asf: Optional[Path] = asf_option("input(s)"),
    amc_fps: Optional[float] = amc_fps_option("input(s)"),
    overwrite: bool = typer.Option(
        False, "--overwrite",
        help="Replace OUT_DIR if it is a mocapkit database holding none of the inputs (anything else is refused). "
             "Missing parent folders are created.",
    ),
) -> None:
    """Build a motion database from FILES and save it to OUT_DIR."""
    from ..database import FPS_RANGE, MotionDatabase, check_database_output, read_joint_map
    from ..parallel import describe_executor

    if not FPS_RANGE[0] <= fps <= FPS_RANGE[1]:  # before any work, naming the option (a database's own range)
        raise MocapError(f"--fps must be a positive number from {FPS_RANGE[0]:g} to {FPS_RANGE[1]:g} (frames per second) "
                         f"for a database, got {fps:g}")
    feature_names = _feature_list(features)  # before any work, naming the option
    check_database_output(out_dir, [*files, *([joint_map] if joint_map is not None else [])], overwrite=overwrite,
                          how="pass --overwrite")
    if asf is not None or amc_fps is not None:
        from ..database import expand_sources
        from ..io.takes import CLI_AMC_NAMES, check_asf

        check_asf(asf, expand_sources(files), amc_fps, names=CLI_AMC_NAMES)
    check_executor(executor)
    jm = read_joint_map(joint_map) if joint_map is not None else None
    console.print(f"building from {plural(len(files), 'path')} on {describe_executor(executor)}")
    try:
        db = MotionDatabase.build(files, fps=fps, features=feature_names, mirror=mirror, joint_map=jm,
                                  executor=executor, asf=asf, amc_fps=amc_fps, executor_option="--executor")
    except ValueError as exc:
        raise MocapError(str(exc)) from None
    db.save(out_dir, overwrite=overwrite)
    console.print(f"wrote {out_dir}: {plural(db.num_clips, 'clip')}, {plural(db.num_frames, 'frame')} @ {db.fps:g} fps, "
                  f"features {', '.join(db.feature_names)}")
    if db.info.get("licence"):  # the takes' terms (mocapkit.rigs.data_terms), kept in database.json
        console.print(f"note: the takes are {db.info['licence']}: so is this database")


@db_app.command("info", cls=FlagsCommand)
def db_info(
    directory: Path = typer.Argument(..., metavar="DIR", help="A database folder."),
    clips: bool = typer.Option(False, "--clips", help="Also list every clip with its frame range."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of a table."),
) -> None:
    """Print the size, frame rate, features and clips of the database in DIR."""
    from ..database import MotionDatabase

    db = MotionDatabase.open(directory)
    summary = db.summary()
    gaps = db.missing_note()  # NaN poses an earlier mocapkit kept (search and reconstruct say it too)
    if as_json:
        if clips:
            summary["clip_list"] = [{"name": c.name, "start": c.start, "frames": c.frames, "source": c.source} for c in db.clips]
        if gaps:
            summary["missing_frames"] = db.missing_frames()
        print(json.dumps(summary))
        return
    print_fields(database_rows(summary))
    if clips:
        print_table(("#", "clip", "first frame", "frames", "source"),
                    ((k, c.name, c.start, c.frames, c.source) for k, c in enumerate(db.clips)))
    if gaps:
        console.print(f"note: {gaps}", soft_wrap=True)


def search(
    db_dir: Path = typer.Argument(..., metavar="DB_DIR", help="A database folder (`mocapkit db build`)."),
    query: Path = typer.Argument(..., metavar="QUERY", help="Query motion (.bvh, .amc, .npz)."),
    k: int = typer.Option(10, "--k", help="Number of matches."),
    features: Optional[str] = typer.Option(None, "--features", help="Feature set (default: the database's first)."),
    neighbors: int = typer.Option(128, "--neighbors", "--neighbours",
                                  help="Nearest neighbours per query frame in the lazy neighbourhood graph."),
    method: str = typer.Option("lng", "--method", help="lng (fast, Krüger 2010) or dtw (exact subsequence DTW)."),
    start: Optional[float] = typer.Option(None, "--start", help="Use the query from this time (s)."),
    end: Optional[float] = typer.Option(None, "--end", help="Use the query up to this time (s; past its end: to its end)."),
    as_json: bool = typer.Option(False, "--json", help="Print the matches as JSON."),
    asf: Optional[Path] = asf_option("input(s)"),
    amc_fps: Optional[float] = amc_fps_option("input(s)"),
    unit: Optional[str] = unit_option("input(s)"),
) -> None:
    """Rank the database segments most similar to QUERY (numerical similarity search)."""
    from ..database import MotionDatabase
    from ..io.takes import CLI_AMC_NAMES, check_asf, load_motion

    if k < 1 or neighbors < 1:  # before any work, naming the option
        raise MocapError(f"{'--k' if k < 1 else '--neighbors'} must be a positive integer, got {min(k, neighbors)}")
    if method not in ("lng", "dtw"):  # before any work, naming the option (the database's "method must be ...")
        raise MocapError(f"--method must be lng or dtw, got {method!r}")
    check_asf(asf, [query], amc_fps, names=CLI_AMC_NAMES)
    db = MotionDatabase.open(db_dir)
    gaps = db.missing_note()  # NaN poses an earlier mocapkit kept: said, not refused (a rebuild from filled takes has none)
    m = load_motion(query, asf, purpose="a query", fps=amc_fps, unit=unit, unit_option="--unit")
    a = 0 if start is None else int(round(start * m.fps))
    b = m.num_frames if end is None else min(int(round(end * m.fps)), m.num_frames)  # --end past the clip: its end
    if not 0 <= a < b <= m.num_frames:
        raise MocapFormatError(query, f"--start/--end select no frames (clip has {plural(m.num_frames, 'frame')}, {m.duration:.2f} s)")
    try:
        with warnings.catch_warnings():  # the command words its own note on fewer matches, below
            warnings.simplefilter("ignore", UserWarning)
            results = db.search(m[a:b], k=k, features=features, neighbors=neighbors, method=method)
    except (KeyError, ValueError) as exc:
        why = str(exc.args[0] if exc.args else exc)
        if isinstance(exc, KeyError) and "no joint plays the role" in why:  # the query's rig lacks an end effector
            raise MocapFormatError(query, f"cannot compute the query's features: {why}") from None
        raise MocapError(f"{db_dir}: {why}") from None
    fewer = (f"{len(results)} of the {k} matches asked for: no other segment of the database lasts between a "
             f"third and three times the query's {(b - a) / m.fps:.2f} s (a longer or shorter one is a "
             "held pose or a pause, not the motion)") if 0 < len(results) < k else None
    if as_json:  # the JSON alone on stdout; the note on stderr
        print(json.dumps([dict(r.as_dict(), start_s=r.start / db.fps, end_s=r.end / db.fps) for r in results]))
        for note in (gaps, fewer):
            if note:
                print(f"note: {note}", file=sys.stderr)
        return
    if gaps:
        console.print(f"note: {gaps}")
    if not results:
        console.print("no match (try a larger --neighbors)")
        return
    qlen = int(round((b - a) / m.fps * db.fps))
    print_table(("#", "clip", "start", "end", "seconds", "cost", "cost/frame"),
                ((rank, r.name, r.start, r.end, f"{r.start / db.fps:.2f}-{r.end / db.fps:.2f}", f"{r.cost:.1f}",
                  f"{r.cost / max(qlen, 1):.2f}") for rank, r in enumerate(results, 1)))
    if fewer:
        console.print(fewer)
