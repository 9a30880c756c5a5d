"""What a take was asked to be cleaned with (its record's ``request``), and how an earlier run's differs from this one's.

:func:`clean_request` is what a joint-angle take's ``.clean.npz`` keeps of the options it was cleaned with
(:func:`mocapkit.marker_files.marker_request` a marker capture's); :func:`mocapkit.batch.clean_batch` takes a take as
complete only when its record holds this run's request, and refuses one made with another, saying how they differ
(:func:`request_change`). Keys a record of an earlier mocapkit lacks read as :data:`REQUEST_DEFAULTS`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

__all__ = ["clean_request", "REQUEST_DEFAULTS", "request_change"]


def clean_request(steps=None, threshold: float = 0.5, drifts: bool = False, context: Sequence | None = None,
                  models: dict | None = None, noise_deg: float | None = None, amc_fps: float | None = None,
                  unit: str | None = None, joint_map: dict | None = None) -> dict:
    """What a take was asked to be cleaned with, as its record keeps it (``params["request"]``).

    :func:`mocapkit.batch.clean_batch` takes a take as complete only when its record holds the same request: a take
    reviewed with ``steps="detect"`` or cleaned at another threshold, noise level, AMC frame rate, unit or
    joint map is not what a later run asks for. ``joint_map``: the names a ``context`` folder's build gives a rig's
    joints (:func:`mocapkit.batch.load_context`), kept as its content, sorted (a map file edited in place is another request);
    kept only where a context is given, the one thing it shapes. Keys a record of an earlier mocapkit lacks read as
    their defaults (:data:`REQUEST_DEFAULTS`).
    """
    from .cleaning.pipeline import NOISE_DEG, STEPS, parse_steps

    def spec(c):
        p = Path(c)
        return str(p.resolve()) if p.exists() else os.fspath(c)

    from .context import is_off

    return {"steps": list(parse_steps(steps or STEPS)), "threshold": float(threshold), "drifts": bool(drifts),
            # the context turned off, however it was said ('none', 'off', 'NONE'): one request, as records kept it
            "context": ["none"] if context and is_off(list(context)) else ([spec(c) for c in context] if context else "default"),
            "models": {k: spec(v) if isinstance(v, (str, os.PathLike)) else type(v).__name__
                       for k, v in sorted((models or {}).items())},
            "noise_deg": float(NOISE_DEG if noise_deg is None else noise_deg),
            "amc_fps": None if amc_fps is None else float(amc_fps), "unit": unit,
            "joint_map": dict(sorted((joint_map or {}).items())) if context and not is_off(list(context)) else {}}


REQUEST_DEFAULTS = {"noise_deg": 1.0, "amc_fps": None, "unit": None, "review": False, "joint_map": {},
                    "zeros_as_gaps": None}  # what a record without these keys was made with


def request_change(done: dict, request: dict, flags: bool = False) -> str:
    """How the request a take's record keeps (``done``; keys it lacks read as :data:`REQUEST_DEFAULTS`) differs from
    this run's ``request``, in one clause for a refusal, each option as the caller gave it
    (:func:`mocapkit.cleaning.request_words.request_changes`; ``flags``: the command line's, else Python's keywords):
    ``it was cleaned without --max-gap (now --max-gap 0.05)``; "" when it does not differ."""
    from .cleaning.request_words import request_changes

    was = {k: done.get(k, REQUEST_DEFAULTS.get(k)) for k in request}
    diff = request_changes(was, request, flags)
    return f"it was cleaned {', '.join(diff)}" if diff else ""
