"""Applying a person's decisions: the command the report gives, and what applying did, said one way for a
joint-angle take and for a marker capture.

:func:`apply_command` is what the report's page needs to say the command that applies its decisions file: the
input's path and the options that read the take as it was reviewed (an AMC's ``--asf`` and ``--amc-fps``, the
``--unit`` of a file that states none), without which the take read is another (no skeleton, another rate or
unit: another digest) and the command fails as copied. ``--record`` (the record the page's cleaning wrote) makes
the options that shaped the cleaning (``--context``, ``--threshold``, ...) unneeded: a context folder moved since
is not read.

``mocapkit clean IN -o OUT --decisions FILE.json`` and ``mocapkit.clean(take, decisions=FILE.json)`` say, after
the decisions are applied (:mod:`mocapkit.cleaning.decisions`, :mod:`mocapkit.cleaning.markers.decisions`): what
they were applied to (a record, or a new cleaning whose digest is the one reviewed), how many changes were
accepted and rejected, how many samples changed, what the reader should know about the file (one written by hand,
changes it does not name) and which changes were rejected. :func:`for_motion` and :func:`for_markers` gather
those facts into a :class:`Decided`; :meth:`Decided.lines` words them, for both kinds of take.
"""

from __future__ import annotations

from dataclasses import dataclass

from . import decisions as dec

__all__ = ["Decided", "for_motion", "for_markers", "apply_command", "MAX_LISTED"]

MAX_LISTED = 12  # rejected changes listed one a line; the rest counted


@dataclass(frozen=True)
class Decided:
    """The facts of one decisions file applied to one cleaning.

    ``decisions``: the file as given; ``record``: the record applied to ("" for a new cleaning); ``changes``: the
    cleaning's number of changes; ``rejected``: each rejected change in words (``KIND:WHO:FIRST-LAST: ...``);
    ``samples``: the samples the decided take changed, of ``total``; ``item``: what a sample is ("joint sample",
    "marker sample"); ``take``: the input's file name (every other sample is its); ``notes``: one line each
    (:func:`mocapkit.cleaning.decisions.ids_notes`, a record without the take's digest).
    """

    decisions: str
    record: str
    changes: int
    rejected: tuple[str, ...]
    samples: int
    total: int
    item: str
    take: str
    notes: tuple[str, ...] = ()

    def headline(self) -> str:
        """One line: the file, what it was applied to, the changes accepted and rejected, the samples changed."""
        src = (f"the record {self.record} (nothing cleaned again)" if self.record
               else "a new cleaning (its values the ones reviewed)")
        n, r = self.changes, len(self.rejected)
        return (f"{self.decisions} applied to {src}: {n - r} of {n} change{'' if n == 1 else 's'} accepted, {r} "
                f"rejected; {self.samples} {self.item}{'' if self.samples == 1 else 's'} of {self.total} changed, "
                f"every other sample is {self.take}'s")

    def holds(self) -> str:
        """What the decided output holds, in one line: the changes accepted and rejected, the samples changed (the
        ``decided`` entry of a record beside it keeps it: :func:`mocapkit.batch_decided.stamp_decided`)."""
        n, r = self.changes, len(self.rejected)
        return (f"{n - r} of {n} change{'' if n == 1 else 's'} accepted, {r} rejected; {self.samples} "
                f"{self.item}{'' if self.samples == 1 else 's'} of {self.total} changed")

    def rejected_lines(self, frames_note: str = "") -> list[str]:
        """``rejected ...`` for the first :data:`MAX_LISTED` rejected changes, a count of the rest, and
        ``frames_note`` (how the frames relate to the file's own numbers) where a change is listed."""
        out = [f"rejected {c}" for c in self.rejected[:MAX_LISTED]]
        if len(self.rejected) > MAX_LISTED:
            out.append(f"... and {len(self.rejected) - MAX_LISTED} more rejected")
        if self.rejected and frames_note:
            out.append(frames_note)
        return out

    def lines(self, frames_note: str = "") -> list[str]:
        """The whole summary: :meth:`headline`, each note as ``note: ...``, then :meth:`rejected_lines`."""
        return [self.headline()] + [f"note: {n}" for n in self.notes] + self.rejected_lines(frames_note)


def for_motion(doc: dict, path, original, result, decisions: dict, record=None, take: str = "") -> Decided:
    """:class:`Decided` for a joint-angle take: ``doc`` read from ``path``, its checked ``decisions`` applied to
    ``result`` (a :class:`~mocapkit.cleaning.clean_record.CleanResult` of ``original``, read from ``record`` or, None,
    a new cleaning); ``take``: the input's file name (default the take's name)."""
    found = dec.changes(result, original)
    rejected = tuple(str(c) for c in found if decisions.get(c.id) == dec.REJECT)
    notes = dec.ids_notes(doc, path, [c.id for c in found])
    if record is not None and not result.take_sha256:
        notes.append(f"{record} was written by an earlier mocapkit and keeps no digest of its take: it was checked by "
                     "rig, length and rate only; make sure it is this take's")
    return Decided(str(path), "" if record is None else str(record), len(found), rejected,
                   int(dec.accepted_cells(result, decisions).sum()), int(result.changed.size), "joint sample",
                   take or original.name or "the input", tuple(notes))


def for_markers(doc: dict, path, original, result, decisions: dict, record=None, take: str = "") -> Decided:
    """:class:`Decided` for a marker capture: ``doc`` read from ``path``, its checked ``decisions`` applied to
    ``result`` (a :class:`~mocapkit.cleaning.markers.MarkerCleanResult` of ``original``, rebuilt from ``record``
    or, None, a new cleaning); ``take``: the input's file name (default the capture's name)."""
    from .markers import decisions as mdec

    found = mdec.changes(original, result.markers, result.fixes)
    rejected = tuple(str(c) for c in found if decisions.get(c.id) == dec.REJECT)
    # the samples the capture written differs from the input in (a sample two chained swaps both move is counted
    # when either is kept)
    n = int(mdec.differs(original, mdec.apply(original, result.markers, result.fixes, decisions)).sum())
    return Decided(str(path), "" if record is None else str(record), len(found), rejected, n,
                   int(result.changed.size), "marker sample", take or original.name or "the input",
                   tuple(dec.ids_notes(doc, path, [c.id for c in found])))


def apply_command(inp, *, asf=None, amc_fps: float | None = None, unit: str | None = None,
                  zeros_as_gaps: bool | None = None) -> dict:
    """What the report's page adds to ``mocapkit clean IN -o OUT --decisions FILE --record RECORD`` for its take:
    ``{"input": IN, "options": [...]}``.

    ``inp``: the input's path as the cleaning was given it (the page's ``--record`` is too); ``asf``: the ASF an
    ``.amc`` input was read with (said as ``--asf`` whether or not it lies beside the AMC: the command then reads
    the same skeleton wherever it is); ``amc_fps``: the AMC frame rate given (``--amc-fps``); ``unit``: the length
    unit given for a file that states none (``--unit``); ``zeros_as_gaps``: how a marker file's exact (0, 0, 0)
    samples were read (``--zeros-as-gaps`` or ``--keep-zeros``; None, decided from the data: neither). Each is needed to read the take the decisions were made
    for: its digest (:func:`mocapkit.cleaning.decisions.take_digest`) keeps its rate and, for a marker capture, its
    unit.
    """
    import os

    opts: list[str] = []
    if asf is not None and os.fspath(inp).lower().endswith(".amc"):
        opts += ["--asf", os.fspath(asf)]
    if amc_fps is not None:
        opts += ["--amc-fps", f"{float(amc_fps):g}"]
    if unit is not None:
        opts += ["--unit", str(unit)]
    if zeros_as_gaps is not None:
        opts += ["--zeros-as-gaps" if zeros_as_gaps else "--keep-zeros"]
    return {"input": os.fspath(inp), "options": opts}
