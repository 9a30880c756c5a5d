"""`mocapkit reconstruct` with each control signal on bundled real clips, and its one-line errors."""

import re
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, metrics, samples
from mocapkit.features import virtual_accelerometers
from tests.cli.helpers import one_error_line, run

QUERY = samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")


@pytest.fixture(scope="module")
def db_dir(tmp_path_factory):
    """A database of the other sneak take and the jog (not the query), at 30 fps."""
    d = tmp_path_factory.mktemp("recon") / "db"
    code, _, err = run("db", "build", str(d), str(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")),
                       str(samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc")), "--fps", "30", "--mirror",
                       "--executor", "serial")
    assert code == 0, err
    return d


@pytest.fixture(scope="module")
def query():
    return mocapkit.load(QUERY).resample(30)


def _reported_cm(stdout: str) -> float:
    m = re.search(r"\((?:root-relative|root and heading removed)\): ([0-9.]+) cm", " ".join(stdout.split()))
    assert m, stdout
    return float(m.group(1))


def _still_pose_error(query, frame=True) -> float:
    """The error of holding the take's first pose throughout: what any reconstruction must beat."""
    still = mocapkit.Motion(query.skeleton, np.repeat(query.rotations[:1], query.num_frames, 0), query.root_positions, query.fps)
    return metrics.joint_position_rms(query, still, root_relative=frame)


def test_markers_from_a_motion(tmp_path, db_dir, query):
    src = tmp_path / "query.npz"
    mocapkit.save(query, src)
    out = tmp_path / "rec.bvh"
    code, stdout, err = run("reconstruct", "--db", str(db_dir), "--markers", str(src), "-o", str(out), "--reference", str(src))
    assert code == 0, err
    assert "6 markers" in stdout
    rec = mocapkit.load(out)
    assert rec.num_frames == query.num_frames and rec.skeleton.is_compatible(query.skeleton)
    cm = _reported_cm(stdout)
    assert cm == pytest.approx(metrics.joint_position_rms(query, rec), abs=0.05)
    assert cm < 0.5 * _still_pose_error(query)


def test_accelerometers_from_a_csv(tmp_path, db_dir, query):
    from mocapkit.io.readings import write_readings_csv

    readings = virtual_accelerometers(query)
    csv = tmp_path / "imu.csv"
    write_readings_csv(csv, np.arange(query.num_frames) / query.fps, readings,
                       ["left_wrist", "right_wrist", "left_ankle", "right_ankle"])
    ref = tmp_path / "query.npz"
    mocapkit.save(query, ref)
    out = tmp_path / "rec.npz"
    code, stdout, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(csv), "-o", str(out),
                            "--skeleton", str(ref), "--reference", str(ref))
    assert code == 0, err
    assert "4 accelerometers" in stdout
    rec = mocapkit.load(out)
    assert rec.num_frames == query.num_frames
    cm = _reported_cm(stdout)
    assert cm == pytest.approx(metrics.joint_position_rms(query, rec, root_relative="heading"), abs=0.05)
    assert cm < _still_pose_error(query, "heading")


def test_ssg_from_a_motion_with_gaps(tmp_path, db_dir, query):
    gapped, _ = corrupt.gaps(query, seed=3, start_prob=0.02)
    src = tmp_path / "gaps.npz"
    mocapkit.save(gapped, src)
    ref = tmp_path / "query.npz"
    mocapkit.save(query, ref)
    out = tmp_path / "rec.npz"
    code, stdout, err = run("reconstruct", "--db", str(db_dir), "--ssg", str(src), "--use", "lhand,rhand,lfoot,rfoot",
                            "-o", str(out), "--reference", str(ref))
    assert code == 0, err
    assert "4 markers" in stdout
    # a tiny database (two clips) and gaps in a quarter of the joints' frames: retrieval only, no fit
    assert _reported_cm(stdout) < 0.8 * _still_pose_error(query)


def test_reconstruct_fails_in_one_line(tmp_path, db_dir):
    c3d = samples.path("Eb015pr.c3d")
    out = tmp_path / "o.bvh"
    code, _, err = run("reconstruct", "--db", str(db_dir), "-o", str(out))
    assert code == 2 and one_error_line(err) and "exactly one of" in err
    code, _, err = run("reconstruct", "--db", str(db_dir), "--markers", str(c3d), "-o", str(out))
    assert code == 2 and one_error_line(err) and "needs --use" in err
    code, _, err = run("reconstruct", "--db", str(db_dir), "--markers", str(c3d), "--use", "NOPE=head", "-o", str(out))
    assert code == 2 and one_error_line(err) and "no marker(s) NOPE" in err
    code, _, err = run("reconstruct", "--db", str(db_dir), "--markers", str(QUERY), "-o", str(QUERY))
    assert code == 2 and one_error_line(err) and "refusing to write over an input" in err
    bad = tmp_path / "bad.csv"
    bad.write_text("time,left_knee.x,left_knee.y,left_knee.z\n0,0,9.81,0\n0.01,0,9.81,0\n")
    code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(bad), "-o", str(out))
    assert code == 2 and one_error_line(err) and "left_knee" in err
    assert not out.exists()


def test_markers_on_the_bandai_rig(tmp_path):
    """The sixth default marker is the pelvis by its role (Hips), and the result is the take's body."""
    from pathlib import Path

    from mocapkit.reconstruct._common import body_motion

    clip = Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh"
    d = tmp_path / "db"
    code, _, err = run("db", "build", str(d), str(clip), "--fps", "30", "--executor", "serial")
    assert code == 0, err
    out = tmp_path / "rec.bvh"
    code, stdout, err = run("reconstruct", "--db", str(d), "--markers", str(clip), "-o", str(out))
    assert code == 0, err
    assert "6 markers" in stdout
    rec, take = mocapkit.load(out), mocapkit.load(clip)
    a, b = body_motion(rec).global_positions(), body_motion(take).global_positions()
    assert np.linalg.norm(a - b, axis=-1).mean() < 2.0  # cm: its own frames are in the database


def _hips_channels_off(rec, take):
    """How far (cm, per axis, worst frame) ``rec``'s Hips position channels are from ``take``'s, with joint_Root's
    channels the take's (at the origin): the file laid out as the take, Hips carrying the world translation."""
    np.testing.assert_array_equal(rec.root_positions, take.root_positions)
    np.testing.assert_array_equal(rec.channel_values()[:, :6], take.channel_values()[:, :6])
    hips = take.skeleton.index("Hips")
    return np.abs(rec.translations[:, hips] - take.translations[:, hips]).max(axis=0)


@pytest.mark.parametrize("mode", ["--markers", "--ssg", "--accelerometers"])
def test_a_bandai_reconstruction_keeps_joint_root_where_the_take_holds_it(tmp_path, bandai_db, mode):
    """joint_Root stays at the origin and Hips carries the translation in every mode, as in the take and the
    database (not joint_Root moved under the pelvis with Hips' X/Z zeroed); --reference compares the whole
    skeleton where the body is placed, and says it does not under accelerometers."""
    import json

    out = tmp_path / "rec.bvh"
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), mode, str(BANDAI), "-o", str(out),
                            "--reference", str(BANDAI), "--json")
    assert code == 0, err
    rep, rec, take = json.loads(stdout), mocapkit.load(out), mocapkit.load(BANDAI)
    off = _hips_channels_off(rec, take)
    assert rep["compared"] == list(take.skeleton.joint_names)  # every joint the reference has, said
    if mode == "--accelerometers":  # the height only: the pelvis's ground position is integrated, its heading free
        assert off[1] < 10.0
        assert "skeleton_position_rms_cm" not in rep and "not_compared" not in rep
        # joint_Root compared where the take holds it (the origin), the pelvis by its height
        assert rep["above_pelvis"] == ["joint_Root"] and rep["above_pelvis_is"] == "held still: global"
        assert rep["above_pelvis_rms_cm"] < 1e-3 and rep["pelvis_height_rms_cm"] < 10.0
    else:
        worst = np.linalg.norm(rec.global_positions() - take.global_positions(), axis=-1).max()
        assert off.max() < 5.0 and worst < 10.0 and rep["skeleton_position_rms_cm"] < 2.0  # cm


def test_accelerometers_compare_joint_root_with_the_reference_and_say_every_joint_compared(tmp_path, bandai_db):
    """joint_Root, above the pelvis, is compared under accelerometers where such a result can be right: globally
    where the reference holds it still (a reference whose joint_Root lies 50 cm away shows 50 cm), in the pelvis's
    ground frame where it moves with the body (dataset 1's dash); the line ends naming every joint as compared."""
    import json

    take = mocapkit.load(BANDAI)
    moved = tmp_path / "moved.npz"  # joint_Root, and with it the body, 50 cm along x: the body's figures stay
    mocapkit.save(mocapkit.Motion(take.skeleton, take.rotations, take.root_positions + [50.0, 0.0, 0.0], take.fps,
                                  take.name, take.translations), moved)
    out = tmp_path / "rec.bvh"
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), "--accelerometers", str(BANDAI), "-o", str(out),
                            "--reference", str(moved))
    assert code == 0, err
    line = " ".join(stdout.split())
    assert re.search(r"pelvis height [0-9.]+ cm, joint_Root 50\.00 cm \(where the reference holds it still\)", line)
    assert "compared: all 22 joints of moved.npz" in line and "not compared" not in line
    dash = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), "--accelerometers", str(dash), "-o",
                            str(tmp_path / "dash.bvh"), "--reference", str(dash), "--json")
    assert code == 0, err
    rep = json.loads(stdout)
    assert rep["above_pelvis_is"] == "in the pelvis's ground frame" and rep["above_pelvis_rms_cm"] < 0.01
    assert len(rep["compared"]) == 22


def test_accelerometers_on_a_take_that_moves_its_root_give_its_root_motion_back(tmp_path, bandai_db):
    """Dataset 1's dash moves joint_Root along the floor with the body (2.7 m in 20 frames); the database's take
    holds it at the origin. The result's joint_Root is where the take's is relative to the pelvis's ground frame
    (heading and floor position), frame by frame, not left at the origin 1.4 m RMS from where it belongs."""
    from mocapkit import rotations as R
    from mocapkit.features import root_frame

    dash = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"
    out = tmp_path / "rec.bvh"
    code, _, err = run("reconstruct", "--db", str(bandai_db), "--accelerometers", str(dash), "-o", str(out))
    assert code == 0, err
    rec, take = mocapkit.load(out), mocapkit.load(dash)
    up = np.array([0.0, 1.0, 0.0])

    def in_pelvis_frame(m):
        h, t = root_frame(m, up)
        return R.quaternion_rotate(R.quaternion_conjugate(h), m.global_positions()[:, 0] - t)

    assert np.linalg.norm(rec.root_positions, axis=-1).max() > 0.0  # not held at the origin
    np.testing.assert_allclose(in_pelvis_frame(rec), in_pelvis_frame(take), atol=1e-3)  # cm (the BVH's 6 decimals)


def test_a_database_of_bandai_namco_takes_says_their_licence_in_db_info_and_reconstruct(tmp_path):
    # the trial: a database and a reconstruction from Bandai Namco takes (CC BY-NC 4.0) said nothing of it
    from pathlib import Path

    clip = Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh"
    d = tmp_path / "db"
    code, stdout, err = run("db", "build", str(d), str(clip), "--fps", "30", "--executor", "serial")
    assert code == 0, err
    assert sum(ln.startswith("note:") and "CC BY-NC 4.0" in ln for ln in stdout.splitlines()) == 1, stdout
    code, stdout, err = run("db", "info", str(d))
    assert code == 0, err
    assert any("licence" in ln and "CC BY-NC 4.0" in ln for ln in stdout.splitlines()), stdout
    code, stdout, err = run("reconstruct", "--db", str(d), "--markers", str(clip), "-o", str(tmp_path / "rec.bvh"))
    assert code == 0, err
    said = [ln for ln in stdout.splitlines() if ln.startswith("note:") and "CC BY-NC 4.0" in ln]
    assert len(said) == 1 and "rec.bvh" in said[0], stdout


def test_accelerometer_options_reach_the_method(tmp_path, db_dir, query):
    """--synthesis/--neighbours/--smoothing change the result as the library's parameters do; bad values and other
    signals are refused in one line before anything is written."""
    from mocapkit.database import MotionDatabase
    from mocapkit.reconstruct import accelerometers as acc

    src = tmp_path / "query.npz"
    mocapkit.save(query[:30], src)  # a second: --smoothing, --neighbours and --synthesis each change its result
    out = tmp_path / "reg.npz"
    code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(src), "-o", str(out),
                       "--synthesis", "regression", "--neighbours", "200", "--smoothing", "0.3")
    assert code == 0, err
    want = acc.reconstruct(virtual_accelerometers(query[:30]), MotionDatabase.open(db_dir), query.fps,
                           skeleton=query.skeleton, synthesis="regression", k=200, smoothing=0.3)
    assert np.allclose(mocapkit.load(out).rotations, want.rotations, atol=1e-9)
    plain = tmp_path / "mean.npz"
    assert run("reconstruct", "--db", str(db_dir), "--accelerometers", str(src), "-o", str(plain))[0] == 0
    assert not np.allclose(mocapkit.load(plain).rotations, want.rotations, atol=1e-6)
    for bad, words in ((["--synthesis", "median"], "--synthesis: synthesis must be 'energy', 'mean' or 'regression'"),
                       (["--smoothing", "1"], "--smoothing: smoothing must be in [0, 1)"),
                       (["--neighbours", "0"], "--neighbours: k must be a positive integer")):
        o = tmp_path / "bad.npz"
        code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(src), "-o", str(o), *bad)
        assert code == 2 and one_error_line(err) and words in err and not o.exists()
    code, _, err = run("reconstruct", "--db", str(db_dir), "--markers", str(src), "-o", str(tmp_path / "m.npz"),
                       "--synthesis", "regression")
    assert code == 2 and one_error_line(err) and "--accelerometers only" in err


def test_neighbours_has_both_spellings_and_a_missing_csv_is_no_such_file(tmp_path, db_dir, query):
    """--neighbours and --neighbors (search's spelling) are one option; a missing accelerometer CSV is the
    one-line 'no such file' of every other input."""
    src = tmp_path / "query.npz"
    mocapkit.save(query[:60], src)
    outs = {}
    for spelling in ("--neighbours", "--neighbors"):
        outs[spelling] = tmp_path / f"{spelling[2:]}.npz"
        code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(src), "-o", str(outs[spelling]),
                           spelling, "200")
        assert code == 0, err
    assert np.array_equal(mocapkit.load(outs["--neighbours"]).rotations, mocapkit.load(outs["--neighbors"]).rotations)
    out = tmp_path / "x.npz"
    code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(src), "-o", str(out),
                       "--neighbors", "0")
    assert code == 2 and one_error_line(err) and "--neighbours: k must be a positive integer" in err
    code, stdout, _ = run("reconstruct", "--help")
    assert code == 0 and "--neighbours" in stdout and "--neighbors" in stdout
    missing = tmp_path / "missing.csv"
    code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(missing), "-o", str(out))
    assert code == 2 and one_error_line(err)
    assert " ".join(err.split()) == f"mocapkit: error: {missing}: no such file"
    assert not out.exists()


def test_accelerometers_of_another_rig_say_whose_body_the_result_is(tmp_path, db_dir):
    bandai = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"
    out = tmp_path / "r.bvh"
    code, stdout, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(bandai), "-o", str(out))
    assert code == 0, err
    assert "the body is the database's skeleton" in " ".join(stdout.split())
    code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(bandai), "-o",
                       str(tmp_path / "s.bvh"), "--reference", str(bandai))
    assert code == 2 and "the reference must have the reconstruction's" in err


BANDAI = Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh"


@pytest.fixture(scope="module")
def bandai_db(tmp_path_factory):
    d = tmp_path_factory.mktemp("bandai") / "db"
    code, _, err = run("db", "build", str(d), str(BANDAI), "--fps", "30", "--executor", "serial")
    assert code == 0, err
    return d


def test_ssg_on_the_bandai_rig_reports_where_the_body_lies(tmp_path, bandai_db):
    """--reference gives the pelvis's and the body's error in the markers' frame beside the root-relative one, in --json too."""
    import json

    out = tmp_path / "rec.bvh"
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), "--ssg", str(BANDAI), "-o", str(out),
                            "--reference", str(BANDAI), "--json")
    assert code == 0, err
    rep = json.loads(stdout)
    assert rep["frames"] == 60 and rep["joint_position_rms_is"] == "root-relative"
    # the body is played back by its pelvis (Hips), which lies on its marker: not metres away
    assert rep["pelvis_position_rms_cm"] < 0.01 and rep["body_position_rms_cm"] < 1.0
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), "--ssg", str(BANDAI), "-o", str(out),
                            "--reference", str(BANDAI), "--overwrite")
    assert code == 0 and "in the markers' frame: pelvis 0.00 cm, body" in " ".join(stdout.split()), stdout


def test_markers_on_a_take_in_metres_give_a_body_in_metres(tmp_path, bandai_db):
    import dataclasses

    take = mocapkit.load(BANDAI)
    sk = take.skeleton
    metres = dataclasses.replace(take, skeleton=dataclasses.replace(sk, offsets=sk.offsets * 0.01, end_site_offsets=sk.end_site_offsets * 0.01),
                                 root_positions=take.root_positions * 0.01, translations=take.translations * 0.01)
    src, out = tmp_path / "walk_m.bvh", tmp_path / "rec.bvh"
    mocapkit.save(metres, src)
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), "--markers", str(src), "-o", str(out), "--reference", str(src))
    assert code == 0, err
    d = np.linalg.norm(mocapkit.load(out).global_positions()[:, 1:] - metres.global_positions()[:, 1:], axis=-1)
    assert d.mean() < 0.02  # metres: the body is the take's, in its unit
    assert _reported_cm(stdout) < 2.0


def test_a_marker_never_seen_is_left_out_and_said(tmp_path, bandai_db):
    from mocapkit.features import virtual_markers
    from mocapkit.io import save_markers
    from mocapkit.markerset import MarkerSet

    take = mocapkit.load(BANDAI)[:20]  # a marker never seen is said whatever the take's length
    names = ["Hand_L", "Hand_R", "Foot_L", "Foot_R", "Head", "Hips"]
    x = virtual_markers(take, names)
    x[:, 0] = np.nan
    ms = MarkerSet(tuple(n.upper() for n in names), x, take.fps, "cm")
    src, out = tmp_path / "m.npz", tmp_path / "rec.bvh"
    save_markers(ms, src)
    use = ",".join(f"{n.upper()}={n}" for n in names)
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), "--markers", str(src), "--use", use, "--up-axis", "y", "-o", str(out))
    assert code == 0, err
    text = " ".join(stdout.split())
    assert "from 5 markers (Hand_R, Foot_L, Foot_R, Head, Hips)" in text
    assert "HAND_L (Hand_L) never seen in m.npz: left out" in text


def test_amc_output_on_the_performer_asf(tmp_path, db_dir, query):
    # the query's first second, an AMC on its performer's ASF (copied beside it) as the bundled take is: what the
    # output is written on does not depend on the take's length
    src = mocapkit.save(mocapkit.load(QUERY)[:120], tmp_path / "in" / QUERY.name)
    assert (tmp_path / "in" / "HDM_bk.asf").is_file()
    out = tmp_path / "rec.amc"
    code, stdout, err = run("reconstruct", "--db", str(db_dir), "--markers", str(src), "-o", str(out))
    assert code == 0, err
    back = mocapkit.load(out)  # read with the ASF copied beside it
    assert back.num_frames == 120 and back.skeleton.is_compatible(query.skeleton)
    csv = tmp_path / "imu.csv"
    from mocapkit.io.readings import write_readings_csv

    write_readings_csv(csv, np.arange(query.num_frames) / query.fps, virtual_accelerometers(query))
    code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(csv), "-o", str(tmp_path / "acc.amc"))
    assert code == 2 and one_error_line(err) and "has none" in err  # the database's skeleton: no ASF to read it with
    assert not (tmp_path / "acc.amc").exists()


def test_jittered_csv_keeps_its_frames_and_nominal_rate(tmp_path, db_dir, query):
    from mocapkit.io.readings import write_readings_csv

    F = query.num_frames
    t = np.arange(F) / 120.0 + np.random.default_rng(1).uniform(-0.002, 0.002, F)
    t[0] = 0.0
    csv = tmp_path / "jit.csv"
    write_readings_csv(csv, t, virtual_accelerometers(query))
    out = tmp_path / "rec.bvh"
    code, stdout, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(csv), "-o", str(out))
    assert code == 0, err
    rec = mocapkit.load(out)
    assert rec.num_frames == F and rec.fps == 120.0
    one = tmp_path / "one.csv"
    write_readings_csv(one, t[:1], virtual_accelerometers(query)[:1])
    code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(one), "-o", str(tmp_path / "one.bvh"))
    assert code == 2 and one_error_line(err) and "no rate" in err


def test_knowledge_folder_is_built_once_and_reused(tmp_path, db_dir, query):
    from mocapkit.io.readings import write_readings_csv

    csv = tmp_path / "imu.csv"
    query = query[:20]  # the knowledge base is the database's, whatever the take's length
    write_readings_csv(csv, np.arange(query.num_frames) / query.fps, virtual_accelerometers(query))
    kb = tmp_path / "kb"
    outs = []
    for i in range(2):
        outs.append(tmp_path / f"rec{i}.bvh")
        code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(csv), "-o", str(outs[-1]), "--knowledge", str(kb))
        assert code == 0, err
        if i == 0:
            stamp = {p.name: p.stat().st_mtime_ns for p in kb.iterdir()}
    assert stamp and {p.name: p.stat().st_mtime_ns for p in kb.iterdir()} == stamp  # opened, not written again
    assert outs[0].read_bytes() == outs[1].read_bytes()
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    code, _, err = run("reconstruct", "--db", str(db_dir), "--accelerometers", str(csv), "-o", str(tmp_path / "x.bvh"),
                       "--knowledge", str(tmp_path / "other"))
    assert code == 2 and one_error_line(err) and (tmp_path / "other" / "notes.txt").read_text() == "mine"


def test_markers_fit_says_where_it_ends_far_from_a_seen_marker(tmp_path, bandai_db):
    import json

    from mocapkit.features import virtual_markers
    from mocapkit.io import save_markers
    from mocapkit.markerset import MarkerSet

    take = mocapkit.load(BANDAI)[:40]  # the take's first 40 frames hold the 3 bad ones and 7 after them
    names = ["Hand_L", "Hand_R", "Foot_L", "Foot_R", "Head", "Hips"]
    x = virtual_markers(take, names)
    x[30:33, 0, 1] += 150.0  # a left-hand marker 1.5 m above the hand: out of the arm's reach
    src, out = tmp_path / "m.npz", tmp_path / "rec.bvh"
    save_markers(MarkerSet(tuple(names), x, take.fps, "cm"), src)
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), "--markers", str(src), "--use", ",".join(names),
                            "--up-axis", "y", "-o", str(out), "--json")
    assert code == 0, err
    far = json.loads(stdout)["far_from_markers"]
    assert 1 <= far["frames"] <= 6 and far["worst_marker"] == "Hand_L (Hand_L)" and 30 <= far["worst_frame"] <= 32


def test_an_npz_reconstruction_says_what_it_holds(tmp_path, db_dir, query):
    """``-o OUT.npz``: beside the Motion (read back by mocapkit.load) the global joint positions (F, J, 3) with their
    unit, the joint names, the rate, the method and a text naming every array."""
    from mocapkit.motion import unit_scale_cm

    src, out = tmp_path / "query.npz", tmp_path / "rec.npz"
    query = query[:20]  # what the npz holds does not depend on the take's length
    mocapkit.save(query, src)
    code, _, err = run("reconstruct", "--db", str(db_dir), "--markers", str(src), "-o", str(out))
    assert code == 0, err
    rec = mocapkit.load(out)
    z = np.load(out)
    np.testing.assert_array_equal(z["positions"], rec.global_positions())
    assert z["positions"].shape == (query.num_frames, rec.num_joints, 3) == (20, rec.num_joints, 3)
    assert list(z["joint_names"]) == list(rec.skeleton.joint_names) and float(z["fps"]) == query.fps
    assert str(z["method"]) == "markers"
    assert float(z["cm_per_unit"]) == pytest.approx(unit_scale_cm(rec.skeleton))
    assert str(z["length_unit"]) == f"{float(z['cm_per_unit']):g} cm"  # HDM05's ASF unit: no common name
    height_cm = np.ptp(z["positions"][0, :, 1]) * float(z["cm_per_unit"])  # the skeleton's up axis is y
    assert 100 < height_cm < 220
    for key in ("positions", "joint_names", "fps", "rotations", "root_positions", "cm_per_unit", "method"):
        assert f"\n{key}:" in str(z["contents"]), key


@pytest.mark.parametrize("signal", ["--markers", "--accelerometers", "--ssg"])
def test_a_coarse_input_keeps_its_rate_and_frames_and_says_it_was_upsampled(tmp_path, db_dir, signal):
    """A 5 fps take against the 30 fps database: reconstructed at 30 fps from markers (or readings) interpolated
    between its frames, and written at 5 fps with its 7 frames; the summary said only "13 frames @ 5 fps" (of the
    whole take; its first 1.25 s here: what is kept and said does not depend on the take's length)."""
    src = tmp_path / "coarse.npz"
    take = mocapkit.load(QUERY)[:150].resample(5)
    mocapkit.save(take, src)
    out = tmp_path / "rec.npz"
    code, stdout, err = run("reconstruct", "--db", str(db_dir), signal, str(src), "-o", str(out))
    assert code == 0, err
    rec = mocapkit.load(out)
    assert (rec.num_frames, rec.fps) == (take.num_frames, 5.0) == (7, 5.0)
    what = "accelerometer readings" if signal == "--accelerometers" else "markers"
    assert (f"note: the {what} at 5 fps were interpolated up to the database's 30 fps (6 frames for each one "
            "recorded) to be reconstructed there, and the result resampled back to 5 fps") in " ".join(stdout.split())
    code, stdout, _ = run("reconstruct", "--db", str(db_dir), signal, str(src), "-o", str(out), "--overwrite",
                          "--json")
    import json
    said = json.loads(stdout.strip().splitlines()[-1])
    assert (said["frames"], said["fps"]) == (7, 5.0) and any("interpolated up" in n for n in said["notes"])


def test_a_reconstruction_from_bandai_takes_keeps_their_licence_in_its_npz_and_info_says_it(tmp_path, bandai_db):
    """The poses are the database's CC BY-NC takes': the npz keeps a licence text (a file shipped alone carries it),
    its contents say it, and `info` of the file says it once."""
    out = tmp_path / "rec.npz"
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), "--markers", str(BANDAI), "-o", str(out))
    assert code == 0, err
    assert sum("CC BY-NC 4.0" in ln for ln in stdout.splitlines()) == 1, stdout
    with np.load(out, allow_pickle=False) as z:
        assert "CC BY-NC 4.0" in str(z["licence"]) and "licence:" in str(z["contents"])
    code, stdout, err = run("info", str(out))
    assert code == 0, err
    assert [ln.split()[0] for ln in stdout.splitlines() if "CC BY-NC 4.0" in ln] == ["licence"], stdout


def test_a_knowledge_base_of_bandai_takes_says_their_licence_in_info(tmp_path, bandai_db):
    """`info` of a knowledge base (reconstruct --knowledge) built from a Bandai Namco database says its licence
    once, as the reconstruction's console line does."""
    kb = tmp_path / "kb"
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), "--accelerometers", str(BANDAI), "-o",
                            str(tmp_path / "rec.bvh"), "--knowledge", str(kb))
    assert code == 0, err
    assert sum("CC BY-NC 4.0" in ln for ln in stdout.splitlines()) == 1, stdout
    code, stdout, err = run("info", str(kb))
    assert code == 0, err
    assert [ln.split()[0] for ln in stdout.splitlines() if "CC BY-NC 4.0" in ln] == ["licence"], stdout


def test_a_reconstruction_from_takes_of_unknown_terms_keeps_no_licence(tmp_path, db_dir, query):
    """HDM05 takes: the project does not know their terms, so nothing is claimed."""
    src, out = tmp_path / "q.npz", tmp_path / "rec.npz"
    mocapkit.save(query[:20], src)
    code, stdout, err = run("reconstruct", "--db", str(db_dir), "--markers", str(src), "-o", str(out))
    assert code == 0, err
    with np.load(out, allow_pickle=False) as z:
        assert "licence" not in z.files and "licence" not in str(z["contents"])
    code, stdout, _ = run("info", str(out))
    assert code == 0 and "licence" not in stdout


def test_ssg_result_says_which_frames_lie_far_from_the_markers(tmp_path, bandai_db):
    """The subsequence graph fits no marker: where it plays motion the markers do not show, frames are named."""
    import json

    from mocapkit.features import virtual_markers
    from mocapkit.io import save_markers
    from mocapkit.markerset import MarkerSet

    take = mocapkit.load(BANDAI)
    names = ["Hand_L", "Hand_R", "Foot_L", "Foot_R", "Hips"]
    x = virtual_markers(take, names)
    x[30:36, 0, 1] += 150.0  # a left-hand marker 1.5 m above the hand: no database motion goes there
    src, out = tmp_path / "m.npz", tmp_path / "rec.bvh"
    save_markers(MarkerSet(tuple(names), x, take.fps, "cm"), src)
    code, stdout, err = run("reconstruct", "--db", str(bandai_db), "--ssg", str(src), "--use", ",".join(names),
                            "--up-axis", "y", "-o", str(out), "--json")
    assert code == 0, err
    said = json.loads(stdout)
    far = said["far_from_markers"]
    assert far["worst_marker"] == "Hand_L (Hand_L)" and 30 <= far["worst_frame"] <= 35
    assert any(a <= 32 <= b for a, b in far["ranges"]) and any("further than usual" in n for n in said["notes"])


def test_a_marker_file_whose_vertical_is_not_z_is_said_in_a_note(db_dir, tmp_path):
    """Trial: a Y-up TRC (OpenSim's convention: the shared data's T.trc) without --up-axis came back lying on its
    side and the command said nothing. CMU 85_02.c3d turned Y-up (y, z, x) and written as a TRC."""
    import dataclasses
    import json

    from mocapkit.io import load_markers, save_markers

    take = load_markers(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")[:120]
    src = save_markers(dataclasses.replace(take, positions=take.positions[..., [1, 2, 0]], source=None),
                       tmp_path / "y_up.trc")
    said = ("the markers stand along the file's y axis, not z (the default, the C3D convention): the body was "
            "reconstructed lying on its side; pass --up-axis y")
    use = "LFHD=head,LANK=lfoot,RANK=rfoot,LFWT=root"
    for up, notes in ((), [said]), (("--up-axis", "y"), []):
        code, stdout, err = run("reconstruct", "--db", str(db_dir), "--ssg", str(src), "--use", use, *up,
                                "-o", str(tmp_path / f"r{len(up)}.npz"), "--json")
        assert code == 0, err
        assert [n for n in json.loads(stdout.strip().splitlines()[-1])["notes"] if "axis" in n] == notes
