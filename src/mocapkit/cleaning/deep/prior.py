"""A Gaussian prior of the joint-angle channels around a frame, and gap filling by its conditional mean.

Mall et al. 2017 (section 4.2, Fig. 10) fill long gaps with the EBD because "the
remarkably accurate reconstructions can be attributed to learning correlations of the
missing joint channel with all other joint channels in the skeleton, as well as temporal
coherence". The simplest learnt model of exactly those correlations is a Gaussian over the
vector of every channel at a few time offsets, ``v(t) = [x(t + l) for l in lags]`` (the
dimensionality-reduction fills Mall et al. cite, Liu and McMillan 2006, Park and Hodgins
2006, are its low-rank cases), in standardised units (each entry of ``v`` minus its training
mean, over its training standard deviation plus one degree): ``z(t)``, covariance ``S``.

A gap is filled as a whole. Every frame ``t`` whose window ``v(t)`` reaches into the gap
contributes the energy ``z(t)^T (S + lambda I)^-1 z(t)`` (a Gaussian field: one factor per
frame, overlapping in time), and the gap entries are the minimiser of the sum, the conditional
mean of the gap given everything observed around it under that field: a sparse, banded linear
system. The missing channels' own samples on either side of the gap enter through the lags,
and so does every other channel over and around the gap; ``lambda`` (the ridge) stands for the
noise of what is read. With :attr:`GapPrior.ramp` the missing channels' own samples within twice
the lags' reach of the gap are not read (solved for too), and the field's fill is offset to meet
the observed samples at both ends of the gap by a linear ramp: the fill then knows as little at
the gap's ends as in its middle, so the offsets measured at the ends correct its level over the
whole gap, and where the prior predicts the take poorly the fill falls back towards the line
between the ends instead of sagging towards the prior's mean in the middle. Without it, the
field reads those samples and its own reading of the ends stands. Each model chooses on its
validation clips (docs/models.md).

Before it fills, the take updates the prior: the mean and covariance of its own complete
frames are pooled with the prior's, the prior counting as :data:`PRIOR_S` seconds of frames. A
performer's own way of moving, and a motion the take repeats (the self-similarity Aristidou et
al. 2018 build on), then outweigh the training clips' average.

A long gap can draw a prior of its own from the training windows nearest the motion around it
(:func:`local_prior`, when the prior keeps its training frames: the shipped Acclaim one), pooled
with the take's global prior: the local models of Tautges (2012) and Krüger et al. (2010) in
this linear setting.

Euler channels are angles: unwrapped along time, a channel that sits near +-180 deg (a game rig's
thighs) lands at +180 in one take and -180 in the next, and the pelvis' heading turns freely over a
take (1076 deg on a Bandai Namco kick). One Gaussian over such a channel sees several modes 360 deg
apart and its mean falls between them, where a fill that reads little (several joints lost at once,
a gap to a take's end) drifts to. A prior fitted with branches (:attr:`GapPrior.branch`) puts every
channel on one branch: each training window ``v(t)`` is shifted, channel by channel, by the multiple
of 360 deg that brings its frame ``t`` nearest the channel's circular mean over the training data;
a gap event is filled with the take's channels shifted the same way (one multiple per channel over
the event's frames, :func:`branch_turns`), and its fill shifted back, so it continues the take's own
branch. A channel that turns freely (the pelvis' heading: over 180 deg within a take in at least
:data:`TURNING_SHARE` of the training takes) keeps no branch and is read as it is: put on one branch
window by window, its windows spread over the whole circle, and the narrower Gaussian drew a Bandai
pelvis gap's fill further towards the training heading (1-4 s gaps of the held-out styles' Hips 68 ->
82 deg RMS).

Such a channel has no mean to fall back on, and a gap that runs to the take's start or end has no far
side to meet: read as it is, its fill drifts towards the prior's mean heading (another Euler branch of
the pelvis of a take that faces the other way: tens of degrees off, up to 180). There the joint that
carries it is held at its one seen end (:func:`held_channels`) and every other channel is filled
reading the held joint, as the line between a gap's ends holds at a take's end.

A :class:`GapPrior` belongs to an EBD model (fitted on the same training clips, saved in
the same file, :func:`fit_gap_prior`); :func:`~mocapkit.cleaning.deep.inference.fill_channels`
uses it where it validated better than the network (see that function).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve, solveh_banded
from scipy.ndimage import gaussian_filter1d
from threadpoolctl import threadpool_limits

from ..markers.gaps import gap_runs
from ..runs import column_runs, run_cells
from .blindspot import WEIGHT as CROSS_WEIGHT
from .blindspot import cross_channel_prediction, noise_share
from .channels import lerp_fill
from .column_statistics import column_means, column_medians, column_quantiles

__all__ = ["GapPrior", "fit_gap_prior", "conditional_fill", "pair_band", "lagged", "lag_frames", "local_prior", "local_windows",
           "LAGS_S", "RIDGE", "PRIOR_S", "branch_turns", "branch_lagged", "circular_mean",
           "held_channels"]

SMOOTH_S = 0.058
"""Std (s) of the Gaussian that smooths the observed channels before they are read as evidence (Mall's 58 ms
baseline filter): the field reads the motion, not the capture noise."""


@dataclass(frozen=True)
class GapPrior:
    """Mean and covariance of lagged channel vectors, standardised.

    lags : (L,) int frame offsets at the model's frame rate, 0 among them;
    mean, scale : (C * L,) the training mean and standard deviation (+1 degree) of each
    entry of ``v(t)`` (lag-major: entry ``l * C + c`` is channel ``c`` at ``lags[l]``);
    cov : (C * L, C * L) covariance of the standardised entries; ridge : ``lambda``
    added to the covariance of what is read; frames : training frames used; ramp : whether
    a fill is offset to meet the observed samples at the gap's ends (module docstring).
    local_frames : (N, C) float32 or None: training frames, one in ``local_step`` of the model's rate,
    whose windows a long gap's local prior is drawn from (:func:`local_prior`; None: the global
    prior fills every gap); local_starts : (clips + 1,) int64, where each training clip's frames
    begin in ``local_frames`` (windows never straddle two clips); local_step : frames of the model's
    rate per stored frame (every lag a multiple of it).
    branch : (C,) float64 degrees or None: each channel's reference angle (its circular mean over the training
    frames); every window was shifted by whole turns towards it before the fit (:func:`branch_lagged`, module
    docstring); NaN for a channel that turns freely (read as it is). None (a prior written before branches):
    every channel read as it is.
    """

    lags: np.ndarray
    mean: np.ndarray
    scale: np.ndarray
    cov: np.ndarray
    ridge: float
    frames: int
    ramp: bool = True
    local_frames: np.ndarray | None = None
    local_starts: np.ndarray | None = None
    local_step: int = 1
    branch: np.ndarray | None = None

    @property
    def num_channels(self) -> int:
        return len(self.mean) // len(self.lags)

    def to_arrays(self) -> dict:
        """The prior as plain arrays (for a model file)."""
        out = {"lags": np.asarray(self.lags, dtype=np.int64), "mean": self.mean, "scale": self.scale,
               "cov": self.cov, "ridge": np.float64(self.ridge), "frames": np.int64(self.frames),
               "ramp": np.bool_(self.ramp)}
        if self.branch is not None:
            out["branch"] = np.asarray(self.branch, dtype=np.float64)
        if self.local_frames is not None:
            out.update(local_frames=np.asarray(self.local_frames, dtype=np.float32),
                       local_starts=np.asarray(self.local_starts, dtype=np.int64), local_step=np.int64(self.local_step))
        return out

    @classmethod
    def from_arrays(cls, d: dict) -> "GapPrior":
        lags = np.asarray(d["lags"], dtype=np.int64).reshape(-1)
        mean = np.asarray(d["mean"], dtype=np.float64).reshape(-1)
        scale = np.asarray(d["scale"], dtype=np.float64).reshape(-1)
        cov = np.asarray(d["cov"], dtype=np.float64)
        n = len(mean)
        if (0 not in lags.tolist() or n % len(lags) or scale.shape != (n,) or cov.shape != (n, n)
                or not np.all(scale > 0) or not np.all(np.isfinite(cov))):
            raise ValueError("inconsistent gap prior arrays")
        branch = d.get("branch")
        if branch is not None:
            branch = np.asarray(branch, dtype=np.float64).reshape(-1)
            if branch.shape != (n // len(lags),) or np.isinf(branch).any():
                raise ValueError("inconsistent gap prior arrays (branch)")
        local = d.get("local_frames")
        if local is None:
            return cls(lags, mean, scale, cov, float(d["ridge"]), int(d["frames"]), bool(d.get("ramp", True)),
                       branch=branch)
        local = np.asarray(local, dtype=np.float32)
        starts = np.asarray(d["local_starts"], dtype=np.int64).reshape(-1)
        step = int(d["local_step"])
        if (local.ndim != 2 or local.shape[1] != n // len(lags) or step < 1 or np.any(lags % step) or len(starts) < 2
                or starts[0] != 0 or starts[-1] != len(local) or np.any(np.diff(starts) < 0)
                or not np.all(np.isfinite(local))):
            raise ValueError("inconsistent gap prior arrays (local frames)")
        return cls(lags, mean, scale, cov, float(d["ridge"]), int(d["frames"]), bool(d.get("ramp", True)),
                   local, starts, step, branch)


def lagged(x: np.ndarray, lags) -> np.ndarray:
    """(F, C) channels -> (F, C * L) vectors ``[x(t + l) for l in lags]``, frames clamped at the ends."""
    x = np.asarray(x)
    F, C = x.shape[0], x.shape[1]
    out = np.empty((F, C * len(lags)), dtype=x.dtype)
    if F == 0:
        return out
    for k, lag in enumerate(lags):  # shifted slices, the ends held: no gather of F index rows per lag
        col = out[:, k * C:(k + 1) * C]
        lag = int(lag)
        n = max(F - abs(lag), 0)  # frames whose t + lag falls inside the take
        if lag >= 0:
            col[:n] = x[F - n:]
            col[n:] = x[F - 1]
        else:
            col[F - n:] = x[:n]
            col[:F - n] = x[0]
    return out


def circular_mean(takes) -> np.ndarray:
    """(C,) degrees in (-180, 180]: each channel's circular mean over every frame of ``takes`` (list of (F, C)
    arrays in degrees), ``atan2(mean sin, mean cos)``; 0 where the angles cancel out."""
    s = sum(np.sin(np.radians(np.asarray(x, dtype=np.float64))).sum(axis=0) for x in takes)
    c = sum(np.cos(np.radians(np.asarray(x, dtype=np.float64))).sum(axis=0) for x in takes)
    return np.degrees(np.arctan2(s, c))


TURNING_SHARE = 0.05
"""A channel turns freely (keeps no branch, :func:`fit_gap_prior`) when it spans over 180 deg within a take in at
least this share of the training takes: on the Bandai training takes the pelvis' Z and Y (15 %), every other
channel at most 2 %."""


def branch_turns(x: np.ndarray, branch: np.ndarray) -> np.ndarray:
    """Whole turns (int, same shape as ``x``) that bring degrees ``x`` (..., C) nearest ``branch`` (C,) degrees:
    ``x - 360 * turns`` lies within 180 deg of it; 0 where ``branch`` is NaN (a channel read as it is)."""
    d = np.asarray(x, dtype=np.float64) - branch
    return np.round(np.where(np.isnan(d), 0.0, d) / 360.0).astype(np.int64)


def branch_lagged(x: np.ndarray, lags, branch: np.ndarray | None) -> np.ndarray:
    """(F, C * L) :func:`lagged` windows of (F, C) degrees ``x``, each window's channel ``c`` shifted by the whole
    turns that bring its frame ``t`` (lag 0) nearest ``branch[c]`` (:func:`branch_turns`): every window on one
    branch, its lags kept continuous (module docstring). ``branch`` None: :func:`lagged` as is."""
    v = lagged(x, lags)
    if branch is None:
        return v
    v = v.astype(np.float64, copy=False)  # the dtype ``v - 360.0 * turns`` had (float32 windows promoted, exactly)
    turns = 360.0 * branch_turns(x, branch)  # (F, C): each lag's block shifted in place, no (F, C * L) temporaries
    C = turns.shape[1]
    for k in range(len(lags)):
        v[:, k * C:(k + 1) * C] -= turns
    return v


LAGS_S = (1 / 15, 2 / 15, 4 / 15)
"""The prior's time offsets (s), each before and after the frame, and the frame itself: 2, 4 and 8 frames at
30 fps, 8, 16 and 32 at 120 fps. Chosen on the validation actor and styles among sets reaching 0.27-0.53 s with
three to eleven lags (a single quarter second, the first prior's, filled 1-4 s gaps 3-6 % worse)."""

RIDGE = 0.03
"""``lambda``, in units of the standardised entries' variance (chosen with :data:`LAGS_S` among 0.001-0.3)."""

PRIOR_S = 1.0
"""How many seconds of the take's own frames the prior counts as when the take's complete frames update it
(:func:`conditional_fill`; chosen on the validation actor and styles among 0.5-10 s, 0.5-2 s within a few
per cent)."""


LOCAL_K = 512
"""Training windows nearest each query frame of a long gap that make its local prior (:func:`local_prior`)."""

LOCAL_N0 = 300.0
"""How many windows' worth the take's global prior counts as against a long gap's neighbours (:func:`local_prior`)."""

LOCAL_QUERIES = 8
"""Query frames spread over a long gap, each looking up :data:`LOCAL_K` neighbours (:func:`local_prior`)."""

LOCAL_MIN_S = 0.5
"""Seconds: the shortest gap filled with a local prior (:func:`local_prior`); a shorter one is filled by its ends
and the global prior."""


def lag_frames(fps: float, lags_s=LAGS_S) -> np.ndarray:
    """(L,) sorted distinct frame offsets at ``fps``: 0 and each of ``lags_s`` before and after, at least one frame."""
    k = {max(1, int(round(float(l) * fps))) for l in lags_s}
    return np.array(sorted({0} | k | {-x for x in k}), dtype=np.int64)


def fit_gap_prior(takes, fps: float, lags_s=LAGS_S, ridge: float = RIDGE, ramp: bool = True, local_takes=None,
                  local_step: int | None = None, branch: bool = False) -> GapPrior:
    """Fit a :class:`GapPrior` on clean takes' channels (list of (F, C) arrays in degrees at ``fps``).

    Lags: :func:`lag_frames` of ``lags_s``; one frame in ``round(fps / 30)``
    enters (neighbouring frames say little more). ``ramp``: :attr:`GapPrior.ramp`.
    ``local_takes`` (list of (F, C) arrays, or None): the clips a long gap's local prior searches
    (:func:`local_prior`), kept one frame in ``local_step`` (default: the largest step every lag is a
    multiple of, at most ``round(fps / 15)``). ``branch``: every window put on one branch per channel first
    (:attr:`GapPrior.branch`, the circular mean of ``takes``' frames; NaN, no branch, for a channel that turns
    freely: :data:`TURNING_SHARE`; module docstring).
    """
    lags = lag_frames(fps, lags_s)
    stride = max(1, int(round(fps / 30.0)))
    ref = None
    if branch:
        if not all(np.all(np.isfinite(x)) for x in takes):
            raise ValueError("the gap prior needs finite training channels, two frames at least")
        kept = [np.asarray(x, dtype=np.float64) for x in takes if len(x)]
        ref = circular_mean(kept)
        turning = np.mean([np.ptp(x, axis=0) > 180.0 for x in kept], axis=0) >= TURNING_SHARE
        ref[turning] = np.nan
    v = [branch_lagged(np.asarray(x, dtype=np.float64), lags, ref)[::stride] for x in takes if len(x)]
    v = np.concatenate(v) if v else np.zeros((0, 0))
    if len(v) < 2 or not np.all(np.isfinite(v)):
        raise ValueError("the gap prior needs finite training channels, two frames at least")
    mean = v.mean(axis=0)
    scale = v.std(axis=0) + 1.0
    z = (v - mean) / scale
    cov = z.T @ z / len(z)
    if local_takes is None:
        return GapPrior(lags, mean, scale, cov, float(ridge), len(v), bool(ramp), branch=ref)
    nonzero = np.abs(lags[lags != 0])
    if local_step is None:
        g = int(np.gcd.reduce(nonzero)) if len(nonzero) else 1
        local_step = max(d for d in range(1, g + 1) if g % d == 0 and d <= max(1, round(fps / 15.0)))
    if local_step < 1 or np.any(lags % local_step):
        raise ValueError(f"local_step {local_step} must divide every lag ({lags.tolist()})")
    kept = [np.asarray(x, dtype=np.float64)[::local_step] for x in local_takes if len(x)]
    if not kept or not all(np.all(np.isfinite(x)) for x in kept):
        raise ValueError("the local prior needs finite training channels")
    starts = np.concatenate([[0], np.cumsum([len(x) for x in kept])]).astype(np.int64)
    return GapPrior(lags, mean, scale, cov, float(ridge), len(v), bool(ramp),
                    np.concatenate(kept).astype(np.float32), starts, int(local_step), ref)


def local_windows(prior: GapPrior) -> np.ndarray:
    """(N, C * L) float32 the standardised windows ``z`` of the prior's local training frames (clip by clip,
    clamped at each clip's ends, as :func:`fit_gap_prior` makes them); (0, C * L) without local frames. Made once
    per prior object and kept on it (read-only): a shipped model is loaded once per process."""
    if prior.local_frames is None:
        return np.zeros((0, len(prior.mean)), dtype=np.float32)
    cached = prior.__dict__.get("_local_windows")
    if cached is not None:
        return cached
    x = np.asarray(prior.local_frames, dtype=np.float64)
    lags = prior.lags // prior.local_step
    v = [branch_lagged(x[a:b], lags, prior.branch) for a, b in zip(prior.local_starts[:-1], prior.local_starts[1:]) if b > a]
    w = ((np.concatenate(v) - prior.mean) / prior.scale).astype(np.float32)
    w.flags.writeable = False
    object.__setattr__(prior, "_local_windows", w)  # a cache beside the frozen fields, not one of them
    return w


def local_prior(windows: np.ndarray, query: np.ndarray, entries: np.ndarray, mean: np.ndarray, cov: np.ndarray,
                k: int = LOCAL_K, n0: float = LOCAL_N0, norms: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(mean (D,), covariance (D, D)) of the standardised windows near a gap: a kernel prior.

    One Gaussian for all motion leans every long gap towards the training clips' average
    relations between joints; the motion around a gap says which of them apply (a reach, a
    squat, a jog). As the local models of Tautges' reconstruction from sparse sensors (2012,
    the kernel priors of the online lazy neighbourhood graph) and Krüger et al.'s (2010) kNN
    search, the prior is drawn from the training windows nearest the take: ``windows`` (N, D)
    standardised (:func:`local_windows`), ``query`` (Q, D) the take's standardised windows at
    a few frames of the gap, compared on ``entries`` only (the channels read there: the
    missing ones' are unknown; with no entry read, as when every channel is missing over the gap,
    nothing says which windows are near, and the global prior is returned). The union of each
    query's ``k`` nearest windows (Euclidean)
    gives a mean and covariance, pooled with the take's global prior (``mean``, ``cov``,
    standardised) as ``n`` windows against ``n0``. On the Acclaim validation actor, 1-4 s
    whole-joint gaps at 0.5 noise: 0.692x -> 0.614x lerp + Gaussian (docs/models.md). The
    search and the neighbours' covariance run in the windows' own precision (float32 for
    :func:`local_windows`), the pooling in float64. ``norms`` (N,): the windows' squared norms as
    ``np.einsum("ij,ij->i", windows, windows)`` gives them, when the caller computed them once for many gaps.
    """
    n_all = len(windows)
    if n_all < 2 or len(query) == 0 or len(entries) == 0:  # nothing to compare on (a whole-body dropout): global
        return mean, cov
    k = max(1, min(int(k), n_all - 1))
    read = np.zeros(windows.shape[1], dtype=bool)
    read[entries] = True
    q = np.where(read, query, 0.0).astype(windows.dtype)  # entries not read weigh nothing in the product
    left = np.flatnonzero(~read)
    whole = np.einsum("ij,ij->i", windows, windows) if norms is None else norms
    norms = whole - np.einsum("ij,ij->i", windows[:, left], windows[:, left])
    d2 = norms[None, :] - 2.0 * (q @ windows.T)
    near = np.unique(np.argpartition(d2, k, axis=1)[:, :k].ravel())
    zl = windows[near]
    n = len(zl)
    ml = zl.mean(axis=0, dtype=np.float64)
    dl = zl - ml.astype(zl.dtype)
    a = n / (n + max(float(n0), 0.0))
    shift = ml - mean
    second = (dl.T @ dl).astype(np.float64) / n
    return (1.0 - a) * mean + a * ml, (1.0 - a) * cov + a * second + a * (1.0 - a) * np.outer(shift, shift)


def _take_update(z: np.ndarray, miss: np.ndarray, prior: GapPrior, n0: float):
    """(mean shift (D,), covariance (D, D) or None): the prior's standardised mean (0) and covariance pooled with
    those of the take's complete rows of ``z`` (no channel missing within the lags' reach), ``n0`` frames' worth
    of prior against the rows' count; (0, None) when fewer than 10 rows or ``n0`` is infinite.

    ``z`` (F, D) is consumed: its complete rows are moved to its front (:func:`complete_rows`) and centred there,
    in place, instead of copied (on an 18-minute 30 fps Bandai Namco take a (F, D) float64 array is 114 MB); the
    same rows in the same order, so the same numbers, bit for bit."""
    rows = ~lagged(np.any(miss, axis=1)[:, None], prior.lags).any(axis=1)  # a frame missing in any lag's reach
    n = int(rows.sum())
    if n < 10 or not np.isfinite(n0):
        return np.zeros(z.shape[1]), None
    d = complete_rows(z, rows)
    m = d.mean(axis=0)
    d -= m  # centred in place: the rows of z, no (n, D) copy
    w = n / (n + max(float(n0), 0.0))
    cov = (1.0 - w) * prior.cov + w * (d.T @ d / n) + w * (1.0 - w) * np.outer(m, m)
    return w * m, cov


def complete_rows(z: np.ndarray, rows: np.ndarray, block: int | None = None) -> np.ndarray:
    """``z[rows]`` (n, D) written over the first ``n`` rows of ``z`` (F, D) and returned as that view: ``rows`` (F,)
    bool, the rows kept in their order. Moved ``block`` rows at a time from the front (default: 1 MiB of rows; row
    ``i`` of the result comes from a row ``>= i``, never one already overwritten), so a long take's lagged windows
    are not copied whole; ``z``'s rows from ``n`` on are left as they were. ``z`` must be C-contiguous (the view is
    then too)."""
    if not z.flags.c_contiguous:
        raise ValueError("complete_rows needs a C-contiguous array")
    if block is None:
        block = max(1, (1 << 20) // max(1, z[:1].nbytes))
    idx = np.flatnonzero(rows)
    for i in range(0, len(idx), block):
        sel = idx[i:i + block]
        if sel[0] != i or sel[-1] != i + len(sel) - 1:  # rows already in place stay (no copy onto themselves)
            z[i:i + len(sel)] = z[sel]
    return z[:len(idx)]


def field_fill(base: np.ndarray, lags: np.ndarray, mean: np.ndarray, scale: np.ndarray, pcols: np.ndarray,
               read: np.ndarray, chans: np.ndarray, u0: int, u1: int, shift=None) -> np.ndarray:
    """(u1 - u0, k) values of channels ``chans`` over frames ``u0:u1`` that minimise the field's energy.

    ``shift`` (C,) or a number, optional: subtracted from ``base`` as read (``field_fill(base - shift, ...)``, the
    same numbers, bit for bit, without a copy of the whole take per call).

    ``base`` (F, C): the channels as read (values of ``chans`` inside ``u0:u1`` are ignored); ``read``: the
    channels the field reads (sorted, ``chans`` among them; the others are marginalised out); ``mean``, ``scale``:
    (L * R,) the entries' mean and scale over ``read`` at every lag, lag-major; ``pcols``: (L * R, L * k) the
    columns of the read entries' precision ``P = (S + lambda I)^-1`` (marginal) at the unknowns' entries, lag-major
    then ``chans``. Every frame ``t`` whose lagged window reaches into ``u0:u1`` adds ``z(t)^T P z(t)`` with
    ``z(t) = (v(t) - mean) / scale``; ``z`` is affine in the unknowns, so the minimiser solves ``H u = -g``,
    ``H`` banded, by a Cholesky of the band.

    When every lag is a multiple of ``m`` (8, 16 and 32 frames at 120 fps: ``m = 8``) and no window is clamped at
    a take's end, a window at ``t`` reads only frames of ``t``'s residue modulo ``m``: the unknowns of different
    residues never meet, and ordered residue by residue ``H`` is block-diagonal with a band ``m`` times narrower
    (``m^2`` times less work, the same numbers). Otherwise they are ordered frame by frame.
    """
    F = len(base)
    L, R, k = len(lags), len(read), len(chans)
    reach = int(np.abs(lags).max())
    t0 = max(0, u0 - reach)
    t = np.arange(t0, min(F, u1 + reach))
    fr = np.clip(t[:, None] + lags[None, :], 0, F - 1)  # (T, L)
    vals = base[fr] if shift is None else base[fr] - shift  # (T, L, C): the frames the windows read
    z = (vals[:, :, read].reshape(len(fr), L * R) - mean) / scale
    inside = (fr >= u0) & (fr < u1)
    q = np.arange(L)[:, None] * R + np.searchsorted(read, chans)[None, :]  # (L, k) the unknowns' entries
    coef = 1.0 / scale[q]  # (L, k): d z / d x of each
    ti, li = np.nonzero(inside)
    z[ti[:, None], q[li]] = -mean[q[li]] * coef[li]  # z at x = 0: the affine part
    nf = u1 - u0
    n = nf * k
    unclamped = np.array_equal(fr, t[:, None] + lags[None, :])
    m = int(np.gcd.reduce(np.abs(lags[lags != 0]))) if unclamped and (lags != 0).any() else 1
    r = np.arange(nf) % m
    first = np.cumsum(np.bincount(r, minlength=m)) - np.bincount(r, minlength=m)  # each residue's first slot
    slot = first[r] + np.arange(nf) // m  # (nf,) frame -> its place (frame order when m = 1)
    unk = slot[np.clip(fr - u0, 0, nf - 1)][:, :, None] * k + np.arange(k)  # (T, L, k) unknown index (where inside)
    pz = (z @ pcols).reshape(len(fr), L, k)
    g = np.bincount(unk[ti, li].ravel(), (coef[li] * pz[ti, li]).ravel(), minlength=n)
    blocks = pcols[q.ravel()].reshape(L, k, L, k).transpose(0, 2, 1, 3)  # (L, L, k, k): P between lag pairs
    # H[i, j] = sum over t and lag pairs (a, b) with both frames inside of coef * P * coef; the lower triangle is
    # stored by diagonal, band[i - j, j] = H[i, j]
    if unclamped:  # a lag pair's frames are (lags[a] - lags[b]) / m slots apart at every t: one diagonal per pair
        pa, pb = np.nonzero(lags[:, None] >= lags[None, :])
        d0 = (lags[pa] - lags[pb]) // m
        tt, pi = np.nonzero(inside[:, pa] & inside[:, pb])
        hit = np.zeros((len(pa), nf))
        hit[pi, slot[fr[tt, pb[pi]] - u0]] = 1.0  # the slots b's frame takes, pair by pair
        val = coef[pa][:, :, None] * blocks[pa, pb] * coef[pb][:, None, :]  # (P, k, k)
        bw = min(n - 1, int(d0.max()) * k + k - 1)
        band = pair_band(d0, val, hit, k, n, bw)
    else:  # clamped at a take's end: entry by entry
        tt, a, b = np.nonzero(inside[:, :, None] & inside[:, None, :])
        ua = np.broadcast_to(unk[tt, a][:, :, None], (len(tt), k, k))
        ub = np.broadcast_to(unk[tt, b][:, None, :], (len(tt), k, k))
        val = coef[a][:, :, None] * blocks[a, b] * coef[b][:, None, :]
        low = ua >= ub
        bw = min(n - 1, int((ua - ub).max()))
        band = np.bincount(((ua - ub) * n + ub)[low], val[low], minlength=(bw + 1) * n).reshape(bw + 1, n)
    u = solveh_banded(band, -g, lower=True, check_finite=False).reshape(nf, k)
    return u[slot]


def pair_band(d0: np.ndarray, val: np.ndarray, hit: np.ndarray, k: int, n: int, bw: int) -> np.ndarray:
    """(bw + 1, n) the lower band of :func:`field_fill`'s ``H`` added lag pair by lag pair (unclamped windows).

    ``d0`` (P,) int: each lag pair's distance in slots; ``val`` (P, k, k): its ``coef * P * coef`` block; ``hit``
    (P, nf): 1 at the slots its second frame takes (``n = nf * k``). ``band[d0 * k + j1 - j2, slot * k + j2] +=
    val[p, j1, j2] * hit[p, slot]`` for every pair ``p``, slot and channels ``j1``, ``j2`` on the band. A cell's
    column is ``j2`` modulo ``k`` and its diagonal ``j1 - j2`` modulo ``k``, so it belongs to one ``(j1, j2)``: one
    bincount over them all, ``(j1, j2)`` then pair then slot, sums each cell from 0 in the order of the
    ``np.add.at`` per ``(j1, j2)`` it replaces (the same numbers, bit for bit; one call instead of ``k^2``).
    """
    idx, wts = [], []
    for j1 in range(k):
        for j2 in range(k):
            row = d0 * k + j1 - j2
            ok = (row >= 0) & (row <= bw)
            idx.append((row[ok][:, None] * n + np.arange(j2, n, k)[None, :]).ravel())
            wts.append((val[ok, j1, j2][:, None] * hit[ok]).ravel())
    return np.bincount(np.concatenate(idx), np.concatenate(wts), minlength=(bw + 1) * n).reshape(bw + 1, n)


def conditional_fill(values: np.ndarray, prior: GapPrior, fps: float, prior_s: float = PRIOR_S,
                     smoothed: np.ndarray | None = None, cross: float = CROSS_WEIGHT, anchor: bool = True,
                     joints: np.ndarray | None = None) -> np.ndarray:
    """Fill the NaN entries of (F, C) channels by the prior's field; observed entries returned as is.

    The take teaches the prior first: its own complete frames (no channel
    missing within the lags' reach) give a mean and covariance, blended with
    the prior's as ``n`` frames against ``prior_s`` seconds' worth
    (``w = n / (n + prior_s * fps)``; the blend is the pooled mean and second
    moment of the two). A performer's own relations between joints, and a
    motion that repeats in the take (the self-similarity of Aristidou et al.
    2018), then outweigh the training clips' average; a short take or one
    mostly missing keeps the prior. ``prior_s=inf`` uses the prior alone.

    Each gap event (the channels missing over the same frames: a whole joint
    lost together is one event) is solved as a whole (:func:`field_fill`),
    reading every channel over the gap and ``2 max |lag|`` frames around it,
    the missing channels' own samples outside the gap among them; another
    channel missing anywhere there is not read (marginalised out: a Schur
    complement of the precision). Events are filled in time order; where the
    event's own channels miss elsewhere within its reach, it reads an earlier
    event's fill there (a later one's linear bridge). With
    :attr:`GapPrior.ramp`, the missing channels are solved for over
    ``2 max |lag|`` frames either side of the gap too (their own samples there
    not read), and the fill is offset to meet the observed (smoothed) samples
    at the gap's ends, linearly across it; at a take's end, the one observed
    side's offset holds; with ``anchor``, a clean take (:func:`is_clean_take`) is ramped so whatever the
    prior. With ``anchor``, on a channel whose samples are clean the fill then
    meets the samples themselves (:func:`anchor_ends`): the reading bends a
    clean motion, and a fill that met it left a step at each end (a 3-frame
    gap of a clean take filled 3 deg off where a straight line was 0.2 off).
    ``fps`` is the channels' rate (the prior's lags are frames at that rate).

    ``smoothed``: the channels as the field reads them, (F, C), NaN
    where missing (linearly bridged here): the observed samples denoised,
    e.g. by the EBF (:func:`~mocapkit.cleaning.deep.inference.fill_channels`
    passes it at low rates, where the fixed Gaussian leaves much noise).
    Default: the 58 ms Gaussian of :data:`SMOOTH_S`. ``cross``: the largest
    weight, in that reading, of each observed channel as the take's other
    channels predict it
    (:func:`~mocapkit.cleaning.deep.blindspot.cross_channel_prediction`,
    which never reads the channel's own sample at the frame); per channel it
    is scaled by the share of the prediction's residual that noise explains
    (:func:`~mocapkit.cleaning.deep.blindspot.noise_share`), so a clean take
    reads its channels about as before. 0: the smoothed channels alone, as
    does a take with less than
    :data:`~mocapkit.cleaning.deep.blindspot.MIN_SECONDS` of complete frames.
    The other joints' word removes noise a filter of one channel leaves: 1-4 s
    whole-joint gaps at 0.5 noise 1.6-1.8 % less error on both rigs'
    validation clips, within 0.1 % without noise (docs/models.md).

    ``joints`` (C,) int, optional: each channel's joint. A gap running to the take's start or end holds
    every channel of a joint that has a freely turning channel (:func:`held_channels`: the pelvis, whose
    heading has no branch) at its one seen end, and the other events are filled reading it; None: each
    channel its own joint (the freely turning channels alone are held).

    BLAS runs on one thread throughout, so the fill is the same to the last bit on any machine and
    under any executor (OpenBLAS splits its sums by its thread count). The long gaps' local priors, which read
    the take as it was before any fill, are made first, in two fixed halves on two threads
    (:func:`~mocapkit.cleaning.deep.threads.run_in_parts`), each call still one BLAS thread.
    """
    with threadpool_limits(1, user_api="blas"):
        return _conditional_fill(values, prior, fps, prior_s, smoothed, cross, anchor, joints)


def held_channels(prior: GapPrior, joints: np.ndarray | None = None) -> np.ndarray | None:
    """(C,) bool, the channels a gap running to the take's start or end holds at its one seen end; None when none.

    Every channel of a joint (``joints`` (C,) int, each channel's joint; None: each channel its own) that has a
    freely turning channel (NaN in :attr:`GapPrior.branch`: the Bandai Namco pelvis' Z and Y). Such a channel
    has no mean to fall back on: read as it is, a fill with no far side to meet drifts towards the training
    clips' heading, and on this rig the pelvis' Euler angles carry the heading between all three channels
    (X is the heading, Z and Y flip by 180 deg where it passes +-90 deg), so the whole joint is held. On the
    Bandai validation styles, the pelvis lost for 1-5 s to a take's end with two other joints lost inside:
    its rotation 19.7 deg RMS off the truth (geodesic) as the field filled it, 14.2 with Z and Y held and X
    read from the field, 12.9 with the joint held; its heading 17.3, 13.5 and 11.7 deg.
    """
    if prior.branch is None or not np.isnan(prior.branch).any():
        return None
    free = np.isnan(prior.branch)
    if joints is None:
        return free
    joints = np.asarray(joints)
    if joints.shape != free.shape:
        raise ValueError(f"joints must name one joint per channel ({free.shape[0]}), got shape {joints.shape}")
    return np.isin(joints, joints[free])


def _conditional_fill(values, prior: GapPrior, fps: float, prior_s: float, smoothed, cross: float,
                      anchor: bool, joints=None) -> np.ndarray:
    x = np.asarray(values, dtype=np.float64)
    F, C = x.shape
    if C != prior.num_channels:
        raise ValueError(f"the gap prior has {prior.num_channels} channels, the values {C}")
    miss = np.isnan(x)
    out = x.copy()
    if not miss.any():
        return out
    if smoothed is None:
        base = gaussian_filter1d(lerp_fill(x), SMOOTH_S * fps, axis=0, mode="nearest")
    else:
        read = np.asarray(smoothed, dtype=np.float64)
        if read.shape != x.shape or not np.isfinite(read[~miss]).all():
            raise ValueError(f"smoothed must be (F, C) = {x.shape} channels, finite where observed; got {read.shape}")
        base = lerp_fill(np.where(miss, np.nan, read))
    pred = cross_channel_prediction(x, fps) if cross > 0 else None
    if pred is not None:  # and as the other joints predict them
        w = cross * noise_share(x, pred)  # per channel: the prediction's weight where noise is what it removes
        base = lerp_fill(np.where(miss, np.nan, (1.0 - w) * base + w * pred))
    lags = prior.lags
    z = branch_lagged(base, lags, prior.branch)  # (F, C * L), standardised in place: a long take's largest array
    z -= prior.mean
    z /= prior.scale
    events: dict[tuple[int, int], list[int]] = {}
    for c in np.flatnonzero(miss.any(axis=0)):
        for s, e in zip(*gap_runs(miss[:, c])):
            events.setdefault((int(s), int(e)), []).append(int(c))
    local = prior.local_frames is not None and any(e - s >= LOCAL_MIN_S * fps for s, e in events)
    # the long events' query windows, kept before _take_update consumes z (its complete rows moved in place)
    queries = {(s, e): z[np.arange(s, e, max(1, (e - s) // LOCAL_QUERIES))]
               for s, e in events if local and e - s >= LOCAL_MIN_S * fps}
    shift, cov = _take_update(z, miss, prior, prior_s * fps)
    del z
    cov = prior.cov if cov is None else cov
    mean = prior.mean + shift * prior.scale
    local_model = None
    if local:
        windows = local_windows(prior)
        norms = np.einsum("ij,ij->i", windows, windows)  # once for every long gap of the take

        def own_model(s: int, e: int, chans: np.ndarray):
            """A long event's local prior (mean, covariance, precision)."""
            read = np.setdiff1d(np.arange(C), chans)
            entries = (np.arange(len(lags))[:, None] * C + read[None, :]).ravel()
            lm, lc = local_prior(windows, queries[(s, e)], entries, shift, cov, LOCAL_K, LOCAL_N0, norms)
            return prior.mean + lm * prior.scale, lc, np.linalg.inv(lc + prior.ridge * np.eye(len(lc)))

        # a local prior reads the take as read before any fill (z), never another event's fill: the long events'
        # are made up front, in two fixed halves on two threads (each BLAS call in one thread, as here: the same
        # numbers, bit for bit, on any machine)
        from .threads import run_in_parts

        long = [(s, e, np.asarray(c)) for (s, e), c in sorted(events.items()) if e - s >= LOCAL_MIN_S * fps]
        made = run_in_parts(lambda lo, hi: [own_model(*ev) for ev in long[lo:hi]], len(long), min_rows=1)
        models = dict(zip([(s, e) for s, e, _ in long], [m for part in made for m in part]))

        def made_model(s: int, e: int, chans: np.ndarray):
            """The event's local prior (mean, covariance, precision), or None for the global one."""
            return models.get((s, e))

        local_model = made_model

    prec = np.linalg.inv(cov + prior.ridge * np.eye(len(cov)))  # of every entry; marginals by Schur complements
    reading = base.copy()  # the observed channels as the field read them (_fill_events fills the gaps of base)
    # a clean take's gaps are ramped onto their ends whatever the prior's own choice (made on noisy clips)
    ramp = prior.ramp or (anchor and is_clean_take(x, miss, fps))
    _fill_events(out, base, miss, events, prior, lags, mean, cov, prec, ramp, local_model, held_channels(prior, joints))
    if anchor:
        anchor_ends(out, x, reading, miss, fps, meets_reading=ramp)
    return out


#: the least weight :func:`raw_weight` gives the observed samples at a gap's ends (below: 0, the reading alone)
RAW_WEIGHT_MIN = 0.9


def raw_weight(x: np.ndarray, reading: np.ndarray, miss: np.ndarray) -> np.ndarray:
    """Per channel, how far a gap's fill should meet the observed samples at its ends rather than their reading.

    An observed sample is the truth plus noise (variance ``n``); the reading (the smoothed channel) is the truth
    plus a smoothing error, so ``x - reading`` has variance ``n + s``. The weight of the raw sample that
    minimises the error at the end is ``s / (n + s)``: 1 on a clean channel, where the reading only bends the
    motion, small on a noisy one. ``n`` from the second differences of runs of observed samples (white noise:
    variance ``6 n``; the median keeps the motion's own curvature out), ``n + s`` from the residuals. A weight
    below :data:`RAW_WEIGHT_MIN` is 0: a noisy channel's fill keeps meeting the reading (on the held-out clips
    at 0.5 noise any smaller weight cost 0.3-1.9 % of the gap error; most channels of a clean take weigh about
    1). (C,); every channel at once (:mod:`.column_statistics`).
    """
    ok3 = ~(miss[2:] | miss[1:-1] | miss[:-2])
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    resid = x - reading
    seen = ~miss
    judged = (seen.sum(axis=0) >= 8) & (ok3.sum(axis=0) >= 8)
    total = column_means(resid * resid, seen & judged)
    noise = _mad_noise(d2, ok3 & judged)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(total <= 0.0, 1.0, np.clip(1.0 - noise / total, 0.0, 1.0))
    w = np.where(judged, w, 0.0)
    return np.where(w >= RAW_WEIGHT_MIN, w, 0.0)


def _mad_noise(d2: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """(C,) the white-noise variance the second differences (F', C) ``d2`` of each channel over its ``rows``
    (F', C) bool say: their median absolute deviation, as a standard deviation (x 1.4826), squared, over 6 (the
    variance of a second difference of white noise of variance ``n`` is ``6 n``)."""
    spread = np.abs(d2 - column_medians(d2, rows))
    # a float's power per channel (C of them): numpy's square can differ from it in the last bit
    return np.array([(1.4826 * m) ** 2 / 6.0 for m in column_medians(spread, rows).tolist()])


#: a channel is clean when its noise estimate (:func:`clean_channels`) is at most this share of what the 58 ms
#: Gaussian takes out of it
CLEAN_NOISE_SHARE = 0.05

#: seconds: how far into a clean channel's gap the cubic through its ends carries weight (:func:`anchor_ends`)
HERMITE_S = 0.1

#: seconds: the longest gap the cubic is blended into. A longer gap's ends weigh little against its middle, and
#: where the channel is noisy only near a gap (Mall's noise over a take's middle third, called clean by the whole
#: take) a 0.9 s gap's cubic followed the noisy end samples' slope: ``clean_takes``' fill error up by a third
HERMITE_MAX_S = 0.25


def clean_channels(x: np.ndarray, miss: np.ndarray, fps: float) -> np.ndarray:
    """(C,) bool: the channels of (F, C) ``x`` (NaN where ``miss``) whose samples carry no capture noise to speak of.

    A clean take's motion bends where it moves fast, and at 30 fps a second difference is mostly that bend, so the
    second differences of every frame (:func:`raw_weight`'s estimate) call a clean channel of a 30 fps take noisy.
    Noise is the same at every frame, motion is not: the noise variance is read from the second differences at the
    quarter of frames where the channel's 58 ms Gaussian reading bends least (white noise of variance ``n`` gives
    ``6 n`` there too; the median absolute deviation keeps what motion is left out; frames held exactly, a still
    stretch or padding, are left out, or a noisy channel held for a quarter of its frames read as clean), and a
    channel is clean when that is at most :data:`CLEAN_NOISE_SHARE` of the mean square the Gaussian takes out of
    it. On the Bandai Namco and HDM05 validation takes 81-98 % of the clean channels are clean by it and 0-5 % at
    Mall's 0.5 noise. Only the channels with a gap are judged (the others False); all of them at once
    (:mod:`.column_statistics`).
    """
    C = x.shape[1]
    clean = np.zeros(C, dtype=bool)
    if len(x) < 8:
        return clean
    cols = np.flatnonzero(miss.any(axis=0))
    x, miss = x[:, cols], miss[:, cols]
    reading = gaussian_filter1d(lerp_fill(x), SMOOTH_S * fps, axis=0, mode="nearest")
    ok3 = ~(miss[2:] | miss[1:-1] | miss[:-2])
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    bend = np.abs(reading[2:] - 2.0 * reading[1:-1] + reading[:-2])
    judged = ok3.sum(axis=0) >= 8
    moving = ok3 & (d2 != 0.0)  # frames held exactly (a still stretch, padding) say nothing of the noise elsewhere
    n_moving = moving.sum(axis=0)
    still = judged & (n_moving < 8)  # a channel held still throughout (but for a few frames) is not noisy
    rated = judged & ~still
    resid = x - reading
    total = column_means(resid * resid, ~miss & rated)
    calm = moving & rated
    calm &= bend <= column_quantiles(bend, calm, 0.25)  # the quarter of frames where the reading bends least
    with np.errstate(invalid="ignore"):
        clean[cols] = np.where(still, n_moving == 0, rated & (_mad_noise(d2, calm) <= CLEAN_NOISE_SHARE * total))
    return clean


#: a take is clean (:func:`is_clean_take`) when at least this share of its channels are (:func:`clean_channels`)
CLEAN_TAKE_SHARE = 0.25


def is_clean_take(x: np.ndarray, miss: np.ndarray, fps: float) -> bool:
    """Whether (F, C) channels ``x`` (NaN where ``miss``) are a clean take's: at least :data:`CLEAN_TAKE_SHARE` of
    every channel, missing or not, clean by :func:`clean_channels`.

    A prior fitted without the ramp (:attr:`GapPrior.ramp`, the Bandai Namco one: chosen on clips at Mall's 0.5
    noise) reads a gap's own channels' smoothed samples next to it and ends where its field ends, steps off the
    samples included: on a clean 30 fps take 1-2.5 deg at each end of a still arm's gap. On a clean take every gap
    is ramped onto its ends instead (:func:`conditional_fill`). On 24 HDM05, CMU and Bandai Namco takes 40-97 % of
    a clean take's channels are clean, 0-13 % at Mall's 0.1 noise and 0-5 % at 0.5: noisy takes keep the prior's
    choice (docs/models.md has the figures).
    """
    if len(x) < 8 or x.shape[1] == 0:
        return False
    judged = miss.copy()
    judged[0] = True  # clean_channels judges the channels with a gap: here every channel
    return bool(clean_channels(np.where(judged, np.nan, x), judged, fps).mean() >= CLEAN_TAKE_SHARE)


def anchor_ends(out: np.ndarray, x: np.ndarray, reading: np.ndarray, miss: np.ndarray, fps: float,
                meets_reading: bool = True) -> None:
    """Make each gap's fill (in ``out``, in place) meet the samples it continues, where they are clean.

    First a linear ramp between the offsets ``x - reading`` at the observed samples on either side of the gap,
    weighted by :func:`raw_weight` (1 on :func:`clean_channels`): on a clean channel the fill then meets the samples
    (no step at the gap's ends), on a noisy one it keeps meeting their reading. That is for a fill that meets the
    reading at the gap's ends (a ramped one: ``meets_reading``). Otherwise the offsets are taken from the fill's
    own ends, continued one frame by its first and last differences: a field that reads the channel's own samples
    near the gap (a prior without the ramp) ends where it ends, not on the reading, and taking the offsets from the
    reading there would leave a step (up to 2.5 deg at each end of a clean 30 fps take's gaps). Then, on a clean
    channel, a gap of at most :data:`HERMITE_MAX_S` with samples on both sides is blended with the cubic Hermite
    curve through its end samples and their slopes (:func:`end_slope`), with the weight ``exp(-d / HERMITE_S)`` at
    ``d`` seconds from the nearer end: the prior's field reads the frames 2-32 frames away, never the neighbours,
    and with its ridge leans towards the training mean, so on clean motion a short gap's fill alone wanders off the
    samples' own course (a still foot 3 deg off in a one-frame gap of a 30 fps take) where the cubic continues it.
    Every gap of every channel at once (:func:`mocapkit.cleaning.runs.column_runs`).
    """
    F = len(x)
    clean = clean_channels(x, miss, fps)
    w = np.where(clean, 1.0, raw_weight(x, reading, miss))
    col, s, e = column_runs(miss)
    keep = (w[col] > 0.0) & ((s > 0) | (e < F))  # a channel missing throughout has no end to meet
    col, s, e = col[keep], s[keep], e[keep]
    before, after = np.maximum(s - 1, 0), np.minimum(e, F - 1)  # the samples either side (where there is one)
    if meets_reading:
        f0, f1 = reading[before, col], reading[after, col]
    else:  # the fill continued one frame past each end; a gap of one frame: its fill
        wide = e - s >= 2
        f0 = np.where(wide, 2.0 * out[s, col] - out[np.minimum(s + 1, F - 1), col], out[s, col])
        f1 = np.where(wide, 2.0 * out[e - 1, col] - out[np.maximum(e - 2, 0), col], out[s, col])
    with np.errstate(invalid="ignore"):
        d0, d1 = x[before, col] - f0, x[after, col] - f1
    d0, d1 = np.where(s > 0, d0, d1), np.where(e < F, d1, d0)  # one side only: its offset holds
    run, frame = run_cells(s, e)
    c = col[run]
    t = (frame - s[run] + 1) / (e - s + 1.0)[run]
    out[frame, c] += w[c] * ((1.0 - t) * d0[run] + t * d1[run])
    cubic = clean[col] & (s > 0) & (e < F) & (e - s <= HERMITE_MAX_S * fps)
    if not cubic.any():
        return
    col, s, e = col[cubic], s[cubic], e[cubic]
    v0 = end_slope(*_outwards(x, miss, s - 1, col, -1))
    v1 = end_slope(*_outwards(x, miss, e, col, 1))
    run, frame = run_cells(s, e)
    c = col[run]
    n = (e - s)[run]
    out[frame, c] = hermite_blend(out[frame, c], frame - s[run], n, x[s - 1, col][run], x[e, col][run],
                                  -v0[run], v1[run], fps)


def _outwards(x: np.ndarray, miss: np.ndarray, first: np.ndarray, col: np.ndarray, step: int):
    """(G, 4) the samples of channels ``col`` (G,) from frames ``first`` (G,) outwards by ``step`` (-1: towards
    the take's start) and (G, 4) which are missing (off the take: missing), for :func:`end_slope`."""
    at = first[:, None] + step * np.arange(4)
    off = (at < 0) | (at >= len(x))
    at = np.clip(at, 0, len(x) - 1)
    return x[at, col[:, None]], off | miss[at, col[:, None]]


def end_slope(x: np.ndarray, miss: np.ndarray) -> float | np.ndarray:
    """The per-frame slope of a channel going away from a gap's end: ``x`` (..., n) the samples from the end
    outwards (``x[..., 0]`` the sample next to the gap), ``miss`` (..., n) which are missing; a float for one end,
    (...) for many.

    The first one-frame difference ``x[1] - x[0]``, unless the first four observed samples disagree: their two
    second differences change by more than half their size, as a glitched sample makes them (a smooth motion bends
    alike from one frame to the next). Then the median of the three differences, which one glitch cannot move:
    from the first difference, a 15 deg glitch two frames before a 0.5 s gap bent its fill by up to 48 deg, while
    on clean motion at 30 fps the median lags the end's slope. With two or three observed samples, the first
    difference; else 0.
    """
    x = np.asarray(x, dtype=np.float64)[..., :4]
    gone = np.asarray(miss, dtype=bool)[..., :4]
    pad = [(0, 0)] * (x.ndim - 1) + [(0, 4 - x.shape[-1])]
    x, gone = np.pad(x, pad, constant_values=np.nan), np.pad(gone, pad, constant_values=True)
    n = np.cumprod(~gone, axis=-1).sum(axis=-1)  # the observed samples next to the end, up to 4
    with np.errstate(invalid="ignore"):
        d = np.diff(x, axis=-1)
        dd = np.diff(d, axis=-1)
        steady = np.abs(dd[..., 0] - dd[..., 1]) <= 0.5 * (np.abs(dd[..., 0]) + np.abs(dd[..., 1]))
    median = np.where(np.isnan(d).any(axis=-1), np.nan, np.sort(d, axis=-1)[..., 1])
    slope = np.where(n < 2, 0.0, np.where((n < 4) | steady, d[..., 0], median))
    return float(slope) if slope.ndim == 0 else slope


def hermite_blend(fill, i, n, a, b, va, vb, fps: float) -> np.ndarray:
    """``fill`` at frame ``i`` of a gap of ``n`` frames between samples ``a`` (frame -1) and ``b`` (frame n),
    blended with the cubic Hermite curve through them with slopes ``va`` and ``vb`` (per frame): the curve's
    weight is ``exp(-d / HERMITE_S)`` at ``d`` seconds from the nearer end (:func:`anchor_ends`). Each argument
    one number or one per cell (every gap of a take together); one gap whole: ``i = np.arange(n)``."""
    u = (i + 1.0) / (n + 1.0)  # from a (0) to b (1)
    h = n + 1.0  # frames between a and b
    cubic = ((2 * u**3 - 3 * u**2 + 1) * a + (u**3 - 2 * u**2 + u) * h * va + (-2 * u**3 + 3 * u**2) * b
             + (u**3 - u**2) * h * vb)
    d = np.minimum(i + 1.0, n - i) / fps
    k = np.exp(-d / HERMITE_S)
    return k * cubic + (1.0 - k) * fill


def _fill_events(out: np.ndarray, base: np.ndarray, miss: np.ndarray, events: dict, prior: GapPrior, lags: np.ndarray,
                 mean: np.ndarray, cov: np.ndarray, prec: np.ndarray, ramp: bool, local=None, held=None) -> None:
    """Fill each gap event of :func:`conditional_fill` in time order, into ``out`` and ``base`` (in place).

    ``ramp``: every event solved over the gap and around it and offset onto ``base`` at the gap's ends
    (:attr:`GapPrior.ramp`, or a clean take: :func:`is_clean_take`). ``local(s, e, chans)``: an event's own
    (mean, covariance, precision) or None for ``mean``, ``cov``, ``prec`` (None: the same for all).

    With :attr:`GapPrior.branch`, the field reads every channel shifted by the whole turns that bring its mean over
    the frames the event reads nearest the branch (:func:`branch_turns`), and the fill is shifted back: one multiple
    per channel and event keeps the event one linear solve, and the fill continues the take's own branch (never a
    360 deg step at a gap's end); per take, a heading that turns over the take would sit far from the branch at
    most of its gaps.

    ``held`` (C,) bool or None (:func:`held_channels`): an event running to the take's start or end holds these of
    its channels at their one seen end (in ``base``: the reading there) before any event is solved, and every
    event reads them as observed."""
    F, C = base.shape
    L = len(lags)
    reach = int(np.abs(lags).max())
    pad = 2 * reach if ramp else 0  # with the ramp the missing channels' own samples are not read nearby
    glob = mean, cov, prec
    unknown = miss.copy()
    todo = []
    for (s, e), chans in sorted(events.items()):
        chans = np.asarray(chans)
        if held is not None and (s == 0) != (e == F) and held[chans].any():  # one seen end
            hold = chans[held[chans]]
            end = e if s == 0 else s - 1
            out[s:e, hold] = base[end, hold]
            base[s:e, hold] = base[end, hold]
            unknown[s:e, hold] = False
            chans = chans[~held[chans]]
        if len(chans):
            todo.append(((s, e), chans))
    for (s, e), chans in todo:
        own = local(s, e, chans) if local is not None else None
        mean, cov, prec = glob if own is None else own
        u0, u1 = max(s - pad, 0), min(e + pad, F)
        other = unknown[max(0, u0 - 2 * reach) : min(F, u1 + 2 * reach)].any(axis=0)
        other[chans] = False
        read = np.flatnonzero(~other)
        ent = (np.arange(L)[:, None] * C + read[None, :]).ravel()
        unk = (np.arange(L)[:, None] * C + chans[None, :]).ravel()
        gone = (np.arange(L)[:, None] * C + np.flatnonzero(other)[None, :]).ravel()
        if not len(gone):
            pcols = prec[np.ix_(ent, unk)]
        elif len(gone) < len(ent):  # the read entries' marginal precision: P_SS - P_SM P_MM^-1 P_MS, at the unknowns
            pm = cho_solve(cho_factor(prec[np.ix_(gone, gone)], check_finite=False), prec[np.ix_(gone, unk)],
                           check_finite=False)
            pcols = prec[np.ix_(ent, unk)] - prec[np.ix_(ent, gone)] @ pm
        else:  # fewer read than not: the inverse of their covariance, at the unknowns
            sigma = cov[np.ix_(ent, ent)] + prior.ridge * np.eye(len(ent))
            pcols = cho_solve(cho_factor(sigma, check_finite=False), np.eye(len(ent))[:, np.searchsorted(ent, unk)],
                              check_finite=False)
        turns = 0.0
        if prior.branch is not None:
            w0, w1 = max(0, u0 - 2 * reach), min(F, u1 + 2 * reach)  # the frames the event's windows read
            turns = 360.0 * branch_turns(base[w0:w1].mean(axis=0), prior.branch)  # (C,)
        pred = field_fill(base, lags, mean[ent], prior.scale[ent], pcols, read, chans, u0, u1, shift=turns)
        if prior.branch is not None:
            pred = pred + turns[chans]
        gap = pred[s - u0 : e - u0]
        if ramp:
            left = base[s - 1, chans] - pred[s - 1 - u0] if s > 0 else None
            right = base[e, chans] - pred[e - u0] if e < F else None
            if left is None and right is None:
                off = np.zeros((e - s, len(chans)))
            elif left is None or right is None:
                off = np.broadcast_to(left if right is None else right, (e - s, len(chans)))
            else:
                r = (np.arange(s, e) - (s - 1))[:, None] / (e - (s - 1))
                off = (1.0 - r) * left + r * right
            gap = gap + off
        out[s:e, chans] = gap
        base[s:e, chans] = gap
