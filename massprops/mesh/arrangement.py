"""The solid ``{w > 0}`` of a closed triangle soup whose faces cross, touch, coincide or repeat.

A closed soup (every directed edge balanced by its reverse, counting
multiplicity) has a winding number ``w`` at every point off its surface; its
solid is where ``w > 0`` (the SPEC, "What solid a mesh describes").  When
faces meet other than along the vertices and edges they share, the surface
integrals of the faces as given measure ``∫ w dV``, not that solid.  This
module finds the faces that bound it:

1. **Pairs.** The compiled search (:meth:`massprops.core.intersect.ExactGeometry.crossing_pairs`)
   lists every pair of faces that meet beyond what they share.
2. **Cuts.** Each face of a pair is cut along its intersection segments with
   the others (for two faces in one plane, along the other's edges): convex
   cells, split where a segment crosses them.  Intersection points are exact
   rationals (homogeneous integer coordinates on the vertices' power-of-two
   grid), never rounded.
3. **Labels.** Each cell, and each patch of uncut faces joined across edges
   that exactly two faces share, gets the winding numbers on its two sides
   from one exact ray count (Simulation of Simplicity for the ray, so no ray
   direction is ever special); the other side follows from the net weight of
   the faces that lie on the cell.  A piece bounds ``{w > 0}`` exactly when
   one side has ``w > 0`` and the other not; it is taken once (the lowest of
   coincident faces owns it), turned to face out of the solid.
4. **Integrals.** Uncut pieces are whole input faces and go to the compiled
   kernel with its bounds; cells are integrated from their exact rational
   corners (no intersection vertex is rounded), each term to 2**-256 of the
   frame's unit in integers, and added with one rounding.

Every decision is a sign of an exact integer expression.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

__all__ = ["Arrangement", "arrange"]


@dataclass(frozen=True)
class Arrangement:
    """The faces bounding ``{w > 0}`` of a soup, and what it took to find them.

    Attributes
    ----------
    faces : ndarray, shape (k, 3), int64
        Whole input faces that bound the solid, wound out of it.
    exact : tuple
        ``(det, first, second, error)``: the signed-tetrahedron sums (see
        :mod:`massprops.core.moments`) of the cut pieces that bound the solid,
        in the scaled coordinates of the geometry's frame, as Fractions
        (``first`` a list of 3, ``second`` 3 × 3), each within ``error`` of
        the exact rational sum.
    area2 : float
        About twice the area of those cut pieces.
    cut_faces, cells : int
        Faces that were cut, and the cells they were cut into.
    negative : bool
        Some region has a negative winding number (a surface wound inward
        outside every other): it is not solid.
    """

    faces: np.ndarray
    exact: tuple
    area2: float
    cut_faces: int
    cells: int
    negative: bool


class _Degenerate(Exception):
    """A query point lies on a surface it must not lie on; another point is tried."""


def _sign(x):
    return (x > 0) - (x < 0)


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _reduced(x, y, z, w):
    """A homogeneous point with ``w > 0`` and no common factor."""
    if w < 0:
        x, y, z, w = -x, -y, -z, -w
    g = math.gcd(math.gcd(x, y), math.gcd(z, w))
    if g > 1:
        x, y, z, w = x // g, y // g, z // g, w // g
    return (x, y, z, w)


def _orient2(p, q, r, i, j):
    """Sign-carrying orientation of homogeneous points p, q, r (w > 0) projected on axes i, j."""
    return (p[i] * (q[j] * r[3] - q[3] * r[j]) - p[j] * (q[i] * r[3] - q[3] * r[i])
            + p[3] * (q[i] * r[j] - q[j] * r[i]))


class _Soup:
    """The faces as integers on one power-of-two grid, with the exact tests the arrangement needs."""

    def __init__(self, geometry, faces, weights):
        scaled = geometry.vertices
        self.faces = faces
        self.weights = weights
        mantissa, exponent = np.frexp(scaled)
        whole = (mantissa * 2.0 ** 53).astype(np.int64)
        nonzero = whole != 0
        self.exponent = int((exponent[nonzero] - 53).min()) if nonzero.any() else 0
        self._whole, self._shift = whole, np.where(nonzero, exponent - 53 - self.exponent, 0)
        self._points = {}
        self._planes = {}
        corners = scaled[faces]
        self.low = corners.min(axis=1)
        self.high = corners.max(axis=1)
        self.scaled = scaled

    def point(self, v):
        """Vertex ``v`` as integers (3)."""
        found = self._points.get(v)
        if found is None:
            found = tuple(int(m) << int(s) for m, s in zip(self._whole[v].tolist(), self._shift[v].tolist()))
            self._points[v] = found
        return found

    def plane(self, t):
        """Corners (3 integer points), normal and offset of face ``t``: ``n · x = d`` on its plane."""
        found = self._planes.get(t)
        if found is None:
            a, b, c = (self.point(int(v)) for v in self.faces[t])
            normal = _cross(_sub(b, a), _sub(c, a))
            found = ((a, b, c), normal, _dot(normal, a))
            self._planes[t] = found
        return found

    # -- winding numbers -----------------------------------------------------------------------

    def winding(self, p, axis, sigma, plane_normal):
        """The winding number at ``p + sigma (ε e1 + ε² e2)`` for an infinitesimal ε > 0.

        ``p`` is homogeneous (integers, w > 0) and lies on a face of normal
        ``plane_normal`` (or on none); e1, e2 are the axes after ``axis``.  The
        ray from the perturbed point runs along +``axis``; each face it crosses
        ahead counts its weight, + when it leaves through the face's front.
        Faces in the query's own plane are crossed or not by the perturbation
        alone.  Raises :class:`_Degenerate` when ``p`` lies on another face.
        """
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3
        x, y, z, w = p
        unit = math.ldexp(1.0, self.exponent)
        pf = (x / w * unit, y / w * unit, z / w * unit)      # the boxes are in scaled coordinates
        margin = 1e-9 * (1.0 + max(abs(pf[0]), abs(pf[1]), abs(pf[2])))
        low, high = self.low, self.high
        near = np.flatnonzero((low[:, a1] <= pf[a1] + margin) & (high[:, a1] >= pf[a1] - margin)
                              & (low[:, a2] <= pf[a2] + margin) & (high[:, a2] >= pf[a2] - margin)
                              & (high[:, axis] >= pf[axis] - margin))
        px, py = p[a1], p[a2]
        total = 0
        for t in near.tolist():
            (a, b, c), normal, offset = self.plane(t)
            facing = _sign(normal[axis])
            level = _dot(normal, (x, y, z)) - offset * w        # sign of n · (p - a), times w > 0
            if level == 0 and _cross(normal, plane_normal) != (0, 0, 0):
                drop = max(range(3), key=lambda k: abs(normal[k]))
                if self._holds(a, b, c, p, (drop + 1) % 3, (drop + 2) % 3):
                    raise _Degenerate          # p on another face: which side it is on is not determined
            if facing == 0:
                continue
            inside = True
            for u, v in ((a, b), (b, c), (c, a)):
                o = (w * u[a1] - px) * (w * v[a2] - py) - (w * u[a2] - py) * (w * v[a1] - px)
                if o == 0:
                    o = sigma * (u[a2] - v[a2]) or sigma * (v[a1] - u[a1])
                if _sign(o) != facing:
                    inside = False
                    break
            if not inside:
                continue
            side = _sign(level) or sigma * (_sign(normal[a1]) or _sign(normal[a2]))
            if side == 0:
                raise _Degenerate
            if -side * facing > 0:                               # the crossing lies ahead of p
                total += int(self.weights[t]) * facing
        return total

    @staticmethod
    def _holds(a, b, c, p, a1, a2):
        """Whether the projection of ``p`` lies in the closed projected triangle (a, b, c)."""
        w = p[3]
        signs = set()
        for u, v in ((a, b), (b, c), (c, a)):
            o = (w * u[a1] - p[a1]) * (w * v[a2] - p[a2]) - (w * u[a2] - p[a2]) * (w * v[a1] - p[a1])
            signs.add(_sign(o))
        return not (1 in signs and -1 in signs)


# -- intersections of two faces ----------------------------------------------------------------

def _on_plane(corners, normal, offset):
    """The points of a triangle on a plane (homogeneous, each once): vertices on it, edges crossing it."""
    levels = [_dot(normal, q) - offset for q in corners]
    if all(s > 0 for s in levels) or all(s < 0 for s in levels):
        return []
    points = [(*q, 1) for q, s in zip(corners, levels) if s == 0]
    for i, j in ((0, 1), (1, 2), (2, 0)):
        si, sj = levels[i], levels[j]
        if (si > 0 and sj < 0) or (si < 0 and sj > 0):
            qi, qj = corners[i], corners[j]
            points.append(_reduced(si * qj[0] - sj * qi[0], si * qj[1] - sj * qi[1], si * qj[2] - sj * qi[2],
                                   si - sj))
    return points


def _span(points, axis):
    """The two extreme points along ``axis`` (homogeneous, w > 0)."""
    low = high = points[0]
    for q in points[1:]:
        if q[axis] * low[3] < low[axis] * q[3]:
            low = q
        if q[axis] * high[3] > high[axis] * q[3]:
            high = q
    return low, high


def _crossing(soup, t, u):
    """``(segment or None, coplanar)``: where faces ``t`` and ``u`` meet, as a segment (two homogeneous points)."""
    corners_t, normal_t, offset_t = soup.plane(t)
    corners_u, normal_u, offset_u = soup.plane(u)
    direction = _cross(normal_t, normal_u)
    if direction == (0, 0, 0):
        if _dot(normal_t, corners_u[0]) == offset_t:
            return None, True
        return None, False                       # parallel planes: they do not meet
    on_t = _on_plane(corners_u, normal_t, offset_t)
    on_u = _on_plane(corners_t, normal_u, offset_u)
    if not on_t or not on_u:
        return None, False
    axis = max(range(3), key=lambda k: abs(direction[k]))
    low_t, high_t = _span(on_t, axis)
    low_u, high_u = _span(on_u, axis)
    low = low_t if low_t[axis] * low_u[3] >= low_u[axis] * low_t[3] else low_u
    high = high_t if high_t[axis] * high_u[3] <= high_u[axis] * high_t[3] else high_u
    if low[axis] * high[3] >= high[axis] * low[3]:
        return None, False                       # a point or nothing: no face is cut
    return (low, high), False


# -- cells of one face ---------------------------------------------------------------------------

def _split(cell, segment, i, j):
    """Cut a convex cell (homogeneous points, one turning sense) by the line of ``segment`` where it crosses it."""
    p, q = segment
    values = [_orient2(p, q, v, i, j) for v in cell]
    if not (any(v > 0 for v in values) and any(v < 0 for v in values)):
        return None
    sense = _sign(_orient2(cell[0], cell[1], cell[2], i, j))
    count = len(cell)
    for k in range(count):
        a, b = cell[k], cell[(k + 1) % count]
        if sense * _orient2(a, b, p, i, j) <= 0 and sense * _orient2(a, b, q, i, j) <= 0:
            return None                          # the segment stays outside this edge: it misses the cell
    left, right = [], []
    for k in range(count):
        a, b = cell[k], cell[(k + 1) % count]
        va, vb = values[k], values[(k + 1) % count]
        if va >= 0:
            left.append(a)
        if va <= 0:
            right.append(a)
        if (va > 0 and vb < 0) or (va < 0 and vb > 0):
            # va, vb are the line's affine values times a's and b's w (and one positive constant)
            x = _reduced(va * b[0] - vb * a[0], va * b[1] - vb * a[1], va * b[2] - vb * a[2], va * b[3] - vb * a[3])
            left.append(x)
            right.append(x)
    return left, right


def _cells(corners, segments, normal):
    """The convex cells a face is cut into by its segments."""
    drop = max(range(3), key=lambda k: abs(normal[k]))
    i, j = (drop + 1) % 3, (drop + 2) % 3
    cells = [[(*q, 1) for q in corners]]
    for segment in segments:
        out = []
        for cell in cells:
            halves = _split(cell, segment, i, j)
            if halves is None:
                out.append(cell)
            else:
                out.extend(halves)
        cells = out
    return cells, (i, j)


def _inner_point(cell, weights=(1, 1, 1)):
    """A point inside a convex cell: a weighted mean of three consecutive corners (homogeneous)."""
    (a, b, c), (wa, wb, wc) = cell[:3], weights
    d = a[3] * b[3] * c[3]
    x = [wa * a[k] * b[3] * c[3] + wb * b[k] * a[3] * c[3] + wc * c[k] * a[3] * b[3] for k in range(3)]
    return _reduced(*x, (wa + wb + wc) * d)


def _contains(corners, p, i, j):
    """Whether homogeneous ``p`` lies strictly inside the projected triangle ``corners`` (axes i, j)."""
    a, b, c = ((*q, 1) for q in corners)
    sense = _sign(_orient2(a, b, c, i, j))
    return all(sense * _orient2(u, v, p, i, j) > 0 for u, v in ((a, b), (b, c), (c, a)))


# -- exact integrals -----------------------------------------------------------------------------

class _Sums:
    """Signed-tetrahedron sums (det, first, second) of triangles with homogeneous corners, in fixed point.

    Each term, a rational, is taken to ``2**-FRACTION_BITS`` of the frame's
    scaled unit (rounded down, in integers), so the sums stay integers; every
    term adds less than one such unit of error, and :attr:`error` counts them.
    """

    FRACTION_BITS = 256

    def __init__(self, exponent):
        self.exponent = exponent           # grid unit = 2**exponent scaled units
        self.det = 0
        self.first = [0, 0, 0]
        self.second = [[0] * 3 for _ in range(3)]
        self.terms = 0
        self.area2 = 0.0

    def _fixed(self, numerator, denominator, power):
        """floor(numerator / denominator · 2**(power · exponent) · 2**FRACTION_BITS)."""
        shift = self.FRACTION_BITS + power * self.exponent
        if shift >= 0:
            return (numerator << shift) // denominator
        return numerator // (denominator << -shift)

    def add_polygon(self, cell, sign):
        for k in range(1, len(cell) - 1):
            self._add(cell[0], cell[k], cell[k + 1], sign)

    def _add(self, p, q, r, sign):
        wp, wq, wr = p[3], q[3], r[3]
        d = wp * wq * wr
        a = [p[k] * wq * wr for k in range(3)]
        b = [q[k] * wp * wr for k in range(3)]
        c = [r[k] * wp * wq for k in range(3)]
        det = sign * (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                      + a[2] * (b[0] * c[1] - b[1] * c[0]))
        if det == 0:
            return
        s = [a[k] + b[k] + c[k] for k in range(3)]
        d3 = d * d * d
        d4 = d3 * d
        d5 = d4 * d
        self.det += self._fixed(det, d3, 3)
        for k in range(3):
            self.first[k] += self._fixed(det * s[k], d4, 4)
            for m in range(k, 3):
                value = self._fixed(det * (s[k] * s[m] + a[k] * a[m] + b[k] * b[m] + c[k] * c[m]), d5, 5)
                self.second[k][m] += value
                if m != k:
                    self.second[m][k] += value
        self.terms += 1
        u = [(b[k] - a[k]) / d for k in range(3)]
        v = [(c[k] - a[k]) / d for k in range(3)]
        n = _cross(u, v)
        self.area2 += math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) * math.ldexp(1.0, 2 * self.exponent)

    def exact(self):
        """``(det, first, second, error)``: the sums as Fractions (scaled units) and a bound on each one's error."""
        unit = Fraction(1, 1 << self.FRACTION_BITS)
        return (self.det * unit, [x * unit for x in self.first], [[x * unit for x in row] for row in self.second],
                self.terms * unit)


# -- the arrangement -----------------------------------------------------------------------------

def _query(soup, t, p, normal):
    """Winding number just in front of face ``t``'s plane at ``p``."""
    axis = min(range(3), key=lambda k: abs(normal[k]))
    a1, a2 = (axis + 1) % 3, (axis + 2) % 3
    sigma = _sign(normal[a1]) or _sign(normal[a2])
    return soup.winding(p, axis, sigma, normal)


_TRIES = ((1, 1, 1), (1, 2, 3), (3, 1, 2), (2, 3, 1), (1, 3, 7), (5, 1, 2))


def _label_cell(soup, t, cell, normal, partners, i, j):
    """``(w in front, net weight on the cell, owned)`` for a cell of face ``t``."""
    for weights in _TRIES:
        p = _inner_point(cell, weights)
        net, owned = int(soup.weights[t]), True
        for u in partners:
            corners_u, normal_u, _ = soup.plane(u)
            if _contains(corners_u, p, i, j):
                net += int(soup.weights[u]) * _sign(_dot(normal_u, normal))
                owned = owned and u > t
        try:
            return _query(soup, t, p, normal), net, owned
        except _Degenerate:
            continue
    raise _Degenerate


def _patches(faces, cut):
    """Groups of uncut faces joined across edges that exactly two faces use, once each way."""
    m = faces.shape[0]
    directed = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    owner = np.repeat(np.arange(m), 3)
    low = np.minimum(directed[:, 0], directed[:, 1])
    high = np.maximum(directed[:, 0], directed[:, 1])
    order = np.lexsort((high, low))
    low, high, owner, forward = low[order], high[order], owner[order], (directed[order, 0] < directed[order, 1])
    starts = np.flatnonzero(np.r_[True, (low[1:] != low[:-1]) | (high[1:] != high[:-1])])
    counts = np.diff(np.r_[starts, low.size])
    pairs = starts[counts == 2]
    a, b = owner[pairs], owner[pairs + 1]
    keep = (forward[pairs] != forward[pairs + 1]) & ~cut[a] & ~cut[b]
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    graph = coo_matrix((np.ones(int(keep.sum())), (a[keep], b[keep])), shape=(m, m))
    return connected_components(graph, directed=False)[1]


def arrange(geometry, faces, weights, pairs):
    """The faces and cut pieces that bound ``{w > 0}`` (see the module docstring).

    Parameters
    ----------
    geometry : massprops.core.intersect.ExactGeometry
        The soup's vertices in their exact frame.
    faces : ndarray, shape (m, 3), int64
        Distinct faces (no two on the same three vertices).
    weights : ndarray, shape (m,), int64
        How many times each face counts (its copies in the soup), at least 1.
    pairs : ndarray, shape (p, 2), int64
        Every pair of faces that meet beyond what they share.

    Returns
    -------
    Arrangement
    """
    soup = _Soup(geometry, faces, weights)
    m = faces.shape[0]
    segments = {}
    partners = {}
    for t, u in pairs.tolist():
        segment, coplanar = _crossing(soup, t, u)
        if coplanar:
            partners.setdefault(t, []).append(u)
            partners.setdefault(u, []).append(t)
            for x, y in ((t, u), (u, t)):
                corners = soup.plane(y)[0]
                segments.setdefault(x, []).extend(((*corners[k], 1), (*corners[(k + 1) % 3], 1)) for k in range(3))
        elif segment is not None:
            segments.setdefault(t, []).append(segment)
            segments.setdefault(u, []).append(segment)
    cut = np.zeros(m, dtype=bool)
    cut[list(segments)] = True
    sums = _Sums(soup.exponent)
    negative = False
    n_cells = 0
    for t, its_segments in segments.items():
        corners, normal, _ = soup.plane(t)
        cells, (i, j) = _cells(corners, its_segments, normal)
        n_cells += len(cells)
        for cell in cells:
            front, net, owned = _label_cell(soup, t, cell, normal, partners.get(t, ()), i, j)
            back = front + net
            negative = negative or front < 0 or back < 0
            if owned and (front > 0) != (back > 0):
                sums.add_polygon(cell, 1 if back > 0 else -1)
    kept = []
    uncut = np.flatnonzero(~cut)
    if uncut.size:
        labels = _patches(faces, cut)
        first = {}
        for t in uncut.tolist():
            first.setdefault(int(labels[t]), t)
        side = {}
        for label, t in first.items():
            corners, normal, _ = soup.plane(t)
            a, b, c = corners
            p = _reduced(a[0] + b[0] + c[0], a[1] + b[1] + c[1], a[2] + b[2] + c[2], 3)
            front = _query(soup, t, p, normal)
            back = front + int(weights[t])
            negative = negative or front < 0 or back < 0
            side[label] = 0 if (front > 0) == (back > 0) else (1 if back > 0 else -1)
        signs = np.array([side[int(label)] for label in labels[uncut]], dtype=np.int64)
        kept_faces = faces[uncut]
        kept = [kept_faces[signs > 0], kept_faces[signs < 0][:, ::-1]]
    out = np.vstack(kept).astype(np.int64) if kept else np.zeros((0, 3), dtype=np.int64)
    return Arrangement(out, sums.exact(), sums.area2, int(cut.sum()), n_cells, negative)
