"""Decisions on a marker cleaning land on the samples each change was made for, whatever was decided about a swap
around it.

CMU 85_02 (41 markers, 120 Hz; tests/data) cut to 600 frames, with Male:LTOE and Male:RTHI swapped over frames
100-159 and, inside the swap, a 60 mm spike at frame 120 on the file's LTOE label (RTHI's recorded trajectory) and a
10-frame gap at 130-139 on the file's RTHI label (LTOE's), put in by hand.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from mocapkit.cleaning.markers import clean_markers
from mocapkit.cleaning.markers import decisions as md
from mocapkit.io import load_markers

CMU = Path(__file__).resolve().parents[2] / "data" / "85_02.c3d"
A, B = 10, 11  # Male:LTOE, Male:RTHI


@pytest.fixture(scope="module")
def cleaning():
    """(input, cleaning, {kind: change}) of the capture with a swap and a spike and a gap inside it."""
    ms = load_markers(CMU)[:600]
    p = np.array(ms.positions)
    p[100:160, [A, B]] = p[100:160, [B, A]]
    p[120, A] += [0.0, 0.0, 60.0]
    p[130:140, B] = np.nan
    src = np.tile(np.arange(ms.num_markers), (ms.num_frames, 1))
    src[100:160, [A, B]] = [B, A]  # the swapped samples keep their residuals and camera masks
    x = ms.with_positions(p, sources=src)
    res = clean_markers(x)
    found = {c.kind: c for c in md.changes(x, res.markers, res.fixes)}
    assert sorted(found) == ["gap", "spike", "swap"]
    return x, res, found


def _cell(m, f, k):
    return m.positions[f, k], m.residuals[f, k], m.cameras[f, k]


def _same(u, v) -> bool:
    return all(np.array_equal(s, t, equal_nan=True) for s, t in zip(u, v))


def _same_cells(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(F, K): whether each cell of two (F, K, ...) arrays is the same, NaN equal to NaN (``_same`` of every cell)."""
    eq = u == v
    if u.dtype.kind in "fc":
        eq |= np.isnan(u) & np.isnan(v)
    return eq.reshape(*eq.shape[:2], -1).all(axis=-1)


@pytest.mark.parametrize("swap,spike,gap", list(itertools.product(["accept", "reject"], repeat=3)))
def test_each_accepted_change_lands_on_its_own_samples(cleaning, swap, spike, gap):
    x, res, found = cleaning
    chosen = {found["swap"].id: swap, found["spike"].id: spike, found["gap"].id: gap}
    out = md.apply(x, res.markers, res.fixes, chosen)
    cl = res.markers
    sw, sp, gp = found["swap"], found["spike"], found["gap"]
    assert (sp.marker_index, gp.marker_index) == (B, A)  # cleaned labelling: the spike on RTHI, the gap on LTOE
    # every other change is accepted: each cell outside the swap's as cleaned (all of them at once, as _same per cell)
    other = np.ones((x.num_frames, x.num_markers), dtype=bool)
    other[sw.first:sw.last + 1, [A, B]] = False
    same = np.all([_same_cells(u, v) for u, v in ((out.positions, cl.positions), (out.residuals, cl.residuals),
                                                   (out.cameras, cl.cameras))], axis=0)
    assert same[other].all(), [(int(f), x.labels[k]) for f, k in np.argwhere(other & ~same)[:5]]
    for f in range(sw.first, sw.last + 1):
        for k in (A, B):
            # the recorded trajectory in the file's column k: marker `own` of the cleaned capture
            own = k if swap == "accept" else (B if k == A else A)
            fixed = (own == B and sp.first <= f <= sp.last and spike == "accept") or (
                own == A and gp.first <= f <= gp.last and gap == "accept")
            recorded = (A if own == B else B) if swap == "accept" else k  # where the input holds it
            want = _cell(cl, f, own) if fixed else _cell(x, f, recorded)
            assert _same(_cell(out, f, k), want), (f, x.labels[k])


def test_the_decided_result_names_the_marker_its_samples_are_written_to(cleaning):
    x, res, found = cleaning
    chosen = {found["swap"].id: "reject", found["spike"].id: "accept", found["gap"].id: "accept"}
    got = md.decided_result(x, res, chosen)
    sp, gp = found["spike"], found["gap"]
    assert np.flatnonzero(got.spikes[sp.first]).tolist() == [A]
    assert got.filled[gp.first:gp.last + 1, B].all() and not got.filled[:, A].any()
    named = {(fx.kind, fx.start): fx.marker for fx in got.fixes}
    assert named[("spike", sp.first)] == x.labels[A] and named[("gap", gp.first)] == x.labels[B]
    assert ("swap", found["swap"].first) not in named


def test_changes_whose_origin_cannot_be_told_are_tied_and_a_split_is_refused():
    # two swaps chained over one marker (LTOE/RTHI 100-199, RTHI/LKNE 150-249) whose cleaned samples are not what
    # exchanging their recorded trajectories in order of first frame gives (the columns exchanged instead), and a
    # spike filled inside them
    from mocapkit.cleaning.markers import MarkerFix

    x = load_markers(CMU)[:400]
    p = np.array(x.positions)
    k = 5  # Male:LKNE
    p[100:200, [A, B]] = p[100:200, [B, A]]
    p[150:250, [B, k]] = p[150:250, [k, B]]
    p[170, k] += [0.0, 0.0, 1.0]
    cleaned = x.with_positions(p)
    lab = x.labels
    fixes = [MarkerFix(lab[A], 100, 200, "swap", 1.0, lab[B]), MarkerFix(lab[B], 150, 250, "swap", 1.0, lab[k]),
             MarkerFix(lab[k], 170, 171, "spike", 1.0)]
    ids = [c.id for c in md.changes(x, cleaned, fixes)]
    assert len(ids) == 3
    assert md.tied(x, cleaned, fixes) == [sorted(ids, key=ids.index)]
    rows = md.review(x, cleaned, fixes)["changes"]
    assert all(sorted(r["tied"]) == sorted(ids) for r in rows)
    # the page's row and the console say which go together and why
    assert all(r["tied_why"] == md.TIED_WHY for r in rows) and "under another marker's label" in md.TIED_WHY
    assert md.tied_lines(x, cleaned, fixes) == [f"{', '.join(sorted(ids, key=ids.index))}: accepted or rejected "
                                                f"together, as {md.TIED_WHY}"]
    with pytest.raises(ValueError, match="under another marker's label: accept or reject them together"):
        md.apply(x, cleaned, fixes, {ids[0]: "reject"})
    back = md.apply(x, cleaned, fixes, {i: "reject" for i in ids})
    assert _same((back.positions, back.residuals, back.cameras), (x.positions, x.residuals, x.cameras))
    every = md.apply(x, cleaned, fixes, {})
    assert _same((every.positions, every.residuals, every.cameras),
                 (cleaned.positions, cleaned.residuals, cleaned.cameras))


def test_chained_swaps_are_two_changes_each_undone_alone():
    # trial27: in CMU 85_02, LTOE/RTHI swapped over frames 100-199 and RTHI/LKNE over 150-249 (three labels cycled
    # in 150-199) were undone right but listed as LKNE/LTOE 150-809 and LKNE/RTHI 250-809 with a nameless change,
    # all tied. Now: the two swaps as recorded, each a change; rejecting one gives the input's samples for its
    # markers over its frames, except where the other (kept) moves the marker they share.
    x = load_markers(CMU)
    lab = list(x.labels)
    a, b, k = lab.index("Male:LTOE"), lab.index("Male:RTHI"), lab.index("Male:LKNE")
    q = np.array(x.positions)
    q[100:200, [a, b]] = q[100:200, [b, a]]
    q[150:250, [b, k]] = q[150:250, [k, b]]
    take = x.with_positions(q)
    res = clean_markers(take)
    assert np.array_equal(res.markers.positions, x.positions)
    swaps = sorted((f.marker, f.other, f.start, f.end) for f in res.fixes if f.kind == "swap")
    assert swaps == [("Male:LKNE", "Male:RTHI", 150, 250), ("Male:LTOE", "Male:RTHI", 100, 200)]
    ids = [c.id for c in md.changes(take, res.markers, res.fixes)]
    assert sorted(ids) == ["swap:Male:LKNE:150-249", "swap:Male:LTOE:100-199"]
    assert md.tied(take, res.markers, res.fixes) == []
    # LTOE/RTHI rejected: LTOE is the input's throughout, RTHI too but where RTHI/LKNE (kept) moves it
    out = md.apply(take, res.markers, res.fixes, {"swap:Male:LTOE:100-199": "reject"}).positions
    assert np.array_equal(out[:, a], q[:, a])
    assert np.array_equal(out[:150, b], q[:150, b]) and np.array_equal(out[250:, b], q[250:, b])
    assert np.array_equal(out[150:250, b], q[150:250, k]) and np.array_equal(out[150:250, k], q[150:250, b])
    # RTHI/LKNE rejected: LKNE is the input's throughout, RTHI too but where LTOE/RTHI (kept) moves it
    out = md.apply(take, res.markers, res.fixes, {"swap:Male:LKNE:150-249": "reject"}).positions
    assert np.array_equal(out[:, k], q[:, k])
    assert np.array_equal(out[200:, b], q[200:, b]) and np.array_equal(out[:100, b], q[:100, b])
    assert np.array_equal(out[100:200, b], q[100:200, a]) and np.array_equal(out[100:200, a], q[100:200, b])
    # every other marker untouched either way; both rejected: the input
    back = md.apply(take, res.markers, res.fixes, {i: "reject" for i in ids}).positions
    assert np.array_equal(back, q)


CHAINS = {  # swaps made in this order (the labeller's); marker names without the subject prefix
    "back to back": [("LTOE", "RTHI", 100, 200), ("RTHI", "LKNE", 200, 300)],
    "back to back, other order": [("RTHI", "LKNE", 100, 200), ("LTOE", "RTHI", 200, 300)],
    "three in a row": [("LTOE", "RTHI", 100, 200), ("RTHI", "LKNE", 200, 300), ("LKNE", "LFHD", 300, 400)],
    "overlapping, later made first": [("RTHI", "LKNE", 150, 250), ("LTOE", "RTHI", 100, 200)],
}


@pytest.mark.parametrize("which", ["85_02", "HDM_bd"])
@pytest.mark.parametrize("chain", list(CHAINS))
def test_each_swap_of_a_chain_is_a_change_rejected_alone(which, chain, shared_data):
    # CMU 85_02 and HDM05's HDM_bd_05-01_01_120 (frames 0-599) with swaps sharing a marker: before, back to back
    # they were one wrong swap to the take's end, and a chain whose later swap was made first was tied. Each swap
    # is now a change of its own: rejecting it gives the input's samples (position, residual, camera mask) on its
    # two trajectories, bit for bit, where no kept swap moves them, and the other swaps stay undone.
    path = CMU if which == "85_02" else shared_data / "c3d_markers_recovery" / "HDM_bd_05-01_01_120.c3d"
    x = load_markers(path)[:600]
    names = [label.split(":")[-1] for label in x.labels]
    src = np.tile(np.arange(x.num_markers), (x.num_frames, 1))
    made = []
    for u, v, s, e in CHAINS[chain]:
        a, b = names.index(u), names.index(v)
        src[s:e, [a, b]] = src[s:e, [b, a]]
        made.append((a, b, s, e))
    take = x.with_positions(np.asarray(x.positions)[np.arange(x.num_frames)[:, None], src], sources=src)
    res = clean_markers(take, steps=["swaps"])  # a complete capture: the other steps change nothing
    assert _same(_cell(res.markers, slice(None), slice(None)), _cell(x, slice(None), slice(None)))
    found = md.changes(take, res.markers, res.fixes)
    assert all(c.kind == "swap" for c in found) and len(found) == len(made)
    assert md.tied(take, res.markers, res.fixes) == []
    for a, b, s, e in made:
        cid = next(c.id for c in found if c.first == s and {c.marker_index, c.other and names.index(
            c.other.split(":")[-1])} == {a, b})
        out = md.apply(take, res.markers, res.fixes, {cid: "reject"})
        others = [(p, r, t, w) for p, r, t, w in made if (p, r, t, w) != (a, b, s, e)]
        for k in (a, b):
            moved = [(t, w) for p, r, t, w in others if k in (p, r)]  # frames where a kept swap moves this marker
            rows = [f for f in range(s, e) if not any(t <= f < w for t, w in moved)]
            assert rows and _same(_cell(out, rows, k), _cell(take, rows, k))
        # each kept swap's own marker outside the rejected one's frames, and every frame no swap of the chain
        # touches: the cleaned samples
        for p, r, t, w in others:
            own = [k for k in (p, r) if k not in (a, b)]
            rows = [f for f in range(t, w) if not s <= f < e]
            assert rows and all(_same(_cell(out, rows, k), _cell(x, rows, k)) for k in own)
        lo, hi = min(m[2] for m in made), max(m[3] for m in made)
        assert _same(_cell(out, slice(hi, None), slice(None)), _cell(x, slice(hi, None), slice(None)))
        assert _same(_cell(out, slice(0, lo), slice(None)), _cell(x, slice(0, lo), slice(None)))
    back = md.apply(take, res.markers, res.fixes, {c.id: "reject" for c in found})
    assert _same(_cell(back, slice(None), slice(None)), _cell(take, slice(None), slice(None)))


def test_labels_cycled_at_one_frame_are_each_a_decision_of_their_own():
    # four labels cycled over frames 100-199 of CMU 85_02 are undone as three swaps over the same frames; taken in
    # the listing's order, the third's two markers were the first two's, so it owned no sample and the swaps were
    # tied (accepted or rejected together)
    x = load_markers(Path(__file__).resolve().parents[2] / "data" / "85_02.c3d")[:600]
    names = [label.split(":")[-1] for label in x.labels]
    ring = [names.index(n) for n in ("LTOE", "RTHI", "LKNE", "LFHD")]
    q = np.array(x.positions, dtype=np.float64)
    q[100:200, ring] = q[100:200, ring[1:] + ring[:1]]
    taken = x.with_positions(q)
    res = clean_markers(taken)
    assert md.tied(taken, res.markers, res.fixes) == []
    assert sorted(c.id for c in md.changes(taken, res.markers, res.fixes)) == sorted(
        f"swap:{f.marker}:100-199" for f in res.fixes if f.kind == "swap") and len(res.fixes) == 3


def test_a_spike_removed_beside_a_gap_left_missing_is_a_spike_change_and_old_decisions_still_apply():
    """A recorded sample removed as a spike beside a gap no fill is written for (here longer than ``max_gap_s``)
    is a spike fix with the distance that made it one, not a nameless ``change`` ("changed by the cleaning");
    a decisions file from before 0.17.0, which named it ``change:M:A-B``, is honoured as the same samples'."""
    original = load_markers(Path(md.__file__).parents[2] / "data" / "Eb015pr.c3d")
    p = np.array(original.positions)
    p[100:120, 0] = np.nan
    p[120, 0] += (0.0, 0.0, 60.0)  # mm: a 60 mm glitch on the first sample seen after the gap
    broken = original.with_positions(p)
    res = clean_markers(broken, max_gap_s=0.05)
    assert np.isnan(res.markers.positions[120, 0]).all() and not np.isnan(p[120, 0]).any()  # removed, left missing
    row = next(c for c in md.changes(broken, res.markers, res.fixes) if c.first <= 120 <= c.last and c.marker_index == 0)
    assert row.id == "spike:RFT1:120-120" and row.size_words() == "removed, left missing"
    fix = next(x for x in res.fixes if x.kind == "spike" and x.start == 120)
    assert 40 < fix.miss_mm < 80 and "mm off the line" in fix.size_text and "longer than --max-gap" in fix.size_text
    old_fixes = [x for x in res.fixes if x is not fix]  # what a 0.16.0 cleaning listed
    old = md.changes(broken, res.markers, old_fixes)
    assert "change:RFT1:120-120" in {c.id for c in old}
    doc = md.template(broken, old, cleaned=res.markers, decisions={"change:RFT1:120-120": "reject"})
    chosen = md.check(doc, "old.decisions.json", broken, res.markers, res.fixes)
    assert chosen["spike:RFT1:120-120"] == "reject" and "change:RFT1:120-120" not in chosen
    back = md.apply(broken, res.markers, res.fixes, chosen)
    assert np.array_equal(back.positions[120, 0], p[120, 0])  # the rejected removal: the recorded sample
    new = md.template(broken, md.changes(broken, res.markers, res.fixes), cleaned=res.markers,
                      decisions={"spike:RFT1:120-120": "reject"})  # a new file on a 0.16.0 record's fixes
    assert md.check(new, "new.decisions.json", broken, res.markers, old_fixes)["change:RFT1:120-120"] == "reject"
