"""Interpolated frames (mocapkit.cleaning.inbetweens): the midpoint of their neighbours, told from real motion."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

import mocapkit
from mocapkit import samples
from mocapkit.cleaning.inbetweens import Inbetween, find_inbetweens, inbetweens_note, midpoint_frames, written_steps
from mocapkit.motion import Motion
from tests.cleaning.ssa.helpers import with_midpoints

DATA = Path(__file__).resolve().parents[1] / "data"


def test_written_steps_read_the_files_precision():
    bvh = mocapkit.load(samples.path("131_01.bvh")).channel_values()  # four fixed decimals
    assert np.all(written_steps(bvh) == 1e-4)
    amc = mocapkit.load(samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"),
                        asf=samples.path("HDM_bd.asf")).channel_values()  # six significant digits
    steps = written_steps(amc)
    big = np.abs(amc) >= 100
    assert big.any() and np.allclose(steps[big], 10.0 ** (np.floor(np.log10(np.abs(amc[big]))) - 5))


def test_clean_takes_have_no_interpolated_frame(shared_data):
    # real motion at 120 fps is nearly linear over three frames, but never on every channel to the file's precision
    takes = [mocapkit.load(samples.path("131_01.bvh")),
             mocapkit.load(samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"), asf=samples.path("HDM_bd.asf")),
             mocapkit.load(samples.path("12_walk.amc"), asf=samples.path("12.asf")),
             mocapkit.load(DATA / "dataset-2_run_active_049.bvh")]
    takes += [mocapkit.load(p) for p in sorted((shared_data / "secondary_bandai_namco_CC-BY-NC").glob("*.bvh"))]
    for m in takes:
        assert not midpoint_frames(m).any(), m.name


def test_inserted_midpoints_are_found(tmp_path):
    src = samples.path("131_01.bvh")
    m = with_midpoints(Path(src), [300, 500, 501], tmp_path / "retimed.bvh", 4)
    found = find_inbetweens(mocapkit.load(m))
    # after frame 300: frame 301; after 500 and after 501: frames 502 and 504, the recorded 501 between them
    assert found == (Inbetween(301, 301), Inbetween(502, 502), Inbetween(504, 504))
    assert inbetweens_note(found).startswith("3 frames (301, 502, 504) look interpolated")


def test_a_linear_blend_of_channels_is_found_and_a_run_of_two():
    m = mocapkit.load(samples.path("131_01.bvh"))[1:200]
    x = m.channel_values()
    thirds = np.stack([x[99] + (x[100] - x[99]) / 3, x[99] + 2 * (x[100] - x[99]) / 3])
    y = np.round(np.concatenate([x[:100], thirds, x[100:]]), 4)
    retimed = Motion.from_channel_values(m.skeleton, y, m.fps)
    assert find_inbetweens(retimed) == (Inbetween(100, 101),)
    skip = np.zeros(retimed.num_frames, dtype=bool)
    skip[99] = True
    assert find_inbetweens(retimed, skip=skip) == ()


def _reference_steps(x: np.ndarray) -> np.ndarray:
    """written_steps by its definition: every candidate precision's share read over all the nonzero values."""
    def share(v, step):
        k = v / step
        return np.mean(np.abs(k - np.round(k)) <= 1e-6 + 1e-9 * np.abs(k))

    floor = 16 * np.spacing(np.maximum(np.abs(x), 1.0))
    nz = np.isfinite(x) & (x != 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.floor(np.log10(np.abs(x)))
    found = [np.full(x.shape, 10.0 ** -d) for d in range(10) if share(x[nz], 10.0 ** -d) >= 0.99][:1]
    found += [np.where(nz, 10.0 ** (np.where(nz, e, 0.0) - s + 1), 0.0) for s in range(1, 13)
              if share(x[nz], 10.0 ** (e[nz] - s + 1)) >= 0.99][:1]
    best = max(found, key=lambda c: float(np.mean(np.log10(c[nz])))) if found else floor
    return np.maximum(best, floor)


def test_written_steps_read_few_values_for_the_same_precision(monkeypatch):
    # a precision most values miss is refused after the first values, and the answer is the one every value gives
    from mocapkit.cleaning import inbetweens

    takes = [mocapkit.load(samples.path("131_01.bvh")),
             mocapkit.load(samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"), asf=samples.path("HDM_bd.asf")),
             mocapkit.load(DATA / "dataset-2_run_active_049.bvh")]
    checked = []
    fits = inbetweens._fits
    monkeypatch.setattr(inbetweens, "_fits", lambda x, step: checked.append(x.size) or fits(x, step))
    for m in takes:
        x = m.channel_values()
        x[5:9, 3] = np.nan  # a gap
        checked.clear()
        assert np.array_equal(written_steps(x), _reference_steps(x), equal_nan=True), m.name
        nonzero = np.count_nonzero(np.isfinite(x) & (x != 0))
        assert sum(checked) < 5 * nonzero, m.name  # every candidate over every value: 11 to 22 times as many


def test_slerp_midpoints_are_made_only_where_the_cheap_tests_leave_a_frame_open(tmp_path, monkeypatch):
    from mocapkit.cleaning import inbetweens

    m = mocapkit.load(with_midpoints(Path(samples.path("131_01.bvh")), [300, 500, 501], tmp_path / "retimed.bvh", 4))
    rows = []
    slerp = inbetweens.R.slerp
    monkeypatch.setattr(inbetweens.R, "slerp", lambda a, b, t: rows.append(len(a)) or slerp(a, b, t))
    assert find_inbetweens(m) == (Inbetween(301, 301), Inbetween(502, 502), Inbetween(504, 504))
    # the three, and the few frames whose root stands still to the file's precision: not each of the F - 2 frames
    assert 3 <= sum(rows) < 0.05 * (m.num_frames - 2)


def _upsampled(path: Path, fps: float, out: Path, asf=None) -> Motion:
    """The first 1.5 s of the take at ``path`` upsampled to ``fps`` by slerp (``convert --fps``), written and
    read back."""
    m = mocapkit.load(path) if asf is None else mocapkit.load(path, asf=asf)
    m = m[1:int(1.5 * m.fps) + 1]
    with warnings.catch_warnings():  # slerp turns an AMC's 2-dof bones a little about their third axis: said, dropped
        warnings.filterwarnings("ignore", message=".*turn about other axes too", category=UserWarning)
        saved = mocapkit.save(m.resample(fps), out, asf=asf) if asf is not None else mocapkit.save(m.resample(fps), out)
    return mocapkit.load(saved) if asf is None else mocapkit.load(saved, asf=asf)


def test_a_take_upsampled_by_slerp_keeps_its_frames(tmp_path):
    # every other frame (120 -> 240 fps), three of every four (30 -> 120 fps) is a midpoint at its true time: left
    # out, the take would be analysed at twice (four times) its speed
    for src, fps in ((samples.path("131_01.bvh"), 240.0), (DATA / "dataset-2_run_active_049.bvh", 120.0)):
        up = _upsampled(Path(src), fps, tmp_path / f"up{fps:g}.bvh")
        assert midpoint_frames(up).mean() > 0.45, up.name
        assert find_inbetweens(up) == (), up.name


def test_upsampling_tells_a_regular_pattern_from_frames_inserted(tmp_path):
    from mocapkit.cleaning.inbetweens import interpolated_note, midpoint_runs, upsampling

    up = _upsampled(samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"), 240.0, tmp_path / "up.amc",
                    asf=samples.path("HDM_bd.asf"))
    assert upsampling(midpoint_runs(up), up.num_frames) == 2
    assert "about 1 of every 2 (the take looks upsampled" in interpolated_note(up)
    retimed = mocapkit.load(with_midpoints(Path(samples.path("131_01.bvh")), [300, 500, 501],
                                           tmp_path / "retimed.bvh", 4))
    assert upsampling(midpoint_runs(retimed), retimed.num_frames) == 0
    assert interpolated_note(retimed).startswith("3 frames (301, 502, 504) look interpolated")
