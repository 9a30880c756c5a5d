"""The text of the motion files this process read, as read: what the BVH and AMC writers keep.

A BVH or AMC written ``like`` the file its take was read from keeps that file's text wherever the take
did not change (:func:`mocapkit.io.bvh.write_bvh`, :func:`mocapkit.io.amc_writer.write_amc`). That
text must be the one the take came from, not what the path holds when the output is written: the
input may have been removed, cut short or replaced meanwhile (a sync tool, a user tidying up), and
the output would then come out without it (other line endings, other number text) with no word.

So the readers :func:`remember` each file's bytes as they read them: the most recent files up to
:data:`MAX_KEPT_BYTES` in all, and the SHA-256 of every file read. :func:`recall` gives the bytes as
read; for a file whose bytes were let go, the file as it is now when it still has the digest it had,
else a one-line :class:`~mocapkit.errors.MocapFormatError` naming it (the output is not written).
"""

from __future__ import annotations

import hashlib
import os
import threading
from collections import OrderedDict
from pathlib import Path

from ..errors import MocapFormatError

__all__ = ["remember", "recall", "forget", "MAX_KEPT_BYTES", "MAX_DIGESTS", "BOM", "bom_length"]

MAX_KEPT_BYTES = 64 << 20  # the bytes of the files read last, in all (a take: a few MB)
MAX_DIGESTS = 100_000  # digests of the files read (a corpus read for a database), about 100 bytes each

BOM = b"\xef\xbb\xbf"
"""The UTF-8 byte-order mark some Windows tools write before a text file's first line (BVH, TRC, ASF, AMC)."""


def bom_length(data: bytes) -> int:
    """How many bytes of a text file's ``data`` are its UTF-8 byte-order mark (:data:`BOM`): 3 or 0.

    The mark is no part of the file's first line: the readers parse the text after it, and the writers that keep a
    file's text (the bytes kept here) keep it too, so such a file written back unchanged is byte for byte the same.
    """
    return len(BOM) if data[:len(BOM)] == BOM else 0


_lock = threading.Lock()
_kept: OrderedDict[str, bytes] = OrderedDict()
_digests: OrderedDict[str, str] = OrderedDict()


def _key(path) -> str:
    return os.path.realpath(os.path.abspath(os.fspath(path)))


def remember(path, data: bytes) -> None:
    """Keep ``data``, the bytes just read from ``path`` (and their digest), for a writer that keeps its text."""
    key, digest = _key(path), hashlib.sha256(data).hexdigest()
    with _lock:
        _kept.pop(key, None)
        _digests.pop(key, None)
        _digests[key] = digest
        while len(_digests) > MAX_DIGESTS:
            _digests.popitem(last=False)
        if len(data) <= MAX_KEPT_BYTES:
            _kept[key] = bytes(data)
            total = sum(len(v) for v in _kept.values())
            while total > MAX_KEPT_BYTES:
                total -= len(_kept.popitem(last=False)[1])


def forget(path=None) -> None:
    """Let go of the kept text and digest of ``path`` (a file this process has just written), or of every one."""
    with _lock:
        if path is None:
            _kept.clear()
            _digests.clear()
        else:
            _kept.pop(_key(path), None)
            _digests.pop(_key(path), None)


def recall(path) -> bytes | None:
    """The bytes of ``path`` as this process last read them.

    Kept ones as they were; otherwise the file now, when it has the digest it had when read (or was
    never read here: a ``like`` of another file); None when it cannot be read and was never read here.
    Raises :class:`~mocapkit.errors.MocapFormatError` naming ``path`` when it was read here but has
    been removed or changed since and its bytes were let go.
    """
    key = _key(path)
    with _lock:
        data, want = _kept.get(key), _digests.get(key)
    if data is not None:
        return data
    try:
        data = Path(path).read_bytes()
    except OSError:
        data = None
    if want is not None and (data is None or hashlib.sha256(data).hexdigest() != want):
        raise MocapFormatError(path, "removed or changed after its take was read, and its text (which the output "
                                     "keeps where the take did not change) is no longer there; read the take again")
    return data
