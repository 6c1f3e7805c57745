"""Signed-tetrahedron integrals of 1, x and x xᵀ over a closed triangle mesh.

Each face (a, b, c) and the reference point span a tetrahedron of signed volume
``det[a b c] / 6``.  Summed over a closed surface, with ``s = a + b + c``::

    ∫ 1 dV     = Σ det / 6
    ∫ x dV     = Σ det · s / 24
    ∫ x xᵀ dV  = Σ det · (s sᵀ + a aᵀ + b bᵀ + c cᵀ) / 120

Numerics (the reasons for every step below):

* Coordinates are first shifted to a reference point near the part and divided
  by a power of two, both exactly (:func:`reference_frame`), so a part far from
  the origin or at any scale integrates like a unit part at the origin.
* ``det`` is evaluated as ``a · ((b − a) × (c − a))`` with Shewchuk's a-priori
  bound ``(7u + 56u²) · permanent``.  Faces whose bound exceeds ``64 u |det|``
  (needles, plates, slivers seen edge-on) are re-evaluated from error-free
  products in double-double; faces even that cannot certify fall back to exact
  rationals.  Ordinary faces keep the fast path.
* Sums are pairwise (numpy's reduction along a contiguous axis) inside chunks
  and exact (``math.fsum``) across chunks, so the rounding bound grows with
  log(n), not n.

The returned bounds are absolute bounds on the error of each sum with respect
to exact arithmetic on the coordinates as given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

__all__ = ["Moments", "reference_frame", "integrate"]

U = 2.0 ** -53
_DET_BOUND = (7.0 + 56.0 * U) * U          # Shewchuk's o3derrboundA
_REFINE_ABOVE = 64.0 * U                   # relative det bound that sends a face to the slow path
_CHUNK = 1 << 15
_SPLITTER = 134217729.0                    # 2**27 + 1, Dekker's split


def _gamma(k):
    return k * U / (1.0 - k * U)


def _pairwise_gamma(n):
    # numpy's pairwise sum: 8 accumulators over blocks of ≤ 128 (≤ 25 roundings
    # per term) and one more per halving above that.
    return _gamma(32 + max(0, int(n).bit_length()))


@dataclass(frozen=True)
class Moments:
    """Raw volume moments of a closed mesh in scaled, shifted coordinates.

    Coordinates are ``y = (x − reference) · 2**-scale_exp``.  In those units
    ``det_sum = Σ det``, ``first = Σ det·s`` (3,), ``second = Σ det·(s sᵀ + a aᵀ +
    b bᵀ + c cᵀ)`` (3, 3), and ``area2 = Σ |(b − a) × (c − a)|``.  Each ``*_error``
    is an absolute bound on that sum's largest element error.  ``order`` says
    which moments were formed (0: volume only, 1: and first, 2: and second).
    """

    reference: np.ndarray
    scale_exp: int
    order: int
    det_sum: float
    det_error: float
    first: np.ndarray
    first_error: float
    second: np.ndarray
    second_error: float
    area2: float
    faces: int
    refined_faces: int
    exact_faces: int

    def negated(self):
        """The moments of the same surface with every face's winding reversed."""
        return Moments(self.reference, self.scale_exp, self.order, -self.det_sum, self.det_error,
                       -self.first, self.first_error, -self.second, self.second_error, self.area2,
                       self.faces, self.refined_faces, self.exact_faces)


def _ceil_log2(x):
    mantissa, exponent = math.frexp(x)
    return exponent - 1 if mantissa == 0.5 else exponent


def _reference_coordinate(low, high):
    """A shift for one axis such that ``x − shift`` is exact for every float x in [low, high]."""
    extent = high - low
    if not extent > 0:
        return low
    k = _ceil_log2(extent)                               # 2**(k-1) < extent ≤ 2**k
    big = math.ldexp(1.0, k)
    if low >= big or high <= -big:
        # Every |x| ≥ 2**k, so x is a multiple of 2**(k-52); the shift is a
        # multiple of 2**(k-8); the difference, a multiple of 2**(k-52) below
        # 2**(k+1) in size, is representable.
        centre = low * 0.5 + high * 0.5
        return math.ldexp(round(math.ldexp(centre, 8 - k)), k - 8)
    if 0 < low and high <= 2 * low:
        return low                                       # Sterbenz: x/2 ≤ low ≤ x
    if high < 0 and low >= 2 * high:
        return high
    return 0.0                                           # the box is within 2 extents of the origin


def reference_frame(vertices):
    """An exact shift and power-of-two scale that bring the part near the origin at unit size.

    The shift is chosen per axis near the bounding box (see
    :func:`_reference_coordinate`) so that ``x − reference`` is exact; the scale
    ``2**scale_exp`` is the smallest power of two at least the largest extent.

    Returns
    -------
    reference : ndarray, shape (3,)
    scale_exp : int
        Lengths are divided by ``2**scale_exp``.
    """
    low = vertices.min(axis=0)
    high = vertices.max(axis=0)
    reference = np.array([_reference_coordinate(float(lo), float(hi)) for lo, hi in zip(low, high)])
    largest = float((high - low).max())
    scale_exp = _ceil_log2(largest) if largest > 0 else 0
    return reference, scale_exp


def _two_product(x, y):
    p = x * y
    t = _SPLITTER * x
    xh = t - (t - x)
    xl = x - xh
    t = _SPLITTER * y
    yh = t - (t - y)
    yl = y - yh
    return p, ((xh * yh - p) + xh * yl + xl * yh) + xl * yl


def _refined_det(a, b, c):
    """det[a b c] per row from error-free triple products summed in double-double.

    Returns the determinant and an absolute bound on its error.
    """
    terms = []
    permanent = np.zeros(a.shape[0])
    for (i, j, k), sign in (((0, 1, 2), 1.0), ((1, 2, 0), 1.0), ((2, 0, 1), 1.0),
                            ((0, 2, 1), -1.0), ((1, 0, 2), -1.0), ((2, 1, 0), -1.0)):
        p, pe = _two_product(a[:, i], b[:, j])
        q, qe = _two_product(p, sign * c[:, k])
        r, re = _two_product(pe, sign * c[:, k])
        terms += [q, qe, r, re]
        permanent += np.abs(q)
    hi = np.zeros(a.shape[0])
    lo = np.zeros(a.shape[0])
    for term in terms:
        s = hi + term
        bb = s - hi
        lo += (hi - (s - bb)) + (term - bb)
        hi = s
    det = hi + lo
    # Each of the 24 terms is exact; the TwoSum chain is exact but for the
    # accumulation of `lo` (≤ 24 roundings of quantities ≤ u·|partial sums|).
    bound = U * np.abs(det) + 2.0 * _gamma(24) * U * (1.0 + 4.0 * U) * permanent
    return det, bound


def _exact_det(a, b, c):
    rows = [[Fraction(float(v)) for v in p] for p in (a, b, c)]
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = rows
    return float(a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0))


def _face_dets(a, b, c):
    """Determinants of a chunk of faces, with absolute error bounds, and refinement counts."""
    e1 = b - a
    e2 = c - a
    p = e1[:, [1, 2, 0]] * e2[:, [2, 0, 1]]
    q = e1[:, [2, 0, 1]] * e2[:, [1, 2, 0]]
    normal = p - q
    det = np.einsum("ij,ij->i", a, normal)
    permanent = np.einsum("ij,ij->i", np.abs(a), np.abs(p) + np.abs(q))
    bound = _DET_BOUND * permanent
    hard = np.flatnonzero(bound > _REFINE_ABOVE * np.abs(det))
    n_exact = 0
    if hard.size:
        fine, fine_bound = _refined_det(a[hard], b[hard], c[hard])
        det[hard] = fine
        bound[hard] = fine_bound
        still = hard[fine_bound > _REFINE_ABOVE * np.abs(fine)]
        for face in still:
            det[face] = _exact_det(a[face], b[face], c[face])
            bound[face] = U * abs(det[face])
        n_exact = still.size
    return det, bound, normal, hard.size, n_exact


def integrate(vertices, faces, *, order=2, chunk=_CHUNK):
    """Integrate the volume moments of a closed, consistently wound surface.

    Parameters
    ----------
    vertices : ndarray, shape (n, 3), float64
        Local-frame coordinates, mesh units.
    faces : ndarray, shape (m, 3), int
        Triangles, outward winding.
    order : {0, 1, 2}
        Highest moment to form: 0 volume, 1 first moments, 2 second moments.

    Returns
    -------
    Moments
    """
    reference, scale_exp = reference_frame(vertices)
    scaled = np.ldexp(vertices - reference, -scale_exp)
    radius = float(np.abs(scaled).max())
    sums = {name: [] for name in ("det", "abs", "bound", "area", "first", "second")}
    refined = exact = 0
    largest_chunk = 0
    for start in range(0, faces.shape[0], chunk):
        corner = scaled[faces[start:start + chunk]]          # (m, 3 corners, 3 axes)
        a, b, c = corner[:, 0], corner[:, 1], corner[:, 2]
        det, bound, normal, n_refined, n_exact = _face_dets(a, b, c)
        refined += n_refined
        exact += n_exact
        largest_chunk = max(largest_chunk, det.shape[0])
        area = np.sqrt(np.einsum("ij,ij->i", normal, normal))
        rows = [det, np.abs(det), bound, area]
        if order >= 1:
            s = a + b + c
            rows += list((det[:, None] * s).T)
        scalars = np.sum(np.stack(rows), axis=1)            # pairwise, row by row
        for name, value in zip(("det", "abs", "bound", "area"), scalars[:4]):
            sums[name].append(value)
        if order >= 1:
            sums["first"].append(scalars[4:])
        if order >= 2:
            sums["second"].append(_second_moment_sum(det, corner, s))
    gamma = _pairwise_gamma(largest_chunk) + U
    det_sum = math.fsum(sums["det"])
    abs_sum = math.fsum(sums["abs"]) * (1 + 2 * gamma)
    bound_sum = math.fsum(sums["bound"]) * (1 + 2 * gamma)
    det_error = bound_sum + gamma * abs_sum
    first = np.zeros(3)
    first_error = 0.0
    if order >= 1:
        first = np.array([math.fsum(col) for col in zip(*sums["first"])])
        first_error = 3 * radius * ((_gamma(3) + gamma) * abs_sum + (1 + _gamma(3)) * bound_sum)
    second = np.zeros((3, 3))
    second_error = 0.0
    if order >= 2:
        flat = [math.fsum(col) for col in zip(*sums["second"])]
        second = np.array([[flat[0], flat[3], flat[4]], [flat[3], flat[1], flat[5]], [flat[4], flat[5], flat[2]]])
        batch_gamma = _gamma(4 * _BATCH) + _pairwise_gamma(largest_chunk // _BATCH + 1)
        second_error = 12 * radius ** 2 * ((_gamma(9) + batch_gamma) * abs_sum + (1 + _gamma(9)) * bound_sum)
    if abs_sum > _CANCELLATION_LIMIT * abs(det_sum):
        # The tetrahedra cancel heavily: redo the sums in double-double.
        from .integrate_dd import integrate_double_double
        dd = integrate_double_double(scaled, faces, order)
        det_sum, det_error = dd["det_sum"], dd["det_error"]
        first, first_error = dd.get("first", first), dd.get("first_error", first_error)
        second, second_error = dd.get("second", second), dd.get("second_error", second_error)
        refined = faces.shape[0]
    return Moments(reference, scale_exp, order, det_sum, det_error, first, first_error, second, second_error,
                   math.fsum(sums["area"]), faces.shape[0], refined, exact)


# Above this ratio Σ|det| / |Σ det| the fast pass loses more than ~4 bits to cancellation.
_CANCELLATION_LIMIT = 16.0


_BATCH = 32
_PAIRS = (np.array([0, 1, 2, 0, 0, 1]), np.array([0, 1, 2, 1, 2, 2]))


def _second_moment_sum(det, corner, s):
    """Σ det·(s sᵀ + a aᵀ + b bᵀ + c cᵀ) over a chunk: xx, yy, zz, xy, xz, yz.

    Small batched matrix products (inner length 4·_BATCH, so each element's
    rounding bound is γ(128)) followed by a pairwise sum over the batches.
    """
    m = det.shape[0]
    padded = -(-m // _BATCH) * _BATCH
    points = np.zeros((padded, 4, 3))
    points[:m, 0] = s
    points[:m, 1:] = corner
    weights = np.zeros(padded)
    weights[:m] = det
    points = points.reshape(padded // _BATCH, 4 * _BATCH, 3)
    weighted = points * np.repeat(weights, 4).reshape(padded // _BATCH, 4 * _BATCH, 1)
    batch = np.matmul(weighted.transpose(0, 2, 1), points)     # (batches, 3, 3)
    six = batch[:, _PAIRS[0], _PAIRS[1]].T                     # (6, batches), contiguous rows
    return np.sum(np.ascontiguousarray(six), axis=1)
