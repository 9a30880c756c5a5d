"""Smooth drifts: digressions with no break, flagged where the context repeats the motion (section 3.4).

Confirmation by a break (:func:`~mocapkit.cleaning.ssa.confirm_flags`) keeps the
detector from flagging motion the context has not seen, but it cannot see what
the movement digression map exists to show (Aristidou et al. 2018, section 3.4
and Figure 1): one joint that leaves the path its neighbour words take, smoothly,
and comes back, with no step anywhere (a slipping marker cluster, a drifting
inertial sensor, a solver easing into a wrong pose).

Where the context repeats the motion, such a digression can be told from
unseen motion by the rest of the body: the neighbour words match the other
joints closely (the context holds this motion), they agree among themselves on
the joint (their spread is small), and the joint alone is far from them. The
statistic, per cell ``(f, j)``:

- ``agreement``: the median, over the other joints of the group whose
  neighbours judge the cell, of their angle from that group's mean motion
  texture at frame ``f`` (radians) -- how well the neighbours that judge the
  joint match the rest of the body (:func:`group_agreement`);
- ``consistency``: the joint's angle from the mean texture over the
  neighbours' spread at the cell and the capture noise, ``a / sqrt(s^2 +
  noise^2)`` (the ``"spread"`` z-score of :func:`detect`).

A run of cells that digress by more than the capture noise and holds no
break is cut into excursions (:func:`excursions`): the joint leaves its
neighbours, peaks and comes back, and where it comes back to within
``return_ratio`` of a peak's consistency before leaving again, a new
excursion begins. An excursion is a smooth drift when, for at least
``min_s`` seconds of it, ``agreement <= repeat_deg`` and ``consistency >=
z_min`` while at most ``others`` other joints digress that strongly at the
same frame (:func:`other_joints_level`) and its left/right partner does not
digress by half as much, nor its parent or one of its children
(:func:`chain_level`): it is flagged whole, down to where the joint is
back among its neighbours. One joint drifts; two may at once. A take whose
style the context lacks moves several joints together away from their
neighbours (both arms of a bow held otherwise, an arm and its hand), and
that is no drift of any one of them; a style is often two-sided, a drift
one joint's; a style bends a chain (a head bowed with the neck, an arm
raised with the elbow opened), while a drift turns one joint and leaves
its children's local rotations on their path. Nor is a digression of a
style next to a drift part of the drift: each excursion is judged alone.

Two drifts at once on a left/right pair or on a parent and its child stop
each other at those gates. They are told from a style by the direction of
the changes (:func:`crossed_turns`): a two-sided style turns both sides the
same way (on the rigs whose mirror keeps local rotations), a bent chain
turns parent and child about one axis, while two drifts turn each joint
about its own axis. Where an excursion one of those gates alone stops, and
its neighbour is stopped or flagged too, turns about an axis crossed with
the neighbour's (``cross_cos``), both are drifts.

An excursion cut by the take's first or last frame must show the part the
take cuts: between that edge and its peak the joint comes back to within
``return_ratio`` of the peak's consistency. One that starts (or ends) at its
peak is a pose held from before the take began (or after it ended): the
idle poses at a take's edges, where styles differ most, are not what the
context is asked about.

A performer's style holds a joint off its neighbours' path, often for the
whole take (an elbow carried higher, a head held lower): that is a
digression of the same direction at every frame, and it is no drift. So the
evidence of a cell is the joint's ``change`` (:func:`offset_change`): its
offset from the mean texture less the offset it holds over the take (the
median), over the same spread and noise, in place of ``consistency``; both
offsets are taken in the joint group that judges the cell, against that
group's own mean texture (:func:`group_offset_change`: the groups'
neighbours differ, and so does the offset a style holds from each). A
drift changes the offset and comes back; a style keeps it. Where a drift
turns the joint back across the offset its style holds, towards the
neighbours' mean, ``consistency`` falls at the drift's height while the
change does not.

Where the context does not repeat the motion (the rest of the
body digresses too) nothing is flagged here: a lone joint's
digression is then indistinguishable from motion the context lacks. For the
same reason :func:`~mocapkit.cleaning.ssa.detect` looks for smooth drifts only
against a context beyond the take itself: analysed alone, a take that raises
one arm once (a wave, a reach) shows exactly what a drift shows, the arm far
from neighbour words (the take's other moments) that match the rest of the
body. Nor on the pelvis or the root, whose rotation carries the path's heading
on rigs whose root stays on the floor. Nor can any statistic here tell a
drift from a joint whose style the context lacks when that joint alone
differs, smoothly and once, inside the take (a take of a style no context
take shares, the arms of a dancing walk): the context cannot confirm what it
does not repeat, and such cells are flagged.
"""

from __future__ import annotations

import numpy as np

__all__ = ["body_agreement", "chain_level", "crossed_turns", "excursions", "group_agreement", "group_offset_change",
           "group_offset_turn", "not_looked_for", "offset_change", "offset_turn", "other_joints_level",
           "smooth_drift_flags"]


def not_looked_for(has_context: bool, default: bool) -> str:
    """The one line a detection says when smooth drifts were asked for but the rule did not run, else "".

    The rule runs only against a context the caller chose that repeats the take's motion (module docstring): with
    none (``has_context`` False: the take analysed alone) or the bundled default context (``default``), nothing
    could be flagged as a drift, and a count of flags must not read as "no drift found".
    """
    if has_context and not default:
        return ""
    which = "the bundled default context, a general sample," if has_context else "no context"
    return (f"smooth drifts not looked for: the drift rule needs a context that repeats the take's motion "
            f"(--context; context= in Python), and {which} repeats none")


def body_agreement(digression: np.ndarray, analysed: np.ndarray) -> np.ndarray:
    """(F, J) median angle from the mean motion texture of the *other* analysed joints at each frame.

    ``digression`` float (F, J) angles in radians (NaN where not analysed or
    not judged); ``analysed`` bool (J,). The value at ``(f, j)`` leaves joint
    ``j`` itself out, so a drifting joint does not lower its own evidence.
    NaN on joints not analysed, at frames where no other joint has a value,
    and everywhere when fewer than two joints are analysed.
    """
    d = np.asarray(digression, dtype=np.float64)
    analysed = np.asarray(analysed, dtype=bool)
    if d.ndim != 2 or analysed.shape != (d.shape[1],):
        raise ValueError(f"need digression (F, J) and analysed (J,), got {d.shape} and {analysed.shape}")
    out = np.full(d.shape, np.nan)
    cols = np.flatnonzero(analysed)
    if len(cols) < 2:
        return out
    sub = d[:, cols]
    for i, j in enumerate(cols):
        rest = np.delete(sub, i, axis=1)
        ok = np.isfinite(rest).any(axis=1)
        if ok.any():
            out[ok, j] = np.nanmedian(rest[ok], axis=1)
    return out


def group_agreement(digression: np.ndarray, best: np.ndarray) -> np.ndarray:
    """(F, m) :func:`body_agreement` within each joint group, read from the group that judges the cell.

    ``digression`` float (G, F, m): per joint group (section 3.1), each joint's angle from that group's mean
    motion texture (radians; NaN where the group does not hold the joint or judge the cell); ``best`` int (F, m)
    the group whose neighbours explain each cell best (``Detection.best_group``). The value at ``(f, j)`` is the
    median angle of the *other* joints of group ``best[f, j]`` from that group's mean texture: how closely the
    neighbour words that judge the joint match the rest of the body. Each joint's smallest angle over the groups
    (``Detection.digression``, what :func:`body_agreement` reads) takes every other joint's closest words,
    which are not the joint's: with more groups to choose from (the Bandai Namco rig's ``upper`` group beside
    ``whole``, ``left`` and ``right``) the body seems to agree where the words that judge the joint do not, and
    untouched takes get drift flags. NaN where that group has no other joint's value.
    """
    d = np.asarray(digression, dtype=np.float64)
    best = np.asarray(best)
    if d.ndim != 3 or best.shape != d.shape[1:]:
        raise ValueError(f"need digression (G, F, m) and best (F, m), got {d.shape} and {best.shape}")
    if d.shape[0] == 0:
        return np.full(best.shape, np.nan)
    return _at_best(np.stack([body_agreement(d[g], np.isfinite(d[g]).any(axis=0)) for g in range(d.shape[0])]), best)


def offset_turn(offsets: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """(F, J, 3) the turn by which each joint's offset from its neighbours differs from the offset it holds.

    ``offsets`` float (F, J, 3) and ``scale`` float (F, J) as :func:`offset_change` reads them. Returns
    ``offset(f) - m`` (a rotation vector in the parent joint's frame, radians), ``m`` the joint's component-wise
    median offset over its judged frames: the direction of the change whose length over ``scale`` is
    :func:`offset_change`. NaN where ``offsets`` or ``scale`` is not finite or ``scale`` is not positive.
    """
    r = np.asarray(offsets, dtype=np.float64)
    scale = np.asarray(scale, dtype=np.float64)
    if r.ndim != 3 or r.shape[2] != 3 or scale.shape != r.shape[:2]:
        raise ValueError(f"need offsets (F, J, 3) and scale (F, J), got {r.shape} and {scale.shape}")
    ok = np.isfinite(r).all(axis=2) & np.isfinite(scale) & (scale > 0)
    out = np.full(r.shape, np.nan)
    for j in np.flatnonzero(ok.any(axis=0)):
        rows = ok[:, j]
        out[rows, j] = r[rows, j] - np.median(r[rows, j], axis=0)
    return out


def offset_change(offsets: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """(F, J) how far each joint's offset from its neighbours moves away from the offset it holds over the take.

    ``offsets`` float (F, J, 3): the turn, in the parent joint's frame, from
    the mean motion texture's rotation of the joint to the take's at each
    frame, as a rotation vector (radians; NaN where the cell is not judged).
    An elbow carried higher is the same turn at every frame. ``scale`` float
    (F, J): the cell's neighbours' spread and capture noise combined
    (radians, the denominator of ``consistency``). Returns ``|offset(f) - m|
    / scale(f)`` with ``m`` the joint's component-wise median offset over its
    judged frames: 0 for a joint held off its neighbours by the same turn
    throughout (a style), about the ``consistency`` of a cell whose joint
    otherwise follows its neighbours.
    NaN where ``offsets`` or ``scale`` is not finite or ``scale`` is not
    positive. A drift covering more than half of a joint's judged frames moves
    the median, and its change is then measured from the drifted offset.
    """
    turn = offset_turn(offsets, scale)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.linalg.norm(turn, axis=2) / np.asarray(scale, dtype=np.float64)


def group_offset_change(offsets: np.ndarray, scale: np.ndarray, best: np.ndarray,
                        turn: np.ndarray | None = None) -> np.ndarray:
    """(F, m) :func:`offset_change` measured in each joint group, read from the group that judges the cell.

    ``offsets`` float (G, F, m, 3) and ``scale`` float (G, F, m): per joint group (section 3.1), the turn from that
    group's mean motion texture to the take (rotation vectors, radians; NaN where the group does not hold the
    joint or judge the cell) and that group's spread and noise; ``best`` int (F, m) the group whose neighbours
    explain each cell best (``Detection.best_group``). The offset a style holds is taken in each group against
    that group's own mean texture, and the cell reads its best group's change. Each group's neighbours pass
    differently close to the take, so the offset a joint holds differs from group to group; a median over the
    take of the offsets of whichever group was best at each frame mixes them, and where the best group changes
    the joint's offset seems to change with no drift at all (on the Bandai Namco rig, where an ``upper`` group
    judges the spine, head and arms beside ``whole``, ``left`` and ``right``). ``turn``: the change's direction,
    :func:`group_offset_turn` of the same arrays, where the caller has it (None: taken here); the change is its
    length over the best group's scale.
    """
    r, scale, best = _group_arrays(offsets, scale, best)
    if r.shape[0] == 0:
        return np.full(best.shape, np.nan)
    turn = group_offset_turn(r, scale, best) if turn is None else np.asarray(turn, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.linalg.norm(turn, axis=2) / _at_best(scale, best)


def group_offset_turn(offsets: np.ndarray, scale: np.ndarray, best: np.ndarray) -> np.ndarray:
    """(F, m, 3) :func:`offset_turn` taken in each joint group, read from the group that judges the cell.

    ``offsets`` (G, F, m, 3), ``scale`` (G, F, m) and ``best`` (F, m) as :func:`group_offset_change` reads them:
    the direction of the change whose length that function gives (radians, rotation vectors in the parent joint's
    frame; NaN where ``best`` names no group or the group does not judge the cell).
    """
    r, scale, best = _group_arrays(offsets, scale, best)
    if r.shape[0] == 0:
        return np.full(best.shape + (3,), np.nan)
    return _at_best(np.stack([offset_turn(r[g], scale[g]) for g in range(r.shape[0])]), best)


def _group_arrays(offsets, scale, best) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``offsets`` (G, F, m, 3), ``scale`` (G, F, m) float and ``best`` (F, m) as arrays, their shapes checked."""
    r = np.asarray(offsets, dtype=np.float64)
    scale = np.asarray(scale, dtype=np.float64)
    best = np.asarray(best)
    if r.ndim != 4 or r.shape[3] != 3 or scale.shape != r.shape[:3] or best.shape != r.shape[1:3]:
        raise ValueError(f"need offsets (G, F, m, 3), scale (G, F, m) and best (F, m), got {r.shape}, "
                         f"{scale.shape} and {best.shape}")
    return r, scale, best


def _at_best(per_group: np.ndarray, best: np.ndarray) -> np.ndarray:
    """(F, m, ...) ``per_group`` (G, F, m, ...) read at each cell's group ``best`` (F, m); NaN where ``best`` names
    none."""
    ok = (best >= 0) & (best < per_group.shape[0])
    extra = (1,) * (per_group.ndim - 3)
    at = np.where(ok, best, 0).reshape((1,) + best.shape + extra)
    return np.where(ok.reshape(ok.shape + extra), np.take_along_axis(per_group, at, axis=0)[0], np.nan)


def other_joints_level(consistency: np.ndarray, judged: np.ndarray, others: int = 1) -> np.ndarray:
    """(F, J) the ``others + 1``-th largest ``consistency`` among the *other* judged joints at each frame.

    ``consistency`` float (F, J) (NaN: no value, never counted); ``judged``
    bool (F, J), the cells whose joint may carry a drift (the others are left
    out of every count). The value at ``(f, j)`` leaves ``j`` itself out: it
    is below ``z`` where at most ``others`` other joints digress by ``z`` or
    more at frame ``f``. ``-inf`` where fewer than ``others + 1`` other
    joints have a value.
    """
    c = np.asarray(consistency, dtype=np.float64)
    judged = np.asarray(judged, dtype=bool)
    if c.ndim != 2 or judged.shape != c.shape:
        raise ValueError(f"need consistency and judged of one (F, J) shape, got {c.shape} and {judged.shape}")
    if int(others) != others or others < 0:
        raise ValueError(f"others must be a whole number >= 0, got {others!r}")
    k = int(others)
    v = np.where(judged & np.isfinite(c), c, -np.inf)
    pad = np.full((v.shape[0], k + 2), -np.inf)
    top = -np.sort(-np.concatenate([v, pad], axis=1), axis=1)[:, : k + 2]  # descending, at least k + 2 columns
    # j among the k + 1 largest: the others' (k + 1)-th largest is the (k + 2)-th of all; else the (k + 1)-th
    return np.where(v >= top[:, [k]], top[:, [k + 1]], top[:, [k]])


def chain_level(consistency: np.ndarray, judged: np.ndarray, parents) -> np.ndarray:
    """(F, J) the largest ``consistency`` of a joint's parent and children among the judged joints, per frame.

    ``consistency`` float (F, J) (NaN: no value, never counted); ``judged``
    bool (F, J), the cells whose joint may carry a drift (the others are left
    out); ``parents`` (J,) the skeleton's parent indices (-1 at the root). A
    style bends a chain of joints together; a drift turns one joint, and its
    children's local rotations keep their path. ``-inf`` where no parent or
    child has a value.
    """
    c = np.asarray(consistency, dtype=np.float64)
    judged = np.asarray(judged, dtype=bool)
    parents = np.asarray(parents, dtype=np.int64)
    if c.ndim != 2 or judged.shape != c.shape or parents.shape != (c.shape[1],):
        raise ValueError(f"need consistency and judged of one (F, J) shape and parents (J,), got {c.shape}, "
                         f"{judged.shape} and {parents.shape}")
    v = np.where(judged & np.isfinite(c), c, -np.inf)
    out = np.full(c.shape, -np.inf)
    child = np.flatnonzero(parents >= 0)
    up = parents[child]
    # each joint takes its parent's value, and each parent the largest of its children's
    out[:, child] = np.maximum(out[:, child], v[:, up])
    np.maximum.at(out.T, up, v[:, child].T)
    return out


def excursions(c: np.ndarray, return_ratio: float = 0.3) -> list[tuple[int, int]]:
    """Half-open ``(a, b)`` excursions of a run of positive values ``c`` (1-D), in order.

    A segment is cut at its deepest valley on either side of its peak when
    that valley is at most ``return_ratio`` times the lower of the two peaks
    it separates (the joint came back close to its neighbours between them),
    and each part is cut again the same way; the valley frame ends one
    excursion and starts the next. ``return_ratio`` 1 cuts at every valley
    below the lower peak, and values near 0 cut nowhere.
    """
    c = np.asarray(c, dtype=np.float64)
    if c.ndim != 1:
        raise ValueError(f"need a 1-D run, got shape {c.shape}")
    if not 0 < return_ratio <= 1:
        raise ValueError(f"return_ratio must be in (0, 1], got {return_ratio!r}")
    out, todo = [], [(0, len(c))]
    while todo:
        a, b = todo.pop()
        p = a + int(np.argmax(c[a:b])) if b > a else a
        cut = None
        # the deepest valley strictly inside the segment on either side of the peak (its end frames may be valleys
        # shared with the neighbouring excursions), with a peak of its own beyond it
        if p > a + 1:
            v = a + 1 + int(np.argmin(c[a + 1 : p]))
            if c[v] <= return_ratio * min(c[p], c[a:v].max()):
                cut = v
        if cut is None and b - 1 > p + 1:
            v = p + 1 + int(np.argmin(c[p + 1 : b - 1]))
            if c[v] <= return_ratio * min(c[p], c[v + 1 : b].max()):
                cut = v
        if cut is None:
            out.append((a, b))
        else:
            todo += [(cut, b), (a, cut + 1)]
    return sorted(out)


def smooth_drift_flags(
    jumps: np.ndarray,
    agreement: np.ndarray,
    consistency: np.ndarray,
    fps: float,
    repeat_deg: float = 5.0,
    z_min: float = 3.0,
    min_s: float = 0.25,
    margin_s: float = 0.05,
    extent: float = 0.5,
    others: int | None = 1,
    return_ratio: float = 0.3,
    partners: np.ndarray | None = None,
    partner_ratio: float = 0.5,
    parents: np.ndarray | None = None,
    chain_ratio: float = 0.5,
    turns: np.ndarray | None = None,
    cross_cos: float = 0.2,
) -> np.ndarray:
    """(F, J) bool: the smooth drifts of a take (module docstring).

    ``jumps`` bool (F, J) the joints' own breaks; ``agreement`` radians and
    ``consistency`` (a ratio) float (F, J) from :func:`body_agreement` and
    :func:`detect` (NaN: no evidence, never flagged). Per joint, a run is a
    connected stretch of cells with ``consistency > extent``: the joint
    outside its neighbours' spread and the capture noise (``extent`` 1), the
    whole excursion down to where it is back among them. Runs with a break
    within ``margin_s`` seconds are :func:`confirm_flags`' to judge; the
    others are cut into excursions (:func:`excursions`, ``return_ratio``),
    and an excursion is flagged whole when at least ``min_s`` seconds of its
    cells have ``agreement <= repeat_deg`` (degrees: the context repeats the
    motion there), ``consistency >= z_min`` (the neighbours agree the joint
    is elsewhere) and at most ``others`` other joints at ``z_min`` or more
    (:func:`other_joints_level` over the joints with an ``agreement``; None:
    not asked) while its left/right partner (``partners``, the permutation
    of :func:`~mocapkit.motion.mirror_pairs`; None: not asked) is below
    ``partner_ratio * z_min``, and so are its parent and children
    (:func:`chain_level` over the same joints; ``parents`` the skeleton's
    parent indices, None: not asked) below ``chain_ratio * z_min``, and, if it touches the first (last) frame,
    its consistency comes down to ``return_ratio`` times its peak's between
    that frame and the peak (module docstring). ``return_ratio`` 1 judges whole runs as they
    are. With ``turns`` (F, J, 3: :func:`group_offset_turn`, the direction of each cell's change) an excursion that
    the partner or the chain gate alone stops is flagged too where it and that neighbour stop each other and turn
    about crossed axes (:func:`crossed_turns`, ``cross_cos``): two drifts at once, not one style.
    """
    from scipy import ndimage

    jumps = np.asarray(jumps, dtype=bool)
    agreement = np.asarray(agreement, dtype=np.float64)
    consistency = np.asarray(consistency, dtype=np.float64)
    if not (jumps.ndim == 2 and jumps.shape == agreement.shape == consistency.shape):
        raise ValueError(
            f"jumps, agreement and consistency must be the same (F, J) shape, got "
            f"{jumps.shape}, {agreement.shape} and {consistency.shape}"
        )
    if not (margin_s >= 0 and min_s >= 0 and repeat_deg >= 0 and 0 < extent <= z_min and fps > 0):
        raise ValueError(f"need margin_s, min_s, repeat_deg >= 0, 0 < extent <= z_min and fps > 0, got "
                         f"{margin_s!r}, {min_s!r}, {repeat_deg!r}, {extent!r}, {z_min!r} and {fps!r}")
    if not 0 < return_ratio <= 1:
        raise ValueError(f"return_ratio must be in (0, 1], got {return_ratio!r}")
    with np.errstate(invalid="ignore"):
        low = consistency > extent
        strong = low & (agreement <= np.radians(repeat_deg)) & (consistency >= z_min)
    if others is not None and strong.any():
        # the joints that may carry a drift: those with evidence (agreement is NaN on the root, the pelvis and
        # joints not analysed)
        strong &= other_joints_level(consistency, np.isfinite(agreement), others) < z_min
    side_ok = chain_ok = np.ones(jumps.shape, dtype=bool)  # the partner and chain gates (True: not asked)
    if partners is not None and strong.any():
        partners = np.asarray(partners, dtype=np.int64)
        if partners.shape != (jumps.shape[1],):
            raise ValueError(f"partners must be ({jumps.shape[1]},) joint indices, got shape {partners.shape}")
        if not 0 < partner_ratio <= 1:
            raise ValueError(f"partner_ratio must be in (0, 1], got {partner_ratio!r}")
        paired = partners != np.arange(len(partners))
        with np.errstate(invalid="ignore"):
            # a style is often two-sided (both arms of a bow held otherwise, both legs bent more): where the
            # joint's mirror partner leaves its neighbours too, the joint's digression is no evidence of a drift
            side_ok = ~(paired[None, :] & (consistency[:, partners] >= partner_ratio * z_min))
    if parents is not None and strong.any():
        if not 0 < chain_ratio <= 1:
            raise ValueError(f"chain_ratio must be in (0, 1], got {chain_ratio!r}")
        # a style bends a chain (a head bowed with the neck, an arm raised with the elbow opened); a drift turns one
        # joint and leaves its children's local rotations on their path
        chain_ok = chain_level(consistency, np.isfinite(agreement), parents) < chain_ratio * z_min
    if not (strong & side_ok & chain_ok).any() and turns is None:
        return np.zeros(jumps.shape, dtype=bool)
    n = int(round(margin_s * fps))
    near = ndimage.binary_dilation(jumps, structure=np.ones((2 * n + 1, 1), dtype=bool)) if n > 0 else jumps
    need = max(int(np.ceil(min_s * fps)), 1)
    out = _excursion_flags(strong & side_ok & chain_ok, low, near, consistency, need, return_ratio)
    if turns is None or not strong.any():
        return out
    turns = np.asarray(turns, dtype=np.float64)
    if turns.shape != jumps.shape + (3,):
        raise ValueError(f"turns must be (F, J, 3) = {jumps.shape + (3,)}, got shape {turns.shape}")
    level = np.nan_to_num(consistency, nan=-np.inf)
    crossed = out.copy()
    J = jumps.shape[1]
    for gate_on, other_ok, neighbours in (
        (parents is not None, side_ok, [[k for k in [int(parents[j])] + list(np.flatnonzero(parents == j)) if k >= 0]
                                        for j in range(J)] if parents is not None else None),
        (partners is not None, chain_ok, [[int(partners[j])] if partners[j] != j else [] for j in range(J)]
                                         if partners is not None else None),
    ):
        if not gate_on:
            continue
        # the excursions this gate alone stops
        stopped = _excursion_flags(strong & other_ok, low, near, consistency, need, return_ratio) & ~out
        crossed |= crossed_turns(stopped, out, turns, level, neighbours, cross_cos)
    return crossed


def _excursion_flags(strong, low, near, consistency, need: int, return_ratio: float) -> np.ndarray:
    """(F, J) bool the excursions of the runs of ``low`` that hold no break (``near``) and at least ``need``
    ``strong`` cells, cut and judged as :func:`smooth_drift_flags` says."""
    from scipy import ndimage

    along_time = np.array([[0, 1, 0], [0, 1, 0], [0, 1, 0]], dtype=bool)  # runs never join across joints
    labels, count = ndimage.label(low, structure=along_time)
    idx = np.arange(1, count + 1)
    broken = ndimage.maximum(near, labels, idx).astype(bool)
    evidence = ndimage.sum(strong, labels, idx)
    out = np.zeros(low.shape, dtype=bool)
    F = low.shape[0]
    boxes = ndimage.find_objects(labels)
    for i in np.flatnonzero(~broken & (evidence >= need)):
        rows, cols = boxes[i]
        A, B, j = rows.start, rows.stop, cols.start
        c = consistency[A:B, j]
        parts = excursions(c, return_ratio) if return_ratio < 1 else [(0, B - A)]
        for a, b in parts:
            if strong[A + a : A + b, j].sum() < need:
                continue
            if return_ratio < 1:
                e = c[a:b]
                m = int(np.argmax(e))
                back = return_ratio * e[m]
                if (A + a == 0 and e[: m + 1].min() > back) or (A + b == F and e[m:].min() > back):
                    continue  # never seen leaving (or coming back): a pose held from before (or after) the take
            out[A + a : A + b, j] = True
    return out


def crossed_turns(stopped: np.ndarray, flagged: np.ndarray, turns: np.ndarray, level: np.ndarray, neighbours,
                  cross_cos: float = 0.2) -> np.ndarray:
    """(F, J) bool: the excursions of ``stopped`` that are one of two drifts at once, not a style.

    ``stopped`` bool (F, J): excursions a neighbour's digression alone keeps from being drifts (the partner or the
    chain gate of :func:`smooth_drift_flags`); ``flagged`` bool (F, J) the drifts flagged; ``turns`` float (F, J,
    3) the direction of each cell's change (:func:`group_offset_turn`; NaN counts as no turn); ``level`` float (F,
    J) the evidence (the change); ``neighbours`` per joint the joints whose digression stops it (its mirror
    partner, or its parent and children). Per excursion (a run of ``stopped`` on one joint) the neighbour with the
    highest level there is the one that stops it. A style moves the two together: a two-sided one turns both sides
    the same way (the Bandai rig's mirror keeps local rotations), a bent chain turns parent and child about
    one axis. Two drifts are two joints each turned about its own axis. The excursion is kept when that neighbour
    is itself stopped or flagged over the excursion (each joint a drift candidate) and their turns summed over the
    excursion are crossed: ``|sum u.w| < cross_cos * sqrt(sum |u|^2 sum |w|^2)``. Aristidou et al. 2018 (section
    3.4) flag one joint's digression; this tells two such joints apart from a chain or a pair moving as one.
    """
    from scipy import ndimage

    stopped = np.asarray(stopped, dtype=bool)
    flagged = np.asarray(flagged, dtype=bool)
    u = np.nan_to_num(np.asarray(turns, dtype=np.float64))
    out = np.zeros(stopped.shape, dtype=bool)
    along_time = np.array([[0, 1, 0], [0, 1, 0], [0, 1, 0]], dtype=bool)
    labels, _ = ndimage.label(stopped, structure=along_time)
    for rows, cols in ndimage.find_objects(labels):
        A, B, j = rows.start, rows.stop, cols.start
        ks = neighbours[j]
        if not ks:
            continue
        k = max(ks, key=lambda k: level[A:B, k].max())
        if not (stopped[A:B, k].any() or flagged[A:B, k].any()):
            continue
        a, w = u[A:B, j], u[A:B, k]
        den = np.sqrt((a * a).sum() * (w * w).sum())
        if den > 0 and abs((a * w).sum()) < cross_cos * den:
            out[A:B, j] = True
    return out
