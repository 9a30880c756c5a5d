"""C3D data-block frames read with numpy: each point's fourth word, and trials longer than 65,535 frames.

The C3D header counts frames in 16-bit words, so it cannot state more than
65,535. Vicon writes a longer trial with the header's last frame at 65,535 and
the true first and last frames in ``TRIAL:ACTUAL_START_FIELD`` and
``TRIAL:ACTUAL_END_FIELD`` (each a 32-bit number in two 16-bit words, low word
first: 100,000 is [34464, 1]); c3d.org's other convention is the frame count in
``POINT:LONG_FRAMES`` (a float). ezc3d 1.7 reads neither and stops at 65,535
frames, so :func:`~mocapkit.io.c3d.read_c3d` asks :func:`long_trial_frames` how
many frames the file holds and reads those past ezc3d's with
:func:`read_frames`, from the data block ezc3d's parameters describe.
:func:`long_frame_parameters` are what :func:`~mocapkit.io.c3d.write_c3d` writes
so that every reader finds them all again. C3D format: Motion Lab Systems,
"The C3D File Format User Guide" (c3d.org).
"""

from __future__ import annotations

import struct

import numpy as np

from ..errors import MocapFormatError
from .c3d_layout import analog_offsets, analog_unsigned, channel_values, parameter_values
from ..words import plural

__all__ = ["FRAME_CAP", "trial_first", "read_float", "sample_bytes", "stored_values", "point_words", "missing_stored",
           "put_missing_stored", "residuals_and_cameras",
           "long_trial_frames", "read_frames", "rest_of_trial", "long_frame_parameters"]

FRAME_CAP = 65535
"""The most frames a C3D header (16-bit frame numbers) can state."""


def read_float(b: bytes, proc: int, at: int) -> float:
    """The 32-bit float at byte ``at`` in the file's processor format (84 Intel, 85 DEC, 86 big-endian IEEE).

    A DEC (VAX F) float is an IEEE float with its two 16-bit words swapped and
    an exponent 2 higher (the C3D user guide's conversion): read as IEEE, a
    DEC file's scale was a meaningless 2e21 (BTK's Gait.c3d, 0.0744 in fact).
    """
    if proc == 85:
        return struct.unpack("<f", bytes((b[at + 2], b[at + 3], b[at], b[at + 1])))[0] / 4.0
    return struct.unpack_from(">f" if proc == 86 else "<f", b, at)[0]


def sample_bytes(scale: float) -> int:
    """Bytes per stored value for a point scale: 4 (floats) when it is negative (or not a number), else 2."""
    return 2 if np.isfinite(scale) and scale >= 0 else 4


def _block(raw: bytes, begin: int, end: int, points: int, analog: int, scale: float):
    """Frames ``begin`` to ``end`` (0-based, end excluded) of the data block as (F, bytes a frame) uint8, the
    processor type, the byte order and the bytes a value; None when the file does not hold them whole."""
    proc = raw[(raw[0] - 1) * 512 + 3]
    e = ">" if proc == 86 else "<"
    data_start, = struct.unpack_from(e + "H", raw, 16)
    size = sample_bytes(scale)
    frame_bytes = (4 * points + analog) * size
    start = (data_start - 1) * 512 + begin * frame_bytes
    frames = end - begin
    if frames <= 0 or start < 0 or frame_bytes <= 0 or start + frames * frame_bytes > len(raw):
        return None
    block = np.frombuffer(raw, dtype=np.uint8, count=frames * frame_bytes, offset=start).reshape(frames, frame_bytes)
    return block, proc, e, size


def stored_values(raw_bytes: np.ndarray, proc: int, e: str, size: int, unsigned: bool = False) -> np.ndarray:
    """float64 values of the stored numbers in ``raw_bytes`` (..., size) uint8: 16-bit integers or floats
    (DEC floats: the two 16-bit halves swapped, the exponent 2 higher, as :func:`read_float`)."""
    data = np.ascontiguousarray(raw_bytes)
    if size == 2:
        return data.view(e + ("u2" if unsigned else "i2"))[..., 0].astype(np.float64)
    if proc == 85:
        return data[..., [2, 3, 0, 1]].copy().view("<f4")[..., 0].astype(np.float64) / 4.0
    return data.view(e + "f4")[..., 0].astype(np.float64)


def point_words(raw: bytes, frames: int, points: int, scale: float, analog: int | None = None) -> np.ndarray | None:
    """(F, M) int: the fourth word of every point sample in the data block, as the C3D guide defines it.

    Its low byte is the residual in units of ``|POINT:SCALE|``, bits 8-14 the
    cameras that saw the sample (bit 8: camera 1), and a negative word marks
    the sample invalid; a float file stores the word as a float holding that
    integer. ezc3d 1.7 reads the two bytes the other way round (its residual
    is the camera byte: ezc3d issue #386) and writes them so, which is why
    :func:`~mocapkit.io.c3d.read_c3d` and :func:`~mocapkit.io.c3d.write_c3d`
    read and write this word themselves, as the ``c3d`` package and the
    capture software do. ``scale``: POINT:SCALE, whose sign says floats
    (negative) or 16-bit integers; ``analog``: analog samples a frame
    (default: the header's count). None when the data block does not hold
    ``frames`` whole frames.
    """
    if analog is None:
        proc = raw[(raw[0] - 1) * 512 + 3]
        analog, = struct.unpack_from(">H" if proc == 86 else "<H", raw, 4)
    got = _block(raw, 0, frames, points, analog, scale)
    if got is None:
        return None
    block, proc, e, size = got
    word = block[:, : 4 * points * size].reshape(frames, points, 4, size)[:, :, 3, :]
    values = stored_values(word, proc, e, size)
    if size == 2:
        return values.astype(np.int64)
    values = np.where(np.isfinite(values), values, -1.0)
    return np.clip(np.trunc(values), -(2**31), 2**31 - 1).astype(np.int64)


def missing_stored(raw: bytes, frames: int, points: int, scale: float, analog: int | None = None) -> np.ndarray | None:
    """(K, 6) float64: the samples the file marks missing (a negative fourth word) whose coordinates it stored as
    anything but (0, 0, 0), one row each: frame (0-based), point, x, y, z (the stored numbers read as a reader
    reads them: an integer file's ``int16 * scale``, a float file's floats) and the word; None where there are
    none or the data block does not hold ``frames`` whole frames (arguments as :func:`point_words`).

    Readers hand such a sample back as missing (ezc3d as NaN), but the file holds numbers there (BTK's
    ADemo1_rewrite_c3d_pc_integer.c3d: 85 samples), which :func:`put_missing_stored` writes back, so that a file
    written unchanged holds what it held (:attr:`~mocapkit.markerset.MarkerSource.missing_stored`). Rows, not an
    (F, M) array: most takes have few such samples and a long one is large.
    """
    if analog is None:
        proc = raw[(raw[0] - 1) * 512 + 3]
        analog, = struct.unpack_from(">H" if proc == 86 else "<H", raw, 4)
    words = point_words(raw, frames, points, scale, analog)
    if words is None or not np.any(words < 0):
        return None
    block, proc, e, size = _block(raw, 0, frames, points, analog, scale)
    f, m = np.nonzero(words < 0)
    cells = block[:, : 4 * points * size].reshape(frames, points, 4, size)[f, m, :3]  # (K, 3, size)
    xyz = stored_values(cells, proc, e, size)
    if size == 2:
        xyz = xyz * float(scale)
    keep = np.isfinite(xyz).all(axis=1) & (xyz != 0).any(axis=1)
    if not keep.any():
        return None
    return np.column_stack([f[keep], m[keep], xyz[keep], words[f[keep], m[keep]]]).astype(np.float64)


def put_missing_stored(block: np.ndarray, markers) -> int:
    """Write back the coordinates and fourth word the file stored under each sample it marks missing
    (:attr:`~mocapkit.markerset.MarkerSource.missing_stored`, :func:`missing_stored`) that is still missing in
    ``markers``; returns how many. ``block``: the data block, a writable (F, 4 * M + analog samples) float32
    view (:func:`~mocapkit.io.c3d_layout.integer_data` turns an integer file's back into its 16-bit numbers).

    Only while the markers are the file's own (:meth:`~mocapkit.markerset.MarkerSet.file_labels`) in the length
    unit the file states (a take in another unit holds no such numbers); a sample filled or otherwise given a
    value is written as the take has it.
    """
    rows = None if markers.source is None else markers.source.missing_stored
    if rows is None or len(rows) == 0 or markers.file_labels() != markers.source.labels:
        return 0
    stated = parameter_values(markers.source.parameters, "POINT", "UNITS")
    if np.size(stated) and str(np.ravel(stated)[0]).strip() != str(markers.units).strip():
        return 0
    f, m = rows[:, 0].astype(np.int64), rows[:, 1].astype(np.int64)
    inside = (f < markers.num_frames) & (m < markers.num_markers)
    f, m, rows = f[inside], m[inside], rows[inside]
    still = markers.missing()[f, m]
    f, m, rows = f[still], m[still], rows[still]
    for k in range(4):  # x, y, z, the word: indexed in the block itself (a reshape of a strided view may copy)
        block[f, 4 * m + k] = rows[:, 2 + k].astype(np.float32)
    return int(still.sum())


def residuals_and_cameras(words: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """(F, M) residuals (-1 where invalid) and (F, M) camera masks (0 there) from :func:`point_words`."""
    invalid = words < 0
    resid = np.where(invalid, -1.0, (words & 0xFF) * abs(float(scale)))
    cameras = np.where(invalid, 0, (words & 0x7F00) >> 8)
    return resid, cameras


def zero_gap_words(resid: np.ndarray, cameras: np.ndarray | None, gaps: np.ndarray) -> np.ndarray | None:
    """(F, M, 2) float: the residual and camera mask (0 where the file gave none) stored with each sample of
    ``gaps`` ((F, M) bool: read as gaps from exact (0, 0, 0)), NaN elsewhere; None where ``gaps`` holds none.
    ``resid``: (F, M) residuals as read, before the gaps were set to -1
    (:attr:`~mocapkit.markerset.MarkerSource.stored_zeros`)."""
    if not np.any(gaps):
        return None
    out = np.stack([resid, np.zeros_like(resid) if cameras is None else cameras], axis=-1).astype(np.float64)
    out[~gaps] = np.nan
    return out


def put_stored_zeros(block: np.ndarray, markers, scale: float) -> int:
    """Write back, as the file had them, the samples the reader read as gaps from exact (0, 0, 0)
    (:attr:`~mocapkit.markerset.MarkerSource.stored_zeros`) that are still missing in ``markers``; returns how many.

    Such a sample gets coordinates 0 and its fourth word (residual byte in units of ``|scale|``, camera mask in
    bits 8-14, as :func:`point_words` reads it), so that a cleaning gives back the samples it did not change bit
    for bit. ``block``: the data block, a writable (F, 4 * M + analog samples) float32 view; ``scale``:
    POINT:SCALE. Only while the markers are the file's own (:meth:`~mocapkit.markerset.MarkerSet.file_labels`).
    """
    stored = None if markers.source is None else markers.source.stored_zeros
    if (stored is None or stored.shape[:2] != markers.positions.shape[:2]
            or markers.file_labels() != markers.source.labels):
        return 0
    cells = markers.missing() & ~np.isnan(stored[..., 0])
    points = block[:, : 4 * markers.num_markers]
    res, cams = np.nan_to_num(stored[..., 0]), np.nan_to_num(stored[..., 1]).astype(np.int64) & 0x7F
    byte = np.clip(np.rint(res / (abs(scale) or 1.0)), 0, 255).astype(np.int64)
    for k in range(3):
        points[:, k::4][cells] = 0.0
    points[:, 3::4][cells] = ((cams << 8) | byte)[cells].astype(np.float32)
    return int(cells.sum())


def _field(words) -> int | None:
    """A TRIAL frame field: a 32-bit number in two 16-bit words, low word first (ezc3d reads them signed); None
    where ``words`` (:func:`~mocapkit.io.c3d_layout.parameter_values`) are fewer than two."""
    if len(words) < 2:
        return None
    return (int(words[0]) & 0xFFFF) | ((int(words[1]) & 0xFFFF) << 16)


def trial_first(parameters: dict, header_first: int) -> int:
    """The trial's first frame number (1-based) read from a header stating ``header_first``, in a file whose
    TRIAL:ACTUAL_START_FIELD may state it past 65,535 (a part of a long trial, as :func:`long_frame_parameters`
    writes it): that 32-bit number where it is past 65,535 and the header's 16-bit word is its low word (or
    the cap, 65,535), else ``header_first``.

    ezc3d reads the header's word alone (frame 66,001 read as 465), and the ``c3d`` package takes the field's
    high word as 65,535 frames (66,001 read as 66,000): a part of a long trial written and read back was
    numbered wrongly, and its events and ``like=`` crops placed by those numbers.
    """
    start = _field(parameter_values(parameters, "TRIAL", "ACTUAL_START_FIELD"))
    if start is not None and start > FRAME_CAP and header_first & 0xFFFF in (start & 0xFFFF, FRAME_CAP):
        return start
    return header_first


def long_trial_frames(path, raw: bytes, parameters: dict, read: int, points: int, analog: int, scale: float) -> int:
    """How many frames a C3D file holds whose reader read ``read`` of them (ezc3d stops at 65,535).

    Only a header at the cap (last frame 65,535) can hide more frames. Then
    the count is the one the parameters state: ``TRIAL:ACTUAL_END_FIELD -
    TRIAL:ACTUAL_START_FIELD + 1`` (Vicon), else ``POINT:LONG_FRAMES``; where
    neither does (ezc3d writes a long trial so), the data block's whole frames,
    where one count alone leaves at most a 512-byte block of padding after them
    (frames wider than 512 bytes); where several do (narrower frames: the
    padding could be frames), the count is not known and the file is refused.
    ``parameters``: ezc3d's parsed section;
    ``points``, ``analog``: points and analog samples a frame; ``scale``:
    POINT:SCALE (its sign says floats or 16-bit integers). Raises
    :class:`~mocapkit.errors.MocapFormatError` when the data block holds fewer
    frames than stated, or a number of bytes no count of whole frames, or
    more than one, explains: reading only the first 65,535 would lose the rest
    unsaid, and guessing would add padding bytes as frames or drop frames.
    """
    proc = raw[(raw[0] - 1) * 512 + 3]
    e = ">" if proc == 86 else "<"
    first, last, data_start = struct.unpack_from(e + "H", raw, 6)[0], struct.unpack_from(e + "H", raw, 8)[0], \
        struct.unpack_from(e + "H", raw, 16)[0]
    if last != FRAME_CAP or read != last - max(first, 1) + 1:
        return read
    frame_bytes = (4 * points + analog) * sample_bytes(scale)
    body = len(raw) - (data_start - 1) * 512
    held = body // frame_bytes if frame_bytes > 0 else 0
    end, begin = _field(parameter_values(parameters, "TRIAL", "ACTUAL_END_FIELD")), \
        _field(parameter_values(parameters, "TRIAL", "ACTUAL_START_FIELD"))
    long_frames = parameter_values(parameters, "POINT", "LONG_FRAMES")
    stated, who = None, ""
    if end is not None and end >= FRAME_CAP:
        stated = end - (begin if begin else max(first, 1)) + 1
        who = "TRIAL:ACTUAL_START_FIELD and ACTUAL_END_FIELD state"
    elif len(long_frames) and np.isfinite(long_frames[0]) and long_frames[0] >= FRAME_CAP:
        stated, who = int(long_frames[0]), "POINT:LONG_FRAMES states"
    if stated is not None:
        if stated < read:
            raise MocapFormatError(path, f"{who} {plural(stated, 'frame')}, fewer than the {read} the header states")
        if held < stated:
            raise MocapFormatError(path, f"truncated file: {who} {plural(stated, 'frame')}, the data block holds {held} "
                                         f"whole frames of {points} points and {analog} analog samples")
        return stated
    # the frames end where the data block's padding starts, and a writer pads at most one 512-byte block (ezc3d
    # writes a whole one where the frames end on a block's end): every count of frames ending in the last 512
    # bytes fits the file, and only one such count tells the trial's length
    fits = np.arange(max(read, -(-(body - 512) // frame_bytes)), held + 1) if frame_bytes > 0 else np.array([read])
    if len(fits) == 1:
        return int(fits[0])
    said = (f"the header stops at frame {FRAME_CAP} and no TRIAL:ACTUAL_END_FIELD or POINT:LONG_FRAMES states the "
            f"trial's length: the data block's {body} bytes")
    if not len(fits):
        raise MocapFormatError(path, f"{said} are {held} frames and {body - held * frame_bytes} bytes more: "
                                     "its length cannot be told")
    raise MocapFormatError(path, f"{said} hold {fits[0]} to {fits[-1]} frames of {frame_bytes} bytes and up to a "
                                 "512-byte block of padding: its length cannot be told")


def read_frames(raw: bytes, begin: int, end: int, points: int, analog: int, scale: float, parameters: dict):
    """Frames ``begin`` to ``end`` (0-based, end excluded) of a C3D data block, read with numpy.

    Returns ``(xyz, analogs)``: ``xyz`` (F, M, 3) float64 point coordinates
    in the file's units as stored (16-bit integers times ``scale`` when it is
    positive, else floats), ``analogs`` (A, F * ratio) float64 at the analog
    rate, ``(stored - ANALOG:OFFSET) * ANALOG:SCALE * ANALOG:GEN_SCALE`` (``ANALOG:FORMAT`` UNSIGNED: stored
    unsigned 16-bit; the offsets as :func:`~mocapkit.io.c3d_layout.analog_offsets` reads them), or None when
    the file holds none. ``analog``: analog samples a
    frame (channels x ratio); ``parameters``: ezc3d's parsed section. None when
    the file does not hold those frames whole.
    """
    got = _block(raw, begin, end, points, analog, scale)
    if got is None:
        return None
    block, proc, e, size = got
    frames = end - begin
    stored = stored_values(block[:, : 4 * points * size].reshape(frames, points, 4, size)[:, :, :3, :], proc, e, size)
    xyz = stored * scale if size == 2 else stored
    used = parameter_values(parameters, "ANALOG", "USED") if analog else []
    channels = int(used[0]) if len(used) else 0
    if not channels or analog % channels:
        return xyz, None
    ratio = analog // channels
    samples = stored_values(block[:, 4 * points * size:].reshape(frames, ratio, channels, size), proc, e, size,
                      unsigned=analog_unsigned(parameters))  # (F, ratio, A)
    offsets = analog_offsets(parameters, channels)
    scales = channel_values(parameters, "ANALOG", "SCALE")
    scales = np.ones(channels) if not len(scales) else np.resize(scales.astype(np.float64), channels)
    gen = parameter_values(parameters, "ANALOG", "GEN_SCALE")
    gen = float(gen[0]) if len(gen) else 1.0
    values = (samples - offsets) * scales * gen
    return xyz, values.transpose(2, 0, 1).reshape(channels, frames * ratio)


def rest_of_trial(path, raw: bytes, parameters: dict, xyz: np.ndarray, analogs: np.ndarray | None, analog: int,
                  scale: float):
    """The frames of a long trial past those a reader read (:func:`long_trial_frames`), or None when there are none.

    ``xyz`` (F, M, 3) and ``analogs`` (A, F * ratio) or None: the frames read
    (ezc3d's values); ``analog``: analog samples a frame; ``parameters``:
    ezc3d's parsed section; ``scale``: POINT:SCALE. Returns ``(xyz, analogs)``
    for the frames after them, as :func:`read_frames` reads them. The last
    frames read are read again here first and must agree with the reader's
    values (to float32 precision, NaN where the reader has it): where they do
    not, this layout is not one read safely, and
    :class:`~mocapkit.errors.MocapFormatError` says so rather than join frames
    read two ways.
    """
    read, points = xyz.shape[0], xyz.shape[1]
    total = long_trial_frames(path, raw, parameters, read, points, analog, scale)
    if total <= read:
        return None
    check = min(read, 64)
    again = read_frames(raw, read - check, read, points, analog, scale, parameters)
    rest = read_frames(raw, read, total, points, analog, scale, parameters)
    ok = again is not None and rest is not None
    if ok:
        seen = ~np.isnan(xyz[read - check:])
        ok = np.allclose(again[0][seen], xyz[read - check:][seen], rtol=1e-6, atol=0)
        ratio = analog // max(analogs.shape[0], 1) if analogs is not None else 0
        if analogs is not None and analogs.size:
            ok = ok and again[1] is not None and np.allclose(again[1], analogs[:, (read - check) * ratio:],
                                                             rtol=1e-6, atol=1e-9)
    if not ok:
        raise MocapFormatError(path, f"the trial holds {total} frames, more than the {read} the C3D header can state, "
                                     "and the data block past them is not laid out as the frames before: it cannot "
                                     "be read safely")
    return rest


def long_frame_parameters(first: int, frames: int) -> dict[tuple[str, str], dict]:
    """(GROUP, NAME) -> parameter (ezc3d's layout) that state ``frames`` frames from frame ``first`` (1-based).

    Both conventions (:func:`long_trial_frames`): TRIAL:ACTUAL_START_FIELD and
    ACTUAL_END_FIELD, two 16-bit words each (low word first, written signed
    as ezc3d writes integers), and POINT:LONG_FRAMES, the count as a float.
    """
    def words(n: int) -> np.ndarray:
        return np.array([n & 0xFFFF, n >> 16]).astype(np.uint16).astype(np.int16).astype(np.int64)

    last = first + frames - 1
    return {
        ("TRIAL", "ACTUAL_START_FIELD"): {"type": 2, "description": "First frame of the trial (two 16-bit words)",
                                          "is_locked": False, "value": words(first)},
        ("TRIAL", "ACTUAL_END_FIELD"): {"type": 2, "description": "Last frame of the trial (two 16-bit words)",
                                        "is_locked": False, "value": words(last)},
        ("POINT", "LONG_FRAMES"): {"type": 4, "description": "Number of frames", "is_locked": False,
                                   "value": np.array([float(frames)])},
    }
