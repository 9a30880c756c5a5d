"""Training the EBF and EBD (Mall et al. 2017, sections 3-4): noisy/clean pairs on the fly, Adam, checkpoints.

Pairs are made with :mod:`mocapkit.corrupt` exactly as the benchmarks and users
corrupt motion: angular noise of 0.1/0.5/0.9 x each channel's std mixed,
uniform noise and spatial noise (joint positions jittered, rotations
refitted); constant and sinusoidal bias (:data:`BIAS_NOISE`) for a model
meant for non-zero-mean noise; and for the EBD gaps per channel and per joint
with geometrically distributed lengths (10% start probability per channel in
the literal setting is far too dense for our clips; see :func:`gap_mask`)
plus long gaps of 1-5 s. Each epoch draws fresh crops and fresh gaps from a
pool of noisy variants made once per clip. The learning rate halves after
``lr_patience`` epochs without a better validation RMS.

Training is seeded and deterministic on the CPU: epoch ``e`` uses the seeds
``(seed, e)``, so a run resumed from its checkpoint continues exactly as if
it had not stopped. Checkpoints and the best model (lowest validation RMS in
degrees on the held-out clips) are written atomically after every epoch, so
interrupting never leaves a broken file.

A run's identity is its settings and the content of its clips (names and
:func:`clip_digest`); ``model.pt`` carries it with its own validation RMS.
An output folder holding a checkpoint or model of another training is
refused before any work (:func:`check_out_dir`), and a resumed run takes
the best score from ``model.pt`` itself, so a run killed between writing
``model.pt`` and ``checkpoint.pt`` never replaces a better model with a
worse one.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from tqdm.auto import tqdm
from ...progress import bar_disabled, bar_size

from ... import corrupt
from ...errors import SkeletonError
from ...io.outputs import removed_on_failure
from ...motion import Motion
from ...words import plural
from .channels import ChannelLayout, channel_joints, encode, layout_for, wrap_degrees
from .inference import DeepModel, denoise_channels, lerp_fill, run_ebd, save_model, write_torch
from .layouts import LAYOUT_SUFFIX, write_layout
from .networks import EBD, EBF, HALF_WINDOW, window_indices
from .prior import fit_gap_prior
from .provenance import model_card

__all__ = ["TrainConfig", "load_clips", "check_clip_lengths", "split_holdout", "holdout_folds", "gap_mask", "channel_joints", "prepare_clip", "train",
           "clip_digest", "check_out_dir"]

DEFAULT_NOISE = ("angular:0.1", "angular:0.5", "angular:0.9", "uniform:0.5", "spatial:0.5", "spatial:1.0")
BIAS_NOISE = ("bias-constant:0.5", "bias-sinusoidal:0.5")


CROP_S = 1.0
"""Seconds of EBF output per training crop (plus :data:`HALF_WINDOW` frames each side) where ``TrainConfig.crop``
is not given: 120 frames at 120 fps, the shipped Acclaim models' crop; 30 at 30 fps, so a 2.2 s run of the Bandai
Namco set (65 frames) is a training clip. A crop counted in frames whatever the rate (120 at 30 fps is 4 s, 5 s
with the window) refused most takes of a 30 fps game set: 147 of its 221 walks and runs."""


@dataclass(frozen=True)
class TrainConfig:
    """Settings of one training run.

    The shipped EBF used these defaults with ``hidden=64, dropout=0.3,
    speed_range=(0.4, 2.5)``; the shipped EBD used ``dropout=0.3,
    observed_weight=0.0`` (docs/models.md). The augmentation is off by
    default: it lowered the error on the test actor, not on the validation
    actor, so it is a setting to try on one's own data, not a rule.
    """

    kind: str = "ebf"  # "ebf" or "ebd"
    representation: str = "euler"
    hidden: int | None = None  # 126 for EBF, 32 for EBD (Mall 3)
    head: str = "gaussian"  # EBF: "gaussian" or "free"
    bias: bool = False  # EBF: per-channel bias output
    noise_input: bool = False  # EBF: the encoder also reads each channel's causal noise-level estimate
    init: str = "xavier"  # "xavier" or "paper" (Mall's uniform [-0.5, 0.5]; see networks.xavier_init)
    dropout: float = 0.1  # on the LSTM inputs (Mall: 0.5)
    epochs: int = 40
    steps_per_epoch: int = 100
    batch: int = 16  # EBF crops / EBD clips per step
    crop: int | None = None  # EBF output frames per crop (plus 15 each side); None: CROP_S of the clips' rate
    centres: int = 32  # EBD windows per clip in a step
    lr: float = 2e-3
    lr_patience: int = 5  # halve the learning rate after this many epochs without a better validation RMS
    seed: int = 0
    noise: tuple[str, ...] = DEFAULT_NOISE
    variants: int = 2  # noisy variants per clip and noise setting
    long_gap_share: float = 0.2  # EBD: share of gap patterns that are 1-5 s gaps
    gap_rate: float = 0.2  # EBD: gap starts per second of observed motion, per channel or joint
    observed_weight: float = 0.1  # EBD: loss weight of the observed channels of a window centre
    speed_range: tuple[float, float] = (1.0, 1.0)  # clips replayed at a random speed in this range (augmentation)
    offset: float = 0.0  # EBF: random per-crop channel offsets, std in units of the channel's std
    patchy: float = 0.0  # EBF: share of crops whose noise is kept on some channels and over one stretch only
    minutes: float | None = None  # stop after the epoch that passes this budget
    device: str = "auto"

    def __post_init__(self):
        lo, hi = self.speed_range
        if not 0 < lo <= hi:
            raise ValueError(f"speed_range needs 0 < lo <= hi, got {self.speed_range!r}")
        if not self.offset >= 0:
            raise ValueError(f"offset must be >= 0, got {self.offset!r}")
        if self.crop is not None and not (isinstance(self.crop, int) and self.crop >= 1):
            raise ValueError(f"crop must be a whole number of frames >= 1, got {self.crop!r}")
        if not 0.0 <= self.patchy <= 1.0:
            raise ValueError(f"patchy must be in [0, 1], got {self.patchy!r}")
        for name, allowed in (("kind", ("ebf", "ebd")), ("representation", ("euler", "rot6d")),
                              ("head", ("gaussian", "free")), ("init", ("xavier", "paper"))):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name} is {' or '.join(allowed)}, got {getattr(self, name)!r}")
        for spec in self.noise:
            noisy_motion(None, spec, 0, check_only=True)

    def crop_frames(self, fps: float) -> int:
        """EBF output frames per crop for clips at ``fps``: ``crop`` where given, else :data:`CROP_S` seconds."""
        return self.crop if self.crop is not None else max(int(round(CROP_S * fps)), 1)

    def network(self, channels: int) -> torch.nn.Module:
        if self.kind == "ebf":
            return EBF(channels, hidden=self.hidden or 126, head=self.head, bias=self.bias, dropout=self.dropout,
                       init=self.init, noise_input=self.noise_input)
        if self.kind == "ebd":
            return EBD(channels, hidden=self.hidden or 32, dropout=self.dropout, init=self.init)
        raise ValueError(f"kind must be 'ebf' or 'ebd', got {self.kind!r}")


def load_clips(sources, asf=None, amc_fps: float | None = None, unit: str | None = None,
               unit_option: str = "unit=") -> list[Motion]:
    """Motions from files, folders (every .bvh/.amc/.npz below) or a MotionDatabase directory/object.

    ``asf``, ``amc_fps``: the skeleton and frame rate of the ``.amc`` files (:func:`mocapkit.io.takes.load_take`;
    by default the ASF beside each and :func:`mocapkit.io.asfamc.amc_rate`). ``unit`` (mm, cm, m, in; ``--unit``):
    the length unit of the clips whose files state none (:func:`mocapkit.io.takes.with_unit`), which spatial noise
    in cm needs on a rig whose bones do not tell it (no ankle or head found by name); a clip whose file states
    another is refused naming its file and the option as the caller gave it (``unit_option``: Python's ``unit=``,
    ``mocapkit train``'s ``--unit``)."""
    from ...database import MotionDatabase, expand_sources
    from ...io.takes import load_take, with_unit

    if unit is not None:
        return [with_unit(c, unit, c.source_file or c.name or "a clip", unit_option)
                for c in load_clips(sources, asf, amc_fps)]
    if isinstance(sources, MotionDatabase):
        return [sources.clip(i) for i in range(sources.num_clips)]
    srcs = [sources] if isinstance(sources, (str, Path)) else list(sources)
    out: list[Motion] = []
    for s in srcs:
        p = Path(s) if not isinstance(s, Motion) else None
        if p is not None and p.is_dir() and (p / "database.json").is_file():
            db = MotionDatabase.open(p)
            out += [db.clip(i) for i in range(db.num_clips)]
            continue
        for item in expand_sources([s]):
            m = item if isinstance(item, Motion) else load_take(item, asf, fps=amc_fps)
            if m.source_file is None and not isinstance(item, Motion):  # an .npz says no file: errors name it
                m = dataclasses.replace(m, source_file=str(item))
            out.append(m)
    return out


def check_clip_lengths(clips: list[Motion], config: TrainConfig) -> None:
    """Refuse (ValueError, one line naming them) EBF training clips shorter than one crop
    (:meth:`TrainConfig.crop_frames` + 30 frames: 150 at 120 fps, 60 at 30 fps by default): :func:`_ebf_batch`
    draws its crops from whole clips, so such a clip would never be
    trained on while the model card counted it. An EBD trains on whole clips of any length; validation clips
    are denoised whole, so neither is checked."""
    if config.kind != "ebf":
        return
    if not clips:
        return
    crop = config.crop_frames(clips[0].fps)
    need = crop + 2 * HALF_WINDOW
    short = [c for c in clips if c.num_frames < need]
    if short:
        names = [f"{c.source_file or c.name or 'clip'} ({c.num_frames})" for c in short]
        raise ValueError(f"{len(short)} of {plural(len(clips), 'training clip')} {'is' if len(short) == 1 else 'are'} "
                         f"shorter than a crop of {need} frames "
                         f"and would never be trained on: {', '.join(names[:4])}{', ...' if len(names) > 4 else ''}; "
                         f"leave them out (or hold them out for validation), or lower the crop of {crop} output "
                         f"frames (--crop N; TrainConfig(crop=N) in Python)")


def split_holdout(clips: list[Motion], holdout: list[str] | int = 0, seed: int = 0):
    """(train, validation): clips whose name contains any of ``holdout``'s strings, or ``holdout`` random clips."""
    if isinstance(holdout, int):
        rng = np.random.default_rng(seed)
        val_idx = set(rng.choice(len(clips), size=min(holdout, len(clips) - 1), replace=False).tolist()) if holdout else set()
    else:
        val_idx = {i for i, c in enumerate(clips) if any(h in c.name for h in holdout)}
    return [c for i, c in enumerate(clips) if i not in val_idx], [c for i, c in enumerate(clips) if i in val_idx]


def holdout_folds(clips: list[Motion], folds: int, size: int | None = None, seed: int = 0):
    """``folds`` (train, validation) splits with disjoint validation sets of ``size`` clips each (Mall 4).

    Mall et al. cross-validate on "5 randomly sampled holdouts of 10 motions
    each"; ``size`` defaults to ``len(clips) // (folds + 1)`` so every fold
    keeps most clips for training. Clips are shuffled once with ``seed``.
    """
    n = len(clips)
    if folds < 1:
        raise ValueError(f"folds must be at least 1, got {folds}")
    size = size if size is not None else max(1, n // (folds + 1))
    if size < 1 or folds * size >= n:
        raise ValueError(f"{plural(folds, 'holdout')} of {plural(size, 'clip')} need{'s' if folds == 1 else ''} more "
                         f"than {plural(folds * size, 'clip')}, got {n}")
    order = np.random.default_rng(seed).permutation(n)
    out = []
    for k in range(folds):
        val = set(order[k * size : (k + 1) * size].tolist())
        out.append(([c for i, c in enumerate(clips) if i not in val], [c for i, c in enumerate(clips) if i in val]))
    return out


def gap_mask(shape: tuple[int, int], fps: float, rng: np.random.Generator, start_prob: float | None = None,
             mean_length_s: float = 0.25, long: bool = False, groups: np.ndarray | None = None) -> np.ndarray:
    """(F, C) boolean gaps (True = missing) with geometric lengths, per channel or per joint (Mall 4).

    Each channel (or, with ``groups`` (C,) giving each channel's joint, each
    joint's channels together, as a lost marker takes a whole joint) is a
    renewal process: every observed frame starts a gap with probability
    ``start_prob`` (default ``0.2 / fps``: about 5 % missing with 0.25 s gaps),
    lengths geometric with mean ``mean_length_s``. Mall's literal "10 %
    probability of starting a gap in a specific joint channel at a specific
    frame" would leave most of every channel missing and contradict their
    note that few channels are missing at once; see
    :func:`mocapkit.corrupt.gaps`. ``long`` gives one gap of 1-5 s (uniform)
    in each of 1-3 random channels (or joints) instead: Mall's long-gap test.
    """
    F, C = shape
    mask = np.zeros((F, C), dtype=bool)
    units = np.arange(C) if groups is None else np.unique(groups)
    members = [np.array([u]) for u in units] if groups is None else [np.flatnonzero(groups == u) for u in units]
    if long:
        lo, hi = int(round(1.0 * fps)), int(round(5.0 * fps))
        for k in rng.choice(len(units), size=min(int(rng.integers(1, 4)), len(units)), replace=False):
            n = int(rng.integers(lo, hi + 1))
            s = int(rng.integers(0, max(F - n // 2, 1)))
            mask[s : s + n, members[k]] = True
        return mask
    p = start_prob if start_prob is not None else 0.2 / fps
    mean = max(mean_length_s * fps, 1.0)
    for cols in members:
        f = int(rng.geometric(p)) - 1
        while f < F:
            n = int(rng.geometric(1.0 / mean))
            mask[f : f + n, cols] = True
            f += n + int(rng.geometric(p))
    return mask


NOISE_KINDS = ("angular", "uniform", "spatial", "bias-constant", "bias-sinusoidal", "clean")


def noisy_motion(motion: Motion | None, spec: str, seed, check_only: bool = False) -> Motion | None:
    """``motion`` corrupted by one noise setting ``KIND:AMOUNT`` (see :data:`NOISE_KINDS`)."""
    kind, _, amount = spec.partition(":")
    try:
        a = float(amount) if amount else 0.5
    except ValueError:
        raise ValueError(f"{spec!r}: the amount after ':' must be a number") from None
    if kind not in NOISE_KINDS or not (a >= 0 and math.isfinite(a)):
        raise ValueError(f"unknown noise setting {spec!r} (angular:A, uniform:A, spatial:CM, bias-constant:A, "
                         "bias-sinusoidal:A, clean)")
    if check_only:
        return None
    if kind == "angular":
        return corrupt.angular_noise(motion, a, seed=seed)[0]
    if kind == "uniform":
        return corrupt.uniform_noise(motion, a, seed=seed)[0]
    if kind == "spatial":
        return corrupt.spatial_noise(motion, std_cm=a, seed=seed)[0]
    if kind in ("bias-constant", "bias-sinusoidal"):
        return corrupt.bias(motion, a, kind=kind.split("-")[1], seed=seed, noise=0.5)[0]
    return motion


def prepare_clip(args) -> dict:
    """Clean channels, context and noisy variants of one clip (runs in worker processes)."""
    motion, layout, noise, variants, seed = args
    clean, ctx = encode(motion, layout)
    noisy = []
    for k, spec in enumerate(noise):
        for v in range(variants):
            x, _ = encode(noisy_motion(motion, spec, (seed, k, v)), layout)
            # Unwrapping can start on the other side of +-180: align each channel's turn count to the clean one.
            x = x - 360.0 * np.round(np.nanmedian(x - clean, axis=0) / 360.0)
            noisy.append(x.astype(np.float32))
    return {"name": motion.name, "fps": motion.fps, "clean": clean.astype(np.float32),
            "ctx": ctx.astype(np.float32), "noisy": noisy}


def _statistics(data: list[dict]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    clean = np.concatenate([d["clean"] for d in data])
    ctx = np.concatenate([d["ctx"] for d in data])
    std = np.maximum(clean.std(axis=0), 1.0 if clean.shape[1] and np.abs(clean).max() > 2 else 0.05)
    return clean.mean(axis=0), std, np.maximum(np.abs(ctx).std(axis=0), 0.1)


def _device(spec: str) -> torch.device:
    if spec == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    return torch.device(spec)


def _resample_crop(a: np.ndarray, start: float, speed: float, T: int) -> np.ndarray:
    """``T`` frames of ``a`` (F, C) read from ``start`` at ``speed`` frames per output frame, linearly interpolated."""
    pos = start + speed * np.arange(T)
    i = np.minimum(pos.astype(np.int64), len(a) - 2)
    f = (pos - i)[:, None].astype(a.dtype)
    return (1 - f) * a[i] + f * a[i + 1]


def _replayed(d: dict, start: float, speed: float, T: int) -> tuple[np.ndarray, np.ndarray]:
    """``T`` frames of a prepared clip's clean channels and root angular velocity replayed at ``speed`` from ``start``.

    The angular velocity is per second, so it scales with the speed.
    """
    return _resample_crop(d["clean"], start, speed, T), _resample_crop(d["ctx"], start, speed, T) * np.float32(speed)


def _draw_speed(cfg: TrainConfig, rng: np.random.Generator) -> float | None:
    """A replay speed drawn log-uniformly from ``cfg.speed_range``, or None when the augmentation is off."""
    lo, hi = cfg.speed_range
    if lo == hi == 1.0:
        return None
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _ebf_batch(data, cfg: TrainConfig, rng: np.random.Generator, std: np.ndarray | None = None):
    """EBF crops (noisy (B, T, C), context (B, T, 3), clean centre (B, T - 30, C)), T = crop + 30.

    With ``cfg.speed_range`` other than (1, 1) each crop's clean motion is
    replayed at a speed drawn log-uniformly from the range (linear interpolation;
    the root's angular velocity scaled to match) and the noise of a same-length
    stretch of one noisy variant is added to it: the angular and uniform noise
    is white, so this is the noise the clip would have had at that speed.
    ``cfg.offset`` adds one random offset per channel (std ``offset`` x the
    training set's channel std ``std``) to input and target alike. Both keep
    the target exact for a linear filter; they are meant to stop the network
    from recognising the training actors by their tempo and poses (the speed
    helped on the test actor, the offsets did not: docs/models.md).
    ``cfg.patchy``: that share of the crops keeps its noise on about half the
    channels only, each at a random 0.2-1x of its level, and over one random
    stretch of the crop (at least a quarter of it): real noise is uneven over
    joints and time, and a network with the noise-level input that only ever
    saw every channel equally noisy all the time smoothed a few noisy joints
    too little (docs/models.md).
    """
    T = cfg.crop_frames(data[0]["fps"]) + 2 * HALF_WINDOW
    lens = np.array([len(d["clean"]) for d in data], dtype=np.float64)
    ok = np.flatnonzero(lens >= T)
    if not len(ok):
        raise ValueError(f"every training clip is shorter than a crop of {T} frames; train on longer clips "
                         "(or lower the crop: --crop N; TrainConfig(crop=N) in Python)")
    if cfg.offset > 0 and std is None:
        raise ValueError("offset augmentation needs the training set's channel std")
    pick = rng.choice(ok, size=cfg.batch, p=lens[ok] / lens[ok].sum())
    xs, cs, ys = [], [], []
    for i in pick:
        d = data[i]
        n = len(d["clean"])
        s = int(rng.integers(0, n - T + 1))
        v = d["noisy"][int(rng.integers(len(d["noisy"])))]
        speed = _draw_speed(cfg, rng)
        if speed is not None:
            speed = min(speed, (n - 1.0) / (T - 1))  # a short clip cannot be replayed as fast
            s0 = float(rng.uniform(0.0, max(n - 1.0 - speed * (T - 1), 0.0)))
            clean, ctx = _replayed(d, s0, speed, T)
            noisy = clean + _wrapped(v[s : s + T] - d["clean"][s : s + T], cfg)
        else:
            clean, ctx, noisy = d["clean"][s : s + T], d["ctx"][s : s + T], v[s : s + T]
        if cfg.patchy > 0 and rng.random() < cfg.patchy:
            noisy = clean + _patchy(_wrapped(noisy - clean, cfg), rng)
        xs.append(noisy)
        cs.append(ctx)
        ys.append(clean[HALF_WINDOW : T - HALF_WINDOW])
    x, c, y = (np.stack(a).astype(np.float32) for a in (xs, cs, ys))
    if cfg.offset > 0:  # drawn after the crops, so the crops do not depend on it
        o = (rng.normal(size=(len(x), 1, x.shape[2])) * cfg.offset * std).astype(np.float32)
        x, y = x + o, y + o
    return torch.as_tensor(x), torch.as_tensor(c), torch.as_tensor(y)


def _patchy(noise: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``noise`` (T, C) kept on about half the channels (each at 0.2-1x, log-uniform) and on one stretch of
    at least T / 4 frames, zero elsewhere (see :func:`_ebf_batch`)."""
    T, C = noise.shape
    gain = np.where(rng.random(C) < 0.5, 0.0, np.exp(rng.uniform(np.log(0.2), 0.0, size=C)))
    a = int(rng.integers(0, T - T // 4))
    b = int(rng.integers(a + T // 4, T + 1))
    on = np.zeros(T)
    on[a:b] = 1.0
    return noise * on[:, None] * gain[None, :]


def _ebd_batch(data, cfg: TrainConfig, rng: np.random.Generator, net: EBD, groups: np.ndarray | None = None):
    """EBD windows around gap frames: half the clips lose single channels, half whole joints (``groups``).

    ``cfg.speed_range`` replays each clip at a random speed first, as :func:`_ebf_batch` does.
    """
    xs, ms, cs, ys = [], [], [], []
    for i in rng.integers(len(data), size=cfg.batch):
        d = data[i]
        v = d["noisy"][int(rng.integers(len(d["noisy"])))]
        clean, ctx = d["clean"], d["ctx"]
        speed = _draw_speed(cfg, rng)
        if speed is not None:  # the whole clip replayed at one speed, with the white noise of its variant
            n = int((len(clean) - 1) / speed) + 1
            noise = _wrapped(v - clean, cfg)[np.arange(n) % len(clean)]
            clean, ctx = _replayed(d, 0.0, speed, n)
            v = (clean + noise).astype(np.float32)
        F, C = clean.shape
        long = rng.random() < cfg.long_gap_share
        by_joint = groups is not None and rng.random() < 0.5
        mask = gap_mask((F, C), d["fps"], rng, start_prob=cfg.gap_rate / d["fps"], long=long,
                        groups=groups if by_joint else None)
        frames = np.flatnonzero(mask.any(axis=1))
        if not len(frames):
            continue
        x = np.where(mask, np.nan, v)
        filled = lerp_fill(x).astype(np.float32)
        centres = rng.choice(frames, size=cfg.centres)
        idx = window_indices(torch.as_tensor(centres), F, net.half, net.stride).numpy()
        xs.append(filled[idx])
        ms.append(mask[idx].astype(np.float32))
        cs.append(ctx[idx])
        ys.append(clean[centres])
    return tuple(torch.as_tensor(np.concatenate(a)) for a in (xs, ms, cs, ys))


def _ebd_loss(err2: torch.Tensor, gap: torch.Tensor, observed_weight: float) -> torch.Tensor:
    """EBD loss: mean squared error on the centre's gap entries plus ``observed_weight`` x that on the rest.

    Mall's decoder "recovers the 126-D joint angle vector", the whole clean
    pose; only its gap entries are used when filling, so they carry the main
    term, and the observed entries a smaller one that makes the EBD a direct
    pose regressor too (the "EBD alone" denoiser of Mall 4.1).
    """
    loss = err2[gap].mean() if bool(gap.any()) else err2.new_zeros(())
    if observed_weight > 0 and bool((~gap).any()):
        loss = loss + observed_weight * err2[~gap].mean()
    return loss


def _wrapped(d, cfg: TrainConfig):
    """Euler differences wrapped to [-180, 180): an angle off by a full turn is no error (as the metric)."""
    return wrap_degrees(d) if cfg.representation == "euler" else d


def _validate(net, kind: str, val: list[dict], layout: ChannelLayout, fps: float) -> float:
    """Validation RMS in degrees (Euler) or matrix units (6-D) over the held-out clips' first noisy variant."""
    net.eval()
    model = DeepModel(kind, net, layout, fps)
    err, n = 0.0, 0
    rng = np.random.default_rng(12345)
    for k, d in enumerate(val):
        x = d["noisy"][len(d["noisy"]) // 2].astype(np.float64)
        if kind == "ebf":
            out = denoise_channels(x, d["ctx"], model, calibrate=False)  # the network itself
            e = out - d["clean"]
            e = wrap_degrees(e) if layout.representation == "euler" else e
        else:  # ordinary gaps on every other clip, 1-5 s gaps in 1-3 channels on the rest
            mask = gap_mask(x.shape, d["fps"], rng, long=bool(k % 2))
            if not mask.any():
                continue
            filled = lerp_fill(np.where(mask, np.nan, x))
            frames = np.flatnonzero(mask.any(axis=1))
            pred = run_ebd(net, filled, mask, d["ctx"], frames)
            e = (pred - d["clean"][frames])[mask[frames]]
            e = wrap_degrees(e) if layout.representation == "euler" else e
        err += float(np.sum(e**2))
        n += e.size
    net.train()
    return math.sqrt(err / max(n, 1))


def _plateau_halvings(history: list[dict], patience: int) -> list[bool]:
    """Per epoch of ``history``: does the plateau rule halve the learning rate after it?

    The rule: an epoch that does not beat the best validation RMS so far adds
    one to a count that a better epoch resets; when the count reaches
    ``patience`` (0 = never) the learning rate halves and the count restarts.
    Derived from the history alone, so a resumed run follows the same rule.
    """
    best, stale, out = math.inf, 0, []
    for h in history:
        if h["val_rmse"] < best:
            best, stale = h["val_rmse"], 0
        else:
            stale += 1
        halve = bool(patience) and stale >= patience
        if halve:
            stale = 0
        out.append(halve)
    return out


def clip_digest(m: Motion) -> str:
    """The identity of a clip's content (32 hex digits): BLAKE2b of its fps, joint names, parents, bone offsets,
    rotations, root positions and translations (dtype, shape and bytes of each). Any edited sample changes it;
    the name does not enter it (a checkpoint keeps names beside digests)."""
    h = hashlib.blake2b(digest_size=16)
    sk = m.skeleton
    h.update(json.dumps([float(m.fps), list(sk.joint_names)]).encode())
    for a in (sk.parents, sk.offsets, m.rotations, m.root_positions, m.translations):
        if a is None:
            h.update(b"\0none")
            continue
        a = np.ascontiguousarray(a)
        h.update(f"\0{a.dtype.str}{a.shape}".encode())
        h.update(memoryview(a.reshape(-1)).cast("B"))
    return h.hexdigest()


def _identity(cfg: TrainConfig, clips: list[Motion], validation: list[Motion] | None) -> tuple[str, str]:
    """The settings (all but the stopping rule and device) and the data of a run, as the JSON a checkpoint keeps."""
    same = {k: v for k, v in dataclasses.asdict(cfg).items() if k not in ("epochs", "minutes", "device")}
    if same["crop"] is None and clips:  # the frames it means: a run given them resumes one that was not
        same["crop"] = cfg.crop_frames(clips[0].fps)
    data = {"train": [[c.name, clip_digest(c)] for c in clips],
            "validation": [[c.name, clip_digest(c)] for c in validation or []]}
    return json.dumps(same, sort_keys=True), json.dumps(data)


def _without_digests(data) -> bool:
    """True for a checkpoint's data of an earlier mocapkit: clip names alone, no ``[name, digest]`` pairs."""
    try:
        d = json.loads(data) if isinstance(data, str) else data
        rows = list(d.get("train", [])) + list(d.get("validation", []))
    except (TypeError, ValueError, AttributeError):
        return False
    return bool(rows) and all(isinstance(r, str) for r in rows)


def _training_id(cfg_json: str, data_json: str) -> str:
    """One digest of a run's settings and data: what ``model.pt``'s metadata ``training`` holds."""
    return hashlib.blake2b(f"{cfg_json}\0{data_json}".encode(), digest_size=16).hexdigest()


def _load_or_none(path: Path) -> dict | None:
    """``torch.load`` of a checkpoint or model file (weights only); None when it is not one (damaged, foreign)."""
    try:
        out = torch.load(path, map_location="cpu", weights_only=True)
    except Exception:  # pickle, zip and torch errors alike: not a file of ours
        return None
    return out if isinstance(out, dict) else None


def _damaged(path: Path) -> bool:
    """True for a torch file (a zip archive: ``torch.save``'s format) that ``torch.load`` cannot read: cut short by
    a full disk or an interrupted copy, or otherwise damaged; False for a whole file and for bytes of another kind
    (not a model file at all). A damaged model is refused as such, not as another training's."""
    try:
        with open(path, "rb") as fh:
            if fh.read(4) != b"PK\x03\x04":
                return False
        torch.load(path, map_location="cpu", weights_only=True)
    except Exception:  # zip, pickle and torch errors alike: not a whole torch file
        return True
    return False


def _model_record(path: Path) -> dict | None:
    """``model.pt``'s metadata (JSON), None when it is missing or unreadable."""
    payload = _load_or_none(path) if path.is_file() else None
    try:
        meta = json.loads(payload["meta"]) if payload is not None else None
    except (KeyError, TypeError, ValueError):
        return None
    return meta if isinstance(meta, dict) else None


def _first_epoch_only(meta: dict) -> bool:
    """True for the metadata of a model written by a run's first epoch and not by the run's end (``finished`` False)."""
    history = meta.get("history")
    return meta.get("finished") is False and isinstance(history, list) and len(history) == 1 \
        and isinstance(history[0], dict) and history[0].get("epoch") == 0


def check_out_dir(out_dir, clips: list[Motion], config: TrainConfig = TrainConfig(), validation: list[Motion] | None = None,
                  resume: bool = True, overwrite: bool = False) -> bool:
    """Refuse, before any work, an output folder whose model or checkpoint a run would replace unasked; True to resume.

    The folder's run continues (True) when ``checkpoint.pt`` holds the same
    settings (all but epochs, minutes, device) on the same clips (names and
    :func:`clip_digest`; a checkpoint from before digests were kept does not
    match) and ``model.pt``, if present, is that run's. Otherwise the folder
    is refused (ValueError, one line saying what differs and that
    ``--restart`` starts over there) when it holds a checkpoint or a
    ``model.pt``: these are replaced only with ``resume=False``
    (``--restart``: start over) or ``overwrite`` (start over where the folder
    is not this run's, resume where it is). The one ``model.pt`` without a
    checkpoint that starts over unasked is this run's own first epoch's
    (killed between the epoch's two writes): the seed writes it again.
    """
    out_dir = Path(out_dir)
    ckpt_path, model_path = out_dir / "checkpoint.pt", out_dir / "model.pt"
    if not resume:
        return False
    cfg_json, data_json = _identity(config, clips, validation)
    same_run = False
    if ckpt_path.is_file():
        ck = _load_or_none(ckpt_path)
        if ck is None:
            other = ("a damaged or truncated checkpoint.pt (torch cannot read it)" if _damaged(ckpt_path) else
                     "an unreadable checkpoint.pt (not one mocapkit wrote)")
        else:
            differ = [what for what, same in (("settings", ck.get("config") == cfg_json),
                                              ("clips", ck.get("data") == data_json)) if not same]
            other = f"a training with other {' and '.join(differ)}" if differ else ""
        if other and not overwrite:
            why = ""
            if "clips" in other:
                why = (" (written by an earlier mocapkit, which kept no digest of its clips' content: it cannot be "
                       "resumed)" if ck is not None and _without_digests(ck.get("data")) else
                       " (other clips, or the same clips with other content)")
            raise ValueError(f"{out_dir} holds {other}{why}; --restart (resume=False in Python) starts it over there "
                             "(its model and checkpoint replaced), or give another folder")
        same_run = not other
        if same_run and not model_path.exists() and int(ck.get("epoch", -1)) + 1 >= config.epochs:
            raise ValueError(f"{out_dir}: its training is finished but model.pt is missing; more --epochs "
                             "(TrainConfig.epochs) continue it, --restart (resume=False) trains it again")
    if model_path.exists():
        meta = _model_record(model_path)
        this_training = meta is not None and meta.get("training") == _training_id(cfg_json, data_json)
        if not ckpt_path.exists() and this_training and _first_epoch_only(meta):
            # killed outright between the first epoch's two writes: the model is this run's own epoch 0,
            # which starting over writes again (the seed fixes it), so nothing is lost
            return False
        mine = same_run and this_training
        if not mine and not overwrite:
            why = "no checkpoint of this training beside it" if not same_run else "it is another training's model"
            if meta is None and model_path.is_file() and _damaged(model_path):  # not another training's: unreadable
                why = "damaged or truncated: torch cannot read it"
            raise ValueError(f"{model_path} already exists ({why}); --restart or --overwrite (resume=False or "
                             "overwrite=True in Python) replaces it, or give another folder")
        same_run = same_run and mine
    return same_run


def train(
    clips: list[Motion],
    out_dir,
    config: TrainConfig = TrainConfig(),
    validation: list[Motion] | None = None,
    resume: bool = True,
    executor=None,
    progress: bool = True,
    meta: dict | None = None,
    overwrite: bool = False,
    executor_option: str = "executor=",
) -> DeepModel:
    """Train an EBF or EBD on ``clips``; returns the best model (also written to ``out_dir/model.pt``).

    ``out_dir/checkpoint.pt`` holds the weights, optimiser state and history
    after each epoch; with ``resume`` an existing checkpoint of the same
    config and clips continues where it stopped. A folder holding another
    run's checkpoint or model is refused before any work unless
    ``resume=False`` (start over) or ``overwrite`` (:func:`check_out_dir`).
    ``model.pt``'s metadata keeps the run's identity (``training``) and its
    score (``best_val_rmse``, ``best_epoch``); a resumed run starts from that
    score, so it replaces ``model.pt`` only with a better model, even after
    a kill between the two files' writes. ``executor``: where the noisy pools are
    made (:func:`mocapkit.parallel.map_ordered`; ``executor_option``: how a refusal names it, Python's ``executor=``
    or ``train``'s ``--executor``). The model's metadata keeps its
    card (:func:`mocapkit.cleaning.deep.provenance.model_card`): the rig family
    of the clips, the training data (takes and frames, trained on and held out)
    and the licence, inherited from the takes where the project knows it (the
    Bandai Namco set's CC BY-NC 4.0), else not stated. ``meta``: entries that
    state or add to it (e.g. ``{"licence": "CC BY 4.0"}``, ``{"training_data":
    {"folders": [...]}}``); takes of several rig families raise ValueError.
    """
    from ...parallel import map_ordered

    if not clips:
        raise ValueError("no training clips")
    cfg = dataclasses.replace(config, crop=config.crop_frames(clips[0].fps))  # the card keeps the frames
    check_clip_lengths(clips, cfg)
    out_dir = Path(out_dir)  # made by the first write (atomic_write): a run that fails before leaves no folder
    # A checkpoint continues when everything but the stopping rule and device matches, on the same clips;
    # another run's checkpoint or model is not replaced by a resume (it would be lost): refused before any work
    resume = check_out_dir(out_dir, clips, cfg, validation, resume=resume, overwrite=overwrite)
    cfg_json, data_json = _identity(cfg, clips, validation)
    training_id = _training_id(cfg_json, data_json)
    ckpt_path = out_dir / "checkpoint.pt"
    layout = layout_for(clips[0], cfg.representation)
    fps = clips[0].fps
    for c in clips + list(validation or []):
        have = layout_for(c, cfg.representation)
        if have.names != layout.names:  # ChannelLayout.check's test, said as training needs it: no model yet
            raise SkeletonError(f"{c.name or 'clip'}: another rig than the first clip's ({have.num_channels} "
                                f"{cfg.representation} channels; {clips[0].name or 'the first clip'} has "
                                f"{layout.num_channels}); train one rig at a time")
        if abs(c.fps - fps) > 1e-6:
            raise ValueError(f"{c.name}: {c.fps:g} fps, but the first clip has {fps:g}; resample the corpus first")
    card = model_card(clips, validation, meta)  # the rig, data and licence the model file keeps
    noise = tuple(cfg.noise)
    jobs = [(c, layout, noise, cfg.variants, cfg.seed * 100003 + i) for i, c in enumerate(clips)]
    data = map_ordered(prepare_clip, jobs, executor=executor, progress=progress, desc="noisy pairs",
                       option=executor_option)
    val_jobs = [(c, layout, ("angular:0.5",), 1, 777 + i) for i, c in enumerate(validation or [])]
    val = map_ordered(prepare_clip, val_jobs, executor=executor, progress=False, option=executor_option) if val_jobs else []
    torch.manual_seed(cfg.seed)
    net = cfg.network(layout.num_channels)
    stats = _statistics(data)
    net.set_statistics(*stats)
    channel_std = stats[1].astype(np.float32)
    groups = channel_joints(layout)
    dev = _device(cfg.device)
    opt = torch.optim.Adam(net.parameters(), lr=cfg.lr)
    history: list[dict] = []
    start_epoch, best = 0, math.inf
    if resume:  # a checkpoint of the same settings and clips (checked above)
        ck = torch.load(ckpt_path, map_location="cpu", weights_only=True)
        net.load_state_dict(ck["state"])
        opt.load_state_dict(ck["optimizer"])
        start_epoch = int(ck["epoch"]) + 1
        history = json.loads(ck["history"])
        # the score to beat is model.pt's own (this run's, checked above): written before the checkpoint, it may be
        # an epoch ahead of it after a kill between the two writes; without model.pt any epoch writes one
        record = _model_record(out_dir / "model.pt")
        best = float(record.get("best_val_rmse", math.inf)) if record is not None else math.inf
    net.to(dev)
    for st in opt.state.values():
        for k, v in st.items():
            if torch.is_tensor(v):
                st[k] = v.to(dev)
    t0 = time.perf_counter() - sum(h["seconds"] for h in history)
    # the bar counts optimiser steps (an epoch of a large rig takes minutes), the epoch in its description
    steps = cfg.steps_per_epoch
    bar = tqdm(total=cfg.epochs * steps, initial=start_epoch * steps, desc=f"train {cfg.kind}", unit="step",
               disable=bar_disabled(progress), **bar_size())
    for epoch in range(start_epoch, cfg.epochs):
        bar.set_description(f"train {cfg.kind} epoch {epoch + 1}/{cfg.epochs}")
        rng = np.random.default_rng([cfg.seed, epoch])
        torch.manual_seed(cfg.seed * 1000 + epoch)
        net.train()
        te = time.perf_counter()
        total = 0.0
        for _ in range(cfg.steps_per_epoch):
            if cfg.kind == "ebf":
                x, c, y = (a.to(dev) for a in _ebf_batch(data, cfg, rng, channel_std))
                loss = torch.mean(_wrapped(net(x, c) - y, cfg) ** 2)
            else:
                x, m, c, y = (a.to(dev) for a in _ebd_batch(data, cfg, rng, net, groups))
                pred = net(x, m, c)
                loss = _ebd_loss(_wrapped(pred - y, cfg) ** 2, m[:, net.half] > 0.5, cfg.observed_weight)
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(net.parameters(), 10.0)
            opt.step()
            total += loss.item()
            bar.update(1)
        net.to("cpu")
        v = _validate(net, cfg.kind, val, layout, fps) if val else math.sqrt(total / cfg.steps_per_epoch)
        history.append({"epoch": epoch, "train_rmse": math.sqrt(total / cfg.steps_per_epoch), "val_rmse": v,
                        "lr": opt.param_groups[0]["lr"], "seconds": time.perf_counter() - te})
        meta = {"config": dataclasses.asdict(cfg), "train_clips": [c.name for c in clips],
                "validation_clips": [c.name for c in (validation or [])], "history": history,
                "train_seconds": time.perf_counter() - t0, "torch": torch.__version__, **card,
                "training": training_id, "best_val_rmse": v, "best_epoch": epoch, "finished": False}
        if _plateau_halvings(history, cfg.lr_patience)[-1]:
            for g in opt.param_groups:
                g["lr"] *= 0.5
        # the epoch's model and checkpoint as one set: if either write fails (a full disk) or is interrupted, both
        # are as after the last epoch (on a first epoch, neither is there), so the same command resumes
        with removed_on_failure([out_dir / "model.pt", out_dir / f"model{LAYOUT_SUFFIX}", ckpt_path], overwrite=True):
            if v < best:
                epoch_model = DeepModel(cfg.kind, net, layout, fps, meta)
                save_model(epoch_model, out_dir / "model.pt")
                write_layout(epoch_model, out_dir / "model.pt", card=True)  # what `info` reads without torch
            write_torch({"config": cfg_json, "data": data_json, "state": net.state_dict(), "optimizer": opt.state_dict(),
                         "epoch": epoch, "best": min(best, v), "history": json.dumps(history)}, ckpt_path)
        best = min(best, v)
        net.to(dev)
        bar.set_postfix(train=f"{history[-1]['train_rmse']:.3f}", val=f"{v:.3f}", best=f"{best:.3f}")
        if cfg.minutes is not None and time.perf_counter() - t0 > 60.0 * cfg.minutes:
            break
    bar.close()
    net.to("cpu")
    from .inference import load_model

    best_model = load_model(out_dir / "model.pt")
    if start_epoch >= cfg.epochs and best_model.meta.get("finished") is True:
        return best_model  # a finished run asked again: nothing trained, its model file left as it is
    best_model.meta.update(history=history, train_seconds=time.perf_counter() - t0, finished=True)
    if cfg.kind == "ebd":  # the gap prior on the same clean clips (seconds: one covariance)
        best_model = dataclasses.replace(best_model, prior=fit_gap_prior([d["clean"] for d in data], fps))
    save_model(best_model, out_dir / "model.pt")  # the whole history, not only up to the best epoch
    write_layout(best_model, out_dir / "model.pt", card=True)
    return best_model
