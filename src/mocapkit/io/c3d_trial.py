"""What :func:`~mocapkit.io.c3d.write_c3d` keeps of a C3D's trial-specific parameters: force plates and events.

A C3D written ``like`` a file keeps that file's parameter groups, but two of
them describe the file's own recording, not a layout:

- ``FORCE_PLATFORM`` names, in ``CHANNEL``, the analog channels each plate's
  signals are in (1-based, C3D User Guide ch. "FORCE_PLATFORM"). A file
  written without those channels (another trial's frames, a resampled take:
  the analogs are dropped) would claim plates whose signals it does not hold:
  :func:`fit_force_plates` writes ``USED`` 0 and leaves the plates out;
- events (the header's event section and the ``EVENT`` group) are times, in
  seconds, of that trial (``(frame - 1) / rate`` of its own frame numbers, as
  Vicon writes them: FunctionalWalk.c3d's first frame 480 at 120 Hz is at
  3.99 s, its events 4.5 to 7.2 s). They are kept only where the file is the
  take's own trial (:func:`same_trial`), and then only the events inside the
  frames written (:func:`event_kept`); a crop of the take keeps the events
  inside it.

C3D format: Motion Lab Systems, "The C3D File Format User Guide" (c3d.org).
"""

from __future__ import annotations

import numpy as np

__all__ = ["same_trial", "event_kept", "fit_force_plates", "fit_event_group", "fit_header_events"]


def same_trial(fps: float, first: int, frames: int, like_fps: float, like_first: int, like_frames: int) -> bool:
    """Whether a ``like`` file (rate ``like_fps`` Hz, first frame number ``like_first``, ``like_frames`` frames)
    spans the very frames of the take written (``fps``, ``first``, ``frames``): only then are its events the
    take's. A file of another rate, start or length is another trial (or another part of one) as far as its
    events go."""
    return bool(np.isclose(fps, like_fps, rtol=0, atol=1e-6 * max(fps, 1.0))) and int(first) == int(like_first) \
        and int(frames) == int(like_frames)


def event_kept(time_s: float, fps: float, first: int, frames: int) -> bool:
    """Whether an event at ``time_s`` seconds (the trial's clock: frame ``n`` at ``(n - 1) / fps``) lies within
    the ``frames`` frames written from frame number ``first`` (half a frame either side)."""
    start = (int(first) - 1) / fps
    return bool(start - 0.5 / fps <= float(time_s) <= start + (int(frames) - 0.5) / fps)


def fit_force_plates(parameters: dict, channels: int) -> bool:
    """Leave out (``USED`` 0, no per-plate parameter) the force plates of ``parameters`` (an ezc3d parameter
    dict, changed in place) whose ``FORCE_PLATFORM:CHANNEL`` names an analog channel beyond the ``channels``
    written. Returns whether any plate was left out. The plates are left out whole: a plate with some of its
    channels is no plate a reader can use either."""
    group = parameters.get("FORCE_PLATFORM")
    if not group or "USED" not in group:
        return False
    used = int(np.ravel(group["USED"]["value"])[0]) if np.size(group["USED"]["value"]) else 0
    chan = np.asarray(group.get("CHANNEL", {}).get("value", []))
    if used <= 0 or (chan.size and int(chan.max()) <= channels):
        return False
    for key in [k for k in group if k not in ("__METADATA__", "USED")]:
        del group[key]
    group["USED"] = dict(group["USED"], value=np.array([0]))
    return True


def _per_event(value, count: int, keep: np.ndarray):
    """``value`` (one entry per event, or TIMES' (2, N) minutes and seconds, flat or not) with only ``keep``."""
    if isinstance(value, list):
        return [v for v, k in zip(value, keep) if k] if len(value) == count else value
    a = np.asarray(value)
    if a.ndim == 2 and a.shape[-1] == count:
        return a[:, keep]
    if a.ndim == 1 and a.size == count:
        return a[keep]
    if a.ndim == 1 and a.size == 2 * count:  # TIMES read flat: (minutes, seconds) per event
        return a.reshape(count, 2)[keep].ravel()
    return value


def fit_event_group(parameters: dict, own: bool, fps: float, first: int, frames: int) -> int:
    """Keep, in ``parameters``' ``EVENT`` group (changed in place), only the events of the take's own trial
    (``own``) that lie within its frames (:func:`event_kept`); ``USED`` and every per-event parameter (LABELS,
    CONTEXTS, TIMES, ...) follow. Returns how many events were left out."""
    group = parameters.get("EVENT")
    if not group or "USED" not in group or "TIMES" not in group:
        return 0
    count = int(np.ravel(group["USED"]["value"])[0]) if np.size(group["USED"]["value"]) else 0
    if count <= 0:
        return 0
    times = np.asarray(group["TIMES"]["value"], dtype=np.float64)
    pairs = times.reshape(count, 2) if times.ndim == 1 else times.reshape(2, -1).T[:count]
    keep = np.array([own and event_kept(60.0 * m + s, fps, first, frames) for m, s in pairs], dtype=bool)
    if keep.all():
        return 0
    for key in [k for k in group if k not in ("__METADATA__", "USED")]:
        if isinstance(group[key], dict) and "value" in group[key]:
            group[key] = dict(group[key], value=_per_event(group[key]["value"], count, keep))
    group["USED"] = dict(group["USED"], value=np.array([int(keep.sum())]))
    return int((~keep).sum())


def fit_header_events(events, own: bool, fps: float, first: int, frames: int) -> tuple:
    """The header events (``(time s, label, flag)``) to write: the take's own trial's (``own``) within its
    frames (:func:`event_kept`); none of another trial's."""
    return tuple(e for e in events if own and event_kept(e[0], fps, first, frames))
