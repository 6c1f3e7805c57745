"""Decimal numbers to float64, correctly rounded, many at once in numpy.

Text readers spend most of their time converting decimal strings (``float``
costs about 0.3 µs for 17 digits).  Here the digits of every token are
gathered into an integer mantissa ``M < 10**18`` and a decimal exponent ``E``
with array operations, then:

* ``M ≤ 2**53`` and ``|E| ≤ 22``: ``M · 10**E`` or ``M / 10**-E`` is one
  correctly rounded operation on exact operands (Clinger's fast path);
* ``M > 2**53``, ``-22 ≤ E < 0`` (the 17 digits of ``repr``-style output):
  the quotient is formed in double-double with a rigorous error bound, and
  its rounding is accepted only when that bound keeps it away from the
  midpoint between two doubles;
* anything else (and the rare quotient too close to a midpoint) goes through
  Python's ``float``.

So every value is the correctly rounded one, as ``float`` gives.
"""

from __future__ import annotations

import numpy as np

__all__ = ["parse_decimals"]

_U = 2.0 ** -53
_POW10 = np.array([10.0 ** k for k in range(23)])                  # exact doubles
_POW10_INT = np.array([10 ** k for k in range(18)], dtype=np.int64)
_MINUS, _PLUS, _DOT, _ZERO = 45, 43, 46, 48
_WIDEST = 40                               # longer tokens: the general parser


def parse_decimals(text):
    """The whitespace-separated numbers of ``text`` (bytes) as float64, or None.

    None when some token is not a plain decimal ``[+-]digits[.digits][(e|E)[+-]digits]``
    (the caller then uses a general parser, which also names the bad token).
    """
    buf = np.frombuffer(text, dtype=np.uint8)
    separator = buf <= 32
    if np.count_nonzero(separator) != sum(text.count(c) for c in (b" ", b"\n", b"\r", b"\t")):
        return None                                      # other control characters
    edges = np.diff((~separator).view(np.int8), prepend=np.int8(0), append=np.int8(0))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if starts.size == 0:
        return np.zeros(0)
    lengths = ends - starts
    width = int(lengths.max())
    if width > _WIDEST:
        return None
    # Character k of every token in row k (padded with spaces): every step works along long rows.
    index = np.arange(width)[:, None] + starts
    np.minimum(index, buf.size - 1, out=index)
    chars = buf[index]
    chars[np.arange(width)[:, None] >= lengths] = 32
    parts = _parts(chars)
    if parts is None:
        return None
    mantissa, exponent = parts
    values, done = _convert(mantissa, exponent)
    for k in np.flatnonzero(~done):                      # out of range or too close to call: exact fallback
        values[k] = abs(float(text[starts[k]:ends[k]]))
    return np.where(chars[0] == _MINUS, -values, values)


def _parts(chars):
    """Mantissa (int64; -1 past 18 significant digits) and decimal exponent per column, or None if malformed."""
    value = chars - np.uint8(_ZERO)
    digit = value < 10
    mark = (chars == ord("e")) | (chars == ord("E"))
    dot = chars == _DOT
    sign = (chars == _MINUS) | (chars == _PLUS)
    if not np.all(digit | mark | dot | sign | (chars == 32)):
        return None
    in_exponent = np.cumsum(mark, axis=0, dtype=np.int8) > 0
    sign_allowed = np.zeros_like(mark)
    sign_allowed[0] = True
    sign_allowed[1:] = mark[:-1]
    mantissa_digit = digit & ~in_exponent
    exponent_digit = digit & in_exponent
    if (np.any(mark.sum(axis=0, dtype=np.int8) > 1) or np.any(dot.sum(axis=0, dtype=np.int8) > 1)
            or np.any(dot & in_exponent) or np.any(sign & ~sign_allowed)
            or not mantissa_digit.any(axis=0).all()
            or np.any(mark.any(axis=0) & ~exponent_digit.any(axis=0))):
        return None
    mantissa, longest = _integer(value, mantissa_digit)
    exponent, widest = _integer(value, exponent_digit)
    if widest.max() > 4:
        return None
    exponent = np.where((sign & in_exponent & (chars == _MINUS)).any(axis=0), -exponent, exponent)
    exponent -= (mantissa_digit & (np.cumsum(dot, axis=0, dtype=np.int8) > 0)).sum(axis=0)
    mantissa[longest > 17] = -1
    return mantissa, exponent


def _integer(value, mask):
    """Per column, the integer the ``mask``ed digits spell (exact below 10**18), and its top nonzero place."""
    place = np.cumsum(mask[::-1], axis=0, dtype=np.int8)[::-1] - np.int8(1)     # digits below this one
    total = np.zeros(mask.shape[1], dtype=np.int64)
    top = np.full(mask.shape[1], -1, dtype=np.int8)
    for row in range(mask.shape[0]):                      # Horner's rule, one character row at a time
        here = mask[row]
        total = np.where(here, total * 10 + value[row], total)
        np.maximum(top, np.where(here & (value[row] > 0), place[row], np.int8(-1)), out=top)
    return total, top


def _convert(mantissa, exponent):
    """``mantissa · 10**exponent`` (magnitudes) correctly rounded where it can be shown; and where."""
    from ..integrate import _two_product

    mantissa_hi = mantissa.astype(np.float64)
    power = _POW10[np.minimum(np.abs(exponent), 22)]
    values = np.where(exponent >= 0, mantissa_hi * power, mantissa_hi / power)
    fast = (mantissa >= 0) & (mantissa <= 2 ** 53) & (np.abs(exponent) <= 22)
    wide = np.flatnonzero((mantissa > 2 ** 53) & (exponent < 0) & (exponent >= -22))
    done = fast
    if wide.size:
        done = fast.copy()
        done[wide], values[wide] = _quotient(mantissa[wide], mantissa_hi[wide], power[wide], _two_product)
    return values, done


def _quotient(mantissa, mantissa_hi, power, two_product):
    """``mantissa / power`` rounded, and whether that rounding is certain (see the module notes).

    ``mantissa_lo = M − fl(M)`` is exact (|M| < 2**60); ``q0 = fl(M_hi / p)``;
    ``P + Pe = q0 p`` exactly; ``a = M_hi − P`` is exact (Sterbenz);
    ``b = fl(M_lo − Pe)`` and ``r = fl(a + b)`` cost u|b| and u|r|;
    ``q1 = fl(r / p)`` costs u|q1|.  So ``|M/p − (q0 + q1)| ≤ u(1+u)(|b|/p + (2+u)|q1|)``,
    below ``err = 4u(|b|/p + |q1|)``.  With ``s + t = q0 + q1`` exactly, ``s``
    is the correct rounding when ``|t| + err`` stays below half the gap from
    ``s`` to its neighbour on ``t``'s side.
    """
    mantissa_lo = (mantissa - mantissa_hi.astype(np.int64)).astype(np.float64)
    q0 = mantissa_hi / power
    product, product_error = two_product(q0, power)
    b = mantissa_lo - product_error
    q1 = ((mantissa_hi - product) + b) / power
    s = q0 + q1
    t = (q0 - s) + q1                                     # exact: |q1| is far below |q0|
    err = 4.0 * _U * (np.abs(b) / power + np.abs(q1))
    gap = np.abs(np.nextafter(s, np.where(t > 0, np.inf, 0.0)) - s)
    return np.abs(t) + err < 0.5 * gap, s
