"""Where a trained model comes from: the rig family it was trained on, its training data and its licence.

A model inherits the terms of the takes it was trained on: the Bandai Namco Research Motiondataset is
CC BY-NC 4.0, so a model trained on it is for non-commercial use only and its model card must say so
(``../shared/data`` README; the shipped ``ebf_bandai.pt`` / ``ebd_bandai.pt``, docs/models.md). These
functions make that card when a model is trained (:func:`model_card`, kept in the model file's metadata)
and read it back from any model file, older ones included (:func:`model_rig`, :func:`model_licence`), with the rig
said by one name everywhere (:func:`rig_name`: the shipped Bandai pair's cards, and models trained with 0.4.0, spell
it ``bandai``; it is read as ``bandai_namco``, the name of :data:`mocapkit.rigs.FAMILIES`).
"""

from __future__ import annotations

import re

from ... import rigs

__all__ = ["BANDAI_LICENCE", "DATA_LICENCES", "HDM05_LICENCE", "HDM05_ONLY_LICENCE", "NOT_STATED", "RIG_RESPELLINGS", "card_as_read", "data_licence",
           "model_card", "model_licence", "model_rig", "restricts_use", "rig_name", "training_rig", "training_rows",
           "unfinished_note", "rms_unit"]

BANDAI_LICENCE = ("CC BY-NC 4.0: trained on the Bandai Namco Research Motiondataset "
                  "(Bandai Namco Research Inc.); non-commercial use only")
#: The terms of a model trained on HDM05 takes (the shipped ``ebf.pt`` / ``ebd.pt``: HDM05 and CMU clips, docs/models.md):
#: HDM05 (Müller et al., Univ. Bonn, tech. report CG-2007-2) is published for research use; the CMU database is free
#: for research and commercial use, so HDM05's terms are the pair's (``../shared/data`` README).
HDM05_ONLY_LICENCE = ("research use only: trained on HDM05 takes (Müller et al., Univ. Bonn, tech. report CG-2007-2; "
                      "published for research use, no commercial terms)")
HDM05_LICENCE = HDM05_ONLY_LICENCE + " and CMU takes (free for research and commercial use)"
#: The clip names the HDM05 database gives its takes (``HDM_bd_walk_001_120``): a card listing such training clips and
#: stating no licence is of a model trained on HDM05, which inherits :data:`HDM05_LICENCE`.
_HDM05_CLIP = re.compile(r"\bHDM_[a-z]{2}_")
#: :data:`mocapkit.rigs.DATA_TERMS` (the terms of the takes of a rig family that is one data set's own rig: the
#: Bandai Namco game rig's CC BY-NC 4.0) as a model trained on such takes words them in its card: the same families.
DATA_LICENCES = {"bandai_namco": BANDAI_LICENCE}
#: What a model card says of a licence nobody stated.
NOT_STATED = "not stated"
#: Earlier spellings of a rig family in model cards -> the family's name (a key of :data:`mocapkit.rigs.FAMILIES`):
#: the shipped ``ebf_bandai.pt`` / ``ebd_bandai.pt`` and models made by ``scripts/train_shipped.py --rig bandai``
#: up to 0.4.0 say ``bandai``.
RIG_RESPELLINGS = {"bandai": "bandai_namco"}
_RESTRICTIVE = re.compile(r"\bNC\b|non-?commercial|research use|no commercial", re.IGNORECASE)


def rig_name(rig):
    """The one name of the rig family ``rig`` (a model card's ``rig`` entry): an earlier spelling of
    :data:`RIG_RESPELLINGS` as the family's name, any other value as it is (None: not known)."""
    return RIG_RESPELLINGS.get(rig, rig) if isinstance(rig, str) else rig


def card_as_read(meta):
    """A model file's metadata (its card) as mocapkit reads it: ``rig`` said by :func:`rig_name`, every other entry as
    stored, so a model read from an older file and saved again says its rig the same way as a new one."""
    if not isinstance(meta, dict) or "rig" not in meta:
        return meta
    return {**meta, "rig": rig_name(meta["rig"])}


def training_rig(clips) -> str | None:
    """The rig family (a key of :data:`mocapkit.rigs.FAMILIES`) of every take in ``clips`` (Motions), None when
    their rig is of no known family; takes of several families raise ValueError naming one take of each (a model
    is trained on one rig)."""
    families: dict[str | None, str] = {}
    for c in clips:
        families.setdefault(rigs.rig_family(c.skeleton), c.name or "a take")
    if len(families) > 1:
        said = ", ".join(f"{name} ({fam or 'no known family'})" for fam, name in families.items())
        raise ValueError(f"takes of several rigs: {said}; train one rig at a time")
    return next(iter(families), None)


def data_licence(clips) -> str | None:
    """The licence the project knows ``clips`` (Motions) to carry: the one of :data:`DATA_LICENCES` when every take
    is of that rig family (:func:`mocapkit.rigs.data_terms`), else None (unknown: the user states it, ``mocapkit
    train --licence``)."""
    return rigs.data_terms([c.skeleton for c in clips], DATA_LICENCES)


def model_card(clips, validation=None, given: dict | None = None) -> dict:
    """The metadata entries a model trained on ``clips`` (training takes, Motions) and ``validation`` (held-out
    takes) keeps about its origin.

    ``rig``: :func:`training_rig` of all the takes (None: no known family); ``licence``: ``given["licence"]`` when
    stated, else :func:`data_licence`, else None (read as :data:`NOT_STATED`); ``training_data``: ``takes`` and
    ``frames`` trained on, ``held_out_takes`` and ``held_out_frames``, plus ``given["training_data"]`` (the CLI adds
    the folders and the hold-out rule). Every other entry of ``given`` is kept as given; a ``rig`` there (as
    ``scripts/train_shipped.py`` gives it) is said by :func:`rig_name`.
    """
    given = dict(given or {})
    val = list(validation or [])
    data = {"takes": len(clips), "frames": int(sum(c.num_frames for c in clips)), "held_out_takes": len(val),
            "held_out_frames": int(sum(c.num_frames for c in val)), **(given.pop("training_data", None) or {})}
    rig = training_rig(list(clips) + val)
    licence = given.pop("licence", None) or data_licence(list(clips) + val)
    return card_as_read({"rig": rig, "licence": licence, "training_data": data, **given})


def model_rig(model) -> str | None:
    """The rig family a :class:`~mocapkit.cleaning.deep.DeepModel` was trained on: its metadata's ``rig``; for a
    model file without one (written before models kept it) "acclaim" where every joint it reads is an Acclaim joint
    (the shipped ``ebf.pt`` / ``ebd.pt``), else None (not known). An earlier spelling of the rig is read as
    :func:`rig_name` says it (the shipped Bandai pair's ``bandai`` is ``bandai_namco``)."""
    meta = model.meta if isinstance(model.meta, dict) else {}
    if "rig" in meta:
        return rig_name(meta["rig"])
    acclaim = {n for names in rigs.FAMILIES["acclaim"].values() for n in names}
    return "acclaim" if set(model.layout.joints) <= acclaim else None


def model_licence(model) -> str:
    """A model's licence as its card states it; for a card that states none but lists HDM05 clips among its
    training clips (``train_clips``: the shipped ``ebf.pt`` / ``ebd.pt``), the terms a model inherits from that
    data: :data:`HDM05_ONLY_LICENCE` where every clip is HDM05's (a model trained on HDM05 takes alone does not
    claim CMU takes), else :data:`HDM05_LICENCE` (HDM05 and CMU clips, as the shipped pair's); else
    :data:`NOT_STATED`."""
    meta = model.meta if isinstance(model.meta, dict) else {}
    if meta.get("licence"):
        return str(meta["licence"])
    clips = meta.get("train_clips")
    names = [str(c) for c in clips] if isinstance(clips, list) else [str(clips or "")]
    if not any(_HDM05_CLIP.search(n) for n in names):
        return NOT_STATED
    return HDM05_ONLY_LICENCE if all(_HDM05_CLIP.search(n) for n in names) else HDM05_LICENCE


def restricts_use(licence: str | None) -> bool:
    """Whether a licence text restricts use (non-commercial or research-only terms, e.g. CC BY-NC): the licences a
    :class:`~mocapkit.errors.LicenceWarning` names wherever the model is used."""
    return bool(licence) and _RESTRICTIVE.search(licence) is not None


def _epochs(meta: dict) -> tuple[int, int | None]:
    """(epochs run, epochs planned) from a model's metadata: its ``history`` and its ``config``'s ``epochs``."""
    history = meta.get("history")
    config = meta.get("config") if isinstance(meta.get("config"), dict) else {}
    planned = config.get("epochs")
    return (len(history) if isinstance(history, list) else 0), (int(planned) if isinstance(planned, int) else None)


def unfinished_note(model) -> str:
    """One line for a model whose training was interrupted (its metadata's ``finished`` is False: ``train`` writes
    each better epoch's model as it goes and marks it finished at the run's end), else "": the model works, but
    it is not what the run was set to make; the same ``mocapkit train`` command resumes it."""
    meta = model.meta if isinstance(model.meta, dict) else {}
    if meta.get("finished") is not False:
        return ""
    run, planned = _epochs(meta)
    what = f"{run} of {planned}" if planned else str(run)
    where = f" {model.source}" if getattr(model, "source", "") else ""
    return (f"the {model.kind.upper()}{where} is from an unfinished training ({what} epochs run); the same "
            "`mocapkit train` command resumes it")


def rms_unit(representation: str) -> str:
    """The unit of a model's training and validation RMS (Mall et al. 2017's error) on channels of ``representation``:
    degrees on Euler channels, rotation-matrix entries on 6-D ones."""
    return "deg" if representation == "euler" else "(rotation-matrix entries)"


def training_rows(meta) -> list[tuple[str, str]]:
    """``info``'s lines on how a model was trained, from its metadata (none for a model file without them):
    epochs run of planned and whether the run finished, the best validation RMS (degrees on Euler channels,
    Mall et al. 2017's error; rotation-matrix units on 6-D ones; the training RMS where nothing was held out)
    with its epoch, and the noise, steps and seed settings."""
    if not isinstance(meta, dict) or not isinstance(meta.get("config"), dict):
        return []
    cfg = meta["config"]
    run, planned = _epochs(meta)
    of = f"{run} of {planned}" if planned else str(run)
    if meta.get("finished") is False:
        state = f"{of}: unfinished (interrupted; the same train command resumes it)"
    elif planned and run < planned:
        state = f"{of}: finished early (its --minutes budget)"
    else:
        state = f"{of}: finished" if "finished" in meta else of
    rows = [("epochs", state)]
    best = meta.get("best_val_rmse")
    if isinstance(best, (int, float)):
        unit = rms_unit(cfg.get("representation", "euler"))
        which = "validation" if meta.get("validation_clips") else "training"
        epoch = meta.get("best_epoch")
        at = f" (epoch {int(epoch) + 1})" if isinstance(epoch, int) else ""
        rows.append((f"best {which} RMS", f"{best:.3f} {unit}{at}"))
    if cfg.get("noise"):
        rows.append(("noise", ", ".join(map(str, cfg["noise"]))))
    rows.append(("settings", f"{cfg.get('steps_per_epoch', '?')} steps per epoch, batch {cfg.get('batch', '?')}, "
                             f"seed {cfg.get('seed', '?')}"))
    return rows
