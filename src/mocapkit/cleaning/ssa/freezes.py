"""Frozen channels found from the take alone: one joint repeating its rotation bit for bit while the body moves.

A tracker or solver that loses a limb writes the last value it had, frame
after frame, until it finds the limb again, and the joint then jumps to where
the limb has gone in the meantime (an OptiTrack Motive BVH export: the right
forearm, hand, foot and toes held the same channels for 44 frames at 120 fps,
then the forearm turned 35 deg in one frame). :func:`held_joints`
(:mod:`~mocapkit.cleaning.ssa.cues`) flags a hold where the similar motion
moves, so only on frames a neighbour word judges; on a rig no context holds
most of a take may have no similar motion at all. This rule needs none: the
three things that mark a frozen channel are in the take itself.

* **An exact repeat**: the joint's rotation identical, bit for bit, over at
  least ``min_s`` seconds (live motion and a solver's output never repeat all
  of a joint's channels exactly while it moves; a written value read twice
  does).
* **While the body moves**: at most a minority of the other joints analysed
  repeat their own rotation over the run (a held pose, a T-pose or a take's
  padded frames hold the whole body: no freeze).
* **Ending in a break**: the step out of the held value is a break of the
  joint's own trajectory (:func:`~mocapkit.cleaning.ssa.cues.own_breaks`: over
  the break threshold and over what the joint's own motion reaches). A joint
  that holds still and starts moving again eases out of the hold.

Left alone, as motion: a joint that repeats its rotation for more than half
the take (a locked joint of a game rig, fingers or toes that never move), a
hold at the rest pose (every channel 0: a solver clamping a straight knee), a
hold that runs to the take's last frame (nothing shows it ended in a break)
and a hold the joint meets again at the same rotation, within ``recur_deg``, in
another exact hold of the take (a limit the solver clamps at, met again and
again; a frozen channel repeats the one arbitrary value it last had). On the
3,692 clean takes of ``benchmarks/clean_untouched.py`` (every collection, all
2,675 Bandai Namco takes, each rig's respellings and 30 fps cuts) it flags
nothing, whether the joints counted are the informative ones or all of them. A
cue of this library, not of Aristidou et al. (2018).
"""

from __future__ import annotations

import numpy as np

from ... import rotations as R

__all__ = ["frozen_channels", "recurring", "MIN_FROZEN_S", "MOVING_SHARE", "RECUR_BLOCK_CELLS"]

#: the shortest exact repeat taken for a frozen channel, seconds (12 frames at 120 fps; at least 4 frames at any rate)
MIN_FROZEN_S = 0.1
#: the share of the other joints analysed that must change their rotation over a hold for the body to be moving
MOVING_SHARE = 0.5
#: pairs of held rotations :func:`recurring` compares at once (a block of rows of its (n, n) angles: 8 MB per
#: (rows, n, 4) float64 temporary); the whole matrix of a 9-minute Bandai Namco session's holds took 400 MB
RECUR_BLOCK_CELLS = 1 << 18


def recurring(held: np.ndarray, recur: float, block_cells: int = RECUR_BLOCK_CELLS) -> np.ndarray:
    """(n,) bool: which of the (n, 4) rotations ``held`` lie within ``recur`` radians of another one of them.

    A hold met again at the same rotation is a limit the solver clamps at, not a frozen channel (module docstring;
    :func:`~mocapkit.cleaning.ssa.cues.held_joints` asks the same of its holds). The (n, n) geodesic angles are
    taken a block of rows at a time, at most ``block_cells`` angles a block (at least one row): a long take has
    thousands of holds per joint, and the whole matrix's temporaries grow as its square. Each angle is the same
    elementwise expression whatever the block, so the answer is the same, bit for bit, for any ``block_cells``.
    """
    held = np.asarray(held, dtype=np.float64)
    n = len(held)
    out = np.zeros(n, dtype=bool)
    rows = max(1, int(block_cells) // max(n, 1))
    for r0 in range(0, n, rows):
        r1 = min(n, r0 + rows)
        near = R.geodesic_angle(held[r0:r1, None], held[None, :]) <= recur
        near[np.arange(r1 - r0), np.arange(r0, r1)] = False  # a hold is not its own recurrence
        out[r0:r1] = near.any(axis=1)
    return out


def frozen_channels(
    rotations: np.ndarray,
    breaks: np.ndarray,
    analysed: np.ndarray,
    fps: float,
    min_s: float = MIN_FROZEN_S,
    moving_share: float = MOVING_SHARE,
    recur_deg: float = 1.0,
    rest_deg: float = 0.01,
) -> np.ndarray:
    """(F, J) bool: the frames of each joint's frozen channels (see the module docstring): the repeats of each hold.

    ``rotations`` (F, J, 4) unit quaternions of the take; ``breaks`` (F, J)
    bool the joints' own breaks (:func:`~mocapkit.cleaning.ssa.cues.own_breaks`,
    a step from ``f`` to ``f + 1`` marking both frames); ``analysed`` (J,) bool
    the joints judged (others are never flagged and do not count as the body);
    ``fps`` the take's frame rate. A hold of frames ``a .. b - 1`` is flagged
    when it lasts at least ``min_s`` seconds (and 4 frames), ends in a break at
    frame ``b - 1`` or ``b``, and on average over its steps at least
    ``moving_share`` of the other analysed joints change their rotation; its
    frames ``a + 1 .. b - 1`` are flagged, not ``a``: the first of the held
    frames is the last sample the channel had before it froze (a corrupted
    HDM05 take whose frozen frames were flagged from ``a`` had that clean
    sample repaired too).
    """
    q = np.asarray(rotations, dtype=np.float64)
    breaks = np.asarray(breaks, dtype=bool)
    analysed = np.asarray(analysed, dtype=bool)
    if q.ndim != 3 or q.shape[2] != 4 or breaks.shape != q.shape[:2] or analysed.shape != q.shape[1:2]:
        raise ValueError(f"need rotations (F, J, 4), breaks (F, J) and analysed (J,), got {q.shape}, "
                         f"{breaks.shape} and {analysed.shape}")
    if not (fps > 0 and min_s >= 0 and 0 <= moving_share <= 1 and recur_deg >= 0 and rest_deg >= 0):
        raise ValueError(f"need fps > 0, min_s >= 0, 0 <= moving_share <= 1, recur_deg >= 0 and rest_deg >= 0, "
                         f"got {fps!r}, {min_s!r}, {moving_share!r}, {recur_deg!r} and {rest_deg!r}")
    F, J = q.shape[:2]
    out = np.zeros((F, J), dtype=bool)
    if F < 3 or analysed.sum() < 2:
        return out
    from scipy import ndimage

    same = np.all(q[1:] == q[:-1], axis=-1) & np.all(np.isfinite(q[1:]), axis=-1)  # (F - 1, J) steps
    moving = (~same[:, analysed]).sum(axis=1)  # (F - 1,) analysed joints changing their rotation at each step
    n_other = analysed.sum() - 1
    min_frames = max(4, int(np.ceil(min_s * fps)))
    recur, rest = np.radians(recur_deg), np.radians(rest_deg)
    for j in np.flatnonzero(analysed & same.any(axis=0)):
        if same[:, j].mean() > 0.5:
            continue
        labels, _ = ndimage.label(same[:, j])
        runs = [(run.start, run.stop + 1) for (run,) in ndimage.find_objects(labels)]  # held frames a .. b - 1
        runs = [(a, b) for a, b in runs if b - a >= min_frames]
        if not runs:
            continue
        held = q[[a for a, _ in runs], j]  # (n, 4)
        exempt = recurring(held, recur) | (R.geodesic_angle(held, R.identity()) <= rest)
        for (a, b), skip in zip(runs, exempt):
            if skip or b >= F or not breaks[b - 1 : b + 1, j].any():
                continue
            share = moving[a : b - 1].mean() / n_other  # j itself holds over these steps, so counts as still
            if share >= moving_share:
                out[a + 1 : b, j] = True  # frame a is the sample the channel froze at; the repeats of it are not
    return out
