"""The shipped networks' layouts without torch: what :func:`.retarget.served_by` reads of a model, kept beside it.

Which takes a model serves (directly, or through a joint map onto the Acclaim rig; Mall et al. 2017 trained
the EBF and EBD on the Acclaim skeleton's Euler channels) depends on its channel layout and, for a joint map,
on the per-channel normalisation its network holds (a channel whose training std is at most 1 deg never moved:
held; the channel means fill a joint the rig lacks). Reading those from the ``.pt`` file imports torch (about
2.5 s), which ``mocapkit info`` on a rig of no known family needed only to say whether the networks serve it.
So ``scripts/train_shipped.py --install``, which installs the shipped models, writes them beside each as
``NAME.layout.json`` (:func:`write_layout`, from the model as installed), and :func:`shipped_layout` answers from
those files with the same rule :func:`..inference.shipped_model` applies to the networks (:func:`pick_served`).
A test checks every shipped ``.json`` against its ``.pt`` (tests/cleaning/test_layouts.py). ``mocapkit train``
writes one beside every ``model.pt`` it saves (``write_layout(..., card=True)``), with the model's card and the
``.pt`` file's size and SHA-256, so ``mocapkit info DIR/model.pt`` reads a model of one's own without torch
(:func:`layout_beside`); where the JSON is missing or describes another file (a ``.pt`` replaced or copied
alone), ``info`` loads the ``.pt`` as before.

The JSON holds ``format``, ``kind`` ("ebf" or "ebd"), ``fps`` (frames per second the model was trained at),
``layout`` (channel names such as ``"lfemur.rx"``, joint names, representation) and ``mean`` / ``std`` (C,
the network's per-channel normalisation in the channels' units, degrees for Euler channels), as float32
values written exactly; a trained model's also ``meta`` (its card: :attr:`..inference.DeepModel.meta`) and
``model_file`` (``size`` in bytes and ``sha256`` of the ``.pt`` it describes).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ...errors import MocapFormatError
from ...io import atomic_write
from ...io.outputs import file_facts
from .channels import ChannelLayout
from .retarget import served_by

__all__ = ["SHIPPED", "SHIPPED_FOR_RIG", "LAYOUT_SUFFIX", "NetStats", "ShippedLayout", "shipped_names",
           "layout_card", "write_layout", "read_layout", "layout_beside", "shipped_layout", "pick_served"]

LAYOUT_FORMAT = "mocapkit.deep-layout/1"
LAYOUT_SUFFIX = ".layout.json"
#: The shipped Acclaim-rig models (docs/models.md), offered first.
SHIPPED = {"ebf": "ebf.pt", "ebd": "ebd.pt"}
#: The shipped models of the other rig families (docs/models.md), offered after the Acclaim ones.
SHIPPED_FOR_RIG = {"bandai_namco": {"ebf": "ebf_bandai.pt", "ebd": "ebd_bandai.pt"}}


def shipped_names(kind: str) -> list[str]:
    """The shipped model files of ``kind``, the Acclaim one first, then each rig family's own."""
    return [SHIPPED[kind]] + [files[kind] for files in SHIPPED_FOR_RIG.values()]


@dataclass(frozen=True)
class NetStats:
    """A network's per-channel normalisation: ``mean`` and ``std``, (C,) float64, in the channels' units."""

    mean: np.ndarray
    std: np.ndarray


@dataclass(frozen=True)
class ShippedLayout:
    """What :func:`.retarget.served_by` reads of a model (``layout``, ``net.mean``, ``net.std``), without its
    weights: a stand-in for a :class:`..inference.DeepModel` wherever only the answer's kind (served or the
    reason) is wanted, never for inference."""

    kind: str
    layout: ChannelLayout
    fps: float
    net: NetStats
    source: str = ""
    #: A trained model's card (``DeepModel.meta``) where the JSON keeps it, else None (the shipped ones').
    meta: dict | None = None
    #: ``{"size": bytes, "sha256": hex}`` of the ``.pt`` the JSON describes, where it says (a trained model's).
    model_file: dict | None = None


def layout_card(model) -> dict:
    """The JSON object :func:`write_layout` writes for ``model`` (a DeepModel or a ShippedLayout)."""
    lay = model.layout
    return {"format": LAYOUT_FORMAT, "kind": model.kind, "fps": float(model.fps),
            "layout": {"names": list(lay.names), "joints": list(lay.joints), "representation": lay.representation},
            "mean": np.asarray(model.net.mean, dtype=np.float64).reshape(-1).tolist(),
            "std": np.asarray(model.net.std, dtype=np.float64).reshape(-1).tolist()}


def write_layout(model, model_path, *, card: bool = False) -> Path:
    """Write :func:`layout_card` of ``model`` beside ``model_path`` (``ebf.pt`` -> ``ebf.layout.json``),
    atomically (a temporary file, then a rename); returns its path. With ``card`` (``mocapkit train``, after
    writing ``model_path``) it also holds the model's ``meta`` and the size and SHA-256 of the file at
    ``model_path``, so :func:`layout_beside` tells it from the JSON of another file."""
    path = Path(model_path).with_suffix(LAYOUT_SUFFIX)
    doc = layout_card(model)
    if card:
        doc.update(meta=model.meta if isinstance(model.meta, dict) else {}, model_file=file_facts(model_path))
    with atomic_write(path, encoding="utf-8") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    return path


def read_layout(path) -> ShippedLayout:
    """The :class:`ShippedLayout` in the JSON file ``path``; MocapFormatError naming the file if it is not one."""
    path = Path(path)
    try:
        card = json.loads(path.read_text(encoding="utf-8"))
        if card.get("format") != LAYOUT_FORMAT:
            raise ValueError(f"format is not {LAYOUT_FORMAT}")
        lay = card["layout"]
        layout = ChannelLayout(tuple(lay["names"]), tuple(lay["joints"]), lay["representation"])
        mean, std = (np.asarray(card[k], dtype=np.float64) for k in ("mean", "std"))
        if mean.shape != (layout.num_channels,) or std.shape != mean.shape:
            raise ValueError("layout and normalisation disagree")
        meta, facts = card.get("meta"), card.get("model_file")
        return ShippedLayout(str(card["kind"]), layout, float(card["fps"]), NetStats(mean, std), str(path),
                             meta if isinstance(meta, dict) else None, facts if isinstance(facts, dict) else None)
    except FileNotFoundError:
        raise MocapFormatError(path, "no such layout file") from None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise MocapFormatError(path, f"malformed model layout ({exc})") from None


def layout_beside(model_path) -> ShippedLayout | None:
    """The layout JSON that ``mocapkit train`` wrote beside the model file ``model_path``, read without torch;
    None where there is none, it is unreadable, or it describes another file (its ``model_file`` size and SHA-256
    are not those of ``model_path``: a ``.pt`` replaced or copied without it), so the caller reads the ``.pt``."""
    model_path = Path(model_path)
    json_path = model_path.with_suffix(LAYOUT_SUFFIX)
    if not json_path.is_file() or not model_path.is_file():
        return None
    try:
        kept = read_layout(json_path)
    except MocapFormatError:
        return None
    facts = kept.model_file
    if kept.meta is None or not facts or facts.get("size") != model_path.stat().st_size:
        return None
    return kept if facts.get("sha256") == file_facts(model_path)["sha256"] else None


def _packaged_layout(name: str) -> ShippedLayout:
    ref = resources.files("mocapkit") / "models" / Path(name).with_suffix(LAYOUT_SUFFIX).name
    with resources.as_file(ref) as p:
        return read_layout(p)


def pick_served(names: Sequence[str], take, get: Callable):
    """The model of ``names`` (:func:`shipped_names`) for ``take``, each read by ``get(name)`` only when needed:
    the first that :func:`.retarget.served_by` says serves the take on its own channels, else the first that
    serves it through a joint map or by role (a rig family's model reading the same rig under another family's
    names: ``Serving.by_role``; so a take under Unreal's names gets the Acclaim pair by default, not silently the
    non-commercial Bandai Namco pair, which ``--model ebf_bandai.pt`` picks), else the first (so the fallback's
    reason is its); without ``take``, the first.
    The one rule of :func:`..inference.shipped_model` (the networks) and :func:`shipped_layout` (their layouts)."""
    first = get(names[0])
    if take is None:
        return first
    mapped = None
    for name in names:
        m = first if name == names[0] else get(name)  # loaded only when the ones before do not serve it directly
        s = served_by(take, m)
        if not isinstance(s, str) and s.direct and not s.by_role:
            return m
        if mapped is None and not isinstance(s, str):
            mapped = m
    return first if mapped is None else mapped


def shipped_layout(kind: str = "ebf", take=None) -> ShippedLayout:
    """:func:`..inference.shipped_model`'s choice for ``take`` (a Motion or Skeleton), read from the layouts kept
    beside the shipped models, without torch: ``served_by(take, shipped_layout("ebf", take))`` says what
    ``served_by(take, shipped_model("ebf", take))`` says, served or the reason."""
    if kind not in SHIPPED:
        raise ValueError(f"kind must be one of {tuple(SHIPPED)}, got {kind!r}")
    return pick_served(shipped_names(kind), take, _packaged_layout)
