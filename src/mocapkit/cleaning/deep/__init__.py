"""Deep cleaning (Mall et al. 2017): the EBF denoiser and EBD gap filler, trained here and shipped pretrained.

- :func:`denoise` / :func:`fill_gaps`: Motion in, Motion out (shipped models by default);
- :class:`Denoiser`: streaming EBF, one frame of file channels at a time;
- :mod:`.networks`: the EBF and EBD modules; :mod:`.channels`: what they see;
- :mod:`.training`: noisy/clean pairs made on the fly with :mod:`mocapkit.corrupt`, Adam, checkpoints.
"""

from .channels import ChannelLayout, layout_for
from .inference import (
    DeepModel,
    Denoiser,
    denoise,
    denoise_channels,
    denoise_rows,
    fill_channels,
    fill_gaps,
    lerp_fill,
    load_model,
    save_model,
    shipped_model,
)
from .networks import EBD, EBF

__all__ = [
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
