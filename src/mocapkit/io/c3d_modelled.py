"""The modelled points of a take, stated in a C3D's POINT group so that a reader tells them from markers.

A C3D lists its modelled quantities by label in POINT parameters named
after their kind (ANGLES, FORCES, MOMENTS, POWERS, SCALARS, REACTIONS:
:data:`~mocapkit.markerset.MODELLED_GROUPS`, as Vicon writes them); modelled
positions (joint centres, centres of mass) are listed nowhere, and a reader
finds them by their camera masks of 0, which a take read from a TRC or an
npz does not have. A take read from a TRC or npz that mocapkit wrote knows
both (:attr:`~mocapkit.markerset.MarkerSource.modelled`, from the TRC's
``ModelledPoints`` field or the npz's ``modelled`` array): written as a C3D,
its quantities go into the POINT group of their kind and its modelled
positions into :data:`POSITIONS_KEY`, mocapkit's own POINT parameter,
which :func:`stated_positions` reads back. Parameters the file already
held are kept as they were: only labels they do not list are added.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..markerset import MODELLED_GROUPS

__all__ = ["POSITIONS_KEY", "modelled_parameters", "stated_positions"]

POSITIONS_KEY = "MODELLED_POSITIONS"  # POINT parameter: labels of the modelled positions (mocapkit's own)


def _listed(point: Mapping, key: str) -> list[str]:
    """The labels POINT parameter ``key`` lists (none where it is absent or no text)."""
    param = point.get(key)
    if not isinstance(param, Mapping) or param.get("type") != -1:
        return []
    return [str(v).strip() for v in np.ravel(param.get("value", [])) if str(v).strip()]


def modelled_parameters(labels, kinds, point: Mapping) -> dict[str, dict]:
    """The POINT parameters to write so that a C3D reader finds the modelled points of a take.

    ``labels`` (M,): the labels written; ``kinds`` (M,) str: each point's
    kind (:meth:`~mocapkit.markerset.MarkerSet.modelled_kinds`: a
    :data:`~mocapkit.markerset.MODELLED_GROUPS` name in lower case,
    "positions", "" for a marker); ``point``: the POINT group about to be
    written. Returns ``{name: parameter}`` for each group that must list
    more labels than it does (its own labels first, then those it lacks, in
    the take's order); empty where the group already lists them all (a C3D
    read and written back).
    """
    out = {}
    for key in (*MODELLED_GROUPS, POSITIONS_KEY):
        kind = "positions" if key == POSITIONS_KEY else key.lower()
        have = _listed(point, key)
        new = [str(label).strip() for label, k in zip(labels, kinds) if k == kind and str(label).strip() not in have]
        if new:
            old = point.get(key, {}) if isinstance(point.get(key), Mapping) else {}
            why = "points a model computed, not markers (mocapkit)" if key == POSITIONS_KEY else ""
            out[key] = {"type": -1, "description": old.get("description", why), "is_locked": old.get("is_locked", False),
                        "value": have + new}
    return out


def stated_positions(parameters: Mapping, labels) -> dict[str, str]:
    """``{label: "positions"}`` for each of ``labels`` that POINT:MODELLED_POSITIONS lists (see the module)."""
    listed = set(_listed(parameters.get("POINT", {}), POSITIONS_KEY))
    return {str(label): "positions" for label in labels if str(label).strip() in listed}
