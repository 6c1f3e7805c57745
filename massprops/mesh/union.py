"""The union of shells that intersect, through manifold3d, checked and bounded.

manifold3d computes the union in floating point: the vertices where
surfaces cross are rounded, and it may re-triangulate.  Its result is not
trusted as it comes:

1. Every output triangle carries the index of the original triangle it came
   from (manifold's face IDs, which we set to the original face numbers).
2. Every new vertex is placed exactly, in rationals, from the original
   coordinates: it lies in the planes of all original triangles its output
   triangles came from.  Where three of those planes are independent it is
   a corner of the union, their common point, rounded once.  Where they span
   only a line (a point along a crease) or a plane (a point inside a flat
   fan), its position along that line or in that plane changes no integral:
   the exact surface has it at the nearest point there, and manifold's
   vertex is kept.
3. The union surface with the exact vertices is checked: closed and
   consistently wound (every edge once each way), every output triangle in
   the plane of its original triangle and wound the same way, and its
   corners (original vertices, union corners) inside that triangle.  A failed
   check refuses the file with a one-line reason.
4. The vertices integrated are off their exact places by ``δ_v`` (rounding,
   or manifold's distance from the crease or plane): that sweeps at most
   ``δ_v · ΣA/3`` of volume (ΣA the areas of the triangles around it,
   enlarged for the other moved vertices).  The sum is the ``swept_volume``
   the caller adds to the error bounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from ..errors import MeshGeometryError
from .solid import swept_volume
from ..core.topology import edge_balance

__all__ = ["United", "unite_shells"]


@dataclass(frozen=True)
class United:
    """A union of shells: its faces over the old vertices and ``new_vertices`` (numbered from ``offset``)."""

    faces: np.ndarray
    new_vertices: np.ndarray
    swept_volume: float
    volume: float


def _manifold(path, count):
    try:
        import manifold3d
    except ImportError:
        raise MeshGeometryError(f"{count} shells intersect; their union needs manifold3d", path=path,
                                fix="pip install manifold3d") from None
    return manifold3d


def _refuse(reason, unit, path):
    raise MeshGeometryError(f"shells {', '.join(map(str, unit))} intersect and their union could not be "
                            f"verified ({reason})", path=path,
                            fix="unite the bodies in a modeller, or export them as separate files")


def unite_shells(vertices, faces, labels, unit, *, offset, path=None):
    """The union of the shells ``unit`` (each closed, outward, free of self-intersections).

    Parameters
    ----------
    vertices : ndarray, shape (n, 3), float64
    faces : ndarray, shape (m, 3), int
    labels : ndarray, shape (m,)
        Shell of each face.
    unit : list of int
        The shells to unite.
    offset : int
        Index the first new vertex will have in the caller's vertex array.

    Returns
    -------
    United
    """
    manifold3d = _manifold(path, len(unit))
    parts = []
    for shell in unit:
        ids = np.flatnonzero(labels == shell)
        used, local = np.unique(faces[ids], return_inverse=True)
        mesh = manifold3d.Mesh64(vert_properties=np.ascontiguousarray(vertices[used], dtype=np.float64),
                                 tri_verts=np.ascontiguousarray(local.reshape(-1, 3), dtype=np.uint64),
                                 face_id=np.ascontiguousarray(ids, dtype=np.uint64))
        part = manifold3d.Manifold(mesh)
        if part.status() != manifold3d.Error.NoError:
            _refuse(f"manifold3d rejects shell {shell}: {part.status().name}", unit, path)
        parts.append(part)
    result = manifold3d.Manifold.batch_boolean(parts, manifold3d.OpType.Add)
    if result.status() != manifold3d.Error.NoError:
        _refuse(f"manifold3d: {result.status().name}", unit, path)
    out = result.to_mesh64()
    out_vertices = np.asarray(out.vert_properties, dtype=np.float64)[:, :3]
    out_faces = np.asarray(out.tri_verts, dtype=np.int64).reshape(-1, 3)
    origin = np.asarray(out.face_id, dtype=np.int64)
    if out_faces.shape[0] == 0 or origin.shape[0] != out_faces.shape[0] or origin.max() >= faces.shape[0] \
            or origin.min() < 0 or not np.all(np.isin(labels[origin], unit)):
        _refuse("its faces do not map to the original triangles", unit, path)
    return _checked_union(vertices, faces, unit, out_vertices, out_faces, origin, offset, float(result.volume()),
                          path)


def _checked_union(vertices, faces, unit, out_vertices, out_faces, origin, offset, volume, path):
    """Map manifold's output onto exact vertices, verify it, and bound the rounding."""
    used = np.unique(faces[origin])
    index = {tuple(v): int(i) for i, v in zip(used.tolist(), vertices[used].tolist())}
    mapped = np.array([index.get(tuple(v), -1) for v in out_vertices.tolist()], dtype=np.int64)
    new = np.flatnonzero(mapped < 0)
    grid = _Grid(vertices, used, out_vertices)
    around = _incident(out_faces, out_vertices.shape[0])
    exact, corners = {}, set()
    rounded = np.zeros((new.size, 3))
    moved = np.zeros(new.size)
    size = float(np.max(np.ptp(vertices[used], axis=0)))
    for k, v in enumerate(new.tolist()):
        point, corner = _exact_vertex(grid, faces, np.unique(origin[around[v]]), v)
        if point is None:
            _refuse(f"a new vertex near {out_vertices[v].tolist()} is on no intersection of the original "
                    "triangles", unit, path)
        rounded[k] = grid.rounded(point) if corner else out_vertices[v]
        if float(np.max(np.abs(rounded[k] - out_vertices[v]))) > 1e-6 * size:
            _refuse(f"a new vertex is {float(np.max(np.abs(rounded[k] - out_vertices[v]))):.3g} from the "
                    "exact intersection", unit, path)
        exact[v] = point
        if corner:
            corners.add(v)
        moved[k] = grid.distance_up(point, rounded[k])
    mapped[new] = vertices.shape[0] + np.arange(new.size)       # numbered after the old vertices, for now
    united = mapped[out_faces]
    approx = (np.vstack([vertices, rounded]).tolist(), np.concatenate([np.zeros(vertices.shape[0]), moved]).tolist())
    moves, defect = _verify(grid, faces, out_faces, united, origin, exact, corners, approx, unit, path)
    shifted = np.zeros(vertices.shape[0] + new.size)
    shifted[mapped[new]] = moved
    for vertex, outside in moves.items():
        shifted[vertex] += outside
    touched = np.flatnonzero(shifted)
    swept = swept_volume(np.vstack([vertices, rounded]), united, touched, shifted[touched]) + defect
    united[united >= vertices.shape[0]] += offset - vertices.shape[0]
    return United(united, rounded, swept, volume)


def _incident(out_faces, n):
    """For each output vertex, the output triangles around it (list of arrays)."""
    corner_face = np.repeat(np.arange(out_faces.shape[0]), 3)
    order = np.argsort(out_faces.ravel(), kind="stable")
    bounds = np.searchsorted(out_faces.ravel()[order], np.arange(n + 1))
    return [corner_face[order[bounds[v]:bounds[v + 1]]] for v in range(n)]


class _Grid:
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


def _on_plane(plane, point):
    (normal, offset), (x, d) = plane, point
    return _dot(normal, x) == offset * d


def _exact_vertex(grid, faces, origins, v):
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
    if not all(_on_plane(plane, point) for plane in planes):
        return None, False
    return point, corner


def _projection(point, planes):
    """The point nearest to ``point`` on the intersection of one or two independent planes."""
    (x, one), (n1, d1) = point, planes[0]
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


def _verify(grid, faces, out_faces, united, origin, exact, corners, approx, unit, path):
    """Closed and consistently wound; each output triangle in its original one's plane, wound alike, with its
    corners (original vertices and union corners) inside that triangle.

    manifold's float decisions can leave a corner outside its face, or a
    sliver wound backwards, by amounts of the order of the coordinates'
    rounding.  Those are bounded, not refused: a corner ``ε`` outside is a
    vertex moved by ``ε`` (returned per vertex), a backward sliver of area
    ``a`` changes any integral by at most that of a cone ``2 a · size / 3``
    (returned as a volume).  Anything beyond :data:`_SLACK` of the part's
    size is refused.  Signs are decided in floats where a certified margin
    allows (:class:`_Filter`), else in integers.

    Returns
    -------
    moves : dict {united vertex: ε}, defect : float (mesh units³)
    """
    uses, balance = edge_balance(united, int(united.max()) + 1)
    if np.any(balance) or np.any(uses % 2):
        _refuse("the result is not a closed, consistently wound surface", unit, path)
    own = faces[origin]
    unchanged = np.zeros(united.shape[0], dtype=bool)
    for turn in range(3):
        unchanged |= np.all(united == np.roll(own, turn, axis=1), axis=1)
    moves, defect, size = {}, 0.0, grid.size
    for t in np.flatnonzero(~unchanged).tolist():
        face = faces[origin[t]].tolist()
        plane = grid.plane(face)
        signs = _Filter(approx, face, plane[0])
        points = [exact[o] if o in exact else grid.original(u)
                  for o, u in zip(out_faces[t].tolist(), united[t].tolist())]
        for o, u, point in zip(out_faces[t].tolist(), united[t].tolist(), points):
            if (o in exact and o not in corners) or (o not in exact and u in face):
                continue       # free along its crease or fan (on its planes by construction); a corner of the face
            if o not in exact and not _on_plane(plane, point):
                _refuse(f"a triangle from original face {int(origin[t])} leaves its plane", unit, path)
            if signs.inside(u):
                continue
            outside = grid.outside(point, [grid.original(i)[0] for i in face], plane[0])
            if outside > _SLACK * size:
                _refuse(f"a triangle from original face {int(origin[t])} leaves that face", unit, path)
            if outside:
                moves[u] = max(moves.get(u, 0.0), outside)
        if signs.wound_along(united[t].tolist()):
            continue
        area = grid.signed_area(points, plane[0])
        if area < 0:
            if -area > _SLACK * size * size:
                _refuse(f"a triangle from original face {int(origin[t])} is wound against it", unit, path)
            defect += 2.0 * -area * size / 3.0
    return moves, defect


class _Filter:
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
        bound = (24 * _U * l1 * l2 + 2 * sum(moved) * (l1 + l2) + 4 * max(moved) ** 2) * (1 + 1e-9)
        return _dot(_cross(e1, e2), self.normal) > bound


_U = 2.0 ** -53


# What manifold's float decisions may leave, relative to the part's size (lengths; areas its square).
_SLACK = 1e-9
