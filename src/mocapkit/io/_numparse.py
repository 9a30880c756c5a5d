"""Fast parser of whitespace-separated ASCII decimal numbers (the body of BVH/AMC-like text files).

:func:`parse_floats` reads a ``bytes`` / ``uint8`` buffer once in a numba
kernel and returns every number as float64, plus how many numbers each line
holds, so a caller can check a fixed count per line and report the line of the
first problem. The values are bit-for-bit what Python's ``float()`` gives for
each token: the kernel uses the exact fast path (an integer mantissa below
2**53 multiplied or divided by an exactly representable power of ten 10**k,
|k| <= 22, is one correctly rounded IEEE operation) and leaves every other
token (more than 18 significant digits, large exponents) to ``float()``.

Accepted tokens: an optional sign, digits with an optional decimal point
(``1``, ``1.``, ``.0083``, ``-0.5``), an optional exponent (``1e-12``,
``3.64024e-015``, ``2E+3``), and ``nan`` / ``inf`` / ``infinity`` in any case.
Separators are spaces, tabs, ``\\r``, ``\\v`` and ``\\f``; ``\\n`` ends a line, so
CRLF files and blank lines need nothing special. With ``comment`` (a BVH's ``#``), a line whose first
non-blank character it is holds no numbers, as a blank line (a ``#`` after a number is still an error).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["parse_floats", "line_of_offset"]

# 10**0 .. 10**22 are exact doubles; a product or quotient with one is correctly rounded.
_POW10 = np.array([10.0**k for k in range(23)], dtype=np.float64)
_TWO53 = 1 << 53
_MAX_DIGITS = 18  # 10**18 - 1 < 2**63: the mantissa stays in int64


@njit(cache=True, inline="always")
def _is_sep(c):
    # space, \t, \r, \v, \f (not \n: that ends the line)
    return c == 32 or c == 9 or c == 13 or c == 11 or c == 12


@njit(cache=True, inline="always")
def _match_word(buf, i, n, word):
    """True when buf[i:i+len(word)] equals ``word`` (lower-case ASCII codes) ignoring case."""
    if i + word.shape[0] > n:
        return False
    for k in range(word.shape[0]):
        if (buf[i + k] | 32) != word[k]:
            return False
    return True


_NAN = np.frombuffer(b"nan", dtype=np.uint8).copy()
_INF = np.frombuffer(b"inf", dtype=np.uint8).copy()
_INFINITY = np.frombuffer(b"infinity", dtype=np.uint8).copy()


@njit(cache=True)
def _count_newlines(buf):
    k = 0
    for i in range(buf.shape[0]):
        if buf[i] == 10:
            k += 1
    return k


@njit(cache=True)
def _parse_kernel(buf, pos, nv, line, values, counts, fb, pow10, w_nan, w_inf, w_infinity, comment):
    """Parse ``buf`` (uint8) from byte ``pos`` into preallocated ``values`` and ``counts``.

    Tokens the fast path cannot convert exactly are listed in ``fb`` (K, 3) as
    (value index, token start, token end) for the caller to convert with
    ``float()``. Returns ``(pos, nv, line, nfb, err_offset, full)``: when
    ``full`` is 1 the ``fb`` table filled up and parsing stopped at ``pos``, to
    be resumed with the returned state; ``err_offset`` is the byte offset of
    the first malformed token, or -1. No array is reallocated inside the loop
    (that would cost reference counting on every token). ``comment``: the byte that starts a comment line
    (skipped to its end, counting no numbers), or -1 for none.
    """
    n = buf.shape[0]
    nfb = 0
    cap = fb.shape[0]
    i = pos
    while i < n:
        c = buf[i]
        if c == 10:
            line += 1
            i += 1
            continue
        if _is_sep(c):
            i += 1
            continue
        if c == comment and counts[line] == 0:  # a comment line: nothing up to its end
            while i < n and buf[i] != 10:
                i += 1
            continue
        start = i
        neg = False
        if c == 45 or c == 43:  # '-' '+'
            neg = c == 45
            i += 1
        v = 0.0
        slow = False
        ok = True
        if i < n and (buf[i] | 32) == 110:  # n
            if _match_word(buf, i, n, w_nan):
                i += 3
                v = np.nan
            else:
                ok = False
        elif i < n and (buf[i] | 32) == 105:  # i
            if _match_word(buf, i, n, w_infinity):
                i += 8
                v = np.inf
            elif _match_word(buf, i, n, w_inf):
                i += 3
                v = np.inf
            else:
                ok = False
        else:
            m = 0
            nd = 0
            e10 = 0
            any_digit = False
            # integer part: leading zeros carry nothing, then up to _MAX_DIGITS significant digits
            while i < n and buf[i] == 48:
                any_digit = True
                i += 1
            while i < n:
                c = buf[i]
                if c < 48 or c > 57:
                    break
                any_digit = True
                if nd < _MAX_DIGITS:
                    m = m * 10 + (c - 48)
                    nd += 1
                else:
                    e10 += 1
                    slow = True
                i += 1
            if i < n and buf[i] == 46:  # '.'
                i += 1
                if m == 0:  # zeros right after the point only move the exponent
                    while i < n and buf[i] == 48:
                        any_digit = True
                        e10 -= 1
                        i += 1
                while i < n:
                    c = buf[i]
                    if c < 48 or c > 57:
                        break
                    any_digit = True
                    if nd < _MAX_DIGITS:
                        m = m * 10 + (c - 48)
                        nd += 1
                        e10 -= 1
                    else:
                        slow = True
                    i += 1
            if not any_digit:
                ok = False
            elif i < n and (buf[i] | 32) == 101:  # 'e'
                i += 1
                eneg = False
                if i < n and (buf[i] == 45 or buf[i] == 43):
                    eneg = buf[i] == 45
                    i += 1
                ex = 0
                any_e = False
                while i < n and 48 <= buf[i] <= 57:
                    any_e = True
                    if ex < 100000:
                        ex = ex * 10 + (buf[i] - 48)
                    i += 1
                if not any_e:
                    ok = False
                e10 += -ex if eneg else ex
            if ok and not slow:
                if m == 0:
                    v = 0.0
                elif m < _TWO53 and -22 <= e10 <= 22:
                    if e10 >= 0:
                        v = float(m) * pow10[e10]
                    else:
                        v = float(m) / pow10[-e10]
                else:
                    slow = True
        if not ok or (i < n and buf[i] != 32 and buf[i] != 10 and not _is_sep(buf[i])):
            return start, nv, line, nfb, start, 0
        if neg:
            v = -v
        if slow:
            if nfb == cap:
                return start, nv, line, nfb, -1, 1
            fb[nfb, 0] = nv
            fb[nfb, 1] = start
            fb[nfb, 2] = i
            nfb += 1
        values[nv] = v
        nv += 1
        counts[line] += 1
    return n, nv, line, nfb, -1, 0


def _as_u8(buf) -> np.ndarray:
    if isinstance(buf, np.ndarray):
        if buf.dtype != np.uint8 or buf.ndim != 1:
            raise TypeError(f"expected a 1-D uint8 array, got {buf.dtype} with shape {buf.shape}")
        return buf
    return np.frombuffer(buf, dtype=np.uint8)


def parse_floats(buf, comment: bytes | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Parse whitespace-separated numbers from ASCII text.

    Parameters
    ----------
    buf : bytes, bytearray, memoryview or uint8 array (N,)
        The text. Lines end with ``\\n`` (a preceding ``\\r`` is whitespace).
    comment : bytes of length 1, optional
        The character that starts a comment line (a BVH's ``b"#"``): such a line counts 0 numbers, as a
        blank one. Default: none (every token must be a number).

    Returns
    -------
    values : float64 array (V,)
        Every number in file order, equal bit for bit to ``float(token)``.
        On an error, the numbers before the bad token.
    counts : int64 array (L,)
        How many numbers each line holds (blank lines count 0); line ``k`` is
        the one after ``k`` newlines. A final newline opens no extra line.
        On an error, the lines up to and including the bad one.
    err_offset : int
        Byte offset in ``buf`` of the first token that is not a number, or -1.
        :func:`line_of_offset` turns it into a line index.

    Examples
    --------
    >>> v, c, err = parse_floats(b"1 -2.5\\r\\n\\n.0083 3e-015 nan\\n")
    >>> v.tolist()[:4], c.tolist(), err
    ([1.0, -2.5, 0.0083, 3e-15], [2, 0, 3], -1)
    >>> parse_floats(b"1 2\\n3 x4\\n")[2]
    6
    >>> parse_floats(b"1 2\\n  # a note\\n3 4\\n", comment=b"#")[1].tolist()
    [2, 0, 2]
    """
    arr = _as_u8(buf)
    code = -1 if comment is None else int(comment[0])
    n = arr.shape[0]
    newlines = _count_newlines(arr)
    values = np.empty(n // 2 + 1, dtype=np.float64)
    counts = np.zeros(newlines + 1, dtype=np.int64)
    fb = np.empty((256, 3), dtype=np.int64)
    raw = None
    pos = nv = line = 0
    while True:
        pos, nv, line, nfb, err, full = _parse_kernel(
            arr, pos, nv, line, values, counts, fb, _POW10, _NAN, _INF, _INFINITY, code
        )
        if nfb:
            if raw is None:
                raw = arr.tobytes()
            for k, s, e in fb[:nfb].tolist():
                values[k] = float(raw[s:e])
        if not full:
            break
        fb = np.empty((2 * fb.shape[0], 3), dtype=np.int64)
    # A buffer ending in '\n' opens no further (empty) line.
    nlines = line + 1 if err >= 0 or (n > 0 and arr[n - 1] != 10) else line
    return values[:nv], counts[:nlines], int(err)


def line_of_offset(buf, offset: int) -> int:
    """Index (0-based) of the line holding byte ``offset`` of ``buf``: the newlines before it."""
    arr = _as_u8(buf)
    return int(np.count_nonzero(arr[:offset] == 10))
