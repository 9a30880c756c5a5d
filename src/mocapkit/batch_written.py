"""The takes an interrupted batch wrote but never said: their rows, read back from their records.

A worker of :func:`mocapkit.batch.clean_batch` renames a take's record into place last, so a take whose output and
record are there is complete. An interrupt (Ctrl-C, SIGTERM) or a stopped pool can come after a take's record is in
place and before its row reached the batch's process (a worker's result on its way, or the line not yet printed):
the take is kept on disk, and its line would be missing from the log. :func:`found_written` finds such takes when
the batch ends early, and :func:`row_from_record` gives each the row its worker would have given (what was filled,
flagged, repaired and denoised; a marker capture's changed samples by kind), read from the record it wrote.
:func:`skipped_counts` reads the same counts for a take skipped as complete, so its row says what the earlier run
found and fixed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from pathlib import Path

from .errors import MocapError

__all__ = ["WRITTEN_NOTE", "found_written", "row_from_record", "skipped_counts"]

#: What the line of a take found written after an interrupt says in place of its cleaning time.
WRITTEN_NOTE = "written before the batch was interrupted; said from its record"


def row_from_record(inp, output, record) -> dict:
    """The batch row of the take ``inp`` written to ``output`` with its ``.clean.npz`` ``record``: ``status`` "done",
    the sample counts the record keeps (``frames``; ``filled``, ``repaired``, ``denoised``, ``flagged`` of a
    joint-angle take, and its ``cuts``, each :class:`~mocapkit.cleaning.take_breaks.Cut`'s fields; a marker
    capture's :func:`~mocapkit.cleaning.markers.counts.sample_counts`: ``changed``,
    ``filled``, ``spikes``, ``swapped``, ``duplicates``, ``foreign``, and its
    :func:`~mocapkit.cleaning.markers.counts.fill_counts`: ``gaps``, ``unvalidated``), ``seconds`` None (not
    measured here)
    and ``reason`` :data:`WRITTEN_NOTE`. Raises :class:`~mocapkit.errors.MocapFormatError` for a record that cannot
    be read."""
    from .cleaning.flags_left import left_line
    from .cleaning.markers.counts import fill_counts, sample_counts
    from .cleaning.markers.record import read_marker_record
    from .cleaning.pipeline import CleanResult

    row = {"input": str(inp), "output": str(output), "status": "done", "reason": WRITTEN_NOTE, "seconds": None}
    if (CleanResult.load_params(record) or {}).get("kind") == "markers":
        rec = read_marker_record(record)
        row.update(frames=int(rec.changed.shape[0]), **sample_counts(rec), **fill_counts(rec))
    else:
        res = CleanResult.load(record)
        row.update(frames=res.num_frames, filled=int(res.filled.sum()), repaired=int(res.repaired.sum()),
                   denoised=int(res.denoised.sum()), flagged=int(res.flags.sum()), left=left_line(res),
                   cuts=[dataclasses.asdict(c) for c in res.cuts])
    return row


def found_written(takes: Iterable[tuple[int, Path, dict]], complete: Callable[[Path, dict], bool]
                  ) -> list[tuple[int, dict]]:
    """``(index, row)`` of each take of ``takes`` (``(index, input, files)``, ``files`` with ``output`` and
    ``record``: the takes whose rows were not said) that is complete on disk: output and record there, and
    ``complete(input, files)`` (the record made for this request, the files as it says they were written). A
    record that cannot be read is left out: the take's next run says what it finds."""
    rows = []
    for k, inp, files in takes:
        out, record = Path(files["output"]), Path(files["record"])
        if not (out.is_file() and record.is_file()) or not complete(inp, files):
            continue
        try:
            rows.append((k, row_from_record(inp, out, record)))
        except MocapError:
            continue
    return rows


def skipped_counts(inp, output, record) -> dict:
    """The counts of :func:`row_from_record` (``frames``, what was filled, repaired, denoised, flagged, ``left``,
    ``cuts``; a marker capture's changed samples by kind) of the take ``inp`` skipped as complete: what the earlier
    run that wrote ``output`` and its ``record`` found and fixed, without its row's ``status``, ``reason`` and
    ``seconds`` (the skipped row's own). Empty for a record that cannot be read: the row is then listed without
    counts, as before a take is cleaned."""
    try:
        row = row_from_record(inp, output, record)
    except MocapError:
        return {}
    return {k: v for k, v in row.items() if k not in ("input", "output", "status", "reason", "seconds")}
