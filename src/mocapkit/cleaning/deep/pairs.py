"""The EBF that smooths an EBD's fill when none is named: the shipped one of its channels, else its pair beside it.

Mall et al. (2017, sec. 4) smooth the gap filler's output with the denoiser: the EBD's filled entries go through an
EBF that reads the very same channels. The shipped models come in such pairs, named alike (``ebd.pt`` /
``ebf.pt``, ``ebd_bandai.pt`` / ``ebf_bandai.pt``: the EBF's file name is the EBD's with "ebd" read "ebf"), and a
pair is told by its channels (:class:`~mocapkit.cleaning.deep.channels.ChannelLayout`), not its name. An EBD trained
on one's own rig has no shipped EBF of its channels; where the file its path pairs it with (:func:`pair_path`: the
EBD's file name with "ebd" read "ebf", ``my_rig_ebd.pt`` -> ``my_rig_ebf.pt`` in the same folder, or for a name
without "ebd" its folder's, ``my_ebd/model.pt`` -> ``my_ebf/model.pt`` as ``mocapkit train -o`` lays models out) is an
EBF reading the same channels, that EBF is its pair, as the shipped pair is the shipped EBD's, and the caller says so
in one line. Every path that smooths an EBD's fill without a named EBF takes its pair by this one rule: ``fill
--model``, ``clean --ebd``, :func:`mocapkit.clean`'s ``models=``, :func:`~mocapkit.cleaning.deep.fill_gaps`. Anything else beside it (no such file, a file that does not
read as a model, an EBD, an EBF of other channels) is no pair: the caller refuses as it does without one.
"""

from __future__ import annotations

import re
from pathlib import Path

from ...errors import MocapFormatError

__all__ = ["pair_name", "pair_path", "paired_ebf"]


def pair_name(name: str) -> str:
    """The file name of the EBF paired with the EBD file ``name``: each "ebd" (any case) read "ebf" in the same case
    (``own_ebd.pt`` -> ``own_ebf.pt``, ``EBD_kt.pt`` -> ``EBF_kt.pt``); "" for a name without "ebd"."""
    if not re.search("ebd", name, flags=re.IGNORECASE):
        return ""
    return re.sub("ebd", lambda m: m.group(0)[:2] + ("f" if m.group(0)[2].islower() else "F"), name,
                  flags=re.IGNORECASE)


def pair_path(ebd_path) -> Path | None:
    """Where the EBF paired with the EBD file ``ebd_path`` would be: the file :func:`pair_name` names beside it
    (``models/kt_ebd.pt`` -> ``models/kt_ebf.pt``); for a file name without "ebd", the same file name in the folder
    whose name :func:`pair_name` reads (``my_ebd/model.pt`` -> ``my_ebf/model.pt``: ``mocapkit train -o my_ebd``'s
    layout); None when neither name has "ebd". Says nothing of whether that file exists."""
    p = Path(ebd_path)
    name = pair_name(p.name)
    if name:
        return p.with_name(name)
    folder = pair_name(p.parent.name)
    return p.parent.with_name(folder) / p.name if folder else None


def _shipped_pair(ebd):
    """The first shipped EBF (the Acclaim one, then each rig family's) that reads ``ebd``'s channels, or None."""
    from importlib import resources

    from .inference import SHIPPED, SHIPPED_FOR_RIG, load_model

    for name in (SHIPPED["ebf"], *(files["ebf"] for files in SHIPPED_FOR_RIG.values())):
        with resources.as_file(resources.files("mocapkit") / "models" / name) as path:
            ebf = load_model(path)
        if ebf.layout == ebd.layout:
            return ebf
    return None


def _beside(ebd):
    """The EBF at :func:`pair_path` of ``ebd``'s file, where it is one reading ``ebd``'s channels; else None."""
    from .inference import load_model

    path = pair_path(ebd.source) if ebd.source else None
    if path is None or not path.is_file():
        return None
    try:
        ebf = load_model(path)
    except MocapFormatError:
        return None
    return ebf if ebf.kind == "ebf" and ebf.layout == ebd.layout else None


def paired_ebf(ebd) -> tuple:
    """``(ebf, line)``: the EBF that smooths what the EBD model ``ebd`` fills when no EBF is named (module docstring).

    The shipped EBF that reads ``ebd``'s channels, with line ""; else the EBF at :func:`pair_path` of ``ebd``'s
    file, with the line that says it is used; else ``(None, "")``: the caller asks for an EBF."""
    shipped = _shipped_pair(ebd)
    if shipped is not None:
        return shipped, ""
    beside = _beside(ebd)
    if beside is None:
        return None, ""
    return beside, (f"the EBF {beside.source} smooths the fill of the EBD {ebd.source}: its pair beside it (by name, "
                    f"reading the same {ebd.layout.num_channels} channels), as no shipped EBF reads them")
