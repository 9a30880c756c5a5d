"""The static summary of a cleaned take: the movement digression map over before/after plots, one PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io import atomic_write
from ..motion import Motion
from .plots import channel_names, draw_channels, draw_mdm, shown_mdm

__all__ = ["plot_summary"]


def plot_summary(result, original: Motion, path, joints: int = 2, title: str | None = None) -> Path:
    """One PNG: the MDM heat map (flags outlined) over before/after channel plots of the most changed joints.

    ``result``: a :class:`~mocapkit.cleaning.clean_record.CleanResult` holding the
    cleaned motion; ``original``: the take it was cleaned from. The joints
    shown (``joints`` of them, among those with rotation channels) are those
    with the most flagged cells, then the most changed ones. Calibration poses
    the cleaning left alone (``result.calibration``) are shaded on the map and
    named in its title. Drawn on the axes
    of one matplotlib figure (:func:`~mocapkit.report.plots.draw_mdm`,
    :func:`~mocapkit.report.plots.draw_channels`), written atomically.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if result.motion is None:
        raise ValueError("plot_summary needs the cleaned motion (result.motion)")
    sk = original.skeleton
    changed = result.changed
    F = max(result.num_frames, 1)
    score = result.flags.sum(axis=0) * F + changed.sum(axis=0)
    order = [int(j) for j in np.argsort(-score, kind="stable") if score[j] > 0 and sk.rotation_order(int(j))]
    picks = order[:joints] or [j for j in range(1, sk.num_joints) if sk.rotation_order(j)][:1]
    label = title or (original.name or "take")
    rows = [len(channel_names(original, sk.joint_names[j])) for j in picks]
    J = len(result.joint_names)
    mdm_h = min(max(0.2 * J, 2.0), 10.0)
    heights = [mdm_h] + [1.6] * sum(rows)
    gaps = 0.9 * (1 + len(picks)) + 0.4  # titles and axis labels between the blocks
    fig = plt.figure(figsize=(12.0, sum(heights) + gaps), dpi=100)
    try:
        grid = fig.add_gridspec(len(heights), 2, height_ratios=heights, width_ratios=[60, 1], hspace=0.6, wspace=0.02,
                                left=0.12, right=0.95, top=1.0 - 1.0 / (sum(heights) + gaps), bottom=0.5 / (sum(heights) + gaps))
        ax = fig.add_subplot(grid[0, 0])
        # grey, not an MDM of 0, where nothing was analysed or judged (a record read back has no detection)
        mdm, grey = shown_mdm(result.mdm, result.analysed, getattr(result, "detection", None))
        handles = draw_mdm(ax, fig.add_subplot(grid[0, 1]), mdm, result.joint_names, result.fps, flags=result.flags,
                           grey=grey)
        calib = tuple(getattr(result, "calibration", ()) or ())
        for c in calib:
            a, b = c.frames
            ax.axvspan(a - 0.5, b - 0.5, color="0.5", alpha=0.3, lw=0)  # the map's x axis counts frames
        said = "; ".join(str(c) for c in calib)
        ax.set_title(f"{label}: movement digression map" + (f" ({said})" if said else ""), loc="left", fontsize=10, pad=28)
        if handles:  # on the title's line, above the map's time axis (its tick labels sit right above the map)
            from matplotlib.transforms import ScaledTranslation

            ax.legend(handles=handles, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=len(handles), fontsize=8,
                      frameon=False, bbox_transform=ax.transAxes + ScaledTranslation(0, 22 / 72, fig.dpi_scale_trans))
        r = 1
        for j, n in zip(picks, rows):
            axes = [fig.add_subplot(grid[r + i, 0]) for i in range(n)]
            for a in axes[1:]:
                a.sharex(axes[0])
            draw_channels(axes, [original, result.motion], sk.joint_names[j], labels=["input", "cleaned"],
                          mask=changed[:, j])
            axes[0].set_title(f"{sk.joint_names[j]}: input vs cleaned ({int(changed[:, j].sum())} of {F} frames changed)",
                              loc="left", fontsize=10)
            r += n
        path = Path(path)
        with atomic_write(path, "wb") as fh:
            fig.savefig(fh, format="png", dpi=100)
    finally:
        plt.close(fig)
    return path
