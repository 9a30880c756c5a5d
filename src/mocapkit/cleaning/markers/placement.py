"""Where each sample of a marker cleaning goes in a capture written with only some of its label swaps undone.

A marker cleaning (:func:`~mocapkit.cleaning.markers.clean_markers`) first
re-labels swapped samples (:func:`~mocapkit.cleaning.markers.swaps.undo_swaps`),
then removes spikes and duplicates and fills gaps in that new labelling. A
person may reject a swap and accept a fix made inside it (or the other way
round): the fix was made on the samples of one recorded trajectory, which the
rejected swap leaves under the other label. Its samples must therefore land in
the column that holds that trajectory in the capture written, not in the
column it had in the cleaned labelling.

Each swap fix exchanges two recorded trajectories over its frames, in
whichever columns the swaps before it put them; applied in order of first
frame (as :func:`undo_swaps` lists them) they give, per frame, a permutation
of the columns. :func:`sources` composes every swap
(the cleaned labelling), :func:`destinations` maps each cleaned cell to its
column in a labelling with only the kept swaps. Arrays are frames-first:
``(F, M)`` int, ``M`` the capture's markers (all of them, as in
:attr:`MarkerSet.labels`).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .swaps import labelling

__all__ = ["sources", "destinations", "relabelled"]


def sources(swaps, labels, frames: int) -> np.ndarray:
    """(F, M) int: the input column whose samples each column of the cleaned capture holds at each frame.

    ``swaps``: the swap fixes (:class:`~mocapkit.cleaning.markers.MarkerFix` of kind ``"swap"``: the recorded
    trajectories of ``marker`` and ``other`` exchanged over frames ``start <= f < end``, wherever the swaps before
    it put them), composed by ``order`` then first frame (:func:`~mocapkit.cleaning.markers.swaps.labelling`);
    ``labels``: the capture's labels (M,); ``frames``: F. A column no swap touched holds its own samples. Chained
    swaps (LTOE/RTHI over 100-199, RTHI/LKNE over 150-249) cycle three columns where they overlap
    (:func:`~mocapkit.cleaning.markers.swaps.recorded_swaps`).
    """
    col = {label: k for k, label in enumerate(labels)}
    return labelling([SimpleNamespace(a=col[x.marker], b=col[x.other], start=x.start, end=x.end,
                                      order=getattr(x, "order", 0)) for x in swaps], len(labels), frames)


def destinations(src: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """(F, M) int: the column of the capture written that each cleaned cell's samples belong to.

    ``src``: :func:`sources` of every swap (the cleaned labelling); ``kept``: :func:`sources` of the swaps kept
    (the labelling written). Cleaned column ``c`` holds input column ``src[f, c]``, which the capture written
    holds in the column ``k`` with ``kept[f, k] == src[f, c]``.
    """
    rows = np.arange(src.shape[0])[:, None]
    inverse = np.empty_like(kept)
    inverse[rows, kept] = np.arange(kept.shape[1])
    return inverse[rows, src]


def relabelled(original, src: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """``original``'s positions (F, M, 3), residuals and camera masks (F, M; None where it has none) in the
    labelling ``src`` (:func:`sources`): what the cleaned capture would hold with only its swaps undone."""
    rows = np.arange(src.shape[0])[:, None]
    pick = [None if a is None else np.asarray(a)[rows, src] for a in (original.residuals, original.cameras)]
    return np.asarray(original.positions)[rows, src], pick[0], pick[1]
