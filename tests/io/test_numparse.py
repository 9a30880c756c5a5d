"""The numba number parser against a pure-Python oracle built on ``float()``."""

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit.io._numparse import line_of_offset, parse_floats

# What the parser accepts, stated independently: sign, digits with an optional point, optional exponent,
# or nan / inf / infinity in any case.
_TOKEN = re.compile(rb"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|(?i:nan|inf|infinity))")
_WORD = re.compile(rb"[^ \t\r\v\f]+")


def reference_parse(buf: bytes):
    """Oracle: split into lines and tokens, convert each with ``float()``; (values, counts, err_offset)."""
    values, counts = [], []
    lines = buf.split(b"\n")
    if buf.endswith(b"\n") or buf == b"":
        lines = lines[:-1]
    start = 0
    for line in lines:
        c = 0
        for m in _WORD.finditer(line):
            tok = m.group()
            if not _TOKEN.fullmatch(tok):
                counts.append(c)
                return values, counts, start + m.start()
            values.append(float(tok))
            c += 1
        counts.append(c)
        start += len(line) + 1
    return values, counts, -1


def same_bits(a, b) -> bool:
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        return False
    both_nan = np.isnan(a) & np.isnan(b)
    return bool(np.all(both_nan | (a.view(np.int64) == b.view(np.int64))))


def check(buf: bytes):
    v, c, err = parse_floats(buf)
    rv, rc, rerr = reference_parse(buf)
    assert err == rerr, (buf, err, rerr)
    assert c.tolist() == rc, (buf, c.tolist(), rc)
    assert same_bits(v, rv), (buf, v.tolist(), rv)
    return v, c, err


def test_examples_from_bvh_files():
    buf = b"9.3722 17.8693 -17.3198\r\n\t.0083 -.5 +2.\r\n\r\n1e-12 3.64024e-015 -4.3199e-07 NaN nan -0\n"
    v, c, err = check(buf)
    assert err == -1 and c.tolist() == [3, 3, 0, 6]
    assert v[3] == 0.0083 and v[4] == -0.5 and v[5] == 2.0 and v[7] == 3.64024e-15
    assert np.isnan(v[9]) and np.isnan(v[10]) and math.copysign(1.0, v[11]) == -1.0


@pytest.mark.parametrize(
    "text",
    [
        "", "\n", "\n\n", "1", "1\n", "1 \n 2", "  \t ", "1e", "1e+", ".", "-", "+", "1.5.3", "--1", "1-2",
        "abc", "1 x", "1,2", "nanx", "infinite", "in", "0x10", "1_000", "1e5.0", "1 2\n3 x4\n", "\r\n1\r\n",
        "123456789012345678901234567890", "0.000000000000000000000000000001", "1e-400", "1e400", "-1e400",
        "9007199254740993", "9007199254740992", "179769313486231580793728971405303415079934132710037826936173778980"
        "444968292764750946649017977587207096330286416692887910946555547851940402630657488671505820681908902000708"
        "383676273854845817711531764475730270069855571366959622842914819860834936475292719074168444365510704342711"
        "559699508093042880177904174497791.9999999999999999999999999999999999999999999999999999999999999999999999",
        "2.2250738585072011e-308", "4.9406564584124654e-324", "2.4703282292062327e-324", "0.1e23", "1e22", "1e23",
        "8.98846567431158e307", "1.00000000000000011102230246251565404236316680908203125",
        "INF -Infinity +nan", "00000000000000000000000000123.4500000000000000000000",
    ],
)
def test_edge_tokens(text):
    check(text.encode())


@given(st.floats(allow_nan=True, allow_infinity=True))
def test_repr_of_any_float(x):
    check(repr(x).encode())
    check(f"{x:.17e}".encode())
    check(f"{x:.6f}".encode())


_digits = st.text(alphabet="0123456789", max_size=25)


@st.composite
def decimal_tokens(draw):
    sign = draw(st.sampled_from(["", "-", "+"]))
    whole = draw(_digits)
    point = draw(st.booleans())
    frac = draw(_digits) if point else ""
    if not whole and not frac:
        whole = "0"
    tok = sign + whole + ("." if point else "") + frac
    if draw(st.booleans()):
        e = draw(st.integers(-400, 400))
        pad = draw(st.integers(0, 3))
        tok += draw(st.sampled_from("eE")) + ("-" if e < 0 else draw(st.sampled_from(["", "+"]))) + str(abs(e)).zfill(pad + 1)
    return tok


@given(decimal_tokens())
@settings(max_examples=2000)
def test_decimal_tokens_equal_float_bit_for_bit(tok):
    v, c, err = parse_floats(tok.encode())
    assert err == -1 and c.tolist() == [1]
    assert same_bits(v, [float(tok)]), (tok, v[0], float(tok))


@given(decimal_tokens(), st.integers(0, 22))
def test_short_mantissas_with_exponents(tok, k):
    # the exact fast path's edge: small mantissas times powers of ten near 10^22
    for t in (tok.split("e")[0].split("E")[0] + f"e{k}", f"{k}e-{k}", f"9007199254740991e{k}"):
        assert same_bits(parse_floats(t.encode())[0], [float(t)]), t


_pieces = st.one_of(
    decimal_tokens(),
    st.sampled_from([" ", "  ", "\t", "\n", "\r\n", "\n\n", "nan", "NaN", "inf", "-Infinity"]),
    st.sampled_from(["x", "1.2.3", "e5", "--", "1e", "abc"]),
)


@given(st.lists(_pieces, max_size=40))
@settings(max_examples=500)
def test_mixed_text_matches_reference(pieces):
    # join numbers with separators so every token stands alone; garbage tokens must be reported where they start
    out = []
    for p in pieces:
        out.append(p)
        if p.strip():
            out.append(" ")
    check("".join(out).encode())


def test_many_slow_tokens_grow_the_fallback_table():
    toks = [f"{k}.{'7' * 20}e{k % 300}" for k in range(3000)]
    text = "\n".join(" ".join(toks[i : i + 7]) for i in range(0, len(toks), 7))
    v, c, err = check(text.encode())
    assert err == -1 and v.shape == (3000,)


def test_uint8_input_and_line_of_offset():
    buf = b"1 2\n3 4\n5 bad\n"
    arr = np.frombuffer(buf, dtype=np.uint8)
    v, c, err = parse_floats(arr)
    assert v.tolist() == [1.0, 2.0, 3.0, 4.0, 5.0] and c.tolist() == [2, 2, 1] and err == 10
    assert line_of_offset(arr, err) == 2
    with pytest.raises(TypeError):
        parse_floats(np.zeros(3))
