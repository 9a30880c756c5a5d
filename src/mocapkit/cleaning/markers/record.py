"""The record ``clean`` writes beside a cleaned marker capture (``OUT_STEM.clean.npz``), read back.

:meth:`~mocapkit.cleaning.markers.clean.MarkerCleanResult.save` writes it: the
(F, M) masks of the samples filled, removed as spikes, re-labelled and changed,
the labels, the fixes, the gaps left unfilled and the runs where two markers
coincide and which is the copy was not told (JSON texts), the markers
never seen, the unlabelled trajectories, the frames where nobody (of a subject) is seen, and ``kind = "markers"``, which
tells it from a motion's record (:class:`~mocapkit.cleaning.clean_record.CleanResult`).
It holds no trajectories: the cleaned capture is the output file.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import MocapFormatError

__all__ = ["MarkerRecord", "read_marker_record", "is_marker_record"]

_MASKS = ("filled", "spikes", "swapped", "changed")


@dataclass(frozen=True)
class MarkerRecord:
    """A marker capture's cleaning record.

    ``labels`` (M,); ``filled``, ``spikes``, ``swapped``, ``changed``: bool (F, M) masks of the samples
    filled, removed as spikes, re-labelled and changed; ``duplicates``: the samples removed as duplicate labels
    (a marker on another's position; all False in a record written before there was such a fix); ``fixes``,
    ``unfilled`` and ``coincident``: one dict per fix, per gap left missing and per run of two markers at the
    same position left as recorded (the fields of :class:`~mocapkit.cleaning.markers.clean.MarkerFix`);
    ``never_seen`` and ``unlabelled``: marker names; ``nobody_seen``: ``(subject, start, end)`` runs of frames
    where none of a subject's markers is seen, left missing (() in a record written before they were kept).
    ``cells`` (F, M) bool, ``cell_positions`` (N, 3), ``cell_residuals`` and ``cell_cameras`` (N,): the cleaned
    values of the samples that differ from the input, and ``take_sha256`` the input's digest, so that decisions
    apply without cleaning again (:mod:`mocapkit.cleaning.markers.decisions`; None and "" in an older record).
    """

    labels: tuple[str, ...]
    filled: np.ndarray
    spikes: np.ndarray
    swapped: np.ndarray
    changed: np.ndarray
    fixes: tuple[dict, ...]
    unfilled: tuple[dict, ...]
    never_seen: tuple[str, ...]
    unlabelled: tuple[str, ...]
    duplicates: np.ndarray | None = None
    coincident: tuple[dict, ...] = ()
    nobody_seen: tuple[tuple[str, int, int], ...] = ()
    cells: np.ndarray | None = None
    cell_positions: np.ndarray | None = None
    cell_residuals: np.ndarray | None = None
    cell_cameras: np.ndarray | None = None
    take_sha256: str = ""

    @property
    def num_frames(self) -> int:
        return int(self.changed.shape[0])

    def count(self, kind: str) -> int:
        """How many fixes of ``kind`` ("gap", "spike", "swap", "duplicate", "foreign") the record lists."""
        return sum(1 for f in self.fixes if f.get("kind") == kind)


def is_marker_record(arrays: dict) -> bool:
    """Whether the npz members ``arrays`` (name -> array, or a set of names with ``kind`` read) are a marker record."""
    kind = arrays.get("kind") if isinstance(arrays, dict) else None
    return kind is not None and np.asarray(kind).shape == () and str(np.asarray(kind)) == "markers"


def read_marker_record(path) -> MarkerRecord:
    """Read a marker capture's ``.clean.npz`` (bounded: :func:`mocapkit.io.npz.load_arrays`, no pickles).

    Raises :class:`~mocapkit.errors.MocapFormatError` naming ``path`` for an npz that is no marker record, or
    whose masks and labels disagree in shape.
    """
    from ...io.npz import load_arrays

    path = Path(path)
    z = load_arrays(path)
    if not is_marker_record(z):
        raise MocapFormatError(path, "not a marker capture's cleaning record (no kind 'markers')")
    missing = [k for k in (*_MASKS, "labels") if k not in z]
    if missing:
        raise MocapFormatError(path, f"a marker cleaning record without {', '.join(missing)}")
    labels = tuple(str(x) for x in np.asarray(z["labels"]).reshape(-1))
    masks = {}
    for k in _MASKS:
        a = np.asarray(z[k])
        if a.dtype != bool or a.ndim != 2 or a.shape[1] != len(labels) or a.shape != np.shape(z["changed"]):
            raise MocapFormatError(path, f"{k}: expected a bool (frames, {len(labels)}) mask, got {a.dtype} {a.shape}")
        masks[k] = a
    if "duplicates" in z:
        a = np.asarray(z["duplicates"])
        if a.dtype != bool or a.shape != masks["changed"].shape:
            raise MocapFormatError(path, f"duplicates: expected a bool (frames, {len(labels)}) mask, got {a.dtype} {a.shape}")
        masks["duplicates"] = a
    else:
        masks["duplicates"] = np.zeros_like(masks["changed"])

    def listed(key: str) -> tuple[dict, ...]:
        if key not in z:
            return ()
        try:
            items = json.loads(str(np.asarray(z[key])))
        except ValueError:
            raise MocapFormatError(path, f"{key}: not the JSON list a record holds") from None
        if not isinstance(items, list) or not all(isinstance(x, dict) for x in items):
            raise MocapFormatError(path, f"{key}: not the JSON list a record holds")
        return tuple(items)

    def names(key: str) -> tuple[str, ...]:
        return tuple(str(x) for x in np.asarray(z[key]).reshape(-1)) if key in z else ()

    absent = ()
    if "nobody_seen" in z:
        try:
            runs = json.loads(str(np.asarray(z["nobody_seen"])))
            absent = tuple((str(w), int(a), int(b)) for w, a, b in runs)
        except (ValueError, TypeError):
            raise MocapFormatError(path, "nobody_seen: not the JSON list of [subject, start, end] a record holds") from None
    samples = _cells(path, z, masks["changed"].shape)
    return MarkerRecord(**samples, labels=labels, fixes=listed("fixes"), unfilled=listed("unfilled"), coincident=listed("coincident"),
                        never_seen=names("never_seen"), unlabelled=names("unlabelled"), nobody_seen=absent, **masks)


def _cells(path, z: dict, shape: tuple) -> dict:
    """The record's cleaned samples (:func:`mocapkit.cleaning.markers.decisions.record_cells`), checked; {} without."""
    if "cells" not in z:
        return {}
    cells = np.asarray(z["cells"])
    if cells.dtype != bool or cells.shape != shape:
        raise MocapFormatError(path, f"cells: expected a bool {shape} mask, got {cells.dtype} {cells.shape}")
    n = int(cells.sum())
    out = {"cells": cells, "take_sha256": str(np.asarray(z.get("take_sha256", "")))}
    for key, tail in (("cell_positions", (3,)), ("cell_residuals", ()), ("cell_cameras", ())):
        if key in z:
            a = np.asarray(z[key])
            if a.shape != (n, *tail) or a.dtype.kind not in "fiu":
                raise MocapFormatError(path, f"{key}: expected {(n, *tail)} numbers, got {a.dtype} {a.shape}")
            out[key] = a
    if "cell_positions" not in out:
        raise MocapFormatError(path, "a marker cleaning record with cells but no cell_positions")
    return out
