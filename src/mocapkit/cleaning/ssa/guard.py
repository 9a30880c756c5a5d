"""The repair guard: a repaired run the take itself shows to be worse than its input is left as it was.

Self-similarity repair (Aristidou et al. 2018, section 4) replaces a flagged joint by the medoid of its
neighbour words, bridges what no word covers by slerp between its ends, and takes a transient offset away
(:mod:`~mocapkit.cleaning.ssa.undo`). Each can leave a joint worse than it found it: a real fast turn that
the break rule flagged (CMU 131_01's RightWrist, 133 degrees at frame 235, until such turns confirmed nothing:
:mod:`~mocapkit.cleaning.ssa.smooth_turns`) came back with a step where the take turned smoothly; a bridge across a flip whose *other* side was flagged (the clean frames before a long
flip of the toes) turns a still joint 180 degrees in 23 frames of clean capture. The truth is not known when a
take is cleaned, but the take's own continuity is. A run of changed cells of one joint is kept only when

* it joins the take no less smoothly than the input did (within :data:`ROUGHNESS_TOL_DEG`): the largest
  angular acceleration (the angle of
  the second difference of the joint's rotation, degrees per frame squared) over the run and the frame on
  each side is not larger after than before (:func:`roughness`), and neither is it at each end of the run
  on its own, within :data:`END_TOL_DEG`, unless the input holds the joint bit-still in the run (:func:`rougher_end`,
  :func:`held`): flags that run on past an error over captured frames otherwise hide the step their repair
  puts at the run's far end behind the error's own step at the near one;
* where it is bridged (no neighbour word covers it), the bridge turns no faster than :data:`BRIDGE_MIN_DEG`
  degrees a frame or :data:`BRIDGE_FACTOR` times the fastest turn the joint makes between two unflagged
  frames, whichever is more: a slerp an order of magnitude faster than the joint ever turns is no motion
  of the joint, it is the error spread over clean frames. (A bound closer to the joint's own peak left
  good bridges of freezes on fast knees and elbows, whose fastest frames are the flagged ones.)

A run that fails is given back its input values bit for bit and named (:class:`LeftRun`): "left: repair not
better than the take". A rule of this library, not of the paper. (Neighbour-word evidence was tried as a
third rule, output against input distance from the words' medoid: the blend that makes a run meet the take
at its ends moves it off the medoid on most good repairs, so it left more good repairs than bad.)
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ... import rotations as R
from ..ik import contact_segments
from ...words import frame_span

__all__ = ["LEFT_PREFIX", "LeftRun", "angular_acceleration", "end_roughness", "guard_joint", "held", "rougher_end",
           "roughness"]

#: degrees per frame squared a repaired run may add to the input's largest angular acceleration: the joins of a
#: 0.25 s blend add about 1 (a smooth drift repaired from a twin: 0.1 -> 1.1), a step put into a real turn tens
ROUGHNESS_TOL_DEG = 2.0
#: degrees per frame squared a repaired run may add at one of its ends to the input's angular acceleration there
#: (:func:`rougher_end`): the joins of good repairs on the HDM05 and CMU takes tuned on added up to 2.4, the steps
#: put where flags ran on past an error over clean frames 6-9
END_TOL_DEG = 5.0
#: a bridge may turn up to this many degrees a frame whatever the joint does elsewhere (at 30 fps, 300 deg/s) ...
BRIDGE_MIN_DEG = 10.0
#: ... and up to this many times the joint's fastest turn between two unflagged frames
BRIDGE_FACTOR = 10.0


@dataclass(frozen=True)
class LeftRun:
    """A run of one joint's repair given back as it was: ``joint`` (name), frames ``start`` to ``end - 1`` of
    the take repaired, and ``reason``, the guard's words for the rule it failed."""

    joint: str
    start: int
    end: int
    reason: str

    def __str__(self) -> str:
        return f"{LEFT_PREFIX}{self.joint} {frame_span(self.start, self.end - 1)} ({self.reason})"

    @classmethod
    def from_note(cls, note: str) -> "LeftRun | None":
        """The run a note of :attr:`CleanResult.notes <mocapkit.cleaning.clean_record.CleanResult.notes>` says
        (``str(run)``, the only form a record keeps); None for any other note."""
        m = _LEFT_NOTE.fullmatch(note)
        return None if m is None else cls(m["joint"], int(m["a"]), int(m["b"] or m["a"]) + 1, m["reason"])


#: how a :class:`LeftRun`'s note begins (the console's, the record's and the report's words)
LEFT_PREFIX = "left: repair not better than the take: "
_LEFT_NOTE = re.compile(re.escape(LEFT_PREFIX) + r"(?P<joint>.+) frames? (?P<a>\d+)(?:-(?P<b>\d+))? \((?P<reason>.*)\)")


def angular_acceleration(q: np.ndarray) -> np.ndarray:
    """(F,) degrees per frame squared: at frame f (1 .. F-2) the angle of ``log(q[f+1] q[f]^-1) -
    log(q[f] q[f-1]^-1)`` (each frame's turn as a rotation vector in the parent's frame); 0 at both ends.

    ``q`` (F, 4) one joint's track. A real turn, however fast, changes its speed gradually; a step in the
    data (a flip, a freeze let go, a badly joined repair) shows as one large value.
    """
    q = np.asarray(q, dtype=np.float64)
    out = np.zeros(len(q))
    if len(q) < 3:
        return out
    v = R.quaternion_to_rotvec(R.quaternion_multiply(q[1:], R.quaternion_inverse(q[:-1])))  # (F-1, 3) radians
    out[1:-1] = np.degrees(np.linalg.norm(v[1:] - v[:-1], axis=-1))
    return out


def roughness(acc: np.ndarray, start: int, end: int) -> float:
    """The largest of ``acc`` (F,) (:func:`angular_acceleration`) over the run ``start .. end - 1`` and the
    frame on each side: every second difference that a value of the run enters."""
    lo, hi = max(start - 1, 0), min(end + 1, len(acc))
    return float(acc[lo:hi].max()) if hi > lo else 0.0


def end_roughness(acc: np.ndarray, start: int, end: int) -> tuple[float, float]:
    """``(entry, exit)``: the largest of ``acc`` (F,) (:func:`angular_acceleration`) at the run's first join (frames
    ``start - 1`` and ``start``, the second differences that hold the turn from the frame before the run into it)
    and at its last (``end - 1`` and ``end``); 0 where the run starts or ends the take."""
    F = len(acc)
    entry = float(acc[max(start - 1, 0) : min(start + 1, F)].max()) if start > 0 else 0.0
    exit_ = float(acc[max(end - 1, 0) : min(end + 1, F)].max()) if end < F else 0.0
    return entry, exit_


def rougher_end(acc_in: np.ndarray, acc_out: np.ndarray, start: int, end: int) -> str | None:
    """The guard's words where one end of the run joins the take with a step the input did not have there, else
    None: at the run's entry or exit (:func:`end_roughness`) the output's angular acceleration passes the input's
    there by more than :data:`END_TOL_DEG`.

    The whole-run rule (:func:`roughness`) compares the largest values over the run, so the error's own step at
    one end (the break the flags start at) hides a step the repair puts at the other, where the input ran on
    smoothly into the take: the flags went on past the error over uncorrupted frames (HDM05 bd grabHighR, the
    right forearm's flags 8 frames past its error's last frame: 0 -> 8-20 degrees off the clean take, a step of
    8.6 deg/frame^2 where the input's was 0.2). Not for a held run (:func:`held`): a frozen channel joins the
    take smoothly where it starts holding, and its repair, moving again, cannot.
    """
    e_in, x_in = end_roughness(acc_in, start, end)
    e_out, x_out = end_roughness(acc_out, start, end)
    for side, r_in, r_out in (("entry", e_in, e_out), ("exit", x_in, x_out)):
        if r_out > r_in + END_TOL_DEG:
            return f"its {side} joins the take less smoothly: {r_out:.1f} against {r_in:.1f} deg/frame^2"
    return None


def held(q: np.ndarray, start: int, end: int) -> bool:
    """Whether the track ``q`` (F, 4) repeats a rotation bit for bit between two consecutive frames of
    ``start - 1 .. end - 1`` (the frame before the run and the run): a frozen channel, which no capture of a
    moving joint shows."""
    seg = q[max(start - 1, 0) : end]
    return bool(len(seg) > 1 and np.all(seg[1:] == seg[:-1], axis=-1).any())


def guard_joint(
    orig: np.ndarray,
    out: np.ndarray,
    changed: np.ndarray,
    bridged: np.ndarray,
    flagged: np.ndarray,
) -> list[tuple[int, int, str]]:
    """The runs of one joint's repair that fail the guard (module docstring), as ``(start, end, reason)``.

    ``orig``, ``out`` (F, 4): the joint's input and repaired tracks; ``changed`` (F,) bool: the frames the
    repair changed (the runs judged are its maximal runs); ``bridged`` (F,) bool: the frames bridged by slerp
    (no neighbour word); ``flagged`` (F,) bool: the joint's flagged frames (the turns between two unflagged
    frames give the joint's own peak speed).
    """
    runs = contact_segments(changed)
    if not runs:
        return []
    acc_in, acc_out = angular_acceleration(orig), angular_acceleration(out)
    speed = np.degrees(R.geodesic_angle(orig[1:], orig[:-1]))  # (F-1,) the turn from frame f to f+1
    free = ~(flagged[1:] | flagged[:-1])
    peak = float(speed[free].max()) if free.any() else np.inf
    out_speed = np.degrees(R.geodesic_angle(out[1:], out[:-1]))
    bad = []
    for s, e in runs:
        r_in, r_out = roughness(acc_in, s, e), roughness(acc_out, s, e)
        if r_out > r_in + ROUGHNESS_TOL_DEG:
            bad.append((s, e, f"joins the take less smoothly: {r_out:.1f} against {r_in:.1f} deg/frame^2"))
            continue
        if bridged[s:e].any():
            fast = float(out_speed[max(s - 1, 0) : e].max())  # the turns into, through and out of the run
            if fast > max(BRIDGE_MIN_DEG, BRIDGE_FACTOR * peak):
                bad.append((s, e, f"a bridge turning {fast:.1f} deg/frame, the joint at most {peak:.1f} elsewhere"))
                continue
        rough_end = None if held(orig, s, e) else rougher_end(acc_in, acc_out, s, e)
        if rough_end is not None:
            bad.append((s, e, rough_end))
    return bad
