"""Reports of a cleaned marker capture: a playable 3-D marker viewer (HTML) and per-marker before/after plots (PNG).

:func:`write_marker_report` writes one self-contained HTML file (no network:
the script and data are inline): the markers as points, drag to turn the
view, a frame slider and a play button; a sample that was filled is drawn
green, a removed spike's fill red, a re-labelled (swapped) sample orange,
and the input's bad value of a spike as a small grey cross; the list of
fixes (marker, frames, kind, size in mm) below, each a link to its first
frame. :func:`plot_marker_fixes` draws, for the markers with most changes,
their three coordinates before (grey) and after (colour) with the changed
frames shaded. Both read a :class:`~mocapkit.cleaning.markers.MarkerCleanResult`.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

__all__ = ["write_marker_report", "plot_marker_fixes"]

_KIND_CODE = {"filled": 1, "spike": 2, "swap": 3}

_SCRIPT = r"""
const D = JSON.parse(document.getElementById('data').textContent);
const cv = document.getElementById('view'), cx = cv.getContext('2d');
const slider = document.getElementById('frame'), label = document.getElementById('flabel');
let yaw = 0.6, pitch = 0.3, playing = false, f = 0, drag = null;
const up = D.up;  // index of the vertical axis
const colours = ['#445', '#1a9850', '#d73027', '#f28e2b'];
function project(p) {
  const x = p[0] - D.centre[0], y = p[1] - D.centre[1], z = p[2] - D.centre[2];
  let h = [x, y, z]; const v = h[up]; h.splice(up, 1);
  const cy = Math.cos(yaw), sy = Math.sin(yaw);
  const a = h[0] * cy - h[1] * sy, b = h[0] * sy + h[1] * cy;
  const cp = Math.cos(pitch), sp = Math.sin(pitch);
  const s = 0.9 * Math.min(cv.width, cv.height) / D.extent;
  return [cv.width / 2 + a * s, cv.height / 2 - (v * cp - b * sp) * s];
}
function draw() {
  cx.clearRect(0, 0, cv.width, cv.height);
  const P = D.pos[f], K = D.kind[f], B = D.bad[f];
  for (let m = 0; m < P.length; m++) {
    if (B[m]) { const q = project(B[m]); cx.strokeStyle = '#999'; cx.beginPath();
      cx.moveTo(q[0] - 4, q[1] - 4); cx.lineTo(q[0] + 4, q[1] + 4); cx.moveTo(q[0] - 4, q[1] + 4); cx.lineTo(q[0] + 4, q[1] - 4); cx.stroke(); }
    if (!P[m]) continue;
    const q = project(P[m]);
    cx.fillStyle = colours[K[m]]; cx.beginPath(); cx.arc(q[0], q[1], K[m] ? 5 : 3.5, 0, 2 * Math.PI); cx.fill();
  }
  label.textContent = 'frame ' + D.frames[f] + ' (' + (D.frames[f] / D.fps).toFixed(2) + ' s)';
}
slider.max = D.pos.length - 1;
slider.oninput = () => { f = +slider.value; draw(); };
document.getElementById('play').onclick = () => { playing = !playing; if (playing) tick(); };
function tick() { if (!playing) return; f = (f + 1) % D.pos.length; slider.value = f; draw();
  setTimeout(() => requestAnimationFrame(tick), 1000 / D.play_fps); }
cv.onmousedown = e => { drag = [e.clientX, e.clientY]; };
window.onmouseup = () => { drag = null; };
cv.onmousemove = e => { if (!drag) return; yaw += (e.clientX - drag[0]) * 0.01;
  pitch = Math.max(-1.5, Math.min(1.5, pitch + (e.clientY - drag[1]) * 0.01)); drag = [e.clientX, e.clientY]; draw(); };
for (const a of document.querySelectorAll('a.fix')) a.onclick = e => { e.preventDefault();
  const t = +a.dataset.frame; let k = 0; while (k + 1 < D.frames.length && D.frames[k + 1] <= t) k++; f = k; slider.value = f; draw(); };
draw();
"""


def _frames(num_frames: int, max_frames: int) -> np.ndarray:
    step = max(1, int(np.ceil(num_frames / max_frames)))
    return np.arange(0, num_frames, step)


def write_marker_report(path, result, *, title: str = "", max_frames: int = 3000, up_axis: int | None = None) -> Path:
    """Write the HTML marker viewer of ``result`` (a MarkerCleanResult) to ``path``; returns the path.

    At most ``max_frames`` frames are kept (evenly spaced), positions in
    millimetres rounded to 0.1 mm. ``up_axis``: 0, 1 or 2 (default: the axis
    along which one frame's markers spread most: a standing body is tallest
    along the vertical).
    """
    from ..io import atomic_write

    path = Path(path)
    before = np.asarray(result.original.positions, dtype=np.float64)
    after = np.asarray(result.markers.positions, dtype=np.float64)
    mm = 10.0 * result.markers.unit_cm
    idx = _frames(after.shape[0], max_frames)
    kind = np.zeros(after.shape[:2], dtype=np.int8)
    kind[result.filled] = _KIND_CODE["filled"]
    kind[result.spikes] = _KIND_CODE["spike"]
    kind[result.swapped] = _KIND_CODE["swap"]
    seen = after[~np.isnan(after).any(axis=-1)]
    centre = np.nanmedian(seen, axis=0) if seen.size else np.zeros(3)
    extent = float(np.nanmax(np.ptp(seen, axis=0))) if seen.size else 1.0
    if up_axis is None:
        frame_spread = np.nanmedian(np.nanmax(after, axis=1) - np.nanmin(after, axis=1), axis=0) if seen.size else np.ones(3)
        up_axis = int(np.nanargmax(frame_spread)) if seen.size else 2  # a standing body is tallest along the vertical

    def pts(a):
        return [[None if np.isnan(p).any() else [round(float(c) * mm, 1) for c in p] for p in row] for row in a]

    bad = np.where(result.spikes[..., None], before, np.nan)
    data = {"pos": pts(after[idx]), "kind": kind[idx].tolist(), "bad": pts(bad[idx]), "frames": idx.tolist(),
            "fps": float(result.markers.fps), "play_fps": float(min(result.markers.fps / max(idx[1] - idx[0], 1)
                                                                     if idx.size > 1 else 30.0, 60.0)),
            "centre": [float(c) * mm for c in centre], "extent": max(extent * mm, 1.0), "up": up_axis}
    rows = "".join(
        f"<tr><td>{html.escape(x.marker)}</td><td><a class='fix' href='#' data-frame='{x.start}'>{x.start}-{x.end - 1}</a></td>"
        f"<td>{x.kind}</td><td>{html.escape(x.size_text)}</td><td>{html.escape(x.other)}</td></tr>"
        for x in result.fixes)
    unfilled = getattr(result, "unfilled", ())
    left = "".join(
        f"<tr><td>{html.escape(x.marker)}</td><td><a class='fix' href='#' data-frame='{x.start}'>{x.start}-{x.end - 1}</a></td>"
        f"<td>{html.escape(x.size_text)}</td></tr>" for x in unfilled)
    left = (f"<h3>Left missing: no plausible fill ({len(unfilled)})</h3><table><tr><th>marker</th><th>frames</th>"
            f"<th>duration, rejected fill, why</th></tr>{left}</table>") if unfilled else ""
    summary = "".join(f"<li>{html.escape(s)}</li>" for s in result.summary())
    head = html.escape(title or result.markers.name or "marker capture")
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    doc = f"""<!DOCTYPE html><html><head><meta charset="utf-8"><title>{head}</title>
<style>body{{font-family:sans-serif;margin:1em}}canvas{{border:1px solid #ccc;cursor:grab}}
table{{border-collapse:collapse}}td,th{{padding:2px 8px;border-bottom:1px solid #eee}}
.k{{display:inline-block;width:10px;height:10px;border-radius:5px;margin:0 4px 0 12px}}</style></head><body>
<h2>{head}</h2><ul>{summary}</ul>
<div><button id="play">play / pause</button> <input id="frame" type="range" min="0" value="0" style="width:60%">
<span id="flabel"></span></div>
<div>drag to turn; <span class="k" style="background:#445"></span>recorded
<span class="k" style="background:#1a9850"></span>gap filled <span class="k" style="background:#d73027"></span>spike replaced
<span class="k" style="background:#f28e2b"></span>label swap undone; grey cross: the spike's recorded value</div>
<canvas id="view" width="900" height="600"></canvas>
<h3>Fixes ({len(result.fixes)})</h3><table><tr><th>marker</th><th>frames</th><th>kind</th><th>size (a gap: duration, method, expected error, distance off the straight line)</th><th>swapped with</th></tr>{rows}</table>
{left}
<script id="data" type="application/json">{payload}</script>
<script>{_SCRIPT}</script></body></html>"""
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
        for mask, colour in ((result.filled[:, m], "tab:green"), (result.spikes[:, m], "tab:red"),
                             (result.swapped[:, m], "tab:orange")):
            d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
            for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
                ax.axvspan(t[a], t[min(b, len(t) - 1)], color=colour, alpha=0.15, lw=0)
        ax.set_ylabel(f"{result.markers.labels[m]}\nmm", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0, 0].legend(loc="upper right", fontsize=7, ncol=3)
    axes[-1, 0].set_xlabel("s")
    fig.suptitle(title or "before (grey) and after; shaded: filled (green), spike (red), swap (orange)", fontsize=9)
    fig.tight_layout()
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=90)
    plt.close(fig)
    return path
