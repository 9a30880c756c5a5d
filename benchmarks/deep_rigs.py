"""The shipped networks on another spelling of their skeleton: CMU 01_01 as ASF/AMC and as the MotionBuilder-release BVH.

Usage::

    python benchmarks/deep_rigs.py [--seeds 3] [--frames N] [--json]

CMU 01_01 is the one take of ``../shared/data`` in both spellings (``cmu_asfamc/01_01.amc`` and
``cmu_bvh/01_01.bvh``, whose frame 0 is the converter's T-pose). It is one of the shipped models'
training takes: this compares the spellings (``cleaning.deep.served_by`` and its joint map), not
how the networks generalise (``deep_denoise`` and ``deep_gapfill`` do that on held-out clips).

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

``details.rigs`` lists the decision of ``served_by`` for every BVH and ASF rig in ``../shared/data``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO / "benchmarks"))

import _harness as harness  # noqa: E402

import mocapkit  # noqa: E402
from mocapkit import corrupt  # noqa: E402
from mocapkit import rotations as R  # noqa: E402
from mocapkit.cleaning import deep  # noqa: E402
from mocapkit.cleaning.deep import channels as ch  # noqa: E402
from mocapkit.cleaning.deep import retarget  # noqa: E402
from mocapkit.cleaning.filters import savgol_smooth  # noqa: E402
from mocapkit.motion import Motion  # noqa: E402

DATA = REPO.parent / "shared" / "data"


def rms(ref: Motion, m: Motion, cells=None) -> float:
    d = np.degrees(R.geodesic_angle(ref.rotations[:, 1:], m.rotations[:, 1:]))
    return float(np.sqrt(np.mean(d[cells[:, 1:]] ** 2 if cells is not None else d ** 2)))


def spelled(bvh: Motion, like: Motion) -> Motion:
    return Motion(bvh.skeleton, like.rotations, bvh.root_positions, bvh.fps, bvh.name)


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
        rows["asf"].append(rms(asf, deep.denoise(noisy)))
        rows["bvh"].append(rms(bvh, deep.denoise(spelled(bvh, noisy))))
        own, _ = corrupt.angular_noise(bvh, 0.5, seed=seed)
        rows["own_noisy"].append(rms(bvh, own))
        rows["own_bvh"].append(rms(bvh, deep.denoise(own)))
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
    details = {
        "take": "CMU 01_01 (training take of the shipped models)", "frames": n, "seeds": args.seeds,
        "serving": serving.describe(), "per_seed": rows, "seconds": round(time.perf_counter() - t0, 1),
        "baselines_are": {"same_noise_bvh": "the ASF spelling, same noisy rotations",
                          "own_noise_bvh": "Savitzky-Golay 0.1 s (the fallback)",
                          "fill_bvh": "the ASF spelling, same gaps"},
        "rigs": rig_decisions(ebf),
    }
    harness.emit("deep_rigs", args, figures=figures, baselines=baselines, targets=targets, details=details)


if __name__ == "__main__":
    main()
