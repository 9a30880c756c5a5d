"""The output guard: one check, for every command and library writer, that an output may be written.

A cleaning tool must never lose what it was given. Before any work is done,
every path a command will write is checked against every path it reads:

- no output may resolve (symlinks, ``./``, ``..``, hard links) to an input
  file, nor lie inside an input folder (a ``--context`` folder, a database);
- no two outputs may be the same file;
- an existing output file is replaced only when ``overwrite`` is true;
- an output that exists and is a folder, or whose parent is a file, is refused;
- an output whose name (or a folder's along its path) is longer than :data:`NAME_MAX` bytes is refused
  (:func:`name_too_long`): no file system can hold it, and its write failed only after the work was done;
- an output inside a folder mocapkit replaces whole (:func:`replaced_whole_around`: a motion database, an
  accelerometer knowledge base) is refused: the folder is ``db build``'s or ``reconstruct --knowledge``'s;
- missing parent folders are created only when the output is written
  (:func:`mocapkit.io.atomic_write` does that), never by the check.

A command that writes several files writes them inside
:func:`removed_on_failure`, so a run that fails half-way leaves none of the
files it created (a report without its take, a take without its record).

The check raises :class:`~mocapkit.errors.MocapFormatError` naming the output
and the problem, which the CLI prints as one line.

>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> (d / "a.bvh").write_text("x")
1
>>> check_outputs([d / "out.bvh"], [d / "a.bvh"])
>>> try:
...     check_outputs([d / "a.bvh"], [d / "a.bvh"])
... except MocapFormatError as exc:
...     print(exc.reason.split(" (")[0])
refusing to write over an input
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import tempfile
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Iterable, Iterator

from ..errors import MocapFormatError
from ..interrupts import interrupts_held, whole_hand_over, whole_step
from ..words import listed

__all__ = ["check_file_path", "check_outputs", "replaced_whole_around", "same_file", "inside",
           "removed_on_failure", "publish", "keep_aside", "named_as_given", "put_back", "drop_kept", "missing_folders",
           "file_facts", "input_facts", "other_input", "temp_prefix", "NAME_MAX", "name_too_long",
           "refuse_existing"]


def resolved(path: os.PathLike | str) -> Path:
    """The absolute path with symlinks, ``.`` and ``..`` resolved (also for paths that do not exist yet)."""
    return Path(os.path.realpath(os.path.abspath(os.fspath(path))))


#: The file that makes a folder a mocapkit motion database, and the format it names (``mocapkit.database_folder``
#: writes both): such a folder holds only what a database save writes, and ``db build --overwrite`` replaces it whole.
DATABASE_DESCRIPTION = "database.json"
DATABASE_FORMAT = "mocapkit-motion-database"


KNOWLEDGE_DESCRIPTION = "knowledge.json"
KNOWLEDGE_FORMAT = 1  # knowledge.json's "format" (mocapkit.reconstruct.accelerometers.knowledge)

# The folders mocapkit replaces whole, as (description file, says it is one, what it is, what replaces it): a file
# written inside one would be refused by that command's next run (the folder holds a file its save does not write)
# or lost with the folder. Found by their description file, as their own refusals find them.
_WHOLE_FOLDERS = (
    (DATABASE_DESCRIPTION, lambda meta: meta.get("format") == DATABASE_FORMAT, "a motion database folder",
     "`db build --overwrite`"),
    (KNOWLEDGE_DESCRIPTION, lambda meta: meta.get("format") == KNOWLEDGE_FORMAT and "sensors" in meta,
     "an accelerometer knowledge base", "`reconstruct --knowledge`"),
)


def replaced_whole_around(path: os.PathLike | str) -> tuple[Path, str, str] | None:
    """``(folder, what it is, what replaces it)`` for the folder mocapkit replaces whole that ``path`` would be
    written inside (its folder or any folder above it), or None.

    Those folders are a motion database (``db build --overwrite`` replaces it) and an accelerometer knowledge base
    (``reconstruct --knowledge`` rebuilds it when its database changes): both are written staged and swapped in
    whole (:func:`mocapkit.database_folder.write_staged`), and both refuse a folder holding a file their save does
    not write. A file written there is refused by :func:`check_outputs`. Only a description file naming the format
    counts (a folder of takes may hold another ``database.json``). A train run folder is not one of them: its
    ``--overwrite`` replaces the model files, never the folder.
    """
    start = resolved(path).parent
    for folder in (start, *start.parents):
        for name, says, what, how in _WHOLE_FOLDERS:
            desc = folder / name
            if not desc.is_file():
                continue
            try:
                with open(desc, encoding="utf-8") as fh:
                    meta = json.loads(fh.read(2**24))
            except (OSError, ValueError):
                continue
            if isinstance(meta, dict) and says(meta):
                return folder, what, how
    return None


def same_file(a: os.PathLike | str, b: os.PathLike | str) -> bool:
    """True when ``a`` and ``b`` name one file: the same resolved path, or the same inode (hard links)."""
    ra, rb = resolved(a), resolved(b)
    if ra == rb:
        return True
    try:
        return os.path.samefile(ra, rb)
    except OSError:
        return False


def inside(path: os.PathLike | str, folder: os.PathLike | str) -> bool:
    """True when ``path`` resolves to ``folder`` itself or to something below it."""
    rp, rf = resolved(path), resolved(folder)
    return rp == rf or rf in rp.parents


def check_file_path(path):
    """``path``, refused where it is a text ending with a path separator (``"out/x.bvh/"``): the caller named a
    folder, and a :class:`~pathlib.Path` made of it has lost the slash (it would write ``out/x.bvh``). Every writer
    and :func:`check_outputs` (the commands' output guard) call it before they make a Path of their output.

    Raises
    ------
    MocapFormatError
        One line naming ``path`` as given.
    """
    if isinstance(path, str) and path.endswith(tuple({"/", os.sep})):
        raise MocapFormatError(path, "ends with a path separator, which names a folder; give a file path for this output")
    return path


def check_outputs(
    outputs: Iterable[os.PathLike | str | None],
    inputs: Iterable[os.PathLike | str | None] = (),
    *,
    overwrite: bool = False,
    how: str = "pass overwrite=True",
    existing: list | None = None,
) -> None:
    """Refuse, before any work, outputs that would replace an input, each other, or an existing file.

    Parameters
    ----------
    outputs : paths the caller will write (``None`` entries are ignored); a text ending with a path separator
        (``out/x.bvh/``) names a folder and is refused, not written as ``out/x.bvh``.
    inputs : every path the caller reads: files and folders (``None`` ignored).
        An output equal to an input file, or inside an input folder, is refused; an output
        equal to an input that does not exist is refused naming the missing input.
    overwrite : allow replacing an existing output *file* (never an input, never a folder).
    how : what the refusal of an existing output tells its caller to do, in the caller's words (Python's
        ``pass overwrite=True``; the command line's ``pass --overwrite``).
    existing : a list the existing outputs (without ``overwrite``) are appended to instead of refused, for a caller
        that checks many takes' outputs and refuses them all at once (:func:`refuse_existing`). Without it every
        existing output of ``outputs`` is named in one refusal, after the other checks: a user fixes them in one go.

    Raises
    ------
    MocapFormatError
        One line naming the output and what is wrong with it.
    """
    for o in outputs:
        check_file_path(o)
    outs = [Path(o) for o in outputs if o is not None]
    for out in outs:  # first: a name too long cannot even be looked up (stat raises "File name too long")
        why = name_too_long(out)
        if why:
            raise MocapFormatError(out, f"cannot be written: {why}; choose a shorter name")
    ins = [Path(i) for i in inputs if i is not None]
    seen: list[Path] = []
    found: list[Path] = [] if existing is None else existing
    for out in outs:
        for inp in ins:
            if same_file(out, inp) and not os.path.lexists(inp):
                raise MocapFormatError(inp, "no such file")  # a missing input, not a collision
            if same_file(out, inp) or (resolved(inp).is_dir() and inside(out, inp)):
                raise MocapFormatError(out, f"refusing to write over an input ({inp}); choose another output path")
            if out.exists() and out.is_dir() and inside(inp, out):
                raise MocapFormatError(out, f"refusing to replace a folder that holds an input ({inp})")
        for other in seen:
            if same_file(out, other):
                raise MocapFormatError(out, f"given as two outputs ({other}); each output needs its own path")
        seen.append(out)
        if out.is_dir():
            raise MocapFormatError(out, "is a folder; give a file path for this output")
        parent = out.parent
        while not parent.exists() and parent != parent.parent:
            parent = parent.parent
        if parent.exists() and not parent.is_dir():
            raise MocapFormatError(out, f"cannot create it: {parent} is a file, not a folder")
        whole = replaced_whole_around(out)
        if whole is not None:
            folder, what, by = whole
            raise MocapFormatError(out, f"refusing to write inside {what} ({folder}), which {by} replaces whole; "
                                        "choose another folder")
        if os.path.lexists(out) and not overwrite:  # a dangling link too
            found.append(out)
    if existing is None:
        refuse_existing(found, how)


def refuse_existing(paths: list, how: str = "pass overwrite=True") -> None:
    """Refuse the existing outputs ``paths`` (none: nothing) in one line that names every one of them: a user who
    fixes the one named and runs again met the next one (``clean-batch`` named only the first of a folder's).

    >>> try:
    ...     refuse_existing(["out/T.trc", "out/G.report.html"], "pass --overwrite")
    ... except MocapFormatError as exc:
    ...     print(exc)
    out/T.trc: already exists; pass --overwrite to replace it, and out/G.report.html, which exists too
    """
    if not paths:
        return
    first, rest = paths[0], [os.fspath(p) for p in paths[1:]]
    also = f", and {listed(rest)}, which {'exists' if len(rest) == 1 else 'exist'} too" if rest else ""
    raise MocapFormatError(first, f"already exists; {how} to replace it{also}")


_NEW_ONLY: ContextVar[frozenset] = ContextVar("mocapkit_new_only", default=frozenset())
_WRITTEN: ContextVar[list | None] = ContextVar("mocapkit_written", default=None)


def publish(tmp: os.PathLike | str, path: os.PathLike | str) -> None:
    """Move the finished temporary file ``tmp`` to ``path`` (:func:`mocapkit.io.atomic_write`'s last step).

    Inside :func:`removed_on_failure` with ``overwrite=False`` an output must still be new when it is
    written: it is linked into place, which fails where a file (or a link) appeared since the check, so
    what another program wrote there meanwhile is never replaced (:class:`~mocapkit.errors.MocapFormatError`).
    Everywhere else, and on a file system without hard links, a plain ``os.replace``.
    """
    path = Path(path)
    key = os.path.abspath(path)
    written = _WRITTEN.get()
    if key in _NEW_ONLY.get():
        try:
            os.link(tmp, path)
        except FileExistsError:
            raise MocapFormatError(path, "appeared while this command ran (another program wrote it); pass "
                                         "overwrite=True (--overwrite on the command line) to replace it") from None
        except OSError:  # no hard links here (some network and FAT file systems): the plain rename
            os.replace(tmp, path)
        else:
            if written is not None:
                written.append(key)
            os.unlink(tmp)
            return
    else:
        os.replace(tmp, path)
    if written is not None:
        written.append(key)


NAME_MAX = 255
"""Bytes a file name may hold on Linux, macOS and Windows file systems (ext4, APFS, NTFS)."""


def name_too_long(path: os.PathLike | str) -> str:
    """Why ``path`` cannot be created, in words, where one of its names (the file's, a folder's) is longer than
    :data:`NAME_MAX` bytes as the file system stores it (UTF-8); "" where every name fits.

    A take named with 250 bytes is a legal file, but its record (stem + ``.clean.npz``, 256 bytes) is not: its
    write failed with "File name too long" after the take was cleaned, or the output check itself raised it
    (``stat`` of such a name). :func:`check_outputs` and :func:`mocapkit.batch.clean_batch` (each take's outputs,
    before any take is cleaned) ask this.

    >>> name_too_long("out/" + "a" * 245 + ".clean.npz")
    ''
    >>> name_too_long("out/" + "a" * 246 + ".clean.npz")
    'its name is 256 bytes, more than the 255 a file name may hold'
    """
    path = Path(path)
    for part in path.parts:
        size = len(os.fsencode(part))
        if size > NAME_MAX:
            where = "its name" if part == path.name else f"the name of its folder {part[:24]}..."
            return f"{where} is {size} bytes, more than the {NAME_MAX} a file name may hold"
    return ""


def temp_prefix(name: str, after: int = 8 + len(".part")) -> str:
    """The start of the hidden temporary name beside the output ``name``: ``.NAME.`` (``mkstemp``/``mkdtemp``
    add 8 random characters and ``.part``: ``after`` bytes follow), with NAME cut to the bytes that leave the
    whole within :data:`NAME_MAX` (240 by default), at a character's end.

    An output name of 241-255 bytes is a legal name, but ``.NAME.RANDOM.part`` is 15 bytes longer: every
    write of it failed with "File name too long", after the work was done (a clean of a take).
    """
    room = NAME_MAX - len("..") - after
    raw = os.fsencode(name)
    if len(raw) <= room:
        return f".{name}."
    cut = raw[:room]
    while cut and (cut[-1] & 0xC0) == 0x80:  # a UTF-8 continuation byte: the character it ends is cut whole
        cut = cut[:-1]
    if cut and cut[-1] >= 0xC0:  # a lead byte left alone
        cut = cut[:-1]
    return f".{os.fsdecode(cut)}."


def named_as_given(exc: OSError, path: Path) -> None:
    """Name the temporary file beside ``path`` in ``exc`` as ``path`` was given: ``tempfile.mkstemp`` makes its name
    absolute, so ``-o ../ro/out.bvh`` on a read-only folder was said as ``/home/me/ro/out.bvh: read-only file
    system`` (:func:`mocapkit.errors.os_error_line` reads the output's name from the temporary file's); now
    ``../ro/out.bvh: read-only file system``."""
    folder, prefix = os.path.abspath(path.parent), temp_prefix(path.name)
    for attr in ("filename", "filename2"):
        name = getattr(exc, attr, None)
        if isinstance(name, str) and os.path.isabs(name) and os.path.dirname(name) == folder:
            base = os.path.basename(name)
            if base.startswith(prefix) and base.endswith(".part"):  # a cut name (temp_prefix) said whole
                base = f".{path.name}.{base[len(prefix):]}"
            if not path.is_absolute() or base != os.path.basename(name):
                setattr(exc, attr, str(path.with_name(base)))


def keep_aside(paths: Iterable[os.PathLike | str | None], kept: dict[Path, Path] | None = None) -> dict[Path, Path]:
    """A hidden hard link (``.NAME.RANDOM.part``, a copy where links fail) beside each existing file of ``paths``,
    and a hidden copy of each that is a symbolic link (the link itself, not what it points to).

    Each output is replaced by a rename, which leaves the old file's data at the link: :func:`put_back`
    restores it, :func:`drop_kept` removes the links. Returns ``{path: link}``: ``kept`` when given, filled as
    each link is made, so that a caller's ``finally`` drops the links of an interrupt that lands before this
    call has returned. A link's name is reserved (``mkstemp``) and entered in ``kept`` before the link is made,
    with interrupts held while the reserved file exists (an interrupt there left it behind, unnamed). A failure
    to make one (a read-only folder) names the output as the caller gave it (:func:`named_as_given`), as
    :func:`mocapkit.io.atomic_write` does.
    """
    kept = {} if kept is None else kept
    p = None
    try:
        for p in paths:
            if p is None:
                continue
            p = Path(p)
            link = p.is_symlink()
            if not (link or p.is_file()):
                continue
            with interrupts_held():
                fd, tmp = tempfile.mkstemp(prefix=temp_prefix(p.name), suffix=".part", dir=p.parent)
                os.close(fd)
                os.unlink(tmp)
            kept[p] = Path(tmp)  # drop_kept removes the link from here on (a name not yet made is passed over)
            if link:
                os.symlink(os.readlink(p), tmp)
            elif _removable_link(p):
                try:
                    os.link(p, tmp)
                except OSError:
                    shutil.copy2(p, tmp)
            else:
                shutil.copy2(p, tmp)
    except BaseException as exc:
        drop_kept(kept)
        if isinstance(exc, OSError) and p is not None:  # a read-only folder: the hidden name said as OUT was given
            named_as_given(exc, Path(p))
        raise
    return kept


def _removable_link(path: Path) -> bool:
    """Whether a hard link to ``path`` made beside it could be removed again: not where the folder is sticky
    (``/tmp``-like, mode 1777) and the file another user's, whose every name only its owner (or the folder's)
    may remove; there :func:`keep_aside` copies instead, so that nothing of its own is left behind."""
    try:
        folder, st = os.stat(path.parent), os.stat(path)
    except OSError:
        return True
    me = os.geteuid() if hasattr(os, "geteuid") else st.st_uid
    return not (folder.st_mode & stat.S_ISVTX) or me in (st.st_uid, folder.st_uid)


def put_back(paths: Iterable[os.PathLike | str | None], kept: dict[Path, Path], written=None) -> None:
    """After a failure: each file of ``paths`` kept by :func:`keep_aside` gets its old contents back, and each
    that did not exist before is removed (only files; never a folder); with ``written`` (absolute paths this
    run wrote) only those: a file another program put there meanwhile stays. Interrupts wait until it is done
    (:func:`mocapkit.interrupts.interrupts_held`)."""
    with interrupts_held():
        _put_back(paths, kept, written)


def _put_back(paths, kept: dict[Path, Path], written) -> None:
    for p in paths:
        if p is None:
            continue
        p = Path(p)
        try:
            if p in kept:
                link = kept[p]
                # a rename onto another name of the same file (an output not yet replaced) does nothing and
                # leaves both names: the link is removed here, and by drop_kept if this fails
                os.replace(link, p)
                if os.path.lexists(link):
                    os.unlink(link)
                del kept[p]
            elif written is None or os.path.abspath(p) in written:
                p.unlink()
        except (FileNotFoundError, IsADirectoryError, PermissionError):
            pass


def drop_kept(kept: dict[Path, Path]) -> None:
    """Remove the links of :func:`keep_aside` (after success, or what :func:`put_back` left)."""
    for link in kept.values():
        try:
            os.unlink(link)
        except OSError:
            pass
    kept.clear()


def file_facts(path: os.PathLike | str) -> dict:
    """``{"size": bytes, "sha256": hex}`` of the file at ``path``: what a record keeps of the files a run read and
    wrote, so a later run can tell an input replaced since, or an output changed or cut short outside mocapkit."""
    import hashlib

    h, size = hashlib.sha256(), 0
    with open(path, "rb") as fh:
        while chunk := fh.read(1 << 20):
            h.update(chunk)
            size += len(chunk)
    return {"size": size, "sha256": h.hexdigest()}


def input_facts(path: os.PathLike | str) -> dict:
    """:func:`file_facts` of a take as read, with the SHA-256 of its absolute path (links resolved): what a record
    keeps of its input, so that a later batch into the same OUT_DIR tells that input replaced since (the same path,
    other bytes: cleaned again) from another folder's take of the same name (another path, other bytes: its output
    is not that batch's to replace unasked). The path's digest, not the path: a record shared with others does not
    carry the folders of the machine that cleaned it."""
    return {**file_facts(path), "path_sha256": _path_digest(path)}


def other_input(kept: dict | None, path: os.PathLike | str) -> bool:
    """Whether a record's :func:`input_facts` name another file than the one at ``path`` (False where the record
    names none: an earlier mocapkit's)."""
    was = (kept or {}).get("path_sha256")
    return isinstance(was, str) and was != _path_digest(path)


def _path_digest(path: os.PathLike | str) -> str:
    import hashlib

    return hashlib.sha256(os.fsencode(Path(path).resolve())).hexdigest()


def missing_folders(folders: Iterable[os.PathLike | str]) -> list[Path]:
    """The folders among ``folders`` and their parents that do not exist yet, deepest first: what writing into them
    will make, and a failed write removes again when they are left empty."""
    found: set[Path] = set()
    for folder in folders:
        f = Path(folder)
        while not f.exists() and f not in found and f != f.parent:
            found.add(f)
            f = f.parent
    return sorted(found, key=lambda p: len(p.parts), reverse=True)


@contextmanager
@whole_hand_over
def removed_on_failure(
    outputs: Iterable[os.PathLike | str | None],
    *,
    overwrite: bool | None = None,
    marker: os.PathLike | str | None = None,
) -> Iterator[None]:
    """Write a set of outputs as one: if the block raises (interrupts included), the set is as it was before.

    An output that did not exist when the block started is removed, and so are the folders made for it
    (when nothing else was put there); one that existed (replaced with
    ``overwrite``) gets its old contents back (:func:`keep_aside`, :func:`put_back`). Each output is
    still written atomically, so a file is either complete or absent. ``marker``: the output written
    last that says the set is complete (a ``.clean.npz`` record, a ``.mask.npz``): an old one is removed
    as the block starts, so a run killed outright (no handler runs) never leaves new files beside the
    old marker; a failure puts it back. ``overwrite=False``: the outputs were checked new before the work
    (:func:`check_outputs`), and one that exists now, or appears before it is written (:func:`publish`),
    was written meanwhile by another program: refused, never replaced.
    """
    outs = [Path(o) for o in outputs if o is not None]
    if overwrite is False:
        for o in outs:
            if os.path.lexists(o):
                raise MocapFormatError(o, "appeared while this command ran (another program wrote it); pass "
                                          "overwrite=True (--overwrite on the command line) to replace it")
    made = missing_folders(o.absolute().parent for o in outs)  # removed again, when empty, on failure
    outer, mine, new_before = _WRITTEN.get(), [], _NEW_ONLY.get()
    new_only = {os.path.abspath(o) for o in outs if not os.path.lexists(o)} if overwrite is False else set()
    kept: dict[Path, Path] = {}
    ready = False
    # set up inside the try, and the context set back by value: an interrupt that landed between keep_aside and the
    # try, or as a ContextVar.set returned (before its token was kept), left the hidden links and the context behind
    try:
        keep_aside(outs, kept)
        _NEW_ONLY.set(new_before | new_only)
        _WRITTEN.set(mine)
        ready = True
        if marker is not None and Path(marker) in kept:
            os.unlink(marker)
        yield
    except BaseException:
        _undo_block(ready, outs, kept, None if overwrite is None else mine, made)
        raise
    finally:
        _end_block(outer, mine, new_before, kept)


@whole_step
def _undo_block(ready: bool, outs: list[Path], kept: dict[Path, Path], written: list | None, made: list[Path]) -> None:
    """removed_on_failure's undo after its block failed, whole (:func:`mocapkit.interrupts.whole_step`): the old
    outputs put back, the new ones and the folders made for them removed. A second Ctrl-C that landed before
    put_back held interrupts skipped it, and the clean-up then dropped the old version's hidden link: the file
    the user had was gone, the half-written new set in its place."""
    if not ready:  # nothing was written yet (and a failed keep_aside must put nothing back)
        return
    put_back(outs, kept, None if written is None else set(written))
    for folder in made:
        try:
            folder.rmdir()
        except OSError:  # not empty (something else was put there), or never made
            pass


@whole_step
def _end_block(outer: list | None, mine: list, new_before: frozenset, kept: dict[Path, Path]) -> None:
    """removed_on_failure's last step, whole (:func:`mocapkit.interrupts.whole_step`): the enclosing block's context
    back, this block's writes handed to it (it removes them too if it fails later), the old outputs' links dropped
    (an interrupt here left them, hidden, beside the outputs)."""
    _WRITTEN.set(outer)
    _NEW_ONLY.set(new_before)
    if outer is not None:
        outer.extend(mine)
    drop_kept(kept)
