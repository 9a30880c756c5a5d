"""Do no harm: the share of (frame, joint) cells `mocapkit clean` changes on untouched takes of every rig.

Usage::

    python benchmarks/clean_untouched.py [--json] [--bandai N | --all] [--workers W] [--quick]

Every take is cleaned by :func:`mocapkit.clean` with its defaults, as
``mocapkit clean IN -o OUT`` does: no context given, so the bundled default
context where it fits the take's skeleton (the Acclaim rig of CMU and HDM05;
a take the context holds is left out of its own context by detect) and the
clip itself elsewhere; default steps. A cell is *changed* when any rotation channel of that joint at
that frame differs from the input at all (for the root, its position too; for a joint with position
channels, those too).
The takes are clean captures, so every changed cell is harm.

Collections (``../shared/data``):

* ``hdm05``: the 280 HDM05 clips (120 fps, five actors' Acclaim skeletons);
* ``cmu_asfamc``: the CMU ASF/AMC takes (120 fps);
* ``cmu_bvh``: the CMU BVH conversions (120 fps, frame 0 the converter's T-pose);
* ``bandai_secondary``: the secondary Bandai Namco clips (30 fps, 22-joint game rig);
* ``bandai``: Bandai Namco Research Motiondataset 1 and 2 via ``benchmarks/_bandai.py``
  (30 fps): a sample stratified over (dataset, content, style), one take of each
  combination in turn in a fixed-seed order until ``--bandai`` takes (default 520),
  or every take with ``--all`` (its result is kept as ``results/clean_untouched_all.json``, beside the
  sample's ``clean_untouched.json``).

Rigs that ``../shared/data`` does not hold, spelled from those takes (``tests/shared.py``; the same
motion on another rig's names and joints, so any cell changed is harm too):

* ``smpl``: every 4th HDM05 clip and the CMU ASF/AMC takes on SMPL's 24 joints and names
  (``Pelvis``, ``L_Hip``, ... : no hip bones, upper neck, fingers or thumbs), 120 fps;
* ``daz``: every 4th HDM05 clip from the third (not ``smpl``'s) and the CMU ASF/AMC takes as the CMU
  Daz-friendly BVH release spells its rig (``hip``, ``abdomen``, ``lThigh``, ``lShldr``, ... : no middle
  spine, upper neck, toes or palms), 120 fps;
* ``xsens``: every 4th HDM05 clip from the second (neither ``smpl``'s nor ``daz``'s) and the CMU ASF/AMC
  takes on Xsens MVN's BVH rig and names (``Hips``, ``Chest``, ``Chest2``, ``Chest4``, ``LeftHip``,
  ``LeftCollar``, ``LeftShoulder``, ... : no hip bones, upper neck, palms or fingers), 120 fps;
* ``unity``: every 4th HDM05 clip from the fourth and the CMU ASF/AMC takes on Unity's humanoid avatar
  (``Hips``, ``Spine``, ``Chest``, ``UpperChest``, ``LeftShoulder``, ``LeftUpperArm``, ``LeftUpperLeg``, ... : no
  hip bones, upper neck or palms), 120 fps;
* ``unnamed``: every 8th HDM05 clip from the second and the CMU ASF/AMC takes as the CMU MotionBuilder release
  spells them, then renamed ``bone0``, ``bone1``, ... (a rig no family knows: its roles read from its tree and
  rest pose), 120 fps;
* ``unreal``: every 10th take of the Bandai Namco sample under Unreal Engine mannequin names
  (``root``, ``pelvis``, ``spine_01``, ``thigh_l``, ...), 30 fps.
* ``lafan``: every 8th HDM05 clip from the sixth and the CMU ASF/AMC takes on the rig of Ubisoft's LaFAN1
  BVH files (``Hips``, ``Spine``-``Spine2``, ``LeftUpLeg``, ``LeftToe``, ``LeftArm``, ... : no hip bones, upper
  neck or fingers; position channels on every joint, their values the offsets), 30 fps (every 4th frame): a
  rig that differs in structure, not only in names.

None fits the bundled default context (another skeleton): each take is judged against itself.
``--no-respelled`` leaves them out.

The same captures at a lower rate (``--no-low-rate`` leaves them out): every 4th frame of a 120 fps
take, so every value is a real capture sample (a take delivered at 30 fps by dropping frames):

* ``hdm05_30fps``: every 4th HDM05 clip (every 20th with ``--quick``), 30 fps;
* ``cmu_asfamc_30fps``, ``cmu_bvh_30fps``: the CMU ASF/AMC takes and BVH conversions, 30 fps
  (the BVH's frame 0, the converter's T-pose, kept).

They are judged against the bundled default context, as the 120 fps takes are; the level-only
baseline is computed on them as on every take.

``--fps F`` measures every take of the run resampled to ``F`` frames per second instead (``Motion.resample``,
as ``mocapkit convert --fps`` does: every k-th frame where the take's rate is k times ``F``, so each value
is a real capture sample, slerp between frames elsewhere; a take at ``F`` or under as it is). The low-rate
rows of issue 21 are ``--fps 24``, ``20``, ``15`` and ``12`` with ``--no-respelled --no-low-rate --bandai 52``;
their results are kept as ``results/clean_untouched_<F>fps.json``.

What the changed cells at 24 and 20 fps are, read run by run against the 120 fps file each take is cut from
(hdm05, cmu_asfamc, cmu_bvh; a run is at a *half turn* where the 120 fps input turns its joint, or one of the
two joints above it, 90 deg or more in one 1/120 s frame over the run's span):

* ``--fps 24``: hdm05 147 cells = 10 denoised + 109 repaired at half turns + 28 repaired on smooth motion;
  cmu_asfamc 167 = 164 denoised + 3 repaired on smooth motion; cmu_bvh 42, all at half turns.
  ``--fps 20``: hdm05 172 = 133 at half turns + 39 on smooth motion; cmu_asfamc 12 = 1 + 11;
  cmu_bvh 37 = 35 + 2.
* The takes over 1 % at 24 fps are the noise rule's (``mocapkit.cleaning.noise_rate``, outside self-similarity
  repair): CMU backflip (87 cells, 5.6 %: the right hand and thumb, frames 18-49, and the left knee) and
  charleston2 (77, 2.3 %: left toes and right elbow), whose cells that module reads one by one, and HDM05 mm
  ``rotateArmsBothBackward1Reps`` 013 (10 of 13 frames of the left elbow, 2.5 %, moved up to 6.1 deg): at
  120 fps the elbow swings between -15 and -25 deg smoothly about 6-7 times a second (steps of 3.7 deg or
  less), which every 5th frame samples 3-4 times a period, steps of 1.3-9.5 deg that reverse as jitter does.
* The hdm05 takes over 1 % at 20 fps (bk ``depositFloorR`` 011, 1.24 %; tr ``throwBasketball`` 014, 1.22 %;
  bk ``depositFloorR`` 007, 1.19 %) and tr ``throwBasketball`` 014 at 24 fps (1.24 %) are repairs of the
  capture's own half turns: the 120 fps input turns the right thigh 179.9 deg in one frame at 137 and 205 of
  007 and at 120 and 160 of 011, the right hand 179.8 and 167.9 deg at 53 and 148 of 014, its median step
  there 0.2-0.5 deg; the thigh's other solution (the knee bent the other way, the limb's positions the same,
  :mod:`mocapkit.cleaning.ssa.flips`) and the hand's flip are turned back as at 120 fps over the same frames
  (the 120 fps run gives 136, 80 and 169 changed cells on those takes), so they are repairs, not harm; so are
  the squat1Reps thighs and knees, the lieDownFloor and throwBasketball hands and 131_02's right thumb.
* The repairs of smooth motion are break and spike flags on a fast turn the rate cuts into one or two steps
  (the flick of ``mocapkit.cleaning.ssa.smooth_turns`` that falls between two frames), none above 1 % of its
  take: at 24 fps the widest is bd ``throwBasketball`` 002's right hand (frames 15-29 and 32, 16 cells,
  0.85 %, moved up to 81 deg): the 120 fps hand turns at most 6.7 deg a frame, the 24 fps one 10.8, 26.8,
  28.5 and 8.8 deg from frame 27 to 31 as the ball leaves it, a break, and the medoid of the nearest words
  replaces it (none of the take's 11 words has a neighbour within 8 deg in some joint group); bd ``kickLFront1Reps`` 003's left foot (a
  spike, frames 14-16, 49.7 deg: at 120 fps 15.9 deg a frame at most), and one or two cells of the HDM05 mm
  wrists and hands, CMU 01_01's toes and lambada's hand. At 20 fps the same throw (13-24, 12 cells),
  dg ``grabHighR`` 013's right foot (34-42, 9) and CMU backflip's root and wrists at the flip (11).
  They are the two-step flick that the 24-20 fps share of the smooth-turn rule keeps a break (an error's
  step), and the joins read them as an error's too: the cubic path the joins imply
  (:func:`mocapkit.cleaning.ssa.guard.joined_path`) lies nearer the repair than the input on kickLFront1Reps
  003's foot (7.3 against 38.6 deg on average over the run) and on mm kickLFront1Reps 022's wrist (2.1
  against 21.3), as on the 28 runs repaired of spikes injected at 24 fps in those two takes and the throw
  (``corrupt.real_errors(kinds=("spike",))``, seeds 1-3: 29.6-83.6 deg from the path before, 0.0-2.9 after),
  and the repaired throw joins the take more smoothly than the input (15.2 against 20.6 deg/frame^2), so
  neither :mod:`~mocapkit.cleaning.ssa.guard` nor a path test gives them back without giving back the
  injected errors' repairs.

Per collection: the share of changed cells, the worst take and its share, and
the cells each step changed (fill, repair, denoise). Targets: at most 0.1 % per
collection and no take above 1 %. Each take is also tagged ``tune`` (Bandai
dataset-1, HDM05 actors other than mm: the data the noise and detection rules
were tuned on) or ``check`` (Bandai dataset-2, HDM05 actor mm, CMU), and the
shares are given for both parts.

Also per collection, ``on_glitching_joints``: the changed cells on joints whose
input turns more than 90 degrees between two frames somewhere in the take (a
thumb or hand flipping by 180 degrees in 1/120 s, as the CMU and HDM05 captures
do): there a change may be the repair of the capture's own glitch, not harm.
The targets count every changed cell all the same.

And ``at_glitch``: the changed cells in runs (one joint, consecutive frames)
where the input turns that joint faster than ``GLITCH_DEG_S`` (5,000 deg/s,
42 deg in one frame at 120 fps; the glitch rule of
``benchmarks/ssa_detection.py``) between two frames within 2 frames of the
run: the repair of a glitch of the capture's own, shown take by take in
``changed_takes`` (each changed run with the largest one-frame turn of the
input next to it), so a reader can tell a fix from harm.

Baseline, in the same run: the share of cells the level-only noise rule (a
cubic residual above 1 deg, without the direction test of
:func:`~mocapkit.cleaning.pipeline.noise_direction`) would have called noisy,
computed on the same inputs.
"""

from __future__ import annotations

import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO / "benchmarks"))
sys.path.insert(0, str(REPO))

import _harness as harness  # noqa: E402
from tests.shared import (daz_spelling, lafan_spelling, motionbuilder_spelling, smpl_spelling,  # noqa: E402
                          unity_spelling, unnamed, unreal_spelling, xsens_spelling)

DATA = REPO.parent / "shared" / "data"
if not DATA.is_dir():  # a worktree beside the main checkout
    DATA = Path("/work/shared/data")
TARGET_COLLECTION = 0.001
TARGET_TAKE = 0.01
GLITCH_DEG = 90.0  # a joint turning this far between two frames glitches (10,800 deg/s at 120 fps)
GLITCH_DEG_S = 5000.0  # a one-frame turn faster than this next to a changed run: the run repairs a glitch


def log(*a):
    print(*a, file=sys.stderr, flush=True)


# how each collection respells a CMU or HDM05 ASF/AMC take (on the MotionBuilder release's spelling first)
_ON_ACCLAIM = {"smpl": smpl_spelling, "daz": daz_spelling, "xsens": xsens_spelling, "unity": unity_spelling,
               "unnamed": unnamed}
RESPELLED = (*_ON_ACCLAIM, "unreal", "lafan")
"""The collections of takes respelled on rigs ``../shared/data`` does not hold (``tests/shared.py``)."""
LOW_RATE = {"hdm05_30fps": 4, "cmu_asfamc_30fps": 4, "cmu_bvh_30fps": 4}
"""The collections of 120 fps takes at a lower rate, and the step between the frames each keeps."""


def respell(motion, spelling: str):
    """``motion`` as the collection ``spelling`` holds it (a Bandai Namco take for ``unreal``); "" as it is."""
    if spelling in LOW_RATE:
        return motion[:: LOW_RATE[spelling]]
    if spelling == "unreal":
        return unreal_spelling(motion)
    if spelling == "lafan":  # LaFAN1's rig at its 30 fps: every 4th frame of a 120 fps take
        return lafan_spelling(motionbuilder_spelling(motion))[::4]
    return _ON_ACCLAIM[spelling](motionbuilder_spelling(motion)) if spelling else motion

def takes(n_bandai: int, all_bandai: bool, seed: int = 0, quick: bool = False,
          respelled: bool = True, low_rate: bool = True) -> list[tuple[str, str, str, str]]:
    """``(collection, path, split, spelling)`` for every take measured (spelling "" for the file as it is)."""
    out = []
    hdm = sorted((DATA / "hdm05_asfamc").glob("*.amc"))
    cmu = sorted((DATA / "cmu_asfamc").glob("*.amc"))
    bvh = sorted((DATA / "cmu_bvh").glob("*.bvh"))
    sec = sorted((DATA / "secondary_bandai_namco_CC-BY-NC").glob("*.bvh"))
    if quick:
        hdm, cmu, sec = hdm[::20], cmu[:2], sec[:3]
    out += [("hdm05", str(p), "check" if "_mm_" in p.name else "tune") for p in hdm]
    out += [("cmu_asfamc", str(p), "check") for p in cmu]
    out += [("cmu_bvh", str(p), "check") for p in bvh]
    out += [("bandai_secondary", str(p), "tune") for p in sec]  # dataset-1 takes
    from _bandai import bandai_takes

    allb = bandai_takes()
    if all_bandai:
        pick = allb
    else:
        rng = np.random.default_rng(seed)
        groups: dict = {}
        for t in allb:
            groups.setdefault((t.dataset, t.content, t.style), []).append(t)
        keys = sorted(groups)
        for k in keys:
            rng.shuffle(groups[k])
        order = [keys[i] for i in rng.permutation(len(keys))]
        pick, r = [], 0
        n = min(n_bandai if not quick else 20, len(allb))
        while len(pick) < n:
            for k in order:
                if r < len(groups[k]) and len(pick) < n:
                    pick.append(groups[k][r])
            r += 1
    out += [("bandai", str(t.path), "tune" if t.dataset == 1 else "check") for t in pick]
    if respelled:
        out += [("smpl", str(p), "check" if "_mm_" in p.name else "tune") for p in hdm[::4 if not quick else 1]]
        out += [("smpl", str(p), "check") for p in cmu]
        out += [("daz", str(p), "check" if "_mm_" in p.name else "tune") for p in hdm[2::4 if not quick else 1]]
        out += [("daz", str(p), "check") for p in cmu]
        out += [("xsens", str(p), "check" if "_mm_" in p.name else "tune") for p in hdm[1::4 if not quick else 1]]
        out += [("xsens", str(p), "check") for p in cmu]
        out += [("unity", str(p), "check" if "_mm_" in p.name else "tune") for p in hdm[3::4 if not quick else 1]]
        out += [("unity", str(p), "check") for p in cmu]
        out += [("unnamed", str(p), "check" if "_mm_" in p.name else "tune") for p in hdm[1::8 if not quick else 1]]
        out += [("unnamed", str(p), "check") for p in cmu]
        out += [("unreal", str(t.path), "tune" if t.dataset == 1 else "check") for t in pick[::10]]
        out += [("lafan", str(p), "check" if "_mm_" in p.name else "tune") for p in hdm[5::8 if not quick else 1]]
        out += [("lafan", str(p), "check") for p in cmu]
    if low_rate:
        out += [("hdm05_30fps", str(p), "check" if "_mm_" in p.name else "tune") for p in hdm[::4 if not quick else 1]]
        out += [("cmu_asfamc_30fps", str(p), "check") for p in cmu]
        out += [("cmu_bvh_30fps", str(p), "check") for p in bvh]
    return [(*item, item[0] if item[0] in RESPELLED or item[0] in LOW_RATE else "") for item in out]


def measure(item: tuple[str, str, str, str], fps: float | None = None) -> dict:
    """Clean one take with the defaults (resampled to ``fps`` first where it is over it); its changed cells, per
    step, and the level-only noise baseline."""
    import warnings

    warnings.simplefilter("ignore")
    import mocapkit
    from mocapkit.cleaning.pipeline import NOISE_DEG, noise_level

    coll, path, split, spelling = item
    p = Path(path)
    m = respell(mocapkit.load(p), spelling)  # an AMC finds its ASF beside it (io.asfamc.find_asf)
    if fps is not None and m.fps > fps:
        m = m.resample(fps)
    t = time.perf_counter()
    res = mocapkit.clean(m)  # the defaults of `mocapkit clean`: the bundled context where it fits
    secs = time.perf_counter() - t
    a, b = m.rotations, res.motion.rotations
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    changed = ~np.all(same, axis=-1)
    pa, pb = m.root_positions, res.motion.root_positions
    changed[:, 0] |= ~np.all((pa == pb) | (np.isnan(pa) & np.isnan(pb)), axis=-1)
    ta, tb = m.translations, res.motion.translations  # position channels below the root (lafan): theirs too
    if ta is not None:
        changed[:, 1:] |= ~np.all((ta == tb) | (np.isnan(ta) & np.isnan(tb)), axis=-1)[:, 1:] if tb is not None else True
    sk = m.skeleton
    dofs = np.array([j > 0 and bool(sk.rotation_order(j)) for j in range(sk.num_joints)])
    level_only = int(((np.nan_to_num(noise_level(m)) > NOISE_DEG) & dofs[None, :]).sum())
    from mocapkit import rotations as R

    step = np.degrees(R.geodesic_angle(a[1:], a[:-1])) if m.num_frames > 1 else np.zeros((0, m.num_joints))
    glitching = np.nan_to_num(step).max(axis=0, initial=0.0) > GLITCH_DEG  # (J,) a one-frame turn no limb makes
    calib = [str(c) for c in getattr(res, "calibration", ()) or ()]
    from scipy import ndimage

    per_frame = GLITCH_DEG_S / m.fps
    runs, at_glitch = [], 0
    for j in np.flatnonzero(changed.any(axis=0)):
        labels, _ = ndimage.label(changed[:, j])
        for (sl,) in ndimage.find_objects(labels):
            lo, hi = sl.start, sl.stop
            near = np.nan_to_num(step[max(lo - 2, 0) : hi + 2, j]).max(initial=0.0)  # turns f -> f + 1 within 2 frames
            at_glitch += (hi - lo) * bool(near > per_frame)
            runs.append(dict(joint=sk.joint_names[j], frames=[int(lo), int(hi - 1)], largest_turn_deg=round(float(near), 1)))
    runs.sort(key=lambda r: r["frames"][1] - r["frames"][0], reverse=True)
    context = next((n for n in res.notes if "context" in n), "")
    return dict(collection=coll, take=p.name, split=split, frames=m.num_frames, joints=m.num_joints, fps=float(m.fps),
                cells=int(changed.size), changed=int(changed.sum()), filled=int(res.filled.sum()),
                repaired=int(res.repaired.sum()), denoised=int(res.denoised.sum()), level_only=level_only,
                on_glitching=int(changed[:, glitching].sum()), at_glitch=int(at_glitch), runs=runs[:12],
                seconds=round(secs, 3), calibration=calib, context_note=context)


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--bandai", type=int, default=520, help="Bandai Namco takes in the stratified sample (default 520)")
    ap.add_argument("--all", action="store_true", help="every Bandai Namco take (2,675)")
    ap.add_argument("--workers", type=int, default=2, help="local processes (default 2)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="a few takes per collection (a smoke run)")
    ap.add_argument("--no-respelled", dest="respelled", action="store_false",
                    help=f"leave out the collections of takes respelled on other rigs ({', '.join(RESPELLED)})")
    ap.add_argument("--no-low-rate", dest="low_rate", action="store_false",
                    help=f"leave out the 120 fps takes at 30 fps ({', '.join(LOW_RATE)})")
    ap.add_argument("--fps", type=float, default=None,
                    help="resample every take over this rate to it first (mocapkit convert --fps)")
    args = ap.parse_args()

    items = takes(args.bandai, args.all, args.seed, args.quick, args.respelled, args.low_rate)
    log(f"{len(items)} takes, {args.workers} workers")
    rows, t0 = [], time.perf_counter()
    with ProcessPoolExecutor(max_workers=max(1, args.workers)) as ex:
        futs = {ex.submit(measure, it, args.fps): it for it in items}
        for i, f in enumerate(as_completed(futs), 1):
            r = f.result()
            rows.append(r)
            share = r["changed"] / r["cells"]
            if i % 20 == 0 or share > TARGET_TAKE or i == len(items):
                log(f"[{i}/{len(items)}] {time.perf_counter() - t0:6.0f} s  {r['collection']}/{r['take']}: "
                    f"{100 * share:.3f} % changed (repair {r['repaired']}, denoise {r['denoised']})")
    rows.sort(key=lambda r: (r["collection"], r["take"]))

    def table(sel):
        out = {}
        for c in sorted({r["collection"] for r in sel}):
            rs = [r for r in sel if r["collection"] == c]
            cells = sum(r["cells"] for r in rs)
            worst = max(rs, key=lambda r: r["changed"] / r["cells"])
            out[c] = dict(takes=len(rs), frames=sum(r["frames"] for r in rs), cells=cells,
                          changed=sum(r["changed"] for r in rs), share=round(sum(r["changed"] for r in rs) / cells, 6),
                          filled=sum(r["filled"] for r in rs), repaired=sum(r["repaired"] for r in rs),
                          denoised=sum(r["denoised"] for r in rs),
                          on_glitching_joints=sum(r["on_glitching"] for r in rs),
                          at_glitch=sum(r["at_glitch"] for r in rs),
                          share_not_at_glitch=round(sum(r["changed"] - r["at_glitch"] for r in rs) / cells, 6),
                          level_only_share=round(sum(r["level_only"] for r in rs) / cells, 6),
                          worst_take=worst["take"], worst_share=round(worst["changed"] / worst["cells"], 6),
                          takes_over_1pct=sum(r["changed"] / r["cells"] > TARGET_TAKE for r in rs),
                          calibration_takes=sum(bool(r["calibration"]) for r in rs))
        return out

    per = table(rows)
    figures, baselines, targets = {}, {}, {}
    for c, t in per.items():
        figures[f"{c} changed share"] = t["share"]
        figures[f"{c} worst take share"] = t["worst_share"]
        baselines[f"{c} changed share"] = t["level_only_share"]
        targets[f"{c} changed share"] = {"value": TARGET_COLLECTION, "op": "<=", "of": "figures"}
        targets[f"{c} worst take share"] = {"value": TARGET_TAKE, "op": "<=", "of": "figures"}
    details = dict(
        per_collection=per,
        tune=table([r for r in rows if r["split"] == "tune"]),
        check=table([r for r in rows if r["split"] == "check"]),
        changed_takes=[{k: r[k] for k in ("collection", "take", "frames", "changed", "repaired", "denoised", "filled",
                                          "on_glitching", "at_glitch", "runs")}
                       for r in rows if r["changed"]],
        calibration=[{"take": r["take"], "poses": r["calibration"]} for r in rows if r["calibration"]],
        bandai="all" if args.all else f"stratified sample of {sum(r['collection'] == 'bandai' for r in rows)}, seed {args.seed}",
        quick=args.quick,
        fps=args.fps,
        seconds=round(time.perf_counter() - t0, 1),
        baseline="share of cells the level-only noise rule (residual > 1 deg, no direction test) calls noisy",
    )
    name = "clean_untouched_all" if args.all else "clean_untouched"  # the whole Bandai set keeps its own result file
    if args.fps is not None:
        name += f"_{args.fps:g}fps"
    harness.emit(name, args, figures=figures, baselines=baselines, targets=targets, details=details)


if __name__ == "__main__":
    main()
