"""Markers in another length unit than the database's: caught by the size of the marker cloud.

Marker-driven reconstruction (:func:`mocapkit.reconstruct.markers.reconstruct`,
:func:`mocapkit.reconstruct.ssg.reconstruct`) takes marker positions in the
database skeleton's unit. Markers in metres fed to a centimetre database are
a body a hundredth the size: the search still finds neighbours, the fit
still converges, and the result is metres off (311 cm RMS on a Bandai Namco
walk) with no word. :func:`check_marker_scale` compares the distances
between the markers with those between the same joints in the database's
own frames and refuses a cloud whose size differs by about a unit factor.

Another performer's build is not a unit: a child's or a tall actor's
distances differ from the database's by tens of per cent, a unit by a factor
of 2.54 (inches) or more. The test is the median, over the marker pairs, of
the ratio of each pair's median distance over the frames; it passes from 0.5
to 2.1. What a take does moves it too: on 20 HDM05 takes of all five actors
(database: four of them) and 13 Bandai Namco takes of dataset-1 (database:
its other styles) it ranged over 0.82-1.16 with six markers (hands, feet,
head, pelvis) and 0.68-1.75 with the hands and feet alone (a wave overhead),
so a unit factor of 2.54 hidden by such a pose can pass unseen; 10 and more
cannot.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..database import MotionDatabase
from ..features import virtual_markers
from ..motion import unit_scale_cm

__all__ = ["marker_scale", "check_marker_scale", "UNITS_CM", "SIZE_RANGE"]

UNITS_CM = {"millimetres": 0.1, "centimetres": 1.0, "inches": 2.54, "HDM05/Acclaim units (5.644 cm)": 2.54 / 0.45,
            "decimetres": 10.0, "metres": 100.0}
"""Length units a marker file or a database may be in, in centimetres."""

SIZE_RANGE = (0.5, 2.1)
"""The marker cloud's size over the database's (:func:`marker_scale`) accepted as one unit: a performer's build."""


def _pair_medians(points: np.ndarray) -> np.ndarray:
    """Median over frames of the distance of every marker pair of ``points`` (F, M, 3): (M (M - 1) / 2,), NaN where never both seen."""
    a, b = np.triu_indices(points.shape[1], k=1)
    d = np.linalg.norm(points[:, a] - points[:, b], axis=-1)
    out = np.full(a.size, np.nan)
    seen = np.isfinite(d).any(axis=0)
    out[seen] = np.nanmedian(d[:, seen], axis=0)
    return out


def marker_scale(markers: np.ndarray, joints: Sequence[str], db: MotionDatabase, clips: int = 16) -> float:
    """How many times larger the marker cloud is than the database's at the same joints (1 for the database's unit and build).

    ``markers`` (F, M, 3) in whatever unit they came in, NaN where unseen;
    ``joints`` (M,) the database joints or end sites they sit on. The
    database's side is its frames in up to ``clips`` clips spread over it
    (:func:`~mocapkit.features.virtual_markers`). Pairs closer than 5 cm in
    the database (two markers on one joint) are left out. NaN when no pair is
    seen in both.
    """
    picks = np.unique(np.linspace(0, db.num_clips - 1, min(clips, db.num_clips)).round().astype(int))
    ref = np.concatenate([virtual_markers(db.clip(int(c)), list(joints)) for c in picks], axis=0)
    mine, theirs = _pair_medians(np.asarray(markers, dtype=np.float64)), _pair_medians(ref)
    far = theirs * unit_scale_cm(db.skeletons[0]) >= 5.0
    ok = np.isfinite(mine) & np.isfinite(theirs) & far & (mine > 0)
    if not ok.any():
        return float("nan")
    return float(np.exp(np.median(np.log(mine[ok] / theirs[ok]))))


def _unit_name(cm: float) -> str:
    """The unit of :data:`UNITS_CM` within 20 % of ``cm`` centimetres, else ``cm`` itself in words."""
    name, size = min(UNITS_CM.items(), key=lambda kv: abs(np.log(kv[1] / cm)))
    return name if abs(np.log(size / cm)) < np.log(1.2) else f"units of about {cm:.3g} cm"


def check_marker_scale(markers: np.ndarray, joints: Sequence[str], db: MotionDatabase) -> None:
    """Refuse markers whose cloud is not the database's size (:func:`marker_scale` outside :data:`SIZE_RANGE`): a ValueError line naming both units.

    Nothing is said where the size cannot be told (no marker pair seen).
    """
    s = marker_scale(markers, joints, db)
    if not np.isfinite(s) or SIZE_RANGE[0] <= s <= SIZE_RANGE[1]:
        return
    db_cm = unit_scale_cm(db.skeletons[0])
    raise ValueError(
        f"markers: their distances are {s:.3g} times the database's at the same joints, so they look like "
        f"{_unit_name(db_cm / s)} while the database is in {_unit_name(db_cm)}; give the markers in "
        f"{_unit_name(db_cm)} (mocapkit.reconstruct.control.control_markers converts a marker file's unit)"
    )
