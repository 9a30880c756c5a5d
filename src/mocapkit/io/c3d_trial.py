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
  take's own trial (:func:`trial_frames`), and then only the events inside the
  frames written (:func:`event_kept`); a crop of the take keeps the events
  inside it, at their own times (its first frame number written with it), and
  so does a crop written ``like`` the whole file: the file is then cut to the
  crop's frames (its analogs and force plates kept too). A resampled take
  (``markers[::2]``) keeps the events within its time span, read on the file's
  clock (:func:`trial_rate`), written ``like`` its own file too (its samples
  are the file's at the frames it came from), and is written from the frame of its own rate
  at its first frame's time (:func:`written_first`).

C3D format: Motion Lab Systems, "The C3D File Format User Guide" (c3d.org).
"""

from __future__ import annotations

import numpy as np

from ..markerset import MarkerSet

__all__ = ["same_rate", "same_trial", "samples_agree", "trial_frames", "event_kept", "channels_held", "fit_force_plates",
           "fit_event_group", "fit_header_events", "trial_span", "trial_rate", "written_first"]


def same_rate(fps: float, like_fps: float) -> bool:
    """Whether two frame rates (Hz) are the same, to a millionth."""
    return bool(np.isclose(fps, like_fps, rtol=0, atol=1e-6 * max(fps, 1.0)))


def same_trial(fps: float, first: int, frames: int, like_fps: float, like_first: int, like_frames: int) -> bool:
    """Whether a ``like`` file (rate ``like_fps`` Hz, first frame number ``like_first``, ``like_frames`` frames)
    spans the very frames of the take written (``fps``, ``first``, ``frames``): only then are its events the
    take's. A file of another rate, start or length is another trial (or another part of one) as far as its
    events go."""
    return same_rate(fps, like_fps) and int(first) == int(like_first) \
        and int(frames) == int(like_frames)


AGREE_CM = 0.1
"""Distance (cm) within which a marker sample of the take and the same marker's sample of a ``like`` file in the
same frame are the same measurement (:func:`samples_agree`): far above float32 rounding (3e-5 mm at a metre) and a
TRC's 5 decimals, and above what most cleaning changes; far below what a marker moves between two trials (another
trial's samples at the same frame number: none of 157,863 within 1 mm, 9 pairs of trials of one lab and
subject each in the test data (PiG, Functional*, CMU 85_02/85_12, c3d.org sample28), median 8 cm to 1.8 m)."""


def samples_agree(markers: MarkerSet, like: MarkerSet) -> bool | None:
    """Whether ``markers`` and ``like`` (a take and a C3D's trial, same frames: (F, M, 3) and (F, M', 3)) hold the
    same measurements: at least half of the samples of a marker seen in both in the same frame lie within
    :data:`AGREE_CM` of each other. None when no such sample exists (no marker in common, or none seen in both):
    the data then say nothing.

    Markers are matched by label, compared in cm (each take's own unit); the modelled quantities a C3D lists
    (:meth:`~mocapkit.markerset.MarkerSet.quantities`: angles, forces) are no lengths and are left out. Half, not
    all: a cleaned take changes some samples (fills are of samples missing in the file, so not compared), and a
    take read from another trial agrees on none (the PiG_Calibration-FlatFoot files of one subject, standing still: 0 of
    10,434 within 1 mm).
    """
    mine = {label: m for m, (label, kind) in enumerate(zip(markers.labels, markers.quantities())) if not kind}
    theirs = {label: m for m, (label, kind) in enumerate(zip(like.labels, like.quantities())) if not kind}
    common = [label for label in mine if label in theirs]
    if not common or markers.num_frames != like.num_frames:
        return None
    a = markers.positions[:, [mine[label] for label in common]] * markers.unit_cm
    b = like.positions[:, [theirs[label] for label in common]] * like.unit_cm
    d = np.linalg.norm(a - b, axis=-1)
    d = d[np.isfinite(d)]
    if d.size == 0:
        return None
    return bool(np.mean(d <= AGREE_CM) >= 0.5)


def trial_frames(markers: MarkerSet, like: MarkerSet) -> slice | None:
    """The frames of ``like`` (a C3D read) that the take ``markers`` holds, as a slice of ``like``'s frames (0-based,
    step 1 or the resampling's), when ``like`` is the take's own trial, else None; the events of ``like`` are the
    take's only then.

    ``like`` is the take's trial when it holds the take's frames (by their numbers: each ``source.first_frame``, 1
    without a source) and the markers seen in both agree there (:func:`samples_agree`): the take itself
    (``slice(0, F)``), a crop of it (``take[100:300]`` written like its file: ``slice(100, 300)``), or a resampled
    take (``take[150:400:2]`` at half the file's rate: ``slice(150, 399, 2)``), compared at the file's frames it
    came from. A resampled take's first frame number is on its file's clock (``trial_rate`` in its source's layout,
    :func:`trial_rate`; a take without one: its own rate), and the file's rate must be a whole multiple of the
    take's. Where no marker is seen in both in a frame of both (no label in common), the data say nothing and
    ``like`` is the take's trial only when it spans the very frames at the take's rate (:func:`same_trial`), as
    before the data were compared: nothing then shows a resampled take to be the file's.
    """
    first = markers.source.first_frame if markers.source is not None else 1
    like_first = like.source.first_frame if like.source is not None else 1
    clock = trial_rate(markers.source.layout, markers.fps) if markers.source is not None else float(markers.fps)
    step, frames = float(like.fps) / float(markers.fps), markers.num_frames
    at = (int(first) - 1) * float(like.fps) / clock + 1 - int(like_first)  # the take's first frame in like's
    if round(step) < 1 or not same_rate(markers.fps * round(step), like.fps) or abs(at - round(at)) > 1e-6:
        return None
    step, start = int(round(step)), int(round(at))
    if start < 0 or start + (frames - 1) * step >= like.num_frames:
        return None
    held = slice(start, start + (frames - 1) * step + 1, step)
    agree = samples_agree(markers, like[held])
    if agree is None:
        agree = step == 1 and same_trial(markers.fps, first, frames, like.fps, like_first, like.num_frames)
    return held if agree else None


def event_kept(time_s: float, fps: float, first: int, frames: int, trial: tuple[int, int] | None = None,
               rate: float | None = None) -> bool:
    """Whether an event at ``time_s`` seconds (the trial's clock: the file's frame ``n`` at ``(n - 1) / rate``)
    lies within the time span of the ``frames`` frames written at ``fps`` Hz from the file's frame number
    ``first`` (half a frame of ``fps`` either side).

    ``rate``: the file's frame rate, the clock of ``first`` and ``trial`` (default ``fps``); a resampled take
    (``markers[::2]``: ``fps`` half the file's ``rate``) spans ``(first - 1) / rate`` to ``(frames - 1) / fps``
    later, which mixing the file's frame numbers with the take's rate put elsewhere (FunctionalWalk.c3d[::3]
    from its frame 580 at 40 Hz: 14.5 s, past all its events). ``trial``: (first frame number, frame count) of
    the whole file read. An event before its first frame or after its last lies in no frame a crop cut away,
    and is kept while the frames written reach that end of the file (a resampled take: its next frame would lie
    past the file's last): a take written whole keeps every event it had (c3d.org's FP1.C3D lists L. E at
    8.0 s, past its 480 frames at 60 Hz: written back, it was lost)."""
    rate = float(fps) if rate is None else float(rate)
    start = (int(first) - 1) / rate
    low, high = start - 0.5 / fps, start + (int(frames) - 0.5) / fps
    if trial is not None:
        if int(first) <= int(trial[0]):
            low = -np.inf
        # the frame after the last written, in the file's frames (first + frames at the file's own rate)
        if int(first) + int(frames) * rate / fps >= int(trial[0]) + int(trial[1]) - 1e-6:
            high = np.inf
    return bool(low <= float(time_s) <= high)


def channels_held(source, own: bool) -> int | None:
    """The analog channels of the C3D file a take was read from (``source``, its
    :class:`~mocapkit.markerset.MarkerSource`), for :func:`fit_force_plates`' ``held``; None where unknown.

    The take's analogs when it holds them; 0 for the take's own file (``own``) that has none (ANALOG:USED 0 or
    absent), so that its plates, which no channel of the file ever held, are kept as it states them (a file of
    plates without analogs lost them written back); None where the take has dropped the file's channels (a
    resampled take: ``source.analogs`` None under an ANALOG:USED above 0), or is no C3D's.
    """
    if source is None:
        return None
    if source.analogs is not None:
        return int(source.analogs.shape[0])
    group = source.parameters.get("ANALOG", {})
    used = np.ravel(group.get("USED", {}).get("value", [])) if isinstance(group, dict) else []
    return 0 if own and (len(used) == 0 or int(used[0]) == 0) else None


def fit_force_plates(parameters: dict, channels: int, held: int | None = None) -> bool:
    """Leave out (``USED`` 0, no per-plate parameter) the force plates of ``parameters`` (an ezc3d parameter
    dict, changed in place) whose ``FORCE_PLATFORM:CHANNEL`` names an analog channel beyond the ``channels``
    written. Returns whether any plate was left out. The plates are left out whole: a plate with some of its
    channels is no plate a reader can use either. ``held``: the analog channels of the file read; where every
    one is written (``channels >= held``) the plates are the file's as it had them, kept even where they name
    channels it never held (BTK's shd01.c3d: plate 2 on channels 8-13 of 6; both plates were left out of it
    written back unchanged)."""
    group = parameters.get("FORCE_PLATFORM")
    if not group or "USED" not in group or (held is not None and channels >= held):
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


def fit_event_group(parameters: dict, own: bool, fps: float, first: int, frames: int,
                    trial: tuple[int, int] | None = None, rate: float | None = None) -> int:
    """Keep, in ``parameters``' ``EVENT`` group (changed in place), only the events of the take's own trial
    (``own``) that lie within its frames (:func:`event_kept`, ``trial`` and ``rate`` as there); ``USED`` and every per-event
    parameter (LABELS, CONTEXTS, TIMES, ...) follow. Returns how many events were left out."""
    group = parameters.get("EVENT")
    if not group or "USED" not in group or "TIMES" not in group:
        return 0
    count = int(np.ravel(group["USED"]["value"])[0]) if np.size(group["USED"]["value"]) else 0
    if count <= 0:
        return 0
    times = np.asarray(group["TIMES"]["value"], dtype=np.float64)
    pairs = times.reshape(count, 2) if times.ndim == 1 else times.reshape(2, -1).T[:count]
    keep = np.array([own and event_kept(60.0 * m + s, fps, first, frames, trial, rate) for m, s in pairs], dtype=bool)
    if keep.all():
        return 0
    for key in [k for k in group if k not in ("__METADATA__", "USED")]:
        if isinstance(group[key], dict) and "value" in group[key]:
            group[key] = dict(group[key], value=_per_event(group[key]["value"], count, keep))
    group["USED"] = dict(group["USED"], value=np.array([int(keep.sum())]))
    return int((~keep).sum())


def fit_header_events(events, own: bool, fps: float, first: int, frames: int,
                      trial: tuple[int, int] | None = None, rate: float | None = None) -> tuple:
    """The header events (``(time s, label, flag)``) to write: the take's own trial's (``own``) within its
    frames (:func:`event_kept`, ``trial`` and ``rate`` as there); none of another trial's."""
    return tuple(e for e in events if own and event_kept(e[0], fps, first, frames, trial, rate))


def trial_rate(layout, fps: float) -> float:
    """The frame rate (Hz) of the whole C3D file a take was read from, the clock of its frame numbers, as
    :func:`~mocapkit.io.c3d.read_c3d` keeps it in ``MarkerSource.layout`` (``trial_rate``); ``fps`` (the take's)
    where it does not (a take read before it was kept)."""
    return float(layout.get("trial_rate", fps)) if layout is not None else float(fps)


def written_first(first: int, fps: float, rate: float) -> int:
    """The first frame number (1-based) to write for a take whose first frame is the file's frame ``first``
    (at the file's ``rate`` Hz), written at ``fps`` Hz: ``first`` itself at the file's rate, else the frame of
    the take's rate nearest the same time, ``1 + round((first - 1) * fps / rate)`` (FunctionalWalk.c3d's
    frame 480 at 120 Hz, 3.992 s, is frame 241 of its ``[::2]`` at 60 Hz, 4.000 s: within half a frame of the
    take's rate; Eb015pr.c3d's frame 151 at 50 Hz, 3.0 s, is frame 76 of its ``[150::2]``, 3.0 s)."""
    if same_rate(fps, rate):
        return int(first)
    return max(1, 1 + int(round((int(first) - 1) * float(fps) / float(rate))))


def trial_span(layout) -> tuple[int, int] | None:
    """(first frame number, frame count) of the whole C3D file a take was read from, as
    :func:`~mocapkit.io.c3d.read_c3d` keeps them in ``MarkerSource.layout`` (``trial_first``, ``trial_frames``);
    None where it does not (a take read before they were kept, or from no C3D)."""
    if "trial_first" not in layout or "trial_frames" not in layout:
        return None
    return int(layout["trial_first"]), int(layout["trial_frames"])
