"""How a refusal says the options a cleaning was asked for: as its caller gave them.

A take's record keeps the options it was cleaned with as Python values (its ``request``:
:func:`mocapkit.batch_request.clean_request`, :func:`mocapkit.marker_files.marker_request`). A refusal that names one
of them speaks to whoever gave it: a ``clean-batch`` user typed ``--max-gap 0.05``, a caller of
``mocapkit.clean_batch(...)`` wrote ``max_gap_s=0.05``. :func:`request_changes` says how an earlier request
differs from this one in either tongue (``flags``): each option by its flag or keyword, its value as typed
(seconds, millimetres, degrees: the units both take), and an option left unset (None, no models, the default
context) in words, never as ``None``:

- ``with --threshold 0.5 (now 0.7)`` / ``with threshold=0.5 (now 0.7)``; ``with --unit cm (now mm)`` /
  ``with unit='cm' (now 'mm')`` (strings, lists and maps as Python writes them: ``repr``, as every refusal
  naming a Python keyword says its value, ``record='R.clean.npz'``, ``executor='tcp://...'``);
- ``without --max-gap (now --max-gap 0.05)`` / ``without max_gap_s (now max_gap_s=0.05)``;
- ``with --drifts (now without it)``, ``without --drifts (now with it)`` / ``with drifts=True (now False)``.

``clean-batch``'s refusal of a take cleaned otherwise (``it was cleaned with ...``) and a decisions file's of
another cleaning (``reviewed with ...``: :func:`mocapkit.cleaning.decisions.request_difference`) say them so.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping

__all__ = ["OPTION_FLAGS", "OPTION_KEYWORDS", "is_unset", "request_changes", "said_option"]

#: How ``mocapkit clean`` / ``clean-batch`` name the options a request keeps (``review``: a marker capture's
#: ``--steps detect``; ``models`` by the flag of each model; ``zeros_as_gaps`` by its two flags).
OPTION_FLAGS = {"steps": "--steps", "threshold": "--threshold", "drifts": "--drifts", "context": "--context",
                "models": "--ebf/--ebd", "noise_deg": "--noise-deg", "amc_fps": "--amc-fps", "unit": "--unit",
                "joint_map": "--joint-map", "max_gap_s": "--max-gap", "max_error_mm": "--max-fill-error",
                "review": "--steps detect", "zeros_as_gaps": "--zeros-as-gaps/--keep-zeros"}
#: How the Python API (``mocapkit.clean``, ``mocapkit.clean_batch``, ``clean_file``) names them.
OPTION_KEYWORDS = {"steps": "steps", "threshold": "threshold", "drifts": "drifts", "context": "context",
                   "models": "models", "noise_deg": "noise_deg", "amc_fps": "amc_fps", "unit": "unit",
                   "joint_map": "joint_map", "max_gap_s": "max_gap_s", "max_error_mm": "max_error_mm",
                   "review": "steps='detect'", "zeros_as_gaps": "zeros_as_gaps"}

_ZEROS_FLAG = {True: "--zeros-as-gaps", False: "--keep-zeros"}
_ZEROS_HOW = {True: "read as gaps", False: "kept as positions", None: "decided from the data"}


def _number(v) -> str:
    """A number as a person types it: ``0.05``, ``3`` for 3.0, the shortest text that reads back as ``v``."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return str(v)
    short = f"{v:g}"
    return short if float(short) == float(v) else repr(float(v))


def is_unset(key: str, value) -> bool:
    """Whether ``value`` is ``key`` left to its default: None, no models, no joint map, the default context, not
    review mode, no ``--drifts``."""
    return (value is None or (key == "models" and value == {}) or (key == "joint_map" and not value)
            or (key == "context" and value == "default") or (key in ("review", "drifts") and value is False))


def said_option(key: str, value, flags: bool) -> str:
    """The option ``key`` of a request given as ``value``, as its caller would have given it: ``--max-gap 0.05``,
    ``max_gap_s=0.05``, ``--context /data/ctx``, ``--ebf m.pt``, ``--drifts``; a joint map by its digest (a map names
    every joint of a rig: ``a --joint-map of digest 1a2b3c4d``). ``value`` is not unset (:func:`request_changes` words that)."""
    name = (OPTION_FLAGS if flags else OPTION_KEYWORDS).get(key, key)
    if key == "joint_map":
        return f"a {name} of digest {hashlib.sha256(json.dumps(value, sort_keys=True).encode()).hexdigest()[:8]}"
    if key == "review":
        return name
    if key == "zeros_as_gaps":
        return _ZEROS_FLAG[bool(value)] if flags else f"{name}={bool(value)}"
    if flags:
        if key == "drifts":
            return name
        if key == "models" and isinstance(value, Mapping):
            return " ".join(f"--{kind} {model}" for kind, model in value.items())
        if key == "context" and isinstance(value, (list, tuple)):
            return " ".join(f"--context {c}" for c in value)
        if isinstance(value, (list, tuple)):
            return f"{name} {','.join(map(str, value))}"
        return f"{name} {_number(value)}"
    if key == "steps" and isinstance(value, (list, tuple)):
        value = ",".join(map(str, value))
    return f"{name}={_number(value) if isinstance(value, (int, float)) else repr(value)}"


def _value(key: str, value, flags: bool) -> str:
    """``value`` alone, as the ``(now ...)`` of a changed option says it: ``0.7``, ``cm`` (``'cm'`` to Python)."""
    said = said_option(key, value, flags)
    if key in ("threshold", "noise_deg", "amc_fps", "unit", "max_gap_s", "max_error_mm", "steps"):
        return said.split("=", 1)[1] if not flags else said.split(" ", 1)[1] if " " in said else said
    if key == "joint_map":
        return said.split(" ", 2)[2]
    return said


def _change(key: str, was, now, flags: bool) -> str:
    """One option that differs: ``with --threshold 0.5 (now 0.7)``, ``without --unit (now --unit cm)``,
    ``with --max-gap 0.05 (now without it)``; a marker capture's exact zeros with what they are read as now."""
    name = (OPTION_FLAGS if flags else OPTION_KEYWORDS).get(key, key)
    if key == "zeros_as_gaps":  # the data decides when neither is given: the line says what the samples are now
        how = f": exact (0, 0, 0) samples {_ZEROS_HOW[now]}"
        then = "neither --zeros-as-gaps nor --keep-zeros" if flags else f"without {name}"
        first = f"with {then}" if was is None and flags else then if was is None else f"with {said_option(key, was, flags)}"
        return f"{first} (now {'without it' if now is None else said_option(key, now, flags)}{how})"
    if key == "review":  # the review mode, or every step
        return f"with {name if was else 'all steps'} (now {name if now else 'all steps'})"
    if key == "drifts" and not flags:  # a Python bool is a value, not a flag left out
        return f"with {name}={was!r} (now {now!r})"
    if is_unset(key, was):
        bare = flags and key == "drifts"  # a flag with no value: "without --drifts (now with it)"
        return f"without {name} (now {'with it' if bare else said_option(key, now, flags)})"
    if is_unset(key, now):
        return f"with {said_option(key, was, flags)} (now without it)"
    return f"with {said_option(key, was, flags)} (now {_value(key, now, flags)})"


def request_changes(was: Mapping, now: Mapping, flags: bool) -> list[str]:
    """How request ``was`` differs from request ``now``, one clause per option that differs (in ``now``'s order,
    then those only ``was`` keeps): :func:`_change`'s words, naming the command line's flags (``flags``) or the
    Python API's keywords. Both are records' ``request`` dicts, their missing keys already read as the defaults."""
    keys = [k for k in list(now) + [k for k in was if k not in now] if was.get(k) != now.get(k)]
    return [_change(k, was.get(k), now.get(k), flags) for k in keys]
