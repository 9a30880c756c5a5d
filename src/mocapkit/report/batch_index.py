"""The overview page of a batch: one HTML table of every take ``clean-batch --report`` wrote, the takes to look at first.

A studio cleans hundreds of takes in one batch and gets one report per take (:mod:`mocapkit.report.html`); a person
who reviews them needs to know where to start. :func:`write_batch_index` writes ``OUT_DIR/index.html``: a
self-contained page (no script, no file beside it) with the batch's totals and one row per take, linked to its
report, in this order: the takes that failed (their one-line reason), then the takes the cleaning changed, most
changed samples first (then most flagged), then the takes flagged but left as they were, then the untouched ones.
Each row says what the take's own line says (:func:`take_counts`): the samples filled, repaired and denoised (a
marker capture: filled, spikes removed, re-labelled, duplicate labels and other points under their labels removed),
the samples flagged, the flagged runs left as they were, its cuts (two takes joined, or frames dropped: named, no
sample changed for them; :func:`~mocapkit.cleaning.take_breaks.cuts_phrase`), and
the file that decided it where a person already accepted or rejected its changes. Within each group a take with
cuts comes before one without.

The page is the batch's own file: :data:`GENERATOR` in its head tells a later batch it may replace it
(:func:`is_batch_index`); any other ``index.html`` in OUT_DIR is a user's, replaced only with ``--overwrite``.
"""

from __future__ import annotations

import html
import os
from pathlib import Path

from ..cleaning.markers.counts import KINDS, counts_words
from ..cleaning.take_breaks import cuts_phrase
from ..io import atomic_write
from ..words import plural

__all__ = ["INDEX_NAME", "GENERATOR", "write_batch_index", "is_batch_index", "take_counts", "ordered_rows"]

#: The overview's file name in OUT_DIR: no take writes it (a take's files end in ``.report.html``,
#: ``.summary.png``, ``.clean.npz`` or a motion format's suffix).
INDEX_NAME = "index.html"

#: The ``<meta name="generator">`` of the overview: the mark of a page a batch wrote.
GENERATOR = "mocapkit clean-batch"

_MARK = f'<meta name="generator" content="{GENERATOR}">'

_STYLE = """body{font:14px/1.4 system-ui,sans-serif;margin:1.5em;color:#222}
h1{font-size:1.3em;margin:0 0 .3em}p{margin:.2em 0}
table{border-collapse:collapse;margin-top:1em}th,td{padding:.3em .6em;border-bottom:1px solid #ddd;text-align:left;
vertical-align:top}th{background:#f4f4f4;position:sticky;top:0}td.n{text-align:right;font-variant-numeric:tabular-nums}
tr.failed td{background:#fdecea}tr.changed td.take{border-left:4px solid #e69f00}tr.left td.take{border-left:4px solid
#56b4e9}tr.untouched{color:#777}tr.untouched.cut{color:#222}tr.untouched.cut td.take{border-left:4px solid #cc79a7}
.why{color:#555;font-size:.92em}"""


def take_counts(row: dict) -> tuple[int, str]:
    """``(changed, words)`` of a batch row (:class:`mocapkit.batch.BatchSummary`'s rows): the samples the cleaning
    changed and what they were, as the take's line says them ("3 filled, 7 repaired"; a marker capture's "3 filled,
    2 spikes removed, 60 duplicate labels removed": every kind of
    :func:`~mocapkit.cleaning.markers.counts.sample_counts`, and its ``changed``, the samples whose values differ,
    where the row holds it); ``(0, "")`` for a row without counts (a failed take)."""
    marker = "spikes" in row  # a marker capture
    kinds = KINDS if marker else (("filled", "filled"), ("repaired", "repaired"), ("denoised", "denoised"))
    changed = row.get("changed")
    changed = int(changed) if changed is not None else sum(int(row.get(key) or 0) for key, _ in kinds)
    return changed, counts_words(row, kinds=kinds)


def _kind(row: dict) -> str:
    if row.get("status") == "failed":
        return "failed"
    if take_counts(row)[0]:
        return "changed"
    return "left" if row.get("flagged") or row.get("left") else "untouched"


_ORDER = {"failed": 0, "changed": 1, "left": 2, "untouched": 3}


def ordered_rows(rows) -> list[dict]:
    """``rows`` in the order a person reviews them (module docstring): failed, changed (most changed samples, then
    most flagged, then most cuts, first), flagged but left, untouched; ties by input path."""
    return sorted(rows, key=lambda r: (_ORDER[_kind(r)], -take_counts(r)[0], -int(r.get("flagged") or 0),
                                       -len(r.get("cuts") or ()), str(r.get("input", ""))))


def is_batch_index(path) -> bool:
    """Whether the file at ``path`` is an overview a batch wrote (its head holds :data:`GENERATOR`)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            return _MARK in fh.read(4096)
    except OSError:
        return False


def _link(target, out_dir: Path) -> str:
    return Path(os.path.relpath(Path(target), out_dir)).as_posix()


def write_batch_index(path, rows, *, in_dir, out_dir, request: str = "", version: str = "") -> Path:
    """Write the overview of a batch to ``path`` (``OUT_DIR/index.html``), atomically; returns ``path``.

    ``rows``: the batch's rows (:class:`mocapkit.batch.BatchSummary`), each with ``input``, ``output``, ``status``,
    ``reason`` and, for a cleaned or complete take, its counts (``frames``; ``filled``, ``repaired``, ``denoised``,
    ``flagged``, ``left`` or a marker capture's ``changed``, ``filled``, ``spikes``, ``swapped``, ``duplicates``,
    ``foreign``), ``cuts`` (each :class:`~mocapkit.cleaning.take_breaks.Cut`'s fields), ``report`` (its report's path,
    or None) and ``decided`` (the decisions file that decided its output, or ""). ``in_dir``, ``out_dir``: the
    batch's folders (links are relative to ``out_dir``, so the folder can be moved or archived whole);
    ``request``: one line of what the takes were cleaned with; ``version``: mocapkit's.
    """
    out_dir = Path(out_dir)
    rows = ordered_rows(rows)
    kinds = [_kind(r) for r in rows]
    counts = {k: kinds.count(k) for k in _ORDER}
    esc = html.escape
    body = []
    for row, kind in zip(rows, kinds):
        name = Path(row["input"]).name
        report = row.get("report")
        take = f'<a href="{esc(_link(report, out_dir))}">{esc(name)}</a>' if report else esc(name)
        rel = Path(os.path.relpath(Path(row["input"]), in_dir)).parent.as_posix()
        where = "" if rel == "." else f'<div class="why">{esc(rel)}/</div>'
        if kind == "failed":
            cells = f'<td class="n"></td><td class="n"></td><td></td><td class="n"></td><td>{esc(row.get("reason", ""))}</td>'
        else:
            changed, words = take_counts(row)
            said = [row.get("left") or "", cuts_phrase(row.get("cuts") or ())]
            if row.get("decided"):
                said.append(f"decided by {row['decided']}")
            cells = (f'<td class="n">{int(row.get("frames") or 0)}</td><td class="n">{changed}</td>'
                     f'<td>{esc(words)}</td><td class="n">{int(row.get("flagged") or 0)}</td>'
                     f'<td>{esc("; ".join(s for s in said if s))}</td>')
        cut = " cut" if kind != "failed" and row.get("cuts") else ""  # a take to look at though nothing changed
        body.append(f'<tr class="{kind}{cut}"><td class="take">{take}{where}</td>{cells}</tr>')
    total = len(rows)
    summary = (f"{plural(total, 'take')}: {counts['failed']} failed, {counts['changed']} changed, "
               f"{counts['left']} flagged and left as they were, {counts['untouched']} untouched.")
    cut = sum(bool(r.get("cuts")) for r in rows)
    if cut:  # a cut changes no sample, so it moves no take up the groups: said over the table
        summary += (f" {plural(cut, 'take')} {'has' if cut == 1 else 'have'} cuts (two takes joined, or frames "
                    f"dropped), named in {'its' if cut == 1 else 'their'} row{'' if cut == 1 else 's'}: no sample "
                    "changed for them; split the take there, or keep it whole.")
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">{_MARK}
<title>mocapkit clean-batch: {esc(str(in_dir))}</title><style>{_STYLE}</style></head><body>
<h1>clean-batch: {esc(str(in_dir))} &rarr; {esc(str(out_dir))}</h1>
<p>{esc(summary)} The takes to look at come first: failed, then the most changed. A take's name opens its report,
where each change can be accepted or rejected.</p>
{f'<p class="why">cleaned with {esc(request)}</p>' if request else ''}
{f'<p class="why">mocapkit {esc(version)}</p>' if version else ''}
<table><thead><tr><th>take</th><th>frames</th><th>changed samples</th><th>what changed</th><th>flagged samples</th>
<th>left as they were, cuts, decided, or why it failed</th></tr></thead>
<tbody>
{chr(10).join(body)}
</tbody></table></body></html>
"""
    with atomic_write(path) as fh:
        fh.write(page)
    return Path(path)
