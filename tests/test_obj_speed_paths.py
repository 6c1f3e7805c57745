"""The vectorised OBJ paths give exactly what Python's ``float``/``int`` and the line reader give.

- :mod:`massprops.io.decimals` (SWAR digits, exact-residual rounding) against
  ``float`` on hard decimals: 17 to 25 significant digits, exact and near
  midpoints between doubles (also just below powers of two), exponents,
  huge, tiny and subnormal values, signs, leading zeros;
- the plain-layout OBJ reader against ``_read_lines``, bit for bit, on line
  endings, tabs, runs of spaces, corner forms and stray lines.
"""

from decimal import Decimal, getcontext

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops.io import decimals, obj
from massprops.io.decimals import parse_decimals


def _tokens(text):
    """``text`` padded as the OBJ reader pads it, and the starts and ends of its words."""
    buf = np.frombuffer(bytes(decimals.PAD) + text + b" " * 9, dtype=np.uint8)
    edges = np.flatnonzero(np.diff((buf <= 32).view(np.int8))) + 1
    return buf, edges[0::2], edges[1::2]


def _assert_as_float(tokens):
    expected = np.array([float(t) for t in tokens])
    few = decimals._FEW
    try:
        for decimals._FEW in (few, 0):            # also the vectorised exponent pass for however few tokens
            for values in (decimals.token_values(*_tokens(b" ".join(tokens))), parse_decimals(b" \n".join(tokens))):
                assert values is not None
                wrong = [t for t, a, b in zip(tokens, values, expected) if a.tobytes() != b.tobytes()]
                assert not wrong, wrong[:5]
    finally:
        decimals._FEW = few


def _near_midpoints(values, digits):
    """Decimals of ``digits`` significant digits at and around the midpoints above ``values``."""
    getcontext().prec = 80
    out = []
    for value in values:
        below, above = Decimal(float(value)), Decimal(float(np.nextafter(value, np.inf)))
        middle = (below + above) / 2
        for near in (middle, middle.next_plus(), middle.next_minus()):
            for k in digits:
                out.append(f"{near:.{k}e}".encode())
                out.append(format(near, f".{k}f").encode())
    return out


def test_midpoints_and_their_neighbours_round_as_float():
    rng = np.random.default_rng(7)
    values = np.concatenate([rng.uniform(0.5, 100.0, 200), 10.0 ** rng.uniform(-12, 17, 200),
                             2.0 ** np.arange(-30, 60)])           # powers of two: the gap below halves
    _assert_as_float(_near_midpoints(values, (15, 16, 17, 18, 19, 22)))
    below_powers = [np.nextafter(2.0 ** k, 0) for k in range(-20, 60)]
    _assert_as_float(_near_midpoints(below_powers, (16, 17, 18)))


def test_exact_ties_round_half_even():
    # integers halfway between doubles (odd above 2**53, 2 mod 4 above 2**54, ...), with the even neighbour
    # below or above, also with digits after the dot
    ties = [2 ** 53 + 1, 2 ** 53 + 3, 2 ** 54 + 2, 2 ** 54 + 6, 2 ** 54 + 10, 2 ** 55 + 4, 2 ** 55 + 12, 2 ** 56 + 8]
    tokens = [f"{t}{suffix}".encode() for t in ties for suffix in ("", ".0", ".00", ".000", "0e-1", "00e-2")]
    _assert_as_float(tokens + [b"0.5", b"2.5e-1", b"1.5", b"2.5"])


def test_common_forms_take_the_vectorised_path():
    rng = np.random.default_rng(11)
    values = rng.choice([-1.0, 1.0], 400) * rng.uniform(0.1, 1.0, 400) * 10.0 ** rng.integers(-2, 7, 400)
    tokens = [(fmt % v).encode() for fmt in ("%.17g", "%.6f", "%.9e", "%.3f", "%d") for v in values]
    buf, starts, ends = _tokens(b" ".join(tokens))
    vectorised, done = decimals._values(buf, starts, ends)
    assert done.all(), [t for t, d in zip(tokens, done) if not d][:5]
    assert vectorised.tobytes() == np.array([float(t) for t in tokens]).tobytes()


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["", "-", "+"]), st.text("0123456789", min_size=1, max_size=21),
                          st.text("0123456789", max_size=24),
                          st.sampled_from(["", "e", "E-", "e+", "e-"]), st.integers(0, 400)),
                min_size=1, max_size=60))
def test_random_decimals_read_as_float(parts):
    _assert_as_float([f"{s}{w}.{f}{m}{e if m else ''}".encode() for s, w, f, m, e in parts])


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=100),
       st.sampled_from(["%.17g", "%r", "%.18g", "%.19g", "%.20g", "%.17e", "%.25g", "%.30f", "%.16e"]))
def test_printed_doubles_read_back_exactly(values, fmt):
    _assert_as_float([(fmt % v).encode() for v in values])


def test_edge_tokens():
    _assert_as_float([b"-0", b"+0", b"-0.0", b"+.5", b".5", b"5.", b"-5.", b"00012.3400", b"0" * 30 + b"1.5", b"1" + b"0" * 24 + b".5",
                      b"-2" + b"0" * 30 + b"1.25", b"7" * 19, b"7" * 20, b"0." + b"7" * 19, b"0." + b"7" * 20,
                      b"0.0000077777777777777777", b"-0.00000000000000000001", b"0.000000000000000000011",
                      b"0.10000000000000000001", b"-0.09999999999999999999", b"0.1000000000000000000000",
                      b"1e5", b"1E-5", b"1e+05", b"1e0000", b"18446744073709551615", b"99999999999999999999",
                      b"1.7976931348623157e308", b"1.7976931348623159e308", b"2.2250738585072014e-308",
                      b"4.9406564584124654e-324", b"2e-324", b"1e400", b"-1e-400", b"123456789012345678.9",
                      b"0.00027976723536093928", b"-0.099782568283715123", b"3.4694469519536142e-18"])
    values = decimals.token_values(*_tokens(b"inf -Infinity nan +NaN 1_0"))
    assert np.isinf(values[:2]).all() and np.isnan(values[2:4]).all() and values[4] == 10.0
    assert decimals.token_values(*_tokens(b"1 2 x")) is None
    for text in (b"nan", b"inf", b"1_0", b"1e12345", b"1e5.", b"+-1", b"1e+", b"-e5", b"1..2", b"0x1p3"):
        assert parse_decimals(text) is None, text


def test_small_integers_and_slashes_match_int():
    words = [b"7", b"0012", b"12345678", b"99999999", b"3/4/5", b"123//9", b"1234567/2"]
    buf, starts, ends = _tokens(b" ".join(words))
    slash = decimals.first_byte_at(buf, starts, ord("/"))
    lengths = np.minimum(ends - starts, slash)
    assert decimals.small_integers(buf, starts, lengths).tolist() == [int(w.split(b"/")[0]) for w in words]
    assert decimals.small_integers(*_tokens(b"12 1x")[:2], np.array([2, 2])) is None
    assert decimals.small_integers(*_tokens(b"123456789")[:2], np.array([9])) is None


def _same_as_lines(text):
    fast = obj._read_plain_layout(text)
    slow = obj._read_lines(text.splitlines(), "x.obj")
    assert fast is not None, text
    assert fast.vertices.tobytes() == slow.vertices.tobytes() and np.array_equal(fast.faces, slow.faces)


@pytest.mark.parametrize("text", [
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3",
    b"v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n\r\n\n",
    b"# head\nv\t0  0\t 0 \nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nusemtl a\nf 1/1/1 2/1/1 3/1/1\nf 3//1 2//1 1//1\n",
    b"o x\ng y\nv -0 +1.5e-3 .5\nv 1. 0 0\nv 0 1 0\nfo 1\nf 1 2 3\nf 3/1 1/2 2\n",
])
def test_plain_layout_matches_line_reader(text):
    _same_as_lines(text)


@pytest.mark.parametrize("text", [
    b"v 0 0 0\nv 1 0 0\n v 0 1 0\nf 1 2 3\n",            # indented vertex line inside the block
    b"# a\rv 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # lone CR: splitlines makes a vertex line
    b"\x0bv 1 1 1\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv\x0b1 1 1\nf 1 2 3\n",
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf\n",
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n# end\n",           # (the general readers take these)
    b"v 0 0 0\nv 1 0 0\nv 0 1\x002\nf 1 2 3\n",
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 123456789\n",
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3//\n",
])
def test_plain_layout_declines_other_layouts(text):
    assert obj._read_plain_layout(text) is None


def test_read_pads_the_file_itself(tmp_path):
    rng = np.random.default_rng(5)
    vertices = rng.normal(size=(50, 3)) * 10.0 ** rng.integers(-20, 20, size=(50, 1))
    path = tmp_path / "part.obj"
    with open(path, "w") as f:
        f.write("".join("v %.17g %.17g %.17g\n" % tuple(v) for v in vertices))
        f.write("".join("f %d %d %d\n" % tuple(rng.integers(1, 51, size=3)) for _ in range(40)))
    mesh = obj.read(path)
    slow = obj._read_lines(path.read_bytes().splitlines(), path)
    assert mesh.vertices.tobytes() == slow.vertices.tobytes() and np.array_equal(mesh.faces, slow.faces)
