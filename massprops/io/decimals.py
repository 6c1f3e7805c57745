"""Decimal numbers to float64, correctly rounded, many at once in numpy.

Text readers spend most of their time converting decimal strings (``float``
and numpy's own parser cost about 0.3 µs for 17 digits).  Here each token
``[+-]digits[.digits]`` (what mesh exporters write; an ``e`` exponent is
split off and read the same way) is read eight bytes at a time as one
64-bit word (SWAR: "SIMD within a register"): the 24 bytes ending at the
token are gathered, bytes before it become ``'0'``, the dot becomes ``'0'``
too, and three multiply-shift steps turn eight ASCII digits into their
value.  That gives an exact integer mantissa ``M < 10**19`` and a decimal
exponent ``k``; then:

* ``M ≤ 2**53`` and ``|k| ≤ 22``: ``M · 10**k`` or ``M / 10**-k`` is one
  correctly rounded operation on exact operands (Clinger's fast path);
* ``-25 ≤ k < 0`` otherwise: ``M / 10**-k = (M / 5**-k) · 2**k``, and the
  rounding of a first guess of ``M / 5**-k`` is settled with its exact
  residual in wrapping 64-bit integer arithmetic (see :func:`_quotient`);
* anything else (more digits, larger exponents) goes through Python's
  ``float``.

So every value is the correctly rounded one, as ``float`` gives.
"""

from __future__ import annotations

import re

import numpy as np

__all__ = ["parse_decimals", "token_values", "small_integers", "PAD"]

PAD = 24                                    # bytes a token needs before its end (one 24-byte window)
_ONES = 0x0101010101010101
_ALL = np.uint64(2 ** 64 - 1)
_HIGH = np.uint64(0x80 * _ONES)
_LOW7 = np.uint64(0x7F * _ONES)
_ZEROS = np.uint64(0x30 * _ONES)
_NIBBLE = np.uint64(0x0F * _ONES)
_UPPER = np.uint64(0xF0 * _ONES)
_SIX = np.uint64(0x06 * _ONES)
_POW10F = np.array([10.0 ** k for k in range(23)])                       # exact doubles
_POW10U = np.array([10 ** k for k in range(20)], dtype=np.uint64)
_POW5U = np.array([5 ** j for j in range(26)], dtype=np.uint64)
_POW5F = np.array([float(5 ** j) for j in range(26)])                    # exact up to 5**22
_FEW = 200                                  # tokens float reads quicker than a vectorised pass's fixed cost
_STRICT = re.compile(rb"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d{1,4})?")


def _byte_mask(words, byte, out, scratch):
    """0x80 in every byte of ``words`` equal to ``byte``, 0 elsewhere, into ``out`` (exact: no carries between bytes)."""
    np.bitwise_xor(words, np.uint64(byte * _ONES), out=scratch)
    np.bitwise_and(scratch, _LOW7, out=out)
    out += _LOW7
    out |= scratch
    out |= ~_HIGH
    out ^= _ALL
    return out


def _eight_digits(words, bad, scratch):
    """Eight ASCII digits per word (first digit in the low byte) to their value, in place; non-digits flagged in ``bad``."""
    np.bitwise_and(words, _UPPER, out=bad)
    bad ^= _ZEROS
    words &= _NIBBLE
    np.add(words, _SIX, out=scratch)
    scratch &= _UPPER
    bad |= scratch
    for factor, keep, shift in ((2561, 0x0F0F0F0F0F0F0F0F, 8), (6553601, 0x00FF00FF00FF00FF, 16),
                                (42949672960001, 0x0000FFFF0000FFFF, 32)):
        words &= np.uint64(keep)
        words *= np.uint64(factor)
        words >>= np.uint64(shift)
    return words


def _windows(buf, ends):
    """The 24 bytes ending at each of ``ends`` as little-endian uint64 words, shape (n, 3)."""
    view = np.ndarray((buf.size - 23,), dtype="V24", buffer=buf, strides=(1,))
    return view[ends - 24].view("<u8").reshape(ends.size, 3)


def _leading_mask(length):
    """Per word of a 24-byte window, the bytes before a token of ``length`` bytes that ends the window: (n, 3)."""
    before = np.empty((length.size, 3), dtype=np.int64)
    for word in range(3):                                   # bytes of this word before the token, 0..8
        np.subtract(24 - 8 * word, length, out=before[:, word])
    np.maximum(before, 0, out=before)
    np.minimum(before, 8, out=before)
    before *= -8
    before += 64
    shift = before.view(np.uint64)
    return np.right_shift(_ALL, shift, out=shift)


def _byte_index(marks):
    """The window byte (0..23) of the one 0x80 flag in words ``marks`` (n, 3), and how many flags there are."""
    flag = marks[:, 0].astype(np.float64) * 2.0 ** -128
    flag += marks[:, 1].astype(np.float64) * 2.0 ** -64
    flag += marks[:, 2].astype(np.float64)
    count = np.bitwise_count(marks[:, 0])
    count += np.bitwise_count(marks[:, 1])
    count += np.bitwise_count(marks[:, 2])
    return ((flag.view(np.int64) >> 52) - 902) >> 3, count


def _mantissas(buf, starts, ends):
    """``[+-]digits[.digits]`` tokens as (M, digits after the dot, negative, readable, dotted); M < 10**19 exact."""
    first = buf[starts]
    negative = first == 45
    length = ends - starts - (negative | (first == 43))               # digits and dot
    words = _windows(buf, ends)
    mask = _leading_mask(length)
    scratch = np.bitwise_xor(words, _ZEROS)
    scratch &= mask
    words ^= scratch                                                    # bytes before the token: '0'
    dots = _byte_mask(words, 46, mask, scratch)
    dot_at, count = _byte_index(dots)
    dots >>= np.uint64(6)
    words += dots                                                       # '.' + 2 == '0'
    values = _eight_digits(words, mask, scratch)
    bad = mask[:, 0] | mask[:, 1]
    bad |= mask[:, 2]
    whole = values[:, 0] * _POW10U[16]
    whole += values[:, 1] * _POW10U[8]
    whole += values[:, 2]
    dotted = count == 1
    after = np.where(dotted, 23 - dot_at, 0)
    readable = (bad == 0) & (count <= 1) & (length >= 1 + dotted) & (length <= 24) & (values[:, 0] <= 1000)
    readable &= after <= 19
    scale = _POW10U[np.minimum(after, 19)]
    above, below = np.divmod(whole, scale)
    above //= np.uint64(10)
    above *= scale
    above += below
    return np.where(dotted, above, whole), after, negative, readable, dotted


def _exponents(buf, starts, ends):
    """Tokens ``mantissa(e|E)exponent``: (M, decimal exponent, negative, readable)."""
    words = _windows(buf, ends)
    length = ends - starts
    mask = _leading_mask(length)
    words |= np.uint64(0x20 * _ONES)
    marks = _byte_mask(words, ord("e"), np.empty_like(words), np.empty_like(words)) & ~mask
    mark_at, count = _byte_index(marks)
    one = (count == 1) & (length <= 24)
    mark = np.where(one, ends - 24 + mark_at, starts)
    mantissa, after, negative, readable, _ = _mantissas(buf, starts, np.maximum(mark, starts + 1))
    power, _, _, power_readable, power_dotted = _mantissas(buf, np.minimum(mark + 1, ends - 1), ends)
    power_negative = buf[np.minimum(mark + 1, ends - 1)] == 45
    readable &= one & power_readable & ~power_dotted & (power < 10000) & (mark + 1 < ends) & (mark > starts)
    exponent = np.where(power_negative, -power.astype(np.int64), power.astype(np.int64)) - after
    return mantissa, exponent, negative, readable


def _quotient(mantissa, power5, mantissa_float):
    """``M / 5**j · 2**-j`` (= ``M / 10**j``) rounded to a double where an exact residual settles it, and where.

    A first guess ``q0 = m · 2**t`` of ``x = M / 5**j`` (m the 53-bit integer
    significand) is within a few units in the last place, so the scaled
    residual ``R = M · 2**-t − m · 5**j`` (``x − q0 = R · 2**t / 5**j``) is far
    below 2**63 and wrapping uint64 arithmetic gives it exactly.  ``q0``, its
    upper or its lower neighbour is then the correct rounding as ``2R`` lies
    within or beyond ``± 5**j`` (``4R`` below a power of two, where the gap
    halves); guesses more than one step off are left undone.  No exact tie
    can occur: with ``t ≤ 0`` it would need ``M = (2m+1) · 5**j · 2**(t-1)``,
    not an integer.  Scaling by ``2**-j`` is exact (far from the subnormals).
    """
    bits = (mantissa_float / _POW5F[power5]).view(np.uint64)
    shift = np.uint64(1075) - (bits >> np.uint64(52))
    significand = bits & np.uint64(2 ** 52 - 1)
    floor = significand == 0                                # a power of two: the gap below is half
    significand |= np.uint64(2 ** 52)
    unit = _POW5U[power5]
    significand *= unit
    twice = ((mantissa << shift) - significand).view(np.int64) << 1
    below = twice << floor
    unit = unit.view(np.int64)
    done = (shift <= np.uint64(63)) & (twice < 3 * unit) & (below > -3 * unit)
    bits += twice > unit
    bits -= below < -unit
    bits -= power5.astype(np.uint64) << np.uint64(52)
    return bits.view(np.float64), done


def _to_float(mantissa, exponent):
    """``mantissa · 10**exponent`` correctly rounded where that can be shown, and where."""
    mantissa_float = mantissa.astype(np.float64)                     # correctly rounded
    power = _POW10F[np.minimum(np.abs(exponent), 22)]
    values = np.where(exponent >= 0, mantissa_float * power, mantissa_float / power)
    done = (exponent == 0) | ((mantissa <= np.uint64(2 ** 53)) & (np.abs(exponent) <= 22))
    hard = np.flatnonzero(~done & (exponent < 0) & (exponent >= -25))
    if hard.size:
        values[hard], done[hard] = _quotient(mantissa[hard], -exponent[hard], mantissa_float[hard])
    return values, done


def _values(buf, starts, ends):
    """Token values where the vectorised path reads them, and where it does (the rest: 0)."""
    mantissa, after, negative, readable, _ = _mantissas(buf, starts, ends)
    exponent = -after
    retry = np.flatnonzero(~readable & (ends - starts <= 24) & (ends - starts >= 3))
    if retry.size > _FEW:                         # (a few are quicker through float)
        m, e, n, r = _exponents(buf, starts[retry], ends[retry])
        mantissa[retry], exponent[retry], negative[retry], readable[retry] = m, e, n, r
    values, done = _to_float(mantissa, exponent)
    return np.where(negative, -values, values), done & readable


def token_values(buf, starts, ends):
    """What Python's ``float`` gives for each token ``buf[starts:ends]``, or None if it refuses one.

    ``buf`` is uint8 with at least :data:`PAD` bytes before every token.
    """
    values, done = _values(buf, starts, ends)
    for k in np.flatnonzero(~done):
        try:
            values[k] = float(buf[starts[k]:ends[k]].tobytes())
        except ValueError:
            return None
    return values


def parse_decimals(text):
    """The whitespace-separated numbers of ``text`` (bytes) as float64, or None.

    None when some token is not of the form ``[+-]digits[.digits][(e|E)[+-]digits]``
    (the caller then uses a general parser, which also names a bad token).
    """
    buf = np.frombuffer(b" " * PAD + text + b" ", dtype=np.uint8)
    separator = buf <= 32
    odd = separator & (buf != 32) & (buf != 10)
    if odd.any() and np.any(odd & (buf != 13) & (buf != 9)):
        return None                                      # a control character
    edges = np.flatnonzero(np.diff(separator.view(np.int8)) != 0) + 1
    starts, ends = edges[0::2], edges[1::2]
    values, done = _values(buf, starts, ends)
    for k in np.flatnonzero(~done):
        token = buf[starts[k]:ends[k]].tobytes()
        if not _STRICT.fullmatch(token):
            return None
        values[k] = float(token)
    return values


def small_integers(buf, starts, lengths):
    """The values of unsigned decimal integers of 1 to 8 digits at ``buf[starts:starts + lengths]``, or None.

    ``buf`` is uint8 with at least 8 bytes after every start.
    """
    if lengths.size and (lengths.min() < 1 or lengths.max() > 8):
        return None
    view = np.ndarray((buf.size - 7,), dtype="V8", buffer=buf, strides=(1,))
    words = view[starts].view("<u8")
    shift = lengths.astype(np.uint64)
    shift *= np.uint64(-8 % 2 ** 64)
    shift += np.uint64(64)                                             # 8 * (8 - length) bits
    words <<= shift
    np.subtract(np.uint64(64), shift, out=shift)
    words |= np.right_shift(_ZEROS, shift, out=shift)                  # right-aligned, '0'-filled
    bad = shift
    values = _eight_digits(words, bad, np.empty_like(words))
    return None if np.any(bad) else values.view(np.int64)


def first_byte_at(buf, starts, byte):
    """Offset of the first ``byte`` in the 8 bytes from each of ``starts`` (8 where there is none)."""
    view = np.ndarray((buf.size - 7,), dtype="V8", buffer=buf, strides=(1,))
    words = view[starts].view("<u8")
    marks = _byte_mask(words, byte, np.empty_like(words), np.empty_like(words))
    lowest = marks & (~marks + np.uint64(1))
    offset = ((lowest.astype(np.float64).view(np.int64) >> 52) - 1030) >> 3
    return np.where(marks == 0, 8, offset)
