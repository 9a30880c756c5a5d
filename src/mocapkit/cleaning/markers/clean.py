"""Clean a marker capture: undo swapped labels, remove duplicate labels and spikes, fill gaps; record every change.

The marker counterpart of :func:`mocapkit.cleaning.pipeline.clean`. The
steps run in this order because each needs the one before: a swap makes
two large jumps that would look like spikes; a marker put on another's
position for a while (a duplicate label,
:mod:`~mocapkit.cleaning.markers.duplicates`), or a label on another point
from the take's or an occlusion's edge up to a jump (a foreign stretch,
:mod:`~mocapkit.cleaning.markers.foreign`; part of the "duplicates" step), is
judged by its rigid neighbours once the swaps are undone, and its removed samples, like removed
spikes, become gaps the fill closes. Every observed sample that is not an error
comes back bit-identical; a swapped sample comes back re-labelled (its
values unchanged); spike samples and gaps are filled
(:mod:`~mocapkit.cleaning.markers.gaps`). A marker missing in the whole take
stays missing and is listed in ``never_seen``. Points a C3D lists as
modelled quantities (Vicon's joint angles, forces, moments, powers:
:meth:`MarkerSet.modelled`) are not markers and come back as they are.
Nor are unlabelled trajectories (no label in the file, or one
starting with ``*``: :meth:`MarkerSet.unlabelled`): which point on the body
each is, and whether it is the same one each time it appears, is unknown
(HDM05's ``*0`` duplicates LFWT; Gait.trc's 72 are fragments seen where no
labelled marker is), so they come back as read, and no labelled marker's
fill, spike test or swap test uses them: a donor of unknown identity and
rigidity could carry a fill anywhere. Frames where no labelled marker is
seen at the take's start or end are frames where nobody is seen; so are
frames mid-take where none of a subject's markers is (markers share a
``Subject:`` prefix in a multi-subject capture: :func:`mocapkit.markerset.subject_of`):
the subject was out of the volume, and its markers stay missing there
(:attr:`MarkerCleanResult.nobody_seen`).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from ...markerset import check_units, subject_of
from ...words import frame_span, plural
from .counts import sample_counts, unvalidated
from .duplicates import find_duplicates
from .foreign import find_foreign
from .gaps import SMOOTH_S, TOO_LONG, fill_gaps, nobody_seen
from .rigid import distance_stats
from .spikes import longest_spike, spike_mask
from .swaps import undo_swaps

__all__ = ["MarkerFix", "MarkerCleanResult", "clean_markers", "STEPS", "why_left", "left_too_long", "unvalidated"]

STEPS = ("swaps", "duplicates", "spikes", "gaps")


@dataclass(frozen=True)
class MarkerFix:
    """One change: ``kind`` "gap", "spike", "swap", "duplicate" or "foreign" on marker ``marker`` for frames ``start <= f < end``
    (``end`` exclusive, as in Python's slices: ``start 89, end 120`` is the summary's inclusive "frames 89-119").

    ``size_mm``: for a gap, the largest distance between the fill and the
    straight line between its ends (how far the marker moved off it, not an
    error); for a spike or a duplicate, the largest distance of a removed
    sample from its fill; for a swap, the distance between the two markers
    where it starts. ``other``: the marker it swapped with; for a duplicate,
    the marker whose position it was put on (``note``: how that was told).
    Kind "foreign": another point under the marker's label from a take's or
    an occlusion's edge up to a jump (:mod:`~mocapkit.cleaning.markers.foreign`),
    removed and filled as a duplicate is (``note``: the evidence; ``size_mm``
    as for a duplicate, NaN where left missing).
    Kind "coincident" (in :attr:`MarkerCleanResult.coincident`, no change):
    ``marker`` and ``other`` at the same position, which one is the copy
    not told; ``size_mm`` their largest distance there. For a gap (and a gap left
    missing, :attr:`MarkerCleanResult.unfilled`): ``seconds``, its duration
    (s); ``method`` and ``donors``, the fill's model (:class:`GapFill`'s
    method; the donors' names, comma-separated); ``expected_mm``, the fill's
    RMS error on stretches of the same length cut where the marker is seen
    (mm; NaN where none could be cut: the fill is unvalidated); ``note``,
    for a gap left missing, why no fill was plausible; ``ends``, how many
    seen ends a gap has: 1 where it reaches the take's first or last frame
    or frames where nobody is seen (its fill is an extrapolation from that
    one end, and ``size_mm`` measures from the one seen sample); ``models``,
    how many models' fills were averaged (``method`` and ``donors`` then name the best);
    ``fill_note``, why a gap had no donor group although markers were seen
    throughout it: too few of them rigid enough to be donors
    (:func:`~mocapkit.cleaning.markers.gaps.donors_allowed`). For a swap,
    ``order``: where it comes when the swaps are composed (by ``order``, then
    first frame: :func:`~mocapkit.cleaning.markers.swaps.labelling`), above 0
    for one the labeller made on top of a later-starting swap it overlaps.
    ``left``: for a duplicate or a foreign stretch whose removed samples were
    left missing, why no fill was written (:attr:`why_left`): longer than
    ``--max-gap``, or the plausibility guard's reason; "" where filled, or
    from a record written before 0.16.0 (read as "no plausible fill").
    ``miss_mm``: for a spike left missing (no fill to measure ``size_mm`` from, so NaN), how far its removed
    samples lay off the straight line through the two seen samples beside the run (the one-sided in-time
    prediction of :mod:`~mocapkit.cleaning.markers.edges`, the test that finds a spike beside a gap; the nearer
    side where both are seen): how far off its path the marker jumped; NaN where neither side has two seen
    samples, or from a record written before 0.17.0.
    ``fill_basis``: how a fill's ``expected_mm`` was widened beyond its stretches' RMS error (its models part
    further in the gap than on the stretches; few or short stretches: :mod:`~mocapkit.cleaning.markers.fill_error`),
    in words; "" where it was not, or from a record written before 0.18.0.
    """

    marker: str
    start: int
    end: int
    kind: str
    size_mm: float
    other: str = ""
    seconds: float = float("nan")
    method: str = ""
    donors: str = ""
    expected_mm: float = float("nan")
    note: str = ""
    ends: int = 2
    models: int = 1
    fill_note: str = ""
    order: int = 0
    left: str = ""
    miss_mm: float = float("nan")
    fill_basis: str = ""

    @property
    def fill_text(self) -> str:
        """A gap's (or a filled duplicate's) duration, method and expected error in words ("" for a spike or a swap)."""
        if self.kind not in ("gap", "duplicate", "foreign") or not self.method:
            return ""
        how = self.method + (f" ({self.donors})" if self.donors else "")
        if self.models > 1:
            how = f"average of {self.models} fills, the best {how}"
        doubt = (f"expected error {self.expected_mm:.1f} mm" + (f" ({self.fill_basis})" if self.fill_basis else "")
                 if np.isfinite(self.expected_mm) else "expected error unknown (no seen stretch to validate on)")
        return f"{self.seconds:.2f} s, {how}, {doubt}" + (f" ({self.fill_note})" if self.fill_note else "")

    @property
    def why_left(self) -> str:
        """Why this run was left missing (:func:`why_left`)."""
        return why_left(self)

    @property
    def too_long(self) -> bool:
        """Whether this gap was left missing because it is longer than ``max_gap_s`` (:func:`left_too_long`)."""
        return left_too_long(self)

    @property
    def left_text(self) -> str:
        """Why a removed duplicate or foreign stretch is left missing, in words: its :attr:`left` reason
        ("longer than --max-gap (0.3 s)": no fill was tried), else "no plausible fill" with the guard's reason."""
        if self.too_long:
            return self.left
        return "no plausible fill" + (f" ({self.left})" if self.left else "")

    @property
    def removed_as(self) -> str:
        """What a duplicate label's or a foreign stretch's removed samples were, with the evidence ("" otherwise)."""
        if self.kind == "duplicate":
            return f"on {self.other}'s position (a duplicate label: {self.note})"
        if self.kind == "foreign":
            return f"another point under its label ({self.note})"
        return ""

    @property
    def size_text(self) -> str:
        """``size_mm`` in words, after a gap's :attr:`fill_text`: what the number measures differs by kind (a gap's is no error)."""
        if self.kind in ("duplicate", "foreign"):
            fill = f" ({self.fill_text})" if self.fill_text else ""
            done = (f"removed, left missing: {self.left_text}" if not np.isfinite(self.size_mm)
                    else f"removed and filled{fill}: removed samples up to {self.size_mm:.1f} mm from the fill")
            return f"{self.removed_as}, {done}"
        if self.kind == "coincident":
            return (f"at the same position as {self.other} ({self.size_mm:.1f} mm apart at most): one is a duplicate "
                    f"label, which one cannot be told ({self.note}): both left as recorded")
        off = (f"; removed samples up to {self.miss_mm:.1f} mm off the line through the seen samples beside them"
               if self.kind == "spike" and np.isfinite(self.miss_mm) else "")
        if self.too_long:
            return f"{self.seconds:.2f} s: left missing: {self.note}{off}"
        if self.note == NOT_ASKED:
            return f"removed: left missing: {self.note}{off}"
        if self.note:
            return f"{self.fill_text or 'removed'}: left missing: no plausible fill ({self.note}){off}"
        what = {"gap": "fill up to {} mm off the straight line between the gap's ends" if self.ends != 1 else
                "extrapolated from its one seen end: fill up to {} mm from the sample seen there",
                "spike": "removed samples up to {} mm from the fill",
                "swap": "markers {} mm apart where it starts"}.get(self.kind, "{} mm")
        text = what.format(f"{self.size_mm:.1f}")
        return f"{self.fill_text}; {text}" if self.kind == "gap" else text


def why_left(fix) -> str:
    """Why a run was left missing: a gap's or a spike's ``note``; a duplicate's or a foreign stretch's ``left`` (its
    ``note`` is the evidence that it was removed). ``fix``: a :class:`MarkerFix`, or a record's dict of its fields
    (:attr:`mocapkit.cleaning.markers.record.MarkerRecord.unfilled`; a field it lacks, an earlier record's, is "")."""
    get = fix.get if isinstance(fix, dict) else lambda name, default: getattr(fix, name, default)
    said = get("left", "") if get("kind", "") in ("duplicate", "foreign") else get("note", "")
    return "" if said is None else str(said)


def left_too_long(fix) -> bool:
    """Whether a gap (:func:`why_left`'s ``fix``) was left missing because it is longer than ``max_gap_s``
    (``--max-gap``): no fill was tried, so none was found implausible. One rule for a clean's summary, its report
    and ``mocapkit info`` of its record."""
    return why_left(fix).startswith(TOO_LONG)


@dataclass(frozen=True)
class MarkerCleanResult:
    """What :func:`clean_markers` returns.

    Attributes
    ----------
    markers : MarkerSet
        The cleaned capture (same labels, rate, unit).
    original : MarkerSet
        The input.
    filled, spikes, swapped : bool arrays (F, M)
        Samples of gaps filled; samples found to be spikes (removed, and
        replaced by a fill where one reached them); samples re-labelled.
        ``filled``, ``spikes`` and ``duplicates`` do not overlap, so that the
        record, the summary and ``clean-batch --json`` count each sample once.
    fixes : tuple of MarkerFix
    never_seen : tuple of str
        Markers missing in the whole take (still missing).
    unseen_start, unseen_end : (int, int)
        The frames ``a <= f < b`` at the take's start and end where no marker
        is seen at all (the subject out of view; unlabelled trajectories seen
        there do not count): left missing, as there is nothing to fill them
        from (:func:`~mocapkit.cleaning.markers.gaps.fill_gaps`).
    unlabelled : tuple of str
        The unlabelled trajectories (:meth:`MarkerSet.unlabelled`), left as read.
    nobody_seen : tuple of (str, int, int)
        ``(subject, start, end)``: the frames ``start <= f < end`` where none
        of a subject's markers is seen ("" for a capture of one subject), other
        than the take's ``unseen_start`` and ``unseen_end``: the subject out of
        the volume (before it walks in, after it leaves, or mid-take); its
        markers are left missing there.
    frames_note : str
        How the frame numbers of the summary and fixes (0-based take indexes)
        relate to the file's own (a TRC's ``Frame#``, a C3D's first frame):
        :func:`mocapkit.cleaning.decisions.frames_note`, the last line of
        :meth:`summary` where it names a frame; "" when not known or 0.
    unfilled : tuple of MarkerFix
        Gaps left missing because no fill passed the plausibility guard
        (:mod:`~mocapkit.cleaning.markers.plausible`): kind "gap", or
        "spike" for a spike run whose samples were removed and could not be
        replaced (it is among :attr:`fixes` too: a change); ``note`` says
        why, the other fields describe the rejected fill. A duplicate's or a
        foreign stretch's removed run left missing is listed too (kind
        "duplicate" or "foreign", among :attr:`fixes` as well): its
        ``left`` says why (:attr:`MarkerFix.why_left`), its ``note`` the evidence.
    duplicates : bool array (F, M)
        Samples of a marker found on another marker's position (a duplicate
        label, :mod:`~mocapkit.cleaning.markers.duplicates`), or another
        point under its label (a foreign stretch,
        :mod:`~mocapkit.cleaning.markers.foreign`): removed, and replaced by a
        fill where one reached them; each run is a fix of kind "duplicate"
        naming the other marker, or of kind "foreign".
    coincident : tuple of MarkerFix
        Runs where two markers sit at the same position and which one is the
        copy could not be told (kind "coincident"): both left as recorded.
    review : bool
        Review mode (``steps="detect"``, the CLI's ``--steps detect``): nothing
        is changed, :attr:`output` is the input, and ``markers``, the masks and
        ``fixes`` say what cleaning would change, for a person to decide on.
    decided : Decided or None
        The decisions applied (:class:`mocapkit.cleaning.decided.Decided`):
        ``markers`` then holds only the accepted changes, every other sample the
        input's, and the masks and ``fixes`` are those of the accepted changes
        (:func:`mocapkit.cleaning.markers.decisions.decided_result`).
    """

    markers: object
    original: object
    filled: np.ndarray
    spikes: np.ndarray
    swapped: np.ndarray
    fixes: tuple[MarkerFix, ...]
    never_seen: tuple[str, ...]
    unseen_start: tuple[int, int] = (0, 0)
    unseen_end: tuple[int, int] = (0, 0)
    unlabelled: tuple[str, ...] = ()
    unfilled: tuple[MarkerFix, ...] = ()
    duplicates: np.ndarray | None = None
    coincident: tuple[MarkerFix, ...] = ()
    nobody_seen: tuple[tuple[str, int, int], ...] = ()
    frames_note: str = ""
    review: bool = False
    decided: object = None

    @property
    def output(self):
        """The capture this cleaning gives back (what ``mocapkit clean`` writes): the input in review mode, else
        :attr:`markers`."""
        return self.original if self.review else self.markers

    @property
    def changed(self) -> np.ndarray:
        """(F, M) samples whose values differ from the input (NaN-aware)."""
        a, b = self.original.positions, self.markers.positions
        same = (a == b) | (np.isnan(a) & np.isnan(b))
        return ~np.all(same, axis=-1)

    @property
    def fill_mask(self) -> np.ndarray:
        """(F, M) samples of :attr:`output` that fills made, not recorded ones: gap, spike and duplicate-label fills
        (none in review mode). A format without residuals (TRC) writes them like recorded ones; the record keeps
        the masks."""
        if self.review:
            return np.zeros(self.filled.shape, dtype=bool)
        return (self.filled | self.spikes | self.duplicate_mask) & ~self.markers.missing()

    @property
    def duplicate_mask(self) -> np.ndarray:
        """(F, M) :attr:`duplicates`, all False where none was given."""
        return self.duplicates if self.duplicates is not None else np.zeros(self.filled.shape, dtype=bool)

    def summary(self) -> list[str]:
        """A few lines for a terminal, :attr:`frames_note` last where they or :attr:`fixes` name a frame.

        With decisions applied, the lines ``mocapkit clean --decisions`` says (:meth:`Decided.lines
        <mocapkit.cleaning.decided.Decided.lines>`); in review mode, first the line saying nothing was changed.
        """
        if self.decided is not None:
            return self.decided.lines(self.frames_note)
        if self.review:
            # of the markers' samples: a C3D's modelled quantities (angles, forces, ...) are left as read, as info counts
            n, total = int(self.changed.sum()), self.changed.shape[0] * int((self.markers.quantities() == "").sum())
            return ([f"review mode (--steps detect): the capture unchanged; cleaning would change {n} of "
                     f"{plural(total, 'marker sample')}"] + dataclasses.replace(self, review=False).said(would=True))
        return self.said()

    def said(self, would: bool = False) -> list[str]:
        """:meth:`summary`'s lines of a cleaning, said of what it did, or (``would``: review mode, the capture written
        unchanged) of what it would do: "would fill 23 gaps (425 samples)", not "23 gaps filled", which read as
        done on a capture whose samples are the input's."""
        counts = {k: sum(1 for x in self.fixes if x.kind == k) for k in ("gap", "spike", "swap")}
        blind = unvalidated(self.fixes)
        sizes = [plural(counts["gap"], "gap"), plural(int(self.filled.sum()), "sample")
                 + (f"; {blind} of them unvalidated: expected error unknown" if blind else ""),
                 plural(counts["spike"], "spike"), plural(int(self.spikes.sum()), "sample"),
                 plural(counts["swap"], "label swap"), plural(int(self.swapped.sum()), "sample")]
        lines = [("would fill {} ({}), remove {} ({}), undo {} ({})" if would else
                  "{} filled ({}), {} removed ({}), {} undone ({})").format(*sizes)
                 + self._removed_counts(would)]
        skip = np.isin(self.markers.labels, self.unlabelled)
        if hasattr(self.original, "modelled"):  # modelled points' unseen samples are no markers' missing ones
            skip = skip | self.original.modelled()
        gone = self.markers.missing()[:, ~skip]
        removed = gone & ~self.original.missing()[:, ~skip]  # recorded samples removed as spikes, no fill passed
        left = int(np.sum(gone & ~removed))
        if left:
            lines.append(f"cleaning would leave {plural(left, 'sample')} missing" if would
                         else f"{plural(left, 'sample')} still missing")
        if removed.any():
            gone_fixes = [x for x in self.fixes if x.kind in _REMOVED and not np.isfinite(x.size_mm)]
            kinds = {x.kind for x in gone_fixes}
            how = " or ".join(w for k, w in (("spike", "spikes"), ("duplicate", "duplicate labels"),
                                             ("foreign", "other points under their labels")) if k in kinds) or "spikes"
            long = sum(1 for x in gone_fixes if x.too_long)
            why = ("longer than --max-gap" if gone_fixes and long == len(gone_fixes) else
                   "no plausible fill, or longer than --max-gap" if long else "no plausible fill")
            gone_n = plural(int(removed.sum()), "recorded sample")
            lines.append(f"cleaning would remove {gone_n} as {how} and leave them missing ({why})" if would
                         else f"{gone_n} removed as {how} and left missing ({why})")
        for x in (x for kind in ("duplicate", "foreign") for x in self.fixes if x.kind == kind):
            done = "removed and filled" if np.isfinite(x.size_mm) else f"removed, left missing ({x.left_text})"
            done = f"would be {done}" if would else done
            lines.append(f"{x.marker} {frame_span(x.start, x.end - 1)}: {x.removed_as}, {done}")
        for x in self.coincident:
            lines.append(f"{x.marker} and {x.other} {frame_span(x.start, x.end - 1)}: at the same position "
                         f"({x.size_mm:.1f} mm apart at most); one is a duplicate label, which one cannot be told "
                         f"({x.note}): both left as recorded")
        long = [x for x in self.unfilled if x.too_long]
        for group, why in ((long, long[0].note if long else ""),
                           ([x for x in self.unfilled if not x.too_long], "no plausible fill")):
            if not group:
                continue
            n = len(group)
            shown = "; ".join(f"{x.marker} {frame_span(x.start, x.end - 1)} ({_REMOVED.get(x.kind, '')}"
                              f"{x.seconds:.2f} s" + ("" if x.too_long or not x.why_left else f": {x.why_left}") + ")"
                              for x in group[:3])
            more = f"; ... and {n - 3} more" if n > 3 else ""
            of = "".join(f"; {k} of them {what}" for k, what in (
                (sum(1 for x in group if x.kind == "spike"), "spikes removed"),
                (sum(1 for x in group if x.kind == "duplicate"), "duplicate labels removed"),
                (sum(1 for x in group if x.kind == "foreign"), "another point under a label, removed")) if k)
            k = sum(x.end - x.start for x in group)
            lines.append(f"{plural(n, 'gap')} ({plural(k, 'sample')}{of}) "
                         f"left missing: {why}: {shown}{more}")
        marker = "labelled marker" if self.unlabelled else "marker"
        for where, (a, b) in (("start", self.unseen_start), ("end", self.unseen_end)):
            if b > a:
                lines.append(f"{frame_span(a, b - 1)} at the take's {where} see{'s' if b - a == 1 else ''} no {marker}: "
                             "left missing (nothing to fill from)")
        f = self.markers.positions.shape[0]
        for who, a, b in self.nobody_seen:
            why = "not yet in the volume?" if a == 0 else ("gone from the volume?" if b == f else "out of the volume?")
            lines.append(f"{who + ': ' if who else ''}{frame_span(a, b - 1)}: nobody seen ({why}), left missing")
        if self.unlabelled:
            n = len(self.unlabelled)
            names = ", ".join(self.unlabelled[:4]) + (f" ... {self.unlabelled[-1]}" if n > 4 else "")
            lines.append(f"{n} unlabelled trajector{'ies' if n > 1 else 'y'} ({names}: no label in the file, or "
                         "one starting with '*') left as read: not a marker's identity, so not cleaned")
        if self.never_seen:
            lines.append(f"missing in the whole take, left missing: {', '.join(self.never_seen)}")
        res = getattr(self.original, "residuals", None)
        seen = ~self.original.missing() if hasattr(self.original, "missing") else None
        if res is not None and (self.filled | self.spikes).any() and seen.any() and np.all(res[seen] == 0):
            lines.append("the input's residuals are all 0, as a fill's are (C3D: 0 is 'interpolated'): a .c3d or .trc "
                         "written cannot tell fills from recorded samples; a .npz's filled mask and the .clean.npz's "
                         "masks (filled, spikes) can")
        names_frames = bool(self.fixes or self.coincident or self.unfilled or self.nobody_seen
                            or self.unseen_start[1] > self.unseen_start[0] or self.unseen_end[1] > self.unseen_end[0])
        if self.frames_note and names_frames:
            lines.append(self.frames_note)
        return lines

    def _removed_counts(self, would: bool) -> str:
        """The totals line's tail for duplicate labels and foreign stretches removed (:func:`~mocapkit.cleaning.
        markers.counts.sample_counts`, "" where none): ", 1 duplicate label removed (60 samples)", so that the line
        counts every changed sample, as ``info`` of the record and ``clean-batch`` do."""
        counts = sample_counts(self)
        said = []
        for kind, key, one, many in (("duplicate", "duplicates", "duplicate label", None),
                                     ("foreign", "foreign", "foreign stretch", "foreign stretches")):
            n = sum(1 for x in self.fixes if x.kind == kind)
            if n:
                samples = plural(counts[key], "sample")
                said.append(f"remove {plural(n, one, many)} ({samples})" if would
                            else f"{plural(n, one, many)} removed ({samples})")
        return "".join(f", {x}" for x in said)

    def save(self, path, written: dict | None = None, request: dict | None = None,
             decided: dict | None = None) -> Path:
        """Write the masks and the list of fixes as ``.npz`` (no pickles), atomically; ``written``: what
        :func:`mocapkit.batch.clean_marker_file` read and wrote (sizes and digests), ``request``: what the
        capture was asked to be cleaned with (:func:`mocapkit.batch.marker_request`), and ``decided``: the decisions
        its output was written with (:func:`mocapkit.batch_decided.decided_entry`), each kept as JSON."""
        from ...io import atomic_write
        from .decisions import record_cells

        path = Path(path)
        labels = list(self.markers.labels)
        fixes = [dataclasses.asdict(x) for x in self.fixes]
        unfilled = [dataclasses.asdict(x) for x in self.unfilled]
        with atomic_write(path, "wb") as fh:
            np.savez_compressed(
                fh,
                filled=self.filled, spikes=self.spikes, swapped=self.swapped, changed=self.changed,
                duplicates=self.duplicate_mask, labels=np.array(labels, dtype=str),
                fixes=np.array(json.dumps(fixes)), unfilled=np.array(json.dumps(unfilled)),
                coincident=np.array(json.dumps([dataclasses.asdict(x) for x in self.coincident])),
                never_seen=np.array(list(self.never_seen), dtype=str),
                unlabelled=np.array(list(self.unlabelled), dtype=str),
                nobody_seen=np.array(json.dumps([list(x) for x in self.nobody_seen])),
                kind=np.array("markers"), **record_cells(self.original, self.markers),
                **({"written": np.array(json.dumps(written))} if written else {}),
                **({"request": np.array(json.dumps(request))} if request else {}),
                **({"decided": np.array(json.dumps(decided))} if decided else {}),
            )
        return path


NOT_ASKED = "beside a gap, which the gaps step (not asked for) does not fill"
"""Why a spike removed beside a gap is left missing when the steps leave gaps alone (``steps`` without "gaps")."""

_REMOVED = {"spike": "a spike removed, ", "duplicate": "a duplicate label removed, ",
            "foreign": "another point under its label removed, "}
"""How a run left missing whose recorded samples were removed begins in the summary (a gap's begins with its duration)."""


def _swap_sources(x: np.ndarray, y: np.ndarray, swapped: np.ndarray) -> np.ndarray:
    """(F, M) int: the marker column of ``x`` each sample of ``y`` came from (its own outside ``swapped``).

    ``x``: positions (F, M, 3) before the swaps were undone; ``y``: after
    (the same samples, re-labelled: :func:`~mocapkit.cleaning.markers.swaps.undo_swaps`);
    ``swapped``: (F, M) bool, the re-labelled samples. A re-labelled sample
    is matched to the sample of ``x`` in its frame with the same values,
    among that frame's re-labelled markers; an unseen one keeps its column.
    """
    f, m = swapped.shape
    src = np.broadcast_to(np.arange(m), (f, m)).copy()
    t, i = np.nonzero(swapped)
    if t.size == 0:
        return src
    same = np.all(y[t, i][:, None, :] == x[t], axis=-1) & swapped[t]  # (N, M)
    found = same.any(axis=1)
    src[t[found], i[found]] = np.argmax(same[found], axis=1)
    return src


def _edge_spikes(spikes: np.ndarray, recorded: np.ndarray, filled: np.ndarray, a: int, b: int, label: str,
                 unit_mm: float) -> list[MarkerFix]:
    """The spike fixes inside a filled gap ``a <= f < b`` of one marker: runs removed beside the gap (found by
    :mod:`~mocapkit.cleaning.markers.edges`) are filled with it, and named as spikes. ``spikes`` (F,) its spike
    mask, ``recorded`` and ``filled`` (F, 3) its samples before and after (capture unit)."""
    d = np.diff(np.concatenate([[0], spikes[a:b].astype(np.int8), [0]]))
    out = []
    for s, e in zip(np.flatnonzero(d == 1) + a, np.flatnonzero(d == -1) + a):
        size = float(np.max(np.linalg.norm(recorded[s:e] - filled[s:e], axis=-1))) * unit_mm
        out.append(MarkerFix(label, int(s), int(e), "spike", size))
    return out


def _line_miss(recorded: np.ndarray, seen: np.ndarray, s: int, e: int) -> float:
    """How far the recorded samples ``s <= f < e`` of one marker lie off the straight line through the two seen
    samples next to the run, extrapolated across it (the one-sided in-time test of
    :mod:`~mocapkit.cleaning.markers.edges`): the largest distance over the run, from the nearer-predicting side
    where both sides have two seen samples; NaN where neither has. ``recorded`` (F, 3) the samples before the
    spikes were removed, ``seen`` (F, 3) after (NaN where removed or unseen), in the capture's unit."""
    f, out = seen.shape[0], []
    for near, far in ((s - 1, s - 2), (e, e + 1)):
        if 0 <= min(near, far) and max(near, far) < f and not np.isnan(seen[[near, far]]).any():
            t = np.arange(s, e)[:, None]
            line = seen[near] + (seen[near] - seen[far]) * (t - near) / (near - far)
            out.append(float(np.max(np.linalg.norm(recorded[s:e] - line, axis=-1))))
    return min(out) if out else float("nan")


def _left_spikes(spikes: np.ndarray, recorded: np.ndarray, seen: np.ndarray, a: int, b: int, label: str,
                 unit_mm: float, fps: float, note: str) -> list[MarkerFix]:
    """The spike fixes inside a gap ``a <= f < b`` of one marker that was left missing: runs removed beside the gap
    (:mod:`~mocapkit.cleaning.markers.edges`) are removed recorded samples, a change, though no fill replaced
    them; size NaN (left missing), ``miss_mm`` how far they lay off the marker's path (:func:`_line_miss`), ``note``
    why no fill was written, ``seconds`` the run's duration at ``fps``. ``spikes`` (F,) its spike mask;
    ``recorded``, ``seen`` (F, 3) as for :func:`_line_miss`."""
    d = np.diff(np.concatenate([[0], spikes[a:b].astype(np.int8), [0]]))
    return [MarkerFix(label, int(s), int(e), "spike", float("nan"), note=note, seconds=(e - s) / fps,
                      miss_mm=_line_miss(recorded, seen, int(s), int(e)) * unit_mm)
            for s, e in zip(np.flatnonzero(d == 1) + a, np.flatnonzero(d == -1) + a)]


def clean_markers(markers, *, steps=STEPS, spike_mm: float = 15.0, swap_mm: float = 15.0,
                  max_gap_s: float | None = None, constrain: bool = True,
                  max_error_mm: float | None = None, progress=None) -> MarkerCleanResult:
    """Clean a :class:`MarkerSet`: undo label swaps, remove spikes, fill gaps.

    Parameters
    ----------
    markers : MarkerSet
        The capture (positions (F, M, 3), NaN where unseen). Its modelled
        points and unlabelled trajectories (:meth:`MarkerSet.modelled`,
        :meth:`MarkerSet.unlabelled`) come back as they are and are used for nothing.
    steps : sequence of str or str
        Any of "swaps", "spikes", "gaps" (comma-separated or a list); they run in that order.
    spike_mm, swap_mm : float
        Detection thresholds in millimetres (see :func:`spike_mask`, :func:`undo_swaps`).
        A duplicate label (:func:`~mocapkit.cleaning.markers.duplicates.find_duplicates`)
        lies more than ``spike_mm`` from where its rigid neighbours put it.
    max_gap_s : float, optional
        Gaps longer than this are left missing.
    max_error_mm : float, optional
        A fill whose expected error (its RMS error on stretches of the same
        length cut where the marker is seen, widened where those resemble
        the gap poorly: :mod:`~mocapkit.cleaning.markers.fill_error`) is
        larger than this, in mm, or unknown (no stretch to validate on), is
        not written: the gap is left missing and named in ``unfilled``.
        Default: each marker's distance to its nearest marker (at least 50
        mm: :func:`~mocapkit.cleaning.markers.gaps.error_limits`); ``inf``
        writes every plausible fill.
    constrain : bool
        Pull filled samples to their usual distances from their rigid
        neighbours (soft constraints, :mod:`~mocapkit.cleaning.markers.constraints`),
        in the gaps where that brought the fill's validation gaps nearer the truth.
    progress : callable, optional
        ``progress(done, more)``, told of the gaps to fill and each one filled
        (:func:`~mocapkit.cleaning.markers.gaps.fill_gaps`, 90 % of the time
        on Qualisys's 03_rolling.c3d): a command's progress bar.

    Returns
    -------
    MarkerCleanResult

    BLAS runs on one thread throughout: the gaps' low-rank fills
    (:mod:`~mocapkit.cleaning.markers.lowrank`) take hundreds of SVDs of
    (window, 39) matrices, which OpenBLAS's threads made many times slower on
    a busy machine (03_rolling.c3d's 760: 53 s of a 76 s clean on two shared
    cores, 2 s on one thread), and one thread gives the same sums whatever
    the machine's cores (the output is bit for bit that of two threads on
    every capture of the recovery, c3d.org, BTKData and TRC test data).
    """
    with threadpool_limits(1, user_api="blas"):
        return _clean_markers(markers, steps, spike_mm, swap_mm, max_gap_s, constrain, max_error_mm, progress)


def _clean_markers(markers, steps, spike_mm, swap_mm, max_gap_s, constrain, max_error_mm,
                   progress) -> MarkerCleanResult:
    """:func:`clean_markers`' work, on one BLAS thread."""
    if isinstance(steps, str):
        steps = [s.strip() for s in steps.split(",") if s.strip()]
    unknown = [s for s in steps if s not in STEPS]
    if unknown:
        raise ValueError(f"unknown step(s) {', '.join(unknown)}; steps are {', '.join(STEPS)}")
    check_units(markers)  # a stated unit off by orders of magnitude: refused, not cleaned at the wrong scale
    unit_mm = 10.0 * markers.unit_cm
    full = np.asarray(markers.positions, dtype=np.float64)
    none = np.zeros(full.shape[1], dtype=bool)
    modelled = markers.modelled() if hasattr(markers, "modelled") else none
    unlabelled = markers.unlabelled() if hasattr(markers, "unlabelled") else none
    # the markers; modelled angles, forces, ... and unlabelled trajectories are left as they are and used for nothing
    work = np.flatnonzero(~modelled & ~unlabelled)
    x = full[:, work]
    f, m = x.shape[:2]
    labels = [markers.labels[i] for i in work]
    subjects = [subject_of(label) for label in labels]
    fixes: list[MarkerFix] = []
    unfilled: list[MarkerFix] = []
    y = x.copy()
    swapped = np.zeros((f, m), dtype=bool)
    if "swaps" in steps:
        y, swaps = undo_swaps(y, unit_mm, threshold_mm=swap_mm)
        for s in swaps:
            swapped[s.start:s.end, [s.a, s.b]] = True
            fixes.append(MarkerFix(labels[s.a], s.start, s.end, "swap", s.distance * unit_mm, labels[s.b],
                                   order=s.order))
    dups = np.zeros((f, m), dtype=bool)
    found = find_duplicates(y, unit_mm, off_mm=spike_mm) if "duplicates" in steps else []
    coincident = [MarkerFix(labels[d.marker], d.start, d.end, "coincident", d.distance * unit_mm, labels[d.other],
                            note=d.why) for d in found if not d.resolved]
    found = [d for d in found if d.resolved]
    for d in found:
        dups[d.start:d.end, d.marker] = True
    # a label on another point from a take's or an occlusion's edge up to a jump: removed as a duplicate's copy is
    foreign = find_foreign(np.where(dups[..., None], np.nan, y), unit_mm, off_mm=spike_mm,
                           min_frames=longest_spike(markers.fps)) if "duplicates" in steps else []
    for g in foreign:
        dups[g.start:g.end, g.marker] = True
    before_fill = y.copy()  # the recorded (re-labelled) samples: what a removed one was
    y[dups] = np.nan
    spikes = np.zeros((f, m), dtype=bool)
    if "spikes" in steps:
        spikes = spike_mask(y, unit_mm, threshold_mm=spike_mm, fps=markers.fps)
    y[spikes] = np.nan
    filled = np.zeros((f, m), dtype=bool)
    never = np.all(np.isnan(y), axis=(0, 2))
    seen_any = np.flatnonzero(~np.all(np.isnan(y), axis=(1, 2)))  # frames with a marker seen (spikes removed)
    dup_fill: dict[tuple, dict] = {}  # (marker, start, end) -> the fill of a duplicate's removed run
    dup_left: dict[tuple, str] = {}  # (marker, start, end) -> why a duplicate's removed run was left missing
    if "gaps" in steps or np.any(spikes) or np.any(dups):
        stats = distance_stats(y)
        max_gap = None if max_gap_s is None else int(round(max_gap_s * markers.fps))
        out, records = fill_gaps(y, stats=stats, max_gap=max_gap, constrain=constrain, unit_mm=unit_mm,
                                 smooth=SMOOTH_S * markers.fps, subjects=subjects,
                                 max_error=None if max_error_mm is None else max_error_mm / unit_mm,
                                 progress=progress)
        for r in records:
            run = slice(r.start, r.end)
            if np.all(dups[run, r.marker]):  # a duplicate's removed samples: named below, with the marker it was on
                if not r.filled:  # and why no fill was written (was always "no plausible fill", --max-gap's too)
                    dup_left[(r.marker, r.start, r.end)] = (f"{TOO_LONG} ({max_gap_s:g} s)"
                                                            if r.implausible.startswith(TOO_LONG) else r.implausible)
                if r.filled:
                    y[run, r.marker] = out[run, r.marker]
                    dup_fill[(r.marker, r.start, r.end)] = dict(
                        method=r.method, donors=", ".join(labels[d] for d in r.donors),
                        expected_mm=r.expected_error * unit_mm)
                continue
            is_spike = bool(np.all(spikes[run, r.marker]))
            edge = (spikes[:, r.marker], before_fill[:, r.marker], y[:, r.marker], r.start, r.end, labels[r.marker],
                    unit_mm, markers.fps)
            if not is_spike and "gaps" not in steps and not np.any(dups[run, r.marker]):
                # spikes removed beside a gap the gaps step does not fill: removed recorded samples, a change
                fixes.extend(_left_spikes(*edge, NOT_ASKED))
                continue
            how = dict(seconds=(r.end - r.start) / markers.fps, method=r.method,
                       donors=", ".join(labels[d] for d in r.donors), expected_mm=r.expected_error * unit_mm,
                       models=r.models, fill_note=r.note, fill_basis=r.basis)
            if not r.filled:  # no plausible fill: left missing, and said so (a spike run's samples removed: a change)
                why = f"{TOO_LONG} ({max_gap_s:g} s)" if r.implausible.startswith(TOO_LONG) else r.implausible
                left_fix = MarkerFix(labels[r.marker], r.start, r.end, "spike" if is_spike else "gap", float("nan"),
                                     note=why, **how)
                if is_spike:
                    left_fix = dataclasses.replace(left_fix, miss_mm=_line_miss(*edge[1:5]) * unit_mm)
                    fixes.append(left_fix)
                else:  # spikes removed beside the gap (edges) are changes of their own, as a filled gap's are
                    fixes.extend(_left_spikes(*edge, why))
                unfilled.append(left_fix)
                continue
            y[run, r.marker] = out[run, r.marker]
            filled[run, r.marker] = ~spikes[run, r.marker] & ~dups[run, r.marker]  # each sample counted once
            if is_spike:
                size = float(np.max(np.linalg.norm(before_fill[run, r.marker] - out[run, r.marker], axis=-1)))
                fixes.append(MarkerFix(labels[r.marker], r.start, r.end, "spike", size * unit_mm))
            else:
                a, b = r.start, r.end
                ends = [t for t in (a - 1, b) if 0 <= t < f and not np.any(np.isnan(y[t, r.marker]))]
                ref = out[ends, r.marker]
                u = (np.arange(1, b - a + 1) / (b - a + 1))[:, None]
                line = (1 - u) * ref[0] + u * ref[-1]
                size = float(np.max(np.linalg.norm(out[run, r.marker] - line, axis=-1)))
                fixes.append(MarkerFix(labels[r.marker], a, b, "gap", size * unit_mm, ends=len(ends), **how))
                fixes.extend(_edge_spikes(spikes[:, r.marker], before_fill[:, r.marker], out[:, r.marker], a, b,
                                          labels[r.marker], unit_mm))
    # a duplicate or foreign stretch no fill reached stays missing rather than wrong (size NaN: the summary says so)
    removed = [(d.marker, d.start, d.end, "duplicate", labels[d.other], d.why) for d in found]
    removed += [(g.marker, g.start, g.end, "foreign", "", g.why) for g in foreign]
    for mk, a, b, kind, other, why in removed:
        gone = np.any(np.isnan(y[a:b, mk]))
        size = (float("nan") if gone else
                float(np.max(np.linalg.norm(before_fill[a:b, mk] - y[a:b, mk], axis=-1))) * unit_mm)
        # left missing: why (longer than --max-gap, or the guard's reason), from its own run or the gap holding it
        held = next((u.why_left for u in unfilled if u.marker == labels[mk] and u.start <= a and b <= u.end), "")
        left = dup_left.get((mk, a, b), held) if gone else ""
        fix = MarkerFix(labels[mk], a, b, kind, size, other, seconds=(b - a) / markers.fps, note=why, left=left,
                        **dup_fill.get((mk, a, b), {}))
        fixes.append(fix)
        if (mk, a, b) in dup_left:  # its own run left missing: listed with the gaps left missing, as a spike's is
            unfilled.append(fix)
    # a spike no fill reached stays missing rather than wrong
    fixes.sort(key=lambda x: (x.start, x.marker, x.kind))
    out = full.copy()
    out[:, work] = y

    def expand(sub):
        mask = np.zeros(full.shape[:2], dtype=bool)
        mask[:, work] = sub
        return mask

    if hasattr(markers, "with_positions"):
        # a re-labelled sample keeps the residual and camera mask it was recorded with
        sources = np.broadcast_to(np.arange(full.shape[1]), full.shape[:2]).copy()
        sources[:, work] = work[_swap_sources(x, before_fill, swapped)]
        cleaned = markers.with_positions(out, sources=sources)
    else:
        cleaned = dataclasses.replace(markers, positions=out)
    lo, hi = (int(seen_any[0]), int(seen_any[-1]) + 1) if seen_any.size else (f, f)
    absent = tuple(r for r in nobody_seen(np.any(np.isnan(y), axis=-1), subjects) if r[1:] not in ((0, lo), (hi, f)))
    return MarkerCleanResult(markers=cleaned, original=markers, filled=expand(filled), spikes=expand(spikes),
                             swapped=expand(swapped), fixes=tuple(fixes),
                             never_seen=tuple(labels[i] for i in np.flatnonzero(never)),
                             unseen_start=(0, lo) if seen_any.size else (0, 0), unseen_end=(hi, f),
                             unlabelled=tuple(markers.labels[i] for i in np.flatnonzero(unlabelled & ~modelled)),
                             unfilled=tuple(sorted(unfilled, key=lambda x: (x.start, x.marker))),
                             duplicates=expand(dups), coincident=tuple(coincident), nobody_seen=absent)

