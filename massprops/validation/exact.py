"""Exact mass properties of a triangle mesh in rational arithmetic: the reference for accuracy reports.

Every float is ``n · 2**e``; after one common power-of-two scaling all
coordinates are Python integers, the signed-tetrahedron sums about the origin
are exact integers, and the few divisions at the end are exact Fractions.
Nothing here shares code with :mod:`massprops.core`, so it can judge it.
Vectorised over numpy object arrays: about a second per 100k triangles.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

__all__ = ["exact_properties"]


def _integers(values):
    """Object array of Python ints ``n`` and an exponent ``e`` with ``values == n · 2**e`` exactly."""
    values = np.asarray(values, dtype=np.float64)
    mantissa, exponent = np.frexp(values)
    ints = (mantissa * 2.0 ** 53).astype(np.int64)          # exact: |mantissa| < 1 has 53 bits
    exponent = exponent.astype(np.int64) - 53
    nonzero = ints != 0
    if not nonzero.any():
        return np.zeros(values.shape, dtype=object), 0
    lowest = np.where(nonzero, ints & -ints, 1)             # the lowest set bit, a power of two
    odd = ints // lowest                                    # exact
    exponent = exponent + np.log2(lowest.astype(np.float64)).astype(np.int64)
    e = int(exponent[nonzero].min())
    shift = np.where(nonzero, exponent - e, 0)
    return odd.astype(object) * (2 ** shift.astype(object)), e

def _rational_integers(values):
    """Object array of Python ints ``n`` and ``unit`` with ``values == n · unit``, for Fractions (or ints)."""
    values = np.asarray(values, dtype=object)
    denominator = 1
    for value in values.ravel().tolist():
        denominator = math.lcm(denominator, Fraction(value).denominator)
    ints = np.array([int(Fraction(v) * denominator) for v in values.ravel().tolist()], dtype=object)
    return ints.reshape(values.shape), Fraction(1, denominator)


def exact_properties(triangles):
    """Exact volume, center of mass and inertia about the COM of a closed surface, density 1.

    Parameters
    ----------
    triangles : array_like, shape (m, 3, 3)
        Corner coordinates (floats, taken exactly as given; or Fractions, an
        object array, for points placed exactly), outward winding.

    Returns
    -------
    dict
        ``volume`` (Fraction), ``center_of_mass`` (3 Fractions),
        ``inertia_com`` (3 × 3 nested lists of Fractions, ``J_G'``).
    """
    if np.asarray(triangles).dtype == object:
        ints, unit = _rational_integers(triangles)
    else:
        ints, e = _integers(triangles)
        unit = Fraction(2) ** e
    a, b, c = ints[:, 0], ints[:, 1], ints[:, 2]
    det = (a[:, 0] * (b[:, 1] * c[:, 2] - b[:, 2] * c[:, 1]) - a[:, 1] * (b[:, 0] * c[:, 2] - b[:, 2] * c[:, 0])
           + a[:, 2] * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0]))
    s = a + b + c
    det_sum = int(det.sum())
    first = [int((det * s[:, i]).sum()) for i in range(3)]
    second = {}
    for i in range(3):
        for j in range(i, 3):
            term = s[:, i] * s[:, j] + a[:, i] * a[:, j] + b[:, i] * b[:, j] + c[:, i] * c[:, j]
            second[i, j] = second[j, i] = int((det * term).sum())
    volume = Fraction(det_sum, 6)
    g = [Fraction(first[i], 4 * det_sum) for i in range(3)]
    central = [[Fraction(second[i, j], 120) - volume * g[i] * g[j] for j in range(3)] for i in range(3)]
    trace = central[0][0] + central[1][1] + central[2][2]
    inertia = [[((trace if i == j else 0) - central[i][j]) * unit ** 5 for j in range(3)] for i in range(3)]
    return {"volume": volume * unit ** 3, "center_of_mass": [x * unit for x in g], "inertia_com": inertia}

