"""Tests of mocapkit.io.readings: accelerometer recordings as CSV."""

from __future__ import annotations

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.errors import MocapFormatError
from mocapkit.features import default_sensors, virtual_accelerometers
from mocapkit.io.readings import DEFAULT_SENSOR_NAMES, read_readings_csv, write_readings_csv


@pytest.fixture(scope="module")
def readings():
    """Simulated readings (F, 4, 3) of a real take, m/s^2, as the accelerometer reconstruction takes them."""
    return virtual_accelerometers(mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")).resample(25))


def test_default_sensor_names_are_those_of_default_sensors():
    sk = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")).skeleton
    assert tuple(s.name for s in default_sensors(sk)) == DEFAULT_SENSOR_NAMES


def test_default_names_for_fewer_and_more_sensors(tmp_path):
    t = np.arange(2) / 10.0
    _, _, two = read_readings_csv(write_readings_csv(tmp_path / "two.csv", t, np.zeros((2, 2, 3))))
    _, _, five = read_readings_csv(write_readings_csv(tmp_path / "five.csv", t, np.zeros((2, 5, 3))))
    assert two == ["left_wrist", "right_wrist"]
    assert five == [f"sensor{i}" for i in range(5)]


def test_nan_round_trips_and_resampling_keeps_the_time_span(tmp_path):
    a = np.arange(4 * 1 * 3, dtype=np.float64).reshape(4, 1, 3)
    a[2, 0, 1] = np.nan
    path = write_readings_csv(tmp_path / "n.csv", [0.0, 0.1, 0.2, 0.3], a, ["s"])
    assert "nan" in path.read_text().splitlines()[3]
    t, b, _ = read_readings_csv(path)
    np.testing.assert_array_equal(np.isnan(b), np.isnan(a))
    t, b, _ = read_readings_csv(path, fps=20)
    np.testing.assert_allclose(t, np.arange(7) / 20.0)
    np.testing.assert_allclose(b[2, 0, 0], a[1, 0, 0])  # t = 0.1 s lies on both grids


def test_fps_must_be_positive(tmp_path):
    path = write_readings_csv(tmp_path / "f.csv", [0.0, 0.1], np.zeros((2, 4, 3)))
    for bad in (0, -5, float("nan")):
        with pytest.raises(ValueError, match="fps must be a positive number"):
            read_readings_csv(path, fps=bad)


def test_csv_round_trip(tmp_path, readings):
    t = np.arange(len(readings)) / 25.0
    path = write_readings_csv(tmp_path / "rec.csv", t, readings)
    ts, rd, names = read_readings_csv(path)
    assert names == ["left_wrist", "right_wrist", "left_ankle", "right_ankle"]
    np.testing.assert_array_equal(ts, [float(f"{x:.6f}") for x in t])
    np.testing.assert_array_equal(rd, np.vectorize(lambda v: float(f"{v:.9g}"))(readings))
    header = path.read_text().splitlines()[0]
    assert header.startswith("time,left_wrist.x,left_wrist.y,left_wrist.z,right_wrist.x")
    assert not list(tmp_path.glob(".*part"))


def test_csv_missing_values_and_irregular_times(tmp_path):
    p = tmp_path / "irr.csv"
    p.write_text("time,a.x,a.y,a.z\n0.0,1,2,3\n0.1,,nan,5\n0.25,4,5,6\n0.3,5,6,7\n0.4,6,7,8\n")
    ts, rd, names = read_readings_csv(p)
    assert names == ["a"]
    np.testing.assert_allclose(ts, [0.0, 0.1, 0.2, 0.3, 0.4])  # median interval 0.1 s
    np.testing.assert_allclose(rd[:, 0, 2], [3, 5, 5 + (6 - 5) * (0.1 / 0.15), 7, 8])
    assert np.isnan(rd[1, 0, 0]) and np.isnan(rd[2, 0, 1])
    ts, rd, _ = read_readings_csv(p, fps=20)
    assert len(ts) == 9 and rd.shape == (9, 1, 3)


@pytest.mark.parametrize(
    "text, match",
    [
        ("", r"bad\.csv:1: empty file"),
        ("t,a.x,a.y,a.z\n0,1,2,3\n", r"bad\.csv:1: the first column must be 'time'"),
        ("time,a.x,a.y\n0,1,2\n", r"bad\.csv:1: expected 3 columns"),
        ("time,a.x,a.z,a.y\n0,1,2,3\n", r"bad\.csv:1: columns 2-4"),
        ("time,a.x,a.y,a.z,a.x,a.y,a.z\n0,1,2,3,4,5,6\n", r"bad\.csv:1: sensor 'a' appears twice"),
        ("time,a.x,a.y,a.z\n0,1,2,3\n0.1,1,2\n", r"bad\.csv:3: expected 4 values, got 3"),
        ("time,a.x,a.y,a.z\n0,1,2,3\n0.1,1,zwei,3\n", r"bad\.csv:3: not a number: 'zwei'"),
        ("time,a.x,a.y,a.z\n0,1,2,3\n0,1,2,3\n", r"bad\.csv:3: time 0 s does not increase"),
        ("time,a.x,a.y,a.z\nnan,1,2,3\n", r"bad\.csv:2: the time must be a finite number"),
        ("time,a.x,a.y,a.z\n", r"bad\.csv: no data rows"),
        # a reading of inf is no acceleration and no missing sample: refused (was read as missing, the pose held)
        ("time,a.x,a.y,a.z\n0,1,2,3\n0.1,1,inf,3\n", r"bad\.csv:3: column a\.y: an infinite reading 'inf'"),
        ("time,a.x,a.y,a.z\n0,1,2,3\n0.1,1,-1e999,3\n", r"bad\.csv:3: column a\.y: an infinite reading '-1e999'"),
        # no sample with every reading: nothing to reconstruct from (was a frozen pose for the whole take, exit 0)
        ("time,a.x,a.y,a.z,b.x,b.y,b.z\n0,1,2,3,4,5,\n0.1,1,2,3,4,5,nan\n",
         r"bad\.csv: no sample has all 6 readings \(column b\.z is empty in every row\)"),
        ("time,a.x,a.y,a.z\n0,,2,3\n0.1,1,,3\n", r"bad\.csv: no sample has all 3 readings \(every row misses one\)"),
        # time in milliseconds: 0.03 Hz, upsampled to the database's rate (hours of frames) before the fix; now refused
        ("time,a.x,a.y,a.z\n0,1,2,3\n33.3,1,2,3\n66.7,1,2,3\n",
         r"bad\.csv: time stamps 33\.35 s apart \(0\.03 Hz\): is the time column in milliseconds"),
        ("time,a.x,a.y,a.z\n0,1,2,3\n1e-6,1,2,3\n2e-6,1,2,3\n", r"bad\.csv: time stamps 1e-06 s apart \(1e\+06 Hz\)"),
    ],
)
def test_csv_bad_files(tmp_path, text, match):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(MocapFormatError, match=match) as e:
        read_readings_csv(p)
    assert "\n" not in str(e.value)


def test_csv_write_refuses_bad_input(tmp_path):
    with pytest.raises(ValueError, match="increasing"):
        write_readings_csv(tmp_path / "x.csv", [0.0, 0.0], np.zeros((2, 4, 3)))
    with pytest.raises(ValueError, match="names"):
        write_readings_csv(tmp_path / "x.csv", [0.0, 1.0], np.zeros((2, 4, 3)), ["a"])
    assert not (tmp_path / "x.csv").exists()


def test_jittered_time_stamps_keep_one_frame_per_sample_at_the_nominal_rate(tmp_path):
    from mocapkit.io.readings import nominal_rate

    rng = np.random.default_rng(0)
    t = np.arange(262) / 120.0 + rng.uniform(0.0, 0.004, 262) ** 2 * 250 - 0.002  # jitter that is not symmetric
    t[0] = 0.0
    assert nominal_rate(t) == (120.0, True)
    ts, rd, _ = read_readings_csv(write_readings_csv(tmp_path / "j.csv", t, np.zeros((262, 4, 3))))
    assert len(ts) == 262 and rd.shape[0] == 262
    np.testing.assert_allclose(np.diff(ts), 1 / 120.0)
    with pytest.raises(ValueError, match="no rate"):
        nominal_rate([0.0])
