"""Repair: replace the flagged joints in flagged frames by the median of their neighbour words (section 4).

Each flagged cell takes the medoid of its source word's neighbour words (the
median of the KNN, an actual motion, as the paper requires) on the word's
flagged joints, blended into the untouched motion with a quadratic
Savitzky-Golay filter; every unflagged value stays bit-identical. A transient
offset's cells keep the joint's own motion, its offset taken away
(:mod:`~mocapkit.cleaning.ssa.undo`); a left/right swap's cells take back their
partner's mirrored rotations (:mod:`~mocapkit.cleaning.ssa.swap_exchange`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ... import rotations as R
from ...errors import SkeletonError
from ...motion import Motion, find_joint, mirror_pairs
from ..filters import window_frames
from ..ik import contact_segments, segment_frames
from .cues import mirrored_rotations
from .detect import Detection
from .neighbours import dropped_terms, near_neighbors, neighbor_words
from .repeats import blend_inbetweens, expand, frame_index, kept_frames, repeat_runs, without_repeats
from .texture import Analysis, align_hemisphere, frame_words, prepare
from .guard import LeftRun, guard_joint, held_guess_runs, margin_runs, on_path_ends, open_end_runs, pair_left
from .negligible import negligible_runs
from .limb_paths import HALF_TURN_DEG, exchange_nearer, limb_left, limb_positions, limb_runs
from .swap_exchange import pair_exchange, partner_swaps, swap_exchanges
from .undo import undone_offsets
from ...words import plural

__all__ = ["Contact", "repair", "repair_with_left"]


@dataclass(frozen=True)
class Contact:
    """An end-effector contact the repair must respect (section 4, Fig. 7).

    joint : name of the end effector (e.g. ``"lwrist"``); frames ``[start,
    end)`` of the input; position : (3,) world position in the file's units.
    """

    joint: str
    start: int
    end: int
    position: tuple

    def target(self) -> np.ndarray:
        return np.asarray(self.position, dtype=np.float64).reshape(3)


def _medoid(words: list[np.ndarray], cols: np.ndarray) -> int:
    """Index of the word closest to all others (sum of squared angles) on the rows ``cols``: the KNN's median."""
    if len(words) == 1:
        return 0
    X = np.stack([w[:, cols] for w in words])  # (K, N, c, 4)
    K = len(words)
    a, b = np.triu_indices(K, 1)
    pair = np.sum(R.geodesic_angle(X[a], X[b]) ** 2, axis=(1, 2))
    cost = np.zeros((K, K))
    cost[a, b] = cost[b, a] = pair
    return int(np.argmin(cost.sum(axis=1)))


def _blend_runs(orig: np.ndarray, new: np.ndarray, flags: np.ndarray, window: int) -> np.ndarray:
    """Smooth transitions into and out of replaced runs, changing only flagged frames (section 4).

    ``orig``, ``new`` (F, 4) one joint's track; ``flags`` (F,). Each run's
    replacement is first offset so that it meets the original at both ends
    (a displacement blended linearly across the run), then the hybrid track is
    filtered with a quadratic Savitzky-Golay filter of ``window`` frames, and
    only the flagged frames take the filtered values. All runs are offset at
    once: :func:`_run_continuity` makes each run hemisphere-continuous on its own.
    """
    F = len(orig)
    out = np.array(orig)
    track = np.array(orig)
    runs = np.array(contact_segments(flags), dtype=np.int64).reshape(-1, 2)
    if len(runs):
        a, b = runs[:, 0], runs[:, 1]
        n = b - a
        idx, run_of, first = segment_frames(a, n)  # the flagged frames run after run, their runs, each run's first
        ref = np.where((a > 0)[:, None], orig[np.maximum(a - 1, 0)], new[a])
        rep = _run_continuity(align_hemisphere(new[idx], ref[run_of]), first, run_of)
        da = np.zeros((len(runs), 3))
        before = a > 0
        da[before] = R.quaternion_log(R.quaternion_multiply(orig[a[before] - 1], R.quaternion_inverse(rep[first[before]])))
        db = da * 0
        after = b < F
        db[after] = R.quaternion_log(R.quaternion_multiply(orig[b[after]], R.quaternion_inverse(rep[(first + n - 1)[after]])))
        da = np.where(before[:, None], da, db)  # a run at either end takes the other end's displacement
        db = np.where(after[:, None], db, da)
        u = (idx - (a - 1)[run_of]) / (b - (a - 1))[run_of]
        delta = (1 - u)[:, None] * da[run_of] + u[:, None] * db[run_of]
        track[idx] = R.quaternion_multiply(R.quaternion_exp(delta), rep)
    cont = R.quaternion_continuity(track, axis=0)
    if F >= window:
        from scipy.signal import savgol_filter  # here: importing scipy.signal takes ~1 s

        smooth = savgol_filter(cont, window, 2, axis=0, mode="interp")
    else:
        smooth = cont
    smooth = R.quaternion_normalize(smooth)
    out[flags] = align_hemisphere(smooth[flags], orig[flags])
    return out


def _run_continuity(q: np.ndarray, first: np.ndarray, run_of: np.ndarray) -> np.ndarray:
    """:func:`mocapkit.rotations.quaternion_continuity` of each run of ``q`` (K, 4) on its own.

    The runs are consecutive rows; ``first`` (n,) their first rows, ``run_of``
    (K,) the run of each row. Signs flip where consecutive rows of a run lie in
    opposite hemispheres (NaN rows bridged, as there); the first row of each
    run keeps its sign.
    """
    pos = np.arange(len(q))
    valid = np.all(np.isfinite(q), axis=-1)
    last = np.maximum.accumulate(np.where(valid, pos, first[run_of]))  # the last valid row of the run so far
    filled = q[last]
    flips = np.zeros(len(q), dtype=np.int64)
    flips[1:] = np.sum(filled[1:] * filled[:-1], axis=-1) < 0.0
    parity = np.cumsum(flips)
    parity -= parity[first][run_of]
    return q * np.where(parity % 2 == 1, -1.0, 1.0)[:, None]


def _bridge(track: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Slerp each run of ``mask`` (F,) in ``track`` (F, 4, changed in place) between its ends; the frames bridged.

    A run's ends are the frames just before and after it (a run at either
    end of the take takes the other end's value on both sides; a run over the
    whole track is left alone). Runs are maximal, so their ends lie outside
    every run and all runs are bridged at once.
    """
    F = len(track)
    runs = np.array(contact_segments(mask), dtype=np.int64).reshape(-1, 2)
    runs = runs[(runs[:, 0] > 0) | (runs[:, 1] < F)]
    a, b = runs[:, 0], runs[:, 1]
    lo = track[np.where(a > 0, a - 1, np.minimum(b, F - 1))]
    hi = np.where((b < F)[:, None], track[np.minimum(b, F - 1)], lo)
    idx, run_of, _ = segment_frames(a, b - a)  # the frames of the runs
    u = (idx - (a - 1)[run_of]) / (b - (a - 1))[run_of]
    track[idx] = R.slerp(lo[run_of], hi[run_of], u)
    out = np.zeros(F, dtype=bool)
    out[idx] = True
    return out


def repair(
    motion: Motion,
    detection: Detection,
    context=None,
    *,
    contacts=None,
    foot_skate: bool = True,
    blend_s: float = 0.25,
    guard: bool = True,
) -> Motion:
    """:func:`repair_with_left`'s repaired take, without the runs it left."""
    return repair_with_left(motion, detection, context, contacts=contacts, foot_skate=foot_skate, blend_s=blend_s,
                            guard=guard)[0]


def repair_with_left(
    motion: Motion,
    detection: Detection,
    context=None,
    *,
    contacts=None,
    foot_skate: bool = True,
    blend_s: float = 0.25,
    guard: bool = True,
) -> tuple[Motion, tuple[LeftRun, ...]]:
    """``(repaired, left)``: replace the flagged joints in flagged frames by the median of their KNN words (section 4).

    For each flagged cell the source word around the frame gives K neighbour
    words (in the group that explained the joint best); the medoid of those
    within twice the nearest one's DTW distance, as for the mean texture
    (the others are the next best of a context that repeats the motion
    fewer than K times, and a medoid of them picks a wrong motion), and
    never of a word of the take itself that spans a flagged cell of the
    joints repaired (it would copy the error back), on the word's flagged
    joints replaces the values (a flagged run no
    neighbour word covers is bridged by slerp between its ends, unflagged
    or already replaced, as a gap would be), which are blended into the
    untouched motion with a quadratic Savitzky-Golay filter (``blend_s``
    seconds). The flagged cells of a transient offset
    (:attr:`Detection.offsets`, not a side swap's) are not replaced: the
    offset measured at its two steps is taken away
    (:func:`~mocapkit.cleaning.ssa.undo.undone_offsets`), and the other
    runs blend into the track so mended. Likewise the cells of a side swap (not a time-reversed stretch)
    that the mirrored exchange joins to the take are exchanged back, each joint taking its partner's mirrored
    rotation (:func:`~mocapkit.cleaning.ssa.swap_exchange.swap_exchanges`), not replaced; so are a swap
    flagged on one side only, over the frames where the exchange joins the take, the partner's cells and the
    swap's frames the flags missed included, and with ``guard`` a pair whose exchange fits the take better
    but not at every end is left as it came, both sides named in ``left``
    (:func:`~mocapkit.cleaning.ssa.swap_exchange.partner_swaps`). Every unflagged value is bit-identical to the
    input, except such an exchange's and, with
    ``foot_skate``, the hip and knee of a leg whose joints were replaced (not
    exchanged back as a swap) in a frame where its foot is planted (foot-skate cleanup, see
    :func:`mocapkit.cleaning.ik.foot_skate_cleanup`). ``contacts`` (list of
    :class:`mocapkit.cleaning.ik.Contact`) picks, instead of the medoid, the
    neighbour word whose end effector comes closest to the contact point, and
    finishes with inverse kinematics. ``context`` must be the one the
    detection was made with; None takes the detection's own when it holds
    its prepared take (:attr:`Detection.analysis`, made by :func:`detect` on
    this motion), which is then reused as is: the take and its context are
    not resampled again. A detection of part of the take (:attr:`Detection.span`, the calibration poses left
    out by :func:`mocapkit.cleaning.whole_take.detect_take`) repairs that part only, as the detection of it
    alone would (``contacts`` count from the take's first frame): every frame outside it stays bit-identical,
    whatever ``foot_skate`` or ``contacts`` say.

    With ``guard`` (the default), each run of one joint's changed cells is checked against the take itself
    before contacts and foot skate (:mod:`~mocapkit.cleaning.ssa.guard`): a run that joins the take less
    smoothly than the input did, a bridge turning far faster than the joint does anywhere else, a run that
    moves no cell by half a degree (:mod:`~mocapkit.cleaning.ssa.negligible`), one that turns its joint half a
    turn and puts the limb below it further than the input did from the path its joins imply, with the runs below
    it inside its frames (:mod:`~mocapkit.cleaning.ssa.limb_paths`), or one within the confirmation's margin
    beside a swap exchanged back or an offset taken away, is given back its input values bit for bit; so is a
    run's end frame that lies on the joint's own path (its break its neighbour's), the run repaired without it;
    and where one side of a left/right pair is given back while its partner digresses over the same frames, the
    pair is exchanged back as a swap where that joins the take, else the partner's run over those frames is given
    back too (:func:`_guard`); ``left`` names each such run (:class:`~mocapkit.cleaning.ssa.guard.LeftRun`, frames
    of ``motion``). Without it every flagged cell is repaired as above and ``left`` is empty.
    """
    if not isinstance(detection, Detection):
        raise TypeError(f"detection must be a Detection, got {type(detection).__name__}")
    if detection.num_frames != motion.num_frames or tuple(motion.skeleton.joint_names) != detection.joint_names:
        raise ValueError(
            f"{motion.name or 'motion'}: the detection was made on another clip "
            f"({plural(detection.num_frames, 'frame')}, {plural(len(detection.joint_names), 'joint')} vs "
            f"{plural(motion.num_frames, 'frame')}, {plural(motion.num_joints, 'joint')})"
        )
    if detection.span is not None:
        return _repair_span(motion, detection, context, contacts=contacts, foot_skate=foot_skate, blend_s=blend_s,
                            guard=guard)
    if detection.once:
        return _repair_repeats(motion, detection, context, contacts=contacts, foot_skate=foot_skate, blend_s=blend_s,
                               guard=guard)
    flags = np.asarray(detection.flags, dtype=bool) & detection.analysed[None, :]
    if not flags.any():
        return motion, ()
    p = detection.params
    fps_a, N = float(p.analysis_fps), int(p.source_length)
    an = _analysis(motion, detection, context)
    src, full, up = an.source, an.texture, an.up
    if an.clips != detection.context_clips:
        raise ValueError(
            f"{motion.name or 'motion'}: repair needs the context the detection was made with "
            f"({len(detection.context_clips) - 1} context clips, got {len(an.clips) - 1})"
        )
    tex_joints = detection.texture_joints
    col = {int(j): i for i, j in enumerate(tex_joints)}
    words = detection.word_starts
    F = motion.num_frames
    tau = np.arange(F) * (fps_a / motion.fps)  # analysis time of each input frame
    word_of = frame_words(words, N, F, fps_a, motion.fps)  # the source word around each input frame
    groups = [np.flatnonzero(detection.group_masks[g]) for g in range(len(detection.group_names))]
    new = np.array(motion.rotations)
    placed = np.zeros(flags.shape, dtype=bool)  # the flagged cells a neighbour word was written into
    own_next = np.zeros(flags.shape, dtype=bool)  # those written from the take's own next (or last) word alone
    heading = R.quaternion_twist(motion.rotations[:, 0], up)
    # a transient offset's own motion is kept: its offset is taken away, not replaced by a neighbour word (a side
    # swap's joint took its partner's pose, no offset of its own: it is exchanged back below)
    base = np.array(motion.rotations)
    undone = np.zeros(flags.shape, dtype=bool)
    offsets = flags & np.asarray(detection.offsets, dtype=bool) & ~np.asarray(detection.swaps, dtype=bool)
    for j in np.flatnonzero(offsets.any(axis=0)):
        base[:, j], undone[:, j] = undone_offsets(motion.rotations[:, j], offsets[:, j])
    offset_undone = undone.copy()
    # a swap detection confirmed by the mirrored exchange is put back by that exchange (swap_exchange.py)
    swapped = flags & np.asarray(detection.swaps, dtype=bool) & ~undone
    if detection.reversals is not None:
        swapped &= ~np.asarray(detection.reversals, dtype=bool)
    if swapped.any():
        values, exchanged = swap_exchanges(motion.rotations, mirrored_rotations(motion), swapped,
                                           mirror_pairs(motion.skeleton.joint_names),
                                           parents=motion.skeleton.parents)
        base[exchanged] = values[exchanged]
        undone |= exchanged
    # a swap flagged on one side only: its partner's mirrored values fit the frames beside the run (swap_exchange.py)
    flags, kept_pairs = _partner_swaps(motion, flags, undone, base, detection.reversals, guard)
    # a run's end frame that lies on the joint's own path is no error's: its break is the next frame's (guard.py)
    on_path = np.zeros(flags.shape, dtype=bool)
    if guard:
        for j in np.flatnonzero((flags & ~undone).any(axis=0)):
            on_path[:, j] = on_path_ends(motion.rotations[:, j], flags[:, j] & ~undone[:, j])
    todo = flags & ~on_path & ~kept_pairs
    flagged_frames_by_word: dict[tuple[int, int], list] = {}
    fi, ji = np.nonzero(todo & ~undone)
    for f, j in zip(fi, ji):
        g = int(detection.best_group[f, j])
        if g < 0:
            continue
        flagged_frames_by_word.setdefault((g, int(word_of[f])), []).append((f, j))
    M = int(p.target_length)
    # the take's own flagged cells at the analysis rate (+-1 frame): a neighbour word from the take that
    # spans one of them on a joint to repair would copy the error back (the rest of a long error, a
    # repeated glitch)
    n_self = int(full.clip_starts[1])
    flagged_a = np.zeros((n_self + 1, flags.shape[1]), dtype=bool)
    np.logical_or.at(flagged_a, np.clip(np.round(tau).astype(np.int64), 0, n_self), flags)
    flagged_a[1:] |= flagged_a[:-1].copy()
    flagged_a[:-1] |= flagged_a[1:].copy()
    # each flagged word's candidates: its neighbours (k, DTW distance, position) in k order, less those of the take
    # that span a flagged cell of the joints to repair
    candidates: dict[tuple[int, int], list[tuple[int, float, int]]] = {}
    for (g, w), cells in flagged_frames_by_word.items():
        here = np.unique([j for _, j in cells])
        pos, dist = detection.neighbor_pos[g, w], detection.neighbor_dist[g, w]
        candidates[(g, w)] = [(k, float(dist[k]), int(q)) for k, q in enumerate(pos)
                              if q >= 0 and not (q < n_self and flagged_a[q : q + M, here].any())]
    warped = _medoid_words(an, src, full, groups, words, candidates, N, M)
    for (g, w), cells in flagged_frames_by_word.items():
        members = groups[g]
        fs = np.array([f for f, _ in cells], dtype=np.int64)
        js = np.array([j for _, j in cells], dtype=np.int64)
        found = [(warped[g, w, k], d, q) for k, d, q in candidates[(g, w)] if warped.get((g, w, k)) is not None]
        if not found:
            continue
        nearest = min(d for _, d, _ in found)
        near = [(nw, q) for nw, d, q in found if near_neighbors(d, nearest)]
        words_k = [nw for nw, _ in near]
        cs = np.searchsorted(members, [col[int(j)] for j in js])  # the cells' rows within the word
        flagged_cols = np.unique(cs)
        x = np.clip(tau[fs] - words[w], 0.0, N - 1.0)
        i0 = np.floor(x).astype(np.int64)
        i1 = np.minimum(i0 + 1, N - 1)
        a = (x - i0)[:, None]
        root = js == 0

        def place(word, target, fs=fs, js=js, cs=cs, i0=i0, i1=i1, a=a, root=root):
            """Write ``word`` (N, m_g, 4) into ``target`` at the flagged cells, interpolated to their frames."""
            q0 = word[i0, cs]
            q1 = align_hemisphere(word[i1, cs], q0)
            q = R.quaternion_normalize(q0 * (1 - a) + q1 * a)
            if root.any():
                q[root] = R.quaternion_multiply(heading[fs[root]], q[root])
            target[fs, js] = align_hemisphere(q, motion.rotations[fs, js])

        choice = None
        if contacts:
            choice = _closest_to_contacts(motion, words_k, place, cells, contacts)
        if choice is None:
            choice = _medoid(words_k, flagged_cols)
        place(words_k[choice], new)
        placed[fs, js] = True
        own_next[fs, js] = all(q < n_self and abs(q - int(words[w])) <= N for _, q in near)  # (guard.open_end_runs)
    # a flagged run no neighbour word was written into is bridged like a gap: slerp between its ends,
    # unflagged or already replaced (blending its own values towards the ends would bend a 180-degree
    # flip, not undo it)
    new[undone] = base[undone]
    bridged = np.zeros(flags.shape, dtype=bool)
    for j in np.flatnonzero((todo & ~placed & ~undone).any(axis=0)):
        bridged[:, j] = _bridge(new[:, j], todo[:, j] & ~placed[:, j] & ~undone[:, j])
        placed[bridged[:, j], j] = True
    window = window_frames(blend_s, motion.fps, 2)
    out_rot = base
    for j in np.flatnonzero(placed.any(axis=0)):
        out_rot[:, j] = _blend_runs(base[:, j], new[:, j], placed[:, j], window)
    left: list[LeftRun] = []
    if guard:  # a run the take shows to be no better than its input is given back as it was (guard.py)
        left = _guard(motion, out_rot, flags, placed & ~undone, undone, bridged, on_path, own_next & ~undone,
                      int(round(p.confirm_margin_s * motion.fps)))
    left = _pair_lines(motion, kept_pairs) + left
    out = dataclasses.replace(motion, rotations=out_rot)
    if contacts:
        from .. import ik

        for c in contacts:
            frames = np.arange(max(c.start, 0), min(c.end, F))
            if len(frames):
                out = ik.two_bone_ik(out, c.joint, c.target(), frames=frames)
    if foot_skate:  # a swap exchanged back holds the capture's own values, its feet where they were captured
        out = _foot_skate(motion, out, flags & ~(undone & ~offset_undone))
    return out, tuple(left)


def _partner_swaps(motion: Motion, flags: np.ndarray, undone: np.ndarray, base: np.ndarray,
                   reversals, guard: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """``(flags, kept)``: the swaps of a left/right pair flagged on one side only
    (:func:`~mocapkit.cleaning.ssa.swap_exchange.partner_swaps`) put back. A confirmed one is exchanged back
    into ``base`` (F, J, 4) and ``undone`` (F, J) (both changed in place), its cells on both joints flagged
    (``flags`` returned with them: the frames the one side's flags missed, the partner's); an unconfirmed one's
    cells on both joints are ``kept`` (F, J) bool: left as they came, neither side repaired from neighbour words,
    which would leave one limb holding the other's motion (:func:`_pair_lines` names them); without ``guard``
    none is kept, as every flagged cell is then repaired."""
    kept = np.zeros(flags.shape, dtype=bool)
    todo = flags & ~undone
    if reversals is not None:
        todo &= ~np.asarray(reversals, dtype=bool)
    partner = mirror_pairs(motion.skeleton.joint_names)
    if not any(todo[:, j].any() and partner[j] != j for j in range(len(partner))):
        return flags, kept
    mirrored = mirrored_rotations(motion)
    found = partner_swaps(base, mirrored, todo, partner, motion.skeleton.parents, motion.fps, fixed=undone)
    flags = np.array(flags)
    for sw in found:
        cols, rows = [sw.joint, sw.partner], slice(sw.start, sw.end + 1)
        if sw.confirmed:
            base[rows, cols] = mirrored[rows, cols]
            undone[rows, cols] = True
            flags[rows, cols] = True
        elif guard:
            kept[rows, cols] = flags[rows, cols]
            kept[sw.flagged[0] : sw.flagged[1] + 1, sw.joint] = True
    return flags, kept


def _pair_lines(motion: Motion, kept: np.ndarray) -> list[LeftRun]:
    """The runs of ``kept`` (F, J) bool (:func:`_partner_swaps`), each named: left, a swap not confirmed."""
    names = motion.skeleton.joint_names
    partner = mirror_pairs(names)
    return [LeftRun(names[j], int(a), int(b), f"its left/right partner {names[partner[j]]} digresses over these "
                    "frames in the mirrored way (the two exchanged fit the frames beside them better, but not at "
                    "every end: a swap not confirmed); a pair is put back together or not at all")
            for j in np.flatnonzero(kept.any(axis=0)) for a, b in contact_segments(kept[:, j])]


def _guard(motion: Motion, out_rot: np.ndarray, flags: np.ndarray, replaced: np.ndarray, undone: np.ndarray,
           bridged: np.ndarray, on_path: np.ndarray, own_next: np.ndarray, margin: int = 0) -> list[LeftRun]:
    """The repair guard (:mod:`~mocapkit.cleaning.ssa.guard`) on ``out_rot`` (F, J, 4), the repaired rotations,
    changed in place: each run it fails given back its input values; the runs left, in order.

    ``flags`` (F, J): the flagged cells; ``replaced``: those written from neighbour words or bridged; ``undone``:
    those put back by the take's own motion (an offset taken away, a swap exchanged back); ``bridged``: the
    bridged ones; ``on_path``: the flagged frames at the runs' ends left on the joint's own path
    (:func:`~mocapkit.cleaning.ssa.guard.on_path_ends`); ``own_next``: the replaced cells whose neighbour
    words were all the take's own motion less than a word from their source word, whose runs at the take's
    first or last frame are given back (:func:`~mocapkit.cleaning.ssa.guard.open_end_runs`), and with the bridged ones
    make the guesses whose held runs are judged by the path their joins imply
    (:func:`~mocapkit.cleaning.ssa.guard.held_guess_runs`). A run replaced throughout within ``margin`` frames (the
    confirmation's, at the take's rate) beside a run put back by the take's own motion is given back
    (:func:`~mocapkit.cleaning.ssa.guard.margin_runs`). A run that turns its joint half a turn is judged by the
    positions of the joints below it (:func:`~mocapkit.cleaning.ssa.limb_paths.limb_runs`), and where it fails, the
    runs below it within its frames replaced throughout are left too
    (:func:`~mocapkit.cleaning.ssa.limb_paths.limb_left`); where its partner digresses over the same frames,
    the pair is exchanged back if that puts both limbs nearer their joined paths
    (:func:`~mocapkit.cleaning.ssa.limb_paths.exchange_nearer`), whatever the rotation joins say. A run of one
    side of a left/right pair that fails while its partner digresses over the same frames is put back as a swap
    where the mirrored exchange joins the take (:func:`~mocapkit.cleaning.ssa.swap_exchange.pair_exchange`), else
    its partner's runs over those frames that hold a replaced cell are left too
    (:func:`~mocapkit.cleaning.ssa.guard.pair_left`).
    """
    orig = motion.rotations
    names = motion.skeleton.joint_names
    left = [LeftRun(names[j], int(f), int(f) + 1, "on the joint's own path: the break there is the next frame's")
            for j, f in zip(*np.nonzero(on_path.T))]
    changed = np.any(out_rot != orig, axis=-1)
    runs: dict[tuple[int, int, int], str] = {}  # (joint, start, end) -> why, the runs given back
    failed = []
    turned = np.degrees(R.geodesic_angle(orig, out_rot)) >= HALF_TURN_DEG  # (F, J): judged by the limb (limb_paths.py)
    pos_in = pos_out = None
    limb_failed: list[tuple[int, int, int]] = []
    for j in np.flatnonzero((replaced | undone).any(axis=0)):
        limb = []
        if turned[:, j].any():
            if pos_in is None:
                pos_in = motion.global_transforms()
                pos_out = dataclasses.replace(motion, rotations=out_rot).global_transforms()
            limb = limb_runs(orig[:, j], out_rot[:, j], changed[:, j], limb_positions(motion, *pos_in, int(j)),
                             limb_positions(motion, *pos_out, int(j)))
        tiny = negligible_runs(orig[:, j], out_rot[:, j], changed[:, j])  # (negligible.py)
        worse = guard_joint(orig[:, j], out_rot[:, j], changed[:, j], bridged[:, j], flags[:, j])
        # then, each run once with the first rule's reason: a run at the take's edge (no join there to judge it by),
        # a freeze's guess (judged by the path its joins imply), a half turn (by the limb's path), a run past an
        # error the take's own motion bounds
        for more in (open_end_runs(changed[:, j], own_next[:, j]),
                     held_guess_runs(orig[:, j], out_rot[:, j], changed[:, j], bridged[:, j] | own_next[:, j]), limb,
                     margin_runs(changed[:, j], replaced[:, j], undone[:, j], margin)):
            worse += [r for r in more if r[:2] not in {w[:2] for w in worse}]
        limb_failed += [(int(j), int(s), int(e)) for s, e, _ in limb]
        worse = [r for r in worse if r[:2] not in {t[:2] for t in tiny}]
        failed += [(int(j), int(s), int(e)) for s, e, _ in worse]
        for s, e, why in tiny + worse:
            runs[int(j), int(s), int(e)] = why
            out_rot[s:e, j] = orig[s:e, j]
    for k, s, e, why in limb_left(changed, limb_failed, motion.skeleton.parents, replaced):  # (limb_paths.py)
        if (k, s, e) not in runs:
            runs[k, s, e] = why
            out_rot[s:e, k] = orig[s:e, k]
    partner = mirror_pairs(names)
    mirrored = None
    unresolved = []
    for j, s, e in failed:  # a pair that digresses over the same frames: put back as a swap where that joins
        p = int(partner[j])
        if p == j or not flags[s:e, p].any():
            continue
        if mirrored is None:
            mirrored = mirrored_rotations(motion)
        got = pair_exchange(orig, mirrored, flags, j, s, e, partner)
        by_limb = got is None and (j, s, e) in limb_failed and exchange_nearer(motion, mirrored, (j, p), s, e)
        if by_limb:  # a half turn left by its limb's positions: the exchange judged by them too (limb_paths.py)
            got = s, e - 1
        if got is None:
            unresolved.append((j, s, e))
            continue
        a, b = got
        trial = np.array(out_rot[:, [j, p]])
        trial[a : b + 1] = mirrored[a : b + 1, [j, p]]
        ok = True
        for i, k in enumerate((j, p) if not by_limb else ()):
            moved = np.any(trial[:, i] != orig[:, k], axis=-1)
            ran = [r for r in contact_segments(moved) if r[0] <= a and r[1] > b]
            bad = guard_joint(orig[:, k], trial[:, i], moved, np.zeros(len(moved), dtype=bool), flags[:, k])
            ok &= not any(r[:2] in {x[:2] for x in bad} for r in ran)
        if not ok:
            unresolved.append((j, s, e))
            continue
        out_rot[:, [j, p]] = trial
        for k in (j, p):  # the runs given back within the exchange are repaired now: what is left of them stays
            for key in [key for key in runs if key[0] == k and key[1] <= b and key[2] > a]:
                why = runs.pop(key)
                for lo, hi in ((key[1], a), (b + 1, key[2])):
                    if hi > lo:
                        runs[k, lo, hi] = why
    changed = np.any(out_rot != orig, axis=-1)
    for k, s, e in runs:
        changed[s:e, k] = True  # the runs given back were changed: pair_left reads the runs as the repair made them
    for j, s, e, why in pair_left(changed, unresolved, partner, replaced):
        if (j, s, e) not in runs:
            runs[j, s, e] = why
            out_rot[s:e, j] = orig[s:e, j]
    left += [LeftRun(names[j], s, e, why) for (j, s, e), why in runs.items()]
    return left


def _medoid_words(an: Analysis, src, full, groups, words, candidates: dict, N: int, M: int) -> dict:
    """``(group, word, k) -> word`` (N, m_g, 4), or None where it has no admissible path or does not fit its clip:
    the warped neighbour words (:func:`~mocapkit.cleaning.ssa.neighbours.neighbor_words`) among ``candidates``
    (``(group, word) -> [(k, distance, position), ...]``) that the repair may take.

    A word's medoid is taken of the candidates that warp within :func:`near_neighbors` of the nearest one that
    does; the others are never warped. A candidate is fetched once it lies within that reach of the nearest
    candidate not yet known to fail; a candidate that fails raises the reach, and the next round fetches what it
    adds, until nothing new is in reach: the nearest candidate that warps is then known, and every candidate
    within its reach. The words the detection kept (:attr:`Analysis.warped`) are read, the rest warped in one
    batch per group and round; each word is its pair's alone, in any batch.
    """
    got: dict = {}
    while True:
        todo: dict[int, list[tuple[int, int, int]]] = {}
        for (g, w), cands in candidates.items():
            live = [d for k, d, _ in cands if got.get((g, w, k), True) is not None]  # not yet known to fail
            if not live:
                continue
            nearest = min(live)
            for k, d, q in cands:
                if (g, w, k) not in got and near_neighbors(d, nearest):
                    todo.setdefault(g, []).append((w, k, q))
        if not todo:
            return got
        for g, items in sorted(todo.items()):
            members = groups[g]
            kept = an.warped.get(np.asarray(members, dtype=np.int64).tobytes())
            row = {} if kept is None else {(int(s), int(q)): i for i, (s, q) in enumerate(zip(kept[0], kept[1]))}
            miss = []
            for w, k, q in items:
                i = row.get((int(words[w]), q))
                if i is None:
                    miss.append((w, k, q))
                else:
                    got[g, w, k] = kept[2][i] if kept[3][i] else None
            if miss:
                ws = np.array([w for w, _, _ in miss], dtype=np.int64)
                qs = np.array([q for _, _, q in miss], dtype=np.int64)
                nws, ok = neighbor_words(src.values, full, members, dropped_terms(members), words[ws], qs, N, M)
                for i, (w, k, _) in enumerate(miss):
                    got[g, w, k] = nws[i] if ok[i] else None


def _repair_span(motion: Motion, detection: Detection, context, **options) -> tuple[Motion, tuple[LeftRun, ...]]:
    """:func:`repair_with_left` of the frames ``detection.span`` analysed, put back into ``motion`` (the rest
    untouched), its left runs in the take's frames."""
    lo, hi = detection.span
    if not np.asarray(detection.flags, dtype=bool).any():
        return motion, ()
    contacts = options.pop("contacts")
    if contacts:  # frames of the part, which starts at lo
        contacts = [dataclasses.replace(c, start=c.start - lo, end=c.end - lo) for c in contacts]
    part, left = repair_with_left(motion[lo:hi], detection.analysed_part(), context, contacts=contacts, **options)
    left = tuple(dataclasses.replace(r, start=r.start + lo, end=r.end + lo) for r in left)
    rot, pos = np.array(motion.rotations), np.array(motion.root_positions)
    rot[lo:hi], pos[lo:hi] = part.rotations, part.root_positions
    tr = None
    if motion.translations is not None:
        tr = np.array(motion.translations)
        tr[lo:hi] = part.translations
    return dataclasses.replace(motion, rotations=rot, root_positions=pos, translations=tr), left


def _closest_to_contacts(motion, words_k, place, cells, contacts) -> int | None:
    """The neighbour word whose end effectors come closest to the contact points (section 4), or None."""
    frames = np.array(sorted({f for f, _ in cells}))
    relevant = [c for c in contacts if np.any((frames >= c.start) & (frames < c.end))]
    if not relevant:
        return None
    costs = []
    for word in words_k:
        trial = np.array(motion.rotations)
        place(word, trial)
        pos = dataclasses.replace(motion, rotations=trial).global_positions()
        cost = 0.0
        for c in relevant:
            fr = frames[(frames >= c.start) & (frames < c.end)]
            cost += float(np.sum(np.linalg.norm(pos[fr, motion.skeleton.index(c.joint)] - c.target(), axis=-1)))
        costs.append(cost)
    return int(np.argmin(costs))


def _foot_skate(original: Motion, repaired: Motion, flags: np.ndarray) -> Motion:
    """Foot-skate cleanup on frames where a leg joint was replaced (Lyard & Magnenat-Thalmann 2007)."""
    from .. import ik

    sk = original.skeleton
    leg_frames = np.zeros(original.num_frames, dtype=bool)
    for role in ("left_foot", "right_foot"):
        try:
            foot = find_joint(sk, role)
        except KeyError:
            continue
        chain = [foot]
        while sk.parents[chain[-1]] > 0:
            chain.append(int(sk.parents[chain[-1]]))
        leg_frames |= flags[:, chain].any(axis=1)
    if not leg_frames.any():
        return repaired
    try:
        contacts = ik.foot_contacts(original)
    except (KeyError, ValueError, SkeletonError):
        return repaired
    return ik.foot_skate_cleanup(repaired, frames=leg_frames, contacts=contacts)



def _repair_repeats(motion: Motion, detection: Detection, context, **options) -> tuple[Motion, tuple[LeftRun, ...]]:
    """:func:`repair_with_left` of the take without the frames that repeat the one before and the interpolated
    frames (:attr:`Detection.once`), as :func:`~mocapkit.cleaning.ssa.detect` analysed it; each repeat then
    written as the frame it repeats (so an unflagged repeat stays bit-identical, and a repeat stays a repeat), each
    interpolated frame as the blend of the mended frames around it where they changed and bit for bit elsewhere
    (:func:`~mocapkit.cleaning.ssa.repeats.blend_inbetweens`); ``contacts`` and the left runs count the take's
    frames."""
    if not np.asarray(detection.flags, dtype=bool).any():
        return motion, ()
    runs, F = detection.once, motion.num_frames
    repeats = repeat_runs(motion)
    if repeats != tuple(detection.repeats) or any(b >= F for _, b in detection.inbetweens):
        raise ValueError(f"{motion.name or 'motion'}: the detection was made on another clip (its repeated or "
                         "interpolated frames differ)")
    index = frame_index(runs, F)
    contacts = options.pop("contacts")
    if contacts:
        contacts = [dataclasses.replace(c, start=int(index[c.start]), end=int(index[c.end - 1]) + 1) for c in contacts]
    once, left = repair_with_left(without_repeats(motion, runs), detection.unrepeated(), context, contacts=contacts,
                                  **options)
    kept = np.flatnonzero(kept_frames(runs, F))  # the take's frame of each frame analysed
    left = tuple(dataclasses.replace(r, start=int(kept[r.start]), end=int(kept[r.end]) if r.end < len(kept) else F)
                 for r in left)  # a run ending on a repeated frame keeps its repeats
    tr = None if motion.translations is None else expand(once.translations, runs, F)
    out = dataclasses.replace(motion, rotations=expand(once.rotations, runs, F),
                              root_positions=expand(once.root_positions, runs, F), translations=tr)
    return blend_inbetweens(motion, out, detection.inbetweens), left


def _analysis(motion: Motion, detection: Detection, context) -> Analysis:
    """The detection's prepared take when it is of ``motion`` and ``context`` (None: the detection's own),
    else ``motion`` and ``context`` prepared again with the detection's parameters and joints."""
    an = detection.analysis
    if an is not None and an.serves(motion) and (context is None or context is an.context_given):
        return an
    return prepare(motion, context, detection.params, joints=detection.texture_joints)
