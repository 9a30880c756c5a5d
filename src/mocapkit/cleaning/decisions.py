"""A person decides: the changes ``clean`` made, one by one, and the take with only the accepted ones.

:func:`mocapkit.cleaning.pipeline.clean` records which (frame, joint) cells
each step changed (``filled``, ``repaired``, ``denoised``). This module turns
that record into a list of :class:`Change` objects a person can review (in the
HTML report, or in Python), reads the person's choices from a small JSON
decisions file, and applies them.

Changes
-------
A change is one contiguous run of frames of one joint changed by the same
step or steps: the changed cells of each joint, split wherever the set of
steps that changed a cell differs. Where two steps changed the same cells (a
repaired stretch that was also denoised) the change names both
(``"repair+denoise"``): the record holds only the final value of a cell, so
those cells are accepted or rejected together. The changes therefore
partition the changed cells: each cell belongs to exactly one change. Its id,
``STEP:JOINT:FIRST-LAST``, depends only on the record, so the same cleaning of
the same take gives the same ids on every run.

Applying decisions
------------------
:func:`apply` starts from the input take and, for every accepted change, puts
the cleaned values of its cells in: the joint's rotation, the root position
for the root joint, the joint's offset for files that animate offsets. Every
other sample (unchanged cells and the cells of rejected changes) is the
input's, bit for bit: rejecting every change gives the input back, accepting
every change gives the cleaned take. Adjacent changes of one joint with
different decisions meet at a frame boundary; nothing is blended across it,
so the take can jump there, as it did in the input. Changes that are parts of one fix (the two sides of a
left/right swap, touching runs of one joint made by nested steps: :mod:`~mocapkit.cleaning.ties`) are
accepted or rejected together (:func:`tied`); decisions that split them are refused. The cleaned values come
from the record (:attr:`CleanResult.samples`, float64 as the pipeline made
them) or, for a record without them, from ``result.motion``.

The decisions file
------------------
Small JSON, written by the report's "download decisions" button
(:func:`template` makes the same document in Python)::

    {"format": "mocapkit.decisions/1", "mocapkit": "0.9.0",
     "take": {"name": "walk.amc", "frames": 523, "joints": 31, "sha256": "..."},
     "output": "walk_clean.bvh",
     "cleaning": {"sha256": "...", "changes": 4, "request": {...}, "record": "walk_clean.clean.npz"},
     "decisions": {"repair:lfemur:120-145": "reject", ...}}

``take.sha256`` is :func:`take_digest` of the input take: decisions made for
another take are refused. The record keeps the same digest of the take it
cleaned (:attr:`CleanResult.take_sha256`): a record of another take, even one
of the same rig and length, is refused too (:func:`check_record`), before the
decisions are checked against it, so that the refusal names the record. A
change the file does not name is accepted (the report's default); an id that
is not a change of this cleaning is refused. Every refusal is one line naming
the file (:class:`~mocapkit.errors.MocapFormatError`). A record written before
the digest was kept is still applied (decisions downloaded from its report keep
working after an upgrade), checked by rig, length and rate only.

``cleaning`` (:func:`cleaning_stamp`) is :func:`cleaning_digest` of the cleaning
the person reviewed, with the options it was asked for and its record's path:
the same ids can name other values (the take cleaned again with another
context), so the decisions apply only to a cleaning with that digest
(:func:`check_cleaning`, :func:`check_request` before a new cleaning). A file
without it (an earlier mocapkit's, or written by hand) is applied to a record
on its ids, and refused for a new cleaning. A key said twice is refused (JSON
would keep the last); a file with ``cleaning`` names every change
(:func:`check_named`).

Examples
--------
>>> import mocapkit
>>> from mocapkit import corrupt
>>> from mocapkit.cleaning.pipeline import clean
>>> m = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
>>> bad, _, _ = corrupt.real_errors(m, n_errors=2, seed=3)
>>> res = clean(bad, steps="detect,repair")
>>> found = changes(res, bad)
>>> out = apply(bad, res, {c.id: "reject" for c in found})
>>> bool(np.array_equal(out.rotations, bad.rotations))
True
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from ..errors import MissingFileError, MocapError, MocapFormatError
from ..markerset import MarkerSet
from ..motion import Motion
from ..joints import mirror_pairs
from .ik import contact_segments
from .ssa.cues import cause_names
from ..digest import take_digest
from .ties import SplitTieError, split_message, swap_cells, tie_groups
from ..words import frame_span, plural

__all__ = ["FORMAT", "ACCEPT", "REJECT", "Change", "changes", "apply", "take_digest", "template", "read_decisions",
           "check_decisions", "check_record", "record_problem", "as_written", "accepted_cells", "flag_segments",
           "frame_note", "frames_note", "review", "check_document", "cleaning_digest", "cleaning_stamp", "check_cleaning", "check_named",
           "unnamed_changes", "applying_notes", "ids_notes", "request_difference", "check_request", "check_choices", "record_wanted", "DuplicateKeyError",
           "RECORD_FLAG", "RECORD_KEYWORD", "review_mode", "tied", "tied_lines", "check_ties"]

#: How a refusal names the record of the cleaning reviewed: the CLI's option, and ``mocapkit.clean``'s keyword.
RECORD_FLAG = "--record"
RECORD_KEYWORD = "record="


def review_mode(option: str = RECORD_FLAG) -> str:
    """Review mode as the caller asks for it, by how it gives a record (``option``): ``steps='detect'`` for
    ``mocapkit.clean`` (:data:`RECORD_KEYWORD`), ``--steps detect`` for the command (:data:`RECORD_FLAG`)."""
    return "steps='detect'" if option == RECORD_KEYWORD else "--steps detect"

FORMAT = "mocapkit.decisions/1"
ACCEPT, REJECT = "accept", "reject"
MAX_FILE_BYTES = 32 * 2**20  # a decisions file lists ids and words; anything larger is not one
_STEPS = ("fill", "repair", "denoise")  # the steps that change cells, in the order they run


@dataclass(frozen=True)
class Change:
    """One contiguous edit of one joint: frames ``first``..``last`` (inclusive) changed by ``step``.

    ``step``: ``"fill"``, ``"repair"``, ``"denoise"``, or several joined by
    ``"+"`` where more than one step changed these cells; ``method``: how the
    step(s) did it (from the record); ``max_deg``: the largest rotation change
    of the joint over these frames in degrees (geodesic angle between input
    and cleaned rotation; NaN where the input was missing in every frame of
    the change); ``reason``: why the step changed the cells (missing, flagged
    with its MDM and the rules that flagged it, noise level).
    A cell counts as missing as :meth:`Motion.missing` says: the root's cell
    also where only its position was missing (its observed rotation is kept,
    so an angle there would only measure rounding).
    """

    id: str
    joint: str
    joint_index: int
    first: int
    last: int
    step: str
    method: str
    max_deg: float
    reason: str

    @property
    def frames(self) -> int:
        return self.last - self.first + 1

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["max_deg"] = None if math.isnan(self.max_deg) else round(self.max_deg, 3)
        return d

    def __str__(self) -> str:
        size = "was missing" if math.isnan(self.max_deg) else f"{_deg(self.max_deg)} deg"
        return f"{self.id}: {self.joint} {frame_span(self.first, self.last)} ({self.step}, {size})"


def _runs(result) -> list[tuple[int, int, int, int]]:
    """``(joint, first, last, code)`` of every run of equal non-zero step code, by first frame then joint."""
    masks = (result.filled, result.repaired, result.denoised)
    code = sum(np.asarray(m, dtype=np.int64) << k for k, m in enumerate(masks))  # (F, J): bit k = step k changed it
    F, J = code.shape
    out = []
    for j in range(J):
        col = code[:, j]
        if not col.any():
            continue
        edges = np.flatnonzero(np.diff(col)) + 1
        starts = np.concatenate([[0], edges])
        ends = np.concatenate([edges, [F]]) - 1
        out.extend((j, int(a), int(b), int(col[a])) for a, b in zip(starts, ends) if col[a])
    out.sort(key=lambda r: (r[1], r[0]))
    return out


def _step_name(code: int) -> str:
    return "+".join(s for k, s in enumerate(_STEPS) if code >> k & 1)


def _change_id(result, j: int, a: int, b: int, code: int) -> str:
    return f"{_step_name(code)}:{result.joint_names[j]}:{a}-{b}"


def _cleaned(result) -> dict:
    """The cleaned values of the changed cells, as :attr:`CleanResult.samples` holds them."""
    if result.samples is not None:
        return result.samples
    m = result.motion
    if m is None:
        raise MocapError("the clean record holds no cleaned samples (written by an older mocapkit) and no cleaned "
                         "take was given; clean the take again")
    cells = result.changed
    out = {"rotations": np.asarray(m.rotations)[cells], "root": np.asarray(m.root_positions)[cells[:, 0]]}
    if m.translations is not None:
        out["translations"] = np.asarray(m.translations)[cells]
    return out


def record_problem(original: Motion, result) -> str:
    """Why ``result`` is not the record of a cleaning of ``original``; "" when it is, as far as the record tells.

    Another rig (joint names), another length or rate, or, for a record that keeps the
    :func:`take_digest` of the take it cleaned (:attr:`CleanResult.take_sha256`), other samples: a
    record of another take of the same rig and length would otherwise put that take's cleaned values
    into this one. A record written before the digest was kept (``take_sha256`` "") can only be
    checked by rig, length and rate.
    """
    if not isinstance(original, Motion):
        raise TypeError(f"original must be a mocapkit Motion, got {type(original).__name__}")
    if tuple(original.skeleton.joint_names) != tuple(result.joint_names):
        return (f"the clean record is of another rig ({plural(len(result.joint_names), 'joint')} "
                f"{', '.join(result.joint_names[:3])}, ...), not this take's")
    if original.num_frames != result.num_frames or not math.isclose(original.fps, result.fps):
        return (f"the clean record is of another take ({plural(result.num_frames, 'frame')} at "
                f"{result.fps:g} fps; this take has {original.num_frames} at {original.fps:g})")
    digest = getattr(result, "take_sha256", "")
    if digest and digest != take_digest(original):
        return (f"the clean record is of another take (the same rig, {plural(result.num_frames, 'frame')} at "
                f"{result.fps:g} fps, but other samples than this take's)")
    return ""


def check_record(original: Motion, result, path) -> None:
    """Refuse, in one line naming the record ``path``, a record that is not of ``original`` (:func:`record_problem`).

    Checked before the decisions are checked against the record: a record of another take makes every
    decision look wrong, and the line then names the file that is.
    """
    problem = record_problem(original, result)
    if problem:
        raise MocapFormatError(path, problem)


#: a cleaned rotation within this angle of what the output file holds is kept bit for bit (degrees)
HELD_TOLERANCE_DEG = 1e-9


def as_written(result, original: Motion, held):
    """``result`` with each changed cell's cleaned rotation as the output file holds it.

    ``held(motion) -> (F, J, 4)``: the rotations a file written from ``motion`` reads back as, e.g.
    :func:`mocapkit.io.asfamc.amc_held_rotations` for an AMC, whose bones with fewer than three dofs
    cannot hold every rotation. The changes' sizes (:func:`changes`), the report and the record then
    say what the file holds, not a rotation it could not. A cleaned rotation within
    :data:`HELD_TOLERANCE_DEG` of what the file holds is kept bit for bit: a record made for such a
    file applies unchanged (accepting every change gives the same output as the cleaning did), and a
    bone with three dofs keeps its cleaned values. Every other sample is left as it is.
    """
    cells = result.changed
    if not cells.any():
        return result
    vals = _cleaned(result)
    rot = np.array(original.rotations)
    rot[cells] = vals["rotations"]
    new = np.asarray(held(dataclasses.replace(original, rotations=rot)))[cells]
    kept = ~(_chord_angles_deg(vals["rotations"], new) > HELD_TOLERANCE_DEG)  # NaN (a missing value): kept
    new = np.where(kept[:, None], vals["rotations"], new)
    out = result
    if result.samples is not None:
        out = dataclasses.replace(out, samples={**result.samples, "rotations": new})
    if result.motion is not None:
        full = np.array(result.motion.rotations)
        full[cells] = new
        out = dataclasses.replace(out, motion=dataclasses.replace(result.motion, rotations=full))
    return out


def _check_take(original: Motion, result) -> None:
    problem = record_problem(original, result)
    if problem:
        raise MocapError(f"{original.name or 'the take'}: {problem}")


def _deg(x: float) -> str:
    """A change's size: one decimal, or two significant digits under 0.1 deg (a real change never reads 0.0)."""
    return f"{x:.1f}" if x >= 0.1 or x == 0 else f"{x:.2g}"


def _angles_deg(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Geodesic angle (degrees) between unit quaternions (..., 4); NaN where either is missing."""
    dot = np.abs(np.sum(q0 * q1, axis=-1))
    with np.errstate(invalid="ignore"):
        return np.degrees(2.0 * np.arccos(np.clip(dot, 0.0, 1.0)))


def _chord_angles_deg(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Geodesic angle (degrees) between unit quaternions (..., 4) from their chord; NaN where either is missing.

    Exact near 0, where the arccos of the dot (:func:`_angles_deg`) reads a rounding error of 1e-16 as 1e-6 deg:
    :func:`as_written` applied to a record it made keeps its values bit for bit, so the record's
    :func:`cleaning_digest` is the one the report showed.
    """
    chord = np.minimum(np.linalg.norm(q0 - q1, axis=-1), np.linalg.norm(q0 + q1, axis=-1))
    with np.errstate(invalid="ignore"):
        return np.degrees(4.0 * np.arcsin(np.clip(chord / 2.0, 0.0, 1.0)))


def _reason(result, step_code: int, j: int, a: int, b: int, missing: np.ndarray) -> str:
    parts = []
    if step_code & 1:
        zeros = getattr(result, "zeros", None)
        nz = 0 if zeros is None else int(zeros[a:b + 1, j].sum())
        n = int((missing[a:b + 1, j] & (True if zeros is None else ~zeros[a:b + 1, j])).sum())
        if nz:  # a dropout the take wrote as 0 (mocapkit.cleaning.zeros), filled as missing
            parts.append(f"written as 0 (a dropout) in {nz} of {plural(b - a + 1, 'frame')}")
        if n or not nz:
            parts.append(f"missing in {n} of {plural(b - a + 1, 'frame')}")
    if step_code & 2:
        mdm = float(np.nanmax(result.mdm[a:b + 1, j])) if result.mdm.size else float("nan")
        flagged = bool(result.flags[a:b + 1, j].any())
        causes = getattr(result, "causes", None)
        rules = [] if causes is None or not flagged else cause_names(causes[a:b + 1, j])
        # the rule first: the held, swap, offset and drift rules flag below the MDM threshold too
        parts.append(f"flagged: {', '.join(rules)} (MDM up to {mdm:.2f})" if rules
                     else f"flagged by self-similarity (MDM up to {mdm:.2f})" if flagged
                     else "repaired with a flagged joint")
    if step_code & 4:
        level = result.noise[a:b + 1, j]
        level = level[np.isfinite(level)]
        limit = result.params.get("noise_deg")
        parts.append(f"noisy: level up to {level.max():.2f} deg" + (f" (limit {limit:g})" if limit else "")
                     if level.size else "noisy")
    return "; ".join(parts)


def changes(result, original: Motion) -> list[Change]:
    """Every change of a clean record, by first frame then joint (module docstring).

    Parameters
    ----------
    result : CleanResult
        From :func:`~mocapkit.cleaning.pipeline.clean` or :meth:`CleanResult.load`.
    original : Motion
        The take as it was before cleaning (the sizes in degrees compare with it).

    Returns
    -------
    list of Change, one per contiguous run of cells of one joint changed by the same step(s).
    """
    _check_take(original, result)
    runs = _runs(result)
    if not runs:
        return []
    cells = result.changed
    cleaned = np.full(original.rotations.shape, np.nan)
    cleaned[cells] = _cleaned(result)["rotations"]
    methods = {s.name: s.method for s in result.steps}
    missing = original.missing()
    out = []
    for j, a, b, code in runs:
        ang = _angles_deg(original.rotations[a:b + 1, j], cleaned[a:b + 1, j])
        ang[missing[a:b + 1, j]] = np.nan  # a cell missing its root position too: it was missing, not turned
        size = float(np.nanmax(ang)) if np.isfinite(ang).any() else float("nan")
        steps = _step_name(code).split("+")
        out.append(Change(
            id=_change_id(result, j, a, b, code), joint=result.joint_names[j], joint_index=j, first=a, last=b,
            step="+".join(steps), method="; ".join(methods.get(s, s) for s in steps), max_deg=size,
            reason=_reason(result, code, j, a, b, missing),
        ))
    return out


def check_choices(decisions: Mapping[str, str], ids) -> None:
    """Raise ValueError, in words, for a key of ``decisions`` that is none of the change ``ids`` of this cleaning,
    or a choice other than ``accept``/``reject`` (a joint-angle take's or a marker capture's changes alike)."""
    unknown = [k for k in decisions if k not in ids]
    if unknown:
        raise ValueError(f"{plural(len(unknown), 'change id')} "
                         f"{'is not a change' if len(unknown) == 1 else 'are not changes'} of this cleaning: "
                         f"{', '.join(map(repr, unknown[:3]))}{', ...' if len(unknown) > 3 else ''}")
    bad = {v for v in decisions.values() if v not in (ACCEPT, REJECT)}
    if bad:
        raise ValueError(f"a decision is 'accept' or 'reject', got {', '.join(map(repr, sorted(map(str, bad))))}")


def tied(result) -> list[tuple[list[str], str]]:
    """The changes of ``result`` a person accepts or rejects together: ``(ids, why)`` per group, by first change
    (:func:`mocapkit.cleaning.ties.tie_groups`: the two sides of one left/right swap, touching runs of one joint
    made by nested steps). A record without :attr:`CleanResult.causes` ties no swap."""
    runs = _runs(result)
    rows = [(j, a, b, frozenset(_step_name(code).split("+"))) for j, a, b, code in runs]
    swaps = swap_cells(getattr(result, "causes", None), result.changed.shape)
    return [([_change_id(result, *runs[k]) for k in g], why)
            for g, why in tie_groups(rows, swaps, mirror_pairs(result.joint_names))]


#: at most this many :func:`tied_lines`, then a count of the rest
MAX_TIED_LINES = 3


def tied_lines(result) -> list[str]:
    """One line per group of :func:`tied` changes, naming them and saying why (the marker side's
    :func:`mocapkit.cleaning.markers.decisions.tied_lines` words), the first :data:`MAX_TIED_LINES` and a count of
    the rest: what ``clean``'s console says beside its summary, so that a person editing a decisions file knows."""
    groups = tied(result)
    out = [f"{', '.join(ids)}: accepted or rejected together, as {why}" for ids, why in groups[:MAX_TIED_LINES]]
    if len(groups) > MAX_TIED_LINES:
        out.append(f"... and {len(groups) - MAX_TIED_LINES} more groups of changes accepted or rejected together "
                   "(the report ties them)")
    return out


def check_ties(decisions: Mapping[str, str], result) -> None:
    """Raise :class:`~mocapkit.cleaning.ties.SplitTieError` (a ValueError), naming the changes and why, where
    ``decisions`` accepts some changes of a :func:`tied` group and rejects others (a change not named is
    accepted): the take written would hold half a fix."""
    for ids, why in tied(result):
        choices = [decisions.get(i, ACCEPT) for i in ids]
        if len(set(choices)) > 1:
            raise SplitTieError(split_message(ids, choices, why, ACCEPT))


def accepted_cells(result, decisions: Mapping[str, str]) -> np.ndarray:
    """(F, J) bool: the cells of the changes ``decisions`` accepts (a change it does not name is accepted).

    Raises ValueError for an id that is not a change of ``result`` or a choice other than accept/reject, and
    :class:`~mocapkit.cleaning.ties.SplitTieError` for decisions that split changes decided together
    (:func:`check_ties`).
    """
    runs = _runs(result)
    ids = {_change_id(result, *r): r for r in runs}
    check_choices(decisions, ids)
    check_ties(decisions, result)
    out = np.zeros(result.changed.shape, dtype=bool)
    for cid, (j, a, b, _) in ids.items():
        if decisions.get(cid, ACCEPT) == ACCEPT:
            out[a:b + 1, j] = True
    return out


def apply(original: Motion, result, decisions: Mapping[str, str]) -> Motion:
    """The input take with only the accepted changes; every other sample bit-identical to ``original``.

    Parameters
    ----------
    original : Motion
        The take before cleaning (same joints, frames and rate as the record).
    result : CleanResult
        The record of the cleaning, with its cleaned samples (:attr:`CleanResult.samples`) or its ``motion``.
    decisions : mapping of change id to "accept" or "reject"
        Changes not named are accepted. :func:`read_decisions` reads a decisions file into one.

    Returns
    -------
    Motion with the input's skeleton, rate and name: rotations, root positions
    and animated offsets are the cleaned values in the cells of accepted
    changes and the input's everywhere else.
    """
    _check_take(original, result)
    acc = accepted_cells(result, decisions)
    cells = result.changed
    vals = _cleaned(result)
    rot = np.array(original.rotations)
    rot[acc] = vals["rotations"][acc[cells]]  # both in row-major cell order
    root = np.array(original.root_positions)
    root[acc[:, 0]] = vals["root"][acc[cells[:, 0], 0]]
    tr = original.translations
    if tr is not None and "translations" in vals:
        tr = np.array(tr)
        tr[acc] = vals["translations"][acc[cells]]
    return dataclasses.replace(original, rotations=rot, root_positions=root, translations=tr)


# -- the decisions file ------------------------------------------------------------------------


def cleaning_digest(result) -> str:
    """SHA-256 (hex) of what a person reviews of a cleaning: which cells each step changed, their cleaned values and
    the options that shaped them (``params["request"]``, :func:`mocapkit.batch_request.clean_request`; None for a
    cleaning made in Python).

    The change ids alone do not tell two cleanings apart: a take cleaned again with another context or threshold
    can give the same ids and other values. Decisions are applied only to the cleaning with this digest
    (:func:`check_cleaning`): the record the report was made from, or a new cleaning that gives the very same
    values (cleaning is deterministic).
    """
    h = hashlib.sha256()
    h.update(json.dumps([list(result.joint_names), list(result.changed.shape), result.params.get("request")],
                        sort_keys=True, default=str).encode())
    for mask in (result.filled, result.repaired, result.denoised):
        h.update(np.packbits(np.asarray(mask, dtype=bool)).tobytes())
    if result.changed.any():
        vals = _cleaned(result)
        for key in ("rotations", "root", "translations"):
            if key in vals:
                a = np.ascontiguousarray(vals[key], dtype="<f8")
                h.update(key.encode() + np.where(np.isnan(a), np.nan, a).tobytes())  # one bit pattern for every NaN
    return h.hexdigest()


def cleaning_stamp(result, record="") -> dict:
    """The ``"cleaning"`` entry of a decisions document: the :func:`cleaning_digest` of the cleaning reviewed, its
    number of changes, the options it was asked for (``request``) and the ``record`` it was written to ("" where
    none was), so that a refusal can say what to pass."""
    return {"sha256": cleaning_digest(result), "changes": len(_runs(result)),
            "request": result.params.get("request"), "record": str(record) if record else ""}


def template(original: Motion, found: list[Change], take: str = "", output: str = "",
             decisions: Mapping[str, str] | None = None, result=None, record="") -> dict:
    """The decisions document for ``found`` (every change "accept" unless ``decisions`` says otherwise).

    With ``result`` (the clean record ``found`` lists) it keeps :func:`cleaning_stamp` as ``"cleaning"``
    (``record``: where that record was written): the decisions then apply to that cleaning only.
    """
    from .. import __version__

    chosen = dict(decisions or {})
    doc = {
        "format": FORMAT,
        "mocapkit": __version__,
        "take": {"name": take or original.name, "frames": original.num_frames, "joints": original.num_joints,
                 "sha256": take_digest(original)},
        "output": output,
    }
    if result is not None:
        doc["cleaning"] = cleaning_stamp(result, record)
    doc["decisions"] = {c.id: chosen.get(c.id, ACCEPT) for c in found}
    return doc


def read_decisions(path) -> dict:
    """Read and check a decisions file's form; returns the document (see :func:`template`).

    Raises :class:`~mocapkit.errors.MocapFormatError` naming the file: not JSON,
    not a decisions file, another format version, a choice other than accept/reject.
    """
    path = Path(path)
    try:
        if path.stat().st_size > MAX_FILE_BYTES:
            raise MocapFormatError(path, f"over {MAX_FILE_BYTES >> 20} MB; not a mocapkit decisions file")
        doc = json.loads(path.read_text(encoding="utf-8-sig"), object_pairs_hook=_unique_keys)  # a BOM is fine
    except DuplicateKeyError as exc:
        raise MocapFormatError(path, f"{exc}: JSON would keep only the last, so say each once") from None
    except FileNotFoundError:
        raise MissingFileError(path) from None
    except IsADirectoryError:
        raise MocapFormatError(path, "a folder, not a decisions file") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise MocapFormatError(path, f"not JSON ({exc})") from None
    except RecursionError:
        raise MocapFormatError(path, "JSON nested too deeply; not a mocapkit decisions file") from None
    return check_document(doc, path)


def what_clean_does(path) -> str:
    """What ``mocapkit clean --decisions PATH`` would do with the decisions file ``path``, in one line (``mocapkit
    info`` says it): refused, with the refusal's own words (:func:`read_decisions`: a choice other than "accept" or
    "reject", a change named twice, no take digest, ...), or how many changes it accepts and rejects and what
    becomes of a change it does not name (accepted for a file written by hand; refused for one the report made, which
    names every change). ``info`` counted every choice but "reject" as accepted and a change named twice by its
    last choice, the very reading ``clean`` refuses."""
    try:
        doc = read_decisions(path)
    except MocapFormatError as exc:
        return f"refused by clean --decisions: {exc.reason}"
    chosen = list(doc["decisions"].values())
    rejected = chosen.count(REJECT)
    counts = f"{len(chosen) - rejected} accepted, {rejected} rejected"
    if "cleaning" not in doc:
        return f"{counts}; a change of the cleaning it does not name is accepted (a file written by hand)"
    total = doc["cleaning"].get("changes")
    if isinstance(total, int) and total > len(chosen):
        return (f"{counts}; refused by clean --decisions: it names {len(chosen)} of the "
                f"{plural(total, 'change')} it was made for (the report names each)")
    return f"{counts}; a change of the cleaning it does not name is refused (the report names each)"


def check_document(doc, path) -> dict:
    """``doc`` (a decisions document, read from ``path`` or given in Python, e.g. to :func:`mocapkit.clean`) after
    checking its form as :func:`read_decisions` does: a mocapkit decisions document of this format version, with the
    take's digest, choices that are "accept" or "reject", and a well-formed ``"cleaning"`` stamp where there is one.
    Refused in one line naming ``path``."""
    fmt = doc.get("format") if isinstance(doc, dict) else None
    if not isinstance(fmt, str) or not fmt.startswith("mocapkit.decisions/"):
        raise MocapFormatError(path, f"not a mocapkit decisions file (no \"format\": \"{FORMAT}\")")
    if fmt != FORMAT:
        raise MocapFormatError(path, f"decisions format {fmt!r}; this mocapkit reads {FORMAT!r}")
    take, dec = doc.get("take"), doc.get("decisions")
    if not isinstance(take, dict) or not isinstance(take.get("sha256"), str):
        raise MocapFormatError(path, "no \"take\" with the \"sha256\" of the take the decisions are for")
    if not isinstance(dec, dict):
        raise MocapFormatError(path, "\"decisions\" must map change ids to \"accept\" or \"reject\"")
    bad = [k for k, v in dec.items() if v not in (ACCEPT, REJECT)]
    if bad:
        raise MocapFormatError(path, f"change {bad[0]!r}: {dec[bad[0]]!r}; a decision is \"accept\" or \"reject\"")
    stamp = doc.get("cleaning")
    if stamp is not None and (not isinstance(stamp, dict) or not isinstance(stamp.get("sha256"), str)):
        raise MocapFormatError(path, "\"cleaning\" must hold the \"sha256\" of the cleaning the decisions were made on")
    return doc


class DuplicateKeyError(ValueError):
    """A JSON object naming one key twice (:func:`read_decisions` refuses it: ``json`` keeps only the last)."""


def _unique_keys(pairs: list) -> dict:
    """``object_pairs_hook`` for :func:`json.loads`: the object, or :class:`DuplicateKeyError` for a key said twice.

    A hand-edited file naming a change ``"reject"`` and then again ``"accept"`` would otherwise be read as an
    accept, silently.
    """
    out = {}
    for key, value in pairs:
        if key in out:
            what = "change" if value in (ACCEPT, REJECT) else "key"
            raise DuplicateKeyError(f"{what} {key!r} is named twice")
        out[key] = value
    return out


def check_decisions(doc: dict, path, original: Motion, result=None, record=None, fresh: bool = False,
                    option: str = RECORD_FLAG, take: str = "") -> dict:
    """The choices of ``doc`` (from :func:`read_decisions`) after checking they fit this take and this record.

    Refused, in one line naming ``path``: decisions for another take (its
    digest differs from :func:`take_digest` of ``original``), decisions made on
    another cleaning than ``result`` (:func:`check_cleaning`; ``record``: the
    path ``result`` was read from, ``fresh``: ``result`` is a new cleaning), an
    id that is not a change of ``result``, or a file made by the report that
    leaves a change unnamed (:func:`check_named`). With ``result`` None only the
    take is checked (before a cleaning, so that decisions for another take are
    refused first). ``option``: how a refusal names the record to give (:func:`record_wanted`); ``take``: the
    input's file name, as a refusal names it (default the take's name).
    """
    named = doc["take"]
    if named["sha256"] != take_digest(original):
        what = f"{named.get('name', '?')}, {named.get('frames', '?')} frame{'' if named.get('frames') == 1 else 's'}"
        raise MocapFormatError(path, f"decisions for another take ({what}), not {take or original.name or 'this take'} "
                               f"({plural(original.num_frames, 'frame')}): its samples differ")
    if result is None:
        return dict(doc["decisions"])
    check_cleaning(doc, path, result, record, fresh, option)
    try:
        accepted_cells(result, doc["decisions"])
    except SplitTieError as exc:
        raise MocapFormatError(path, str(exc)) from None
    except ValueError as exc:
        raise MocapFormatError(path, f"{exc} (decisions made for another cleaning of the take?)") from None
    check_named(doc, path, result)
    return dict(doc["decisions"])


def _is_review_mode(result) -> bool:
    """Whether ``result`` is of ``--steps detect`` (review mode): detection ran and no step that changes cells."""
    return bool(result.steps) and all(s.name == "detect" for s in result.steps)


def check_cleaning(doc: dict, path, result, record=None, fresh: bool = False, option: str = RECORD_FLAG) -> None:
    """Refuse, in one line, decisions that would be applied to values the person did not review.

    A record that holds no changes (review mode, ``--steps detect``) while ``doc`` names some is refused naming
    the record. A ``doc`` keeping the :func:`cleaning_digest` of the cleaning it was made on (``"cleaning"``,
    written by the report) applies only to a cleaning with that digest: another record, or a new cleaning made
    with other options (another ``--context``, ``--threshold``, ...), gives other values under the same ids. A
    ``doc`` without it (an earlier mocapkit's, or written by hand) is taken on its ids for a record (``record``),
    and refused for a new cleaning (``fresh``): nothing tells that cleaning is the one reviewed. ``option``: how a
    refusal names the record to give (:func:`record_wanted`).
    """
    _check_has_changes(doc, path, result, record, option)
    stamp = doc.get("cleaning")
    if stamp is None:
        if fresh:
            _check_stamped(doc, path, option)
        return
    if stamp["sha256"] == cleaning_digest(result):
        return
    want = record_wanted(stamp, option)
    if not fresh:
        where = f"the record {record}" if record is not None else "this clean record"
        if record is not None and _names_record(stamp, record):  # the record it names, written again since
            raise MocapFormatError(path, f"made on another cleaning than {where} (its changes or cleaned values "
                                         "differ), though it names that record: the record was written again since "
                                         "the review (the take cleaned again); review that record's report anew")
        raise MocapFormatError(path, f"made on another cleaning than {where} (its changes or cleaned values differ); "
                                     f"give the record of the cleaning reviewed: {want}")
    diff = request_difference(stamp.get("request"), result.params.get("request"), option)
    diff = diff or "its changes or cleaned values differ"
    raise MocapFormatError(path, f"made on another cleaning than this new one: {diff}; apply them to the reviewed "
                                 f"values: {want}, or clean with the same options")


def _names_record(stamp: dict, record) -> bool:
    """Whether the record a decisions file names (``stamp["record"]``) is the file ``record``."""
    named = stamp.get("record")
    if not isinstance(named, str) or not named:
        return False
    return os.path.realpath(named) == os.path.realpath(os.fspath(record))


def _check_stamped(doc: dict, path, option: str = RECORD_FLAG) -> None:
    """Refuse, for a new cleaning, a ``doc`` that keeps no digest of the cleaning it was made on."""
    if doc.get("cleaning") is None:
        raise MocapFormatError(path, "keeps no digest of the cleaning it was made on (an earlier mocapkit's file, or "
                                     "one written by hand): a new cleaning may differ from the one reviewed; give "
                                     f"that cleaning's record with {option}")


def _check_has_changes(doc: dict, path, result, record=None, option: str = RECORD_FLAG) -> None:
    """Refuse decisions naming changes for a cleaning that made none, saying why it made none where it is review
    mode (``--steps detect``, ``steps='detect'``, which only flags: :func:`review_mode`): naming the record ``record`` where one was given, else ``path``."""
    named = doc["decisions"]
    if not named or result.changed.any():
        return
    mode = f"is from review mode ({review_mode(option)}) and " if _is_review_mode(result) else ""
    if record is not None:
        raise MocapFormatError(record, f"the clean record {mode}holds no changes, while {Path(path).name} names "
                                       f"{len(named)}; give the record of the cleaning the decisions were made on")
    raise MocapFormatError(path, f"names {plural(len(named), 'change')}, and this cleaning {mode}changed nothing; give the "
                                 f"record of the cleaning the decisions were made on ({option})")


def check_request(doc: dict, path, request: dict, option: str = RECORD_FLAG) -> None:
    """Refuse, before a new cleaning, decisions it cannot be the reviewed cleaning for: a file that keeps no digest
    of its cleaning (:func:`check_cleaning` would refuse it after cleaning), or one made on a cleaning asked for
    with other options than ``request`` (:func:`mocapkit.batch_request.clean_request`; its digest, which keeps the options,
    cannot match). A cleaning with a context can take minutes: the line comes first. One line naming ``path``, the
    options that differ and the record to pass instead (``option``: how it is given, :func:`record_wanted`)."""
    stamp = doc.get("cleaning")
    if stamp is None:
        _check_stamped(doc, path, option)
        return
    diff = request_difference(stamp.get("request"), request, option)
    if diff:
        raise MocapFormatError(path, f"made on another cleaning than this new one: {diff}; apply them to the "
                                     f"reviewed values: {record_wanted(stamp, option)}, or clean with the same options")


def record_wanted(stamp: dict, option: str = RECORD_FLAG) -> str:
    """What to pass to apply decisions to the cleaning reviewed: the record it was written to, given as ``option``
    says: :data:`RECORD_FLAG` (the CLI's ``--record PATH``) or :data:`RECORD_KEYWORD` (``mocapkit.clean``'s
    ``record='PATH'``)."""
    reviewed = stamp.get("record") if isinstance(stamp.get("record"), str) else ""
    if not reviewed:
        return f"{option} with the record written beside the reviewed output"
    return f"{option}{reviewed!r}" if option.endswith("=") else f"{option} {reviewed}"


def request_difference(was, now, option: str = RECORD_FLAG) -> str:
    """How the options of two cleanings differ, in words naming each as the caller gives it
    (:func:`mocapkit.cleaning.request_words.request_changes`): ``option`` (:data:`RECORD_FLAG`, the CLI's
    ``--record``, or :data:`RECORD_KEYWORD`, ``record=``) says which, the command line's flags
    ("reviewed without --context (now --context /data/ctx), reviewed with --threshold 0.5 (now 0.4)") or Python's
    keywords ("reviewed with threshold=0.5 (now 0.4)"); "" where they are the same or either is not known (None: a
    cleaning made in Python)."""
    from .request_words import request_changes

    if not isinstance(was, dict) or not isinstance(now, dict):
        return ""
    return ", ".join(f"reviewed {change}" for change in request_changes(was, now, not option.endswith("=")))


def unnamed_changes(doc: dict, result) -> list[str]:
    """The ids of the changes of ``result`` that ``doc`` does not name (accepted when applied, unless refused)."""
    named = doc["decisions"]
    return [cid for cid in (_change_id(result, *r) for r in _runs(result)) if cid not in named]


def check_named(doc: dict, path, result) -> None:
    """Refuse, naming ``path``, a file made by the report (one keeping ``"cleaning"``) that leaves changes unnamed.

    The report names every change; one missing was taken out by hand, and applying it would accept a change nobody
    reviewed. A file without ``"cleaning"`` (written by hand) may name only some: the others are accepted, and
    :func:`applying_notes` says how many.
    """
    if "cleaning" not in doc:
        return
    left = unnamed_changes(doc, result)
    if left:
        raise MocapFormatError(path, f"names {len(doc['decisions'])} of the {plural(len(left) + len(doc['decisions']), 'change')} "
                                     f"it was made for; {len(left)} not named ({left[0]!r}"
                                     f"{', ...' if len(left) > 1 else ''}): say \"accept\" or \"reject\" for each")


def applying_notes(doc: dict, path, result) -> list[str]:
    """What a person applying ``doc`` (read from ``path``) to the record ``result`` should know, one line each: a
    file that keeps no digest of its cleaning (taken on its ids), and the changes it does not name (accepted)."""
    return ids_notes(doc, path, [_change_id(result, *r) for r in _runs(result)])


def ids_notes(doc: dict, path, ids) -> list[str]:
    """:func:`applying_notes` for a cleaning whose changes are ``ids`` (a joint-angle take's or a marker capture's:
    :func:`mocapkit.cleaning.markers.decisions.changes`), so that both say the same lines."""
    out = []
    if "cleaning" not in doc:
        out.append(f"{path} keeps no digest of the cleaning it was made on (an earlier mocapkit's file, or written "
                   "by hand): it was applied to the record as its change ids match; make sure that record is the one "
                   "reviewed")
    named = doc["decisions"]
    left = [cid for cid in ids if cid not in named]
    if left:
        total = len(ids)
        out.append(f"{path} names {total - len(left)} of {plural(total, 'change')}: the {len(left)} it does not name "
                   f"{'was' if len(left) == 1 else 'were'} accepted")
    return out


def flag_segments(result) -> list[dict]:
    """Every flagged run of frames of one joint, by first frame then joint name, and the rules that flagged it.

    Each is ``{"joint", "joint_index", "first", "last", "why"}`` (frames inclusive; ``why``: the words
    of :data:`~mocapkit.cleaning.ssa.cues.CAUSES` for the rules that flagged any of its cells, empty for
    a record without :attr:`CleanResult.causes`). Flags are what detection found, whether or not a step
    changed those cells: in review mode (``--steps detect``) they are all the report has to show.
    """
    flags = np.asarray(result.flags, dtype=bool)
    causes = getattr(result, "causes", None)
    out = [{"joint": result.joint_names[j], "joint_index": int(j), "first": a, "last": b - 1,
            "why": [] if causes is None else cause_names(causes[a:b, j])}
           for j in np.flatnonzero(flags.any(axis=0)) for a, b in contact_segments(flags[:, j])]
    out.sort(key=lambda d: (d["first"], d["joint"]))  # as Detection.segments() orders them
    return out


def frame_note(take: str = "", first: int | None = None) -> str:
    """How the frame numbers of changes, flags and ids relate to the input file's own.

    They are 0-based indexes into the take (frame 0 is its first frame) whatever the file says: the
    change ids of decisions files keep them. ``first``: the number the file ``take`` gives the take's first
    frame (an AMC's, a TRC's ``Frame#``, a C3D's first frame; None for a file that does not number
    them, :func:`mocapkit.io.takes.file_first_frame`), said when it is not 0. The line names the capture's
    frame that frame 0 is, not where the file starts counting: a part of a take (``markers[100:]`` of
    Eb015pr.c3d, which numbers its frames from 1) starts at its frame 101.
    """
    text = "frame numbers count from 0, the take's first frame"
    if first is not None and first != 0:
        text += (f", which is {take or 'the input'}'s frame {first}: its frame {first + 10} is frame 10 here")
    return text


def frames_note(path=None, take=None) -> str:
    """The line a summary says about frame numbers for a take read from the file ``path``: :func:`frame_note`
    when the file numbers its frames from other than 0 (an AMC from 1, a TRC's ``Frame#``, a C3D's first
    frame), "" when it does not number them (a BVH, a motion npz) or counts from 0, as the take's indexes do.

    ``take``: the :class:`~mocapkit.markerset.MarkerSet` read from ``path``, whose source keeps the first
    frame's number (:func:`mocapkit.io.takes.file_first_frame`); with ``path`` None it is named by its
    ``name``. :meth:`CleanResult.summary <mocapkit.cleaning.clean_record.CleanResult.summary>` and
    :meth:`MarkerCleanResult.summary <mocapkit.cleaning.markers.MarkerCleanResult.summary>` say it, so
    ``mocapkit.clean`` and ``mocapkit clean`` say the same.
    """
    from ..io.takes import file_first_frame
    from ..markerset import MarkerSet

    if path is None and not isinstance(take, MarkerSet):
        return ""
    first = file_first_frame("" if path is None else path, take)
    if first in (None, 0):
        return ""
    return frame_note(Path(path).name if path is not None else take.name, first)


def review(original: Motion, result, take: str = "", output: str = "", decisions: Mapping[str, str] | None = None,
           first_frame: int | None = None, record="", command: dict | None = None) -> dict:
    """What the HTML report needs to let a person decide: ``{"changes": [...], "decisions": document, "flags": [...],
    "frames": note}``.

    ``changes``: :meth:`Change.as_dict` of :func:`changes` (a change :func:`tied` to others names them all in
    ``"tied"`` and says why in ``"tied_why"``: the list accepts or rejects them together); ``decisions``:
    :func:`template` with the choices of ``decisions`` (every other change accepted) and the stamp of this cleaning, ``record`` the
    path its record was written to (the page tells the reviewer to pass it); ``flags``: :func:`flag_segments`;
    ``frames``: :func:`frame_note` for the input file ``take`` whose first frame is numbered ``first_frame``;
    ``command``: the input and options of the command the page says to apply the decisions with
    (:func:`mocapkit.cleaning.decided.apply_command`).
    """
    found = changes(result, original)
    together = {i: (ids, why) for ids, why in tied(result) for i in ids}
    return {"changes": [{**c.as_dict(), **({"tied": together[c.id][0], "tied_why": together[c.id][1]}
                                            if c.id in together else {})} for c in found],
            "decisions": template(original, found, take, output, decisions, result=result, record=record),
            "flags": flag_segments(result), "frames": frame_note(take, first_frame), "command": command}
