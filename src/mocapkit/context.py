"""What a take is compared with: ``--context`` resolved to a motion database, built once and cached.

Self-similarity cleaning (Aristidou et al. 2018, "Self-similarity analysis for
motion capture cleaning", Computer Graphics Forum 37(2), section 3.3) judges a
take's motion words by their nearest neighbours in a *context*: the clip
itself, related clips, or a large database. A word with no neighbour close
enough is left unjudged, so a take the context has never seen the like of is
mostly unjudged. This module turns what a user gives into that context:

* **a database folder** (written by ``mocapkit db build`` or
  :meth:`MotionDatabase.save`): opened as it is;
* **a folder of takes** (searched recursively for ``.bvh``, ``.amc`` and
  ``.npz`` motions; ``.clean.npz`` and ``.mask.npz`` records left out) **or a
  list of files**: built into a database once (:func:`build_context`) and
  cached (:func:`cached_context`), so the next run opens it in milliseconds;
* **nothing**: the **default context** bundled with the package
  (:func:`default_context`, ``mocapkit/data/context/``; rebuilt by
  ``scripts/build_default_context.py``), or no context at all when the user
  says ``none`` (``--context none``, ``context=False`` or ``"none"``).

**The cache** lives under ``$MOCAPKIT_CACHE_DIR/contexts/`` (else
``$XDG_CACHE_HOME/mocapkit/contexts/`` or ``~/.cache/mocapkit/contexts/``), one database folder per key. The key hashes
each file's resolved path, size and modification time (and, for an AMC, those
of the ASF beside it, which the reader uses), the build settings and the
database format, so an edited, added or removed file makes a new key. A build
is written into a hidden staging folder and renamed into place in one step:
two processes building one key at once both succeed (the first rename wins,
the other's copy is discarded), and an interrupted build leaves only a hidden
``.build-*`` folder, never something that looks complete (such leftovers are
swept after a day). The cache holds copies made from the user's files, never
the files themselves, and nothing in it replaces them.

**Rigs.** A database holds one skeleton topology. Takes of a folder on
another topology than the majority's are left out of the build with one note
naming them; a take on one of those other topologies gets a second build of
the same files that keeps its own (``prefer``, cached under its own key), so
the takes of a mixed folder each meet the ones on their skeleton. A file found
in a folder that cannot be context (a marker capture, a take with missing
joints, an AMC without its ASF) is left out with a note; one named on its own
is refused. A database serves a take (:func:`fit_context`) when the joint
names agree, or when the topology (parents) agrees and every bone's rest
direction agrees within :data:`REST_TOLERANCE_DEG`: then local rotations mean
the same on both skeletons (mocapkit reads ASF rotations as ``C M C^-1`` about
the ASF's rest directions, so the CMU ASF/AMC takes and their cgspeed BVH
conversions, ``lfemur``/``LeftUpLeg``/``LeftHip``, hold identical rotations)
and the context's joints are renamed to the take's. Otherwise an explicit
context is refused with the reason, and the default context is skipped with
one note (the take is judged against itself).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import time
import uuid
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from .errors import MocapError, MocapFormatError
from .words import plural

__all__ = [
    "BUILD_FPS",
    "BUILD_FEATURES",
    "REST_TOLERANCE_DEG",
    "cache_root",
    "context_files",
    "context_key",
    "topology_id",
    "build_context",
    "context_take",
    "motions_context",
    "cached_context",
    "noted_missing",
    "default_context",
    "default_context_path",
    "resolve_context",
    "fit_context",
    "context_label",
    "terms_note",
    "is_off",
]

#: Frame rate contexts are built at (fps): the self-similarity analysis rate
#: (:class:`mocapkit.cleaning.ssa.SSAParams`, 24 fps), so nothing is lost and no clip is resampled twice.
BUILD_FPS = 24.0
#: Feature sets stored with a built context (a database needs one; F15, Krüger et al. 2010).
BUILD_FEATURES = ("F15",)
#: Largest angle (degrees) between a bone's rest direction on the take's and on the context's
#: skeleton for the context to serve the take by topology.
REST_TOLERANCE_DEG = 30.0
_OFF = ("none", "off")
_RECORDS = (".clean.npz", ".mask.npz")
_STALE_S = 24 * 3600.0  # a staging folder older than this is a build that was killed


def is_off(spec) -> bool:
    """True when ``spec`` turns the context off: ``False``, ``"none"``/``"off"`` (any case), or a list of just that."""
    if spec is False:
        return True
    if isinstance(spec, (list, tuple)) and len(spec) == 1:
        spec = spec[0]
    return isinstance(spec, (str, os.PathLike)) and os.fspath(spec).strip().lower() in _OFF


def cache_root() -> Path:
    """Folder of cached contexts: ``$MOCAPKIT_CACHE_DIR/contexts``, else ``$XDG_CACHE_HOME/mocapkit/contexts``,
    else ``~/.cache/mocapkit/contexts``."""
    base = os.environ.get("MOCAPKIT_CACHE_DIR")
    if base:
        return Path(base).expanduser() / "contexts"
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg and os.path.isabs(xdg):  # a relative one is to be ignored (the XDG spec)
        return Path(xdg) / "mocapkit" / "contexts"
    return Path.home() / ".cache" / "mocapkit" / "contexts"


def default_context_path() -> Path:
    """The bundled default context's database folder (``mocapkit/data/context``)."""
    from importlib import resources

    return Path(str(resources.files("mocapkit") / "data" / "context"))


def _is_database(p: Path) -> bool:
    from .database_folder import DESCRIPTION

    return p.is_dir() and (p / DESCRIPTION).is_file()


def context_files(spec) -> list[Path]:
    """The motion files a folder or list of paths names, in a stable order.

    Folders are searched recursively for ``.bvh``, ``.amc`` and ``.npz`` files
    (hidden files and cleaning records ``*.clean.npz``/``*.mask.npz`` left
    out), sorted by path; files are taken as given. Raises
    :class:`~mocapkit.errors.MocapFormatError` naming a missing path, a file of
    another kind, a database folder among other paths, or a folder without
    motion files.
    """
    from .database import SUFFIXES

    paths = [Path(spec)] if isinstance(spec, (str, os.PathLike)) else [Path(p) for p in spec]
    out: list[Path] = []
    for p in paths:
        if _is_database(p):
            raise MocapFormatError(p, "a motion database folder must be the only context given")
        if p.is_dir():
            found = sorted(q for q in p.rglob("*") if q.suffix.lower() in SUFFIXES and not q.name.startswith(".")
                           and not q.name.lower().endswith(_RECORDS) and q.is_file())
            if not found:
                raise MocapFormatError(p, f"the folder holds no motion files ({', '.join(SUFFIXES)}) to use as context")
            out.extend(found)
        elif p.is_file():
            if p.suffix.lower() not in SUFFIXES:
                raise MocapFormatError(p, f"cannot be context (expected {', '.join(SUFFIXES)} motion files or a folder)")
            out.append(p)
        else:
            raise MocapFormatError(p, "no such file or folder (a context is a database folder, a folder of takes or files)")
    seen, unique = set(), []
    for p in out:
        r = p.resolve()
        if r not in seen:
            seen.add(r)
            unique.append(p)
    return unique


def _stamp(p: Path) -> list:
    st = p.stat()
    return [str(p.resolve()), st.st_size, st.st_mtime_ns]


def topology_id(skeleton) -> str:
    """A short digest of a skeleton's topology: its joint names and parents (what one database holds)."""
    text = json.dumps([list(skeleton.joint_names), [int(x) for x in skeleton.parents]])
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


def context_key(files: Sequence, fps: float = BUILD_FPS, features: Sequence[str] = BUILD_FEATURES,
                prefer: str | None = None, optional: Sequence = (), joint_map: dict | None = None) -> str:
    """The cache key of a context built from ``files``: a hex digest of every file's resolved path, size and
    mtime (an AMC's also of the ASF beside it), the settings (``prefer``: a :func:`topology_id`; ``optional``:
    the files found in folders; ``joint_map``: the names the clips' joints were given) and the database format
    version."""
    from .database_folder import FORMAT_VERSION
    from .io.asfamc import find_asf

    stamps = []
    for f in files:
        p = Path(f)
        row = _stamp(p)
        if p.suffix.lower() == ".amc":
            try:
                row.append(_stamp(find_asf(p)))
            except MocapError:
                row.append(None)  # the build refuses it, naming the file
        stamps.append(row)
    settings = {"files": stamps, "fps": float(fps), "features": list(features), "format": FORMAT_VERSION, "layout": 2}
    if prefer is not None:
        settings["prefer"] = prefer
    if joint_map:
        settings["joint_map"] = sorted(dict(joint_map).items())
    found = sorted(str(Path(f).resolve()) for f in optional)
    if found:
        settings["optional"] = found
    text = json.dumps(settings, sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:32]


def _progress(total: int, enabled: bool):
    """A rich progress bar on stderr (a no-op when not ``enabled``). The file name it shows is shown as it is: no
    rich markup (``[/b]``) nor emoji code (``:smile:``) read in it."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from .progress import bar_disabled

    mode = bar_disabled(enabled)  # on a terminal only, as every bar (mocapkit.progress)
    console = Console(stderr=True, force_terminal=True if mode is False else None, markup=False, emoji=False,
                      highlight=False)
    return Progress(TextColumn("building context"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                    TextColumn("{task.description}", markup=False), console=console,
                    disable=mode is True or (mode is None and not console.is_terminal), transient=True)


def _names(paths: Sequence[Path]) -> str:
    return ", ".join(p.name for p in paths[:5]) + (f" and {len(paths) - 5} more" if len(paths) > 5 else "")


def _context_take(p: Path, fps: float):
    """The take at ``p`` resampled for a context; MocapFormatError naming it when it cannot be context."""
    from .io.takes import load_motion

    return context_take(load_motion(p, purpose="context"), fps, p)


def context_take(m, fps: float = BUILD_FPS, source=None):
    """The Motion ``m`` as a context clip: resampled to ``fps`` (slerp, :meth:`Motion.resample`) and named (by
    ``source``'s stem when it has no name). A take with no frames or with missing joints cannot be context:
    :class:`~mocapkit.errors.MocapFormatError` naming ``source`` (a file), or ``m.name``."""
    where = source if source is not None else (m.name or "a context Motion")
    if m.num_frames == 0:
        raise MocapFormatError(where, "the take has no frames; it cannot be context")
    if not np.all(np.isfinite(m.rotations)):
        raise MocapFormatError(where, "the take has missing joints (NaN); fill it before using it as context")
    m = m.resample(fps)
    return m if m.name or source is None else dataclasses.replace(m, name=Path(source).stem)


def build_context(files: Sequence, *, fps: float = BUILD_FPS, features: Sequence[str] = BUILD_FEATURES,
                  progress: bool = False, label: str | None = None, prefer: str | None = None,
                  optional: Sequence = (), tell: Callable[[str], None] | None = None, joint_map: dict | None = None):
    """Build a context database from motion files; returns ``(database, notes)``.

    Every file is read (an AMC with the ASF beside it, as the readers find
    it), resampled to ``fps`` and featurised. The database takes the skeleton
    topology (joint names and parents) ``prefer`` names (a :func:`topology_id`)
    when a file is on it, else the one that holds the most clips; files on
    another topology are left out and named in one note, and the database's
    ``info["topologies"]`` lists every topology seen. A file that cannot be
    context is refused (:class:`~mocapkit.errors.MocapFormatError` naming it),
    or, when it is among ``optional`` (files found in a folder), left out and
    named in a note. ``progress`` shows a rich progress bar on stderr.
    ``label`` is stored in the database's ``info`` (what the summary says
    judged a take). ``tell``: called with one line as the build starts and one as it ends (the clips it holds of
    the files read, and the seconds it took), for a log where no bar shows (``mocapkit clean-batch``).
    ``joint_map`` ({clip joint: joint of a known rig}, ``--joint-map``): the names the clips' joints take in the
    database (:meth:`MotionDatabase.build`), for a rig whose own names say no roles (no hands, feet or head
    found for the features); a take on the clips' own names is then served by hierarchy and rest pose
    (:func:`fit_context`).
    """
    files = [Path(f) for f in files]
    if not files:
        raise MocapError("no context files given")
    t0 = time.perf_counter()
    if tell is not None:
        tell(f"building context {label or 'the context files'}: {len(files)} file{'s' if len(files) != 1 else ''}, "
             "once (cached for the next run)")
    found = {Path(f).resolve() for f in optional}
    motions, used, bad = [], [], []
    with _progress(len(files), progress) as bar:
        task = bar.add_task("", total=len(files))
        for p in files:
            bar.update(task, description=p.name)
            try:
                m = _context_take(p, fps)
            except MocapError as exc:  # a format error, or a skeleton error the reader found
                if p.resolve() not in found:
                    raise
                bad.append((p, str(exc), exc))
                bar.advance(task)
                continue
            motions.append(m)
            used.append(p)
            bar.advance(task)
    notes = []
    if bad:
        notes.append(f"context: left out {len(bad)} of {plural(len(files), 'file')} that cannot be context "
                     f"({bad[0][1]}{'; ' + _names([b[0] for b in bad[1:]]) if len(bad) > 1 else ''})")
    if not motions:
        raise bad[0][2]  # nothing left: the first file's own error
    db, notes = _database(motions, used, len(files), notes, fps, features, label or "the context files", prefer,
                          joint_map=joint_map, named=True)
    if tell is not None:
        clips = db.num_clips
        tell(f"built context {label or 'the context files'}: {clips} clip{'s' if clips != 1 else ''} of "
             f"{len(files)} file{'s' if len(files) != 1 else ''} ({time.perf_counter() - t0:.1f} s)")
    return db, notes


def motions_context(motions: Sequence, *, fps: float = BUILD_FPS, features: Sequence[str] = BUILD_FEATURES,
                    prefer: str | None = None, joint_map: dict | None = None):
    """The context database of Motions already read, built in memory as :func:`build_context` builds one from
    their files; returns ``(database, notes)``.

    Each Motion is resampled to ``fps`` (slerp) and stored as float32 (:meth:`MotionDatabase.build`), as
    the files' database is, so that cleaning with ``context=[Motion, ...]`` gives bit for bit what
    ``context=[path, ...]`` gives for the Motions read from those paths (float32 keeps about 1e-7 of a unit
    quaternion: far under a thousandth of a degree). Takes on a skeleton other than the
    chosen one (``prefer``, else the majority's) are left out and named in a note, as files are; a Motion
    with no frames or missing joints is refused (:func:`context_take`).
    """
    clips = [context_take(m, fps) for m in motions]
    names = [Path(m.name or f"context Motion {i}") for i, m in enumerate(motions)]
    return _database(clips, names, len(clips), [], fps, features, "the context Motions", prefer, joint_map=joint_map)


def _database(motions: list, used: list, total: int, notes: list, fps: float, features: Sequence[str], label: str,
              prefer: str | None, joint_map: dict | None = None, named: bool = False):
    """The database of the context clips ``motions`` (read from ``used``, of ``total`` asked for) on the topology
    ``prefer`` names when one is on it, else the majority's; the others left out with a note; ``joint_map``
    renames their joints (:meth:`MotionDatabase.build`); ``named``: ``used`` are the files read, which a clip's
    error names. Returns ``(database, notes)``."""
    from .database import MotionDatabase

    topo = [topology_id(m.skeleton) for m in motions]
    counts: dict = {}
    for t in topo:
        counts[t] = counts.get(t, 0) + 1
    majority = max(counts, key=lambda t: (counts[t], -topo.index(t)))
    best = prefer if prefer in counts else majority
    keep = [(m, p) if named else m for m, p, t in zip(motions, used, topo) if t == best]
    left = [p for p, t in zip(used, topo) if t != best]
    if left:
        why = "than this take's" if best == prefer and counts[best] < max(counts.values()) else "than the one of the others"
        notes.append(f"context: left out {len(left)} of {plural(total, 'take')} on another skeleton {why}, "
                     f"{plural(len(motions[topo.index(best)].skeleton.joint_names), 'joint')} ({_names(left)})")
    db = MotionDatabase.build(keep, fps=fps, features=tuple(features), progress=False, executor="serial",
                              joint_map=joint_map or None)
    db.info["label"] = label
    db.info["notes"] = notes
    db.info["topologies"] = sorted(counts)
    db.info["majority"] = majority
    db.info["kept"] = best  # the clips' topology as read: a joint map renames the database's
    return db, notes


def _sweep(root: Path) -> None:
    """Remove staging folders of builds killed long ago (hidden ``.build-*`` folders older than a day)."""
    try:
        entries = list(root.iterdir())
    except OSError:
        return
    now = time.time()
    for e in entries:
        try:
            if e.name.startswith(".build-") and e.is_dir() and now - e.stat().st_mtime > _STALE_S:
                shutil.rmtree(e, ignore_errors=True)
        except OSError:
            pass


def cached_context(files: Sequence, *, cache_dir=None, fps: float = BUILD_FPS, features: Sequence[str] = BUILD_FEATURES,
                   progress: bool = False, label: str | None = None, prefer: str | None = None, optional: Sequence = (),
                   build: bool = True, tell: Callable[[str], None] | None = None, joint_map: dict | None = None):
    """The context database of ``files``, built once into the cache and opened from it afterwards.

    ``cache_dir``: the cache folder (default :func:`cache_root`). The build
    goes into a hidden staging folder beside the entry and is renamed into
    place; when another process put the same key in place first, its copy is
    used and this one discarded. A cached entry that no longer opens (a disk
    fault) is rebuilt. A cache that cannot be written (read-only, full) or an
    entry another user's permissions hide does not stop the work: the build
    is used from memory, and its notes say why it was not cached. Entries get
    the permissions the umask gives a new folder, so a shared cache serves
    everyone. ``prefer``, ``optional``, ``tell`` (a line as a build starts and ends; none for an entry opened
    from the cache) and ``joint_map`` (part of the key): :func:`build_context`'s.
    Returns a :class:`~mocapkit.database.MotionDatabase` (memory-mapped when
    cached) whose ``info`` holds ``label`` and the build's notes; with ``build``
    False, None when the cache does not hold it.
    """
    from .database import MotionDatabase

    files = [Path(f) for f in files]
    try:
        root = Path(cache_dir) if cache_dir is not None else cache_root()
    except RuntimeError:  # no home folder to hold the cache (a container run under an unknown user)
        root = None
    key = context_key(files, fps, features, prefer=prefer, optional=optional, joint_map=joint_map)
    if root is None:
        if not build:
            return None
        db, _ = build_context(files, fps=fps, features=features, progress=progress, label=label, prefer=prefer,
                              optional=optional, tell=tell, joint_map=joint_map)
        return _uncached(db, "no home folder holds the context cache")
    entry = root / key
    cached, hidden = _open_entry(entry, label)
    if cached is not None:
        return cached
    if not build:
        return None
    db, _ = build_context(files, fps=fps, features=features, progress=progress, label=label, prefer=prefer,
                          optional=optional, tell=tell, joint_map=joint_map)
    if prefer is not None and db.info.get("majority") == db.info.get("kept"):
        # the take's skeleton is the folder's majority (or absent from it): the build without a preference,
        # cached under its key, so that a later request without one (a batch's first check) finds it
        key = context_key(files, fps, features, optional=optional, joint_map=joint_map)
        entry = root / key
        cached, hidden = _open_entry(entry, label)
        if cached is not None:
            return cached
    if hidden:
        return _uncached(db, f"the cache entry {entry} cannot be read ({hidden})", _HIDDEN_ADVICE)
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return _uncached(db, f"{root}: cannot create the context cache ({exc.strerror or exc})")
    _sweep(root)
    staging = root / f".build-{key}-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    try:
        db.save(staging / "db")  # the umask's folder mode, as any folder (database_folder.staging_folder)
        try:
            os.rename(staging / "db", entry)
        except OSError:
            if not _is_database(entry):  # not another process's finished copy: a real failure
                raise
    except (OSError, MocapFormatError) as exc:
        return _uncached(db, f"{entry}: cannot write the context cache ({getattr(exc, 'strerror', None) or exc})")
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    cached, hidden = _open_entry(entry, label)
    return cached if cached is not None else _uncached(db, f"the cache entry {entry} cannot be read ({hidden})", _HIDDEN_ADVICE)


def noted_missing(db, rebuild: str | None = None):
    """``db`` (an opened :class:`~mocapkit.database.MotionDatabase`) with a note among its context notes
    (``info["notes"]``) where it holds NaN poses, which mocapkit 0.14.0 and earlier kept for a take with gaps
    (:meth:`~mocapkit.database.MotionDatabase.missing_note`; ``rebuild``: how to build it anew, in words). Said, not
    refused: a search leaves their clips out. The one check of a context opened from disk, a database folder given
    (``--context DB``) and a cache entry (:func:`cached_context`) alike: an entry a 0.14.0 build cached is still
    opened under its key, and was not checked."""
    gaps = db.missing_note(rebuild)
    if gaps:
        said = db.info.get("notes")
        db.info["notes"] = [*(said if isinstance(said, list) else ()), gaps]
    return db


_REBUILD_ENTRY = "remove this cache entry to build it again (a take with gaps is then left out, named)"


def _open_entry(entry: Path, label):
    """``(database, "")`` from a cache entry; ``(None, "")`` when it is missing or damaged (a damaged entry is
    removed, to be built again); ``(None, reason)`` when it is there but this user cannot read it."""
    from .database import MotionDatabase

    if not entry.is_dir():
        return None, ""
    try:
        return noted_missing(_labelled(MotionDatabase.open(entry), label), _REBUILD_ENTRY), ""
    except PermissionError as exc:
        return None, exc.strerror or str(exc)
    except (MocapFormatError, OSError) as exc:
        if isinstance(exc.__cause__ or exc.__context__, PermissionError) or "Permission denied" in str(exc):
            return None, "Permission denied"
        shutil.rmtree(entry, ignore_errors=True)  # our own entry, damaged: build it again
        return None, ""


_HIDDEN_ADVICE = ("another user's entry, private (as mocapkit 0.1.0 made them): its owner can `chmod -R go+rX` it or "
                  "remove it")


def _uncached(db, why: str, advice: str = "set MOCAPKIT_CACHE_DIR to a writable folder"):
    """The context ``db`` as built in memory, its notes saying why it was not cached and what to do about it."""
    db.info["notes"] = [*db.info.get("notes", []), f"not cached: {why}; {advice}"]
    return db



def _labelled(db, label):
    if label:
        db.info["label"] = label
    return db


def default_context():
    """The bundled default context (:class:`~mocapkit.database.MotionDatabase`), or None when the package lacks it."""
    from .database import MotionDatabase

    p = default_context_path()
    if not _is_database(p):
        return None
    db = MotionDatabase.open(p)
    db.info["label"] = "the bundled default context"
    db.info["default"] = True
    return db


def _describe(paths: list[Path]) -> str:
    if len(paths) == 1 and paths[0].is_dir():
        return f"the takes of {paths[0]}"
    return "the context files" if len(paths) > 1 else f"the context file {paths[0]}"


def resolve_context(spec, *, default: bool = True, cache_dir=None, progress: bool = False, prefer: str | None = None,
                    tell: Callable[[str], None] | None = None, joint_map: dict | None = None):
    """What ``--context`` (or ``context=``) names, as the analysis takes it.

    ``spec`` may be None or empty (the bundled default context when
    ``default``, else None), ``False``/``"none"`` (None: the clip itself), a
    :class:`~mocapkit.database.MotionDatabase` (returned as it is), a
    Motion or a list of Motions (built in memory as their files would be,
    :func:`motions_context`, so that both give the same result bit for bit),
    a database folder (opened), or a folder of takes and/or a list of
    motion files (built once and cached, :func:`cached_context`). ``prefer``:
    the :func:`topology_id` of the take the context is for; when the files
    hold takes on it but most are on another skeleton, the context built
    from them keeps the take's. ``tell``: called with a line as a build of
    files starts and as it ends (:func:`build_context`). ``joint_map`` ({clip joint: joint of a known rig},
    ``--joint-map``): the names a build of files or Motions gives the clips' joints, for a rig whose names say no
    roles (a database folder is opened as it was built). Returns a MotionDatabase or None.
    """
    from .database import MotionDatabase
    from .motion import Motion

    if is_off(spec):
        return None
    if spec is None or (isinstance(spec, (list, tuple)) and len(spec) == 0):
        return default_context() if default else None
    if isinstance(spec, MotionDatabase):
        return spec
    if isinstance(spec, Motion):
        spec = [spec]
    if not isinstance(spec, (str, os.PathLike, list, tuple)):
        raise TypeError("context must be None, False, 'none', a MotionDatabase, a folder, or a list of files or "
                        f"Motions; got {type(spec).__name__} {spec!r:.60}")
    items = [spec] if isinstance(spec, (str, os.PathLike)) else list(spec)
    if all(isinstance(c, Motion) for c in items):
        db, _ = motions_context(items, prefer=prefer, joint_map=joint_map)  # as their files would be built: the same result bit for bit
        return db
    if not all(isinstance(c, (str, os.PathLike)) for c in items):
        raise TypeError("context must be a MotionDatabase, Motions, or paths of files and folders (not a mix)")
    paths = [Path(c) for c in items]
    if len(paths) == 1 and _is_database(paths[0]):
        db = MotionDatabase.open(paths[0])
        db.info["label"] = f"the database {paths[0]}"
        return noted_missing(db)
    files = context_files(paths)
    optional = [f for f in files if f not in paths]  # found in a folder, not named
    kw = {"cache_dir": cache_dir, "progress": progress, "label": _describe(paths), "optional": optional, "tell": tell,
          "joint_map": joint_map}
    plain = cached_context(files, build=prefer is None, **kw)  # the majority's build, when there is one
    kept = (plain.info.get("kept") or topology_id(plain.skeletons[0])) if plain is not None else None
    if plain is not None and (prefer not in plain.info.get("topologies", ()) or kept == prefer):
        return plain
    # built for the take's skeleton; when that is the majority's (or absent), cached as the plain build
    return cached_context(files, prefer=prefer, **kw)


def _rest_directions(sk) -> np.ndarray:
    """(J, 3) unit rest offsets (zero rows for joints at their parent)."""
    o = np.asarray(sk.offsets, dtype=np.float64)
    n = np.linalg.norm(o, axis=1, keepdims=True)
    return np.where(n > 1e-9 * max(float(n.max()), 1e-12), o / np.where(n > 0, n, 1.0), 0.0)


def _same_rest(a, b) -> str:
    """Empty when skeletons ``a`` and ``b`` share parents and rest bone directions, else why not."""
    if len(a.joint_names) != len(b.joint_names):
        return f"{plural(len(a.joint_names), 'joint')}, the context's {len(b.joint_names)}"
    if not np.array_equal(np.asarray(a.parents), np.asarray(b.parents)):
        return "another hierarchy (parents)"
    da, db_ = _rest_directions(a), _rest_directions(b)
    both = (np.linalg.norm(da, axis=1) > 0) & (np.linalg.norm(db_, axis=1) > 0)
    cos = np.clip(np.sum(da * db_, axis=1), -1.0, 1.0)
    worst = np.degrees(np.arccos(cos[both])).max(initial=0.0)
    if worst > REST_TOLERANCE_DEG:
        j = int(np.flatnonzero(both)[np.argmax(np.degrees(np.arccos(cos[both])))])
        return f"another rest pose: the bone to {a.joint_names[j]!r} points {worst:.0f} deg away"
    return ""


def _other_up_axis(a, b) -> str:
    """Empty when skeletons ``a`` and ``b`` stand along the same axis in their rest poses, else why not."""
    from .features import detect_up_axis

    ua, ub = detect_up_axis(a), detect_up_axis(b)
    if np.array_equal(ua, ub):
        return ""
    name = lambda v: ("-" if v.min() < 0 else "") + "xyz"[int(np.argmax(np.abs(v)))]  # noqa: E731
    return f"another rest pose: it stands along {name(ua)}, the context along {name(ub)}"


def terms_note(context) -> str:
    """One line naming the terms of the takes ``context`` holds where the project knows them (a database's
    ``info["licence"]``: :func:`mocapkit.rigs.data_terms`, e.g. the Bandai Namco set's CC BY-NC 4.0), since a
    repair draws its motion from them; "" for a context of unknown terms, clips or None."""
    info = getattr(context, "info", None)
    if not isinstance(info, dict) or not info.get("licence"):
        return ""
    return f"{context_label(context)} holds takes under {info['licence']}: a repair draws its motion from them"


def context_label(context) -> str:
    """What judged a take, for its summary: ``"the clip itself"``, ``"2 context clips"``, or the database's
    label with its size (``"the bundled default context (31 clips, 79 s)"``)."""
    if context is None:
        return "the clip itself"
    info = getattr(context, "info", None)
    if info is None:
        n = len(context) if isinstance(context, (list, tuple)) else 1
        return f"{n} context clip{'s' if n != 1 else ''}"
    size = f"{context.num_clips} clip{'s' if context.num_clips != 1 else ''}, {context.duration:.0f} s"
    return f"{info['label']} ({size})" if info.get("label") else f"a database of {size}"


def _renamed_context(context, names: tuple):
    """``context`` with its joints named ``names`` (arrays shared, nothing copied)."""
    from .database import MotionDatabase

    renamed = [dataclasses.replace(s, joint_names=names) for s in context.skeletons]
    return MotionDatabase(fps=context.fps, skeletons=renamed, clips=context.clips, rotations=context.rotations,
                          root_positions=context.root_positions, features=context.features,
                          translations=context.translations, clip_ids=context.clip_ids, path=context.path,
                          info=context.info)


def fit_context(motion, context):
    """``context`` made to serve ``motion``; returns ``(context, note)`` (note: one line, or "").

    A list of Motions and a database on the take's joint names and up axis
    come back as they are; a database built under a joint map (``info["joint_map"]``, :func:`build_context`)
    serves a take whose joints the map names as the database's, on the same up axis, renamed to the take's; so
    does a database on the take's names with a namespace set aside (``rig|lfemur``:
    :func:`mocapkit.rigs.family_names`), without a note. A database on the same topology and rest pose under other joint
    names (module docstring) comes back with its joints renamed to the take's
    (arrays shared, nothing copied) and a note saying so. Otherwise the
    bundled default context is dropped (``(None, note)``: the take is judged
    against itself) and any other context is refused with
    :class:`~mocapkit.errors.MocapError` giving the reason.
    """
    from .database import MotionDatabase
    from .rigs import family_names

    if not isinstance(context, MotionDatabase):
        return context, ""
    built = "; ".join(str(n) for n in context.info.get("notes", ()) if isinstance(n, str))
    names = tuple(motion.skeleton.joint_names)
    ref = context.skeletons[0]
    jm = context.info.get("joint_map") or {}
    mapped = tuple(jm.get(n, n) for n in names) if isinstance(jm, dict) else names
    if mapped != names and tuple(ref.joint_names) == mapped:
        # a take of the rig the context was built from under its joint map: its joints are the map's, by name
        why = _other_up_axis(dataclasses.replace(motion.skeleton, joint_names=mapped), ref)  # roles by the map
        if not why:
            return _renamed_context(context, names), "; ".join(
                n for n in (built, f"{context_label(context)}: joints named by its joint map "
                                   f"({names[1]!r} -> {mapped[1]!r}, ...)") if n)
    bare = family_names(motion.skeleton)
    if bare != names and tuple(ref.joint_names) == bare:
        # the context's names under a namespace (rig|lfemur, mocapkit.rigs.family_prefix): its joints, by name
        if not _other_up_axis(dataclasses.replace(motion.skeleton, joint_names=bare), ref):
            return _renamed_context(context, names), built
    if tuple(ref.joint_names) == names:
        # the same names on another basis (a Z-up export of a Y-up rig keeps them): the context's local rotations
        # are in the other basis; other rest differences of a rig under the same names (an actor's toes 33 deg
        # apart) serve as they did
        why = _other_up_axis(motion.skeleton, ref)
        if not why:
            return context, built
    else:
        why = _same_rest(motion.skeleton, ref)
    label = context_label(context)
    if why:
        if context.info.get("default"):
            return None, f"{label} not used: this take's joints differ from the context's ({why}); the take is judged against itself"
        raise MocapError(f"{motion.name or 'take'}: its joints differ from those of the context, {label} ({why}); "
                         "give a context on this take's skeleton" + (f" ({built})" if built else ""))
    out = _renamed_context(context, names)
    note = f"{context.info.get('label') or 'the context'}: joints matched by hierarchy and rest pose ({ref.joint_names[1]!r} -> {names[1]!r}, ...)"
    return out, "; ".join(n for n in (built, note) if n)
