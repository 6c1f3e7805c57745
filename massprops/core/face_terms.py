"""One chunk of faces: the integrand's terms per face and their pairwise sums.

The inner loop of :mod:`massprops.core.integrate`, on coordinates already shifted
and scaled there.  Each face's determinant carries Shewchuk's a-priori bound;
faces whose bound is too loose relative to their determinant (slivers,
needles, plates seen edge-on) are re-evaluated here: from a rotation of their
corners, then in double-double, then in exact rationals.  All work happens in
one preallocated workspace of named row blocks (:func:`workspace`), so a chunk
takes ~30 numpy calls and no temporaries.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from .integrate_dd import DET_ERROR, det_double_double
from .rounding import U, gamma

__all__ = ["WORKSPACE_ROWS", "workspace", "chunk_sums"]

DET_BOUND = (7.0 + 56.0 * U) * U           # Shewchuk's o3derrboundA
_REFINE_ABOVE = 64.0 * U                   # relative det bound that sends a face to the slow path


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
WORKSPACE_ROWS = sum(math.prod(shape) for _, shape in _BLOCKS)


def workspace(buffer, m):
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


def chunk_sums(scaled_axes, faces, order, measure, weights, w):
    """Pairwise sums over one chunk of faces, in a preallocated workspace.

    Parameters
    ----------
    scaled_axes : ndarray, shape (3, n), float64
        Scaled vertex coordinates, one contiguous row per axis.
    faces : ndarray, shape (m, 3), int
    w : dict of ndarray
        The workspace views for m faces (:func:`workspace`); every operation
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
        bound *= gamma(6)
        np.multiply(area, gamma(3), out=det)
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
    bound *= DET_BOUND


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
    h = corners.shape[2]
    squares = np.empty((3, 3, h))                                 # (edge, axis, face)
    np.subtract(corners[1:], corners[:2], out=squares[:2])        # b − a, c − b
    np.subtract(corners[0], corners[2], out=squares[2])           # a − c
    np.square(squares, out=squares)
    lengths = squares[:, 0]
    lengths += squares[:, 1]
    lengths += squares[:, 2]
    ab, bc, ca = lengths                                          # squared lengths
    shortest = np.minimum(np.minimum(ab, bc), ca)
    needle = np.maximum(np.maximum(ab, bc), ca) > 4.0 * shortest
    # Needles whose shortest edge does not already start the face (the first shortest wins a tie):
    # at b, rotate to (b, c, a); at c, to (c, a, b).
    groups = (np.flatnonzero(needle & (bc == shortest) & (bc < ab)),
              np.flatnonzero(needle & (ca == shortest) & (ca < ab) & (ca < bc)))
    needles = np.concatenate(groups)
    if not needles.size:
        return det, bound
    w = workspace(np.empty(WORKSPACE_ROWS * needles.size), needles.size)
    start = 0
    for turn, faces in zip((1, 2), groups):
        chosen = np.take(corners, faces, axis=2)
        for corner in range(3):
            w["points"][corner, :, start:start + faces.size] = chosen[(corner + turn) % 3]
        start += faces.size
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
