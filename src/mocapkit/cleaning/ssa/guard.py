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

Three more rules, of the run's frames and of a left/right pair rather than of its joins:

* **A take's edge written from the take's own next moment is a guess nothing checks** (:func:`open_end_runs`):
  the rules above judge a repair by how it meets the take, and a run that starts (ends) the take meets it at
  one end only; its other end is wherever the neighbour word puts it. Where that word is a repeat of the
  motion (another stride, another grab) it is evidence; where every word the run was written from is the take
  itself, starting inside its source word or right after it (at most one word, 15 analysis frames, away), it
  is the same stretch of motion a moment later, not a repeat of it: a short take's onset has nothing else to
  be compared with. Bandai Namco dataset-2 ``raise-up-both-hands`` takes (1.5 s at 30 fps) had their right
  forearm's first 6-8 frames, where both arms swing out and back before rising, "repaired" 36-44 deg away
  from the capture on average (9 takes, ``active_055``-``097``; the left arm makes the same swing, unflagged),
  from the words 8-17 analysis frames after the first one; on the corrupted short Bandai takes tried
  (``corrupt.real_errors`` seeds 2001-2004 on six ``raise-up``/``wave`` takes) the two runs written at a
  take's edge came out worse than their input (0.0 -> 27.0 and 9.5 -> 73.8 deg off the clean take). Such a run
  is given back and named; the flag stays for a person to see. A run written from a word elsewhere in the
  take or its context is judged as before (an HDM05 swap of the femurs running to a 120 fps take's last frame
  came back 0.2 deg off the clean take from another grab), and so is one put back by the take's own motion
  (an offset taken away, a swap exchanged back).

* **A run's extent stops at the break that bounds it** (:func:`on_path_ends`): the first flagged frame of a run
  whose step into the next frame is the break, while the frame before it continues into it smoothly, lies on
  the joint's own path, and is no error's: the break that flagged it is its neighbour's (a spike of k frames
  breaks at the frame before it too, the midpoint residual of a frame beside it; likewise the last frame,
  the frame after it). Repaired, it took a bridge across a fast turn: a Bandai Namco punch at 30 fps, a spike
  on the right upper arm at frames 251-252, was repaired from frame 250, which came out 16.8 deg off the clean
  take and left 251 37.6 deg off; the left knee's spike at frame 46 put the clean frame 45 8.2 deg off. Such
  a frame is left as it came (named, as below), and the run repaired without it.
* **A guess across a freeze is kept only where it comes nearer than the hold to the path the joins imply**
  (:func:`held_guess_runs`): a held run (:func:`held`) that is bridged, or written from the take's own next moment
  alone (as :func:`open_end_runs` reads it), over all its frames or some of them, is judged by no join: the hold
  joins the take smoothly where it starts and with its own step where it ends, so the rules above let any smooth
  guess through. Yet the take holds two more facts than a slerp uses: the joint's turn into the run (the frame
  before it from the one before that) and out of it (the frame after it into the next). The cubic Hermite curve that
  leaves the last live sample at the first and arrives at the run's next frame with the second (:func:`joined_path`)
  is the path those joins imply; a guess no nearer to it, on average over the run, than the held input is given
  back. A run written throughout from a repeat of the motion elsewhere in the take or its context is evidence of its
  own and is not judged so; one that a word covers in part is a guess where it is not, and the blend carries the
  guess into the word's frames. HDM05 bk ``rotateArmsBothBackward1Reps`` (``real_errors`` seed 1002): the right
  wrist frozen over frames 101-133 turns 17 deg one way and back while frozen, and its bridge, turning the other
  way, comes out 15.8 deg off the clean take where the freeze is 9.6 (7.0 against 3.9 deg from the joined path); bd
  ``sneak2StepsLStart`` 001 (seed 1001): the right toes' freeze over 102-126, written from the take's own next
  moment, flexes where the toes extend (12.1 against 10.8 deg off the clean take; 13.5 against 12.2 from the path);
  dg ``throwBasketball`` 007 (seed 1002): the right wrist, which hardly moves, frozen over 268-300, bridged over its
  first 5 frames and written from a neighbour word over the rest, came out 7.6 deg off the clean take where the
  freeze is 4.2 (6.8 against 6.2 deg from the path).
* **An error the take's own motion put back ends where its exchange ends** (:func:`margin_runs`): the
  confirmation takes in the digressing frames within its margin (``confirm_margin_s``) of a break, for the
  neighbour words an error leads astray span it on both sides; where a swap is exchanged back or an offset
  taken away, the joins of the take's own motion bound the error, and a run of the same joint replaced from
  neighbour words over frames only that margin (and the break's frame) away from it is the digression spread
  past the error, not an error of its own. Bandai Namco ``dataset-2_walk_active_013`` (seed 2001): the
  forearms' swap over frames 52-56, exchanged back, and the left one's frames 58-59, clean, written from a
  neighbour word 1.1 deg off the clean take; HDM05 bd ``jogLeftCircle4StepsRstart`` 001 (seed 1002): the
  right upper arm's clean frame 81, six frames past its swap exchanged back over 14-74, 1.0 deg off. Such a run is
  given back and named.
* **A left/right pair is put back together or not at all** (:func:`pair_left`): where the guard leaves a run
  of one joint of a pair (:func:`~mocapkit.joints.mirror_pairs`), the partner's repaired runs over the same
  frames are left too. Two sides that digress over the same frames are most often one error of the pair (a
  swap the detection did not name as one); half repaired, one limb of the pair takes a neighbour word's motion
  while the other still holds the first one's: the same punch with its upper arms swapped over frames
  150-164 had its left arm repaired (24.6 deg off the clean take) and its right one left holding the left
  arm's motion.

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

__all__ = ["LEFT_PREFIX", "LeftRun", "ON_PATH_RATIO", "angular_acceleration", "end_roughness", "guard_joint", "held",
           "held_guess_runs", "joined_path", "margin_runs", "on_path_ends", "open_end_runs", "pair_left", "rougher_end",
           "roughness"]

#: degrees per frame squared a repaired run may add to the input's largest angular acceleration: the joins of a
#: 0.25 s blend add about 1 (a smooth drift repaired from a twin: 0.1 -> 1.1), a step put into a real turn tens
ROUGHNESS_TOL_DEG = 2.0
#: degrees per frame squared a repaired run may add at one of its ends to the input's angular acceleration there
#: (:func:`rougher_end`): the joins of good repairs on the HDM05 and CMU takes tuned on added up to 2.4, the steps
#: put where flags ran on past an error over clean frames 6-9
END_TOL_DEG = 5.0
#: a run's end frame lies on the joint's own path (:func:`on_path_ends`) when the angular acceleration on its
#: outer side is under this share of the one at the frame (the punch's upper arm: 7.9 against 76.4 deg/frame^2,
#: its knee 4.0 against 38.6; a swap's or an offset's first frame, off the path, has its step on its outer side)
ON_PATH_RATIO = 0.25
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


def open_end_runs(changed: np.ndarray, own_next: np.ndarray) -> list[tuple[int, int, str]]:
    """The runs of ``changed`` (F,) bool, one joint's changed frames, that start or end the take and hold a cell of
    ``own_next`` (F,) bool (written from words of the take itself at most a word from the cell's source word, not
    put back by the take's own motion), as ``(start, end, reason)`` (end exclusive): a guess with no join at the
    take's edge and no repeat of the motion to check it by (module docstring)."""
    changed, sole = np.asarray(changed, dtype=bool), np.asarray(own_next, dtype=bool)
    F = len(changed)
    out = []
    for s, e in contact_segments(changed):
        if (s == 0 or e == F) and sole[s:e].any():
            edge = "first" if s == 0 else "last"
            out.append((int(s), int(e), f"written up to the take's {edge} frame from the take's own next moment: no "
                                        f"frame beyond it nor a repeat of the motion to judge it by"))
    return out


def joined_path(q: np.ndarray, start: int, end: int) -> np.ndarray | None:
    """(end - start, 4) unit quaternions: the path the joins of the run ``start .. end - 1`` of the track ``q`` (F, 4)
    imply (module docstring); None where the run has no turn on one side to read (``start < 2`` or
    ``end > F - 2``).

    The cubic Hermite curve, in rotation vectors about ``q[start - 1]`` (radians), from that frame to ``q[end]``
    over ``end - start + 1`` frame steps, its tangents the joint's turn into the run (``q[start - 2]`` to
    ``q[start - 1]``) and out of it (``q[end]`` to ``q[end + 1]``), each a turn per frame: the smoothest path that
    meets both joins at the joint's own position and speed. The values inside the run are never read.
    """
    q = np.asarray(q, dtype=np.float64)
    F = len(q)
    if start < 2 or end > F - 2 or end <= start:
        return None
    base = q[start - 1]
    rel = R.quaternion_to_rotvec(R.quaternion_multiply(R.quaternion_inverse(base)[None], q[[start - 2, end, end + 1]]))
    p1 = rel[1]
    m0, m1 = -rel[0], rel[2] - rel[1]  # radians per frame: the turn into the run and out of it
    steps = end - start + 1
    u = (np.arange(start, end) - (start - 1))[:, None] / steps
    path = (u**3 - 2 * u**2 + u) * steps * m0 + (3 * u**2 - 2 * u**3) * p1 + (u**3 - u**2) * steps * m1
    return R.quaternion_multiply(base[None], R.rotvec_to_quaternion(path))


def held_guess_runs(orig: np.ndarray, out: np.ndarray, changed: np.ndarray,
                    guess: np.ndarray) -> list[tuple[int, int, str]]:
    """The held runs of one joint's repair whose guess comes no nearer than the hold to the path their joins imply
    (module docstring), as ``(start, end, reason)`` (end exclusive).

    ``orig``, ``out`` (F, 4): the joint's input and repaired tracks; ``changed`` (F,) bool: the frames the repair
    changed (the runs judged are its maximal runs); ``guess`` (F,) bool: the cells no repeat of the motion wrote
    (bridged, or written from the take's own next moment alone). A run is judged where the input holds the joint
    bit-still in it (:func:`held`) and some cell of it is a guess; the mean angle (degrees) of the output and of
    the input from :func:`joined_path` over the run are compared.
    """
    orig, out = np.asarray(orig, dtype=np.float64), np.asarray(out, dtype=np.float64)
    guess = np.asarray(guess, dtype=bool)
    bad = []
    for s, e in contact_segments(np.asarray(changed, dtype=bool)):
        if not (guess[s:e].any() and held(orig, s, e)):
            continue
        path = joined_path(orig, s, e)
        if path is None:
            continue
        d_out = float(np.degrees(R.geodesic_angle(out[s:e], path)).mean())
        d_in = float(np.degrees(R.geodesic_angle(orig[s:e], path)).mean())
        if d_out >= d_in:
            bad.append((int(s), int(e), f"a guess across a freeze {d_out:.1f} deg from the path its joins imply, the "
                                        f"hold {d_in:.1f}"))
    return bad


def margin_runs(changed: np.ndarray, replaced: np.ndarray, undone: np.ndarray,
                margin: int) -> list[tuple[int, int, str]]:
    """The runs of one joint's repair that lie within the confirmation's margin beside a run the take's own motion
    put back (module docstring), as ``(start, end, reason)`` (end exclusive).

    ``changed`` (F,) bool: the frames the repair changed (the runs judged are its maximal runs); ``replaced`` (F,)
    bool: the frames written from neighbour words or bridged; ``undone`` (F,) bool: the frames put back by the
    take's own motion (a swap exchanged back, an offset taken away); ``margin`` frames: the confirmation's margin
    at the take's rate (``round(confirm_margin_s * fps)``). A run replaced throughout, with no frame put back,
    is judged; it fails where it lies within ``margin + 1`` frames after the end of a run of ``undone`` (the
    break's second frame, then the margin) or before its start.
    """
    changed, replaced = np.asarray(changed, dtype=bool), np.asarray(replaced, dtype=bool)
    undone = np.asarray(undone, dtype=bool)
    put_back = contact_segments(undone)
    bad = []
    for s, e in contact_segments(changed):
        if undone[s:e].any() or not replaced[s:e].all():
            continue
        for a, b in put_back:
            if b <= s and e <= b + margin + 1 or e <= a and s >= a - margin - 1:
                bad.append((int(s), int(e), f"within the confirmation's margin of frames {a}-{b - 1}, put back by the "
                                            "take's own motion: the digression spread past the error"))
                break
    return bad


def on_path_ends(q: np.ndarray, flags: np.ndarray) -> np.ndarray:
    """(F,) bool: the frames of ``flags`` (F,) bool, one joint's flagged frames to replace, that lie on the joint's
    own path at the ends of their runs (module docstring), to be left as they came.

    ``q`` (F, 4) the joint's input track. A run's first frame ``s`` is on the path when the angular acceleration
    (:func:`angular_acceleration`) at ``s - 1``, the turn from the frames before it into ``s``, is under
    :data:`ON_PATH_RATIO` times the one at ``s`` (the turn from ``s`` into the run's next frame), and that is a
    step (over :data:`END_TOL_DEG`); its last frame ``l`` likewise with ``l + 1`` on the outer side. At most one
    frame at each end, never a whole run, and never at the take's first or last two frames (no acceleration
    there on the outer side).
    """
    flags = np.asarray(flags, dtype=bool)
    out = np.zeros(len(flags), dtype=bool)
    runs = contact_segments(flags)
    if not runs:
        return out
    acc = angular_acceleration(q)
    F = len(flags)
    for s, e in runs:
        if e - s < 2:
            continue
        if s >= 2 and acc[s] > END_TOL_DEG and acc[s - 1] < ON_PATH_RATIO * acc[s]:
            out[s] = True
        last = e - 1
        if last + 1 <= F - 2 and last - 1 > s - (0 if out[s] else 1) and acc[last] > END_TOL_DEG \
                and acc[last + 1] < ON_PATH_RATIO * acc[last]:
            out[last] = True
    return out


def pair_left(changed: np.ndarray, left: list[tuple[int, int, int]], partner,
              replaced: np.ndarray | None = None) -> list[tuple[int, int, int, str]]:
    """The runs to leave because the guard left their left/right partner's run over the same frames (module
    docstring), as ``(joint, start, end, reason)``, until none is added.

    ``changed`` (F, J) bool: the cells the repair changed (the runs judged are each joint's maximal runs);
    ``left`` ``(joint, start, end)``: the runs the guard left (the frames ``start .. end - 1``), whose partner's
    runs over the same frames (sharing half the frames the two span or more) are judged; ``partner`` (J,)
    int: each joint's partner (:func:`~mocapkit.joints.mirror_pairs`, itself when unpaired); ``replaced`` (F, J)
    bool or None (all): the cells replaced from neighbour words or bridged. Only a partner's run replaced so
    throughout is left: a run that the take's own motion puts back in part (a swap exchanged back, an offset
    taken away) is confirmed at that part's joins, whatever its partner's repair did (HDM05 bk throwBasketball
    004 with ``real_errors`` seed 1002: the left forearm's swap exchanged back, 27.0 -> 0.6 deg off the clean
    take, while the right one's flags over clean frames before the swap were left; dg lieDownFloor 011, seed
    1001: the left femur's swap over frames 95-111, 129.6 -> 1.0 deg off, while the right femur's 58 frames were
    left: not the same frames).
    """
    partner = np.asarray(partner, dtype=np.int64)
    replaced = np.ones(changed.shape, dtype=bool) if replaced is None else np.asarray(replaced, dtype=bool)
    todo = list(left)
    done: set[tuple[int, int, int]] = set(left)
    out = []
    while todo:
        j, s, e = todo.pop()
        p = int(partner[j])
        if p == j or not changed[s:e, p].any():
            continue
        for a, b in contact_segments(changed[:, p]):
            same = 2 * (min(b, e) - max(a, s)) >= max(b, e) - min(a, s)  # over the same frames: half their union
            if same and (p, a, b) not in done and replaced[a:b, p].all():
                done.add((p, a, b))
                todo.append((p, a, b))
                out.append((p, a, b, f"its left/right partner's repair over frames {s}-{e - 1} was left: a pair is "
                                     "put back together or not at all"))
    return out
