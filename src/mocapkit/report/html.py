"""The cleaning report: one self-contained HTML page with a 3D stick-figure viewer.

:func:`write_report` writes a single ``.html`` file that needs nothing else: the
viewer's JavaScript and CSS (``viewer.js``, ``viewer.css`` beside this module,
hand-written, no libraries) and the data are inlined, so the page opens from
disk, offline, in any current browser, and can be mailed or archived as is.

What the page holds
-------------------
- global joint (and end-site) positions of both motions in centimetres, from
  forward kinematics, turned so that the take's up axis is +y, quantised to
  int16 on one shared grid (1 mm steps unless the take spans more than 65 m);
  the cleaned motion as a patch of the points that differ when fewer than half do;
- the movement digression map quantised to uint8, and one uint8 per cell with
  bit 0 = flagged, bit 1 = changed by the cleaning, bit 2 / 3 = missing in the
  original / cleaned motion, bit 4 = not judged by detection (no similar motion to judge it against);
- the rotation channels (degrees, as the file gives them) before and after of
  the joints the cleaning flagged or changed, int16 on a per-channel grid;
- the framing (:mod:`mocapkit.report.view`): floor height, camera target (fixed,
  or a per-frame track following the body) and the camera distance at which
  every point of every frame lies inside the panel, whatever the orbit angle.
- with ``review`` (:mod:`mocapkit.cleaning.decisions`), the list of changes,
  each with accept/reject and a "jump to frame" link, and a button that
  downloads the decisions JSON (its own JSON block and ``review.js``).

Binary arrays travel as base64 of little-endian bytes inside one JSON block, so
a 60 s take at 120 fps is a few MB.

Long takes
----------
Up to ``max_frames`` frames the viewer shows every frame (the page's frame list
is null). A longer take shows a sorted, non-uniform list of its frames
(:func:`shown_frames`): every k-th frame, ``k = ceil(frames / max_frames)``, its last frame, and
every frame of each run of flagged or changed cells (and of each change and flag
of ``review``) with :data:`DETAIL_MARGIN` frames either side, so that a person
reviewing a change sees exactly the frames it touched; the page carries the list
(``frameList``, int32) and plays the take at its real rate, the detail at every
frame and the rest at every k-th. The heat map and the flags keep the maximum /
any over the frames from one shown frame to the next, so a one-frame spike is
never lost, and the page says what it shows. The list is capped at
``2 * max_frames`` frames: when the detail does not fit, it is kept by priority,
whole tiers in this order while they fit: the first frame of each run (where the
review list jumps), every changed frame, every flagged frame, the margins; the
page says which tiers it kept.
"""

from __future__ import annotations

import base64
import dataclasses
import html as _html
import json
import math
from importlib import resources
from pathlib import Path

import numpy as np

from ..io import atomic_write
from ..motion import Motion, unit_scale_cm
from .view import body_points, find_up_axis, fit_view, rotation_to_y

__all__ = ["write_report", "cut_rows", "shown_frames", "DEFAULT_MAX_FRAMES", "DETAIL_MARGIN", "MAX_PLOT_JOINTS"]

#: frames the viewer keeps by default: a 60 s take at 120 fps is shown at full rate.
DEFAULT_MAX_FRAMES = 7200
#: in a long take, frames shown on each side of a run of flagged or changed frames.
DETAIL_MARGIN = 3
#: at most this many joints get before/after channel plots (those flagged or changed most).
MAX_PLOT_JOINTS = 12

_MISSING_I16 = -32768
_BIT_FLAG, _BIT_CHANGED, _BIT_MISSING_ORIG, _BIT_MISSING_CLEAN, _BIT_NOT_JUDGED = 1, 2, 4, 8, 16


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def _quantise_i16(arrays, min_step: float):
    """Quantise float arrays on one grid: ``value = lo + (q + 32767) * step``; NaN -> -32768.

    Returns (lo, step, [int16 arrays]); the grid covers the finite values of all arrays.
    """
    finite = [a[np.isfinite(a)] for a in arrays]
    finite = [f for f in finite if f.size]
    if finite:
        lo = float(min(f.min() for f in finite))
        hi = float(max(f.max() for f in finite))
    else:
        lo = hi = 0.0
    step = max(min_step, (hi - lo) / 65534.0)
    out = []
    for a in arrays:
        q = np.full(a.shape, _MISSING_I16, dtype="<i2")
        ok = np.isfinite(a)
        q[ok] = (np.rint((a[ok] - lo) / step) - 32767).clip(-32767, 32767).astype("<i2")
        out.append(q)
    return lo, step, out


def _cell_mask(a, name: str, shape: tuple[int, int]) -> np.ndarray | None:
    if a is None:
        return None
    arr = np.asarray(a)
    if arr.shape != shape:
        raise ValueError(f"{name}: expected shape (F, J) = {shape}, got {arr.shape}")
    if arr.dtype != bool:
        if not np.issubdtype(arr.dtype, np.number) or not np.all(np.isin(arr, (0, 1))):
            raise ValueError(f"{name}: expected a boolean (F, J) mask, got values of dtype {arr.dtype}")
        arr = arr.astype(bool)
    return arr


def _run_starts(mask: np.ndarray) -> np.ndarray:
    """(F,) bool: frames where a run of True cells of some joint of the (F, J) ``mask`` begins."""
    start = mask.copy()
    start[1:] &= ~mask[:-1]
    return start.any(axis=1)


def _review_spans(review: dict | None, F: int) -> dict[str, list[tuple[int, int]]]:
    """``(first, last)`` frames of the review's changes and flags that lie in the take; a cut's two frames (the last
    before the break and the first after it) are shown as a flag's are, every frame."""
    out: dict[str, list[tuple[int, int]]] = {"changes": [], "flags": []}
    if not isinstance(review, dict):
        return out
    for key, items in (("changes", review.get("changes")), ("flags", review.get("flags")), ("flags", review.get("cuts"))):
        for item in items if isinstance(items, list) else ():
            if not isinstance(item, dict):
                continue
            a, b = item.get("first"), item.get("last", item.get("first"))
            if isinstance(a, (int, np.integer)) and isinstance(b, (int, np.integer)) and 0 <= a <= b < F:
                out[key].append((int(a), int(b)))
    return out


def shown_frames(num_frames: int, max_frames: int, flags=None, changed=None, *,
                 starts=(), margin: int = DETAIL_MARGIN) -> tuple[np.ndarray, int, str]:
    """The take frames the report's viewer shows: ``(frames, stride, detail)``.

    Up to ``max_frames`` frames: all of them, stride 1, detail ``"all"``. A longer
    take: every ``stride``-th frame (``stride = ceil(num_frames / max_frames)``, at
    most ``max_frames`` of them) and the detail frames, at most ``2 * max_frames``
    frames in all. The detail comes in tiers, each kept whole while the total stays
    within that cap, in this order (the first that does not fit ends it):

    1. ``"starts"``: the frame where each run of flagged or changed cells of a joint
       begins, and the frames in ``starts`` (the review list's "jump to frame"
       targets); when even these do not fit, evenly spaced ones of them (``"some"``);
    2. ``"changes"``: every frame with a changed cell;
    3. ``"runs"``: every frame with a flagged cell;
    4. ``"full"``: ``margin`` frames either side of each run of frames of tiers 2-3.

    ``detail`` names the last tier kept (``"none"`` when nothing is flagged or changed).

    Parameters
    ----------
    num_frames, max_frames : int
        Frames in the take; frames the viewer keeps at a uniform rate.
    flags, changed : bool arrays (F,) or (F, J), optional
        Flagged / changed cells (or frames); a run starts where a column's run of True does.
    starts : iterable of int
        Further frames to show first (where the review list jumps).
    margin : int
        Frames shown either side of each run of detail frames.

    Returns
    -------
    frames : int64 array (N,), sorted, starting at 0
    stride : int
    detail : str

    Examples
    --------
    >>> f = np.zeros(100, bool); f[41:43] = True
    >>> frames, stride, detail = shown_frames(100, 20, f)
    >>> stride, detail, [int(x) for x in frames if 35 <= x < 50]
    (5, 'full', [35, 38, 39, 40, 41, 42, 43, 44, 45])
    """
    F = int(num_frames)
    if F <= max_frames:
        return np.arange(F), 1, "all"
    stride = math.ceil(F / int(max_frames))
    cap = 2 * int(max_frames)

    def frames_mask(a):
        if a is None:
            return np.zeros(F, dtype=bool)
        a = np.asarray(a, dtype=bool)
        return a if a.ndim == 1 else a.any(axis=1)

    def cell_starts(a):
        if a is None:
            return np.zeros(F, dtype=bool)
        a = np.asarray(a, dtype=bool)
        return _run_starts(a if a.ndim == 2 else a[:, None])

    keep = np.zeros(F, dtype=bool)
    keep[::stride] = True
    keep[F - 1] = True  # the take's last frame: the viewer can reach the end
    first = cell_starts(flags) | cell_starts(changed)
    first[[int(f) for f in starts]] = True
    ch, fl = frames_mask(changed), frames_mask(flags)
    if not (first.any() or ch.any() or fl.any()):
        return np.flatnonzero(keep), stride, "none"
    with_first = keep | first
    if with_first.sum() > cap:  # more run starts than room: evenly spaced ones of them
        room = cap - int(keep.sum())
        extra = np.flatnonzero(first & ~keep)
        pick = extra[np.unique(np.linspace(0, len(extra) - 1, max(room, 0)).round().astype(int))] if room > 0 else []
        keep[pick] = True
        return np.flatnonzero(keep), stride, "some"
    keep, detail = with_first, "starts"
    runs = ch | fl
    for name, tier in (("changes", ch), ("runs", fl), ("full", None)):
        if tier is None:  # the margins: either side of each run of changed or flagged frames
            if margin <= 0:
                break
            k = int(margin)
            kernel = np.ones(2 * k + 1, dtype=int)
            tier = np.convolve(runs.astype(int), kernel, mode="full")[k:k + F] > 0  # any length of take
        cand = keep | tier
        if cand.sum() > cap:
            break
        keep, detail = cand, name
    return np.flatnonzero(keep), stride, detail


def _motion_frames(m: Motion, frames: np.ndarray) -> Motion:
    """The motion at the given frames (any sorted list of them)."""
    if len(frames) == m.num_frames:
        return m
    tr = None if m.translations is None else m.translations[frames]
    return dataclasses.replace(m, rotations=m.rotations[frames], root_positions=m.root_positions[frames],
                               translations=tr)


def _channel_plots(original: Motion, cleaned: Motion, interest: np.ndarray, idx: np.ndarray):
    """Rotation channels (deg) before/after of the joints with most flagged/changed cells."""
    counts = interest.sum(axis=0)
    order = [j for j in np.argsort(-counts, kind="stable") if counts[j] > 0]
    names = original.channel_names()
    per_joint = {}
    for j in order:
        prefix = f"{original.skeleton.joint_names[j]}."
        cols = [c for c, n in enumerate(names) if n.startswith(prefix) and n.endswith("rotation")]
        if cols:
            per_joint[int(j)] = cols
        if len(per_joint) == MAX_PLOT_JOINTS:
            break
    if not per_joint:
        return []
    with np.errstate(invalid="ignore"):
        v_orig = original.channel_values()[idx]
        v_clean = cleaned.channel_values()[idx]
    plots = []
    for j in sorted(per_joint):
        cols = per_joint[j]
        lo, step, (qo, qc) = _quantise_i16([v_orig[:, cols], v_clean[:, cols]], min_step=0.01)
        plots.append({
            "joint": j,
            "channels": [names[c].split(".", 1)[1] for c in cols],
            "lo": lo,
            "step": step,
            "original": _b64(qo),
            "cleaned": _b64(qc),
        })
    return plots


def _positions_block(lo: float, step: float, q_orig: np.ndarray, q_clean: np.ndarray) -> dict:
    """Both motions' quantised positions (N, P, 3); the cleaned one as a patch when that is smaller.

    Cleaning usually moves a few joints (and what hangs below them) in a few frames: then the
    cleaned motion travels as the points that differ from the original, flat indices (uint32)
    into (N, P) plus their int16 (K, 3) values, 10 bytes a point instead of 6 for all of them.
    """
    block = {"lo": lo, "step": step, "original": _b64(q_orig)}
    differ = np.any(q_clean != q_orig, axis=-1).ravel()
    if differ.mean() < 0.5:
        where = np.flatnonzero(differ)
        block["cleanedPatch"] = {
            "index": _b64(where.astype("<u4")),
            "values": _b64(q_clean.reshape(-1, 3)[where]),
        }
    else:
        block["cleaned"] = _b64(q_clean)
    return block


def _asset(name: str) -> str:
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


def _script_json(obj) -> str:
    # inside <script>, "</script" or "<!--" must not appear: escape every "<"
    return json.dumps(obj, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")


def review_parts(review: dict | None) -> tuple[str, str, str]:
    """CSS, JSON block and script of the changes list (all empty without ``review``)."""
    if review is None:
        return "", "", ""
    if not isinstance(review, dict) or not isinstance(review.get("changes"), list) or \
            not isinstance(review.get("decisions"), dict):
        raise ValueError("review: expected {'changes': [...], 'decisions': {...}} (mocapkit.cleaning.decisions)")
    block = f'\n<script type="application/json" id="mocapkit-review">{_script_json(review)}</script>'
    return "\n" + _asset("review.css"), block, "\n" + _asset("review.js")


def write_report(
    path,
    original: Motion,
    cleaned: Motion,
    *,
    mdm=None,
    flags=None,
    changed=None,
    title: str = "",
    fps: float | None = None,
    max_frames: int | None = None,
    up_axis=None,
    review: dict | None = None,
    analysed=None,
    not_judged=None,
    judged_note: str = "",
    warnings=(),
) -> Path:
    """Write the self-contained HTML cleaning report of ``original`` -> ``cleaned``.

    Parameters
    ----------
    path : str or Path
        The ``.html`` file to write (atomically: temp file + rename).
    original, cleaned : Motion
        The input and the cleaned motion: same skeleton, same frame count. NaN
        (missing joints) is allowed in either and shows as gaps.
    mdm : float array (F, J) in [0, 1], optional
        Movement digression map (:attr:`mocapkit.cleaning.ssa.Detection.mdm`); NaN counts as 0.
    flags : bool array (F, J), optional
        Joints flagged as erroneous: drawn red on the skeleton, marked on the heat map.
    changed : bool array (F, J), optional
        Cells the cleaning changed.
    title : str
        Page title; defaults to the original's name.
    fps : float, optional
        Frame rate to show and play at; defaults to ``original.fps``.
    max_frames : int, optional
        Frames the viewer keeps (default :data:`DEFAULT_MAX_FRAMES`); longer takes
        are shown at every k-th frame and at every frame of each flagged or changed
        run with :data:`DETAIL_MARGIN` frames either side, at most ``2 * max_frames``
        frames (:func:`shown_frames`), which the page states.
    up_axis : str, int or 3-vector, optional
        The take's up axis (``"y"``, ``"z"``, ``"-z"``, ...); by default it is
        found from the data (:func:`mocapkit.report.view.find_up_axis`). The page
        turns it to its +y and frames the figure whole in every frame
        (:func:`mocapkit.report.view.fit_view`).
    review : dict, optional
        ``{"changes": [Change.as_dict(), ...], "decisions": document}``
        (:func:`mocapkit.cleaning.decisions.changes` and
        :func:`~mocapkit.cleaning.decisions.template`): the page lists the
        changes for a person to accept or reject and download the decisions.
    analysed : bool array (J,), optional
        The joints detection analysed (:attr:`mocapkit.cleaning.clean_record.CleanResult.analysed`). The
        heat map draws the others striped grey, "not analysed", and the page names them, rather than
        an MDM of 0 that looks checked and clean. None: every joint is drawn by its MDM.
    not_judged : bool array (F, J), optional
        Cells of analysed joints that no neighbour word judged
        (:func:`mocapkit.cleaning.judged.not_judged_cells`): their MDM is 0 though nothing checked them, so the
        heat map stripes them like the joints not analysed. ``judged_note``: the words the page's summary says
        of them (:func:`mocapkit.cleaning.judged.not_judged_note`, as the console says them).
    warnings : sequence of str
        Lines shown under the title as ``warning: ...``, as the console says them: a step's fallback, the licence
        of a model whose terms restrict use (:attr:`mocapkit.cleaning.clean_record.CleanResult.warnings`; the
        non-commercial Bandai Namco models), so a page passed on says what the take's cleaning may be used for.

    Returns
    -------
    Path of the written file.

    Examples
    --------
    >>> import tempfile, pathlib, mocapkit
    >>> m = mocapkit.load(mocapkit.samples.path("12_walk.amc"))[:60]
    >>> out = write_report(pathlib.Path(tempfile.mkdtemp()) / "r.html", m, m, title="walk")
    >>> out.read_text().count("https://")
    0
    """
    for name, m in (("original", original), ("cleaned", cleaned)):
        if not isinstance(m, Motion):
            raise TypeError(f"{name} must be a Motion, got {type(m).__name__}")
    if not original.skeleton.is_compatible(cleaned.skeleton):
        raise ValueError("original and cleaned must share one skeleton (same joints and parents)")
    F, J = original.num_frames, original.num_joints
    if cleaned.num_frames != F:
        raise ValueError(f"original has {F} frames but cleaned has {cleaned.num_frames}; they must match")
    if F == 0:
        raise ValueError("the motions have no frames")
    shape = (F, J)
    mdm_arr = None
    if mdm is not None:
        mdm_arr = np.asarray(mdm, dtype=np.float64)
        if mdm_arr.shape != shape:
            raise ValueError(f"mdm: expected shape (F, J) = {shape}, got {mdm_arr.shape}")
        finite = mdm_arr[np.isfinite(mdm_arr)]
        if finite.size and (finite.min() < -1e-6 or finite.max() > 1 + 1e-6):
            raise ValueError(f"mdm: values must lie in [0, 1], got [{finite.min():.3g}, {finite.max():.3g}]")
        mdm_arr = np.nan_to_num(mdm_arr, nan=0.0).clip(0.0, 1.0)
    flags_arr = _cell_mask(flags, "flags", shape)
    changed_arr = _cell_mask(changed, "changed", shape)
    unjudged_arr = _cell_mask(not_judged, "not_judged", shape)
    unchecked = []
    if analysed is not None:
        analysed = np.asarray(analysed)
        if analysed.shape != (J,) or analysed.dtype != bool:
            raise ValueError(f"analysed: expected a bool array of shape (J,) = ({J},), got {analysed.dtype} {analysed.shape}")
        unchecked = [int(j) for j in np.flatnonzero(~analysed)]
    if max_frames is None:
        max_frames = DEFAULT_MAX_FRAMES
    if int(max_frames) != max_frames or max_frames < 2:
        raise ValueError(f"max_frames must be an integer >= 2, got {max_frames!r}")
    show_fps = float(original.fps if fps is None else fps)
    if not math.isfinite(show_fps) or show_fps <= 0:
        raise ValueError(f"fps must be a positive number, got {fps!r}")

    # the review's changes and flags count as runs too: a rejected change is not in ``changed``
    spans = _review_spans(review, F)
    span = {k: np.zeros(F, dtype=bool) for k in spans}
    for k, runs in spans.items():
        for a, b in runs:
            span[k][a:b + 1] = True

    def with_span(cells, k):
        if not span[k].any():
            return cells
        return span[k][:, None] if cells is None else np.column_stack([cells, span[k]])

    idx, stride, detail = shown_frames(F, int(max_frames), with_span(flags_arr, "flags"),
                                       with_span(changed_arr, "changes"),
                                       starts=[a for runs in spans.values() for a, _ in runs])
    sk = original.skeleton
    try:
        scale = unit_scale_cm(sk)
    except Exception:  # no human in any known unit: show file units as they are
        scale = 1.0
    with np.errstate(invalid="ignore"):
        p_orig = _motion_frames(original, idx).global_positions(end_sites=True)
        p_clean = _motion_frames(cleaned, idx).global_positions(end_sites=True)
    turn = rotation_to_y(find_up_axis(sk, p_orig[:, :J], up_axis=up_axis)) * scale
    body = body_points(sk, p_orig)  # in the rig's units, before the turn and the scale
    p_orig, p_clean = p_orig @ turn.T, p_clean @ turn.T
    framing = fit_view([p_orig, p_clean], fps=show_fps, body=body, frames=idx)  # smoothed over 1 s of the take
    # one grid for all three axes keeps the decoder trivial; 1 mm unless the take spans > 65 m
    lo, step, (q_orig, q_clean) = _quantise_i16([p_orig, p_clean], min_step=0.1)

    miss_o, miss_c = original.missing(), cleaned.missing()
    bits = np.zeros(shape, dtype=np.uint8)
    if flags_arr is not None:
        bits |= flags_arr.astype(np.uint8) * _BIT_FLAG
    if changed_arr is not None:
        bits |= changed_arr.astype(np.uint8) * _BIT_CHANGED
    bits |= miss_o.astype(np.uint8) * _BIT_MISSING_ORIG
    bits |= miss_c.astype(np.uint8) * _BIT_MISSING_CLEAN
    all_shown = len(idx) == F
    if not all_shown:  # each shown frame stands for the frames up to the next shown one
        bits = np.bitwise_or.reduceat(bits, idx, axis=0)
    if unjudged_arr is not None:  # a shown frame is not judged where none of the frames it stands for is
        unjudged_shown = unjudged_arr if all_shown else np.logical_and.reduceat(unjudged_arr, idx, axis=0)
        bits |= unjudged_shown.astype(np.uint8) * _BIT_NOT_JUDGED
    mdm_q = None
    if mdm_arr is not None:
        mdm_q = np.rint((mdm_arr if all_shown else np.maximum.reduceat(mdm_arr, idx, axis=0)) * 255).astype(np.uint8)

    interest = np.zeros(shape, dtype=bool)
    for a in (flags_arr, changed_arr):
        if a is not None:
            interest |= a
    plots = _channel_plots(original, cleaned, interest, idx)

    names = list(sk.joint_names) + list(sk.end_site_names)
    parents = [int(p) for p in sk.parents] + [int(p) for p in sk.end_site_parents]
    title = title or original.name or "mocapkit report"
    data = {
        "version": 1,
        "title": title,
        "fps": show_fps,
        "frames": F,
        "stride": stride,
        "n": int(len(idx)),
        # the take frame of each shown frame (sorted); null when every frame is shown
        "frameList": None if all_shown else _b64(idx.astype("<i4")),
        "detail": detail,
        "margin": DETAIL_MARGIN,
        "numJoints": J,
        "names": names,
        "parents": parents,
        "unitCm": scale,
        "view": framing.to_page(),
        "pos": _positions_block(lo, step, q_orig, q_clean),
        "mdm": None if mdm_q is None else _b64(mdm_q),
        "bits": _b64(bits),
        "has": {"mdm": mdm_q is not None, "flags": flags_arr is not None, "changed": changed_arr is not None},
        # the joints detection did not analyse: striped on the heat map, named in the summary (not an MDM of 0)
        "notAnalysed": unchecked,
        "stats": {
            "flagged": None if flags_arr is None else int(flags_arr.sum()),
            "changed": None if changed_arr is None else int(changed_arr.sum()),
            "missingOriginal": int(miss_o.sum()),
            "missingCleaned": int(miss_c.sum()),
            "flaggedJoints": None if flags_arr is None else [names[j] for j in np.flatnonzero(flags_arr.any(axis=0))],
            # frames no neighbour word judged, in the console's words: a change-free stretch there was not checked
            "notJudged": str(judged_note or ""),
        },
        "plots": plots,
    }
    esc = _html.escape(title)
    review_css, review_block, review_js = review_parts(review)
    warned = "".join(f'<p class="warning">warning: {_html.escape(str(w))}</p>' for w in warnings if w)
    page = f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data:">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="mocapkit">
<title>{esc} - mocapkit report</title>
<style>
{_asset("viewer.css")}{review_css}
</style>
</head>
<body>
<header><h1>{esc}</h1>{warned}<p id="summary"></p></header>
<main id="app"><noscript>This report needs JavaScript to draw the viewer.</noscript></main>
<script type="application/json" id="mocapkit-data">{_script_json(data)}</script>{review_block}
<script>
{_asset("viewer.js")}{review_js}
</script>
</body>
</html>
"""
    path = Path(path)
    with atomic_write(path, "w", encoding="utf-8") as fh:
        fh.write(page)
    return path


def cut_rows(cuts) -> list[dict]:
    """The report's row of each :class:`~mocapkit.cleaning.take_breaks.Cut`: ``frame`` (the first frame after the
    break), ``first``/``last`` (the frames either side of it, shown in full by the viewer), ``share`` (the score: the
    share of the moving joints breaking there, 0-1), ``meaning`` and ``did``
    (what the cleaning did: nothing, no sample changed for it). A cut changes no sample, so it is no change to
    accept or reject: a person sees it and decides (split the take there, or keep it)."""
    from ..cleaning.take_breaks import CUT_KEPT

    return [{"frame": int(c.frame), "first": max(0, int(c.frame) - 1), "last": int(c.frame), "share": float(c.share),
             "meaning": c.meaning, "did": CUT_KEPT} for c in cuts]


def write_clean_report(path, original: Motion, result, *, inp=None, output: str = "", record="", decisions=None,
                       applied: str = "", command: dict | None = None, asf=None) -> Path:
    """Write the report of a cleaning to review and decide: :func:`write_report` with the list of changes.

    The report ``mocapkit clean --report`` writes, for a :class:`~mocapkit.cleaning.clean_record.CleanResult` made by
    the CLI or in Python (:func:`mocapkit.clean`): its *Download decisions* keeps the cleaning's digest, so the
    file applies with ``mocapkit clean IN -o OUT --decisions FILE --record RECORD`` or
    ``mocapkit.clean(IN, decisions=FILE, record=RECORD)`` alike.

    Parameters
    ----------
    path : str or Path
        The ``.html`` file to write.
    original : Motion
        The take before cleaning (the one ``result`` cleaned).
    result : CleanResult
        The whole cleaning, not a decided result (its changes are the ones to decide).
    inp : str or Path, optional
        The input file as the cleaning was given it (default ``original.source_file``): the page's title, its
        frame numbering and its apply command name it.
    output : str
        The output's file name the decisions document names.
    record : str or Path
        Where ``result``'s record was written (:meth:`CleanResult.save`): the page's command passes it.
    decisions : mapping of change id to "accept" or "reject", optional
        Decisions already taken: the page draws the take with only the accepted changes and starts from them;
        ``applied`` names their file in the title.
    command : dict, optional
        :func:`mocapkit.cleaning.decided.apply_command`'s; default from ``inp``, ``asf`` and the AMC rate and unit
        the cleaning's options keep (``params["request"]``).
    """
    from ..cleaning import decisions as dec
    from ..cleaning.decided import apply_command
    from ..cleaning.flags_left import flag_outcomes
    from ..cleaning.judged import not_judged_cells, not_judged_note
    from ..errors import MocapError
    from ..io.takes import file_first_frame
    from .plain import with_plain_words

    if getattr(result, "decided", None) is not None:
        raise MocapError(f"{path}: a decided result has nothing left to decide; write the report of the cleaning "
                         "the decisions were applied to")
    inp = inp if inp is not None else original.source_file
    name = Path(inp).name if inp else (original.name or "take")
    cleaned, changed = result.motion, result.changed
    if decisions is not None or cleaned is None:
        cleaned, changed = dec.apply(original, result, decisions or {}), dec.accepted_cells(result, decisions or {})
    if command is None and inp:
        request = result.params.get("request") or {}
        command = apply_command(inp, asf=asf, amc_fps=request.get("amc_fps"), unit=request.get("unit"))
    review = dec.review(original, result, take=name, output=output, decisions=decisions,
                        first_frame=file_first_frame(inp) if inp else None, record=record, command=command)
    review["flags"] = flag_outcomes(result)  # each flag with what the cleaning did about it
    review["cuts"] = cut_rows(getattr(result, "cuts", ()))  # named for a person to see: no sample changed for them
    review = with_plain_words(review, result)  # an animator's sentence first, the detector's words as detail
    det = result.detection  # None for a record read back: it keeps no per-cell judgement
    return write_report(path, original, cleaned, mdm=result.mdm, flags=result.flags, changed=changed,
                        analysed=result.analysed, warnings=getattr(result, "warnings", ()),
                        not_judged=None if det is None else not_judged_cells(det),
                        judged_note=not_judged_note(det, original.num_frames),
                        title=f"{name}: cleaned" + (f" ({applied} applied)" if applied else ""), review=review)
