"""A person decides, for a marker capture: each change ``clean`` made, accepted or rejected, and the capture with
only the accepted ones.

The marker counterpart of :mod:`mocapkit.cleaning.decisions`: the same
decisions file (:data:`~mocapkit.cleaning.decisions.FORMAT`, read by
:func:`~mocapkit.cleaning.decisions.read_decisions`), the same words
(``accept``, ``reject``), the same digest check of the take
(:func:`~mocapkit.cleaning.decisions.take_digest` of a :class:`MarkerSet`) and
the same report list (``review.js``).

Changes
-------
A change is one fix of :func:`~mocapkit.cleaning.markers.clean_markers`
(:class:`~mocapkit.cleaning.markers.MarkerFix`): a swap undone (both markers'
samples over its frames), a duplicate label or a foreign stretch removed, a spike removed, a gap
filled, with its id ``KIND:MARKER:FIRST-LAST`` (frames inclusive, 0-based), which
depends only on the record, so the same cleaning of the same capture gives the
same ids. Its samples are those of its frames and marker(s) that differ between
the input and the cleaned capture (position, residual or camera mask). A sample
two fixes touched belongs to one of them, in the order duplicate, foreign, spike, gap,
swap (a spike found on a re-labelled sample is the spike's); the changes
therefore partition the changed samples. A changed sample no fix names (none in
the test data) is a change of kind ``change`` per run of frames of its marker.

Applying decisions
------------------
:func:`apply` starts from the input: the samples of each accepted change get
the cleaned position, residual and camera mask, every other sample keeps the
input's, bit for bit (a rejected fill stays missing, with residual -1; a
rejected swap keeps the recorded labels). A change lands on the recorded
trajectory it was made for, through the swaps kept (:func:`placed`,
:mod:`~mocapkit.cleaning.markers.placement`): a spike or gap fixed inside a
rejected swap is written under the label the file gives those samples.
Changes whose samples' origin cannot be told apart from a swap's are decided
together (:func:`tied`). Rejecting every change gives the input back;
accepting every change gives the cleaned capture.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Mapping

import numpy as np

from ...errors import MocapError, MocapFormatError
from ..decisions import (ACCEPT, FORMAT, RECORD_FLAG, REJECT, review_mode, check_choices, check_decisions, frame_note, record_wanted,
                         request_difference, take_digest)
from .clean import MarkerCleanResult, MarkerFix
from .placement import destinations, relabelled, sources
from ...words import frame_span, plural

__all__ = ["MarkerChange", "differs", "changes", "accepted_samples", "tied", "TIED_WHY", "tied_lines", "placed",
           "apply", "cleaning_digest",
           "template", "same_samples", "check", "review", "record_cells", "result_from_record", "check_record", "decided_result",
           "clean_and_decide"]

_ORDER = ("duplicate", "foreign", "spike", "gap", "swap")  # who owns a sample two fixes touched


@dataclass(frozen=True)
class MarkerChange:
    """One fix of a marker capture as a person decides it: ``kind`` on ``marker`` over frames ``first``..``last``.

    ``marker_index``: its column in the capture; ``other``: the marker a swap exchanged labels with (a
    duplicate: the marker whose position it was on); ``size_mm``: :attr:`MarkerFix.size_mm` (NaN: a spike
    or duplicate removed and left missing); ``reason``: :attr:`MarkerFix.size_text`.
    """

    id: str
    marker: str
    marker_index: int
    first: int
    last: int
    kind: str
    size_mm: float
    other: str = ""
    reason: str = ""

    def size_words(self) -> str:
        if math.isnan(self.size_mm):  # a recorded sample removed and no fill written (a change fixes do not name: ?)
            return "left missing" if self.kind == "change" else "removed, left missing"
        return f"{self.size_mm:.1f} mm"

    def as_dict(self) -> dict:
        """The report's row (``review.js``: ``joint`` and ``joint_index`` name the marker, ``size`` its words)."""
        return {"id": self.id, "joint": self.marker, "joint_index": self.marker_index, "first": self.first,
                "last": self.last, "step": self.kind, "method": "", "size": self.size_words(),
                "size_mm": None if math.isnan(self.size_mm) else round(self.size_mm, 3),
                "other": self.other, "reason": self.reason}

    def __str__(self) -> str:
        with_ = f" with {self.other}" if self.other and self.kind == "swap" else ""
        return f"{self.id}: {self.marker} {frame_span(self.first, self.last)} ({self.kind}{with_}, {self.size_words()})"


def differs(original, cleaned) -> np.ndarray:
    """(F, M) bool: the samples whose position (NaN-aware), residual or camera mask differ between two captures."""
    a, b = np.asarray(original.positions), np.asarray(cleaned.positions)
    out = ~np.all((a == b) | (np.isnan(a) & np.isnan(b)), axis=-1)
    for x, y in ((original.residuals, cleaned.residuals), (original.cameras, cleaned.cameras)):
        if x is not None and y is not None:
            out |= np.asarray(x) != np.asarray(y)
        elif (x is None) != (y is None):
            out |= True
    return out


def _fix(x) -> MarkerFix:
    if isinstance(x, MarkerFix):
        return x
    names = {f.name for f in dataclasses.fields(MarkerFix)}
    return MarkerFix(**{k: v for k, v in dict(x).items() if k in names})


def _claiming(fixes: list[MarkerFix]) -> list[MarkerFix]:
    """``fixes`` in the order their samples are claimed: swaps over the same frames each next to one claimed before.

    Labels cycled at one frame are undone as k - 1 swaps over the same
    frames on k markers, a tree of exchanges: taken in the order of the
    list, a swap whose two markers earlier ones already hold would own no
    sample and could not be decided alone. Each such group is taken from
    its first swap on, each next one the first that shares one marker with
    those taken (every swap then owns the samples of the marker it adds);
    other fixes keep their places.
    """
    out, groups = [], {}
    for x in fixes:
        groups.setdefault((x.start, x.end) if x.kind == "swap" else id(x), []).append(x)
    for group in groups.values():
        held: set[str] = set()
        while group:
            nxt = next((x for x in group if len({x.marker, x.other} & held) == 1), group[0])
            group.remove(nxt)
            held |= {nxt.marker, nxt.other}
            out.append(nxt)
    return out


def _change_id(x: MarkerFix) -> str:
    return f"{x.kind}:{x.marker}:{x.start}-{x.end - 1}"


def _owners(original, cleaned, fixes) -> tuple[list[MarkerChange], np.ndarray]:
    """The changes and ``(F, M)`` int: the index of the change each sample belongs to, -1 for none."""
    labels = list(original.labels)
    col = {label: k for k, label in enumerate(labels)}
    diff = differs(original, cleaned)
    owner = np.full(diff.shape, -1, dtype=np.int64)
    found: list[MarkerChange] = []
    fixes = [_fix(x) for x in fixes if _fix(x).kind in _ORDER and _fix(x).marker in col]
    seen: dict[str, int] = {}
    for x in sorted(_claiming(fixes), key=lambda x: _ORDER.index(x.kind)):
        cols = [col[x.marker]] + ([col[x.other]] if x.kind == "swap" and x.other in col else [])
        cid = _change_id(x)
        if cid not in seen:
            seen[cid] = len(found)
            found.append(MarkerChange(cid, x.marker, col[x.marker], x.start, x.end - 1, x.kind, float(x.size_mm),
                                      x.other, x.size_text))
        take = np.zeros(diff.shape, dtype=bool)
        take[x.start:x.end, cols] = True
        owner[take & diff & (owner < 0)] = seen[cid]
    for m in np.flatnonzero(np.any(diff & (owner < 0), axis=0)):  # a change no fix names: one per run of frames
        rest = np.concatenate([[0], (diff[:, m] & (owner[:, m] < 0)).astype(np.int8), [0]])
        for a, b in zip(np.flatnonzero(np.diff(rest) == 1), np.flatnonzero(np.diff(rest) == -1)):
            owner[a:b, m] = len(found)
            found.append(MarkerChange(f"change:{labels[m]}:{a}-{b - 1}", labels[m], int(m), int(a), int(b - 1),
                                      "change", float("nan"), reason="changed by the cleaning"))
    used = sorted(set(np.unique(owner[owner >= 0]).tolist()))
    keep = sorted(used, key=lambda k: (found[k].first, found[k].marker, found[k].kind))
    remap = np.full(len(found) + 1, -1, dtype=np.int64)
    remap[keep] = np.arange(len(keep))
    return [found[k] for k in keep], remap[owner]


def changes(original, cleaned, fixes) -> list[MarkerChange]:
    """Every change of a marker cleaning, by first frame then marker (module docstring).

    ``original``, ``cleaned``: the capture before and after (:class:`MarkerSet`, same labels and frames);
    ``fixes``: :attr:`MarkerCleanResult.fixes` or a record's fix dicts. Fixes that changed no sample are not listed.
    """
    return _owners(original, cleaned, fixes)[0]


def accepted_samples(original, cleaned, fixes, decisions: Mapping[str, str]) -> np.ndarray:
    """(F, M) bool: the samples of the changes ``decisions`` accepts (a change it does not name is accepted), in
    the cleaned capture's labelling (:func:`placed` says where each lands in the capture written).

    Raises ValueError for an id that is not a change of this cleaning or a choice other than accept/reject.
    """
    found, owner = _owners(original, cleaned, fixes)
    check_choices(decisions, {c.id for c in found})
    chosen = [k for k, c in enumerate(found) if decisions.get(c.id, ACCEPT) == ACCEPT]
    return np.isin(owner, chosen)


def _swaps(original, fixes) -> list[MarkerFix]:
    col = set(original.labels)
    return [x for x in (_fix(y) for y in fixes) if x.kind == "swap" and x.marker in col and x.other in col]


def _region(x: MarkerFix, labels: list, shape) -> np.ndarray:
    """(F, M) bool: the cells of a swap fix (both markers over its frames)."""
    r = np.zeros(shape, dtype=bool)
    r[x.start:x.end, [labels.index(x.marker), labels.index(x.other)]] = True
    return r


def _under(x, r, found, owner, swaps, regions) -> set[int]:
    """The changes a swap with no change of its own (its samples all another's) is decided with: those owning
    samples in its cells ``r`` and the swaps listed as changes whose cells overlap them."""
    index = {c.id: k for k, c in enumerate(found)}
    on = set(np.unique(owner[r & (owner >= 0)]).tolist())
    return on | {index[_change_id(y)] for y, q in zip(swaps, regions) if _change_id(y) in index and np.any(q & r)}


def _tied(original, cleaned, found, owner, swaps, src) -> list[list[int]]:
    """The groups of changes (indices into ``found``) that are decided together: where the cleaned samples of a
    swap are not its markers' recorded samples exchanged (:func:`~mocapkit.cleaning.markers.placement.sources`
    does not give the cleaning's labelling there: chained swaps no order of undoing one at a time gives, or a record
    whose chained swaps were listed as the cleaning's own column exchanges rather than by
    :func:`~mocapkit.cleaning.markers.swaps.recorded_swaps`), where a change's samples came from cannot be told, so that swap and every change on its markers over its frames, grown to every change
    overlapping those, go together; and a swap fix that owns no change of its own goes with the changes
    :func:`_under` it. Empty where every swap is its markers' samples exchanged and a change."""
    labels = list(original.labels)
    pos, res, cams = relabelled(original, src)
    inner = np.isin(owner, [k for k, c in enumerate(found) if c.kind != "swap"])
    odd = differs(SimpleNamespace(positions=pos, residuals=res, cameras=cams), cleaned)
    odd &= ~inner & (src != np.arange(len(labels)))
    regions = [_region(x, labels, owner.shape) for x in swaps]
    groups: list[set[int]] = [_under(x, r, found, owner, swaps, regions) for x, r in zip(swaps, regions)
                              if _change_id(x) not in {c.id for c in found}]
    for r0 in (r for r in regions if np.any(r & odd)):
        area, ids = r0.copy(), set()
        while True:
            grown = set(np.unique(owner[area & (owner >= 0)]).tolist())
            new_area = area | np.isin(owner, list(grown))
            for r in regions:
                if np.any(r & new_area):
                    new_area |= r
            if grown == ids and np.array_equal(new_area, area):
                break
            area, ids = new_area, grown
        groups.append(ids)
    merged: list[set[int]] = []
    for g in groups:
        for m in [m for m in merged if m & g]:
            merged.remove(m)
            g = g | m
        merged.append(g)
    return [sorted(g) for g in merged if len(g) > 1]


TIED_WHY = ("the swaps among them exchange labels over shared frames in a way no order of undoing them one at a "
            "time gives, so where each change's samples came from cannot be told, and undoing one alone could put a "
            "trajectory under another marker's label")
"""Why :func:`tied` changes go together, in words: what the report's list and the console say."""


def tied_lines(original, cleaned, fixes) -> list[str]:
    """One line per group of :func:`tied` changes, naming them and saying why (:data:`TIED_WHY`): what a cleaning's
    console says beside its summary, so that a person knows before deciding."""
    return [f"{', '.join(g)}: accepted or rejected together, as {TIED_WHY}" for g in tied(original, cleaned, fixes)]


def tied(original, cleaned, fixes) -> list[list[str]]:
    """The ids of the changes a person accepts or rejects together (the report's list ties them), by group;
    empty for a cleaning whose every swap is its markers' recorded samples exchanged (every cleaning of the test
    captures). Within a group, a split decision is refused (:func:`placed`)."""
    found, owner = _owners(original, cleaned, fixes)
    swaps = _swaps(original, fixes)
    src = sources(swaps, list(original.labels), original.num_frames)
    return [[found[k].id for k in g] for g in _tied(original, cleaned, found, owner, swaps, src)]


def placed(original, cleaned, fixes, decisions: Mapping[str, str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each accepted change lands: ``(take, src, dest)``, each (F, M).

    ``take`` (bool): the cleaned cells whose cleaned sample is written; ``src`` (int): the input column each
    cleaned column holds (:func:`~mocapkit.cleaning.markers.placement.sources` of every swap); ``dest`` (int): the
    column of the capture written each cleaned cell goes to, through the swaps kept
    (:func:`~mocapkit.cleaning.markers.placement.destinations`). A spike or gap fixed inside a rejected swap thus
    lands on the recorded trajectory it was made for, under the label the file gives it; a spike rejected inside
    an accepted swap keeps its recorded samples, re-labelled. Every cell not taken gets the input's sample from
    ``src``: the samples of every rejected change are the input's, bit for bit.

    Raises ValueError, naming the changes, for decisions that split a group :func:`tied` ties (where a change's
    samples came from cannot be told there, and nothing is placed on a guess).
    """
    found, owner = _owners(original, cleaned, fixes)
    check_choices(decisions, {c.id for c in found})
    choice = [decisions.get(c.id, ACCEPT) for c in found]
    labels = list(original.labels)
    swaps = _swaps(original, fixes)
    src = sources(swaps, labels, original.num_frames)
    for g in _tied(original, cleaned, found, owner, swaps, src):
        if len({choice[k] for k in g}) > 1:
            ids = [found[k].id for k in g]
            raise ValueError(f"{', '.join(ids)} are decided apart, but {TIED_WHY}: accept or reject them together")
    index = {c.id: k for k, c in enumerate(found)}
    regions = [_region(x, labels, owner.shape) for x in swaps]

    def swap_kept(x, r) -> bool:  # a swap with no change of its own: as the changes it is decided with (tied: alike)
        if _change_id(x) in index:
            return choice[index[_change_id(x)]] == ACCEPT
        return all(choice[k] == ACCEPT for k in _under(x, r, found, owner, swaps, regions))

    kept = sources([x for x, r in zip(swaps, regions) if swap_kept(x, r)], labels, original.num_frames)
    dest = destinations(src, kept)
    same = dest == np.arange(len(labels))
    take = np.isin(owner, [k for k, c in enumerate(choice) if c == ACCEPT]) | ((owner < 0) & same)
    return take, src, dest


def _put(values: np.ndarray, dest: np.ndarray) -> np.ndarray:
    """``values`` (F, M, ...) moved column-wise to ``dest`` (F, M): ``out[f, dest[f, c]] = values[f, c]``."""
    out = np.empty_like(values)
    out[np.arange(dest.shape[0])[:, None], dest] = values
    return out


def apply(original, cleaned, fixes, decisions: Mapping[str, str]):
    """The input capture with only the accepted changes: a :class:`MarkerSet` like ``original``.

    The samples of accepted changes hold ``cleaned``'s positions, residuals and camera masks, in the column of the
    recorded trajectory they were made for (:func:`placed`); every other sample is ``original``'s, bit for bit.
    Raises ValueError as :func:`placed` does.
    """
    take, src, dest = placed(original, cleaned, fixes, decisions)
    base = relabelled(original, src)
    got = [None if b is None else _put(np.where(take[..., None] if b.ndim == 3 else take, np.asarray(c), b), dest)
           for b, c in zip(base, (cleaned.positions, cleaned.residuals, cleaned.cameras))]
    return dataclasses.replace(original, positions=got[0], residuals=got[1], cameras=got[2])


def cleaning_digest(original, cleaned) -> str:
    """SHA-256 (hex) of what a person reviews of a marker cleaning: which samples it changed (:func:`differs`) and
    their cleaned positions, residuals and camera masks.

    The change ids alone do not tell two cleanings apart: the capture cleaned again with another ``--max-gap`` or
    ``--max-fill-error`` can give the same ids and other fills. Decisions keep this digest (:func:`template`) and
    apply only to a cleaning with it (:func:`check`): the record the report was made from, or a new cleaning
    giving the very same samples (cleaning is deterministic).
    """
    cells = differs(original, cleaned)
    h = hashlib.sha256(json.dumps([list(original.labels), list(cells.shape)]).encode())
    h.update(np.packbits(cells).tobytes())
    for name, a in (("positions", cleaned.positions), ("residuals", cleaned.residuals),
                    ("cameras", cleaned.cameras)):
        if a is not None:
            v = np.ascontiguousarray(np.asarray(a)[cells], dtype="<f8")
            h.update(name.encode() + np.where(np.isnan(v), np.nan, v).tobytes())  # one bit pattern for every NaN
    return h.hexdigest()


def template(original, found: list[MarkerChange], take: str = "", output: str = "",
             decisions: Mapping[str, str] | None = None, cleaned=None, request=None, record="") -> dict:
    """The decisions document for ``found`` (every change "accept" unless ``decisions`` says otherwise).

    With ``cleaned`` (the capture ``found`` lists the changes of) it keeps ``"cleaning"``: the
    :func:`cleaning_digest`, the number of changes, the options asked for (``request``) and the ``record`` it was
    written to, so that the decisions apply to that cleaning only and a refusal can say what to pass.
    """
    from ... import __version__

    chosen = dict(decisions or {})
    doc = {"format": FORMAT, "mocapkit": __version__,
           "take": {"name": take or original.name, "frames": original.num_frames, "markers": original.num_markers,
                    "sha256": take_digest(original)},
           "output": output}
    if cleaned is not None:
        doc["cleaning"] = {"sha256": cleaning_digest(original, cleaned), "changes": len(found), "request": request,
                           "record": str(record) if record else ""}
    doc["decisions"] = {c.id: chosen.get(c.id, ACCEPT) for c in found}
    return doc


def same_samples(chosen: Mapping[str, str], found: list[MarkerChange]) -> dict:
    """``chosen`` with each id of kind ``change`` renamed to the change of ``found`` on the same marker and frames,
    and each id of ``found``'s ``change`` rows likewise from the fix a decisions file names there.

    Before 0.17.0 a spike removed beside a gap left missing was in no fix, so its change was ``change:M:A-B``
    ("changed by the cleaning"); a cleaning now names it ``spike:M:A-B``. The cleaning's digest
    (:func:`cleaning_digest`) is of the samples alone, so it matches both: a decisions file made from a 0.16.0
    report is honoured on a new cleaning, and a new file on a 0.16.0 record, as the same samples' decision. Any
    other unknown id is left for :func:`check` to refuse.
    """
    ids = {c.id for c in found}
    where: dict[tuple, list[str]] = {}
    for c in found:
        where.setdefault((c.marker, c.first, c.last), []).append(c.id)
    out = {}
    for key, choice in chosen.items():
        kind, _, rest = key.partition(":")
        marker, _, frames = rest.rpartition(":")
        first, _, last = frames.partition("-")
        same = where.get((marker, int(first), int(last)), []) if first.isdigit() and last.isdigit() else []
        if key not in ids and len(same) == 1 and same[0] not in chosen and "change" in (kind, same[0].partition(":")[0]):
            key = same[0]
        out[key] = choice
    return out


def check(doc: dict, path, original, cleaned=None, fixes=(), *, request=None, fresh: bool = False,
          option: str = RECORD_FLAG) -> dict:
    """The choices of ``doc`` (:func:`~mocapkit.cleaning.decisions.read_decisions`) checked against this capture
    (its digest) and, with ``cleaned``, this cleaning; refused in one line naming ``path``.

    Against a cleaning: every id must be one of its changes; a ``doc`` keeping ``"cleaning"`` (made by the report)
    applies only to a cleaning with that :func:`cleaning_digest` and must name every change (one left out was
    taken out by hand: nobody reviewed it); a ``doc`` without it (written by hand) is refused for a new cleaning
    (``fresh``; ``request``: its options, named in the refusal) and taken on its ids for a record.
    """
    chosen = check_decisions(doc, path, original)
    if cleaned is None:
        return chosen
    stamp = doc.get("cleaning")
    if stamp is not None and stamp.get("sha256") != cleaning_digest(original, cleaned):
        want = record_wanted(stamp, option)
        diff = request_difference(stamp.get("request"), request, option) if fresh else ""
        raise MocapFormatError(path, f"made on another cleaning than {'this new one' if fresh else 'this record'}: "
                                     f"{diff or 'its changed samples differ'}; apply them to the reviewed samples: "
                                     f"{want}")
    chosen = same_samples(chosen, changes(original, cleaned, fixes))
    try:
        accepted_samples(original, cleaned, fixes, chosen)
    except ValueError as exc:
        raise MocapFormatError(path, f"{exc} (decisions made for another cleaning of the capture?)") from None
    try:
        placed(original, cleaned, fixes, chosen)
    except ValueError as exc:
        raise MocapFormatError(path, str(exc)) from None
    if stamp is None:
        if fresh:
            raise MocapFormatError(path, "keeps no digest of the cleaning it was made on (written by hand?): a new "
                                         "cleaning may differ from the one reviewed; give that cleaning's record "
                                         f"with {option}")
        return chosen
    left = [c.id for c in changes(original, cleaned, fixes) if c.id not in chosen]
    if left:
        raise MocapFormatError(path, f"names {len(chosen)} of the {plural(len(chosen) + len(left), 'change')} it was made for; "
                                     f"{len(left)} not named ({left[0]!r}...): a change nobody reviewed is not applied")
    return chosen


def review(original, cleaned, fixes, take: str = "", output: str = "", decisions: Mapping[str, str] | None = None,
           first_frame: int | None = None, flags: list | None = None, request=None, record="",
           command: dict | None = None) -> dict:
    """What the report's accept/reject list needs (:func:`mocapkit.cleaning.decisions.review`'s form): ``changes``
    (a change :func:`tied` to others names them all in ``"tied"`` and says why in ``"tied_why"``: the list accepts
    or rejects them together),
    the ``decisions`` document (stamped with this cleaning, ``request`` its options and ``record`` where its record
    was written: :func:`template`), ``flags`` (none for a marker capture unless given), ``frames``, ``item`` and
    ``command`` (:func:`mocapkit.cleaning.decided.apply_command`)."""
    found = changes(original, cleaned, fixes)
    together = {i: g for g in tied(original, cleaned, fixes) for i in g}
    return {"changes": [{**c.as_dict(), **({"tied": together[c.id], "tied_why": TIED_WHY} if c.id in together else {})}
                        for c in found],
            "decisions": template(original, found, take, output, decisions, cleaned=cleaned, request=request,
                                  record=record),
            "flags": list(flags or []), "frames": frame_note(take, first_frame), "item": "marker", "command": command}


# -- the record's cleaned samples --------------------------------------------------------------


def record_cells(original, cleaned) -> dict:
    """The npz members a record keeps so that decisions apply without cleaning again: ``cells`` (F, M) bool
    (:func:`differs`), ``cell_positions`` (N, 3) float64, ``cell_residuals`` and ``cell_cameras`` (N,) where the
    capture has them, and ``take_sha256`` (:func:`~mocapkit.cleaning.decisions.take_digest` of ``original``)."""
    cells = differs(original, cleaned)
    out = {"cells": cells, "cell_positions": np.asarray(cleaned.positions)[cells],
           "take_sha256": np.array(take_digest(original))}
    if cleaned.residuals is not None:
        out["cell_residuals"] = np.asarray(cleaned.residuals)[cells]
    if cleaned.cameras is not None:
        out["cell_cameras"] = np.asarray(cleaned.cameras)[cells]
    return out


def check_record(original, record, path) -> None:
    """Refuse, in one line naming ``path``, a marker record that is not of ``original`` or keeps no cleaned samples."""
    if tuple(record.labels) != tuple(original.labels) or record.num_frames != original.num_frames:
        raise MocapFormatError(path, f"the clean record is of another capture ({plural(record.num_frames, 'frame')}, "
                                     f"{plural(len(record.labels), 'marker')}; this one has {original.num_frames} and "
                                     f"{original.num_markers})")
    if record.cells is None:
        raise MocapFormatError(path, "this record keeps no cleaned samples (written by an earlier mocapkit): "
                                     "clean the capture again to apply decisions")
    if record.take_sha256 != take_digest(original):
        raise MocapFormatError(path, "the clean record is of another capture (the same markers and frames, but "
                                     "other samples than this one's)")


def result_from_record(original, record) -> MarkerCleanResult:
    """The :class:`MarkerCleanResult` a record (:func:`~mocapkit.cleaning.markers.record.read_marker_record`,
    checked with :func:`check_record`) keeps for ``original``: the cleaned capture rebuilt from its cells."""
    if record.cells is None:
        raise MocapError("the clean record keeps no cleaned samples; clean the capture again")
    cells = record.cells
    pos = np.array(original.positions)
    pos[cells] = record.cell_positions
    res, cams = original.residuals, original.cameras
    if res is not None and record.cell_residuals is not None:
        res = np.array(res)
        res[cells] = record.cell_residuals
    if cams is not None and record.cell_cameras is not None:
        cams = np.array(cams)
        cams[cells] = record.cell_cameras
    cleaned = dataclasses.replace(original, positions=pos, residuals=res, cameras=cams)
    f = original.num_frames
    return MarkerCleanResult(markers=cleaned, original=original, filled=record.filled, spikes=record.spikes,
                             swapped=record.swapped, fixes=tuple(_fix(x) for x in record.fixes),
                             never_seen=record.never_seen, unseen_start=(0, 0), unseen_end=(f, f),
                             unlabelled=record.unlabelled, unfilled=tuple(_fix(x) for x in record.unfilled),
                             duplicates=record.duplicates, coincident=tuple(_fix(x) for x in record.coincident),
                             nobody_seen=record.nobody_seen)


# -- review mode and decisions, one path for the library and the CLI ------------------------------


def _relabelled_fix(x: MarkerFix, dest: np.ndarray, labels: list) -> MarkerFix:
    """``x`` named by the marker whose column its samples land in (:func:`placed`) where a rejected swap around it
    leaves them under another label over all its frames (a fix split over two columns keeps its name)."""
    col = {label: k for k, label in enumerate(labels)}
    if x.kind == "swap" or x.marker not in col or x.end <= x.start:
        return x
    moved = {}
    for field in ("marker", "other"):
        k = col.get(getattr(x, field))
        to = None if k is None else np.unique(dest[x.start:x.end, k])
        if to is not None and to.size == 1 and to[0] != k:
            moved[field] = labels[int(to[0])]
    return dataclasses.replace(x, **moved) if moved else x


def decided_result(original, result: MarkerCleanResult, decisions: Mapping[str, str], decided=None
                   ) -> MarkerCleanResult:
    """``result`` with only the changes ``decisions`` accepts: what a person's decisions give back.

    ``markers`` is :func:`apply`'s capture; ``filled``, ``spikes``, ``swapped`` and ``duplicates`` keep only the
    accepted changes' samples, ``fixes`` (and a removed spike left missing in ``unfilled``) only the accepted
    changes', each in the column its samples are written to (:func:`placed`: under the label a rejected swap
    leaves them), so that a report or summary of it shows the capture written, not the whole cleaning;
    ``decided``: the :class:`~mocapkit.cleaning.decided.Decided` kept on it (its :meth:`~MarkerCleanResult.summary`).
    """
    acc = accepted_samples(original, result.markers, result.fixes, decisions)
    take, _, dest = placed(original, result.markers, result.fixes, decisions)
    rejected = {c.id for c in changes(original, result.markers, result.fixes) if decisions.get(c.id) == REJECT}
    labels = list(original.labels)

    def kept(x) -> bool:
        return _change_id(x) not in rejected

    def mask(m):
        return _put(np.asarray(m) & acc & take, dest)

    return dataclasses.replace(
        result, markers=apply(original, result.markers, result.fixes, decisions), filled=mask(result.filled),
        spikes=mask(result.spikes), swapped=mask(result.swapped), duplicates=mask(result.duplicate_mask),
        fixes=tuple(_relabelled_fix(x, dest, labels) for x in result.fixes if kept(x)),
        unfilled=tuple(_relabelled_fix(x, dest, labels) for x in result.unfilled if kept(x)), decided=decided)


def clean_and_decide(original, *, name="", steps=None, max_gap_s=None, max_error_mm=None, decisions=None,
                     record=None, review: bool = False, request=None, take: str = "", option: str = RECORD_FLAG,
                     progress=None) -> tuple[MarkerCleanResult, MarkerCleanResult]:
    """A marker capture cleaned (or its earlier ``record`` read back), then reviewed or decided: the one path of
    ``mocapkit.clean`` and ``mocapkit clean`` for a marker capture.

    ``original``: the capture (:class:`MarkerSet`), ``name`` what a refusal names it by (its file); ``steps``,
    ``max_gap_s``, ``max_error_mm``: :func:`~mocapkit.cleaning.markers.clean_markers`'s. ``decisions``: a
    decisions file or its document as a dict (:func:`mocapkit.cleaning.decide.decisions_document`), checked against the capture before any
    cleaning and against the cleaning after (:func:`check`: the digest of the cleaning reviewed, every change
    named); ``record``: the ``.clean.npz`` of an earlier cleaning, reused (needs ``decisions``); ``review``: review
    mode, nothing changed (not with ``decisions``). ``request``: the options asked for
    (:func:`mocapkit.marker_files.marker_request`), named where a new cleaning's digest differs; ``take``: the
    input's file name for the summary; ``option``: how a refusal names the record to give (the CLI's ``--record``,
    :func:`mocapkit.clean`'s ``record=``); ``progress``: :func:`~mocapkit.cleaning.markers.clean_markers`'s.

    Returns ``(cleaning, given)``: the whole cleaning (what a record keeps) and what comes back: the cleaning in
    review mode (``review=True``), :func:`decided_result` with decisions, else the cleaning itself. Every refusal is
    one line naming the file (:class:`~mocapkit.errors.MocapError`).
    """
    from ..decide import decisions_document
    from ..decided import for_markers
    from .clean import STEPS, clean_markers
    from .record import read_marker_record

    name = name or original.name or "the capture"
    if record is not None and decisions is None:
        raise MocapError(f"{record}: an earlier run's record is applied with decisions; give the decisions file")
    if review and decisions is not None:
        raise MocapError(f"{name}: review mode ({review_mode(option)}) changes nothing; decisions apply to a cleaning")
    path, doc = decisions_document(decisions) if decisions is not None else (None, None)
    if doc is not None:
        check(doc, path, original)  # decisions for another capture: refused before any cleaning
    if record is not None:
        rec = read_marker_record(record)
        check_record(original, rec, record)  # the record against the capture first, then the decisions against it
        res = result_from_record(original, rec)
    else:
        try:
            res = clean_markers(original, steps=steps or STEPS, max_gap_s=max_gap_s, max_error_mm=max_error_mm,
                                progress=progress)
        except ValueError as exc:
            raise MocapError(f"{name}: {exc}") from None
    if review:
        return res, dataclasses.replace(res, review=True)
    if doc is None:
        return res, res
    chosen = check(doc, path, original, res.markers, res.fixes, request=request, fresh=record is None, option=option)
    said = for_markers(doc, path, original, res, chosen, record=record, take=take)
    return res, decided_result(original, res, chosen, said)
