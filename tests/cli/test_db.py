"""`mocapkit db build`, `db info` and `search` on the bundled clips, and their one-line errors."""


import mocapkit
from mocapkit.cli import main
from tests.cli import helpers
from tests.cli.helpers import SAMPLE, one_error_line, run


def _db_sources():
    return [str(mocapkit.samples.path(n)) for n in ("12_walk.amc", "HDM_bk_sneak2StepsLStart_004_120.amc", "HDM_bk_sneak2StepsLStart_005_120.amc")]


def test_db_build_info_and_search(tmp_path, capsys):
    import json

    db_dir = tmp_path / "db"
    assert main(["db", "build", str(db_dir), *_db_sources(), "--mirror", "--features", "F15,F30", "--executor", "serial"]) == 0
    assert "6 clips" in capsys.readouterr().out
    assert main(["db", "info", str(db_dir), "--json"]) == 0
    info = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert info["clips"] == 6 and info["mirrored_clips"] == 3 and info["features"] == {"F15": 15, "F30": 30}
    query = mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")
    assert main(["search", str(db_dir), str(query), "--k", "2", "--start", "0.5", "--end", "1.5", "--json"]) == 0
    res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert res[0]["name"] == "HDM_bk_sneak2StepsLStart_005_120" and res[0]["start"] == 15 and res[0]["end"] == 44
    assert res[0]["cost"] < 0.01 and res[1]["cost"] > res[0]["cost"]
    assert main(["search", str(db_dir), str(query), "--k", "2", "--features", "F30", "--json"]) == 0
    res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert res[0]["name"] == "HDM_bk_sneak2StepsLStart_005_120"
    # a query on another rig works: features are joint positions by role, in centimetres
    assert main(["search", str(db_dir), SAMPLE, "--k", "1", "--start", "2", "--end", "3"]) == 0
    assert "cost/frame" in capsys.readouterr().out


def test_db_errors_are_one_line(tmp_path):
    db_dir = tmp_path / "db"
    code, _, err = run("db", "build", str(db_dir), str(mocapkit.samples.path("12_walk.amc")), SAMPLE, "--executor", "serial")
    assert code == 2 and one_error_line(err) and "131_01.bvh" in err and "skeleton differs" in err
    assert not db_dir.exists()
    code, _, err = run("db", "info", str(tmp_path))
    assert code == 2 and "not a motion database" in err and one_error_line(err)
    code, _, err = run("db", "info", str(tmp_path / "nope"))  # it said "not a motion database (no database.json)"
    assert code == 2 and one_error_line(err) and f"{tmp_path / 'nope'}: no such folder" in " ".join(err.split())
    assert main(["db", "build", str(db_dir), str(mocapkit.samples.path("12_walk.amc")), "--executor", "serial"]) == 0
    code, _, err = run("db", "build", str(db_dir), str(mocapkit.samples.path("12_walk.amc")))
    assert code == 2 and "already exists; pass --overwrite" in err  # the command's flag, not the library's keyword
    code, _, err = run("search", str(db_dir), str(mocapkit.samples.path("Eb015pr.c3d")))
    assert code == 2 and "Eb015pr.c3d" in err and one_error_line(err)
    code, _, err = run("search", str(db_dir), str(mocapkit.samples.path("12_walk.amc")), "--features", "F39")
    assert code == 2 and "no feature set 'F39'" in err and one_error_line(err)


def test_clip_names_with_markup_print_as_they_are(tmp_path, capsys):
    import dataclasses

    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    clip = tmp_path / "clip.npz"
    mocapkit.save(dataclasses.replace(walk, name="[/]"), clip)
    db_dir = tmp_path / "db"
    assert main(["db", "build", str(db_dir), str(clip), "--executor", "serial"]) == 0
    capsys.readouterr()
    assert main(["db", "info", str(db_dir), "--clips"]) == 0
    assert "[/]" in capsys.readouterr().out
    assert main(["search", str(db_dir), str(clip), "--k", "1", "--start", "0.5", "--end", "1.5"]) == 0
    assert "[/]" in capsys.readouterr().out


def test_db_build_overwrite_replaces_only_a_database_without_the_inputs(tmp_path, capsys):
    import shutil

    p = tmp_path / "p"
    (p / "takes").mkdir(parents=True)
    shutil.copy(mocapkit.samples.path("12_walk.amc"), p / "takes" / "walk.amc")
    shutil.copy(mocapkit.samples.path("12.asf"), p / "takes" / "walk.asf")
    (p / "notes.txt").write_text("x")
    before = helpers.tree(p)
    assert main(["db", "build", str(p), str(p / "takes" / "walk.amc"), "--overwrite", "--executor", "serial"]) == 2
    assert one_error_line(capsys.readouterr().err)
    assert helpers.tree(p) == before
    db_dir = tmp_path / "db"
    assert main(["db", "build", str(db_dir), str(p / "takes" / "walk.amc"), "--executor", "serial"]) == 0
    assert main(["db", "build", str(db_dir), str(p / "takes" / "walk.amc"), "--executor", "serial", "--overwrite",
                 "--mirror"]) == 0
    assert "2 clips" in capsys.readouterr().out


def test_executor_is_checked_before_any_work(tmp_path, capsys):
    db_dir = tmp_path / "db"
    assert main(["db", "build", str(db_dir), str(mocapkit.samples.path("12_walk.amc")), "--executor", "garbage"]) == 2
    err = capsys.readouterr().err
    assert one_error_line(err) and "garbage" in err and not db_dir.exists()
    assert main(["clean-batch", str(tmp_path), str(tmp_path / "out"), "--executor", "garbage"]) == 2
    assert "garbage" in capsys.readouterr().err and not (tmp_path / "out").exists()


def test_search_takes_both_spellings_of_neighbors(tmp_path, capsys):
    """--neighbors and --neighbours (reconstruct's spelling) are one option."""
    db_dir = tmp_path / "db"
    assert main(["db", "build", str(db_dir), *_db_sources()[:2], "--executor", "serial"]) == 0
    query = str(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    results = {}
    for spelling in ("--neighbors", "--neighbours"):
        capsys.readouterr()
        assert main(["search", str(db_dir), query, "--k", "2", spelling, "16", "--json"]) == 0
        results[spelling] = capsys.readouterr().out.strip().splitlines()[-1]
    assert results["--neighbors"] == results["--neighbours"]
    code, out, _ = run("search", "--help")
    assert code == 0 and "--neighbors" in out and "--neighbours" in out


def test_db_build_names_fps(tmp_path):
    db_dir = tmp_path / "db"
    code, _, err = run("db", "build", str(db_dir), str(mocapkit.samples.path("12_walk.amc")), "--fps", "-5")
    assert code == 2 and one_error_line(err) and "--fps must be a positive number from 1 to 1000 " in err
    code, _, err = run("db", "build", str(db_dir), str(mocapkit.samples.path("12_walk.amc")), "--fps", "2000")
    assert code == 2 and one_error_line(err) and "from 1 to 1000 (frames per second) for a database" in err
    assert not db_dir.exists()


def test_db_build_names_features_before_any_work(tmp_path):
    """Before 0.15.0 an unknown --features printed "building from 1 path ..." and then refused the Python
    "unknown feature set 'F99'", without naming the option."""
    db_dir = tmp_path / "db"
    for given, got in (("F99", "got F99"), ("F15,F99", "got F99"), (",", "got ','")):
        code, out, err = run("db", "build", str(db_dir), str(mocapkit.samples.path("12_walk.amc")), "--features", given)
        assert code == 2 and one_error_line(err) and out == "", (out, err)
        assert ("--features must be one or more of F15, F30, F39, F15x3, F15x5, F30x3, F39x3 (comma-separated), "
                + got) in err, err
    assert not db_dir.exists()


def test_search_clamps_end_and_names_k_and_neighbors(tmp_path):
    db_dir = tmp_path / "db"
    assert main(["db", "build", str(db_dir), *_db_sources()[:2], "--executor", "serial"]) == 0
    query = str(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    whole = run("search", str(db_dir), query, "--k", "2", "--json")
    past = run("search", str(db_dir), query, "--k", "2", "--json", "--end", "500")  # past the clip's end: its end
    assert whole[0] == past[0] == 0 and whole[1] == past[1]
    for opt in ("--k", "--neighbors"):
        code, _, err = run("search", str(db_dir), query, opt, "0")
        assert code == 2 and one_error_line(err) and f"{opt} must be a positive integer, got 0" in err
    code, _, err = run("search", str(db_dir), query, "--method", "knn")  # the option, not the Python argument
    assert code == 2 and one_error_line(err) and "error: --method must be lng or dtw, got 'knn'" in err, err


def test_a_query_whose_rig_lacks_the_features_names_the_query(tmp_path):
    from tests.shared import unknown_rig

    db = tmp_path / "db"
    assert run("db", "build", str(db), SAMPLE)[0] == 0
    query = tmp_path / "q.bvh"
    unknown_rig(query)
    code, _, err = run("search", str(db), str(query))
    assert code == 2 and one_error_line(err) and f"{query}: cannot compute the query's features" in " ".join(err.split())


def test_search_takes_the_query_s_unit(tmp_path, capsys):
    """The query's positions (F30) are compared in centimetres: --unit says what a file that states no unit holds, as
    on clean. The CMU BVH is read at 5.6 cm a unit (its bones, an adult's); read as metres, the same query is 18
    times too large and matches nothing as well."""
    import json

    db_dir = tmp_path / "db"
    assert main(["db", "build", str(db_dir), *_db_sources(), "--features", "F30", "--executor", "serial"]) == 0
    capsys.readouterr()
    found = {}
    for unit in (None, "m"):
        assert main(["search", str(db_dir), SAMPLE, "--k", "1", "--start", "2", "--end", "3", "--json",
                     *(["--unit", unit] if unit else [])]) == 0
        found[unit] = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert found[None] and (not found["m"] or found["m"][0]["cost"] > 10 * found[None][0]["cost"])
    code, _, err = run("search", str(db_dir), SAMPLE, "--unit", "furlong")
    assert code == 2 and one_error_line(err) and "furlong" in err


def test_db_build_reads_amc_files_with_asf_and_amc_fps(tmp_path, capsys):
    """Docs trial: README says every command that reads AMC takes --asf and --amc-fps; db build had neither, so
    AMC files in a folder of several ASFs could not go into a database ("name the skeleton with --asf FILE", then
    "No such option: --asf")."""
    import json
    import shutil

    folder = tmp_path / "takes"
    folder.mkdir()
    shutil.copy(mocapkit.samples.path("12_walk.amc"), folder / "walk.amc")
    for asf in ("12.asf", "HDM_bd.asf"):
        shutil.copy(mocapkit.samples.path(asf), folder / asf)
    code, _, err = run("db", "build", str(tmp_path / "refused"), str(folder), "--executor", "serial")
    assert code == 2 and one_error_line(err) and "--asf" in err
    db_dir = tmp_path / "db"
    assert main(["db", "build", str(db_dir), str(folder), "--asf", str(folder / "12.asf"), "--amc-fps", "60",
                 "--executor", "serial", "--fps", "30"]) == 0
    capsys.readouterr()
    assert main(["db", "info", str(db_dir), "--json", "--clips"]) == 0
    info = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    # read at 60 fps, the take lasts twice as long as at 120: twice the frames at the database's 30 fps
    assert info["clip_list"][0]["frames"] == int((walk.num_frames - 1) * 30 / 60) + 1
    code, _, err = run("db", "build", str(tmp_path / "x"), SAMPLE, "--asf", str(folder / "12.asf"))
    assert code == 2 and one_error_line(err) and "no input is an .amc file" in err


def test_search_says_when_fewer_segments_than_k_remain_with_and_without_json(tmp_path):
    """Docs trial: the guide says search says so when fewer than --k segments remain; with --json it said nothing."""
    import json

    db_dir = tmp_path / "db"
    assert main(["db", "build", str(db_dir), _db_sources()[1], "--executor", "serial"]) == 0
    query = _db_sources()[1]
    code, out, err = run("search", str(db_dir), query, "--k", "50", "--start", "0.5", "--end", "1.5")
    assert code == 0 and "of the 50 matches asked for" in out
    code, out, err = run("search", str(db_dir), query, "--k", "50", "--start", "0.5", "--end", "1.5", "--json")
    found = json.loads(out.strip().splitlines()[-1])
    assert code == 0 and 0 < len(found) < 50 and f"note: {len(found)} of the 50 matches asked for" in err


def test_a_database_of_an_earlier_mocapkit_with_nan_poses_is_opened_with_a_note(tmp_path):
    """mocapkit 0.14.0 put a take with gaps in a database as NaN poses (`db build` refuses such a take now): search,
    clean --context and reconstruct opened it without a word. They open it still, and say in one `note:` line
    naming the database how many frames have missing joints and how to rebuild it."""
    import json

    import numpy as np

    from mocapkit.context import fit_context, resolve_context
    from mocapkit.database import MotionDatabase

    take = mocapkit.load(_db_sources()[1])
    db_dir = MotionDatabase.build([take], executor="serial", progress=False).save(tmp_path / "db")
    assert MotionDatabase.open(db_dir).missing_note() == ""  # a database built now has none
    rot = np.load(db_dir / "rotations.npy", mmap_mode="r+")  # what 0.14.0 wrote for a take with a gap: NaN poses
    rot[10:13, 5] = np.nan
    rot.flush()
    del rot
    db = MotionDatabase.open(db_dir)
    said = (f"{db_dir}: 3 frames of {db.num_frames} have missing joints (NaN), kept by mocapkit 0.14.0 or earlier; "
            "a search leaves their clips out and a reconstruction may fail: rebuild it from the takes filled")
    assert db.missing_frames() == 3 and db.missing_note().startswith(said)
    code, out, err = run("search", str(db_dir), _db_sources()[1], "--k", "1", "--start", "1.5", "--end", "2.5")
    assert code == 0 and f"note: {said}" in " ".join(out.split()) and "cost/frame" in out
    code, out, err = run("search", str(db_dir), _db_sources()[1], "--k", "1", "--start", "1.5", "--end", "2.5",
                         "--json")
    assert code == 0 and len(json.loads(out.strip().splitlines()[-1])) == 1 and f"note: {said}" in err
    assert sum(line.startswith("note: ") and "missing joints" in line for line in err.splitlines()) == 1
    code, out, err = run("db", "info", str(db_dir))  # db info said nothing of them
    assert code == 0 and f"note: {said}" in " ".join(out.split())
    code, out, err = run("db", "info", str(db_dir), "--json")
    assert code == 0 and json.loads(out)["missing_frames"] == 3
    ctx, note = fit_context(take, resolve_context([db_dir]))  # clean --context DB: among the context's notes
    assert ctx is not None and said in note
    # reconstruct failed on them with numpy's words after the note ("...005_120.amc: Eigenvalues did not converge"):
    # now one line naming the database and the rebuild, exit 2, nothing written
    out_file = tmp_path / "r.npz"
    code, out, err = run("reconstruct", "--db", str(db_dir), "-o", str(out_file), "--markers", _db_sources()[2])
    assert code == 2 and not out_file.exists() and "note:" not in out + err, (out, err)
    assert one_error_line(err) and (f"mocapkit: error: {db_dir}: 3 frames of {db.num_frames} have missing joints (NaN, "
                                    "kept by mocapkit 0.14.0 or earlier) and the reconstruction failed on them; rebuild "
                                    "the database with `mocapkit db build` (`mocapkit fill` a take with gaps first); "
                                    "nothing written") in " ".join(err.split()), err
