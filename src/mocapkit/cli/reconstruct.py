"""``reconstruct``: full-body motion from sparse markers, accelerometers or gappy markers and a database."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import MissingFileError, MocapError, MocapFormatError
from .common import amc_fps_option, asf_option, console, guard, overwrite_option, plural, unit_option

# Krüger's six markers (2010, sec. 5.2): the four end effectors, the head and the root
SIX_MARKERS = ("left_hand", "right_hand", "left_foot", "right_foot", "head")


def _default_use(sk) -> str:
    from ..motion import find_joint
    from ..rigs import pelvis_index

    try:
        # the sixth marker on the pelvis by its role (Bandai Namco: Hips, not the floor-bound joint_Root)
        return ",".join([sk.joint_names[find_joint(sk, role)] for role in SIX_MARKERS] + [sk.joint_names[pelvis_index(sk)]])
    except KeyError as exc:
        raise MocapError(f"{exc.args[0]}; give the markers with --use LABEL=JOINT,...") from None


def _performer_skeleton(path: Optional[Path], source, db):
    """--skeleton, else the control motion's own skeleton when it fits the database, else None (the database's)."""
    from .. import io
    from ..io.asfamc import read_asf
    from ..motion import Motion

    if path is not None:
        sk = read_asf(path) if path.suffix.lower() == ".asf" else io.load(path)
        sk = sk.skeleton if isinstance(sk, Motion) else sk
        if not hasattr(sk, "joint_names") or not sk.is_compatible(db.skeletons[0]):
            raise MocapFormatError(path, "not a skeleton with the database's joints")
        return sk
    if isinstance(source, Motion) and source.skeleton.is_compatible(db.skeletons[0]):
        return source.skeleton
    return None


def _sensors_named(names, db, path: Path):
    """The database skeleton's default sensors in the CSV's column order."""
    from ..features import default_sensors

    table = {s.name: s for s in default_sensors(db.skeletons[0])}
    unknown = [n for n in names if n not in table]
    if unknown:
        raise MocapFormatError(path, f"unknown sensor(s) {', '.join(unknown)}; known: {', '.join(table)}")
    return [table[n] for n in names]


def reconstruct(
    db_dir: Path = typer.Option(..., "--db", help="The knowledge base: a database folder (`mocapkit db build`)."),
    out: Path = typer.Option(..., "--out", "-o", help="Reconstructed full-body motion (.bvh or .npz; .amc on an ASF skeleton, read back with that ASF)."),
    markers: Optional[Path] = typer.Option(
        None, "--markers", help="A few marker trajectories (.c3d, marker .npz, or a motion whose joints become markers): local linear models (Krüger 2010, 5.2)."
    ),
    accelerometers: Optional[Path] = typer.Option(
        None, "--accelerometers", help="Accelerometer CSV (time,<sensor>.x,.y,.z,... in s and m/s^2), or a motion to simulate them on: online LNG, the mean pose of its best paths (Tautges ch. 3)."
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
    synthesis: Optional[str] = typer.Option(
        None, "--synthesis", help="Accelerometers: the pose from the candidates: mean (default; small databases), regression (on the recent readings; better on large ones), energy (Tautges eq. 3.4)."
    ),
    neighbours: Optional[int] = typer.Option(None, "--neighbours", "--neighbors", help="Accelerometers: K nearest database frames per sample (default 1 % of the database's frames, 128-4096)."),
    smoothing: Optional[float] = typer.Option(None, "--smoothing", help="Accelerometers: causal pose smoothing a in [0, 1) (default 0)."),
    asf: Optional[Path] = asf_option(),
    amc_fps: Optional[float] = amc_fps_option(),
    unit: Optional[str] = unit_option(),
    overwrite: bool = overwrite_option(),
) -> None:
    """Reconstruct full-body motion from sparse control signals and a motion database."""
    from .. import io
    from ..database import MotionDatabase
    from ..io.c3d import MarkerSet
    from ..io.takes import check_asf, load_motion, load_take
    from ..motion import Motion
    from ..reference import check_reference, position_error_cm

    given = [(k, p) for k, p in (("markers", markers), ("accelerometers", accelerometers), ("ssg", ssg)) if p is not None]
    if len(given) != 1:
        raise MocapError("give exactly one of --markers, --accelerometers or --ssg")
    kind, inp = given[0]
    given_acc = [(o, k, v) for o, k, v in (("--synthesis", "synthesis", synthesis), ("--neighbours", "k", neighbours),
                                           ("--smoothing", "smoothing", smoothing)) if v is not None]
    acc_params = {k: v for _, k, v in given_acc}
    if acc_params and kind != "accelerometers":
        raise MocapError("--synthesis, --neighbours and --smoothing apply to --accelerometers only")
    if given_acc:
        from ..reconstruct.accelerometers import check_params
    for option, key, value in given_acc:  # the method's own rule, before anything is read or written
        try:
            check_params({key: value})
        except ValueError as e:
            raise MocapError(f"{option}: {e}") from None
    guard([out], [inp, db_dir, skeleton, reference, asf], overwrite)
    check_asf(asf, [inp, reference], amc_fps)
    io.suffix_kind(out, io.WRITERS, "writing")
    if out.suffix.lower() == ".amc":  # an AMC is read with its actor's ASF beside it: a database keeps none
        raise MocapFormatError(out, "a reconstruction is written as .bvh or .npz (an AMC needs its skeleton's ASF "
                                    "beside it, which a database does not keep)")
    if not inp.is_file():  # as every reader says it (the CSV reader would say "cannot read the file: [Errno 2] ...")
        raise (MocapFormatError(inp, "not a regular file") if inp.exists() else MissingFileError(inp))
    db = MotionDatabase.open(db_dir)
    if kind == "accelerometers":
        from ..reconstruct import accelerometers as acc
    if kind == "accelerometers" and inp.suffix.lower() == ".csv":
        from ..io.readings import read_readings_csv

        times, readings, names = read_readings_csv(inp)
        source = None
        fps = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 else db.fps
        sensors = _sensors_named(names, db, inp)
    else:
        source = load_take(inp, asf, fps=amc_fps, unit=unit)
        if kind == "accelerometers" and not isinstance(source, Motion):
            raise MocapFormatError(inp, "accelerometers come as a CSV (or a motion to simulate them on), not markers")
    performer = _performer_skeleton(skeleton, source, db)
    if kind == "accelerometers":
        if source is not None:
            from ..features import virtual_accelerometers

            readings, fps, sensors = virtual_accelerometers(source), source.fps, None
        what = plural(readings.shape[1], "accelerometer")
        frames = readings.shape[0]
    else:
        from ..reconstruct.control import control_markers

        if use is None and isinstance(source, MarkerSet):
            raise MocapFormatError(inp, "a marker file needs --use LABEL=JOINT,... to say which joint each marker sits on")
        spec = use if use is not None else _default_use(source.skeleton)
        try:
            pos, joints, fps = control_markers(source, spec, db.skeletons[0], up_axis=up_axis)
        except ValueError as exc:
            raise MocapError(f"{inp}: {exc}") from None
        what = f"{plural(len(joints), 'marker')} ({', '.join(joints)})"
        frames = pos.shape[0]
    ref = None
    if reference is not None:  # checked before the (long) reconstruction
        ref = check_reference(load_motion(reference, asf, purpose="a reference", fps=amc_fps, unit=unit), reference,
                              frames=frames,
                              skeleton=db.skeletons[0], whose=f"the reconstruction's ({db_dir.name}'s skeleton)")
    try:
        if kind == "accelerometers":
            result = acc.reconstruct(readings, db, fps, sensors, skeleton=performer, progress=True, **acc_params)
        else:
            if kind == "markers":
                from ..reconstruct import markers as method
            else:
                from ..reconstruct import ssg as method
            result = method.reconstruct(pos, joints, db, fps, skeleton=performer, progress=True)
    except ValueError as exc:
        raise MocapError(f"{inp}: {exc}") from None
    report = ""
    if ref is not None:
        check_reference(ref, reference, frames=result.num_frames, skeleton=result.skeleton,
                        whose=f"the reconstruction's ({db_dir.name}'s skeleton)")
        # accelerometers see no heading: their error is measured with each motion's heading removed
        heading = kind == "accelerometers"
        err = position_error_cm(ref, result, heading=heading)
        how = "root and heading removed" if heading else "root-relative"
        report = f"; joint-position RMS against {reference.name} ({how}): {err:.2f} cm"
    io.save(result, out, like=False, copy_asf=False)
    console.print(f"wrote {out}: {plural(result.num_frames, 'frame')} @ {result.fps:g} fps from {what}{report}")
    if isinstance(source, Motion) and not source.skeleton.is_compatible(result.skeleton):
        console.print(f"note: the body is the database's skeleton ({result.skeleton.num_joints} joints), not "
                      f"{inp.name}'s: the sensors' readings come from any rig, the poses from the database")
