"""Train the shipped EBF and EBD (docs/models.md) on the ASF/AMC clips of ../shared/data.

Held out (never trained on; benchmarks/deep_*.py test on them through :func:`split`): every clip of
HDM05 actor "mm" and the CMU clips 12 walk, charleston2 and 11_01 (kick).
Validation for picking the best epoch: the HDM05 clips of actor "tr" (also
not trained on). Writes ``<out>/{ebf,ebd}/model.pt`` and, with --install,
copies them into src/mocapkit/models/. Prints one JSON object as the last line.

    python scripts/train_shipped.py --kind ebf --minutes 30 --install --json
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
TEST_HOLDOUT = ("HDM_mm_", "12_from_examples", "charleston2", "11_01")
VALIDATION = ("HDM_tr_",)


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


def main() -> None:
    import mocapkit
    from mocapkit.cleaning.deep.training import TrainConfig, train

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kind", choices=("ebf", "ebd"), required=True)
    ap.add_argument("--minutes", type=float, default=30.0)
    ap.add_argument("--epochs", type=int, default=400)
    ap.add_argument("--hidden", type=int, default=None)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--bias", action="store_true", help="EBF: also predict a per-channel bias (eq. 1's b)")
    ap.add_argument("--noise-input", action="store_true",
                    help="EBF: the encoder also reads each channel's causal noise-level estimate")
    ap.add_argument("--dropout", type=float, default=None, help="dropout on the LSTM inputs (default TrainConfig's)")
    ap.add_argument("--observed-weight", type=float, default=None, help="EBD: loss weight of observed entries")
    ap.add_argument("--speed-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                    help="replay the training clips at a random speed in [LO, HI] (augmentation)")
    ap.add_argument("--offset", type=float, default=None, help="EBF: random channel offsets, x channel std")
    ap.add_argument("--patchy", type=float, default=None,
                    help="EBF: share of crops with noise on some channels and over one stretch only")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "models"))
    ap.add_argument("--install", action="store_true", help="copy the model into src/mocapkit/models/")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    if a.threads:
        torch.set_num_threads(a.threads)
    train_f, val_f, test_f = split(corpus())
    clips = [mocapkit.load(f) for f in train_f]
    val = [mocapkit.load(f) for f in val_f]
    hidden = a.hidden or (64 if a.kind == "ebf" else 32)
    extra = {k: v for k, v in (("dropout", a.dropout), ("observed_weight", a.observed_weight), ("offset", a.offset), ("patchy", a.patchy),
                               ("speed_range", tuple(a.speed_range) if a.speed_range else None)) if v is not None}
    cfg = TrainConfig(kind=a.kind, hidden=hidden, epochs=a.epochs, steps_per_epoch=50, minutes=a.minutes, seed=0,
                      bias=a.kind == "ebf" and a.bias, noise_input=a.kind == "ebf" and a.noise_input, **extra)
    out = Path(a.out) / a.kind
    t = time.perf_counter()
    model = train(clips, out, cfg, validation=val, executor="serial")
    seconds = time.perf_counter() - t
    hist = model.meta["history"]
    if a.install:
        shutil.copyfile(out / "model.pt", ROOT / "src" / "mocapkit" / "models" / f"{a.kind}.pt")
    res = {
        "benchmark": "train_shipped", "kind": a.kind, "hidden": hidden, "bias": cfg.bias, "noise_input": cfg.noise_input, "train_clips": len(clips),
        "train_frames": int(sum(c.num_frames for c in clips)), "validation_clips": len(val),
        "test_clips": [f.name for f in test_f], "epochs_run": len(hist),
        "best_val_rmse": min(h["val_rmse"] for h in hist), "train_seconds_total": model.meta["train_seconds"],
        "wall_seconds_this_run": seconds, "threads": torch.get_num_threads(), "device": "cpu",
    }
    print(json.dumps(res) if a.json else json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
