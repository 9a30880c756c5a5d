"""A batch output decided in place: the record says so, and a later batch keeps it.

The review loop writes a take's decisions over its batch output (``mocapkit clean IN -o OUT --decisions FILE``
with OUT's own ``.clean.npz`` as the record, ``--overwrite``): OUT then holds only the accepted changes, and no
longer the file the batch wrote. :func:`stamp_decided` keeps, beside the record's ``written`` facts, a
``decided`` entry: the decisions file and the size and SHA-256 of OUT as the decisions wrote it
(:func:`mocapkit.io.outputs.file_facts`). :func:`decided_by` reads it back: a later :func:`mocapkit.batch.clean_batch`
takes such a take as complete ("kept: decided by FILE") instead of an output changed outside mocapkit, and where its
input changed since, cleans it again only when told to (``overwrite``), saying that the decisions are discarded.
The record's cleaning is not touched (its arrays are copied as they are), so the same decisions, or new ones made
on its report, still apply to it.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

__all__ = ["stamp_decided", "decided_entry", "decided_by", "is_own_record"]


def is_own_record(record, out) -> bool:
    """Whether ``record`` is ``out``'s own record (its stem + ``.clean.npz``, the file itself, links resolved):
    decisions applied with it write over the batch's output in place."""
    from .cleaning.pipeline import clean_path
    from .io.outputs import same_file

    own = clean_path(Path(out))
    return record is not None and own.exists() and same_file(record, own)


def stamp_decided(record, decisions, out, holds: str = "") -> None:
    """Keep in ``record`` (a joint-angle take's or a marker capture's ``.clean.npz``) that ``out`` was written by
    applying ``decisions`` (a file path, kept absolute): ``{"decisions": path, "output": file_facts(out), "holds":
    holds}`` (``holds``: what ``out`` holds, :meth:`mocapkit.cleaning.decided.Decided.holds`; the record's own counts
    are the cleaning reviewed). OUT's own record applied in place is stamped so; the record of a new cleaning that
    ``clean --decisions`` writes beside OUT is saved with the same entry (:func:`decided_entry`).

    The record is rewritten atomically with every array as it was; a joint-angle record keeps the entry in its
    ``params`` (``params["decided"]``), a marker capture's record as its ``decided`` field.
    """
    from .io import atomic_write

    entry = decided_entry(decisions, out, holds)
    record = Path(record)
    with np.load(record, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    if "meta" in arrays:
        meta = json.loads(str(arrays["meta"]))
        meta["params"] = {**(meta.get("params") or {}), "decided": entry}
        arrays["meta"] = np.array(json.dumps(meta))
    else:
        arrays["decided"] = np.array(json.dumps(entry))
    with atomic_write(record, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def decided_entry(decisions, out, holds: str = "") -> dict:
    """The ``decided`` entry :func:`stamp_decided` keeps (the record of a new cleaning is saved with it):
    ``{"decisions": path (absolute), "output": file_facts(out), "holds": holds}``."""
    from .io.outputs import file_facts

    return {"decisions": os.path.abspath(os.fspath(decisions)), "output": file_facts(out), "holds": holds}


def decided_by(params: dict | None, out) -> str:
    """The decisions file that wrote ``out`` as it is now (the record's ``decided`` entry, :func:`stamp_decided`,
    whose output facts match the file), else ""."""
    from .io.outputs import file_facts

    entry = (params or {}).get("decided")
    if not isinstance(entry, dict) or not isinstance(entry.get("output"), dict):
        return ""
    was = entry["output"]
    out = Path(out)
    if not out.is_file() or out.stat().st_size != was.get("size") or file_facts(out) != was:
        return ""
    return str(entry.get("decisions") or "")
