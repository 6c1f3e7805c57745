"""Signed-tetrahedron integrals of 1, x and x xᵀ over a closed triangle mesh.

Each face (a, b, c) and the reference point span a tetrahedron of signed volume
``det[a b c] / 6``.  Summed over a closed surface, with ``s = a + b + c``::

    ∫ 1 dV     = Σ det / 6
    ∫ x dV     = Σ det · s / 24
    ∫ x xᵀ dV  = Σ det · (s sᵀ + a aᵀ + b bᵀ + c cᵀ) / 120

With the pairs ``u = a + b, b + c, c + a``, ``Σ u = 2 s`` and ``Σ u uᵀ = s sᵀ +
a aᵀ + b bᵀ + c cᵀ``: the kernel forms ``det·u`` and ``det·u_i·u_j`` (three
points, not four, each with fewer roundings) and lets the sums over faces and
pairs do the rest.

Numerics (the reasons for every step below):

* Coordinates are first shifted to a reference point near the part and divided
  by a power of two, both exactly (:func:`reference_frame`), so a part far from
  the origin or at any scale integrates like a unit part at the origin.
* ``det`` is evaluated as ``a · ((b − a) × (c − a))`` with Shewchuk's a-priori
  bound ``(7u + 56u²) · permanent``.  Faces whose bound exceeds ``64 u |det|``
  (needles, plates, slivers seen edge-on) are first re-evaluated from a
  rotation of their corners (a sliver's cross product cancels at one corner,
  not at all), then from error-free products in double-double; faces even
  that cannot certify fall back to exact rationals.  Ordinary faces keep the
  fast path.
* Sums are pairwise (numpy's reduction along a contiguous axis) inside chunks
  and exact (``math.fsum``) across chunks and pairs, so the rounding bound
  grows with log(n), not n.

The returned bounds are absolute bounds on the error of each sum with respect
to exact arithmetic on the coordinates as given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import MeshGeometryError
from .face_terms import WORKSPACE_ROWS, chunk_sums, workspace
from .integrate_dd import integrate_double_double
from .rounding import U, gamma as _gamma

__all__ = ["Moments", "reference_frame", "integrate"]

_CHUNK = 1 << 14                           # faces per chunk: few GIL hand-overs, two workspaces fit in L3


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
        return _short_centre(low, high)
    if 0 < low and high <= 2 * low:
        return low                                       # Sterbenz: x/2 ≤ low ≤ x
    if high < 0 and low >= 2 * high:
        return high
    return 0.0                                           # the box is within 2 extents of the origin


def _short_centre(low, high):
    """A number near (low + high) / 2 with at most ~10 significant bits (a multiple of 2**(k-8), extent ≤ 2**k)."""
    extent = high - low
    if not extent > 0 or not math.isfinite(extent):
        return low
    k = _ceil_log2(extent)
    return math.ldexp(round(math.ldexp(low * 0.5 + high * 0.5, 8 - k)), k - 8)


def _subtracts_exactly(row, shift):
    """Whether ``x − shift`` is exact for every x of ``row``: Knuth's TwoSum error is zero for each.

    In blocks, so a huge mesh needs no full-size temporaries.
    """
    for start in range(0, row.size, _EXACT_CHECK_BLOCK):
        x = row[start:start + _EXACT_CHECK_BLOCK]
        difference = x - shift
        back = difference - x                            # TwoSum(x, −shift): the rounding error of
        error = x - (difference - back)                  # the difference is (x − (d − b)) + (−shift − b),
        error += -shift - back                           # zero exactly when the difference is exact
        if error.any():                                  # (NaN, from an overflow, counts as inexact)
            return False
    return True


_EXACT_CHECK_BLOCK = 1 << 16


def reference_frame(vertices):
    """An exact shift and power-of-two scale that bring the part near the origin at unit size.

    The shift is chosen per axis: the box's centre (a short number near it)
    where ``x − centre`` is exact for every coordinate, which is checked — a
    reference inside the part leaves few faces whose plane passes near it —
    else a point of the box that is provably exact for any coordinates in it
    (:func:`_reference_coordinate`); either way ``x − reference`` is exact.  The scale
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
    reference, scale_exp, _ = _frame(axes)
    return reference, scale_exp


def _frame(axes):
    """reference_frame of coordinates given as contiguous rows (3, n), and the scaled radius.

    The radius ``max |x − reference| · 2**-scale_exp`` is exact: it comes from
    the bounding box, whose differences from the reference are exact too.
    """
    low = axes.min(axis=1)
    high = axes.max(axis=1)
    with np.errstate(over="ignore"):
        largest = float((high - low).max())
    if largest == math.inf and np.isfinite(low).all() and np.isfinite(high).all():
        raise MeshGeometryError(f"the mesh spans more than the largest double (from {float(low.min()):.3g} to "
                                f"{float(high.max()):.3g})", fix="rescale it (give it in a larger length unit)")
    reference = np.array([_reference_coordinate(float(lo), float(hi)) for lo, hi in zip(low, high)])
    for axis, (lo, hi) in enumerate(zip(low.tolist(), high.tolist())):
        # The box's centre leaves fewer faces whose plane passes near the reference
        # (hard determinants) and less cancellation: take it wherever it subtracts exactly.
        centre = _short_centre(lo, hi)
        if centre != reference[axis] and _subtracts_exactly(axes[axis], centre):
            reference[axis] = centre
    scale_exp = _ceil_log2(largest) if largest > 0 else 0
    radius = float(np.maximum(np.abs(high - reference), np.abs(low - reference)).max())
    return reference, scale_exp, math.ldexp(radius, -scale_exp)


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
        :mod:`massprops.mesh.volume`); its product adds one rounding to the bounds.
    measure : {"volume", "area"}
        "area" replaces each face's ``det`` by ``|(b − a) × (c − a)|`` (twice its
        area), so the sums become surface integrals (:mod:`massprops.mesh.sheet`).

    Returns
    -------
    Moments
    """
    scaled_axes = np.ascontiguousarray(np.asarray(vertices, dtype=np.float64).T)     # (3, n)
    reference, scale_exp, radius = _frame(scaled_axes)
    scaled_axes -= reference[:, None]                          # exact (see reference_frame)
    if scale_exp > -1000:
        scaled_axes *= math.ldexp(1.0, -scale_exp)             # exact: a power of two (faster than np.ldexp)
    else:
        np.ldexp(scaled_axes, -scale_exp, out=scaled_axes)     # a part below 2**-1000: the factor would overflow
    faces = np.asarray(faces)
    if faces.size and _outside(faces, vertices.shape[0]):
        raise IndexError("a face refers to a vertex that does not exist")
    totals, refined, exact = _face_sums(scaled_axes, faces, order, measure, weights, chunk)
    sums, abs_sum = _bounded_sums(totals, order, radius, _pairwise_gamma(min(chunk, faces.shape[0])) + U)
    det_sum, det_error, first, first_error, second, second_error = sums
    if measure == "volume" and abs_sum > _CANCELLATION_LIMIT * abs(det_sum):
        # The tetrahedra cancel heavily: redo the sums (weighted or not) in double-double.
        dd = integrate_double_double(scaled_axes.T, faces, order, weights=weights)
        det_sum, det_error = dd["det_sum"], dd["det_error"]
        first, first_error = dd.get("first", first), dd.get("first_error", first_error)
        second, second_error = dd.get("second", second), dd.get("second_error", second_error)
        refined = faces.shape[0]
    return Moments(reference, scale_exp, order, det_sum, det_error, first, first_error, second, second_error,
                   totals[3], faces.shape[0], refined, exact)


def _bounded_sums(totals, order, radius, gamma):
    """Σ det, Σ det·s, Σ det·Q from the kernel's totals (:func:`_face_sums`), each with its error bound.

    ``gamma`` bounds the relative rounding of one chunk's pairwise sum and the
    final rounding of ``fsum``; ``radius`` is the largest scaled coordinate.
    Returns the six values and the (bounded above) Σ |det|.
    """
    det_sum = totals[0]
    abs_sum = totals[1] * (1 + 2 * gamma)
    bound_sum = totals[2] * (1 + 2 * gamma)
    det_error = bound_sum + gamma * abs_sum
    first, first_error, second, second_error = np.zeros(3), 0.0, np.zeros((3, 3)), 0.0
    if order >= 1:
        # Σ det·s = ½ Σ det·(a + b + b + c + c + a): each term det·u has 2 roundings.
        first = 0.5 * np.array(totals[4:7])
        first_error = 3 * radius * ((_gamma(2) + gamma * (1 + _gamma(2))) * abs_sum + (1 + _gamma(2)) * bound_sum)
    if order >= 2:
        xx, yy, zz, xy, yz, zx = totals[7:13]
        second = np.array([[xx, xy, zx], [xy, yy, yz], [zx, yz, zz]])
        # Per face: Σ over the pairs of u uᵀ is s sᵀ + a aᵀ + b bᵀ + c cᵀ (≤ 12 r² each
        # element); each term det·u_i·u_j has 4 roundings (γ(4)); then the pairwise sum.
        second_error = 12 * radius ** 2 * ((_gamma(4) + gamma * (1 + _gamma(4))) * abs_sum
                                           + (1 + _gamma(4)) * bound_sum)
    return (det_sum, det_error, first, first_error, second, second_error), abs_sum


# Above this ratio Σ|det| / |Σ det| the fast pass loses more than ~4 bits to cancellation.
_CANCELLATION_LIMIT = 16.0


def _outside(faces, count):
    """Whether any face index is negative or at least ``count``."""
    if faces.dtype == np.int64:
        return faces.view(np.uint64).max() >= count        # one pass: negatives wrap above 2**63
    return faces.min() < 0 or faces.max() >= count


def _face_sums(scaled_axes, faces, order, measure, weights, chunk):
    """Chunk sums added exactly (``math.fsum``) across chunks, chunks spread over threads.

    numpy releases the GIL inside each operation, so threads run chunks in
    parallel; every chunk's sums are the same whichever thread forms them and
    ``fsum`` is exact, so the result does not depend on the thread count
    (:func:`massprops.core.parallel.thread_count`).

    Returns
    -------
    totals : list of 13 floats
        Σ det, Σ |det|, Σ bound, Σ area, Σ det·(2 s) (3), the six Σ det·Q terms
        (xx, yy, zz, xy, yz, zx); zeros for the orders not formed.
    refined, exact : int
    """
    starts = range(0, faces.shape[0], chunk)

    def run(part):
        size = min(chunk, faces.shape[0])
        buffer = np.empty(WORKSPACE_ROWS * size)
        full = workspace(buffer, size)
        return [chunk_sums(scaled_axes, faces[start:start + chunk], order, measure,
                            None if weights is None else weights[start:start + chunk],
                            full if faces.shape[0] - start >= size else workspace(buffer, faces.shape[0] - start))
                for start in part]

    from .parallel import thread_count

    workers = min(thread_count(), len(starts) // _CHUNKS_PER_THREAD)
    if workers <= 1:
        results = run(starts)
    else:
        from concurrent.futures import ThreadPoolExecutor
        with ThreadPoolExecutor(workers) as pool:
            results = [r for part in pool.map(run, [starts[k::workers] for k in range(workers)]) for r in part]
    totals = []
    if results:
        sums = np.array([sums for sums, _, _ in results])
        totals = [math.fsum(column) for column in sums[:, :4].T]
        # Each moment term (kind, axis) is summed over all chunks and its three pairs at once.
        terms = sums[:, 4:].reshape(len(results), -1, 3, 3)
        totals += [math.fsum(terms[:, kind, :, axis].ravel()) for kind in range(terms.shape[1]) for axis in range(3)]
    return (totals + [0.0] * (13 - len(totals)), sum(r for _, r, _ in results), sum(e for _, _, e in results))


_CHUNKS_PER_THREAD = 4                    # below this many chunks a thread costs more than it saves
