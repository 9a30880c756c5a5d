"""Detection: the movement digression map and the error flags of a take (sections 3.4 and 5).

Where a joint digresses from the mean motion texture (:mod:`~mocapkit.cleaning.ssa.neighbours`),
the *movement digression map* (MDM) is high: that is an error, or a motion the
context has never seen. :func:`detect` returns the MDM and the flags at the
input's frame rate, confirmed by the cues of :mod:`~mocapkit.cleaning.ssa.cues`.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ... import rotations as R
from ...motion import Motion, mirror_pairs
from ...rigs import pelvis_index
from ...words import plural
from ..ik import contact_segments
from . import word_dtw
from .backed import backed_breaks
from .coarse_cues import backs_offsets, hold_min_frames
from .cues import (
    flag_causes,
    held_joints,
    mirrored_rotations,
    own_breaks,
    offsets_from_residuals,
    unshared_offsets,
    step_angles,
    uncompensated_breaks,
    swaps_from_residuals,
    CAUSE_DTYPE,
)
from .drifts import group_agreement, group_offset_change, group_offset_turn, not_looked_for, smooth_drift_flags
from .edge_swaps import edge_swaps, possible_swap_note
from .neighbours import Neighbors, flagged_words, mean_motion_texture, nearest_words, unseen_words
from .params import SSAParams
from .spikes import lone_spikes, spike_breaks
from .repeats import analysed_once, expand, inbetween_runs, kept_frames, repeat_runs, without_repeats
from .freeze_bounds import bounded_holds, held_repeats
from .freezes import frozen_channels
from .recurring_peaks import recurring_breaks
from .reversals import reversed_runs
from .smooth_turns import smooth_turn_breaks
from .still_positions import position_kept_breaks
from .swap_exchange import joined_swaps
from .turning_holds import without_turning_points
from .texture import Analysis, facing_aligned, frame_words, prepare, upsample_quaternions

__all__ = ["Detection", "detect", "detect_prepared", "movement_digression_map", "flag_runs"]

_D = SSAParams()


def movement_digression_map(
    digression: np.ndarray,
    normalization: str = _D.normalization,
    row_scale: float = _D.row_scale,
    floor_deg: float = _D.floor_deg,
    z_scale: float = _D.z_scale,
) -> np.ndarray:
    """MDM in [0, 1] from per-cell digressions (F, J) (section 3.4): ``1 - exp(-M^2)``.

    ``normalization`` says what ``digression`` holds and how rows are scaled:

    - ``"median"`` (default): angles in radians; each joint's row is divided by
      ``max(row_scale * row median, floor_deg)``.
    - ``"spread"``: digressions already divided by the neighbours' spread at
      the cell (:func:`detect`); ``M = digression / z_scale``.
    - ``"mean"``: angles; rows divided by their mean, as the paper writes it
      (every row's mean then sits at ``1 - e^-1 = 0.63``, above the paper's
      threshold of 0.5, so this flags a large share of any clip).

    NaN digressions (not analysed) give 0.
    """
    d = np.asarray(digression, dtype=np.float64)
    valid = np.isfinite(d)
    filled = np.where(valid, d, np.nan)
    any_valid = valid.any(axis=0)
    scale = np.full(d.shape[1], np.inf)
    if normalization == "spread":
        scale[:] = z_scale
    elif normalization == "mean":
        scale[any_valid] = np.nanmean(filled[:, any_valid], axis=0)
    elif normalization == "median":
        scale[any_valid] = np.maximum(row_scale * np.nanmedian(filled[:, any_valid], axis=0), np.radians(floor_deg))
    else:
        raise ValueError(f"normalization must be 'spread', 'median' or 'mean', got {normalization!r}")
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, np.inf)
    Mn = np.where(valid, d / scale, 0.0)
    return 1.0 - np.exp(-(Mn**2))


@dataclass(frozen=True, eq=False)
class Detection:
    """Result of :func:`detect`; everything (F, J) is at the input's frames and joint order.

    mdm : float (F, J) movement digression map in [0, 1] (0 on joints not analysed);
    flags : bool (F, J) the errors: ``mdm > threshold`` confirmed by ``jumps``
    (:func:`confirm_flags`), with ``holds``, ``swaps`` and ``offsets``; or ``mdm >
    threshold`` alone when the detection was made with ``confirm=False``; jumps : bool (F, J) the analysed joints'
    :func:`discontinuities` over their own motion's level (less the turns their chain undoes, :func:`~mocapkit.cleaning.ssa.cues.uncompensated_breaks`, and at 24-30 fps the breaks their speed beside them explains, :func:`~mocapkit.cleaning.ssa.cues.motion_explained`); holds, swaps, offsets : bool (F, J) their
    :func:`held_joints` (a hold that holds a frozen channel cut to its frozen cells,
    :func:`~mocapkit.cleaning.ssa.freeze_bounds.bounded_holds`), :func:`side_swaps` (with the swaps whose
    exchange back joins the take, :func:`~mocapkit.cleaning.ssa.swap_exchange.joined_swaps`) and
    :func:`transient_offsets` (flagged with confirmation at any threshold); agreement : float (F, J)
    the median angle in radians of the other joints of the group that judges
    the cell from that group's mean texture
    (:func:`~mocapkit.cleaning.ssa.drifts.group_agreement`), consistency : float (F, J) the joint's
    angle over the neighbours' spread and noise (the evidence of the smooth
    drifts, :func:`smooth_drift_flags`, where ``params.drift_change`` is
    off); change : float (F, J) or None, the joint's offset from
    the mean texture less the offset it holds over the take, over the same
    spread and noise, both in the joint group that judges the cell
    (:func:`~mocapkit.cleaning.ssa.drifts.group_offset_change`;
    the drift rule's evidence, None where ``params.drift`` or
    ``params.drift_change`` is off); turn : float (F, J, 3) or None, that change's direction, a rotation vector in
    the parent joint's frame, radians (:func:`~mocapkit.cleaning.ssa.drifts.group_offset_turn`: the drift rule's
    crossed pairs, ``params.drift_cross_cos``; None where ``change`` is, or for a detection saved before, whose
    :meth:`drifts` then does not ask them); digression : float (F, J) angle in
    radians between the input and the mean motion texture (NaN where not
    analysed); best_group : int8 (F, J) the group whose neighbours explain the
    cell best (-1 none); spikes : bool (F, J) the ``jumps`` that are spikes
    (:func:`~mocapkit.cleaning.ssa.spikes.spike_breaks`; None for a detection
    saved before they were told apart); lone_spikes : bool (F, J) the spikes far
    past the joint's own motion on cells no neighbour word judges, flagged with
    confirmation (:func:`~mocapkit.cleaning.ssa.spikes.lone_spikes`; None for a
    detection saved before); frozen : bool (F, J) the frozen channels, an exact repeat while the body moves that
    ends in a break, flagged whether or not a neighbour word judges them
    (:func:`~mocapkit.cleaning.ssa.freezes.frozen_channels`; None for a detection saved before);
    parents : int (J,) the skeleton's parent indices, read by the drift rule's chains
    (None for a detection saved before, whose :meth:`drifts` then does not ask them). ``left_out``: ``((joint name, why), ...)``
    the joints not analysed and why (:func:`~mocapkit.cleaning.ssa.texture.left_out_joints`;
    :meth:`not_analysed`). The rest records how the analysis
    was made so that :func:`repair` can fetch the neighbour words again.

    span : ``(lo, hi)`` or None. None: the whole take was analysed. ``(lo, hi)``: only its frames ``lo .. hi - 1``
    were (:meth:`padded`: the calibration poses at the take's ends left out,
    :func:`mocapkit.cleaning.whole_take.detect_take`); the (F, J) arrays are at the take's frames, with nothing
    flagged outside the span, while the word starts and neighbours count from ``lo``. :meth:`causes`,
    :meth:`drifts` and :meth:`with_threshold` judge the analysed frames only (:meth:`analysed_part`), and
    :func:`repair` replaces cells inside the span only.

    repeats : ``((first, last), ...)``: the runs of frames that repeat the frame before bit for bit
    (:func:`~mocapkit.cleaning.ssa.repeats.repeat_runs`, counted from the first frame analysed), analysed once:
    :func:`detect` analysed the take without them and each repeat holds what the frame it repeats holds (so a frame
    written twice changes no flag but its own, :mod:`~mocapkit.cleaning.ssa.repeats`); the word starts and
    neighbours count frames of the take without them. :meth:`causes`, :meth:`drifts` and :meth:`with_threshold`
    judge that take (:meth:`unrepeated`), and :func:`repair` mends it.

    inbetweens : ``((first, last), ...)``: the runs of frames that lie evenly between the frames around them (an
    interpolated frame another tool inserted: :func:`~mocapkit.cleaning.ssa.repeats.inbetween_runs`), analysed
    once like the repeats: each holds the flags and cues of either frame around it and the values of the one
    before (:func:`~mocapkit.cleaning.ssa.repeats.expand`), and :func:`repair` blends it again only where those
    frames change.
    """

    mdm: np.ndarray
    flags: np.ndarray
    digression: np.ndarray
    best_group: np.ndarray
    threshold: float
    fps: float
    joint_names: tuple
    analysed: np.ndarray  # (J,) bool
    texture_joints: np.ndarray  # (m,) skeleton indices
    group_names: tuple
    group_masks: np.ndarray  # (G, m) bool
    word_starts: np.ndarray  # (W,) at the analysis rate
    neighbor_pos: np.ndarray  # (G, W, K)
    neighbor_iend: np.ndarray
    neighbor_jend: np.ndarray
    neighbor_dist: np.ndarray
    context_clips: tuple  # ((name, frames at the analysis rate), ...) of the context texture, clip 0 = the input
    jumps: np.ndarray  # (F, J) bool
    holds: np.ndarray  # (F, J) bool
    swaps: np.ndarray  # (F, J) bool
    offsets: np.ndarray  # (F, J) bool
    agreement: np.ndarray  # (F, J) float, radians
    consistency: np.ndarray  # (F, J) float
    params: SSAParams = field(default_factory=SSAParams)
    notes: tuple = ()
    analysis: Analysis | None = field(default=None, repr=False)
    spikes: np.ndarray | None = None
    change: np.ndarray | None = None  # (F, J) float, None without the drift rule
    span: tuple | None = None  # (lo, hi): the frames analysed, when not the whole take (padded)
    left_out: tuple = ()  # ((joint name, why), ...): the joints not analysed
    lone_spikes: np.ndarray | None = None  # (F, J) bool, None for a detection saved before the rule
    parents: np.ndarray | None = None  # (J,) int, the skeleton's parents (the drift rule's chains); None: saved before
    repeats: tuple = ()  # ((first, last), ...): frames repeating the frame before, analysed once
    reversals: np.ndarray | None = None  # (F, J) bool: swap cells whose run plays better backwards; None: saved before
    inbetweens: tuple = ()  # ((first, last), ...): frames lying evenly between the frames around them, analysed once
    frozen: np.ndarray | None = None  # (F, J) bool: frozen channels (freezes.frozen_channels); None: saved before
    turn: np.ndarray | None = None  # (F, J, 3) float: the change's direction (radians); None without it or saved before

    @property
    def once(self) -> tuple:
        """``((first, last), ...)``: the runs of frames the take was analysed without (:attr:`repeats` and
        :attr:`inbetweens`), by first frame."""
        return analysed_once(self.repeats, self.inbetweens)

    @property
    def num_frames(self) -> int:
        return int(self.mdm.shape[0])

    def not_analysed(self) -> dict[str, str]:
        """Joint name -> why it was not analysed, for every joint outside :attr:`texture_joints` (in skeleton
        order; "not analysed" for a detection saved before the reasons were kept). Their MDM is 0 and nothing
        flags them: they were not checked, not found clean."""
        why = dict(self.left_out)
        return {n: why.get(n, "not analysed") for n, a in zip(self.joint_names, self.analysed) if not a}

    def segments(self) -> list[tuple[str, int, int]]:
        """Flagged runs as ``(joint name, start frame, end frame)``, half-open, sorted by start (:func:`flag_runs`)."""
        return flag_runs(self.flags, self.joint_names)

    def drifts(self) -> np.ndarray:
        """(F, J) bool smooth drifts (:func:`smooth_drift_flags`; any threshold), none where ``params.drift`` is off."""
        if not self.params.drift:
            return np.zeros(self.mdm.shape, dtype=bool)
        if self.span is not None:  # judged on the frames analysed, as the detection itself was
            return _pad_frames(self.analysed_part().drifts(), self.span[0], self.num_frames, False)
        if self.once:
            return expand(self.unrepeated().drifts(), self.once, self.num_frames, self.inbetweens)
        return _drifts(self.jumps, self.agreement, self.consistency, self.fps, self.params, self.joint_names, self.change,
                       self.parents, self.turn)

    def causes(self) -> np.ndarray:
        """(F, J) :data:`~mocapkit.cleaning.ssa.cues.CAUSE_DTYPE`: which rules flag each cell (:func:`~mocapkit.cleaning.ssa.cues.flag_causes`; ``flags``
        is exactly where it is not 0). Made once where the flags were made (:func:`detect`, :meth:`with_threshold`,
        :meth:`padded`: :meth:`_with_causes`), else here; a copy each call."""
        made = self.__dict__.get("_causes")
        if made is not None:
            return made.copy()
        if self.span is not None:
            return _pad_frames(self.analysed_part().causes(), self.span[0], self.num_frames, 0)
        if self.once:
            return expand(self.unrepeated().causes(), self.once, self.num_frames, self.inbetweens)
        return self.flag_causes(self.threshold)

    def flag_causes(self, threshold: float) -> np.ndarray:
        """(F, J) :data:`~mocapkit.cleaning.ssa.cues.CAUSE_DTYPE`: :func:`~mocapkit.cleaning.ssa.cues.flag_causes` of this analysis at ``threshold`` (the
        frames analysed only: a detection of a :attr:`span` is judged by :meth:`causes` and :meth:`with_threshold`)."""
        return flag_causes(self.mdm, self.jumps, self.holds, self.swaps, self.offsets, threshold, self.fps,
                           self.params.confirm, self.params.confirm_margin_s, self.drifts(), self.spikes,
                           np.isfinite(self.digression), self.lone_spikes, self.reversals, self.frozen)

    def _with_causes(self, causes: np.ndarray) -> "Detection":
        """This detection, its :meth:`causes` ``causes`` (their flags its :attr:`flags`), kept beside the frozen
        fields so that they are not made again (a cache, not a field: ``dataclasses.replace`` leaves it behind)."""
        object.__setattr__(self, "_causes", np.array(causes, dtype=CAUSE_DTYPE))
        return self

    def with_threshold(self, threshold: float) -> "Detection":
        """The same analysis flagged at another threshold (confirmed by the jumps if the detection was)."""
        threshold = float(threshold)
        if not 0.0 < threshold < 1.0:
            raise ValueError(f"threshold must be in (0, 1), got {threshold}")
        if self.span is not None:
            sub = self.analysed_part().with_threshold(threshold)
            out = dataclasses.replace(self, threshold=threshold, flags=_pad_frames(sub.flags, self.span[0],
                                                                                   self.num_frames, False))
            return out._with_causes(_pad_frames(sub.causes(), self.span[0], self.num_frames, 0))
        if self.once:
            sub = self.unrepeated().with_threshold(threshold)
            out = dataclasses.replace(self, threshold=threshold,
                                      flags=expand(sub.flags, self.once, self.num_frames, self.inbetweens))
            return out._with_causes(expand(sub.causes(), self.once, self.num_frames, self.inbetweens))
        causes = self.flag_causes(threshold)  # flag_rule's flags are where they are not 0
        return dataclasses.replace(self, threshold=threshold, flags=causes != 0)._with_causes(causes)

    def padded(self, lo: int, num_frames: int) -> "Detection":
        """This detection of frames ``lo .. lo + self.num_frames - 1`` of a take of ``num_frames`` frames, put back
        at the take's frames: nothing flagged outside them (no MDM, no cue, no digression), ``span`` set, and a
        note saying which frames were analysed. The word starts and neighbours still count from ``lo``, and
        :attr:`analysis` stays the prepared part, which :func:`repair` reuses on it (:meth:`analysed_part`)."""
        if self.span is not None:
            raise ValueError("the detection is padded already")
        lo, F = int(lo), int(num_frames)
        hi = lo + self.num_frames
        if lo < 0 or hi > F:
            raise ValueError(f"frames {lo}-{hi - 1} are not frames of a take of {F}")
        pads = {k: v for k, v in _PADS.items() if getattr(self, k) is not None}
        out = dataclasses.replace(self, **{k: _pad_frames(np.asarray(getattr(self, k)), lo, F, v) for k, v in pads.items()},
                                  span=(lo, hi), notes=tuple(self.notes) + (_span_note(lo, hi),))
        made = self.__dict__.get("_causes")
        return out if made is None else out._with_causes(_pad_frames(made, lo, F, 0))

    def analysed_part(self) -> "Detection":
        """The detection of the frames analysed (:attr:`span`) alone, as :func:`detect` made it on them; ``self``
        when the whole take was analysed."""
        if self.span is None:
            return self
        lo, hi = self.span
        notes = tuple(self.notes)
        if notes and notes[-1] == _span_note(lo, hi):
            notes = notes[:-1]
        cut = {k: np.asarray(getattr(self, k))[lo:hi] for k in _PADS if getattr(self, k) is not None}
        return dataclasses.replace(self, **cut, span=None, notes=notes)

    def unrepeated(self) -> "Detection":
        """The detection of the frames analysed without their repeats and interpolated frames (:attr:`once`), as
        :func:`detect` made it on the take without them; ``self`` when there are none. Call it on
        :meth:`analysed_part`'s detection."""
        if not self.once:
            return self
        if self.span is not None:
            raise ValueError("call unrepeated() on the analysed part (analysed_part())")
        keep = kept_frames(self.once, self.num_frames)
        cut = {k: np.asarray(getattr(self, k))[keep] for k in _PADS if getattr(self, k) is not None}
        return dataclasses.replace(self, **cut, repeats=(), inbetweens=())

    def repeated(self, repeats, num_frames: int, inbetweens=()) -> "Detection":
        """This detection of a take without its ``repeats`` (:func:`~mocapkit.cleaning.ssa.repeats.repeat_runs`)
        and ``inbetweens`` (:func:`~mocapkit.cleaning.ssa.repeats.inbetween_runs`) put at the take's
        ``num_frames`` frames: each repeat holds the rows of the frame it repeats, each interpolated frame those
        of the frames around it (:func:`~mocapkit.cleaning.ssa.repeats.expand`)."""
        repeats = tuple((int(a), int(b)) for a, b in repeats)
        inbetweens = tuple((int(a), int(b)) for a, b in inbetweens)
        once = analysed_once(repeats, inbetweens)
        if not once:
            return self
        if self.once or self.span is not None:
            raise ValueError("the detection is of the take with its repeats already")
        arrays = {k: expand(getattr(self, k), once, num_frames, inbetweens) for k in _PADS
                  if getattr(self, k) is not None}
        return dataclasses.replace(self, **arrays, repeats=repeats, inbetweens=inbetweens)

    def save(self, path) -> Path:
        """Write as ``.npz`` (no pickles) through a temporary file and a rename."""
        from ...io import atomic_write

        arrays = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                  if f.name != "analysis" and getattr(self, f.name) is not None}
        arrays.pop("span", None)
        arrays.pop("repeats", None)
        arrays.pop("inbetweens", None)
        meta = {
            "span": None if self.span is None else [int(v) for v in self.span],
            "threshold": self.threshold,
            "fps": self.fps,
            "joint_names": list(self.joint_names),
            "group_names": list(self.group_names),
            "context_clips": [list(c) for c in self.context_clips],
            "params": self.params.as_dict(),
            "notes": list(self.notes),
            "left_out": [list(p) for p in self.left_out],
            "repeats": [list(r) for r in self.repeats],
            "inbetweens": [list(r) for r in self.inbetweens],
        }
        for key in meta:
            arrays.pop(key, None)
        arrays["meta"] = np.array(json.dumps(meta))
        path = Path(path)
        with atomic_write(path, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        return path

    @classmethod
    def load(cls, path) -> "Detection":
        """Read a detection written by :meth:`save`."""
        from ...errors import MocapFormatError

        from ...io.npz import load_arrays

        path = Path(path)
        try:
            data = load_arrays(path)  # declared shapes checked before anything is inflated
            meta = json.loads(str(data.pop("meta")))
            for key in ("jumps", "holds", "swaps", "offsets"):  # written before these rules existed
                if key not in data:
                    data[key] = np.zeros(data["mdm"].shape, dtype=bool)
            for key in ("agreement", "consistency"):  # written before the drift rule: no evidence
                if key not in data:
                    data[key] = np.full(data["mdm"].shape, np.nan)
            return cls(
                **data,
                threshold=float(meta["threshold"]),
                fps=float(meta["fps"]),
                joint_names=tuple(meta["joint_names"]),
                group_names=tuple(meta["group_names"]),
                context_clips=tuple((str(n), int(f)) for n, f in meta["context_clips"]),
                params=SSAParams.from_dict(meta["params"]),
                notes=tuple(meta["notes"]),
                left_out=tuple((str(n), str(w)) for n, w in meta.get("left_out", [])),
                span=None if meta.get("span") is None else (int(meta["span"][0]), int(meta["span"][1])),
                repeats=tuple((int(a), int(b)) for a, b in meta.get("repeats", [])),
                inbetweens=tuple((int(a), int(b)) for a, b in meta.get("inbetweens", [])),
            )
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise MocapFormatError(path, f"not a mocapkit detection file ({e})") from None


def flag_runs(flags: np.ndarray, joint_names) -> list[tuple[str, int, int]]:
    """The runs of ``flags`` ((F, J) bool) as ``(joint name, start frame, end frame)``, half-open, sorted by start
    then joint name: :meth:`Detection.segments`, and the review mode's flags with the turn-overs among them
    (:func:`mocapkit.cleaning.whole_take.review_turn_overs`)."""
    flags = np.asarray(flags, dtype=bool)
    out = []
    for j in np.flatnonzero(flags.any(axis=0)):
        out += [(joint_names[j], a, b) for a, b in contact_segments(flags[:, j])]
    return sorted(out, key=lambda s: (s[1], s[0]))


#: what each (F, J) array of a :class:`Detection` holds on frames that were not analysed (:meth:`Detection.padded`)
_PADS = {"mdm": 0.0, "flags": False, "digression": np.nan, "best_group": -1, "jumps": False, "holds": False,
         "swaps": False, "offsets": False, "agreement": np.nan, "consistency": np.nan, "spikes": False, "change": np.nan,
         "lone_spikes": False, "reversals": False, "frozen": False, "turn": np.nan}


def _pad_frames(a: np.ndarray, lo: int, F: int, fill) -> np.ndarray:
    """(F, ...) holding ``a`` at frames ``lo .. lo + len(a) - 1`` and ``fill`` elsewhere."""
    out = np.full((F,) + a.shape[1:], fill, dtype=a.dtype)
    out[lo : lo + a.shape[0]] = a
    return out


def _span_note(lo: int, hi: int) -> str:
    """The note of a detection analysed on frames ``lo .. hi - 1`` only (:meth:`Detection.padded`)."""
    return f"analysed frames {lo}-{hi - 1} (calibration poses or blank frames at the take's ends left out); word starts count from there"


def _drifts(jumps, agreement, consistency, fps: float, p: SSAParams, joint_names, change=None,
            parents=None, turn=None) -> np.ndarray:
    """:func:`smooth_drift_flags` with the drift parameters of ``p``, partners paired by ``joint_names``, chains
    read from ``parents`` (the skeleton's parent indices; None: the chain is not asked).

    With ``change`` (:func:`offset_change`, used where ``p.drift_change``) the evidence of a cell is the change, not
    ``consistency`` (a style holds its offset, a drift changes it); with its direction ``turn`` (F, J, 3) too, two
    neighbours that stop each other and turn about crossed axes are two drifts (``p.drift_cross_cos``)."""
    turns = None
    if change is not None and p.drift_change:
        consistency = change
        turns = turn if p.drift_cross_cos is not None else None
    ratio = p.drift_partner_ratio
    partners = None if ratio is None else mirror_pairs(joint_names)
    chain = p.drift_chain_ratio
    return smooth_drift_flags(jumps, agreement, consistency, fps, p.drift_repeat_deg, p.drift_z, p.drift_min_s,
                              p.confirm_margin_s, p.drift_extent, p.drift_others, p.drift_return_ratio, partners,
                              1.0 if ratio is None else ratio, None if chain is None else parents,
                              1.0 if chain is None else chain, turns,
                              0.0 if p.drift_cross_cos is None else p.drift_cross_cos)


def _digression(motion, mean_tex, spread, texture_joints, up, fps_a, noise_deg, shift_s=0.0, speeds=False, offsets=False):
    """Per-group digression of the input (at its own rate) from the mean texture upsampled from ``fps_a``.

    With ``shift_s`` the angle at frame f is the smallest over the mean
    texture's frames within ``shift_s`` seconds of f: a timing tolerance.

    Returns ``(angle, z)``, both (G, F, m): the rotation angle in radians, and
    that angle over the neighbours' spread at the cell, ``sqrt(spread^2 +
    noise^2)`` with ``noise_deg`` the capture noise floor. With ``speeds``
    also the mean texture's angular speed at the input's frames, deg/s (G, F, m).
    With ``offsets`` also the turn, in the parent joint's frame, that takes the
    mean texture's rotation to the input's, as a rotation vector, radians (G, F,
    m, 3), and that denominator, radians (G, F, m)
    (the evidence of :func:`~mocapkit.cleaning.ssa.drifts.offset_change`).
    """
    F = motion.num_frames
    inp = facing_aligned(motion.rotations, up)[:, texture_joints]
    G = mean_tex.shape[0]
    ang = np.full((G, F, len(texture_joints)), np.nan)
    z = np.full_like(ang, np.nan)
    t = np.arange(F) * (fps_a / motion.fps)
    src_t = np.arange(mean_tex.shape[1])
    noise = np.radians(noise_deg)
    speed = np.full_like(ang, np.nan) if speeds else None
    rot = np.full(ang.shape + (3,), np.nan) if offsets else None
    scale = np.full_like(ang, np.nan) if offsets else None
    for g in range(G):
        # the group's joints; the others' mean texture is NaN throughout, and so would be all they give
        live = np.flatnonzero(~np.isnan(mean_tex[g]).all(axis=(0, 2)))
        if not len(live):
            continue
        up_q = upsample_quaternions(mean_tex[g][:, live], fps_a, F, motion.fps)
        if speeds and F > 1:
            step = np.degrees(step_angles(up_q)) * motion.fps
            speed[g][:, live] = np.concatenate([step, step[-1:]])
        # timing tolerance: the smallest angle to the mean texture a few frames earlier or later
        a = word_dtw.shift_tolerant_angles(inp[:, live], up_q, int(round(shift_s * motion.fps)))
        ang[g][:, live] = a
        sp = np.stack([np.interp(t, src_t, spread[g][:, c]) for c in live], axis=1)
        den = np.sqrt(np.where(np.isfinite(sp), sp, 0.0) ** 2 + noise**2)
        z[g][:, live] = a / den
        if offsets:
            rel = R.quaternion_multiply(inp[:, live], R.quaternion_conjugate(up_q))  # in the parent's frame
            rot[g][:, live] = R.quaternion_to_rotvec(np.where(rel[..., :1] < 0, -rel, rel))
            scale[g][:, live] = den
    return (ang, z) + ((speed,) if speeds else ()) + ((rot, scale) if offsets else ())


def detect(
    motion: Motion,
    context=None,
    threshold: float = 0.5,
    *,
    params: SSAParams | None = None,
    groups: Mapping[str, Sequence] | None = None,
    progress: bool = False,
    **overrides,
) -> Detection:
    """Movement digression map and error flags of ``motion`` by self-similarity (sections 3 and 5).

    Parameters
    ----------
    motion : Motion
        The take to analyse (any frame rate; no missing frames).
    context : None, list of Motions, or MotionDatabase
        Where to look for similar words besides the clip itself: None is local
        analysis; related clips (same joints) make a small or large context.
        A context clip whose samples are mostly the input's (more than half of
        its cells, :func:`~mocapkit.cleaning.ssa.texture.own_share`: the take
        itself, renamed or with errors) is the input itself and is left out,
        whatever the names.
    threshold : float
        MDM value above which a cell is flagged (0.5 in the paper).
    params : SSAParams, optional
        The analysis parameters (default ``SSAParams()``, the paper's and this
        library's defaults; see :class:`SSAParams` for each).
    groups : dict name -> joint names or indices, optional
        Joint groups for motion words; default :func:`joint_groups` (whole,
        upper, lower, left, right).
    progress : bool
        Show a progress bar over the words.
    **overrides
        Any field of :class:`SSAParams` (``k=1``, ``confirm=False``,
        ``max_word_angle_deg=8.0``, ...) replacing the one in ``params``.

    Raises :class:`~mocapkit.errors.NotJudgedError` (a ValueError) on a take no motion word can judge: shorter than
    one word (0.625 s, counted without its repeated and interpolated frames) or under 12 fps
    (:func:`~mocapkit.cleaning.ssa.texture.too_coarse`); its one line names the take and the length or rate a word
    needs, the words ``mocapkit.clean`` says as it skips such a take (its result's ``detection`` then None).

    The detection keeps the prepared take (:attr:`Detection.analysis`), so
    :func:`repair` does not resample the take and its context again. Frames that repeat the frame before bit
    for bit are analysed once (:attr:`Detection.repeats`, :mod:`~mocapkit.cleaning.ssa.repeats`): the take is
    analysed without them, and each takes what the frame it repeats was given; so are frames another tool
    interpolated between two recorded ones (:attr:`Detection.inbetweens`), each given what the frames around it
    were given.
    """
    if not 0.0 < threshold < 1.0:
        raise ValueError(f"threshold must be in (0, 1), got {threshold}")
    params = (SSAParams() if params is None else params).replace(**overrides)
    runs = repeat_runs(motion) if isinstance(motion, Motion) else ()
    inbetweens = inbetween_runs(motion, runs) if isinstance(motion, Motion) else ()
    once = without_repeats(motion, analysed_once(runs, inbetweens))
    det = detect_prepared(prepare(once, context, params, groups=groups), threshold, progress=progress)
    return det.repeated(runs, motion.num_frames, inbetweens)


def _judged_by_context(src, full, grows, words, nb: Neighbors, unseen: np.ndarray, prefilter: bool,
                       max_word_angle_deg, opts: dict) -> np.ndarray:
    """Fill, in place, the neighbours of the (joint group, word) pairs the take alone leaves ``unseen`` (G, W) from
    the whole texture ``full`` (the take, then its context); returns the pairs still unseen. Positions in the take
    are positions in ``full`` (the take is its first clip)."""
    redo = unseen.any(axis=0)
    nb2 = nearest_words(src, full, grows, words[redo], self_clip=0, prefilter=prefilter, **opts)
    still = unseen_words(nb2, grows, max_word_angle_deg)
    take = unseen[:, redo]  # (G, R): the groups the take did not see, per redone word
    for a in ("pos", "iend", "jend", "dist"):
        arr = getattr(nb, a)
        sub = arr[:, redo]
        sub[take] = getattr(nb2, a)[take]
        arr[:, redo] = sub
    out = unseen.copy()
    out[:, redo] = take & still
    return out


def detect_prepared(an: Analysis, threshold: float = 0.5, *, progress: bool = False) -> Detection:
    """:func:`detect` on a take already prepared by :func:`prepare` (with its parameters and context)."""
    from tqdm.auto import tqdm
    from ...progress import bar_disabled, bar_size

    motion, p = an.motion, an.params
    N, M = int(p.source_length), int(p.target_length)
    src, full, tex_joints, up = an.source, an.texture, an.joints, an.up
    notes = list(an.notes)
    fps = p.analysis_fps
    normalization, row_scale, floor_deg, z_scale = p.normalization, p.row_scale, p.floor_deg, p.z_scale
    max_word_angle_deg = p.max_word_angle_deg
    resid = an.residuals  # for the breaks and the side swaps (midpoint_residuals, made once per analysis)
    # breaks that stand out from the joint's own motion and speed (30 fps too)
    jumps = own_breaks(resid, p.jump_deg, motion.fps, motion.rotations)
    own = jumps.copy()  # the frozen channels end in a break of the joint's own, whatever its chain does
    # a peak the frame-rate cap alone lets through, that the joint's own motion makes again elsewhere, is motion
    jumps = recurring_breaks(resid, jumps, motion.fps, p.jump_deg)
    # a fast turn that speeds up and slows down over several frames and never turns back (a hand's flick) is motion
    jumps = smooth_turn_breaks(np.asarray(motion.rotations, dtype=np.float64), resid, jumps, p.jump_deg,
                               motion.skeleton.parents, motion.fps)
    # a turn the joint's chain undoes (a solver sharing a bend another way) is no evidence of an error
    chain_memo: dict = {}  # the break events judged compensated or not, read again by the lone spikes
    jumps = uncompensated_breaks(np.asarray(motion.rotations, dtype=np.float64), motion.skeleton.parents, jumps,
                                 chain_memo)
    # a chain turned over in place (a thigh flipped about itself, the knee bent the other way) moves no joint
    positions, unpruned = motion.global_positions(), jumps
    jumps = position_kept_breaks(positions, motion.skeleton.parents, jumps, resid)
    sk = motion.skeleton
    gnames, grows = list(an.group_names), list(an.group_rows)
    words = an.words
    W, G, m = len(words), len(grows), len(tex_joints)
    k = p.k
    has_context = an.has_context
    two_stage = p.two_stage
    prefilter = bool(p.prefilter)  # the approximate kd-tree search only when asked for: the exact one scales
    opts = dict(k=k, source_length=N, target_length=M, min_width=p.min_width, max_run=p.max_run, candidates=p.candidates)
    neighbors = Neighbors(
        np.full((G, W, k), -1, dtype=np.int64),
        np.zeros((G, W, k), dtype=np.int16),
        np.zeros((G, W, k), dtype=np.int16),
        np.full((G, W, k), np.inf, dtype=np.float32),
    )
    mean_tex = np.full((G, src.num_frames, m, 4), np.nan)
    spread = np.full((G, src.num_frames, m), np.nan)
    kept: dict = {}  # the words the mean texture warps against the whole texture, for the repair of the flagged ones
    bar = tqdm(total=W * G * (2 if two_stage and has_context else 1), desc=f"ssa {motion.name or 'motion'}", disable=bar_disabled(progress), **bar_size(), unit="word")
    try:
        if two_stage and has_context:
            whole = [gnames.index("whole")] if "whole" in gnames else [int(np.argmax([len(r) for r in grows]))]
            nb1 = nearest_words(src, src, [grows[i] for i in whole], words, self_clip=0, progress=bar, **opts)
            unseen_words(nb1, [grows[i] for i in whole], max_word_angle_deg)
            mt1, sp1 = mean_motion_texture(src, src, [grows[i] for i in whole], words, nb1, N, M, return_spread=True)
            a1, z1 = _digression(motion, mt1, sp1, tex_joints, up, fps, p.noise_deg, p.shift_s)
            mdm1 = movement_digression_map(z1[0] if normalization == "spread" else a1[0], normalization, row_scale, floor_deg, z_scale)
            hot_frames = np.flatnonzero(mdm1.max(axis=1) > p.screen_threshold) * (fps / motion.fps)
            distinct = np.zeros(W, dtype=bool)
            for f in hot_frames:
                distinct |= (words <= f) & (f < words + N)
            # words overlapping the distinct ones, so every frame of the region keeps full word coverage
            region = np.zeros(src.num_frames, dtype=bool)
            for s in words[distinct]:
                region[s : s + N] = True
            redo = np.array([region[s : s + N].any() for s in words])
            for gi in whole:
                neighbors.pos[gi], neighbors.iend[gi] = nb1.pos[0], nb1.iend[0]
                neighbors.jend[gi], neighbors.dist[gi] = nb1.jend[0], nb1.dist[0]
                mean_tex[gi] = mt1[0]
                spread[gi] = sp1[0]
            if redo.any():
                sub = words[redo]
                nb2 = nearest_words(src, full, grows, sub, self_clip=0, prefilter=prefilter, progress=bar, **opts)
                unseen_words(nb2, grows, max_word_angle_deg)
                for a in ("pos", "iend", "jend", "dist"):
                    getattr(neighbors, a)[:, redo] = getattr(nb2, a)
                mt2, sp2 = mean_motion_texture(src, full, grows, sub, nb2, N, M, return_spread=True, keep=kept)
                # region frames take the second stage; groups other than the whole body exist only there
                mean_tex[:, region] = mt2[:, region]
                spread[:, region] = sp2[:, region]
                for gi in range(G):
                    if gi not in whole:
                        mean_tex[gi, ~region] = np.nan
                        spread[gi, ~region] = np.nan
            notes.append(f"two-stage: {int(redo.sum())} of {plural(W, 'word')} re-analysed against the context")
        else:
            # the bundled default context, a general sample of other people's motion, only judges the words the take
            # itself cannot: as every word's neighbours it outvoted the take's own repetitions, and the mean of other
            # people's style hid errors (33 corrupted HDM05 and CMU takes: recall 0.815 -> 0.712, error after repair
            # 7.6 -> 10.4 deg)
            info = getattr(an.context_given, "info", None)
            gaps_only = has_context and isinstance(info, dict) and bool(info.get("default"))
            nb = nearest_words(src, src if gaps_only else full, grows, words, self_clip=0,
                               prefilter=prefilter and has_context and not gaps_only, progress=bar, **opts)
            unseen = unseen_words(nb, grows, max_word_angle_deg)
            if gaps_only and unseen.any():
                before = int(unseen.any(axis=0).sum())
                unseen = _judged_by_context(src, full, grows, words, nb, unseen, prefilter, max_word_angle_deg, opts)
                notes.append(f"{before} of {plural(W, 'word')} {'has nothing like it' if before == 1 else 'have nothing like them'} "
                             "in the take in some joint group: judged against the default context there")
            if unseen.any():
                n_unseen = int(unseen.any(axis=0).sum())
                notes.append(
                    f"{n_unseen} of {plural(W, 'word')} {'has' if n_unseen == 1 else 'have'} no neighbour within "
                    f"{max_word_angle_deg:g} deg (RMS joint angle) in some joint group: not judged there"
                )
            neighbors = nb
            mean_tex, spread = mean_motion_texture(src, full, grows, words, nb, N, M, return_spread=True, keep=kept)
    finally:
        bar.close()
    dig_g, z_g, speed_g, *more = _digression(motion, mean_tex, spread, tex_joints, up, fps, p.noise_deg, p.shift_s,
                                             speeds=True, offsets=p.drift and p.drift_change)  # (G, F, m)
    F, J = motion.num_frames, sk.num_joints
    filled = np.where(np.isnan(dig_g), np.inf, dig_g)
    best = np.argmin(filled, axis=0)  # (F, m): the group whose mean texture is closest
    dmin = np.take_along_axis(filled, best[None], axis=0)[0]
    smin = np.take_along_axis(z_g if normalization == "spread" else filled, best[None], axis=0)[0]
    smin = np.where(np.isfinite(dmin), smin, np.inf)
    ok = np.isfinite(smin)
    digression = np.full((F, J), np.nan)
    digression[:, tex_joints] = np.where(ok, dmin, np.nan)
    scores = np.full((F, J), np.nan)
    scores[:, tex_joints] = np.where(ok, smin, np.nan)
    best_group = np.full((F, J), -1, dtype=np.int8)
    best_group[:, tex_joints] = np.where(ok, best, -1)
    mean_speed = np.full((F, J), np.nan)
    mean_speed[:, tex_joints] = np.where(ok, np.take_along_axis(speed_g, best[None], axis=0)[0], np.nan)
    mdm = movement_digression_map(scores, normalization, row_scale, floor_deg, z_scale)
    consistency = np.full((F, J), np.nan)
    consistency[:, tex_joints] = np.where(ok, np.take_along_axis(z_g, best[None], axis=0)[0], np.nan)
    change = turn = None
    if more:  # the drift rule's second evidence: the joint's offset from its neighbours, less the one it holds
        rot_g, scale_g = more
        turned = group_offset_turn(rot_g, scale_g, best)  # the change's direction; its length is the change
        change = np.full((F, J), np.nan)
        change[:, tex_joints] = np.where(ok, group_offset_change(rot_g, scale_g, best, turn=turned), np.nan)
        turn = np.full((F, J, 3), np.nan)
        turn[:, tex_joints] = np.where(ok[..., None], turned, np.nan)
    analysed = np.zeros(J, dtype=bool)
    analysed[tex_joints] = True
    q = np.asarray(motion.rotations, dtype=np.float64)
    # breaks under the joint's own level whose shape the digression backs (a spike, an offset and its undoing)
    # (a chain turned over in place confirms nothing there either)
    backed = backed_breaks(q, resid, digression, analysed, motion.fps, sk.parents, p.jump_deg, p.offset_min_deg,
                           memo=chain_memo, offsets=backs_offsets(motion.fps, p.analysis_fps))
    backed = smooth_turn_breaks(q, resid, backed, p.jump_deg, sk.parents, motion.fps)  # nor does a smooth turn
    if backed.any():
        jumps |= backed & position_kept_breaks(positions, sk.parents, unpruned | backed, resid)
    jumps &= analysed[None, :]
    holds = held_joints(motion, mean_speed, travel_deg=p.hold_travel_deg,
                        min_frames=hold_min_frames(motion.fps, p.analysis_fps)) & analysed[None, :]
    holds = without_turning_points(q, holds)  # still for one step where it turns back: its swing's end, not a freeze
    holds = held_repeats(holds)  # a hold's first frame is the live sample it repeats (freeze_bounds.py)
    # a channel repeated bit for bit while the body moves, ending in a break, needs no similar motion to judge it
    frozen = frozen_channels(q, own, analysed, motion.fps)
    holds = bounded_holds(holds, frozen)  # a hold that holds a freeze: its repeats, not the sample it froze at
    mirrored = mirrored_rotations(motion)
    def two_breaks(held=None, found=None):  # the swaps of two breaks, ``held`` break frames paired with no other
        got = swaps_from_residuals(resid, sk.joint_names, motion.fps, p.swap_jump_deg, p.swap_max_s, analysed,
                                   rotations=q, mirrored=mirrored, held=held)
        got = got if found is None else got | found
        # a swap whose steps its joints' own fast motion hides, proved by the exchange back joining the take
        return got | joined_swaps(q, mirrored, resid, mirror_pairs(sk.joint_names), sk.parents, motion.fps,
                                  p.swap_jump_deg, p.swap_max_s, analysed, got, held=held)

    swaps = two_breaks()
    # a swap from the take's first frame or to its last breaks once: found where its reading tells, else named
    edge_cells, held = np.zeros((F, J), dtype=bool), np.zeros((F, J), dtype=bool)
    for e in edge_swaps(q, mirrored, resid, digression, sk.joint_names, sk.parents, motion.fps,
                        p.swap_jump_deg, p.swap_max_s, swaps, analysed):
        for at in e.breaks:  # its breaks: the steps at -> at + 1, paired with no other
            held[at : at + 2, [e.joint, e.partner]] = True
        edge_cells[e.start : e.end + 1, [e.joint, e.partner]] = e.found
        if not e.found:
            notes.append(possible_swap_note(e, sk.joint_names))
    if held.any():
        swaps = two_breaks(held, edge_cells)
    offsets = offsets_from_residuals(
        np.asarray(motion.rotations, dtype=np.float64), resid, motion.fps, p.offset_jump_deg, p.offset_max_s,
        p.offset_min_deg, analysed, sk.joint_names, sk.parents, digression,
    )
    offsets = unshared_offsets(offsets, digression, p.offset_min_deg)  # an offset the similar motion holds is motion
    # smooth-drift evidence only against a context beyond the take that the caller chose (not the bundled default
    # context, a general sample that repeats no take's motion), and never on the pelvis or the root, whose rotation
    # carries the path's heading (module docstring of :mod:`~mocapkit.cleaning.ssa.drifts`)
    info = getattr(an.context_given, "info", None)
    chosen = has_context and not (isinstance(info, dict) and info.get("default"))
    if p.drift and not chosen:
        notes.append(not_looked_for(has_context, isinstance(info, dict) and bool(info.get("default"))))
    agreement = np.full((F, J), np.nan)
    if chosen:  # the other joints' angles from the mean texture of the neighbour words that judge the joint
        agreement[:, tex_joints] = np.where(ok, group_agreement(dig_g, best), np.nan)
    agreement[:, [0, pelvis_index(sk)]] = np.nan
    drifts = (_drifts(jumps, agreement, consistency, motion.fps, p, sk.joint_names, change, sk.parents, turn)
              if p.drift else None)
    spikes = spike_breaks(q, resid, jumps)
    # a spike far past the joint's own motion is an error where no similar motion judges it
    lone = lone_spikes(q, resid, np.isfinite(digression), analysed, sk.parents, p.jump_deg, memo=chain_memo)
    # a swap run that joins the take better played backwards is named a time-reversed stretch (same cells flagged)
    backwards = reversed_runs(q, swaps, analysed)
    causes = flag_causes(mdm, jumps, holds, swaps, offsets, threshold, motion.fps, p.confirm, p.confirm_margin_s,
                         drifts, spikes, np.isfinite(digression), lone, backwards, frozen)
    flags = causes != 0  # flag_rule's flags
    if kept:  # the repair of these flags reads their words (Analysis.warped); the others are let go
        word_of = frame_words(words, N, F, fps, motion.fps)
        an.warped.update(flagged_words(kept, grows, flags & analysed[None, :], best_group, word_of, words))
    del kept
    masks = an.group_masks()
    if not ok.all():
        some, every = int((~ok).any(axis=1).sum()), int((~ok).all(axis=1).sum())
        notes.append(f"{plural(some, 'frame')} {'has' if some == 1 else 'have'} joints that no neighbour word judges "
                     f"({every} of {'it' if some == 1 else 'them'} no joint at all): "
                     "not judged there; a context that repeats the motion judges more")
    clips = an.clips
    params = p.replace(two_stage=bool(two_stage and has_context), prefilter=bool(prefilter and has_context))
    det = Detection(
        mdm=mdm, flags=flags, digression=digression, best_group=best_group, threshold=float(threshold),
        fps=motion.fps, joint_names=tuple(sk.joint_names), analysed=analysed, texture_joints=tex_joints,
        group_names=tuple(gnames), group_masks=masks, word_starts=words, neighbor_pos=neighbors.pos,
        neighbor_iend=neighbors.iend, neighbor_jend=neighbors.jend, neighbor_dist=neighbors.dist,
        context_clips=clips, jumps=jumps, holds=holds, swaps=swaps, offsets=offsets,
        agreement=agreement, consistency=consistency, params=params, notes=tuple(notes),
        analysis=an, spikes=spikes, change=change, turn=turn, left_out=tuple(an.left_out), lone_spikes=lone,
        parents=np.asarray(sk.parents, dtype=np.int64), reversals=backwards, frozen=frozen,
    )
    # Detection.causes() made again gives these (its threshold float(threshold), its drifts() these or none where
    # p.drift is off, its params' confirmation p's) unless the threshold compares otherwise as a float
    return det._with_causes(causes) if isinstance(threshold, float) else det
