"""Deep cleaning (Mall et al. 2017): the EBF denoiser and EBD gap filler, trained here and shipped pretrained.

- :func:`denoise` / :func:`fill_gaps`: Motion in, Motion out (shipped models by default);
- :func:`served_by`: the one rule for which takes a model serves (directly, or through a joint map onto the
  Acclaim skeleton: :mod:`.retarget`); :func:`denoise_or_fallback` / :func:`fill_or_fallback` apply it with the
  fallbacks every command shares;
- :class:`Denoiser`: streaming EBF, one frame of file channels at a time (:mod:`.streaming`);
- :mod:`.networks`: the EBF and EBD modules; :mod:`.channels`: what they see;
- :mod:`.prior`: the Gaussian gap prior an EBD model carries (its conditional mean fills gaps by default);
- :mod:`.training`: noisy/clean pairs made on the fly with :mod:`mocapkit.corrupt`, Adam, checkpoints.
"""

from .channels import ChannelLayout, layout_for
from .inference import (
    EBF_READ_MAX_FPS,
    ebf_takes_part,
    FALLBACK_DENOISE,
    FALLBACK_FILL,
    FILL_METHODS,
    SHIPPED_FOR_RIG,
    DeepModel,
    denoise,
    denoise_channels,
    denoise_or_fallback,
    fill_channels,
    fill_gaps,
    fill_or_fallback,
    lerp_fill,
    licence_note,
    load_model,
    check_named,
    refusal,
    save_model,
    shipped_model,
)
from .networks import EBD, EBF
from .pairs import paired_ebf
from .prior import GapPrior, conditional_fill, fit_gap_prior
from .retarget import Serving, served_by
from .streaming import Denoiser, denoise_rows

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
]
