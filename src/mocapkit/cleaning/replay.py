"""Options given beside a record that is replayed: honoured where they agree with it, refused where they do not.

Decisions applied with ``record=`` (``mocapkit.clean``; the CLI's ``--record``, or the record ``clean --decisions``
finds beside OUT) go to the cleaning the record keeps: nothing is cleaned again, so the options that shape a cleaning
(its steps, threshold, drifts, context, models and noise level; a marker capture's longest gap and largest fill
error) cannot change it. Given beside the record, such an option is one the user expects to act; it is taken only
where the record's cleaning was asked for with the very same value (``params["request"]``, as
:func:`mocapkit.batch_request.clean_request` and :func:`mocapkit.marker_files.marker_request` keep it), and refused in one
line naming the record, each option as the caller spells it and the value the record was made with, before
anything is written. The options that read the take (an AMC's ASF and frame rate, a length unit) are the take's, not
the cleaning's: they are used, and the take read with them must be the one the record was made from
(:func:`mocapkit.cleaning.decisions.check_record`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from ..errors import MocapError
from .pipeline import STEPS, CleanResult
from .request_words import OPTION_FLAGS, OPTION_KEYWORDS, is_unset, said_option

__all__ = ["given_options", "check_replay"]


def _as_given(key: str, value, flags: bool, unset: str) -> str:
    """Option ``key`` of a request at ``value`` as its caller gives it (:func:`mocapkit.cleaning.request_words.said_option`:
    ``--threshold 0.3``, ``threshold=0.3``, ``--ebf m.pt``, ``steps='detect'``); one at its default (None, no
    models, the default context) by its name and ``unset`` (the record's: ``--max-gap not given``), never ``None``;
    Python's ``drifts=False`` is a value given, not an option left out."""
    name = (OPTION_FLAGS if flags else OPTION_KEYWORDS)[key]
    if is_unset(key, value) and (flags or key != "drifts"):
        return f"{name}{unset}"
    return said_option(key, value, flags)


def given_options(steps, threshold: float, drifts: bool, context: bool, models, noise_deg) -> list[str]:
    """The keys of a joint-angle cleaning's options (a record's ``request``) that a caller set away from their
    defaults: ``steps`` parsed (a tuple), ``threshold`` (default 0.5), ``drifts``, ``context`` whether one was given,
    ``models`` the models chosen (none: the shipped ones), ``noise_deg`` (None: the default). What
    :func:`check_replay` checks beside a record, the same for ``mocapkit.clean`` and ``mocapkit clean``."""
    return [key for key, given in (("steps", tuple(steps) != STEPS), ("threshold", threshold != 0.5),
                                   ("drifts", bool(drifts)), ("context", bool(context)), ("models", bool(models)),
                                   ("noise_deg", noise_deg is not None)) if given]


def check_replay(record, request: Mapping, given: Iterable[str], flags: bool, option: str) -> None:
    """Refuse the options ``given`` beside ``record`` whose values are not those its cleaning was asked for.

    ``record``: the ``.clean.npz`` replayed; ``request``: the options of this call as a record keeps them;
    ``given``: the keys of ``request`` the caller set (a default left alone is not given); ``flags``: whether the
    caller is the command line (its flags, :data:`~mocapkit.cleaning.request_words.OPTION_FLAGS`) or Python (its
    keywords, :data:`~mocapkit.cleaning.request_words.OPTION_KEYWORDS`); ``option``: how it gave the record
    ("record=", "--record"). Each option is said as that caller gives it, with its value
    (:func:`~mocapkit.cleaning.request_words.said_option`), in the order of those tables.
    A record that keeps no request (written by an earlier mocapkit, or by a cleaning in Python before requests were
    kept) agrees with no option given. Raises :class:`~mocapkit.errors.MocapError` (one line naming ``record``);
    :class:`~mocapkit.errors.MocapFormatError` where ``record`` is no mocapkit record.
    """
    given = [k for k in OPTION_FLAGS if k in set(given)]
    if not given:
        return
    was = (CleanResult.load_params(record) or {}).get("request")
    was = was if isinstance(was, Mapping) else {}
    differ = [k for k in given if k not in was or was[k] != request.get(k)]
    if not differ:
        return
    said = ", ".join(_as_given(k, request.get(k), flags, "" if flags else "=") for k in differ)
    kept = ", ".join(_as_given(k, was[k], flags, " not given") if k in was
                     else f"{(OPTION_FLAGS if flags else OPTION_KEYWORDS)[k]} not kept" for k in differ)
    raise MocapError(f"{record}: {said} given beside {option}, whose cleaning is applied as it was made ({kept} in "
                     f"the record): leave {'it' if len(differ) == 1 else 'them'} out, or clean anew without {option}")
