"""A multilinear model's file: the motion tensors of one class, saved once and read back into the model.

Building a model (Tautges 2012, ch. 2) aligns every clip to the reference clip by DTW and stacks them into the
motion tensors of sec. 2.2.2 (:func:`~mocapkit.reconstruct.motion_tensor.motion_tensor`): the long part. The
HOSVD of those tensors (eq. 2.1) takes well under a second, so the file keeps the tensors, not the
decomposition, and :func:`load_model` decomposes them again with the model's own settings: a model read back
fits readings as the one saved did.

The file is an ``.npz`` (read with ``allow_pickle=False``, bounded before inflating:
:func:`mocapkit.io.npz.load_arrays`) of:

* ``kind``: ``"multilinear model"``; ``format_version``: :data:`FORMAT_VERSION`;
* ``rotations`` (4, B, L, d_1, ..., d_n) and ``root`` (3, L, d_1, ..., d_n), float64: ``Theta_q`` and
  ``Theta_p`` (:class:`~mocapkit.reconstruct.motion_tensor.MotionTensor`); ``observed`` (d_1, ..., d_n) bool;
* ``up`` (3,): the clips' vertical;
* ``held_rotations`` (1, J, 4), ``held_root`` (1, 3) and ``held_translations`` (1, J, 3), where the clips hold
  the joints above the pelvis still (the Bandai Namco ``joint_Root`` at the origin);
* ``description``: a JSON text with the natural ``modes`` and their ``entries``, the ``skeleton``
  (:func:`mocapkit.database_folder.skeleton_to_json`), ``fps``, the ``reference`` clip and the clip
  ``names`` per observed cell, the model's ``settings`` (ranks, regularization, time warp, starts), the
  ``sources`` (file names), their ``class`` and, where the clips' terms are known, their ``licence``
  (:func:`mocapkit.rigs.data_terms`): a model is made from the takes and carries their terms.

Anything else is refused in one line naming the file (:class:`~mocapkit.errors.MocapFormatError`): not an
npz, not a model, a format version this mocapkit does not read, arrays of shapes that do not fit together.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Sequence

import numpy as np

from ..database_folder import skeleton_from_json, skeleton_to_json
from ..errors import MocapError, MocapFormatError
from ..motion import Motion
from .motion_tensor import MotionTensor
from .multilinear import MultilinearModel

__all__ = ["FORMAT_VERSION", "KIND", "SETTINGS", "save_model", "load_model"]

#: The version of the file layout this mocapkit writes and reads.
FORMAT_VERSION = 1
#: The ``kind`` array of a model file.
KIND = "multilinear model"
#: The :class:`~mocapkit.reconstruct.multilinear.MultilinearModel` settings a file keeps.
SETTINGS = ("ranks", "regularization", "warp_iterations", "warp_smoothing", "starts", "missing")
_ARRAYS = ("kind", "format_version", "rotations", "root", "observed", "up", "description")
_HELD = ("held_rotations", "held_root", "held_translations")


def save_model(model: MultilinearModel, path, sources: Sequence[str] = (), licence: str | None = None,
               motion_class: str = "") -> Path:
    """Write a fitted ``model`` to ``path`` (an ``.npz``) atomically (temp file + rename); returns the path.

    ``sources``: the clips' file names, and ``motion_class`` their class, kept in the description; ``licence``: the clips' terms
    (:func:`mocapkit.rigs.data_terms`), kept so that whoever gets the file gets them.
    """
    from ..io import atomic_write

    if not hasattr(model, "tensor_"):
        raise ValueError("save_model: the model is not fitted yet; call fit(clips) first")
    t: MotionTensor = model.tensor_
    description = {
        "modes": list(t.modes),
        "entries": [[_label(e) for e in ent] for ent in t.entries],
        "skeleton": skeleton_to_json(t.skeleton),
        "fps": float(t.fps),
        "reference": str(t.reference),
        "names": [str(n) for n in t.names],
        "settings": {k: getattr(model, k) for k in SETTINGS},
        "sources": [str(s) for s in sources],
        "class": str(motion_class),
        **({"licence": licence} if licence else {}),
    }
    arrays = {
        "kind": np.array(KIND),
        "format_version": np.array(FORMAT_VERSION),
        "rotations": np.asarray(t.rotations, dtype=np.float64),
        "root": np.asarray(t.root, dtype=np.float64),
        "observed": np.asarray(t.observed, dtype=bool),
        "up": np.asarray(t.up, dtype=np.float64),
        "description": np.array(json.dumps(description)),
    }
    if t.held is not None:
        arrays["held_rotations"] = np.asarray(t.held.rotations, dtype=np.float64)
        arrays["held_root"] = np.asarray(t.held.root_positions, dtype=np.float64)
        if t.held.translations is not None:
            arrays["held_translations"] = np.asarray(t.held.translations, dtype=np.float64)
    path = Path(path)
    with atomic_write(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    return path


def _label(e):
    """A label as JSON holds it: int, float and str kept, anything else as its text."""
    if isinstance(e, (bool, np.bool_)):
        return str(e)
    if isinstance(e, (int, np.integer)):
        return int(e)
    if isinstance(e, (float, np.floating)):
        return float(e)
    return str(e)


def load_model(path, progress: bool = False) -> tuple[MultilinearModel, dict]:
    """The model saved at ``path`` (:func:`save_model`), decomposed again, and its description (a dict).

    Raises :class:`~mocapkit.errors.MocapFormatError` (one line naming ``path``) for a file that is not a
    model of this format version, or whose arrays do not fit together.
    """
    from ..io.npz import load_arrays

    path = Path(path)
    if not path.is_file():
        from ..errors import MissingFileError

        raise (MocapFormatError(path, "not a regular file") if path.exists() else MissingFileError(path))
    try:
        data = load_arrays(path)
    except MocapError:
        raise
    except Exception as exc:  # noqa: BLE001 - a file that is no npz at all: one line
        raise MocapFormatError(path, f"not a multilinear model (not an npz: {' '.join(str(exc).split())})") from None
    kind = data.get("kind")
    if kind is None or kind.shape != () or kind.dtype.kind != "U" or str(kind) != KIND:
        what = f"an npz of kind {str(kind)!r}" if kind is not None and kind.shape == () else "an npz without its kind"
        raise MocapFormatError(path, f"not a multilinear model ({what}; `mocapkit multilinear build` writes one)")
    version = data.get("format_version")
    if version is None or version.shape != () or version.dtype.kind not in "iu":
        raise MocapFormatError(path, "a multilinear model without a format version; rebuild it with "
                                     "`mocapkit multilinear build`")
    if int(version) != FORMAT_VERSION:
        raise MocapFormatError(path, f"a multilinear model of format version {int(version)}; this mocapkit reads "
                                     f"version {FORMAT_VERSION}: rebuild it with `mocapkit multilinear build`")
    missing = [k for k in _ARRAYS if k not in data]
    if missing:
        raise MocapFormatError(path, f"a multilinear model without {', '.join(missing)}")
    try:
        desc = json.loads(str(data["description"]))
    except ValueError as exc:
        raise MocapFormatError(path, f"unreadable model description ({exc})") from None
    keys = ("modes", "entries", "skeleton", "fps", "reference", "names", "settings", "sources")
    if not isinstance(desc, dict) or any(k not in desc for k in keys):
        raise MocapFormatError(path, f"the model description lacks {', '.join(k for k in keys if k not in (desc if isinstance(desc, dict) else {}))}")
    skeleton = skeleton_from_json(desc["skeleton"], "skeleton", path)
    tensor = _tensor(path, data, desc, skeleton)
    settings = desc["settings"]
    if not isinstance(settings, dict) or set(settings) - set(SETTINGS):
        raise MocapFormatError(path, f"the model settings must be an object of {', '.join(SETTINGS)}")
    try:
        model = MultilinearModel(modes=tensor.modes, fps=tensor.fps, progress=progress, **settings).fit(tensor)
    except (TypeError, ValueError) as exc:
        raise MocapFormatError(path, f"cannot decompose the model's tensors: {' '.join(str(exc).split())}") from None
    return model, desc


def _tensor(path: Path, data: dict, desc: dict, skeleton) -> MotionTensor:
    """The :class:`MotionTensor` of a model file, every shape checked against the others first."""
    from ._common import body_joints

    rot, root, observed, up = data["rotations"], data["root"], data["observed"], data["up"]
    modes, entries = desc["modes"], desc["entries"]
    if not (isinstance(modes, list) and modes and all(isinstance(m, str) for m in modes)
            and isinstance(entries, list) and len(entries) == len(modes) and all(isinstance(e, list) for e in entries)):
        raise MocapFormatError(path, "the model's modes and entries must be lists, one list of entries per mode")
    shape = tuple(len(e) for e in entries)
    B = len(body_joints(skeleton))
    for name, a, want in (("rotations", rot, (4, B, None) + shape), ("root", root, (3, None) + shape),
                          ("observed", observed, shape), ("up", up, (3,))):
        if a.ndim != len(want) or any(w is not None and s != w for s, w in zip(a.shape, want)):
            raise MocapFormatError(path, f"model array {name} has shape {a.shape}, expected "
                                         f"{tuple('L' if w is None else w for w in want)}")
        if a.dtype.kind != ("b" if name == "observed" else "f") or (a.dtype.kind == "f" and not np.isfinite(a).all()):
            raise MocapFormatError(path, f"model array {name} must be {'bool' if name == 'observed' else 'finite float'}")
    if rot.shape[2] != root.shape[1] or rot.shape[2] < 5:
        raise MocapFormatError(path, f"the model's rotation and root tensors have {rot.shape[2]} and {root.shape[1]} "
                                     "frames (5 or more, the same)")
    if not np.linalg.norm(up) > 0:
        raise MocapFormatError(path, "the model's vertical (up) is the zero vector")
    names = desc["names"]
    if not isinstance(names, list) or len(names) != int(observed.sum()):
        raise MocapFormatError(path, f"the model names {len(names) if isinstance(names, list) else 0} clips for its "
                                     f"{int(observed.sum())} observed cells")
    fps = desc["fps"]
    if not isinstance(fps, (int, float)) or not np.isfinite(fps) or fps <= 0:
        raise MocapFormatError(path, f"the model's fps must be a positive number, got {fps!r}")
    held = None
    if "held_rotations" in data:
        J = skeleton.num_joints
        hr, hp = data["held_rotations"], data.get("held_root")
        ht = data.get("held_translations")
        if hp is None or hr.shape != (1, J, 4) or hp.shape != (1, 3) or (ht is not None and ht.shape != (1, J, 3)):
            raise MocapFormatError(path, f"the model's held pose must be held_rotations (1, {J}, 4), held_root (1, 3) "
                                         f"and held_translations (1, {J}, 3)")
        held = Motion(skeleton, hr, hp, float(fps), "held", ht)
    return MotionTensor(rotations=rot, root=root, modes=tuple(modes), entries=tuple(tuple(e) for e in entries),
                        observed=observed, skeleton=skeleton, fps=float(fps), reference=str(desc["reference"]),
                        names=tuple(str(n) for n in names), up=up / np.linalg.norm(up), held=held)
