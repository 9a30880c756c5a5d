"""Accelerometer recordings as CSV: the input of the accelerometer reconstruction.

One header line, then one line per sample::

    time,left_wrist.x,left_wrist.y,left_wrist.z,right_wrist.x,...,right_ankle.z
    0.000000,1.234,-9.61,0.52,...

``time`` then three columns ``<sensor>.x, <sensor>.y, <sensor>.z`` per
sensor, in the sensor's local frame, m/s^2 (gravity included, as an
accelerometer reads it); time in seconds, strictly increasing, at a rate from
1 Hz to 100 kHz (:data:`RATE_RANGE`). Empty cells
and ``nan`` are missing values; an infinite reading is refused, and so is a
recording none of whose samples has every reading (it would reconstruct one
frozen pose). The default sensor names
(:data:`DEFAULT_SENSOR_NAMES`) are those of
:func:`mocapkit.features.default_sensors`. Irregular time stamps are
resampled (linearly) to a uniform grid at the recording's nominal rate
(:func:`nominal_rate`): stamps that jitter about a steady rate keep one frame
per sample; where samples were dropped the grid spans the recording.

The readings feed :func:`mocapkit.reconstruct.accelerometers.reconstruct`
(Tautges 2012, ch. 3), which expects them as an (F, S, 3) array at one rate.

>>> import numpy as np, tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> t = np.arange(3) / 100.0
>>> path = write_readings_csv(folder / "rec.csv", t, np.full((3, 4, 3), 9.81))
>>> times, readings, names = read_readings_csv(path)
>>> readings.shape, names[0], float(readings[0, 0, 0])
((3, 4, 3), 'left_wrist', 9.81)
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import MocapFormatError
from . import atomic_write
from ..words import plural

__all__ = ["DEFAULT_SENSOR_NAMES", "RATE_RANGE", "nominal_rate", "read_readings_csv", "write_readings_csv"]

#: Sensor names of :func:`mocapkit.features.default_sensors`, in its order.
DEFAULT_SENSOR_NAMES = ("left_wrist", "right_wrist", "left_ankle", "right_ankle")


#: Sample rates (Hz) a recording is read at: a median time step outside them is a time column in another unit.
RATE_RANGE = (1.0, 100_000.0)

# rates a recording is taken at: a time stamp's rate within 0.1 % of one of them is that rate (as BVH frame times are read)
_RATES = (24, 25, 30, 48, 50, 60, 100, 120, 240, 250, 500, 1000)


def nominal_rate(times) -> tuple[float, bool]:
    """The rate (Hz) a recording's time stamps (F,) were taken at, and whether every sample has its own frame.

    Each interval is compared with the median interval. When none is 1.5
    times the median or more (no sample dropped: the stamps only jitter),
    every sample is a frame and the rate is ``(F - 1) / (t[-1] - t[0])``, one
    over the mean interval: a jitter that is not symmetric moves the median
    (8.24 ms for a 120 Hz recording with +-2 ms of jitter), not the mean.
    Otherwise the rate is one over the median interval, and the grid spans
    the recording. A rate within 0.1 % of a whole rate, of one of the usual
    capture rates or of its NTSC variant (``r * 1000 / 1001``) is that rate,
    as :func:`mocapkit.io.bvh.read_bvh` reads frame times.

    Raises ``ValueError`` for fewer than two stamps (no rate to read).
    """
    t = np.asarray(times, dtype=np.float64)
    if t.size < 2:
        raise ValueError(f"{t.size} sample gives no rate; at least 2 are needed")
    dt = np.diff(t)
    step = float(np.median(dt))
    per_sample = bool(np.all(dt < 1.5 * step))
    fps = (t.size - 1) / float(t[-1] - t[0]) if per_sample else 1.0 / step
    for r in (round(fps), *_RATES, *(r * 1000 / 1001 for r in _RATES)):
        if r >= 1 and abs(fps - r) <= 1e-3 * r:
            return float(r), per_sample
    return fps, per_sample


def _parse_cell(s: str) -> float:
    s = s.strip()
    if s == "":
        return math.nan
    return float(s)


def read_readings_csv(path, fps: float | None = None):
    """Read a recording of accelerometer readings (format in the module docstring).

    Parameters
    ----------
    path : str or Path
    fps : float, optional
        Resample to this rate. When None, uniform time stamps are kept as
        they are and irregular ones are resampled to the nominal rate
        (:func:`nominal_rate`): one frame per sample when they only jitter.

    Returns
    -------
    timestamps : float array (F,), seconds, uniform
    readings : float array (F, S, 3), m/s^2
    sensor_names : list of str (S,)

    Raises
    ------
    MocapFormatError
        ``"PATH:LINE: reason"`` for a bad header, a bad number, a wrong
        number of values, non-increasing or non-finite time, a median time
        step outside :data:`RATE_RANGE` (a time column in ms or us), an
        infinite reading, or no sample with every reading.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as e:
        raise MocapFormatError(path, f"cannot read the file: {e}") from None
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise MocapFormatError(path, "empty file; expected a header 'time,<sensor>.x,<sensor>.y,<sensor>.z,...'", 1)
    head = [h.strip() for h in lines[0].split(",")]
    if head[0].lower() != "time":
        raise MocapFormatError(path, f"the first column must be 'time', got {head[0]!r}", 1)
    cols = head[1:]
    if not cols or len(cols) % 3:
        raise MocapFormatError(path, f"expected 3 columns <sensor>.x,<sensor>.y,<sensor>.z per sensor after 'time', got {len(cols)}", 1)
    names = []
    for s in range(len(cols) // 3):
        trio = cols[3 * s:3 * s + 3]
        base = trio[0].rsplit(".", 1)[0] if "." in trio[0] else None
        if base is None or trio != [f"{base}.x", f"{base}.y", f"{base}.z"] or not base:
            raise MocapFormatError(path, f"columns {3 * s + 2}-{3 * s + 4} must be <sensor>.x,<sensor>.y,<sensor>.z, got {','.join(trio)}", 1)
        if base in names:
            raise MocapFormatError(path, f"sensor {base!r} appears twice in the header", 1)
        names.append(base)
    ncol = 1 + len(cols)
    rows = []
    lineno = []
    for ln, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = line.split(",")
        if len(cells) != ncol:
            raise MocapFormatError(path, f"expected {plural(ncol, 'value')}, got {len(cells)}", ln)
        try:
            vals = [_parse_cell(c) for c in cells]
        except ValueError:
            bad = next(c for c in cells if not _is_number(c))
            raise MocapFormatError(path, f"not a number: {bad.strip()!r}", ln) from None
        if not np.isfinite(vals[0]):
            raise MocapFormatError(path, "the time must be a finite number", ln)
        inf = next((k for k, v in enumerate(vals) if k and math.isinf(v)), None)
        if inf is not None:  # a saturated or broken sensor: not an acceleration, nor a missing sample (empty / nan)
            raise MocapFormatError(path, f"column {head[inf]}: an infinite reading {cells[inf].strip()!r} (a reading is a "
                                   "finite number, or empty or nan where missing)", ln)
        if rows and vals[0] <= rows[-1][0]:
            raise MocapFormatError(path, f"time {vals[0]:g} s does not increase (previous {rows[-1][0]:g} s)", ln)
        rows.append(vals)
        lineno.append(ln)
    if not rows:
        raise MocapFormatError(path, "no data rows after the header")
    data = np.array(rows, dtype=np.float64)
    _check_some_sample_complete(path, data[:, 1:], cols)
    t = data[:, 0]
    a = data[:, 1:].reshape(len(t), len(names), 3)
    dt = np.diff(t)
    if dt.size and not RATE_RANGE[0] <= 1.0 / float(np.median(dt)) <= RATE_RANGE[1]:
        # a time column in ms or us reads as a rate under 1 Hz: resampled to a database's rate it became hours of frames
        step = float(np.median(dt))
        raise MocapFormatError(path, f"time stamps {step:.4g} s apart ({1.0 / step:.3g} Hz): is the time column in "
                               f"milliseconds or microseconds? It is in seconds, for a rate from {RATE_RANGE[0]:g} Hz "
                               f"to {RATE_RANGE[1]:g} Hz")
    if fps is None:
        if dt.size == 0:
            return t, a, names
        step = float(np.median(dt))
        if np.all(np.abs(dt - step) <= 1e-3 * step + 2e-6):
            return t, a, names
        fps, per_sample = nominal_rate(t)
        G = len(t) if per_sample else int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1
    else:
        fps = float(fps)
        if not np.isfinite(fps) or fps <= 0:
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        G = int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1
    tg = t[0] + np.arange(G) / fps
    flat = a.reshape(len(t), -1)
    out = np.stack([np.interp(tg, t, flat[:, c]) for c in range(flat.shape[1])], axis=1)
    return tg, out.reshape(G, len(names), 3), names


def _check_some_sample_complete(path: Path, values: np.ndarray, columns: list[str]) -> None:
    """Refuse a recording (values (N, 3S), m/s^2, NaN where missing) none of whose samples has every reading.

    A sample missing a reading holds the pose (Tautges 2012, ch. 3, as
    :mod:`mocapkit.reconstruct.accelerometers.synthesis` runs it): with no
    complete sample the whole take would come back as one frozen pose, written
    and reported as a reconstruction. Names the column empty in every row, if
    one is (a sensor not recorded), else says every row misses one.
    """
    seen = np.isfinite(values)
    if seen.all(axis=1).any():
        return
    empty = [c for c, s in zip(columns, seen.any(axis=0)) if not s]
    why = (f"column{'s' if len(empty) > 1 else ''} {', '.join(empty[:3])}{', ...' if len(empty) > 3 else ''} "
           f"{'are' if len(empty) > 1 else 'is'} empty in every row") if empty else "every row misses one"
    raise MocapFormatError(path, f"no sample has all {len(columns)} readings ({why}): nothing to reconstruct from")


def _is_number(s: str) -> bool:
    try:
        _parse_cell(s)
        return True
    except ValueError:
        return False


def write_readings_csv(path, timestamps, readings, sensor_names=None, digits: int = 9) -> Path:
    """Write a recording (format in the module docstring), atomically (temp file + rename).

    Parameters
    ----------
    path : str or Path
    timestamps : float array (F,)
        Seconds, finite and strictly increasing.
    readings : float array (F, S, 3)
        m/s^2 in each sensor's frame; NaN is written as ``nan``.
    sensor_names : sequence of str (S,), optional
        The first S of :data:`DEFAULT_SENSOR_NAMES`; ``sensor0, sensor1, ...`` for more than four sensors.
    digits : int
        Significant digits of the readings (time is written with 6 decimals,
        microseconds).

    Returns the path.
    """
    t = np.asarray(timestamps, dtype=np.float64)
    a = np.asarray(readings, dtype=np.float64)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"readings: expected shape (F, S, 3), got {a.shape}")
    if t.shape != (a.shape[0],):
        raise ValueError(f"timestamps: expected shape ({a.shape[0]},), got {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError("timestamps must be finite and strictly increasing")
    S = a.shape[1]
    if sensor_names is None:
        n = len(DEFAULT_SENSOR_NAMES)
        sensor_names = DEFAULT_SENSOR_NAMES[:S] if S <= n else [f"sensor{i}" for i in range(S)]
    names = [str(n) for n in sensor_names]
    if len(names) != S:
        raise ValueError(f"sensor_names: {plural(len(names), 'name')} for {plural(S, 'sensor')}")
    for n in names:
        if not n or "," in n or "\n" in n:
            raise ValueError(f"sensor name {n!r} cannot be written in a CSV header")
    path = Path(path)
    header = "time," + ",".join(f"{n}.{c}" for n in names for c in "xyz")
    fmt = f"{{:.{int(digits)}g}}"
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(header + "\n")
        flat = a.reshape(len(t), -1)
        for ti, row in zip(t, flat):
            fh.write(f"{ti:.6f}," + ",".join(fmt.format(v) for v in row) + "\n")
    return path
