"""Gap filling the way a mocap user does it today: linear, cubic and quintic spline fills.

These are the baselines the deep gap filler (Mall et al. 2017, the EBD) is
measured against. Mall et al. compare with linear interpolation ("lerp"); the
tools a user reaches for instead are spline fills:

- **Vicon Nexus 2** documents four fills (Vicon FAQ "What gap filling
  algorithms are used in Nexus 2?"), among them *Woltring (quintic spline)*,
  *Pattern* (offset by a donor trajectory) and *Rigid Body*. The Woltring fill
  "generates a quintic spline using valid frames around the gap as seed data"
  and fills the gap "using the interpolated values from the spline". The
  manual fill looks up to ``gap/2 + 5`` frames backwards and forwards from the
  gap and needs at least 10 valid frames there, not necessarily consecutive;
  the pipeline operation wants ``gap/2 + 5`` *consecutive* valid frames on each
  side, accepts as few as 5 per side, and rejects the fill otherwise. Nothing
  in the FAQ says the fill smooths: it interpolates the seed frames. Woltring's
  GCVSPL (1986) with zero error variance is such an interpolating (natural)
  spline of order 2M, M = 3 for the quintic; with a non-zero variance GCVSPL is
  a smoothing filter, a different tool (e.g. Visual3D's GCVSPL command:
  "0 = an interpolating spline is calculated").
- The PyPI package **gapfill** (M. K. Jung, ``fill_marker_gap_interp``) copies
  the manual Nexus rule: per gap it takes the frames within
  ``ceil(gap/2) + 5`` on each side, keeps the valid ones, needs at least 10,
  and fits ``scipy.interpolate.InterpolatedUnivariateSpline`` (an
  interpolating FITPACK spline, ``s = 0``) of degree ``k = 3`` by default
  (``k = 5`` gives the quintic) per coordinate. Gaps touching the first or
  last frame, and gaps with too few neighbours, are left unfilled.

What this module implements (:func:`fill_channels`, vectorised over channels):

- ``"linear"``: straight line between the observed samples just before and
  just after each gap (Mall's lerp baseline).
- ``"cubic"`` / ``"quintic"``: an *interpolating* spline of degree 3 / 5
  (``scipy.interpolate.make_interp_spline``, not-a-knot end conditions)
  through the observed samples of a local window around each gap, evaluated
  at the missing frames. Not-a-knot ends reproduce any polynomial of degree
  <= k exactly; GCVSPL's natural ends (derivatives 3 and 4 zero for the
  quintic) change the fit mostly near the window's outer edges, away from
  the gap.
- The window (default, ``context_s=None``) is the Nexus manual / gapfill rule:
  ``ceil(n/2) + 5`` frames on each side of a gap of ``n`` frames, observed
  samples only (other gaps inside the window are skipped, as in Nexus). With
  ``context_s`` it is ``round(context_s * fps)`` frames on each side instead,
  whatever the gap length. The fit is local, so the cost does not grow with
  the clip.
- Where Nexus and gapfill *reject* a fill with too few neighbours, this module
  falls back to a lower order instead, so every interior gap is filled: the
  quintic needs at least 3 observed samples in the window on each side, the
  cubic 2, else the gap is filled linearly (which needs only the two
  neighbours). Requiring samples on both sides keeps the spline an
  interpolation, never a one-sided extrapolation.
- Runs touching the start or end of the clip have no sample on one side: they
  hold the nearest observed value (constant extrapolation, as
  ``InterpolatedUnivariateSpline(ext="const")`` would give; Nexus and gapfill
  leave them empty). A channel with no observed sample at all stays NaN.
- Observed samples are never modified (bit-identical); only NaN is missing.

An interpolating spline passes through every seed sample, so on jittery
capture data it carries the jitter next to the gap into the fill: on the raw
CMU walk (12_walk, 120 fps) cubic and linear fills of short gaps are about
even joint-angle-wise, while on smooth signals (the root trajectory, or the
walk after a 10 ms Gaussian) the cubic is clearly better. The quintic does
about as well as the cubic on gaps up to about 0.1 s and overshoots more
beyond that (see the tests).

Gaps sharing the same fit pattern (order, gap length, window shape) are fitted
in one batched ``make_interp_spline`` call with one right-hand side per gap,
so a long clip with thousands of gaps costs a Python step per gap plus one
small banded solve per distinct pattern.

:func:`fill_motion` applies this to a :class:`~mocapkit.motion.Motion` whose
missing joints are NaN quaternions, on the file's joint-angle channels
(:meth:`Motion.channel_values`, degrees), as Mall et al. and the mocap tools
treat them: each rotation channel is unwrapped in time over its observed
samples first (period 360, so a +-180 wrap is not a 360 degree swing) and the
filled values are wrapped back to (-180, 180]. The three Euler channels of a
3-DOF joint may still sit on different branches before and after a gap (two
Euler triples describe every rotation; near gimbal lock the decomposition
switches branch), and a channel-wise fill then interpolates between branches;
this baseline does not try to solve that (a quaternion-space fill would).

Examples
--------
>>> import numpy as np
>>> t = np.arange(12.0)
>>> x = np.stack([t**3 - 4 * t, np.sin(t / 3)], axis=1)     # (F, C) = (12, 2)
>>> x[5:8] = np.nan
>>> np.round(fill_channels(x, "cubic")[5:8, 0], 9).tolist()    # a cubic is filled exactly
[105.0, 192.0, 315.0]
>>> fill_channels(x, "linear")[5:8, 0].tolist()
[156.0, 264.0, 372.0]
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.interpolate import make_interp_spline

from ..motion import Motion
from .runs import column_runs, run_cells

__all__ = ["fill_channels", "fill_motion", "METHODS", "nexus_window"]

METHODS = ("linear", "cubic", "quintic")
_DEGREE = {"linear": 1, "cubic": 3, "quintic": 5}
# Observed samples needed on EACH side of a gap for a spline of degree k: (k + 1) / 2.
_MIN_SIDE = {5: 3, 3: 2}


def nexus_window(gap_frames) -> np.ndarray:
    """Frames searched on each side of a gap by Nexus's manual Woltring fill and gapfill: ``ceil(n/2) + 5``.

    >>> nexus_window([1, 2, 10, 31]).tolist()
    [6, 6, 10, 21]
    """
    n = np.asarray(gap_frames, dtype=np.int64)
    return (n + 1) // 2 + 5


def _check_method(method: str) -> int:
    if method not in _DEGREE:
        raise ValueError(f"unknown gap-fill method {method!r}; choose one of {', '.join(METHODS)}")
    return _DEGREE[method]


def _check_context(context_s, fps: float) -> int | None:
    """Frames per side for ``context_s`` seconds (at least 1), or None for the Nexus rule."""
    fps = float(fps)
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    if context_s is None:
        return None
    c = float(context_s)
    if not (np.isfinite(c) and c > 0):
        raise ValueError(f"context_s must be a positive number of seconds or None, got {context_s!r}")
    return max(1, int(round(c * fps)))


def fill_channels(values, method: str = "linear", fps: float = 120.0, context_s: float | None = None) -> np.ndarray:
    """Fill every NaN run of each channel of ``values`` (F, C) by ``method``; see the module notes.

    Parameters
    ----------
    values : array (F, C)
        Samples in any unit, frames first, NaN where missing. Not modified.
    method : {"linear", "cubic", "quintic"}
        Straight line between the gap's neighbours, or an interpolating spline
        of degree 3 / 5 through the observed samples of a window around the gap
        (lower orders where the window holds too few samples: quintic needs 3
        observed samples on each side, cubic 2).
    fps : float
        Frames per second; only used to turn ``context_s`` into frames.
    context_s : float, optional
        Seconds on each side of a gap whose observed samples the spline is fitted
        to. None (default): Nexus's manual Woltring window, ``ceil(n/2) + 5``
        frames each side of an ``n``-frame gap (:func:`nexus_window`).

    Returns
    -------
    array (F, C), same float dtype as ``values`` (float64 for integer input)
        Observed entries bit-identical to the input; runs with samples on both
        sides filled by ``method``; runs touching the first or last frame hold
        the nearest observed value; channels with no observed sample stay NaN.

    Raises
    ------
    ValueError
        ``values`` not 2-D, containing +-inf, unknown ``method``, bad ``fps`` or ``context_s``.

    Examples
    --------
    >>> x = np.array([[np.nan, 0.0], [1.0, np.nan], [np.nan, 2.0], [3.0, np.nan]])
    >>> fill_channels(x).tolist()        # leading/trailing runs hold, interior ones lerp
    [[1.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 2.0]]
    """
    k_req = _check_method(method)
    side_frames = _check_context(context_s, fps)
    arr = np.asarray(values)
    if arr.ndim != 2:
        raise ValueError(f"values: expected a 2-D (frames, channels) array, got shape {arr.shape}")
    if not np.issubdtype(arr.dtype, np.floating):
        arr = arr.astype(np.float64)
    if np.isinf(arr).any():
        raise ValueError("values contain +-inf; only NaN marks a missing sample")
    out = arr.copy()
    F, C = arr.shape
    missing = np.isnan(arr)
    if F == 0 or C == 0 or not missing.any():
        return out

    vt = np.ascontiguousarray(arr.T, dtype=np.float64)  # (C, F): one channel per row
    obs_t = ~np.ascontiguousarray(missing.T)
    ch, start, end = column_runs(missing)

    lead = (start == 0) & (end < F)
    trail = (end == F) & (start > 0)
    interior = (start > 0) & (end < F)

    # Edge runs hold the nearest observed value.
    for sel, src in ((lead, end), (trail, start - 1)):
        if sel.any():
            run, frame = run_cells(start[sel], end[sel])
            c = ch[sel][run]
            out[frame, c] = vt[c, src[sel][run]]

    ch, start, end = ch[interior], start[interior], end[interior]
    if len(ch) == 0:
        return out
    k = np.ones(len(ch), dtype=np.int64)
    if k_req > 1:
        n = end - start
        h = nexus_window(n) if side_frames is None else np.full(len(n), side_frames)
        lo = np.maximum(start - h, 0)
        hi = np.minimum(end + h, F)
        # Observed samples on each side inside the window, from per-channel cumulative counts.
        cum = np.zeros((C, F + 1), dtype=np.int64)
        np.cumsum(obs_t, axis=1, out=cum[:, 1:])
        left = cum[ch, start] - cum[ch, lo]
        right = cum[ch, hi] - cum[ch, end]
        side = np.minimum(left, right)
        for deg in sorted(_MIN_SIDE):  # 3 then 5: a later (higher) order overrides where it fits
            if deg <= k_req:
                k[side >= _MIN_SIDE[deg]] = deg

    # Linear: the line through the two neighbours of each run, all runs at once.
    lin = k == 1
    if lin.any():
        run, frame = run_cells(start[lin], end[lin])
        c = ch[lin][run]
        a = start[lin][run] - 1
        b = end[lin][run]
        v0, v1 = vt[c, a], vt[c, b]
        t = (frame - a) / (b - a)
        out[frame, c] = v0 + t * (v1 - v0)

    # Splines: group runs by (degree, length, window pattern) and fit each group in one call.
    spl = np.flatnonzero(~lin)
    if len(spl):
        groups: dict[tuple, list[int]] = {}
        for i in spl.tolist():
            c, s, e, a, b = int(ch[i]), int(start[i]), int(end[i]), int(lo[i]), int(hi[i])
            key = (int(k[i]), e - s, s - a, b - e, obs_t[c, a:s].tobytes(), obs_t[c, e:b].tobytes())
            groups.setdefault(key, []).append(i)
        for (deg, n_gap, n_left, n_right, left_b, right_b), idx in groups.items():
            left_ok = np.frombuffer(left_b, dtype=bool)
            right_ok = np.frombuffer(right_b, dtype=bool)
            # Frames relative to the gap's first frame: window left of it is negative.
            x = np.concatenate([np.arange(-n_left, 0)[left_ok], np.arange(n_gap, n_gap + n_right)[right_ok]])
            idx = np.asarray(idx)
            c = ch[idx]
            s = start[idx]
            y = vt[c[None, :], s[None, :] + x[:, None]]  # (m, G): one column per gap
            spline = make_interp_spline(x.astype(np.float64), y, k=deg, check_finite=False)
            gap = np.arange(n_gap)
            filled = spline(gap.astype(np.float64))  # (n_gap, G)
            out[s[None, :] + gap[:, None], c[None, :]] = filled
    return out


def _unwrap_observed(values: np.ndarray, missing: np.ndarray) -> np.ndarray:
    """Each column unwrapped (period 360) over its observed samples only; missing samples stay NaN.

    Missing samples are first replaced by the previous observed one (the first
    observed for a leading run), so they add zero steps and ``np.unwrap`` sees
    exactly the observed subsequence.
    """
    F = values.shape[0]
    idx = np.where(missing, 0, np.arange(F)[:, None])
    np.maximum.accumulate(idx, axis=0, out=idx)
    first = np.argmax(~missing, axis=0)  # first observed frame (0 for an all-NaN column)
    idx = np.where(missing & (np.arange(F)[:, None] < first), first, idx)
    held = np.take_along_axis(values, idx, axis=0)
    un = np.unwrap(np.nan_to_num(held), period=360.0, axis=0)
    return np.where(missing, np.nan, un)


def _wrap180(x: np.ndarray) -> np.ndarray:
    """Angles in degrees wrapped to (-180, 180]."""
    return 180.0 - np.mod(180.0 - x, 360.0)


def fill_motion(motion: Motion, method: str = "linear", context_s: float | None = None) -> Motion:
    """Fill the missing (NaN) joints of ``motion`` channel by channel with :func:`fill_channels`.

    The joint-angle channels (:meth:`Motion.channel_values`, degrees; NaN where
    a joint is missing) are unwrapped over their observed samples, filled by
    ``method`` at the clip's frame rate, wrapped back to (-180, 180] and turned
    back into quaternions (:meth:`Motion.from_channel_values`). Every joint
    rotation that was observed is then copied back from the input, so it is
    bit-identical; filled rotations are put in the hemisphere of the nearest
    earlier observed rotation of the joint (no sign jumps). Missing root
    positions (and missing animated offsets of BVH files that have them) are
    filled the same way, observed ones kept. A joint missing in every frame stays
    NaN. Skeleton, fps, name and frame count are unchanged.

    Examples
    --------
    >>> import mocapkit
    >>> from mocapkit import corrupt, metrics
    >>> m = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    >>> gappy, mask = corrupt.gaps(m, seed=0)
    >>> filled = fill_motion(gappy, "cubic")
    >>> bool(filled.missing().any()), bool(np.array_equal(filled.rotations[~mask], m.rotations[~mask]))
    (False, True)
    >>> round(metrics.joint_angle_rms(m, filled), 2)           # degrees, over all channels and frames
    1.07
    """
    if not isinstance(motion, Motion):
        raise ValueError(f"fill_motion needs a mocapkit Motion, got {type(motion).__name__}")
    _check_method(method)
    _check_context(context_s, motion.fps)
    sk = motion.skeleton
    rot_in = motion.rotations
    rot_missing = np.any(np.isnan(rot_in), axis=-1)  # (F, J)
    root_missing = np.any(np.isnan(motion.root_positions), axis=-1)
    tr_missing = motion.translations is not None and bool(np.isnan(motion.translations).any())
    if not (rot_missing.any() or root_missing.any() or tr_missing):
        return motion

    values = motion.channel_values()
    is_rot = np.array([c.endswith("rotation") for j in range(sk.num_joints) for c in sk.joint_channels(j)], dtype=bool)
    miss = np.isnan(values)
    work = values.copy()
    if is_rot.any():
        work[:, is_rot] = _unwrap_observed(values[:, is_rot], miss[:, is_rot])
    filled = fill_channels(work, method, fps=motion.fps, context_s=context_s)
    filled[:, is_rot] = _wrap180(filled[:, is_rot])
    filled = np.where(miss, filled, values)
    new = Motion.from_channel_values(
        sk, filled, motion.fps, name=motion.name, animated_offsets=True
    )  # only its rotations are used; positions and offsets are filled directly below

    rot = np.array(rot_in)
    if rot_missing.any():
        # Hemisphere of the last observed rotation of the joint (the first one for a leading gap).
        F = motion.num_frames
        ref_idx = np.where(rot_missing, 0, np.arange(F)[:, None])
        np.maximum.accumulate(ref_idx, axis=0, out=ref_idx)
        first = np.argmax(~rot_missing, axis=0)
        ref_idx = np.where(rot_missing & (np.arange(F)[:, None] < first), first, ref_idx)
        ref = np.take_along_axis(rot_in, ref_idx[..., None], axis=0)
        q = new.rotations
        flip = np.sum(q * ref, axis=-1, keepdims=True) < 0.0
        q = np.where(flip, -q, q)
        rot[rot_missing] = q[rot_missing]
    root = np.array(motion.root_positions)
    if root_missing.any():
        root = fill_channels(root, method, fps=motion.fps, context_s=context_s)
    tr = motion.translations
    if tr_missing:
        F, J = tr.shape[:2]
        tr = fill_channels(tr.reshape(F, 3 * J), method, fps=motion.fps, context_s=context_s).reshape(F, J, 3)
    return dataclasses.replace(motion, rotations=rot, root_positions=root, translations=tr)
