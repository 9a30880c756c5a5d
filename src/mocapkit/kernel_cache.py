"""Where numba keeps mocapkit's compiled kernels, and a place for them when there is none.

numba caches a kernel (``@njit(cache=True)``) in the ``__pycache__`` folder
beside its source, else in the user's cache folder (``$XDG_CACHE_HOME/numba``
or ``~/.cache/numba``), else in ``NUMBA_CACHE_DIR`` when that is set; with
none of them writable it raises "cannot cache function" at the first kernel,
and every command that reads a take fails. That is the ordinary shape of a
locked-down install: a read-only site-packages used by an account without a
writable home (a container, a service account, a Dask worker run as another
user). :func:`ensure_cache_dir`, run when mocapkit is imported, gives numba a
private folder under the system's temporary folder then; kernels compile once
per machine boot there instead of failing. To share one warm cache among users
of a system-wide install, run ``python -m mocapkit.warmup`` with
``NUMBA_CACHE_DIR`` set to a shared folder and set it for every user.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

__all__ = ["ensure_cache_dir", "writable"]


def writable(folder: Path) -> bool:
    """True when ``folder`` exists or can be made, and a file can be written in it (numba's own test)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
        return True
    except OSError:
        return False


def _user_cache() -> Path | None:
    base = os.environ.get("XDG_CACHE_HOME")
    if base:
        return Path(base) / "numba"
    try:
        return Path.home() / ".cache" / "numba"
    except RuntimeError:  # no HOME and no password entry
        return None


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
    folder = Path(tempfile.gettempdir()) / f"mocapkit-numba-{who}"
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    if "numba" in sys.modules:
        sys.modules["numba"].config.CACHE_DIR = str(folder)
    return str(folder)
