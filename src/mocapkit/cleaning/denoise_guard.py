"""Do no harm in denoising: a cell the denoiser moved further than the take's noise explains is kept as it came.

A smoother reads every frame of its window. Where the take holds a jump no noise makes, it spreads the jump over
the good frames around it: HDM05's ``HDM_dg_squat1Reps_025_120.amc`` turns ``lfemur`` by 180 deg on frames 78-82
of the file itself (a flip in the source, not noise), and at 0.1 noise the EBF moved frame 77, a good frame, by
128 deg (the Savitzky-Golay fallback by 86), with nothing repaired. So :func:`guarded` runs the denoiser and finds
the cells it moved further than :func:`departure_bounds` (a bound tied to each joint's own noise level) that are
no noise sample:

* :func:`jump_cells`: a jump is a turn between neighbouring frames that white noise of the joint's level makes
  once in ``1 / SPIKE_P`` steps (:func:`jump_bounds`), or such a turn between the means of 2 to ``RUN_FRAMES``
  frames on either side (:func:`jump_steps`: under heavy noise a single step's bound passes 180 deg, and a flip
  held for a few frames is seen only between means; HDM05's squat at 0.5 noise). The frames between two jumps,
  fewer than those on either side, are a flip the file holds and are kept whole (CMU's ``backflip.amc`` turns
  hands and thumbs by 120-170 deg for one frame of its file; smoothed as noise, such a turn dragged the good
  frames beside it by up to 135 deg); beside a lone jump, the far cells it dragged are kept. Kept as it came, a
  flip stays the take's own for detection and repair to judge: a smoother cannot tell a flip in the file from a
  turn the body made, and what it made of one could not be undone;
* :func:`held_cells`: a far cell beside another far cell within the bound of it (two white-noise samples side
  by side, each past the bound, are about as rare as the square of one), while one large sample that happens to
  sit near one plain neighbour is noise's and stays the denoiser's (HDM05 grabHighR at 0.5 noise: kept, such a
  sample left the take 82 deg off);
* :func:`displaced_runs`: a run of 2 to ``RUN_FRAMES`` frames the denoiser moved the same way by more on average
  than noise moves such a mean (under heavy noise, a flip of a few frames none of whose frames alone is past
  what noise makes: the squat's at 0.5 noise).

Those cells are then missing to a second run (read around, as around a gap: their neighbours are denoised without
the jump), and come back as they came, bit for bit; a cell of the second run that is still held or a jump is
kept as it came too. The count and the joints are said in the step's note.

Rotations are (F, J, 4) unit quaternions (w, x, y, z), frames first; angles in degrees.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from .. import rotations as R
from .runs import true_runs
from ..motion import Motion
from ..words import frame_runs, plural

__all__ = ["midpoint_deviation", "noise_std", "departure_bounds", "jump_bounds", "far_cells",
           "held_cells", "displaced_runs", "jump_cells", "beside", "kept_cells", "kept_cells_line", "LINE_RUNS", "guard",
           "Guarded", "guarded", "guarded_take", "SIGMAS", "MARGIN_DEG", "SPIKE_P", "RUN_FRAMES", "JUMP_APART", "window_steps",
           "window_step_table", "jump_steps", "motion_speed"]

SIGMAS = 4.0  # the bound, in standard deviations of the noise along its widest axis: white noise passes it ~2e-4
MARGIN_DEG = 3.0  # added to the bound: what a smoother may move a clean cell by (a capture's own jitter)
RUN_FRAMES = 8  # the longest run :func:`displaced_runs` reads as one (a flip held for a few frames)
JUMP_APART = 2  # steps either side of a jump read between window means within which no other such jump is read
SPIKE_P = 1e-9  # the chance a cell of white noise passes :func:`jump_bounds` (a take of 1e6 cells: once in 1,000)
# a white noise sample n_t less the mean of its neighbours' has 1.5 times its variance; the median of |N(0, 1)|
_MEDIAN_ABS_NORMAL = 0.6745


@functools.cache
def _chi3_isf() -> float:
    """``chi(3).isf(SPIKE_P)``: where the ``SPIKE_P`` tail of the chi distribution with 3 degrees of freedom starts
    (6.7), computed on first use (importing ``scipy.stats`` takes ~0.5 s, which a take without noise never needs)."""
    from scipy.stats import chi

    return float(chi(3).isf(SPIKE_P))


def midpoint_deviation(rotations: np.ndarray) -> np.ndarray:
    """(F, J, 3) degrees: each cell's rotation away from the midpoint of its two neighbours in time (the normalised
    sum of the two quaternions, the geodesic midpoint), as a rotation vector in the midpoint's frame; NaN at the
    first and last frame and next to a missing cell. Smooth motion at capture rates leaves well under a degree;
    white noise shows whole, along its own axes."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.full(q.shape[:2] + (3,), np.nan)
    if len(q) < 3:
        return out
    a, b = q[:-2], q[2:]
    b = np.where(np.sum(a * b, axis=-1, keepdims=True) < 0.0, -b, b)
    mid = a + b
    mid /= np.maximum(np.linalg.norm(mid, axis=-1, keepdims=True), 1e-12)
    rel = R.quaternion_multiply(R.quaternion_conjugate(mid), q[1:-1])
    out[1:-1] = np.degrees(R.quaternion_to_rotvec(rel))
    return out


def noise_std(rotations: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(J,) degrees: the standard deviation of each joint's noise along its widest axis.

    The noise's std along each axis of :func:`midpoint_deviation` is its median absolute value over the joint's
    ``cells`` (F, J) (the ones being denoised: a take noisy in one stretch is judged by that stretch) over that of
    white noise; the widest axis counts (noise added to Euler channels is far wider along one axis than the
    others). The median is the robust choice: a few frames of a jump (a flip, a spike) do not raise it. A joint
    without a cell to judge by gets 0.
    """
    dev = np.abs(midpoint_deviation(rotations))
    dev = np.where(np.asarray(cells, dtype=bool)[..., None], dev, np.nan)
    J = dev.shape[1]
    std = np.zeros(J)
    judged = np.any(np.isfinite(dev[..., 0]), axis=0)
    if judged.any():
        med = np.nanmedian(dev[:, judged], axis=0)  # (judged, 3)
        std[judged] = med.max(axis=-1) / (_MEDIAN_ABS_NORMAL * np.sqrt(1.5))
    return std


def departure_bounds(rotations: np.ndarray, cells: np.ndarray, std: np.ndarray | None = None) -> np.ndarray:
    """(J,) degrees: how far a denoiser may move a cell of each joint, ``SIGMAS`` times :func:`noise_std` (over
    ``cells`` (F, J); ``std`` (J,): that std, already measured) plus ``MARGIN_DEG``."""
    return SIGMAS * (noise_std(rotations, cells) if std is None else std) + MARGIN_DEG


def jump_bounds(rotations: np.ndarray, cells: np.ndarray, std: np.ndarray | None = None) -> np.ndarray:
    """(J,) degrees: the turn between neighbouring frames that white noise of :func:`noise_std` (over ``cells``
    (F, J); ``std`` (J,): that std, already measured) passes once in ``1 / SPIKE_P`` steps, plus ``MARGIN_DEG``: a
    jump no noise sample makes.

    A step between two noisy frames carries the difference of two samples, ``sqrt(2)`` times the noise's std;
    read as isotropic at the widest axis's std (an upper bound on noise narrower along the other axes), its length
    follows the chi distribution with 3 degrees of freedom, whose ``SPIKE_P`` tail starts at 6.7 of its scale.
    """
    return _chi3_isf() * np.sqrt(2.0) * (noise_std(rotations, cells) if std is None else std) + MARGIN_DEG


def far_cells(before: np.ndarray, after: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """(F, J) bool: cells whose rotation ``after`` (F, J, 4) is more than their joint's ``bounds`` (J,) degrees from
    ``before``; a missing cell on either side is not far."""
    d = np.degrees(R.geodesic_angle(np.asarray(before, dtype=np.float64), np.asarray(after, dtype=np.float64)))
    return np.nan_to_num(d, nan=0.0) > np.asarray(bounds)[None, :]


def _steps(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, J) degrees each: every cell's turn from the frame before and to the frame after; NaN without one."""
    step = np.degrees(R.geodesic_angle(q[1:], q[:-1]))  # (F - 1, J)
    pad = np.full((1, q.shape[1]), np.nan)
    return np.concatenate([pad, step]), np.concatenate([step, pad])


def held_cells(rotations: np.ndarray, far: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """(F, J) bool: the ``far`` cells (F, J) that the take holds where they are: next to another far cell within
    their joint's ``bounds`` (J,) degrees of it (a run of far cells that agree: the frames of a flip held for
    several frames), or with no neighbour to judge by. A far cell whose neighbours are not far is what noise makes
    (a large sample, even one that happens to sit near one of them), and is left to the denoiser."""
    q = np.asarray(rotations, dtype=np.float64)
    far = np.asarray(far, dtype=bool)
    before, after = _steps(q)
    bounds = np.asarray(bounds)[None, :]
    pad = np.zeros((1, q.shape[1]), dtype=bool)
    far_before = np.concatenate([pad, far[:-1]])
    far_after = np.concatenate([far[1:], pad])
    agrees = (far_before & (np.nan_to_num(before, nan=np.inf) <= bounds)) | (
        far_after & (np.nan_to_num(after, nan=np.inf) <= bounds))
    alone = np.isnan(before) & np.isnan(after)
    return far & (agrees | alone)


def displaced_runs(rotations: np.ndarray, denoised: np.ndarray, cells: np.ndarray,
                   std: np.ndarray | None = None) -> np.ndarray:
    """(F, J) bool: the ``cells`` (F, J) in a run of 2 to ``RUN_FRAMES`` frames that ``denoised`` (F, J, 4) moved
    from ``rotations`` (F, J, 4) the same way on average, by more than noise moves such a mean.

    The denoiser's move of a cell (a rotation vector, degrees) is at most its noise sample where the take is
    noise; the mean of ``n`` independent samples has ``1 / sqrt(n)`` of their std, so a mean longer than
    ``chi(3).isf(SPIKE_P)`` times :func:`noise_std` over ``sqrt(n)``, plus ``MARGIN_DEG``, is a run the take holds
    (a flip of a few frames, each frame of which alone is within what heavy noise makes). A missing cell counts
    as not moved. ``std`` (J,): :func:`noise_std` of ``rotations`` over ``cells``, already measured."""
    q = np.asarray(rotations, dtype=np.float64)
    d = np.asarray(denoised, dtype=np.float64)
    cells = np.asarray(cells, dtype=bool)
    d = np.where(np.sum(q * d, axis=-1, keepdims=True) < 0.0, -d, d)
    move = np.nan_to_num(np.degrees(R.quaternion_to_rotvec(R.quaternion_multiply(R.quaternion_conjugate(d), q))))
    F, J = cells.shape
    total = np.concatenate([np.zeros((1, J, 3)), np.cumsum(move, axis=0)])  # (F + 1, J, 3)
    std = noise_std(q, cells) if std is None else std
    k = _chi3_isf()
    out = np.zeros((F, J), dtype=bool)
    for n in range(2, min(RUN_FRAMES, F) + 1):
        hit = np.linalg.norm(total[n:] - total[:-n], axis=-1) / n > (k * std / np.sqrt(n) + MARGIN_DEG)[None, :]
        for i in range(n):
            out[i:F - n + 1 + i] |= hit
    return out & cells


def window_steps(rotations: np.ndarray, n: int) -> np.ndarray:
    """(F - 1, J) degrees: at each step between frames ``f`` and ``f + 1`` of ``rotations`` (F, J, 4), the turn
    between the mean rotation of the ``n`` frames up to ``f`` and that of the ``n`` frames from ``f + 1`` (each the
    normalised sum of its quaternions, signs made continuous in time: the chordal mean, which averages small-angle
    noise like vectors); NaN where a window leaves the take or holds a missing cell. ``n = 1`` is the plain step.
    """
    return _steps_of(_window_sums(np.asarray(rotations, dtype=np.float64)), n)


def window_step_table(rotations: np.ndarray, most: int) -> np.ndarray:
    """(most, F - 1, J) degrees: :func:`window_steps` of ``rotations`` (F, J, 4) for ``n`` = 1 to ``most`` (row
    ``n - 1``), the signs and running sums they share made once."""
    sums = _window_sums(np.asarray(rotations, dtype=np.float64))
    return np.stack([_steps_of(sums, n) for n in range(1, most + 1)])


def _window_sums(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The running sums :func:`window_steps` reads its means from: of ``q`` (F, J, 4) with signs made continuous in
    time, (F + 1, J, 4), and of its missing cells, (F + 1, J)."""
    F, J = q.shape[:2]
    gone = np.isnan(q).any(axis=-1)
    a = np.nan_to_num(q)
    flip = np.concatenate([np.zeros((1, J), bool), np.sum(a[1:] * a[:-1], axis=-1) < 0.0])
    a = np.where((np.cumsum(flip, axis=0) % 2 == 1)[..., None], -a, a)  # each frame on its neighbour's side
    total = np.concatenate([np.zeros((1, J, 4)), np.cumsum(a, axis=0)])  # (F + 1, J, 4)
    holes = np.concatenate([np.zeros((1, J)), np.cumsum(gone, axis=0)])
    return total, holes


def _steps_of(sums: tuple[np.ndarray, np.ndarray], n: int) -> np.ndarray:
    total, holes = sums
    F, J = total.shape[0] - 1, total.shape[1]
    out = np.full((max(F - 1, 0), J), np.nan)
    if F < 2 * n:
        return out
    mean = total[n:] - total[:-n]  # (F - n + 1, J, 4): frames i .. i + n - 1
    whole = (holes[n:] - holes[:-n]) == 0
    norm = np.linalg.norm(mean, axis=-1, keepdims=True)
    ok = whole & (norm[..., 0] > 1e-9)
    mean = np.where(ok[..., None], mean / np.maximum(norm, 1e-12), np.array([1.0, 0.0, 0.0, 0.0]))
    before, after = mean[:F - 2 * n + 1], mean[n:]  # windows ending at frame f, starting at f + 1 (f = n-1 .. F-n-1)
    step = np.degrees(R.geodesic_angle(before, after))
    out[n - 1:F - n] = np.where(ok[:F - 2 * n + 1] & ok[n:], step, np.nan)
    return out


def motion_speed(denoised: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(J,) degrees a frame: each joint's typical turn between neighbouring frames of ``denoised`` (F, J, 4), the
    median over the steps between two of its ``cells`` (F, J) (0 without one): how fast the motion under the noise
    moves, which the median reads past the few frames a denoiser smeared a jump over."""
    d = np.asarray(denoised, dtype=np.float64)
    cells = np.asarray(cells, dtype=bool)
    step = window_steps(d, 1)
    step = np.where(cells[1:] & cells[:-1], step, np.nan)
    out = np.zeros(d.shape[1])
    some = np.any(np.isfinite(step), axis=0)
    if some.any():
        out[some] = np.nanmedian(step[:, some], axis=0)
    return out


def jump_steps(rotations: np.ndarray, bounds: np.ndarray, speed: np.ndarray | None = None,
               table: np.ndarray | None = None) -> np.ndarray:
    """(F - 1, J) bool: the steps of ``rotations`` (F, J, 4) between frames ``f`` and ``f + 1`` that are a jump.

    A jump is a turn :func:`jump_bounds` (``bounds`` (J,) degrees) says noise makes once in ``1 / SPIKE_P`` steps,
    read between single frames and, where ``speed`` (J,) (degrees a frame: how fast each joint moves) is given,
    between the means of ``n`` = 2 to ``RUN_FRAMES`` frames on either side (:func:`window_steps`; only where the
    step's share of its bound, the largest over ``n``, peaks within ``JUMP_APART`` steps: windows that straddle one
    jump all read it, and noise moves their peak by a frame or two): the mean of
    ``n`` noise samples has ``1 / sqrt(n)`` of their std, so its bound is ``(bounds - MARGIN_DEG) / sqrt(n) +
    MARGIN_DEG`` plus the ``(n - 1) * speed`` the joint turns as the windows' centres move ``n - 1`` frames further
    apart. Under heavy noise a single step's bound passes 180 deg (at a std of 18.6 deg), where no turn reaches
    it: a flip the file holds for a few frames is still plain between the means (HDM05 squat 025 at 0.5 noise,
    lfemur's 180-deg flip on frames 78-82 at a std of 23 deg: single-step bound 221 deg, 5-frame bound 100).
    ``table``: :func:`window_step_table` of ``rotations`` to ``RUN_FRAMES`` or more, when already made."""
    q = np.asarray(rotations, dtype=np.float64)
    bounds = np.asarray(bounds, dtype=np.float64)
    if speed is not None and table is None:
        table = window_step_table(q, RUN_FRAMES)
    jump = np.nan_to_num(window_steps(q, 1) if table is None else table[0], nan=0.0) > bounds[None, :]
    if speed is None:
        return jump
    score = np.zeros_like(jump, dtype=np.float64)  # the largest share of its bound a window step reaches
    for n in range(2, RUN_FRAMES + 1):
        bound_n = (bounds - MARGIN_DEG) / np.sqrt(n) + MARGIN_DEG + (n - 1) * np.asarray(speed)
        score = np.fmax(score, np.nan_to_num(table[n - 1], nan=0.0) / bound_n[None, :])
    from scipy.ndimage import maximum_filter1d  # here: importing scipy.ndimage takes ~0.2 s

    peak = score >= maximum_filter1d(score, size=2 * JUMP_APART + 1, axis=0, mode="nearest")
    return jump | (peak & (score > 1.0))


def jump_cells(rotations: np.ndarray, far: np.ndarray, bounds: np.ndarray,
               speed: np.ndarray | None = None, table: np.ndarray | None = None) -> np.ndarray:
    """(F, J) bool: the cells a jump in the take explains, of ``rotations`` (F, J, 4) whose ``far`` cells (F, J) a
    denoiser moved too far. A jump is a step :func:`jump_steps` finds (``bounds`` (J,): :func:`jump_bounds`;
    ``speed`` (J,): :func:`motion_speed`, None: single steps only; ``table``: :func:`window_step_table` of
    ``rotations``, when already made).

    Per joint with a far cell, the frames between two jumps that are fewer than the frames before and after them
    (a flip the file holds for a stretch, a one-frame flip included) are returned whole when one of them, or a
    frame beside them, is far: the flip is the file's, and its frames, judged by their own neighbours, would move
    towards the frames around it (under heavy noise the denoiser may drag the good frames beside a flip further
    than the flip's own: HDM05 squat 025 at 0.5 noise, seed 0, frames 77 and 83 beside the flip 78-82). Each run
    of far cells that touches a jump is returned too (the frames a smoother dragged towards it), but for one beside
    a flip returned whole (read around, the flip drags no more)."""
    q = np.asarray(rotations, dtype=np.float64)
    far = np.asarray(far, dtype=bool)
    F, J = far.shape
    out = np.zeros((F, J), dtype=bool)
    jump = np.zeros((max(F - 1, 0), J), dtype=bool)  # (F - 1, J): only the joints with a far cell are read
    cols = np.flatnonzero(far.any(axis=0))  # (each joint's steps are its own: the others' would be thrown away)
    if len(cols):
        jump[:, cols] = jump_steps(q[:, cols], np.asarray(bounds)[cols], None if speed is None else np.asarray(speed)[cols],
                                   None if table is None else table[:, :, cols])
    for j in np.flatnonzero(jump.any(axis=0)):
        cuts = np.flatnonzero(jump[:, j]) + 1  # the first frame after each jump
        edges = np.concatenate([[0], cuts, [F]])
        size = np.diff(edges)
        flip = np.zeros(F, dtype=bool)
        for k in range(1, len(cuts)):
            a, b = edges[k], edges[k + 1]
            if size[k] < size[k - 1] and size[k] < size[k + 1] and far[a - 1:b + 1, j].any():
                flip[a:b] = True
        out[:, j] = flip
        for first, last in true_runs(far[:, j] & ~flip):
            touch = cuts[(cuts >= first) & (cuts <= last + 1)]
            if any(not flip[c - 1] if c == first else not flip[c] for c in touch):
                out[first:last + 1, j] = True
    return out


def beside(kept: np.ndarray, far: np.ndarray) -> np.ndarray:
    """(F, J) bool: the ``far`` cells (F, J) joined to a ``kept`` cell (F, J) by a run of far cells in time."""
    kept, far = np.asarray(kept, dtype=bool), np.asarray(far, dtype=bool)
    out = np.zeros_like(far)
    for j in np.flatnonzero(kept.any(axis=0)):
        k = kept[:, j]
        for first, last in true_runs(far[:, j] | k):
            if k[first:last + 1].any():
                out[first:last + 1, j] = True
    return out & far & ~kept


#: the runs of one joint's kept cells :func:`kept_cells_line` names; past them, a count
LINE_RUNS = 6


def kept_cells_line(kept: np.ndarray, names, what: str = "kept as they came") -> str:
    """The line naming the cells ``kept`` (F, J) bool at the take's frames: their count, ``what`` was done with them
    and why (the denoiser moved them further than the take's noise explains), and the runs of each of the first
    three joints (``names``: the take's joint names), each run exactly (:func:`~mocapkit.words.frame_runs`, at most
    :data:`LINE_RUNS`; one span from the first kept frame to the last would name frames between them that the
    denoiser or a repair changed). "" for none."""
    kept = np.asarray(kept, dtype=bool)
    if not kept.any():
        return ""
    joints = np.flatnonzero(kept.any(axis=0))
    said = ", ".join(f"{names[j]} {frame_runs(true_runs(kept[:, j]), most=LINE_RUNS)}" for j in joints[:3])
    more = f" and {len(joints) - 3} more joints" if len(joints) > 3 else ""
    return (f"{plural(int(kept.sum()), 'cell')} {what}: the denoiser moved them further than the take's noise "
            f"explains ({said}{more}; frames from 0)")


def kept_cells(rotations: np.ndarray, denoised: np.ndarray, judged: np.ndarray,
               std: np.ndarray | None = None, memo: dict | None = None) -> np.ndarray:
    """(F, J) bool: the cells of ``judged`` (F, J) that :func:`guarded` keeps as they came, of ``rotations`` (F, J, 4)
    denoised into ``denoised`` (F, J, 4): of those moved further than :func:`departure_bounds` (:func:`far_cells`),
    the ones a jump explains (:func:`jump_cells`) and, of the others not beside them (frames the jump dragged,
    which a run around the jump denoises), the held ones (:func:`held_cells`); and the runs moved further on
    average than noise explains (:func:`displaced_runs`). Bounds from the noise of ``judged`` (``std`` (J,): its
    :func:`noise_std`, already measured). ``memo``: a dict kept between calls on the same ``rotations`` (the
    columns of its :func:`window_step_table` made so far).

    Every test reads each joint on its own, so only the joints with a judged cell are read (a joint without one
    keeps none), and past the far cells only the joints with a far cell (on a 60 s take at 120 fps with three
    noisy joints, three and then one or two of 31): the same cells as reading them all, at a tenth of the work."""
    q = np.asarray(rotations, dtype=np.float64)
    judged = np.asarray(judged, dtype=bool)
    out = np.zeros(judged.shape, dtype=bool)
    joints = np.flatnonzero(judged.any(axis=0))
    if not len(joints):
        return out
    q, judged = q[:, joints], judged[:, joints]
    den = np.asarray(denoised, dtype=np.float64)[:, joints]
    std = noise_std(q, judged) if std is None else np.asarray(std)[joints]  # once for the three bounds below
    bounds = departure_bounds(q, judged, std)
    far = far_cells(q, den, bounds) & judged
    runs = displaced_runs(q, den, judged, std)
    if far.any():
        cols = np.flatnonzero(far.any(axis=0))  # the others hold no far cell: no jump, no held cell
        qc, fc = q[:, cols], far[:, cols]
        table = _table_columns(q, cols, joints[cols], {} if memo is None else memo)
        jumps = jump_cells(qc, fc, jump_bounds(q, judged, std)[cols], motion_speed(den[:, cols], judged[:, cols]),
                           table)
        runs[:, cols] |= jumps | held_cells(qc, fc & ~jumps & ~beside(jumps, fc), bounds[cols])
    out[:, joints] = runs
    return out


def _table_columns(q: np.ndarray, cols: np.ndarray, joints: np.ndarray, memo: dict) -> np.ndarray:
    """(RUN_FRAMES, F - 1, len(cols)) degrees: :func:`window_step_table` of ``q`` (F, K, 4) to ``RUN_FRAMES``, of
    its columns ``cols`` alone (each joint's windows are its own: the same numbers as the whole table's columns),
    which are the take's ``joints``; each joint's made is kept in ``memo`` (``"columns"``: joint -> (RUN_FRAMES,
    F - 1)) for a later call on the same take."""
    made = memo.setdefault("columns", {})
    new = [i for i, j in enumerate(joints) if int(j) not in made]
    if new:
        table = window_step_table(q[:, cols[new]], RUN_FRAMES)
        for k, i in enumerate(new):
            made[int(joints[i])] = table[:, :, k]
    return np.stack([made[int(j)] for j in joints], axis=-1)


@dataclasses.dataclass(frozen=True)
class Guarded:
    """What :func:`guard` made of a denoise: ``motion`` denoised, the run's ``method`` and ``note`` (a fallback, a
    licence: the run's own words), and ``kept`` (F, J) bool, the cells kept as they came (bit-identical to the
    input), which :attr:`said` names ("" for none); ``measured``: :func:`guarded_take`'s line naming the filled
    cells whose measured channels were kept ("" for none, or not asked)."""

    motion: Motion
    method: str
    note: str
    kept: np.ndarray
    measured: str = ""

    @property
    def said(self) -> str:
        """The line naming the kept cells (count, joints, frames), "" when none is kept."""
        return kept_cells_line(self.kept, self.motion.skeleton.joint_names)

    @property
    def lines(self) -> list[str]:
        """Its lines, each one on its own (``clean`` says each as a note of its own): the run's note, :attr:`said`,
        :attr:`measured`, those that say something."""
        return [x for x in (self.note, self.said, self.measured) if x]

    def as_tuple(self) -> tuple[Motion, str, str]:
        """``(motion, method, note)``, :attr:`lines` joined by "; " into the one note the ``denoise`` command,
        :func:`guarded` and :func:`~mocapkit.cleaning.whole_take.denoise_take` give."""
        return self.motion, self.method, "; ".join(self.lines)


def guard(motion: Motion, cells: np.ndarray | None, run, keep: np.ndarray | None = None) -> Guarded:
    """Denoise ``motion`` by ``run(motion, cells) -> (motion, method, note)`` (only ``cells`` (F, J), None: every
    non-root joint), keeping as they came the cells :func:`kept_cells` finds (a flip, held, a run; module docstring),
    read around by a second run; :class:`Guarded` says them.

    ``keep`` (F, J) bool: cells kept as they came whatever this take's judgement, read around as the ones found are:
    ``clean`` denoises again after its repair, and the cells its first denoise kept are kept in the take it writes
    (a judgement made afresh on the repaired take let the denoiser move cells it had said were kept as they came:
    a Bandai punch at 0.3 noise, Head frames 249-257, moved by up to 25 deg)."""
    F, J = motion.num_frames, motion.num_joints
    judged = np.zeros((F, J), dtype=bool)
    if cells is None:
        judged[:, 1:] = True
    else:
        judged[:] = np.asarray(cells, dtype=bool)
    out, method, note = run(motion, cells)
    std = np.zeros(J)  # the take's noise: the same for both runs' judgements (0 where no cell is judged)
    joints = np.flatnonzero(judged.any(axis=0))
    std[joints] = noise_std(motion.rotations[:, joints], judged[:, joints])
    memo: dict = {}  # and the take's window steps
    kept = kept_cells(motion.rotations, out.rotations, judged, std, memo)
    if keep is not None:
        kept |= np.asarray(keep, dtype=bool) & judged
    if not kept.any():
        return Guarded(out, method, note, kept)
    around = motion.with_rotations(np.where(kept[..., None], np.nan, motion.rotations))  # Euler angles: the kept cells'
    out, method, note = run(around, judged & ~kept)
    kept |= kept_cells(motion.rotations, out.rotations, judged, std, memo)
    rot = np.where(kept[..., None], motion.rotations, out.rotations)
    return Guarded(dataclasses.replace(out, rotations=rot), method, note, kept)


def guarded(motion: Motion, cells: np.ndarray | None, run) -> tuple[Motion, str, str]:
    """:func:`guard`'s ``(motion, method, note)``, the note saying the kept cells when there are any; every kept
    cell is bit-identical to the input."""
    return guard(motion, cells, run).as_tuple()


def guarded_take(motion: Motion, cells: np.ndarray | None, run, *, zeros=None, measured: bool = True,
                 keep: np.ndarray | None = None) -> Guarded:
    """The denoise of a take that ``mocapkit denoise``, ``clean``'s denoise step
    (:func:`mocapkit.cleaning.whole_take.denoise_guarded`, :func:`~mocapkit.cleaning.whole_take.denoise_take`) and
    :func:`mocapkit.cleaning.deep.denoise` share: ``run`` (as for :func:`guard`) under :func:`guard` (``keep`` passed
    on: ``clean``'s denoise after its repair keeps the cells its first denoise kept), with the take's channels
    written as 0 where the capture lost data (:func:`~mocapkit.cleaning.zeros.find_zeros`; ``zeros``: its result
    when the caller has it) missing to ``run`` and back as written, and a filled cell's measured channels kept where
    its missing ones explain the denoise (:func:`~mocapkit.cleaning.measured.keep_measured_in_denoise`, said in
    :attr:`Guarded.measured`; ``measured`` False: left to a caller that has the whole take of a part it denoises).
    Returns the :class:`Guarded`; every kept cell is bit-identical to the input."""
    from .measured import keep_measured_in_denoise, kept_note
    from .zeros import as_missing, find_zeros

    zc, runs, zf = find_zeros(motion) if zeros is None else zeros
    src = as_missing(motion, zc, zf) if runs else motion
    done = guard(src, cells, run, keep)
    if runs:  # the lost samples as written; positions, which denoising keeps, as they were
        rot = np.where(zc[..., None], motion.rotations, done.motion.rotations)
        done = dataclasses.replace(done, motion=dataclasses.replace(
            done.motion, rotations=rot, root_positions=motion.root_positions, translations=motion.translations))
    if measured:  # a filled cell's measured channels kept where its missing ones explain the denoise
        out, kept, stood = keep_measured_in_denoise(motion, done.motion)
        done = dataclasses.replace(done, motion=out,
                                   measured=kept_note(kept, motion.skeleton.joint_names, "denoise", stood))
    return done

