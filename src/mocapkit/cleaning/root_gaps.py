"""The root's own gaps on rigs whose root is the pelvis (HDM05 and CMU ASF/AMC, CMU BVH): filled from the body.

The networks read and write the non-root joints' channels only (Mall et al. 2017, section 3: "we assume that the
trajectory of the root of the skeleton is clean"), so a take whose root rotation or position is missing over a
stretch has its body filled by them (by the cubic spline on a rig they do not serve) and its root by this module
whatever fills the body (:func:`fill_root_gaps`), conditioned on the rest of the body where the body says something
about it, else by a curve that meets the gap's ends and their velocities. On a rig no network serves (34 root
gaps of 0.5-2.6 s in HDM05 and CMU takes on the LaFAN1, Xsens, Daz and Unity rigs less their clavicles) the
position lost alone is 11.2 -> 9.5 cm RMS off against the cubic spline (median 4.2 -> 1.9), and the rotation lost
with it 27.9 -> 20.4 deg (median 4.3 -> 3.8; 18 gaps nearer, 16 further):

- **Position** (:func:`contact_path`): a planted foot stays where it is in the world, so across a gap the root moves
  opposite to the lowest foot joint's motion relative to it (the body's own pose in the gap, turned by the root's
  rotation): the root's path is the sum of those steps from the frame before the gap. The path is then bent
  linearly onto the measured frame after the gap. Where it misses that frame by more than
  :data:`CONTACT_MISS_CM` the feet were not planted (a jump, a slide, a fall) and the cubic interpolating spline of
  :func:`mocapkit.cleaning.gapfill.fill_channels` (through the observed samples around the gap: it meets both
  ends' velocities) fills it instead. So does it where the root's rotation is lost too over the gap or at its
  ends: the feet, turned about the root by a filled rotation a few degrees off, put the path further off than the
  spline (on 18 gaps of 0.5-2.6 s in HDM05 and CMU takes on the Acclaim and Xsens rigs, the root lost whole:
  10.9 -> 10.2 cm RMS, median 4.5 -> 1.5, 12 nearer and 2 further), as :func:`fill_pelvis_path` leaves the
  contacts out under a filled pelvis rotation.
- **Rotation** (:func:`fill_root_rotation`): the root's rotation is taken apart into its heading (the twist about
  the vertical) and its tilt (the rest, in the heading's frame, :func:`heading_and_tilt`). The heading, which
  the local pose cannot tell, is filled by the cubic spline of its unwrapped angle; the tilt either by the
  Hermite curve that meets both ends' angular velocities, blended into the line between them away from the ends
  (:func:`mocapkit.cleaning.deep.prior.hermite_blend`), or from the body: a ridge regression of the tilt on the
  sines and cosines of every other joint's channels, fitted on the take's own frames where the root is
  measured, plus the line between its misses at the gap's ends (so that it meets both). Which of these two, or
  the cubic spline of the whole rotation, fills a gap is decided on the take itself: each fills
  :data:`CHECK_STRETCHES` stretches of the same length cut from the frames where the root is measured, and the
  one nearest the truth there fills the gap (the take's own evidence: a long take of a steady gait gives the
  regression enough frames, a short one picks the curve).

On a game rig whose root stays on the floor and whose pelvis carries the body's path in its animated offset (the
Bandai Namco rig's ``Hips`` over ``joint_Root``), :func:`fill_pelvis` fills the pelvis' path alike: found by its
role, taken to the world through the joints above it, filled by the feet's contacts, the cubic spline or the line
between the gap's ends, whichever refills the take's own measured stretches best (:func:`fill_pelvis_path`), and
the contacts only where the pelvis' rotation is measured over the gap. The pelvis' rotation there is the
networks' (they read and write it as any other joint's). On 35 gaps of 0.5-2 s in 24 Bandai takes (both datasets,
none the rule was chosen on) with the position channels written ``nan`` the path is 7.4 -> 3.4 cm RMS off against
the line (median 5.1 -> 0.6), and 7.4 -> 7.0 with the rotation lost too (the networks' rotation, 3 deg off at the
median, swings the feet about the pelvis: the contacts are not used there).

Runs touching the take's first or last frame hold the nearest measured value (one end: nothing to meet). Measured root
rotations and position axes are returned bit-identical. On gaps of 0.5-2 s cut into real takes (``../shared/data``; 53
HDM05 AMC gaps of each kind in takes other than those the constants were chosen on, 14 CMU AMC and 12 CMU BVH at other
frames of the same takes) the position is 15.3 -> 5.5, 10.1 -> 9.1, 16.0 -> 11.2 cm RMS off against the line between
the gap's ends, the rotation 12.7 -> 11.2, 27.5 -> 25.5, 22.3 -> 23.3 deg: a heading that turns on through the gap (a
spin) is not in the body's pose, and neither fill finds it.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import rotations as R
from ..errors import SkeletonError
from ..features import detect_up_axis, find_up_axis
from ..joints import find_joint, unit_scale_cm
from ..motion import Motion
from ..rigs import pelvis_index
from .deep.prior import hermite_blend
from .gapfill import fill_channels
from .runs import column_runs

__all__ = ["fill_root_gaps", "fill_root", "fill_pelvis", "fill_pelvis_path", "fill_root_rotation", "contact_path",
           "heading_and_tilt", "foot_joints", "CONTACT_MISS_CM", "CHECK_STRETCHES", "TILT_RIDGE", "FOOT_ROLES"]

#: Centimetres: the foot contacts' path across a position gap is kept where it lands this close to the measured
#: frame after the gap (bent onto it), else the cubic spline fills the gap (the feet were not planted).
CONTACT_MISS_CM = 20.0
#: Stretches of the take, as long as a gap, on which the candidate fills are tried (:func:`fill_root_rotation`,
#: :func:`fill_pelvis_path`).
CHECK_STRETCHES = 6
#: Frames kept clear of any gap on each side of a trial stretch.
CHECK_MARGIN = 10
#: The ridge weight of the tilt's regression on the body's channels (standardised features), per frame.
TILT_RIDGE = 0.1
#: Seconds over which the velocity at a gap's end is read (a backward or forward mean slope).
SLOPE_S = 1 / 30
#: The joints whose lowest is taken as the planted one: the ankles and the toes (the ankles alone on a rig without
#: toes, :func:`foot_joints`).
FOOT_ROLES = ("left_foot", "right_foot", "left_toe", "right_toe")


def _runs(gap: np.ndarray) -> list[tuple[int, int]]:
    """Runs of True of a (F,) bool mask as ``(start, end)``, end exclusive."""
    _, start, end = column_runs(np.asarray(gap, dtype=bool)[:, None])
    return list(zip(start.tolist(), end.tolist()))


def foot_joints(skeleton) -> list[int]:
    """The joints of :data:`FOOT_ROLES` the rig has: both ankles, and the toes where it has them (the Daz release's
    rig has none: its ankles are the lowest joints of its legs). Raises KeyError where an ankle is not found."""
    feet = [find_joint(skeleton, r) for r in FOOT_ROLES[:2]]
    for role in FOOT_ROLES[2:]:
        try:
            feet.append(find_joint(skeleton, role))
        except KeyError:
            pass
    return feet


def heading_and_tilt(q: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(heading, tilt)`` of rotations ``q`` (F, 4): the twist angle about the vertical ``up`` (3,) in radians (F,),
    and the rest ``conj(twist) q`` as a rotation vector (F, 3) in the heading's frame (the pelvis' pitch and roll,
    the same whichever way the body faces); ``q = twist(heading) * exp(tilt)``."""
    t = R.quaternion_twist(q, up)
    heading = 2.0 * np.arctan2(t[..., 1:] @ up, t[..., 0])
    return heading, R.quaternion_to_rotvec(R.quaternion_multiply(R.quaternion_conjugate(t), q))


def _slopes(x: np.ndarray, a: int, b: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame velocities (D,) of ``x`` (F, D) at ``a`` (read over up to ``k`` frames before it) and ``b`` (after
    it), over the finite samples next to each; zero where only the end itself is."""
    F = len(x)

    def one(at: int, step: int) -> np.ndarray:
        idx = at + step * np.arange(k + 1)
        idx = idx[(idx >= 0) & (idx < F)]
        ok = np.isfinite(x[idx]).all(axis=-1)
        n = len(idx) if ok.all() else int(np.argmin(ok))
        return (x[idx[n - 1]] - x[idx[0]]) / (step * (n - 1)) if n > 1 else np.zeros(x.shape[1:])

    return one(a, -1), one(b, 1)


def _blend(x: np.ndarray, gap: np.ndarray, fps: float) -> np.ndarray:
    """``x`` (F, D) with its ``gap`` rows (F,) filled by :func:`~mocapkit.cleaning.deep.prior.hermite_blend` of the
    line between the ends (the Hermite curve meeting both ends' velocities near them); edge runs hold."""
    out = fill_channels(np.where(gap[:, None], np.nan, x), "linear")
    k = max(1, int(round(SLOPE_S * fps)))
    F = len(x)
    for s, e in _runs(gap):
        if s == 0 or e == F:
            continue
        va, vb = _slopes(np.where(gap[:, None], np.nan, x), s - 1, e, k)
        i = np.arange(e - s)[:, None]
        out[s:e] = hermite_blend(out[s:e], i, e - s, x[s - 1], x[e], va, vb, fps)
    return out


def _body_features(body: Motion) -> np.ndarray:
    """(F, 2K) the sines and cosines of the K rotation channels of ``body``'s non-root joints (0 where NaN)."""
    sk = body.skeleton
    cols = [i for i, (j, c) in enumerate((j, c) for j in range(sk.num_joints) for c in sk.joint_channels(j))
            if j > 0 and c.endswith("rotation")]
    x = np.radians(np.nan_to_num(body.channel_values()[:, cols]))
    return np.concatenate([np.sin(x), np.cos(x)], axis=1)


def _ridge(X: np.ndarray, Y: np.ndarray, fit: np.ndarray) -> np.ndarray:
    """The ridge regression (:data:`TILT_RIDGE`, standardised ``X``) of ``Y`` (F, D) on ``X`` (F, P) fitted on the
    rows ``fit`` (F,) bool, evaluated on every row."""
    Xf, Yf = X[fit], Y[fit]
    mu, sd, ym = Xf.mean(axis=0), Xf.std(axis=0) + 1e-6, Yf.mean(axis=0)
    Z = (Xf - mu) / sd
    W = np.linalg.solve(Z.T @ Z + TILT_RIDGE * len(Z) * np.eye(Z.shape[1]), Z.T @ (Yf - ym))
    return ((X - mu) / sd) @ W + ym


def _candidates(q: np.ndarray, gap: np.ndarray, up, X, fps: float) -> dict[str, np.ndarray]:
    """The root rotations (F, 4) of each candidate fill of the ``gap`` rows of ``q`` (F, 4; measured rows kept):
    ``"spline"`` the cubic spline of the quaternion's components, ``"curve"`` heading by the cubic spline and tilt
    by the blended Hermite curve, ``"body"`` heading alike and tilt from the body (:func:`fill_root_rotation`)."""
    seen = ~gap
    qc = np.where(gap[:, None], np.nan, q)
    qc[seen] = R.quaternion_continuity(q[seen])
    out = {"spline": R.quaternion_normalize(fill_channels(qc, "cubic", fps))}
    if up is None:
        return out
    heading, tilt = heading_and_tilt(np.where(gap[:, None], R.identity(), q), up)
    heading[seen] = np.unwrap(heading[seen])
    heading = fill_channels(np.where(gap, np.nan, heading)[:, None], "cubic", fps)[:, 0]
    turn = R.quaternion_from_axis_angle(np.broadcast_to(up, (len(q), 3)), heading)
    tilts = {"curve": _blend(tilt, gap, fps)}
    if X is not None and seen.sum() > X.shape[1]:
        pred = _ridge(X, tilt, seen)
        tilts["body"] = pred + fill_channels(np.where(gap[:, None], np.nan, tilt - pred), "linear")
    for name, t in tilts.items():
        out[name] = R.quaternion_multiply(turn, R.rotvec_to_quaternion(t))
    return out


def _trials(gap: np.ndarray, trial) -> dict[int, list]:
    """For each length ``n`` of an interior run of ``gap`` (F,) bool: the answers of ``trial(cut, a, b)`` on up to
    :data:`CHECK_STRETCHES` stretches ``a .. b - 1`` of ``n`` frames clear of ``gap`` by :data:`CHECK_MARGIN`, spread
    evenly over the take, ``cut`` (F,) bool the gap with the stretch cut too: the take's measured frames on which
    :func:`fill_root_rotation` and :func:`fill_pelvis_path` try their candidate fills."""
    F = len(gap)
    cs = np.concatenate([[0], np.cumsum(gap)])
    out: dict[int, list] = {}
    for s, e in _runs(gap):
        n = e - s
        if n in out or s == 0 or e == F:
            continue
        first = np.arange(CHECK_MARGIN, F - n - CHECK_MARGIN)
        first = first[cs[first + n + CHECK_MARGIN] == cs[first - CHECK_MARGIN]]
        pick = np.linspace(0, len(first) - 1, min(CHECK_STRETCHES, len(first))).round().astype(int)
        out[n] = []
        for a in sorted(set(first[pick].tolist())):
            cut = gap.copy()
            cut[a:a + n] = True
            out[n].append(trial(cut, a, a + n))
    return out


def fill_root_rotation(q: np.ndarray, gap: np.ndarray, fps: float, up=None, X=None) -> tuple[np.ndarray, dict]:
    """The root rotations ``q`` (F, 4) with their ``gap`` rows (F,) bool filled (module notes); measured rows
    bit-identical. ``up`` (3,): the vertical (None: the spline alone); ``X`` (F, P): the body's features
    (:func:`_body_features`; None: no regression). Returns ``(q, chosen)``: ``chosen`` maps each gap's
    ``(start, end)`` to the candidate that filled it (``"spline"``, ``"curve"`` or ``"body"``)."""
    q = np.asarray(q, dtype=np.float64)
    gap = np.asarray(gap, dtype=bool)
    if not gap.any() or gap.all():
        return q.copy(), {}
    full = _candidates(q, gap, up, X, fps)
    out = np.array(q)
    chosen = {}
    trials = _trials(gap, lambda trial, a, b: {
        name: float(np.mean(R.geodesic_angle(got[a:b], q[a:b]) ** 2))
        for name, got in _candidates(q, trial, up, X, fps).items()})
    # a candidate a stretch cannot make (the body's, on too few measured frames) adds nothing to its score
    score = {n: {name: sum(t.get(name, 0.0) for t in got) for name in full} for n, got in trials.items()}
    for s, e in _runs(gap):
        tried = score.get(e - s)
        best = min(tried, key=tried.get) if tried and any(tried.values()) else ("curve" if "curve" in full
                                                                                  else "spline")
        chosen[(s, e)] = best
        out[s:e] = full[best][s:e]
    return out, chosen


def contact_path(p: np.ndarray, s: int, e: int, feet: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, float]:
    """The root positions (e - s, 3) of frames ``s .. e - 1`` from the foot contacts, and how far (file units) the
    contacts' path misses the measured frame ``e`` before it is bent onto it.

    ``p`` (F, 3): root positions, measured at ``s - 1`` and ``e``; ``feet`` (F, n, 3): the foot joints' positions
    relative to the root in world axes (the body's pose turned by the root's rotation). Each frame the lowest foot
    joint along ``up`` is taken as planted: the root steps by minus its motion to the next frame."""
    a, b = s - 1, e
    low = np.argmin(feet[a:b] @ up, axis=1)
    i = np.arange(b - a)
    path = p[a] + np.cumsum(feet[a:b][i, low] - feet[a + 1:b + 1][i, low], axis=0)  # frames s .. b
    miss = p[b] - path[-1]
    u = (np.arange(1, e - s + 1) / (e - s + 1.0))[:, None]
    return path[:-1] + u * miss, float(np.linalg.norm(miss))


def fill_root(motion: Motion, body: Motion | None = None) -> tuple[Motion, dict]:
    """``body`` (``motion`` with its other joints filled; default ``motion``) with the root's missing rotations and
    position axes of ``motion`` filled (module notes), every measured root number of ``motion`` bit-identical.

    Returns ``(motion, how)``: ``how`` maps ``("rotation" | "position", start, end)`` of each interior gap to what
    filled it (``"spline"``, ``"curve"``, ``"body"`` for a rotation; ``"contacts"`` or ``"spline"`` for a
    position: the spline where the root's rotation is lost too at a frame of the gap or beside it). A rig whose
    feet or vertical cannot be told fills by the spline alone."""
    body = motion if body is None else body
    rot_gap = np.isnan(motion.rotations[:, 0]).any(axis=-1)
    pos_in = motion.root_positions
    pos_gap = np.isnan(pos_in).any(axis=-1)
    how: dict = {}
    if not (rot_gap.any() or pos_gap.any()):
        return body, how
    sk = motion.skeleton
    try:
        up = detect_up_axis(sk)
        feet = foot_joints(sk)
        cm = unit_scale_cm(sk)
    except (KeyError, SkeletonError, ValueError):
        up, feet, cm = None, None, None
    rot = np.array(body.rotations)
    if rot_gap.all():  # nothing to fill from: the identity, as a joint never seen
        rot[:, 0] = R.identity((len(rot),))
    elif rot_gap.any():
        X = _body_features(body) if up is not None else None
        q, chosen = fill_root_rotation(motion.rotations[:, 0], rot_gap, motion.fps, up, X)
        rot[:, 0] = np.where(rot_gap[:, None], q, motion.rotations[:, 0])
        how.update({("rotation", s, e): c for (s, e), c in chosen.items()})
    pos = np.array(pos_in)
    if pos_gap.any() and not pos_gap.all():
        filled = fill_channels(np.where(pos_gap[:, None], np.nan, pos_in), "cubic", motion.fps)
        if feet is not None:
            local = dataclasses.replace(body, rotations=rot, root_positions=np.zeros_like(pos_in))
            at = local.global_positions()[:, feet]  # (F, n, 3): the feet relative to the root, in world axes
            for s, e in _runs(pos_gap):
                if s == 0 or e == len(pos_in):
                    continue
                path, miss = contact_path(filled, s, e, at, up)
                turned = rot_gap[s - 1:e + 1].any()  # the feet swing about a root rotation that is itself a fill
                kept = miss * cm <= CONTACT_MISS_CM and not turned
                how[("position", s, e)] = "contacts" if kept else "spline"
                if kept:
                    filled[s:e] = path
        pos = np.where(np.isnan(pos_in), filled, pos_in)
    elif pos_gap.all():  # nothing to fill from: an axis never measured at the origin, the others held
        pos = np.where(np.isnan(pos_in), 0.0, fill_channels(pos_in, "linear"))
    return dataclasses.replace(body, rotations=rot, root_positions=pos), how


def _path_candidates(w: np.ndarray, gap: np.ndarray, at: np.ndarray, up: np.ndarray, cm: float,
                     fps: float) -> dict[str, np.ndarray]:
    """The pelvis paths (F, 3) of each candidate fill of the ``gap`` rows (F,) of ``w`` (F, 3, world axes, file
    units): ``"line"`` the line between the gap's ends, ``"spline"`` the cubic spline, ``"contacts"`` the feet's
    contacts (:func:`contact_path` with the feet ``at`` (F, n, 3) relative to the pelvis; the spline where the path
    misses the far end by more than :data:`CONTACT_MISS_CM`). Runs touching the take's ends hold."""
    cut = np.where(gap[:, None], np.nan, w)
    spline = fill_channels(cut, "cubic", fps)
    contacts = np.array(spline)
    for s, e in _runs(gap):
        if 0 < s and e < len(w):
            path, miss = contact_path(spline, s, e, at, up)
            if miss * cm <= CONTACT_MISS_CM:
                contacts[s:e] = path
    return {"line": fill_channels(cut, "linear"), "spline": spline, "contacts": contacts}


def fill_pelvis_path(w: np.ndarray, gap: np.ndarray, at: np.ndarray, up: np.ndarray, cm: float, fps: float,
                     turned: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
    """The pelvis path ``w`` (F, 3; world axes, file units) with its ``gap`` rows (F,) filled, measured rows
    bit-identical: each gap by the candidate of :func:`_path_candidates` nearest the truth on :data:`CHECK_STRETCHES`
    stretches of the same length cut from the frames where the path is measured (as :func:`fill_root_rotation`
    chooses): a gap whose contacts reach its far end by those stretches where they reached theirs (the contacts, the
    spline or the line), any other by all of them (the spline or the line); where no stretch fits, the feet's contacts
    as :func:`fill_root` takes them, else the line. ``at`` (F, n, 3): the foot joints relative to the pelvis in world
    axes; ``cm``: centimetres per file unit; ``turned`` (F,) bool: the frames whose pelvis rotation is itself a fill.
    A gap that meets such a frame is not filled from the contacts: a pelvis turned a few degrees off swings the feet
    about it, and the stretches, whose rotation is measured, cannot tell how far (on the Bandai Namco takes, the
    networks' rotation, 3 deg off at the median, put the contacts' path further off the truth than the line on most
    gaps); nor is a gap whose contacts miss its far end by more than :data:`CONTACT_MISS_CM` (the feet were not
    planted: the stretches' evidence for the contacts does not hold there). Returns ``(w, chosen)``: ``chosen`` maps
    each gap's ``(start, end)`` to ``"line"``, ``"spline"`` or ``"contacts"``."""
    full = _path_candidates(w, gap, at, up, cm, fps)
    F = len(w)
    turned = np.zeros(F, dtype=bool) if turned is None else np.asarray(turned, dtype=bool)
    out = np.array(w)
    chosen = {}

    def tried(trial: np.ndarray, a: int, b: int) -> tuple[bool, dict[str, float]]:  # did the contacts hold; errors
        got = _path_candidates(w, trial, at, up, cm, fps)
        return (not np.array_equal(got["contacts"][a:b], got["spline"][a:b]),
                {name: float(np.mean(np.sum((got[name][a:b] - w[a:b]) ** 2, axis=-1))) for name in full})

    score = {n: ({name: sum(err[name] for _, err in got) for name in ("line", "spline")},  # all stretches
                 {name: sum(err[name] for held, err in got if held) for name in full})  # those the contacts held on
             for n, got in _trials(gap, tried).items()}
    for s, e in _runs(gap):
        every, on_held = score.get(e - s, ({}, {}))
        held = 0 < s and e < F and not np.array_equal(full["contacts"][s:e], full["spline"][s:e])
        if held and not turned[max(s - 1, 0):e + 1].any():  # the contacts as the stretches they held on judge them
            best = min(on_held, key=on_held.get) if any(on_held.values()) else "contacts"
        else:  # a turned pelvis, or contacts that missed the far end
            best = min(every, key=every.get) if any(every.values()) else "line"
        chosen[(s, e)] = best
        out[s:e] = full[best][s:e]
    return out, chosen


def fill_pelvis(motion: Motion, body: Motion) -> tuple[Motion, dict]:
    """``body`` (``motion`` with its joints' rotations filled and its animated offsets bridged) with the pelvis'
    missing animated offset filled from the body, on a game rig whose root stays on the floor and whose pelvis
    carries the body's path in its animated offset (``motion.translations[:, pelvis]``, (F, 3) file units: the
    Bandai Namco rig's ``Hips`` over ``joint_Root``), every measured number of ``motion`` bit-identical.

    The pelvis is found by its role (:func:`mocapkit.rigs.pelvis_index`). Its path is taken to the world through
    the joints above it (in ``body``), filled there by :func:`fill_pelvis_path` (the feet's contacts, the cubic
    spline or the line, whichever refills the take's own measured stretches best), and brought back into the
    parent's frame. Its rotation is ``body``'s: the networks read and write the pelvis' rotation on that rig, as
    any other joint's. A rig whose root is the pelvis is :func:`fill_root`'s, and a rig without animated offsets,
    feet, or a measured frame of the pelvis' offset keeps ``body``'s. Returns ``(motion, how)``: ``how`` maps
    ``("position", start, end)`` of each interior gap to what filled it.
    """
    tr = motion.translations
    sk = motion.skeleton
    j = pelvis_index(sk)
    if j == 0 or tr is None or body.translations is None:
        return body, {}
    off_in = tr[:, j]
    gap = np.isnan(off_in).any(axis=-1)
    if not gap.any() or gap.all():
        return body, {}
    try:
        feet = foot_joints(sk)
        cm = unit_scale_cm(sk)
    except (KeyError, SkeletonError, ValueError):
        return body, {}
    parent = int(sk.parents[j])
    # the feet are read through the measured rotations: the networks refill a cell whose offset alone is lost
    seen = ~np.isnan(motion.rotations).any(axis=-1, keepdims=True)
    read = dataclasses.replace(body, rotations=np.where(seen, motion.rotations, body.rotations))
    grot, gpos = read.global_transforms()
    up = find_up_axis(sk, gpos)
    above, base = grot[:, parent], gpos[:, parent]
    w = base + R.quaternion_rotate(above, np.where(gap[:, None], 0.0, off_in))
    w[gap] = np.nan
    at = gpos[:, feet] - gpos[:, j][:, None]  # (F, n, 3): the feet relative to the pelvis, in world axes
    turned = np.isnan(motion.rotations[:, j]).any(axis=-1)
    filled, chosen = fill_pelvis_path(w, gap, at, up, cm, motion.fps, turned)
    local = R.quaternion_rotate(R.quaternion_conjugate(above), filled - base)
    trans = np.array(body.translations)
    trans[:, j] = np.where(np.isnan(off_in), local, off_in)
    return dataclasses.replace(body, translations=trans), {("position", s, e): c for (s, e), c in chosen.items()}


def fill_root_gaps(motion: Motion, body: Motion) -> tuple[Motion, dict]:
    """``body`` (``motion`` with its other joints filled, by the networks or by the cubic spline where none serves
    the rig, and its other animated offsets bridged) with ``motion``'s lost root filled from the body
    (:func:`fill_root`) and a game rig's lost pelvis path too (:func:`fill_pelvis`): the one place every fill of a
    take (:func:`mocapkit.cleaning.deep.fill_or_fallback`) takes the root from, whatever fills the rest. Every
    measured root or pelvis number of ``motion`` is bit-identical. Returns ``(motion, how)``: ``how`` maps
    ``"root"`` and ``"pelvis"`` to what :func:`fill_root` and :func:`fill_pelvis` say filled each gap."""
    how: dict = {"root": {}, "pelvis": {}}
    if motion.missing()[:, 0].any():
        body, how["root"] = fill_root(motion, body)
    if motion.translations is not None:
        body, how["pelvis"] = fill_pelvis(motion, body)
    return body, how
