"""Framing of the report's stick-figure viewer: which way is up, where the floor is, where the camera looks.

Takes come Y up or Z up, in centimetres, metres, inches or CMU units, and a
game rig's rest pose may lie on its side (the Bandai Namco rig's spine points
along x at rest; its motion stands it up). The report's page only draws: this
module decides, in Python where it can be tested without a browser,

- the **up axis** of the data (:func:`find_up_axis`, kept here from :mod:`mocapkit.features`, where the rule lives): the signed coordinate axis
  along which head - feet points in most frames, by joint roles
  (:func:`mocapkit.motion.find_joint`), unless a straight standing rest pose says
  otherwise and the take stands along it often enough (lying down votes like
  standing up); the rest pose when no frame has both; the axis of largest extent
  when the rig has no head or feet;
- the rotation turning it into the page's +y (:func:`rotation_to_y`);
- the **framing** (:func:`fit_view`): the floor, a fixed camera target (the
  take's bounding-box centre) or a target that follows the body across the floor
  (and cuts where it jumps: takes joined end to end), and for each the camera
  distance at which a sphere holding every drawn point of every frame fits in the
  panel with a margin, whatever the orbit angle (following: every frame but the
  outliers, see :attr:`Framing.radius_follow`, so that a root jumping metres away
  for a frame does not shrink a long take's figure to a speck).

The bound behind the distance: the viewer's pinhole camera looks at the target
with a half field of view ``HALF_FOV`` across the panel's smaller side; a sphere
of radius ``r`` centred on the target, seen from distance ``d``, appears as a
disc of half-angle ``asin(r / d)``. With ``d = r / sin(atan((1 - margin) *
tan(HALF_FOV))`` that disc, and so every point inside the sphere, lies within
``1 - margin`` of the panel's half-size in every frame and for every yaw and
pitch. The page (``viewer.js``) uses the same ``HALF_FOV`` and scales its focal
length by the panel's smaller side, so what is fitted here is what is drawn.
"""

from __future__ import annotations

import base64
import math
from dataclasses import dataclass

import numpy as np

from ..features import REST_POSE_MIN_SHARE, find_up_axis
from ..motion import Skeleton

__all__ = [
    "HALF_FOV",
    "MARGIN",
    "REST_POSE_MIN_SHARE",
    "FOLLOW_RATIO",
    "FOLLOW_OUTLIER",
    "Framing",
    "find_up_axis",
    "rotation_to_y",
    "fit_view",
    "camera_distance",
    "body_points",
]

#: half field of view (radians) of the viewer's camera across the panel's smaller side.
HALF_FOV = math.pi / 8
#: share of the panel's half-size kept free around the figure.
MARGIN = 0.08
#: a take whose fixed framing would draw the figure this many times smaller than following it is followed.
FOLLOW_RATIO = 1.5
#: following, frames whose farthest point lies over this many times the median frame's from the target are not sized for.
FOLLOW_OUTLIER = 2.0
#: following, a step of the body's centroid over half its height plus this speed (cm/s) is a cut, not motion.
JUMP_SPEED = 1000.0




def rotation_to_y(up: np.ndarray) -> np.ndarray:
    """Proper rotation matrix (3, 3) taking the signed coordinate axis ``up`` to +y.

    Identity for +y, 180 deg about x for -y, otherwise 90 deg about ``up x y``
    (so +z up becomes +y and +y becomes -z: a right-handed turn, no mirror).
    """
    u = np.asarray(up, dtype=np.float64)
    y = np.array([0.0, 1.0, 0.0])
    if np.allclose(u, y):
        return np.eye(3)
    if np.allclose(u, -y):
        return np.diag([1.0, -1.0, -1.0])
    axis = np.cross(u, y)
    axis /= np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + K + K @ K  # Rodrigues at 90 deg: sin = 1, 1 - cos = 1


def body_points(skeleton: Skeleton, positions: np.ndarray) -> np.ndarray:
    """(P,) bool over joints then end sites: the points that hang together through rigid bones.

    A bone whose length in the take strays by more than a fifth from its length
    in the rig (the rest pose) is no body segment but a free link, which only
    animated translations (BVH position channels) make: game rigs put a reference
    joint on the floor (the Bandai Namco rig's ``joint_Root`` stays at the world
    origin in some takes while ``Hips``, moved by its own position channels,
    dances two metres away). Cutting the free links leaves components; the body
    is the one with most points. The viewer neither draws nor frames the rest.

    Parameters
    ----------
    skeleton : Skeleton
        The rig: parents and rest-pose bone lengths.
    positions : float array (N, P, 3)
        Global positions of joints and end sites (``end_sites=True``) in the
        rig's units; NaN where missing.
    """
    pos = np.asarray(positions, dtype=np.float64)
    rest = skeleton.rest_positions(end_sites=True)
    parents = [int(q) for q in skeleton.parents] + [int(q) for q in skeleton.end_site_parents]
    P = len(parents)
    if pos.ndim != 3 or pos.shape[1:] != (P, 3):
        raise ValueError(f"positions: expected (N, {P}, 3) joints then end sites, got {pos.shape}")
    size = float(np.ptp(rest, axis=0).max()) if P > 1 else 1.0
    comp = list(range(P))

    def find(a):
        while comp[a] != a:
            comp[a] = comp[comp[a]]
            a = comp[a]
        return a

    for p, q in enumerate(parents):
        if q < 0:
            continue
        rest_len = float(np.linalg.norm(rest[p] - rest[q]))
        length = np.linalg.norm(pos[:, p] - pos[:, q], axis=-1)
        length = length[np.isfinite(length)]
        if not length.size or np.abs(length - rest_len).max() <= 0.2 * rest_len + 1e-6 * size:
            comp[find(p)] = find(q)
    roots = np.array([find(p) for p in range(P)])
    return roots == int(np.argmax(np.bincount(roots, minlength=P)))


def camera_distance(radius: float, half_fov: float = HALF_FOV, margin: float = MARGIN) -> float:
    """Distance from which a sphere of ``radius``, looked at, fills ``1 - margin`` of the panel's half-size."""
    return float(radius) / math.sin(math.atan((1.0 - margin) * math.tan(half_fov)))


@dataclass(frozen=True)
class Framing:
    """How the viewer frames a take; lengths in the page's units (cm), +y up.

    Attributes
    ----------
    floor : float
        Height of the floor grid: the median over frames of the lowest drawn point.
    centre : (3,) float
        The fixed camera target: centre of the bounding box of every drawn point.
    radius_fixed : float
        Radius of the sphere about ``centre`` holding every drawn point of every frame.
    track : (N, 2) float
        The following camera target's (x, z) in each shown frame: the body's
        centroid over the floor, averaged over about a second so the view does not
        shake, and cut where the body jumps (takes joined end to end).
    track_height : float
        The following target's (constant) height: the median over frames of each frame's mid-height.
    radius_follow : float
        Radius of the sphere about the following target holding every drawn point of its frame,
        in every frame but those whose farthest point is over :data:`FOLLOW_OUTLIER` times the
        median frame's (a root that jumps metres away for a frame or two in the input).
    follow : bool
        Whether the view starts following (the fixed framing would draw the
        figure over ``FOLLOW_RATIO`` times smaller).
    grid_step : float
        Spacing of the floor grid: a round number near a quarter of the figure's height.
    hidden : (P,) bool
        Points off the body (:func:`body_points`): neither drawn nor framed.
    """

    floor: float
    centre: np.ndarray
    radius_fixed: float
    track: np.ndarray
    track_height: float
    radius_follow: float
    follow: bool
    grid_step: float
    hidden: np.ndarray

    def distance(self, follow: bool) -> float:
        """Camera distance that keeps every drawn point in the panel (see the module docstring)."""
        return camera_distance(self.radius_follow if follow else self.radius_fixed)

    def to_page(self) -> dict:
        """The JSON the page's viewer reads (the track as base64 little-endian float32 (N, 2))."""
        return {
            "halfFov": HALF_FOV,
            "floor": self.floor,
            "centre": [float(v) for v in self.centre],
            "trackHeight": self.track_height,
            "track": base64.b64encode(np.ascontiguousarray(self.track, dtype="<f4").tobytes()).decode("ascii"),
            "follow": self.follow,
            "distance": {"fixed": self.distance(False), "follow": self.distance(True)},
            "radius": {"fixed": self.radius_fixed, "follow": self.radius_follow},
            "hidden": [int(p) for p in np.flatnonzero(self.hidden)],
            "gridStep": self.grid_step,
            "gridSpan": {"fixed": self.grid_span(False), "follow": self.grid_span(True)},
        }

    def grid_span(self, follow: bool) -> float:
        """Half-width of the floor grid drawn about the target: the framed sphere and a bit, in whole steps."""
        r = self.radius_follow if follow else self.radius_fixed
        return self.grid_step * max(2, math.ceil(1.3 * r / self.grid_step))


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a)
    a.setflags(write=False)
    return a


def _round_step(x: float) -> float:
    """A 1, 2 or 5 times a power of ten close to ``x`` (> 0)."""
    e = 10.0 ** math.floor(math.log10(x))
    return min((m * e for m in (1.0, 2.0, 5.0, 10.0)), key=lambda s: abs(math.log(s / x)))


def _moving_average(a: np.ndarray, width: int) -> np.ndarray:
    """Centred moving average of (N, C) over ``width`` rows; the ends repeat the first/last row."""
    if width <= 1 or len(a) < 2:
        return a
    h = width // 2
    padded = np.concatenate([np.repeat(a[:1], h, axis=0), a, np.repeat(a[-1:], h, axis=0)])
    c = np.cumsum(np.concatenate([np.zeros((1, a.shape[1])), padded]), axis=0)
    return (c[2 * h + 1:] - c[:-2 * h - 1]) / (2 * h + 1)


def _follow_track(rows: np.ndarray, xz: np.ndarray, have: np.ndarray, fps: float, size: float) -> np.ndarray:
    """(N, 2) follow target over the floor at each row: the centroids ``xz`` smoothed over about a second.

    The centroids are interpolated to every take frame between the rows, and smoothed
    within pieces: a step between two rows longer than half the figure's ``size`` plus
    :data:`JUMP_SPEED` times the time between them is a cut (takes joined end to end, a
    root that jumps), where the camera cuts too instead of gliding across the room.
    """
    N = len(rows)
    idx = np.flatnonzero(have)
    if not idx.size:
        return np.zeros((N, 2))
    r, v = rows[idx], xz[idx]
    limit = 0.5 * size + JUMP_SPEED * np.diff(r) / max(fps, 1e-9)
    piece = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(v, axis=0), axis=1) > limit)])
    every = np.arange(int(rows[0]), int(rows[-1]) + 1)  # each take frame the rows span
    of = piece[np.clip(np.searchsorted(r, every, side="right") - 1, 0, len(r) - 1)]  # the piece of the row before
    full = np.empty((len(every), 2))
    width = int(round(max(fps, 1.0))) | 1
    bounds = np.flatnonzero(np.diff(of)) + 1
    for a, b in zip(np.concatenate([[0], bounds]), np.concatenate([bounds, [len(every)]])):
        mine = piece == of[a]
        full[a:b] = _moving_average(np.stack([np.interp(every[a:b], r[mine], v[mine, k]) for k in range(2)], axis=1),
                                    width)
    return full[rows - rows[0]]


def fit_view(positions, fps: float = 30.0, body=None, frames=None) -> Framing:
    """Frame the drawn points of a take so that the figure is whole in every frame.

    Parameters
    ----------
    positions : sequence of float arrays (N, P, 3)
        Every motion the viewer draws with one camera (the input and the cleaned
        take), page units (cm), +y up; NaN (missing) points are ignored.
    fps : float
        Frame rate of the take; sets the track's smoothing (about 1 s).
    body : bool array (P,), optional
        The points on the body (:func:`body_points`); the others are left out of
        the framing and marked hidden. Default: all.
    frames : int array (N,), optional
        The take frame of each row, sorted (the shown frames of a long take,
        :func:`mocapkit.report.html.shown_frames`: not evenly spaced); default
        ``0 .. N-1``. The follow track is interpolated to every take frame,
        smoothed over about ``fps`` of them and read back at these.

    A take without one finite point gets a 170 cm figure at the origin.
    """
    arrays = [np.asarray(p, dtype=np.float64) for p in positions]
    if not arrays:
        raise ValueError("fit_view needs at least one (N, P, 3) array")
    N = arrays[0].shape[0]
    for a in arrays:
        if a.ndim != 3 or a.shape[-1] != 3 or a.shape[0] != N:
            raise ValueError(f"positions must be (N, P, 3) arrays with one N; got {[x.shape for x in arrays]}")
    P = arrays[0].shape[1]
    body = np.ones(P, dtype=bool) if body is None else np.asarray(body, dtype=bool)
    if body.shape != (P,):
        raise ValueError(f"body: expected a ({P},) bool mask, got shape {body.shape}")
    pts = np.concatenate([a[:, body] for a in arrays], axis=1)  # (N, P', 3): both motions' body points
    finite = np.all(np.isfinite(pts), axis=-1)  # (N, P')
    if not finite.any():
        return Framing(0.0, _frozen(np.array([0.0, 85.0, 0.0])), 100.0, _frozen(np.zeros((N, 2))), 85.0, 100.0,
                       False, 50.0, _frozen(~body))
    allp = pts[finite]
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    centre = (lo + hi) / 2
    radius_fixed = float(np.sqrt(((allp - centre) ** 2).sum(axis=1).max()))
    y = np.where(finite, pts[..., 1], np.inf)
    low = y.min(axis=1)
    floor = float(np.median(low[np.isfinite(low)]))
    # the follow target: the body's centroid over the floor, smoothed; frames without a point hold the nearest
    cnt = finite.sum(axis=1)
    have = cnt > 0
    xz = np.zeros((N, 2))
    xz[have] = np.stack([np.where(finite, pts[..., k], 0.0).sum(axis=1)[have] / cnt[have] for k in (0, 2)], axis=1)
    rows = np.arange(N) if frames is None else np.asarray(frames, dtype=np.int64)
    if rows.shape != (N,) or (N > 1 and np.any(np.diff(rows) <= 0)):
        raise ValueError(f"frames: expected {N} increasing take frames, got shape {rows.shape}")
    ylo = np.where(finite, pts[..., 1], np.inf).min(axis=1)[have]
    yhi = np.where(finite, pts[..., 1], -np.inf).max(axis=1)[have]
    size = float(np.median(yhi - ylo))  # the figure's usual height (its extent when lying)
    track = _follow_track(rows, xz, have, fps, size)
    track_height = float(np.median((ylo + yhi) / 2))
    target = np.concatenate([track[:, :1], np.full((N, 1), track_height), track[:, 1:]], axis=1)
    d2 = ((pts - target[:, None, :]) ** 2).sum(axis=-1)
    reach = np.sqrt(np.where(finite, d2, 0.0).max(axis=1))[have]  # each frame's farthest point from its target
    # sized for every frame but those where a point strays over FOLLOW_OUTLIER times the usual reach
    # (a root jumping metres away in the input for a frame or two): such a frame would shrink the whole take
    usual = float(np.median(reach))
    radius_follow = float(reach[reach <= FOLLOW_OUTLIER * usual].max())
    radius_fixed = max(radius_fixed, 1e-6)
    radius_follow = max(radius_follow, 1e-6)
    height = float(hi[1] - floor) if hi[1] > floor else float(hi[1] - lo[1])
    grid_step = _round_step(max(height, 1e-6) / 4)
    return Framing(
        floor=floor,
        centre=_frozen(centre),
        radius_fixed=radius_fixed,
        track=_frozen(track),
        track_height=track_height,
        radius_follow=radius_follow,
        follow=radius_fixed > FOLLOW_RATIO * radius_follow,
        grid_step=grid_step,
        hidden=_frozen(~body),
    )
