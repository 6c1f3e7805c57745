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

from .integrate_dd import det_double_double, integrate_double_double

__all__ = ["Moments", "reference_frame", "integrate"]

U = 2.0 ** -53
_DET_BOUND = (7.0 + 56.0 * U) * U          # Shewchuk's o3derrboundA
_REFINE_ABOVE = 64.0 * U                   # relative det bound that sends a face to the slow path
_CHUNK = 1 << 14                           # faces per chunk: fewer GIL hand-overs, workspace near L2


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
    axes = np.asarray(vertices).T          # per-axis reductions: much faster on contiguous rows
    if not axes.flags.c_contiguous:
        axes = np.ascontiguousarray(axes)
    low = axes.min(axis=1)
    high = axes.max(axis=1)
    reference = np.array([_reference_coordinate(float(lo), float(hi)) for lo, hi in zip(low, high)])
    largest = float((high - low).max())
    scale_exp = _ceil_log2(largest) if largest > 0 else 0
    return reference, scale_exp


def _refined_det(a, b, c):
    """det[a b c] per row from error-free triple products summed in double-double.

    Returns the determinant and an absolute bound on its error.
    """
    (hi, lo), permanent = det_double_double(a, b, c)
    det = hi + lo
    # Each of the 24 terms is exact; the TwoSum chain is exact but for the
    # accumulation of `lo` (≤ 24 roundings of quantities ≤ u·|partial sums|).
    bound = U * np.abs(det) + 2.0 * _gamma(24) * U * (1.0 + 4.0 * U) * permanent
    return det, bound


def _exact_det(a, b, c):
    rows = [[Fraction(float(v)) for v in p] for p in (a, b, c)]
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = rows
    return float(a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0))


# Rows of the per-chunk workspace (each row holds one value per face).  Edge
# vectors and points carry two extra rows repeating x and y, so that the
# cyclic shifts (y, z, x) and (z, x, y) are plain contiguous slices.
_A, _B, _C, _S = 0, 5, 10, 15             # corners a, b, c and s = a + b + c: 5 rows each
_E1, _E2 = 20, 25                         # b − a and c − a: 5 rows each
_P, _Q, _N, _T = 30, 33, 36, 39           # the cross product's two halves, the normal, scratch: 3 rows each
_DET, _ABS, _BOUND, _AREA = 42, 43, 44, 45
_FIRST, _SECOND = 46, 49                  # det·s (3 rows) and the six second-moment terms
_ROWS = 55
_SUMMED = {0: slice(_DET, _FIRST), 1: slice(_DET, _SECOND), 2: slice(_DET, _ROWS)}


def _chunk_sums(scaled_axes, faces, order, measure, weights, work):
    """Pairwise sums over one chunk of faces, in a preallocated workspace.

    Parameters
    ----------
    scaled_axes : ndarray, shape (3, n), float64
        Scaled vertex coordinates, one contiguous row per axis.
    faces : ndarray, shape (m, 3), int
    work : ndarray, shape (_ROWS, ≥ m), float64
        Scratch; every operation writes into it (no temporaries).

    Returns
    -------
    sums : ndarray
        Σ det, Σ |det|, Σ bound, Σ area, then Σ det·s (order ≥ 1), then the
        second-moment terms xx, yy, zz, xy, yz, xz (order 2).
    refined, exact : int
        Faces sent to the double-double and to the exact path.
    """
    m = faces.shape[0]
    w = work[:, :m]
    for k, corner in enumerate((_A, _B, _C)):
        for axis in range(3):
            np.take(scaled_axes[axis], faces[:, k], out=w[corner + axis], mode="clip")
    a, e1, e2 = w[_A:_A + 3], w[_E1:_E1 + 5], w[_E2:_E2 + 5]
    np.subtract(w[_B:_B + 3], a, out=e1[:3])
    np.subtract(w[_C:_C + 3], a, out=e2[:3])
    e1[3:] = e1[:2]
    e2[3:] = e2[:2]
    p, q, normal, scratch = w[_P:_P + 3], w[_Q:_Q + 3], w[_N:_N + 3], w[_T:_T + 3]
    np.multiply(e1[1:4], e2[2:5], out=p)
    np.multiply(e1[2:5], e2[1:4], out=q)
    np.subtract(p, q, out=normal)
    det, bound, area = w[_DET], w[_BOUND], w[_AREA]
    np.multiply(normal, normal, out=scratch)
    _row_sum(scratch, area)
    np.sqrt(area, out=area)
    np.abs(p, out=p)
    np.abs(q, out=q)
    np.add(p, q, out=p)                                   # |p| + |q|, per component
    refined = exact = 0
    if measure == "area":
        _row_sum(p, bound)
        bound *= _gamma(6)
        np.multiply(area, _gamma(3), out=det)
        bound += det
        det[:] = area
    else:
        np.multiply(a, normal, out=scratch)
        _row_sum(scratch, det)
        np.abs(a, out=scratch)
        np.multiply(scratch, p, out=scratch)
        _row_sum(scratch, bound)
        bound *= _DET_BOUND
        refined, exact = _refine_hard_faces(w, m)
    if weights is not None:
        det[:], bound[:] = _weighted(det, bound, weights)
    np.abs(det, out=w[_ABS])
    if order >= 1:
        s = w[_S:_S + 5]
        np.add(a, w[_B:_B + 3], out=s[:3])
        np.add(s[:3], w[_C:_C + 3], out=s[:3])
        np.multiply(s[:3], det, out=w[_FIRST:_FIRST + 3])
    if order >= 2:
        _second_moment_terms(w, det)
    return np.sum(w[_SUMMED[order]], axis=1), refined, exact


def _row_sum(rows, out):
    """out = (rows[0] + rows[1]) + rows[2], the order the error bounds assume."""
    np.add(rows[0], rows[1], out=out)
    out += rows[2]


def _refine_hard_faces(w, m):
    """Re-evaluate the determinants whose a-priori bound is too large relative to them."""
    det, bound, scratch = w[_DET], w[_BOUND], w[_T]
    np.abs(det, out=scratch)
    scratch *= _REFINE_ABOVE
    hard = np.flatnonzero(bound > scratch)
    if not hard.size:
        return 0, 0
    a, b, c = (w[corner:corner + 3, hard].T for corner in (_A, _B, _C))
    fine, fine_bound = _refined_det(a, b, c)
    still = np.flatnonzero(fine_bound > _REFINE_ABOVE * np.abs(fine))
    for face in still:
        fine[face] = _exact_det(a[face], b[face], c[face])
        fine_bound[face] = U * abs(fine[face])
    det[hard] = fine
    bound[hard] = fine_bound
    return hard.size, still.size


def _second_moment_terms(w, det):
    """det·(s sᵀ + a aᵀ + b bᵀ + c cᵀ) per face: xx, yy, zz, then xy, yz, zx.

    Each term is summed s, a, b, c in that order (3 additions), then weighted.
    """
    diagonal, off = w[_SECOND:_SECOND + 3], w[_SECOND + 3:_SECOND + 6]
    product = w[_T:_T + 3]
    for k, point in enumerate((_S, _A, _B, _C)):
        rows = w[point:point + 5]
        rows[3:] = rows[:2]
        if k == 0:
            np.multiply(rows[:3], rows[:3], out=diagonal)
            np.multiply(rows[:3], rows[1:4], out=off)
            continue
        np.multiply(rows[:3], rows[:3], out=product)
        diagonal += product
        np.multiply(rows[:3], rows[1:4], out=product)
        off += product
    w[_SECOND:_SECOND + 6] *= det


def _weighted(det, bound, weights):
    """Face terms times exact weights, and their bounds: one more rounding each."""
    weighted = det * weights
    return weighted, np.abs(weights) * bound * (1.0 + 2.0 * U) + 2.0 * U * np.abs(weighted)


def integrate(vertices, faces, *, order=2, chunk=_CHUNK, weights=None, measure="volume"):
    """Integrate the volume moments of a closed, consistently wound surface.

    Parameters
    ----------
    vertices : ndarray, shape (n, 3), float64
        Local-frame coordinates, mesh units.
    faces : ndarray, shape (m, 3), int
        Triangles, outward winding.
    order : {0, 1, 2}
        Highest moment to form: 0 volume, 1 first moments, 2 second moments.
    weights : ndarray, shape (m,), float64, optional
        A factor per face term, taken as exact (a cell's density, see
        :mod:`massprops.volume`); its product adds one rounding to the bounds.
    measure : {"volume", "area"}
        "area" replaces each face's ``det`` by ``|(b − a) × (c − a)|`` (twice its
        area), so the sums become surface integrals (:mod:`massprops.shell`).

    Returns
    -------
    Moments
    """
    scaled_axes = np.ascontiguousarray(np.asarray(vertices, dtype=np.float64).T)     # (3, n)
    reference, scale_exp = reference_frame(scaled_axes.T)
    scaled_axes -= reference[:, None]                          # exact (see reference_frame)
    np.ldexp(scaled_axes, -scale_exp, out=scaled_axes)
    scaled = scaled_axes.T
    radius = float(np.abs(scaled_axes).max())
    faces = np.asarray(faces)
    if faces.size and (faces.min() < 0 or faces.max() >= vertices.shape[0]):
        raise IndexError("a face refers to a vertex that does not exist")
    totals, refined, exact = _face_sums(scaled_axes, faces, order, measure, weights, chunk)
    gamma = _pairwise_gamma(min(chunk, faces.shape[0])) + U
    det_sum = totals[0]
    abs_sum = totals[1] * (1 + 2 * gamma)
    bound_sum = totals[2] * (1 + 2 * gamma)
    det_error = bound_sum + gamma * abs_sum
    first = np.zeros(3)
    first_error = 0.0
    if order >= 1:
        first = np.array(totals[4:7])
        first_error = 3 * radius * ((_gamma(3) + gamma) * abs_sum + (1 + _gamma(3)) * bound_sum)
    second = np.zeros((3, 3))
    second_error = 0.0
    if order >= 2:
        xx, yy, zz, xy, yz, zx = totals[7:13]
        second = np.array([[xx, xy, zx], [xy, yy, yz], [zx, yz, zz]])
        # Per face: s has 2 roundings, each product 1 more, the four-point sum 3,
        # the weight det 1 (γ(9)); then the pairwise sum over the chunk.
        second_error = 12 * radius ** 2 * ((_gamma(9) + gamma * (1 + _gamma(9))) * abs_sum
                                           + (1 + _gamma(9)) * bound_sum)
    if measure == "volume" and abs_sum > _CANCELLATION_LIMIT * abs(det_sum):
        # The tetrahedra cancel heavily: redo the sums (weighted or not) in double-double.
        dd = integrate_double_double(scaled, faces, order, weights=weights)
        det_sum, det_error = dd["det_sum"], dd["det_error"]
        first, first_error = dd.get("first", first), dd.get("first_error", first_error)
        second, second_error = dd.get("second", second), dd.get("second_error", second_error)
        refined = faces.shape[0]
    return Moments(reference, scale_exp, order, det_sum, det_error, first, first_error, second, second_error,
                   totals[3], faces.shape[0], refined, exact)


# Above this ratio Σ|det| / |Σ det| the fast pass loses more than ~4 bits to cancellation.
_CANCELLATION_LIMIT = 16.0


def _face_sums(scaled_axes, faces, order, measure, weights, chunk):
    """Chunk sums added exactly (``math.fsum``) across chunks, chunks spread over threads.

    numpy releases the GIL inside each operation, so threads run chunks in
    parallel; every chunk's sums are the same whichever thread forms them and
    ``fsum`` is exact, so the result does not depend on the thread count
    (:func:`massprops.parallel.thread_count`).
    """
    starts = range(0, faces.shape[0], chunk)

    def run(part):
        work = np.empty((_ROWS, chunk))
        return [_chunk_sums(scaled_axes, faces[start:start + chunk], order, measure,
                            None if weights is None else weights[start:start + chunk], work) for start in part]

    from .parallel import thread_count

    workers = min(thread_count(), len(starts) // _CHUNKS_PER_THREAD)
    if workers <= 1:
        results = run(starts)
    else:
        from concurrent.futures import ThreadPoolExecutor
        with ThreadPoolExecutor(workers) as pool:
            results = [r for part in pool.map(run, [starts[k::workers] for k in range(workers)]) for r in part]
    width = _SUMMED[order].stop - _DET
    totals = [math.fsum(column) for column in zip(*(sums for sums, _, _ in results))] or [0.0] * width
    return (totals + [0.0] * (13 - width), sum(r for _, r, _ in results), sum(e for _, _, e in results))


_CHUNKS_PER_THREAD = 4                    # below this many chunks a thread costs more than it saves
