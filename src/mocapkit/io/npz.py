"""mocapkit's native format: a numpy ``.npz`` that round-trips a Motion (or MarkerSet) losslessly.

Every array is stored as is (float64, NaN included); the skeleton's text
fields (channels, limits) are stored as JSON strings. Files are read with
``allow_pickle=False``: an npz is untrusted input and can execute no code.
"""

from __future__ import annotations

import json
import struct
import tokenize
import zipfile
import zlib
from pathlib import Path

import numpy as np

from ..errors import MocapError, MocapFormatError, SkeletonError
from .outputs import check_file_path
from ..motion import Motion, Skeleton, check_fps
from . import atomic_write
from .c3d_trial import same_rate, trial_rate

__all__ = ["read_npz", "write_npz", "load_arrays", "unread_arrays", "FORMAT_VERSION", "MAX_NPZ_BYTES",
           "MAX_NPZ_MEMBERS"]

FORMAT_VERSION = 1

MOTION_ARRAYS = frozenset({"kind", "format_version", "rotations", "root_positions", "fps", "name", "joint_names",
                           "parents", "offsets", "end_site_parents", "end_site_offsets", "channels", "limits",
                           "unit_cm", "axes", "translations"})
"""The arrays of a motion npz that :func:`read_npz` reads (beside them, :mod:`mocapkit.io.kept_channels`' keys)."""
MARKER_ARRAYS = frozenset({"kind", "format_version", "labels", "positions", "fps", "units", "name", "first_frame",
                           "first_frame_rate", "file_labels", "filled", "modelled"})
"""The arrays of a marker npz that :func:`read_npz` reads."""


def filled_samples(markers, filled=None) -> np.ndarray:
    """(F, M) bool: the samples of ``markers`` that are no recorded ones, which a marker npz lists in ``filled``.

    ``filled`` ((F, M) bool, or None): a cleaning's fills
    (:attr:`~mocapkit.cleaning.markers.MarkerCleanResult.fill_mask`); with
    them, the samples the take itself marks so: a marker npz's own ``filled``
    mask (:attr:`~mocapkit.markerset.MarkerSource.filled`), and the samples a
    C3D marks as interpolated (:meth:`~mocapkit.markerset.MarkerSet.interpolated`:
    a capture program's fills).
    """
    shape = markers.positions.shape[:2]
    out = np.zeros(shape, dtype=bool) if filled is None else np.asarray(filled, dtype=bool).copy()
    source = markers.source
    if source is not None and source.filled is not None and source.filled.shape == shape:
        out |= source.filled
    return (out | markers.interpolated()) & ~markers.missing()


def write_npz(obj, path, compress: bool = True, extra: dict | None = None, filled=None) -> None:
    """Write a Motion or MarkerSet to ``path`` atomically (temp file + rename).

    Names (joints, markers, the clip, the unit) are stored as numpy strings,
    which hold any code point, lone surrogates included, but drop trailing
    NUL characters: a name ending in one is refused (``MocapFormatError``
    naming it) before anything is written. ``extra``: more arrays written
    beside the format's own (which they may not replace; :func:`read_npz`
    ignores them), e.g. what :func:`mocapkit.reconstruct.output.described_arrays`
    adds so that a reconstruction says what it holds.

    A MarkerSet gets, beside its ``positions`` (F, M, 3), a bool ``filled``
    (F, M): the samples that are no recorded ones (:func:`filled_samples` of
    ``filled``, a cleaning's fills), which a C3D marks by residual 0 and a
    TRC cannot mark; :func:`read_npz` reads it back
    (:attr:`~mocapkit.markerset.MarkerSource.filled`). Where some points are
    modelled (a C3D's angles, forces, ..., its centre of mass and other
    positions no camera measured), a str ``modelled`` (M,): each point's kind,
    "" for a marker (:meth:`~mocapkit.markerset.MarkerSet.modelled_kinds`),
    read back as :attr:`~mocapkit.markerset.MarkerSource.modelled`, so that
    they are not cleaned as markers; the C3D's parameter groups themselves are
    not kept.
    """
    from .c3d import MarkerSet

    path = Path(check_file_path(path))  # "out/x/" names a folder: refused, not written as out/x
    if isinstance(obj, Motion):
        _check_texts(path, "joint", obj.skeleton.joint_names)
        _check_texts(path, "clip name", [obj.name])
    elif isinstance(obj, MarkerSet):
        _check_texts(path, "marker", obj.labels)
        _check_texts(path, "clip name", [obj.name])
        _check_texts(path, "unit", [obj.units])
    if isinstance(obj, Motion):
        sk = obj.skeleton
        arrays = {
            "kind": np.array("motion"),
            "format_version": np.array(FORMAT_VERSION),
            "rotations": obj.rotations,
            "root_positions": obj.root_positions,
            "fps": np.array(obj.fps),
            "name": np.array(obj.name),
            "joint_names": np.array(sk.joint_names),
            "parents": sk.parents,
            "offsets": sk.offsets,
            "end_site_parents": sk.end_site_parents,
            "end_site_offsets": sk.end_site_offsets,
            "channels": np.array(json.dumps(sk.channels)),
            "limits": np.array(json.dumps(sk.limits)),
            "unit_cm": np.array(np.nan if sk.unit_cm is None else sk.unit_cm),
        }
        if sk.axes is not None:
            arrays["axes"] = sk.axes
        if obj.translations is not None:
            arrays["translations"] = obj.translations
    elif isinstance(obj, MarkerSet):
        arrays = {
            "kind": np.array("markers"),
            "format_version": np.array(FORMAT_VERSION),
            "labels": np.array(obj.labels),
            "positions": obj.positions,
            "fps": np.array(obj.fps),
            "units": np.array(obj.units),
            "name": np.array(obj.name),
            # the file's first frame number, and its labels where they repeat one (labels holds unique names)
            "first_frame": np.array(obj.source.first_frame if obj.source is not None else 1),
            "filled": filled_samples(obj, filled),
        }
        clock = trial_rate(obj.source.layout if obj.source is not None else None, obj.fps)
        if not same_rate(clock, obj.fps):  # a resampled take's first frame is numbered on its file's clock
            arrays["first_frame_rate"] = np.array(float(clock))
        if obj.file_labels() != obj.labels:
            _check_texts(path, "marker", obj.file_labels())
            arrays["file_labels"] = np.array(obj.file_labels())
        kinds = obj.modelled_kinds()
        if np.any(kinds != ""):  # the modelled points, which the npz cannot otherwise tell from markers
            arrays["modelled"] = np.array(kinds, dtype=str)
    else:
        raise TypeError(f"write_npz takes a Motion or MarkerSet, got {type(obj).__name__}")
    clash = sorted(set(extra or {}) & set(arrays))
    if clash:
        raise ValueError(f"extra arrays may not replace the format's own: {', '.join(clash)}")
    arrays.update(extra or {})
    with atomic_write(path, "wb") as fh:
        (np.savez_compressed if compress else np.savez)(fh, **arrays)


def _check_texts(path: Path, what: str, texts) -> None:
    """Refuse a name an npz string array would change: numpy drops trailing NUL characters."""
    for k, text in enumerate(texts):
        if text.endswith("\x00"):
            raise MocapFormatError(path, f"{what} {k} name {ascii(text)} ends in a NUL character, which npz drops; rename it")


MAX_NPZ_BYTES = 512 * 2**20
"""Default limit of :func:`load_arrays`: bytes the arrays of one npz may hold once loaded.

Counted on the declared shapes, each element as at least 8 bytes (readers
convert numbers to float64), before anything is inflated. 512 MiB is a
75-minute, 31-joint take at 120 fps; checking it and building a Motion then
stays well under 2 GB.
"""

MAX_NPZ_MEMBERS = 4096
"""Most members an npz may list; the zip directory is counted before it is parsed."""

_EOCD = b"PK\x05\x06"


def _member_count(path: Path) -> int | None:
    """Entries the zip's end-of-central-directory record declares (65535 for zip64), or None if none is found."""
    with open(path, "rb") as fh:
        fh.seek(0, 2)
        size = fh.tell()
        fh.seek(max(0, size - 22 - 65535))
        tail = fh.read()
    at = tail.rfind(_EOCD)
    if at < 0 or at + 22 > len(tail):
        return None
    return struct.unpack_from("<H", tail, at + 10)[0]


def load_arrays(path, max_bytes: int = MAX_NPZ_BYTES, max_members: int = MAX_NPZ_MEMBERS,
                keys=None) -> dict[str, np.ndarray]:
    """Every ``.npy`` array of an npz (a zip), or those named in ``keys``, checked before any of it is inflated.

    The safe ``np.load`` for a user's npz: the zip directory's entry count is
    read first (at most ``max_members``); then each member's ``.npy`` header
    is read from its stream (a few hundred bytes inflated) and its declared
    shape and dtype are checked: no object dtypes (they need pickle), no more
    data than the member holds, and all arrays together at most ``max_bytes``
    (each element counted as at least 8 bytes). Only then is each array read,
    once, into its final buffer. Members not ending in ``.npy`` are skipped.

    Parameters
    ----------
    path : str or path-like
    max_bytes : int
        Limit on the loaded arrays, in bytes (default :data:`MAX_NPZ_BYTES`).
    max_members : int
        Limit on the zip's entries (default :data:`MAX_NPZ_MEMBERS`).
    keys : iterable of str, optional
        Read only these members (names without ``.npy``; those the npz lacks are absent from the result).
        Every member's header is checked all the same, so the npz is refused exactly where it is refused
        whole; only the other members' data is not inflated (the kept source numbers of an .npz, read at
        every repair and denoise of a take, without inflating its rotations again).

    Returns
    -------
    dict of str to numpy.ndarray
        Keyed by member name without ``.npy``.

    Raises
    ------
    MocapFormatError
        One line naming the file: not a zip, too many members, an array over
        the limit (its shape, dtype and bytes), object arrays, a garbled or
        truncated member.
    """
    path = Path(path)
    try:
        count = _member_count(path)
        if count is not None and count > max_members:
            raise MocapFormatError(path, f"the zip lists {count} members, more than the {max_members} an npz may have")
        with zipfile.ZipFile(path) as zf:
            infos = [i for i in zf.infolist() if i.filename.endswith(".npy")]
            if len(zf.infolist()) > max_members:
                raise MocapFormatError(
                    path, f"the zip lists {len(zf.infolist())} members, more than the {max_members} an npz may have"
                )
            headers = []
            total = 0
            for info in infos:
                key = info.filename[:-4]
                with zf.open(info) as fh:
                    version = np.lib.format.read_magic(fh)
                    if version == (1, 0):
                        shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
                    elif version == (2, 0):
                        shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
                    else:
                        raise MocapFormatError(path, f"array {key!r}: unsupported .npy version {version}")
                    if dtype.hasobject:
                        raise MocapFormatError(path, f"array {key!r} holds Python objects (refused: they would need pickle)")
                    count = 1
                    for d in shape:
                        count *= int(d)
                    need = count * dtype.itemsize
                    held = info.file_size - fh.tell()
                    if need > held:
                        raise MocapFormatError(
                            path, f"array {key!r} claims shape {shape} ({need} bytes) but holds {held} bytes"
                        )
                    total += count * max(dtype.itemsize, 8)
                    if total > max_bytes:
                        raise MocapFormatError(
                            path, f"array {key!r} of shape {shape} and dtype {dtype} brings the arrays to "
                            f"{total:,} bytes, over the {max_bytes:,}-byte limit (refused before inflating)"
                        )
                headers.append((key, info))
            out: dict[str, np.ndarray] = {}
            wanted = None if keys is None else set(keys)
            for key, info in headers:
                if wanted is not None and key not in wanted:
                    continue
                with zf.open(info) as fh:
                    out[key] = np.lib.format.read_array(fh, allow_pickle=False)
            return out
    except MocapFormatError:
        raise
    except (zipfile.BadZipFile, zlib.error, OSError, ValueError, EOFError, struct.error, NotImplementedError,
            SyntaxError, tokenize.TokenError, OverflowError, RuntimeError) as exc:
        # SyntaxError, TokenError: a garbled .npy header; RuntimeError: zipfile on an encrypted member
        raise MocapFormatError(path, f"not a readable .npz file ({exc})".replace("\n", " ")) from None


def _scalar(path: Path, data: dict, key: str, kind: str):
    """The 0-d array ``data[key]`` as a Python str / int / float (``kind`` 's', 'i' or 'f'), checked."""
    a = data[key]
    if a.ndim != 0:
        raise MocapFormatError(path, f"npz array {key!r} must be a scalar, got shape {a.shape}")
    ok = {"s": "U", "i": "iu", "f": "fiu"}[kind]
    if a.dtype.kind not in ok:
        raise MocapFormatError(path, f"npz array {key!r} has dtype {a.dtype}, expected {'a string' if kind == 's' else 'a number'}")
    return {"s": str, "i": int, "f": float}[kind](a[()])


def _real(path: Path, data: dict, key: str, integer: bool = False, finite: bool = False, optional: bool = False):
    """``data[key]`` checked to be a real (integer) array without infinities (and NaN when ``finite``)."""
    if optional and key not in data:
        return None
    a = data[key]
    kinds = "iu" if integer else "fiu"
    if a.dtype.kind not in kinds:
        raise MocapFormatError(path, f"npz array {key!r} has dtype {a.dtype}, expected {'integers' if integer else 'real numbers'}")
    if a.dtype.kind == "f":
        bad = ~np.isfinite(a) if finite else np.isinf(a)
        if np.any(bad):
            raise MocapFormatError(path, f"npz array {key!r} holds {'non-finite' if finite else 'infinite'} values")
    return a


def _json(path: Path, data: dict, key: str):
    text = _scalar(path, data, key, "s")
    try:
        return json.loads(text)
    except (ValueError, RecursionError):
        raise MocapFormatError(path, f"npz array {key!r} is not valid JSON") from None


def _check_rotations(path: Path, q: np.ndarray) -> None:
    """Each quaternion all NaN (missing) or of unit norm."""
    if q.ndim != 3 or q.shape[-1] != 4:
        return  # Motion reports the shape
    nan = np.isnan(q)
    if np.any(nan.any(-1) != nan.all(-1)):
        raise MocapFormatError(path, "npz rotations: a quaternion is partly NaN")
    if np.any(np.abs(np.where(nan, 0.0, q)) > 2.0):
        raise MocapFormatError(path, "npz rotations are not unit quaternions (a component exceeds 1)")
    norm = np.linalg.norm(np.where(nan, 0.0, q), axis=-1)
    off = np.abs(norm - 1.0)[~nan.any(-1)]
    if off.size and off.max() > 1e-6:
        raise MocapFormatError(path, f"npz rotations are not unit quaternions (norm off by {off.max():.3g})")


def read_npz(path):
    """Read a file written by :func:`write_npz` (a Motion, or a MarkerSet for marker files).

    Raises :class:`~mocapkit.errors.MocapFormatError` for anything else: not a
    zip of ``.npy`` arrays, arrays over :data:`MAX_NPZ_BYTES` or a header that
    claims more data than the member holds (both refused before inflating,
    :func:`load_arrays`), object arrays, a missing array, an array
    of the wrong shape or dtype, infinite values, non-unit quaternions, a
    non-positive frame rate.

    A Motion's ``source_file`` is ``path``: the numbers an .npz made from a BVH or AMC keeps of that file
    (:mod:`mocapkit.io.kept_channels`) are found there by :func:`mocapkit.io.save`, as by a command given the .npz
    as ``like``, so the cells a later step leaves are written with the file's own numbers.
    """
    from ..markerset import MODELLED_GROUPS, MarkerSet, MarkerSource

    path = Path(path)
    data = load_arrays(path)
    try:
        if "format_version" not in data:
            raise MocapFormatError(path, "not a mocapkit npz (no format_version array)")
        version = _scalar(path, data, "format_version", "i")
        if version != FORMAT_VERSION:
            raise MocapFormatError(path, f"not a mocapkit npz (format_version {version}, expected {FORMAT_VERSION})")
        kind = _scalar(path, data, "kind", "s")
        if kind not in ("motion", "markers"):  # a multilinear model (reconstruct --multilinear) is read there
            raise MocapFormatError(path, f"an npz of kind {kind!r}, not a motion or markers")
        try:
            fps = check_fps(_scalar(path, data, "fps", "f"))
        except SkeletonError as exc:
            raise MocapFormatError(path, str(exc)) from None
        name = _scalar(path, data, "name", "s")
        if kind == "markers":
            labels = data["labels"]
            if labels.ndim != 1 or labels.dtype.kind != "U":
                raise MocapFormatError(path, f"npz labels must be a 1-D string array, got {labels.dtype} {labels.shape}")
            positions = _real(path, data, "positions")
            if positions.ndim != 3 or positions.shape[0] == 0:
                raise MocapFormatError(path, f"npz positions must be (F, M, 3) with F >= 1, got {positions.shape}")
            first = _scalar(path, data, "first_frame", "i") if "first_frame" in data else 1  # older npz: none
            if abs(first) >= 2**31:
                raise MocapFormatError(path, f"npz first_frame {first} is out of range")
            clock = {}  # the clock of first_frame where it is not fps (a resampled take: its file's rate)
            if "first_frame_rate" in data:
                try:
                    clock = {"trial_rate": check_fps(_scalar(path, data, "first_frame_rate", "f"))}
                except SkeletonError as exc:
                    raise MocapFormatError(path, f"npz first_frame_rate: {exc}") from None
            file_labels = data.get("file_labels")
            if file_labels is not None and (file_labels.ndim != 1 or file_labels.dtype.kind != "U"
                                            or len(file_labels) != len(labels)):
                raise MocapFormatError(path, f"npz file_labels must be a 1-D string array of {len(labels)}, got "
                                       f"{file_labels.dtype} {file_labels.shape}")
            filled = data.get("filled")  # older npz: none
            if filled is not None and (filled.dtype != bool or filled.shape != positions.shape[:2]):
                raise MocapFormatError(path, f"npz filled must be a bool array {positions.shape[:2]}, got "
                                       f"{filled.dtype} {filled.shape}")
            kinds = data.get("modelled")  # older npz, or no modelled point: none
            known = ("",) + tuple(g.lower() for g in MODELLED_GROUPS) + ("positions",)
            if kinds is not None and (kinds.dtype.kind != "U" or kinds.shape != labels.shape
                                      or not set(kinds.tolist()) <= set(known)):
                raise MocapFormatError(path, f"npz modelled must be a string array of {len(labels)} kinds "
                                       f"({', '.join(known[1:])} or empty), got {kinds.dtype} {kinds.shape}")
            return MarkerSet(
                labels=tuple(str(s) for s in labels),
                positions=positions,
                fps=fps,
                units=_scalar(path, data, "units", "s"),
                name=name,
                reader="npz",
                source=MarkerSource(format="npz", first_frame=first, layout=clock,
                                    labels=() if file_labels is None else tuple(str(s) for s in file_labels),
                                    filled=filled,
                                    modelled={} if kinds is None else {str(label): str(k) for label, k in
                                                                       zip(labels, kinds) if k}),
            )
        channels = _json(path, data, "channels")
        limits = _json(path, data, "limits")
        unit_cm = _scalar(path, data, "unit_cm", "f")
        if not (np.isnan(unit_cm) or (np.isfinite(unit_cm) and unit_cm > 0)):
            raise MocapFormatError(path, f"unit_cm must be a positive number, got {unit_cm!r}")
        joint_names = data["joint_names"]
        if joint_names.ndim != 1 or joint_names.dtype.kind != "U":
            raise MocapFormatError(path, f"npz joint_names must be a 1-D string array, got {joint_names.dtype} {joint_names.shape}")
        rotations = _real(path, data, "rotations")
        _check_rotations(path, rotations)
        if rotations.ndim != 3 or rotations.shape[0] == 0:
            raise MocapFormatError(path, f"npz rotations must be (F, J, 4) with F >= 1, got {rotations.shape}")
        axes = _real(path, data, "axes", finite=True, optional=True)
        if axes is not None and axes.ndim == 2 and axes.shape[-1] == 4:
            if np.any(np.abs(np.linalg.norm(axes, axis=-1) - 1.0) > 1e-6):
                raise MocapFormatError(path, "npz axes are not unit quaternions")
        skeleton = Skeleton(
            joint_names=tuple(str(s) for s in joint_names),
            parents=_real(path, data, "parents", integer=True),
            offsets=_real(path, data, "offsets", finite=True),
            end_site_parents=_real(path, data, "end_site_parents", integer=True),
            end_site_offsets=_real(path, data, "end_site_offsets", finite=True),
            channels=None if channels is None else tuple(tuple(c) for c in channels),
            axes=axes,
            limits=None if limits is None else tuple(tuple(tuple(p) for p in jl) for jl in limits),
            unit_cm=None if np.isnan(unit_cm) else unit_cm,
        )
        return Motion(
            skeleton=skeleton,
            rotations=rotations,
            root_positions=_real(path, data, "root_positions"),
            fps=fps,
            name=name,
            translations=_real(path, data, "translations", optional=True),
            source_file=str(path),  # the file io.save writes like: the source BVH's or AMC's numbers it keeps
        )
    except KeyError as exc:
        raise MocapFormatError(path, f"npz lacks the array {exc.args[0]!r}") from None
    except (ValueError, TypeError, MocapError) as exc:
        if isinstance(exc, MocapFormatError):
            raise
        raise MocapFormatError(path, f"inconsistent npz contents: {exc}".replace("\n", " ")) from None


def unread_arrays(path) -> list[str]:
    """The arrays of the npz at ``path`` that no mocapkit reader reads, in the file's order: arrays a user added
    (``np.savez(out, **dict(np.load(take)), my_labels=...)``), or a reconstruction's ``positions``, ``licence``
    ... (:func:`mocapkit.reconstruct.output.described_arrays`). A file written from the take holds only the
    format's own arrays, so a command's note names these as left out (:func:`mocapkit.io.motion_notes`,
    :func:`mocapkit.io.marker_notes`). Only the zip's directory and its ``kind`` are read; [] where the file
    cannot be read (gone since, not an npz)."""
    from .kept_channels import COMMENTS_KEY, HEADER_KEY, LAYOUT_KEY, TEXT_KEYS, VALUES_KEY

    try:
        with np.load(Path(path), allow_pickle=False) as z:
            names = [name for name in z.files]
            kind = str(z["kind"][()]) if "kind" in names else ""
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error):
        return []
    known = MARKER_ARRAYS if kind == "markers" else \
        MOTION_ARRAYS | {VALUES_KEY, LAYOUT_KEY, HEADER_KEY, COMMENTS_KEY, *TEXT_KEYS.values()}
    return [name for name in names if name not in known]
