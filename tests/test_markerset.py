import numpy as np
import pytest

import mocapkit
from mocapkit.io import MarkerSet as IoMarkerSet
from mocapkit.io.c3d import MarkerSet as C3dMarkerSet
from mocapkit.io import load_markers
from mocapkit.markerset import MarkerSet, MarkerSource, length_unit_cm, zero_gap_mask


def _ms(residuals=True, analogs=True):
    pos = np.arange(10 * 2 * 3, dtype=float).reshape(10, 2, 3)
    pos[2, 1] = np.nan
    res = np.full((10, 2), 0.5) if residuals else None
    source = MarkerSource("c3d", {"POINT": {}}, analogs=np.arange(3 * 40, dtype=float).reshape(3, 40) if analogs else None)
    return MarkerSet(labels=("a", "b"), positions=pos, fps=100.0, residuals=res, source=source)


def test_the_container_is_importable_from_io_and_io_c3d():
    assert IoMarkerSet is MarkerSet and C3dMarkerSet is MarkerSet


def test_residuals_are_minus_one_where_missing_and_read_only():
    ms = _ms()
    assert ms.residuals[2, 1] == -1.0 and ms.residuals[2, 0] == 0.5
    assert ms.missing()[2, 1] and ms.missing().sum() == 1
    with pytest.raises(ValueError):
        ms.residuals[0, 0] = 3.0
    with pytest.raises(ValueError):
        ms.positions[0, 0, 0] = 3.0
    with pytest.raises(ValueError, match="residuals"):
        MarkerSet(labels=("a",), positions=np.zeros((4, 1, 3)), fps=30.0, residuals=np.zeros((3, 1)))
    no = _ms(residuals=False)
    assert no.residuals is None and no.residual_or_default()[2, 1] == -1 and no.residual_or_default()[0, 0] == 0


def test_with_positions_is_an_immutable_update_that_marks_changed_samples_interpolated():
    ms = _ms()
    new = np.array(ms.positions)
    new[2, 1] = [1.0, 2.0, 3.0]  # a filled gap
    new[5, 0] += 1.0  # a moved sample
    new[7, 0] = np.nan  # a sample removed
    out = ms.with_positions(new)
    assert out is not ms and ms.missing()[2, 1] and not out.missing()[2, 1]
    assert out.residuals[2, 1] == 0.0 and out.residuals[5, 0] == 0.0 and out.residuals[7, 0] == -1.0
    assert out.residuals[6, 0] == 0.5 and out.residuals[6, 1] == 0.5  # untouched samples keep theirs
    assert out.labels == ms.labels and out.source is ms.source and out.fps == ms.fps
    with pytest.raises(ValueError, match="shape"):
        ms.with_positions(new[:5])


def test_select_and_slices_keep_residuals_and_analogs_aligned():
    ms = _ms()
    b = ms.select(["b"])
    assert b.residuals.shape == (10, 1) and b.residuals[2, 0] == -1
    part = ms[2:5]
    assert part.num_frames == 3 and part.residuals.shape == (3, 2) and part.residuals[0, 1] == -1
    # 4 analog samples per frame: frames 2..4 are analog samples 8..19; the first frame number moves
    assert part.source.analogs.shape == (3, 12) and part.source.analogs[0, 0] == 8.0
    assert part.source.first_frame == 3
    assert ms[::2].source.analogs is None and ms[::2].fps == 50.0


def test_source_is_read_only():
    src = _ms().source
    with pytest.raises(TypeError):
        src.parameters["X"] = 1
    with pytest.raises(ValueError):
        src.analogs[0, 0] = 1.0
    assert src.analog_ratio(10) == 4 and MarkerSource("trc").analog_ratio(10) == 0


@pytest.mark.parametrize("unit, cm", [("mm", 0.1), ("MM ", 0.1), ("cm", 1.0), ("m", 100.0), ("mete", 100.0),
                                      ("meters", 100.0), ("in", 2.54), ("dm", 10.0)])
def test_length_units(unit, cm):
    assert length_unit_cm(unit) == cm
    assert MarkerSet(labels=("a",), positions=np.zeros((1, 1, 3)), fps=30, units=unit).unit_cm == cm


def test_an_unknown_unit_names_itself():
    with pytest.raises(ValueError, match="unknown length unit 'deg'"):
        length_unit_cm("deg")


def test_zero_gap_mask_rules():
    pos = np.full((20, 3, 3), 800.0)
    pos[:, 0] = 0.0  # a marker never seen, stored as zeros throughout
    pos[5:8, 1] = 0.0  # a jump to the origin and back
    pos[:, 2] = np.linspace(-30.0, 30.0, 20)[:, None]  # passes within 10 cm of the origin...
    pos[10, 2] = 0.0  # ...and is at exactly 0 once, next to samples 3 mm away: a value, not a gap
    mask = zero_gap_mask(pos, unit_cm=0.1)
    assert mask[:, 0].all() and mask[5:8, 1].all() and mask[:, 1].sum() == 3 and not mask[:, 2].any()
    # the same trajectory in metres: 0.8 m away is still far
    assert zero_gap_mask(pos / 1000.0, unit_cm=100.0)[5:8, 1].all()
    assert not zero_gap_mask(np.full((5, 1, 3), 1.0), unit_cm=0.1).any()


def test_the_bundled_sample_has_residuals_and_its_analogs():
    ms = mocapkit.load(mocapkit.samples.path("Eb015pr.c3d"))
    assert ms.residuals.shape == (450, 26) and np.all(ms.residuals[ms.missing()] == -1)
    assert np.all(ms.residuals[~ms.missing()] >= 0)
    assert ms.source.format == "c3d" and ms.source.analogs.shape == (16, 1800) and ms.zero_gaps == 0
    assert "POINT" in ms.source.parameters and "ANALOG" in ms.source.parameters


def test_a_frame_slice_written_to_c3d_keeps_frame_numbers_and_analogs_in_step(shared_data, tmp_path):
    from mocapkit.io import load_markers, save_markers

    ms = load_markers(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d")
    part = ms[10:110]
    back = load_markers(save_markers(part, tmp_path / "part.c3d"))
    assert back.num_frames == 100 and back.source.first_frame == ms.source.first_frame + 10
    trial = back.source.parameters["TRIAL"]
    assert list(trial["ACTUAL_START_FIELD"]["value"]) == [back.source.first_frame, 0]
    assert list(trial["ACTUAL_END_FIELD"]["value"]) == [back.source.first_frame + 99, 0]
    ratio = ms.source.analog_ratio(ms.num_frames)
    assert np.array_equal(back.source.analogs, ms.source.analogs[:, 10 * ratio : 110 * ratio].astype(np.float32))
    assert np.array_equal(back.positions, part.positions.astype(np.float32), equal_nan=True)


def test_a_marker_take_is_sliced_as_a_motion_is():
    ms = mocapkit.load(mocapkit.samples.path("Eb015pr.c3d"))
    one = ms[3]
    assert one.num_frames == 1 and np.array_equal(one.positions, ms.positions[3:4], equal_nan=True)
    with pytest.raises(ValueError, match="run forwards"):
        ms[::-1]
    with pytest.raises(ValueError, match="a step of 1000 frames gives 0.05 fps"):
        ms[::1000]
    assert ms[::2].fps == ms.fps / 2


def test_unique_labels_name_repeats_apart_and_unnamed_markers_by_place():
    from mocapkit.markerset import unique_labels

    assert unique_labels(["RKNE", " RKNE ", "", "A", "A_2", "A"], 8) == (
        "RKNE", "RKNE_2", "M003", "A", "A_2", "A_3", "M007", "M008")


def test_file_labels_are_the_files_while_the_markers_are_its_own():
    import dataclasses

    ms = _ms()
    ms = dataclasses.replace(ms, labels=("a", "a_2"), source=dataclasses.replace(ms.source, labels=("a", "a")))
    assert ms.file_labels() == ("a", "a") and ms[2:5].file_labels() == ("a", "a")
    assert ms.select(["a_2", "a"]).file_labels() == ("a_2", "a")
    assert ms.select(["a"]).file_labels() == ("a",)


def test_residuals_and_camera_masks_follow_their_samples():
    import dataclasses

    ms = dataclasses.replace(_ms(), cameras=np.tile([[3, 96]], (10, 1)))
    pos = np.array(ms.positions)
    pos[5:7] = pos[5:7, ::-1]  # re-labelled samples
    pos[8, 0] += 1.0  # a changed one
    sources = np.tile([0, 1], (10, 1))
    sources[5:7] = [1, 0]
    out = ms.with_positions(pos, sources=sources)
    assert out.cameras[5].tolist() == [96, 3] and out.cameras[8].tolist() == [0, 96]
    assert out.residuals[8, 0] == 0.0 and out.residuals[5, 0] == 0.5
    plain = ms.with_positions(pos)  # without sources the re-labelled samples read as changed
    assert plain.cameras[5].tolist() == [0, 0] and plain.residuals[5, 0] == 0.0
    assert ms[3:6].cameras.shape == (3, 2) and ms.select(["b"]).cameras[:, 0].tolist() == [96] * 10


def test_unlabelled_trajectories_come_from_the_files_own_labels_and_survive_npz_c3d_and_trc(tmp_path):
    # a TRC column without a label (read as M and its place) and Vicon's '*0' are unlabelled; a marker the file
    # names M003 is not, nor is one named M002 by a user (no source)
    from mocapkit.io import load_markers, save_markers
    from mocapkit.markerset import unique_labels

    raw = ("A", "", "*0", "M003", "B")
    pos = np.arange(6 * 5 * 3, dtype=float).reshape(6, 5, 3) + 1.0
    ms = MarkerSet(labels=unique_labels(raw, 5), positions=pos, fps=50.0, source=MarkerSource("trc", labels=raw))
    assert ms.labels == ("A", "M002", "*0", "M003", "B")
    assert ms.unlabelled().tolist() == [False, True, True, False, False]
    assert ms.select(["B", "M002", "*0"]).unlabelled().tolist() == [False, True, True]  # found by name
    assert MarkerSet(labels=("A", "M002", "*1"), positions=pos[:, :3], fps=50.0).unlabelled().tolist() == [False, False, True]
    for name in ("t.npz", "t.c3d", "t.trc"):
        back = load_markers(save_markers(ms, tmp_path / name))
        assert back.labels == ms.labels and back.unlabelled().tolist() == [False, True, True, False, False], name


def test_the_unit_inferred_from_marker_distances_is_never_wrong_on_real_files(shared_data):
    """Every marker file of the shared data that reads and states mm or m: the whole-body captures (the curated
    folders) are inferred in their stated unit, every other file (peers' test files: a knee, a cube) in its stated
    unit or none (the unit is asked for then); the same data in cm fits neither."""
    from mocapkit.errors import MocapFormatError
    from mocapkit.markerset import infer_units

    curated = ["c3d_markers", "trc_markers", "c3d_markers_recovery"]
    files = [(p, True) for d in curated for p in sorted((shared_data / d).glob("*.[ct][3r][dc]"))]
    files += [(p, False) for p in sorted((shared_data / "peer_files").rglob("*")) if p.suffix.lower() in (".c3d", ".trc")]
    checked = 0
    for path, whole_body in files:
        try:
            ms = mocapkit.io.load_markers(path)
        except MocapFormatError:
            continue
        unit = {0.1: "mm", 100.0: "m"}.get(length_unit_cm(ms.units))
        if unit is None:
            continue
        got = infer_units(ms.positions)
        assert got == unit if whole_body else got in (unit, None), (path, got, ms.units)
        in_cm = ms.positions * (0.1 if unit == "mm" else 100.0)
        assert infer_units(in_cm) is None, path  # the same data in cm
        checked += 1
    assert checked > 40


def test_computed_points_are_found_per_subject_in_a_two_subject_file(shared_data):
    # Nexus prefixes each subject's points (Alice:LFEO, Bob:LFEO): an axis triad was looked up by its name without
    # the prefix, so the last subject's index won: Alice's axes (96 in Plug-in Gait, 20 found by name or the floor)
    # were cleaned as markers, filled (170 samples made up) and used as donors for her real markers
    from mocapkit.io import load_markers

    one = load_markers(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d")
    alone = one.computed()
    assert alone.sum() == 96
    x = np.asarray(one.positions)
    labels = tuple(f"{who}:{label}" for who in ("Alice", "Bob") for label in one.labels)
    two = MarkerSet(labels=labels, positions=np.concatenate([x, x + [0.0, 2500.0, 0.0]], axis=1), fps=one.fps)
    assert two.computed().tolist() == alone.tolist() * 2


def test_a_marker_set_built_in_python_has_its_unit_checked(shared_data):
    """units= was never checked on a MarkerSet built from arrays: metres left at the default "mm" missed a 60 mm
    spike, mm labelled "m" lost 4,705 good samples as spikes, and "furlong" failed later with a bare ValueError."""
    import mocapkit
    from mocapkit.errors import MocapError
    from mocapkit.io import load_markers
    from mocapkit.markerset import MarkerSet

    f = load_markers(shared_data / "c3d_markers_recovery" / "85_02.c3d")
    p = np.array(f.positions)
    p[300, 7] += [60.0, 0.0, 0.0]
    with pytest.raises(MocapError, match="units: unknown length unit 'furlong'"):
        MarkerSet(f.labels, p, f.fps, units="furlong")
    with pytest.raises(MocapError, match="said to be in 'mm'.*a body's in 'm'.*1000 times smaller.*units='m'"):
        mocapkit.clean(MarkerSet(f.labels, p / 1000.0, f.fps))
    with pytest.raises(MocapError, match="said to be in 'm'.*a body's in 'mm'.*1000 times larger"):
        mocapkit.clean(MarkerSet(f.labels, p, f.fps, units="m"))
    for ms in (MarkerSet(f.labels, p, f.fps), MarkerSet(f.labels, p / 1000.0, f.fps, units="m")):
        res = mocapkit.clean(ms)
        assert res.spikes.sum() == 1 and res.spikes[300, 7]


@pytest.mark.parametrize("name", ["Centre_of_Mass", "COM", "BodyCoM", "center of mass"])
def test_a_centre_of_mass_in_a_trc_is_modelled_whatever_its_spelling(shared_data, tmp_path, name):
    # A TRC lists no modelled points: Plug-in Gait's CentreOfMass, written to a TRC under another lab's spelling,
    # was a marker, and its 30 unseen frames of PiG_Motion-FlatFoot-Full were filled as a marker's gap.
    from mocapkit.cleaning.markers import clean_markers
    from mocapkit.io import load_markers, save_markers

    pig = load_markers(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d")
    save_markers(pig, tmp_path / "pig.trc")
    text = (tmp_path / "pig.trc").read_text()
    (tmp_path / "lab.trc").write_text(text.replace("\tCentreOfMass\t", f"\t{name}\t", 1))
    take = load_markers(tmp_path / "lab.trc")
    j = list(take.labels).index(name)
    assert take.computed()[j] and take.modelled()[j]
    assert np.isnan(take.positions[:, j]).any()
    markers = [i for i, label in enumerate(take.labels) if label in ("LASI", "RASI", "LPSI", "RPSI", "LTHI", "LKNE")]
    res = clean_markers(take.select([take.labels[i] for i in markers + [j]]), steps=("gaps",))
    assert np.array_equal(res.markers.positions[:, -1], take.positions[:, j], equal_nan=True)
    assert not any(x.marker == name for x in res.fixes)


# a part of a resampled take against the same frames taken from the file in one slice (50 Hz Eb015pr.c3d)
RESLICED = [("[::2][75:200]", slice(150, 400, 2)), ("[10:][::3]", slice(10, None, 3)),
            ("[::2][::2][5:]", slice(20, None, 4)), ("[::2][-50:]", slice(350, None, 2)),
            ("[-100:][::2]", slice(350, None, 2)), ("[::3][7:40]", slice(21, 120, 3))]


def test_a_resampled_take_sliced_again_is_numbered_and_written_as_the_files_frames_sliced_once(tmp_path):
    import ezc3d

    from mocapkit.io import load_markers, save_markers

    ms = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    (tmp_path / "once").mkdir()
    assert ms[::2][75:200].source.first_frame == 151  # the file's frame 151 (3.0 s), not frame 76 (1.5 s)
    for steps, once in RESLICED:
        part, direct = eval(f"ms{steps}"), ms[once]  # noqa: S307 (the slices as a user types them)
        assert part.source.first_frame == direct.source.first_frame, steps
        assert np.array_equal(part.positions, direct.positions, equal_nan=True), steps
        for suffix in (".c3d", ".trc", ".npz"):
            a, b = tmp_path / f"part{suffix}", tmp_path / "once" / f"part{suffix}"  # one name: a TRC states it
            save_markers(part, a, overwrite=True)
            save_markers(direct, b, overwrite=True)
            assert a.read_bytes() == b.read_bytes(), (steps, suffix)
    c3d = tmp_path / "part.c3d"
    save_markers(ms[::2][75:200], c3d, overwrite=True)
    head = ezc3d.c3d(str(c3d))["header"]["points"]
    assert head["first_frame"] + 1 == 76 and head["frame_rate"] == 25  # 3.0 s at 25 Hz, as ms[150:400:2] writes it
    # its events are those of 3.0 s to 7.96 s (RHS at 5.40 s, RTO at 7.32 s), not of 1.5 s to 6.46 s (RIC at 2.72 s)
    within = [e for e in ms.source.events if 3.0 - 0.02 <= e[0] <= 7.96 + 0.02]
    assert [e[1] for e in within][:2] == ["RHS ", "RTO "] and not any(e[1] == "RIC " for e in within)
    assert [e[1] for e in load_markers(c3d).source.events] == [e[1] for e in within]


def test_a_resampled_take_keeps_its_first_frames_time_through_trc_and_npz(tmp_path):
    from mocapkit.io import load_markers, save_markers

    ms = load_markers(mocapkit.samples.path("Eb015pr.c3d"))
    trc = save_markers(ms[150::2], tmp_path / "part.trc")
    row = trc.read_text().splitlines()[6].split("\t")  # after 5 header lines and an empty one
    assert row[:2] == ["76", "3.000000"]  # frame 76 at 25 Hz: 3.0 s, the file's frame 151 (not 151 at 25 Hz: 6.0 s)
    back = load_markers(save_markers(ms[::2][75:], tmp_path / "part.npz"))
    assert back.source.first_frame == 151 and back.source.layout["trial_rate"] == 50
    assert load_markers(save_markers(back, tmp_path / "back.c3d")).source.first_frame == 76


def test_a_sample_cameras_saw_is_no_interpolated_one_whatever_its_rounded_residual():
    # C3D stores a residual in steps of |POINT:SCALE| (Eb015pr: 0.083 mm) beside the cameras that saw the sample. A
    # residual under half a step is stored as 0; with cameras named it was measured, not filled. 0.15.0 called it
    # interpolated: a marker npz listed it in `filled` ("no recorded one") and a TRC note counted it as a fill.
    import dataclasses

    from mocapkit import samples
    from mocapkit.io import load_markers

    ms = load_markers(samples.path("Eb015pr.c3d"))
    assert ms.interpolated().sum() == 19 and not np.any(ms.cameras[ms.interpolated()])  # its own fills: no camera
    seen = ~ms.missing() & (ms.residuals > 0) & (ms.cameras > 0)
    f, m = np.argwhere(seen)[0]
    res = np.array(ms.residuals)
    res[f, m] = 0.0  # measured by cameras, its residual rounded to 0
    low = dataclasses.replace(ms, residuals=res)
    assert not low.interpolated()[f, m] and low.interpolated().sum() == 19
    cams = np.array(ms.cameras)
    cams[f, m] = 0  # and with no camera named: a fill
    assert dataclasses.replace(low, cameras=cams).interpolated()[f, m]


def test_functionalwalks_camera_seen_samples_of_residual_0_are_recorded_ones(shared_data):
    from mocapkit.io import load_markers

    ms = load_markers(shared_data / "c3d_markers" / "FunctionalWalk.c3d")  # Vicon, residuals in 0.18 mm steps
    zero = ~ms.missing() & (ms.residuals == 0) & ~ms.modelled() & ~ms.unlabelled()
    assert zero.sum() == 11215 and np.sum(zero & (ms.cameras > 0)) == 11203
    assert ms.interpolated().sum() == 12  # was 11,215: every sample under 0.09 mm of residual


def test_repr_counts_markers_as_info_does(shared_data):
    """Trial T1: the repr said "193 markers, 10.5% missing" where `mocapkit info` says 113 markers (+80 modelled
    quantities) and 0.00 %: every missing sample was a force's or moment's. Counted by the one helper."""
    from mocapkit.markerset import marker_counts

    take = load_markers(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Hole.c3d")
    assert marker_counts(take) == (113, 80, 0.0)
    assert repr(take) == ("MarkerSet('PiG_Motion-FlatFoot-Hole', 320 frames @ 100 fps, 113 markers "
                          "(+80 modelled quantities), 0.0% missing)")
    assert repr(take[:1]).startswith("MarkerSet('PiG_Motion-FlatFoot-Hole', 1 frame @ 100 fps, 113 markers")


def test_a_part_counts_its_own_zero_gaps(tmp_path):
    """Trial T1: 03_rolling.c3d[:700].zero_gaps was the whole file's 35,965 (the part has 6,909). A C3D part counts
    those in its frames (source.stored_zeros); a TRC keeps no place for them: its part's count cannot be known (None)."""
    from pathlib import Path

    from mocapkit.io import save_markers

    take = load_markers(Path(__file__).resolve().parent / "data" / "85_02.c3d")[:300]
    x, res = np.array(take.positions), np.array(take.residuals)
    x[100:140, 7], res[100:140, 7] = 0.0, 2.0  # an occlusion stored as (0, 0, 0), as exporters store one
    back = load_markers(save_markers(take.with_positions(x, residuals=res), tmp_path / "zeros.c3d"))
    assert back.zero_gaps == 40 and back[:].zero_gaps == 40
    assert back[:120].zero_gaps == 20 and back[130:].zero_gaps == 10 and back[200:].zero_gaps == 0
    assert back[100:140:2].zero_gaps == 20 and back[110].zero_gaps == 1
    trc = load_markers(save_markers(take.with_positions(x, residuals=res), tmp_path / "zeros.trc"))
    assert trc.zero_gaps == 40 and trc[:].zero_gaps == 40 and trc[:120].zero_gaps is None  # cannot be known
    # a choice of markers counts its own too (it kept the whole take's 40): the C3D's by its stored zeros, chosen
    # with the markers; a TRC's cannot be known but where every marker is chosen
    label, others = back.labels[7], [lb for lb in back.labels if lb != back.labels[7]]
    assert back.select([label]).zero_gaps == 40 and back.select(others).zero_gaps == 0
    assert back.select([label, label]).zero_gaps == 80 and back.select(others[::-1] + [label]).zero_gaps == 40
    assert back.select([label])[:120].zero_gaps == 20 and back.select(others)[:120].zero_gaps == 0
    assert trc.select(others).zero_gaps is None and trc.select([label] + others).zero_gaps == 40
