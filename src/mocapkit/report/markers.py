"""Reports of a cleaned marker capture: a playable 3-D marker viewer (HTML) and per-marker before/after plots (PNG).

:func:`write_marker_report` writes one self-contained HTML file (no network:
the script and data are inline): the markers as points, drag to turn the
view, a frame slider and a play button; a sample that was filled is drawn
green, a removed spike's fill red, a re-labelled (swapped) sample orange, a
removed duplicate label's fill purple, a removed foreign stretch's fill (another
point under the marker's label, :mod:`~mocapkit.cleaning.markers.foreign`) brown,
and the input's bad value of a spike, a duplicate or a foreign stretch as a small grey cross; the list of
fixes (marker, frames, kind, size in mm) below, each a link to its first
frame that selects its marker (ringed in blue and named in the viewer), as
each change's *jump to frame* of the accept/reject list does. :func:`plot_marker_fixes` draws, for the markers with most changes,
their three coordinates before (grey) and after (colour) with the changed
frames shaded. Both read a :class:`~mocapkit.cleaning.markers.MarkerCleanResult`.
"""

from __future__ import annotations

import dataclasses
import html
import json
from pathlib import Path

import numpy as np

__all__ = ["write_marker_report", "plot_marker_fixes"]

_KIND_CODE = {"filled": 1, "spike": 2, "swap": 3, "duplicate": 4, "foreign": 5}

_SCRIPT = r"""
const D = JSON.parse(document.getElementById('data').textContent);
const cv = document.getElementById('view'), cx = cv.getContext('2d');
const slider = document.getElementById('frame'), label = document.getElementById('flabel');
const followBox = document.getElementById('follow');
let yaw = 0.6, pitch = 0.3, playing = false, f = 0, drag = null, sel = -1;  // sel: the marker a jump selected
const up = D.up;  // index of the vertical axis
const colours = ['#445', '#1a9850', '#d73027', '#f28e2b', '#7b3294', '#8c510a'], SELECTED = '#1f78b4';
followBox.checked = D.view.follow;
followBox.onchange = () => draw();
function target() { return followBox.checked ? D.view.track[f] : D.view.centre; }
function project(p, t) {
  // orthographic: every point within the framed sphere about the target lies in the canvas at any yaw and pitch
  const x = p[0] - t[0], y = p[1] - t[1], z = p[2] - t[2];
  let h = [x, y, z]; const v = h[up]; h.splice(up, 1);
  const cy = Math.cos(yaw), sy = Math.sin(yaw);
  const a = h[0] * cy - h[1] * sy, b = h[0] * sy + h[1] * cy;
  const cp = Math.cos(pitch), sp = Math.sin(pitch);
  const s = D.view.fill * Math.min(cv.width, cv.height) / 2 / D.view.radius[followBox.checked ? 'follow' : 'fixed'];
  return [cv.width / 2 + a * s, cv.height / 2 - (v * cp - b * sp) * s];
}
function draw() {
  cx.clearRect(0, 0, cv.width, cv.height);
  const P = D.pos[f], K = D.kind[f], B = D.bad[f], t = target();
  for (let m = 0; m < P.length; m++) {
    if (B[m]) { const q = project(B[m], t); cx.strokeStyle = '#999'; cx.beginPath();
      cx.moveTo(q[0] - 4, q[1] - 4); cx.lineTo(q[0] + 4, q[1] + 4); cx.moveTo(q[0] - 4, q[1] + 4); cx.lineTo(q[0] + 4, q[1] - 4); cx.stroke(); }
    if (!P[m]) continue;
    const q = project(P[m], t);
    cx.fillStyle = colours[K[m]]; cx.beginPath(); cx.arc(q[0], q[1], K[m] ? 5 : 3.5, 0, 2 * Math.PI); cx.fill();
  }
  const S = sel >= 0 ? (P[sel] || B[sel]) : null;  // the selected marker: a ring and its label where it is seen
  if (S) { const q = project(S, t); cx.strokeStyle = SELECTED; cx.lineWidth = 2.5; cx.beginPath();
    cx.arc(q[0], q[1], 11, 0, 2 * Math.PI); cx.stroke(); cx.lineWidth = 1;
    cx.fillStyle = SELECTED; cx.font = '13px sans-serif'; cx.fillText(D.labels[sel], q[0] + 14, q[1] - 8); }
  label.textContent = 'frame ' + D.frames[f] + ' / ' + (D.num_frames - 1) + ' (' + (D.frames[f] / D.fps).toFixed(2) + ' s)'
    + (sel >= 0 ? ', ' + D.labels[sel] + (S ? '' : ' (missing here)') : '');
}
function indexOf(t) {  // the shown frame that is take frame t, else the nearest shown one before it
  let lo = 0, hi = D.frames.length - 1;
  while (lo < hi) { const mid = (lo + hi + 1) >> 1; if (D.frames[mid] <= t) lo = mid; else hi = mid - 1; }
  return lo;
}
// playback in real time: the position runs in take frames at the capture's rate and the frame drawn is
// the shown one at or before it (frames in between are skipped when the screen draws fewer per second)
let pos = 0, lastT = null;
function show(k) { f = Math.max(0, Math.min(D.frames.length - 1, k)); pos = D.frames[f]; slider.value = f; draw(); }
slider.max = D.pos.length - 1;
slider.oninput = () => show(+slider.value);
function tick(now) {
  if (!playing) return;
  if (lastT !== null) {
    pos = (pos + (now - lastT) / 1000 * D.fps) % D.num_frames;
    const k = indexOf(pos);
    if (k !== f) { f = k; slider.value = f; draw(); }
  }
  lastT = now; requestAnimationFrame(tick);
}
document.getElementById('play').onclick = () => { playing = !playing; lastT = null; if (playing) requestAnimationFrame(tick); };
cv.onmousedown = e => { drag = [e.clientX, e.clientY]; };
window.onmouseup = () => { drag = null; };
cv.onmousemove = e => { if (!drag) return; yaw += (e.clientX - drag[0]) * 0.01;
  pitch = Math.max(-1.5, Math.min(1.5, pitch + (e.clientY - drag[1]) * 0.01)); drag = [e.clientX, e.clientY]; draw(); };
for (const a of document.querySelectorAll('a.fix')) a.onclick = e => { e.preventDefault(); playing = false;
  sel = a.dataset.marker === undefined ? -1 : +a.dataset.marker; show(indexOf(+a.dataset.frame)); };
window.markerReport = { frame: () => D.frames[f], show: t => show(indexOf(t)), playing: () => playing,
  selected: () => sel };
// what the accept/reject list (review.js) moves: the marker selected (ringed and named) and the frame on show
window.mocapkitReport = { select: m => { sel = m; draw(); }, setFrame: t => { playing = false; show(indexOf(t)); } };
draw();
"""


def _duplicates(result) -> np.ndarray:
    """(F, M) the samples removed as duplicate labels or foreign stretches (none for a result without the mask)."""
    d = getattr(result, "duplicates", None)
    return d if d is not None else np.zeros(result.filled.shape, dtype=bool)


def _foreign(result) -> np.ndarray:
    """(F, M) the samples of :func:`_duplicates` removed as foreign stretches (fixes of kind "foreign"): another
    point under the marker's label, not a copy of another marker's (:mod:`~mocapkit.cleaning.markers.foreign`)."""
    removed = _duplicates(result)
    out = np.zeros(removed.shape, dtype=bool)
    col = {label: k for k, label in enumerate(result.markers.labels)}
    for x in result.fixes:
        if x.kind == "foreign" and x.marker in col:
            out[x.start:x.end, col[x.marker]] = True
    return out & removed


def shown_marker_frames(result, max_frames: int) -> tuple[np.ndarray, int, str]:
    """The capture frames the marker viewer keeps: ``(frames, stride, detail)``.

    As the joint-angle report (:func:`mocapkit.report.html.shown_frames`): every
    frame up to ``max_frames``; a longer capture keeps every ``stride``-th frame,
    its last frame, and every frame of each fix (gap filled, spike removed, swap
    undone) with frames either side, the first frame of each fix before all (where
    its link lands), at most ``2 * max_frames`` frames.
    """
    from .html import shown_frames

    touched = result.filled | result.spikes | result.swapped | _duplicates(result)
    return shown_frames(result.markers.positions.shape[0], int(max_frames), changed=touched,
                        starts=[x.start for x in result.fixes])


_DETAIL_WORDS = {
    "full": "every frame of each fix, with 3 frames either side",
    "runs": "every frame of each fix",
    "changes": "every frame of each fix",
    "starts": "the first frame of each fix (too many fixed frames to show them all)",
    "some": "the first frame of some of the fixes (too many to show them all)",
}


def _shown_note(frames: np.ndarray, num_frames: int, stride: int, detail: str) -> str:
    """What a long capture's viewer shows, in words; empty when it shows every frame."""
    if len(frames) == num_frames:
        return ""
    extra = _DETAIL_WORDS.get(detail)
    suffix = {1: "st", 2: "nd", 3: "rd"}.get(stride % 10, "th") if stride % 100 not in (11, 12, 13) else "th"
    nth = f"{stride}{suffix}"  # every 2nd frame, not "every 2th"
    return (f"Long capture: the viewer shows every {nth} frame, the last one"
            + (f" and {extra}" if extra else "") + f" ({len(frames)} of {num_frames} frames); "
            "it plays in real time, skipping the frames between.")


def _marker_framing(points, frames: np.ndarray, fps: float, up: int) -> dict:
    """Where the marker viewer looks and how far it zooms, in the capture's axes (mm).

    The marker viewer projects orthographically, so a sphere of radius ``r`` about the
    target stays within ``r`` of the canvas centre at any yaw and pitch: the page scales
    ``fill * min(width, height) / 2`` pixels to the radius of the sphere holding every
    drawn point (markers and the grey crosses of removed spikes). The target is the
    bounding-box centre of the capture, or (``follow``, on captures that travel) the
    markers' centroid smoothed over a second (:func:`mocapkit.report.view.fit_view`).
    """
    from .view import FOLLOW_RATIO, MARGIN, fit_view

    order = [a for a in range(3) if a != up]
    perm = [order[0], up, order[1]]  # the page's y is the vertical: what fit_view frames
    fv = fit_view([p[..., perm] for p in points], fps=fps, frames=frames)
    back = np.argsort(perm)

    def orig(v):
        return [round(float(c), 1) for c in np.asarray(v)[back]]

    track = [orig([x, fv.track_height, z]) for x, z in fv.track]
    return {"centre": orig(fv.centre), "track": track, "fill": 1.0 - MARGIN,
            "radius": {"fixed": fv.radius_fixed, "follow": fv.radius_follow},
            "follow": bool(fv.radius_fixed > FOLLOW_RATIO * fv.radius_follow)}


def write_marker_report(path, result, *, title: str = "", max_frames: int = 3000, up_axis: int | None = None,
                        review: dict | None = None, review_mode: bool = False, read=()) -> Path:
    """Write the HTML marker viewer of ``result`` (a MarkerCleanResult) to ``path``; returns the path.

    Up to ``max_frames`` frames every frame is kept; a longer capture keeps every
    k-th frame, its last frame and every frame of each fix with frames either side
    (:func:`shown_marker_frames`), and the page says so. Positions in millimetres
    rounded to 0.1 mm. ``up_axis``: 0, 1 or 2 (default: the axis along which one
    frame's markers spread most: a standing body is tallest along the vertical).
    The page plays in real time at the capture's rate and frames every drawn point
    of every frame whole (:func:`_marker_framing`). ``review``: the changes to accept or reject and the
    decisions document (:func:`mocapkit.cleaning.markers.decisions.review`), drawn by the joint-angle
    report's list (:func:`mocapkit.report.html.review_parts`); ``review_mode`` (or ``result.review``): the
    capture was only reviewed (``--steps detect``), the page says its output holds the input unchanged. With
    decisions applied, ``result`` is the decided one
    (:func:`mocapkit.cleaning.markers.decisions.decided_result`): the viewer draws the capture written. ``read``:
    lines on how the file was read that the changes rest on (samples stored as (0, 0, 0) read as gaps:
    :func:`mocapkit.marker_files.zeros_read_lines`), said first in the summary.
    """
    from ..io import atomic_write
    from .html import review_parts

    path = Path(path)
    before = np.asarray(result.original.positions, dtype=np.float64)
    after = np.asarray(result.markers.positions, dtype=np.float64)
    mm = 10.0 * result.markers.unit_cm
    idx, stride, detail = shown_marker_frames(result, max_frames)
    kind = np.zeros(after.shape[:2], dtype=np.int8)
    kind[result.filled] = _KIND_CODE["filled"]
    kind[result.spikes] = _KIND_CODE["spike"]
    kind[result.swapped] = _KIND_CODE["swap"]
    removed = result.spikes | _duplicates(result)  # recorded values that were removed: drawn as grey crosses
    kind[_duplicates(result)] = _KIND_CODE["duplicate"]
    kind[_foreign(result)] = _KIND_CODE["foreign"]
    seen = after[~np.isnan(after).any(axis=-1)]
    if up_axis is None:
        frame_spread = np.nanmedian(np.nanmax(after, axis=1) - np.nanmin(after, axis=1), axis=0) if seen.size else np.ones(3)
        up_axis = int(np.nanargmax(frame_spread)) if seen.size else 2  # a standing body is tallest along the vertical

    def pts(a):
        return [[None if np.isnan(p).any() else [round(float(c) * mm, 1) for c in p] for p in row] for row in a]

    bad = np.where(removed[..., None], before, np.nan)
    fps = float(result.markers.fps)
    data = {"pos": pts(after[idx]), "kind": kind[idx].tolist(), "bad": pts(bad[idx]), "frames": idx.tolist(),
            "num_frames": int(after.shape[0]), "fps": fps, "up": up_axis, "labels": list(result.markers.labels),
            "view": _marker_framing([after[idx] * mm, bad[idx] * mm], idx, fps, up_axis)}
    note = _shown_note(idx, after.shape[0], stride, detail)
    col = {label: k for k, label in enumerate(result.markers.labels)}

    def link(x) -> str:  # a fix's link: its first frame, its marker selected
        at = f" data-marker='{col[x.marker]}'" if x.marker in col else ""
        return f"<a class='fix' href='#' data-frame='{x.start}'{at}>{x.start}-{x.end - 1}</a>"

    rows = "".join(
        f"<tr><td>{html.escape(x.marker)}</td><td>{link(x)}</td>"
        f"<td>{x.kind}</td><td>{html.escape(x.size_text)}</td><td>{html.escape(x.other)}</td></tr>"
        for x in result.fixes)
    unfilled = getattr(result, "unfilled", ())
    left = "".join(
        f"<tr><td>{html.escape(x.marker)}</td><td>{link(x)}</td>"
        f"<td>{html.escape(x.size_text)}</td></tr>" for x in unfilled)
    why = "no plausible fill" if not any(x.too_long for x in unfilled) else (
        unfilled[0].why_left if all(x.too_long for x in unfilled) else "no plausible fill, or longer than --max-gap")
    left = (f"<h3>Left missing: {why} ({len(unfilled)})</h3><table><tr><th>marker</th><th>frames</th>"
            f"<th>duration, rejected fill, why</th></tr>{left}</table>") if unfilled else ""
    coincident = getattr(result, "coincident", ())
    same = "".join(
        f"<tr><td>{html.escape(x.marker)}, {html.escape(x.other)}</td><td><a class='fix' href='#' data-frame='{x.start}'>"
        f"{x.start}-{x.end - 1}</a></td><td>{html.escape(x.size_text)}</td></tr>" for x in coincident)
    same = (f"<h3>Two markers at one position, left as recorded ({len(coincident)})</h3><table><tr><th>markers</th>"
            f"<th>frames</th><th>what</th></tr>{same}</table>") if coincident else ""
    lines = result.summary()
    if review_mode or result.review:
        lines = ["review mode (--steps detect): the capture was written unchanged; the fixes below are what "
                 "cleaning would change"] + list(read) + dataclasses.replace(result, review=False).summary()
    else:
        lines = list(read) + lines
    summary = "".join(f"<li>{html.escape(s)}</li>" for s in lines)
    review_css, review_block, review_js = review_parts(review)
    head = html.escape(title or result.markers.name or "marker capture")
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    doc = f"""<!DOCTYPE html><html><head><meta charset="utf-8"><title>{head}</title>
<style>body{{font-family:sans-serif;margin:1em}}canvas{{border:1px solid #ccc;cursor:grab}}
table{{border-collapse:collapse}}td,th{{padding:2px 8px;border-bottom:1px solid #eee}}
.k{{display:inline-block;width:10px;height:10px;border-radius:5px;margin:0 4px 0 12px}}{review_css}</style></head><body>
<h2>{head}</h2><ul>{summary}</ul>
<div><button id="play">play / pause</button> <input id="frame" type="range" min="0" value="0" style="width:60%">
<span id="flabel"></span> <label><input id="follow" type="checkbox"> follow</label></div>
<p id="shown-note">{html.escape(note)}</p>
<div>drag to turn; <span class="k" style="background:#445"></span>recorded
<span class="k" style="background:#1a9850"></span>gap filled <span class="k" style="background:#d73027"></span>spike replaced
<span class="k" style="background:#f28e2b"></span>label swap undone <span class="k" style="background:#7b3294"></span>duplicate label replaced
<span class="k" style="background:#8c510a"></span>foreign stretch (another point under the label) replaced;
grey cross: the removed recorded value</div>
<canvas id="view" width="900" height="600"></canvas>
<h3>Fixes ({len(result.fixes)})</h3><table><tr><th>marker</th><th>frames</th><th>kind</th><th>size (a gap: duration, method, expected error, distance off the straight line)</th><th>swapped with / on</th></tr>{rows}</table>
{left}{same}
<script id="data" type="application/json">{payload}</script>
<script>{_SCRIPT}</script>{review_block}{review_js and f"<script>{review_js}</script>"}</body></html>"""
    with atomic_write(path, "w", encoding="utf-8") as fh:
        fh.write(doc)
    return path


def plot_marker_fixes(path, result, *, max_markers: int = 8, title: str = "") -> Path:
    """Per-marker before/after plots (PNG) of the ``max_markers`` markers with most changed samples."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io import atomic_write

    path = Path(path)
    before = np.asarray(result.original.positions, dtype=np.float64)
    after = np.asarray(result.markers.positions, dtype=np.float64)
    mm = 10.0 * result.markers.unit_cm
    changed = result.changed | result.filled
    counts = changed.sum(axis=0)
    chosen = [int(m) for m in np.argsort(-counts, kind="stable")[:max_markers] if counts[m] > 0]
    if not chosen:
        chosen = [0] if after.shape[1] else []
    t = np.arange(after.shape[0]) / result.markers.fps
    fig, axes = plt.subplots(max(len(chosen), 1), 1, figsize=(10, 1.9 * max(len(chosen), 1) + 0.6), squeeze=False,
                             sharex=True)
    colours = ("tab:red", "tab:green", "tab:blue")
    for ax, m in zip(axes[:, 0], chosen):
        for c in range(3):
            ax.plot(t, before[:, m, c] * mm, color="0.6", lw=1.6)
            ax.plot(t, after[:, m, c] * mm, color=colours[c], lw=0.8, label="xyz"[c])
        foreign = _foreign(result)
        copies = _duplicates(result) & ~foreign
        for mask, colour in ((result.filled[:, m], "tab:green"), (result.spikes[:, m], "tab:red"),
                             (result.swapped[:, m], "tab:orange"), (copies[:, m], "tab:purple"),
                             (foreign[:, m], "tab:brown")):
            d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
            for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
                ax.axvspan(t[a], t[min(b, len(t) - 1)], color=colour, alpha=0.15, lw=0)
        ax.set_ylabel(f"{result.markers.labels[m]}\nmm", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0, 0].legend(loc="upper right", fontsize=7, ncol=3)
    axes[-1, 0].set_xlabel("s")
    fig.suptitle(title or "before (grey) and after; shaded: filled (green), spike (red), swap (orange), "
                 "duplicate label (purple), foreign stretch (brown)", fontsize=9)
    fig.tight_layout()
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=90)
    plt.close(fig)
    return path
