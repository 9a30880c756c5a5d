"""Deep cleaning (Mall et al. 2017): the EBF denoiser and EBD gap filler, trained here and shipped pretrained.

- :func:`denoise` / :func:`fill_gaps`: Motion in, Motion out (shipped models by default);
- :func:`served_by`: the one rule for which takes a model serves (directly, or through a joint map onto the
  Acclaim skeleton: :mod:`.retarget`); :func:`denoise_or_fallback` / :func:`fill_or_fallback` apply it with the
  fallbacks every command shares;
- :class:`Denoiser`: streaming EBF, one frame of file channels at a time (:mod:`.streaming`);
- :mod:`.networks`: the EBF and EBD modules; :mod:`.channels`: what they see;
- :mod:`.prior`: the Gaussian gap prior an EBD model carries (its conditional mean fills gaps by default);
- :mod:`.training`: noisy/clean pairs made on the fly with :mod:`mocapkit.corrupt`, Adam, checkpoints;
- :func:`shipped_layout`: the shipped models' layouts from the JSON beside them, for :func:`served_by` without
  torch (:mod:`.layouts`).

Each name is imported from its module on first use, so ``served_by(take, shipped_layout("ebf", take))``
(``mocapkit info``) runs without importing torch.
"""

from importlib import import_module

# each public name and the module that defines it: imported on first use (PEP 562), so that code asking only which
# takes a model serves (:mod:`.retarget`, :mod:`.channels`, :mod:`.layouts`) does not import torch (about 2.5 s)
_WHERE = {
    **dict.fromkeys(("ChannelLayout", "layout_for"), "channels"),
    **dict.fromkeys(("EBF_READ_MAX_FPS", "ebf_takes_part", "FALLBACK_DENOISE", "FALLBACK_FILL", "FILL_METHODS",
                     "SHIPPED_FOR_RIG", "DeepModel", "denoise", "denoise_channels", "denoise_or_fallback",
                     "fill_channels", "fill_gaps", "fill_or_fallback", "lerp_fill", "licence_note", "load_model",
                     "check_named", "refusal", "save_model", "shipped_model"), "inference"),
    **dict.fromkeys(("EBD", "EBF"), "networks"),
    "paired_ebf": "pairs",
    **dict.fromkeys(("GapPrior", "conditional_fill", "fit_gap_prior"), "prior"),
    **dict.fromkeys(("Serving", "served_by"), "retarget"),
    **dict.fromkeys(("Denoiser", "denoise_rows"), "streaming"),
    **dict.fromkeys(("ShippedLayout", "shipped_layout"), "layouts"),
}


def __getattr__(name: str):
    """A public name of the package (:data:`_WHERE`) or one of its modules (``deep.inference``), imported now."""
    if name in _WHERE:
        value = getattr(import_module(f".{_WHERE[name]}", __name__), name)
    elif not name.startswith("__"):
        try:
            value = import_module(f".{name}", __name__)
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_WHERE))


__all__ = [
    "EBF_READ_MAX_FPS",
    "ebf_takes_part",
    "FALLBACK_DENOISE",
    "FALLBACK_FILL",
    "FILL_METHODS",
    "SHIPPED_FOR_RIG",
    "GapPrior",
    "conditional_fill",
    "fit_gap_prior",
    "licence_note",
    "Serving",
    "served_by",
    "denoise_or_fallback",
    "fill_or_fallback",
    "refusal",
    "check_named",
    "paired_ebf",
    "ChannelLayout",
    "layout_for",
    "DeepModel",
    "Denoiser",
    "denoise",
    "denoise_channels",
    "denoise_rows",
    "fill_channels",
    "fill_gaps",
    "lerp_fill",
    "load_model",
    "save_model",
    "shipped_model",
    "EBD",
    "EBF",
    "ShippedLayout",
    "shipped_layout",
]
