"""A refusal names the options a take was cleaned with as its caller gives them: the command line's flags and values
as typed, or the Python API's keywords; an option left unset in words, never ``None``."""

from mocapkit.batch_request import clean_request, request_change
from mocapkit.cleaning.decisions import RECORD_FLAG, RECORD_KEYWORD, request_difference
from mocapkit.marker_files import marker_request


def test_a_changed_marker_request_is_said_in_the_callers_words():
    was, now = marker_request(zeros_as_gaps=False), marker_request(max_gap_s=0.05, zeros_as_gaps=False)
    assert request_change(was, now, flags=True) == "it was cleaned without --max-gap (now --max-gap 0.05)"
    assert request_change(was, now) == "it was cleaned without max_gap_s (now max_gap_s=0.05)"
    assert request_change(now, marker_request(unit="cm", zeros_as_gaps=False), flags=True) == (
        "it was cleaned without --unit (now --unit cm), with --max-gap 0.05 (now without it)")
    assert request_change(marker_request(max_error_mm=20.0, review=True), marker_request(), flags=True) == (
        "it was cleaned with --max-fill-error 20 (now without it), with --steps detect (now all steps)")
    assert request_change(marker_request(), marker_request(unit="cm", review=True)) == (
        "it was cleaned without unit (now unit='cm'), with all steps (now steps='detect')")
    assert request_change(was, now, flags=True) != request_change(was, now) and "None" not in request_change(was, now)


def test_a_changed_joint_angle_request_is_said_in_the_callers_words():
    was, now = clean_request(steps="detect", drifts=True), clean_request(threshold=0.7, noise_deg=3, amc_fps=100.0)
    assert request_change(was, now, flags=True) == (
        "it was cleaned with --steps detect (now fill,detect,repair,denoise), with --threshold 0.5 (now 0.7), "
        "with --drifts (now without it), with --noise-deg 1 (now 3), without --amc-fps (now --amc-fps 100)")
    assert request_change(was, now) == (
        "it was cleaned with steps='detect' (now 'fill,detect,repair,denoise'), with threshold=0.5 (now 0.7), "
        "with drifts=True (now False), with noise_deg=1 (now 3), without amc_fps (now amc_fps=100)")
    ctx, other = clean_request(context=["none"]), clean_request(context=["none"], models={"ebf": "ebf_bandai.pt"})
    assert request_change(ctx, other, flags=True) == "it was cleaned without --ebf/--ebd (now --ebf ebf_bandai.pt)"
    assert request_change(other, ctx) == "it was cleaned with models={'ebf': 'ebf_bandai.pt'} (now without it)"


def test_a_decisions_files_other_cleaning_is_said_as_its_record_was_given():
    was, now = {"context": "default", "threshold": 0.5}, {"context": ["ctx"], "threshold": 0.4}
    assert request_difference(was, now, RECORD_FLAG) == ("reviewed without --context (now --context ctx), "
                                                         "reviewed with --threshold 0.5 (now 0.4)")
    assert request_difference(was, now, RECORD_KEYWORD) == ("reviewed without context (now context=['ctx']), "
                                                            "reviewed with threshold=0.5 (now 0.4)")
    assert request_difference(was, None, RECORD_FLAG) == ""


def test_python_values_are_quoted_one_way_in_a_line():
    """Decisions made on another cleaning, refused to a Python caller, said `unit="cm"` (JSON) beside
    `record='R.clean.npz'` (Python's repr) in one line: every value a refusal gives a Python keyword is now
    Python's repr, as the caller writes it."""
    import pytest

    from mocapkit.cleaning.decisions import check_request
    from mocapkit.errors import MocapFormatError

    doc = {"cleaning": {"record": "R.clean.npz", "request": marker_request()}}
    with pytest.raises(MocapFormatError) as err:
        check_request(doc, "d.json", marker_request(unit="cm", review=True), RECORD_KEYWORD)
    said = str(err.value)
    assert "reviewed without unit (now unit='cm'), reviewed with all steps (now steps='detect')" in said, said
    assert "record='R.clean.npz'" in said and '"' not in said


def test_a_marker_captures_review_mode_is_refused_with_decisions_in_the_callers_words(tmp_path):
    import pytest

    from mocapkit import samples
    from mocapkit.errors import MocapError
    from mocapkit.marker_files import clean_marker_file

    inp, said = samples.path("Eb015pr.c3d"), "changes nothing; decisions apply to a cleaning"
    for flags, mode in ((False, "steps='detect'"), (True, "--steps detect")):
        with pytest.raises(MocapError) as err:
            clean_marker_file(inp, tmp_path / "out.c3d", review=True, decisions=tmp_path / "d.json", flags=flags)
        assert str(err.value) == f"{inp}: review mode ({mode}) {said}"
    assert not list(tmp_path.iterdir())


def test_a_batchs_joint_angle_options_refused_for_a_marker_capture_are_said_as_given(tmp_path):
    """clean-batch --drifts over a folder holding a capture failed it with "drifts applies only to joint-angle takes":
    Python's name to a CLI user."""
    import shutil

    from mocapkit import samples
    from mocapkit.batch import clean_batch

    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(samples.path("Eb015pr.c3d"), src / "e.c3d")
    for flags, said in ((True, "--drifts, --noise-deg apply"), (False, "drifts=, noise_deg= apply")):
        s = clean_batch(src, tmp_path / f"out{flags}", drifts=True, noise_deg=2.0, executor="serial", progress=False,
                        flags=flags)
        assert s.count("failed") == 1 and f"{said} only to joint-angle takes" in s.failed[0]["reason"], s.rows


def test_joint_angle_options_refused_for_a_marker_capture_are_said_as_a_python_call_writes_them():
    """`mocapkit.clean("x.c3d", steps="fill,denoise", threshold=0.8)` said "steps fill,denoise, threshold apply only
    to joint-angle takes": bare names a Python caller never wrote. Now as the call writes them."""
    import pytest

    import mocapkit
    from mocapkit import samples

    with pytest.raises(mocapkit.MocapError) as err:
        mocapkit.clean(samples.path("Eb015pr.c3d"), steps="fill,denoise", threshold=0.8, drifts=True, noise_deg=2.0)
    assert str(err.value).endswith(": a marker capture is cleaned whole (label swaps, spikes, gaps): "
                                   "steps='fill,denoise', threshold=, drifts=, noise_deg= apply only to joint-angle "
                                   "takes"), str(err.value)


def test_clean_file_refuses_threshold_and_context_for_a_marker_capture_as_it_refuses_drifts(tmp_path):
    """`clean_file("x.c3d", ..., threshold=0.8, context=[...])` cleaned the capture whole and wrote it, the two
    joint-angle options silently ignored, where it refused `drifts=` and `noise_deg=` in one line. Now refused alike,
    nothing written; a batch's CLI user reads the flags."""
    import pytest

    from mocapkit import samples
    from mocapkit.batch import clean_file
    from mocapkit.errors import MocapError

    inp = samples.path("Eb015pr.c3d")
    for flags, said in ((False, "threshold=, context= apply"), (True, "--threshold, --context apply")):
        with pytest.raises(MocapError) as err:
            clean_file(inp, tmp_path / "out.c3d", threshold=0.8, context=[tmp_path / "ctx"], flags=flags)
        assert str(err.value) == (f"{inp}: a marker capture is cleaned whole (label swaps, spikes, gaps): {said} "
                                  "only to joint-angle takes"), str(err.value)
    with pytest.raises(MocapError, match=r": context= applies only"):
        clean_file(inp, tmp_path / "out.c3d", context=["none"])
    assert not list(tmp_path.iterdir())


def test_clean_commands_joint_angle_flags_refused_for_a_marker_capture_keep_their_words_and_order(tmp_path):
    """`mocapkit clean` kept its own list of the flags a marker capture refuses beside marker_files' table; now the
    table's (plus --reference, the command's own): the line it prints is the one it printed, steps as typed."""
    from mocapkit import samples

    from tests.cli.helpers import one_error_line, run

    ref = tmp_path / "ref.bvh"
    ref.write_text("")
    code, _, err = run("clean", samples.path("Eb015pr.c3d"), "-o", tmp_path / "x.c3d", "--steps", "denoise,fill",
                       "--threshold", "0.8", "--noise-deg", "2", "--context", "none", "--drifts", "--reference", ref,
                       "--ebf", "ebf_bandai.pt", "--ebd", "ebd_bandai.pt")
    assert code == 2 and one_error_line(err), err
    assert ("a marker capture is cleaned whole (label swaps, spikes, gaps): --steps denoise,fill, --threshold, "
            "--noise-deg, --context, --drifts, --reference, --ebf, --ebd apply only to joint-angle takes") in \
        " ".join(err.split()), err


def test_a_joint_map_is_refused_for_a_marker_capture_on_every_entry_point(tmp_path):
    """`clean_file("x.c3d", ..., joint_map={...})` (a clean-batch row's call) and `mocapkit clean x.c3d --joint-map m`
    cleaned the capture whole and wrote it, the map silently ignored, where `mocapkit.clean` refused `joint_map=`.
    Now every entry point refuses it in one line naming the file and the option as its caller wrote it, and an AMC's
    skeleton or rate (`asf=`, `amc_fps=`/`fps=`, the tables' amc_fps) given with a marker capture is refused too,
    nothing written."""
    import shutil

    import pytest

    import mocapkit
    from mocapkit import samples
    from mocapkit.batch import clean_batch, clean_file
    from mocapkit.errors import MocapError

    from tests.cli.helpers import one_error_line, run

    inp, jm = samples.path("Eb015pr.c3d"), {"kt_b04": "Hand_L"}
    tail = ": a marker capture is cleaned whole (label swaps, spikes, gaps): {} applies only to joint-angle takes"
    with pytest.raises(MocapError) as err:
        mocapkit.clean(inp, joint_map=jm)
    assert str(err.value) == "Eb015pr" + tail.format("joint_map=")  # the take's name: as before
    for flags, said in ((False, "joint_map="), (True, "--joint-map")):
        with pytest.raises(MocapError) as err:
            clean_file(inp, tmp_path / "out.c3d", joint_map=jm, flags=flags)
        assert str(err.value) == f"{inp}" + tail.format(said), str(err.value)
    with pytest.raises(MocapError, match="amc_fps= is the frame rate of an .amc input"):
        clean_file(inp, tmp_path / "out.c3d", amc_fps=120.0)
    with pytest.raises(MocapError, match=r"Eb015pr.c3d: fps= applies to .amc files only"):
        mocapkit.clean(inp, fps=120.0)
    with pytest.raises(MocapError, match=r"Eb015pr.c3d: asf= applies to .amc files only"):
        mocapkit.clean(inp, asf=samples.path("12.asf"))
    (tmp_path / "map.json").write_text('{"kt_b04": "Hand_L"}')
    code, _, stderr = run("clean", inp, "-o", tmp_path / "x.c3d", "--joint-map", tmp_path / "map.json")
    assert code == 2 and one_error_line(stderr), stderr
    assert f"{inp}" + tail.format("--joint-map") in " ".join(stderr.split()), stderr
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(inp, src / "e.c3d")
    s = clean_batch(src, tmp_path / "out", joint_map=jm, executor="serial", progress=False, flags=True)
    assert s.count("failed") == 1 and s.failed[0]["reason"].endswith(tail.format("--joint-map")[2:]), s.rows
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in", "map.json"]  # nothing written
