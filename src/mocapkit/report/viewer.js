/* mocapkit cleaning report: stick-figure viewer, MDM heat map and channel plots.
 * Hand-written, no libraries, no network: everything comes from the JSON block
 * #mocapkit-data that mocapkit.report.html.write_report inlines in the page.
 * 2D canvas with a perspective projection of our own (orbit camera, y up).
 */
(function () {
  "use strict";

  var T0 = performance.now(), TIMES = {};
  var D = JSON.parse(document.getElementById("mocapkit-data").textContent);
  TIMES.parse = performance.now() - T0;
  var N = D.n, P = D.names.length, J = D.numJoints, STRIDE = D.stride, F = D.frames;
  var MISSING = -32768;
  var BIT_FLAG = 1, BIT_CHANGED = 2, BIT_MISS_O = 4, BIT_MISS_C = 8, BIT_NOT_JUDGED = 16;

  // ---- decoding ---------------------------------------------------------
  function bytes(b64) {
    var s = atob(b64), out = new Uint8Array(s.length);
    for (var i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
    return out;
  }
  // shown frame i <-> take frame: every frame (no list), or in a long take a sorted list of them
  // (every k-th frame and every frame of each change and flag); shown frame i stands for the take
  // frames frameOf(i) .. frameEnd(i) - 1 (its heat-map cell and its flags cover them all)
  var FRAMES = D.frameList ? new Int32Array(bytes(D.frameList).buffer) : null;
  function frameOf(i) { return FRAMES ? FRAMES[i] : i; }
  function frameEnd(i) { return i + 1 < N ? frameOf(i + 1) : F; }
  function indexOf(f) {
    // the shown frame that is take frame f, else the nearest shown one before it
    f = Math.floor(Number(f));
    if (!(f > 0)) return 0;  // also NaN
    if (!FRAMES) return Math.min(N - 1, f);
    var lo = 0, hi = N - 1;
    while (lo < hi) {
      var mid = (lo + hi + 1) >> 1;
      if (FRAMES[mid] <= f) lo = mid; else hi = mid - 1;
    }
    return lo;
  }
  function dequant(b64, lo, step) {
    var q = new Int16Array(bytes(b64).buffer), out = new Float32Array(q.length);
    for (var i = 0; i < q.length; i++) out[i] = q[i] === MISSING ? NaN : lo + (q[i] + 32767) * step;
    return out;
  }
  function cleanedPositions(orig) {
    if (D.pos.cleaned) return dequant(D.pos.cleaned, D.pos.lo, D.pos.step);
    // a patch: the points (flat index into (N, P)) where the cleaned motion differs
    var out = new Float32Array(orig), patch = D.pos.cleanedPatch;
    var where = new Uint32Array(bytes(patch.index).buffer), vals = dequant(patch.values, D.pos.lo, D.pos.step);
    for (var k = 0; k < where.length; k++) {
      var o = where[k] * 3;
      out[o] = vals[k * 3]; out[o + 1] = vals[k * 3 + 1]; out[o + 2] = vals[k * 3 + 2];
    }
    return out;
  }
  var POS = { original: dequant(D.pos.original, D.pos.lo, D.pos.step) };
  POS.cleaned = cleanedPositions(POS.original);
  var MDM = D.mdm ? bytes(D.mdm) : null;   // (N, J) uint8, 255 = 1.0
  var BITS = bytes(D.bits);                // (N, J)
  var UNCHECKED = D.notAnalysed || [];     // joints detection did not analyse
  var NOT_ANALYSED = new Uint8Array(J);
  UNCHECKED.forEach(function (j) { NOT_ANALYSED[j] = 1; });
  var PLOTS = D.plots.map(function (p) {
    return { joint: p.joint, channels: p.channels,
             original: dequant(p.original, p.lo, p.step), cleaned: dequant(p.cleaned, p.lo, p.step) };
  });
  TIMES.decode = performance.now() - T0;
  var plotOfJoint = {};
  PLOTS.forEach(function (p, k) { plotOfJoint[p.joint] = k; });

  // ---- state --------------------------------------------------------------
  var S = {
    index: 0, playing: false, speed: 1, overlay: false, follow: true, selected: -1,
    yaw: 0.6, pitch: 0.25, dist: 450, drawCount: 0, pos: 0, lastT: null, dirty: true
  };

  // framing, computed by mocapkit.report.view.fit_view: at the fitted distance every point of
  // every frame lies in the panel (the focal length scales with the panel's smaller side)
  var V = D.view, TRACK = new Float32Array(bytes(V.track).buffer), HIDDEN = {};
  V.hidden.forEach(function (p) { HIDDEN[p] = true; });  // points off the body: a rig's floor reference
  function fittedDist() { return V.distance[S.follow ? "follow" : "fixed"]; }
  S.follow = V.follow;
  S.dist = fittedDist();
  var target = V.centre.slice();

  // ---- DOM ----------------------------------------------------------------
  function el(tag, attrs, parent) {
    var e = document.createElement(tag);
    for (var k in attrs) {
      if (k === "text") e.textContent = attrs[k]; else e.setAttribute(k, attrs[k]);
    }
    if (parent) parent.appendChild(e);
    return e;
  }
  var app = document.getElementById("app");
  app.textContent = "";
  var summary = document.getElementById("summary");
  (function () {
    var st = D.stats, parts = [];
    parts.push(D.frames + " frames at " + fmt(D.fps) + " fps (" + (D.frames / D.fps).toFixed(2) + " s), " + J + " joints");
    // the terminal's and `info`'s words: "joint samples", singular for one
    if (st.flagged !== null) parts.push(plural(st.flagged, "flagged joint sample") + " in " + plural(st.flaggedJoints.length, "joint") +
      (st.flaggedJoints.length ? " (" + st.flaggedJoints.slice(0, 8).join(", ") + (st.flaggedJoints.length > 8 ? ", ..." : "") + ")" : ""));
    if (st.changed !== null) parts.push(plural(st.changed, "joint sample") + " changed by the cleaning");
    if (st.missingOriginal) parts.push(plural(st.missingOriginal, "missing joint sample") + " in the input");
    if (UNCHECKED.length) parts.push(UNCHECKED.length + " joint" + (UNCHECKED.length === 1 ? "" : "s") +
      " not analysed by detection (" + UNCHECKED.map(function (j) { return D.names[j]; }).join(", ") + ")");
    // frames no similar motion judged: a stretch with no change there was not checked, not found clean
    if (st.notJudged) parts.push(st.notJudged);
    summary.textContent = parts.join("; ") + ".";
    if (N < F) el("p", { "class": "note", id: "downsample-note", text: downsampleNote() }, document.querySelector("header"));
  })();
  function plural(n, word) { return n + " " + word + (n === 1 ? "" : "s"); }  // words.plural's rule
  function fmt(x) { return Math.abs(x - Math.round(x)) < 1e-9 ? String(Math.round(x)) : x.toFixed(2); }
  function ordinal(n) {
    var t = n % 100, u = n % 10;
    return n + (t >= 11 && t <= 13 ? "th" : u === 1 ? "st" : u === 2 ? "nd" : u === 3 ? "rd" : "th");
  }
  function downsampleNote() {
    // what a long take shows (mocapkit.report.html.shown_frames): the detail tiers it kept
    var m = D.margin, extra = {
      full: "every frame of each change and flag" + (m ? ", with " + m + " frame" + (m === 1 ? "" : "s") + " either side" : ""),
      runs: "every frame of each change and flag (too many to add the frames either side)",
      changes: "every frame of each change and the first frame of each flag (too many flagged frames to show them all)",
      starts: "the first frame of each change and flag (too many changed and flagged frames to show them all)",
      some: "the first frame of some of the changes and flags (too many to show them all)"
    }[D.detail];
    return "Long take: the viewer shows every " + ordinal(STRIDE) + " frame, the last one" + (extra ? " and " + extra : "") +
      " (" + N + " of " + F + "); the heat map and the flags keep the maximum over the frames from one shown frame to the next.";
  }

  var viewSec = el("section", { "class": "viewer" }, app);
  var bar = el("div", { "class": "toolbar" }, viewSec);
  var playBtn = el("button", { id: "play", type: "button", text: "Play" }, bar);
  var slider = el("input", { id: "scrub", type: "range", min: "0", max: String(Math.max(0, N - 1)), step: "1", value: "0",
                             "aria-label": "frame" }, bar);
  var frameLabel = el("span", { id: "frame-label", "class": "frame-label" }, bar);
  var speedLbl = el("label", { text: "speed " }, bar);
  var speedSel = el("select", { id: "speed" }, speedLbl);
  [0.1, 0.25, 0.5, 1, 2, 4].forEach(function (v) {
    var o = el("option", { value: String(v), text: v + "x" }, speedSel);
    if (v === 1) o.selected = true;
  });
  var modeBtn = el("button", { id: "mode", type: "button", text: "Overlay" }, bar);
  var followLbl = el("label", {}, bar);
  var followBox = el("input", { id: "follow", type: "checkbox" }, followLbl);
  followBox.checked = S.follow;
  followLbl.appendChild(document.createTextNode(" follow"));
  var resetBtn = el("button", { id: "reset-view", type: "button", text: "Reset view" }, bar);
  var canvas = el("canvas", { id: "viewer", "class": "viewer-canvas" }, viewSec);
  var legend = el("div", { "class": "legend" }, viewSec);
  [["original", "input"], ["cleaned", "cleaned"], ["flag", "flagged joint (this frame)"], ["sel", "selected joint"]]
    .forEach(function (x) { var s = el("span", {}, legend); el("i", { "class": "sw " + x[0] }, s); s.appendChild(document.createTextNode(x[1])); });
  el("span", { "class": "hint", text: "drag: orbit, wheel: zoom, double-click: reset, space: play/pause, arrows: step" }, legend);

  var heatSec = el("section", { "class": "heat" }, app);
  el("h2", { text: "Movement digression map" }, heatSec);
  var heatNote = el("p", { "class": "note" }, heatSec);
  heatNote.textContent = (D.has.mdm ? "Colour: MDM (0 dark to 1 bright)" : "No MDM given") +
    (D.has.flags ? "; red: flagged" : (D.has.changed ? "; red: changed by the cleaning" : "")) +
    "; grey: missing in the input" + (UNCHECKED.length || D.stats.notJudged ? "; striped: not judged by detection (" +
      (UNCHECKED.length ? "a joint not analysed" : "") + (UNCHECKED.length && D.stats.notJudged ? ", or " : "") +
      (D.stats.notJudged ? "frames with no similar motion to judge them against" : "") + "; not checked, no MDM)" : "") +
    ". Click a cell to jump to that frame and select that joint.";
  var heat = el("canvas", { id: "heatmap", "class": "heat-canvas" }, heatSec);

  var plotSec = el("section", { "class": "plots" }, app);
  el("h2", { text: "Channels before / after" }, plotSec);
  el("p", { "class": "note", text: PLOTS.length ?
    "Rotation channels (degrees, as the file gives them) of the flagged or changed joints: input wide and faint, cleaned thin; shaded: flagged or changed frames. Click a plot to jump." :
    "No joint was flagged or changed." }, plotSec);
  var selPlotBox = el("div", { id: "selected-plot" }, plotSec);
  var plotBox = el("div", { id: "plot-list" }, plotSec);
  var plotCanvases = PLOTS.map(function (p, k) {
    var wrap = el("div", { "class": "plot", "data-joint": D.names[p.joint] }, plotBox);
    el("div", { "class": "plot-title", text: D.names[p.joint] + ": " + p.channels.join(", ") + " (deg)" }, wrap);
    var c = el("canvas", { "class": "plot-canvas" }, wrap);
    c.addEventListener("click", function (ev) { onPlotClick(ev, c, p.joint); });
    return { wrap: wrap, canvas: c, cache: null, joint: p.joint };
  });
  var selPlot = null; // root-relative position plot of a selected joint that has no channel plot

  // ---- camera and projection --------------------------------------------
  function camera(w, h) {
    var cp = Math.cos(S.pitch);
    var eye = [target[0] + S.dist * cp * Math.sin(S.yaw), target[1] + S.dist * Math.sin(S.pitch),
               target[2] + S.dist * cp * Math.cos(S.yaw)];
    var f = norm([target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]]);
    var r = norm(cross(f, [0, 1, 0]));
    var u = cross(r, f);
    return { eye: eye, f: f, r: r, u: u, cx: w / 2, cy: h / 2, focal: 0.5 * Math.min(w, h) / Math.tan(V.halfFov),
             near: 0.01 * V.radius.fixed };
  }
  function norm(v) { var l = Math.hypot(v[0], v[1], v[2]) || 1; return [v[0] / l, v[1] / l, v[2] / l]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function project(cam, x, y, z, ox) {
    var dx = x - cam.eye[0], dy = y - cam.eye[1], dz = z - cam.eye[2];
    var zc = dx * cam.f[0] + dy * cam.f[1] + dz * cam.f[2];
    if (!(zc > cam.near)) return null; // behind the camera, or NaN
    var xc = dx * cam.r[0] + dy * cam.r[1] + dz * cam.r[2];
    var yc = dx * cam.u[0] + dy * cam.u[1] + dz * cam.u[2];
    return [ox + cam.cx + cam.focal * xc / zc, cam.cy - cam.focal * yc / zc, zc];
  }

  function updateTarget() {
    target = S.follow ? [TRACK[2 * S.index], V.trackHeight, TRACK[2 * S.index + 1]] : V.centre.slice();
  }

  // ---- drawing: viewer -----------------------------------------------------
  var COL = { original: "#3b6fc4", cleaned: "#2b9348", flag: "#e03131", sel: "#f59f00", grid: "#d0d4da" };

  function innerWidth(sec) {
    // content width of a section (its padding excluded), so canvases never overflow it
    var cs = getComputedStyle(sec);
    var w = sec.clientWidth - parseFloat(cs.paddingLeft || 0) - parseFloat(cs.paddingRight || 0);
    return Math.max(200, Math.floor(w || 800));
  }
  function sizeCanvas(c, cssW, cssH) {
    var dpr = window.devicePixelRatio || 1;
    c.style.width = cssW + "px"; c.style.height = cssH + "px";
    var w = Math.round(cssW * dpr), h = Math.round(cssH * dpr);
    if (c.width !== w || c.height !== h) { c.width = w; c.height = h; }
    var ctx = c.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    return ctx;
  }

  function drawGrid(ctx, cam, ox) {
    var step = V.gridStep, span = V.gridSpan[S.follow ? "follow" : "fixed"];
    var gx = Math.round(target[0] / step) * step, gz = Math.round(target[2] / step) * step, y = V.floor;
    ctx.strokeStyle = COL.grid; ctx.lineWidth = 1;
    ctx.beginPath();
    for (var k = -span; k <= span; k += step) {
      seg(ctx, cam, ox, [gx + k, y, gz - span], [gx + k, y, gz + span]);
      seg(ctx, cam, ox, [gx - span, y, gz + k], [gx + span, y, gz + k]);
    }
    ctx.stroke();
  }
  function seg(ctx, cam, ox, a, b) {
    // split into pieces so that lines crossing near the camera stay sane
    var n = 6, prev = null;
    for (var t = 0; t <= n; t++) {
      var s = t / n, p = project(cam, a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s, a[2] + (b[2] - a[2]) * s, ox);
      if (p && prev) { ctx.moveTo(prev[0], prev[1]); ctx.lineTo(p[0], p[1]); }
      prev = p;
    }
  }

  function drawSkeleton(ctx, cam, ox, which, colour, alpha, dashed) {
    var a = POS[which], base = S.index * P * 3, pts = new Array(P);
    for (var p = 0; p < P; p++) {
      var o = base + p * 3;
      pts[p] = HIDDEN[p] ? null : project(cam, a[o], a[o + 1], a[o + 2], ox);
    }
    var rowBits = S.index * J;
    ctx.globalAlpha = alpha;
    ctx.lineCap = "round";
    ctx.setLineDash(dashed ? [6, 4] : []);
    // bones: the bone from joint p's parent to p is moved by the parent's rotation
    for (p = 1; p < P; p++) {
      var q = D.parents[p];
      if (q < 0 || !pts[p] || !pts[q]) continue; // missing joint: a gap, not a line to nowhere
      var flagged = q < J && (BITS[rowBits + q] & BIT_FLAG);
      ctx.strokeStyle = flagged ? COL.flag : colour;
      ctx.lineWidth = flagged ? 4 : 3;
      ctx.beginPath(); ctx.moveTo(pts[q][0], pts[q][1]); ctx.lineTo(pts[p][0], pts[p][1]); ctx.stroke();
    }
    ctx.setLineDash([]);
    for (p = 0; p < J; p++) {
      if (!pts[p]) continue;
      var fl = BITS[rowBits + p] & BIT_FLAG;
      ctx.fillStyle = fl ? COL.flag : colour;
      ctx.beginPath(); ctx.arc(pts[p][0], pts[p][1], fl ? 5 : 2.5, 0, 2 * Math.PI); ctx.fill();
    }
    ctx.globalAlpha = 1;
    if (S.selected >= 0 && pts[S.selected]) {
      ctx.strokeStyle = COL.sel; ctx.lineWidth = 2.5;
      ctx.beginPath(); ctx.arc(pts[S.selected][0], pts[S.selected][1], 10, 0, 2 * Math.PI); ctx.stroke();
    }
  }

  function drawViewer() {
    var w = innerWidth(viewSec), h = Math.max(280, Math.min(540, Math.round(w * 0.5)));
    var ctx = sizeCanvas(canvas, w, h);
    ctx.fillStyle = "#ffffff"; ctx.fillRect(0, 0, w, h);
    updateTarget();
    if (S.overlay) {
      var cam = camera(w, h);
      drawGrid(ctx, cam, 0);
      drawSkeleton(ctx, cam, 0, "original", COL.original, 0.55, true);
      drawSkeleton(ctx, cam, 0, "cleaned", COL.cleaned, 1, false);
      label(ctx, 10, "input (dashed) + cleaned");
    } else {
      var half = w / 2, cam2 = camera(half, h);
      ctx.save(); ctx.beginPath(); ctx.rect(0, 0, half, h); ctx.clip();
      drawGrid(ctx, cam2, 0); drawSkeleton(ctx, cam2, 0, "original", COL.original, 1, false);
      ctx.restore();
      ctx.save(); ctx.beginPath(); ctx.rect(half, 0, half, h); ctx.clip();
      drawGrid(ctx, cam2, half); drawSkeleton(ctx, cam2, half, "cleaned", COL.cleaned, 1, false);
      ctx.restore();
      ctx.strokeStyle = "#adb5bd"; ctx.beginPath(); ctx.moveTo(half, 0); ctx.lineTo(half, h); ctx.stroke();
      label(ctx, 10, "input"); label(ctx, half + 10, "cleaned");
    }
    if (S.selected >= 0) {
      ctx.fillStyle = COL.sel; ctx.font = "12px sans-serif";
      ctx.fillText("selected: " + D.names[S.selected], 10, h - 10);
    }
    S.drawCount++;
  }
  function label(ctx, x, text) { ctx.fillStyle = "#495057"; ctx.font = "13px sans-serif"; ctx.fillText(text, x, 18); }

  // ---- drawing: heat map ---------------------------------------------------
  var H = { left: 0, top: 6, width: 0, height: 0, rowHeight: 10, cache: null, cssW: 0 };
  var LUT = (function () { // a viridis-like ramp, 256 entries
    var stops = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]], out = [];
    for (var i = 0; i < 256; i++) {
      var t = i / 255 * (stops.length - 1), k = Math.min(stops.length - 2, Math.floor(t)), f = t - k;
      out.push([0, 1, 2].map(function (c) { return Math.round(stops[k][c] + (stops[k + 1][c] - stops[k][c]) * f); }));
    }
    return out;
  })();

  function layoutHeat() {
    var w = innerWidth(heatSec);
    H.rowHeight = Math.max(6, Math.min(14, Math.floor(360 / J)));
    var fontPx = Math.min(11, H.rowHeight);
    var m = heat.getContext("2d");
    m.font = fontPx + "px sans-serif";
    var lw = 0;
    for (var j = 0; j < J; j++) lw = Math.max(lw, m.measureText(D.names[j]).width);
    H.font = fontPx;
    H.left = Math.ceil(lw) + 8;
    H.width = Math.max(50, w - H.left - 10);
    H.height = H.rowHeight * J;
    H.cssW = w;
    H.cssH = H.top + H.height + 30;
    H.cache = buildHeatImage();
  }

  function buildHeatImage() {
    var W = Math.max(1, Math.round(H.width)), off = document.createElement("canvas");
    off.width = W; off.height = J;
    var ctx = off.getContext("2d"), img = ctx.createImageData(W, J), px = img.data;
    var red = D.has.flags ? BIT_FLAG : (D.has.changed ? BIT_CHANGED : 0);
    for (var c = 0; c < W; c++) {
      // the take frames of column c, and the shown frames whose spans meet them
      var f0 = Math.floor(c * F / W), f1 = Math.max(f0 + 1, Math.floor((c + 1) * F / W));
      var i0 = indexOf(f0), i1 = indexOf(f1 - 1) + 1;
      for (var j = 0; j < J; j++) {
        var v = 0, b = 0;
        for (var i = i0; i < i1; i++) {
          if (MDM && MDM[i * J + j] > v) v = MDM[i * J + j];
          b |= BITS[i * J + j];
        }
        var rgb = LUT[v];
        if (red && (b & red)) rgb = [Math.round(rgb[0] * 0.2 + 224 * 0.8), Math.round(rgb[1] * 0.2 + 49 * 0.8), Math.round(rgb[2] * 0.2 + 49 * 0.8)];
        else if ((b & BIT_MISS_O) && !v) rgb = [190, 190, 190];
        else if (NOT_ANALYSED[j] || ((b & BIT_NOT_JUDGED) && !v)) rgb = (c >> 2) % 2 ? [222, 226, 230] : [173, 181, 189];  // striped: not checked
        var o = (j * W + c) * 4;
        px[o] = rgb[0]; px[o + 1] = rgb[1]; px[o + 2] = rgb[2]; px[o + 3] = 255;
      }
    }
    ctx.putImageData(img, 0, 0);
    return off;
  }

  function niceStep(range, pixels, minGap) {
    var raw = range * minGap / Math.max(1, pixels), p = Math.pow(10, Math.floor(Math.log10(Math.max(raw, 1e-9))));
    var steps = [1, 2, 5, 10];
    for (var k = 0; k < steps.length; k++) if (steps[k] * p >= raw) return steps[k] * p;
    return 10 * p;
  }

  function drawHeat() {
    if (!H.cache || H.cssW !== innerWidth(heatSec)) layoutHeat();
    var ctx = sizeCanvas(heat, H.cssW, H.cssH);
    ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, H.cssW, H.cssH);
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(H.cache, H.left, H.top, H.width, H.height);
    ctx.font = H.font + "px sans-serif"; ctx.textBaseline = "middle"; ctx.textAlign = "right";
    var every = H.rowHeight >= 9 ? 1 : 2;
    for (var j = 0; j < J; j += every) {
      ctx.fillStyle = j === S.selected ? COL.sel : "#343a40";
      ctx.fillText(D.names[j], H.left - 4, H.top + (j + 0.5) * H.rowHeight);
    }
    if (S.selected >= 0 && every > 1) {
      ctx.fillStyle = COL.sel; ctx.fillText(D.names[S.selected], H.left - 4, H.top + (S.selected + 0.5) * H.rowHeight);
    }
    // frame ticks in the take's own frame numbers
    ctx.textAlign = "center"; ctx.textBaseline = "top"; ctx.fillStyle = "#343a40"; ctx.strokeStyle = "#343a40";
    var step = niceStep(F, H.width, 70), y0 = H.top + H.height;
    ctx.beginPath();
    for (var f = 0; f < F; f += step) {
      var x = H.left + f / F * H.width;
      ctx.moveTo(x, y0); ctx.lineTo(x, y0 + 4);
      ctx.fillText(String(f), x, y0 + 6);
    }
    ctx.stroke();
    ctx.textAlign = "left"; ctx.fillText("frame", H.left + H.width - 30, y0 + 18);
    // highlights: selected row, current frame
    if (S.selected >= 0) {
      ctx.strokeStyle = COL.sel; ctx.lineWidth = 2;
      ctx.strokeRect(H.left - 1, H.top + S.selected * H.rowHeight - 1, H.width + 2, H.rowHeight + 2);
    }
    var f0 = frameOf(S.index), f1 = frameEnd(S.index), cx = H.left + (f0 + f1) / 2 / F * H.width;
    ctx.strokeStyle = "#ffffff"; ctx.lineWidth = 3;
    ctx.beginPath(); ctx.moveTo(cx, H.top); ctx.lineTo(cx, y0); ctx.stroke();
    ctx.strokeStyle = "#000000"; ctx.lineWidth = 1;
    ctx.beginPath(); ctx.moveTo(cx, H.top); ctx.lineTo(cx, y0); ctx.stroke();
    if (S.selected >= 0) {
      ctx.strokeStyle = COL.sel; ctx.lineWidth = 2;
      var cw = Math.max(3, (f1 - f0) / F * H.width);
      ctx.strokeRect(cx - cw / 2, H.top + S.selected * H.rowHeight, cw, H.rowHeight);
    }
  }

  function canvasXY(ev, c) {
    var r = c.getBoundingClientRect();
    return [ev.clientX - r.left, ev.clientY - r.top];
  }
  heat.addEventListener("click", function (ev) {
    var xy = canvasXY(ev, heat), W = Math.max(1, Math.round(H.width));
    // multiply first: (x / width) * W rounds a click on the left edge of column c (x = c) into column c - 1
    var c = Math.floor((xy[0] - H.left) * W / H.width), j = Math.floor((xy[1] - H.top) / H.rowHeight);
    if (c < 0 || c >= W || j < 0 || j >= J) return;
    select(j);
    setIndex(cellIndex(c, W, j, Math.floor((xy[0] - H.left) / H.width * F)));
  });
  function cellIndex(c, W, j, under) {
    // where a click on the cell (column c of W, joint j) lands: a column of a long take holds many frames,
    // so on what made the cell red (its first flagged, else changed, frame for j), else on its most
    // digressing frame for j, else on the frame under the pointer
    var f0 = Math.floor(c * F / W), f1 = Math.max(f0 + 1, Math.floor((c + 1) * F / W));
    var i0 = indexOf(f0), i1 = indexOf(f1 - 1) + 1;
    var red = D.has.flags ? BIT_FLAG : (D.has.changed ? BIT_CHANGED : 0), first = -1, best = -1, v = 0;
    for (var i = i0; i < i1; i++) {
      if (red && (BITS[i * J + j] & red)) {
        if (frameOf(i) >= f0) return i;  // in the column itself before a span reaching in from the column before
        if (first < 0) first = i;
      }
      if (MDM && MDM[i * J + j] > v) { v = MDM[i * J + j]; best = i; }
    }
    return first >= 0 ? first : best >= 0 ? best : indexOf(Math.min(Math.max(under, f0), f1 - 1));
  }

  // ---- drawing: channel plots ----------------------------------------------
  var CH = ["#1c7ed6", "#e8590c", "#7048e8", "#0ca678", "#c2255c", "#495057"];

  function renderPlot(series, joint, cssW, cssH) {
    // series: {original: [Float32Array per channel], cleaned: [...], labels, wrap (degrees)}
    var off = document.createElement("canvas"), dpr = window.devicePixelRatio || 1;
    off.width = Math.round(cssW * dpr); off.height = Math.round(cssH * dpr);
    var ctx = off.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    var L = 46, R = 8, T = 6, B = 18, pw = cssW - L - R, ph = cssH - T - B;
    var lo = Infinity, hi = -Infinity;
    [series.original, series.cleaned].forEach(function (set) {
      set.forEach(function (a) { for (var i = 0; i < a.length; i++) if (a[i] === a[i]) { if (a[i] < lo) lo = a[i]; if (a[i] > hi) hi = a[i]; } });
    });
    if (!isFinite(lo)) { lo = -1; hi = 1; }
    if (hi - lo < 1e-6) { lo -= 1; hi += 1; }
    var pad = (hi - lo) * 0.06; lo -= pad; hi += pad;
    ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, cssW, cssH);
    // flagged / changed frames of this joint
    ctx.fillStyle = "rgba(224,49,49,0.13)";
    for (var i = 0; i < N; i++) {  // one rectangle per run of marked frames
      if (!(BITS[i * J + joint] & (BIT_FLAG | BIT_CHANGED))) continue;
      var i1 = i;
      while (i1 + 1 < N && (BITS[(i1 + 1) * J + joint] & (BIT_FLAG | BIT_CHANGED))) i1++;
      ctx.fillRect(L + frameOf(i) / F * pw, T, Math.max(1, (frameEnd(i1) - frameOf(i)) / F * pw), ph);
      i = i1;
    }
    ctx.strokeStyle = "#ced4da"; ctx.lineWidth = 1; ctx.strokeRect(L, T, pw, ph);
    ctx.fillStyle = "#495057"; ctx.font = "10px sans-serif"; ctx.textAlign = "right"; ctx.textBaseline = "middle";
    var ys = niceStep(hi - lo, ph, 28);
    ctx.beginPath();
    for (var v = Math.ceil(lo / ys) * ys; v <= hi; v += ys) {
      var y = T + (hi - v) / (hi - lo) * ph;
      ctx.fillText(String(Math.round(v * 100) / 100), L - 4, y);
      ctx.moveTo(L, y); ctx.lineTo(L + 4, y);
    }
    ctx.stroke();
    ctx.textAlign = "center"; ctx.textBaseline = "top";
    var fs = niceStep(F, pw, 70);
    for (var f = 0; f < F; f += fs) ctx.fillText(String(f), L + f / F * pw, T + ph + 3);
    function line(a, colour, faint, width) {
      // the input is drawn faint and wide under the cleaned line: dashes on a 7200-point path
      // cost Skia a second per page, and where the two agree the cleaned line covers the input
      ctx.strokeStyle = colour; ctx.lineWidth = width; ctx.globalAlpha = faint ? 0.35 : 1;
      ctx.beginPath();
      var keep = decimate(a, pw), pen = false, prev = NaN;
      for (var k = 0; k < keep.length; k++) {
        var i = keep[k], v = a[i];
        if (v !== v) { pen = false; prev = v; continue; }
        var x = L + (frameOf(i) + 0.5) / F * pw, yv = T + (hi - v) / (hi - lo) * ph;
        // an Euler channel wrapping at +-180 deg is a jump, not a line across the plot
        if (pen && !(series.wrap && Math.abs(v - prev) > series.wrap)) ctx.lineTo(x, yv); else ctx.moveTo(x, yv);
        pen = true; prev = v;
      }
      ctx.stroke();
      ctx.globalAlpha = 1;
    }
    series.original.forEach(function (a, k) { line(a, CH[k % CH.length], true, 3); });
    series.cleaned.forEach(function (a, k) { line(a, CH[k % CH.length], false, 1.6); });
    ctx.textAlign = "left"; ctx.textBaseline = "top"; ctx.font = "10px sans-serif";
    var lx = L + 6;
    series.labels.forEach(function (name, k) {
      ctx.fillStyle = CH[k % CH.length]; ctx.fillText(name, lx, T + 3); lx += ctx.measureText(name).width + 10;
    });
    ctx.fillStyle = "#868e96"; ctx.fillText("wide faint: input, thin: cleaned", lx + 6, T + 3);
    return { image: off, L: L, pw: pw, T: T, ph: ph, cssW: cssW, cssH: cssH };
  }

  function decimate(a, pw) {
    // indices to draw: all of them when there are few; else per pixel column the first, the
    // lowest, the highest and the last sample (in time order) and every NaN boundary, so the
    // envelope and the gaps look as with every sample, at a few points per pixel. Columns are
    // spans of take frames (shown frames are not evenly spaced in a long take)
    var n = a.length, cols = Math.max(1, Math.floor(pw));
    if (n <= 2 * cols) { var all = new Array(n); for (var q = 0; q < n; q++) all[q] = q; return all; }
    var out = [], i1 = 0;
    for (var c = 0; c < cols && i1 < n; c++) {
      // column c: the shown frames after column c - 1's with frameOf(i) + 1 <= (c + 1) * F / cols
      var i0 = i1;
      while (i1 < n && (frameOf(i1) + 1) * cols <= (c + 1) * F) i1++;
      if (i1 === i0) continue;
      var lo = -1, hi = -1, gap = false;
      for (var i = i0; i < i1; i++) {
        var v = a[i];
        if (v !== v) { gap = true; continue; }
        if (lo < 0 || v < a[lo]) lo = i;
        if (hi < 0 || v > a[hi]) hi = i;
      }
      if (gap) { for (i = i0; i < i1; i++) out.push(i); continue; }
      var pick = [i0, lo, hi, i1 - 1].sort(function (u, v) { return u - v; });
      for (var k = 0; k < 4; k++) if (!k || pick[k] !== pick[k - 1]) out.push(pick[k]);
    }
    return out;
  }

  function channelSeries(k) {
    var p = PLOTS[k], C = p.channels.length, o = [], c = [];
    for (var ch = 0; ch < C; ch++) {
      var a = new Float32Array(N), b = new Float32Array(N);
      for (var i = 0; i < N; i++) { a[i] = p.original[i * C + ch]; b[i] = p.cleaned[i * C + ch]; }
      o.push(a); c.push(b);
    }
    return { original: o, cleaned: c, labels: p.channels, wrap: 180 };
  }
  function positionSeries(j) {
    // the joint's position relative to the root (cm): errors show, walking does not
    var o = [], c = [];
    ["original", "cleaned"].forEach(function (which, w) {
      var a = POS[which];
      for (var ax = 0; ax < 3; ax++) {
        var s = new Float32Array(N);
        for (var i = 0; i < N; i++) s[i] = a[(i * P + j) * 3 + ax] - a[(i * P) * 3 + ax];
        (w ? c : o).push(s);
      }
    });
    return { original: o, cleaned: c, labels: ["x", "y (up)", "z"], wrap: 0 };
  }

  function drawPlotCursor(canvasEl, cache) {
    var ctx = sizeCanvas(canvasEl, cache.cssW, cache.cssH);
    ctx.drawImage(cache.image, 0, 0, cache.cssW, cache.cssH);
    var x = cache.L + (frameOf(S.index) + 0.5) / F * cache.pw;
    ctx.strokeStyle = "#000"; ctx.lineWidth = 1;
    ctx.beginPath(); ctx.moveTo(x, cache.T); ctx.lineTo(x, cache.T + cache.ph); ctx.stroke();
  }

  var plotW = 0;
  function drawPlots() {
    var w = innerWidth(plotSec) - 2;
    if (w !== plotW) { plotW = w; plotCanvases.forEach(function (pc) { pc.cache = null; }); if (selPlot) selPlot.cache = null; }
    // rasterising a 7200-frame plot costs tens of ms in software: render the missing ones a few
    // per animation frame (the selected joint's first) so the viewer shows without waiting for them
    var t0 = performance.now(), pending = false;
    function ensure(pc, series) {
      if (!pc.cache) {
        if (performance.now() - t0 > 40) { sizeCanvas(pc.canvas, w, 130); pending = true; return false; }
        pc.cache = renderPlot(series(), pc.joint, w, 130);
      }
      drawPlotCursor(pc.canvas, pc.cache);
      return true;
    }
    if (selPlot) ensure(selPlot, function () { return positionSeries(selPlot.joint); });
    plotCanvases.forEach(function (pc, k) {
      ensure(pc, function () { return channelSeries(k); });
      pc.wrap.classList.toggle("selected", PLOTS[k].joint === S.selected);
    });
    if (pending) setTimeout(invalidate, 0);
    else if (TIMES.plotsDone === undefined) TIMES.plotsDone = performance.now() - T0;
  }
  function onPlotClick(ev, c, joint) {
    var pc = plotCanvases.filter(function (x) { return x.canvas === c; })[0];
    var cache = pc ? pc.cache : selPlot && selPlot.cache;
    if (!cache) return;
    var xy = canvasXY(ev, c), f = Math.floor((xy[0] - cache.L) / cache.pw * F);
    if (f >= 0 && f < F) { select(joint); setIndex(indexOf(f)); }
  }

  // ---- state changes -------------------------------------------------------
  function select(j) {
    if (j === S.selected) return;
    S.selected = j;
    selPlotBox.textContent = "";
    selPlot = null;
    if (j >= 0) {
      var wrap = el("div", { "class": "plot selected", "data-joint": D.names[j] }, selPlotBox);
      el("div", { "class": "plot-title", text: "selected " + D.names[j] + ": position relative to the root (cm)" }, wrap);
      var c = el("canvas", { "class": "plot-canvas" }, wrap);
      selPlot = { joint: j, canvas: c, cache: null };
      c.addEventListener("click", function (ev) { onPlotClick(ev, c, j); });
    }
    invalidate();
  }
  function setIndex(i) {
    i = Math.max(0, Math.min(N - 1, Math.round(Number(i)) || 0));
    S.index = i; S.pos = frameOf(i);
    slider.value = String(i);
    invalidate();
  }
  function invalidate() {
    if (!S.dirty) { S.dirty = true; requestAnimationFrame(frame); }
  }
  function redraw() {
    var f = frameOf(S.index);
    frameLabel.textContent = "frame " + f + " / " + (F - 1) + "  (" + (f / D.fps).toFixed(2) + " s)";
    var t0 = performance.now();
    drawViewer();
    var t1 = performance.now();
    drawHeat();
    var t2 = performance.now();
    drawPlots();
    var t3 = performance.now();
    if (TIMES.viewer === undefined) { TIMES.viewer = t1 - t0; TIMES.heat = t2 - t1; TIMES.plots = t3 - t2; }
    S.dirty = false;
  }
  function frame(t) {
    if (S.playing) {
      if (S.lastT !== null) {
        // S.pos is in take frames: real time, every frame of the detail, the rest at the stride
        S.pos += (t - S.lastT) / 1000 * D.fps * S.speed;
        if (S.pos >= F) S.pos = S.pos % F;
        S.index = indexOf(S.pos);
        slider.value = String(S.index);
      }
      S.lastT = t;
      redraw();
      requestAnimationFrame(frame);
    } else if (S.dirty) {
      redraw();
    }
  }
  function play(on) {
    if (on === S.playing) return;
    S.playing = on; S.lastT = null;
    playBtn.textContent = on ? "Pause" : "Play";
    if (on) requestAnimationFrame(frame);
  }

  // ---- input ----------------------------------------------------------------
  playBtn.addEventListener("click", function () { play(!S.playing); });
  slider.addEventListener("input", function () { play(false); setIndex(slider.value); });
  speedSel.addEventListener("change", function () { S.speed = Number(speedSel.value) || 1; });
  modeBtn.addEventListener("click", function () {
    S.overlay = !S.overlay; modeBtn.textContent = S.overlay ? "Side by side" : "Overlay"; invalidate();
  });
  followBox.addEventListener("change", function () { S.follow = followBox.checked; S.dist = fittedDist(); invalidate(); });
  function resetView() { S.yaw = 0.6; S.pitch = 0.25; S.dist = fittedDist(); invalidate(); }
  resetBtn.addEventListener("click", resetView);
  canvas.addEventListener("dblclick", resetView);
  var drag = null;
  canvas.addEventListener("pointerdown", function (ev) { drag = [ev.clientX, ev.clientY]; canvas.setPointerCapture(ev.pointerId); });
  canvas.addEventListener("pointermove", function (ev) {
    if (!drag) return;
    S.yaw -= (ev.clientX - drag[0]) * 0.01;
    S.pitch = Math.max(-1.45, Math.min(1.45, S.pitch + (ev.clientY - drag[1]) * 0.01));
    drag = [ev.clientX, ev.clientY];
    invalidate();
  });
  function endDrag() { drag = null; }
  canvas.addEventListener("pointerup", endDrag);
  canvas.addEventListener("pointercancel", endDrag);
  canvas.addEventListener("wheel", function (ev) {
    ev.preventDefault();
    var d0 = fittedDist();
    S.dist = Math.max(0.2 * d0, Math.min(50 * d0, S.dist * Math.exp(ev.deltaY * 0.001)));
    invalidate();
  }, { passive: false });
  document.addEventListener("keydown", function (ev) {
    var tag = ev.target && ev.target.tagName;
    if (tag === "INPUT" || tag === "SELECT" || tag === "BUTTON" || tag === "TEXTAREA") return;
    if (ev.key === " ") { ev.preventDefault(); play(!S.playing); }
    else if (ev.key === "ArrowRight") { play(false); setIndex(S.index + 1); }
    else if (ev.key === "ArrowLeft") { play(false); setIndex(S.index - 1); }
  });
  window.addEventListener("resize", function () { H.cache = null; invalidate(); });

  // ---- API for tests and for people at the console ----------------------------
  window.mocapkitReport = {
    frame: function () { return frameOf(S.index); },         // frame number in the take
    index: function () { return S.index; },                  // frame index in the viewer (into shownFrames())
    setFrame: function (f) { play(false); setIndex(indexOf(f)); redraw(); },  // f, or the shown frame before it
    setIndex: function (i) { play(false); setIndex(i); redraw(); },
    selectedJoint: function () { return S.selected; },
    selectedJointName: function () { return S.selected >= 0 ? D.names[S.selected] : null; },
    select: function (j) { select(typeof j === "string" ? D.names.indexOf(j) : j); redraw(); },
    drawCount: function () { return S.drawCount; },
    play: function () { play(true); },
    pause: function () { play(false); },
    playing: function () { return S.playing; },
    overlay: function (on) { if (on !== undefined) { S.overlay = !!on; redraw(); } return S.overlay; },
    position: function (which, f, j) {                       // cm, y up, as drawn at take frame f; null when missing
      var o = ((indexOf(f) * P) + j) * 3, a = POS[which];
      return [a[o], a[o + 1], a[o + 2]].map(function (v) { return v === v ? v : null; });
    },
    heatmapLayout: function () { return { left: H.left, top: H.top, width: H.width, height: H.height, rowHeight: H.rowHeight, frames: F, joints: J }; },
    shownFrames: function () { var out = new Array(N); for (var i = 0; i < N; i++) out[i] = frameOf(i); return out; },
    timings: TIMES,                                          // ms since the script started
    info: { frames: F, shown: N, stride: STRIDE, detail: D.detail, fps: D.fps, joints: J, names: D.names.slice(0, J), plots: PLOTS.map(function (p) { return D.names[p.joint]; }) }
  };
  TIMES.setup = performance.now() - T0;
  redraw();
  TIMES.firstDraw = performance.now() - T0;
  TIMES.scriptStart = T0;                                    // ms since navigation start
})();
