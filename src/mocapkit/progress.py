"""Progress bars: on a terminal while long work runs, not in logs and pipes.

Every bar of mocapkit (tqdm) is made with ``disable=bar_disabled(progress)``:
asked for and writing to a terminal, it is drawn; written to a file or a pipe
(a batch's log, ``2>&1 | tee``) it is left out, so the log holds the result
lines only, one per line. ``MOCAPKIT_PROGRESS=1`` draws the bars anyway (a
supervisor that reads them), ``MOCAPKIT_PROGRESS=0`` never.

>>> bar_disabled(False)
True
"""

from __future__ import annotations

import os

__all__ = ["bar_disabled"]


def bar_disabled(progress: bool) -> bool | None:
    """tqdm's ``disable`` for a bar the caller asks for (``progress``): True (never drawn), False (always), or
    None (drawn only when its stream is a terminal; tqdm's own test)."""
    if not progress:
        return True
    forced = os.environ.get("MOCAPKIT_PROGRESS", "").strip()
    if forced in ("0", "1"):
        return forced == "0"
    return None
