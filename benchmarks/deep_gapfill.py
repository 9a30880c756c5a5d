"""Gap filling with noise: the shipped fills against lerp+Gaussian, lerp+EBF and spline fills (Mall et al. 2017, 4.2).

Usage::

    python benchmarks/deep_gapfill.py [--seeds 5] [--quick] [--ebf MODEL.pt] [--json]

Held-out clips (``_deep.test_clips``, never trained on), 0.5 angular noise, then three
gap settings, each ``--seeds`` times per clip:

* ``ordinary``: whole joints missing (``corrupt.gaps`` defaults: geometric lengths,
  mean 0.25 s, up to 2 s, about 2.5 % of every joint), the occlusion pattern of a
  marker that drops out;
* ``long``: one gap of 1-4 s (uniform; cut to the clip less 0.25 s each side) in one
  joint-angle channel with at least 5 degrees of motion, three channels per clip and
  seed, one at a time (Mall's Fig. 10). Clips shorter than 1.5 s are skipped.
* ``long_joint``: the same gaps in every channel of the chosen channel's joint (a whole
  joint lost for 1-4 s, as a marker cluster occluded; the issue's target setting).

Fills, each followed by the denoising a user would run on the completed take:

* ``lerp+gauss``: linear interpolation, then a 58 ms Gaussian (Mall's baseline);
* ``lerp+ebf``: linear interpolation, then the shipped EBF;
* ``ebd+ebf``: the shipped EBD network on the gap entries, then the EBF on the whole take
  (``deep.fill_channels(..., smooth=False, method="ebd")`` then ``deep.denoise_channels``:
  Mall's pipeline);
* ``prior+ebf``: the shipped EBD model's Gaussian gap prior (each gap filled as a whole by the
  conditional mean of its Gaussian field, :mod:`mocapkit.cleaning.deep.prior`; at these clips'
  120 fps it reads the observed channels through its 58 ms Gaussian: ``deep.EBF_READ_MAX_FPS``),
  as ``fill`` and ``clean`` run it (``deep.fill_channels(..., ebf, smooth=True)``: at 120 fps the
  EBF takes no part in it), then the EBF on the whole take; ``prior_gauss_read+ebf`` the same
  with ``smooth=False`` (the same fill at this rate; the row is kept for its Bandai twin in
  ``deep_rigs_bandai.py``);
* ``cubic+gauss`` / ``quintic+gauss``: interpolating cubic / quintic (Woltring-style)
  splines over the Vicon Nexus window (``cleaning.gapfill``), then the 58 ms Gaussian;
* ``cubic`` / ``quintic`` / ``lerp``: the fills alone, the noisy observed samples
  left as they are (what a gap fill in Nexus or the ``gapfill`` package returns);
* ``words+ebf``: the shipped fill (``prior``'s, ``smooth=True``), then every gap event of at least 0.5 s
  refilled from the take's own motion words (Aristidou et al. 2018, section 4: each gap frame's word of
  the observed channels, the median of its 4 nearest words' missing channels among the take's frames where
  they are observed, offset to meet the gap's ends; :mod:`_self_similarity`), then the EBF on the whole take;
  ``prior_words+ebf`` the same words blended with the prior's fill by how near they are
  (``exp(-(d / 0.5)^2)``, ``d`` the words' RMS distance in standard deviations): self-similarity where the
  take repeats, the prior's conditional mean where it does not. ``cpu_s`` gives the CPU seconds per
  gapped take of the shipped fill and of the words step;
* ``knn+gauss`` (long gaps only): a database lookup in the spirit of Krueger et al. 2010,
  to see how much the other channels say about the missing one: each gap frame's other
  channels (58 ms Gaussian of the noisy take) are looked up among the training clips'
  frames (every second frame, channels scaled by their std), the missing channel
  is the mean of the 8 nearest, offset linearly to meet the gap's ends, then the 58 ms
  Gaussian. The EBD is a learnt version of the same question.

Errors in degrees (wrapped differences) against the clean clip: ``all`` = RMS over
every channel and frame (Mall's Fig. 9), ``gap`` = RMS over the missing entries only.
Averaged over (clip, seed[, channel]) runs. Target: on the long gaps, the shipped fill's
gap RMS at least 40 % below lerp+gauss's (ratio <= 0.60), whole joints and single
channels; the network's own row (``ebd+ebf``) is reported beside it.
"""

from __future__ import annotations

import time

import numpy as np

import _deep  # noqa: F401
import _harness as harness
from _deep import gaussian, test_clips, wrapped_rms
from _self_similarity import self_similar_fill

import mocapkit  # noqa: E402
from mocapkit import corrupt  # noqa: E402
from mocapkit.cleaning import deep, gapfill  # noqa: E402
from mocapkit.cleaning.deep.channels import encode  # noqa: E402

METHODS = ("lerp+gauss", "lerp+ebf", "ebd+ebf", "prior+ebf", "prior_gauss_read+ebf", "cubic+gauss", "quintic+gauss",
           "lerp", "cubic", "quintic", "ebd", "prior", "words+ebf", "prior_words+ebf")
LONG_METHODS = METHODS + ("knn+gauss",)
SIGMA = 0.058
KNN = 8


class PoseDatabase:
    """The training clips' joint-angle channels (every second frame), searched by brute force.

    (55 dimensions are too many for a kd-tree to prune: a matrix product is faster.)
    """

    def __init__(self, layout):
        import train_shipped

        train, _, _ = train_shipped.split(train_shipped.corpus())
        self.frames = np.concatenate([encode(mocapkit.load(p), layout)[0][::2] for p in train])
        self.scale = self.frames.std(axis=0) + 1.0
        self.scaled = self.frames / self.scale
        self.norms = np.sum(self.scaled**2, axis=1)
        self.clips = len(train)

    def fill(self, smooth: np.ndarray, c: int, s: int, e: int) -> np.ndarray:
        """Channel ``c`` over frames ``s:e`` from the frames whose other channels are nearest to ``smooth``'s."""
        q = smooth[s:e] / self.scale
        q[:, c] = 0.0
        # squared distances over the other channels: |q|^2 - 2 q.x + |x|^2 with channel c left out
        d2 = (self.norms - self.scaled[:, c] ** 2)[None, :] - 2.0 * q @ self.scaled.T
        idx = np.argpartition(d2, KNN, axis=1)[:, :KNN]
        pred = self.frames[idx, c].mean(axis=1)
        w = np.linspace(0.0, 1.0, e - s)
        return pred + (1.0 - w) * (smooth[s - 1, c] - pred[0]) + w * (smooth[e, c] - pred[-1])


def run_methods(x_gapped, ctx, fps, ebf, ebd, cpu: dict | None = None) -> dict:
    """Every method's completed (F, C) channels for one gapped noisy take; ``cpu``: CPU seconds of the shipped fill
    (``prior``) and of the words step (``words``) added to it."""
    lerp = deep.lerp_fill(x_gapped)
    cubic = gapfill.fill_channels(x_gapped, "cubic", fps)
    quintic = gapfill.fill_channels(x_gapped, "quintic", fps)
    ebd_only = deep.fill_channels(x_gapped, ctx, ebd, smooth=False, fps=fps, method="ebd")
    prior_gauss = deep.fill_channels(x_gapped, ctx, ebd, smooth=False, fps=fps, method="prior")
    t0 = time.process_time()
    prior_fill = deep.fill_channels(x_gapped, ctx, ebd, ebf, fps=fps, smooth=True, method="prior")
    t1 = time.process_time()
    miss = np.isnan(x_gapped)
    blended = self_similar_fill(prior_fill, miss, fps)
    t2 = time.process_time()
    words = self_similar_fill(prior_fill, miss, fps, d0=None)
    if cpu is not None:
        cpu["prior"] = cpu.get("prior", 0.0) + t1 - t0
        cpu["words"] = cpu.get("words", 0.0) + t2 - t1
        cpu["fills"] = cpu.get("fills", 0) + 1
    return {
        "lerp": lerp, "cubic": cubic, "quintic": quintic, "ebd": ebd_only, "prior": prior_gauss,
        "lerp+gauss": gaussian(lerp, SIGMA, fps),
        "lerp+ebf": deep.denoise_channels(lerp, ctx, ebf, fps=fps),
        "ebd+ebf": deep.denoise_channels(ebd_only, ctx, ebf, fps=fps),
        "prior+ebf": deep.denoise_channels(prior_fill, ctx, ebf, fps=fps),
        "prior_gauss_read+ebf": deep.denoise_channels(prior_gauss, ctx, ebf, fps=fps),
        "words+ebf": deep.denoise_channels(words, ctx, ebf, fps=fps),
        "prior_words+ebf": deep.denoise_channels(blended, ctx, ebf, fps=fps),
        "cubic+gauss": gaussian(cubic, SIGMA, fps),
        "quintic+gauss": gaussian(quintic, SIGMA, fps),
    }


def main(argv=None) -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--ebf", default=None, help="an EBF model file to use instead of the shipped one")
    a = ap.parse_args(argv)
    ebf = deep.load_model(a.ebf) if a.ebf else deep.shipped_model("ebf")
    ebd = deep.shipped_model("ebd")
    clips = test_clips(a.quick)
    settings = ("ordinary", "long", "long_joint")
    res = {s: {m: {"all": [], "gap": []} for m in (LONG_METHODS if s == "long" else METHODS)} for s in settings}
    joint_of = np.array([n.split(".")[0] for n in ebd.layout.names])
    database = PoseDatabase(ebf.layout)
    long_lengths: list[float] = []
    missing_share: list[float] = []
    t0 = time.perf_counter()
    from tqdm import tqdm

    cpu: dict = {}
    for path in tqdm(clips, desc="clips", disable=a.json):
        cpu[path.name] = {}
        clean = mocapkit.load(path)
        fps = clean.fps
        y, _ = encode(clean, ebf.layout)
        for seed in range(a.seeds):
            rng = np.random.default_rng([seed, 5, len(path.name)])
            noisy = corrupt.angular_noise(clean, 0.5, seed=(seed, 21))[0]
            # ordinary: whole joints missing
            gapped, _ = corrupt.gaps(noisy, seed=(seed, 22))
            x, ctx = encode(gapped, ebf.layout)
            miss = np.isnan(x)
            if miss.any() and not miss.all(axis=0).any():
                missing_share.append(float(miss.mean()))
                for m, out in run_methods(x, ctx, fps, ebf, ebd, cpu[path.name]).items():
                    res["ordinary"][m]["all"].append(wrapped_rms(out, y))
                    res["ordinary"][m]["gap"].append(wrapped_rms(out, y, miss))
            # long: one channel at a time
            F = len(y)
            margin = int(round(0.25 * fps))
            if F < int(1.5 * fps):
                continue
            xn, ctx = encode(noisy, ebf.layout)
            moving = np.flatnonzero(np.std(y, axis=0) >= 5.0)
            for c in rng.choice(moving, size=min(3, len(moving)), replace=False):
                hi = min(int(4 * fps), F - 2 * margin)
                n = int(rng.integers(int(fps), hi + 1))
                s = int(rng.integers(margin, F - margin - n + 1))
                xg = xn.copy()
                xg[s : s + n, c] = np.nan
                mask = np.isnan(xg)
                long_lengths.append(n / fps)
                outs = run_methods(xg, ctx, fps, ebf, ebd, cpu[path.name])
                looked_up = outs["lerp+gauss"].copy()
                looked_up[s : s + n, c] = database.fill(outs["lerp+gauss"], int(c), s, s + n)
                outs["knn+gauss"] = gaussian(np.where(mask, looked_up, xg), SIGMA, fps)
                for m, out in outs.items():
                    res["long"][m]["all"].append(wrapped_rms(out, y))
                    res["long"][m]["gap"].append(wrapped_rms(out, y, mask))
            # long_joint: the same kind of gap over every channel of a moving channel's joint (own draws)
            rng_j = np.random.default_rng([seed, 6, len(path.name)])
            for c in rng_j.choice(moving, size=min(3, len(moving)), replace=False):
                hi = min(int(4 * fps), F - 2 * margin)
                n = int(rng_j.integers(int(fps), hi + 1))
                s = int(rng_j.integers(margin, F - margin - n + 1))
                xg = xn.copy()
                xg[s : s + n, joint_of == joint_of[c]] = np.nan
                mask = np.isnan(xg)
                for m, out in run_methods(xg, ctx, fps, ebf, ebd, cpu[path.name]).items():
                    res["long_joint"][m]["all"].append(wrapped_rms(out, y))
                    res["long_joint"][m]["gap"].append(wrapped_rms(out, y, mask))
    seconds = time.perf_counter() - t0
    out: dict = {"clips": len(clips), "seeds": a.seeds, "noise": "angular:0.5",
                 "unit": "degrees RMS", "settings": {}}
    for s in settings:
        table = {m: {k: round(float(np.mean(v)), 3) for k, v in res[s][m].items()} for m in res[s]}
        base = table["lerp+gauss"]["gap"]
        out["settings"][s] = {
            "runs": len(res[s]["ebd+ebf"]["gap"]), "mean": table,
            "ratio_gap_prior_ebf_vs_lerp_gauss": round(table["prior+ebf"]["gap"] / base, 3),
            "ratio_gap_ebd_ebf_vs_lerp_gauss": round(table["ebd+ebf"]["gap"] / base, 3),
            "ratio_gap_prior_words_ebf_vs_lerp_gauss": round(table["prior_words+ebf"]["gap"] / base, 3),
            "ratio_gap_words_ebf_vs_lerp_gauss": round(table["words+ebf"]["gap"] / base, 3),
            "ratio_all_ebd_ebf_vs_lerp_gauss": round(table["ebd+ebf"]["all"] / table["lerp+gauss"]["all"], 3),
            "ratio_gap_ebd_ebf_vs_best_spline": round(
                table["ebd+ebf"]["gap"] / min(table["cubic+gauss"]["gap"], table["quintic+gauss"]["gap"]), 3),
        }
    out["settings"]["ordinary"]["missing_share"] = round(float(np.mean(missing_share)), 4) if missing_share else 0.0
    out["settings"]["long"]["ratio_gap_knn_vs_lerp_gauss"] = round(
        out["settings"]["long"]["mean"]["knn+gauss"]["gap"] / out["settings"]["long"]["mean"]["lerp+gauss"]["gap"], 3)
    out["settings"]["long"]["knn_database"] = f"{database.clips} training clips, {len(database.frames)} frames"
    out["settings"]["long"]["gap_seconds_mean"] = round(float(np.mean(long_lengths)), 2)
    out["settings"]["long"]["gap_seconds_range"] = [round(min(long_lengths), 2), round(max(long_lengths), 2)]
    fills = sum(c.get("fills", 0) for c in cpu.values())
    out["cpu_s"] = {k: round(sum(c.get(k, 0.0) for c in cpu.values()) / max(fills, 1), 4) for k in ("prior", "words")}
    out["cpu_s"]["per"] = f"gapped take ({fills} fills): the shipped fill, and the words step after it"
    out.update(baseline="lerp+gauss: linear fill, then a 58 ms Gaussian, same gaps, same run",
               seconds=round(seconds, 1))
    if not a.json:
        for s in settings:
            print(f"{s} gaps ({out['settings'][s]['runs']} runs): RMS deg over all entries / gap entries")
            for m in out["settings"][s]["mean"]:
                t = out["settings"][s]["mean"][m]
                print(f"  {m:<15}{t['all']:>9.3f}{t['gap']:>9.3f}")
    means = {g: out["settings"][g]["mean"] for g in settings}
    figures, baselines = {}, {}
    for key, setting, method in (("long_gap_rms_deg", "long", "prior+ebf"), ("long_joint_gap_rms_deg", "long_joint", "prior+ebf"),
                                 ("ordinary_gap_rms_deg", "ordinary", "prior+ebf"), ("long_ebd_gap_rms_deg", "long", "ebd+ebf"),
                                 ("long_joint_ebd_gap_rms_deg", "long_joint", "ebd+ebf"),
                                 ("ordinary_ebd_gap_rms_deg", "ordinary", "ebd+ebf"), ("long_knn_gap_rms_deg", "long", "knn+gauss"),
                                 ("long_words_gap_rms_deg", "long", "prior_words+ebf"),
                                 ("long_joint_words_gap_rms_deg", "long_joint", "prior_words+ebf"),
                                 ("ordinary_words_gap_rms_deg", "ordinary", "prior_words+ebf")):
        figures[key] = means[setting][method]["gap"]
        baselines[key] = means[setting]["lerp+gauss"]["gap"]
    harness.emit(
        "deep_gapfill", a, figures=figures, baselines=baselines,
        targets={"long_gap_rms_deg": {"value": 0.60, "op": "<=", "of": "ratios"},
                 "long_joint_gap_rms_deg": {"value": 0.60, "op": "<=", "of": "ratios"}},
        details=out,
    )


if __name__ == "__main__":
    main()
