"""The double-double pass of the volume integrals, for meshes whose tetrahedra cancel.

The fast pass in :mod:`massprops.core.integrate` is accurate to a few units of
rounding of ``Σ|det|``.  When the tetrahedra from the reference point cancel
heavily (``Σ|det| ≫ |Σ det|``: a thin rotated plate or needle whose bounding box
straddles the origin, where no exact shift to its centre exists), that is not
enough.  This pass forms every term — ``det``, ``det·s``, ``det·Q`` — as a
double-double (hi + lo, relative error O(u²)) from error-free products, and
adds all hi and lo parts with ``math.fsum`` (correctly rounded), so the
result is accurate to O(u) of the answer itself whatever the cancellation.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from .rounding import U, gamma

__all__ = ["integrate_double_double", "det_double_double", "DET_ERROR"]

_SPLITTER = 134217729.0


def two_sum(a, b):
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _fast_two_sum(a, b):
    s = a + b
    return s, b - (s - a)


def two_prod(a, b):
    p = a * b
    t = _SPLITTER * a
    ah = t - (t - a)
    al = a - ah
    t = _SPLITTER * b
    bh = t - (t - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def dd_add(x, y):
    s, e = two_sum(x[0], y[0])
    return _fast_two_sum(s, e + (x[1] + y[1]))


def dd_mul(x, y):
    p, e = two_prod(x[0], y[0])
    return _fast_two_sum(p, e + (x[0] * y[1] + x[1] * y[0]))


# det[a b c] = Σ sign · a_i b_j c_k over the six permutations (i, j, k).
_I, _J, _K = ([0, 1, 2, 0, 1, 2], [1, 2, 0, 2, 0, 1], [2, 0, 1, 1, 2, 0])
_SIGNS = np.array([1.0, 1.0, 1.0, -1.0, -1.0, -1.0])[:, None]


# The error of det_double_double's hi + lo, relative to its permanent P = Σ|major|
# (≥ (1 − γ(5)) of the exact Σ|major|).  lo is a float sum of 17 values (γ(16)
# of their magnitudes): the 5 exact TwoSum errors of the tree over the six major
# terms (≤ u of its partial sums, over 3 levels: ≤ 3u(1 + γ(3)) Σ|major|), the six
# exact product errors (≤ u |major|) and the six minor terms (≤ u(1 + γ(2)) |major|);
# the minor terms' own roundings add ≤ u²(1 + γ(2)) Σ|major|.
DET_ERROR = (5.0 * gamma(16) + U) * U * (1.0 + gamma(12))


def det_double_double(a, b, c):
    """det[a b c] per row as a double-double, and the permanent Σ|a_i b_j c_k|.

    Each of the six signed products a_i·b_j·c_k is split error-free into a
    major term, its rounding error and a minor term (the error of a_i·b_j
    times c_k, rounded once); the major terms are added in a tree of TwoSums
    (a handful of array operations, whatever the row count): ``hi`` is the
    root, ``lo`` the float sum of everything else.  ``hi + lo`` is within
    ``DET_ERROR · permanent`` of the exact determinant.

    Parameters
    ----------
    a, b, c : ndarray, shape (h, 3)

    Returns
    -------
    (hi, lo) : pair of ndarray, shape (h,)
    permanent : ndarray, shape (h,)
    """
    p, p_error = two_prod(a.T[_I], b.T[_J])                    # (6, h): a_i b_j exactly
    c_k = _SIGNS * c.T[_K]
    major, major_error = two_prod(p, c_k)
    rest, partial = [major_error, p_error * c_k], major
    while partial.shape[0] > 1:
        half = partial.shape[0] // 2
        total, error = two_sum(partial[:half], partial[half:2 * half])
        rest.append(error)
        partial = np.concatenate([total, partial[2 * half:]])
    lo = np.concatenate(rest).sum(axis=0)
    return _fast_two_sum(partial[0], lo), np.abs(major).sum(axis=0)


_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def _chunk_terms(a, b, c, order, weights=None):
    """Double-double terms of one chunk: lists of (hi, lo) arrays per sum."""
    det, permanent = det_double_double(a, b, c)
    if weights is not None:
        det = dd_mul(det, (weights, np.zeros_like(weights)))
        permanent = permanent * np.abs(weights)
    terms = {"det": [det], "first": [], "second": []}
    if order >= 1:
        s = [dd_add(two_sum(a[:, i], b[:, i]), (c[:, i], 0.0)) for i in range(3)]
        terms["first"] = [dd_mul(det, s[i]) for i in range(3)]
    if order >= 2:
        for i, j in _PAIRS:
            q = dd_mul(s[i], s[j])
            for p in (a, b, c):
                q = dd_add(q, two_prod(p[:, i], p[:, j]))
            terms["second"].append(dd_mul(det, q))
    return terms, np.abs(det[0]), permanent


def _fsum_dd(parts):
    return math.fsum(itertools.chain.from_iterable(np.concatenate(p) for p in parts))


def integrate_double_double(scaled, faces, order, chunk=1 << 14, weights=None):
    """Σ det, Σ det·s, Σ det·Q over all faces, each correctly rounded from double-double terms.

    Parameters
    ----------
    scaled : ndarray, shape (n, 3)
        Shifted, scaled coordinates (exact images of the input).
    faces : ndarray, shape (m, 3)
    weights : ndarray, shape (m,), optional
        Exact per-face factors (a cell's density) multiplying every term.

    Returns
    -------
    dict with det_sum, first (3,), second (3, 3) and their absolute error bounds.
    """
    det_parts, first_parts, second_parts = [], [[] for _ in range(3)], [[] for _ in range(6)]
    abs_sum = permanent_sum = 0.0
    for start in range(0, faces.shape[0], chunk):
        corner = scaled[faces[start:start + chunk]]
        terms, abs_det, permanent = _chunk_terms(corner[:, 0], corner[:, 1], corner[:, 2], order,
                                                 None if weights is None else weights[start:start + chunk])
        det_parts.append(terms["det"][0])
        for k, t in enumerate(terms["first"]):
            first_parts[k].append(t)
        for k, t in enumerate(terms["second"]):
            second_parts[k].append(t)
        abs_sum += math.fsum(abs_det)
        permanent_sum += math.fsum(permanent)
    radius = float(np.abs(scaled).max())
    # Per term: det to DET_ERROR·permanent; each dd product/sum adds ≤ 8u² relative
    # of its operands' magnitudes; fsum rounds the total once.
    det_term = DET_ERROR * permanent_sum * (1 + 2 * U) + 64 * U * U * abs_sum
    det_sum = _fsum_dd(det_parts)
    out = {"det_sum": det_sum, "det_error": det_term + U * abs(det_sum), "abs_sum": abs_sum}
    if order >= 1:
        first = np.array([_fsum_dd(p) for p in first_parts])
        out["first"] = first
        out["first_error"] = 3 * radius * det_term * 4 + U * float(np.abs(first).max())
    if order >= 2:
        flat = [_fsum_dd(p) for p in second_parts]
        second = np.array([[flat[0], flat[3], flat[4]], [flat[3], flat[1], flat[5]], [flat[4], flat[5], flat[2]]])
        out["second"] = second
        out["second_error"] = 12 * radius ** 2 * det_term * 8 + U * float(np.abs(second).max())
    return out
