"""Static matplotlib figures, written atomically as PNG."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from ..io import atomic_write
from ..motion import Motion

__all__ = ["plot_channels", "plot_mdm", "draw_channels", "draw_mdm", "channel_names", "shown_mdm"]


def channel_names(motion: Motion, joint: str) -> list[str]:
    """The rotation channels of ``joint`` as the file gives them (``"lknee.Xrotation"``, ...); ValueError if none."""
    prefix = f"{joint}."
    names = [n for n in motion.channel_names() if n.startswith(prefix) and n.endswith("rotation")]
    if not names:
        raise ValueError(f"joint {joint!r} has no rotation channels to plot")
    return names


def draw_channels(axes, motions: Sequence[Motion], joint: str, labels: Sequence[str] | None = None,
                  mask: np.ndarray | None = None) -> None:
    """Draw the rotation channels (degrees) of one joint for several motions on ``axes``, one per channel.

    ``axes``: a sequence of matplotlib axes, one per rotation channel of ``joint``
    (:func:`channel_names` of the first motion), sharing the time axis (seconds);
    one line per motion; frames where ``mask`` (F,) or (F, J) marks the joint are
    shaded, and missing samples show as gaps.
    """
    if not motions:
        raise ValueError("plot_channels needs at least one motion")
    labels = list(labels) if labels is not None else [m.name or f"motion {i}" for i, m in enumerate(motions)]
    first = motions[0]
    j = first.skeleton.index(joint)
    names = channel_names(first, joint)
    axes = list(axes)
    if len(axes) != len(names):
        raise ValueError(f"joint {joint!r} has {len(names)} rotation channels, got {len(axes)} axes")
    styles = [dict(lw=1.6, color="#1f77b4"), dict(lw=1.0, color="#d62728", alpha=0.85), dict(lw=1.0, color="#2ca02c")]
    for k, m in enumerate(motions):
        values = m.channel_values()
        cols = m.channel_names()
        t = np.arange(m.num_frames) / m.fps
        for row, name in enumerate(names):
            axes[row].plot(t, values[:, cols.index(name)], label=labels[k], **styles[k % len(styles)])
    if mask is not None:
        mask = np.asarray(mask)
        flagged = mask[:, j] if mask.ndim == 2 else mask
        t = np.arange(len(flagged)) / first.fps
        # shading every frame says nothing (dense noise): shade only when some frames are untouched
        for row in range(len(names) if not flagged.all() else 0):
            axes[row].fill_between(t, 0, 1, where=flagged, color="orange", alpha=0.25,
                                   transform=axes[row].get_xaxis_transform(), label="changed" if row == 0 else None)
    for row, name in enumerate(names):
        axes[row].set_ylabel(f"{name.split('.')[-1]} (deg)")
        axes[row].grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)  # where it hides the least of the curves and the changed spans
    axes[-1].set_xlabel("time (s)")


def plot_channels(
    motions: Sequence[Motion],
    joint: str,
    path,
    labels: Sequence[str] | None = None,
    mask: np.ndarray | None = None,
    title: str | None = None,
) -> Path:
    """Plot the rotation channels (degrees) of one joint for several motions over time (:func:`draw_channels`).

    One subplot per rotation channel of ``joint`` (as the file gives them, see
    :meth:`Motion.channel_values`), one line per motion; frames where ``mask``
    (F,) or (F, J) marks the joint are shaded, and missing samples show as gaps.
    Motions must share the joint; their frame rates may differ (the x axis is seconds).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not motions:
        raise ValueError("plot_channels needs at least one motion")
    labels = list(labels) if labels is not None else [m.name or f"motion {i}" for i, m in enumerate(motions)]
    names = channel_names(motions[0], joint)
    fig, axes = plt.subplots(len(names), 1, figsize=(10, 2.2 * len(names) + 0.6), sharex=True, squeeze=False)
    try:
        draw_channels(axes[:, 0], motions, joint, labels, mask)
        fig.suptitle(title or f"{joint}: " + " vs ".join(labels))
        fig.tight_layout()
        path = Path(path)
        with atomic_write(path, "wb") as fh:
            fig.savefig(fh, format="png", dpi=110)
    finally:
        plt.close(fig)
    return path


# -- movement digression map (Aristidou et al. 2018, Fig. 1 bottom, Fig. 9) -----------

_MDM_DPI = 100
_MDM_ROW_IN = 0.2          # inches per joint row (capped total height below)
_MDM_MAX_ROWS_IN = 24.0    # the joint rows never take more than this many inches
_MDM_FRAMES_PER_IN = 80.0  # clip length -> axes width
_MDM_AXES_W_IN = (4.0, 18.0)
_MDM_TOP_IN, _MDM_BOTTOM_IN, _MDM_RIGHT_IN = 1.0, 0.6, 1.2


def _mdm_layout(num_frames: int, joint_names: Sequence[str]) -> dict:
    """Figure geometry in inches for an MDM of ``num_frames`` x ``len(joint_names)``.

    The height grows with the number of joints (one row each, every name
    readable), the width with the clip length up to a cap; the left margin
    fits the longest joint name. ``size`` is the figure size in inches,
    ``pixels`` the PNG's (width, height), whole pixels at 100 dpi.
    """
    J = max(len(joint_names), 1)
    row = min(_MDM_ROW_IN, _MDM_MAX_ROWS_IN / J)
    fontsize = float(np.clip(row * 72.0 * 0.6, 4.0, 8.0))
    longest = max((len(str(n)) for n in joint_names), default=1)
    left = 0.3 + 0.62 * longest * fontsize / 72.0
    axes_w = float(np.clip(num_frames / _MDM_FRAMES_PER_IN, *_MDM_AXES_W_IN))
    axes_h = max(row * J, 1.0)
    pixels = (int(round((left + axes_w + _MDM_RIGHT_IN) * _MDM_DPI)),
              int(round((_MDM_TOP_IN + axes_h + _MDM_BOTTOM_IN) * _MDM_DPI)))
    size = (pixels[0] / _MDM_DPI, pixels[1] / _MDM_DPI)
    return dict(size=size, pixels=pixels, left=left, axes_w=axes_w, axes_h=axes_h, fontsize=fontsize)


def _mask_outline(mask: np.ndarray, x0: float) -> np.ndarray:
    """Segments (N, 2, 2) in (frame, joint) data coordinates outlining the True cells of an (F, J) mask.

    Edges between a True and a False (or outside) cell, merged into runs, so
    a long flagged stretch is a handful of lines whatever its length.
    """
    P = np.pad(mask.astype(bool), 1)
    segs = []
    # vertical edges: between frames i-1 and i, along joints
    V = P[1:, 1:-1] != P[:-1, 1:-1]  # (F + 1, J)
    d = np.diff(np.pad(V, ((0, 0), (1, 1))).astype(np.int8), axis=1)
    si, sj = np.nonzero(d == 1)
    _, ej = np.nonzero(d == -1)
    x = x0 + si - 0.5
    segs.append(np.stack([np.stack([x, sj - 0.5], -1), np.stack([x, ej - 0.5], -1)], axis=1))
    # horizontal edges: between joints i-1 and i, along frames
    H = (P[1:-1, 1:] != P[1:-1, :-1]).T  # (J + 1, F)
    d = np.diff(np.pad(H, ((0, 0), (1, 1))).astype(np.int8), axis=1)
    si, sf = np.nonzero(d == 1)
    _, ef = np.nonzero(d == -1)
    y = si - 0.5
    segs.append(np.stack([np.stack([x0 + sf - 0.5, y], -1), np.stack([x0 + ef - 0.5, y], -1)], axis=1))
    return np.concatenate(segs).astype(np.float64)


def _bin_max(a: np.ndarray, k: int) -> np.ndarray:
    """Max over consecutive blocks of ``k`` frames of an (F, J) array, NaN only where a block is all NaN."""
    F, J = a.shape
    nb = -(-F // k)
    pad = np.full((nb * k, J), np.nan)
    pad[:F] = a
    blocks = pad.reshape(nb, k, J)
    finite = ~np.isnan(blocks)
    out = np.where(finite, blocks, -np.inf).max(axis=1)
    out[~finite.any(axis=1)] = np.nan
    return out


def plot_mdm(
    mdm: np.ndarray,
    joint_names: Sequence[str],
    fps: float,
    path,
    flags: np.ndarray | None = None,
    truth: np.ndarray | None = None,
    title: str | None = None,
    threshold: float | None = 0.5,
    start_frame: int = 0,
    grey: str = "not analysed",
) -> Path:
    """Draw a movement digression map as a heat map PNG (Aristidou et al. 2018, section 3.4, Fig. 1, Fig. 9).

    ``mdm`` is (F, J) with values in [0, 1] (NaN: not analysed, drawn grey):
    joints are rows, labelled with ``joint_names``; frames run left to right
    with frame numbers below (counted from ``start_frame``) and seconds
    (``frame / fps``) above. Colours run cold to hot ("inferno", fixed to
    [0, 1]); the colorbar "digression" marks ``threshold`` (None: no mark).
    ``flags`` (F, J) bool, e.g. the detector's output, are outlined in cyan;
    ``truth`` (F, J) bool, e.g. the injected errors of a benchmark, in dashed
    green. The figure is one 0.2 in row per joint (all rows within 24 in) and
    about 80 frames per inch (4 to 18 in); clips longer than the axes has
    pixels are shown by the maximum over each block of frames, so a
    one-frame spike never disappears. Written atomically at 100 dpi; returns
    the path. Bad shapes or values raise ``ValueError``. ``grey``: the legend's words for the NaN cells
    ("not analysed or judged" where they include cells no neighbour word judged:
    :func:`mocapkit.cleaning.judged.not_judged_cells`, MDM 0 though nothing checked them).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    joint_names = [str(n) for n in joint_names]
    mdm, masks = _checked_mdm(mdm, joint_names, fps, threshold, flags, truth)
    F = mdm.shape[0]
    lay = _mdm_layout(F, joint_names)
    w, h = lay["size"]
    # half a pixel more so that matplotlib's truncation to whole pixels lands on ``pixels`` exactly
    fig = plt.figure(figsize=((lay["pixels"][0] + 0.5) / _MDM_DPI, (lay["pixels"][1] + 0.5) / _MDM_DPI), dpi=_MDM_DPI)
    try:
        ax = fig.add_axes((lay["left"] / w, _MDM_BOTTOM_IN / h, lay["axes_w"] / w, lay["axes_h"] / h))
        cax = fig.add_axes(((lay["left"] + lay["axes_w"] + 0.2) / w, _MDM_BOTTOM_IN / h, 0.18 / w, lay["axes_h"] / h))
        handles = _draw_mdm(ax, cax, mdm, joint_names, fps, masks, threshold, start_frame, lay["axes_w"] * _MDM_DPI,
                            lay["fontsize"], max(int(lay["axes_w"] * 1.2), 4), grey)
        if handles:
            fig.legend(handles=handles, loc="upper right", ncol=len(handles), fontsize=8, frameon=False,
                       bbox_to_anchor=(1.0, 1.0))
        fig.text(0.01, 1.0 - 0.12 / h, title if title is not None else "movement digression map",
                 ha="left", va="top", fontsize=10)
        path = Path(path)
        with atomic_write(path, "wb") as fh:
            fig.savefig(fh, format="png", dpi=_MDM_DPI)
    finally:
        plt.close(fig)
    return path


def _draw_mdm(ax, cax, mdm, joint_names, fps, masks, threshold, start_frame, width_px, fontsize, nbins,
              grey: str = "not analysed") -> list:
    """Draw a checked MDM on ``ax`` with its colorbar in ``cax``; returns the legend handles."""
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator

    F, J = mdm.shape
    x0 = float(start_frame)
    k = max(1, int(np.ceil(F / width_px)))
    img = _bin_max(mdm, k) if k > 1 else mdm
    cmap = plt.get_cmap("inferno").with_extremes(bad="#9e9e9e")
    extent = (x0 - 0.5, x0 - 0.5 + img.shape[0] * k, J - 0.5, -0.5)
    im = ax.imshow(
        np.ma.masked_invalid(img.T), cmap=cmap, vmin=0.0, vmax=1.0, aspect="auto",
        interpolation="nearest", extent=extent,
    )
    ax.set_xlim(x0 - 0.5, x0 + F - 0.5)
    ax.set_ylim(J - 0.5, -0.5)
    ax.set_yticks(np.arange(J))
    ax.set_yticklabels(joint_names, fontsize=fontsize)
    ax.tick_params(axis="y", length=2, pad=2)
    ax.xaxis.set_major_locator(MaxNLocator(nbins=nbins, integer=True))
    ax.tick_params(axis="x", labelsize=8)
    ax.set_xlabel("frame", fontsize=9)
    sec = ax.secondary_xaxis("top", functions=(lambda f: f / fps, lambda s: s * fps))
    sec.tick_params(labelsize=8)
    sec.set_xlabel("time (s)", fontsize=9)
    handles = []
    styles = {"truth": dict(colors="#39ff14", linewidths=1.4, linestyles=(0, (3, 2))),
              "flags": dict(colors="#00e5ff", linewidths=1.1)}
    labels = {"truth": "truth", "flags": "flagged"}
    for name in ("truth", "flags"):
        if name in masks and masks[name].any():
            ax.add_collection(LineCollection(_mask_outline(masks[name], x0), **styles[name]))
        if name in masks:
            st = styles[name]
            handles.append(Line2D([], [], color=st["colors"], lw=st["linewidths"],
                                  linestyle=st.get("linestyles", "-"), label=labels[name]))
    if np.isnan(mdm).any():
        handles.append(Patch(facecolor="#9e9e9e", label=grey))
    cb = ax.figure.colorbar(im, cax=cax)
    cb.set_label("digression", fontsize=9)
    cb.ax.tick_params(labelsize=8)
    if threshold is not None:
        cax.axhline(threshold, color="#00e5ff", lw=1.5)
    return handles


def shown_mdm(mdm: np.ndarray, analysed: np.ndarray | None, detection=None) -> tuple[np.ndarray, str]:
    """The MDM (F, J) as :func:`plot_mdm` and :func:`draw_mdm` should draw it, and the legend's words for its grey:
    NaN (grey, "not analysed") for the joints not analysed, and for the cells no neighbour word judged when
    ``detection`` (a :class:`~mocapkit.cleaning.ssa.Detection`; None for a record read back, which keeps no
    per-cell judgement) has any (:func:`mocapkit.cleaning.judged.not_judged_cells`: MDM 0 though nothing checked
    them, read as "found clean" in black; "not analysed or judged"), as the HTML report stripes them."""
    shown = np.array(mdm, dtype=np.float64)
    if analysed is not None:
        shown[:, ~np.asarray(analysed, dtype=bool)] = np.nan
    if detection is not None:
        from ..cleaning.judged import not_judged_cells

        unjudged = not_judged_cells(detection)
        if unjudged.shape == shown.shape and unjudged.any():
            shown[unjudged] = np.nan
            return shown, "not analysed or judged"
    return shown, "not analysed"


def draw_mdm(ax, cax, mdm: np.ndarray, joint_names: Sequence[str], fps: float, flags: np.ndarray | None = None,
             truth: np.ndarray | None = None, threshold: float | None = 0.5, start_frame: int = 0,
             grey: str = "not analysed") -> list:
    """Draw a movement digression map on the matplotlib axes ``ax``, its colorbar in ``cax``.

    The same picture as :func:`plot_mdm` (same arguments and checks) on axes of
    any figure; clips longer than the axes has pixels are shown by the maximum
    over each block of frames. Returns the legend handles (flags, truth, not
    analysed) for the caller's legend; ``grey``: the legend's words for the NaN cells (as :func:`plot_mdm`).
    """
    joint_names = [str(n) for n in joint_names]
    mdm, masks = _checked_mdm(mdm, joint_names, fps, threshold, flags, truth)
    width_px = max(ax.get_position().width * ax.figure.get_figwidth() * ax.figure.dpi, 1.0)
    fontsize = max(4.0, min(8.0, 72.0 * ax.get_position().height * ax.figure.get_figheight() / max(len(joint_names), 1) * 0.8))
    return _draw_mdm(ax, cax, mdm, joint_names, fps, masks, threshold, start_frame, width_px, fontsize,
                     max(int(width_px / _MDM_DPI * 1.2), 4), grey)


def _checked_mdm(mdm, joint_names, fps, threshold, flags, truth):
    """``mdm`` as float64 (F, J) and the masks as bool, or ValueError naming what is wrong."""
    mdm = np.asarray(mdm, dtype=np.float64)
    if mdm.ndim != 2:
        raise ValueError(f"mdm must be a (frames, joints) array, got shape {mdm.shape}")
    F, J = mdm.shape
    if F == 0 or J == 0:
        raise ValueError(f"mdm is empty: shape {mdm.shape}")
    if J != len(joint_names):
        raise ValueError(f"mdm has {J} joint columns but {len(joint_names)} joint names were given")
    bad = ~np.isnan(mdm) & ~((mdm >= -1e-9) & (mdm <= 1.0 + 1e-9))
    if bad.any():
        f, j = (int(i[0]) for i in np.nonzero(bad))
        raise ValueError(
            f"mdm values must lie in [0, 1] (or be NaN); frame {f}, joint {joint_names[j]!r} is {mdm[f, j]!r}"
        )
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    if threshold is not None and not 0.0 <= threshold <= 1.0:
        raise ValueError(f"threshold must lie in [0, 1], got {threshold!r}")
    masks = {}
    for name, m in (("flags", flags), ("truth", truth)):
        if m is not None:
            m = np.asarray(m)
            if m.shape != mdm.shape:
                raise ValueError(f"{name} must have the shape of mdm {mdm.shape}, got {m.shape}")
            masks[name] = m.astype(bool)
    return mdm, masks
