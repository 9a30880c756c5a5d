"""The networks of Mall et al. 2017: EBF (Encoder-Bidirectional-Filter) and EBD (Encoder-Bidirectional-Decoder).

EBF (section 3, Fig. 2): per frame, the joint-angle channels plus the root's
3 angular velocities go through an encoder of 4 fully connected tanh layers to
a 64-D code, 2 bidirectional LSTM layers, and a filter head of 4 fully
connected layers whose last uses ``exp`` to output one Gaussian standard
deviation per channel; the cleaned channel is the normalised Gaussian-weighted
average of that channel over +-15 frames (eq. 1, ``b = 0``). Variants: a
per-channel bias output (eq. 1 with ``b``) and a free-form 31-tap filter.

Noise-level input (not in the paper; ``noise_input=True``). Beside each
channel the encoder can also read :func:`noise_level_feature`: the log of the
channel's noise std estimated from its second differences over the previous
32 frames, relative to the channel's training std. A Gaussian's best width
depends on the noise level, which the raw channels alone do not tell the
network well (light noise gets smoothed too much). The estimate is causal, so
streaming stays exact. The shipped EBF does without it: a level measured over
the past 0.27 s lags behind noise that starts mid-take on a few joints, which
is what real takes have (docs/models.md gives the reasons).

Look-ahead. The paper's B-LSTM sees "15 frames of lookback and 15 frames of
lookahead" and "maintains persistent, hidden state to track the motion over
time". We keep exactly that budget and make streaming exact and cheap: in each
:class:`LookaheadLSTM` layer the forward direction is an ordinary causal LSTM
whose state persists over the whole take, and the backward direction restarts
from zero ``L`` frames ahead of each output frame. With ``L = 7`` and ``8`` in
the two layers the network's output at frame t depends on frames up to t + 15,
so a streaming run emits frame t when frame t + 15 arrives and equals the
offline run; one pass costs 2 forward and 17 backward LSTM steps per frame
instead of the 94 a per-frame 31-frame window would.

EBD (section 3, "Gap filling"): the same encoder (its input also carries the
gap mask), a 2-layer B-LSTM with 32 units per direction over a window of 31
samples at stride 4 (+-60 frames), and a decoder of 4 fully connected layers
back to the channels. It predicts a correction to the linear interpolation at
the window's centre; only gap entries are replaced.

All modules take raw channels (degrees for Euler, matrix entries for 6-D) and
normalise internally with buffers saved with the weights.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from numba import njit
from torch import nn

from .threads import run_in_parts

__all__ = [
    "HALF_WINDOW",
    "gaussian_weights",
    "apply_filter",
    "gaussian_filter_frames",
    "LookaheadLSTM",
    "noise_level_feature",
    "noise_level_observed",
    "observed_second_differences",
    "EBF",
    "EBD",
    "paper_init",
    "xavier_init",
]

HALF_WINDOW = 15  # +-15 frames at 120 fps (Mall 3)
LOG_SIGMA_RANGE = (-6.0, 4.0)  # sigma in frames: e^-6 (identity) .. e^4 (flat over the window)
NOISE_WINDOW = 32  # frames of second differences behind a frame in its noise estimate (0.27 s at 120 fps)
NOISE_FLOOR = 0.01  # channel units (degrees) added to the noise std before the log


def gaussian_weights(sigma: torch.Tensor, half: int = HALF_WINDOW) -> torch.Tensor:
    """Normalised Gaussian taps (..., 2 half + 1) for standard deviations ``sigma`` (...) in frames (eq. 1)."""
    k = torch.arange(-half, half + 1, dtype=sigma.dtype, device=sigma.device)
    logits = -0.5 * (k / sigma.unsqueeze(-1)) ** 2
    return torch.softmax(logits, dim=-1)  # exp / Z, computed stably; sigma -> 0 gives the centre tap 1


def apply_filter(x: torch.Tensor, weights: torch.Tensor, half: int = HALF_WINDOW) -> torch.Tensor:
    """Filter (B, T + 2 half, C) channels with per-frame taps (B, T, C, 2 half + 1) -> (B, T, C)."""
    win = x.unfold(1, 2 * half + 1, 1)  # (B, T, C, 2h+1)
    return torch.sum(win * weights, dim=-1)


@njit(cache=True)
def gaussian_filter_frames(xp: np.ndarray, log_sigma: np.ndarray, half: int = HALF_WINDOW) -> np.ndarray:
    """Eq. 1 without autograd: (F + 2 half, C) padded channels, (F, C) log sigmas -> (F, C) float64.

    The same normalised Gaussian average as ``apply_filter(x,
    gaussian_weights(exp(log_sigma)))``, for inference: the taps are never
    stored; by symmetry w_k = w_-k = exp(-k^2 / (2 sigma^2)), and consecutive
    taps follow w_k = w_{k-1} a q^{k-1} with a = exp(-1 / (2 sigma^2)),
    q = exp(-1 / sigma^2), so each output costs two exponentials. A tiny sigma
    underflows every off-centre tap to 0: the identity, as the softmax gives.
    """
    F, C = log_sigma.shape
    out = np.empty((F, C))
    for t in range(F):
        for c in range(C):
            s = np.exp(-2.0 * np.float64(log_sigma[t, c]))  # 1 / sigma^2
            r = np.exp(-0.5 * s)
            q = np.exp(-s)
            w, z = 1.0, 1.0
            acc = np.float64(xp[t + half, c])
            for k in range(1, half + 1):
                w *= r
                r *= q
                acc += w * (np.float64(xp[t + half - k, c]) + np.float64(xp[t + half + k, c]))
                z += 2.0 * w
            out[t, c] = acc / z
    return out


def _mlp(sizes: list[int], last_activation: bool) -> nn.Sequential:
    layers: list[nn.Module] = []
    for k in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[k], sizes[k + 1]))
        if k < len(sizes) - 2 or last_activation:
            layers.append(nn.Tanh())
    return nn.Sequential(*layers)


def paper_init(module: nn.Module, lstm_std: float = 0.1) -> None:
    """Mall's initialisation: dense weights uniform on [-0.5, 0.5], LSTM weights Gaussian; biases 0.

    The paper gives no Gaussian width; ``lstm_std`` = 0.1. Dense weights are
    scaled by sqrt(64 / fan_in) so layers wider than the paper's keep its
    pre-activation spread instead of saturating every tanh.
    """
    for m in module.modules():
        if isinstance(m, nn.Linear):
            bound = 0.5 * min(1.0, math.sqrt(64.0 / m.in_features))
            nn.init.uniform_(m.weight, -bound, bound)
            nn.init.zeros_(m.bias)
        elif isinstance(m, nn.LSTM):
            for name, p in m.named_parameters():
                if name.startswith("weight"):
                    nn.init.normal_(p, 0.0, lstm_std)
                else:
                    nn.init.zeros_(p)


def xavier_init(module: nn.Module) -> None:
    """Glorot-uniform dense weights with the tanh gain (5/3), PyTorch's default LSTM init; biases 0.

    The shipped models' initialisation. Mall's uniform [-0.5, 0.5] gives the
    first tanh layers pre-activations of std ~2 on normalised input (64-115
    inputs of variance ~1 each), so most units start saturated; on this
    machine's training budget that left both networks at the level of a fixed
    Gaussian (EBF) or worse than the linear fill (EBD) after 1,000 steps,
    where this initialisation (with dropout 0.1) is clearly past them after
    400 (docs/models.md).
    """
    for m in module.modules():
        if isinstance(m, nn.Linear):
            nn.init.xavier_uniform_(m.weight, gain=5.0 / 3.0)
            nn.init.zeros_(m.bias)
        elif isinstance(m, nn.LSTM):
            m.reset_parameters()


INITS = {"xavier": xavier_init, "paper": paper_init}


def _initialise(module: nn.Module, init: str) -> None:
    if init not in INITS:
        raise ValueError(f"init must be one of {tuple(INITS)}, got {init!r}")
    INITS[init](module)


def noise_level_feature(x: torch.Tensor, std: torch.Tensor, window: int = NOISE_WINDOW) -> torch.Tensor:
    """Causal noise level of every channel: (B, T, C) raw channels -> (B, T, C).

    For white noise of std s the second difference ``x[t] - 2 x[t-1] + x[t-2]``
    has variance 6 s^2, while a smooth motion sampled at 120 fps contributes
    little to it; so ``sqrt(mean of d^2 over the last window frames / 6)`` estimates
    s (frames before the first two count d = 0, as do the edge-padded frames of
    :func:`inference._pad`). Returned as ``(log((s + 0.01) / std) + 3) / 3``,
    ``log`` clamped to [-8, 2], so typical values lie in [-2, 2]; ``std`` (C,)
    is the network's channel normalisation. Depends on frames up to t only:
    the streaming :class:`streaming.Denoiser` computes the same numbers.
    """
    d = torch.zeros_like(x)
    d[:, 2:] = x[:, 2:] - 2.0 * x[:, 1:-1] + x[:, :-2]
    sq = torch.nn.functional.pad((d**2).transpose(1, 2), (window - 1, 0))  # (B, C, T + window - 1)
    mean = torch.nn.functional.avg_pool1d(sq, window, stride=1).transpose(1, 2)  # (B, T, C)
    level = torch.log((torch.sqrt(mean / 6.0) + NOISE_FLOOR) / std).clamp(-8.0, 2.0)
    return (level + 3.0) / 3.0


def observed_second_differences(x: np.ndarray, observed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Second differences ``x[t] - 2 x[t-1] + x[t-2]`` of (F, C) channels (0 at t < 2) and where all three
    samples are ``observed`` (F, C) bool: ((F, C) float64, (F, C) bool). For white noise of std s they have
    variance 6 s^2."""
    x = np.asarray(x, dtype=np.float64)
    ok = np.asarray(observed, dtype=bool)
    d = np.zeros_like(x)
    d[2:] = x[2:] - 2.0 * x[1:-1] + x[:-2]
    valid = np.zeros_like(ok)
    valid[2:] = ok[2:] & ok[1:-1] & ok[:-2]
    return d, valid


def noise_level_observed(
    x: np.ndarray, observed: np.ndarray, std: np.ndarray, window: int = NOISE_WINDOW
) -> np.ndarray:
    """:func:`noise_level_feature` of (F, C) channels from their observed samples only: (F, C).

    A second difference counts only where its three frames are all ``observed``
    (F, C) bool, and a frame's level is the mean over the counted ones in its
    window; a frame whose own second difference does not count (in or next
    to a gap) takes the level of the last frame whose does (before the first
    one, the first one's). Filled gap entries are not measurements: their
    lerp or EBD values, smooth by construction, would read as a channel
    without noise.
    """
    x = np.asarray(x, dtype=np.float64)
    d, valid = observed_second_differences(x, observed)
    sums = np.cumsum(np.where(valid, d * d, 0.0), axis=0)
    counts = np.cumsum(valid, axis=0)
    sums[window:] -= sums[:-window].copy()
    counts[window:] -= counts[:-window].copy()
    mean = np.zeros(x.shape)
    np.divide(sums, counts, out=mean, where=counts > 0)
    for c in np.flatnonzero(~valid.all(axis=0)):  # carry the last measured level through the gaps
        seen = np.flatnonzero(valid[:, c])
        if not len(seen):
            continue
        idx = np.maximum.accumulate(np.where(valid[:, c], np.arange(len(x)), -1))
        mean[:, c] = mean[np.where(idx >= 0, idx, seen[0]), c]
    return _noise_level(mean, std)


def noise_level_step(d2_window: np.ndarray, std: np.ndarray, window: int = NOISE_WINDOW) -> np.ndarray:
    """:func:`noise_level_feature` of one frame from its last ``window`` squared second differences (<= window, C)."""
    return _noise_level(d2_window.sum(axis=0) / window, std)


def _noise_level(mean_d2: np.ndarray, std: np.ndarray) -> np.ndarray:
    """The feature of :func:`noise_level_feature` from mean squared second differences, in numpy."""
    level = np.log((np.sqrt(np.maximum(mean_d2, 0.0) / 6.0) + NOISE_FLOOR) / std)
    return (np.minimum(np.maximum(level, -8.0), 2.0) + 3.0) / 3.0  # np.clip costs 10 us more per call


class LookaheadLSTM(nn.Module):
    """A bidirectional LSTM layer whose backward direction sees ``lookahead`` frames ahead only.

    forward: causal, state carried over the whole sequence (or passed in for
    streaming). backward: for each position t, an LSTM run from zero state over
    x[t + L], ..., x[t]. Input (B, T, I) -> output (B, T - L, 2 H).
    """

    def __init__(self, input_size: int, hidden: int, lookahead: int):
        super().__init__()
        self.hidden = hidden
        self.lookahead = int(lookahead)
        self.fwd = nn.LSTM(input_size, hidden, batch_first=True)
        self.bwd = nn.LSTM(input_size, hidden, batch_first=True)

    def backward_outputs(self, x: torch.Tensor, chunk: int = 8192, parts: int = 1) -> torch.Tensor:
        """(B, T, I) -> (B, T - L, H): the backward direction at every position with a full look-ahead.

        Position t's backward output is an LSTM run from zero state over
        x[t + L], ..., x[t]. Each input frame enters L + 1 such runs, so its
        input projection ``W_ih x + b`` is computed once for the whole
        sequence and the L + 1 recurrent steps of all windows run batched;
        this is the ``nn.LSTM`` cell (same weights, same gate order i, f, g, o)
        at about half the cost of running ``self.bwd`` on every window.
        ``parts``: the positions are cut into this many parts run
        concurrently (:func:`mocapkit.cleaning.deep.threads.run_in_parts`;
        the same result).

        Without gradients (inference) each step makes two new tensors, the
        recurrent product ``h W_hh^T`` and ``tanh(c)``; the gates, the cell
        and the output are worked out in place in them (the same elementwise
        operations on the same operands, each tensor with the strides it had:
        the same numbers, bit for bit, as the step written out, which training
        runs for autograd). The ten temporaries a step that made, allocated and
        freed again, cost a quarter of the pass on a 60 s take.
        """
        B, T, I = x.shape
        L, H = self.lookahead, self.hidden
        n = T - L
        if n <= 0:
            return x.new_zeros((B, 0, H))
        lstm = self.bwd
        gi = torch.nn.functional.linear(x, lstm.weight_ih_l0, lstm.bias_ih_l0 + lstm.bias_hh_l0)  # (B, T, 4H)
        w_hh = lstm.weight_hh_l0
        step = max(1, chunk // max(B, 1))
        in_place = not torch.is_grad_enabled()  # inference (the parts' threads run in the caller's grad mode)

        def positions(lo: int, hi: int) -> list[torch.Tensor]:
            out = []
            for s in range(lo, hi, step):
                m = min(step, hi - s)
                h = c = None
                for k in range(L, -1, -1):  # x[t + L] first, x[t] last
                    g = gi[:, s + k : s + k + m]  # a view of gi, which every window reads: never written
                    if not in_place:  # autograd (training) keeps each step's tensors: every one a new tensor
                        if h is not None:
                            g = g + torch.matmul(h, w_hh.t())
                        i, f, gg, o = g.chunk(4, dim=-1)
                        i, o, gg = torch.sigmoid(i), torch.sigmoid(o), torch.tanh(gg)
                        c = i * gg if c is None else torch.sigmoid(f) * c + i * gg
                        h = o * torch.tanh(c)
                        continue
                    # the gate inputs in a tensor of their own: x's projection plus h's (IEEE sums commute)
                    g = g.clone() if h is None else torch.matmul(h, w_hh.t()).add_(g)
                    i, f, gg, o = g.chunk(4, dim=-1)
                    i.sigmoid_()
                    o.sigmoid_()
                    gg.tanh_()
                    # c = sigmoid(f) * c + i * gg, in c's and i's storage (the first step's c: i * gg, a contiguous
                    # tensor, as c always is: tanh reads it in the same SIMD lanes as it did)
                    c = i * gg if c is None else c.mul_(f.sigmoid_()).add_(i.mul_(gg))
                    h = torch.tanh(c).mul_(o)
                out.append(h)
            return out

        return torch.cat([h for part in run_in_parts(positions, n, parts) for h in part], dim=1)

    def forward(self, x: torch.Tensor, state=None, parts: int = 1):
        """(B, T, I) -> ((B, T - L, 2 H), forward state after the last of those positions); ``parts``: see
        :meth:`backward_outputs`."""
        n = x.shape[1] - self.lookahead
        f, st = self.fwd(x[:, : max(n, 0)], state) if n > 0 else (x.new_zeros((x.shape[0], 0, self.hidden)), state)
        return torch.cat([f, self.backward_outputs(x, parts=parts)], dim=-1), st


class _Normalised(nn.Module):
    """Holds channel mean/std and context scale as buffers (saved with the weights)."""

    def __init__(self, channels: int, context: int):
        super().__init__()
        self.channels = channels
        self.context = context
        self.register_buffer("mean", torch.zeros(channels))
        self.register_buffer("std", torch.ones(channels))
        self.register_buffer("ctx_scale", torch.ones(context))

    def set_statistics(self, mean, std, ctx_scale) -> None:
        self.mean.copy_(torch.as_tensor(mean, dtype=self.mean.dtype))
        self.std.copy_(torch.as_tensor(std, dtype=self.std.dtype))
        self.ctx_scale.copy_(torch.as_tensor(ctx_scale, dtype=self.ctx_scale.dtype))

    def normalise(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.mean) / self.std

    def normalise_context(self, ctx: torch.Tensor) -> torch.Tensor:
        return ctx / self.ctx_scale


class EBF(_Normalised):
    """Encoder-Bidirectional-Filter (Mall 3, Fig. 2).

    ``head``: "gaussian" (one sigma per channel and frame, the paper's model) or
    "free" (31 normalised taps per channel and frame); ``bias`` adds a
    per-channel bias output (eq. 1's ``b``, in units of the channel's std);
    ``noise_input`` feeds the encoder :func:`noise_level_feature` too.
    Call with raw channels ``x`` (B, T, C) and context (B, T, 3); returns the
    filtered channels of positions [15, T - 15): (B, T - 30, C).
    """

    def __init__(
        self,
        channels: int,
        context: int = 3,
        code: int = 64,
        hidden: int = 126,
        lookahead: tuple[int, int] = (7, 8),
        head: str = "gaussian",
        bias: bool = False,
        dropout: float = 0.5,
        width: int = 128,
        init: str = "paper",
        noise_input: bool = False,
    ):
        super().__init__(channels, context)
        if head not in ("gaussian", "free"):
            raise ValueError(f"head must be 'gaussian' or 'free', got {head!r}")
        if sum(lookahead) > HALF_WINDOW:
            raise ValueError(f"total look-ahead {sum(lookahead)} exceeds the filter's {HALF_WINDOW} frames")
        self.config = dict(
            channels=channels, context=context, code=code, hidden=hidden, lookahead=list(lookahead),
            head=head, bias=bias, dropout=dropout, width=width, init=init,
        )
        if noise_input:  # only when set, so the files of models without it keep their config
            self.config["noise_input"] = True
        self.head_kind = head
        self.with_bias = bias
        self.noise_input = bool(noise_input)
        n_in = channels * (2 if noise_input else 1) + context
        self.encoder = _mlp([n_in, width, width, width // 2 + code // 2, code], last_activation=True)
        self.drop = nn.Dropout(dropout)
        self.lstm1 = LookaheadLSTM(code, hidden, lookahead[0])
        self.lstm2 = LookaheadLSTM(2 * hidden, hidden, lookahead[1])
        taps = 2 * HALF_WINDOW + 1
        n_out = channels * (taps if head == "free" else 1) + (channels if bias else 0)
        self.head = _mlp([2 * hidden, width, width, width, n_out], last_activation=False)
        _initialise(self, init)
        with torch.no_grad():  # start as a mild smoother: sigma = 2 frames, and (almost) no bias
            if init == "xavier":
                self.head[-1].weight.mul_(0.1)
            if head == "gaussian":
                self.head[-1].bias[:channels].fill_(math.log(2.0))
            if bias:
                self.head[-1].weight[-channels:].mul_(0.01)

    @property
    def delay(self) -> int:
        """Frames of look-ahead the network needs (15)."""
        return HALF_WINDOW

    def encode(self, x: torch.Tensor, ctx: torch.Tensor, noise: torch.Tensor | None = None) -> torch.Tensor:
        """The 64-D code (B, T, code). ``noise`` (B, T, C): the noise-level input when it was computed elsewhere
        (at a take's own frame rate, before resampling); by default :func:`noise_level_feature` of ``x``."""
        parts = [self.normalise(x)]
        if self.noise_input:
            parts.append(noise_level_feature(x, self.std) if noise is None else noise)
        return self.encoder(torch.cat(parts + [self.normalise_context(ctx)], dim=-1))

    def filter_parameters(self, y2: torch.Tensor):
        """(B, T, 2H) -> (log sigma (B, T, C) clamped, or free-tap logits (B, T, C, 31); bias (B, T, C) or None).

        The bias is in channel units (degrees for Euler channels).
        """
        out = self.head(y2)
        C = self.channels
        b = out[..., -C:] * self.std if self.with_bias else None
        if self.head_kind == "gaussian":
            return out[..., :C].clamp(*LOG_SIGMA_RANGE), b
        return out[..., : C * (2 * HALF_WINDOW + 1)].reshape(*out.shape[:-1], C, 2 * HALF_WINDOW + 1), b

    def head_outputs(self, y2: torch.Tensor):
        """(B, T, 2H) -> (taps (B, T, C, 31), bias (B, T, C) in channel units or None)."""
        p, b = self.filter_parameters(y2)
        if self.head_kind == "gaussian":
            return gaussian_weights(torch.exp(p)), b
        return torch.softmax(p, dim=-1), b

    def sigma(self, x: torch.Tensor, ctx: torch.Tensor) -> torch.Tensor:
        """Predicted Gaussian sigmas (B, T - 30, C) in frames (Gaussian head only)."""
        if self.head_kind != "gaussian":
            raise ValueError("sigma() needs the Gaussian head")
        y2 = self.trunk(x, ctx)[:, HALF_WINDOW:]
        return torch.exp(self.head(y2)[..., : self.channels].clamp(*LOG_SIGMA_RANGE))

    def trunk(self, x: torch.Tensor, ctx: torch.Tensor, noise: torch.Tensor | None = None,
              parts: int = 1) -> torch.Tensor:
        """The encoder and both look-ahead LSTM layers: (B, T, C) channels, (B, T, 3) context -> (B, T - 15, 2 H)
        features of positions [0, T - 15), the input the filter head reads (``noise``: the noise-level input,
        else the network's own; ``parts``: see :meth:`LookaheadLSTM.backward_outputs`)."""
        e = self.drop(self.encode(x, ctx, noise))
        y1, _ = self.lstm1(e, parts=parts)
        y2, _ = self.lstm2(self.drop(y1), parts=parts)
        return y2  # positions [0, T - 15)

    def forward(self, x: torch.Tensor, ctx: torch.Tensor) -> torch.Tensor:
        y2 = self.trunk(x, ctx)[:, HALF_WINDOW:]  # positions [15, T - 15)
        taps, b = self.head_outputs(y2)
        out = apply_filter(x, taps)
        return out - b if b is not None else out


class EBD(_Normalised):
    """Encoder-Bidirectional-Decoder gap filler (Mall 3, "Gap filling").

    Input windows (N, 31, 2 C + 3): lerp-filled raw channels, the gap mask
    (1 = missing) and root context, sampled at ``stride`` frames around each
    frame to fill; output (N, C): raw channels at the window centre, as the
    lerp value there plus a learnt correction.
    """

    def __init__(
        self,
        channels: int,
        context: int = 3,
        code: int = 64,
        hidden: int = 32,
        half: int = HALF_WINDOW,
        stride: int = 4,
        dropout: float = 0.5,
        width: int = 128,
        init: str = "paper",
    ):
        super().__init__(channels, context)
        self.config = dict(
            channels=channels, context=context, code=code, hidden=hidden, half=half, stride=stride,
            dropout=dropout, width=width, init=init,
        )
        self.half = half
        self.stride = stride
        self.encoder = _mlp([2 * channels + context, width, width, width // 2 + code // 2, code], last_activation=True)
        self.drop = nn.Dropout(dropout)
        self.lstm = nn.LSTM(code, hidden, num_layers=2, bidirectional=True, batch_first=True, dropout=dropout)
        self.decoder = _mlp([2 * hidden, width, width, width, channels], last_activation=False)
        _initialise(self, init)
        with torch.no_grad():
            self.decoder[-1].weight.mul_(0.1)  # start close to the lerp

    def forward(self, x: torch.Tensor, mask: torch.Tensor, ctx: torch.Tensor) -> torch.Tensor:
        """x (N, 31, C) lerp-filled raw channels, mask (N, 31, C) float, ctx (N, 31, 3) -> (N, C)."""
        xn = self.normalise(x)
        e = self.encoder(torch.cat([xn, mask, self.normalise_context(ctx)], dim=-1))
        y, _ = self.lstm(self.drop(e))
        corr = self.decoder(y[:, self.half])
        return (xn[:, self.half] + corr) * self.std + self.mean

    def forward_at(self, x: torch.Tensor, mask: torch.Tensor, ctx: torch.Tensor, centres: torch.Tensor,
                   parts: int = 1) -> torch.Tensor:
        """:meth:`forward` on the windows around ``centres`` (N,) of whole tracks -> (N, C), each frame encoded once.

        ``x`` (F, C) lerp-filled raw channels, ``mask`` (F, C) float, ``ctx``
        (F, 3). The encoder sees one frame at a time, so the windows of
        neighbouring centres, which share most of their frames (a gap of n
        frames asks for n windows of 31), share those frames' codes: the
        encoder runs once per distinct frame instead of 31 times per centre,
        and only the LSTM and decoder run per window. ``parts``: the centres
        are cut into this many parts run concurrently
        (:func:`mocapkit.cleaning.deep.threads.run_in_parts`; the same result).
        """

        def windows(lo: int, hi: int) -> torch.Tensor:
            idx = window_indices(centres[lo:hi], len(x), self.half, self.stride)
            used, inv = torch.unique(idx, return_inverse=True)
            e = self.encoder(torch.cat([self.normalise(x[used]), mask[used], self.normalise_context(ctx[used])], dim=-1))
            y, _ = self.lstm(self.drop(e[inv]))
            corr = self.decoder(y[:, self.half])
            return (self.normalise(x[idx[:, self.half]]) + corr) * self.std + self.mean

        return torch.cat(run_in_parts(windows, len(centres), parts))


def window_indices(centres: torch.Tensor, length: int, half: int = HALF_WINDOW, stride: int = 4) -> torch.Tensor:
    """(N, 2 half + 1) frame indices centres + stride k, k in [-half, half], clamped to [0, length)."""
    k = torch.arange(-half, half + 1, device=centres.device) * stride
    return (centres[:, None] + k[None]).clamp(0, length - 1)
