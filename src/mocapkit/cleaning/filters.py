"""Whole-clip smoothing of joint rotations: the "filter everything" baselines of Aristidou et al. 2018, Table 2.

Section 6.2 contrasts repairing only the erroneous joints with methods that
"repair the global motion at once, smoothing even the rotations of correct
joints". These filters are that kind of method, kept simple and reusable:

- :func:`gaussian_smooth` — a Gaussian low-pass of ``sigma_s`` seconds;
- :func:`savgol_smooth` — a Savitzky-Golay filter (local least-squares
  polynomial of degree ``polyorder`` over ``window_s`` seconds), which keeps
  peaks better than a Gaussian of similar noise reduction.

Both act on quaternions: the track of each joint is first made
hemisphere-continuous (:func:`mocapkit.rotations.quaternion_continuity`), each
of its four components is filtered along time, and the result is
renormalised and put back in the input's hemisphere (same rotation sign as the
input, so no sign jumps are introduced). Widths are in seconds, so a filter
means the same at 30 and 120 fps. Missing frames (NaN) stay NaN; each run of
observed frames is filtered on its own, so nothing leaks across a gap. The
root trajectory is filtered the same way unless ``root=False``; joints not
selected are returned bit-identical.

Examples
--------
>>> import mocapkit
>>> from mocapkit import corrupt, metrics
>>> from mocapkit.cleaning.filters import gaussian_smooth
>>> m = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
>>> noisy, _ = corrupt.angular_noise(m, amount=0.2, seed=0)
>>> smooth = gaussian_smooth(noisy)
>>> bool(metrics.pose_error(m, smooth).mean() < metrics.pose_error(m, noisy).mean())
True
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from .. import rotations as R
from ..corrupt import joint_set
from ..motion import Motion
from .ik import contact_segments

__all__ = ["gaussian_smooth", "savgol_smooth", "window_frames"]


def window_frames(window_s: float, fps: float, polyorder: int = 2) -> int:
    """An odd frame count close to ``window_s * fps`` and at least ``polyorder + 2`` (then made odd).

    >>> window_frames(0.25, 120.0), window_frames(0.25, 30.0), window_frames(0.01, 30.0, polyorder=2)
    (31, 9, 5)
    """
    if not (np.isfinite(window_s) and window_s > 0):
        raise ValueError(f"window_s must be a positive number of seconds, got {window_s!r}")
    if not (isinstance(polyorder, (int, np.integer)) and polyorder >= 0):
        raise ValueError(f"polyorder must be a non-negative integer, got {polyorder!r}")
    n = max(int(round(window_s * fps)), int(polyorder) + 2)
    return n if n % 2 == 1 else n + 1


def _filter_tracks(x: np.ndarray, valid: np.ndarray, func: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Apply ``func`` (filters axis 0) to tracks ``x`` (F, K, C) where ``valid`` (F, K); each observed run alone.

    Tracks observed throughout are filtered together in one call; the others
    run by run. Cells not valid are returned as they were (NaN).
    """
    out = np.array(x)
    full = valid.all(axis=0)
    if full.any():
        out[:, full] = func(x[:, full])
    for k in np.flatnonzero(~full):
        for s, e in contact_segments(valid[:, k]):
            out[s:e, k] = func(x[s:e, k])
    return out


def _smooth(motion: Motion, func, joints, root: bool) -> Motion:
    sel = joint_set(motion, joints, include_root=True)
    rot = np.array(motion.rotations)
    if motion.num_frames >= 2 and sel.any():
        src = motion.rotations[:, sel]
        cont = R.quaternion_continuity(src, axis=0)
        valid = np.all(np.isfinite(cont), axis=-1)
        filt = _filter_tracks(cont, valid, func)
        filt = R.quaternion_normalize(filt)
        filt = np.where(np.sum(filt * src, axis=-1, keepdims=True) < 0.0, -filt, filt)
        rot[:, sel] = np.where(valid[..., None], filt, src)
    pos = motion.root_positions
    if root and motion.num_frames >= 2:
        valid = np.all(np.isfinite(pos), axis=-1)
        pos = _filter_tracks(pos[:, None], valid[:, None], func)[:, 0]
    return dataclasses.replace(motion, rotations=rot, root_positions=pos)


def gaussian_smooth(motion: Motion, sigma_s: float = 0.02, joints=None, root: bool = True) -> Motion:
    """Gaussian low-pass of the rotation (and root position) tracks, std ``sigma_s`` seconds.

    ``scipy.ndimage.gaussian_filter1d`` with ``mode="nearest"`` (ends padded
    with their value) on hemisphere-continuous quaternion components, then
    renormalised. ``joints`` (names or indices, default all, root rotation
    included) selects what is smoothed; ``root`` whether the root trajectory is.
    The default 0.02 s (2.4 frames at 120 fps) takes out frame-to-frame jitter
    and leaves visible motion mostly alone. Returns a new Motion.
    """
    if not (np.isfinite(sigma_s) and sigma_s > 0):
        raise ValueError(f"sigma_s must be a positive number of seconds, got {sigma_s!r}")
    sigma = sigma_s * motion.fps
    from scipy.ndimage import gaussian_filter1d  # here: importing scipy.ndimage takes ~0.2 s

    def func(x: np.ndarray) -> np.ndarray:
        return gaussian_filter1d(x, sigma, axis=0, mode="nearest")

    return _smooth(motion, func, joints, root)


def savgol_smooth(
    motion: Motion, window_s: float = 0.2, polyorder: int = 2, joints=None, root: bool = True
) -> Motion:
    """Savitzky-Golay smoothing of the rotation (and root position) tracks over ``window_s`` seconds.

    The window is :func:`window_frames` (odd, at least ``polyorder + 2``);
    ``scipy.signal.savgol_filter`` with ``mode="interp"`` (the polynomial fit
    over the first/last window gives the ends). An observed run shorter than
    the window uses the longest odd window it holds, and one too short for
    the polynomial is left as it is. Other arguments as in
    :func:`gaussian_smooth`. Returns a new Motion.
    """
    from scipy.signal import savgol_filter  # here: importing scipy.signal takes ~1 s, which most commands never need

    window = window_frames(window_s, motion.fps, polyorder)

    def func(x: np.ndarray) -> np.ndarray:
        n = x.shape[0]
        w = window if window <= n else (n if n % 2 == 1 else n - 1)
        if w <= polyorder:
            return x
        return savgol_filter(x, w, polyorder, axis=0, mode="interp")

    return _smooth(motion, func, joints, root)
