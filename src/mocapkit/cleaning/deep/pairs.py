"""The EBF that smooths an EBD's fill when none is named: the shipped one of its channels, else its pair beside it.

Mall et al. (2017, sec. 4) smooth the gap filler's output with the denoiser: the EBD's filled entries go through an
EBF that reads the very same channels. The shipped models come in such pairs, named alike (``ebd.pt`` /
``ebf.pt``, ``ebd_bandai.pt`` / ``ebf_bandai.pt``: the EBF's file name is the EBD's with "ebd" read "ebf"), and a
pair is told by its channels (:class:`~mocapkit.cleaning.deep.channels.ChannelLayout`), not its name. An EBD trained
on one's own rig has no shipped EBF of its channels; where the EBD's own folder holds the file its name pairs it with
(``my_rig_ebd.pt`` -> ``my_rig_ebf.pt``), an EBF reading the same channels, that EBF is its pair, as the shipped pair
is the shipped EBD's, and the caller says so in one line. Anything else beside it (no such file, a file that does not
read as a model, an EBD, an EBF of other channels) is no pair: the caller refuses as it does without one.
"""

from __future__ import annotations

import re
from pathlib import Path

from ...errors import MocapFormatError

__all__ = ["pair_name", "paired_ebf"]


def pair_name(name: str) -> str:
    """The file name of the EBF paired with the EBD file ``name``: each "ebd" (any case) read "ebf" in the same case
    (``own_ebd.pt`` -> ``own_ebf.pt``, ``EBD_kt.pt`` -> ``EBF_kt.pt``); "" for a name without "ebd"."""
    if not re.search("ebd", name, flags=re.IGNORECASE):
        return ""
    return re.sub("ebd", lambda m: m.group(0)[:2] + ("f" if m.group(0)[2].islower() else "F"), name,
                  flags=re.IGNORECASE)


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
    """The EBF in ``ebd``'s folder that :func:`pair_name` names, where it is one reading ``ebd``'s channels; else
    None."""
    from .inference import load_model

    name = pair_name(Path(ebd.source).name) if ebd.source else ""
    path = Path(ebd.source).with_name(name) if name else None
    if path is None or not path.is_file():
        return None
    try:
        ebf = load_model(path)
    except MocapFormatError:
        return None
    return ebf if ebf.kind == "ebf" and ebf.layout == ebd.layout else None


def paired_ebf(ebd) -> tuple:
    """``(ebf, line)``: the EBF that smooths what the EBD model ``ebd`` fills when no EBF is named (module docstring).

    The shipped EBF that reads ``ebd``'s channels, with line ""; else the EBF beside ``ebd``'s file under its
    :func:`pair_name`, with the line that says it is used; else ``(None, "")``: the caller asks for an EBF."""
    shipped = _shipped_pair(ebd)
    if shipped is not None:
        return shipped, ""
    beside = _beside(ebd)
    if beside is None:
        return None, ""
    return beside, (f"the EBF {beside.source} smooths the fill of the EBD {ebd.source}: its pair beside it (by name, "
                    f"reading the same {ebd.layout.num_channels} channels), as no shipped EBF reads them")
