"""Which gap fills to doubt: runs that depart far from what the take around them says.

A fill is a guess. Where the take holds a joint nearly still and the fill swings it far off the line
between the gap's seen ends (or off its one seen end, for a gap at the take's start or end), the fill is
said, not changed (``clean``'s and ``fill``'s notes; docs/guide/deep-models.md, Limits).
"""

from __future__ import annotations

import numpy as np

from ..runs import true_runs

__all__ = ["doubtful_runs", "end_line", "DOUBT_SPREAD", "DOUBT_FLOOR_DEG", "DOUBT_MIN_DEG"]


#: A fill is doubtful (:func:`doubtful_runs`) where it departs from the straight line between a run's seen ends by
#: more than DOUBT_SPREAD times the channel's own spread (its standard deviation over the take's seen frames, plus
#: DOUBT_FLOOR_DEG) and by more than DOUBT_MIN_DEG: a joint the take shows nearly still that the fill swings far.
#: The prior's training scale does not tell a bad fill from a good one (on the Bandai held-out takes a fill departing
#: over 3 training sigmas, 10-30 deg, from the line was worse than the line in 15 of the 107 standard gap runs it
#: marked); the take's own spread does better (docs/guide/deep-models.md, Limits).
DOUBT_SPREAD = 6.0
DOUBT_FLOOR_DEG = 1.0
DOUBT_MIN_DEG = 10.0



def end_line(values: np.ndarray) -> np.ndarray:
    """The straight line through each NaN run of (F, C) degrees ``values`` between its seen ends, the far end moved
    by whole turns to within 180 deg of the near one; a run at the take's start or end holds its one seen end."""
    x = np.array(values, dtype=np.float64)
    miss = np.isnan(x)
    for c in np.flatnonzero(miss.any(axis=0)):
        if miss[:, c].all():
            continue
        for a, b in true_runs(miss[:, c]):
            lo = x[a - 1, c] if a > 0 else None
            hi = x[b + 1, c] if b + 1 < len(x) else None
            if lo is None or hi is None:
                x[a:b + 1, c] = hi if lo is None else lo
                continue
            hi = lo + (hi - lo + 180.0) % 360.0 - 180.0
            x[a:b + 1, c] = lo + (hi - lo) * np.arange(1, b - a + 2) / (b - a + 2)
    return x


def doubtful_runs(values: np.ndarray, filled: np.ndarray, groups: np.ndarray):
    """Where the fill ``filled`` of (F, C) degrees ``values`` (NaN: the gaps) departs from the straight line between
    the gaps' seen ends (:func:`end_line`) by more than :data:`DOUBT_SPREAD` times the channel's spread over the
    take's seen frames (plus :data:`DOUBT_FLOOR_DEG`) and by more than :data:`DOUBT_MIN_DEG`. ``groups`` (C,): each
    channel's joint; a joint's run is its frames missing any of its channels. A run at the take's start or end has
    one seen end and no line: its reference is that end held (as :func:`end_line` makes it). Returns
    ``[(group, first, last, departure_deg, spread_deg, side)]``: the largest departure over the run's doubtful
    channels (wrapped to within 180 deg), that channel's spread, and ``side`` None for a run between two seen
    ends, ``"start"`` or ``"end"`` for one at the take's start or end (a note names its reference so). The fill is
    not changed (a line is no better a guess of a long gap in general); the list is what a caller says
    (``clean``'s notes)."""
    x = np.asarray(values, dtype=np.float64)
    miss = np.isnan(x)
    if not miss.any():
        return []
    F = len(x)
    spread = np.array([np.std(x[~miss[:, c], c]) if (~miss[:, c]).any() else 0.0 for c in range(x.shape[1])])
    dev = np.abs((np.asarray(filled, dtype=np.float64) - end_line(x) + 180.0) % 360.0 - 180.0)
    dev = np.where(miss, dev, 0.0)
    groups = np.asarray(groups)
    out = []
    for g in np.unique(groups[miss.any(axis=0)]):
        cols = np.flatnonzero(groups == g)
        for a, b in true_runs(miss[:, cols].any(axis=1)):
            side = "start" if a == 0 else "end" if b == F - 1 else None
            sp = spread[cols]
            allow = np.maximum(DOUBT_SPREAD * (sp + DOUBT_FLOOR_DEG), DOUBT_MIN_DEG)
            d = dev[a:b + 1][:, cols].max(axis=0)
            over = d > allow
            if over.any():
                c = int(np.argmax(np.where(over, d, -1.0)))
                out.append((int(g), int(a), int(b), float(d[c]), float(sp[c]), side))
    return out
