"""Left and right labels exchanged throughout a take: a rig mapped left for right, found from geometry alone.

A skeleton whose ``LeftUpLeg`` sits on the body's right (a retargeting map or
an export that swapped the sides) reads as a correct take: every name is a
known one, every bone as long as its partner. Cleaning, search and
reconstruction then pair the wrong limbs with the database's. The names cannot
tell; the body can. :func:`exchanged_sides` reads the body's left from the
joints' positions alone and names the limbs whose left-named joint lies on the
body's right. It changes nothing: the take comes back as it was.

The body's left, from the legs' hinges
--------------------------------------
Left is up x forward in right-handed axes (the BVH and Acclaim convention; a
left-handed export of a correct take reads as one with its sides exchanged).
Each leg gives it at two hinges, with up along the leg and forward where the
joint bends:

* the knee bends the shin backwards: ``(knee - hip) x (ankle - knee)``
  points to the body's left, its length the sine of the knee's bend;
* the foot points forward from the shin: ``(knee - ankle) x (toe - ankle)``
  points to the body's left, its length about 1 (the ankle stays near a right
  angle).

Their sum over both legs, ``l_t`` (frames-first, ``(F, 3)``), is the body's
left in frame ``t`` whichever leg is named which (the sum is symmetric in the
names), weighted by how sure each hinge is: a straight knee adds nothing, a
squat's deep bend much. The spine's up is not used: a trunk leaning into a
dash or a pick-up tilts it far from the legs' up, and the forward it gives
turns with it (on HDM05 bk ``depositFloorR`` 008 the feet and knees
projected across the spine's up agree with the names at 0.22, the hinges at
0.9 or more).

For each pair (the hips, where the legs leave the pelvis, and the shoulders),
``d_t`` is the unit vector from the right-named joint to the left-named one
and the pair's agreement over the take is
``a = sum_t d_t . l_t / sum_t |l_t|`` in [-1, 1]: 1 where the left-named
joint lies on the body's left in every frame, -1 where it lies on the right.
The rest pose gives the same with its rest positions (the offsets); a rest
pose whose legs are straight and whose feet lie along the shins (the Bandai
Namco game rig's, every bone along one axis) has ``|l|`` near 0 and cannot
tell.

A pair is exchanged when its agreement over the take is below
:data:`EXCHANGED_BELOW` and the rest pose does not say otherwise (its
agreement below 0, or it cannot tell). On every take of ``../shared/data``
(HDM05, CMU ASF/AMC and BVH, the Bandai Namco sets, the peers' files) and the
rigs the benchmarks respell them on (3,319 takes), the lowest agreement is
0.80 for the hips and 0.66 for the shoulders (Bandai Namco dataset-1
``walk-right_sad_001``); the same takes with their names exchanged give their
negatives, and every one of them with sides in its names is named.

Only the joints whose names carry a side (:func:`mocapkit.joints.joint_sides`)
are judged: a rig whose sides were read from its rest pose has nothing to
exchange.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .joints import joint_sides, standard_joints

__all__ = ["EXCHANGED_BELOW", "NOTE_START", "ExchangedSides", "exchanged_phrase", "exchanged_sides", "side_agreement"]

#: A pair's agreement (module docstring) below this: its left-named joint lies on the body's right.
EXCHANGED_BELOW = -0.5
#: The legs' hinges must give at least this mean ``|l|`` (a sum of sines; a standing body with feet gives
#: about 2) for the take, or the rest pose, to tell left from right.
BEND_MIN = 0.2
#: How :class:`ExchangedSides`' note begins: a cleaning's notes (its record, a batch's row) are found by it.
NOTE_START = "left and right exchanged: "
_PAIRS = {"legs": "hip", "arms": "shoulder"}
_LEG_ROLES = ("hip", "knee", "foot")


@dataclass(frozen=True)
class ExchangedSides:
    """The limb pairs of a take whose left-named joint lies on the body's right.

    ``pairs``: ``"legs"``, ``"arms"`` or both; ``named_left``: the left-named joint of each (the file's names,
    ``LeftUpLeg``, ``LeftArm``); ``agreement``: each pair's agreement over the take (-1 to 1, module docstring);
    ``rest``: each pair's in the rest pose, None where the rest pose cannot tell.
    """

    pairs: tuple[str, ...]
    named_left: tuple[str, ...]
    agreement: tuple[float, ...]
    rest: tuple[float | None, ...]

    def __str__(self) -> str:
        rest = ("the rest pose too" if all(r is not None for r in self.rest)
                else "the rest pose cannot tell")
        said = ", ".join(f"{p} {a:+.2f}" for p, a in zip(self.pairs, self.agreement))
        joints = " and ".join(self.named_left)
        return (f"{NOTE_START}{joints} (named left) {'lie' if len(self.named_left) > 1 else 'lies'} "
                f"on the body's right over the whole take (agreement {said}, of -1 to 1; {rest}), by the knees' "
                "and ankles' bend in right-handed axes: a rig mapped left for right; the names are kept, nothing "
                "changed")


def exchanged_phrase(notes) -> str:
    """The short form of the exchanged-sides note among a cleaning's ``notes`` (str sequence), "" where none is.

    ``"left and right exchanged: LeftUpLeg and LeftArm on the body's right (names kept)"``: the joints the long
    note (``str(ExchangedSides)``, which the record and a batch's JSON row keep whole) names, for a line that
    says one take in one line (``mocapkit clean-batch``).
    """
    for note in notes or ():
        if isinstance(note, str) and note.startswith(NOTE_START) and " (named left) " in note:
            joints = note[len(NOTE_START):note.index(" (named left) ")]
            return f"{NOTE_START}{joints} on the body's right (names kept)"
    return ""


def side_agreement(positions: np.ndarray, joints: dict[str, int]) -> tuple[dict[str, float], float]:
    """Each pair's agreement of its names with the body's left (module docstring) and the mean ``|l|``.

    ``positions``: (F, J, 3) or (J, 3) joint positions (any length unit); ``joints``: role -> joint index with
    ``left_``/``right_`` ``hip``, ``knee``, ``foot`` (``toe`` where the rig has toes) and ``shoulder``. Returns
    ``({"legs": a, "arms": a}, mean |l|)``; frames with a missing position are left out (NaN agreements where
    none is left).
    """
    p = np.asarray(positions, dtype=float)
    p = p[None] if p.ndim == 2 else p
    left = np.zeros((p.shape[0], 3))
    for side in ("left", "right"):
        hip, knee, foot = (p[:, joints[f"{side}_{r}"]] for r in _LEG_ROLES)
        left += np.cross(_unit(knee - hip), _unit(foot - knee))
        if "left_toe" in joints and "right_toe" in joints:
            left += np.cross(_unit(knee - foot), _unit(p[:, joints[f"{side}_toe"]] - foot))
    ok = np.isfinite(left).all(axis=1)
    weight = np.linalg.norm(left[ok], axis=1)
    out = {}
    for pair, role in _PAIRS.items():
        d = _unit(p[ok, joints[f"left_{role}"]] - p[ok, joints[f"right_{role}"]])
        out[pair] = float(np.einsum("ij,ij->", d, left[ok]) / weight.sum()) if weight.sum() > 0 else float("nan")
    return out, float(weight.mean()) if weight.size else 0.0


def exchanged_sides(motion) -> ExchangedSides | None:
    """The limb pairs of ``motion`` (a :class:`~mocapkit.motion.Motion`) named left on the body's right, or None
    (the names agree with the body, the rig lacks the legs' or arms' joints, its names carry no sides, or its
    legs never bend enough to tell). Reads positions only; changes nothing."""
    sk = motion.skeleton
    roles = [f"{s}_{r}" for s in ("left", "right") for r in (*_LEG_ROLES, "shoulder")]
    joints = standard_joints(sk)
    if not all(r in joints for r in roles):
        return None
    named = joint_sides(sk.joint_names)
    if any(named[joints[r]] != r.split("_")[0] for r in roles):  # sides read from the rest pose, not the names
        return None
    if any(f"{s}_toe" in joints and named[joints[f"{s}_toe"]] != s for s in ("left", "right")):
        joints = {k: v for k, v in joints.items() if not k.endswith("_toe")}  # toes read otherwise: the knees alone
    take, bend = side_agreement(motion.global_positions(), joints)
    if not bend >= BEND_MIN:
        return None
    rest, rest_bend = side_agreement(sk.rest_positions(), joints)
    found = [(pair, take[pair], rest[pair] if rest_bend >= BEND_MIN else None) for pair in _PAIRS
             if take[pair] < EXCHANGED_BELOW and not (rest_bend >= BEND_MIN and rest[pair] >= 0)]
    if not found:
        return None
    return ExchangedSides(pairs=tuple(f[0] for f in found),
                          named_left=tuple(sk.joint_names[joints[f"left_{_PAIRS[f[0]]}"]] for f in found),
                          agreement=tuple(round(f[1], 3) for f in found),
                          rest=tuple(None if f[2] is None else round(f[2], 3) for f in found))


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 1e-12, n, np.inf)
