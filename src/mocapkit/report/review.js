/* mocapkit cleaning report: the changes the cleaning made, each accepted or rejected by a person,
 * the flags detection raised, each with the rule that raised it, and the cuts (two takes joined), which change no
 * sample and are listed for a person to decide.
 * Reads the JSON block #mocapkit-review (mocapkit.cleaning.decisions: the changes and the
 * decisions document); absent, it does nothing. Each change has accept/reject (default accept)
 * and a link that moves the viewer to its first frame and selects its joint. The "Download
 * decisions" button saves the decisions document (a Blob download, no server) for
 * `mocapkit clean IN -o OUT --decisions FILE.json --record RECORD` (RECORD: the record this cleaning wrote,
 * doc.cleaning.record; IN and the options that read the take as reviewed, --asf, --amc-fps, --unit: R.command).
 */
(function () {
  "use strict";
  var block = document.getElementById("mocapkit-review");
  if (!block) return;
  var R = JSON.parse(block.textContent);
  var doc = R.decisions, list = R.changes;
  var item = R.item || "joint";  // what a change moves: a joint, or a marker of a marker capture

  function el(tag, attrs, parent) {
    var e = document.createElement(tag);
    for (var k in attrs) {
      if (k === "text") e.textContent = attrs[k]; else e.setAttribute(k, attrs[k]);
    }
    if (parent) parent.appendChild(e);
    return e;
  }
  var sec = el("section", { "class": "changes", id: "changes" }, document.getElementById("app") || document.body);
  var flags = R.flags || [];
  var cuts = R.cuts || [];  // where two takes were joined: named for a person to decide, no sample changed for them
  el("h2", { text: "Changes (" + list.length + ")" }, sec);
  var frameNote = R.frames ? " " + R.frames.charAt(0).toUpperCase() + R.frames.slice(1) + "." : "";
  var count = null;
  if (list.length) {
    el("p", { "class": "note", id: "apply-command", text: "Every change the cleaning made, one " + item + " over a run of " +
      "frames. Accept or reject each one, then download the decisions and run: " + applyCommand() +
      " (the record of the cleaning shown here: the accepted changes get exactly the values reviewed, rejected " +
      "changes the input's samples back)." + frameNote }, sec);
    var bar = el("div", { "class": "toolbar" }, sec);
    var allAcc = el("button", { type: "button", id: "accept-all", text: "Accept all" }, bar);
    var allRej = el("button", { type: "button", id: "reject-all", text: "Reject all" }, bar);
    var dl = el("button", { type: "button", id: "download-decisions", text: "Download decisions" }, bar);
    count = el("span", { id: "decision-count", "class": "note" }, bar);
  } else {  // nothing to accept, reject or download: no buttons that would do nothing
    el("p", { "class": "note", id: "nothing-to-decide", text: "Nothing to decide: the cleaning changed no sample, so " +
      "there is nothing to accept or reject and no decisions to download" + (flags.length ?
      " (review mode, --steps detect, only flags: the flags below are what detection found)." : ".") +
      (cuts.length ? " The cuts below change no sample either: they are named for you to decide about." : "") +
      frameNote }, sec);
  }

  var rows = [];
  if (list.length) {
    var table = el("table", {}, sec), head = el("tr", {}, el("thead", {}, table));
    ["", item, "frames", "step", "max change", "why", ""].forEach(function (h) { el("th", { text: h }, head); });
    var body = el("tbody", {}, table);
    list.forEach(function (c, k) {
      var tr = el("tr", { "data-change": c.id }, body);
      var td = el("td", { "class": "choice" }, tr);
      var lab = el("label", {}, td);
      var box = el("input", { type: "checkbox", "class": "accept", "data-index": String(k), "aria-label": "accept " + c.id }, lab);
      lab.appendChild(document.createTextNode(" accept"));
      box.checked = doc.decisions[c.id] !== "reject";
      box.addEventListener("change", function () { set(k, box.checked); });
      el("td", { text: c.joint }, tr);
      el("td", { "class": "num", text: c.first === c.last ? String(c.first) : c.first + "-" + c.last }, tr);
      el("td", { text: c.step, title: c.method }, tr);
      el("td", { "class": "num", text: c.size !== undefined ? c.size : c.max_deg === null ? "was missing" : (c.max_deg >= 0.1 || c.max_deg === 0 ? c.max_deg.toFixed(1) : c.max_deg.toPrecision(2)) + " deg" }, tr);
      var others = (c.tied || []).filter(function (id) { return id !== c.id; });
      var why = el("td", { "class": "reason", text: (c.plain ? c.plain + " " : "") }, tr);
      // the detector's words stay, as the detail of the sentence
      el("span", { "class": "detail", text: (c.plain ? "(" + c.reason + ")" : c.reason) + (others.length ?
        " (accepted or rejected with " + others.join(", ") + (c.tied_why ? ": " + c.tied_why : "") + ")" : "") }, why);
      var jt = el("td", { "class": "jump" }, tr);
      var jb = el("button", { type: "button", "class": "jump", "data-index": String(k), text: "jump to frame " + c.first }, jt);
      jb.addEventListener("click", function () { jump(k, true); });
      rows.push({ tr: tr, box: box });
      paint(k);
    });
  } else {
    el("p", { text: "The cleaning changed nothing." }, sec);
  }

  // the cuts: a take made of two takes joined breaks at one frame. The cleaning changes no sample for a cut (its
  // breaks confirm no repair), so a cut is no change to accept or reject: it is listed here, with its score and what
  // it means, for a person to decide (split the take there, or keep it), and said in the summary above the viewer
  if (cuts.length) {
    var csec = el("div", { "class": "cuts", id: "cuts" }, sec);
    el("h3", { text: "Cuts (" + cuts.length + ")" }, csec);
    el("p", { "class": "note", text: "Where the whole body jumps at one frame: two takes joined, or frames dropped. " +
      "The cleaning changed no sample for a cut, so there is nothing to accept or reject; you decide what to do " +
      "with the take." }, csec);
    var ctable = el("table", {}, csec), chead = el("tr", {}, el("thead", {}, ctable));
    ["frame", "score", "what it means", "what the cleaning did", ""].forEach(function (h) { el("th", { text: h }, chead); });
    var cbody = el("tbody", {}, ctable);
    cuts.forEach(function (c) {
      var tr = el("tr", { "data-cut": String(c.frame) }, cbody);
      el("td", { "class": "num", text: String(c.frame) }, tr);
      el("td", { "class": "num", text: Math.round(100 * c.share) + " % of the joints" }, tr);
      el("td", { "class": "reason", text: c.meaning }, tr);
      el("td", { "class": "outcome", text: c.did }, tr);
      var jb = el("button", { type: "button", "class": "jump", text: "jump to frame " + c.frame }, el("td", { "class": "jump" }, tr));
      jb.addEventListener("click", function () { goTo(null, c.frame); });
    });
    var said = document.getElementById("summary");
    if (said) said.textContent += " " + plural(cuts.length, "cut") + " at frame" + (cuts.length === 1 ? " " : "s ") +
      cuts.map(function (c) { return c.frame; }).join(", ") + " (two takes joined, or frames dropped): no sample " +
      "changed for " + (cuts.length === 1 ? "it" : "them") + ", listed under the changes for you to decide.";
  }
  function plural(n, word) { return n + " " + word + (n === 1 ? "" : "s"); }

  // what detection flagged, and which rule flagged it: in review mode (--steps detect) all there is to see
  if (flags.length) {
    var fsec = el("section", { "class": "changes flags", id: "flags" }, sec.parentNode);
    el("h2", { text: "Flags (" + flags.length + ")" }, fsec);
    el("p", { "class": "note", text: "What detection flagged, one joint over a run of frames, and the rule that " +
      "flagged it. The changes above are what the cleaning did about them; a flag it left as it was says why." }, fsec);
    var ftable = el("table", {}, fsec), fhead = el("tr", {}, el("thead", {}, ftable));
    ["joint", "frames", "why", "what the cleaning did", ""].forEach(function (h) { el("th", { text: h }, fhead); });
    var fbody = el("tbody", {}, ftable);
    flags.forEach(function (f) {
      var tr = el("tr", { "data-flag": f.joint + ":" + f.first + "-" + f.last }, fbody);
      el("td", { text: f.joint }, tr);
      el("td", { "class": "num", text: f.first === f.last ? String(f.first) : f.first + "-" + f.last }, tr);
      var fwhy = el("td", { "class": "reason", text: f.plain ? f.plain + " " : "" }, tr);
      el("span", { "class": "detail", text: f.plain ? "(" + f.why.join(", ") + ")" : f.why.join(", ") }, fwhy);
      // f.left: why a flag was left as it was ("" where a change above is the cleaning's answer)
      el("td", { "class": "outcome" + (f.left ? " left" : ""),
        text: f.left === undefined ? "" : (f.left || "changed: see the changes above") }, tr);
      var jb = el("button", { type: "button", "class": "jump", text: "jump to frame " + f.first }, el("td", { "class": "jump" }, tr));
      jb.addEventListener("click", function () { goTo(f.joint_index, f.first); });
    });
  }

  function paint(k) {
    rows[k].tr.className = (rows[k].box.checked ? "" : "rejected") + (k === current ? " current" : "");
  }
  // changes the cleaning ties ("tied": their ids, "tied_why": why) are accepted or rejected together: parts of one
  // fix (the two sides of a swap, touching runs of one joint one step smoothed, a marker change whose origin cannot
  // be told apart from a swap's), whose split would be refused when applied
  var at = {};
  list.forEach(function (c, k) { at[c.id] = k; });
  function set(k, accept, bulk) {
    (list[k].tied || [list[k].id]).forEach(function (id) {
      var j = at[id] === undefined ? k : at[id];
      doc.decisions[list[j].id] = accept ? "accept" : "reject";
      if (rows[j]) { rows[j].box.checked = accept; paint(j); }
      if (j === current) showCurrent();
    });
    if (!bulk) tally();
  }
  function setAll(accept) { list.forEach(function (c, k) { set(k, accept, true); }); tally(); }
  function tally() {
    if (!count) return;
    var rej = 0;
    list.forEach(function (c) { if (doc.decisions[c.id] === "reject") rej++; });
    count.textContent = (list.length - rej) + " accepted, " + rej + " rejected";
  }
  // the change on show in the viewer: the viewer's own bar steps through the changes and accepts or
  // rejects them, so a reviewer need not scroll between the list and the viewer for each one
  var current = -1, nav = null;
  function jump(k, fromList) {
    if (k < 0 || k >= list.length) return;
    var was = current;
    current = k;
    if (was >= 0) paint(was);
    paint(k);
    showCurrent();
    goTo(list[k].joint_index, list[k].first, !fromList);
  }
  function goTo(joint, frame, stay) {
    var api = window.mocapkitReport;
    if (!api) return;
    if (joint !== null) api.select(joint);  // a cut is of the whole body: no joint to select
    api.setFrame(frame);
    var v = document.querySelector(".viewer");
    if (!stay && v && v.scrollIntoView) v.scrollIntoView({ block: "start" });  // its bars and the figure
  }
  function showCurrent() {
    if (!nav) return;
    var c = list[current];
    nav.label.textContent = c ? "change " + (current + 1) + " of " + list.length + ": " + c.joint + ", frames " +
      (c.first === c.last ? c.first : c.first + "-" + c.last) + " (" + c.step + ")" : list.length + " changes";
    nav.accept.disabled = !c;
    nav.accept.checked = !!c && doc.decisions[c.id] !== "reject";
    nav.prev.disabled = current <= 0;
    nav.next.disabled = current >= list.length - 1;
    nav.back.disabled = !c;
  }
  function backToList() {
    if (current >= 0 && rows[current].tr.scrollIntoView) rows[current].tr.scrollIntoView({ block: "center" });
  }
  (function () {
    var viewer = document.querySelector(".viewer");
    if (!viewer || !list.length) return;
    var bar = el("div", { "class": "toolbar change-nav", id: "change-nav" });
    viewer.insertBefore(bar, viewer.children[1] || null);
    nav = {
      prev: el("button", { type: "button", id: "prev-change", text: "\u25c0 previous change" }, bar),
      label: el("span", { id: "change-label", "class": "change-label" }, bar),
      accept: null,
      next: null,
      back: null
    };
    var lab = el("label", {}, bar);
    nav.accept = el("input", { type: "checkbox", id: "change-accept" }, lab);
    lab.appendChild(document.createTextNode(" accept"));
    nav.next = el("button", { type: "button", id: "next-change", text: "next change \u25b6" }, bar);
    nav.back = el("button", { type: "button", id: "back-to-list", text: "back to its row" }, bar);
    nav.prev.addEventListener("click", function () { jump(current - 1); });
    nav.next.addEventListener("click", function () { jump(current + 1); });
    nav.back.addEventListener("click", backToList);
    nav.accept.addEventListener("change", function () { if (current >= 0) set(current, nav.accept.checked); });
    showCurrent();  // before any jump, "next" shows the first change
  })();
  // the record the decisions apply to: the one this cleaning wrote (the decisions keep its digest, and
  // `clean --decisions` refuses any other cleaning, a new one with other options included)
  function recordName() {
    var rec = doc.cleaning && doc.cleaning.record;
    return rec ? shellWord(rec) : "RECORD.clean.npz";
  }
  // the command that applies the decisions: the input as the cleaning was given it, and the options that read
  // the take as reviewed (an AMC's --asf and --amc-fps, a --unit), or the take read is another and is refused
  function applyCommand() {
    var cmd = R.command || {};
    return ["mocapkit clean", shellWord(cmd.input || doc.take.name || "IN"), "-o OUT --decisions", fileName(),
            "--record", recordName()].concat((cmd.options || []).map(shellWord)).join(" ");
  }
  function shellWord(s) {
    s = String(s);
    return /^[A-Za-z0-9._\/:=+-]+$/.test(s) ? s : "'" + s.replace(/'/g, "'\\''") + "'";
  }
  function fileName() {
    var stem = String(doc.take.name || "take").replace(/\.[^.\/]*$/, "").replace(/[^A-Za-z0-9._-]+/g, "_");
    return stem + ".decisions.json";
  }
  function text() { return JSON.stringify(doc, null, 1) + "\n"; }
  function download() {
    var blob = new Blob([text()], { type: "application/json" });
    var url = URL.createObjectURL(blob), a = document.createElement("a");
    a.setAttribute("href", url);
    a.setAttribute("download", fileName());
    a.style.display = "none";
    document.body.appendChild(a);
    a.click();
    document.body.removeChild(a);
    setTimeout(function () { URL.revokeObjectURL(url); }, 10000);
  }
  if (list.length) {
    allAcc.addEventListener("click", function () { setAll(true); });
    allRej.addEventListener("click", function () { setAll(false); });
    dl.addEventListener("click", download);
  }
  tally();

  // for tests and for people at the console
  window.mocapkitReview = {
    changes: function () { return list.map(function (c) { return c.id; }); },
    flags: function () { return flags.map(function (f) { return f.joint + ":" + f.first + "-" + f.last; }); },
    cuts: function () { return cuts.map(function (c) { return c.frame; }); },
    decisions: function () { return JSON.parse(text()); },
    set: function (id, choice) { var k = list.map(function (c) { return c.id; }).indexOf(id); if (k >= 0) set(k, choice === "accept"); },
    jump: function (k) { jump(k, true); },
    current: function () { return current; },
    fileName: fileName
  };
})();
