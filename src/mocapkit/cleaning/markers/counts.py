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
"""

from __future__ import annotations

import numpy as np

__all__ = ["KINDS", "sample_counts", "counts_words"]

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
    kinds with none left out."""
    return ", ".join(f"{int(counts[key])} {words}" for key, words in kinds if counts.get(key))
