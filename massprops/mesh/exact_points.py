"""Exact places of a union's vertices, and exact signs about them, for :mod:`massprops.mesh.union`.

Coordinates become Python integers on one power-of-two grid (every float
is an integer multiple of the smallest power of two among them), so planes,
their intersections and every sign test are exact; a float filter with a
certified margin decides the clear cases first.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

__all__ = ["Grid", "SignFilter", "exact_vertex", "on_plane"]

_U = 2.0 ** -53


class Grid:
    """Coordinates as Python integers on one power-of-two grid, so every test below is exact and fast.

    Points are homogeneous: ``(X, D)`` is the point ``X / D · 2**exponent``
    with integers ``X`` (3) and ``D > 0``; original and output vertices have ``D = 1``.
    """

    def __init__(self, vertices, used, out_vertices):
        self.size = float(np.max(np.ptp(vertices[used], axis=0))) * math.sqrt(3.0)     # ≥ the box's diagonal
        values = np.concatenate([vertices[used].ravel(), out_vertices.ravel()])
        mantissa, exponent = np.frexp(values[values != 0])
        self.exponent = int(exponent.min()) - 53 if exponent.size else 0
        self._original = dict(zip(used.tolist(), self._ints(vertices[used])))
        self._out = self._ints(out_vertices)
        self._planes = {}

    def _ints(self, points):
        mantissa, exponent = np.frexp(np.asarray(points, dtype=np.float64))
        whole = (mantissa * 2.0 ** 53).astype(np.int64).astype(object)
        shift = np.where(mantissa == 0, 0, exponent.astype(np.int64) - 53 - self.exponent).astype(object)
        return [tuple(int(m) << int(e) for m, e in zip(row_m, row_e)) for row_m, row_e in zip(whole, shift)]

    def original(self, i):
        return (self._original[int(i)], 1)

    def output(self, v):
        return (self._out[int(v)], 1)

    def plane(self, face):
        """Normal and offset of an original triangle's plane: n · x = d (integers)."""
        key = tuple(int(i) for i in face)
        if key not in self._planes:
            a, b, c = (self._original[i] for i in key)
            normal = _cross(_sub(b, a), _sub(c, a))
            self._planes[key] = (normal, _dot(normal, a))
        return self._planes[key]

    def rounded(self, point):
        """The nearest floats to a homogeneous point (correctly rounded, through Fraction)."""
        (x, d), e = point, self.exponent
        return [float(Fraction(c * 2 ** max(e, 0), d * 2 ** max(-e, 0))) for c in x]

    def outside(self, point, triangle, normal):
        """How far a point of the triangle's plane lies outside it, an upper bound (0 inside), mesh units."""
        (x, d), worst = point, Fraction(0)
        for p, q in ((triangle[0], triangle[1]), (triangle[1], triangle[2]), (triangle[2], triangle[0])):
            side = _dot(_cross(_sub(q, p), _sub(x, _scaled(p, d))), normal)
            if side < 0:
                edge = _sub(q, p)
                # distance² = (side / d)² / (|n|² |q − p|²), grid units²
                worst = max(worst, Fraction(side * side, d * d * _dot(normal, normal) * _dot(edge, edge)))
        return self._length_up(worst)

    def signed_area(self, points, normal):
        """The area of a triangle of homogeneous points wound against ``normal``, negative, mesh units² (rounded
        away from zero); 0 for a triangle wound along it."""
        (x0, d0), (x1, d1), (x2, d2) = points
        y0, y1, y2 = _scaled(x0, d1 * d2), _scaled(x1, d0 * d2), _scaled(x2, d0 * d1)
        along = _dot(_cross(_sub(y1, y0), _sub(y2, y0)), normal)
        if along >= 0:
            return 0.0                               # wound like its face (only the backward ones matter)
        # area² = along² / (4 (d0 d1 d2)⁴ |n|²), grid units⁴
        squared = Fraction(along * along, 4 * (d0 * d1 * d2) ** 4 * _dot(normal, normal))
        return -self._length_up(squared, power=2)

    def _length_up(self, squared, power=1):
        """``sqrt(squared)`` in mesh units (a length, or an area with ``power=2``) rounded up; 0 for 0."""
        if squared == 0:
            return 0.0
        value = squared * Fraction(2) ** (2 * power * self.exponent)
        return math.sqrt(float(value)) * (1 + 1e-12) + 2.0 ** -1070

    def distance_up(self, point, floats):
        """An upper bound on the distance between a homogeneous point and floats (mesh units)."""
        (x, d), e = point, self.exponent
        scale = Fraction(2) ** e
        squared = sum((Fraction(c, d) * scale - Fraction(float(f))) ** 2 for c, f in zip(x, floats))
        return math.sqrt(float(squared)) * (1 + 2.0 ** -48) + 2.0 ** -1070


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _scaled(a, k):
    return (a[0] * k, a[1] * k, a[2] * k)


def on_plane(plane, point):
    (normal, offset), (x, d) = plane, point
    return _dot(normal, x) == offset * d


def exact_vertex(grid, faces, origins, v):
    """Where new output vertex ``v`` belongs, exactly: ``(homogeneous point, is_corner)``, or ``(None, False)``.

    The planes of the original triangles ``origins`` around it meet in a
    point (three independent planes): that point, a corner of the union,
    exactly.  Two independent planes meet in a line along which the vertex is
    a collinear point of a crease, and one plane holds a flat fan: moving the
    vertex along that line or in that plane changes no integral, so the exact
    surface has it at the nearest point of the line or plane, manifold's
    vertex projected (only its distance from there counts).
    """
    planes = [grid.plane(faces[f]) for f in origins.tolist()]
    independent = []
    for normal, offset in planes:
        trial = independent + [(normal, offset)]
        if _rank([n for n, _ in trial]) == len(trial):
            independent = trial
        if len(independent) == 3:
            break
    if len(independent) == 3:
        point, corner = _three_planes(*independent), True
    elif independent:
        point, corner = _projection(grid.output(v), independent), False
    else:
        return None, False
    if not all(on_plane(plane, point) for plane in planes):
        return None, False
    return point, corner


def _projection(point, planes):
    """The point nearest to ``point`` on the intersection of one or two independent planes."""
    (x, _), (n1, d1) = point, planes[0]
    if len(planes) == 1:
        g = _dot(n1, n1)
        return (tuple(x[k] * g + (d1 - _dot(n1, x)) * n1[k] for k in range(3)), g)
    n2, d2 = planes[1]
    # x + a n1 + b n2 on both planes: a 2×2 system in a, b (Gram matrix, positive determinant).
    g11, g12, g22 = _dot(n1, n1), _dot(n1, n2), _dot(n2, n2)
    r1, r2 = d1 - _dot(n1, x), d2 - _dot(n2, x)
    det = g11 * g22 - g12 * g12
    a, b = r1 * g22 - r2 * g12, r2 * g11 - r1 * g12
    return (tuple(x[k] * det + a * n1[k] + b * n2[k] for k in range(3)), det)


def _rank(normals):
    if len(normals) == 1:
        return int(any(normals[0]))
    if len(normals) == 2:
        return 2 if any(_cross(normals[0], normals[1])) else 1
    return 3 if _dot(normals[0], _cross(normals[1], normals[2])) != 0 else 2


def _three_planes(p1, p2, p3):
    (n1, d1), (n2, d2), (n3, d3) = p1, p2, p3
    c23, c31, c12 = _cross(n2, n3), _cross(n3, n1), _cross(n1, n2)
    det = _dot(n1, c23)
    sign = 1 if det > 0 else -1
    return (tuple(sign * (d1 * c23[k] + d2 * c31[k] + d3 * c12[k]) for k in range(3)), sign * det)


class SignFilter:
    """Signs decided in floats with a certified margin, for one original face.

    ``approx`` holds each vertex's float coordinates and how far (at most)
    the exact point is from them (Python lists: the arithmetic here is on a
    few numbers at a time).  The face's unit normal comes from its exact
    integer normal, rounded (relative error a few u).  A sign is given only
    when the float value clears its bound: rounding of the products (24 u of
    the operands' sizes, generous) plus what the vertices' distances from
    their exact places can change.
    """

    def __init__(self, approx, face, normal):
        self.points, self.moved = approx
        shift = max(max(abs(c).bit_length() for c in normal) - 60, 0)
        unit = [float(c >> shift) for c in normal]
        length = math.sqrt(_dot(unit, unit))
        self.normal = [c / length for c in unit]
        self.face = [self.points[i] for i in face]

    def inside(self, vertex):
        """True when the vertex is certainly strictly inside the face (on the inner side of each edge)."""
        x, slack = self.points[vertex], self.moved[vertex]
        a, b, c = self.face
        for p, q in ((a, b), (b, c), (c, a)):
            edge, arm = _sub(q, p), _sub(x, p)
            span = math.sqrt(_dot(edge, edge))
            bound = 24 * _U * span * math.sqrt(_dot(arm, arm)) + slack * span * (1 + 1e-9)
            if not _dot(_cross(edge, arm), self.normal) > bound:
                return False
        return True

    def wound_along(self, triangle):
        """True when the triangle is certainly wound along the face's normal."""
        a, b, c = (self.points[i] for i in triangle)
        e1, e2 = _sub(b, a), _sub(c, a)
        l1, l2 = math.sqrt(_dot(e1, e1)), math.sqrt(_dot(e2, e2))
        moved = [self.moved[i] for i in triangle]
        bound = (24 * _U * l1 * l2 + 2 * sum(moved) * (l1 + l2) + 4 * max(moved) * max(moved)) * (1 + 1e-9)
        return _dot(_cross(e1, e2), self.normal) > bound
