"""Where numba keeps mocapkit's compiled kernels, and a place for them when there is none.

numba caches a kernel (``@njit(cache=True)``) in ``NUMBA_CACHE_DIR`` when that
is set, else in the ``__pycache__`` folder beside its source, else in the
user's cache folder (``$XDG_CACHE_HOME/numba`` or ``~/.cache/numba`` on Linux,
``~/Library/Caches/numba`` on macOS); with
none of them writable it raises "cannot cache function" at the first kernel,
and every command that reads a take fails. That is the ordinary shape of a
locked-down install: a read-only site-packages used by an account without a
writable home (a container, a service account, a Dask worker run as another
user). :func:`ensure_cache_dir`, run when mocapkit is imported, gives numba a
private folder under the system's temporary folder then (made by this user and
closed to others: numba's cache holds pickles); kernels compile once
per machine boot there instead of failing. To share one warm cache among users
of a system-wide install, run ``python -m mocapkit.warmup`` with
``NUMBA_CACHE_DIR`` set to a shared folder and set it for every user.
"""

from __future__ import annotations

import os
import stat
import sys
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["ensure_cache_dir", "read_only", "writable"]


def writable(folder: Path) -> bool:
    """True when ``folder`` exists or can be made, and a file can be written in it (numba's own test)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
        return True
    except OSError:
        return False


def _user_cache() -> Path | None:
    """numba's user-wide cache folder, as its ``appdirs`` finds it on this system (without importing numba)."""
    try:
        home = Path.home()
    except RuntimeError:  # no HOME and no password entry
        home = None
    if sys.platform == "darwin":
        return home / "Library" / "Caches" / "numba" if home else None
    if sys.platform == "win32":
        local = os.environ.get("LOCALAPPDATA")
        return Path(local) / "numba" / "numba" / "Cache" if local else None
    base = os.environ.get("XDG_CACHE_HOME")
    if base and os.path.isabs(base):
        return Path(base) / "numba"
    return home / ".cache" / "numba" if home else None


def _private_folder(base: Path, name: str) -> Path:
    """``base/name`` made by this user, readable and writable by no one else; when another user holds that name (or
    it is a link, or others may write in it), a fresh folder of this process instead (numba loads pickles from its
    cache: a folder another user can write in would run their code here)."""
    folder = base / name
    try:
        os.mkdir(folder, 0o700)
    except FileExistsError:
        pass
    except OSError:
        return Path(tempfile.mkdtemp(prefix=name + "-", dir=base))
    try:
        st = os.lstat(folder)
    except OSError:
        return Path(tempfile.mkdtemp(prefix=name + "-", dir=base))
    mine = not hasattr(os, "getuid") or st.st_uid == os.getuid()
    if stat.S_ISDIR(st.st_mode) and mine and not st.st_mode & 0o022:
        return folder
    return Path(tempfile.mkdtemp(prefix=name + "-", dir=base))


def ensure_cache_dir() -> str | None:
    """Point numba at a private temporary folder when it could cache mocapkit's kernels nowhere; returns that
    folder, or None when numba has a place already (``NUMBA_CACHE_DIR`` set, the package's folders writable, or
    the user's cache folder writable).

    Runs before numba reads its configuration where it can (``NUMBA_CACHE_DIR``);
    when numba was imported first, its ``config.CACHE_DIR`` is set too.
    """
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    if writable(Path(__file__).resolve().parent / "io" / "__pycache__"):
        return None
    user = _user_cache()
    if user is not None and writable(user):
        return None
    who = os.getuid() if hasattr(os, "getuid") else os.environ.get("USERNAME", "user")
    folder = _private_folder(Path(tempfile.gettempdir()), f"mocapkit-numba-{who}")
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    if "numba" in sys.modules:
        sys.modules["numba"].config.CACHE_DIR = str(folder)
    return str(folder)


def read_only(x: np.ndarray) -> np.ndarray:
    """A read-only view of ``x``, no copy.

    numba compiles a kernel once per argument type and caches each, and a read-only array is a type of its own: a
    texture ``detect`` searches or a database opened from disk is read-only, a caller's own array writable. Passing
    every array read-only gives one machine code (the one the warm-up caches) for every caller.
    """
    view = x.view()
    view.flags.writeable = False
    return view
