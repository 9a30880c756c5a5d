"""MotionDatabase: many clips stacked along frames, with features, saved on disk and memory-mapped.

A database is the unit of "knowledge" that similarity search, self-similarity
cleaning and reconstruction compare a motion against (Krüger et al. 2010,
sec. 3-5). It is packed arrays plus clip ranges:

* every clip is resampled to one frame rate; frame ``i`` of the database has
  a clip (:attr:`MotionDatabase.clip_ids`) and a frame number in it, and
  consecutive frames of one clip have consecutive indices, so a path in a
  neighbourhood graph may step ``i -> i + 1`` exactly when
  ``clip_ids[i] == clip_ids[i + 1]`` (never across a clip boundary);
* rotations ``(N, J, 4)`` and root positions ``(N, 3)`` are stored as float32
  (1e-7 relative precision; :meth:`MotionDatabase.clip` returns float64
  Motions), features ``(N, D)`` as float64 in centimetres so clips of rigs in
  different units compare;
* all clips share one skeleton topology (joint names and parents). Bone
  lengths may differ (several actors); a clip of another topology is
  rejected unless a joint map says how its joints correspond;
* :meth:`MotionDatabase.save` writes a directory of ``.npy`` files plus a JSON
  description; :meth:`MotionDatabase.open` memory-maps them, so a
  million-frame database opens in milliseconds and worker processes share
  the pages instead of copying them.

Indexes (kd-trees) are built from a database on demand
(:meth:`MotionDatabase.index`) and never stored in it.
"""

from __future__ import annotations

import dataclasses
import json
import os
import warnings
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

from .database_folder import FORMAT_VERSION, FPS_RANGE, Description, check_database_output, content_digest, read_folder, skeleton_to_json, write_folder
from .errors import MocapError, MocapFormatError
from .features import FEATURE_SETS, WINDOWED_SETS, feature_set
from .io.outputs import same_file
from .mirroring import mirror_for_rig
from .motion import Motion, Skeleton, readonly_view
from .rigs import data_terms
from .search.matches import Match
from .words import plural

__all__ = ["MotionDatabase", "ClipInfo", "SearchResult", "FORMAT_VERSION", "FPS_RANGE", "SUFFIXES", "check_database_output", "expand_sources", "read_joint_map"]

#: File suffixes a database is built from (C3D marker files hold no skeleton motion).
SUFFIXES = (".bvh", ".amc", ".npz")


@dataclass(frozen=True)
class ClipInfo:
    """One clip of a database: its name, where it came from, and its frame range.

    ``start`` is the database index of its first frame; it covers
    ``start .. start + frames - 1``. ``skeleton`` indexes
    :attr:`MotionDatabase.skeletons`.
    """

    name: str
    source: str
    start: int
    frames: int
    skeleton: int
    mirrored: bool = False

    @property
    def stop(self) -> int:
        """One past the last database index of the clip."""
        return self.start + self.frames


#: :meth:`MotionDatabase.search` returns no segment more than this many times shorter or longer than the query
MAX_WARP = 3.0


@dataclass(frozen=True, eq=False)
class SearchResult:
    """A database segment similar to a query: clip, first and last frame (at the database rate), cost.

    ``match`` keeps the database-index form with the warping path (rows
    ``(query frame, database frame)``, query frames at the database rate).
    """

    clip: int
    name: str
    start: int
    end: int
    cost: float
    match: Match

    def as_dict(self) -> dict:
        return {"clip": self.clip, "name": self.name, "start": self.start, "end": self.end, "cost": self.cost}


# -- skeleton topology ----------------------------------------------------------------------------


def _topology(sk: Skeleton) -> tuple:
    return tuple(sk.joint_names), tuple(int(p) for p in sk.parents)


def _topology_difference(sk: Skeleton, ref: tuple) -> str:
    names, parents = _topology(sk)
    rnames, rparents = ref
    if len(names) != len(rnames):
        return f"{plural(len(names), 'joint')}, the database has {len(rnames)}"
    for j, (a, b) in enumerate(zip(names, rnames)):
        if a != b:
            return f"joint {j} is {a!r}, the database's is {b!r}"
    for j, (a, b) in enumerate(zip(parents, rparents)):
        if a != b:
            return f"joint {names[j]!r} has another parent"
    return ""


# -- preparing one clip (runs in worker processes) --------------------------------------------


def _check_features(features: Sequence[str]) -> tuple[str, ...]:
    names = tuple(features)
    if not names:
        raise ValueError("features: at least one feature set is needed (e.g. ('F15',))")
    known = list(FEATURE_SETS) + list(WINDOWED_SETS)
    for n in names:
        if n not in known:
            raise ValueError(f"unknown feature set {n!r}; known: {', '.join(known)}")
    return names


def _retarget(m: Motion, ref_skeleton: Skeleton, joint_map: Mapping[str, str], source: str) -> Motion:
    """Copy local rotations joint by joint onto the reference topology (rest poses assumed to agree)."""
    rnames = ref_skeleton.joint_names
    src = {n: j for j, n in enumerate(m.skeleton.joint_names)}
    rot = np.zeros((m.num_frames, len(rnames), 4))
    rot[..., 0] = 1.0
    mapped = 0
    inverse = {v: k for k, v in joint_map.items()}
    for j, name in enumerate(rnames):
        s = inverse.get(name, name if name in src else None)
        if s is None:
            continue
        if s not in src:
            raise MocapFormatError(source, f"joint map names {s!r}, which the clip's skeleton lacks")
        rot[:, j] = m.rotations[:, src[s]]
        mapped += 1
    root_src = inverse.get(rnames[0], rnames[0])
    if root_src not in src:
        raise MocapFormatError(source, f"joint map does not map the database root {rnames[0]!r}")
    scale = 1.0
    if m.skeleton.unit_cm and ref_skeleton.unit_cm:
        scale = m.skeleton.unit_cm / ref_skeleton.unit_cm
    return Motion(ref_skeleton, rot, m.root_positions * scale, m.fps, m.name)


def _renamed(m: Motion, joint_map: Mapping[str, str], source: str) -> Motion:
    """``m`` with the joints ``joint_map`` names (clip joint -> database joint) renamed, rotations untouched.

    Joints the map does not name keep their names; a clip that lacks every joint the map names (one already
    on the database's names) comes back as it is. Two joints renamed alike are refused naming ``source``."""
    names = tuple(joint_map.get(n, n) for n in m.skeleton.joint_names)
    if names == tuple(m.skeleton.joint_names):
        return m
    if len(set(names)) != len(names):
        twice = sorted({n for n in names if names.count(n) > 1})
        raise MocapFormatError(source, f"the joint map gives two of the clip's joints the name {twice[0]!r}")
    return dataclasses.replace(m, skeleton=dataclasses.replace(m.skeleton, joint_names=names))


def read_joint_map(path) -> dict:
    """The joint map a JSON file holds (``--joint-map``): an object {clip joint: database joint}, e.g.
    ``{"kt_b04": "Hand_L"}``, which names a rig's joints after a rig of known naming so that its roles (hands,
    feet, head) are found. A file that is not such an object is refused in one line naming it."""
    path = Path(path)
    try:
        jm = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise MocapFormatError(path, f"not a readable JSON joint map ({exc})") from None
    if not isinstance(jm, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in jm.items()):
        raise MocapFormatError(path, "a joint map is a JSON object of joint name -> joint name")
    return jm


def _prepare(item, fps: float, features: tuple[str, ...], mirror: bool, ref_skeleton: Skeleton | None, joint_map,
             amc: dict | None = None) -> list[dict]:
    """Load (if a path), check, resample and featurise one clip; with ``mirror`` also its mirror image.

    ``item``: a Motion, a path, ``(path to read, source to keep)`` or ``(Motion, the file it was read from)``;
    ``amc``: ``{"asf": ..., "fps": ...}`` for an ``.amc`` file (:func:`mocapkit.io.takes.load_take`). ``joint_map``
    (clip joint -> database joint) renames every clip's joints first, the first clip's included, so that a rig
    whose names say no roles gets its features on the names the map gives."""
    from .io.takes import load_take

    if isinstance(item, Motion):
        m, source = item, f"<motion {item.name}>"
    elif isinstance(item, tuple) and isinstance(item[0], Motion):
        m, source = item[0], str(item[1])
    else:
        path, source = (Path(item[0]), str(item[1])) if isinstance(item, tuple) else (Path(item), str(item))
        m = load_take(path, **(amc or {}))
        if not isinstance(m, Motion):
            raise MocapFormatError(path, "a marker file holds no skeleton motion and cannot go into a motion database")
    if m.num_frames == 0:
        raise MocapFormatError(source, "the clip has no frames")
    gaps = m.missing().any(axis=1)
    if gaps.any():  # NaN poses and features: a search would drop the clip, a reconstruction fail naming its query
        n = int(gaps.sum())
        raise MocapFormatError(source, f"{n} frame{'s have' if n != 1 else ' has'} missing joints (NaN); fill the "
                                       "gaps first (mocapkit fill) to put the take in a motion database")
    if joint_map:
        m = _renamed(m, joint_map, source)
    if ref_skeleton is not None:
        diff = _topology_difference(m.skeleton, _topology(ref_skeleton))
        if diff:
            if joint_map is None:
                raise MocapFormatError(
                    source, f"skeleton differs from the database's ({diff}); pass a joint map to retarget it"
                )
            m = _retarget(m, ref_skeleton, {}, source)  # its joints renamed by the map: equal names map
    m = m.resample(fps)
    out = []
    for mirrored in (False, True) if mirror else (False,):
        # a mirrored clip's rotations must fit the skeleton every clip's poses are reused on: on a rig whose
        # joints' rest frames differ by side the mirror image keeps the clip's own skeleton
        mm = mirror_for_rig(m) if mirrored else m
        try:
            feats = {n: feature_set(mm, n, scale_cm=True).values for n in features}
        except MocapError as exc:
            raise MocapFormatError(source, f"cannot compute features: {exc}") from None
        except KeyError as exc:  # the features' end effectors (hands, feet, head) found by role: none here
            raise MocapFormatError(source, f"cannot compute features {', '.join(features)}: "
                                           f"{exc.args[0] if exc.args else exc}; give a joint map onto a rig of "
                                           "known naming (--joint-map; joint_map= from Python)") from None
        tr = None if mm.translations is None else _float32(mm.translations, "joint translations", source)
        out.append(
            {
                "name": m.name + (" (mirrored)" if mirrored else ""),
                "source": source,
                "mirrored": mirrored,
                "skeleton": mm.skeleton,
                "rotations": mm.rotations.astype(np.float32),
                "root_positions": _float32(mm.root_positions, "root positions", source),
                "translations": tr,
                "features": feats,
            }
        )
    return out


def _float32(values: np.ndarray, what: str, source) -> np.ndarray:
    """``values`` as float32, the database's storage type; a finite value beyond float32's range is refused
    (it would be stored as infinity) with one line naming the clip."""
    with np.errstate(over="ignore"):
        out = values.astype(np.float32)
    if np.isinf(out).any() and not np.isinf(values[np.isinf(out)]).all():
        raise MocapFormatError(source, f"{what} beyond {float(np.finfo(np.float32).max):.3g} file units: "
                                       "not a motion a database can hold")
    return out


def _in_memory(item) -> bool:
    """True for a clip already read: a Motion, or ``(Motion, the file it was read from)``."""
    return isinstance(item, Motion) or (isinstance(item, tuple) and bool(item) and isinstance(item[0], Motion))


def expand_sources(sources) -> list:
    """The clips ``sources`` names: Motions as given, files checked, folders searched recursively.

    ``sources`` is one path or Motion, or a sequence of them. Returns Motions
    and paths of :data:`SUFFIXES` files (a folder's sorted by path), each
    file once however many times it is named (directly, through its folder,
    through a link); raises :class:`~mocapkit.errors.MocapFormatError` for a
    missing path, a file of another kind, or a folder without motion files.
    """
    if isinstance(sources, (str, os.PathLike, Motion)):
        sources = [sources]
    items: list = []
    seen: set = set()

    def add(path: Path) -> None:
        key = path.resolve()
        if key not in seen:  # a file given and also found in a folder given went in twice (its matches twice)
            seen.add(key)
            items.append(path)

    for s in sources:
        if isinstance(s, Motion) or (isinstance(s, tuple) and s and isinstance(s[0], Motion)):
            items.append(s)
            continue
        p = Path(s)
        if p.is_dir():
            found = sorted(q for q in p.rglob("*") if q.suffix.lower() in SUFFIXES and q.is_file())
            if not found:
                raise MocapFormatError(p, f"the folder holds no motion files ({', '.join(SUFFIXES)})")
            for q in found:
                add(q)
        elif p.is_file():
            if p.suffix.lower() not in SUFFIXES:
                raise MocapFormatError(p, f"cannot go into a motion database (expected {', '.join(SUFFIXES)})")
            add(p)
        else:
            raise MocapFormatError(p, "no such file or folder")
    if not items:
        raise ValueError("no clips given")
    return items


# -- the database -------------------------------------------------------------------------------


class MotionDatabase:
    """Clips stacked along frames at one frame rate, with their features (see the module docstring).

    Build one with :meth:`build`, keep it with :meth:`save`, reopen it with
    :meth:`open`. Arrays are read-only.

    Attributes
    ----------
    fps : float
    skeletons : tuple of Skeleton
        The distinct skeletons (one topology, possibly several bone lengths).
    clips : tuple of ClipInfo
    rotations : float32 array (N, J, 4)
        Local joint rotations, w first.
    root_positions : float32 array (N, 3)
        File units of each clip's skeleton.
    features : dict of str -> float64 array (N, D)
        Krüger's feature sets in centimetres (:func:`mocapkit.features.feature_set`).
    clip_ids : int32 array (N,)
        Clip number of each frame.
    path : Path or None
        The directory it was opened from.
    digest : str
        Identity of the content (:func:`mocapkit.database_folder.content_digest`):
        read from ``database.json`` when opened, else computed once on first use.

    Examples
    --------
    >>> from mocapkit import samples
    >>> db = MotionDatabase.build([samples.path("12_walk.amc")], fps=30, mirror=True, progress=False)
    >>> db
    MotionDatabase(2 clips, 172 frames @ 30 fps, features F15)
    >>> db.clip_names
    ('12_walk', '12_walk (mirrored)')
    >>> db.locate(100), db.index_of("12_walk (mirrored)", 14)
    ((1, 14), 100)
    """

    def __init__(
        self,
        *,
        fps: float,
        skeletons: Sequence[Skeleton],
        clips: Sequence[ClipInfo],
        rotations: np.ndarray,
        root_positions: np.ndarray,
        features: Mapping[str, np.ndarray],
        translations: np.ndarray | None = None,
        clip_ids: np.ndarray | None = None,
        path: Path | None = None,
        info: Mapping | None = None,
        digest: str = "",
    ):
        self.fps = float(fps)
        self.skeletons = tuple(skeletons)
        self.clips = tuple(clips)
        N = int(rotations.shape[0])
        starts = np.array([c.start for c in self.clips] + [N], dtype=np.int64)
        if len(self.clips) == 0 or starts[0] != 0 or np.any(np.diff(starts) != [c.frames for c in self.clips]):
            raise ValueError("clips must tile the frames 0..N-1 in order")
        if root_positions.shape != (N, 3):
            raise ValueError(f"root_positions: expected shape ({N}, 3), got {root_positions.shape}")
        for name, f in features.items():
            if f.ndim != 2 or f.shape[0] != N:
                raise ValueError(f"features[{name!r}]: expected shape ({N}, D), got {f.shape}")
        self.rotations = readonly_view(rotations)
        self.root_positions = readonly_view(root_positions)
        self.translations = None if translations is None else readonly_view(translations)
        self.features = {k: readonly_view(v) for k, v in features.items()}
        self.clip_starts = readonly_view(starts)
        if clip_ids is None:
            clip_ids = np.repeat(np.arange(len(self.clips), dtype=np.int32), [c.frames for c in self.clips])
        self.clip_ids = readonly_view(clip_ids)
        self.path = path
        self.info = dict(info or {})
        self._indexes: dict = {}
        self._digest = digest  # the folder's stored content digest; "" until computed
        self._missing: int | None = None  # frames with a NaN pose (missing_frames), counted on first use

    # -- sizes and lookups ---------------------------------------------------------------

    @property
    def num_frames(self) -> int:
        return int(self.rotations.shape[0])

    @property
    def num_clips(self) -> int:
        return len(self.clips)

    @property
    def num_joints(self) -> int:
        return int(self.rotations.shape[1])

    @property
    def feature_names(self) -> tuple[str, ...]:
        return tuple(self.features)

    @property
    def clip_names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.clips)

    @property
    def duration(self) -> float:
        """Total length in seconds."""
        return self.num_frames / self.fps

    def __len__(self) -> int:
        return self.num_frames

    def __repr__(self) -> str:
        return (
            f"MotionDatabase({self.num_clips} clips, {self.num_frames} frames @ {self.fps:g} fps, "
            f"features {', '.join(self.feature_names)})"
        )

    def clip_number(self, clip) -> int:
        """The clip number of ``clip`` given as a number or a name."""
        if isinstance(clip, (int, np.integer)):
            c = int(clip)
            if not 0 <= c < self.num_clips:
                raise IndexError(f"clip {c} out of range for {plural(self.num_clips, 'clip')}")
            return c
        for k, info in enumerate(self.clips):
            if info.name == clip:
                return k
        raise KeyError(f"no clip named {clip!r} in the database")

    def locate(self, index):
        """(clip number, frame in clip) of database frame(s) ``index`` (int or int array)."""
        idx = np.asarray(index, dtype=np.int64)
        if np.any((idx < 0) | (idx >= self.num_frames)):
            raise IndexError(f"database frame out of range 0..{self.num_frames - 1}")
        clip = self.clip_ids[idx].astype(np.int64)
        frame = idx - self.clip_starts[clip]
        if idx.ndim == 0:
            return int(clip), int(frame)
        return clip, frame

    def index_of(self, clip, frame: int) -> int:
        """Database frame index of ``frame`` of ``clip`` (number or name)."""
        c = self.clip_number(clip)
        info = self.clips[c]
        if not 0 <= frame < info.frames:
            raise IndexError(f"frame {frame} out of range for clip {info.name!r} ({plural(info.frames, 'frame')})")
        return info.start + int(frame)

    def clip_range(self, clip) -> tuple[int, int]:
        """Half-open database range ``[start, stop)`` of a clip."""
        info = self.clips[self.clip_number(clip)]
        return info.start, info.stop

    def excluded_frames(self, exclude, mirrors: bool = True) -> np.ndarray | None:
        """The database frames (bool, N) that the half-open range ``exclude = (lo, hi)`` bans from a search; None for None.

        With ``mirrors``, every clip the range covers whole also bans its
        mirror twin (``NAME`` and ``NAME (mirrored)`` of one source, built
        with ``mirror=True``): a leave-one-out search with
        ``exclude=db.clip_range(NAME)`` would otherwise find the query's own
        mirror image.
        """
        if exclude is None:
            return None
        lo, hi = (int(x) for x in np.asarray(exclude, dtype=np.int64).reshape(2))
        banned = np.zeros(self.num_frames, dtype=bool)
        banned[max(lo, 0) : max(hi, 0)] = True
        if mirrors:
            whole = {(c.source, c.name.removesuffix(" (mirrored)")) for c in self.clips if lo <= c.start and c.stop <= hi}
            for c in self.clips:
                if (c.source, c.name.removesuffix(" (mirrored)")) in whole:
                    banned[c.start : c.stop] = True
        return banned

    # -- motions out ------------------------------------------------------------------------

    def segment(self, start: int, stop: int, name: str | None = None) -> Motion:
        """Database frames ``start .. stop-1`` (within one clip) as a float64 Motion."""
        if not 0 <= start < stop <= self.num_frames:
            raise IndexError(f"segment [{start}, {stop}) out of range 0..{self.num_frames}")
        c = int(self.clip_ids[start])
        if int(self.clip_ids[stop - 1]) != c:
            raise ValueError(f"segment [{start}, {stop}) crosses a clip boundary")
        info = self.clips[c]
        rot = np.asarray(self.rotations[start:stop], dtype=np.float64)
        rot /= np.linalg.norm(rot, axis=-1, keepdims=True)
        tr = None if self.translations is None else np.asarray(self.translations[start:stop], dtype=np.float64)
        if tr is not None and np.isnan(tr).all():
            tr = None
        if name is None:
            a, b = start - info.start, stop - 1 - info.start
            name = info.name if (a == 0 and b == info.frames - 1) else f"{info.name}[{a}:{b + 1}]"
        return Motion(
            self.skeletons[info.skeleton],
            rot,
            np.asarray(self.root_positions[start:stop], dtype=np.float64),
            self.fps,
            name,
            translations=tr,
        )

    def clip(self, clip) -> Motion:
        """A whole clip (number or name) as a float64 Motion at the database's frame rate."""
        start, stop = self.clip_range(clip)
        return self.segment(start, stop)

    # -- features and indexes -----------------------------------------------------------------

    def _feature_name(self, name: str | None) -> str:
        if name is None:
            return self.feature_names[0]
        if name not in self.features:
            raise KeyError(f"the database has no feature set {name!r}; it has {', '.join(self.feature_names)}")
        return name

    def query_features(self, motion: Motion, name: str | None = None) -> np.ndarray:
        """Features of ``motion`` computed as the database's were: resampled to :attr:`fps`, centimetres.

        Returns float array (F', D) with F' frames at the database rate.
        """
        name = self._feature_name(name)
        return feature_set(motion.resample(self.fps), name, scale_cm=True).values

    def index(self, features: str | None = None, backend: str = "kdtree", **options):
        """The :class:`~mocapkit.search.knn.KNNIndex` over a feature set, built on first use and cached."""
        from .search.knn import KNNIndex

        name = self._feature_name(features)
        key = (name, backend, tuple(sorted(options.items())))
        if key not in self._indexes:
            self._indexes[key] = KNNIndex(self.features[name], backend=backend, **options)
        return self._indexes[key]

    # -- similarity search (Krüger sec. 4.1, 5.1) ----------------------------------------------------

    def _results(self, matches: Iterable[Match]) -> list[SearchResult]:
        out = []
        for mt in matches:
            c, a = self.locate(mt.start)
            out.append(SearchResult(c, self.clips[c].name, a, a + mt.end - mt.start, mt.cost, mt))
        return out

    def search(
        self,
        query,
        k: int = 10,
        features: str | None = None,
        neighbors: int = 128,
        method: str = "lng",
        exclude=None,
        max_neighbors: int = 2048,
        max_warp: float = MAX_WARP,
        exclude_mirrors: bool = True,
    ) -> list[SearchResult]:
        """Numerical similarity search: the ``k`` best non-overlapping segments similar to ``query``.

        With ``method="lng"`` (default) the lazy neighbourhood graph on the
        ``neighbors`` nearest frames of every query frame (Krüger sec. 4.1,
        O(m log n)); with ``method="dtw"`` exact subsequence DTW (O(mn), the
        reference). Costs are sums of Euclidean feature distances (cm) along
        the warping path.

        Parameters
        ----------
        query : Motion or float array (M, D)
            A motion (resampled and featurised like the database) or
            precomputed query features.
        k : int
            Number of results.
        features : str, optional
            Feature set (default: the database's first).
        neighbors : int
            Neighbourhood size K of the graph. When fewer than ``k`` matches
            are found, K grows fourfold up to ``max_neighbors``: a query
            unlike the database may have no chain of consecutive neighbours
            at small K (the LNG finds only paths through reported neighbours).
        method : {"lng", "dtw"}
        exclude : (lo, hi), optional
            Half-open database range no result may use (e.g. the query's own
            clip); a clip it covers whole takes its mirror twin with it
            (:meth:`excluded_frames`) unless ``exclude_mirrors=False``.
        max_neighbors : int
            Largest neighbourhood the LNG may grow to.
        max_warp : float
            A segment more than ``max_warp`` times shorter or longer than the
            query is not returned (:data:`MAX_WARP`): the classic DTW steps let
            a path stay on one database frame (or one query frame) for any
            number of steps, so a 2.5 s query "matched" a single held frame
            where fewer than ``k`` real matches exist.
        exclude_mirrors : bool
            See ``exclude``.

        Fewer than ``k`` results come with a :class:`UserWarning` saying why.
        """
        results, why = self._search(query, k, features, neighbors, method, exclude, max_neighbors, max_warp, exclude_mirrors)
        if len(results) < k:
            warnings.warn(f"{len(results)} of the {k} matches asked for: {why}", UserWarning, stacklevel=2)
        return results

    def _search(self, query, k, features, neighbors, method, exclude, max_neighbors, max_warp, exclude_mirrors=True):
        """:meth:`search`'s results and the reason, in words, why there may be fewer than ``k``."""
        from .search import dtw, lng

        name = self._feature_name(features)
        q = self.query_features(query, name) if isinstance(query, Motion) else np.asarray(query, dtype=np.float64)
        data = self.features[name]
        if q.ndim != 2 or q.shape[1] != data.shape[1]:
            raise ValueError(f"query features: expected shape (M, {data.shape[1]}), got {q.shape}")
        if not max_warp >= 1.0:
            raise ValueError(f"max_warp must be at least 1, got {max_warp!r}")

        def kept(found):  # segments of a plausible speed against the query's length
            return [mt for mt in found if len(q) <= max_warp * (mt.end - mt.start + 1) <= max_warp**2 * len(q)]

        if method not in ("lng", "dtw"):
            raise ValueError(f"method must be 'lng' or 'dtw', got {method!r}")
        banned = self.excluded_frames(exclude, exclude_mirrors)
        if method == "lng":
            # A query unlike anything in the database can leave the neighbourhoods without a
            # chain of consecutive frames: widen them (x4) until k matches exist or max_neighbors.
            K = min(int(neighbors), self.num_frames)
            while True:
                dist, idx = self._neighbours(name, q, K, banned)
                matches = kept(lng.lazy_neighborhood_graph(idx, dist, self.clip_ids, k=2 * k))
                if len(matches) >= k or K >= min(max_neighbors, self.num_frames):
                    break
                K = min(4 * K, max_neighbors, self.num_frames)
            why = (f"the lazy neighbourhood graph found no more chains of neighbouring frames at up to {K} neighbours "
                   f"per query frame (max_neighbors; method='dtw' searches every segment), and segments more than "
                   f"max_warp={max_warp:g} times shorter or longer than the query are not returned")
        else:
            matches = kept(dtw.subsequence_dtw(q, data, self.clip_ids, k=2 * k, exclude=banned))
            why = (f"no other segment of the database{' outside exclude' if banned is not None else ''} lasts between "
                   f"1/{max_warp:g} and {max_warp:g} times the query's {len(q)} frames (max_warp)")
        return self._results(matches[:k]), why

    def _neighbours(self, name: str, q: np.ndarray, K: int, banned: np.ndarray | None):
        """The ``K`` nearest database frames (dist, idx: (M, K), inf / -1 where missing) of each query row, none ``banned``."""
        if banned is None or not banned.any():
            return self.index(name).query(q, k=K)
        n_banned = int(banned.sum())
        d, i = self.index(name).query(q, k=min(K + n_banned, self.num_frames))
        bad = (i >= 0) & banned[np.clip(i, 0, None)]
        d, i = np.where(bad, np.inf, d), np.where(bad, -1, i)
        order = np.argsort(d, axis=1, kind="stable")
        return np.take_along_axis(d, order, axis=1)[:, :K], np.take_along_axis(i, order, axis=1)[:, :K]

    def logical_search(
        self,
        query,
        k: int = 10,
        iterations: int = 2,
        features: str | None = None,
        neighbors: int = 128,
        max_cost_ratio: float = 2.0,
    ) -> list[SearchResult]:
        """Logical similarity search by iteration (Krüger sec. 5.1, after Kovar and Gleicher 2004).

        The segments found for the query become queries themselves, and so
        on for ``iterations`` rounds. Every round-one segment is kept; a later
        segment is kept when its cost per query frame is at most
        ``max_cost_ratio`` times the largest per-frame cost of round one (so a
        round-one hit on the query itself, at cost 0, does not shut the door).
        Every returned segment lasts between 1/:data:`MAX_WARP` and
        :data:`MAX_WARP` times the user's query (as :meth:`search`'s, with
        ``max_warp`` 3): a later round's segment is judged against ``query``,
        not against the segment it was found for, which may itself be a third
        as long (a 30-frame query returned 4-frame segments in round two). A
        segment outside these lengths is neither returned nor searched with.
        Returns all kept segments, non-overlapping, ranked by cost per frame
        of the query that found them.
        """
        name = self._feature_name(features)
        q0 = self.query_features(query, name) if isinstance(query, Motion) else np.asarray(query, dtype=np.float64)
        data = self.features[name]
        found: list[tuple[float, SearchResult]] = []
        frontier = [q0]
        bound = np.inf
        for round_ in range(max(1, iterations)):
            new_frontier = []
            for q in frontier:
                for r in self._search(q, k, name, neighbors, "lng", None, 2048, MAX_WARP)[0]:
                    per_frame = r.cost / max(len(q), 1)
                    length = r.match.end - r.match.start + 1  # against the user's query, not this round's
                    if not len(q0) <= MAX_WARP * length <= MAX_WARP**2 * len(q0):
                        continue
                    if per_frame > bound or any(r.match.overlaps(f.match) for _, f in found):
                        continue
                    found.append((per_frame, r))
                    new_frontier.append(np.asarray(data[r.match.start : r.match.end + 1]))
            if round_ == 0:
                bound = max_cost_ratio * max([pf for pf, _ in found] + [1e-9])
            frontier = new_frontier
            if not frontier:
                break
        found.sort(key=lambda t: t[0])
        return [r for _, r in found]

    # -- building -------------------------------------------------------------------------------

    @classmethod
    def build(
        cls,
        sources,
        fps: float = 30,
        features: Sequence[str] = ("F15",),
        mirror: bool = False,
        joint_map: Mapping[str, str] | None = None,
        executor=None,
        progress: bool = True,
        asf=None,
        amc_fps: float | None = None,
        executor_option: str = "executor=",
    ) -> "MotionDatabase":
        """Build a database from files, folders (searched recursively) and/or Motions.

        Every clip is resampled to ``fps`` (slerp), featurised with the named
        feature sets (centimetres), and with ``mirror=True`` also added as its
        mirror image. Clips whose skeleton topology differs from the first
        clip's are rejected with :class:`~mocapkit.errors.MocapFormatError`
        unless ``joint_map`` (clip joint name -> database joint name; unnamed
        joints map by equal name) says how to copy their local rotations —
        which is only right when the rest poses agree. The map renames every
        clip's joints, the first clip's included, so a rig whose joint names
        say no roles (``kt_a01``, ...) gets its features on the names it maps to.

        Loading and featurising runs on ``executor`` (:mod:`mocapkit.parallel`:
        local processes by default, ``"dask"`` or a scheduler address for a
        Dask cluster; ``executor_option``: how a refusal of it names the option, Python's ``executor=`` or
        ``db build``'s ``--executor``). ``asf`` and ``amc_fps``: the skeleton and frame rate of
        the ``.amc`` files among the sources (:func:`mocapkit.io.takes.load_take`;
        by default the ASF beside each and :func:`mocapkit.io.asfamc.amc_rate`); either given
        where no source is an ``.amc`` file is refused (:func:`mocapkit.io.takes.check_asf`), not ignored.
        """
        from .parallel import map_ordered

        fps = float(fps)
        if not FPS_RANGE[0] <= fps <= FPS_RANGE[1]:
            raise ValueError(f"fps must be between {FPS_RANGE[0]:g} and {FPS_RANGE[1]:g}, got {fps!r}")
        features = _check_features(features)
        # a file goes out absolute (a remote Dask worker resolves a relative path against its own working folder),
        # with the path as given, which the clip keeps as its source
        items = [it if _in_memory(it) else (os.path.abspath(it), str(it)) for it in expand_sources(sources)]
        if asf is not None or amc_fps is not None:  # an AMC's skeleton and rate: refused where no source is an AMC
            from .io.takes import check_asf

            check_asf(asf, [it[0] for it in items if not _in_memory(it)], amc_fps)
        amc = {"asf": None if asf is None else os.path.abspath(asf), "fps": amc_fps}
        first = _prepare(items[0], fps, features, mirror, None, joint_map, amc)
        ref = first[0]["skeleton"]
        job = partial(_prepare, fps=fps, features=features, mirror=mirror, ref_skeleton=ref, joint_map=joint_map,
                      amc=amc)
        # files are loaded and featurised on the executor; Motions already in memory stay here
        file_slots = [k for k in range(1, len(items)) if not _in_memory(items[k])]
        loaded = map_ordered(job, [items[k] for k in file_slots], executor=executor, progress=progress, desc="clips",
                             done=1, option=executor_option)  # the first clip, read here for the reference skeleton
        prepared: list = [first] + [None] * (len(items) - 1)
        for k, group in zip(file_slots, loaded):
            prepared[k] = group
        for k in range(1, len(items)):
            if prepared[k] is None:
                prepared[k] = job(items[k])
        entries = [e for group in prepared for e in group]
        return cls._stack(entries, fps, features, info={"mirror": mirror, "joint_map": dict(joint_map or {})})

    @classmethod
    def _stack(cls, entries: list[dict], fps: float, features: tuple[str, ...], info: dict) -> "MotionDatabase":
        N = sum(e["rotations"].shape[0] for e in entries)
        J = entries[0]["rotations"].shape[1]
        rot = np.empty((N, J, 4), dtype=np.float32)
        root = np.empty((N, 3), dtype=np.float32)
        any_tr = any(e["translations"] is not None for e in entries)
        tr = np.full((N, J, 3), np.nan, dtype=np.float32) if any_tr else None
        feats = {n: np.empty((N, entries[0]["features"][n].shape[1])) for n in features}
        skeletons: list[Skeleton] = []
        keys: dict[str, int] = {}
        clips = []
        names_seen: dict[str, int] = {}
        a = 0
        for e in entries:
            F = e["rotations"].shape[0]
            key = json.dumps(skeleton_to_json(e["skeleton"]), sort_keys=True)
            if key not in keys:
                keys[key] = len(skeletons)
                skeletons.append(e["skeleton"])
            name = e["name"]
            if name in names_seen:  # clip names are unique keys: number repeats
                names_seen[name] += 1
                name = f"{name} #{names_seen[name]}"
            else:
                names_seen[name] = 1
            clips.append(ClipInfo(name, e["source"], a, F, keys[key], e["mirrored"]))
            rot[a : a + F] = e["rotations"]
            root[a : a + F] = e["root_positions"]
            if tr is not None and e["translations"] is not None:
                tr[a : a + F] = e["translations"]
            for n in features:
                feats[n][a : a + F] = e["features"][n]
            a += F
        terms = data_terms(skeletons)  # the Bandai Namco takes' CC BY-NC 4.0, kept in database.json and said by info
        info = {**info, "licence": terms} if terms else info
        return cls(fps=fps, skeletons=skeletons, clips=clips, rotations=rot, root_positions=root, features=feats, translations=tr, info=info)

    # -- saving and opening ---------------------------------------------------------------------

    @property
    def digest(self) -> str:
        """The content digest (:func:`mocapkit.database_folder.content_digest`): a cache key that changes with any sample.

        Free for a database saved by this mocapkit and opened (``database.json``
        keeps it); otherwise its arrays are hashed once (about 1 GB/s) and the
        result kept.
        """
        if not self._digest:
            self._digest = content_digest(*self._folder_parts())
        return self._digest

    def _folder_parts(self) -> tuple[Description, dict]:
        """The description (without digest) and the arrays, keyed by file, that :meth:`save` writes."""
        desc = Description(
            fps=self.fps,
            num_frames=self.num_frames,
            skeletons=self.skeletons,
            clips=tuple((c.name, c.source, c.start, c.frames, c.skeleton, c.mirrored) for c in self.clips),
            features={n: int(f.shape[1]) for n, f in self.features.items()},
            info=self.info,
        )
        arrays = {"rotations.npy": self.rotations, "root_positions.npy": self.root_positions, "clip_ids.npy": self.clip_ids}
        if self.translations is not None:
            arrays["translations.npy"] = self.translations
        arrays.update({f"features/{n}.npy": f for n, f in self.features.items()})
        return desc, arrays

    def save(self, directory, overwrite: bool = False, inputs: Iterable = ()) -> Path:
        """Write the database to the folder ``directory`` (created; replaced only with ``overwrite``).

        Layout (:mod:`mocapkit.database_folder`): ``database.json`` (frame
        rate, skeletons, clips, feature sets), ``rotations.npy``,
        ``root_positions.npy``, ``clip_ids.npy``, ``features/<name>.npy`` and,
        when some clip animates joint offsets, ``translations.npy``.

        ``directory`` is first checked by :func:`check_database_output`
        against ``inputs`` (the paths the database was built from): it may not
        be, lie in or hold an input, and an existing folder is replaced only
        with ``overwrite`` and only when it is a mocapkit database. The folder
        is written beside the target and renamed into place; an old database
        is deleted only after the new one is in place, so an interrupted save
        leaves the old or the new database, never a partial one. Returns
        ``directory`` as a Path.
        """
        if self.path is not None and same_file(directory, self.path):
            raise MocapFormatError(directory, "cannot save a database over the folder it is opened from")
        desc, arrays = self._folder_parts()
        write_folder(directory, desc._replace(digest=self.digest), arrays, inputs=inputs, overwrite=overwrite)
        return Path(directory)

    @classmethod
    def open(cls, directory, mmap: bool = True) -> "MotionDatabase":
        """Open a database written by :meth:`save`; arrays are memory-mapped read-only unless ``mmap=False``.

        The folder is checked in full before any array is mapped
        (:func:`mocapkit.database_folder.read_folder`: the description's
        size, nesting, version and every field, each ``.npy`` header against
        the description and the file's size); any fault is one
        :class:`~mocapkit.errors.MocapFormatError` line naming the file.
        """
        directory = Path(directory)
        desc, arrays = read_folder(directory, mmap=mmap)
        try:
            return cls(
                fps=desc.fps,
                skeletons=desc.skeletons,
                clips=[ClipInfo(*c) for c in desc.clips],
                rotations=arrays["rotations.npy"],
                root_positions=arrays["root_positions.npy"],
                features={n: arrays[f"features/{n}.npy"] for n in desc.features},
                translations=arrays.get("translations.npy"),
                clip_ids=arrays["clip_ids.npy"],
                path=directory,
                info=desc.info,
                digest=desc.digest,
            )
        except ValueError as exc:
            raise MocapFormatError(directory, f"inconsistent database ({exc})") from None

    # -- summary -------------------------------------------------------------------------------------

    def summary(self) -> dict:
        """Sizes and contents as a JSON-friendly dict (what ``mocapkit db info`` prints)."""
        sizes = np.array([c.frames for c in self.clips])
        nbytes = self.rotations.nbytes + self.root_positions.nbytes + sum(f.nbytes for f in self.features.values())
        return {
            "path": None if self.path is None else str(self.path),
            "clips": self.num_clips,
            "mirrored_clips": sum(c.mirrored for c in self.clips),
            "frames": self.num_frames,
            "fps": self.fps,
            "duration_s": round(self.duration, 3),
            "joints": self.num_joints,
            "skeletons": len(self.skeletons),
            "features": {n: int(f.shape[1]) for n, f in self.features.items()},
            "feature_unit": "cm",
            "clip_frames_min_median_max": [int(sizes.min()), int(np.median(sizes)), int(sizes.max())],
            "array_megabytes": round(nbytes / 2**20, 1),
            **({"licence": str(self.info["licence"])} if self.info.get("licence") else {}),
        }

    # -- poses a database of an earlier mocapkit may hold --------------------------------------------

    def missing_frames(self) -> int:
        """How many of the database's frames hold a missing joint (a NaN rotation or root position).

        ``db build`` refuses a take with gaps since 0.15.0, but mocapkit 0.14.0 and earlier stored such a take's
        missing joints as NaN poses (and NaN features): a search leaves their clips out and a reconstruction may fail
        on them. Read once, in blocks of 65,536 frames (an opened database's arrays are memory-mapped), and kept.
        """
        if self._missing is None:
            n, step = 0, 1 << 16
            for a in range(0, self.num_frames, step):
                rot = np.asarray(self.rotations[a:a + step])
                bad = np.isnan(rot.reshape(len(rot), -1)).any(axis=1)
                bad |= np.isnan(np.asarray(self.root_positions[a:a + step])).any(axis=1)
                n += int(np.count_nonzero(bad))
            self._missing = n
        return self._missing

    def missing_note(self, rebuild: str | None = None) -> str:
        """One line for a ``note:``, naming the database and how many frames have missing joints (NaN poses an
        earlier mocapkit kept: :meth:`missing_frames`) and how to rebuild it without them; "" when none has.
        ``rebuild``: how, in words, where it is not a database folder the user built (a context cache entry:
        :func:`mocapkit.context.noted_missing`)."""
        n = self.missing_frames()
        if not n:
            return ""
        name = self.path if self.path is not None else "the database"
        return (f"{name}: {plural(n, 'frame')} of {self.num_frames} {'has' if n == 1 else 'have'} missing joints "
                "(NaN), kept by mocapkit 0.14.0 or earlier; a search leaves their clips out and a reconstruction may fail: "
                + (rebuild or "rebuild it from the takes filled (`mocapkit fill`; `db build` refuses a take with gaps)"))
