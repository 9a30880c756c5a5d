"""``mocapkit clean`` and ``clean-batch`` on marker captures, end to end: C3D in, C3D out, read back with ezc3d."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from mocapkit.io import load_markers, save_markers

from .helpers import SAMPLE, one_error_line, run

CMU = Path(__file__).resolve().parents[1] / "data" / "85_02.c3d"


def _ezc3d_points(path: Path) -> np.ndarray:
    """(F, M, 3) points as ezc3d reads them, NaN where the residual is negative."""
    import ezc3d

    c = ezc3d.c3d(str(path))
    pts = np.asarray(c["data"]["points"][:3]).transpose(2, 1, 0)
    res = np.asarray(c["data"]["meta_points"]["residuals"][0]).T
    pts[res < 0] = np.nan
    return pts


def _write_with_ezc3d(path: Path, points: np.ndarray, labels, fps: float) -> None:
    """A C3D written by ezc3d alone (not mocapkit's writer): points (F, M, 3) in mm, residual -1 where NaN."""
    import ezc3d

    f, m = points.shape[:2]
    pts = np.ones((4, m, f))
    pts[:3] = points.transpose(2, 1, 0)
    res = np.zeros((1, m, f))
    res[0][np.isnan(pts[0])] = -1.0
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [float(fps)]
    c["parameters"]["POINT"]["LABELS"]["value"] = list(labels)
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    c["data"]["points"] = pts
    c["data"]["meta_points"]["residuals"] = res
    c.write(str(path))


@pytest.fixture(scope="module")
def cut_take(tmp_path_factory):
    """85_02 (complete, 41 markers, 120 Hz) with gaps cut at random, written with ezc3d: (path, truth, gap mask).

    One gap of 0.5-2 s on each of eight markers drawn at random: the
    independent check of issue 22, run through the command line.
    """
    d = tmp_path_factory.mktemp("cut")
    ms = load_markers(CMU)
    truth = np.array(ms.positions) * 10.0 * ms.unit_cm
    rng = np.random.default_rng(22)
    f, m = truth.shape[:2]
    mask = np.zeros((f, m), bool)
    for k in rng.choice(m, 8, replace=False):
        n = int(rng.uniform(0.5, 2.0) * ms.fps)
        a = int(rng.integers(60, f - n - 60))
        mask[a:a + n, k] = True
    y = truth.copy()
    y[mask] = np.nan
    path = d / "cut.c3d"
    _write_with_ezc3d(path, y, ms.labels, ms.fps)
    return path, truth, mask


def _interpolated(points: np.ndarray, kind: str) -> np.ndarray:
    """Each coordinate interpolated over its gaps from all its seen samples (numpy / scipy, not mocapkit)."""
    from scipy.interpolate import CubicSpline

    out = points.copy()
    t = np.arange(len(points))
    for k in range(points.shape[1]):
        seen = ~np.isnan(points[:, k, 0])
        if seen.all():
            continue
        for c in range(3):
            if kind == "linear":
                out[~seen, k, c] = np.interp(t[~seen], t[seen], points[seen, k, c])
            else:
                out[~seen, k, c] = CubicSpline(t[seen], points[seen, k, c])(t[~seen])
    return out


def test_clean_c3d_end_to_end(cut_take, tmp_path):
    inp, truth, mask = cut_take
    out = tmp_path / "clean.c3d"
    code, stdout, stderr = run("clean", inp, "-o", out, "--report", tmp_path / "r.html", "--png", tmp_path / "p.png")
    assert code == 0, stderr
    # the files as a person lists them (it said "wrote A and B and C and D")
    assert f"wrote {out}, {tmp_path / 'clean.clean.npz'}, {tmp_path / 'r.html'} and {tmp_path / 'p.png'}: " in stdout, stdout
    assert f"{len(np.flatnonzero(mask.any(0)))} gaps filled" in stdout
    assert "mm off the straight line between the gap's ends" in stdout  # what a gap's size measures (no error)
    got = _ezc3d_points(out)
    before = _ezc3d_points(inp)
    assert np.array_equal(np.isnan(before), np.repeat(mask[..., None], 3, -1))  # the gaps as ezc3d wrote them
    assert not np.isnan(got).any()
    assert np.array_equal(got[~mask], before[~mask])  # observed samples unchanged, as written
    rms = lambda p: np.sqrt(np.mean(np.sum((p[mask] - truth[mask]) ** 2, -1)))  # noqa: E731
    err = rms(got)
    best_interp = min(rms(_interpolated(before, "linear")), rms(_interpolated(before, "cubic")))
    assert err < 0.5 * best_interp
    assert err < 40.0  # mm: the fill follows the marker's rigid neighbours, not a line through the room
    with np.load(tmp_path / "clean.clean.npz") as rec:
        assert np.array_equal(rec["filled"], mask)
    page = (tmp_path / "r.html").read_text()
    assert "gap filled" in page and '"kind"' in page and "off the straight line" in page
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"


@pytest.fixture(scope="module")
def cut_take_as_trc(cut_take, tmp_path_factory):
    """``clean CUT.c3d -o clean.trc``, run once for the two tests that read its output: (out, exit code, stdout,
    stderr). The tests only read the file and the record beside it."""
    out = tmp_path_factory.mktemp("trc") / "clean.trc"
    return (out, *run("clean", cut_take[0], "-o", out))


def test_clean_c3d_to_trc_and_refusals(cut_take, cut_take_as_trc, tmp_path):
    inp, _, _ = cut_take
    out, code, _, stderr = cut_take_as_trc
    assert code == 0, stderr
    assert not load_markers(out).missing().any()
    code, _, stderr = run("clean", inp, "-o", out)  # exists: refused without --overwrite
    assert code != 0 and one_error_line(stderr)
    code, _, stderr = run("clean", inp, "-o", tmp_path / "x.bvh")
    assert code != 0 and one_error_line(stderr) and not (tmp_path / "x.bvh").exists()
    code, _, stderr = run("clean", inp, "-o", tmp_path / "y.c3d", "--reference", inp)
    assert code != 0 and "--reference" in stderr and not (tmp_path / "y.c3d").exists()


def test_max_gap_and_max_fill_error_leave_gaps_missing_and_say_why(cut_take, tmp_path):
    # clean_markers had max_gap_s and the CLI no way to set it; --max-fill-error sets the limit on a fill's
    # expected error (default: the marker's distance to its nearest marker)
    inp, _, mask = cut_take
    code, stdout, stderr = run("clean", inp, "-o", tmp_path / "a.c3d", "--max-gap", "0.01")
    assert code == 0, stderr
    assert np.array_equal(np.isnan(_ezc3d_points(tmp_path / "a.c3d"))[..., 0], mask)  # every gap left as read
    assert "left missing: longer than --max-gap (0.01 s)" in stdout and "no plausible fill" not in stdout  # and named
    code, stdout, stderr = run("clean", inp, "-o", tmp_path / "b.c3d", "--max-fill-error", "0.001")
    assert code == 0, stderr
    assert "left missing: no plausible fill" in stdout and "over the 0 mm a fill may be off" in stdout
    code, _, stderr = run("clean", SAMPLE, "-o", tmp_path / "c.bvh", "--max-fill-error", "10")
    assert code != 0 and one_error_line(stderr) and "applies only to marker captures" in stderr


@pytest.fixture
def mixed_folder(cut_take, tmp_path):
    """IN_DIR with the cut marker capture and a skeletal take (the CMU sample's first 2 s: what a batch does with a
    joint-angle take beside a marker capture does not depend on its length)."""
    import mocapkit

    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(cut_take[0], src / "markers.c3d")
    mocapkit.save(mocapkit.load(SAMPLE)[:240], src / "walk.bvh")
    return src


def test_clean_batch_mixes_marker_and_skeletal_takes(mixed_folder, tmp_path):
    code, stdout, stderr = run("clean-batch", mixed_folder, tmp_path / "out", "--executor", "serial")
    assert code == 0, stderr + stdout
    assert (tmp_path / "out" / "markers.c3d").exists() and (tmp_path / "out" / "markers.clean.npz").exists()
    assert (tmp_path / "out" / "walk.bvh").exists()
    assert "2 cleaned" in stdout
    assert not load_markers(tmp_path / "out" / "markers.c3d").missing().any()


def test_clean_batch_takes_max_gap_for_its_marker_captures_and_leaves_joint_angle_takes_alone(mixed_folder, cut_take,
                                                                                              tmp_path):
    """clean had --max-gap and --max-fill-error, clean-batch neither: a folder of captures could not set them."""
    _, _, mask = cut_take
    code, stdout, stderr = run("clean-batch", mixed_folder, tmp_path / "out", "--executor", "serial",
                               "--max-gap", "0.01")
    assert code == 0, stderr + stdout
    assert np.array_equal(np.isnan(_ezc3d_points(tmp_path / "out" / "markers.c3d"))[..., 0], mask)  # left as read
    walk = tmp_path / "walk_alone"
    assert run("clean", mixed_folder / "walk.bvh", "-o", walk.with_suffix(".bvh"))[0] == 0
    assert (tmp_path / "out" / "walk.bvh").read_bytes() == walk.with_suffix(".bvh").read_bytes()  # no effect there


@pytest.mark.parametrize("options", [["--steps", "fill"], ["--threshold", "0.8"], ["--drifts"], ["--context", "none"]])
def test_options_of_joint_angle_takes_are_refused_for_a_marker_capture(cut_take, tmp_path, options):
    """Review mode (--steps detect) must not change a take: a marker capture, which has none, is refused, not cleaned."""
    inp, _, _ = cut_take
    (tmp_path / "d.json").write_text("{}")
    options = [str(tmp_path / o) if o == "d.json" else o for o in options]
    code, _, stderr = run("clean", inp, "-o", tmp_path / "x.c3d", *options)
    assert code == 2 and one_error_line(stderr), stderr
    assert "a marker capture is cleaned whole" in stderr and options[0] in stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.json"]


def test_review_mode_batch_writes_its_marker_captures_unchanged(mixed_folder, tmp_path):
    code, stdout, stderr = run("clean-batch", mixed_folder, tmp_path / "out", "--executor", "serial", "--steps", "detect")
    assert code == 0, stderr + stdout
    a, b = load_markers(mixed_folder / "markers.c3d"), load_markers(tmp_path / "out" / "markers.c3d")
    assert np.array_equal(a.positions, b.positions, equal_nan=True) and (tmp_path / "out" / "walk.bvh").exists()


@pytest.fixture(scope="module")
def eb015pr_as_c3d(tmp_path_factory):
    """``clean Eb015pr.c3d -o e.c3d``, run once for the two tests that read what it said and wrote: (out, exit code,
    stdout, stderr)."""
    out = tmp_path_factory.mktemp("eb015pr") / "e.c3d"
    return (out, *run("clean", mocapkit_sample("Eb015pr.c3d"), "-o", out))


def test_what_the_output_format_cannot_hold_is_said_in_one_note(eb015pr_as_c3d, tmp_path):
    # trial11: C3D -> TRC / npz dropped analogs, events, parameters, residuals and camera masks without a word
    c3d = mocapkit_sample("Eb015pr.c3d")
    code, stdout, _ = run("clean", c3d, "-o", tmp_path / "x.trc")
    assert code == 0
    said = [line for line in stdout.splitlines() if line.startswith("note: ")]
    assert said[-1] == (f"note: {tmp_path / 'x.trc'}: not written, as TRC cannot hold them: the input's 16 analog "
                        "channels, events, parameter groups, residuals and camera masks (a .c3d output keeps them)")
    assert all("samples the cleaning wrote" in n or "interpolated" in n for n in said[:-1])  # what TRC cannot tell apart
    code, stdout, _ = run("convert", c3d, tmp_path / "x.npz")
    assert code == 0 and f"note: {tmp_path / 'x.npz'}: not written, as a marker npz cannot hold them" in stdout
    _, code, stdout, _ = eb015pr_as_c3d  # clean Eb015pr.c3d -o e.c3d
    assert code == 0 and "note: " not in stdout


def test_a_reader_note_is_shown_by_clean_convert_and_clean_batch(tmp_path):
    # trial11: a capture's repeated labels were renamed on writing without a word (BTK's Gait.c3d: RKNE -> RKNE_2)
    ms = load_markers(CMU)[:120]  # the take's first second: a note about its labels, whatever its length
    folder = tmp_path / "in"
    folder.mkdir()
    labels = list(ms.labels)
    labels[5] = labels[4]
    _write_with_ezc3d(folder / "dup.c3d", np.array(ms.positions), labels, ms.fps)
    note = (f"the file repeats marker label {labels[4]}: the repeats are called {labels[4]}_2 here; files written "
            "from this take keep the file's labels")
    code, stdout, _ = run("convert", folder / "dup.c3d", tmp_path / "d.trc")
    assert code == 0 and f"note: {folder / 'dup.c3d'}: {note}" in stdout
    code, stdout, _ = run("clean", folder / "dup.c3d", "-o", tmp_path / "d.c3d")
    assert code == 0 and f"note: {folder / 'dup.c3d'}: {note}" in stdout
    code, stdout, _ = run("clean-batch", folder, tmp_path / "out", "--executor", "serial")
    assert code == 0 and f"note: {folder / 'dup.c3d'}: {note}" in stdout  # as clean and convert say it
    import ezc3d

    for out in (tmp_path / "d.c3d", tmp_path / "out" / "dup.c3d"):
        assert list(ezc3d.c3d(str(out))["parameters"]["POINT"]["LABELS"]["value"]) == labels
    assert (tmp_path / "d.trc").read_text().splitlines()[3].split("\t")[2::3][4:6] == [labels[4], labels[4]]


@pytest.mark.parametrize("inp, out, kind, said", [
    ("m.c3d", "x.c3d", "noise", "m.c3d: --kind noise changes joint rotations, which a marker capture has none of; the "
                                "kind that works on marker files (.c3d, .trc, marker .npz): gaps"),
    ("m.npz", "x.npz", "spike", "m.npz: --kind spike changes joint rotations"),
    ("m.trc", "x.trc", "gap", "m.trc: --kind gap is no corruption kind; the kind that works on marker files"),
    ("131_01.bvh", "x.c3d", "noise", "x.c3d: a skeleton take is written as .bvh, .amc or .npz; .c3d and .trc hold markers")])
def test_corrupt_of_a_marker_file_takes_gaps_alone(tmp_path, inp, out, kind, said):
    # trial11: corrupt on a .c3d said "unknown suffix '.c3d' for writing"; then it refused every marker file, while
    # corrupt.gaps works on a MarkerSet: a rotation kind is refused naming the file and the kind that works
    source = tmp_path / inp
    if inp.endswith(".bvh"):
        shutil.copy(SAMPLE, source)
    else:
        save_markers(load_markers(CMU)[:20], source)
    code, _, err = run("corrupt", source, tmp_path / out, "--kind", kind)
    assert code != 0 and one_error_line(err) and said in err
    assert not (tmp_path / out).exists()


def test_corrupt_makes_gaps_in_a_marker_file_with_its_ground_truth(tmp_path):
    """`corrupt IN.c3d OUT --kind gaps` was refused; it writes OUT (.c3d, .trc) and an (F, M) mask over OUT's markers,
    with their labels, that `info` reads as markers: the samples made missing, and no other changed."""
    from mocapkit.io.masks import read_mask

    take = load_markers(mocapkit_sample("Eb015pr.c3d"))
    for out, truth in ((tmp_path / "g.c3d", tmp_path / "g.mask.npz"), (tmp_path / "g.trc", tmp_path / "t.mask.npz")):
        code, said, err = run("corrupt", mocapkit_sample("Eb015pr.c3d"), out, "--kind", "gaps", "--seed", "1",
                              "--mask", truth)
        assert code == 0, err
        back, mask = load_markers(out), read_mask(truth, frames=take.num_frames)
        assert mask.shape == (450, 26) and 0 < mask.sum() < mask.size // 10
        assert f"{int(mask.sum())} marker samples made missing" in said
        assert tuple(np.load(truth)["labels"]) == back.labels == take.labels
        assert np.array_equal(back.missing(), take.missing() | mask)
        assert np.allclose(back.positions[~mask], take.positions[~mask], atol=1e-3, equal_nan=True)
    code, said, _ = run("info", tmp_path / "g.mask.npz")
    assert code == 0 and "markers    26" in said and f"{int(mask.sum())} marker samples in" in said


def _point_words(path) -> np.ndarray:
    """(F, M, 5) x, y, z, residual and camera mask of every sample as the ``c3d`` package reads the file."""
    import c3d

    with open(path, "rb") as fh:
        return np.array([p.copy() for _, p, _ in c3d.Reader(fh).read_frames()])


def test_corrupt_keeps_a_gap_stored_as_zeros_and_a_marker_at_the_origin_as_the_file_has_them(tmp_path):
    """An exporter that stores an occlusion as (0, 0, 0) with a residual (Qualisys: 03_rolling.c3d's 35,965
    samples) has it read as a gap; `corrupt --kind gaps` wrote every such sample it did not touch as residual -1,
    and a marker whose path crosses the origin stays measured there. Only the samples the mask names change."""
    ms = load_markers(CMU)[:300]
    p, res = np.array(ms.positions), np.array(ms.residuals)
    p[100:130, 7], res[100:130, 7] = 0.0, 2.0  # Male:LANK occluded, stored as Qualisys stores it
    p[:, 9] -= p[150, 9]  # a marker at exactly (0, 0, 0) in frame 150, measured: its neighbours are mm away
    inp = save_markers(ms.with_positions(p, residuals=res), tmp_path / "in.c3d")
    take = load_markers(inp)
    assert take.missing()[100:130, 7].all() and not take.missing()[150, 9] and take.zero_gaps == 30
    out = tmp_path / "out.c3d"
    code, _, err = run("corrupt", inp, out, "--kind", "gaps", "--seed", "3")
    assert code == 0, err
    mask = np.load(tmp_path / "out.mask.npz")["mask"]
    a, b = _point_words(inp), _point_words(out)
    assert 0 < mask.sum() and (b[mask, 3] == -1).all()
    assert np.array_equal(a[~mask], b[~mask])  # before: the 30 stored zeros' residual 2 written as -1
    assert not mask[100:130, 7].any() and (b[100:130, 7, :3] == 0).all() and (b[100:130, 7, 3] > 0).all()
    assert not mask[150, 9] and (b[150, 9, :3] == 0).all() and b[150, 9, 3] >= 0  # measured at the origin


def test_corrupt_of_a_qualisys_take_changes_only_the_samples_it_makes_missing(shared_data, tmp_path):
    """03_rolling.c3d (Qualisys: 23 % of its samples are gaps stored as (0, 0, 0) with a residual): 35,965 samples
    the corruption did not touch came back as residual -1; now none does."""
    inp, out = shared_data / "c3d_markers_recovery" / "03_rolling.c3d", tmp_path / "out.c3d"
    code, _, err = run("corrupt", inp, out, "--kind", "gaps", "--seed", "1")
    assert code == 0, err
    mask = np.load(tmp_path / "out.mask.npz")["mask"]
    a, b = _point_words(inp), _point_words(out)
    assert (a[..., :3] == 0).all(-1).sum() == 35965 and 0 < mask.sum()
    assert np.array_equal(a[~mask], b[~mask])


def mocapkit_sample(name: str) -> str:
    import mocapkit

    return str(mocapkit.samples.path(name))


def test_the_record_console_and_batch_json_count_filled_and_spike_samples_alike(tmp_path):
    # trial15: the record's filled mask held 43 samples (the 40 of a gap and the 3 of a spike) while the console
    # and clean-batch --json said 40 filled and 3 spikes
    import json

    ms = load_markers(CMU)[:480]  # the take's first 4 s hold the gap and the spike: the counts are of them alone
    y = np.array(ms.positions) * 10.0 * ms.unit_cm
    y[300:340, 4] = np.nan  # a 40-frame gap
    y[100:103, 9] += [35.0, -40.0, 20.0]  # a 3-frame spike, 57 mm
    src = tmp_path / "in"
    src.mkdir()
    _write_with_ezc3d(src / "bad.c3d", y, ms.labels, ms.fps)
    code, stdout, stderr = run("clean", src / "bad.c3d", "-o", tmp_path / "one.c3d")
    assert code == 0, stderr
    assert "1 gap filled (40 samples), 1 spike removed (3 samples), 0 label swaps undone (0 samples)" in stdout
    with np.load(tmp_path / "one.clean.npz") as rec:
        filled, spikes = rec["filled"], rec["spikes"]
    assert filled.sum() == 40 and filled[300:340, 4].all()
    assert spikes.sum() == 3 and spikes[100:103, 9].all() and not (filled & spikes).any()
    code, stdout, stderr = run("clean-batch", src, tmp_path / "out", "--json", "--executor", "serial")
    assert code == 0, stderr
    (row,) = json.loads(stdout)["rows"]
    with np.load(tmp_path / "out" / "bad.clean.npz") as rec:
        assert (row["filled"], row["spikes"]) == (int(rec["filled"].sum()), int(rec["spikes"].sum())) == (40, 3)


def test_clean_of_a_missing_file_onto_itself_names_the_missing_file(tmp_path):
    code, _, err = run("clean", "ghost.c3d", "-o", "ghost.c3d", cwd=tmp_path)
    assert code != 0 and one_error_line(err)
    assert "ghost.c3d: no such file" in err and "refusing" not in err
    assert list(tmp_path.iterdir()) == []


def test_a_trc_output_says_how_many_of_its_samples_are_fills_and_where_they_are_listed(cut_take, cut_take_as_trc,
                                                                                       eb015pr_as_c3d, tmp_path):
    """trial27: 263 filled samples of a cleaned TRC looked exactly like recorded ones and the summary said nothing
    (a C3D output marks them with residual 0; TRC has no residual column)."""
    _, _, mask = cut_take
    out, code, stdout, stderr = cut_take_as_trc  # clean CUT.c3d -o clean.trc
    assert code == 0, stderr
    assert (f"note: {out}: {int(mask.sum())} samples the cleaning wrote (gaps filled, spikes and duplicates replaced) are written like recorded ones: a TRC has no residual "
            f"column to tell them apart; {out.parent / 'clean.clean.npz'} lists them") in stdout
    folder = tmp_path / "in"
    folder.mkdir()
    shutil.copy(out, folder / "cut.trc")  # a TRC with gaps, cleaned by a batch into TRC
    cut = load_markers(out)
    cut_positions = np.array(cut.positions)
    cut_positions[mask] = np.nan
    save_markers(cut.with_positions(cut_positions), folder / "cut.trc", overwrite=True)
    code, stdout, stderr = run("clean-batch", folder, tmp_path / "out", "--executor", "serial")
    assert code == 0, stderr + stdout
    assert (f"note: {tmp_path / 'out' / 'cut.trc'}: {int(mask.sum())} samples the cleaning wrote (gaps filled, spikes and duplicates replaced) are "
            "written like recorded ones") in stdout
    eb = load_markers(mocapkit_sample("Eb015pr.c3d"))  # residuals over 0: its fills are marked with residual 0 ...
    e_c3d, code, _, stderr = eb015pr_as_c3d  # clean Eb015pr.c3d -o e.c3d
    assert code == 0, stderr
    with np.load(e_c3d.with_name("e.clean.npz")) as rec:
        made = int(rec["filled"].sum() + rec["spikes"].sum()
                   + (rec["duplicates"].sum() if "duplicates" in rec.files else 0))  # foreign stretches refilled too
    marked = made + int(np.sum(~eb.missing() & (eb.residuals == 0)))  # and so were the capture program's own fills
    code, stdout, stderr = run("convert", e_c3d, tmp_path / "again.trc")  # ... which TRC loses: said
    assert code == 0, stderr
    assert (f"note: {tmp_path / 'again.trc'}: {marked} samples the input marks as interpolated (residual 0) "
            "are written like recorded ones") in stdout


def test_modelled_quantities_are_left_out_of_a_trc_by_clean_and_convert_unless_kept(shared_data, tmp_path):
    """trial27: C3D -> TRC wrote Plug-in Gait's angles (deg), forces, moments and powers as markers under Units mm."""
    inp = shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d"
    note = "left out 80 modelled quantities, not markers (26 angles, 20 forces, 18 moments, 16 powers)"
    for args, out in ((["convert", inp], tmp_path / "a.trc"), (["clean", inp, "-o"], tmp_path / "b.trc")):
        code, stdout, stderr = run(*args, out)
        assert code == 0, stderr
        assert f"note: {out}: {note}" in stdout
        if args[0] == "clean":  # counted as info counts them (113 markers): the line said '315 frames x 193 markers'
            said = " ".join(stdout.split())
            assert ": 315 frames x 113 markers (+80 modelled quantities, left as read), " in said, said
            assert " of 35595 marker samples changed" in said, said
        labels = load_markers(out).labels
        assert len(labels) == 113 and "LHipAngles" not in labels and "LAnklePower" not in labels and "LASI" in labels
    code, stdout, stderr = run("convert", inp, tmp_path / "c.trc", "--keep-modelled")
    assert code == 0, stderr
    assert "left out" not in stdout and "80 modelled quantities kept" in stdout
    assert len(load_markers(tmp_path / "c.trc").labels) == 193
    code, _, stderr = run("clean", SAMPLE, "-o", tmp_path / "d.bvh", "--keep-modelled")
    assert code != 0 and one_error_line(stderr) and "applies only to marker captures" in stderr


@pytest.mark.parametrize("command", ["convert", "clean"])
def test_keep_modelled_is_refused_in_one_line_where_it_means_nothing(shared_data, tmp_path, command):
    """trial27: --keep-modelled was taken and did nothing for a .c3d or .npz output, nor for a .trc or .npz input:
    only a C3D lists modelled quantities and only a .trc output leaves them out."""
    pig = shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d"
    save_markers(load_markers(pig), tmp_path / "pig.npz")
    (tmp_path / "pig.trc").write_bytes((shared_data / "trc_markers" / "T.trc").read_bytes())
    for inp, out, word in ((pig, "a.c3d", "a .c3d or .npz output keeps every point"),
                           (pig, "a.npz", "a .c3d or .npz output keeps every point"),
                           (tmp_path / "pig.npz", "b.trc", "a .trc or .npz input lists none"),
                           (tmp_path / "pig.trc", "c.trc", "a .trc or .npz input lists none")):
        args = [command, inp, tmp_path / out] if command == "convert" else [command, inp, "-o", tmp_path / out]
        code, _, stderr = run(*args, "--keep-modelled")
        assert code != 0 and one_error_line(stderr) and word in stderr and "--keep-modelled" in stderr, stderr
        assert not (tmp_path / out).exists() and not (tmp_path / (Path(out).stem + ".clean.npz")).exists()


@pytest.fixture(scope="module")
def origin_folder(tmp_path_factory):
    """Eb015pr's first 120 frames as a TRC, with a marker ORIGIN at exactly (0, 0, 0) in every frame (a lab-origin
    marker): read as never seen by default, kept as a position with --keep-zeros."""
    import mocapkit
    from mocapkit.markerset import MarkerSet

    d = tmp_path_factory.mktemp("origin")
    ms = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    pos = np.concatenate([ms.positions[:120], np.zeros((120, 1, 3))], axis=1)
    save_markers(MarkerSet(labels=(*ms.labels, "ORIGIN"), positions=pos, fps=ms.fps, units=ms.units), d / "z.trc")
    return d


def test_clean_and_clean_batch_keep_zeros_on_request(origin_folder, tmp_path):
    """convert had --keep-zeros, clean and clean-batch not: a marker truly at the origin was cleaned as a gap."""
    from mocapkit.cleaning.pipeline import CleanResult

    inp = origin_folder / "z.trc"
    code, stdout, stderr = run("clean", inp, "-o", tmp_path / "a.trc")
    assert code == 0, stderr + stdout
    assert "read 120 samples stored as exact (0, 0, 0) as gaps (--keep-zeros keeps them" in stdout
    assert "left missing: ORIGIN" in stdout
    code, stdout, stderr = run("clean", inp, "-o", tmp_path / "b.trc", "--keep-zeros")
    assert code == 0, stderr + stdout
    assert "(0, 0, 0)" not in stdout and "ORIGIN" not in stdout
    assert CleanResult.load_params(tmp_path / "b.clean.npz")["request"]["zeros_as_gaps"] is False
    code, stdout, stderr = run("clean-batch", origin_folder, tmp_path / "out", "--executor", "serial", "--keep-zeros")
    assert code == 0 and "1 cleaned" in stdout, stderr + stdout
    assert (tmp_path / "out" / "z.trc").read_bytes() == (tmp_path / "b.trc").read_bytes()
    code, stdout, stderr = run("clean-batch", origin_folder, tmp_path / "out", "--executor", "serial")
    assert code == 2 and ("it was cleaned with --keep-zeros (now without it: exact (0, 0, 0) samples decided from "
                          "the data); use --overwrite") in stdout + stderr, stdout + stderr
    # another limit, said as typed (was "max_gap_s None (now 0.05)": Python's names to a CLI user)
    code, stdout, stderr = run("clean-batch", origin_folder, tmp_path / "out", "--executor", "serial", "--keep-zeros",
                               "--max-gap", "0.05", "--max-fill-error", "20")
    assert code == 2 and ("it was cleaned without --max-gap (now --max-gap 0.05), without --max-fill-error (now "
                          "--max-fill-error 20); use --overwrite") in stdout + stderr, stdout + stderr
    code, _, err = run("clean", SAMPLE, "-o", tmp_path / "w.bvh", "--keep-zeros")
    assert code == 2 and one_error_line(err) and "--keep-zeros applies only to marker captures" in err
