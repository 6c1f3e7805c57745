"""Decimal numbers to float64, correctly rounded, many at once in numpy.

Text readers spend most of their time converting decimal strings (``float``
and numpy's own parser cost about 0.3 µs for 17 digits).  For tokens of the
form ``[+-]digits[.digits][(e|E)[+-]digits]`` (what mesh exporters write)
the dots are deleted, the exponent marks made spaces, and numpy reads the
digits as integers (fast, and exact below 10**18), so each token becomes a
mantissa ``M`` and a decimal exponent ``E`` (its exponent minus the digits
after its dot).  Then:

* ``M ≤ 2**53`` and ``|E| ≤ 22``: ``M · 10**E`` or ``M / 10**-E`` is one
  correctly rounded operation on exact operands (Clinger's fast path);
* ``M > 2**53`` and ``-22 ≤ E < 0`` (the 17 digits of ``repr``-style
  output): the quotient is formed in double-double with a rigorous error
  bound, and its rounding is accepted only when that bound keeps it off the
  midpoint between two doubles (see :func:`_quotient`);
* anything else (more digits, larger exponents, and the rare quotient too
  close to call) goes through Python's ``float``.

So every value is the correctly rounded one, as ``float`` gives.
"""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["parse_decimals"]

_U = 2.0 ** -53
_POW10 = np.array([10.0 ** k for k in range(23)])                  # exact doubles
_MINUS, _PLUS, _DOT, _ZERO, _LOWER_E, _UPPER_E = 45, 43, 46, 48, 101, 69
_MARK_TO_SPACE = bytes.maketrans(b"eE", b"  ")


def parse_decimals(text):
    """The whitespace-separated numbers of ``text`` (bytes) as float64, or None.

    None when some token is not of the form ``[+-]digits[.digits][(e|E)[+-]digits]``
    (the caller then uses a general parser, which also names a bad token).
    """
    buf = np.frombuffer(text, dtype=np.uint8)
    separator = buf <= 32
    odd = separator & (buf != 32) & (buf != 10)
    if odd.any() and np.any(odd & (buf != 13) & (buf != 9)):
        return None                                      # a control character
    sign = (buf == _MINUS) | (buf == _PLUS)
    dot = buf == _DOT
    mark = (buf == _LOWER_E) | (buf == _UPPER_E)
    if not np.all(separator | sign | dot | mark | ((buf - np.uint8(_ZERO)) < 10)):
        return None                                      # nan, inf, anything else
    edges = np.diff((~separator).view(np.int8), prepend=np.int8(0), append=np.int8(0))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if starts.size == 0:
        return np.zeros(0)
    layout = _layout(starts, ends, sign, dot, mark)
    if layout is None:
        return None
    marked, frac_digits, digits = layout
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        try:                                             # "1.25e-3" reads as the integers 125 and -3
            integers = np.fromstring(text.translate(_MARK_TO_SPACE, b"."), dtype=np.int64, sep=" ")
        except ValueError:
            return None
    if integers.size != starts.size + marked.size:
        return None
    has_mark = np.zeros(starts.size, dtype=bool)
    has_mark[marked] = True
    first = np.arange(starts.size) + np.cumsum(has_mark) - has_mark
    mantissa = np.abs(integers[first])
    mantissa[digits > 18] = -1                           # more digits than int64 reads exactly
    exponent = -frac_digits
    exponent[marked] += integers[first[marked] + 1]
    values, done = _convert(mantissa, exponent)
    for k in np.flatnonzero(~done):                      # out of range or too close to call: exact fallback
        values[k] = abs(float(text[starts[k]:ends[k]]))
    return np.where(buf[starts] == _MINUS, -values, values)


def _at_most_one(mask, starts):
    """Positions of ``mask`` and the tokens they lie in, or None if a token holds two."""
    where = np.flatnonzero(mask)
    owner = np.searchsorted(starts, where, side="right") - 1
    return None if where.size and np.any(np.diff(owner) == 0) else (where, owner)


def _layout(starts, ends, sign, dot, mark):
    """Tokens with an exponent, digits after the dot and mantissa digits per token; None if malformed."""
    dots, marks = _at_most_one(dot, starts), _at_most_one(mark, starts)
    if dots is None or marks is None:
        return None
    (dot_at, dotted), (mark_at, marked) = dots, marks
    mantissa_end = ends.copy()
    mantissa_end[marked] = mark_at
    exponent_length = ends[marked] - mark_at - 1
    if np.any(exponent_length < 1) or np.any(dot_at >= mantissa_end[dotted]):
        return None                                      # "1e", or a dot in the exponent
    signed = sign[starts]
    exponent_signed = sign[mark_at + 1]
    if np.count_nonzero(sign) != np.count_nonzero(signed) + np.count_nonzero(exponent_signed):
        return None                                      # a sign inside a number
    if np.any(exponent_length - exponent_signed < 1) or np.any(exponent_length - exponent_signed > 4):
        return None                                      # "1e-", or an exponent past 9999
    frac_digits = np.zeros(starts.size, dtype=np.int64)
    frac_digits[dotted] = mantissa_end[dotted] - dot_at - 1
    digits = mantissa_end - starts - signed
    digits[dotted] -= 1
    if digits.min() < 1:                                 # a lone sign or dot
        return None
    return marked, frac_digits, digits


def _convert(mantissa, exponent):
    """``mantissa · 10**exponent`` correctly rounded where that can be shown, and where.

    ``mantissa`` is int64 (-1: unknown).
    """
    from ..integrate_dd import two_prod

    mantissa_hi = mantissa.astype(np.float64)              # correctly rounded (exact up to 2**53)
    power = _POW10[np.minimum(np.abs(exponent), 22)]
    values = np.where(exponent >= 0, mantissa_hi * power, mantissa_hi / power)
    done = (mantissa >= 0) & (((mantissa <= 2 ** 53) & (np.abs(exponent) <= 22)) | (exponent == 0))
    wide = np.flatnonzero((mantissa > 2 ** 53) & (exponent < 0) & (exponent >= -22))
    if wide.size:
        done[wide], values[wide] = _quotient(mantissa[wide], mantissa_hi[wide], power[wide], two_prod)
    return values, done


def _quotient(mantissa, mantissa_hi, power, two_product):
    """``M / p`` rounded to a double (p = 10**E exact, 2**53 < M < 10**18), and whether that is certain.

    ``M_lo = M − M_hi`` is exact (an integer below 2**7); ``q0 = fl(M_hi / p)``;
    ``P + Pe = q0 p`` exactly (Dekker); ``a = M_hi − P`` is exact (Sterbenz,
    P is within a factor 2 of M_hi); ``b = fl(M_lo − Pe)`` and
    ``r = fl(a + b)`` err by at most u|b| and u|r|; ``q1 = fl(r / p)`` by
    u|q1|.  So ``|M/p − (q0 + q1)| ≤ u(|b|/p + (2+u)|q1|) < err = 4u(|b|/p + |q1|)``
    (with room for rounding in ``err`` itself).  With ``s + t = q0 + q1``
    exactly (|q1| ≪ |q0|), ``s`` is the correct rounding of ``M/p`` when
    ``|t| + err`` stays below half the gap from ``s`` to its neighbour on
    ``t``'s side.
    """
    mantissa_lo = (mantissa - mantissa_hi.astype(np.int64)).astype(np.float64)
    q0 = mantissa_hi / power
    product, product_error = two_product(q0, power)
    b = mantissa_lo - product_error
    q1 = ((mantissa_hi - product) + b) / power
    s = q0 + q1
    t = (q0 - s) + q1
    err = 4.0 * _U * (np.abs(b) / power + np.abs(q1))
    gap = np.abs(np.nextafter(s, np.where(t > 0, np.inf, 0.0)) - s)
    return np.abs(t) + err < 0.5 * gap, s
