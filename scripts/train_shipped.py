"""Train the shipped EBF and EBD (docs/models.md), one pair per rig family.

``--rig acclaim`` (default): the ASF/AMC clips of ../shared/data. Held out
(never trained on; benchmarks/deep_*.py test on them through :func:`split`):
every clip of HDM05 actor "mm" and the CMU clips 12 walk, charleston2 and
11_01 (kick). Validation for picking the best epoch: the HDM05 clips of actor
"tr". Installs as ``ebf.pt`` / ``ebd.pt``.

``--rig bandai``: the Bandai Namco Research Motiondataset 1 and 2 takes
(22-joint game rig, 30 fps; ``benchmarks/_bandai.py`` unpacks them outside the
repository), held out by whole styles (:func:`bandai_split`): test = every
take of dataset-2 style ``elderly`` and of dataset-1 styles ``old``, ``sad``
and ``proud``; validation = dataset-1 styles ``tired`` and ``childish``;
training = every other take. Installs as ``ebf_bandai.pt`` / ``ebd_bandai.pt``
(CC BY-NC 4.0, as the data: non-commercial).

Writes ``<out>/<rig>/{ebf,ebd}/model.pt`` (checkpoint beside it; a rerun of the
same command resumes) and, with --install, copies the model into
src/mocapkit/models/. Prints one JSON object as the last line.

    python scripts/train_shipped.py --kind ebf --minutes 30 --install --json
    python scripts/train_shipped.py --rig bandai --kind ebf --minutes 25 --threads 1 --install
    python scripts/train_shipped.py --rig bandai --kind ebd --prior-only --install   # the EBD's gap prior only
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from pathlib import Path

import torch

from mocapkit.cleaning.deep.provenance import BANDAI_LICENCE, rig_name

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("MOCAPKIT_SHARED_DATA", ROOT.parent / "shared" / "data"))  # $MOCAPKIT_SHARED_DATA: a checkout elsewhere
TEST_HOLDOUT = ("HDM_mm_", "12_from_examples", "charleston2", "11_01")
VALIDATION = ("HDM_tr_",)
#: Bandai Namco styles held out, as (dataset, style): never trained on, never cut.
BANDAI_TEST = ((2, "elderly"), (1, "old"), (1, "sad"), (1, "proud"))
BANDAI_VALIDATION = ((1, "tired"), (1, "childish"))
#: Whether each rig's gap prior meets a gap's ends by a ramp (mocapkit.cleaning.deep.prior, GapPrior.ramp), chosen
#: on the validation clips (1-4 s whole-joint gaps at 0.5 noise, prior + EBF against lerp + 58 ms Gaussian):
#: HDM05 "tr" 0.684x with the ramp, 0.774x without; Bandai "tired"/"childish" 0.587x with, 0.553x without.
PRIOR_RAMP = {"acclaim": True, "bandai": False}
#: Whether each rig's gap prior is fitted on its training clips' mirror images too (mocapkit.mirroring.mirror_for_rig,
#: left and right exchanged), chosen on the same validation clips (1-4 s whole joints, prior + EBF against lerp +
#: 58 ms Gaussian): HDM05 "tr" 0.672x -> 0.653x at 0.5 noise, 0.682x -> 0.664x at 0.1, 0.675x -> 0.659x without noise
#: (13,302 rows of 392 entries: the covariance is short of data); Bandai "tired"/"childish" 0.544x -> 0.551x (292,431
#: rows: mirroring adds no data it lacks, and its performers' sides differ).
PRIOR_MIRROR = {"acclaim": True, "bandai": False}
#: Whether each rig's gap prior keeps its training clips' frames (not their mirror images) for the local prior of long
#: gaps (mocapkit.cleaning.deep.prior.local_prior), chosen on the same validation clips: HDM05 "tr", 1-4 s whole
#: joints 0.692x -> 0.614x, single channels 0.583x -> 0.481x, ordinary gaps 0.837x -> 0.812x (one frame in 8 kept,
#: 15 a second, 1.5 MB; the mirror images too, or every 4th frame, 0.614-0.618x). Not for the Bandai prior: its
#: 292,431 frames at its lags' step would be 37 MB, and its gaps meet the target without it.
PRIOR_LOCAL = {"acclaim": True, "bandai": False}
#: Whether each rig's gap prior puts every Euler channel on one branch (mocapkit.cleaning.deep.prior, GapPrior.branch):
#: the Bandai rig's thighs sit at +-180 deg (+180 in some takes, -180 in others) and its pelvis turns freely, so one
#: Gaussian saw modes 360 deg apart; on one branch, the held-out styles' hard gaps (3 joints lost at once, 1-5 s)
#: 10.20 -> 9.55 deg, their 1-4 s whole-joint gaps 0.585x -> 0.592x (docs/models.md). The Acclaim prior has no such
#: channel (largest scale 51 deg).
PRIOR_BRANCH = {"acclaim": False, "bandai": True}
INSTALL_NAME = {("acclaim", "ebf"): "ebf.pt", ("acclaim", "ebd"): "ebd.pt",
                ("bandai", "ebf"): "ebf_bandai.pt", ("bandai", "ebd"): "ebd_bandai.pt"}


def corpus():
    files = sorted((DATA / "hdm05_asfamc").glob("*.amc")) + sorted((DATA / "cmu_asfamc").glob("*.amc"))
    if not files:
        sys.exit(f"{DATA}: no ASF/AMC clips (needs ../shared/data)")
    return files


def split(files):
    test = [f for f in files if any(h in f.name for h in TEST_HOLDOUT)]
    val = [f for f in files if any(h in f.name for h in VALIDATION)]
    train = [f for f in files if f not in test and f not in val]
    return train, val, test


def bandai_split(takes):
    """(train, validation, test) lists of :class:`_bandai.BandaiTake`, by whole style (module docstring)."""
    test = [t for t in takes if (t.dataset, t.style) in BANDAI_TEST]
    val = [t for t in takes if (t.dataset, t.style) in BANDAI_VALIDATION]
    train = [t for t in takes if t not in test and t not in val]
    return train, val, test


def bandai_takes():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from _bandai import bandai_takes as takes

    return takes()


def main() -> None:
    import mocapkit
    from mocapkit.cleaning.deep.training import TrainConfig, train

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kind", choices=("ebf", "ebd"), required=True)
    ap.add_argument("--rig", choices=("acclaim", "bandai"), default="acclaim",
                    help="which rig family's corpus and split (module docstring)")
    ap.add_argument("--every", type=int, default=1, help="train on every N-th training take only (smaller pools)")
    ap.add_argument("--minutes", type=float, default=30.0)
    ap.add_argument("--epochs", type=int, default=400)
    ap.add_argument("--hidden", type=int, default=None)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--bias", action="store_true", help="EBF: also predict a per-channel bias (eq. 1's b)")
    ap.add_argument("--noise-input", action="store_true",
                    help="EBF: the encoder also reads each channel's causal noise-level estimate")
    ap.add_argument("--dropout", type=float, default=None, help="dropout on the LSTM inputs (default TrainConfig's)")
    ap.add_argument("--observed-weight", type=float, default=None, help="EBD: loss weight of observed entries")
    ap.add_argument("--lr-patience", type=int, default=None,
                    help="halve the learning rate after this many epochs without a better validation RMS")
    ap.add_argument("--speed-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                    help="replay the training clips at a random speed in [LO, HI] (augmentation)")
    ap.add_argument("--offset", type=float, default=None, help="EBF: random channel offsets, x channel std")
    ap.add_argument("--patchy", type=float, default=None,
                    help="EBF: share of crops with noise on some channels and over one stretch only")
    ap.add_argument("--mirror", action="store_true",
                    help="also train on every training clip's mirror image (mocapkit.mirroring.mirror_for_rig)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "models"))
    ap.add_argument("--install", action="store_true", help="copy the model into src/mocapkit/models/")
    ap.add_argument("--prior-only", action="store_true",
                    help="EBD: fit only the Gaussian gap prior on the training clips and attach it to the installed "
                         "EBD (the network unchanged)")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    if a.prior_only and a.kind != "ebd":
        ap.error("--prior-only is for --kind ebd")
    if a.threads:
        torch.set_num_threads(a.threads)
    if a.rig == "bandai":
        train_t, val_t, test_t = bandai_split(bandai_takes())
        train_f, val_f, test_f = [t.path for t in train_t], [t.path for t in val_t], [t.path for t in test_t]
    else:
        train_f, val_f, test_f = split(corpus())
    train_f = train_f[::a.every]
    clips = [mocapkit.load(f) for f in train_f]
    val = [mocapkit.load(f) for f in val_f]
    if a.prior_only:
        return attach_prior(a, clips, train_f, test_f)
    if a.mirror:
        from mocapkit.mirroring import mirror_for_rig

        clips = clips + [mirror_for_rig(c) for c in clips]
    hidden = a.hidden or (64 if a.kind == "ebf" else 32)
    extra = {k: v for k, v in (("dropout", a.dropout), ("observed_weight", a.observed_weight), ("offset", a.offset), ("patchy", a.patchy),
                               ("lr_patience", a.lr_patience),
                               ("speed_range", tuple(a.speed_range) if a.speed_range else None)) if v is not None}
    # crop=120: the shipped models' crop at either rate (TrainConfig's default is 1 s of the clips' rate)
    cfg = TrainConfig(kind=a.kind, hidden=hidden, epochs=a.epochs, steps_per_epoch=50, minutes=a.minutes, seed=0, crop=120,
                      bias=a.kind == "ebf" and a.bias, noise_input=a.kind == "ebf" and a.noise_input, **extra)
    out = Path(a.out) / a.kind if a.rig == "acclaim" else Path(a.out) / a.rig / a.kind
    t = time.perf_counter()
    meta = {"rig": rig_name(a.rig), "licence": BANDAI_LICENCE} if a.rig == "bandai" else {"rig": a.rig}
    model = train(clips, out, cfg, validation=val, executor="serial", meta=meta)
    seconds = time.perf_counter() - t
    hist = model.meta["history"]
    if a.install:
        install(out / "model.pt", ROOT / "src" / "mocapkit" / "models" / INSTALL_NAME[a.rig, a.kind])
    res = {
        "benchmark": "train_shipped", "rig": a.rig, "kind": a.kind, "every": a.every, "mirror": a.mirror, "hidden": hidden, "bias": cfg.bias, "noise_input": cfg.noise_input, "train_clips": len(clips),
        "train_frames": int(sum(c.num_frames for c in clips)), "validation_clips": len(val),
        "test_clips": [f.name for f in test_f], "epochs_run": len(hist),
        "best_val_rmse": min(h["val_rmse"] for h in hist), "train_seconds_total": model.meta["train_seconds"],
        "wall_seconds_this_run": seconds, "threads": torch.get_num_threads(), "device": "cpu",
    }
    print(json.dumps(res) if a.json else json.dumps(res, indent=1))


def install(model_file: Path, installed: Path) -> None:
    """Copy ``model_file`` to ``installed`` (src/mocapkit/models/) and write beside it the layout that
    `mocapkit info` reads without torch (mocapkit.cleaning.deep.layouts; tests/cleaning/test_layouts.py checks
    that the two agree)."""
    from mocapkit.cleaning.deep import load_model
    from mocapkit.cleaning.deep.layouts import write_layout

    shutil.copyfile(model_file, installed)
    write_layout(load_model(installed), installed)


def attach_prior(a, clips, train_f, test_f) -> None:
    """Fit the EBD's Gaussian gap prior (mocapkit.cleaning.deep.prior) on the training clips' clean channels and
    write the installed EBD with it (to <out>/.../model_prior.pt; with --install over the installed file)."""
    import dataclasses

    from mocapkit.cleaning.deep import fit_gap_prior, load_model, save_model
    from mocapkit.cleaning.deep.channels import encode
    from mocapkit.mirroring import mirror_for_rig

    installed = ROOT / "src" / "mocapkit" / "models" / INSTALL_NAME[a.rig, "ebd"]
    model = load_model(installed)
    t = time.perf_counter()
    bad = [c.name for c in clips if abs(c.fps - model.fps) > 1e-6]
    if bad:
        sys.exit(f"{bad[0]}: not at the model's {model.fps:g} fps")
    fitted = clips + [mirror_for_rig(c) for c in clips] if PRIOR_MIRROR[a.rig] else clips
    local = [encode(c, model.layout)[0] for c in clips] if PRIOR_LOCAL[a.rig] else None
    prior = fit_gap_prior([encode(c, model.layout)[0] for c in fitted], model.fps, ramp=PRIOR_RAMP[a.rig],
                          local_takes=local, branch=PRIOR_BRANCH[a.rig])
    meta = dict(model.meta, gap_prior={"train_clips": len(clips), "mirrored": PRIOR_MIRROR[a.rig], "frames": prior.frames,
                                       "lags_frames": prior.lags.tolist(), "ridge": prior.ridge, "ramp": prior.ramp,
                                       "local_frames": 0 if prior.local_frames is None else len(prior.local_frames),
                                       "local_step": prior.local_step, "branch": prior.branch is not None,
                                       "fit_seconds": round(time.perf_counter() - t, 1)})
    model = dataclasses.replace(model, meta=meta, prior=prior)
    out = Path(a.out) / ("ebd" if a.rig == "acclaim" else f"{a.rig}/ebd") / "model_prior.pt"
    out.parent.mkdir(parents=True, exist_ok=True)
    save_model(model, out)
    if a.install:
        install(out, installed)
    res = {"benchmark": "train_shipped", "rig": a.rig, "kind": "ebd prior", "train_clips": len(clips),
           "prior_frames": prior.frames, "test_clips": [f.name for f in test_f], **meta["gap_prior"]}
    print(json.dumps(res) if a.json else json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
