"""Using the trained networks: load/save model files, offline denoising and gap filling (streaming: :mod:`.streaming`).

A model file is untrusted input: it is read with ``torch.load(...,
weights_only=True)`` (tensors, numbers and strings only, no pickled code) and
every field is checked before use; anything else raises
:class:`~mocapkit.errors.MocapFormatError` naming the file.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np
import torch

from ... import rigs
from ... import rotations as R
from ...errors import LicenceWarning, MocapFormatError, SkeletonError
from ...words import frame_span
from ...io import atomic_write
from ...motion import Motion
from ..measured import measured_rotations
from ..root_gaps import fill_root_gaps
from .channels import ChannelLayout, channel_joints, lerp_fill, with_measured
from .doubt import doubtful_runs
from .layouts import SHIPPED, SHIPPED_FOR_RIG, pick_served, shipped_names
from .prior import GapPrior, conditional_fill
from .provenance import card_as_read, model_licence, model_rig, restricts_use, unfinished_note
from .retarget import Serving, served_by
from .sure import BLOCK_S, block_edges, calibrated_log_sigma, scoring_stride, wrapped_channels
from .threads import INFERENCE_PARTS, RELEASE_FRAMES, release_freed_memory, torch_threads
from .retarget import decode as decode_served
from .retarget import encode as encode_served
from .networks import (
    EBD,
    EBF,
    HALF_WINDOW,
    NOISE_WINDOW,
    gaussian_filter_frames,
    noise_level_observed,
)

__all__ = [
    "DeepModel",
    "save_model",
    "load_model",
    "shipped_model",
    "SHIPPED_FOR_RIG",
    "licence_note",
    "licence_notes",
    "denoise",
    "fill_gaps",
    "denoise_channels",
    "fill_channels",
    "FILL_METHODS",
    "EBF_READ_MAX_FPS",
    "ebf_takes_part",
    "lerp_fill",
    "model_of_kind",
    "needs_resampling",
    "serving",
    "denoise_or_fallback",
    "fill_or_fallback",
    "passed_over",
    "FALLBACK_DENOISE",
    "FALLBACK_FILL",
    "refusal",
    "check_named",
    "served_or_refused",
]

FORMAT = "mocapkit.deep/1"


@dataclass(frozen=True)
class DeepModel:
    """A trained EBF or EBD with the channel layout and frame rate it was trained for."""

    kind: str  # "ebf" or "ebd"
    net: torch.nn.Module
    layout: ChannelLayout
    fps: float
    meta: dict = field(default_factory=dict)
    prior: GapPrior | None = None  # an EBD's Gaussian gap prior, fitted on its training clips (:mod:`.prior`)
    source: str = field(default="", compare=False)  # the file it was read from ("" for a model made in memory)

    def __post_init__(self):
        self.net.eval()


def save_model(model: DeepModel, path) -> Path:
    """Write ``model`` to ``path`` (temp file + rename): weights, config, layout, fps and metadata. (A shipped
    model also gets :func:`.layouts.write_layout` beside it: ``scripts/train_shipped.py --install``.)"""
    path = Path(path)
    payload = {
        "format": FORMAT,
        "kind": model.kind,
        "config": json.dumps(model.net.config),
        "layout": json.dumps(
            {"names": list(model.layout.names), "joints": list(model.layout.joints),
             "representation": model.layout.representation}
        ),
        "fps": float(model.fps),
        "meta": json.dumps(model.meta),
        "state": {k: v.detach().cpu().clone() for k, v in model.net.state_dict().items()},
    }
    if model.prior is not None:
        payload["prior"] = {k: torch.from_numpy(np.array(v)) for k, v in model.prior.to_arrays().items()}
    return write_torch(payload, path)


def write_torch(payload: dict, path) -> Path:
    """``torch.save`` of ``payload`` to ``path``, atomically (temp file + rename); returns the path.

    The file is made in memory and written in one piece: torch's zip writer, writing to a file itself, turns a
    failed write (a full disk) into a RuntimeError naming neither the file nor the cause; this way it is an
    ``OSError`` (ENOSPC) naming ``path``, and nothing is left.
    """
    import io

    path = Path(path)
    buf = io.BytesIO()
    torch.save(payload, buf)
    with atomic_write(path, "wb") as fh:
        fh.write(buf.getbuffer())
    return path


def load_model(path, kind: str | None = None) -> DeepModel:
    """Read a model file written by :func:`save_model` (weights only; a bad file raises MocapFormatError).

    A bare file name of a shipped model (``ebf.pt``, ``ebd.pt``, ``ebf_bandai.pt``, ``ebd_bandai.pt``; see
    docs/models.md) that is no file in the working folder is that shipped model, so ``--model ebf.pt`` picks the
    Acclaim networks for any take. ``kind`` ("ebf" or "ebd"), when given, is checked: a model of the other kind
    raises MocapFormatError naming the file.
    """
    path = Path(path)
    if path.name in _shipped_files() and path.parent == Path(".") and not path.exists():
        model = _packaged(path.name)
    else:
        model = _read_model(path)
    if kind is not None and model.kind != kind:
        raise MocapFormatError(path, f"an {model.kind.upper()} model, but this needs an {kind.upper()}")
    return model


def _shipped_files() -> set[str]:
    return {name for kind in SHIPPED for name in shipped_names(kind)}


def _read_model(path: Path) -> DeepModel:
    """The model in the file ``path``, read once per process while the file stays as it was.

    ``mocapkit clean --ebf F --ebd G`` checks the files before any work, then fill and denoise each ask for
    them: one ``torch.load`` per file, keyed on the file's resolved path, size, modification time and inode, so
    a file written over (a new training) is read again. Every caller gets the same :class:`DeepModel`, as
    the shipped ones always were; it is read-only by convention (nothing in mocapkit changes a loaded model,
    its parameters require no gradient): ``copy.deepcopy`` it to change it.
    """
    try:
        st = path.stat()
    except FileNotFoundError:
        raise MocapFormatError(path, "no such model file") from None
    except OSError:
        return _parse_model(path)  # unreadable: torch.load says why, naming the file
    try:
        return _model_of_file(str(path.resolve()), st.st_size, st.st_mtime_ns, st.st_ino)
    except MocapFormatError as exc:  # named as the caller gave it, not resolved
        raise MocapFormatError(path, exc.reason) from None


@lru_cache(maxsize=8)
def _model_of_file(resolved: str, size: int, mtime_ns: int, inode: int) -> DeepModel:
    """:func:`_parse_model` of the file at ``resolved`` as it is now (the other arguments: the cache key)."""
    model = _parse_model(Path(resolved))
    model.net.requires_grad_(False)
    return model


def _parse_model(path: Path) -> DeepModel:
    try:
        payload = torch.load(path, map_location="cpu", weights_only=True)
    except FileNotFoundError:
        raise MocapFormatError(path, "no such model file") from None
    except Exception as exc:  # noqa: BLE001 - any unpickling failure is a format error
        raise MocapFormatError(path, f"not a mocapkit model file ({type(exc).__name__})") from None
    try:
        if isinstance(payload, dict) and "optimizer" in payload and "format" not in payload:
            raise MocapFormatError(path, "a training checkpoint (what resumes a training), not a model; use the "
                                         "model.pt beside it")
        if not isinstance(payload, dict) or payload.get("format") != FORMAT:
            raise ValueError(f"format is not {FORMAT}")
        kind = payload["kind"]
        config = json.loads(payload["config"])
        lay = json.loads(payload["layout"])
        layout = ChannelLayout(tuple(lay["names"]), tuple(lay["joints"]), lay["representation"])
        cls = {"ebf": EBF, "ebd": EBD}[kind]
        if "lookahead" in config:
            config["lookahead"] = tuple(config["lookahead"])
        net = cls(**config)
        net.load_state_dict(payload["state"], strict=True)
        fps = float(payload["fps"])
        meta = card_as_read(json.loads(payload.get("meta", "{}")))
        if config["channels"] != layout.num_channels or not fps > 0:
            raise ValueError("layout and network disagree")
        prior = None
        if payload.get("prior") is not None:
            prior = GapPrior.from_arrays({k: v.numpy() for k, v in payload["prior"].items()})
            if kind != "ebd" or prior.num_channels != layout.num_channels:
                raise ValueError("the gap prior does not fit the model's channels")
    except MocapFormatError:
        raise
    except Exception as exc:  # noqa: BLE001
        raise MocapFormatError(path, f"malformed mocapkit model ({exc})") from None
    return DeepModel(kind, net, layout, fps, meta, prior, source=str(path))


@lru_cache(maxsize=8)
def _packaged(name: str) -> DeepModel:
    ref = resources.files("mocapkit") / "models" / name
    with resources.as_file(ref) as p:
        return _read_model(Path(p))


def shipped_model(kind: str = "ebf", take=None) -> DeepModel:
    """The pretrained EBF or EBD inside the package (see docs/models.md) for ``take``'s rig.

    Without ``take`` (a Motion or Skeleton): the Acclaim-rig model (``ebf.pt``
    / ``ebd.pt``). With it: the first shipped model of ``kind`` that
    :func:`served_by` says serves the take on its own channels (the Acclaim
    one, then each rig family's own model in :data:`SHIPPED_FOR_RIG`, e.g.
    ``ebf_bandai.pt`` for the Bandai Namco game rig), else the first that
    serves it through a joint map (the Acclaim one: the CMU BVH
    conversions, HumanIK, Mixamo, SMPL and Unreal rigs); the Acclaim one when none does,
    so the fallback's reason is its.
    """
    if kind not in SHIPPED:
        raise ValueError(f"kind must be one of {tuple(SHIPPED)}, got {kind!r}")
    return pick_served(shipped_names(kind), take, _packaged)  # each loaded only when the ones before do not serve


def passed_over(kind: str, take) -> str:
    """Why the shipped model of ``kind`` for ``take``'s own rig family (:data:`SHIPPED_FOR_RIG`) does not serve it
    directly, in one line (:func:`served_by`'s reason: the joints or channels that differ); "" where the family has
    no model of its own or it serves the take. Said beside the output whenever :func:`shipped_model` had to take
    another (a Bandai Namco rig with a bone inserted in a limb goes to the Acclaim model's joint map)."""
    sk = getattr(take, "skeleton", take)
    family = rigs.rig_family(sk)
    name = SHIPPED_FOR_RIG.get(family, {}).get(kind)
    if name is None:
        return ""
    s = served_by(sk, _packaged(name))
    if not isinstance(s, str) and s.direct:
        return ""
    why = s if isinstance(s, str) else f"it serves it only through a joint map ({s.describe()})"
    return f"the {family} {kind.upper()} ({name}) was not used: {why}"


def _smoothing_ebf(ebd: DeepModel, denoiser, take=None, said: list | None = None) -> DeepModel:
    """The EBF that smooths what ``ebd`` fills: ``denoiser`` (:func:`_model`'s kinds) or, when None, its pair
    (:func:`~mocapkit.cleaning.deep.pairs.paired_ebf`: the shipped EBF that reads the EBD's channels, ``ebf.pt`` for
    ``ebd.pt``, ``ebf_bandai.pt`` for ``ebd_bandai.pt``, else the EBF of those channels at the EBD file's
    :func:`~mocapkit.cleaning.deep.pairs.pair_path`, whose line is appended to ``said`` when given); with no pair
    (an EBD trained on one's own rig, alone), ValueError saying to give its EBF.
    An EBF of another rig than the EBD's is refused with ValueError (a request, not a reason to fall back).
    ``take``: the take served (for :func:`model_of_kind`)."""
    if denoiser is None:
        from .pairs import paired_ebf

        ebf, line = paired_ebf(ebd)
        if line and said is not None:
            said.append(line)
        if ebf is None:
            what = f"the EBD {ebd.source}" if ebd.source else "the given EBD"
            raise ValueError(f"no shipped EBF reads the {ebd.layout.num_channels} channels of {what}: give the EBF "
                             "trained on its rig (fill --denoiser, clean --ebf; denoiser= or models= in Python), or "
                             "fill without it (--no-smooth; smooth=False in Python)")
    else:
        ebf = model_of_kind(denoiser, "ebf", take)
    if ebf.layout != ebd.layout:
        raise ValueError(f"the EBF reads {ebf.layout.num_channels} channels and the EBD {ebd.layout.num_channels}: "
                         "they are not a pair; give the EBF of the EBD's rig as its denoiser")
    return ebf


def licence_note(model: DeepModel, options: dict[str, str] | None = None) -> str:
    """One line naming a model's licence when it restricts use (a model inherits its training data's,
    :func:`~mocapkit.cleaning.deep.provenance.restricts_use`: non-commercial or research-only terms), else "".

    ``options``: the option that picks another model of each kind in the command that prints the line
    (``{"ebd": "--model", "ebf": "--denoiser"}`` in ``fill``); without it the line names clean's ``--ebf`` /
    ``--ebd`` and the Python API's ``models=``.
    """
    lic = model_licence(model)
    if not restricts_use(lic):  # a licence without such terms (e.g. CC BY, MIT) is said by `mocapkit info` only
        return ""
    option = (options or {}).get(model.kind) or f"--{model.kind} (clean, clean-batch; models= in Python)"
    return (f"licence of the {model.kind.upper()} used: {lic}; {option} picks another: no shipped model is cleared for "
            "commercial use (ebf.pt/ebd.pt: HDM05's research terms; the _bandai pair: CC BY-NC 4.0), `mocapkit "
            "train` makes one from takes you may use (docs/models.md)")


def licence_notes(models: list[DeepModel], options: dict[str, str] | None = None) -> list[str]:
    """:func:`licence_note` of each model used together (a fill's EBD and the EBF that smooths it), models of one
    licence said in one line: ``"licence of the EBD and EBF used: CC BY-NC 4.0: ...; --ebd, --ebf (clean,
    clean-batch; models= in Python) pick others: ..."``. Two lines repeated the same terms and advice word for
    word (about 800 characters on every Bandai Namco take with gaps, in clean, clean-batch and the report)."""
    said = [(m, licence_note(m, options)) for m in models]
    said = [(m, n) for m, n in said if n]
    if len(said) < 2 or len({model_licence(m) for m, _ in said}) > 1:
        return [n for _, n in said]
    kinds = [m.kind for m, _ in said]
    picked = [(options or {}).get(k) for k in kinds]
    pick = (", ".join(picked) if all(picked) else
            ", ".join(f"--{k}" for k in kinds) + " (clean, clean-batch; models= in Python)")
    return [f"licence of the {' and '.join(k.upper() for k in kinds)} used: {model_licence(said[0][0])}; {pick} pick "
            "others: no shipped model is cleared for commercial use (ebf.pt/ebd.pt: HDM05's research terms; the "
            "_bandai pair: CC BY-NC 4.0), `mocapkit train` makes one from takes you may use (docs/models.md)"]


def model_of_kind(model, kind: str, take=None) -> DeepModel:
    """``model`` as a :class:`DeepModel` of ``kind`` ("ebf" or "ebd"): a Serving's model, a model, a model file, or None
    for the shipped model that serves ``take`` (:func:`shipped_model`); another kind raises ValueError."""
    if isinstance(model, Serving):
        model = model.model
    if model is None:
        return shipped_model(kind, take)
    if isinstance(model, (str, Path)):
        model = load_model(model)
    if not isinstance(model, DeepModel) or model.kind != kind:
        raise ValueError(f"expected an {kind.upper()} model, got {getattr(model, 'kind', type(model).__name__)}")
    return model


def serving(motion: Motion, model, kind: str) -> Serving:
    """The :class:`Serving` of ``motion`` by ``model`` (a Serving, DeepModel, model file or None: shipped).

    Raises :class:`SkeletonError` with :func:`served_by`'s one-line reason
    when the model does not serve the take.
    """
    if isinstance(model, Serving):
        return model
    m = model_of_kind(model, kind, motion)
    s = served_by(motion, m)
    if isinstance(s, str):
        raise SkeletonError(s)
    return s


# -- array level ---------------------------------------------------------------------


def _pad(x: np.ndarray, ctx: np.ndarray, half: int = HALF_WINDOW):
    xp = np.concatenate([np.repeat(x[:1], half, 0), x, np.repeat(x[-1:], half, 0)], axis=0)
    cp = np.concatenate([np.zeros((half, ctx.shape[1])), ctx, np.zeros((half, ctx.shape[1]))], axis=0)
    return xp, cp


@torch_threads()
@torch.inference_mode()
def _run_ebf(
    net: EBF, xp: np.ndarray, cp: np.ndarray, chunk: int = 4096, noise: np.ndarray | None = None,
    observed: np.ndarray | None = None, edges: np.ndarray | None = None, stride: int = 1, fps: float | None = None,
    wrapped_only: bool = False,
) -> np.ndarray:
    """Offline EBF on padded (F + 30, C) channels: the trunk in one pass, the head in chunks, then the filter.

    The Gaussian head's filter runs in numba (:func:`gaussian_filter_frames`,
    on float32 inputs as the network sees them) instead of building the
    (F, C, 31) taps; the free-tap head uses the torch filter. ``noise``
    (F + 30, C): the noise-level input computed elsewhere (see
    :func:`denoise_channels`), else the network's own. ``observed`` (F, C)
    bool: calibrate the Gaussian head's widths per channel and block
    (``edges``: block starts and the end, over the F frames) by Stein's risk
    estimate on these samples (every ``stride``-th frame of a block scored;
    ``fps`` the model's rate; an Euler channel that wrapped in training,
    :func:`mocapkit.cleaning.deep.sure.wrapped_channels`, by the least risk alone)
    (:func:`mocapkit.cleaning.deep.sure.calibrated_log_sigma`); None keeps
    the network's widths. ``wrapped_only``: calibrate those wrapped channels
    alone, the others keep the network's widths.
    """
    x = torch.as_tensor(xp, dtype=torch.float32)[None]
    c = torch.as_tensor(cp, dtype=torch.float32)[None]
    nz = None if noise is None else torch.as_tensor(noise, dtype=torch.float32)[None]
    y2 = net.trunk(x, c, nz, parts=INFERENCE_PARTS)[:, HALF_WINDOW:]  # (1, F, 2H)
    F = y2.shape[1]
    x32 = x[0].numpy()
    if net.head_kind == "gaussian":
        heads = [net.filter_parameters(y2[:, s : s + chunk]) for s in range(0, F, chunk)]
        log_sigma = np.concatenate([p[0].numpy() for p, _ in heads]) if heads else np.zeros((0, net.channels), np.float32)
        if observed is not None:
            wrapped = wrapped_channels(net.std.numpy())  # none in a 6-D model (its channels lie in [-1, 1])
            calibrated = calibrated_log_sigma(x32, log_sigma, observed, edges, HALF_WINDOW, stride, fps, wrapped)
            log_sigma = np.where(wrapped[None, :], calibrated, log_sigma) if wrapped_only else calibrated
        out = gaussian_filter_frames(x32, log_sigma)
        if net.with_bias:
            out = out - np.concatenate([b[0].double().numpy() for _, b in heads])
        return out
    out = np.empty((F, net.channels))
    for s in range(0, F, chunk):
        p, b = net.filter_parameters(y2[:, s : s + chunk])
        n = p.shape[1]
        win = x[:, s : s + n + 2 * HALF_WINDOW].unfold(1, 2 * HALF_WINDOW + 1, 1)
        y = torch.sum(win * torch.softmax(p, dim=-1), dim=-1)[0].double().numpy()
        if b is not None:
            y = y - b[0].double().numpy()
        out[s : s + n] = y
    return out


def _to_rate(values: np.ndarray, fps_from: float, fps_to: float, n_to: int | None = None) -> np.ndarray:
    """Linear resampling of (F, C) along time from ``fps_from`` to ``fps_to`` (same start time)."""
    F = len(values)
    t_from = np.arange(F) / fps_from
    if n_to is None:
        n_to = int(np.floor((F - 1) * fps_to / fps_from + 1e-9)) + 1
    t_to = np.minimum(np.arange(n_to) / fps_to, t_from[-1])
    return np.stack([np.interp(t_to, t_from, values[:, c]) for c in range(values.shape[1])], axis=1)


def needs_resampling(fps: float | None, model_fps: float) -> bool:
    """Whether data at ``fps`` (None: the model's own rate) must be resampled to the model's rate."""
    return fps is not None and abs(fps - model_fps) > 1e-6 * model_fps


def denoise_channels(
    values: np.ndarray,
    context: np.ndarray,
    model=None,
    fps: float | None = None,
    missing: np.ndarray | None = None,
    until: int | None = None,
    calibrate: bool = True,
) -> np.ndarray:
    """EBF on raw channels (F, C) (degrees, unwrapped) with root context (F, 3) rad/s -> (F, C).

    ``fps``: the data's rate; when it differs from the model's the channels
    are resampled to the model's rate and back. A network with the
    noise-level input then gets it estimated at the data's own rate (over the
    same 0.27 s) and resampled: linear upsampling correlates the noise over
    neighbouring frames, which hides it from second differences taken at the
    model's rate (a 30 fps take looked 4x less noisy). NaN entries are
    lerp-filled for the network and NaN again in the result. ``missing``
    (F, C) bool: entries that are filled, not observed (the gap filler's
    EBD values); the noise level is measured on the observed entries only
    (:func:`networks.noise_level_observed`), as it is around NaN entries.
    ``until``: only the first ``until`` frames of the result are needed; the
    network then runs on the frames they depend on and no further (the EBF
    looks :data:`HALF_WINDOW` frames ahead and its noise level and forward
    LSTM look back, so those frames are bit-identical to a run on the whole
    take), and the frames from ``until`` on are NaN.
    ``calibrate``: scale the Gaussian head's widths per channel and
    :data:`~mocapkit.cleaning.deep.sure.BLOCK_S` seconds by Stein's risk
    estimate on the observed samples (:mod:`.sure`: clean motion and light
    noise get a light touch); only at the model's own rate (a resampled take's
    noise is correlated from frame to frame), but for the channels that
    wrapped in training (:func:`~mocapkit.cleaning.deep.sure.wrapped_channels`),
    calibrated at any rate. False: the network's widths, as
    the streaming :class:`~mocapkit.cleaning.deep.streaming.Denoiser` uses them with ``calibrate=False``.
    """
    m = model_of_kind(model, "ebf")
    x = np.asarray(values, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != m.layout.num_channels:
        raise ValueError(f"values: expected (F, {m.layout.num_channels}) channels, got {x.shape}")
    if len(x) == 0:
        return x.copy()
    miss = np.isnan(x)
    xf = lerp_fill(x)
    ctx = np.nan_to_num(np.asarray(context, dtype=np.float64))
    resample = needs_resampling(fps, m.fps)
    if resample:
        xf_m, ctx_m = _to_rate(xf, fps, m.fps), _to_rate(ctx, fps, m.fps)
    else:
        xf_m, ctx_m = xf, ctx
    noise = None
    filled = miss if missing is None else (miss | np.asarray(missing, dtype=bool))
    if m.net.noise_input and (resample or filled.any()):  # else the network measures it itself, as streaming does
        window = max(3, int(round(NOISE_WINDOW * fps / m.fps))) if resample else NOISE_WINDOW
        level = noise_level_observed(xf, ~filled, m.net.std.numpy().astype(np.float64), window)
        noise = _to_rate(level, fps, m.fps, n_to=len(xf_m)) if resample else level
    # a resampled take is calibrated on the channels that wrapped in training alone (sure.wrapped_channels: the
    # network's width there is no guide, and the input's was never worse): a take at a multiple of the model's rate
    # is read at the model's rate sample for sample, so its noise stays white there
    wrapped_only = resample and bool(wrapped_channels(m.net.std.numpy()).any())
    calibrate = calibrate and (not resample or wrapped_only) and m.net.head_kind == "gaussian"
    edges = block_edges(len(xf_m), int(round(BLOCK_S * m.fps))) if calibrate else None  # of the whole take
    end = len(xf_m)
    if until is not None:  # the model-rate frames the first `until` frames interpolate from, and 15 frames of look-ahead
        n_m = min(int(until), len(x)) if not resample else int(np.ceil(max(int(until) - 1, 0) * m.fps / fps)) + 2
        if calibrate:  # and the rest of their calibration block, scored as in a whole run
            n_m = int(edges[np.searchsorted(edges, max(n_m, 1), side="left")])
        end = min(len(xf_m), max(n_m, 1) + HALF_WINDOW + 1)
    xp, cp = _pad(xf_m[:end], ctx_m[:end])
    if calibrate and resample:  # a model-rate sample is observed where the data's samples it reads are
        observed = _to_rate(filled.astype(np.float64), fps, m.fps, n_to=len(xf_m))[:end] == 0.0
    else:
        observed = ~filled[:end] if calibrate else None
    run_edges = np.append(edges[edges < end], end) if calibrate else None  # the blocks this run holds
    out = _run_ebf(m.net, xp, cp, noise=None if noise is None else _pad(noise[:end], ctx_m[:end])[0],
                   observed=observed, edges=run_edges, stride=scoring_stride(m.fps), fps=m.fps, wrapped_only=wrapped_only)
    del xp, cp
    if end >= RELEASE_FRAMES:  # a long take's temporaries, freed into heaps that keep them (threads module)
        release_freed_memory()
    if resample:
        out = _to_rate(out, m.fps, fps, n_to=len(x))
    elif end < len(x):
        out = np.concatenate([out, np.full((len(x) - end, out.shape[1]), np.nan)])
    if until is not None:
        out[int(until):] = np.nan
    out[miss] = np.nan
    return out


@torch_threads()
@torch.inference_mode()
def run_ebd(net: EBD, filled: np.ndarray, mask: np.ndarray, ctx: np.ndarray, frames: np.ndarray, batch: int = 8192):
    """The EBD's predictions (len(frames), C) at ``frames`` of lerp-filled channels (F, C) with their gap mask
    (F, C) and root context (F, 3), at the model's rate, in batches of ``batch`` windows."""
    x = torch.as_tensor(filled, dtype=torch.float32)
    mk = torch.as_tensor(mask, dtype=torch.float32)
    c = torch.as_tensor(ctx, dtype=torch.float32)
    out = np.empty((len(frames), net.channels))
    for s in range(0, len(frames), batch):
        centres = torch.as_tensor(frames[s : s + batch])
        out[s : s + len(centres)] = net.forward_at(x, mk, c, centres, parts=INFERENCE_PARTS).double().numpy()
    return out


EBF_READ_MAX_FPS = 60.0
"""The highest model rate (frames/s) at which the gap prior reads the observed channels through the EBF
(:func:`fill_channels`). At 30 fps the prior's 58 ms Gaussian spans 1.7 frames and leaves much of the noise in what
it reads: the EBF's reading cut the error of 1-4 s whole-joint gaps by 1.4 % on the Bandai validation styles; at
120 fps it spans 7 frames and the EBF's reading changed nothing on the Acclaim validation actor (+0.1 %) for a
network pass."""

FILL_METHODS = ("auto", "prior", "ebd")


def _fills_by_prior(model: DeepModel, method: str) -> bool:
    """Whether ``method`` (:data:`FILL_METHODS`) fills gaps with ``model``'s gap prior rather than its network;
    ValueError for an unknown method, or "prior" asked of a model that carries none (an error, not a fallback)."""
    if method not in FILL_METHODS:
        raise ValueError(f"method must be one of {FILL_METHODS}, got {method!r}")
    if method == "prior" and model.prior is None:
        raise ValueError("this EBD model carries no gap prior; fill with method='ebd' or fit one (mocapkit train)")
    return model.prior is not None and method != "ebd"


def ebf_takes_part(model: DeepModel, smooth: bool, method: str = "auto") -> bool:
    """Whether :func:`fill_channels` with this EBD ``model`` runs the EBF: with ``smooth``, over the network's fill, or
    as the gap prior's reading of the observed channels at a model rate up to :data:`EBF_READ_MAX_FPS`."""
    return smooth and (not _fills_by_prior(model, method) or model.fps <= EBF_READ_MAX_FPS)


def fill_channels(
    values: np.ndarray, context: np.ndarray, model=None, denoiser=None, fps: float | None = None, smooth: bool = True,
    method: str = "auto",
) -> np.ndarray:
    """Fill the NaN entries of raw channels (F, C) by the EBD network or its gap prior, with the EBF where ``smooth``.

    Mall's gap pipeline: gaps are first linearly interpolated, the EBD replaces
    only the gap entries, and (``smooth``) the completed signal goes through the
    EBF; here the EBF's output is kept on the gap entries only, with the
    network's own filter widths (no calibration: the entries it smooths are
    filled, not measured), so observed values are returned bit-identical.
    ``model``/``denoiser``: EBD/EBF (None = shipped). ``method``: what fills
    the gap entries: ``"ebd"`` the network, ``"prior"`` the model's Gaussian gap
    prior (:mod:`.prior`, fitted on the EBD's training clips), ``"auto"`` the
    prior when the model carries one (the shipped ones do: it left less error
    than the EBD on held-out actors and styles, short and long gaps, both rigs;
    docs/models.md), else the EBD. The prior's fill is the conditional mean of
    smoothed readings and is not filtered again (the EBF over it changed
    nothing on the Acclaim validation actor and cost 2 % on the Bandai
    validation styles); with ``smooth``, a model of at most
    :data:`EBF_READ_MAX_FPS` reads the observed channels as the EBF denoises
    them (SURE-calibrated, :mod:`.sure`) instead of through its 58 ms Gaussian;
    either reading is averaged with the take's own cross-channel prediction
    (:func:`.prior.conditional_fill`'s ``cross``). :func:`ebf_takes_part` says
    whether the EBF runs at all.
    """
    m = model_of_kind(model, "ebd")
    use_prior = _fills_by_prior(m, method)
    x = np.asarray(values, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != m.layout.num_channels:
        raise ValueError(f"values: expected (F, {m.layout.num_channels}) channels, got {x.shape}")
    miss = np.isnan(x)
    if not miss.any() or len(x) == 0:
        return x.copy()
    if miss.all(axis=0).any():
        bad = int(np.flatnonzero(miss.all(axis=0))[0])
        raise ValueError(f"channel {m.layout.names[bad]} has no observed sample; nothing to fill it from")
    ctx = np.nan_to_num(np.asarray(context, dtype=np.float64))
    filled = lerp_fill(x)
    resample = needs_resampling(fps, m.fps)
    if resample:
        f_m, c_m = _to_rate(filled, fps, m.fps), _to_rate(ctx, fps, m.fps)
        k_m = _to_rate(miss.astype(np.float64), fps, m.fps) > 0.0
    else:
        f_m, c_m, k_m = filled, ctx, miss
    frames = np.flatnonzero(k_m.any(axis=1))
    if use_prior:
        gappy = np.where(k_m, np.nan, f_m)
        # at low rates the prior reads the observed channels through the EBF (a better filter of the evidence there
        # than its fixed Gaussian; module constant)
        read = denoise_channels(gappy, c_m, denoiser) if ebf_takes_part(m, smooth, method) else None
        f_m = conditional_fill(gappy, m.prior, m.fps, smoothed=read, joints=channel_joints(m.layout))
    else:
        pred = run_ebd(m.net, f_m, k_m, c_m, frames)
        f_m = f_m.copy()
        sub = f_m[frames]
        sub[k_m[frames]] = pred[k_m[frames]]
        f_m[frames] = sub
        if smooth:  # the EBF's output is kept on the gap entries only: it runs up to the last of them
            f_m = np.where(k_m, denoise_channels(f_m, c_m, denoiser, missing=k_m, until=int(frames[-1]) + 1,
                                                 calibrate=False), f_m)
    out = _to_rate(f_m, m.fps, fps, n_to=len(x)) if resample else f_m
    return np.where(miss, out, x)


# -- Motion level ----------------------------------------------------------------------


def denoise(motion: Motion, model=None, cells: np.ndarray | None = None, *, guard: bool = True) -> Motion:
    """Denoise every non-root joint of ``motion`` with the EBF (Mall 3); root trajectory and rotation kept.

    ``model``: a :class:`DeepModel`, a model file, or None for the shipped
    EBF that serves the take's rig (:func:`shipped_model`: the Acclaim one, ``ebf.pt``, or a rig family's own,
    such as ``ebf_bandai.pt`` for the Bandai Namco game rig). A model whose licence restricts use (the Bandai
    Namco models are CC BY-NC: non-commercial) is said by a :class:`~mocapkit.errors.LicenceWarning`
    (:func:`licence_note`), as the CLI says it. Frames and skeleton are the input's; missing joints stay missing.
    ``cells`` (F, J) bool: denoise only these cells, the others are returned bit-identical.

    ``guard`` (default): the ``mocapkit denoise`` command's result, bit for bit
    (:func:`~mocapkit.cleaning.denoise_guard.guarded_take`): a cell the network moves further than the take's
    noise explains (a flip the file holds, CMU 131_02's RThumb: up to 58 deg moved on a clean take without it)
    is kept as it came and its neighbours denoised without it, channels written as 0 where the capture lost data
    are left as written, and the command's note on them is a ``UserWarning``. ``guard=False``: the network's
    own output, nothing kept; the network then runs only up to the frames ``cells`` need
    (:func:`denoise_channels`' ``until``), and the denoised cells are the same as a run on every cell gives.

    >>> import mocapkit
    >>> from mocapkit import corrupt, metrics
    >>> from mocapkit.cleaning.deep import denoise
    >>> clean = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    >>> noisy, _ = corrupt.angular_noise(clean, amount=0.5, seed=1)
    >>> out = denoise(noisy)
    >>> bool(metrics.joint_angle_rms(clean, out, include_root=False) < 0.6 * metrics.joint_angle_rms(clean, noisy, include_root=False))
    True
    """
    sv = serving(motion, model, "ebf")
    warn_licence(sv.model, {"ebf": "model="})
    if not guard:
        return _denoise(motion, sv, cells)
    from ..denoise_guard import guarded_take

    out, _, note = guarded_take(motion, cells,
                                lambda m, c: (_denoise(m, serving(m, model, "ebf"), c), "", "")).as_tuple()
    if note:
        import warnings

        warnings.warn(f"{motion.name or 'motion'}: {note}", UserWarning, stacklevel=2)
    return out


def _denoise(motion: Motion, sv: Serving, cells: np.ndarray | None) -> Motion:
    """:func:`denoise` by the model ``sv`` serves the take with, without a word about its licence (the caller says it)."""
    m = sv.model
    keep = motion.missing()
    until = None
    if cells is not None:
        cells = np.asarray(cells, dtype=bool)
        if cells.shape != keep.shape:
            raise ValueError(f"cells must be (F, J) = {keep.shape}, got {cells.shape}")
        rows = np.flatnonzero(cells.any(axis=1))
        if len(rows) == 0:
            return motion
        until = int(rows[-1]) + 1
        keep = keep | ~cells
    values, ctx = encode_served(motion, sv)
    out = denoise_channels(values, ctx, m, fps=motion.fps, until=until)
    if sv.direct:
        res = decode_served(np.nan_to_num(out), motion, sv, keep=keep)
        others = list(sv.others)  # joints beside the model's (a weapon bone): the fallback's filter, as below
    else:
        out = np.where(np.isnan(out), values, out)  # a NaN channel (a missing joint on a mapped chain) stays as it is
        res = decode_served(np.nan_to_num(out), motion, sv, keep=keep, residual=_residual_filter(motion.fps))
        # the rig's joints the network does not filter get the fallback's filter: those it reads at its means (it
        # never saw them move) and those the map does not cover (Chest3 on a five-segment trunk), but the root and
        # the joints above the pelvis, whose rotation is the body's (kept, as the root's is)
        sk = motion.skeleton
        covered = set(sv.joints) | set(sv.pelvis_chain) | {0}
        others = [j for j in range(1, sk.num_joints) if j not in covered and sk.rotation_order(j)]
    if not others:
        return res
    from ..filters import savgol_smooth

    cells = np.zeros(keep.shape, dtype=bool)
    cells[:, others] = True
    cells &= ~keep
    smooth = savgol_smooth(motion, window_s=0.1, polyorder=2, joints=others, root=False)
    return dataclasses.replace(res, rotations=np.where(cells[..., None], smooth.rotations, res.rotations))


def _residual_filter(fps: float):
    """The fallback's quadratic Savitzky-Golay filter over 0.1 s along time, for the part of a mapped joint's
    rotation outside the Acclaim degrees of freedom (which the EBF does not see)."""
    from scipy.signal import savgol_filter

    from ..filters import window_frames

    window = window_frames(0.1, fps, 2)

    def smooth(x: np.ndarray) -> np.ndarray:
        if len(x) < window:
            return x
        return savgol_filter(x, window, 2, axis=0, mode="interp")

    return smooth


def fill_gaps(motion: Motion, model=None, denoiser=None, smooth: bool = True, method: str = "auto") -> Motion:
    """Fill missing joints (NaN rotations) with the EBD model (with its EBF, ``smooth``); observed cells unchanged.

    ``method``: the EBD network or the model's gap prior; ``smooth``: the EBF
    over the network's fill, or as the prior's reading (:func:`fill_channels`).
    Returns a Motion with the input's skeleton, frames and root trajectory;
    every observed (frame, joint) rotation is bit-identical to the input's.
    A missing root rotation or position is not the networks' to fill: it is
    filled from the body (:func:`mocapkit.cleaning.root_gaps.fill_root_gaps`: the
    feet's contacts carry the position, the heading's spline and the body's
    tilt the rotation; on a game rig whose pelvis carries the body's path
    in its animated offset, ``motion.translations`` (F, J, 3): Bandai
    Namco's Hips over a still ``joint_Root``, a missing pelvis offset too);
    any other joint's missing animated offset is interpolated linearly (on that
    rig they are constant through a take, so the line holds them).
    ``model`` / ``denoiser``: models or files, None for the shipped pair that serves the take's rig (the Bandai
    Namco one, CC BY-NC, on that rig): a model whose licence restricts use is said by a
    :class:`~mocapkit.errors.LicenceWarning`, as the CLI says it.
    """
    sv = serving(motion, model, "ebd")
    if motion.missing().any():
        warn_licence(sv.model, {"ebd": "model=", "ebf": "denoiser="})
        if smooth and ebf_takes_part(sv.model, smooth, method):
            warn_licence(_smoothing_ebf(sv.model, denoiser, motion), {"ebd": "model=", "ebf": "denoiser="})
    return _fill_gaps(motion, sv, denoiser, smooth, method)[0]


def warn_licence(model: DeepModel, options: dict[str, str]) -> None:
    """Warn (:class:`~mocapkit.errors.LicenceWarning`) with :func:`licence_note`'s line when ``model``'s licence
    restricts use; ``options`` names the argument that picks another model."""
    note = licence_note(model, options)
    if note:
        import warnings

        warnings.warn(note, LicenceWarning, stacklevel=3)


def _fill_gaps(motion: Motion, model, denoiser, smooth: bool, method: str) -> tuple[Motion, list]:
    """:func:`fill_gaps`, and the runs of its fill that depart far from the line between their ends or from the one
    seen end of a run at the take's start or end (:func:`.doubt.doubtful_runs`, as ``[(joint name, first, last,
    departure_deg, spread_deg, side)]``)."""
    sv = serving(motion, model, "ebd")
    m = sv.model
    missing = motion.missing()
    if not missing.any():
        return motion, []
    src = motion if sv.direct and not sv.joints else _hold_unmapped(motion, sv, missing)
    values, ctx = encode_served(src, sv)
    if src is motion and m.layout.representation == "euler":  # a partly missing joint's measured angles: conditioned on
        values = with_measured(values, measured_rotations(motion), motion.skeleton)
    if smooth:  # the shipped EBF of the EBD's pair when none is given
        denoiser = _smoothing_ebf(m, denoiser, motion)
    out = fill_channels(values, ctx, m, denoiser, fps=motion.fps, smooth=smooth, method=method)
    doubts = [(sv.take_name(motion.skeleton, m.layout.joints[g]), *run)  # the file's name (its namespace kept)
              for g, *run in doubtful_runs(values, out, channel_joints(m.layout))]
    res = decode_served(out, src, sv, keep=~missing)
    rot = np.array(res.rotations)
    for j in np.flatnonzero(missing[:, 1:].any(axis=0)) + 1:  # joints without channels hold one rotation
        if np.isnan(rot[:, j]).any():
            seen = np.flatnonzero(~missing[:, j])
            rot[missing[:, j], j] = motion.rotations[seen[0], j] if len(seen) else R.identity()
    res = dataclasses.replace(res, rotations=rot)
    tr = motion.translations
    if tr is not None and np.isnan(tr).any():  # the animated offsets' gaps, as the root position's (observed kept)
        F, J = tr.shape[:2]
        line = lerp_fill(tr.reshape(F, 3 * J)).reshape(F, J, 3)
        res = dataclasses.replace(res, translations=np.where(np.isnan(tr), line, tr))
    return fill_root_gaps(motion, res)[0], doubts  # the root's and a game rig's pelvis' gaps: from the body


#: the doubtful runs :func:`doubt_note` names before it counts the rest
DOUBT_LINES = 3


def doubt_note(doubts, what: str = "the gap prior's fill") -> str:
    """One line for the runs of a fill that depart far from the line between their ends, or from the one seen end
    of a run at the take's start or end (:func:`_fill_gaps`), else "": ``"Hips frames 120-239: the gap prior's fill
    departs up to 95 deg from the line between the gap's ends (the channel spreads 2 deg over the take's seen
    frames); look at it before use"``; for a run at the take's start or end, ``"... departs up to 40 deg from the
    gap's one seen end (the gap runs to the take's end; the channel spreads 2 deg over the take's seen frames)
    ..."``."""
    if not doubts:
        return ""
    said = [f"{j} {frame_span(a, b)}: {what} departs up to {d:.0f} deg from "
            + ("the line between the gap's ends (the" if side is None else
               f"the gap's one seen end (the gap runs to the take's {side}; the")
            + f" channel spreads {sp:.0f} deg over the take's seen frames)" for j, a, b, d, sp, side in doubts[:DOUBT_LINES]]
    more = f", and {len(doubts) - DOUBT_LINES} more such runs" if len(doubts) > DOUBT_LINES else ""
    return ", ".join(said) + more + "; look at it before use"


#: What replaces the networks on a take they do not serve (the same in ``clean``, ``denoise`` and ``fill``).
FALLBACK_FILL = "cubic spline"
FALLBACK_DENOISE = "Savitzky-Golay (0.1 s)"


def refusal(model: DeepModel, why: str, given=None) -> SkeletonError:
    """The error for a model the user named (a file, a shipped name or a model object) that cannot serve a take:
    one line naming the model as ``given`` (the file or shipped name the user typed: ``ebf_bandai.pt``, not the
    installed copy's path), else its file (``model.source``; "the given EBF" for a model made in memory), and ``why``.
    A named model is used or refused, never replaced by the fallback: that is for the shipped models chosen by
    the take's rig (:func:`denoise_or_fallback`, :func:`fill_or_fallback`)."""
    name = str(given) if isinstance(given, (str, Path)) else model.source
    what = f"the {model.kind.upper()} {name}" if name else f"the given {model.kind.upper()}"
    return SkeletonError(f"{what} cannot serve this take: {why}")


def check_named(motion: Motion, models: dict) -> None:
    """Refuse, before any work, a model the caller named that cannot serve ``motion``.

    ``models``: ``{"ebf": ..., "ebd": ...}`` of model files, shipped names or :class:`DeepModel` s (None or a
    missing key: the shipped model for the take's rig, which falls back instead). Raises :func:`refusal`'s
    SkeletonError for the first that :func:`served_by` says does not serve the take, so ``clean --ebf M`` is
    refused even where its denoise step would find nothing to denoise and never run the model.
    """
    for kind in ("ebd", "ebf"):
        if models.get(kind) is None:
            continue
        served_or_refused(motion, models[kind], kind)


def served_or_refused(motion: Motion, model, kind: str):
    """``(model, serving)``: ``model`` as a :class:`DeepModel` of ``kind`` (:func:`model_of_kind`; None: the shipped
    one for the take's rig) and :func:`served_by`'s answer for ``motion`` (a Serving, or the reason it cannot
    serve). A model the caller named (``model`` not None) that cannot serve the take raises :func:`refusal`'s
    SkeletonError: it is used or refused; only the shipped model chosen by the rig falls back."""
    m = model_of_kind(model, kind, motion)
    sv = served_by(motion, m)
    if isinstance(sv, str) and model is not None:
        raise refusal(m, sv, model)  # named as given
    return m, sv


def _fallback_note(method: str, kind: str, label: str, why: str) -> str:
    return f"{method}: the {label} {kind.upper()} does not serve this rig ({why})"


def _method(kind: str, label: str, sv: Serving, name: str | None = None, skeleton=None) -> str:
    """How a take was served, for the output line: the model, the rig family or joint map, and the joints beside
    the model's that the fallback took (``skeleton`` names them)."""
    rig = model_rig(sv.model)  # None: a model file that does not say its rig, of other joints than Acclaim's
    via = (f", {sv.family}" if rig != "acclaim" and sv.family else "") if sv.direct else f", via the {sv.family} joint map"
    if sv.direct and rig not in (None, "acclaim") and sv.family not in (None, rig):  # retarget.role_names_for
        via = f", the {sv.family} rig's joints read by role as {rig}'s"
    if sv.direct and sv.others and skeleton is not None:
        names = [skeleton.joint_names[j] for j in sv.others]
        via += f"; {', '.join(names[:3])}{', ...' if len(names) > 3 else ''} beside its joints by the fallback"
    return f"{name or kind.upper()} ({label}{via})"


def fill_or_fallback(motion: Motion, model=None, denoiser=None, smooth: bool = True, label: str = "shipped",
                     method: str = "auto", options: dict[str, str] | None = None, doubts: list | None = None):
    """Fill the gaps of ``motion`` with the EBD model (+ EBF) where they serve it, else with the cubic spline.

    The rule is :func:`served_by` (direct, or through a joint map). Where
    the EBD serves the take, :func:`fill_gaps` fills it (by the network or
    its gap prior, ``method`` as :func:`fill_channels`; with the EBF when
    ``smooth`` and the EBF serves it too, :func:`ebf_takes_part`); where it does not, or a
    channel the network needs is never observed, the cubic interpolating
    spline of :func:`mocapkit.cleaning.gapfill.fill_motion` fills every gap but the root's (and a game rig's
    pelvis path), which is filled from the body either way (:func:`mocapkit.cleaning.root_gaps.fill_root_gaps`).
    The fallback is for the shipped models chosen by the take's rig (``model`` None): a model the caller named
    (``model`` given) that cannot serve the take raises :func:`refusal`'s SkeletonError instead.
    Returns ``(motion, method, note)``: ``note`` is "" with the networks
    (or one line naming a restrictive licence of the model used, e.g. the
    non-commercial Bandai Namco models: :func:`licence_note`), else one line
    saying which fallback ran and why. ``label`` names the model in
    both ("shipped", a file name); ``options``: the caller's option per
    model kind, for the licence line. A take without gaps is returned as is.
    Runs of the fill that depart far from the line between their ends, or from the one seen end of a run at the
    take's start or end (:func:`.doubt.doubtful_runs`), are said
    by :func:`doubt_note`: appended to ``doubts`` when given (a caller saying it on its own), else to ``note``.
    """
    from ..gapfill import fill_motion

    if not motion.missing().any():
        return motion, "nothing (no gaps)", ""
    m, sv = served_or_refused(motion, model, "ebd")  # a model asked for by name is used or refused
    if not isinstance(sv, str):
        by_prior = _fills_by_prior(sv.model, method)  # raises before the try: a bad request is no reason to fall back
        paired: list[str] = []  # the line naming an own-rig EBF found as the EBD's pair
        ebf = served_by(motion, _smoothing_ebf(sv.model, denoiser, motion, paired)) if smooth else "not asked"
        smooth = not isinstance(ebf, str)
        try:
            out, runs = _fill_gaps(motion, sv, ebf if smooth else None, smooth, method)
            ebf_ran = ebf_takes_part(sv.model, smooth, method)
            # the EBF found as the EBD's pair said only where it smooths: `fill` and `clean` say this one line alike
            notes = dict.fromkeys(n for n in (*(paired if ebf_ran else ()),
                                              *licence_notes([sv.model, *([ebf.model] if ebf_ran else [])], options),
                                              unfinished_note(sv.model),
                                              unfinished_note(ebf.model) if ebf_ran else "") if n)
            if model is None:
                notes = {passed_over("ebd", motion): None} | notes
            notes.pop("", None)
            name = "EBD's gap prior" if by_prior else None
            how = _method("ebd", label, sv, name, motion.skeleton) + (" + EBF" if ebf_ran else "")
            doubt = doubt_note(runs, "the gap prior's fill" if by_prior else "the EBD's fill")
            if doubt and doubts is not None:
                doubts.append(doubt)
            elif doubt:
                notes[doubt] = None
            return out, how, "; ".join(notes)
        except ValueError as exc:
            if model is not None:
                raise refusal(m, str(exc), model) from None
            why = str(exc)
    else:
        why = sv
    note = _fallback_note(FALLBACK_FILL, "ebd", label, why)
    own = passed_over("ebd", motion) if model is None else ""
    out = fill_root_gaps(motion, fill_motion(motion, "cubic"))[0]  # the root as the networks' fill takes it
    return out, FALLBACK_FILL, f"{own}; {note}" if own else note


def denoise_or_fallback(motion: Motion, model=None, cells: np.ndarray | None = None, label: str = "shipped",
                        options: dict[str, str] | None = None):
    """Denoise ``motion`` (only ``cells`` (F, J) when given) with the EBF where it serves the take, else by a
    quadratic Savitzky-Golay filter over 0.1 s (:func:`mocapkit.cleaning.filters.savgol_smooth`).

    The rule is :func:`served_by`. Without ``cells`` every non-root joint is
    denoised. A named ``model`` that does not serve the take raises :func:`refusal`'s SkeletonError (the fallback
    is for the shipped model chosen by the take's rig). Returns ``(motion, method, note)`` as :func:`fill_or_fallback`
    (``options`` as there); cells outside ``cells`` (and the root) are bit-identical to the input.
    """
    from ..filters import savgol_smooth

    m, sv = served_or_refused(motion, model, "ebf")  # a model asked for by name is used or refused
    own = passed_over("ebf", motion) if model is None else ""
    if not isinstance(sv, str):
        note = "; ".join(n for n in (own, licence_note(sv.model, options), unfinished_note(sv.model)) if n)
        return _denoise(motion, sv, cells), _method("ebf", label, sv, skeleton=motion.skeleton), note
    J = motion.skeleton.num_joints
    if cells is None:
        cells = np.zeros((motion.num_frames, J), dtype=bool)
        cells[:, 1:] = True
    cells = np.asarray(cells, dtype=bool)
    joints = np.flatnonzero(cells.any(axis=0))
    den = savgol_smooth(motion, window_s=0.1, polyorder=2, joints=joints, root=False)
    rot = np.where(cells[..., None], den.rotations, motion.rotations)
    out = dataclasses.replace(motion, rotations=rot)
    note = _fallback_note("Savitzky-Golay", "ebf", label, sv)
    return out, FALLBACK_DENOISE, f"{own}; {note}" if own else note


def _hold_unmapped(motion: Motion, sv: Serving, missing: np.ndarray) -> Motion:
    """``motion`` with the missing cells of non-root joints the joint map does not cover (e.g. ``LHipJoint``, the
    thumbs) filled by interpolating the joint's rotation between the observed frames on either side (held at the
    take's ends), so the chains through them are complete and such a joint moves on through its gap."""
    rot = np.array(motion.rotations)
    mapped = set(sv.joints)
    for j in np.flatnonzero(missing[:, 1:].any(axis=0)) + 1:
        seen = ~missing[:, j]
        if int(j) in mapped or not seen.any():
            continue
        q = np.array(motion.rotations[:, j])
        q[seen] = R.quaternion_continuity(q[seen])  # one hemisphere, then each component interpolated
        rot[missing[:, j], j] = R.quaternion_normalize(lerp_fill(q))[missing[:, j]]
    return dataclasses.replace(motion, rotations=rot)
