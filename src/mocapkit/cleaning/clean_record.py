"""The record of a cleaning: :class:`CleanResult` and its :class:`StepRecord` s, the ``.clean.npz`` they are saved as.

:func:`mocapkit.cleaning.pipeline.clean` returns a :class:`CleanResult`: the cleaned take, the per-step masks of
the cells each step changed (``filled``, ``repaired``, ``denoised``: (F, J) bool), the detection's movement
digression map and flags (Aristidou et al. 2018), the noise level, and per step a :class:`StepRecord` (seconds,
cells changed, method, note). :meth:`CleanResult.save` writes it beside the cleaned output
(:func:`clean_path`: ``walk.bvh`` -> ``walk.clean.npz``; format :data:`FORMAT`, no pickles) and
:meth:`CleanResult.load` reads it back, so that :mod:`mocapkit.cleaning.decisions` can apply a person's choices
without cleaning again. :meth:`CleanResult.summary` is the text ``mocapkit clean`` prints (:func:`capped_lines`:
at most :data:`MAX_LINES` lines of one kind). Everything here is importable from
:mod:`mocapkit.cleaning.pipeline` too, where it was first defined.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import MissingFileError, MocapFormatError
from ..motion import Motion, frozen
from ..words import plural
from .calibration import CalibrationPose
from .stutters import Stutter
from .take_breaks import Cut
from .zeros import ZeroRun

__all__ = ["FORMAT", "MAX_LINES", "StepRecord", "CleanResult", "clean_path", "capped_lines", "record_kind_hint"]

FORMAT = "mocapkit.clean/1"


@dataclass(frozen=True)
class StepRecord:
    """What one step did: its name, seconds, cells changed, the method used and why, and a note.

    The seconds are not saved (:meth:`as_dict`): a record of the same take and request is then the same file on
    every run (a checksum or a diff of two runs' records showed only the timings); a loaded step's are NaN.
    """

    name: str
    seconds: float
    cells: int
    method: str
    note: str = ""

    def as_dict(self) -> dict:
        return {k: v for k, v in dataclasses.asdict(self).items() if k != "seconds"}

    def __str__(self) -> str:
        took = f" ({self.seconds:.2f} s)" if np.isfinite(self.seconds) else ""
        s = f"{self.name}{took}: {self.method}"
        if self.name != "detect" and not self.method.startswith(("skipped", "nothing")):
            s += f", {plural(self.cells, 'joint sample')} changed"
        return s + (f"; {self.note}" if self.note else "")


@dataclass(frozen=True, eq=False)
class CleanResult:
    """Result of :func:`~mocapkit.cleaning.pipeline.clean`; every (F, J) array is at the input's frames and joint order.

    ``motion``: the cleaned take (None when loaded from a file without one);
    ``detection``: the :class:`~mocapkit.cleaning.ssa.Detection` (None when
    detect did not run or after :meth:`load`); ``mdm``/``flags``: its movement
    digression map and flags (zeros/False when detect did not run);
    ``filled``/``repaired``/``denoised``: bool, the cells each step changed;
    ``noise``: float (F, J) the noise level of :func:`~mocapkit.cleaning.pipeline.noise_level` in degrees
    (NaN when denoise did not run); ``steps``: :class:`StepRecord` per step
    that ran; ``notes``: what fell back and why; ``calibration``: the
    :class:`~mocapkit.cleaning.calibration.CalibrationPose` opening or closing
    the take, left alone by every step. When there is one, detect ran on the
    frames between (``params["analysed"]``, ``[lo, hi)``): the detection's
    (F, J) arrays are padded back to the take's frames, its word and neighbour
    arrays count from ``lo``. ``samples`` (after
    :meth:`load`; None for a record written without them): the cleaned
    values of the changed cells, ``{"rotations": (K, 4), "root": (K0, 3)[,
    "translations": (K, 3)]}`` with K = ``changed.sum()`` in row-major cell
    order and K0 the frames whose root cell changed, so that
    :mod:`mocapkit.cleaning.decisions` can apply a person's choices exactly.
    ``causes``: (F, J) :data:`~mocapkit.cleaning.ssa.cues.CAUSE_DTYPE`, which of detect's rules flagged each cell (bits of
    :data:`~mocapkit.cleaning.ssa.cues.CAUSES`, 0 where not flagged; None when
    detect did not run or for a record written without them).
    ``take_sha256``: :func:`mocapkit.cleaning.decisions.take_digest` of the take
    that was cleaned, so that a record is applied to no other take (a record of
    another take of the same rig and length would put that take's cleaned values
    in); "" for a record written before it was kept.
    ``left_out``: ``((joint name, why), ...)``, the joints detect did not analyse and why
    (:meth:`mocapkit.cleaning.ssa.Detection.not_analysed`; their MDM is 0 and nothing flags
    them: not checked, rather than found clean); None when detect did not run or for a record
    written before they were kept. :attr:`analysed` is the same as a mask.
    ``zeros``: bool (F, J), the cells the take wrote as 0 where it lost data (a dropout,
    :mod:`mocapkit.cleaning.zeros`), which fill filled as missing cells (None for a record written before they were
    found); ``zero_runs``: their :class:`~mocapkit.cleaning.zeros.ZeroRun` s, named in the summary;
    ``stutters``: the :class:`~mocapkit.cleaning.stutters.Stutter` s, frames repeating the one before bit for bit
    while the take moves, named and left as they are.
    ``cuts``: the :class:`~mocapkit.cleaning.take_breaks.Cut` s detect found (two takes joined, or frames dropped), at
    the take's frames: named, no sample changed for them (the HTML report lists them beside the changes).
    ``frames_note``: how the frame numbers of the summary, flags and changes (0-based take indexes) relate to the
    input file's own, :func:`mocapkit.cleaning.decisions.frames_note`; "" when the take came from no file that
    numbers its frames from other than 0 (a Motion, a BVH). Set by :func:`mocapkit.clean` and
    :func:`mocapkit.batch.clean_file`, which know the file; not kept in the record.
    ``decided``: the :class:`~mocapkit.cleaning.decided.Decided` of the decisions applied to get this result
    (:func:`mocapkit.cleaning.decide.decided_result`; None for a cleaning); :meth:`summary` then says it.
    """

    motion: Motion | None
    mdm: np.ndarray
    flags: np.ndarray
    filled: np.ndarray
    repaired: np.ndarray
    denoised: np.ndarray
    noise: np.ndarray
    joint_names: tuple
    fps: float
    steps: tuple = ()
    notes: tuple = ()
    params: dict = field(default_factory=dict)
    detection: object = None
    samples: dict | None = None
    calibration: tuple = ()
    causes: np.ndarray | None = None
    take_sha256: str = ""
    left_out: tuple | None = None
    zeros: np.ndarray | None = None
    zero_runs: tuple = ()
    stutters: tuple = ()
    cuts: tuple = ()
    frames_note: str = ""
    decided: object = None

    def __post_init__(self):
        # read-only, and not the detection's own arrays: a caller writing res.repaired[:] = False changed what
        # decisions.changes listed, and the detection with it
        for name in ("mdm", "flags", "filled", "repaired", "denoised", "noise", "causes", "zeros"):
            a = getattr(self, name)
            if a is not None:
                object.__setattr__(self, name, frozen(np.asarray(a)))

    def __repr__(self) -> str:
        return (f"CleanResult({self.motion!r}, {int(self.flags.sum())} flagged, {int(self.filled.sum())} filled, "
                f"{int(self.repaired.sum())} repaired, {int(self.denoised.sum())} denoised joint samples)")

    @property
    def changed(self) -> np.ndarray:
        """(F, J) bool: cells any step changed."""
        return self.filled | self.repaired | self.denoised

    @property
    def num_frames(self) -> int:
        return int(self.filled.shape[0])

    @property
    def analysed(self) -> np.ndarray | None:
        """(J,) bool: the joints detect analysed (all but :attr:`left_out`); None when that is not known."""
        if self.left_out is None:
            return None
        out = set(n for n, _ in self.left_out)
        return np.array([n not in out for n in self.joint_names], dtype=bool)

    @property
    def warnings(self) -> tuple[str, ...]:
        """The notes a step said of itself: a fallback, the licence of a model used whose terms restrict use
        (the non-commercial Bandai Namco models), or the channels the fill made up in cells the file measures in
        part (:func:`mocapkit.cleaning.measured.filled_channels_note`): what `mocapkit clean` says as ``warning:``
        lines and the HTML report shows above its viewer."""
        said = " ".join(s.note for s in self.steps)
        return tuple(n for n in self.notes if n and n in said)

    def summary(self) -> list[str]:
        """One line per calibration pose, per run written as 0 and per stutter (at most :data:`MAX_LINES` of each,
        then one line counting the rest), one per step, the notes, then :attr:`frames_note` where the result names
        any frame (a flag, a calibration pose, a run written as 0, a stutter). A decided result (:attr:`decided`)
        says what ``mocapkit clean --decisions`` says instead (:meth:`~mocapkit.cleaning.decided.Decided.lines`)."""
        if self.decided is not None:
            return self.decided.lines(self.frames_note)
        said = " ".join(s.note for s in self.steps)
        names_frames = bool(self.flags.any() or self.calibration or self.zero_runs or self.stutters)
        return ([str(c) for c in self.calibration] + capped_lines(self.zero_runs, "runs written as 0")
                + capped_lines(self.stutters, "stutters") + [str(s) for s in self.steps]
                + [f"note: {n}" for n in self.notes if n not in said]
                + ([self.frames_note] if self.frames_note and names_frames else []))

    def save(self, path) -> Path:
        """Write the MDM, flags, per-step masks and records as ``.npz`` (no pickles), atomically."""
        from ..io import atomic_write

        path = Path(path)
        from .. import __version__

        meta = {
            "format": FORMAT,
            "mocapkit": __version__,  # which version cleaned it: an upgrade's takes can be told from earlier ones
            "joint_names": list(self.joint_names),
            "fps": self.fps,
            "steps": [s.as_dict() for s in self.steps],
            "notes": list(self.notes),
            "params": self.params,
            "calibration": [dataclasses.asdict(c) for c in self.calibration],
            "take_sha256": self.take_sha256,
            "left_out": None if self.left_out is None else [list(p) for p in self.left_out],
            "zero_runs": [dataclasses.asdict(z) for z in self.zero_runs],
            "stutters": [dataclasses.asdict(z) for z in self.stutters],
            "cuts": [dataclasses.asdict(c) for c in self.cuts],
        }
        samples = {}
        if self.motion is not None:  # the cleaned values of the changed cells: decisions apply them exactly
            cells = self.changed
            samples = dict(cleaned_rotations=self.motion.rotations[cells],
                           cleaned_root=self.motion.root_positions[cells[:, 0]])
            if self.motion.translations is not None:
                samples["cleaned_translations"] = self.motion.translations[cells]
        from .ssa.cues import CAUSE_DTYPE

        causes = {} if self.causes is None else {"causes": np.asarray(self.causes, dtype=CAUSE_DTYPE)}
        if self.zeros is not None:
            causes["zeros"] = np.asarray(self.zeros, dtype=bool)
        with atomic_write(path, "wb") as fh:
            np.savez_compressed(
                fh,
                mdm=self.mdm.astype(np.float32),
                flags=self.flags,
                filled=self.filled,
                repaired=self.repaired,
                denoised=self.denoised,
                changed=self.changed,
                noise=self.noise.astype(np.float32),
                meta=np.array(json.dumps(meta)),
                **samples,
                **causes,
            )
        return path

    @staticmethod
    def load_params(path) -> dict | None:
        """The ``params`` of a record written by :meth:`save`, read without its arrays.

        A marker capture's record (:class:`mocapkit.cleaning.markers.MarkerCleanResult`) gives ``kind``
        ``"markers"``, ``written`` (the sizes and digests of the files read and written), ``request`` (what it
        was asked to be cleaned with) and ``decided`` (:func:`mocapkit.batch_decided.stamp_decided`), each where it keeps one, and None when it keeps neither. Raises
        :class:`~mocapkit.errors.MocapFormatError` naming ``path`` when it is no
        mocapkit record or cannot be read (empty, cut short, another program's file).
        """
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                if "meta" not in data.files:
                    if "kind" in data.files and str(data["kind"]) == "markers":
                        kept = {k: json.loads(str(data[k])) for k in ("written", "request", "decided") if k in data.files}
                        return {"kind": "markers", **kept} if kept else None
                    raise ValueError("it holds no record")
                meta = json.loads(str(data["meta"]))
        except Exception as exc:  # EOFError, BadZipFile, ValueError, OSError, ...: the file is not a record
            raise MocapFormatError(path, f"not a readable mocapkit clean record ({type(exc).__name__}: {exc})") from None
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            raise MocapFormatError(path, "not a mocapkit clean record")
        params = meta.get("params")
        return params if isinstance(params, dict) else None

    @classmethod
    def load(cls, path, motion: Motion | None = None) -> "CleanResult":
        """Read a file written by :meth:`save`; ``motion`` (e.g. the cleaned output) is attached as is."""
        from ..io.npz import load_arrays
        from .ssa.cues import CAUSE_DTYPE

        path = Path(path)
        if not path.exists():  # said as such, not as a file that is no record
            raise MissingFileError(path)
        try:
            data = load_arrays(path)  # declared shapes checked before anything is inflated
            meta = json.loads(str(data["meta"]))
            if meta.get("format") != FORMAT:
                raise ValueError(f"format {meta.get('format')!r}, expected {FORMAT!r}")
            res = cls(
                motion=motion,
                mdm=data["mdm"].astype(np.float64),
                flags=data["flags"].astype(bool),
                filled=data["filled"].astype(bool),
                repaired=data["repaired"].astype(bool),
                denoised=data["denoised"].astype(bool),
                noise=data["noise"].astype(np.float64),
                joint_names=tuple(meta["joint_names"]),
                fps=float(meta["fps"]),
                steps=tuple(StepRecord(**{"seconds": float("nan"), **s}) for s in meta["steps"]),
                notes=tuple(meta["notes"]),
                params=dict(meta["params"]),
                samples={k[len("cleaned_"):]: data[k].astype(np.float64) for k in
                         ("cleaned_rotations", "cleaned_root", "cleaned_translations") if k in data} or None,
                calibration=tuple(CalibrationPose(**c) for c in meta.get("calibration", [])),
                causes=data["causes"].astype(CAUSE_DTYPE) if "causes" in data else None,
                take_sha256=str(meta.get("take_sha256") or ""),
                left_out=None if meta.get("left_out") is None else tuple((str(n), str(w)) for n, w in meta["left_out"]),
                zeros=data["zeros"].astype(bool) if "zeros" in data else None,
                zero_runs=tuple(ZeroRun(**z) for z in meta.get("zero_runs", [])),
                stutters=tuple(Stutter(**z) for z in meta.get("stutters", [])),
                cuts=tuple(Cut(**c) for c in meta.get("cuts", [])),
            )
        except KeyError as e:  # an npz of another kind: say what it lacks, not a bare KeyError
            raise MocapFormatError(path, f"not a mocapkit clean file: it holds no {e.args[0]!r}"
                                         f"{record_kind_hint(path)}") from None
        except (OSError, ValueError, TypeError) as e:
            raise MocapFormatError(path, f"not a mocapkit clean file ({e})") from None
        shape = (res.num_frames, len(res.joint_names))
        arrays = ((res.mdm, res.flags, res.repaired, res.denoised, res.noise) + (() if res.causes is None else (res.causes,))
                  + (() if res.zeros is None else (res.zeros,)))
        if any(a.shape != shape for a in arrays):
            raise MocapFormatError(path, f"not a mocapkit clean file (arrays are not all {shape})")
        k, k0 = int(res.changed.sum()), int(res.changed[:, 0].sum())
        want = {"rotations": (k, 4), "root": (k0, 3), "translations": (k, 3)}
        if res.samples is not None and ("rotations" not in res.samples or "root" not in res.samples
                                        or any(v.shape != want[n] for n, v in res.samples.items())):
            raise MocapFormatError(path, f"not a mocapkit clean file (the cleaned samples are not {k} changed cells)")
        return res


def record_kind_hint(path) -> str:
    """What else an npz that is no clean record is, in words for a refusal (", ... (a .mask.npz ...)"), or ""."""
    from ..io.npz import load_arrays

    try:
        names = set(load_arrays(path))
    except (MocapFormatError, OSError):
        return ""
    if {"mask", "kind"} <= names and "meta" not in names:
        return " (it is a mask file, the ground truth `mocapkit corrupt` writes: give the .clean.npz `clean` wrote)"
    if "kind" in names and "meta" not in names:
        return " (it is a marker capture's record: give a joint-angle take's .clean.npz)"
    return ""


#: lines of one kind (runs written as 0, stutters) the summary names before it counts the rest
MAX_LINES = 12


def capped_lines(items, what: str, listed: str = " (the clean record lists them all)") -> list[str]:
    """One line per item (``str``), at most :data:`MAX_LINES`, then one line counting the rest (``listed``: where
    they all are)."""
    lines = [str(x) for x in items[:MAX_LINES]]
    if len(items) > MAX_LINES:
        lines.append(f"... and {len(items) - MAX_LINES} more {what}{listed}")
    return lines


def clean_path(out) -> Path:
    """The record written beside a cleaned output: ``walk.bvh`` -> ``walk.clean.npz``."""
    out = Path(out)
    return out.with_name(out.name[: -len(out.suffix)] + ".clean.npz" if out.suffix else out.name + ".clean.npz")
