"""The samples one marker cleaning changed, by kind: the one count every view of it says.

A marker cleaning changes a sample in one of five ways: a gap filled, a spike removed, a label swap undone, a
duplicate label removed (a marker on another's position, :mod:`~mocapkit.cleaning.markers.duplicates`) or another
point under a marker's label removed (a foreign stretch, :mod:`~mocapkit.cleaning.markers.foreign`). The ``clean``
totals line, ``clean-batch``'s line per take, its ``OUT_DIR/index.html`` and ``mocapkit info`` of the record each say
these counts, every kind of them, so that a take whose only change is a removed duplicate label never reads "nothing
to change" nor is filed "untouched". :func:`sample_counts` gives every view the same numbers, from a
:class:`~mocapkit.cleaning.markers.clean.MarkerCleanResult` or the record it wrote
(:class:`~mocapkit.cleaning.markers.record.MarkerRecord`), :data:`KINDS` their words and :func:`counts_words` the
words a batch row's counts read as.

Of the gaps filled, those with no expected error (no seen stretch of the marker to validate the fill on:
:mod:`~mocapkit.cleaning.markers.fill_error`) are *unvalidated*, written unchecked by the default limit: every view
counts them apart, by the same rule (:func:`unvalidated`; :func:`fill_counts` gives a batch row the gaps and the
unvalidated among them, :func:`unvalidated_words` their words, "1 of 2 gaps unvalidated: expected error unknown").
"""

from __future__ import annotations

import numpy as np

__all__ = ["KINDS", "sample_counts", "counts_words", "unvalidated", "fill_counts", "unvalidated_words"]

#: ``(key, words)`` of each kind of change, in the order every view lists them: the keys of :func:`sample_counts`
#: (and of a batch row), the words after the count ("226 filled, 43 other points under their labels removed").
KINDS = (("filled", "filled"), ("spikes", "spikes removed"), ("swapped", "re-labelled"),
         ("duplicates", "duplicate labels removed"), ("foreign", "other points under their labels removed"))


def _get(fix, name: str):
    return fix.get(name) if isinstance(fix, dict) else getattr(fix, name, None)


def sample_counts(result) -> dict[str, int]:
    """The samples ``result`` changed, by kind: ``{"changed", "filled", "spikes", "swapped", "duplicates",
    "foreign"}`` -> count.

    ``result``: a :class:`~mocapkit.cleaning.markers.clean.MarkerCleanResult` or a
    :class:`~mocapkit.cleaning.markers.record.MarkerRecord` (its ``labels``; a record written before duplicate
    labels were removed has no ``duplicates`` mask: 0). ``changed``: the samples whose values differ from the input
    (its (F, M) ``changed`` mask: a sample two kinds touch, a re-labelled one later removed as a spike, counts once);
    the others count each kind's mask, the removed duplicates mask split by its fixes into duplicate labels and
    foreign stretches (fixes of kind "foreign").
    """
    dups = getattr(result, "duplicates", None)
    filled = np.asarray(result.filled, dtype=bool)
    dups = np.zeros(filled.shape, dtype=bool) if dups is None else np.asarray(dups, dtype=bool)
    labels = getattr(result, "labels", None)
    if labels is None:
        labels = result.markers.labels
    col = {}
    for k, label in enumerate(labels):
        col.setdefault(str(label), k)
    foreign = np.zeros(dups.shape, dtype=bool)
    for fix in result.fixes:
        if _get(fix, "kind") == "foreign" and _get(fix, "marker") in col:
            foreign[int(_get(fix, "start")):int(_get(fix, "end")), col[_get(fix, "marker")]] = True
    foreign &= dups
    return {"changed": int(np.asarray(result.changed).sum()), "filled": int(filled.sum()),
            "spikes": int(np.asarray(result.spikes).sum()), "swapped": int(np.asarray(result.swapped).sum()),
            "duplicates": int((dups & ~foreign).sum()), "foreign": int(foreign.sum())}


def counts_words(counts, kinds=KINDS) -> str:
    """The ``kinds`` (``(key, words)`` pairs, by default :data:`KINDS`) of :func:`sample_counts` or of a batch row
    holding their keys, in words: "226 filled, 5 spikes removed, 43 other points under their labels removed"; the
    kinds with none left out. The filled samples of a row holding :func:`fill_counts` with unvalidated fills among
    them say so: "310 filled (1 of 2 gaps unvalidated: expected error unknown)"."""
    blind = unvalidated_words(counts)
    return ", ".join(f"{int(counts[key])} {words}" + (f" ({blind})" if key == "filled" and blind else "")
                     for key, words in kinds if counts.get(key))


def unvalidated(fixes) -> int:
    """How many of ``fixes`` (:class:`~mocapkit.cleaning.markers.clean.MarkerFix`, or a record's dicts of their
    fields) are gaps filled with no expected error: no stretch of the marker's seen data to validate the fill on. Such
    a fill is written unchecked by the default limit, counted apart by every view of a cleaning (its summary, the
    batch's line and index, ``mocapkit info``), and refused by a limit a user gives (``--max-fill-error``,
    ``max_error_mm=``)."""
    out = 0
    for x in fixes:
        expected = _get(x, "expected_mm")
        if _get(x, "kind") == "gap" and _get(x, "method") and not np.isfinite(float(np.nan if expected is None
                                                                                   else expected)):
            out += 1
    return out


def fill_counts(result) -> dict[str, int]:
    """``{"gaps", "unvalidated"}`` -> count of ``result``'s fixes (a
    :class:`~mocapkit.cleaning.markers.clean.MarkerCleanResult` or a
    :class:`~mocapkit.cleaning.markers.record.MarkerRecord`): the gaps it filled, as its summary counts them (fixes of
    kind "gap"), and the :func:`unvalidated` fills among them."""
    return {"gaps": sum(1 for x in result.fixes if _get(x, "kind") == "gap"), "unvalidated": unvalidated(result.fixes)}


def unvalidated_words(counts) -> str:
    """The unvalidated fills of ``counts`` (a batch row or :func:`fill_counts`) in words, as the cleaning's summary
    says them: "1 of 2 gaps unvalidated: expected error unknown"; "" where none is."""
    blind = int(counts.get("unvalidated") or 0)
    if not blind:
        return ""
    gaps = int(counts.get("gaps") or blind)
    return f"{blind} of {gaps} {'gap' if gaps == 1 else 'gaps'} unvalidated: expected error unknown"
