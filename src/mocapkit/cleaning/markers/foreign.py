"""Find foreign stretches: a marker's label on some other point from the edge of what is seen up to a jump.

A labeller that starts a take, or picks a marker up again after an
occlusion, may give its label to another point (a ghost, a reflection, a
marker of no label) until the right point is found; then the trajectory
jumps, in one frame, to where the marker really is. c3d.org's Eb015pr.c3d
(50 Hz, mm) starts so: LFT3 lies 20-22 mm from LFT1 and 39-42 mm from LFT2
in frames 0-42, jumps 71 mm between frames 42 and 43, and from there to the
take's end keeps the foot's geometry (67-71 and 75-80 mm). Which side of
the jump is wrong is told by the marker's rigid partners, the markers whose
distance to it the take shows nearly constant (a spread of at most
``partner_mm``; :func:`~mocapkit.cleaning.markers.rigid.distance_stats`):
their distance to it is the body's, the same in every frame up to skin
motion. A stretch is foreign when

* it runs from the first (or last) frame of a seen run of the marker (the
  take's start or end, or an occlusion's edge) up to a jump;
* in every frame of it every seen partner's distance lies more than
  max(``off_mm``, 3 spreads) from its usual (median) value, and at least one
  partner is seen: the point is not where the marker sits on the body;
* at the jump, the marker moves more than ``off_mm`` in one frame relative
  to each partner (a marker on skin cannot; a label moving to another point
  does), into frames where every seen partner is at its usual distance;
* the rest of the seen run agrees with the partners (in at least 90 % of its
  frames with a partner seen) and is at least as long as the stretch, and
  the stretch is longer than a spike (``min_frames``) and under half the
  marker's seen frames: the usual distances are the marker's own.

That is the evidence by which :mod:`~mocapkit.cleaning.markers.duplicates`
removes a duplicate label (the copy far from where its rigid neighbours
put it, the other near) with a jump to separate the two; short runs of a
few frames at an edge are glitches, judged by
:mod:`~mocapkit.cleaning.markers.edges`. Positions are (F, M, 3), frames
first, NaN for unseen samples, in the capture's unit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .rigid import DistanceStats, distance_stats

__all__ = ["Foreign", "find_foreign"]


@dataclass(frozen=True)
class Foreign:
    """Marker ``marker``'s samples in frames ``start <= f < end`` are another point's.

    ``off``: the smallest, over the stretch's frames, of the largest miss of a
    seen partner's usual distance (capture unit); ``jump``: the marker's
    smallest move relative to a partner at the jump (capture unit); ``why``:
    the evidence in words.
    """

    marker: int
    start: int
    end: int
    off: float
    jump: float
    why: str


def _judge(x: np.ndarray, m: int, partners: np.ndarray, median: np.ndarray, tol: np.ndarray):
    """(F,) off, (F,) on and (F, P) miss of marker ``m`` against its ``partners`` (see :func:`find_foreign`)."""
    dist = np.linalg.norm(x[:, [m]] - x[:, partners], axis=-1)  # (F, P), NaN where either is unseen
    miss = np.abs(dist - median[None, :])
    seen = ~np.isnan(miss)
    judged = seen.any(axis=1)
    off = judged & np.all(~seen | (miss > tol[None, :]), axis=1)
    on = judged & np.all(~seen | (miss <= tol[None, :]), axis=1)
    return off, on, miss


def find_foreign(positions: np.ndarray, unit_mm: float = 1.0, *, off_mm: float = 15.0, partner_mm: float = 3.0,
                 min_frames: int = 5, stats: DistanceStats | None = None) -> list[Foreign]:
    """The foreign stretches of every marker (see the module's docstring), in frame order.

    ``positions`` (F, M, 3), NaN where unseen; ``unit_mm`` millimetres per
    unit; ``off_mm`` how far (mm) a partner's distance must lie from its
    usual value, and how far the marker must jump relative to each partner;
    ``partner_mm`` the largest spread (mm) of a rigid partner's distance;
    ``min_frames`` the longest stretch left to the spike tests (a stretch
    must be longer); ``stats`` the take's usual inter-marker distances
    (computed from ``positions`` when not given).
    """
    x = np.asarray(positions, dtype=np.float64)
    f, m = x.shape[:2]
    if stats is None:
        stats = distance_stats(x)
    spread = np.where(stats.count >= 10, stats.spread, np.inf)
    off_u = off_mm / unit_mm
    found = []
    seen_all = ~np.any(np.isnan(x), axis=-1)
    for mk in range(m):
        partners = np.flatnonzero((spread[mk] * unit_mm <= partner_mm) & (np.arange(m) != mk))
        total = int(seen_all[:, mk].sum())
        if partners.size == 0 or total == 0:
            continue
        tol = np.maximum(off_u, 3.0 * spread[mk, partners])
        off, on, miss = _judge(x, mk, partners, stats.median[mk, partners], tol)
        d = np.diff(np.concatenate([[0], seen_all[:, mk].astype(np.int8), [0]]))
        for s, e in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            for step in (1, -1):
                frames = np.arange(s, e) if step == 1 else np.arange(e - 1, s - 1, -1)
                bad = off[frames]
                n = int(np.argmin(bad)) if not bad.all() else frames.size  # the stretch's length from the edge
                if n <= min_frames or n >= frames.size or 2 * n >= total:
                    continue
                t0, t1 = frames[n - 1], frames[n]  # the stretch's last frame, the first one after the jump
                rest = frames[n:]
                judged = np.any(~np.isnan(miss[rest]), axis=1)  # frames with a partner seen
                if not on[t1] or rest.size < n or on[rest][judged].mean() < 0.9:
                    continue
                both = partners[~np.isnan(miss[t0]) & ~np.isnan(miss[t1])]
                if both.size == 0:
                    continue
                rel = (x[t1, mk] - x[t0, mk])[None, :] - (x[t1, both] - x[t0, both])  # (B, 3)
                jump = float(np.min(np.linalg.norm(rel, axis=-1)))
                if jump <= off_u:
                    continue
                lo, hi = (s, s + n) if step == 1 else (e - n, e)
                worst = float(np.min(np.nanmax(np.where(np.isnan(miss[lo:hi]), -np.inf, miss[lo:hi]), axis=1)))
                where = "the take's start" if lo == 0 else ("the take's end" if hi == f else
                                                           ("an occlusion's end" if step == 1 else "an occlusion"))
                why = (f"from {where}: at least {worst * unit_mm:.0f} mm off its usual distance to a rigid partner "
                       f"in every frame, then a {jump * unit_mm:.0f} mm jump into its usual place")
                found.append(Foreign(mk, int(lo), int(hi), worst, jump, why))
    return sorted(found, key=lambda g: (g.start, g.marker))
