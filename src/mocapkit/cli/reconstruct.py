"""``reconstruct``: full-body motion from sparse markers, accelerometers or gappy markers and a database."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import MissingFileError, MocapError, MocapFormatError
from .common import (amc_fps_option, asf_option, console, guard, overwrite_option, plural, unit_option,
                     warnings_as_notes)

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


def _drop_unseen(pos, joints, spec: str):
    """Markers (F, M, 3) and joints without those never seen in the take, and the ``LABEL (joint)`` of the dropped.

    A marker empty in every frame says nothing; counting it as used would
    claim a fit it did not make. The others still carry the reconstruction,
    so it goes on without it and says so (a mislabelled --use shows up there).
    """
    import numpy as np

    from ..reconstruct.control import parse_use

    seen = np.isfinite(pos).all(axis=-1).any(axis=0)
    labels = [a for a, _ in parse_use(spec)]
    unseen = [f"{a} ({j})" for a, j, ok in zip(labels, joints, seen) if not ok]
    return pos[:, seen], [j for j, ok in zip(joints, seen) if ok], unseen


def _asf_for_amc(out: Path, skeleton: Optional[Path], performer, source, inp: Path, asf: Optional[Path], overwrite: bool):
    """The ASF an ``.amc`` output is read back with (None for other outputs), checked before any work.

    The body is written on the performer's skeleton: ``--skeleton X.asf``, or
    an ``.amc`` input's own (read with its ASF). On the database's skeleton
    there is no ASF file to read an AMC with: refused in one line.
    """
    if out.suffix.lower() != ".amc":
        return None
    from ..io.takes import asf_for_output, asf_of

    if skeleton is not None and skeleton.suffix.lower() == ".asf":
        found = skeleton
    elif skeleton is None and performer is not None and getattr(source, "skeleton", None) is performer:
        found = asf_of(inp, asf)
    else:
        found = None
    if found is None:
        raise MocapFormatError(out, "an .amc is read with its skeleton's ASF, and this body's skeleton has none "
                                    "(give --skeleton PERFORMER.asf, or write .bvh or .npz)")
    asf_for_output(out, found, overwrite, how="use --overwrite")  # where it is copied, refused now if that would lose a file
    return found


def _write(result, out: Path, asf_file: Optional[Path], overwrite: bool, method: str, licence: Optional[str]) -> None:
    """Save the reconstruction (an npz that says what it holds, the database takes' ``licence`` among it); an
    ``.amc`` with its ASF beside it (copied when the folder lacks it)."""
    from ..io.outputs import removed_on_failure
    from ..io.takes import asf_for_output, place_asf
    from ..reconstruct.output import save_reconstruction

    notes: list[str] = []  # what OUT cannot hold of the poses (a bone of fewer dofs turned about others)
    if asf_file is None:
        with warnings_as_notes(notes):
            save_reconstruction(result, out, method, licence=licence)
    else:
        from ..io.amc_writer import check_amc_writable

        check_amc_writable(result, out)
        copy = asf_for_output(out, asf_file, overwrite, how="use --overwrite")
        with removed_on_failure([copy, out], overwrite=overwrite):
            place_asf(copy, asf_file)
            with warnings_as_notes(notes):
                save_reconstruction(result, out, method, asf=asf_file, licence=licence)
        if copy is not None:
            console.print(f"copied the skeleton {asf_file} to {copy}: an AMC is read with the ASF beside it")
    for note in notes:
        console.print(f"note: {note}")


def _sensors_named(names, db, path: Path):
    """The database skeleton's default sensors in the CSV's column order."""
    from ..features import default_sensors

    table = {s.name: s for s in default_sensors(db.skeletons[0])}
    unknown = [n for n in names if n not in table]
    if unknown:
        raise MocapFormatError(path, f"unknown sensor(s) {', '.join(unknown)}; known: {', '.join(table)}")
    return [table[n] for n in names]


def _nan_database_line(db, db_dir: Path) -> str:
    """The one line that refuses a reconstruction which failed on, or returned, the NaN poses a database of mocapkit
    0.14.0 or earlier kept for a take with gaps (:meth:`~mocapkit.database.MotionDatabase.missing_frames`): numpy's
    "Eigenvalues did not converge" under --markers, NaN frames under --ssg and --accelerometers. Nothing is written."""
    n = db.missing_frames()
    return (f"{db_dir}: {plural(n, 'frame')} of {db.num_frames} {'has' if n == 1 else 'have'} missing joints (NaN, "
            "kept by mocapkit 0.14.0 or earlier) and the reconstruction failed on them; rebuild the database with "
            "`mocapkit db build` (`mocapkit fill` a take with gaps first); nothing written")


def _reference_report(ref, result, reference: Path) -> tuple[str, dict]:
    """The ``--reference`` figures of a result that does not place the body (accelerometers, a multilinear model):
    root and heading removed, the pelvis's height and the joints above it (:func:`mocapkit.reference.unplaced_errors_cm`),
    and every joint named as compared: the line's tail and the JSON's keys."""
    from ..reference import position_error_cm, unplaced_errors_cm

    err = position_error_cm(ref, result, heading=True)
    how = "root and heading removed"
    report = f"; joint-position RMS against {reference.name} ({how}): {err:.2f} cm"
    errors = {"reference": str(reference), "joint_position_rms_cm": err, "joint_position_rms_is": how}
    unplaced = unplaced_errors_cm(ref, result)
    report += f"; pelvis height {unplaced['pelvis_height_rms_cm']:.2f} cm"
    if "above_pelvis" in unplaced:
        where = ("where the reference holds it still" if unplaced["above_pelvis_is"].startswith("held")
                 else "in the pelvis's ground frame")
        report += f", {' and '.join(unplaced['above_pelvis'])} {unplaced['above_pelvis_rms_cm']:.2f} cm ({where})"
    errors.update(unplaced)
    return report, errors


def _reconstruct_multilinear(model_path: Path, kind: str, inp: Path, out: Path, skeleton: Optional[Path],
                             reference: Optional[Path], as_json: bool, asf: Optional[Path], amc_fps: Optional[float],
                             unit: Optional[str], overwrite: bool, use: Optional[str], up_axis: Optional[str],
                             unused: list[str]) -> None:
    """``reconstruct --multilinear MODEL``: the model's mode weights and time map fitted to global gravity-free
    accelerations (Tautges 2012, secs. 2.3-2.4), the fitted motion written to OUT. ``--accelerometers TAKE``: the
    four default sensors simulated on TAKE, turned into the world frame by their orientations (sec. 2.3.1);
    ``--markers FILE``: the markers' own accelerations at the joints they sit on (the fit sees no position)."""
    from .. import io
    from ..features import default_sensors
    from ..io.c3d import MarkerSet
    from ..io.takes import CLI_AMC_NAMES, check_asf, load_motion, load_take
    from ..motion import Motion
    from ..reconstruct.multilinear import marker_accelerations, simulated_readings
    from ..reconstruct.multilinear_file import load_model
    from ..reconstruct.output import laid_out_like
    from ..reference import check_reference

    if kind == "ssg":
        raise MocapError("--multilinear fits accelerations: give the take as --accelerometers or --markers, not --ssg "
                         "(Tautges 2012, ch. 2)")
    unused += [o for o, v in (("--use", use), ("--up-axis", up_axis)) if v is not None and kind == "accelerometers"]
    if unused:
        raise MocapError(f"{', '.join(unused)} {'does' if len(unused) == 1 else 'do'} not apply to --multilinear"
                         + (" --accelerometers" if kind == "accelerometers" else ""))
    guard([out], [inp, model_path, skeleton, reference, asf], overwrite)
    check_asf(asf, [inp, reference], amc_fps, names=CLI_AMC_NAMES)
    io.suffix_kind(out, io.WRITERS, "writing")
    if inp.suffix.lower() == ".csv":
        raise MocapFormatError(inp, "a readings CSV holds each sensor's own frame, and a multilinear model is fitted "
                                    "to global accelerations, which need the sensors' orientations (Tautges 2012, "
                                    "sec. 2.3.1): give a motion to simulate the sensors on")
    if not inp.is_file():
        raise (MocapFormatError(inp, "not a regular file") if inp.exists() else MissingFileError(inp))
    model, desc = load_model(model_path, progress=not as_json)
    source = load_take(inp, asf, fps=amc_fps, unit=unit, unit_option="--unit")
    if kind == "accelerometers" and not isinstance(source, Motion):
        raise MocapFormatError(inp, "accelerometers are simulated on a motion, not on markers (give it as --markers)")
    if isinstance(source, Motion) and not source.skeleton.is_compatible(model.skeleton_):
        raise MocapFormatError(inp, f"its joints differ from the model's ({model_path.name}: "
                                    f"{model.skeleton_.num_joints} joints); a model fits takes of its own rig")
    performer = source.skeleton if isinstance(source, Motion) else model.skeleton_
    if skeleton is not None:
        from ..io.asfamc import read_asf

        sk = read_asf(skeleton) if skeleton.suffix.lower() == ".asf" else io.load(skeleton)
        sk = sk.skeleton if isinstance(sk, Motion) else sk
        if not hasattr(sk, "joint_names") or not sk.is_compatible(model.skeleton_):
            raise MocapFormatError(skeleton, "not a skeleton with the model's joints")
        performer = sk
    asf_file = _asf_for_amc(out, skeleton, performer if isinstance(source, Motion) else None, source, inp, asf,
                            overwrite)
    notes: list[str] = []
    if kind == "accelerometers":
        sensors, readings, orient = simulated_readings(source)  # the IMUs' readings and orientations (sec. 2.3.1)
        fps, what = source.fps, plural(len(sensors), "accelerometer")
        sensors = default_sensors(performer, up_axis=model.up_)  # the same four on the body the model animates
    else:
        from ..reconstruct.control import control_markers

        if use is None and isinstance(source, MarkerSet):
            raise MocapFormatError(inp, "a marker file needs --use LABEL=JOINT,... to say which joint each marker sits on")
        spec = use if use is not None else _default_use(source.skeleton)
        said: list[str] = []
        try:
            with warnings_as_notes(said):
                pos, joints, fps = control_markers(source, spec, model.skeleton_, up_axis=up_axis, option="--up-axis")
        except ValueError as exc:
            raise MocapError(f"{inp}: {exc}") from None
        pos, joints, unseen = _drop_unseen(pos, joints, spec)
        if not joints:
            raise MocapFormatError(inp, f"no marker named in --use is seen in any frame ({', '.join(unseen)})")
        notes += said + ([f"{', '.join(unseen)} never seen in {inp.name}: left out"] if unseen else [])
        readings, orient, sensors = marker_accelerations(pos, fps, model.skeleton_), None, joints
        what = f"{plural(len(joints), 'marker')} ({', '.join(joints)})"
    frames = readings.shape[0]
    if frames < 5:
        raise MocapFormatError(inp, f"{plural(frames, 'frame')}: a fit needs at least 5")
    ref = None
    if reference is not None:  # checked before the (long) fit
        ref = check_reference(load_motion(reference, asf, purpose="a reference", fps=amc_fps, unit=unit,
                                          unit_option="--unit"), reference, frames=frames,
                              skeleton=model.skeleton_, whose=f"the model's ({model_path.name})", option="--unit")
    try:
        weights, result, info = model.fit_readings(readings, fps, sensors=sensors, orientations=orient,
                                                   skeleton=performer, return_info=True)
    except ValueError as exc:
        raise MocapError(f"{inp}: {exc}") from None
    if isinstance(source, Motion):
        result = laid_out_like(result, source, follow=False)  # the joints above the pelvis as the take has them
    report, errors = "", {}
    if ref is not None:
        report, errors = _reference_report(ref, result, reference)
        compared = list(result.skeleton.joint_names)
        report += f"; compared: all {len(compared)} joints of {reference.name}"
        errors.update(compared=compared)
    licence = desc.get("licence")
    if licence:
        notes.append(f"the poses come from {model_path}, built from takes under {licence}: so is {out.name}")
    _write(result, out, asf_file, overwrite, "multilinear", licence)
    grid = " x ".join(f"{m} ({len(e)})" for m, e in zip(desc["modes"], desc["entries"]))
    fit = (f"multilinear model {model_path.name} ({desc.get('class') or 'one class'}, {grid}); acceleration "
           f"distance {info['relative_distance']:.3f} of the readings' (the class mean {info['mean_distance']:.3f})")
    if as_json:
        import json

        print(json.dumps({"out": str(out), "frames": result.num_frames, "fps": result.fps, "method": "multilinear",
                          "from": what, "model": str(model_path),
                          "weights": {m: [round(float(x), 6) for x in w] for m, w in zip(model.modes_, weights)},
                          "relative_distance": info["relative_distance"], "mean_distance": info["mean_distance"],
                          **errors, "notes": notes}))
        return
    console.print(f"wrote {out}: {plural(result.num_frames, 'frame')} @ {result.fps:g} fps from {what}, {fit}{report}")
    for note in notes:
        console.print(f"note: {note}")


def reconstruct(
    db_dir: Optional[Path] = typer.Option(None, "--db", help="The knowledge base: a database folder (`mocapkit db build`); or give --multilinear."),
    multilinear: Optional[Path] = typer.Option(None, "--multilinear", help="Instead of --db: a multilinear model of the take's motion class (`mocapkit multilinear build`), fitted to the accelerations of --accelerometers or of --markers (Tautges ch. 2)."),
    out: Path = typer.Option(..., "--out", "-o", help="Reconstructed full-body motion (.bvh or .npz; .amc when the body is on an ASF's skeleton: --skeleton X.asf, or an .amc input; the ASF is copied beside it)."),
    markers: Optional[Path] = typer.Option(
        None, "--markers", help="A few marker trajectories (.c3d, .trc, marker .npz, or a motion whose joints become markers): local linear models (Krüger 2010, 5.2)."
    ),
    accelerometers: Optional[Path] = typer.Option(
        None, "--accelerometers", help="Accelerometer CSV (time,<sensor>.x,.y,.z,... in s and m/s^2), or a motion to simulate them on: online LNG, the mean pose of its best paths (Tautges ch. 3)."
    ),
    ssg: Optional[Path] = typer.Option(
        None, "--ssg", help="Marker trajectories with gaps (.c3d, .trc, marker .npz, or a motion): the subsequence graph (Tautges ch. 4)."
    ),
    use: Optional[str] = typer.Option(
        None, "--use", help="Markers as LABEL[=JOINT],... (default for a motion: hands, feet, head and root)."
    ),
    up_axis: Optional[str] = typer.Option(None, "--up-axis", help="Vertical axis of a marker file (default z, the C3D convention; an OpenSim .trc is y: a note says when the markers stand along another axis)."),
    skeleton: Optional[Path] = typer.Option(
        None, "--skeleton", help="The performer's skeleton (.asf, or a motion file), same joints as the database; default: the input motion's, else the database's."
    ),
    reference: Optional[Path] = typer.Option(None, "--reference", help="The true motion, to report the joint-position error against."),
    synthesis: Optional[str] = typer.Option(
        None, "--synthesis", help="Accelerometers: the pose from the candidates: mean (default; small databases), regression (on the recent readings; better on large ones), energy (Tautges eq. 3.4)."
    ),
    neighbours: Optional[int] = typer.Option(None, "--neighbours", "--neighbors", help="Accelerometers: K nearest database frames per sample (default 1 % of the database's frames, 128-4096)."),
    smoothing: Optional[float] = typer.Option(None, "--smoothing", help="Accelerometers: causal pose smoothing a in [0, 1) (default 0)."),
    knowledge: Optional[Path] = typer.Option(
        None, "--knowledge", help="Accelerometers: a folder for the database's knowledge base, built and saved there on the first run, opened memory-mapped on later ones (rebuilt when the database changes)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object (output, frames, rate, markers used and left out, errors) instead of the summary line."),
    asf: Optional[Path] = asf_option(),
    amc_fps: Optional[float] = amc_fps_option(),
    unit: Optional[str] = unit_option(),
    overwrite: bool = overwrite_option(),
) -> None:
    """Reconstruct full-body motion from sparse control signals and a motion database."""
    from .. import io
    from ..database import MotionDatabase
    from ..io.c3d import MarkerSet
    from ..io.takes import CLI_AMC_NAMES, check_asf, load_motion, load_take
    from ..motion import Motion, unit_scale_cm
    from ..reference import check_reference, global_errors_cm, position_error_cm, skeleton_error_cm

    given = [(k, p) for k, p in (("markers", markers), ("accelerometers", accelerometers), ("ssg", ssg)) if p is not None]
    if len(given) != 1:
        raise MocapError("give exactly one of --markers, --accelerometers or --ssg")
    kind, inp = given[0]
    if (db_dir is None) == (multilinear is None):
        raise MocapError("give exactly one knowledge base: --db DB_DIR (a database) or --multilinear MODEL (a model)")
    if multilinear is not None:
        return _reconstruct_multilinear(
            multilinear, kind, inp, out, skeleton, reference, as_json, asf, amc_fps, unit, overwrite, use, up_axis,
            unused=[o for o, v in (("--synthesis", synthesis), ("--neighbours", neighbours), ("--smoothing", smoothing),
                                   ("--knowledge", knowledge)) if v is not None])
    given_acc = [(o, k, v) for o, k, v in (("--synthesis", "synthesis", synthesis), ("--neighbours", "k", neighbours),
                                           ("--smoothing", "smoothing", smoothing)) if v is not None]
    acc_params = {k: v for _, k, v in given_acc}
    if (acc_params or knowledge is not None) and kind != "accelerometers":
        raise MocapError("--synthesis, --neighbours, --smoothing and --knowledge apply to --accelerometers only")
    if given_acc:
        from ..reconstruct.accelerometers import check_params
    for option, key, value in given_acc:  # the method's own rule, before anything is read or written
        try:
            check_params({key: value})
        except ValueError as e:
            raise MocapError(f"{option}: {e}") from None
    guard([out], [inp, db_dir, skeleton, reference, asf], overwrite)
    check_asf(asf, [inp, reference], amc_fps, names=CLI_AMC_NAMES)
    io.suffix_kind(out, io.WRITERS, "writing")
    if knowledge is not None:
        from ..reconstruct.accelerometers.knowledge import check_knowledge_base_output

        check_knowledge_base_output(knowledge)  # a folder of other files is refused before any work
    if not inp.is_file():  # as every reader says it (the CSV reader would say "cannot read the file: [Errno 2] ...")
        raise (MocapFormatError(inp, "not a regular file") if inp.exists() else MissingFileError(inp))
    db = MotionDatabase.open(db_dir)
    gaps = db.missing_note()  # NaN poses an earlier mocapkit kept: a note after a result, one error line if it fails
    unseen: list[str] = []
    if kind == "accelerometers":
        from ..reconstruct import accelerometers as acc
    if kind == "accelerometers" and inp.suffix.lower() == ".csv":
        from ..io.readings import read_readings_csv

        from ..io.readings import nominal_rate

        times, readings, names = read_readings_csv(inp)
        source = None
        try:
            fps = nominal_rate(times)[0]  # the recording's own rate, never the database's
        except ValueError as exc:
            raise MocapFormatError(inp, str(exc)) from None
        sensors = _sensors_named(names, db, inp)
    else:
        source = load_take(inp, asf, fps=amc_fps, unit=unit, unit_option="--unit")
        if kind == "accelerometers" and not isinstance(source, Motion):
            raise MocapFormatError(inp, "accelerometers come as a CSV (or a motion to simulate them on), not markers")
    performer = _performer_skeleton(skeleton, source, db)
    asf_file = _asf_for_amc(out, skeleton, performer, source, inp, asf, overwrite)
    if kind == "accelerometers":
        if source is not None:
            from ..features import virtual_accelerometers

            readings, fps, sensors = virtual_accelerometers(source), source.fps, None
        what = plural(readings.shape[1], "accelerometer")
        frames = readings.shape[0]
    else:
        from ..reconstruct.control import control_markers, far_from_markers, parse_use

        lying = ""
        if use is None and isinstance(source, MarkerSet):
            raise MocapFormatError(inp, "a marker file needs --use LABEL=JOINT,... to say which joint each marker sits on")
        spec = use if use is not None else _default_use(source.skeleton)
        said: list[str] = []  # a file whose vertical is not the one it was read with (control.up_axis_note)
        try:
            with warnings_as_notes(said):
                pos, joints, fps = control_markers(source, spec, db.skeletons[0], up_axis=up_axis, option="--up-axis")
        except ValueError as exc:
            raise MocapError(f"{inp}: {exc}") from None
        lying = "; ".join(said)
        pos, joints, unseen = _drop_unseen(pos, joints, spec)
        if not joints:
            raise MocapFormatError(inp, f"no marker named in --use is seen in any frame ({', '.join(unseen)})")
        what = f"{plural(len(joints), 'marker')} ({', '.join(joints)})"
        frames = pos.shape[0]
    ref = None
    if reference is not None:  # checked before the (long) reconstruction
        ref = check_reference(load_motion(reference, asf, purpose="a reference", fps=amc_fps, unit=unit,
                                          unit_option="--unit"), reference,
                              frames=frames,
                              skeleton=db.skeletons[0], whose=f"the reconstruction's ({db_dir.name}'s skeleton)",
                              option="--unit")
    try:
        if kind == "accelerometers":
            if knowledge is not None:  # primes the knowledge base the reconstruction then uses
                acc.knowledge_base(db, sensors, cache_dir=knowledge, progress=not as_json)
            result = acc.reconstruct(readings, db, fps, sensors, skeleton=performer, progress=not as_json, **acc_params)
        else:
            if kind == "markers":
                from ..reconstruct import markers as method
            else:
                from ..reconstruct import ssg as method
            result = method.reconstruct(pos, joints, db, fps, skeleton=performer, progress=not as_json)
    except ValueError as exc:  # numpy's LinAlgError ("Eigenvalues did not converge") is one
        if gaps:
            raise MocapError(_nan_database_line(db, db_dir)) from None
        raise MocapError(f"{inp}: {exc}") from None
    if gaps and result.missing().any():  # NaN poses taken from the database: not written, not even to an .npz
        raise MocapError(_nan_database_line(db, db_dir))
    if isinstance(source, Motion) and source.skeleton.is_compatible(result.skeleton):
        from ..reconstruct.output import laid_out_like

        # the joints above the pelvis (joint_Root) as the input has them; a root it moves, frame by frame where
        # the body is placed in its frame (markers), else relative to the pelvis (accelerometers do not place it)
        result = laid_out_like(result, source, follow=kind != "accelerometers")
    report, errors = "", {}
    if ref is not None:
        check_reference(ref, reference, frames=result.num_frames, skeleton=result.skeleton,
                        whose=f"the reconstruction's ({db_dir.name}'s skeleton)", option="--unit")
        # accelerometers see no heading: their error is measured with each motion's heading removed, the pelvis's
        # height and the joints above it in the ground frame where a body not placed can be right
        heading = kind == "accelerometers"
        from ..rigs import pelvis_index

        above = pelvis_index(result.skeleton) != 0  # a root above the pelvis (joint_Root): compared where placed
        if heading:
            report, errors = _reference_report(ref, result, reference)
        else:
            err = position_error_cm(ref, result)
            report = f"; joint-position RMS against {reference.name} (root-relative): {err:.2f} cm"
            errors = {"reference": str(reference), "joint_position_rms_cm": err, "joint_position_rms_is": "root-relative"}
            # markers place the body in their frame: where it lies is part of the error
            pelvis_cm, body_cm = global_errors_cm(ref, result)
            report += f"; in the markers' frame: pelvis {pelvis_cm:.2f} cm, body {body_cm:.2f} cm"
            errors.update(pelvis_position_rms_cm=pelvis_cm, body_position_rms_cm=body_cm)
            if above:  # the whole skeleton, the root above the pelvis too
                whole_cm = skeleton_error_cm(ref, result)
                report += f", whole skeleton (with {result.skeleton.joint_names[0]}) {whole_cm:.2f} cm"
                errors.update(skeleton_position_rms_cm=whole_cm)
        compared = list(result.skeleton.joint_names)  # each in one of the figures above
        report += f"; compared: all {len(compared)} joints of {reference.name}"
        errors.update(compared=compared)
    from ..reconstruct.control import upsampled_note

    coarse = upsampled_note(fps, db.fps, "the accelerometer readings" if kind == "accelerometers" else "the markers")
    notes, far = ([coarse] if coarse else []), {}
    if kind != "accelerometers" and isinstance(source, MarkerSet) and lying:
        notes.append(lying)
    if kind != "accelerometers":  # markers: a fit's compromise; ssg: database motion that does not follow them
        labels = [a for a, _ in parse_use(spec) if not any(u.startswith(f"{a} (") for u in unseen)]
        far = far_from_markers(result, pos, joints, unit_scale_cm(db.skeletons[0]), labels)
        if far["frames"]:
            runs = ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in far["ranges"][:5])
            more = f" and {len(far['ranges']) - 5} more" if len(far["ranges"]) > 5 else ""
            notes.append(f"the {'fit' if kind == 'markers' else 'result'} ends over {far['over_cm']:g} cm further than usual "
                         f"from a seen marker in {plural(far['frames'], 'frame')} of {result.num_frames} "
                         f"(frames {runs}{more}; worst: {far['worst_marker']} {far['worst_cm']:.1f} cm at frame {far['worst_frame']})")
    if kind != "accelerometers" and unseen:
        notes.append(f"{', '.join(unseen)} never seen in {inp.name}: left out (the other markers carry the fit)")
    if isinstance(source, Motion) and not source.skeleton.is_compatible(result.skeleton):
        notes.append(f"the body is the database's skeleton ({result.skeleton.num_joints} joints), not "
                     f"{inp.name}'s: the sensors' readings come from any rig, the poses from the database")
    if gaps:  # the result is whole, but the database still holds the NaN poses a rebuild drops
        notes.append(gaps)
    if db.info.get("licence"):  # the poses are the database's takes': their terms hold for the output
        notes.append(f"the poses come from {db_dir}, built from takes under {db.info['licence']}: so is {out.name}")
    _write(result, out, asf_file, overwrite, kind, db.info.get("licence"))
    if as_json:
        import json

        print(json.dumps({"out": str(out), "frames": result.num_frames, "fps": result.fps, "method": kind,
                          "from": what, "left_out": list(unseen) if kind != "accelerometers" else [],
                          **errors, **({"far_from_markers": far} if far else {}), "notes": notes}))
        return
    console.print(f"wrote {out}: {plural(result.num_frames, 'frame')} @ {result.fps:g} fps from {what}{report}")
    for note in notes:
        console.print(f"note: {note}")
