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
   cells, split where a segment crosses them.  The compiled core cuts first
   (:class:`_Compiled`: intersection points kept implicit, every sign settled
   by a certified filter, symbolically or exactly); the faces it hands back
   are cut here, where intersection points are exact rationals (homogeneous
   integer coordinates on the vertices' power-of-two grid).  No decision
   uses a rounded point.  ``arrange(..., compiled=False)`` cuts every face
   here: the reference.
3. **Labels.** Each cell, and each patch of uncut faces joined across edges
   that exactly two faces share, gets the winding numbers on its two sides
   from one exact ray count (Simulation of Simplicity for the ray, so no ray
   direction is ever special; counted in the compiled core where its filter
   settles every face the ray may meet, here otherwise); the other side follows from the net weight of
   the faces that lie on the cell.  A piece bounds ``{w > 0}`` exactly when
   one side has ``w > 0`` and the other not; it is taken once (the lowest of
   coincident faces owns it), turned to face out of the solid.
4. **Integrals.**  Uncut pieces are whole input faces; cut pieces are
   triangulated cells whose new corners (the intersection points) are
   rounded once, each with its rounding error found exactly.  Both go to the compiled kernel with its
   bounds, widened by the volume the rounded corners could sweep
   (:func:`massprops.mesh.solid.swept_volume` with an apex: the cut pieces
   need not share their corners, so each triangle is bounded on its own).

Every decision is a sign of an exact integer expression.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.intersect import _PARALLEL_ABOVE, _extension
from ..core.threads import thread_count
from ..model.errors import MassPropsError

__all__ = ["Arrangement", "ArrangementError", "arrange"]


@dataclass(frozen=True)
class Arrangement:
    """The faces bounding ``{w > 0}`` of a soup, and what it took to find them.

    Attributes
    ----------
    faces : ndarray, shape (k, 3), int64
        Whole input faces that bound the solid, wound out of it.
    pieces : ndarray, shape (c, 3), int64
        Triangles of the cut pieces that bound the solid, wound out of it:
        indices below ``n`` (the geometry's vertex count) are input vertices,
        ``n + i`` is ``points[i]``.
    points : ndarray, shape (q, 3), float64
        The new corners (intersection points), each coordinate its exact
        rational value rounded to nearest, in the geometry's scaled frame.
    rounding : ndarray, shape (q, 3), float64
        An upper bound on each coordinate's rounding (0 where it is exact).
    negative : bool
        Some region has a negative winding number (a surface wound inward
        outside every other): it is not solid.
    """

    faces: np.ndarray
    pieces: np.ndarray
    points: np.ndarray
    rounding: np.ndarray
    negative: bool


class _Degenerate(Exception):
    """A query point lies on a surface it must not lie on; another point is tried."""


class ArrangementError(MassPropsError, ArithmeticError):
    """No query point could be found off the other faces for some piece (never seen)."""


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
    g = math.gcd(x, y, z, w)
    if g > 1:
        x, y, z, w = x // g, y // g, z // g, w // g
    return (x, y, z, w)


def _turn(u, v, p, a1, a2):
    """Orientation of integer points ``u``, ``v`` and homogeneous ``p`` (w > 0) seen on axes a1, a2, times w²."""
    w = p[3]
    return (w * u[a1] - p[a1]) * (w * v[a2] - p[a2]) - (w * u[a2] - p[a2]) * (w * v[a1] - p[a1])


def _orient2(p, q, r, i, j):
    """Sign-carrying orientation of homogeneous points p, q, r (w > 0) projected on axes i, j."""
    return (p[i] * (q[j] * r[3] - q[3] * r[j]) - p[j] * (q[i] * r[3] - q[3] * r[i])
            + p[3] * (q[i] * r[j] - q[j] * r[i]))


class _Soup:
    """The faces as integers on one power-of-two grid, with the exact tests the arrangement needs."""

    def __init__(self, geometry, faces, weights):
        self.faces = faces
        self.weights = weights
        self._exponent = None                   # the integer grid is made when the exact path first asks
        self._points = {}
        self._planes = {}
        self.scaled = geometry.vertices
        self._columns = {}
        self._boxes = None

    @property
    def exponent(self):
        """The grid's unit is ``2**exponent``: every coordinate is an integer multiple of it."""
        if self._exponent is None:
            mantissa, exponent = np.frexp(self.scaled)
            whole = (mantissa * 2.0 ** 53).astype(np.int64)
            nonzero = whole != 0
            self._exponent = int((exponent[nonzero] - 53).min()) if nonzero.any() else 0
            self._whole, self._shift = whole, np.where(nonzero, exponent - 53 - self._exponent, 0)
        return self._exponent

    def _floats(self):
        """The faces' corners and boxes in floating point, for :meth:`_near` (made when first asked)."""
        if self._boxes is None:
            corners = self.scaled[self.faces]
            self.low = corners.min(axis=1)
            self.high = corners.max(axis=1)
            # Every query's box margin (below) is at most this one: the columns may only add candidates.
            self._reach = 1.0 + float(np.abs(self.scaled).max(initial=0.0))
            self._margin = 2e-9 * self._reach
            self._corners = corners
            self._weights_float = self.weights.astype(np.float64)
            self._boxes = True

    def point(self, v):
        """Vertex ``v`` as integers (3)."""
        found = self._points.get(v)
        if found is None:
            self.exponent                       # noqa: B018 - makes the grid
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

    def windings(self, queries):
        """Winding numbers of many queries at once; None where a query point lies on another face.

        Each query is ``(p, axis, sigma, plane_normal)``: the winding number at
        ``p + sigma (ε e1 + ε² e2)`` for an infinitesimal ε > 0, where ``p`` is
        homogeneous (integers, w > 0) and lies on a face of normal
        ``plane_normal`` (or on none) and e1, e2 are the axes after ``axis``.
        The ray from the perturbed point runs along +``axis``; each face it
        crosses ahead counts its weight, + when it leaves through the face's
        front.  Faces in the query's own plane are crossed or not by the
        perturbation alone.  The faces near each ray are found in floating
        point with margins (:meth:`_near`); every count is exact.
        """
        totals = [0] * len(queries)
        for index, decided, faces in self._near(queries):
            p, axis, sigma, plane_normal = queries[index]
            try:
                totals[index] = decided + sum(self._ahead(t, p, axis, sigma, plane_normal) for t in faces)
            except _Degenerate:
                totals[index] = None
        return totals

    def _ahead(self, t, p, axis, sigma, plane_normal):
        """Weight face ``t`` adds to the winding number of the query (0 when the ray misses it)."""
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3
        x, y, z, w = p
        (a, b, c), normal, offset = self.plane(t)
        facing = _sign(normal[axis])
        level = _dot(normal, (x, y, z)) - offset * w        # sign of n · (p - a), times w > 0
        if level == 0 and _cross(normal, plane_normal) != (0, 0, 0):
            drop = max(range(3), key=lambda k: abs(normal[k]))
            if self._holds(a, b, c, p, (drop + 1) % 3, (drop + 2) % 3):
                raise _Degenerate          # p on another face: which side it is on is not determined
        if facing == 0:
            return 0
        for u, v in ((a, b), (b, c), (c, a)):
            o = _turn(u, v, p, a1, a2)
            if o == 0:
                o = sigma * (u[a2] - v[a2]) or sigma * (v[a1] - u[a1])
            if _sign(o) != facing:
                return 0
        side = _sign(level) or sigma * (_sign(normal[a1]) or _sign(normal[a2]))
        if side == 0:
            raise _Degenerate
        return int(self.weights[t]) * facing if -side * facing > 0 else 0     # the crossing lies ahead of p

    _CHUNK = 4096

    def _near(self, queries):
        """``(query index, decided, faces)`` for every query: the faces its ray may meet or its point
        may lie on, and the weight already counted for faces decided in floating point.

        A face is left out when its box (widened by a margin far above the
        rounding of the query point) misses the ray, or when two of its edges,
        seen along the ray, certainly put the point on opposite sides
        (:meth:`_crossed`): then it neither holds the point nor is crossed.  A
        face whose edges certainly put the point strictly inside, and whose
        plane the ray certainly meets ahead of or behind the point, is counted
        here; every other face is left to the exact test.
        """
        unit = math.ldexp(1.0, self.exponent)
        self._floats()
        for axis in range(3):
            mine = [k for k, q in enumerate(queries) if q[1] == axis]
            a1, a2 = (axis + 1) % 3, (axis + 2) % 3
            for start in range(0, len(mine), self._CHUNK):
                chunk = mine[start:start + self._CHUNK]
                # Each coordinate correctly rounded (int / int), then scaled by a power of two: exact.
                pf = np.array([(p[0] / p[3], p[1] / p[3], p[2] / p[3]) for p, *_ in (queries[k] for k in chunk)],
                              dtype=np.float64) * unit
                query, faces = self._column(axis, len(mine)).pairs(pf[:, a1], pf[:, a2])
                margin = 1e-9 * (1.0 + np.abs(pf).max(axis=1))[query]
                point = pf[query]
                low, high = self.low[faces], self.high[faces]
                keep = ((low[:, a1] <= point[:, a1] + margin) & (high[:, a1] >= point[:, a1] - margin)
                        & (low[:, a2] <= point[:, a2] + margin) & (high[:, a2] >= point[:, a2] - margin)
                        & (high[:, axis] >= point[:, axis] - margin))
                query, faces, point = query[keep], faces[keep], point[keep]
                crossed = self._crossed(faces, point, axis)
                keep = np.isnan(crossed)
                decided = np.bincount(query, weights=np.where(keep, 0.0, crossed),
                                      minlength=len(chunk)).astype(np.int64).tolist()
                query, faces = query[keep], faces[keep]
                bounds = np.searchsorted(query, np.arange(len(chunk) + 1))
                faces = faces.tolist()
                for k, index in enumerate(chunk):
                    yield index, decided[k], faces[bounds[k]:bounds[k + 1]]

    _EDGES = np.array([1, 2, 0])

    def _crossed(self, faces, points, axis):
        """Per (face, point) pair: the weight the ray adds, 0 when it certainly misses, NaN when undecided.

        Points are the query points rounded to nearest (relative error at most
        u = 2**-53) and corners are exact.  Each computed edge value
        ``o = x₁ y₂ - y₁ x₂`` is within ``u (R (|x₁|+|x₂|+|y₁|+|y₂|) + 5 (|x₁ y₂| + |y₁ x₂|))``
        plus terms of order u² of the exact one (R bounds every coordinate);
        the bound ``B`` used is about a thousand times that.  Two edges beyond
        ``±B`` of opposite signs: the point is strictly outside the face seen
        along the ray, so the face neither holds it nor is crossed.  Three of
        one sign: strictly inside, and the face faces that way.  Then the
        plane's height over the point, ``Σ λᵢ dᵢ`` with ``λᵢ = oᵢ / Σ o``,
        has relative error at most ``2 max(B/|o|)`` plus rounding in each term;
        beyond that bound the ray certainly meets the plane ahead (counted) or
        behind (not), and the point is not on the face.
        """
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3
        corners = self._corners[faces]
        x = corners[:, :, a1] - points[:, a1, None]
        y = corners[:, :, a2] - points[:, a2, None]
        xn, yn = x[:, self._EDGES], y[:, self._EDGES]
        first, second = x * yn, y * xn
        value = first - second                         # value[:, k]: edge from corner k to k+1
        reach = self._reach
        bound = 1e-13 * (reach * (np.abs(x) + np.abs(y) + np.abs(xn) + np.abs(yn))
                         + np.abs(first) + np.abs(second) + reach * reach * 1e-13)
        positive, negative = value > bound, value < -bound
        out = np.full(faces.shape[0], np.nan)
        out[positive.any(axis=1) & negative.any(axis=1)] = 0.0
        inside = positive.all(axis=1) | negative.all(axis=1)
        if inside.any():
            v = value[inside]
            # The edge opposite corner k is the one from k+1 to k+2: λ_k = value[:, k+1] / Σ value.
            weight = v[:, self._EDGES] / v.sum(axis=1)[:, None]
            relative = (bound[inside] / np.abs(v)).max(axis=1)
            height = corners[inside, :, axis] - points[inside, axis, None]
            hit = (weight * height).sum(axis=1)
            error = (np.abs(weight) * (np.abs(height) * (2.0 * relative[:, None] + 1e-13) + 1e-13 * reach)).sum(axis=1)
            facing = np.where(positive[inside].all(axis=1), 1.0, -1.0)
            sure = np.abs(hit) > error
            counted = np.where(hit > 0, facing * self._weights_float[faces[inside]], 0.0)
            out[np.flatnonzero(inside)[sure]] = counted[sure]
        return out

    def _column(self, axis, queries):
        """Faces bucketed by their boxes seen along ``axis`` (built once per axis, for about ``queries`` rays)."""
        columns = self._columns.get(axis)
        if columns is None:
            columns = self._columns[axis] = _Columns(self.low, self.high, axis, self._margin, queries)
        return columns

    @staticmethod
    def _holds(a, b, c, p, a1, a2):
        """Whether the projection of ``p`` lies in the closed projected triangle (a, b, c)."""
        signs = {_sign(_turn(u, v, p, a1, a2)) for u, v in ((a, b), (b, c), (c, a))}
        return not (1 in signs and -1 in signs)


class _Columns:
    """Faces bucketed by their boxes seen along one axis: a uniform grid of columns (CSR lists).

    A face is listed in every column its box, widened by ``margin``, meets;
    columns are found with floating-point operations, which are monotone, so a
    point inside a widened box always falls in one of that box's columns.
    """

    def __init__(self, low, high, axis, margin, queries):
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3
        lo = low[:, [a1, a2]] - margin
        hi = high[:, [a1, a2]] + margin
        self.origin = lo.min(axis=0) if lo.size else np.zeros(2)
        extent = (hi.max(axis=0) - self.origin) if lo.size else np.ones(2)
        count = lo.shape[0]
        # About four columns a ray (listing faces costs about what scanning them would), at most 256 a side.
        side = max(1, min(int(math.sqrt(count / 4.0)), int(2 * math.sqrt(queries)) + 1, 256))
        while True:
            self.size = np.maximum(extent / side, np.finfo(float).tiny)
            first = self._index(lo, side)
            last = self._index(hi, side)
            spans = (last - first + 1)
            per_face = spans[:, 0] * spans[:, 1]
            if side == 1 or per_face.sum() <= 16 * count:
                break
            side = max(1, side // 2)                # large faces: fewer, larger columns
        self.side = side
        owner = np.repeat(np.arange(count), per_face)
        offset = np.arange(owner.size) - np.repeat(np.cumsum(per_face) - per_face, per_face)
        width = spans[owner, 1]
        cx = first[owner, 0] + offset // width
        cy = first[owner, 1] + offset % width
        cell = cx * side + cy
        order = np.argsort(cell.astype(np.uint16), kind="stable")         # below 2**16 columns: a radix sort
        self.faces = owner[order]
        self.starts = np.searchsorted(cell[order], np.arange(side * side + 1))

    def _index(self, points, side):
        return np.clip(np.floor((points - self.origin) / self.size), 0, side - 1).astype(np.int64)

    def pairs(self, x, y):
        """``(query, face)`` index pairs (sorted by query): the faces listed in each point's column."""
        i = np.clip(np.floor((x - self.origin[0]) / self.size[0]), 0, self.side - 1).astype(np.int64)
        j = np.clip(np.floor((y - self.origin[1]) / self.size[1]), 0, self.side - 1).astype(np.int64)
        cell = i * self.side + j
        begin, count = self.starts[cell], self.starts[cell + 1] - self.starts[cell]
        query = np.repeat(np.arange(cell.size), count)
        position = np.arange(query.size) - np.repeat(np.cumsum(count) - count, count) + begin[query]
        return query, self.faces[position]


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


def _box(points, i, j):
    """The box (low_i, high_i, low_j, high_j) of homogeneous points on axes i, j, widened past any rounding."""
    xs = [p[i] / p[3] for p in points]
    ys = [p[j] / p[3] for p in points]
    low_x, high_x, low_y, high_y = min(xs), max(xs), min(ys), max(ys)
    pad = 1e-9 * (abs(low_x) + abs(high_x) + abs(low_y) + abs(high_y)) + 1e-300
    return low_x - pad, high_x + pad, low_y - pad, high_y + pad


def _apart(a, b):
    return a[1] < b[0] or b[1] < a[0] or a[3] < b[2] or b[3] < a[2]


def _cells(corners, segments, normal):
    """The convex cells a face is cut into by its segments.

    A segment whose box (each coordinate correctly rounded, then widened)
    misses a cell's box misses the cell: the exact test is skipped.
    """
    drop = max(range(3), key=lambda k: abs(normal[k]))
    i, j = (drop + 1) % 3, (drop + 2) % 3
    first = [(*q, 1) for q in corners]
    boxed = len(segments) > 3                  # with few segments the boxes cost more than the tests they save
    cells = [(first, _box(first, i, j) if boxed else None)]
    for segment in segments:
        reach = _box(segment, i, j) if boxed else None
        out = []
        for cell, box in cells:
            halves = None if boxed and _apart(box, reach) else _split(cell, segment, i, j)
            if halves is None:
                out.append((cell, box))
            else:
                out.extend((half, _box(half, i, j) if boxed else None) for half in halves)
        cells = out
    return [cell for cell, _ in cells], (i, j)


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


class _Corners:
    """Corners of the kept pieces: input vertices by index, intersection points numbered after them."""

    def __init__(self, soup, before=0):
        self.soup = soup
        self.vertices = {(*q, 1): v for v, q in soup._points.items()}
        self.count = soup.scaled.shape[0] + before      # ``before`` new corners are numbered ahead of these
        self.new = {}

    def index(self, q):
        found = self.vertices.get(q)
        if found is None:
            found = self.new.setdefault(q, self.count + len(self.new))
        return found

    def add_polygon(self, cell, triangles, outward):
        ids = [self.index(q) for q in (cell if outward else cell[::-1])]
        triangles.extend((ids[0], ids[k], ids[k + 1]) for k in range(1, len(ids) - 1))

    def points(self):
        """The new corners in scaled coordinates, each rounded to nearest, and each coordinate's rounding error.

        ``x / w`` of two ints is correctly rounded; times a power of two it
        stays exact.  The error ``|x/w - r|`` is found exactly in integers and
        rounded up.
        """
        if not self.new:
            return np.zeros((0, 3)), np.zeros((0, 3))
        unit = math.ldexp(1.0, self.soup.exponent)
        values, errors = [], []
        for q in self.new:
            w = q[3]
            for x in q[:3]:
                r = x / w
                numerator, denominator = r.as_integer_ratio()
                gap = abs(x * denominator - numerator * w)
                values.append(r)
                errors.append(0.0 if gap == 0 else math.nextafter(gap / (w * denominator), math.inf))
        shape = (-1, 3)
        return (np.array(values, dtype=np.float64).reshape(shape) * unit,
                np.array(errors, dtype=np.float64).reshape(shape) * unit)


# -- the cut in the compiled core ---------------------------------------------------------------

class _Compiled:
    """The cut stage run by the compiled core (``massprops/core/src/isect/arrange.c``).

    It decides every sign exactly or not at all: a face (or both faces of a
    pair) whose decisions its certified floating-point filter could not
    settle is handed back, and cut here by the exact rational path.

    Attributes
    ----------
    kind : ndarray, shape (p,), int8
        Per pair: 0 the faces do not cut each other, 1 a segment, 2 coplanar, -1 handed back.
    status : ndarray, shape (m,), int8
        Per face: 0 not cut, 1 cut by the core, 2 handed back.
    drop : ndarray, shape (m,), int8
        Per face cut by the core: the axis its projection drops.
    face, starts, corners : ndarray, int64
        Cell ``c`` belongs to face ``face[c]``; its corners are
        ``corners[starts[c]:starts[c + 1]]`` (turning as the face does): input
        vertices by index, ``n + k`` for ``points[k]``.
    inside : ndarray, shape (c, 6, 2), float64
        Points strictly inside each cell, on the axes after ``drop`` (NaN
        where none was certified): each is the point of the face's plane over
        these two coordinates, rebuilt exactly by :meth:`inner`.
    points, rounding : ndarray, shape (q, 3), float64
        The new corners rounded once, and a certified bound on each coordinate's rounding (the
        filter's; the kept ones are rounded again from their exact values where that bound exceeds a unit
        in the last place, in :func:`arrange`).
    definitions : ndarray, shape (q, 7), int64
        How each new corner is defined (kind, then vertices or faces, then the projection's axes).
    """

    def __init__(self, geometry, faces, pairs, cut=None, available=None):
        faces = np.ascontiguousarray(faces, dtype=np.int64)
        pairs = np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2)
        # (the threads the core may use, asked once: each stage takes them above its size)
        self.available = thread_count() if available is None else available
        self.threads = self.available if faces.shape[0] > _PARALLEL_ABOVE else 1
        if cut is None:
            cut = _extension().arrange(geometry.vertices, faces, pairs, self.threads)
        kind, status, drop, face, count, corners, inner, points, rounding, definitions = cut
        self.definitions = np.frombuffer(definitions, dtype=np.int64).reshape(-1, 7)
        self.kind = np.frombuffer(kind, dtype=np.int8)
        self.status = np.frombuffer(status, dtype=np.int8)
        self.drop = np.frombuffer(drop, dtype=np.int8)
        self.face = np.frombuffer(face, dtype=np.int64)
        self.starts = np.zeros(self.face.shape[0] + 1, dtype=np.int64)
        np.cumsum(np.frombuffer(count, dtype=np.int64), out=self.starts[1:])
        self.corners = np.frombuffer(corners, dtype=np.int64)
        self.inside = np.frombuffer(inner, dtype=np.float64).reshape(-1, 6, 2)
        self.points = np.frombuffer(points, dtype=np.float64).reshape(-1, 3)
        self.rounding = np.frombuffer(rounding, dtype=np.float64).reshape(-1, 3)

    def inner(self, soup, t, cell, attempt, i, j):
        """Inner point ``attempt`` of cell ``cell`` of face ``t`` (homogeneous integers, w > 0), or None.

        The point of the face's plane over the certified doubles (x, y) on
        axes i, j: ``n · q = d`` solved for the dropped coordinate, exactly.
        """
        x, y = self.inside[cell, attempt].tolist()
        if x != x or y != y:
            return None
        _, normal, offset = soup.plane(t)
        drop = 3 - i - j
        # x = a / b, y = c / e with b, e powers of two; on the soup's grid (unit 2**exponent) over one denominator
        (a, b), (c, e) = x.as_integer_ratio(), y.as_integer_ratio()
        denominator = max(b, e)
        a, c = a * (denominator // b), c * (denominator // e)
        if soup.exponent >= 0:
            denominator <<= soup.exponent
        else:
            a, c = a << -soup.exponent, c << -soup.exponent
        n_drop = normal[drop]
        p = [0, 0, 0]
        p[i], p[j] = a * n_drop, c * n_drop
        p[drop] = offset * denominator - normal[i] * a - normal[j] * c
        return _reduced(*p, n_drop * denominator)

    def label(self, soup, pieces, first_patch, labels, done):
        """Fill ``labels`` (and ``done``) where the compiled core settles the count: cells of the compiled cut
        (with the net weight of the faces in their plane that hold their inner point) and patches
        (``pieces``, a :class:`_Pieces`, from ``first_patch`` on)."""
        cells = self.face.shape[0]
        roots = [piece[0] for piece in pieces.rest[first_patch - cells:]]
        k = cells + len(roots)
        if not k:
            return
        faces = np.concatenate([self.face, np.array(roots, dtype=np.int64)]) if roots else self.face
        points = np.full((k, 2), math.nan)             # NaN: a patch's face, asked at its centroid
        points[:cells] = self.inside[:, 0]
        starts = np.zeros(k + 1, dtype=np.int64)
        partners = pieces.partners
        if partners:
            mine = [partners.get(t, ()) for t in self.face.tolist()]
            starts[1:cells + 1] = np.cumsum([len(p) for p in mine])
            starts[cells + 1:] = starts[cells]
            flat = np.fromiter((u for p in mine for u in p), dtype=np.int64, count=int(starts[-1]))
        else:
            flat = starts[:0]
        front, net, owned, status = _extension().labels(
            soup.scaled, soup.faces, np.ascontiguousarray(soup.weights, dtype=np.int64), faces, points, starts,
            flat, self.available if k * 64 > _PARALLEL_ABOVE else 1)
        answered = np.frombuffer(status, dtype=np.int8) == 0
        # query q is piece q for the compiled cells, piece first_patch + (q - cells) for the patches
        chosen = np.arange(k)
        chosen[cells:] += first_patch - cells
        chosen = chosen[answered]
        labels[chosen, 0] = np.frombuffer(front, dtype=np.int64)[answered]
        labels[chosen, 1] = np.frombuffer(net, dtype=np.int64)[answered]
        labels[chosen, 2] = np.frombuffer(owned, dtype=np.int8)[answered] != 0
        done[chosen] = True

    def fans(self, cells, outward):
        """Triangles (k, 3) fanning the cells chosen (ascending), reversed where not ``outward`` (a cell turned
        inward is fanned from its last corner, as the exact path's reversed polygon)."""
        triangles = _extension().fans(self.starts, self.corners, np.ascontiguousarray(cells, dtype=np.int64),
                                      np.ascontiguousarray(outward, dtype=bool).view(np.uint8))
        return np.frombuffer(triangles, dtype=np.int64).reshape(-1, 3)


# -- the arrangement -----------------------------------------------------------------------------

def _ray(normal):
    """``(axis, sigma)``: the ray for a query on a plane of ``normal``: along the axis it leans on least."""
    axis = min(range(3), key=lambda k: abs(normal[k]))
    a1, a2 = (axis + 1) % 3, (axis + 2) % 3
    return axis, _sign(normal[a1]) or _sign(normal[a2])


_TRIES = ((1, 1, 1), (1, 2, 3), (3, 1, 2), (2, 3, 1), (1, 3, 7), (5, 1, 2))


def _label_cells(soup, pieces, compiled=None, first_patch=None):
    """``(w in front, net weight on the piece, owned)`` (k, 3) for each piece ``(t, cell, normal, partners, i, j)``.

    ``cell`` is a list of homogeneous corners (its inner points are weighted
    means of three of them), or the number of a cell of ``compiled`` (a
    :class:`_Compiled`, which gives its cells' inner points); pieces from
    ``first_patch`` on are whole faces of patches.  With ``compiled``, the
    compiled core counts first (:meth:`_Compiled.label`); what it hands back
    is counted here.  All pieces' rays are counted together
    (:meth:`_Soup.windings`); a piece whose inner point lies on another face
    is asked again at another inner point.
    """
    labels = np.zeros((len(pieces), 3), dtype=np.int64)
    done = np.zeros(len(pieces), dtype=bool)
    if compiled is not None:
        compiled.label(soup, pieces, first_patch, labels, done)
    pending = np.flatnonzero(~done).tolist()
    for attempt, weights in enumerate(_TRIES):
        if not pending:
            break
        queries, nets, asked = [], [], []
        for k in pending:
            t, cell, normal, partners, i, j = pieces[k]
            if normal is None:
                corners, normal, _ = soup.plane(t)
                if cell is None:
                    cell = [(*q, 1) for q in corners]
            p = _inner_point(cell, weights) if isinstance(cell, list) else compiled.inner(soup, t, cell, attempt, i, j)
            if p is None:
                continue
            asked.append(k)
            net, owned = int(soup.weights[t]), True
            for u in partners:
                corners_u, normal_u, _ = soup.plane(u)
                if _contains(corners_u, p, i, j):
                    net += int(soup.weights[u]) * _sign(_dot(normal_u, normal))
                    owned = owned and u > t
            queries.append((p, *_ray(normal), normal))
            nets.append((net, owned))
        fronts = soup.windings(queries)
        for k, front, (net, owned) in zip(asked, fronts, nets):
            if front is not None:
                labels[k] = (front, net, owned)
                done[k] = True
        pending = [k for k in pending if not done[k]]
    if pending:
        raise ArrangementError(f"{len(pending)} pieces of crossing faces lie on other faces at every point tried",
                               fix="report this mesh: the arrangement could not label it")
    return labels


class _Pieces:
    """The pieces to label, in order: the compiled cut's cells (piece k is cell k; as a tuple
    ``(t, cell, normal, partners, i, j)`` only when the exact path asks for it, normal None: the exact
    normal is made then), then the exact path's cells and the patches' faces (``rest``)."""

    def __init__(self, compiled, partners):
        self.compiled, self.partners = compiled, partners
        self.cells = 0 if compiled is None else compiled.face.shape[0]
        self.rest = []

    def __len__(self):
        return self.cells + len(self.rest)

    def __getitem__(self, k):
        if k >= self.cells:
            return self.rest[k - self.cells]
        t = int(self.compiled.face[k])
        drop = int(self.compiled.drop[t])
        return (t, k, None, self.partners.get(t, ()), (drop + 1) % 3, (drop + 2) % 3)

    def extend(self, items):
        self.rest.extend(items)


def _patches(faces, cut, n):
    """Groups of uncut faces joined across edges that exactly two faces use, once each way: a label per face
    (the group's lowest face; a cut face is labelled by itself), and the groups' labels (ascending); the
    faces' vertices are below ``n``."""
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    labels, roots = _extension().patches(faces, np.ascontiguousarray(cut, dtype=bool).view(np.uint8), n)
    return np.frombuffer(labels, dtype=np.int64), np.frombuffer(roots, dtype=np.int64)


def _all_at_once(geometry, faces, weights, pairs, available):
    """The arrangement in one compiled call (isect/resolve.c: the steps of :func:`arrange`, in the same order,
    with the same answer bit for bit) when the compiled core settles every face and piece; else its cut (as
    :class:`_Compiled` takes it), for the steps in :func:`arrange` to go on from, or None (make the cut there).
    The threads are the steps' own (``available`` above ``_PARALLEL_ABOVE`` faces, or rays times 64)."""
    done = _extension().resolve(geometry.vertices, faces, weights, pairs,
                                available if faces.shape[0] > _PARALLEL_ABOVE else 1, available, _PARALLEL_ABOVE)
    if len(done) != 4:
        return done
    out, pieces, rows, negative = done
    rows = np.frombuffer(rows, dtype=np.float64).reshape(-1, 6)
    return Arrangement(np.frombuffer(out, dtype=np.int64).reshape(-1, 3),
                       np.frombuffer(pieces, dtype=np.int64).reshape(-1, 3), rows[:, :3].copy(), rows[:, 3:].copy(),
                       negative)


def arrange(geometry, faces, weights, pairs, *, compiled=True):
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
    compiled : bool
        Cut the faces in the compiled core (:class:`_Compiled`), which hands
        back what its filter cannot decide; False cuts every face with the
        exact rational path here (the reference).

    Returns
    -------
    Arrangement
    """
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    m = faces.shape[0]
    pairs = np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2)
    if compiled:
        available = thread_count()
        weights = np.ascontiguousarray(weights, dtype=np.int64)
        done = _all_at_once(geometry, faces, weights, pairs, available)
        if isinstance(done, Arrangement):
            return done
        compiled = _Compiled(geometry, faces, pairs, done, available)
    else:
        compiled = None
    soup = _Soup(geometry, faces, weights)
    back = np.ones(m, dtype=bool) if compiled is None else compiled.status == 2
    segments = {}
    partners = {}
    if compiled is not None:
        for t, u in pairs[compiled.kind == 2].tolist():
            partners.setdefault(t, []).append(u)
            partners.setdefault(u, []).append(t)
        if back.any():
            exact = pairs[back[pairs[:, 0]] | back[pairs[:, 1]]]
            unsure = set(map(tuple, pairs[compiled.kind == -1].tolist()))
        else:
            exact, unsure = pairs[:0], set()
    else:
        exact, unsure = pairs, None
    for t, u in exact.tolist():
        segment, coplanar = _crossing(soup, t, u)
        if coplanar:
            if unsure is None or (t, u) in unsure:
                partners.setdefault(t, []).append(u)
                partners.setdefault(u, []).append(t)
            for x, y in ((t, u), (u, t)):
                if back[x]:
                    corners = soup.plane(y)[0]
                    segments.setdefault(x, []).extend(((*corners[k], 1), (*corners[(k + 1) % 3], 1))
                                                      for k in range(3))
        elif segment is not None:
            for x in (t, u):
                if back[x]:
                    segments.setdefault(x, []).append(segment)
    cut = np.zeros(m, dtype=bool) if compiled is None else compiled.status == 1
    cut[list(segments)] = True
    pieces = _Pieces(compiled, partners)
    for t, its_segments in segments.items():
        corners, normal, _ = soup.plane(t)
        cells, (i, j) = _cells(corners, its_segments, normal)
        pieces.extend((t, cell, normal, partners.get(t, ()), i, j) for cell in cells)
    n_cells = len(pieces)
    # one piece per patch: a whole face (cell None: its corners), asked at its centroid first; a patch is
    # labelled by its lowest face
    patch, roots = _patches(faces, cut, soup.scaled.shape[0])
    pieces.extend((t, None, None, (), 0, 1) for t in roots.tolist())
    labels = _label_cells(soup, pieces, compiled, n_cells)
    front, behind, owned = labels[:, 0], labels[:, 0] + labels[:, 1], labels[:, 2].astype(bool)
    negative = bool(np.any(front < 0) or np.any(behind < 0))
    bounding = (front > 0) != (behind > 0)
    kept_corners = _Corners(soup, 0 if compiled is None else compiled.points.shape[0])
    triangles = []
    keep = np.flatnonzero((bounding & owned)[:n_cells])
    outward = behind > 0
    # the compiled cells are the first pieces, piece k being cell k; the exact path's follow
    fanned = keep[:np.searchsorted(keep, 0 if compiled is None else compiled.face.shape[0])]
    for k in keep[fanned.size:].tolist():
        kept_corners.add_polygon(pieces[k][1], triangles, bool(outward[k]))
    triangles = [np.array(triangles, dtype=np.int64).reshape(-1, 3)]
    if fanned.size:
        triangles.append(compiled.fans(fanned, outward[fanned]))
    out = np.zeros((0, 3), dtype=np.int64)
    if roots.size:
        # each face takes its patch's side: +1 kept as it is, -1 turned (after those kept), 0 (and every cut
        # face) left out
        side = np.zeros(m, dtype=np.int8)
        side[roots] = np.where(bounding[n_cells:], np.where(behind[n_cells:] > 0, 1, -1), 0)
        out = np.frombuffer(_extension().patch_faces(faces, patch, side), dtype=np.int64).reshape(-1, 3)
    # (a copy where the fans alone are the pieces: their new corners are renumbered in place below)
    pieces = np.vstack(triangles) if len(triangles) > 1 else triangles[0].copy()
    points, rounding = kept_corners.points()
    # the new corners the kept pieces use (the compiled core's first, numbered ahead of the exact path's), each
    # with its rounding bound: the compiled core's rounded again from their exact values (with exact
    # expansions) where the filter's bound exceeds a unit in the last place (an exact rounding is within half
    # of one; most intersections of an edge with a plane are already within one); one for points that round
    # alike with the same bound, in lexicographic order (as np.unique(table, axis=0)); the pieces' new corners
    # renumbered to them
    if compiled is None:
        mine = (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 7), dtype=np.int64), 1)
    else:
        mine = (compiled.points, compiled.rounding, compiled.definitions, compiled.threads)
    rows = _extension().kept_corners(soup.scaled, faces, pieces, *mine[:3], np.ascontiguousarray(points),
                                     np.ascontiguousarray(rounding), mine[3])
    rows = np.frombuffer(rows, dtype=np.float64).reshape(-1, 6)
    return Arrangement(out, pieces, rows[:, :3].copy(), rows[:, 3:].copy(), negative)
