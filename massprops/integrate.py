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
from fractions import Fraction

import numpy as np

from .integrate_dd import DET_ERROR, det_double_double, integrate_double_double

__all__ = ["Moments", "reference_frame", "integrate"]

U = 2.0 ** -53
_DET_BOUND = (7.0 + 56.0 * U) * U          # Shewchuk's o3derrboundA
_REFINE_ABOVE = 64.0 * U                   # relative det bound that sends a face to the slow path
_CHUNK = 1 << 14                           # faces per chunk: few GIL hand-overs, two workspaces fit in L3


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
    reference, scale_exp, _ = _frame(axes)
    return reference, scale_exp


def _frame(axes):
    """reference_frame of coordinates given as contiguous rows (3, n), and the scaled radius.

    The radius ``max |x − reference| · 2**-scale_exp`` is exact: it comes from
    the bounding box, whose differences from the reference are exact too.
    """
    low = axes.min(axis=1)
    high = axes.max(axis=1)
    reference = np.array([_reference_coordinate(float(lo), float(hi)) for lo, hi in zip(low, high)])
    largest = float((high - low).max())
    scale_exp = _ceil_log2(largest) if largest > 0 else 0
    radius = float(np.maximum(np.abs(high - reference), np.abs(low - reference)).max())
    return reference, scale_exp, math.ldexp(radius, -scale_exp)


def _refined_det(a, b, c):
    """det[a b c] per row from error-free triple products summed in double-double.

    Returns the determinant and an absolute bound on its error.
    """
    (hi, lo), permanent = det_double_double(a, b, c)
    det = hi + lo
    # hi + lo is within DET_ERROR·permanent of det; rounding it to a double adds u|det|.
    bound = U * np.abs(det) + DET_ERROR * permanent
    return det, bound


def _exact_det(a, b, c):
    rows = [[Fraction(float(v)) for v in p] for p in (a, b, c)]
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = rows
    return float(a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0))


# The per-chunk workspace: named blocks of rows (one value per face in each row),
# carved from one flat buffer so every view is contiguous whatever the chunk's
# length.  Whole blocks go through each numpy call (a chunk takes ~30 calls,
# so threads seldom wait for the GIL), and blocks are corner-major, so most
# calls see contiguous operands of one shape: numpy's cheapest kind of call.
# "pairs" reuses the rows of "edges" and "halves", dead by then, so the
# workspace stays smaller and in cache.
_SUMMED_ROWS = {0: 4, 1: 13, 2: 31}       # det, |det|, bound, area; det·u (3×3); det·u_i·u_i, det·u_i·u_i+1
_BLOCKS = (("points", (3, 3)),            # (corner, axis): a, b, c
           ("edges", (2, 5)),             # (edge, axis): b − a, c − a; axes x y z x y, so cyclic shifts are slices
           ("halves", (2, 3)),            # (half, axis): the cross product's two products
           ("normal", (3,)), ("scratch", (3,)),
           ("summed", (_SUMMED_ROWS[2],)))
_OVERLAID = ("pairs", (3, 3), "edges")    # (pair, axis): a + b, b + c, c + a, from where "edges" starts
_WORKSPACE_ROWS = sum(math.prod(shape) for _, shape in _BLOCKS)


def _views(buffer, m):
    """The workspace blocks for a chunk of ``m`` faces, as contiguous views of ``buffer``."""
    views, starts, start = {}, {}, 0
    for name, shape in _BLOCKS:
        size = math.prod(shape) * m
        views[name] = buffer[start:start + size].reshape(*shape, m)
        starts[name] = start
        start += size
    name, shape, over = _OVERLAID
    views[name] = buffer[starts[over]:starts[over] + math.prod(shape) * m].reshape(*shape, m)
    return views


def _chunk_sums(scaled_axes, faces, order, measure, weights, w):
    """Pairwise sums over one chunk of faces, in a preallocated workspace.

    Parameters
    ----------
    scaled_axes : ndarray, shape (3, n), float64
        Scaled vertex coordinates, one contiguous row per axis.
    faces : ndarray, shape (m, 3), int
    w : dict of ndarray
        The workspace views for m faces (:func:`_views`); every operation
        writes into them (no temporaries).

    Returns
    -------
    sums : ndarray
        Σ det, Σ |det|, Σ bound, Σ area, then (order ≥ 1) Σ det·u_i for the
        pairs u = a + b, b + c, c + a, then (order 2) Σ det·u_i·u_i and
        Σ det·u_i·u_(i+1) (the xx, yy, zz and xy, yz, zx terms), each as
        (pair, axis i).  Over the three pairs, Σ u = 2 s and Σ u uᵀ =
        s sᵀ + a aᵀ + b bᵀ + c cᵀ.
    refined, exact : int
        Faces sent to the double-double and to the exact path.
    """
    m = faces.shape[0]
    points = w["points"]
    for corner in range(3):
        np.take(scaled_axes, faces[:, corner], axis=1, out=points[corner], mode="clip")
    summed = w["summed"][:_SUMMED_ROWS[order]]
    det, absolute, bound, area = summed[:4]
    permanent = _cross_product(w, area)
    refined = exact = 0
    if measure == "area":
        _row_sum(permanent, bound)
        bound *= _gamma(6)
        np.multiply(area, _gamma(3), out=det)
        bound += det
        det[:] = area
    else:
        _determinant(w, det, bound)
        refined, exact = _refine_hard_faces(points, det, bound, absolute, w["scratch"][0])
    if weights is not None:
        det[:], bound[:] = _weighted(det, bound, weights)
    if weights is not None or measure == "area":
        np.abs(det, out=absolute)
    if order >= 1:
        _moment_terms(w, det, summed[4:].reshape(-1, 3, 3, m))
    return np.add.reduce(summed, axis=1), refined, exact


def _cross_product(w, area):
    """normal = (b − a) × (c − a) into w["normal"], area = |normal|; returns |p| + |q| per axis."""
    points, edges, halves, normal = w["points"], w["edges"], w["halves"], w["normal"]
    for k in range(2):
        np.subtract(points[k + 1], points[0], out=edges[k, :3])
        np.copyto(edges[k, 3:], edges[k, :2])
    # halves = (e1[i+1]·e2[i+2], e2[i+1]·e1[i+2]) for each axis i: normal is their difference.
    np.multiply(edges[0, 1:4], edges[1, 2:5], out=halves[0])
    np.multiply(edges[1, 1:4], edges[0, 2:5], out=halves[1])
    np.subtract(halves[0], halves[1], out=normal)
    squares = w["scratch"]
    np.multiply(normal, normal, out=squares)
    _row_sum(squares, area)
    np.sqrt(area, out=area)
    np.abs(halves, out=halves)
    permanent = w["pairs"][0]                        # free until the moment terms
    np.add(halves[0], halves[1], out=permanent)
    return permanent


def _determinant(w, det, bound):
    """det = a · normal, and Shewchuk's bound on its error (the permanent from |a|, |p| + |q|)."""
    a, scratch = w["points"][0], w["scratch"]
    np.multiply(a, w["normal"], out=scratch)
    _row_sum(scratch, det)
    np.abs(a, out=scratch)
    scratch *= w["pairs"][0]
    _row_sum(scratch, bound)
    bound *= _DET_BOUND


def _row_sum(rows, out):
    """out = (rows[0] + rows[1]) + rows[2], the order the error bounds assume."""
    np.add(rows[0], rows[1], out=out)
    out += rows[2]


def _refine_hard_faces(points, det, bound, absolute, scratch):
    """Re-evaluate the determinants whose a-priori bound is too large relative to them.

    det is invariant under a cyclic rotation of the corners, but its bound is
    not: a sliver's cross product cancels at the corners whose two edges are
    nearly parallel, and not at the third.  So the other two rotations are
    tried in plain float first; only faces none of them certifies go to
    double-double, and those it cannot certify to exact rationals.
    Writes ``absolute = |det|`` (``scratch`` is a free row).
    """
    np.abs(det, out=absolute)
    np.multiply(absolute, _REFINE_ABOVE, out=scratch)
    hard = np.flatnonzero(bound > scratch)
    if not hard.size:
        return 0, 0
    corners = points[:, :, hard]
    det[hard], bound[hard] = _best_rotation(corners, det[hard], bound[hard])
    absolute[hard] = np.abs(det[hard])
    still_hard = bound[hard] > _REFINE_ABOVE * absolute[hard]
    hard, corners = hard[still_hard], corners[:, :, still_hard]
    if not hard.size:
        return 0, 0
    a, b, c = (corner.T for corner in corners)
    fine, fine_bound = _refined_det(a, b, c)
    still = np.flatnonzero(fine_bound > _REFINE_ABOVE * np.abs(fine))
    for face in still:
        fine[face] = _exact_det(a[face], b[face], c[face])
        fine_bound[face] = U * abs(fine[face])
    det[hard] = fine
    bound[hard] = fine_bound
    absolute[hard] = np.abs(fine)
    return hard.size, still.size


def _best_rotation(corners, det, bound):
    """det and its bound from the corners as given or rotated to start the shortest edge.

    A sliver's cross product cancels at the corners whose two edges are nearly
    parallel, which the ends of its shortest edge are not (unless all its
    corners are: an obtuse sliver).  det is the same for every cyclic rotation.
    Faces without a short edge are left alone: what makes them hard is their
    plane passing near the reference point, which no rotation changes.

    Parameters
    ----------
    corners : ndarray, shape (3, 3, h)
        (corner, axis, face).
    det, bound : ndarray, shape (h,)
        From the corners as given; the smaller bound wins.  Changed in place.
    """
    following = np.take(corners, [1, 2, 0], axis=0)             # (b, c, a)
    lengths = np.square(following - corners).sum(axis=1)         # |b − a|², |c − b|², |a − c|²
    start = np.argmin(lengths, axis=0)
    # Needles whose shortest edge does not already start the face.
    needles = np.flatnonzero((start != 0) & (lengths.max(axis=0) > 4.0 * lengths.min(axis=0)))
    if not needles.size:
        return det, bound
    w = _views(np.empty(_WORKSPACE_ROWS * needles.size), needles.size)
    np.copyto(w["points"], np.take(following[:, :, needles], [1, 2, 0], axis=0))   # (c, a, b)
    np.copyto(w["points"], following[:, :, needles], where=start[needles] == 1)
    rotated_det, rotated_bound, area = w["summed"][0], w["summed"][1], w["summed"][3]
    _cross_product(w, area)
    _determinant(w, rotated_det, rotated_bound)
    better = rotated_bound < bound[needles]
    det[needles[better]] = rotated_det[better]
    bound[needles[better]] = rotated_bound[better]
    return det, bound


def _moment_terms(w, det, terms):
    """det·u, then (order 2) det·u_i·u_i and det·u_i·u_(i+1) per face and pair u, into ``terms``.

    ``terms`` has shape (1 or 3, 3, 3, m): (kind, pair, axis i, face).
    """
    points, pairs = w["points"], w["pairs"]
    np.add(points[:2], points[1:], out=pairs[:2])
    np.add(points[2], points[0], out=pairs[2])
    weighted = terms[0]
    np.multiply(pairs, det, out=weighted)
    if terms.shape[0] > 1:
        np.multiply(weighted, pairs, out=terms[1])
        np.multiply(weighted[:, :2], pairs[:, 1:], out=terms[2, :, :2])
        np.multiply(weighted[:, 2], pairs[:, 0], out=terms[2, :, 2])


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
    reference, scale_exp, radius = _frame(scaled_axes)
    scaled_axes -= reference[:, None]                          # exact (see reference_frame)
    scaled_axes *= math.ldexp(1.0, -scale_exp)                 # exact: a power of two (faster than np.ldexp)
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
    (:func:`massprops.parallel.thread_count`).

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
        buffer = np.empty(_WORKSPACE_ROWS * size)
        full = _views(buffer, size)
        return [_chunk_sums(scaled_axes, faces[start:start + chunk], order, measure,
                            None if weights is None else weights[start:start + chunk],
                            full if faces.shape[0] - start >= size else _views(buffer, faces.shape[0] - start))
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
