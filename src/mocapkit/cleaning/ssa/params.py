"""The parameters of the self-similarity analysis, in one frozen dataclass (Aristidou et al. 2018, section 5).

:class:`SSAParams` is the one source of the analysis defaults: :func:`~mocapkit.cleaning.ssa.detect`,
:func:`~mocapkit.cleaning.ssa.repair`, the cues' functions and :func:`mocapkit.cleaning.pipeline.clean`
take theirs from it. A :class:`~mocapkit.cleaning.ssa.Detection` records the parameters it was made with
(with ``prefilter`` and ``two_stage`` resolved to what ran), and its file stores them as a JSON object.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

__all__ = ["SSAParams"]

_NORMALIZATIONS = ("median", "spread", "mean")


@dataclass(frozen=True)
class SSAParams:
    """Parameters of the self-similarity analysis; the defaults are the paper's (section 5) and this library's.

    Words and neighbours (section 3):

    analysis_fps : float
        Frame rate the motion texture is resampled to (24 fps); word lengths count frames at this rate.
    source_length, stride, target_length : int
        Source words of ``source_length`` (N = 15) frames every ``stride`` (5) frames, target words of
        ``target_length`` (M = 20) frames at every frame.
    max_run : int
        The DTW's slope constraint: at most this many consecutive non-diagonal steps (3).
    k : int
        Neighbour words per source word (K = 5).
    joints : int or tuple
        The ``joints`` most informative joints (24), or exactly these (names or indices).
    two_stage, screen_threshold : bool, float
        Section 5's two stages: local analysis of the whole body first, then the context with all groups
        only around words whose local MDM exceeds ``screen_threshold``.
    prefilter, candidates : bool, int
        Rank only ``candidates`` kd-tree candidates per word by DTW: approximate (a word's best neighbour can be
        missed), so off unless asked for; the default search is exact at any context size (None is off).
    max_word_angle_deg : float or None
        Leave unjudged the words whose nearest neighbour differs by more than this RMS joint angle (None:
        judge every word, as the paper does).

    The movement digression map (section 3.4):

    normalization, row_scale, floor_deg, z_scale : str, float, degrees, float
        Row normalisation (:func:`~mocapkit.cleaning.ssa.movement_digression_map`).
    noise_deg : degrees
        Capture noise floor added to the neighbours' spread (``normalization="spread"``).
    shift_s : seconds
        Timing tolerance: a joint's digression at a frame is its smallest angle from the mean texture
        within this time.

    Confirmation and the cues (:mod:`mocapkit.cleaning.ssa.cues`):

    confirm, jump_deg, confirm_margin_s : bool, degrees, seconds
        Flag a digression only where the joint's own trajectory breaks by more than ``jump_deg`` within
        ``confirm_margin_s`` of it; ``confirm=False`` gives the paper's ``MDM > threshold``.
    hold_travel_deg : degrees
        A held joint is flagged where its mean motion texture travels this far.
    swap_jump_deg, swap_max_s : degrees, seconds
        Left/right swaps: both joints of a pair break by this much, twice within this time.
    offset_jump_deg, offset_max_s, offset_min_deg : degrees, seconds, degrees
        Transient offsets: a joint steps off its path by at least ``offset_min_deg`` and back within
        ``offset_max_s``, at breaks over ``offset_jump_deg``.
    drift, drift_repeat_deg, drift_z, drift_min_s, drift_extent : bool, degrees, ratio, seconds, ratio
        Smooth drifts (:mod:`mocapkit.cleaning.ssa.drifts`): a digression with no break is flagged where,
        for at least ``drift_min_s``, the other joints of the group that judges the joint sit within
        ``drift_repeat_deg`` (median) of that group's neighbours' mean (the context repeats the motion,
        :func:`~mocapkit.cleaning.ssa.drifts.group_agreement`) and the joint's angle is ``drift_z`` times the
        neighbours' spread and noise; the flagged run extends while that ratio exceeds ``drift_extent``;
    drift_others, drift_return_ratio : int or None, ratio
        At most ``drift_others`` other joints may digress by ``drift_z`` at the same frames (one joint
        drifts, two may at once; a style the context lacks moves several); a run is judged excursion by
        excursion, cut where the joint comes back to ``drift_return_ratio`` of a peak's ratio before leaving
        again, and an excursion cut by the take's first or last frame must come back that far between the
        edge and its peak (the joint seen leaving its path, not a pose held from before the take);
    drift_partner_ratio : ratio or None
        A cell is no evidence of a drift where the joint's left/right partner digresses by this share of
        ``drift_z`` at the same frame (a style is often two-sided, a drift one joint's); None: not asked.
    drift_chain_ratio : ratio or None
        Nor where the joint's parent or one of its children does (a style bends a chain, a drift turns one
        joint and leaves its children's local rotations on their path,
        :func:`~mocapkit.cleaning.ssa.drifts.chain_level`); None: not asked.
    drift_cross_cos : ratio or None
        Where the partner or the chain gate alone stops a joint's excursion and the neighbour that stops it is
        stopped or flagged there too, the two are two drifts when their changes turn about crossed axes: the
        cosine of the two turns summed over the excursion under this (a two-sided style turns both sides alike,
        a bent chain parent and child about one axis; :func:`~mocapkit.cleaning.ssa.drifts.crossed_turns`).
        Read with ``drift_change`` only; None: not asked.
    drift_change : bool
        A cell is evidence of a drift only as far as the joint's offset from its neighbours' mean differs
        from the offset it holds over the take (the median; both in the group that judges the cell,
        :func:`~mocapkit.cleaning.ssa.drifts.group_offset_change`): that ratio, not the joint's angle ratio, is
        the one compared with ``drift_z`` and ``drift_extent``. A style holds an offset for the whole
        take; a drift leaves and comes back (:func:`~mocapkit.cleaning.ssa.drifts.offset_change`); False:
        the angle ratio.
        The drift rule is off by default (``drift=True``, ``mocapkit detect --drifts`` / ``clean --drifts``):
        only a context that repeats the take's motion makes the evidence mean a drift.
    """

    analysis_fps: float = 24.0
    source_length: int = 15
    stride: int = 5
    target_length: int = 20
    max_run: int = 3
    k: int = 5
    joints: Any = 24
    two_stage: bool = False
    screen_threshold: float = 0.3
    prefilter: bool | None = False
    candidates: int = 48
    max_word_angle_deg: float | None = None
    normalization: str = "median"
    row_scale: float = 3.0
    floor_deg: float = 20.0
    z_scale: float = 2.5
    noise_deg: float = 5.0
    shift_s: float = 0.02
    confirm: bool = True
    jump_deg: float = 8.0
    confirm_margin_s: float = 0.05
    hold_travel_deg: float = 10.0
    swap_jump_deg: float = 6.0
    swap_max_s: float = 1.0
    offset_jump_deg: float = 7.0
    offset_max_s: float = 1.0
    offset_min_deg: float = 10.0
    drift: bool = False
    drift_repeat_deg: float = 5.0
    drift_z: float = 3.0
    drift_min_s: float = 0.15
    drift_extent: float = 0.75
    drift_others: int | None = 1
    drift_return_ratio: float = 0.3
    drift_partner_ratio: float | None = 0.5
    drift_chain_ratio: float | None = 0.5
    drift_cross_cos: float | None = 0.2
    drift_change: bool = True

    def __post_init__(self):
        N, M = self.source_length, self.target_length
        if not 2 <= N <= M:
            raise ValueError(f"need 2 <= source_length <= target_length, got {N} and {M}")
        if not (np.isfinite(self.analysis_fps) and self.analysis_fps > 0):
            raise ValueError(f"analysis_fps must be a positive frame rate, got {self.analysis_fps!r}")
        if not (self.stride >= 1 and self.k >= 1 and self.max_run >= 1):
            raise ValueError(f"need stride, k and max_run >= 1, got {self.stride}, {self.k} and {self.max_run}")
        if self.normalization not in _NORMALIZATIONS:
            raise ValueError(f"normalization must be 'spread', 'median' or 'mean', got {self.normalization!r}")
        if not (np.isfinite(self.jump_deg) and self.jump_deg > 0):
            raise ValueError(f"jump_deg must be a positive number of degrees, got {self.jump_deg!r}")
        if not (np.isfinite(self.confirm_margin_s) and self.confirm_margin_s >= 0):
            raise ValueError(f"confirm_margin_s must be >= 0 seconds, got {self.confirm_margin_s!r}")
        if not (np.isfinite(self.hold_travel_deg) and self.hold_travel_deg > 0):
            raise ValueError(f"hold_travel_deg must be a positive number of degrees, got {self.hold_travel_deg!r}")
        if self.drift_others is not None and not (int(self.drift_others) == self.drift_others >= 0):
            raise ValueError(f"drift_others must be None or a whole number >= 0, got {self.drift_others!r}")
        if not 0 < self.drift_return_ratio <= 1:
            raise ValueError(f"drift_return_ratio must be in (0, 1], got {self.drift_return_ratio!r}")
        if self.drift_partner_ratio is not None and not 0 < self.drift_partner_ratio <= 1:
            raise ValueError(f"drift_partner_ratio must be None or in (0, 1], got {self.drift_partner_ratio!r}")
        if self.drift_chain_ratio is not None and not 0 < self.drift_chain_ratio <= 1:
            raise ValueError(f"drift_chain_ratio must be None or in (0, 1], got {self.drift_chain_ratio!r}")
        if self.drift_cross_cos is not None and not 0 < self.drift_cross_cos <= 1:
            raise ValueError(f"drift_cross_cos must be None or in (0, 1], got {self.drift_cross_cos!r}")
        if not isinstance(self.joints, (int, np.integer)):
            object.__setattr__(self, "joints", tuple(j if isinstance(j, str) else int(j) for j in self.joints))

    @property
    def min_width(self) -> int:
        """The DTW's width constraint: a warped window longer than 10 frames (11), at most the source word."""
        return min(11, int(self.source_length))

    def replace(self, **changes) -> "SSAParams":
        """A copy with ``changes``; an unknown name raises TypeError listing the known ones."""
        known = {f.name for f in dataclasses.fields(self)}
        bad = sorted(set(changes) - known)
        if bad:
            raise TypeError(f"unknown self-similarity parameter(s) {', '.join(bad)}; known: {', '.join(sorted(known))}")
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        """The parameters as a JSON-ready dict (``joints`` a list when it names joints)."""
        out = dataclasses.asdict(self)
        if isinstance(out["joints"], tuple):
            out["joints"] = list(out["joints"])
        return out

    @classmethod
    def from_dict(cls, values: Mapping) -> "SSAParams":
        """Parameters from :meth:`as_dict`'s output; files written before the rename give ``fps`` for
        ``analysis_fps``, and keys this version does not know are ignored."""
        values = dict(values)
        if "fps" in values and "analysis_fps" not in values:
            values["analysis_fps"] = values.pop("fps")
        known = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in values.items() if k in known})
