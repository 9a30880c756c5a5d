"""Streaming denoising: the EBF one frame at a time, behind the capture (Mall et al. 2017).

Mall et al. note that the bidirectional network "operates in a streaming
setting": its backward LSTM layers look ahead a fixed number of frames (the
shipped EBF 7 + 8, :class:`~mocapkit.cleaning.deep.networks.LookaheadLSTM`), and
its filter spans 15 frames each side, so the network's widths for a frame are
known once 15 more have arrived. The offline widths are then scaled per
channel and :data:`~mocapkit.cleaning.deep.sure.BLOCK_S` block by Stein's risk
estimate (:func:`~mocapkit.cleaning.deep.sure.calibrated_log_sigma`), which
needs the block whole and half a block after it (the take's last block takes
in a shorter remainder). :class:`Denoiser` runs on a live stream of
file-channel rows (a BVH MOTION line or an AMC frame) 15 frames behind with
the network's own widths, the look-ahead a live capture can afford; with
``calibrate=True`` it calibrates as the offline command does and equals it
frame for frame, a block and a half behind (179 frames at 30 fps);
:func:`denoise_rows` is its batch counterpart on a whole take, which gives the
same numbers with the same ``calibrate``.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import torch
from numba import njit

from ... import rotations as R
from ...errors import SkeletonError
from ...io.euler_branches import three_axis_groups
from ...motion import Skeleton
from .channels import UNWRAP_ALPHA, euler_columns, euler_values, root_angular_velocity
from .inference import denoise_channels, model_of_kind, needs_resampling, warn_licence
from .networks import EBF, HALF_WINDOW, LOG_SIGMA_RANGE, NOISE_WINDOW, gaussian_filter_frames, noise_level_step
from .sure import BLOCK_S, READ_BEYOND, block_edges, calibrated_log_sigma, scoring_stride, wrapped_channels
from .retarget import served_by

__all__ = ["Denoiser", "denoise_rows"]


class Denoiser:
    """Streaming EBF: ``push(row)`` a frame of file channels, get a cleaned frame :attr:`lag` frames later.

    A row is one line of a BVH MOTION block / AMC frame: all of the skeleton's
    channels in file order (:meth:`Motion.channel_values`). The first pushes
    emit nothing until :attr:`lag` more frames have arrived; then each push
    returns the cleaned row of the frame :attr:`lag` earlier. :meth:`flush`
    returns the last :attr:`lag`. ``calibrate=False`` (default): the
    network's own widths, 15 frames behind, the delay a live capture can
    take. ``calibrate=True`` (a Gaussian-head model): the widths calibrated per
    channel and block as offline
    (:func:`~mocapkit.cleaning.deep.sure.calibrated_log_sigma`, the shared
    function; a Bandai Namco channel that wrapped in training,
    :func:`~mocapkit.cleaning.deep.sure.wrapped_channels`, among them), so the
    stream equals ``mocapkit denoise``; a block is calibrated once it,
    :data:`~mocapkit.cleaning.deep.sure.READ_BEYOND` frames around it and half
    a block after it have arrived, so :attr:`lag` is a block and a half (179
    frames at 30 fps, 719 at 120). The output equals
    :func:`denoise_rows` with the same ``calibrate`` on the whole take frame for
    frame (to float32 rounding). Each joint's Euler triple is read on one branch, the
    one nearest its previous frame's (:func:`~mocapkit.cleaning.deep.channels.euler_values`,
    as :func:`~mocapkit.cleaning.deep.denoise` reads a take), so a row on the
    other branch near gimbal lock (a Bandai Namco ``Hips`` in a heading turn) is
    no 180-deg jump; cleaned rows come out on that one branch, wrapped to
    [-180, 180). Root channels pass through unchanged. Each push
    runs the network's layers on one frame with the weights as float64 numpy
    arrays and numba loops (about 0.8 ms on this CPU, where the same layers as
    ~20 PyTorch calls cost 2 ms).
    """

    def __init__(self, skeleton: Skeleton, fps: float, model=None, calibrate: bool = False):
        m = model_of_kind(model, "ebf", skeleton)
        if m.layout.representation != "euler":
            raise ValueError("streaming needs an Euler-channel model")
        sv = served_by(skeleton, m)
        if isinstance(sv, str):
            raise SkeletonError(f"skeleton: {sv}")
        if not sv.direct or sv.joints:
            how = "has joints the model does not know" if sv.direct else "is served through a joint map"
            raise SkeletonError(f"skeleton: streaming needs exactly the model's channels; this {sv.family} rig {how} "
                                f"and is served offline only (deep.denoise)")
        if needs_resampling(fps, m.fps):
            raise ValueError(f"streaming runs at the model's rate ({m.fps:g} fps), got {fps:g} fps")
        warn_licence(m, {"ebf": "model="})  # the Bandai Namco model is non-commercial, as deep.denoise says
        self.model = m
        self.net: EBF = m.net
        self.skeleton = skeleton
        self.fps = float(fps)
        self._cols = euler_columns(skeleton)
        self._triples = three_axis_groups(skeleton)
        self._branch = None  # the last row with each joint's triple on its branch (channels.euler_values)
        self._root = _root_rotation_columns(skeleton)
        self._n_file = sum(len(skeleton.joint_channels(j)) for j in range(skeleton.num_joints))
        L1, L2 = self.net.lstm1.lookahead, self.net.lstm2.lookahead
        self._L = (L1, L2)
        self._codes: deque = deque(maxlen=L1 + 1)
        self._gi1: deque = deque(maxlen=L1 + 1)
        self._y1: deque = deque(maxlen=L2 + 1)
        self._gi2: deque = deque(maxlen=L2 + 1)
        self._k = _numpy_weights(self.net)
        self._root_order = skeleton.rotation_order(0)
        self._x: deque = deque(maxlen=2 * HALF_WINDOW + 1)
        self._d2: deque = deque(maxlen=NOISE_WINDOW)  # squared second differences, for the noise-level input
        self._rows: deque = deque(maxlen=HALF_WINDOW + 1)
        H = self.net.lstm1.hidden
        self._s1 = self._s2 = (np.zeros(H), np.zeros(H))  # forward (h, c) of the two layers
        self._p = 0  # padded positions processed
        self._prev_q = None
        self._ref = None
        self._started = False
        self._calibrate = bool(calibrate) and self.net.head_kind == "gaussian"  # as denoise_channels
        self._block = int(round(BLOCK_S * m.fps))
        self._ready = max(-(-self._block // 2), READ_BEYOND + HALF_WINDOW)  # frames after a block that fix it
        self.lag = self._block + self._ready - 1 if self._calibrate else HALF_WINDOW
        """Frames between a push and the frame its returned row is of."""
        self._wrapped = wrapped_channels(self._k["std"])
        self._pushed = 0  # frames pushed
        self._lo = 0  # the first frame of the block not yet calibrated
        self._xs: list = []  # padded positions from self._xs0 on: the network's inputs (float32, as offline)
        self._xs0 = 0
        self._held: list = []  # frames from self._lo - len(context) on: (log sigma, bias, row)
        self._held0 = 0
        self._queue: deque = deque()  # cleaned rows waiting for their turn

    def _inputs(self, row: np.ndarray):
        branch = row.copy()  # each 3-axis triple nearest the frame before's, as channels.euler_values, causally
        for order, idx in self._triples:
            start = None if self._branch is None else self._branch[idx]
            branch[idx] = R.continuous_euler(row[idx][None], order, start=start)[0]
        self._branch = branch
        raw = branch[self._cols]
        if self._ref is None:
            self._ref = raw.copy()
        u = self._ref + (np.mod(raw - self._ref + 180.0, 360.0) - 180.0)  # as channels.unwrap_degrees
        self._ref = self._ref + UNWRAP_ALPHA * (u - self._ref)
        order = self._root_order
        q = R.euler_to_quaternion(row[self._root], order) if order else R.identity()
        if self.skeleton.axes is not None:
            q = _conjugated(self.skeleton.axes[0], q)
        w = np.zeros(3) if self._prev_q is None else _omega(self._prev_q, q, self.fps)
        self._prev_q = q
        return u, w

    def _step(self, x: np.ndarray, w: np.ndarray, row: np.ndarray):
        """One padded position: the network's layers on this frame in numpy (float64 weights).

        Exactly the offline network's arithmetic on one frame, without the
        per-call overhead of ~20 small PyTorch calls: the input projections
        of each position enter a deque once, the backward LSTM runs of
        L + 1 steps use them, the forward states persist.
        """
        k = self._k
        L1, L2 = self._L
        parts = [(x - k["mean"]) / k["std"]]
        if self.net.noise_input:  # networks.noise_level_feature, one frame at a time
            d = x - 2.0 * self._x[-1] + self._x[-2] if len(self._x) >= 2 else np.zeros_like(x)
            self._d2.append(d * d)
            parts.append(noise_level_step(np.array(self._d2), k["std"]))
        self._x.append(x)
        self._rows.append(row)
        if self._calibrate:
            self._xs.append(x.astype(np.float32))
        e = _mlp_forward(k["encoder"], np.concatenate(parts + [w / k["ctx_scale"]]), True)
        self._codes.append(e)
        self._gi1.append(_affine(k["b1"][0], e, k["b1"][2]))
        p = self._p
        self._p += 1
        if p - L1 < 0:
            return None
        self._s1 = _lstm_steps(_affine(k["f1"][0], self._codes[0], k["f1"][2])[None], *self._s1, k["f1"][1])
        f1 = self._s1[0]
        y1 = np.concatenate([f1, _lstm_backward(self._gi1, k["b1"][1])])
        self._y1.append(y1)
        self._gi2.append(_affine(k["b2"][0], y1, k["b2"][2]))
        if p - L1 - L2 < 0:
            return None
        self._s2 = _lstm_steps(_affine(k["f2"][0], self._y1[0], k["f2"][2])[None], *self._s2, k["f2"][1])
        f2 = self._s2[0]
        y2 = np.concatenate([f2, _lstm_backward(self._gi2, k["b2"][1])])
        t = p - HALF_WINDOW
        if t < HALF_WINDOW:
            return None
        out = _mlp_forward(k["head"], y2, False)
        C = self.net.channels
        win = np.stack(self._x)  # positions t-15 .. t+15, (31, C)
        if self.net.head_kind == "gaussian":
            log_sigma = np.clip(out[:C], *LOG_SIGMA_RANGE)
            if self._calibrate:  # filtered once its block is calibrated (_calibrated)
                bias = out[-C:] * k["std"] if self.net.with_bias else None
                self._held.append((log_sigma.astype(np.float32), bias, np.array(self._rows[0], dtype=np.float64)))
                return None
            res_c = gaussian_filter_frames(win, log_sigma[None])[0]
        else:
            logits = out[: C * (2 * HALF_WINDOW + 1)].reshape(C, 2 * HALF_WINDOW + 1)
            taps = np.exp(logits - logits.max(axis=1, keepdims=True))
            res_c = np.sum(win.T * taps, axis=1) / taps.sum(axis=1)
        if self.net.with_bias:
            res_c = res_c - out[-C:] * k["std"]
        res = np.array(self._rows[0], dtype=np.float64)
        res[self._cols] = (res_c + 180.0) % 360.0 - 180.0
        return res

    def push(self, row) -> np.ndarray | None:
        """Add one frame of file channels (C_file,); returns the cleaned row 15 frames back, or None."""
        row = np.asarray(row, dtype=np.float64)
        if row.shape != (self._n_file,):
            raise ValueError(f"a row has {self._n_file} channels (the skeleton's, in file order), got shape {row.shape}")
        if not np.all(np.isfinite(row)):
            raise ValueError("streaming input rows must be finite (fill gaps first)")
        x, w = self._inputs(row)
        if not self._started:
            self._started = True
            for _ in range(HALF_WINDOW):  # edge padding, as offline
                self._step(x, np.zeros(3), row)
        self._last = (x, row)
        out = self._step(x, w, row)
        if not self._calibrate:
            return out
        self._pushed += 1
        if self._pushed >= self._lo + self._block + self._ready:  # the block's edges are the whole take's
            self._queue.extend(self._calibrated(self._lo, self._lo + self._block))
        return self._queue.popleft() if self._queue else None

    def flush(self) -> list[np.ndarray]:
        """Emit the frames still waiting for look-ahead (end of take: the last frame is held)."""
        if not self._started:
            return []
        x, row = self._last
        out = []
        for _ in range(HALF_WINDOW):
            r = self._step(x, np.zeros(3), row)
            if r is not None:
                out.append(r)
        if self._calibrate:
            edges = block_edges(self._pushed, self._block)
            for lo, hi in zip(edges[:-1], edges[1:]):
                if lo >= self._lo:
                    self._queue.extend(self._calibrated(int(lo), int(hi)))
            out = list(self._queue)
            self._queue.clear()
        return out

    def _calibrated(self, lo: int, hi: int) -> list[np.ndarray]:
        """The cleaned rows of frames [lo, hi), one block, by the offline calibration
        (:func:`~mocapkit.cleaning.deep.sure.calibrated_log_sigma` on the block with
        :data:`~mocapkit.cleaning.deep.sure.READ_BEYOND` frames either side, where the take has them)."""
        a, e = max(0, lo - READ_BEYOND), min(self._pushed, hi + READ_BEYOND)
        xp = np.stack(self._xs[a - self._xs0 : e + 2 * HALF_WINDOW - self._xs0])  # (e - a + 30, C) float32
        held = self._held[a - self._held0 : e - self._held0]
        log_sigma = np.stack([h[0] for h in held])
        edges = np.unique(np.array([0, lo - a, hi - a, e - a]))
        cal = calibrated_log_sigma(xp, log_sigma, np.ones(log_sigma.shape, dtype=bool), edges, HALF_WINDOW,
                                   scoring_stride(self.model.fps), self.model.fps, self._wrapped)
        res_c = gaussian_filter_frames(xp[lo - a : hi - a + 2 * HALF_WINDOW], cal[lo - a : hi - a])
        rows = []
        for k, (_, bias, row) in enumerate(held[lo - a : hi - a]):
            res = row.copy()
            c = res_c[k] if bias is None else res_c[k] - bias
            res[self._cols] = (c + 180.0) % 360.0 - 180.0
            rows.append(res)
        self._lo = hi
        keep = max(0, hi - READ_BEYOND)  # the next block's context on
        del self._xs[: keep - self._xs0], self._held[: keep - self._held0]
        self._xs0 = self._held0 = keep
        return rows


def _numpy_weights(net: EBF) -> dict:
    """The EBF's weights as float64 numpy arrays for the streaming path (eval mode: no dropout)."""
    def a(t):
        return t.detach().cpu().double().numpy()

    def mlp(seq):
        return [(a(m.weight), a(m.bias)) for m in seq if isinstance(m, torch.nn.Linear)]

    def lstm(m):  # (W_ih, W_hh, b_ih + b_hh), gate order i, f, g, o
        return a(m.weight_ih_l0), a(m.weight_hh_l0), a(m.bias_ih_l0) + a(m.bias_hh_l0)

    return {"encoder": mlp(net.encoder), "head": mlp(net.head), "f1": lstm(net.lstm1.fwd), "b1": lstm(net.lstm1.bwd),
            "f2": lstm(net.lstm2.fwd), "b2": lstm(net.lstm2.bwd), "mean": a(net.mean), "std": a(net.std),
            "ctx_scale": a(net.ctx_scale)}


@njit(cache=True)
def _affine(W: np.ndarray, v: np.ndarray, b: np.ndarray) -> np.ndarray:
    """W v + b in plain loops: for one frame's small layers this beats a (threaded) BLAS call."""
    out = b.copy()
    for r in range(W.shape[0]):
        acc = 0.0
        for q in range(W.shape[1]):
            acc += W[r, q] * v[q]
        out[r] += acc
    return out


def _mlp_forward(layers, v: np.ndarray, last_tanh: bool) -> np.ndarray:
    for k, (W, b) in enumerate(layers):
        v = _affine(W, v, b)
        if k < len(layers) - 1 or last_tanh:
            v = np.tanh(v)
    return v


@njit(cache=True)
def _lstm_steps(gis: np.ndarray, h: np.ndarray, c: np.ndarray, w_hh: np.ndarray):
    """PyTorch's LSTM cell (gates i, f, g, o) over input gates ``gis`` (n, 4H) in order from state (h, c).

    Returns the new (h, c); the inputs are not modified.
    """
    H = w_hh.shape[1]
    h = h.copy()
    c = c.copy()
    g = np.empty(4 * H)
    for n in range(gis.shape[0]):
        for r in range(4 * H):
            acc = gis[n, r]
            for q in range(H):
                acc += w_hh[r, q] * h[q]
            g[r] = acc
        for q in range(H):
            i = 1.0 / (1.0 + np.exp(-g[q]))
            f = 1.0 / (1.0 + np.exp(-g[H + q]))
            gg = np.tanh(g[2 * H + q])
            o = 1.0 / (1.0 + np.exp(-g[3 * H + q]))
            c[q] = f * c[q] + i * gg
            h[q] = o * np.tanh(c[q])
    return h, c


def _lstm_backward(gis, w_hh: np.ndarray) -> np.ndarray:
    """The backward direction's output at the window's first position: from zero state, last to first."""
    H = w_hh.shape[1]
    return _lstm_steps(np.stack(gis)[::-1].copy(), np.zeros(H), np.zeros(H), w_hh)[0]


def _root_rotation_columns(skeleton: Skeleton) -> np.ndarray:
    chans = skeleton.joint_channels(0)
    return np.array([k for k, c in enumerate(chans) if c.endswith("rotation")], dtype=np.int64)


def _conjugated(c: np.ndarray, q: np.ndarray) -> np.ndarray:
    """c q c^-1 for one unit quaternion (the ASF axis frame), as :func:`_root_quaternion` does for rows."""
    return R.quaternion_multiply(R.quaternion_multiply(c, q), R.quaternion_conjugate(c))


def _omega(prev: np.ndarray, q: np.ndarray, fps: float) -> np.ndarray:
    """:func:`root_angular_velocity` of one frame pair: rotvec(prev^-1 q) * fps, rad/s, (3,)."""
    r = R.quaternion_multiply(R.quaternion_conjugate(prev), q)
    if r[0] < 0.0:
        r = -r
    s = math.sqrt(r[1] * r[1] + r[2] * r[2] + r[3] * r[3])
    scale = math.atan2(s, r[0]) / s if s > 1e-12 else 1.0 + s * s / 6.0
    out = 2.0 * fps * scale * r[1:]
    return np.zeros(3) if np.any(np.isnan(out)) else out


def _root_quaternion(skeleton: Skeleton, rows: np.ndarray, root_cols: np.ndarray) -> np.ndarray:
    order = skeleton.rotation_order(0)
    if not order:
        return R.identity((len(rows),))
    q = R.euler_to_quaternion(rows[:, root_cols], order)
    if skeleton.axes is not None:
        c = skeleton.axes[0]
        q = R.quaternion_multiply(R.quaternion_multiply(c, q), R.quaternion_conjugate(c))
    return q


def denoise_rows(skeleton: Skeleton, rows: np.ndarray, fps: float, model=None, calibrate: bool = False) -> np.ndarray:
    """Offline EBF on file-channel rows (F, C_file), the batch counterpart of :class:`Denoiser`: the same numbers as
    streaming with the same ``calibrate`` (True: the widths calibrated as :func:`~mocapkit.cleaning.deep.denoise`
    calibrates them; False: the network's own).

    ``skeleton``: a :class:`~mocapkit.motion.Skeleton` (``motion.skeleton``); ``rows``: numbers (F, C_file) in the
    skeleton's file-channel layout (``motion.channel_values()``), degrees; ``fps``: their frame rate. Anything
    else is refused at the entry with a ``TypeError`` naming what was given (a Motion for either, most often).
    """
    if not isinstance(skeleton, Skeleton):
        raise TypeError(f"denoise_rows: skeleton must be a Skeleton (motion.skeleton), got {type(skeleton).__name__}")
    try:
        arr = np.asarray(rows, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"denoise_rows: rows must be an array (F, C) of file-channel values "
                        f"(motion.channel_values()), got {type(rows).__name__}") from None
    if arr.ndim != 2:
        raise ValueError(f"denoise_rows: rows must be 2-D (F, C) file-channel values, got shape {arr.shape}")
    m = model_of_kind(model, "ebf", skeleton)
    warn_licence(m, {"ebf": "model="})
    m.layout.check(skeleton, "skeleton")
    rows = arr
    cols = euler_columns(skeleton)
    x = euler_values(rows, skeleton)  # each joint's triple on one branch, as deep.denoise and streaming read it
    q = _root_quaternion(skeleton, rows, _root_rotation_columns(skeleton))
    out = denoise_channels(x, root_angular_velocity(q, fps), m, fps=fps, calibrate=calibrate)  # as streaming runs
    res = rows.copy()
    res[:, cols] = (out + 180.0) % 360.0 - 180.0
    return res
