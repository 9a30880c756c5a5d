"""The shipped networks on another spelling of their skeleton: CMU 01_01 as ASF/AMC and as the MotionBuilder-release BVH.

Usage::

    python benchmarks/deep_rigs.py [--seeds 3] [--frames N] [--json]

CMU 01_01 is the one take of ``../shared/data`` in both spellings (``cmu_asfamc/01_01.amc`` and
``cmu_bvh/01_01.bvh``, whose frame 0 is the converter's T-pose). It is one of the shipped models'
training takes: this compares the spellings (``cleaning.deep.served_by`` and its joint map), not
how the networks generalise (``deep_denoise`` and ``deep_gapfill`` do that on held-out clips). Every denoise is
the network's own output (``deep.denoise(..., guard=False)``), as in ``deep_denoise``.

* ``channels_max_diff_deg``: the largest difference between the channels the network reads from the
  BVH (through the joint map) and from the AMC;
* ``same_noise_*``: 0.5 angular noise drawn on the AMC's channels, the same noisy rotations written
  in both spellings, denoised: joint-angle RMS (geodesic, degrees, non-root joints) against the
  clean take; the BVH's must equal the ASF's (target ratio <= 1.02);
* ``own_noise_bvh``: 0.5 noise drawn on the BVH's own three channels per joint (partly outside
  the Acclaim degrees of freedom), denoised through the joint map, against the Savitzky-Golay
  fallback (0.1 s, quadratic) that a rig the networks do not serve gets (baseline, same run);
* ``fill_*``: the same gaps (``corrupt.gaps`` defaults) in both spellings, filled by EBD + EBF:
  RMS on the filled cells (target ratio <= 1.02).

Rigs on another rest pose or with fewer joints (``served_by`` retargets them, module docstring of
``cleaning.deep.retarget``), each against the fallback it got before (Savitzky-Golay, 0.1 s, quadratic:
the baseline, same run), 0.5 noise on the rig's own channels, ``--seeds`` draws:

* ``retarget_3dsmax_body``: the CMU 3dsMax-friendly BVH takes (``cmu_bvh/131_0*.bvh``, arms hanging
  down at rest, 10 bones retargeted), RMS over every joint but the thumbs; ``retarget_3dsmax_thumbs``
  the thumbs alone (their rest twist is not the Acclaim one, and the takes' thumbs flip by 150 deg
  within a frame, which any filter smears);
* ``retarget_mixamo``: CMU 01_01's BVH under Mixamo's names (no middle spine, no palms: held at the
  model's means; the spine's lower two segments read as one), the noise on the joints a Mixamo rig
  has, against the same noisy take through the MotionBuilder-release map (the ratio to that, target
  <= 1.1) and the fallback (in ``details``);
* ``retarget_smpl``: CMU 01_01's BVH on SMPL's rig (``tests/shared.smpl_spelling``: 24 joints named ``Pelvis``,
  ``L_Hip`` ..., no hip bones, upper neck, fingers or thumbs; the dropped joints' turns joined to their children's);
* ``retarget_daz``: the same take as cgspeed's Daz-friendly release spells it (``tests/shared.daz_spelling``:
  ``hip``, ``abdomen``, ``lButtock``, ``lThigh``, ``lShldr`` ...; no middle spine, upper neck, toes or palms);
* ``retarget_xsens``: the same take on Xsens MVN's BVH rig (``tests/shared.xsens_spelling``: ``Hips``, ``Chest``,
  ``Chest2``, ``Chest4``, ``LeftHip``, ``LeftCollar``, ``LeftShoulder`` ...; no hip bones, upper neck, palms or
  fingers); ``details`` also gives the same take read as before the ``xsens_mvn`` family, by the 3dsMax
  conversion's names (the chest then ``Chest2``, the thorax ``Chest4`` no role): ``retarget_xsens_as_3dsmax``;
* ``retarget_unity``: the same take on Unity's humanoid avatar (``tests/shared.unity_spelling``: ``Hips``,
  ``Spine``, ``Chest``, ``UpperChest``, ``LeftShoulder`` the clavicle, ``LeftUpperArm``, ``LeftUpperLeg``,
  ``LeftToes``, ``LeftIndexProximal`` ...; no hip bones, upper neck or palms);
* ``retarget_unnamed``: CMU 01_01's BVH with its joints renamed ``bone0``, ``bone1``, ... (``tests/shared.unnamed``:
  no family, no sides in the names), served through the roles its tree and rest pose show
  (``rigs.roles_by_topology``); before, such a rig got the fallback (the baseline); ``details`` gives the same
  noisy take through the MotionBuilder release's named map (``retarget_unnamed_named``);
* ``retarget_pybvh``: another project's clip (VictorS-67/pybvh, HumanIK names, Z up: its body frame
  turned; no hands below the wrist), 30 fps;
* ``retarget_biovision``: another project's take (20tab/bvh-python ``test_mocapbank.bvh``, 455 frames at
  30 fps: ``Hips, Chest, Chest2, Neck, Head``, limbs to the wrists; its missing lower back and lower
  neck share the turns of the segments below them);
* ``retarget_bandai``: Bandai Namco takes through the Acclaim networks' joint map (``--model
  ebf.pt``; body frame turned, 27 bones retargeted, 8 joints held), beside the rig's own EBF
  (``details``), every 400th take of the set when it is unpacked (``benchmarks/_bandai.py``);
  ``retarget_unreal`` the same takes under Unreal Engine mannequin names (``root``, ``pelvis``, ``spine_01``,
  ``thigh_l`` ...; ``tests/shared.unreal_spelling``), which get the Acclaim networks by default (the Bandai rig's
  own model, CC BY-NC, serves that rig's own names only).

``details.rigs`` lists the decision of ``served_by`` for every BVH and ASF rig in ``../shared/data``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import sys
import time
from pathlib import Path
from types import MappingProxyType

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO / "benchmarks"))
sys.path.insert(0, str(REPO))

import _harness as harness  # noqa: E402

import mocapkit  # noqa: E402
from mocapkit import corrupt, rigs  # noqa: E402
from mocapkit import rotations as R  # noqa: E402
from mocapkit.cleaning import deep  # noqa: E402
from mocapkit.cleaning.deep import channels as ch  # noqa: E402
from mocapkit.cleaning.deep import retarget  # noqa: E402
from mocapkit.cleaning.filters import savgol_smooth  # noqa: E402
from mocapkit.motion import Motion  # noqa: E402
from tests.shared import (daz_spelling, smpl_spelling, unity_spelling, unnamed, unreal_spelling,  # noqa: E402
                          xsens_spelling)

DATA = REPO.parent / "shared" / "data"


def rms(ref: Motion, m: Motion, cells=None) -> float:
    d = np.degrees(R.geodesic_angle(ref.rotations[:, 1:], m.rotations[:, 1:]))
    return float(np.sqrt(np.mean(d[cells[:, 1:]] ** 2 if cells is not None else d ** 2)))


def spelled(bvh: Motion, like: Motion) -> Motion:
    return Motion(bvh.skeleton, like.rotations, bvh.root_positions, bvh.fps, bvh.name)


def mixamo_spelling(bvh: Motion) -> Motion:
    """A MotionBuilder-release CMU BVH under Mixamo's names (tests/cleaning/test_retarget.py does the same)."""
    hik = {"LFingers": "LeftHandIndex1", "RFingers": "RightHandIndex1", "LThumb": "LeftHandThumb1",
           "RThumb": "RightHandThumb1"}
    sk = bvh.skeleton
    names = tuple("mixamorig:" + hik.get(n, n) for n in sk.joint_names)
    mix = dataclasses.replace(sk, joint_names=names)
    return dataclasses.replace(bvh, skeleton=mix)


@contextlib.contextmanager
def _families(table):
    """``rigs.FAMILIES`` replaced by ``table`` for the block (a figure of the rig tables as they were)."""
    saved = rigs.FAMILIES
    rigs.FAMILIES = MappingProxyType(table)
    try:
        yield
    finally:
        rigs.FAMILIES = saved


def retargeted(ebf, seeds: int) -> tuple[dict, dict, dict]:
    """The retargeted rigs' figures, baselines and details (module docstring)."""
    rows: dict[str, list] = {}

    def add(key, value):
        rows.setdefault(key, []).append(value)

    def versus_fallback(name, take, cells=None, model=None, joints=None):
        for seed in range(seeds):
            noisy, _ = corrupt.angular_noise(take, 0.5, seed=seed, joints=joints)
            add(f"{name}_input", rms(take, noisy, cells))
            add(name, rms(take, deep.denoise(noisy, model, guard=False), cells))
            add(f"{name}_fallback", rms(take, savgol_smooth(noisy, window_s=0.1, polyorder=2, root=False), cells))

    three = [mocapkit.load(p) for p in sorted((DATA / "cmu_bvh").glob("131_0*.bvh"))]
    for take in three:
        thumbs = np.zeros((take.num_frames, take.num_joints), dtype=bool)
        thumbs[:, [take.skeleton.index(n) for n in ("LThumb", "RThumb")]] = True
        versus_fallback("retarget_3dsmax_body", take, ~thumbs)
        versus_fallback("retarget_3dsmax_thumbs", take, thumbs)
    bvh = mocapkit.load(DATA / "cmu_bvh" / "01_01.bvh")[1:]
    mix = mixamo_spelling(bvh)
    own = sorted(rigs.roles(mix.skeleton).values())  # the joints a Mixamo rig has (not LowerBack, LHipJoint ...)
    names = [mix.skeleton.joint_names[j] for j in own if j > 0]
    versus_fallback("retarget_mixamo", mix, joints=names)
    for seed in range(seeds):
        noisy, _ = corrupt.angular_noise(mix, 0.5, seed=seed, joints=names)
        add("retarget_mixamo_mb", rms(bvh, deep.denoise(dataclasses.replace(noisy, skeleton=bvh.skeleton), guard=False)))
    smpl = smpl_spelling(bvh)
    versus_fallback("retarget_smpl", smpl)
    daz = daz_spelling(bvh)
    versus_fallback("retarget_daz", daz)
    xsens = xsens_spelling(bvh)
    versus_fallback("retarget_xsens", xsens)
    before = dict(rigs.FAMILIES)  # the same take as the 3dsMax conversion's names read it before the xsens_mvn family
    del before["xsens_mvn"]
    with _families(before):
        versus_fallback("retarget_xsens_as_3dsmax", xsens)
    unity = unity_spelling(bvh)
    versus_fallback("retarget_unity", unity)
    odd = unnamed(bvh)
    versus_fallback("retarget_unnamed", odd)
    for seed in range(seeds):
        noisy, _ = corrupt.angular_noise(odd, 0.5, seed=seed)
        add("retarget_unnamed_named", rms(bvh, deep.denoise(dataclasses.replace(noisy, skeleton=bvh.skeleton), guard=False)))
    versus_fallback("retarget_pybvh", mocapkit.load(REPO / "tests" / "data" / "pybvh_test1_zup.bvh"))
    versus_fallback("retarget_biovision", mocapkit.load(DATA / "peer_files" / "20tab+bvh-python" / "tests" /
                                                        "test_mocapbank.bvh"))
    from _bandai import bandai_takes

    try:
        bandai = [mocapkit.load(t.path) for t in bandai_takes()[::400]]
    except (FileNotFoundError, SystemExit):
        bandai = []
    for take in bandai:
        versus_fallback("retarget_bandai", take, model=ebf)
        for seed in range(seeds):
            noisy, _ = corrupt.angular_noise(take, 0.5, seed=seed)
            add("retarget_bandai_own", rms(take, deep.denoise(noisy, guard=False)))
        versus_fallback("retarget_unreal", unreal_spelling(take))
    mean = {k: float(np.mean(v)) for k, v in rows.items()}
    names = ["retarget_3dsmax_body", "retarget_3dsmax_thumbs", "retarget_mixamo", "retarget_smpl", "retarget_daz",
             "retarget_xsens", "retarget_unity", "retarget_unnamed", "retarget_pybvh", "retarget_biovision"]
    names += ["retarget_bandai", "retarget_unreal"] if bandai else []
    figures = {n: mean[n] for n in names}
    baselines = {n: mean[f"{n}_fallback"] for n in names}
    baselines["retarget_mixamo"] = mean["retarget_mixamo_mb"]
    details = {"retarget_means": mean, "retarget_takes": {
        "3dsmax": [t.name for t in three], "mixamo": "CMU 01_01 (BVH) renamed",
        "smpl": "CMU 01_01 (BVH) on SMPL's 24 joints and names", "daz": "CMU 01_01 (BVH) as the Daz-friendly release",
        "xsens": "CMU 01_01 (BVH) on Xsens MVN's 22 joints and names",
        "unity": "CMU 01_01 (BVH) on Unity's humanoid avatar (26 joints)",
        "unnamed": "CMU 01_01 (BVH), joints renamed bone0, bone1, ...",
        "pybvh": "pybvh_test1_zup",
        "bandai": [t.name for t in bandai], "unreal": "the Bandai takes under Unreal mannequin names"},
        "retarget_serving": {"3dsmax": deep.served_by(three[0], ebf).describe(),
                             "mixamo": deep.served_by(mix, ebf).describe(),
                             "smpl": deep.served_by(smpl, ebf).describe(),
                             "daz": deep.served_by(daz, ebf).describe(),
                             "xsens": deep.served_by(xsens, ebf).describe(),
                             "unity": deep.served_by(unity, ebf).describe(),
                             "unnamed": deep.served_by(odd, ebf).describe(),
                             "unreal": deep.served_by(unreal_spelling(bandai[0]), ebf).describe() if bandai else None,
                             "bandai": deep.served_by(bandai[0], ebf).describe() if bandai else None}}
    return figures, baselines, details


def rig_decisions(ebf) -> dict:
    out = {}
    files = sorted(DATA.glob("*/*.bvh")) + sorted(DATA.glob("*/*.asf"))
    for p in files:
        sk = mocapkit.io.asfamc.read_asf(p) if p.suffix == ".asf" else mocapkit.load(p).skeleton
        s = deep.served_by(sk, ebf)
        out[str(p.relative_to(DATA))] = s if isinstance(s, str) else ("directly" if s.direct else s.describe())
    return out


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=None, help="first N frames only (default: the whole take)")
    args = ap.parse_args()
    if not DATA.is_dir():
        sys.exit(f"{DATA}: not found (this benchmark needs ../shared/data)")
    asf = mocapkit.load(DATA / "cmu_asfamc" / "01_01.amc", asf=DATA / "cmu_asfamc" / "01.asf")
    bvh = mocapkit.load(DATA / "cmu_bvh" / "01_01.bvh")[1:]
    n = min(asf.num_frames, bvh.num_frames, args.frames or asf.num_frames)
    asf, bvh = asf[:n], bvh[:n]
    ebf = deep.shipped_model("ebf")
    serving = deep.served_by(bvh, ebf)
    assert isinstance(serving, deep.Serving) and not serving.direct, serving
    diff = float(np.abs(retarget.encode(bvh, serving)[0] - ch.encode(asf, ebf.layout)[0]).max())
    rows = {k: [] for k in ("noisy", "asf", "bvh", "own_noisy", "own_bvh", "own_savgol", "fill_asf", "fill_bvh")}
    t0 = time.perf_counter()
    for seed in range(args.seeds):
        noisy, _ = corrupt.angular_noise(asf, 0.5, seed=seed)
        rows["noisy"].append(rms(asf, noisy))
        rows["asf"].append(rms(asf, deep.denoise(noisy, guard=False)))
        rows["bvh"].append(rms(bvh, deep.denoise(spelled(bvh, noisy), guard=False)))
        own, _ = corrupt.angular_noise(bvh, 0.5, seed=seed)
        rows["own_noisy"].append(rms(bvh, own))
        rows["own_bvh"].append(rms(bvh, deep.denoise(own, guard=False)))
        rows["own_savgol"].append(rms(bvh, savgol_smooth(own, window_s=0.1, polyorder=2, root=False)))
        gapped, _ = corrupt.gaps(asf, seed=seed)
        miss = gapped.missing()
        rows["fill_asf"].append(rms(asf, deep.fill_gaps(gapped), miss))
        rows["fill_bvh"].append(rms(bvh, deep.fill_gaps(spelled(bvh, gapped)), miss))
    mean = {k: float(np.mean(v)) for k, v in rows.items()}
    figures = {
        "channels_max_diff_deg": diff,
        "same_noise_input": mean["noisy"],
        "same_noise_bvh": mean["bvh"],
        "own_noise_input": mean["own_noisy"],
        "own_noise_bvh": mean["own_bvh"],
        "fill_bvh": mean["fill_bvh"],
    }
    baselines = {"same_noise_bvh": mean["asf"], "own_noise_bvh": mean["own_savgol"], "fill_bvh": mean["fill_asf"]}
    targets = {
        "channels_max_diff_deg": {"value": 1e-3, "op": "<=", "of": "figures"},
        "same_noise_bvh": {"value": 1.02, "op": "<=", "of": "ratios"},
        "own_noise_bvh": {"value": 1.0, "op": "<=", "of": "ratios"},
        "fill_bvh": {"value": 1.02, "op": "<=", "of": "ratios"},
    }
    r_fig, r_base, r_det = retargeted(ebf, args.seeds)
    figures.update(r_fig)
    baselines.update(r_base)
    targets.update({n: {"value": 1.0, "op": "<=", "of": "ratios"} for n in r_fig if n != "retarget_mixamo"})
    targets["retarget_mixamo"] = {"value": 1.1, "op": "<=", "of": "ratios"}
    details = {
        **r_det,
        "take": "CMU 01_01 (training take of the shipped models)", "frames": n, "seeds": args.seeds,
        "serving": serving.describe(), "per_seed": rows, "seconds": round(time.perf_counter() - t0, 1),
        "baselines_are": {"same_noise_bvh": "the ASF spelling, same noisy rotations",
                          "own_noise_bvh": "Savitzky-Golay 0.1 s (the fallback)",
                          "fill_bvh": "the ASF spelling, same gaps",
                          "retarget_*": "Savitzky-Golay 0.1 s (the fallback those rigs got before)",
                          "retarget_mixamo": "the same noisy take through the MotionBuilder-release map"},
        "rigs": rig_decisions(ebf),
    }
    harness.emit("deep_rigs", args, figures=figures, baselines=baselines, targets=targets, details=details)


if __name__ == "__main__":
    main()
