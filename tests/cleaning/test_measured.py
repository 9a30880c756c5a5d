"""A BVH cell with one ``nan`` channel (an AMC bone line with one ``nan`` dof): the fill fills that channel alone, the
file's measured ones kept bit for bit (mocapkit.cleaning.measured, the writers keeping their text)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mocapkit import samples
from mocapkit.cleaning.whole_take import fill_take
from mocapkit.io.amc_writer import write_amc
from mocapkit.io.asfamc import read_amc
from mocapkit.io.bvh import read_bvh, write_bvh

DATA = Path(__file__).resolve().parents[1] / "data"


def _with_nan(src: Path, out: Path, column: int, frames: range) -> list[str]:
    """``src`` with its ``column``-th number written ``nan`` in ``frames``; the file's lines."""
    lines = src.read_text().split("\n")
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    for f in frames:
        tokens = lines[at + f].split(" ")
        tokens[column] = "nan"
        lines[at + f] = " ".join(tokens)
    out.write_text("\n".join(lines))
    return lines


@pytest.mark.parametrize("take, column, joint", [
    ("pybvh_test1_zup.bvh", 7, 1),  # pybvh's Xsens-like take: the Spine's Zrotation (of Xrotation Zrotation Yrotation)
    ("dataset-1_dash_normal_001.bvh", 13, 2),  # a Bandai Namco take: its Spine's Yposition (its rotation whole)
])
def test_fill_of_one_nan_channel_keeps_the_measured_channels_text(tmp_path, take, column, joint):
    path = tmp_path / "one_nan.bvh"
    lines = _with_nan(DATA / take, path, column, range(5, 13))
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    taken = read_bvh(path)
    assert taken.missing()[5:13, joint].all()
    done = fill_take(taken)
    assert done.filled[5:13, joint].all() and not done.motion.missing().any()
    name, channel = taken.channel_names()[column].split(".")
    assert "8 partly measured cells filled in their nan channels alone" in done.warnings[-1]
    assert done.warnings[-1].endswith(f": {name} {channel} (frames 5-12)")  # which channel the fill made up
    out = tmp_path / "out.bvh"
    write_bvh(done.motion, out, like=path)
    written = out.read_text().split("\n")
    changed = [(i, k) for i, (a, b) in enumerate(zip(lines, written)) for k, (x, y) in
               enumerate(zip(a.split(" "), b.split(" "))) if x != y]
    assert changed == [(at + f, column) for f in range(5, 13)]  # only the nan numbers; the measured ones the file's
    back = read_bvh(out).channel_values()[3:15, column]
    assert np.all(np.abs(np.diff(back)) < 5.0)  # the filled channel joins its curve


def test_fill_of_one_nan_dof_keeps_the_measured_dofs_text(tmp_path):
    asf = samples.path("HDM_bk.asf")
    lines = samples.path("HDM_bk_sneak2StepsLStart_004_120.amc").read_text(encoding="latin-1").split("\n")
    frame, nan_at = 0, []
    for i, line in enumerate(lines):  # lhumerus's second dof written nan in frames 10 to 17
        tokens = line.split(" ")
        if tokens[0].isdigit():
            frame = int(tokens[0])
        elif tokens[0] == "lhumerus" and 10 <= frame < 18:
            tokens[2] = "nan"
            lines[i] = " ".join(tokens)
            nan_at.append(i)
    path = tmp_path / "one_nan.amc"
    path.write_text("\n".join(lines), encoding="latin-1")
    done = fill_take(read_amc(path, asf=asf))
    assert not done.motion.missing().any()
    out = tmp_path / "out.amc"
    write_amc(done.motion, out, like=path, asf=asf)
    written = out.read_text(encoding="latin-1").split("\n")
    changed = [(i, k) for i, (a, b) in enumerate(zip(lines, written)) for k, (x, y) in
               enumerate(zip(a.split(" "), b.split(" "))) if x != y]
    assert len(nan_at) == 8 and changed == [(i, 2) for i in nan_at]  # the nan dofs alone; the measured as the file's


def test_a_nan_channel_left_unfilled_stays_nan_from_an_npz(tmp_path):
    """An .npz keeping a BVH's numbers, written back with ``allow_nan`` before any fill: the cell's ``nan`` channel
    is written ``nan`` and its measured channels the file's numbers (the bridged curve a fill is placed near was
    written as the missing channel's number, ``0.000000``: a gap turned into a measurement)."""
    from mocapkit import io
    from mocapkit.io.npz import read_npz

    path = tmp_path / "one_nan.bvh"
    lines = _with_nan(DATA / "cmu_01_01_start.bvh", path, 7, range(20, 30))  # LHipJoint's Yrotation
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    kept = tmp_path / "one_nan.npz"
    io.save(read_bvh(path), kept, like=path)
    out = tmp_path / "back.bvh"
    write_bvh(read_npz(kept), out, allow_nan=True, like=kept)
    written = out.read_text().split("\n")
    for f in range(20, 30):
        want = [float(x) for x in lines[at + f].split(" ")[6:9]]
        got = [float(x) for x in written[at + f].split(" ")[6:9]]
        assert np.isnan(got[1]) and got[0] == want[0] and got[2] == want[2], (f, got, want)


def test_a_cell_the_motion_has_is_its_own_whatever_its_file_says(tmp_path):
    """A take read from a file with one ``nan`` channel, whose partly missing cells the caller has since given a
    rotation of its own, filled for another gap: those cells are the caller's, bit for bit (the file's measured
    channels were put into them: (10, 20, 30) deg came back (0, 20, 0), marked filled)."""
    import dataclasses

    from mocapkit import rotations as R

    path = tmp_path / "one_nan.bvh"
    _with_nan(DATA / "cmu_01_01_start.bvh", path, 7, range(20, 30))  # LHipJoint's Yrotation
    taken = read_bvh(path)
    rot = np.array(taken.rotations)
    rot[20:30, 1] = R.euler_to_quaternion(np.array([10.0, 20.0, 30.0]), "ZYX")  # the caller's own fill
    rot[50:56, 5] = np.nan  # a gap for the fill
    done = fill_take(dataclasses.replace(taken, rotations=rot))
    assert done.filled[50:56, 5].all() and not done.filled[20:30, 1].any()
    assert np.array_equal(done.motion.rotations[20:30, 1], rot[20:30, 1])


def test_a_fill_needs_no_file_its_take_was_read_from(tmp_path, monkeypatch):
    """A take whose file was replaced after it was read, its bytes let go (64 MB of other files read since:
    mocapkit.io.sources): a gap of whole cells is filled all the same. keep_measured's look at the file for
    ``nan`` channels raised the writer's 'removed or changed after its take was read', and fill_take failed."""
    from mocapkit.io import sources

    path = tmp_path / "gap.bvh"
    _with_nan(DATA / "cmu_01_01_start.bvh", path, 6, range(20, 30))
    _with_nan(path, path, 7, range(20, 30))
    _with_nan(path, path, 8, range(20, 30))  # LHipJoint missing whole in frames 20-29: no channel measured
    monkeypatch.setattr(sources, "MAX_KEPT_BYTES", 0)  # only the digest is kept (a large corpus read since)
    taken = read_bvh(path)
    path.write_text("replaced by a sync tool\n")
    done = fill_take(taken)
    assert done.filled[20:30, 1].all() and not done.motion.missing().any()


def test_near_gimbal_lock_the_written_rotation_is_the_fills_nearest(tmp_path):
    """Bandai bye_giant's Spine (ZXY, its X 89.4-89.6 deg in frames 12-19) with its Zrotation nan, filled 1 deg
    off the file's rotation: the rotation kept with the measured X and Y is at most that far from the fill (the
    file's own Z is one such). The fill's Z taken apart from its rotation and set beside the file's X and Y put it
    up to tens of degrees away (Z and Y trade off near gimbal lock)."""
    import dataclasses

    from mocapkit import rotations as R
    from mocapkit.cleaning.measured import keep_measured

    path = tmp_path / "one_nan.bvh"
    _with_nan(DATA / "dataset-1_bye_giant_001.bvh", path, 15, range(12, 20))
    before, truth = read_bvh(path), read_bvh(DATA / "dataset-1_bye_giant_001.bvh")
    off = R.euler_to_quaternion(np.array([1.0, 0.0, 0.0]), "XYZ")  # the fill's error: 1 deg about X
    rot = np.array(truth.rotations)
    rot[12:20, 2] = R.quaternion_multiply(rot[12:20, 2], np.broadcast_to(off, (8, 4)))
    kept, cells = keep_measured(before, dataclasses.replace(before, rotations=rot))
    assert cells[12:20, 2].all() and cells.sum() == 8
    assert np.degrees(R.geodesic_angle(kept.rotations[12:20, 2], rot[12:20, 2])).max() <= 1.0 + 1e-6


def _one_nan_and_a_spike(path: Path) -> tuple[list[str], int]:
    """cmu_01_01_start at ``path`` with LeftUpLeg's Z ``nan`` in frames 20-25 and 57-62 and a 12 deg spike in its
    measured Y and X at frame 60; the file's lines, as written, and the index of its first motion line."""
    lines = _with_nan(DATA / "cmu_01_01_start.bvh", path, 9, [*range(20, 26), *range(57, 63)])  # LeftUpLeg's Z
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    tokens = lines[at + 60].split(" ")
    tokens[10], tokens[11] = f"{float(tokens[10]) + 12:.4f}", f"{float(tokens[11]) - 12:.4f}"  # the spike: Y, X
    lines[at + 60] = " ".join(tokens)
    path.write_text("\n".join(lines))
    return lines, at


def test_a_repair_of_a_filled_cell_moves_its_missing_channel_not_the_measured_ones(tmp_path):
    """cmu_01_01_start's LeftUpLeg with its Zrotation nan in frames 20-25 and 57-62, filled; detection flagging
    those cells (set here, so the repair judges exactly them, as a full clean's detect can), the repair replaced each
    whole rotation (by 0.19-0.60 deg: a medoid repair of a clean cell) and the written BVH moved the measured Y and X
    of frames 20-25 by up to 0.18 deg: numbers the file measured, changed on no evidence against them. Now only the
    nan numbers change there, the rotation within REPAIR_TOLERANCE_DEG of the repair's. Frame 60 carries a 12 deg
    spike in its measured Y and X, which no Z undoes: that repair (17 deg) stands whole, its measured channels what
    it corrects, as in a cell the file measures whole."""
    import dataclasses

    from mocapkit import rotations as R
    from mocapkit.cleaning.whole_take import detect_take, repair_take, repair_whole

    path = tmp_path / "one_nan.bvh"
    lines, at = _one_nan_and_a_spike(path)
    filled = fill_take(read_bvh(path)).motion
    flags = np.zeros((filled.num_frames, filled.num_joints), dtype=bool)
    flags[20:26, 2] = flags[60, 2] = True
    det = detect_take(filled).detection
    det = dataclasses.replace(det, flags=flags)
    done = repair_whole(filled, det)
    assert done.repaired[20:26, 2].all() and done.repaired[60, 2]
    out = tmp_path / "out.bvh"
    write_bvh(done.motion, out, like=path)
    written = out.read_text().split("\n")
    changed = [(i - at, k) for i, (a, b) in enumerate(zip(lines, written)) for k, (x, y) in
               enumerate(zip(a.split(" "), b.split(" "))) if x != y]
    assert [c for c in changed if c[0] != 60] == [(f, 9) for f in [*range(20, 26), 57, 58, 59, 61, 62]]
    assert {k for f, k in changed if f == 60} == {9, 10, 11}  # the spike repaired: its measured Y and X too
    from mocapkit.cleaning.measured import REPAIR_TOLERANCE_DEG

    raw = repair_take(filled, det).rotations[20:26, 2]
    assert np.degrees(R.geodesic_angle(done.motion.rotations[20:26, 2], raw)).max() <= REPAIR_TOLERANCE_DEG
    assert done.measured.startswith("6 filled cells (LeftUpLeg) kept the file's measured channels")


def test_the_repair_step_says_which_filled_cells_kept_their_measured_channels_and_which_it_changed_whole(
        tmp_path, monkeypatch):
    """The repair of a filled cell either keeps its measured channels (its nan one alone reaches the repair) or
    stands whole, moving them (evidence against them: frame 60's 12 deg spike in its measured Y and X). clean's repair
    step said neither, so a user could not tell that measured numbers were changed, nor why; the denoise says its
    kept cells. Now the repair's note says both, a count and the joints. cmu_01_01_start's LeftUpLeg as above,
    detection set to flag frames 20-25 and 60 (the take is too short for its own detection to judge them)."""
    from mocapkit.cleaning import pipeline

    path = tmp_path / "one_nan.bvh"
    _one_nan_and_a_spike(path)
    detect = pipeline.detect_take

    def flagging(motion, *args, **kwargs):
        found = detect(motion, *args, **kwargs)
        flags = np.zeros((motion.num_frames, motion.num_joints), dtype=bool)
        flags[20:26, 2] = flags[60, 2] = True
        return dataclasses.replace(found, detection=dataclasses.replace(found.detection, flags=flags))

    monkeypatch.setattr(pipeline, "detect_take", flagging)
    res = pipeline.clean(read_bvh(path), steps="fill,detect,repair")
    note = next(s.note for s in res.steps if s.name == "repair")
    assert ("6 filled cells (LeftUpLeg) kept the file's measured channels, the repair moving the missing ones alone "
            "(within 1 deg of its rotation); 1 filled cell (LeftUpLeg) changed whole by the repair, measured channels "
            "too: the missing ones alone came no nearer than 1 deg to its rotation (evidence against the measured "
            "ones)") in note, note


def _noisy_around(src: Path, out: Path, column: int, gap: range, sigma: float, in_gap: bool) -> list[str]:
    """``src`` with its ``column``-th number ``nan`` in frames ``gap`` and white noise of ``sigma`` deg (seeded) on
    the three numbers of that column's joint in every other frame (``in_gap``: on the gap's measured numbers too)."""
    lines = src.read_text().split("\n")
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    rng, base = np.random.default_rng(0), column - column % 3
    for f in range(len(lines) - at):
        tokens = lines[at + f].split(" ")
        if len(tokens) <= column:
            continue
        for k in range(base, base + 3):
            if f in gap and k == column:
                tokens[k] = "nan"
            elif in_gap or f not in gap:
                tokens[k] = f"{float(tokens[k]) + rng.normal(0.0, sigma):.4f}"
        lines[at + f] = " ".join(tokens)
    out.write_text("\n".join(lines))
    return lines


@pytest.mark.parametrize("in_gap", [False, True])
def test_a_denoise_of_a_filled_cell_moves_its_missing_channel_not_clean_measured_ones(tmp_path, in_gap):
    """cmu_01_01_start's LeftUpLeg with its Zrotation nan in frames 45-50 and 2 deg noise written on its channels
    around them: noisy, its run denoised whole, the filled cells in it too. Their measured Y and X, which carry no
    noise, moved by up to 0.85 deg (numbers the file measured, changed on no evidence against them); now only the
    nan numbers change there, and the step's note says so. With the noise on those measured numbers too
    (``in_gap``), no Z reaches the denoised rotation: the denoise stands whole, the noise its evidence."""
    from mocapkit.cleaning.pipeline import clean

    path = tmp_path / "noisy.bvh"
    lines = _noisy_around(DATA / "cmu_01_01_start.bvh", path, 9, range(45, 51), 2.0, in_gap)
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    res = clean(read_bvh(path), steps="fill,denoise")
    assert res.filled[45:51, 2].all() and res.denoised[45:51, 2].all()
    out = tmp_path / "out.bvh"
    write_bvh(res.motion, out, like=path)
    written = out.read_text().split("\n")
    changed = {(i - at, k) for i, (a, b) in enumerate(zip(lines, written)) for k, (x, y) in
               enumerate(zip(a.split(" "), b.split(" "))) if x != y and 45 <= i - at < 51}
    note = next(s.note for s in res.steps if s.name == "denoise")
    if in_gap:
        assert {k for _, k in changed} == {9, 10, 11} and "kept the file's measured channels" not in note
        assert "(LeftUpLeg) changed whole by the denoise, measured channels too" in note  # said, as the repair's
    else:
        assert changed == {(f, 9) for f in range(45, 51)}
        assert "6 filled cells (LeftUpLeg) kept the file's measured channels" in note


def test_denoise_take_of_a_whole_filled_take_keeps_clean_measured_channels(tmp_path):
    """The same take through whole_take.denoise_take (``mocapkit denoise``'s path, and clean's on a take with no
    calibration pose): the whole take has the file's rows, and there the filled cells keep their measured ones (all
    but one, whose measured ones alone the EBF moved by more than the tolerance: its denoise stands whole)."""
    from mocapkit.cleaning.pipeline import noisy_cells
    from mocapkit.cleaning.whole_take import denoise_take

    path = tmp_path / "noisy.bvh"
    lines = _noisy_around(DATA / "cmu_01_01_start.bvh", path, 9, range(45, 51), 2.0, False)
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    filled = fill_take(read_bvh(path))
    noisy, _ = noisy_cells(filled.motion, filled=filled.filled)
    out, _, note = denoise_take(filled.motion, cells=noisy)
    raw = np.array([[float(x) for x in lines[at + f].split(" ")[10:12]] for f in range(45, 51)])
    same = np.isclose(out.channel_values()[45:51, 10:12], raw, rtol=0.0, atol=1e-9).all(axis=1)  # Y and X: the file's
    assert noisy[45:51, 2].all() and same.sum() >= 5  # (one, 1.2 deg off, stands whole: the EBF reads frame 0 here)
    assert f"{same.sum()} filled cells (LeftUpLeg) kept the file's measured channels" in note


def test_a_teleport_put_back_moves_a_measured_root_axis_only_on_its_own_jump(tmp_path):
    """cmu_01_01_start's root with its Yposition nan in frames 30-32 and 70-72 (filled, X and Z kept as written),
    and a teleport in those frames: X and Z 20 in away in 30-32, X alone in 70-72. The put-back replaced the whole
    position by the line between the frames around: in 70-72 the measured Z, on its path, moved too (by up to 0.006
    in), on no evidence against it. Now it is written as the file gives it there; X (its jump) and the filled Y are
    put back, and in 30-32 Z, which jumps too, is."""
    from mocapkit.cleaning.whole_take import detect_take, repair_whole

    path = tmp_path / "teleport.bvh"
    lines = _with_nan(DATA / "cmu_01_01_start.bvh", path, 1, [*range(30, 33), *range(70, 73)])  # the root's Y
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    for f in [*range(30, 33), *range(70, 73)]:
        tokens = lines[at + f].split(" ")
        for k in (0, 2) if f < 50 else (0,):
            tokens[k] = f"{float(tokens[k]) + 20:.5f}"
        lines[at + f] = " ".join(tokens)
    path.write_text("\n".join(lines))
    filled = fill_take(read_bvh(path)).motion
    done = repair_whole(filled, detect_take(filled).detection)
    assert len(done.put_back) == 2 and done.teleported[30:33, 0].all() and done.teleported[70:73, 0].all()
    out = tmp_path / "out.bvh"
    write_bvh(done.motion, out, like=path)
    written = out.read_text().split("\n")
    changed = {(i - at, k) for i, (a, b) in enumerate(zip(lines, written)) for k, (x, y) in
               enumerate(zip(a.split(" "), b.split(" "))) if x != y and k < 3}
    want = {(f, k) for f in range(30, 33) for k in (0, 1, 2)} | {(f, k) for f in range(70, 73) for k in (0, 1)}
    assert changed == want  # 70-72: Z as the file writes it


def test_a_file_that_writes_no_nan_is_not_read_again_for_measured_channels(tmp_path, monkeypatch):
    """The denoise and the repair keep a filled cell's measured channels from its file (keep_measured_in_denoise,
    keep_measured_in_repair), and parsed the file's numbers again on every take they changed: 0.5-0.8 s a call on a
    4.5-minute BVH. A file whose text holds no ``nan`` has no partly measured cell: it is not parsed again."""
    import mocapkit.io.bvh as bvh
    from mocapkit.cleaning.measured import keep_measured_in_denoise, measured_axes

    calls = []
    real = bvh.source_values
    monkeypatch.setattr(bvh, "source_values", lambda *a, **k: calls.append(1) or real(*a, **k))
    for path, parsed in [(DATA / "cmu_01_01_start.bvh", False), (tmp_path / "gap.bvh", True)]:
        if parsed:
            _with_nan(DATA / "cmu_01_01_start.bvh", path, 7, range(20, 26))
        take = fill_take(read_bvh(path)).motion
        moved = dataclasses.replace(take, rotations=np.roll(take.rotations, 1, axis=0))  # every cell changed
        calls.clear()
        keep_measured_in_denoise(take, moved)
        measured_axes(take)
        assert bool(calls) == parsed


def test_two_nan_channels_take_the_pair_nearest_the_fill(tmp_path):
    """131_01's LeftElbow (ZXY) with its Zrotation and Xrotation nan in frames 300-339 and its Yrotation measured,
    filled 5 deg off the file's rotation (about the joint's local Y): the Z and X kept are the pair whose rotation,
    beside the measured Y, is nearest the fill (no step of either angle brings it nearer), 3.2 deg from it on
    average. The fill's own Z and X set beside the measured Y were 5.0 deg from it. The measured Y stays the
    file's text."""
    from mocapkit import rotations as R
    from mocapkit.cleaning.measured import keep_measured

    src = samples.path("131_01.bvh")
    path = tmp_path / "two_nan.bvh"
    lines = _with_nan(src, path, 60, range(300, 340))
    _with_nan(path, path, 61, range(300, 340))
    before, truth = read_bvh(path), read_bvh(src)
    assert before.missing()[300:340, 19].all() and before.missing().sum() == 40
    off = np.broadcast_to(R.euler_to_quaternion(np.array([5.0, 0.0, 0.0]), "YXZ"), (40, 4))
    rot = np.array(truth.rotations)
    rot[300:340, 19] = R.quaternion_multiply(rot[300:340, 19], off)
    kept, cells = keep_measured(before, dataclasses.replace(before, rotations=rot))
    assert cells[300:340, 19].all() and cells.sum() == 40
    fill = rot[300:340, 19]
    away = np.degrees(R.geodesic_angle(kept.rotations[300:340, 19], fill))
    assert away.mean() < 3.5
    zxy = R.quaternion_to_euler(kept.rotations[300:340, 19], "ZXY")
    for k in (0, 1):  # the nearest: a step of Z or of X either way moves the rotation away from the fill
        for step in (-0.05, 0.05):
            moved = zxy.copy()
            moved[:, k] += step
            assert np.all(np.degrees(R.geodesic_angle(R.euler_to_quaternion(moved, "ZXY"), fill)) >= away - 1e-9)
    out = tmp_path / "out.bvh"
    write_bvh(kept, out, like=path)
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    written, given = out.read_text().split("\n"), path.read_text().split("\n")
    changed = {(i - at, k) for i, (a, b) in enumerate(zip(given, written)) for k, (x, y) in
               enumerate(zip(a.split(" "), b.split(" "))) if x != y}
    assert changed == {(f, k) for f in range(300, 340) for k in (60, 61)}  # the nan numbers alone



def _amc_with_nan(path: Path, nan: dict) -> list[str]:
    """12_walk.amc (and its 12.asf beside it) at ``path`` with, for each ``bone: (dofs, frames)`` of ``nan``, those
    dofs (0-based, after the bone's name) written ``nan`` in those 0-based frames; the file's lines."""
    import shutil

    lines = samples.path("12_walk.amc").read_text(encoding="latin-1").split("\n")
    shutil.copy(samples.path("12.asf"), path.with_suffix(".asf"))
    at, first = None, None
    for i, line in enumerate(lines):
        tokens = line.split(" ")
        if len(tokens) == 1 and tokens[0].isdigit():
            at = int(tokens[0])
            first = at if first is None else first
        elif at is not None and tokens[0] in nan and at - first in nan[tokens[0]][1]:
            for d in nan[tokens[0]][0]:
                tokens[1 + d] = "nan"
            lines[i] = " ".join(tokens)
    path.write_text("\n".join(lines), encoding="latin-1")
    return lines


def test_every_fill_path_names_the_channels_it_filled_and_keeps_the_measured_ones(tmp_path):
    """12_walk.amc with lhumerus' rx and rz ``nan`` in frames 100-139 (its ry measured) and lradius (one dof) ``nan``
    whole in frames 200-209: `mocapkit fill`, `mocapkit clean` (all steps and ``--steps fill``) and
    ``mocapkit.clean`` write the ``nan`` numbers alone, and each says which channels of the partly measured cells
    it filled (the summary, the record, the report, the fill command's lines); the whole joint's gap is the cell count's. The
    fill said "50 joint samples changed" and named no channel: which numbers of lhumerus were the file's and which
    made up could be told only by a diff with the input."""
    import mocapkit
    from mocapkit.cleaning.clean_record import CleanResult
    from mocapkit.report.html import write_clean_report
    from tests.cli.helpers import run

    path = tmp_path / "two_nan.amc"
    given = _amc_with_nan(path, {"lhumerus": ((0, 2), range(100, 140)), "lradius": ((0,), range(200, 210))})
    nan_at = {(i, k) for i, line in enumerate(given) for k, x in enumerate(line.split(" ")) if x == "nan"}
    assert len(nan_at) == 90
    said = ("40 partly measured cells filled in their nan channels alone, the measured channels kept as the file "
            "writes them: lhumerus rx and rz (frames 100-139)")
    done = fill_take(read_amc(path))
    assert said in done.warnings and done.filled.sum() == 50
    res = mocapkit.clean(path, steps="fill")
    assert any(said in line for line in res.summary())
    res.save(tmp_path / "rec.clean.npz")
    assert said in CleanResult.load(tmp_path / "rec.clean.npz").steps[0].note
    write_clean_report(tmp_path / "report.html", read_amc(path), res)
    assert said in (tmp_path / "report.html").read_text()
    for args in (["fill"], ["clean", "--steps", "fill"], ["clean"]):
        out = tmp_path / f"{args[0]}_{len(args)}.amc"
        code, stdout, _ = run(*args, path, "-o", out)
        assert code == 0 and said in " ".join(stdout.split()), (args, stdout)
        written = out.read_text(encoding="latin-1").split("\n")
        changed = {(i, k) for i, (a, b) in enumerate(zip(given, written)) for k, (x, y) in
                   enumerate(zip(a.split(" "), b.split(" "))) if x != y}
        assert changed == nan_at, args  # every nan filled, every measured number the file's text


def test_the_numbers_a_bvh_holds_in_memory_are_the_files_measured_ones_bit_for_bit(tmp_path):
    """131_01's LeftElbow with its Xrotation ``nan`` in frames 300-339 (Z and Y measured) and its root's Yposition
    in frames 500-539, filled: :func:`mocapkit.io.bvh.written_values` (the numbers a BVH written from the take
    holds) gives every number the file measures bit for bit, as the file written does. It gave the measured
    angles of the filled cells as their rotation's conversion, some 1e-14 deg off the file's."""
    from mocapkit.cleaning.gapfill import fill_motion
    from mocapkit.cleaning.measured import keep_measured
    from mocapkit.io.bvh import written_values

    path = tmp_path / "one_nan.bvh"
    lines = _with_nan(samples.path("131_01.bvh"), path, 61, range(300, 340))
    _with_nan(path, path, 1, range(500, 540))
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    given = np.array([[float(x) for x in t.split()] for t in path.read_text().split("\n")[at:] if t.strip()])
    before = read_bvh(path)
    kept, cells = keep_measured(before, fill_motion(before, "cubic"))
    assert cells[300:340, 19].all() and not kept.missing().any()
    numbers = written_values(kept)
    measured = np.isfinite(given)
    assert np.array_equal(numbers[measured], given[measured])
    assert np.isfinite(numbers).all()
    out = tmp_path / "out.bvh"
    write_bvh(kept, out, like=path)
    back = np.array([[float(x) for x in t.split()] for t in out.read_text().split("\n")[at:] if t.strip()])
    assert np.array_equal(back[measured], given[measured])



def test_the_spline_fallback_keeps_the_measured_channels_and_names_the_filled_one(tmp_path, monkeypatch):
    """131_01 with LeftElbow's Xrotation ``nan`` in frames 300-339, filled where no network serves the take (the
    cubic spline of fill_or_fallback's fallback): the spline's fill is kept on the measured Z and Y as the
    networks' is, only the ``nan`` numbers written, and the fill's lines name the channel."""
    from mocapkit.cleaning.deep import inference

    monkeypatch.setattr(inference, "served_or_refused", lambda motion, model, kind: (None, "no network serves it"))
    path = tmp_path / "one_nan.bvh"
    given = _with_nan(samples.path("131_01.bvh"), path, 61, range(300, 340))
    done = fill_take(read_bvh(path))
    assert done.method == inference.FALLBACK_FILL and done.filled.sum() == 40
    assert done.warnings == ("40 partly measured cells filled in their nan channels alone, the measured channels "
                             "kept as the file writes them: LeftElbow Xrotation (frames 300-339)",)
    out = tmp_path / "out.bvh"
    write_bvh(done.motion, out, like=path)
    at = next(i for i, t in enumerate(given) if t.startswith("Frame Time")) + 1
    written = out.read_text().split("\n")
    changed = [(i, k) for i, (a, b) in enumerate(zip(given, written)) for k, (x, y) in
               enumerate(zip(a.split(" "), b.split(" "))) if x != y]
    assert changed == [(at + f, 61) for f in range(300, 340)]
