"""Which changes of a joint-angle cleaning a person accepts or rejects together, and why.

A change (:mod:`mocapkit.cleaning.decisions`) is one run of frames of one joint changed by the same step(s). Some
changes are parts of one fix: deciding one without the other writes a take that is neither the input nor the
cleaning, with a defect neither had. Two kinds of changes are *tied*:

* **the two sides of one left/right swap.** A swap the detection flags on a joint and on its mirror partner
  (:func:`~mocapkit.motion.mirror_pairs`) over shared frames is put back on both sides at once: confirmed, by the
  mirrored exchange (:func:`~mocapkit.cleaning.ssa.swap_exchange.swap_exchanges`), each side taking its
  partner's mirrored rotation; else by neighbour words on both. Two changes are tied where they are of a joint
  and its partner, both repaired, and share a frame whose cells the detection flagged as a swap
  (:data:`~mocapkit.cleaning.ssa.cues.CAUSES` ``"swap"``) on both joints. Accepting one side alone gives both
  limbs the same side's motion; rejecting one side alone leaves the other's motion nowhere in the take.
* **touching changes of one joint made by nested steps**: change ``A`` ends on the frame before change ``B``
  starts (``A.last + 1 == B.first``) and the steps of one are among the other's (a one-frame
  ``repair+denoise`` inside a ``denoise`` run, a ``fill`` run followed by ``fill+denoise``). The step the two
  share made the values on both sides of the join together (a denoising filter runs across it, a repair blends
  into its neighbours), so the take is continuous there only with both: deciding them apart leaves a step at
  the join, a visible pop where a one-frame change is rejected inside a smoothed run.

Ties are transitive: a group is every change reached through them. Touching changes whose steps are disjoint
(a ``fill`` run next to a ``repair`` run) are not tied: each answers its own problem (a gap, a flagged error),
and rejecting one gives back the input's own values, whose step at the join is the input's.

A person decides a group as one: the report's boxes move together and say why (``"tied"``, ``"tied_why"`` of
:func:`mocapkit.cleaning.decisions.review`), and decisions that split a group are refused
(:class:`SplitTieError`; a file, in one line naming it, the changes and why). The change ids are unchanged
(the decisions file's format): a file that decides each group as one applies as before.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .ssa.cues import CAUSES

__all__ = ["SWAP_WHY", "STEPS_WHY", "SplitTieError", "swap_cells", "tie_groups", "split_message"]

SWAP_WHY = ("the two sides of one left/right swap put back: one side alone would give both limbs the same side's "
            "motion, or lose one side's motion")
"""Why the two sides of a swap's repair are decided together, in words: the report's rows and refusals say it."""

STEPS_WHY = ("touching runs of one joint that one step changed together: one alone would leave a step (a pop) "
             "where they meet")
"""Why touching changes of one joint with nested steps are decided together, in words."""

_SWAP_BIT = 1 << [name for name, _ in CAUSES].index("swap")


class SplitTieError(ValueError):
    """Decisions that accept some changes of a tied group and reject others (:func:`split_message` says which)."""


def swap_cells(causes, shape: tuple[int, int]) -> np.ndarray:
    """(F, J) bool: the cells the detection flagged as a left/right swap, from a record's ``causes`` (F, J) (bits of
    :data:`~mocapkit.cleaning.ssa.cues.CAUSES`); all False for a record without them (None)."""
    if causes is None:
        return np.zeros(shape, dtype=bool)
    return (np.asarray(causes).astype(np.int64) & _SWAP_BIT) != 0


def tie_groups(rows: Sequence[tuple[int, int, int, frozenset]], swaps: np.ndarray,
               partner) -> list[tuple[list[int], str]]:
    """The tied groups of ``rows`` (module docstring): ``(indices into rows, why)`` per group of two or more.

    ``rows``: ``(joint, first, last, steps)`` of each change (frames inclusive; ``steps`` the set of step names,
    e.g. ``{"repair", "denoise"}``); ``swaps`` (F, J) bool: the cells flagged as a swap (:func:`swap_cells`);
    ``partner`` (J,) int: each joint's left/right partner, itself where it has none. ``why``: :data:`SWAP_WHY`,
    :data:`STEPS_WHY`, or both joined, as the group's ties are. Groups in order of their first row, indices
    ascending.
    """
    n = len(rows)
    parent = list(range(n))

    def find(k: int) -> int:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    kinds: list[tuple[int, int, str]] = []
    by_joint: dict[int, list[int]] = {}
    for k, (j, _, _, _) in enumerate(rows):
        by_joint.setdefault(int(j), []).append(k)
    for ks in by_joint.values():
        ks = sorted(ks, key=lambda k: rows[k][1])
        for x, y in zip(ks, ks[1:]):
            sx, sy = rows[x][3], rows[y][3]
            if rows[x][2] + 1 == rows[y][1] and (sx <= sy or sy <= sx):
                kinds.append((x, y, STEPS_WHY))
    swaps = np.asarray(swaps, dtype=bool)
    partner = np.asarray(partner, dtype=np.int64)
    for j, ks in by_joint.items():
        p = int(partner[j])
        if p <= j or p not in by_joint:
            continue
        both = swaps[:, j] & swaps[:, p]
        for x in ks:
            for y in by_joint[p]:
                (_, a, b, sx), (_, c, d, sy) = rows[x], rows[y]
                lo, hi = max(a, c), min(b, d)
                if "repair" in sx and "repair" in sy and lo <= hi and both[lo:hi + 1].any():
                    kinds.append((x, y, SWAP_WHY))
    for x, y, _ in kinds:
        parent[find(x)] = find(y)
    groups: dict[int, list[int]] = {}
    for k in range(n):
        groups.setdefault(find(k), []).append(k)
    whys: dict[int, set[str]] = {}
    for x, _, why in kinds:
        whys.setdefault(find(x), set()).add(why)
    out = [(g, "; and ".join(w for w in (SWAP_WHY, STEPS_WHY) if w in whys[r])) for r, g in groups.items()
           if len(g) > 1]
    out.sort(key=lambda item: item[0][0])
    return out


def split_message(ids: Sequence[str], choices: Sequence[str], why: str, accept: str = "accept") -> str:
    """The words of a refusal of decisions that split the tied group ``ids`` (``choices``: each one's decision):
    which it accepts, which it rejects, and why they go together."""
    def listed(xs: list[str]) -> str:
        return ", ".join(xs[:3]) + (f" and {len(xs) - 3} more" if len(xs) > 3 else "")

    acc = [i for i, c in zip(ids, choices) if c == accept]
    rej = [i for i, c in zip(ids, choices) if c != accept]
    return (f"accepts {listed(acc)} but rejects {listed(rej)}, which are decided together ({why}): accept or reject "
            "them all")
