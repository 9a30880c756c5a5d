"""Tests of the package's top level: ``mocapkit.clean`` on a file or a Motion, and a cheap import."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, samples
from mocapkit.cleaning.pipeline import CleanResult


@pytest.fixture(scope="module")
def broken():
    """The bundled walk with two real-style capture errors, and where they are (F, J) bool."""
    m = mocapkit.load(samples.path("12_walk.amc"))
    bad, mask, _ = corrupt.real_errors(m, n_errors=2, seed=3)
    return bad, mask


@pytest.fixture(scope="module")
def cleaned(broken):
    return mocapkit.clean(broken[0])


def test_clean_a_motion_repairs_the_errors_and_keeps_the_rest(broken, cleaned):
    bad, mask = broken
    assert isinstance(cleaned, CleanResult)
    assert [s.name for s in cleaned.steps] == ["fill", "detect", "repair", "denoise"]
    assert cleaned.repaired.any() and (cleaned.flags & mask).any()
    untouched = ~(cleaned.filled | cleaned.repaired | cleaned.denoised)
    np.testing.assert_array_equal(cleaned.motion.rotations[untouched], bad.rotations[untouched])


def test_clean_a_path_equals_cleaning_the_loaded_motion(tmp_path, broken, cleaned):
    path = mocapkit.save(broken[0], tmp_path / "walk_broken.npz")
    res = mocapkit.clean(str(path))
    np.testing.assert_array_equal(res.motion.rotations, cleaned.motion.rotations)
    np.testing.assert_array_equal(res.flags, cleaned.flags)
    assert path.is_file() and not (tmp_path / "walk_broken.clean.npz").exists()  # the library writes nothing


def test_clean_passes_steps_and_threshold(broken):
    res = mocapkit.clean(broken[0], steps=["fill", "detect"], threshold=0.9)
    assert [s.name for s in res.steps] == ["fill", "detect"]
    assert res.params["threshold"] == 0.9 and not res.repaired.any()
    with pytest.raises(ValueError, match="threshold"):
        mocapkit.clean(broken[0], threshold=1.5)


def test_clean_passes_drifts_and_models(broken, monkeypatch):
    # the guide's drifts=True and models= (the CLI's --drifts, --ebf/--ebd) reach the pipeline
    import mocapkit.cleaning.pipeline as P

    seen, real = {}, P.clean

    def spy(*args, **kwargs):
        seen.update(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(P, "clean", spy)
    res = mocapkit.clean(broken[0], steps="fill,detect,denoise", drifts=True, models={"ebf": "ebf.pt"})
    assert seen["drifts"] is True and seen["models"] == {"ebf": "ebf.pt"}
    assert [s.name for s in res.steps] == ["fill", "detect", "denoise"]


def test_clean_an_amc_with_its_asf_and_file_context():
    amc = samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")
    res = mocapkit.clean(amc, [samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")], steps="fill,detect",
                         asf=samples.path("HDM_bk.asf"))
    assert res.num_frames == mocapkit.load(amc).num_frames
    assert "context" in res.steps[1].method


@pytest.fixture(scope="module")
def plain_capture():
    """The bundled Eb015pr.c3d cleaned by the library with no arguments (read, never changed, by several tests)."""
    return mocapkit.clean(samples.path("Eb015pr.c3d"))


def test_clean_takes_a_marker_capture_to_the_marker_cleaner(plain_capture):
    res = plain_capture
    assert type(res).__name__ == "MarkerCleanResult"
    assert not res.markers.missing().any() and res.original.missing().any()
    for kwargs in ({"steps": "fill,detect"}, {"threshold": 0.8}, {"drifts": True}, {"context": "none"}):
        with pytest.raises(mocapkit.MocapError, match="a marker capture is cleaned whole"):
            mocapkit.clean(samples.path("Eb015pr.c3d"), **kwargs)


@pytest.fixture(scope="module")
def capture_run(tmp_path_factory):
    """The bundled Eb015pr.c3d (26 markers, 450 frames; its own gaps and spikes) cleaned by the CLI with a report:
    (folder, input, output, record, what the command printed on stdout)."""
    d = tmp_path_factory.mktemp("markers")
    inp = samples.path("Eb015pr.c3d")
    code, stdout, err = _cli("clean", inp, "-o", d / "out.c3d")
    assert code == 0, err
    return d, inp, d / "out.c3d", d / "out.clean.npz", stdout


def _cli(*args):
    from tests.cli.helpers import run

    return run(*args)


def test_review_mode_of_a_marker_capture_changes_nothing_and_says_what_the_cli_says(tmp_path, plain_capture):
    inp = samples.path("Eb015pr.c3d")
    plain, res = plain_capture, mocapkit.clean(inp, steps="detect")
    assert res.review and res.output is res.original and res.fixes == plain.fixes and len(res.fixes) == 16
    assert np.array_equal(res.output.positions, plain.original.positions, equal_nan=True)
    code, out, err = _cli("clean", inp, "-o", tmp_path / "r.c3d", "--steps", "detect")
    assert code == 0, err
    assert res.summary()[0].startswith("review mode (--steps detect): the capture unchanged; cleaning would change "
                                       "274 of 11700 marker samples")
    assert all(f"  {line}\n" in out for line in res.summary()), (res.summary(), out)


def _decisions(folder, inp, choices, stamped=True, name="d.json"):
    """A decisions file as the report downloads it (``stamped``) or as written by hand, for the CLI's record."""
    from tests.shared import marker_decisions_file

    return marker_decisions_file(folder, inp, choices, name, stamped)


def test_decisions_apply_to_a_marker_capture_as_the_cli_applies_them(capture_run, plain_capture, tmp_path):
    """The same file gives the same capture and the same summary lines in the library and in the CLI, from a new
    cleaning and from the record; the rejected change's samples are the input's, every other sample plain clean's."""
    from mocapkit.io import load_markers

    d, inp, out, record, _ = capture_run
    path = _decisions(d, inp, {"foreign:LFT3:0-42": "reject", "gap:PV2:403-449": "reject"})
    plain = plain_capture
    for rec in (None, record):
        res = mocapkit.clean(inp, decisions=path, record=rec)
        assert res.decided is not None and len(res.fixes) == len(plain.fixes) - 2
        back = np.zeros(res.changed.shape, bool)
        back[0:43, plain.original.labels.index("LFT3")] = back[403:450, plain.original.labels.index("PV2")] = True
        assert np.array_equal(res.markers.positions[back], plain.original.positions[back], equal_nan=True)
        assert np.array_equal(res.markers.positions[~back], plain.markers.positions[~back], equal_nan=True)
        assert not res.spikes[back].any() and not res.filled[back].any()
        got = tmp_path / f"{rec is None}.c3d"
        code, stdout, err = _cli("clean", inp, "-o", got, "--decisions", path, *(["--record", rec] if rec else []))
        assert code == 0, err
        lines = res.summary()
        assert lines[0].startswith(f"{path} applied to ") and "14 of 16 changes accepted, 2 rejected" in lines[0]
        assert stdout.splitlines()[0].endswith(f": {lines[0]}") and all(x in stdout for x in lines[1:]), (lines, stdout)
        assert np.allclose(load_markers(got).positions, res.markers.positions, equal_nan=True, atol=1e-3)  # float32


def test_marker_decisions_as_a_dict_apply_as_their_file_does(capture_run):
    """decisions= takes the document as a dict for a marker capture as for a joint-angle take (refusals name
    "the decisions given")."""
    import json

    d, inp, out, record, _ = capture_run
    path = _decisions(d, inp, {"foreign:LFT3:0-42": "reject"}, name="dict.json")
    doc = json.loads(path.read_text())
    a, b = (mocapkit.clean(inp, decisions=x, record=record) for x in (doc, path))
    assert a.markers.positions.tobytes() == b.markers.positions.tobytes()
    assert a.summary()[0] == b.summary()[0].replace(str(path), "the decisions given", 1)
    with pytest.raises(mocapkit.MocapFormatError, match="the decisions given: decisions for another take"):
        mocapkit.clean(samples.path("Eb015pr.c3d"), decisions={**doc, "take": {**doc["take"], "sha256": "0" * 64}})


def test_marker_decisions_are_refused_in_the_library_with_the_clis_words(capture_run, tmp_path):
    """A hand-written file (no digest of the cleaning reviewed) is refused for a new cleaning and taken with the
    record, noting it; a file for another capture is refused; review mode takes no decisions; each refusal is the
    line the CLI says (the record as ``record=``, the CLI's ``--record``)."""
    from mocapkit.io import load_markers, save_markers

    d, inp, out, record, _ = capture_run
    hand = _decisions(d, inp, {"foreign:LFT3:0-42": "reject"}, stamped=False, name="hand.json")
    with pytest.raises(mocapkit.MocapFormatError) as exc:
        mocapkit.clean(inp, decisions=hand)
    code, _, err = _cli("clean", inp, "-o", tmp_path / "x.c3d", "--decisions", hand)
    said = str(exc.value)  # the command's line, naming the record as each is given it
    assert code == 2 and "keeps no digest" in said and said.endswith("record with record=") and "--record" not in said
    assert said.replace("with record=", "with --record") in err, (exc.value, err)
    res = mocapkit.clean(inp, decisions=hand, record=record)
    assert any(x.startswith(f"note: {hand} keeps no digest") for x in res.summary())
    other = save_markers(load_markers(inp)[:400], tmp_path / "other.c3d")
    with pytest.raises(mocapkit.MocapFormatError, match="decisions for another take"):
        mocapkit.clean(other, decisions=hand)
    with pytest.raises(mocapkit.MocapError, match="review mode"):
        mocapkit.clean(inp, steps="detect", decisions=hand)
    with pytest.raises(mocapkit.MocapError, match="applied with decisions"):
        mocapkit.clean(inp, record=record)


def test_the_summary_says_how_frames_relate_to_the_files_numbers_as_the_cli_does(tmp_path, capsys, plain_capture,
                                                                                   capture_run):
    """An AMC numbers its frames from 1, a C3D from its header's first frame: ``mocapkit clean`` says how its 0-based
    frames relate to them, and the library's summary says the same line; a Motion numbers no frames."""
    import shutil

    from mocapkit.cli import main

    shutil.copy(samples.path("12.asf"), tmp_path / "bad.asf")
    bad, _, _ = corrupt.real_errors(mocapkit.load(samples.path("12_walk.amc")), n_errors=4, seed=11)
    inp = mocapkit.save(bad, tmp_path / "bad.amc")
    note = "frame numbers count from 0, the take's first frame, which is {}'s frame 1: its frame 11 is frame 10 here"
    lines = mocapkit.clean(inp, steps="detect").summary()
    assert lines[-1] == note.format("bad.amc"), lines
    assert main(["clean", str(inp), "-o", str(tmp_path / "o.amc"), "--steps", "detect"]) == 0
    assert f"\n  {lines[-1]}\n" in capsys.readouterr().out
    assert not any("is frame 10 here" in x for x in mocapkit.clean(bad, steps="detect").summary())
    c3d = samples.path("Eb015pr.c3d")
    lines = plain_capture.summary()
    assert lines[-1] == note.format("Eb015pr.c3d"), lines
    assert f"\n  {lines[-1]}\n" in capture_run[-1]  # `mocapkit clean Eb015pr.c3d -o out.c3d` printed it
    # a part of the take: its frame 0 is the capture's frame 101 (it said "Eb015pr numbers its frames from 101",
    # though Eb015pr.c3d numbers them from 1)
    part = mocapkit.io.load_markers(c3d)[100:]
    lines = mocapkit.clean(part, steps="detect").summary()
    assert lines[-1] == ("frame numbers count from 0, the take's first frame, which is Eb015pr's frame 101: its frame "
                         "111 is frame 10 here"), lines


def test_clean_takes_the_noise_level_the_amc_rate_and_the_unit_as_the_cli_does(tmp_path):
    """``noise_deg``, ``fps`` and ``unit`` are clean's --noise-deg, --amc-fps and --unit; ``fps`` is for AMC files."""
    amc = samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")
    asf = samples.path("HDM_bk.asf")
    res = mocapkit.clean(amc, "none", steps="fill,detect", asf=asf, fps=60.0)
    assert res.motion.fps == 60.0
    bad = corrupt.angular_noise(mocapkit.load(amc, asf=asf), amount=0.5, seed=1)[0]
    assert mocapkit.clean(bad, "none", steps="denoise").denoised.any()
    high = mocapkit.clean(bad, "none", steps="denoise", noise_deg=1e6)
    assert not high.denoised.any() and "level > 1e+06 deg" in high.steps[0].note
    with pytest.raises(mocapkit.MocapFormatError, match=r"131_01\.bvh.*fps= applies to \.amc files only"):
        mocapkit.clean(samples.path("131_01.bvh"), fps=60.0)
    with pytest.raises(mocapkit.MocapError, match="a marker capture is cleaned whole"):
        mocapkit.clean(samples.path("Eb015pr.c3d"), noise_deg=3.0)
    take = tmp_path / "take.bvh"
    mocapkit.save(mocapkit.load(samples.path("131_01.bvh"))[:60], take)
    assert mocapkit.clean(take, "none", steps="fill", unit="cm").motion.skeleton.unit_cm == 1.0


def test_clean_refuses_what_is_not_a_motion(tmp_path):
    with pytest.raises(mocapkit.MocapFormatError, match=r"131_01\.bvh.*asf= applies to \.amc files only"):
        mocapkit.clean(samples.path("131_01.bvh"), asf=samples.path("12.asf"))
    with pytest.raises(mocapkit.MocapFormatError, match="nothing.npz"):
        mocapkit.clean(tmp_path / "nothing.npz")
    with pytest.raises(TypeError, match="Motion or a file path"):
        mocapkit.clean(np.zeros((4, 3)))


def test_import_is_cheap():
    """Importing the package loads neither torch nor the cleaning pipeline (and so compiles no numba kernel), nor
    scipy.spatial (0.3 s; mocapkit.rotations imports it where it is used)."""
    code = ("import sys, mocapkit; print(sorted(m for m in ('torch', 'numba', 'mocapkit.cleaning', 'scipy.spatial') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_save_replaces_like_open_and_refuses_with_overwrite_false(tmp_path):
    m = mocapkit.load(mocapkit.samples.path("12_walk.amc"))[:10]
    p = mocapkit.save(m, tmp_path / "a.npz")
    before = p.read_bytes()
    with pytest.raises(mocapkit.MocapFormatError, match="already exists; pass overwrite=True"):
        mocapkit.save(m[:5], p, overwrite=False)
    assert p.read_bytes() == before
    mocapkit.save(m[:5], p)  # the default: replaced, as open(path, "w") would
    assert mocapkit.load(p).num_frames == 5


def test_clean_checks_its_arguments_before_any_work(tmp_path):
    """Model files were checked only when a take needed them (the CLI refuses --ebf typo.pt up front), a Motion's
    fps=/asf=/unit= were ignored, and wrong types gave errors from deep inside (a bare ValueError, '<' between str
    and float, 'bool' object is not iterable) or the CLI's wording."""
    import mocapkit
    from mocapkit.cleaning import deep

    m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:200]
    with pytest.raises(mocapkit.MocapFormatError, match="typo_ebf.pt: no such model file"):
        mocapkit.clean(m, models={"ebf": tmp_path / "typo_ebf.pt"})
    with pytest.raises(mocapkit.MocapFormatError, match="an EBD model, but this needs an EBF"):
        mocapkit.clean(m, models={"ebf": "ebd.pt"})
    with pytest.raises(mocapkit.MocapError, match=r"models\['ebf'\] is an EBD model"):
        mocapkit.clean(m, models={"ebf": deep.load_model("ebd.pt")})
    with pytest.raises(TypeError, match="models must be a dict"):
        mocapkit.clean(m, models=["ebf.pt"])
    for kw in ({"fps": 30}, {"asf": "actor.asf"}, {"unit": "m"}):
        with pytest.raises(mocapkit.MocapError, match=f"{next(iter(kw))}= applies to a file"):
            mocapkit.clean(m, **kw)
    with pytest.raises(TypeError, match="threshold must be a number in"):
        mocapkit.clean(m, threshold="0.4")
    with pytest.raises(TypeError, match="context must be None, False"):
        mocapkit.clean(m, context=True)
    with pytest.raises(ValueError, match="no step given"):
        mocapkit.clean(m, steps="")
    with pytest.raises(mocapkit.MocapError, match="^unit='metres': one of mm, cm, m, in"):
        mocapkit.clean(mocapkit.samples.path("131_01.bvh"), unit="metres")


def test_a_results_masks_are_read_only_and_its_own():
    """CleanResult is frozen, but its masks were writable and the detection's own: res.repaired[:] = False changed
    what decisions.changes listed."""
    walk = mocapkit.load(samples.path("12_walk.amc"))[:150]
    broken, _, _ = corrupt.real_errors(walk, seed=1)
    res = mocapkit.clean(broken, context=False, steps="fill,detect,repair")
    for name in ("mdm", "flags", "filled", "repaired", "denoised", "noise", "causes", "zeros"):
        a = getattr(res, name)
        with pytest.raises(ValueError, match="read-only"):
            a[...] = 0
        with pytest.raises(ValueError, match="WRITEABLE"):
            a.setflags(write=True)
    assert res.detection.flags is not res.flags


def test_decisions_for_a_motion_are_read_as_the_command_reads_them(broken, tmp_path):
    """A joint-angle take's decisions apply here too (tests/cleaning/test_decide.py): a missing file is the
    command's "no such file", before any cleaning."""
    with pytest.raises(mocapkit.MissingFileError, match="d.json"):
        mocapkit.clean(broken[0], decisions=tmp_path / "d.json")


def test_library_refusals_name_the_librarys_parameters_not_the_clis_flags(tmp_path):
    """Refusals raised from ``mocapkit.clean`` said the command's spellings (``--steps detect``, ``--unit``,
    ``--context``) to a Python caller, who has none of them; each now names what Python gives, or neither."""
    c3d = samples.path("Eb015pr.c3d")
    with pytest.raises(mocapkit.MocapError) as exc:
        mocapkit.clean(c3d, steps="detect", decisions={"decisions": {}})
    assert str(exc.value) == f"{c3d}: review mode (steps='detect') changes nothing; decisions apply to a cleaning"
    amc = samples.path("12_walk.amc")  # its ASF states its unit
    with pytest.raises(mocapkit.MocapFormatError) as exc:
        mocapkit.clean(amc, steps="fill", unit="mm")
    assert str(exc.value).endswith("not mm: unit= is for a file that states none"), exc.value
    with pytest.raises(mocapkit.MocapFormatError) as exc:
        mocapkit.clean(amc, tmp_path / "missing", steps="detect")
    assert str(exc.value) == (f"{tmp_path / 'missing'}: no such file or folder (a context is a database folder, a "
                              "folder of takes or files)")


def test_clean_takes_the_joint_map_of_a_context_folder_as_the_cli_does(tmp_path, monkeypatch):
    """``joint_map=`` (a dict, or the JSON file ``--joint-map`` takes) lets a folder of a rig whose names say no roles
    be the context of ``mocapkit.clean``, and the result's request keeps it as the CLI's record does."""
    import json
    from pathlib import Path

    from mocapkit.errors import MocapFormatError
    from tests.shared import unnamed

    data = Path(__file__).parent / "data"
    folder = tmp_path / "kt"
    folder.mkdir()
    for n in ("dataset-1_dash_normal_001", "dataset-2_run_active_049"):
        m = mocapkit.load(data / f"{n}.bvh")
        mocapkit.save(unnamed(m), folder / f"{n}.bvh")
    jm = {f"bone{j}": n for j, n in enumerate(m.skeleton.joint_names)}
    (tmp_path / "map.json").write_text(json.dumps(jm))
    take = unnamed(mocapkit.load(data / "dataset-1_run_masculinity_001.bvh"))
    monkeypatch.setenv("MOCAPKIT_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(MocapFormatError, match="dataset-1_dash_normal_001.bvh: "):
        mocapkit.clean(take, context=folder)
    for given in (jm, tmp_path / "map.json"):
        res = mocapkit.clean(take, context=folder, joint_map=given)
        assert any("joints named by its joint map" in n for n in res.notes)
        assert np.array_equal(res.motion.rotations, take.rotations)  # a clean take untouched
        assert res.params["request"]["joint_map"] == dict(sorted(jm.items()))
    with pytest.raises(MocapFormatError, match=r"nomap\.json: "):
        mocapkit.clean(take, context=folder, joint_map=tmp_path / "nomap.json")
