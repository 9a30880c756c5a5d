"""Smooth drifts: does ``ssa.detect`` flag a joint that drifts 35 degrees away and back with no step?

Issue 24 item 6. Each scored take gets smooth there-and-back drifts
(:func:`mocapkit.corrupt.smooth_drifts`: a raised cosine on one rotation
channel, 35 deg at its middle, 1-2 s long, no frame-to-frame step) on limb and
spine joints found by role (thighs, shins, upper arms, forearms, spine, chest,
neck); ``detect`` runs on it against a context, and its flags are scored at the
(motion word, joint) level as ``benchmarks/ssa_detection.py`` scores them
(words of 15 frames every 5 at 24 fps; truth: cells the drift moved by at
least 5 deg; cells it moved by less are neither required nor wrong).

Sets (Bandai Namco Research Motiondataset 1 and 2, ``benchmarks/_bandai.py``):

* ``bandai``: held-out styles (dataset 1: feminine, giant, happy, masculinity,
  musical, not-confident, old, proud, sad, tired; dataset 2: elderly,
  exhausted, feminine, masculine), one take per (content, style), contents
  that repeat (walks, runs, dashes, waves, bows, raise-ups); the context is a
  database (``MotionDatabase.build``) of the same content's takes in the other
  styles (never the take's own style), up to ``--context-s`` seconds.
* ``calibration``: the same on the styles the drift rule's parameters were
  checked on (dataset 1: normal, active, angry, childish, chimpira; dataset 2:
  normal, active); with ``--split calibration`` only these are scored.
* ``hdm05``: the short HDM05 takes of the issue (one jog and one sneak of each
  of actors bd, bk, dg, mm, tr) against an 8-clip context of other actors'
  clips of the class, as ``ssa_detection.py``'s ``small`` context: a second
  figure, where a single repetition is all the context holds of each take.

* ``dance`` (issue 24 item 7): the Bandai dance with injected real errors,
  against the dance alone, the Bandai action takes and all of dataset 1
  (:func:`dance_big_context`), beside ``ssa_detection.py``'s ``dance_30fps``.

Contents are scored by group too (``details.results``): ``locomotion`` (walks,
runs, dashes), ``arms`` (waves, raise-ups) and ``gestures`` (bows, byes,
guides); ``--groups`` picks which are scored. The drift rule's parameters
(``SSAParams.drift_*``) were set on ``--split calibration``: ``drift_z`` 3 (against 2.5)
on its locomotion, ``drift_others``, ``drift_return_ratio`` and ``drift_partner_ratio``
over all groups (``drift_others`` 1 against 0 and 2, ``drift_return_ratio`` 0.3 against
0.2 and 0.5, ``drift_partner_ratio`` 0.5 against 0.33, 0.67 and None), then the evidence
(``drift_change``: the joint's change from the turn it holds over the take, alone, rather
than the smaller of it and the angle ratio), ``drift_chain_ratio`` 0.5 (against 0.4, 0.67
and None), ``drift_min_s`` 0.15 s (against 0.2 and 0.25) and ``drift_extent`` 0.75
(against 0.5 and 1) together over all groups, with ``drift_z`` 3 against 3.25 and 3.5
(F1 0.809 -> 0.841: recall 0.770 -> 0.821, precision 0.852 -> 0.861, clean-take drift
cells 0.257 % -> 0.212 %); all are scored here on the held-out styles
(``details.results`` also gives ``ssa_without_change``, the same analysis with the angle
ratio as the evidence).

Those values were set with the Bandai rig's joint groups wrong (``ssa.texture.joint_groups``: legs
traced from ``joint_Root``, so ``lower`` was the whole body and ``upper`` missing). With the groups
corrected (an ``upper`` group beside ``whole``, ``lower``, ``left`` and ``right``) the calibration
split fell from recall 0.822, precision 0.859 to 0.779, 0.816 (clean-take drift cells 0.212 % ->
0.361 %), and no value brought it back, on ``--split calibration`` only: ``drift_z`` 2.5-3.5,
``drift_repeat_deg`` 3-8, ``drift_chain_ratio`` 0.4-1 and None, ``drift_partner_ratio`` 0.33-1 and
None, ``drift_min_s`` 0.1-0.25, ``drift_extent`` 0.5-1.5, ``drift_others`` 0-3 and None,
``drift_return_ratio`` 0.2-0.5 one at a time, and ``drift_z`` (2.75-4) with ``drift_repeat_deg``,
``drift_chain_ratio`` or ``drift_partner_ratio`` in pairs, gave F1 0.785-0.808 against 0.797. Two of
the rule's statistics mixed the groups instead: the offset a joint holds over the take was the median
of whichever group judged each frame (now each group's own, ``drifts.group_offset_change``: F1 0.797
-> 0.813, clean-take drift cells 585 -> 454), and ``agreement`` read each other joint's own closest
words, not the words that judge the joint (now ``drifts.group_agreement``: F1 0.825, recall 0.780,
precision 0.875, clean-take drift cells 275, 0.170 %). The same sweep again then gave F1
0.742-0.827, no value more than 0.003 over the defaults without more clean-take drift cells, so the
values above stand.

Where the held-out styles' misses come from (read on half of them, the ``study`` half: dataset 1 feminine, giant,
happy, masculinity, musical and dataset 2 elderly, exhausted; the ``measure`` half, dataset 1 not-confident, old,
proud, sad, tired and dataset 2 feminine, masculine, only scored; both seeds): on locomotion, the drifts alone on
their chain and side are found at recall 0.9105 (2,302 truth words; 0.9139 and 0.9073 by half), those that overlap
a drift on their left/right partner, parent or child at 0.4507 (142; 0.3679 and 0.6944) with the partner and chain
gates alone, which take the second drift for a style (``recall_paired_drifts``). Of the single drifts missed whole, most have
the rest of the body over ``drift_repeat_deg`` from the words that judge the joint (the musical and feminine
styles) or a partner digressing with the style; on the study half 46 of the 162 locomotion words missed (28 %) are
the first or last words of drifts found, where the change is still under ``drift_extent``. No rule tried lifted
recall without costing the overall precision or the untouched takes (both halves together, against recall 0.8124,
precision 0.9040 and 587 clean-take drift cells): flagging each excursion on down to the change's nearest valley
(0.8326, 0.8940, 638 cells; locomotion 0.8838 -> 0.9043 at precision 0.9457 -> 0.9376); the held offset taken again
without the cells whose change is 4 or more, three times (0.8228, 0.8944, 625; hdm05 clean-take cells 47 -> 150),
or without the drifts a first pass flagged (0.8233, 0.8917, 600; keeping only what both passes flag: study half
0.7728, 0.8667, 424 against 0.7770, 0.8623, 445); the partner gate only where the partner's change turns the same
way, on the Bandai rig whose limbs' mirror leaves local rotations as they are (0.8306, 0.8822, 985); no partner
gate (0.8461, 0.8459, 1,349); ``drift_extent`` 0.6 (0.8197, 0.8890, 645). Rejecting every excursion the take's
first or last frame cuts, which raised precision on the study half (0.7770 -> 0.7650, 0.8623 -> 0.9051, 445 -> 249
cells), lost the measure half's drifts near the edges of short takes (0.8475 -> 0.8187, 0.9454 -> 0.9515, 142 cells
either way; gestures recall 0.7559 -> 0.6614): the study half's gain was three styles' excursions running on to a
take's end (a hand held to the end of a guide, an arm after a wave). Where the partner gate alone stops a cell
(study half), the partner's change over the joint's has quartiles 0.56, 0.86, 1.12 on the untouched takes and 0.41,
0.58, 0.90 on the drifted cells: the magnitude does not tell a two-sided style from a second drift. The
direction does (``SSAParams.drift_cross_cos``, :func:`~mocapkit.cleaning.ssa.drifts.crossed_turns`): on the study
half the cosine of a partner-stopped cell's change turn with its partner's has median 0.92 on the untouched takes
(a two-sided style turns both sides alike) against 0.02 on paired drifts (each turns about its own channel), but
cell by cell 30 % of the untouched takes' cells fall under 0.5. Judged per excursion (the two turns summed over
it, ``|cos| < 0.2``; 0.1-0.3 tried on the study half) and only where the neighbour that stops it is a drift candidate
there too (stopped the same way, or flagged), both halves together: recall 0.8124 -> 0.8259, precision 0.9040 ->
0.9039, clean-take drift cells 587 -> 587; locomotion 0.8838 -> 0.9014 at precision 0.9457 -> 0.9443, its paired
drifts 0.4507 -> 0.6901; the measure half alone, scored once, 0.8475 -> 0.8521, 0.9454 -> 0.9457, 142 -> 142 cells
(gestures' paired drifts 0.6143 -> 0.7429); hdm05 the same. Without the neighbour a drift candidate the study half's
precision falls 0.8623 -> 0.8505 (a drift on one side frees its partner's style).

Tried for two drifts turned about one axis: telling them from a style by time (a ``drift_recur_ratio``,
``local_pairs`` beside ``crossed_turns``): a style recurs at each repetition of the motion (every walk cycle, every
wave), a drift is one excursion. An excursion the partner or chain gate alone stops, its neighbour a drift
candidate there, was flagged where, for both joints, the change everywhere else in the take (outside the joint's
runs over ``drift_extent`` that meet the excursion) stays under 0.4 of its peak in the excursion. Read on
the calibration split alone, its two seeds (0-1) and, for more pairs, six more (2-7; on seeds 0-1 only 7 of the
excursions these gates stop, and crossed turns leave, are drifts): the joint's largest change elsewhere over its
peak has median 0.41 on the stopped drifts (21 on seeds 2-7) against 0.58 on the untouched takes' stopped
excursions (18) and 0.65 on the drifted takes' others (87). Recall 0.7968 -> 0.8020 at precision 0.8693 -> 0.8701
(seeds 0-1), 0.7817 -> 0.7863 at 0.8816 -> 0.8822 (seeds 2-7; paired drifts 0.6689 -> 0.7084, locomotion 0.8938 ->
0.9011), clean-take drift cells 308 -> 308; 0.35-0.5 the same, 0.3 less (seeds 2-7 0.7831), 0.6 costs gestures'
precision (seeds 0-1 0.6548 -> 0.6279). Freeing too an excursion whose neighbour is no drift candidate but
digresses elsewhere in the take, at the gate's level and on 5 frames or more, without the joint (the neighbour's
style beside a drift; the joint's change alone under 0.4 elsewhere) lifted seeds 0-1 to 0.8112 at 0.8708, but cost
seeds 2-7 the arms' precision 0.9812 -> 0.9587 (0.8822 -> 0.8792 overall); on any such frame, 308 -> 328 clean-take
cells. The held-out split, scored once (both halves, both seeds, the same detections with and without the rule):
recall 0.8259 -> 0.8298, precision 0.9039 -> 0.8942, clean-take drift cells 587 -> 689 (share 0.001288 ->
0.001512); locomotion 0.9014 -> 0.9038 at 0.9443 -> 0.9444 (its paired drifts 0.6901 -> 0.7324, its clean-take
cells 142 -> 142), arms unchanged (paired 0.48), gestures 0.6991 -> 0.7080 at 0.7805 -> 0.7500 with all the new
clean-take cells (392 -> 494); hdm05 and the dance unchanged. A gesture made once (a bow, a guide) leaves the rest
of its take idle: under 0.4 "everywhere else in the take" says nothing of the take's other repetitions of the
motion, which it has none of, and a two-sided style shown once passes; the calibration styles' gestures happened
not to show it. So the rule is not in ``detect``. What it lacks is the
take's other words of the same motion (the take's own words among a word's neighbours, or the other joints'
self-similarity), to compare the pair with where the take repeats the motion and to judge nothing where it does
not; two drifts turned about one axis are still taken for a style.

Figures: recall and precision of ``detect``'s flags (all of them: what a user
gets) per set; the baseline, in the same run from the same analysis, is the
flags without the smooth-drift rule (``params.drift=False``'s flags). Also:
the cells the drift rule flags on the untouched takes (each take is detected
clean too: every such cell is harm), and the drift rule's statistic on the
drifted cells (``agreement``, ``consistency``), and which gate of the rule stops which cells
(:func:`gate_blockers`: ``gate_blockers_drifted`` on the drifted cells, ``gate_blockers_untouched`` on the
untouched takes' judged cells; a gate that stops many of the first and few of the second is worth a look).
``details.results`` also gives, per set and group, the recall of the drifts that overlap in time another drift on
their left/right partner, parent or child (``recall_paired_drifts``, :func:`paired_drifts`: the partner and chain
gates take that neighbour's digression for a style's) apart from the others' (``recall_single_drifts``).

    python benchmarks/drift_detection.py --json
    python benchmarks/drift_detection.py --quick --json     # a few takes per set
"""

from __future__ import annotations

import dataclasses
import sys
import time
import zlib
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO / "benchmarks"))

import _harness as harness  # noqa: E402
from _bandai import bandai_takes  # noqa: E402

import mocapkit  # noqa: E402
from mocapkit import corrupt, rigs  # noqa: E402
from mocapkit import rotations as R  # noqa: E402
from mocapkit.cleaning import ssa  # noqa: E402
from mocapkit.cleaning.ssa.cues import flag_rule  # noqa: E402
from mocapkit.database import MotionDatabase  # noqa: E402
from mocapkit.metrics import DetectionScore, word_precision_recall  # noqa: E402

DATA = REPO.parent / "shared" / "data"
if not DATA.is_dir():
    DATA = Path("/work/shared/data")
TARGET = (0.90, 0.90)
ROLES = ("left_thigh", "right_thigh", "left_shin", "right_shin", "left_upper_arm", "right_upper_arm",
         "left_forearm", "right_forearm", "spine", "spine_mid", "chest", "neck")
HELD_OUT = {1: ("feminine", "giant", "happy", "masculinity", "musical", "not-confident", "old", "proud", "sad", "tired"),
            2: ("elderly", "exhausted", "feminine", "masculine")}
CALIBRATION = {1: ("normal", "active", "angry", "childish", "chimpira"), 2: ("normal", "active")}
CONTENTS = {1: ("walk", "run", "dash", "walk-back", "walk-left", "walk-right", "bow", "byebye", "guide"),
            2: ("walk", "run", "walk-turn-left", "wave-both-hands", "wave-right-hand", "raise-up-both-hands")}


def content_group(name: str) -> str:
    """locomotion (walks, runs, dashes), arms (waves, raise-ups) or gestures (bows, byes, guides)."""
    if any(w in name for w in ("wave", "raise-up")):
        return "arms"
    if any(w in name for w in ("bow", "bye", "guide")):
        return "gestures"
    return "locomotion"


def word_frames(fps):
    return int(round(15 * fps / 24)), int(round(5 * fps / 24))


def score(flags, truth, fps, ignore):
    n, s = word_frames(fps)
    return word_precision_recall(flags, truth, word_length=n, stride=s, per_joint=True, ignore=ignore)


def add(a, b):
    return b if a is None else DetectionScore(a.tp + b.tp, a.fp + b.fp, a.fn + b.fn)


def row(sc):
    return {"recall": round(sc.recall, 4), "precision": round(sc.precision, 4), "tp": sc.tp, "fp": sc.fp, "fn": sc.fn}


def drift_joints(motion):
    r = rigs.roles(motion.skeleton)
    return [motion.skeleton.joint_names[r[x]] for x in ROLES if x in r]


def bandai_cases(split: str, per: int, context_s: float, quick: bool):
    """(name, path, the other styles' takes of the content, context seconds) for the held-out (or calibration) styles."""
    styles = HELD_OUT if split == "bandai" else CALIBRATION
    takes = bandai_takes()
    out = []
    for d in (1, 2):
        for content in CONTENTS[d][: 2 if quick else None]:
            pool = [t for t in takes if t.dataset == d and t.content == content]
            for style in styles[d][: 2 if quick else None]:
                mine = [t for t in pool if t.style == style][:per]
                others = [t for t in pool if t.style != style]  # never the take's own style
                for t in mine:
                    out.append((t.path.name, t.path, others, context_s))
    return out


def load_context(paths, context_s):
    """The other styles' takes of the content, in a fixed interleaved order, up to ``context_s`` seconds."""
    by_style: dict = {}
    for t in paths:
        by_style.setdefault(t.style, []).append(t)
    order = []
    for i in range(max((len(v) for v in by_style.values()), default=0)):
        order += [v[i] for _, v in sorted(by_style.items()) if i < len(v)]
    ctx, total = [], 0.0
    for t in order:
        m = mocapkit.load(t.path)
        ctx.append(m)
        total += m.duration
        if total >= context_s:
            break
    return ctx


def hdm_cases(quick: bool):
    hdm = sorted((DATA / "hdm05_asfamc").glob("HDM_*.amc"))
    out = []
    for cls in ("jog", "sneak"):
        for actor in ("bd", "bk", "dg", "mm", "tr")[: 2 if quick else None]:
            mine = [p for p in hdm if p.name.startswith(f"HDM_{actor}_{cls}")]
            if not mine:
                continue
            others = [p for p in hdm if f"_{cls}" in p.name and not p.name.startswith(f"HDM_{actor}_")][:8]
            out.append((mine[0].name, mine[0], others))
    return out


GATES = ("z", "agreement", "others", "partner", "chain")


def gate_blockers(det, cells) -> dict:
    """Of ``cells`` (F, J) bool, how many pass every cell-level gate of the drift rule (``pass``), and how many
    fail one gate alone (that gate's name): the cells each gate alone keeps from being evidence.

    The gates are :func:`~mocapkit.cleaning.ssa.drifts.smooth_drift_flags`' on the detection's own evidence
    (``change`` where ``params.drift_change``, else ``consistency``) and drift parameters: ``z`` (the evidence at
    ``drift_z``), ``agreement`` (the other joints within ``drift_repeat_deg``), ``others`` (at most ``drift_others``
    other joints at ``drift_z``), ``partner`` and ``chain`` (the left/right partner, parent and children under
    their ratio of ``drift_z``); a gate the parameters turn off passes every cell. Counted on the drifted cells it
    says what keeps drifts from being flagged; on an untouched take's cells, what keeps its style from being
    flagged: a gate loosened gains the first and loses the second."""
    from mocapkit.cleaning.ssa.drifts import chain_level, other_joints_level
    from mocapkit.motion import mirror_pairs

    p = det.params
    c = det.change if det.change is not None and p.drift_change else det.consistency
    a = det.agreement
    judged = np.isfinite(a)
    z = p.drift_z
    with np.errstate(invalid="ignore"):
        ok = {"z": c >= z, "agreement": a <= np.radians(p.drift_repeat_deg)}
        ok.update({g: np.ones(c.shape, dtype=bool) for g in ("others", "partner", "chain")})
        if p.drift_others is not None:
            ok["others"] = other_joints_level(c, judged, p.drift_others) < z
        if p.drift_partner_ratio is not None:
            perm = mirror_pairs(det.joint_names)
            ok["partner"] = ~((perm != np.arange(len(perm)))[None, :] & (c[:, perm] >= p.drift_partner_ratio * z))
        if p.drift_chain_ratio is not None and det.parents is not None:
            ok["chain"] = chain_level(c, judged, det.parents) < p.drift_chain_ratio * z
    cells = np.asarray(cells, dtype=bool) & judged
    out = {"cells": int(cells.sum()), "pass": int((np.logical_and.reduce([ok[g] for g in GATES]) & cells).sum())}
    for g in GATES:
        rest = np.logical_and.reduce([ok[o] for o in GATES if o != g])
        out[g] = int((rest & ~ok[g] & cells).sum())
    return out


def paired_drifts(records, joint_names, parents) -> np.ndarray:
    """(n,) bool: which of one seed's drifts ``records`` overlaps in time another drift on its left/right partner,
    its parent or one of its children.

    The drift rule takes such a neighbour's digression at the same frames for a style's (``drift_partner_ratio``:
    a style is often two-sided; ``drift_chain_ratio``: a style bends a chain), so two drifts there at once are
    found only where the two turn about crossed axes (``drift_cross_cos``); ``details.results`` scores their recall
    apart (``recall_paired_drifts``) from that of the others (``recall_single_drifts``)."""
    from mocapkit.motion import mirror_pairs

    perm = mirror_pairs(joint_names)
    idx = [list(joint_names).index(r.joint) for r in records]
    out = np.zeros(len(records), dtype=bool)
    for a, (ra, ja) in enumerate(zip(records, idx)):
        for b, (rb, jb) in enumerate(zip(records, idx)):
            near = (jb == perm[ja] and jb != ja) or parents[ja] == jb or parents[jb] == ja
            out[a] |= a != b and near and rb.start < ra.end and ra.start < rb.end
    return out


def drift_recall(flags, truth, ignore, records, paired, joint_names, fps) -> dict:
    """``{"recall_single_drifts": (tp, fn), "recall_paired_drifts": (tp, fn)}``: the words of the drifts that
    :func:`paired_drifts` calls single (paired) found by ``flags``, the other drifts' cells left unscored."""
    out = {}
    for name, which in (("recall_single_drifts", ~paired), ("recall_paired_drifts", paired)):
        cells = np.zeros(truth.shape, dtype=bool)
        for r, w in zip(records, which):
            if w:
                cells[r.start:r.end, list(joint_names).index(r.joint)] = True
        sc = score(flags, truth & cells, fps, ignore | (truth & ~cells))
        out[name] = (sc.tp, sc.fn)
    return out


def add_counts(stats, name, counts):
    total = stats.setdefault(name, {})
    for k, v in counts.items():
        total[k] = total.get(k, 0) + v


def run_case(name, clean, context, drifts, seeds, fps_db, stats, totals, key, rows, detect_opts):
    joints = drift_joints(clean)
    db = MotionDatabase.build(context, fps=fps_db, progress=False, executor="serial") if context else None
    t0 = time.process_time()
    own = ssa.detect(clean, db, **detect_opts)
    own_drift = own.drifts()
    stats.setdefault(f"{key}/clean_take_drift_cells_without_change", 0)
    stats[f"{key}/clean_take_drift_cells_without_change"] += int(dataclasses.replace(own, change=None).drifts().sum())
    stats.setdefault(f"{key}/clean_take_drift_cells", 0)
    stats[f"{key}/clean_take_drift_cells"] += int(own_drift.sum()) if own_drift is not None else 0
    stats.setdefault(f"{key}/clean_take_cells", 0)
    stats[f"{key}/clean_take_cells"] += int(own.analysed.sum() * clean.num_frames)
    add_counts(stats, f"{key}/gate_blockers_untouched", gate_blockers(own, np.ones(own.agreement.shape, dtype=bool)))
    for seed in range(seeds):
        bad, mask, records = corrupt.smooth_drifts(clean, n_drifts=drifts, seed=(zlib.crc32(name.encode()), seed), joints=joints)
        truth = mask & (np.degrees(R.geodesic_angle(clean.rotations, bad.rotations)) >= 5.0)
        ignore = mask & ~truth
        det = ssa.detect(bad, db, **detect_opts)
        base = flag_rule(det.mdm, det.jumps, det.holds, det.swaps, det.offsets, det.threshold, det.fps,
                         det.params.confirm, det.params.confirm_margin_s, None)
        dr = det.drifts()
        add_counts(stats, f"{key}/gate_blockers_drifted", gate_blockers(det, truth))
        paired = paired_drifts(records, clean.skeleton.joint_names, clean.skeleton.parents)
        for k, (tp, fn) in drift_recall(det.flags, truth, ignore, records, paired, clean.skeleton.joint_names,
                                        clean.fps).items():
            for part in [key] + ([f"{key}/{content_group(name)}"] if key != "hdm05" else []):
                add_counts(stats, f"{part}/{k}", {"tp": tp, "fn": fn})
        # the same analysis with the drift rule reading the angle ratio (``drift_change`` off)
        unchanged = flag_rule(det.mdm, det.jumps, det.holds, det.swaps, det.offsets, det.threshold, det.fps,
                              det.params.confirm, det.params.confirm_margin_s,
                              dataclasses.replace(det, change=None).drifts(), det.spikes, np.isfinite(det.digression))
        for method, flags in (("ssa", det.flags), ("baseline", base), ("drift_rule_only", dr),
                              ("ssa_without_change", unchanged)):
            sc = score(flags, truth, clean.fps, ignore)
            totals[(key, method)] = add(totals.get((key, method)), sc)
            if key != "hdm05":
                part = (f"{key}/{content_group(name)}", method)
                totals[part] = add(totals.get(part), sc)
        for r in records:
            j = clean.skeleton.index(r.joint)
            seg = truth[r.start:r.end, j]
            if seg.any():
                stats.setdefault(f"{key}/agreement_deg", []).append(
                    float(np.degrees(np.nanmedian(det.agreement[r.start:r.end, j][seg]))))
                stats.setdefault(f"{key}/consistency_max", []).append(float(np.nanmax(det.consistency[r.start:r.end, j][seg])))
        rows.append(dict(set=key, take=name, seed=seed, drifts=[(r.joint, r.start, r.end) for r in records],
                         flagged=[int(det.flags[r.start:r.end, clean.skeleton.index(r.joint)].sum()) for r in records]))
    return time.process_time() - t0


def dance_big_context(seeds: int, contexts: list[str], quick: bool) -> dict:
    """Issue 24 item 7: the Bandai Namco dance (dataset 1, 63 s, 30 fps; the archive's only dance take) scored as
    ``ssa_detection.py``'s ``dance_30fps`` scores it (``real_errors``, 4 per seed, 5 deg visible, clean-take
    glitches ignored), against: ``local`` (the take alone: today's figure), ``action`` (the Bandai action takes:
    call, punch, slash, kick, respond; 73 s) and ``dataset1`` (every other take of dataset 1, about 1,000 s,
    searched exactly). The CMU dances cannot take this context: it is another rig, and a context
    must share the take's hierarchy (``mocapkit.context.fit_context`` maps names, not rigs)."""
    import ssa_detection as S

    takes = [t for t in bandai_takes() if t.dataset == 1]
    dance = [t for t in takes if t.content == "dance-short"][0]
    clean = mocapkit.load(dance.path)
    if quick:
        clean = clean[: int(20 * clean.fps)]
    action = [t for t in takes if t.content in ("call", "punch", "slash", "kick", "respond")]
    pools = {"local": [], "action": action, "dataset1": [t for t in takes if t.path != dance.path]}
    names = clean.skeleton.joint_names
    ign = S.glitches(clean, 5000.0)
    inject = [names[j] for j in ssa.informative_joints([clean], 24) if j != 0]
    out = {"clip": dance.path.name, "frames": clean.num_frames, "fps": clean.fps}
    for c in contexts:
        ctx = [mocapkit.load(t.path) for t in pools[c]]
        db = MotionDatabase.build(ctx, fps=30, progress=False, executor="serial") if ctx else None

        def run(m):
            return ssa.detect(m, db, threshold=0.5, z_scale=3.0, noise_deg=5.0, normalization="median", drift=True)

        t0 = time.process_time()
        own = run(clean).flags
        strict = unscored = no_drift = None
        for seed in range(seeds):
            bad, mask, _ = corrupt.real_errors(clean, n_errors=4, seed=1000 + seed, joints=inject)
            truth = S.truth_mask(clean, bad, mask, 5.0)
            ign_seed = ign | (mask & ~truth)
            det = run(bad)
            flags = det.flags
            strict = add(strict, S.score(flags, truth, clean.fps, ignore=ign_seed))
            unscored = add(unscored, S.score(flags, truth, clean.fps, ignore=ign_seed | own))
            plain = flag_rule(det.mdm, det.jumps, det.holds, det.swaps, det.offsets, det.threshold, det.fps,
                              det.params.confirm, det.params.confirm_margin_s, None)
            no_drift = add(no_drift, S.score(plain, truth, clean.fps, ignore=ign_seed))
        out[c] = {"context_s": round(sum(m.duration for m in ctx), 1), "context_takes": len(ctx),
                  "ssa": row(no_drift), "ssa_with_drift_rule": row(strict), "ssa_with_drift_rule_take_pairs_unscored": row(unscored),
                  "untouched_take_flagged_cells_with_drift_rule": int(own.sum()), "cpu_s": round(time.process_time() - t0, 1)}
    return out


def main(argv=None):
    ap = harness.parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="two contents and two styles per dataset, two HDM05 actors")
    ap.add_argument("--split", default="bandai", choices=["bandai", "calibration"],
                    help="score the held-out styles (default) or the calibration styles")
    ap.add_argument("--sets", default="bandai,hdm05,dance")
    ap.add_argument("--dance-contexts", default="local,action,dataset1")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--drifts", type=int, default=2, help="drifts per take and seed")
    ap.add_argument("--per", type=int, default=1, help="takes per (content, style)")
    ap.add_argument("--context-s", type=float, default=60.0)
    ap.add_argument("--repeat-deg", type=float, default=None)
    ap.add_argument("--drift-z", type=float, default=None)
    ap.add_argument("--drift-min-s", type=float, default=None)
    ap.add_argument("--drift-extent", type=float, default=None)
    ap.add_argument("--groups", default="locomotion,arms,gestures", help="content groups scored (content_group)")
    args = ap.parse_args(argv)
    sets = args.sets.split(",")
    opts = {"drift": True}  # the rule is opt-in: a context that repeats the motion is this benchmark's premise
    opts.update({k: v for k, v in (("drift_repeat_deg", args.repeat_deg), ("drift_z", args.drift_z),
                              ("drift_min_s", args.drift_min_s), ("drift_extent", args.drift_extent))
            if v is not None})
    totals, stats, rows, cpu = {}, {}, [], {}
    if "bandai" in sets:
        key = "bandai" if args.split == "bandai" else "calibration"
        for name, path, others, context_s in bandai_cases(args.split, args.per, args.context_s, args.quick):
            if content_group(name) not in args.groups.split(","):
                continue
            clean = mocapkit.load(path)
            ctx = load_context(others, context_s)
            cpu.setdefault(key, []).append(run_case(name, clean, ctx, args.drifts, args.seeds, 30, stats, totals, key, rows, opts))
            if not args.json:
                sc = totals[(key, "ssa")]
                print(f"{key} {name:48s} running R {sc.recall:.3f} P {sc.precision:.3f}", flush=True)
    if "hdm05" in sets:
        for name, path, others in hdm_cases(args.quick):
            clean = mocapkit.load(path)
            ctx = [mocapkit.load(p) for p in others]
            cpu.setdefault("hdm05", []).append(run_case(name, clean, ctx, args.drifts, args.seeds, 120, stats, totals, "hdm05", rows, opts))
            if not args.json:
                sc = totals[("hdm05", "ssa")]
                print(f"hdm05 {name:48s} running R {sc.recall:.3f} P {sc.precision:.3f}", flush=True)
    dance = dance_big_context(1 if args.quick else 3, args.dance_contexts.split(","), args.quick) if "dance" in sets else None
    results = {f"{k}/{m}": row(sc) for (k, m), sc in sorted(totals.items())}
    figures, baselines, targets = {}, {}, {}
    keys = [f"{k}{g}" for k in ("bandai", "calibration") for g in ("", "/locomotion", "/arms", "/gestures")] + ["hdm05"]
    for key in keys:
        if f"{key}/ssa" not in results:
            continue
        for what in ("recall", "precision"):
            name = f"{key.replace('/', ' ')} {what}"
            figures[name] = results[f"{key}/ssa"][what]
            baselines[name] = results[f"{key}/baseline"][what]
            if key.startswith("bandai"):
                targets[name] = {"value": TARGET[0 if what == "recall" else 1], "op": ">=", "of": "figures"}
    for key in ("bandai", "calibration", "hdm05"):
        if (key, "ssa") not in totals:
            continue
        cells = stats.get(f"{key}/clean_take_cells", 0)
        figures[f"{key} clean-take drift cell share"] = round(stats.get(f"{key}/clean_take_drift_cells", 0) / max(cells, 1), 6)
    if dance is not None:
        for c in args.dance_contexts.split(","):
            for what in ("recall", "precision"):
                figures[f"bandai dance {c} {what}"] = dance[c]["ssa"][what]
                if c != "local" and "local" in dance:
                    baselines[f"bandai dance {c} {what}"] = dance["local"]["ssa"][what]
    summary = {}
    for k, v in stats.items():
        if k.rsplit("/", 1)[-1].startswith("recall_"):  # drift_recall's words: found and missed, and their recall
            results[k] = {"recall": round(v["tp"] / (v["tp"] + v["fn"]), 4) if v["tp"] + v["fn"] else None, **v}
            continue
        if isinstance(v, list):  # NaN: a drift on a joint the analysis left out (not among the informative joints)
            v = np.asarray(v, dtype=float)
            ok = v[np.isfinite(v)]
            summary[k] = {"median": round(float(np.median(ok)), 2) if len(ok) else None,
                          "p10": round(float(np.percentile(ok, 10)), 2) if len(ok) else None,
                          "p90": round(float(np.percentile(ok, 90)), 2) if len(ok) else None,
                          "n": int(len(ok)), "not_analysed": int(len(v) - len(ok))}
        else:
            summary[k] = v
    details = {"results": results, "statistic": summary, "cases": rows, "dance_big_context": dance,
               "cpu_s_per_take": {k: round(float(np.mean(v)), 2) for k, v in cpu.items()},
               "params": ssa.SSAParams().replace(**opts).as_dict(),
               "note": "figures: all of detect's flags (target on the held-out Bandai styles); baselines: the same "
                       "analysis's flags without the smooth-drift rule; drift_rule_only: the drift rule's flags alone; "
                       "clean-take drift cell share: cells the drift rule flags on the untouched takes over analysed cells; "
                       "statistic gate_blockers_drifted / _untouched: of the drifted cells (of the untouched takes' judged "
                       "cells), those that pass every cell-level gate of the drift rule and those one gate alone stops "
                       "(gate_blockers)"}
    if not args.json:
        for k, v in results.items():
            print(f"{k:32s} recall {v['recall']:.3f} precision {v['precision']:.3f} (tp {v['tp']} fp {v['fp']} fn {v['fn']})")
        print({k: v for k, v in figures.items() if "share" in k}, summary)
    harness.emit("drift_detection", args, figures=figures, baselines=baselines, targets=targets, details=details)


if __name__ == "__main__":
    main()
