"""Static matplotlib figures, written atomically as PNG."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from ..io import atomic_write
from ..motion import Motion

__all__ = ["plot_channels"]


def plot_channels(
    motions: Sequence[Motion],
    joint: str,
    path,
    labels: Sequence[str] | None = None,
    mask: np.ndarray | None = None,
    title: str | None = None,
) -> Path:
    """Plot the rotation channels (degrees) of one joint for several motions over time.

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
    first = motions[0]
    j = first.skeleton.index(joint)
    prefix = f"{joint}."
    names = [n for n in first.channel_names() if n.startswith(prefix) and n.endswith("rotation")]
    if not names:
        raise ValueError(f"joint {joint!r} has no rotation channels to plot")
    fig, axes = plt.subplots(len(names), 1, figsize=(10, 2.2 * len(names) + 0.6), sharex=True, squeeze=False)
    styles = [dict(lw=1.6, color="#1f77b4"), dict(lw=1.0, color="#d62728", alpha=0.85), dict(lw=1.0, color="#2ca02c")]
    for k, m in enumerate(motions):
        values = m.channel_values()
        cols = m.channel_names()
        t = np.arange(m.num_frames) / m.fps
        for row, name in enumerate(names):
            axes[row, 0].plot(t, values[:, cols.index(name)], label=labels[k], **styles[k % len(styles)])
    if mask is not None:
        mask = np.asarray(mask)
        flagged = mask[:, j] if mask.ndim == 2 else mask
        t = np.arange(len(flagged)) / first.fps
        # shading every frame says nothing (dense noise): shade only when some frames are untouched
        for row in range(len(names) if not flagged.all() else 0):
            axes[row, 0].fill_between(t, 0, 1, where=flagged, color="orange", alpha=0.25,
                                      transform=axes[row, 0].get_xaxis_transform(), label="changed" if row == 0 else None)
    for row, name in enumerate(names):
        axes[row, 0].set_ylabel(f"{name.split('.')[-1]} (deg)")
        axes[row, 0].grid(alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(title or f"{joint}: " + " vs ".join(labels))
    fig.tight_layout()
    path = Path(path)
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=110)
    plt.close(fig)
    return path
