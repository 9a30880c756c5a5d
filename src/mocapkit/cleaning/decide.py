"""A joint-angle take's decisions applied in Python as ``mocapkit clean --decisions`` applies them.

:func:`clean_and_decide` is :func:`mocapkit.clean` with ``decisions=``: the decisions file (or the same document
as a dict) is checked against the take before anything is cleaned, then applied to the record of the cleaning
reviewed (``record=``, the CLI's ``--record``: nothing is cleaned again, no context is read) or to a new cleaning
whose :func:`~mocapkit.cleaning.decisions.cleaning_digest` is the one the file keeps. Its checks and refusals are
those of :mod:`mocapkit.cleaning.decisions` that :func:`mocapkit.batch.clean_file` makes, in the same order and
words, so a refusal is the CLI's line. :func:`decided_result` is what comes back: the take with only the accepted
changes, its masks holding only their cells, and the :class:`~mocapkit.cleaning.decided.Decided` its
:meth:`~mocapkit.cleaning.clean_record.CleanResult.summary` says.

A library cleaning keeps the options it was asked for as the CLI's record does (``params["request"]``,
:func:`mocapkit.batch_request.clean_request`), so its record (:meth:`CleanResult.save`) and report
(:func:`mocapkit.report.html.write_clean_report`) carry the digest the CLI computes for the same cleaning:
decisions made in either page apply from either path.
"""

from __future__ import annotations

import copy
import dataclasses
import os
from collections.abc import Callable, Mapping

from ..errors import MocapError, MocapFormatError
from . import decisions as dec
from .decided import for_motion
from .pipeline import CleanResult

__all__ = ["GIVEN", "decisions_document", "decided_result", "clean_and_decide", "decide_take", "the_odd_take"]

GIVEN = "the decisions given"  # what a refusal names decisions given as a dict (no file)


def decisions_document(decisions) -> tuple[str, dict]:
    """``(name, document)`` of ``decisions``: a decisions file (:func:`~mocapkit.cleaning.decisions.read_decisions`,
    named by its path) or the same document as a mapping (checked by
    :func:`~mocapkit.cleaning.decisions.check_document`, named :data:`GIVEN`; copied, so the caller's dict is not
    changed). Refused in one line naming it."""
    if isinstance(decisions, Mapping):
        return GIVEN, dec.check_document(copy.deepcopy(dict(decisions)), GIVEN)
    if not isinstance(decisions, (str, os.PathLike)):
        raise TypeError(f"decisions= is a decisions file or its document (a dict), got {type(decisions).__name__}")
    return os.fspath(decisions), dec.read_decisions(decisions)


def decided_result(original, result: CleanResult, decisions: Mapping[str, str], decided=None) -> CleanResult:
    """``result`` with only the changes ``decisions`` accepts: what a person's decisions give back.

    ``motion`` is :func:`~mocapkit.cleaning.decisions.apply`'s take (the input's samples, bit for bit, outside the
    accepted changes); ``filled``, ``repaired`` and ``denoised`` keep only the accepted changes' cells, so that a
    report or a saved record of it says what the take holds; ``decided``: the
    :class:`~mocapkit.cleaning.decided.Decided` its :meth:`~CleanResult.summary` says.
    """
    acc = dec.accepted_cells(result, decisions)
    return dataclasses.replace(result, motion=dec.apply(original, result, decisions), filled=result.filled & acc,
                               repaired=result.repaired & acc, denoised=result.denoised & acc, samples=None,
                               decided=decided)


def clean_and_decide(original, cleaning: Callable[[], CleanResult], *, decisions, record=None,
                     request: dict | None = None, take: str = "", option: str = dec.RECORD_KEYWORD
                     ) -> tuple[CleanResult, CleanResult]:
    """A joint-angle take's decisions applied to the record reviewed or to a new cleaning, as the CLI applies them.

    ``original``: the take (:class:`~mocapkit.motion.Motion`); ``cleaning()``: the new cleaning of it
    (:func:`mocapkit.cleaning.pipeline.clean` with the options asked for), called only without ``record``;
    ``decisions``: a decisions file or its document (:func:`decisions_document`); ``record``: the ``.clean.npz`` of
    the cleaning reviewed, read back instead of cleaning again; ``request``: the options asked for
    (:func:`mocapkit.batch_request.clean_request`), kept on the new cleaning (its digest includes them) and named where
    they differ from those reviewed; ``take``: the input's file name for the summary; ``option``: how a refusal
    names the record to give (default ``record=``, this function's keyword).

    Refused, in one line naming the file, in this order: decisions for another take (before any cleaning), a
    record of another take, decisions made with other options than ``request`` (before a new cleaning), made on
    another cleaning, naming a change that is not one, or leaving one unnamed
    (:func:`~mocapkit.cleaning.decisions.check_decisions`).

    Returns ``(cleaning, decided)``: the whole cleaning (what its record keeps) and :func:`decided_result`.
    """
    path, doc = decisions_document(decisions)
    res, _, decided = decide_take(original, cleaning, doc, path, record=record, request=request, take=take,
                                  option=option)
    return res, decided


def the_odd_take(doc: dict, path, original, record_result: CleanResult, record, source) -> None:
    """Refuse, naming the input ``source``, a take that is not the one both the decisions ``doc`` (read from
    ``path``) and the record ``record`` were made for: they agree with each other (the record keeps the digest of
    the take the decisions name), so it is the input that is another take, or an edited one. Nothing where the
    decisions are of this take, or the record keeps no digest (the decisions and record checks then say which)."""
    named = doc["take"]
    if named["sha256"] == dec.take_digest(original) or record_result.take_sha256 != named["sha256"]:
        return
    raise MocapFormatError(source or original.name or "the input",
                           f"not the take that {os.path.basename(os.fspath(path))} and the record "
                           f"{os.path.basename(os.fspath(record))} were made for ({named.get('name', '?')}, "
                           f"{named.get('frames', '?')} frame{'' if named.get('frames') == 1 else 's'}; this file has {original.num_frames}): its samples "
                           "differ (another take, or one edited since)")


def decide_take(original, cleaning: Callable[[], CleanResult], doc: dict, path, *, record=None,
                request: dict | None = None, take: str = "", option: str = dec.RECORD_KEYWORD,
                prepared: Callable[[CleanResult], CleanResult] | None = None, named=None,
                held: Callable[[CleanResult], CleanResult] | None = None, source=None
                ) -> tuple[CleanResult, dict, CleanResult]:
    """The checks and steps of :func:`clean_and_decide` on a decisions document ``doc`` already read from ``path``
    (:func:`decisions_document`), which :func:`mocapkit.batch.clean_file` makes for the CLI too.

    ``prepared``: applied to the cleaning (new or read back) before the decisions are checked against it
    (``clean_file``'s frames note); ``held``: the cleaning as the output file holds it
    (:func:`~mocapkit.cleaning.decisions.as_written`: an AMC's bones with fewer than three dofs), to which the
    decisions are applied. They are checked against the cleaning as the person reviewed it: as it was read or
    made where the file's digest is of that (a batch's ``.bvh`` record applied to an ``.amc`` output), else as
    held (a record made for an ``.amc`` output; the change ids are the same either way). ``named``: what a
    refusal of a record without its cleaned samples names (default ``record``). ``source``: the input's path,
    named where it is the file that does not match (the decisions and the record are of one take, another than
    it: :func:`the_odd_take`). Other arguments as :func:`clean_and_decide`'s. Returns ``(cleaning, chosen, decided)``: the cleaning as held, ``chosen`` the
    checked choices (:func:`~mocapkit.cleaning.decisions.check_decisions`)."""
    if record is not None:
        res = CleanResult.load(record)
        the_odd_take(doc, path, original, res, record, source if source is not None else take)
    dec.check_decisions(doc, path, original, take=take)  # decisions for another take: refused before any cleaning
    if record is not None:
        dec.check_record(original, res, record)  # the record first, then the decisions against it
    else:
        dec.check_request(doc, path, request, option)  # a cleaning with other options cannot be the one reviewed
        res = cleaning()
        res = dataclasses.replace(res, params={**res.params, "request": request})
    if prepared is not None:
        res = prepared(res)
    shown = res if held is None else held(res)
    try:
        stamp = doc.get("cleaning") or {}
        reviewed = res if shown is not res and stamp.get("sha256") == dec.cleaning_digest(res) else shown
        chosen = dec.check_decisions(doc, path, original, reviewed, record=record, fresh=record is None,
                                     option=option, take=take)
        said = for_motion(doc, path, original, shown, chosen, record, take=take)
        return shown, chosen, decided_result(original, shown, chosen, said)
    except MocapFormatError:
        raise
    except MocapError as exc:  # a record without its cleaned samples
        raise MocapError(f"{record if named is None else named}: {exc}") from None
