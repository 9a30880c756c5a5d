"""Writing AMC: a take on an ASF skeleton back into the Acclaim format it came from.

An AMC holds, per frame, a frame-number line and one line per bone, ``name
v1 v2 ...`` in the bone's dof order (the ASF's ``dof`` list; the root's
``order``, translations included). It has no skeleton of its own: it is read
with the ASF the take was read with, so only a motion whose skeleton came from
an ASF (``Skeleton.axes`` set, rotation channels only below the root) can be
written, and its joints' rotations are written on that skeleton's dofs.

The inverse of :mod:`mocapkit.io.asfamc`'s reading: the local rotation
``q = C M C^-1`` (``C`` the bone's ``axis`` frame) gives ``M = C^-1 q C``,
decomposed into the bone's dof angles, extrinsic in dof order
(:func:`mocapkit.rotations.quaternion_to_euler`; for a bone with one or two
dofs the rotation about the others is dropped, which is exact for any
rotation the bone's dofs can make). The angles written are continuous over
frames (:func:`mocapkit.rotations.continuous_euler`: whole turns and, for a
bone with 3 rotation dofs, the other branch of the middle angle, whichever is
nearest the neighbouring frames; with 1 or 2 dofs only whole turns).

Written like the file the take was read from (``like``): every frame whose
cells did not change is that file's text, byte for byte, and a changed cell
rewrites only its bone's numbers on that line (a root that only moved keeps
its angles' text, one that only turned its position's), on the triple nearest
the file's numbers of that cell where its rotation moved less than
:data:`~mocapkit.io.euler_branches.NEAR_SOURCE_DEG`, else nearest the file's
numbers at the bone's nearest unchanged frames, so an untouched take comes
back the same file, as :func:`mocapkit.io.bvh.write_bvh` does for BVH. An
.npz made from an AMC keeps the file's numbers (:func:`source_numbers`,
:mod:`mocapkit.io.kept_channels`), and an AMC written from it chooses each
cell's numbers the same way, writing an unchanged cell's in their shortest
exact form.

An AMC has no field for its frame rate: it is read at 120 fps unless an HDM05
name or mocapkit's comment line says otherwise (:func:`mocapkit.io.asfamc.amc_rate`).
A take at another rate is written with that comment line first
(``# frame rate: 60 fps (mocapkit)``, :func:`mocapkit.io.asfamc.with_rate`),
which other AMC readers skip as a comment; a take at 120 fps is written as
before, without it.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import rotations as R
from ..errors import MocapFormatError
from .outputs import check_file_path
from ..motion import Motion, source_part
from .asfamc import amc_dofs, amc_table_arrays, with_rate
from .euler_branches import MEASURED_TOLERANCE_DEG, bridged, measured_text, partly_missing, source_branches
from .kept_channels import kept_values
from ..words import plural

__all__ = ["write_amc", "check_amc_writable", "dof_values", "file_dofs", "source_numbers"]

_FRAME_LINE = re.compile(r"^\s*\d+\s*$")


def check_amc_writable(motion: Motion, path, missing_ok: bool = False) -> None:
    """Raise :class:`MocapFormatError` naming ``path`` when ``motion`` cannot be written as AMC.

    AMC needs the take's own ASF skeleton (the file has none of its own):
    ``skeleton.axes`` from an ASF, translations only on the root, no joint
    turning that has no dof in the ASF, at least one frame, and no missing
    values (unless ``missing_ok``: a check made before gaps are filled).
    """
    path = Path(path)
    sk = motion.skeleton
    if sk.axes is None:
        raise MocapFormatError(path, "AMC is written for a take read from ASF/AMC (the ASF is its skeleton); "
                               "this take has no ASF skeleton: write .bvh or .npz")
    dofs = amc_dofs(sk)
    if any(d.startswith("t") for j in range(1, sk.num_joints) for d in dofs[j]):
        raise MocapFormatError(path, "AMC holds translations on the root only; write .bvh or .npz")
    if motion.translations is not None and motion.num_frames:
        tr = np.asarray(motion.translations)[:, 1:]
        if np.any((tr != sk.offsets[1:]) & np.isfinite(tr)):
            raise MocapFormatError(path, "the take moves joints other than the root, which AMC cannot hold; "
                                   "write .bvh or .npz")
    v = np.abs(np.asarray(motion.rotations)[..., 1:])
    turning = np.any(np.where(np.isfinite(v), v, 0.0) > 1e-12, axis=(0, 2))
    still = [sk.joint_names[j] for j in np.flatnonzero(turning) if not any(d.startswith("r") for d in dofs[j])]
    if still:
        raise MocapFormatError(path, f"joint {still[0]!r} turns but its ASF bone has no rotation dof; "
                               "write .bvh or .npz")
    bad = np.any(np.isnan(motion.rotations), axis=(1, 2)) | np.any(np.isnan(motion.root_positions), axis=1)
    if np.any(bad) and not missing_ok:
        raise MocapFormatError(path, f"the take has missing values (NaN) in {plural(int(bad.sum()), 'frame')}, which AMC "
                               "cannot hold; fill them or write .npz")
    if motion.num_frames == 0:
        raise MocapFormatError(path, "the take has no frames; AMC needs at least one")


def dof_values(motion: Motion, dofs, radians: bool, source: "_LikeSource | None" = None) -> list[np.ndarray | None]:
    """Per joint the (F, n_j) numbers of its AMC line (degrees or radians), None without dofs.

    A bone's rotation dofs are the Euler triple (or pair, or single angle) of
    ``C^-1 q C`` nearest its neighbouring frames
    (:func:`mocapkit.rotations.continuous_euler`: whole turns, and for 3 dofs
    the other branch of the middle angle): with ``source`` (the AMC the take
    was read from, or the numbers an .npz made from one keeps: ``numbers``
    (F, columns) in these units, ``turned`` (F, J) bool), an unchanged cell is
    the file's numbers, a changed cell whose rotation stays within
    :data:`~mocapkit.io.euler_branches.NEAR_SOURCE_DEG` of the file's the
    triple nearest the file's numbers of that cell, and any other changed cell
    (a repaired flip) the branch of its nearest placed frame of the same bone,
    chained through the changed frames between (a bone with none starts from
    the file's first frame), as :func:`mocapkit.io.bvh.write_bvh` writes
    (:func:`mocapkit.io.euler_branches.source_branches`); without it each
    bone starts from the plain conversion and every frame continues from the
    one before.
    """
    sk = motion.skeleton
    out: list[np.ndarray | None] = []
    col0 = 0
    for j, d in enumerate(dofs):
        if not d:
            out.append(None)
            continue
        cols = []
        rot = "".join(x[1] for x in d if x[0] == "r")
        if rot:
            c = np.broadcast_to(sk.axes[j], motion.rotations[:, j].shape)
            m = R.quaternion_multiply(R.quaternion_multiply(R.quaternion_conjugate(c), motion.rotations[:, j]), c)
            ang = R.quaternion_to_euler(m, rot, degrees=not radians)
            fixed = start = None
            if source is not None:
                file_cols = [col0 + i for i, x in enumerate(d) if x[0] == "r"]
                given = source.numbers[:, file_cols]
                part = partly_missing(given)  # a nan dof beside measured ones: placed nearest the bridged curve
                if part.any():
                    given = np.where(part[:, None], bridged(given), given)
                ang, fixed = source_branches(ang, given, source.turned[:, j], rot, degrees=not radians)
                start = given[0]
            ang = R.continuous_euler(ang, rot, fixed=fixed, start=start, degrees=not radians)
        k = 0
        for x in d:
            if x[0] == "t":
                cols.append(np.asarray(motion.root_positions)[:, "xyz".index(x[1])])
            else:
                cols.append(ang[:, k])
                k += 1
        out.append(np.stack(cols, axis=1))
        col0 += len(d)
    return out


def file_dofs(motion: Motion, asf, like) -> tuple[tuple[str, ...], ...]:
    """The AMC layout to write: the ASF's own (``asf``, else the one beside an AMC ``like``) where it is this
    skeleton's, with the root's numbers in its ``order``; else the skeleton's (root translations first)."""
    from .asfamc import asf_dofs
    from .takes import asf_of

    dofs = amc_dofs(motion.skeleton)
    if asf is None and like is not None:
        asf = asf_of(like)
    if asf is None or not Path(asf).is_file():
        return _kept_dofs(like, dofs)
    try:
        given = asf_dofs(asf)
    except MocapFormatError:
        return dofs
    if len(given) != len(dofs) or any(sorted(a) != sorted(b) for a, b in zip(given, dofs)):
        return dofs  # another skeleton's ASF
    return tuple(tuple(d) for d in given)


def _kept_dofs(like, dofs):
    """The layout of the AMC an .npz ``like`` was made from (:data:`~mocapkit.io.kept_channels.LAYOUT_KEY`, its
    root's order as its ASF gave it) where it keeps that AMC's text and the layout is ``dofs`` reordered; else
    ``dofs``: an AMC written from the .npz, with no ASF at hand, keeps the file's root order with its text."""
    from ..errors import MocapError
    from .kept_channels import LAYOUT_KEY, TEXT_KEYS
    from .npz import load_arrays

    if like is None or like is False or Path(like).suffix.lower() != ".npz" or not Path(like).is_file():
        return dofs
    try:
        data = load_arrays(like, keys=(LAYOUT_KEY, TEXT_KEYS[".amc"]))
        layout = data.get(LAYOUT_KEY) if TEXT_KEYS[".amc"] in data else None
        given = json.loads(str(layout)) if layout is not None and layout.dtype.kind == "U" and layout.ndim == 0 else None
    except (MocapError, OSError, ValueError):
        return dofs
    if (not isinstance(given, list) or len(given) != len(dofs)
            or any(not isinstance(a, list) or sorted(map(str, a)) != sorted(b) for a, b in zip(given, dofs))):
        return dofs
    return tuple(tuple(str(x) for x in d) for d in given)


def write_amc(motion: Motion, path, precision: int = 6, like=None, asf=None) -> None:
    """Write ``motion`` as an AMC file for its ASF skeleton (atomically: a failed write leaves no file).

    motion : a take whose skeleton came from an ASF (:func:`check_amc_writable`
    says why another cannot be written); path : the ``.amc`` file, read back
    with the same ASF; precision : decimals of every number; asf : the ASF the
    take was read with (by default the one beside ``like``), whose ``:root
    order`` the root's line follows; like : the AMC file ``motion`` was read
    from, or an .npz made from it that keeps its text (:func:`mocapkit.io.kept_channels.kept_text`; the root's
    order then as that AMC had it, :func:`_kept_dofs`). Where it is that file (same skeleton, the take
    holding its frames, all or a contiguous slice's as the file numbers them, :func:`mocapkit.motion.source_part`;
    its units stated in its header), every frame whose rotations
    and root position are bit for bit the file's is copied as the file has it,
    and a changed cell rewrites only its bone's numbers, on the triple nearest
    the file's numbers of that cell, or for a rotation turned 90 degrees or more
    from the file's, on the branch of the bone's nearest unchanged frames (never
    that of the broken value it replaces) (:func:`dof_values`); otherwise the
    file is written whole, ``:FULLY-SPECIFIED`` and
    ``:DEGREES``, frames numbered from 1, every bone with dofs on its own line,
    its angles Euler-filtered from frame to frame (:func:`dof_values`), and where
    ``like`` is an .npz keeping the numbers of the AMC it was made from
    (:func:`source_numbers`, :mod:`mocapkit.io.kept_channels`) each cell's numbers
    are chosen as from that AMC (the file's own where the rotation is the file's),
    their text written anew. Either way a
    take whose rate the file would not be read at gets mocapkit's rate comment line
    first (:func:`~mocapkit.io.asfamc.with_rate`).
    """
    from . import atomic_write

    path = Path(check_file_path(path))  # "out/x/" names a folder: refused, not written as out/x
    precision = int(precision)
    if precision < 0:
        raise ValueError(f"precision must be >= 0, got {precision}")
    check_amc_writable(motion, path)
    dofs = file_dofs(motion, asf, like)
    source = _like_source(like, motion, dofs) if like is not None else None
    if source is not None:
        _write_like(path, motion, dofs, source, precision)
        return
    kept = _kept_source(like, motion, dofs)
    values = dof_values(motion, dofs, radians=False, source=kept)
    names = motion.skeleton.joint_names
    joints = [j for j in range(len(dofs)) if dofs[j]]
    cell = "%s" if kept is not None else f"%.{precision}f"
    row = "%d\n" + "".join(f"{names[j]} " + " ".join([cell] * len(dofs[j])) + "\n" for j in joints)
    table = np.concatenate([values[j] for j in joints], axis=1)
    if kept is not None:  # the file's own numbers where the cell is the file's, in their shortest exact form
        own = _unchanged_columns(motion, dofs, kept)
        fmt = f"%.{precision}f"
        table = np.array([[_shortest(v) if o else fmt % v for v, o in zip(r, k)]
                          for r, k in zip(table.tolist(), own.tolist())], dtype=object).reshape(table.shape)
    table = np.concatenate([np.arange(1, motion.num_frames + 1)[:, None].astype(table.dtype), table], axis=1)
    block = max(1, 2**18 // table.shape[1])
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(with_rate(":FULLY-SPECIFIED\n:DEGREES\n", motion.fps, path))
        for f0 in range(0, table.shape[0], block):
            rows = table[f0 : f0 + block]
            fh.write((row * rows.shape[0]) % tuple(rows.ravel().tolist()))


def _shortest(v: float) -> str:
    """The shortest text that reads back as ``v`` exactly, a whole number without its ``.0``."""
    t = repr(v)
    return t[:-2] if t.endswith(".0") else t


def _unchanged_columns(motion: Motion, dofs, kept: "_Kept") -> np.ndarray:
    """(F, columns) bool: the cells, in the layout ``dofs`` (joints with dofs only), that are still the kept file's:
    a bone's angles where its rotation did not change, the root's position where it did not move."""
    moved = np.any(np.asarray(motion.root_positions) != _kept_translations(kept.numbers, dofs), axis=-1)
    cols = [~moved if x[0] == "t" else ~kept.turned[:, j] for j, d in enumerate(dofs) for x in d]
    return np.stack(cols, axis=1)


def _kept_translations(numbers: np.ndarray, dofs) -> np.ndarray:
    """(F, 3) the root position the numbers give (0 on an axis with no dof), as the reader takes it."""
    out = np.zeros((numbers.shape[0], 3))
    col = 0
    for d in dofs:
        for x in d:
            if x[0] == "t":
                out[:, "xyz".index(x[1])] = numbers[:, col]
            col += 1
    return out


@dataclass(frozen=True)
class _Kept:
    """The numbers of the AMC an .npz was made from (degrees) and the cells whose rotation is no longer the file's."""

    numbers: np.ndarray  # (F, columns): each bone's dofs in the layout written, the file's branches
    turned: np.ndarray  # (F, J) bool


def source_numbers(motion: Motion, like, asf=None, with_text: bool = False) -> tuple:
    """The numbers ``(F, columns)`` of the AMC ``like`` (the file ``motion`` was read from, or an .npz keeping such
    a file's, :mod:`mocapkit.io.kept_channels`) in the layout :func:`write_amc` writes ``motion`` with (each bone's
    dofs in order; angles in degrees, the file's own whole turns and branches), and that layout; None for the
    numbers where ``like`` is no such file (other skeleton, layout or frames), or ``motion`` has no ASF skeleton.

    An .npz written from an ASF/AMC take keeps them, so that an AMC written from the .npz later
    (``mocapkit fill take.npz -o out.amc``) writes each untouched cell with the file's numbers, not the same
    rotation on another branch. ``with_text``: a third item, the bytes of that AMC (read from it, or kept by an .npz
    made from it: :func:`mocapkit.io.kept_channels.kept_text`) where ``motion`` is still on its skeleton and frames,
    which an .npz keeps so that an AMC written from it keeps every unchanged line's text; else None."""
    if like is None or like is False or motion.skeleton.axes is None or motion.num_frames == 0:
        return (None, (), None) if with_text else (None, ())
    dofs = file_dofs(motion, asf, like)
    src = _like_source(like, motion, dofs)
    if src is not None:
        numbers = src.numbers.copy()
        if src.radians:
            rot = np.array([x[0] == "r" for d in dofs for x in d])
            numbers[:, rot] = np.degrees(numbers[:, rot])
        return (numbers, dofs, src.text if src.whole else None) if with_text else (numbers, dofs)
    kept = _kept_source(like, motion, dofs)
    return ((None if kept is None else kept.numbers), dofs) + ((None,) if with_text else ())


def kept_lines(motion: Motion, like, asf=None) -> str | None:
    """The text of the AMC ``like`` that an AMC written from ``motion`` like it keeps: its header and the lines of
    the frames ``motion`` holds (all, or a slice's: :func:`mocapkit.motion.source_part`), for the count of its
    comment lines left out; None where ``motion`` is not written like it."""
    if like is None or like is False or motion.skeleton.axes is None or motion.num_frames == 0:
        return None
    src = _like_source(like, motion, file_dofs(motion, asf, like))
    return None if src is None else src.header + "".join("".join(block) for block in src.frames)


def _kept_source(like, motion: Motion, dofs) -> _Kept | None:
    """The numbers of the AMC an .npz ``like`` was made from, where they fit ``motion`` and the layout ``dofs``."""
    if like is None or like is False or Path(like).suffix.lower() != ".npz":
        return None
    numbers = kept_values(like, dofs, motion.num_frames)
    if numbers is None:
        return None
    ref, _ = amc_table_arrays(numbers, motion.skeleton, dofs, radians=False)
    return _Kept(numbers, np.any(motion.rotations != ref, axis=-1))


@dataclass(frozen=True)
class _LikeSource:
    """The AMC a take was read from: its header, its frames' lines, its units and which cells changed."""

    header: str  # the text before the first frame
    frames: list[list[str]]  # per frame its lines, the frame-number line first (line endings kept)
    radians: bool
    changed: np.ndarray  # (F, J) bool: cells whose rotation (or, for the root, position) differs from the file's
    turned: np.ndarray  # (F, J) bool: cells whose rotation differs from the file's
    moved: np.ndarray  # (F,) bool: frames whose root position differs from the file's
    numbers: np.ndarray  # (F, columns): the file's numbers, each bone's dofs in file order (its own branches)
    text: bytes  # the file's bytes as read, which an .npz made from the take keeps (kept_channels.TEXT_KEYS)
    whole: bool = True  # the take holds every frame of the file (else a contiguous part: motion.source_part)


def _like_source(like, motion: Motion, dofs) -> _LikeSource | None:
    """The source AMC's lines and changed cells, or None when ``like`` is not the file ``motion`` came from: the AMC
    itself, or an .npz made from it that keeps its text (:func:`mocapkit.io.kept_channels.kept_text`)."""
    from .asfamc import amc_header, read_amc_numbers
    from .kept_channels import kept_text
    from .sources import recall

    like = Path(like)
    if like.suffix.lower() not in (".amc", ".npz"):
        return None
    # the text as the take was read from it, even if the file was removed or changed since; or as an .npz keeps it
    data = recall(like) if like.suffix.lower() == ".amc" else kept_text(like, ".amc")
    if data is None:
        return None
    try:
        ref, numbers = read_amc_numbers(like, asf=motion.skeleton, fps=motion.fps, dofs=dofs, data=data)
    except (MocapFormatError, OSError):
        return None
    body_at, _, radians = amc_header(data)  # the reader's rule for where the frames start and the units
    part = source_part(motion, ref.num_frames)  # the file's frames the take holds: all of them, or a slice's
    if part is None or radians is None:
        return None  # radians None: units left to the ASF; the file is written whole, its units stated
    frames: list[list[str]] = []
    for line in data[body_at:].decode("latin-1").splitlines(keepends=True):
        if _FRAME_LINE.match(line.split("#", 1)[0]):
            frames.append([line])
        elif frames:
            frames[-1].append(line)
        else:
            return None  # the body does not open with a frame number
    if len(frames) != ref.num_frames:
        return None
    whole = len(part) == ref.num_frames
    if not whole:  # a slice: its frames' blocks as the file numbers them (an AMC's frame numbers run on from any)
        frames, ref, numbers = frames[part.start:part.stop], ref[part.start:part.stop], numbers[part.start:part.stop]
    header = data[:body_at].decode("latin-1")
    turned = np.any((motion.rotations != ref.rotations), axis=-1)
    moved = np.any(np.asarray(motion.root_positions) != ref.root_positions, axis=-1)
    changed = turned.copy()
    changed[:, 0] |= moved
    return _LikeSource(header, frames, radians, changed, turned, moved, numbers, data, whole)


def _write_like(path: Path, motion: Motion, dofs, source: _LikeSource, precision: int) -> None:
    """Write the take keeping ``source``'s text wherever a frame or a bone's line did not change (and a root's
    angles where only its position changed, its position where only its rotation did; in a bone line the file
    gives partly ``nan``, the dofs it measures where the fill put them back, within
    :data:`~mocapkit.io.euler_branches.MEASURED_TOLERANCE_DEG`)."""
    from . import atomic_write

    names = motion.skeleton.joint_names
    values = dof_values(motion, dofs, radians=source.radians, source=source)
    fmt = f"%.{precision}f"
    starts = np.cumsum([0] + [len(d) for d in dofs])
    # the dofs the file measures beside a nan one of their kind, put back by the fill: the file's text
    kept = measured_text(np.concatenate([np.empty((motion.num_frames, 0)) if v is None else v for v in values],
                                        axis=1),
                         dofs, source.numbers, kind_of=lambda dof: dof[0] if dof[0] in "rt" else "",
                         tolerance={"r": np.radians(MEASURED_TOLERANCE_DEG) if source.radians
                                    else MEASURED_TOLERANCE_DEG, "t": 0.0})
    with atomic_write(path, "w", encoding="latin-1", newline="") as fh:
        fh.write(with_rate(source.header, motion.fps, path))
        for f, block in enumerate(source.frames):
            joints = [j for j in np.flatnonzero(source.changed[f]) if dofs[j]]
            if not joints:
                fh.write("".join(block))
                continue
            block = list(block)
            at = {}
            for i, line in enumerate(block[1:], start=1):
                tok = line.split("#", 1)[0].split()
                if tok:
                    at[tok[0]] = i
            ending = "\r\n" if block[0].endswith("\r\n") else "\n"
            for j in joints:
                new = values[j][f]
                i = at.get(names[j])
                if i is None:  # the frame did not list the bone (read as the identity): it is listed now
                    block.append(names[j] + " " + " ".join(fmt % v for v in new) + ending)
                    continue
                line = block[i]
                body = line.rstrip("\r\n")
                tok = body.split("#", 1)[0].split()
                for k, v in enumerate(new):  # angles already on the branch of the bone's unchanged frames (dof_values)
                    if kept[f, starts[j] + k]:
                        continue
                    if source.moved[f] if dofs[j][k][0] == "t" else source.turned[f, j]:
                        tok[k + 1] = fmt % v  # a root that only moved keeps its angles' text, and the other way
                block[i] = " ".join(tok) + (line[len(body):] or ending)
            fh.write("".join(block))
