"""What a marker file holds besides its trajectories, in words: a C3D's analog channels, force plates and events,
and the number of the file's first frame.

``mocapkit info`` prints these lines for a marker file, so that a user sees
what a .trc or .npz output would leave out and how the file's frame numbers
relate to the take's 0-based indexes before converting or cleaning it. The
values come from the C3D parameter section as the reader kept it
(:class:`~mocapkit.markerset.MarkerSource`): ANALOG:USED and ANALOG:RATE,
FORCE_PLATFORM:USED and TYPE, EVENT:USED and LABELS, else the header's
events (C3D format: Motion Lab Systems, "The C3D File Format User Guide",
c3d.org).
"""

from __future__ import annotations

from collections import Counter

import numpy as np


from ..markerset import MarkerSet, marker_counts
from ..words import plural
from .c3d_layout import parameter_values

__all__ = ["marker_file_contents", "marker_counts", "zero_gaps_line"]


def _values(parameters, group: str, name: str) -> list:
    """The values of parameter ``group:name`` as a flat list ([] when the file has none)."""
    return list(parameter_values(parameters, group, name))


def _first_int(values) -> int:
    """The first value as an int, 0 for none or one that is not a number."""
    try:
        return int(values[0]) if values else 0
    except (TypeError, ValueError):
        return 0


def _counted(names) -> str:
    """``["Foot Strike", "Foot Off", "Foot Strike"]`` -> "2 Foot Strike, 1 Foot Off" (in order of first use)."""
    return ", ".join(f"{n} {name}" for name, n in Counter(names).items())


def never_seen_line(markers: MarkerSet) -> str:
    """How many of ``markers``' markers (modelled quantities aside, as :func:`marker_counts` counts them) are
    missing in every frame, with the first five labels: ``32 of 110 markers never seen: LFHD, RFHD, ...``; ""
    where every one is seen. A share of missing samples made of markers never seen (a marker set's labels the
    capture did not use: 29 % of Vicon's FunctionalWalk.c3d) is no gap that ``clean`` could fill, so ``info``
    says which part of its missing line they are."""
    kept = markers.quantities() == ""
    if not kept.any() or not markers.num_frames:
        return ""
    never = kept & markers.missing().all(axis=0)
    n = int(never.sum())
    if not n:
        return ""
    names = [markers.labels[i] for i in np.flatnonzero(never)]
    shown = ", ".join(names[:5]) + (", ..." if n > 5 else "")
    return f"{n} of {plural(int(kept.sum()), 'marker')} never seen: {shown}"


def marker_file_contents(markers: MarkerSet) -> list[tuple[str, str]]:
    """``(field, value)`` rows for what ``markers``' file holds besides its trajectories, only those present.

    ``first frame``: the file's number of the take's first frame (a C3D's
    header, a TRC's first ``Frame#``), the frame the take's index 0 is, where
    it is not 1 (a trimmed capture: FunctionalWalk.c3d starts at 480);
    for a C3D, ``analogs`` (channel count and rate in Hz), ``force plates``
    (count and types) and ``events`` (count and labels, from the EVENT group,
    else the header's event labels); for a marker npz, ``filled`` (how many
    samples its ``filled`` mask marks as no recorded ones). [] for a take read from no file.
    """
    source = markers.source
    if source is None:
        return []
    first = int(source.first_frame)
    rows = [("first frame", str(first))] if first != 1 else []
    if source.filled is not None and source.filled.any():
        rows.append(("filled", f"{int(source.filled.sum())} of {source.filled.size} marker samples are no recorded "
                               "ones (the npz's filled mask)"))
    if source.format != "c3d":
        return rows
    params = source.parameters
    channels = source.analogs.shape[0] if source.analogs is not None else 0
    if channels:
        rate = _values(params, "ANALOG", "RATE")
        hz = float(rate[0]) if rate else markers.fps * source.analog_ratio(markers.num_frames)
        rows.append(("analogs", f"{channels} channel{'s' if channels > 1 else ''} at {hz:g} Hz"))
    plates = _first_int(_values(params, "FORCE_PLATFORM", "USED"))
    if plates > 0:
        types = [str(t) for t in _values(params, "FORCE_PLATFORM", "TYPE")[:plates]]
        kinds = f" (type {', '.join(dict.fromkeys(types))})" if types else ""
        rows.append(("force plates", f"{plates}{kinds}"))
    used = _first_int(_values(params, "EVENT", "USED"))
    labels = [str(x).strip() for x in _values(params, "EVENT", "LABELS")[:used]] if used > 0 else []
    if not labels:
        labels = [str(label).strip() for _, label, _ in source.events]
    if labels:
        rows.append(("events", f"{len(labels)} ({_counted(labels)})"))
    elif used > 0:
        rows.append(("events", str(used)))
    return rows


def zero_gaps_line(count: int) -> str:
    """What the reader made of samples stored as exact (0, 0, 0), for ``info``, ``convert`` and ``clean``.

    ``count``: :attr:`MarkerSet.zero_gaps`, the samples read as gaps (decided run by run from the data unless
    ``zeros_as_gaps=`` says; docs/guide/markers.md, Gaps stored as zeros: 23 % of Qualisys's 03_rolling.c3d), so
    that a missing share or a cleaning's gap count that comes from them is never unexplained.
    """
    return f"read {count} sample{'' if count == 1 else 's'} stored as exact (0, 0, 0) as gaps"
