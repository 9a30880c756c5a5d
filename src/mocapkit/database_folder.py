"""The motion database folder on disk: its layout, the guard on writing it, the checks on opening it.

A :class:`~mocapkit.database.MotionDatabase` is saved as a folder::

    database.json         description: format, version, fps, frames, feature sets,
                          skeletons, clips (name, source, start, frames, skeleton, mirrored), info
    rotations.npy         float32 (N, J, 4), local rotations, w first
    root_positions.npy    float32 (N, 3), file units of the clip's skeleton
    clip_ids.npy          int32 (N,), clip number of each frame
    translations.npy      float32 (N, J, 3), only when some clip animates joint offsets
    features/<name>.npy   float64 (N, D), one per feature set, centimetres

Writing must lose nothing (:func:`check_database_output`): the folder may not
be, lie in or hold an input, and an existing folder is replaced only when the
caller says so and it is a mocapkit database holding nothing else. The write
goes to a hidden temporary folder beside the target and is renamed into
place (:func:`publish_folder`, interrupts held across the swap); what a
killed write left beside the target is tidied, or put back, before the next
write (:func:`recover_leftovers`). ``database.json`` keeps a content digest
(:func:`content_digest`, in ``info``) computed once at save time, so a cache built from
the database (a knowledge base) can tell another content at no cost.

Opening trusts nothing (:func:`read_folder`): the description is bounded in
size and nesting before it is parsed, every field's type and range is
checked, feature names are plain identifiers of known feature sets (never
paths), and every ``.npy`` header is compared with the description and the
file's size before numpy maps it. Each failure is one
:class:`~mocapkit.errors.MocapFormatError` line naming the file.
"""

from __future__ import annotations

import errno
import hashlib
import json
import math
import os
import re
import shutil
import socket
import tempfile
import time
from pathlib import Path
from typing import Callable, Iterable, Mapping, NamedTuple, Sequence

import numpy as np

from .errors import MocapError, MocapFormatError
from .features import FEATURE_SETS, WINDOWED_SETS
from .interrupts import interrupts_held
from .io.outputs import (DATABASE_DESCRIPTION, DATABASE_FORMAT, inside, missing_folders, resolved, same_file,
                         temp_prefix)
from .motion import Skeleton
from .words import plural

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "DESCRIPTION",
    "FPS_RANGE",
    "Description",
    "check_database_output",
    "skeleton_to_json",
    "skeleton_from_json",
    "description_json",
    "content_digest",
    "staging_folder",
    "publish_folder",
    "write_staged",
    "recover_leftovers",
    "write_folder",
    "read_folder",
]

FORMAT = DATABASE_FORMAT
FORMAT_VERSION = 1
DESCRIPTION = DATABASE_DESCRIPTION
#: Frame rates (fps) a database may have: queries are resampled to it, so it bounds their size.
FPS_RANGE = (1.0, 1000.0)
#: dtype of each stored array, by file name ("features" for every features/<name>.npy).
_ARRAY_DTYPES = {
    "rotations.npy": np.dtype("<f4"),
    "root_positions.npy": np.dtype("<f4"),
    "translations.npy": np.dtype("<f4"),
    "clip_ids.npy": np.dtype("<i4"),
    "features": np.dtype("<f8"),
}
_MAX_DESCRIPTION_BYTES = 16 * 2**20  # a 2,000-clip database's takes 0.3 MB; 16 MB of "{}," parse in 0.5 GB
_MAX_JSON_DEPTH = 32  # a saved description nests 6 deep (a skeleton's limits); info may add a little
_JSON_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"')
_CHUNK = 2**20  # frames of clip_ids compared at a time
_FEATURE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")
_TOP_KEYS = ("format", "format_version", "fps", "num_frames", "feature_unit", "features", "skeletons", "clips")
_SKELETON_KEYS = ("joint_names", "parents", "offsets", "end_site_parents", "end_site_offsets", "channels", "axes", "limits", "unit_cm")
_CLIP_KEYS = ("name", "source", "start", "frames", "skeleton", "mirrored")
_DIGEST = re.compile(r"blake2b-256:[0-9a-f]{64}")
_DIGEST_KEY = "content_digest"  # kept in info: a mocapkit that predates it still opens the folder
_KEPT = "kept"  # the replaced folder's name inside its .NAME.OWNER-XXXX.old folder


class Description(NamedTuple):
    """What ``database.json`` says, checked.

    ``clips`` holds one ``(name, source, start, frames, skeleton, mirrored)``
    tuple per clip (the fields of :class:`~mocapkit.database.ClipInfo`);
    ``features`` maps each feature set to its number of columns;
    ``digest`` is the stored :func:`content_digest` (``info["content_digest"]``
    in the file, taken out of ``info`` here; "" in a folder saved before
    mocapkit kept one).
    """

    fps: float
    num_frames: int
    skeletons: tuple[Skeleton, ...]
    clips: tuple[tuple, ...]
    features: dict[str, int]
    info: dict
    digest: str = ""


# -- paths ---------------------------------------------------------------------------------------


def _named_inside(path, folder) -> bool:
    """True when ``path`` is ``folder`` or below it by name: ``.`` and ``..`` removed, symlinks not followed."""
    p, f = (Path(os.path.normpath(os.path.abspath(os.fspath(x)))) for x in (path, folder))
    return p == f or f in p.parents


def _one_line(exc: BaseException) -> str:
    """An exception's message on one line (numpy's and others' may span several)."""
    return " ".join(str(exc).split())


# -- the description -----------------------------------------------------------------------------


def skeleton_to_json(sk: Skeleton) -> dict:
    """A skeleton as the JSON object ``database.json`` stores (lists, numbers, strings, null)."""
    return {
        "joint_names": list(sk.joint_names),
        "parents": sk.parents.tolist(),
        "offsets": sk.offsets.tolist(),
        "end_site_parents": sk.end_site_parents.tolist(),
        "end_site_offsets": sk.end_site_offsets.tolist(),
        "channels": None if sk.channels is None else [list(c) for c in sk.channels],
        "axes": None if sk.axes is None else sk.axes.tolist(),
        "limits": None if sk.limits is None else [[list(p) for p in jl] for jl in sk.limits],
        "unit_cm": sk.unit_cm,
    }


def _json_depth(text: str) -> int:
    """Deepest nesting of ``[`` and ``{`` in JSON text, counted in linear time (strings skipped)."""
    bare = _JSON_STRING.sub("", text).encode("utf-8", "surrogatepass")
    b = np.frombuffer(bare, dtype=np.uint8)
    step = np.isin(b, (ord("["), ord("{"))).astype(np.int32) - np.isin(b, (ord("]"), ord("}")))
    return int(np.cumsum(step, dtype=np.int32).max(initial=0))


def _read_json(path: Path) -> dict:
    """The parsed ``database.json``, bounded in size and depth before parsing; a JSON object."""
    try:
        size = path.stat().st_size
        if size > _MAX_DESCRIPTION_BYTES:
            raise MocapFormatError(path, f"database description of {plural(size, 'byte')} is over the {_MAX_DESCRIPTION_BYTES}-byte limit")
        with open(path, encoding="utf-8") as fh:
            text = fh.read(_MAX_DESCRIPTION_BYTES + 1)
        depth = _json_depth(text)
        if depth > _MAX_JSON_DEPTH:
            raise MocapFormatError(path, f"database description nests {depth} deep (at most {_MAX_JSON_DEPTH})")
        desc = json.loads(text)
    except MocapFormatError:
        raise
    except (OSError, ValueError, RecursionError) as exc:
        raise MocapFormatError(path, f"unreadable database description ({_one_line(exc)})") from None
    if not isinstance(desc, dict):
        raise MocapFormatError(path, f"the database description is a JSON {type(desc).__name__}, not an object")
    return desc


def _is_int(x) -> bool:
    return type(x) is int  # JSON integers; not bool


def _is_number(x, allow_inf: bool = False) -> bool:
    return (type(x) is int or type(x) is float) and (math.isfinite(x) or (allow_inf and not math.isnan(x)))


def _is_rows(x, width: int, allow_inf: bool = False) -> bool:
    """True when ``x`` is a list of lists of ``width`` numbers each."""
    return isinstance(x, list) and all(isinstance(r, list) and len(r) == width and all(_is_number(v, allow_inf) for v in r) for r in x)


def _is_ints(x) -> bool:
    return isinstance(x, list) and all(_is_int(v) for v in x)


def _is_strings(x) -> bool:
    return isinstance(x, list) and all(isinstance(v, str) for v in x)


def _check_keys(d, keys: Sequence[str], optional: Sequence[str], where: str, path: Path) -> None:
    """``d`` is a JSON object with every one of ``keys``, and nothing besides them and ``optional``."""
    if type(d) is dict and len(d) == len(keys) and all(k in d for k in keys):
        return
    if not isinstance(d, dict):
        raise MocapFormatError(path, f"{where}: expected a JSON object, got {type(d).__name__}")
    missing = [k for k in keys if k not in d]
    unknown = sorted(set(d) - set(keys) - set(optional))
    if missing:
        raise MocapFormatError(path, f"{where}: missing {', '.join(missing)}")
    if unknown:
        raise MocapFormatError(path, f"{where}: unknown field(s) {', '.join(map(repr, unknown))}")


def skeleton_from_json(d, where: str, path: Path) -> Skeleton:
    """A skeleton from its JSON object, every field's type checked first (one line on failure)."""
    _check_keys(d, _SKELETON_KEYS, (), where, path)
    checks = {
        "joint_names": _is_strings(d["joint_names"]) and len(d["joint_names"]) > 0,
        "parents": _is_ints(d["parents"]),
        "offsets": _is_rows(d["offsets"], 3),
        "end_site_parents": _is_ints(d["end_site_parents"]),
        "end_site_offsets": _is_rows(d["end_site_offsets"], 3),
        "channels": d["channels"] is None or (isinstance(d["channels"], list) and all(_is_strings(c) for c in d["channels"])),
        "axes": d["axes"] is None or _is_rows(d["axes"], 4),
        "limits": d["limits"] is None or (isinstance(d["limits"], list) and all(_is_rows(jl, 2, allow_inf=True) for jl in d["limits"])),
        "unit_cm": d["unit_cm"] is None or (_is_number(d["unit_cm"]) and d["unit_cm"] > 0),
    }
    bad = [k for k, ok in checks.items() if not ok]
    if bad:
        raise MocapFormatError(path, f"{where}: wrong type or value of {', '.join(bad)}")
    try:
        return Skeleton(
            joint_names=tuple(d["joint_names"]),
            parents=np.asarray(d["parents"], dtype=np.int64),
            offsets=np.asarray(d["offsets"], dtype=np.float64).reshape(-1, 3),
            end_site_parents=np.asarray(d["end_site_parents"], dtype=np.int64),
            end_site_offsets=np.asarray(d["end_site_offsets"], dtype=np.float64).reshape(-1, 3),
            channels=None if d["channels"] is None else tuple(tuple(c) for c in d["channels"]),
            axes=None if d["axes"] is None else np.asarray(d["axes"], dtype=np.float64).reshape(-1, 4),
            limits=None if d["limits"] is None else tuple(tuple(tuple(p) for p in jl) for jl in d["limits"]),
            unit_cm=d["unit_cm"],
        )
    except (MocapError, ValueError, OverflowError) as exc:
        raise MocapFormatError(path, f"{where}: {_one_line(exc)}") from None


def _feature_columns(name: str) -> int:
    """Columns of a known feature set: 3 per joint, times the window's samples."""
    base, samples = (name, 1) if name in FEATURE_SETS else WINDOWED_SETS[name]
    return 3 * len(FEATURE_SETS[base]) * samples


def _check_features(feats, path: Path) -> dict[str, int]:
    if not isinstance(feats, dict) or not feats:
        raise MocapFormatError(path, "features: expected a non-empty JSON object of feature set -> columns")
    for name, dims in feats.items():
        if not _FEATURE_NAME.fullmatch(name):
            raise MocapFormatError(path, f"feature name {name!r} is not a plain identifier")
        if name not in FEATURE_SETS and name not in WINDOWED_SETS:
            raise MocapFormatError(path, f"unknown feature set {name!r}; known: {', '.join(list(FEATURE_SETS) + list(WINDOWED_SETS))}")
        if not _is_int(dims) or dims != _feature_columns(name):
            raise MocapFormatError(path, f"feature set {name!r} has {_feature_columns(name)} columns, not {dims!r}")
    return dict(feats)


def _check_clips(raw, N: int, n_skeletons: int, path: Path) -> tuple[tuple, ...]:
    """Clip records that tile frames ``0 .. N-1`` in order, with unique names and valid skeleton numbers."""
    if not isinstance(raw, list) or not raw:
        raise MocapFormatError(path, "clips: expected a non-empty list")
    clips, names, start = [], set(), 0
    for k, c in enumerate(raw):
        _check_keys(c, _CLIP_KEYS, (), f"clip {k}", path)
        if not (isinstance(c["name"], str) and isinstance(c["source"], str) and isinstance(c["mirrored"], bool)) or not all(
            _is_int(c[f]) for f in ("start", "frames", "skeleton")
        ):
            raise MocapFormatError(path, f"clip {k}: wrong type (name, source: text; start, frames, skeleton: integers; mirrored: true/false)")
        name = c["name"]
        if c["start"] != start or c["frames"] < 1 or start + c["frames"] > N:
            raise MocapFormatError(path, f"clip {k} ({name!r}): start {c['start']}, {plural(c['frames'], 'frame')}; expected start {start} and 1 .. {N - start} frames")
        if not 0 <= c["skeleton"] < n_skeletons:
            raise MocapFormatError(path, f"clip {k} ({name!r}): skeleton {c['skeleton']} out of range 0 .. {n_skeletons - 1}")
        if name in names:
            raise MocapFormatError(path, f"clip {k}: name {name!r} repeats an earlier clip's")
        names.add(name)
        clips.append(tuple(c[f] for f in _CLIP_KEYS))
        start += c["frames"]
    if start != N:
        raise MocapFormatError(path, f"the clips cover {plural(start, 'frame')}, num_frames says {N}")
    return tuple(clips)


def _check_description(desc: dict, path: Path) -> Description:
    """Every field of a parsed ``database.json``, its type and range."""
    _check_keys(desc, _TOP_KEYS, ("info",), "database description", path)
    if desc["format"] != FORMAT:
        raise MocapFormatError(path, f"not a mocapkit motion database (format {desc['format']!r})")
    if not _is_int(desc["format_version"]) or desc["format_version"] != FORMAT_VERSION:
        raise MocapFormatError(path, f"format version {desc['format_version']!r}; this mocapkit reads version {FORMAT_VERSION}")
    fps, N = desc["fps"], desc["num_frames"]
    if not (_is_number(fps, allow_inf=True) and FPS_RANGE[0] <= fps <= FPS_RANGE[1]):
        raise MocapFormatError(path, f"fps {fps!r} is not a frame rate between {FPS_RANGE[0]:g} and {FPS_RANGE[1]:g}")
    if not (_is_int(N) and N >= 1):
        raise MocapFormatError(path, f"num_frames {N!r} is not a positive integer")
    if desc["feature_unit"] != "cm":
        raise MocapFormatError(path, f"feature_unit {desc['feature_unit']!r}; databases store features in 'cm'")
    info = desc.get("info", {})
    if not isinstance(info, dict):
        raise MocapFormatError(path, "info: expected a JSON object")
    features = _check_features(desc["features"], path)
    if not isinstance(desc["skeletons"], list) or not desc["skeletons"]:
        raise MocapFormatError(path, "skeletons: expected a non-empty list")
    skeletons = tuple(skeleton_from_json(s, f"skeleton {k}", path) for k, s in enumerate(desc["skeletons"]))
    for k, sk in enumerate(skeletons[1:], 1):
        if sk.joint_names != skeletons[0].joint_names or not np.array_equal(sk.parents, skeletons[0].parents):
            raise MocapFormatError(path, f"skeleton {k}: other joints or parents than skeleton 0 (a database has one topology)")
    clips = _check_clips(desc["clips"], N, len(skeletons), path)
    info = dict(info)
    digest = info.pop(_DIGEST_KEY, "")
    if not (isinstance(digest, str) and (digest == "" or _DIGEST.fullmatch(digest))):
        raise MocapFormatError(path, f"info: {_DIGEST_KEY}: expected 'blake2b-256:' and 64 hexadecimal digits")
    return Description(float(fps), N, skeletons, clips, features, info, digest)


# -- arrays --------------------------------------------------------------------------------------


def _array_dtype(rel: str) -> np.dtype:
    return _ARRAY_DTYPES[rel.split("/")[0]]


def _load_array(directory: Path, rel: str, shape: tuple, mmap: bool) -> np.ndarray:
    """A stored array after checking its file: inside the folder, header dtype and shape, size.

    The header is read and the file's size compared with what it declares
    before numpy maps or reads anything, so an empty, truncated or padded file
    is one error line rather than a crash.
    """
    p = directory / rel
    dtype = _array_dtype(rel)
    if not p.is_file() or not inside(p, directory):
        raise MocapFormatError(p, "missing, not a regular file, or a link out of the database folder")
    try:
        with open(p, "rb") as fh:
            version = np.lib.format.read_magic(fh)
            if version not in ((1, 0), (2, 0)):
                raise ValueError(f".npy format version {version[0]}.{version[1]}, expected 1.0 or 2.0")
            read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            got_shape, fortran, got_dtype = read_header(fh)
            offset = fh.tell()
            size = os.fstat(fh.fileno()).st_size
    except Exception as exc:  # numpy's header parser raises ValueError, SyntaxError, TokenError, ...
        raise MocapFormatError(p, f"unreadable array header ({type(exc).__name__}: {_one_line(exc)})") from None
    if got_dtype != dtype or fortran:
        raise MocapFormatError(p, f"expected a C-ordered {dtype} array, got a {'Fortran-ordered' if fortran else 'C-ordered'} {got_dtype} one")
    if tuple(got_shape) != tuple(shape):
        raise MocapFormatError(p, f"expected shape {tuple(shape)} (from {DESCRIPTION}), got {tuple(got_shape)}")
    nbytes = math.prod(shape) * dtype.itemsize
    if size != offset + nbytes:
        raise MocapFormatError(p, f"holds {plural(size - offset, 'byte')} of data where its header declares {nbytes}: truncated or damaged")
    try:
        return np.load(p, mmap_mode="r" if mmap else None, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise MocapFormatError(p, f"unreadable array ({_one_line(exc)})") from None


# -- writing and reading the folder ---------------------------------------------------------------


def _not_a_database(folder: Path) -> str:
    """Why an existing ``folder`` may not be replaced ("" when it is a mocapkit database or empty).

    Only what :func:`write_folder` writes may be lost: ``database.json``
    naming the format, the top-level ``.npy`` files and ``features/<name>.npy``,
    all regular files (no links, no other files or folders).
    """
    if not folder.is_dir():
        return "it is a file, not a database folder"
    with os.scandir(folder) as it:
        if next(it, None) is None:
            return ""
    if not (folder / DESCRIPTION).is_file() or (folder / DESCRIPTION).is_symlink():
        return f"it is not a mocapkit database (no {DESCRIPTION})"
    try:
        kind = _read_json(folder / DESCRIPTION).get("format")
    except MocapFormatError:
        kind = None
    if kind != FORMAT:
        return f"it is not a mocapkit database ({DESCRIPTION} does not say so)"
    with os.scandir(folder) as entries:
        for e in entries:
            if e.name == "features" and e.is_dir(follow_symlinks=False):
                with os.scandir(e.path) as features:
                    for f in features:
                        if not (f.name.endswith(".npy") and _FEATURE_NAME.fullmatch(f.name[:-4]) and f.is_file(follow_symlinks=False)):
                            return f"it holds features/{f.name}, which a database save does not write"
            elif e.name not in _ARRAY_DTYPES and e.name != DESCRIPTION or not e.is_file(follow_symlinks=False):
                return f"it holds {e.name}, which a database save does not write"
    return ""


def _owner() -> str:
    """This process as the owner tag of its hidden folders: pid and a hash of the host name (``1234-a1b2c3``)."""
    return f"{os.getpid()}-{hashlib.blake2b(socket.gethostname().encode(), digest_size=3).hexdigest()}"


def _owner_dead(tag: str) -> bool:
    """True when the process of owner ``tag`` (:func:`_owner`) ran on this host and is gone.

    Another host's process cannot be asked, and a pid reused since reads as
    alive: both are left alone (never deleted by mistake, at worst kept).
    """
    pid, _, host = tag.partition("-")
    if host != _owner().partition("-")[2]:
        return False
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except (PermissionError, OverflowError, ValueError):  # another user's live process; a pid out of range
        return False
    return False


_STAGED_AFTER = len("4194304-a1b2c3") + len("-XXXXXXXX.part")
"""Bytes that follow NAME in a staging folder's name at most (the largest Linux pid; "part" or "old"): NAME is cut
to what leaves the whole within NAME_MAX (:func:`mocapkit.io.outputs.temp_prefix`), the same cut for every
owner, so :func:`_leftovers` finds a dead owner's folders by it."""


def staging_folder(target, kind: str = "part") -> Path:
    """A new hidden folder ``.NAME.OWNER-XXXXXXXX.KIND`` beside ``target`` (``NAME`` its name, ``OWNER`` this process).

    Where a folder is written before it is renamed into place (``kind``
    "part") or where the folder it replaces waits until the swap is done
    ("old"). The owner tag (pid and host) lets :func:`recover_leftovers`
    tell a killed run's leftovers from a live writer's. A "part" folder gets
    the permissions of a folder made with ``mkdir`` (the umask's, not
    ``mkdtemp``'s owner-only ones), since it becomes the target.
    """
    target = Path(target)
    prefix = temp_prefix(target.name, _STAGED_AFTER) + f"{_owner()}-"  # a folder name of 225-255 bytes: cut
    path = Path(tempfile.mkdtemp(prefix=prefix, suffix=f".{kind}", dir=target.parent))
    if kind == "part":
        try:
            probe = path / "mode"  # os.mkdir's mode under the umask, read without changing the process's umask
            os.mkdir(probe)
            os.chmod(path, os.stat(probe).st_mode & 0o7777)
            probe.rmdir()
        except BaseException:
            shutil.rmtree(path, ignore_errors=True)
            raise
    return path


def _leftovers(target: Path) -> list[tuple[Path, str, str]]:
    """The ``.NAME.OWNER-XXXXXXXX.{part,old}`` folders beside ``target`` whose owner is dead: ``(path, kind, inner)``,
    newest first; ``inner`` names the replaced folder inside an ``.old`` one.

    mocapkit 0.1.0 named them ``.NAME.XXXXXXXX.{part,old}`` (no owner; the replaced database in ``.old/db``): its
    ``.old`` folders are taken as dead once a minute old (its swap took milliseconds); its ``.part`` folders, which a
    long build of that version may still be writing, are left alone.
    """
    name = re.escape(temp_prefix(target.name, _STAGED_AFTER)[1:-1])  # as staging_folder cuts it
    tagged = re.compile(rf"\.{name}\.(\d+-[0-9a-f]{{6}})-[a-z0-9_]{{8}}\.(part|old)")
    legacy = re.compile(rf"\.{name}\.[a-z0-9_]{{8}}\.(old)")
    found = []
    try:
        with os.scandir(target.parent) as entries:
            for e in entries:
                if not e.is_dir(follow_symlinks=False):
                    continue
                when = e.stat(follow_symlinks=False).st_mtime_ns
                m = tagged.fullmatch(e.name)
                if m and _owner_dead(m.group(1)):
                    found.append((Path(e.path), m.group(2), _KEPT, when))
                m = legacy.fullmatch(e.name)
                if m and time.time_ns() - when > 60 * 10**9:
                    found.append((Path(e.path), m.group(1), "db", when))
    except OSError:
        return []
    return [(p, kind, inner) for p, kind, inner, _ in sorted(found, key=lambda f: -f[3])]


def recover_leftovers(target) -> Path | None:
    """Tidy what killed writes of the folder ``target`` left beside it; returns the folder put back, if any.

    A write killed outright (``kill -9``, power loss: no handler runs)
    between the two renames of :func:`publish_folder` leaves ``target``
    missing and the folder it replaced in ``.NAME.OWNER-X.old/kept``: when
    ``target`` is missing that folder (the newest) is renamed back, so the
    user's data is where it was before the killed run (it is returned, so a
    caller can say so). Then the hidden ``.part`` folders and the ``.old``
    folders of dead owners are removed: a ``.part`` is an unfinished write,
    an ``.old`` beside an existing ``target`` a folder its run was asked to
    replace. Folders of live processes (another writer right now) and of
    other hosts are never touched.
    """
    target = Path(target)
    restored = None
    found = _leftovers(target)
    if not os.path.lexists(target):
        for path, kind, inner in found:
            if kind == "old" and (path / inner).is_dir():
                with interrupts_held():
                    os.rename(path / inner, target)
                    path.rmdir()
                restored = path / inner
                break
    for path, _, _ in found:
        if path.exists() and (restored is None or path != restored.parent):
            shutil.rmtree(path, ignore_errors=True)
    return restored


def publish_folder(tmp, target) -> None:
    """Put the finished folder ``tmp`` (made by :func:`staging_folder` beside ``target``) at ``target``.

    An existing ``target`` (a folder the caller may replace: checked before)
    is first moved aside into a ``.old`` folder; it is deleted only once
    the new folder is in place, and renamed back if that rename fails.
    SIGINT and SIGTERM wait until the swap is done
    (:func:`mocapkit.interrupts.interrupts_held`), so an interrupt never
    leaves ``target`` missing; a ``kill -9`` between the two renames leaves
    the old folder for :func:`recover_leftovers` to put back.
    """
    tmp, target = Path(tmp), Path(target)
    with interrupts_held():
        if not os.path.lexists(target):
            os.rename(tmp, target)
            return
        old = staging_folder(target, "old")
        try:
            os.replace(target, old / _KEPT)
        except BaseException:
            old.rmdir()
            raise
        try:
            os.replace(tmp, target)
        except BaseException:
            os.replace(old / _KEPT, target)
            old.rmdir()
            raise
        shutil.rmtree(old, ignore_errors=True)


def description_json(description: Description) -> dict:
    """``description`` as the JSON object ``database.json`` stores, without its digest (``info`` as given)."""
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "fps": description.fps,
        "num_frames": description.num_frames,
        "feature_unit": "cm",
        "features": dict(description.features),
        "skeletons": [skeleton_to_json(s) for s in description.skeletons],
        "clips": [dict(zip(_CLIP_KEYS, c)) for c in description.clips],
        "info": {k: v for k, v in description.info.items() if k != _DIGEST_KEY},
    }


def content_digest(description: Description, arrays: Mapping[str, np.ndarray]) -> str:
    """The identity of a database's content: ``"blake2b-256:"`` and 64 hex digits.

    A BLAKE2b hash of :func:`description_json` without ``info`` (frame rate,
    skeletons, clips, feature sets; keys sorted: ``info`` is notes, which
    callers change) and without the clips' sources (a folder typed as
    ``takes``, ``/abs/takes`` or ``../x/takes`` gave three digests) and of every array of the layout (name, stored dtype,
    shape, bytes; in file-name order). Two databases with the same digest
    hold the same motion; any edited sample changes it. About 0.4-1 GB/s:
    :func:`write_folder` computes it once and stores it in ``database.json``
    (``info["content_digest"]``, which an older mocapkit reads as a note), so
    an opened database knows it without reading its arrays.
    """
    h = hashlib.blake2b(digest_size=32)
    desc = description_json(description)
    del desc["info"]
    for clip in desc["clips"]:  # where a clip was read from, as the user typed it, is not what it holds
        clip.pop("source", None)
    h.update(json.dumps(desc, sort_keys=True).encode("utf-8"))
    for rel in sorted(arrays):
        a = np.ascontiguousarray(arrays[rel], dtype=_array_dtype(rel))
        h.update(f"\0{rel}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(memoryview(a.reshape(-1)).cast("B"))
    return f"blake2b-256:{h.hexdigest()}"


def check_database_output(directory, inputs: Iterable = (), overwrite: bool = False,
                          how: str = "pass overwrite=True") -> None:
    """Refuse, before any work, a database folder whose writing could lose anything.

    ``directory`` may not be an input, lie inside an input folder, or hold an
    input (any input file or folder below it), compared both through
    symlinks and by name. Its parent may not be a file. When it exists it is
    replaced only with ``overwrite`` and only when it is a mocapkit database
    (its ``database.json`` says so and it holds nothing but what a database
    save writes) or an empty folder. A database that a killed write left
    hidden beside a missing ``directory`` is first put back
    (:func:`recover_leftovers`), so it is never lost to a new write: it is
    then replaced only with ``overwrite``, as any existing database.

    Parameters
    ----------
    directory : path of the database folder to write.
    inputs : paths read to build it (files or folders); entries that are not
        paths (``None``, Motions) are ignored.
    overwrite : allow replacing an existing database folder.
    how : what the refusal of an existing folder tells the caller to do (the library's keyword; the
        command line's ``pass --overwrite``).

    Raises
    ------
    MocapFormatError
        One line naming ``directory`` and what is wrong with it.
    """
    out = Path(directory)
    for inp in inputs:
        if not isinstance(inp, (str, os.PathLike)):
            continue
        if same_file(out, inp) or inside(out, inp) or _named_inside(out, inp):
            raise MocapFormatError(out, f"refusing to write a database over or inside an input ({inp}); choose another folder")
        if inside(inp, out) or _named_inside(inp, out):
            raise MocapFormatError(out, f"refusing to replace a folder that holds an input ({inp}); choose another folder")
    parent = resolved(out).parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise MocapFormatError(out, f"cannot create it: {parent} is a file, not a folder")
    restored = recover_leftovers(resolved(out)) if resolved(out).parent.is_dir() else None
    if not os.path.lexists(out):
        return
    if not overwrite:
        note = f" (put back from {restored}, where an interrupted write had left it)" if restored else ""
        raise MocapFormatError(out, f"already exists{note}; {how} to replace it")
    why = _not_a_database(resolved(out)) if out.exists() else "it is a broken symbolic link"
    if why:
        raise MocapFormatError(out, f"refusing to replace it: {why}")


def write_folder(directory, description: Description, arrays: Mapping[str, np.ndarray], *, inputs: Iterable = (), overwrite: bool = False) -> Path:
    """Write a database folder atomically after :func:`check_database_output`; returns its resolved path.

    ``arrays`` maps each file of the layout (``"rotations.npy"``,
    ``"features/F15.npy"``, ...) to its array, stored in the layout's dtype.
    Everything is written into a hidden temporary folder beside the target
    (:func:`staging_folder`); an existing database is moved aside, the new
    one renamed into place, and the old one deleted only then (put back if
    the rename fails; :func:`publish_folder`), so an interrupted write
    leaves the old or the new database, never a mix. ``database.json``'s
    ``info`` gets ``description.digest``, or :func:`content_digest` when it is "". A
    failing write (disk full, no permission) is a one-line
    :class:`~mocapkit.errors.MocapFormatError` naming ``directory``.
    """
    for rel in arrays:
        top, _, name = rel.partition("/")
        if not (rel in _ARRAY_DTYPES or top == "features" and name.endswith(".npy") and _FEATURE_NAME.fullmatch(name[:-4])):
            raise ValueError(f"{rel!r} is not a file of the database layout (feature names are plain identifiers)")
    inputs = list(inputs)
    check_database_output(directory, inputs, overwrite=overwrite)
    existed = os.path.lexists(directory)
    desc = description_json(description)

    def fill(tmp: Path) -> None:
        (tmp / "features").mkdir()
        for rel, a in arrays.items():
            with open(tmp / rel, "wb") as fh:  # through Python's writes: a full disk is ENOSPC, not a short count
                np.save(_Stream(fh), np.ascontiguousarray(a, dtype=_array_dtype(rel)), allow_pickle=False)
        desc["info"][_DIGEST_KEY] = description.digest or content_digest(description, arrays)
        with open(tmp / DESCRIPTION, "w", encoding="utf-8") as fh:
            json.dump(desc, fh, indent=1)

    def recheck() -> None:
        if not existed and os.path.lexists(directory):  # another process wrote it since the first check
            raise MocapFormatError(directory, "appeared while this command ran (another program wrote it); nothing "
                                              "was written over it")
        check_database_output(directory, inputs, overwrite=overwrite)

    return write_staged(directory, fill, recheck, "the database")


def write_staged(directory, fill: Callable[[Path], None], recheck: Callable[[], None], what: str) -> Path:
    """Write the folder ``directory`` whole or not at all: ``fill(tmp)`` writes its files into a hidden
    :func:`staging_folder` beside it, ``recheck()`` refuses the write if the target changed meanwhile (raising), and
    :func:`publish_folder` swaps it in. On any failure or interrupt the staging folder is removed; a failing write
    is one :class:`~mocapkit.errors.MocapFormatError` naming ``directory`` and ``what`` ("the database"). A
    symlinked ``directory``: what it points to is replaced. Returns the folder written (resolved).
    """
    target = resolved(directory)
    made = missing_folders([target.parent])  # removed again, when left empty, if the write fails
    tmp = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = staging_folder(target)
        fill(tmp)
        recheck()
        publish_folder(tmp, target)
    except BaseException as exc:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
        for folder in made:
            try:
                folder.rmdir()
            except OSError:  # not empty (something else was put there), or never made
                pass
        if isinstance(exc, OSError):
            why = "no space left on the device" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
            raise MocapFormatError(directory, f"cannot write {what} ({why})") from None
        raise
    return target


class _Stream:
    """A file seen by numpy as a plain stream: ``np.save`` then writes it with ``write`` (16 MiB chunks), whose
    failure is an ``OSError`` with its errno, not ``tofile``'s "N requested and M written" (no errno, no cause)."""

    def __init__(self, fh):
        self.write = fh.write


def read_folder(directory, mmap: bool = True) -> tuple[Description, dict[str, np.ndarray]]:
    """The checked description and arrays of a database folder (arrays keyed by file, as in :func:`write_folder`).

    Arrays are memory-mapped read-only unless ``mmap=False``. Nothing is
    mapped before the description and every ``.npy`` header have been checked
    (see the module docstring); ``clip_ids.npy`` must agree with the clip
    ranges. A folder replaced while it is read (``db build --overwrite``
    swapping in a new build) could give the description of one build and
    arrays of the other: the folder's identity is compared before and after,
    and the reading is done again when it changed.
    """
    directory = Path(directory)
    for attempt in range(_OPEN_TRIES):
        before = _identity(directory)
        try:
            out = _read_folder(directory, mmap)
        except (MocapFormatError, OSError):
            if before is None or _identity(directory) == before or attempt == _OPEN_TRIES - 1:
                raise
            continue  # it was replaced while read: its parts disagreed
        if before is not None and _identity(directory) == before:
            return out
    raise MocapFormatError(directory, f"was replaced {_OPEN_TRIES} times while it was being opened; open it again "
                                      "once its build is done")


_OPEN_TRIES = 5


def _identity(directory: Path):
    try:
        st = os.stat(directory)
    except OSError:
        return None
    return st.st_dev, st.st_ino, st.st_mtime_ns


def _read_folder(directory: Path, mmap: bool) -> tuple[Description, dict[str, np.ndarray]]:
    desc_path = directory / DESCRIPTION
    if not directory.exists():
        hidden = [p / inner for p, kind, inner in _leftovers(resolved(directory)) if kind == "old" and (p / inner).is_dir()]
        if hidden:  # said, not moved: opening changes nothing; the next write puts it back
            raise MocapFormatError(directory, f"no such folder; an interrupted write left the previous database at {hidden[0]}")
        raise MocapFormatError(directory, "no such folder (a motion database is a folder `mocapkit db build` writes)")
    if not directory.is_dir() or not desc_path.is_file():
        raise MocapFormatError(directory, f"not a motion database (no {DESCRIPTION})")
    d = _check_description(_read_json(desc_path), desc_path)
    N, J = d.num_frames, d.skeletons[0].num_joints
    shapes = {"rotations.npy": (N, J, 4), "root_positions.npy": (N, 3), "clip_ids.npy": (N,)}
    if os.path.lexists(directory / "translations.npy"):
        shapes["translations.npy"] = (N, J, 3)
    shapes.update({f"features/{n}.npy": (N, cols) for n, cols in d.features.items()})
    arrays = {rel: _load_array(directory, rel, shape, mmap) for rel, shape in shapes.items()}
    ids, starts = arrays["clip_ids.npy"], np.array([c[2] for c in d.clips])
    for a in range(0, N, _CHUNK):  # in chunks: memory stays bounded on any N
        expected = np.searchsorted(starts, np.arange(a, min(a + _CHUNK, N)), side="right") - 1
        wrong = np.flatnonzero(ids[a : a + _CHUNK] != expected)
        if wrong.size:
            k = int(expected[wrong[0]])
            raise MocapFormatError(directory / "clip_ids.npy", f"clip numbers disagree with the clip ranges in {DESCRIPTION} (clip {k})")
    return d, arrays
