"""What the deep-cleaning benchmarks share: the held-out test clips and the channel-level baselines.

The test clips are the ones the shipped EBF/EBD never saw (``scripts/train_shipped.py``, ``TEST_HOLDOUT``):
every HDM05 clip of actor ``mm`` (all 11 classes) and the CMU clips 11_01 (kick),
12's walk and charleston2. Baselines work on the same joint-angle channels the networks
see (:func:`mocapkit.cleaning.deep.channels.encode`: the file's non-root rotation
channels in degrees, unwrapped along time), as Mall et al. filter them.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.signal import savgol_filter

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO / "benchmarks"))
sys.path.insert(0, str(REPO / "scripts"))  # train_shipped: the split into training and held-out clips

import train_shipped  # noqa: E402

DATA = train_shipped.DATA
LOCOMOTION = ("jog", "sneak", "12_from_examples")  # walks and jogs: the "locomotion" rows


def test_clips(quick: bool = False) -> list[Path]:
    """The held-out clips (never trained on); ``quick``: one per HDM05 class plus the CMU ones."""
    if not DATA.is_dir():
        sys.exit(f"{DATA}: not found (the deep benchmarks need ../shared/data)")
    _, _, test = train_shipped.split(train_shipped.corpus())
    if quick:
        seen, keep = set(), []
        for p in test:
            cls = p.name.split("_")[2] if p.name.startswith("HDM_") else p.name
            if cls not in seen:
                seen.add(cls)
                keep.append(p)
        test = keep[::3] + [p for p in test if not p.name.startswith("HDM_")]
    return test


def motion_class(path: Path) -> str:
    """HDM05 class name or the CMU clip's stem."""
    return path.name.split("_")[2] if path.name.startswith("HDM_") else path.stem


def wrapped_rms(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> float:
    """RMS in degrees of angle differences wrapped to [-180, 180), over ``mask`` (default all entries)."""
    d = (np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0
    if mask is not None:
        d = d[mask]
    return float(np.sqrt(np.mean(d**2)))


def gaussian(values: np.ndarray, sigma_s: float, fps: float) -> np.ndarray:
    """Gaussian of std ``sigma_s`` seconds along time on every channel (ends padded with their value)."""
    return gaussian_filter1d(values, sigma_s * fps, axis=0, mode="nearest")


def savgol(values: np.ndarray, window_s: float, fps: float, polyorder: int = 2) -> np.ndarray:
    """Savitzky-Golay of ``window_s`` seconds (odd window), polynomial ends."""
    w = int(round(window_s * fps)) | 1
    w = min(w, len(values) if len(values) % 2 else len(values) - 1)
    return savgol_filter(values, w, polyorder, axis=0, mode="interp") if w > polyorder else values.copy()
